"""The IMM's models and mixing (compiled helpers shared by the IMM filter, ``estimation.imm``,
and Kim's smoother, ``estimation.imm_smoother``): the model codes, each model's transition and
process noise over a step (``model_matrices``, with the coordinated turn's rate ``turn_rate``),
the step's model-switch matrix ``expm(Lam dt)`` (``switch_matrix``), the dense prediction and
the moment-matched mixture (``combine``). The models are described in ``estimation.imm``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.models.motion import white_acceleration_q, white_jerk_q
from rangeproc.settings import IMM_MODELS

CV, CA, CT = 0, 1, 2
#: Names of the model codes (config ``imm_models`` and the fused.parquet columns ``p_<name>``).
MODEL_NAMES = IMM_MODELS
#: Largest turn rate (rad/s) the CT model uses (about 29 deg/s).
MAX_TURN_RATE = 0.5
#: Horizontal speed (m/s) below which the CT model does not turn.
MIN_TURN_SPEED = 1.0


@njit(cache=True, nogil=True, error_model="numpy")
def turn_rate(x: np.ndarray) -> float:
    """``omega = (v_e a_n - v_n a_e) / |v_h|^2`` (rad/s) of state ``x``, bounded."""
    ve, vn, ae, an = x[3], x[4], x[6], x[7]
    v2 = ve * ve + vn * vn
    if v2 < MIN_TURN_SPEED * MIN_TURN_SPEED:
        return 0.0
    w = (ve * an - vn * ae) / v2
    return min(max(w, -MAX_TURN_RATE), MAX_TURN_RATE)


@njit(cache=True, nogil=True, error_model="numpy")
def model_matrices(code: int, dt: float, q: float, omega: float, F: np.ndarray,
                   Q: np.ndarray) -> None:
    """Transition ``F`` (n, n) and process noise ``Q`` (n, n) of one model over ``dt`` (s).

    States beyond the ninth are constants (F = I, no noise). ``q``: white-jerk PSD (m^2/s^5);
    ``omega``: the CT turn rate (rad/s), ignored by the others.
    """
    n = F.shape[0]
    F[:, :] = 0.0
    Q[:, :] = 0.0
    for i in range(n):
        F[i, i] = 1.0
    dt2 = dt * dt
    qa = q * 1.0                                          # white-acceleration PSD, m^2/s^3
    for ax in range(3):
        p, v, a = ax, 3 + ax, 6 + ax
        ca_axis = code == CA or (code == CT and ax == 2)
        if ca_axis:                                        # white jerk
            F[p, v] = dt
            F[p, a] = 0.5 * dt2
            F[v, a] = dt
            Q[p, p], Q[p, v], Q[p, a], Q[v, v], Q[v, a], Q[a, a] = white_jerk_q(dt, q)
            Q[v, p] = Q[p, v]
            Q[a, p] = Q[p, a]
            Q[a, v] = Q[v, a]
        else:                                              # white acceleration, a reset
            Q[p, p], Q[p, v], Q[v, v] = white_acceleration_q(dt, qa)
            Q[v, p] = Q[p, v]
            Q[a, a] = Q[v, v]
            F[a, a] = 0.0
            if code == CV:
                F[p, v] = dt
    if code == CT:                                         # horizontal coordinated turn
        w = omega
        s = math.sin(w * dt)
        c = math.cos(w * dt)
        if abs(w) > 1e-9:
            sw = s / w
            cw = (1.0 - c) / w
        else:
            sw = dt
            cw = 0.5 * w * dt2
        F[0, 3], F[0, 4] = sw, -cw                         # p_h += (s/w) v - ((1-c)/w) J' v
        F[1, 3], F[1, 4] = cw, sw
        F[3, 3], F[3, 4] = c, -s                           # v_h rotated by w dt
        F[4, 3], F[4, 4] = s, c
        F[6, 3], F[6, 4] = -w * s, -w * c                  # a_h = w J v_h (centripetal)
        F[7, 3], F[7, 4] = w * c, -w * s


@njit(cache=True, nogil=True, error_model="numpy")
def switch_matrix(Lam: np.ndarray, dt: float, out: np.ndarray, work: np.ndarray) -> None:
    """``out = expm(Lam dt)`` (r, r) by scaling and squaring a 12-term Taylor series; rows are
    renormalised to sum to one (a stochastic matrix up to rounding). ``work`` (2, r, r)."""
    r = Lam.shape[0]
    norm = 0.0
    for i in range(r):
        acc = 0.0
        for j in range(r):
            acc += abs(Lam[i, j]) * dt
        norm = max(norm, acc)
    sq = 0
    while norm > 0.5:
        norm *= 0.5
        sq += 1
    scale = dt / (2.0 ** sq)
    term = work[0]
    tmp = work[1]
    for i in range(r):
        for j in range(r):
            term[i, j] = 1.0 if i == j else 0.0
            out[i, j] = term[i, j]
    for k in range(1, 13):                                 # out = sum (A^k / k!)
        for i in range(r):
            for j in range(r):
                acc = 0.0
                for l in range(r):
                    acc += term[i, l] * Lam[l, j] * scale
                tmp[i, j] = acc / k
        for i in range(r):
            for j in range(r):
                term[i, j] = tmp[i, j]
                out[i, j] += term[i, j]
    for _ in range(sq):
        for i in range(r):
            for j in range(r):
                acc = 0.0
                for l in range(r):
                    acc += out[i, l] * out[l, j]
                tmp[i, j] = acc
        for i in range(r):
            for j in range(r):
                out[i, j] = tmp[i, j]
    for i in range(r):
        acc = 0.0
        for j in range(r):
            out[i, j] = max(out[i, j], 0.0)
            acc += out[i, j]
        for j in range(r):
            out[i, j] /= acc


@njit(cache=True, error_model="numpy")
def dense_predict(F: np.ndarray, Q: np.ndarray, x: np.ndarray, P: np.ndarray, xt: np.ndarray,
             T: np.ndarray) -> None:
    """``x <- F x``, ``P <- F P F^T + Q`` (dense, in place; ``xt`` (n,), ``T`` (n, n) work)."""
    n = x.shape[0]
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += F[i, j] * x[j]
        xt[i] = acc
    for i in range(n):
        x[i] = xt[i]
    for i in range(n):                                     # T = F P
        for j in range(n):
            acc = 0.0
            for l in range(n):
                if F[i, l] != 0.0:
                    acc += F[i, l] * P[l, j]
            T[i, j] = acc
    for i in range(n):                                     # P = T F^T + Q
        for j in range(i + 1):
            acc = Q[i, j]
            for l in range(n):
                if F[j, l] != 0.0:
                    acc += T[i, l] * F[j, l]
            P[i, j] = acc
            P[j, i] = acc


@njit(cache=True, error_model="numpy")
def combine(X: np.ndarray, P: np.ndarray, w: np.ndarray, x: np.ndarray, out: np.ndarray,
             dx: np.ndarray) -> None:
    """Moment-matched mixture: ``x = sum w_j X_j``, ``out = sum w_j (P_j + dx dx^T)``.

    Components of zero weight are skipped, not multiplied by 0: their X_j, P_j may be unset
    (a model the smoother pruned at this epoch), and 0 * NaN is NaN."""
    r, n = X.shape
    for a in range(n):
        acc = 0.0
        for j in range(r):
            if w[j] != 0.0:
                acc += w[j] * X[j, a]
        x[a] = acc
    for a in range(n):
        for b in range(n):
            out[a, b] = 0.0
    for j in range(r):
        if w[j] == 0.0:
            continue
        for a in range(n):
            dx[a] = X[j, a] - x[a]
        for a in range(n):
            for b in range(n):
                out[a, b] += w[j] * (P[j, a, b] + dx[a] * dx[b])
