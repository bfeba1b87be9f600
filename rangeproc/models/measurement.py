"""Measurement models with analytic Jacobians, shared by every sensor kind.

Every measurement row carries its own geometry, so two models cover all five sensor kinds:

* ``CARTESIAN`` (GPS): components ``[d_e, d_n, d_u, w_e, w_n, w_u]`` with
  ``d = Qr (p - s)`` and ``w = Qr (v - sv)``: position and velocity in a rotated local frame.
  For GPS ``s = sv = 0`` and ``Qr`` rotates range ENU into the receiver's local ENU, so the
  noise is diagonal (horizontal, horizontal, vertical, velocity x3).
* ``SPHERICAL`` (radar, theodolite, MISTRAM): components ``[R, A, E, Rdot]``:
  slant range, azimuth, elevation, range rate, from ``d = Qr (p - s)``, ``w = Qr (v - sv)``:
  ``R = |d|``, ``A = atan2(d_0, d_1)`` (clockwise from the local "north" axis d_1),
  ``E = atan2(d_2, hypot(d_0, d_1))``, ``Rdot = d . w / R``
  (He 2015 eq. 3-4 for R, A, E; Zhou et al. 2001 eq. 2 for the range rate
  ``Rdot^j = alpha^j(t)^T X_v / R^j``).
  ``Qr`` maps range ENU into the sensor's local (east-like, north-like, up) axes: the site's
  ENU for a fixed site; for a deck-mounted sensor ``P C^T`` with C body->range-ENU and
  P = [[0,1,0],[1,0,0],[0,0,-1]] taking FRD to (right, forward, up), so that A is the deck
  azimuth from the bow toward starboard and E the elevation above the deck plane.

A component that was not measured is NaN in ``z`` and is simply left out of the update.

Shapes: state ``x`` (n,) with the kinematic block first (``[p, v, a]``, range ENU);
``s``, ``sv`` (3,) sensor position (m) and velocity (m/s) in range ENU; ``Qr`` (3, 3).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

CARTESIAN = 0
SPHERICAL = 1
N_COMPONENTS = 6

#: Names and SI units of the components of each model (report and summary use them).
COMPONENTS = {
    CARTESIAN: (("e", "n", "u", "ve", "vn", "vu"), ("m", "m", "m", "m/s", "m/s", "m/s")),
    SPHERICAL: (("range", "azimuth", "elevation", "range_rate"), ("m", "rad", "rad", "m/s")),
}

#: Component index of an angle that wraps at +-pi (the azimuth of SPHERICAL).
AZIMUTH = 1
#: Component index of the elevation of SPHERICAL.
ELEVATION = 2


@njit(cache=True, nogil=True, error_model="numpy")
def wrap_angle(a: float) -> float:
    """Wrap an angle (rad) to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    w = a - two_pi * math.floor((a + math.pi) / two_pi)   # in [-pi, pi)
    if w == -math.pi:
        w = math.pi
    return w


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def slant_terms(d0: float, d1: float, d2: float) -> tuple[float, float, float, float]:
    """Slant range ``r``, ``r^2``, horizontal range ``rho`` and ``rho^2`` (m, m^2) of the
    sensor-local vector ``d`` (m), guarded away from zero (``r`` >= 1e-9 m, ``rho`` >=
    1e-9 r + 1e-12 m: an object at the sensor or at its zenith keeps finite Jacobians). The
    one definition for the spherical model here and the fast path (``estimation.fast_update``).
    """
    rho2 = d0 * d0 + d1 * d1
    r = max(math.sqrt(rho2 + d2 * d2), 1e-9)
    rho = max(math.sqrt(rho2), 1e-9 * r + 1e-12)
    return r, r * r, rho, rho * rho


@njit(cache=True, error_model="numpy")
def measure(model: int, x: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
            h: np.ndarray, H: np.ndarray) -> None:
    """Predicted measurement ``h`` (6,) and Jacobian ``H`` (6, n) at state ``x``, in place.

    Unused trailing components (SPHERICAL has 4) are set to zero. Columns of H beyond the
    kinematic velocity block are zero (measurements do not see acceleration). Written with
    scalars only: no allocation per call.
    """
    p0 = x[0] - s[0]
    p1 = x[1] - s[1]
    p2 = x[2] - s[2]
    v0 = x[3] - sv[0]
    v1 = x[4] - sv[1]
    v2 = x[5] - sv[2]
    d0 = Qr[0, 0] * p0 + Qr[0, 1] * p1 + Qr[0, 2] * p2      # d = Qr (p - s)
    d1 = Qr[1, 0] * p0 + Qr[1, 1] * p1 + Qr[1, 2] * p2
    d2 = Qr[2, 0] * p0 + Qr[2, 1] * p1 + Qr[2, 2] * p2
    w0 = Qr[0, 0] * v0 + Qr[0, 1] * v1 + Qr[0, 2] * v2      # w = Qr (v - sv)
    w1 = Qr[1, 0] * v0 + Qr[1, 1] * v1 + Qr[1, 2] * v2
    w2 = Qr[2, 0] * v0 + Qr[2, 1] * v1 + Qr[2, 2] * v2
    H[:, :] = 0.0
    if model == CARTESIAN:
        h[0] = d0
        h[1] = d1
        h[2] = d2
        h[3] = w0
        h[4] = w1
        h[5] = w2
        for i in range(3):
            for j in range(3):
                H[i, j] = Qr[i, j]
                H[3 + i, 3 + j] = Qr[i, j]
        return
    # SPHERICAL: Jacobians with respect to the local vectors d, w, then chained through Qr.
    r, r2, rho, rho2 = slant_terms(d0, d1, d2)
    dw = d0 * w0 + d1 * w1 + d2 * w2
    h[0] = r
    h[1] = math.atan2(d0, d1)
    h[2] = math.atan2(d2, rho)
    h[3] = dw / r
    h[4] = 0.0
    h[5] = 0.0
    jr0 = d0 / r                                          # dR/dd
    jr1 = d1 / r
    jr2 = d2 / r
    ja0 = d1 / rho2                                       # dA/dd
    ja1 = -d0 / rho2
    je0 = -d0 * d2 / (r2 * rho)                           # dE/dd
    je1 = -d1 * d2 / (r2 * rho)
    je2 = rho / r2
    c = dw / (r2 * r)
    jd0 = w0 / r - c * d0                                 # dRdot/dd
    jd1 = w1 / r - c * d1
    jd2 = w2 / r - c * d2
    for j in range(3):
        q0 = Qr[0, j]
        q1 = Qr[1, j]
        q2 = Qr[2, j]
        a_r = jr0 * q0 + jr1 * q1 + jr2 * q2
        H[0, j] = a_r
        H[1, j] = ja0 * q0 + ja1 * q1
        H[2, j] = je0 * q0 + je1 * q1 + je2 * q2
        H[3, j] = jd0 * q0 + jd1 * q1 + jd2 * q2
        H[3, 3 + j] = a_r                                 # dRdot/dv = (d/R)^T Qr


@njit(cache=True, error_model="numpy")
def innovation(model: int, z: np.ndarray, h: np.ndarray, out: np.ndarray) -> None:
    """Residual ``out = z - h`` (6,), azimuth wrapped to (-pi, pi] for SPHERICAL; NaN kept."""
    for i in range(z.shape[0]):
        out[i] = z[i] - h[i]
    if model == SPHERICAL and not math.isnan(out[AZIMUTH]):
        out[AZIMUTH] = wrap_angle(out[AZIMUTH])


def measure_py(model: int, x: np.ndarray, s: np.ndarray, sv: np.ndarray,
               Qr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Python wrapper of :func:`measure`: returns ``(h (6,), H (6, n))``."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    h = np.zeros(N_COMPONENTS)
    H = np.zeros((N_COMPONENTS, x.shape[0]))
    measure(int(model), x, np.asarray(s, float), np.asarray(sv, float),
            np.ascontiguousarray(Qr, dtype=np.float64), h, H)
    return h, H
