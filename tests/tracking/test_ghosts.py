"""Multipath ghosts: a plot track that follows a nearer boat's bearing further out is clutter;
a boat that crosses behind another for a few scans is kept (``tracking.ghosts``)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import rangeproc.tracking.synthesis as synthesis
from rangeproc.pipeline import run
from rangeproc.tracking.ghosts import GHOST_SHARE, ghost_tracks, shadowed
from rangeproc.tracking.plot_tracker import plot_timing, track_plots
from rangeproc.tracking.plots import plot_positions

SCAN = 2.5                                    # s, a harbour radar's revisit
SIGMA = np.array([5.0, np.radians(2.0), np.nan])   # range m, azimuth rad, no elevation


def _path(who: str, t: np.ndarray) -> np.ndarray:
    """(N, 2) east, north (m) of boat A, its ghost G or boat B at times t (s)."""
    a = np.column_stack([-90.0 + 3.0 * t, np.full(t.size, 120.0)])
    if who == "A":
        return a
    if who == "G":
        return a / np.linalg.norm(a, axis=1)[:, None] * (400.0 + 1.0 * t)[:, None]
    return np.column_stack([300.0 - 4.0 * t, 250.0 - 1.0 * t])


def _scene(seed: int = 3) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Plots of a framed surface radar at the origin over 60 scans: boat A at 150 m crossing
    the bearing at 3 m/s; a ghost of A on A's bearing at 400 m, drifting 1 m/s outward
    (every scan A is seen in); boat B at 300 m crossing behind A between scans 25 and 35 and
    far from its bearing else; sea clutter, 3 plots a scan over 1 km^2. Returns the plots
    (t, range, azimuth, elevation) and the truth per plot ("A", "G", "B", "")."""
    rng = np.random.default_rng(seed)
    cols: dict[str, list] = {"t": [], "r": [], "az": [], "who": []}

    def add(t: float, e: float, n: float, who: str, r_extra: float = 0.0) -> None:
        r = np.hypot(e, n) + r_extra
        cols["t"].append(t)
        cols["r"].append(r + rng.normal(0.0, SIGMA[0]))
        cols["az"].append(np.arctan2(e, n) + rng.normal(0.0, SIGMA[1]))
        cols["who"].append(who)

    for k in range(60):
        t = k * SCAN
        tt = np.array([t])
        if rng.random() < 0.9:                       # boat A, east at 3 m/s
            add(t, *_path("A", tt)[0], "A")
            if rng.random() < 0.9:                   # A's ghost, on its bearing, further out
                add(t, *_path("G", tt)[0], "G")
        if rng.random() < 0.9:                       # boat B, crossing behind A
            add(t, *_path("B", tt)[0], "B")
        for _ in range(rng.poisson(3.0)):
            add(t, *rng.uniform(-500.0, 500.0, 2), "")
    plots = {k: np.asarray(v, dtype=float) for k, v in cols.items() if k != "who"}
    return plots, np.asarray(cols["who"])


def _labels(plots: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plot tracker's labels, the plots' frames and sigmas (N, 3)."""
    n = plots["t"].size
    sig = np.tile(SIGMA, (n, 1))
    p, R = plot_positions(plots["r"], plots["az"], np.full(n, np.nan), sig,
                          np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
    timing = plot_timing(plots["t"], plots["az"], p, R, planar=True)
    label = track_plots(plots["t"], p, R, timing.frame, timing.clock, True,
                        timing.stamp_sigma)
    return label, timing.frame, sig


def _tracks_of(label: np.ndarray, who: np.ndarray) -> dict[str, int]:
    """Truth name -> the number of tracks holding mostly its plots."""
    out: dict[str, int] = {}
    for k in np.unique(label[label >= 0]):
        names, counts = np.unique(who[label == k], return_counts=True)
        top = str(names[np.argmax(counts)])
        out[top] = out.get(top, 0) + 1
    return out


def test_a_ghost_on_a_near_boats_bearing_is_confirmed_by_the_track_score() -> None:
    """The negative control: the plot tracker alone follows the ghost as it does a boat."""
    plots, who = _scene()
    label, _, _ = _labels(plots)
    tracks = _tracks_of(label, who)
    assert tracks.get("G", 0) >= 1 and tracks.get("A", 0) >= 1 and tracks.get("B", 0) >= 1


def test_the_ghost_track_is_clutter_and_both_boats_keep_their_tracks() -> None:
    plots, who = _scene()
    label, frame, sig = _labels(plots)
    out, ghosts = ghost_tracks(frame, plots["r"], plots["az"], np.full(who.size, np.nan),
                               sig, label, planar=True)
    tracks = _tracks_of(out, who)
    assert ghosts >= 1 and "G" not in tracks
    assert tracks.get("A", 0) >= 1 and tracks.get("B", 0) >= 1
    # every plot of A and B the tracker gave a track keeps one, and the labels stay 0..K-1
    boats = np.isin(who, ["A", "B"])
    assert ((out >= 0) == (label >= 0))[boats].all()
    assert set(np.unique(out[out >= 0])) == set(range(int(out.max()) + 1))
    # B crossed behind A for a few scans: some of its plots are shadowed, not most
    b_track = np.bincount(label[(who == "B") & (label >= 0)]).argmax()
    mine = label == b_track
    behind = shadowed(frame, plots["r"], plots["az"], np.full(who.size, np.nan), sig,
                      label, True)
    assert 0.0 < behind[mine].mean() < GHOST_SHARE


def test_no_ghost_without_a_nearer_track_on_the_line_of_sight() -> None:
    """Elevation counts where it is measured: a track behind another in azimuth but 5 sigma
    apart in elevation is no ghost; with a planar sensor it would be."""
    n = 20
    frame = np.repeat(np.arange(n), 2)
    label = np.tile([0, 1], n)
    rng = np.tile([150.0, 400.0], n)
    az = np.full(2 * n, 0.3)
    el = np.tile([0.01, 0.01 + 5.0 * np.sqrt(2.0) * 0.002], n)
    sig = np.tile([5.0, 0.002, 0.002], (2 * n, 1))
    out, ghosts = ghost_tracks(frame, rng, az, el, sig, label, planar=False)
    assert ghosts == 0 and (out == label).all()
    out, ghosts = ghost_tracks(frame, rng, az, el, sig, label, planar=True)
    assert ghosts == 1 and (out == np.tile([0, -1], n)).all()


def _write_scene(folder) -> None:
    """The scene of :func:`_scene` as a recording: a radar on a ferry lying still at the
    range origin (north-up), one time stamp per scan, no elevation."""
    plots, _ = _scene()
    t0 = 1.7e9
    t = np.arange(-2.0, plots["t"].max() + 2.0, 0.1)
    pd.DataFrame({"time": t0 + t, "roll": 0.0, "pitch": 0.0, "yaw": 0.0, "lat": 60.0,
                  "lon": 10.0, "height": 0.0}).to_csv(folder / "FERRY.csv", index=False)
    pd.DataFrame({"time": t0 + plots["t"], "range": plots["r"],
                  "azimuth": np.degrees(np.mod(plots["az"], 2.0 * np.pi)),
                  "elevation": np.nan}).to_csv(folder / "RADAR.csv", index=False)
    (folder / "scenario.toml").write_text(
        '[range]\norigin = { lat = 60.0, lon = 10.0, height = 0.0 }\n\n'
        '[output]\ndir = "out"\nrate_hz = 1.0\n\n'
        '[[sensors]]\nid = "FERRY"\nkind = "ins"\nfile = "FERRY.csv"\nangle_unit = "deg"\n'
        'sigma = { roll = 0.01, pitch = 0.01, yaw = 0.01, position = 0.1 }\n\n'
        '[[sensors]]\nid = "RADAR"\nkind = "radar"\nfile = "RADAR.csv"\n'
        'platform = "FERRY"\nlever_arm = [0.0, 0.0, 0.0]\nangle_unit = "deg"\n'
        'sigma = { range = 5.0, azimuth = 2.0, elevation = 2.0 }\n')


def _written(folder) -> dict[str, str]:
    """Output object -> the truth ("A", "B", "G") it follows (median distance under 30 m),
    or "" for none."""
    fused = pd.read_parquet(folder / "out" / "fused.parquet")
    out = {}
    for obj, g in fused.groupby("target_id"):
        t = g.time.to_numpy() - 1.7e9
        dist = {w: float(np.median(np.hypot(*(g[["e", "n"]].to_numpy() - _path(w, t)).T)))
                for w in "ABG"}
        best = min(dist, key=dist.get)
        out[str(obj)] = best if dist[best] < 30.0 else ""
    return out


@pytest.mark.parametrize("rule", [True, False], ids=["ghost rule", "negative control"])
def test_a_radar_only_scene_writes_the_boats_and_not_the_ghost(tmp_path, monkeypatch,
                                                               rule) -> None:
    """End to end, a scanning radar alone: both boats are written, the ghost is not; without
    the ghost rule (the negative control) the ghost is written as a third object."""
    _write_scene(tmp_path)
    if not rule:
        monkeypatch.setattr(synthesis, "ghost_tracks", lambda *a, **k: (a[5].copy(), 0))
    run(tmp_path / "scenario.toml")
    written = sorted(_written(tmp_path).values())
    if rule:
        assert written == ["A", "B"]                 # the boats, nothing else
    else:
        assert "A" in written and "B" in written and "G" in written
