"""A span's lead-in: the rows before its first position fix, estimated backwards in time.

A track starts from its first position fixes (``fusion.initialise``). When angle-only or
range-rate rows come long before them (a theodolite that acquires an object half a minute
before the radar does), starting at the first row means extrapolating the start back over
that time from a few seconds of fixes: a velocity error of a few m/s becomes hundreds of
metres and a manoeuvre kilometres, which the stated prior does not cover. The angles then
pull the state along their lines of sight, the gate rejects the radar when it arrives, and
the estimate may leave for good (a lead-in of half a minute around a turn: 1e8 m).

Instead the span is started at its first fix, where the fixes start it well, and the rows
before it are filtered and smoothed backwards in time from the smoothed state there: time
reversal ``t' = -t`` keeps positions and accelerations and negates velocities (state
``[p, -v, a]``, sensor velocity ``-sv``) and with them every rate a row measures (a range
rate, a GPS velocity), so the same measurement models and kernels run unchanged. The
smoothed state at the fix conditions on every row after it, so the lead-in's estimate is the
smoother's given the lead-in's rows and everything after them. (The rows of the lead-in do not
feed back into the estimate after the fix; angle-only rows add little there.)
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.initialise import Prior, fix_rows
from rangeproc.models.measurement import SPHERICAL
from rangeproc.models.motion import N_KINEMATIC

#: A lead-in shorter than this (s) is left to the forward start (the track start's fixes
#: cover 4 s: ``initial_state``'s window); a longer one is estimated backwards.
LEAD_IN_S = 4.0


def lead_in_rows(batch: MeasurementBatch) -> int:
    """Rows of ``batch`` before the time of its first position fix when they span more than
    :data:`LEAD_IN_S` seconds before it, else 0 (also when the batch has under two fixes:
    its start is then the prior's or impossible, not a lead-in). Rows at the fix's time
    belong to the rest."""
    rows = fix_rows(batch)
    if len(rows) < 2:
        return 0
    t_fix = batch.t[rows[0]]
    return int(np.searchsorted(batch.t, t_fix)) if t_fix - batch.t[0] > LEAD_IN_S else 0


def negate_rates(values: np.ndarray, model: np.ndarray) -> np.ndarray:
    """A copy of per-row components ``values`` (N, 6) with the rates negated: a spherical
    row's range rate (component 3), a Cartesian row's velocity (components 3-5)."""
    out = np.array(values, dtype=np.float64, copy=True)
    sph = model == SPHERICAL
    out[sph, 3] *= -1.0
    out[~sph, 3:6] *= -1.0
    return out


def time_reversed(batch: MeasurementBatch) -> MeasurementBatch:
    """The rows in reverse order at times ``-t`` with every rate negated (measured rates and
    the sensors' velocities). Its own inverse."""
    def rev(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(a[::-1])

    model = rev(batch.model)
    return MeasurementBatch(rev(-batch.t), model, negate_rates(rev(batch.z), model),
                            rev(batch.sigma), rev(batch.s), rev(-batch.sv), rev(batch.Qr),
                            rev(batch.sensor), rev(batch.source_row), rev(batch.station),
                            rev(batch.track), batch.sensor_ids)


def _velocity_signs(n: int) -> np.ndarray:
    """(n,) +1, with -1 on the velocity block of the kinematic state."""
    sign = np.ones(n)
    sign[3:6] = -1.0
    return sign


def reversed_prior(t: float, x: np.ndarray, P: np.ndarray) -> Prior:
    """The kinematic state ``x`` (n,) with covariance ``P`` (n, n) at time ``t`` (s) as the
    prior of a time-reversed filter: at ``-t``, velocity negated."""
    sign = _velocity_signs(N_KINEMATIC)
    return Prior(-float(t), x[:N_KINEMATIC] * sign,
                 P[:N_KINEMATIC, :N_KINEMATIC] * np.outer(sign, sign))


def forward_in_time(result):
    """A :class:`~rangeproc.fusion.estimator_types.FusionResult` of time-reversed rows turned
    back: epochs ascending in ``t``, velocities and their covariances' signs restored, rows
    in forward order (its batch with the sigmas and values the reversed run used), rate
    residuals negated back; one span over its rows."""
    n = result.xs.shape[1]
    sign = _velocity_signs(n)
    i, j = np.tril_indices(n)
    packed_sign = sign[i] * sign[j]
    n_epochs = len(result.epoch_t)
    back = time_reversed(result.batch)           # its sigmas and any corrected values
    prob = result.model_prob
    down = result.down_weight
    return replace(
        result,
        epoch_t=np.ascontiguousarray(-result.epoch_t[::-1]),
        xs=np.ascontiguousarray(result.xs[::-1] * sign),
        Ps=np.ascontiguousarray(result.Ps[::-1] * packed_sign),
        grid=np.ascontiguousarray(result.grid[::-1]),
        batch=back,
        meas_epoch=np.ascontiguousarray(n_epochs - 1 - result.meas_epoch[::-1]),
        used=np.ascontiguousarray(result.used[::-1]),
        nis=np.ascontiguousarray(result.nis[::-1]),
        dof=np.ascontiguousarray(result.dof[::-1]),
        res=negate_rates(result.res[::-1], back.model),
        hph=np.ascontiguousarray(result.hph[::-1]),
        q=np.ascontiguousarray(result.q[::-1]),
        model_prob=None if prob is None else np.ascontiguousarray(prob[::-1]),
        down_weight=None if down is None else np.ascontiguousarray(down[::-1]),
        spans=((float(back.t[0]), float(back.t[-1])),))
