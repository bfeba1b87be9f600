"""The forward filters' fast path: the common rows updated by fused code at a fixed state size.

Nearly every row of a range is one of: a radar's range, azimuth and elevation; a
theodolite's azimuth and elevation; a GPS position. Their Jacobian is zero beyond the three
position columns, they have at most three components, and the fusion's state is the 9-state
CA model (``models.motion.N_KINEMATIC``). :func:`ekf_row` updates such a row in one compiled
body with those sizes as compile-time constants (one specialisation, for the one state size
the pipeline uses), with all of the general update's behaviour (``estimation.update``): the
whole-row chi-square gate, the per-component re-gating of a failed row, the Joseph form,
the row's chi-square and Gaussian log-likelihood term; the divergence guard follows in the
kernel as for any row. It performs the same floating-point operations in the same order as
the general code (terms of a zero Jacobian entry are left out: adding ``0 * p`` changes no
sum), so a row gives the same bits on either path.

Rows it does not take are updated by the general code (``estimation.moments``,
``estimation.update``): a range rate or GPS velocity component (Jacobian in the velocity
columns), an angle-only row whose linearisation error is worth adding
(``moments.add_linearisation_noise``: a wide prior near the sensor), any state size other
than nine.

The helpers are inlined into the kernel (``inline="always"``): a call of a separately
compiled helper with array arguments costs reference counting on every array, more than the
arithmetic of a small row. The gated update is not a copy: it is ``estimation.update``'s one
source compiled with this path's sizes (``update.specialise_update``), and the moments'
``H P`` and ``H P H^T`` are ``moments.cross_moments`` at three columns.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.estimation.moments import LIN_NOISE_SHARE, cross_moments
from rangeproc.estimation.update import specialise_update
from rangeproc.models.measurement import (
    AZIMUTH,
    CARTESIAN,
    N_COMPONENTS,
    SPHERICAL,
    slant_terms,
    wrap_angle,
)
from rangeproc.models.motion import N_KINEMATIC

#: The state size of the fast path (compile-time constant) and the Jacobian columns its rows
#: can be non-zero in (position).
N = N_KINEMATIC
NP = 3


@njit(cache=True, nogil=True, error_model="numpy")
def fast_workspace():
    """Work arrays of the fast path, ``(idx, sel, sig_row, sig, y, yw, sdiag, C, Z, Hs, S, HP,
    Kt, AP, APHt)``: index and sigma vectors (3,), innovations (3,), ``C``, ``HP``, ``Kt``
    (3, 9), ``Z``, ``Hs``, ``S`` (3, 3), ``AP`` (9, 9), ``APHt`` (9, 3)."""
    return (np.empty(NP, dtype=np.int64), np.empty(NP, dtype=np.int64), np.empty(NP),
            np.empty(NP), np.empty(NP), np.empty(NP), np.empty(NP), np.empty((NP, N)),
            np.empty((NP, NP)), np.empty((NP, NP)), np.empty((NP, NP)), np.empty((NP, N)),
            np.empty((NP, N)), np.empty((N, N)), np.empty((N, NP)))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _position_jacobian(model: int, xl: np.ndarray, s: np.ndarray, Qr: np.ndarray, i: int,
                       want0: bool, want1: bool, want2: bool, H: np.ndarray,
                       h: np.ndarray) -> None:
    """``h[c]`` and the position columns ``H[c, :3]`` of the wanted components c < 3 of row
    ``i`` (``s`` (N, 3), ``Qr`` (N, 3, 3)) at ``xl``: ``models.measurement.measure``'s
    arithmetic for those entries."""
    p0 = xl[0] - s[i, 0]
    p1 = xl[1] - s[i, 1]
    p2 = xl[2] - s[i, 2]
    d0 = Qr[i, 0, 0] * p0 + Qr[i, 0, 1] * p1 + Qr[i, 0, 2] * p2      # d = Qr (p - s)
    d1 = Qr[i, 1, 0] * p0 + Qr[i, 1, 1] * p1 + Qr[i, 1, 2] * p2
    d2 = Qr[i, 2, 0] * p0 + Qr[i, 2, 1] * p1 + Qr[i, 2, 2] * p2
    if model == CARTESIAN:
        h[0] = d0
        h[1] = d1
        h[2] = d2
        for a in range(NP):
            for j in range(NP):
                H[a, j] = Qr[i, a, j]
        return
    r, r2, rho, rho2 = slant_terms(d0, d1, d2)
    if want0:
        h[0] = r
        jr0 = d0 / r
        jr1 = d1 / r
        jr2 = d2 / r
        for j in range(NP):
            H[0, j] = jr0 * Qr[i, 0, j] + jr1 * Qr[i, 1, j] + jr2 * Qr[i, 2, j]
    if want1:
        h[1] = math.atan2(d0, d1)
        ja0 = d1 / rho2
        ja1 = -d0 / rho2
        for j in range(NP):
            H[1, j] = ja0 * Qr[i, 0, j] + ja1 * Qr[i, 1, j]
    if want2:
        h[2] = math.atan2(d2, rho)
        je0 = -d0 * d2 / (r2 * rho)
        je1 = -d1 * d2 / (r2 * rho)
        je2 = rho / r2
        for j in range(NP):
            H[2, j] = je0 * Qr[i, 0, j] + je1 * Qr[i, 1, j] + je2 * Qr[i, 2, j]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _needs_linearisation_noise(x: np.ndarray, s: np.ndarray, Qr: np.ndarray, i: int,
                               P: np.ndarray, sig: np.ndarray, m: int) -> bool:
    """Whether ``moments.add_linearisation_noise`` would work out this angle-only row's
    linearisation error (its cheap bound, same arithmetic): such rows take the general
    path."""
    p0 = x[0] - s[i, 0]
    p1 = x[1] - s[i, 1]
    p2 = x[2] - s[i, 2]
    d0 = Qr[i, 0, 0] * p0 + Qr[i, 0, 1] * p1 + Qr[i, 0, 2] * p2
    d1 = Qr[i, 1, 0] * p0 + Qr[i, 1, 1] * p1 + Qr[i, 1, 2] * p2
    rho2 = max(d0 * d0 + d1 * d1, 1e-6)
    tr = P[0, 0] + P[1, 1] + P[2, 2]
    bound = (tr / rho2) ** 2
    for a in range(m):
        if bound > LIN_NOISE_SHARE * sig[a] * sig[a]:
            return True
    return False


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def ekf_moments(model: int, z: np.ndarray, sigma: np.ndarray, s: np.ndarray, Qr: np.ndarray,
                i: int, x: np.ndarray, x_lin: np.ndarray, k: int, use_lin: bool,
                P: np.ndarray, idx: np.ndarray, sig: np.ndarray, y: np.ndarray,
                C: np.ndarray, Z: np.ndarray, Hs: np.ndarray) -> int:
    """The EKF's innovation moments of row ``i`` (of the batch arrays ``z``, ``sigma``,
    ``s``, ``Qr``) if the fast path takes it, linearised at ``x`` or at ``x_lin[k]``: fills
    ``idx[:m]``, ``sig[:m]`` (stated sigmas), ``y[:m]``, ``C[:m]`` = H P (m, 9), ``Z`` = H P
    H^T, ``Hs[:m]`` the position columns of H, and returns ``m``; 0 for a row without a
    measured component, -1 for a row the fast path does not take (module docstring)."""
    m = 0
    for c in range(N_COMPONENTS):
        if not math.isnan(z[i, c]) and sigma[i, c] > 0.0:
            if c >= NP:
                return -1
            idx[m] = c
            sig[m] = sigma[i, c]
            m += 1
    if m == 0:
        return 0
    if model != CARTESIAN and model != SPHERICAL:
        return -1
    if model == SPHERICAL and idx[0] != 0 and _needs_linearisation_noise(x, s, Qr, i, P, sig,
                                                                         m):
        return -1
    want0 = want1 = want2 = False
    for a in range(m):
        want0 = want0 or idx[a] == 0
        want1 = want1 or idx[a] == 1
        want2 = want2 or idx[a] == 2
    # h and H's position rows at component index c (< 3), then moved to row a <= c
    _position_jacobian(model, x_lin[k] if use_lin else x, s, Qr, i, want0, want1, want2, Hs,
                       y)
    for a in range(m):
        c = idx[a]
        hc = y[c]
        if use_lin:                                  # h(x_lin) + H (x - x_lin)
            acc = 0.0
            for j in range(NP):
                acc += Hs[c, j] * (x[j] - x_lin[k, j])
            hc += acc
        v = z[i, c] - hc                             # innovation, azimuth wrapped
        if model == SPHERICAL and c == AZIMUTH:
            v = wrap_angle(v)
        y[a] = v
        for j in range(NP):
            Hs[a, j] = Hs[c, j]
    cross_moments(Hs, P, m, N, NP, C, Z)             # C = H P, Z = H P H^T
    return m


#: The gated update of a fast-path row: ``update.update_row``'s source compiled at n = 9 with
#: the Jacobian in the position columns and no Sage-Husa statistics, inlined (the same
#: operations in the same order); returns ``(nis, accepted, n_accepted, mask, loglik)``.
_, update = specialise_update(N, NP, "always", False)
