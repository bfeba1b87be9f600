"""The forward filters' compiled kernels, one per filter family.

Each kernel runs one forward pass of He 2015 sec. 3.1 over a time-ordered batch of rows:
prediction by the constant-acceleration model (eq. 6-7, ``estimation.kernels``), then each row's
gated update (eq. 8-10, ``estimation.update``) and the divergence guard
(``estimation.divergence``). The families differ only in what they add around those steps,
and a run compiles only the kernel of the family it uses:

* :func:`ekf_forward`: the linearised update (Joseph form), optionally linearised at a
  previous smoothed trajectory and with the maneuver-norm constraint (``askf``);
* :func:`ukf_forward`: the unscented update;
* :func:`sage_husa_forward`: improved Sage-Husa adaptive measurement noise
  (``estimation.adaptive``), EKF or UKF update;
* :func:`fading_forward`: Ye and Cui's strong tracking (``estimation.fading``), EKF or UKF;
* :func:`spline_forward`: Zhou et al.'s self-adaptive spline filter
  (``estimation.spline_filter``), EKF or UKF.

Callers use the typed entry :func:`rangeproc.estimation.forward.run_filter`; its
:class:`~rangeproc.estimation.forward.FilterRows`, ``FilterPrior`` and ``FilterSettings``
document the arguments (times in s, range ENU in m, the CA state ``[p, v, a]`` (9,) then any
calibration states). Every kernel returns ``(xf (E, n), Pf (E, n(n+1)/2) packed, nis (N,),
dof (N,), rejected (N,) bit masks, loglik, n_resets, ll_rows (N,))`` followed by its family's
own outputs.

Epoch bookkeeping: ``epoch_t`` (E,) are the distinct times at which a state is wanted
(measurement times and output-grid times); each row names its epoch. A kernel stores the
state after all rows of an epoch (packed covariance), which is all the RTS smoother needs:
the predicted covariance is recomputed there by the same arithmetic.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

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
from rangeproc.estimation.kernels import N_OBSERVED, predict_epoch
from rangeproc.estimation.linalg import pack
from rangeproc.estimation.moments import (
    EKF,
    add_linearisation_noise,
    ekf_moments,
    row_moments,
    ukf_moments,
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
from rangeproc.models.measurement import N_COMPONENTS
from rangeproc.models.motion import N_KINEMATIC


@njit(cache=True, nogil=True, error_model="numpy")
def forward_start(E: int, N: int, x0: np.ndarray, P0: np.ndarray, sensor: np.ndarray):
    """What every kernel starts from: its outputs ``xf`` (E, n), ``Pf`` (E, n(n+1)/2),
    ``nis`` (N,) NaN, ``dof``, ``rejected`` (N,) int64 zeros, ``ll_rows`` (N,) zeros; the
    state ``x``, ``P`` (copies of the prior); the divergence guard's per-sensor counts and
    ``resets`` = [number, last epoch] (``estimation.divergence.guard_row``)."""
    n = x0.shape[0]
    resets = np.zeros(2, dtype=np.int64)
    resets[1] = -1
    return (np.empty((E, n)), np.empty((E, n * (n + 1) // 2)), np.full(N, np.nan),
            np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.int64), np.zeros(N),
            x0.copy(), P0.copy(), np.zeros(n_series(sensor), dtype=np.int64), resets)


@njit(cache=True, nogil=True, error_model="numpy")
def store_epoch(x: np.ndarray, P: np.ndarray, xf: np.ndarray, Pf: np.ndarray, k: int) -> None:
    """Store the state after epoch ``k``'s rows (covariance packed); a non-finite state is a
    numerical failure (FloatingPointError)."""
    for a in range(x.shape[0]):
        if not math.isfinite(x[a]):
            raise FloatingPointError("non-finite state in the Kalman filter")
        xf[k, a] = x[a]
    pack(P, Pf[k])


@njit(cache=True, nogil=True, error_model="numpy")
def n_series(sensor: np.ndarray) -> int:
    """Number of sensors the rows name (``max(sensor) + 1``; 1 without rows)."""
    top = 0
    for i in range(sensor.shape[0]):
        top = max(top, sensor[i])
    return top + 1


@njit(cache=True, nogil=True, error_model="numpy")
def ekf_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                reset_inflation: float, x_lin: np.ndarray, maneuver_norm: float):
    """The extended Kalman filter: linearised at the prediction, or at ``x_lin`` (E, n) when
    it has E rows (one Gauss-Newton step of the iterated extended Kalman smoother); with
    ``maneuver_norm`` > 0 (m/s^2) the constant-norm maneuver of patent CN109581356A as a
    pseudo-measurement after each epoch's rows (``estimation.constraint``)."""
    E, N, n = epoch_t.shape[0], meas_epoch.shape[0], x0.shape[0]
    xf, Pf, nis, dof, rejected, ll_rows, x, P, consecutive, resets = forward_start(
        E, N, x0, P0, sensor)
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, _, _,
     _) = row_workspace(n)
    sig_row = np.empty(N_COMPONENTS)
    Pu = np.empty(n)
    use_lin = x_lin.shape[0] == E
    fast = n == fu.N                                     # the fast path's state size
    (f_idx, f_sel, f_sig_row, f_sig, f_y, f_yw, f_sdiag, f_C, f_Z, f_Hs, f_S, f_HP, f_Kt, f_AP,
     f_APHt) = fu.fast_workspace()
    loglik = 0.0
    i = 0
    for k in range(E):
        predict_epoch(x, P, AP, epoch_t, q_steps, k)
        while i < N and meas_epoch[i] == k:
            m = fu.ekf_moments(model[i], z, sigma, s, Qr, i, x, x_lin, k, use_lin, P, f_idx,
                               f_sig_row, f_y, f_C, f_Z, f_Hs) if fast else -1
            if m >= 0:                                   # the fast path took the row
                dof[i] = m
                if m > 0:
                    val, ok, _, mask, ll_row = fu.update(
                        f_y, f_sig_row, f_C, f_Z, f_Hs, f_idx, m, x, P, gate, True, f_sel,
                        f_sig, f_yw, f_HP, f_S, f_Kt, f_AP, f_APHt, f_sdiag)
                    loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                    guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets,
                              reset_after, reset_inflation, P)
                i += 1
                continue
            m = measured_components(z[i], sigma[i], idx, sig_row)
            dof[i] = m
            if m > 0:
                ekf_moments(model[i], z[i], s[i], sv[i], Qr[i], x, x_lin[k] if use_lin else x,
                            use_lin, P, idx, m, h, H, y6, y, C, Z, Hs)
                add_linearisation_noise(model[i], sig_row, idx, m, x, s[i], Qr[i], P)
                val, ok, _, mask, ll_row = update_row(
                    y, sig_row, C, Z, Hs, idx, m, x, P, gate, True, False, sel, sig, yw, HP,
                    S, Kt, AP, APHt, sdiag, ew, Sinv)
                loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets, reset_after,
                          reset_inflation, P)
            i += 1
        if maneuver_norm > 0.0:
            norm_update(x, P, x_lin[k] if use_lin else x, maneuver_norm, Pu)
        store_epoch(x, P, xf, Pf, k)
    return xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows


@njit(cache=True, nogil=True, error_model="numpy")
def ukf_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                reset_inflation: float, ukf: np.ndarray):
    """The unscented Kalman filter: the update by the unscented transform with sigma-point
    parameters ``ukf`` = ``[alpha, beta, kappa]`` (Ye and Cui: kappa = 3 - n); the linear
    prediction is exact."""
    E, N, n = epoch_t.shape[0], meas_epoch.shape[0], x0.shape[0]
    xf, Pf, nis, dof, rejected, ll_rows, x, P, consecutive, resets = forward_start(
        E, N, x0, P0, sensor)
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
     xsig) = row_workspace(n)
    sig_row = np.empty(N_COMPONENTS)
    loglik = 0.0
    i = 0
    for k in range(E):
        predict_epoch(x, P, AP, epoch_t, q_steps, k)
        while i < N and meas_epoch[i] == k:
            m = measured_components(z[i], sigma[i], idx, sig_row)
            dof[i] = m
            if m > 0:
                if not ukf_moments(model[i], z[i], s[i], sv[i], Qr[i], x, P, idx, m, ukf, L,
                                   Zs, xsig, h, H, y6, y, C, Z):
                    raise FloatingPointError("covariance not positive definite in UKF")
                val, ok, _, mask, ll_row = update_row(
                    y, sig_row, C, Z, Hs, idx, m, x, P, gate, False, False, sel, sig, yw, HP,
                    S, Kt, AP, APHt, sdiag, ew, Sinv)
                loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets, reset_after,
                          reset_inflation, P)
            i += 1
        store_epoch(x, P, xf, Pf, k)
    return xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows


@njit(cache=True, nogil=True, error_model="numpy")
def sage_husa_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                      z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                      Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                      q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                      reset_inflation: float, x_lin: np.ndarray, method: int, ukf: np.ndarray,
                      adapt_window: int, adapt_mean: bool):
    """Improved Sage-Husa adaptive measurement noise (``estimation.adaptive``) over windows of
    ``adapt_window`` accepted rows per sensor component (also removing the windowed noise
    mean with ``adapt_mean``); ``method`` ``EKF`` (linearised at ``x_lin`` when it has E rows)
    or ``UKF``. Returns the common outputs, then ``sigma_used`` (N, 6): the adapted sigmas
    each update used (NaN where not measured)."""
    E, N, n = epoch_t.shape[0], meas_epoch.shape[0], x0.shape[0]
    xf, Pf, nis, dof, rejected, ll_rows, x, P, consecutive, resets = forward_start(
        E, N, x0, P0, sensor)
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
     xsig) = row_workspace(n)
    sig_row = np.empty(N_COMPONENTS)
    y_raw = np.empty(N_COMPONENTS)
    use_lin = x_lin.shape[0] == E and method == EKF
    joseph = method == EKF
    G = n_series(sensor) * N_COMPONENTS
    window = max(adapt_window, 1)
    sh_buf = np.zeros((G, window, 2))
    sh_count = np.zeros(G, dtype=np.int64)
    sh_pos = np.zeros(G, dtype=np.int64)
    sh_acc = np.zeros((G, 2))
    sigma_used = np.full((N, N_COMPONENTS), np.nan)
    loglik = 0.0
    i = 0
    for k in range(E):
        predict_epoch(x, P, AP, epoch_t, q_steps, k)
        while i < N and meas_epoch[i] == k:
            m = measured_components(z[i], sigma[i], idx, sig_row)
            dof[i] = m
            if m > 0:
                row_moments(method, model[i], z[i], s[i], sv[i], Qr[i], x,
                            x_lin[k] if use_lin else x, use_lin, P, idx, m, ukf, L, Zs, xsig,
                            h, H, y6, y, C, Z, Hs, sig_row)
                for a in range(m):
                    y_raw[a] = y[a]
                sh_adapt(sensor[i], idx, m, sig_row, y, sh_count, sh_acc, adapt_window,
                         adapt_mean)
                for a in range(m):
                    sigma_used[i, idx[a]] = sig_row[a]
                val, ok, n_acc, mask, ll_row = update_row(
                    y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, True, sel, sig, yw, HP,
                    S, Kt, AP, APHt, sdiag, ew, Sinv)
                loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                if ok:                                   # Sage-Husa window, accepted only
                    for b in range(n_acc):
                        a = sel[b]
                        scale = sig_row[a] / sigma[i, idx[a]]
                        ratio = (ew[b] * ew[b] + 1.0 - Sinv[b, b]) * scale * scale
                        sh_record(sensor[i] * N_COMPONENTS + idx[a], ratio, y_raw[a], sh_buf,
                                  sh_count, sh_pos, sh_acc, adapt_window)
                if guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets,
                             reset_after, reset_inflation, P):
                    sh_reset(sh_count, sh_pos, sh_acc)  # divergence: back to a-priori noise
            i += 1
        store_epoch(x, P, xf, Pf, k)
    return xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows, sigma_used


@njit(cache=True, nogil=True, error_model="numpy")
def fading_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                   z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                   Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                   q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                   reset_inflation: float, x_lin: np.ndarray, method: int, ukf: np.ndarray,
                   stf: np.ndarray):
    """Strong tracking (Ye and Cui, ``estimation.fading``) with parameters ``stf`` (5,):
    forgetting factor rho, weakening factor beta, prior ratios alpha of position, velocity,
    acceleration; ``method`` ``EKF`` (linearised at ``x_lin`` when it has E rows) or ``UKF``.
    Returns the common outputs, then ``fade`` (E, 9): the fading factors applied to the
    prediction ending at each epoch (the smoother applies them too)."""
    E, N, n = epoch_t.shape[0], meas_epoch.shape[0], x0.shape[0]
    xf, Pf, nis, dof, rejected, ll_rows, x, P, consecutive, resets = forward_start(
        E, N, x0, P0, sensor)
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
     xsig) = row_workspace(n)
    sig_row = np.empty(N_COMPONENTS)
    use_lin = x_lin.shape[0] == E and method == EKF
    joseph = method == EKF
    fade = np.ones((E, N_KINEMATIC))
    v_stf = 0.0
    n_stf = 0
    G_stf = np.zeros((N_OBSERVED, N_OBSERVED))
    Hw = np.zeros((N_COMPONENTS, N_OBSERVED))
    St = np.empty((N_COMPONENTS, N_COMPONENTS))
    tcol = np.empty((N_COMPONENTS, 1))
    b_ep = np.empty(N_OBSERVED)
    loglik = 0.0
    i = 0
    for k in range(E):
        dt = predict_epoch(x, P, AP, epoch_t, q_steps, k)
        if k > 0:
            if dt > 0.0 and i < N and meas_epoch[i] == k:
                e2, m_epoch, fixes = epoch_innovations(i, meas_epoch, model, z, sigma, s, sv,
                                                       Qr, x, P, gate, G_stf, h, H, y6, Hw,
                                                       St, tcol, b_ep)
                if m_epoch > 0:
                    v_row = e2 / m_epoch
                    v_stf = v_row if n_stf == 0 else (stf[STF_RHO] * v_stf + v_row) / (
                        1.0 + stf[STF_RHO])
                    n_stf += 1
                    if n_stf > STF_WARMUP and fixes and fading_factors(
                            stf, v_stf, m_epoch, G_stf, P, dt, q_steps[k], fade[k]):
                        apply_fading(P, fade[k], dt, q_steps[k])
        while i < N and meas_epoch[i] == k:
            m = measured_components(z[i], sigma[i], idx, sig_row)
            dof[i] = m
            if m > 0:
                row_moments(method, model[i], z[i], s[i], sv[i], Qr[i], x,
                            x_lin[k] if use_lin else x, use_lin, P, idx, m, ukf, L, Zs, xsig,
                            h, H, y6, y, C, Z, Hs, sig_row)
                val, ok, _, mask, ll_row = update_row(
                    y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, False, sel, sig, yw, HP,
                    S, Kt, AP, APHt, sdiag, ew, Sinv)
                loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets, reset_after,
                          reset_inflation, P)
            i += 1
        store_epoch(x, P, xf, Pf, k)
    return xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows, fade


@njit(cache=True, nogil=True, error_model="numpy")
def spline_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                   z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                   Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                   q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                   reset_inflation: float, x_lin: np.ndarray, method: int, ukf: np.ndarray,
                   spl: np.ndarray):
    """Zhou et al.'s self-adaptive spline filter (``estimation.spline_filter``) with the
    anomaly test's chi-square quantiles ``spl`` (``spline_params``): a piecewise-constant jerk
    enters every prediction as a known input, and an epoch whose stacked innovation
    chi-square exceeds its quantile has its rows updated with the adapted sigmas and starts a
    new segment with a re-estimated jerk. ``method`` ``EKF`` (linearised at ``x_lin`` when it
    has E rows) or ``UKF``.

    Returns the common outputs, then ``fade`` (E, 9) the covariance opening at each anomaly,
    ``jerk`` (E, 3) the jerk input (m/s^3) of the step ending at each epoch, ``anomaly``
    (E, 2) the epoch's stacked chi-square and its degrees of freedom (0, 0 without rows),
    ``knot`` (E,) bool: the anomaly test fired there (a new segment starts).
    """
    E, N, n = epoch_t.shape[0], meas_epoch.shape[0], x0.shape[0]
    xf, Pf, nis, dof, rejected, ll_rows, x, P, consecutive, resets = forward_start(
        E, N, x0, P0, sensor)
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
     xsig) = row_workspace(n)
    sig_row = np.empty(N_COMPONENTS)
    use_lin = x_lin.shape[0] == E and method == EKF
    joseph = method == EKF
    fade = np.ones((E, N_KINEMATIC))
    G_ep = np.zeros((N_OBSERVED, N_OBSERVED))
    Hw = np.zeros((N_COMPONENTS, N_OBSERVED))
    St = np.empty((N_COMPONENTS, N_COMPONENTS))
    tcol = np.empty((N_COMPONENTS, 1))
    jerk_out = np.zeros((E, 3))
    anomaly = np.zeros((E, 2))
    knot = np.zeros(E, dtype=np.bool_)
    jerk = np.zeros(3)
    G_spl = n_series(sensor) * N_COMPONENTS
    rss = np.zeros(G_spl)
    rss_n = np.zeros(G_spl, dtype=np.int64)
    a_knot = np.zeros(3)
    t_knot = 0.0
    b_spl = np.empty(N_OBSERVED)
    L_spl = np.empty((N_OBSERVED, N_OBSERVED))
    n_meas_ep = 0
    last_knot = -SPL_MIN_SEGMENT
    anomalous = False
    seg_open = False
    dt = 0.0
    loglik = 0.0
    i = 0
    for k in range(E):
        if k > 0:
            dt = predict_epoch(x, P, AP, epoch_t, q_steps, k)
            add_jerk(x, jerk, dt)                        # Zhou et al. 2001 eqs. 5/6
            for a in range(3):
                jerk_out[k, a] = jerk[a]
        i_epoch = i
        if i < N and meas_epoch[i] == k:                 # Zhou et al. 2001 sec. 2.2
            chi, m_ep = epoch_chi2(i, meas_epoch, model, z, sigma, s, sv, Qr, x, P, gate,
                                   G_ep, L_spl, h, H, y6, Hw, St, tcol, b_spl)
            anomaly[k, 0] = chi
            anomaly[k, 1] = m_ep
            anomalous = (m_ep > 0 and n_meas_ep >= SPL_WARMUP and not seg_open
                         and n_meas_ep - last_knot >= SPL_MIN_SEGMENT
                         and chi > anomaly_threshold(spl, m_ep))
            if anomalous:                                # covariance opened (fading)
                knot[k] = True
                last_knot = n_meas_ep
                lam = anomaly_inflation(chi, m_ep, G_ep, P)
                for a in range(N_KINEMATIC):             # stored: the smoother runs it too
                    fade[k, a] = lam
                apply_fading(P, fade[k], dt, q_steps[k])
        while i < N and meas_epoch[i] == k:
            m = measured_components(z[i], sigma[i], idx, sig_row)
            dof[i] = m
            if m > 0:
                row_moments(method, model[i], z[i], s[i], sv[i], Qr[i], x,
                            x_lin[k] if use_lin else x, use_lin, P, idx, m, ukf, L, Zs, xsig,
                            h, H, y6, y, C, Z, Hs, sig_row)
                if anomalous:                            # Zhou et al. 2001 2.3.1: adapted R
                    for a in range(m):
                        g = sensor[i] * N_COMPONENTS + idx[a]
                        if rss_n[g] >= SPL_RMS_MIN:
                            rms = math.sqrt(rss[g] / (rss_n[g] - 1))
                            sig_row[a] = min(max(sig_row[a], rms), SPL_MAX_RATIO * sig_row[a])
                val, ok, n_acc, mask, ll_row = update_row(
                    y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, True, sel, sig, yw, HP,
                    S, Kt, AP, APHt, sdiag, ew, Sinv)
                loglik = record_row(i, val, mask, ll_row, loglik, nis, rejected, ll_rows)
                if ok:                                   # running residual RSS (2.3.1)
                    for b in range(n_acc):
                        g = sensor[i] * N_COMPONENTS + idx[sel[b]]
                        r = ew[b] * sig[b]               # post-update residual z - h(x_k)
                        rss[g] += r * r
                        rss_n[g] += 1
                guard_row(val, ok, mask, m, gate, k, sensor[i], consecutive, resets, reset_after,
                          reset_inflation, P)
            i += 1
        if i_epoch < i:                                  # the epoch had rows
            if anomalous:                                # Zhou et al. 2001 2.3.2: new segment
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
        store_epoch(x, P, xf, Pf, k)
    return xf, Pf, nis, dof, rejected, loglik, resets[0], ll_rows, fade, jerk_out, anomaly, knot
