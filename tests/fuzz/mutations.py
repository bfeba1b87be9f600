"""Fuzz mutations of the base scenario: the hypothesis strategies.

A :class:`Mutation` is a family name and a tuple of small frozen operations (``Op``), with a
short human-readable description. Strategies are deterministic functions of hypothesis draws
(every pseudo-random choice, e.g. a shuffle, uses a drawn seed), so hypothesis can replay and
shrink them. :func:`apply_mutation` copies the base folder and applies the operations; it
depends on nothing but its arguments.

The operations live in ``table_ops`` (cells, rows, columns, time stamps) and ``file_ops``
(Parquet, config, bytes, output folder; ``Mutation`` and ``apply_mutation``, re-exported here),
the TOML and text helpers in ``tomltext``.
"""
from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

from hypothesis import strategies as st

from .base import CONFIG_NAME, BaseLayout, SensorFile
from .file_ops import (ArrowLayout, ArrowType, Bytes, ConfigDelete, ConfigSensor, ConfigSet,
                       Mutation, OutputObstacle, ToParquet, apply_mutation, combine)
from .table_ops import ColumnMap, ColumnOp, CopyPrevious, IsoTimes, Op, Rows, RowOp, SetCell
from .tomltext import POSITION_SCALE, config_keys, get_key

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["Mutation", "apply_mutation", "families", "mutations"]


GARBAGE = ("abc", "N/A", "--", "1.2.3", "0x1F", "1e", "TRUE", "null", "NULL", "None", "+5",
           "5e", "infinity", "-Infinity", "NaN", "nan(123)", "1d5", ".", "-", "1_000", "$12",
           "12 m", "1e-", "#", '"', "'", "=1+1", "\\N")
UNICODE = ("Ω", "３４６２９７", "١٢٣", "𝟙𝟚𝟛", "\u00a0", "e\u0301", "🚀", "\u200b5",
           "−5", "½", "五", "\ufeff1")
WHITESPACE = (" ", "   ", "\t", " \t ")
ISO_VARIANTS = ("Z", "+00:00", "+05:30", "-08:00", "space", "naive")
NUMBERS = ("nan", "inf", "-inf", "1e308", "-1e308", "1e-308", "0", "-0", "5e-324", "1e309")


def rows_selection(n_rows: int) -> st.SearchStrategy[Rows]:
    """One row, every row, every k-th row or the first n rows of a file."""
    return st.one_of(
        st.builds(Rows, st.just("row"), st.integers(1, max(1, n_rows))),
        st.just(Rows("all")),
        st.builds(Rows, st.just("every"), st.sampled_from((2, 3, 10))),
        st.builds(Rows, st.just("first"), st.sampled_from((1, 20))))


def cell_setter(column: str) -> st.SearchStrategy[tuple[str, Any]]:
    """A cell change (setter name, argument); ISO-8601 text only for ``time``."""
    choices = [
        st.just(("empty", None)),
        st.tuples(st.just("text"), st.sampled_from(GARBAGE)),
        st.tuples(st.just("text"), st.text(
            st.characters(blacklist_categories=("Cs", "Cc")), min_size=1, max_size=12)),
        st.tuples(st.just("number"), st.sampled_from(NUMBERS)),
        st.just(("negate", None)), st.just(("times_1e6", None)),
        st.tuples(st.just("digits"), st.sampled_from((20, 309, 400, 4000, -400))),
        st.just(("comma", None)),
        st.tuples(st.just("text"), st.sampled_from(WHITESPACE)),
        st.tuples(st.just("text"), st.sampled_from(UNICODE)),
        st.just(("padded", None)),
    ]
    if column == "time":
        choices.append(st.tuples(st.just("iso"), st.sampled_from(ISO_VARIANTS)))
    return st.one_of(choices)


def cell_ops(f: SensorFile) -> st.SearchStrategy[Op]:
    """One cell of file ``f`` changed."""
    @st.composite
    def one_cell(draw: Callable) -> Op:
        column = draw(st.sampled_from(f.columns))
        setter, arg = draw(cell_setter(column))
        return SetCell(f.name, draw(st.integers(1, f.n_rows)), column, setter, arg)
    return one_cell()


def row_ops(f: SensorFile, parquet: bool = False) -> st.SearchStrategy[Op]:
    """Rows of file ``f`` deleted, duplicated, reordered, blanked, made ragged, truncated
    (``parquet``: only changes that apply to a Parquet file, e.g. after ``ToParquet``)."""
    i = st.integers(1, f.n_rows)
    ops = [
        st.builds(RowOp, st.just(f.name), st.just("delete"), i, st.sampled_from((1, 2, 50))),
        st.builds(RowOp, st.just(f.name), st.just("delete_every"), st.just(1),
                  st.sampled_from((2, 3, 10))),
        st.builds(RowOp, st.just(f.name), st.just("keep_first"), st.just(1),
                  st.sampled_from((1, 2, 3, 5))),
        st.just(RowOp(f.name, "header_only")),
        st.builds(RowOp, st.just(f.name), st.just("duplicate"), i),
        st.just(RowOp(f.name, "double")), st.just(RowOp(f.name, "append_copy")),
        st.builds(RowOp, st.just(f.name), st.just("shuffle"), st.just(1),
                  st.integers(0, 2**31)),
        st.just(RowOp(f.name, "reverse")),
        st.builds(RowOp, st.just(f.name), st.just("blank"), i),
        st.builds(RowOp, st.just(f.name), st.just("header_again"), i),
    ]
    if not (f.is_parquet or parquet):
        ops += [
            st.builds(RowOp, st.just(f.name), st.just("ragged_more"), i, st.sampled_from((1, 5))),
            st.builds(RowOp, st.just(f.name), st.just("ragged_less"), i,
                      st.sampled_from((1, 2, 20))),
            st.just(RowOp(f.name, "no_header")),
            st.builds(Bytes, st.just(f.name), st.just("truncate_row"), i),
        ]
    return st.one_of(ops)


RENAMES = ("Time", "TIME", " time ", "rng", "t", "x", "", "time\u200b", "rånge", "range,1",
           "time_s")


def column_ops(f: SensorFile) -> st.SearchStrategy[Op]:
    """A column of file ``f`` dropped, renamed, duplicated, added, reordered or filled."""
    col = st.sampled_from(f.columns)
    fill = st.one_of(st.tuples(st.just("number"), st.sampled_from(("0", "1e308", "-1", "nan"))),
                     st.tuples(st.just("text"), st.sampled_from(("abc", " ", "Ω"))),
                     st.just(("empty", None)))
    extra_name = st.sampled_from(("extra", "notes", "range_rate", "track_id", "station",
                                  "range", "quality", ""))
    extra_value = st.sampled_from(("", "x", "1.5", "nan", "7", "M1"))
    return st.one_of(
        st.builds(ColumnOp, st.just(f.name), st.just("drop"), col),
        st.builds(ColumnOp, st.just(f.name), st.just("rename"), col, st.sampled_from(RENAMES)),
        st.builds(ColumnOp, st.just(f.name), st.just("duplicate"), col),
        st.builds(ColumnOp, st.just(f.name), st.just("extra"), st.just(""),
                  st.tuples(extra_name, extra_value)),
        st.builds(ColumnOp, st.just(f.name), st.just("reorder"), st.just(""),
                  st.integers(0, 2**31)),
        st.builds(ColumnOp, st.just(f.name), st.just("fill"), col, fill))


def time_ops(f: SensorFile, layout: BaseLayout) -> st.SearchStrategy[Op]:
    """Time stamps of file ``f`` shifted, scaled, collapsed, duplicated or written as ISO."""
    shift = st.sampled_from((1e3, 1e6, 1e9, 1e15)).flatmap(
        lambda d: st.sampled_from((d, -d)))
    one_time = st.sampled_from((layout.t_min + 5.0, layout.t_min + 1e7, 0.0, -1.0))
    return st.one_of(
        st.builds(ColumnMap, st.just(f.name), st.just("time"),
                  st.builds(Rows, st.just("row"), st.integers(1, f.n_rows)), st.just("add"),
                  shift),
        st.builds(ColumnMap, st.just(f.name), st.just("time"), st.just(Rows("all")),
                  st.just("add"), st.sampled_from((86400.0, -86400.0, -layout.t_min - 100.0,
                                                   1e9))),
        st.builds(ColumnMap, st.just(f.name), st.just("time"), st.just(Rows("all")),
                  st.just("set"), one_time),
        st.just(ColumnMap(f.name, "time", Rows("all"), "mul", 1000.0)),
        st.builds(CopyPrevious, st.just(f.name), st.just("time"), rows_selection(f.n_rows)),
        st.builds(IsoTimes, st.just(f.name), st.sampled_from(ISO_VARIANTS)),
        st.builds(ConfigSet, st.just(("sensors", f.index, "time_offset")),
                  st.sampled_from((1e9, -1e9, 1e15, 1e308, -1e308, math.nan, math.inf,
                                   86400.0, 1e6, -1e3, "0.05", True))))


#: (sensor kind, column) -> absurd but parseable values.
ABSURD: dict[tuple[str, str], tuple[float, ...]] = {
    ("radar", "range"): (1e308, 0.0, -100.0, 1e7),
    ("radar", "azimuth"): (1e20, -1e20, 720.0),
    ("radar", "elevation"): (500.0, -95.0, 90.0),
    ("radar", "range_rate"): (1e300, -1e300, 3e8),
    ("theodolite", "range"): (1e308, 0.0, -5.0),
    ("theodolite", "azimuth"): (1e20, 720.0),
    ("theodolite", "elevation"): (500.0, 90.0),
    ("gps", "lat"): (89.9999, -89.9999, 90.0, 91.0),
    ("gps", "lon"): (359.0, -180.0, 360.0, 1e6),
    ("gps", "height"): (1e9, -1e7),
    ("gps", "ve"): (1e12,), ("gps", "vn"): (1e12,), ("gps", "vu"): (-1e12,),
    ("ins", "pitch"): (1e6, 90.0), ("ins", "roll"): (1e6, 180.0), ("ins", "yaw"): (1e20,),
    ("ins", "lat"): (89.9999,), ("ins", "height"): (1e9,), ("ins", "ve"): (1e12,),
    ("mistram", "range_rate"): (1e300, -1e300, 3e8),
}
#: (sensor kind, column) -> offset of a run of wild points.
WILD: dict[tuple[str, str], float] = {
    ("radar", "range"): 5000.0, ("radar", "azimuth"): 30.0, ("radar", "elevation"): 20.0,
    ("theodolite", "azimuth"): 30.0, ("gps", "lat"): 0.5, ("gps", "height"): 3000.0,
    ("mistram", "range_rate"): 500.0, ("ins", "yaw"): 90.0,
}


def value_ops(f: SensorFile) -> st.SearchStrategy[Op]:
    """Physically absurd values in file ``f`` (one row, many rows, or a wild run at the start)."""
    absurd = [(c, v) for (k, c), vs in ABSURD.items() if k == f.kind and c in f.columns
              for v in vs]
    wild = [(c, d) for (k, c), d in WILD.items() if k == f.kind and c in f.columns]
    choices = []
    if absurd:
        choices.append(st.tuples(st.sampled_from(absurd), rows_selection(f.n_rows)).map(
            lambda p: ColumnMap(f.name, p[0][0], p[1], "set", p[0][1])))
    if wild:
        choices.append(st.sampled_from(wild).map(
            lambda p: ColumnMap(f.name, p[0], Rows("first", 20), "add", p[1])))
    return st.one_of(choices)


def parquet_ops(f: SensorFile) -> st.SearchStrategy[Op]:
    """Parquet-only changes of a Parquet file ``f`` (types, layout, corrupt or cut bytes)."""
    col = st.sampled_from(f.columns)
    kinds = st.sampled_from(("string", "large_string", "int32", "int64", "float32",
                             "timestamp_utc", "timestamp_naive", "dictionary", "all_null",
                             "null_type", "decimal", "list", "bool"))
    at = st.integers(0, POSITION_SCALE)
    return st.one_of(
        st.builds(ArrowType, st.just(f.name), col, kinds),
        st.builds(ArrowLayout, st.just(f.name),
                  st.sampled_from(("row_groups", "no_dictionary", "zstd", "gzip",
                                   "no_statistics", "format_1_0", "page_v2")),
                  st.sampled_from((1, 7, 100))),
        st.builds(Bytes, st.just(f.name), st.just("overwrite"), at,
                  st.binary(min_size=1, max_size=64)),
        st.builds(Bytes, st.just(f.name), st.just("truncate"), at),
        st.builds(Bytes, st.just(f.name), st.just("footer"), st.just(0),
                  st.sampled_from((b"PAR2", b"\x00" * 8, b"\xff\xff\xff\x7fPAR1"))))


def parquet_mutation(layout: BaseLayout) -> st.SearchStrategy[Mutation]:
    """A CSV sensor converted to Parquet, alone or with a cell/row/column/time/Parquet change of
    the converted file; or a Parquet change of a file that is Parquet in the base."""
    csv_files = [f for f in layout.files if not f.is_parquet]
    native = [f for f in layout.files if f.is_parquet]

    @st.composite
    def converted_or_native(draw: Callable) -> Mutation:
        if native and draw(st.booleans()):
            f = draw(st.sampled_from(native))
            return Mutation("parquet", (draw(parquet_ops(f)),))
        f = draw(st.sampled_from(csv_files))
        extra = draw(st.one_of(
            st.just(None), cell_ops(f), row_ops(f, parquet=True), column_ops(f),
            time_ops(f, layout), parquet_ops(f)))
        return Mutation("parquet", (ToParquet(f.name),) + ((extra,) if extra else ()))
    return converted_or_native()


def encoding_ops(layout: BaseLayout) -> st.SearchStrategy[Op]:
    """Encodings, delimiters and foreign bytes in a sensor file."""
    csv_names = [f.name for f in layout.files if not f.is_parquet]
    all_names = [f.name for f in layout.files]
    at = st.integers(0, POSITION_SCALE)
    text_actions = ("bom", "utf16", "utf16be", "crlf", "cr", "semicolon", "tab",
                    "no_final_newline")
    return st.one_of(
        st.builds(Bytes, st.sampled_from(csv_names), st.sampled_from(text_actions)),
        st.builds(Bytes, st.sampled_from(csv_names), st.just("insert"), at,
                  st.sampled_from((b"\xe9", b"caf\xe9", b"\x00", b"\xff\xfe"))),
        st.builds(Bytes, st.sampled_from(all_names), st.sampled_from(("insert", "overwrite")),
                  at, st.binary(min_size=1, max_size=32)),
        st.builds(Bytes, st.sampled_from(all_names), st.just("empty")),
        st.builds(Bytes, st.sampled_from(all_names), st.just("replace"), st.just(0),
                  st.binary(min_size=1, max_size=4096)),
        st.builds(Bytes, st.sampled_from(csv_names), st.just("append"), st.just(0),
                  st.sampled_from((b"\n\n\n", b"garbage line\n", b"\x1a", b",,,,\n"))))


def config_ops(layout: BaseLayout) -> st.SearchStrategy[Op]:
    """Config changes: keys deleted or set to absurd values, unknown keys, sensors removed,
    duplicated or pointed at missing files, absurd [output] and [processing], invalid TOML."""
    doc = tomllib.loads(layout.config_text)
    keys = config_keys(doc)
    numeric = [k for k in keys if isinstance(get_key(doc, k), (int, float))
               and not isinstance(get_key(doc, k), bool)]
    strings = [k for k in keys if isinstance(get_key(doc, k), str)]
    tables = [()] + [k for k in keys if isinstance(get_key(doc, k), dict)]
    n_sensors = len(doc["sensors"])
    sigma_keys = [k for k in keys if len(k) == 4 and k[2] == "sigma"]
    site_keys = [k for k in keys if len(k) == 4 and k[2] == "site"]
    lever = [k for k in keys if len(k) >= 3 and k[2] == "lever_arm"]
    sensor_index = st.integers(0, n_sensors - 1)
    any_value = st.sampled_from((0, 0.0, -1.0, 1e308, -1e308, 1e-308, math.nan, math.inf,
                                 "a string", "10", True, [], {}, 2**63))
    at = st.integers(0, POSITION_SCALE)
    processing = st.sampled_from((
        ("noise_passes", 1_000_000), ("noise_passes", 0), ("noise_passes", 50),
        ("noise_passes", -1), ("noise_passes", 1.5), ("process_noise", 1e300),
        ("process_noise", 1e-300), ("process_noise", 0.0), ("gate_probability", 1e-300),
        ("gate_probability", 1.0 - 1e-16), ("gate_probability", 0.5), ("gate_probability", 1.0),
        ("filter", "bogus"), ("filter", "ukf"), ("filter", "EKF"), ("adapt_noise", False),
        ("adapt_noise", "no"), ("bogus_key", 1),
        ("filter", "sage-husa"), ("filter", "askf"), ("maneuver_norm", 8.0),
        ("maneuver_norm", 1e-300), ("maneuver_norm", 1e300), ("sage_husa_window", 2),
        ("sage_husa_window", 10**9), ("sage_husa_mean", True), ("max_gap", 0.5),
        ("max_gap", 1e-9), ("time_margin", 0.0), ("max_speed", 1.0), ("max_range", 1.0),
        ("filter", "stukf"), ("filter", "imm"), ("stukf_weakening", 1.0),
        ("stukf_weakening", 1e300), ("stukf_forgetting", 1e-300), ("stukf_ratios", [1e3] * 3),
        ("stukf_ratios", [1, 1]), ("imm_models", ["ct"]), ("imm_models", ["cv", "cv"]),
        ("imm_models", []), ("imm_sojourn", 1e-300), ("imm_sojourn", 1e-3)))
    return st.one_of(
        st.builds(ConfigDelete, st.sampled_from(keys)),
        st.builds(ConfigSet, st.sampled_from(numeric), any_value),
        st.builds(ConfigSet, st.sampled_from(strings),
                  st.sampled_from(("", " ", "bogus", "Ω", "x" * 5000, 5, True))),
        st.builds(ConfigSet, st.sampled_from(tables).map(lambda t: t + ("unknown_key",)),
                  st.just(1)),
        st.builds(ConfigDelete, sensor_index.map(lambda i: ("sensors", i))),
        st.just(ConfigSet(("sensors",), [])),
        st.builds(ConfigSensor, sensor_index, st.sampled_from(("duplicate", "copy"))),
        st.builds(ConfigSet, st.tuples(st.just("sensors"), sensor_index, st.just("id")),
                  st.sampled_from(tuple(s["id"] for s in doc["sensors"]))),
        st.builds(ConfigSensor, sensor_index, st.just("file"),
                  st.sampled_from(("missing.csv", "adir.csv", ".", "", "R1.csv", "G1.csv",
                                   "TH1.parquet", "scenario.toml", "R1.xlsx", "MISSING.parquet"))),
        st.builds(ConfigSet, st.tuples(st.just("sensors"), sensor_index,
                                       st.just("angle_unit")),
                  st.sampled_from(("grad", "DEG", "degrees", "", "rad", "mil", 5))),
        st.builds(ConfigSet, st.just(("output", "rate_hz")),
                  st.sampled_from((1e9, 1e-9, 1e308, 1e-308, 1e6, 1000.0, 0.01, 0, -10.0))),
        processing.map(lambda kv: ConfigSet(("processing", kv[0]), kv[1])),
        st.builds(ConfigSet, st.sampled_from(sigma_keys),
                  st.sampled_from((1e-300, 1e300, 5e-324, 1e-12, 1e12))),
        st.builds(ConfigSet, st.sampled_from(site_keys or numeric),
                  st.sampled_from((1e300, -1e7, 90.0, -90.0, 359.9999, -180.0))),
        st.builds(ConfigSet, st.sampled_from(lever or numeric),
                  st.sampled_from((1e300, -1e300, 1e6))),
        st.builds(ConfigSet, st.sampled_from((("range", "origin", "lat"),
                                              ("range", "origin", "lon"),
                                              ("range", "origin", "height"))),
                  st.sampled_from((90.0, -90.0, 180.0, -180.0, 1e300, -6.4e6))),
        st.builds(ConfigSet, st.just(("targets",)),
                  st.sampled_from(([], [{"id": "T1"}, {"id": "T1"}], [{"id": "T1"},
                                                                      {"id": "T2"}]))),
        st.builds(Bytes, st.just(CONFIG_NAME), st.sampled_from(("insert", "overwrite")), at,
                  st.sampled_from((b"\xff", b"[[sensors", b"=", b"\x00", b'"', b"\n[range]\n"))),
        st.builds(Bytes, st.just(CONFIG_NAME), st.just("truncate"), at),
        st.builds(Bytes, st.just(CONFIG_NAME), st.sampled_from(("bom", "utf16", "crlf",
                                                                "empty"))),
        st.builds(Bytes, st.just(CONFIG_NAME), st.just("replace"), st.just(0),
                  st.binary(min_size=1, max_size=512)))


OUTPUT_DIRS = (".", "a/b/c", "ünïcode out", "with space", "R1.csv", "R1.csv/inner",
               "scenario.toml", "", " ", "out/", "./out/../out", "adir.csv")


def run_mutation(layout: BaseLayout) -> st.SearchStrategy[Mutation]:
    """Whole-run changes: where ``[output].dir`` points (or the default 'out') and what already
    exists there (a file, a previous run's outputs, a symlink to a file, a dangling symlink)."""
    where = st.one_of(st.just(()), st.sampled_from(OUTPUT_DIRS).map(
        lambda d: (ConfigSet(("output", "dir"), d),)))
    what = st.one_of(st.just(()), st.sampled_from(("file", "stale", "symlink_file",
                                                   "dangling")).map(
        lambda k: (OutputObstacle(k),)))
    return st.tuples(where, what).filter(lambda p: p[0] or p[1]).map(
        lambda p: Mutation("run", p[0] + p[1]))


def family_strategies(layout: BaseLayout) -> dict[str, st.SearchStrategy[Mutation]]:
    """Family name -> strategy of single mutations of that family."""
    files = st.sampled_from(layout.files)

    def per_file(ops: Callable[[SensorFile], st.SearchStrategy[Op]], family: str
                 ) -> st.SearchStrategy[Mutation]:
        return files.flatmap(ops).map(lambda op: Mutation(family, (op,)))

    def one(ops: st.SearchStrategy[Op], family: str) -> st.SearchStrategy[Mutation]:
        return ops.map(lambda op: Mutation(family, (op,)))

    return {
        "cell": per_file(cell_ops, "cell"),
        "row": per_file(row_ops, "row"),
        "column": per_file(column_ops, "column"),
        "encoding": one(encoding_ops(layout), "encoding"),
        "time": per_file(lambda f: time_ops(f, layout), "time"),
        "value": st.sampled_from([f for f in layout.files if any(
            (f.kind, c) in ABSURD for c in f.columns)]).flatmap(value_ops).map(
            lambda op: Mutation("value", (op,))),
        "parquet": parquet_mutation(layout),
        "config": one(config_ops(layout), "config"),
        "run": run_mutation(layout),
    }


def mutations(layout: BaseLayout) -> st.SearchStrategy[Mutation]:
    """A mutation of one family, or (family 'combo', drawn like a family) two combined. Every
    draw matters to the result, so distinct hypothesis examples are distinct mutations."""
    fams = family_strategies(layout)
    single = st.sampled_from(sorted(fams)).flatmap(lambda name: fams[name])
    combo = st.tuples(single, single).filter(lambda pair: pair[0] != pair[1]).map(
        lambda pair: combine(*pair))
    return st.sampled_from(sorted(fams) + ["combo"]).flatmap(
        lambda name: combo if name == "combo" else fams[name])


def families(layout: BaseLayout) -> Sequence[str]:
    """The family names (plus 'combo')."""
    return sorted(family_strategies(layout)) + ["combo"]
