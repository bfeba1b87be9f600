"""The extent and the labels of the report's plan views (``map.png``, ``trajectory.png``).

**Extent** (:func:`map_extent`, ``map.png``): the view is fitted to the objects, not to every
sensor. A sensor (a fixed site, or a platform's whole track) joins the view when the view with
it spans at most :data:`NEAR_FACTOR` times the objects' own span; one farther away would
shrink the objects to a corner (a harbour's boats within 200 m of the ferry in a 2.4 km view),
so it is left out of the extent and indicated on the view's edge instead, in its direction,
with its distance from the view's centre (:func:`edge_point`, :func:`direction_arrow`). The
view is padded by :data:`PAD_FRACTION` of its larger side (at least :data:`MIN_PAD_KM`).

**Labels** (:func:`place_labels`): drawn after the view's limits are final. Labels whose
anchors fall within :data:`MERGE_PX` pixels of each other and share a suffix are one label
("RADAR, LIDAR, EO, IR (platform)": sensors on one platform share its track), and each label
takes the first of a few positions around its anchor (:data:`OFFSETS`) that overlaps no label
placed before it and stays inside the axes (the least overlapping one when none is free).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.transforms import Bbox

#: A sensor joins the view when the view with it spans at most this many times the objects'.
NEAR_FACTOR = 2.0
#: Padding of the view, as a share of its larger side ...
PAD_FRACTION = 0.08
#: ... and at least this much (km).
MIN_PAD_KM = 0.02
#: Labels whose anchors lie this close (pixels) are one label.
MERGE_PX = 10.0
#: Label positions tried around an anchor: (dx, dy) in points, horizontal and vertical
#: alignment of the text.
OFFSETS = ((5, 5, "left", "bottom"), (5, -5, "left", "top"), (-5, 5, "right", "bottom"),
           (-5, -5, "right", "top"), (0, 9, "center", "bottom"), (0, -9, "center", "top"),
           (5, 17, "left", "bottom"), (5, -17, "left", "top"), (-5, 17, "right", "bottom"),
           (-5, -17, "right", "top"))
_ARROWS = "→↗↑↖←↙↓↘"


@dataclass(frozen=True, slots=True)
class Label:
    """A label to place: anchor ``x, y`` (data units), ``name`` (merged with others at the
    same anchor and ``suffix``), text ``suffix``, colour, weight, size (points)."""

    x: float
    y: float
    name: str
    suffix: str = ""
    color: str = "0.2"
    weight: str = "normal"
    size: float = 8.0


def site_points(pos: np.ndarray) -> np.ndarray:
    """(K, 2) finite east, north (km) of a site: (3,) fixed position or (N, 3) platform
    track (m)."""
    p = np.asarray(pos, dtype=float)
    if p.ndim == 1:
        p = p[None, :] if p.size >= 2 else np.zeros((0, 2))
    if p.ndim != 2 or p.shape[1] < 2:
        return np.zeros((0, 2))
    p = p[:, :2] / 1e3
    return p[np.isfinite(p).all(axis=1)]


def map_extent(objects: Sequence[np.ndarray], sites: Mapping[str, np.ndarray]
               ) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo (2,), hi (2,)) km of the view (module docstring): the objects' points (each
    (K, 2) km) and the sites near enough, padded; the sites' alone when there is no object
    point; None when there is nothing."""
    pts = [np.asarray(a, dtype=float).reshape(-1, 2) for a in objects]
    pts = [a[np.isfinite(a).all(axis=1)] for a in pts]
    obj = np.concatenate(pts) if pts else np.zeros((0, 2))
    near = {k: site_points(v) for k, v in sites.items()}
    near = {k: q for k, q in near.items() if q.size}
    if obj.size == 0:
        if not near:
            return None
        obj = np.concatenate(list(near.values()))
        near = {}
    lo, hi = obj.min(axis=0), obj.max(axis=0)
    limit = NEAR_FACTOR * max(float((hi - lo).max()), 2.0 * MIN_PAD_KM)
    centre = 0.5 * (lo + hi)
    for name in sorted(near, key=lambda k: float(np.min(np.linalg.norm(near[k] - centre,
                                                                         axis=1)))):
        q = near[name]
        nlo, nhi = np.minimum(lo, q.min(axis=0)), np.maximum(hi, q.max(axis=0))
        if float((nhi - nlo).max()) <= limit:
            lo, hi = nlo, nhi
    pad = max(PAD_FRACTION * float((hi - lo).max()), MIN_PAD_KM)
    return lo - pad, hi + pad


def inside(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether point ``p`` (2,) lies within the box ``lo``-``hi``."""
    return bool(np.all(p >= lo) and np.all(p <= hi))


def edge_point(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, inset: float = 0.04
               ) -> np.ndarray:
    """Where the ray from the box's centre toward ``p`` (outside it) meets the box shrunk by
    ``inset`` of its size on every side."""
    c = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo) * (1.0 - 2.0 * inset)
    d = np.asarray(p, dtype=float) - c
    with np.errstate(divide="ignore"):
        scale = np.min(np.where(d != 0, half / np.abs(d), np.inf))
    return c + d * min(float(scale), 1.0)


def direction_arrow(d: np.ndarray) -> str:
    """The arrow (of eight) nearest the direction ``d`` (east, north)."""
    k = int(round(math.atan2(float(d[1]), float(d[0])) / (math.pi / 4))) % 8
    return _ARROWS[k]


def place_labels(ax: Axes, labels: Sequence[Label]) -> list:
    """Draw ``labels`` on ``ax`` without overlap (module docstring); call once the limits
    are final. Returns the annotations drawn."""
    fig = ax.figure
    renderer = fig.canvas.get_renderer()       # type: ignore[attr-defined]
    ax.apply_aspect()
    frame = ax.get_window_extent(renderer)
    groups: list[tuple[np.ndarray, Label, list[str]]] = []
    for lab in labels:
        p = ax.transData.transform((lab.x, lab.y))
        if not (np.isfinite(p).all() and frame.contains(*p)):
            continue
        for q, first, names in groups:
            if (first.suffix, first.color) == (lab.suffix, lab.color) \
                    and float(np.hypot(*(q - p))) <= MERGE_PX:
                if lab.name not in names:
                    names.append(lab.name)
                break
        else:
            groups.append((p, lab, [lab.name]))
    placed: list[Bbox] = []
    drawn = []
    for _, lab, names in groups:
        best = None
        for dx, dy, ha, va in OFFSETS:
            ann = ax.annotate(", ".join(names) + lab.suffix, (lab.x, lab.y), xytext=(dx, dy),
                              textcoords="offset points", ha=ha, va=va, fontsize=lab.size,
                              color=lab.color, fontweight=lab.weight, zorder=7,
                              bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none",
                                        alpha=0.7))
            box = ann.get_window_extent(renderer).expanded(1.04, 1.1)
            clash = sum(_area(box, other) for other in placed)
            out = box.width * box.height - _area(box, frame)
            cost = clash + out
            if best is None or cost < best[0]:
                if best is not None:
                    best[1].remove()
                best = (cost, ann, box)
            else:
                ann.remove()
            if cost == 0.0:
                break
        assert best is not None
        placed.append(best[2])
        drawn.append(best[1])
    return drawn


def _area(a: Bbox, b: Bbox) -> float:
    """Area (pixels^2) of the intersection of two boxes."""
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(w, 0.0) * max(h, 0.0)
