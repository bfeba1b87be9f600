"""Fuzz test of ``rangeproc run``: mutated inputs and configs end in exit 0 with outputs that
pass the contract checks, or exit 2 with one line naming the file (see ``harness.classify``).

Each hypothesis example mutates a fresh copy of the small base scenario (``base.py``) with one
mutation, or two combined (``mutations.py``), and runs it in a forked child of this warmed
process (``harness.py``). Environment:

* ``RANGEPROC_FUZZ_EXAMPLES``: number of examples (default 20: the bounded sample of
  ``make test``);
* ``RANGEPROC_FUZZ_SEED``: random seed (default: hypothesis' derandomized, fixed sequence);
* ``RANGEPROC_FUZZ_RECORD``: a JSON-lines file; when set, nothing is asserted: one line per
  case is appended and the campaign continues through failures (``bench/fuzz.py``);
* ``RANGEPROC_FUZZ_TIMEOUT`` (s, default 30) and ``RANGEPROC_FUZZ_MEM_MIB`` (default 2048):
  per-case wall-clock and extra address-space limits.

A failure is shrunk to the smallest mutation that still fails (hypothesis' explain phase is
left out: it traces the test, and the forked child would inherit the tracer).
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, seed, settings

from .base import BaseScenario, build_base, copy_base, plan_base
from .harness import Outcome, case_facts, check_outputs, run_case, warm_up
from .mutations import Mutation, apply_mutation, mutations

EXAMPLES = int(os.environ.get("RANGEPROC_FUZZ_EXAMPLES", "20"))
SEED = os.environ.get("RANGEPROC_FUZZ_SEED")
RECORD = os.environ.get("RANGEPROC_FUZZ_RECORD")
TIMEOUT_S = float(os.environ.get("RANGEPROC_FUZZ_TIMEOUT", "30"))
MEM_LIMIT = int(float(os.environ.get("RANGEPROC_FUZZ_MEM_MIB", "2048")) * 2**20)


@pytest.fixture(scope="session")
def fuzz_base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[BaseScenario]:
    """The base scenario, checked to run cleanly: this process is warmed up by an in-process
    run of it (on a copy), which must exit 0 with outputs that pass the harness' checks."""
    root = tmp_path_factory.mktemp("fuzz")
    base = build_base(root / "base")
    warm = copy_base(base, root / "warm")
    assert warm_up(warm) == 0, "the base scenario does not run"
    problems = check_outputs(case_facts(warm))
    assert not problems, f"the base scenario's outputs fail the checks: {problems}"
    yield base
    shutil.rmtree(root, ignore_errors=True)


def record(path: str, mutation: Mutation, outcome: Outcome) -> None:
    """Append one JSON line describing the case to ``path``."""
    line = {"family": mutation.family, "description": mutation.description,
            "outcome": outcome.kind, "exit_code": outcome.exit_code, "signal": outcome.signal,
            "wall_s": round(outcome.wall_s, 3), "cpu_s": round(outcome.cpu_s, 3),
            "peak_rss_mib": round(outcome.peak_rss_mib, 1),
            "base_rss_mib": round(outcome.base_rss_mib, 1), "first_line": outcome.first_line,
            "error_line": outcome.error_line, "detail": outcome.detail, "seed": SEED}
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(line, ensure_ascii=False) + "\n")


def _seeded(test: Callable[..., None]) -> Callable[..., None]:
    """``hypothesis.seed(RANGEPROC_FUZZ_SEED)`` when the variable is set."""
    return seed(int(SEED))(test) if SEED is not None else test


@_seeded
@settings(max_examples=EXAMPLES, deadline=None, derandomize=SEED is None, database=None,
          print_blob=True, phases=(Phase.explicit, Phase.generate, Phase.shrink),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.filter_too_much, HealthCheck.large_base_example])
@given(mutation=mutations(plan_base()))
def test_fuzz_run(fuzz_base: BaseScenario, mutation: Mutation) -> None:
    """Every mutated case ends in exit 0 with valid outputs or in exit 2 with one line naming
    the file (in record mode: one JSON line per case, no assertion)."""
    if not RECORD:
        outcome = run_mutation(fuzz_base, mutation)
        assert outcome.good, f"{mutation.description}\n{outcome.explain()}"
        return
    try:
        outcome = run_mutation(fuzz_base, mutation)
    except Exception:  # noqa: BLE001 - a campaign records a fault of the suite and goes on
        outcome = Outcome(kind="harness_error", exit_code=None, signal=None, wall_s=0.0,
                          cpu_s=0.0, peak_rss_mib=0.0, base_rss_mib=0.0,
                          stderr=traceback.format_exc(), detail="the fuzz suite failed")
    record(RECORD, mutation, outcome)


def run_mutation(base: BaseScenario, mutation: Mutation) -> Outcome:
    """Apply ``mutation`` to a fresh copy of the base (a temporary folder, removed after) and
    run it with the per-case limits."""
    with tempfile.TemporaryDirectory(prefix="case-", dir=base.folder.parent) as tmp:
        config = apply_mutation(mutation, base, Path(tmp) / "case")
        return run_case(config, TIMEOUT_S, MEM_LIMIT)
