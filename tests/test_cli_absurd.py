"""Absurd but parseable data (issue: never an internal error, never unbounded).

The four cases a new user met: a radar range of 1e308, one corrupt time stamp 1e6 s late, a
GPS file on a time scale a day off, every GPS row stamped with one far time. Each must end in a
clean run with the row edited, or in exit 2 naming the sensor and both time spans; and the
output must stay the size of the data.
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

CONFIG = "scenario.toml"


def edit_csv(folder: Path, name: str, fn) -> None:
    df = pd.read_csv(folder / name)
    out = fn(df)
    df = df if out is None else out
    df.to_csv(folder / name, index=False, float_format="%.17g")


def fused_rows(folder: Path) -> int:
    return pq.read_metadata(folder / "out" / "fused.parquet").num_rows


@pytest.fixture(scope="module")
def normal_rows(sample_run) -> int:
    return fused_rows(sample_run.folder)


@pytest.mark.parametrize("row", [0, 500])
def test_range_1e308_is_edited_and_the_run_is_clean(scenario, cli, explain, normal_rows,
                                                    row) -> None:
    edit_csv(scenario, "R1.csv", lambda df: df.__setitem__("range", df["range"].where(
        df.index != row, 1e308)))
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert summary["sensors"]["R1"]["n_edited"]["limit"] == 1
    assert summary["sensors"]["R1"]["edit_examples"][0]["row"] == row + 1
    assert fused_rows(scenario) == normal_rows


def test_one_stamp_1e6_s_late_is_edited_and_does_not_stretch_the_flight(
        scenario, cli, explain, normal_rows) -> None:
    edit_csv(scenario, "R1.csv", lambda df: df.__setitem__("time", df["time"].where(
        df.index != 500, df["time"] + 1e6)))
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    assert "R1: edited before estimation:" in res.stderr and " 1 time" in res.stderr
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert summary["sensors"]["R1"]["n_edited"]["time"] == 1
    assert len(summary["targets"]["T1"]["spans"]) == 1
    assert fused_rows(scenario) == normal_rows


def test_gps_a_day_off_is_refused_naming_the_sensor_and_both_spans(scenario, cli) -> None:
    cfg = scenario / CONFIG
    text = cfg.read_text().replace('target = "T1"\n', 'target = "T1"\ntime_offset = 86400.0\n'
                                   ).replace("time_offset = 0.0\n\n[[sensors]]\nid = \"MISTRAM\"",
                                             "\n[[sensors]]\nid = \"MISTRAM\"")
    cfg.write_text(text)
    res = cli(["run", "--quiet", cfg])
    assert res.exit_code == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("rangeproc: error: G1.csv: sensor G1 time span 432697.")
    assert "other sensors (346297." in lines[0]
    assert not (scenario / "out" / "fused.parquet").exists()
    cfg.write_text(text.replace('time_offset = 86400.0\n',
                                'time_offset = 86400.0\nallow_disjoint_time = true\n'))
    res = cli(["run", "--quiet", cfg])                 # accepted when intended: two spans
    assert res.exit_code == 0, res.stderr
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert len(summary["targets"]["T1"]["spans"]) == 2


@pytest.mark.parametrize("shift, ok", [(-1e5, False), (60.0, True)])
def test_every_gps_row_at_one_time(scenario, cli, explain, shift, ok) -> None:
    edit_csv(scenario, "G1.csv", lambda df: df.__setitem__("time", df["time"].iloc[0] + shift))
    res = cli(["run", "--quiet", scenario / CONFIG])
    if ok:                   # inside the others' span: the repeats are edited, the run is clean
        assert res.exit_code == 0, explain(res)
        summary = json.loads((scenario / "out" / "summary.json").read_text())
        assert summary["sensors"]["G1"]["n_edited"]["repeated stamp"] == 995
    else:
        assert res.exit_code == 2, explain(res)
        assert res.stderr.startswith("rangeproc: error: G1.csv: sensor G1 time span")
        assert res.stderr.count("\n") == 1


def test_a_long_gap_splits_the_output_into_spans(scenario, cli, explain) -> None:
    t0 = pd.read_csv(scenario / "G1.csv")["time"].min()
    def cut(df: pd.DataFrame) -> pd.DataFrame:
        return df[(df.time <= t0 + 30) | (df.time >= t0 + 100)]

    for name in ("R1.csv", "S1.csv", "G1.csv", "MISTRAM.csv"):
        edit_csv(scenario, name, cut)
    th = cut(pd.read_parquet(scenario / "TH1.parquet"))
    th.to_parquet(scenario / "TH1.parquet", index=False)
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    spans = summary["targets"]["T1"]["spans"]
    assert len(spans) == 2 and spans[1][0] - spans[0][1] > 60.0
    fused = pd.read_parquet(scenario / "out" / "fused.parquet")
    inside = (fused.time > spans[0][1] + 1.0) & (fused.time < spans[1][0] - 1.0)
    # the gap is bridged (fusion.bridge), and marked
    assert inside.sum() > 600 and fused.bridged[inside].all()
    assert (fused.n_sensors[inside] == 0).all()
    assert len(fused) < 10.0 * (spans[1][1] - spans[0][0]) + 2   # bounded by the time span


def test_ins_without_usable_attitude_is_refused_naming_its_file(scenario, cli) -> None:
    text = (scenario / "SHIP_INS.csv").read_text().splitlines()
    head, rows = text[0], text[1:]
    col = head.split(",").index("roll")
    blank = [",".join(" " if i == col else v for i, v in enumerate(r.split(","))) for r in rows]
    (scenario / "SHIP_INS.csv").write_text("\n".join([head, *blank]) + "\n")
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 2, res.stderr
    assert res.stderr.startswith("rangeproc: error: SHIP_INS.csv: fewer than 2 usable rows")
    assert res.stderr.count("\n") == 1


def test_mistram_rows_all_at_one_time_run_clean(scenario, cli, explain) -> None:
    edit_csv(scenario, "MISTRAM.csv", lambda df: df.assign(time=df["time"].iloc[3000]))
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert summary["sensors"]["MISTRAM"]["n_edited"]["repeated stamp"] == 9584 - 4


def _start_run(offset: float, n: int):
    def corrupt(df: pd.DataFrame) -> None:
        df.loc[: n - 1, "range"] += offset
    return corrupt


@pytest.mark.parametrize(("offset", "n", "reason", "n_components"), [
    (3000.0, 40, "speed", 3),        # 60 km/s into the track: impossible, longer than a window
    (150.0, 5, "pre-edit", 1),       # possible speed, but wild: the Hampel window sees it
])
def test_a_run_of_wild_fixes_at_track_start_is_edited(scenario, cli, explain, normal_rows,
                                                      offset, n, reason, n_components) -> None:
    edit_csv(scenario, "R1.csv", _start_run(offset, n))
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    edits = pd.read_parquet(scenario / "out" / "edits.parquet")
    mine = edits[(edits.sensor == "R1") & (edits.reason == reason)]
    assert set(range(1, n + 1)) <= set(mine[mine.component == "range"].row)
    assert len(mine[mine.row <= n]) == n * n_components
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert summary["sensors"]["R1"]["n_edited"][reason] == len(mine)
    assert fused_rows(scenario) == normal_rows
