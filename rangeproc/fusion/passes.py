"""One filter + smoother pass of the centralised estimator over a span's epochs.

:func:`run_pass` runs the configured forward filter (EKF/UKF, with the adaptive,
strong-tracking, constrained or spline options, or the IMM) and its smoother once, from a
given start and process noise, optionally linearised at a previous smoothed track, and
returns the smoothed track with every row's gate result and smoothed residual
(:class:`PassResult`). ``fusion.centralised`` strings the passes together (start, process
noise, refinement, registration).
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from rangeproc.errors import NumericalError
from rangeproc.estimation.fading import fading_params
from rangeproc.estimation.forward import (
    EKF,
    UKF,
    FilterPrior,
    FilterSettings,
    run_filter,
)
from rangeproc.estimation.imm import IMMOutput
from rangeproc.estimation.imm_smoother import imm_smooth
from rangeproc.estimation.linalg import unpack
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.estimation.rts import rts_smooth
from rangeproc.estimation.spline_filter import spline_params
from rangeproc.fusion.batch import MeasurementBatch

log = logging.getLogger(__name__)

#: Relative weight below which a model pair (or a model) is left out of the IMM smoother
#: (``estimation.imm_smoother``): a pair carrying under 5 % of its model's smoothing weight
#: moves that model's smoothed mean by under 5 % of the pairs' difference, itself small over
#: one step (on a straight-turn-straight flight the smoothed RMSE is 2 % above 1 % pruning's,
#: still 8 % under the CA smoother's); it halves the smoother's cost against 1 %.
IMM_PRUNE = 5e-2
#: Variance factor on the first pass's smoothed first-epoch acceleration covariance that
#: starts the IMM's refinement passes (``imm_start``).
IMM_START_WIDENING = 10.0
def component_use(z: np.ndarray, rejected: np.ndarray) -> np.ndarray:
    """(N, 6) bool: component measured and not rejected by the gate (bit mask ``rejected``)."""
    m = z.shape[1]
    if m <= 8:                 # the bits tested are the low byte's (a cast keeps it): bytes
        low = rejected.astype(np.uint8)[:, None]
        return np.isfinite(z) & ((low & (np.uint8(1) << np.arange(m, dtype=np.uint8))) == 0)
    bits = (rejected[:, None] >> np.arange(m)[None, :]) & 1
    return np.isfinite(z) & (bits == 0)


class PassResult(NamedTuple):
    """One filter + smoother pass: smoothed ``xs`` (E, n), packed ``Ps`` (E, n(n+1)/2; empty
    (0, 0) once let go, :func:`without_covariances`); ``em`` (E,) the EM
    process-noise statistic (None for the IMM, whose models carry their own dynamics); per row
    ``nis``, ``dof``, ``used`` (N, 6), ``res``, ``hph`` (N, 6); divergence-guard ``resets``;
    the ``batch`` with the sigmas used; ``model_prob`` (E, r) the IMM's smoothed model
    probabilities (None otherwise); ``knots`` the spline filter's anomaly times (s; empty
    for the other filters)."""

    xs: np.ndarray
    Ps: np.ndarray
    em: np.ndarray | None
    nis: np.ndarray
    dof: np.ndarray
    used: np.ndarray
    res: np.ndarray
    hph: np.ndarray
    resets: int
    batch: MeasurementBatch
    model_prob: np.ndarray | None = None
    knots: np.ndarray | None = None


class GateResult(NamedTuple):
    """A forward filter's per-row gate results: ``nis``, ``dof``, ``rejected`` bit masks (N,)
    and the divergence guard's ``n_resets`` (of ``FilterOutput`` or ``IMMOutput``)."""

    nis: np.ndarray
    dof: np.ndarray
    rejected: np.ndarray
    n_resets: int


def run_pass(batch: MeasurementBatch, epoch_t, meas_epoch, x0, P0, q, gate, st, x_lin,
             maneuver_norm: float = 0.0) -> PassResult:
    """One filter + smoother pass with settings ``st`` (``EstimatorSettings``: its forward
    filter ``st.family``, the ``[processing]`` values by name); returns the smoothed track,
    gate results and residuals. The forward filter's output type, as its family declares it
    (``rangeproc.families``), picks the smoother: Kim's for the IMM's, the RTS otherwise."""
    settings = filter_settings(st, gate, maneuver_norm)
    model_prob = None
    try:
        fwd = run_filter(batch.filter_rows(epoch_t, meas_epoch),
                         FilterPrior(x0, P0, q, x_lin if len(x_lin) == len(epoch_t) else None),
                         settings)
        gates = GateResult(fwd.nis, fwd.dof, fwd.rejected, fwd.n_resets)
        if isinstance(fwd, IMMOutput):
            codes, lam = settings.imm
            xs, Ps, model_prob = imm_smooth(epoch_t, fwd.xm, fwd.Pm, fwd.mu, fwd.omega, q,
                                            codes, lam, IMM_PRUNE)
            em, sigma_used, knot = None, np.zeros((0, 6)), np.zeros(0, dtype=bool)
        else:
            sigma_used, knot, fade = fwd.sigma_used, fwd.knot, fwd.fade
            if "anomaly" in st.family.family.adds:
                log.info("spline filter: %d anomaly knots", int(knot.sum()))
            elif "fading" in st.family.family.adds:
                faded = fade.max(axis=1) > 1.0
                log.info("strong tracking: %d of %d epochs faded (largest factor %.3g)",
                         int(faded.sum()), len(faded), float(fade.max()))
            xs, Ps, em = rts_smooth(epoch_t, fwd.xf, fwd.Pf, q, True, True,  # in place
                                    fade if fade.shape[0] else None,
                                    fwd.jerk if fwd.jerk.shape[0] else None)
        del fwd                                  # its likelihood rows are not needed
    except FloatingPointError as exc:
        raise NumericalError(f"estimator failed: {exc}") from exc
    if not np.isfinite(xs).all():
        raise NumericalError("estimator failed: non-finite smoothed state")
    res, hph = smoothed_residuals(meas_epoch, batch.model, batch.z, batch.s, batch.sv,
                                  batch.Qr, xs, Ps)
    if sigma_used.shape[0]:                  # adapted in the filter: report what it used
        batch = batch.with_sigma(np.where(np.isfinite(sigma_used), sigma_used, batch.sigma))
    return PassResult(xs, Ps, em, gates.nis, gates.dof, component_use(batch.z, gates.rejected),
                      res, hph, gates.n_resets, batch, model_prob,
                      epoch_t[knot] if knot.shape[0] else epoch_t[:0])


def filter_settings(st, gate: np.ndarray, maneuver_norm: float = 0.0) -> FilterSettings:
    """The forward filter's settings of a pass with estimator settings ``st``
    (``EstimatorSettings``): its family's update and declared parameters (the
    ``[processing]`` keys ``rangeproc.families`` names), the gate, the guard."""
    chosen, p = st.family, st.processing
    adds = chosen.family.adds
    imm = None
    if "models" in adds:
        imm = (np.asarray(chosen.imm_models, dtype=np.int64),
               imm_generator(len(chosen.imm_models), p.imm_sojourn))
    return FilterSettings(
        gate, method=UKF if chosen.family.update == "ukf" else EKF, ukf=tuple(st.ukf),
        reset_after=st.reset_after, reset_inflation=st.reset_inflation,
        adapt_window=p.sage_husa_window if "adaptive-noise" in adds else 0,
        adapt_mean=p.sage_husa_mean, maneuver_norm=maneuver_norm,
        fading=fading_params(p.stukf_forgetting, p.stukf_weakening, p.stukf_ratios)
        if "fading" in adds else None,
        spline=spline_params(p.spline_anomaly_probability) if "anomaly" in adds else None,
        imm=imm)


#: Rows gathered at a time by :func:`corrected_residuals` (bounds its copies of the rows'
#: arrays, 232 B a row, to 15 MiB; two row chunks side by side, ``rangeproc.parallel``).
CORRECTED_BLOCK_ROWS = 65_536


def corrected_residuals(b: MeasurementBatch, sensors, out: PassResult,
                        meas_epoch: np.ndarray) -> np.ndarray:
    """The pass's residuals (N, 6) with those of the rows of ``sensors`` (indices), whose
    values were just corrected, recomputed (same smoothed track; ``hph`` changes only to
    second order and is kept, so the pass's covariances ``out.Ps`` are not read: they may
    have been let go, :func:`without_covariances`). The rows are taken
    :data:`CORRECTED_BLOCK_ROWS` at a time (the same values)."""
    rows = np.flatnonzero(np.isin(b.sensor, list(sensors)))
    res = out.res.copy()
    for lo in range(0, len(rows), CORRECTED_BLOCK_ROWS):
        k = rows[lo:lo + CORRECTED_BLOCK_ROWS]
        res[k] = smoothed_residuals(meas_epoch[k], b.model[k], b.z[k], b.s[k], b.sv[k],
                                    b.Qr[k], out.xs, None)[0]
    return res


def without_covariances(out: PassResult) -> PassResult:
    """``out`` without its smoothed covariances (``Ps`` empty (0, 0)): a pass being refined
    is not the span's result (the next pass replaces it, or it is run again from its inputs
    should the next fail), and nothing the refinement reads between the passes (the
    registration, the residuals of corrected rows, the noise estimates) needs them; they
    are a span's largest array (E x 45 x 8 B: 52 MiB of a 298,000-row sortie)."""
    return out._replace(Ps=np.empty((0, 0)))


def imm_generator(n_models: int, sojourn: float) -> np.ndarray:
    """(r, r) model-switching generator (1/s): mean time ``sojourn`` (s) in each model, a
    switch going to each other model alike."""
    if n_models == 1:
        return np.zeros((1, 1))
    lam = np.full((n_models, n_models), 1.0 / (sojourn * (n_models - 1)))
    np.fill_diagonal(lam, -1.0 / sojourn)
    return lam


def imm_start(first: PassResult, x0: np.ndarray, P0: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """The IMM's start in the refinement passes: the span's own prior ``x0, P0`` for position
    and velocity, the acceleration as the first pass (the constant-acceleration EKF and RTS
    smoother) estimated it at the first epoch, its variance widened
    :data:`IMM_START_WIDENING` times.

    From a wide acceleration prior every model is still learning the motion for seconds and
    the simplest wins on Occam's razor (a 3 g thrust looks like constant velocity to the
    likelihoods); Kim's smoother, which does not re-weigh models with smoothed states, then
    extrapolated the start hundreds of metres off (the experiment of patent CN109581356A). Told the
    acceleration, the right model explains the data from the first fix. Position and
    velocity keep the honest prior: where they are weakly observed (range rates alone) a
    smoothed start counted twice made the result overconfident.
    """
    n = first.xs.shape[1]
    Ps = np.empty((n, n))
    unpack(first.Ps[0], Ps)
    x, P = x0.copy(), P0.copy()
    x[6:9] = first.xs[0, 6:9]
    P[6:9, :] = 0.0
    P[:, 6:9] = 0.0
    P[6:9, 6:9] = IMM_START_WIDENING * Ps[6:9, 6:9]
    return x, P


def data_misfit(res: np.ndarray, sigma: np.ndarray, used: np.ndarray) -> float:
    """Mean squared whitened residual over the used components (1 for a consistent fit)."""
    w = np.where(used, res / sigma, 0.0)
    return float((w * w).sum() / max(int(used.sum()), 1))


def constraint_agrees(constrained: PassResult, free: PassResult, rho: float) -> bool:
    """Whether the data agree with the maneuver norm ``rho`` the constrained ASKF imposed.

    A wrong norm (given 3 % high, say) cannot be met by turning the maneuver and drags the
    track off the measurements. Both refined results are compared on the components the
    unconstrained fit used (a track dragged off rejects the rest), whitened by its sigmas
    (each fit's own noise re-estimation would otherwise absorb the misfit). The
    unconstrained smoother's mean squared whitened residual is ``1 - h``, ``h`` the mean
    ``H P_s H^T / sigma^2`` (the share of the noise its state absorbs), so a true constraint,
    which can at most take that freedom away, leaves a misfit up to the noise level
    ``u_fit + h``; beyond it, plus three standard
    deviations of a mean of ``n`` chi-square(1) terms, the data reject the norm.
    """
    used = free.used                   # the constrained fit's own gate may have given up
    sigma = free.batch.sigma
    n = max(int(used.sum()), 1)
    c_fit = data_misfit(constrained.res, sigma, used)
    u_fit = data_misfit(free.res, sigma, used)
    absorbed = float(np.where(used, free.hph / sigma**2, 0.0).sum() / n)
    bound = u_fit + absorbed + 3.0 * np.sqrt(2.0 / n)
    if c_fit <= bound:
        log.info("askf: norm %.4g m/s^2 agrees with the data (misfit %.3g, noise level %.3g)",
                 rho, c_fit, bound)
        return True
    log.warning("askf: the data reject the maneuver norm %.4g m/s^2 (mean squared whitened "
                "residual %.3g beyond the noise level %.3g): constraint dropped", rho, c_fit,
                bound)
    return False
