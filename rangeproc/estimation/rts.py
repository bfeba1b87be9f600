"""Rauch-Tung-Striebel fixed-interval smoother over stored filter epochs (compiled).

Correct for a transition that varies step to step: the transition and process noise of the
step k -> k+1 are rebuilt from ``epoch_t[k+1] - epoch_t[k]`` and that step's white-jerk PSD
``q_steps[k+1]``, and the predicted covariance ``P_{k+1|k} = F_k P_{k|k} F_k^T + Q_k`` is
recomputed from the stored filtered covariance by the same arithmetic the filter used, so gain
and predicted moments always belong to the same step (FilterPy issue #278 pairs F_{k+1} with
step k). The smoothed covariance uses the Joseph-like symmetric form

    P_{k|N} = (I - C_k F_k) P_{k|k} (I - C_k F_k)^T + C_k (Q_k + P_{k+1|N}) C_k^T,

algebraically equal to the textbook ``P_{k|k} + C_k (P_{k+1|N} - P_{k+1|k}) C_k^T`` (with the
gain ``C_k = P_{k|k} F_k^T P_{k+1|k}^{-1}``) but a sum of positive semi-definite terms, so it
stays symmetric positive semi-definite by construction. The 9-state model without fading
(the EKF, UKF and Sage-Husa families) takes :func:`_rts_fixed` instead: the
textbook form, re-symmetrised, at a compile-time state size, with a third of the arithmetic;
a step where it would lose digits is handed to the symmetric form.

It also returns the EM statistic of the process noise (Shumway & Stoffer 1982): for each step
the expected squared acceleration increment given all data,
``E[(a_{k+1} - a_k)^2 | Z] = (da_s)^2 + P_{k+1|N} + P_{k|N} - 2 P_{k+1,k|N}`` averaged over the
three axes, with the lag-one covariance ``P_{k+1,k|N} = P_{k+1|N} C_k^T``. Under the
white-jerk model its expectation is ``q dt``, so windowed sums give a local q. (On a step the
strong-tracking filter faded, the fading's own share of the acceleration variance,
``Q_eff - q dt`` on the acceleration diagonal, is taken out: it is not white jerk.)
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rangeproc.estimation.fading import apply_fading
from rangeproc.estimation.kernels import add_q, left_f, left_f_t, predict_cov, predict_state
from rangeproc.estimation.linalg import (
    chol_solve_inplace,
    cholesky_inplace,
    pack,
    unpack,
    unpack_n,
)

from rangeproc.estimation.spline_filter import add_jerk
from rangeproc.models.motion import N_KINEMATIC, ca_axis_step, white_jerk_q

N = N_KINEMATIC
_cholesky = njit(nogil=True, error_model="numpy", inline="always")(cholesky_inplace.py_func)
_chol_solve = njit(nogil=True, error_model="numpy", inline="always")(chol_solve_inplace.py_func)


@njit(nogil=True, error_model="numpy", inline="always")
def _pack_mirrored(P: np.ndarray, out: np.ndarray) -> None:
    """:func:`linalg.pack` of an exactly symmetric (mirrored) ``P`` at the state size
    :data:`N`: its lower triangle as it is (``pack``'s ``0.5 * (p + p)`` is ``p``, bit for
    bit)."""
    k = 0
    for i in range(N):
        for j in range(i + 1):
            out[k] = P[i, j]
            k += 1


#: Relative diagonal loadings tried when a predicted covariance fails its Cholesky factorisation
#: to rounding (thousands of updates at one epoch can leave P_{k|k} a hair indefinite).
JITTER = (1e-12, 1e-10, 1e-8, 1e-6)
#: Largest ratio of a predicted to a smoothed variance at which a step is smoothed in the
#: textbook form (:func:`_rts_fixed`): beyond it the difference of the two costs more than
#: three digits, and the step takes the symmetric form.
TEXTBOOK_RATIO = 1e3


@njit(cache=True, nogil=True, error_model="numpy")
def _jittered_cholesky(P_pred: np.ndarray, P_f: np.ndarray, T: np.ndarray, dt: float,
                       q: float, lam: np.ndarray, faded: bool) -> bool:
    """Recompute ``P_pred = F P_f F^T + Q`` (faded by ``lam`` when ``faded``) and factor it
    with the smallest diagonal loading ``jitter * max(diag)`` of :data:`JITTER` that makes
    it positive definite (in place).

    The loading is a negligible extra process noise at that one step; False when even the
    largest fails (the covariance is then genuinely broken)."""
    n = P_f.shape[0]
    for jitter in JITTER:
        scale = 0.0
        for i in range(n):
            for j in range(n):
                P_pred[i, j] = P_f[i, j]
        predict_cov(P_pred, T, dt, q)
        if faded:
            apply_fading(P_pred, lam, dt, q)
        for i in range(n):
            scale = max(scale, abs(P_pred[i, i]))
        if not scale > 0.0:
            return False
        for i in range(n):
            P_pred[i, i] += jitter * scale
        if cholesky_inplace(P_pred, n):
            return True
    return False


@njit(cache=True, nogil=True, error_model="numpy")
def rts_smooth(epoch_t: np.ndarray, xf: np.ndarray, Pf: np.ndarray, q_steps: np.ndarray,
               want_em: bool = True, in_place: bool = False, fade=None, jerk=None):
    """Smooth filtered states.

    Args:
        epoch_t: (E,) epoch times (s); xf: (E, n) filtered states; Pf: (E, n(n+1)/2) packed
            filtered covariances; q_steps: (E,) white-jerk PSD (m^2/s^5) of the step ending at
            each epoch (``q_steps[0]`` unused), the same the filter used.
        want_em: compute the EM statistic (skipped when only the smoothed track is wanted).
        in_place: overwrite ``xf`` and ``Pf`` with the smoothed values instead of copying
            them (halves the stored history on long runs).
        fade: None, or (E, 9) the strong-tracking fading factors the filter applied to the
            prediction ending at each epoch (``estimation.fading``): the predicted covariance
            is then ``Lambda^(1/2) F P F^T Lambda^(1/2) + Q`` and the step's effective process
            noise ``P_pred - F P F^T`` replaces Q in the smoothed covariance (the smoother of
            the model the filter actually ran).
        jerk: None, or (E, 3) the known jerk input (m/s^3) the filter added to the prediction
            ending at each epoch (Zhou et al.'s spline filter, ``estimation.spline_filter``): the
            predicted state is then ``F x + B S`` and the EM statistic takes the input's
            acceleration increment ``S dt`` out (it is not white jerk).

    Returns:
        xs (E, n), Ps (E, n(n+1)/2) packed smoothed states and covariances, and
        em (E,) the EM acceleration-increment statistic of the step ending at each epoch
        (m^2/s^4, ``em[0] = 0``; all zero when ``want_em`` is False).
    """
    E, n = xf.shape
    if in_place:
        xs = xf
        Ps = Pf
    else:                         # written from the last epoch back; filtered values read
        xs = np.empty_like(xf)    # from xf, Pf (no copy of the history first)
        Ps = np.empty_like(Pf)
        if E > 0:                 # element loops: a row assignment compiles numba's
            for i in range(n):    # shape-mismatch message (str of ints, 4 s a first run)
                xs[E - 1, i] = xf[E - 1, i]
            for i in range(Pf.shape[1]):
                Ps[E - 1, i] = Pf[E - 1, i]
    em = np.zeros(E)
    P_f = np.empty((n, n))
    P_next = np.empty((n, n))
    P_pred = np.empty((n, n))
    FP = np.empty((n, n))
    Ct = np.empty((n, n))                              # C^T, then reused
    At = np.empty((n, n))
    T = np.empty((n, n))
    M = np.empty((n, n))
    Q_eff = np.empty((n, n))
    no_fade = np.ones(9)
    x_pred = np.empty(n)
    x_filt = np.empty(n)                             # filtered state at k
    dx = np.empty(n)
    fixed = n == N_KINEMATIC and fade is None         # the fixed-size textbook form
    unpack(Ps[E - 1], P_next)
    k = E - 2
    while k >= 0:
        if fixed:                                      # it returns the step it leaves
            k = _rts_fixed(epoch_t, xf, Pf, xs, Ps, q_steps, want_em, jerk, em, k)
            if k < 0:
                break
            unpack(Ps[k + 1], P_next)
        dt = epoch_t[k + 1] - epoch_t[k]
        q = q_steps[k + 1]
        unpack(Pf[k], P_f)                             # the filtered value at k
        for i in range(n):
            x_pred[i] = xf[k, i]
            x_filt[i] = xf[k, i]
            for j in range(n):
                P_pred[i, j] = P_f[i, j]
        predict_state(x_pred, dt)
        if jerk is not None:                           # + B S: the known jerk input
            add_jerk(x_pred, jerk[k + 1], dt)
        predict_cov(P_pred, T, dt, q)                  # P_pred = F P_f F^T + Q
        lam = no_fade
        faded = False
        if fade is not None:
            lam = fade[k + 1]
            for i in range(lam.shape[0]):
                faded = faded or lam[i] != 1.0
        if faded:                                      # Q_eff = P_pred - F P_f F^T
            for i in range(n):
                for j in range(n):
                    Q_eff[i, j] = -P_pred[i, j]
            apply_fading(P_pred, lam, dt, q)
            for i in range(n):
                for j in range(n):
                    Q_eff[i, j] += P_pred[i, j]
            add_q(Q_eff, dt, q)
        left_f(P_f, Ct, dt)                            # F P_f
        if not cholesky_inplace(P_pred, n) and not _jittered_cholesky(P_pred, P_f, T, dt, q,
                                                                      lam, faded):
            raise FloatingPointError("predicted covariance not positive definite in RTS")
        chol_solve_inplace(P_pred, n, Ct, n)           # C^T = P_pred^-1 F P_f (in place)
        for i in range(n):
            dx[i] = xs[k + 1, i] - x_pred[i]
        for i in range(n):                             # xs = xf + C (xs_next - x_pred)
            acc = x_filt[i]
            for j in range(n):
                acc += Ct[j, i] * dx[j]
            xs[k, i] = acc
        # A^T = I - F^T C^T (F^T applied through its structure)
        left_f_t(Ct, At, dt)
        for i in range(n):
            for j in range(n):
                At[i, j] = -At[i, j]
            At[i, i] += 1.0
        # P_s = A P_f A^T + C (Q + P_next) C^T   (symmetric positive semi-definite terms);
        # every product below runs its innermost loop over contiguous columns.
        for i in range(n):                             # M = A P_f
            for j in range(n):
                M[i, j] = 0.0
            for l in range(n):
                a = At[l, i]
                for j in range(n):
                    M[i, j] += a * P_f[l, j]
        for i in range(n):                             # T = P_next + Q
            for j in range(n):
                T[i, j] = P_next[i, j] + (Q_eff[i, j] if faded else 0.0)
        if not faded:
            add_q(T, dt, q)
        for i in range(n):                             # FP <- C (P_next + Q)
            for j in range(n):
                FP[i, j] = 0.0
            for l in range(n):
                c = Ct[l, i]
                for j in range(n):
                    FP[i, j] += c * T[l, j]
        for i in range(n):                             # P_s = M A^T + FP C^T (lower half)
            for j in range(i + 1):
                P_f[i, j] = 0.0
            for l in range(n):
                a = M[i, l]
                c = FP[i, l]
                for j in range(i + 1):
                    P_f[i, j] += a * At[l, j] + c * Ct[l, j]
        for i in range(n):
            for j in range(i):
                P_f[j, i] = P_f[i, j]
        pack(P_f, Ps[k])
        if want_em:                                    # EM statistic, lag-one covariance
            acc = 0.0                                  # P_{k+1,k|N} = P_next C^T
            for ax in range(6, 9):
                cross = 0.0
                for l in range(n):
                    cross += P_next[ax, l] * Ct[l, ax]
                d = xs[k + 1, ax] - xs[k, ax]
                if jerk is not None:                   # the known input's increment
                    d -= jerk[k + 1, ax - 6] * dt
                acc += d * d + P_next[ax, ax] + P_f[ax, ax] - 2.0 * cross
                if faded:                              # the fading's share is not white jerk
                    acc -= Q_eff[ax, ax] - q * dt
            em[k + 1] = max(acc, 0.0) / 3.0
        P_next, P_f = P_f, P_next                      # smoothed k becomes "next"
        k -= 1
    return xs, Ps, em



@njit(cache=True, nogil=True, error_model="numpy")
def _rts_fixed(epoch_t: np.ndarray, xf: np.ndarray, Pf: np.ndarray, xs: np.ndarray,
               Ps: np.ndarray, q_steps: np.ndarray, want_em: bool, jerk, em: np.ndarray,
               start: int) -> int:
    """:func:`rts_smooth`'s steps for the 9-state CA model without fading, with the state
    size a compile-time constant, in the textbook form (the filtered values read from ``xf``,
    ``Pf``, the smoothed ones written to ``xs``, ``Ps``, which may be the same arrays, and
    ``em``; module docstring):

        C_k^T = P_{k+1|k}^-1 F P_{k|k},   P_{k|N} = P_{k|k} + C_k (P_{k+1|N} - P_{k+1|k}) C_k^T

    with the lower triangle computed and mirrored (re-symmetrised), from step ``start`` (the
    smoothed values of ``start + 1`` in ``xs``, ``Ps``) down to 0. It stops at a step whose
    predicted covariance needs diagonal loading to factor, or whose smoothed variances are
    not above ``P_{k+1|k} / TEXTBOOK_RATIO`` (the difference ``P_{k+1|N} - P_{k+1|k}`` of
    two large covariances would cost digits the symmetric form keeps: a step just after the
    divergence guard re-opened the covariance): it returns that step's index, and
    :func:`rts_smooth` does the step in the symmetric form and hands back (-1: all done).
    """
    P_f = np.empty((N, N))
    P_next = np.empty((N, N))
    P_pred = np.empty((N, N))                          # factored in place: L
    D = np.empty((N, N))
    Ct = np.empty((N, N))
    M = np.empty((N, N))
    x_pred = np.empty(N)
    dx = np.empty(N)
    p_diag = np.empty(N)
    unpack_n(Ps[start + 1], P_next, N)
    for k in range(start, -1, -1):
        dt = epoch_t[k + 1] - epoch_t[k]
        q = q_steps[k + 1]
        h2 = 0.5 * dt * dt
        unpack_n(Pf[k], P_f, N)
        for i in range(N):
            x_pred[i] = xf[k, i]
        for a in range(3):                             # x_pred = F x_f (+ B S)
            x_pred[a] += dt * x_pred[3 + a] + h2 * x_pred[6 + a]
            x_pred[3 + a] += dt * x_pred[6 + a]
        if jerk is not None:
            add_jerk(x_pred, jerk[k + 1], dt)
        for j in range(N):                             # Ct <- F P_f (column structure)
            for a in range(3):
                Ct[a, j], Ct[3 + a, j], Ct[6 + a, j] = ca_axis_step(
                    P_f[a, j], P_f[3 + a, j], P_f[6 + a, j], dt, h2)
        for i in range(N):                             # P_pred = (F P_f) F^T + Q
            for a in range(3):
                P_pred[i, a], P_pred[i, 3 + a], P_pred[i, 6 + a] = ca_axis_step(
                    Ct[i, a], Ct[i, 3 + a], Ct[i, 6 + a], dt, h2)
        q00, q01, q02, q11, q12, q22 = white_jerk_q(dt, q)
        for a in range(3):
            P_pred[a, a] += q00
            P_pred[a, 3 + a] += q01
            P_pred[3 + a, a] += q01
            P_pred[a, 6 + a] += q02
            P_pred[6 + a, a] += q02
            P_pred[3 + a, 3 + a] += q11
            P_pred[3 + a, 6 + a] += q12
            P_pred[6 + a, 3 + a] += q12
            P_pred[6 + a, 6 + a] += q22
        for i in range(N):                             # symmetrised; D = P_next - P_pred
            for j in range(i):
                v = 0.5 * (P_pred[i, j] + P_pred[j, i])
                P_pred[i, j] = v
                P_pred[j, i] = v
        for i in range(N):
            p_diag[i] = P_pred[i, i]
            for j in range(N):
                D[i, j] = P_next[i, j] - P_pred[i, j]
        if not _cholesky(P_pred, N):
            return k                                   # loading needed: the general code
        _chol_solve(P_pred, N, Ct, N)                  # C^T = P_pred^-1 F P_f (in place)
        for i in range(N):
            dx[i] = xs[k + 1, i] - x_pred[i]
        for i in range(N):                             # xs = xf + C (xs_next - x_pred)
            acc = xf[k, i]
            for j in range(N):
                acc += Ct[j, i] * dx[j]
            x_pred[i] = acc
        for i in range(N):                             # M = (P_next - P_pred) C^T
            for j in range(N):
                M[i, j] = 0.0
            for l in range(N):
                d = D[i, l]
                for j in range(N):
                    M[i, j] += d * Ct[l, j]
        for i in range(N):                             # P_s = P_f + C M (lower half)
            for j in range(i + 1):
                acc = P_f[i, j]
                for l in range(N):
                    acc += Ct[l, i] * M[l, j]
                if j == i and not acc * TEXTBOOK_RATIO > p_diag[i]:
                    return k                           # digits lost: the symmetric form
                D[i, j] = acc
        for i in range(N):
            xs[k, i] = x_pred[i]
            for j in range(i):
                D[j, i] = D[i, j]
        _pack_mirrored(D, Ps[k])
        if want_em:                                    # EM statistic, lag-one covariance
            acc = 0.0                                  # P_{k+1,k|N} = P_next C^T
            for ax in range(6, 9):
                cross = 0.0
                for l in range(N):
                    cross += P_next[ax, l] * Ct[l, ax]
                d = xs[k + 1, ax] - xs[k, ax]
                if jerk is not None:                   # the known input's increment
                    d -= jerk[k + 1, ax - 6] * dt
                acc += d * d + P_next[ax, ax] + D[ax, ax] - 2.0 * cross
            em[k + 1] = max(acc, 0.0) / 3.0
        P_next, D = D, P_next                          # smoothed k becomes "next"
    return -1
