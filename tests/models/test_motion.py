"""The white-jerk and white-acceleration noise and the CA and CV steps are written once
(``models.motion``) and every user (filters, smoothers, IMM, strong tracking, the trackers of
``tracking/``) gets the same maths."""
import numpy as np
import pytest

from rangeproc.estimation.kernels import add_q
from rangeproc.models.motion import (
    axes_blocks,
    ca_steps,
    ca_transition_py,
    cv_predict,
    white_acceleration_q,
    white_jerk_q,
)
from rangeproc.tracking.score import _carry
from rangeproc.tracking.segments import _predict


def _f1(dt: float) -> np.ndarray:
    return np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])


def _q1(dt: float, q: float) -> np.ndarray:
    q00, q01, q02, q11, q12, q22 = white_jerk_q(dt, q)
    return np.array([[q00, q01, q02], [q01, q11, q12], [q02, q12, q22]])


def _q1_cv(dt: float, q: float) -> np.ndarray:
    q00, q01, q11 = white_acceleration_q(dt, q)
    return np.array([[q00, q01], [q01, q11]])


#: (noise block, the last column of the per-axis transition F1(s)): white jerk (CA), white
#: acceleration (CV).
NOISES = {"jerk": (_q1, lambda s: _f1(s)[:, 2]), "acceleration": (_q1_cv, lambda s: [s, 1.0])}


@pytest.mark.parametrize("noise", NOISES)
@pytest.mark.parametrize("dt", [1e-3, 0.1, 3.0])
def test_noise_block_is_the_integral_of_the_white_noise(dt, noise):
    # Q1 = q int_0^dt F1(s) g g^T F1(s)^T ds, g the last unit vector: a polynomial of degree
    # 4 (jerk) or 2 (acceleration), exact with 3-point Gauss-Legendre
    block, column = NOISES[noise]
    nodes, weights = np.polynomial.legendre.leggauss(3)
    ref = 0.0
    for u, w in zip(nodes, weights):
        col = np.asarray(column(0.5 * dt * (u + 1.0)))
        ref = ref + 0.5 * dt * w * 2.5 * np.outer(col, col)
    np.testing.assert_allclose(block(dt, 2.5), ref, rtol=1e-13)


@pytest.mark.parametrize("noise", [white_jerk_q, white_acceleration_q])
def test_noise_block_takes_arrays_like_scalars(noise):
    d, q = np.array([0.01, 0.7, 2.0]), np.array([1.0, 30.0, 0.2])
    arrays = noise.py_func(d, q)
    for i in range(3):
        assert tuple(a[i] for a in arrays) == noise(float(d[i]), float(q[i]))


@pytest.mark.parametrize("dt", [0.4, -0.4])
def test_add_q_backward_step_is_the_carried_noise(dt):
    # carrying a state back by |dt|: x(t - |dt|) = F(-|dt|) (x(t) - w), so the noise is
    # F(dt) Q(|dt|) F(dt)^T, which is D Q(|dt|) D (velocity signs flipped), never Q(dt)
    F, Q = ca_transition_py(abs(dt), 2.0)
    Fd, _ = ca_transition_py(dt, 0.0)
    want = Fd @ Q @ Fd.T if dt < 0 else Q
    got = np.zeros((9, 9))
    add_q(got, dt, 2.0)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    assert np.linalg.eigvalsh(got).min() > -1e-12
    if dt < 0:                                # negative control: the unsigned formula
        naive = np.kron(_q1(dt, 2.0), np.eye(3))
        assert np.linalg.eigvalsh(naive).min() < -1e-3


@pytest.mark.parametrize("dt", [0.25, -0.25])
def test_tracking_carry_is_the_fusion_prediction(dt):
    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    P = A @ A.T + 9 * np.eye(9)
    x = rng.normal(size=9)
    F, _ = ca_transition_py(dt, 0.0)
    Qb = np.zeros((9, 9))
    add_q(Qb, dt, 1.5)
    xo, Po = np.empty(9), np.empty((9, 9))
    _carry(x, P, dt, 1.5, xo, Po)
    np.testing.assert_allclose(xo, F @ x, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(Po, F @ P @ F.T + Qb, rtol=1e-12, atol=1e-12)


def test_segment_prediction_is_one_axis_of_the_ca_model():
    rng = np.random.default_rng(4)
    A = rng.normal(size=(3, 3))
    P = A @ A.T + np.eye(3)
    x = rng.normal(size=3)
    dt, q = 0.3, 4.0
    xp, Pp = x.copy(), P.copy()
    _predict(xp, Pp, dt, q)
    F = _f1(dt)
    np.testing.assert_allclose(xp, F @ x, rtol=1e-14)
    np.testing.assert_allclose(Pp, F @ P @ F.T + _q1(dt, q), rtol=1e-13)
    assert np.array_equal(Pp, Pp.T)


@pytest.mark.parametrize("dt", [0.8, -0.8])
def test_cv_predict_is_the_cv_model_either_way(dt):
    # forward: F P F^T + Q(dt); backward: the forward noise carried back, F Q(|dt|) F^T
    rng = np.random.default_rng(5)
    A = rng.normal(size=(6, 6))
    P = A @ A.T + np.eye(6)
    x = rng.normal(size=6)
    F = np.kron(np.array([[1.0, dt], [0.0, 1.0]]), np.eye(3))
    Fa = np.kron(np.array([[1.0, abs(dt)], [0.0, 1.0]]), np.eye(3))
    Qf = np.kron(_q1_cv(abs(dt), 3.0), np.eye(3))
    Q = Qf if dt > 0 else np.linalg.solve(Fa, Qf) @ np.linalg.solve(Fa, np.eye(6)).T
    xp, Pp = cv_predict(x, P, np.asarray(dt), 3.0)
    np.testing.assert_allclose(xp, F @ x, rtol=1e-14)
    np.testing.assert_allclose(Pp, F @ P @ F.T + Q, rtol=1e-12, atol=1e-12)
    if dt < 0:                                # negative control: the unsigned formula
        naive = np.kron(_q1_cv(dt, 3.0), np.eye(3))
        assert np.linalg.eigvalsh(naive).min() < -1e-3


def test_cv_predict_is_the_fusion_imm_cv_model():
    """The plot tracker's CV prediction (numpy, over many tracks) and the fusion IMM's CV
    model (compiled, 9 states) give the same position-velocity block."""
    from rangeproc.estimation.imm_models import CV, dense_predict, model_matrices
    rng = np.random.default_rng(6)
    K = 20
    A = rng.normal(size=(K, 6, 6))
    P = A @ np.swapaxes(A, 1, 2) + np.eye(6)
    x = rng.normal(size=(K, 6)) * 50.0
    dt, q = rng.uniform(0.01, 12.0, K), rng.uniform(0.5, 1200.0, K)
    xp, Pp = cv_predict(x, P, dt, q)
    F, Q, xt, T = np.empty((9, 9)), np.empty((9, 9)), np.empty(9), np.empty((9, 9))
    for k in range(K):
        x9, P9 = np.zeros(9), np.eye(9)
        x9[:6], P9[:6, :6] = x[k], P[k]
        model_matrices(CV, dt[k], q[k], 0.0, F, Q)
        np.testing.assert_array_equal(Q[:6, :6], np.kron(_q1_cv(dt[k], q[k]), np.eye(3)))
        dense_predict(F, Q, x9, P9, xt, T)
        np.testing.assert_allclose(x9[:6], xp[k], rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(P9[:6, :6], Pp[k], rtol=1e-13, atol=1e-9)


def test_array_steps_are_the_compiled_ca_model():
    """``ca_steps`` (bridging, registration) and the compiled transition give the same F and
    Q, step by step; ``axes_blocks`` orders them as the state (position, velocity,
    acceleration, each e, n, u); a per-step q scales each step's noise."""
    dt = np.array([0.0, 0.05, 0.4, 2.5, 31.0])
    q = np.array([0.3, 1.0, 7.0, 0.01, 2.0])
    F1, Q1 = ca_steps(dt, q)
    for k in range(dt.size):
        F, Q = ca_transition_py(dt[k], q[k])
        np.testing.assert_array_equal(axes_blocks(F1)[k], F)
        np.testing.assert_allclose(axes_blocks(Q1)[k], Q, rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(ca_steps(dt, 2.0)[1], 2.0 * ca_steps(dt)[1], rtol=1e-14)
