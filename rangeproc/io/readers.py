"""Sensor-file readers: CSV or Parquet (data contract section 2) -> :class:`SensorLog`.

The format is chosen by the file extension (``.csv``/``.txt`` CSV with a header row;
``.parquet``/``.pq`` Parquet). Only the contract's columns are loaded (others are never
parsed); header names must match exactly, apart from surrounding whitespace.

CSV dialect: the column separator (comma, semicolon or tab) and decimal mark are sniffed
(``io.dialect``); a dialect other than the contract's is said once, as a note.

CSV fast path: pyarrow.csv with explicit float64 types for every numeric column (including
``time``); only when that fails are the columns re-read as text and converted here, which
locates the first offending cell (and accepts ISO-8601 times and whitespace-only cells).

Row numbers are 1-based data-record numbers: the first record after the header is row 1 (for
CSV this is the line number minus 1, blank lines aside; for Parquet the row index + 1).

Every problem raises :class:`~rangeproc.errors.DataError` with one line naming the file and the
row/column, e.g. ``R1.csv: row 17, column 'range': 'abc' is not a number``.
"""
from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from rangeproc.config import ANGLE_COMPONENTS, ANGLE_TO_RADIANS, SensorSettings
from rangeproc.errors import DataError
from rangeproc.io.dialect import SEPARATORS, sniff_dialect
from rangeproc.io.logs import SensorLog
from rangeproc.io.timeparse import CellError, clean_strings, time_to_seconds, to_float
from rangeproc.run_warnings import NOTE

log = logging.getLogger(__name__)

#: kind -> (required numeric columns, optional numeric columns), contract order (no ``time``).
NUMERIC_COLUMNS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = MappingProxyType({
    "radar": (("range", "azimuth", "elevation"), ("range_rate",)),
    "theodolite": (("azimuth", "elevation"), ("range",)),
    "gps": (("lat", "lon", "height"), ("ve", "vn", "vu")),
    "mistram": (("range_rate",), ()),
    "ins": (("roll", "pitch", "yaw", "lat", "lon", "height"), ("ve", "vn", "vu")),
})
#: kind -> (required text columns, optional text columns); always read as strings.
TEXT_COLUMNS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = MappingProxyType({
    "radar": ((), ("track_id",)),
    "theodolite": ((), ("track_id",)),
    "gps": ((), ()),
    "mistram": (("station",), ()),
    "ins": ((), ()),
})
_INS_REQUIRED = ("roll", "pitch", "yaw", "lat", "lon", "height")
_CSV_SUFFIXES = (".csv", ".txt")
_PARQUET_SUFFIXES = (".parquet", ".pq")


def read_sensor(settings: SensorSettings) -> SensorLog:
    """Read one sensor's file into a :class:`SensorLog` (SI units, radians, sorted by time).

    Angles are converted from ``settings.angle_unit`` to radians, ``settings.time_offset`` is
    added to the time, rows are stable-sorted by time. Rows in which every measurement
    component is empty are dropped (``n_read`` still counts them); so are fully blank rows
    (every loaded cell empty, time included). INS rows missing any attitude or position
    component are dropped with a warning. ``track_id``: when every cell is an integer the
    values are kept, otherwise labels are numbered 0, 1, ... in order of first appearance; an
    empty ``track_id`` cell becomes -1. All returned arrays are read-only.

    Raises:
        DataError: missing/unreadable/empty file, unsupported extension, missing column, text
            in a numeric column, non-finite value, empty time, ISO time without UTC offset,
            unknown or empty MISTRAM station, latitude/longitude out of range.
    """
    path = Path(settings.file)
    name = path.name
    suffix = path.suffix.lower()
    if suffix not in _CSV_SUFFIXES + _PARQUET_SUFFIXES:
        raise DataError(f"{name}: unsupported file extension '{path.suffix}' (expected one of: "
                        f"{', '.join(_CSV_SUFFIXES + _PARQUET_SUFFIXES)})")
    if not path.exists():
        raise DataError(f"{name}: file not found ({path})")
    if not path.is_file():
        raise DataError(f"{name}: not a regular file ({path})")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise DataError(f"{name}: cannot read file ({exc.strerror or exc})") from None
    if size == 0:
        raise DataError(f"{name}: file is empty")

    num_req, num_opt = NUMERIC_COLUMNS[settings.kind]
    txt_req, txt_opt = TEXT_COLUMNS[settings.kind]
    wanted = {"time": True, **dict.fromkeys(num_req + txt_req, True),
              **dict.fromkeys(num_opt + txt_opt, False)}
    text = set(txt_req + txt_opt)
    try:
        if suffix in _CSV_SUFFIXES:
            table = read_csv_table(path, wanted, text)
        else:
            table = read_parquet_table(path, wanted)
    except OSError as exc:
        raise DataError(f"{name}: cannot read file ({exc.strerror or exc})") from None
    if table.num_rows == 0:
        raise DataError(f"{name}: no data rows")
    return _assemble(settings, table)


# --------------------------------------------------------------------------------------------
# Columns present
# --------------------------------------------------------------------------------------------

def _select(name: str, header: list[str], wanted: Mapping[str, bool]) -> dict[str, int]:
    """Contract column name -> position in the header (whitespace-stripped names)."""
    found: dict[str, int] = {}
    for i, raw in enumerate(header):
        key = raw.strip()
        if key in wanted:
            if key in found:
                raise DataError(f"{name}: duplicate column '{key}' (header positions "
                                f"{found[key] + 1} and {i + 1})")
            found[key] = i
    for key, required in wanted.items():
        if required and key not in found:
            raise DataError(f"{name}: missing required column '{key}'")
    return found


# --------------------------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------------------------

def cell_error(name: str, rows: np.ndarray, column: str, exc: CellError) -> DataError:
    """The one-line DataError of a bad cell: file ``name``, the 1-based data row (``rows``
    maps table positions to file rows) and the column."""
    where = "" if exc.index is None else f"row {rows[exc.index]}, "
    return DataError(f"{name}: {where}column '{column}': {exc.problem}")


def read_time(table: pa.Table, rows: np.ndarray, name: str) -> np.ndarray:
    """The ``time`` column in seconds (float or ISO-8601, ``io.timeparse``); a bad cell is a
    :func:`cell_error`."""
    try:
        return time_to_seconds(table.column("time"))
    except CellError as exc:
        raise cell_error(name, rows, "time", exc) from None


def read_csv_table(path: Path, wanted: Mapping[str, bool], text: set[str]) -> pa.Table:
    """The ``wanted`` columns (name -> required) of CSV file ``path`` as an Arrow table, the
    ``text`` ones as strings and the rest as float64 where they parse (else as text, for the
    caller's cell checks); DataError for a missing required column.

    The column separator and decimal mark are sniffed (``io.dialect``): a semicolon- or
    tab-separated file, with decimal points or commas, is read as written and said once (a
    note); one whose dialect is ambiguous is refused naming the separator."""
    dialect, header = sniff_dialect(path, wanted, text)
    try:
        found = _select(path.name, header, wanted)
    except DataError as exc:
        if dialect.separator == ",":
            raise
        shown = ", ".join(h.strip() for h in header)
        raise DataError(f"{exc} (header read as {SEPARATORS[dialect.separator]}-separated: "
                        f"{shown})") from None
    if not dialect.is_contract:
        log.log(NOTE, "%s: read as %s (the contract's CSV: commas between columns, decimal "
                "points)", path.name, dialect.describe())
    position = {i: key for key, i in found.items()}
    names = [position.get(i, f"__ignored_{i}") for i in range(len(header))]
    read = pacsv.ReadOptions(column_names=names, skip_rows=1)
    parse = pacsv.ParseOptions(delimiter=dialect.separator)
    convert = dict(include_columns=list(found), null_values=[""], strings_can_be_null=True,
                   decimal_point=dialect.decimal)
    # 1) every numeric column float64 (the usual case); 2) time as text (ISO-8601 times);
    # 3) everything as text: conversion in timeparse locates the first bad cell.
    attempts = (
        {k: (pa.string() if k in text else pa.float64()) for k in found},
        {k: (pa.string() if k in text or k == "time" else pa.float64()) for k in found},
        {k: pa.string() for k in found},
    )
    for types in attempts:
        try:
            table = pacsv.read_csv(path, read_options=read, parse_options=parse,
                                   convert_options=pacsv.ConvertOptions(column_types=types,
                                                                        **convert))
        except pa.ArrowInvalid as exc:
            last = exc
            continue
        return _decimal_points(table, text) if dialect.decimal == "," else table
    raise _csv_parse_error(path, names, last, dialect.separator)


def _decimal_points(table: pa.Table, text: set[str]) -> pa.Table:
    """The numeric columns read as text (to locate a bad cell) with decimal commas made
    points, so that only a cell that is no number in the file's dialect is reported."""
    for i, name in enumerate(table.column_names):
        col = table.column(i)
        if name not in text and pa.types.is_string(col.type):
            table = table.set_column(i, name, pc.replace_substring(col, ",", "."))
    return table


def _csv_parse_error(path: Path, names: list[str], exc: pa.ArrowInvalid,
                     separator: str = ",") -> DataError:
    """Structural CSV problem: find its row with a single-threaded pass and an invalid-row hook."""
    bad: list[pacsv.InvalidRow] = []

    def hook(row: pacsv.InvalidRow) -> str:
        bad.append(row)
        return "error"

    try:
        pacsv.read_csv(path, read_options=pacsv.ReadOptions(column_names=names, skip_rows=1,
                                                            use_threads=False),
                       parse_options=pacsv.ParseOptions(delimiter=separator,
                                                        invalid_row_handler=hook),
                       convert_options=pacsv.ConvertOptions(
                           column_types={n: pa.string() for n in names}))
    except pa.ArrowInvalid:
        pass
    if bad:
        row = bad[0]
        where = f"row {row.number - 1}: " if row.number else ""
        sep = "" if separator == "," else f" (separated by {SEPARATORS[separator]}s)"
        return DataError(f"{path.name}: {where}expected {row.expected_columns} fields{sep}, "
                         f"got {row.actual_columns}")
    detail = " ".join(str(exc).split())
    return DataError(f"{path.name}: cannot parse CSV ({detail[:200]})")


# --------------------------------------------------------------------------------------------
# Parquet
# --------------------------------------------------------------------------------------------

def read_parquet_table(path: Path, wanted: Mapping[str, bool]) -> pa.Table:
    """The ``wanted`` columns (name -> required) of Parquet file ``path`` as an Arrow table;
    DataError for an unreadable file or a missing required column."""
    try:
        schema = pq.read_schema(path)
        found = _select(path.name, list(schema.names), wanted)
        table = pq.read_table(path, columns=[schema.names[i] for i in found.values()])
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
        detail = " ".join(str(exc).split())
        raise DataError(f"{path.name}: not a readable Parquet file ({detail[:200]})") from None
    return table.rename_columns(list(found))


# --------------------------------------------------------------------------------------------
# Table -> SensorLog
# --------------------------------------------------------------------------------------------

def _assemble(settings: SensorSettings, table: pa.Table) -> SensorLog:
    name = settings.file.name
    kind = settings.kind
    n_read = table.num_rows
    rows = np.arange(1, n_read + 1, dtype=np.int64)

    # Fully blank rows (e.g. ",,,," exported by spreadsheets) are dropped before any check.
    blank = _all_null(table, table.column_names)
    if blank is not None and pc.any(blank).as_py():
        keep = pc.invert(blank)
        table = table.filter(keep)
        rows = rows[keep.to_numpy(zero_copy_only=False)]

    def fail(column: str, exc: CellError) -> DataError:
        return cell_error(name, rows, column, exc)

    time = read_time(table, rows, name)

    num_req, num_opt = NUMERIC_COLUMNS[kind]
    factor = ANGLE_TO_RADIANS[settings.angle_unit]
    columns: dict[str, np.ndarray] = {}
    for col in num_req + num_opt:
        if col not in table.column_names:
            columns[col] = np.full(table.num_rows, np.nan)
            continue
        try:
            values = to_float(table.column(col)).to_numpy(zero_copy_only=False)
        except CellError as exc:
            raise fail(col, exc) from None
        if col in ANGLE_COMPONENTS and factor != 1.0:
            values = values * factor
        columns[col] = values
    _check_geodetic(columns, rows, name)

    station = None
    if kind == "mistram":
        try:
            station = _station_index(table.column("station"), settings)
        except CellError as exc:
            raise fail("station", exc) from None
    track_id = _track_codes(table.column("track_id")) if "track_id" in table.column_names \
        else None

    keep = _measured(kind, columns, rows, name)
    if keep is not None:
        time, rows = time[keep], rows[keep]
        columns = {k: v[keep] for k, v in columns.items()}
        station = None if station is None else station[keep]
        track_id = None if track_id is None else track_id[keep]

    time = time + settings.time_offset
    if time.size and np.any(time[1:] < time[:-1]):
        order = np.argsort(time, kind="stable")
        time, rows = time[order], rows[order]
        columns = {k: v[order] for k, v in columns.items()}
        station = None if station is None else station[order]
        track_id = None if track_id is None else track_id[order]

    for arr in (time, rows, station, track_id, *columns.values()):
        if arr is not None:
            arr.flags.writeable = False  # the log is immutable; some arrays share Arrow memory
    log.info("%s: read %d rows, kept %d", name, n_read, time.size)
    return SensorLog(sensor_id=settings.id, kind=kind, time=time,
                     columns=MappingProxyType(columns), row=rows, track_id=track_id,
                     station=station, n_read=n_read)


def _all_null(table: pa.Table, names: list[str]) -> pa.Array | None:
    """Boolean array, True where every listed column is null; None if a column has no nulls."""
    mask = None
    for col in names:
        c = table.column(col)
        if c.null_count == 0:
            return None
        m = pc.is_null(c)
        mask = m if mask is None else pc.and_(mask, m)
    return None if mask is None else _flat_bool(mask)


def _flat_bool(mask: pa.Array | pa.ChunkedArray) -> pa.Array:
    return mask.combine_chunks() if isinstance(mask, pa.ChunkedArray) else mask


def _check_geodetic(columns: Mapping[str, np.ndarray], rows: np.ndarray, name: str) -> None:
    """Latitude in [-90, 90], longitude in [-180, 360) degrees (as in the config)."""
    for col, lo, hi, closed in (("lat", -90.0, 90.0, "]"), ("lon", -180.0, 360.0, ")")):
        if col not in columns:
            continue
        v = columns[col]
        bad = (v < lo) | ((v > hi) if closed == "]" else (v >= hi))  # NaN (empty) passes
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"{name}: row {rows[i]}, column '{col}': {v[i]:g} is outside "
                            f"[{lo:g}, {hi:g}{closed} degrees")


def _measured(kind: str, columns: Mapping[str, np.ndarray], rows: np.ndarray,
              name: str) -> np.ndarray | None:
    """Boolean keep-mask of rows with something measured, or None when every row is kept."""
    if kind == "ins":
        keep = np.ones(rows.size, dtype=bool)
        for col in _INS_REQUIRED:
            keep &= ~np.isnan(columns[col])
        n_drop = int(rows.size - keep.sum())
        if n_drop:
            log.warning("%s: dropped %d rows with an empty attitude or position cell "
                        "(first: row %d)", name, n_drop, rows[np.argmin(keep)])
    else:
        keep = np.zeros(rows.size, dtype=bool)
        for values in columns.values():
            keep |= ~np.isnan(values)
        n_drop = int(rows.size - keep.sum())
        if n_drop:
            log.info("%s: dropped %d rows with nothing measured", name, n_drop)
    return keep if n_drop else None


def _station_index(col: pa.ChunkedArray, settings: SensorSettings) -> np.ndarray:
    """MISTRAM station ids -> (N,) int64 index into ``settings.stations``."""
    s = clean_strings(col)
    if s.null_count:
        i = int(pc.index(pc.is_null(s), True).as_py())
        raise CellError(i, "empty (station id is required)")
    ids = [st.id for st in settings.stations]
    idx = pc.index_in(s, value_set=pa.array(ids, pa.string()))
    if idx.null_count:
        i = int(pc.index(pc.is_null(idx), True).as_py())
        raise CellError(i, f"station '{s[i].as_py()}' not in config (known: {', '.join(ids)})")
    return idx.to_numpy(zero_copy_only=False).astype(np.int64)


def _track_codes(col: pa.ChunkedArray) -> np.ndarray:
    """track_id -> (N,) int64: integer labels kept, other labels factorised, empty -> -1."""
    s = clean_strings(col)
    try:
        values = to_float(s).to_numpy(zero_copy_only=False)
    except CellError:
        values = None
    if values is not None:
        measured = ~np.isnan(values)
        if np.all(values[measured] == np.round(values[measured])) and \
                np.all(np.abs(values[measured]) < 2.0**53):
            out = np.full(values.shape, -1, dtype=np.int64)
            out[measured] = values[measured].astype(np.int64)
            return out
    if isinstance(s, pa.ChunkedArray):
        s = s.combine_chunks()  # one dictionary for the whole column
    codes = pc.dictionary_encode(s).indices
    return pc.fill_null(pc.cast(codes, pa.int64()), -1).to_numpy(zero_copy_only=False)
