"""Centralised multi-sensor estimation of one target: all rows through one EKF + RTS smoother.

Stages (each a function of arrays; numerics in the compiled kernels):

0. spans: the rows are cut wherever the target goes unobserved for longer than ``max_gap``;
   each span is estimated on its own (own start, own process noise) and has output epochs
   only inside it, so a long gap (or a stray time stamp that survived editing) costs no
   memory, no output rows and no numerical trouble from a covariance grown over hours;
1. epochs: the union of row times and output-grid times, so the smoother estimates the state
   exactly at the grid epochs (no interpolation between measurement epochs);
2. noise pre-edit: a-priori sigmas raised to difference-based estimates (``editing.noise``);
3. initialisation from the first position fixes (``fusion.initialise``);
4. process noise: when not configured, the white-jerk PSD is chosen by maximising the
   innovation likelihood over a logarithmic grid, then made time-varying in the refinement
   passes from the smoother's EM statistic (``estimation.tuning``);
5. filter + smoother, residuals; then ``noise_passes`` refinement passes, each one
   re-linearising every measurement at the previous smoothed trajectory (iterated extended
   Kalman smoother, i.e. a Gauss-Newton step on the whole flight: Bell, "The iterated Kalman
   smoother as a Gauss-Newton method", SIAM J. Optim. 1994), and, with ``adapt_noise``,
   re-estimating the measurement noise from the residuals (global and burst-local) and the
   local process noise (EM).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import chi2

from rangeproc.editing.noise import difference_sigma, residual_sigma
from rangeproc.errors import NumericalError
from rangeproc.estimation.constraint import estimate_norm
from rangeproc.estimation.forward import EKF, NO_SPLINE, kalman_forward
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.estimation.rts import rts_smooth
from rangeproc.estimation.spline_filter import spline_params
from rangeproc.estimation.tuning import local_process_noise, start_process_noise
from rangeproc.fusion.batch import MeasurementBatch, concat_batches
from rangeproc.fusion.initialise import NoPositionFix, Prior, initial_state, prior_at
from rangeproc.fusion.spline_refine import spline_refine

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True, slots=True)
class EstimatorSettings:
    """Settings of the centralised estimator.

    gate_probability: chi-square gate probability per row (dof = measured components).
    noise_passes: refinement passes after the first (re-linearise at the smoothed track and,
        with adapt_noise, re-estimate noise and process noise).
    adapt_noise: estimate noise from the data (difference pre-edit + residual passes).
    process_noise: white-jerk PSD q (m^2/s^5), held constant; None = estimate it: maximum
        likelihood over ``q_grid`` first, then local EM updates over ``q_window`` seconds.
    q_grid: candidate q values for the likelihood search.
    q_window: window (s) of the local process-noise estimate.
    reset_after / reset_inflation: divergence guard of the filter (see ``kalman_forward``).
    method: measurement update, ``EKF`` or ``UKF`` (``estimation.forward``); ukf: the UKF's
        ``(alpha, beta, kappa)``, kappa = 3 - n per seed 001.
    max_gap: longest time (s) without any row inside one span (module docstring, stage 0).
    adapt_window: > 0: improved Sage-Husa adaptive measurement noise in the filter over windows
        of this many rows (``estimation.adaptive``; ``filter = "sage-husa"``); adapt_mean: also
        estimate and remove the noise mean.
    askf: seed 004's augmented-state filter with the maneuver-norm constraint on the
        acceleration block, imposed in the refinement passes (linearised at the previous
        smoothed track; the first pass is unconstrained, ``noise_passes = 0`` leaves it so):
        ``maneuver_norm`` (m/s^2) when given, else estimated from the first pass's smoothed
        accelerations (``estimation.constraint.estimate_norm``); without a usable norm the
        unconstrained ASKF (the constant-acceleration EKF).
    stf: seed 001's strong tracking (``filter = "stukf"``): ``(rho, beta, alpha_position,
        alpha_velocity, alpha_acceleration)`` of ``estimation.fading``; empty = off.
    spline: seed 000's self-adaptive spline filter (``filter = "spline"``,
        ``estimation.spline_filter``): jerk input per segment, anomaly test, adapted R and
        jerk at anomalies, then the batch cubic B-spline fit (``estimation.spline_fit``) on
        the anomaly knots plus regular knots replaces the smoothed track
        (``fusion.spline_refine``).
    spline_probability: probability ``1 - alpha`` of the anomaly test's chi-square quantile.
    spline_knot_spacing: regular knot spacing (s) of the batch fit; None = from the data's
        dynamics (``fusion.spline_refine.knot_times``).
    """

    gate_probability: float = 0.9999
    noise_passes: int = 2
    adapt_noise: bool = True
    process_noise: float | None = None
    q_grid: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2, 5, 8))
    q_window: float = 2.0
    reset_after: int = 50
    reset_inflation: float = 100.0
    method: int = EKF
    ukf: tuple[float, float, float] = (1.0, 2.0, 3.0 - 9)
    max_gap: float = 60.0
    adapt_window: int = 0
    adapt_mean: bool = False
    askf: bool = False
    maneuver_norm: float | None = None
    stf: tuple[float, ...] = ()
    spline: bool = False
    spline_probability: float = 0.999
    spline_knot_spacing: float | None = None


@dataclass(frozen=True, slots=True)
class FusionResult:
    """Smoothed estimate of one target and the per-row bookkeeping.

    epoch_t: (E,) s; xs: (E, n); Ps: (E, n(n+1)/2) packed covariance; grid: (E,) bool, True at
    output-grid epochs; batch: the rows with the sigmas finally used; meas_epoch: (N,);
    used: (N, 6) bool, component measured and accepted by the gate in the final pass;
    nis, dof: (N,) row innovation chi-square and measured components; res, hph: (N, 6) smoothed
    residuals and explained variance; q: (E,) white-jerk PSD used on the step ending at each
    epoch (m^2/s^5); noise: global sigma estimate per
    (sensor index, component); n_resets: divergence-guard resets in the final pass;
    spans: ((t_first, t_last), ...) s of the estimated spans; n_unstarted: rows per sensor
    index of spans that could not be started (no position fix) and are not in ``batch``;
    maneuver_norm: the norm (m/s^2) the constrained ASKF imposed, None when unconstrained.
    """

    epoch_t: np.ndarray
    xs: np.ndarray
    Ps: np.ndarray
    grid: np.ndarray
    batch: MeasurementBatch
    meas_epoch: np.ndarray
    used: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    res: np.ndarray
    hph: np.ndarray
    q: np.ndarray
    noise: dict[tuple[int, int], float]
    n_resets: int
    spans: tuple[tuple[float, float], ...] = ()
    n_unstarted: dict[int, int] = field(default_factory=dict)
    maneuver_norm: float | None = None


def gate_thresholds(probability: float) -> np.ndarray:
    """(7,) chi-square thresholds indexed by degrees of freedom (index 0 unused)."""
    g = np.full(7, np.inf)
    g[1:] = chi2.ppf(probability, np.arange(1, 7))
    return g


def output_grid(t_first: float, t_last: float, rate_hz: float) -> np.ndarray:
    """Uniform grid (s) at ``rate_hz`` on whole multiples of the period within [first, last]."""
    k0 = int(np.ceil(t_first * rate_hz - 1e-9))
    k1 = int(np.floor(t_last * rate_hz + 1e-9))
    return np.arange(k0, k1 + 1, dtype=np.float64) / rate_hz


def _epochs(t_rows: np.ndarray, grid_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    epoch_t = np.union1d(t_rows, grid_t)
    meas_epoch = np.searchsorted(epoch_t, t_rows)
    grid = np.zeros(len(epoch_t), dtype=bool)
    grid[np.searchsorted(epoch_t, grid_t)] = True
    return epoch_t, meas_epoch.astype(np.int64), grid


def component_use(z: np.ndarray, rejected: np.ndarray) -> np.ndarray:
    """(N, 6) bool: component measured and not rejected by the gate (bit mask ``rejected``)."""
    bits = (rejected[:, None] >> np.arange(z.shape[1])[None, :]) & 1
    return np.isfinite(z) & (bits == 0)


def _run(batch: MeasurementBatch, epoch_t, meas_epoch, x0, P0, q, gate, st, x_lin,
         maneuver_norm: float = 0.0):
    """One filter + smoother pass; returns the smoothed track, gate results and residuals."""
    try:
        xf, Pf, nis, dof, rej, _, resets, _, sigma_used, fade, jerk, _, knot = kalman_forward(
            epoch_t, meas_epoch, batch.model, batch.z, batch.sigma, batch.s, batch.sv,
            batch.Qr, batch.sensor, x0, P0, q, gate, st.reset_after, st.reset_inflation, x_lin,
            st.method, np.asarray(st.ukf, dtype=np.float64), st.adapt_window, st.adapt_mean,
            maneuver_norm, np.asarray(st.stf, dtype=np.float64),
            spline_params(st.spline_probability) if st.spline else NO_SPLINE)
        if knot.shape[0]:
            log.info("spline filter: %d anomaly knots", int(knot.sum()))
        elif fade.shape[0]:
            faded = fade.max(axis=1) > 1.0
            log.info("strong tracking: %d of %d epochs faded (largest factor %.3g)",
                     int(faded.sum()), len(faded), float(fade.max()))
        xs, Ps, em = rts_smooth(epoch_t, xf, Pf, q, True, True,   # in place over xf, Pf
                                fade if fade.shape[0] else None,
                                jerk if jerk.shape[0] else None)
    except FloatingPointError as exc:
        raise NumericalError(f"estimator failed: {exc}") from exc
    res, hph = smoothed_residuals(meas_epoch, batch.model, batch.z, batch.s, batch.sv,
                                  batch.Qr, xs, Ps)
    if sigma_used.shape[0]:                  # adapted in the filter: report what it used
        batch = batch.with_sigma(np.where(np.isfinite(sigma_used), sigma_used, batch.sigma))
    return (xs, Ps, em, nis, dof, component_use(batch.z, rej), res, hph, resets, batch,
            epoch_t[knot] if knot.shape[0] else epoch_t[:0])


def span_slices(t: np.ndarray, max_gap: float) -> list[slice]:
    """Cut ascending row times ``t`` (s) wherever a step exceeds ``max_gap`` (s)."""
    cuts = (np.flatnonzero(np.diff(t) > max_gap) + 1).tolist()
    bounds = [0, *cuts, len(t)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def fuse_target(batch: MeasurementBatch, rate_hz: float,
                settings: EstimatorSettings = EstimatorSettings(),
                tick: Callable[..., None] = lambda *a, **k: None,
                prior: Prior | None = None) -> FusionResult:
    """Estimate one target's trajectory from its measurement batch (see module docstring).

    Each span (stage 0) is estimated by :func:`fuse_span`; a span that cannot be started (no
    position fix in it) is left out with a warning and its rows counted in ``n_unstarted``.
    ``tick(n, note)`` advances ``1 + noise_passes`` in all (progress display). ``prior``: a
    given state of the target, used by the span nearest to its time when that span has no
    position fix to start from.

    Raises:
        NoPositionFix: no span can be started (the first span's reason).
    """
    slices = span_slices(batch.t, settings.max_gap)
    if prior is not None:
        dist = [max(batch.t[sl.start] - prior.t, prior.t - batch.t[sl.stop - 1], 0.0)
                for sl in slices]
        with_prior = int(np.argmin(dist))
    if len(slices) == 1:
        result = fuse_span(batch, rate_hz, settings, tick, prior)
        return replace(result, spans=((float(batch.t[0]), float(batch.t[-1])),))
    done: list[FusionResult] = []
    unstarted: dict[int, int] = {}
    first_error: NoPositionFix | None = None
    ticked = 0.0
    for j, sl in enumerate(slices):
        part = batch.rows(sl)
        share = len(part) / len(batch)

        def span_tick(n: int = 1, note: str = "", share: float = share) -> None:
            nonlocal ticked
            before = int(ticked)
            ticked += n * share
            if int(ticked) > before:
                tick(int(ticked) - before, note)

        try:
            done.append(fuse_span(part, rate_hz, settings, span_tick,
                                  prior if prior is not None and j == with_prior else None))
        except NoPositionFix as exc:
            first_error = first_error or exc
            log.warning("span %.3f to %.3f s (%d rows) left out: %s", part.t[0], part.t[-1],
                        len(part), exc)
            for i, c in zip(*np.unique(part.sensor, return_counts=True)):
                unstarted[int(i)] = unstarted.get(int(i), 0) + int(c)
    if not done:
        assert first_error is not None
        raise first_error
    if int(ticked) < 1 + settings.noise_passes:
        tick(1 + settings.noise_passes - int(ticked), "")
    return _concat(done, unstarted)


def _concat(parts: list[FusionResult], unstarted: dict[int, int]) -> FusionResult:
    """One result from the results of consecutive spans."""
    offsets = np.cumsum([0] + [len(p.epoch_t) for p in parts[:-1]])
    noise: dict[tuple[int, int], float] = {}
    weight: dict[tuple[int, int], int] = {}
    for p in parts:                       # row-weighted mean variance of each sensor's noise
        for key, sig in p.noise.items():
            n = int((p.batch.sensor == key[0]).sum())
            noise[key] = noise.get(key, 0.0) + n * sig * sig
            weight[key] = weight.get(key, 0) + n
    noise = {k: float(np.sqrt(v / max(weight[k], 1))) for k, v in noise.items()}

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts])

    return FusionResult(
        epoch_t=cat("epoch_t"), xs=cat("xs"), Ps=cat("Ps"), grid=cat("grid"),
        batch=concat_batches([p.batch for p in parts]),
        meas_epoch=np.concatenate([p.meas_epoch + o for p, o in zip(parts, offsets)]),
        used=cat("used"), nis=cat("nis"), dof=cat("dof"), res=cat("res"), hph=cat("hph"),
        q=cat("q"), noise=noise, n_resets=sum(p.n_resets for p in parts),
        spans=tuple((float(p.batch.t[0]), float(p.batch.t[-1])) for p in parts),
        n_unstarted=unstarted, maneuver_norm=parts[0].maneuver_norm)


def fuse_span(batch: MeasurementBatch, rate_hz: float,
              settings: EstimatorSettings = EstimatorSettings(),
              tick: Callable[..., None] = lambda *a, **k: None,
              prior: Prior | None = None) -> FusionResult:
    """Estimate the trajectory over one span of rows (stages 1-5 of the module docstring).

    The track starts from the span's first position fixes; only when there are none (e.g.
    range rates alone) from ``prior`` moved to the first epoch. ``tick(n, note)`` is called
    once per pass (progress display).

    Raises:
        NoPositionFix: no position fix and no prior.
    """
    grid_t = output_grid(float(batch.t[0]), float(batch.t[-1]), rate_hz)
    epoch_t, meas_epoch, grid = _epochs(batch.t, grid_t)
    gate = gate_thresholds(settings.gate_probability)
    if settings.adapt_noise:
        batch = batch.with_sigma(difference_sigma(batch))
    started = False                   # from the given prior (it then enters the spline fit)
    try:
        x0, P0 = initial_state(batch, float(epoch_t[0]))
    except NoPositionFix:
        if prior is None:
            raise
        x0, P0 = prior_at(prior, float(epoch_t[0]))
        started = True
    if settings.process_noise is not None:
        q = np.full(len(epoch_t), settings.process_noise)
    else:
        q0, q = start_process_noise(batch, epoch_t, x0, P0, gate, settings.q_grid,
                                    settings.reset_after, settings.reset_inflation)
        log.info("pass 1: q = %.3g m^2/s^5 (maximum likelihood), local median %.3g", q0,
                 float(np.median(q)))
    x_lin = np.empty((0, x0.shape[0]))
    # askf: the first pass is unconstrained (the constraint needs the maneuver's direction,
    # which the data give): the refinement passes impose it, linearised at its smoothed track
    rho = settings.maneuver_norm if settings.askf else None
    out = _run(batch, epoch_t, meas_epoch, x0, P0, q, gate, settings, x_lin)
    if settings.askf and rho is None:
        rho = estimate_norm(out[0][grid][:, 6:9])
        log.info("askf: maneuver norm %s", "not usable (unconstrained)" if rho is None
                 else f"{rho:.3g} m/s^2 (estimated)")
    tick(1, "pass 1")
    noise: dict[tuple[int, int], float] = {}
    for p in range(settings.noise_passes):
        xs, Ps, em, nis, dof, used, res, hph, _, _, _ = out
        x_lin = xs
        if settings.adapt_noise:
            sigma, noise = residual_sigma(batch, res, hph, used)
            batch = batch.with_sigma(sigma)
        if settings.process_noise is None:
            q = local_process_noise(epoch_t, em, window=settings.q_window)
        log.info("pass %d: median q = %.3g m^2/s^5", p + 2, float(np.median(q)))
        out = _run(batch, epoch_t, meas_epoch, x0, P0, q, gate, settings, x_lin, rho or 0.0)
        tick(1, f"pass {p + 2}")
    xs, Ps, em, nis, dof, used, res, hph, resets, batch, knots = out
    if settings.spline:          # seed 000's post-flight counterpart: the batch spline fit
        xs, Ps, res, hph = spline_refine(
            batch, epoch_t, meas_epoch, xs, Ps, used, res, hph, q, knots,
            settings.spline_knot_spacing, (float(epoch_t[0]), x0, P0) if started else None)
    return FusionResult(epoch_t=epoch_t, xs=xs, Ps=Ps, grid=grid, batch=batch,
                        meas_epoch=meas_epoch, used=used, nis=nis, dof=dof, res=res,
                        hph=hph, q=q, noise=noise, n_resets=resets, maneuver_norm=rho)
