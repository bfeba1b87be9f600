"""CSV dialects (rangeproc.io.dialect): a semicolon- or tab-separated file, with decimal
points or commas, is read as its comma version and said once; an ambiguous or unreadable one
is refused with one line naming the separator."""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

from conftest import describe, invoke
from newuser import make_flight
from rangeproc.config import SensorSettings
from rangeproc.errors import DataError
from rangeproc.io.dialect import Dialect
from rangeproc.io.readers import read_sensor
from rangeproc.run_warnings import NOTE

COMMA = """\
time,range,azimuth,elevation,range_rate,track_id
100.0,15000.5,45.25,10.0,-120.5,7
100.1,14990.0,45.125,1e-1,-120.4,7
100.2,14980.25,-0.5,10.2,,8
"""


def _dialect(text: str, separator: str, decimal: str) -> str:
    """``text`` (comma-separated, decimal points) written in another dialect."""
    out = []
    for line in text.splitlines():
        cells = [c.replace(".", decimal) for c in line.split(",")]
        out.append(separator.join(cells))
    return "\n".join(out) + "\n"


def _read(tmp_path: Path, text: str, name: str = "R1.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return read_sensor(SensorSettings(id="R1", kind="radar", file=path))


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.row, b.row)
    np.testing.assert_array_equal(a.track_id, b.track_id)
    assert a.columns.keys() == b.columns.keys()
    for k in a.columns:
        np.testing.assert_array_equal(a.columns[k], b.columns[k], err_msg=k)


@pytest.mark.parametrize(("separator", "decimal", "words"), [
    (";", ",", "semicolon-separated (';') with decimal commas"),
    (";", ".", "semicolon-separated (';') with decimal points"),
    ("\t", ".", "tab-separated with decimal points"),
    ("\t", ",", "tab-separated with decimal commas")])
def test_each_dialect_reads_as_its_comma_version_and_is_said_once(tmp_path, caplog, separator,
                                                                  decimal, words):
    reference = _read(tmp_path, COMMA, "comma.csv")
    caplog.clear()
    with caplog.at_level(NOTE):
        other = _read(tmp_path, _dialect(COMMA, separator, decimal))
    _same(other, reference)
    notes = [r for r in caplog.records if r.levelno == NOTE]
    assert len(notes) == 1, caplog.text
    assert notes[0].getMessage().startswith(f"R1.csv: read as {words}")
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_the_contract_dialect_says_nothing(tmp_path, caplog):
    with caplog.at_level(logging.DEBUG):
        _read(tmp_path, COMMA)
    assert not [r for r in caplog.records if r.levelno >= NOTE]


def test_the_issue_case_semicolons_and_decimal_commas(tmp_path):
    """A spreadsheet's export: it used to give "missing required column 'time'"."""
    log = _read(tmp_path, "time;range;azimuth;elevation\n1,5;1000,25;45,5;2,75\n"
                          "2,5;1001,25;45,75;2,5\n")
    np.testing.assert_array_equal(log.time, [1.5, 2.5])
    np.testing.assert_array_equal(log.columns["range"], [1000.25, 1001.25])


def test_an_ambiguous_separator_is_refused_naming_both(tmp_path):
    text = "time;range;azimuth;elevation;\ttime\trange\tazimuth\televation\n1;2;3;4;\t1\t2\t3\t4\n"
    with pytest.raises(DataError) as err:
        _read(tmp_path, text)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith("R1.csv: ambiguous column separator: the header row splits into the "
                          "required columns at ';' and at tab")


def test_both_decimal_marks_in_one_file_are_refused_naming_a_cell_of_each(tmp_path):
    text = "time;range;azimuth;elevation\n1;1000,5;45;2\n2;1001.5;45;2\n"
    with pytest.raises(DataError) as err:
        _read(tmp_path, text)
    assert str(err.value) == (
        "R1.csv: semicolon-separated (';') with both decimal marks: row 1, column 'range': "
        "'1000,5' and row 2, column 'range': '1001.5'; write every number with one decimal "
        "mark")


def test_a_missing_column_names_the_separator_it_was_read_with(tmp_path):
    with pytest.raises(DataError) as err:
        _read(tmp_path, "time;rng;azimuth;elevation\n1;2;3;4\n")
    assert str(err.value) == ("R1.csv: missing required column 'range' (header read as "
                              "semicolon-separated: time, rng, azimuth, elevation)")


def test_a_short_row_names_the_separator(tmp_path):
    with pytest.raises(DataError) as err:
        _read(tmp_path, "time;range;azimuth;elevation\n1;2;3;4\n2;3;4\n")
    assert str(err.value) == ("R1.csv: row 2: expected 4 fields (separated by semicolons), "
                              "got 3")


def test_a_bad_cell_among_decimal_commas_is_the_one_named(tmp_path):
    with pytest.raises(DataError) as err:
        _read(tmp_path, "time;range;azimuth;elevation\n1;1000,5;45;2\n2;abc;45,5;2\n")
    assert str(err.value) == "R1.csv: row 2, column 'range': 'abc' is not a number"


def test_a_dialect_in_words():
    assert Dialect().is_contract and not Dialect(";", ",").is_contract
    assert Dialect("\t", ",").describe() == "tab-separated with decimal commas"


def test_a_run_on_a_semicolon_file_says_it_once_and_warns_nothing(tmp_path):
    """End to end: the radar file of a hand-made flight rewritten as a European spreadsheet
    exports it; the run reads it as the comma file (same fused track) with one note."""
    flight = make_flight(tmp_path / "comma")
    ref = invoke(["run", "--quiet", flight.config])
    assert ref.exit_code == 0, describe(ref)
    other = make_flight(tmp_path / "semi")
    path = other.folder / "R1.csv"
    path.write_text(_dialect(path.read_text(), ";", ","))
    res = invoke(["run", "--quiet", other.config])
    assert res.exit_code == 0, describe(res)
    lines = res.stderr.splitlines()
    assert lines == ["rangeproc: note: R1.csv: read as semicolon-separated (';') with decimal "
                     "commas (the contract's CSV: commas between columns, decimal points)"]
    summary = json.loads((other.folder / "out" / "summary.json").read_text())
    assert summary["warnings"] == []
    a = json.loads((flight.folder / "out" / "summary.json").read_text())
    assert summary["sensors"]["R1"]["n_used"] == a["sensors"]["R1"]["n_used"]
