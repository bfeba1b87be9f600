"""Seed 001 (strong-tracking UKF with multiple fading factors, GPS/SINS).

Document (sec. 4): a 360 s ballistic flight, GPS every 1 s; from 200 s to 210 s the
pseudoranges get extra white noise of sigma 100 m and the pseudorange rates 1 m/s; the
strong-tracking UKF keeps a much smaller position error than the standard UKF through it.

Here: the GPS is a position + velocity fix (rangeproc fuses fixes, not pseudoranges); the burst
adds white noise of sigma 100 m per position axis and 1 m/s per velocity axis to the fixes
with t in [200, 210) s, the stated sigmas stay nominal. ``filter = "ukf"`` (and the same with
``adapt_noise = false``, i.e. without the offline burst detector) against ``filter = "stukf"``
when rangeproc has it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import common as c

SEED = 2001
DURATION = 360.0                   #: s
BURST = (200.0, 210.0)             #: s since start, extra noise on the fixes in [start, stop)
SIGMA_POS = np.array([5.0, 5.0, 8.0])  #: m, nominal fix noise per ENU axis
SIGMA_VEL = 0.1                    #: m/s per axis, nominal
BURST_POS, BURST_VEL = 100.0, 1.0  #: m, m/s per axis, extra white noise in the burst
THRUST, BURN, PITCH_END = 30.0, 80.0, 45.0  #: m/s^2, s, deg: boost with a linear pitch-over

CASES = {  # label -> [processing] keys; "stukf" only when rangeproc accepts it
    "ukf": {"filter": "ukf"},
    "ukf, adapt_noise = false": {"filter": "ukf", "adapt_noise": False},
    "stukf": {"filter": "stukf"},
}


def ballistic_accel(tau: np.ndarray) -> np.ndarray:
    """Acceleration (K, 3) m/s^2 at tau (s): thrust pitching over from vertical to PITCH_END
    along east until BURN, flat-earth gravity throughout."""
    pitch = np.radians(90.0 + (PITCH_END - 90.0) * np.clip(tau / BURN, 0.0, 1.0))
    thrust = np.where(tau < BURN, THRUST, 0.0)
    return np.column_stack([thrust * np.cos(pitch), np.zeros_like(tau),
                            thrust * np.sin(pitch) - c.GRAVITY])


def scenario(rng: np.random.Generator) -> tuple[c.Truth, c.Sensor]:
    """Truth and the GPS log with the noise burst."""
    truth = c.integrate(DURATION, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ballistic_accel)
    times = c.sample_times(0.0, DURATION, 1.0)
    tau = times - c.T0
    burst = (tau >= BURST[0]) & (tau < BURST[1])
    sig_p = np.tile(SIGMA_POS, (len(times), 1))
    sig_p[burst] = np.hypot(sig_p[burst], BURST_POS)
    sig_v = np.where(burst, np.hypot(SIGMA_VEL, BURST_VEL), SIGMA_VEL)
    log = c.gps_log(truth, times, rng, sig_p, sig_v)
    sigma = {"horizontal": SIGMA_POS[0], "vertical": SIGMA_POS[2], "velocity": SIGMA_VEL}
    return truth, c.Sensor("G1", "gps", log, sigma)


def plot(errs: dict[str, c.Errors], raw: tuple[np.ndarray, np.ndarray], path: Path) -> Path:
    """Position error over the flight, and position and velocity errors around the burst."""
    fig, ax = c.figure(3, sharex=False)
    colors = {**c.case_colors(list(errs)), "raw fixes": "0.65"}
    zoom = (BURST[0] - 20.0, BURST[1] + 20.0)
    c.plot_series(ax[0, 0], [(e.t, c.norm(e.pos), k) for k, e in errs.items()],
                  ylabel="3-D position error (m)", logy=True, colors=colors,
                  title="Seed 001: ballistic flight, GPS fixes, noise burst 200-210 s")
    for a in ax[:, 0]:
        c.shade(a, *BURST, "burst: +100 m / +1 m/s white noise")
    near = (raw[0] >= zoom[0]) & (raw[0] <= zoom[1])
    c.plot_series(ax[1, 0], [(raw[0][near], raw[1][near], "raw fixes")],
                  ylabel="3-D position error (m)", colors=colors, marker=".", ms=4)
    c.plot_series(ax[1, 0], [(e.t, c.norm(e.pos), k) for k, e in errs.items()],
                  ylabel="3-D position error (m)", logy=True, colors=colors)
    c.plot_series(ax[2, 0], [(e.t, c.norm(e.vel), k) for k, e in errs.items()],
                  ylabel="3-D velocity error (m/s)", logy=True, colors=colors)
    for a in ax[1:, 0]:
        a.set_xlim(*zoom)
    return c.save(fig, path)


def run(workdir: Path, figdir: Path | None = None) -> tuple[dict[str, str], list[Path]]:
    """Run the experiment in ``workdir``; figures to ``figdir`` (default workdir)."""
    rng = np.random.default_rng(SEED)
    truth, gps = scenario(rng)
    runs, errs = c.errors_by_case(workdir, CASES, gps, truth)
    rej, meas = c.rejected_components(runs["ukf"], "G1", *BURST)
    t_raw = gps.log["time"].to_numpy(float)
    raw = (t_raw - c.T0, c.norm(c.log_enu(gps.log) - truth.at(t_raw)[0]))
    png = plot(errs, raw, (figdir or workdir) / "seed001_error.png")
    in_burst = (raw[0] >= BURST[0]) & (raw[0] < BURST[1])
    raw_in = float(np.sqrt(np.mean(raw[1][in_burst] ** 2)))
    inside = {k: e.rmse("pos", BURST[0], BURST[1]) for k, e in errs.items()}
    outside = {k: e.rmse("pos", mask=(e.t < BURST[0]) | (e.t > BURST[1]))
               for k, e in errs.items()}
    ours = "; ".join(f"{k}: {c.fmt(inside[k])} m in / {c.fmt(outside[k], 2)} m out"
                     for k in errs)
    have_st = "stukf" in errs
    gate = (f"rangeproc's standard ukf is barely hurt by the burst: its chi-square gate "
            f"rejects {rej} of the {meas} burst fix components (mostly positions)")
    holds = (f"not testable yet: `stukf` is not yet available in rangeproc; {gate}"
             if not have_st else
             "yes" if inside["stukf"] < 0.5 * inside["ukf"] else
             f"no (nothing left to fix): stukf {c.fmt(inside['stukf'])} m vs ukf "
             f"{c.fmt(inside['ukf'])} m inside the burst; {gate}")
    row = {
        "experiment": "001 strong-tracking UKF",
        "claim": "through a 200-210 s burst (sigma 100 m / 1 m/s) the strong-tracking UKF "
                 "keeps a much smaller position error than the standard UKF",
        "ours": f"position RMSE inside / outside the burst: raw fixes {c.fmt(raw_in)} m in; "
                + ours,
        "holds": holds,
        "adds": "the smoother spans the burst from both sides and the offline burst "
                "detector down-weights the noisy fixes: "
                f"ukf {c.fmt(inside['ukf'])} m vs {c.fmt(inside['ukf, adapt_noise = false'])}"
                " m without it, against the raw fixes' " + c.fmt(raw_in) + " m",
        "details": (
            f"Truth: {DURATION:.0f} s ballistic flight from the range origin, thrust "
            f"{THRUST:.0f} m/s^2 pitching over from vertical to {PITCH_END:.0f} deg (east) "
            f"until {BURN:.0f} s, then flat-earth gravity (apogee ~155 km). One GPS-kind "
            f"sensor, 1 Hz, position sigma {SIGMA_POS.tolist()} m (E, N, U), velocity "
            f"{SIGMA_VEL} m/s per axis, stated as such; fixes with t in [{BURST[0]:.0f}, "
            f"{BURST[1]:.0f}) s get extra white noise sigma {BURST_POS:.0f} m per axis and "
            f"{BURST_VEL:.0f} m/s per axis (not stated). The document fuses pseudoranges in "
            "a tight GPS/SINS coupling; rangeproc fuses fixes, so its burst is on the fix "
            "(position and velocity). " + c.describe_cases(CASES)
            + f". Output at 10 Hz; 'in' = epochs with {BURST[0]:.0f} <= t <= "
              f"{BURST[1]:.0f} s."),
    }
    return row, [png]
