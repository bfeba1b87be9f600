"""An object first seen beside another, within its radar's resolution and moving with it: its
span before, along the other's trajectory plus their offset, bridged (fusion.formation)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.formation import formation_spans, plot_cell
from rangeproc.results import TrackEstimate
from rangeproc.settings import Geodetic

FRAME = RangeFrame(Geodetic(lat=63.4, lon=10.4, height=0.0))
RATE = 5.0                                   # Hz, the output grid
STATED = np.array([[5.0, np.radians(2.0), np.nan]])      # one radar: range m, azimuth rad


def _track(name: str, t: np.ndarray, start: np.ndarray, v: np.ndarray,
           sigma_v: float = 0.5) -> TrackEstimate:
    """A straight track from ``start`` (E, N m) at velocity v (m/s) over times t (s), position
    sigma 2 m, velocity sigma ``sigma_v``."""
    x = np.zeros((t.size, 9))
    x[:, :2] = start + (t - t[0])[:, None] * v
    x[:, 3:5] = v
    P = np.tile(np.diag([4.0, 4.0, 4.0] + [sigma_v ** 2] * 3 + [1.0] * 3), (t.size, 1, 1))
    lat, lon, h = FRAME.to_geodetic(x[:, :3])
    return TrackEstimate(name, t, x, P, np.ones(t.size, np.int64), lat, lon, h,
                         data_gap=np.zeros(t.size))


def _radar_rows(track: TrackEstimate) -> SimpleNamespace:
    """The fusion result's batch of ``track``: one radar row a second from the origin."""
    t = track.time[::5]
    p = track.x[::5, :2]
    z = np.full((t.size, 6), np.nan)
    z[:, 0] = np.hypot(p[:, 0], p[:, 1])
    z[:, 1] = np.arctan2(p[:, 0], p[:, 1])
    return SimpleNamespace(batch=SimpleNamespace(t=t, z=z, sensor=np.zeros(t.size, int),
                                                 Qr=np.tile(np.eye(3), (t.size, 1, 1))))


def _scene(offset: float, dv: float, sigma_v: float = 0.5):
    """Boat A at 2 m/s north from 150 m east over 60 s; boat B ``offset`` m east of it, seen
    from 40 s on, ``dv`` m/s faster."""
    t = np.arange(0.0, 60.0, 1.0 / RATE)
    a = _track("A", t, np.array([150.0, 0.0]), np.array([0.0, 2.0]))
    tb = t[t >= 40.0]
    b = _track("B", tb, np.array([150.0 + offset, 80.0]), np.array([0.0, 2.0 + dv]), sigma_v)
    return [a, b], {"A": _radar_rows(a), "B": _radar_rows(b)}


def test_a_boat_hidden_beside_another_is_written_along_it():
    tracks, results = _scene(offset=10.0, dv=0.1)
    a, b = formation_spans(tracks, results, FRAME, RATE, 100.0, STATED)
    assert a is tracks[0]                                 # B ends with A: nothing beyond
    assert b.time[0] == 0.0 and b.time.size == 300       # its whole hidden span
    hidden = b.time < 40.0
    assert np.allclose(b.x[hidden, 0], 160.0) and np.allclose(b.x[hidden, 1], 2.0 * b.time[hidden])
    assert (b.data_gap[hidden] > 1.0).sum() == hidden.sum() - 5     # bridged, not measured
    sigma = np.sqrt(b.P[hidden, 0, 0])
    assert (np.diff(sigma) <= 0.0).all() and sigma[0] > sigma[-1]   # growing away from t0
    assert (b.n_sensors[hidden] == 0).all()


def test_the_relative_velocity_bounds_the_span():
    # 0.5 m/s apart: a resolution (27 m: the 99 % gate of two plots' noise, 5 m x 6.2 m at
    # 179 m) in 54 s, held to the bridging limit of 20 s
    tracks, results = _scene(offset=10.0, dv=0.5)
    b = formation_spans(tracks, results, FRAME, RATE, 20.0, STATED)[1]
    assert b.time[0] == 20.0
    # 2 m/s apart (inside the velocity gate of a poorly known start): a few seconds only
    tracks, results = _scene(offset=10.0, dv=2.0, sigma_v=2.0)
    b = formation_spans(tracks, results, FRAME, RATE, 100.0, STATED)[1]
    assert 25.0 < b.time[0] < 40.0


def test_resolved_or_diverging_neighbours_are_not_a_formation():
    tracks, results = _scene(offset=60.0, dv=0.1)          # 60 m apart: resolved
    assert formation_spans(tracks, results, FRAME, RATE, 100.0, STATED)[1] is tracks[1]
    tracks, results = _scene(offset=10.0, dv=3.0)          # 3 m/s apart, well known
    assert formation_spans(tracks, results, FRAME, RATE, 100.0, STATED)[1] is tracks[1]
    tracks, _ = _scene(offset=10.0, dv=0.1)                 # no radar row: no resolution
    assert formation_spans(tracks, {}, FRAME, RATE, 100.0, STATED)[1] is tracks[1]


def test_the_cell_lies_along_the_line_of_sight_of_a_turned_platform():
    """A radar on a deck heading east measures azimuth from the bow: a boat 500 m north lies at
    -90 deg in the radar's axes. Its cell is long across the line of sight (500 m x 2 deg =
    17 m) and short along it (5 m): along north, not along the deck's west."""
    heading_east = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # ENU -> deck
    d = heading_east @ np.array([0.0, 500.0, 0.0])
    z = np.full((1, 6), np.nan)
    z[0, 0], z[0, 1] = 500.0, np.arctan2(d[0], d[1])
    rows = SimpleNamespace(batch=SimpleNamespace(t=np.zeros(1), z=z, sensor=np.zeros(1, int),
                                                 Qr=heading_east[None]))
    cell = plot_cell(rows, 0.0, STATED)
    north = np.array([0.0, 1.0])
    assert abs(np.sqrt(north @ cell @ north) - 5.0) < 1e-9
    east = np.array([1.0, 0.0])
    assert abs(np.sqrt(east @ cell @ east) - 500.0 * np.radians(2.0)) < 1e-9
