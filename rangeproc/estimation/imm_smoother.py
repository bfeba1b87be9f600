"""Kim's fixed-interval IMM smoother over :func:`estimation.imm.imm_forward`'s model-conditioned
output (compiled; the models and the filter are in ``estimation.imm``, whose docstring has the
equations): for each pair (model j at k, model i at k+1) an RTS step with model i's transition
from model j's filtered estimate, weighted by ``mu_k|k(j) pi_ji mu_k+1|N(i) / c_i``; the
smoothed model probabilities are those weights' marginals.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from rangeproc.kernel_cache import specialisation

from rangeproc.estimation.imm_models import (
    combine_n,
    model_matrices,
    sparse_covariance,
    switch_matrix,
)
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace, pack_n, unpack
from rangeproc.estimation.prefetch import LINE_DOUBLES, prefetch

_cholesky = njit(nogil=True, error_model="numpy", inline="always")(cholesky_inplace.py_func)
_chol_solve = njit(nogil=True, error_model="numpy", inline="always")(chol_solve_inplace.py_func)
_model_matrices = njit(nogil=True, error_model="numpy", inline="always")(
    model_matrices.py_func)
_unpack = njit(nogil=True, error_model="numpy", inline="always")(unpack.py_func)

#: Epochs ahead (backwards in time) whose history and output lines the smoother prefetches
#: (``estimation.prefetch``): 4 and 16 measured alike (0.2 us an epoch off 2.5 on 20,000
#: epochs), 32 a little slower; 8 sits between.
PREFETCH_AHEAD = 8


def _specialise(n_state: int) -> Callable:
    """:func:`imm_smooth`'s loop compiled with the state size ``n_state`` a compile-time
    constant and the pair step inlined."""
    N_STATE = n_state

    def kernel(epoch_t, xm, Pm, mu, omega, q_steps, codes, Lam, prune):
        E, r = xm.shape[0], xm.shape[1]
        n = N_STATE
        npk = n * (n + 1) // 2
        xs = np.empty((E, n))
        Ps = np.empty((E, npk))
        mus = np.empty((E, r))
        Xn = np.empty((r, n))                                   # smoothed per model at k+1
        Pn = np.empty((r, n, n))
        Xk = np.zeros((r, n))                 # zeros: a pruned model's rows are never set
        Pk = np.zeros((r, n, n))
        wc = np.ones(r)                       # combination weights (ones: prefetch all first)
        Xp = np.empty((r, r, n))                                # pair means at k
        Pp = np.empty((r, r, n, n))
        W = np.empty((r, r))
        Pi = np.empty((r, r))
        swork = np.empty((2, r, r))
        last_dt = -1.0
        cbar = np.empty(r)
        F = np.empty((r, n, n))                                 # each model's step
        Qm = np.empty((r, n, n))
        built = np.zeros(r, dtype=np.bool_)                     # F[i], Qm[i] hold ...
        built_dt = np.zeros(r)                                  # ... this step's matrices
        built_q = np.zeros(r)
        built_w = np.zeros(r)
        Pf = np.empty((n, n))
        Ppred = np.empty((n, n))
        xpred = np.empty(n)
        FP = np.empty((n, n))
        D = np.empty((n, n))
        dx = np.empty(n)
        T = np.empty((n, n))
        for i in range(r):
            Xn[i] = xm[E - 1, i]
            unpack(Pm[E - 1, i], Pn[i])
        for i in range(r):
            mus[E - 1, i] = mu[E - 1, i]
        combine_n(Xn, Pn, mus[E - 1], xs[E - 1], T, dx, N_STATE)
        pack_n(T, Ps[E - 1], N_STATE)
        blk = r * npk
        for k in range(E - 2, -1, -1):
            kp = k - PREFETCH_AHEAD                             # the history read, the
            if kp >= 0:                                         # output written, ahead:
                for j in range(r):                              # the models smoothed at
                    if wc[j] != 0.0:                            # k + 1 (a pruned model's
                        o = kp * blk + j * npk                  # rows are seldom read)
                        for b in range(0, npk + LINE_DOUBLES - 1, LINE_DOUBLES):
                            prefetch(Pm, o + min(b, npk - 1))
                        prefetch(xm, (kp * r + j) * n)
                        prefetch(xm, (kp * r + j) * n + n - 1)
                for b in range(0, npk, LINE_DOUBLES):
                    prefetch(Ps, kp * npk + b)
                prefetch(xs, kp * n)
                prefetch(mu, kp * r)
                prefetch(omega, kp * r)
                prefetch(mus, kp * r)
            dt = epoch_t[k + 1] - epoch_t[k]
            if dt != last_dt:                                   # regular steps: computed once
                switch_matrix(Lam, dt, Pi, swork)
                last_dt = dt
            for i in range(r):
                acc = 0.0
                for j in range(r):
                    acc += Pi[j, i] * mu[k, j]
                cbar[i] = max(acc, 1e-300)
            total = 0.0
            for j in range(r):
                row = 0.0
                for i in range(r):
                    W[j, i] = mu[k, j] * Pi[j, i] * mus[k + 1, i] / cbar[i]
                    row += W[j, i]
                mus[k, j] = row
                total += row
            for j in range(r):
                mus[k, j] /= total
                for i in range(r):                              # negligible pairs and models
                    if W[j, i] < prune * mus[k, j] * total or mus[k, j] < prune:
                        W[j, i] = 0.0
            for i in range(r):                                  # model i's step, once, and
                for j in range(r):                              # only when it changed
                    if W[j, i] != 0.0:
                        q, w = q_steps[k + 1], omega[k + 1, i]
                        if not (built[i] and built_dt[i] == dt and built_q[i] == q
                                and built_w[i] == w):
                            _model_matrices(codes[i], dt, q, w, F[i], Qm[i])
                            built[i] = True
                            built_dt[i], built_q[i], built_w[i] = dt, q, w
                        break
            wsum = 0.0
            for j in range(r):
                tot = 0.0
                pairs = 0
                last = 0
                for i in range(r):
                    if W[j, i] != 0.0:
                        tot += W[j, i]
                        pairs += 1
                        last = i
                wc[j] = mus[k, j] if tot > 0.0 else 0.0
                wsum += wc[j]
                if pairs == 0:                                  # skipped: filled in below
                    continue
                _unpack(Pm[k, j], Pf)
                if pairs == 1:             # the pair's weight over the model's total is 1:
                    i = last               # its mixture is the pair's own step, bit for bit
                    _pair_step(F[i], Qm[i], xm[k, j], Pf, Xn[i], Pn[i], xpred, Ppred, FP, D,
                               T, dx, Xk[j], Pk[j], N_STATE, codes[i])
                    continue
                for i in range(r):
                    if W[j, i] != 0.0:
                        _pair_step(F[i], Qm[i], xm[k, j], Pf, Xn[i], Pn[i], xpred, Ppred, FP,
                                   D, T, dx, Xp[j, i], Pp[j, i], N_STATE, codes[i])
                for a in range(n):
                    acc = 0.0
                    for i in range(r):
                        acc += W[j, i] / tot * Xp[j, i, a]
                    Xk[j, a] = acc
                for a in range(n):
                    for b in range(n):
                        Pk[j, a, b] = 0.0
                for i in range(r):
                    if W[j, i] == 0.0:
                        continue
                    w = W[j, i] / tot
                    for a in range(n):
                        dx[a] = Xp[j, i, a] - Xk[j, a]
                    for a in range(n):
                        for b in range(n):
                            Pk[j, a, b] += w * (Pp[j, i, a, b] + dx[a] * dx[b])
            for j in range(r):
                wc[j] /= wsum
            combine_n(Xk, Pk, wc, xs[k], T, dx, N_STATE)
            pack_n(T, Ps[k], N_STATE)
            Xn, Xk = Xk, Xn                                     # smoothed k becomes "next"
            Pn, Pk = Pk, Pn
            for j in range(r):
                if wc[j] == 0.0:   # a skipped model carries the combined smoothed estimate back:
                    Xn[j] = xs[k]  # its chain must not restart from its filter where it
                    Pn[j] = T      # matters again earlier in the flight
        return xs, Ps, mus

    return njit(cache=True, nogil=True, error_model="numpy")(
        specialisation(kernel, n_state))


_KERNELS: dict[int, Callable] = {}


def imm_smooth(epoch_t: np.ndarray, xm: np.ndarray, Pm: np.ndarray, mu: np.ndarray,
               omega: np.ndarray, q_steps: np.ndarray, codes: np.ndarray, Lam: np.ndarray,
               prune: float):
    """Kim's fixed-interval IMM smoother over :func:`imm_forward`'s model-conditioned output.

    A pair (j at k, i at k+1) whose weight is below ``prune`` times the total weight of model
    j's pairs is skipped: it would move model j's smoothed mixture by that fraction of the
    pair means' difference (a model switch between two epochs a fraction of a second apart
    is rare, so most cross pairs are negligible except around a manoeuvre's onset). A model
    whose smoothed probability is below ``prune`` is left out of the combination and carries
    the combined smoothed estimate back to the step before (not its own filtered one: the
    chain of a model that matters again earlier in the flight must not restart from its
    filter).

    Returns:
        xs (E, n), Ps (E, n(n+1)/2) the combined smoothed states and packed covariances, and
        mus (E, r) the smoothed model probabilities.
    """
    n = xm.shape[2]
    kernel = _KERNELS.get(n)
    if kernel is None:
        kernel = _KERNELS[n] = _specialise(n)
    return kernel(epoch_t, xm, Pm, mu, omega, q_steps, codes, Lam, prune)


@njit(cache=True, error_model="numpy", inline="always")
def _pair_step(F: np.ndarray, Q: np.ndarray, x_f: np.ndarray, P_f: np.ndarray,
               x_next: np.ndarray, P_next: np.ndarray, x_pred: np.ndarray, P_pred: np.ndarray,
               Ct: np.ndarray, E: np.ndarray, G: np.ndarray, dx: np.ndarray,
               x_out: np.ndarray, P_out: np.ndarray, n: int, code: int = -1) -> None:
    """One RTS step of a model pair: from the filtered ``x_f, P_f`` through ``F, Q`` to the
    smoothed ``x_next, P_next`` of the next epoch:

        C = P_f F^T P_pred^-1,  x = x_f + C (x_next - F x_f),
        P = P_f + C (P_next - P_pred) C^T,  P_pred = F P_f F^T + Q.

    Every product runs its innermost loop over contiguous rows; ``F`` is sparse (at most three
    non-zeros a row) and skipped where zero (at nine states, with the model's ``code``, only
    the entries that can be non-zero are added: ``imm_models.structured_covariance``);
    ``C`` is read from ``Ct`` (its transpose, the solve's result) where it is. Work arrays:
    ``x_pred, dx`` (n,), the rest (n, n); ``n`` the state size (the caller's compile-time
    constant). Inlined, with the Cholesky helpers.
    """
    for a in range(n):                                      # x_pred = F x_f
        acc = 0.0
        for l in range(n):
            f = F[a, l]
            if f != 0.0:
                acc += f * x_f[l]
        x_pred[a] = acc
    sparse_covariance(F, Q, P_f, Ct, P_pred, n, code)       # Ct = F P_f, P_pred = Ct F^T + Q
    for a in range(n):                                      # E = P_next - P_pred
        for b in range(n):
            E[a, b] = P_next[a, b] - P_pred[a, b]
    if not _cholesky(P_pred, n):
        raise FloatingPointError("predicted covariance not positive definite in the IMM "
                                 "smoother")
    _chol_solve(P_pred, n, Ct, n)                           # Ct <- P_pred^-1 F P_f = C^T
    for a in range(n):
        dx[a] = x_next[a] - x_pred[a]
    for a in range(n):                                      # x = x_f + C dx
        acc = x_f[a]
        for b in range(n):
            acc += Ct[b, a] * dx[b]
        x_out[a] = acc
    for a in range(n):                                      # G = C E
        for b in range(n):
            G[a, b] = 0.0
        for l in range(n):
            c = Ct[l, a]
            for b in range(n):
                G[a, b] += c * E[l, b]
    for a in range(n):                                      # P = P_f + G C^T
        for b in range(a + 1):
            acc = P_f[a, b]
            for l in range(n):
                acc += G[a, l] * Ct[l, b]
            P_out[a, b] = acc
            P_out[b, a] = acc
