"""Every rejected point on its residual figure and on the page (issue 28, item 4), on the
hand-made flight (tests/newuser.py: three wild radar ranges, +400 m, removed by the Hampel
pre-edit before estimation, so not in the residual rows).

One run through the CLI; the residual sets and the edit table it hands to the report are
kept (``write_report`` wrapped), so the figure's selection of rejected points is tested, not
its pixels.
"""
from __future__ import annotations

import re
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest

import rangeproc.report.figures as figmod
from conftest import describe, invoke
from newuser import WILD_ROWS, make_flight
from rangeproc.report.common import merge_sensors
from rangeproc.report.page import page_html, rejected_table
from rangeproc.report.residuals import plot_residuals, rejected_points
from rangeproc.results import SensorResiduals


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.parts: list[str] = []

    def handle_data(self, data):  # type: ignore[no-untyped-def]
        self.parts.append(data)


def page_text(html: str) -> str:
    p = _Text()
    p.feed(html)
    return " ".join(p.parts)


@pytest.fixture(scope="module")
def run(tmp_path_factory):  # type: ignore[no-untyped-def]
    """(flight, output folder, {"residuals", "edits"} given to write_report)."""
    made = make_flight(tmp_path_factory.mktemp("rejected_points"))
    seen: dict = {}
    real = figmod.write_report

    def keep(report_dir, tracks, residuals, **kw):  # type: ignore[no-untyped-def]
        seen.update(residuals=list(residuals), edits=kw.get("edits"))
        return real(report_dir, tracks, residuals, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(figmod, "write_report", keep)
        result = invoke(["run", "--quiet", made.config])
    assert result.exit_code == 0, describe(result)
    return made, made.folder / "out", seen


def _radar_view(seen):  # type: ignore[no-untyped-def]
    return next(v for v in merge_sensors(seen["residuals"]) if v.sensor_id == "R1")


def test_residual_figure_draws_the_three_pre_edited_points(run) -> None:
    made, _, seen = run
    view = _radar_view(seen)
    assert not view.rejected_comp.any()          # not in the residual rows: pre-edited
    points = rejected_points(view, seen["edits"])
    assert points.n == 3 and points.time.size == 3
    assert set(points.panel) == {view.components.index("range")}
    np.testing.assert_allclose(points.time, made.radar_unix[list(WILD_ROWS)], atol=1e-3)
    np.testing.assert_allclose(points.residual, 400.0, atol=25.0)
    assert set(points.reason) == {"pre-edit"}
    fig = plot_residuals(view, float(view.time[0]), points)
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "rejected (3)" in labels
    titles = [ax.get_title(loc="right") for ax in fig.axes]
    assert any(t.startswith("rejected 3") for t in titles)


def test_gps_without_rejections_draws_none(run) -> None:
    _, _, seen = run
    gps = next(v for v in merge_sensors(seen["residuals"]) if v.sensor_id == "G1")
    assert rejected_points(gps, seen["edits"]).n == 0


def test_points_without_residual_and_whole_rows_are_drawn_and_counted_once() -> None:
    n = 50
    t = np.arange(n, dtype=float)
    res = SensorResiduals("G9", "gps", "T1", ("e", "n", "u"), ("m", "m", "m"), t,
                          np.random.default_rng(1).normal(0.0, 1.0, (n, 3)),
                          np.ones((n, 3)), np.zeros((n, 3), bool), np.ones(n))
    res.rejected[10, 2] = True                    # one gate rejection of u
    view = merge_sensors([res])[0]
    edits = pd.DataFrame({"sensor": ["G9", "G9", "G9", "X"],
                          "time": [20.0, 30.0, 1e12, 5.0],
                          "component": ["lat", "*", "height", "lat"],
                          "residual": [np.nan, np.nan, 5.0, np.nan],
                          "reason": ["pre-edit", "time", "limit", "limit"],
                          "action": ["rejected"] * 4})
    points = rejected_points(view, edits)
    assert points.n == 4                          # gate 1 + G9's three (X is another sensor)
    drawn = sorted(zip(points.time.tolist(), points.panel.tolist()))
    assert drawn == [(10.0, 2), (20.0, 1), (30.0, 0), (30.0, 1), (30.0, 2), (1e12, 2)]
    fig = plot_residuals(view, 0.0, points)
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "rejected (4)" in labels and "no residual (top edge)" in labels
    assert fig.axes[0].get_xlim()[1] < 100.0      # the far time stamp did not stretch it


def test_page_counts_and_lists_the_rejected_points(run) -> None:
    _, out, _ = run
    html = (out / "report" / "index.html").read_text(encoding="utf-8")
    text = page_text(html)
    assert "rejected (wild)" not in text
    assert "rejected points" in text and "down-weighted (expected if Gaussian)" in text
    assert "pre-edit 3" in text
    table = html[html.index("<h2>Rejected points</h2>"):]
    table = table[:table.index("</table>")]
    rows = re.findall(r"<tr><td>.*?</tr>", table)
    assert len(rows) == 3
    radar = pd.read_csv(out.parent / "R1.csv")
    for row, k in zip(rows, WILD_ROWS):
        cells = re.findall(r"<td[^>]*>(.*?)</td>", row)
        assert cells[1:4] == ["R1", str(k + 1), "range"]
        assert cells[4] == f"{radar.range[k]:.10g} m"
        assert cells[5].startswith("+3") or cells[5].startswith("+4")
        assert cells[6] == "pre-edit"


def test_page_sensor_row_shows_down_weighted_against_expected(run) -> None:
    _, out, _ = run
    import json
    summary = json.loads((out / "summary.json").read_text())
    text = page_text((out / "report" / "index.html").read_text(encoding="utf-8"))
    r1 = summary["sensors"]["R1"]
    assert f"{r1['n_down_weighted']} ({r1['n_down_weighted_expected']:.3g})" in text


def test_rejected_table_is_capped_with_the_rest_counted() -> None:
    shown = [{"sensor": "R1", "row": k, "time": float(k), "component": "azimuth",
              "value": 12.5, "residual": -0.25, "unit": "deg", "reason": "gate"}
             for k in range(50)]
    html = rejected_table({"rejected_points": {"n": 120, "shown": shown}})
    assert html.count("<tr><td>") == 50
    assert "and 70 more in edits.parquet" in html
    assert "12.5 deg" in html and "-0.25 deg" in html
    assert "No point was rejected" in rejected_table({"rejected_points": {"n": 0, "shown": []}})
    assert "Rejected points" in page_html({"rejected_points": {"n": 120, "shown": shown}}, [],
                                          "t")


def test_coverage_residuals_and_page_give_one_count_of_rejected_points(run) -> None:
    """coverage.png said "0 rej" for the radar whose residual figure and page say 3 rejected
    points (pre-edited, not in the residual rows): every figure now counts the page's
    points, labelled as points, and marks each of them."""
    import json

    from rangeproc.report.timeline import plot_coverage

    _, out, seen = run
    summary = json.loads((out / "summary.json").read_text())
    views = merge_sensors(seen["residuals"])
    fig = plot_coverage(views, [], float(views[0].time[0]), seen["edits"])
    ax = fig.axes[0]
    for view in views:
        n = summary["sensors"][view.sensor_id]["n_rejected_points"]
        assert rejected_points(view, seen["edits"]).n == n
        text = next(t.get_text() for t in ax.texts if t.get_gid() == f"counts {view.sensor_id}")
        used = summary["sensors"][view.sensor_id]["n_used"]
        assert text.splitlines()[:2] == [f"{used:,} rows used", f"{n:,} points rejected"]
        res = plot_residuals(view, float(view.time[0]), rejected_points(view, seen["edits"]))
        assert f"rejected {n:,} points" in " ".join(t.get_text() for t in res.texts)
    assert summary["sensors"]["R1"]["n_rejected_points"] == 3
    ticks = [ln for ln in ax.lines if ln.get_marker() == "|"]
    assert sum(ln.get_xdata().size for ln in ticks) == 3        # the three wild ranges
