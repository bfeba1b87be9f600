"""Per-sensor segmentation: a track is cut where the sensor jumped to another object."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.tracking.segments import _predict, _update, segment_track


def test_scalar_ca_predict_and_update_equal_the_matrix_form() -> None:
    rng = np.random.default_rng(0)
    for _ in range(5):
        a = rng.normal(size=(3, 3))
        P = a @ a.T
        x = rng.normal(size=3)
        dt, q, r, z = rng.uniform(0.01, 2.0), rng.uniform(0.1, 5.0), 0.5, 1.3
        F = np.array([[1, dt, dt * dt / 2], [0, 1, dt], [0, 0, 1]])
        Q = q * np.array([[dt**5 / 20, dt**4 / 8, dt**3 / 6], [dt**4 / 8, dt**3 / 3, dt**2 / 2],
                          [dt**3 / 6, dt**2 / 2, dt]])
        xe, Pe = F @ x, F @ P @ F.T + Q
        xs, Ps = x.copy(), P.copy()
        _predict(xs, Ps, dt, q)
        np.testing.assert_allclose(xs, xe, atol=1e-12)
        np.testing.assert_allclose(Ps, Pe, atol=1e-12)
        k = Pe[:, 0] / (Pe[0, 0] + r)
        _update(xs, Ps, z, r)
        np.testing.assert_allclose(xs, xe + k * (z - xe[0]), atol=1e-12)
        np.testing.assert_allclose(Ps, Pe - np.outer(k, Pe[0]), atol=1e-12)


def turning_track(n: int = 2400, rate: float = 20.0, seed: int = 1):
    """Range (m), azimuth, elevation (rad) of a 250 m/s aircraft in a 5 g turn 20 km out."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    omega = 50.0 / 250.0
    e = 20_000.0 + 1250.0 * np.sin(omega * t)
    nn = 5_000.0 + 1250.0 * (1 - np.cos(omega * t))
    u = 3_000.0 + 20.0 * t
    r = np.sqrt(e * e + nn * nn + u * u)
    z = np.column_stack([r + rng.normal(0, 5.0, n),
                         np.mod(np.arctan2(e, nn), 2 * np.pi) + rng.normal(0, 2e-4, n),
                         np.arcsin(u / r) + rng.normal(0, 2e-4, n)])
    return t, z


def test_one_object_hard_turning_stays_one_segment_despite_wild_values() -> None:
    t, z = turning_track()
    z[[100, 900, 901, 1500], 0] += [400.0, -300.0, 500.0, 800.0]
    seg = segment_track(t, z, angle_columns=(1,))
    assert seg.label.max() == 0
    assert {100, 900, 901, 1500} <= set(np.flatnonzero(seg.rejected))


@pytest.mark.parametrize(("column", "jump"), [(0, 300.0), (1, 0.01), (2, -0.006)])
def test_a_jump_to_another_object_starts_a_segment_exactly_there(column, jump) -> None:
    t, z = turning_track()
    z[1300:, column] += jump
    seg = segment_track(t, z, angle_columns=(1,))
    assert (np.flatnonzero(np.diff(seg.label)) + 1).tolist() == [1300]


def test_angle_only_track_is_segmented_and_gaps_end_segments() -> None:
    t, z = turning_track()
    z = z[:, 1:].copy()
    z[700:, 0] += 0.02                              # operator slews to another object
    keep = (t < 80.0) | (t > 86.0)                  # and a 6 s gap later on
    seg = segment_track(t[keep], z[keep], angle_columns=(0,))
    cuts = t[keep][np.flatnonzero(np.diff(seg.label)) + 1]
    np.testing.assert_allclose(cuts, [t[700], 86.0 + 1 / 20.0], atol=1e-9)
