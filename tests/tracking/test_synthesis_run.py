"""Track synthesis end to end: one object stays one object; a lock jump becomes a new object."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from rangeproc.evaluate import evaluate_run
from rangeproc.summary_types import disagreements

CONFIG = "scenario.toml"


def test_the_sample_is_one_object_with_every_row(sample_run) -> None:
    table = pd.read_parquet(sample_run.out_dir / "association.parquet")
    assert list(table.columns) == ["sensor", "row", "time", "target_id", "segment", "reason"]
    n_rows = {sid: len(pd.read_csv(sample_run.folder / f"{sid}.csv")) for sid in ("R1", "S1")}
    n_rows["TH1"] = len(pd.read_parquet(sample_run.folder / "TH1.parquet"))
    for sid, n in n_rows.items():
        mine = table[table.sensor == sid]
        assert mine.row.tolist() == list(range(n))              # one row per input row
        kept = mine[~mine.reason.str.startswith("removed")]
        assert (kept.target_id == "T1").all() and (kept.reason == "associated").all()
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    assert set(summary["association"]["objects"]) == {"T1"}
    assert summary["association"]["exact"]
    fused = pd.read_parquet(sample_run.out_dir / "fused.parquet")
    assert set(fused.target_id) == {"T1"}


def test_a_lock_jump_to_another_object_becomes_a_second_object(scenario, cli, explain) -> None:
    r1 = pd.read_csv(scenario / "R1.csv")
    order = np.argsort(r1.time.to_numpy(), kind="stable")
    later = order[len(order) // 2:]                  # the second half of the flight, in time
    r1.loc[later, "range"] += 5000.0                 # the lock is on something 5 km further
    r1.loc[later, "azimuth"] += 3.0
    r1.loc[later, "range_rate"] += 30.0
    r1.to_csv(scenario / "R1.csv", index=False, float_format="%.17g")
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    table = pd.read_parquet(scenario / "out" / "association.parquet")
    r1_rows = table[table.sensor == "R1"].set_index("row")
    assert (r1_rows.loc[np.sort(later), "target_id"] == "O1").mean() > 0.99
    assert (r1_rows.drop(index=later).target_id == "T1").mean() > 0.99
    metrics = evaluate_run(scenario / "out", scenario / "truth.csv")["targets"]["T1"]
    assert metrics["pos_rmse"] < 0.15 and min(metrics["inside_3sigma_enu"]) > 0.95


def _radar_angles(enu: np.ndarray, site: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """(N, 3) range (m), azimuth, elevation (deg) of ENU points from a site."""
    d = (enu - site) @ rot.T
    r = np.linalg.norm(d, axis=1)
    return np.column_stack([r, np.degrees(np.mod(np.arctan2(d[:, 0], d[:, 1]), 2 * np.pi)),
                            np.degrees(np.arcsin(d[:, 2] / r))])


def test_a_lock_that_slides_onto_a_diverging_object_is_split(scenario, cli, explain) -> None:
    """No step at the swap: the second object is where the first one is at that moment and
    then drifts away at 40 m/s; the per-row fit, not the per-sensor filter, must find it."""
    from rangeproc.config import load_config
    from rangeproc.frames.geodesy import RangeFrame

    cfg = load_config(scenario / CONFIG)
    radar = next(s for s in cfg.sensors if s.id == "R1")
    site, rot = RangeFrame(cfg.origin).site(radar.site)
    truth = pd.read_csv(scenario / "truth.csv")
    r1 = pd.read_csv(scenario / "R1.csv")
    t = r1.time.to_numpy()
    ts = float(np.quantile(t, 0.6))
    true_p = np.column_stack([np.interp(t, truth.time, truth[c]) for c in "enu"])
    drift = np.clip(t - ts, 0.0, None)[:, None] * np.array([30.0, -25.0, 8.0])
    shift = _radar_angles(true_p + drift, site.reshape(3), rot) - _radar_angles(
        true_p, site.reshape(3), rot)
    shift[:, 1] = (shift[:, 1] + 180.0) % 360.0 - 180.0
    r1[["range", "azimuth", "elevation"]] += shift
    r1.to_csv(scenario / "R1.csv", index=False, float_format="%.17g")
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    table = pd.read_parquet(scenario / "out" / "association.parquet")
    r1_rows = table[table.sensor == "R1"].sort_values("time")
    late = r1_rows[r1_rows.time > ts + 10.0]         # 400 m apart and more
    early = r1_rows[r1_rows.time < ts]
    assert (late.target_id == "O1").mean() > 0.95
    assert (early.target_id == "T1").mean() > 0.95
    metrics = evaluate_run(scenario / "out", scenario / "truth.csv")["targets"]["T1"]
    assert metrics["pos_rmse"] < 0.15


def test_fused_epochs_carry_their_provenance(sample_run) -> None:
    fused = pd.read_parquet(sample_run.out_dir / "fused.parquet")
    named = fused.sensors.str.split(",").map(len).where(fused.sensors != "", 0)
    assert (named == fused.n_sensors).all()
    assert set(",".join(fused.sensors).split(",")) >= {"R1", "TH1", "S1", "G1", "MISTRAM"}
    assert (fused.data_gap_s >= 0).all() and (fused.bridged == (fused.data_gap_s > 1.0)).all()
    assert fused.data_gap_s.max() < 1.0                  # the sample has no uncovered gap


def cut_every_sensor(scenario, lo: float, hi: float) -> None:
    """Remove every sensor's rows with time in [lo, hi] (s) from the sample copy."""
    for name in ("R1", "S1", "G1", "MISTRAM"):
        df = pd.read_csv(scenario / f"{name}.csv")
        df[(df.time < lo) | (df.time > hi)].to_csv(scenario / f"{name}.csv", index=False,
                                                    float_format="%.17g")
    th = pd.read_parquet(scenario / "TH1.parquet")
    th[(th.time < lo) | (th.time > hi)].to_parquet(scenario / "TH1.parquet")


def test_a_gap_without_data_is_bridged_with_growing_uncertainty(scenario, cli, explain) -> None:
    t0 = pd.read_csv(scenario / "G1.csv").time.min()
    lo, hi = t0 + 50.0, t0 + 56.0
    cut_every_sensor(scenario, lo, hi)
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    fused = pd.read_parquet(scenario / "out" / "fused.parquet")
    inside = fused[(fused.time > lo + 1.5) & (fused.time < hi - 1.5)]
    outside = fused[(fused.time < lo - 2.0) | (fused.time > hi + 2.0)]
    assert len(inside) > 20 and inside.bridged.all() and not outside.bridged.any()
    assert (inside.sensors == "").all()
    assert inside.sigma_e.max() > 3 * outside.sigma_e.median()
    metrics = evaluate_run(scenario / "out", scenario / "truth.csv")["targets"]["T1"]
    assert min(metrics["inside_3sigma_enu"]) > 0.97


def test_a_gap_longer_than_max_gap_is_bridged_between_the_spans(scenario, cli, explain) -> None:
    t0 = pd.read_csv(scenario / "G1.csv").time.min()
    lo, hi = t0 + 30.0, t0 + 100.0                   # 70 s > max_gap: two spans
    cut_every_sensor(scenario, lo, hi)
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert len(summary["targets"]["T1"]["spans"]) == 2
    fused = pd.read_parquet(scenario / "out" / "fused.parquet")
    assert np.allclose(np.diff(fused.time), 0.1)     # no hole in the output grid
    inside = fused[(fused.time > lo + 2) & (fused.time < hi - 2)]
    assert inside.bridged.all() and (inside.n_sensors == 0).all()
    metrics = evaluate_run(scenario / "out", scenario / "truth.csv")["targets"]["T1"]
    assert min(metrics["inside_3sigma_enu"]) > 0.95   # honest across the fitted gap


def test_mixed_scenario_that_broke_the_smoother_now_runs(tmp_path, cli, explain) -> None:
    """The issue's failure: a jumping radar lock plus an operator switch ended in 'predicted
    covariance not positive definite in RTS' (the divergence guard inflated the covariance
    of an object whose angle-only rows kept failing the gate, without bound, to 1e87)."""
    from rangeproc.simulate import simulate_multi

    config = simulate_multi(tmp_path / "mixed", kind="mixed", seed=1)
    res = cli(["run", "--quiet", config])
    assert res.exit_code == 0, explain(res)
    fused = pd.read_parquet(tmp_path / "mixed" / "out" / "fused.parquet")
    assert {"T1"} <= set(fused.target_id) and fused.target_id.nunique() >= 3
    assert np.isfinite(fused[["e", "n", "u", "sigma_e"]].to_numpy()).all()
    metrics = evaluate_run(tmp_path / "mixed" / "out", tmp_path / "mixed" / "truth.csv")
    assert metrics["targets"]["T1"]["pos_rmse"] < 0.5
    summary = json.loads((tmp_path / "mixed" / "out" / "summary.json").read_text())
    assert list(disagreements(summary)) == []          # several objects: as declared


def test_track_relay_joins_pieces_of_one_sensor_track_across_a_short_gap() -> None:
    """``_track_relay``: (after, gap, edge) of the closest same-sensor, same-track_id join;
    None for another track_id, another sensor, an overlap, a plot track or a long gap."""
    from rangeproc.tracking.objects import Segment
    from rangeproc.tracking.relay import BRIDGE_SECONDS, _track_relay

    def seg(sensor: int, track: int, t0: float, t1: float) -> Segment:
        return Segment(0, sensor, np.arange(3), track, t0, t1, True)

    piece = [seg(1, 50, 20.0, 33.0)]
    other = [seg(2, -1, 5.0, 45.0), seg(1, 50, 35.0, 120.0)]
    assert _track_relay(piece, other) == (False, 2.0, 33.0)
    assert _track_relay([seg(1, 50, 130.0, 140.0)], other) == (True, 10.0, 130.0)
    assert _track_relay([seg(1, 51, 20.0, 33.0)], other) is None
    assert _track_relay([seg(3, 50, 20.0, 33.0)], other) is None
    assert _track_relay([seg(1, 50, 30.0, 40.0)], other) is None
    assert _track_relay([seg(1, -1, 20.0, 33.0)], [seg(1, -1, 35.0, 50.0)]) is None
    assert _track_relay([seg(1, 50, 0.0, 1.0)],
                        [seg(1, 50, 2.0 + BRIDGE_SECONDS, 300.0)]) is None
