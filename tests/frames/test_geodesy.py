"""Geodesy: reference values, round trips (hypothesis) and equivalence with pyproj / pymap3d."""
from __future__ import annotations

import numpy as np
import pymap3d
import pyproj
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rangeproc.config import Geodetic
from rangeproc.frames.geodesy import (
    RangeFrame,
    aer_to_enu,
    ecef_to_enu_matrix,
    ecef_to_geodetic,
    enu_to_aer,
    geodetic_to_ecef,
)

A = 6378137.0
B = 6356752.314245  # WGS-84 semi-minor axis, m
HYP = settings(derandomize=True, deadline=None, max_examples=150)

LLH_TO_ECEF = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
ECEF_TO_LLH = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)

lats = st.floats(-90.0, 90.0)
lons = st.floats(-180.0, 180.0)
heights = st.floats(-1.0e4, 1.0e6)


def pyproj_topocentric(origin: Geodetic) -> pyproj.Transformer:
    """Independent geodetic (lon, lat deg, h) -> ENU at origin, via PROJ."""
    return pyproj.Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        "+step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={origin.lat!r} +lon_0={origin.lon!r} "
        f"+h_0={origin.height!r}"
    )


def lon_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


# ---------------------------------------------------------------- reference values

@pytest.mark.parametrize(
    ("llh", "xyz"),
    [
        ((0.0, 0.0, 0.0), (A, 0.0, 0.0)),
        ((90.0, 0.0, 0.0), (0.0, 0.0, B)),
        ((-90.0, 0.0, 0.0), (0.0, 0.0, -B)),
        ((0.0, 90.0, 0.0), (0.0, A, 0.0)),
        ((0.0, -90.0, 1000.0), (0.0, -(A + 1000.0), 0.0)),
        ((0.0, 180.0, 0.0), (-A, 0.0, 0.0)),
        ((0.0, -180.0, 500.0), (-(A + 500.0), 0.0, 0.0)),
        ((90.0, 123.0, 100.0), (0.0, 0.0, B + 100.0)),
    ],
)
def test_reference_values(llh, xyz):
    np.testing.assert_allclose(geodetic_to_ecef(*llh), xyz, rtol=0, atol=1e-6)
    lat, lon, h = ecef_to_geodetic(np.array(xyz))
    assert lat == pytest.approx(llh[0], abs=1e-12)
    assert h == pytest.approx(llh[2], abs=1e-6)
    if abs(llh[0]) < 90.0:
        assert lon_diff(lon, llh[1]) == pytest.approx(0.0, abs=1e-12)
        assert -180.0 < lon <= 180.0


def test_earth_centre_is_minus_a():
    lat, _, h = ecef_to_geodetic([0.0, 0.0, 0.0])
    assert lat == 0.0 and h == pytest.approx(-A)


def test_shapes_and_broadcasting():
    assert geodetic_to_ecef(1.0, 2.0, 3.0).shape == (3,)
    out = geodetic_to_ecef(np.zeros((4, 1)), np.zeros(5), 0.0)
    assert out.shape == (4, 5, 3) and out.dtype == np.float64
    lat, lon, h = ecef_to_geodetic(np.ones((2, 7, 3)) * 7e6)
    assert lat.shape == lon.shape == h.shape == (2, 7)
    assert ecef_to_enu_matrix(np.zeros(6), 0.0).shape == (6, 3, 3)
    with pytest.raises(ValueError):
        ecef_to_geodetic(np.ones((3, 2)))


# ---------------------------------------------------------------- against pyproj

def test_geodetic_to_ecef_matches_pyproj():
    rng = np.random.default_rng(1)
    n = 5000
    lat, lon, h = rng.uniform(-90, 90, n), rng.uniform(-180, 180, n), rng.uniform(-1e4, 2e6, n)
    ref = np.stack(LLH_TO_ECEF.transform(lon, lat, h), axis=-1)
    np.testing.assert_allclose(geodetic_to_ecef(lat, lon, h), ref, rtol=0, atol=1e-6)


def test_ecef_to_geodetic_matches_pyproj_inverse():
    """PROJ's own inverse (Bowring) is good to ~1e-6 m only below ~10 km: compare there."""
    rng = np.random.default_rng(2)
    n = 5000
    lat, lon, h = rng.uniform(-90, 90, n), rng.uniform(-180, 180, n), rng.uniform(-1e3, 1e4, n)
    xyz = np.stack(LLH_TO_ECEF.transform(lon, lat, h), axis=-1)
    ref_lon, ref_lat, ref_h = ECEF_TO_LLH.transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    glat, glon, gh = ecef_to_geodetic(xyz)
    metres_per_deg = np.radians(1.0) * (A + h)
    assert np.max(np.abs(glat - ref_lat) * metres_per_deg) < 5e-6
    assert np.max(np.abs(lon_diff(glon, ref_lon)) * metres_per_deg) < 1e-6
    assert np.max(np.abs(gh - ref_h)) < 5e-6


def test_ecef_to_geodetic_recovers_pyproj_forward_inputs_up_to_2000_km():
    """Truth = the geodetic inputs of PROJ's (exact, closed-form) forward transform."""
    rng = np.random.default_rng(3)
    n = 5000
    lat, lon, h = rng.uniform(-90, 90, n), rng.uniform(-180, 180, n), rng.uniform(-1e4, 2e6, n)
    xyz = np.stack(LLH_TO_ECEF.transform(lon, lat, h), axis=-1)
    glat, glon, gh = ecef_to_geodetic(xyz)
    metres_per_deg = np.radians(1.0) * (A + h)
    assert np.max(np.abs(glat - lat) * metres_per_deg) < 1e-6
    assert np.max(np.abs(lon_diff(glon, lon)) * metres_per_deg) < 1e-6
    assert np.max(np.abs(gh - h)) < 1e-6


# ---------------------------------------------------------------- round trips

@HYP
@given(lat=lats, lon=lons, h=heights)
@example(lat=90.0, lon=0.0, h=0.0)
@example(lat=-90.0, lon=45.0, h=1000.0)
@example(lat=0.0, lon=180.0, h=0.0)
@example(lat=0.0, lon=-180.0, h=0.0)
@example(lat=45.0, lon=179.9999999, h=10.0)
@example(lat=89.9999999, lon=-179.9999999, h=0.0)
def test_geodetic_ecef_round_trip(lat, lon, h):
    xyz = geodetic_to_ecef(lat, lon, h)
    lat2, lon2, h2 = ecef_to_geodetic(xyz)
    assert lat2 == pytest.approx(lat, abs=1e-11)
    assert h2 == pytest.approx(h, abs=1e-6)
    assert -180.0 < lon2 <= 180.0
    if abs(lat) < 89.9999:
        assert lon_diff(lon2, lon) == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(geodetic_to_ecef(lat2, lon2, h2), xyz, rtol=0, atol=1e-6)


@HYP
@given(
    x=st.floats(-9e6, 9e6), y=st.floats(-9e6, 9e6), z=st.floats(-9e6, 9e6),
)
@example(x=0.0, y=0.0, z=7e6)
@example(x=-7e6, y=0.0, z=0.0)
def test_ecef_geodetic_round_trip(x, y, z):
    xyz = np.array([x, y, z])
    if np.linalg.norm(xyz) < 6.2e6:  # deep inside the Earth (h < -160 km): out of scope
        return
    back = geodetic_to_ecef(*ecef_to_geodetic(xyz))
    np.testing.assert_allclose(back, xyz, rtol=0, atol=1e-6)


# ---------------------------------------------------------------- ENU

@HYP
@given(lat=lats, lon=lons)
def test_enu_matrix_is_rotation_and_matches_pymap3d(lat, lon):
    r = ecef_to_enu_matrix(lat, lon)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-14)
    for j in range(3):
        ref = pymap3d.ecef2enuv(*np.eye(3)[j], lat, lon)
        np.testing.assert_allclose(r[:, j], ref, atol=1e-14)
    # the up row is the ellipsoid normal: along the ECEF step of a 1 m height increase
    up = geodetic_to_ecef(lat, lon, 1.0) - geodetic_to_ecef(lat, lon, 0.0)
    np.testing.assert_allclose(r[2], up, atol=1e-8)


ORIGINS = [
    Geodetic(lat=34.9, lon=-117.9, height=700.0),
    Geodetic(lat=-33.0, lon=179.95, height=0.0),  # antimeridian
    Geodetic(lat=89.99, lon=10.0, height=50.0),  # near the pole
    Geodetic(lat=0.0, lon=0.0, height=-20.0),
]


@pytest.mark.parametrize("origin", ORIGINS, ids=lambda o: f"{o.lat},{o.lon}")
def test_range_frame_to_enu_matches_pyproj_topocentric(origin):
    rng = np.random.default_rng(3)
    n = 2000
    # points within ~1 degree of the origin (crossing the antimeridian/pole where applicable)
    e_n_u = np.c_[rng.uniform(-1.5e5, 1.5e5, (n, 2)), rng.uniform(-100, 3e4, n)]
    lat, lon, h = pymap3d.enu2geodetic(*e_n_u.T, origin.lat, origin.lon, origin.height)
    frame = RangeFrame(origin)
    got = frame.to_enu(lat, lon, h)
    ref = np.stack(pyproj_topocentric(origin).transform(lon, lat, h), axis=-1)
    assert got.shape == (n, 3)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6)
    np.testing.assert_allclose(got, e_n_u, rtol=0, atol=1e-6)
    glat, glon, gh = frame.to_geodetic(got)
    np.testing.assert_allclose(glat, lat, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lon_diff(glon, lon), 0.0, atol=1e-8 if origin.lat > 89 else 1e-10)
    np.testing.assert_allclose(gh, h, rtol=0, atol=1e-6)


@HYP
@given(
    olat=lats, olon=lons, oh=st.floats(-500.0, 5000.0),
    e=st.floats(-2e5, 2e5), n=st.floats(-2e5, 2e5), u=st.floats(-1e3, 1e5),
)
@example(olat=90.0, olon=0.0, oh=0.0, e=1000.0, n=-5000.0, u=10.0)
@example(olat=-90.0, olon=0.0, oh=0.0, e=0.0, n=0.0, u=0.0)
@example(olat=10.0, olon=180.0, oh=0.0, e=50000.0, n=0.0, u=0.0)
@example(olat=10.0, olon=-180.0, oh=0.0, e=-50000.0, n=0.0, u=0.0)
def test_range_frame_enu_geodetic_round_trip(olat, olon, oh, e, n, u):
    frame = RangeFrame(Geodetic(lat=olat, lon=olon, height=oh))
    enu = np.array([[e, n, u]])
    back = frame.to_enu(*frame.to_geodetic(enu))
    np.testing.assert_allclose(back, enu, rtol=0, atol=1e-6)


def test_range_frame_caches_and_is_value_object():
    o = Geodetic(lat=34.9, lon=-117.9, height=700.0)
    f1, f2 = RangeFrame(o), RangeFrame(Geodetic(lat=34.9, lon=-117.9, height=700.0))
    assert f1 == f2 and hash(f1) == hash(f2)
    np.testing.assert_allclose(f1.to_enu(o.lat, o.lon, o.height), 0.0, atol=1e-9)
    with pytest.raises(ValueError):
        f1.origin_ecef[0] = 0.0  # read-only cache
    with pytest.raises(AttributeError):
        f1.origin = o  # type: ignore[misc]


@pytest.mark.parametrize("origin", ORIGINS[:2], ids=lambda o: f"{o.lat},{o.lon}")
def test_local_rotation_matches_pymap3d_site_enu(origin):
    """Site->target vector in site ENU: pymap3d with the site as origin == L(site) @ diff."""
    rng = np.random.default_rng(4)
    frame = RangeFrame(origin)
    n = 500
    site_enu = np.c_[rng.uniform(-5e4, 5e4, (n, 2)), rng.uniform(0, 500, n)]
    tgt_enu = site_enu + np.c_[rng.uniform(-5e4, 5e4, (n, 2)), rng.uniform(0, 2e4, n)]
    s_lat, s_lon, s_h = frame.to_geodetic(site_enu)
    t_lat, t_lon, t_h = frame.to_geodetic(tgt_enu)
    ref = np.stack(pymap3d.geodetic2enu(t_lat, t_lon, t_h, s_lat, s_lon, s_h), axis=-1)
    rot = frame.local_rotation(s_lat, s_lon)
    assert rot.shape == (n, 3, 3)
    got = np.einsum("nij,nj->ni", rot, tgt_enu - site_enu)
    assert np.max(np.abs(got - ref)) < 1e-6
    # and site() gives the same for one site
    pos, r1 = frame.site(Geodetic(lat=s_lat[0], lon=s_lon[0], height=s_h[0]))
    np.testing.assert_allclose(pos, site_enu[0], atol=1e-6)
    np.testing.assert_allclose(r1 @ (tgt_enu[0] - pos), ref[0], atol=1e-6)


def test_local_rotation_at_origin_is_identity():
    o = ORIGINS[0]
    np.testing.assert_allclose(RangeFrame(o).local_rotation(o.lat, o.lon), np.eye(3), atol=1e-15)


# ---------------------------------------------------------------- AER

@pytest.mark.parametrize(
    ("enu", "aer"),
    [
        ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        ((1.0, 0.0, 0.0), (np.pi / 2, 0.0, 1.0)),
        ((0.0, -2.0, 0.0), (np.pi, 0.0, 2.0)),
        ((-1.0, 0.0, 0.0), (1.5 * np.pi, 0.0, 1.0)),
        ((0.0, 0.0, 3.0), (0.0, np.pi / 2, 3.0)),
        ((3.0, 0.0, -4.0), (np.pi / 2, -np.arctan2(4.0, 3.0), 5.0)),
        ((-1e-300, 1.0, 0.0), (0.0, 0.0, 1.0)),  # must not round to 2 pi
    ],
)
def test_aer_reference_values(enu, aer):
    az, el, r = enu_to_aer(np.array(enu))
    assert 0.0 <= az < 2 * np.pi
    np.testing.assert_allclose([az, el, r], aer, atol=1e-15)


def test_enu_to_aer_matches_pymap3d_and_does_not_mutate():
    rng = np.random.default_rng(5)
    enu = rng.uniform(-1e5, 1e5, (3000, 3))
    enu[np.abs(enu) < 1e-2] = 1.0  # pymap3d zeroes components below 1 mm
    keep = enu.copy()
    az, el, r = enu_to_aer(enu)
    np.testing.assert_array_equal(enu, keep)
    ref = pymap3d.enu2aer(*enu.copy().T, deg=False)
    np.testing.assert_allclose(az, ref[0], atol=1e-13)
    np.testing.assert_allclose(el, ref[1], atol=1e-13)
    np.testing.assert_allclose(r, ref[2], rtol=1e-15)
    assert np.all((az >= 0.0) & (az < 2 * np.pi))


@HYP
@given(e=st.floats(-1e6, 1e6), n=st.floats(-1e6, 1e6), u=st.floats(-1e6, 1e6))
def test_aer_round_trip(e, n, u):
    enu = np.array([e, n, u])
    az, el, r = enu_to_aer(enu)
    np.testing.assert_allclose(aer_to_enu(az, el, r), enu, rtol=0, atol=1e-9 * max(1.0, r))
    assert aer_to_enu(np.zeros(4), 0.0, 1.0).shape == (4, 3)
