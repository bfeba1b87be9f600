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
from matplotlib.figure import Figure

from rangeproc.campaign.summary import MOVE_SIGMAS
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


def plot_sensor(rows: pd.DataFrame, sensor: str) -> Figure:
    """The figure of one sensor from its rows of ``campaign.parquet`` (campaign order)."""
    noise, terms = _names(rows, "noise_"), _names(rows, "cal_")
    panels = [("noise", n) for n in noise] + [("cal", t) for t in terms]
    n = max(1, len(panels))
    cols = 2 if n > 3 else 1
    nrows = int(np.ceil(n / cols))
    fig = new_figure(6.5 * cols, 1.2 + 2.0 * nrows)
    x = np.arange(len(rows))
    labels = rows["sortie"].astype(str).tolist()
    kind = rows["kind"].iloc[0] if len(rows) else ""
    fig.suptitle(f"{sensor} ({kind}) across {len(rows)} sorties: noise and calibration",
                 fontsize=11, fontweight="bold")
    if not panels:
        ax = fig.add_subplot(1, 1, 1)
        ax.text(0.5, 0.5, "no noise or calibration estimates", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
        return fig
    for k, (what, name) in enumerate(panels):
        ax = fig.add_subplot(nrows, cols, k + 1)
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
        ax.set_xticks(x)
        ax.set_xticklabels(labels, rotation=45 if len(labels) > 6 else 0, ha="right"
                           if len(labels) > 6 else "center", fontsize=7)
        ax.set_xlim(-0.5, len(x) - 0.5)
        ax.legend(fontsize=7, loc="best")
    fig.supxlabel("sortie (campaign order)", fontsize=9)
    fig.tight_layout()
    return fig


def write_sensor_figures(table: pd.DataFrame, folder: Path) -> list[Path]:
    """``sensor_<id>.png`` per sensor of ``table`` with any noise or calibration estimate
    into ``folder``; returns the paths."""
    paths = []
    with matplotlib.rc_context(STYLE):
        for sensor, rows in table.groupby("sensor", sort=False):
            if not (_names(rows, "noise_") or _names(rows, "cal_")):
                continue                         # an INS: nothing estimated to show
            path = Path(folder) / f"sensor_{safe_name(str(sensor))}.png"
            save_figure(plot_sensor(rows.reset_index(drop=True), str(sensor)), path)
            paths.append(path)
    return paths
