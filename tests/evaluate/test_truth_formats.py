"""`rangeproc evaluate` with a range's truth (issue 28 item 5), on hand-made files.

One hand-made flight (``tests/newuser.py``: radar + GPS, truth.csv with ISO-8601 UTC times and
WGS-84 lat, lon, height, no velocity) is run once for the module; each test then writes the
truth the way a range would (float Unix seconds, range ENU, with local-ENU velocities, ...) or
spoils it, and checks the figures against an oracle computed here with pymap3d, or the one
error line (exit 2) that names the file, the 1-based data row and the column.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pymap3d
import pytest

from conftest import describe, invoke
from newuser import DAY_UNIX, ORIGIN, make_flight, truth_at

FIGURES = ("n_epochs", "pos_rmse", "pos_rmse_enu", "pos_p95", "inside_3sigma_enu",
           "nees_pos_mean")


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    """The hand-made flight, processed once by ``rangeproc run``."""
    f = make_flight(tmp_path_factory.mktemp("truth_formats") / "flight")
    result = invoke(["run", "--quiet", f.config])
    assert result.exit_code == 0, describe(result)
    return f


def out_copy(flight, dest: Path, summary: bool = True) -> Path:  # type: ignore[no-untyped-def]
    """A private output folder: the run's fused.parquet (and summary.json, naming the config)."""
    dest.mkdir()
    shutil.copy(flight.folder / "out" / "fused.parquet", dest)
    if summary:
        shutil.copy(flight.folder / "out" / "summary.json", dest)
    return dest


def evaluate(out: Path, truth: Path, *extra: str):  # type: ignore[no-untyped-def]
    return invoke(["evaluate", out, truth, *extra])


def evaluated(out: Path, truth: Path, *extra: str) -> tuple[dict, str, str]:
    """Run evaluate, expect success; (T1's metrics from evaluation.json, stdout, stderr)."""
    result = evaluate(out, truth, *extra)
    assert result.exit_code == 0, describe(result)
    metrics = json.loads((out / "evaluation.json").read_text())
    return metrics["targets"]["T1"], result.stdout, result.stderr


def one_error_line(result) -> str:  # type: ignore[no-untyped-def]
    assert result.exit_code == 2, describe(result)
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error: "), describe(result)
    assert "Traceback" not in result.output
    return lines[0]


def truth_table(flight) -> pd.DataFrame:  # type: ignore[no-untyped-def]
    """The hand-made truth: time (ISO text), lat, lon, height, plus unix (float s)."""
    df = pd.read_csv(flight.truth, dtype={"time": str})
    df["unix"] = (pd.to_datetime(df["time"], utc=True)
                  - pd.Timestamp("1970-01-01", tz="UTC")) / pd.Timedelta(seconds=1)
    return df


def write(df: pd.DataFrame, path: Path, columns: list[str]) -> Path:
    df[columns].to_csv(path, index=False, float_format="%.10f")
    return path


def oracle_rmse(flight) -> tuple[float, int]:  # type: ignore[no-untyped-def]
    """Position RMSE (m) of the fused lat, lon, height against the true trajectory at the fused
    epochs, each error taken in the true point's local ENU with pymap3d; and the epoch count."""
    fused = pd.read_parquet(flight.folder / "out" / "fused.parquet")
    lat, lon, h = truth_at(fused["time"].to_numpy())
    e, n, u = pymap3d.geodetic2enu(fused["lat"].to_numpy(), fused["lon"].to_numpy(),
                                   fused["height"].to_numpy(), lat, lon, h)
    err2 = np.asarray(e) ** 2 + np.asarray(n) ** 2 + np.asarray(u) ** 2
    return float(np.sqrt(np.mean(err2))), len(fused)


def local_velocities(unix: np.ndarray, lat0: float | None = None, lon0: float | None = None
                     ) -> np.ndarray:
    """(S, 3) true velocity (m/s), central difference of the ECEF track, in the local ENU of
    each point, or of (lat0, lon0) when given."""
    dt = 0.01
    ahead = np.column_stack(pymap3d.geodetic2ecef(*truth_at(unix + dt)))
    behind = np.column_stack(pymap3d.geodetic2ecef(*truth_at(unix - dt)))
    v = (ahead - behind) / (2 * dt)
    lat, lon, _ = truth_at(unix)
    if lat0 is not None:
        lat, lon = np.full_like(lat, lat0), np.full_like(lon, lon0)
    return np.column_stack(pymap3d.ecef2enuv(v[:, 0], v[:, 1], v[:, 2], lat, lon))


# ------------------------------------------------------------------------ accepted forms

def test_iso_geodetic_truth_matches_pymap3d_oracle(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    m, stdout, stderr = evaluated(out, flight.truth)
    rmse, n = oracle_rmse(flight)
    assert m["n_epochs"] == m["n_fused_epochs"] == n == 1201
    assert m["n_without_truth"] == 0
    assert m["pos_rmse"] == pytest.approx(rmse, rel=1e-5)
    assert 0.05 < m["pos_rmse"] < 5.0                    # a few metres at most, not zero
    assert f"epochs T1: {n} of {n} fused epochs evaluated, 0 without truth" in stdout
    assert "lat, lon, height; range origin 35, -117.5, 700 m from" in stdout
    assert str(flight.config) in stdout
    # no velocity in this truth: said on stderr and in the table, not faked
    assert stderr == "rangeproc: WARNING: truth.csv: no ve, vn, vu columns: velocity not " \
                     "evaluated\n"
    assert "velocity not evaluated" in stdout
    assert m["vel_rmse"] is None and m["vel_rmse_enu"] is None and m["vel_p95"] is None


def test_float_unix_and_enu_truth_give_the_same_figures(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    ref, _, _ = evaluated(out, flight.truth)
    df = truth_table(flight)
    e, n, u = pymap3d.geodetic2enu(df["lat"], df["lon"], df["height"], *ORIGIN)
    df["e"], df["n"], df["u"] = e, n, u
    unix_llh = write(df.assign(time=df["unix"]), tmp_path / "unix.csv",
                     ["time", "lat", "lon", "height"])
    iso_enu = write(df, tmp_path / "enu.csv", ["time", "e", "n", "u"])
    pq = tmp_path / "unix_enu.parquet"
    df.assign(time=df["unix"])[["time", "e", "n", "u"]].to_parquet(pq)
    for path in (unix_llh, iso_enu, pq):
        m, stdout, _ = evaluated(out, path)
        for key in FIGURES:
            assert m[key] == pytest.approx(ref[key], rel=1e-6, abs=1e-6), (path.name, key)
    assert "(e, n, u)" in stdout and "range origin" not in stdout


def test_velocity_local_enu_is_rotated_into_the_range_frame(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    df = truth_table(flight)
    v_local = local_velocities(df["unix"].to_numpy())
    v_range = local_velocities(df["unix"].to_numpy(), ORIGIN[0], ORIGIN[1])
    # the two frames differ by ~1.4 mrad at the track's ends: 0.2 m/s at 150 m/s
    assert np.abs(v_local - v_range).max() > 0.1
    df["ve"], df["vn"], df["vu"] = v_local.T
    geo, stdout, stderr = evaluated(out, write(df, tmp_path / "geo_v.csv",
                                               ["time", "lat", "lon", "height", "ve", "vn",
                                                "vu"]))
    assert stderr == "" and "velocity not evaluated" not in stdout
    e, n, u = pymap3d.geodetic2enu(df["lat"], df["lon"], df["height"], *ORIGIN)
    df["e"], df["n"], df["u"] = e, n, u
    df["ve"], df["vn"], df["vu"] = v_range.T
    enu, _, _ = evaluated(out, write(df, tmp_path / "enu_v.csv",
                                     ["time", "e", "n", "u", "ve", "vn", "vu"]))
    assert geo["vel_rmse"] == pytest.approx(enu["vel_rmse"], rel=1e-4)
    assert geo["vel_rmse_enu"] == pytest.approx(enu["vel_rmse_enu"], rel=1e-4, abs=1e-5)
    assert 0.0 < geo["vel_rmse"] < 2.0


def test_partial_truth_counts_epochs_without_truth(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    df = truth_table(flight)
    first = df[df["unix"] <= df["unix"].iloc[0] + 60.0]       # the first minute only
    m, stdout, _ = evaluated(out, write(first, tmp_path / "minute.csv",
                                        ["time", "lat", "lon", "height"]))
    assert m["n_epochs"] == 601 and m["n_without_truth"] == 600 and m["n_fused_epochs"] == 1201
    assert "epochs T1: 601 of 1201 fused epochs evaluated, 600 without truth; truth span " \
           "1778508000.000 .. 1778508060.000 s (2026-05-11T14:00:00.000Z .. " \
           "2026-05-11T14:01:00.000Z)" in stdout


# ------------------------------------------------------------------------------ the origin

@pytest.mark.parametrize("case", ["config moved", "no summary"])
def test_origin_option_when_the_config_is_not_there(flight, tmp_path, case):
    ref, _, _ = evaluated(out_copy(flight, tmp_path / "ref"), flight.truth)
    out = out_copy(flight, tmp_path / "out", summary=case != "no summary")
    if case == "config moved":
        summary = json.loads((out / "summary.json").read_text())
        summary["config"]["file"] = str(tmp_path / "gone" / "config.toml")
        (out / "summary.json").write_text(json.dumps(summary))
        why = f"the run's config {tmp_path / 'gone' / 'config.toml'} (from summary.json) is " \
              "not there"
    else:
        why = f"{out / 'summary.json'} not found"
    line = one_error_line(evaluate(out, flight.truth))
    assert line == (f"rangeproc: error: truth.csv: position is lat, lon, height and needs the "
                    f"range origin: {why}; give --origin LAT,LON,HEIGHT (WGS-84 degrees, "
                    "degrees, metres above the ellipsoid)")
    assert not (out / "evaluation.json").exists()
    m, stdout, _ = evaluated(out, flight.truth, "--origin", ",".join(map(str, ORIGIN)))
    for key in FIGURES:
        assert m[key] == pytest.approx(ref[key], rel=1e-12), key
    assert "range origin 35, -117.5, 700 m from --origin" in stdout


def test_config_changed_since_the_run_is_a_warning(flight, tmp_path):
    ref, _, _ = evaluated(out_copy(flight, tmp_path / "ref"), flight.truth)
    out = out_copy(flight, tmp_path / "out")
    config = tmp_path / "edited.toml"
    config.write_text(flight.config.read_text() + "\n# edited after the run\n")
    summary = json.loads((out / "summary.json").read_text())
    summary["config"]["file"] = str(config)
    (out / "summary.json").write_text(json.dumps(summary))
    m, stdout, stderr = evaluated(out, flight.truth)
    assert (f"rangeproc: WARNING: {config} changed since the run (SHA-256 differs from "
            "summary.json); its [range] origin is used") in stderr.splitlines()
    assert f"range origin 35, -117.5, 700 m from {config}" in stdout
    for key in FIGURES:
        assert m[key] == pytest.approx(ref[key], rel=1e-12), key


def test_origin_option_overrides_the_config(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    m, stdout, _ = evaluated(out, flight.truth, "--origin", "35.0,-117.5,720")  # 20 m higher
    assert m["pos_rmse_enu"][2] == pytest.approx(20.0, abs=1.0)
    assert "range origin 35, -117.5, 720 m from --origin" in stdout


@pytest.mark.parametrize("text, expect", [
    ("35,-117.5", "--origin: expected LAT,LON,HEIGHT (WGS-84 degrees, degrees, metres above "
                  "the ellipsoid), got '35,-117.5'"),
    ("95,-117.5,700", "--origin: latitude 95 outside [-90, 90] degrees"),
])
def test_bad_origin_option(flight, tmp_path, text, expect):
    out = out_copy(flight, tmp_path / "out")
    assert one_error_line(evaluate(out, flight.truth, "--origin", text)) == \
        f"rangeproc: error: {expect}"


# -------------------------------------------------------------------- errors, one line each

def spoil(flight, path: Path, row: int, column: str, text: str) -> Path:
    """truth.csv with data row ``row`` (1-based) cell ``column`` replaced by ``text``."""
    lines = flight.truth.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = text
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("row, column, text, expect", [
    (7, "lat", "abc", "row 7, column 'lat': 'abc' is not a number"),
    (12, "height", "", "row 12, column 'height': empty (every truth row needs a value here)"),
    (5, "time", "2026-05-11T14:00:02.000",
     "row 5, column 'time': ISO-8601 time '2026-05-11T14:00:02.000' has no UTC offset or 'Z'"),
    (3, "time", "2026-05-11T14:00:00.500Z",
     "row 3, column 'time': same time as row 2 (1778508000.5 s)"),
    (9, "lon", "400", "row 9, column 'lon': 400 is outside [-180, 360) degrees"),
])
def test_bad_truth_cell_is_one_line_with_row_and_column(flight, tmp_path, row, column, text,
                                                        expect):
    out = out_copy(flight, tmp_path / "out")
    bad = spoil(flight, tmp_path / "truth.csv", row, column, text)
    assert one_error_line(evaluate(out, bad)) == f"rangeproc: error: truth.csv: {expect}"
    assert not (out / "evaluation.json").exists()


@pytest.mark.parametrize("columns, expect", [
    (["time", "lat", "lon"], "missing column 'height' (position: e, n, u in range ENU m, or "
                             "lat, lon, height in WGS-84 degrees and metres)"),
    (["time", "lat", "lon", "height", "ve", "vn"],
     "missing column 'vu' (velocity: give ve, vn, vu or none of them)"),
])
def test_incomplete_column_set_is_one_line(flight, tmp_path, columns, expect):
    out = out_copy(flight, tmp_path / "out")
    df = truth_table(flight).assign(ve=150.0, vn=0.0)
    bad = write(df, tmp_path / "truth.csv", columns)
    assert one_error_line(evaluate(out, bad)) == f"rangeproc: error: truth.csv: {expect}"


def test_truth_on_another_time_scale_names_both_spans(flight, tmp_path):
    out = out_copy(flight, tmp_path / "out")
    df = truth_table(flight)
    sod = write(df.assign(time=df["unix"] - DAY_UNIX), tmp_path / "sod.csv",
                ["time", "lat", "lon", "height"])              # seconds of day
    line = one_error_line(evaluate(out, sod))
    assert line == ("rangeproc: error: sod.csv: no fused epoch within the truth's time span: "
                    "truth 50400.000 .. 50520.000 s, fused.parquet 1778508000.000 .. "
                    "1778508120.000 s (2026-05-11T14:00:00.000Z .. 2026-05-11T14:02:00.000Z); "
                    "are both on one time scale (ISO-8601 times are read as Unix seconds)?")
    assert not (out / "evaluation.json").exists()
