"""Run one fuzz case of ``rangeproc run`` in a forked child and classify its outcome.

The parent first runs the base scenario once in-process (:func:`warm_up`) so that numba
kernels, pyarrow and matplotlib are loaded; each case then runs in a child forked from it,
which starts in milliseconds. The child

* redirects file descriptors 1 and 2 to temporary files (C-level output is captured too) and
  rebinds ``sys.stdout``/``sys.stderr``, the root logger and Python's warning display to them,
  as in a fresh ``rangeproc`` process;
* limits its address space (``RLIMIT_AS``) to its current size plus the case's memory limit,
  its file writes (``RLIMIT_FSIZE``) to :data:`FILE_LIMIT_BYTES` and disables core files, so a
  runaway allocation or write fails instead of taking the machine;
* calls ``rangeproc.cli.main(["run", "--quiet", CONFIG], standalone_mode=True)``, catches the
  ``SystemExit`` (any other exception is printed as a traceback, exit 1) and leaves with
  ``os._exit``: it never returns into pytest or hypothesis.

The parent polls ``os.wait4`` against a deadline, SIGKILLs the child on timeout, and takes the
child's peak RSS and CPU time from its rusage. Outcome kinds: ``ok`` and ``input_error`` are
good; ``traceback``, ``exit1``, ``exit3``, ``exit_other``, ``timeout``, ``killed``,
``bad_message`` and ``bad_output`` are bugs (see :func:`classify`).
"""
from __future__ import annotations

import gc
import json
import logging
import math
import os
import resource
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

GOOD = ("ok", "input_error")
BAD = ("traceback", "exit1", "exit3", "exit_other", "timeout", "killed", "bad_message",
       "bad_output", "harness_error")
FUSED_COLUMNS = ("target_id", "time", "lat", "lon", "height", "e", "n", "u", "ve", "vn", "vu",
                 "ae", "an", "au", "sigma_e", "sigma_n", "sigma_u", "n_sensors")
MAX_FUSED_BYTES = 50 * 2**20      # fused.parquet must stay below this (bytes)
BOUND_SPAN_S = 120.0              # output rows <= rate_hz * BOUND_SPAN_S * (input rows + 10)
FILE_LIMIT_BYTES = 2**30          # largest file a case may write (RLIMIT_FSIZE)
STDERR_KEEP = 1 << 20             # bytes of the child's stderr kept
ERROR_PREFIX = "rangeproc: error: "
LOG_PREFIXES = ("rangeproc: WARNING:", "rangeproc: INFO:")
STAGING_PREFIX = ".rangeproc-staging-"
PARQUET_SUFFIXES = (".parquet", ".pq")


@dataclass(frozen=True)
class Outcome:
    """The result of one case.

    ``kind``: one of :data:`GOOD` or :data:`BAD`; ``exit_code``: the child's exit status (None
    when it died by a signal); ``signal``: the killing signal number or None; ``wall_s``,
    ``cpu_s``: wall-clock and user+system CPU seconds of the child; ``peak_rss_mib``: the
    child's peak resident set (MiB, including what it shares with the parent);
    ``base_rss_mib``: the parent's resident set when it forked (MiB); ``stderr``: the child's
    stderr text; ``detail``: why a case is classified as it is (empty for ``ok``).
    """

    kind: str
    exit_code: int | None
    signal: int | None
    wall_s: float
    cpu_s: float
    peak_rss_mib: float
    base_rss_mib: float
    stderr: str
    detail: str = ""

    @property
    def good(self) -> bool:
        return self.kind in GOOD

    @property
    def first_line(self) -> str:
        """The first non-empty stderr line ('' if none)."""
        return next((x for x in self.stderr.splitlines() if x.strip()), "")

    @property
    def error_line(self) -> str:
        """The first ``rangeproc: error:`` line, else the first stderr line."""
        return next((x for x in self.stderr.splitlines() if x.startswith(ERROR_PREFIX)),
                    self.first_line)

    def explain(self) -> str:
        """Multi-line text for assertion messages."""
        how = f"signal {self.signal}" if self.signal is not None else f"exit {self.exit_code}"
        return (f"outcome {self.kind} ({how}, {self.wall_s:.2f} s, peak RSS "
                f"{self.peak_rss_mib:.0f} MiB){': ' + self.detail if self.detail else ''}\n"
                f"--- stderr ---\n{self.stderr[:4000]}")


# ============================================================================================
# Child side
# ============================================================================================

def _vm_size_bytes() -> int:
    """This process's virtual memory size (VmSize in /proc/self/status), bytes."""
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _rss_mib() -> float:
    """This process's resident set (VmRSS), MiB."""
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def _show_warning(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
                  line: str | None = None) -> None:
    """Python's warning display, to the current ``sys.stderr``."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


def _fresh_process_io(stdout_path: str, stderr_path: str) -> None:
    """Make the child's output look like a fresh process writing to files: fds 1 and 2 on the
    capture files, new ``sys.stdout``/``sys.stderr``, no logging handlers (the CLI installs
    its own), Python's default warning filters and display."""
    for fd, path in ((1, stdout_path), (2, stderr_path)):
        target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(target, fd)
        os.close(target)
    sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
    sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False,
                      buffering=1)
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    root.setLevel(logging.WARNING)
    warnings.resetwarnings()
    for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning,
                     ResourceWarning):
        warnings.simplefilter("ignore", category)
    warnings.showwarning = _show_warning


def _limit_resources(mem_limit_bytes: int) -> None:
    """Address space = current size + ``mem_limit_bytes``; file size cap; no core files."""
    limit = _vm_size_bytes() + mem_limit_bytes
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT_BYTES, FILE_LIMIT_BYTES))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def _exit_status(exc: SystemExit) -> int:
    """The process exit status Python gives a ``SystemExit``."""
    if exc.code is None:
        return 0
    if isinstance(exc.code, int):
        return exc.code & 0xFF
    sys.stderr.write(f"{exc.code}\n")
    return 1


def _child(config: Path, stdout_path: str, stderr_path: str, mem_limit_bytes: int) -> NoReturn:
    """Body of the forked child: run the CLI once, then ``os._exit`` with its status."""
    code = 70
    try:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        sys.settrace(None)      # e.g. hypothesis' explain phase traces the parent
        sys.setprofile(None)
        _fresh_process_io(stdout_path, stderr_path)
        _limit_resources(mem_limit_bytes)
        from rangeproc.cli import main

        try:
            main(["run", "--quiet", str(config)], standalone_mode=True)
            code = 0
        except SystemExit as exc:
            code = _exit_status(exc)
        except BaseException:  # noqa: B036 - report anything, as the interpreter would
            traceback.print_exc()
            code = 1
    except BaseException:  # noqa: B036 - set-up failed: say so on the captured stderr
        try:
            os.write(2, traceback.format_exc().encode())
        finally:
            code = 70
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


# ============================================================================================
# Parent side
# ============================================================================================

def warm_up(config: Path) -> int:
    """Run ``rangeproc run --quiet CONFIG`` in this process (loads numba kernels, pyarrow,
    matplotlib for the children to inherit); returns its exit status."""
    from rangeproc.cli import main

    try:
        main(["run", "--quiet", str(config)], standalone_mode=True)
    except SystemExit as exc:
        return 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 1
    return 0


@dataclass(frozen=True)
class CaseFacts:
    """What the parent knows about a case before running it: output folder, rate, the names a
    message may use for the case's files and the number of input data rows."""

    out_dir: Path
    rate_hz: float
    names: frozenset[str]
    n_input_rows: int


def _count_rows(path: Path) -> int:
    """Data rows of a sensor file, generously: Parquet metadata, else line count."""
    if path.suffix.lower() in PARQUET_SUFFIXES:
        try:
            return pq.ParquetFile(path).metadata.num_rows
        except Exception:  # noqa: BLE001 - an unreadable file counts as its byte lines
            pass
    data = path.read_bytes()
    return data.count(b"\n") + data.count(b"\r") + 1


def case_facts(config: Path) -> CaseFacts:
    """Output folder, rate and file names from the (possibly broken) config, and input rows
    over the regular files beside it. Defaults when the config cannot be read: 'out', 10 Hz."""
    folder = config.parent
    out_name: Any = "out"
    rate: Any = 10.0
    names = {config.name}
    try:
        doc = tomllib.loads(config.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError, OSError):
        doc = {}
    output = doc.get("output", {}) if isinstance(doc, dict) else {}
    if isinstance(output, dict):
        out_name, rate = output.get("dir", out_name), output.get("rate_hz", rate)
    sensors = doc.get("sensors", []) if isinstance(doc, dict) else []
    for s in sensors if isinstance(sensors, list) else []:
        f = s.get("file") if isinstance(s, dict) else None
        if isinstance(f, str) and f.strip():
            names.add(Path(f).name)
            names.add((folder / f).resolve().name)
    out_dir = (folder / (out_name if isinstance(out_name, str) and out_name.strip()
                         else "out")).resolve()
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not \
            math.isfinite(rate) or rate <= 0:
        rate = 10.0
    n_rows = 0
    for p in folder.iterdir():
        if p.is_file() and not p.is_symlink() and p.name != config.name:
            names.add(p.name)
            n_rows += _count_rows(p)
    names -= {"", ".", ".."}
    return CaseFacts(out_dir, float(rate), frozenset(names), n_rows)


def snapshot(path: Path) -> Any:
    """What is at ``path``: None (nothing), ('file', size, mtime_ns), ('link', target) or a
    dict of relative names to such entries for a folder (recursively)."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    if os.path.islink(path):
        return ("link", os.readlink(path))
    if not os.path.isdir(path):
        return ("file", st.st_size, st.st_mtime_ns)
    return {p.name: snapshot(p) for p in sorted(path.iterdir())}


def check_outputs(facts: CaseFacts) -> list[str]:
    """Problems with the outputs of a successful run (data contract section 4)."""
    out = facts.out_dir
    fused, summary, report = out / "fused.parquet", out / "summary.json", out / "report"
    problems = []
    if out.is_dir():
        problems += [f"staging folder left: {p.name}" for p in out.iterdir()
                     if p.name.startswith(STAGING_PREFIX)]
    if not fused.is_file():
        return problems + ["no fused.parquet"]
    size = fused.stat().st_size
    if size >= MAX_FUSED_BYTES:
        return problems + [f"fused.parquet is {size / 2**20:.0f} MiB"]
    problems += _check_fused(pq.read_table(fused), facts)
    try:
        doc = json.loads(summary.read_text(encoding="utf-8"))
        missing = [k for k in ("sensors", "targets") if not isinstance(doc, dict) or k not in doc]
        problems += [f"summary.json has no '{k}'" for k in missing]
    except (OSError, ValueError) as exc:
        problems.append(f"summary.json unreadable: {exc}")
    pngs = [p for p in report.glob("*.png") if p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"] \
        if report.is_dir() else []
    if not pngs:
        problems.append("report/ holds no PNG")
    return problems


def _check_fused(table: pa.Table, facts: CaseFacts) -> list[str]:
    """Columns, order, finiteness, positive sigmas and row bound of fused.parquet."""
    missing = [c for c in FUSED_COLUMNS if c not in table.column_names]
    if missing:
        return [f"fused.parquet lacks columns {missing}"]
    problems = []
    bound = facts.rate_hz * BOUND_SPAN_S * (facts.n_input_rows + 10)
    if table.num_rows > bound:
        problems.append(f"fused.parquet has {table.num_rows} rows > bound {bound:.0f}")
    for name in table.column_names:
        col = table.column(name)
        if col.null_count and name in FUSED_COLUMNS:
            problems.append(f"column '{name}' has {col.null_count} nulls")
        if pa.types.is_floating(col.type):
            v = col.to_numpy()
            if not np.isfinite(v).all():
                problems.append(f"column '{name}' has non-finite values")
    for name in ("sigma_e", "sigma_n", "sigma_u"):
        v = table.column(name).to_numpy()
        if not (v > 0).all():
            problems.append(f"column '{name}' has values <= 0")
    ids = [str(x) for x in table.column("target_id").to_pylist()]
    t = table.column("time").to_numpy()
    if any(a > b for a, b in zip(ids, ids[1:])):
        problems.append("not sorted by target_id")
    same = np.array([a == b for a, b in zip(ids, ids[1:])], dtype=bool)
    if len(t) > 1 and not (np.diff(t)[same] > 0).all():
        problems.append("times not strictly increasing within a target")
    return problems


def _check_message(stderr: str, names: Iterable[str]) -> str:
    """'' when stderr is one ``rangeproc: error:`` line naming a file of the case, plus only
    log lines; otherwise what is wrong."""
    lines = [x for x in stderr.splitlines() if x.strip()]
    errors = [x for x in lines if x.startswith(ERROR_PREFIX)]
    others = [x for x in lines if not x.startswith(ERROR_PREFIX)
              and not x.startswith(LOG_PREFIXES)]
    if len(errors) != 1:
        return f"{len(errors)} error lines"
    if others:
        return f"stray stderr line: {others[0][:200]!r}"
    if not any(n in errors[0] for n in names):
        return "the error line names no file of the case"
    return ""


def classify(exit_code: int | None, sig: int | None, timed_out: bool, stderr: str,
             facts: CaseFacts, before: Any) -> tuple[str, str]:
    """(kind, detail) of a finished case; ``before`` is the output folder's snapshot."""
    if timed_out:
        return "timeout", "killed at the deadline"
    if sig is not None:
        return "killed", f"signal {signal.Signals(sig).name}"
    if "Traceback (most recent call last)" in stderr:
        return "traceback", ""
    if exit_code == 0:
        problems = check_outputs(facts)
        return ("bad_output", "; ".join(problems)) if problems else ("ok", "")
    after = snapshot(facts.out_dir)
    if after != before and not (before is None and after == {}):
        return "bad_output", f"exit {exit_code} changed the output folder"
    if exit_code == 2:
        problem = _check_message(stderr, facts.names)
        return ("bad_message", problem) if problem else ("input_error", "")
    kind = {1: "exit1", 3: "exit3"}.get(exit_code, "exit_other")
    return kind, f"exit {exit_code}"


def _wait(pid: int, deadline: float) -> tuple[int, Any, bool]:
    """Reap ``pid``, SIGKILLing it at ``deadline`` (monotonic s): (status, rusage, timed out)."""
    pause = 0.002
    while True:
        wpid, status, usage = os.wait4(pid, os.WNOHANG)
        if wpid == pid:
            return status, usage, False
        if time.monotonic() >= deadline:
            os.kill(pid, signal.SIGKILL)
            _, status, usage = os.wait4(pid, 0)
            return status, usage, True
        time.sleep(pause)
        pause = min(0.02, pause * 1.5)


def run_case(config_path: Path, timeout_s: float, mem_limit_bytes: int) -> Outcome:
    """Run ``rangeproc run --quiet CONFIG`` in a forked child and classify the result.

    ``timeout_s``: wall-clock limit (s), after which the child is SIGKILLed; ``mem_limit_bytes``:
    address space the child may add to what it inherits. The case folder is the config's
    folder; its output folder is taken from the config (default 'out').
    """
    config_path = Path(config_path).resolve()
    facts = case_facts(config_path)
    before = snapshot(facts.out_dir)
    with tempfile.TemporaryDirectory(prefix="rangeproc-fuzz-io-") as io_dir:
        out_path, err_path = os.path.join(io_dir, "stdout"), os.path.join(io_dir, "stderr")
        sys.stdout.flush()
        sys.stderr.flush()
        base_rss = _rss_mib()
        started = time.monotonic()
        gc.freeze()   # the child's collections skip (and so do not copy) the inherited heap
        pid = os.fork()
        if pid == 0:
            _child(config_path, out_path, err_path, mem_limit_bytes)
        gc.unfreeze()
        status, usage, timed_out = _wait(pid, started + timeout_s)
        wall = time.monotonic() - started
        try:
            with open(err_path, "rb") as fh:
                stderr = fh.read(STDERR_KEEP).decode("utf-8", errors="backslashreplace")
        except OSError:
            stderr = ""
    code = os.waitstatus_to_exitcode(status)
    exit_code, sig = (code, None) if code >= 0 else (None, -code)
    kind, detail = classify(exit_code, sig, timed_out, stderr, facts, before)
    return Outcome(kind=kind, exit_code=exit_code, signal=sig, wall_s=wall,
                   cpu_s=usage.ru_utime + usage.ru_stime, peak_rss_mib=usage.ru_maxrss / 1024.0,
                   base_rss_mib=base_rss, stderr=stderr, detail=detail)
