"""bench/harbour.py: the harbour kind's acceptance (issues 41 and 42) on a real run of one seed
and on rows made to fail each criterion, so the score punishes what it should: a gap in the
moving span, a sigma too small, a swap, a moored boat made an object of."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))          # bench/ is scripts, not a package
import harbour as bench  # noqa: E402

GOOD = {"seed": 1, "object": "B1", "role": "boat", "coverage_moving": 0.97, "rmse": 5.0,
        "swaps": 0, "inside_3sigma": 0.99}


@pytest.mark.parametrize("change, missed", [
    ({}, []),
    ({"coverage_moving": 0.6}, ["coverage"]),
    ({"rmse": 9.0}, ["rmse"]),
    ({"rmse": None, "coverage_moving": 0.0}, ["coverage", "rmse"]),
    ({"swaps": 2}, ["swaps"]),
    ({"inside_3sigma": 0.4}, ["3 sigma"]),
    ({"role": "moored", "followed": 0.9}, ["followed"]),
    ({"role": "moored", "followed": 0.1, "coverage_moving": None}, []),
])
def test_each_criterion_is_missed_where_it_should_be(change, missed) -> None:
    assert bench.misses({**GOOD, **change}) == missed


def test_acceptance_counts_per_role() -> None:
    rows = [GOOD, {**GOOD, "object": "B2", "role": "ship", "coverage_moving": 0.5},
            {**GOOD, "object": "M1", "role": "moored", "followed": 0.0}, {"seed": 2, "error": "x"}]
    acc = bench.acceptance(rows)
    assert acc["boat"] == {"objects": 1, "accepted": 1, "outside": []}
    assert acc["ship"]["accepted"] == 0 and acc["ship"]["outside"] == ["1 B2: coverage"]
    assert acc["moored"]["accepted"] == 1 and acc["run"]["outside"] == ["2 : run failed"]


def _cut(out: Path, obj_match: str, t0: float, t1: float) -> None:
    """Remove output object ``obj_match``'s epochs in [t0, t1] from ``out/fused.parquet``."""
    f = pd.read_parquet(out / "fused.parquet")
    drop = (f.target_id.astype(str) == obj_match) & (f.time >= t0) & (f.time <= t1)
    f[~drop].to_parquet(out / "fused.parquet", index=False)


@pytest.fixture(scope="module")
def seed10(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[dict], Path]:
    """Seed 10 (its ferry heads east: yaw about 100 deg) simulated, run and scored
    (rangeproc only); its rows and work folder."""
    work = tmp_path_factory.mktemp("harbour")
    return bench.seed_rows(10, work, gnn=False), work


def test_the_baseline_reads_plots_in_the_ferry_frame(seed10) -> None:
    """Stone Soup's plots (``bench/autoferry.read_plots``) of the harbour scene, where the
    azimuth is measured from the ferry's deck and the sensors sit off the INS point, lie on
    the hulls that ``truth_association.csv`` says they came from."""
    import autoferry
    scen = seed10[1] / "harbour_10"
    plots = autoferry.read_plots(scen)
    assoc = pd.read_csv(scen / "truth_association.csv", keep_default_na=False)
    truth = pd.read_csv(scen / "truth.csv")
    for obj in ("B1", "B2"):
        rows = assoc[(assoc.target_id == obj) & (assoc.sensor == "RADAR")].row.to_numpy()
        mine = (plots.sensor == "RADAR") & np.isin(plots.row, rows)
        tb = truth[truth.target_id == obj]
        he = np.interp(plots.t[mine], tb.time, tb.hull_e)
        hn = np.interp(plots.t[mine], tb.time, tb.hull_n)
        miss = np.hypot(plots.p[mine, 0] - he, plots.p[mine, 1] - hn)
        assert mine.sum() > 10 and np.median(miss) < 20.0, (obj, np.median(miss))


def test_a_seed_is_scored_and_a_gap_and_a_small_sigma_cost(seed10) -> None:
    rows, tmp_path = seed10
    by = {r["object"]: r for r in rows}
    assert {r["role"] for r in rows} >= {"boat", "ship", "moored"}
    boat = by["B1"]
    assert boat["match"] is not None and boat["coverage_moving"] > 0.8
    assert boat["rmse_hull"] is not None and boat["antenna_offset_m"] > 0
    scen, out = tmp_path / "harbour_10", tmp_path / "harbour_10" / "out"
    events = json.loads((scen / "truth_events.json").read_text())
    t0, t1 = events["objects"]["B1"]["moving"]
    _cut(out, boat["match"], t0 + 10.0, t0 + 10.0 + 0.5 * (t1 - t0))  # half the span blank
    gap = bench.score(out, scen, events)["B1"]
    assert gap["coverage_moving"] < boat["coverage_moving"] - 0.4
    f = pd.read_parquet(out / "fused.parquet")
    sigma = [c for c in f.columns if c.startswith("sigma_")]
    cov = [c for c in f.columns if c.startswith("cov_")]
    f[sigma], f[cov] = f[sigma] / 10.0, f[cov] / 100.0          # every sigma 10x too small
    f.to_parquet(out / "fused.parquet", index=False)
    small = bench.score(out, scen, events)["B1"]
    assert small["inside_3sigma"] < min(bench.INSIDE_LIMIT, gap["inside_3sigma"] - 0.3)
    assert "3 sigma" in bench.misses({**boat, **small})
