"""Multi-object evaluation: assignment, GOSPA, identity metrics, the CLI and bad input.

Truth objects move on straight lines sampled at 100 Hz, so linear interpolation to the 10 Hz
fused epochs is exact and every expected value can be computed by hand.
"""
from __future__ import annotations

import datetime as dt
import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from rangeproc.cli import main
from rangeproc.errors import DataError
from rangeproc.evaluate import evaluate_run, format_report
from rangeproc.evaluate import multi
from rangeproc.evaluate.multi import fused_on_epochs, grid_epochs, multi_object_metrics

T0 = 345_600.0
RATE = 10.0        # fused epochs per second
C = 50.0           # default cutoff (m)
MISS = C**2 / 2    # GOSPA (p=2, alpha=2) cost of one missed or false object: c^p / alpha (m^2)

# (start position m, velocity m/s) of the truth objects used below; 1 km or more apart
LINES = {"T1": ((100.0, 0.0, 5000.0), (200.0, -50.0, 3.0)),
         "T2": ((100.0, 1000.0, 5000.0), (200.0, -50.0, 3.0)),
         "T3": ((-3000.0, 0.0, 2000.0), (0.0, 150.0, 0.0))}


def _pos(tid: str, t: np.ndarray) -> np.ndarray:
    p0, v = (np.asarray(x) for x in LINES[tid])
    return p0 + np.outer(t - T0, v)


def _truth(ids=("T1", "T2"), span=(0.0, 20.0)) -> pd.DataFrame:
    t = T0 + span[0] + 0.01 * np.arange(int(round((span[1] - span[0]) * 100)) + 1)
    parts = []
    for tid in ids:
        p = _pos(tid, t)
        v = np.broadcast_to(np.asarray(LINES[tid][1]), p.shape)
        parts.append(pd.DataFrame({"target_id": tid, "time": t, "e": p[:, 0], "n": p[:, 1],
                                   "u": p[:, 2], "ve": v[:, 0], "vn": v[:, 1], "vu": v[:, 2]}))
    return pd.concat(parts, ignore_index=True)


def _epochs(k0: int, k1: int) -> np.ndarray:
    """Fused epochs k/RATE s after T0 for k0 <= k < k1 (whole multiples of the period)."""
    return (np.round(T0 * RATE) + np.arange(k0, k1)) / RATE


def _fused(fid: str, t: np.ndarray, pos: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"target_id": fid, "time": t, "e": pos[:, 0], "n": pos[:, 1],
                         "u": pos[:, 2], "ve": 0.0, "vn": 0.0, "vu": 0.0, "sigma_e": 1.0,
                         "sigma_n": 1.0, "sigma_u": 1.0})


def _follow(fid: str, tid: str, t: np.ndarray, offset=(0.0, 0.0, 0.0)) -> pd.DataFrame:
    return _fused(fid, t, _pos(tid, t) + np.asarray(offset))


def _run(tmp_path, fused_parts, truth, **kw):
    pd.concat(fused_parts, ignore_index=True).to_parquet(tmp_path / "fused.parquet")
    truth.to_csv(tmp_path / "truth.csv", index=False)
    return evaluate_run(tmp_path, tmp_path / "truth.csv", **kw)


def test_perfect_match_with_other_ids(tmp_path):
    t = _epochs(10, 151)                 # fused covers 1 .. 15 s of the 0 .. 20 s truth
    t3 = t[t >= T0 + 5.0]                # T3 exists from 5 s only
    truth = pd.concat([_truth(("T1", "T2"), span=(1.0, 15.0)),
                       _truth(("T3",), span=(5.0, 15.0))])
    m = _run(tmp_path, [_follow("O1", "T2", t), _follow("O2", "T1", t),
                        _follow("O3", "T3", t3)], truth)
    # truth ids are scored by their best match: errors, 3-sigma share and NEES under B1 -> O1
    assert {k: v["fused_id"] for k, v in m["targets"].items()} == {"T1": "O2", "T2": "O1",
                                                                  "T3": "O3"}
    assert m["targets"]["T1"]["pos_rmse"] == pytest.approx(0.0, abs=1e-9)
    assert m["targets"]["T1"]["inside_3sigma_enu"] == [1.0, 1.0, 1.0]
    assert m["targets"]["T3"]["n_epochs"] == t3.size and m["unmatched"] == []
    mu = m["multi"]
    assert mu["n_epochs"] == t.size and mu["cutoff_m"] == C
    assert mu["gospa"]["mean"] == pytest.approx(0.0, abs=1e-9)
    assert mu["gospa"]["max"] == pytest.approx(0.0, abs=1e-9)
    for tid, fid, n in (("T1", "O2", t.size), ("T2", "O1", t.size), ("T3", "O3", t3.size)):
        r = mu["truth"][tid]
        assert r["best_match"] == fid and r["n_epochs"] == n == r["best_match_epochs"]
        assert r["best_match_rmse"] == pytest.approx(0.0, abs=1e-9)
        assert r["assigned_rmse"] == pytest.approx(0.0, abs=1e-9)
        assert r["coverage"] == 1.0
        assert r["swaps"] == 0 and r["fragmentation"] == 0
        assert mu["fused"][fid] == {"n_epochs": n, "majority_truth": tid, "purity": 1.0,
                                    "false_epochs": 0}
    assert mu["totals"]["n_truth"] == 3 and mu["totals"]["n_fused"] == 3
    assert mu["totals"]["swaps"] == 0
    json.dumps(m)
    text = format_report(m)
    assert any(ln.startswith("T1>O2") for ln in text.splitlines())
    rows = [ln.split() for ln in text.splitlines() if ln.split()[:1] in (["T1"], ["T2"])]
    assert rows == [["T1", "O2", "0.00", "0.00", "0.00", "1.000", "0", "0"],
                    ["T2", "O1", "0.00", "0.00", "0.00", "1.000", "0", "0"]]
    assert "GOSPA" in text


def test_identity_swap(tmp_path):
    t = _epochs(0, 100)
    first = np.arange(t.size) < 60       # A follows T1 for 60 epochs, then T2; B the reverse
    a = np.where(first[:, None], _pos("T1", t), _pos("T2", t))
    b = np.where(first[:, None], _pos("T2", t), _pos("T1", t))
    mu = _run(tmp_path, [_fused("A", t, a), _fused("B", t, b)], _truth(span=(0, 9.9)))["multi"]
    assert mu["gospa"]["max"] == pytest.approx(0.0, abs=1e-9)
    for tid, best in (("T1", "A"), ("T2", "B")):
        r = mu["truth"][tid]
        assert r["swaps"] == 1 and r["fragmentation"] == 0 and r["coverage"] == 1.0
        assert r["best_match"] == best and r["best_match_epochs"] == 60
        # the best match sits on the other object (1000 m away) for 40 of 100 epochs
        assert r["best_match_rmse"] == pytest.approx(1000.0 * np.sqrt(0.4))
        assert r["assigned_rmse"] == pytest.approx(0.0, abs=1e-9)
    assert mu["fused"]["A"]["purity"] == pytest.approx(0.6)
    assert mu["fused"]["A"]["majority_truth"] == "T1"
    assert mu["fused"]["B"]["majority_truth"] == "T2"
    assert mu["totals"]["swaps"] == 2


@pytest.mark.parametrize("cutoff", [50.0, 20.0])
def test_missed_object(tmp_path, cutoff):
    t = _epochs(0, 50)
    m = _run(tmp_path, [_follow("O1", "T1", t)], _truth(span=(0, 4.9)), cutoff=cutoff)
    g = m["multi"]["gospa"]
    # one missed object per epoch: d^2 = c^p / alpha = c^2 / 2
    assert g["missed_mean"] == pytest.approx(cutoff**2 / 2)
    assert g["mean"] == pytest.approx(np.sqrt(cutoff**2 / 2))
    assert g["max"] == pytest.approx(np.sqrt(cutoff**2 / 2))
    assert g["false_mean"] == 0.0 and g["localisation_mean"] == pytest.approx(0.0, abs=1e-12)
    assert g["n_missed_mean"] == pytest.approx(1.0)
    r = m["multi"]["truth"]["T2"]
    assert r["coverage"] == 0.0 and r["best_match"] is None and r["best_match_rmse"] is None
    assert m["multi"]["truth"]["T1"]["coverage"] == 1.0
    assert "T2      -" in format_report(m)


def test_coverage_over_the_observed_span(tmp_path):
    """An object first measured halfway through is covered over the half it was seen."""
    t = _epochs(0, 100)
    late = t[t >= T0 + 5.0]                      # T2 tracked from 5 s on, when first seen
    m = _run(tmp_path, [_follow("O1", "T1", t), _follow("O2", "T2", late)], _truth(span=(0, 9.9)),
             observed={"T2": (T0 + 5.0, T0 + 9.9), "T1": (T0, T0 + 9.9)})
    r2, r1 = m["multi"]["truth"]["T2"], m["multi"]["truth"]["T1"]
    assert r2["coverage"] == pytest.approx(0.5)
    assert r2["coverage_observed"] == 1.0 and r1["coverage_observed"] == 1.0
    m = _run(tmp_path, [_follow("O1", "T1", t)], _truth(span=(0, 9.9)),
             observed={"T2": (T0, T0 + 2.0)})
    assert m["multi"]["truth"]["T2"]["coverage_observed"] == 0.0
    assert m["multi"]["truth"]["T1"]["coverage_observed"] is None     # no span given


def test_false_object(tmp_path):
    t = _epochs(0, 50)
    far = _follow("O9", "T1", t, offset=(0.0, -1000.0, 0.0))
    m = _run(tmp_path, [_follow("T1", "T1", t), far], _truth(("T1",), span=(0, 4.9)))
    assert m["targets"]["T1"]["pos_rmse"] == pytest.approx(0.0, abs=1e-9)  # old keys still work
    assert m["unmatched"] == ["O9"]
    mu = m["multi"]
    assert mu["gospa"]["false_mean"] == pytest.approx(MISS)
    assert mu["gospa"]["missed_mean"] == 0.0
    assert mu["gospa"]["mean"] == pytest.approx(np.sqrt(MISS))
    assert mu["fused"]["O9"] == {"n_epochs": t.size, "majority_truth": None, "purity": 0.0,
                                 "false_epochs": t.size}
    assert mu["totals"]["false_epochs"] == t.size


@pytest.mark.parametrize("d, cutoff, loc, miss_false", [
    (3.0, 50.0, 9.0, 0.0),              # d < c: localisation d^2
    (60.0, 50.0, 0.0, 2 * MISS),        # d >= c: one missed plus one false object
    (60.0, 100.0, 3600.0, 0.0),
])
def test_localisation_and_cutoff(tmp_path, d, cutoff, loc, miss_false):
    t = _epochs(0, 30)
    off = np.array([0.6, 0.0, 0.8]) * d
    mu = _run(tmp_path, [_follow("O1", "T1", t, off), _follow("O2", "T2", t)],
              _truth(span=(0, 2.9)), cutoff=cutoff)["multi"]
    g = mu["gospa"]
    assert g["localisation_mean"] == pytest.approx(loc)
    assert g["missed_mean"] + g["false_mean"] == pytest.approx(miss_false)
    assert g["mean"] == pytest.approx(np.sqrt(loc + miss_false))
    r = mu["truth"]["T1"]
    if loc:
        assert r["best_match_rmse"] == pytest.approx(d) and r["coverage"] == 1.0
        assert r["assigned_rmse"] == pytest.approx(d)
    else:
        assert r["coverage"] == 0.0 and r["best_match"] is None


@pytest.mark.parametrize("other", [False, True])
@pytest.mark.parametrize("gap, fragments", [(2, 0), (3, 1), (10, 1)])
def test_fragmentation(tmp_path, gap, fragments, other):
    """O1 follows T1 with ``gap`` epochs missing; with ``other`` O2 (on T2) fills those epochs,
    else the evaluation epochs are filled at the fused rate."""
    t = _epochs(0, 40)
    keep = (np.arange(40) < 20) | (np.arange(40) >= 20 + gap)
    parts = [_follow("O1", "T1", t[keep])] + ([_follow("O2", "T2", t)] if other else [])
    mu = _run(tmp_path, parts, _truth(("T1", "T2") if other else ("T1", "T3"),
                                      span=(0, 3.9)))["multi"]
    r = mu["truth"]["T1"]
    assert mu["n_epochs"] == 40
    assert r["fragmentation"] == fragments and r["swaps"] == 0
    assert r["coverage"] == pytest.approx((40 - gap) / 40)
    # the missed epochs of T1 are in the GOSPA (and T3 is missed throughout without O2)
    missed = gap if other else gap + 40
    assert mu["gospa"]["missed_mean"] == pytest.approx(MISS * missed / 40)


def test_grid_epochs_fall_on_the_output_epochs():
    g = grid_epochs(T0 + 0.05, T0 + 0.55, 0.1 * (1 + 1e-9))      # a median of output steps
    np.testing.assert_array_equal(g, (np.round(T0 * 10) + np.arange(1, 6)) / 10)
    np.testing.assert_allclose(grid_epochs(0.0, 1.0, 0.3), [0.0, 0.3, 0.6, 0.9])


def test_fused_on_epochs_interpolates_within_steps_not_across_gaps():
    t = np.array([0.0, 0.1, 0.2, 0.7, 0.75, 0.8])
    pos = np.repeat(t[:, None] * 10.0, 3, axis=1)
    got = fused_on_epochs(t, pos, np.arange(10) / 10.0, 0.1)[:, 0]
    np.testing.assert_allclose(got[[0, 1, 2, 7, 8]], [0.0, 1.0, 2.0, 7.0, 8.0])
    assert np.isnan(got[3:7]).all() and np.isnan(got[9])     # a gap, and after the last row
    mid = fused_on_epochs(np.array([0.0, 0.15]), np.zeros((2, 3)) + [[0.0], [3.0]],
                          np.array([0.1]), 0.1)
    np.testing.assert_allclose(mid, [[2.0, 2.0, 2.0]])        # 0.15 s apart: interpolated


def test_matches_stone_soup_gospa(monkeypatch):
    """Per-epoch GOSPA against Stone Soup's GOSPAMetric on a random case with objects appearing,
    disappearing, missed (errors beyond c) and false. Stone Soup's ``distance`` is the p-th root
    (m), its ``localisation``, ``missed`` and ``false`` are the un-rooted parts (m^2): compare
    our ``gospa`` with the former and our parts with the latter. Objects are crowded so that
    many epochs need the full assignment (not only unambiguous within-cutoff pairs)."""
    ospa = pytest.importorskip("stonesoup.metricgenerator.ospametric")
    state = pytest.importorskip("stonesoup.types.state")
    calls = []
    lsa = multi.linear_sum_assignment
    monkeypatch.setattr(multi, "linear_sum_assignment", lambda c: calls.append(c) or lsa(c))
    rng = np.random.default_rng(11)
    metric = ospa.GOSPAMetric(p=2, c=C)
    base = dt.datetime(2024, 1, 1)
    for _ in range(10):
        k_n = 80
        te = np.arange(k_n) / RATE
        truths, rows = {}, []
        for i in range(int(rng.integers(2, 5))):
            p0, v = rng.normal(0.0, 20.0, 3), rng.normal(0.0, 5.0, 3)
            a, b = sorted(rng.integers(0, k_n, 2))
            truths[f"T{i}"] = (p0, v, te[a], te[b] + 0.05)
            ts = np.arange(te[a] * 100, (te[b] + 0.05) * 100 + 0.5) / 100
            rows.append((np.full(ts.size, f"T{i}"), ts, p0 + np.outer(ts, v)))
        fused = []
        for j, (p0, v, ta, tb) in enumerate(truths.values()):   # noisy tracks, partial spans
            sel = (te >= ta - 1.0) & (te <= tb + 1.0) & (rng.random(k_n) < 0.8)
            fused.append((f"O{j}", te[sel], p0 + np.outer(te[sel], v)
                          + rng.normal(0.0, 25.0, (sel.sum(), 3))))
        for j in range(int(rng.integers(0, 3))):                # clutter-like false objects
            sel = rng.random(k_n) < 0.5
            fused.append((f"F{j}", te[sel], rng.normal(0.0, 50.0, (sel.sum(), 3))))
        ev = multi_object_metrics(
            np.concatenate([f[1] for f in fused]),
            np.concatenate([np.full(f[1].size, f[0]) for f in fused]),
            np.concatenate([f[2] for f in fused]),
            np.concatenate([r[1] for r in rows]), np.concatenate([r[0] for r in rows]),
            np.concatenate([r[2] for r in rows]), cutoff=C)
        assert ev.t.size > 0 and (ev.missed > 0).any() and (ev.localisation > 0).any()
        for k, tk in enumerate(ev.t):
            stamp = base + dt.timedelta(seconds=float(tk))
            meas = [state.State(p[np.isclose(ft, tk)][0].reshape(3, 1), timestamp=stamp)
                    for _, ft, p in fused if np.isclose(ft, tk).any()]
            tru = [state.State((p0 + tk * v).reshape(3, 1), timestamp=stamp)
                   for p0, v, ta, tb in truths.values() if ta <= tk <= tb]
            if not meas and not tru:     # an epoch filled in a gap of the whole output
                assert ev.gospa[k] == 0.0
                continue
            ref = metric.compute_gospa_metric(meas, tru)[0].value
            assert ev.gospa[k] == pytest.approx(ref["distance"], rel=1e-9, abs=1e-9)
            for part in ("localisation", "missed", "false"):
                assert getattr(ev, part)[k] == pytest.approx(abs(ref[part]), rel=1e-9,
                                                             abs=1e-9)
    assert len(calls) > 100 and max(c.shape[0] for c in calls) >= 3


def test_single_matching_object_has_no_multi(tmp_path):
    t = _epochs(0, 20)
    m = _run(tmp_path, [_follow("T1", "T1", t, (1.0, 0.0, 0.0))], _truth(("T1",)))
    assert "multi" not in m and m["targets"]["T1"]["pos_rmse"] == pytest.approx(1.0)
    assert "multi-object" not in format_report(m)


def test_cli_multi_table_and_outputs(tmp_path):
    t = _epochs(0, 50)
    pd.concat([_follow("O1", "T2", t, (3.0, 0.0, 0.0)), _follow("O2", "T1", t)]
              ).to_parquet(tmp_path / "fused.parquet")
    _truth(("T1", "T2", "T3"), span=(0, 4.9)).to_parquet(tmp_path / "truth.parquet")
    res = CliRunner().invoke(main, ["evaluate", str(tmp_path), str(tmp_path / "truth.parquet"),
                                    "--cutoff", "30"])
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert any(ln.startswith("multi-object: 3 truth, 2 fused objects") for ln in lines)
    row = {ln.split()[0]: ln.split() for ln in lines if ln.split()[:1] in (["T1"], ["T2"],
                                                                           ["T3"])}
    assert row["T1"][1:3] == ["O2", "0.00"] and row["T2"][1:3] == ["O1", "3.00"]
    assert row["T3"][1] == "-" and row["T3"][5] == "0.000"
    gospa_line = [ln for ln in lines if ln.startswith("GOSPA")]
    assert len(gospa_line) == 1 and f"missed {30.0**2 / 2:.2f}" in gospa_line[0]
    saved = json.loads((tmp_path / "evaluation.json").read_text())
    assert saved["multi"]["cutoff_m"] == 30.0
    assert saved["multi"]["truth"]["T2"]["best_match_rmse"] == pytest.approx(3.0)
    assert saved["multi"]["gospa"]["mean"] == pytest.approx(np.sqrt(9.0 + 450.0))
    series = pd.read_parquet(tmp_path / "evaluation_gospa.parquet")
    assert len(series) == 50 and series["missed"].to_numpy() == pytest.approx(450.0)
    assert saved["multi"]["gospa"]["series_file"].endswith("evaluation_gospa.parquet")


@pytest.mark.parametrize("where", ["start", "middle", "end"])
def test_a_minute_without_output_is_a_minute_lost(tmp_path, where):
    """Scores count every epoch of the truth's span: an object left unreported for one minute
    of a ten-minute span loses that minute in coverage and pays one missed object per epoch in
    GOSPA, wherever the minute lies (also before the first or after the last fused epoch)."""
    t = _epochs(0, 6000)                            # 600 s at 10 Hz
    k = np.arange(t.size)
    lost = {"start": k < 600, "middle": (k >= 3000) & (k < 3600), "end": k >= 5400}[where]
    truth = _truth(("T1", "T2"), span=(0.0, 599.9))
    mu = _run(tmp_path, [_follow("O1", "T1", t[~lost]), _follow("O2", "T2", t)], truth)["multi"]
    assert mu["n_epochs"] == 6000
    assert mu["truth"]["T1"]["coverage"] == pytest.approx(0.9)
    assert mu["truth"]["T2"]["coverage"] == 1.0
    assert mu["gospa"]["missed_mean"] == pytest.approx(MISS * 0.1)
    assert mu["truth"]["T1"]["fragmentation"] == (where == "middle")
    # the negative control: the same output without the gap loses nothing
    mu = _run(tmp_path, [_follow("O1", "T1", t), _follow("O2", "T2", t)], truth)["multi"]
    assert mu["truth"]["T1"]["coverage"] == 1.0 and mu["gospa"]["missed_mean"] == 0.0


def _cli_error(tmp_path, fused: pd.DataFrame, truth: pd.DataFrame) -> str:
    fused.to_parquet(tmp_path / "fused.parquet")
    truth.to_csv(tmp_path / "truth.csv", index=False)
    res = CliRunner().invoke(main, ["evaluate", str(tmp_path), str(tmp_path / "truth.csv")])
    assert res.exit_code == 2, res.output
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error: "), res.stderr
    assert not (tmp_path / "evaluation.json").exists()
    assert not (tmp_path / "evaluation_gospa.parquet").exists()
    return lines[0]


@pytest.mark.parametrize("case, expect", [
    ("truth_missing_u", "truth.csv: missing column 'u'"),
    ("truth_empty", "truth.csv: no data rows"),
    ("fused_empty", "fused.parquet: no data rows"),
    ("fused_missing_target_id", "fused.parquet: missing column 'target_id'"),
    ("truth_not_a_number", "truth.csv: row 4, column 'e': 'x' is not a number"),
    ("fused_duplicate_epoch", "fused.parquet: column 'time': target O1 has two rows"),
])
def test_bad_input_is_one_line(tmp_path, case, expect):
    t = _epochs(0, 10)
    fused = pd.concat([_follow("O1", "T1", t), _follow("O2", "T2", t)], ignore_index=True)
    truth = _truth()
    if case == "truth_missing_u":
        truth = truth.drop(columns=["u"])
    elif case == "truth_empty":
        truth = truth.iloc[:0]
    elif case == "fused_empty":
        fused = fused.iloc[:0]
    elif case == "fused_missing_target_id":
        fused = fused.drop(columns=["target_id"])
    elif case == "truth_not_a_number":
        truth["e"] = truth["e"].astype(object)
        truth.loc[3, "e"] = "x"
    else:
        fused = pd.concat([fused, fused.iloc[[2]]], ignore_index=True)
    assert expect in _cli_error(tmp_path, fused, truth)


def test_cutoff_must_be_positive(tmp_path):
    res = CliRunner().invoke(main, ["evaluate", str(tmp_path), str(tmp_path / "t.csv"),
                                    "--cutoff", "0"])
    assert res.exit_code == 2 and "--cutoff" in res.stderr
    with pytest.raises(ValueError, match="cutoff"):
        multi_object_metrics(np.zeros(1), np.array(["O1"]), np.zeros((1, 3)), np.zeros(1),
                             np.array(["T1"]), np.zeros((1, 3)), cutoff=-1.0)


def test_library_error_is_data_error(tmp_path):
    _truth().iloc[:0].to_csv(tmp_path / "truth.csv", index=False)
    _follow("O1", "T1", _epochs(0, 3)).to_parquet(tmp_path / "fused.parquet")
    with pytest.raises(DataError, match="truth.csv: no data rows"):
        evaluate_run(tmp_path, tmp_path / "truth.csv")


def test_two_dimensional_output_scored_by_best_match(tmp_path):
    """A 2-D tracker's output (sigma_u = 0 everywhere) matched to truth B1: the NEES is taken
    over east and north (2 dof) instead of failing on a singular covariance."""
    t = _epochs(0, 50)
    f = _follow("S1", "T1", t, (0.5, -0.5, 0.0))
    f["sigma_u"] = 0.0
    truth = _truth(("T1", "T2"), span=(0, 4.9))
    truth["target_id"] = truth["target_id"].map({"T1": "B1", "T2": "B2"})
    m = _run(tmp_path, [f], truth)
    b1 = m["targets"]["B1"]
    assert b1["fused_id"] == "S1" and b1["nees_dof"] == 2
    assert b1["nees_pos_mean"] == pytest.approx(0.5)          # (0.5^2 + 0.5^2) / 1^2
    assert "B2" not in m["targets"] and m["unmatched"] == []
