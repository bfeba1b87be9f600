"""``editing.robust.robust_spread``: 1.4826 MAD, against a direct computation, on all values
and on its evenly spaced subsample of a long series."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.editing.robust import MAD_TO_SIGMA, robust_spread


def mad_sigma(x: np.ndarray) -> float:
    return float(MAD_TO_SIGMA * np.median(np.abs(x - np.median(x))))


def test_gaussian_scale_and_non_finite_values():
    rng = np.random.default_rng(5)
    x = rng.normal(3.0, 2.0, 50_000)
    x[::97] = np.nan
    x[::101] = np.inf
    assert robust_spread(x) == pytest.approx(mad_sigma(x[np.isfinite(x)]))
    assert robust_spread(x) == pytest.approx(2.0, rel=0.02)
    assert np.isnan(robust_spread(np.array([np.nan, np.inf])))


@pytest.mark.parametrize("n", [1_001, 1_999, 2_000, 7_919, 123_457])
def test_subsample_is_evenly_spaced_with_both_ends(n):
    x = np.random.default_rng(n).standard_normal(n) * np.linspace(1.0, 5.0, n)  # drifting
    x[-1] = 1e6                                     # the last value is always in the sample
    idx = np.unique(np.linspace(0, n - 1, 1_000).astype(np.int64))   # sorted, no repeats
    assert len(idx) == 1_000 and idx[-1] == n - 1
    assert robust_spread(x, max_samples=1_000) == mad_sigma(x[idx])
