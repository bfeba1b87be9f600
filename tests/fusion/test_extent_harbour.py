"""Seeded Monte Carlo on the simulator's harbour kind (extended hulls, antennas off the hull's
centre, AR(1) camera errors, truth at the antenna): the objects rangeproc finds hold at least
90 % of their epochs inside 3 sigma east and north, pooled over the draws, and a sigma that
leaves the reference point's spread out does not (the negative control)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import describe, invoke

from rangeproc.evaluate.metrics import evaluate_run
from rangeproc.fusion.extent import Extent, extent_covariance
from rangeproc.simulate import simulate_multi

SEEDS = (1, 2, 3)
DURATION = 120.0            # s: the ship leaves its quay within it
CUTOFF = 20.0               # m: the evaluation's pairing distance (a boat's hull and wake)


def _run(tmp: Path, seed: int) -> tuple[Path, Path]:
    config = simulate_multi(tmp / f"h{seed}", kind="harbour", seed=seed, duration=DURATION)
    result = invoke(["run", "--quiet", config])
    assert result.exit_code == 0, describe(result)
    return config.parent / "out", config.parent / "truth.csv"


def _inside(out: Path, truth: Path, spread: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Per epoch of the best matches: |error| <= 3 sigma east, north ((N,) bool each), with the
    written sigma or (``spread`` False) that sigma less the reference point's spread."""
    fused = pd.read_parquet(out / "fused.parquet")
    if fused.empty:                                          # a draw where none is found
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
    m = evaluate_run(out, truth, cutoff=CUTOFF)
    true = pd.read_csv(truth)
    targets = json.loads((out / "summary.json").read_text())["targets"]
    east, north = [], []
    for tid, row in m["multi"]["truth"].items():
        match = row["best_match"]
        if match is None:
            continue
        f = fused[fused.target_id == match]
        t = true[true.target_id == tid]
        f = f[(f.time >= t.time.min()) & (f.time <= t.time.max())]
        err = np.c_[f.e - np.interp(f.time, t.time, t.e), f.n - np.interp(f.time, t.time, t.n)]
        close = np.hypot(err[:, 0], err[:, 1]) < CUTOFF      # the epochs the match holds
        var = np.c_[f.sigma_e**2, f.sigma_n**2]
        if not spread:
            entry = targets[match]
            v = entry["reference_sigma_m"] ** 2
            ext = entry["extent_sigma_m"]
            ref = Extent(along=max(v, ext["along"] ** 2), across=max(v, ext["across"] ** 2))
            C = extent_covariance(ref, np.c_[f.ve, f.vn])
            var = var - np.c_[C[:, 0, 0], C[:, 1, 1]]
        ok = np.abs(err) <= 3 * np.sqrt(np.maximum(var, 0.0))
        east.append(ok[close, 0])
        north.append(ok[close, 1])
    return np.concatenate(east), np.concatenate(north)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("harbour_mc")
    return [_run(tmp, s) for s in SEEDS]


def test_found_objects_hold_three_sigma(runs):
    east, north = (np.concatenate(a) for a in zip(*(_inside(o, t) for o, t in runs)))
    print(f"harbour MC: {east.size} epochs, inside 3 sigma east {east.mean():.3f}, "
          f"north {north.mean():.3f}")
    assert east.size > 500
    assert east.mean() >= 0.9 and north.mean() >= 0.9, (east.mean(), north.mean())


def test_a_sigma_without_the_spread_fails(runs):
    # negative control: the smoother's own sigma, without the reference point's spread
    east, north = (np.concatenate(a) for a in zip(*(_inside(o, t, False) for o, t in runs)))
    print(f"without the spread: east {east.mean():.3f}, north {north.mean():.3f}")
    assert min(east.mean(), north.mean()) < 0.9, (east.mean(), north.mean())
