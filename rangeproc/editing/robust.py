"""Robust statistics shared by the editing steps, the estimator and the report.

The median absolute deviation scaled to a Gaussian sigma (Hampel 1974; Huber 1981, sec. 5.1):
``sigma = 1.4826 MAD`` is a consistent estimate of a Gaussian sigma whatever a minority of
wild values does.
"""
from __future__ import annotations

import numpy as np

#: 1 / Phi^-1(3/4): the MAD of a Gaussian is this many times smaller than its sigma.
MAD_TO_SIGMA = 1.482602218505602


def robust_spread(x: np.ndarray, *, max_samples: int = 200_000) -> float:
    """1.4826 x median absolute deviation of the finite values of ``x`` (an evenly spaced
    subsample of at most ``max_samples``, first and last included); NaN when none."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if x.size > max_samples:    # a step above 1: the truncated indices strictly increase
        x = x[np.linspace(0, x.size - 1, max_samples).astype(np.int64)]
    if x.size == 0:
        return float("nan")
    return float(MAD_TO_SIGMA * np.median(np.abs(x - np.median(x))))
