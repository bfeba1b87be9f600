"""The process-noise likelihood search keeps at least MIN_SEARCH_RATE_HZ rows per second of
the span: decimated thinner, the filter no longer follows the target between the rows it
sees and the likelihood over q turns erratic (the one-hour 2M-row sortie, README)."""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.tuning import MAX_SEARCH_ROWS, MIN_SEARCH_RATE_HZ, search_rows
from rangeproc.fusion import refinement
from rangeproc.fusion.centralised import fuse_span
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.settings import ProcessingSettings

from conftest import gps_line_batch


def test_search_rows_is_the_cap_or_the_rate_floor_whichever_is_more():
    assert search_rows(120.0) == MAX_SEARCH_ROWS                 # a short flight: the cap
    assert search_rows(3600.0) == int(MIN_SEARCH_RATE_HZ * 3600.0)   # an hour: the floor
    assert search_rows(3600.0, 10 ** 7) == 10 ** 7
    assert search_rows(0.0, 5) == 5


def test_fuse_span_searches_over_the_floored_row_count(monkeypatch):
    seen = {}
    real = refinement.start_process_noise

    def spy(*args, **kwargs):
        seen["max_rows"] = kwargs["max_rows"]
        return real(*args, **kwargs)

    monkeypatch.setattr(refinement, "start_process_noise", spy)
    t = np.arange(0.0, 900.0, 0.5)
    fuse_span(gps_line_batch(t, np.random.default_rng(2)), 1.0,
              EstimatorSettings(processing=ProcessingSettings(noise_passes=0)))
    assert seen["max_rows"] == search_rows(t[-1] - t[0]) == int(MIN_SEARCH_RATE_HZ * 899.5)


def test_the_search_thins_each_sensor_alike_where_a_global_stride_would_alias(monkeypatch):
    """Four GPS receivers at the same time stamps merge as G1 G2 G3 G4 G1 ...: every 4th row
    of the merged rows would be G1's alone; the search keeps each receiver's every 4th."""
    from rangeproc.estimation import tuning
    from rangeproc.fusion.batch import SensorRows, merge
    from rangeproc.fusion.centralised import gate_thresholds

    t = np.arange(0.0, 100.0, 0.1)
    one = [gps_line_batch(t, np.random.default_rng(k)) for k in range(4)]
    batch = merge([(k, SensorRows(b.t, b.model, b.z, b.sigma, b.s, b.sv, b.Qr, b.source_row,
                                  b.station, b.track)) for k, b in enumerate(one)],
                  ("G1", "G2", "G3", "G4"))
    assert len(np.unique(batch.sensor[::4])) == 1
    seen = []
    real = tuning.run_filter

    def spy(rows, prior, settings):
        seen.append(np.bincount(rows.sensor, minlength=4))
        return real(rows, prior, settings)

    monkeypatch.setattr(tuning, "run_filter", spy)
    epoch_t = np.unique(batch.t)
    x0 = np.zeros(9)
    x0[:3] = batch.z[0, :3]
    x0[3:6] = (100.0, 50.0, 0.0)
    P0 = np.diag([100.0] * 6 + [10.0] * 3)
    tuning.start_process_noise(batch, epoch_t, x0, P0, gate_thresholds(0.9999), (1.0, 10.0),
                               50, 100.0, max_rows=len(batch) // 4)
    assert seen and all(c.min() >= 0.9 * c.max() for c in seen)
