"""Stage 8, report: the figures an engineer reads first and the page that holds them
(``rangeproc.report``), drawn into the staging folder of the write stage."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.stages.associate import Associated
from rangeproc.timescale import TimeScale


def draw_figures(folder: Path, tracks: list[TrackEstimate], residuals: list[SensorResiduals],
                 sensor_summary: dict[str, dict], sites: dict, associated: Associated,
                 association, edit_rows, scale: TimeScale, first: Callable[[], None],
                 progress: Callable[[str], None]) -> list[Path]:
    """The report's PNG figures in ``folder``; ``first`` runs while the first figures are
    drawn (the tables are written meanwhile), ``progress(name)`` after each figure."""
    from rangeproc.report.figures import write_report     # matplotlib: only when drawing

    several = associated.synthesis is not None
    return write_report(folder, tracks, residuals, sites=sites, calibration={
        sid: ss["calibration"] for sid, ss in sensor_summary.items() if ss.get("calibration")},
        association=association if several else None, stray=associated.stray, first=first,
        edits=edit_rows, progress=progress, scale=scale)


def write_report_page(folder: Path, figures: list[Path], summary: dict, title: str) -> Path:
    """The report page (``index.html``) with the summary's tables and the figures."""
    from rangeproc.report.page import write_page

    return write_page(folder, figures, summary, title)
