"""Gate lock-out of sparse plots (``fusion.lockout``): a plots-only object that turns hard
between two scans is estimated again from the plots after the turn instead of being lost."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from rangeproc.fusion.batch import MeasurementBatch, SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_target, gate_thresholds
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.lockout import SPARSE_STEP_S, locked_out, lockout_time, sparse_sensors
from rangeproc.models.measurement import CARTESIAN, SPHERICAL

SPEED = 250.0            # m/s
SIGMA = np.array([40.0, 0.002, 0.004])     # a surveillance radar's range (m), angles (rad)


def truth(turn_at: float | None, rate: float, end: float) -> tuple[np.ndarray, ...]:
    """Times (s), east and north (m) of an aircraft flying north from 30 km north of the
    radar at 3 km height, turning back (``rate`` rad/s, a half circle) from ``turn_at``."""
    dt = 0.01
    tt = np.arange(0.0, end + dt, dt)
    psi = (np.zeros_like(tt) if turn_at is None
           else np.clip((tt - turn_at) * rate, 0.0, np.pi))
    return (tt, np.cumsum(SPEED * np.sin(psi)) * dt,
            30_000.0 + np.cumsum(SPEED * np.cos(psi)) * dt)


def radar_plots(seed: int, turn_at: float | None, rate: float = 0.3, period: float = 4.0,
                end: float = 140.0) -> tuple[MeasurementBatch, tuple[np.ndarray, ...]]:
    """One plot per ``period`` s scan (detected every scan) of a radar at the origin."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.5, end, period)
    tt, e, n = truth(turn_at, rate, end)
    pe, pn, pu = np.interp(t, tt, e), np.interp(t, tt, n), np.full(t.size, 3000.0)
    a = empty_rows(t.size, SPHERICAL)
    a["z"][:, 0] = np.sqrt(pe**2 + pn**2 + pu**2)
    a["z"][:, 1] = np.arctan2(pe, pn)
    a["z"][:, 2] = np.arctan2(pu, np.hypot(pe, pn))
    a["z"][:, :3] += rng.normal(0.0, SIGMA, (t.size, 3))
    a["sigma"][:, :3] = SIGMA
    rows = SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                      track=np.full(t.size, -1), **a)
    return merge([(0, rows)], ("SR1",)), (tt, e, n)


def horizontal_error(result, truth_track) -> np.ndarray:
    tt, e, n = truth_track
    et = result.epoch_t[result.grid]
    x = result.xs[result.grid]
    return np.hypot(x[:, 0] - np.interp(et, tt, e), x[:, 1] - np.interp(et, tt, n))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_turn_between_scans_does_not_lose_the_plots_after_it(seed: int) -> None:
    # a 7.6 g half circle in 10.5 s, two or three plots inside it: the filter's prediction
    # runs on straight while the plots come back; without the cut the gate rejects the
    # range of every later plot and the track ends kilometres away (10 km on these seeds)
    batch, track = radar_plots(seed, turn_at=110.0)
    result = fuse_target(batch, 1.0, EstimatorSettings())
    assert result.used[:, 0].all()                  # every plot's range is used
    err = horizontal_error(result, track)
    assert err.max() < 400.0                        # a few plot sigmas, not kilometres
    assert len(result.spans) == 2                   # estimated again from the cut


def test_a_straight_flight_is_not_cut() -> None:
    batch, track = radar_plots(4, turn_at=None)
    result = fuse_target(batch, 1.0, EstimatorSettings())
    assert len(result.spans) == 1
    assert lockout_time(result, gate_thresholds(0.9999)) is None
    assert horizontal_error(result, track).max() < 150.0


def test_only_sensors_with_scan_like_steps_are_sparse() -> None:
    t = np.concatenate([np.arange(0.0, 20.0, 0.1), np.arange(0.0, 20.0, SPARSE_STEP_S),
                        np.arange(0.0, 20.0, 1.0), [5.0]])
    sensor = np.concatenate([np.zeros(200), np.ones(14), np.full(20, 2), [3]]).astype(int)
    order = np.argsort(t, kind="stable")
    assert sparse_sensors(sensor[order], t[order]) == [1]


def test_plots_missed_while_a_dense_sensor_measures_the_object_cut_nothing() -> None:
    # two consecutive radar plots 1.5 km long in range (clutter, a wrong association) while
    # a 1 Hz GPS holds the track: the plots' own trouble, not a lost track
    batch, (tt, e, n) = radar_plots(5, turn_at=None)
    radar = SensorRows(t=batch.t, source_row=batch.source_row, station=batch.station,
                       track=batch.track, model=batch.model, z=batch.z.copy(),
                       sigma=batch.sigma, s=batch.s, sv=batch.sv, Qr=batch.Qr)
    radar.z[20:22, 0] += 1500.0
    tg = np.arange(0.0, 140.0, 1.0)
    gps = empty_rows(tg.size, CARTESIAN)
    rng = np.random.default_rng(6)
    gps["z"][:, :3] = np.column_stack([np.interp(tg, tt, e), np.interp(tg, tt, n),
                                       np.full(tg.size, 3000.0)]) + rng.normal(0, 3.0, (tg.size, 3))
    gps["sigma"][:, :3] = 3.0
    gps_rows = SensorRows(t=tg, source_row=np.arange(tg.size), station=np.full(tg.size, -1),
                          track=np.full(tg.size, -1), **gps)
    both = merge([(0, radar), (1, gps_rows)], ("SR1", "G1"))
    result = fuse_target(both, 1.0, EstimatorSettings())
    assert len(result.spans) == 1
    assert lockout_time(result, gate_thresholds(0.9999)) is None


def test_an_object_without_plots_is_not_checked_for_lock_outs() -> None:
    # a tracking radar at 10 Hz (no sparse sensor): nothing can be locked out, so neither
    # the residuals nor the noise are read (they cost a pass over every row of a long
    # instrumented sortie); a scanning radar's plots are read
    t = np.arange(0.0, 60.0, 0.1)
    a = empty_rows(t.size, CARTESIAN)
    a["z"][:, :3] = 1000.0
    rows = SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                      track=np.full(t.size, -1), **a)
    dense = merge([(0, rows)], ("R1",))
    unread = SimpleNamespace(batch=dense, res=None, noise=None)
    gate = gate_thresholds(0.999)
    assert not locked_out(unread, gate).any() and lockout_time(unread, gate) is None
    plots, _ = radar_plots(1, turn_at=None)
    with pytest.raises((TypeError, AttributeError)):
        locked_out(SimpleNamespace(batch=plots, res=None, noise=None), gate)
