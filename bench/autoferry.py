"""Real data: the Autoferry scenarios through rangeproc and through Stone Soup's standard
multi-target tracker, scored identically against the boats' GNSS truth.

Usage::

    python bench/autoferry.py [--scenarios 2 3 ...] [--work DIR] [--json bench/autoferry.json]

For each scenario (``tools/autoferry.py`` converts it to the data contract):

1. **rangeproc, contract-faithful**: the conversion as the dataset gives it (2-D plots: radar
   and lidar elevation empty), ``rangeproc.pipeline.run`` in-process; its outcome (objects, or
   the exception, its exit status as ``rangeproc run`` would give it and the stage it came
   from) is recorded.
2. **rangeproc, surface-plane variant** (``tools/autoferry.py --elevation-zero``: radar/lidar
   elevation 0, the objects on the sea surface): run and scored. This is the run in the table
   whenever the faithful one cannot be scored.
3. **Stone Soup** on the same radar and lidar plots (read back from the converted RADAR.csv,
   LIDAR.csv and FERRY.csv: ferry ENU position + range (sin az, cos az)): a 2-D
   constant-velocity model (``ConstantVelocity`` per axis, PSD :data:`SS_Q`), a
   ``LinearGaussian`` measurement model on position per plot (its covariance the plot's
   range/azimuth sigmas of ``scenario.toml`` carried to east/north), ``DistanceHypothesiser``
   (Mahalanobis, missed distance 3) with ``GNNWith2DAssignment``, ``MultiMeasurementInitiator``
   (3 updates to confirm, like rangeproc's 3 hits) and ``UpdateTimeStepsDeleter`` (as many
   scans as the scenario has in :data:`SS_DELETE_S` s; ``--deleter time``: ``UpdateTimeDeleter``
   instead, see :func:`stonesoup_tracks`), in ``MultiTargetTracker``. Its tracks are written in the
   contract's ``fused.parquet`` layout as objects "S1", "S2", ... on the same uniform
   ``rate_hz`` grid as rangeproc's output (each track from its first state to its last update,
   each grid epoch the track's last state predicted to it), so that both outputs are scored by
   the same ``evaluate_run``: per-epoch GOSPA and assignment compare objects that exist at one
   epoch, and a tracker whose objects carry rows only at their own update times would count
   the other boat missed at nearly every epoch.

Scoring: ``rangeproc.evaluate.metrics.evaluate_run(out_dir, truth.csv, cutoff=CUTOFF_M)``;
the cutoff is 20 m (not the 50 m default): the boats are 10-30 m long and the radar's plots
scatter by about 5 m in range and 2 deg in azimuth (9 m at 250 m), so an object within 20 m
of the GNSS antenna is on the boat, and one further off is on something else (the quays,
moored boats and the other boat are often 30-100 m away).

Prints one table (scenario, boat; per tracker best-match RMSE, assigned RMSE, coverage, swaps,
fragmentation; mean GOSPA per scenario) and writes everything to ``bench/autoferry.json``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import math
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from types import ModuleType
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:                  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

import numpy as np
import pandas as pd
import pymap3d

REPO = Path(__file__).resolve().parents[1]
TOOL_PATH = REPO / "tools" / "autoferry.py"
JSON_PATH = REPO / "bench" / "autoferry.json"
#: Assignment cutoff of the scoring (m): see the module docstring.
CUTOFF_M = 20.0
#: Stone Soup: white-acceleration PSD of the constant-velocity model per axis (m^2/s^3); a
#: boat turning at 0.5 m/s^2 over a few seconds stays well inside the gate.
SS_Q = 1.0
#: Stone Soup: prior velocity sigma of a new track (m/s; the boats run at up to ~10 m/s).
SS_PRIOR_SPEED = 5.0
#: Stone Soup: Mahalanobis missed distance of the hypothesiser (the tutorials' 3).
SS_MISSED_DISTANCE = 3.0
#: Stone Soup: updates that confirm a track (rangeproc's plot tracker: 3 hits).
SS_MIN_POINTS = 3
#: Stone Soup: seconds without an update that delete a confirmed track (5 radar scans, as
#: rangeproc's plot tracker) and a tentative one (2 radar scans).
SS_DELETE_S = 5 * 1.68
SS_DELETE_TENTATIVE_S = 2 * 1.68
#: Unix epoch, for Stone Soup's datetime stamps (naive, UTC).
EPOCH = datetime(1970, 1, 1)
#: rangeproc exit statuses (cli.py) by exception class name.
EXIT_STATUS = {"ConfigError": 2, "DataError": 2, "NoPositionFix": 2, "NumericalError": 3}

log = logging.getLogger("autoferry")


def load_tool() -> ModuleType:
    """``tools/autoferry.py`` as a module (tools/ is not a package)."""
    name = "autoferry_tool"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, TOOL_PATH)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


# ---- the plots, read back from a converted scenario -------------------------------------------

@dataclass(frozen=True, slots=True)
class Plots:
    """Radar and lidar plots of one scenario in the range ENU frame (time ordered).

    t: (N,) s; p: (N, 2) east, north (m); R: (N, 2, 2) their covariance (m^2); sensor: (N,)
    sensor id; ferry: (N, 2) the ferry's east, north (m) at the plot time; row: (N,) 0-based
    data row in the sensor's file (as in rangeproc's association.parquet).
    """

    t: np.ndarray
    p: np.ndarray
    R: np.ndarray
    sensor: np.ndarray
    ferry: np.ndarray
    row: np.ndarray


def read_plots(folder: Path) -> Plots:
    """The RADAR and LIDAR plots of a converted scenario ``folder`` (its scenario.toml,
    FERRY.csv, RADAR.csv, LIDAR.csv): ferry ENU from the INS lat/lon (pymap3d) at the plot
    time, plus range (sin az, cos az); covariance from the config's range/azimuth sigmas:
    R = J diag(sr^2, sa^2) J^T, J = d(e, n)/d(r, az)."""
    cfg = tomllib.loads((folder / "scenario.toml").read_text())
    o = cfg["range"]["origin"]
    by_id = {s["id"]: s for s in cfg["sensors"]}
    ins = pd.read_csv(folder / by_id["FERRY"]["file"])
    fe, fn, _ = pymap3d.geodetic2enu(ins["lat"].to_numpy(), ins["lon"].to_numpy(),
                                     ins["height"].to_numpy(), o["lat"], o["lon"], o["height"])
    ti = ins["time"].to_numpy(float)
    parts = []
    for sid in ("RADAR", "LIDAR"):
        d = pd.read_csv(folder / by_id[sid]["file"])
        t = d["time"].to_numpy(float)
        r = d["range"].to_numpy(float)
        az = np.radians(d["azimuth"].to_numpy(float))
        s_r = float(by_id[sid]["sigma"]["range"])
        s_a = math.radians(float(by_id[sid]["sigma"]["azimuth"]))
        ferry = np.column_stack([np.interp(t, ti, fe), np.interp(t, ti, fn)])
        p = ferry + r[:, None] * np.column_stack([np.sin(az), np.cos(az)])
        J = np.empty((t.size, 2, 2))                       # d(e, n) / d(r, az)
        J[:, 0, 0], J[:, 1, 0] = np.sin(az), np.cos(az)
        J[:, 0, 1], J[:, 1, 1] = r * np.cos(az), -r * np.sin(az)
        R = J @ np.diag([s_r**2, s_a**2]) @ np.transpose(J, (0, 2, 1))
        parts.append((t, p, R, np.full(t.size, sid, dtype=object), ferry, np.arange(t.size)))
    t = np.concatenate([x[0] for x in parts])
    order = np.argsort(t, kind="stable")
    return Plots(t[order], *(np.concatenate([x[k] for x in parts])[order] for k in range(1, 6)))


# ---- Stone Soup ---------------------------------------------------------------------------

def _stamp(t: float) -> datetime:
    return EPOCH + timedelta(seconds=float(t))


def _seconds(ts: datetime) -> float:
    return (ts - EPOCH).total_seconds()


def stonesoup_tracks(plots: Plots, q: float = SS_Q, delete_s: float = SS_DELETE_S,
                     deleter: str = "steps") -> list[Any]:
    """Stone Soup's MultiTargetTracker (GNN, CV) over ``plots``, one scan per time stamp;
    every track ever confirmed (a list of ``stonesoup.types.track.Track``, in order of birth).

    State [e, ve, n, vn] (Stone Soup's per-axis order). ``deleter = "steps"`` (default):
    ``UpdateTimeStepsDeleter`` with as many steps (scans of either sensor) as the scenario has
    on average in ``delete_s`` s for confirmed tracks and in :data:`SS_DELETE_TENTATIVE_S` s
    for tentative ones; ``"time"``: ``UpdateTimeDeleter`` with those times. The radar (1.68 s)
    and lidar (0.5 s, only when it sees something) scans interleave, so a fixed number of
    steps lasts longer where only the radar sees an object than where the lidar does too; the
    time-based deleter avoids that (the two give mean GOSPA within about 1 m of each other on
    these scenarios: README).
    """
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeDeleter, UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    predictor = KalmanPredictor(transition)
    updater = KalmanUpdater(measurement_model=None)     # each detection carries its model
    hypothesiser = DistanceHypothesiser(predictor, updater, measure=Mahalanobis(),
                                        missed_distance=SS_MISSED_DISTANCE)
    associator = GNNWith2DAssignment(hypothesiser)
    scan_t = np.unique(plots.t)
    if deleter == "time":
        confirmed_del = UpdateTimeDeleter(timedelta(seconds=delete_s))
        tentative_del = UpdateTimeDeleter(timedelta(seconds=SS_DELETE_TENTATIVE_S))
    elif deleter == "steps":
        per_s = scan_t.size / max(float(scan_t[-1] - scan_t[0]), 1e-9)
        confirmed_del = UpdateTimeStepsDeleter(max(2, round(per_s * delete_s)))
        tentative_del = UpdateTimeStepsDeleter(max(2, round(per_s * SS_DELETE_TENTATIVE_S)))
    else:
        raise ValueError(f"deleter must be 'time' or 'steps', got {deleter!r}")
    prior = GaussianState(np.zeros((4, 1)), np.diag([0.0, SS_PRIOR_SPEED**2,
                                                      0.0, SS_PRIOR_SPEED**2]))
    initiator = MultiMeasurementInitiator(prior_state=prior, measurement_model=None,
                                          deleter=tentative_del, data_associator=associator,
                                          updater=updater, min_points=SS_MIN_POINTS)
    scans = []
    bounds = np.flatnonzero(np.diff(plots.t) > 0) + 1
    for rows in np.split(np.arange(plots.t.size), bounds):
        ts = _stamp(plots.t[rows[0]])
        scans.append((ts, {Detection(plots.p[i].reshape(2, 1), timestamp=ts,
                                     measurement_model=LinearGaussian(4, (0, 2), plots.R[i]),
                                     metadata={"sensor": plots.sensor[i]}) for i in rows}))
    tracker = MultiTargetTracker(initiator=initiator, deleter=confirmed_del, detector=scans,
                                 data_associator=associator, updater=updater)
    every: dict[int, Any] = {}
    for _, tracks in tracker:
        for tr in tracks:
            every[id(tr)] = tr
    # named in order of first state (ties, tracks born at one scan: by position), so the
    # names do not depend on set iteration order
    return sorted(every.values(), key=lambda tr: (tr.states[0].timestamp,
                                                  *np.asarray(tr.states[0].state_vector,
                                                              float).ravel()[[0, 2]]))


def tracks_table(tracks: list[Any], rate_hz: float, q: float = SS_Q,
                 origin: dict[str, float] | None = None) -> pd.DataFrame:
    """Stone Soup tracks as a ``fused.parquet`` table (DATA_CONTRACT section 4): objects
    "S1", "S2", ... (in order of first state); epochs on the uniform grid of ``rate_hz``
    (multiples of 1/rate_hz s) from each track's first state to its last update, each the last
    state at or before the epoch predicted to it by the CV model (PSD ``q``). u, vu, a* = 0
    (2-D); sigma_u = 0; n_sensors: sensors whose plots updated the track within the epoch's
    interval."""
    from stonesoup.types.update import Update

    o = origin or {"lat": 0.0, "lon": 0.0, "height": 0.0}
    frames = []
    for k, tr in enumerate(tracks, start=1):
        st = list(tr.states)
        ts = np.array([_seconds(s.timestamp) for s in st])
        upd = [i for i, s in enumerate(st) if isinstance(s, Update) and s.hypothesis]
        if not upd:
            continue
        t0, t1 = ts[0], ts[upd[-1]]
        grid = np.arange(math.ceil(t0 * rate_hz - 1e-9), math.floor(t1 * rate_hz + 1e-9) + 1
                         ) / rate_hz
        if grid.size == 0:
            continue
        x = np.stack([np.asarray(s.state_vector, float).ravel() for s in st])   # (S, 4)
        P = np.stack([np.asarray(s.covar, float) for s in st])                   # (S, 4, 4)
        j = np.searchsorted(ts, grid + 1e-9, side="right") - 1
        dt = grid - ts[j]
        F = np.tile(np.eye(4), (grid.size, 1, 1))
        F[:, 0, 1] = F[:, 2, 3] = dt
        Q = np.zeros((grid.size, 4, 4))
        for a in (0, 2):                                  # CV white-acceleration Q per axis
            Q[:, a, a] = q * dt**3 / 3
            Q[:, a, a + 1] = Q[:, a + 1, a] = q * dt**2 / 2
            Q[:, a + 1, a + 1] = q * dt
        xg = np.einsum("kij,kj->ki", F, x[j])
        Pg = F @ P[j] @ np.transpose(F, (0, 2, 1)) + Q
        upd_t = np.array([ts[i] for i in upd])
        upd_s = np.array([st[i].hypothesis.measurement.metadata.get("sensor", "")
                          for i in upd], dtype=object)
        n_sensors = np.array([len(set(upd_s[(upd_t > g - 1.0 / rate_hz) & (upd_t <= g)]))
                              for g in grid], dtype=np.int64)
        zero = np.zeros(grid.size)
        lat, lon, h = pymap3d.enu2geodetic(xg[:, 0], xg[:, 2], zero, o["lat"], o["lon"],
                                           o["height"])
        frames.append(pd.DataFrame({
            "target_id": f"S{k}", "time": grid, "lat": lat, "lon": lon, "height": h,
            "e": xg[:, 0], "n": xg[:, 2], "u": zero, "ve": xg[:, 1], "vn": xg[:, 3], "vu": zero,
            "ae": zero, "an": zero, "au": zero,
            "sigma_e": np.sqrt(Pg[:, 0, 0]), "sigma_n": np.sqrt(Pg[:, 2, 2]), "sigma_u": zero,
            "n_sensors": n_sensors, "cov_en": Pg[:, 0, 2]}))
    cols = ["target_id", "time", "lat", "lon", "height", "e", "n", "u", "ve", "vn", "vu", "ae",
            "an", "au", "sigma_e", "sigma_n", "sigma_u", "n_sensors", "cov_en"]
    if not frames:
        return pd.DataFrame(columns=cols)
    df = pd.concat(frames, ignore_index=True)
    # contract order: sorted by target_id then time ("S10" after "S1", as rangeproc's ids)
    return df.sort_values(["target_id", "time"], kind="stable").reset_index(drop=True)


def run_stonesoup(folder: Path, out_dir: Path, deleter: str = "steps") -> dict[str, Any]:
    """Stone Soup on a converted scenario ``folder``: writes ``out_dir/fused.parquet``;
    returns {"n_tracks", "n_plots", "seconds"}."""
    cfg = tomllib.loads((folder / "scenario.toml").read_text())
    start = time.perf_counter()
    plots = read_plots(folder)
    tracks = stonesoup_tracks(plots, deleter=deleter)
    table = tracks_table(tracks, float(cfg["output"]["rate_hz"]), origin=cfg["range"]["origin"])
    seconds = time.perf_counter() - start
    out_dir.mkdir(parents=True, exist_ok=True)
    table.to_parquet(out_dir / "fused.parquet", index=False)
    return {"n_tracks": int(table["target_id"].nunique()) if len(table) else 0,
            "n_plots": int(plots.t.size), "seconds": seconds}


# ---- rangeproc ----------------------------------------------------------------------------

class _StageLog:
    """A progress display that remembers the stages started (to name the failing one)."""

    def __init__(self) -> None:
        self.started: list[str] = []

    def start(self, stage: str, total: int) -> None:
        self.started.append(stage)

    def advance(self, stage: str, n: int = 1, note: str = "") -> None:
        pass

    def finish(self, stage: str, seconds: float) -> None:
        pass


def run_rangeproc(config: Path) -> dict[str, Any]:
    """``rangeproc.pipeline.run(config)`` in-process. Returns {"ok", "seconds",
    "stage_seconds"} and, on success, what it found (objects, association reasons per sensor,
    segments); on failure the exception, the exit status ``rangeproc run`` gives it and the
    last stage started."""
    from rangeproc.pipeline import run
    from rangeproc.progress import StageClock

    stages = _StageLog()
    clock = StageClock(display=stages)
    start = time.perf_counter()
    try:
        out = run(config, clock=clock)
    except Exception as exc:                              # recorded, never fatal to the bench
        name = type(exc).__name__
        return {"ok": False, "seconds": time.perf_counter() - start,
                "stage_seconds": dict(clock.seconds), "error": f"{name}: {exc}",
                "exception": name, "exit_status": EXIT_STATUS.get(name, 1),
                "last_stage": stages.started[-1] if stages.started else None,
                "traceback_tail": traceback.format_exc().strip().splitlines()[-3:]}
    assoc = pd.read_parquet(out.out_dir / "association.parquet")
    reasons = {str(s): {str(k): int(v) for k, v in g["reason"].value_counts().items()}
               for s, g in assoc.groupby("sensor")}
    summary = out.summary.get("association", {})
    objects = summary.get("objects", {})
    return {"ok": True, "seconds": time.perf_counter() - start,
            "stage_seconds": dict(clock.seconds), "out_dir": str(out.out_dir),
            "objects": sorted(t.target_id for t in out.tracks),
            "n_segments": summary.get("n_segments"),
            "n_unassigned_segments": summary.get("n_unassigned_segments"),
            "segments_per_object": {k: len(v["segments"]) for k, v in objects.items()},
            "reasons": reasons}


# ---- scoring and the table ----------------------------------------------------------------

def score(out_dir: Path, truth: Path, cutoff: float = CUTOFF_M) -> dict[str, Any]:
    """evaluate_run's multi-object summary, reduced to what the table shows."""
    from rangeproc.evaluate.metrics import evaluate_run

    multi = evaluate_run(out_dir, truth, cutoff=cutoff)["multi"]
    boats = {tid: {k: m[k] for k in ("best_match", "best_match_rmse", "assigned_rmse",
                                     "coverage", "swaps", "fragmentation", "n_epochs")}
             for tid, m in multi["truth"].items()}
    false_objects = sum(1 for m in multi["fused"].values() if m["majority_truth"] is None)
    return {"boats": boats, "gospa_mean": multi["gospa"]["mean"],
            "gospa_parts_mean_m2": {k: multi["gospa"][f"{k}_mean"]
                                    for k in ("localisation", "missed", "false")},
            "n_objects": multi["totals"]["n_fused"], "n_never_on_a_boat": false_objects}


def plot_fate(folder: Path, out_dir: Path, truth: Path, best: dict[str, str | None],
              radius: float = CUTOFF_M) -> dict[str, dict[str, int]]:
    """Where rangeproc put each boat's plots: per boat, the radar/lidar plots within
    ``radius`` (m) of its GNSS position (truth interpolated to the plot time) counted by what
    ``association.parquet`` says of them: "best match" (the boat's best-matching object in
    ``best``), "other object", or the association reason (clutter, ...). A plot near both
    boats counts for both."""
    plots = read_plots(folder)
    assoc = pd.read_parquet(out_dir / "association.parquet")
    key = assoc.set_index(["sensor", "row"])
    idx = pd.MultiIndex.from_arrays([plots.sensor.astype(str), plots.row])
    target = key["target_id"].reindex(idx).fillna("").to_numpy(str)
    reason = key["reason"].reindex(idx).fillna("missing").to_numpy(str)
    tr = pd.read_csv(truth)
    out: dict[str, dict[str, int]] = {}
    for boat, g in tr.groupby("target_id"):
        tt = g["time"].to_numpy(float)
        be = np.interp(plots.t, tt, g["e"].to_numpy(float), left=np.nan, right=np.nan)
        bn = np.interp(plots.t, tt, g["n"].to_numpy(float), left=np.nan, right=np.nan)
        near = np.hypot(plots.p[:, 0] - be, plots.p[:, 1] - bn) < radius
        name = best.get(str(boat))
        is_best = (target == name) if name else np.zeros(target.size, dtype=bool)
        label = np.where(is_best, "best match",
                         np.where(target != "", "other object", reason))[near]
        names, counts = np.unique(label, return_counts=True)
        out[str(boat)] = {"near_plots": int(near.sum()),
                          **{str(a): int(b) for a, b in zip(names, counts)},
                          "objects": int(np.unique(target[near][target[near] != ""]).size)}
    return out


def run_scenario(tool: ModuleType, data: Any, n: int, work: Path, cutoff: float = CUTOFF_M,
                 deleter: str = "steps") -> dict[str, Any]:
    """Convert, run both trackers and score scenario ``n`` under ``work``."""
    res: dict[str, Any] = {"scenario": n}
    faithful = tool.convert_scenario(data, n, work / "contract")
    surface = tool.convert_scenario(data, n, work / "surface", elevation_zero=True)
    truth = faithful.parent / "truth.csv"
    res["rangeproc_contract"] = run_rangeproc(faithful)
    if res["rangeproc_contract"]["ok"]:
        res["rangeproc_contract"]["score"] = score(faithful.parent / "out", truth, cutoff)
    res["rangeproc_surface"] = run_rangeproc(surface)
    if res["rangeproc_surface"]["ok"]:
        sc = score(surface.parent / "out", truth, cutoff)
        res["rangeproc_surface"]["score"] = sc
        res["rangeproc_surface"]["plot_fate"] = plot_fate(
            surface.parent, surface.parent / "out", truth,
            {b: m["best_match"] for b, m in sc["boats"].items()}, cutoff)
    ss_dir = work / "stonesoup" / f"scenario_{n}"
    res["stonesoup"] = run_stonesoup(faithful.parent, ss_dir, deleter=deleter)
    res["stonesoup"]["score"] = score(ss_dir, truth, cutoff)
    return res


def _num(x: float | None, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def format_table(results: list[dict[str, Any]]) -> str:
    """One line per scenario and boat: rangeproc (the contract run if it could be scored,
    else the surface-plane run, its object ids marked *) and Stone Soup side by side."""
    def cells(run: dict[str, Any] | None, boat: str, first: bool, tag: str) -> str:
        if run is None:
            return f"{'failed':<9} {'-':>6} {'-':>5} {'-':>5} {'-':>3} {'-':>3} {'-':>6}"
        m = run["boats"].get(boat, {})
        g = _num(run["gospa_mean"], ".1f") if first else ""
        name = (m.get("best_match") or "-") + tag
        return (f"{name:<9} {_num(m.get('best_match_rmse'), '.1f'):>6}"
                f" {_num(m.get('assigned_rmse'), '.1f'):>5} {_num(m.get('coverage'), '.2f'):>5}"
                f" {m.get('swaps', '-'):>3} {m.get('fragmentation', '-'):>3} {g:>6}")

    head = (f"{'scen':>4} {'boat':<4} | {'rangeproc':<9} {'RMSE':>6} {'asgn':>5} {'cov':>5} "
            f"{'sw':>3} {'fr':>3} {'GOSPA':>6} | {'StoneSoup':<9} {'RMSE':>6} {'asgn':>5} "
            f"{'cov':>5} {'sw':>3} {'fr':>3} {'GOSPA':>6}")
    lines = [head, "-" * len(head)]
    for r in results:
        rc = r["rangeproc_contract"]
        rp = rc if rc.get("ok") else r["rangeproc_surface"]
        tag = "" if rc.get("ok") else "*"
        for k, boat in enumerate(("B1", "B2")):
            ours = cells(rp.get("score"), boat, k == 0, tag)
            theirs = cells(r["stonesoup"]["score"], boat, k == 0, "")
            lines.append(f"{r['scenario']:>4} {boat:<4} | {ours} | {theirs}")
    lines.append("RMSE: best-match RMSE (m, every epoch both exist); asgn: RMSE over the epochs "
                 f"assigned within the {CUTOFF_M:g} m cutoff (m); cov: coverage; sw: swaps; fr: "
                 "fragmentation; GOSPA: mean per scenario (m; p = 2, alpha = 2, c = cutoff).")
    if any(not r["rangeproc_contract"].get("ok") for r in results):
        lines.append("*: the contract-faithful run (elevation empty) failed; the scores are of "
                     "the surface-plane variant (elevation 0).")
    return "\n".join(lines)


def format_runs(results: list[dict[str, Any]]) -> str:
    """Per scenario: outcome, objects and wall-clock seconds of each run."""
    head = (f"{'scen':>4} | {'rangeproc contract':<22} | {'rangeproc surface':<17} "
            f"{'assoc s':>7} {'fuse s':>6} {'report s':>8} | {'Stone Soup':<10} {'s':>5}")
    lines = [head, "-" * len(head)]
    for r in results:
        rc, rs, ss = r["rangeproc_contract"], r["rangeproc_surface"], r["stonesoup"]
        c = (f"{len(rc['objects'])} objects" if rc["ok"]
             else f"exit {rc['exit_status']} ({rc['exception']})")
        c = f"{c:<16} {rc['seconds']:5.1f}"
        st = rs.get("stage_seconds", {})
        s = (f"{len(rs['objects'])} objects" if rs["ok"] else "failed")
        lines.append(f"{r['scenario']:>4} | {c:<22} | {s:<11} {rs['seconds']:5.1f} "
                     f"{st.get('associate', 0.0):7.1f} {st.get('fuse', 0.0):6.1f} "
                     f"{st.get('report', 0.0):8.1f} | {ss['n_tracks']:>3} tracks "
                     f"{ss['seconds']:5.1f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    tool = load_tool()
    ap.add_argument("--scenarios", type=int, nargs="+", default=list(tool.SCENARIOS))
    ap.add_argument("--data", type=Path, default=tool.DATA_DIR, help="the dataset's folder")
    ap.add_argument("--work", type=Path, help="keep the converted scenarios and outputs here "
                                              "(default: a temporary folder)")
    ap.add_argument("--json", type=Path, default=JSON_PATH, help="results file")
    ap.add_argument("--cutoff", type=float, default=CUTOFF_M, help="assignment cutoff (m)")
    ap.add_argument("--deleter", choices=("steps", "time"), default="steps",
                    help="Stone Soup deleter (see stonesoup_tracks)")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    data = tool.load_dataset(a.data)
    results = []
    with tempfile.TemporaryDirectory(prefix="autoferry-") as tmp:
        work = a.work or Path(tmp)
        for n in a.scenarios:
            t0 = time.perf_counter()
            r = run_scenario(tool, data, n, work, a.cutoff, a.deleter)
            r["seconds"] = time.perf_counter() - t0
            rc, rs = r["rangeproc_contract"], r["rangeproc_surface"]
            print(f"scenario {n}: rangeproc (contract) "
                  + ("ok" if rc["ok"] else f"exit {rc['exit_status']} in stage "
                     f"'{rc['last_stage']}': {rc['error']}")
                  + f" [{rc['seconds']:.1f} s]; rangeproc (surface) "
                  + (f"{len(rs['objects'])} objects [{rs['seconds']:.1f} s]" if rs["ok"]
                     else f"failed: {rs['error']}")
                  + f"; Stone Soup {r['stonesoup']['n_tracks']} tracks "
                  f"[{r['stonesoup']['seconds']:.1f} s]", flush=True)
            results.append(r)
    table = format_table(results)
    runs = format_runs(results)
    print()
    print(table)
    print()
    print(runs)
    a.json.write_text(json.dumps({
        "cutoff_m": a.cutoff, "stonesoup": {"q": SS_Q, "prior_speed": SS_PRIOR_SPEED,
                                            "missed_distance": SS_MISSED_DISTANCE,
                                            "min_points": SS_MIN_POINTS,
                                            "delete_s": SS_DELETE_S,
                                            "delete_tentative_s": SS_DELETE_TENTATIVE_S,
                                            "deleter": a.deleter},
        "results": results, "table": table, "runs": runs}, indent=1, default=str))
    print(f"\nwritten: {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
