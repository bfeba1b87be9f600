"""Where one pipeline run's time and memory go: seconds and resident memory per stage and per
part of the fuse stage, for ``bench.py``'s timed subprocess.

Stages come from the run's :class:`rangeproc.progress.StageClock` (a display that records
their boundaries); the fuse stage's parts are functions wrapped by name where the fusion
calls them (:data:`FUSE_PARTS`). At every boundary the process's resident set (``VmRSS``) is
read, and its peak since the last boundary (``VmHWM``, then reset through
``/proc/self/clear_refs``, Linux >= 4.0) is credited to every stage and part open at that
moment: each gets its exact peak, not a sample of it. Without ``/proc`` (not Linux) only the
seconds are recorded.

Parts run inside the objects' threads when a run fuses several objects at once: their seconds
are then thread-seconds summed over objects and their memory is that of the whole process.
"""
from __future__ import annotations

import functools
import importlib
import threading
import time
from pathlib import Path

#: (module, function) -> part of the fusion, shown under the stage that called it (the
#: associate stage fuses rows too). Wrapped in the module that calls it, so each call is
#: counted once; a label that starts with spaces is a part inside the part above it (counted
#: in both; the stage's remainder, "other", is what its top-level parts leave). One label may
#: be wrapped in several modules (the first pass is run from ``centralised``, the refinement
#: passes from ``refinement``): its calls and seconds add up. The forward filters of the
#: process-noise search run side by side in threads: their seconds are thread-seconds.
FUSE_PARTS = {
    ("rangeproc.stages.fuse", "merge"): "merge rows",
    ("rangeproc.fusion.centralised", "lead_in_rows"): "lead-in rows",
    ("rangeproc.fusion.centralised", "difference_sigma"): "noise (first estimate)",
    ("rangeproc.fusion.centralised", "thinned_pass_rows"): "thinning",
    ("rangeproc.fusion.centralised", "initial_state"): "start state",
    ("rangeproc.fusion.centralised", "searched_q"): "process noise search",
    ("rangeproc.fusion.refinement", "searched_q"): "process noise search",
    ("rangeproc.estimation.tuning", "run_filter"): "  forward filters (q candidates)",
    ("rangeproc.fusion.centralised", "run_pass"): "filter + smoother pass",
    ("rangeproc.fusion.refinement", "run_pass"): "filter + smoother pass",
    ("rangeproc.fusion.passes", "run_filter"): "  forward filter",
    ("rangeproc.fusion.passes", "rts_smooth"): "  RTS smoother",
    ("rangeproc.fusion.passes", "imm_smooth"): "  IMM smoother",
    ("rangeproc.fusion.passes", "smoothed_residuals"): "  residuals",
    ("rangeproc.fusion.passes", "component_use"): "  gate use",
    ("rangeproc.fusion.centralised", "unsupported_time"): "white or discounted first pass",
    ("rangeproc.fusion.centralised", "correlation_factors"): "white or discounted first pass",
    ("rangeproc.fusion.centralised", "imm_start"): "IMM start",
    ("rangeproc.fusion.refinement", "refraction_corrections"): "refraction",
    ("rangeproc.fusion.refinement", "register"): "registration",
    ("rangeproc.fusion.refinement", "apply_increments"): "corrected rows",
    ("rangeproc.fusion.refinement", "corrected_residuals"): "corrected residuals",
    ("rangeproc.fusion.refinement", "row_shift"): "corrected residuals",
    ("rangeproc.fusion.refinement", "residual_sigma"): "noise (from residuals)",
    ("rangeproc.fusion.refinement", "local_process_noise"): "local process noise",
    ("rangeproc.fusion.refinement", "carry_to_every_row"): "thinned pass to every row",
    ("rangeproc.fusion.centralised", "calibration_covariance"): "calibration covariance",
    ("rangeproc.fusion.centralised", "lockout_time"): "lock-out check",
    ("rangeproc.fusion.centralised", "_concat"): "spans joined",
}

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


def rss_and_peak() -> tuple[int, int] | None:
    """(VmRSS, VmHWM) in bytes, or None where /proc does not give them."""
    try:
        fields = {}
        for line in _STATUS.read_text().splitlines():
            if line.startswith(("VmRSS:", "VmHWM:")):
                fields[line[:5]] = int(line.split()[1]) * 1024
        return fields["VmRSS"], fields["VmHWM"]
    except (OSError, KeyError, ValueError):
        return None


class Breakdown:
    """Seconds, calls and memory (RSS at entry, peak, RSS at exit) per stage and fuse part."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.open: dict[str, int] = {}                   # label -> open count
        self.order: list[str] = []
        self.rec: dict[str, dict] = {}
        self.memory = rss_and_peak() is not None and self._reset_peak()
        self.stage = ""                                  # the stage open now
        self.run_peak = 0                                # peak RSS over every boundary

    @staticmethod
    def _reset_peak() -> bool:
        try:
            _CLEAR_REFS.write_text("5")
            return True
        except OSError:
            return False

    def _boundary(self) -> int | None:
        """Credit the peak since the last boundary to the open labels; RSS now (bytes)."""
        if not self.memory:
            return None
        rss, peak = rss_and_peak()
        self.run_peak = max(self.run_peak, peak)
        for label in self.open:
            r = self.rec[label]
            r["peak_rss"] = max(r["peak_rss"], peak)
        self._reset_peak()
        return rss

    def enter(self, label: str) -> float:
        with self.lock:
            rss = self._boundary()
            r = self.rec.setdefault(label, {"seconds": 0.0, "calls": 0, "rss_in": rss,
                                            "peak_rss": rss or 0, "rss_out": rss})
            if label not in self.order:
                self.order.append(label)
            r["calls"] += 1
            self.open[label] = self.open.get(label, 0) + 1
        return time.perf_counter()

    def leave(self, label: str, t0: float) -> None:
        dt = time.perf_counter() - t0
        with self.lock:
            rss = self._boundary()
            r = self.rec[label]
            r["seconds"] += dt
            r["rss_out"] = rss
            self.open[label] -= 1
            if not self.open[label]:
                del self.open[label]

    def peak_rss(self) -> int | None:
        """The process's peak RSS (bytes) since this breakdown started (its resets of
        ``VmHWM`` hide that peak from ``VmHWM`` alone); None without ``/proc``."""
        if not self.memory:
            return None
        return max(self.run_peak, rss_and_peak()[1])

    # -- a StageClock display ------------------------------------------------------------
    def start(self, stage: str, total: int) -> None:
        self.stage = stage
        self._stage_t0 = self.enter(stage)

    def advance(self, stage: str, n: int = 1, note: str = "") -> None:
        pass

    def finish(self, stage: str, seconds: float) -> None:
        self.leave(stage, self._stage_t0)
        self.stage = ""

    # -- the fuse stage's parts ----------------------------------------------------------
    def wrap_fuse_parts(self) -> None:
        """Wrap :data:`FUSE_PARTS` where they are called (names no longer there are skipped:
        their time stays in the stage's remainder)."""
        for (module, name), label in FUSE_PARTS.items():
            mod = importlib.import_module(module)
            fn = getattr(mod, name, None)
            if fn is not None:
                setattr(mod, name, self._wrapped(fn, label))

    def _wrapped(self, fn, part: str):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            label = f"{self.stage}: {part}"        # the stage that called it (association
            t0 = self.enter(label)                 # fuses objects' rows too)
            try:
                return fn(*args, **kwargs)
            finally:
                self.leave(label, t0)
        return timed

    def records(self) -> list[dict]:
        """One dict per label in first-entered order: label, seconds, calls, and when memory
        is known rss_in / peak_rss / rss_out bytes."""
        out = []
        for label in self.order:
            r = dict(self.rec[label], label=label)
            if not self.memory:
                for key in ("rss_in", "peak_rss", "rss_out"):
                    r.pop(key, None)
            out.append(r)
        return out


def remainders(records: list[dict]) -> dict[str, float]:
    """Seconds of each stage with parts that its top-level parts leave unexplained
    ("other"; stage label -> s)."""
    out = {}
    for st in (r for r in records if ": " not in r["label"]):
        parts = [r for r in records if r["label"].startswith(st["label"] + ": ")]
        if parts:
            out[st["label"]] = st["seconds"] - sum(
                r["seconds"] for r in parts if not r["label"].split(": ", 1)[1].startswith(" "))
    return out


def print_breakdown(records: list[dict], stages_total: float) -> None:
    """The table: seconds (share of the run's stages) and RSS in -> peak -> out (MiB) per
    stage, its parts under it and what its parts leave unexplained ("other")."""
    mib = 2 ** 20
    has_mem = bool(records) and "peak_rss" in records[0]
    print(f"{'stage / part':<38}{'calls':>6}{'seconds':>9}{'share':>7}"
          + (f"{'RSS in':>9}{'peak':>8}{'out':>8}  MiB" if has_mem else ""))

    def line(label: str, calls: str, seconds: float, r: dict | None) -> None:
        share = seconds / stages_total if stages_total else 0.0
        text = f"{label:<38}{calls:>6}{seconds:9.2f}{share:7.0%}"
        if has_mem and r is not None:
            text += f"{r['rss_in'] / mib:9.0f}{r['peak_rss'] / mib:8.0f}{r['rss_out'] / mib:8.0f}"
        print(text)

    stages = [r for r in records if ": " not in r["label"]]
    for st in stages:
        line(st["label"], str(st["calls"]), st["seconds"], st)
        parts = [r for r in records if r["label"].startswith(st["label"] + ": ")]
        for r in parts:
            line("  " + r["label"].split(": ", 1)[1], str(r["calls"]), r["seconds"], r)
        if parts:
            line("  other", "", remainders(records)[st["label"]], None)
