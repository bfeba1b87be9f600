"""A 2-D radar (range and azimuth, elevation empty in every row): a surface target is
tracked, its height held near the sensor's plane, and the fused track is honest."""
from __future__ import annotations

import numpy as np
import pandas as pd

from rangeproc.evaluate import evaluate_run

ORIGIN = {"lat": 63.4389, "lon": 10.3991, "height": 40.0}
SIGMA_RANGE, SIGMA_AZ_DEG = 5.0, 1.0


def _boat(t: np.ndarray) -> np.ndarray:
    """(N, 3) ENU of a boat turning at 4 m/s on a 300 m circle about (0, 400) m, on the
    range origin's horizontal plane (u = 0)."""
    w = 4.0 / 300.0
    return np.column_stack([300.0 * np.sin(w * t), 400.0 - 300.0 * np.cos(w * t),
                            np.zeros_like(t)])


def _write(folder, seed: int = 3) -> None:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 150.0, 1.0) + 1.7e9
    p = _boat(t - t[0])
    r = np.linalg.norm(p, axis=1)
    az = np.degrees(np.mod(np.arctan2(p[:, 0], p[:, 1]), 2 * np.pi))
    pd.DataFrame({"time": t, "range": r + rng.normal(0, SIGMA_RANGE, t.size),
                  "azimuth": az + rng.normal(0, SIGMA_AZ_DEG, t.size),
                  "elevation": np.full(t.size, np.nan)}).to_csv(folder / "NAV.csv", index=False)
    tt = np.arange(t[0], t[-1], 0.1)
    q = _boat(tt - t[0])
    v = np.gradient(q, tt, axis=0)
    pd.DataFrame({"target_id": "T1", "time": tt, "e": q[:, 0], "n": q[:, 1], "u": q[:, 2],
                  "ve": v[:, 0], "vn": v[:, 1], "vu": v[:, 2]}).to_csv(folder / "truth.csv",
                                                                       index=False)
    o = ORIGIN
    (folder / "scenario.toml").write_text(f"""
[range]
origin = {{ lat = {o['lat']}, lon = {o['lon']}, height = {o['height']} }}

[output]
dir = "out"
rate_hz = 1.0

[[sensors]]
id = "NAV"
kind = "radar"
file = "NAV.csv"
site = {{ lat = {o['lat']}, lon = {o['lon']}, height = {o['height']} }}
angle_unit = "deg"
sigma = {{ range = {SIGMA_RANGE}, azimuth = {SIGMA_AZ_DEG}, elevation = {SIGMA_AZ_DEG} }}
""")


def test_a_two_d_radar_alone_tracks_a_surface_target(tmp_path, cli, explain) -> None:
    _write(tmp_path)
    res = cli(["run", "--quiet", tmp_path / "scenario.toml"])
    assert res.exit_code == 0, explain(res)
    fused = pd.read_parquet(tmp_path / "out" / "fused.parquet")
    assert set(fused.target_id) == {"T1"}
    m = evaluate_run(tmp_path / "out", tmp_path / "truth.csv")["targets"]["T1"]
    # A plot's horizontal error at 100-700 m: 5 m in range, 1 deg (2-12 m) across; the
    # smoothed track must do far better than one plot, and its height stay near the plane
    # (a tenth of a radian at these ranges is 10-70 m) instead of wandering off.
    assert m["pos_rmse"] < 6.0, m
    assert np.abs(fused.u).max() < 60.0
    assert min(m["inside_3sigma_enu"]) > 0.95, m
