"""The forward filter's typed entry: :func:`run_filter` runs the kernel of one filter family.

A forward pass of He 2015 sec. 3.1 (prediction eq. 6-7, gain eq. 8, Joseph-form update
eq. 9, state update eq. 10, chi-square gating per row then per component) over a
time-ordered batch of rows. The arguments come in three named groups:

* :class:`FilterRows`: the epochs and the measurement rows;
* :class:`FilterPrior`: where the pass starts (state and covariance at the first epoch), the
  process noise of each step, and optionally the trajectory to linearise at;
* :class:`FilterSettings`: the family and its parameters, the gate, the divergence guard.

The family is one of the registry's (``rangeproc.families``, keyed by the config's
``processing.filter`` strings); :func:`run_filter` returns the output type the family
declares: a :class:`FilterOutput`, or the IMM's ``estimation.imm.IMMOutput``. The compiled
loop is written once (``estimation.forward_loop``) and specialised per family (the IMM's
several models have their own loop, ``estimation.imm``); each specialisation is compiled (or
loaded from the cache) the first time its family runs, so a run compiles only what it uses.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rangeproc.estimation.forward_loop import forward_kernel
from rangeproc.estimation.imm import IMMOutput, imm_forward
from rangeproc.estimation.moments import EKF, UKF
from rangeproc.families import REGISTRY
from rangeproc.models.motion import N_KINEMATIC

__all__ = ["EKF", "UKF", "FilterOutput", "FilterPrior", "FilterRows", "FilterSettings",
           "run_filter", "UKF_DEFAULT"]

#: The UKF's sigma-point parameters ``(alpha, beta, kappa)`` for the 9-state CA model, with
#: kappa = 3 - n per Ye and Cui.
UKF_DEFAULT = (1.0, 2.0, 3.0 - N_KINEMATIC)

#: The filter families a forward pass runs (``FilterSettings.family``): the registry's, but
#: "auto", which chooses one of them per object.
FAMILIES = tuple(name for name, f in REGISTRY.items() if not f.chooses)


class FilterRows(NamedTuple):
    """The epochs and the measurement rows of one pass (rows time-ordered).

    epoch_t: (E,) ascending distinct epoch times (s); the prior is at ``epoch_t[0]``.
    meas_epoch: (N,) int64 epoch index of each row (non-decreasing).
    model, z, sigma, s, sv, Qr, sensor: the rows' arrays as ``fusion.batch.MeasurementBatch``
    declares them (``MeasurementBatch.filter_rows`` builds this tuple).
    """

    epoch_t: np.ndarray
    meas_epoch: np.ndarray
    model: np.ndarray
    z: np.ndarray
    sigma: np.ndarray
    s: np.ndarray
    sv: np.ndarray
    Qr: np.ndarray
    sensor: np.ndarray


class FilterPrior(NamedTuple):
    """Where a pass starts and how the state moves.

    x0: (n,) state at ``epoch_t[0]`` (``[p, v, a]`` in range ENU, then calibration states);
    P0: (n, n) its covariance.
    q_steps: (E,) white-jerk PSD (m^2/s^5) of the step ending at each epoch (index 0 unused).
    x_lin: (E, n) states to linearise the EKF update at (the previous smoothed trajectory:
        one Gauss-Newton step of the iterated extended Kalman smoother); None linearises at
        the prediction as the plain EKF does. The UKF ignores it.
    """

    x0: np.ndarray
    P0: np.ndarray
    q_steps: np.ndarray
    x_lin: np.ndarray | None = None


class FilterSettings(NamedTuple):
    """The filter family, its parameters, the gate and the divergence guard.

    gate: (7,) chi-square thresholds by degrees of freedom (``inf`` disables gating).
    method: the measurement update, ``EKF`` (linearised, Joseph form) or ``UKF`` (unscented).
    ukf: the UKF's ``(alpha, beta, kappa)``.
    reset_after: divergence guard: consecutive rejected (or grossly partly rejected) rows of
        one sensor after which the kinematic covariance is re-opened
        (``estimation.divergence.guard_row``); 0 disables it. reset_inflation: the least
        factor of that re-opening.
    adapt_window: > 0: improved Sage-Husa adaptive measurement noise over windows of this
        many accepted rows per sensor component (``estimation.adaptive``); adapt_mean: also
        remove the windowed noise mean.
    maneuver_norm: > 0 (m/s^2): the constant-norm maneuver of patent CN109581356A on the
        acceleration block after each epoch's rows (``estimation.constraint``; EKF only).
    fading: strong tracking's parameters (``estimation.fading.fading_params``), None = off.
    spline: the spline filter's anomaly quantiles (``estimation.spline_filter
        .spline_params``), None = off.
    imm: the IMM's ``(codes (r,), generator (r, r) in 1/s)`` (``estimation.imm``; starting
        from equal model probabilities), None = off.

    At most one of adaptive noise, fading, the spline filter and the IMM is on; that choice,
    else the maneuver norm ("askf"), else the method, is the :attr:`family`.
    """

    gate: np.ndarray
    method: int = EKF
    ukf: tuple[float, float, float] = UKF_DEFAULT
    reset_after: int = 0
    reset_inflation: float = 1.0
    adapt_window: int = 0
    adapt_mean: bool = False
    maneuver_norm: float = 0.0
    fading: np.ndarray | None = None
    spline: np.ndarray | None = None
    imm: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def family(self) -> str:
        """The registry's family that runs: one of :data:`FAMILIES`."""
        extras = [name for name, on in (("sage-husa", self.adapt_window > 0),
                                        ("stukf", self.fading is not None),
                                        ("spline", self.spline is not None),
                                        ("imm", self.imm is not None)) if on]
        if len(extras) > 1:
            raise ValueError(f"filter settings combine {' and '.join(extras)}; "
                             "at most one of them runs")
        plain = "ukf" if self.method == UKF else "ekf"
        if self.maneuver_norm > 0.0:
            if extras or plain != "ekf":
                raise ValueError("the maneuver norm needs the plain EKF, not "
                                 f"{(extras or [plain])[0]}")
            return "askf"
        return extras[0] if extras else plain


class FilterOutput(NamedTuple):
    """A forward pass's results.

    xf: (E, n) filtered states; Pf: (E, n(n+1)/2) packed filtered covariances
        (``estimation.linalg.pack``).
    nis: (N,) each row's innovation chi-square (NaN without measured components);
    dof: (N,) int64 measured components; rejected: (N,) int64 bit mask of the components the
        gate rejected (bit c = component c).
    loglik: Gaussian log-likelihood of the whitened innovations (a rejected row counted at
        the gate); ll_rows: (N,) each row's contribution to it.
    n_resets: the divergence guard's covariance re-openings.
    sigma_used: (N, 6) the adapted sigmas the update used (Sage-Husa; (0, 6) otherwise: the
        input sigmas then).
    fade: (E, 9) the fading factors applied to the prediction ending at each epoch (strong
        tracking and the spline filter; (0, 9) otherwise).
    jerk: (E, 3) the spline filter's jerk input (m/s^3) of the step ending at each epoch;
        anomaly: (E, 2) its epoch chi-square and degrees of freedom; knot: (E,) bool, its
        anomaly test fired there (all three with no rows for the other families).
    """

    xf: np.ndarray
    Pf: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    rejected: np.ndarray
    loglik: float
    n_resets: int
    ll_rows: np.ndarray
    sigma_used: np.ndarray
    fade: np.ndarray
    jerk: np.ndarray
    anomaly: np.ndarray
    knot: np.ndarray


def _f64(a, ndim: int) -> np.ndarray:
    """C-contiguous float64 (one compiled signature per kernel)."""
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.ndim != ndim:
        raise ValueError(f"expected a {ndim}-d array, got shape {out.shape}")
    return out


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def run_filter(rows: FilterRows, prior: FilterPrior,
               settings: FilterSettings) -> FilterOutput | IMMOutput:
    """Run the forward filter of ``settings.family`` over ``rows`` from ``prior``; the
    result is the output type the family declares (``families.Family.output``).

    The motion model is linear (constant acceleration), so the prediction is exact for both
    update methods. Raises FloatingPointError when the state turns non-finite (or a UKF
    covariance is not positive definite), ValueError for settings that combine families or a
    maneuver norm without the EKF.
    """
    family = settings.family
    x0 = _f64(prior.x0, 1)
    n = x0.shape[0]
    E = len(rows.epoch_t)
    common = (_f64(rows.epoch_t, 1), _i64(rows.meas_epoch), _i64(rows.model),
              _f64(rows.z, 2), _f64(rows.sigma, 2), _f64(rows.s, 2), _f64(rows.sv, 2),
              _f64(rows.Qr, 3), _i64(rows.sensor), x0, _f64(prior.P0, 2),
              _f64(prior.q_steps, 1), _f64(settings.gate, 1), int(settings.reset_after),
              float(settings.reset_inflation))
    x_lin = np.empty((0, n)) if prior.x_lin is None else _f64(prior.x_lin, 2)
    if x_lin.shape[0] not in (0, E):
        raise ValueError(f"x_lin has {x_lin.shape[0]} rows for {E} epochs")
    ukf = _f64(settings.ukf, 1)
    method = int(settings.method)
    if REGISTRY[family].output == "IMMOutput":
        codes, lam = settings.imm
        codes = _i64(codes)
        return IMMOutput._make(imm_forward(*common, x_lin, codes, _f64(lam, 2),
                                           np.full(len(codes), 1.0 / len(codes))))
    if family == "askf":
        par = np.array([float(settings.maneuver_norm)])
    elif family == "sage-husa":
        par = np.array([float(settings.adapt_window), float(bool(settings.adapt_mean))])
    elif family == "stukf":
        par = _f64(settings.fading, 1)
    elif family == "spline":
        par = _f64(settings.spline, 1)
    else:
        par = np.empty(0)
    out = forward_kernel(REGISTRY[family], n)(*common, x_lin, method, ukf, par)
    return FilterOutput(*out)
