"""Fuzz mutation operations on the tables of sensor files, and what every operation builds on.

:class:`Work` is a case folder while a mutation is applied (the parsed config and the current
file names), :class:`Tab` a sensor file in memory and :class:`Op` the base of every operation.
The operations here are stage 1 (see ``file_ops``): changes of cells, rows, columns and time
stamps. CSV cells are the original text; Parquet cells Python values (a text value in a numeric
Parquet column turns the column into strings).

Rows in descriptions are 1-based data rows (the first record after the header is row 1), as in
rangeproc's messages. File names in operations are the *base* names (``R1.csv``); the current
name (``R1.parquet`` after ``ToParquet``) is looked up when the operation is applied.
"""
from __future__ import annotations

import csv
import io
import math
import random
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import pyarrow as pa
import pyarrow.parquet as pq

from .base import CONFIG_NAME, BaseLayout
from .tomltext import as_float, dump_toml, fmt_float, iso_time, short

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


# ============================================================================================
# The case being built
# ============================================================================================

@dataclass
class Tab:
    """A sensor file in memory. ``rows`` may be ragged (CSV). CSV cells are the file's text;
    Parquet cells Python values, with ``types`` the original Arrow type per column name."""

    names: list[str]
    rows: list[list[Any]]
    parquet: bool
    types: dict[str, pa.DataType]

    def index(self, column: str) -> int | None:
        """Position of ``column`` in the header, or None when the file lacks it."""
        return self.names.index(column) if column in self.names else None


def _column_array(values: list[Any], t: pa.DataType | None) -> pa.Array:
    """Values -> Arrow array: the original type if they fit, else float64, else strings."""
    for candidate in (t, pa.float64()):
        try:
            return pa.array(values, type=candidate)
        except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError, OverflowError):
            continue
    return pa.array([None if v is None else v if isinstance(v, str) else repr(v)
                     for v in values], type=pa.string())


class Work:
    """A case folder while a mutation is applied: the parsed config and the current file names.

    ``names`` maps each base file name to its current name in the folder (they differ after
    ``ToParquet``). Internal to :func:`apply_mutation`.
    """

    def __init__(self, folder: Path, layout: BaseLayout) -> None:
        self.folder = folder
        self.layout = layout
        self.config: dict[str, Any] = tomllib.loads(layout.config_text)
        self.config_changed = False
        self.names = {f.name: f.name for f in layout.files}
        self.names[CONFIG_NAME] = CONFIG_NAME

    def path(self, base_name: str) -> Path:
        """Current path of a base file."""
        return self.folder / self.names.get(base_name, base_name)

    def is_parquet(self, base_name: str) -> bool:
        return self.path(base_name).suffix == ".parquet"

    def load(self, base_name: str) -> Tab:
        """Read a (so far well-formed) sensor file into a :class:`Tab`."""
        path = self.path(base_name)
        if path.suffix == ".parquet":
            table = pq.ParquetFile(path).read()   # (pq.read_table rejects duplicate names)
            cols = [table.column(i).to_pylist() for i in range(table.num_columns)]
            rows = [list(r) for r in zip(*cols)] if cols else []
            return Tab(list(table.column_names), rows, True,
                       {f.name: f.type for f in table.schema})
        text = path.read_bytes().decode("utf-8")
        records = list(csv.reader(io.StringIO(text, newline="")))
        return Tab(records[0] if records else [], records[1:], False, {})

    def save(self, base_name: str, tab: Tab) -> None:
        """Write a :class:`Tab` back in its format (CSV: '\\n' line ends, minimal quoting)."""
        path = self.path(base_name)
        if tab.parquet:
            arrays = [_column_array([r[j] if j < len(r) else None for r in tab.rows],
                                    tab.types.get(name)) for j, name in enumerate(tab.names)]
            pq.write_table(pa.Table.from_arrays(arrays, names=list(tab.names)), path)
            return
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(tab.names)
        writer.writerows(tab.rows)
        path.write_bytes(buf.getvalue().encode("utf-8"))

    def flush_config(self) -> None:
        """Write the config back if an operation changed it."""
        if self.config_changed:
            self.path(CONFIG_NAME).write_text(dump_toml(self.config), encoding="utf-8")
            self.config_changed = False

    def sensor_entry(self, base_name: str) -> dict[str, Any] | None:
        """The ``[[sensors]]`` table whose ``file`` is the base file (None if removed)."""
        for s in self.config.get("sensors", []):
            if isinstance(s, dict) and s.get("file") == base_name:
                return s
        return None


# ============================================================================================
# Operations
# ============================================================================================

@dataclass(frozen=True)
class Op:
    """One step of a mutation. ``stage`` orders the steps of combined mutations."""

    stage: ClassVar[int] = 1

    def apply(self, work: Work) -> None:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError


# ---- row selections ------------------------------------------------------------------------

@dataclass(frozen=True)
class Rows:
    """A selection of data rows: ('row', i) one 1-based row, ('all', 0), ('every', k) every
    k-th row from the first, ('first', n) the first n rows."""

    how: str
    n: int = 0

    def indices(self, count: int) -> list[int]:
        """0-based indices into a table of ``count`` rows (clamped)."""
        if count == 0:
            return []
        if self.how == "row":
            return [min(self.n, count) - 1]
        if self.how == "every":
            return list(range(0, count, self.n))
        if self.how == "first":
            return list(range(min(self.n, count)))
        return list(range(count))

    def describe(self) -> str:
        return {"row": f"row {self.n}", "all": "every row", "every": f"every {self.n}-th row",
                "first": f"the first {self.n} rows"}[self.how]


# ---- cell values -----------------------------------------------------------------------------

def _negate(cell: Any, parquet: bool) -> Any:
    x = as_float(cell)
    if parquet:
        return -x if x is not None else cell
    s = str(cell).strip()
    return s[1:] if s.startswith("-") else ("-" + s if s else s)


def _scaled(cell: Any, parquet: bool, factor: float) -> Any:
    x = as_float(cell)
    if x is None:
        return cell
    return x * factor if parquet else fmt_float(x * factor)


def _comma(cell: Any, parquet: bool) -> Any:
    s = cell if isinstance(cell, str) else fmt_float(cell) if isinstance(cell, float) else \
        str(cell)
    return s.replace(".", ",") if "." in s else s + ",5"


def _iso_cell(cell: Any, parquet: bool, variant: str) -> Any:
    x = as_float(cell)
    return cell if x is None or not math.isfinite(x) or abs(x) > 1e11 else iso_time(x, variant)


def cell_value(setter: str, arg: Any, cell: Any, parquet: bool) -> Any:
    """The new content of a cell: ``setter`` names the change (see ``CELL_SETTERS``), ``arg`` its
    drawn parameter, ``cell`` the current content (CSV text or Parquet value)."""
    if setter == "empty":
        return None if parquet else ""
    if setter == "text":
        return arg
    if setter == "number":
        return float(arg) if parquet else arg
    if setter == "negate":
        return _negate(cell, parquet)
    if setter == "times_1e6":
        return _scaled(cell, parquet, 1e6)
    if setter == "digits":
        return "1" * arg if arg > 0 else "0." + "0" * -arg + "1"
    if setter == "comma":
        return _comma(cell, parquet)
    if setter == "padded":
        return f" {cell} " if not parquet or isinstance(cell, str) else f" {fmt_float(cell)} "
    if setter == "iso":
        return _iso_cell(cell, parquet, arg)
    raise ValueError(setter)


def describe_setter(setter: str, arg: Any) -> str:
    """Short text for a cell change."""
    return {"empty": "empty", "negate": "negated", "times_1e6": "x 1e6",
            "comma": "with a comma decimal", "padded": "padded with spaces",
            "digits": f"a {abs(arg)}-digit string" if isinstance(arg, int) else "",
            "iso": f"ISO-8601 ({arg})"}.get(setter) or short(arg)


@dataclass(frozen=True)
class SetCell(Op):
    """One cell of a sensor file (``row`` 1-based data row, ``column`` header name)."""

    file: str
    row: int
    column: str
    setter: str
    arg: Any = None

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        if self.column not in tab.names or not tab.rows:
            return
        j = tab.names.index(self.column)
        row = tab.rows[min(self.row, len(tab.rows)) - 1]
        if j < len(row):
            row[j] = cell_value(self.setter, self.arg, row[j], tab.parquet)
            work.save(self.file, tab)

    def describe(self) -> str:
        return (f"{self.file} row {self.row} column '{self.column}' "
                f"= {describe_setter(self.setter, self.arg)}")


@dataclass(frozen=True)
class ColumnMap(Op):
    """Numeric change of one column over a row selection: ``action`` 'set' (to ``value``),
    'add' (``value``), 'mul' (by ``value``); text cells are left as they are."""

    file: str
    column: str
    rows: Rows
    action: str
    value: float

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        j = tab.index(self.column)
        if j is None:
            return
        for i in self.rows.indices(len(tab.rows)):
            row = tab.rows[i]
            if j >= len(row):
                continue
            x = as_float(row[j])
            if self.action == "set":
                new = self.value
            elif x is None:
                continue
            else:
                new = x + self.value if self.action == "add" else x * self.value
            row[j] = new if tab.parquet else fmt_float(new)
        work.save(self.file, tab)

    def describe(self) -> str:
        verb = {"set": "=", "add": "+=", "mul": "*="}[self.action]
        return f"{self.file} '{self.column}' {verb} {self.value:.6g} in {self.rows.describe()}"


@dataclass(frozen=True)
class CopyPrevious(Op):
    """Each selected row's ``column`` takes the previous row's value (duplicate stamps)."""

    file: str
    column: str
    rows: Rows

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        j = tab.index(self.column)
        if j is None:
            return
        for i in self.rows.indices(len(tab.rows)):
            if i > 0 and j < len(tab.rows[i]) and j < len(tab.rows[i - 1]):
                tab.rows[i][j] = tab.rows[i - 1][j]
        work.save(self.file, tab)

    def describe(self) -> str:
        return f"{self.file} '{self.column}' repeated from the row before in {self.rows.describe()}"


@dataclass(frozen=True)
class IsoTimes(Op):
    """Every ``time`` cell as ISO-8601 text (``variant`` as in :func:`iso_time`)."""

    file: str
    variant: str

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        if "time" not in tab.names:
            return
        j = tab.names.index("time")
        for row in tab.rows:
            if j < len(row):
                row[j] = _iso_cell(row[j], tab.parquet, self.variant)
        work.save(self.file, tab)

    def describe(self) -> str:
        return f"{self.file} every time as ISO-8601 ({self.variant})"


@dataclass(frozen=True)
class RowOp(Op):
    """A change of the data rows. ``action``: delete (row ``i``, ``n`` rows), delete_every
    (every ``n``-th), keep_first (``n`` rows), header_only, duplicate (row ``i``), double (every
    row twice), append_copy (all rows appended again), shuffle (seed ``n``), reverse,
    blank (a blank line before row ``i``; Parquet: an all-null row), ragged_more / ragged_less
    (row ``i`` with ``n`` fields more / fewer; CSV only), header_again (the header line again
    before row ``i``), no_header (header line removed; CSV only)."""

    file: str
    action: str
    i: int = 1
    n: int = 1

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        rows, k = tab.rows, max(0, min(self.i, len(tab.rows)) - 1)
        a = self.action
        if a == "delete":
            del rows[k:k + self.n]
        elif a == "delete_every":
            rows[:] = [r for m, r in enumerate(rows) if m % self.n != 0]
        elif a == "keep_first":
            del rows[self.n:]
        elif a == "header_only":
            rows.clear()
        elif a == "duplicate" and rows:
            rows.insert(k + 1, list(rows[k]))
        elif a == "double":
            rows[:] = [list(r) for r in rows for _ in range(2)]
        elif a == "append_copy":
            rows += [list(r) for r in rows]
        elif a == "shuffle":
            random.Random(self.n).shuffle(rows)
        elif a == "reverse":
            rows.reverse()
        elif a == "blank":
            rows.insert(k, [None] * len(tab.names) if tab.parquet else [])
        elif a == "ragged_more" and rows and not tab.parquet:
            rows[k] = rows[k] + ["1"] * self.n
        elif a == "ragged_less" and rows and not tab.parquet:
            rows[k] = rows[k][:max(0, len(rows[k]) - self.n)] or [""]
        elif a == "header_again":
            rows.insert(k, list(tab.names))
        elif a == "no_header" and not tab.parquet and rows:
            tab.names = rows.pop(0)
        work.save(self.file, tab)

    def describe(self) -> str:
        a, f, i, n = self.action, self.file, self.i, self.n
        return {
            "delete": f"{f} row {i} deleted" if n == 1 else f"{f} rows {i}..{i + n - 1} deleted",
            "delete_every": f"{f} every {n}-th row deleted",
            "keep_first": f"{f} only the first {n} rows kept",
            "header_only": f"{f} every data row deleted (header only)",
            "duplicate": f"{f} row {i} duplicated", "double": f"{f} every row twice",
            "append_copy": f"{f} all rows appended again (concatenated log)",
            "shuffle": f"{f} rows shuffled (seed {n})", "reverse": f"{f} rows reversed",
            "blank": f"{f} blank line before row {i}",
            "ragged_more": f"{f} row {i} with {n} extra fields",
            "ragged_less": f"{f} row {i} with {n} fields missing",
            "header_again": f"{f} header line repeated before row {i}",
            "no_header": f"{f} header line removed"}[a]


@dataclass(frozen=True)
class ColumnOp(Op):
    """A change of one column. ``action``: drop, rename (to ``arg``), duplicate, extra (a new
    column named ``arg[0]`` filled with ``arg[1]``), reorder (columns shuffled, seed ``arg``),
    fill (every cell of ``column`` = cell setter ``arg`` = (setter, value))."""

    file: str
    action: str
    column: str = ""
    arg: Any = None

    def apply(self, work: Work) -> None:
        tab = work.load(self.file)
        a = self.action
        if a == "extra":
            name, value = self.arg
            tab.names.append(name)
            for row in tab.rows:
                if len(row) == len(tab.names) - 1:
                    row.append(value if not tab.parquet or value != "" else None)
        elif a == "reorder":
            order = list(range(len(tab.names)))
            random.Random(self.arg).shuffle(order)
            tab.names = [tab.names[p] for p in order]
            tab.rows = [[r[p] for p in order] if len(r) == len(order) else r for r in tab.rows]
        elif self.column in tab.names:
            j = tab.names.index(self.column)
            if a == "drop":
                del tab.names[j]
                for row in tab.rows:
                    if j < len(row):
                        del row[j]
            elif a == "rename":
                tab.names[j] = self.arg
            elif a == "duplicate":
                tab.names.insert(j + 1, self.column)
                for row in tab.rows:
                    if j < len(row):
                        row.insert(j + 1, row[j])
            elif a == "fill":
                for row in tab.rows:
                    if j < len(row):
                        row[j] = cell_value(self.arg[0], self.arg[1], row[j], tab.parquet)
        work.save(self.file, tab)

    def describe(self) -> str:
        a, f, c = self.action, self.file, self.column
        if a == "extra":
            return f"{f} extra column {self.arg[0]!r} = {short(self.arg[1])}"
        if a == "reorder":
            return f"{f} columns reordered (seed {self.arg})"
        if a == "rename":
            return f"{f} column '{c}' renamed to {self.arg!r}"
        if a == "fill":
            return f"{f} every '{c}' = {describe_setter(*self.arg)}"
        return f"{f} column '{c}' {a}{'ped' if a == 'drop' else 'd'}"
