"""``rangeproc campaign`` on a real ``dask.distributed.LocalCluster`` with worker processes.

Checked: every sortie done and its outputs identical to ``rangeproc run`` on the same config;
a corrupt sortie isolated (its one-line reason recorded, exit status 4, the others done); a
worker killed mid-sortie neither loses nor duplicates a sortie; a rerun skips what is up to
date and redoes what changed; a bad campaign file is a one-line exit 2.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import threading
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from conftest import sensor_subset

from rangeproc.campaign import load_campaign, run_campaign
from rangeproc.cli import main
from rangeproc.errors import ConfigError
from rangeproc.pipeline import run

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
FAST = ("R1", "G1")                  # a quick subset of the sample's sensors


def sortie_config(folder: Path, name: str, out: str, sensors=FAST) -> Path:
    """A copy of the sample's scenario.toml in ``folder`` reading ../data, writing ``out``,
    with only ``sensors``."""
    text = sensor_subset((SAMPLE / "scenario.toml").read_text(), sensors)
    text = text.replace('dir = "out"', f'dir = "../out/{out}"').replace('file = "',
                                                                       'file = "../data/')
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


@pytest.fixture(autouse=True)
def environment_restored():
    """This process's environment as it was before each test: distributed's LocalCluster
    writes its workers' thread limits (``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``,
    ``OPENBLAS_NUM_THREADS`` = 1) into the environment of the process that starts it, and
    the processes later tests start would inherit them (a rangeproc run on single-threaded
    BLAS differs from one on several threads in the last bits of its covariances)."""
    saved = dict(os.environ)
    yield
    os.environ.clear()
    os.environ.update(saved)


@pytest.fixture()
def campaign_dir(tmp_path: Path) -> Path:
    """data/ (the sample's files), flights/a.toml, b.toml, c.toml, campaign.toml."""
    shutil.copytree(SAMPLE, tmp_path / "data", ignore=shutil.ignore_patterns("out", ".*"))
    flights = tmp_path / "flights"
    flights.mkdir()
    for name in "abc":
        sortie_config(flights, name, name)
    (tmp_path / "campaign.toml").write_text(
        '[output]\ndir = "records"\n\n'
        + "".join(f'[[sorties]]\nconfig = "flights/{n}.toml"\n\n' for n in "abc"))
    return tmp_path


def records(folder: Path) -> dict:
    return json.loads((folder / "records" / "campaign.json").read_text())


def test_every_sortie_done_as_rangeproc_run_and_a_corrupt_one_isolated(campaign_dir) -> None:
    flights = campaign_dir / "flights"
    for name in "ab":
        sortie_config(flights, name, name, sensors=("G1",))          # GPS only: quick
    shutil.copy(campaign_dir / "data" / "R1.csv", campaign_dir / "data" / "R1_bad.csv")
    cfg_c = flights / "c.toml"
    cfg_c.write_text(cfg_c.read_text().replace("../data/R1.csv", "../data/R1_bad.csv"))
    bad = campaign_dir / "data" / "R1_bad.csv"
    lines = bad.read_text().splitlines()
    cells = lines[5].split(",")
    cells[lines[0].split(",").index("range")] = "abc"
    lines[5] = ",".join(cells)
    bad.write_text("\n".join(lines) + "\n")

    result = CliRunner().invoke(main, ["campaign", "--quiet", "--workers", "2",
                                       str(campaign_dir / "campaign.toml")])
    assert result.exit_code == 4, result.output
    rec = records(campaign_dir)
    assert rec["counts"] == {"done": 2, "skipped": 0, "failed": 1}
    status = {s["id"]: s for s in rec["sorties"]}
    assert status["c"]["status"] == "failed" and status["c"]["exit_code"] == 2
    assert "R1_bad.csv: row 5, column 'range'" in status["c"]["reason"]
    assert result.stderr.strip().splitlines() == [
        f"rangeproc: sortie c failed: {status['c']['reason']}"]
    # identical to rangeproc run on the same config (another output folder)
    direct = campaign_dir / "flights" / "direct.toml"
    direct.write_text((campaign_dir / "flights" / "a.toml").read_text()
                      .replace('"../out/a"', '"../out/direct"'))
    run(direct)
    for name in ("fused.parquet", "association.parquet", "edits.parquet"):
        pd.testing.assert_frame_equal(pd.read_parquet(campaign_dir / "out" / "a" / name),
                                      pd.read_parquet(campaign_dir / "out" / "direct" / name))
    assert not (campaign_dir / "out" / "c").exists() or not any(
        (campaign_dir / "out" / "c").iterdir())


def test_rerun_skips_what_is_up_to_date_and_redoes_what_changed(campaign_dir) -> None:
    for name in "abc":
        sortie_config(campaign_dir / "flights", name, name, sensors=("G1",))
    spec = load_campaign(campaign_dir / "campaign.toml")
    first = run_campaign(spec, workers=2)
    assert first.counts() == {"done": 3, "skipped": 0, "failed": 0}
    second = run_campaign(spec, workers=2)
    assert second.counts() == {"done": 0, "skipped": 3, "failed": 0}
    cfg_b = campaign_dir / "flights" / "b.toml"
    cfg_b.write_text(cfg_b.read_text().replace("rate_hz = 10.0", "rate_hz = 5.0"))
    third = run_campaign(spec, workers=2)
    assert {o.id: o.status for o in third.outcomes} == {"a": "skipped", "b": "done",
                                                        "c": "skipped"}
    assert run_campaign(spec, workers=1, resume=False).counts()["done"] == 3


def test_a_worker_killed_mid_sortie_loses_and_duplicates_nothing(campaign_dir) -> None:
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as watcher:
        spec = load_campaign(campaign_dir / "campaign.toml")
        box: dict = {}
        thread = threading.Thread(target=lambda: box.update(
            result=run_campaign(spec, scheduler=cluster.scheduler_address)))
        thread.start()
        killed = None
        deadline = time.monotonic() + 60
        while killed is None and time.monotonic() < deadline:
            busy = {w: keys for w, keys in watcher.processing().items() if keys}
            if busy:
                worker = sorted(busy)[0]
                pid = watcher.run(os.getpid, workers=[worker])[worker]
                time.sleep(0.5)                          # well inside the sortie's run
                os.kill(pid, signal.SIGKILL)
                killed = (pid, busy[worker][0])
            time.sleep(0.05)
        thread.join(timeout=240)
    assert killed is not None, "no sortie was ever seen running"
    result = box["result"]
    assert [o.id for o in result.outcomes] == ["a", "b", "c"]          # each exactly once
    assert result.counts() == {"done": 3, "skipped": 0, "failed": 0}
    lost = next(o for o in result.outcomes if o.id in killed[1])
    assert not lost.where.endswith(f":{killed[0]}")                    # rerun elsewhere
    for name in "abc":
        out = campaign_dir / "out" / name
        summary = json.loads((out / "summary.json").read_text())
        assert summary["config"]["file"].endswith(f"{name}.toml")
        assert not list(out.glob(".rangeproc-staging-*"))


@pytest.mark.parametrize("text, message", [
    ('[[sorties]]\nconfig = "flights/a.toml"\n\n[[sorties]]\nconfig = "flights/a.toml"\n',
     "sorties[1].id: duplicate sortie id 'a'"),
    ('[[sorties]]\nconfig = "flights/zzz.toml"\n', "sorties[0].config:"),
    ("[sorties]\n", "sorties: expected a non-empty array"),
    ('flights = 1\n', "flights: unknown key"),
])
def test_bad_campaign_file_is_one_line_exit_2(campaign_dir, text: str, message: str) -> None:
    path = campaign_dir / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_campaign(path)
    result = CliRunner().invoke(main, ["campaign", "--quiet", str(path)])
    assert result.exit_code == 2
    assert len(result.stderr.strip().splitlines()) == 1


def test_two_sorties_writing_one_folder_are_refused(campaign_dir) -> None:
    cfg_b = campaign_dir / "flights" / "b.toml"
    cfg_b.write_text(cfg_b.read_text().replace('"../out/b"', '"../out/a"'))
    with pytest.raises(ConfigError, match=r"b\.toml: output\.dir: .* is also sortie 'a'"):
        load_campaign(campaign_dir / "campaign.toml")


def test_a_folder_of_configs_is_a_campaign(campaign_dir) -> None:
    spec = load_campaign(campaign_dir / "flights")
    assert [s.id for s in spec.sorties] == ["a", "b", "c"]
    assert spec.out_dir == (campaign_dir / "flights" / "campaign").resolve()


def test_a_folder_of_sortie_folders_is_a_campaign(campaign_dir) -> None:
    """FOLDER/<id>/config.toml: each sub-folder with a config.toml is a sortie named after
    the sub-folder, writing where its config says; other sub-folders are not sorties."""
    folder = campaign_dir / "sorties"
    text = sensor_subset((SAMPLE / "scenario.toml").read_text(), ("G1",))  # GPS only: quick
    for name in ("F102", "F101"):
        (folder / name).mkdir(parents=True)
        (folder / name / "config.toml").write_text(
            text.replace('file = "', 'file = "../../data/'))          # output: <id>/out
    (folder / "notes").mkdir()                                           # no config.toml
    spec = load_campaign(folder)
    assert [(s.id, s.config) for s in spec.sorties] == [
        (n, (folder / n / "config.toml").resolve()) for n in ("F101", "F102")]
    assert spec.out_dir == (folder / "campaign").resolve()
    result = CliRunner().invoke(main, ["campaign", "--quiet", "--workers", "2", str(folder)])
    assert result.exit_code == 0, result.output
    rec = json.loads((folder / "campaign" / "campaign.json").read_text())
    assert rec["counts"] == {"done": 2, "skipped": 0, "failed": 0}
    assert {s["id"]: s["out_dir"] for s in rec["sorties"]} == {
        n: str((folder / n / "out").resolve()) for n in ("F101", "F102")}
    assert all((folder / n / "out" / "fused.parquet").is_file() for n in ("F101", "F102"))


def test_a_sortie_whose_outputs_cannot_be_written_fails_with_exit_5(campaign_dir,
                                                                   monkeypatch) -> None:
    """A full disk while a sortie writes: its outcome is failed, exit 5, the one line
    ``rangeproc run`` prints (path and cause), and nothing of it published."""
    import errno

    import pyarrow.parquet as pq

    from rangeproc.campaign.sortie import run_sortie
    from rangeproc.campaign.spec import Sortie

    config = sortie_config(campaign_dir / "flights", "a", "a", sensors=("G1",))

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No "
                                    "space left on device")

    monkeypatch.setattr(pq, "write_table", full)
    outcome = run_sortie(Sortie("a", config.resolve()), resume=False)
    out = (campaign_dir / "out" / "a").resolve()
    assert (outcome.status, outcome.exit_code) == ("failed", 5)
    assert outcome.reason == f"cannot write {out / 'fused.parquet'}: No space left on device"
    assert not any(out.iterdir())

def test_campaign_records_assess_each_instrument(campaign_dir, open_page) -> None:
    """campaign.parquet holds each sortie's summary figures; sensor figures and the page
    exist; the page loads in Chromium without error, every figure shown."""
    for name in "ab":
        sortie_config(campaign_dir / "flights", name, name, sensors=("R1", "G1"))
    cfg_c = campaign_dir / "flights" / "c.toml"
    cfg_c.write_text(cfg_c.read_text().replace("../data/R1.csv", "../data/NOPE.csv"))
    spec = load_campaign(campaign_dir / "campaign.toml")
    result = run_campaign(spec, workers=2)
    folder = campaign_dir / "records"
    table = pd.read_parquet(folder / "campaign.parquet")
    assert sorted(set(zip(table.sortie, table.sensor))) == [
        ("a", "G1"), ("a", "R1"), ("b", "G1"), ("b", "R1")]
    for o in result.outcomes[:2]:
        summary = json.loads((Path(o.out_dir) / "summary.json").read_text())
        row = table[(table.sortie == o.id) & (table.sensor == "R1")].iloc[0]
        r1 = summary["sensors"]["R1"]
        assert row.n_read == r1["n_read"] and row.n_rejected == r1["n_rejected"]
        assert row.noise_azimuth == r1["noise"]["azimuth"]["estimated"]
        assert row.cal_range == r1["calibration"]["range"]["estimate"]
        assert row.cal_range_sigma == r1["calibration"]["range"]["sigma"]
        assert not row.calibration_moved             # the same data twice cannot move
    assert (folder / "sensor_R1.png").is_file() and (folder / "sensor_G1.png").is_file()
    errors, images = open_page(folder / "index.html")
    assert errors == []
    assert len(images) >= 2 and all(done and width > 300 for _, done, width in images)
    text = (folder / "index.html").read_text()
    assert "NOPE.csv: file not found" in text and 'href="../out/a/report/index.html"' in text


def test_moved_flags_a_calibration_beyond_three_combined_sigmas() -> None:
    from rangeproc.campaign.summary import moved_between_sorties

    table = pd.DataFrame({
        "sensor": ["R1", "R2", "R1", "R1", "R1", "R1"],
        "cal_range": [0.0, 9.0, 0.5, float("nan"), 5.0, 5.2],
        "cal_range_sigma": [1.0, 1.0, 1.0, float("nan"), 1.0, 1.0]})
    # R1: 0.0 -> 0.5 (0.35 combined sigmas), skip the unobservable sortie, 0.5 -> 5.0
    # (3.18 > 3), 5.0 -> 5.2; R2 has no previous sortie
    assert moved_between_sorties(table, "cal_range", "cal_range_sigma").tolist() == [
        False, False, False, False, True, False]


def test_local_workers_run_without_the_statistical_profiler():
    """The local cluster's worker processes get ``LOCAL_WORKER_CONFIG`` (no 10 ms stack
    sampling for a dashboard nobody serves)."""
    import dask

    from rangeproc.campaign.runner import _client

    client, where = _client(None, 1, 1)
    try:
        seen = client.run(lambda: dask.config.get("distributed.worker.profile.enabled"))
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()
    assert where.startswith("LocalCluster") and list(seen.values()) == [False]
    assert dask.config.get("distributed.worker.profile.enabled")   # this process: unchanged


def test_each_worker_gets_its_share_of_the_cores_and_loads_the_kernels_at_start():
    """Two local workers on this machine: each sortie thread gets half the cores (at least
    one), and the plugin's warm-up has loaded the EKF kernel before any sortie ran."""
    from rangeproc.campaign.runner import _client
    from rangeproc.campaign.worker import SortieWorker, threads_by_host
    from rangeproc.parallel import CORES_ENV, usable_cores

    def loaded() -> int:
        from rangeproc.estimation.forward_loop import forward_kernel
        from rangeproc.families import family
        return len(forward_kernel(family("ekf")).signatures)

    client, _ = _client(None, 2, 2)
    try:
        hosts = threads_by_host(client)
        assert sum(hosts.values()) == 2
        client.register_plugin(SortieWorker(hosts))
        shares = client.run(lambda: (os.environ.get(CORES_ENV), usable_cores()))
        kernels = client.run(loaded)
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()
    share = max(1, usable_cores() // 2)
    assert list(shares.values()) == [(str(share), share)] * 2
    assert all(n >= 1 for n in kernels.values())


def test_core_share_and_host_of_an_address():
    from rangeproc.campaign.worker import _host, core_share

    assert core_share(16, 16) == 1 and core_share(16, 4) == 4 and core_share(2, 3) == 1
    assert core_share(8, 0) == 8
    assert _host("tcp://10.0.0.5:40123") == "10.0.0.5"
    assert _host("tcp://[::1]:8786") == "[::1]"
