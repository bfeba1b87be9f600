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

The spline filter does not survive everything the EKF does: with a noise burst on every
station (x10 for 10 s) its passes diverged to kilometres on one of those flights while the
EKF kept 1.5 m. So "auto" also runs the EKF smoother on an object it gives the spline fit and
keeps the spline result only where both agree within their uncertainty
(:func:`spline_or_ekf`): the mean over the output epochs of the squared Mahalanobis distance
of their positions, ``d^T (P_spline + P_ekf)^-1 d``, at most :data:`AGREE` (the spline fit's
gain over the EKF there is within its uncertainty; a diverged track is far outside it).
"""
from __future__ import annotations

import numpy as np

from typing import Any

from rangeproc.estimation.linalg import unpack_many
from rangeproc.fusion.batch import MeasurementBatch

#: Component index of a range rate in the spherical model's rows ``[R, A, E, Rdot]``.
RANGE_RATE = 3
#: Largest mean squared Mahalanobis distance (3 dof) between the spline and EKF positions
#: at which the spline result is kept (a 3-sigma agreement on average).
AGREE = 9.0


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


def spline_or_ekf(spline: Any, ekf: Any) -> tuple[Any, str, str]:
    """The spline result when its positions agree with the EKF smoother's within their
    uncertainty (module docstring), else the EKF's: (result, filter, why); both are
    ``fusion.centralised.FusionResult`` of the same rows (centralised imports this module)."""
    ok = (spline.grid.sum() == ekf.grid.sum() and np.array_equal(spline.epoch_t, ekf.epoch_t))
    m2 = np.inf
    if ok:
        d = spline.xs[spline.grid, :3] - ekf.xs[ekf.grid, :3]
        n = spline.xs.shape[1]
        C = unpack_many(spline.Ps[spline.grid], n, 3) + unpack_many(ekf.Ps[ekf.grid], n, 3)
        m2 = float(np.mean(np.einsum("ni,ni->n", d, np.linalg.solve(C, d[:, :, None])[:, :, 0])))
    if m2 <= AGREE:
        return spline, "spline", ("auto: range rates alone observe the position weakly; the "
                                  f"batch spline fit comes nearest the bound there (it agrees "
                                  f"with the EKF smoother: Mahalanobis^2 {m2:.2g})")
    return ekf, "ekf", ("auto: range rates alone; the spline filter strays from the EKF "
                        f"smoother (Mahalanobis^2 {m2:.3g}, a noise burst or wild rows it did "
                        "not survive): the EKF smoother")
