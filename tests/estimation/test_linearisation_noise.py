"""The EKF's linearisation error added to radar/theodolite sigmas, against Monte Carlo."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.estimation.moments import LIN_NOISE_CAP, add_linearisation_noise
from rangeproc.models.measurement import SPHERICAL, measure_py


def _monte_carlo_variance(x, s, Qr, P, n=400_000, seed=7):
    """Variance per component of h(x + e) - h(x) - H e, e ~ N(0, P) in position."""
    rng = np.random.default_rng(seed)
    h0, H = measure_py(SPHERICAL, x, s, np.zeros(3), Qr)
    e = rng.multivariate_normal(np.zeros(3), P[:3, :3], size=n)
    d = (Qr @ (x[:3] + e - s).T).T
    rho = np.hypot(d[:, 0], d[:, 1])
    r = np.linalg.norm(d, axis=1)
    h = np.column_stack([r, np.arctan2(d[:, 0], d[:, 1]), np.arctan2(d[:, 2], rho)])
    lin = h0[:3] + e @ H[:3, :3].T
    err = h - lin
    err[:, 1] = (err[:, 1] + np.pi) % (2 * np.pi) - np.pi
    return err.var(axis=0)


@pytest.mark.parametrize("case", ["near_zenith", "elongated_along_sight", "rotated_platform"])
def test_the_added_variance_is_the_second_order_error_of_the_expansion(case) -> None:
    """Azimuth and elevation: the variance added to each sigma equals the Monte Carlo
    variance of the expansion's error (to 10 %, second-order theory against the exact
    functions), for a target passing near a theodolite's zenith with a 30 m prior, a prior
    stretched along the line of sight, and a rolled and pitched ship-borne sensor, each below
    the cap. (Where
    the prior's sigma approaches a third of the range, higher orders take over and the
    Monte Carlo tails grow without bound; second order is then a floor, not the value.)"""
    x = np.zeros(9)
    s = np.array([100.0, -50.0, 20.0])
    Qr = np.eye(3)
    if case == "near_zenith":
        x[:3] = s + [800.0, 900.0, 5000.0]
        P = np.diag([30.0**2] * 3 + [1.0] * 6)
    elif case == "elongated_along_sight":
        x[:3] = s + [3000.0, 4000.0, 1500.0]
        u = (x[:3] - s) / np.linalg.norm(x[:3] - s)
        P = np.eye(9)
        P[:3, :3] = 30.0**2 * np.eye(3) + (400.0**2 - 30.0**2) * np.outer(u, u)
    else:
        from scipy.spatial.transform import Rotation

        Qr = Rotation.from_euler("xyz", [8.0, -5.0, 30.0], degrees=True).as_matrix()
        x[:3] = s + [1500.0, 700.0, 2500.0]
        P = np.diag([50.0**2, 25.0**2, 40.0**2] + [1.0] * 6)
    sig0 = np.array([1e-7, 1e-7])                             # tiny: the extra is all there is
    sig = sig0.copy()
    add_linearisation_noise(SPHERICAL, sig, np.array([1, 2]), 2, x, s, Qr, P)
    extra = sig**2 - sig0**2
    mc = _monte_carlo_variance(x, s, Qr, P)
    assert extra.max() < LIN_NOISE_CAP**2                    # the formula, not the cap
    np.testing.assert_allclose(extra, mc[1:], rtol=0.10)


def test_the_added_sigma_is_capped() -> None:
    """A 200 m prior 1.2 km from the zenith: 0.035 rad of expansion error in azimuth, more
    than the cap, which is what is added (a row must keep some information)."""
    x = np.zeros(9)
    x[:3] = [800.0, 900.0, 5000.0]
    P = np.diag([200.0**2] * 3 + [1.0] * 6)
    assert _monte_carlo_variance(x, np.zeros(3), np.eye(3), P)[1] > 10 * LIN_NOISE_CAP**2
    sig = np.array([1e-7, 1e-7])
    add_linearisation_noise(SPHERICAL, sig, np.array([1, 2]), 2, x, np.zeros(3), np.eye(3), P)
    np.testing.assert_allclose(sig[0], np.hypot(1e-7, LIN_NOISE_CAP))


def test_a_row_with_a_range_is_left_as_it_is() -> None:
    """A radar row fixes the position by itself: its sigmas are not widened, whatever the
    prior (the filter's first update removes the expansion's error)."""
    x = np.zeros(9)
    x[:3] = [800.0, 900.0, 5000.0]
    sig = np.array([5.0, 1e-4, 1e-4])
    before = sig.copy()
    add_linearisation_noise(SPHERICAL, sig, np.array([0, 1, 2]), 3, x, np.zeros(3),
                            np.eye(3), np.diag([200.0**2] * 3 + [1.0] * 6))
    np.testing.assert_array_equal(sig, before)


def test_a_converged_track_leaves_the_row_unchanged() -> None:
    """1 m of position sigma at 10 km: below the share worth evaluating, bit-identical."""
    x = np.zeros(9)
    x[:3] = [6000.0, 8000.0, 1000.0]
    sig = np.array([5e-4, 5e-4])
    before = sig.copy()
    add_linearisation_noise(SPHERICAL, sig, np.array([1, 2]), 2, x, np.zeros(3),
                            np.eye(3), np.eye(9))
    np.testing.assert_array_equal(sig, before)
