"""Error behaviour of ``rangeproc run`` end to end (data contract section 4, exit statuses).

Every unusable input or config gives exit status 2 and exactly one line on stderr,
``rangeproc: error: <message>``, naming the file and the row/column or key at fault, with no
traceback and no output file created. Numerical failures give 3, an output that cannot be
written 5 (one line naming the path and the cause), anything else 1 (a traceback only with
``--debug``). Output files are atomic: a failure never leaves a partial or temp file.

Each case mutates a fresh copy of sample_data (``scenario`` fixture); sample_data/ itself is
never touched.
"""
from __future__ import annotations

import csv
import errno
import io
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import rangeproc.stages.fuse
import rangeproc.report.figures
from conftest import keep_sensors
from rangeproc.errors import DataError, NumericalError, RangeprocError

CONFIG = "scenario.toml"
FAST = {"R1", "G1"}  # a quick subset of the sample's sensors: a run takes ~1 s

# --------------------------------------------------------------------------------------------
# helpers: mutate the copied scenario
# --------------------------------------------------------------------------------------------


def replace_once(path: Path, old: str, new: str) -> int:
    """Replace the first occurrence of ``old`` in a text file; returns its 1-based line number."""
    text = path.read_text()
    at = text.find(old)
    assert at >= 0, f"{old!r} not in {path.name}: the test fixture changed"
    path.write_text(text[:at] + new + text[at + len(old):])
    return text.count("\n", 0, at) + 1


def read_rows(path: Path) -> list[list[str]]:
    with path.open(newline="") as fh:
        return list(csv.reader(fh))


def write_rows(path: Path, rows: list[list[str]]) -> None:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    path.write_text(buf.getvalue())


def set_cell(path: Path, row: int, column: str, value: str) -> None:
    """Set the cell of a CSV sensor file at 1-based data ``row`` and ``column``; the cell must
    hold a value before (so the mutation is what the reader sees)."""
    rows = read_rows(path)
    j = rows[0].index(column)
    assert rows[row][j].strip(), f"{path.name} row {row} {column}: already empty"
    rows[row][j] = value
    write_rows(path, rows)


def drop_column(path: Path, column: str) -> None:
    rows = read_rows(path)
    j = rows[0].index(column)
    write_rows(path, [r[:j] + r[j + 1:] for r in rows])


def iso(seconds: float, offset: bool = True) -> str:
    """Seconds since the Unix epoch -> ISO-8601 text, with 'Z' or without any offset."""
    text = np.datetime_as_string(np.datetime64(int(round(seconds * 1e6)), "us"))
    return text + ("Z" if offset else "")


def iso_times(path: Path, naive_rows: set[int] | None = None) -> None:
    """Rewrite a CSV's time column as ISO-8601 text ('Z'), without an offset in ``naive_rows``
    (1-based data rows; None: every row)."""
    rows = read_rows(path)
    j = rows[0].index("time")
    for i in range(1, len(rows)):
        rows[i][j] = iso(float(rows[i][j]), offset=naive_rows is not None and i not in naive_rows)
    write_rows(path, rows)


def rewrite_parquet(path: Path, column: str, make: Callable[[pa.ChunkedArray], pa.Array]
                    ) -> None:
    """Replace one column of a Parquet file by ``make(old_column)``."""
    table = pq.read_table(path)
    i = table.schema.get_field_index(column)
    table = table.set_column(i, column, make(table.column(column)))
    pq.write_table(table, path)


def parquet_text_with(bad_row: int, bad: str) -> Callable[[pa.ChunkedArray], pa.Array]:
    """Numbers written as text, with ``bad`` at 1-based ``bad_row``."""
    def make(col: pa.ChunkedArray) -> pa.Array:
        values = [repr(v) for v in col.to_pylist()]
        values[bad_row - 1] = bad
        return pa.array(values, pa.string())
    return make


def parquet_float_with(bad_row: int, bad: float) -> Callable[[pa.ChunkedArray], pa.Array]:
    def make(col: pa.ChunkedArray) -> pa.Array:
        values = col.to_numpy().copy()
        values[bad_row - 1] = bad
        return pa.array(values, pa.float64(), from_pandas=False)
    return make


def listing(folder: Path) -> list[str]:
    """Every file below ``folder`` (hidden ones too), relative, sorted. Folders are left out:
    the contract is about files (an empty output folder may be created up front)."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if not p.is_dir())


def temp_files(folder: Path) -> list[str]:
    return [str(p.relative_to(folder)) for p in folder.rglob("*")
            if p.name.startswith(".") or "tmp" in p.name.lower()]


def assert_one_error_line(result, explain, code: int, *needles: str) -> str:
    """Exit ``code``, exactly one stderr line ``rangeproc: error: ...`` holding every needle,
    nothing on stdout, no traceback. Returns the line."""
    assert result.exit_code == code, explain(result)
    lines = result.stderr.splitlines()
    assert len(lines) == 1, explain(result)
    line = lines[0]
    assert line.startswith("rangeproc: error: "), explain(result)
    assert "Traceback" not in result.output and "Traceback" not in result.stderr
    assert result.stdout == "", explain(result)
    for needle in needles:
        assert needle in line, f"{needle!r} not in the error line: {line}"
    return line


# --------------------------------------------------------------------------------------------
# exit status 2: one case per kind of unusable input
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """A mutation of the copied scenario and what the error line must name.

    ``mutate(folder)`` may return a list of extra needles computed from the files (e.g. a
    line number); any other return value is ignored.
    ``config`` is the config file name passed to ``run``.
    """

    mutate: Callable[[Path], list[str] | None]
    needles: tuple[str, ...]
    config: str = CONFIG


def _cfg(old: str, new: str) -> Callable[[Path], None]:
    return lambda d: (replace_once(d / CONFIG, old, new), None)[1]


def _cell(name: str, row: int, column: str, value: str) -> Callable[[Path], None]:
    return lambda d: set_cell(d / name, row, column, value)


def _toml_syntax(d: Path) -> list[str]:
    line = replace_once(d / CONFIG, "rate_hz = 10.0", "rate_hz = = 10.0")
    return [f"line {line}"]


def _unsupported_extension(d: Path) -> None:
    (d / "S1.csv").rename(d / "S1.xlsx")
    replace_once(d / CONFIG, 'file = "S1.csv"', 'file = "S1.xlsx"')


def _ragged_row(d: Path) -> None:
    lines = (d / "R1.csv").read_text().splitlines(keepends=True)
    lines[20] = lines[20].rstrip("\n") + ",99\n"  # data row 20 gets an extra field
    (d / "R1.csv").write_text("".join(lines))


def _output_dir_is_a_file(d: Path) -> None:
    keep_sensors(d, FAST)
    replace_once(d / CONFIG, 'dir = "out"', 'dir = "truth.csv"')


def _output_dir_under_a_file(d: Path) -> None:
    keep_sensors(d, FAST)
    replace_once(d / CONFIG, 'dir = "out"', 'dir = "truth.csv/out"')


CASES: dict[str, Case] = {
    # --- sensor files ---
    "missing sensor file": Case(lambda d: (d / "S1.csv").unlink(), ("S1.csv", "not found")),
    "missing required column": Case(lambda d: drop_column(d / "R1.csv", "elevation"),
                                    ("R1.csv", "'elevation'")),
    "text in a numeric column": Case(_cell("R1.csv", 17, "range", "abc"),
                                     ("R1.csv", "row 17", "'range'", "'abc'")),
    "inf value": Case(_cell("G1.csv", 5, "height", "inf"), ("G1.csv", "row 5", "'height'")),
    "nan text": Case(_cell("S1.csv", 9, "azimuth", "nan"), ("S1.csv", "row 9", "'azimuth'")),
    "-inf time": Case(_cell("MISTRAM.csv", 3, "time", "-inf"),
                      ("MISTRAM.csv", "row 3", "'time'")),
    "station not in config": Case(_cell("MISTRAM.csv", 6, "station", "M9"),
                                  ("MISTRAM.csv", "row 6", "'station'", "M9")),
    "ISO time without offset in one row": Case(
        lambda d: iso_times(d / "G1.csv", naive_rows={7}),
        ("G1.csv", "row 7", "'time'", "offset")),
    "ISO times without offset": Case(lambda d: iso_times(d / "G1.csv"),
                                     ("G1.csv", "row 1", "'time'", "offset")),
    "ISO time among numeric times": Case(_cell("G1.csv", 8, "time", "2024-05-01T10:00:00Z"),
                                         ("G1.csv", "row 8", "'time'")),
    "empty time cell": Case(_cell("G1.csv", 4, "time", ""), ("G1.csv", "row 4", "'time'")),
    "latitude out of range": Case(_cell("G1.csv", 2, "lat", "-126.9"),
                                  ("G1.csv", "row 2", "'lat'")),
    "ragged CSV row": Case(_ragged_row, ("R1.csv", "row 20")),
    "empty sensor file": Case(lambda d: (d / "S1.csv").write_text(""), ("S1.csv", "empty")),
    "header only": Case(lambda d: (d / "S1.csv").write_text("time,range,azimuth,elevation\n"),
                        ("S1.csv", "no data rows")),
    "unsupported file extension": Case(_unsupported_extension, ("S1.xlsx",)),
    "parquet text in a numeric column": Case(
        lambda d: rewrite_parquet(d / "TH1.parquet", "azimuth", parquet_text_with(11, "abc")),
        ("TH1.parquet", "row 11", "'azimuth'", "'abc'")),
    "parquet inf value": Case(
        lambda d: rewrite_parquet(d / "TH1.parquet", "range", parquet_float_with(4, np.inf)),
        ("TH1.parquet", "row 4", "'range'")),
    "parquet missing column": Case(
        lambda d: pq.write_table(pq.read_table(d / "TH1.parquet").drop_columns(["elevation"]),
                                 d / "TH1.parquet"),
        ("TH1.parquet", "'elevation'")),
    "parquet naive timestamps": Case(
        lambda d: rewrite_parquet(d / "TH1.parquet", "time", lambda c: naive_timestamps(c)),
        ("TH1.parquet", "'time'", "time zone")),
    "not a parquet file": Case(lambda d: (d / "TH1.parquet").write_text("time,azimuth\n1,2\n"),
                               ("TH1.parquet",)),
    # --- config ---
    "config file missing": Case(lambda d: None, ("nope.toml", "not found"), config="nope.toml"),
    "TOML syntax error": Case(_toml_syntax, ("scenario.toml", "invalid TOML")),
    "unknown top-level key": Case(_cfg("[range]", "verbose = true\n\n[range]"),
                                  ("scenario.toml", "verbose", "unknown key")),
    "misspelt top-level table": Case(_cfg("[output]", "[ouput]"),
                                     ("scenario.toml", "ouput", "unknown key")),
    "unknown key in [output]": Case(_cfg("rate_hz", "rate_hertz"),
                                    ("scenario.toml", "output.rate_hertz")),
    "misspelt sigma key": Case(_cfg("sigma = { range = 7.36", "sigma = { rnage = 7.36"),
                               ("scenario.toml", "sensors[0].sigma.rnage")),
    "misspelt sensor key": Case(_cfg('angle_unit = "deg"', 'angel_unit = "deg"'),
                                ("scenario.toml", "sensors[0].angel_unit")),
    "misspelt station key": Case(_cfg('{ id = "M1", lat', '{ id = "M1", lag'),
                                 ("scenario.toml", "sensors[5].stations[0].lag")),
    "unknown sensor kind": Case(_cfg('kind = "radar"', 'kind = "lidar"'),
                                ("scenario.toml", "sensors[0].kind", "lidar")),
    "unknown angle_unit": Case(_cfg('angle_unit = "deg"', 'angle_unit = "grad"'),
                               ("scenario.toml", "sensors[0].angle_unit", "grad")),
    "platform names no sensor": Case(_cfg('platform = "SHIP_INS"', 'platform = "BOAT_INS"'),
                                     ("scenario.toml", "sensors[2].platform", "BOAT_INS")),
    "platform names a non-ins sensor": Case(_cfg('platform = "SHIP_INS"', 'platform = "R1"'),
                                            ("scenario.toml", "sensors[2].platform", "R1")),
    "duplicate sensor id": Case(_cfg('id = "TH1"', 'id = "R1"'),
                                ("scenario.toml", "sensors[1].id", "R1")),
    "negative sigma": Case(_cfg("sigma = { range = 7.36", "sigma = { range = -7.36"),
                           ("scenario.toml", "sensors[0].sigma.range")),
    "missing [range]": Case(_cfg("[range]\norigin", "#[range]\n#origin"),
                            ("scenario.toml", "range", "missing required key")),
    "misspelt [range]": Case(_cfg("[range]\norigin", "[rangex]\norigin"),
                             ("scenario.toml", "rangex")),
    "text where a number is expected": Case(_cfg("rate_hz = 10.0", 'rate_hz = "10"'),
                                            ("scenario.toml", "output.rate_hz")),
    "output dir is a file": Case(_output_dir_is_a_file, ("scenario.toml", "output.dir")),
    "output dir under a file": Case(_output_dir_under_a_file, ("scenario.toml", "output.dir")),
}


def naive_timestamps(col: pa.ChunkedArray) -> pa.Array:
    """Float seconds -> timestamps without a time zone."""
    us = np.round(col.to_numpy() * 1e6).astype("int64")
    return pa.array(us.astype("datetime64[us]"), pa.timestamp("us"))


@pytest.mark.parametrize("case", list(CASES.values()), ids=list(CASES))
def test_unusable_input_is_exit_2_with_one_line(cli, explain, scenario, case):
    extra = case.mutate(scenario)
    extra = extra if isinstance(extra, list) else []  # other return values mean nothing
    before = listing(scenario)
    result = cli(["run", scenario / case.config])
    assert_one_error_line(result, explain, 2, *case.needles, *extra)
    # no file written anywhere: no outputs, no temp files
    assert listing(scenario) == before


def test_long_bad_cell_is_quoted_briefly(cli, scenario):
    """Messages stay short enough to read on one terminal line (no dumped file contents)."""
    set_cell(scenario / "R1.csv", 17, "range", "x" * 5000)
    result = cli(["run", scenario / CONFIG])
    assert result.exit_code == 2
    assert len(result.stderr.splitlines()) == 1
    assert len(result.stderr) < 400, result.stderr


# --------------------------------------------------------------------------------------------
# other exit statuses: errors raised from inside the pipeline
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("exc, code, needles", [
    (NumericalError("T1: covariance not positive definite at t=12.3 s"), 3,
     ("covariance not positive definite",)),
    (RuntimeError("boom"), 1, ("internal error", "RuntimeError", "boom", "--debug")),
    (ZeroDivisionError("float division by zero"), 1, ("ZeroDivisionError",)),
    (DataError("G1.csv: row 3,\ncolumn 'lat': bad\n"), 2, ("G1.csv: row 3, column 'lat'",)),
    (RangeprocError("something else"), 1, ("something else",)),
    (KeyboardInterrupt(), 130, ("interrupted",)),
], ids=["numerical", "runtime", "zerodivision", "multiline-data", "base", "interrupt"])
def test_errors_inside_the_pipeline(cli, explain, scenario, monkeypatch, exc, code, needles):
    keep_sensors(scenario, FAST)

    def fail(*args, **kwargs):
        raise exc

    monkeypatch.setattr(rangeproc.stages.fuse, "fuse_target", fail)
    before = listing(scenario)
    result = cli(["run", scenario / CONFIG])
    assert_one_error_line(result, explain, code, *needles)
    assert listing(scenario) == before


DEBUG_SCRIPT = textwrap.dedent("""
    import sys
    import rangeproc.stages.fuse
    from rangeproc.cli import main

    def fail(*args, **kwargs):
        raise RuntimeError("boom from fuse_target")

    rangeproc.stages.fuse.fuse_target = fail
    main(sys.argv[1:], prog_name="rangeproc")
""")


@pytest.mark.parametrize("debug", [False, True], ids=["plain", "debug"])
def test_unexpected_error_traceback_only_with_debug(scenario, debug):
    """In a real process (logging set up by the CLI, not by pytest)."""
    keep_sensors(scenario, FAST)
    args = (["--debug"] if debug else []) + ["run", "--quiet", str(scenario / CONFIG)]
    proc = subprocess.run([sys.executable, "-c", DEBUG_SCRIPT, *args], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert proc.stdout == ""
    if debug:
        assert "Traceback" in proc.stderr
        assert "RuntimeError: boom from fuse_target" in proc.stderr
    else:
        assert proc.stderr.splitlines() == [
            "rangeproc: error: internal error: RuntimeError: boom from fuse_target (rerun with "
            "--debug for the traceback)"]
    assert listing(scenario / "out") == []


# --------------------------------------------------------------------------------------------
# atomic outputs
# --------------------------------------------------------------------------------------------

def assert_complete_fused(path: Path) -> None:
    table = pq.read_table(path)  # raises on a truncated file
    assert table.num_rows > 100
    assert {"target_id", "time", "e", "n", "u", "sigma_e", "n_sensors"} <= set(table.column_names)


def assert_complete_pngs(folder: Path) -> list[str]:
    names = []
    for png in sorted(folder.glob("*")):
        data = png.read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and data.endswith(b"IEND\xaeB`\x82"), \
            f"{png.name}: partial PNG left behind"
        names.append(png.name)
    return names


def test_report_failure_between_figures(cli, explain, scenario, monkeypatch):
    """A failure after fused.parquet and two figures were staged: nothing is published (the
    outputs of a run are moved into place only when all of them are complete)."""
    keep_sensors(scenario, FAST)
    real = rangeproc.report.figures.write_report

    def failing(report_dir, tracks, residuals, **kwargs):
        def progress(name: str) -> None:
            if "consistency" in name:
                raise RuntimeError("report failed")
        return real(report_dir, tracks, residuals, **{**kwargs, "progress": progress})

    monkeypatch.setattr(rangeproc.report.figures, "write_report", failing)
    result = cli(["run", scenario / CONFIG])
    assert_one_error_line(result, explain, 1, "report failed")
    out = scenario / "out"
    assert temp_files(out) == []
    assert listing(out) == []


def test_failed_rerun_leaves_previous_outputs_intact(cli, explain, scenario, monkeypatch):
    """A good run, then a rerun that fails in the report: the first run's outputs stay, whole
    and unmixed (same bytes), with no temp or staging files."""
    keep_sensors(scenario, FAST)
    assert cli(["run", scenario / CONFIG, "--quiet"]).exit_code == 0
    out = scenario / "out"
    before = {name: (out / name).read_bytes() for name in listing(out)}
    assert "fused.parquet" in before and "summary.json" in before

    def failing(*args, **kwargs):
        raise RuntimeError("report failed")

    monkeypatch.setattr(rangeproc.report.figures, "write_report", failing)
    result = cli(["run", scenario / CONFIG])
    assert_one_error_line(result, explain, 1, "report failed")
    assert temp_files(out) == []
    assert {name: (out / name).read_bytes() for name in listing(out)} == before


def test_report_failure_inside_a_png_write(cli, explain, scenario, monkeypatch):
    """savefig dies half way through the first PNG: no partial PNG, no temp file."""
    import matplotlib.figure

    keep_sensors(scenario, FAST)

    def half_write(self, fname, *args, **kwargs):
        target = fname if hasattr(fname, "write") else open(fname, "wb")
        target.write(b"\x89PNG\r\n\x1a\n" + b"\0" * 1000)
        target.flush()
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", half_write)
    result = cli(["run", scenario / CONFIG])
    out = scenario / "out"
    line = assert_one_error_line(result, explain, 5, "No space left on device")
    assert line.startswith(f"rangeproc: error: cannot write {out.resolve() / 'report'}/")
    assert line.endswith(".png: No space left on device"), line
    assert temp_files(out) == []
    assert listing(out) == []


def test_parquet_write_failure_leaves_no_fused_file(cli, explain, scenario, monkeypatch):
    """write_table dies after writing part of the file: no fused.parquet at all, no temp."""
    keep_sensors(scenario, FAST)

    def half_write(table, where, *args, **kwargs):
        Path(where).write_bytes(b"PAR1" + b"\0" * 4096)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pq, "write_table", half_write)
    result = cli(["run", scenario / CONFIG])
    out = scenario / "out"
    line = assert_one_error_line(result, explain, 5)
    assert line == (f"rangeproc: error: cannot write {out.resolve() / 'fused.parquet'}: "
                    "No space left on device")
    assert temp_files(out) == []
    assert listing(out) == []  # no fused.parquet, no summary.json, no figure


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EROFS, errno.EACCES])
def test_an_output_that_cannot_be_written_is_one_line_exit_5(cli, explain, scenario,
                                                             monkeypatch, code):
    """The OS refuses a write (pyarrow's own wording of a full disk, a read-only file
    system, no permission) on a rerun: one line naming the published path and the OS's
    cause, exit 5, the previous run's outputs untouched and nothing staged left."""
    keep_sensors(scenario, FAST)
    assert cli(["run", scenario / CONFIG, "--quiet"]).exit_code == 0
    out = scenario / "out"
    before = {name: (out / name).read_bytes() for name in listing(out)}

    def refused(table, where, *args, **kwargs):
        raise OSError(code, f"Error writing bytes to file. Detail: [errno {code}] "
                            f"{os.strerror(code)}")

    monkeypatch.setattr(pq, "write_table", refused)
    result = cli(["run", scenario / CONFIG])
    line = assert_one_error_line(result, explain, 5)
    assert line == (f"rangeproc: error: cannot write {out.resolve() / 'fused.parquet'}: "
                    f"{os.strerror(code)}")
    assert temp_files(out) == []
    assert {name: (out / name).read_bytes() for name in listing(out)} == before


def test_a_read_only_output_folder_is_one_line_exit_5(cli, explain, scenario, monkeypatch):
    """A pre-created output folder without write permission: refused before any processing
    with one line naming the folder, exit 5, nothing written. Root ignores permissions, so
    there the folder's check (``os.access``) is made to answer as for another user."""
    keep_sensors(scenario, FAST)
    out = scenario / "out"
    out.mkdir()
    out.chmod(0o555)
    try:
        if os.geteuid() == 0:
            real = os.access
            monkeypatch.setattr(os, "access", lambda path, mode, **kw: False if Path(
                path) == out.resolve() and mode & os.W_OK else real(path, mode, **kw))
        result = cli(["run", scenario / CONFIG])
    finally:
        out.chmod(0o755)
    line = assert_one_error_line(result, explain, 5)
    assert line == f"rangeproc: error: cannot write {out.resolve()}: Permission denied"
    assert listing(out) == [] and list(out.iterdir()) == []
