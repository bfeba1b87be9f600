"""A recorded track as the simulator's truth (``simulate.recorded``, ``rangeproc simulate
--trajectory``): the smoothing spline against an analytic maneuver, the re-placement, the
geodetic form, and bad files."""
from __future__ import annotations

import math

import numpy as np
import pymap3d as pm
import pytest

from rangeproc.simulate.recorded import (
    PLACE_DISTANCE,
    RECORD_SIGMA,
    RECORD_SIGMA_V,
    read_recording,
    recorded_trajectory,
)
from tests.conftest import describe, invoke

G = 9.80665


def _turn(t: np.ndarray):
    """A level 2 g turn at 200 m/s, climbing at 20 m/s: position, velocity, acceleration."""
    w = 2.0 * G / 200.0
    r = 200.0 / w
    p = np.column_stack([r * np.sin(w * t), r * np.cos(w * t), 6000.0 + 20.0 * t])
    v = np.column_stack([200.0 * np.cos(w * t), -200.0 * np.sin(w * t), np.full_like(t, 20.0)])
    a = np.column_stack([-200.0 * w * np.sin(w * t), -200.0 * w * np.cos(w * t),
                         np.zeros_like(t)])
    return p, v, a


@pytest.mark.parametrize("with_velocity", [False, True])
def test_a_sampled_turn_comes_back_within_its_noise(with_velocity):
    """Samples at 1 Hz with the noise the spline assumes (RECORD_SIGMA m, RECORD_SIGMA_V m/s):
    the smoothed track keeps the turn's shape to a few sigmas (with velocities, positions
    are their integral: its error wanders)."""
    t = np.arange(0.0, 120.0, 1.0)
    p, v, _ = _turn(t)
    g = np.random.default_rng(1)
    tr = recorded_trajectory(t, p + g.normal(0.0, RECORD_SIGMA, p.shape),
                             v + g.normal(0.0, RECORD_SIGMA_V, v.shape) if with_velocity
                             else None, 1000.0, 200.0, 0.5)
    tt = np.arange(10.0, 110.0, 0.37)               # away from the ends, between samples
    P, V, A = tr.state(1000.0 + tt)
    p0, v0, a0 = _turn(tt)
    shift = (P - p0).mean(axis=0)                   # the re-placement moves the track only
    assert np.abs(P - p0 - shift).max() < 4.0 * RECORD_SIGMA
    assert np.abs(V - v0).max() < 2.0 * RECORD_SIGMA_V
    assert np.abs(A - a0).max() < 0.25 * 2.0 * G
    assert shift[2] == pytest.approx(0.0, abs=RECORD_SIGMA)     # heights are kept


def test_the_track_is_placed_around_the_origin_and_retimed():
    t = 5000.0 + np.arange(0.0, 300.0, 1.0)
    p, v, _ = _turn(t - 5000.0)
    tr = recorded_trajectory(t, p, v, 123.0, 100.5, math.radians(90.0))
    assert tr.t0 == 123.0 and tr.duration == pytest.approx(100.0)
    P = tr.state(tr.node_time)[0]
    assert P[:, :2].mean(axis=0) == pytest.approx([PLACE_DISTANCE, 0.0], abs=20.0)
    assert tr.node_time[1] - tr.node_time[0] == pytest.approx(0.01)
    assert tr.node_p.shape == tr.node_v.shape == tr.node_a.shape == (len(tr.node_time), 3)


def test_a_geodetic_recording_with_velocities_is_read_in_one_local_frame(tmp_path):
    """A 60 km straight leg due east: velocities given in each point's own ENU are rotated
    into the first point's frame, where they agree with the positions' differences."""
    t = np.arange(0.0, 300.0, 1.0)
    lat0, lon0, h0 = 48.7, -1.4, 6000.0
    e = 200.0 * t
    lat, lon, h = pm.enu2geodetic(e, 0 * e, 0 * e, lat0, lon0, h0)
    # each point's local east, north, up velocity of that straight ENU line
    x, y, z = pm.enu2uvw(np.full_like(t, 200.0), 0 * t, 0 * t, lat0, lon0)
    ve, vn, vu = pm.uvw2enu(x, y, z, lat, lon)
    path = tmp_path / "leg.csv"
    rows = ["time,lat,lon,height,ve,vn,vu"] + [
        f"{a},{b:.9f},{c:.9f},{d:.3f},{f:.5f},{g_:.5f},{k:.5f}"
        for a, b, c, d, f, g_, k in zip(t, lat, lon, h, ve, vn, vu)]
    path.write_text("\n".join(rows) + "\n")
    tt, pos, vel = read_recording(path)
    assert np.abs(np.diff(pos, axis=0) - vel[1:]).max() < 0.05
    assert np.abs(vel - [200.0, 0.0, 0.0]).max() < 0.05


def test_simulate_flies_a_recorded_track(tmp_path):
    t = np.arange(0.0, 60.0, 1.0)
    p, v, _ = _turn(t)
    path = tmp_path / "track.csv"
    path.write_text("time,e,n,u,ve,vn,vu\n" + "".join(
        f"{a},{b},{c},{d},{e},{f},{g}\n" for a, (b, c, d), (e, f, g) in zip(t, p, v)))
    res = invoke(["simulate", tmp_path / "sc", "--trajectory", path, "--duration", 40,
                  "--quiet"])
    assert res.exit_code == 0, describe(res)
    truth = np.genfromtxt(tmp_path / "sc" / "truth.csv", delimiter=",", names=True,
                          dtype=None, encoding="utf-8")
    span = truth["time"][-1] - truth["time"][0]
    assert span == pytest.approx(40.0, abs=0.6)
    speed = np.hypot(truth["ve"], truth["vn"])
    assert np.abs(speed - 200.0).max() < 2.0 * RECORD_SIGMA_V   # the recorded flight


@pytest.mark.parametrize("text, says", [
    ("time,e,n,u\n0,1,2,3\n1,1,2,x\n", "row 2"),
    ("time,e,n\n0,1,2\n", "u"),
    ("time,e,n,u\n" + "".join(f"{i},{i},0,0\n" for i in range(5)), "at least 12"),
])
def test_a_bad_recording_is_one_line_naming_the_file(tmp_path, text, says):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    res = invoke(["simulate", tmp_path / "sc", "--trajectory", path])
    assert res.exit_code == 2, describe(res)
    assert "bad.csv" in res.stderr and says in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_a_recorded_track_is_not_for_several_objects(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("time,e,n,u\n" + "".join(f"{i},{i},0,0\n" for i in range(20)))
    res = invoke(["simulate", tmp_path / "sc", "--trajectory", path, "--objects", "crossing"])
    assert res.exit_code == 2 and "--trajectory" in res.stderr, describe(res)
