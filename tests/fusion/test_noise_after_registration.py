"""Noise after registration: a late radar does not inflate a clean theodolite's noise estimate.

The simulator's 120 s flight (seed 1: it maneuvers, and R1 measures range rate) seen by a
tracking radar R1, a theodolite TH1 and the target's GPS, run twice: as written, and with
R1's time stamps 0.25 s late. The registration finds the latency and corrects R1's rows; the
noise of every sensor must then be estimated from a track fit to the corrected rows
(``fusion.centralised``: settling passes while the registration still moves the rows).
Without them the theodolite's azimuth noise came out 18 % high on this flight (a negative
control below runs that way).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import rangeproc.fusion.refinement as refinement
from rangeproc.fusion.registration import row_shift
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario

LATE = 0.25     #: s, R1's time stamps minus the true times
TH1_COMPONENTS = ("range", "azimuth", "elevation")


def _flight(folder: Path, late: float) -> Path:
    """The R1/TH1/G1 flight in ``folder``, R1's time column moved ``late`` seconds."""
    cfg = simulate_scenario(folder, seed=1, duration=120.0, sensors="R1,TH1,G1")
    if late:
        radar = pd.read_csv(folder / "R1.csv")
        radar["time"] += late
        radar.to_csv(folder / "R1.csv", index=False, float_format="%.6f")
    return cfg


def _th1_noise(summary: dict) -> dict[str, float]:
    noise = summary["sensors"]["TH1"]["noise"]
    return {c: noise[c]["estimated"] for c in TH1_COMPONENTS}


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, dict]:
    clean = run(_flight(tmp_path_factory.mktemp("clean"), 0.0)).summary
    late_cfg = _flight(tmp_path_factory.mktemp("late"), LATE)
    late = run(late_cfg).summary
    settling = refinement.SETTLING_PASSES
    refinement.SETTLING_PASSES = 0          # the noise from the last pass as it was
    try:
        unsettled = run(late_cfg).summary
    finally:
        refinement.SETTLING_PASSES = settling
    return {"clean": clean, "late": late, "unsettled": unsettled}


def test_latency_is_found_and_applied(runs):
    latency = runs["late"]["sensors"]["R1"]["calibration"]["latency"]
    assert latency["applied"]
    assert abs(latency["estimate"] - LATE) < 0.005, latency


def test_late_radar_leaves_the_theodolite_noise_within_10_percent(runs):
    clean, late = _th1_noise(runs["clean"]), _th1_noise(runs["late"])
    for c in TH1_COMPONENTS:
        assert abs(late[c] / clean[c] - 1.0) < 0.10, (c, clean[c], late[c])
    bursts = [runs[k]["sensors"]["TH1"]["n_down_weighted_by_reason"].get("burst", 0)
              for k in ("clean", "late")]
    assert bursts[1] <= bursts[0] + 10, bursts     # no burst made of the radar's lateness


def test_negative_control_without_settling_the_theodolite_is_blamed(runs):
    clean, unsettled = _th1_noise(runs["clean"]), _th1_noise(runs["unsettled"])
    assert unsettled["azimuth"] / clean["azimuth"] - 1.0 > 0.10, (clean, unsettled)


def test_row_shift_is_the_largest_rms_shift_in_sigmas():
    sensor = np.array([0, 0, 1, 1])
    before = np.zeros((4, 6))
    after = before.copy()
    after[:2, 1] = [0.3, -0.4]            # sensor 0, component 1: RMS 0.3536 sigmas of 1
    after[2:, 0] = [1.0, 1.0]             # sensor 1, component 0: 1.0 / sigma 4 = 0.25
    after[3, 2] = np.nan                  # a component not measured does not count
    sigma = np.ones((4, 6))
    sigma[2:, 0] = 4.0
    assert row_shift(before, after, sigma, sensor) == pytest.approx(np.sqrt(0.125))
    assert row_shift(before, before, sigma, sensor) == 0.0
