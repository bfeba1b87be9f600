"""A discovered object that is another object seen through one sensor's uncorrected bias.

Association tolerates a constant offset per component of a segment (``tracking.score``: at
most ``BIAS_SIGMAS`` of the stated sigma and ``BIAS_TOLERANCE``), no more, so that nearby
objects stay apart. A sensor whose systematic error is larger (a ship radar's mount yawed
0.3 deg: 5 mrad, 17 of its stated azimuth sigmas; a latency of 60 ms on a crossing target)
then makes its rows a second, discovered object that follows a known one at a constant
offset in the sensor's own measurement space. The registration would estimate that error
(``fusion.registration``), but only from rows associated with the object.

The test is bias-aware association (Levedahl 2002; Kragel, Danford and Poore 2008: the
association likelihood maximised over the sensor's bias): for a discovered object whose rows
all come from one sensor's radar or theodolite segments (not plot tracks), and each other
object over whose span that sensor holds no overlapping segment of its own (a sensor that
follows one object at a time cannot follow both), fit to the rows' residuals against that
object's trajectory a constant offset per measured component and a latency,
``r ~ b + tau dh/dt`` (weighted least squares on the stated sigmas, refitted without the
rows beyond :data:`REFIT_SIGMAS` until those stay the same). The discovered object is that
object seen with a bias when

* the fitted offsets and latency are within :data:`PRIOR_SIGMAS` of the registration's
  a-priori spread (``fusion.registration.PRIOR_SIGMA``), and
* with the fit removed, the rows' normalised innovation squared (the row's noise and the
  object's own uncertainty, ``tracking.score``) has its median and its 90th percentile at
  most :data:`NIS_RATIO` times those of the chi-square distribution of its degrees of
  freedom: the rows follow the object as closely as its own sensors do, over the whole
  overlap, not over most of it. Two different objects do not keep a constant offset in a
  sensor's range and angles while the geometry turns (objects in formation that split).

The object that fits best takes the discovered object's rows.
"""
from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from rangeproc.fusion.registration import PRIOR_SIGMA
from rangeproc.models.measurement import AZIMUTH, N_COMPONENTS, SPHERICAL
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.objects import Objects, Segment, as_batch, member_conflict
from rangeproc.tracking.score import scores_after_offset

log = logging.getLogger(__name__)

#: Largest median and 90th percentile of the bias-corrected rows' NIS, in those of the
#: chi-square distribution of their dof.
NIS_RATIO = 2.0
#: The fitted terms may be at most this many of the registration's a-priori sigmas.
PRIOR_SIGMAS = 3.0
#: Rows whose normalised residual after a fit exceeds this are left out of the next fit,
#: repeated until the rows left out stay the same (at most MAX_REFITS fits).
REFIT_SIGMAS = 5.0
MAX_REFITS = 10
#: A-priori sigma of a constant offset per spherical component (range, azimuth, elevation).
_PRIOR_OFFSET = np.array([PRIOR_SIGMA["range"], PRIOR_SIGMA["azimuth"],
                          PRIOR_SIGMA["elevation"]])


def bias_fit(t: np.ndarray, z: np.ndarray, res: np.ndarray, sigma: np.ndarray
             ) -> tuple[np.ndarray, float, np.ndarray] | None:
    """Constant offsets of the spherical components and a latency explaining residuals.

    Args:
        t: (M,) s, the rows' times (ascending within each run of the rows).
        z: (M, 6) measurements; res: (M, 6) residuals ``z - h(x(t))`` against a trajectory;
            sigma: (M, 6) stated sigmas. Components: range (m), azimuth, elevation (rad).

    Returns:
        (b (3,) offsets of range m, azimuth rad, elevation rad; tau (s); offsets (M, 6), the
        fitted ``b + tau dh/dt`` per row and component, 0 where unmeasured), or None when
        fewer rows than unknowns are usable. ``dh/dt`` is the predicted measurement's rate by
        central differences over the rows that measure the component (azimuth unwrapped).
    """
    pred = z[:, :3] - res[:, :3]
    measured = np.isfinite(pred[:, AZIMUTH])             # unwrapped over the measured rows
    pred[measured, AZIMUTH] = np.unwrap(pred[measured, AZIMUTH])
    rate = np.zeros(pred.shape)
    for c in range(3):                   # central differences over each component's rows
        at = np.flatnonzero(np.isfinite(pred[:, c]))
        if at.size >= 3:
            dt = t[at[2:]] - t[at[:-2]]
            with np.errstate(divide="ignore", invalid="ignore"):
                rate[at[1:-1], c] = np.nan_to_num(
                    (pred[at[2:], c] - pred[at[:-2], c]) / np.where(dt > 0, dt, np.nan))
    use = np.isfinite(res[:, :3]) & np.isfinite(sigma[:, :3]) & (sigma[:, :3] > 0)
    comps = np.flatnonzero(use.any(axis=0))
    if use.sum() < comps.size + 2:
        return None
    offsets = np.zeros((t.size, N_COMPONENTS))
    keep = use.copy()
    for _ in range(MAX_REFITS):             # refit without the wild rows until none changes
        i, c = np.nonzero(keep)
        A = np.zeros((i.size, comps.size + 1))
        A[np.arange(i.size), np.searchsorted(comps, c)] = 1.0
        A[:, -1] = rate[i, c]
        w = 1.0 / sigma[i, c]
        coef = np.linalg.lstsq(A * w[:, None], res[i, c] * w, rcond=None)[0]
        b = np.zeros(3)
        b[comps] = coef[:-1]
        tau = float(coef[-1])
        offsets[:, :3] = np.where(use, b[None, :] + tau * rate, 0.0)
        u = np.abs(np.where(use, res[:, :3] - offsets[:, :3], 0.0)) / np.where(use, sigma[:, :3],
                                                                               1.0)
        now = use & (u < REFIT_SIGMAS)
        if now.sum() < comps.size + 2:
            return None
        if np.array_equal(now, keep):
            break
        keep = now
    return b, tau, offsets


def _fit_score(objects: Objects, sensor: int, rows: np.ndarray, other: str) -> float:
    """The larger of the median and the 90th percentile of the rows' NIS with their bias fit
    removed, in those of the chi-square distribution of their dof, against object ``other``
    (inf when the fit is implausible or impossible)."""
    track = objects.tracks[other]
    inside = rows[(objects.rows[sensor].t[rows] >= track.t[0])
                  & (objects.rows[sensor].t[rows] <= track.t[-1])]
    batch = as_batch(objects.rows[sensor], objects.sensor_ids, sensor)
    if inside.size < 0.5 * rows.size or np.any(batch.model[inside] != SPHERICAL):
        return np.inf
    def plausible_offsets(res: np.ndarray) -> np.ndarray | None:
        """The bias fit's offsets (M, 6) when the fit is possible and plausible, else None."""
        fit = bias_fit(batch.t[inside], batch.z[inside], res, batch.sigma[inside])
        if fit is None or np.any(np.abs(fit[0]) > PRIOR_SIGMAS * _PRIOR_OFFSET) \
                or abs(fit[1]) > PRIOR_SIGMAS * PRIOR_SIGMA["latency"]:
            return None
        return fit[2]

    scored = scores_after_offset(batch, inside, track, plausible_offsets)
    if scored is None:
        return np.inf
    nis = scored[1]
    dof = np.maximum(np.isfinite(batch.z[inside]).sum(axis=1), 1)
    ratio = max(float(np.median(nis / chi2_ppf(0.5, dof))),
                float(np.quantile(nis / chi2_ppf(0.9, dof), 0.9)))
    log.debug("bias fit of %s's rows to %s: NIS %.3g of chi-square", objects.sensor_ids[sensor],
              other, ratio)
    return ratio


def join_biased_duplicates(objects: Objects, keys: Sequence[str], discovered: Sequence[str],
                           segs_of: dict[str, list[Segment]]) -> list[str]:
    """Join each discovered object that another of ``keys`` explains through one sensor's
    bias (module docstring) to that object; returns the discovered objects left.

    ``segs_of``: each object's segments (the joined object's move with its rows)."""
    left = list(discovered)
    for k in sorted(discovered, key=lambda k: sum(s.size for _, s in objects.members[k])):
        segs = segs_of.get(k, [])
        sensors = {i for i, _ in objects.members[k]}
        if len(sensors) != 1 or not segs or any(s.plot for s in segs):
            continue
        sensor = sensors.pop()
        rows = np.sort(np.concatenate([sel for _, sel in objects.members[k]]))
        best, best_ratio = None, NIS_RATIO
        for j in keys:
            if j == k or (j in discovered and j not in left) or j not in objects.tracks \
                    or any(member_conflict(objects, j, s, segs_of) for s in segs):
                continue
            ratio = _fit_score(objects, sensor, rows, j)
            if ratio <= best_ratio:
                best, best_ratio = j, ratio
        if best is None:
            continue
        log.info("the rows of %s's discovered object follow %s but for a constant bias "
                 "(NIS %.2g of chi-square after the fit): joined to it",
                 objects.sensor_ids[sensor], best, best_ratio)
        objects.members[best].extend(objects.members.pop(k))
        segs_of.setdefault(best, []).extend(segs_of.pop(k))
        left.remove(k)
    return left
