"""A pass being refined lets its smoothed covariances go before the registration and the noise
estimate run on it (``fusion.refinement``, ``fusion.passes.without_covariances``): they are a
span's largest array and nothing between the passes reads them. The residuals of corrected rows
and the calibration's covariance are computed without them, or without full-size copies, and
with the same values."""
from __future__ import annotations

import weakref
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import rangeproc.pipeline as pipeline
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.fusion import centralised, refinement
from rangeproc.fusion.centralised import fuse_span
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.passes import PassResult, corrected_residuals, without_covariances
from rangeproc.fusion.registration import Calibration, spans_calibration_covariance
from rangeproc.settings import ProcessingSettings

from conftest import SAMPLE_CONFIG, gps_line_batch


class _Watch:
    """Weak references to the covariances of every pass run; at each watched call, whether
    the latest pass's were still alive."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.latest: weakref.ref | None = None
        self.alive_at: list[tuple[str, bool]] = []
        for module in (centralised, refinement):
            monkeypatch.setattr(module, "run_pass", self._passes(module.run_pass))

    def _passes(self, real):  # noqa: ANN001, ANN202
        def run(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
            out = real(*args, **kwargs)
            self.latest = weakref.ref(out.Ps)     # not the result: the watch holds nothing
            return out
        return run

    def watch(self, monkeypatch: pytest.MonkeyPatch, name: str) -> None:
        real = getattr(refinement, name)

        def watched(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
            self.alive_at.append((name, self.latest is not None and self.latest() is not None))
            return real(*args, **kwargs)
        monkeypatch.setattr(refinement, name, watched)


def test_the_refined_pass_has_let_its_covariances_go_at_the_noise_estimate(monkeypatch):
    w = _Watch(monkeypatch)
    for name in ("residual_sigma", "local_process_noise"):
        w.watch(monkeypatch, name)
    batch = gps_line_batch(np.arange(0.0, 60.0, 0.25), np.random.default_rng(5), noise=3.0,
                           velocity=(100.0, 50.0, -2.0), accel=(1.0, 0.0, 0.0))
    result = fuse_span(batch, 2.0, EstimatorSettings(processing=ProcessingSettings(
        noise_passes=2)))
    assert len(w.alive_at) == 4                     # two rounds, both estimates: the check ran
    assert not any(alive for _, alive in w.alive_at), w.alive_at
    assert w.latest() is result.Ps                  # the final pass keeps its covariances
    assert result.Ps.shape == (len(result.epoch_t), 45)


def test_the_refined_pass_has_let_its_covariances_go_at_the_registration(
        scenario: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    w = _Watch(monkeypatch)
    w.watch(monkeypatch, "register")
    out = pipeline.run(scenario / SAMPLE_CONFIG)
    assert out.tracks
    registered = [alive for name, alive in w.alive_at if name == "register"]
    assert registered                               # the sample registers its sensors
    assert not any(registered)


def test_residuals_alone_are_the_residuals_with_the_explained_variance():
    rng = np.random.default_rng(2)
    batch = gps_line_batch(np.arange(0.0, 30.0, 0.5), rng)
    n = len(batch)
    xs = np.zeros((n, 9))
    xs[:, :3] = batch.z[:, :3] + rng.normal(0.0, 1.0, (n, 3))
    Ps = np.tile(np.eye(9)[np.tril_indices(9)], (n, 1)) * 4.0
    epochs = np.arange(n, dtype=np.int64)
    args = (epochs, batch.model, batch.z, batch.s, batch.sv, batch.Qr, xs)
    res, hph = smoothed_residuals(*args, Ps)
    alone, none = smoothed_residuals(*args, None)
    assert none is None
    np.testing.assert_array_equal(alone, res)
    assert np.isfinite(hph[:, :3]).all() and (hph[:, :3] > 0).all()


def test_corrected_residuals_do_not_read_the_covariances():
    batch = gps_line_batch(np.arange(0.0, 60.0, 0.25), np.random.default_rng(8))
    out = fuse_span(batch, 2.0, EstimatorSettings(processing=ProcessingSettings(
        noise_passes=1)))
    z = out.batch.z.copy()
    z[:, 0] -= 5.0                                 # a bias taken out of the rows
    moved = replace(out.batch, z=z)
    result = PassResult(out.xs, out.Ps, None, out.nis, out.dof, out.used, out.res, out.hph,
                        out.n_resets, out.batch)
    full = corrected_residuals(moved, [0], result, out.meas_epoch)
    gone = corrected_residuals(moved, [0], without_covariances(result), out.meas_epoch)
    np.testing.assert_array_equal(gone, full)
    np.testing.assert_allclose(full[:, 0], out.res[:, 0] - 5.0, atol=1e-9)
    assert without_covariances(result).Ps.size == 0


def test_calibration_covariance_columns_are_those_of_the_whole():
    rng = np.random.default_rng(4)
    node_t = np.linspace(0.0, 10.0, 11)
    A = rng.normal(size=(11, 9, 9))
    cal = Calibration((), np.zeros(0), np.zeros(0), np.zeros((0, 0)), (), node_t,
                      np.einsum("gij,gkj->gik", A, A))
    t = np.linspace(-1.0, 11.0, 50)
    whole = spans_calibration_covariance((cal,), t)
    cols = (0, 2, 5)
    np.testing.assert_array_equal(spans_calibration_covariance((cal,), t, cols),
                                  whole[:, list(cols)])
    assert (whole[(t < 0) | (t > 10)] == 0.0).all()
