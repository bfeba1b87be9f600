"""Independent jobs side by side on the cores of one machine.

* :func:`thread_map`: threads, for work that is mostly compiled kernel time (objects' filters
  and smoothers, segment scores): the kernels (``numba``, ``nogil=True``) release the GIL.
  Results come back in the order the jobs were given and do not depend on the thread count;
  the first job to raise stops the jobs that have not started and its exception propagates.
* :func:`row_chunks`: contiguous row slices for a compiled row-by-row kernel run over them
  with :func:`thread_map`.
* :func:`shared_with_child`: this process and one forked child, for work that holds the GIL
  (the report's matplotlib figures).
* :func:`one_heap`: every thread allocates from the C library's main heap (run at
  ``import rangeproc``), whose freed pages ``io.memory.release_freed`` hands back.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools
import gc
import multiprocessing
import os
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

import numpy as np

T = TypeVar("T")
R = TypeVar("R")


#: glibc's ``mallopt`` parameter: the most heaps (arenas) the threads allocate from.
M_ARENA_MAX = -8


@functools.cache
def _libc() -> ctypes.CDLL | None:
    """The C library, looked up once (``find_library`` runs ``ldconfig``: ~10 ms), or None."""
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name) if name else None
    except OSError:
        return None


def libc_function(function: str) -> Callable[..., int] | None:
    """glibc's ``function`` (``malloc_trim``, ``mallopt``), or None (another C library, or
    none found)."""
    libc = _libc()
    return getattr(libc, function, None) if libc is not None else None


def one_heap() -> bool:
    """Let every thread allocate from the C library's main heap (glibc
    ``mallopt(M_ARENA_MAX, 1)``), whose free pages ``io.memory.release_freed`` hands back in
    full: glibc gives each thread a heap of its own (up to 8 per core), where what a worker
    thread freed stays resident between the trims. Threads that already hold a heap of their
    own keep it (run it before any thread allocates: ``import rangeproc`` does). The threads
    share the heap's lock: the kernels write into arrays made before they start, so they
    seldom take it. False where there is no ``mallopt`` (nothing done)."""
    mallopt = libc_function("mallopt")
    return bool(mallopt(M_ARENA_MAX, 1)) if mallopt is not None else False


#: Environment variable: the most cores one run may use, when several runs share a machine
#: (a campaign's Dask workers set it to their share, ``campaign.worker``).
CORES_ENV = "RANGEPROC_CORES"


def usable_cores() -> int:
    """Cores this process may run on: its CPU affinity where the OS tells it, at most
    ``RANGEPROC_CORES`` when that is set to a positive integer."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:                                 # not on Linux
        cores = os.cpu_count() or 1
    share = os.environ.get(CORES_ENV, "").strip()
    if share.isdigit() and int(share) > 0:
        cores = min(cores, int(share))
    return cores


def thread_map(fn: Callable[[T], R], items: Sequence[T],
               cost: Callable[[T], float] | None = None) -> list[R]:
    """``[fn(x) for x in items]`` with up to one thread per usable core.

    cost: an estimate of each job's run time; the costliest start first so the threads
    finish together. One job (or one core) runs in the calling thread, without a pool.
    """
    workers = min(usable_cores(), len(items))
    if workers <= 1:
        return [fn(x) for x in items]
    order = sorted(range(len(items)), key=lambda k: -cost(items[k])) if cost \
        else list(range(len(items)))
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="rangeproc") as pool:
        futures = {k: pool.submit(fn, items[k]) for k in order}
        try:
            return [futures[k].result() for k in range(len(items))]
        except BaseException:
            for future in futures.values():
                future.cancel()
            raise


#: Rows below which a row kernel is not split: starting a thread and joining the pieces cost
#: about 0.1 ms, a row 0.1-1 µs.
MIN_CHUNK_ROWS = 50_000


def row_chunks(n_rows: int, parts: int | None = None) -> list[slice]:
    """Contiguous slices covering ``range(n_rows)`` in order, for a row kernel run over them
    side by side (:func:`thread_map`): ``parts`` of them (default one per usable core), fewer
    when a slice would hold under :data:`MIN_CHUNK_ROWS` rows (one slice for short inputs).

    A kernel whose rows are independent gives the same values for any split; one that sums
    over rows should pass a fixed ``parts`` so that its rounding does not depend on the
    machine's core count.
    """
    parts = usable_cores() if parts is None else parts
    parts = max(1, min(parts, n_rows // MIN_CHUNK_ROWS))
    edges = np.linspace(0, n_rows, parts + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


#: Seconds the parent waits, after an exception, for the child to finish its job under way.
CHILD_STOP_SECONDS = 60.0


def shared_with_child(run_job: Callable[[int], None], n_jobs: int,
                      done: Callable[[int], None] = lambda k: None,
                      first: Callable[[], None] = lambda: None) -> None:
    """``run_job(k)`` for k in ``range(n_jobs)``, shared with one forked child process.

    For work that holds the GIL (matplotlib drawing): this process and a child forked from it
    (it sees the same data without copying or pickling) take the next job from a shared
    counter until none is left. The jobs' effects must be files or the like: nothing returns
    from the child. ``done(k)`` is called in this process as each job finishes (the child's
    as they are reported). The first exception in either process stops both (the child after
    the job it is running, so that job cleans up after itself) and propagates
    here (the child's is sent back whole, or as ``RuntimeError`` with its text when it cannot
    be pickled). Without a second core, without ``fork``, outside the main thread or inside
    a daemonic process (a Dask worker) every job runs here, in order.

    ``first()`` runs here before this process takes a job, once the child has started: other
    work (writing the run's tables) overlaps the child's first jobs. Its exception stops the
    child and propagates.
    """
    if n_jobs < 2 or not _can_fork():
        first()
        for k in range(n_jobs):
            run_job(k)
            done(k)
        return
    ctx = multiprocessing.get_context("fork")
    counter = ctx.Value("i", 0)
    reader, writer = ctx.Pipe(duplex=False)

    def take() -> int:
        with counter.get_lock():
            k = counter.value
            counter.value = k + 1
        return k

    def child() -> None:
        reader.close()
        try:
            while (k := take()) < n_jobs:
                run_job(k)
                writer.send(("done", k))
            writer.send(("ok", None))
        except BaseException as exc:  # noqa: BLE001 - sent to the parent, raised there
            try:
                writer.send(("error", exc))
            except Exception:  # noqa: BLE001 - the exception does not pickle
                writer.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))

    for stream in (sys.stdout, sys.stderr):   # or the child would write their buffers again
        if stream is not None:
            stream.flush()
    worker = ctx.Process(target=child, name="rangeproc-child", daemon=True)
    gc.freeze()     # the child's collector then leaves the shared heap's pages unwritten
    try:
        worker.start()
    finally:
        gc.unfreeze()
    writer.close()
    finished = False

    def drain(block: bool) -> None:
        nonlocal finished
        while not finished and (block or reader.poll()):
            try:
                what, value = reader.recv()
            except EOFError:
                worker.join()
                raise RuntimeError(f"child process ended with exit code {worker.exitcode} "
                                   "before finishing its jobs") from None
            if what == "done":
                done(value)
            elif what == "ok":
                finished = True
            else:
                raise value

    try:
        first()
        while (k := take()) < n_jobs:
            run_job(k)
            done(k)
            drain(block=False)
        drain(block=True)
    except BaseException:
        # stop the child taking jobs and let it finish the one under way, so that its own
        # clean-up (a temporary file of an atomic write) runs: a killed child left it behind
        with counter.get_lock():
            counter.value = n_jobs
        worker.join(timeout=CHILD_STOP_SECONDS)
        if worker.is_alive():
            worker.kill()
        raise
    finally:
        worker.join()
        reader.close()


def _can_fork() -> bool:
    """True when forking a helper process is safe and useful here (see
    :func:`shared_with_child`)."""
    return (usable_cores() >= 2 and "fork" in multiprocessing.get_all_start_methods()
            and threading.current_thread() is threading.main_thread()
            and not multiprocessing.current_process().daemon)
