"""Writing the simulator's files: sensor logs and truth as CSV or Parquet, configs as text.

Every file goes through ``io.writers.atomic_path`` (a temporary file renamed into place).
Floats are rounded to a fixed number of decimals per column, far below every noise level, to
keep the files compact.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from rangeproc.io.writers import atomic_path

#: decimals written per column (keeps files compact; far below every noise level)
_DECIMALS = {"time": 6, "range": 4, "range_rate": 5, "lat": 10, "lon": 10, "height": 4,
             "ve": 5, "vn": 5, "vu": 5, "e": 6, "n": 6, "u": 6, "ae": 6, "an": 6, "au": 6,
             "roll": 8, "pitch": 8, "yaw": 8}
_ANGLE_DECIMALS = 10  # azimuth/elevation: 1e-10 deg/rad/mil


_TRUTH_DECIMALS = {"time": 6, "lat": 11, "lon": 11}  # others: 7 (0.1 um, 0.1 um/s)


def _table(cols: Mapping[str, np.ndarray | pa.Array], decimals: dict[str, int],
           default: int) -> pa.Table:
    arrays = {}
    for k, val in cols.items():
        if isinstance(val, pa.Array):  # typed with nulls, e.g. track_id with empty cells
            arrays[k] = val
        elif val.dtype.kind == "f":
            val = np.round(val, decimals.get(k, default))
            arrays[k] = pa.array(val, from_pandas=True)  # NaN -> null (empty cell)
        else:
            arrays[k] = pa.array(val)
    return pa.table(arrays)


def int_column(values: np.ndarray, present: np.ndarray) -> pa.Array:
    """(M,) integers as a column whose cells are empty where ``present`` (M,) bool is False
    (e.g. a ``track_id`` column holding plots), for :func:`atomic_write_table`."""
    return pa.array(np.asarray(values, dtype=np.int64), mask=~np.asarray(present, dtype=bool),
                    type=pa.int64())


def text_column(values: list[str | None]) -> pa.Array:
    """Strings as a column whose ``None`` cells are empty, for :func:`atomic_write_table`."""
    return pa.array(values, type=pa.string())


def atomic_write_table(path: Path, cols: Mapping[str, np.ndarray | pa.Array], *,
                       truth: bool = False) -> None:
    """Write columns as CSV (plain header, empty cell = missing) or Parquet (by extension),
    via a temporary file renamed into place. Floats are rounded (``truth``: finer); a
    ``pa.Array`` column is written as it is (its nulls as empty cells)."""
    if truth:
        table = _table(cols, _TRUTH_DECIMALS, 7)
    else:
        table = _table(cols, _DECIMALS, _ANGLE_DECIMALS)
    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            pq.write_table(table, tmp)
        else:
            with open(tmp, "wb") as f:
                f.write((",".join(table.column_names) + "\n").encode())
                pacsv.write_csv(table, f, pacsv.WriteOptions(include_header=False,
                                                             quoting_style="none"))


def atomic_write_text(path: Path, text: str) -> None:
    """Write text via a temporary file renamed into place."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
