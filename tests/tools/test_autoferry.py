"""tools/autoferry.py (the Autoferry dataset -> data contract) and bench/autoferry.py's Stone
Soup runners (GNN, JPDA, the GNN's RTS-smoothed tracks), its camera-less conversion and its
time limit, on scenario 2 of the shared dataset (skipped where the dataset is absent). The
smoother and the acceptance block without the dataset: test_autoferry_baselines.py.

The INS round trip is checked independently of pymap3d (which the converter uses): pyproj's
WGS-84 geodetic -> ECEF, then the ECEF -> NED rotation at the Piren origin written out here.
"""
from __future__ import annotations

import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:                  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

import numpy as np
import pandas as pd
import pytest

from rangeproc.config import load_config
from rangeproc.evaluate.metrics import evaluate_run
from rangeproc.pipeline import run
from rangeproc.stages.read import read_all

REPO = Path(__file__).resolve().parents[2]


sys.path.insert(0, str(REPO / "bench"))          # bench/ is scripts, not a package
import autoferry as bench  # noqa: E402

tool = bench.load_tool()

pytestmark = pytest.mark.skipif(not (tool.DATA_DIR / tool.PLOTS_FILE).is_file(),
                                reason=f"Autoferry dataset not found in {tool.DATA_DIR}")


@pytest.fixture(scope="module")
def dataset():
    return tool.load_dataset()


@pytest.fixture(scope="module")
def scenario2(tmp_path_factory, dataset) -> Path:
    """Scenario 2 converted (contract-faithful); returns its scenario.toml."""
    return tool.convert_scenario(dataset, 2, tmp_path_factory.mktemp("af"))


def test_config_and_files_accepted_by_rangeproc(scenario2, dataset):
    cfg = load_config(scenario2)
    kinds = {s.id: s.kind for s in cfg.sensors}
    assert kinds == {"FERRY": "ins", "RADAR": "radar", "LIDAR": "radar", "EO": "theodolite",
                     "IR": "theodolite"}
    for s in cfg.sensors:
        if s.kind != "ins":
            assert s.platform == "FERRY" and s.lever_arm == (0.0, 0.0, 0.0)
    assert "targets" not in tomllib.loads(scenario2.read_text())     # boats are undeclared
    assert cfg.output.rate_hz == 5.0 and cfg.output.dir == scenario2.parent / "out"
    assert (cfg.origin.lat, cfg.origin.lon, cfg.origin.height) == (
        tool.ORIGIN["lat"], tool.ORIGIN["lon"], tool.ORIGIN["height"])
    logs = read_all(cfg)
    d = dataset.scenario(2)
    for sid, (_, name) in tool.SENSORS.items():
        src = d.plots if name in ("radar", "lidar") else d.bearings
        assert logs[sid].n_read == int((src["sensor"] == name).sum())
    radar = pd.read_csv(scenario2.parent / "RADAR.csv", keep_default_na=True)
    assert list(radar.columns) == ["time", "range", "azimuth", "elevation"]
    assert radar["elevation"].isna().all()                          # 2-D plots, no track_id
    eo = pd.read_csv(scenario2.parent / "EO.csv")
    assert list(eo.columns) == ["time", "azimuth", "elevation"]
    # the time stamps are the dataset's unix seconds, unrounded
    assert np.array_equal(np.sort(radar["time"].to_numpy()),
                          np.sort(d.plots.loc[d.plots["sensor"] == "radar", "unix_s"].to_numpy()))


def _ned_pyproj(lat: np.ndarray, lon: np.ndarray, h: np.ndarray) -> np.ndarray:
    """(N, 3) NED (m) about the Piren origin via pyproj's geodetic -> ECEF and the rotation."""
    pyproj = pytest.importorskip("pyproj")
    to_ecef = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    o = tool.ORIGIN
    x, y, z = to_ecef.transform(lon, lat, h)
    x0, y0, z0 = to_ecef.transform(o["lon"], o["lat"], o["height"])
    p, l_ = np.radians(o["lat"]), np.radians(o["lon"])
    rot = np.array([[-np.sin(p) * np.cos(l_), -np.sin(p) * np.sin(l_), np.cos(p)],   # north
                    [-np.sin(l_), np.cos(l_), 0.0],                                    # east
                    [-np.cos(p) * np.cos(l_), -np.cos(p) * np.sin(l_), -np.sin(p)]])   # down
    d = np.column_stack([np.asarray(x) - x0, np.asarray(y) - y0, np.asarray(z) - z0])
    return d @ rot.T


def test_ins_round_trips_to_ferry_ned(scenario2, dataset):
    ins = pd.read_csv(scenario2.parent / "FERRY.csv")
    assert ins["time"].is_unique and ins["time"].is_monotonic_increasing
    assert (ins[["roll", "pitch", "yaw"]] == 0.0).all().all()
    assert np.allclose(ins["height"], tool.ORIGIN["height"])
    d = dataset.scenario(2)
    own = pd.concat([d.plots, d.bearings]).groupby("unix_s")[
        ["ownship_north_m", "ownship_east_m"]].mean()
    assert np.array_equal(own.index.to_numpy(), ins["time"].to_numpy())   # every sensor time
    ned = _ned_pyproj(ins["lat"].to_numpy(), ins["lon"].to_numpy(), ins["height"].to_numpy())
    assert np.abs(ned[:, 0] - own["ownship_north_m"].to_numpy()).max() < 0.01
    assert np.abs(ned[:, 1] - own["ownship_east_m"].to_numpy()).max() < 0.01
    # height = origin height, so the points lie d^2 / 2R below the tangent plane (< 5 cm here)
    r = np.hypot(ned[:, 0], ned[:, 1])
    assert np.allclose(ned[:, 2], r**2 / (2 * 6.38e6), atol=0.005)


def test_truth_has_both_boats_in_range_enu(scenario2, dataset):
    truth = pd.read_csv(scenario2.parent / "truth.csv")
    assert list(truth.columns) == ["target_id", "time", "e", "n", "u", "ve", "vn", "vu"]
    assert set(truth["target_id"]) == {"B1", "B2"}
    d = dataset.scenario(2).truth
    b1 = truth[truth["target_id"] == "B1"]
    src = d[d["target_id"] == 1].sort_values("unix_s")
    assert np.array_equal(b1["e"].to_numpy(), src["east_m"].to_numpy())
    assert np.array_equal(b1["n"].to_numpy(), src["north_m"].to_numpy())
    assert (truth["u"] == 0.0).all() and (truth["vu"] == 0.0).all()
    speed = np.hypot(truth["ve"], truth["vn"])
    assert np.isfinite(speed).all() and speed.max() < 20.0          # boats, m/s


def test_elevation_zero_variant_and_cli(tmp_path, capsys):
    assert tool.main([str(tmp_path), "--scenarios", "2", "--elevation-zero"]) == 0
    radar = pd.read_csv(tmp_path / "scenario_2" / "LIDAR.csv")
    assert (radar["elevation"] == 0.0).all()
    assert "surface-plane" in (tmp_path / "scenario_2" / "scenario.toml").read_text()
    assert tool.main([str(tmp_path), "--scenarios", "99"]) == 2
    assert "scenario 99 is not in the dataset" in capsys.readouterr().err


def test_stonesoup_runner_tracks_scenario_2(scenario2, tmp_path):
    """Stone Soup's GNN tracker on scenario 2's plots (a few seconds; must stay under 60 s)."""
    plots = bench.read_plots(scenario2.parent)
    assert set(plots.sensor) == {"RADAR", "LIDAR"} and np.all(np.diff(plots.t) >= 0)
    out = bench.run_stonesoup(scenario2.parent, tmp_path / "ss", smooth_dir=tmp_path / "rts")
    assert out["n_tracks"] >= 2 and out["seconds"] < 60.0
    fused = pd.read_parquet(tmp_path / "ss" / "fused.parquet")
    assert fused["target_id"].str.fullmatch(r"S\d+").all()
    grid = fused["time"].to_numpy() * 5.0
    assert np.allclose(grid, np.round(grid), atol=1e-6)             # the 5 Hz grid
    multi = evaluate_run(tmp_path / "ss", scenario2.parent / "truth.csv", cutoff=20.0)["multi"]
    assert set(multi["truth"]) == {"B1", "B2"}
    assert max(m["coverage"] for m in multi["truth"].values()) > 0.5
    # the RTS-smoothed tracks: the same objects on the same epochs, other positions
    smoothed = pd.read_parquet(tmp_path / "rts" / "fused.parquet")
    assert out["smoothed"]["n_tracks"] == out["n_tracks"]
    assert smoothed[["target_id", "time"]].equals(fused[["target_id", "time"]])
    assert not np.allclose(smoothed["e"], fused["e"])
    rts = evaluate_run(tmp_path / "rts", scenario2.parent / "truth.csv", cutoff=20.0)["multi"]
    assert max(m["coverage"] for m in rts["truth"].values()) > 0.5


def test_stonesoup_jpda_runner_tracks_scenario_2(scenario2, tmp_path):
    """Stone Soup's JPDA on the same plots: objects J1, J2, ... on the same grid (about 6 s)."""
    plots = bench.read_plots(scenario2.parent)
    lam = bench.clutter_density(plots)
    area = np.ptp(plots.p[:, 0]) * np.ptp(plots.p[:, 1])
    assert lam == pytest.approx(plots.t.size / np.unique(plots.t).size / area)
    assert 1e-7 < lam < 1e-4                                     # a few plots per km^2
    out = bench.run_stonesoup(scenario2.parent, tmp_path / "jp", method="jpda")
    assert out["n_tracks"] >= 2 and out["seconds"] < 60.0
    assert out["clutter_spatial_density"] == lam
    fused = pd.read_parquet(tmp_path / "jp" / "fused.parquet")
    assert fused["target_id"].str.fullmatch(r"J\d+").all()
    assert fused["n_sensors"].between(0, 2).all()
    grid = fused["time"].to_numpy() * 5.0
    assert np.allclose(grid, np.round(grid), atol=1e-6)
    multi = evaluate_run(tmp_path / "jp", scenario2.parent / "truth.csv", cutoff=20.0)["multi"]
    assert min(m["coverage"] for m in multi["truth"].values()) > 0.5


def test_jpda_time_limit_abandons_the_child(scenario2, tmp_path):
    """A run past its limit comes back as not finished (the child terminated), not an error."""
    out = bench.run_with_timeout(bench.run_stonesoup,
                                 (scenario2.parent, tmp_path / "jp", "steps", "jpda"), 0.05)
    assert out["finished"] is False and out["timed_out"] is True
    assert "did not finish" in out["error"] and out["wall_seconds"] < 30.0
    assert not (tmp_path / "jp" / "fused.parquet").exists()


def test_strip_cameras(dataset, tmp_path):
    config = bench.strip_cameras(tool.convert_scenario(dataset, 2, tmp_path))
    assert {s.id for s in load_config(config).sensors} == {"FERRY", "RADAR", "LIDAR"}
    assert not (config.parent / "EO.csv").exists() and not (config.parent / "IR.csv").exists()
    assert (config.parent / "RADAR.csv").is_file() and (config.parent / "truth.csv").is_file()


@pytest.mark.parametrize("scenario", [3, 4, 5, 6, 13, 16, 17, 22])
def test_every_real_scenario_runs_end_to_end(scenario, dataset, tmp_path):
    """Every scenario, contract-faithful, runs to its outputs (scenario 2 above). Scenario
    17 once ended in exit 1: a discovered object lost every plot in the plot-by-plot
    association, and naming it took the minimum of nothing."""
    config = tool.convert_scenario(dataset, scenario, tmp_path)
    run(config)
    assert (config.parent / "out" / "fused.parquet").is_file()
