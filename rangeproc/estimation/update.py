"""The measurement update of the forward filters (compiled helpers): whitening, Cholesky
gain, Joseph-form covariance update and chi-square gating of one row, whole or per component.

One row's update follows He 2015 sec. 3.1: gain (eq. 8), Joseph-form covariance update
(eq. 9), state update (eq. 10), with innovation chi-square gating: a row whose normalised
innovation squared exceeds the gate is not used and the filter carries the prediction (He
2015: "an abnormal measurement is replaced by the prediction"; the chi-square test itself is
Zhou et al. 2001 sec. 2.2). Gating is per component when it can be: if a row fails, the
components whose own marginal test fails are dropped and the rest is gated again, so a radar
range glitch does not throw away good angles and range rate.

Numerical care, so that radar rows mixing 25 m^2 with 4e-8 rad^2 stay well conditioned over
100,000+ steps: every row is *whitened* (each component and its Jacobian row divided by the
component's sigma, so R becomes I and the innovation covariance S = H P H^T + I has
eigenvalues >= 1), S is factored by Cholesky, and the covariance update is the Joseph form
``(I - K H) P (I - K H)^T + K K^T``, evaluated through ``A P = P - K (H P)`` so that it costs
O(n^2 m) instead of O(n^3) (the same terms, associated differently), then symmetrised.

Used by the shared forward loop (``estimation.forward_loop``) and the IMM (``estimation.imm``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import N_OBSERVED
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace
from rangeproc.models.measurement import N_COMPONENTS

LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True, error_model="numpy")
def measured_components(z_row: np.ndarray, sigma_row: np.ndarray, idx: np.ndarray,
                        sig_row: np.ndarray) -> int:
    """Write into ``idx`` the components of one row (6,) that are measured (value not NaN,
    sigma > 0) and into ``sig_row`` their stated sigmas; return how many."""
    m = 0
    for c in range(N_COMPONENTS):
        if not math.isnan(z_row[c]) and sigma_row[c] > 0.0:
            idx[m] = c
            sig_row[m] = sigma_row[c]
            m += 1
    return m


@njit(cache=True, error_model="numpy")
def record_row(i: int, nis_row: float, mask: int, ll_row: float, loglik: float,
               nis: np.ndarray, rejected: np.ndarray, ll_rows: np.ndarray) -> float:
    """Store row ``i``'s gate results (chi-square, rejected bit mask, log-likelihood term)
    and return the log-likelihood with the row added."""
    nis[i] = nis_row
    rejected[i] = mask
    total = loglik + ll_row
    ll_rows[i] = total - loglik
    return total


@njit(cache=True, error_model="numpy")
def row_workspace(n: int):
    """Work arrays of :func:`row_moments` and :func:`gated_update` for an n-state filter:
    ``(h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
    xsig)`` (shared by the Kalman and IMM loops, so one update serves both)."""
    m = N_COMPONENTS
    return (np.empty(m), np.zeros((m, n)), np.empty(m), np.empty(m),
            np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64), np.empty(m),
            np.empty((m, n)), np.empty((m, m)), np.zeros((m, N_OBSERVED)), np.empty(m),
            np.empty((m, n)), np.empty((m, m)), np.empty((m, n)), np.empty((n, n)),
            np.empty((n, m)), np.empty(m), np.empty(m), np.empty((m, m)), np.empty((n, n)),
            np.empty((2 * n + 1, m)), np.empty(n))


def specialise_update(n_fixed: int, n_cols: int, inline: str, stats: bool) -> tuple:
    """:func:`gated_update` and :func:`update_row` compiled with the state size ``n_fixed``
    (0: read from ``x``), the Jacobian's non-zero columns ``n_cols``, the Cholesky helpers
    inlined (``inline = "always"``) or called, and the Sage-Husa statistics possible
    (``stats``): the general update and the fast path's (``estimation.fast_update``) are this
    one source, the fast path's with its sizes as compile-time constants."""
    N_FIXED, N_COLS, STATS, INLINE = n_fixed, n_cols, stats, inline == "always"

    @njit(cache=True, nogil=True, error_model="numpy", inline=inline)
    def gated(y: np.ndarray, sig: np.ndarray, C: np.ndarray, Z: np.ndarray,
                     Hs: np.ndarray, sel: np.ndarray, m: int, x: np.ndarray, P: np.ndarray,
                     gate: np.ndarray, joseph: bool, yw: np.ndarray, HP: np.ndarray,
                     S: np.ndarray, Kt: np.ndarray, AP: np.ndarray, APHt: np.ndarray,
                     sdiag: np.ndarray, want_stats: bool, ew: np.ndarray, Sinv: np.ndarray):
        """Gate the components at positions ``sel[:m]`` of the moments and, if they pass, update
        ``x``, ``P`` in place.

        Whitening: ``yw = y / sigma``, ``HP = C / sigma`` (rows), ``S = Z / (sigma sigma^T) + I``.
        Gain ``K^T = S^-1 HP`` (He 2015 eq. 8), ``x += K yw`` (eq. 10). Covariance: the Joseph
        form ``(I - K H) P (I - K H)^T + K K^T`` (eq. 9, needs the Jacobian rows ``Hs``) when
        ``joseph``, else ``P - K S K^T = P - K HP`` (unscented update). Returns
        ``(nis, passed, logdet_S)``; ``sdiag[:m]`` receives the marginal whitened innovation
        variances (for per-component tests). With ``want_stats`` and a passed gate, ``ew[:m]``
        receives ``S^-1 yw`` (the whitened post-update residual) and ``Sinv[:m, :m]`` ``S^-1``
        (Sage-Husa, ``estimation.adaptive``).
        """
        n = N_FIXED if N_FIXED > 0 else x.shape[0]
        for a in range(m):
            pa = sel[a]
            inv = 1.0 / sig[a]
            yw[a] = y[pa] * inv
            for j in range(n):
                HP[a, j] = C[pa, j] * inv
        for a in range(m):
            for b in range(a + 1):
                v = Z[sel[a], sel[b]] / (sig[a] * sig[b])
                S[a, b] = v
                S[b, a] = v
            S[a, a] += 1.0
            sdiag[a] = S[a, a]
        if not (_cholesky(S, m) if INLINE else cholesky_inplace(S, m)):
            return math.inf, False, 0.0
        logdet = 0.0
        for a in range(m):
            logdet += 2.0 * math.log(S[a, a])
        for a in range(m):                                   # nis = yw^T S^-1 yw
            Kt[a, 0] = yw[a]
        if INLINE:
            _chol_solve(S, m, Kt, 1)
        else:
            chol_solve_inplace(S, m, Kt, np.int64(1))      # int64, not Literal[int](1):
            # the n-column call's compiled solve serves it (one signature)
        nis = 0.0
        for a in range(m):
            nis += yw[a] * Kt[a, 0]
        if nis > gate[m]:
            return nis, False, logdet
        if STATS and want_stats:
            for a in range(m):
                ew[a] = Kt[a, 0]
                for b in range(m):
                    Sinv[a, b] = 1.0 if a == b else 0.0
            if INLINE:
                _chol_solve(S, m, Sinv, m)
            else:
                chol_solve_inplace(S, m, Sinv, m)
        for a in range(m):                                   # K^T = S^-1 (H P): gain, eq. 8
            for j in range(n):
                Kt[a, j] = HP[a, j]
        if INLINE:
            _chol_solve(S, m, Kt, n)
        else:
            chol_solve_inplace(S, m, Kt, n)
        for j in range(n):                                   # x += K yw, eq. 10
            acc = 0.0
            for a in range(m):
                acc += Kt[a, j] * yw[a]
            x[j] += acc
        if joseph:
            for i in range(n):                               # Joseph form, eq. 9: A P = P - K H P
                for j in range(n):
                    AP[i, j] = P[i, j]
                for a in range(m):
                    kai = Kt[a, i]
                    for j in range(n):
                        AP[i, j] -= kai * HP[a, j]
            for i in range(n):                               # (A P) H^T, whitened rows of Hs
                for a in range(m):
                    acc = 0.0
                    inv = 1.0 / sig[a]
                    for c in range(N_COLS):
                        acc += AP[i, c] * Hs[sel[a], c] * inv
                    APHt[i, a] = acc
            for i in range(n):                               # A P A^T + K K^T (R = I)
                for j in range(n):
                    P[i, j] = AP[i, j]
                for a in range(m):
                    u = Kt[a, i] - APHt[i, a]
                    for j in range(n):
                        P[i, j] += u * Kt[a, j]
        else:
            for i in range(n):                               # P - K S K^T = P - K (H P)
                for a in range(m):
                    kai = Kt[a, i]
                    for j in range(n):
                        P[i, j] -= kai * HP[a, j]
        for i in range(n):
            for j in range(i):
                v = 0.5 * (P[i, j] + P[j, i])
                P[i, j] = v
                P[j, i] = v
        return nis, True, logdet

    @njit(cache=True, nogil=True, error_model="numpy", inline=inline)
    def row(y: np.ndarray, sig_row: np.ndarray, C: np.ndarray, Z: np.ndarray,
                   Hs: np.ndarray, idx: np.ndarray, m: int, x: np.ndarray, P: np.ndarray,
                   gate: np.ndarray, joseph: bool, stats: bool, sel: np.ndarray, sig: np.ndarray,
                   yw: np.ndarray, HP: np.ndarray, S: np.ndarray, Kt: np.ndarray, AP: np.ndarray,
                   APHt: np.ndarray, sdiag: np.ndarray, ew: np.ndarray, Sinv: np.ndarray):
        """Gate one row's ``m`` components (sigmas ``sig_row``) and update ``x, P`` with what
        passes: the whole row, else the components that pass their own marginal test, gated
        again (module docstring).

        Returns ``(nis, accepted, n_accepted, mask, loglik)``: the row's chi-square, whether any
        component updated, how many (``sel[:n]``, ``sig[:n]`` hold them), the bit mask of the
        rejected components (bit = component index, all of them when none passed) and the row's
        Gaussian log-likelihood term (a rejected component counted at the gate).
        """
        for a in range(m):
            sel[a] = a
            sig[a] = sig_row[a]
        val, ok, logdet = math.inf, False, 0.0
        n_acc = 0
        mask = 0
        ll = 0.0
        mk = m
        for attempt in range(2):            # one call site: the update is compiled in once
            v, passed, ld = gated(y, sig, C, Z, Hs, sel, mk, x, P, gate, joseph, yw, HP, S,
                                  Kt, AP, APHt, sdiag, stats, ew, Sinv)
            if attempt == 1:                # the components that passed their own test
                if passed:
                    ok = True
                    n_acc = mk
                    ll = -0.5 * (v + ld + mk * LOG_2PI + (m - mk) * gate[1])
                break
            val, ok, logdet = v, passed, ld
            if ok or m < 2 or not math.isfinite(val):
                break
            # drop components failing their own marginal test, gate the rest again
            mk = 0
            for a in range(m):
                if yw[a] * yw[a] / sdiag[a] <= gate[1]:
                    sel[mk] = a
                    sig[mk] = sig_row[a]
                    mk += 1
                else:
                    mask |= 1 << idx[a]
            if not 0 < mk < m:
                break
        if not ok:
            mask = 0
            for a in range(m):
                mask |= 1 << idx[a]
            ll = -0.5 * (min(val, gate[m]) + logdet + m * LOG_2PI)
        elif mask == 0:
            n_acc = m
            ll = -0.5 * (val + logdet + m * LOG_2PI)
        return val, ok, n_acc, mask, ll

    return gated, row


_cholesky = njit(nogil=True, error_model="numpy", inline="always")(cholesky_inplace.py_func)
_chol_solve = njit(nogil=True, error_model="numpy", inline="always")(chol_solve_inplace.py_func)
#: The general update: any state size, Jacobian in the observed columns, Sage-Husa statistics.
gated_update, update_row = specialise_update(0, N_OBSERVED, "never", True)
