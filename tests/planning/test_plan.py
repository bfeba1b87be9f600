"""``rangeproc plan``: the predicted sigma against what a run of the same flight states and
achieves, what the outputs hold, bad input."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rangeproc.pipeline import run
from rangeproc.planning.plan import run_plan
from rangeproc.simulate import simulate_scenario
from tests.conftest import describe, invoke

SIGMAS = ["sigma_e", "sigma_n", "sigma_u", "sigma_ve", "sigma_vn", "sigma_vu"]
COLUMNS = ["time", "e", "n", "u", *SIGMAS, *[f"{c}_calibrated" for c in SIGMAS], "n_sensors",
           "sensors", "weak"]


@pytest.fixture(scope="module")
def planned_and_flown(tmp_path_factory):
    """A simulated flight: its plan (from its truth, before flying) and its run."""
    folder = tmp_path_factory.mktemp("plan")
    cfg = simulate_scenario(folder, seed=2, duration=90.0, sensors="R1,S1,SHIP_INS,G1,MISTRAM")
    plan = run_plan(cfg, folder / "truth.csv")
    out = run(cfg)
    fused = pd.read_parquet(out.out_dir / "fused.parquet")
    return folder, plan, fused[fused.target_id == "T1"]


def test_the_plan_predicts_the_sigma_the_run_states(planned_and_flown):
    """Per axis, the median predicted sigma within 30 % of the run's own (the run also sees
    the flight's dropouts, noise bursts and wild points, which the plan does not know)."""
    _, plan, fused = planned_and_flown
    t = plan.table
    for ax in "enu":
        predicted = np.median(np.interp(fused.time, t.time, t[f"sigma_{ax}"]))
        stated = np.median(fused[f"sigma_{ax}"])
        assert 0.7 < predicted / stated < 1.3, ax


def test_the_plan_table_and_summary(planned_and_flown):
    folder, plan, _ = planned_and_flown
    t = pd.read_parquet(folder / "out" / "plan.parquet")
    assert list(t.columns) == COLUMNS
    assert (t[[c for c in COLUMNS if c.startswith("sigma")]] > 0).all().all()
    assert (np.diff(t.time) > 0).all()
    assert t.n_sensors.max() >= 4 and set(",".join(t.sensors).split(",")) >= {"R1", "S1", "G1"}
    assert (folder / "out" / "plan.png").stat().st_size > 10_000
    s = plan.summary
    assert s["sensors"]["R1"]["calibration"]["range"]["predicted_sigma"] > 0
    assert "unobservable" in s["sensors"]["G1"]["calibration"]["latency"]
    assert s["sensors"]["R1"]["rate_and_components_from"] == "file"


def test_the_calibrated_sigma_is_the_plan_without_the_calibration(planned_and_flown, tmp_path):
    """The ``_calibrated`` columns are the smoother's sigma with every term known: the plan of
    the same config with the registration off (no term of the planned rows is significant,
    so both runs see the same rows), and below the sigma with the terms' uncertainty."""
    folder, plan, _ = planned_and_flown
    assert not any(c.get("applied") for s in plan.summary["sensors"].values()
                   for c in s.get("calibration", {}).values())
    cfg = folder / "scenario.toml"
    off = tmp_path / "off.toml"
    off.write_text(cfg.read_text().replace('dir = "out"', f'dir = "{tmp_path / "out"}"')
                   + "\n[processing]\ncalibration = false\n")
    for name in ("R1.csv", "S1.csv", "SHIP_INS.csv", "G1.csv", "MISTRAM.csv"):
        (tmp_path / name).symlink_to(folder / name)
    t_off = run_plan(off, folder / "truth.csv").table
    t = plan.table
    for c in SIGMAS:
        assert t[f"{c}_calibrated"].to_numpy() == pytest.approx(t_off[c].to_numpy(), rel=1e-6)
        assert (t[f"{c}_calibrated"] <= t[c] * (1 + 1e-9)).all()
    assert max(np.median(1.0 - t[f"{c}_calibrated"] / t[c]) for c in SIGMAS[:3]) > 0.02


def test_a_sensor_without_file_takes_its_rate_and_the_kinds_components(tmp_path):
    """A pre-flight config: no sensor file exists; rate_hz or the kind's default rate."""
    cfg = simulate_scenario(tmp_path, seed=2, duration=40.0, sensors="R1,G1")
    text = cfg.read_text().replace('file = "R1.csv"', 'file = "R1_later.csv"\nrate_hz = 5.0')
    cfg.write_text(text.replace('file = "G1.csv"', 'file = "G1_later.csv"'))
    out = run_plan(cfg, tmp_path / "truth.csv")
    r1, g1 = out.summary["sensors"]["R1"], out.summary["sensors"]["G1"]
    assert (r1["rate_hz"], r1["rate_and_components_from"]) == (5.0, "rate_hz")
    assert r1["components"] == ["range", "azimuth", "elevation"] or \
        tuple(r1["components"]) == ("range", "azimuth", "elevation")
    assert (g1["rate_hz"], g1["rate_and_components_from"]) == (10.0, "defaults")
    assert 150 <= r1["rows"] <= 205


def test_weak_geometry_near_zenith_is_named(tmp_path):
    """A theodolite the planned track passes right over is near zenith there."""
    cfg = simulate_scenario(tmp_path, seed=3, duration=30.0, sensors="TH1,G1")
    site = [line for line in cfg.read_text().splitlines() if line.startswith("site")][0]
    lat, lon = (float(v.split("=")[1]) for v in site.split("{")[1].split(",")[:2])
    from rangeproc.config import load_config
    from rangeproc.frames.geodesy import RangeFrame
    frame = RangeFrame(load_config(cfg).origin)
    st = frame.to_enu(lat, lon, 0.0).reshape(3)
    t = np.arange(0.0, 30.0, 0.5)
    track = pd.DataFrame({"time": t + 1000.0, "e": st[0] - 3000.0 + 200.0 * t,
                          "n": np.full_like(t, st[1]), "u": np.full_like(t, 3000.0)})
    track.to_csv(tmp_path / "over.csv", index=False)
    out = run_plan(cfg, tmp_path / "over.csv")
    weak = out.table.weak[out.table.weak != ""]
    assert len(weak) and all("TH1 near zenith" in w for w in weak)
    mid = out.table.time.between(1014.0, 1016.0)
    assert out.table.weak[mid].str.contains("near zenith").all()


@pytest.mark.parametrize("text, says", [
    ("time,e,n,u\n0,1,2,3\n", "at least 12"),
    ("time,e,n\n0,1,2\n", "u"),
])
def test_a_bad_trajectory_is_one_line(tmp_path, text, says):
    cfg = simulate_scenario(tmp_path, seed=1, duration=20.0, sensors="G1")
    (tmp_path / "bad.csv").write_text(text)
    res = invoke(["plan", cfg, tmp_path / "bad.csv"])
    assert res.exit_code == 2, describe(res)
    assert "bad.csv" in res.stderr and says in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "plan.parquet").exists()


def test_the_command_prints_the_plan(tmp_path):
    cfg = simulate_scenario(tmp_path, seed=1, duration=20.0, sensors="R1,G1")
    res = invoke(["plan", cfg, tmp_path / "truth.csv"])
    assert res.exit_code == 0, describe(res)
    assert "1-sigma median" in res.stdout and "R1:" in res.stdout and "plan.png" in res.stdout


def test_a_geodetic_plan_is_the_range_frame_plan(tmp_path):
    """The planned track in lat, lon, height (converted with the config's origin) plans as
    the same track in range ENU."""
    cfg = simulate_scenario(tmp_path, seed=4, duration=30.0, sensors="R1,G1")
    truth = pd.read_csv(tmp_path / "truth.csv")
    truth[["time", "e", "n", "u"]].to_csv(tmp_path / "enu.csv", index=False)
    truth[["time", "lat", "lon", "height"]].to_csv(tmp_path / "geo.csv", index=False)
    enu = run_plan(cfg, tmp_path / "enu.csv").table
    geo = run_plan(cfg, tmp_path / "geo.csv").table
    assert np.abs(geo[["e", "n", "u"]].to_numpy() - enu[["e", "n", "u"]].to_numpy()).max() < 0.01
    for ax in ("e", "n", "u"):
        assert np.median(geo[f"sigma_{ax}"] / enu[f"sigma_{ax}"]) == pytest.approx(1.0, abs=0.02)


def test_a_platform_sensor_without_its_ins_file_is_left_out_with_a_line(tmp_path):
    cfg = simulate_scenario(tmp_path, seed=5, duration=30.0, sensors="S1,SHIP_INS,G1")
    (tmp_path / "SHIP_INS.csv").rename(tmp_path / "SHIP_INS_later.csv")
    out = run_plan(cfg, tmp_path / "truth.csv")
    assert "S1" not in out.summary["sensors"]
    assert any(line.startswith("S1: its platform's INS (SHIP_INS)") for line in
               out.summary["left_out"])
    with_ins = tmp_path / "with_ins"
    cfg2 = simulate_scenario(with_ins, seed=5, duration=30.0, sensors="S1,SHIP_INS,G1")
    assert "S1" in run_plan(cfg2, with_ins / "truth.csv").summary["sensors"]


def test_the_figure_shows_every_sensor_slower_ones_too():
    """A 1 Hz GPS on a 10 Hz output grid has rows at every tenth epoch only: its row of the
    figure is a bar over the flight, as the 10 Hz radar's is (it was drawn as zero-length
    segments, an empty row); a gap in its rows stays a gap."""
    from rangeproc.planning.figure import draw_plan

    t = np.arange(0.0, 60.0, 0.1)
    gps = (np.arange(t.size) % 10 == 0) & ((t < 20.0) | (t > 30.0))
    table = pd.DataFrame({"time": t, **{c: np.ones(t.size) for c in SIGMAS},
                          "sensors": ["R1,G1" if g else "R1" for g in gps],
                          "weak": [""] * t.size})
    fig = draw_plan(table, {"sensors": {"R1": {}, "G1": {}}})
    bars = {c.get_gid(): c for c in fig.axes[2].collections}
    widths = {sid: sum(p.get_extents().width for p in bars[f"rows {sid}"].get_paths())
              for sid in ("R1", "G1")}
    assert widths["R1"] == pytest.approx(59.9, abs=0.2)
    assert widths["G1"] == pytest.approx(19.0 + 28.0)    # rows 0-19 s and 31-59 s: the gap stays
