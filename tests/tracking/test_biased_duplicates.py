"""A sensor's rows offset by an uncorrected bias beyond association's tolerance are joined to
the object they follow (``tracking.biased_duplicates``), and the registration then estimates
the bias; the bias fit itself against analytic offsets."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

import rangeproc.tracking.synthesis as synthesis
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario
from rangeproc.tracking.biased_duplicates import bias_fit


def _rows(rng: np.random.Generator, b: np.ndarray, tau: float, sigma: np.ndarray):
    """60 s at 20 Hz of a crossing target's predicted (range, azimuth, elevation), the
    measurements offset by ``b + tau dh/dt`` plus white noise of ``sigma`` (3,); returns
    (t, z, residuals, sigmas, dh/dt)."""
    t = np.arange(0.0, 60.0, 0.05)
    pred = np.column_stack([20e3 + 150.0 * t, np.pi - 0.2 + 0.01 * t + 0.02 * np.sin(t / 9.0),
                            0.1 + 0.002 * t])
    rate = np.column_stack([np.full(t.size, 150.0), 0.01 + 0.02 / 9.0 * np.cos(t / 9.0),
                            np.full(t.size, 0.002)])
    res = b + tau * rate + rng.normal(0.0, 1.0, pred.shape) * sigma
    z = np.full((t.size, 6), np.nan)
    z[:, :3] = pred + res
    full_res = np.full_like(z, np.nan)
    full_res[:, :3] = res
    s = np.full_like(z, np.nan)
    s[:, :3] = sigma
    return t, z, full_res, s, rate


@pytest.mark.parametrize("case", ["clean", "wild", "gaps"])
def test_the_bias_fit_recovers_constant_offsets_and_the_latency(case: str) -> None:
    rng = np.random.default_rng(4)
    b, tau, sigma = np.array([12.0, 5.2e-3, -1e-3]), 0.06, np.array([9.0, 3e-4, 9e-4])
    t, z, res, s, rate = _rows(rng, b, tau, sigma)
    if case == "wild":                                # 2 % of the rows 200 sigmas off
        bad = rng.choice(t.size, t.size // 50, replace=False)
        res[bad, 1] += 200.0 * sigma[1]
        z[bad, 1] += 200.0 * sigma[1]
    if case == "gaps":          # azimuths across north (+-pi) and 5 % of the rows without one
        z[:, 1] -= np.pi - 0.2
        z[:, 1] = (z[:, 1] + np.pi) % (2.0 * np.pi) - np.pi
        gone = rng.choice(t.size, t.size // 20, replace=False)
        z[gone, 1] = res[gone, 1] = np.nan
    fit_b, fit_tau, offsets = bias_fit(t, z, res, s)
    # the error of (b, tau) against its least-squares covariance (A^T W A)^-1 with the design
    # of the rows: offsets per component, the rate of each for the latency
    A = np.zeros((3 * t.size, 4))
    for c in range(3):
        A[c::3, c] = 1.0 / sigma[c]
        A[c::3, 3] = rate[:, c] / sigma[c]
    d = np.append(fit_b - b, fit_tau - tau)
    assert d @ (A.T @ A) @ d < chi2.ppf(0.999, 4), d
    assert np.all(offsets[:, 3:] == 0.0)


def test_a_ship_radar_yawed_and_late_stays_with_its_target(tmp_path, monkeypatch) -> None:
    """S1 yawed 0.3 deg (17 of its azimuth sigmas) and 60 ms late: without the join its rows
    become an undeclared object O1; with it they join T1 and its mount yaw is estimated."""
    cfg = simulate_scenario(tmp_path / "s", seed=2, duration=60.0,
                            faults={"S1": {"mount_yaw": 0.0052, "latency": 0.06}})
    out = run(cfg)
    assert list(out.summary["targets"]) == ["T1"]
    assert out.summary["sensors"]["S1"]["targets"] == ["T1"]
    yaw = out.summary["sensors"]["S1"]["calibration"]["mount_yaw"]
    assert yaw["applied"] and abs(yaw["estimate"] - 0.0052) < 3.0 * yaw["sigma"]
    monkeypatch.setattr(synthesis, "join_biased_duplicates",
                        lambda objects, keys, discovered, segs_of: list(discovered))
    assert list(run(cfg).summary["targets"]) == ["T1", "O1"]       # the case is exercised
