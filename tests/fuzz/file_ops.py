"""Fuzz mutation operations on whole files, and applying a mutation to a copy of the base.

:func:`apply_mutation` runs a mutation's operations in stages, so that two combined mutations
compose sensibly:

0. ``ToParquet``: a CSV sensor file becomes Parquet (the config's ``file`` follows);
1. table operations on cells, rows and columns (``table_ops``);
2. Parquet type and layout operations (``ArrowType``, ``ArrowLayout``);
3. config operations on the parsed TOML, written back by ``tomltext.dump_toml`` (the config
   file is copied unchanged when no config operation applies);
4. byte operations on one file (encodings, delimiters, NUL and random bytes, truncation);
5. run-level operations (what already exists at the output directory).

Every stage but 1 is here, with :class:`Mutation` and :func:`combine`.
"""
from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any, ClassVar

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from .base import BaseScenario, copy_base
from .table_ops import Op, Work
from .tomltext import POSITION_SCALE, Key, as_float, at_fraction, get_key, short, show_key


# ---- Parquet files -------------------------------------------------------------------------

@dataclass(frozen=True)
class ToParquet(Op):
    """A CSV sensor file rewritten as ``<stem>.parquet`` (types as pyarrow infers them); the
    config's ``file`` is changed to the new name."""

    stage: ClassVar[int] = 0
    file: str

    def apply(self, work: Work) -> None:
        src = work.path(self.file)
        if src.suffix != ".csv":
            return
        table = pacsv.read_csv(src)
        dst = src.with_suffix(".parquet")
        pq.write_table(table, dst)
        src.unlink()
        work.names[self.file] = dst.name
        entry = work.sensor_entry(self.file)
        if entry is not None:
            entry["file"] = dst.name
            work.config_changed = True

    def describe(self) -> str:
        return f"{self.file} converted to {Path(self.file).stem}.parquet"


def _arrow_column(col: pa.ChunkedArray, kind: str) -> pa.Array | pa.ChunkedArray:
    """A Parquet column re-typed (see :class:`ArrowType`)."""
    values = col.to_pylist()
    floats = [as_float(v) for v in values]
    finite = [x if x is not None and math.isfinite(x) else None for x in floats]
    if kind == "string":
        return pa.array([None if v is None else v if isinstance(v, str) else repr(v)
                         for v in values], pa.string())
    if kind == "large_string":
        return pa.array([None if v is None else str(v) for v in values], pa.large_string())
    if kind in ("int32", "int64"):
        lim = 2**31 - 1 if kind == "int32" else 2**63 - 1
        return pa.array([None if x is None else max(-lim, min(lim, int(x))) for x in finite],
                        pa.int32() if kind == "int32" else pa.int64())
    if kind == "float32":
        return pa.array(floats, pa.float64()).cast(pa.float32(), safe=False)
    if kind in ("timestamp_utc", "timestamp_naive"):
        tz = "UTC" if kind == "timestamp_utc" else None
        return pa.array([None if x is None or abs(x) > 9e12 else int(round(x * 1e6))
                         for x in finite], pa.timestamp("us", tz=tz))
    if kind == "dictionary":
        return col.combine_chunks().dictionary_encode()
    if kind == "all_null":
        return pa.nulls(len(col), type=col.type)
    if kind == "null_type":
        return pa.nulls(len(col))
    if kind == "decimal":
        return pa.array([None if x is None or abs(x) >= 1e17 else Decimal(repr(x))
                         .quantize(Decimal("0.000001")) for x in finite], pa.decimal128(24, 6))
    if kind == "list":
        return pa.array([[x] for x in floats], pa.list_(pa.float64()))
    if kind == "bool":
        return pa.array([None if x is None else x != 0 for x in floats], pa.bool_())
    raise ValueError(kind)


@dataclass(frozen=True)
class ArrowType(Op):
    """A Parquet column stored with another Arrow type: string, large_string, int32, int64,
    float32, timestamp_utc / timestamp_naive (seconds -> microsecond timestamps), dictionary,
    all_null (same type), null_type, decimal, list, bool. No-op on a CSV file."""

    stage: ClassVar[int] = 2
    file: str
    column: str
    kind: str

    def apply(self, work: Work) -> None:
        if not work.is_parquet(self.file):
            return
        path = work.path(self.file)
        table = pq.ParquetFile(path).read()   # (pq.read_table rejects duplicate names)
        if self.column not in table.column_names:
            return
        j = table.column_names.index(self.column)
        new = _arrow_column(table.column(j), self.kind)
        pq.write_table(table.set_column(j, self.column, new), path)

    def describe(self) -> str:
        return f"{self.file} column '{self.column}' stored as Arrow {self.kind}"


@dataclass(frozen=True)
class ArrowLayout(Op):
    """The same Parquet data written differently: row_groups (of ``n`` rows), no_dictionary,
    zstd, gzip, no_statistics, format_1_0, page_v2. No-op on a CSV file."""

    stage: ClassVar[int] = 2
    file: str
    kind: str
    n: int = 0

    def apply(self, work: Work) -> None:
        if not work.is_parquet(self.file):
            return
        path = work.path(self.file)
        table = pq.ParquetFile(path).read()   # (pq.read_table rejects duplicate names)
        kw: dict[str, Any] = {
            "row_groups": {"row_group_size": max(1, self.n)},
            "no_dictionary": {"use_dictionary": False}, "zstd": {"compression": "zstd"},
            "gzip": {"compression": "gzip"}, "no_statistics": {"write_statistics": False},
            "format_1_0": {"version": "1.0"}, "page_v2": {"data_page_version": "2.0"},
        }[self.kind]
        pq.write_table(table, path, **kw)

    def describe(self) -> str:
        extra = f" of {self.n} rows" if self.kind == "row_groups" else ""
        return f"{self.file} rewritten as Parquet with {self.kind}{extra}"


# ---- config ------------------------------------------------------------------------------

@dataclass(frozen=True)
class ConfigSet(Op):
    """Config key ``key`` set to ``value`` (missing tables on the way are created)."""

    stage: ClassVar[int] = 3
    key: Key
    value: Any

    def apply(self, work: Work) -> None:
        doc: Any = work.config
        for part in self.key[:-1]:
            if isinstance(part, str) and isinstance(doc, dict):
                doc = doc.setdefault(part, {})
            elif isinstance(part, int) and isinstance(doc, list) and part < len(doc):
                doc = doc[part]
            else:
                return
        last, value = self.key[-1], copy.deepcopy(self.value)   # values may be shared
        if isinstance(doc, dict) and isinstance(last, str):
            doc[last] = value
        elif isinstance(doc, list) and isinstance(last, int) and last < len(doc):
            doc[last] = value
        else:
            return
        work.config_changed = True

    def describe(self) -> str:
        return f"config {show_key(self.key)} = {short(self.value)}"


@dataclass(frozen=True)
class ConfigDelete(Op):
    """Config key ``key`` removed (a table, a value or an array element)."""

    stage: ClassVar[int] = 3
    key: Key

    def apply(self, work: Work) -> None:
        try:
            parent = get_key(work.config, self.key[:-1])
            del parent[self.key[-1]]
        except (KeyError, IndexError, TypeError):
            return
        work.config_changed = True

    def describe(self) -> str:
        return f"config {show_key(self.key)} deleted"


@dataclass(frozen=True)
class ConfigSensor(Op):
    """A ``[[sensors]]`` entry changed as a whole. ``action``: duplicate (a copy appended,
    same id), copy (a copy appended with id + '_2'), file (its ``file`` = ``arg``; 'adir.csv'
    is created as a directory)."""

    stage: ClassVar[int] = 3
    index: int
    action: str
    arg: str = ""

    def apply(self, work: Work) -> None:
        sensors = work.config.get("sensors")
        if not isinstance(sensors, list) or self.index >= len(sensors):
            return
        entry = sensors[self.index]
        if self.action in ("duplicate", "copy"):
            new = copy.deepcopy(entry)
            if self.action == "copy" and isinstance(new.get("id"), str):
                new["id"] = new["id"] + "_2"
            sensors.append(new)
        elif self.action == "file":
            entry["file"] = self.arg
            if self.arg == "adir.csv":
                (work.folder / "adir.csv").mkdir(exist_ok=True)
        work.config_changed = True

    def describe(self) -> str:
        if self.action == "file":
            return f"config sensors[{self.index}].file = {self.arg!r}"
        what = "same id" if self.action == "duplicate" else "id + '_2'"
        return f"config sensors[{self.index}] appended again ({what})"


# ---- bytes -------------------------------------------------------------------------------

def mutate_bytes(data: bytes, action: str, at: int, arg: bytes) -> bytes:
    """Byte-level change of a file (see :class:`Bytes`)."""
    p = at_fraction(at, len(data))
    if action == "bom":
        return b"\xef\xbb\xbf" + data
    if action in ("utf16", "utf16be"):
        text = data.decode("utf-8", errors="replace")
        return text.encode("utf-16" if action == "utf16" else "utf-16-be")
    if action == "crlf":
        return data.replace(b"\n", b"\r\n")
    if action == "cr":
        return data.replace(b"\n", b"\r")
    if action == "semicolon":
        return data.replace(b",", b";")
    if action == "tab":
        return data.replace(b",", b"\t")
    if action == "insert":
        return data[:p] + arg + data[p:]
    if action == "overwrite":
        return data[:p] + arg + data[p + len(arg):]
    if action == "footer":
        return data[:max(0, len(data) - len(arg))] + arg
    if action == "truncate":
        return data[:p]
    if action == "truncate_row":
        lines = data.split(b"\n")
        k = min(at, len(lines) - 1)
        before = sum(len(x) + 1 for x in lines[:k])
        return data[:before + max(1, len(lines[k]) // 2)]
    if action == "empty":
        return b""
    if action == "replace":
        return arg
    if action == "no_final_newline":
        return data.rstrip(b"\r\n")
    if action == "append":
        return data + arg
    raise ValueError(action)


@dataclass(frozen=True)
class Bytes(Op):
    """A byte-level change of one file (a sensor file or the config). ``action``: bom, utf16
    (with BOM), utf16be, crlf, cr, semicolon, tab (delimiter), insert / overwrite (``arg`` at
    position ``at``/1e6 of the length), footer (last bytes overwritten), truncate (cut at
    ``at``/1e6), truncate_row (cut in the middle of line ``at``), empty, replace (the whole
    file is ``arg``), no_final_newline, append."""

    stage: ClassVar[int] = 4
    file: str
    action: str
    at: int = 0
    arg: bytes = b""

    def apply(self, work: Work) -> None:
        path = work.path(self.file)
        if path.is_file():
            path.write_bytes(mutate_bytes(path.read_bytes(), self.action, self.at, self.arg))

    def describe(self) -> str:
        f, a = self.file, self.action
        where = f" at {self.at / POSITION_SCALE:.0%}"
        return {
            "bom": f"{f} with a UTF-8 BOM", "utf16": f"{f} encoded as UTF-16 (BOM)",
            "utf16be": f"{f} encoded as UTF-16-BE (no BOM)", "crlf": f"{f} with CRLF line ends",
            "cr": f"{f} with CR line ends", "semicolon": f"{f} with ';' delimiters",
            "tab": f"{f} with tab delimiters", "insert": f"{f} {short(self.arg)} inserted{where}",
            "overwrite": f"{f} overwritten with {short(self.arg)}{where}",
            "footer": f"{f} last {len(self.arg)} bytes overwritten",
            "truncate": f"{f} truncated{where}",
            "truncate_row": f"{f} cut in the middle of line {self.at}",
            "empty": f"{f} empty (0 bytes)",
            "replace": f"{f} replaced by {len(self.arg)} random bytes",
            "no_final_newline": f"{f} without a final newline",
            "append": f"{f} with {short(self.arg)} appended"}[a]


# ---- run ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class OutputObstacle(Op):
    """What exists at the output directory before the run. ``kind``: file (a regular file),
    stale (a folder with an old fused.parquet, summary.json and report/), symlink_file (a
    symlink to a sensor file), dangling (a symlink to nowhere)."""

    stage: ClassVar[int] = 5
    kind: str

    def apply(self, work: Work) -> None:
        out = work.config.get("output", {})
        name = out.get("dir", "out") if isinstance(out, dict) else "out"
        if not isinstance(name, str) or not name.strip() or Path(name).is_absolute():
            return
        path = Path(os.path.normpath(work.folder / name))
        if path.exists() or path.is_symlink() or path == work.folder:
            return
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError:     # the parent is a file (e.g. dir = "R1.csv/inner")
            return
        if self.kind == "file":
            path.write_bytes(b"an ordinary file where the output folder should be\n")
        elif self.kind == "stale":
            (path / "report").mkdir(parents=True)
            (path / "fused.parquet").write_bytes(b"stale")
            (path / "summary.json").write_text("{}")
            (path / "report" / "old.png").write_bytes(b"stale")
        elif self.kind == "symlink_file":
            path.symlink_to(work.path("R1.csv"))
        elif self.kind == "dangling":
            path.symlink_to(work.folder / "nowhere" / "out")

    def describe(self) -> str:
        return {"file": "output dir exists as a regular file",
                "stale": "output dir holds a previous run's files",
                "symlink_file": "output dir is a symlink to a sensor file",
                "dangling": "output dir is a dangling symlink"}[self.kind]


# ============================================================================================
# Mutation and application
# ============================================================================================

@dataclass(frozen=True)
class Mutation:
    """What a fuzz case changes: ``family`` (for the outcome table), ``ops`` and a one-line
    ``description`` (for the table and failure messages)."""

    family: str
    ops: tuple[Op, ...]

    @property
    def description(self) -> str:
        return f"{self.family}: " + "; ".join(op.describe() for op in self.ops)


def combine(first: Mutation, second: Mutation) -> Mutation:
    """Two mutations applied together (family 'combo')."""
    return Mutation("combo", first.ops + second.ops)


def apply_mutation(mutation: Mutation, base: BaseScenario, dest: Path) -> Path:
    """Copy the base folder to ``dest`` (must not exist) and apply ``mutation`` there; returns
    the config path. Operations run by stage (see the module docstring), in order within one."""
    config_path = copy_base(base, dest)
    work = Work(dest, base.layout)
    for op in sorted(mutation.ops, key=lambda o: o.stage):
        if op.stage >= Bytes.stage:
            work.flush_config()
        op.apply(work)
    work.flush_config()
    return config_path


