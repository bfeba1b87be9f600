"""The track start from the first position fixes (``fusion.initialise.initial_state``)."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.initialise import initial_state

SIG = np.array([39.0, 0.002, 0.004])            # a surveillance radar's plot (m, rad, rad)


def _plots(t: np.ndarray, p: np.ndarray, rng: np.random.Generator, plot_batch):
    """Range/azimuth/elevation plots (site at the origin) of positions ``p`` (N, 3) m."""
    r = np.linalg.norm(p, axis=1)
    rae = np.column_stack([r, np.mod(np.arctan2(p[:, 0], p[:, 1]), 2 * np.pi),
                           np.arcsin(p[:, 2] / r)]) + rng.normal(size=(t.size, 3)) * SIG
    return plot_batch(t, rae, SIG)


def _track(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    start, v = np.array([10_000.0, -27_000.0, 7_000.0]), np.array([250.0, 120.0, -5.0])
    return start + t[:, None] * v, v


def test_a_clutter_plot_first_does_not_lean_the_start(plot_batch) -> None:
    """A 4 s scan: the first plot is clutter 4.7 km away, 11.8 s before the object's own.
    The Huber line leaned the velocity by hundreds of m/s (the gate then rejected the
    object's plots and the track left for a thousand kilometres); the redescending fit
    ignores the clutter plot."""
    rng = np.random.default_rng(7)
    t = np.array([0.0, 11.8, 15.8, 19.8, 23.8, 27.8])
    p, v = _track(t)
    p[0] += np.array([-3_000.0, 3_500.0, -1_200.0])
    x0, P0 = initial_state(_plots(t, p, rng, plot_batch), 0.0)
    assert np.linalg.norm(x0[3:6] - v) < 15.0, x0[3:6]
    assert np.linalg.norm(x0[:3] - _track(t[:1])[0][0]) < 300.0


def test_clean_fixes_keep_the_huber_line(monkeypatch, plot_batch) -> None:
    """Without a gross outlier the start is the Huber fit, as before (the redescending fit
    is not reached), and with the clutter plot it is (the first test's case)."""
    from rangeproc.fusion import initialise

    calls = []
    real = initialise._redescending_line
    monkeypatch.setattr(initialise, "_redescending_line",
                        lambda *a: calls.append(1) or real(*a))
    rng = np.random.default_rng(8)
    t = np.array([0.0, 11.8, 15.8, 19.8, 23.8, 27.8])
    p, v = _track(t)
    x0, _ = initial_state(_plots(t, p, rng, plot_batch), 0.0)
    assert np.linalg.norm(x0[3:6] - v) < 15.0 and not calls
    p[0] += np.array([-3_000.0, 3_500.0, -1_200.0])
    initial_state(_plots(t, p, rng, plot_batch), 0.0)
    assert calls
