"""Spans: a target unobserved for longer than max_gap is estimated in separate spans."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.errors import DataError
from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_span, fuse_target, span_slices
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.models.measurement import CARTESIAN, SPHERICAL
from rangeproc.settings import ProcessingSettings


def gps_rows(t: np.ndarray, rng: np.random.Generator) -> SensorRows:
    n = t.size
    a = empty_rows(n, CARTESIAN)
    truth = np.column_stack([100.0 * t, 50.0 * t, 3000.0 + 0.0 * t])
    a["z"][:, :3] = truth + rng.normal(0.0, 2.0, (n, 3))
    a["sigma"][:, :3] = 2.0
    return SensorRows(t=t, source_row=np.arange(n), station=np.full(n, -1),
                      track=np.full(n, -1), **a)


def rate_only_rows(t: np.ndarray) -> SensorRows:
    n = t.size
    a = empty_rows(n, SPHERICAL)
    a["z"][:, 3] = 100.0
    a["sigma"][:, 3] = 0.1
    return SensorRows(t=t, source_row=np.arange(n), station=np.zeros(n, np.int64),
                      track=np.full(n, -1), **a)


def test_span_slices_cut_only_at_long_steps() -> None:
    t = np.array([0.0, 1.0, 2.0, 70.0, 71.0, 200.0])
    assert [(s.start, s.stop) for s in span_slices(t, 60.0)] == [(0, 3), (3, 5), (5, 6)]
    assert [(s.start, s.stop) for s in span_slices(t[:3], 60.0)] == [(0, 3)]


def test_two_spans_have_no_epochs_in_the_gap_and_equal_separate_runs() -> None:
    rng = np.random.default_rng(4)
    t = np.concatenate([np.arange(0.0, 30.0, 0.5), np.arange(500.0, 530.0, 0.5)])
    batch = merge([(0, gps_rows(t, rng))], ("G1",))
    st = EstimatorSettings(processing=ProcessingSettings(noise_passes=1))
    res = fuse_target(batch, 2.0, st)
    assert res.spans == ((0.0, 29.5), (500.0, 529.5))
    grid_t = res.epoch_t[res.grid]
    assert not ((grid_t > 29.5) & (grid_t < 500.0)).any()
    first = fuse_span(batch.rows(slice(0, 60)), 2.0, st)
    second = fuse_span(batch.rows(slice(60, 120)), 2.0, st)
    np.testing.assert_array_equal(res.xs, np.concatenate([first.xs, second.xs]))
    np.testing.assert_array_equal(res.meas_epoch[60:], second.meas_epoch + len(first.epoch_t))
    assert res.n_unstarted == {}


def test_a_span_that_cannot_start_is_left_out_and_counted() -> None:
    rng = np.random.default_rng(5)
    gps = gps_rows(np.arange(0.0, 30.0, 0.5), rng)
    rates = rate_only_rows(np.arange(200.0, 210.0, 0.5))
    batch = merge([(0, gps), (1, rates)], ("G1", "M"))
    once = EstimatorSettings(processing=ProcessingSettings(noise_passes=0))
    res = fuse_target(batch, 2.0, once)
    assert len(res.spans) == 1 and res.n_unstarted == {1: 20}
    assert len(res.batch) == 60
    with pytest.raises(DataError, match="cannot initialise"):
        fuse_target(merge([(1, rates)], ("G1", "M")), 2.0, once)
