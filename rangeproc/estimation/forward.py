"""Kalman filter (EKF or UKF update) over a time-ordered batch of measurement rows (compiled).

One forward pass of He 2015 sec. 3.1: prediction (eq. 6-7), gain (eq. 8), Joseph-form
covariance update (eq. 9), state update (eq. 10), and innovation chi-square gating: a row
whose normalised innovation squared exceeds the gate is not used and the filter carries the
prediction (He 2015: "an abnormal measurement is replaced by the prediction"; the chi-square
test itself is Zhou et al. 2001 sec. 2.2). Gating is per component when it can be: if a row fails,
the components whose own marginal test fails are dropped and the rest is gated again, so a
radar range glitch does not throw away good angles and range rate.

Numerical care, so that radar rows mixing 25 m^2 with 4e-8 rad^2 stay well conditioned over
100,000+ steps: every row is *whitened* (each component and its Jacobian row divided by the
component's sigma, so R becomes I and the innovation covariance S = H P H^T + I has
eigenvalues >= 1), S is factored by Cholesky, and the covariance update is the Joseph form
``(I - K H) P (I - K H)^T + K K^T``, evaluated through ``A P = P - K (H P)`` so that it costs
O(n^2 m) instead of O(n^3) (the same terms, associated differently), then symmetrised.

Epoch bookkeeping: ``epoch_t`` (E,) are the distinct times at which a state is wanted
(measurement times and output-grid times); each measurement row names its epoch. The filter
stores the state after all rows of an epoch (packed covariance), which is all the RTS smoother
needs: the predicted covariance is recomputed there by the same arithmetic.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from rangeproc.estimation.adaptive import sh_adapt, sh_record, sh_reset
from rangeproc.estimation.constraint import norm_update
from rangeproc.estimation.fading import (
    STF_RHO,
    STF_WARMUP,
    apply_fading,
    epoch_innovations,
    fading_factors,
)
from rangeproc.estimation.kernels import N_OBSERVED, predict_cov, predict_state
from rangeproc.estimation.divergence import (
    MAX_RESET_INFLATION,
    PARTIAL_DIVERGENCE,
    reset_covariance,
)
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace, pack
from rangeproc.estimation.moments import (  # EKF, UKF: kalman_forward's method codes
    EKF,
    UKF,  # noqa: F401
    add_linearisation_noise,
    row_moments,
)
from rangeproc.estimation.spline_filter import (
    SPL_MAX_RATIO,
    SPL_MIN_SEGMENT,
    SPL_JERK_SPAN,
    SPL_RMS_MIN,
    SPL_WARMUP,
    add_jerk,
    anomaly_inflation,
    anomaly_threshold,
    epoch_chi2,
    segment_jerk,
)
from rangeproc.models.measurement import N_COMPONENTS
from rangeproc.models.motion import N_KINEMATIC

LOG_2PI = math.log(2.0 * math.pi)



#: ``stf`` argument of :func:`kalman_forward` that switches strong-tracking fading off.
NO_FADING = np.zeros(0)

#: ``spl`` argument of :func:`kalman_forward` that switches the adaptive spline filter off.
NO_SPLINE = np.zeros(0)


class ForwardOutput(NamedTuple):
    """:func:`kalman_forward`'s results by name (``ForwardOutput._make(kalman_forward(...))``;
    the compiled kernel returns the plain tuple, in this order; see its Returns)."""

    xf: np.ndarray
    Pf: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    rejected: np.ndarray
    loglik: float
    n_resets: int
    ll_rows: np.ndarray
    sigma_used: np.ndarray
    fade: np.ndarray
    jerk: np.ndarray
    anomaly: np.ndarray
    knot: np.ndarray


@njit(cache=True, error_model="numpy", inline="always")
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


@njit(cache=True, error_model="numpy", inline="always")
def gated_update(y: np.ndarray, sig: np.ndarray, C: np.ndarray, Z: np.ndarray,
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
    n = x.shape[0]
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
    if not cholesky_inplace(S, m):
        return math.inf, False, 0.0
    logdet = 0.0
    for a in range(m):
        logdet += 2.0 * math.log(S[a, a])
    for a in range(m):                                   # nis = yw^T S^-1 yw
        Kt[a, 0] = yw[a]
    chol_solve_inplace(S, m, Kt, 1)
    nis = 0.0
    for a in range(m):
        nis += yw[a] * Kt[a, 0]
    if nis > gate[m]:
        return nis, False, logdet
    if want_stats:
        for a in range(m):
            ew[a] = Kt[a, 0]
            for b in range(m):
                Sinv[a, b] = 1.0 if a == b else 0.0
        chol_solve_inplace(S, m, Sinv, m)
    for a in range(m):                                   # K^T = S^-1 (H P): gain, eq. 8
        for j in range(n):
            Kt[a, j] = HP[a, j]
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
                for c in range(N_OBSERVED):
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


@njit(cache=True, error_model="numpy", inline="always")
def update_row(y: np.ndarray, sig_row: np.ndarray, C: np.ndarray, Z: np.ndarray,
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
    val, ok, logdet = gated_update(y, sig, C, Z, Hs, sel, m, x, P, gate, joseph, yw, HP, S, Kt,
                                   AP, APHt, sdiag, stats, ew, Sinv)
    n_acc = m if ok else 0
    mask = 0
    ll = 0.0
    if not ok and m > 1 and math.isfinite(val):
        # drop components failing their own marginal test, gate the rest again
        mk = 0
        for a in range(m):
            if yw[a] * yw[a] / sdiag[a] <= gate[1]:
                sel[mk] = a
                sig[mk] = sig_row[a]
                mk += 1
            else:
                mask |= 1 << idx[a]
        if 0 < mk < m:
            val2, ok2, logdet2 = gated_update(y, sig, C, Z, Hs, sel, mk, x, P, gate, joseph,
                                              yw, HP, S, Kt, AP, APHt, sdiag, stats, ew, Sinv)
            if ok2:
                ok = True
                n_acc = mk
                ll = -0.5 * (val2 + logdet2 + mk * LOG_2PI + (m - mk) * gate[1])
        if not ok:
            mask = 0
    if ok and mask == 0:
        ll = -0.5 * (val + logdet + m * LOG_2PI)
    if not ok:
        for a in range(m):
            mask |= 1 << idx[a]
        ll = -0.5 * (min(val, gate[m]) + logdet + m * LOG_2PI)
    return val, ok, n_acc, mask, ll


@njit(cache=True, nogil=True, error_model="numpy")
def kalman_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                   z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                   Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                   q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                   reset_inflation: float, x_lin: np.ndarray, method: int, ukf: np.ndarray,
                   adapt_window: int, adapt_mean: bool, maneuver_norm: float,
                   stf: np.ndarray, spl: np.ndarray):
    """Run the Kalman filter (EKF or UKF measurement update) over all epochs.

    Args:
        epoch_t: (E,) ascending distinct epoch times (s); the prior ``x0, P0`` is at epoch_t[0].
        meas_epoch: (N,) epoch index of each row (non-decreasing).
        model: (N,) measurement model code per row; z, sigma: (N, 6) values / 1-sigma (NaN in z
            = not measured); s, sv: (N, 3) sensor position / velocity in range ENU; Qr: (N,3,3);
            sensor: (N,) int64 sensor index of each row (>= 0).
        x0: (n,), P0: (n, n) prior. q_steps: (E,) white-jerk PSD (m^2/s^5) of the step
            ending at each epoch (index 0 unused). gate: (7,) chi-square thresholds by degrees
            of freedom (inf disables gating).
        reset_after: divergence guard. When one sensor has this many consecutive rows
            rejected, or accepted only in part with a chi-square above ``PARTIAL_DIVERGENCE``
            times the gate (other sensors' rows may be accepted in between: an
            angle-only sensor can keep "agreeing" with a track that drifted along its line of
            sight; nor does a radar's accepted elevation hold a track whose range and azimuth
            it rejects after a manoeuvre), the kinematic
            covariance is multiplied by ``max(reset_inflation, 4 nis / gate)`` (at most
            ``MAX_RESET_INFLATION``, never beyond ``RESET_CEILING``, and at most once per
            epoch: thousands of rows sharing one time stamp must not compound it) so the track
            re-acquires instead of rejecting that sensor for ever. 0 disables.
        x_lin: (E, n) linearisation states per epoch (the previous smoothed trajectory: one
            Gauss-Newton step of the iterated extended Kalman smoother), or an array with zero
            rows to linearise at the prediction as the plain EKF does (EKF only).
        method: ``EKF`` (linearised update, Joseph form) or ``UKF`` (unscented update).
        ukf: (3,) ``[alpha, beta, kappa]`` of the UKF sigma points (Ye and Cui: kappa = 3 - n);
            ignored by the EKF. (Both are explicit arguments, never defaults: numba's cache
            keys an omitted array default on the object, so it would recompile every process.)
        adapt_window: > 0: improved Sage-Husa adaptive measurement noise over windows of this
            many accepted rows per sensor component (``estimation.adaptive``); 0: off, the
            stated sigmas are used as they are. adapt_mean: also remove the windowed noise
            mean from the innovations.
        maneuver_norm: > 0: the constant-norm maneuver of patent CN109581356A,
            ``||d|| = maneuver_norm`` (m/s^2) on the acceleration block as a
            pseudo-measurement at every epoch after its rows (``estimation.constraint``),
            linearised at ``x_lin`` when given; 0: off.
        stf: (5,) strong tracking (Ye and Cui, ``estimation.fading``): forgetting factor rho,
            weakening factor beta, prior ratios alpha of position, velocity, acceleration;
            an empty array switches fading off.
        spl: Zhou et al.'s self-adaptive spline filter (``estimation.spline_filter``): the
            anomaly test's chi-square quantiles (``spline_params``); an empty array
            (``NO_SPLINE``) switches it off. On: a piecewise-constant jerk enters every
            prediction as a known input, and an epoch whose stacked innovation chi-square
            exceeds its quantile has its rows updated with the adapted sigmas and starts a new
            segment with a re-estimated jerk. Not combined with ``adapt_window``.

    The motion model is linear (constant acceleration), so the prediction is exact for both
    methods and the UKF differs from the EKF only in the measurement update.

    Returns:
        xf (E, n) filtered states, Pf (E, n(n+1)/2) packed filtered covariances,
        nis (N,) row innovation chi-square, dof (N,) int64 measured components,
        rejected (N,) int64 bit mask of the components the gate rejected (bit c = component
        c), loglik (Gaussian log-likelihood of the whitened innovations, rejected rows counted
        at the gate), n_resets (int), ll_rows (N,) each row's contribution to loglik,
        sigma_used (N, 6) the sigmas the update used (adapted; ``(0, 6)`` when adaptation is
        off, the input sigmas then), fade (E, 9) the fading factors applied to the
        prediction ending at each epoch (``(0, 9)`` when fading is off), jerk (E, 3) the
        jerk input (m/s^3) of the step ending at each epoch, anomaly (E, 2) the epoch's
        stacked chi-square and its degrees of freedom (0, 0 without rows), knot (E,) bool:
        the anomaly test fired there (a new segment starts); the last three have no rows
        when the spline filter is off.
    """
    E = epoch_t.shape[0]
    N = meas_epoch.shape[0]
    n = x0.shape[0]
    xf = np.empty((E, n))
    Pf = np.empty((E, n * (n + 1) // 2))
    nis = np.full(N, np.nan)
    dof = np.zeros(N, dtype=np.int64)
    rejected = np.zeros(N, dtype=np.int64)
    ll_rows = np.zeros(N)
    x = x0.copy()
    P = P0.copy()
    (h, H, y6, y, idx, sel, sig, C, Z, Hs, yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv, L, Zs,
     xsig) = row_workspace(n)
    use_lin = x_lin.shape[0] == E and method == EKF
    adapt = adapt_window > 0
    G = (np.max(sensor) + 1 if N > 0 else 1) * N_COMPONENTS if adapt else 1
    sh_buf = np.zeros((G, max(adapt_window, 1), 2))
    sh_count = np.zeros(G, dtype=np.int64)
    sh_pos = np.zeros(G, dtype=np.int64)
    sh_acc = np.zeros((G, 2))
    sigma_used = np.full((N if adapt else 0, N_COMPONENTS), np.nan)
    sig_row = np.empty(N_COMPONENTS)
    Pu = np.empty(n)
    y_raw = np.empty(N_COMPONENTS)
    joseph = method == EKF
    fading = stf.shape[0] > 0
    spline = spl.shape[0] > 0
    if spline and (adapt or fading):
        raise ValueError("the spline filter combines with neither Sage-Husa nor fading")
    fade = np.ones((E if fading or spline else 0, N_KINEMATIC))
    v_stf = 0.0
    n_stf = 0
    G_stf = np.zeros((N_OBSERVED, N_OBSERVED))
    Hw = np.zeros((N_COMPONENTS, N_OBSERVED))
    St = np.empty((N_COMPONENTS, N_COMPONENTS))
    tcol = np.empty((N_COMPONENTS, 1))
    E_spl = E if spline else 0
    jerk_out = np.zeros((E_spl, 3))
    anomaly = np.zeros((E_spl, 2))
    knot = np.zeros(E_spl, dtype=np.bool_)
    jerk = np.zeros(3)
    G_spl = (np.max(sensor) + 1 if N > 0 else 1) * N_COMPONENTS if spline else 1
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
    consecutive = np.zeros(np.max(sensor) + 1 if N > 0 else 1, dtype=np.int64)
    n_resets = 0
    last_reset = -1
    i = 0
    for k in range(E):
        if k > 0:
            dt = epoch_t[k] - epoch_t[k - 1]
            predict_state(x, dt)
            predict_cov(P, AP, dt, q_steps[k])
            if spline:                                   # Zhou et al. 2001 eqs. 5/6: jerk input
                add_jerk(x, jerk, dt)
                for a in range(3):
                    jerk_out[k, a] = jerk[a]
            if fading and dt > 0.0 and i < N and meas_epoch[i] == k:
                e2, m_epoch, fixes = epoch_innovations(i, meas_epoch, model, z, sigma, s, sv,
                                                       Qr, x, P, gate, G_stf, h, H, y6, Hw,
                                                       St, tcol, b_spl)
                if m_epoch > 0:                          # strong tracking (estimation.fading)
                    v_row = e2 / m_epoch
                    v_stf = v_row if n_stf == 0 else (stf[STF_RHO] * v_stf + v_row) / (
                        1.0 + stf[STF_RHO])
                    n_stf += 1
                    if n_stf > STF_WARMUP and fixes and fading_factors(
                            stf, v_stf, m_epoch, G_stf, P, dt, q_steps[k], fade[k]):
                        apply_fading(P, fade[k], dt, q_steps[k])
        i_epoch = i
        if spline and i < N and meas_epoch[i] == k:   # Zhou et al. 2001 sec. 2.2: anomaly test
            chi, m_ep = epoch_chi2(i, meas_epoch, model, z, sigma, s, sv, Qr, x, P, gate,
                                   G_stf, L_spl, h, H, y6, Hw, St, tcol, b_spl)
            anomaly[k, 0] = chi
            anomaly[k, 1] = m_ep
            anomalous = (m_ep > 0 and n_meas_ep >= SPL_WARMUP and not seg_open
                         and n_meas_ep - last_knot >= SPL_MIN_SEGMENT
                         and chi > anomaly_threshold(spl, m_ep))
            if anomalous:                                # covariance opened (fading)
                knot[k] = True
                last_knot = n_meas_ep
                lam = anomaly_inflation(chi, m_ep, G_stf, P)
                for a in range(N_KINEMATIC):             # stored: the smoother runs it too
                    fade[k, a] = lam
                apply_fading(P, fade[k], dt, q_steps[k])
        while i < N and meas_epoch[i] == k:
            m = 0
            for c in range(N_COMPONENTS):
                if not math.isnan(z[i, c]) and sigma[i, c] > 0.0:
                    idx[m] = c
                    m += 1
            dof[i] = m
            if m == 0:
                i += 1
                continue
            ll_before = loglik
            row_moments(method, model[i], z[i], s[i], sv[i], Qr[i], x,
                        x_lin[k] if use_lin else x, use_lin, P, idx, m, ukf, L, Zs, xsig, h,
                        H, y6, y, C, Z, Hs)
            for a in range(m):
                sig_row[a] = sigma[i, idx[a]]
                y_raw[a] = y[a]
            if method == EKF:
                add_linearisation_noise(model[i], sig_row, idx, m, x, s[i], Qr[i], P)
            if adapt:
                sh_adapt(sensor[i], idx, m, sig_row, y, sh_count, sh_acc, adapt_window,
                         adapt_mean)
                for a in range(m):
                    sigma_used[i, idx[a]] = sig_row[a]
            if anomalous:                                # Zhou et al. 2001 2.3.1: adapted R
                for a in range(m):
                    g = sensor[i] * N_COMPONENTS + idx[a]
                    if rss_n[g] >= SPL_RMS_MIN:
                        rms = math.sqrt(rss[g] / (rss_n[g] - 1))
                        sig_row[a] = min(max(sig_row[a], rms), SPL_MAX_RATIO * sig_row[a])
            val, ok, n_acc, mask, ll_row = update_row(
                y, sig_row, C, Z, Hs, idx, m, x, P, gate, joseph, adapt or spline, sel, sig,
                yw, HP, S, Kt, AP, APHt, sdiag, ew, Sinv)
            nis[i] = val
            rejected[i] = mask
            loglik += ll_row
            if adapt and ok:                             # Sage-Husa window, accepted only
                for b in range(n_acc):
                    a = sel[b]
                    scale = sig_row[a] / sigma[i, idx[a]]
                    ratio = (ew[b] * ew[b] + 1.0 - Sinv[b, b]) * scale * scale
                    sh_record(sensor[i] * N_COMPONENTS + idx[a], ratio, y_raw[a], sh_buf,
                              sh_count, sh_pos, sh_acc, adapt_window)
            if spline and ok:                            # running residual RSS (2.3.1)
                for b in range(n_acc):
                    g = sensor[i] * N_COMPONENTS + idx[sel[b]]
                    r = ew[b] * sig[b]                   # post-update residual z - h(x_k)
                    rss[g] += r * r
                    rss_n[g] += 1
            if ok and (mask == 0 or val <= PARTIAL_DIVERGENCE * gate[m]):
                consecutive[sensor[i]] = 0
            else:                                        # a gross partial rejection counts:
                consecutive[sensor[i]] += 1              # the rest can hold a drifting track
                if reset_after > 0 and consecutive[sensor[i]] >= reset_after \
                        and last_reset != k:
                    reset_covariance(P, min(max(reset_inflation, 4.0 * val / gate[m]),
                                            MAX_RESET_INFLATION))
                    consecutive[:] = 0
                    n_resets += 1
                    last_reset = k
                    if adapt:                            # divergence: back to a-priori noise
                        sh_reset(sh_count, sh_pos, sh_acc)
            ll_rows[i] = loglik - ll_before
            i += 1
        if spline and i_epoch < i:                       # the epoch had rows
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
        if maneuver_norm > 0.0:
            norm_update(x, P, x_lin[k] if x_lin.shape[0] == E else x, maneuver_norm, Pu)
        for a in range(n):
            if not math.isfinite(x[a]):
                raise FloatingPointError("non-finite state in the Kalman filter")
        xf[k] = x
        pack(P, Pf[k])
    return (xf, Pf, nis, dof, rejected, loglik, n_resets, ll_rows, sigma_used, fade,
            jerk_out, anomaly, knot)
