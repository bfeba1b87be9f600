"""A lost plot track's stray tail (``tracking.plot_tails``): the last plots it took after
coasting through missed scans go back to clutter; tracks that miss fewer scans, or whose
last run could confirm a track of its own, keep their plots."""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plot_tails import STRAY_MISSES, stray_tails
from rangeproc.tracking.plots import CONFIRM_SCANS


def _tracks(runs: dict[int, list[int]], clutter: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(clock, label) of plots in the given scans per track, and clutter plots."""
    clock = [float(s) for scans in runs.values() for s in scans] + [float(s) for s in clutter]
    label = [k for k, scans in runs.items() for _ in scans] + [-1] * len(clutter)
    order = np.argsort(clock, kind="stable")
    return np.asarray(clock)[order], np.asarray(label, dtype=np.int64)[order]


def test_a_lone_plot_after_missed_scans_goes_back_to_clutter() -> None:
    stray = 15 + STRAY_MISSES + 1                       # STRAY_MISSES scans missed
    runs = {0: [*range(16), stray],                     # lost at 15, a stray plot later
            1: [*range(11), 10 + STRAY_MISSES],          # one scan fewer missed: kept
            2: [*range(6), *range(6 + STRAY_MISSES, 6 + STRAY_MISSES + CONFIRM_SCANS)],
            3: [*range(6), *range(6 + STRAY_MISSES, 6 + STRAY_MISSES + CONFIRM_SCANS - 1)]}
    clock, label = _tracks(runs, clutter=[2, 7, 30])
    out = stray_tails(clock, label)
    assert out[(label == 0) & (clock == stray)].tolist() == [-1]      # the stray plot
    assert (out[(label == 0) & (clock < stray)] == 0).all()           # the rest stays
    assert (out[label == 1] == 1).all()                  # fewer misses: one object
    assert (out[label == 2] == 2).all()                  # a run that could confirm alone
    tail3 = (label == 3) & (clock >= 6 + STRAY_MISSES)
    assert (out[tail3] == -1).all() and (out[(label == 3) & ~tail3] == 3).all()
    assert (out[label == -1] == -1).all()
    assert (stray_tails(clock, np.full(clock.size, -1)) == -1).all()


def test_revisits_of_a_radar_without_scans_count_as_scans() -> None:
    """Plots in no scan order: the clock counts revisits, jittered. A last plot 3.04
    revisits after the one before (2 missed) stays; one 4.1 revisits after (3 missed)
    goes back to clutter."""
    clock = np.array([0.0, 0.5, 1.02, 1.5, 1.98, 2.45, 3.01, 3.5, 6.05, 7.6])
    label = np.array([0, 1, 0, 1, 0, 1, 0, 1, 0, 1])
    assert stray_tails(clock, label).tolist() == [0, 1, 0, 1, 0, 1, 0, 1, 0, -1]


def test_stray_runs_are_stripped_back_to_a_run_that_could_confirm() -> None:
    """A track that coasted out of view and took one clutter plot after a long silence and
    another after that: both go back to clutter, not only the last (the first would have
    been held as the track's end, 200 m off its object). A short run between two runs that
    could confirm a track of their own stays: only the tail is stripped."""
    gap = STRAY_MISSES + 1
    runs = {0: [*range(20), 20 + gap, 20 + 2 * gap],                  # two lone strays
            1: [*range(10), *range(10 + gap, 10 + gap + CONFIRM_SCANS - 1),
                *range(20 + gap, 20 + gap + CONFIRM_SCANS)]}         # short run mid-track
    clock, label = _tracks(runs, clutter=[])
    out = stray_tails(clock, label)
    assert (out[(label == 0) & (clock >= 20)] == -1).all()
    assert (out[(label == 0) & (clock < 20)] == 0).all()
    assert (out[label == 1] == 1).all()


def test_the_forward_pass_counts_a_lidars_silence_as_missed_scans(tmp_path) -> None:
    """Harbour kind, seed 8: boat B1 leaves the lidar's view at 29 s; its lidar track then
    took clutter plots at 51 s and 61 s, the lidar writing no frame in between. Counted in
    the lidar's own frames the silence was one scan, the tail stood, and the boat's quick
    trajectory took the first stray plot's range: it drifted 300 m and the ship's lidar track
    joined it, so the boat became two objects. With the silence counted the boat is one."""
    import pandas as pd
    from rangeproc.evaluate import evaluate_run
    from rangeproc.pipeline import run
    from rangeproc.simulate import simulate_multi
    run(simulate_multi(tmp_path, kind="harbour", seed=8))
    multi = evaluate_run(tmp_path / "out", tmp_path / "truth.csv")["multi"]["truth"]
    assert multi["B1"]["swaps"] == 0, multi["B1"]
    got = pd.read_parquet(tmp_path / "out" / "association.parquet")
    true = pd.read_csv(tmp_path / "truth_association.csv", keep_default_na=False)
    lidar = got.merge(true.rename(columns={"target_id": "true"}), on=["sensor", "row"])
    lidar = lidar[(lidar.sensor == "LIDAR") & (lidar.true == "B1")
                  & (lidar.target_id.fillna("") != "")]
    assert lidar.target_id.nunique() == 1, lidar.target_id.value_counts().to_dict()
