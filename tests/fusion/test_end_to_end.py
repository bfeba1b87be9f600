"""End to end against the independent simulator: geometry exactness, accuracy, robustness."""
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rangeproc.config import FILTERS, load_config
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.evaluate import evaluate_run
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.batch import merge
from rangeproc.pipeline import run
from rangeproc.stages.assemble import assemble_all
from rangeproc.stages.read import read_all
from rangeproc.simulate import simulate_scenario

STATE = ["e", "n", "u", "ve", "vn", "vu", "ae", "an", "au"]


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    """A 60 s simulated flight (seed 5) with every sensor kind, wild points and dropouts."""
    folder = tmp_path_factory.mktemp("e2e")
    simulate_scenario(folder, seed=5, duration=60.0)
    return folder


def _with_sigmas(config: Path, factor: float | None, dst: Path, drop: tuple[str, ...] = ()):
    text = config.read_text()
    if factor is None:
        text = re.sub(r"(?m)^sigma = .*\n", "", text)
    else:
        def scale(m):
            return "sigma = {" + re.sub(r"= ([0-9.eE+-]+)",
                                        lambda v: f"= {float(v.group(1)) * factor!r}",
                                        m.group(1)) + "}"
        text = re.sub(r"sigma = \{([^}]*)\}", scale, text)
    blocks = re.split(r"(?m)^(?=\[\[sensors\]\])", text)
    text = "".join(b for b in blocks if not any(f'kind = "{k}"' in b for k in drop))
    dst.write_text(text.replace('dir = "out"', f'dir = "{dst.stem}_out"'))
    return dst


def test_noise_free_measurements_match_truth_geometry(tmp_path):
    """Every sensor's model evaluated at the simulator's truth reproduces its noise-free
    measurements: frames, platform stabilisation, lever arm, time offsets, units and MISTRAM
    all agree with an implementation that shares no code with them."""
    simulate_scenario(tmp_path, seed=7, duration=30.0, noise=False)
    cfg = load_config(tmp_path / "scenario.toml")
    frame = RangeFrame(cfg.origin)
    rows = assemble_all(cfg, frame, read_all(cfg))
    truth = pd.read_csv(tmp_path / "truth.csv")
    ids = tuple(s.id for s in cfg.sensors)
    for sid, a in rows.items():
        b = merge([(ids.index(sid), a.rows)], ids)
        x = np.column_stack([np.interp(b.t, truth.time, truth[c]) for c in STATE])
        # 100 Hz truth, linearly interpolated: a few mm / urad of interpolation error at most
        res, _ = smoothed_residuals(np.arange(len(b.t)), b.model, b.z, b.s, b.sv, b.Qr, x,
                                    np.zeros((len(b.t), 45)))
        worst = np.array([np.abs(c[np.isfinite(c)]).max() if np.isfinite(c).any() else np.nan
                          for c in res.T])
        kind = cfg.sensors[ids.index(sid)].kind
        if kind == "gps":
            assert worst[:3].max() < 0.05 and worst[3:].max() < 0.05, (sid, worst)
        elif kind == "mistram":
            assert worst[3] < 0.01, (sid, worst)
        else:
            if np.isfinite(worst[0]):                             # range, when measured
                assert worst[0] < 0.05, (sid, worst)
            assert np.nanmax(worst[1:3]) < 5e-6, (sid, worst)   # 5 urad: 0.1 m at 20 km


@pytest.mark.parametrize("factor", [1.0, 0.2, 5.0, None],
                         ids=["true sigmas", "sigmas 5x too small", "sigmas 5x too large",
                              "no sigmas (defaults)"])
def test_accuracy_and_consistency_whatever_the_stated_sigmas(scenario, factor):
    config = _with_sigmas(scenario / "scenario.toml", factor,
                          scenario / f"s{str(factor).replace('.', '_')}.toml")
    out = run(config)
    m = evaluate_run(out.out_dir, scenario / "truth.csv")["targets"]["T1"]
    assert m["pos_rmse"] < 1.0
    assert m["vel_rmse"] < 0.3
    assert min(m["inside_3sigma_enu"]) > 0.9


def test_degrades_gracefully_without_mistram_and_theodolite(scenario):
    config = _with_sigmas(scenario / "scenario.toml", 1.0, scenario / "reduced.toml",
                          drop=("mistram", "theodolite"))
    out = run(config)
    m = evaluate_run(out.out_dir, scenario / "truth.csv")["targets"]["T1"]
    assert m["pos_rmse"] < 3.0
    assert m["vel_rmse"] < 2.0
    assert min(m["inside_3sigma_enu"]) > 0.9
    assert set(out.summary["sensors"]) == {"R1", "S1", "SHIP_INS", "G1"}


def _with_filter(config: Path, name: str) -> Path:
    dst = config.with_name(f"filter_{name}.toml")
    dst.write_text(config.read_text().replace('dir = "s1_0_out"', f'dir = "{dst.stem}_out"')
                   + f'\n[processing]\nfilter = "{name}"\n')
    return dst


@pytest.fixture(scope="module")
def ekf_metrics(scenario):
    base = _with_sigmas(scenario / "scenario.toml", 1.0, scenario / "s1_0.toml")
    out = run(_with_filter(base, "ekf"))
    return evaluate_run(out.out_dir, scenario / "truth.csv")["targets"]["T1"]


@pytest.mark.parametrize("name", [f for f in FILTERS if f != "ekf"])
def test_every_filter_on_the_faulty_scenario(scenario, ekf_metrics, name):
    """Each selectable filter on the whole pipeline (wild points, dropouts, a burst): position
    RMSE within 1.3x of the EKF default, at least 95 % of epochs inside 3 sigma."""
    base = _with_sigmas(scenario / "scenario.toml", 1.0, scenario / "s1_0.toml")
    out = run(_with_filter(base, name))
    m = evaluate_run(out.out_dir, scenario / "truth.csv")["targets"]["T1"]
    assert m["pos_rmse"] <= 1.3 * ekf_metrics["pos_rmse"], (m["pos_rmse"], ekf_metrics)
    assert min(m["inside_3sigma_enu"]) >= 0.95, m["inside_3sigma_enu"]
