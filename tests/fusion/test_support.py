"""An object's trajectory is written only where its own rows support it (fusion.support)."""
from __future__ import annotations

import numpy as np

from rangeproc.frames.geodesy import Geodetic, RangeFrame
from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.products import track_estimate
from rangeproc.fusion.support import (
    MIN_UNFIT_SECONDS,
    left_out,
    position_rows,
    supported,
    unsupported_stretches,
)
from rangeproc.models.measurement import N_COMPONENTS
from tests.conftest import gps_line_batch


def _fit_all(batch):
    used = np.isfinite(batch.z)
    return used, np.zeros((len(batch), N_COMPONENTS))


def test_rows_that_fit_support_the_whole_trajectory() -> None:
    batch = gps_line_batch(np.arange(0.0, 60.0, 1.0), np.random.default_rng(1))
    used, res = _fit_all(batch)
    t = np.arange(0.0, 60.0, 0.2)
    assert supported(t, batch, used, res).all()


def test_a_run_of_rows_that_do_not_fit_is_unsupported_a_lone_wild_point_is_not() -> None:
    t_rows = np.arange(0.0, 60.0, 1.0)
    batch = gps_line_batch(t_rows, np.random.default_rng(2))
    used, res = _fit_all(batch)
    used[10] = False                                   # a lone wild point at 10 s
    used[30:38] = False                                # 30-37 s: a run that does not fit
    t = np.arange(0.0, 60.0, 0.2)
    keep = supported(t, batch, used, res)
    assert keep[(t < 29.0) | (t > 38.0)].all()         # down to the fitting rows either side
    assert not keep[(t > 29.0) & (t < 38.0)].any()
    assert keep[np.abs(t - 10.0) < 1.0].all()


def test_rows_that_stop_fitting_at_the_end_cut_the_trajectory_there() -> None:
    batch = gps_line_batch(np.arange(0.0, 60.0, 1.0), np.random.default_rng(3))
    used, res = _fit_all(batch)
    used[50:] = False
    is_position, fits = position_rows(batch, used, res)
    assert unsupported_stretches(batch.t, is_position, fits) == [(49.0, np.inf)]
    t = np.arange(0.0, 60.0, 0.2)
    assert np.array_equal(supported(t, batch, used, res), t <= 49.0)


def test_a_short_run_or_a_biased_sensor_between_fitting_rows_stays_supported() -> None:
    batch = gps_line_batch(np.arange(0.0, 60.0, 0.05), np.random.default_rng(4))
    used, res = _fit_all(batch)
    used[np.arange(len(batch)) % 3 != 0] = False       # two of three rows rejected throughout
    t = np.arange(0.0, 60.0, 0.2)
    assert supported(t, batch, used, res).all()
    used, res = _fit_all(batch)
    short = (batch.t > 20.0) & (batch.t < 20.0 + 0.8 * MIN_UNFIT_SECONDS)
    used[short] = False                                 # 80 rows, shorter than the limit
    assert supported(t, batch, used, res).all()


def test_a_residual_far_outside_the_stated_noise_does_not_fit_under_inflated_noise() -> None:
    batch = gps_line_batch(np.arange(0.0, 60.0, 1.0), np.random.default_rng(5), sigma=2.0)
    used, res = _fit_all(batch)
    batch.sigma[:, :3] = 5_000.0              # the noise estimate of rows of several things
    res[20:40, 0] = 3_000.0                   # accepted, thousands of metres off
    stated = np.array([[2.0, 2.0, 2.0]])
    t = np.arange(0.0, 60.0, 0.2)
    assert supported(t, batch, used, res).all()          # no ceiling: within 5 sigma
    keep = supported(t, batch, used, res, stated)
    assert not keep[(t > 19.0) & (t < 40.0)].any() and keep[(t < 19.0) | (t > 40.0)].all()
    res[20:40, 0] = 60.0 * (-1.0) ** np.arange(20)  # 3 sigma of a 10x burst of a 2 m
    assert supported(t, batch, used, res, stated).all()   # sensor, white: fits


def test_rows_that_drift_to_one_side_do_not_fit_under_inflated_noise() -> None:
    """A track carried past its rows: residuals within 5 of the inflated sigmas, growing on
    one side beyond 5 stated sigmas, stop fitting; the end after them is not written."""
    batch = gps_line_batch(np.arange(0.0, 60.0, 1.0), np.random.default_rng(7), sigma=2.0)
    used, res = _fit_all(batch)
    batch.sigma[:, :3] = 50.0                 # the noise estimate of rows of several things
    stated = np.array([[2.0, 2.0, 2.0]])
    res[45:, 1] = 12.0 + 3.0 * np.arange(15)  # 12-54 m, all north of the trajectory
    t = np.arange(0.0, 60.0, 0.2)
    assert supported(t, batch, used, res).all()          # no stated sigma: no drift test
    is_position, fits = position_rows(batch, used, res, stated)
    assert not fits[45:].any() and fits[:45].all()
    assert np.array_equal(supported(t, batch, used, res, stated), t <= 44.0)
    res[45:48, 1] = 30.0                      # three one-signed rows between fitting ones: a
    res[48:, 1] = 0.0                         # run shorter than DRIFT_ROWS fits
    assert position_rows(batch, used, res, stated)[1].all()


def test_a_short_end_stretch_that_does_not_fit_is_not_written() -> None:
    """The last 3 s of rows reject the trajectory: shorter than MIN_UNFIT_SECONDS, but at an
    end no fitting row brings the trajectory back, so it is not written; the same rows
    between fitting ones are left to the length rule."""
    batch = gps_line_batch(np.arange(0.0, 60.0, 0.5), np.random.default_rng(8))
    used, res = _fit_all(batch)
    used[batch.t > 57.0] = False
    t = np.arange(0.0, 60.0, 0.2)
    assert np.array_equal(supported(t, batch, used, res), t <= 57.0)
    used, res = _fit_all(batch)
    used[(batch.t > 40.0) & (batch.t < 43.0)] = False
    assert supported(t, batch, used, res).all()


def test_an_object_with_another_objects_rows_is_not_written_where_they_took_it() -> None:
    """End to end: GPS rows of one object, then 20 s of rows of another one 3 km away. The
    smoother's estimate there is not the object's (whatever its gate and noise did), and the
    written track keeps only the stretch its own rows support, within 3 sigma of truth."""
    rng = np.random.default_rng(6)
    t_rows = np.arange(0.0, 80.0, 0.5)
    batch = gps_line_batch(t_rows, rng, noise=2.0, sigma=2.0)
    other = t_rows >= 60.0
    batch.z[other, 0] += 3_000.0 + 40.0 * (t_rows[other] - 60.0)
    res = fuse_target(batch, 5.0)
    frame = RangeFrame(Geodetic(lat=45.0, lon=10.0, height=0.0))
    track = track_estimate("O1", res, frame, 5.0, stated=np.array([[2.0, 2.0, 2.0]]))
    assert track.time.max() < 61.0
    assert track.time.min() <= 0.5 and track.time.max() > 55.0
    truth = np.array([0.0, 0.0, 3000.0]) + np.outer(track.time, (100.0, 50.0, 0.0))
    err = track.x[:, :3] - truth
    sig = np.sqrt(np.einsum("nii->ni", track.P[:, :3, :3]))
    assert (np.abs(err) <= 3.0 * sig + 1e-9).mean() >= 0.95


def test_left_out_names_each_run_of_epochs_not_written():
    t = np.arange(10.0)
    keep = np.array([1, 0, 0, 1, 1, 0, 1, 1, 0, 0], bool)
    assert left_out(t, keep) == ((1.0, 2.0), (5.0, 5.0), (8.0, 9.0))
    assert left_out(t, np.ones(10, bool)) == ()
    assert left_out(t, np.zeros(10, bool)) == ((0.0, 9.0),)
