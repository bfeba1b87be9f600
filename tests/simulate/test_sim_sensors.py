"""Independent re-derivation of simulated measurements from the written files.

Noise-free scenarios are re-computed here with pyproj (geodetic <-> ECEF) and explicit
rotation matrices, from truth.csv (cubic Hermite interpolation) and the config, i.e. from what
a processor sees, not from the simulator's geometry code.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomllib
from scipy.interpolate import CubicSpline

from rangeproc.simulate import draw_scenario, simulate_scenario
from geo_oracle import TO_GEO, ecef, enu_basis, truth_splines

DUR = 90.0



class Run:
    def __init__(self, root: Path, seed: int, sensors: str = "all", noise: bool = False):
        self.dir = root / f"s{seed}_{int(noise)}_{sensors.replace(',', '_')}"
        simulate_scenario(self.dir, seed=seed, duration=DUR, sensors=sensors, noise=noise)
        self.cfg = tomllib.loads((self.dir / "scenario.toml").read_text())
        self.sensor = {s["id"]: s for s in self.cfg["sensors"]}
        o = self.cfg["range"]["origin"]
        self.o_ecef = ecef(o["lat"], o["lon"], o["height"])[0]
        self.o_rot = enu_basis(o["lat"], o["lon"])[0]
        self.p, self.v = truth_splines(self.dir)

    def read(self, sid: str) -> tuple[pd.DataFrame, np.ndarray]:
        path = self.dir / self.sensor[sid]["file"]
        df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
        if not pd.api.types.is_numeric_dtype(df["time"]):
            t = (pd.to_datetime(df["time"], utc=True).dt.as_unit("ns").astype("int64")
                 .to_numpy() / 1e9)
        else:
            t = df["time"].to_numpy(float)
        return df, t + self.sensor[sid]["time_offset"]

    def target_ecef(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Target ECEF position and velocity (M, 3) from truth.csv."""
        return self.o_ecef + self.p(t) @ self.o_rot, self.v(t) @ self.o_rot


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("sim")


@pytest.mark.parametrize("seed", [1, 4])
def test_fixed_radar_matches_geometry(root, seed):
    run = Run(root, seed, "R1")
    df, t = run.read("R1")
    s = run.sensor["R1"]
    if seed == 4:
        assert s["time_offset"] == 0.05
    x, v = run.target_ecef(t)
    site = s["site"]
    d = x - ecef(site["lat"], site["lon"], site["height"])
    enu = d @ enu_basis(site["lat"], site["lon"])[0].T
    az = np.degrees(np.mod(np.arctan2(enu[:, 0], enu[:, 1]), 2 * math.pi))
    el = np.degrees(np.arctan2(enu[:, 2], np.hypot(enu[:, 0], enu[:, 1])))
    rng = np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(df["range"], rng, atol=2e-3)
    np.testing.assert_allclose(df["azimuth"], az, atol=1e-6)
    np.testing.assert_allclose(df["elevation"], el, atol=1e-6)
    if "range_rate" in df:
        np.testing.assert_allclose(df["range_rate"], np.einsum("ij,ij->i", d, v) / rng,
                                   atol=1e-4)
    assert (seed % 2 == 1) == ("range_rate" in df)


@pytest.mark.parametrize("seed", [3, 5])
def test_ship_radar_matches_geometry(root, seed):
    run = Run(root, seed, "S1,SHIP_INS")
    df, t = run.read("S1")
    ins, t_ins = run.read("SHIP_INS")
    order = np.argsort(t_ins)
    t_ins, ins = t_ins[order], ins.iloc[order]
    if seed == 3:
        assert run.sensor["S1"]["time_offset"] == 0.05
    yaw_unwrapped = np.degrees(np.unwrap(np.radians(ins["yaw"].to_numpy())))
    f = {k: CubicSpline(t_ins, ins[k].to_numpy()) for k in ("roll", "pitch", "lat", "lon",
                                                             "height")}
    r, p, y = (np.radians(f["roll"](t)), np.radians(f["pitch"](t)),
               np.radians(CubicSpline(t_ins, yaw_unwrapped)(t)))
    one, zero = np.ones_like(r), np.zeros_like(r)
    rz = np.stack((np.stack((np.cos(y), -np.sin(y), zero), -1),
                   np.stack((np.sin(y), np.cos(y), zero), -1), np.stack((zero, zero, one), -1)), 1)
    ry = np.stack((np.stack((np.cos(p), zero, np.sin(p)), -1), np.stack((zero, one, zero), -1),
                   np.stack((-np.sin(p), zero, np.cos(p)), -1)), 1)
    rx = np.stack((np.stack((one, zero, zero), -1), np.stack((zero, np.cos(r), -np.sin(r)), -1),
                   np.stack((zero, np.sin(r), np.cos(r)), -1)), 1)
    c_bn = rz @ ry @ rx
    lat, lon, h = f["lat"](t), f["lon"](t), f["height"](t)
    enu = enu_basis(lat, lon)
    ned = enu[:, [1, 0, 2], :] * np.array([1.0, 1.0, -1.0])[None, :, None]  # rows n, e, d
    lever = np.array(run.sensor["S1"]["lever_arm"])
    sensor = ecef(lat, lon, h) + np.einsum("mji,mj->mi", ned, c_bn @ lever)
    x, _ = run.target_ecef(t)
    los_ned = np.einsum("mij,mj->mi", ned, x - sensor)
    b = np.einsum("mji,mj->mi", c_bn, los_ned)  # C_bn^T
    np.testing.assert_allclose(df["range"], np.linalg.norm(b, axis=1), atol=2e-3)
    az = np.degrees(np.mod(np.arctan2(b[:, 1], b[:, 0]), 2 * math.pi))
    daz = (df["azimuth"].to_numpy() - az + 180.0) % 360.0 - 180.0
    assert np.abs(daz).max() < 1e-6
    el = np.degrees(np.arctan2(-b[:, 2], np.hypot(b[:, 0], b[:, 1])))
    np.testing.assert_allclose(df["elevation"], el, atol=1e-6)
    # the lever arm matters at this tolerance (checks it is applied, not ignored)
    assert np.abs(np.linalg.norm(x - ecef(lat, lon, h), axis=1) - df["range"]).max() > 0.5


def test_ins_velocity_and_yaw_wrap():
    sc = draw_scenario(1, DUR)
    tau = np.linspace(1.0, DUR - 1.0, 400)
    d = 1e-3
    lat, lon, h = sc.ship.geodetic(tau)
    xp, xm = (ecef(*sc.ship.geodetic(tau + s)) for s in (d, -d))
    v_enu = np.einsum("mij,mj->mi", enu_basis(lat, lon), (xp - xm) / (2 * d))
    np.testing.assert_allclose(sc.ship.velocity(tau), v_enu, atol=1e-5)
    yaw = np.degrees(sc.ship.attitude(np.linspace(0, DUR, 5000))[:, 2])
    assert yaw.min() >= 0.0 and yaw.max() < 360.0
    assert (yaw < 5).any() and (yaw > 355).any()  # seed 1: heading near north, wraps


def test_gps_matches_truth_iso_time(root):
    run = Run(root, 2, "G1")
    df, t = run.read("G1")
    assert df["time"].str.endswith("Z").all()
    assert run.sensor["G1"]["time_offset"] == 0.05
    x, v = run.target_ecef(t)
    lon, lat, h = TO_GEO.transform(x[:, 0], x[:, 1], x[:, 2])
    np.testing.assert_allclose(df["lat"], lat, atol=1e-9)
    np.testing.assert_allclose(df["lon"], lon, atol=1e-9)
    np.testing.assert_allclose(df["height"], h, atol=1e-3)
    v_rx = np.einsum("mij,mj->mi", enu_basis(lat, lon), v)
    np.testing.assert_allclose(df[["ve", "vn", "vu"]].to_numpy(), v_rx, atol=1e-4)
    gaps = np.diff(np.sort(t))
    assert gaps.max() > 5.0  # a dropout


def test_mistram_range_rate(root):
    run = Run(root, 1, "MISTRAM")
    df, t = run.read("MISTRAM")
    st = {s["id"]: s for s in run.sensor["MISTRAM"]["stations"]}
    assert 4 <= len(st) <= 8
    assert df["time"].duplicated().any()
    pos = np.array([ecef(st[s]["lat"], st[s]["lon"], st[s]["height"])[0] for s in df["station"]])
    x, v = run.target_ecef(t)
    d = x - pos
    rr = np.einsum("ij,ij->i", d, v) / np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(df["range_rate"], rr, atol=1e-4)
    # against the numerical derivative of range
    h = 1e-3
    num = (np.linalg.norm(run.target_ecef(t + h)[0] - pos, axis=1)
           - np.linalg.norm(run.target_ecef(t - h)[0] - pos, axis=1)) / (2 * h)
    np.testing.assert_allclose(df["range_rate"], num, atol=1e-4)


@pytest.mark.parametrize("seed,unit", [(3, "mil"), (5, "rad"), (1, "deg")])
def test_theodolite_units_and_coverage(root, seed, unit):
    run = Run(root, seed, "TH1")
    df, t = run.read("TH1")
    s = run.sensor["TH1"]
    assert s["angle_unit"] == unit and len(df) > 0
    to_rad = {"mil": 2 * math.pi / 6400, "rad": 1.0, "deg": math.pi / 180}[unit]
    x, _ = run.target_ecef(t)
    site = s["site"]
    d = x - ecef(site["lat"], site["lon"], site["height"])
    enu = d @ enu_basis(site["lat"], site["lon"])[0].T
    az = np.mod(np.arctan2(enu[:, 0], enu[:, 1]), 2 * math.pi)
    el = np.arctan2(enu[:, 2], np.hypot(enu[:, 0], enu[:, 1]))
    np.testing.assert_allclose(df["azimuth"] * to_rad, az, atol=2e-9)
    np.testing.assert_allclose(df["elevation"] * to_rad, el, atol=2e-9)
    rng = np.linalg.norm(d, axis=1)
    assert el.min() > math.radians(3.0) and rng.max() < 25e3
    assert ("range" in df) == (seed % 4 < 2)
    if "range" in df:
        laser = df["range"].to_numpy()
        assert np.all(np.isnan(laser) == (rng >= 15e3))
        np.testing.assert_allclose(laser[rng < 15e3], rng[rng < 15e3], atol=2e-3)


def test_noise_levels_match_config(root):
    """Noisy minus noise-free rows: robust std close to the config sigma; ~0.5-1 % wild."""
    clean, noisy = Run(root, 1, "R1,G1", noise=False), Run(root, 1, "R1,G1", noise=True)
    a, _ = clean.read("R1")
    b, _ = noisy.read("R1")
    sig = noisy.sensor["R1"]["sigma"]
    diff = b - a
    wild = ((diff["range"].abs() > 60) | (diff["azimuth"].abs() > 0.1)
            | (diff["elevation"].abs() > 0.1))
    assert 0.003 <= wild.mean() <= 0.012
    assert b["elevation"].isna().sum() >= 3 and a["elevation"].notna().all()
    for k in ("range", "azimuth", "elevation", "range_rate"):
        robust = 1.4826 * np.nanmedian(np.abs(diff[k][~wild]))
        assert robust == pytest.approx(sig[k], rel=0.12), k
    ga, t = clean.read("G1")
    gb, _ = noisy.read("G1")
    dh = (gb["height"] - ga["height"]).to_numpy()
    b0, b1 = draw_scenario(1, DUR).g1_burst
    burst = (t >= b0) & (t < b1)
    calm = ~burst & (np.abs(dh) < 40)
    assert np.std(dh[burst]) > 5 * np.std(dh[calm])
    assert np.std(dh[calm]) == pytest.approx(noisy.sensor["G1"]["sigma"]["vertical"], rel=0.2)
