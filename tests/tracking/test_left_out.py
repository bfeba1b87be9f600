"""A row scored as if left out of the trajectory it helped estimate
(``tracking.score.score_rows_left_out``), against the trajectory estimated without it."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.centralised import EstimatorSettings, fuse_target
from rangeproc.tracking.objects import object_track
from rangeproc.tracking.score import score_rows, score_rows_left_out

SETTINGS = EstimatorSettings(noise_passes=0, adapt_noise=False, process_noise=1.0)


def plots(plot_batch, seed: int):
    """A surveillance radar's plots of one aircraft, one per 4 s scan (range 43 m, angles
    1.5 mrad): a sparse object, whose smoothed track leans towards each of its plots."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 120.0, 4.0)
    p = np.column_stack([-20_000.0 + 200.0 * t, 8_000.0 + 50.0 * t, 6_000.0 + 0.0 * t])
    r = np.linalg.norm(p, axis=1)
    rae = np.column_stack([r, np.arctan2(p[:, 0], p[:, 1]), np.arcsin(p[:, 2] / r)])
    sigma = np.array([43.0, 1.5e-3, 1.5e-3])
    return plot_batch(t, rae + rng.normal(size=rae.shape) * sigma, sigma)


@pytest.mark.parametrize("seed", [1, 2])
def test_the_left_out_score_is_the_score_against_the_track_without_the_row(plot_batch,
                                                                           seed) -> None:
    batch = plots(plot_batch, seed)
    with_all = object_track(fuse_target(batch, 4.0, SETTINGS))
    for i in (5, 14, 22):
        keep = np.delete(np.arange(len(batch)), i)
        without = object_track(fuse_target(batch.rows(keep), 4.0, SETTINGS))
        _, nis_out, llr_out = score_rows(batch, np.array([i]), without)
        _, nis_in, llr_in = score_rows(batch, np.array([i]), with_all)
        _, nis_loo, llr_loo = score_rows_left_out(batch, np.array([i]), with_all,
                                                  np.array([True]))
        assert nis_loo[0] == pytest.approx(nis_out[0], rel=0.1, abs=0.05)
        assert llr_loo[0] == pytest.approx(llr_out[0], abs=0.2)
        assert nis_in[0] < nis_loo[0]           # its own track flatters the row
    _, nis, _ = score_rows(batch, np.arange(len(batch)), with_all)
    _, nis_plain, _ = score_rows_left_out(batch, np.arange(len(batch)), with_all,
                                          np.zeros(len(batch), bool))
    np.testing.assert_array_equal(nis, nis_plain)          # non-members: the plain score
