"""The achievable accuracy drawn beside the achieved (``fusion.achievable``): equal where the
run used its rows as the instruments allow, smaller where the data were worse than the
instruments (a GPS noise burst), and the long-span thinning equivalent to every row."""
from __future__ import annotations

import weakref
from dataclasses import replace

import numpy as np
import pytest

import rangeproc.fusion.achievable as ach
import rangeproc.fusion.products as products
import rangeproc.pipeline as pipeline
from rangeproc.frames.geodesy import Geodetic, RangeFrame
from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.products import track_estimate
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario
from rangeproc.simulate.scenario import draw_scenario
from tests.conftest import gps_line_batch


@pytest.fixture(scope="module")
def burst_run(tmp_path_factory):
    """A flight seen by its GPS alone, which has a noise burst (x10 for 8-12 s)."""
    folder = tmp_path_factory.mktemp("achievable")
    cfg = simulate_scenario(folder, seed=4, duration=60.0, sensors="G1")
    out = run(cfg)
    return out.tracks[0], draw_scenario(4, 60.0).g1_burst


def test_achievable_equals_achieved_where_the_rows_were_as_stated(burst_run):
    track, (b0, b1) = burst_run
    achieved = np.sqrt(np.diagonal(track.P, axis1=1, axis2=2)[:, :3])
    far = (track.time < b0 - 10.0) | (track.time > b1 + 10.0)
    ratio = np.median(track.achievable[far] / achieved[far], axis=0)
    assert ratio == pytest.approx(np.ones(3), abs=0.1)


def test_achievable_is_smaller_inside_a_noise_burst(burst_run):
    track, (b0, b1) = burst_run
    achieved = np.sqrt(np.diagonal(track.P, axis1=1, axis2=2)[:, :3])
    inside = (track.time > b0 + 2.0) & (track.time < b1 - 2.0)
    assert inside.any()
    assert np.median(achieved[inside] / track.achievable[inside]) > 1.5


def test_a_long_span_thinned_with_scaled_sigma_gives_the_same(tmp_path, monkeypatch):
    cfg = simulate_scenario(tmp_path, seed=2, duration=40.0, sensors="R1,G1")
    whole = run(cfg).tracks[0].achievable
    monkeypatch.setattr(ach, "MAX_ROWS", 600)          # about 1,000 rows: each series by 2
    thinned = run(cfg).tracks[0].achievable
    assert np.median(thinned / whole) == pytest.approx(1.0, abs=0.03)


def test_the_fusion_covariances_are_let_go_before_the_pass(tmp_path, monkeypatch):
    # the achievable pass runs after the edit table and the row accounting, on results whose
    # per-epoch covariances, residuals and explained variances are gone: a long sortie never
    # holds them beside the pass's filter history (the products stage's peak)
    cfg = simulate_scenario(tmp_path, seed=2, duration=40.0, sensors="R1,G1")
    fused: list[weakref.ref] = []
    seen: list[int] = []                # at each pass: the fusion's arrays still alive
    settle, achievable = pipeline.settle, products.achievable_sigma

    def watched_settle(*args, **kwargs):
        out = settle(*args, **kwargs)
        fused.extend(weakref.ref(a) for _, r in out[0] for a in (r.Ps, r.res, r.hph))
        return out

    def watched(result):
        seen.append(sum(r() is not None for r in fused))
        assert result.Ps.size == 0
        return achievable(result)

    monkeypatch.setattr(pipeline, "settle", watched_settle)
    monkeypatch.setattr(products, "achievable_sigma", watched)
    tracks = run(cfg).tracks
    assert fused and seen == [0] * len(tracks)
    assert all(np.isfinite(tr.achievable).any() for tr in tracks)


@pytest.mark.parametrize("max_rows", [ach.MAX_ROWS, 600])
def test_the_filter_gets_only_the_columns_it_reads(tmp_path, monkeypatch, max_rows):
    # every row: the batch's own columns; thinned: copies of the kept rows of the columns the
    # filter reads (no copy of the batch's sigma, times or bookkeeping), and the pages the
    # thinning freed handed back before the filter makes its arrays
    cfg = simulate_scenario(tmp_path, seed=2, duration=120.0, sensors="R1,G1")
    monkeypatch.setattr(ach, "MAX_ROWS", max_rows)
    calls: list[tuple] = []
    trims = [0]
    achievable, filt, freed = products.achievable_sigma, ach.run_filter, ach.release_freed_between

    def watched(result):
        calls.append((result.batch, []))
        return achievable(result)

    def watched_filter(rows, *args):
        calls[-1][1].append((rows, trims[0]))
        return filt(rows, *args)

    def counted(n_rows: int) -> bool:
        trims[0] += 1
        return freed(n_rows)

    monkeypatch.setattr(products, "achievable_sigma", watched)
    monkeypatch.setattr(ach, "run_filter", watched_filter)
    monkeypatch.setattr(ach, "release_freed_between", counted)
    assert run(cfg).tracks
    (batch, [(rows, trimmed)]), = calls
    assert trimmed == 1
    shared = [rows.model is batch.model, rows.z is batch.z, rows.s is batch.s,
              rows.Qr is batch.Qr, rows.sensor is batch.sensor]
    if max_rows >= len(batch):
        assert all(shared)
    else:
        assert not any(shared) and len(rows.z) < len(batch)
        assert {len(a) for a in (rows.model, rows.z, rows.sigma, rows.sv, rows.sensor)} == \
            {len(rows.meas_epoch)}


def test_the_late_column_is_the_one_made_with_the_track():
    # GPS rows with a gap (two spans, bridged) whose last 20 s are another object's (left
    # unwritten): the column filled after the products equals the one track_estimate makes,
    # and epochs added at the left-out times (as fusion.formation extends a track) stay NaN
    rng = np.random.default_rng(6)
    t_rows = np.arange(0.0, 80.0, 0.5)
    t_rows = t_rows[(t_rows < 20.0) | (t_rows >= 32.0)]
    batch = gps_line_batch(t_rows, rng, noise=2.0, sigma=2.0)
    other = t_rows >= 60.0
    batch.z[other, 0] += 3_000.0 + 40.0 * (t_rows[other] - 60.0)
    split = EstimatorSettings()
    split = replace(split, processing=replace(split.processing, max_gap=5.0))
    result = fuse_target(batch, 5.0, split)
    frame = RangeFrame(Geodetic(lat=45.0, lon=10.0, height=0.0))
    kw = dict(stated=np.array([[2.0, 2.0, 2.0]]), max_bridge=60.0)
    made = track_estimate("O1", result, frame, 5.0, **kw)
    late = products.with_achievable_sigma(
        track_estimate("O1", result, frame, 5.0, with_achievable=False, **kw), result)
    assert len(result.spans) == 2 and made.unwritten
    assert np.isnan(made.achievable).all(axis=1).any()          # the bridged epochs
    assert np.array_equal(late.achievable, made.achievable, equal_nan=True)
    grid_t = result.epoch_t[result.grid]
    extra = grid_t[grid_t > made.time[-1]]                       # the left-out epochs
    extended = replace(made, time=np.r_[made.time, extra], achievable=None)
    filled = products.with_achievable_sigma(extended, result).achievable
    assert extra.size and np.isnan(filled[made.time.size:]).all()
    assert np.array_equal(filled[:made.time.size], made.achievable, equal_nan=True)
