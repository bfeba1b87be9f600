"""The white-jerk noise and the CA step are written once (``models.motion``) and every user
(filters, smoothers, IMM, strong tracking, the trackers of ``tracking/``) gets the same maths."""
import numpy as np
import pytest

from rangeproc.estimation.kernels import add_q
from rangeproc.models.motion import ca_transition_py, white_jerk_q
from rangeproc.tracking.score import _carry
from rangeproc.tracking.segments import _predict


def _f1(dt: float) -> np.ndarray:
    return np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])


def _q1(dt: float, q: float) -> np.ndarray:
    q00, q01, q02, q11, q12, q22 = white_jerk_q(dt, q)
    return np.array([[q00, q01, q02], [q01, q11, q12], [q02, q12, q22]])


@pytest.mark.parametrize("dt", [1e-3, 0.1, 3.0])
def test_white_jerk_q_is_the_integral_of_the_jerk_noise(dt):
    # Q1 = q int_0^dt F1(s) g g^T F1(s)^T ds, g = (0, 0, 1): a degree-4 polynomial,
    # exact with 3-point Gauss-Legendre
    nodes, weights = np.polynomial.legendre.leggauss(3)
    ref = np.zeros((3, 3))
    for u, w in zip(nodes, weights):
        s = 0.5 * dt * (u + 1.0)
        col = _f1(s)[:, 2]
        ref += 0.5 * dt * w * 2.5 * np.outer(col, col)
    np.testing.assert_allclose(_q1(dt, 2.5), ref, rtol=1e-13)


def test_white_jerk_q_takes_arrays_like_scalars():
    d, q = np.array([0.01, 0.7, 2.0]), np.array([1.0, 30.0, 0.2])
    arrays = white_jerk_q.py_func(d, q)
    for i in range(3):
        assert tuple(a[i] for a in arrays) == white_jerk_q(float(d[i]), float(q[i]))


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
