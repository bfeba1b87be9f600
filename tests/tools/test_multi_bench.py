"""bench/multi.py's acceptance (``make multi``): the criteria an object row misses at either
cutoff, the per-kind counts, and the oracle's own coverage that tells a shortfall of the
sensors from one of the association (made-up rows and a hand-made output, no simulation)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))          # bench/ is scripts, not a package
import multi as bench  # noqa: E402


def row(**kw) -> dict:
    """An object row that meets every criterion at both cutoffs, changed by ``kw``."""
    r = {"kind": "scale", "seed": 1, "object": "U1", "match": "O1", "rmse": 80.0,
         "oracle_rmse": 80.0, "ratio": 1.0, "coverage_observed": 0.95,
         "coverage_scaled": 0.99, "oracle_coverage_scaled": 0.99, "swaps": 0,
         "row_purity": 1.0}
    r.update(kw)
    return r


def test_scaled_cutoff_accepts_what_only_the_sensor_limits():
    """A surveillance-only object 80 m off its truth, as its oracle: outside at 50 m, inside
    at the scaled cutoff; a gap (scaled coverage short) stays outside (negative control)."""
    coarse = row(coverage_observed=0.4)
    assert bench.misses(coarse, "coverage_observed") == ["coverage"]
    assert bench.misses(coarse) == []
    gap = row(coverage_observed=0.4, coverage_scaled=0.7)
    assert bench.misses(gap) == ["coverage"]
    assert bench.misses(row(swaps=1, ratio=1.3, row_purity=0.9)) == ["swaps", "ratio", "purity"]
    assert bench.misses(row(ratio=None)) == ["ratio"]


def test_acceptance_counts_per_kind_and_names_the_misses():
    rows = [row(), row(object="U2", coverage_observed=0.3),
            row(object="U3", coverage_observed=0.5, coverage_scaled=0.8,
                oracle_coverage_scaled=0.8),
            row(object="U4", coverage_observed=0.5, coverage_scaled=0.8,
                oracle_coverage_scaled=1.0),
            row(kind="crossing", object="T1", oracle_rmse=1.0, rmse=1.0),
            {"kind": "crossing", "seed": 2, "error": "boom"}]
    acc = bench.acceptance(rows)
    assert acc["scale"]["objects"] == 4 and acc["scale"]["accepted_50m"] == 1
    assert acc["scale"]["accepted_scaled"] == 2
    assert acc["scale"]["outside"] == ["1 U3: coverage (oracle too)", "1 U4: coverage"]
    assert acc["crossing"] == {"objects": 1, "errors": 1, "accepted_50m": 1,
                               "accepted_scaled": 1, "outside": [], "honest": 0,
                               "scored_honesty": 0, "not_honest": []}


def test_honesty_counts_shares_under_the_limit_and_skips_moored_and_unmatched():
    """Inside 3 sigma on 0.94 of the epochs is under a point object's 0.95 but meets a harbour
    hull's 0.90; a moored object and a row without the share are not scored."""
    rows = [row(inside_3sigma=0.99, oracle_inside_3sigma=0.99),
            row(object="U2", inside_3sigma=0.94, oracle_inside_3sigma=0.99),
            row(object="U3", inside_3sigma=None),
            row(kind="harbour", object="B1", inside_3sigma=0.94),
            row(kind="harbour", object="M1", role="moored", inside_3sigma=0.1)]
    acc = bench.acceptance(rows)
    assert (acc["scale"]["honest"], acc["scale"]["scored_honesty"]) == (1, 2)
    assert acc["scale"]["not_honest"] == ["1 U2: 0.94 (oracle 0.99)"]
    assert (acc["harbour"]["honest"], acc["harbour"]["scored_honesty"]) == (1, 1)
    assert bench.inside_3sigma({"inside_3sigma_enu": [0.99, 0.9, 1.0]}) == 0.9
    assert bench.inside_3sigma({}) is None


@pytest.fixture()
def made_run(tmp_path: Path) -> Path:
    """An object flying east at 100 m/s for 100 s (truth at 10 Hz) and an output of it, 10 Hz:
    100 m north of it over the last 40 s, nothing at all over 20-40 s."""
    t = np.round(np.arange(0.0, 100.001, 0.1), 3)
    pd.DataFrame({"target_id": "U1", "time": t, "e": 100.0 * t, "n": 0.0, "u": 1000.0}
                 ).to_csv(tmp_path / "truth.csv", index=False)
    keep = (t < 20.0) | (t > 40.0)
    out = tmp_path / "out"
    out.mkdir()
    pd.DataFrame({"time": t[keep], "target_id": "U1", "e": 100.0 * t[keep],
                  "n": np.where(t[keep] > 60.0, 100.0, 0.0), "u": 1000.0}
                 ).to_parquet(out / "fused.parquet", index=False)
    return tmp_path


def test_oracle_coverage_counts_the_gap_and_the_cutoff(made_run: Path):
    c50, c300 = bench.oracle_coverage(made_run / "out", made_run / "truth.csv", "U1",
                                      (0.0, 100.0), (50.0, 300.0))
    assert c50 == pytest.approx(0.4, abs=0.02)    # 0-20 s and 40-60 s
    assert c300 == pytest.approx(0.8, abs=0.02)   # all but the gap
    # observed from 50 s on only: the gap is outside the span
    (c300_late,) = bench.oracle_coverage(made_run / "out", made_run / "truth.csv", "U1",
                                         (50.0, 100.0), (300.0,))
    assert c300_late == pytest.approx(1.0)
    assert bench.oracle_coverage(made_run / "out", made_run / "truth.csv", "U9",
                                 (0.0, 100.0), (50.0,)) == [None]
