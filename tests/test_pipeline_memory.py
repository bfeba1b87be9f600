"""Memory a run lets go of stays gone: the Arrow reads leave nothing in Arrow's own pool, the
fusion results are released before the report draws, and every stage starts by handing the
C heap's free pages back (``io.memory``, ``pipeline``)."""
from __future__ import annotations

import ctypes
import ctypes.util
import threading
import weakref
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

import rangeproc.pipeline as pipeline
from rangeproc.config import load_config
from rangeproc.io.memory import (
    BETWEEN_STEPS_ROWS,
    release_freed,
    release_freed_between,
    system_arrow_pool,
)
from rangeproc.progress import SilentDisplay, StageClock
from rangeproc.stages.read import read_all

from conftest import SAMPLE_CONFIG


def test_the_read_stage_leaves_nothing_in_arrows_own_pool(scenario: Path) -> None:
    default = pa.default_memory_pool()
    if default.backend_name == "system":
        pytest.skip("Arrow's default pool is the system allocator here")
    held = default.bytes_allocated()
    system_held = pa.system_memory_pool().bytes_allocated()
    logs = read_all(load_config(scenario / SAMPLE_CONFIG))
    # the columns the logs share with Arrow live in the system pool; the default one holds
    # at most a stray buffer of the parser's (a few kB, let go on the next read)
    in_default = default.bytes_allocated() - held
    in_system = pa.system_memory_pool().bytes_allocated() - system_held
    assert in_system > 10_000
    assert in_default < in_system / 4
    assert pa.default_memory_pool().backend_name == default.backend_name   # restored
    assert sum(len(lg) for lg in logs.values()) > 0


def test_the_default_pool_is_restored_when_a_read_fails() -> None:
    name = pa.default_memory_pool().backend_name
    with pytest.raises(RuntimeError), system_arrow_pool():
        assert pa.default_memory_pool().backend_name == "system"
        raise RuntimeError("a bad file")
    assert pa.default_memory_pool().backend_name == name


class _Watch(SilentDisplay):
    """At each stage's start: which watched arrays are still alive, and how many times the
    free pages were handed back so far."""

    def __init__(self, trims: list[int]) -> None:
        self.refs: dict[str, list[weakref.ref]] = {}
        self.alive: dict[str, dict[str, int]] = {}
        self.trims_at: dict[str, int] = {}
        self.trims = trims

    def start(self, stage: str, total: int) -> None:
        self.alive.setdefault(stage, {k: sum(r() is not None for r in v)
                                      for k, v in self.refs.items()})
        self.trims_at.setdefault(stage, self.trims[0])


def test_fusion_results_are_released_before_the_report_and_stages_trim(
        scenario: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    trims = [0]
    watch = _Watch(trims)
    fuse_objects = pipeline.fuse_objects

    def watched(*args, **kwargs):        # noqa: ANN002, ANN003, ANN202
        fused = fuse_objects(*args, **kwargs)
        watch.refs["fusion"] = [weakref.ref(a) for _, res in fused
                                for a in (res.Ps, res.xs, res.res, res.batch.z)]
        return fused

    def counted() -> None:
        trims[0] += 1

    monkeypatch.setattr(pipeline, "fuse_objects", watched)
    monkeypatch.setattr(pipeline, "release_freed", counted)
    out = pipeline.run(scenario / SAMPLE_CONFIG, clock=StageClock(display=watch))
    assert out.tracks
    assert watch.alive["products"]["fusion"] == len(watch.refs["fusion"])  # the check can see
    assert watch.alive["report"]["fusion"] == 0       # them, and they are gone by the report
    # every stage handed the free pages back as it started (9 stage starts: write twice),
    # the fuse stage also at each of its passes' ticks
    order = ["read", "screen", "assemble", "associate", "fuse", "products", "write", "report"]
    assert all(watch.trims_at[a] < watch.trims_at[b] for a, b in zip(order, order[1:]))
    assert watch.trims_at["products"] - watch.trims_at["fuse"] > 1
    assert trims[0] > 9


def test_release_freed_gives_a_fragmented_heaps_pages_back() -> None:
    if not release_freed():
        pytest.skip("no malloc_trim in this C library")
    keep, gone = [], []
    for _ in range(3000):                 # 80 kB arrays: below glibc's mmap threshold, in
        keep.append(np.ones(10_000))      # the heap, every other one freed
        gone.append(np.ones(10_000))
    del gone
    before = _rss()
    assert release_freed()
    assert _rss() < before - 100 * 2**20  # of the 240 MB freed, most left the resident set
    assert len(keep) == 3000


def _rss() -> int:
    """This process's resident set (bytes; Linux /proc), or skip."""
    try:
        text = Path("/proc/self/status").read_text()
    except OSError:
        pytest.skip("no /proc")
    return int(next(line for line in text.splitlines() if line.startswith("VmRSS:")).split()[1]
               ) * 1024



def test_worker_threads_allocate_from_the_main_heap(tmp_path: Path) -> None:
    """``import rangeproc`` puts every thread on the C library's main heap
    (``parallel.one_heap``), whose freed pages ``release_freed`` hands back: a worker thread
    that allocates makes no heap of its own (glibc's ``malloc_info`` lists the heaps)."""
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    if not hasattr(libc, "malloc_info") or not release_freed():
        pytest.skip("not glibc")
    libc.fopen.restype = ctypes.c_void_p
    libc.fopen.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
    libc.malloc_info.argtypes = [ctypes.c_int, ctypes.c_void_p]
    libc.fclose.argtypes = [ctypes.c_void_p]

    def heaps() -> int:
        out = tmp_path / "heaps.xml"
        f = libc.fopen(str(out).encode(), b"w")
        libc.malloc_info(0, f)
        libc.fclose(f)
        return out.read_text().count("<heap nr=")

    def churn() -> None:               # 80 kB arrays: heap blocks, not mmapped ones
        made = [np.ones(10_000) for _ in range(100)]
        assert len(made) == 100

    before = heaps()
    workers = [threading.Thread(target=churn) for _ in range(4)]
    for w in workers:                  # side by side, as rangeproc.parallel runs them
        w.start()
    for w in workers:
        w.join()
    assert heaps() == before == 1


def test_steps_hand_pages_back_between_them_on_long_spans_only(monkeypatch) -> None:
    # a short span's or object's steps free too little for the trim's refaults to pay
    import rangeproc.io.memory as memory
    if not release_freed():
        pytest.skip("no malloc_trim in this C library")
    trims = [0]

    def counted() -> bool:
        trims[0] += 1
        return True

    monkeypatch.setattr(memory, "release_freed", counted)
    assert not release_freed_between(BETWEEN_STEPS_ROWS - 1)
    assert trims[0] == 0
    assert release_freed_between(BETWEEN_STEPS_ROWS)
    assert trims[0] == 1
