"""Scenario files against the data contract; config; determinism; sensor subsets."""
from __future__ import annotations

import filecmp

import numpy as np
import pandas as pd
import pytest
import tomllib

from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.simulate import simulate_scenario

DUR = 60.0
REQUIRED = {"radar": {"time", "range", "azimuth", "elevation"},
            "theodolite": {"time", "azimuth", "elevation"},
            "gps": {"time", "lat", "lon", "height"},
            "mistram": {"time", "station", "range_rate"},
            "ins": {"time", "roll", "pitch", "yaw", "lat", "lon", "height"}}
OPTIONAL = {"radar": {"range_rate", "track_id"}, "theodolite": {"range", "track_id"},
            "gps": {"ve", "vn", "vu"}, "mistram": set(), "ins": {"ve", "vn", "vu"}}
SIGMA_KEYS = {"radar": {"range", "azimuth", "elevation", "range_rate"},
              "theodolite": {"azimuth", "elevation", "range"},
              "gps": {"horizontal", "vertical", "velocity"}, "mistram": {"range_rate"},
              "ins": {"roll", "pitch", "yaw", "position"}}
SENSOR_KEYS = {"id", "kind", "file", "site", "platform", "lever_arm", "angle_unit",
               "time_offset", "sigma", "target", "stations"}


@pytest.fixture(scope="module", params=[1, 2, 3, 4])
def run(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(f"seed{request.param}")
    cfg = simulate_scenario(out, seed=request.param, duration=DUR)
    return request.param, cfg


def _read(path):
    return pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)


def _seconds(col: pd.Series) -> np.ndarray:
    if pd.api.types.is_numeric_dtype(col):
        return col.to_numpy(float)
    assert col.str.endswith("Z").all()
    return pd.to_datetime(col, utc=True).dt.as_unit("ns").astype("int64").to_numpy() / 1e9


def test_config_has_only_contract_keys(run):
    seed, cfg = run
    doc = tomllib.loads(cfg.read_text())
    assert set(doc) == {"range", "output", "targets", "sensors"}
    assert set(doc["range"]) == {"origin"} and set(doc["range"]["origin"]) == {
        "lat", "lon", "height"}
    assert doc["output"] == {"dir": "out", "rate_hz": 10.0}
    assert doc["targets"] == [{"id": "T1"}]
    ids = [s["id"] for s in doc["sensors"]]
    assert ids == ["R1", "TH1", "S1", "SHIP_INS", "G1", "MISTRAM"]
    for s in doc["sensors"]:
        assert set(s) <= SENSOR_KEYS and set(s["sigma"]) <= SIGMA_KEYS[s["kind"]]
        assert all(v > 0 for v in s["sigma"].values())
        assert (cfg.parent / s["file"]).is_file()
    assert sum(s["time_offset"] == 0.05 for s in doc["sensors"]) == 1
    assert 20 <= abs(doc["range"]["origin"]["lat"]) <= 60


def test_config_loads_with_rangeproc(run):
    _, cfg = run
    conf = load_config(cfg)
    assert {s.id for s in conf.sensors} == {"R1", "TH1", "S1", "SHIP_INS", "G1", "MISTRAM"}


def test_files_follow_contract(run):
    seed, cfg = run
    doc = tomllib.loads(cfg.read_text())
    truth = pd.read_csv(cfg.parent / "truth.csv")
    assert list(truth.columns) == ["target_id", "time", "e", "n", "u", "ve", "vn", "vu", "ae",
                                   "an", "au", "lat", "lon", "height"]
    np.testing.assert_allclose(np.diff(truth["time"]), 0.01, atol=1e-6)
    t_lo, t_hi = truth["time"].min(), truth["time"].max()
    assert (t_lo > 1e9) == (seed % 2 == 0)  # ISO seeds put every file on Unix seconds
    unsorted = []
    for s in doc["sensors"]:
        df = _read(cfg.parent / s["file"])
        kind = s["kind"]
        assert REQUIRED[kind] <= set(df.columns) <= REQUIRED[kind] | OPTIONAL[kind], s["id"]
        t = _seconds(df["time"]) + s["time_offset"]
        assert t_lo <= t.min() and t.max() <= t_hi
        if np.any(np.diff(t) < 0):
            unsorted.append(s["id"])
        if kind == "ins":
            assert df["yaw"].between(0, 360, inclusive="left").all()
    assert len(unsorted) == 1


def test_deterministic_and_subset(tmp_path):
    a = simulate_scenario(tmp_path / "a", seed=7, duration=DUR)
    b = simulate_scenario(tmp_path / "b", seed=7, duration=DUR)
    c = simulate_scenario(tmp_path / "c", seed=7, duration=DUR, sensors="R1,S1,SHIP_INS,G1")
    d = simulate_scenario(tmp_path / "d", seed=8, duration=DUR)
    for name in ("R1.csv", "TH1.parquet", "S1.csv", "SHIP_INS.csv", "G1.csv", "MISTRAM.csv",
                 "truth.csv", "scenario.toml"):
        assert filecmp.cmp(a.parent / name, b.parent / name, shallow=False), name
    for name in ("R1.csv", "S1.csv", "SHIP_INS.csv", "G1.csv", "truth.csv"):
        assert filecmp.cmp(a.parent / name, c.parent / name, shallow=False), name
    assert not (c.parent / "MISTRAM.csv").exists() and not (c.parent / "TH1.parquet").exists()
    ids = [s["id"] for s in tomllib.loads(c.read_text())["sensors"]]
    assert ids == ["R1", "S1", "SHIP_INS", "G1"]
    assert not filecmp.cmp(a.parent / "R1.csv", d.parent / "R1.csv", shallow=False)
    assert not list(tmp_path.rglob("*.tmp"))


def test_noise_seed_measures_the_same_flight_again(tmp_path):
    """Another noise seed: the same truth, sites, sigmas and rows' rates; other draws of the
    sampling and noise, around the same exact measurements."""
    a = simulate_scenario(tmp_path / "a", seed=7, duration=DUR)
    b = simulate_scenario(tmp_path / "b", seed=7, duration=DUR, noise_seed=70)
    x = simulate_scenario(tmp_path / "x", seed=7, duration=DUR, noise=False, noise_seed=70)
    assert filecmp.cmp(a.parent / "truth.csv", b.parent / "truth.csv", shallow=False)
    assert b.read_text().splitlines()[1:] == a.read_text().splitlines()[1:]
    assert "sensor noise seed 70" in b.read_text().splitlines()[0]
    ra, rb, rx = (pd.read_csv(p.parent / "MISTRAM.csv") for p in (a, b, x))
    assert abs(len(ra) - len(rb)) <= 0.01 * len(ra)
    assert not np.array_equal(ra["range_rate"][:100], rb["range_rate"][:100])
    sigma = tomllib.loads(b.read_text())["sensors"][-1]["sigma"]["range_rate"]
    err = (rb["range_rate"] - rx["range_rate"]).to_numpy()     # rows alike: timing stream shared
    assert np.median(np.abs(err)) / 0.6745 == pytest.approx(sigma, rel=0.1)


@pytest.mark.parametrize("sensors", ["R2", "S1,G1", ""])
def test_bad_sensor_list(tmp_path, sensors):
    with pytest.raises(ConfigError, match="sensors="):
        simulate_scenario(tmp_path, sensors=sensors)


def test_bad_duration(tmp_path):
    with pytest.raises(ConfigError, match="duration"):
        simulate_scenario(tmp_path, duration=5.0)
