"""Registration end to end: faults injected by the simulator with truth (contract section 4)."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import REGISTRATION_FAULTS, simulate_scenario


def _variant(config: Path, name: str, *, processing: str = "", drop: tuple[str, ...] = (),
             sensor_keys: dict[str, str] | None = None) -> Path:
    """A copy of ``config`` with its own output folder, without the sensors ``drop``, extra
    ``[processing]`` lines and extra keys per sensor id."""
    blocks = re.split(r"(?m)^(?=\[\[sensors\]\])", config.read_text())
    keep = []
    for b in blocks:
        m = re.search(r'(?m)^id = "([^"]+)"', b)
        sid = m.group(1) if m and b.startswith("[[sensors]]") else None
        if sid in drop:
            continue
        if sid and sensor_keys and sid in sensor_keys:
            b = b.rstrip("\n") + "\n" + sensor_keys[sid] + "\n\n"
        keep.append(b)
    text = "".join(keep).replace('dir = "out"', f'dir = "out_{name}"')
    if processing:
        text += "\n[processing]\n" + processing + "\n"
    dst = config.with_name(f"{name}.toml")
    dst.write_text(text)
    return dst


@pytest.fixture(scope="module")
def faulted(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("faults")
    return simulate_scenario(folder, seed=4, duration=120.0, faults=REGISTRATION_FAULTS)


@pytest.fixture(scope="module")
def faulted_run(faulted):
    return run(faulted)


def test_injected_faults_are_recovered_within_three_sigma_and_30_percent(faulted,
                                                                          faulted_run):
    truth = json.loads((faulted.parent / "truth_calibration.json").read_text())
    sensors = faulted_run.summary["sensors"]
    for sid, terms in truth.items():
        for name, true in terms.items():
            got = sensors[sid]["calibration"][name]
            assert got["unit"] == {"range": "m", "latency": "s"}.get(name, "rad")
            err = abs(got["estimate"] - true)
            assert err < 3.0 * got["sigma"], (sid, name, got, true)
            assert err < 0.3 * abs(true), (sid, name, got, true)
            assert got["applied"]
    # the trajectory is honest again and close to what unbiased data give
    metrics = evaluate_run(faulted_run.out_dir, faulted.parent / "truth.csv")["targets"]["T1"]
    assert min(metrics["inside_3sigma_enu"]) >= 0.95
    assert metrics["pos_rmse"] < 0.2


def test_a_deck_azimuth_offset_is_the_mount_yaw_and_the_azimuth_bias_is_unobservable(
        faulted_run):
    s1 = faulted_run.summary["sensors"]["S1"]["calibration"]
    assert s1["azimuth"]["estimate"] is None and s1["azimuth"]["sigma"] is None
    assert "not separable from S1 mount_yaw" in s1["azimuth"]["unobservable"]
    # a fixed radar has no mount terms; GPS is the reference
    assert set(faulted_run.summary["sensors"]["R1"]["calibration"]) == {
        "range", "azimuth", "elevation", "latency"}
    assert "reference" in faulted_run.summary["sensors"]["G1"]["calibration"]["latency"][
        "unobservable"]


def test_residual_figures_and_edits_are_after_correction(faulted_run):
    r1 = faulted_run.summary["sensors"]["R1"]
    assert abs(r1["bias"]["range"]["median_residual"]) < 2.0      # 15 m before correction
    edits = pd.read_parquet(faulted_run.out_dir / "edits.parquet")
    assert (edits[edits.sensor == "R1"].reason == "gate").sum() < 0.02 * r1["n_rows"]


def test_without_an_absolute_reference_nothing_is_estimated_and_nothing_changes(faulted):
    sensors_only = ("G1", "MISTRAM", "TH1", "S1", "SHIP_INS")
    on = run(_variant(faulted, "noref_on", drop=sensors_only))
    off = run(_variant(faulted, "noref_off", drop=sensors_only,
                       processing="calibration = false"))
    cal = on.summary["sensors"]["R1"]["calibration"]
    for name in ("range", "azimuth", "elevation", "latency"):
        assert cal[name]["estimate"] is None
        assert "no absolute reference" in cal[name]["unobservable"]
    a = pd.read_parquet(on.out_dir / "fused.parquet")
    b = pd.read_parquet(off.out_dir / "fused.parquet")
    np.testing.assert_allclose(a[["e", "n", "u"]], b[["e", "n", "u"]], atol=1e-9)
    assert off.summary["sensors"]["R1"]["calibration"]["range"]["not_estimated"].startswith(
        "registration off")


def test_opt_out_with_a_known_correction(faulted):
    out = run(_variant(faulted, "known", sensor_keys={
        "R1": 'calibrate = ["latency"]\ncalibration = { range = 15.0 }'}))
    cal = out.summary["sensors"]["R1"]["calibration"]
    assert cal["range"] == {"estimate": 15.0, "sigma": None, "unit": "m", "given": 15.0,
                            "not_estimated": "not asked for (the sensor's calibrate key)"}
    assert cal["azimuth"]["estimate"] is None                  # opted out, no given value
    assert "latency" in cal and cal["latency"]["sigma"] is not None
    assert abs(out.summary["sensors"]["R1"]["bias"]["range"]["median_residual"]) < 2.0


def test_clean_data_lose_nothing(tmp_path):
    cfg = simulate_scenario(tmp_path, seed=2, duration=60.0)
    on = run(_variant(cfg, "on"))
    off = run(_variant(cfg, "off", processing="calibration = false"))
    rm_on = evaluate_run(on.out_dir, tmp_path / "truth.csv")["targets"]["T1"]
    rm_off = evaluate_run(off.out_dir, tmp_path / "truth.csv")["targets"]["T1"]
    assert rm_on["pos_rmse"] <= 1.03 * rm_off["pos_rmse"]
    assert min(rm_on["inside_3sigma_enu"]) >= min(rm_off["inside_3sigma_enu"]) - 0.01


def test_the_last_weights_and_the_rates_are_not_held_through_the_solves(faulted, monkeypatch):
    # the (N, 6) weights of the last solve are let go before it, and the (N, 4) rates are
    # made after the solves (they depend on the track only): neither is resident during a
    # solve it is not used in
    import gc
    import weakref

    import rangeproc.fusion.registration as reg
    weights: list = []
    rates: list = []
    during: list[tuple[bool, int]] = []       # per solve: its weights alive, rates made
    ne, solve, post = reg.normal_equations, reg.solve_joint, reg.postfit

    def ne_spy(*args, **kwargs):
        weights.append(weakref.ref(args[6]))
        return ne(*args, **kwargs)

    def solve_spy(*args, **kwargs):
        gc.collect()
        during.append((weights[-1]() is not None, sum(r() is not None for r in rates)))
        return solve(*args, **kwargs)

    def post_spy(*args, **kwargs):
        out = post(*args, **kwargs)
        rates.append(weakref.ref(out[1]))
        return out

    monkeypatch.setattr(reg, "normal_equations", ne_spy)
    monkeypatch.setattr(reg, "solve_joint", solve_spy)
    monkeypatch.setattr(reg, "postfit", post_spy)
    assert run(_variant(faulted, "held")).tracks
    assert len(during) >= 2 * reg.IRLS_PASSES
    for k, (alive, held) in enumerate(during):
        assert alive == (k % reg.IRLS_PASSES < reg.IRLS_PASSES - 1)
        assert held == 0
