"""``consistency.png``: per sensor, windowed mean NIS vs time against its chi-square 95 % band,
and the histogram of normalised residuals (residual / sigma) against N(0, 1).

The NIS of a row has as many degrees of freedom as the row has measured (non-NaN) components.
Used rows are cut into consecutive windows of W rows; the window's NIS sum is chi-square with
D = sum of the rows' dof, so its mean per row lies in [chi2.ppf(0.025, D), chi2.ppf(0.975, D)] / W
with 95 % probability when the noise model is right.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from scipy import stats

from rangeproc.report.common import CYCLE, KIND_COLORS, SensorView, new_figure, t0_note, time_label

#: Windows per sensor aimed at (window length W = rows / this, clipped to the limits below).
TARGET_WINDOWS = 400
MIN_WINDOW, MAX_WINDOW = 10, 2_000
#: Histogram range of normalised residuals (in sigma) and bin count.
Z_MAX, Z_BINS = 5.0, 50


def window_nis(time: np.ndarray, nis: np.ndarray, dof: np.ndarray,
               window: int) -> tuple[np.ndarray, ...]:
    """Mean NIS over consecutive windows of ``window`` rows and its chi-square 95 % band.

    time, nis, dof: (N,) of the rows to use (finite nis, dof > 0), time-ordered.
    Returns (t_mid (B,), mean_nis (B,), expected (B,) = mean dof, lo (B,), hi (B,)).
    The last window takes the remainder rows (fewer than ``2 * window``).
    """
    n = time.size
    if n == 0:
        e = np.zeros(0)
        return e, e, e, e, e
    nb = max(n // window, 1)
    starts = np.arange(nb) * window
    counts = np.diff(np.append(starts, n)).astype(float)
    s_nis = np.add.reduceat(nis, starts)
    s_dof = np.add.reduceat(dof.astype(float), starts)
    t_mid = 0.5 * (time[starts] + time[np.append(starts[1:], n) - 1])
    lo = stats.chi2.ppf(0.025, s_dof) / counts
    hi = stats.chi2.ppf(0.975, s_dof) / counts
    return t_mid, s_nis / counts, s_dof / counts, lo, hi


def plot_consistency(views: Sequence[SensorView], t0: float) -> Figure:
    """Draw the consistency figure: one row per sensor (times relative to t0, s)."""
    nrow = max(len(views), 1)
    fig = new_figure(14.0, max(3.8, 1.3 + 1.75 * nrow))
    gs = fig.add_gridspec(nrow, 2, width_ratios=(3.2, 1.0), left=0.07, right=0.985,
                          top=1.0 - 0.85 / fig.get_figheight(),
                          bottom=0.6 / fig.get_figheight(), wspace=0.14, hspace=0.3)
    fig.suptitle("Consistency: windowed mean NIS vs chi-square 95 % band, and normalised "
                 "residuals vs N(0,1)  (used rows only)", fontsize=12, fontweight="bold",
                 y=1.0 - 0.12 / fig.get_figheight(), va="top")
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")
    ax_t0: Axes | None = None
    for i, v in enumerate(views):
        ax_t = fig.add_subplot(gs[i, 0], sharex=ax_t0)
        ax_t0 = ax_t0 or ax_t
        ax_h = fig.add_subplot(gs[i, 1])
        _nis_panel(ax_t, v, t0)
        _hist_panel(ax_h, v)
        if i < len(views) - 1:
            ax_t.tick_params(labelbottom=False)
            ax_h.tick_params(labelbottom=False)
        else:
            ax_t.set_xlabel(time_label(t0))
            ax_h.set_xlabel("residual / σ")
    if not views:
        ax = fig.add_subplot(gs[0, :])
        ax.text(0.5, 0.5, "no sensor residuals", transform=ax.transAxes, ha="center",
                va="center", fontsize=12, color="0.4")
        ax.set_axis_off()
    return fig


def _nis_panel(ax: Axes, v: SensorView, t0: float) -> None:
    dof = np.isfinite(v.residual).sum(axis=1)
    ok = ~v.rejected & np.isfinite(v.nis) & (dof > 0) & np.isfinite(v.time)
    color = KIND_COLORS.get(v.kind, CYCLE[0])
    ax.set_ylabel(f"{v.sensor_id}\nmean NIS", fontsize=8.5)
    n = int(ok.sum())
    if n == 0:
        ax.text(0.5, 0.5, f"{v.sensor_id}: no NIS values", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
        ax.set_yticks([])
        return
    w = int(np.clip(n // TARGET_WINDOWS, MIN_WINDOW, MAX_WINDOW))
    t_mid, mean, expect, lo, hi = window_nis(v.time[ok], v.nis[ok], dof[ok], w)
    x = t_mid - t0
    ax.fill_between(x, lo, hi, color="0.8", lw=0, step="mid", label="95 % band")
    ax.step(x, expect, where="mid", color="0.35", lw=0.8, ls="--", label="expected (= dof)")
    outside = (mean < lo) | (mean > hi)
    ax.plot(x, mean, "-", color=color, lw=1.0, marker="." if x.size < 60 else None, ms=4,
            label=f"mean NIS, window {w} rows")
    ax.plot(x[outside], mean[outside], ls="none", marker="o", ms=2.5, color="#d62728",
            label="outside band")
    pos = np.concatenate([mean[mean > 0], lo[lo > 0], hi])
    if pos.size and np.isfinite(pos).any():
        ax.set_yscale("log")
        ymin = float(np.nanmin(pos)) / 1.6
        ymax = float(np.nanmax(pos)) * 1.6
        ax.set_ylim(ymin, ymax)
    anees = float(v.nis[ok].sum() / dof[ok].sum())
    frac = 100.0 * float(outside.mean())
    ax.text(0.005, 0.95, f"{v.sensor_id} ({v.kind})   NIS/dof overall {anees:.3g}   "
            f"{frac:.0f} % of {x.size} windows outside band", transform=ax.transAxes,
            ha="left", va="top", fontsize=8,
            bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.7", alpha=0.85))
    ax.legend(loc="upper right", fontsize=7, ncol=4, framealpha=0.85)


def _hist_panel(ax: Axes, v: SensorView) -> None:
    edges = np.linspace(-Z_MAX, Z_MAX, Z_BINS + 1)
    width = edges[1] - edges[0]
    used_comp = v.used_comp
    zz = np.linspace(-Z_MAX, Z_MAX, 201)
    ax.plot(zz, stats.norm.pdf(zz), color="k", lw=1.2, ls="--", label="N(0,1)")
    any_drawn = False
    for j, comp in enumerate(v.components):
        with np.errstate(divide="ignore", invalid="ignore"):
            z = v.residual[used_comp[:, j], j] / v.sigma[used_comp[:, j], j]
        z = z[np.isfinite(z)]
        if z.size == 0:
            continue
        counts, _ = np.histogram(z, bins=edges)
        dens = counts / (z.size * width)
        rms = float(np.sqrt(np.mean(z**2)))
        ax.stairs(dens, edges, color=CYCLE[j % len(CYCLE)], lw=1.1, label=f"{comp} rms {rms:.2f}")
        any_drawn = True
    ax.set_xlim(-Z_MAX, Z_MAX)
    ax.set_yticks([])
    if any_drawn:
        ax.legend(loc="upper left", fontsize=6.5, handlelength=1.2, framealpha=0.8,
                  borderaxespad=0.2)
    else:
        ax.text(0.5, 0.5, "no used residuals", transform=ax.transAxes, ha="center",
                va="center", color="0.4")
