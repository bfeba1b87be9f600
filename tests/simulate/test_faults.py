"""simulate_scenario(faults=...): systematic sensor faults with truth (data contract section 4).

Checks are independent of the simulator's geometry code: biases against the same seed's
fault-free files; latency against truth.csv (cubic Hermite interpolation) with pyproj; the mount
rotation against the fault-free deck angles and against a re-derivation from the scenario's
truth objects (ship motion, trajectory) with scipy rotations composed axis by axis.
"""
from __future__ import annotations

import filecmp
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomllib
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from rangeproc.cli import main
from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.simulate import REGISTRATION_FAULTS, draw_scenario, resolve_faults, simulate_scenario
from rangeproc.simulate import sensors as sn
from geo_oracle import TO_GEO, ecef, enu_basis, truth_splines

DUR = 40.0
ARCSEC = math.pi / (180.0 * 3600.0)
TO_RAD = {"deg": math.pi / 180.0, "rad": 1.0, "mil": 2.0 * math.pi / 6400.0}
FILES = ("R1.csv", "TH1.parquet", "S1.csv", "SHIP_INS.csv", "G1.csv", "MISTRAM.csv",
         "truth.csv", "scenario.toml")
BIASES = {"R1": {"range": 15.0, "azimuth": 0.5e-3, "elevation": 0.5e-3},
          "TH1": {"range": 3.0, "azimuth": 20 * ARCSEC, "elevation": -20 * ARCSEC},
          "S1": {"range": -7.5, "azimuth": -1e-3, "elevation": 2e-3}}


def wrap(a: np.ndarray) -> np.ndarray:
    """Angle difference (rad) wrapped to [-pi, pi)."""
    return np.mod(a + math.pi, 2 * math.pi) - math.pi


class Run:
    """One simulated folder: config, files, truth.csv interpolants."""

    def __init__(self, folder: Path, seed: int, sensors: str = "all", noise: bool = False,
                 faults=None):
        self.dir, self.seed = folder, seed
        self.cfg_path = simulate_scenario(folder, seed=seed, duration=DUR, sensors=sensors,
                                          noise=noise, faults=faults)
        self.cfg = tomllib.loads(self.cfg_path.read_text())
        self.sensor = {s["id"]: s for s in self.cfg["sensors"]}
        o = self.cfg["range"]["origin"]
        self.o_ecef = ecef(o["lat"], o["lon"], o["height"])[0]
        self.o_rot = enu_basis(o["lat"], o["lon"])[0]
        self.p, self.v = truth_splines(folder)

    def read(self, sid: str) -> tuple[pd.DataFrame, np.ndarray]:
        """The sensor's rows and their measurement times (stamp + time_offset, s)."""
        path = self.dir / self.sensor[sid]["file"]
        df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
        if pd.api.types.is_numeric_dtype(df["time"]):
            t = df["time"].to_numpy(float)
        else:
            t = (pd.to_datetime(df["time"], utc=True).dt.as_unit("ns").astype("int64")
                 .to_numpy() / 1e9)
        return df, t + self.sensor[sid]["time_offset"]

    def angles_rad(self, sid: str, df: pd.DataFrame, col: str) -> np.ndarray:
        return df[col].to_numpy(float) * TO_RAD[self.sensor[sid].get("angle_unit", "deg")]

    def target_ecef(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Target ECEF position and velocity (M, 3) from truth.csv."""
        return self.o_ecef + self.p(t) @ self.o_rot, self.v(t) @ self.o_rot

    def site_rae(self, sid: str, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """Range (m), azimuth, elevation (rad), range rate (m/s) from a fixed site at true t."""
        x, v = self.target_ecef(t)
        site = self.sensor[sid]["site"]
        d = x - ecef(site["lat"], site["lon"], site["height"])
        enu = d @ enu_basis(site["lat"], site["lon"])[0].T
        rng = np.linalg.norm(d, axis=1)
        return (rng, np.mod(np.arctan2(enu[:, 0], enu[:, 1]), 2 * math.pi),
                np.arctan2(enu[:, 2], np.hypot(enu[:, 0], enu[:, 1])),
                np.einsum("ij,ij->i", d, v) / rng)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("faults")


# ------------------------------------------------------------------------------------------
# (a) biases = measured minus true, added before noise
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed,noise", [(1, False), (3, False), (5, False), (2, True)])
def test_biases_shift_rows_exactly(root, seed, noise):
    """Seeds 1/3/5: TH1 in deg (laser), mil (no laser), rad (laser); seed 2 with noise: the
    noise, wild points and empty cells are the same draws with and without faults."""
    ids = "R1,TH1,S1,SHIP_INS"
    clean = Run(root / f"a{seed}{noise:d}", seed, ids, noise)
    bad = Run(root / f"a{seed}{noise:d}f", seed, ids, noise, faults=BIASES)
    assert filecmp.cmp(clean.dir / "SHIP_INS.csv", bad.dir / "SHIP_INS.csv", shallow=False)
    for sid, bias in BIASES.items():
        a, ta = clean.read(sid)
        b, tb = bad.read(sid)
        assert len(a) > 50, sid
        np.testing.assert_array_equal(ta, tb)
        assert list(a.columns) == list(b.columns)
        if "range" in a:
            ok = a["range"].notna().to_numpy()
            assert np.array_equal(ok, b["range"].notna().to_numpy())
            np.testing.assert_allclose((b["range"] - a["range"])[ok], bias["range"],
                                       atol=1.1e-4)
        if "range_rate" in a:
            np.testing.assert_array_equal(b["range_rate"], a["range_rate"])
        for k in ("azimuth", "elevation"):
            ra, rb = clean.angles_rad(sid, a, k), bad.angles_rad(sid, b, k)
            assert np.array_equal(np.isnan(ra), np.isnan(rb)), (sid, k)
            ok = np.isfinite(ra)
            np.testing.assert_allclose(wrap(rb[ok] - ra[ok]), bias[k], atol=1e-9,
                                       err_msg=f"{sid} {k}")
        az = bad.angles_rad(sid, b, "azimuth")
        az = az[np.isfinite(az)]
        assert np.all((az >= 0) & (az < 2 * math.pi)), sid
    assert ("range" in bad.read("TH1")[0]) == (seed % 4 < 2)


def test_azimuth_bias_wraps():
    az = np.array([2 * math.pi - 1e-4, 1e-4, math.pi])
    rae = (np.array([1e3, 2e3, np.nan]), az, np.zeros(3), np.ones(3))
    r, a, e, rr = sn.add_biases(rae, {"range": 15.0, "azimuth": 5e-4, "elevation": -1e-3})
    np.testing.assert_allclose(a, [4e-4, 6e-4, math.pi + 5e-4], atol=1e-15)
    np.testing.assert_array_equal(r, [1015.0, 2015.0, np.nan])
    np.testing.assert_array_equal(e, -1e-3)
    assert rr is rae[3]
    _, a, _ = sn.add_biases(rae[:3], {"azimuth": -2e-4})
    np.testing.assert_allclose(a, [2 * math.pi - 3e-4, 2 * math.pi - 1e-4, math.pi - 2e-4],
                               atol=1e-15)


# ------------------------------------------------------------------------------------------
# (b) latency = stamp minus true time: the row stamped t holds the geometry of t - latency
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed,latency", [(4, 0.040), (1, -0.030)])
def test_latency_fixed_sites(root, seed, latency):
    """R1 (seed 4: R1 also has the known time_offset 0.05, independent of the fault) and TH1
    (seed 1: the one with time_offset): values at stamp t are the truth at t - latency."""
    faults = {"R1": {"latency": latency}, "TH1": {"latency": latency}}
    clean = Run(root / f"b{seed}", seed, "R1,TH1")
    run = Run(root / f"b{seed}f", seed, "R1,TH1", faults=faults)
    assert run.sensor[("R1", "TH1")[seed % 4 == 1]]["time_offset"] == 0.05
    for sid in ("R1", "TH1"):
        df, t = run.read(sid)
        rng, az, el, rr = run.site_rae(sid, t - latency)
        if "range" in df:
            ok = df["range"].notna().to_numpy()
            np.testing.assert_allclose(df["range"][ok], rng[ok], atol=2e-3)
        np.testing.assert_allclose(wrap(run.angles_rad(sid, df, "azimuth") - az), 0,
                                   atol=2e-8)
        np.testing.assert_allclose(run.angles_rad(sid, df, "elevation"), el, atol=2e-8)
        if "range_rate" in df:
            np.testing.assert_allclose(df["range_rate"], rr, atol=1e-4)
        # sensitivity: the truth at the stamp itself is far off
        _, az_t, _, _ = run.site_rae(sid, t)
        assert np.abs(wrap(run.angles_rad(sid, df, "azimuth") - az_t)).max() > 1e-5
    # R1: same stamps as without the fault
    np.testing.assert_array_equal(clean.read("R1")[1], run.read("R1")[1])


def test_latency_gps_and_mistram(root):
    """Seed 2: ISO GPS times and G1 with time_offset 0.05; MISTRAM stamps early (-20 ms)."""
    lat_g, lat_m = 0.040, -0.020
    faults = {"G1": {"latency": lat_g}, "MISTRAM": {"latency": lat_m}}
    clean = Run(root / "g", 2, "G1,MISTRAM")
    run = Run(root / "gf", 2, "G1,MISTRAM", faults=faults)
    assert run.sensor["G1"]["time_offset"] == 0.05
    df, t = run.read("G1")
    np.testing.assert_array_equal(t, clean.read("G1")[1])
    x, v = run.target_ecef(t - lat_g)
    lon, lat, h = TO_GEO.transform(x[:, 0], x[:, 1], x[:, 2])
    np.testing.assert_allclose(df["lat"], lat, atol=1e-9)
    np.testing.assert_allclose(df["lon"], lon, atol=1e-9)
    np.testing.assert_allclose(df["height"], h, atol=1e-3)
    v_rx = np.einsum("mij,mj->mi", enu_basis(lat, lon), v)
    np.testing.assert_allclose(df[["ve", "vn", "vu"]].to_numpy(), v_rx, atol=1e-4)
    assert np.abs(df["height"] - TO_GEO.transform(*run.target_ecef(t)[0].T)[2]).max() > 0.01

    df, t = run.read("MISTRAM")
    np.testing.assert_array_equal(t, clean.read("MISTRAM")[1])
    st = {s["id"]: s for s in run.sensor["MISTRAM"]["stations"]}
    pos = np.array([ecef(st[s]["lat"], st[s]["lon"], st[s]["height"])[0] for s in df["station"]])
    x, v = run.target_ecef(t - lat_m)
    d = x - pos
    np.testing.assert_allclose(df["range_rate"], np.einsum("ij,ij->i", d, v)
                               / np.linalg.norm(d, axis=1), atol=1e-4)


# ------------------------------------------------------------------------------------------
# (c) mount rotation of S1 (with latency and biases on top)
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [3, 5])
def test_mount_yaw_shifts_deck_azimuth(root, seed):
    """A pure mount yaw turns about the deck normal: azimuth - yaw, elevation and range kept,
    whatever the ship's roll and pitch (an antenna yawed +0.3 deg reads 0.3 deg less)."""
    yaw = math.radians(0.3)
    clean = Run(root / f"c{seed}", seed, "S1,SHIP_INS")
    run = Run(root / f"c{seed}f", seed, "S1,SHIP_INS", faults={"S1": {"mount_yaw": yaw}})
    a, ta = clean.read("S1")
    b, tb = run.read("S1")
    np.testing.assert_array_equal(ta, tb)
    np.testing.assert_allclose(b["range"], a["range"], atol=1e-4)
    d_az = wrap(run.angles_rad("S1", b, "azimuth") - clean.angles_rad("S1", a, "azimuth"))
    np.testing.assert_allclose(d_az, -yaw, atol=1e-9)
    np.testing.assert_allclose(run.angles_rad("S1", b, "elevation"),
                               clean.angles_rad("S1", a, "elevation"), atol=1e-9)


def _rot(axis: int, angle: np.ndarray) -> Rotation:
    vec = np.zeros((np.size(angle), 3))
    vec[:, axis] = angle
    return Rotation.from_rotvec(vec)


@pytest.mark.parametrize("seed", [3, 5])
def test_mount_latency_and_bias_against_truth(root, seed):
    """S1 with a full mount, latency and biases against a re-derivation from the scenario's
    truth objects at t - latency: d_sensor = M^T C_bn^T (p_target - p_ship - C_bn lever), NED at
    the ship, M = Rz(yaw) Ry(pitch) Rx(roll); then measured = true + bias. Seed 3: S1 also has
    the known time_offset 0.05; seed 5: heading near north (yaw wraps)."""
    mount = {"mount_roll": 0.004, "mount_pitch": -0.006, "mount_yaw": math.radians(0.3)}
    f = {**mount, "latency": 0.040, "range": 12.0, "azimuth": 0.7e-3, "elevation": -0.4e-3}
    run = Run(root / f"m{seed}", seed, "S1,SHIP_INS", faults={"S1": f})
    assert (run.sensor["S1"]["time_offset"] == 0.05) == (seed == 3)
    df, t = run.read("S1")
    sc = draw_scenario(seed, DUR)
    tt = t - f["latency"]
    lat, lon, h = sc.ship.geodetic(tt - sc.t0)
    att = sc.ship.attitude(tt - sc.t0)
    c_bn = _rot(2, att[:, 2]) * _rot(1, att[:, 1]) * _rot(0, att[:, 0])
    m = (_rot(2, mount["mount_yaw"]) * _rot(1, mount["mount_pitch"])
         * _rot(0, mount["mount_roll"]))
    ned = enu_basis(lat, lon)[:, [1, 0, 2], :] * np.array([1.0, 1.0, -1.0])[None, :, None]
    lever = np.array(run.sensor["S1"]["lever_arm"])
    p_sensor = ecef(lat, lon, h) + np.einsum("mji,mj->mi", ned, c_bn.apply(lever))
    x = run.o_ecef + sc.traj.state(tt)[0] @ run.o_rot
    d = m.apply(c_bn.apply(np.einsum("mij,mj->mi", ned, x - p_sensor), inverse=True),
                inverse=True)
    np.testing.assert_allclose(df["range"], np.linalg.norm(d, axis=1) + f["range"], atol=2e-4)
    az = np.arctan2(d[:, 1], d[:, 0]) + f["azimuth"]
    el = np.arctan2(-d[:, 2], np.hypot(d[:, 0], d[:, 1])) + f["elevation"]
    np.testing.assert_allclose(wrap(run.angles_rad("S1", df, "azimuth") - az), 0, atol=1e-9)
    np.testing.assert_allclose(run.angles_rad("S1", df, "elevation"), el, atol=1e-9)
    # the INS file is untouched by S1's faults and is the same ship (noise-free)
    ins, t_ins = run.read("SHIP_INS")
    np.testing.assert_allclose(ins["roll"], np.degrees(sc.ship.attitude(t_ins - sc.t0)[:, 0]),
                               atol=1e-7)


# ------------------------------------------------------------------------------------------
# (d) validation, (e) no faults = today's files, (f) truth_calibration.json, CLI preset
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("faults,needle", [
    ({"R2": {"range": 1.0}}, "unknown sensor id 'R2'"),
    ({"R1": {"bias": 1.0}}, "unknown fault 'bias'"),
    ({"SHIP_INS": {"latency": 0.01}}, "faults.SHIP_INS.latency: not applicable"),
    ({"R1": {"mount_yaw": 0.01}}, "faults.R1.mount_yaw: not applicable"),
    ({"TH1": {"mount_roll": 0.01}}, "not applicable"),
    ({"G1": {"range": 1.0}}, "faults.G1.range: not applicable"),
    ({"MISTRAM": {"azimuth": 1e-3}}, "not applicable"),
    ({"R1": {"range": float("nan")}}, "faults.R1.range"),
    ({"R1": {"range": "15"}}, "faults.R1.range"),
    ({"R1": {"range": True}}, "faults.R1.range"),
    ({"S1": {"mount_yaw": 0.3 * 180 / math.pi}}, "SI units"),  # degrees given for radians
    ({"S1": {"latency": 40.0}}, "faults.S1.latency"),
    ({"R1": 15.0}, "faults.R1"),
    ("registration", "faults="),
])
def test_invalid_faults_raise_config_error(tmp_path, faults, needle):
    with pytest.raises(ConfigError, match="simulate: ") as info:
        simulate_scenario(tmp_path / "x", seed=1, duration=DUR, faults=faults)
    assert needle in str(info.value)
    assert not (tmp_path / "x").exists()  # checked before anything is written


def test_no_faults_is_todays_output(tmp_path):
    base = simulate_scenario(tmp_path / "a", seed=6, duration=DUR).parent
    for name, faults in (("b", None), ("c", {})):
        other = simulate_scenario(tmp_path / name, seed=6, duration=DUR, faults=faults).parent
        for f in FILES:
            assert filecmp.cmp(base / f, other / f, shallow=False), (name, f)
        assert sorted(p.name for p in other.iterdir()) == sorted(p.name for p in base.iterdir())
    assert not (base / "truth_calibration.json").exists()
    # a faulted run changes only the faulted sensors' files (+ the config comment)
    bad = simulate_scenario(tmp_path / "d", seed=6, duration=DUR, faults=REGISTRATION_FAULTS).parent
    for f in ("SHIP_INS.csv", "G1.csv", "MISTRAM.csv", "truth.csv"):
        assert filecmp.cmp(base / f, bad / f, shallow=False), f
    for f in ("R1.csv", "TH1.parquet", "S1.csv"):
        assert not filecmp.cmp(base / f, bad / f, shallow=False), f
    # rewriting the folder without faults removes the now stale truth
    simulate_scenario(tmp_path / "d", seed=6, duration=DUR)
    assert not (bad / "truth_calibration.json").exists()
    assert filecmp.cmp(base / "R1.csv", bad / "R1.csv", shallow=False)


def test_truth_calibration_json(tmp_path):
    cfg = simulate_scenario(tmp_path / "a", seed=3, duration=DUR, faults=REGISTRATION_FAULTS)
    doc = json.loads((cfg.parent / "truth_calibration.json").read_text())
    # seed 3: S1 also has the scenario's known time_offset of +0.05 s (its stamps are 50 ms
    # early); the contract's latency is the residual after that offset: the fault, 0.04 s
    assert {s.id: s.time_offset for s in load_config(cfg).sensors}["S1"] == 0.05
    assert doc == {"R1": {"range": 15.0, "azimuth": 0.5e-3, "elevation": 0.5e-3},
                   "TH1": {"azimuth": pytest.approx(20 * ARCSEC),
                           "elevation": pytest.approx(-20 * ARCSEC)},
                   "S1": {"mount_yaw": pytest.approx(math.radians(0.3)),
                          "latency": pytest.approx(0.04)}}
    assert {s.id for s in load_config(cfg).sensors} == {"R1", "TH1", "S1", "SHIP_INS", "G1",
                                                        "MISTRAM"}
    assert not list(tmp_path.rglob("*.tmp"))
    # only the sensors written; ints accepted as SI floats
    cfg = simulate_scenario(tmp_path / "b", seed=3, duration=DUR, sensors="R1,G1",
                            faults={"R1": {"range": 15}, "S1": {"latency": 0.04}})
    doc = json.loads((cfg.parent / "truth_calibration.json").read_text())
    assert doc == {"R1": {"range": 15.0}} and isinstance(doc["R1"]["range"], float)


def test_cli_faults_preset_and_json(tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["simulate", str(tmp_path / "a"), "--duration", "20",
                               "--sensors", "R1,S1,SHIP_INS", "--faults", "registration",
                               "-q"])
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "a" / "truth_calibration.json").read_text())
    assert doc == {k: REGISTRATION_FAULTS[k] for k in ("R1", "S1")}
    # the preset's former name is still accepted (not listed in the help)
    assert resolve_faults("issue8") is resolve_faults("Registration") is REGISTRATION_FAULTS
    res = runner.invoke(main, ["simulate", "--help"])
    assert "'registration'" in res.output and "issue8" not in res.output
    spec = json.dumps({"R1": {"range": 15.0}})
    res = runner.invoke(main, ["simulate", str(tmp_path / "b"), "--duration", "20",
                               "--sensors", "R1", "--faults", spec, "-q"])
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "b" / "truth_calibration.json").read_text()) == {
        "R1": {"range": 15.0}}
    path = tmp_path / "f.json"
    path.write_text(spec)
    res = runner.invoke(main, ["simulate", str(tmp_path / "c"), "--duration", "20",
                               "--sensors", "R1", "--faults", str(path), "-q"])
    assert res.exit_code == 0, res.output
    assert filecmp.cmp(tmp_path / "b" / "R1.csv", tmp_path / "c" / "R1.csv", shallow=False)
    res = runner.invoke(main, ["simulate", str(tmp_path / "d"), "--duration", "20",
                               "--faults", "none", "-q"])
    assert res.exit_code == 0 and not (tmp_path / "d" / "truth_calibration.json").exists()
    for bad, needle in (("issue9", "issue9"), ('{"R1": {"rnage": 1}}', "rnage"),
                        ("{bad json", "unreadable")):
        res = runner.invoke(main, ["simulate", str(tmp_path / "e"), "--faults", bad])
        assert res.exit_code == 2, res.output
        assert res.stderr.startswith("rangeproc: error: simulate: faults") and needle in res.stderr
    assert not (tmp_path / "e").exists()
