"""Attitude: body->NED convention, Slerp interpolation with gaps, time-series helpers."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangeproc.errors import DataError
from rangeproc.frames.attitude import (
    NED_TO_ENU,
    body_to_ned,
    clean_series,
    interpolate_attitude,
    locate,
    rates_at_samples,
)

HYP = settings(derandomize=True, deadline=None, max_examples=150)
angles = st.floats(-np.pi, np.pi)
D = np.radians


def rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def hand_c(roll: float, pitch: float, yaw: float) -> np.ndarray:
    return rz(yaw) @ ry(pitch) @ rx(roll)


def test_ned_to_enu_constant():
    np.testing.assert_array_equal(NED_TO_ENU @ [1.0, 2.0, 3.0], [2.0, 1.0, -3.0])
    assert np.linalg.det(NED_TO_ENU) == pytest.approx(1.0)
    assert NED_TO_ENU.dtype == np.float64
    with pytest.raises(ValueError):
        NED_TO_ENU[0, 0] = 1.0


@HYP
@given(roll=angles, pitch=st.floats(-np.pi / 2, np.pi / 2), yaw=angles)
def test_body_to_ned_is_rz_ry_rx(roll, pitch, yaw):
    np.testing.assert_allclose(
        body_to_ned(roll, pitch, yaw).as_matrix(), hand_c(roll, pitch, yaw), atol=1e-14
    )


def test_body_to_ned_vectorised():
    rng = np.random.default_rng(0)
    r, p, y = rng.uniform(-1, 1, (3, 50))
    mats = body_to_ned(r, p, y).as_matrix()
    assert mats.shape == (50, 3, 3)
    for i in range(50):
        np.testing.assert_allclose(mats[i], hand_c(r[i], p[i], y[i]), atol=1e-14)
    assert body_to_ned(r, 0.0, 0.0).as_matrix().shape == (50, 3, 3)  # broadcasting


@HYP
@given(roll=angles, pitch=st.floats(-1.5, 1.5), yaw=angles)
def test_body_ned_round_trip(roll, pitch, yaw):
    c = body_to_ned(roll, pitch, yaw)
    y2, p2, r2 = c.as_euler("ZYX")
    np.testing.assert_allclose(body_to_ned(r2, p2, y2).as_matrix(), c.as_matrix(), atol=1e-13)
    assert p2 == pytest.approx(pitch, abs=1e-9)
    v = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(c.apply(c.apply(v), inverse=True), v, atol=1e-13)


def test_physical_sanity():
    # yaw 90 deg: bow points east (NED [0,1,0]; ENU [1,0,0])
    c = body_to_ned(0.0, 0.0, D(90.0))
    np.testing.assert_allclose(c.apply([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(NED_TO_ENU @ c.apply([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0], atol=1e-15)
    # yaw 90 deg: starboard points south
    np.testing.assert_allclose(c.apply([0.0, 1.0, 0.0]), [-1.0, 0.0, 0.0], atol=1e-15)
    # pitch +10 deg: bow up (negative down component)
    bow = body_to_ned(0.0, D(10.0), 0.0).apply([1.0, 0.0, 0.0])
    np.testing.assert_allclose(bow, [np.cos(D(10)), 0.0, -np.sin(D(10))], atol=1e-15)
    # roll +10 deg: starboard down
    stbd = body_to_ned(D(10.0), 0.0, 0.0).apply([0.0, 1.0, 0.0])
    np.testing.assert_allclose(stbd, [0.0, np.cos(D(10)), np.sin(D(10))], atol=1e-15)


# ---------------------------------------------------------------- interpolation

def test_slerp_across_yaw_wrap():
    t = np.array([0.0, 1.0])
    rot, valid = interpolate_attitude(t, [0.0, 0.0], [0.0, 0.0], [D(359.0), D(1.0)],
                                      [0.0, 0.25, 0.5, 0.75, 1.0])
    assert valid.all()
    yaw = np.degrees(rot.as_euler("ZYX")[:, 0]) % 360.0
    np.testing.assert_allclose((yaw + 180.0) % 360.0 - 180.0, [-1.0, -0.5, 0.0, 0.5, 1.0],
                               atol=1e-10)


def test_slerp_exact_at_samples_and_for_constant_rate():
    t = np.arange(0.0, 5.0, 0.5)
    roll, pitch, yaw = D(5.0) * np.ones_like(t), D(-3.0) * np.ones_like(t), 0.2 * t
    tq = np.linspace(0.0, 4.5, 37)
    rot, valid = interpolate_attitude(t, roll, pitch, yaw, tq)
    assert valid.all() and len(rot) == tq.size
    # constant yaw rate with fixed roll/pitch is NOT a single-axis rotation in body axes, but
    # at the samples Slerp must be exact
    on = np.isin(tq, t)
    ref = body_to_ned(roll[0], pitch[0], 0.2 * tq[on]).as_matrix()
    np.testing.assert_allclose(rot.as_matrix()[on], ref, atol=1e-14)
    # level, constant yaw rate: a fixed-axis rotation, Slerp is exact everywhere
    rot2, _ = interpolate_attitude(t, 0 * t, 0 * t, yaw, tq)
    np.testing.assert_allclose(rot2.as_matrix(), body_to_ned(0.0, 0.0, 0.2 * tq).as_matrix(),
                               atol=1e-14)


def test_valid_mask_span_and_gaps():
    t = np.array([0.0, 0.1, 0.2, 0.3, 2.0, 2.1, 2.2])  # 1.7 s gap between 0.3 and 2.0
    yaw = D(np.array([0.0, 1.0, 2.0, 3.0, 50.0, 51.0, 52.0]))
    z = np.zeros_like(t)
    tq = np.array([-0.5, 0.0, 0.15, 0.3, 0.31, 1.0, 1.9, 2.0, 2.05, 2.2, 2.3, np.nan])
    rot, valid = interpolate_attitude(t, z, z, yaw, tq, max_gap=1.0)
    np.testing.assert_array_equal(
        valid, [False, True, True, True, False, False, False, True, True, True, False, False]
    )
    got = np.degrees(rot.as_euler("ZYX")[:, 0])
    # invalid entries take the nearest sample, never NaN
    np.testing.assert_allclose(
        got, [0.0, 0.0, 1.5, 3.0, 3.0, 3.0, 50.0, 50.0, 50.5, 52.0, 52.0, 0.0], atol=1e-10
    )
    # a larger max_gap bridges the gap
    _, valid2 = interpolate_attitude(t, z, z, yaw, tq, max_gap=2.0)
    assert valid2[4:7].all()


def test_duplicates_nan_rows_and_errors():
    t = np.array([0.0, 0.5, 0.5, 1.0, 1.5])
    yaw = np.array([0.0, 0.1, 9.0, 0.3, np.nan])  # duplicate time: keep the first (0.1)
    z = np.zeros_like(t)
    rot, valid = interpolate_attitude(t, z, z, yaw, [0.5, 1.2, 1.5])
    assert rot[0].as_euler("ZYX")[0] == pytest.approx(0.1)
    np.testing.assert_array_equal(valid, [True, False, False])  # NaN row dropped: span ends at 1
    with pytest.raises(DataError, match="sorted"):
        interpolate_attitude([0.0, 2.0, 1.0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0.5])
    with pytest.raises(DataError, match="fewer than 2"):
        interpolate_attitude([0.0, 1.0], [0, np.nan], [0, 0], [0, 0], [0.5])
    rot1, v1 = interpolate_attitude([0.0, 1.0], [0, 0], [0, 0], [0, 1.0], 0.5)  # scalar query
    assert len(rot1) == 1 and v1.tolist() == [True]


def test_clean_series_reports_file_row():
    with pytest.raises(DataError, match="INS1: row 12: column time"):
        clean_series([0.0, 2.0, 1.0], [1, 2, 3], source="INS1", row=np.array([10, 11, 12]))
    t, (c,), keep = clean_series([0.0, 0.0, 1.0], [[1, 1], [2, 2], [3, np.nan]])
    np.testing.assert_array_equal(t, [0.0])
    np.testing.assert_array_equal(keep, [True, False, False])
    assert c.shape == (1, 2)


def test_locate_fraction_and_nearest():
    t = np.array([0.0, 1.0, 3.0])
    loc = locate(t, np.array([0.25, 1.0, 2.5, 3.0, 5.0]), max_gap=1.5)
    np.testing.assert_array_equal(loc.k, [0, 1, 1, 1, 1])
    np.testing.assert_allclose(loc.frac, [0.25, 0.0, 1.0, 1.0, 1.0])  # 2.5: nearest is 3
    np.testing.assert_array_equal(loc.valid, [True, True, False, True, False])
    np.testing.assert_allclose(loc.t_eval, [0.25, 1.0, 3.0, 3.0, 3.0])


def test_rates_at_samples_second_order_and_gaps():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.05, 0.15, 40))
    f = 3.0 * t**2 - t + 2.0  # quadratic: non-uniform central differences are exact
    slopes = (np.diff(f) / np.diff(t))[:, None] * [1.0, -2.0]
    rate = rates_at_samples(t, slopes, max_gap=1.0)
    np.testing.assert_allclose(rate[1:-1, 0], 6.0 * t[1:-1] - 1.0, rtol=1e-10)
    np.testing.assert_allclose(rate[:, 1], -2.0 * rate[:, 0])
    np.testing.assert_allclose(rate[[0, -1], 0], slopes[[0, -1], 0])  # one-sided ends
    # gaps after samples 9, 19 and 20: one-sided at gap edges, 0 for the isolated sample 20
    t2 = t.copy()
    t2[10:] += 5.0
    t2[20:] += 5.0
    t2[21:] += 5.0
    s2 = (np.diff(f) / np.diff(t2))[:, None]
    r2 = rates_at_samples(t2, s2, max_gap=1.0)
    assert r2[9, 0] == pytest.approx(s2[8, 0])
    assert r2[10, 0] == pytest.approx(s2[10, 0])
    assert r2[19, 0] == pytest.approx(s2[18, 0])
    assert r2[20, 0] == 0.0
    assert r2[21, 0] == pytest.approx(s2[21, 0])
