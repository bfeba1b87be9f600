"""A MISTRAM station on the flight path (its range passes through zero: 1.7 m at the closest)
adds its geometry and nothing worse: the sample flight with its station M1 moved onto the
trajectory at mid-flight and M1's range rates recomputed from the truth there."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.config import load_config
from rangeproc.evaluate import evaluate_run
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.pipeline import run
from tests.conftest import SAMPLE_DATA


def _on_path(folder: Path) -> tuple[Path, Path]:
    shutil.copytree(SAMPLE_DATA, folder, ignore=shutil.ignore_patterns("out", ".*"))
    truth = pd.read_csv(folder / "truth.csv")
    mid = truth.iloc[len(truth) // 2]
    text = re.sub(r'(\{ id = "M1", )lat = [-\d.]+, lon = [-\d.]+, height = [-\d.]+',
                  rf"\g<1>lat = {mid.lat:.9f}, lon = {mid.lon:.9f}, height = {mid.height:.3f}",
                  (folder / "scenario.toml").read_text(), count=1)
    (folder / "scenario.toml").write_text(text)
    cfg = load_config(folder / "scenario.toml")
    mistram = next(s for s in cfg.sensors if s.kind == "mistram")
    site = RangeFrame(cfg.origin).site(mistram.stations[0].site)[0].reshape(3)
    rows = pd.read_csv(folder / "MISTRAM.csv")
    sel = (rows.station == "M1").to_numpy()
    t = rows.time[sel].to_numpy()
    p = np.column_stack([np.interp(t, truth.time, truth[a]) for a in "enu"]) - site
    v = np.column_stack([np.interp(t, truth.time, truth["v" + a]) for a in "enu"])
    noise = np.random.default_rng(5).normal(0.0, mistram.sigma["range_rate"], sel.sum())
    rows.loc[sel, "range_rate"] = np.einsum("ij,ij->i", p, v) / np.linalg.norm(p, axis=1) + noise
    assert np.linalg.norm(p, axis=1).min() < 10.0
    rows.to_csv(folder / "MISTRAM.csv", index=False)
    rows[~sel].to_csv(folder / "MISTRAM_without_M1.csv", index=False)
    without = folder / "without_M1.toml"
    without.write_text(text.replace('file = "MISTRAM.csv"', 'file = "MISTRAM_without_M1.csv"')
                       .replace('dir = "out"', 'dir = "out_without"'))
    return folder / "scenario.toml", without


def test_a_station_on_the_flight_path_degrades_nothing(tmp_path):
    on, without = _on_path(tmp_path / "sample")
    truth = tmp_path / "sample" / "truth.csv"
    with_it = evaluate_run(run(on).out_dir, truth)["targets"]["T1"]
    without_it = evaluate_run(run(without).out_dir, truth)["targets"]["T1"]
    assert with_it["pos_rmse"] <= 1.1 * without_it["pos_rmse"]
    assert with_it["vel_rmse"] <= 1.1 * without_it["vel_rmse"]
    assert min(with_it["inside_3sigma_enu"]) >= 0.95
