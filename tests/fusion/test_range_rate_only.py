"""Range-rate-only trajectory determination (seed 000's capability): MISTRAM alone starts from
a given ``[[targets]] initial`` state and reports honest sigmas."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pymap3d
import pytest

from rangeproc.config import FILTERS
from rangeproc.evaluate import evaluate_run
from rangeproc.fusion.initialise import given_prior, prior_at


def mistram_only_config(folder: Path, *, initial: bool, seed: int = 1) -> Path:
    """scenario.toml reduced to the MISTRAM sensor; with ``initial``, the truth state at the
    first MISTRAM time perturbed by draws of the stated sigmas (10 m, 5 m/s)."""
    text = (folder / "scenario.toml").read_text()
    blocks = re.split(r"(?m)^(?=\[\[sensors\]\])", text)
    keep = "".join(b for b in blocks
                   if not b.startswith("[[sensors]]") or 'kind = "mistram"' in b)
    if initial:
        truth = pd.read_csv(folder / "truth.csv")
        t0 = pd.read_csv(folder / "MISTRAM.csv")["time"].min()
        row = truth.iloc[int((truth["time"] - t0).abs().argmin())]
        rng = np.random.default_rng(seed)
        dp, dv = rng.normal(0.0, 10.0, 3), rng.normal(0.0, 5.0, 3)
        origin = [float(v) for v in re.search(
            r"origin = \{ lat = ([-\d.]+), lon = ([-\d.]+), height = ([-\d.]+)", text).groups()]
        lat, lon, h = pymap3d.enu2geodetic(row.e + dp[0], row.n + dp[1], row.u + dp[2], *origin)
        init = (f"initial = {{ time = {row.time}, lat = {lat:.9f}, lon = {lon:.9f}, "
                f"height = {h:.3f}, ve = {row.ve + dv[0]:.4f}, vn = {row.vn + dv[1]:.4f}, "
                f"vu = {row.vu + dv[2]:.4f}, sigma_position = 10.0, sigma_velocity = 5.0 }}\n")
        keep = keep.replace('id = "T1"\n', 'id = "T1"\n' + init, 1)
    path = folder / ("mistram_initial.toml" if initial else "mistram_alone.toml")
    path.write_text(keep)
    return path


def test_mistram_alone_without_initial_state_names_the_key(scenario, cli) -> None:
    res = cli(["run", "--quiet", mistram_only_config(scenario, initial=False)])
    assert res.exit_code == 2
    line = res.stderr.strip()
    assert "\n" not in line
    assert line.startswith("rangeproc: error: mistram_alone.toml: targets[0].initial: "
                           "target T1: cannot initialise the track")
    assert "initial = { time = ..." in line


@pytest.mark.parametrize("name", FILTERS)
def test_mistram_alone_with_initial_state_is_accurate_and_honest(scenario, cli, explain,
                                                                name) -> None:
    """Every filter starts from the given state and stays accurate and honest."""
    config = mistram_only_config(scenario, initial=True)
    config.write_text(config.read_text() + f'\n[processing]\nfilter = "{name}"\n')
    res = cli(["run", "--quiet", config])
    assert res.exit_code == 0, explain(res)
    m = evaluate_run(scenario / "out", scenario / "truth.csv")["targets"]["T1"]
    assert m["pos_rmse"] < 100.0 and m["vel_rmse"] < 1.0
    assert min(m["inside_3sigma_enu"]) >= 0.95, m


@pytest.mark.parametrize("dt", [-7.5, 0.0, 12.0])
def test_prior_moves_by_the_constant_acceleration_model_both_ways(dt: float) -> None:
    prior = given_prior(100.0, np.array([1.0, 2.0, 3.0]), np.array([10.0, -5.0, 1.0]), 10.0,
                        5.0)
    x, P = prior_at(prior, 100.0 + dt)
    np.testing.assert_allclose(x[:3], prior.x[:3] + dt * prior.x[3:6])
    np.testing.assert_allclose(P[0, 0], 10.0**2 + dt**2 * 5.0**2 + (0.5 * dt * dt * 30.0)**2)
    back = given_prior(100.0 + dt, x[:3], x[3:6], 1.0, 1.0)
    np.testing.assert_allclose(prior_at(back, 100.0)[0][:6], prior.x[:6], atol=1e-12)
    assert np.all(np.linalg.eigvalsh(P) > 0)


def test_mistram_alone_spline_filter_is_accurate_and_honest(scenario, cli, explain) -> None:
    """Seed 000's own setting: range rates alone, ``filter = "spline"`` (anomaly-knot filter,
    then the batch B-spline fit from the given initial state)."""
    path = mistram_only_config(scenario, initial=True)
    spline = path.with_name("mistram_spline.toml")
    spline.write_text(path.read_text().replace('dir = "out"', 'dir = "out_spline"')
                      + '\n[processing]\nfilter = "spline"\n')
    res = cli(["run", "--quiet", spline])
    assert res.exit_code == 0, explain(res)
    m = evaluate_run(scenario / "out_spline", scenario / "truth.csv")["targets"]["T1"]
    assert m["pos_rmse"] < 100.0 and m["vel_rmse"] < 1.0
    assert min(m["inside_3sigma_enu"]) >= 0.95, m


def test_auto_runs_the_spline_fit_on_range_rates_alone_and_says_so(scenario, cli, explain
                                                                    ) -> None:
    """The default filter ("auto") runs the EKF's passes and the batch spline fit for MISTRAM
    alone, and the EKF when position-bearing rows are there; the summary says which and
    why."""
    config = mistram_only_config(scenario, initial=True)
    res = cli(["run", "--quiet", config])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    chosen = summary["targets"]["T1"]["filter"]
    assert (chosen["configured"], chosen["used"]) == ("auto", "ekf+spline-fit")
    assert "range rates alone" in chosen["why"]
    res = cli(["run", "--quiet", scenario / "scenario.toml"])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert summary["targets"]["T1"]["filter"]["used"] == "ekf"


def test_an_explicit_filter_is_kept_on_range_rates_alone(scenario, cli, explain) -> None:
    config = mistram_only_config(scenario, initial=True)
    config.write_text(config.read_text() + '\n[processing]\nfilter = "ekf"\n')
    res = cli(["run", "--quiet", config])
    assert res.exit_code == 0, explain(res)
    chosen = json.loads((scenario / "out" / "summary.json").read_text())["targets"]["T1"][
        "filter"]
    assert chosen == {"configured": "ekf", "used": "ekf", "why": "configured"}
