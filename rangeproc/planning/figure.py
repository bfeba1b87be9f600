"""The figure of ``rangeproc plan``: predicted sigma over the flight and who carries it."""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd

from rangeproc.report.common import (
    CYCLE,
    REJECT_COLOR,
    STYLE,
    log_axis,
    new_figure,
    save_figure,
    true_runs,
)


def plan_figure(table: pd.DataFrame, summary: dict, path: Path) -> Path:
    """``plan.png``: the predicted 1-sigma position (m) and velocity (m/s) per axis against
    time from the plan's start (s, log scale), solid with the calibration's uncertainty and
    dotted with every calibration term known, and below them each sensor's coverage (a bar
    where it has rows), weak geometry marked in red."""
    with matplotlib.rc_context(STYLE):
        return _draw(table, summary, path)


def _draw(table: pd.DataFrame, summary: dict, path: Path) -> Path:
    t = table["time"].to_numpy() - float(table["time"].iloc[0])
    ids = list(summary["sensors"])
    fig = new_figure(9.0, 7.5)
    ax_p, ax_v, ax_s = fig.subplots(3, 1, sharex=True,
                                    gridspec_kw={"height_ratios": [3, 2, 0.4 + 0.35 * len(ids)]})
    for i, ax in enumerate("enu"):
        for part, name, style in (("", "", "-"), ("_calibrated", ", calibration known", ":")):
            if f"sigma_{ax}{part}" not in table:
                continue
            ax_p.plot(t, table[f"sigma_{ax}{part}"], color=CYCLE[i], lw=1.2, ls=style,
                      label=f"σ {ax.upper()}{name}")
            ax_v.plot(t, table[f"sigma_v{ax}{part}"], color=CYCLE[i], lw=1.2, ls=style,
                      label=f"σ v{ax}{name}")
    for ax in (ax_p, ax_v):
        log_axis(ax)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=3)
    ax_p.set_ylabel("predicted 1σ position (m)")
    ax_v.set_ylabel("predicted 1σ velocity (m/s)")
    ax_p.set_title("Achievable accuracy of the planned flight (rangeproc plan)")
    sensors = table["sensors"].to_numpy()
    weak = table["weak"].to_numpy()
    for row, sid in enumerate(ids):
        have = np.array([sid in s.split(",") for s in sensors])
        starts, stops = true_runs(have)
        for a, b in zip(starts, stops):
            ax_s.plot([t[a], t[b - 1]], [row, row], color=CYCLE[row % len(CYCLE)], lw=6,
                      solid_capstyle="butt")
        bad = np.array([w.startswith(sid + " ") or f"; {sid} " in w for w in weak])
        starts, stops = true_runs(bad)
        for a, b in zip(starts, stops):
            ax_s.plot([t[a], t[b - 1]], [row, row], color=REJECT_COLOR, lw=6,
                      solid_capstyle="butt")
    ax_s.set_yticks(range(len(ids)), ids)
    ax_s.set_ylim(-0.7, len(ids) - 0.3)
    ax_s.invert_yaxis()
    ax_s.set_xlabel("time from the plan's start (s)")
    ax_s.set_title("sensors with rows (red: weak geometry)", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)
