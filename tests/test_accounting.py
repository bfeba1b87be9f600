"""Every row accounted for (stages.accounting, editing.repeats, fusion.isolated), on hand-made
files (tests/handmade.py): each spoiled case gives exactly one warning line naming the sensor,
the count and the likely cause; the rows of every sensor add up to the rows read; a sensor's
misplaced rows make no phantom object unless keep_isolated = true; clean files say nothing."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from conftest import describe, invoke
from handmade import SITE, THEO_SITE, make_case


def _run(case):
    result = invoke(["run", "--quiet", case.config])
    assert result.exit_code == 0, describe(result)
    lines = [ln for ln in result.stderr.strip().splitlines() if ln]
    out = case.folder / "out"
    return lines, json.loads((out / "summary.json").read_text()), out


def _adds_up(summary) -> None:
    for sid, s in summary["sensors"].items():
        r = s["rows"]
        total = (r["used"] + r["no_measurement"] + sum(r["rejected"].values())
                 + r.get("no_platform_geometry", 0) + sum(r.get("not_associated", {}).values())
                 + r["not_started"])
        assert total == r["read"] == s["n_read"], (sid, r)


def test_clean_files_say_nothing_and_every_row_is_used(tmp_path):
    lines, summary, _ = _run(make_case(tmp_path, theodolite=True, ship=True))
    assert lines == [] and summary["warnings"] == []
    _adds_up(summary)
    for sid in ("R1", "G1", "TH1", "S1"):
        assert summary["sensors"][sid]["rows"]["used"] == summary["sensors"][sid]["n_read"]


@pytest.mark.parametrize("site", [(THEO_SITE[1], THEO_SITE[0], THEO_SITE[2]),
                                  (THEO_SITE[0], -THEO_SITE[1], THEO_SITE[2])],
                         ids=["lat-lon-swapped", "lon-sign-flipped"])
def test_a_theodolite_with_a_wrong_site_is_said_to_contribute_nothing(tmp_path, site):
    lines, summary, _ = _run(make_case(tmp_path, theodolite=True, theo_config_site=site))
    assert len(lines) == 1, lines
    assert lines[0].startswith("rangeproc: WARNING: TH1.csv: sensor TH1 contributes nothing, "
                               "1201 of its 1201 rows lost to 'no object fits': ")
    assert "its site is likely wrong (latitude and longitude swapped" in lines[0]
    rows = summary["sensors"]["TH1"]["rows"]
    assert rows["used"] == 0 and rows["not_associated"] == {"no object fits": 1201}
    _adds_up(summary)


def test_an_ins_log_ending_two_minutes_early_names_both_spans(tmp_path):
    lines, summary, _ = _run(make_case(tmp_path, ship=True, duration=180.0, ins_short=120.0))
    assert len(lines) == 1, lines
    assert lines[0].startswith("rangeproc: WARNING: S1.csv: sensor S1 loses 1191 of 1801 rows "
                               "(66%) to 'no platform geometry': INS SHIP (SHIP.csv) spans ")
    assert lines[0].endswith("the INS log ends 119.0 s before the sensor's last row")
    s1 = summary["sensors"]["S1"]
    assert s1["rows"]["no_platform_geometry"] == s1["n_no_platform_geometry"] == 1191
    _adds_up(summary)


def test_300_duplicated_rows_are_dropped_counted_and_said(tmp_path):
    lines, summary, out = _run(make_case(tmp_path, duplicate_rows=300))
    assert lines == ["rangeproc: WARNING: R1.csv: 300 rows repeat an earlier row exactly "
                     "(first: row 901): dropped as duplicates (the log or a block of it written "
                     "twice?)"]
    r1 = summary["sensors"]["R1"]
    assert r1["rows"]["rejected"] == {"duplicate": 300} and r1["rows"]["used"] == 1201
    edits = pd.read_parquet(out / "edits.parquet")
    assert (edits["reason"] == "duplicate").sum() == 300
    _adds_up(summary)


def test_a_stuck_clock_repeating_150_stamps_is_said(tmp_path):
    lines, summary, out = _run(make_case(tmp_path, stuck_rows=150))
    assert len(lines) == 1, lines
    assert lines[0].startswith("rangeproc: WARNING: R1.csv: 150 rows repeat the time stamp of "
                               "an earlier row with other values (first: row 401 at ")
    assert "a stuck clock?" in lines[0]
    assert summary["sensors"]["R1"]["rows"]["rejected"] == {"repeated stamp": 150}
    assert summary["sensors"]["R1"]["rows"]["used"] == 1051
    _adds_up(summary)


@pytest.mark.parametrize("spoil", [{"radar_range_scale": 1e-3},
                                   {"radar_config_site": (SITE[0] + 0.045, SITE[1], SITE[2])}],
                         ids=["range-in-km", "site-5-km-off"])
def test_misplaced_radar_rows_make_no_phantom_object(tmp_path, spoil):
    lines, summary, out = _run(make_case(tmp_path / "a", **spoil))
    assert len(lines) == 1, lines
    assert "R1.csv and G1.csv disagree" in lines[0]
    assert lines[0].endswith("left out of fused.parquet: O1 (its rows are in edits.parquet, "
                             "reason isolated; [processing] keep_isolated = true keeps it)")
    fused = pd.read_parquet(out / "fused.parquet")
    assert set(fused["target_id"]) == {"T1"} and list(summary["targets"]) == ["T1"]
    edits = pd.read_parquet(out / "edits.parquet")
    assert ((edits["sensor"] == "R1") & (edits["reason"] == "isolated")).sum() == 1201
    assoc = pd.read_parquet(out / "association.parquet")
    assert set(assoc.loc[assoc["sensor"] == "R1", "reason"]) == {"isolated"}
    assert summary["sensors"]["R1"]["rows"]["rejected"] == {"isolated": 1201}
    _adds_up(summary)

    kept = make_case(tmp_path / "b", extra="[processing]\nkeep_isolated = true\n", **spoil)
    lines, summary, out = _run(kept)
    assert len(lines) >= 1 and "disagree" in lines[0] and "left out" not in lines[0]
    fused = pd.read_parquet(out / "fused.parquet")
    assert set(fused["target_id"]) == {"T1", "O1"}
    _adds_up(summary)


def test_the_sample_rows_add_up(sample_run):
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    assert summary["warnings"] == []
    _adds_up(summary)


def test_a_plot_feed_losing_plots_to_no_object_is_its_normal_lot():
    """A radar of plots (no track_id) whose plots of objects no other sensor follows fit no
    object: no line while it contributes; a tracked feed losing as many rows, or a plot feed
    contributing nothing, still gets one."""
    from pathlib import Path
    from types import SimpleNamespace

    import numpy as np

    from rangeproc.stages.accounting import accounting_lines

    fate = np.array(["used"] * 880 + ["no object fits"] * 120, dtype=object)
    sensor = SimpleNamespace(id="LIDAR", kind="radar", file=Path("LIDAR.csv"), site=None)
    cfg = SimpleNamespace(sensors=(sensor,))

    def lines(track_id, f=fate):
        logs = {"LIDAR": SimpleNamespace(track_id=track_id)}
        return list(accounting_lines(cfg, {"LIDAR": f}, logs))

    assert lines(None) == []
    assert len(lines(np.zeros(1000, dtype=np.int64))) == 1
    nothing = np.array(["no object fits"] * 1000, dtype=object)
    assert len(lines(None, nothing)) == 1 and "contributes nothing" in lines(None, nothing)[0]
