"""CLI tests (click CliRunner) on a copy of the bundled sample scenario: help, version, ``run``
outputs against the data contract (section 4), ``simulate``, ``evaluate`` and determinism.

The shared run (``sample_run`` in conftest.py) is done once per session; the tests here only
read its outputs. Independent references: pymap3d for geodetic <-> range ENU, hashlib for the
input hashes, a NumPy RMSE against truth.csv, tomllib for the config values.
"""
from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
from importlib.metadata import version as dist_version
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pymap3d
import pytest

import rangeproc
from rangeproc.cli import main

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

CONTRACT_COLUMNS = ("target_id", "time", "lat", "lon", "height", "e", "n", "u", "ve", "vn",
                    "vu", "ae", "an", "au", "sigma_e", "sigma_n", "sigma_u", "n_sensors")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_END = b"IEND\xaeB`\x82"  # the IEND chunk (type + CRC) that closes every complete PNG


def toml_of(path: Path) -> dict:
    """The config as plain TOML (read independently of rangeproc.config)."""
    with path.open("rb") as fh:
        return tomllib.load(fh)


def data_rows(path: Path) -> int:
    """Number of data records in a sensor file (CSV: non-empty lines minus the header)."""
    if path.suffix == ".parquet":
        return pq.read_metadata(path).num_rows
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    return len(lines) - 1


def sensor_times(path: Path) -> np.ndarray:
    """The raw ``time`` column of a sensor file (float seconds)."""
    if path.suffix == ".parquet":
        return pq.read_table(path, columns=["time"]).column("time").to_numpy()
    return pd.read_csv(path, usecols=["time"])["time"].to_numpy(float)


def files_under(folder: Path) -> list[Path]:
    """Every file below ``folder`` (hidden ones too), relative paths, sorted."""
    return sorted(p.relative_to(folder) for p in folder.rglob("*") if p.is_file())


# --------------------------------------------------------------------------------------------
# help and version
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_group_help_lists_every_command(cli, explain, flag):
    result = cli([flag])
    assert result.exit_code == 0, explain(result)
    assert result.stdout.startswith("Usage: ")
    assert "fuse flight-test range tracking logs" in result.stdout
    for name in main.commands:
        assert f"  {name}" in result.stdout, f"command {name!r} missing from the group help"
    for option in ("--debug", "--version", "--help"):
        assert option in result.stdout


def test_group_has_commands():
    assert {"run", "simulate", "evaluate"} <= set(main.commands)


@pytest.mark.parametrize("name", sorted(main.commands))
def test_every_command_has_help(cli, explain, name):
    """Iterates over main.commands, so a new command is covered (and must document itself)."""
    command = main.commands[name]
    assert command.help and len(command.help.split()) >= 10, f"{name}: help text too short"
    for param in command.params:
        if param.param_type_name == "option":
            assert getattr(param, "help", None), f"{name} {param.opts}: option without help"
    result = cli([name, "--help"])
    assert result.exit_code == 0, explain(result)
    assert result.stdout.startswith(f"Usage: main {name}") or \
        result.stdout.startswith(f"Usage: rangeproc {name}"), result.stdout
    first_line = command.help.strip().splitlines()[0]
    assert first_line.split(" (")[0] in " ".join(result.stdout.split())
    for param in command.params:
        if param.param_type_name == "argument":
            assert param.human_readable_name.upper() in result.stdout
        elif param.param_type_name == "option":
            assert param.opts[0] in result.stdout
    assert result.stderr == ""


def test_version(cli, explain):
    result = cli(["--version"])
    assert result.exit_code == 0, explain(result)
    assert result.stdout.strip() == f"rangeproc, version {rangeproc.__version__}"
    assert rangeproc.__version__ == dist_version("rangeproc")


# --------------------------------------------------------------------------------------------
# run: the shared sample run
# --------------------------------------------------------------------------------------------

def test_run_quiet_prints_nothing(sample_run):
    assert sample_run.result.stdout == ""
    assert sample_run.result.stderr == ""


def test_run_writes_the_contract_outputs(sample_run):
    cfg = toml_of(sample_run.config)
    non_ins = [s["id"] for s in cfg["sensors"] if s["kind"] != "ins"]
    expected = {Path("fused.parquet"), Path("summary.json")} | {
        Path("report") / name for name in
        ["trajectory.png", "coverage.png", "consistency.png",
         *(f"residuals_{sid}.png" for sid in non_ins)]}
    found = set(files_under(sample_run.out_dir))
    assert expected <= found, f"missing: {sorted(map(str, expected - found))}"
    # extra outputs are the project's to add, but never temp or hidden files
    assert not [p for p in found if p.name.startswith(".") or "tmp" in p.name.lower()]


def test_report_pngs_are_complete(sample_run):
    pngs = sorted((sample_run.out_dir / "report").glob("*.png"))
    assert len(pngs) >= 3 + 5
    for png in pngs:
        data = png.read_bytes()
        assert data.startswith(PNG_SIGNATURE), png.name
        assert data.endswith(PNG_END), f"{png.name}: truncated PNG"
        assert len(data) > 10_000, f"{png.name}: suspiciously small figure"


@pytest.fixture(scope="module")
def fused(sample_run) -> pd.DataFrame:
    return pd.read_parquet(sample_run.out_dir / "fused.parquet")


def test_fused_has_contract_columns_and_types(fused):
    assert [c for c in CONTRACT_COLUMNS if c not in fused.columns] == []
    assert len(fused) > 1000
    assert all(isinstance(v, str) for v in fused["target_id"])
    assert set(fused["target_id"]) == {"T1"}
    assert pd.api.types.is_integer_dtype(fused["n_sensors"])
    numeric = [c for c in CONTRACT_COLUMNS if c not in ("target_id", "n_sensors")]
    for col in numeric:
        assert pd.api.types.is_float_dtype(fused[col]), col
        assert np.isfinite(fused[col].to_numpy()).all(), f"{col}: non-finite values"
    for col in ("sigma_e", "sigma_n", "sigma_u"):
        assert (fused[col] > 0).all(), col


def test_fused_sorted_on_uniform_grid(fused, sample_run):
    rate_hz = toml_of(sample_run.config)["output"]["rate_hz"]
    keys = list(zip(fused["target_id"], fused["time"]))
    assert keys == sorted(keys), "not sorted by target_id then time"
    for _, grp in fused.groupby("target_id"):
        dt = np.diff(grp["time"].to_numpy())
        np.testing.assert_allclose(dt, 1.0 / rate_hz, rtol=0, atol=1e-9)


def test_fused_span_matches_observed_span(fused, sample_run):
    """Epochs cover the span in which the target was observed, and not more (contract sec. 4)."""
    cfg = toml_of(sample_run.config)
    dt = 1.0 / cfg["output"]["rate_hz"]
    firsts, lasts = [], []
    for s in cfg["sensors"]:
        if s["kind"] == "ins":
            continue
        t = sensor_times(sample_run.folder / s["file"]) + s.get("time_offset", 0.0)
        firsts.append(t.min())
        lasts.append(t.max())
    t0, t1 = min(firsts), max(lasts)
    time = fused["time"].to_numpy()
    assert t0 - dt <= time[0] <= t0 + dt
    assert t1 - dt <= time[-1] <= t1 + dt


def test_fused_n_sensors(fused, sample_run):
    n_meas = sum(s["kind"] != "ins" for s in toml_of(sample_run.config)["sensors"])
    n = fused["n_sensors"].to_numpy()
    assert n.min() >= 1
    assert n.max() <= n_meas
    assert n.max() >= 3  # several sensors overlap in the sample flight


def test_fused_geodetic_matches_enu(fused, sample_run):
    """lat/lon/height and e/n/u describe the same points (pymap3d as the reference)."""
    o = toml_of(sample_run.config)["range"]["origin"]
    e, n, u = pymap3d.geodetic2enu(fused["lat"].to_numpy(), fused["lon"].to_numpy(),
                                   fused["height"].to_numpy(), o["lat"], o["lon"], o["height"])
    np.testing.assert_allclose(e, fused["e"], atol=1e-3)
    np.testing.assert_allclose(n, fused["n"], atol=1e-3)
    np.testing.assert_allclose(u, fused["u"], atol=1e-3)


@pytest.fixture(scope="module")
def summary(sample_run) -> dict:
    return json.loads((sample_run.out_dir / "summary.json").read_text())


def test_summary_sensors(summary, sample_run):
    cfg = toml_of(sample_run.config)
    assert list(summary["sensors"]) == [s["id"] for s in cfg["sensors"]]
    for s in cfg["sensors"]:
        ss = summary["sensors"][s["id"]]
        assert ss["n_read"] == data_rows(sample_run.folder / s["file"]), s["id"]
        # a row with only some components rejected counts as used and as rejected, so the
        # two counts need not add up to at most n_read
        assert 0 < ss["n_used"] <= ss["n_read"]
        assert 0 <= ss["n_rejected"] <= ss["n_read"]
        # disjoint row counts: used (some component used) + wholly rejected <= rows with data
        assert ss["n_used"] + ss["n_rejected"] <= ss["n_rows"]
        if s["kind"] == "ins":
            continue
        assert ss["n_used"] >= 0.95 * ss["n_read"], s["id"]  # a few wild points at most
        assert ss["noise"], f"{s['id']}: no noise estimates"
        for comp, est in ss["noise"].items():
            assert est["estimated"] is not None and est["estimated"] > 0, (s["id"], comp)
            assert est["apriori"] is not None and est["apriori"] > 0, (s["id"], comp)
    # the simulator puts wild points into the radar and theodolite logs
    r1 = summary["sensors"]["R1"]
    assert r1["n_rejected"] + r1["n_partly_rejected"] > 0
    assert sum(r1["n_components_rejected"].values()) > 0


def test_summary_targets(summary, fused):
    assert set(summary["targets"]) == set(fused["target_id"])
    for tid, grp in fused.groupby("target_id"):
        st = summary["targets"][tid]
        assert st["t_start"] == pytest.approx(grp["time"].iloc[0], abs=1e-9)
        assert st["t_end"] == pytest.approx(grp["time"].iloc[-1], abs=1e-9)
        assert isinstance(st["gaps"], list)
        for gap in st["gaps"]:
            assert len(gap) == 2 and st["t_start"] - 1.0 <= gap[0] < gap[1] <= st["t_end"] + 1.0


def test_summary_hashes_match_input_files(summary, sample_run):
    cfg = toml_of(sample_run.config)
    assert summary["rangeproc_version"] == rangeproc.__version__
    assert summary["config"]["sha256"] == hashlib.sha256(
        sample_run.config.read_bytes()).hexdigest()
    assert set(summary["inputs"]) == {s["id"] for s in cfg["sensors"]}
    for s in cfg["sensors"]:
        path = sample_run.folder / s["file"]
        entry = summary["inputs"][s["id"]]
        assert Path(entry["file"]).resolve() == path.resolve()
        assert entry["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest(), s["id"]


# --------------------------------------------------------------------------------------------
# evaluate
# --------------------------------------------------------------------------------------------

def reference_position_rmse(fused: pd.DataFrame, truth: pd.DataFrame) -> tuple[float, int]:
    """Position RMSE (m) of fused vs truth linearly interpolated at the fused epochs inside the
    truth span; and the number of such epochs."""
    t = fused["time"].to_numpy()
    tt = truth["time"].to_numpy()
    inside = (t >= tt.min()) & (t <= tt.max())
    order = np.argsort(tt)
    err = np.column_stack([fused[c].to_numpy()[inside] - np.interp(t[inside], tt[order],
                                                                   truth[c].to_numpy()[order])
                           for c in ("e", "n", "u")])
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1)))), int(inside.sum())


def test_evaluate_sample_run(cli, explain, sample_run, tmp_path):
    out = tmp_path / "eval"
    out.mkdir()
    shutil.copy(sample_run.out_dir / "fused.parquet", out / "fused.parquet")
    truth_path = sample_run.folder / "truth.csv"
    result = cli(["evaluate", out, truth_path])
    assert result.exit_code == 0, explain(result)
    assert result.stderr == ""
    assert "pos RMSE" in result.stdout and "NEES" in result.stdout
    row = [ln for ln in result.stdout.splitlines() if ln.startswith("T1 ")]
    assert len(row) == 1, result.stdout

    metrics = json.loads((out / "evaluation.json").read_text())
    m = metrics["targets"]["T1"]
    fused = pd.read_parquet(out / "fused.parquet")
    rmse, n = reference_position_rmse(fused, pd.read_csv(truth_path))
    assert m["n_epochs"] == n
    assert m["pos_rmse"] == pytest.approx(rmse, rel=1e-9)
    assert f"{rmse:.2f}" in row[0]
    # a real accuracy check on the bundled flight: the fused track is well below 1 m
    assert rmse < 1.0
    assert set(files_under(out)) == {Path("fused.parquet"), Path("evaluation.json")}


def test_evaluate_without_fused_output_is_input_error(cli, explain, tmp_path, sample_run):
    result = cli(["evaluate", tmp_path, sample_run.folder / "truth.csv"])
    assert result.exit_code == 2, explain(result)
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error: "), explain(result)
    assert "fused.parquet" in lines[0]
    assert not (tmp_path / "evaluation.json").exists()


# --------------------------------------------------------------------------------------------
# simulate -> run -> evaluate
# --------------------------------------------------------------------------------------------

def test_simulate_then_run(cli, explain, tmp_path):
    sim = tmp_path / "sim"
    result = cli(["simulate", sim, "--seed", "7", "--duration", "30"])
    assert result.exit_code == 0, explain(result)
    assert result.stderr == ""
    assert str(sim / "scenario.toml") in result.stdout
    cfg = toml_of(sim / "scenario.toml")
    for s in cfg["sensors"]:
        assert (sim / s["file"]).is_file(), s["file"]
    assert (sim / "truth.csv").is_file()

    result = cli(["run", sim / "scenario.toml"])
    assert result.exit_code == 0, explain(result)
    out_dir = sim / cfg["output"]["dir"]
    n_written = len(files_under(out_dir))
    assert f"wrote {n_written} files to {out_dir}" in result.stdout
    fused = pd.read_parquet(out_dir / "fused.parquet")
    span = fused["time"].iloc[-1] - fused["time"].iloc[0]
    assert 25.0 <= span <= 31.0

    result = cli(["evaluate", out_dir, sim / "truth.csv"])
    assert result.exit_code == 0, explain(result)
    rmse, n = reference_position_rmse(fused, pd.read_csv(sim / "truth.csv"))
    assert n > 200
    assert rmse < 2.0


def test_simulate_quiet_and_sensor_subset(cli, explain, tmp_path):
    result = cli(["simulate", tmp_path / "g", "--duration", "20", "--sensors", "G1", "--quiet"])
    assert result.exit_code == 0, explain(result)
    assert result.stdout == "" and result.stderr == ""
    cfg = toml_of(tmp_path / "g" / "scenario.toml")
    assert [s["id"] for s in cfg["sensors"]] == ["G1"]
    assert sorted(p.name for p in (tmp_path / "g").iterdir()) == \
        ["G1.csv", "scenario.toml", "truth.csv"]


@pytest.mark.parametrize("args, needle", [
    (["--duration", "5"], "duration"),
    (["--sensors", "R1,XX"], "XX"),
])
def test_simulate_bad_options_are_input_errors(cli, explain, tmp_path, args, needle):
    result = cli(["simulate", tmp_path / "s", *args])
    assert result.exit_code == 2, explain(result)
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error: "), explain(result)
    assert needle in lines[0]
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())


# --------------------------------------------------------------------------------------------
# determinism (and --quiet in a real process)
# --------------------------------------------------------------------------------------------

def test_run_twice_gives_identical_fused_output(sample_run, tmp_path):
    """The same config on the same inputs, run again in a fresh process, gives the same bytes.

    The second run uses a copy of the folder (same config text, same input bytes) so the
    shared outputs stay untouched; it also checks that ``--quiet`` prints nothing in a real
    process, where logging goes to the real stderr.
    """
    again = tmp_path / "again"
    shutil.copytree(sample_run.folder, again, ignore=shutil.ignore_patterns("out"))
    proc = subprocess.run([sys.executable, "-m", "rangeproc.cli", "run", "--quiet",
                           str(again / "scenario.toml")], capture_output=True, timeout=300)
    assert proc.returncode == 0, proc.stderr.decode()
    assert proc.stdout == b"" and proc.stderr == b""
    first = sample_run.out_dir / "fused.parquet"
    second = again / "out" / "fused.parquet"
    pd.testing.assert_frame_equal(pd.read_parquet(first), pd.read_parquet(second),
                                  check_exact=True)
    assert first.read_bytes() == second.read_bytes()


def test_the_console_command_leaves_with_the_commands_status_and_flushed_output(tmp_path):
    """``rangeproc.cli.entry`` (the console script) ends without the interpreter's teardown:
    the exit status is the command's and what it printed arrives whole."""
    ok = subprocess.run([sys.executable, "-m", "rangeproc.cli", "--version"],
                        capture_output=True, timeout=120)
    assert ok.returncode == 0 and ok.stdout.decode().strip().endswith(rangeproc.__version__)
    bad = subprocess.run([sys.executable, "-m", "rangeproc.cli", "run", "--quiet",
                          str(tmp_path / "missing.toml")], capture_output=True, timeout=120)
    assert bad.returncode == 2
    lines = bad.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error:") \
        and "missing.toml" in lines[0]
    usage = subprocess.run([sys.executable, "-m", "rangeproc.cli", "no-such-command"],
                           capture_output=True, timeout=120)
    assert usage.returncode == 2 and b"No such command" in usage.stderr
