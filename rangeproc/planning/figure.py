"""The figure of ``rangeproc plan``: predicted sigma over the flight and who carries it."""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rangeproc.report.common import (
    CYCLE,
    REJECT_COLOR,
    STYLE,
    log_axis,
    new_figure,
    save_figure,
)
from rangeproc.report.timeline import used_spans


#: A sensor's coverage bar is broken where its epochs are further apart than this many times
#: their median spacing (and at least 1.5 output intervals).
GAP_STEPS = 3.0


def plan_figure(table: pd.DataFrame, summary: dict, path: Path) -> Path:
    """``plan.png``: the predicted 1-sigma position (m) and velocity (m/s) per axis against
    time from the plan's start (s, log scale), solid with the calibration's uncertainty and
    dotted with every calibration term known, and below them each sensor's coverage (a bar
    where it has rows), weak geometry marked in red."""
    with matplotlib.rc_context(STYLE):
        return save_figure(draw_plan(table, summary), path)


def coverage_spans(t: np.ndarray, have: np.ndarray) -> list[tuple[float, float]]:
    """(start, width) in s of the bars of one sensor's row: its epochs ``t[have]`` merged
    where consecutive ones are at most :data:`GAP_STEPS` median spacings apart (and 1.5
    output intervals), each bar at least one output interval wide, so that a sensor slower
    than the output rate (a 1 Hz GPS on a 10 Hz grid: every tenth epoch) is a bar, not a
    row of invisible points."""
    tt = t[have]
    if tt.size == 0:
        return []
    grid = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    own = float(np.median(np.diff(tt))) if tt.size > 1 else grid
    start, end = used_spans(tt, gap=max(GAP_STEPS * own, 1.5 * grid))
    return [(float(a), float(max(b - a, grid))) for a, b in zip(start, end)]


def draw_plan(table: pd.DataFrame, summary: dict) -> Figure:
    """The figure of :func:`plan_figure` (not saved)."""
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
        ax_s.broken_barh(coverage_spans(t, have), (row - 0.22, 0.44),
                         facecolors=CYCLE[row % len(CYCLE)], gid=f"rows {sid}")
        bad = np.array([w.startswith(sid + " ") or f"; {sid} " in w for w in weak])
        if bad.any():
            ax_s.broken_barh(coverage_spans(t, bad), (row - 0.22, 0.44),
                             facecolors=REJECT_COLOR, gid=f"weak {sid}")
    ax_s.set_yticks(range(len(ids)), ids)
    ax_s.set_ylim(-0.7, len(ids) - 0.3)
    ax_s.invert_yaxis()
    ax_s.set_xlabel("time from the plan's start (s)")
    ax_s.set_title("sensors with rows (red: weak geometry)", fontsize=9)
    fig.tight_layout()
    return fig
