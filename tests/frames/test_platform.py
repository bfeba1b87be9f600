"""Moving platform: deck <-> stabilised angles and sensor geometry from an INS log.

The brute-force truth uses pymap3d directly and hand-written Rz Ry Rx matrices, not rangeproc.
"""
from __future__ import annotations

import numpy as np
import pymap3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangeproc.config import Geodetic
from rangeproc.errors import DataError
from rangeproc.frames.geodesy import RangeFrame, enu_to_aer
from rangeproc.frames.platform import (
    deck_angles,
    deck_to_range,
    deck_to_stabilised,
    deck_unit_vector,
    platform_geometry,
    range_to_deck,
    stabilised_to_deck,
)
from rangeproc.io.logs import SensorLog

HYP = settings(derandomize=True, deadline=None, max_examples=150)
D = np.radians
N2E = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def hand_c(roll, pitch, yaw) -> np.ndarray:
    """(..., 3, 3) Rz(yaw) @ Ry(pitch) @ Rx(roll), written out by hand."""
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, float) for a in (roll, pitch, yaw)))
    o, z = np.ones_like(roll), np.zeros_like(roll)

    def m(rows):
        return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)

    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (np.cos, np.sin))
    rx = m([[o, z, z], [z, cr, -sr], [z, sr, cr]])
    ry = m([[cp, z, sp], [z, o, z], [-sp, z, cp]])
    rz = m([[cy, -sy, z], [sy, cy, z], [z, z, o]])
    return rz @ ry @ rx


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ---------------------------------------------------------------- deck angles

def test_deck_unit_vector_reference_and_inverse():
    np.testing.assert_allclose(deck_unit_vector(0.0, 0.0), [1.0, 0.0, 0.0], atol=1e-16)
    np.testing.assert_allclose(deck_unit_vector(D(90.0), 0.0), [0.0, 1.0, 0.0], atol=1e-16)
    np.testing.assert_allclose(deck_unit_vector(0.0, D(90.0)), [0.0, 0.0, -1.0], atol=1e-16)
    np.testing.assert_allclose(deck_unit_vector(D(-90.0), D(-30.0)),
                               [0.0, -np.cos(D(30)), 0.5], atol=1e-16)
    az, el = deck_angles([[0.0, -1.0, 0.0], [-1e-300, 1.0, 0.0], [1.0, 0.0, 1.0]])
    np.testing.assert_allclose(az, [1.5 * np.pi, 0.5 * np.pi, 0.0], atol=1e-15)
    np.testing.assert_allclose(el, [0.0, 0.0, -np.pi / 4], atol=1e-15)


def test_stabilisation_physical_sanity():
    # pitch +10 deg (bow up): straight ahead on the deck appears 10 deg above the horizon
    az, el = deck_to_stabilised(0.0, 0.0, 0.0, D(10.0), 0.0)
    assert az == pytest.approx(0.0, abs=1e-15) and el == pytest.approx(D(10.0), abs=1e-15)
    # roll +10 deg (starboard down): a starboard-beam target at deck el 0 appears at -10 deg
    az, el = deck_to_stabilised(D(90.0), 0.0, D(10.0), 0.0, D(30.0))
    assert az == pytest.approx(D(120.0), abs=1e-14) and el == pytest.approx(D(-10.0), abs=1e-14)
    # yaw 90 deg (heading east): dead ahead is az 90 deg
    az, el = deck_to_stabilised(0.0, D(5.0), 0.0, 0.0, D(90.0))
    assert az == pytest.approx(D(90.0)) and el == pytest.approx(D(5.0))
    assert np.ndim(az) == 0


@HYP
@given(az=st.floats(0.0, 6.28), el=st.floats(-1.5, 1.5), yaw=st.floats(-7.0, 7.0))
def test_level_platform_only_rotates_azimuth(az, el, yaw):
    az_s, el_s = deck_to_stabilised(az, el, 0.0, 0.0, yaw)
    assert wrap(az_s - az - yaw) == pytest.approx(0.0, abs=1e-9)
    assert el_s == pytest.approx(el, abs=1e-12)
    assert 0.0 <= az_s < 2 * np.pi


@HYP
@given(
    az=st.floats(-7.0, 7.0), el=st.floats(-1.55, 1.55),
    roll=st.floats(-np.pi, np.pi), pitch=st.floats(-1.5, 1.5), yaw=st.floats(-np.pi, np.pi),
)
def test_deck_stabilised_round_trip_and_hand_matrix(az, el, roll, pitch, yaw):
    az_s, el_s = deck_to_stabilised(az, el, roll, pitch, yaw)
    # independent: NED unit vector = hand C @ FRD unit vector
    u_b = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), -np.sin(el)])
    u_n = hand_c(roll, pitch, yaw) @ u_b
    u_s = np.array([np.cos(el_s) * np.cos(az_s), np.cos(el_s) * np.sin(az_s), -np.sin(el_s)])
    np.testing.assert_allclose(u_s, u_n, atol=1e-12)
    az_u, el_u = stabilised_to_deck(az_s, el_s, roll, pitch, yaw)
    np.testing.assert_allclose(deck_unit_vector(az_u, el_u), u_b, atol=1e-12)
    assert el_u == pytest.approx(el, abs=1e-9)


def test_stabilisation_vectorised_broadcasting():
    rng = np.random.default_rng(0)
    az, el = rng.uniform(0, 6, (4, 5)), rng.uniform(-1, 1, (4, 5))
    az_s, el_s = deck_to_stabilised(az, el, D(3.0), D(-2.0), rng.uniform(0, 6, 5))
    assert az_s.shape == el_s.shape == (4, 5)
    az_u, el_u = stabilised_to_deck(az_s, el_s, D(3.0), D(-2.0), rng.uniform(0, 6, 5))
    assert az_u.shape == (4, 5)


# ---------------------------------------------------------------- platform geometry

ORIGIN = Geodetic(lat=34.0, lon=-119.5, height=0.0)
FRAME = RangeFrame(ORIGIN)
T0 = 1000.0  # INS time scale need not start at 0
LEVER = np.array([12.0, -3.0, -18.0])  # body FRD, m


def true_pos(t):
    """(N, 3) ship INS point in range ENU: straight run plus heave."""
    s = np.asarray(t, float) - T0
    return np.stack([2.0e4 + 6.0 * s, -1.5e4 + 8.0 * s, 1.0 * np.sin(2 * np.pi * s / 8.0)], -1)


def true_vel(t):
    s = np.asarray(t, float) - T0
    return np.stack([6.0 + 0 * s, 8.0 + 0 * s, (2 * np.pi / 8.0) * np.cos(2 * np.pi * s / 8.0)], -1)


def true_att(t):
    s = np.asarray(t, float) - T0
    roll = D(10.0) * np.sin(2 * np.pi * s / 8.0 + 0.4)
    pitch = D(3.0) * np.sin(2 * np.pi * s / 6.0)
    yaw = D(40.0) + D(1.0) * s
    return roll, pitch, yaw


def true_geodetic(t):
    p = true_pos(t)
    return pymap3d.enu2geodetic(p[:, 0], p[:, 1], p[:, 2], ORIGIN.lat, ORIGIN.lon, ORIGIN.height)


def local_to_range(lat, lon):
    """(N, 3, 3) local ENU at (lat, lon) -> range ENU, built from pymap3d vector transforms."""
    cols = []
    for v in np.eye(3):
        u, vv, w = pymap3d.enu2uvw(v[0], v[1], v[2], lat, lon)
        cols.append(np.stack(pymap3d.ecef2enuv(u, vv, w, ORIGIN.lat, ORIGIN.lon), -1))
    return np.stack(cols, axis=-1)


def true_body_to_range(t):
    lat, lon, _ = true_geodetic(t)
    return local_to_range(lat, lon) @ N2E @ hand_c(*true_att(t))


def true_sensor(t, lever=LEVER):
    return true_pos(t) + true_body_to_range(t) @ lever


def make_ins(t, *, with_velocity: bool, drop=None) -> SensorLog:
    lat, lon, h = true_geodetic(t)
    roll, pitch, yaw = true_att(t)
    if with_velocity:
        v_local = np.einsum("nji,nj->ni", local_to_range(lat, lon), true_vel(t))  # L v
    else:
        v_local = np.full((t.size, 3), np.nan)
    cols = dict(roll=roll, pitch=pitch, yaw=yaw, lat=lat, lon=lon, height=h,
                ve=v_local[:, 0], vn=v_local[:, 1], vu=v_local[:, 2])
    if drop is not None:
        for k in ("roll", "lat"):
            cols[k] = np.where(drop, np.nan, cols[k])
    n = t.size
    return SensorLog(sensor_id="SHIP_INS", kind="ins", time=t, columns=cols,
                     row=np.arange(1, n + 1), track_id=None, station=None, n_read=n)


T_INS = T0 + np.arange(0.0, 20.0 + 1e-9, 0.01)  # 100 Hz, 20 s


def test_geometry_at_ins_samples_matches_brute_force():
    ins = make_ins(T_INS, with_velocity=True)
    g = platform_geometry(ins, FRAME, T_INS, LEVER)
    assert g.position.shape == (T_INS.size, 3) and g.body_to_range.shape == (T_INS.size, 3, 3)
    assert g.valid.all()
    np.testing.assert_allclose(g.body_to_range, true_body_to_range(T_INS), atol=1e-12)
    np.testing.assert_allclose(g.position, true_sensor(T_INS), rtol=0, atol=1e-6)
    # zero lever arm: the INS point itself
    g0 = platform_geometry(ins, FRAME, T_INS)
    np.testing.assert_allclose(g0.position, true_pos(T_INS), rtol=0, atol=1e-6)


@pytest.mark.parametrize("with_velocity", [True, False], ids=["ins_velocity", "differenced"])
def test_moving_rolling_ship_between_samples(with_velocity):
    rng = np.random.default_rng(7)
    tq = np.sort(rng.uniform(T_INS[1], T_INS[-2], 3000))
    g = platform_geometry(make_ins(T_INS, with_velocity=with_velocity), FRAME, tq, LEVER)
    assert g.valid.all()
    # lever-arm position vs brute force (linear/Slerp interpolation error only)
    assert np.max(np.abs(g.position - true_sensor(tq))) < 1e-3
    rot = g.body_to_range
    np.testing.assert_allclose(rot @ np.swapaxes(rot, 1, 2), np.broadcast_to(np.eye(3), rot.shape),
                               atol=1e-12)
    # velocity vs central finite difference of the true sensor position
    h = 1e-4
    v_fd = (true_sensor(tq + h) - true_sensor(tq - h)) / (2 * h)
    assert np.max(np.abs(g.velocity - v_fd)) < 1e-3
    # the lever-arm rate matters here (roll 10 deg at 8 s period, 18 m lever arm: ~1.5 m/s)
    assert np.max(np.linalg.norm(v_fd - true_vel(tq), axis=1)) > 1.0
    # self-consistency: velocity vs finite difference of the returned positions
    hs = 0.03
    gp = platform_geometry(make_ins(T_INS, with_velocity=with_velocity), FRAME,
                           np.r_[tq + hs, tq - hs], LEVER).position
    v_self = (gp[: tq.size] - gp[tq.size:]) / (2 * hs)
    inner = (tq > T_INS[0] + hs) & (tq < T_INS[-1] - hs)
    assert np.max(np.abs(g.velocity - v_self)[inner]) < 2e-3


def test_valid_mask_outside_span_and_in_gaps():
    t = T_INS[~((T_INS > T0 + 5.0) & (T_INS < T0 + 6.5))]  # 1.5 s gap
    drop = (t > T0 + 12.0) & (t < T0 + 13.2)  # NaN attitude/position rows: 1.2 s gap
    ins = make_ins(t, with_velocity=False, drop=drop)
    tq = T0 + np.array([-1.0, 0.0, 2.0, 5.0, 5.5, 6.0, 6.5, 8.0, 12.5, 19.0, 20.0, 21.0])
    g = platform_geometry(ins, FRAME, tq, LEVER, max_gap=1.0)
    np.testing.assert_array_equal(
        g.valid, [False, True, True, True, False, False, True, True, False, True, True, False]
    )
    for a in (g.position, g.velocity, g.body_to_range):
        assert np.isfinite(a).all()
    # invalid entries carry the nearest sample
    np.testing.assert_allclose(g.position[0], true_sensor(T_INS[:1])[0], atol=1e-6)
    np.testing.assert_allclose(g.position[5], true_sensor(T0 + np.array([6.5]))[0], atol=1e-6)
    g2 = platform_geometry(ins, FRAME, tq, LEVER, max_gap=2.0)
    assert g2.valid[4] and g2.valid[5] and g2.valid[8]


def test_geometry_errors():
    ins = make_ins(T_INS[:10], with_velocity=False)
    cols = {k: v for k, v in ins.columns.items() if k != "yaw"}
    bad = SensorLog(sensor_id="SHIP_INS", kind="ins", time=ins.time, columns=cols, row=ins.row,
                    track_id=None, station=None, n_read=10)
    with pytest.raises(DataError, match="SHIP_INS: column yaw"):
        platform_geometry(bad, FRAME, [T0])
    nan_all = make_ins(T_INS[:10], with_velocity=False, drop=np.arange(10) > 0)
    with pytest.raises(DataError, match="SHIP_INS: fewer than 2"):
        platform_geometry(nan_all, FRAME, [T0])
    with pytest.raises(ValueError):
        platform_geometry(ins, FRAME, [T0], lever_arm=(1.0, 2.0))


def test_deck_measurements_round_trip_and_stabilised_aer():
    """Deck angles of a target, stabilised with the INS attitude, equal the AER of the target
    in the local ENU frame at the sensor (conventions tied end to end)."""
    rng = np.random.default_rng(3)
    tq = T_INS[::50]
    g = platform_geometry(make_ins(T_INS, with_velocity=True), FRAME, tq, LEVER)
    target = g.position + rng.uniform(-3e4, 3e4, (tq.size, 3)) * [1, 1, 0.2] + [0, 0, 4e3]
    az_u, el_u, r = range_to_deck(g, target)
    np.testing.assert_allclose(deck_to_range(g, az_u, el_u, r), target, atol=1e-7)
    az_s, el_s = deck_to_stabilised(az_u, el_u, *true_att(tq))
    lat, lon, _ = true_geodetic(tq)
    local = np.einsum("nji,nj->ni", local_to_range(lat, lon), target - g.position)
    az_ref, el_ref, r_ref = enu_to_aer(local)
    np.testing.assert_allclose(wrap(az_s - az_ref), 0.0, atol=1e-9)
    np.testing.assert_allclose(el_s, el_ref, atol=1e-9)
    np.testing.assert_allclose(r, r_ref, rtol=1e-12)


def test_geometry_query_shapes():
    ins = make_ins(T_INS[:100], with_velocity=False)
    g1 = platform_geometry(ins, FRAME, T0 + 0.5, LEVER)  # scalar -> N = 1
    assert g1.position.shape == (1, 3) and g1.valid.tolist() == [True]
    g0 = platform_geometry(ins, FRAME, np.array([]), LEVER)
    assert g0.position.shape == (0, 3) and g0.body_to_range.shape == (0, 3, 3)
    assert g0.valid.dtype == bool
