"""A plot track's extent: the variance a hull adds to its plots' noise, estimated from the
track's own innovations by covariance matching (``tracking.plot_tracker``, *Extent*)."""
from __future__ import annotations

from typing import Protocol

import numpy as np

#: A track's extent is the mean excess of its innovations over its last this many plots
#: (:func:`extent_update`).
EXTENT_MEMORY = 10
#: A track's extent is used (added to its plot noise) only when its signed mean exceeds this
#: many standard errors of the mean, the innovations' own scatter (:func:`extent_in_use`):
#: a point target's scatters about 0 and would otherwise widen its gate to clutter.
EXTENT_SIGNIFICANCE = 2.0


class TrackExtent(Protocol):
    """What :func:`extent_in_use` reads of a plot track: its plots ``rows``, the signed mean
    of its extent ``extent`` and the mean noise variance ``noise`` of its plots (m^2 per
    measured axis)."""

    rows: list
    extent: float
    noise: float


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
