"""simulate_scenario(rate_scale=...): rows scale with the rate, same scenario, contract kept."""
from __future__ import annotations

import filecmp

import numpy as np
import pytest

from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.io.readers import read_sensor
from rangeproc.simulate import simulate_scenario

DUR, SEED = 30.0, 3  # seed 3: R1 with range rate, TH1 angles only, G1 is the shuffled file
BASE_HZ = {"R1": 20.0, "S1": 10.0, "SHIP_INS": 50.0, "G1": 10.0, "MISTRAM": 20.0}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("rate")
    return {k: simulate_scenario(root / f"x{k}", seed=SEED, duration=DUR, rate_scale=k)
            for k in (1.0, 2.0)}


def _logs(cfg):
    conf = load_config(cfg)  # the library's own reader checks the files against the contract
    return {s.id: (s, read_sensor(s)) for s in conf.sensors}


def test_rate_scale_doubles_rows_and_keeps_contract(runs):
    one, two = _logs(runs[1.0]), _logs(runs[2.0])
    assert set(one) == set(two) == {"R1", "TH1", "S1", "SHIP_INS", "G1", "MISTRAM"}
    for sid, (settings, log2) in two.items():
        log1 = one[sid][1]
        assert log1.n_read > 0, sid
        # whole epochs only change at the ends of each coverage window / dropout (+-1 each);
        # MISTRAM writes one row per station per epoch
        per_epoch = len(settings.stations) if sid == "MISTRAM" else 1
        assert abs(log2.n_read - 2 * log1.n_read) <= 4 * per_epoch, sid
        assert set(log2.columns) == set(log1.columns), sid
        t = np.unique(log2.time)
        if sid in BASE_HZ:  # (TH1's base rate is drawn per seed: 20 or 25 Hz)
            assert np.median(np.diff(t)) == pytest.approx(0.5 / BASE_HZ[sid], abs=2e-6), sid
        for name, col in log2.columns.items():
            ok = np.isfinite(col)
            # as many empty cells (in proportion) as at scale 1 (TH1 range: none measured)
            assert ok.mean() == pytest.approx(np.isfinite(log1.columns[name]).mean(),
                                              abs=0.03), (sid, name)
            if name in ("azimuth", "yaw"):
                assert np.all((col[ok] >= 0) & (col[ok] < 2 * np.pi)), (sid, name)


def test_rate_scale_keeps_scenario(runs):
    a, b = runs[1.0].parent, runs[2.0].parent
    assert filecmp.cmp(a / "truth.csv", b / "truth.csv", shallow=False)  # same trajectory
    head_a, *rest_a = (a / "scenario.toml").read_text().splitlines()
    head_b, *rest_b = (b / "scenario.toml").read_text().splitlines()
    # same sites, sigmas, offsets, stations; only the comment line names the scale
    assert rest_a == rest_b and "sample rates" not in head_a and "sample rates x2" in head_b
    assert not filecmp.cmp(a / "R1.csv", b / "R1.csv", shallow=False)


@pytest.mark.parametrize("scale", [0.0, -1.0, 20.5, float("nan"), float("inf")])
def test_bad_rate_scale(tmp_path, scale):
    with pytest.raises(ConfigError, match="rate_scale"):
        simulate_scenario(tmp_path, duration=DUR, rate_scale=scale)
    assert not list(tmp_path.iterdir())  # validated before anything is written
