"""Plots of hand-built scan scenes as the plot tracker takes them (shared by the tests of
``tracking.two_passes`` and ``tracking.pass_splits``)."""
from __future__ import annotations

import numpy as np


def as_plots(rows: list[tuple[float, np.ndarray, int]], period: float
             ) -> tuple[np.ndarray, ...]:
    """``rows`` (time s, east/north (2,) m, truth label (-1 clutter)) -> t (N,), p (N, 3) m,
    R (N, 3, 3) m^2 (5 m per horizontal axis, height free), scan (N,) of a radar of scan
    ``period`` s, truth label (N,), in time order."""
    rows = sorted(rows, key=lambda r: r[0])
    t = np.array([r[0] for r in rows])
    p = np.array([[*r[1], 0.0] for r in rows])
    R = np.tile(np.diag([25.0, 25.0, 1e4]), (t.size, 1, 1))
    return t, p, R, np.round(t / period).astype(np.int64), np.array([r[2] for r in rows])
