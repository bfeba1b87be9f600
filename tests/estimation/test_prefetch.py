"""The software prefetch (``estimation.prefetch``) is a hint: it reaches the compiled code as
``llvm.prefetch`` and changes no value; Kim's IMM smoother runs around its prefetch distance."""
import numpy as np
import pytest
from numba import njit

from rangeproc.estimation import imm_smoother
from rangeproc.estimation.prefetch import LINE_DOUBLES, prefetch


@njit(cache=False)
def _summed_backwards(a, ahead):
    flat = a.ravel()
    acc = 0.0
    for i in range(flat.shape[0] - 1, -1, -1):
        if ahead > 0 and i - ahead >= 0:
            prefetch(a, i - ahead)
        acc += flat[i] * (i + 1)
    return acc


def test_prefetch_is_emitted_and_changes_nothing():
    a = np.random.default_rng(3).normal(size=(257, 45))
    before = a.copy()
    assert _summed_backwards(a, 4 * LINE_DOUBLES) == _summed_backwards(a, 0)
    assert np.array_equal(a, before)
    ir = next(iter(_summed_backwards.inspect_llvm().values()))
    assert "llvm.prefetch" in ir


@pytest.mark.parametrize("extra", [-1, 0, 1, 2, 5])
def test_imm_smoother_around_its_prefetch_distance(extra):
    """Histories shorter than, as long as and longer than the distance the smoother
    prefetches ahead (epochs whose prefetch index would be negative are skipped)."""
    E = max(imm_smoother.PREFETCH_AHEAD + extra, 1)
    rng = np.random.default_rng(E)
    r, n = 3, 9
    t = np.arange(E) * 0.1
    xm = rng.normal(size=(E, r, n))
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    Pm = np.tile(P[np.tril_indices(n)], (E, r, 1))
    mu = np.full((E, r), 1.0 / r)
    lam = np.full((r, r), 0.05) - np.eye(r) * 0.05 * r
    xs, Ps, mus = imm_smoother.imm_smooth(t, xm, Pm, mu, np.zeros((E, r)), np.full(E, 1.0),
                                          np.arange(r), lam, 0.0)
    assert xs.shape == (E, n) and Ps.shape == (E, n * (n + 1) // 2)
    assert np.isfinite(xs).all() and np.isfinite(Ps).all()
    assert np.allclose(mus.sum(axis=1), 1.0)
