"""Post-flight refinement of ``filter = "spline"``: the batch cubic B-spline fit on the filter's
anomaly knots plus regular knots replaces the smoothed track (Zhou et al. 2001: offline
processing by batch estimation on a spline trajectory is the high-accuracy counterpart of its
real-time filter; ``estimation.spline_fit``).

Knots: the anomaly times of the final pass (where the filter saw the jerk change) plus a
regular grid whose spacing follows the data's dynamics unless configured
(``spline_knot_spacing``). The rule: over one knot interval a cubic cannot follow the white
jerk the smoother estimated, whose position variance over an interval ``D`` is ``q D^5 / 20``
(the CA model's ``Q[0, 0]``) and velocity variance ``q D^3 / 3``; the interval is the longest
where neither exceeds the smoothed variance of the estimate, ``D = min((20 sigma_p^2 / q)^(1/5),
(3 sigma_v^2 / q)^(1/3))`` with the local ``q``, ``sigma_p``, ``sigma_v`` of the smoother
(range rates fix velocity far better than position, so the velocity term matters), so the
spline's representation error stays at the level of the estimate's own uncertainty: short
intervals in manoeuvres and where the data are precise, long ones in cruise. ``D`` is held in
``[max(SPACING_MIN, 4 row steps), SPACING_MAX]``.

Safeguards (each falls back to the smoothed track with a logged warning, never an error): a
fit that raises (no usable rows, singular system), a non-finite result, one inconsistent
with the data (whitened chi-square per degree of freedom more than :data:`MAX_CHI2_RATIO`
times the smoother's, per used component, at least 1), or one that strays from the smoothed
track beyond its uncertainty without fitting the data better than it does. The fit's
covariance assumes the sigmas; when its chi-square per degree of freedom exceeds 1 the
covariance is scaled by it (the usual variance-of-unit-weight correction), so misfit shows in
the sigmas.

On range rates alone (``filter_choice.range_rates_only``), whichever of the two estimates is
kept, its covariance is widened by the outer product of their difference
``d = x_fit - x_smooth`` (all nine states, at every epoch of the fit's span):
``P + DISAGREEMENT_SHARE d d^T``. There the position is observed only through the change of
the geometry and the model of the trajectory (knots against white jerk) decides much of the
estimate; the choice between the two is a test, not a certainty. In the manner of Bayesian
model averaging, the second moment of the truth about the kept estimate holds ``(1 - w) d
d^T`` for the weight ``1 - w`` of the other model; with the share 1 the other estimate lies
within one sigma of the kept one along ``d``, so the kept sigma covers the disagreement
instead of claiming one of them right (one flight kept the fit with 87 % of its epochs inside
3 sigma). Where the position is observed directly both are sound and their difference says
nothing of the kept one's error (for an efficient ``A``, ``Cov(B - A) = Cov(B) - Cov(A)``):
widening there only inflates (the spline filter's NEES on the linear-Gaussian case of
``tests/fusion/test_every_filter.py`` fell from 3 to 2.4, under its chi-square bound), so it
is not done.
"""
from __future__ import annotations

import logging
import warnings

import numpy as np

from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.estimation.spline_fit import fit_spline
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.filter_choice import range_rates_only

log = logging.getLogger(__name__)

#: Bounds (s) of the automatic regular knot spacing.
SPACING_MIN = 0.1
SPACING_MAX = 10.0
#: Scales of the dynamics rule's knot spacing among which the information criterion chooses.
SPACING_SCALES = (1.0, 2.0, 4.0, 8.0)
#: Largest accepted ratio of the fit's chi-square per dof to the smoother's.
MAX_CHI2_RATIO = 2.0
#: Share of the outer product of the fit's and the smoother's difference added to the kept
#: estimate's covariance (module docstring).
DISAGREEMENT_SHARE = 1.0
_TRIL = np.tril_indices(9)


def knot_times(epoch_t: np.ndarray, Ps: np.ndarray, q: np.ndarray, row_t: np.ndarray,
               anomalies: np.ndarray, spacing: float | None, scale: float = 1.0
               ) -> np.ndarray:
    """Interior knot times (s): the anomaly times plus a regular grid of ``spacing`` s, or of
    the dynamics rule of the module docstring times ``scale`` when ``spacing`` is None."""
    t0, t1 = float(epoch_t[0]), float(epoch_t[-1])
    if spacing is not None:
        grid = np.arange(t0 + spacing, t1, spacing)
    else:
        steps = np.diff(np.unique(row_t))
        lo = max(SPACING_MIN, 4.0 * float(np.median(steps)) if steps.size else SPACING_MIN)
        var_p = (Ps[:, 0] + Ps[:, 2] + Ps[:, 5]) / 3.0          # packed diagonal of e, n, u
        var_v = (Ps[:, 9] + Ps[:, 14] + Ps[:, 20]) / 3.0        # of ve, vn, vu
        qq = np.maximum(q, 1e-12)
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.minimum((20.0 * var_p / qq) ** 0.2, (3.0 * var_v / qq) ** (1.0 / 3.0))
        d = np.clip(scale * np.nan_to_num(d, nan=SPACING_MAX, posinf=SPACING_MAX), lo,
                    max(lo, SPACING_MAX))
        out, t = [], t0
        while True:
            t += float(d[min(np.searchsorted(epoch_t, t), len(epoch_t) - 1)])
            if t >= t1:
                break
            out.append(t)
        grid = np.asarray(out)
    return np.union1d(grid, anomalies)


def _best_fit(batch: MeasurementBatch, epoch_t, meas_epoch, xs, Ps, used, q, anomalies,
              spacing: float | None, prior: tuple | None):
    """The batch fit on the knots of ``spacing``, or, when it is None, the one of the dynamics
    rule scaled by :data:`SPACING_SCALES` with the least Bayesian information criterion
    ``chi2 + 3 n_coef ln(n)`` (the rule sets where knots are needed, the criterion how many
    the data support: denser knots than that fit the noise and the velocity suffers), going
    sparser only while the fit stays within the smoother's uncertainty (:func:`_agrees`).
    The rule's own knots are the reference: where the smoother is the weaker estimate (range
    rates alone) it is the fit that corrects it, so the smoother cannot veto that one."""
    best, best_bic = None, np.inf
    n = max(int(used.sum()), 2)
    for scale in (1.0,) if spacing is not None else SPACING_SCALES:
        knots = knot_times(epoch_t, Ps, q, batch.t, anomalies, spacing, scale)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)    # a ridge = unobservable: no
            fit = fit_spline(batch.t, batch.model, batch.z, batch.sigma, batch.s, batch.sv,
                             batch.Qr, interior_knots=knots, x_init=xs[meas_epoch], use=used,
                             prior=prior)
        bic = fit.chi2 + fit.coef.size * np.log(n)
        if best is not None and not (bic < best_bic and _agrees(fit, epoch_t, xs, Ps)):
            break                                  # sparser knots only fit worse from here
        best, best_bic = fit, bic
    return best


def _agrees(fit, epoch_t: np.ndarray, xs: np.ndarray, Ps: np.ndarray) -> bool:
    """Whether a sparser fit stays within the smoother's own uncertainty: the mean squared
    Mahalanobis distance of its position and velocity from the smoothed ones (under the
    smoother's covariance) at most the dimension, 6. Both use the same data, so a fit that
    strays further is biased (too few knots for a manoeuvre where the data are thin): the
    information criterion, a global count, cannot see it there."""
    inside = np.flatnonzero((epoch_t >= fit.knots[0]) & (epoch_t <= fit.knots[-1]))
    inside = inside[:: max(1, inside.size // 2000)]          # a sample is enough
    x_fit, _ = fit.evaluate(epoch_t[inside])
    d = x_fit[:, :6] - xs[inside, :6]
    P = np.zeros((inside.size, 9, 9))
    P[:, _TRIL[0], _TRIL[1]] = Ps[inside]
    P = P + np.tril(P, -1).transpose(0, 2, 1)
    m2 = np.einsum("ki,ki->k", d, np.linalg.solve(P[:, :6, :6], d[..., None])[..., 0])
    log.info("spline fit: %d coefficients, mean squared Mahalanobis distance %.3g from the "
             "smoother", fit.coef.size, float(np.mean(m2)))
    return bool(np.mean(m2) <= 6.0)


def disagreement(x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(E, 45) packed ``DISAGREEMENT_SHARE d d^T`` of ``d = x_a - x_b`` (E, 9): what the
    kept estimate's covariance gains from the other's difference (module docstring)."""
    d = x_a[:, :9] - x_b[:, :9]
    return DISAGREEMENT_SHARE * d[:, _TRIL[0]] * d[:, _TRIL[1]]


def spline_refine(batch: MeasurementBatch, epoch_t: np.ndarray, meas_epoch: np.ndarray,
                  xs: np.ndarray, Ps: np.ndarray, used: np.ndarray, res: np.ndarray,
                  hph: np.ndarray, q: np.ndarray, anomalies: np.ndarray,
                  spacing: float | None, prior: tuple | None):
    """The batch spline fit replacing the smoothed ``xs, Ps`` (packed) at the epochs inside
    its span, and the residuals ``res, hph`` recomputed from it; the inputs unchanged (with a
    warning) when the fit fails or is inconsistent (module docstring).

    ``used`` (N, 6): the components the final pass accepted; ``prior``: ``(t, x, P)`` of the
    given initial state when the span was started from it, else None."""
    if xs.shape[1] != 9:                 # the fit is of the 9-state kinematics only
        return xs, Ps, res, hph
    try:
        fit = _best_fit(batch, epoch_t, meas_epoch, xs, Ps, used, q, anomalies, spacing, prior)
    except (ValueError, ArithmeticError, RuntimeWarning, np.linalg.LinAlgError) as exc:
        log.warning("spline fit failed (%s): the smoothed track is kept", exc)
        return xs, Ps, res, hph
    w = np.isfinite(res) & used
    n_used = int(w.sum())
    chi2_smooth = float(np.sum((res[w] / batch.sigma[w]) ** 2)) / max(n_used, 1)
    ratio = fit.chi2 / max(fit.dof, 1)
    if not np.isfinite(fit.chi2) or not np.all(np.isfinite(fit.coef)) \
            or ratio > MAX_CHI2_RATIO * max(chi2_smooth, 1.0):
        log.warning("spline fit inconsistent (chi2/dof %.3g against the smoother's %.3g): "
                    "the smoothed track is kept", ratio, chi2_smooth)
        return xs, Ps, res, hph
    if ratio > chi2_smooth and not _agrees(fit, epoch_t, xs, Ps):
        # it contradicts the smoother without explaining the data better: the weaker
        # estimate (e.g. across GPS dropouts with radars alone); where the smoother is the
        # weaker one (range rates alone) the fit explains the data better and is kept
        log.warning("spline fit strays from the smoothed track without fitting the data better "
                    "(chi2/dof %.3g against %.3g): the smoothed track is kept", ratio,
                    chi2_smooth)
        inside = (epoch_t >= fit.knots[0]) & (epoch_t <= fit.knots[-1])
        if range_rates_only(batch):
            Ps = Ps.copy()
            Ps[inside] += disagreement(fit.evaluate(epoch_t[inside])[0], xs[inside])
        return xs, Ps, res, hph
    inside = (epoch_t >= fit.knots[0]) & (epoch_t <= fit.knots[-1])
    x_fit, P_fit = fit.evaluate(epoch_t[inside])
    P_fit *= max(ratio, 1.0)
    xs, Ps = xs.copy(), Ps.copy()
    Ps[inside] = P_fit[:, _TRIL[0], _TRIL[1]]
    if range_rates_only(batch):
        Ps[inside] += disagreement(x_fit, xs[inside])
    xs[inside, :9] = x_fit
    log.info("spline fit: %d interior knots (%d at anomalies), chi2/dof %.3g (smoother %.3g), "
             "%d Gauss-Newton steps", len(fit.knots) - 8, len(anomalies), ratio, chi2_smooth,
             fit.n_iter)
    res, hph = smoothed_residuals(meas_epoch, batch.model, batch.z, batch.s, batch.sv,
                                  batch.Qr, xs, Ps)
    return xs, Ps, res, hph
