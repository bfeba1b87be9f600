"""A Dask worker set up for sorties: its share of the machine's cores, and rangeproc with its
compiled kernels loaded once when the worker starts rather than in its first sortie.

:class:`SortieWorker` is a ``distributed.WorkerPlugin`` that the campaign registers on every
worker of its cluster (``campaign.runner``). On ``setup`` it

1. sets ``RANGEPROC_CORES`` (``rangeproc.parallel.CORES_ENV``) in the worker process to the
   worker's share of its machine: its machine's usable cores divided among the sortie
   threads running there (every worker of the cluster on the same host, each with its task
   threads). A sortie's own side-by-side work (objects' filters, segment scores, the report's
   forked child) then stays within that share instead of starting a thread per core in every
   worker;
2. loads rangeproc and its compiled kernels by running the pipeline once on a short simulated
   flight in a temporary folder (:func:`warm_kernels`): the kernels load from the cache (or
   compile once, into it), so the first sortie costs what the others cost.
"""
from __future__ import annotations

import logging
import os
import tempfile
import time
from pathlib import Path

from distributed import WorkerPlugin

from rangeproc.parallel import CORES_ENV, usable_cores

log = logging.getLogger(__name__)

#: Seconds of the simulated flight :func:`warm_kernels` processes (the simulator's shortest).
WARM_FLIGHT_S = 20.0


def warm_kernels() -> float:
    """Run the pipeline once on a short simulated flight in a temporary folder (every sensor
    kind, the default filter), loading the compiled kernels a sortie uses; returns the
    seconds it took."""
    from rangeproc.pipeline import run
    from rangeproc.progress import StageClock
    from rangeproc.simulate import simulate_scenario

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="rangeproc-warm-") as tmp:
        config = simulate_scenario(Path(tmp), seed=1, duration=WARM_FLIGHT_S)
        run(config, clock=StageClock())
    return time.perf_counter() - t0


def core_share(cores: int, threads_on_host: int) -> int:
    """Cores for one sortie when ``threads_on_host`` sortie threads share ``cores`` (>= 1)."""
    return max(1, cores // max(1, threads_on_host))


class SortieWorker(WorkerPlugin):
    """Worker plugin (module docstring).

    threads_by_host: the cluster's task threads per host address (``{host: n}``, from the
    scheduler's worker list when the campaign starts); a worker on a host not listed counts
    its own threads only. warm: also load the kernels (:func:`warm_kernels`).
    """

    name = "rangeproc-sortie-worker"

    def __init__(self, threads_by_host: dict[str, int] | None = None, warm: bool = True):
        self.threads_by_host = dict(threads_by_host or {})
        self.warm = warm

    def setup(self, worker) -> None:  # type: ignore[no-untyped-def]
        host = _host(worker.address)
        threads = self.threads_by_host.get(host, worker.state.nthreads)
        os.environ[CORES_ENV] = str(core_share(usable_cores(), threads))
        if self.warm:
            try:
                seconds = warm_kernels()
                log.info("worker %s: kernels loaded in %.1f s", worker.address, seconds)
            except Exception as exc:  # noqa: BLE001 - a failed warm-up costs time, not sorties
                log.warning("worker %s: kernel warm-up failed (%s: %s); the first sortie "
                            "loads them", worker.address, type(exc).__name__, exc)


def _host(address: str) -> str:
    """The host of a Dask address (``tcp://10.0.0.5:40123`` -> ``10.0.0.5``)."""
    return address.split("://", 1)[-1].rsplit(":", 1)[0]


def threads_by_host(client) -> dict[str, int]:  # type: ignore[no-untyped-def]
    """``{host: task threads}`` over the workers the scheduler knows now."""
    out: dict[str, int] = {}
    for address, info in client.scheduler_info().get("workers", {}).items():
        host = _host(address)
        out[host] = out.get(host, 0) + int(info.get("nthreads", 1))
    return out
