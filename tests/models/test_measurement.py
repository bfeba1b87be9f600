"""Measurement models: values against independent geometry, Jacobians against finite differences."""
import numpy as np
import pymap3d
import pytest
from scipy.spatial.transform import Rotation

from rangeproc.models.measurement import CARTESIAN, SPHERICAL, measure_py, wrap_angle


def _random_case(rng):
    x = np.concatenate([rng.uniform(-40e3, 40e3, 2), rng.uniform(500, 9000, 1),
                        rng.uniform(-300, 300, 3), rng.uniform(-30, 30, 3)])
    s = np.array([rng.uniform(-5e3, 5e3), rng.uniform(-5e3, 5e3), rng.uniform(0, 100)])
    sv = rng.uniform(-10, 10, 3)
    Qr = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
    return x, s, sv, Qr


def _numeric_jacobian(model, x, s, sv, Qr, eps):
    n = len(x)
    J = np.zeros((6, n))
    for j in range(n):
        dx = np.zeros(n)
        dx[j] = eps[j]
        hp, _ = measure_py(model, x + dx, s, sv, Qr)
        hm, _ = measure_py(model, x - dx, s, sv, Qr)
        d = hp - hm
        d[1] = wrap_angle(d[1]) if model == SPHERICAL else d[1]
        J[:, j] = d / (2 * eps[j])
    return J


@pytest.mark.parametrize("model", [CARTESIAN, SPHERICAL])
def test_jacobian_matches_central_differences(model):
    rng = np.random.default_rng(3)
    for _ in range(50):
        x, s, sv, Qr = _random_case(rng)
        _, H = measure_py(model, x, s, sv, Qr)
        eps = np.array([1e-2] * 3 + [1e-4] * 3 + [1e-3] * 3)
        J = _numeric_jacobian(model, x, s, sv, Qr, eps)
        scale = np.maximum(np.abs(J), 1e-12)
        np.testing.assert_allclose(H, J, rtol=1e-5, atol=1e-9 * scale.max())


def test_spherical_matches_pymap3d_aer_at_a_fixed_site():
    """A fixed site: range ENU -> site ENU rotation, then AER equals pymap3d.geodetic2aer."""
    lat0, lon0, h0 = 34.9, -117.9, 700.0
    site = (35.0, -117.5, 713.0)
    tgt = (35.2, -117.7, 6000.0)
    e, n, u = pymap3d.geodetic2enu(*tgt, lat0, lon0, h0)
    se, sn, su = pymap3d.geodetic2enu(*site, lat0, lon0, h0)
    # rotation range ENU -> site ENU, built from pymap3d's own enu2uvw at both points
    def enu_axes(lat, lon):
        return np.array([pymap3d.enu2uvw(*v, lat, lon) for v in np.eye(3)])  # rows: E,N,U in ECEF
    Qr = enu_axes(site[0], site[1]) @ enu_axes(lat0, lon0).T
    x = np.array([e, n, u, 0, 0, 0, 0, 0, 0.0])
    h, _ = measure_py(SPHERICAL, x, np.array([se, sn, su]), np.zeros(3), Qr)
    az, el, r = pymap3d.geodetic2aer(*tgt, *site)
    assert h[0] == pytest.approx(r, abs=1e-6)
    assert wrap_angle(h[1] - np.radians(az)) == pytest.approx(0.0, abs=1e-10)
    assert h[2] == pytest.approx(np.radians(el), abs=1e-10)


def test_range_rate_equals_derivative_of_range():
    """Seed 000 eq. 2: Rdot = alpha^T v / R equals d|p - s|/dt along the motion."""
    rng = np.random.default_rng(5)
    x, s, sv, Qr = _random_case(rng)
    dt = 1e-4
    p0, v = x[:3], x[3:6] - sv

    def r(t):
        return np.linalg.norm(p0 + v * t - s)

    h, _ = measure_py(SPHERICAL, x, s, sv, Qr)
    assert h[3] == pytest.approx((r(dt) - r(-dt)) / (2 * dt), rel=1e-7)


def test_wrap_angle_range():
    a = np.linspace(-20, 20, 4001)
    w = np.array([wrap_angle(v) for v in a])
    assert (w > -np.pi).all() and (w <= np.pi).all()
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
