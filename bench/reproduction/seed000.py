"""Seed 000 (self-adaptive spline filter, trajectory from MISTRAM range rates alone).

Document (sec. 3): the flight over [0, 20] s and [20, 40] s is one cubic polynomial per
segment; 8 range-rate stations with sigma 0.3 m/s; the innovation chi-square chi2_M(k) (M = 8
degrees of freedom) flags the knot at 20 s, the state equation is re-estimated there and the
filter re-converges (figures only, no numbers).

Here: the same two-segment cubic (position and velocity continuous at the knot; acceleration
and jerk change there), 8 stations at 10 Hz, MISTRAM alone started from a given
``[[targets]] initial`` state; ``filter = "ekf"`` and ``filter = "spline"`` when rangeproc has
it. The per-epoch chi-square is the sum of the per-row NIS of the final filter pass over the
stations of one epoch (``RunOutput.residuals[...].nis``: in memory only, the written outputs
hold no per-row NIS).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.stats import chi2

from . import common as c

SEED = 2000
KNOT, DURATION = 20.0, 40.0          #: s
SIGMA_RR = 0.3                       #: m/s, range-rate noise (stated as such)
RATE = 10.0                          #: Hz, MISTRAM sample rate
N_STATIONS = 8
P0, V0 = (-5e3, -8e3, 6e3), (250.0, 350.0, 120.0)        #: m, m/s
A0 = np.array([2.0, -1.0, 5.0])                          #: m/s^2 at t = 0
JERK = (np.array([0.3, 0.2, -0.4]), np.array([-1.5, 1.0, 1.2]))   #: m/s^3 per segment
A_JUMP = np.array([-6.0, 4.0, -5.0])                     #: m/s^2, acceleration step at KNOT
INITIAL_SIGMA = (10.0, 1.0)          #: m, m/s: the given initial state's error (drawn, stated)
ALPHA = 0.01                         #: significance of the chi-square flag
CASES = {"ekf": {"filter": "ekf"}, "spline": {"filter": "spline"}}
#: the document's constant-Q form: ekf with q held at the median of the ekf run's local q
CONSTANT_Q = "ekf, constant q"


def accel(tau: np.ndarray) -> np.ndarray:
    """Acceleration (K, 3) m/s^2 of the two cubic segments at tau (s)."""
    first = A0 + np.outer(tau, JERK[0])
    a_knot = A0 + KNOT * JERK[0] + A_JUMP
    second = a_knot + np.outer(tau - KNOT, JERK[1])
    return np.where((tau < KNOT)[:, None], first, second)


def stations(rng: np.random.Generator) -> dict[str, c.Geo]:
    """N_STATIONS ground stations 10-50 km from the flight's middle, in random directions."""
    mid = np.asarray(P0) + 0.5 * DURATION * np.asarray(V0)
    out = {}
    for k in range(N_STATIONS):
        r, az = rng.uniform(10e3, 50e3), rng.uniform(0.0, 2 * np.pi)
        out[f"M{k + 1}"] = c.geo_at(mid[0] + r * np.sin(az), mid[1] + r * np.cos(az),
                                    rng.uniform(-50.0, 300.0))
    return out


def scenario(rng: np.random.Generator) -> tuple[c.Truth, c.Sensor, dict[str, float]]:
    """Truth, the MISTRAM log and the given initial state."""
    truth = c.integrate(DURATION, P0, V0, accel)
    sites = stations(rng)
    log = c.mistram_log(truth, c.sample_times(0.0, DURATION, RATE), sites, rng, SIGMA_RR)
    init = c.initial_state(truth, c.T0, rng, *INITIAL_SIGMA)
    return truth, c.Sensor("MISTRAM", "mistram", log, {"range_rate": SIGMA_RR},
                           stations=sites), init


def epoch_chi2(case: c.Case) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per MISTRAM epoch: time since start (s), summed row NIS and the number of rows summed
    (the degrees of freedom), from the final filter pass."""
    r = next(r for r in case.output.residuals if r.sensor_id == "MISTRAM")
    ok = np.isfinite(r.nis)
    t, inv = np.unique(np.round(r.time[ok] - c.T0, 6), return_inverse=True)
    return t, np.bincount(inv, r.nis[ok]), np.bincount(inv)


def plot(errs: dict[str, c.Errors], nis: dict[str, tuple], path: Path) -> Path:
    """Position and velocity error, and the per-epoch chi-square with its 1 - ALPHA bound."""
    fig, ax = c.figure(3)
    colors = c.case_colors(list(errs))
    c.plot_series(ax[0, 0], [(e.t, c.norm(e.pos), k) for k, e in errs.items()],
                  ylabel="3-D position error (m)", colors=colors,
                  title="Seed 000: MISTRAM range rates only (8 stations, σ 0.3 m/s), knot at "
                        "20 s")
    c.plot_series(ax[1, 0], [(e.t, c.norm(e.vel), k) for k, e in errs.items()],
                  ylabel="3-D velocity error (m/s)", colors=colors)
    c.plot_series(ax[2, 0], [(t, x, f"{k}: χ² per epoch") for k, (t, x, _) in nis.items()],
                  ylabel="epoch χ² (sum of row NIS)", logy=True,
                  colors={f"{k}: χ² per epoch": colors[k] for k in nis})
    dof = max(int(np.max(d)) for _, _, d in nis.values())
    c.reference_line(ax[2, 0], chi2.ppf(1 - ALPHA, dof), f"χ²({dof}) {1 - ALPHA:.0%} quantile")
    for a in ax[:, 0]:
        a.axvline(KNOT, color="tab:red", lw=1.0, ls=":", label="knot (20 s)")
        a.legend(fontsize=8, loc="best")
    return c.save(fig, path)


def flags(t: np.ndarray, x: np.ndarray, dof: np.ndarray) -> tuple[int, int, float]:
    """Epochs flagged (chi-square above its 1 - ALPHA quantile) within 1 s of the knot, and
    elsewhere, and the time (s) of the largest epoch chi-square."""
    flagged = x > chi2.ppf(1 - ALPHA, np.maximum(dof, 1))
    near = np.abs(t - KNOT) <= 1.0
    return int((flagged & near).sum()), int((flagged & ~near).sum()), float(t[np.argmax(x)])


def run(workdir: Path, figdir: Path | None = None) -> tuple[dict[str, str], list[Path]]:
    """Run the experiment in ``workdir``; figures to ``figdir`` (default workdir)."""
    rng = np.random.default_rng(SEED)
    truth, mistram, init = scenario(rng)
    c.write_logs(workdir, [mistram])
    runs = c.run_cases(workdir, CASES, [mistram], initial=init)
    q = runs["ekf"].output.summary["targets"]["T1"]["process_noise_q"]["median"]
    runs[CONSTANT_Q] = c.run_case(workdir, "constant_q", [mistram],
                                  {"filter": "ekf", "process_noise": q}, initial=init)
    errs = {k: c.track_errors(r.fused, truth) for k, r in runs.items()}
    nis = {k: epoch_chi2(r) for k, r in runs.items()}
    png = plot(errs, nis, (figdir or workdir) / "seed000_error_chi2.png")
    flag = {k: flags(*v) for k, v in nis.items()}
    ours = "; ".join(
        f"{k}: pos RMSE {c.fmt(e.rmse('pos'), 2)} m, vel {c.fmt(e.rmse('vel'), 3)} m/s, "
        f"{100 * e.inside_3sigma():.0f} % in 3σ, χ² flags {flag[k][0]} epoch(s) within 1 s "
        f"of the knot and {flag[k][1]} elsewhere (max at {flag[k][2]:.1f} s)"
        for k, e in errs.items())
    seen = {k: f[0] >= 2 and abs(f[2] - KNOT) <= 1.0 for k, f in flag.items()}
    row = {
        "experiment": "000 adaptive spline filter (MISTRAM only)",
        "claim": "with 8 range-rate stations (σ 0.3 m/s) the χ² curve flags the knot at 20 s "
                 "and the filter re-converges",
        "ours": ours + ("" if "spline" in runs else "; spline: not yet available"),
        "holds": "χ² flags the knot (>= 2 epochs within 1 s, largest χ² there): "
                 + ", ".join(f"{k} {'yes' if v else 'no'}" for k, v in seen.items())
                 + f". With the default local q the offline filter absorbs the knot; with q "
                   f"held constant ({c.fmt(q, 2)} m²/s⁵, the default run's median) it is "
                   "flagged as in the document. No divergence to re-converge from: the "
                   "error stays at its level after 20 s",
        "adds": "the smoother uses the whole flight on both sides of the knot; the "
                "refinement passes re-linearise the range rates at the smoothed track and "
                "raise the process noise locally around the knot (local EM)",
        "details": (
            f"Truth: two cubic segments [0, {KNOT:.0f}] and [{KNOT:.0f}, {DURATION:.0f}] s "
            f"from {P0} m at {V0} m/s, acceleration {A0.tolist()} m/s² at 0 s, jerk "
            f"{JERK[0].tolist()} then {JERK[1].tolist()} m/s³, an acceleration step of "
            f"{A_JUMP.tolist()} m/s² at the knot (position and velocity continuous). "
            f"{N_STATIONS} MISTRAM stations 10-50 km away, {RATE:.0f} Hz, σ {SIGMA_RR} m/s "
            "(stated). `[[targets]] initial` = truth at 0 s plus draws of σ "
            f"{INITIAL_SIGMA[0]:.0f} m / {INITIAL_SIGMA[1]:.0f} m/s per axis, stated as "
            "sigma_position / sigma_velocity. " + c.describe_cases(CASES)
            + f"; `{CONSTANT_Q}`: ekf with process_noise = {c.fmt(q, 3)} m²/s⁵, the median "
              "of the ekf run's locally estimated q, held constant like the document's Q"
            + f". χ² flag: epoch sum of row NIS above the χ²(dof) {1 - ALPHA:.0%} quantile. "
              "Per-row NIS is not in fused.parquet or summary.json; it is taken from the "
              "in-memory RunOutput (the report's consistency.png shows a windowed form)."),
    }
    return row, [png]
