"""simulate_multi kind ``harbour``: a ferry's radar, lidar and cameras among extended hulls,
a ship leaving a quay, moored boats, quays and clutter, in the Autoferry conversion's form.

The checks recompute geometry from the truth files (truth.csv hull centre and heading,
truth_platform.csv, the dimensions and lever arms in truth_events.json) with plain
trigonometry, not the simulator's code; files are read back with rangeproc's own readers.
"""
from __future__ import annotations

import filecmp
import json
import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomllib

from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.evaluate.truth import read_truth
from rangeproc.simulate import MULTI_KINDS, simulate_multi
from rangeproc.stages.read import read_all
from rangeproc.stages.screen import screen

SEEDS = (2, 3)  # one ferry with deck angles (yaw = heading), one north-up (yaw 0)
DUR = 150.0


class Scene:
    """One simulated harbour folder and its truth, with geometry rebuilt from the files."""

    def __init__(self, cfg_path: Path):
        self.dir = cfg_path.parent
        self.cfg = tomllib.loads(cfg_path.read_text())
        self.sensor = {s["id"]: s for s in self.cfg["sensors"]}
        self.truth = pd.read_csv(self.dir / "truth.csv")
        self.platform = pd.read_csv(self.dir / "truth_platform.csv")
        self.assoc = pd.read_csv(self.dir / "truth_association.csv", keep_default_na=False)
        self.events = json.loads((self.dir / "truth_events.json").read_text())
        self.north_up = self.events["ferry"]["north_up"]

    def rows(self, sid: str) -> tuple[pd.DataFrame, pd.DataFrame]:
        """The sensor's file rows and their association rows (same order)."""
        df = pd.read_csv(self.dir / self.sensor[sid]["file"])
        lab = self.assoc[self.assoc["sensor"] == sid].reset_index(drop=True)
        assert lab["row"].tolist() == list(range(len(df))), sid
        return df, lab

    def ferry(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ferry reference point (M, 2) m and yaw (M,) rad at times t (linear)."""
        p = self.platform
        pos = np.column_stack([np.interp(t, p["time"], p[c]) for c in ("e", "n")])
        yaw = np.interp(t, p["time"], np.unwrap(np.radians(p["yaw"])))
        return pos, yaw

    def sensor_pos(self, sid: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sensor position (M, 2) m and the ferry's yaw (M,) rad at times t."""
        pos, yaw = self.ferry(t)
        x, y = self.sensor[sid]["lever_arm"][:2]
        off = np.column_stack((x * np.sin(yaw) + y * np.cos(yaw),
                               x * np.cos(yaw) - y * np.sin(yaw)))
        return pos + off, yaw

    def hull(self, oid: str, t: np.ndarray) -> np.ndarray:
        """(M, 4, 2) hull corners of object oid at times t, from truth.csv and the events."""
        tr = self.truth[self.truth["target_id"] == oid]
        c = np.column_stack([np.interp(t, tr["time"], tr[k]) for k in ("hull_e", "hull_n")])
        psi = np.interp(t, tr["time"], np.unwrap(np.radians(tr["heading"])))
        ob = self.events["objects"][oid]
        fwd = np.column_stack((np.sin(psi), np.cos(psi)))
        stb = np.column_stack((np.cos(psi), -np.sin(psi)))
        hl, hb = ob["length_m"] / 2, ob["beam_m"] / 2
        return np.stack([c + sf * hl * fwd + ss * hb * stb
                         for sf, ss in ((1, 1), (-1, 1), (-1, -1), (1, -1))], axis=1)

    def bearing(self, sid: str, t: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """(M,) deck bearing (rad) of sea-level points pts (M, 2) from the sensor."""
        s, yaw = self.sensor_pos(sid, t)
        d = pts - s
        return np.mod(np.arctan2(d[:, 0], d[:, 1]) - yaw, 2 * math.pi)


@pytest.fixture(scope="module", params=SEEDS, ids=lambda s: f"seed{s}")
def scene(request, tmp_path_factory):
    return Scene(simulate_multi(tmp_path_factory.mktemp("harbour") / "h", kind="harbour",
                                seed=request.param, duration=DUR))


@pytest.fixture(scope="module")
def exact(tmp_path_factory):
    """Both ferry forms without noise (clutter and the hull spread kept)."""
    return [Scene(simulate_multi(tmp_path_factory.mktemp("exact") / f"h{s}", kind="harbour",
                                 seed=s, duration=DUR, noise=False)) for s in SEEDS]


def test_harbour_is_a_kind():
    assert MULTI_KINDS["harbour"] == (3, 4)


def test_seeds_cover_both_ferry_forms(exact):
    assert {s.north_up for s in exact} == {True, False}


def test_contract_form_and_read_back_without_warning(scene, caplog):
    """The recordings' conversion form, read by rangeproc's read and screen stages with no
    warning and no unit suspicion; truth read by ``rangeproc evaluate``'s reader."""
    cfg = scene.cfg
    assert "targets" not in cfg and cfg["output"]["rate_hz"] == 5.0
    kinds = {s["id"]: s["kind"] for s in cfg["sensors"]}
    assert {k: kinds[k] for k in ("FERRY", "RADAR", "LIDAR", "EO")} == {
        "FERRY": "ins", "RADAR": "radar", "LIDAR": "radar", "EO": "theodolite"}
    for _sid, s in scene.sensor.items():
        df = pd.read_csv(scene.dir / s["file"])
        assert "track_id" not in df.columns
        if s["kind"] == "ins":
            assert list(df.columns) == ["time", "roll", "pitch", "yaw", "lat", "lon", "height"]
            assert (df["yaw"] == 0).all() == scene.north_up
            continue
        assert s["platform"] == "FERRY"
        assert (s["lever_arm"] == [0.0, 0.0, 0.0]) == scene.north_up
        want = ["time", "range", "azimuth", "elevation"] if s["kind"] == "radar" else \
            ["time", "azimuth", "elevation"]
        assert list(df.columns) == want and df["elevation"].isna().all()
    caplog.set_level(logging.WARNING, logger="rangeproc")
    conf = load_config(scene.dir / "scenario.toml")
    logs = read_all(conf)
    screened = screen(conf, logs)
    assert not screened.unit_suspicions
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    for sid, log in logs.items():
        assert log.n_read == len(pd.read_csv(scene.dir / scene.sensor[sid]["file"])), sid
    truth = read_truth(scene.dir / "truth.csv")
    assert set(truth.target_id) == set(scene.events["objects"]) and len(set(truth.target_id)) >= 3
    assert set(scene.assoc["sensor"]) == {k for k, v in kinds.items() if v != "ins"}


def _returns(sc: Scene, sid: str, oid: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True times (M,), sensor positions (M, 2) and the points (M, 2) m of object oid's rows,
    placed from the ferry's true pose at their true time by range and deck azimuth."""
    df, lab = sc.rows(sid)
    m = (lab["target_id"] == oid).to_numpy()
    t = lab["true_time"].to_numpy(float)[m]
    s, yaw = sc.sensor_pos(sid, t)
    az = np.radians(df["azimuth"].to_numpy(float)[m]) + yaw
    p = s + df["range"].to_numpy(float)[m, None] * np.column_stack((np.sin(az), np.cos(az)))
    return t, s, p


def _side_check(corners: np.ndarray, s: np.ndarray, p: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point p (M, 2): distance (m) to the nearest side of its hull (corners (M, 4, 2)),
    whether that side's outer side faces the sensor s (M, 2), and the distance along it."""
    a, b = corners, np.roll(corners, -1, axis=1)
    e = b - a
    u = np.clip(np.einsum("mkj,mkj->mk", p[:, None] - a, e) / np.einsum("mkj,mkj->mk", e, e),
                0, 1)
    dist = np.linalg.norm(p[:, None] - (a + u[..., None] * e), axis=2)
    side = np.argmin(dist, axis=1)
    k = np.arange(p.shape[0])
    out = np.stack((-e[k, side, 1], e[k, side, 0]), axis=1)       # outward: corners clockwise
    facing = np.einsum("mj,mj->m", s - 0.5 * (a[k, side] + b[k, side]), out) > 0
    return dist[k, side], facing, np.linalg.norm(p - a[k, side], axis=1)


def test_returns_lie_on_the_visible_side(exact):
    """Noise-free radar and lidar returns of every object, placed from the ferry's true pose
    at their true time, lie on a side of the hull whose outer side faces the sensor, spread
    along it (not one point, not the centre)."""
    for sc in exact:
        for sid in ("RADAR", "LIDAR"):
            _, lab = sc.rows(sid)
            seen = 0
            for oid in sorted(set(lab["target_id"]) - {""}):
                t, s, p = _returns(sc, sid, oid)
                dist, facing, along = _side_check(sc.hull(oid, t), s, p)
                assert dist.max() < 0.3, (sid, oid, dist.max())
                assert facing.all(), (sid, oid)
                beam = sc.events["objects"][oid]["beam_m"]
                centre = sc.hull(oid, t).mean(axis=1)
                assert np.linalg.norm(p - centre, axis=1).min() > 0.5 * beam - 0.3
                if t.size > 20:
                    assert np.ptp(along) > 0.5 * beam, (sid, oid)
                seen += t.size
            assert seen > 20 or sid == "LIDAR", (sid, seen)


def test_negative_control_far_side_fails_the_geometry_check(exact):
    """The same check rejects returns moved to the hull's far side (mirrored through the
    centre: still on the hull, on sides facing away from the sensor)."""
    for sc in exact:
        t, s, p = _returns(sc, "RADAR", "B1")
        corners = sc.hull("B1", t)
        far = 2 * corners.mean(axis=1) - p
        dist, facing, _ = _side_check(corners, s, far)
        assert dist.max() < 0.3 and not facing.any()


def _camera_residuals(sc: Scene, sid: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per object: frame times and bearing residuals (rad) against the centre of the hull's
    angular extent rebuilt from the truth files."""
    df, lab = sc.rows(sid)
    out = []
    for oid in sorted(set(lab["target_id"]) - {""}):
        m = (lab["target_id"] == oid).to_numpy()
        t = df["time"].to_numpy(float)[m]
        corners = sc.hull(oid, t)
        b = np.stack([sc.bearing(sid, t, corners[:, i]) for i in range(4)], axis=1)
        d = np.mod(b - b[:, :1] + math.pi, 2 * math.pi) - math.pi
        centre = b[:, 0] + 0.5 * (d.min(axis=1) + d.max(axis=1))
        res = np.mod(np.radians(df["azimuth"].to_numpy(float)[m]) - centre + math.pi,
                     2 * math.pi) - math.pi
        out.append((t, res))
    return out


def test_camera_bearing_is_the_hull_centre_without_noise(exact):
    for sc in exact:
        for _t, res in _camera_residuals(sc, "EO"):
            assert np.abs(res).max() < math.radians(0.02)


def test_camera_errors_are_ar1_with_the_set_correlation(tmp_path):
    """Over a seeded 300 s draw, the EO residuals of consecutive frames correlate as the
    AR(1) set (rho in truth_events.json) and their spread is its sigma; a white-noise
    control (the same residuals shuffled) is far from it."""
    sc = Scene(simulate_multi(tmp_path / "h", kind="harbour", seed=5, duration=300.0))
    eo = sc.events["sensors"]["EO"]
    rho, sigma, step = eo["rho"], math.radians(eo["sigma_azimuth"]), 1.0 / eo["rate"]
    x, y, pooled = [], [], []
    for t, res in _camera_residuals(sc, "EO"):
        nxt = np.abs(np.diff(t) - step) < 1e-3
        x.append(res[:-1][nxt])
        y.append(res[1:][nxt])
        pooled.append(res)
    x, y = np.concatenate(x), np.concatenate(y)
    assert x.size > 2000
    r = float(np.corrcoef(x, y)[0, 1])
    assert abs(r - rho) < 0.04, (r, rho)
    allres = np.concatenate(pooled)
    assert abs(np.std(allres) / sigma - 1) < 0.15
    shuffled = np.random.default_rng(0).permutation(np.concatenate((x, y)))
    assert abs(np.corrcoef(shuffled[:x.size], shuffled[x.size:])[0, 1]) < 0.1


def test_ship_leaves_the_quay_on_time(exact):
    for sc in exact:
        ev = next(e for e in sc.events["events"] if e["event"] == "quay_departure")
        t0 = sc.truth["time"].min()
        assert 40.0 <= ev["time"] - t0 <= 50.0 and ev["objects"] == ["B2"]
        ship = sc.truth[sc.truth["target_id"] == "B2"]
        t = ship["time"].to_numpy()
        c = ship[["hull_e", "hull_n"]].to_numpy()
        step = np.linalg.norm(c - c[0], axis=1)
        assert step[t <= ev["time"]].max() < 1e-6          # lies still until then
        assert step[t <= ev["time"] + 1.0].max() < 0.5     # and starts gently
        assert step[t >= ev["time"] + 15.0].min() > 20.0   # then it is under way
        # it lay alongside Q1: its hull centre beam/2 + 1 m off the quay line
        q = sc.events["quays"]["Q1"]
        a, b = np.array(q["a"]), np.array(q["b"])
        d = (b - a) / np.linalg.norm(b - a)
        off = c[0] - a
        gap = abs(off[0] * d[1] - off[1] * d[0])
        assert abs(gap - (sc.events["objects"]["B2"]["beam_m"] / 2 + 1.0)) < 0.02
        assert sc.events["objects"]["B2"]["moving"][0] == pytest.approx(ev["time"], abs=0.06)
        # the radar saw it at the quay, and under way
        lab = sc.assoc[(sc.assoc["sensor"] == "RADAR") & (sc.assoc["target_id"] == "B2")]
        tt = lab["true_time"].to_numpy(float)
        assert (tt < ev["time"]).sum() >= 5 and (tt > ev["time"] + 20).sum() >= 5
        for oid, ob in sc.events["objects"].items():
            if ob["role"] == "moored":
                m = sc.truth[sc.truth["target_id"] == oid]
                assert m[["e", "n", "hull_e", "hull_n", "heading"]].nunique().max() == 1
                assert ob["moving"] is None


def test_truth_antenna_is_the_lever_arm_off_the_centre(scene):
    for oid, ob in scene.events["objects"].items():
        tr = scene.truth[scene.truth["target_id"] == oid]
        psi = np.radians(tr["heading"].to_numpy())
        x, y = ob["antenna_lever_arm_m"]
        e = tr["hull_e"] + x * np.sin(psi) + y * np.cos(psi)
        n = tr["hull_n"] + x * np.cos(psi) - y * np.sin(psi)
        np.testing.assert_allclose(tr["e"], e, atol=1e-5)
        np.testing.assert_allclose(tr["n"], n, atol=1e-5)
    boat = scene.truth[scene.truth["target_id"] == "B1"]
    speed = np.hypot(boat["ve"], boat["vn"])
    assert speed.min() > 1.0


def test_stated_sigma_is_the_residuals_robust_spread(scene):
    """The radar's stated range and azimuth sigmas are the 1.4826 x MAD of its object rows'
    residuals against the antenna truth at the stamps; not the generator's own sigma."""
    df, lab = scene.rows("RADAR")
    m = (lab["target_id"] != "").to_numpy()
    t = df["time"].to_numpy(float)[m]
    ids = lab["target_id"].to_numpy()[m]
    ant = np.zeros((t.size, 2))
    for oid in set(ids):
        k = ids == oid
        tr = scene.truth[scene.truth["target_id"] == oid]
        ant[k] = np.column_stack([np.interp(t[k], tr["time"], tr[c]) for c in ("e", "n")])
    s, _ = scene.sensor_pos("RADAR", t)
    rng = np.linalg.norm(ant - s, axis=1)
    d_az = np.mod(np.radians(df["azimuth"].to_numpy(float)[m]) - scene.bearing("RADAR", t, ant)
                  + math.pi, 2 * math.pi) - math.pi

    def spread(x):
        return 1.4826 * np.median(np.abs(x - np.median(x)))

    sigma = scene.sensor["RADAR"]["sigma"]
    assert spread(df["range"].to_numpy(float)[m] - rng) == pytest.approx(sigma["range"],
                                                                         rel=0.03)
    assert math.degrees(spread(d_az)) == pytest.approx(sigma["azimuth"], rel=0.03)
    gen = scene.events["sensors"]["RADAR"]
    assert sigma["range"] > 1.2 * gen["sigma_range"]
    assert gen["stated_sigma"]["range"] == pytest.approx(sigma["range"], rel=1e-3)


def test_clutter_and_quay_returns(scene):
    """Sea clutter: Poisson at the documented rate per scan; quay returns at the quays'
    fixed scatterers; radar plots share their scan's stamp, one plot per object per scan."""
    df, lab = scene.rows("RADAR")
    gen = scene.events["sensors"]["RADAR"]
    stamps = np.unique(df["time"])
    assert np.allclose(np.diff(stamps), gen["period"], atol=1e-5)
    n_scans = int(round(DUR / gen["period"]))
    sea = (lab["source"] == "sea").sum()
    lam = gen["sea_clutter_per_scan"]
    assert abs(sea - lam * n_scans) < 4 * math.sqrt(lam * n_scans) + 2
    per_scan = lab[lab["target_id"] != ""].groupby([df["time"], lab["target_id"]]).size()
    assert per_scan.max() == 1
    scans_b1 = per_scan.xs("B1", level=1).size
    assert 0.75 * stamps.size < scans_b1 <= stamps.size     # Pd 0.9 (in coverage)
    quay = lab["source"].str.startswith("Q").to_numpy()
    assert quay.sum() > 0
    s, yaw = scene.sensor_pos("RADAR", lab["true_time"].to_numpy(float)[quay])
    az = np.radians(df["azimuth"].to_numpy(float)[quay]) + yaw
    p = s + df["range"].to_numpy(float)[quay, None] * np.column_stack((np.sin(az),
                                                                        np.cos(az)))
    sc = np.concatenate([np.array(q["scatterers"]) for q in scene.events["quays"].values()])
    nearest = np.min(np.linalg.norm(p[:, None] - sc[None], axis=2), axis=1)
    assert np.median(nearest) < 3 * scene.events["sensors"]["RADAR"]["sigma_range"] + 10


def test_same_seed_identical_files(tmp_path):
    a = simulate_multi(tmp_path / "a", kind="harbour", seed=7, duration=60.0).parent
    b = simulate_multi(tmp_path / "b", kind="harbour", seed=7, duration=60.0).parent
    c = simulate_multi(tmp_path / "c", kind="harbour", seed=8, duration=60.0).parent
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {"truth.csv", "truth_platform.csv", "truth_association.csv", "truth_events.json",
            "scenario.toml", "FERRY.csv", "RADAR.csv", "EO.csv"} <= set(names)
    for name in names:
        assert filecmp.cmp(a / name, b / name, shallow=False), name
    assert not filecmp.cmp(a / "RADAR.csv", c / "RADAR.csv", shallow=False)


@pytest.mark.parametrize("n", [3, 4])
def test_n_objects(tmp_path, n):
    sc = Scene(simulate_multi(tmp_path, kind="harbour", seed=1, duration=40.0, n_objects=n))
    assert sorted(sc.events["objects"]) == ["B1", "B2", "M1", "M2"][:n]


def test_bad_n_objects(tmp_path):
    with pytest.raises(ConfigError, match="n_objects=5"):
        simulate_multi(tmp_path / "x", kind="harbour", seed=1, duration=60.0, n_objects=5)
    assert not (tmp_path / "x").exists()


def test_visible_points_unit():
    """Dead ahead only the bow is seen; abeam only one long side; from inside nothing."""
    from rangeproc.simulate.harbour_motion import hull_corners, visible_points
    rng = np.random.default_rng(1)
    corners = hull_corners(np.zeros((3, 2)), np.zeros(3), 20.0, 6.0)   # heading north
    sensor = np.array([[0.0, 100.0], [100.0, 0.0], [1.0, 2.0]])       # ahead, abeam, inside
    pts, hull = visible_points(rng, corners, sensor, np.array([50, 50, 50]))
    assert np.bincount(hull, minlength=3).tolist() == [50, 50, 0]
    np.testing.assert_allclose(pts[hull == 0, 1], 10.0)                # the bow, n = L/2
    assert np.ptp(pts[hull == 0, 0]) > 4.0
    np.testing.assert_allclose(pts[hull == 1, 0], 3.0)                 # starboard, e = B/2
