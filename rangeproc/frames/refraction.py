"""Tropospheric refraction corrections for fixed-site radars and optical theodolites.

A ray leaving a sensor is bent by the vertical gradient of the refractive index and slowed by
the refractive index itself, so the sensor measures

* an elevation higher than the true geometric elevation of the target (the ray arrives from
  above the chord because it curves toward the denser air below), and
* a range longer than the true geometric slant range (the electrical path length
  ``integral n ds`` exceeds the chord).

This module computes both errors, ``measured - true``, i.e. with the same sign convention as
the calibration biases elsewhere in rangeproc, and removes them (:func:`correct`).

Atmosphere and geometry
-----------------------
A spherically stratified atmosphere over a sphere of radius ``earth_radius`` (default
:data:`EARTH_RADIUS` = 6 371 000 m, the mean Earth radius; pass the local radius of curvature
of the ellipsoid in the azimuth of the ray for a slightly better local fit - the difference is
below 1 % of the refraction). Heights are heights above the WGS-84 ellipsoid, used as the
sea-level approximation; only height differences from the site enter the models, because the
refractivity is referenced to the site. The refractive index is ``n(h) = 1 + N(h) 1e-6``, ``N``
in N-units. Azimuthal (horizontal) gradients, ducting and terrain are not modelled.

``"4/3"``
    The standard 4/3 effective Earth radius model (Bean & Dutton; Skolnik, *Radar Handbook*,
    ch. "Propagation"): a linear refractivity profile with gradient
    ``dN/dh = -1e6 / (4 a)`` N-units per metre (about -39 N/km), for which rays are straight
    lines over an Earth of radius ``k a``, ``k = 4/3``. The profile is referenced to the site and
    clipped at zero: ``N(h) = max(Ns - (h - h_s) 1e6 / (4 a), 0)``, so the refracting layer is
    ``Ns 4 a / 1e6`` (8.0 km for Ns = 313) thick; above it the ray is straight and the total
    bending stays finite. Both errors have closed forms to first order in ``N`` (see
    :func:`_effective_earth_errors`): for a target inside the layer the elevation error is
    ``eps ~= kappa R / 2`` with the ray curvature ``kappa = -(dn/dh) cos E = cos E / (4 a)``.
    The model is a radio model; its gradient does not depend on ``ns`` (``ns`` only sets the
    range error and the layer thickness).

``"exponential"``
    The CRPL exponential reference atmosphere (Bean & Thayer 1959; Bean & Dutton, *Radio
    Meteorology*, NBS Monograph 92, 1966, sec. 3.7): ``N(h) = Ns exp(-(h - h_s) / H)`` with
    the surface refractivity ``Ns`` at the site height ``h_s``. When ``scale_height`` is not
    given, ``H = 1 / c_e`` from the CRPL relation ``c_e = ln(Ns / (Ns + dN))`` per km with
    ``dN = -7.32 exp(0.005577 Ns)`` N/km (the mean gradient of the first kilometre): H = 6.95 km
    for Ns = 313 (:func:`crpl_scale_height`). The errors come from a numerical ray trace
    (:func:`trace`).

Ray trace
---------
The ray is integrated in the vertical plane of the sight line in Cartesian coordinates
centred on the site (x horizontal toward the target, y up), with the electrical path length
``L`` as the independent variable: ``dp/dL = t / n``, ``dt/dL = (grad n - (grad n . t) t) / n^2``
(the ray equation; it conserves Snell's invariant ``n r cos(theta)`` of a stratified sphere).
A straight ray is integrated exactly, so the truncation error only affects the (small)
refraction itself. A fixed number of classical Runge-Kutta steps per row (``steps``, default
24) is spaced geometrically in ``L`` - fine near the site where the air is dense, coarse far
out - with the scale ``l = H / sqrt(sin^2 E + 2 H / a)``. The kernel is compiled with numba
and traces blocks of rows together so that its loops vectorise: about 0.6 s per million rows
on one core. Beyond ``40 l`` (40 scale heights up even for a grazing ray) the ray flies
straight to its end. Against 3000 steps the default is accurate to 2e-5 (elevation error) and
6e-5 (range error) for elevations 0-90 deg, ranges 30 m - 10 000 km and sites at 0-3 km
(5e-4 for rays dipping 1.5 deg below the horizontal of a 3 km site).

The trace stops where the electrical path length equals the given ``slant_range``, so the end
point is the true target position for a *measured* range and a *measured* (apparent) elevation:
the errors are functions of the measured quantities, and :func:`correct` removes them in one
step without iteration. :func:`apparent` is the inverse (true -> measured), for simulation.
``range_error`` is the exact ``L - |chord|`` of the traced ray: ``integral N 1e-6 ds`` along the
path plus the (second-order) geometric excess of the curved path over the chord.

Inputs and units
----------------
Angles in radians, lengths in metres, refractivity in N-units. All public functions are
vectorised: ``elevation``, ``slant_range``, ``site_height``, ``ns`` and ``scale_height``
broadcast against each other; outputs are float64 arrays of the broadcast shape (0-d for scalar
inputs). NaN in any input gives NaN in the outputs of that element.

Optical sensors
---------------
Use the same functions with the optical surface refractivity, :func:`optical_refractivity`
(Barrell & Sears 1939 phase refractivity of dry air, as adopted with the Owens water-vapour
term by the IAG, 1999; 277.9 at 15 degC, 1013.25 hPa, 0.55 um), with the ``"exponential"``
model and preferably the density scale height :func:`homogeneous_scale_height` (8.4 km at
15 degC) - at moderate elevations the refraction ``(n0 - 1) cot E`` does not depend on the
profile anyway. The radio default :data:`RADIO_NS` = 313 is the CRPL reference value
(Bean & Dutton).

References
----------
* B. R. Bean, E. J. Dutton, *Radio Meteorology*, NBS Monograph 92 (1966): CRPL exponential
  reference atmosphere, ray tracing, the 4/3 Earth.
* Recommendation ITU-R P.834, *Effects of tropospheric refraction on radiowave propagation*:
  ray curvature ``-(dn/dh) cos(theta) / n``, effective Earth radius, the empirical total
  bending ``tau(h, theta)`` used by the tests.
* M. I. Skolnik, *Radar Handbook*, 4/3 Earth model; E. J. Dutton, G. D. Thayer, NBS Technical
  Note 97 (1961), *Techniques for computing refraction of radio waves in the troposphere*.
* J. C. Owens, Appl. Opt. 6 (1967); IAG resolution (1999) on the refractive index of air for
  electromagnetic distance measurement (Barrell & Sears coefficients).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from rangeproc.frames.raytrace import EXPONENTIAL, trace_kernel

__all__ = [
    "EARTH_RADIUS",
    "K_FACTOR",
    "MODELS",
    "RADIO_NS",
    "RayTrace",
    "apparent",
    "correct",
    "crpl_scale_height",
    "elevation_error",
    "homogeneous_scale_height",
    "optical_refractivity",
    "range_error",
    "refraction_errors",
    "refractivity",
    "total_bending",
    "trace",
]

#: Mean Earth radius (m), the default radius of the spherical Earth.
EARTH_RADIUS = 6_371_000.0
#: Effective Earth radius factor of the standard radio atmosphere.
K_FACTOR = 4.0 / 3.0
#: CRPL reference surface refractivity for radio (N-units), Bean & Dutton.
RADIO_NS = 313.0
#: Model names accepted by the ``model`` argument.
MODELS = ("4/3", "exponential")
#: Runge-Kutta steps per row of the ray trace (see the module docstring for the accuracy).
DEFAULT_STEPS = 24

_LINEAR = 0
_EXPONENTIAL = EXPONENTIAL
_KIND = {"4/3": _LINEAR, "exponential": _EXPONENTIAL}
_EXIT_SCALE_HEIGHTS = 40.0  # exp(-40) ~ 4e-18: the exponential atmosphere has ended there


class RayTrace(NamedTuple):
    """Result of :func:`trace`; every field has the broadcast shape of the inputs.

    Attributes:
        true_elevation: elevation of the chord from the site to the ray's end point (rad).
        true_range: length of that chord (m).
        bending: total bending, the angle between the ray's initial and final directions (rad,
            positive when the ray curves down).
        end_height: height of the end point above the site's height (m).
        central_angle: Earth-central angle between the site and the end point (rad).
    """

    true_elevation: np.ndarray
    true_range: np.ndarray
    bending: np.ndarray
    end_height: np.ndarray
    central_angle: np.ndarray


# --------------------------------------------------------------------------- atmosphere ----

def crpl_scale_height(ns: ArrayLike) -> np.ndarray:
    """Scale height of the CRPL exponential reference atmosphere (m) for a surface refractivity.

    ``H = 1 / c_e`` with ``c_e = ln(Ns / (Ns + dN))`` (1/km) and
    ``dN = -7.32 exp(0.005577 Ns)`` N/km (Bean & Dutton, *Radio Meteorology*, sec. 3.7). The
    relation was fitted for 200 <= Ns <= 450; it is defined while ``Ns + dN > 0``
    (Ns > 7.6) and NaN below that.

    Args:
        ns: surface refractivity (N-units), any shape.

    Returns:
        Scale height in metres, the shape of ``ns``. 6951 m for Ns = 313.
    """
    ns = np.asarray(ns, dtype=np.float64)
    dn = -7.32 * np.exp(0.005577 * ns)
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = ns + dn > 0.0
        ce = np.log(np.where(ok, ns, 1.0) / np.where(ok, ns + dn, 0.5))
    return np.where(ok, 1000.0 / ce, np.nan)


def homogeneous_scale_height(temperature_c: ArrayLike = 15.0) -> np.ndarray:
    """Height of the homogeneous atmosphere ``R_d T / g`` (m): the density scale height.

    The column of air above the site divided by its density at the site; the scale height to
    use with :func:`optical_refractivity` (optical refractivity is proportional to the density
    of dry air). ``R_d`` = 287.05 J/(kg K), ``g`` = 9.80665 m/s^2: 8434 m at 15 degC.

    Args:
        temperature_c: air temperature at the site (degC), any shape.
    """
    return 287.05 * (np.asarray(temperature_c, dtype=np.float64) + 273.15) / 9.80665


def optical_refractivity(pressure_hpa: ArrayLike = 1013.25, temperature_c: ArrayLike = 15.0,
                         wavelength_um: float = 0.55, water_vapour_hpa: ArrayLike = 0.0,
                         group: bool = False) -> np.ndarray:
    """Surface refractivity (N-units) of air for visible / near-infrared light.

    Barrell & Sears (1939) refractivity of standard dry air at 0 degC, 1013.25 hPa,
    ``N0 = 287.6155 + 1.62887 / lambda^2 + 0.01360 / lambda^4`` (phase) or
    ``287.6155 + 4.88660 / lambda^2 + 0.06800 / lambda^4`` (group, for laser ranging),
    scaled to the ambient density and corrected for water vapour (Owens 1967; the IAG 1999
    resolution): ``N = N0 (273.15 / T) (P / 1013.25) - 11.27 e / T``. Equivalent to the rule of
    thumb ``N ~= 79 P / T`` (P in hPa, T in K). Angles (theodolites) use the phase refractivity.

    Args:
        pressure_hpa: total air pressure (hPa).
        temperature_c: air temperature (degC).
        wavelength_um: vacuum wavelength (micrometres); 0.55 um is the visual peak.
        water_vapour_hpa: partial pressure of water vapour (hPa).
        group: return the group refractivity instead of the phase refractivity.

    Returns:
        N-units, the broadcast shape of the inputs. 277.9 at the defaults.
    """
    s2 = 1.0 / wavelength_um ** 2
    if group:
        n0 = 287.6155 + 4.88660 * s2 + 0.06800 * s2 * s2
    else:
        n0 = 287.6155 + 1.62887 * s2 + 0.01360 * s2 * s2
    t = np.asarray(temperature_c, dtype=np.float64) + 273.15
    p = np.asarray(pressure_hpa, dtype=np.float64)
    e = np.asarray(water_vapour_hpa, dtype=np.float64)
    return n0 * (273.15 / t) * (p / 1013.25) - 11.27 * e / t


def refractivity(height: ArrayLike, site_height: ArrayLike, model: str,
                 ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
                 earth_radius: float = EARTH_RADIUS) -> np.ndarray:
    """Refractivity profile ``N(h)`` (N-units) of a model, referenced to the site.

    Args:
        height: height above the ellipsoid (m).
        site_height: height of the site above the ellipsoid (m), where ``N = ns``.
        model: ``"4/3"`` (linear, clipped at 0) or ``"exponential"``.
        ns: refractivity at the site (N-units).
        scale_height: exponential scale height (m); None: :func:`crpl_scale_height` of ``ns``.
        earth_radius: radius ``a`` of the spherical Earth (m); sets the 4/3 gradient.

    Returns:
        N-units, the broadcast shape of the inputs.
    """
    kind = _model_kind(model, scale_height)
    dh = np.asarray(height, dtype=np.float64) - np.asarray(site_height, dtype=np.float64)
    ns = np.asarray(ns, dtype=np.float64)
    if kind == _LINEAR:
        return np.maximum(ns - dh * _gradient(earth_radius), 0.0)
    h = crpl_scale_height(ns) if scale_height is None else np.asarray(scale_height, float)
    return np.where(ns == 0.0, 0.0, ns * np.exp(-dh / np.where(ns == 0.0, 1.0, h)))


def _gradient(earth_radius: float) -> float:
    """Magnitude of the 4/3-Earth refractivity gradient, N-units per metre."""
    return 1.0e6 * (1.0 - 1.0 / K_FACTOR) / earth_radius


def _model_kind(model: str, scale_height: object) -> int:
    if model not in _KIND:
        raise ValueError(f"unknown refraction model {model!r}; expected one of {MODELS}")
    kind = _KIND[model]
    if kind == _LINEAR and scale_height is not None:
        raise ValueError("scale_height only applies to the 'exponential' model")
    return kind


def _broadcast(*arrays: ArrayLike) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """Broadcast to a common shape; return the shape and flat contiguous float64 copies."""
    b = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in arrays))
    shape = b[0].shape
    return shape, [np.ascontiguousarray(x).reshape(-1) for x in b]


def trace(elevation: ArrayLike, slant_range: ArrayLike, site_height: ArrayLike, model: str,
          ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
          earth_radius: float = EARTH_RADIUS, steps: int = DEFAULT_STEPS) -> RayTrace:
    """Numerical ray trace from the site at a measured elevation for a measured range.

    The ray leaves the site (``earth_radius + site_height`` from the centre) at the apparent
    elevation ``elevation`` and is followed until its electrical path length ``integral n ds``
    equals ``slant_range``. Works for both models (``"4/3"`` traces the clipped linear profile
    numerically: the reference for the closed forms).

    Args:
        elevation: apparent (measured) elevation (rad).
        slant_range: measured slant range = electrical path length (m), >= 0.
        site_height: site height above the ellipsoid (m).
        model: ``"4/3"`` or ``"exponential"``.
        ns: site refractivity (N-units).
        scale_height: exponential scale height (m); None: CRPL (:func:`crpl_scale_height`).
        earth_radius: radius of the spherical Earth (m).
        steps: Runge-Kutta steps per row.

    Returns:
        :class:`RayTrace` of arrays of the broadcast input shape.
    """
    kind = _model_kind(model, scale_height)
    if steps < 1:
        raise ValueError("steps must be >= 1")
    if kind == _EXPONENTIAL:
        h = crpl_scale_height(ns) if scale_height is None else scale_height
        shape, (el, rng, hs, nss, hh) = _broadcast(elevation, slant_range, site_height, ns, h)
        # no atmosphere: any finite scale height (the CRPL one is undefined for Ns = 0)
        hh = np.where(nss == 0.0, 7000.0, hh)
        with np.errstate(divide="ignore"):
            par = 1.0 / hh
    else:
        shape, (el, rng, hs, nss) = _broadcast(elevation, slant_range, site_height, ns)
        par = np.full(el.shape, _gradient(earth_radius) * 1.0e-6)
    out = np.empty((el.shape[0], 5))
    trace_kernel(el, rng, earth_radius + hs, nss, par, kind, int(steps), out)
    return RayTrace(*(out[:, k].reshape(shape) for k in range(5)))


# ------------------------------------------------------- 4/3 Earth closed forms ----

def _effective_earth_errors(elevation: np.ndarray, slant_range: np.ndarray,
                            site_height: np.ndarray, ns: np.ndarray, earth_radius: float,
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closed-form first-order errors of the clipped linear (4/3 Earth) profile.

    In the effective Earth (radius ``k a``, site at ``rho0 = k a + h_s``) the ray is the
    straight line ``rho(s)^2 = (s + q)^2 + p^2`` with ``q = rho0 sin E``, ``p = rho0 cos E``;
    heights and local elevation angles are (to first order) those of the real geometry. Along
    it the real ray's curvature is ``kappa(s) = g cos(theta(s)) = g p / rho(s)``
    (``g = 1 / (4 a)``) while ``N > 0``, i.e. for ``s < s_top`` where the line leaves the layer
    ``rho = rho0 + Ns / G`` (``G = 1e6 g``), and 0 beyond. With ``s1 = min(R, s_top)``:

    * elevation error (angle between the initial tangent and the chord of length ``R``)
      ``eps = (1/R) int_0^s1 (R - s) kappa ds = g p [A (1 + q/R) - (rho1 - rho0) / R]``,
      ``A = int_0^s1 ds / rho = ln((s1 + q + rho1) / (q + rho0))``; for a target inside the
      layer ``eps ~= R cos(E) / (8 a)``;
    * total bending ``tau = g p A(s_top)`` (-> ``(Ns 1e-6) cot E`` at high elevation);
    * range error ``dR = 1e-6 int_0^s1 N ds = 1e-6 [Ns s1 - G int_0^s1 (rho - rho0) ds]``
      with ``int rho ds = ((s + q) rho + p^2 asinh((s + q) / p)) / 2``, plus the excess of
      the arc over the chord ``tau1^2 s1 (4 R - 3 s1) / (24 R)`` (``tau1 = g p A(s1)``, the
      curvature taken as uniform over ``[0, s1]``; ``kappa^2 R^3 / 24`` inside the layer) -
      second order, but 10 % of ``dR`` for a grazing ray to a target 1000 km away.

    ``R`` is used as the straight-line length (the measured and the true range differ by
    ``dR / R`` ~ 1e-4, a relative change of the errors of the same order).

    Returns:
        (eps, dR, tau), arrays of the broadcast shape.
    """
    k = K_FACTOR
    g = (1.0 - 1.0 / k) / earth_radius                 # |dn/dh| (1/m)
    big_g = 1.0e6 * g                                  # |dN/dh| (N-units/m)
    rho0 = k * earth_radius + site_height
    q = rho0 * np.sin(elevation)
    p = rho0 * np.cos(elevation)
    with np.errstate(divide="ignore", invalid="ignore"):
        dh_top = np.maximum(ns, 0.0) / big_g
        c = dh_top * (2.0 * rho0 + dh_top)
        d = np.sqrt(q * q + c)
        s_top = np.where(q >= 0.0, c / (q + d), d - q)
        s_top = np.where(c == 0.0, 0.0, s_top)          # no layer (Ns <= 0)

        def a_int(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """(A(s), rho(s) - rho0) without cancellation."""
            rho = np.sqrt((s + q) ** 2 + p * p)
            drho = s * (2.0 * q + s) / (rho + rho0)
            return np.log1p((s + drho) / (q + rho0)), drho

        s1 = np.minimum(slant_range, s_top)
        a1, drho1 = a_int(s1)
        eps = g * p * (a1 * (1.0 + q / slant_range) - drho1 / slant_range)
        eps = np.where(slant_range == 0.0, 0.0, eps)
        a_top, _ = a_int(s_top)
        tau = g * p * a_top
        # int_0^s1 (rho - rho0) ds = [(s+q) rho + p^2 A]_0^s1 / 2 - rho0 s1
        w1 = s1 + q
        rho1 = rho0 + drho1
        int_drho = 0.5 * (w1 * rho1 - q * rho0 + p * p * a1) - rho0 * s1
        # plus the excess of the curved path over the chord, second order but ~10 % of dR for
        # long grazing paths: (1/2) int (ray slope relative to the chord)^2 ds with the
        # curvature spread evenly over [0, s1] (total tau1): tau1^2 s1 (4R - 3 s1) / (24 R)
        tau1 = g * p * a1
        excess = tau1 * tau1 * s1 * (4.0 * slant_range - 3.0 * s1) / (24.0 * slant_range)
        dr = 1.0e-6 * (ns * s1 - big_g * int_drho) + np.where(slant_range > 0.0, excess, 0.0)
    bad = slant_range < 0.0
    return np.where(bad, np.nan, eps), np.where(bad, np.nan, dr), tau


# --------------------------------------------------------------- public API ----

def refraction_errors(elevation: ArrayLike, slant_range: ArrayLike, site_height: ArrayLike,
                      model: str, ns: ArrayLike = RADIO_NS,
                      scale_height: ArrayLike | None = None, *,
                      earth_radius: float = EARTH_RADIUS, steps: int = DEFAULT_STEPS,
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Elevation and range errors (measured - true) at once (one ray trace per row).

    Args:
        elevation: apparent (measured) elevation (rad).
        slant_range: measured slant range (m), the electrical path length.
        site_height: site height above the ellipsoid (m).
        model: ``"4/3"`` (closed form) or ``"exponential"`` (ray trace).
        ns: surface refractivity at the site (N-units); :data:`RADIO_NS` for radio,
            :func:`optical_refractivity` for optical sensors.
        scale_height: exponential scale height (m); None: CRPL from ``ns``. Not allowed with
            ``"4/3"``.
        earth_radius: radius of the spherical Earth (m).
        steps: Runge-Kutta steps per row of the ray trace (exponential model).

    Returns:
        ``(eps, dR)``: elevation error (rad, > 0: the target looks higher) and range error
        (m, > 0: the measured range is longer), arrays of the broadcast input shape.
    """
    kind = _model_kind(model, scale_height)
    if kind == _LINEAR:
        shape, (el, rng, hs, nss) = _broadcast(elevation, slant_range, site_height, ns)
        eps, dr, _ = _effective_earth_errors(el, rng, hs, nss, earth_radius)
        return eps.reshape(shape), dr.reshape(shape)
    t = trace(elevation, slant_range, site_height, model, ns, scale_height,
              earth_radius=earth_radius, steps=steps)
    el, rng = np.broadcast_arrays(np.asarray(elevation, float), np.asarray(slant_range, float))
    el = np.broadcast_to(el, t.true_range.shape)
    rng = np.broadcast_to(rng, t.true_range.shape)
    return el - t.true_elevation, rng - t.true_range


def elevation_error(elevation: ArrayLike, slant_range: ArrayLike, site_height: ArrayLike,
                    model: str, ns: ArrayLike = RADIO_NS,
                    scale_height: ArrayLike | None = None, *,
                    earth_radius: float = EARTH_RADIUS,
                    steps: int = DEFAULT_STEPS) -> np.ndarray:
    """Refraction elevation error ``eps`` = apparent (measured) - true elevation (rad).

    The true elevation is that of the chord from the site to the target. ``eps > 0``: refraction
    makes targets look higher. Arguments as :func:`refraction_errors` (``elevation`` and
    ``slant_range`` are the measured values). About ``R cos(E) / (8 a)`` for a target inside the
    4/3 layer, tending to the total bending :func:`total_bending` for targets far beyond the
    atmosphere.

    Returns:
        Radians, the broadcast shape of the inputs.
    """
    return refraction_errors(elevation, slant_range, site_height, model, ns, scale_height,
                             earth_radius=earth_radius, steps=steps)[0]


def range_error(elevation: ArrayLike, slant_range: ArrayLike, site_height: ArrayLike,
                model: str, ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
                earth_radius: float = EARTH_RADIUS, steps: int = DEFAULT_STEPS) -> np.ndarray:
    """Refraction range error ``dR`` = measured (electrical) - true geometric slant range (m).

    ``integral N 1e-6 ds`` along the path plus the second-order excess of the curved path over
    the chord (the ray trace gives the exact difference; the 4/3 closed form is first order).
    Arguments as :func:`refraction_errors`. About ``Ns 1e-6 H / sin(E)`` for a target beyond
    the exponential atmosphere (2.18 m at the zenith for Ns = 313).

    Returns:
        Metres, the broadcast shape of the inputs.
    """
    return refraction_errors(elevation, slant_range, site_height, model, ns, scale_height,
                             earth_radius=earth_radius, steps=steps)[1]


def correct(elevation: ArrayLike, slant_range: ArrayLike, site_height: ArrayLike, model: str,
            ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
            earth_radius: float = EARTH_RADIUS,
            steps: int = DEFAULT_STEPS) -> tuple[np.ndarray, np.ndarray]:
    """True geometric (elevation, slant range) from measured ones.

    Exact within the model, without iteration: the errors are functions of the measured
    values (the ray is traced from the apparent elevation for the measured electrical length).
    For an optical sensor that measures no range, pass any plausible range (the elevation
    error depends weakly on it once the target is above the refracting layer) and ignore the
    returned range.

    Args:
        as :func:`refraction_errors`.

    Returns:
        ``(true_elevation (rad), true_range (m))``, arrays of the broadcast input shape.
    """
    eps, dr = refraction_errors(elevation, slant_range, site_height, model, ns, scale_height,
                                earth_radius=earth_radius, steps=steps)
    return np.asarray(elevation, float) - eps, np.asarray(slant_range, float) - dr


def apparent(true_elevation: ArrayLike, true_range: ArrayLike, site_height: ArrayLike,
             model: str, ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
             earth_radius: float = EARTH_RADIUS, steps: int = DEFAULT_STEPS,
             iterations: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Measured (elevation, slant range) of a target at a true elevation and range.

    The inverse of :func:`correct`, for simulating measurements: solves
    ``E' - eps(E', R') = E`` by the secant method (the first step is the fixed-point step
    ``E' = E + eps(E, R)``) with ``R' = R + dR(E', R')`` alongside (``dR`` hardly depends on
    ``R'``). Five iterations reach < 1e-10 rad and < 1 mm down to the horizon.

    Args:
        true_elevation: geometric elevation of the chord to the target (rad).
        true_range: geometric slant range (m).
        iterations: evaluations of :func:`refraction_errors`.
        others: as :func:`refraction_errors`.

    Returns:
        ``(apparent_elevation (rad), measured_range (m))``, the broadcast input shape.
    """
    e_true, r_true = np.broadcast_arrays(np.asarray(true_elevation, float),
                                         np.asarray(true_range, float))
    e, r = e_true, r_true
    e_prev = f_prev = None
    for _ in range(iterations):
        eps, dr = refraction_errors(e, r, site_height, model, ns, scale_height,
                                    earth_radius=earth_radius, steps=steps)
        f = e - eps - e_true                   # residual of the apparent elevation
        slope = np.ones_like(f)
        if e_prev is not None:
            de = e - e_prev
            with np.errstate(divide="ignore", invalid="ignore"):
                s = (f - f_prev) / de
            # 1 - d eps / dE lies in (0.5, 1.5) for any physical atmosphere
            slope = np.where((de != 0.0) & (s > 0.5) & (s < 1.5), s, 1.0)
        e_prev, f_prev = e, f
        e, r = e - f / slope, r_true + dr
    return e, r


def total_bending(elevation: ArrayLike, site_height: ArrayLike, model: str,
                  ns: ArrayLike = RADIO_NS, scale_height: ArrayLike | None = None, *,
                  earth_radius: float = EARTH_RADIUS,
                  steps: int = 4 * DEFAULT_STEPS) -> np.ndarray:
    """Total bending ``tau`` of a ray leaving the atmosphere (rad).

    The angle between the ray's directions at the site and beyond the atmosphere: the limit of
    :func:`elevation_error` for a target at infinity (the quantity of the ITU-R P.834 formula
    for ``tau(h, theta)``, and the astronomical refraction for optical ``ns``).

    Args:
        elevation: apparent elevation at the site (rad).
        others: as :func:`refraction_errors`.

    Returns:
        Radians, the broadcast shape of the inputs.
    """
    kind = _model_kind(model, scale_height)
    if kind == _LINEAR:
        shape, (el, hs, nss) = _broadcast(elevation, site_height, ns)
        _, _, tau = _effective_earth_errors(el, np.full(el.shape, np.inf), hs, nss,
                                            earth_radius)
        return tau.reshape(shape)
    # trace up to _EXIT_SCALE_HEIGHTS scale heights above the site (straight-line estimate,
    # doubled): the bending beyond is nil
    h = crpl_scale_height(ns) if scale_height is None else np.asarray(scale_height, float)
    shape, (el, hs, nss, hh) = _broadcast(elevation, site_height, ns, h)
    hh = np.where(nss == 0.0, 7000.0, hh)   # no atmosphere (the CRPL H is undefined)
    r0 = earth_radius + hs
    dh = _EXIT_SCALE_HEIGHTS * hh
    q = r0 * np.sin(el)
    s_exit = 2.0 * (np.sqrt(q * q + dh * (2.0 * r0 + dh)) - q)
    t = trace(el, s_exit, hs, model, nss, hh, earth_radius=earth_radius, steps=steps)
    return t.bending.reshape(shape)
