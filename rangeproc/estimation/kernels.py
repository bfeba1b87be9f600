"""Allocation-free building blocks of the compiled recursions (numba).

They exploit the structure of the models instead of multiplying dense matrices:

* the CA transition is ``F = F1 (x) I3`` with the upper-triangular 3x3 block
  ``F1 = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]`` (state index = 3 * order + axis), so
  ``F P`` and ``P F^T`` cost 18 multiply-adds per column instead of 81; states beyond the
  ninth (biases) are constants that F leaves alone;
* the white-jerk noise and the per-axis step are those of ``models.motion``
  (``white_jerk_q``, ``ca_axis_step``), written once for every user;
* every measurement Jacobian is zero beyond the first six columns (position, velocity), so
  ``H P`` costs ``6 m n`` instead of ``n^2 m``.

All functions write into caller-provided work arrays.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from rangeproc.models.motion import ca_axis_step, white_jerk_q

#: Columns of the state that measurements can depend on (position and velocity).
N_OBSERVED = 6


@njit(cache=True, error_model="numpy")
def predict_state(x: np.ndarray, dt: float) -> None:
    """``x <- F x`` for the CA block (in place); extra states unchanged."""
    h2 = 0.5 * dt * dt
    for a in range(3):
        x[a] += dt * x[3 + a] + h2 * x[6 + a]
        x[3 + a] += dt * x[6 + a]


@njit(cache=True, error_model="numpy")
def add_q(P: np.ndarray, dt: float, q: float) -> None:
    """``P <- P + Q(dt, q)`` for the CA block (``models.motion.white_jerk_q``). A backward
    step (``dt`` < 0: carrying a state back in time) adds ``D Q(|dt|) D``, ``D`` flipping
    the sign of the velocity rows and columns: the covariance of ``F(dt)`` times the noise
    of the forward step ``|dt|``; forward steps are unchanged by the sign (a product by 1)."""
    sg = -1.0 if dt < 0.0 else 1.0
    q00, q01, q02, q11, q12, q22 = white_jerk_q(abs(dt), q)
    q01 = q01 * sg
    q12 = q12 * sg
    for a in range(3):
        P[a, a] += q00
        P[a, 3 + a] += q01
        P[3 + a, a] += q01
        P[a, 6 + a] += q02
        P[6 + a, a] += q02
        P[3 + a, 3 + a] += q11
        P[3 + a, 6 + a] += q12
        P[6 + a, 3 + a] += q12
        P[6 + a, 6 + a] += q22


def specialise_predict(n_fixed: int, inline: str) -> tuple:
    """``(left_f, right_f_t, left_f_t, predict_cov, predict_epoch)`` compiled with the state
    size ``n_fixed`` a compile-time constant (0: read from the arrays) and inlined into their
    callers (``inline = "always"``) or called (``"never"``): the general kernels below and
    the fixed-size ones of the forward loops (``estimation.forward_loop``,
    ``estimation.imm``) are this one source; a fixed size lets the compiler unroll the
    loops, and inlining spares the reference counting of every array argument of a call."""
    N_FIXED = n_fixed
    state = _inlined(predict_state) if inline == "always" else predict_state
    q_add = _inlined(add_q) if inline == "always" else add_q

    @njit(cache=True, error_model="numpy", inline=inline)
    def left_f(P: np.ndarray, out: np.ndarray, dt: float) -> None:
        """``out <- F P`` (n, n) using the Kronecker structure of F (``models.motion
        .ca_axis_step`` on each axis of each column)."""
        n = N_FIXED if N_FIXED > 0 else P.shape[0]
        h2 = 0.5 * dt * dt
        for j in range(n):
            for a in range(3):
                out[a, j], out[3 + a, j], out[6 + a, j] = ca_axis_step(P[a, j], P[3 + a, j],
                                                                       P[6 + a, j], dt, h2)
            for i in range(9, n):
                out[i, j] = P[i, j]

    @njit(cache=True, error_model="numpy", inline=inline)
    def right_f_t(B: np.ndarray, out: np.ndarray, dt: float) -> None:
        """``out <- B F^T`` (n, n) using the Kronecker structure of F (each row's axes by
        ``models.motion.ca_axis_step``); ``out`` may be ``B`` itself."""
        n = N_FIXED if N_FIXED > 0 else B.shape[0]
        h2 = 0.5 * dt * dt
        for i in range(n):
            for a in range(3):
                out[i, a], out[i, 3 + a], out[i, 6 + a] = ca_axis_step(B[i, a], B[i, 3 + a],
                                                                       B[i, 6 + a], dt, h2)
            for j in range(9, n):
                out[i, j] = B[i, j]

    @njit(cache=True, error_model="numpy", inline=inline)
    def left_f_t(B: np.ndarray, out: np.ndarray, dt: float) -> None:
        """``out <- F^T B`` (n, n) using the Kronecker structure of F (F^T is lower triangular)."""
        n = N_FIXED if N_FIXED > 0 else B.shape[0]
        h2 = 0.5 * dt * dt
        for j in range(n):
            for a in range(3):
                b0 = B[a, j]
                b1 = B[3 + a, j]
                b2 = B[6 + a, j]
                out[a, j] = b0
                out[3 + a, j] = dt * b0 + b1
                out[6 + a, j] = h2 * b0 + dt * b1 + b2
            for i in range(9, n):
                out[i, j] = B[i, j]

    @njit(cache=True, error_model="numpy", inline=inline)
    def predict_cov(P: np.ndarray, FP: np.ndarray, dt: float, q: float) -> None:
        """``P <- F P F^T + Q`` in place (symmetric result); ``FP`` (n, n) work, left = F P.

        Q is ``q Q1(dt) (x) I3`` with the white-jerk block Q1 (``models.motion.white_jerk_q``).
        """
        n = N_FIXED if N_FIXED > 0 else P.shape[0]
        left_f(P, FP, dt)
        right_f_t(FP, P, dt)                            # P = (F P) F^T, column structure
        q_add(P, dt, q)
        for i in range(n):
            for j in range(i):
                v = 0.5 * (P[i, j] + P[j, i])
                P[i, j] = v
                P[j, i] = v

    @njit(cache=True, error_model="numpy", inline=inline)
    def predict_epoch(x: np.ndarray, P: np.ndarray, FP: np.ndarray, epoch_t: np.ndarray,
                      q_steps: np.ndarray, k: int) -> float:
        """Predict ``x``, ``P`` (in place) from epoch ``k - 1`` to epoch ``k`` with the step's
        white-jerk PSD ``q_steps[k]``; returns the step (s), 0 at ``k = 0`` (nothing to do)."""
        if k == 0:
            return 0.0
        dt = epoch_t[k] - epoch_t[k - 1]
        state(x, dt)
        predict_cov(P, FP, dt, q_steps[k])
        return dt

    return left_f, right_f_t, left_f_t, predict_cov, predict_epoch


def _inlined(fn: Callable) -> Callable:
    """``fn`` (a compiled kernel) compiled again to be inlined into its callers."""
    return njit(error_model="numpy", inline="always")(fn.py_func)


#: The general kernels: any state size, called.
left_f, right_f_t, left_f_t, predict_cov, predict_epoch = specialise_predict(0, "never")
