"""The process-noise likelihood search keeps at least MIN_SEARCH_RATE_HZ rows per second of
the span: decimated thinner, the filter no longer follows the target between the rows it
sees and the likelihood over q turns erratic (the one-hour 2M-row sortie, README)."""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.tuning import MAX_SEARCH_ROWS, MIN_SEARCH_RATE_HZ, search_rows
from rangeproc.fusion import centralised
from rangeproc.fusion.centralised import EstimatorSettings, fuse_span
from rangeproc.settings import ProcessingSettings

from conftest import gps_line_batch


def test_search_rows_is_the_cap_or_the_rate_floor_whichever_is_more():
    assert search_rows(120.0) == MAX_SEARCH_ROWS                 # a short flight: the cap
    assert search_rows(3600.0) == int(MIN_SEARCH_RATE_HZ * 3600.0)   # an hour: the floor
    assert search_rows(3600.0, 10 ** 7) == 10 ** 7
    assert search_rows(0.0, 5) == 5


def test_fuse_span_searches_over_the_floored_row_count(monkeypatch):
    seen = {}
    real = centralised.start_process_noise

    def spy(*args, **kwargs):
        seen["max_rows"] = kwargs["max_rows"]
        return real(*args, **kwargs)

    monkeypatch.setattr(centralised, "start_process_noise", spy)
    t = np.arange(0.0, 900.0, 0.5)
    fuse_span(gps_line_batch(t, np.random.default_rng(2)), 1.0,
              EstimatorSettings(processing=ProcessingSettings(noise_passes=0)))
    assert seen["max_rows"] == search_rows(t[-1] - t[0]) == int(MIN_SEARCH_RATE_HZ * 899.5)
