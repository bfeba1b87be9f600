"""summary.json declared (``rangeproc.summary_types``): a run writes what the declaration
says, and every declared key says what it holds."""
from __future__ import annotations

import json
import typing

from rangeproc.summary_types import RunSummary, declared_keys, disagreements


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


def test_every_declared_key_says_what_it_holds() -> None:
    undocumented = [f"{r.__name__}.{d.name}" for r in records() for d in declared_keys(r)
                    if d.doc is None or not d.doc.what.strip()]
    assert undocumented == []


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
