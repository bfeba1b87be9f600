"""Campaign benchmark: N sample-sized sorties, serially and on a local Dask cluster.

Builds ``bench/data/campaign_<N>/`` (N copies of the bundled sample sortie's config, each
writing its own output folder, all reading the one copy of ``sample_data``), then times:

1. **serial, one process**: ``pipeline.run`` on every sortie in turn in this process (the
   compiled kernels loaded once, as a cluster's workers keep them);
2. **serial, a process per sortie**: ``rangeproc run`` in a shell-style loop (each process
   pays its imports and kernel loading);
3. ``rangeproc campaign --force`` (``campaign.run_campaign``) on a ``LocalCluster`` with 1 and
   with 2 worker processes, the cluster's start included;
4. Dask's overhead per task: 400 no-op tasks through a 2-worker ``LocalCluster``.

Prints the scaling (2 workers at most 0.6x the serial time, at least 1.7x the throughput of
1 worker), a scaling model from the measured per-sortie cost, the cluster's fixed cost and the
contention, and what a 16-worker cluster would need; writes ``bench/campaign.json``.

    python bench/campaign.py [--sorties 20] [--skip-process-loop]
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from rangeproc.parallel import usable_cores

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = ROOT / "sample_data"
TARGET_RATIO = 0.6
#: Throughput of 2 workers against 1 the campaign must reach on a 2-core machine.
TARGET_THROUGHPUT_2 = 1.7


def build(n: int) -> Path:
    """``bench/data/campaign_<n>/``: flights/s01.toml ... and campaign.toml."""
    folder = ROOT / "bench" / "data" / f"campaign_{n}"
    shutil.rmtree(folder, ignore_errors=True)
    (folder / "flights").mkdir(parents=True)
    text = (SAMPLE / "scenario.toml").read_text()
    for k in range(1, n + 1):
        body = text.replace('dir = "out"', f'dir = "../out/s{k:02d}"')
        body = body.replace('file = "', f'file = "{SAMPLE.as_posix()}/')
        (folder / "flights" / f"s{k:02d}.toml").write_text(body)
    (folder / "campaign.toml").write_text(
        '[output]\ndir = "records"\n\n' + "".join(
            f'[[sorties]]\nconfig = "flights/s{k:02d}.toml"\n\n' for k in range(1, n + 1)))
    return folder


def cpu_seconds() -> float:
    """CPU time (s) of this process and its finished children (the report's forked child)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def serial_in_process(folder: Path) -> tuple[float, list[float], float]:
    """(wall s, per-sortie wall s, CPU s) of ``pipeline.run`` on every sortie in turn."""
    from rangeproc.pipeline import run

    run(folder / "flights" / "s01.toml")                     # warm: kernels loaded
    each = []
    t0, c0 = time.perf_counter(), cpu_seconds()
    for cfg in sorted((folder / "flights").glob("*.toml")):
        t1 = time.perf_counter()
        run(cfg)
        each.append(time.perf_counter() - t1)
    return time.perf_counter() - t0, each, cpu_seconds() - c0


def serial_processes(folder: Path) -> float:
    exe = Path(sys.executable).with_name("rangeproc")
    t0 = time.perf_counter()
    for cfg in sorted((folder / "flights").glob("*.toml")):
        subprocess.run([str(exe), "run", "--quiet", str(cfg)], check=True)
    return time.perf_counter() - t0


def campaign(folder: Path, workers: int) -> tuple[float, list[float]]:
    from rangeproc.campaign import load_campaign, run_campaign

    t0 = time.perf_counter()
    result = run_campaign(load_campaign(folder / "campaign.toml"), workers=workers,
                          resume=False)
    wall = time.perf_counter() - t0
    assert result.counts()["done"] == len(result.outcomes), result.counts()
    return wall, [o.seconds for o in result.outcomes]


def task_overhead(n: int = 400) -> tuple[float, float]:
    """(s per no-op task through a 2-worker LocalCluster, cluster start s)."""
    import logging

    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        start = time.perf_counter() - t0
        client.gather(client.map(abs, range(50)))             # warm
        t1 = time.perf_counter()
        client.gather([client.submit(abs, -k, pure=False) for k in range(n)])
        return (time.perf_counter() - t1) / n, start


def scaling_model(n_sorties: int, one_s: float, two_s: float, c1: float, c2: float) -> dict:
    """The campaign's time on n workers, ``T(n) = F + ceil(N / n) c k(n)``, from the measured
    1- and 2-worker campaigns: ``c`` the per-sortie cost alone (``c1``), ``k(2) = c2 / c1``
    the contention of two sorties on this machine's cores, ``F`` the fixed cost (what the
    1-worker campaign took beyond its sorties). Projects 16 workers on 16 cores at the
    contention ``k(2)`` (one worker per core, as here), for these N sorties and for 16 N."""
    fixed = max(0.0, one_s - n_sorties * c1)
    k2 = c2 / c1

    def t(n: int, n_s: int, k: float) -> float:
        return fixed + -(-n_s // n) * c1 * k

    t16 = t(16, n_sorties, k2)
    t16_big = t(16, 16 * n_sorties, k2)
    return {"c_s": c1, "c2_s": c2, "k2": k2, "fixed_s": fixed, "throughput_2": one_s / two_s,
            "t16_s": t16, "linear_16": t(1, n_sorties, 1.0) / (16 * t16),
            "linear_16_big": t(1, 16 * n_sorties, 1.0) / (16 * t16_big)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sorties", type=int, default=20)
    ap.add_argument("--skip-process-loop", action="store_true",
                    help="leave out the rangeproc-run-per-sortie loop")
    a = ap.parse_args(argv)
    folder = build(a.sorties)
    print(f"campaign bench: {a.sorties} sample-sized sorties in {folder}", flush=True)
    serial, each, serial_cpu = serial_in_process(folder)
    cores = serial_cpu / serial
    print(f"serial, one process:          {serial:6.1f} s ({statistics.median(each):.2f} s "
          f"per sortie, median; {serial_cpu:.1f} CPU s = {cores:.2f} cores busy on average: "
          "the report's two processes and the fuse's threads)", flush=True)
    loop = None if a.skip_process_loop else serial_processes(folder)
    if loop is not None:
        print(f"serial, a process per sortie: {loop:6.1f} s ({loop / a.sorties:.2f} s per "
              "sortie: imports and kernel loading each time)", flush=True)
    one, one_each = campaign(folder, 1)
    print(f"campaign, 1 worker:           {one:6.1f} s", flush=True)
    two, two_each = campaign(folder, 2)
    print(f"campaign, 2 workers:          {two:6.1f} s", flush=True)
    per_task, start = task_overhead()
    ratio = two / serial
    model = scaling_model(a.sorties, one, two, statistics.median(one_each),
                          statistics.median(two_each))
    print(f"Dask: {per_task * 1e3:.2f} ms per task through the scheduler; LocalCluster start "
          f"{start:.1f} s")
    print(f"scaling model T(n) = F + ceil(N / n) * c * k(n): per-sortie cost c = "
          f"{model['c_s']:.2f} s (1 worker), contention k(2) = {model['k2']:.2f} (2 workers on "
          f"{usable_cores()} cores), fixed cost F = {model['fixed_s']:.1f} s (cluster start, "
          "workers loading the kernels, dispatch, close)")
    print(f"scaling: 1 -> 2 workers {one:.1f} -> {two:.1f} s: {model['throughput_2']:.2f}x the "
          f"throughput (target >= {TARGET_THROUGHPUT_2:g}x: "
          f"{'PASS' if model['throughput_2'] >= TARGET_THROUGHPUT_2 else 'FAIL'})")
    print(f"16 workers on 16 cores, {a.sorties} sorties: about {model['t16_s']:.1f} s if the "
          f"contention stays k(2); {model['linear_16']:.0%} of linear (for {16 * a.sorties} "
          f"sorties: {model['linear_16_big']:.0%})")
    bound = cores / usable_cores()
    print(f"bound: the serial loop already keeps {cores:.2f} of {usable_cores()} cores busy, "
          f"so {usable_cores()} workers on these cores can at best reach {bound:.2f}x its time "
          "(the same CPU seconds spread over all cores)")
    verdict = "PASS" if ratio <= TARGET_RATIO else "FAIL"
    print(f"  2-worker campaign <= {TARGET_RATIO:g}x the in-process serial loop: {two:.1f} / "
          f"{serial:.1f} s = {ratio:.2f}x  {verdict}")
    if loop:
        shell = two / loop
        print(f"  2-worker campaign <= {TARGET_RATIO:g}x a shell loop of `rangeproc run`: "
              f"{two:.1f} / {loop:.1f} s = {shell:.2f}x  "
              f"{'PASS' if shell <= TARGET_RATIO else 'FAIL'}")
    (ROOT / "bench" / "campaign.json").write_text(json.dumps({
        "sorties": a.sorties, "serial_in_process_s": serial, "serial_each_s": each,
        "serial_cpu_s": serial_cpu, "serial_cores_busy": cores, "ratio_bound": bound,
        "serial_process_loop_s": loop, "campaign_1_worker_s": one,
        "campaign_2_workers_s": two, "campaign_1_each_s": one_each,
        "campaign_2_each_s": two_each, "task_overhead_s": per_task,
        "local_cluster_start_s": start, "ratio_2_workers_to_serial": ratio,
        "scaling_model": model, "projected_16_workers_s": model["t16_s"],
        "ratio_2_workers_to_process_loop": two / loop if loop else None}, indent=2))


if __name__ == "__main__":
    main()
