"""The clutter map (tracking.clutter_map): a moving object's own plots are not its clutter; a
stationary return's are."""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.clutter_map import CLUTTER_OWN_SCANS, clutter_density


def _scene(seed: int = 2):
    """40 scans of a planar sensor (plot sigma 5 m): 5 clutter plots a scan over 1 km^2, a
    boat at 2 m/s (5 m a scan, 3 plots in a 15 m cell) and a quay return in every scan.
    (p, R, clock, kind): kind 0 clutter, 1 boat, 2 quay."""
    rng = np.random.default_rng(seed)
    p, clock, kind = [], [], []
    for k in range(40):
        p.append([-100.0 + 5.0 * k + rng.normal(0, 5), 200.0 + rng.normal(0, 5), 0.0])
        clock.append(k), kind.append(1)
        p.append([300.0 + rng.normal(0, 2), -300.0 + rng.normal(0, 2), 0.0])
        clock.append(k), kind.append(2)
        for _ in range(rng.poisson(5)):
            p.append(rng.uniform([-500.0, -500.0, 0.0], [500.0, 500.0, 0.0]))
            clock.append(k), kind.append(0)
    R = np.tile(np.diag([25.0, 25.0, 1e4]), (len(p), 1, 1))
    return np.array(p), R, np.array(clock, dtype=float), np.array(kind)


def test_a_moving_objects_own_plots_are_not_its_clutter():
    p, R, clock, kind = _scene()
    sea = 5.0 / 1e6                                          # clutter plots / scan / m^2
    with_own = clutter_density(p, R, 40.0, True)
    without = clutter_density(p, R, 40.0, True, clock)
    boat, quay = kind == 1, kind == 2
    # the negative control: counted with its own plots, the boat's cells look 10-100 times
    # denser than the sea it sails on
    assert np.median(with_own[boat]) > 10 * sea
    assert np.median(without[boat]) < 3 * sea
    # a quay return, in every scan, keeps its density, far above the sea's
    assert np.median(without[quay]) > 20 * sea
    assert abs(np.median(without[quay]) / np.median(with_own[quay]) - 1.0) < 0.2
    assert CLUTTER_OWN_SCANS >= 3
