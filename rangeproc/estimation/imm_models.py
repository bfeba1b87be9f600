"""The IMM's models and mixing (compiled helpers shared by the IMM filter, ``estimation.imm``,
and Kim's smoother, ``estimation.imm_smoother``): the model codes, each model's transition and
process noise over a step (``model_matrices``, with the coordinated turn's rate ``turn_rate``),
the step's model-switch matrix ``expm(Lam dt)`` (``switch_matrix``), the dense prediction and
the moment-matched mixture (``combine``). The models are described in ``estimation.imm``.

The IMM interaction (Blom and Bar-Shalom 1988) is defined here once, for every IMM of the
package: the predicted model probabilities ``c_j = sum_i pi_ij mu_i`` (floored at
:data:`MIN_PROBABILITY`), the mixing weights ``mu_i|j = pi_ij mu_i / c_j`` and each model's
mixed start, the moments ``x0_j = sum_i mu_i|j x_i``,
``P0_j = sum_i mu_i|j (P_i + (x_i - x0_j)(x_i - x0_j)^T)``. :func:`mix` is the compiled form
(the fusion's IMM, one track), :func:`mix_moments` the same expressions in the same order over
numpy arrays of many tracks (the plot tracker, ``tracking.plot_tracker``), so both give the
same bits. :func:`uniform_switch_matrix` is ``switch_matrix``'s closed form for the chain in
which every switch is alike (the plot tracker's).
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
#: Floor of a predicted model probability ``c_j`` (its log and the division by it stay finite).
MIN_PROBABILITY = 1e-300


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


@njit(cache=True, error_model="numpy", inline="always")
def _t_row(F: np.ndarray, P: np.ndarray, T: np.ndarray, i: int, cnt: int, l0: int, l1: int,
           l2: int) -> None:
    """``T[i] = sum_l F[i, l] P[l]`` over the ``cnt`` (1 to 3) columns ``l0 < l1 < l2`` of
    row ``i`` of F that can be non-zero, from 0.0 in ascending order (nine columns)."""
    f0 = F[i, l0]
    f1 = F[i, l1]
    f2 = F[i, l2]
    for j in range(9):
        acc = 0.0
        acc += f0 * P[l0, j]
        if cnt > 1:
            acc += f1 * P[l1, j]
        if cnt > 2:
            acc += f2 * P[l2, j]
        T[i, j] = acc


@njit(cache=True, error_model="numpy", inline="always")
def _p_col(F: np.ndarray, Q: np.ndarray, T: np.ndarray, P_out: np.ndarray, j: int, cnt: int,
           l0: int, l1: int, l2: int) -> None:
    """``P_out[i, j] = Q[i, j] + sum_l T[i, l] F[j, l]``, ``i >= j``, over the ``cnt``
    columns ``l0 < l1 < l2`` of row ``j`` of F that can be non-zero, in ascending order."""
    f0 = F[j, l0]
    f1 = F[j, l1]
    f2 = F[j, l2]
    for i in range(j, 9):
        acc = Q[i, j]
        acc += T[i, l0] * f0
        if cnt > 1:
            acc += T[i, l1] * f1
        if cnt > 2:
            acc += T[i, l2] * f2
        P_out[i, j] = acc


@njit(cache=True, error_model="numpy", inline="always")
def structured_covariance(code: int, F: np.ndarray, Q: np.ndarray, P_in: np.ndarray,
                          T: np.ndarray, P_out: np.ndarray) -> None:
    """:func:`sparse_covariance` of a model's nine-state ``F`` (:func:`model_matrices` of
    ``code``): the same sums, with the entries of F that can be non-zero known here instead
    of found by testing every entry. Each axis of CV and CA, and CT's vertical axis, is
    ``F1 = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]`` or a part of it (CV: the acceleration
    reset, zero entries); CT's horizontal rows read the two horizontal velocities. An entry
    that is zero (CV's, or CT's at a zero turn rate) adds ``0 * p`` to a sum that is never
    -0, which changes no bit (``P_in`` finite), so the result is :func:`sparse_covariance`'s
    bit for bit (``tests/estimation/test_imm_structured.py``)."""
    if code == CT:
        _t_row(F, P_in, T, 0, 3, 0, 3, 4)
        _t_row(F, P_in, T, 1, 3, 1, 3, 4)
        _t_row(F, P_in, T, 2, 3, 2, 5, 8)
        _t_row(F, P_in, T, 3, 2, 3, 4, 4)
        _t_row(F, P_in, T, 4, 2, 3, 4, 4)
        _t_row(F, P_in, T, 5, 2, 5, 8, 8)
        _t_row(F, P_in, T, 6, 2, 3, 4, 4)
        _t_row(F, P_in, T, 7, 2, 3, 4, 4)
        _t_row(F, P_in, T, 8, 1, 8, 8, 8)
        _p_col(F, Q, T, P_out, 0, 3, 0, 3, 4)
        _p_col(F, Q, T, P_out, 1, 3, 1, 3, 4)
        _p_col(F, Q, T, P_out, 2, 3, 2, 5, 8)
        _p_col(F, Q, T, P_out, 3, 2, 3, 4, 4)
        _p_col(F, Q, T, P_out, 4, 2, 3, 4, 4)
        _p_col(F, Q, T, P_out, 5, 2, 5, 8, 8)
        _p_col(F, Q, T, P_out, 6, 2, 3, 4, 4)
        _p_col(F, Q, T, P_out, 7, 2, 3, 4, 4)
        _p_col(F, Q, T, P_out, 8, 1, 8, 8, 8)
    else:                                                  # CV, CA: per axis
        for a in range(3):
            _t_row(F, P_in, T, a, 3, a, 3 + a, 6 + a)
            _t_row(F, P_in, T, 3 + a, 2, 3 + a, 6 + a, 6 + a)
            _t_row(F, P_in, T, 6 + a, 1, 6 + a, 6 + a, 6 + a)
        for a in range(3):
            _p_col(F, Q, T, P_out, a, 3, a, 3 + a, 6 + a)
            _p_col(F, Q, T, P_out, 3 + a, 2, 3 + a, 6 + a, 6 + a)
            _p_col(F, Q, T, P_out, 6 + a, 1, 6 + a, 6 + a, 6 + a)
    for i in range(9):
        for j in range(i):
            P_out[j, i] = P_out[i, j]


@njit(cache=True, error_model="numpy", inline="always")
def sparse_covariance(F: np.ndarray, Q: np.ndarray, P_in: np.ndarray, T: np.ndarray,
                      P_out: np.ndarray, n: int, code: int = -1) -> None:
    """``T <- F P_in``, then ``P_out <- T F^T + Q`` (``P_out`` may be ``P_in``; all (n, n)).

    ``F`` is sparse (at most three non-zeros a row): each product adds the terms of its
    non-zero entries only, in ascending order of the summed index, and runs its innermost
    loop over contiguous columns (a branch per entry of F, not per term). At nine states
    with the model's ``code`` given, :func:`structured_covariance` does the same sums
    without the tests (a third of the time). Inlined into the IMM's prediction and Kim's
    pair step, so both predict the same bits."""
    if n == 9 and code >= 0:
        structured_covariance(code, F, Q, P_in, T, P_out)
        return
    for i in range(n):                                     # T = F P_in
        for j in range(n):
            T[i, j] = 0.0
        for l in range(n):
            f = F[i, l]
            if f != 0.0:
                for j in range(n):
                    T[i, j] += f * P_in[l, j]
    for i in range(n):                                     # P_out = T F^T + Q (lower half)
        for j in range(i + 1):
            P_out[i, j] = Q[i, j]
    for j in range(n):
        for l in range(n):
            f = F[j, l]
            if f != 0.0:
                for i in range(j, n):
                    P_out[i, j] += T[i, l] * f
    for i in range(n):
        for j in range(i):
            P_out[j, i] = P_out[i, j]


@njit(cache=True, error_model="numpy", inline="always")
def dense_predict_n(F: np.ndarray, Q: np.ndarray, x: np.ndarray, P: np.ndarray,
                    xt: np.ndarray, T: np.ndarray, n: int, code: int = -1) -> None:
    """``x <- F x``, ``P <- F P F^T + Q`` (in place; ``xt`` (n,), ``T`` (n, n) work; the
    covariance by :func:`sparse_covariance`, structured at nine states when the model's
    ``code`` is given); ``n`` the state size, a compile-time constant in the inlining
    caller."""
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += F[i, j] * x[j]
        xt[i] = acc
    for i in range(n):
        x[i] = xt[i]
    sparse_covariance(F, Q, P, T, P, n, code)


@njit(cache=True, error_model="numpy")
def dense_predict(F: np.ndarray, Q: np.ndarray, x: np.ndarray, P: np.ndarray, xt: np.ndarray,
                  T: np.ndarray) -> None:
    """:func:`dense_predict_n` at the size of ``x`` (n,), called."""
    dense_predict_n(F, Q, x, P, xt, T, x.shape[0])


@njit(cache=True, error_model="numpy", inline="always")
def combine_n(X: np.ndarray, P: np.ndarray, w: np.ndarray, x: np.ndarray, out: np.ndarray,
              dx: np.ndarray, n: int) -> None:
    """Moment-matched mixture: ``x = sum w_j X_j``, ``out = sum w_j (P_j + dx dx^T)``
    (``X`` (r, n), ``P`` (r, n, n) symmetric, ``w`` (r,); ``x``, ``dx`` (n,), ``out``
    (n, n); ``n`` the state size, a compile-time constant in the inlining caller).

    Components of zero weight are skipped, not multiplied by 0: their X_j, P_j may be unset
    (a model the smoother pruned at this epoch), and 0 * NaN is NaN. The lower triangle is
    summed and mirrored: the upper one's terms are the same products of the same symmetric
    entries, so the mirror has the bits a full sum would give (half the arithmetic)."""
    r = X.shape[0]
    for a in range(n):
        acc = 0.0
        for j in range(r):
            if w[j] != 0.0:
                acc += w[j] * X[j, a]
        x[a] = acc
    for a in range(n):
        for b in range(a + 1):
            out[a, b] = 0.0
    for j in range(r):
        if w[j] == 0.0:
            continue
        wj = w[j]
        for a in range(n):
            dx[a] = X[j, a] - x[a]
        for a in range(n):
            for b in range(a + 1):
                out[a, b] += wj * (P[j, a, b] + dx[a] * dx[b])
    for a in range(n):
        for b in range(a):
            out[b, a] = out[a, b]


@njit(cache=True, error_model="numpy")
def combine(X: np.ndarray, P: np.ndarray, w: np.ndarray, x: np.ndarray, out: np.ndarray,
            dx: np.ndarray) -> None:
    """:func:`combine_n` at the size of ``X`` (r, n), called."""
    combine_n(X, P, w, x, out, dx, X.shape[1])


@njit(cache=True, nogil=True, error_model="numpy")
def predicted_probabilities(Pi: np.ndarray, mu: np.ndarray, c: np.ndarray) -> None:
    """``c_j = max(sum_i Pi[i, j] mu_i, MIN_PROBABILITY)`` into ``c`` (r,): the model
    probabilities ``mu`` (r,) carried over a step of switch matrix ``Pi`` (r, r)."""
    r = mu.shape[0]
    for j in range(r):
        acc = 0.0
        for a in range(r):
            acc += Pi[a, j] * mu[a]
        c[j] = max(acc, MIN_PROBABILITY)


@njit(cache=True, nogil=True, error_model="numpy")
def mix(Pi: np.ndarray, mu: np.ndarray, X: np.ndarray, P: np.ndarray, c: np.ndarray,
        w: np.ndarray, X0: np.ndarray, P0: np.ndarray, dx: np.ndarray) -> None:
    """The IMM interaction of one track (module docstring), into ``c`` (r,) the predicted
    model probabilities and ``X0`` (r, n), ``P0`` (r, n, n) the models' mixed starts, from
    the switch matrix ``Pi`` (r, r) (``Pi[i, j]`` = P(model j next | model i now)), the model
    probabilities ``mu`` (r,) and the models' states ``X`` (r, n), covariances ``P``
    (r, n, n); ``w`` (r,), ``dx`` (n,) work."""
    r = mu.shape[0]
    predicted_probabilities(Pi, mu, c)
    for j in range(r):                                     # mu_i|j, then the moments
        for a in range(r):
            w[a] = Pi[a, j] * mu[a] / c[j]
        combine(X, P, w, X0[j], P0[j], dx)


def mix_moments(Pi: np.ndarray, mu: np.ndarray, X: np.ndarray, P: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`mix` over the leading axes (...) of many tracks, in numpy: ``Pi`` (..., r, r),
    ``mu`` (..., r), ``X`` (..., r, n), ``P`` (..., r, n, n) -> the predicted model
    probabilities c (..., r) and the mixed starts X0 (..., r, n), P0 (..., r, n, n). The
    same expressions in the same order as :func:`mix` and :func:`combine` (a component of
    zero weight adds nothing), so a track gets the same bits from either."""
    r = mu.shape[-1]
    c = np.empty(mu.shape)
    for j in range(r):
        acc = np.zeros(mu.shape[:-1])
        for a in range(r):
            acc += Pi[..., a, j] * mu[..., a]
        c[..., j] = np.maximum(acc, MIN_PROBABILITY)
    X0 = np.zeros(X.shape)
    P0 = np.zeros(P.shape)
    for j in range(r):
        w = [Pi[..., a, j] * mu[..., a] / c[..., j] for a in range(r)]
        with np.errstate(invalid="ignore"):               # 0 * nan, then left out
            for a in range(r):
                wx = w[a][..., None] * X[..., a, :]
                X0[..., j, :] += np.where(w[a][..., None] != 0.0, wx, 0.0)
            for a in range(r):
                dx = X[..., a, :] - X0[..., j, :]
                term = w[a][..., None, None] * (P[..., a, :, :]
                                                + dx[..., :, None] * dx[..., None, :])
                P0[..., j, :, :] += np.where(w[a][..., None, None] != 0.0, term, 0.0)
    return c, X0, P0


def uniform_switch_matrix(dt: np.ndarray, r: int, sojourn: float) -> np.ndarray:
    """(..., r, r) model-switch matrices over steps ``dt`` (...) s (either sign) of the chain
    that stays in each model ``sojourn`` s on average and then goes to each other model alike
    (the generator ``fusion.passes.imm_generator`` makes): ``expm(Lam |dt|)``
    (:func:`switch_matrix`) in closed form, ``(1 - exp(-r |dt| / (sojourn (r - 1)))) / r``
    off the diagonal, the rest of each row on it."""
    other = (1.0 - np.exp(-r * np.abs(dt) / (sojourn * (r - 1)))) / r
    Pi = other[..., None, None] * np.ones((r, r))
    Pi[..., np.arange(r), np.arange(r)] = 1.0 - (r - 1) * other[..., None]
    return Pi
