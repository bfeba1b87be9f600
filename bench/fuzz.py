"""Fuzz campaign of ``rangeproc run`` (``make fuzz``): thousands of mutated cases, one table.

Runs the hypothesis fuzz test (``tests/fuzz``) in parallel pytest processes, each with its own
seed, ``RANGEPROC_FUZZ_EXAMPLES`` = its share of the cases and ``RANGEPROC_FUZZ_RECORD`` = its
own JSON-lines file (record mode: nothing is asserted, every case is recorded and the campaign
goes on). Then prints, per mutation family, the count of each outcome, the totals, the largest
peak memory and the longest run with their cases, and every bad case (description and first
stderr line). Exit status 1 when any case is bad (or a worker failed), else 0.

Usage: ``python bench/fuzz.py [--cases 2000] [--seed 1] [--jobs 2] [--timeout 60]
[--mem-mib 3072] [--records DIR]``.
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GOOD = ("ok", "input_error")
BAD = ("traceback", "exit1", "exit3", "exit_other", "timeout", "killed", "bad_message",
       "bad_output", "harness_error")
SHORT = {"input_error": "input_err", "exit_other": "exit_oth", "bad_message": "bad_msg",
         "bad_output": "bad_out", "harness_error": "harness"}
PROGRESS_EVERY_S = 30.0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=int(os.environ.get("FUZZ_CASES", "2000")),
                    help="total cases over all workers (default 2000)")
    ap.add_argument("--seed", type=int, default=1,
                    help="seed of the first worker; worker k uses seed + k (default 1)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel pytest workers (default 2)")
    ap.add_argument("--timeout", type=float, default=60.0, help="per-case limit, s (default 60)")
    ap.add_argument("--mem-mib", type=float, default=3072.0,
                    help="per-case extra address space, MiB (default 3072)")
    ap.add_argument("--records", type=Path, default=None,
                    help="folder for the JSON-lines records and worker logs (default: a new "
                         "temporary folder, kept)")
    return ap.parse_args(argv)


def count_lines(path: Path) -> int:
    """Lines in a file (0 if it does not exist yet)."""
    try:
        with path.open("rb") as fh:
            return sum(1 for _ in fh)
    except OSError:
        return 0


def start_worker(k: int, cases: int, a: argparse.Namespace, records: Path
                 ) -> tuple[subprocess.Popen, Path, Path]:
    """Start pytest worker ``k`` on ``cases`` cases; returns (process, record file, log)."""
    record, log = records / f"worker{k}.jsonl", records / f"worker{k}.log"
    record.unlink(missing_ok=True)
    env = dict(os.environ, RANGEPROC_FUZZ_SEED=str(a.seed + k),
               RANGEPROC_FUZZ_EXAMPLES=str(cases), RANGEPROC_FUZZ_RECORD=str(record),
               RANGEPROC_FUZZ_TIMEOUT=str(a.timeout), RANGEPROC_FUZZ_MEM_MIB=str(a.mem_mib),
               MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "pytest", "tests/fuzz", "-q", "-p", "no:cacheprovider"]
    with log.open("wb") as fh:
        # its own process group, so that stopping the campaign stops its case children too
        proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
    return proc, record, log


def stop_workers(workers: list[tuple[subprocess.Popen, Path, Path]]) -> None:
    """Kill every worker still running, with the case processes it started."""
    for p, _, _ in workers:
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait()


def run_campaign(a: argparse.Namespace, records: Path) -> tuple[list[dict], list[str]]:
    """Run the workers to completion, printing progress; returns (records, worker problems)."""
    shares = [a.cases // a.jobs + (1 if k < a.cases % a.jobs else 0) for k in range(a.jobs)]
    workers = [start_worker(k, n, a, records) for k, n in enumerate(shares) if n > 0]
    started = last = time.monotonic()
    # Ctrl-C or a SIGTERM to this process stops the workers too (they ran on as orphans)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    try:
        while any(p.poll() is None for p, _, _ in workers):
            time.sleep(1.0)
            if time.monotonic() - last >= PROGRESS_EVERY_S:
                last = time.monotonic()
                done = sum(count_lines(r) for _, r, _ in workers)
                print(f"  {done}/{a.cases} cases, {last - started:.0f} s", flush=True)
    finally:
        stop_workers(workers)
    problems = []
    for p, _, log in workers:
        if p.returncode != 0:
            tail = log.read_text(errors="replace").splitlines()[-15:]
            problems.append(f"worker exited {p.returncode} (log {log}):\n    "
                            + "\n    ".join(tail))
    rows = [json.loads(line) for _, r, _ in workers if r.exists()
            for line in r.read_text(encoding="utf-8").splitlines() if line.strip()]
    return rows, problems


def outcome_table(rows: list[dict]) -> str:
    """Per-family counts of each outcome, with totals."""
    kinds = [k for k in GOOD + BAD if k in GOOD or any(r["outcome"] == k for r in rows)]
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for r in rows:
        counts[r["family"]][r["outcome"]] += 1
        counts["TOTAL"][r["outcome"]] += 1
    head = f"{'family':<10}" + "".join(f"{SHORT.get(k, k):>10}" for k in kinds) + f"{'cases':>8}"
    lines = [head, "-" * len(head)]
    for fam in sorted(f for f in counts if f != "TOTAL") + ["TOTAL"]:
        if fam == "TOTAL":
            lines.append("-" * len(head))
        c = counts[fam]
        lines.append(f"{fam:<10}" + "".join(f"{c[k]:>10}" for k in kinds)
                     + f"{sum(c.values()):>8}")
    return "\n".join(lines)


def extremes(rows: list[dict]) -> str:
    """The largest peak memory and the longest run, with their cases, and typical times."""
    top_mem = max(rows, key=lambda r: r["peak_rss_mib"])
    top_time = max(rows, key=lambda r: r["wall_s"])
    lines = [
        f"largest peak RSS: {top_mem['peak_rss_mib']:.0f} MiB (of the forked child; its warmed "
        f"parent had {top_mem['base_rss_mib']:.0f} MiB) [{top_mem['outcome']}]\n    "
        f"{top_mem['description']}",
        f"longest run: {top_time['wall_s']:.1f} s [{top_time['outcome']}]\n    "
        f"{top_time['description']}"]
    for kind in GOOD:
        t = sorted(r["wall_s"] for r in rows if r["outcome"] == kind)
        if t:
            lines.append(f"{kind}: median {t[len(t) // 2]:.2f} s, max {t[-1]:.2f} s per case")
    return "\n".join(lines)


def bad_cases(rows: list[dict]) -> str:
    """Every bad case: outcome, description, first stderr line (or why it is bad)."""
    lines = []
    for r in sorted((r for r in rows if r["outcome"] not in GOOD),
                    key=lambda r: (BAD.index(r["outcome"]) if r["outcome"] in BAD else 99,
                                   r["description"])):
        said = r.get("error_line") or r.get("first_line") or ""
        why = f" [{r['detail']}]" if r.get("detail") else ""
        lines.append(f"- {r['outcome']}{why}: {r['description']}\n    stderr: {said[:300]}")
    return "\n".join(lines)


def report(rows: list[dict], problems: list[str], elapsed: float, a: argparse.Namespace,
           records: Path) -> bool:
    """Print the campaign's tables; True when it is clean."""
    n_bad = sum(r["outcome"] not in GOOD for r in rows)
    distinct = len({r["description"] for r in rows})
    print(f"\nfuzz campaign: {len(rows)} cases run ({distinct} distinct mutations) of "
          f"{a.cases} asked, {a.jobs} workers, seeds {a.seed}..{a.seed + a.jobs - 1}, "
          f"{elapsed:.0f} s; limits {a.timeout:g} s and {a.mem_mib:g} MiB per case")
    print(f"records: {records}\n")
    if rows:
        print(outcome_table(rows) + "\n")
        print(extremes(rows) + "\n")
    if n_bad:
        print(f"{n_bad} bad cases:\n" + bad_cases(rows))
    for p in problems:
        print(p)
    clean = bool(rows) and not n_bad and not problems
    print("\nresult: " + ("clean: every case exit 0 with valid outputs or exit 2 with one line"
                          if clean else "NOT clean"))
    return clean


def main(argv: list[str] | None = None) -> None:
    a = parse_args(argv)
    records = a.records or Path(tempfile.mkdtemp(prefix="rangeproc-fuzz-"))
    records.mkdir(parents=True, exist_ok=True)
    print(f"fuzz: {a.cases} cases in {a.jobs} workers (records in {records})", flush=True)
    started = time.monotonic()
    rows, problems = run_campaign(a, records)
    clean = report(rows, problems, time.monotonic() - started, a, records)
    sys.exit(0 if clean else 1)


if __name__ == "__main__":
    main()
