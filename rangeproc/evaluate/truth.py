"""Truth trajectory for ``rangeproc evaluate``: read, check, and express in the range frame.

Format (:data:`TRUTH_FORMAT`): CSV with a header row or Parquet, chosen by the extension as for
sensor files (``.csv``/``.txt``, ``.parquet``/``.pq``); other columns are ignored.

- ``time``: float seconds on the fused output's time scale, or ISO-8601 text with ``Z`` or a
  UTC offset (read as Unix seconds, as in the sensor files); one form per column. Parquet may
  also hold UTC-aware timestamps.
- position: ``e, n, u`` (range ENU, m) or ``lat, lon, height`` (WGS-84 degrees, metres above
  the ellipsoid; converted with the range origin); with both, ``e, n, u`` is used.
- velocity, optional: ``ve, vn, vu`` (m/s), all three or none. With ``e, n, u`` they are range
  ENU; with ``lat, lon, height`` local ENU at the truth point (as a GPS/INS writes them) and
  are rotated into the range frame. Without them velocity is not evaluated.
- ``target_id``, optional: without it the file is one object.

Every cell of a column that is read must be filled; fully blank rows are skipped. Problems raise
:class:`~rangeproc.errors.DataError` as the sensor readers do: one line naming the file, the
1-based data row (first record after the header = row 1) and the column.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from rangeproc.config import Geodetic
from rangeproc.errors import DataError
from rangeproc.evaluate.origin import ORIGIN_FORM, Origin, run_origin
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.io.readers import cell_error, read_csv_table, read_parquet_table, read_time
from rangeproc.io.timeparse import CellError, clean_strings, to_float
from rangeproc.timescale import on_unix_scale

log = logging.getLogger(__name__)

ENU = ("e", "n", "u")
GEODETIC = ("lat", "lon", "height")
VELOCITY = ("ve", "vn", "vu")
TRUTH_FORMAT = ("time (float s or ISO-8601 with Z/offset); e, n, u (range ENU m) or lat, lon, "
                "height (WGS-84 deg, m); optional ve, vn, vu (m/s); optional target_id")
_SUFFIXES = (".csv", ".txt", ".parquet", ".pq")
_WANTED = {"time": True, "target_id": False, **dict.fromkeys(ENU + GEODETIC + VELOCITY, False)}


@dataclass(frozen=True, kw_only=True, slots=True)
class TruthTable:
    """A truth file as written, S rows (blank rows dropped), sorted by (target_id, time).

    form: "enu" or "geodetic"; time: (S,) s; target_id: (S,) str or None (no such column);
    position: (S, 3) e, n, u m (enu) or lat deg, lon deg, height m (geodetic); velocity:
    (S, 3) m/s (range ENU or local ENU, as the form) or None; row: (S,) 1-based data rows.
    """

    path: Path
    form: str
    time: np.ndarray
    target_id: np.ndarray | None
    position: np.ndarray
    velocity: np.ndarray | None
    row: np.ndarray


@dataclass(frozen=True, kw_only=True, slots=True)
class Truth:
    """Truth in the range frame: time (S,) s, target_id (S,) str (None: one unnamed object),
    pos (S, 3) range ENU m, vel (S, 3) range ENU m/s or None; ``form`` as written and the
    ``origin`` used for a geodetic truth."""

    path: Path
    form: str
    time: np.ndarray
    target_id: np.ndarray | None
    pos: np.ndarray
    vel: np.ndarray | None
    origin: Origin | None = None

    def describe(self) -> dict[str, object]:
        """JSON-ready account of the format (for evaluation.json)."""
        org = self.origin.origin if self.origin is not None else None
        return {"position": "lat, lon, height" if self.form == "geodetic" else "e, n, u",
                "velocity": self.vel is not None, "target_id": self.target_id is not None,
                "origin": None if org is None else [org.lat, org.lon, org.height],
                "origin_source": self.origin.source if org is not None else None,
                "time_span": [float(self.time.min()), float(self.time.max())]}


# ---------------------------------------------------------------------------------- reading

def read_truth(path: Path) -> TruthTable:
    """Read and check a truth file (module docstring); DataError naming file, row and column."""
    path = Path(path)
    table = _read_table(path)
    name = path.name
    rows = np.arange(1, table.num_rows + 1, dtype=np.int64)
    table, rows = _drop_blank(table, rows)
    if table.num_rows == 0:
        raise DataError(f"{name}: no data rows (need {TRUTH_FORMAT})")
    form, pos_cols = _position_form(name, table.column_names)
    vel_cols = _velocity_columns(name, table.column_names)

    def fail(column: str, exc: CellError) -> DataError:
        return cell_error(name, rows, column, exc)

    time = read_time(table, rows, name)
    values = {}
    for col in pos_cols + vel_cols:
        try:
            values[col] = _filled_numbers(table.column(col))
        except CellError as exc:
            raise fail(col, exc) from None
    ids = None
    if "target_id" in table.column_names:
        try:
            ids = _filled_text(table.column("target_id"))
        except CellError as exc:
            raise fail("target_id", exc) from None
    if form == "geodetic":
        _check_geodetic(name, values, rows)
    pos = np.column_stack([values[c] for c in pos_cols])
    vel = np.column_stack([values[c] for c in vel_cols]) if vel_cols else None
    order = np.lexsort((time, ids)) if ids is not None else np.argsort(time, kind="stable")
    truth = TruthTable(path=path, form=form, time=time[order],
                       target_id=None if ids is None else ids[order], position=pos[order],
                       velocity=None if vel is None else vel[order], row=rows[order])
    _check_unique_times(name, truth)
    return truth


def _read_table(path: Path) -> pa.Table:
    name = path.name
    if path.suffix.lower() not in _SUFFIXES:
        raise DataError(f"{name}: unsupported file extension '{path.suffix}' (expected one of: "
                        f"{', '.join(_SUFFIXES)})")
    if not path.is_file():
        raise DataError(f"{name}: file not found ({path})")
    if path.stat().st_size == 0:
        raise DataError(f"{name}: file is empty (need {TRUTH_FORMAT})")
    try:
        if path.suffix.lower() in (".csv", ".txt"):
            return read_csv_table(path, _WANTED, {"target_id"})
        return read_parquet_table(path, _WANTED)
    except OSError as exc:
        raise DataError(f"{name}: cannot read file ({exc.strerror or exc})") from None


def _drop_blank(table: pa.Table, rows: np.ndarray) -> tuple[pa.Table, np.ndarray]:
    """Drop rows in which every read cell is empty (spreadsheet exports); keep row numbers."""
    blank = np.ones(table.num_rows, dtype=bool)
    for col in table.column_names:
        blank &= pc.is_null(table.column(col)).to_numpy(zero_copy_only=False)
    if not blank.any():
        return table, rows
    return table.filter(pa.array(~blank)), rows[~blank]


def _position_form(name: str, columns: list[str]) -> tuple[str, tuple[str, ...]]:
    """("enu", ENU) or ("geodetic", GEODETIC); DataError naming the first missing column."""
    for form, cols in (("enu", ENU), ("geodetic", GEODETIC)):
        if all(c in columns for c in cols):
            return form, cols
    for cols in (ENU, GEODETIC):
        if any(c in columns for c in cols):
            missing = next(c for c in cols if c not in columns)
            raise DataError(f"{name}: missing column '{missing}' (position: e, n, u in range "
                            "ENU m, or lat, lon, height in WGS-84 degrees and metres)")
    raise DataError(f"{name}: no position columns (need e, n, u in range ENU m, or lat, lon, "
                    "height in WGS-84 degrees and metres)")


def _velocity_columns(name: str, columns: list[str]) -> tuple[str, ...]:
    """VELOCITY when all three are there, () when none; DataError for some but not all."""
    have = [c for c in VELOCITY if c in columns]
    if have and len(have) < len(VELOCITY):
        missing = next(c for c in VELOCITY if c not in columns)
        raise DataError(f"{name}: missing column '{missing}' (velocity: give ve, vn, vu or "
                        "none of them)")
    return VELOCITY if have else ()


def _filled_numbers(col: pa.ChunkedArray) -> np.ndarray:
    """(S,) float64; CellError at the first text, non-finite or empty cell."""
    out = to_float(col)
    if out.null_count:
        raise CellError(int(pc.index(pc.is_null(out), True).as_py()),
                        "empty (every truth row needs a value here)")
    return out.to_numpy(zero_copy_only=False)


def _filled_text(col: pa.ChunkedArray) -> np.ndarray:
    """(S,) str target ids; CellError at the first empty cell."""
    s = clean_strings(col)
    if s.null_count:
        raise CellError(int(pc.index(pc.is_null(s), True).as_py()), "empty (target id)")
    return s.to_numpy(zero_copy_only=False).astype(str)


def _check_geodetic(name: str, values: dict[str, np.ndarray], rows: np.ndarray) -> None:
    """Latitude in [-90, 90], longitude in [-180, 360) degrees (as in the config)."""
    for col, bad in (("lat", np.abs(values["lat"]) > 90.0),
                     ("lon", (values["lon"] < -180.0) | (values["lon"] >= 360.0))):
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"{name}: row {rows[i]}, column '{col}': {values[col][i]:g} is "
                            "outside " + ("[-90, 90]" if col == "lat" else "[-180, 360)")
                            + " degrees")


def _check_unique_times(name: str, truth: TruthTable) -> None:
    """Two rows of one object at one time are ambiguous truth: DataError naming both rows."""
    same = truth.time[1:] == truth.time[:-1]
    if truth.target_id is not None:
        same &= truth.target_id[1:] == truth.target_id[:-1]
    if same.any():
        i = int(np.argmax(same))
        a, b = sorted((int(truth.row[i]), int(truth.row[i + 1])))
        who = "" if truth.target_id is None else f" of target {truth.target_id[i]}"
        raise DataError(f"{name}: row {b}, column 'time': same time as row {a}{who} "
                        f"({float(truth.time[i])!r} s)")


# ------------------------------------------------------------------------------ range frame

def to_range_frame(table: TruthTable, origin: Origin | None) -> Truth:
    """The truth in range ENU. A geodetic truth needs ``origin.origin``: DataError otherwise,
    saying where the origin was looked for and how to give it (``--origin``)."""
    if table.form == "enu":
        return Truth(path=table.path, form="enu", time=table.time, target_id=table.target_id,
                     pos=table.position, vel=table.velocity)
    if origin is None or origin.origin is None:
        why = f": {origin.missing}" if origin is not None and origin.missing else ""
        raise DataError(f"{table.path.name}: position is lat, lon, height and needs the range "
                        f"origin{why}; give --origin {ORIGIN_FORM}")
    pos, vel = geodetic_to_range(origin.origin, table.position, table.velocity)
    return Truth(path=table.path, form="geodetic", time=table.time, target_id=table.target_id,
                 pos=pos, vel=vel, origin=origin)


def geodetic_to_range(origin: Geodetic, llh: np.ndarray, vel_local: np.ndarray | None
                      ) -> tuple[np.ndarray, np.ndarray | None]:
    """llh (S, 3) lat deg, lon deg, height m -> (S, 3) range ENU m; vel_local (S, 3) local ENU
    m/s at each point -> (S, 3) range ENU m/s (None stays None)."""
    frame = RangeFrame(origin)
    lat, lon, h = llh[:, 0], llh[:, 1], llh[:, 2]
    pos = frame.to_enu(lat, lon, h)
    if vel_local is None:
        return pos, None
    rot = frame.local_rotation(lat, lon)               # range ENU -> local ENU, (S, 3, 3)
    return pos, np.einsum("sji,sj->si", rot, vel_local)


# ---------------------------------------------------------------------------------- checks

def check_overlap(fused_time: np.ndarray, truth: Truth, fused_name: str) -> None:
    """DataError naming both spans when no fused epoch (fused_time (R,) s) lies within the
    truth's time span: the two are on different time scales, or from different flights."""
    t0, t1 = float(truth.time.min()), float(truth.time.max())
    if np.any((fused_time >= t0) & (fused_time <= t1)):
        return
    f0, f1 = float(np.min(fused_time)), float(np.max(fused_time))
    raise DataError(f"{truth.path.name}: no fused epoch within the truth's time span: truth "
                    f"{span_text(t0, t1)}, {fused_name} {span_text(f0, f1)}; are both on one "
                    "time scale (ISO-8601 times are read as Unix seconds)?")


def span_text(t0: float, t1: float) -> str:
    """``"t0 .. t1 s"``, with the UTC instants when the times are on the Unix scale
    (``rangeproc.timescale``, the rule every output follows)."""
    text = f"{t0:.3f} .. {t1:.3f} s"
    if on_unix_scale(t0, t1):
        text += f" ({_utc(t0)} .. {_utc(t1)})"
    return text


def _utc(t: float) -> str:
    return datetime.fromtimestamp(t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def load_truth(path: Path, out_dir: Path, origin: Geodetic | None = None) -> Truth:
    """:func:`read_truth` then :func:`to_range_frame`, the origin of a geodetic truth from
    ``origin`` (``--origin``) or the run in ``out_dir`` (:func:`run_origin`). Warns when
    velocity is not evaluated, or when ``origin`` is given for a truth that needs none."""
    table = read_truth(path)
    if table.velocity is None:
        log.warning("%s: no ve, vn, vu columns: velocity not evaluated", table.path.name)
    if table.form == "enu":
        if origin is not None:
            log.warning("%s: position is e, n, u (range ENU): --origin not used",
                        table.path.name)
        return to_range_frame(table, None)
    return to_range_frame(table, run_origin(out_dir, origin))
