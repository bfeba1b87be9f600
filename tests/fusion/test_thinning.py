"""Long spans: the hyperparameter passes on an evenly thinned subset of the rows, the final pass
on every row (``fusion.thinning``)."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from rangeproc import pipeline
from rangeproc.evaluate.metrics import evaluate_run
from rangeproc.fusion import thinning
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.noise import residual_sigma
from rangeproc.models.measurement import SPHERICAL
from rangeproc.simulate import simulate_scenario


def _stations_batch(n_epochs: int, n_stations: int, rate_hz: float) -> MeasurementBatch:
    """MISTRAM-like rows: every station at every epoch, in station order (as merged)."""
    t = np.repeat(np.arange(n_epochs) / rate_hz, n_stations)
    n = len(t)
    z = np.full((n, 6), np.nan)
    z[:, 3] = 1.0
    return MeasurementBatch(
        t, np.full(n, SPHERICAL, dtype=np.int64), z, np.ones((n, 6)),
        np.zeros((n, 3)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
        np.zeros(n, dtype=np.int64), np.arange(n, dtype=np.int64),
        np.tile(np.arange(n_stations), n_epochs).astype(np.int64),
        np.full(n, -1, dtype=np.int64), ("M",))


def test_thinning_keeps_every_series_evenly_where_a_global_stride_aliases():
    b = _stations_batch(4000, 4, 20.0)
    assert len(np.unique(b.station[::4])) == 1            # the global stride: one station left
    kept = b.thinned(4, least_rate_hz=1.0, least_rows=10)
    counts = np.bincount(b.station[kept])
    assert counts.tolist() == [1001] * 4                  # every 4th row and the last
    for s in range(4):                                    # every 4th row of its own series
        t = b.t[kept][b.station[kept] == s]
        np.testing.assert_allclose(np.diff(t)[:-1], 4 / 20.0)
        assert t[-1] == b.t[-1]
    assert kept[0] == 0 and kept[-1] == len(b) - 1
    assert np.all(np.diff(kept) > 0)


def test_a_slow_series_is_thinned_less_never_below_its_floor():
    b = _stations_batch(400, 1, 2.0)                      # 2 Hz over 200 s
    kept = b.thinned(8, least_rate_hz=1.0, least_rows=10)  # floor: 200 rows
    assert 200 <= len(kept) <= 201                        # every 2nd row (and the last)
    whole = b.thinned(8, least_rate_hz=5.0, least_rows=10)  # floor above its rate: all kept
    assert len(whole) == len(b)


def test_only_long_spans_with_refinement_passes_are_thinned():
    assert thinning.thinning_stride(thinning.THIN_ABOVE_ROWS, 2) == 1
    assert thinning.thinning_stride(10 * thinning.THIN_TARGET_ROWS, 0) == 1
    assert thinning.thinning_stride(10 * thinning.THIN_TARGET_ROWS + 7, 2) == 10


def test_track_at_is_exact_for_constant_acceleration_and_bounded_by_the_jerk():
    t = np.linspace(0.0, 10.0, 11)
    a0, v0, p0 = np.array([1.0, -2.0, 0.5]), np.array([100.0, 30.0, -5.0]), np.zeros(3)

    def ca(tt):
        tt = tt[:, None]
        return np.hstack([p0 + v0 * tt + 0.5 * a0 * tt**2, v0 + a0 * tt,
                          np.broadcast_to(a0, (len(tt), 3))])

    fine = np.linspace(0.0, 10.0, 1001)
    np.testing.assert_allclose(thinning.track_at(t, ca(t), fine), ca(fine), atol=1e-9)
    j = 0.6                                                # constant jerk on one axis

    def cj(tt):
        x = ca(tt)
        x[:, 0] += j * tt**3 / 6.0
        x[:, 3] += j * tt**2 / 2.0
        x[:, 6] += j * tt
        return x

    err = thinning.track_at(t, cj(t), fine) - cj(fine)
    dt = 1.0
    assert np.abs(err[:, 0]).max() <= j * dt**3 / 6.0       # the module docstring's bound
    assert np.abs(err[:, 0]).max() > 0.0


def test_steps_at_gives_each_fine_step_the_coarse_step_containing_it():
    coarse = np.array([0.0, 1.0, 2.0, 3.0])
    q = np.array([0.0, 10.0, 20.0, 30.0])
    fine = np.array([0.0, 0.5, 1.0, 1.2, 2.0, 2.9, 3.0])
    np.testing.assert_array_equal(thinning.steps_at(coarse, q, fine),
                                  [0.0, 10.0, 10.0, 20.0, 20.0, 30.0, 30.0])


def test_negated_explained_variance_recovers_sigma_of_rows_the_smoother_did_not_use():
    """A row outside the smoother's data: E[res^2] = sigma^2 + H P H^T (seeded Monte Carlo)."""
    rng = np.random.default_rng(5)
    n, sigma, track_sd = 20_000, 2.0, 1.5
    res = rng.normal(0.0, sigma, n) + rng.normal(0.0, track_sd, n)
    b = _stations_batch(n, 1, 10.0)
    r = np.full((n, 6), np.nan)
    r[:, 3] = res
    hph = np.zeros((n, 6))
    hph[:, 3] = -track_sd**2
    used = np.isfinite(r)
    _, found, _ = residual_sigma(b, r, hph, used)
    assert found[(0, 3)] == pytest.approx(sigma, rel=0.03)
    _, naive, _ = residual_sigma(b, r, np.zeros_like(hph), used)
    assert naive[(0, 3)] > 1.1 * sigma                      # without it: 25 % too large


@pytest.fixture(scope="module")
def thinned_and_whole(tmp_path_factory):
    """One simulated flight run twice: every row in every pass, and with its passes before
    the last on a quarter of the rows (the thresholds lowered to make it a long span)."""
    root = tmp_path_factory.mktemp("thin")
    metrics, logs = {}, {}
    for name in ("whole", "thinned"):
        cfg = simulate_scenario(root / name, seed=4, duration=120.0)
        mp = pytest.MonkeyPatch()
        if name == "thinned":
            mp.setattr(thinning, "THIN_ABOVE_ROWS", 1000)
            mp.setattr(thinning, "THIN_TARGET_ROWS", 1)
        handler, logger = _Collect(), logging.getLogger("rangeproc.fusion.centralised")
        level = logger.level
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        try:
            pipeline.run(cfg)
        finally:
            logger.removeHandler(handler)
            logger.setLevel(level)
            mp.undo()
        metrics[name] = evaluate_run(cfg.parent / "out", cfg.parent / "truth.csv")
        logs[name] = handler.lines
    return metrics, logs


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.INFO)
        self.lines: list[str] = []

    def emit(self, record):
        self.lines.append(record.getMessage())


def test_a_thinned_run_says_so_and_matches_the_whole_run_within_five_percent(thinned_and_whole):
    metrics, logs = thinned_and_whole
    assert any("long span" in line for line in logs["thinned"])
    assert not any("long span" in line for line in logs["whole"])
    whole, thin = metrics["whole"]["targets"]["T1"], metrics["thinned"]["targets"]["T1"]
    for key in ("pos_rmse", "vel_rmse"):               # no worse than 5 % (nor suspiciously
        assert 0.8 * whole[key] <= thin[key] <= 1.05 * whole[key], key   # better)
    # both conservative (about 0.4): the calibration terms left uncorrected enter the sigma
    # with the square of their estimates (estimation.consider), which differ by their noise
    assert thin["nees_pos_mean"] == pytest.approx(whole["nees_pos_mean"], rel=0.2)
    assert min(thin["inside_3sigma_enu"]) >= 0.95


def _thinned_span(monkeypatch, fail_call: int | None = None, filter_name: str = "ekf"):
    """A 100 Hz GPS minute, its passes before the last on every 4th row; the run_pass calls."""
    from rangeproc.errors import NumericalError
    from rangeproc.fusion import centralised, refinement
    from rangeproc.fusion.centralised import fuse_span
    from rangeproc.fusion.estimator_types import EstimatorSettings
    from rangeproc.settings import ProcessingSettings

    from conftest import gps_line_batch

    monkeypatch.setattr(thinning, "THIN_ABOVE_ROWS", 1000)
    monkeypatch.setattr(thinning, "THIN_TARGET_ROWS", 1500)
    monkeypatch.setattr(thinning, "MIN_SERIES_ROWS", 10)
    monkeypatch.setattr(thinning, "MIN_THIN_RATE_HZ", 1.0)
    calls = []
    real = centralised.run_pass

    def spy(batch, *args, **kwargs):
        calls.append(len(batch))
        if len(calls) == fail_call:
            raise NumericalError("injected failure")
        return real(batch, *args, **kwargs)

    monkeypatch.setattr(centralised, "run_pass", spy)       # the first pass
    monkeypatch.setattr(refinement, "run_pass", spy)        # the refinement passes
    batch = gps_line_batch(np.arange(0.0, 60.0, 0.01), np.random.default_rng(8), noise=3.0,
                           velocity=(100.0, 50.0, -2.0), accel=(1.0, 0.0, 0.0))
    res = fuse_span(batch, 10.0, EstimatorSettings(
        processing=ProcessingSettings(noise_passes=2, filter=filter_name)))
    return batch, res, calls


def test_the_passes_before_the_last_see_the_thinned_rows_the_last_every_row(monkeypatch):
    batch, res, calls = _thinned_span(monkeypatch)
    assert calls == [1501, 1501, len(batch)]               # every 4th row and the last
    assert len(res.nis) == len(res.batch) == len(batch)
    assert np.isfinite(res.nis).sum() == len(batch)       # every row gated by the final pass
    assert res.used.shape == (len(batch), 6) and res.down_weight.shape == (len(batch), 6)
    assert len(res.q) == len(res.epoch_t)


def test_a_failed_thinned_pass_still_ends_with_a_pass_on_every_row(monkeypatch, caplog):
    with caplog.at_level(logging.WARNING, logger="rangeproc.fusion.centralised"):
        batch, res, calls = _thinned_span(monkeypatch, fail_call=2)
    assert "the pass it refines is kept" in caplog.text
    assert calls == [1501, 1501, 1501, len(batch)]        # pass 1 again, then every row
    assert len(res.nis) == len(batch) and np.isfinite(res.nis).all()


@pytest.mark.parametrize("filter_name", ["ukf", "imm", "sage-husa", "stukf", "askf", "spline"])
def test_every_filter_ends_a_thinned_span_on_every_row(monkeypatch, filter_name):
    batch, res, calls = _thinned_span(monkeypatch, filter_name=filter_name)
    assert calls[:2] == [1501, 1501] and calls[-1] == len(batch)
    assert len(res.nis) == len(batch) and len(res.q) == len(res.epoch_t)
    truth = np.array([0.0, 0.0, 3000.0]) + np.outer(res.epoch_t, (100.0, 50.0, -2.0)) \
        + 0.5 * np.outer(res.epoch_t ** 2, (1.0, 0.0, 0.0))
    assert np.sqrt(np.mean((res.xs[res.grid, :3] - truth[res.grid]) ** 2)) < 1.0
