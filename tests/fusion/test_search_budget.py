"""The process-noise search's row budget per run, shared by the objects (pipeline)."""
from __future__ import annotations

from rangeproc.fusion.centralised import EstimatorSettings
from rangeproc.pipeline import MIN_OBJECT_SEARCH_ROWS, search_budget


def test_one_object_keeps_the_whole_budget_and_several_share_it() -> None:
    st = EstimatorSettings()
    full = st.q_search_rows
    assert search_budget(st, 2_000_000, 2_000_000).q_search_rows == full
    assert search_budget(st, 30_000, 30_000).q_search_rows == full
    # ten equal objects: a tenth each, but never fewer than the floor
    assert search_budget(st, 100_000, 1_000_000).q_search_rows == max(
        MIN_OBJECT_SEARCH_ROWS, full // 10)
    # a dominant object keeps most of it; a small one its floor
    assert search_budget(st, 900_000, 1_000_000).q_search_rows == full * 9 // 10
    assert search_budget(st, 100, 1_000_000).q_search_rows == MIN_OBJECT_SEARCH_ROWS
    # other settings are untouched
    assert search_budget(st, 100, 1_000_000).noise_passes == st.noise_passes
