"""Truth trajectory: self-consistency, maneuver levels, envelope."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.simulate.trajectory import G0, Pulses, integrate_nodes, plan_trajectory

T0 = 345_600.0


@pytest.fixture(scope="module", params=[1, 2, 7])
def traj(request):
    return plan_trajectory(np.random.default_rng(request.param), 900.0, T0)


def test_pulse_integral_matches_quadrature():
    p = Pulses.from_list([(1.0, 1.5, 2.0, 0.3), (8.0, 1.0, 0.0, -0.5), (12.0, 2.0, 5.0, 1.0)])
    tau = np.linspace(-1.0, 25.0, 260_001)
    val, integral = p.evaluate(tau)
    trap = np.concatenate(([0.0], np.cumsum(0.5 * (val[1:] + val[:-1]) * np.diff(tau))))
    np.testing.assert_allclose(integral, trap, atol=1e-9)
    np.testing.assert_allclose(integral[-1], 0.3 * 3.5 - 0.5 * 1.0 + 1.0 * 7.0, atol=1e-12)
    # continuous value with bounded slope: smoothstep peak slope 1.5 * amp / ramp = 0.75 here
    slope = np.abs(np.diff(val) / np.diff(tau)).max()
    assert 0.74 < slope < 0.76


def test_state_derivatives_consistent(traj):
    t = T0 + np.linspace(0.3, 899.7, 5001)
    d = 1e-3
    p, v, a = traj.state(t)
    pp, vp, _ = traj.state(t + d)
    pm_, vm, _ = traj.state(t - d)
    np.testing.assert_allclose((pp - pm_) / (2 * d), v, atol=2e-4)
    np.testing.assert_allclose((vp - vm) / (2 * d), a, atol=2e-4)


def test_nodes_reproduced_and_integration_converged(traj):
    p, v, a = traj.state(traj.node_time[:2000])
    np.testing.assert_allclose(p, traj.node_p[:2000], atol=1e-6)
    np.testing.assert_allclose(v, traj.node_v[:2000], atol=1e-9)
    fine, _, _ = integrate_nodes(traj.v0, traj.psi0, 0.0,
                                 (traj.speed_rate, traj.turn_rate, traj.path_rate),
                                 traj.node_p[0], traj.duration, traj.h / 10)
    np.testing.assert_allclose(fine[::10], traj.node_p, atol=1e-5)


def test_truth_100hz_differences_match_velocity(traj):
    h = traj.h
    dp = (traj.node_p[2:] - traj.node_p[:-2]) / (2 * h)
    np.testing.assert_allclose(dp, traj.node_v[1:-1], atol=5e-3)
    da = (traj.node_v[2:] - traj.node_v[:-2]) / (2 * h)
    np.testing.assert_allclose(da, traj.node_a[1:-1], atol=5e-3)


def test_acceleration_continuous_finite_jerk(traj):
    jerk = np.linalg.norm(np.diff(traj.node_a, axis=0), axis=1) / traj.h
    assert jerk.max() < 300.0


def test_turn_levels_within_bounds(traj):
    turns = [s for s in traj.segments if s.kind == "turn" and s.end < traj.duration]
    assert len(turns) >= 3
    for s in turns:
        t = traj.t0 + np.linspace(s.start, s.end, 2001)
        _, v, a = traj.state(t)
        a_h = np.linalg.norm(a[:, :2], axis=1)
        assert 3.0 * G0 * 0.999 <= a_h.max() <= 6.0 * G0 * 1.001
        np.testing.assert_allclose(a_h.max(), s.level * G0, rtol=1e-3)
        np.testing.assert_allclose(v[:, 2], 0.0, atol=1e-9)  # level turn
    a_all = np.linalg.norm(traj.node_a, axis=1)
    assert a_all.max() <= 6.0 * G0 * 1.001
    kinds = {s.kind for s in traj.segments}
    assert {"turn", "climb", "speed"} <= kinds


def test_envelope(traj):
    r = np.hypot(traj.node_p[:, 0], traj.node_p[:, 1])
    assert 7e3 < r.min() and r.max() < 62e3
    assert 3000.0 <= traj.node_p[:, 2].min() and traj.node_p[:, 2].max() <= 8000.0
    speed = np.linalg.norm(traj.node_v, axis=1)
    assert 150.0 <= speed.min() and speed.max() <= 300.0


def test_deterministic_by_seed():
    a = plan_trajectory(np.random.default_rng(5), 300.0, T0)
    b = plan_trajectory(np.random.default_rng(5), 300.0, T0)
    c = plan_trajectory(np.random.default_rng(6), 300.0, T0)
    np.testing.assert_array_equal(a.node_p, b.node_p)
    assert not np.allclose(a.node_p[-1], c.node_p[-1])
