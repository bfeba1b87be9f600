"""``calibration.png``: every sensor's estimated systematic errors with their uncertainty.

One panel per unit (range biases in m; angle biases and mount angles in mrad; latencies in
ms), one row per sensor term: the estimate with its 1-sigma (thick) and 3-sigma (thin) bars,
filled when the rows were corrected (significant), hollow when the estimate is within 3 sigma
of zero (rows left as measured). Terms the data cannot separate are listed with the reason
instead of a bar; given (known) corrections are marked.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

from rangeproc.report.common import CYCLE, new_figure

#: panel title, display scale from SI and unit label, per SI unit of the terms
PANELS = (("m", 1.0, "range bias (m)"), ("rad", 1e3, "angle bias, mount angle (mrad)"),
          ("s", 1e3, "latency (ms)"))
MUTED = "#7f7f7f"


def _rows(calibration: Mapping[str, Mapping[str, dict]], unit: str
          ) -> list[tuple[str, dict]]:
    return [(f"{sid} {name}", term) for sid, terms in calibration.items()
            for name, term in terms.items()
            if term.get("unit") == unit and term.get("sigma") is not None]


def _notes(calibration: Mapping[str, Mapping[str, dict]]) -> list[str]:
    return [f"{sid} {name}: {term['unobservable']}" for sid, terms in calibration.items()
            for name, term in terms.items() if "unobservable" in term]


#: Figure layout (inches): a panel's height per term row and its fixed part, the space under
#: each panel for its tick labels and axis label, above the panels for the title, right of
#: them for the "estimate ± sigma" notes, and per line of the "Not estimated" list. Fixed
#: rather than ``tight_layout``, which drew the figure once more to measure it (two thirds of
#: this figure's cost).
ROW_IN, PANEL_IN, UNDER_IN, TOP_IN, RIGHT_IN, NOTE_IN = 0.32, 0.25, 0.62, 0.55, 1.15, 0.17
WIDTH_IN = 9.0
#: Width of one character of the 8 pt tick labels (inches, DejaVu Sans average).
CHAR_IN = 8.0 / 72.0 * 0.62


def plot_calibration(calibration: Mapping[str, Mapping[str, dict]]) -> Figure:
    """The figure from ``summary.json``'s ``sensors.<id>.calibration`` entries (SI units)."""
    panels = [(p, _rows(calibration, p[0])) for p in PANELS]
    panels = [(p, rows) for p, rows in panels if rows]
    notes = _notes(calibration)
    heights = [max(len(rows), 1) * ROW_IN + PANEL_IN for _, rows in panels] or [0.8]
    notes_in = NOTE_IN * (len(notes) + 1) if notes else 0.1
    height = TOP_IN + sum(heights) + UNDER_IN * len(heights) + notes_in
    fig = new_figure(WIDTH_IN, height)
    title = ("Sensor calibration: estimate, 1σ (thick) and 3σ (thin); hollow = within 3σ "
             "of zero, rows not corrected; | = given correction")
    fig.suptitle(title, fontsize=9, y=1.0 - 0.15 / height, va="top")
    if notes:
        fig.text(0.01, 0.05 / height, "Not estimated:\n" + "\n".join(notes), fontsize=7,
                 va="bottom", color=MUTED)
    if not panels:
        ax = fig.add_subplot(1, 1, 1)
        ax.axis("off")
        ax.text(0.5, 0.5, "no calibration term estimated", ha="center", va="center")
        return fig
    longest = max(len(name) for _, rows in panels for name, _ in rows)
    left_in = 0.3 + CHAR_IN * longest
    grid = fig.add_gridspec(
        len(panels), 1, height_ratios=heights, left=left_in / WIDTH_IN,
        right=1.0 - RIGHT_IN / WIDTH_IN, top=1.0 - TOP_IN / height,
        bottom=(notes_in + UNDER_IN) / height, hspace=UNDER_IN / float(np.mean(heights)))
    for k, ((_unit, scale, label), rows) in enumerate(panels):
        ax = fig.add_subplot(grid[k])
        for j, (_name, term) in enumerate(rows):
            est, sig = term["estimate"] * scale, term["sigma"] * scale
            color = CYCLE[j % len(CYCLE)] if term.get("applied") else MUTED
            ax.plot([est - 3 * sig, est + 3 * sig], [j, j], color=color, lw=1.0)
            ax.plot([est - sig, est + sig], [j, j], color=color, lw=4.0, solid_capstyle="butt")
            ax.plot([est], [j], "o", ms=6, color=color,
                    mfc=color if term.get("applied") else "white")
            if "given" in term:
                ax.plot([term["given"] * scale], [j], "|", ms=12, color="black")
            ax.annotate(f"{est:.4g} ± {sig:.2g}", (1.01, j), xycoords=("axes fraction", "data"),
                        va="center", fontsize=7, color=color)
        ax.axvline(0.0, color="black", lw=0.6)
        ax.set_yticks(range(len(rows)), [name for name, _ in rows])
        ax.set_ylim(len(rows) - 0.5, -0.5)
        ax.set_xlabel(label)
        ax.grid(axis="x", alpha=0.3)
    return fig
