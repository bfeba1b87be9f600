"""``report/index.html``: the run on one self-contained page.

The page holds the summary tables and every report figure. Figures are embedded as base64
``data:`` PNGs, the style sheet is inline and there is no script, so the file opens from a
disk, a mail or a share with no network and nothing else beside it. The tables:

* **objects**: span, duration, epochs, gaps (count, longest), largest 1-sigma position
  uncertainty, the process noise found, divergence resets, segments associated;
* **sensors**: rows read, used, rejected points (not used at all: edited before estimation
  or rejected by the gate) per reason, down-weighted components with the count Gaussian noise
  gives; noise a priori and estimated per component; calibration estimates with their
  1-sigma, or why a term is unobservable;
* **rejected points**: the first ones in time order (time, sensor, file row, component,
  value and residual in the file's own unit, reason), the rest counted (``edits.parquet``).

Everything comes from the run's ``summary.json`` dictionary; angles are shown in mrad and
latencies in ms; times as UTC clock time when their calendar is known, else as seconds from
the run's start (``rangeproc.timescale``). The run's warnings are in a box at the top. Written
atomically.
"""
from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path

from rangeproc.io.writers import atomic_path
from rangeproc.report.common import display_unit
from rangeproc.summary_types import CalibrationTerm, RunSummary, SensorSummary, TimeOffsetRecord
from rangeproc.timescale import TimeScale, from_summary

#: What each figure shows (by file name; residual figures by prefix).
CAPTIONS = {
    "trajectory.png": "Plan view with the sensors' sites, altitude, speed and 1-sigma position "
                      "uncertainty per object.",
    "consistency.png": "Normalised innovations squared per sensor against their chi-square "
                       "bounds, and their histograms.",
    "coverage.png": "Used data spans per sensor, rejected points, and how many sensors "
                    "contributed to each object when.",
    "objects.png": "Which sensor saw which object when: relays, swaps found, bridged gaps.",
    "map.png": "Every object in plan view in its own colour, zoomed to the objects (a sensor "
               "far away is marked on the edge, toward it); clutter and unassigned plots grey.",
    "calibration.png": "Estimated biases, latency and mount angles with 1-sigma bars.",
}

STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 24px auto; max-width: 1200px;
       color: #1d2630; padding: 0 16px; }
h1 { font-size: 22px; margin-bottom: 4px; } h2 { font-size: 18px; margin-top: 32px; }
h3 { font-size: 15px; margin: 24px 0 4px; }
p.meta { color: #5a6570; margin-top: 0; }
table { border-collapse: collapse; width: 100%; margin: 8px 0 16px; font-size: 13px; }
th, td { border-bottom: 1px solid #d8dde2; padding: 4px 8px; text-align: left;
         vertical-align: top; }
th { background: #f1f4f7; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 8px 0 28px; } figure img { max-width: 100%; border: 1px solid #d8dde2; }
figcaption { color: #5a6570; font-size: 13px; }
nav a { margin-right: 12px; }
div.warnings { background: #fff4d6; border: 1px solid #e0a800; border-left: 6px solid #e0a800;
               padding: 8px 14px; margin: 12px 0 20px; } div.warnings ul { margin: 4px 0; }
p.nowarn { color: #2e7d32; margin: 8px 0; }
"""


def esc(x: object) -> str:
    return html.escape(str(x))


def _num(v: float | None, digits: int = 4) -> str:
    return "–" if v is None else f"{v:.{digits}g}"


def _shown(value: float | None, unit: str) -> str:
    """A value in its display unit ('0.473 mrad')."""
    if value is None:
        return "–"
    scale, shown = display_unit(unit)
    return f"{value * scale:.4g} {shown}"


def html_table(head: Sequence[str], rows: Sequence[Sequence[str]], numeric: set[int]) -> str:
    """An HTML table; cells are HTML already (escaped by the caller)."""
    out = ["<table><thead><tr>", *(f"<th>{esc(h)}</th>" for h in head), "</tr></thead><tbody>"]
    for row in rows:
        out.append("<tr>" + "".join(f'<td class="num">{c}</td>' if j in numeric else
                                    f"<td>{c}</td>" for j, c in enumerate(row)) + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _when(t: float | None, scale: TimeScale) -> str:
    """A range time as UTC clock time (calendar known) or seconds from the run's start."""
    return "–" if t is None else esc(scale.clock(float(t)))


def objects_table(summary: RunSummary) -> str:
    """The per-object table (``summary["targets"]`` and its association); start and end as
    UTC clock time or seconds from the run's start (``rangeproc.timescale``)."""
    scale = from_summary(summary)
    assoc = (summary.get("association") or {}).get("objects", {})
    rows = []
    for oid, t in summary.get("targets", {}).items():
        gaps = t.get("gaps") or []
        longest = max((float(g[1]) - float(g[0]) for g in gaps
                       if isinstance(g, (list, tuple)) and len(g) == 2), default=0.0)
        q = (t.get("process_noise_q") or {}).get("median")
        a = assoc.get(oid, {})
        rows.append([
            esc(oid) + (" <small>(discovered)</small>" if a.get("discovered") else ""),
            _when(t.get("t_start"), scale), _when(t.get("t_end"), scale),
            _num(None if t.get("t_start") is None else t["t_end"] - t["t_start"], 5),
            esc(t.get("n_epochs", "–")), esc(len(gaps)), _num(longest, 3),
            _num(t.get("max_sigma_position_m"), 3), _num(q, 3),
            esc(t.get("divergence_resets", "–")), esc(len(a.get("segments", [])) or "–")])
    return html_table(["object", "start", "end", "duration (s)", "epochs", "gaps",
                   "longest gap (s)", "max 1σ position (m)", "q median (m²/s⁵)",
                   "divergence resets", "segments"], rows, set(range(1, 11)))


def _along_across(record: dict | None) -> str:
    """``along / across`` (m) of an extent-like record, or a dash."""
    if not record:
        return "–"
    return f"{_num(record.get('along'), 3)} / {_num(record.get('across'), 3)}"


def reference_table(summary: RunSummary) -> str:
    """Where the reference point of each object measured by plots alone can be: the 1-sigma
    spreads (m) whose largest per axis the position covariance carries (``targets.<id>``:
    ``extent_sigma_m``, ``persistent_offset_sigma_m``, ``return_spread_sigma_m``,
    ``reference_sigma_m``) and the output left unwritten by the support rule (s); empty when
    no object has any (point objects, instrumented aircraft)."""
    rows = []
    for oid, t in summary.get("targets", {}).items():
        spreads = [t.get("reference_sigma_m") or 0.0, t.get("return_spread_sigma_m") or 0.0,
                   *((t.get(k) or {}).get(a) or 0.0 for k in
                     ("extent_sigma_m", "persistent_offset_sigma_m") for a in ("along", "across"))]
        unwritten = sum(float(b) - float(a) for a, b in t.get("unwritten") or [])
        if not any(spreads) and not unwritten:
            continue
        rows.append([esc(oid), _along_across(t.get("extent_sigma_m")),
                     _along_across(t.get("persistent_offset_sigma_m")),
                     _num(t.get("return_spread_sigma_m"), 3), _num(t.get("reference_sigma_m"), 3),
                     _num(unwritten, 3)])
    if not rows:
        return ""
    return ("<h2>Reference point</h2><p>1-sigma spreads of where each object's reference point "
            "can be about the track (m); the position sigma carries the largest per axis. "
            "Unwritten: output seconds left out where the object's own plots reject the "
            "trajectory.</p>" + html_table(
                ["object", "hull along / across (m)", "persistent offset along / across (m)",
                 "return spread (m)", "reference (m)", "unwritten (s)"], rows, {3, 4, 5}))


def sensors_table(summary: RunSummary) -> str:
    """The per-sensor table: counts, noise and calibration."""
    rows = []
    for sid, s in summary.get("sensors", {}).items():
        edited = sum((s.get("n_edited") or {}).values())
        noise = "<br>".join(
            f"{esc(c)}: {esc(_shown(n.get('apriori'), n.get('unit', '')))} → "
            f"<b>{esc(_shown(n.get('estimated'), n.get('unit', '')))}</b>"
            + (f" (ρ {n['correlation']:.2f}: ×{n['discount']:.2f})"
               if (n.get("discount") or 1.0) > 1.0 else "")
            for c, n in (s.get("noise") or {}).items())
        cal = "<br>".join([*_time_offset_cell(s.get("time_offset")),
                           *(_calibration_cell(name, c)
                             for name, c in (s.get("calibration") or {}).items())])
        rows.append([esc(sid), esc(s.get("kind", "")), esc(s.get("n_read", s.get("n_rows", "–"))),
                     esc(s.get("n_used", "–")), _rows_lost_cell(s), _rejected_cell(s, edited),
                     _down_weighted_cell(s), noise or "–", cal or "–"])
    return html_table(["sensor", "kind", "rows read", "used", "rows not used (by reason)",
                       "rejected points", "down-weighted (expected if Gaussian)",
                       "noise 1σ: a priori → estimated (ρ: correlated in time, σ ×)",
                       "calibration (± 1σ)"], rows,
                      {2, 3, 4, 5, 6})


def _rows_lost_cell(s: SensorSummary) -> str:
    """The sensor's rows that no object used, per reason (``summary.json``'s ``rows``,
    ``stages.accounting``): rejected, without platform geometry, not associated, not
    started, nothing measured; "–" when every row was used."""
    r = s.get("rows")
    if not r:
        return "–"
    lost = {**(r.get("rejected") or {}),
            "no platform geometry": r.get("no_platform_geometry") or 0,
            **(r.get("not_associated") or {}), "not started": r.get("not_started") or 0,
            "nothing measured": r.get("no_measurement") or 0}
    lost = {k: v for k, v in lost.items() if v}
    if not lost:
        return "–"
    why = "<br>".join(f"{esc(v)} {esc(k)}" for k, v in sorted(lost.items(), key=lambda kv: -kv[1]))
    return f"{esc(sum(lost.values()))}<br><small>{why}</small>"


def _rejected_cell(s: SensorSummary, edited: int) -> str:
    """Rejected points (not used at all) with their count per reason; a summary without
    them: the gate's rows plus the edits before estimation."""
    if "n_rejected_points" not in s:
        return esc(int(s.get("n_rejected") or 0) + edited)
    why = ", ".join(f"{esc(k)} {esc(v)}" for k, v in (s.get("n_rejected_by_reason") or {}).items())
    return esc(s["n_rejected_points"]) + (f"<br><small>{why}</small>" if why else "")


def _down_weighted_cell(s: SensorSummary) -> str:
    """Components used with a weight below 2/3, and how many Gaussian noise of the estimated
    sigma gives (``fusion.edit_audit``)."""
    if "n_down_weighted" not in s:
        return "–"
    expected = s.get("n_down_weighted_expected")
    why = ", ".join(f"{esc(k)} {esc(v)}"
                    for k, v in (s.get("n_down_weighted_by_reason") or {}).items())
    return (esc(s["n_down_weighted"]) + (f" ({_num(expected, 3)})" if expected is not None
                                         else "") + (f"<br><small>{why}</small>" if why else ""))


def rejected_table(summary: RunSummary) -> str:
    """The rejected points (``summary["rejected_points"]``, ``fusion.edit_audit``): time, sensor,
    file row, component, value and residual in the file's unit, reason; 'and N more' when
    the summary lists only the first ones."""
    listed = summary.get("rejected_points") or {}
    shown = listed.get("shown") or []
    if not shown:
        return "<p>No point was rejected.</p>"
    scale = from_summary(summary)
    rows = [[_when(p.get("time"), scale), esc(p.get("sensor", "")), esc(p.get("row", "")),
             esc(p.get("component", "")), _value(p.get("value"), p.get("unit", ""), 10),
             _value(p.get("residual"), p.get("unit", ""), 4, "+"), esc(p.get("reason", ""))]
            for p in shown]
    more = int(listed.get("n", len(shown))) - len(shown)
    note = f"<p>… and {more:,} more in edits.parquet.</p>" if more > 0 else ""
    return html_table(["time", "sensor", "row", "component", "value", "residual", "reason"],
                      rows, {2, 4, 5}) + note


def _value(v: float | None, unit: str, digits: int, sign: str = "") -> str:
    """A value in the file's own unit ('11583.358 m'; ``sign`` "+": '+394.2 m'); '–' when
    there is none."""
    return "–" if v is None or v != v else esc(f"{v:{sign}.{digits}g} {unit}".strip())


def _time_offset_cell(offset: TimeOffsetRecord | None) -> list[str]:
    """The configured ``time_offset`` as the user gave it: a clock alignment as seconds and
    the instant it names, a known latency correction in ms (none: nothing)."""
    if not offset:
        return []
    if offset.get("instant"):
        return [f"time_offset (clock alignment): {offset['value']:+.3f} s = "
                f"{esc(offset['instant'])}"]
    return [f"time_offset (known latency): {esc(_shown(offset['value'], 's'))}"]


def _calibration_cell(name: str, c: CalibrationTerm) -> str:
    if c.get("estimate") is None:
        return f"{esc(name)}: <i>unobservable</i> ({esc(c.get('unobservable', ''))})"
    applied = "" if c.get("applied", True) else " <small>(not significant, not applied)</small>"
    unit = c.get("unit", "")
    return (f"{esc(name)}: {esc(_shown(c['estimate'], unit))} ± "
            f"{esc(_shown(c.get('sigma'), unit))}{applied}")


def figure_block(path: Path, caption: str | None = None) -> str:
    """One embedded figure with its caption (default: by its file name, :data:`CAPTIONS`)."""
    name = path.name
    caption = caption or CAPTIONS.get(name) or (
        f"Post-fit residuals of sensor {name[len('residuals_'):-4]} with their 3-sigma "
        "envelope; rejected points marked." if name.startswith("residuals_") else name)
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<figure id="{esc(path.stem)}"><h3>{esc(name)}</h3>'
            f'<img alt="{esc(name)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def warnings_box(summary: RunSummary) -> str:
    """The run's warnings (``summary["warnings"]``, one line each) in a box for the top of the
    page; 'no warnings' when there are none."""
    lines = [str(w) for w in summary.get("warnings") or []]
    if not lines:
        return '<p class="nowarn">no warnings</p>'
    items = "".join(f"<li>{esc(w)}</li>" for w in lines)
    return (f'<div class="warnings" id="warnings"><b>{len(lines)} warning'
            f'{"s" * (len(lines) != 1)}</b><ul>{items}</ul></div>')


def _times_line(summary: RunSummary) -> str:
    """How the page's times read: the run's start as UTC and raw, or raw with 'from start'."""
    scale = from_summary(summary)
    if scale.start != scale.start:                                  # NaN: no epochs
        return ""
    return f'<p class="meta">Times: {esc(scale.start_text())}</p>'


def page_html(summary: RunSummary, figures: Sequence[Path], title: str) -> str:
    """The whole page as a string."""
    cfg = summary.get("config", {})
    n_obj, n_sen = len(summary.get("targets", {})), len(summary.get("sensors", {}))
    meta = (f"rangeproc {esc(summary.get('rangeproc_version', ''))} · config "
            f"{esc(cfg.get('file', ''))} · {n_obj} object{'s' * (n_obj != 1)} · "
            f"{n_sen} sensor{'s' * (n_sen != 1)} · run took "
            f"{_num(summary.get('elapsed_s'), 3)} s")
    nav = " ".join(f'<a href="#{esc(p.stem)}">{esc(p.stem)}</a>' for p in figures)
    return "".join([
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{esc(title)}</h1><p class=\"meta\">{meta}</p>",
        _times_line(summary),
        warnings_box(summary),
        "<h2>Objects</h2>", objects_table(summary), reference_table(summary),
        "<h2>Sensors</h2>", sensors_table(summary),
        "<h2>Rejected points</h2>", rejected_table(summary),
        f"<h2>Figures</h2><nav>{nav}</nav>",
        *(figure_block(p) for p in figures),
        "</body></html>\n"])


def write_page(report_dir: Path, figures: Sequence[Path], summary: RunSummary,
               title: str) -> Path:
    """Write ``report_dir/index.html`` (atomic) from the run's ``summary`` and its figure
    files (embedded in the order given); returns its path."""
    path = Path(report_dir) / "index.html"
    with atomic_path(path) as tmp:
        tmp.write_text(page_html(summary, figures, title), encoding="utf-8")
    return path
