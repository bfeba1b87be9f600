"""Innovation moments of one measurement row (compiled): the EKF's linearisation (with the
second-order error of angle-only rows), the UKF's unscented transform, and the dispatch
between them. Used by ``estimation.forward`` and ``estimation.imm``.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import N_OBSERVED
from rangeproc.estimation.linalg import cholesky_inplace
from rangeproc.models.measurement import (
    AZIMUTH,
    N_COMPONENTS,
    SPHERICAL,
    innovation,
    measure,
    wrap_angle,
)


#: Measurement update methods (``estimation.forward.FilterSettings.method``).
EKF = 0
UKF = 1
#: The measurement components (range, azimuth, elevation; or a Cartesian position) and the
#: state columns (position) they depend on: the first three of each.
N_POSITION = 3


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def cross_moments(Hs: np.ndarray, P: np.ndarray, m: int, n: int, n_cols: int, C: np.ndarray,
                  Z: np.ndarray) -> None:
    """``C[:m]`` = H P (m, n) and ``Z[:m, :m]`` = H P H^T of the selected Jacobian rows
    ``Hs[:m]``, zero beyond their first ``n_cols`` columns (the general update's six observed
    columns; the fast path's three position columns, ``estimation.fast_update``)."""
    for a in range(m):
        for j in range(n):
            acc = 0.0
            for c in range(n_cols):
                acc += Hs[a, c] * P[c, j]
            C[a, j] = acc
    for a in range(m):
        for b in range(a + 1):
            acc = 0.0
            for c in range(n_cols):
                acc += C[a, c] * Hs[b, c]
            Z[a, b] = acc
            Z[b, a] = acc


@njit(cache=True, error_model="numpy")
def ekf_moments(model: int, z: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                x: np.ndarray, x_lin: np.ndarray, use_lin: bool, P: np.ndarray,
                idx: np.ndarray, m: int, h: np.ndarray, H: np.ndarray, y6: np.ndarray,
                y: np.ndarray, C: np.ndarray, Z: np.ndarray, Hs: np.ndarray) -> None:
    """Innovation moments of the measured components ``idx[:m]`` by linearisation.

    Linearised at the prediction ``x`` (EKF) or at ``x_lin`` (iterated smoother pass:
    ``h(x) ~ h(x_lin) + H(x_lin) (x - x_lin)``). Fills ``y[:m]`` the innovation (azimuth
    wrapped), ``C[:m]`` = H P (cross-covariance transposed, (m, n)), ``Z[:m, :m]`` = H P H^T,
    and ``Hs[:m, :6]`` the selected Jacobian rows (for the Joseph form).
    """
    n = x.shape[0]
    if use_lin:
        measure(model, x_lin, s, sv, Qr, h, H)
        for c in range(N_COMPONENTS):
            acc = 0.0
            for j in range(N_OBSERVED):
                acc += H[c, j] * (x[j] - x_lin[j])
            h[c] += acc
    else:
        measure(model, x, s, sv, Qr, h, H)
    innovation(model, z, h, y6)
    for a in range(m):
        i = idx[a]
        y[a] = y6[i]
        for c in range(N_OBSERVED):
            Hs[a, c] = H[i, c]
    cross_moments(Hs, P, m, n, N_OBSERVED, C, Z)     # H sparse (6 columns)


#: A row's linearisation variance is worked out only where its cheap upper bound exceeds
#: this share of the row's own variance (elsewhere it is negligible and the row unchanged).
LIN_NOISE_SHARE = 1e-3
#: ... and never exceeds this sigma (rad): uncapped, a track whose covariance had grown to
#: 1e8 m got rows inflated until they carried nothing, so the covariance stayed there. A
#: measured trade-off (README, "Several objects"): 0.3 mrad let a near-zenith pass diverge
#: again, 10 mrad kept a theodolite's 15 s angle-only start from pinning its track.
LIN_NOISE_CAP = 1e-3


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _mul3(A: np.ndarray, B: np.ndarray, out: np.ndarray, b_transposed: bool) -> None:
    """``out = A B`` (or ``A B^T``) of the leading (3, 3) blocks. Inlined: called with
    ``b_transposed`` a literal True and False, it compiled twice (two Literal[bool]
    signatures) for a few multiplications."""
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for c in range(3):
                acc += A[a, c] * (B[b, c] if b_transposed else B[c, b])
            out[a, b] = acc


@njit(cache=True, nogil=True, error_model="numpy")
def _half_trace_square(H2: np.ndarray, Pd: np.ndarray, M: np.ndarray) -> float:
    """``1/2 tr((H2 Pd)^2)`` of two (3, 3) matrices (``M`` a (3, 3) workspace)."""
    _mul3(H2, Pd, M, False)
    acc = 0.0
    for a in range(3):
        for b in range(3):
            acc += M[a, b] * M[b, a]
    return 0.5 * acc


@njit(cache=True, nogil=True, error_model="numpy")
def _elevation_gradient(d0: float, d1: float, d2: float, g: np.ndarray) -> None:
    """Gradient of ``atan2(d2, hypot(d0, d1))`` with respect to ``d`` into ``g`` (3,)."""
    rho = max(math.sqrt(d0 * d0 + d1 * d1), 1e-12)
    r2 = max(rho * rho + d2 * d2, 1e-12)
    g[0] = -d0 * d2 / (r2 * rho)
    g[1] = -d1 * d2 / (r2 * rho)
    g[2] = rho / r2


@njit(cache=True, nogil=True, error_model="numpy")
def add_linearisation_noise(model: int, sig_row: np.ndarray, idx: np.ndarray, m: int,
                            x: np.ndarray, s: np.ndarray, Qr: np.ndarray,
                            P: np.ndarray) -> None:
    """Widen a radar/theodolite row's sigmas ``sig_row[:m]`` (components ``idx[:m]``) by the
    error of the EKF's first-order expansion, in place.

    The second-order term of a component ``h`` about the prediction has variance
    ``1/2 tr((H2 P_d)^2)`` for a Gaussian prior (``H2`` the Hessian of ``h`` in the sensor's
    frame ``d = Qr (p - s)``, ``P_d = Qr P_pos Qr^T``): azimuth the Hessian of
    ``atan2(d0, d1)`` (eigenvalues +-1/rho^2 in the horizontal plane), elevation by central
    differences of its gradient; at most :data:`LIN_NOISE_CAP` in sigma. Negligible on a
    converged track (1 m at 10 km: 1e-16 rad^2; it is not even evaluated below
    :data:`LIN_NOISE_SHARE` of the row's variance); where the prior is wide against the
    range (a target passing near a theodolite's zenith with a 200 m prior, 1.2 km away
    horizontally: some 0.03 rad against an 80 urad sigma) it keeps the precise angles from
    pulling the track by an expansion that no longer holds, which made the track diverge to
    thousands of kilometres.

    Only for rows without a range (a theodolite, a radar row whose range failed): a row with
    a range fixes the position by itself and its first update removes the expansion's
    error; inflating it instead kept a track that had lost its object kilometres off for
    40 s where the process noise was high (a manoeuvre), so radar rows are left as they are.
    """
    if model != SPHERICAL or (m > 0 and idx[0] == 0):  # angle-only rows (see above)
        return
    p0 = x[0] - s[0]
    p1 = x[1] - s[1]
    p2 = x[2] - s[2]
    d0 = Qr[0, 0] * p0 + Qr[0, 1] * p1 + Qr[0, 2] * p2
    d1 = Qr[1, 0] * p0 + Qr[1, 1] * p1 + Qr[1, 2] * p2
    d2 = Qr[2, 0] * p0 + Qr[2, 1] * p1 + Qr[2, 2] * p2
    rho2 = max(d0 * d0 + d1 * d1, 1e-6)
    r2 = max(rho2 + d2 * d2, 1e-6)
    tr = P[0, 0] + P[1, 1] + P[2, 2]              # bounds every eigenvalue of P_pos
    wanted = False
    for a in range(m):
        c = idx[a]
        bound = (tr / rho2) ** 2 if c == 1 or c == 2 else 0.0   # |H2| <= 1/rho^2 for both
        wanted = wanted or bound > LIN_NOISE_SHARE * sig_row[a] * sig_row[a]
    if not wanted:
        return
    Pd = np.empty((3, 3))
    T = np.empty((3, 3))
    H2 = np.zeros((3, 3))
    M = np.empty((3, 3))
    _mul3(Qr, P, T, False)                           # P_d = Qr P_pos Qr^T
    _mul3(T, Qr, Pd, True)
    r = math.sqrt(r2)
    for a in range(m):
        c = idx[a]
        if c == 1:
            q = rho2 * rho2
            H2[:, :] = 0.0
            H2[0, 0] = -2.0 * d0 * d1 / q
            H2[1, 1] = 2.0 * d0 * d1 / q
            H2[0, 1] = (d0 * d0 - d1 * d1) / q
            H2[1, 0] = H2[0, 1]
        elif c == 2:
            step = 1e-4 * r
            gp = np.empty(3)
            gm = np.empty(3)
            for j in range(3):
                e0 = step if j == 0 else 0.0
                e1 = step if j == 1 else 0.0
                e2 = step if j == 2 else 0.0
                _elevation_gradient(d0 + e0, d1 + e1, d2 + e2, gp)
                _elevation_gradient(d0 - e0, d1 - e1, d2 - e2, gm)
                for i in range(3):
                    H2[i, j] = (gp[i] - gm[i]) / (2.0 * step)
        else:
            continue
        extra = _half_trace_square(H2, Pd, M)
        extra = min(extra, LIN_NOISE_CAP * LIN_NOISE_CAP)
        if extra > 0.0:
            sig_row[a] = math.sqrt(sig_row[a] * sig_row[a] + extra)


def specialise_ukf(n_fixed: int, inline: str) -> Callable:
    """:func:`ukf_moments` compiled with the state size ``n_fixed`` a compile-time constant
    (0: read from ``x``) and, with ``inline = "always"``, inlined into its caller with the
    measurement model and the Cholesky factorisation inlined into it (the general function
    below and the forward loop's fixed-size UKF, ``estimation.forward_loop``, are this one
    source: the same operations in the same order)."""
    N_FIXED = n_fixed
    factor = cholesky_inplace
    meas = measure
    if inline == "always":
        factor = njit(nogil=True, error_model="numpy", inline="always")(
            cholesky_inplace.py_func)
        meas = njit(nogil=True, error_model="numpy", inline="always")(measure.py_func)

    @njit(cache=True, nogil=True, error_model="numpy", inline=inline)
    def ukf_moments(model: int, z: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                    x: np.ndarray, P: np.ndarray, idx: np.ndarray, m: int, ukf: np.ndarray,
                    L: np.ndarray, Zs: np.ndarray, xs: np.ndarray, h: np.ndarray, H: np.ndarray,
                    y6: np.ndarray, y: np.ndarray, C: np.ndarray, Z: np.ndarray) -> bool:
        """Innovation moments of the measured components ``idx[:m]`` by the unscented transform.

        Symmetric 2n+1 scaled sigma points (Ye and Cui sec. 2: ``lambda = alpha^2 (n + kappa) - n``,
        weights ``W0m = lambda / (n + lambda)``, ``W0c = W0m + 1 - alpha^2 + beta``,
        ``Wi = 1 / (2 (n + lambda))``) with ``ukf = [alpha, beta, kappa]``. Sigma-point azimuths
        are unwrapped around the central point's before averaging. Fills ``y``, ``C`` (cross-
        covariance transposed, (m, n)) and ``Z`` (predicted measurement covariance) like
        :func:`ekf_moments`. Returns False when ``(n + lambda) P`` is not positive definite.

        The points of the columns of the lower Cholesky factor beyond :data:`N_POSITION` move
        no position (the factor is zero above its diagonal), so on a row that measures only
        position components (range, angles, a Cartesian position) their ``h`` is the
        centre's, bit for bit: copied, not recomputed (12 of the 19 points at nine states).
        """
        n = N_FIXED if N_FIXED > 0 else x.shape[0]
        alpha, beta, kappa = ukf[0], ukf[1], ukf[2]
        lam = alpha * alpha * (n + kappa) - n
        c = n + lam
        for i in range(n):
            for j in range(n):
                L[i, j] = c * P[i, j]
        if not factor(L, n):
            return False
        wm0 = lam / c
        wc0 = wm0 + 1.0 - alpha * alpha + beta
        wi = 0.5 / c
        position_only = True                                 # the row measures position only
        for a in range(m):
            position_only = position_only and idx[a] < N_POSITION
        for j in range(2 * n + 1):                           # h at each sigma point
            col = (j - 1) % n
            if j > 0 and position_only and col >= N_POSITION:
                for cc in range(N_COMPONENTS):               # L's column moves no position:
                    Zs[j, cc] = Zs[0, cc]                    # the centre's h, bit for bit
                continue
            for i in range(n):
                xs[i] = x[i]
            if j > 0:
                sign = 1.0 if j <= n else -1.0
                for i in range(n):
                    xs[i] += sign * L[i, col]
            meas(model, xs, s, sv, Qr, h, H)
            for cc in range(N_COMPONENTS):
                Zs[j, cc] = h[cc]
        if model == SPHERICAL:                               # azimuth continuity around point 0
            for j in range(1, 2 * n + 1):
                Zs[j, AZIMUTH] = Zs[0, AZIMUTH] + wrap_angle(Zs[j, AZIMUTH] - Zs[0, AZIMUTH])
        for cc in range(N_COMPONENTS):                       # predicted measurement mean
            acc = wm0 * Zs[0, cc]
            for j in range(1, 2 * n + 1):
                acc += wi * Zs[j, cc]
            h[cc] = acc
        innovation(model, z, h, y6)
        for a in range(m):
            i = idx[a]
            y[a] = y6[i]
            for k in range(n):                               # C = sum W (Z_j - zhat)(X_j - x)^T
                C[a, k] = 0.0
            for col in range(n):
                d = wi * (Zs[1 + col, i] - Zs[1 + n + col, i])
                for k in range(n):
                    C[a, k] += d * L[k, col]
        for a in range(m):
            ia = idx[a]
            for b in range(a + 1):
                ib = idx[b]
                acc = wc0 * (Zs[0, ia] - h[ia]) * (Zs[0, ib] - h[ib])
                for j in range(1, 2 * n + 1):
                    acc += wi * (Zs[j, ia] - h[ia]) * (Zs[j, ib] - h[ib])
                Z[a, b] = acc
                Z[b, a] = acc
        return True

    return ukf_moments


#: The general unscented moments: any state size, called.
ukf_moments = specialise_ukf(0, "never")


@njit(cache=True, error_model="numpy")
def ekf_row_moments(model: int, z: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                    x: np.ndarray, x_lin: np.ndarray, use_lin: bool, P: np.ndarray,
                    idx: np.ndarray, m: int, h: np.ndarray, H: np.ndarray, y6: np.ndarray,
                    y: np.ndarray, C: np.ndarray, Z: np.ndarray, Hs: np.ndarray,
                    sig_row: np.ndarray) -> None:
    """:func:`row_moments` of the EKF: :func:`ekf_moments` and the second-order error of its
    linearisation added to the row's sigmas ``sig_row`` (:func:`add_linearisation_noise`).
    Called directly where the method is known when compiling (the EKF's loops), so that the
    unscented moments they never run are not compiled into them."""
    ekf_moments(model, z, s, sv, Qr, x, x_lin, use_lin, P, idx, m, h, H, y6, y, C, Z, Hs)
    add_linearisation_noise(model, sig_row, idx, m, x, s, Qr, P)


@njit(cache=True, error_model="numpy")
def row_moments(method: int, model: int, z: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, x: np.ndarray, x_lin: np.ndarray, use_lin: bool,
                P: np.ndarray, idx: np.ndarray, m: int, ukf: np.ndarray, L: np.ndarray,
                Zs: np.ndarray, xs: np.ndarray, h: np.ndarray, H: np.ndarray,
                y6: np.ndarray, y: np.ndarray, C: np.ndarray, Z: np.ndarray,
                Hs: np.ndarray, sig_row: np.ndarray) -> None:
    """Innovation moments of one row by :func:`ekf_moments` or :func:`ukf_moments`; for the
    EKF also the second-order error of its linearisation added to the row's sigmas
    ``sig_row`` (:func:`add_linearisation_noise`; the unscented transform carries it)."""
    if method == EKF:
        ekf_row_moments(model, z, s, sv, Qr, x, x_lin, use_lin, P, idx, m, h, H, y6, y, C, Z,
                        Hs, sig_row)
    elif not ukf_moments(model, z, s, sv, Qr, x, P, idx, m, ukf, L, Zs, xs, h, H, y6, y, C,
                         Z):
        raise FloatingPointError("covariance not positive definite in UKF")
