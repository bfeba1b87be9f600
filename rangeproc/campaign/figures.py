"""Per-sensor PNG figures across a campaign's sorties: noise, biases, latency, mount angles.

One figure per sensor (``sensor_<id>.png`` in the campaign's records folder): a panel per
noise component (estimated 1-sigma per sortie, the a-priori value dashed) and a panel per
calibration term (estimate with its 1-sigma bar per sortie; a term that moved beyond
``summary.MOVE_SIGMAS`` combined sigmas since the previous sortie in red, unobservable
sorties left empty). Angles are shown in mrad, latency in ms. Drawn with the report's
plumbing (``report.common``: Agg canvas, atomic palette PNG).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rangeproc.campaign.summary import MOVE_SIGMAS
from rangeproc.parallel import shared_with_child
from rangeproc.report.common import (REJECT_COLOR, STYLE, display_unit, new_figure, safe_name,
                                     save_figure)

#: SI unit of a noise component or calibration term by name (metres when not listed).
SI_UNITS = {"azimuth": "rad", "elevation": "rad", "mount_roll": "rad", "mount_pitch": "rad",
            "mount_yaw": "rad", "latency": "s", "range_rate": "m/s", "ve": "m/s",
            "vn": "m/s", "vu": "m/s"}


def shown_as(name: str) -> tuple[float, str]:
    """(scale, unit) to show component or term ``name`` (``report.common.display_unit``)."""
    return display_unit(SI_UNITS.get(name, "m"))


def _names(rows: pd.DataFrame, prefix: str) -> list[str]:
    skip = ("_apriori", "_sigma", "_moved")
    return [c[len(prefix):] for c in rows.columns if c.startswith(prefix)
            and not c.endswith(skip) and rows[c].notna().any()]


#: Figure layout (inches): panel width and height, the margins around the panels and the
#: gap between panel rows (room for a panel's title). Fixed rather than ``tight_layout``,
#: which measured every text twice and was half a figure's drawing time.
PANEL_W, PANEL_H = 6.5, 2.0
TOP_IN, LEFT_IN, RIGHT_IN, ROW_GAP_IN, COL_GAP_IN = 0.75, 1.0, 0.2, 0.45, 1.05
#: Sortie labels longer than this many characters are cut (with "…") on the x axis.
MAX_LABEL_CHARS = 18


def _bottom_margin(labels: list[str], rotated: bool) -> float:
    """Inches below the bottom panels for their sortie labels (7 pt) and the axis label."""
    longest = max((len(s) for s in labels), default=1)
    text = 7.0 / 72.0 * 0.62 * longest                   # width of the longest label, inches
    return 0.55 + (text * np.sin(np.pi / 4) if rotated else 7.0 / 72.0)


def plot_sensor(rows: pd.DataFrame, sensor: str) -> Figure:
    """The figure of one sensor from its rows of ``campaign.parquet`` (campaign order).

    Panels in columns of shared sortie axes; the sortie labels are drawn under the bottom
    panel of each column only.
    """
    noise, terms = _names(rows, "noise_"), _names(rows, "cal_")
    panels = [("noise", n) for n in noise] + [("cal", t) for t in terms]
    n = max(1, len(panels))
    cols = 2 if n > 3 else 1
    nrows = int(np.ceil(n / cols))
    x = np.arange(len(rows))
    labels = [s if len(s) <= MAX_LABEL_CHARS else s[:MAX_LABEL_CHARS - 1] + "…"
              for s in rows["sortie"].astype(str)]
    rotated = len(labels) > 6
    bottom = _bottom_margin(labels, rotated)
    width = LEFT_IN + cols * PANEL_W + (cols - 1) * COL_GAP_IN + RIGHT_IN
    height = TOP_IN + nrows * PANEL_H + (nrows - 1) * ROW_GAP_IN + bottom
    fig = new_figure(width, height)
    kind = rows["kind"].iloc[0] if len(rows) else ""
    fig.suptitle(f"{sensor} ({kind}) across {len(rows)} sorties: noise and calibration",
                 fontsize=11, fontweight="bold", y=1.0 - 0.12 / height, va="top")
    if not panels:
        ax = fig.add_subplot(1, 1, 1)
        ax.text(0.5, 0.5, "no noise or calibration estimates", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
        return fig
    gs = fig.add_gridspec(nrows, cols, left=LEFT_IN / width, right=1.0 - RIGHT_IN / width,
                          top=1.0 - TOP_IN / height, bottom=bottom / height,
                          hspace=ROW_GAP_IN / PANEL_H, wspace=COL_GAP_IN / PANEL_W)
    first_in_col: dict[int, Axes] = {}
    for k, (what, name) in enumerate(panels):
        row, col = divmod(k, cols)
        ax = fig.add_subplot(gs[row, col], sharex=first_in_col.get(col))
        first_in_col.setdefault(col, ax)
        _draw_panel(ax, rows, x, what, name)
        last_in_col = k + cols >= len(panels)
        if last_in_col:
            ax.set_xticks(x)
            ax.set_xticklabels(labels, rotation=45 if rotated else 0,
                               ha="right" if rotated else "center", fontsize=7)
            ax.set_xlabel("sortie (campaign order)", fontsize=9)
        else:
            ax.tick_params(labelbottom=False)
        ax.set_xlim(-0.5, len(x) - 0.5)
    return fig


def _draw_panel(ax: Axes, rows: pd.DataFrame, x: np.ndarray, what: str, name: str) -> None:
    """One noise component (``what`` "noise") or calibration term ("cal") across sorties."""
    scale, unit = shown_as(name)
    if what == "noise":
        ax.plot(x, rows[f"noise_{name}"] * scale, "o-", color="#1f77b4", ms=4,
                label="estimated")
        if f"noise_{name}_apriori" in rows:
            ax.plot(x, rows[f"noise_{name}_apriori"] * scale, "--", color="#7f7f7f",
                    label="a priori")
        ax.set_ylabel(f"{name} 1σ [{unit}]")
        ax.set_title(f"noise: {name}", fontsize=9)
    else:
        v = rows[f"cal_{name}"].to_numpy(float) * scale
        s = rows.get(f"cal_{name}_sigma", pd.Series(np.nan, index=rows.index)
                     ).to_numpy(float) * scale
        moved = rows.get(f"cal_{name}_moved", pd.Series(False, index=rows.index)
                         ).to_numpy(bool)
        ax.axhline(0.0, color="#7f7f7f", lw=0.8)
        ax.errorbar(x[~moved], v[~moved], yerr=s[~moved], fmt="o", color="#2ca02c",
                    ms=4, capsize=3, label="estimate ± 1σ")
        if moved.any():
            ax.errorbar(x[moved], v[moved], yerr=s[moved], fmt="o", color=REJECT_COLOR,
                        ms=5, capsize=3,
                        label=f"moved > {MOVE_SIGMAS:g}σ since previous sortie")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.set_title(f"calibration: {name}", fontsize=9)
    ax.legend(fontsize=7, loc="best")


def write_sensor_figures(table: pd.DataFrame, folder: Path) -> list[Path]:
    """``sensor_<id>.png`` per sensor of ``table`` with any noise or calibration estimate
    into ``folder``; returns the paths. Drawn by this process and a forked child side by side
    (``rangeproc.parallel.shared_with_child``), as a run's report."""
    jobs = [(rows.reset_index(drop=True), str(sensor),
             Path(folder) / f"sensor_{safe_name(str(sensor))}.png")
            for sensor, rows in table.groupby("sensor", sort=False)
            if _names(rows, "noise_") or _names(rows, "cal_")]     # an INS: nothing to show

    def draw(k: int) -> None:
        rows, sensor, path = jobs[k]
        with matplotlib.rc_context(STYLE):
            save_figure(plot_sensor(rows, sensor), path)

    shared_with_child(draw, len(jobs))
    return [path for _, _, path in jobs]
