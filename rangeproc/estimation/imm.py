"""Interacting multiple model (IMM) filter and smoother over the same measurement rows (compiled).

The IMM (Blom & Bar-Shalom 1988) runs ``r`` motion models in parallel on the common state
``[p, v, a]`` (range ENU) and mixes them every epoch through a Markov chain of model switches:

1. mixing: ``c_j = sum_i pi_ij mu_i``, ``mu_i|j = pi_ij mu_i / c_j``, each model starts from
   the mixture ``x0_j = sum_i mu_i|j x_i`` (covariance with the spread of the means);
2. model-conditioned prediction with the model's own transition and process noise;
3. the epoch's rows update every model by the same compiled update as the single filter
   (``moments.ekf_row_moments`` + ``update.gated_update``, the common rows by the fused fast
   path ``estimation.fast_update``: whitening, chi-square gating per row, then per
   component), accumulating each model's innovation likelihood; the covariance in the
   standard form ``P - K H P``, re-symmetrised, not the single filter's Joseph form
   (:data:`JOSEPH`);
4. ``mu_j = c_j L_j / sum``; the output is the moment-matched combination (its mean; its
   covariance only on request, ``combined``: Kim's smoother reads the models' moments).

Models (codes ``CV``, ``CA``, ``CT`` in ``estimation.imm_models``, with their matrices and the
mixing), all on the 9-state layout so that they mix:

* ``CV``: constant velocity, white acceleration of PSD ``q_a = q * 1 s^2`` on position and
  velocity; the acceleration is reset to zero (variance ``q_a dt``, which keeps it positive
  definite and lets the mixing hand a CA model a small acceleration);
* ``CA``: the constant-acceleration white-jerk model of the single filter (PSD ``q``);
* ``CT``: horizontal coordinated turn at the turn rate of the model's mixed estimate,
  ``omega = (v_e a_n - v_n a_e) / |v_h|^2`` (bounded by :data:`MAX_TURN_RATE`), exact
  rotation of the horizontal velocity, acceleration set to the centripetal ``omega J v``;
  vertical channel constant acceleration; noise as CV horizontally (``q_a``) and CA vertically.
  The rate is held for the step and stored, so the smoother rebuilds the same transition.

``q`` is the white-jerk PSD of the step (the pipeline's estimate); the other models' PSD derive
from it (``q_a = q * 1 s^2``: the acceleration variance a white-jerk process gains in one
second), so one number still sets the dynamics' scale.

Model switches are a continuous-time Markov chain with generator ``Lam`` (r, r) (rows sum to
zero; rates in 1/s): the step's transition matrix is ``expm(Lam dt)``, so the mixing does not
depend on the sampling rate. The smoother is Kim's fixed-interval IMM smoother (Kim 1994; Bar-
Shalom, Li & Kirubarajan 2001 sec. 11.6.8): for each pair (model j at k, model i at k+1) an RTS
step with model i's transition from model j's filtered estimate, the pair weighted by
``mu_k|k(j) pi_ji mu_k+1|N(i) / c_i``; smoothed model probabilities are those weights'
marginals (``estimation.imm_smoother``).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

from rangeproc.kernel_cache import specialisation

from rangeproc.estimation.divergence import (
    MAX_RESET_INFLATION,
    PARTIAL_DIVERGENCE,
    reset_covariance,
)
from rangeproc.estimation.update import row_workspace, update_row
from rangeproc.estimation.moments import ekf_row_moments
from rangeproc.estimation import fast_update as fu
from rangeproc.estimation.kernels import predict_epoch, specialise_predict
from rangeproc.estimation.linalg import pack_n
from rangeproc.models.measurement import N_COMPONENTS
from rangeproc.estimation.imm_models import (
    CA,
    CT,
    combine_n,
    dense_predict_n,
    model_matrices,
    switch_matrix,
    turn_rate,
)

#: The per-epoch helpers, inlined into the loop (a call with array arguments costs their
#: reference counting, several times per model and epoch).
_model_matrices = njit(nogil=True, error_model="numpy", inline="always")(
    model_matrices.py_func)

class IMMOutput(NamedTuple):
    """:func:`imm_forward`'s results by name (``IMMOutput._make(imm_forward(...))``; the
    compiled kernel returns the plain tuple, in this order; see its Returns)."""

    xf: np.ndarray
    Pf: np.ndarray          # (0, n(n+1)/2) unless imm_forward(..., combined=True)
    xm: np.ndarray
    Pm: np.ndarray
    mu: np.ndarray
    omega: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    rejected: np.ndarray
    loglik: float
    n_resets: int


#: The models' covariance update: False, the standard form ``P - K H P`` (re-symmetrised)
#: instead of the Joseph form. The gain is the optimal one to rounding, so the two agree to
#: rounding (the Joseph form's correction term ``(K - (I - K H) P H^T) K^T`` is itself
#: rounding; Bar-Shalom, Li & Kirubarajan 2001 sec. 5.2.3): on seeds 1-3 of ``make accuracy``
#: every figure within 1e-9 relative of the Joseph form's, with less than half the
#: covariance update's arithmetic (the IMM updates every model with every row: about 0.5 us
#: of its 5.1 per row in ``make bench``'s kernel part). Its round-off grows with the ratio
#: of prior to posterior variance: ``tests/estimation/test_imm.py`` holds the one-model IMM
#: to the Joseph-form EKF to 1e-9 (each covariance entry over ``sqrt(P_ii P_jj)``) on radar
#: rows (25 m^2 with 4e-8 rad^2) from priors up to (1 km)^2, every covariance positive
#: definite (docs/methods/estimators.md: "The IMM at three EKF rows").
JOSEPH = False

#: The CA prediction at the fast path's state size, inlined (a module global: a compiled
#: helper held in a closure cell would keep the loop out of the cache).
_predict_fixed = specialise_predict(fu.N, "always")[4]


def _specialise(n_state: int) -> Callable:
    """:func:`imm_forward`'s loop compiled with the state size ``n_state`` a compile-time
    constant: at the CA model's nine states, the common rows update every model through the
    forward filters' fused fast path (``estimation.fast_update``; the general update for the
    other rows) and the CA prediction is the fixed-size kernel, inlined."""
    N_STATE = n_state
    FAST = n_state == fu.N

    def kernel(epoch_t, meas_epoch, model, z, sigma, s, sv, Qr, sensor, x0, P0, q_steps, gate,
               reset_after, reset_inflation, x_lin, codes, Lam, mu0, combined):
        E = epoch_t.shape[0]
        N = meas_epoch.shape[0]
        n = N_STATE
        r = codes.shape[0]
        npk = n * (n + 1) // 2
        xf = np.empty((E, n))
        Pf = np.empty((E if combined else 0, npk))
        xm = np.empty((E, r, n))
        Pm = np.empty((E, r, npk))
        mu_out = np.empty((E, r))
        omega = np.zeros((E, r))
        nis = np.full(N, np.nan)
        dof = np.zeros(N, dtype=np.int64)
        rejected = np.zeros(N, dtype=np.int64)
        X = np.empty((r, n))
        PP = np.empty((r, n, n))
        for j in range(r):
            X[j] = x0
            PP[j] = P0
        mu = mu0.copy()
        Pi = np.empty((r, r))
        swork = np.empty((2, r, r))
        last_dt = -1.0
        cbar = np.empty(r)
        X0 = np.empty((r, n))
        P0m = np.empty((r, n, n))
        ll = np.empty(r)
        F = np.empty((r, n, n))                                 # each model's step
        Qm = np.empty((r, n, n))
        built = np.zeros(r, dtype=np.bool_)                     # F[j], Qm[j] hold the
        built_dt = np.zeros(r)                                  # matrices of this step,
        built_q = np.zeros(r)                                   # PSD and turn rate
        built_w = np.zeros(r)
        xt = np.empty(n)
        T = np.empty((n, n))
        dx = np.empty(n)
        (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
         xsig) = row_workspace(n)
        sig_row = np.empty(N_COMPONENTS)
        (f_idx, f_sel, f_sig_row, f_sig, f_y, f_yw, f_sdiag, f_C, f_Z, f_Hs, f_S, f_HP, f_Kt,
         f_AP, f_APHt, f_winv, f_dinv) = fu.fast_workspace()
        wmix = np.empty(r)
        use_lin = x_lin.shape[0] == E
        consecutive = np.zeros(np.max(sensor) + 1 if N > 0 else 1, dtype=np.int64)
        n_resets = 0
        last_reset = -1
        loglik = 0.0
        i = 0
        for k in range(E):
            dt = epoch_t[k] - epoch_t[k - 1] if k > 0 else 0.0
            if k > 0:
                if dt != last_dt:                               # regular steps: computed once
                    switch_matrix(Lam, dt, Pi, swork)
                    last_dt = dt
                for j in range(r):                              # 1. mixing
                    acc = 0.0
                    for a in range(r):
                        acc += Pi[a, j] * mu[a]
                    cbar[j] = max(acc, 1e-300)
                for j in range(r):
                    for a in range(r):
                        wmix[a] = Pi[a, j] * mu[a] / cbar[j]
                    combine_n(X, PP, wmix, X0[j], P0m[j], dx, N_STATE)
                X, X0 = X0, X                                   # the mixed starts are the
                PP, P0m = P0m, PP                               # models' states (no copy)
                for j in range(r):                              # 2. model-conditioned prediction
                    w = turn_rate(X[j]) if codes[j] == CT else 0.0
                    omega[k, j] = w
                    if codes[j] == CA:                          # the single filter's arithmetic
                        if FAST:
                            _predict_fixed(X[j], PP[j], T, epoch_t, q_steps, k)
                        else:
                            predict_epoch(X[j], PP[j], T, epoch_t, q_steps, k)
                    else:                                       # the step's matrices, rebuilt
                        q = q_steps[k]                          # only when they changed
                        if not (built[j] and built_dt[j] == dt and built_q[j] == q
                                and built_w[j] == w):
                            _model_matrices(codes[j], dt, q, w, F[j], Qm[j])
                            built[j] = True
                            built_dt[j], built_q[j], built_w[j] = dt, q, w
                        dense_predict_n(F[j], Qm[j], X[j], PP[j], xt, T, N_STATE,
                                        codes[j])
            else:
                for j in range(r):
                    cbar[j] = mu[j]
            best = 0
            for j in range(r):
                ll[j] = 0.0
                if cbar[j] > cbar[best]:
                    best = j
            while i < N and meas_epoch[i] == k:                 # 3. the epoch's rows, per model
                m = 0
                for c in range(N_COMPONENTS):
                    if not math.isnan(z[i, c]) and sigma[i, c] > 0.0:
                        idx[m] = c
                        m += 1
                dof[i] = m
                if m == 0:
                    i += 1
                    continue
                for j in range(r):
                    mf, n_cols = fu.ekf_moments(
                        model[i], z, sigma, s, sv, Qr, i, X[j], x_lin, k, use_lin, PP[j], f_idx,
                        f_sig_row, f_y, f_C, f_Z, f_Hs) if FAST else (-1, fu.NP)
                    if mf > 0:                                  # the fast path took the row
                        val, ok, ld = fu.whole_row(f_y, f_sig_row, f_C, f_Z, f_Hs, mf, n_cols,
                                                   X[j], PP[j], gate, JOSEPH, f_yw, f_winv,
                                                   f_HP, f_S, f_dinv, f_Kt, f_AP, f_APHt)
                        mask = 0
                        if ok:                                  # the whole row passed
                            ll_row = fu.row_loglik(val, ld, mf)
                        else:                                   # per-component re-gating
                            val, ok, _, mask, ll_row = fu.update(
                                f_y, f_sig_row, f_C, f_Z, f_Hs, f_idx, mf, X[j], PP[j], gate,
                                JOSEPH, False, f_sel, f_sig, f_yw, f_HP, f_S, f_Kt, f_AP, f_APHt,
                                f_sdiag, ew, Sinv)
                    else:
                        for a in range(m):
                            sig_row[a] = sigma[i, idx[a]]
                        ekf_row_moments(model[i], z[i], s[i], sv[i], Qr[i], X[j],
                                        x_lin[k] if use_lin else X[j], use_lin, PP[j], idx, m,
                                        h, H, y6, y, C, Z, Hs, sig_row)
                        val, ok, _, mask, ll_row = update_row(y, sig_row, C, Z, Hs, idx, m, X[j],
                                                              PP[j], gate, JOSEPH, False, sel, sig,
                                                              yw, HP, S, Kt, AP, APHt, sdiag, ew,
                                                              Sinv)
                    ll[j] += ll_row
                    if j == best:
                        nis[i] = val
                        rejected[i] = mask
                all_rejected = True                             # divergence guard, as the filter
                any_rejected = False
                for a in range(m):
                    if (rejected[i] >> idx[a]) & 1 == 0:
                        all_rejected = False
                    else:
                        any_rejected = True
                if not (all_rejected or any_rejected
                        and nis[i] > PARTIAL_DIVERGENCE * gate[m]):
                    consecutive[sensor[i]] = 0
                else:
                    consecutive[sensor[i]] += 1
                    if reset_after > 0 and consecutive[sensor[i]] >= reset_after \
                            and last_reset != k:
                        base = min(max(reset_inflation, 4.0 * nis[i] / gate[m]),
                                   MAX_RESET_INFLATION)
                        for j in range(r):
                            reset_covariance(PP[j], base)
                        consecutive[:] = 0
                        n_resets += 1
                        last_reset = k
                i += 1
            top = -np.inf                                       # 4. model probabilities
            for j in range(r):
                ll[j] += math.log(cbar[j])
                top = max(top, ll[j])
            tot = 0.0
            for j in range(r):
                mu[j] = math.exp(ll[j] - top)
                tot += mu[j]
            for j in range(r):
                mu[j] /= tot
            loglik += top + math.log(tot)
            if combined:                                        # combination
                combine_n(X, PP, mu, xt, T, dx, N_STATE)
                pack_n(T, Pf[k], N_STATE)
            else:                                               # its mean alone: combine_n's
                for a in range(n):                              # sums, the same bits
                    acc = 0.0
                    for j in range(r):
                        if mu[j] != 0.0:
                            acc += mu[j] * X[j, a]
                    xt[a] = acc
            for b in range(n):
                if not math.isfinite(xt[b]):
                    raise FloatingPointError("non-finite state in the IMM filter")
            xf[k] = xt
            mu_out[k] = mu
            for j in range(r):
                xm[k, j] = X[j]
                pack_n(PP[j], Pm[k, j], N_STATE)
        return xf, Pf, xm, Pm, mu_out, omega, nis, dof, rejected, loglik, n_resets

    return njit(cache=True, nogil=True, error_model="numpy")(
        specialisation(kernel, n_state))


_KERNELS: dict[int, Callable] = {}


def imm_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                reset_inflation: float, x_lin: np.ndarray, codes: np.ndarray,
                Lam: np.ndarray, mu0: np.ndarray, combined: bool = False):
    """IMM filter over all epochs (module docstring), EKF updates.

    Arguments as the shared forward loop (``estimation.forward_loop``: rows, prior,
    ``q_steps``, gate, divergence guard, ``x_lin`` linearisation states or zero rows) plus
    ``codes`` (r,) model codes, ``Lam`` (r, r) switching generator (1/s) and ``mu0`` (r,)
    initial model probabilities; ``combined``: also the combined filtered covariance ``Pf``
    (Kim's smoother and the pipeline read the models' moments only, so by default it is
    neither computed nor stored: ``Pf`` is then (0, n(n+1)/2)).

    Returns:
        xf (E, n) combined filtered states, Pf (E, n(n+1)/2) packed (``combined``, else
        (0, n(n+1)/2)); xm (E, r, n), Pm
        (E, r, n(n+1)/2) model-conditioned filtered states and covariances, mu (E, r) model
        probabilities, omega (E, r) turn rate each model used on the step ending at each
        epoch; nis (N,), dof (N,), rejected (N,) bit masks (under the model most probable
        before the epoch's update), loglik, n_resets.
    """
    n = x0.shape[0]
    kernel = _KERNELS.get(n)
    if kernel is None:
        kernel = _KERNELS[n] = _specialise(n)
    return kernel(epoch_t, meas_epoch, model, z, sigma, s, sv, Qr, sensor, x0, P0, q_steps,
                  gate, reset_after, reset_inflation, x_lin, codes, Lam, mu0, combined)
