"""Segment scores (``tracking.score``) against an independent computation: GPS-like Cartesian
rows at the object's epochs, where S = P_pos + R and the llr is a plain Gaussian mixture."""
from __future__ import annotations

import math
import warnings

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import CARTESIAN
from rangeproc.tracking.score import (
    BIAS_SIGMAS,
    BIAS_TOLERANCE_CARTESIAN,
    EXTENT_CARTESIAN,
    OUTLIER_PROBABILITY,
    ObjectTrack,
    score_rows,
    segment_score,
)


def _case(rng: np.random.Generator, bias: float):
    n = 40
    t = np.arange(n) * 0.5
    x = np.zeros((n, 9))
    x[:, 0], x[:, 3] = 100.0 + 30.0 * t, 30.0
    x[:, 1], x[:, 4] = -50.0 + 10.0 * t, 10.0
    A = rng.normal(size=(n, 9, 9)) * 0.5
    P = A @ A.transpose(0, 2, 1) + 4.0 * np.eye(9)
    track = ObjectTrack(t, x, P, np.full(n, 1.0))
    sigma = np.zeros((n, 6))
    sigma[:, :3] = 3.0
    z = np.full((n, 6), np.nan)
    z[:, :3] = x[:, :3] + rng.normal(size=(n, 3)) * 3.0 + bias
    z[7, :3] += 400.0                                        # a wild row
    batch = MeasurementBatch(t, np.full(n, CARTESIAN), z, sigma, np.zeros((n, 3)),
                             np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                             np.zeros(n, np.int64), np.arange(n), np.full(n, -1),
                             np.full(n, -1), ("G1",))
    return batch, track


def _expected_llr(batch: MeasurementBatch, track: ObjectTrack, off: np.ndarray) -> np.ndarray:
    eps = OUTLIER_PROBABILITY
    out = []
    for i in range(batch.t.size):
        nu = batch.z[i, :3] - off[:3] - track.x[i, :3]
        S = track.P[i, :3, :3] + np.diag(batch.sigma[i, :3] ** 2)
        d2 = float(nu @ np.linalg.solve(S, nu))
        log_n = -0.5 * d2 - 0.5 * math.log(np.linalg.det(2.0 * math.pi * S))
        log_ratio = log_n + float(np.log(EXTENT_CARTESIAN[:3]).sum())
        out.append(math.log((1.0 - eps) * math.exp(log_ratio) + eps))
    return np.array(out)


def test_row_scores_are_the_gaussian_mixture_llr() -> None:
    batch, track = _case(np.random.default_rng(3), 0.0)
    rows = np.arange(batch.t.size)
    res, nis, llr = score_rows(batch, rows, track)
    np.testing.assert_allclose(llr, _expected_llr(batch, track, np.zeros(6)), rtol=1e-9)
    np.testing.assert_allclose(res[:, :3], batch.z[:, :3] - track.x[:, :3], atol=1e-9)
    assert np.isnan(res[:, 3:]).all() and llr[7] < math.log(OUTLIER_PROBABILITY) + 1e-6


def test_segment_score_removes_the_clipped_median_offset() -> None:
    """A 6 m bias per axis: removed up to min(10 m, 3 sigma = 9 m) per axis, so the segment
    scores as the offset-free rows do."""
    batch, track = _case(np.random.default_rng(4), 6.0)
    rows = np.arange(batch.t.size)
    total, off, llr = segment_score(batch, rows, track)
    tol = np.minimum(BIAS_TOLERANCE_CARTESIAN, BIAS_SIGMAS * 3.0)
    median = np.median(batch.z[:, :3] - track.x[:, :3], axis=0)
    np.testing.assert_allclose(off[:3], np.clip(median, -tol[:3], tol[:3]), atol=1e-12)
    assert 4.0 < off[:3].min() and off[:3].max() < 8.0
    np.testing.assert_allclose(llr, _expected_llr(batch, track, off), rtol=1e-9)
    assert total == llr.sum()
    unbiased = score_rows(batch, rows, track)[2].sum()
    assert total > unbiased + 10.0                           # the bias would have cost


def test_clipped_median_offset_equals_the_numpy_computation() -> None:
    """The compiled offset equals median / nanmedian / clip in numpy, NaNs and an all-NaN
    component included."""
    from rangeproc.tracking.score import clipped_median_offset

    rng = np.random.default_rng(11)
    for m in (1, 2, 7, 40):
        res = rng.normal(scale=20.0, size=(m, 6))
        res[rng.random((m, 6)) < 0.3] = np.nan
        res[:, 5] = np.nan
        sig = np.abs(rng.normal(scale=4.0, size=(m, 6)))
        sig[rng.random((m, 6)) < 0.2] = np.nan
        tol = np.array([50.0, 2e-3, 2e-3, 1.0, 0.0, 0.0]) * 1e3
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            cap = np.minimum(tol, BIAS_SIGMAS * np.nan_to_num(np.nanmedian(sig, axis=0), nan=0.0))
        med = np.array([np.median(v[np.isfinite(v)]) if np.isfinite(v).any() else 0.0
                        for v in res.T])
        got = clipped_median_offset(res, sig, np.arange(m), tol, BIAS_SIGMAS)
        np.testing.assert_array_equal(got, np.clip(med, -cap, cap))


def _one_row(t: float, p: np.ndarray, sigma: float) -> MeasurementBatch:
    z = np.full((1, 6), np.nan)
    z[0, :3] = p
    sig = np.zeros((1, 6))
    sig[0, :3] = sigma
    return MeasurementBatch(np.array([t]), np.array([CARTESIAN]), z, sig, np.zeros((1, 3)),
                            np.zeros((1, 3)), np.eye(3)[None], np.zeros(1, np.int64),
                            np.arange(1), np.full(1, -1), np.full(1, -1), ("G1",))


def test_a_row_beyond_the_span_is_carried_with_the_bridges_gap_noise() -> None:
    """A row 20 s after (or before) an aircraft's trajectory is predicted with the bridge's
    gap noise (``fusion.bridge``: white jerk of the track's q plus the manoeuvre PSD its end
    speed allows), computed here from the bridge's own numpy functions; a backward carry
    flips the position-velocity terms. Without the manoeuvre the same row, 1.2 km off the
    straight line (a turn flown in the gap), would lie far outside any gate."""
    from rangeproc.fusion.bridge import ca_transition, gap_noise
    from rangeproc.models.motion import manoeuvre_psd
    from rangeproc.quantiles import chi2_ppf
    n = 11
    t = np.arange(n) * 1.0
    x = np.zeros((n, 9))
    x[:, 0], x[:, 3] = 200.0 * t, 200.0
    P = np.tile(np.diag([25.0] * 3 + [4.0] * 3 + [1.0] * 3), (n, 1, 1))
    q = 0.05
    track = ObjectTrack(t, x, P, np.full(n, q))
    for end, dt in ((n - 1, 20.0), (0, -20.0)):
        xe, Pe = x[end], P[end]
        F = ca_transition(np.array([dt]))[0]
        qm = float(manoeuvre_psd(xe[None, 3:6], Pe[None, 3:6, 3:6])[0])
        Q = gap_noise(np.array([dt]), q, qm)[0]
        if dt < 0.0:                       # D Q D, D = diag(1, -1, 1) per axis
            d = np.diag([1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0])
            Q = d @ Q @ d
        xp, Pp = F @ xe, F @ Pe @ F.T + Q
        row = xp[:3] + np.array([0.0, 1200.0, 0.0])
        batch = _one_row(float(t[end] + dt), row, 10.0)
        _, nis, _ = score_rows(batch, np.array([0]), track)
        S = Pp[:3, :3] + 100.0 * np.eye(3)
        nu = row - xp[:3]
        assert math.isclose(float(nis[0]), float(nu @ np.linalg.solve(S, nu)), rel_tol=1e-9)
        assert nis[0] < chi2_ppf(0.9999, 3)
        S0 = F @ Pe @ F.T + gap_noise(np.array([dt]), q, 0.0)[0]
        assert float(nu @ np.linalg.solve(S0[:3, :3] + 100.0 * np.eye(3), nu)) > chi2_ppf(
            0.9999, 3)
