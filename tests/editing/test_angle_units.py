"""Angle units that do not fit the values (editing.units) and sensors far from the others
(fusion.agreement), on hand-made files (tests/newuser.py): one clear line each."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from conftest import describe, invoke
from newuser import SITE, make_flight
from rangeproc.editing.units import fitting_units


def _run(flight):
    result = invoke(["run", "--quiet", flight.config])
    lines = result.stderr.strip().splitlines()
    return result, lines


def test_fitting_units():
    assert fitting_units(np.array([0.1, 6.2, 3.0]), circular=True) == ("rad", "deg", "mil")
    assert fitting_units(np.array([10.0, 282.0]), circular=True) == ("deg", "mil")
    assert fitting_units(np.array([10.0, 5013.0]), circular=True) == ("mil",)
    assert fitting_units(np.array([-170.0, 170.0]), circular=True) == ("deg", "mil")
    assert fitting_units(np.array([0.2, 1.5]), circular=False) == ("rad", "deg", "mil")
    assert fitting_units(np.array([9.3, 45.0]), circular=False) == ("deg", "mil")
    assert fitting_units(np.array([900.0]), circular=False) == ("mil",)
    assert fitting_units(np.array([9000.0]), circular=True) == ()


def test_radians_in_a_degree_file_beside_a_gps_cannot_be_meant(tmp_path):
    flight = make_flight(tmp_path, radar_angles="rad", angle_unit="deg")
    result, lines = _run(flight)
    assert result.exit_code == 2, describe(result)
    assert len(lines) == 1, lines
    assert lines[0].startswith('rangeproc: error: R1.csv: angle_unit = "deg" but every azimuth '
                               "within [")
    assert "the values look like rad" in lines[0]
    assert "km from every other sensor's view" in lines[0] and "(G1)" in lines[0]
    assert lines[0].endswith('set angle_unit = "rad"')
    assert not (tmp_path / "out").exists()


def test_radians_in_a_degree_file_alone_is_a_warning_in_the_summary(tmp_path):
    flight = make_flight(tmp_path, radar_angles="rad", angle_unit="deg", with_gps=False)
    result, lines = _run(flight)
    assert result.exit_code == 0, describe(result)
    warn = [ln for ln in lines if "look like rad" in ln]
    assert len(warn) == 1 and warn[0].startswith("rangeproc: WARNING: R1.csv: angle_unit")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert any("the values look like rad" in w for w in summary["warnings"])


@pytest.mark.parametrize("written,configured,column,fit", [
    ("deg", "rad", "azimuth", "deg"), ("mil", "deg", "azimuth", "mil"),
    ("mil", "rad", "azimuth", "mil")])
def test_values_impossible_in_the_configured_unit_exit_2(tmp_path, written, configured,
                                                         column, fit):
    flight = make_flight(tmp_path, radar_angles=written, angle_unit=configured)
    result, lines = _run(flight)
    assert result.exit_code == 2, describe(result)
    assert len(lines) == 1
    assert re.match(f"rangeproc: error: R1.csv: column '{column}': [0-9]+% of the values lie "
                    f"outside what angle_unit = \"{configured}\" allows \\(values in ",
                    lines[0]), lines[0]
    assert lines[0].endswith(f'they fit {fit} (set angle_unit = "{fit}" if so)')


def test_degrees_written_as_configured_raise_nothing(tmp_path):
    flight = make_flight(tmp_path)
    result, lines = _run(flight)
    assert result.exit_code == 0, describe(result)
    assert not [ln for ln in lines if "WARNING" in ln], lines
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["warnings"] == []


def test_a_radar_site_5_km_off_disagrees_with_the_gps(tmp_path):
    wrong_site = (SITE[0] + 0.045, SITE[1], SITE[2])        # about 5 km north
    flight = make_flight(tmp_path, config_site=wrong_site)
    result, lines = _run(flight)
    assert result.exit_code == 0, describe(result)
    warn = [ln for ln in lines if "disagree" in ln]
    assert len(warn) == 1, lines
    assert warn[0].startswith("rangeproc: WARNING: R1.csv and G1.csv disagree: sensor R1's ")
    assert "check their sites, units (angle_unit, metres) and time_offset" in warn[0]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert any("disagree" in w for w in summary["warnings"])


def test_swapped_azimuth_and_elevation_columns_are_named(tmp_path):
    flight = make_flight(tmp_path)
    path = tmp_path / "R1.csv"
    lines = path.read_text().splitlines()
    assert lines[0] == "time,range,azimuth,elevation"
    path.write_text("\n".join(["time,range,elevation,azimuth", *lines[1:]]) + "\n")
    result, err = _run(flight)
    assert result.exit_code == 2, describe(result)
    assert len(err) == 1
    assert err[0].startswith("rangeproc: error: R1.csv: columns 'azimuth' and 'elevation' look "
                             "swapped: the elevations [")


def test_a_sigma_stated_in_the_wrong_unit_is_named(tmp_path):
    flight = make_flight(tmp_path)                          # noise 0.01 deg
    text = flight.config.read_text()
    flight.config.write_text(text.replace("azimuth = 0.01, elevation = 0.01",
                                          "azimuth = 0.57, elevation = 0.01"))
    result, lines = _run(flight)
    assert result.exit_code == 0, describe(result)
    warn = [ln for ln in lines if "stated sigma" in ln]
    assert len(warn) == 1, lines
    assert re.match(r"rangeproc: WARNING: R1.csv: stated sigma azimuth 0.57 deg is [0-9.]+x the "
                    r"0.0[0-9]+ deg its residuals show: sigmas are 1-sigma", warn[0]), warn[0]
    assert "elevation" not in warn[0]
