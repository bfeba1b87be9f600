"""Atmospheric refraction: published values, independent integrals and closed forms.

References used as truth (none of them computed by rangeproc):

* ITU-R P.834 eq. (9): empirical total bending ``tau(h, theta)`` of the reference atmosphere
  ``N(h) = 315 exp(-h / 7.35 km)`` (coefficients cross-checked with Orekit's
  ``ITURP834AtmosphericRefraction``), a low-elevation formula.
* The zenith delay of an exponential profile, ``Ns 1e-6 H (1 - exp(-s / H))`` (analytic), and the
  Saastamoinen zenith hydrostatic delay ``2.2768 m / 1000 hPa``.
* Laplace's refraction formula for astronomical refraction,
  ``R = alpha (1 - beta) tan z - alpha (beta - alpha / 2) tan^3 z`` (``alpha = n0 - 1``,
  ``beta = H / a``), and its leading term ``(n0 - 1) cot E``.
* Edlen (1966) dispersion formula of standard air for the optical refractivity.
* The 4/3 Earth: rays straight over an Earth of radius ``k a`` - a horizontal ray rises
  ``d^2 / (2 k a)`` above the ground - and a brute-force RK4 trace of the linear profile.
* Fermat's principle: the electrical length of the ray is that of the chord to first order and
  never longer (scipy quadrature of ``N`` along the chord).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from rangeproc.frames.refraction import (
    EARTH_RADIUS,
    K_FACTOR,
    RADIO_NS,
    apparent,
    correct,
    crpl_scale_height,
    elevation_error,
    homogeneous_scale_height,
    optical_refractivity,
    range_error,
    refraction_errors,
    refractivity,
    total_bending,
    trace,
)

D = np.radians
A = EARTH_RADIUS
MODELS = ("4/3", "exponential")
ARCSEC = np.pi / 180.0 / 3600.0


def itu_p834_tau_deg(h_km: float, theta_deg: np.ndarray) -> np.ndarray:
    """ITU-R P.834 eq. (9): total bending (deg) at apparent elevation theta (deg), height h."""
    t = theta_deg
    return 1.0 / (1.314 + 0.6437 * t + 0.02869 * t * t
                  + h_km * (0.2305 + 0.09428 * t + 0.01096 * t * t) + 0.008583 * h_km * h_km)


def chord_integral(true_elevation: float, true_range: float, ns: float, h: float,
                   site_height: float = 0.0) -> float:
    """int N 1e-6 ds along the straight chord of an exponential profile (scipy quad)."""
    r0 = A + site_height
    s_el = np.sin(true_elevation)

    def n(s: float) -> float:
        dh = np.sqrt(r0 * r0 + 2.0 * r0 * s * s_el + s * s) - r0
        return ns * 1e-6 * np.exp(-dh / h)

    return quad(n, 0.0, true_range, limit=500, epsabs=1e-12, epsrel=1e-10)[0]


# ------------------------------------------------------------------ atmosphere ----

def test_optical_refractivity_matches_edlen_1966():
    # Edlen (1966) standard air (15 degC, 1013.25 hPa, dry): (n - 1) 1e8 =
    # 8342.13 + 2406030 / (130 - s^2) + 15997 / (38.9 - s^2), s = 1 / lambda (um^-1)
    for lam in (0.45, 0.55, 0.65, 0.80):
        s2 = 1.0 / lam ** 2
        edlen = (8342.13 + 2406030.0 / (130.0 - s2) + 15997.0 / (38.9 - s2)) * 1e-2
        assert optical_refractivity(1013.25, 15.0, lam) == pytest.approx(edlen, rel=5e-4)
    # the rule of thumb N ~= 79 P / T
    for p, t in ((1013.25, 15.0), (850.0, -5.0), (1030.0, 35.0)):
        assert optical_refractivity(p, t) == pytest.approx(79.0 * p / (t + 273.15), rel=5e-3)
    # group > phase refractivity; humidity lowers the optical refractivity slightly
    assert optical_refractivity(group=True) > optical_refractivity()
    assert 0.0 < optical_refractivity() - optical_refractivity(water_vapour_hpa=15.0) < 1.0


def test_crpl_scale_height_definition():
    # Bean & Thayer (1959): N(1 km) = Ns + dN, dN = -7.32 exp(0.005577 Ns)
    for ns in (250.0, 313.0, 400.0):
        n1 = refractivity(1200.0, 200.0, "exponential", ns)
        assert n1 == pytest.approx(ns - 7.32 * np.exp(0.005577 * ns), rel=1e-12)
    # the 1958 CRPL reference atmosphere for Ns = 313: c_e = 0.1439 per km
    assert 1000.0 / crpl_scale_height(313.0) == pytest.approx(0.1439, rel=1e-3)
    assert np.isnan(crpl_scale_height(5.0))
    assert homogeneous_scale_height(15.0) == pytest.approx(8434.0, abs=1.0)


def test_refractivity_profiles():
    g = 1e6 / (4.0 * A)
    assert refractivity(1000.0, 0.0, "4/3", 313.0) == pytest.approx(313.0 - 1000.0 * g)
    assert refractivity(20000.0, 0.0, "4/3", 313.0) == 0.0          # clipped
    assert refractivity(500.0, 500.0, "exponential", 313.0) == pytest.approx(313.0)
    assert refractivity(7000.0, 0.0, "exponential", 300.0, 7000.0) == pytest.approx(
        300.0 / np.e)
    assert refractivity(3000.0, 0.0, "exponential", 0.0) == 0.0


# --------------------------------------------------------------- 4/3 Earth model ----

@pytest.mark.parametrize("site_height", [0.0, 2000.0])
@pytest.mark.parametrize("slant_range", [1e3, 1e4, 1e5, 3e5, 1e6])
def test_four_thirds_closed_form_matches_ray_trace(site_height, slant_range):
    el = D(np.array([-0.5, 0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 45.0, 80.0]))
    t = trace(el, slant_range, site_height, "4/3", steps=3000)   # brute-force RK4
    eps_ref = el - t.true_elevation
    dr_ref = slant_range - t.true_range
    eps, dr = refraction_errors(el, slant_range, site_height, "4/3")
    np.testing.assert_allclose(eps, eps_ref, rtol=2e-3)
    np.testing.assert_allclose(dr, dr_ref, rtol=2e-3)


def test_four_thirds_short_range_is_kappa_r_over_2():
    # eps ~= kappa R / 2 with kappa = cos(E) / (4 a): R cos(E) / (8 a)
    el = D(np.array([0.0, 10.0, 30.0, 60.0, 85.0]))
    r = 2000.0
    eps = elevation_error(el, r, 0.0, "4/3")
    np.testing.assert_allclose(eps, r * np.cos(el) / (8.0 * A), rtol=1e-3)
    # and dR ~= Ns 1e-6 R for a short horizontal path
    assert range_error(0.0, r, 0.0, "4/3") == pytest.approx(RADIO_NS * 1e-6 * r, rel=1e-3)


def test_four_thirds_horizontal_ray_rises_d2_over_2ka():
    d = np.array([20e3, 50e3, 100e3, 200e3, 300e3])      # all inside the 8 km layer
    t = trace(0.0, d, 0.0, "4/3", steps=2000)
    ground = A * t.central_angle
    np.testing.assert_allclose(ground, d, rtol=1e-3)
    np.testing.assert_allclose(t.end_height, ground ** 2 / (2.0 * K_FACTOR * A), rtol=2e-3)
    # without refraction it would be d^2 / (2 a)
    t0 = trace(0.0, d, 0.0, "4/3", 0.0, steps=200)
    np.testing.assert_allclose(t0.end_height, (A * t0.central_angle) ** 2 / (2.0 * A),
                               rtol=2e-3)


def test_four_thirds_total_bending_high_elevation_is_n0_cot_e():
    # above the layer: tau -> (n0 - 1) cot E whatever the profile (Laplace)
    el = D(np.array([20.0, 45.0, 70.0]))
    tau = total_bending(el, 0.0, "4/3")
    np.testing.assert_allclose(tau, RADIO_NS * 1e-6 / np.tan(el), rtol=1e-2)


# ------------------------------------------------------------- exponential model ----

@pytest.mark.parametrize("h_km", [0.0, 1.0, 3.0])
def test_exponential_total_bending_matches_itu_r_p834(h_km):
    # P.834 reference atmosphere N = 315 exp(-h / 7.35 km), referred to a site at h
    theta = np.array([0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0])
    tau = np.degrees(total_bending(D(theta), h_km * 1e3, "exponential",
                                   315.0 * np.exp(-h_km / 7.35), 7350.0))
    ratio = tau / itu_p834_tau_deg(h_km, theta)
    low = theta <= 5.0
    assert np.all(np.abs(ratio[low] - 1.0) < 0.035), ratio
    # the empirical fit is for low elevations and drifts from the ray trace above 5 deg
    assert np.all(np.abs(ratio[~low] - 1.0) < 0.16), ratio


def test_elevation_error_of_a_far_target_tends_to_total_bending():
    el = D(np.array([0.0, 1.0, 5.0, 20.0, 60.0]))
    tau = total_bending(el, 0.0, "exponential")
    np.testing.assert_allclose(elevation_error(el, 1e9, 0.0, "exponential"), tau, rtol=1e-3)
    # at finite range the elevation error is smaller (parallax of the bending)
    assert np.all(elevation_error(el[:-1], 50e3, 0.0, "exponential") < tau[:-1])


@pytest.mark.parametrize("slant_range", [1e3, 3e4, 2e5, 2e6])
def test_zenith_range_error_is_the_analytic_integral(slant_range):
    h = crpl_scale_height(RADIO_NS)
    dr = range_error(np.pi / 2, slant_range, 0.0, "exponential")
    s = slant_range - dr                                     # geometric end of the path
    assert dr == pytest.approx(RADIO_NS * 1e-6 * h * -np.expm1(-s / h), rel=1e-4)


def test_zenith_delay_is_near_saastamoinen():
    zenith = range_error(np.pi / 2, 1e6, 0.0, "exponential")
    assert zenith == pytest.approx(RADIO_NS * 1e-6 * crpl_scale_height(RADIO_NS), rel=1e-4)
    # Saastamoinen hydrostatic zenith delay at 1013.25 hPa: 2.307 m; the single exponential
    # CRPL profile (fitted to the lower troposphere) is 6 % short of it
    assert zenith == pytest.approx(2.2768 * 1.01325, rel=0.10)


def test_slant_range_error_follows_one_over_sin_e():
    el = D(np.array([10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0]))
    dr = range_error(el, 2e6, 0.0, "exponential")
    zenith = range_error(np.pi / 2, 2e6, 0.0, "exponential")
    np.testing.assert_allclose(dr * np.sin(el) / zenith, 1.0, atol=0.03)


@pytest.mark.parametrize("slant_range", [5e3, 5e4, 3e5, 2e6])
def test_range_error_obeys_fermat(slant_range):
    """dR = int N ds along the chord to first order, and never more (the ray is stationary)."""
    el = D(np.array([0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 90.0]))
    h = crpl_scale_height(RADIO_NS)
    t = trace(el, slant_range, 0.0, "exponential", steps=200)   # converged to 1e-7
    dr = slant_range - t.true_range
    chord = np.array([chord_integral(e, r, RADIO_NS, h)
                      for e, r in zip(t.true_elevation, t.true_range)])
    assert np.all(dr <= chord * (1.0 + 1e-6))
    rel = dr / chord - 1.0
    if slant_range <= 5e4:
        assert np.all(np.abs(rel) < 1e-3), rel
    assert np.all(np.abs(rel[el >= D(5.0)]) < 1e-2), rel


def test_optical_refraction_matches_astronomical_refraction():
    n_opt = optical_refractivity(1013.25, 15.0)
    h = homogeneous_scale_height(15.0)
    el = D(np.array([20.0, 45.0, 70.0]))
    tau = total_bending(el, 0.0, "exponential", n_opt, h)
    alpha = n_opt * 1e-6
    # leading term (n0 - 1) cot E (58 arcsec at 45 deg)
    np.testing.assert_allclose(tau, alpha / np.tan(el), rtol=0.02)
    assert tau[1] / ARCSEC == pytest.approx(57.3, abs=0.5)
    # Laplace's two-term formula
    beta = h / A
    tan_z = 1.0 / np.tan(el)
    laplace = alpha * (1.0 - beta) * tan_z - alpha * (beta - alpha / 2.0) * tan_z ** 3
    np.testing.assert_allclose(tau, laplace, rtol=1e-3)
    # the same through elevation_error for a star-like target
    np.testing.assert_allclose(elevation_error(el, 1e9, 0.0, "exponential", n_opt, h), tau,
                               rtol=1e-3)


def test_default_steps_converge():
    el = D(np.array([-1.0, 0.0, 0.25, 1.0, 3.0, 10.0, 30.0, 70.0, 90.0]))
    r = np.array([30.0, 1e3, 1e4, 1e5, 3e5, 1e6, 1e7])[:, None]
    for site_height in (0.0, 3000.0):
        e = el if site_height > 0 else el[1:]
        ref = refraction_errors(e, r, site_height, "exponential", steps=3000)
        got = refraction_errors(e, r, site_height, "exponential")
        for g, f in zip(got, ref):
            assert np.all(np.abs(g - f) <= 5e-4 * np.abs(f) + 1e-15)


# ------------------------------------------------------------------------ sanity ----

@pytest.mark.parametrize("model", MODELS)
def test_no_atmosphere_no_error(model):
    el = D(np.array([0.0, 3.0, 45.0, 90.0]))
    eps, dr = refraction_errors(el, 2e5, 100.0, model, ns=0.0)
    np.testing.assert_allclose(eps, 0.0, atol=1e-15)
    np.testing.assert_allclose(dr, 0.0, atol=1e-9)
    np.testing.assert_allclose(total_bending(el, 100.0, model, ns=0.0), 0.0, atol=1e-15)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("slant_range", [2e4, 1e5, 1e6])
def test_errors_positive_and_decreasing_with_elevation(model, slant_range):
    el = D(np.linspace(0.0, 89.0, 60))
    eps, dr = refraction_errors(el, slant_range, 0.0, model)
    assert np.all(eps > 0.0) and np.all(dr > 0.0)
    assert np.all(np.diff(eps) < 0.0)
    assert np.all(np.diff(dr) < 0.0)
    assert abs(elevation_error(np.pi / 2, slant_range, 0.0, model)) < 1e-12


@pytest.mark.parametrize("model", MODELS)
def test_shapes_broadcast(model):
    el = D(np.array([[1.0], [10.0], [40.0]]))
    r = np.array([1e3, 1e4, 1e5, 1e6])
    eps, dr = refraction_errors(el, r, np.array([0.0, 10.0, 20.0, 30.0]), model)
    assert eps.shape == dr.shape == (3, 4)
    assert elevation_error(0.1, 1e4, 0.0, model).shape == ()
    te, tr = correct(el, r, 0.0, model)
    assert te.shape == tr.shape == (3, 4)
    # rows are independent of their neighbours
    np.testing.assert_allclose(eps[1, 2], elevation_error(el[1, 0], r[2], 20.0, model),
                               rtol=1e-12)
    assert total_bending(el, 0.0, model).shape == (3, 1)


@pytest.mark.parametrize("model", MODELS)
def test_nan_in_nan_out(model):
    el = np.array([0.1, np.nan, 0.2, 0.3, 0.4, 0.5])
    r = np.array([1e4, 1e4, np.nan, 1e4, 1e4, -5.0])
    hs = np.array([0.0, 0.0, 0.0, np.nan, 0.0, 0.0])
    ns = np.array([313.0, 313.0, 313.0, 313.0, np.nan, 313.0])
    eps, dr = refraction_errors(el, r, hs, model, ns)
    assert np.isfinite(eps[0]) and np.isfinite(dr[0])
    assert np.all(np.isnan(eps[1:])) and np.all(np.isnan(dr[1:]))
    # zero range: no error
    eps0, dr0 = refraction_errors(0.1, 0.0, 0.0, model)
    assert eps0 == 0.0 and dr0 == 0.0


@pytest.mark.parametrize("model", MODELS)
def test_correct_inverts_apparent(model):
    e_true = D(np.array([-0.3, 0.0, 0.2, 1.0, 3.0, 10.0, 60.0]))[:, None]
    r_true = np.array([2e4, 3e5, 1e6])
    e_app, r_meas = apparent(e_true, r_true, 0.0, model)
    assert np.all(e_app > e_true) and np.all(r_meas > r_true)
    e_back, r_back = correct(e_app, r_meas, 0.0, model)
    np.testing.assert_allclose(e_back, np.broadcast_to(e_true, e_back.shape), atol=1e-10)
    np.testing.assert_allclose(r_back, np.broadcast_to(r_true, r_back.shape), atol=1e-5)


def test_correct_returns_the_traced_end_point():
    el = D(np.array([0.5, 5.0, 50.0]))
    t = trace(el, 1.5e5, 300.0, "exponential", 320.0, 7500.0)
    te, tr = correct(el, 1.5e5, 300.0, "exponential", 320.0, 7500.0)
    np.testing.assert_array_equal(te, t.true_elevation)
    np.testing.assert_array_equal(tr, t.true_range)


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown refraction model"):
        elevation_error(0.1, 1e4, 0.0, "flat")
    with pytest.raises(ValueError, match="scale_height"):
        range_error(0.1, 1e4, 0.0, "4/3", scale_height=7000.0)
    with pytest.raises(ValueError, match="steps"):
        trace(0.1, 1e4, 0.0, "exponential", steps=0)
