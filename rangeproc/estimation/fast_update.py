"""The forward filters' fast path: the common rows updated by fused code at a fixed state size.

Nearly every row of a range is one of: a radar's range, azimuth and elevation (with or
without its range rate); a theodolite's azimuth and elevation; a GPS position; a range-rate
station's range rate. Their Jacobian is zero beyond the three position columns, or beyond
the six position and velocity columns for a row with a range rate; they have at most four
components, and the fusion's state is the 9-state CA model (``models.motion.N_KINEMATIC``).
:func:`ekf_moments` and :func:`whole_row` update such a row in fused code with those sizes
as compile-time constants (one specialisation, for the one state size the pipeline uses),
with all of the general update's behaviour (``estimation.update``): the whole-row chi-square
gate, the per-component re-gating of a failed row, the Joseph form, the row's chi-square and
Gaussian log-likelihood term; the divergence guard follows in the kernel as for any row. It
performs the same floating-point operations in the same order as the general code (terms of
a zero Jacobian entry are left out: adding ``0 * p`` changes no sum), so a row gives the
same bits on either path.

Rows it does not take are updated by the general code (``estimation.moments``,
``estimation.update``): a GPS velocity component, an angle-only row whose linearisation
error is worth adding (``moments.add_linearisation_noise``: a wide prior near the sensor),
any state size other than nine.

The helpers are inlined into the kernel (``inline="always"``): a call of a separately
compiled helper with array arguments costs reference counting on every array, more than the
arithmetic of a small row. The gated update is not a copy: it is ``estimation.update``'s one
source compiled with this path's sizes (``update.specialise_update``), or in the EKF loop,
where a row the whole-row gate rejects is rare, the general update called (:data:`regate`);
the moments' ``H P`` and ``H P H^T`` are ``moments.cross_moments`` at three columns (six
for a row with a range rate).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.estimation.moments import LIN_NOISE_SHARE, cross_moments
from rangeproc.estimation.kernels import N_OBSERVED
from rangeproc.estimation.update import LOG_2PI, specialise_update, update_row
from rangeproc.models.measurement import (
    AZIMUTH,
    CARTESIAN,
    N_COMPONENTS,
    SPHERICAL,
    slant_terms,
    wrap_angle,
)
from rangeproc.models.motion import N_KINEMATIC

#: The state size of the fast path (compile-time constant) and the Jacobian columns its
#: position components (range, azimuth, elevation; a Cartesian position) can be non-zero in.
N = N_KINEMATIC
NP = 3
#: The most components of a fast-path row (range, azimuth, elevation and range rate) and the
#: component index of the range rate, whose Jacobian also fills the velocity columns
#: (``kernels.N_OBSERVED`` columns in all).
MP = 4
RANGE_RATE = 3


@njit(cache=True, nogil=True, error_model="numpy")
def fast_workspace():
    """Work arrays of the fast path, ``(idx, sel, sig_row, sig, y, yw, sdiag, C, Z, Hs, S, HP,
    Kt, AP, APHt, winv, dinv)``: index and sigma vectors (4,), innovations (4,), ``C``,
    ``HP``, ``Kt`` (4, 9), ``Z``, ``S`` (4, 4), ``Hs`` (4, ``N_OBSERVED``) zeros (a row's
    columns written, the others kept zero: :data:`regate`), ``AP`` (9, 9), ``APHt`` (9, 4),
    and :func:`whole_row`'s reciprocals ``winv``, ``dinv`` (6,)."""
    return (np.empty(MP, dtype=np.int64), np.empty(MP, dtype=np.int64), np.empty(MP),
            np.empty(MP), np.empty(MP), np.empty(MP), np.empty(MP), np.empty((MP, N)),
            np.empty((MP, MP)), np.zeros((MP, N_OBSERVED)), np.empty((MP, MP)),
            np.empty((MP, N)),
            np.empty((MP, N)), np.empty((N, N)), np.empty((N, MP)), np.empty(N_COMPONENTS),
            np.empty(N_COMPONENTS))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sensor_frame(xl: np.ndarray, k: int, s: np.ndarray, Qr: np.ndarray,
                  i: int) -> tuple[float, float, float]:
    """``Qr (xl[k:k + 3] - s[i])`` of row ``i`` (m or m/s in the sensor's frame): the
    position (``k`` 0, ``s`` the sites) or velocity (``k`` 3, ``s`` the sensors' velocities)
    relative to the sensor, as ``models.measurement.measure`` computes it."""
    a0 = xl[k] - s[i, 0]
    a1 = xl[k + 1] - s[i, 1]
    a2 = xl[k + 2] - s[i, 2]
    return (Qr[i, 0, 0] * a0 + Qr[i, 0, 1] * a1 + Qr[i, 0, 2] * a2,
            Qr[i, 1, 0] * a0 + Qr[i, 1, 1] * a1 + Qr[i, 1, 2] * a2,
            Qr[i, 2, 0] * a0 + Qr[i, 2, 1] * a1 + Qr[i, 2, 2] * a2)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _position_jacobian(model: int, d0: float, d1: float, d2: float, r: float, r2: float,
                       rho: float, rho2: float, Qr: np.ndarray, i: int, want0: bool,
                       want1: bool, want2: bool, H: np.ndarray, h: np.ndarray) -> None:
    """``h[c]`` and the position columns ``H[c, :3]`` of the wanted components c < 3 of row
    ``i`` (``Qr`` (N, 3, 3)) from the sensor-frame vector ``d`` (:func:`_sensor_frame`) and,
    for SPHERICAL, its :func:`slant_terms`: ``models.measurement.measure``'s arithmetic for
    those entries."""
    if model == CARTESIAN:
        h[0] = d0
        h[1] = d1
        h[2] = d2
        for a in range(NP):
            for j in range(NP):
                H[a, j] = Qr[i, a, j]
        return
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
def _range_rate_jacobian(d0: float, d1: float, d2: float, r: float, r2: float,
                         xl: np.ndarray, sv: np.ndarray, Qr: np.ndarray, i: int, H: np.ndarray,
                         h: np.ndarray) -> None:
    """``h[3]`` and ``H[3, :6]`` of row ``i``'s range rate at ``xl`` (``sv`` (N, 3) the
    sensor's velocity) from the sensor-frame vector ``d`` and its slant range ``r``, ``r2``:
    ``models.measurement.measure``'s arithmetic for those entries."""
    w0, w1, w2 = _sensor_frame(xl, 3, sv, Qr, i)                      # w = Qr (v - sv)
    dw = d0 * w0 + d1 * w1 + d2 * w2
    h[RANGE_RATE] = dw / r
    jr0 = d0 / r
    jr1 = d1 / r
    jr2 = d2 / r
    c = dw / (r2 * r)
    jd0 = w0 / r - c * d0                                 # dRdot/dd
    jd1 = w1 / r - c * d1
    jd2 = w2 / r - c * d2
    for j in range(NP):
        q0 = Qr[i, 0, j]
        q1 = Qr[i, 1, j]
        q2 = Qr[i, 2, j]
        H[RANGE_RATE, j] = jd0 * q0 + jd1 * q1 + jd2 * q2
        H[RANGE_RATE, NP + j] = jr0 * q0 + jr1 * q1 + jr2 * q2   # dRdot/dv = (d/R)^T Qr


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _needs_linearisation_noise(x: np.ndarray, s: np.ndarray, Qr: np.ndarray, i: int,
                               P: np.ndarray, idx: np.ndarray, sig: np.ndarray,
                               m: int) -> bool:
    """Whether ``moments.add_linearisation_noise`` would work out this angle-only row's
    linearisation error (its cheap bound on the angle components, same arithmetic): such
    rows take the general path."""
    d0, d1, _ = _sensor_frame(x, 0, s, Qr, i)
    rho2 = max(d0 * d0 + d1 * d1, 1e-6)
    tr = P[0, 0] + P[1, 1] + P[2, 2]
    bound = (tr / rho2) ** 2
    for a in range(m):
        if (idx[a] == 1 or idx[a] == 2) and bound > LIN_NOISE_SHARE * sig[a] * sig[a]:
            return True
    return False


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def ekf_moments(model: int, z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, i: int, x: np.ndarray, x_lin: np.ndarray, k: int,
                use_lin: bool, P: np.ndarray, idx: np.ndarray, sig: np.ndarray, y: np.ndarray,
                C: np.ndarray, Z: np.ndarray, Hs: np.ndarray):
    """The EKF's innovation moments of row ``i`` (of the batch arrays ``z``, ``sigma``,
    ``s``, ``sv``, ``Qr``) if the fast path takes it, linearised at ``x`` or at
    ``x_lin[k]``: fills ``idx[:m]``, ``sig[:m]`` (stated sigmas), ``y[:m]``, ``C[:m]`` = H P
    (m, 9), ``Z`` = H P H^T, ``Hs[:m]`` the Jacobian's first ``n_cols`` columns (the others
    zero), and returns ``(m, n_cols)``: ``n_cols`` 3 (position) or 6 for a row with a range
    rate. ``m`` is 0 for a row without a measured component, -1 for a row the fast path does
    not take (module docstring)."""
    m = 0
    n_cols = NP
    for c in range(N_COMPONENTS):
        if not math.isnan(z[i, c]) and sigma[i, c] > 0.0:
            if c > RANGE_RATE or (c == RANGE_RATE and model != SPHERICAL):
                return -1, NP
            if c == RANGE_RATE:
                n_cols = N_OBSERVED
            idx[m] = c
            sig[m] = sigma[i, c]
            m += 1
    if m == 0:
        return 0, NP
    if model != CARTESIAN and model != SPHERICAL:
        return -1, NP
    if model == SPHERICAL and idx[0] != 0 and _needs_linearisation_noise(x, s, Qr, i, P, idx,
                                                                         sig, m):
        return -1, NP
    want0 = want1 = want2 = False
    for a in range(m):
        want0 = want0 or idx[a] == 0
        want1 = want1 or idx[a] == 1
        want2 = want2 or idx[a] == 2
    # h and H's rows at component index c, then moved to row a <= c
    xl = x_lin[k] if use_lin else x
    d0, d1, d2 = _sensor_frame(xl, 0, s, Qr, i)                       # d = Qr (p - s)
    r = r2 = rho = rho2 = 0.0
    if model == SPHERICAL:
        r, r2, rho, rho2 = slant_terms(d0, d1, d2)
    if want0 or want1 or want2:
        _position_jacobian(model, d0, d1, d2, r, r2, rho, rho2, Qr, i, want0, want1, want2,
                           Hs, y)
    if n_cols > NP:
        _range_rate_jacobian(d0, d1, d2, r, r2, xl, sv, Qr, i, Hs, y)
    for a in range(m):
        c = idx[a]
        cols = N_OBSERVED if c == RANGE_RATE else NP
        hc = y[c]
        if use_lin:                                  # h(x_lin) + H (x - x_lin)
            acc = 0.0
            for j in range(cols):
                acc += Hs[c, j] * (x[j] - x_lin[k, j])
            hc += acc
        v = z[i, c] - hc                             # innovation, azimuth wrapped
        if model == SPHERICAL and c == AZIMUTH:
            v = wrap_angle(v)
        y[a] = v
        for j in range(cols):
            Hs[a, j] = Hs[c, j]
        for j in range(cols, N_OBSERVED):            # zeros where an earlier range rate
            Hs[a, j] = 0.0                           # wrote (the general update reads them)
    cross_moments(Hs, P, m, N, n_cols, C, Z)         # C = H P, Z = H P H^T
    return m, n_cols


#: The gated update of a fast-path row that :func:`whole_row` rejects (its per-component
#: re-gating): ``update.update_row``'s source compiled at n = 9 with the Jacobian in the
#: position columns and no Sage-Husa statistics, inlined (the same operations in the same
#: order), for the loops where rejected rows are common: the IMM (a row under a model that
#: does not fit the motion) and the UKF's fixed-size rows (:func:`row_update`). Returns
#: ``(nis, accepted, n_accepted, mask, loglik)``.
_, update = specialise_update(N, N_OBSERVED, "always", False)

#: The EKF loop's re-gating, where a rejected row is rare (a wild value): the general
#: ``update.update_row`` itself, called, not inlined, so that the loop compiles one gated
#: update for both paths and its hot body stays small (issue 44 item 6). Its Joseph term runs
#: over ``kernels.N_OBSERVED`` Jacobian columns; the fast path's ``Hs``
#: (:func:`fast_workspace`) keeps the columns beyond position at exact zero, whose terms
#: leave every sum's bits unchanged (a sum started at +0.0 is never -0.0, and adding a signed
#: zero to any other value returns it): the same results as :data:`update`.
regate = update_row


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def whole_row(y: np.ndarray, sig: np.ndarray, C: np.ndarray, Z: np.ndarray, Hs: np.ndarray,
              m: int, n_cols: int, x: np.ndarray, P: np.ndarray, gate: np.ndarray, joseph: bool,
              yw: np.ndarray, winv: np.ndarray, HP: np.ndarray, S: np.ndarray,
              dinv: np.ndarray, Kt: np.ndarray, AP: np.ndarray, APHt: np.ndarray):
    """The whole-row gated update of a row's ``m`` components at n = 9: ``update``'s
    arithmetic for a row whose chi-square passes the gate, fused into one body.

    Moments as :func:`update` takes them (``y``, ``sig`` (m,), ``C`` = H P (m, 9), ``Z`` =
    H P H^T, ``Hs`` the Jacobian's first ``n_cols`` columns (m, n_cols), needed when
    ``joseph``). Whitened (``yw = y / sig``, ``HP = C / sig``, ``S = Z / (sig sig^T) + I``),
    Cholesky of ``S``,
    chi-square ``yw^T S^-1 yw`` against ``gate[m]``; if it passes, gain ``K^T = S^-1 HP``,
    ``x += K yw`` and the Joseph form ``(I - K H) P (I - K H)^T + K K^T`` (``joseph``) or
    ``P - K HP``, symmetrised. The same floating-point operations in the same order as
    ``update.specialise_update``'s ``gated``, each reciprocal (``1 / sig``, ``1 / L_ii``)
    computed once instead of at every use: the same bits. Returns ``(nis, passed,
    logdet_S)``; ``x``, ``P`` are untouched unless it passed (the caller then runs
    :func:`update`, whose per-component re-gating starts from the same moments).
    Work arrays: ``yw``, ``winv``, ``dinv`` (>= m,), ``S`` (m, m), ``HP``, ``Kt`` (m, 9),
    ``AP`` (9, 9), ``APHt`` (9, m).
    """
    for a in range(m):                                   # whitening
        inv = 1.0 / sig[a]
        winv[a] = inv
        yw[a] = y[a] * inv
        for j in range(N):
            HP[a, j] = C[a, j] * inv
    for a in range(m):
        for b in range(a + 1):
            v = Z[a, b] / (sig[a] * sig[b])
            S[a, b] = v
            S[b, a] = v
        S[a, a] += 1.0
    for j in range(m):                                   # S = L L^T (linalg.cholesky_inplace)
        d = S[j, j]
        for k in range(j):
            d -= S[j, k] * S[j, k]
        if not d > 0.0:
            return math.inf, False, 0.0
        d = math.sqrt(d)
        S[j, j] = d
        for i in range(j + 1, m):
            v = S[i, j]
            for k in range(j):
                v -= S[i, k] * S[j, k]
            S[i, j] = v / d
        dinv[j] = 1.0 / d
    logdet = 0.0
    for a in range(m):
        logdet += 2.0 * math.log(S[a, a])
    for i in range(m):                                   # nis = yw^T S^-1 yw
        v = yw[i]
        for k in range(i):
            v -= S[i, k] * Kt[k, 0]
        Kt[i, 0] = v * dinv[i]
    for i in range(m - 1, -1, -1):
        v = Kt[i, 0]
        for k in range(i + 1, m):
            v -= S[k, i] * Kt[k, 0]
        Kt[i, 0] = v * dinv[i]
    nis = 0.0
    for a in range(m):
        nis += yw[a] * Kt[a, 0]
    if nis > gate[m]:
        return nis, False, logdet
    for i in range(m):                                   # K^T = S^-1 (H P): gain, eq. 8
        for j in range(N):
            Kt[i, j] = HP[i, j]
        for k in range(i):
            lik = S[i, k]
            for j in range(N):
                Kt[i, j] -= lik * Kt[k, j]
        inv = dinv[i]
        for j in range(N):
            Kt[i, j] *= inv
    for i in range(m - 1, -1, -1):
        for k in range(i + 1, m):
            lki = S[k, i]
            for j in range(N):
                Kt[i, j] -= lki * Kt[k, j]
        inv = dinv[i]
        for j in range(N):
            Kt[i, j] *= inv
    for j in range(N):                                   # x += K yw, eq. 10
        acc = 0.0
        for a in range(m):
            acc += Kt[a, j] * yw[a]
        x[j] += acc
    if joseph:
        for i in range(N):                               # Joseph form, eq. 9: A P = P - K H P
            for j in range(N):
                AP[i, j] = P[i, j]
            for a in range(m):
                kai = Kt[a, i]
                for j in range(N):
                    AP[i, j] -= kai * HP[a, j]
        for i in range(N):                               # (A P) H^T, whitened rows of Hs
            for a in range(m):
                acc = 0.0
                inv = winv[a]
                for c in range(n_cols):
                    acc += AP[i, c] * Hs[a, c] * inv
                APHt[i, a] = acc
        for i in range(N):                               # A P A^T + K K^T (R = I)
            for j in range(N):
                P[i, j] = AP[i, j]
            for a in range(m):
                u = Kt[a, i] - APHt[i, a]
                for j in range(N):
                    P[i, j] += u * Kt[a, j]
    else:
        for i in range(N):                               # P - K S K^T = P - K (H P)
            for a in range(m):
                kai = Kt[a, i]
                for j in range(N):
                    P[i, j] -= kai * HP[a, j]
    for i in range(N):
        for j in range(i):
            v = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = v
            P[j, i] = v
    return nis, True, logdet



@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def row_loglik(nis: float, logdet: float, m: int) -> float:
    """The Gaussian log-likelihood term of a row whose ``m`` whitened components all passed
    (``update.update_row``'s expression): ``-(nis + log det S + m log 2 pi) / 2``."""
    return -0.5 * (nis + logdet + m * LOG_2PI)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def row_update(y: np.ndarray, sig_row: np.ndarray, C: np.ndarray, Z: np.ndarray,
               Hs: np.ndarray, idx: np.ndarray, m: int, x: np.ndarray, P: np.ndarray,
               gate: np.ndarray, joseph: bool, sel: np.ndarray, sig: np.ndarray,
               yw: np.ndarray, winv: np.ndarray, HP: np.ndarray, S: np.ndarray,
               dinv: np.ndarray, Kt: np.ndarray, AP: np.ndarray, APHt: np.ndarray,
               sdiag: np.ndarray, ew: np.ndarray, Sinv: np.ndarray):
    """The fast path's gated update of one row: :func:`whole_row`, and for a row it rejects
    :func:`update` (per-component re-gating; the same results as :func:`update` alone).
    Returns ``(nis, accepted, n_accepted, mask, loglik)`` as ``update.update_row``."""
    val, ok, logdet = whole_row(y, sig_row, C, Z, Hs, m, NP, x, P, gate, joseph, yw, winv, HP, S,
                                dinv, Kt, AP, APHt)
    if ok:
        return val, True, m, 0, row_loglik(val, logdet, m)
    return update(y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, False, sel, sig, yw, HP,
                  S, Kt, AP, APHt, sdiag, ew, Sinv)
