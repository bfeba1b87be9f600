"""The report's map (``map.png``): zoomed to the objects, far sensors marked on the edge,
labels that do not overprint each other (``report.mapview``), on a harbour like Autoferry's:
two boats within 300 m of a ferry that carries four sensors, one fixed site 3 km away."""
from __future__ import annotations

import matplotlib
import numpy as np

from rangeproc.report.common import STYLE
from rangeproc.report.mapview import (Label, direction_arrow, edge_point, map_extent,
                                      place_labels)
from rangeproc.report.objects import plot_map
from rangeproc.report.trajectory import plot_trajectory
from rangeproc.results import TrackEstimate


def _boat(tid: str, e0: float, n0: float, ve: float, vn: float) -> TrackEstimate:
    t = np.arange(0.0, 100.0, 0.5)
    k = t.size
    x = np.zeros((k, 9))
    x[:, 0], x[:, 1] = e0 + ve * t, n0 + vn * t
    x[:, 3], x[:, 4] = ve, vn
    return TrackEstimate(target_id=tid, time=t, x=x, P=np.tile(np.eye(9), (k, 1, 1)),
                         n_sensors=np.ones(k, dtype=np.int64), lat=np.full(k, 63.4),
                         lon=np.full(k, 10.4), height=np.zeros(k))


def harbour():
    boats = [_boat("T1", -100.0, -150.0, 2.0, 2.0), _boat("O1", 50.0, 100.0, -2.0, 0.5)]
    ferry = np.column_stack([np.linspace(-20.0, 20.0, 50), np.zeros(50), np.zeros(50)])
    sites = {s: ferry + 0.01 * i for i, s in enumerate(("RADAR", "LIDAR", "EO", "IR"))}
    sites["QUAY"] = np.array([2_000.0, 2_200.0, 5.0])
    return boats, sites


def _texts(ax) -> list:
    return [t for t in ax.texts if t.get_text().strip()]


def _overlaps(ax) -> list[tuple[str, str]]:
    r = ax.figure.canvas.get_renderer()
    boxes = [(t.get_text(), t.get_window_extent(r)) for t in _texts(ax)]
    return [(a, b) for i, (a, ba) in enumerate(boxes) for b, bb in boxes[i + 1:]
            if ba.overlaps(bb)]


def test_the_map_zooms_to_the_objects_and_marks_the_far_site():
    boats, sites = harbour()
    with matplotlib.rc_context(STYLE):
        fig = plot_map(boats, np.zeros((0, 3)), sites)
    ax = fig.axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert max(x1 - x0, y1 - y0) < 0.6                 # km: the boats' 350 m, padded
    assert x0 < -0.1 and x1 > 0.05 and y0 < -0.15 and y1 > 0.1
    far = [ln for ln in ax.get_lines() if ln.get_gid() == "far QUAY"]
    assert len(far) == 1
    e, n = far[0].get_xdata()[0], far[0].get_ydata()[0]
    assert x0 < e < x1 and y0 < n < y1                 # on the edge, inside the view
    label = next(t.get_text() for t in _texts(ax) if t.get_text().startswith("QUAY"))
    assert label.startswith("QUAY ↗ 2.9") and label.endswith(" km")


def test_sensors_on_one_platform_get_one_label_and_no_label_overprints_another():
    boats, sites = harbour()
    with matplotlib.rc_context(STYLE):
        for _fig, ax in ((f := plot_map(boats, np.zeros((0, 3)), sites), f.axes[0]),
                        (g := plot_trajectory(boats, sites, 0.0), g.axes[0])):
            texts = [t.get_text() for t in _texts(ax)]
            platform = [t for t in texts if "(platform)" in t]
            assert platform == ["RADAR, LIDAR, EO, IR (platform)"], texts
            assert _overlaps(ax) == []


def test_a_near_site_stays_in_the_view():
    """The ferry is within the boats' span: it joins the view (not an edge marker)."""
    boats, sites = harbour()
    lo, hi = map_extent([b.x[:, :2] / 1e3 for b in boats],
                        {"F": sites["RADAR"], "Q": sites["QUAY"]})
    assert np.all(lo < -0.1) and np.all(hi < 0.35)
    near = {"Q": np.array([300.0, 0.0, 0.0])}         # within twice the boats' span
    lo2, hi2 = map_extent([b.x[:, :2] / 1e3 for b in boats], near)
    assert hi2[0] > 0.3


def test_edge_point_and_arrow():
    lo, hi = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    p = edge_point(np.array([10.5, 0.5]), lo, hi)
    np.testing.assert_allclose(p, [0.96, 0.5])
    assert direction_arrow(np.array([1.0, 1.0])) == "↗"
    assert direction_arrow(np.array([0.0, -3.0])) == "↓"


def test_labels_placed_apart_even_at_one_anchor_with_different_suffixes():
    """Negative control of the placer: two labels at one anchor that do not merge (their
    suffixes differ) are moved apart rather than printed over each other."""
    from matplotlib.figure import Figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(4, 4))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    place_labels(ax, [Label(0.5, 0.5, "A", " (platform)"), Label(0.5, 0.5, "B", " 3 km"),
                      Label(0.5, 0.5, "C", " (platform)")])
    assert sorted(t.get_text() for t in ax.texts) == ["A, C (platform)", "B 3 km"]
    assert _overlaps(ax) == []
