"""summary.json declared (``rangeproc.summary_types``): a run writes what the declaration
says, and the outputs page documents exactly the declared keys.

The page's tables of summary.json are generated from the declaration
(``rangeproc.summary_reference``); what can still part is the page's own text: a section
whose marker is missing (declared but not documented), a hand-written table or a dotted key
in the prose that the declaration lacks (documented but not declared). Each check has its
negative control.
"""
from __future__ import annotations

import json
import re
import typing
from pathlib import Path

import pytest

from rangeproc.summary_reference import MARKER, fill, marker, section_table
from rangeproc.summary_types import (
    DOCUMENTED,
    RunSummary,
    declared_keys,
    disagreements,
)

DOCS = Path(__file__).resolve().parents[1] / "docs"
SECTION_HEAD = "## `summary.json`"


def summary_section(page: str) -> str:
    """The text of the outputs page's summary.json section (up to the next ``## ``)."""
    start = page.index(SECTION_HEAD)
    end = page.find("\n## ", start + 1)
    return page[start:] if end < 0 else page[start:end]


def records(record: type = RunSummary, seen: set[type] | None = None) -> set[type]:
    """Every TypedDict reachable from ``record`` through its keys' types."""
    seen = set() if seen is None else seen
    if record in seen:
        return seen
    seen.add(record)
    for d in declared_keys(record):
        stack = [d.type]
        while stack:
            tp = stack.pop()
            if typing.is_typeddict(tp):
                records(tp, seen)
            stack.extend(typing.get_args(tp))
    return seen


def _resolve(path: list[str]) -> bool:
    """Whether a dotted key path of the page (``sensors.<id>.rows``; ``<...>`` stands for
    any key of a mapping) names declared keys, from the top level or from a section."""
    def walk(record: type, parts: list[str]) -> bool:
        keys = {d.name: d.type for d in declared_keys(record)}
        if not parts:
            return True
        if parts[0] not in keys:
            return False
        rest, tp = parts[1:], keys[parts[0]]
        while rest:
            origin, args = typing.get_origin(tp), typing.get_args(tp)
            if origin is dict and rest[0].startswith("<"):
                tp, rest = args[1], rest[1:]
                continue
            if typing.is_typeddict(tp):
                return walk(tp, rest)
            inner = [a for a in args if typing.is_typeddict(a)]
            if len(inner) == 1:
                return walk(inner[0], rest)
            return False
        return True
    starts = [RunSummary, *(r for r in records() if r is not RunSummary)]
    return any(walk(r, path) for r in starts)


#: A dotted key in backticks: ``sensors.<id>.calibration.<name>``, ``association.objects``.
DOTTED = re.compile(r"`([a-z_]+(?:\.(?:<[a-z ]+>|[a-z_0-9]+))+)`")


def page_disagreements(page: str) -> list[str]:
    """Where the outputs page (its Markdown as written, with markers) and the declaration
    part: a documented section without its marker, a marker twice, a hand-written table row
    in the summary.json section, a dotted key in its text that no declaration holds."""
    text = summary_section(page)
    out = []
    named = MARKER.findall(text)
    for section, _ in DOCUMENTED:
        if named.count(section) != 1:
            out.append(f"section {section!r}: {named.count(section)} markers (want 1)")
    out += [f"marker {n!r}: no such declared section" for n in named
            if n not in dict(DOCUMENTED)]
    out += [f"hand-written table row, not from the declaration: {line}"
            for line in text.splitlines() if line.startswith("|")]
    out += [f"`{m}`: not a declared key" for m in DOTTED.findall(text)
            if not m.endswith((".parquet", ".json")) and not _resolve(m.split("."))]
    return out


def outputs_page() -> str:
    return (DOCS / "outputs.md").read_text(encoding="utf-8")


# ------------------------------------------------------------------- the page against it
def test_the_outputs_page_and_the_declaration_agree() -> None:
    assert page_disagreements(outputs_page()) == []


def test_a_section_left_undocumented_fails() -> None:
    page = outputs_page().replace(marker("rows") + "\n", "")
    assert page_disagreements(page) == ["section 'rows': 0 markers (want 1)"]


def test_a_key_documented_but_not_declared_fails() -> None:
    page = outputs_page().replace(marker("targets"),
                                  marker("targets") + "\n| `n_bogus` | a key nobody writes |")
    found = page_disagreements(page)
    assert len(found) == 1 and "n_bogus" in found[0]
    prose = outputs_page().replace("(`sensors.<id>.rows`", "(`sensors.<id>.rowz`")
    assert prose != outputs_page()
    assert page_disagreements(prose) == ["`sensors.<id>.rowz`: not a declared key"]


def test_the_filled_page_lists_every_declared_key_once() -> None:
    text = summary_section(fill(outputs_page()))
    listed = [name for line in text.splitlines() if line.startswith("| `")
              for name in re.findall(r"`([a-z_0-9]+)`", line.split(" | ")[0])]
    want = [d.name for _, record in DOCUMENTED for d in declared_keys(record)]
    assert sorted(listed) == sorted(want)
    assert "<!--" not in text


def test_every_declared_key_says_what_it_holds() -> None:
    undocumented = [f"{r.__name__}.{d.name}" for r in records() for d in declared_keys(r)
                    if d.doc is None or not d.doc.what.strip()]
    assert undocumented == []


def test_a_marker_of_no_section_is_refused() -> None:
    with pytest.raises(ValueError, match="no such summary.json section"):
        fill("<!-- summary.json: nonsense -->\n")


def test_consecutive_keys_with_one_doc_share_a_row() -> None:
    table = section_table("summary")
    assert "| `rangeproc_version`, `python`, `numpy` | the versions that made the run |" in table
    assert table.count("\n") + 1 == 2 + len(declared_keys(RunSummary)) - 2


# ------------------------------------------------------------------- a run against it
def test_the_sample_run_writes_what_is_declared(sample_run) -> None:
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    assert list(disagreements(summary)) == []


def test_an_undeclared_or_missing_key_is_found(sample_run) -> None:
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    sid = next(iter(summary["sensors"]))
    summary["sensors"][sid]["rows"]["n_bogus"] = 1
    del summary["targets"]["T1"]["n_epochs"]
    summary["time_scale"] = None
    summary["association"]["objects"]["T1"]["segments"][0]["extra"] = 0
    assert sorted(disagreements(summary)) == sorted([
        f"sensors.{sid}.rows.n_bogus: written but not declared in RowsSummary",
        "targets.T1.n_epochs: declared required in TargetSummary but missing",
        "association.objects.T1.segments[0].extra: written but not declared in "
        "SegmentRecord",
        "time_scale: null, declared TimeScaleRecord"])
    summary["time_scale"] = []
    assert "time_scale: not an object" in list(disagreements(summary))
