"""Epoch bookkeeping does not depend on the time scale (hand-made flight, tests/newuser.py).

The same radar rows, stamped on the Unix scale (1.78e9 s), in GPS seconds of week and in
seconds of day, exactly half an output interval off the output grid (the hardest case for
float rounding), must give identical ``n_sensors``, ``sensors`` and ``data_gap_s``.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rangeproc.fusion.products import epoch_of_rows, epoch_provenance, sensors_per_epoch
from conftest import describe, invoke
from newuser import make_flight


@pytest.fixture(scope="module")
def fused_by_scale(tmp_path_factory):
    tables = {}
    for scale in ("unix", "gpsweek", "sod"):
        flight = make_flight(tmp_path_factory.mktemp(scale), scale=scale, with_gps=False,
                             radar_phase=0.05)
        result = invoke(["run", "--quiet", flight.config])
        assert result.exit_code == 0, describe(result)
        tables[scale] = pd.read_parquet(flight.folder / "out" / "fused.parquet")
    return tables


def test_bookkeeping_identical_on_three_time_scales(fused_by_scale):
    ref = fused_by_scale["sod"]
    assert len(ref) > 1000 and (ref["n_sensors"] == 1).all()
    assert (ref["sensors"] == "R1").all()
    for scale in ("unix", "gpsweek"):
        other = fused_by_scale[scale]
        assert len(other) == len(ref), scale
        np.testing.assert_array_equal(other["n_sensors"], ref["n_sensors"], err_msg=scale)
        np.testing.assert_array_equal(other["sensors"], ref["sensors"], err_msg=scale)
        np.testing.assert_array_equal(other["data_gap_s"], ref["data_gap_s"], err_msg=scale)


@pytest.mark.parametrize("t0", [50400.0, 1778508000.0, 172800.0])
def test_rows_half_an_interval_off_the_grid_fall_in_the_later_epoch(t0):
    rate = 10.0
    grid = t0 + np.arange(100) / rate
    rows = t0 + 0.05 + np.arange(99) / rate           # on every boundary but the first
    epoch = epoch_of_rows(grid, rate, rows)
    np.testing.assert_array_equal(epoch, np.arange(1, 100))
    ns = sensors_per_epoch(grid, rate, rows, np.zeros(99, dtype=np.int64))
    assert ns[0] == 0 and (ns[1:] == 1).all()
    names, gap = epoch_provenance(grid, rate, rows, np.zeros(99, dtype=np.int64), ("R1",))
    assert names[0] == "" and (names[1:] == "R1").all()
    np.testing.assert_array_equal(gap, np.full(100, 0.05))


def test_rows_outside_the_grid_or_in_a_left_out_epoch_belong_to_none():
    grid = 1000.0 + np.array([0.0, 0.1, 0.3])          # epoch 0.2 left out (unsupported)
    epoch = epoch_of_rows(grid, 10.0, np.array([999.9, 1000.02, 1000.2, 1000.31, 1000.4]))
    np.testing.assert_array_equal(epoch, [-1, 0, -1, 2, -1])
