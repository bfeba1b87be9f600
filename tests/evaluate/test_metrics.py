"""evaluate_run / format_report on synthetic fused-truth pairs with known errors."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from rangeproc.errors import DataError
from rangeproc.evaluate import evaluate_run, format_report
from rangeproc.evaluate.metrics import interpolate_truth

T0 = 345_600.0


def _truth(n=2001, tid="T1") -> pd.DataFrame:
    t = T0 + 0.01 * np.arange(n)  # 20 s at 100 Hz, linear motion -> exact interpolation
    tau = t - T0
    return pd.DataFrame({"target_id": tid, "time": t, "e": 100.0 + 200.0 * tau,
                         "n": -50.0 * tau, "u": 5000.0 + 3.0 * tau, "ve": 200.0, "vn": -50.0,
                         "vu": 3.0, "ae": 0.0, "an": 0.0, "au": 0.0})


def _fused(truth: pd.DataFrame, t: np.ndarray, tid="T1", dpos=(0.0, 0.0, 0.0),
           dvel=(0.0, 0.0, 0.0), sigma=(1.0, 1.0, 1.0)) -> pd.DataFrame:
    cols = {}
    for k in ("e", "n", "u", "ve", "vn", "vu"):
        cols[k] = np.interp(t, truth["time"], truth[k])
    for k, d in zip(("e", "n", "u"), dpos):
        cols[k] = cols[k] + d
    for k, d in zip(("ve", "vn", "vu"), dvel):
        cols[k] = cols[k] + d
    df = pd.DataFrame({"target_id": tid, "time": t, **cols})
    for k, s in zip(("sigma_e", "sigma_n", "sigma_u"), sigma):
        df[k] = s
    return df


def _write(tmp_path, fused, truth, fmt="csv"):
    fused.to_parquet(tmp_path / "fused.parquet")
    path = tmp_path / f"truth.{fmt}"
    truth.to_csv(path, index=False) if fmt == "csv" else truth.to_parquet(path)
    return path


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_constant_offset(tmp_path, fmt):
    truth = _truth()
    t = T0 - 1.0 + 0.1 * np.arange(250)  # starts before and ends after the truth span
    fused = _fused(truth, t, dpos=(1.0, 0.0, 0.0), dvel=(0.0, 0.3, 0.4), sigma=(0.5, 2, 2))
    m = evaluate_run(tmp_path, _write(tmp_path, fused, truth, fmt))
    r = m["targets"]["T1"]
    inside = (t >= T0) & (t <= T0 + 20.0)
    assert r["n_epochs"] == inside.sum() == 201
    assert r["pos_rmse"] == pytest.approx(1.0)
    assert r["pos_rmse_enu"] == pytest.approx([1.0, 0.0, 0.0], abs=1e-9)
    assert r["pos_p95"] == pytest.approx(1.0)
    assert r["vel_rmse"] == pytest.approx(0.5)
    assert r["vel_rmse_enu"] == pytest.approx([0.0, 0.3, 0.4], abs=1e-9)
    assert r["inside_3sigma_enu"] == [1.0, 1.0, 1.0]
    assert r["nees_pos_mean"] == pytest.approx(4.0)  # (1 / 0.5)^2
    lo, hi = r["nees_pos_chi2_95"]
    assert lo == pytest.approx(chi2.ppf(0.025, 603) / 201) and lo < 3 < hi
    assert m["unmatched"] == []
    json.dumps(m)  # serialisable


def test_gaussian_errors_consistent_nees_and_coverage(tmp_path):
    rng = np.random.default_rng(3)
    truth = _truth()
    t = T0 + 0.005 + 0.01 * np.arange(1999)
    sig = np.array([2.0, 3.0, 5.0])
    # correlated covariance: rho_en = 0.6
    cov = np.diag(sig**2)
    cov[0, 1] = cov[1, 0] = 0.6 * sig[0] * sig[1]
    err = rng.multivariate_normal(np.zeros(3), cov, t.size)
    fused = _fused(truth, t, sigma=sig)
    fused[["e", "n", "u"]] += err
    fused["cov_en"], fused["cov_eu"], fused["cov_nu"] = cov[0, 1], 0.0, 0.0
    r = evaluate_run(tmp_path, _write(tmp_path, fused, truth))["targets"]["T1"]
    lo, hi = r["nees_pos_chi2_95"]
    assert lo < r["nees_pos_mean"] < hi
    np.testing.assert_allclose(r["pos_rmse_enu"], sig, rtol=0.06)
    assert all(0.99 < f <= 1.0 for f in r["inside_3sigma_enu"])
    full = np.mean(np.einsum("ni,ij,nj->n", err, np.linalg.inv(cov), err))
    assert r["nees_pos_mean"] == pytest.approx(full, rel=1e-6)
    # without the covariance columns: diagonal NEES
    r_diag = evaluate_run(tmp_path, _write(tmp_path, fused.drop(columns=["cov_en", "cov_eu",
                                                                          "cov_nu"]), truth))
    diag = np.mean(np.sum(err**2 / sig**2, axis=1))
    assert r_diag["targets"]["T1"]["nees_pos_mean"] == pytest.approx(diag, rel=1e-6)
    assert abs(full - diag) > 1e-3


def test_p95_and_unmatched(tmp_path):
    truth = _truth()
    t = T0 + 0.1 * np.arange(100)
    fused = _fused(truth, t)
    fused["u"] += np.arange(100) / 10.0  # errors 0.0 .. 9.9 m
    other = _fused(truth, t, tid="T9")
    m = evaluate_run(tmp_path, _write(tmp_path, pd.concat([fused, other]), truth))
    r = m["targets"]["T1"]
    assert r["pos_p95"] == pytest.approx(np.percentile(np.arange(100) / 10.0, 95))
    assert m["unmatched"] == ["T9"] and "T9" not in m["targets"]
    text = format_report(m)
    assert "T1" in text and "unmatched" in text and "T9" in text
    assert f"{r['pos_rmse']:.2f}" in text


def test_no_overlap_reports_zero(tmp_path):
    truth = _truth()
    fused = _fused(truth, T0 + 0.1 * np.arange(10))
    fused["time"] += 100.0
    m = evaluate_run(tmp_path, _write(tmp_path, fused, truth))
    assert m["targets"]["T1"]["n_epochs"] == 0 and m["targets"]["T1"]["pos_rmse"] is None
    assert "no fused epoch" in format_report(m)


def test_interpolation_unsorted_truth():
    t = np.array([2.0, 0.0, 1.0])
    x = np.array([[20.0], [0.0], [10.0]])
    out, inside = interpolate_truth(t, x, np.array([-1.0, 0.5, 1.5, 2.0, 3.0]))
    assert inside.tolist() == [False, True, True, True, False]
    np.testing.assert_allclose(out[inside, 0], [5.0, 15.0, 20.0])


def test_missing_inputs(tmp_path):
    truth = _truth()
    with pytest.raises(DataError, match="fused.parquet: file not found"):
        evaluate_run(tmp_path, tmp_path / "truth.csv")
    fused = _fused(truth, T0 + np.arange(3.0)).drop(columns=["sigma_u"])
    path = _write(tmp_path, fused, truth)
    with pytest.raises(DataError, match="missing column 'sigma_u'"):
        evaluate_run(tmp_path, path)


@pytest.mark.parametrize("terms", [0, 2])
def test_a_nees_below_its_bounds_with_estimated_calibration_says_why(tmp_path, terms):
    """A sigma far larger than the error: one line naming the calibration terms' share, only
    when the run's summary.json says it estimated some (null estimates do not count)."""
    truth = _truth()
    t = T0 + 0.1 * np.arange(150)
    fused = _fused(truth, t, dpos=(0.01, 0.0, 0.0), sigma=(1.0, 1.0, 1.0))
    cal = {"range": {"estimate": 0.1, "sigma": 0.2}, "latency": {"estimate": None}}
    sensors = {f"R{k}": {"calibration": cal} for k in range(terms)}
    (tmp_path / "summary.json").write_text(json.dumps({"sensors": sensors}))
    m = evaluate_run(tmp_path, _write(tmp_path, fused, truth))
    assert m["calibration_terms"] == terms
    lines = [x for x in format_report(m).splitlines() if x.startswith("NEES under")]
    assert len(lines) == (1 if terms else 0)
    if terms:
        assert "(T1)" in lines[0] and "the 2 calibration terms" in lines[0]
