"""Where and when a measurement was taken: the ``meta`` block every bench's JSON carries.

``make accuracy``, ``make registration``, ``make multi``, ``make autoferry`` and ``make bench``
write their results to ``docs/measurements/<name>.json`` (committed: they are the
measurements the documentation's validation pages are generated from, ``docs/hooks/
validation.py``). Each file holds a ``meta`` block made here:

* ``machine``: the CPU model (``/proc/cpuinfo``'s ``model name``, else ``platform.processor``),
  logical cores and those this process may use, memory, the operating system, the load
  average (1, 5, 15 min) when the measurement ended (other work on the machine slows a
  timing), Python, numpy and numba versions (and any peer library asked for, e.g. FilterPy
  and Stone Soup);
* ``date``: UTC, ISO 8601 to the second, when the measurement finished;
* ``git_commit``: the checkout's short hash, ``+dirty`` when it had uncommitted changes;
* ``command``: the command line that produced the file (script path relative to the
  repository and its arguments).

The benches whose JSON used to be a bare list of rows (accuracy, registration, several
objects) now write ``{"meta": ..., "rows": [...]}``; :func:`rows` reads either form.
"""
from __future__ import annotations

import datetime as dt
import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def cpu_model() -> str:
    """The CPU's model name (Linux: ``/proc/cpuinfo``), else what ``platform`` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "Hardware", "cpu model") and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def memory_gib() -> float | None:
    """Total memory (GiB) from ``/proc/meminfo``; None where it cannot be read."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return round(int(line.split()[1]) / 2**20, 1)
    except (OSError, ValueError, IndexError):
        pass
    return None


def os_name() -> str:
    """The distribution's name (``/etc/os-release``) and kernel, else ``platform.platform``."""
    try:
        info = dict(line.split("=", 1) for line in
                    Path("/etc/os-release").read_text().splitlines() if "=" in line)
        pretty = info.get("PRETTY_NAME", "").strip().strip('"')
        if pretty:
            return f"{pretty}, {platform.system()} {platform.release()}"
    except OSError:
        pass
    return platform.platform()


def git_commit() -> str | None:
    """Short hash of the checkout, ``+dirty`` with uncommitted changes; None outside git."""
    git = ["git", "-C", str(ROOT)]
    try:
        commit = subprocess.run(git + ["rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
        dirty = subprocess.run(git + ["status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return commit + ("+dirty" if dirty else "")


def _version(module: str) -> str | None:
    try:
        return str(__import__(module).__version__)
    except Exception:                                # not installed, or no __version__
        return None


def machine(peers: tuple[str, ...] = ()) -> dict[str, Any]:
    """The machine and software the measurement ran on."""
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count()
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        load = None
    info: dict[str, Any] = {
        "cpu": cpu_model(), "cores": os.cpu_count(), "cores_usable": usable,
        "memory_gib": memory_gib(), "os": os_name(), "python": platform.python_version(),
        "load_average": load}
    for module in ("numpy", "numba", *peers):
        info[module] = _version(module)
    return info


def command(argv: list[str] | None = None) -> str:
    """The command line: the script's path relative to the repository, then its arguments."""
    argv = list(sys.argv if argv is None else argv)
    if argv:
        script = Path(argv[0]).resolve()
        try:
            argv[0] = str(script.relative_to(ROOT))
        except ValueError:
            pass
    return " ".join(["python", *argv])


def run_meta(argv: list[str] | None = None, peers: tuple[str, ...] = ()) -> dict[str, Any]:
    """The ``meta`` block: machine, UTC date, git commit and command line."""
    return {"machine": machine(peers),
            "date": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
            "git_commit": git_commit(), "command": command(argv)}


def with_meta(rows: list[Any], argv: list[str] | None = None,
              peers: tuple[str, ...] = ()) -> dict[str, Any]:
    """``{"meta": ..., "rows": rows}``: a list-valued bench result with its meta block."""
    return {"meta": run_meta(argv, peers), "rows": rows}


def rows(data: Any) -> list[Any]:
    """The rows of a bench result in either form: a bare list (files written before the meta
    block) or ``{"meta": ..., "rows": [...]}``."""
    return data["rows"] if isinstance(data, dict) else data


def add_result_arguments(ap: Any, default_out: Path) -> None:
    """``--out`` (the result file, default ``default_out``) and ``--summarise JSON`` (print
    the tables of a result written before, run nothing) on the argparse parser ``ap``."""
    ap.add_argument("--out", type=Path, default=default_out)
    ap.add_argument("--summarise", type=Path, metavar="JSON",
                    help="print the tables of a result written before, run nothing")


def summarised(path: Path | None, print_tables: Any) -> bool:
    """True after printing (``print_tables(rows)``) the rows of the result at ``path`` given
    by ``--summarise``; False when it was not given."""
    if path is None:
        return False
    print_tables(rows(json.loads(path.read_text())))
    return True

