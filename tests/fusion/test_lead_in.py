"""A span's lead-in (angle-only rows long before the first position fix) is estimated
backwards in time from the fix (``fusion.lead_in``)."""
from __future__ import annotations

import numpy as np
import pytest

import rangeproc.fusion.centralised as centralised
import rangeproc.fusion.lead_in as lead_in
from rangeproc.estimation.linalg import unpack_many
from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_span, output_grid
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.lead_in import forward_in_time, lead_in_rows, time_reversed
from rangeproc.estimation.imm_models import CA
from rangeproc.models.measurement import SPHERICAL, measure_py
from rangeproc.settings import ProcessingSettings

RATE_HZ = 5.0
THEODOLITE_SITE = np.array([-12000.0, 3000.0, 300.0])


def truth(t: np.ndarray, a: float = 30.0) -> np.ndarray:
    """(N, 9) state: 200 m/s east at 4 km height, a turn to the north at ``a`` m/s^2 (3 g)
    over 10-20 s (the lead-in), straight after it; ``a = 0``: straight throughout."""
    x = np.zeros((t.size, 9))
    for k, tk in enumerate(t):
        v = np.array([200.0, 0.0, 0.0])
        p = np.array([-20000.0 + 200.0 * tk, 5000.0, 4000.0])
        acc = np.zeros(3)
        if tk > 10.0 and a > 0.0:           # a constant-rate turn: v rotates at a / |v|
            w = a / 200.0
            th = w * (min(tk, 20.0) - 10.0)
            p = np.array([-20000.0 + 2000.0 + 200.0 * np.sin(th) / w,
                          5000.0 + 200.0 * (1.0 - np.cos(th)) / w, 4000.0])
            v = 200.0 * np.array([np.cos(th), np.sin(th), 0.0])
            acc = a * np.array([-np.sin(th), np.cos(th), 0.0]) if tk < 20.0 else acc
            if tk > 20.0:
                p = p + v * (tk - 20.0)
        x[k, 0:3], x[k, 3:6], x[k, 6:9] = p, v, acc
    return x


def spherical_rows(t: np.ndarray, site: np.ndarray, sigma: np.ndarray, measured: list[int],
                   rng: np.random.Generator, turn: float) -> SensorRows:
    n = t.size
    a = empty_rows(n, SPHERICAL)
    a["s"][:] = site
    x = truth(t, turn)
    for k in range(n):
        h, _ = measure_py(SPHERICAL, x[k], site, np.zeros(3), np.eye(3))
        a["z"][k, measured] = h[measured] + rng.normal(0.0, sigma[measured])
    a["sigma"][:, :4] = sigma
    return SensorRows(t=t, source_row=np.arange(n), station=np.full(n, -1),
                      track=np.full(n, -1), **a)


def scenario(seed: int, turn: float = 30.0):
    """A theodolite from 0 s, a radar (range, angles, range rate) only from 35 s."""
    rng = np.random.default_rng(seed)
    theo = spherical_rows(np.arange(0.0, 60.0, 0.1), THEODOLITE_SITE,
                          np.array([1.0, 7e-5, 7e-5, 1.0]), [1, 2], rng, turn)
    radar = spherical_rows(np.arange(35.0, 60.0, 0.05), np.zeros(3),
                           np.array([5.0, 5e-4, 5e-4, 0.1]), [0, 1, 2, 3], rng, turn)
    return merge([(0, theo), (1, radar)], ("TH1", "R1"))


def errors(res, turn: float = 30.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output epochs (s), position errors (K, 3) m and covariances (K, 3, 3)."""
    t = res.epoch_t[res.grid]
    err = res.xs[res.grid, :3] - truth(t, turn)[:, :3]
    return t, err, unpack_many(res.Ps[res.grid], res.xs.shape[1], 3)


def test_time_reversal_is_its_own_inverse() -> None:
    b = scenario(1)
    back = time_reversed(time_reversed(b))
    for name in ("t", "model", "z", "sigma", "s", "sv", "Qr", "sensor", "source_row"):
        np.testing.assert_array_equal(getattr(back, name), getattr(b, name))
    rev = time_reversed(b)
    assert np.all(np.diff(rev.t) >= 0.0)
    radar = np.isfinite(b.z[:, 3])
    np.testing.assert_array_equal(rev.z[::-1][radar, 3], -b.z[radar, 3])


def test_a_reversed_run_reproduces_the_forward_smoother() -> None:
    """The time-reversed problem (rows, rates and velocities turned) is the same problem: its
    smoothed track, turned back, matches the forward one well inside their sigmas, and the
    range rates pass the gate alike (a wrong sign would reject them all)."""
    b = scenario(2)
    rest = b.rows(slice(lead_in_rows(b), None))
    grid = output_grid(rest.t[0], rest.t[-1], RATE_HZ)
    st = EstimatorSettings(processing=ProcessingSettings(noise_passes=1))
    fwd = fuse_span(rest, RATE_HZ, st, grid_t=grid)
    back = forward_in_time(fuse_span(time_reversed(rest), RATE_HZ, st,
                                     grid_t=np.ascontiguousarray(-grid[::-1])))
    np.testing.assert_array_equal(back.epoch_t, fwd.epoch_t)
    sig = np.sqrt(unpack_many(fwd.Ps[fwd.grid], 9)[:, [0, 1, 2], [0, 1, 2]])
    middle = slice(50, -50)                       # away from both starts
    diff = np.abs(back.xs[back.grid, :3] - fwd.xs[fwd.grid, :3])
    assert (diff[middle] < 0.3 * sig[middle]).all()
    assert abs(back.used[:, 3].mean() - fwd.used[:, 3].mean()) < 0.01
    assert fwd.used[np.isfinite(rest.z[:, 3]), 3].mean() > 0.95
    np.testing.assert_array_equal(back.batch.source_row, rest.source_row)


@pytest.mark.parametrize("seed", [3, 4])
def test_an_angle_only_lead_in_is_estimated_honestly_and_the_rest_as_if_it_started_at_the_fix(
        seed: int) -> None:
    b = scenario(seed)
    k = lead_in_rows(b)
    assert k > 0 and b.t[k] == pytest.approx(35.0)
    st = EstimatorSettings()
    res = fuse_span(b, RATE_HZ, st)
    assert res.spans == ((0.0, float(b.t[-1])),)
    assert len(res.batch) == len(b) and np.all(np.diff(res.epoch_t) >= 0.0)
    np.testing.assert_array_equal(res.batch.source_row, b.source_row)
    np.testing.assert_array_equal(res.epoch_t[res.grid], output_grid(0.0, b.t[-1], RATE_HZ))
    # from the fix on: exactly the run that starts there
    rest = fuse_span(b.rows(slice(k, None)), RATE_HZ, st,
                     grid_t=output_grid(35.0, b.t[-1], RATE_HZ))
    after = res.epoch_t >= 35.0
    np.testing.assert_array_equal(res.xs[after], rest.xs)
    # the lead-in: its errors are explained by its covariance (position NEES, 3 dof)
    t, err, P = errors(res)
    early = t < 35.0
    nees = np.einsum("ni,nij,nj->n", err[early], np.linalg.inv(P[early]), err[early])
    assert 1.0 < nees.mean() < 6.0              # 2.4 and 3.3 on these seeds
    assert nees.max() < 25.9                    # chi-square 3 dof, 1 - 1e-5
    # ... and after the fix the radar ties it down
    assert np.sqrt((err[~early] ** 2).sum(axis=1).mean()) < 1.0


def test_the_start_extrapolated_back_to_the_first_row_was_wrong_and_overconfident(
        monkeypatch) -> None:
    """Before the lead-in was estimated backwards, the start was extrapolated from the
    fixes over the whole lead-in with a 100 m sigma: on this flight (a turn in the lead-in)
    it was kilometres off, the lead-in's covariance did not cover its errors, and the track
    after the fix was spoilt too (the gate had rejected the radar)."""
    b = scenario(5)
    st = EstimatorSettings()
    out = {}
    for name, lead_s in (("backwards", lead_in.LEAD_IN_S), ("extrapolated", np.inf)):
        monkeypatch.setattr(lead_in, "LEAD_IN_S", lead_s)
        t, err, P = errors(fuse_span(b, RATE_HZ, st))
        early = t < 35.0
        nees = np.einsum("ni,nij,nj->n", err[early], np.linalg.inv(P[early]), err[early])
        out[name] = (nees.mean(), np.sqrt((err[~early] ** 2).sum(axis=1).mean()))
    assert out["backwards"][0] < 6.0 < 20.0 < out["extrapolated"][0]
    assert out["backwards"][1] < 1.0 < 50.0 < out["extrapolated"][1]


def test_a_straight_lead_in_is_carried_back_by_the_constant_velocity_model(monkeypatch) -> None:
    """Angles alone do not range the object: its lead-in is the fix's state carried back. The
    constant-acceleration model alone carries the acceleration estimated at the fix back too
    (its error grows with the square of the time); the IMM's constant-velocity model does
    not, so on a straight flight its lead-in is far closer, and honest either way."""
    b = scenario(7, turn=0.0)
    out = {}
    for name, models in (("imm", centralised.LEAD_IN_MODELS), ("ca", (CA,))):
        monkeypatch.setattr(centralised, "LEAD_IN_MODELS", models)
        t, err, P = errors(fuse_span(b, RATE_HZ, EstimatorSettings()), turn=0.0)
        early = t < 35.0
        nees = np.einsum("ni,nij,nj->n", err[early], np.linalg.inv(P[early]), err[early])
        out[name] = (np.sqrt((err[early] ** 2).sum(axis=1).mean()), nees.mean())
    assert out["imm"][0] < 0.5 * out["ca"][0], out
    assert out["imm"][1] < 6.0, out
