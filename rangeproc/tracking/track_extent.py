"""A plot track's extent: the variance a hull adds to its plots' noise, estimated from the
track's own innovations by covariance matching (``tracking.plot_tracker``, *Extent*), and, for
a sensor that gives several returns of one object a scan, from the spread of the returns of
the object in each scan (:class:`HullSpread`), which spans the hull where each track, taking
one end of it, sees its own innovations small."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

#: A track's extent is the mean excess of its innovations over its last this many plots
#: (:func:`extent_update`).
EXTENT_MEMORY = 10
#: A track's extent is used (added to its plot noise) only when its signed mean exceeds this
#: many standard errors of the mean, the innovations' own scatter (:func:`extent_in_use`):
#: a point target's scatters about 0 and would otherwise widen its gate to clutter.
EXTENT_SIGNIFICANCE = 2.0
#: A track's hull spread (:class:`HullSpread`) weighs its scans with this memory (scans, an
#: exponential forgetting ``1 - 1 / SPREAD_MEMORY`` a scan): a ship that turns shows another
#: part of its hull.
SPREAD_MEMORY = 50
#: Returns beyond the first of each scan (after the forgetting) a track's hull spread needs
#: before it is used (:meth:`HullSpread.extent`): the estimate of a 2 x 2 covariance from 20
#: degrees of freedom is within about a third of its value.
SPREAD_DOF = 20.0


@dataclass(slots=True)
class HullSpread:
    """The spread of a track's returns within one scan (the plot it takes and the plots no
    track took beside it, :func:`pair_close`), pooled over its scans with the forgetting of
    ``SPREAD_MEMORY``: ``scatter`` (2, 2) m^2 the summed outer products of the returns about
    their scan's mean (east, north), ``noise`` (2, 2) m^2 the sum of ``n - 1`` times the mean
    stated noise of a scan's ``n`` returns, ``dof`` the sum of ``n - 1``; ``since``, for another
    track (by ``id``) that may hold the same hull, the time (s) from which it has and the
    returns counted between the two (``tracking.hull_merge``); ``cached`` the last
    :meth:`extent` (None: to be computed)."""

    scatter: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    noise: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    dof: float = 0.0
    since: dict[int, tuple[float, int, int]] = field(default_factory=dict)
    cached: tuple[np.ndarray | None] | None = None

    def add(self, q: np.ndarray, R: np.ndarray) -> None:
        """One scan of the track: its returns' horizontal points q (n, 2) m (n >= 1, its own
        plot among them) with stated noises R (n, 2, 2) m^2. The pooled within-scan covariance
        (Koch 2008's scatter) of points ``hull + noise`` has the expectation
        ``(n - 1) (H + mean R)`` a scan, H the hull's (return_spread's estimator)."""
        keep = 1.0 - 1.0 / SPREAD_MEMORY
        n = q.shape[0]
        dev = q - q.mean(axis=0)
        self.scatter = keep * self.scatter + dev.T @ dev
        self.noise = keep * self.noise + (n - 1) * R.mean(axis=0)
        self.dof = keep * self.dof + (n - 1)
        self.cached = None

    def extent(self) -> np.ndarray | None:
        """(2, 2) m^2 the hull's covariance, east and north: the pooled scatter less the
        stated noise (its negative part, a noise stated larger than the returns scatter,
        left out), or None before ``SPREAD_DOF``."""
        if self.cached is None:
            if self.dof < SPREAD_DOF:
                self.cached = (None,)
            else:
                w, V = np.linalg.eigh((self.scatter - self.noise) / self.dof)
                self.cached = ((V * np.maximum(w, 0.0)) @ V.T,)
        return self.cached[0]


class TrackExtent(Protocol):
    """What :func:`extent_in_use` reads of a plot track: its plots ``rows``, the signed mean
    of its extent ``extent`` and the mean noise variance ``noise`` of its plots (m^2 per
    measured axis); the spread of its returns within a scan ``hull``."""

    rows: list
    extent: float
    noise: float
    hull: HullSpread


def extent_update(extent: float, n: int, c: np.ndarray, d: np.ndarray, S: np.ndarray,
                  axes: int, used: float | None = None,
                  plot_noise: float | None = None) -> float:
    """A track's extent variance (m^2 per measured axis) after a plot, by covariance matching
    (Mehra 1972; the extent of Koch 2008's random-matrix model, isotropic): the plot's
    innovation beyond what its noise and the track's uncertainty explain,
    ``(|d|^2 - tr(S - extent I)) / axes`` over the ``axes`` measured axes, averaged over the
    track's plots, the last ``EXTENT_MEMORY`` weighing most. The mean is kept signed (a point
    target's excess scatters about 0: clipping each sample would bias it up, and a track
    grown wide takes clutter), and the track's extent is its positive part.

    extent: the signed mean before the plot; n: the track's plots before this one; c (M,) the
    predicted model probabilities; d (M, 3) m the innovations; S (M, 3, 3) m^2 their
    covariances, with ``used`` m^2 per axis of extent in them (default: the extent's positive
    part; :func:`extent_in_use`); plot_noise: the plot's own noise variance (m^2 per axis,
    the track's uncertainty left out): a plot counts by ``(plot_noise / s)^2`` of a settled
    track's, s its innovation variance per axis, the share of its information on the extent
    (a young track's innovations, its velocity unknown, tell next to nothing of it and would
    pull the mean far below 0 for many plots). Default: every plot counts fully. A ship 30 m
    long seen from the side gives plots anywhere along its hull, 10 m and more off its
    centre, where the radar's stated noise is 3 m; a point target's extent stays near 0."""
    dm = np.einsum("m,mi->i", c, d)[:axes]
    used = max(extent, 0.0) if used is None else used
    noise = float(np.einsum("m,mii->", c, S[:, :axes, :axes])) - axes * used
    excess = (float(dm @ dm) - noise) / axes
    w = 1.0 / min(n + 1, EXTENT_MEMORY)
    if plot_noise is not None:
        w *= min(1.0, plot_noise * axes / max(noise, 1e-12)) ** 2
    return (1.0 - w) * extent + w * excess


def extent_in_use(tr: TrackExtent, axes: int) -> float:
    """The extent variance (m^2 per measured axis) added to track ``tr``'s plot noise: its
    signed mean (:func:`extent_update`) where it exceeds ``EXTENT_SIGNIFICANCE`` standard
    errors of that mean, else 0. An innovation of variance s per axis (noise and extent) over
    ``axes`` axes gives an excess of variance ``2 s^2 / axes``; the mean is over
    ``min(n, EXTENT_MEMORY)`` plots. A point target's mean scatters about 0 by that error and
    would, used whenever positive, widen its gate to clutter; a hull's stands well above it."""
    n = min(len(tr.rows), EXTENT_MEMORY)
    if tr.extent <= 0.0 or n < 2:
        return 0.0
    se = (tr.noise + tr.extent) * np.sqrt(2.0 / (axes * n))
    return tr.extent if tr.extent > EXTENT_SIGNIFICANCE * se else 0.0


def hull_extent(tr: TrackExtent, axes: int) -> np.ndarray:
    """(3, 3) m^2 the covariance of a return of track ``tr`` about the point it follows: its
    hull spread (:meth:`HullSpread.extent`, east and north) where measured, else its extent in
    use (:func:`extent_in_use`) on each of the ``axes`` measured axes."""
    E = np.zeros((3, 3))
    H = tr.hull.extent()
    if H is None:
        E[np.arange(axes), np.arange(axes)] = extent_in_use(tr, axes)
    else:
        E[:2, :2] = H
    return E


def pair_close(tr: TrackExtent | None, pa: np.ndarray, pb: np.ndarray, Ra: np.ndarray,
               Rb: np.ndarray, gate: float, axes: int) -> bool:
    """Whether plots pa and pb (3,) m, covariances Ra, Rb (3, 3) m^2, can be two returns of
    track ``tr``'s hull: apart by at most their noise and twice its extent
    (:func:`hull_extent`; none without a track), within the chi-square ``gate``."""
    C = Ra + Rb
    if tr is not None:
        C = C + 2.0 * hull_extent(tr, axes)
    dp = pa - pb
    return bool(dp @ np.linalg.solve(C, dp) <= gate)
