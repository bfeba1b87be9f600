"""The registration's compiled rows and solver against independent computations."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rangeproc.estimation.registration import (
    LATENCY_SLOT,
    MOUNT_SLOT,
    N_SLOTS,
    normal_equations,
    process_blocks,
    row_design,
    solve_joint,
)
from rangeproc.fusion.assemble import FRD_TO_DECK, deck_turn
from rangeproc.models.measurement import SPHERICAL, measure_py


def _deck_axes(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Qr of a deck sensor on a platform with this attitude (range ENU ~ NED swapped)."""
    enu_to_ned = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    body_to_ned = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
    return FRD_TO_DECK @ body_to_ned.T @ enu_to_ned


def _design(x, s, sv, Qr, Qdot, moving, dt=0.0):
    h, H = np.zeros(6), np.zeros((6, 9))
    hrow, arow = np.zeros((6, 9)), np.zeros((6, N_SLOTS))
    row_design(SPHERICAL, x, s, sv, Qr, Qdot, moving, dt, h, H, hrow, arow)
    return hrow, arow


STATE = np.array([12000.0, -8000.0, 3000.0, 150.0, 80.0, -20.0, 3.0, -15.0, 2.0])
SITE = np.array([200.0, 300.0, 10.0])


def test_contract_sign_of_a_mount_yaw():
    # contract section 4: an antenna yawed +0.3 deg reports deck azimuths 0.3 deg smaller
    Qr = _deck_axes(0.0, 0.0, 0.4)
    h0, _ = measure_py(SPHERICAL, STATE, SITE, np.zeros(3), Qr)
    h1, _ = measure_py(SPHERICAL, STATE, SITE, np.zeros(3),
                       deck_turn(0.0, 0.0, math.radians(0.3)) @ Qr)
    assert h1[1] - h0[1] == pytest.approx(-math.radians(0.3), abs=1e-12)
    assert h1[2] == pytest.approx(h0[2], abs=1e-12)


def test_mount_sensitivity_equals_finite_differences():
    Qr = _deck_axes(0.08, -0.05, 2.0)
    _, arow = _design(STATE, SITE, np.zeros(3), Qr, np.zeros((3, 3)), True)
    eps = 1e-7
    for j in range(3):
        ang = np.zeros(3)
        ang[j] = eps
        hp, _ = measure_py(SPHERICAL, STATE, SITE, np.zeros(3), deck_turn(*ang) @ Qr)
        ang[j] = -eps
        hm, _ = measure_py(SPHERICAL, STATE, SITE, np.zeros(3), deck_turn(*ang) @ Qr)
        fd = (hp - hm) / (2 * eps)
        np.testing.assert_allclose(arow[1:3, MOUNT_SLOT + j], fd[1:3], atol=1e-8)
        assert arow[0, MOUNT_SLOT + j] == pytest.approx(0.0, abs=1e-9)   # the range does not
        assert abs(fd[0]) < 1e-4                                          # (rounding of fd)
        assert arow[3, MOUNT_SLOT + j] == 0.0          # the range rate does not turn


def test_latency_sensitivity_is_minus_the_rate_including_the_platform_turning():
    # a ship rolling at 0.05 rad/s and moving; the row measured at t - L
    def axes(t):
        return _deck_axes(0.08 + 0.05 * t, -0.05 + 0.01 * t, 2.0 + 0.02 * t)

    def ship(t):
        return SITE + np.array([5.0, -3.0, 0.0]) * t, np.array([5.0, -3.0, 0.0])

    def state(t):                      # constant acceleration from STATE at t = 0
        p, v, a = STATE[:3], STATE[3:6], STATE[6:9]
        return np.concatenate([p + v * t + 0.5 * a * t * t, v + a * t, a])

    eps = 1e-4
    Qdot = (axes(eps) - axes(-eps)) / (2 * eps)
    s0, sv = ship(0.0)
    _, arow = _design(state(0.0), s0, sv, axes(0.0), Qdot, True)
    hp, _ = measure_py(SPHERICAL, state(eps), ship(eps)[0], sv, axes(eps))
    hm, _ = measure_py(SPHERICAL, state(-eps), ship(-eps)[0], sv, axes(-eps))
    rate = (hp - hm) / (2 * eps)
    np.testing.assert_allclose(arow[:3, LATENCY_SLOT], -rate[:3], rtol=1e-6, atol=1e-10)
    # range rate: the range acceleration as seen from the unaccelerated ship
    np.testing.assert_allclose(arow[3, LATENCY_SLOT], -rate[3], rtol=1e-5)


def test_node_sensitivity_is_the_jacobian_through_the_transition():
    dt = 0.37
    F1 = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    F = np.kron(F1, np.eye(3))
    hrow, _ = _design(F @ STATE, SITE, np.zeros(3), np.eye(3), np.zeros((3, 3)), False, dt)
    _, H = measure_py(SPHERICAL, F @ STATE, SITE, np.zeros(3), np.eye(3))
    np.testing.assert_allclose(hrow, H[:, :9] @ F, atol=1e-15)


def _small_problem(rng):
    """Two fixed radars with biases watching a CA target, rows at 5 Hz, nodes at 1 Hz."""
    t = np.arange(0.0, 20.0, 0.2)
    truth = np.array([np.concatenate([STATE[:3] + STATE[3:6] * tt + 0.5 * STATE[6:] * tt * tt,
                                      STATE[3:6] + STATE[6:] * tt, STATE[6:]]) for tt in t])
    sites = np.array([SITE, [-5000.0, 2000.0, 50.0]])
    rows = []
    for k, tt in enumerate(t):
        for r in range(2):
            rows.append((tt, k, r))
    n = len(rows)
    z = np.full((n, 6), np.nan)
    s = np.zeros((n, 3))
    sensor = np.zeros(n, dtype=np.int64)
    meas_epoch = np.zeros(n, dtype=np.int64)
    bias = np.array([[12.0, 4e-4, -3e-4], [-6.0, 0.0, 2e-4]])
    for i, (_tt, k, r) in enumerate(rows):
        h, _ = measure_py(SPHERICAL, truth[k], sites[r], np.zeros(3), np.eye(3))
        z[i, :3] = h[:3] + bias[r] + rng.normal(0.0, [5.0, 2e-4, 2e-4])
        s[i], sensor[i], meas_epoch[i] = sites[r], r, k
    # linearise at a track 20 m off the truth
    xs = truth + np.concatenate([[20.0, -10.0, 5.0], np.zeros(6)])
    sig = np.tile([5.0, 2e-4, 2e-4, np.nan, np.nan, np.nan], (n, 1))
    return t, truth, xs, z, s, sensor, meas_epoch, sig


def _nodes_and_weights(t, meas_epoch, sig):
    """(node_t, node, weight) of the small problem: 1 s nodes, 1/sigma^2 weights (0 = not
    measured)."""
    node_t = np.arange(0.0, 20.0, 1.0)
    node = np.clip(np.round(t[meas_epoch]).astype(np.int64), 0, len(node_t) - 1)
    weight = np.where(np.isfinite(sig), 1.0 / np.where(np.isfinite(sig), sig, 1.0) ** 2, 0.0)
    return node_t, node, weight


def test_row_kernels_split_into_chunks_give_the_values_of_one_piece(monkeypatch):
    """normal_equations, postfit and smoothed_residuals run long inputs in row chunks on
    threads: the same residuals exactly, the same sums to rounding."""
    from rangeproc import parallel
    from rangeproc.estimation.registration import postfit
    from rangeproc.estimation.residuals import smoothed_residuals

    rng = np.random.default_rng(11)
    t, truth, xs, z, s, sensor, meas_epoch, sig = _small_problem(rng)
    n = len(sensor)
    node_t, node, weight = _nodes_and_weights(t, meas_epoch, sig)
    slots = np.full((2, N_SLOTS), -1, dtype=np.int64)
    slots[0, :4] = [0, 1, 2, 3]
    slots[1, :3] = [4, 5, 6]
    model, sv, Qr = np.full(n, SPHERICAL), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1))
    head = (meas_epoch, node, node_t, t[meas_epoch], model)
    geo = (s, sv, Qr, np.full(n, -1), np.zeros((1, 3, 3)), sensor, slots, xs)
    Ps = np.tile(np.eye(9)[np.triu_indices(9)], (len(xs), 1)) * 0.5

    def all_three():
        ne = normal_equations(*head, z, weight, *geo, 7)
        dx, c = rng_fixed.normal(size=(len(node_t), 9)), rng_fixed.normal(size=7) * 1e-3
        return ne, postfit(*head, *geo, ne[5], dx, c), smoothed_residuals(
            meas_epoch, model, z, s, sv, Qr, xs, Ps)

    rng_fixed = np.random.default_rng(3)
    whole = all_three()
    monkeypatch.setattr(parallel, "MIN_CHUNK_ROWS", n // 5)
    monkeypatch.setattr(parallel, "usable_cores", lambda: 3)
    assert len(parallel.row_chunks(n)) == 3
    rng_fixed = np.random.default_rng(3)
    split = all_three()
    for a, b in zip(whole[0][:5], split[0][:5]):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(a).max())
    for a, b in [(whole[0][5], split[0][5]), *zip(whole[1], split[1]),
                 *zip(whole[2], split[2])]:
        np.testing.assert_array_equal(a, b)
    assert np.isfinite(whole[2][0]).any() and np.isfinite(whole[1][0]).any()


def _bias_problem(rng):
    """``normal_equations``' arguments for the small problem with range, azimuth and
    elevation biases of both radars (6 terms), and the problem's parts."""
    t, truth, xs, z, s, sensor, meas_epoch, sig = _small_problem(rng)
    n = len(sensor)
    node_t, node, weight = _nodes_and_weights(t, meas_epoch, sig)
    slots = np.full((2, N_SLOTS), -1, dtype=np.int64)
    slots[0, :3] = [0, 1, 2]
    slots[1, :3] = [3, 4, 5]
    args = (meas_epoch, node, node_t, t[meas_epoch], np.full(n, SPHERICAL), z, weight, s,
            np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.full(n, -1),
            np.zeros((1, 3, 3)), sensor, slots, xs, 6)
    return args, (t, truth, xs, z, s, sensor, meas_epoch, sig, node_t, node, weight, slots)


def test_schur_solution_equals_the_dense_least_squares():
    args, (t, truth, xs, z, s, sensor, meas_epoch, sig, node_t, node, weight, slots) = \
        _bias_problem(np.random.default_rng(5))
    n = len(sensor)
    Nxx, Nxc, Ncc, bx, bc, r = normal_equations(*args)
    q = np.full(len(node_t) - 1, 0.5)
    x_node = xs[np.round(node_t / 0.2).astype(int)]
    diag, upper, rhs = process_blocks(node_t, q, x_node)
    diag[0] += np.eye(9) * 1e-6
    S, srhs, Xc, xb = solve_joint(Nxx + diag, upper, Nxc, Ncc, bx + rhs, bc)
    c = np.linalg.solve(S, srhs)
    dx = xb - Xc @ c

    # dense: build the full weighted design independently (finite-difference Jacobians)
    G = len(node_t)
    rows_A, rows_b = [], []
    for i in range(n):
        g, dt = node[i], t[meas_epoch[i]] - node_t[node[i]]
        F = np.kron(np.array([[1, dt, dt * dt / 2], [0, 1, dt], [0, 0, 1]]), np.eye(3))
        x0 = xs[meas_epoch[i]]
        h0, _ = measure_py(SPHERICAL, x0, s[i], np.zeros(3), np.eye(3))
        J = np.zeros((6, 9))
        for j in range(9):
            e = np.zeros(9)
            e[j] = 1e-3
            hp, _ = measure_py(SPHERICAL, x0 + F @ e, s[i], np.zeros(3), np.eye(3))
            hm, _ = measure_py(SPHERICAL, x0 - F @ e, s[i], np.zeros(3), np.eye(3))
            J[:, j] = (hp - hm) / 2e-3
        for c_ in range(3):
            a = np.zeros(9 * G + 6)
            a[9 * g:9 * g + 9] = J[c_]
            a[9 * G + 3 * sensor[i] + c_] = 1.0
            w = 1.0 / sig[i, c_]
            res = z[i, c_] - h0[c_]
            rows_A.append(a * w)
            rows_b.append(res * w)
    for g in range(G - 1):
        d = node_t[g + 1] - node_t[g]
        F1 = np.array([[1, d, d * d / 2], [0, 1, d], [0, 0, 1]])
        Q1 = 0.5 * np.array([[d**5 / 20, d**4 / 8, d**3 / 6], [d**4 / 8, d**3 / 3, d**2 / 2],
                             [d**3 / 6, d**2 / 2, d]])
        L = np.linalg.cholesky(np.linalg.inv(np.kron(Q1, np.eye(3))))
        F = np.kron(F1, np.eye(3))
        e = x_node[g + 1] - F @ x_node[g]
        block = np.zeros((9, 9 * G + 6))
        block[:, 9 * g:9 * g + 9] = -F
        block[:, 9 * g + 9:9 * g + 18] = np.eye(9)
        rows_A.extend(L.T @ block)
        rows_b.extend(L.T @ (-e))
    prior = np.zeros((9, 9 * G + 6))
    prior[:, :9] = np.eye(9) * 1e-3
    rows_A.extend(prior)
    rows_b.extend(np.zeros(9))
    sol = np.linalg.lstsq(np.array(rows_A), np.array(rows_b), rcond=None)[0]
    # (finite-difference Jacobians in the dense oracle: agreement to ~1e-5 relative)
    np.testing.assert_allclose(c, sol[9 * G:], rtol=1e-4)
    np.testing.assert_allclose(dx.ravel(), sol[:9 * G], rtol=1e-4, atol=1e-3)


def test_the_divergence_guard_never_inflates_beyond_its_ceilings() -> None:
    from rangeproc.estimation.divergence import RESET_CEILING, reset_covariance

    P = np.diag(np.r_[np.full(3, 1e2), np.full(3, 1.0), np.full(3, 0.1)])
    reset_covariance(P, 100.0)                                  # far below the ceilings
    np.testing.assert_allclose(np.diag(P), np.r_[np.full(3, 1e4), np.full(3, 1e2),
                                                 np.full(3, 10.0)])
    P = np.diag(np.r_[np.full(3, 1e2), np.full(3, 1.0), np.full(3, 0.1)])
    reset_covariance(P, 1e6)                                    # each state to its ceiling
    np.testing.assert_allclose(np.diag(P), np.repeat(np.square(RESET_CEILING), 3))
    huge = np.diag(np.r_[np.full(3, 1e12), np.ones(6)])
    reset_covariance(huge, 1e6)
    assert huge[0, 0] == 1e12                                   # already there: no growth
    assert huge[3, 3] == RESET_CEILING[1] ** 2                  # the others still grow


def test_the_divergence_reset_drops_the_kinematic_correlations() -> None:
    """After a reset a position fix must not turn into a velocity error through the
    coasting model's position-velocity correlation; calibration states keep their block."""
    from rangeproc.estimation.divergence import reset_covariance

    rng = np.random.default_rng(3)
    A = rng.normal(size=(11, 11))
    P = A @ A.T + 11 * np.eye(11)
    cal = P[9:, 9:].copy()
    reset_covariance(P, 100.0)
    assert np.count_nonzero(P[:9, :] - np.diag(np.diag(P))[:9, :]) == 0
    np.testing.assert_array_equal(P[9:, 9:], cal)
    assert np.all(np.linalg.eigvalsh(P) > 0)


def test_normal_equations_without_residuals_give_the_same_sums():
    args, _ = _bias_problem(np.random.default_rng(13))
    full = normal_equations(*args)
    sums = normal_equations(*args, residuals=False)
    assert sums[5] is None and np.isfinite(full[5]).any()
    for a, b in zip(full[:5], sums[:5]):
        np.testing.assert_array_equal(a, b)
