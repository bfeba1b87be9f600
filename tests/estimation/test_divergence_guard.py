"""The divergence guard re-opens the covariance once per epoch, never compounding."""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.divergence import MAX_RESET_INFLATION
from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.estimation.rts import rts_smooth
from rangeproc.fusion.batch import empty_rows
from rangeproc.models.measurement import CARTESIAN
from rangeproc.settings import ProcessingSettings

from conftest import gps_line_batch


def test_thousands_of_rejected_rows_at_one_epoch_reset_once_and_smooth() -> None:
    """2,000 GPS rows sharing one stamp, all 50 km off: one reset at that epoch, a
    finite positive-definite covariance after it, and the smoother runs."""
    rng = np.random.default_rng(11)
    t_good = np.arange(0.0, 20.0, 0.1)
    n_bad = 2000
    t = np.sort(np.concatenate([t_good, np.full(n_bad, 10.05)]))
    a = empty_rows(t.size, CARTESIAN)
    a["z"][:, :3] = np.column_stack([100.0 * t, 0.0 * t, 1000.0 + 0.0 * t])
    a["z"][:, :3] += rng.normal(0.0, 1.0, (t.size, 3))
    at_once = np.flatnonzero(t == 10.05)
    a["z"][at_once, :3] += 50_000.0          # every component: no partial acceptance
    a["sigma"][:, :3] = 1.0
    epoch_t = np.unique(t)
    meas_epoch = np.searchsorted(epoch_t, t).astype(np.int64)
    x0 = np.zeros(9)
    x0[0:3] = a["z"][0, :3]
    x0[3] = 100.0
    P0 = np.diag([100.0] * 3 + [25.0] * 3 + [1.0] * 3)
    gate = np.full(7, np.inf)
    gate[1:] = [15.1, 18.4, 21.1, 23.5, 25.7, 27.9]
    out = run_filter(
        FilterRows(epoch_t, meas_epoch, a["model"], a["z"], a["sigma"], a["s"], a["sv"],
                   a["Qr"], np.zeros(t.size, np.int64)),
        FilterPrior(x0, P0, np.full(epoch_t.size, 1.0)),
        FilterSettings(gate, reset_after=50, reset_inflation=100.0))
    xf, Pf, n_resets = out.xf, out.Pf, out.n_resets
    assert n_resets == 1
    assert np.isfinite(Pf).all() and np.isfinite(xf).all()
    assert Pf.max() < MAX_RESET_INFLATION * 1e3
    xs, Ps, _ = rts_smooth(epoch_t, xf, Pf, np.full(epoch_t.size, 1.0), True, False)
    assert np.isfinite(xs).all()
    assert abs(xs[-1, 0] - 100.0 * epoch_t[-1]) < 5.0


def _radar_pass(x0: np.ndarray, P0: np.ndarray, seconds: float = 60.0):
    """A 20 Hz range/azimuth/elevation/range-rate radar at the origin on a target 30 km out
    flying 250 m/s east; returns (epoch_t, truth (E, 9), filtered states (E, 9), resets)."""
    from rangeproc.models.measurement import SPHERICAL, measure_py

    rng = np.random.default_rng(5)
    t = np.arange(0.0, seconds, 0.05)
    truth = np.zeros((t.size, 9))
    truth[:, 0] = -3000.0 + 250.0 * t
    truth[:, 1] = 30_000.0
    truth[:, 2] = 6000.0
    truth[:, 3] = 250.0
    a = empty_rows(t.size, SPHERICAL)
    sig = np.array([10.0, 5e-4, 5e-4, 0.2])
    for i in range(t.size):
        h, _ = measure_py(SPHERICAL, truth[i], a["s"][i], a["sv"][i], a["Qr"][i])
        a["z"][i, :4] = h[:4] + rng.normal(0.0, sig)
    a["sigma"][:, :4] = sig
    meas_epoch = np.arange(t.size, dtype=np.int64)
    gate = np.full(7, np.inf)
    gate[1:] = [15.1, 18.4, 21.1, 23.5, 25.7, 27.9]
    out = run_filter(
        FilterRows(t, meas_epoch, a["model"], a["z"], a["sigma"], a["s"], a["sv"], a["Qr"],
                   np.zeros(t.size, np.int64)),
        FilterPrior(x0, P0, np.full(t.size, 1.0)),
        FilterSettings(gate, reset_after=50, reset_inflation=100.0))
    return t, truth, out.xf, out.n_resets


def test_a_track_started_on_the_wrong_line_of_sight_is_recovered() -> None:
    """Started 15 degrees (8 km) off in azimuth with a confident, correlated covariance (a
    track that coasted through a manoeuvre): the accepted range, elevation and range rate used to
    hold it there while every azimuth was rejected, for ever. The reset drops the stale
    correlations and opens each state to its ceiling, and the radar re-acquires."""
    x0 = np.zeros(9)
    bearing = np.radians(15.0)                       # rotate the true start about the radar
    c, s = np.cos(bearing), np.sin(bearing)
    x0[0], x0[1] = c * -3000.0 - s * 30_000.0, s * -3000.0 + c * 30_000.0
    x0[2], x0[3] = 6000.0, 250.0
    A = np.random.default_rng(2).normal(size=(9, 9))
    P0 = 0.5 * (A @ A.T) + np.diag([400.0] * 3 + [100.0] * 3 + [1.0] * 3)
    t, truth, xf, n_resets = _radar_pass(x0, P0)
    assert n_resets >= 1
    err = np.linalg.norm(xf[:, :3] - truth[:, :3], axis=1)
    assert err[t > 30.0].max() < 50.0


def test_the_local_process_noise_stays_below_its_ceiling() -> None:
    """A pass that lost its object smooths a wild track; its EM statistic must not become
    the next pass's process noise unbounded."""
    from rangeproc.estimation.tuning import local_process_noise

    t = np.arange(0.0, 100.0, 0.1)
    em = np.full(t.size, 1e-2)
    em[500:520] = 1e20
    q = local_process_noise(t, em, ceiling=1e5)
    assert q.max() == 1e5
    assert np.isclose(np.median(q), 0.1)


def test_a_refinement_pass_that_fails_numerically_keeps_the_pass_before(monkeypatch,
                                                                         caplog) -> None:
    """A refinement pass that raises (e.g. a non-finite smoothed state) does not end the run
    or reach the output: the pass it refines stands, with a warning."""
    import rangeproc.fusion.centralised as centralised
    import rangeproc.fusion.refinement as refinement
    from rangeproc.errors import NumericalError

    batch = gps_line_batch(np.arange(0.0, 60.0, 0.5), np.random.default_rng(7))
    settings = centralised.EstimatorSettings(processing=ProcessingSettings(noise_passes=2))
    calls = {"n": 0}
    real = centralised.run_pass

    def second_fails(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            raise NumericalError("estimator failed: non-finite smoothed state")
        return real(*args, **kwargs)

    reference = centralised.fuse_target(batch, 10.0, centralised.EstimatorSettings(
        processing=ProcessingSettings(noise_passes=0)))
    monkeypatch.setattr(centralised, "run_pass", second_fails)     # the first pass
    monkeypatch.setattr(refinement, "run_pass", second_fails)      # the refinement passes
    result = centralised.fuse_target(batch, 10.0, settings)
    assert calls["n"] == 3     # the failed pass ends the refinement; the pass it refines,
    #                            let go while it ran, is done again (test_refine_fallback.py)
    assert np.isfinite(result.xs).all()
    np.testing.assert_allclose(result.xs, reference.xs, rtol=0, atol=1e-9)
    assert "pass 2: estimator failed: non-finite smoothed state; the pass it refines is kept" \
        in caplog.text
