"""simulate_multi kind ``scale``: issue 9's several-objects benchmark scenario (10 objects by
default; surveillance radar SR1 with a 4 s scan and 20 clutter plots per scan; tracking radars
R1, R2, R3 at 20 Hz per track, two tracks each, handed over to other objects; GPS on exactly
four objects). Short runs here; ``bench/bench.py`` runs it for 1800 s."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import tomllib
from click.testing import CliRunner

from rangeproc.cli import main
from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.io.readers import read_sensor
from rangeproc.simulate import MULTI_KINDS, simulate_multi

RADARS = ("R1", "R2", "R3")


@pytest.fixture(scope="module", params=[3, 4], ids=lambda s: f"seed{s}")
def scen(request, tmp_path_factory):
    """(folder, config dict, truth association, events) of a 60 s, 6-object scale run."""
    cfg = simulate_multi(tmp_path_factory.mktemp("scale") / "s", kind="scale",
                         seed=request.param, duration=60.0, n_objects=6)
    assoc = pd.read_csv(cfg.parent / "truth_association.csv", dtype={"target_id": str})
    events = json.loads((cfg.parent / "truth_events.json").read_text())
    return cfg.parent, tomllib.loads(cfg.read_text()), assoc, events


def test_scale_is_a_kind():
    assert "scale" in MULTI_KINDS and MULTI_KINDS["scale"][0] >= 5


def test_sensors_and_targets(scen):
    folder, cfg, _, events = scen
    kinds = {s["id"]: s["kind"] for s in cfg["sensors"]}
    assert kinds == {"SR1": "radar", "R1": "radar", "R2": "radar", "R3": "radar",
                     "G1": "gps", "G2": "gps", "G3": "gps", "G4": "gps"}
    declared = [t["id"] for t in cfg["targets"]]
    assert declared == ["T1", "T2", "T3", "T4"]  # GPS on exactly four objects
    assert sorted(s["target"] for s in cfg["sensors"] if s["kind"] == "gps") == declared
    truth = pd.read_csv(folder / "truth.csv", usecols=["target_id", "time"])
    assert sorted(truth["target_id"].unique()) == ["T1", "T2", "T3", "T4", "U1", "U2"]
    assert {i: o["declared"] for i, o in events["objects"].items()} == {
        "T1": True, "T2": True, "T3": True, "T4": True, "U1": False, "U2": False}
    assert events["kind"] == "scale"
    # every file parses with rangeproc's reader; tracking radars carry track_ids, SR1 none
    conf = load_config(folder / "scenario.toml")
    for s in conf.sensors:
        log = read_sensor(s)
        assert log.n_read > 0, s.id
        if s.id in RADARS:
            assert np.all(log.track_id >= 0), s.id
        elif s.id == "SR1":
            assert np.all(log.track_id == -1)


def test_tracking_radars_20hz_with_handovers(scen):
    folder, _, assoc, events = scen
    changes = [e for e in events["events"] if e["event"] == "track_change"]
    for sid in RADARS:
        df = pd.read_csv(folder / f"{sid}.csv")
        lab = assoc[assoc["sensor"] == sid].reset_index(drop=True)
        assert len(lab) == len(df) and lab["target_id"].notna().all()
        objs = set(lab["target_id"])
        assert 2 <= len(objs) <= 4, (sid, objs)  # two tracks, each maybe handed over
        mine = [e for e in changes if e["sensor"] == sid]
        assert 1 <= len(mine) <= 2, sid  # track 0 always handed over
        for e in mine:
            assert 1.0 <= e["gap"] <= 5.0 and e["from"] != e["to"]
            assert e["track_id_to"] in (e["track_id_from"], e["track_id_from"] + 1)
        # at most two objects at a time, each at 20 Hz less a few per cent missed
        t = df["time"].to_numpy(float)
        span = t.max() - t.min()
        per_s = len(df) / span
        assert 2 * 20 * 0.85 < per_s <= 2 * 20 * 1.01, (sid, per_s)
        for _, grp in df.groupby(lab["target_id"].to_numpy()):
            dt = np.diff(grp["time"].to_numpy(float))
            assert np.median(dt) == pytest.approx(0.05, abs=1e-3), sid


def test_surveillance_clutter(scen):
    folder, _, assoc, _ = scen
    df = pd.read_csv(folder / "SR1.csv")
    lab = assoc[assoc["sensor"] == "SR1"]
    clutter = lab["target_id"].isna().to_numpy()
    scans = (df["time"].max() - df["time"].min()) / 4.0
    assert 12.0 < clutter.sum() / scans < 28.0  # Poisson, mean 20 plots per 4 s scan
    assert lab["target_id"].dropna().nunique() >= 5  # SR1 sees (nearly) every object


def test_default_ten_objects_cli(tmp_path):
    res = CliRunner().invoke(main, ["simulate", str(tmp_path / "a"), "--objects", "scale",
                                    "--seed", "2", "--duration", "30", "-q"])
    assert res.exit_code == 0, res.output
    cfg = tomllib.loads((tmp_path / "a" / "scenario.toml").read_text())
    ids = json.loads((tmp_path / "a" / "truth_events.json").read_text())["objects"]
    assert len(ids) == 10 and sum(o["declared"] for o in ids.values()) == 4
    assert [t["id"] for t in cfg["targets"]] == ["T1", "T2", "T3", "T4"]


def test_too_few_objects(tmp_path):
    with pytest.raises(ConfigError, match="n_objects=4: kind 'scale' has 5-"):
        simulate_multi(tmp_path / "x", kind="scale", seed=1, duration=60.0, n_objects=4)
