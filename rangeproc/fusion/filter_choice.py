"""The estimator ``filter = "auto"`` chooses for one object (the default).

The constant-acceleration EKF with its iterated smoother (``filter = "ekf"``) for every object
with a position-bearing measurement (a GPS fix, a radar or theodolite angle, a range). For an
object measured by range rates alone (MISTRAM, a radar's Doppler) the same EKF passes (their
editing, noise and burst estimates, process noise), then the batch cubic B-spline fit of
``fusion.spline_refine`` (Zhou et al. 2001: offline processing by batch estimation on a
spline trajectory) on the final pass's track and sigmas, :data:`EKF_SPLINE_FIT`.

From range rates the position is observed only through the change of the geometry, most
weakly along the vertical from stations on the ground. The EKF's relinearised smoother can
settle on a vertical off by tens of metres there (on two of six simulated flights with
MISTRAM alone it reached 1.5 and 6.4 times the position error of a smoother told the true
noise and wild points); the batch fit, whose knots tie the whole flight together, does not.
The self-adaptive spline filter's own passes, the other way to that fit (``filter =
"spline"``), do not survive a noise burst on every station: its smoothed residuals across
the burst inflated the estimated noise 30-fold and the fit that followed reached 2.6 times
the bound, while the EKF's passes find the burst (``fusion.noise``) and the fit on their
sigmas reaches 1.1 times (``docs/methods/estimators.md``, range rates alone).
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch

#: Component index of a range rate in the spherical model's rows ``[R, A, E, Rdot]``.
RANGE_RATE = 3
#: What ``filter = "auto"`` runs for an object measured by range rates alone.
EKF_SPLINE_FIT = "ekf+spline-fit"


def range_rates_only(batch: MeasurementBatch) -> bool:
    """True when every measured component of ``batch`` is a range rate (and there is one)."""
    measured = np.isfinite(batch.z)
    return bool(measured[:, RANGE_RATE].any()) and not np.delete(measured, RANGE_RATE,
                                                                   axis=1).any()


def choose_filter(configured: str, batch: MeasurementBatch) -> tuple[str, str]:
    """(what runs, why) for ``processing.filter = configured`` on ``batch``: the configured
    filter, or "auto"'s choice: ``"ekf"`` or :data:`EKF_SPLINE_FIT` (module docstring)."""
    if configured != "auto":
        return configured, "configured"
    if range_rates_only(batch):
        return EKF_SPLINE_FIT, ("auto: range rates alone observe the position weakly; the "
                                "EKF's passes (editing, noise, bursts), then the batch spline "
                                "fit of the whole flight")
    return "ekf", "auto: position-bearing measurements"
