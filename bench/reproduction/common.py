"""Shared helpers of the seed reproductions: synthetic truth, contract logs, configs, runs,
error metrics and figures.

Conventions: the truth lives in the range ENU frame at :data:`ORIGIN` (m, m/s, m/s^2); every
experiment starts at range time :data:`T0` (s) and figures show ``t - T0``. Logs are written
to the data contract (``/work/shared/DATA_CONTRACT.md``): CSV, angles in degrees, GPS
velocity in the receiver's local ENU. Every random draw comes from a ``numpy.random.Generator``
the experiment seeds itself.
"""
from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pymap3d as pm  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from rangeproc.pipeline import RunOutput, run  # noqa: E402

T0 = 1000.0  #: s, range time of every experiment's t = 0
GRAVITY = 9.80665  #: m/s^2, flat-earth gravity of the ballistic truth


@dataclass(frozen=True, slots=True)
class Geo:
    """A WGS-84 point: ``lat``, ``lon`` in degrees, ``height`` in metres."""

    lat: float
    lon: float
    height: float


#: range origin of every experiment (seed 002's start latitude, 43.8815 N)
ORIGIN = Geo(43.8815, 125.35, 200.0)


# ------------------------------------------------------------------------------------------
# Truth
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Truth:
    """Truth on a fine uniform grid: t (K,) s; p, v, a (K, 3) range ENU (m, m/s, m/s^2)."""

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray

    def at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Linear interpolation of p, v, a at ``times`` (s) -> three (N, 3) arrays."""
        def interp(x: np.ndarray) -> np.ndarray:
            return np.column_stack([np.interp(times, self.t, x[:, j]) for j in range(3)])
        return interp(self.p), interp(self.v), interp(self.a)


def integrate(duration: float, p0: Sequence[float], v0: Sequence[float],
              accel: Callable[[np.ndarray], np.ndarray], dt: float = 0.01) -> Truth:
    """Truth from t = T0 to T0 + duration (s) driven by ``accel(tau) -> (K, 3)`` m/s^2 of the
    time since start tau (s); p0 (m), v0 (m/s) at T0. Exact for accelerations linear within a
    step (trapezoidal velocity, Simpson-consistent position increment)."""
    tau = np.arange(int(round(duration / dt)) + 1) * dt
    a = np.asarray(accel(tau), float)
    dv = 0.5 * (a[:-1] + a[1:]) * dt
    v = np.vstack([np.zeros(3), np.cumsum(dv, axis=0)]) + np.asarray(v0, float)
    dp = v[:-1] * dt + (2.0 * a[:-1] + a[1:]) * dt * dt / 6.0
    p = np.vstack([np.zeros(3), np.cumsum(dp, axis=0)]) + np.asarray(p0, float)
    return Truth(T0 + tau, p, v, a)


def sample_times(start: float, stop: float, rate_hz: float) -> np.ndarray:
    """Uniform sensor times (range s) from T0 + start to T0 + stop (s since start) inclusive."""
    n = int(np.floor((stop - start) * rate_hz + 1e-9)) + 1
    return T0 + start + np.arange(n) / rate_hz


# ------------------------------------------------------------------------------------------
# Geometry (WGS-84 through pymap3d)
# ------------------------------------------------------------------------------------------

def enu2geodetic(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range-ENU points p (N, 3) m -> lat, lon (deg), height (m), each (N,)."""
    return pm.enu2geodetic(p[:, 0], p[:, 1], p[:, 2], ORIGIN.lat, ORIGIN.lon, ORIGIN.height)


def geo_at(e: float, n: float, u: float) -> Geo:
    """The WGS-84 point at range-ENU (e, n, u) m."""
    lat, lon, h = pm.enu2geodetic(e, n, u, ORIGIN.lat, ORIGIN.lon, ORIGIN.height)
    return Geo(round(float(lat), 9), round(float(lon), 9), round(float(h), 3))


def geo_enu(site: Geo) -> np.ndarray:
    """Range-ENU position (3,) m of a WGS-84 point."""
    return np.array(pm.geodetic2enu(site.lat, site.lon, site.height,
                                    ORIGIN.lat, ORIGIN.lon, ORIGIN.height), float)


def log_enu(log: pd.DataFrame) -> np.ndarray:
    """Range-ENU positions (N, 3) m of a log's ``lat``, ``lon`` (deg), ``height`` (m)."""
    lat, lon, h = (log[k].to_numpy(float) for k in ("lat", "lon", "height"))
    return np.column_stack(pm.geodetic2enu(lat, lon, h, ORIGIN.lat, ORIGIN.lon, ORIGIN.height))


def _ecef(p: np.ndarray) -> np.ndarray:
    """Range-ENU points (N, 3) m -> ECEF (N, 3) m."""
    return np.column_stack(pm.enu2ecef(p[:, 0], p[:, 1], p[:, 2],
                                       ORIGIN.lat, ORIGIN.lon, ORIGIN.height))


def _ecef_vector(v: np.ndarray) -> np.ndarray:
    """Range-ENU vectors (N, 3) -> ECEF vectors (N, 3) (same unit)."""
    return np.column_stack(pm.enu2uvw(v[:, 0], v[:, 1], v[:, 2], ORIGIN.lat, ORIGIN.lon))


def local_velocity(v: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Range-ENU velocities (N, 3) m/s -> the receiver-local ENU at lat, lon (deg) (N, 3)."""
    u = _ecef_vector(v)
    return np.column_stack(pm.uvw2enu(u[:, 0], u[:, 1], u[:, 2], lat, lon))


def site_aer(p: np.ndarray, site: Geo) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Azimuth, elevation (rad, in the site's own local ENU) and slant range (m) of range-ENU
    points p (N, 3) seen from ``site``."""
    lat, lon, h = enu2geodetic(p)
    az, el, rng = pm.geodetic2aer(lat, lon, h, site.lat, site.lon, site.height)
    return np.radians(az), np.radians(el), np.asarray(rng, float)


def range_rate(p: np.ndarray, v: np.ndarray, site: Geo) -> np.ndarray:
    """d/dt |p - site| (m/s, positive receding) for range-ENU p (N, 3) m and v (N, 3) m/s."""
    los = _ecef(p) - np.array(pm.geodetic2ecef(site.lat, site.lon, site.height))
    return np.einsum("ij,ij->i", los, _ecef_vector(v)) / np.linalg.norm(los, axis=1)


# ------------------------------------------------------------------------------------------
# Sensor logs (contract section 2)
# ------------------------------------------------------------------------------------------

def gps_log(truth: Truth, times: np.ndarray, rng: np.random.Generator,
            sigma_pos: float | np.ndarray, sigma_vel: float | np.ndarray | None = None,
            offset: Sequence[float] = (0.0, 0.0, 0.0)) -> pd.DataFrame:
    """GPS rows at ``times`` (s): position with white noise ``sigma_pos`` (m; scalar, (3,) per
    ENU axis or (N, 3) per row) plus a constant range-ENU ``offset`` (m); velocity (receiver
    ENU) with noise ``sigma_vel`` (m/s; scalar or (N,)); no velocity columns when None."""
    p, v, _ = truth.at(times)
    noisy = p + np.asarray(offset, float) + rng.normal(size=p.shape) * sigma_pos
    lat, lon, h = enu2geodetic(noisy)
    log = pd.DataFrame({"time": times, "lat": lat, "lon": lon, "height": h})
    if sigma_vel is not None:
        sv = np.reshape(np.asarray(sigma_vel, float), (-1, 1))
        vel = local_velocity(v, lat, lon) + rng.normal(size=v.shape) * sv
        log[["ve", "vn", "vu"]] = vel
    return log


def site_log(truth: Truth, times: np.ndarray, site: Geo, rng: np.random.Generator,
             sigma: Mapping[str, float]) -> pd.DataFrame:
    """Radar/theodolite rows at ``times`` (s) from a fixed ``site``: the components named in
    ``sigma`` (range m, azimuth and elevation rad, range_rate m/s) with white noise of those
    1-sigmas; angles written in degrees."""
    p, v, _ = truth.at(times)
    az, el, rg = site_aer(p, site)
    true = {"range": rg, "azimuth": az, "elevation": el, "range_rate": range_rate(p, v, site)}
    log = pd.DataFrame({"time": times})
    for name in ("range", "azimuth", "elevation", "range_rate"):
        if name in sigma:
            x = true[name] + rng.normal(size=len(times)) * sigma[name]
            log[name] = np.degrees(x) % 360.0 if name == "azimuth" else (
                np.degrees(x) if name == "elevation" else x)
    return log


def mistram_log(truth: Truth, times: np.ndarray, stations: Mapping[str, Geo],
                rng: np.random.Generator, sigma: float) -> pd.DataFrame:
    """MISTRAM rows: one per station and time (s), range rate (m/s) with noise ``sigma``."""
    p, v, _ = truth.at(times)
    parts = [pd.DataFrame({"time": times, "station": sid,
                           "range_rate": range_rate(p, v, site)
                           + rng.normal(size=len(times)) * sigma})
             for sid, site in stations.items()]
    return pd.concat(parts, ignore_index=True).sort_values("time", kind="stable")


# ------------------------------------------------------------------------------------------
# Config and runs (contract section 3)
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sensor:
    """One ``[[sensors]]`` entry and its log. sigma: SI (m, rad, m/s), converted to the
    config's degrees here; site: fixed radar/theodolite; stations: MISTRAM."""

    id: str
    kind: str
    log: pd.DataFrame
    sigma: Mapping[str, float]
    site: Geo | None = None
    stations: Mapping[str, Geo] = field(default_factory=dict)

    def toml(self) -> str:
        """The sensor's ``[[sensors]]`` table (file ``<id>.csv`` next to the config)."""
        sig = {k: float(np.degrees(s)) if k in ("azimuth", "elevation") else float(s)
               for k, s in self.sigma.items()}
        lines = ["[[sensors]]", f'id = "{self.id}"', f'kind = "{self.kind}"',
                 f'file = "{self.id}.csv"', f"sigma = {toml_value(sig)}"]
        if self.site is not None:
            lines += [f"site = {toml_value(_geo_dict(self.site))}", 'angle_unit = "deg"']
        if self.stations:
            lines.append("stations = " + toml_value(
                [{"id": k, **_geo_dict(g)} for k, g in self.stations.items()]))
        return "\n".join(lines) + "\n"


def _geo_dict(g: Geo) -> dict[str, float]:
    return {"lat": g.lat, "lon": g.lon, "height": g.height}


def toml_value(x: Any) -> str:
    """A TOML literal: bool, int, float, str, list, or dict as an inline table."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, (int, float, np.floating, np.integer)):
        return repr(float(x)) if isinstance(x, (float, np.floating)) else str(int(x))
    if isinstance(x, str):
        return '"' + x.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(x, Mapping):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in x.items()) + " }"
    return "[" + ", ".join(toml_value(v) for v in x) + "]"


def write_logs(workdir: Path, sensors: Sequence[Sensor]) -> None:
    """Write every sensor's log as ``workdir/<id>.csv``."""
    workdir.mkdir(parents=True, exist_ok=True)
    for s in sensors:
        s.log.to_csv(workdir / f"{s.id}.csv", index=False, float_format="%.10g")


def initial_state(truth: Truth, time: float, rng: np.random.Generator,
                  sigma_position: float, sigma_velocity: float) -> dict[str, float]:
    """``[[targets]] initial`` at ``time`` (s): truth perturbed by draws of the stated
    1-sigmas (m, m/s per axis)."""
    p, v, _ = truth.at(np.array([time]))
    p = p + rng.normal(size=3) * sigma_position
    v = v[0] + rng.normal(size=3) * sigma_velocity
    g = geo_at(*p[0])
    return {"time": time, "lat": g.lat, "lon": g.lon, "height": g.height,
            "ve": float(v[0]), "vn": float(v[1]), "vu": float(v[2]),
            "sigma_position": sigma_position, "sigma_velocity": sigma_velocity}


def write_config(workdir: Path, name: str, sensors: Sequence[Sensor],
                 processing: Mapping[str, Any], *, rate_hz: float = 10.0,
                 initial: Mapping[str, float] | None = None) -> Path:
    """``workdir/<name>.toml`` over the logs of :func:`write_logs`; outputs in
    ``workdir/out_<name>``; ``processing``: the ``[processing]`` keys."""
    target = {"id": "T1", **({"initial": dict(initial)} if initial else {})}
    text = "\n".join([
        f"# bench/reproduction case {name}",
        "[range]", f"origin = {toml_value(_geo_dict(ORIGIN))}", "",
        "[output]", f'dir = "out_{name}"', f"rate_hz = {float(rate_hz)!r}", "",
        "[[targets]]", *(f"{k} = {toml_value(v)}" for k, v in target.items()), "",
        "[processing]", *(f"{k} = {toml_value(v)}" for k, v in processing.items()), "",
        *(s.toml() for s in sensors)])
    path = workdir / f"{name}.toml"
    path.write_text(text)
    return path


@dataclass(frozen=True)
class Case:
    """One pipeline run: ``name``, ``config`` path, ``fused`` table (fused.parquet) and the
    in-memory :class:`rangeproc.pipeline.RunOutput` (``output``)."""

    name: str
    config: Path
    fused: pd.DataFrame
    output: RunOutput


def run_case(workdir: Path, name: str, sensors: Sequence[Sensor],
             processing: Mapping[str, Any], **config_kw: Any) -> Case:
    """Write the config of one case, run the pipeline on it and load its fused track."""
    config = write_config(workdir, name, sensors, processing, **config_kw)
    out = run(config)
    return Case(name, config, pd.read_parquet(out.out_dir / "fused.parquet"), out)


def run_cases(workdir: Path, cases: Mapping[str, Mapping[str, Any]],
              sensors: Sequence[Sensor], **config_kw: Any) -> dict[str, Case]:
    """Run every case (label -> ``[processing]`` keys) whose ``filter`` rangeproc has (the
    others are left out: see :func:`describe_cases`), as configs ``c0``, ``c1``, ..."""
    return {label: run_case(workdir, f"c{i}", sensors, keys, **config_kw)
            for i, (label, keys) in enumerate(cases.items())
            if filter_available(keys.get("filter", "ekf"))}


def errors_by_case(workdir: Path, cases: Mapping[str, Mapping[str, Any]], sensor: Sensor,
                   truth: Truth, **config_kw: Any) -> tuple[dict[str, Case], dict[str, Errors]]:
    """Write one sensor's log, run every case on it and score each against ``truth``."""
    write_logs(workdir, [sensor])
    runs = run_cases(workdir, cases, [sensor], **config_kw)
    return runs, {label: track_errors(case.fused, truth) for label, case in runs.items()}


def describe_cases(cases: Mapping[str, Mapping[str, Any]]) -> str:
    """'Cases: `label`: {keys}; ...' plus which were skipped because rangeproc does not
    have their filter yet."""
    text = "Cases ([processing] keys): " + "; ".join(f"`{k}`: `{toml_value(v)}`"
                                                    for k, v in cases.items())
    missing = sorted({v["filter"] for v in cases.values()
                      if not filter_available(v.get("filter", "ekf"))})
    if missing:
        text += (f" ({', '.join(f'`{m}`' for m in missing)} skipped: not yet available, "
                 f"not in rangeproc's filter names {list(available_filters())})")
    return text


def rejected_components(case: Case, sensor_id: str, start: float = -np.inf,
                        stop: float = np.inf) -> tuple[int, int]:
    """(rejected, measured) components of a sensor's rows with start <= t - T0 < stop (s),
    from the final pass's gate (``RunOutput.residuals``)."""
    for r in case.output.residuals:
        if r.sensor_id == sensor_id:
            sel = (r.time - T0 >= start) & (r.time - T0 < stop)
            measured = np.isfinite(r.residual[sel])
            return int((r.rejected[sel] & measured).sum()), int(measured.sum())
    return 0, 0


def available_filters() -> tuple[str, ...]:
    """The ``[processing] filter`` names the installed rangeproc accepts (the list its config
    validates against: ``FILTERS`` in ``rangeproc.settings``, else ``rangeproc.config``)."""
    for module in ("rangeproc.settings", "rangeproc.config"):
        names = getattr(importlib.import_module(module), "FILTERS", None)
        if names is not None:
            return tuple(names)
    return ()


def filter_available(name: str) -> bool:
    """Whether ``[processing] filter = name`` is implemented in this rangeproc."""
    return name in available_filters()


# ------------------------------------------------------------------------------------------
# Errors against truth
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Errors:
    """Fused minus truth at the fused epochs: t (N,) s since T0; pos, vel, acc (N, 3) range
    ENU (m, m/s, m/s^2); sigma (N, 3) the fused 1-sigma position (m); n_sensors (N,)."""

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    sigma: np.ndarray
    n_sensors: np.ndarray

    def rmse(self, kind: str = "pos", start: float = -np.inf, stop: float = np.inf,
             axes: slice = slice(0, 3), mask: np.ndarray | None = None) -> float:
        """RMS of the error vector norm of ``kind`` (pos m, vel m/s, acc m/s^2) over epochs
        with start <= t <= stop (s since T0) and ``mask`` (N,) bool; ``axes`` selects ENU
        components."""
        sel = (self.t >= start) & (self.t <= stop) & (True if mask is None else mask)
        return rms(getattr(self, kind)[sel][:, axes])

    def inside_3sigma(self, mask: np.ndarray | None = None) -> float:
        """Fraction of epochs (within ``mask``) whose position error is within 3 sigma on
        every axis."""
        sel = slice(None) if mask is None else mask
        return float(np.mean(np.all(np.abs(self.pos[sel]) <= 3.0 * self.sigma[sel], axis=1)))


def track_errors(fused: pd.DataFrame, truth: Truth) -> Errors:
    """Errors of the fused track of target T1 against truth (interpolated to its epochs)."""
    f = fused[fused["target_id"] == "T1"]
    t = f["time"].to_numpy(float)
    p, v, a = truth.at(t)
    return Errors(t - T0, f[["e", "n", "u"]].to_numpy(float) - p,
                  f[["ve", "vn", "vu"]].to_numpy(float) - v,
                  f[["ae", "an", "au"]].to_numpy(float) - a,
                  f[["sigma_e", "sigma_n", "sigma_u"]].to_numpy(float),
                  f["n_sensors"].to_numpy(int))


def norm(x: np.ndarray) -> np.ndarray:
    """Row norms of (N, k)."""
    return np.linalg.norm(x, axis=1)


def rms(x: np.ndarray) -> float:
    """RMS of the row norms of error vectors x (N, k); NaN when empty."""
    return float(np.sqrt(np.mean(np.sum(x * x, axis=1)))) if len(x) else float("nan")


# ------------------------------------------------------------------------------------------
# Figures (matplotlib object API, Agg)
# ------------------------------------------------------------------------------------------

def figure(nrows: int, ncols: int = 1, *, width: float = 9.0, row_height: float = 2.8,
           sharex: bool = True) -> tuple[Figure, np.ndarray]:
    """A figure with an (nrows, ncols) array of axes (inches)."""
    fig = Figure(figsize=(width, row_height * nrows + 0.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    return fig, axes


def plot_series(ax: Axes, series: Sequence[tuple[np.ndarray, np.ndarray, str]], *,
                ylabel: str, xlabel: str = "time since start (s)", title: str = "",
                logy: bool = False, colors: Mapping[str, str] | None = None,
                **line_kw: Any) -> None:
    """One line per (t, y, label); labelled axes, grid and legend. ``colors``: label ->
    colour, so that one case keeps its colour across panels."""
    for t, y, label in series:
        color = (colors or {}).get(label)
        ax.plot(t, y, label=label, lw=1.0, **({"color": color} if color else {}), **line_kw)
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")


def case_colors(labels: Sequence[str]) -> dict[str, str]:
    """A fixed colour per case label (matplotlib's tab10 cycle, in order)."""
    return {label: f"C{i % 10}" for i, label in enumerate(labels)}


def reference_line(ax: Axes, y: float, label: str, color: str = "0.3") -> None:
    """A dashed horizontal line (e.g. a document's figure) with a legend entry."""
    ax.axhline(y, ls="--", lw=1.0, color=color, label=label)
    ax.legend(fontsize=8, loc="best")


def shade(ax: Axes, start: float, stop: float, label: str, color: str = "tab:red") -> None:
    """Shade the time window [start, stop] (s since start) with a legend entry."""
    ax.axvspan(start, stop, color=color, alpha=0.12, label=label)
    ax.legend(fontsize=8, loc="best")


def save(fig: Figure, path: Path) -> Path:
    """Write the figure as PNG (110 dpi) and return its path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def fmt(x: float, digits: int = 1) -> str:
    """A number for the table ('n/a' when not finite)."""
    return f"{x:.{digits}f}" if np.isfinite(x) else "n/a"
