"""The campaign's page, ``<records>/index.html``: one self-contained page over its sorties.

Holds the sorties table (status, the one-line reason of a failure, time, where it ran, a
link to the sortie's own ``report/index.html``), the instrument assessment per sensor (the
sorties with data, the median estimated noise per component, the calibration terms that
moved between sorties and where), and every ``sensor_<id>.png`` embedded. Same style and
rules as a run's page (``report.page``: inline style sheet, figures as ``data:`` PNGs, no
script). Written atomically.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rangeproc.campaign.figures import shown_as
from rangeproc.io.writers import atomic_path
from rangeproc.report.page import STYLE, esc, figure_block, html_table

if TYPE_CHECKING:
    from rangeproc.campaign.result import CampaignResult


def sorties_table(record: CampaignResult, folder: Path) -> str:
    rows = []
    for o in record.outcomes:
        page = Path(o.out_dir) / "report" / "index.html" if o.out_dir else None
        link = (f'<a href="{esc(Path(os.path.relpath(page, folder)).as_posix())}">report</a>'
                if page is not None and page.is_file() else "–")
        status = esc(o.status) if o.status != "failed" else \
            f'<b style="color:#d62728">failed</b> (exit {o.exit_code})'
        rows.append([esc(o.id), status, esc(o.reason) or "–", f"{o.seconds:.1f}",
                     esc(o.where) or "–", link])
    return html_table(["sortie", "status", "reason", "seconds", "ran on", "page"], rows, {3})


def assessment_table(table: pd.DataFrame) -> str:
    rows = []
    for sensor, g in table.groupby("sensor", sort=False):
        noise = []
        for c in [c for c in g.columns if c.startswith("noise_") and not c.endswith("_apriori")]:
            if g[c].notna().any():
                scale, unit = shown_as(c[6:])
                noise.append(f"{esc(c[6:])}: {np.nanmedian(g[c]) * scale:.4g} {unit}")
        moved = []
        for c in [c for c in g.columns if c.startswith("cal_") and c.endswith("_moved")]:
            where = g.loc[g[c].fillna(False).astype(bool), "sortie"].tolist()
            if where:
                moved.append(f"{esc(c[4:-6])} at {esc(', '.join(map(str, where)))}")
        rows.append([esc(sensor), esc(g["kind"].iloc[0]), str(len(g)),
                     "<br>".join(noise) or "–",
                     ('<b style="color:#d62728">' + "<br>".join(moved) + "</b>") if moved
                     else "none"])
    return html_table(["sensor", "kind", "sorties", "median estimated noise 1σ",
                       "calibration moved beyond 3σ"], rows, {2})


def write_campaign_page(record: CampaignResult, title: str, table: pd.DataFrame,
                        figures: Sequence[Path], folder: Path) -> Path:
    """Write ``folder/index.html``; returns its path."""
    counts = record.counts()
    meta = (f"{len(record.outcomes)} sorties: {counts['done']} done, {counts['skipped']} "
            f"skipped (up to date), {counts['failed']} failed · {record.seconds:.1f} s on "
            f"{esc(record.cluster)}")
    body = "".join([
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{esc(title)}</h1><p class=\"meta\">{meta}</p>",
        "<h2>Sorties</h2>", sorties_table(record, folder),
        "<h2>Instruments across the campaign</h2>",
        assessment_table(table) if not table.empty else "<p>No sortie produced outputs.</p>",
        "<h2>Figures</h2>",
        *(figure_block(p, f"Noise and calibration of sensor {p.stem[len('sensor_'):]} per "
                          "sortie (±1σ); red: moved since the previous sortie.")
          for p in figures),
        "</body></html>\n"])
    path = Path(folder) / "index.html"
    with atomic_path(path) as tmp:
        tmp.write_text(body, encoding="utf-8")
    return path
