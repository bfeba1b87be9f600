"""Convert the Autoferry sensor-fusion dataset to rangeproc's data contract.

Usage::

    python tools/autoferry.py OUT_DIR [--scenarios 2 3 ...] [--data DIR] [--elevation-zero]
    python tools/autoferry.py --spreads

writes ``OUT_DIR/scenario_<n>/`` for each scenario (default: all nine, 2 3 4 5 6 13 16 17 22)
from the three CSV files of ``../shared/realdata/autoferry/`` (README there: the milliAmpere
ferry in Trondheim harbour with a radar, a lidar and EO/IR cameras; two boats with GNSS truth).
``--spreads`` prints the per-scenario residual spreads of every sensor against the GNSS truth
(:func:`residual_spreads`, how the a-priori sigmas below were chosen) instead of converting.

Mapping (dataset -> contract, DATA_CONTRACT.md sections 1-3):

* **Frame and time.** The dataset's local NED frame "Piren" (origin lat 63.4389029083, lon
  10.39908278, height 39.923 m; everything 2-D, down = 0) is the contract's range frame:
  ``[range].origin`` is the Piren origin, so range ENU = (east_m, north_m, -down_m) exactly.
  ``time`` is the dataset's ``unix_s`` as float seconds, unchanged, in every file.
* **FERRY.csv** (kind ``ins``): the ferry as a moving platform. One row per unique time stamp
  of the radar, lidar, EO and IR rows merged (their ``ownship_north_m, ownship_east_m`` agree
  to 0.5 mm where stamps coincide; the mean is taken); roll = pitch = yaw = 0 (the dataset's
  plots and bearings are already north-referenced, so the deck frame is the NED frame);
  ``lat, lon`` from the ownship NED offsets (down = 0) with ``pymap3d.ned2geodetic`` about the
  origin; ``height`` = the origin's height (the sea surface; such a point lies d^2 / 2R below
  the tangent plane, 2 cm at d = 500 m, which is ignored).
* **RADAR.csv, LIDAR.csv** (kind ``radar``, ``platform = "FERRY"``, ``lever_arm = [0, 0, 0]``):
  one row per plot: ``range`` = ``range_m``, ``azimuth`` = ``azimuth_deg_from_north`` (deg; the
  deck azimuth, since yaw = 0), ``elevation`` empty (2-D sensors), no ``track_id`` column: these
  are plots (clutter included) for rangeproc to associate. Plots of one scan share one time
  stamp (radar scans every ~1.68 s, lidar every ~0.5 s).
* **EO.csv, IR.csv** (kind ``theodolite`` on the same platform): ``azimuth`` =
  ``bearing_deg_from_north``, ``elevation`` empty, no ``range``, no ``track_id``: angle-only
  detections (several per frame, ~0.07 s apart, including other objects in view).
* **scenario.toml**: the origin, ``[output] dir = "out"``, ``rate_hz = 5``, the five sensors
  with the a-priori sigmas of :data:`SIGMAS` (``angle_unit = "deg"``) and **no**
  ``[[targets]]``: the boats carry no GPS in the data given to rangeproc, both are undeclared
  objects to be discovered (rangeproc names the largest after its default target T1 and the
  others O1, O2, ...).
* **truth.csv** (for ``rangeproc evaluate``, never read by ``run``): ``target_id`` "B1" (target
  1, Havfruen) and "B2" (target 2: Gunnerus in scenarios 2-6, a jet boat in 13-22), ``time``,
  ``e, n, u`` = east_m, north_m, -down_m (m), ``ve, vn, vu`` by central finite differences of
  the GNSS positions (``numpy.gradient``; one-sided at the ends).

Surface-plane variant (``--elevation-zero``): the radar and lidar rows get ``elevation = 0``
(deg) instead of an empty cell, with the sensor's elevation sigma (2 deg). This states what the
dataset itself assumes (everything at down = 0, the ferry's deck frame level): the objects are
on the sea surface at the sensor's height. It exists because rangeproc cannot start an object
from 2-D plots (a row needs range, azimuth *and* elevation to fix a position: see the README's
"Real data: Autoferry"); the default conversion is the faithful one, elevation empty.

A-priori sigmas (:data:`SIGMAS`): robust spreads (1.4826 x median absolute deviation) of the
residuals against the GNSS truth of the nearer boat (``--spreads``; radar/lidar plots within
40 / 20 m of a boat, camera bearings within 8 deg of one), medians over the nine scenarios:
radar range 4.5 m and azimuth 1.7 deg (the dataset README: range spread 3-11 m, azimuth a few
degrees; we take 5 m and 2 deg), lidar range 2.1 m and azimuth 1.8 deg (the azimuth spread
is the boats' extent seen at 40-120 m, not the lidar's beam: we take 2 m and 2 deg), EO 2.5
deg and IR 3.3 deg (wider than the 0.5-1 deg a camera's pixels suggest, again mostly target
extent and the GNSS antenna not being the centre of the detected box: we take 2.5 and 3 deg).
The truth is used only to choose these constants, once; the conversion itself never reads it
into the sensor files.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd
import pymap3d

REPO = Path(__file__).resolve().parents[1]
#: The dataset as shared with the project (read-only).
DATA_DIR = REPO.parent / "shared" / "realdata" / "autoferry"
PLOTS_FILE = "radar_lidar_plots.csv"
BEARINGS_FILE = "eo_ir_bearings.csv"
TRUTH_FILE = "targets_gnss_truth.csv"
#: The Piren NED origin (deg, deg, m above the ellipsoid): the range origin.
ORIGIN: Mapping[str, float] = MappingProxyType(
    {"lat": 63.4389029083, "lon": 10.39908278, "height": 39.923})
SCENARIOS = (2, 3, 4, 5, 6, 13, 16, 17, 22)
#: Output sample rate of the fused trajectory (Hz).
RATE_HZ = 5.0
#: Contract sensor id -> (kind, dataset sensor name).
SENSORS: Mapping[str, tuple[str, str]] = MappingProxyType({
    "RADAR": ("radar", "radar"), "LIDAR": ("radar", "lidar"),
    "EO": ("theodolite", "eo"), "IR": ("theodolite", "ir")})
PLATFORM = "FERRY"
#: A-priori 1-sigma per sensor (m, deg): see the module docstring for how they were chosen.
SIGMAS: Mapping[str, Mapping[str, float]] = MappingProxyType({
    "RADAR": MappingProxyType({"range": 5.0, "azimuth": 2.0, "elevation": 2.0}),
    "LIDAR": MappingProxyType({"range": 2.0, "azimuth": 2.0, "elevation": 2.0}),
    "EO": MappingProxyType({"azimuth": 2.5, "elevation": 2.5}),
    "IR": MappingProxyType({"azimuth": 3.0, "elevation": 3.0}),
    PLATFORM: MappingProxyType({"roll": 0.01, "pitch": 0.01, "yaw": 0.01, "position": 0.5}),
})
#: Truth target ids: dataset target_id -> contract id.
BOATS: Mapping[int, str] = MappingProxyType({1: "B1", 2: "B2"})


@dataclass(frozen=True, slots=True)
class Dataset:
    """The three tables of the dataset (all scenarios), as read from its CSV files."""

    plots: pd.DataFrame      # radar_lidar_plots.csv
    bearings: pd.DataFrame   # eo_ir_bearings.csv
    truth: pd.DataFrame      # targets_gnss_truth.csv

    def scenario(self, n: int) -> Dataset:
        """The rows of scenario ``n`` only; ValueError if it has no plots."""
        out = Dataset(*(df[df["scenario"] == n].reset_index(drop=True)
                        for df in (self.plots, self.bearings, self.truth)))
        if out.plots.empty:
            have = sorted(int(x) for x in self.plots["scenario"].unique())
            raise ValueError(f"scenario {n} is not in the dataset (scenarios: {have})")
        return out


def load_dataset(data_dir: Path = DATA_DIR) -> Dataset:
    """Read the dataset's three CSV files from ``data_dir``."""
    data_dir = Path(data_dir)
    return Dataset(pd.read_csv(data_dir / PLOTS_FILE), pd.read_csv(data_dir / BEARINGS_FILE),
                   pd.read_csv(data_dir / TRUTH_FILE))


def ned2geodetic(north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Latitude, longitude (deg) of points at ``north``, ``east`` (m; down = 0) in the Piren NED
    frame (WGS-84, pymap3d)."""
    lat, lon, _ = pymap3d.ned2geodetic(np.asarray(north, float), np.asarray(east, float),
                                       np.zeros(np.shape(north)), ORIGIN["lat"], ORIGIN["lon"],
                                       ORIGIN["height"])
    return np.asarray(lat, float), np.asarray(lon, float)


def ins_table(data: Dataset) -> pd.DataFrame:
    """The ferry's INS rows of one scenario: ``time`` (s), roll = pitch = yaw = 0 (deg),
    ``lat, lon`` (deg), ``height`` (m), one row per unique time stamp of every sensor row."""
    cols = ["unix_s", "ownship_north_m", "ownship_east_m"]
    own = pd.concat([data.plots[cols], data.bearings[cols]], ignore_index=True)
    own = own.groupby("unix_s", sort=True).mean().reset_index()
    lat, lon = ned2geodetic(own["ownship_north_m"].to_numpy(), own["ownship_east_m"].to_numpy())
    zero = np.zeros(len(own))
    return pd.DataFrame({"time": own["unix_s"].to_numpy(float), "roll": zero, "pitch": zero,
                         "yaw": zero, "lat": lat, "lon": lon,
                         "height": np.full(len(own), ORIGIN["height"])})


def radar_table(data: Dataset, sensor: str, elevation_zero: bool = False) -> pd.DataFrame:
    """Plots of ``sensor`` ("radar" or "lidar"): ``time`` (s), ``range`` (m), ``azimuth`` (deg
    from north), ``elevation`` empty (NaN, written as an empty cell) or, with
    ``elevation_zero``, 0 deg (the surface-plane variant); time ordered."""
    d = data.plots[data.plots["sensor"] == sensor].sort_values("unix_s", kind="stable")
    return pd.DataFrame({"time": d["unix_s"].to_numpy(float),
                         "range": d["range_m"].to_numpy(float),
                         "azimuth": d["azimuth_deg_from_north"].to_numpy(float),
                         "elevation": np.full(len(d), 0.0 if elevation_zero else np.nan)})


def camera_table(data: Dataset, sensor: str) -> pd.DataFrame:
    """Bearings of ``sensor`` ("eo" or "ir"): ``time`` (s), ``azimuth`` (deg from north),
    ``elevation`` empty; time ordered."""
    d = data.bearings[data.bearings["sensor"] == sensor].sort_values("unix_s", kind="stable")
    return pd.DataFrame({"time": d["unix_s"].to_numpy(float),
                         "azimuth": d["bearing_deg_from_north"].to_numpy(float),
                         "elevation": np.full(len(d), np.nan)})


def truth_table(data: Dataset) -> pd.DataFrame:
    """GNSS truth of both boats in the range ENU frame: ``target_id`` ("B1", "B2"), ``time``
    (s), ``e, n, u`` (m), ``ve, vn, vu`` (m/s, central finite differences)."""
    parts = []
    for tid, name in BOATS.items():
        d = data.truth[data.truth["target_id"] == tid].sort_values("unix_s", kind="stable")
        if d.empty:
            continue
        t = d["unix_s"].to_numpy(float)
        enu = np.column_stack([d["east_m"].to_numpy(float), d["north_m"].to_numpy(float),
                               -d["down_m"].to_numpy(float)])
        vel = np.gradient(enu, t, axis=0) if len(t) > 1 else np.zeros_like(enu)
        parts.append(pd.DataFrame({"target_id": name, "time": t, "e": enu[:, 0],
                                   "n": enu[:, 1], "u": enu[:, 2] + 0.0, "ve": vel[:, 0],
                                   "vn": vel[:, 1], "vu": vel[:, 2]}))
    return pd.concat(parts, ignore_index=True)


def _toml_table(d: Mapping[str, float]) -> str:
    return "{ " + ", ".join(f"{k} = {v!r}" for k, v in d.items()) + " }"


def config_text(scenario: int, elevation_zero: bool = False) -> str:
    """``scenario.toml``: contract config of one converted scenario (files beside it)."""
    variant = " (surface-plane variant: radar/lidar elevation = 0)" if elevation_zero else ""
    lines = [f"# Autoferry scenario {scenario}, converted by tools/autoferry.py{variant}",
             "# (no [[targets]]: both boats are undeclared objects for rangeproc to discover)",
             "", "[range]", f"origin = {_toml_table(ORIGIN)}", "", "[output]",
             'dir = "out"', f"rate_hz = {RATE_HZ!r}", ""]
    lines += ["[[sensors]]", f'id = "{PLATFORM}"', 'kind = "ins"', f'file = "{PLATFORM}.csv"',
              'angle_unit = "deg"', f"sigma = {_toml_table(SIGMAS[PLATFORM])}", ""]
    for sid, (kind, _) in SENSORS.items():
        lines += ["[[sensors]]", f'id = "{sid}"', f'kind = "{kind}"', f'file = "{sid}.csv"',
                  f'platform = "{PLATFORM}"', "lever_arm = [0.0, 0.0, 0.0]",
                  'angle_unit = "deg"', f"sigma = {_toml_table(SIGMAS[sid])}", ""]
    return "\n".join(lines)


def _write_csv(df: pd.DataFrame, path: Path) -> None:
    df.to_csv(path, index=False, na_rep="")      # shortest round-trip repr of each float


def convert_scenario(data: Dataset, scenario: int, out_dir: Path, elevation_zero: bool = False
                     ) -> Path:
    """Write ``out_dir/scenario_<n>/`` (sensor CSVs, ``scenario.toml``, ``truth.csv``) from
    ``data`` (the whole dataset or that scenario's rows); returns the config path.
    ``elevation_zero``: the surface-plane variant (radar/lidar elevation 0 instead of empty)."""
    d = data.scenario(scenario)
    folder = Path(out_dir) / f"scenario_{scenario}"
    folder.mkdir(parents=True, exist_ok=True)
    ins = ins_table(d)
    _write_csv(ins, folder / f"{PLATFORM}.csv")
    for sid, (kind, name) in SENSORS.items():
        table = (radar_table(d, name, elevation_zero) if kind == "radar"
                 else camera_table(d, name))
        _write_csv(table, folder / f"{sid}.csv")
    _write_csv(truth_table(d), folder / "truth.csv")
    cfg = folder / "scenario.toml"
    cfg.write_text(config_text(scenario, elevation_zero))
    return cfg


def convert(out_dir: Path, scenarios: Iterable[int] = SCENARIOS, data_dir: Path = DATA_DIR,
            elevation_zero: bool = False) -> list[Path]:
    """Convert each of ``scenarios``; returns their config paths."""
    data = load_dataset(data_dir)
    return [convert_scenario(data, int(n), out_dir, elevation_zero) for n in scenarios]


def _robust_spread(x: np.ndarray) -> float:
    """1.4826 x median absolute deviation (the sigma of a normal core), NaN if empty."""
    x = x[np.isfinite(x)]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")


def _wrap_deg(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def residual_spreads(data: Dataset, plot_gate_m: Mapping[str, float] = MappingProxyType(
                         {"radar": 40.0, "lidar": 20.0}), bearing_gate_deg: float = 8.0
                     ) -> pd.DataFrame:
    """Per scenario and sensor, residuals against the GNSS truth of the nearer boat.

    Each plot/bearing is compared with the boat (truth interpolated to its time) nearest to it
    (plots: position distance; bearings: angle); plots within ``plot_gate_m[sensor]`` (m) and
    bearings within ``bearing_gate_deg`` of a boat count. Columns: scenario, sensor, n (rows),
    n_near (rows counted), range_median, range_spread (m), azimuth_median, azimuth_spread
    (deg), range_to_boat_median (m); spreads are :func:`_robust_spread`.
    """
    out = []
    for sc in sorted(int(s) for s in data.plots["scenario"].unique()):
        d = data.scenario(sc)
        for name in ("radar", "lidar", "eo", "ir"):
            plot = name in plot_gate_m
            rows = (d.plots[d.plots["sensor"] == name] if plot
                    else d.bearings[d.bearings["sensor"] == name])
            t = rows["unix_s"].to_numpy(float)
            on, oe = rows["ownship_north_m"].to_numpy(float), rows["ownship_east_m"].to_numpy(float)
            best = np.full((len(rows), 4), np.nan)       # distance, d range, d az, range
            for tid in BOATS:
                tr = d.truth[d.truth["target_id"] == tid].sort_values("unix_s")
                if tr.empty:
                    continue
                tt = tr["unix_s"].to_numpy(float)
                inside = (t >= tt[0]) & (t <= tt[-1])
                bn = np.interp(t, tt, tr["north_m"].to_numpy(float)) - on
                be = np.interp(t, tt, tr["east_m"].to_numpy(float)) - oe
                rng = np.hypot(bn, be)
                az = np.degrees(np.arctan2(be, bn))
                if plot:
                    dr = rows["range_m"].to_numpy(float) - rng
                    da = _wrap_deg(rows["azimuth_deg_from_north"].to_numpy(float) - az)
                    dist = np.hypot(rows["rel_north_m"].to_numpy(float) - bn,
                                    rows["rel_east_m"].to_numpy(float) - be)
                else:
                    dr = np.full(len(rows), np.nan)
                    da = _wrap_deg(rows["bearing_deg_from_north"].to_numpy(float) - az)
                    dist = np.abs(da)
                dist = np.where(inside, dist, np.inf)
                take = ~(best[:, 0] <= dist)
                best[take] = np.column_stack([dist, dr, da, rng])[take]
            near = best[:, 0] < (plot_gate_m[name] if plot else bearing_gate_deg)
            b = best[near]
            out.append({"scenario": sc, "sensor": name, "n": len(rows), "n_near": int(near.sum()),
                        "range_median": float(np.median(b[:, 1])) if plot and b.size
                        else float("nan"),
                        "range_spread": _robust_spread(b[:, 1]) if plot else float("nan"),
                        "azimuth_median": float(np.median(b[:, 2])) if b.size else float("nan"),
                        "azimuth_spread": _robust_spread(b[:, 2]),
                        "range_to_boat_median": float(np.median(b[:, 3])) if b.size
                        else float("nan")})
    return pd.DataFrame(out)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description="Convert the Autoferry dataset (radar/lidar plots, EO/IR bearings, GNSS "
                    "truth) to rangeproc's data contract: OUT_DIR/scenario_<n>/ with "
                    "scenario.toml, FERRY/RADAR/LIDAR/EO/IR.csv and truth.csv.")
    ap.add_argument("out_dir", type=Path, nargs="?", help="output folder (created)")
    ap.add_argument("--scenarios", type=int, nargs="+", default=list(SCENARIOS),
                    help=f"scenario numbers (default: {' '.join(map(str, SCENARIOS))})")
    ap.add_argument("--data", type=Path, default=DATA_DIR,
                    help=f"the dataset's folder (default: {DATA_DIR})")
    ap.add_argument("--elevation-zero", action="store_true",
                    help="surface-plane variant: write elevation = 0 deg for the radar and "
                         "lidar plots instead of an empty cell (see the module docstring)")
    ap.add_argument("--spreads", action="store_true",
                    help="print the residual spreads against GNSS truth (how the a-priori "
                         "sigmas were chosen) and exit")
    a = ap.parse_args(argv)
    if a.spreads:
        table = residual_spreads(load_dataset(a.data))
        with pd.option_context("display.width", 200, "display.max_rows", 100):
            print(table.round(2).to_string(index=False))
            print("\nmedian over scenarios:")
            print(table.groupby("sensor")[["range_median", "range_spread", "azimuth_median",
                                           "azimuth_spread"]].median().round(2))
        return 0
    if a.out_dir is None:
        ap.error("OUT_DIR is required (unless --spreads)")
    try:
        configs = convert(a.out_dir, a.scenarios, a.data, a.elevation_zero)
    except (OSError, ValueError) as exc:
        print(f"autoferry: error: {exc}", file=sys.stderr)
        return 2
    for c in configs:
        print(c)
    return 0


if __name__ == "__main__":
    sys.exit(main())
