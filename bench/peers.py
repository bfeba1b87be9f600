"""Kernel benchmark helpers: one radar data set, and the same EKF + RTS smoother, and the same
UKF + smoother, run by rangeproc, FilterPy and Stone Soup.

The data set (:func:`radar_data`): one fixed radar at the range origin measuring slant range,
azimuth and elevation of a target flying a climbing circle of 20 km radius around it at
250 m/s (so the azimuth crosses the +-pi cut every ~500 s and all three filters must wrap the
azimuth residual). Rows every ``DT = 1/16`` s: a power of two, so the epoch times, their
differences and Stone Soup's microsecond ``timedelta`` steps are all exact and every
implementation sees the same ``dt`` bit for bit. Noise: 5 m range, 0.2 mrad in both angles.

The maths all three run: CA model with white-jerk PSD ``q`` (rangeproc's ``ca_transition``),
prior ``x0, P0`` at the first row, update at the first row, then predict/update per row
(no gating, no divergence guard), then a fixed-interval RTS smoother.

Conventions (rangeproc): state ``[e, n, u, ve, vn, vu, ae, an, au]``; ``A = atan2(e, n)``
clockwise from north; ``E = atan2(u, hypot(e, n))``. Stone Soup orders its CA state per axis
``[x, vx, ax, y, vy, ay, z, vz, az]`` (permutation :data:`SS_ORDER`) and its
``CartesianToElevationBearingRange`` measures ``[elevation, bearing, range]`` with bearing
``atan2(y, x)`` counter-clockwise from x (east); so it is fed ``[E, wrap(pi/2 - A), R]``
with ``R = diag(sig_E^2, sig_A^2, sig_R^2)`` (a sign flip and offset of an angle leave its
variance unchanged), and its results are permuted back.
"""
from __future__ import annotations

import contextlib
import functools
import math
from typing import NamedTuple
from dataclasses import dataclass
from datetime import datetime, timedelta

import numpy as np

from rangeproc.models.motion import ca_transition_py

DT = 1.0 / 16.0                        #: s between rows
SIGMA = np.array([5.0, 2e-4, 2e-4])    #: range (m), azimuth (rad), elevation (rad)
Q_PSD = 1.0                            #: white-jerk PSD of the filter (m^2/s^5)
#: UKF sigma points [alpha, beta, kappa] (seed 001: kappa = 3 - n, n = 9). All three
#: implementations use lambda = alpha^2 (n + kappa) - n, so the points and weights are the same.
UKF_PARAMS = np.array([1.0, 2.0, -6.0])
#: Stone Soup state index -> rangeproc state index (per-axis vs per-derivative ordering)
SS_ORDER = np.array([3 * deriv + axis for axis in range(3) for deriv in range(3)])
SS_BACK = np.argsort(SS_ORDER)         #: rangeproc state index -> Stone Soup state index


@dataclass(frozen=True)
class RadarData:
    """t (N,) s; z (N, 3) [R (m), A (rad), E (rad)] in rangeproc's convention; x0 (9,),
    P0 (9, 9) prior at t[0]; q white-jerk PSD (m^2/s^5)."""

    t: np.ndarray
    z: np.ndarray
    x0: np.ndarray
    P0: np.ndarray
    q: float

    def head(self, n: int) -> RadarData:
        """The first ``n`` rows (same prior)."""
        return RadarData(self.t[:n], self.z[:n], self.x0, self.P0, self.q)


@dataclass(frozen=True)
class Estimates:
    """Filtered and smoothed states (N, 9) in rangeproc's order, smoothed position variances
    (N, 3) (m^2)."""

    xf: np.ndarray
    xs: np.ndarray
    var_pos: np.ndarray


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles (rad) to [-pi, pi)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def radar_data(n: int, seed: int = 1) -> RadarData:
    """Truth on a climbing circle around the radar, noisy [R, A, E] rows, perturbed prior."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    radius, speed, phase = 20e3, 250.0, math.pi - 0.3   # crosses azimuth pi after 24 s
    w = speed / radius
    ang = w * t + phase
    e, nn = radius * np.sin(ang), radius * np.cos(ang)
    u = 5e3 + 300.0 * np.sin(0.01 * t)
    rho = np.hypot(e, nn)
    z = np.column_stack([np.hypot(rho, u), np.arctan2(e, nn), np.arctan2(u, rho)])
    z += rng.normal(0.0, SIGMA, size=z.shape)
    z[:, 1] = wrap(z[:, 1])
    truth0 = np.array([e[0], nn[0], u[0], speed * math.cos(phase), -speed * math.sin(phase),
                       3.0, -w * speed * math.sin(phase), -w * speed * math.cos(phase), 0.0])
    x0 = truth0 + rng.normal(0.0, [30.0] * 3 + [10.0] * 3 + [1.0] * 3)
    P0 = np.diag([100.0 ** 2] * 3 + [30.0 ** 2] * 3 + [10.0 ** 2] * 3)
    return RadarData(t, z, x0, P0, Q_PSD)


# ---------------------------------------------------------------------------------------------
# rangeproc. ADAPT HERE when the kernel signatures change: rangeproc_inputs builds the arrays
# (not timed), rangeproc_kernel is the timed call, rangeproc_estimates unpacks its results.
# ---------------------------------------------------------------------------------------------
class RangeprocCall(NamedTuple):
    """One timed rangeproc call: ``run_filter``'s three arguments."""

    rows: object
    prior: object
    settings: object

    def imm_args(self) -> tuple:
        """The 16 leading positional arguments of ``imm_forward`` (rows, prior, q, gate,
        divergence guard, no linearisation trajectory)."""
        r, p, s = self.rows, self.prior, self.settings
        return (*r, p.x0, p.P0, p.q_steps, s.gate, s.reset_after, s.reset_inflation,
                np.empty((0, p.x0.shape[0])))


def rangeproc_inputs(d: RadarData, method: int = 0, adapt_window: int = 0,
                     maneuver_norm: float = 0.0, stf: np.ndarray | None = None,
                     spl: np.ndarray | None = None) -> RangeprocCall:
    """``run_filter``'s arguments for one radar at the origin, gating off; ``method`` 0 =
    EKF, 1 = UKF (``rangeproc.estimation.forward.EKF`` / ``UKF``) with the sigma points
    :data:`UKF_PARAMS`; ``adapt_window`` > 0: Sage-Husa adaptive noise; ``maneuver_norm`` > 0:
    seed 004's norm constraint at every epoch (m/s^2); ``stf``: seed 001's strong-tracking
    parameters (``rangeproc.estimation.fading``), None = off; ``spl``: seed 000's
    spline-filter anomaly quantiles (``rangeproc.estimation.spline_filter``), None = off."""
    from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings
    from rangeproc.models.measurement import SPHERICAL
    n = len(d.t)
    z = np.full((n, 6), np.nan)
    z[:, :3] = d.z
    sigma = np.ones((n, 6))
    sigma[:, :3] = SIGMA
    zeros3 = np.zeros((n, 3))
    rows = FilterRows(d.t, np.arange(n, dtype=np.int64), np.full(n, SPHERICAL, dtype=np.int64),
                      z, sigma, zeros3, zeros3.copy(), np.tile(np.eye(3), (n, 1, 1)),
                      np.zeros(n, dtype=np.int64))
    prior = FilterPrior(d.x0.copy(), d.P0.copy(), np.full(n, d.q))
    settings = FilterSettings(np.full(7, np.inf), method=int(method),
                              ukf=tuple(UKF_PARAMS), adapt_window=int(adapt_window),
                              adapt_mean=adapt_window > 0, maneuver_norm=float(maneuver_norm),
                              fading=stf, spline=spl)
    return RangeprocCall(rows, prior, settings)


def rangeproc_kernel(call: RangeprocCall) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The timed call: forward pass (the family ``call.settings`` names) + RTS smoother
    (without the EM process-noise statistic, which the peers do not compute; with the spline
    filter's jerk input when it ran). The motion model is linear, so the unscented RTS
    smoother is this same RTS smoother, run in place on the filter's arrays as the pipeline
    runs it (the filtered states copied first: the agreement rows compare them). Returns
    (xf, xs, Ps packed)."""
    from rangeproc.estimation.forward import run_filter
    from rangeproc.estimation.rts import rts_smooth
    out = run_filter(*call)
    xf = out.xf.copy()
    xs, Ps = rts_smooth(call.rows.epoch_t, out.xf, out.Pf, call.prior.q_steps, False, True,
                        None, out.jerk if out.jerk.shape[0] else None)[:2]
    return xf, xs, Ps


def rangeproc_imm_kernel(args: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The timed IMM call: ``args`` = ``RangeprocCall.imm_args()`` + model codes, switching
    generator, initial probabilities; IMM filter + Kim's smoother (pruning as the pipeline).
    Returns (xf, xs, Ps packed)."""
    from rangeproc.estimation.imm import imm_forward
    from rangeproc.estimation.imm_smoother import imm_smooth
    from rangeproc.fusion.passes import IMM_PRUNE
    codes, lam = args[16], args[17]
    out = imm_forward(*args)
    xs, Ps, _ = imm_smooth(args[0], out[2], out[3], out[4], out[5], args[11], codes, lam,
                           IMM_PRUNE)
    return out[0], xs, Ps


def rangeproc_estimates(out: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Estimates:
    """Unpack the kernel's output (packed lower triangle, row-major: diag i at i(i+3)/2)."""
    xf, xs, Ps = out
    diag = [i * (i + 3) // 2 for i in range(3)]
    return Estimates(xf, xs, Ps[:, diag])


# ---------------------------------------------------------------------------------------------
# FilterPy: ExtendedKalmanFilter per row with a plain-NumPy RAE model, then rts_smoother.
# ---------------------------------------------------------------------------------------------
def rae_h(x: np.ndarray) -> np.ndarray:
    """[R, A, E] of state x (radar at the origin, rangeproc's angle convention)."""
    e, n, u = x[0], x[1], x[2]
    rho = math.hypot(e, n)
    return np.array([math.hypot(rho, u), math.atan2(e, n), math.atan2(u, rho)])


def rae_jacobian(x: np.ndarray) -> np.ndarray:
    """(3, 9) Jacobian of :func:`rae_h`."""
    e, n, u = x[0], x[1], x[2]
    rho2 = e * e + n * n
    rho = math.sqrt(rho2)
    r2 = rho2 + u * u
    r = math.sqrt(r2)
    H = np.zeros((3, 9))
    H[0, :3] = e / r, n / r, u / r
    H[1, :2] = n / rho2, -e / rho2
    H[2, :3] = -e * u / (r2 * rho), -n * u / (r2 * rho), rho / r2
    return H


def rae_residual(z: np.ndarray, h: np.ndarray) -> np.ndarray:
    """z - h with the azimuth wrapped."""
    y = z - h
    y[1] = wrap(y[1])
    return y


def filterpy_run(d: RadarData) -> Estimates:
    """FilterPy ExtendedKalmanFilter (update at the prior's epoch, then predict/update) and
    KalmanFilter.rts_smoother with the same F, Q every step."""
    from filterpy.kalman import ExtendedKalmanFilter, KalmanFilter
    F, Q = ca_transition_py(DT, d.q)
    ekf = ExtendedKalmanFilter(dim_x=9, dim_z=3)
    ekf.x, ekf.P, ekf.F, ekf.Q = d.x0.copy(), d.P0.copy(), F, Q
    ekf.R = np.diag(SIGMA ** 2)
    n = len(d.t)
    xf, Pf = np.empty((n, 9)), np.empty((n, 9, 9))
    for k in range(n):
        if k:
            ekf.predict()
        ekf.update(d.z[k], rae_jacobian, rae_h, residual=rae_residual)
        xf[k], Pf[k] = ekf.x, ekf.P
    xs, Ps, _, _ = KalmanFilter(dim_x=9, dim_z=3).rts_smoother(xf, Pf, [F] * n, [Q] * n)
    return Estimates(xf, xs, Ps[:, [0, 1, 2], [0, 1, 2]])


# ---------------------------------------------------------------------------------------------
# Stone Soup: ExtendedKalmanPredictor/Updater with its own CA and elevation-bearing-range
# models, then KalmanSmoother (its Rauch-Tung-Striebel smoother).
# ---------------------------------------------------------------------------------------------
@functools.cache
def _analytic_model_class() -> type:
    """Stone Soup's CartesianToElevationBearingRange with the analytic Jacobian of
    :func:`rae_jacobian` (rows elevation, bearing = pi/2 - A, range; radar at the origin,
    no rotation). Everything else (h(x), angle types, wrapping) is Stone Soup's own."""
    from stonesoup.models.measurement.nonlinear import CartesianToElevationBearingRange

    class AnalyticElevationBearingRange(CartesianToElevationBearingRange):
        def jacobian(self, state, **kwargs):
            H = rae_jacobian(np.asarray(state.state_vector, float).ravel()[SS_BACK])
            return np.vstack([H[2], -H[1], H[0]])[:, SS_ORDER]

    return AnalyticElevationBearingRange


def stonesoup_models(q: float, analytic: bool = False) -> tuple:
    """(transition model, measurement model) in Stone Soup's conventions. ``analytic``: the
    measurement model gets the analytic Jacobian instead of Stone Soup's finite difference."""
    from stonesoup.models.measurement.nonlinear import CartesianToElevationBearingRange
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantAcceleration,
    )
    tm = CombinedLinearGaussianTransitionModel([ConstantAcceleration(noise_diff_coeff=q)] * 3)
    cls = _analytic_model_class() if analytic else CartesianToElevationBearingRange
    mm = cls(ndim_state=9, mapping=(0, 3, 6), noise_covar=np.diag(SIGMA[[2, 1, 0]] ** 2))
    return tm, mm


def stonesoup_model_check(q: float = Q_PSD, dt: float = DT) -> dict[str, float]:
    """Max |difference| of Stone Soup's F, Q (permuted) from rangeproc's, and of its h(x)
    (converted to [R, A, E]) from :func:`rae_h`, at one state."""
    from stonesoup.types.array import StateVector
    from stonesoup.types.state import State
    tm, mm = stonesoup_models(q)
    F, Q = ca_transition_py(dt, q)
    step = timedelta(seconds=dt)
    x = np.array([-1234.5, 18000.0, 4800.0, 200.0, -30.0, 2.0, 0.5, 0.1, 0.0])
    h = np.asarray(mm.function(State(StateVector(x[SS_ORDER]))), dtype=float).ravel()
    h_rae = np.array([h[2], wrap(np.pi / 2 - h[1]), h[0]])
    ix = np.ix_(SS_ORDER, SS_ORDER)
    return {"F": float(np.abs(tm.matrix(time_interval=step) - F[ix]).max()),
            "Q": float(np.abs(tm.covar(time_interval=step) - Q[ix]).max()),
            "h": float(np.abs(wrap(h_rae - rae_h(x))).max())}


def stonesoup_inputs(d: RadarData, analytic: bool = False) -> tuple:
    """Models, prior and Detection objects (built outside the timed region)."""
    from stonesoup.types.array import CovarianceMatrix, StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    tm, mm = stonesoup_models(d.q, analytic)
    t0 = datetime(2026, 5, 4, 10, 0, 0)
    ix = np.ix_(SS_ORDER, SS_ORDER)
    prior = GaussianState(StateVector(d.x0[SS_ORDER]), CovarianceMatrix(d.P0[ix]), timestamp=t0)
    dets = [Detection(StateVector([el, wrap(np.pi / 2 - az), r]),
                      timestamp=t0 + timedelta(seconds=float(tk)), measurement_model=mm)
            for tk, (r, az, el) in zip(d.t, d.z)]
    return tm, mm, prior, dets


def stonesoup_run(inputs: tuple) -> Estimates:
    """Predict/update per detection (the first predicts over dt = 0: F = I, Q = 0), then
    smooth with Stone Soup's KalmanSmoother, which reuses the stored predictions."""
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.smoother.kalman import KalmanSmoother
    tm, mm, _, _ = inputs
    return _stonesoup_track(inputs, ExtendedKalmanPredictor(tm), _stonesoup_updater(mm),
                            KalmanSmoother(tm))


def _stonesoup_track(inputs: tuple, predictor, updater, smoother) -> Estimates:
    """The timed Stone Soup loop: predict/update per detection into a Track, then smooth."""
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.track import Track
    _, _, prior, dets = inputs
    track = Track()
    state = prior
    for det in dets:
        pred = predictor.predict(state, timestamp=det.timestamp)
        state = updater.update(SingleHypothesis(pred, det))
        track.append(state)
    smoothed = smoother.smooth(track)
    xf = np.array([np.asarray(s.state_vector, float).ravel() for s in track])[:, SS_BACK]
    xs = np.array([np.asarray(s.state_vector, float).ravel() for s in smoothed])[:, SS_BACK]
    var = np.array([np.diag(s.covar)[[0, 3, 6]] for s in smoothed])
    return Estimates(xf, xs, var)


def _stonesoup_updater(mm):
    """Stone Soup's ExtendedKalmanUpdater with the Joseph-form covariance update
    (``use_joseph_cov``), the form rangeproc and FilterPy use.

    With the stock measurement model the Jacobian is a forward finite difference
    (``stonesoup.functions.jacobian``) whose step is ``1e8 * np.spacing(x)`` floored at 1e-8;
    ``np.spacing`` is negative for negative x, so every negative coordinate gets a 1e-8 m
    step and its Jacobian column carries ~1e-4 relative round-off (on a 20 km target). That,
    not the filter maths, is why the stock run differs from rangeproc by millimetres; with
    ``analytic=True`` the same code agrees to round-off.
    """
    from stonesoup.updater.kalman import ExtendedKalmanUpdater
    return ExtendedKalmanUpdater(mm, use_joseph_cov=True)


# ---------------------------------------------------------------------------------------------
# UKF row: the same data and CA model with an unscented measurement update (sigma points
# UKF_PARAMS), then the smoother. The transition is linear, so every unscented prediction and
# the unscented RTS smoother reduce to the linear ones (up to round-off): rangeproc runs its
# RTS smoother, FilterPy its UnscentedKalmanFilter.rts_smoother, Stone Soup its
# UnscentedKalmanSmoother.
# ---------------------------------------------------------------------------------------------
def rae_mean(sigmas: np.ndarray, wm: np.ndarray) -> np.ndarray:
    """Weighted mean (3,) of (2n+1, 3) [R, A, E] sigma points with the azimuths unwrapped
    around the central point's, as rangeproc does (FilterPy's ``z_mean_fn``)."""
    out = wm @ sigmas
    a0 = sigmas[0, 1]
    out[1] = a0 + wm @ wrap(sigmas[:, 1] - a0)
    return out


def filterpy_ukf_run(d: RadarData, redraw: bool = False) -> Estimates:
    """FilterPy UnscentedKalmanFilter (MerweScaledSigmaPoints with :data:`UKF_PARAMS`, the
    same ``rae_h``, wrapped azimuth residual and :func:`rae_mean`): update at the prior's
    epoch, then predict/update per row, then its unscented ``rts_smoother``.

    ``redraw=False`` is FilterPy as shipped. ``redraw=True`` sets ``sigmas_f`` to sigma points
    of the predicted moments before every update, as rangeproc (and the test
    tests/estimation/test_ukf.py) does: FilterPy 1.4.x's ``update`` reused the points
    propagated through ``fx`` in ``predict`` (which do not carry Q); FilterPy 2.0's ``predict``
    redraws them itself, so there the two variants are identical. Either way the first
    update has no ``predict`` before it, and FilterPy's constructor leaves ``sigmas_f`` zero,
    so they are drawn from the prior here.
    """
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
    F, Q = ca_transition_py(DT, d.q)
    alpha, beta, kappa = (float(v) for v in UKF_PARAMS)
    points = MerweScaledSigmaPoints(9, alpha=alpha, beta=beta, kappa=kappa)
    ukf = UnscentedKalmanFilter(dim_x=9, dim_z=3, dt=DT, hx=rae_h, fx=lambda x, dt: F @ x,
                                points=points, z_mean_fn=rae_mean, residual_z=rae_residual)
    ukf.x, ukf.P, ukf.Q, ukf.R = d.x0.copy(), d.P0.copy(), Q, np.diag(SIGMA ** 2)
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    n = len(d.t)
    xf, Pf = np.empty((n, 9)), np.empty((n, 9, 9))
    for k in range(n):
        if k:
            ukf.predict()
            if redraw:
                ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
        ukf.update(d.z[k])
        xf[k], Pf[k] = ukf.x, ukf.P
    xs, Ps, _ = ukf.rts_smoother(xf, Pf)
    return Estimates(xf, xs, Ps[:, [0, 1, 2], [0, 1, 2]])


def stonesoup_ukf_run(inputs: tuple) -> Estimates:
    """Stone Soup UnscentedKalmanPredictor / UnscentedKalmanUpdater per detection, then
    UnscentedKalmanSmoother, all with :data:`UKF_PARAMS` (``stonesoup.functions.gauss2sigma``
    uses the same ``lambda = alpha^2 (n + kappa) - n`` and weights as rangeproc and FilterPy;
    the smoother's own default is kappa = 0, so it is passed explicitly). Its updater draws
    sigma points from the predicted moments, as rangeproc does. ``inputs`` from
    :func:`stonesoup_inputs` (stock measurement model: the UKF needs no Jacobian). One
    difference that is Stone Soup's own: angle means are circular
    (``Angle.average``: atan2 of the weighted sines and cosines) where rangeproc takes the
    weighted mean of the azimuths unwrapped around the central point."""
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.smoother.kalman import UnscentedKalmanSmoother
    from stonesoup.updater.kalman import UnscentedKalmanUpdater
    tm, mm, _, _ = inputs
    sp = dict(zip(("alpha", "beta", "kappa"), (float(v) for v in UKF_PARAMS)))
    return _stonesoup_track(inputs, UnscentedKalmanPredictor(tm, **sp),
                            UnscentedKalmanUpdater(mm, **sp), UnscentedKalmanSmoother(tm, **sp))


@contextlib.contextmanager
def _stonesoup_unwrapped_angle_mean():
    """Temporarily make Stone Soup average angles as rangeproc does (weighted mean of the
    angles unwrapped around the first, the central sigma point) instead of its circular mean.
    Only for the agreement check :func:`stonesoup_ukf_linear_mean`, never timed."""
    from stonesoup.types.angle import Angle
    saved = Angle.__dict__["average"]

    def average(cls, angles, weights=None):
        a = np.asarray(angles, dtype=float)
        w = np.full(a.size, 1.0 / a.size) if weights is None else np.asarray(weights, float)
        return cls(a[0] + w @ wrap(a - a[0]) / w.sum())

    Angle.average = classmethod(average)
    try:
        yield
    finally:
        Angle.average = saved


def stonesoup_ukf_linear_mean(inputs: tuple) -> Estimates:
    """:func:`stonesoup_ukf_run` with rangeproc's angle mean: isolates the circular-mean
    difference (a check, not a benchmark)."""
    with _stonesoup_unwrapped_angle_mean():
        return stonesoup_ukf_run(inputs)


def agreement(ref: Estimates, other: Estimates) -> dict[str, float]:
    """Max |difference| of filtered / smoothed positions (m), the same relative to the largest
    |position| coordinate, and the max relative difference of the smoothed position sigmas."""
    n = min(len(ref.xf), len(other.xf))
    scale = float(np.abs(ref.xs[:n, :3]).max())
    df = float(np.abs(ref.xf[:n, :3] - other.xf[:n, :3]).max())
    ds = float(np.abs(ref.xs[:n, :3] - other.xs[:n, :3]).max())
    sig_ref, sig_other = np.sqrt(ref.var_pos[:n]), np.sqrt(other.var_pos[:n])
    return {"filtered_pos_abs_m": df, "smoothed_pos_abs_m": ds,
            "filtered_pos_rel": df / scale, "smoothed_pos_rel": ds / scale,
            "smoothed_sigma_rel": float(np.abs(sig_other / sig_ref - 1.0).max())}
