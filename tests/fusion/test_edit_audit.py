"""Edits an engineer can see and audit (issue 28, item 4), on the hand-made flight
(tests/newuser.py: one 10 Hz radar with three wild ranges, +400 m, and a GPS, clean Gaussian
noise otherwise).

edits.parquet keeps hard rejections and down-weightings apart (``action``), gives values and
residuals in the file's own units beside the SI ones, and the summary counts both apart, with
the down-weighting count Gaussian noise of the estimated sigma implies.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from conftest import describe, invoke
from newuser import WILD_ROWS, make_flight
from rangeproc.fusion.edit_audit import REJECTED_SHOWN, rejected_examples
from rangeproc.fusion.edit_table import (
    DOWN_WEIGHTED,
    EDIT_COLUMNS,
    MATERIAL_WEIGHT,
    REJECTED,
    with_file_units,
)

#: 0-based radar data row whose azimuth the spoiled flight moves by AZ_SPIKE_DEG.
AZ_ROW, AZ_SPIKE_DEG = 400, 0.5


def _run(folder):  # type: ignore[no-untyped-def]
    result = invoke(["run", "--quiet", folder / "config.toml"])
    assert result.exit_code == 0, describe(result)
    out = folder / "out"
    return (pd.read_parquet(out / "edits.parquet"),
            json.loads((out / "summary.json").read_text()))


@pytest.fixture(scope="module")
def flight(tmp_path_factory):  # type: ignore[no-untyped-def]
    """(flight, edits table, summary) of one run of the hand-made flight as made."""
    made = make_flight(tmp_path_factory.mktemp("edits_flight"))
    return (made, *_run(made.folder))


@pytest.fixture(scope="module")
def azimuth_spike(tmp_path_factory):  # type: ignore[no-untyped-def]
    """(radar file, edits table) of the flight with one azimuth spoiled in its degree file."""
    made = make_flight(tmp_path_factory.mktemp("edits_azimuth"))
    radar = pd.read_csv(made.folder / "R1.csv")
    radar.loc[AZ_ROW, "azimuth"] += AZ_SPIKE_DEG
    radar.to_csv(made.folder / "R1.csv", index=False, float_format="%.8f")
    return radar, _run(made.folder)[0]


def test_wild_ranges_are_rejected_at_their_rows_in_metres(flight) -> None:
    made, edits, _ = flight
    assert tuple(edits.columns) == EDIT_COLUMNS
    rejected = edits[edits.action == REJECTED]
    assert rejected.row.tolist() == [k + 1 for k in WILD_ROWS]
    assert (rejected.sensor == "R1").all() and (rejected.component == "range").all()
    assert (rejected.reason == "pre-edit").all() and (rejected.weight == 0).all()
    assert (rejected.unit == "m").all() and (rejected.file_unit == "m").all()
    radar = pd.read_csv(made.folder / "R1.csv")
    written = radar.range.to_numpy()[list(WILD_ROWS)]
    np.testing.assert_allclose(rejected.value_file_unit, written, atol=1e-9)
    np.testing.assert_allclose(rejected.value, written, atol=1e-9)
    # the residual against the fused track is the planted 400 m (5 m noise)
    np.testing.assert_allclose(rejected.residual, 400.0, atol=25.0)
    assert (rejected.residual_file_unit == rejected.residual).all()
    assert (rejected.normalised_residual > 40.0).all()


def test_rejections_and_down_weightings_are_kept_apart(flight) -> None:
    _, edits, _ = flight
    assert set(edits.action) <= {REJECTED, DOWN_WEIGHTED}
    weighted = edits[edits.action == DOWN_WEIGHTED]
    assert len(weighted) > 0
    assert set(weighted.reason) <= {"burst", "residual"}
    assert ((weighted.weight > 0) & (weighted.weight < MATERIAL_WEIGHT)).all()
    # Huber's rule: weight 2 / |u| below 2/3 is a residual beyond 3 global sigmas
    huber = weighted[weighted.reason == "residual"]
    assert (np.abs(huber.normalised_residual) > 2.5).all()


def test_summary_counts_rejections_and_down_weightings_apart(flight) -> None:
    _, edits, summary = flight
    r1 = summary["sensors"]["R1"]
    assert r1["n_rejected_points"] == 3
    assert r1["n_rejected_by_reason"] == {"pre-edit": 3}
    assert r1["n_edited"] == {"pre-edit": 3}
    for sid, ss in summary["sensors"].items():
        mine = edits[edits.sensor == sid]
        weighted = mine[mine.action == DOWN_WEIGHTED]
        assert ss["n_rejected_points"] == (mine.action == REJECTED).sum(), sid
        assert ss["n_down_weighted"] == len(weighted), sid
        assert ss["n_down_weighted_by_reason"] == weighted.reason.value_counts().to_dict(), sid
    listed = summary["rejected_points"]
    assert listed["n"] == 3
    assert [(p["sensor"], p["row"], p["component"], p["reason"], p["unit"])
            for p in listed["shown"]] == [("R1", k + 1, "range", "pre-edit", "m")
                                          for k in WILD_ROWS]
    assert all(375.0 < p["residual"] < 425.0 for p in listed["shown"])


def test_down_weighting_on_clean_data_is_what_the_noise_model_implies(flight) -> None:
    """3 x 1201 radar and 3 x 121 GPS components of Gaussian noise: Huber's rule records a
    component beyond 3 sigmas, some 0.27 % of them (fewer after the fit); the count is
    within a Poisson band of the expected one."""
    _, _, summary = flight
    total_n = total_e = 0.0
    for sid, ss in summary["sensors"].items():
        n, e = ss["n_down_weighted"], ss["n_down_weighted_expected"]
        assert abs(n - e) <= 3.0 * math.sqrt(e) + 2.0, (sid, n, e)
        total_n, total_e = total_n + n, total_e + e
    r1 = summary["sensors"]["R1"]["n_down_weighted_expected"]
    assert 0.5 * 3 * 1201 * 0.0027 < r1 < 3 * 1201 * 0.0027
    assert abs(total_n - total_e) <= 3.0 * math.sqrt(total_e) + 2.0


def test_angles_are_in_degrees_in_a_degree_file(flight, azimuth_spike) -> None:
    made, edits, _ = flight
    radar = pd.read_csv(made.folder / "R1.csv")
    angles = edits[edits.component.isin(["azimuth", "elevation"])]
    assert len(angles) > 0
    assert (angles.unit == "rad").all() and (angles.file_unit == "deg").all()
    np.testing.assert_allclose(angles.value_file_unit, np.degrees(angles.value), rtol=1e-12)
    written = [radar.loc[r - 1, c] for r, c in zip(angles.row, angles.component)]
    np.testing.assert_allclose(angles.value_file_unit, written, atol=1e-7)
    np.testing.assert_allclose(angles.residual_file_unit, np.degrees(angles.residual),
                               rtol=1e-12)
    spoiled, spiked = azimuth_spike
    hit = spiked[(spiked.action == REJECTED) & (spiked.component == "azimuth")]
    assert hit.row.tolist() == [AZ_ROW + 1]
    assert hit.file_unit.iat[0] == "deg"
    assert hit.value_file_unit.iat[0] == pytest.approx(spoiled.azimuth[AZ_ROW], abs=1e-7)
    assert hit.residual_file_unit.iat[0] == pytest.approx(AZ_SPIKE_DEG, abs=0.05)


def test_file_units_of_angles_follow_the_sensor_angle_unit() -> None:
    table = pd.DataFrame({"sensor": ["A", "B", "B", "B"],
                          "component": ["azimuth", "elevation", "range", "*"],
                          "value": [np.pi / 2, np.pi, 100.0, np.nan],
                          "residual": [0.01, np.pi / 3200, 2.0, np.nan]})
    out = with_file_units(table, {"A": "deg", "B": "mil"})
    assert out.file_unit.tolist() == ["deg", "mil", "m", ""]
    assert out.unit.tolist() == ["rad", "rad", "m", ""]
    np.testing.assert_allclose(out.value_file_unit[:3], [90.0, 3200.0, 100.0])
    np.testing.assert_allclose(out.residual_file_unit[:3], [np.degrees(0.01), 1.0, 2.0])
    assert np.isnan(out.value_file_unit.iat[3])


def test_rejected_examples_are_capped_in_time_order() -> None:
    n = REJECTED_SHOWN + 20
    table = pd.DataFrame({"sensor": "R1", "row": np.arange(n, 0, -1),
                          "time": np.arange(n, 0, -1, dtype=float), "component": "range",
                          "value_file_unit": 1.0, "residual_file_unit": np.nan,
                          "file_unit": "m", "reason": "limit", "action": REJECTED})
    table = pd.concat([table, table.head(5).assign(action=DOWN_WEIGHTED)])
    listed = rejected_examples(table)
    assert listed["n"] == n and len(listed["shown"]) == REJECTED_SHOWN
    assert [p["time"] for p in listed["shown"]] == list(range(1, REJECTED_SHOWN + 1))
    assert listed["shown"][0]["residual"] is None
