"""A boat seen by a navigation radar's plots (one a 2.4 s scan) and by two cameras whose
bearing errors are AR(1) (lag-1 correlation 0.8-0.9, 5-9 Hz): taken as white, the cameras'
slowly varying errors read as manoeuvre, the process-noise search asks for a process noise
that lets the first pass follow them and the track leaves the boat between the radar's plots.
The first pass is run again with the cameras discounted (``fusion.centralised``,
``fusion.noise.correlation_factors``) and the boat is followed; the negative control keeps the
white first pass and loses it.

The cameras' detections are kept to the span of the radar's plots here
(``tracking.angle_plots.CONTINUE_GAP_S`` = 0: no detection continues the boat beyond it), so
that the span starts and ends on radar plots: continued by the cameras' bearings, this
scene's span starts on them and the white first pass follows the boat as well (coverage
1.00 either way), which would leave the negative control nothing to show."""
from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import describe, invoke

import rangeproc.fusion.centralised as centralised
import rangeproc.tracking.angle_plots as angle_plots
from rangeproc.evaluate.metrics import evaluate_run
from rangeproc.simulate import simulate_multi

SEED = 10                   # a harbour scene whose boat the white first pass loses
CUTOFF = 20.0               # m: the evaluation's pairing distance


@pytest.fixture(autouse=True)
def _cameras_within_the_radar_span(monkeypatch):
    monkeypatch.setattr(angle_plots, "CONTINUE_GAP_S", 0.0)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return simulate_multi(tmp_path_factory.mktemp("corr") / "h", kind="harbour", seed=SEED,
                          duration=120.0)


def _boat(config) -> tuple[float, float]:
    result = invoke(["run", "--quiet", config])
    assert result.exit_code == 0, describe(result)
    m = evaluate_run(config.parent / "out", config.parent / "truth.csv", cutoff=CUTOFF)
    row = m["multi"]["truth"]["B1"]
    return row["coverage"], row["best_match_rmse"] or np.inf


def _unwritten_s(config) -> float:
    """Seconds of output left unwritten (summary.json ``targets.<id>.unwritten``), all
    objects together."""
    targets = json.loads((config.parent / "out" / "summary.json").read_text())["targets"]
    return sum(b - a for entry in targets.values() for a, b in entry["unwritten"])


def test_the_boat_is_followed_with_the_cameras_discounted(scene):
    coverage, rmse = _boat(scene)
    print(f"B1 coverage {coverage:.2f}, best-match RMSE {rmse:.1f} m")
    assert coverage >= 0.9 and rmse <= 8.0


def test_negative_control_the_white_first_pass_loses_the_boat(scene, monkeypatch):
    monkeypatch.setattr(centralised, "_white_or_discounted", lambda white, *a, **k: white)
    coverage, rmse = _boat(scene)
    print(f"white first pass: B1 coverage {coverage:.2f}, best-match RMSE {rmse:.1f} m")
    assert coverage < 0.5
    # what was not written is said: the lost boat's span is listed as unwritten
    assert _unwritten_s(scene) > 60.0
