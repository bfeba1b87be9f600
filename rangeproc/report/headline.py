"""The run's headline on the terminal: what ``rangeproc run`` prints after the outputs are in
place, a few lines an engineer reads before opening the report.

One line per object (at most :data:`MAX_OBJECTS`, then a count of the rest): its id, epochs,
span (UTC clock time when the calendar is known, ``rangeproc.timescale``) and its 1-sigma
position uncertainty on its worst axis (east, north or up) per epoch, median and maximum over
the epochs (the maximum is ``summary.json``'s ``max_sigma_position_m``); then the number of
warnings and the report page's path.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rangeproc.results import TrackEstimate
from rangeproc.summary_types import RunSummary
from rangeproc.timescale import TimeScale, from_summary

#: Objects listed one per line; the others are counted.
MAX_OBJECTS = 5


def worst_axis_sigma(track: TrackEstimate) -> np.ndarray:
    """(K,) m: per epoch, the largest 1-sigma position uncertainty of the three axes."""
    P = np.asarray(track.P, dtype=float)
    if P.size == 0:
        return np.zeros(0)
    var = np.diagonal(P[:, :3, :3], axis1=1, axis2=2)
    return np.sqrt(np.clip(np.max(var, axis=1), 0.0, None))


def _span(scale: TimeScale, first: float, last: float) -> str:
    """'2026-05-11 14:00:00.0 to 14:02:00.0 UTC' (calendar known; the date once when both are
    on one day) or 't = 0.0 to 120.0 s from start'."""
    if not scale.known:
        return f"t = {first - scale.start:.1f} to {last - scale.start:.1f} s from start"
    a, b = scale.clock(first), scale.clock(last)
    return f"{a[:-4]} to {b[11:] if a[:10] == b[:10] else b}"


def headline(summary: RunSummary, tracks: Sequence[TrackEstimate],
             page: Path | None) -> list[str]:
    """The headline's lines (no trailing newlines) for a run's ``summary`` and ``tracks``;
    ``page``: the report page (``report/index.html``), None when there is none."""
    scale = from_summary(summary)
    lines = []
    shown = [tr for tr in tracks if np.size(tr.time)]
    for tr in shown[:MAX_OBJECTS]:
        t = np.asarray(tr.time, dtype=float)
        sig = worst_axis_sigma(tr)
        ok = sig[np.isfinite(sig)]
        span = _span(scale, float(t[0]), float(t[-1]))
        sigma = (f"1σ position (worst axis) median {float(np.median(ok)):.2f} m, max "
                 f"{float(np.max(ok)):.2f} m" if ok.size else "no uncertainty")
        lines.append(f"{tr.target_id}: {t.size:,} epochs, {span}; {sigma}")
    if len(shown) > MAX_OBJECTS:
        rest = shown[MAX_OBJECTS:]
        ids = ", ".join(tr.target_id for tr in rest[:8]) + (", ..." if len(rest) > 8 else "")
        lines.append(f"... and {len(rest)} more objects ({ids}): see the report")
    n_warn = len(summary.get("warnings") or [])
    lines.append(f"{n_warn} warning{'s' * (n_warn != 1)}" +
                 (" (on stderr and at the top of the report)" if n_warn else ""))
    if page is not None:
        lines.append(f"report: {page}")
    return lines
