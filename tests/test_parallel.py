"""rangeproc.parallel: threads over compiled kernels and one forked child for figures."""
from __future__ import annotations

import multiprocessing
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rangeproc import parallel
from rangeproc.estimation.rts import rts_smooth
from rangeproc.parallel import shared_with_child, thread_map


def test_thread_map_keeps_the_order_of_the_items_whatever_the_cost_order():
    items = list(range(20))
    out = thread_map(lambda x: (time.sleep(0.001 * (x % 3)), x * x)[1], items,
                     cost=lambda x: x % 5)
    assert out == [x * x for x in items]


def test_thread_map_propagates_the_first_exception():
    def job(x: int) -> int:
        if x == 3:
            raise ValueError("job 3 failed")
        return x

    with pytest.raises(ValueError, match="job 3 failed"):
        thread_map(job, list(range(8)))


def test_compiled_kernels_release_the_gil_so_threads_overlap():
    """While an RTS smoother runs in another thread, this thread keeps running Python over
    most of the kernel's run: it released the GIL. (Holding it, this loop runs only in the
    switch interval before the call: 1 % of the window, measured with ``nogil`` removed.)"""
    n = 300_000
    t = np.arange(n, dtype=float) * 0.05
    xf = np.zeros((n, 9))
    rows, cols = np.tril_indices(9)                     # packed lower triangle, row-major
    Pf = np.tile((rows == cols).astype(float), (n, 1))
    q = np.full(n, 1.0)
    rts_smooth(t[:10], xf[:10].copy(), Pf[:10].copy(), q[:10], True, False, None, None)
    window: list[float] = []

    def smooth() -> None:
        window.append(time.perf_counter())
        rts_smooth(t, xf, Pf, q, True, False, None, None)
        window.append(time.perf_counter())

    worker = threading.Thread(target=smooth)
    stamps = []
    worker.start()
    while worker.is_alive():
        stamps.append(time.perf_counter())
    worker.join()
    stamps = np.asarray(stamps)
    inside = stamps[(stamps > window[0]) & (stamps < window[1])]
    covered = (inside.max() - inside.min()) / (window[1] - window[0]) if inside.size else 0.0
    assert covered > 0.5, (covered, window[1] - window[0])  # GIL held: one switch interval


def _write_job(folder: Path):
    def run(k: int) -> None:
        path = folder / f"{k}.txt"
        with open(path, "a") as fh:                     # "a": a job done twice shows
            fh.write(f"{os.getpid()}\n")
    return run


def test_row_chunks_cover_the_rows_in_order_and_leave_short_inputs_whole(monkeypatch):
    assert parallel.row_chunks(parallel.MIN_CHUNK_ROWS * 2 - 1, parts=2) == [
        slice(0, parallel.MIN_CHUNK_ROWS * 2 - 1)]
    monkeypatch.setattr(parallel, "MIN_CHUNK_ROWS", 10)
    for n, parts in ((10, 4), (101, 3), (1000, 7), (0, 2)):
        chunks = parallel.row_chunks(n, parts=parts)
        assert len(chunks) == max(1, min(parts, n // 10))
        assert np.array_equal(np.concatenate([np.arange(n)[c] for c in chunks]), np.arange(n))
        assert all(c.stop - c.start >= 10 for c in chunks) or len(chunks) == 1


def test_shared_with_child_runs_every_job_exactly_once(tmp_path):
    done: list[int] = []
    shared_with_child(_write_job(tmp_path), 12, done.append)
    assert sorted(done) == list(range(12))
    lines = [(tmp_path / f"{k}.txt").read_text().splitlines() for k in range(12)]
    assert all(len(x) == 1 for x in lines)


def test_shared_with_child_raises_the_childs_exception(tmp_path, monkeypatch):
    parent = os.getpid()

    def run(k: int) -> None:
        if os.getpid() != parent or not parallel._can_fork():
            raise KeyError(f"figure {k}")
        time.sleep(0.2)                                 # leave the other jobs to the child

    with pytest.raises(KeyError, match="figure"):
        shared_with_child(run, 4)


def test_shared_with_child_runs_in_order_here_outside_the_main_thread(tmp_path):
    """Forking from a worker thread (a Dask worker runs tasks in threads) is not safe: the
    jobs then run in the calling thread, in order."""
    pids: list[int] = []
    seen: list[int] = []

    def run(k: int) -> None:
        pids.append(os.getpid())
        seen.append(k)

    worker = threading.Thread(target=shared_with_child, args=(run, 5))
    worker.start()
    worker.join()
    assert seen == list(range(5)) and set(pids) == {os.getpid()}


def test_shared_with_child_runs_first_here_once_while_the_child_takes_jobs(tmp_path):
    """``first`` runs once, in this process, before it takes a job; the child meanwhile
    starts on the jobs (with two cores)."""
    here = os.getpid()
    calls: list[tuple[int, float]] = []
    taken_here: list[tuple[int, float]] = []

    def first() -> None:
        calls.append((os.getpid(), time.perf_counter()))
        time.sleep(0.3)

    def run(k: int) -> None:
        _write_job(tmp_path)(k)
        if os.getpid() == here:
            taken_here.append((k, time.perf_counter()))

    shared_with_child(run, 6, first=first)
    assert [pid for pid, _ in calls] == [os.getpid()]
    assert all(t > calls[0][1] for _, t in taken_here)
    jobs = [(tmp_path / f"{k}.txt").read_text().split() for k in range(6)]
    assert all(len(x) == 1 for x in jobs)
    if parallel._can_fork():                    # the child did jobs while first() ran
        assert any(int(x[0]) != os.getpid() for x in jobs)


def test_shared_with_child_stops_the_child_when_first_raises(tmp_path):
    def first() -> None:
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        shared_with_child(_write_job(tmp_path), 50, first=first)
    assert not [c for c in multiprocessing.active_children() if c.name == "rangeproc-child"]


@pytest.mark.parametrize(("value", "limited"), [("1", True), ("0", False), ("x", False),
                                                ("", False)])
def test_usable_cores_keeps_to_the_share_a_campaign_worker_sets(
        monkeypatch: pytest.MonkeyPatch, value: str, limited: bool) -> None:
    from rangeproc.parallel import CORES_ENV, usable_cores
    monkeypatch.delenv(CORES_ENV, raising=False)
    machine = usable_cores()
    monkeypatch.setenv(CORES_ENV, value)
    assert usable_cores() == (1 if limited else machine)
