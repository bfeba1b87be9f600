"""Chi-square and normal quantiles without importing ``scipy.stats`` (a third of a second
of every run's start-up, for these few functions).

The formulas are scipy.stats's own (``chi2._ppf`` = ``2 gammaincinv(k/2, p)``,
``norm._ppf`` = ``ndtri``), so the values are identical to ``scipy.stats.chi2.ppf`` and
``scipy.stats.norm.ppf``/``pdf`` for 0 < p < 1 (tested).
"""
from __future__ import annotations

import numpy as np
from scipy.special import gammaincinv, ndtri


def chi2_ppf(p, dof):
    """Quantile of the chi-square distribution: p in (0, 1), dof > 0 (array-like, broadcast)."""
    return 2.0 * gammaincinv(np.asarray(dof, dtype=float) / 2.0, p)


def norm_ppf(p):
    """Quantile of the standard normal distribution, p in (0, 1)."""
    return ndtri(p)


def norm_pdf(x):
    """Density of the standard normal distribution."""
    x = np.asarray(x, dtype=float)
    return np.exp(-0.5 * x * x) / np.sqrt(2.0 * np.pi)
