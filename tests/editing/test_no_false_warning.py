"""A valid input gets no warning: an INS whose attitude is all zero (an Autoferry-style
platform whose plots are already north-referenced), and a stated sigma of a component the
file does not measure (a 2-D radar's or a camera's empty elevation)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pymap3d

from conftest import describe, invoke
from rangeproc.config import SensorSettings
from rangeproc.editing.units import angle_unit_check, stated_sigma_line
from rangeproc.io.logs import SensorLog

ORIGIN = (63.4389, 10.3991, 40.0)        #: a harbour: lat, lon (deg), height (m)
T0 = 1.62e9                              #: Unix s


def _boat(t: np.ndarray) -> np.ndarray:
    """(N, 3) ENU (m) of a boat circling at 4 m/s on a 150 m circle about (0, 250) m."""
    w = 4.0 / 150.0
    return np.column_stack([150.0 * np.sin(w * t), 250.0 - 150.0 * np.cos(w * t),
                            np.zeros_like(t)])


def _ferry(t: np.ndarray) -> np.ndarray:
    """(N, 3) ENU (m) of the ferry crossing east at 1 m/s."""
    return np.column_stack([-60.0 + 1.0 * t, np.zeros_like(t), np.zeros_like(t)])


def write_harbour(folder: Path, *, elevation_sigma_deg: float = 0.01, seed: int = 5) -> Path:
    """FERRY.csv (an ins with roll = pitch = yaw = 0), NAV.csv (a 2-D radar on it: range and
    azimuth from north, elevation empty), EO.csv (a camera: azimuth only) and scenario.toml
    whose radar states ``elevation_sigma_deg`` for the elevation it does not measure."""
    rng = np.random.default_rng(seed)
    ti = np.arange(0.0, 150.0, 0.1)
    f = _ferry(ti)
    lat, lon, h = pymap3d.enu2geodetic(f[:, 0], f[:, 1], f[:, 2], *ORIGIN)
    zero = np.zeros(ti.size)
    pd.DataFrame({"time": T0 + ti, "roll": zero, "pitch": zero, "yaw": zero, "lat": lat,
                  "lon": lon, "height": h}).to_csv(folder / "FERRY.csv", index=False)
    for name, step, cols in (("NAV", 1.0, ("range", "azimuth", "elevation")),
                             ("EO", 0.2, ("azimuth", "elevation"))):
        t = np.arange(0.5, 149.0, step)
        d = _boat(t) - _ferry(t)
        r = np.linalg.norm(d[:, :2], axis=1)
        az = np.degrees(np.mod(np.arctan2(d[:, 0], d[:, 1]), 2 * np.pi))
        table = {"time": T0 + t, "range": r + rng.normal(0, 3.0, t.size),
                 "azimuth": az + rng.normal(0, 1.0, t.size), "elevation": np.nan}
        pd.DataFrame({"time": table["time"], **{c: table[c] for c in cols}}).to_csv(
            folder / f"{name}.csv", index=False)
    o = ORIGIN
    config = folder / "scenario.toml"
    config.write_text(f"""
[range]
origin = {{ lat = {o[0]}, lon = {o[1]}, height = {o[2]} }}

[output]
dir = "out"
rate_hz = 2.0

[[sensors]]
id = "FERRY"
kind = "ins"
file = "FERRY.csv"
angle_unit = "deg"
sigma = {{ roll = 0.01, pitch = 0.01, yaw = 0.01, position = 0.5 }}

[[sensors]]
id = "NAV"
kind = "radar"
file = "NAV.csv"
platform = "FERRY"
angle_unit = "deg"
sigma = {{ range = 3.0, azimuth = 1.0, elevation = {elevation_sigma_deg} }}

[[sensors]]
id = "EO"
kind = "theodolite"
file = "EO.csv"
platform = "FERRY"
angle_unit = "deg"
sigma = {{ azimuth = 1.0, elevation = {elevation_sigma_deg} }}
""")
    return config


def _ins_log(roll, pitch, yaw) -> tuple[SensorLog, SensorSettings]:
    n = len(yaw)
    rad = math.pi / 180.0
    cols = {"roll": np.asarray(roll) * rad, "pitch": np.asarray(pitch) * rad,
            "yaw": np.asarray(yaw) * rad, "lat": np.full(n, 63.0), "lon": np.full(n, 10.0),
            "height": np.zeros(n)}
    log = SensorLog("FERRY", "ins", np.arange(n, dtype=float), cols,
                    np.arange(1, n + 1), None, None, n)
    s = SensorSettings(id="FERRY", kind="ins", file=Path("FERRY.csv"), angle_unit="deg")
    return log, s


def test_an_all_zero_attitude_is_no_unit_evidence():
    zero = np.zeros(50)
    assert angle_unit_check(*_ins_log(zero, zero, zero)) is None


def test_zeros_beside_radian_values_still_suspect_radians_and_name_only_those():
    """Negative control: a yaw written in radians among zero roll and pitch is suspected,
    and the line names the yaw alone (the zeros say nothing)."""
    zero = np.zeros(50)
    yaw = np.linspace(0.1, 6.2, 50)
    found = angle_unit_check(*_ins_log(zero, zero, yaw))
    assert found is not None and found.likely == "rad"
    assert "every yaw within [0.1, 6.2]" in found.text
    assert "roll" not in found.text and "pitch" not in found.text


def test_a_sigma_of_an_absent_component_is_not_checked():
    s = SensorSettings(id="NAV", kind="radar", file=Path("NAV.csv"), angle_unit="deg",
                       platform="FERRY")
    noise = {"range": {"unit": "m", "apriori": 3.0, "estimated": 2.9},
             "elevation": {"unit": "rad", "apriori": 1.7e-4, "estimated": 0.05}}
    line = stated_sigma_line(s, noise)
    assert line is not None and "stated sigma elevation" in line     # the control
    assert stated_sigma_line(s, noise, absent={"elevation", "range_rate"}) is None


def test_an_autoferry_style_platform_runs_without_a_warning(tmp_path):
    """Zero attitude and elevation sigmas stated 0.01 deg for empty elevation columns (the
    2-D radar's elevation rows are the estimator's plane, 0.1 rad): no warning at all."""
    config = write_harbour(tmp_path)
    result = invoke(["run", "--quiet", config])
    assert result.exit_code == 0, describe(result)
    assert "WARNING" not in result.stderr, result.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["warnings"] == []
    # the elevation residuals exist (the plane rows), so the check had something to skip
    assert "elevation" in summary["sensors"]["NAV"]["noise"]


def test_the_sample_runs_without_a_warning(sample_run):
    assert "WARNING" not in sample_run.result.stderr, sample_run.result.stderr
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    assert summary["warnings"] == []


def test_a_sensor_is_judged_on_the_noise_of_all_its_rows():
    """A camera whose rows carry one object's track alone (tiny residuals) and fit another
    loosely: the stated sigma is judged on the pooled estimate, not on the last object's."""
    from rangeproc.fusion.sensor_use import _pooled

    s = SensorSettings(id="IR", kind="theodolite", file=Path("IR.csv"), angle_unit="deg",
                       platform="FERRY", sigma={"azimuth": math.radians(3.0)})

    def noise(parts):
        return {"azimuth": {"unit": "rad", "apriori": s.sigma["azimuth"],
                            "estimated": _pooled([(sig, np.zeros(n)) for n, sig in parts])}}

    both = noise([(300, 0.009), (100, 0.0028)])
    assert both["azimuth"]["estimated"] == 0.009       # the rows' majority's estimate
    assert stated_sigma_line(s, both) is None                         # 5.8x: within 10x
    assert stated_sigma_line(s, noise([(100, 0.0028)])) is not None   # 19x alone


def test_a_sigma_is_judged_on_the_object_that_agrees_best():
    """The objects a radar's rows went to: one fits its stated 4.4 m, two hold rows of several
    things (kilometres): no line. Every object 1000x off (a unit slip): the line stays."""
    from rangeproc.stages.products import most_agreeing_noise

    s = SensorSettings(id="RADAR", kind="radar", file=Path("RADAR.csv"), angle_unit="deg",
                       platform="FERRY", sigma={"range": 4.4})
    entry = {"noise": {"range": {"unit": "m", "apriori": 4.4, "estimated": 5080.0}},
             "by_object": {"T1": {"n_used": 60, "noise": {"range": 3.9}},
                           "O1": {"n_used": 90, "noise": {"range": 5080.0}},
                           "O2": {"n_used": 5, "noise": {"range": 4.4}},
                           "O3": {"n_used": 80, "noise": {"range": 7200.0}}}}
    assert stated_sigma_line(s, entry["noise"]) is not None        # the pooled estimate
    noise = most_agreeing_noise(entry)
    assert noise["range"]["estimated"] == 3.9 and stated_sigma_line(s, noise) is None
    assert entry["noise"]["range"]["estimated"] == 5080.0           # the summary untouched
    slip = {"noise": {"range": {"unit": "m", "apriori": 4.4, "estimated": 4400.0}},
            "by_object": {"T1": {"n_used": 60, "noise": {"range": 4300.0}},
                          "O1": {"n_used": 90, "noise": {"range": 4500.0}}}}
    assert stated_sigma_line(s, most_agreeing_noise(slip)) is not None
    # most rows in objects too short to estimate a noise from: no judgement
    few = {"noise": {"range": {"unit": "m", "apriori": 4.4, "estimated": 5080.0}},
           "by_object": {"O3": {"n_used": 41, "noise": {"range": 5080.0}},
                         "T1": {"n_used": 92, "noise": {"range": None}},
                         "O1": {"n_used": 5, "noise": {"range": None}}}}
    assert most_agreeing_noise(few)["range"]["estimated"] is None
    assert stated_sigma_line(s, most_agreeing_noise(few)) is None
