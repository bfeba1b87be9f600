"""RTS: a filtered covariance that rounding left a hair indefinite is loaded, not fatal."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.estimation.linalg import pack
from rangeproc.estimation.rts import rts_smooth


def packed(P: np.ndarray) -> np.ndarray:
    out = np.empty(P.shape[0] * (P.shape[0] + 1) // 2)
    pack(P, out)
    return out


def test_slightly_indefinite_filtered_covariance_is_smoothed() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    good = A @ A.T + 9 * np.eye(9)
    w, V = np.linalg.eigh(good)
    w[0] = -1e-13 * w[-1]                    # what rounding after thousands of updates leaves
    bad = (V * w) @ V.T
    epoch_t = np.array([0.0, 1e-6, 1.0])
    xf = np.zeros((3, 9))
    Pf = np.stack([packed(good), packed(bad), packed(good)])
    q = np.full(3, 1e-12)                    # no process noise to hide it
    xs, Ps, _ = rts_smooth(epoch_t, xf, Pf.copy(), q, False, False)
    assert np.isfinite(xs).all() and np.isfinite(Ps).all()


def test_a_broken_covariance_still_fails_loudly() -> None:
    P = -np.eye(9)
    epoch_t = np.array([0.0, 1.0])
    with pytest.raises(FloatingPointError, match="not positive definite"):
        rts_smooth(epoch_t, np.zeros((2, 9)), np.stack([packed(P), packed(P)]),
                   np.full(2, 1e-12), False, False)
