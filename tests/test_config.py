"""Tests of rangeproc.config.load_config: the contract example, units, defaults, every error."""
from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import pytest

from rangeproc.config import DEFAULT_SIGMAS, Config, load_config
from rangeproc.errors import ConfigError

#: The data contract's example config, verbatim.
CONTRACT_EXAMPLE = """\
[range]
origin = { lat = 34.9, lon = -117.9, height = 700.0 }

[output]
dir = "out"            # relative to the config file's folder
rate_hz = 10.0         # fused trajectory sample rate

[[targets]]            # optional; by default one target "T1".
id = "T1"

[[sensors]]
id = "R1"
kind = "radar"
file = "R1.csv"        # relative to the config file's folder
site = { lat = 35.0, lon = -117.5, height = 713.0 }
angle_unit = "deg"
time_offset = 0.0
sigma = { range = 6.0, azimuth = 0.0143, elevation = 0.0143 }

[[sensors]]
id = "S1"
kind = "radar"
file = "S1.csv"
platform = "SHIP_INS"            # id of an `ins` sensor
lever_arm = [12.0, 0.0, -18.0]   # body FRD, metres
sigma = { range = 10.0, azimuth = 0.046, elevation = 0.046 }

[[sensors]]
id = "SHIP_INS"
kind = "ins"
file = "SHIP_INS.csv"
sigma = { roll = 0.01, pitch = 0.01, yaw = 0.01, position = 0.5 }

[[sensors]]
id = "G1"
kind = "gps"
file = "G1.csv"
target = "T1"
sigma = { horizontal = 2.5, vertical = 5.0, velocity = 0.15 }

[[sensors]]
id = "MISTRAM"
kind = "mistram"
file = "MISTRAM.csv"
sigma = { range_rate = 0.03 }
stations = [ { id = "M1", lat = 35.02, lon = -117.50, height = 720.0 } ]
"""

#: A smaller valid config that the error cases below edit (sensors[0..5]).
BASE = """\
[range]
origin = { lat = 34.9, lon = -117.9, height = 700.0 }

[output]
dir = "out"
rate_hz = 10.0

[[sensors]]
id = "R1"
kind = "radar"
file = "R1.csv"
site = { lat = 35.0, lon = -117.5, height = 713.0 }
sigma = { range = 6.0, azimuth = 0.0143, elevation = 0.0143 }

[[sensors]]
id = "S1"
kind = "radar"
file = "S1.csv"
platform = "SHIP_INS"
lever_arm = [12.0, 0.0, -18.0]

[[sensors]]
id = "SHIP_INS"
kind = "ins"
file = "SHIP_INS.csv"

[[sensors]]
id = "G1"
kind = "gps"
file = "G1.csv"

[[sensors]]
id = "MISTRAM"
kind = "mistram"
file = "MISTRAM.csv"
stations = [ { id = "M1", lat = 35.02, lon = -117.50, height = 720.0 },
             { id = "M2", lat = 35.10, lon = -117.60, height = 730.0 } ]

[[sensors]]
id = "T1V"
kind = "theodolite"
file = "T1V.csv"
site = { lat = 34.95, lon = -117.7, height = 705.0 }
"""

R1_SITE = 'site = { lat = 35.0, lon = -117.5, height = 713.0 }'
R1_SIGMA = 'sigma = { range = 6.0, azimuth = 0.0143, elevation = 0.0143 }'
ORIGIN = 'origin = { lat = 34.9, lon = -117.9, height = 700.0 }'
S1_PLATFORM = 'platform = "SHIP_INS"'
LEVER = 'lever_arm = [12.0, 0.0, -18.0]'
STATION_M2 = '{ id = "M2", lat = 35.10, lon = -117.60, height = 730.0 }'
INS_FILE = 'file = "SHIP_INS.csv"'
GPS_FILE = 'file = "G1.csv"'
MISTRAM_FILE = 'file = "MISTRAM.csv"'
THEO_FILE = 'file = "T1V.csv"'
RATE = 'rate_hz = 10.0'


def write(tmp_path: Path, text: str, name: str = "sample.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def edit(old: str, new: str, base: str = BASE) -> str:
    assert base.count(old) == 1, f"fixture snippet not unique: {old!r}"
    return base.replace(old, new)


def after(anchor: str, extra: str, base: str = BASE) -> str:
    return edit(anchor, f"{anchor}\n{extra}", base)


TWO_TARGETS = '[[targets]]\nid = "A"\n\n[[targets]]\nid = "B"\n\n'

# (case id, config text, key path expected in the message, problem text expected)
ERROR_CASES = [
    ("syntax", BASE + "\nx = = 1\n", f"line {BASE.count(chr(10)) + 2}, column", "invalid TOML"),
    ("syntax-duplicate-key", edit(RATE, RATE + "\nrate_hz = 5.0"), "line 7", "invalid TOML"),
    ("missing-range", edit("[range]\n" + ORIGIN + "\n", ""), "range:", "missing required key"),
    ("missing-origin", edit(ORIGIN, ""), "range.origin:", "missing required key"),
    ("missing-origin-lat", edit("lat = 34.9, ", ""), "range.origin.lat:",
     "missing required key"),
    ("missing-sensors", edit(BASE[BASE.index("[[sensors]]"):], ""), "sensors:",
     "missing required key"),
    ("missing-id", edit('id = "R1"\n', ""), "sensors[0].id:", "missing required key"),
    ("missing-kind", edit('kind = "gps"\n', ""), "sensors[3].kind:", "missing required key"),
    ("missing-file", edit(INS_FILE + "\n", ""), "sensors[2].file:", "missing required key"),
    ("string-for-number", edit("lat = 34.9,", 'lat = "34.9",'), "range.origin.lat:",
     "expected a number, got a string"),
    ("bool-for-number", edit(RATE, "rate_hz = true"), "output.rate_hz:",
     "expected a number, got a boolean"),
    ("number-for-string", edit('id = "R1"', "id = 7"), "sensors[0].id:", "expected a string"),
    ("inf-height", edit("height = 700.0", "height = inf"), "range.origin.height:", "finite"),
    ("nan-sigma", edit("range = 6.0", "range = nan"), "sensors[0].sigma.range:", "finite"),
    ("inf-time-offset", after(THEO_FILE, "time_offset = -inf"), "sensors[5].time_offset:",
     "finite"),
    ("unknown-top", "foo = 1\n" + BASE, "foo:", "unknown key (expected one of: range, output"),
    ("unknown-range", edit(ORIGIN, ORIGIN + "\nzone = 11"), "range.zone:", "unknown key"),
    ("unknown-origin", edit("height = 700.0", "height = 700.0, alt = 3"), "range.origin.alt:",
     "unknown key (expected one of: lat, lon, height)"),
    ("unknown-output", edit(RATE, "rate = 10.0"), "output.rate:", "unknown key"),
    ("unknown-target", '[[targets]]\nid = "T1"\nname = "x"\n\n' + BASE, "targets[0].name:",
     "unknown key (expected one of: id, initial, lever_arm)"),
    ("target-lever-arm-length", '[[targets]]\nid = "T1"\nlever_arm = [1.0, 2.0]\n\n' + BASE,
     "targets[0].lever_arm:", "expected 3 numbers"),
    ("target-lever-arm-type", '[[targets]]\nid = "T1"\nlever_arm = [1.0, "r", 0.0]\n\n' + BASE,
     "targets[0].lever_arm[1]:", "expected a number"),
    ("target-lever-arm-range", '[[targets]]\nid = "T1"\nlever_arm = [0.0, 0.0, 2e4]\n\n' + BASE,
     "targets[0].lever_arm[2]:", "outside the plausible range"),
    ("unknown-sensor", after(GPS_FILE, 'colour = "red"'), "sensors[3].colour:",
     "unknown key"),
    ("unknown-site", edit("height = 713.0", "height = 713.0, datum = 1"),
     "sensors[0].site.datum:", "unknown key"),
    ("unknown-sigma", edit("azimuth = 0.0143,", "azimth = 0.0143,"), "sensors[0].sigma.azimth:",
     "unknown key (expected one of: range, azimuth, elevation, range_rate)"),
    ("wrong-kind-sigma", after(GPS_FILE, "sigma = { range = 3.0 }"), "sensors[3].sigma.range:",
     "expected one of: horizontal, vertical, velocity"),
    ("unknown-station", edit("height = 730.0 }", "height = 730.0, elev = 2 }"),
     "sensors[4].stations[1].elev:", "unknown key"),
    ("unknown-processing", BASE + "\n[processing]\ngate = 0.99\n", "processing.gate:",
     "unknown key (expected one of: gate_probability"),
    ("unknown-kind", edit('kind = "gps"', 'kind = "gnss"'), "sensors[3].kind:",
     "unknown sensor kind 'gnss' (expected one of: radar, theodolite, gps, mistram, ins)"),
    ("unknown-angle-unit", after(THEO_FILE, 'angle_unit = "grad"'), "sensors[5].angle_unit:",
     "unknown angle unit 'grad' (expected one of: deg, rad, mil)"),
    ("duplicate-sensor", edit('id = "S1"', 'id = "R1"'), "sensors[1].id:",
     "duplicate sensor id 'R1' (also sensors[0].id)"),
    ("duplicate-target", '[[targets]]\nid = "A"\n\n[[targets]]\nid = "A"\n\n' + BASE,
     "targets[1].id:", "duplicate target id 'A'"),
    ("duplicate-station", edit('id = "M2"', 'id = "M1"'), "sensors[4].stations[1].id:",
     "duplicate station id 'M1'"),
    ("site-and-platform", after(S1_PLATFORM, R1_SITE), "sensors[1]:",
     "exactly one of 'site'"),
    ("neither-site-nor-platform", edit(S1_PLATFORM + "\n" + LEVER + "\n", ""), "sensors[1]:",
     "exactly one of 'site'"),
    ("platform-unknown", edit(S1_PLATFORM, 'platform = "SHIP"'), "sensors[1].platform:",
     "'SHIP' names no sensor (ins sensors: SHIP_INS)"),
    ("platform-not-ins", edit(S1_PLATFORM, 'platform = "G1"'), "sensors[1].platform:",
     "'G1' is a gps sensor, not an ins"),
    ("lever-arm-without-platform", edit(R1_SITE, R1_SITE + "\n" + LEVER),
     "sensors[0].lever_arm:", "only allowed together with 'platform'"),
    ("lever-arm-length", edit(LEVER, "lever_arm = [1.0, 2.0]"), "sensors[1].lever_arm:",
     "expected 3 numbers"),
    ("lever-arm-type", edit(LEVER, 'lever_arm = [1.0, "2", 3.0]'), "sensors[1].lever_arm[1]:",
     "expected a number"),
    ("site-on-gps", after(GPS_FILE, R1_SITE), "sensors[3].site:",
     "not allowed for a gps sensor"),
    ("site-on-mistram", after(MISTRAM_FILE, R1_SITE), "sensors[4].site:",
     "not allowed for a mistram sensor"),
    ("platform-on-ins", after(INS_FILE, S1_PLATFORM), "sensors[2].platform:",
     "not allowed for an ins sensor"),
    ("target-on-radar", after(R1_SITE, 'target = "T1"'), "sensors[0].target:",
     "not allowed for a radar sensor"),
    ("target-on-theodolite", after(THEO_FILE, 'target = "T1"'), "sensors[5].target:",
     "not allowed for a theodolite sensor"),
    ("target-on-ins", after(INS_FILE, 'target = "T1"'), "sensors[2].target:",
     "not allowed for an ins sensor"),
    ("target-undeclared", TWO_TARGETS + after(GPS_FILE, 'target = "C"'), "sensors[3].target:",
     "'C' is not a declared target (declared: A, B)"),
    ("target-required", TWO_TARGETS + after(MISTRAM_FILE, 'target = "A"'),
     "sensors[3].target:", "required for a gps sensor when there are several targets"),
    ("target-required-derived",
     after(MISTRAM_FILE, 'target = "A"', after(GPS_FILE, 'target = "B"')) +
     '\n[[sensors]]\nid = "G2"\nkind = "gps"\nfile = "G2.csv"\n',
     "sensors[6].target:", "required for a gps sensor"),
    ("empty-targets", "targets = []\n" + BASE, "targets:", "empty"),
    ("mistram-without-stations", edit(MISTRAM_FILE + "\n" + 'stations = [ ' + '{ id = "M1", '
                                      'lat = 35.02, lon = -117.50, height = 720.0 },\n'
                                      "             " + STATION_M2 + " ]", MISTRAM_FILE),
     "sensors[4].stations:", "missing required key"),
    ("mistram-empty-stations", BASE.replace(BASE[BASE.index("stations = ["):
                                                 BASE.index("]", BASE.index("stations = [")) + 1],
                                            "stations = []"),
     "sensors[4].stations:", "at least one station"),
    ("stations-on-radar", after(R1_SITE, "stations = []"), "sensors[0].stations:",
     "not allowed for a radar sensor"),
    ("station-missing-lat", edit("lat = 35.10, ", ""), "sensors[4].stations[1].lat:",
     "missing required key"),
    ("sigma-zero", edit("range = 6.0", "range = 0.0"), "sensors[0].sigma.range:", "must be > 0"),
    ("sigma-negative", after(INS_FILE, "sigma = { yaw = -1 }"), "sensors[2].sigma.yaw:",
     "must be > 0"),
    ("sigma-string", edit("range = 6.0", 'range = "6"'), "sensors[0].sigma.range:",
     "expected a number"),
    ("sigma-not-table", after(GPS_FILE, "sigma = 3.0"), "sensors[3].sigma:",
     "expected a table"),
    ("lat-high", edit("lat = 34.9,", "lat = 91.0,"), "range.origin.lat:", "outside [-90, 90]"),
    ("lon-360", edit("lon = -117.5,", "lon = 360.0,"), "sensors[0].site.lon:",
     "outside [-180, 360)"),
    ("lon-low", edit("lon = -117.60", "lon = -180.5"), "sensors[4].stations[1].lon:",
     "outside [-180, 360)"),
    ("rate-zero", edit(RATE, "rate_hz = 0"), "output.rate_hz:", "must be > 0"),
    ("rate-negative", edit(RATE, "rate_hz = -5.0"), "output.rate_hz:", "must be > 0"),
    ("output-dir-type", edit('dir = "out"', "dir = 3"), "output.dir:", "expected a string"),
    ("sensors-not-array", "sensors = 3\n" + BASE[:BASE.index("[[sensors]]")], "sensors:",
     "expected an array"),
    ("sensors-empty", "sensors = []\n" + BASE[:BASE.index("[[sensors]]")], "sensors:",
     "at least one sensor"),
    ("gate-one", BASE + "\n[processing]\ngate_probability = 1.0\n",
     "processing.gate_probability:", "must be in [0.5, 1)"),
    ("noise-passes-negative", BASE + "\n[processing]\nnoise_passes = -1\n",
     "processing.noise_passes:", "must be in [0, 20]"),
    ("noise-passes-float", BASE + "\n[processing]\nnoise_passes = 1.5\n",
     "processing.noise_passes:", "expected an integer"),
    ("noise-passes-bool", BASE + "\n[processing]\nnoise_passes = true\n",
     "processing.noise_passes:", "expected an integer"),
    ("adapt-noise-string", BASE + '\n[processing]\nadapt_noise = "yes"\n',
     "processing.adapt_noise:", "expected true or false"),
    ("process-noise-zero", BASE + "\n[processing]\nprocess_noise = 0.0\n",
     "processing.process_noise:", "must be > 0"),
    ("processing-not-table", "processing = 3\n" + BASE, "processing:", "expected a table"),
    # absurd but finite values: plausibility bounds
    ("rate-huge", edit(RATE, "rate_hz = 1e9"), "output.rate_hz:", "outside the plausible range"),
    ("rate-tiny", edit(RATE, "rate_hz = 1e-308"), "output.rate_hz:", "outside the plausible range"),
    ("origin-height-huge", edit("height = 700.0", "height = 1e300"), "range.origin.height:",
     "outside the plausible range"),
    ("time-offset-huge", edit("range = 6.0", "range = 6.0 }\ntime_offset = 1e15\n#"),
     "sensors[0].time_offset:", "outside the plausible range"),
    ("sigma-tiny", edit("range = 6.0", "range = 1e-300"), "sensors[0].sigma.range:",
     "outside the plausible range"),
    ("sigma-angle-huge", edit("azimuth = 0.0143", "azimuth = 1e6"),
     "sensors[0].sigma.azimuth:", "outside the plausible range"),
    ("noise-passes-huge", BASE + "\n[processing]\nnoise_passes = 1000000\n",
     "processing.noise_passes:", "must be in [0, 20]"),
    ("process-noise-huge", BASE + "\n[processing]\nprocess_noise = 1e300\n",
     "processing.process_noise:", "outside the plausible range"),
    ("gate-tiny", BASE + "\n[processing]\ngate_probability = 1e-300\n",
     "processing.gate_probability:", "must be in [0.5, 1)"),
    ("max-gap-zero", BASE + "\n[processing]\nmax_gap = 0.0\n",
     "processing.max_gap:", "outside the plausible range"),
    ("allow-disjoint-string", edit("range = 6.0", 'range = 6.0 }\nallow_disjoint_time = "y"\n#'),
     "sensors[0].allow_disjoint_time:", "expected true or false"),
]


@pytest.mark.parametrize("text, key, problem", [c[1:] for c in ERROR_CASES],
                         ids=[c[0] for c in ERROR_CASES])
def test_config_errors_are_one_line_and_name_file_and_key(
        tmp_path: Path, text: str, key: str, problem: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("sample.toml: "), msg
    assert key in msg, msg
    assert problem in msg, msg


def test_base_fixture_is_valid(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, BASE))
    assert [s.id for s in cfg.sensors] == ["R1", "S1", "SHIP_INS", "G1", "MISTRAM", "T1V"]


def test_missing_config_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "nope.toml")
    msg = str(info.value)
    assert msg.startswith("nope.toml: ") and "not found" in msg and str(tmp_path) in msg
    assert "\n" not in msg


def test_non_utf8_config(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_bytes(b'[range]\norigin = { lat = 1.0, lon = 2.0, height = 3.0 }\n# \xff\xfe\n')
    with pytest.raises(ConfigError, match=r"^bad\.toml: "):
        load_config(path)


def test_contract_example(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, CONTRACT_EXAMPLE))
    assert isinstance(cfg, Config)
    assert cfg.path == (tmp_path / "sample.toml").resolve()
    assert (cfg.origin.lat, cfg.origin.lon, cfg.origin.height) == (34.9, -117.9, 700.0)
    assert cfg.output.dir == (tmp_path / "out").resolve()
    assert cfg.output.rate_hz == 10.0
    assert [t.id for t in cfg.targets] == ["T1"]
    r1, s1, ins, g1, mis = cfg.sensors
    assert r1.file == (tmp_path / "R1.csv").resolve() and r1.file.is_absolute()
    assert r1.site is not None and r1.site.height == 713.0 and r1.platform is None
    assert r1.sigma["range"] == 6.0
    assert r1.sigma["azimuth"] == pytest.approx(math.radians(0.0143), rel=1e-15)
    assert r1.sigma["range_rate"] == DEFAULT_SIGMAS["radar"]["range_rate"]  # default filled
    assert isinstance(r1.sigma, MappingProxyType)
    assert s1.platform == "SHIP_INS" and s1.site is None
    assert s1.lever_arm == (12.0, 0.0, -18.0)
    assert ins.sigma["yaw"] == pytest.approx(math.radians(0.01))
    assert ins.sigma["position"] == 0.5 and ins.sigma["velocity"] == 0.1
    assert g1.target == "T1" and g1.sigma["horizontal"] == 2.5
    assert mis.target == "T1"  # filled in: only one target
    assert [s.id for s in mis.stations] == ["M1"]
    assert mis.stations[0].site.lat == 35.02
    assert mis.sigma == {"range_rate": 0.03}


@pytest.mark.parametrize("unit, value, expected_rad", [
    ("deg", 90.0, math.pi / 2),
    ("rad", 0.25, 0.25),
    ("mil", 1600.0, math.pi / 2),   # 6400 mil per circle: 1600 mil == 90 deg
    ("mil", 1.0, 2 * math.pi / 6400),
])
def test_angle_sigma_units(tmp_path: Path, unit: str, value: float, expected_rad: float) -> None:
    text = after(R1_SITE, f'angle_unit = "{unit}"',
                 edit("azimuth = 0.0143", f"azimuth = {value}"))
    text = after(INS_FILE, f'angle_unit = "{unit}"\nsigma = {{ roll = {value} }}', text)
    cfg = load_config(write(tmp_path, text))
    r1, _, ins = cfg.sensors[:3]
    assert r1.angle_unit == unit
    assert r1.sigma["azimuth"] == pytest.approx(expected_rad, rel=1e-14)
    assert r1.sigma["range"] == 6.0  # lengths untouched by angle_unit
    assert ins.sigma["roll"] == pytest.approx(expected_rad, rel=1e-14)
    assert ins.sigma["position"] == DEFAULT_SIGMAS["ins"]["position"]


def test_defaults_when_optional_parts_absent(tmp_path: Path) -> None:
    text = ("[range]\norigin = { lat = 0, lon = 0, height = 0 }\n\n"
            '[[sensors]]\nid = "G"\nkind = "gps"\nfile = "g.parquet"\n')
    cfg = load_config(write(tmp_path, text))
    assert cfg.output.dir == (tmp_path / "out").resolve() and cfg.output.rate_hz == 10.0
    assert [t.id for t in cfg.targets] == ["T1"]
    (g,) = cfg.sensors
    assert g.target == "T1" and g.angle_unit == "deg" and g.time_offset == 0.0
    assert dict(g.sigma) == dict(DEFAULT_SIGMAS["gps"])
    assert cfg.processing.gate_probability == 0.9999 and cfg.processing.process_noise is None
    assert isinstance(cfg.origin.lat, float)  # TOML integers accepted as numbers


def test_default_sigmas_are_read_only_and_match_contract_keys() -> None:
    assert {k: tuple(v) for k, v in DEFAULT_SIGMAS.items()} == {
        "radar": ("range", "azimuth", "elevation", "range_rate"),
        "theodolite": ("azimuth", "elevation", "range"),
        "gps": ("horizontal", "vertical", "velocity"),
        "mistram": ("range_rate",),
        "ins": ("roll", "pitch", "yaw", "position", "velocity"),
    }
    assert DEFAULT_SIGMAS["radar"]["range"] == 10.0
    assert DEFAULT_SIGMAS["theodolite"]["azimuth"] == 1e-4
    with pytest.raises(TypeError):
        DEFAULT_SIGMAS["radar"]["range"] = 1.0  # type: ignore[index]
    with pytest.raises(TypeError):
        DEFAULT_SIGMAS["sonar"] = {}  # type: ignore[index]


def test_sensor_settings_are_frozen(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, BASE))
    with pytest.raises((AttributeError, TypeError)):
        cfg.sensors[0].kind = "gps"  # type: ignore[misc]
    with pytest.raises(TypeError):
        cfg.sensors[0].sigma["range"] = 1.0  # type: ignore[index]


def test_targets_derived_from_sensor_names_when_not_declared(tmp_path: Path) -> None:
    text = after(MISTRAM_FILE, 'target = "B"', after(GPS_FILE, 'target = "A"'))
    cfg = load_config(write(tmp_path, text))
    assert [t.id for t in cfg.targets] == ["A", "B"]
    by_id = {s.id: s for s in cfg.sensors}
    assert by_id["G1"].target == "A" and by_id["MISTRAM"].target == "B"
    assert by_id["R1"].target is None


def test_single_derived_target_fills_unnamed_sensor(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, after(GPS_FILE, 'target = "DRONE"')))
    assert [t.id for t in cfg.targets] == ["DRONE"]
    assert {s.id: s.target for s in cfg.sensors}["MISTRAM"] == "DRONE"


def test_declared_targets_and_named_sensors(tmp_path: Path) -> None:
    text = TWO_TARGETS + after(MISTRAM_FILE, 'target = "A"', after(GPS_FILE, 'target = "B"'))
    cfg = load_config(write(tmp_path, text))
    assert [t.id for t in cfg.targets] == ["A", "B"]
    assert {s.id: s.target for s in cfg.sensors}["G1"] == "B"


def test_processing_section(tmp_path: Path) -> None:
    text = BASE + ("\n[processing]\ngate_probability = 0.99\nnoise_passes = 0\n"
                   "adapt_noise = false\nprocess_noise = 2.5\n")
    p = load_config(write(tmp_path, text)).processing
    assert (p.gate_probability, p.noise_passes, p.adapt_noise, p.process_noise) == (
        0.99, 0, False, 2.5)


def test_relative_paths_resolve_against_config_folder_not_cwd(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg_dir = tmp_path / "campaign" / "flight7"
    cfg_dir.mkdir(parents=True)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    text = edit('dir = "out"', 'dir = "../results"',
                edit('file = "R1.csv"', 'file = "data/R1.csv"'))
    text = edit(GPS_FILE, f'file = "{(tmp_path / "abs" / "G1.csv").as_posix()}"', text)
    write(cfg_dir, text, "flight.toml")
    monkeypatch.chdir(elsewhere)
    cfg = load_config(Path("..") / "campaign" / "flight7" / "flight.toml")
    assert cfg.path == (cfg_dir / "flight.toml").resolve()
    assert cfg.output.dir == (tmp_path / "campaign" / "results").resolve()
    by_id = {s.id: s for s in cfg.sensors}
    assert by_id["R1"].file == (cfg_dir / "data" / "R1.csv").resolve()
    assert by_id["G1"].file == (tmp_path / "abs" / "G1.csv").resolve()
    assert all(s.file.is_absolute() for s in cfg.sensors)


def test_a_targets_lever_arm_is_read_in_its_body_frame(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, '[[targets]]\nid = "T1"\nlever_arm = [-3, 1.5, 0]\n\n'
                            + BASE))
    assert cfg.targets[0].lever_arm == (-3.0, 1.5, 0.0)
    assert load_config(write(tmp_path, BASE)).targets[0].lever_arm == (0.0, 0.0, 0.0)


def test_time_offset_and_lever_arm_values(tmp_path: Path) -> None:
    text = after(THEO_FILE, "time_offset = -0.125", edit(LEVER, "lever_arm = [1, -2.5, 3]"))
    by_id = {s.id: s for s in load_config(write(tmp_path, text)).sensors}
    assert by_id["T1V"].time_offset == -0.125
    assert by_id["S1"].lever_arm == (1.0, -2.5, 3.0)
    assert by_id["R1"].lever_arm == (0.0, 0.0, 0.0)


def test_target_initial_state_is_parsed_and_checked(tmp_path: Path) -> None:
    init = ('initial = { time = 1234.5, lat = 34.6, lon = -117.8, height = 4500.0, ve = 120.0, '
            'vn = -35.0, vu = 4.0, sigma_position = 10.0, sigma_velocity = 5.0 }\n')
    text = '[[targets]]\nid = "T1"\n' + init + "\n" + BASE
    cfg = load_config(write(tmp_path, text))
    got = cfg.targets[0].initial
    assert got is not None and got.time == 1234.5 and got.velocity == (120.0, -35.0, 4.0)
    assert got.position.height == 4500.0 and got.sigma_position == 10.0
    for old, new, key in (("time = 1234.5, ", "", "targets[0].initial.time: missing"),
                          ("lat = 34.6, ", "", "targets[0].initial.lat: missing"),
                          ("sigma_velocity = 5.0", "sigma_velocity = -1.0",
                           "targets[0].initial.sigma_velocity: must be > 0")):
        with pytest.raises(ConfigError) as info:
            load_config(write(tmp_path, text.replace(old, new, 1)))
        assert key in str(info.value), str(info.value)
    with pytest.raises(ConfigError, match=r"targets\[0\]\.initial\.speed: unknown key"):
        load_config(write(tmp_path, text.replace("vu = 4.0", "speed = 4.0")))
