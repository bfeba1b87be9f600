"""The forward filter ``filter = "auto"`` chooses for one object (the default).

The constant-acceleration EKF with its iterated smoother (``filter = "ekf"``) for every object
with a position-bearing measurement (a GPS fix, a radar or theodolite angle, a range); the
self-adaptive spline filter and its batch B-spline fit (``filter = "spline"``, Zhou et al.)
for an object measured by range rates alone (MISTRAM, a radar's Doppler). There the position
is observed only through the change of the geometry, most weakly along the vertical from
stations on the ground: on six simulated flights with MISTRAM alone, started from a given
state, the EKF smoother reached 0.96-6.4 times the position error of the better of the two
smoothers told the true noise and wild points (its relinearised passes settle on a vertical
off by tens of metres on two of them, whatever the passes or the process noise), the spline
fit 0.77-1.25 times (``docs/methods/estimators.md``, range rates alone).
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch

#: Component index of a range rate in the spherical model's rows ``[R, A, E, Rdot]``.
RANGE_RATE = 3


def range_rates_only(batch: MeasurementBatch) -> bool:
    """True when every measured component of ``batch`` is a range rate (and there is one)."""
    measured = np.isfinite(batch.z)
    return bool(measured[:, RANGE_RATE].any()) and not np.delete(measured, RANGE_RATE,
                                                                   axis=1).any()


def choose_filter(configured: str, batch: MeasurementBatch) -> tuple[str, str]:
    """(the filter to run, why) for ``processing.filter = configured`` on ``batch``."""
    if configured != "auto":
        return configured, "configured"
    if range_rates_only(batch):
        return "spline", ("auto: range rates alone observe the position weakly; the batch "
                          "spline fit comes nearest the bound there")
    return "ekf", "auto: position-bearing measurements"
