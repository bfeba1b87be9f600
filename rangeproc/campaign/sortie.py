"""One sortie of a campaign, as a Dask task: resume check, ``rangeproc run``, outcome.

:func:`run_sortie` never raises for the sortie's own trouble: a bad input or config (exit 2),
a numerical failure (exit 3), an output that cannot be written (exit 5: a full disk, a
read-only folder) or anything unexpected (exit 1) becomes a ``failed``
:class:`Outcome` with the one-line reason ``rangeproc run`` would print, so one bad flight
never stops the others. The outputs are exactly ``rangeproc run``'s (``pipeline.run``:
staged and renamed into place, so a sortie that fails or whose worker dies leaves its
previous outputs untouched and no half-written file).

**Resume.** A sortie is ``skipped`` when its ``summary.json`` and outputs exist and the
summary's config and input SHA-256 equal those of the files now: the same config and the
same data give the same outputs, so they are not recomputed.
"""
from __future__ import annotations

import json
import os
import socket
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from rangeproc.campaign.spec import Sortie
from rangeproc.errors import (ConfigError, DataError, NumericalError, OutputError,
                              RangeprocError, write_failure)

#: Exit status of each failure kind (as ``rangeproc run``).
EXIT_OF = ((ConfigError, 2), (DataError, 2), (NumericalError, 3), (OutputError, 5),
           (RangeprocError, 1))
#: Outputs whose presence (with a matching summary) makes a sortie done.
DONE_FILES = ("fused.parquet", "summary.json", "report/index.html")


@dataclass(frozen=True, slots=True)
class Outcome:
    """What became of one sortie. status: "done" (run now), "skipped" (outputs already match
    the config and inputs), "failed" (``reason`` one line, ``exit_code`` as ``rangeproc
    run``'s); seconds: wall time of the task; where: host and process that ran it."""

    id: str
    config: str
    out_dir: str
    status: str
    reason: str = ""
    exit_code: int = 0
    seconds: float = 0.0
    where: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


def fingerprint_matches(config_path: Path) -> Path | None:
    """The sortie's output folder when its outputs are complete and were made from the
    config and inputs as they are now; None otherwise (including an unreadable config)."""
    from rangeproc.config import load_config
    from rangeproc.io.writers import file_sha256

    try:
        cfg = load_config(config_path)
        out = cfg.output.dir
        if not all((out / f).is_file() for f in DONE_FILES):
            return None
        summary = json.loads((out / "summary.json").read_text())
        if summary["config"]["sha256"] != file_sha256(cfg.path):
            return None
        inputs = summary["inputs"]
        if set(inputs) != {s.id for s in cfg.sensors}:
            return None
        for s in cfg.sensors:
            if inputs[s.id]["sha256"] != file_sha256(s.file):
                return None
        return out
    except (RangeprocError, OSError, ValueError, KeyError, TypeError):
        return None


def run_sortie(sortie: Sortie, resume: bool = True) -> Outcome:
    """Run one sortie (module docstring); never raises for the sortie's own failures."""
    from rangeproc.pipeline import run
    from rangeproc.progress import StageClock

    t0 = time.perf_counter()
    where = f"{socket.gethostname()}:{os.getpid()}"
    base = {"id": sortie.id, "config": str(sortie.config), "where": where}
    if resume and (out := fingerprint_matches(sortie.config)) is not None:
        return Outcome(**base, out_dir=str(out), status="skipped",
                       seconds=time.perf_counter() - t0)
    try:
        result = run(sortie.config, clock=StageClock())
    except Exception as raised:  # noqa: BLE001 - every failure is this sortie's outcome
        exc = write_failure(raised, getattr(raised, "filename", None) or "the outputs") or raised
        code = next((c for kind, c in EXIT_OF if isinstance(exc, kind)), 1)
        reason = str(exc) if isinstance(exc, RangeprocError) else \
            f"internal error: {type(exc).__name__}: {exc}"
        return Outcome(**base, out_dir="", status="failed",
                       reason=" ".join(reason.split()), exit_code=code,
                       seconds=time.perf_counter() - t0)
    return Outcome(**base, out_dir=str(result.out_dir), status="done",
                   seconds=time.perf_counter() - t0)
