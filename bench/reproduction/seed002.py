"""Seed 002 (improved Sage-Husa adaptive KF, airborne electro-optical target location).

Document (sec. 5): a target moving north at constant speed from 43.8815 N, position and
velocity observed every 1 s with noise variances 6400 m^2 and 0.04 m^2/s^2; the raw
positions are about 250 m off; the standard KF keeps about 150 m of error, the improved
Sage-Husa filter gets under 50 m after about 150 s (first 400 s analysed).

Here: GPS-kind rows (position + velocity) with those noises and a constant 250 m horizontal
offset in every position fix; ``filter = "ekf"`` with the document's sigmas stated, against
``filter = "sage-husa"`` with and without ``sage_husa_mean`` (noise-mean estimation).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import common as c

SEED = 2002
DURATION = 400.0           #: s, the document's analysed span
SPEED = 10.0               #: m/s northward (the document gives no speed)
SIGMA_POS = 80.0           #: m per axis (variance 6400 m^2)
SIGMA_VEL = 0.2            #: m/s per axis (variance 0.04 m^2/s^2)
OFFSET = (150.0, 200.0, 0.0)  #: m, constant error of every position fix (|offset| = 250 m)
SETTLED = 150.0            #: s, after which the document's adaptive filter is under 50 m

CASES = {  # label -> [processing] keys
    "ekf (standard KF)": {"filter": "ekf"},
    "sage-husa": {"filter": "sage-husa"},
    "sage-husa + mean": {"filter": "sage-husa", "sage_husa_mean": True},
}


def scenario(rng: np.random.Generator) -> tuple[c.Truth, c.Sensor]:
    """Truth (ground target, constant speed north) and its biased GPS-kind log."""
    truth = c.integrate(DURATION, (0.0, 0.0, 0.0), (0.0, SPEED, 0.0),
                        lambda tau: np.zeros((len(tau), 3)))
    times = c.sample_times(0.0, DURATION, 1.0)
    log = c.gps_log(truth, times, rng, SIGMA_POS, SIGMA_VEL, offset=OFFSET)
    sigma = {"horizontal": SIGMA_POS, "vertical": SIGMA_POS, "velocity": SIGMA_VEL}
    return truth, c.Sensor("G1", "gps", log, sigma)


def raw_errors(sensor: c.Sensor, truth: c.Truth) -> tuple[np.ndarray, np.ndarray]:
    """Time since start (s) and horizontal error (m) of the raw position fixes."""
    t = sensor.log["time"].to_numpy(float)
    p, _, _ = truth.at(t)
    d = c.log_enu(sensor.log) - p
    return t - c.T0, np.hypot(d[:, 0], d[:, 1])


def plot(errs: dict[str, c.Errors], raw: tuple[np.ndarray, np.ndarray], path: Path) -> Path:
    """Horizontal error vs time (raw, filters, document figures) and the error left after
    removing the constant offset (what is observable)."""
    fig, ax = c.figure(2)
    off = np.asarray(OFFSET)[:2]
    colors = {**c.case_colors(list(errs)), "raw fixes": "0.65"}
    c.plot_series(ax[0, 0], [(raw[0], raw[1], "raw fixes")]
                  + [(e.t, c.norm(np.c_[e.pos[:, :2], np.zeros(len(e.t))]), k)
                     for k, e in errs.items()],
                  ylabel="horizontal position error (m)", colors=colors,
                  title="Seed 002: error against truth (fixes carry a constant 250 m offset)")
    c.reference_line(ax[0, 0], 150.0, "document: standard KF ~150 m", "tab:gray")
    c.reference_line(ax[0, 0], 50.0, "document: adaptive KF < 50 m after 150 s", "k")
    c.plot_series(ax[1, 0], [
        (e.t, np.hypot(*(e.pos[:, :2] - off).T), k) for k, e in errs.items()],
        ylabel="|error - offset| (m)", logy=True, colors=colors,
        title="error relative to truth + offset (the random part the data can remove)")
    return c.save(fig, path)


def run(workdir: Path, figdir: Path | None = None) -> tuple[dict[str, str], list[Path]]:
    """Run the experiment in ``workdir``; figures to ``figdir`` (default workdir)."""
    rng = np.random.default_rng(SEED)
    truth, gps = scenario(rng)
    errs = c.errors_by_case(workdir, CASES, gps, truth, rate_hz=1.0)[1]
    raw = raw_errors(gps, truth)
    png = plot(errs, raw, (figdir or workdir) / "seed002_error.png")
    late = {k: e.rmse("pos", SETTLED, axes=slice(0, 2)) for k, e in errs.items()}
    rand = {k: c.rms(e.pos[:, :2] - np.asarray(OFFSET)[:2]) for k, e in errs.items()}
    raw_late = float(np.sqrt(np.mean(raw[1][raw[0] >= SETTLED] ** 2)))
    best = min(late.values())
    drift = c.norm(np.mean(errs["sage-husa + mean"].vel, axis=0)[None])[0]
    ours = "; ".join(f"{k} {c.fmt(v)} m" for k, v in late.items())
    row = {
        "experiment": "002 Sage-Husa adaptive KF",
        "claim": "raw fixes ~250 m off; standard KF ~150 m error; improved Sage-Husa < 50 m "
                 "after ~150 s",
        "ours": f"horizontal RMSE after 150 s: raw {c.fmt(raw_late)} m; {ours}",
        "holds": ("yes" if best < 50.0 else
                  "no: a constant offset in every position fix, with no other position "
                  "reference, is unobservable; every filter (and any filter) follows it. "
                  "Estimating the noise mean (sage_husa_mean) makes it worse: the track "
                  f"drifts with a {c.fmt(drift, 2)} m/s mean velocity error"),
        "adds": "removes the random part: |error - offset| RMSE "
                + ", ".join(f"{k} {c.fmt(v)} m" for k, v in rand.items())
                + f" (fix noise {SIGMA_POS:.0f} m per axis)",
        "details": (
            f"Truth: ground target at {SPEED:.0f} m/s north from {c.ORIGIN.lat} N for "
            f"{DURATION:.0f} s. One GPS-kind sensor, 1 Hz, position and velocity, noise "
            f"sigma {SIGMA_POS:.0f} m per axis and {SIGMA_VEL} m/s per axis, every position "
            f"fix offset by {OFFSET} m (E, N, U; |offset| 250 m). Config: sigma = "
            f"{{ horizontal = {SIGMA_POS}, vertical = {SIGMA_POS}, velocity = {SIGMA_VEL} }} "
            "(the document's noise, stated), rate_hz = 1, default [processing] apart from "
            "filter (adapt_noise = true, q estimated, 2 refinement passes). "
            + c.describe_cases(CASES)
            + ". The velocity fixes are unbiased and integrate to the displacement only: "
            "they cannot locate the start, so the offset is unobservable; the document's "
            "noise-mean estimate can only remove it if the filter starts from a known true "
            "position, which is information not in the measurements (the document's KF "
            "ending ~150 m off a ~250 m offset suggests its filters were started near the "
            "truth). With `sage_husa_mean = true` the windowed innovation mean includes the "
            "start-up transient and the filter's own lag; subtracting it biases the velocity "
            "and the track drifts."),
    }
    return row, [png]
