"""Extended Kalman filter over a time-ordered batch of measurement rows (compiled).

One forward pass of seed 003 sec. 3.1: prediction (eq. 6-7), gain (eq. 8), Joseph-form
covariance update (eq. 9), state update (eq. 10), and innovation chi-square gating: a row
whose normalised innovation squared exceeds the gate is not used and the filter carries the
prediction (seed 003: "an abnormal measurement is replaced by the prediction"; the chi-square
test itself is seed 000 sec. 2.2). Gating is per component when it can be: if a row fails,
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

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import N_OBSERVED, predict_cov, predict_state
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace, pack
from rangeproc.models.measurement import N_COMPONENTS, innovation, measure
from rangeproc.models.motion import N_KINEMATIC

LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True, error_model="numpy")
def _gated_update(y: np.ndarray, sigma: np.ndarray, H: np.ndarray, idx: np.ndarray, m: int,
                  x: np.ndarray, P: np.ndarray, gate: np.ndarray, apply: bool,
                  yw: np.ndarray, Hw: np.ndarray, HP: np.ndarray, S: np.ndarray,
                  Kt: np.ndarray, AP: np.ndarray, APHt: np.ndarray, sdiag: np.ndarray):
    """Whiten the components ``idx[:m]``, gate them jointly and, if ``apply`` and they pass,
    update ``x``, ``P`` in place. Returns ``(nis, passed, logdet_S)``; ``sdiag[:m]`` receives
    the marginal whitened innovation variances (for per-component tests)."""
    n = x.shape[0]
    for a in range(m):
        i = idx[a]
        inv = 1.0 / sigma[i]
        yw[a] = y[i] * inv
        for c in range(N_OBSERVED):
            Hw[a, c] = H[i, c] * inv
    for a in range(m):                                   # HP = Hw P (m, n), Hw sparse
        for j in range(n):
            acc = 0.0
            for c in range(N_OBSERVED):
                acc += Hw[a, c] * P[c, j]
            HP[a, j] = acc
    for a in range(m):                                   # S = Hw P Hw^T + I
        for b in range(a + 1):
            acc = 0.0
            for c in range(N_OBSERVED):
                acc += HP[a, c] * Hw[b, c]
            S[a, b] = acc
            S[b, a] = acc
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
    if nis > gate[m] or not apply:
        return nis, nis <= gate[m], logdet
    for a in range(m):                                   # K^T = S^-1 (H P): gain, eq. 8
        for j in range(n):
            Kt[a, j] = HP[a, j]
    chol_solve_inplace(S, m, Kt, n)
    for j in range(n):                                   # x += K yw, eq. 10
        acc = 0.0
        for a in range(m):
            acc += Kt[a, j] * yw[a]
        x[j] += acc
    for i in range(n):                                   # Joseph form, eq. 9: A P = P - K H P
        for j in range(n):
            AP[i, j] = P[i, j]
        for a in range(m):
            kai = Kt[a, i]
            for j in range(n):
                AP[i, j] -= kai * HP[a, j]
    for i in range(n):                                   # (A P) H^T
        for a in range(m):
            acc = 0.0
            for c in range(N_OBSERVED):
                acc += AP[i, c] * Hw[a, c]
            APHt[i, a] = acc
    for i in range(n):                                   # A P A^T + K K^T (R = I)
        for j in range(n):
            P[i, j] = AP[i, j]
        for a in range(m):
            u = Kt[a, i] - APHt[i, a]
            for j in range(n):
                P[i, j] += u * Kt[a, j]
    for i in range(n):
        for j in range(i):
            v = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = v
            P[j, i] = v
    return nis, True, logdet


@njit(cache=True, error_model="numpy")
def ekf_forward(epoch_t: np.ndarray, meas_epoch: np.ndarray, model: np.ndarray,
                z: np.ndarray, sigma: np.ndarray, s: np.ndarray, sv: np.ndarray,
                Qr: np.ndarray, sensor: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                q_steps: np.ndarray, gate: np.ndarray, reset_after: int,
                reset_inflation: float, x_lin: np.ndarray):
    """Run the EKF over all epochs.

    Args:
        epoch_t: (E,) ascending distinct epoch times (s); the prior ``x0, P0`` is at epoch_t[0].
        meas_epoch: (N,) epoch index of each row (non-decreasing).
        model: (N,) measurement model code per row; z, sigma: (N, 6) values / 1-sigma (NaN in z
            = not measured); s, sv: (N, 3) sensor position / velocity in range ENU; Qr: (N,3,3);
            sensor: (N,) int64 sensor index of each row (>= 0).
        x0: (n,), P0: (n, n) prior. q_steps: (E,) white-jerk PSD (m^2/s^5) of the step
            ending at each epoch (index 0 unused). gate: (7,) chi-square thresholds by degrees
            of freedom (inf disables gating).
        reset_after: divergence guard. When one sensor has this many consecutive rejected
            rows (other sensors' rows may be accepted in between: an angle-only sensor can keep
            "agreeing" with a track that drifted along its line of sight), the kinematic
            covariance is multiplied by ``max(reset_inflation, 4 nis / gate)`` so the track
            re-acquires instead of rejecting that sensor for ever. 0 disables.
        x_lin: (E, n) linearisation states per epoch (the previous smoothed trajectory: one
            Gauss-Newton step of the iterated extended Kalman smoother), or an array with zero
            rows to linearise at the prediction as the plain EKF does.

    Returns:
        xf (E, n) filtered states, Pf (E, n(n+1)/2) packed filtered covariances,
        nis (N,) row innovation chi-square, dof (N,) int64 measured components,
        rejected (N,) int64 bit mask of the components the gate rejected (bit c = component
        c), loglik (Gaussian log-likelihood of the whitened innovations, rejected rows counted
        at the gate), n_resets (int).
    """
    E = epoch_t.shape[0]
    N = meas_epoch.shape[0]
    n = x0.shape[0]
    xf = np.empty((E, n))
    Pf = np.empty((E, n * (n + 1) // 2))
    nis = np.full(N, np.nan)
    dof = np.zeros(N, dtype=np.int64)
    rejected = np.zeros(N, dtype=np.int64)
    x = x0.copy()
    P = P0.copy()
    h = np.empty(N_COMPONENTS)
    H = np.zeros((N_COMPONENTS, n))
    y = np.empty(N_COMPONENTS)
    idx = np.empty(N_COMPONENTS, dtype=np.int64)
    keep = np.empty(N_COMPONENTS, dtype=np.int64)
    yw = np.empty(N_COMPONENTS)
    Hw = np.zeros((N_COMPONENTS, N_OBSERVED))
    HP = np.empty((N_COMPONENTS, n))
    S = np.empty((N_COMPONENTS, N_COMPONENTS))
    Kt = np.empty((N_COMPONENTS, n))
    AP = np.empty((n, n))
    APHt = np.empty((n, N_COMPONENTS))
    sdiag = np.empty(N_COMPONENTS)
    use_lin = x_lin.shape[0] == E
    loglik = 0.0
    consecutive = np.zeros(np.max(sensor) + 1 if N > 0 else 1, dtype=np.int64)
    n_resets = 0
    i = 0
    for k in range(E):
        if k > 0:
            dt = epoch_t[k] - epoch_t[k - 1]
            predict_state(x, dt)
            predict_cov(P, AP, dt, q_steps[k])
        while i < N and meas_epoch[i] == k:
            if use_lin:                                  # h(x) ~ h(xl) + H(xl) (x - xl)
                measure(model[i], x_lin[k], s[i], sv[i], Qr[i], h, H)
                for c in range(N_COMPONENTS):
                    acc = 0.0
                    for j in range(N_OBSERVED):
                        acc += H[c, j] * (x[j] - x_lin[k, j])
                    h[c] += acc
            else:
                measure(model[i], x, s[i], sv[i], Qr[i], h, H)
            innovation(model[i], z[i], h, y)
            m = 0
            for c in range(N_COMPONENTS):
                if not math.isnan(y[c]) and sigma[i, c] > 0.0:
                    idx[m] = c
                    m += 1
            dof[i] = m
            if m == 0:
                i += 1
                continue
            val, ok, logdet = _gated_update(y, sigma[i], H, idx, m, x, P, gate, True,
                                            yw, Hw, HP, S, Kt, AP, APHt, sdiag)
            nis[i] = val
            mask = 0
            if not ok and m > 1 and math.isfinite(val):
                # drop components failing their own marginal test, gate the rest again
                mk = 0
                for a in range(m):
                    if yw[a] * yw[a] / sdiag[a] <= gate[1]:
                        keep[mk] = idx[a]
                        mk += 1
                    else:
                        mask |= 1 << idx[a]
                if 0 < mk < m:
                    val2, ok2, logdet2 = _gated_update(y, sigma[i], H, keep, mk, x, P, gate,
                                                       True, yw, Hw, HP, S, Kt, AP, APHt,
                                                       sdiag)
                    if ok2:
                        ok = True
                        loglik -= 0.5 * (val2 + logdet2 + mk * LOG_2PI + (m - mk) * gate[1])
                if not ok:
                    mask = 0
            if ok and mask == 0:
                loglik -= 0.5 * (val + logdet + m * LOG_2PI)
            if ok:
                consecutive[sensor[i]] = 0
                rejected[i] = mask
            else:
                for a in range(m):
                    mask |= 1 << idx[a]
                rejected[i] = mask
                consecutive[sensor[i]] += 1
                loglik -= 0.5 * (min(val, gate[m]) + logdet + m * LOG_2PI)
                if reset_after > 0 and consecutive[sensor[i]] >= reset_after:
                    factor = max(reset_inflation, 4.0 * val / gate[m])
                    for a in range(min(n, N_KINEMATIC)):
                        for b in range(min(n, N_KINEMATIC)):
                            P[a, b] *= factor
                    consecutive[:] = 0
                    n_resets += 1
            i += 1
        for a in range(n):
            if not math.isfinite(x[a]):
                raise FloatingPointError("non-finite state in EKF")
        xf[k] = x
        pack(P, Pf[k])
    return xf, Pf, nis, dof, rejected, loglik, n_resets
