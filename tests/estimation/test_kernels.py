"""Structured kernels equal the dense reference maths (F = F1 (x) I3, Q = q Q1 (x) I3)."""
import numpy as np
import pytest

from rangeproc.estimation.kernels import left_f, left_f_t, predict_cov, predict_state
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace, pack, unpack
from rangeproc.models.motion import ca_transition_py


@pytest.mark.parametrize("n", [9, 12])
@pytest.mark.parametrize("dt", [1e-4, 0.05, 2.0])
def test_structured_prediction_equals_dense(n, dt):
    rng = np.random.default_rng(int(dt * 1e4) + n)
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    x = rng.normal(size=n)
    F, Q = ca_transition_py(dt, 3.0, n)
    work = np.empty((n, n))
    out = np.empty((n, n))
    left_f(P, out, dt)
    np.testing.assert_allclose(out, F @ P, rtol=1e-13, atol=1e-12)
    left_f_t(P, out, dt)
    np.testing.assert_allclose(out, F.T @ P, rtol=1e-13, atol=1e-12)
    Pp = P.copy()
    predict_cov(Pp, work, dt, 3.0)
    np.testing.assert_allclose(Pp, F @ P @ F.T + Q, rtol=1e-12, atol=1e-12)
    assert np.array_equal(Pp, Pp.T)
    xp = x.copy()
    predict_state(xp, dt)
    np.testing.assert_allclose(xp, F @ x, rtol=1e-14, atol=1e-13)


def test_cholesky_solve_and_packing():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    S = A @ A.T + np.eye(9)
    B = rng.normal(size=(9, 4))
    L = S.copy()
    assert cholesky_inplace(L, 9)
    np.testing.assert_allclose(np.tril(L), np.linalg.cholesky(S), rtol=1e-12)
    X = B.copy()
    chol_solve_inplace(L, 9, X, 4)
    np.testing.assert_allclose(X, np.linalg.solve(S, B), rtol=1e-10)
    p = np.empty(45)
    pack(S, p)
    back = np.empty((9, 9))
    unpack(p, back)
    np.testing.assert_allclose(back, S, rtol=0, atol=1e-15)
    notpd = -np.eye(3)
    assert not cholesky_inplace(notpd, 3)


def test_unpacking_many_equals_unpacking_one_by_one():
    from rangeproc.estimation.linalg import unpack_many

    rng = np.random.default_rng(4)
    n, K = 12, 7
    full = np.empty((K, n, n))
    packed = np.empty((K, n * (n + 1) // 2))
    for k in range(K):
        A = rng.normal(size=(n, n))
        full[k] = A @ A.T
        pack(full[k], packed[k])
    one = np.empty((K, n, n))
    for k in range(K):
        unpack(packed[k], one[k])
    np.testing.assert_array_equal(unpack_many(packed, n), one)
    np.testing.assert_allclose(one, full, rtol=1e-15, atol=1e-12)
    np.testing.assert_array_equal(unpack_many(packed, n, 9), one[:, :9, :9])  # leading block
    assert unpack_many(packed[:0], n).shape == (0, n, n)
