"""The achievable accuracy drawn beside the achieved (``fusion.achievable``): equal where the
run used its rows as the instruments allow, smaller where the data were worse than the
instruments (a GPS noise burst), and the long-span thinning equivalent to every row."""
from __future__ import annotations

import weakref

import numpy as np
import pytest

import rangeproc.fusion.achievable as ach
import rangeproc.fusion.products as products
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario
from rangeproc.simulate.scenario import draw_scenario


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


def test_the_pass_history_is_let_go_before_the_grid_covariances(tmp_path, monkeypatch):
    # the achievable pass's smoothed covariances (one per epoch) are gone before the output
    # grid's are unpacked: a long sortie never holds both (products stage's peak)
    cfg = simulate_scenario(tmp_path, seed=2, duration=40.0, sensors="R1,G1")
    smoothed: list[weakref.ref] = []
    seen: list[tuple[int, int]] = []        # at each unpack: passes run, their arrays alive
    rts, unpack = ach.rts_smooth, products.unpack_many

    def watched_rts(*args):
        out = rts(*args)
        smoothed.append(weakref.ref(out[1]))
        return out

    def watched_unpack(*args):
        seen.append((len(smoothed), sum(r() is not None for r in smoothed)))
        return unpack(*args)

    monkeypatch.setattr(ach, "rts_smooth", watched_rts)
    monkeypatch.setattr(products, "unpack_many", watched_unpack)
    assert run(cfg).tracks
    assert seen and all(n >= 1 for n, _ in seen)        # the pass ran first ...
    assert [alive for _, alive in seen] == [0] * len(seen)   # ... and was let go


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
