"""Run a campaign's sorties on a Dask cluster (``dask.distributed``) and record the outcome.

By default a ``LocalCluster`` of worker *processes* on this machine (one per usable core,
one thread each); with ``scheduler`` an existing cluster at that address (its workers need
rangeproc installed and the sorties' files at the same paths). Every worker gets the
:class:`~rangeproc.campaign.worker.SortieWorker` plugin: a sortie uses its worker's share of
the machine's cores (not a thread per core in every worker), and the compiled kernels are
loaded when the worker starts, not in its first sortie. Each sortie is one task
(:func:`rangeproc.campaign.sortie.run_sortie`); a worker that dies mid-sortie has its task
rescheduled by Dask on another worker (up to the scheduler's ``allowed-failures``, 3 by
default), and as the sortie's outputs are only renamed into place at its end, the rerun
neither loses nor duplicates anything. A task that still cannot finish is recorded as failed
("worker lost").

Writes ``<campaign out_dir>/campaign.json`` (atomic): every sortie's outcome in campaign
order, the counts, the wall time and where it ran.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path

from rangeproc.campaign.result import CampaignResult
from rangeproc.campaign.sortie import Outcome, run_sortie
from rangeproc.campaign.spec import Campaign
from rangeproc.errors import ConfigError
from rangeproc.io.writers import write_json
from rangeproc.parallel import usable_cores

log = logging.getLogger(__name__)

#: Dask settings of the local cluster's workers: no statistical profiler. It samples the
#: task thread's stack every 10 ms for a dashboard the local cluster does not serve, and
#: took 5-6 % of a sample sortie's time on a worker (3.30 -> 3.12 s, 9 sorties, twice).
LOCAL_WORKER_CONFIG = {"distributed.worker.profile.enabled": False}


def _client(scheduler: str | None, workers: int | None, n_tasks: int):  # type: ignore[no-untyped-def]
    """A connected ``distributed.Client`` and a description of its cluster."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, TimeoutError) as exc:
            raise ConfigError(f"--scheduler: cannot connect to {scheduler} ({exc})") from None
        return client, f"scheduler {scheduler}"
    import dask

    n = max(1, min(workers or usable_cores(), n_tasks))
    with dask.config.set(LOCAL_WORKER_CONFIG):           # handed to the worker processes
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster), f"LocalCluster, {n} worker process{'es' * (n != 1)}"


def run_campaign(campaign: Campaign, *, scheduler: str | None = None,
                 workers: int | None = None, resume: bool = True,
                 tick: Callable[[int, str], None] = lambda n, note: None) -> CampaignResult:
    """Run every sortie of ``campaign`` (module docstring); ``tick(1, sortie id)`` as each
    finishes. ConfigError when the scheduler cannot be reached."""
    from distributed import as_completed

    from rangeproc.campaign.worker import SortieWorker, threads_by_host

    t0 = time.perf_counter()
    client, where = _client(scheduler, workers, len(campaign.sorties))
    outcomes: dict[str, Outcome] = {}
    try:
        # each worker: its share of its machine's cores, the kernels loaded before any sortie
        client.register_plugin(SortieWorker(threads_by_host(client)))
        futures = {client.submit(run_sortie, s, resume, pure=False,
                                 key=f"rangeproc-sortie-{k}-{s.id}"): s
                   for k, s in enumerate(campaign.sorties)}
        for future in as_completed(futures):
            sortie = futures[future]
            try:
                outcome = future.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker, a lost connection, ...
                name = type(exc).__name__
                why = ("worker lost: the worker running it died on every attempt"
                       if name == "KilledWorker" else f"{name}: {' '.join(str(exc).split())}")
                outcome = Outcome(id=sortie.id, config=str(sortie.config), out_dir="",
                                  status="failed", reason=why, exit_code=1)
            outcomes[sortie.id] = outcome
            tick(1, sortie.id)
    finally:
        cluster = getattr(client, "cluster", None)
        client.close()
        if cluster is not None and scheduler is None:
            cluster.close()
    result = CampaignResult(tuple(outcomes[s.id] for s in campaign.sorties), campaign.out_dir,
                            time.perf_counter() - t0, where)
    write_records(campaign, result)
    return result


def write_records(campaign: Campaign, result: CampaignResult) -> list[Path]:
    """The campaign's records in its output folder (each atomic): ``campaign.parquet``
    (``campaign.summary``), ``sensor_<id>.png`` (``campaign.figures``), ``index.html``
    (``campaign.page``) and, last, ``campaign.json``; returns their paths."""
    from rangeproc.campaign.figures import write_sensor_figures
    from rangeproc.campaign.page import write_campaign_page
    from rangeproc.campaign.summary import campaign_table
    from rangeproc.io.writers import write_parquet

    folder = campaign.out_dir
    folder.mkdir(parents=True, exist_ok=True)
    table = campaign_table(result.outcomes)
    written = [write_parquet(table, folder / "campaign.parquet")]
    figures = write_sensor_figures(table, folder) if not table.empty else []
    written += figures
    written.append(write_campaign_page(result, f"rangeproc campaign: {campaign.source.name}",
                                       table, figures, folder))
    written.append(write_json({"campaign": str(campaign.source), "cluster": result.cluster,
                               "seconds": result.seconds, "counts": result.counts(),
                               "sorties": [o.as_dict() for o in result.outcomes]},
                              folder / "campaign.json"))
    return written
