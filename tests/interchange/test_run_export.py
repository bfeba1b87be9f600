"""``[output] export``: a run writes the interchange files with its other outputs, atomically,
and a bad ``export`` or ``epoch`` key is a one-line exit 2 before any processing."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from conftest import keep_sensors

CONFIG = "scenario.toml"


def set_output(folder: Path, lines: str) -> None:
    """Add ``lines`` to the scenario's [output] table."""
    path = folder / CONFIG
    text = path.read_text()
    assert "[output]\n" in text
    path.write_text(text.replace("[output]\n", "[output]\n" + lines, 1))


def test_run_writes_the_exports_with_its_outputs(scenario: Path, cli, explain) -> None:
    keep_sensors(scenario, {"R1", "G1"})
    set_output(scenario, 'export = ["czml", "csv"]\nepoch = "2026-05-11T00:00:00Z"\n')
    result = cli(["run", "--quiet", scenario / CONFIG])
    assert result.exit_code == 0, explain(result)
    out = scenario / "out"
    fused = pd.read_parquet(out / "fused.parquet")
    table = pd.read_csv(out / "fused.csv")
    assert len(table) == len(fused) and table["utc"].iloc[0].startswith("2026-05-1")
    packets = json.loads((out / "fused.czml").read_text())
    assert [p["id"] for p in packets[1:]] == sorted(set(fused.target_id),
                                                    key=list(fused.target_id).index)
    assert not (out / "fused.kml").exists()
    assert not [p for p in out.rglob("*") if p.name.startswith(".")]   # no temp or staging


@pytest.mark.parametrize("lines, message", [
    ('export = ["kmz"]\n', "output.export[0]: unknown format 'kmz'"),
    ('export = "kml"\n', "output.export: expected an array"),
    ('epoch = "2026-05-11"\n', "output.epoch: '2026-05-11' has no UTC offset"),
    ('epoch = 12\n', "output.epoch: expected a string"),
])
def test_bad_export_keys_are_one_line_exit_2(scenario: Path, cli, lines: str,
                                             message: str) -> None:
    set_output(scenario, lines)
    result = cli(["run", "--quiet", scenario / CONFIG])
    assert result.exit_code == 2
    err = result.stderr.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "scenario.toml" in err[0], err
    assert not (scenario / "out" / "fused.parquet").exists()
