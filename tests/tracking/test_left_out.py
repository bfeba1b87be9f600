"""A row scored as if left out of the trajectory it helped estimate
(``tracking.score.score_rows_left_out``), against the trajectory estimated without it."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.tracking.objects import object_track
from rangeproc.tracking.score import ObjectTrack, score_rows, score_rows_left_out
from rangeproc.settings import ProcessingSettings

SETTINGS = EstimatorSettings(
    processing=ProcessingSettings(noise_passes=0, adapt_noise=False, process_noise=1.0))


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


def row_scores(batch, i: int, with_all, without):
    """Row ``i``'s (NIS, llr) against the trajectory estimated without it, against the one
    estimated with it, and left out of the latter (``score_rows_left_out``)."""
    row = np.array([i])
    _, nis_out, llr_out = score_rows(batch, row, without)
    _, nis_in, llr_in = score_rows(batch, row, with_all)
    _, nis_loo, llr_loo = score_rows_left_out(batch, row, with_all, row)
    return (nis_out[0], llr_out[0]), (nis_in[0], llr_in[0]), (nis_loo[0], llr_loo[0])


@pytest.mark.parametrize("seed", [1, 2])
def test_the_left_out_score_is_the_score_against_the_track_without_the_row(plot_batch,
                                                                           seed) -> None:
    batch = plots(plot_batch, seed)
    with_all = object_track(fuse_target(batch, 4.0, SETTINGS))
    for i in (5, 14, 22):
        without = object_track(fuse_target(batch.rows(np.delete(np.arange(len(batch)), i)),
                                           4.0, SETTINGS))
        (nis_out, llr_out), (nis_in, _), (nis_loo, llr_loo) = row_scores(batch, i, with_all,
                                                                         without)
        assert nis_loo == pytest.approx(nis_out, rel=0.1, abs=0.05)
        assert llr_loo == pytest.approx(llr_out, abs=0.2)
        assert nis_in < nis_loo                 # its own track flatters the row
    _, nis, _ = score_rows(batch, np.arange(len(batch)), with_all)
    _, nis_plain, _ = score_rows_left_out(batch, np.arange(len(batch)), with_all,
                                          np.full(len(batch), -1))
    np.testing.assert_array_equal(nis, nis_plain)          # non-members: the plain score


def with_rival(plot_batch, seed: int, at: int):
    """:func:`plots` and one more plot 3 ms after plot ``at``, 250 m north of the aircraft
    (another aircraft of a formation, seen in the same scan): (batch, rival row, own row)."""
    base = plots(plot_batch, seed)
    rng = np.random.default_rng(seed + 100)
    t0 = float(base.t[at]) + 0.003
    p = np.array([-20_000.0 + 200.0 * t0, 8_250.0 + 50.0 * t0, 6_000.0])
    r = float(np.linalg.norm(p))
    sigma = np.array([43.0, 1.5e-3, 1.5e-3])
    rae = np.array([r, np.arctan2(p[0], p[1]), np.arcsin(p[2] / r)]) + rng.normal(size=3) * sigma
    t = np.insert(base.t, at + 1, t0)
    z = np.insert(base.z[:, :3], at + 1, rae, axis=0)
    return plot_batch(t, z, sigma), at + 1, at


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("at", [0, 1, 11, 29])
def test_a_rival_plot_is_scored_against_the_track_without_the_objects_plot_of_its_scan(
        plot_batch, seed, at) -> None:
    """The formation's rival plot meets the trajectory with the object's own plot of the
    scan left out (``deleted_states``), as re-estimating without that plot does. At the
    track's first plot (``at`` 0) the re-estimate also starts later, from other fixes, and
    at its last (29) it ends earlier: the rival then lies beyond its span, carried there with
    the gap noise (white jerk and the manoeuvre its speed allows, ``tracking.score``), which
    the deletion, keeping the trajectory's ends, does not add. The deletion still lies
    between the plain score and the re-estimate's, at least half of the way to the latter."""
    batch, rival, own = with_rival(plot_batch, seed, at)
    n = len(batch)
    with_own = object_track(fuse_target(batch.rows(np.delete(np.arange(n), rival)), 4.0,
                                        SETTINGS))
    without = object_track(fuse_target(batch.rows(np.delete(np.arange(n), [rival, own])),
                                       4.0, SETTINGS))
    _, nis_out, llr_out = score_rows(batch, np.array([rival]), without)
    _, nis_in, _ = score_rows(batch, np.array([rival]), with_own)
    _, nis_del, llr_del = score_rows_left_out(batch, np.array([rival]), with_own,
                                              np.array([own]))
    if at in (0, 29):
        assert min(nis_out[0], nis_in[0]) < nis_del[0] < max(nis_out[0], nis_in[0])
        assert abs(nis_del[0] - nis_out[0]) < 0.5 * abs(nis_in[0] - nis_out[0])
    else:
        assert nis_del[0] == pytest.approx(nis_out[0], rel=0.1, abs=0.05)
        assert llr_del[0] == pytest.approx(llr_out[0], abs=0.2)


def test_deleted_states_equal_the_information_form_in_a_linear_case() -> None:
    """One Cartesian position row: x_del = P_del (P⁻¹ x - Hᵀ R⁻¹ z), P_del⁻¹ = P⁻¹ - Hᵀ R⁻¹ H."""
    from rangeproc.models.measurement import CARTESIAN
    from rangeproc.tracking.score import deleted_states

    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    P = 0.1 * A @ A.T + np.eye(9)          # the row explains less than its noise
    x = rng.normal(size=9) * 10.0
    z = np.full((1, 6), np.nan)
    z[0, :3] = x[:3] + rng.normal(size=3)
    sigma = np.zeros((1, 6))
    sigma[0, :3] = [4.0, 5.0, 6.0]
    xd, Pd, ok = deleted_states(np.array([0]), np.array([0.0]), np.array([CARTESIAN]), z, sigma,
                                np.zeros((1, 3)), np.zeros((1, 3)), np.eye(3)[None],
                                np.array([0.0]), x[None], P[None], np.array([1.0]))
    H = np.zeros((3, 9))
    H[:, :3] = np.eye(3)
    Rinv = np.diag(1.0 / sigma[0, :3] ** 2)
    P_del = np.linalg.inv(np.linalg.inv(P) - H.T @ Rinv @ H)
    x_del = P_del @ (np.linalg.solve(P, x) - H.T @ Rinv @ z[0, :3])
    assert ok[0]
    np.testing.assert_allclose(Pd[0], P_del, rtol=1e-8)
    np.testing.assert_allclose(xd[0], x_del, rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_row_is_left_out_with_the_noise_its_trajectory_weighed_it_with(plot_batch,
                                                                         seed) -> None:
    """Plots three times noisier than stated: the fusion raises the sensor's sigma from the
    plots' own scatter (``fusion.noise.difference_sigma``), so its trajectory weighs each
    plot less than stated, and removing a plot as stated removes more than it gave
    (``R - H P Hᵀ`` is not positive definite, and before, the plain, flattering score
    stood). The removal uses the sigma the trajectory recorded (``ObjectTrack.weighed``):
    it agrees with re-estimating, with those sigmas, without the plot; the same track
    without the record keeps the plain score."""
    adaptive = EstimatorSettings(processing=ProcessingSettings(
        noise_passes=0, adapt_noise=True, process_noise=1.0))
    clean = plots(plot_batch, seed)
    rng = np.random.default_rng(seed + 50)
    stated = np.array([43.0, 1.5e-3, 1.5e-3])
    z = clean.z[:, :3] + 2.0 * rng.normal(size=(len(clean), 3)) * stated
    batch = plot_batch(clean.t, z, stated)
    with_all = object_track(fuse_target(batch, 4.0, adaptive))
    assert with_all.weighed is not None
    source, weighed = with_all.weighed[0]
    assert (weighed[:, 0] > 1.5 * stated[0]).all()          # the sigma was raised
    as_weighed = batch.with_sigma(weighed[np.argsort(np.argsort(batch.source_row))])
    unrecorded = ObjectTrack(with_all.t, with_all.x, with_all.P, with_all.q)
    for i in (1, 5, 14, 22, 28):
        without = object_track(fuse_target(as_weighed.rows(np.delete(np.arange(len(batch)), i)),
                                           4.0, SETTINGS))
        (nis_out, llr_out), (nis_in, _), (nis_loo, llr_loo) = row_scores(batch, i, with_all,
                                                                         without)
        _, nis_old, _ = score_rows_left_out(batch, np.array([i]), unrecorded, np.array([i]))
        assert nis_loo == pytest.approx(nis_out, rel=0.1, abs=0.05)
        assert llr_loo == pytest.approx(llr_out, abs=0.3)
        assert nis_old[0] == nis_in < 0.8 * nis_out           # as stated: not removable
