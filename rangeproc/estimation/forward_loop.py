"""The forward filter's epoch loop, written once and specialised per filter family.

One forward pass of He 2015 sec. 3.1 over a time-ordered batch of rows: prediction by the
constant-acceleration model (eq. 6-7, ``estimation.kernels``), then each row's gated update
(eq. 8-10, ``estimation.update``, moments by ``estimation.moments``) and the divergence guard
(``estimation.divergence``), the state stored after each epoch's rows. A family adds to named
steps of this loop, as its module in ``rangeproc.families`` declares (``families.STEPS``):

* ``jerk-input``: the spline filter's jerk input after each prediction
  (``estimation.spline_filter``);
* ``fading``: strong tracking's fading factors before the epoch's rows (``estimation.fading``);
* ``anomaly``: the spline filter's anomaly test, adapted sigmas, residual sums and segments;
* ``adaptive-noise``: Sage-Husa's windowed noise before each row's update and its window
  after (``estimation.adaptive``);
* ``norm-constraint``: the maneuver-norm pseudo-measurement after each epoch's rows
  (``estimation.constraint``).

:func:`forward_kernel` compiles the loop once per family with the family's steps (and, where
the family fixes it, its measurement update) as compile-time constants: numba prunes the
branches of the steps a family does not add before typing, so a family pays nothing for them
and its first run compiles only its own specialisation (docs/methods/estimators.md, "One
loop"). The plain EKF (and the ASKF) update the common rows through the fused fast path
(``estimation.fast_update``) with the general update as the fallback.

Every specialisation takes the same arguments (``estimation.forward.run_filter`` documents
them: rows, prior, ``q_steps``, gate, guard, ``x_lin``, ``method``, ``ukf`` and ``par``, the
family's parameters as one float array) and returns ``(xf (E, n), Pf (E, n(n+1)/2) packed,
nis (N,), dof (N,), rejected (N,) bit masks, loglik, n_resets, ll_rows (N,), sigma_used
(N, 6), fade (E, 9), jerk (E, 3), anomaly (E, 2), knot (E,))``, the last five with no rows
for a family that does not fill them.

Epoch bookkeeping: ``epoch_t`` (E,) are the distinct times at which a state is wanted
(measurement times and output-grid times); each row names its epoch. The loop stores the
state after all rows of an epoch (packed covariance), which is all the RTS smoother needs:
the predicted covariance is recomputed there by the same arithmetic.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from rangeproc.kernel_cache import specialisation

from rangeproc.estimation import fast_update as fu
from rangeproc.estimation.adaptive import sh_adapt, sh_record, sh_reset
from rangeproc.estimation.constraint import norm_update
from rangeproc.estimation.divergence import guard_row
from rangeproc.estimation.fading import (
    STF_RHO,
    STF_WARMUP,
    apply_fading,
    epoch_innovations,
    fading_factors,
)
from rangeproc.estimation.kernels import N_OBSERVED, predict_epoch, specialise_predict
from rangeproc.estimation.linalg import pack_n
from rangeproc.estimation.moments import (
    EKF,
    UKF,
    ekf_row_moments,
    row_moments,
    specialise_ukf,
)
from rangeproc.estimation.spline_filter import (
    SPL_JERK_SPAN,
    SPL_MAX_RATIO,
    SPL_MIN_SEGMENT,
    SPL_RMS_MIN,
    SPL_WARMUP,
    add_jerk,
    anomaly_inflation,
    anomaly_threshold,
    epoch_chi2,
    segment_jerk,
)
from rangeproc.estimation.update import (
    measured_components,
    record_row,
    row_workspace,
    update_row,
)
from rangeproc.families import Family
from rangeproc.models.measurement import N_COMPONENTS
from rangeproc.models.motion import N_KINEMATIC

#: Parameter layout of ``par`` per step: ``adaptive-noise`` ``[window (rows), remove mean
#: (0/1)]``; ``norm-constraint`` ``[norm (m/s^2)]``; ``fading`` ``estimation.fading
#: .fading_params``; ``anomaly`` ``estimation.spline_filter.spline_params``.
SH_WINDOW, SH_MEAN = 0, 1
NORM = 0


@njit(cache=True, nogil=True, error_model="numpy")
def n_series(sensor: np.ndarray) -> int:
    """Number of sensors the rows name (``max(sensor) + 1``; 1 without rows)."""
    top = 0
    for i in range(sensor.shape[0]):
        top = max(top, sensor[i])
    return top + 1


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def store_epoch(x: np.ndarray, P: np.ndarray, xf: np.ndarray, Pf: np.ndarray, k: int,
                n: int) -> None:
    """Store the ``n``-state ``x``, ``P`` after epoch ``k``'s rows (covariance packed, as
    ``linalg.pack``); a non-finite state is a numerical failure (FloatingPointError)."""
    for a in range(n):
        if not math.isfinite(x[a]):
            raise FloatingPointError("non-finite state in the Kalman filter")
        xf[k, a] = x[a]
    pack_n(P, Pf[k], n)


#: The divergence guard and the row's record, inlined into the loop (a call with array
#: arguments costs their reference counting on every row).
_guard_row = njit(nogil=True, error_model="numpy", inline="always")(guard_row.py_func)
_record_row = njit(nogil=True, error_model="numpy", inline="always")(record_row.py_func)


#: The prediction and the unscented moments at the pipeline's state size, inlined (module
#: globals: a compiled helper held in a closure cell would keep the loop out of the cache).
_predict_fixed = specialise_predict(N_KINEMATIC, "always")[4]
_ukf_fixed = specialise_ukf(N_KINEMATIC, "always")


def _specialise(family: Family, n_state: int) -> Callable:
    """The loop compiled with ``family``'s steps and the state size ``n_state`` as constants
    (module docstring)."""
    JERK = "jerk-input" in family.adds
    FADING = "fading" in family.adds
    ANOMALY = "anomaly" in family.adds
    ADAPTIVE = "adaptive-noise" in family.adds
    CONSTRAINT = "norm-constraint" in family.adds
    ROW_NOISE = ADAPTIVE or ANOMALY          # the update keeps its whitened innovations
    FADE_OUT = FADING or ANOMALY
    # the plain families fix their update (the others take it as an argument)
    METHOD = -1 if (JERK or FADING or ANOMALY or ADAPTIVE) else (
        UKF if family.update == "ukf" else EKF)
    FAST = METHOD == EKF and n_state == fu.N  # the fused fast path for the common rows
    UFAST = METHOD == UKF and n_state == fu.N  # the unscented update at the fixed size
    EKF_ONLY = METHOD == EKF                 # the unscented moments are not compiled in
    FIXED = n_state == N_KINEMATIC           # the fixed-size prediction
    N_STATE = n_state

    def forward(epoch_t, meas_epoch, model, z, sigma, s, sv, Qr, sensor, x0, P0, q_steps, gate,
                reset_after, reset_inflation, x_lin, method, ukf, par):
        E, N, n = epoch_t.shape[0], meas_epoch.shape[0], N_STATE
        meth = METHOD if METHOD >= 0 else method
        joseph = meth == EKF
        use_lin = x_lin.shape[0] == E and meth == EKF
        # --- what every family starts from
        xf, Pf = np.empty((E, n)), np.empty((E, n * (n + 1) // 2))
        nis, ll_rows = np.full(N, np.nan), np.zeros(N)
        dof, rejected = np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.int64)
        x, P = x0.copy(), P0.copy()
        consecutive = np.zeros(n_series(sensor), dtype=np.int64)
        resets = np.zeros(2, dtype=np.int64)
        resets[1] = -1
        (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
         xsig) = row_workspace(n)
        sig_row = np.empty(N_COMPONENTS)
        (f_idx, f_sel, f_sig_row, f_sig, f_y, f_yw, f_sdiag, f_C, f_Z, f_Hs, f_S, f_HP, f_Kt,
         f_AP, f_APHt, f_winv, f_dinv) = fu.fast_workspace()
        # --- the steps' own state, sized to nothing where the family does not add them
        G = n_series(sensor) * N_COMPONENTS
        window = max(int(par[SH_WINDOW]), 1) if ADAPTIVE else 1
        adapt_window = int(par[SH_WINDOW]) if ADAPTIVE else 0
        adapt_mean = ADAPTIVE and par[SH_MEAN] != 0.0
        G_sh = G if ADAPTIVE else 0
        sh_buf = np.zeros((G_sh, window, 2))
        sh_count = np.zeros(G_sh, dtype=np.int64)
        sh_pos = np.zeros(G_sh, dtype=np.int64)
        sh_acc = np.zeros((G_sh, 2))
        y_raw = np.empty(N_COMPONENTS)
        sigma_used = np.full((N if ADAPTIVE else 0, N_COMPONENTS), np.nan)
        maneuver_norm = par[NORM] if CONSTRAINT else 0.0
        Pu = np.empty(n)
        E_ep = E if ANOMALY else 0
        fade = np.ones((E if FADE_OUT else 0, N_KINEMATIC))
        jerk_out = np.zeros((E if JERK else 0, 3))
        anomaly = np.zeros((E_ep, 2))
        knot = np.zeros(E_ep, dtype=np.bool_)
        G_ep = np.zeros((N_OBSERVED, N_OBSERVED))
        Hw = np.zeros((N_COMPONENTS, N_OBSERVED))
        St = np.empty((N_COMPONENTS, N_COMPONENTS))
        tcol = np.empty((N_COMPONENTS, 1))
        b_ep = np.empty(N_OBSERVED)
        L_ep = np.empty((N_OBSERVED, N_OBSERVED))
        v_stf = 0.0
        n_stf = 0
        jerk = np.zeros(3)
        G_spl = G if ANOMALY else 0
        rss = np.zeros(G_spl)
        rss_n = np.zeros(G_spl, dtype=np.int64)
        a_knot = np.zeros(3)
        t_knot = 0.0
        n_meas_ep = 0
        last_knot = -SPL_MIN_SEGMENT
        anomalous = False
        seg_open = False
        loglik = 0.0
        i = 0
        for k in range(E):
            # --- predict (eq. 6-7), with the spline filter's jerk input (Zhou et al. eqs. 5/6)
            if FIXED:
                dt = _predict_fixed(x, P, AP, epoch_t, q_steps, k)
            else:
                dt = predict_epoch(x, P, AP, epoch_t, q_steps, k)
            if JERK and k > 0:
                add_jerk(x, jerk, dt)
                for a in range(3):
                    jerk_out[k, a] = jerk[a]
            # --- before the epoch's rows
            i_epoch = i
            if FADING and k > 0 and dt > 0.0 and i < N and meas_epoch[i] == k:
                e2, m_epoch, fixes = epoch_innovations(i, meas_epoch, model, z, sigma, s, sv,
                                                       Qr, x, P, gate, G_ep, h, H, y6, Hw,
                                                       St, tcol, b_ep)
                if m_epoch > 0:
                    v_row = e2 / m_epoch
                    v_stf = v_row if n_stf == 0 else (par[STF_RHO] * v_stf + v_row) / (
                        1.0 + par[STF_RHO])
                    n_stf += 1
                    if n_stf > STF_WARMUP and fixes and fading_factors(
                            par, v_stf, m_epoch, G_ep, P, dt, q_steps[k], fade[k]):
                        apply_fading(P, fade[k], dt, q_steps[k])
            if ANOMALY and i < N and meas_epoch[i] == k:     # Zhou et al. 2001 sec. 2.2
                chi, m_ep = epoch_chi2(i, meas_epoch, model, z, sigma, s, sv, Qr, x, P, gate,
                                       G_ep, L_ep, h, H, y6, Hw, St, tcol, b_ep)
                anomaly[k, 0] = chi
                anomaly[k, 1] = m_ep
                anomalous = (m_ep > 0 and n_meas_ep >= SPL_WARMUP and not seg_open
                             and n_meas_ep - last_knot >= SPL_MIN_SEGMENT
                             and chi > anomaly_threshold(par, m_ep))
                if anomalous:                            # covariance opened (fading)
                    knot[k] = True
                    last_knot = n_meas_ep
                    lam = anomaly_inflation(chi, m_ep, G_ep, P)
                    for a in range(N_KINEMATIC):         # stored: the smoother runs it too
                        fade[k, a] = lam
                    apply_fading(P, fade[k], dt, q_steps[k])
            # --- the epoch's rows: gated update (eq. 8-10) and divergence guard
            while i < N and meas_epoch[i] == k:
                if FAST:
                    m, n_cols = fu.ekf_moments(model[i], z, sigma, s, sv, Qr, i, x, x_lin, k,
                                               use_lin, P, f_idx, f_sig_row, f_y, f_C, f_Z,
                                               f_Hs)
                    if m >= 0:                           # the fast path took the row
                        dof[i] = m
                        if m > 0:
                            val, ok, ld = fu.whole_row(f_y, f_sig_row, f_C, f_Z, f_Hs, m,
                                                       n_cols, x, P, gate, True, f_yw, f_winv,
                                                       f_HP, f_S, f_dinv, f_Kt, f_AP, f_APHt)
                            if ok:                       # the whole row passed the gate
                                loglik = _record_row(i, val, 0, fu.row_loglik(val, ld, m),
                                                     loglik, nis, rejected, ll_rows)
                                consecutive[sensor[i]] = 0   # the guard's count restarts
                            else:                        # per-component re-gating
                                val, ok, _, mask, ll_row = fu.regate(   # the general
                                    f_y, f_sig_row, f_C, f_Z, f_Hs, f_idx, m, x, P, gate,
                                    joseph, ROW_NOISE, f_sel, f_sig, f_yw, f_HP, f_S, f_Kt,
                                    f_AP, f_APHt, f_sdiag, ew, Sinv)  # update's signature
                                loglik = _record_row(i, val, mask, ll_row, loglik, nis,
                                                     rejected, ll_rows)
                                _guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive,
                                           resets, reset_after, reset_inflation, P)
                        i += 1
                        continue
                m = measured_components(z[i], sigma[i], idx, sig_row)
                dof[i] = m
                if m > 0:
                    if UFAST:                            # all rows, inlined, n fixed
                        if not _ukf_fixed(model[i], z[i], s[i], sv[i], Qr[i], x, P, idx, m,
                                          ukf, L, Zs, xsig, h, H, y6, y, C, Z):
                            raise FloatingPointError("covariance not positive definite in UKF")
                    elif EKF_ONLY:
                        ekf_row_moments(model[i], z[i], s[i], sv[i], Qr[i], x,
                                        x_lin[k] if use_lin else x, use_lin, P, idx, m, h, H,
                                        y6, y, C, Z, Hs, sig_row)
                    else:
                        row_moments(meth, model[i], z[i], s[i], sv[i], Qr[i], x,
                                    x_lin[k] if use_lin else x, use_lin, P, idx, m, ukf, L,
                                    Zs, xsig, h, H, y6, y, C, Z, Hs, sig_row)
                    if ADAPTIVE:                         # Sage-Husa: windowed noise
                        for a in range(m):
                            y_raw[a] = y[a]
                        sh_adapt(sensor[i], idx, m, sig_row, y, sh_count, sh_acc,
                                 adapt_window, adapt_mean)
                        for a in range(m):
                            sigma_used[i, idx[a]] = sig_row[a]
                    if ANOMALY and anomalous:            # Zhou et al. 2001 2.3.1: adapted R
                        for a in range(m):
                            g = sensor[i] * N_COMPONENTS + idx[a]
                            if rss_n[g] >= SPL_RMS_MIN:
                                rms = math.sqrt(rss[g] / (rss_n[g] - 1))
                                sig_row[a] = min(max(sig_row[a], rms),
                                                 SPL_MAX_RATIO * sig_row[a])
                    if UFAST:                            # the fast path's update, P - K HP
                        val, ok, n_acc, mask, ll_row = fu.row_update(
                            y, sig_row, C, Z, Hs, idx, m, x, P, gate, False, sel, sig, yw,
                            f_winv, HP, S, f_dinv, Kt, AP, APHt, sdiag, ew, Sinv)
                    else:
                        val, ok, n_acc, mask, ll_row = update_row(
                            y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, ROW_NOISE, sel,
                            sig, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv)
                    loglik = _record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                    if ADAPTIVE and ok:                  # Sage-Husa window, accepted only
                        for b in range(n_acc):
                            a = sel[b]
                            scale = sig_row[a] / sigma[i, idx[a]]
                            ratio = (ew[b] * ew[b] + 1.0 - Sinv[b, b]) * scale * scale
                            sh_record(sensor[i] * N_COMPONENTS + idx[a], ratio, y_raw[a],
                                      sh_buf, sh_count, sh_pos, sh_acc, adapt_window)
                    if ANOMALY and ok:                   # running residual RSS (2.3.1)
                        for b in range(n_acc):
                            g = sensor[i] * N_COMPONENTS + idx[sel[b]]
                            r = ew[b] * sig[b]           # post-update residual z - h(x_k)
                            rss[g] += r * r
                            rss_n[g] += 1
                    if _guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets,
                                 reset_after, reset_inflation, P) and ADAPTIVE:
                        sh_reset(sh_count, sh_pos, sh_acc)  # divergence: a-priori noise
                i += 1
            # --- after the epoch's rows
            if CONSTRAINT and maneuver_norm > 0.0:
                norm_update(x, P, x_lin[k] if use_lin else x, maneuver_norm, Pu)
            if ANOMALY and i_epoch < i:                  # the epoch had rows
                if anomalous:                            # Zhou et al. 2001 2.3.2: new segment
                    for a in range(3):
                        a_knot[a] = x[6 + a]
                    t_knot = epoch_t[k]
                    anomalous = False
                    seg_open = True
                elif seg_open and n_meas_ep - last_knot >= SPL_MIN_SEGMENT - 1 \
                        and epoch_t[k] - t_knot >= SPL_JERK_SPAN:
                    segment_jerk(x, a_knot, epoch_t[k] - t_knot, jerk)
                    seg_open = False
                n_meas_ep += 1
            store_epoch(x, P, xf, Pf, k, N_STATE)
        return (xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows, sigma_used, fade,
                jerk_out, anomaly, knot)

    return njit(cache=True, nogil=True, error_model="numpy")(
        specialisation(forward, family.name, n_state))


_KERNELS: dict[tuple[str, int], Callable] = {}


def forward_kernel(family: Family, n_state: int = N_KINEMATIC) -> Callable:
    """The compiled loop of ``family`` at the state size ``n_state`` (made on first use;
    compiled, or loaded from the cache, at its first call)."""
    key = (family.name, n_state)
    kernel = _KERNELS.get(key)
    if kernel is None:
        kernel = _KERNELS[key] = _specialise(family, n_state)
    return kernel
