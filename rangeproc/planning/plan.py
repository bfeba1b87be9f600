"""``rangeproc plan CONFIG TRAJECTORY``: the accuracy a flight can achieve, before it flies.

From a planned trajectory and a config's sensors, predict the fused position and velocity
sigma over the flight, which sensors carry the solution where, where the geometry is weak
and which calibration terms the flight will make observable.

Method (a covariance analysis with the run's own models and smoother): the planned track is
interpolated by a quintic spline (``simulate.recorded``); every sensor's rows along it are
made with the config's geometry, sigmas and rates (``planning.rows``: the measurement model
at the planned state plus the stated noise, seeded); and the run's fusion stage
(``fusion.centralised.fuse_target``: the process-noise search, the refinement passes, the
registration and its consider covariance) estimates the track from them. The smoother's
covariance is the prediction: in a linearised Kalman smoother it does not depend on the
measured values, only on the geometry, the noise and the process noise, which the search
chooses from rows like the flight's. The calibration terms are those the run would estimate
(``[processing] calibration``, each sensor's ``calibrate``), with the run's observability
test.

Outputs in the config's ``[output] dir``: ``plan.parquet`` (one row per output epoch:
``time``, ``e, n, u`` the planned position, ``sigma_e, sigma_n, sigma_u`` (m),
``sigma_ve, sigma_vn, sigma_vu`` (m/s), the same with ``_calibrated`` appended (every
calibration term known: the sensors calibrated exactly, or free of systematic errors; the
calibration's share of the covariance left out), ``n_sensors`` and ``sensors`` (the sensors
with rows within the epoch's output interval), ``weak`` (weak geometry there, e.g. ``TH1 near zenith
(84 deg)``)), ``plan.json`` (the sensors as planned, the calibration terms' predicted sigma
or why they stay unobservable, the sigma's summary) and ``plan.png``.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.config import Config, load_config
from rangeproc.errors import DataError
from rangeproc.estimation.linalg import packed_diagonal
from rangeproc.evaluate.truth import geodetic_to_range
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.calibration_summary import calibration_summary
from rangeproc.fusion.centralised import N_PACKED_NODE, fuse_target
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.fusion.registration import spans_calibration_covariance
from rangeproc.io.writers import write_json, write_parquet
from rangeproc.models.measurement import SPHERICAL
from rangeproc.planning.figure import plan_figure
from rangeproc.planning.rows import SensorPlan, planned_rows
from rangeproc.simulate.recorded import read_track, recorded_trajectory
from rangeproc.stages.fuse import calibration_specs, estimator_settings, target_prior

log = logging.getLogger(__name__)

#: A theodolite above this elevation (rad) is near zenith: its azimuth fixes little.
ZENITH_ELEVATION = np.radians(80.0)
#: A radar below this elevation (rad) looks through the most refraction and multipath.
LOW_ELEVATION = np.radians(3.0)


@dataclass(frozen=True)
class PlanOutput:
    """What ``rangeproc plan`` wrote: the table, the summary and the files."""

    table: pd.DataFrame
    summary: dict
    written: tuple[Path, ...]


def planned_track(path: Path, cfg: Config) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Times (M,) s, range ENU positions (M, 3) m and velocities (M, 3) m/s or None of a
    planned trajectory (the truth format of ``rangeproc evaluate``; geodetic with the
    config's origin). One object; at least ``simulate.recorded.MIN_SAMPLES`` rows."""
    table = read_track(Path(path), "a planned trajectory")
    if table.form == "geodetic":
        pos, vel = geodetic_to_range(cfg.origin, table.position, table.velocity)
        return table.time, pos, vel
    return table.time, table.position, table.velocity


def run_plan(config_path: str | Path, trajectory_path: str | Path, *, seed: int = 1,
             tick: Callable[..., None] = lambda *a, **k: None) -> PlanOutput:
    """Plan one flight (module docstring) and write its outputs."""
    cfg = load_config(config_path)
    frame = RangeFrame(cfg.origin)
    t, pos, vel = planned_track(Path(trajectory_path), cfg)
    span = float(t[-1] - t[0])
    track = recorded_trajectory(t, pos, vel, float(t[0]), span, None, smooth=False)
    batch, plans, left_out = planned_rows(cfg, frame, track.state, float(t[0]),
                                          float(t[0]) + span, seed)
    for line in left_out:
        log.warning("plan: %s", line)
    if len(batch) == 0:
        raise DataError(f"{Path(trajectory_path).name}: no configured sensor sees the planned "
                        "trajectory")
    settings = estimator_settings(cfg)
    prior = target_prior(cfg.targets[0], frame) if cfg.targets else None
    fused = fuse_target(batch, cfg.output.rate_hz, settings, tick, prior=prior)
    table = plan_table(fused, track.state, cfg, batch)
    summary = plan_summary(cfg, fused, plans, left_out, table)
    out_dir = Path(cfg.output.dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = (write_parquet(table, out_dir / "plan.parquet"),
               write_json(summary, out_dir / "plan.json"),
               plan_figure(table, summary, out_dir / "plan.png"))
    return PlanOutput(table, summary, written)


def plan_table(fused: FusionResult, state: Callable, cfg: Config,
               batch: MeasurementBatch) -> pd.DataFrame:
    """One row per output epoch: planned position, predicted sigmas, contributing sensors,
    weak geometry (module docstring)."""
    t = fused.epoch_t[fused.grid]
    Ps = fused.Ps[fused.grid]
    p = state(t)[0]
    sig_p = np.sqrt(np.maximum(packed_diagonal(Ps, 0, 3), 0.0))
    sig_v = np.sqrt(np.maximum(packed_diagonal(Ps, 3, 3), 0.0))
    known = Ps[:, :N_PACKED_NODE] - spans_calibration_covariance(fused.calibration, t)
    known_p = np.sqrt(np.maximum(packed_diagonal(known, 0, 3), 0.0))
    known_v = np.sqrt(np.maximum(packed_diagonal(known, 3, 3), 0.0))
    dt = 1.0 / cfg.output.rate_hz
    rows = fused.batch
    k = np.clip(np.searchsorted(t, rows.t - 0.5 * dt), 0, len(t) - 1)
    ids = rows.sensor_ids
    seen = np.zeros((len(t), len(ids)), dtype=bool)
    seen[k, rows.sensor] = True
    weak = [[] for _ in t]
    kinds = {s.id: s.kind for s in cfg.sensors}
    spherical = (rows.model == SPHERICAL) & np.isfinite(rows.z[:, 2])
    for i, sid in enumerate(ids):
        sel = spherical & (rows.sensor == i)
        if not sel.any():
            continue
        el = np.full(len(t), np.nan)
        np.fmax.at(el, k[sel], rows.z[sel, 2])
        flag, what = ((el > ZENITH_ELEVATION, "near zenith") if kinds[sid] == "theodolite"
                      else (el < LOW_ELEVATION, "at low elevation"))
        for j in np.flatnonzero(flag):
            weak[j].append(f"{sid} {what} ({np.degrees(el[j]):.0f} deg)")
    return pd.DataFrame({
        "time": t, "e": p[:, 0], "n": p[:, 1], "u": p[:, 2],
        "sigma_e": sig_p[:, 0], "sigma_n": sig_p[:, 1], "sigma_u": sig_p[:, 2],
        "sigma_ve": sig_v[:, 0], "sigma_vn": sig_v[:, 1], "sigma_vu": sig_v[:, 2],
        **{f"sigma_{ax}_calibrated": known_p[:, i] for i, ax in enumerate("enu")},
        **{f"sigma_v{ax}_calibrated": known_v[:, i] for i, ax in enumerate("enu")},
        "n_sensors": seen.sum(axis=1).astype(np.int64),
        "sensors": [",".join(ids[j] for j in np.flatnonzero(r)) for r in seen],
        "weak": ["; ".join(w) for w in weak]})


def plan_summary(cfg: Config, fused: FusionResult, plans: dict[str, SensorPlan],
                 left_out: list[str], table: pd.DataFrame) -> dict:
    """plan.json: the sensors as planned, the calibration terms (predicted sigma or why not
    observable), the predicted sigmas' median and largest value per axis."""
    specs = calibration_specs(cfg) if cfg.processing.calibration else ()
    sensors = {}
    for i, s in enumerate(cfg.sensors):
        if s.id not in plans:
            continue
        plan = plans[s.id]
        entry: dict = {"kind": s.kind, "rate_hz": plan.rate_hz, "components": plan.columns,
                       "rate_and_components_from": plan.source,
                       "rows": int(np.count_nonzero(fused.batch.sensor == i))}
        if specs:
            cal = calibration_summary(s, i, specs[i], fused.calibration)
            entry["calibration"] = {name: ({"predicted_sigma": c["sigma"], "unit": c["unit"]}
                                           if c.get("sigma") is not None else
                                           {"unobservable": c.get("unobservable")
                                            or c.get("not_estimated")})
                                    for name, c in cal.items()}
        sensors[s.id] = entry
    sig = {ax: {"median": float(np.median(table[f"sigma_{ax}"])),
                "max": float(np.max(table[f"sigma_{ax}"]))}
           for ax in ("e", "n", "u", "ve", "vn", "vu")}
    weak = table["weak"][table["weak"] != ""]
    return {"config": str(cfg.path), "epochs": len(table),
            "span_s": [float(table["time"].iloc[0]), float(table["time"].iloc[-1])],
            "sigma": sig, "sensors": sensors, "left_out": left_out,
            "weak_geometry_epochs": int(len(weak)),
            "weak_geometry": sorted({w.split(" (")[0] for line in weak
                                     for w in line.split("; ")})}


def format_plan(out: PlanOutput) -> list[str]:
    """The lines the terminal shows."""
    s = out.summary
    lines = [f"planned {s['epochs']:,} epochs over {s['span_s'][1] - s['span_s'][0]:.0f} s; "
             "1-sigma median (max): position "
             + ", ".join(f"{ax} {s['sigma'][ax]['median']:.3g} ({s['sigma'][ax]['max']:.3g}) m"
                         for ax in "enu")
             + "; velocity "
             + ", ".join(f"{ax[1]} {s['sigma'][ax]['median']:.3g} m/s"
                         for ax in ("ve", "vn", "vu"))]
    for sid, e in s["sensors"].items():
        cal = e.get("calibration", {})
        obs = [f"{n} ±{c['predicted_sigma']:.2g} {c['unit']}" for n, c in cal.items()
               if "predicted_sigma" in c]
        not_obs = [n for n, c in cal.items() if "unobservable" in c]
        text = f"{sid}: {e['rows']:,} rows at {e['rate_hz']:g} Hz ({e['rate_and_components_from']})"
        if obs:
            text += "; observable: " + ", ".join(obs)
        if not_obs:
            text += "; not observable: " + ", ".join(not_obs)
        lines.append(text)
    lines += [f"left out: {line}" for line in s["left_out"]]
    if s["weak_geometry"]:
        lines.append(f"weak geometry at {s['weak_geometry_epochs']} epochs: "
                     + ", ".join(s["weak_geometry"]))
    lines.append("wrote " + ", ".join(str(p) for p in out.written))
    return lines
