"""Shared helpers of the PNG report: figure creation, atomic saving, decimation, time axis.

Everything here is plotting plumbing with no knowledge of a particular figure. Arrays are
NumPy; times are seconds on the range time scale unless a name says ``since t0``.
"""
from __future__ import annotations

import io
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.ticker import Formatter, Locator

from rangeproc.io.writers import atomic_path
from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.timescale import TimeScale, utc_text

#: Resolution of every report PNG (dots per inch).
DPI = 110
#: Most points of one series drawn in a scatter (rejected points come on top of this).
MAX_POINTS = 20_000
#: matplotlib rc settings applied (via ``rc_context``) while the report is drawn.
STYLE = {
    "font.size": 9.0,
    "axes.titlesize": 9.5,
    "axes.labelsize": 9.0,
    "legend.fontsize": 8.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.grid": True,
    # a fixed title height: matplotlib otherwise measures every axis's tick labels to lift
    # titles clear of top-side ticks, which these figures do not have (6 % of the drawing)
    "axes.titley": 1.0,
    "grid.alpha": 0.35,
    "grid.linewidth": 0.6,
    "axes.formatter.useoffset": False,
    "path.simplify": True,
    "agg.path.chunksize": 20_000,
    # glyphs unhinted: FreeType's hinting pass per glyph was 12 % of the report's drawing
    # (matplotlib 3.11); at 110 dpi, antialiased, the text is as legible
    "text.hinting": "no_hinting",
}
#: Colour of rejected (wild) points and of "no sensor" coverage.
REJECT_COLOR = "#d62728"
#: Colours per sensor kind (coverage rows, consistency panels).
KIND_COLORS = {
    "radar": "#1f77b4",
    "theodolite": "#2ca02c",
    "gps": "#ff7f0e",
    "mistram": "#9467bd",
    "ins": "#7f7f7f",
}
#: Qualitative colours for targets and groups (stations).
CYCLE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf",
         "#bcbd22", "#7f7f7f", "#393b79")


@dataclass(frozen=True, slots=True)
class SensorView:
    """All residual rows of one sensor (merged over targets), sorted by time.

    time: (N,) s; residual, sigma: (N, m) SI (rad for angles), NaN = not measured;
    rejected_comp: (N, m) bool, component rejected by the gate; rejected: (N,) bool, any
    component of the row rejected; nis: (N,) float; group: (N,) int64 index into
    ``group_names`` (MISTRAM station and/or target, a single group "" otherwise).
    """

    sensor_id: str
    kind: str
    targets: tuple[str, ...]
    components: tuple[str, ...]
    units: tuple[str, ...]
    time: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    rejected_comp: np.ndarray
    rejected: np.ndarray
    nis: np.ndarray
    group: np.ndarray
    group_names: tuple[str, ...]

    @property
    def used_comp(self) -> np.ndarray:
        """(N, m) bool: component measured and not rejected."""
        return np.isfinite(self.residual) & ~self.rejected_comp

    @property
    def used(self) -> np.ndarray:
        """(N,) bool: at least one component measured and used."""
        return self.used_comp.any(axis=1)


def _as_2d(a: np.ndarray, n: int, m: int, what: str) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 1 and m == 1:
        arr = arr[:, None]
    if arr.shape != (n, m):
        raise ValueError(f"SensorResiduals.{what}: shape {arr.shape}, expected {(n, m)}")
    return arr


def merge_sensors(residuals: Sequence[SensorResiduals]) -> list[SensorView]:
    """Merge the residual sets of each sensor id (one per target) into one time-sorted view.

    Components are the union over the sets (first-seen order); a component a set lacks is NaN.
    Order of the returned views = first appearance of each sensor id.
    """
    by_id: dict[str, list[SensorResiduals]] = {}
    for r in residuals:
        by_id.setdefault(r.sensor_id, []).append(r)
    views = []
    for sid, parts in by_id.items():
        comps: list[str] = []
        units: list[str] = []
        for p in parts:
            for c, u in zip(p.components, p.units):
                if c not in comps:
                    comps.append(c)
                    units.append(u)
        targets = tuple(dict.fromkeys(p.target_id for p in parts))
        names: list[str] = []
        cols_t, cols_r, cols_s, cols_j, cols_n, cols_g = [], [], [], [], [], []
        for p in parts:
            t = np.asarray(p.time, dtype=float).reshape(-1)
            n, m = t.size, len(comps)
            res = np.full((n, m), np.nan)
            sig = np.full((n, m), np.nan)
            idx = [comps.index(c) for c in p.components]
            res[:, idx] = _as_2d(p.residual, n, len(p.components), "residual")
            sig[:, idx] = _as_2d(p.sigma, n, len(p.components), "sigma")
            prefix = p.target_id if len(targets) > 1 else ""
            if p.station is not None:
                st = np.asarray(p.station, dtype=np.int64).reshape(-1)
                uniq, inv = np.unique(st, return_inverse=True)
                labels = [f"{prefix} stn {k}".strip() for k in uniq]
            else:
                inv = np.zeros(n, dtype=np.int64)
                labels = [prefix]
            gmap = np.array([_index_of(names, lab) for lab in labels], dtype=np.int64)
            cols_t.append(t)
            cols_r.append(res)
            cols_s.append(sig)
            rej = np.zeros((n, m), dtype=bool)
            pr = np.asarray(p.rejected, dtype=bool)
            if pr.ndim == 1:                      # row-level flag: every measured component
                rej[:, idx] = pr.reshape(-1, 1) & np.isfinite(res[:, idx])
            else:
                rej[:, idx] = pr.reshape(n, len(p.components))
            cols_j.append(rej)
            cols_n.append(np.asarray(p.nis, dtype=float).reshape(-1))
            cols_g.append(gmap[inv] if gmap.size else np.zeros(0, dtype=np.int64))
        t = np.concatenate(cols_t)
        order = _time_order(t)
        views.append(SensorView(
            sensor_id=sid, kind=parts[0].kind, targets=targets, components=tuple(comps),
            units=tuple(units), time=t[order], residual=np.concatenate(cols_r)[order],
            sigma=np.concatenate(cols_s)[order], rejected_comp=np.concatenate(cols_j)[order],
            rejected=np.concatenate(cols_j)[order].any(axis=1),
            nis=np.concatenate(cols_n)[order], group=np.concatenate(cols_g)[order],
            group_names=tuple(names) if names else ("",)))
    return views


def _index_of(names: list[str], label: str) -> int:
    if label not in names:
        names.append(label)
    return names.index(label)


def _time_order(t: np.ndarray) -> np.ndarray | slice:
    """Stable time order of ``t`` (a no-op slice when already sorted; NaN times go last)."""
    if t.size < 2 or bool(np.all(t[1:] >= t[:-1])):
        return slice(None)
    return np.argsort(t, kind="stable")


def time_origin(tracks: Sequence[TrackEstimate], views: Sequence[SensorView]) -> float:
    """t0 (s, range time scale): the earliest finite epoch of any track or residual row."""
    firsts = [float(np.nanmin(a)) for a in [tr.time for tr in tracks] + [v.time for v in views]
              if np.size(a) and np.isfinite(a).any()]
    return min(firsts) if firsts else 0.0


class TimeOrigin(float):
    """t0 (s, range time scale) of the report's time axes that also carries the run's calendar
    (``scale``, :class:`rangeproc.timescale.TimeScale`; None: unknown). It is a float, so
    ``t - t0`` is seconds since t0 as before; :func:`time_axis`, :func:`time_label` and
    :func:`t0_note` read the calendar from it (a plain float: calendar unknown)."""

    scale: TimeScale | None

    def __new__(cls, t0: float, scale: TimeScale | None = None) -> TimeOrigin:
        obj = super().__new__(cls, t0)
        obj.scale = scale if scale is not None and scale.known else None
        return obj

    def __reduce__(self) -> tuple:
        return (TimeOrigin, (float(self), self.scale))


def _scale_of(t0: float) -> TimeScale | None:
    scale = getattr(t0, "scale", None)
    return scale if scale is not None and scale.known and np.isfinite(t0) else None


#: Tick steps (s) of a UTC clock axis: round seconds, minutes and hours.
CLOCK_STEPS = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 60.0, 120.0, 300.0,
               600.0, 900.0, 1200.0, 1800.0, 3600.0, 7200.0, 10800.0, 21600.0, 43200.0,
               86400.0)


def day_seconds(instant: np.datetime64) -> float:
    """Seconds of ``instant`` after 00:00 UTC of its day."""
    instant = np.datetime64(instant, "ns")
    return float((instant - instant.astype("datetime64[D]")) / np.timedelta64(1, "s"))


class ClockLocator(Locator):
    """Ticks of an axis in seconds since t0 at round UTC clock times (every 10 s, 1 min, ...):
    ``offset`` is t0's seconds after 00:00 UTC of its day."""

    def __init__(self, offset: float, nbins: int = 7) -> None:
        self.offset, self.nbins = float(offset), int(nbins)

    def __call__(self) -> np.ndarray:
        vmin, vmax = self.axis.get_view_interval()
        return self.tick_values(vmin, vmax)

    def tick_values(self, vmin: float, vmax: float) -> np.ndarray:
        lo, hi = sorted((float(vmin), float(vmax)))
        span = hi - lo
        if not (np.isfinite(span) and span > 0):
            return np.array([lo]) if np.isfinite(lo) else np.zeros(0)
        step = next((s for s in CLOCK_STEPS if span / s <= self.nbins),
                    86400.0 * np.ceil(span / 86400.0 / self.nbins))
        k = np.arange(np.ceil((lo + self.offset) / step), np.floor((hi + self.offset) / step) + 1)
        return k * step - self.offset


class ClockFormatter(Formatter):
    """Tick labels 'hh:mm:ss' (with tenths when the ticks are closer than 1 s) of an axis in
    seconds since ``base`` (a UTC ``datetime64``)."""

    def __init__(self, base: np.datetime64) -> None:
        self.base = np.datetime64(base, "ns")
        self.tenths = False

    def __call__(self, x: float, pos: int | None = None) -> str:
        if not np.isfinite(x):
            return ""
        instant = self.base + np.timedelta64(int(round(x * 1e9)), "ns")
        text = utc_text(instant)[11:21]                             # hh:mm:ss.s
        return text if self.tenths else text[:8]

    def format_ticks(self, values: Sequence[float]) -> list[str]:
        v = np.asarray(values, dtype=float)
        steps = np.diff(v[np.isfinite(v)])
        self.tenths = bool(steps.size and np.min(np.abs(steps)) < 0.999)
        return [self(x, i) for i, x in enumerate(values)]


def time_label(t0: float) -> str:
    """x-axis label for times relative to ``t0`` (s): UTC clock time when t0 carries a known
    calendar (:class:`TimeOrigin`), else seconds from start."""
    scale = _scale_of(t0)
    if scale is None:
        return "time from start t0 [s]"
    return f"time, UTC on {utc_text(scale.utc(t0))[:10]} [hh:mm:ss]"


def time_axis(ax: Axes, t0: float) -> None:
    """Label ``ax``'s x axis (seconds since ``t0``) with :func:`time_label`; with a known
    calendar its ticks are also round UTC clock times labelled 'hh:mm:ss' (the data stay
    seconds since t0). Axes sharing x with ``ax`` share the ticks."""
    ax.set_xlabel(time_label(t0))
    scale = _scale_of(t0)
    if scale is not None:
        base = scale.utc(t0)
        ax.xaxis.set_major_locator(ClockLocator(day_seconds(base)))
        ax.xaxis.set_major_formatter(ClockFormatter(base))


def t0_note(t0: float) -> str:
    """One-line footnote naming t0: its UTC instant and raw range time when the calendar is
    known, else its raw range time with a word on the unknown calendar."""
    scale = _scale_of(t0)
    if scale is None:
        return (f"t0 = {float(t0):.3f} s on the range time scale; calendar date unknown "
                "(set [output] epoch for UTC)")
    return f"t0 = {scale.clock(t0)} ({float(t0):.3f} s on the range time scale)"


def new_figure(width_in: float, height_in: float) -> Figure:
    """A pyplot-free Agg figure of the given size (inches)."""
    fig = Figure(figsize=(width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as a palette PNG to ``path`` atomically (temp file beside it, then replace).

    The figure is left to the garbage collector afterwards (``Figure.clear`` rebuilt every
    axis's ticks on its way out: a tenth of a figure's drawing time). No temp file survives
    an exception.
    """
    path = Path(path)
    limit_ticks(fig)
    with atomic_path(path) as tmp:            # a failure in either step names ``path``
        buf = io.BytesIO()
        fig.savefig(buf, format="rgba", dpi=DPI)  # raw RGBA pixels: no PNG encode/decode
        width, height = fig.canvas.get_width_height(physical=True)
        rgba = np.frombuffer(buf.getbuffer(), dtype=np.uint8).reshape(height, width, 4)
        write_palette_png(rgba, tmp)
    return path


#: Most major tick intervals of a linear axis (time / x, value / y) left to matplotlib's
#: default locator. Its "auto" count gave 8-12 per axis; every tick is six artists built
#: and drawn (7 % of the report's drawing time went to the ones this removes).
MAX_TICKS_X, MAX_TICKS_Y = 7, 5


def limit_ticks(fig: Figure) -> None:
    """Give every linear axis of ``fig`` still on matplotlib's default locator at most
    :data:`MAX_TICKS_X` / :data:`MAX_TICKS_Y` intervals at 1-2-2.5-5 steps (axes that
    chose their ticks, log axes and shared axes' own choices are left alone)."""
    from matplotlib.ticker import AutoLocator, MaxNLocator

    for ax in fig.axes:
        for axis, nbins in ((ax.xaxis, MAX_TICKS_X), (ax.yaxis, MAX_TICKS_Y)):
            if type(axis.get_major_locator()) is AutoLocator:
                axis.set_major_locator(MaxNLocator(nbins=nbins, steps=[1, 2, 2.5, 5, 10]))


def write_palette_png(rgba: np.ndarray, dst: Path) -> None:
    """Encode an (H, W, 4) uint8 image as a 256-colour palette PNG at ``dst``.

    Plots hold few colours, so this is visually lossless and about 3x smaller than RGBA.
    """
    from PIL import Image, PngImagePlugin

    height, width = rgba.shape[:2]     # alpha dropped by PIL's raw decoder (7x faster than
    rgb = Image.frombytes("RGB", (width, height),   # a strided NumPy copy of the RGB planes)
                          np.ascontiguousarray(rgba), "raw", "RGBX")
    pal = rgb.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", "rangeproc")
    pal.save(dst, format="png", compress_level=3, pnginfo=info)   # 2.6x faster than 6, +12 %


_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def safe_name(name: str) -> str:
    """A file-name-safe form of an id: runs of other characters become ``_``
    ('S 1/a' -> 'S_1_a')."""
    out = _UNSAFE.sub("_", name).strip("._")
    return out or "unnamed"


def decimate_indices(y: np.ndarray, *, max_points: int = MAX_POINTS,
                     keep: np.ndarray | None = None) -> np.ndarray:
    """Indices (ascending) of the points of a time-ordered series worth drawing.

    y: (N,) values in time order. keep: (N,) bool, points always returned when y is finite
    (rejected points: every one is drawn). Of the other finite points at most ``max_points``
    are returned: an even stride through the series (keeps the density) plus the minimum and
    maximum of equal-count time buckets (keeps the envelope, so spikes are never thinned away).
    Non-finite y are never returned.
    """
    y = np.asarray(y, dtype=float).reshape(-1)
    finite = np.isfinite(y)
    keep_mask = np.zeros(y.size, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    always = np.flatnonzero(finite & keep_mask)
    cand = np.flatnonzero(finite & ~keep_mask)
    m = cand.size
    if m > max_points:
        yc = y[cand]
        nb = max(1, max_points // 20)
        k = m // nb
        blocks = yc[: nb * k].reshape(nb, k)
        base = np.arange(nb) * k
        ext = np.concatenate([base + blocks.argmin(axis=1), base + blocks.argmax(axis=1)])
        stride = np.linspace(0, m - 1, max_points - 2 * nb).astype(np.int64)
        cand = cand[np.unique(np.concatenate([ext, stride]))]
    return np.union1d(cand, always).astype(np.int64)


def stride_indices(n: int, max_points: int) -> np.ndarray:
    """Evenly spaced indices 0..n-1 (first and last included), at most ``max_points``."""
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_points).astype(np.int64))


def break_gaps(t: np.ndarray, *ys: np.ndarray, factor: float = 3.0) -> tuple[np.ndarray, ...]:
    """Insert NaN between samples farther apart than ``factor`` x the median spacing.

    t: (K,) ascending; ys: (K, ...) arrays. Returns (t', *ys') with NaN rows at gaps so that
    lines are not drawn across data gaps.
    """
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return (t, *ys)
    dt = np.diff(t)
    pos = dt[dt > 0]
    if pos.size == 0:
        return (t, *ys)
    gaps = np.flatnonzero(dt > factor * np.median(pos)) + 1
    if gaps.size == 0:
        return (t, *ys)
    out = [np.insert(t, gaps, np.nan)]
    for y in ys:
        y = np.asarray(y, dtype=float)
        out.append(np.insert(y, gaps, np.nan, axis=0))
    return tuple(out)


def display_unit(unit: str) -> tuple[float, str]:
    """(scale, label) to show an SI quantity: radians as mrad, seconds (latencies) as ms,
    everything else unchanged."""
    table = {"rad": (1.0e3, "mrad"), "rad/s": (1.0e3, "mrad/s"), "s": (1.0e3, "ms"),
             "m": (1.0, "m"), "m/s": (1.0, "m/s"), "m/s^2": (1.0, "m/s²")}
    return table.get(unit, (1.0, unit))


def true_runs(flag: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start, stop) index arrays of the runs of True in ``flag`` (N,): run k is
    ``flag[start[k]:stop[k]]`` (stop exclusive)."""
    edge = np.diff(np.concatenate([[0], np.asarray(flag).astype(np.int8), [0]]))
    return np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)


def n_sensors_colormap(n_max: int) -> tuple[ListedColormap, BoundaryNorm]:
    """Discrete colour map for n_sensors 0..n_max: 0 (coasting, no data) red, then viridis."""
    import matplotlib

    n_max = max(int(n_max), 1)
    base = matplotlib.colormaps["viridis"]
    colors = [REJECT_COLOR] + [base(x) for x in np.linspace(0.05, 0.95, n_max)]
    cmap = ListedColormap(colors, name="n_sensors")
    norm = BoundaryNorm(np.arange(-0.5, n_max + 1.0), cmap.N)
    return cmap, norm


def binned_extreme(t: np.ndarray, v: np.ndarray, edges: np.ndarray,
                   how: str = "max") -> np.ndarray:
    """Per-bin max (or min) of v over time bins; NaN where a bin has no finite value.

    t: (N,) ascending; v: (N,); edges: (B+1,) ascending bin edges. Returns (B,).
    """
    nb = edges.size - 1
    out = np.full(nb, np.nan)
    ok = np.isfinite(v) & (t >= edges[0]) & (t <= edges[-1])
    t, v = t[ok], v[ok]
    if t.size == 0 or nb < 1:
        return out
    starts = np.searchsorted(t, edges[:-1], side="left")
    stops = np.searchsorted(t, edges[1:], side="left")
    stops[-1] = np.searchsorted(t, edges[-1], side="right")
    nonempty = stops > starts
    ufunc = np.fmax if how == "max" else np.fmin
    if nonempty.any():
        # bins are contiguous and empty ones hold no points, so each reduceat slice is one bin
        out[nonempty] = ufunc.reduceat(v, starts[nonempty])
    return out


def log_axis(ax: Axes, axis: str = "y") -> None:
    """Log scale with plain-number tick labels at 1-2-3-5 steps (no 2x10^1 labels)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    getattr(ax, f"set_{axis}scale")("log")
    a = ax.yaxis if axis == "y" else ax.xaxis
    a.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 3.0, 5.0)))
    a.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    a.set_minor_formatter(NullFormatter())


#: n_sensors is drawn as its maximum over this window (s): a 1 Hz sensor in a 10 Hz output
#: grid contributes to one epoch in ten, and would otherwise make the colour flicker.
N_SENSORS_WINDOW = 1.0


def n_sensors_running_max(time: np.ndarray, n_sensors: np.ndarray,
                          window: float = N_SENSORS_WINDOW) -> np.ndarray:
    """(K,) float: the largest n_sensors within a centred ``window`` (s) of each epoch.

    time: (K,) s, ascending uniform grid (the median step sets the window length in epochs).
    """
    from scipy.ndimage import maximum_filter1d

    ns = np.asarray(n_sensors, dtype=float)
    dt = np.diff(np.asarray(time, dtype=float))
    dt = dt[dt > 0]
    if ns.size < 2 or dt.size == 0:
        return ns
    size = int(round(window / float(np.median(dt))))
    return maximum_filter1d(ns, size, mode="nearest") if size > 1 else ns
