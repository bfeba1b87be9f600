"""Allocation-free building blocks of the compiled recursions (numba).

They exploit the structure of the models instead of multiplying dense matrices:

* the CA transition is ``F = F1 (x) I3`` with the upper-triangular 3x3 block
  ``F1 = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]`` (state index = 3 * order + axis), so
  ``F P`` and ``P F^T`` cost 18 multiply-adds per column instead of 81; states beyond the
  ninth (biases) are constants that F leaves alone;
* every measurement Jacobian is zero beyond the first six columns (position, velocity), so
  ``H P`` costs ``6 m n`` instead of ``n^2 m``.

All functions write into caller-provided work arrays.
"""
from __future__ import annotations

import numpy as np
from numba import njit

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
def left_f(P: np.ndarray, out: np.ndarray, dt: float) -> None:
    """``out <- F P`` (n, n) using the Kronecker structure of F."""
    n = P.shape[0]
    h2 = 0.5 * dt * dt
    for j in range(n):
        for a in range(3):
            p0 = P[a, j]
            p1 = P[3 + a, j]
            p2 = P[6 + a, j]
            out[a, j] = p0 + dt * p1 + h2 * p2
            out[3 + a, j] = p1 + dt * p2
            out[6 + a, j] = p2
        for i in range(9, n):
            out[i, j] = P[i, j]


@njit(cache=True, error_model="numpy")
def left_f_t(B: np.ndarray, out: np.ndarray, dt: float) -> None:
    """``out <- F^T B`` (n, n) using the Kronecker structure of F (F^T is lower triangular)."""
    n = B.shape[0]
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


@njit(cache=True, error_model="numpy")
def predict_cov(P: np.ndarray, FP: np.ndarray, dt: float, q: float) -> None:
    """``P <- F P F^T + Q`` in place (symmetric result); ``FP`` (n, n) work, left = F P.

    Q is ``q Q1(dt) (x) I3`` with the white-jerk block Q1 (see ``models.motion``).
    """
    n = P.shape[0]
    left_f(P, FP, dt)
    h2 = 0.5 * dt * dt
    for i in range(n):                              # P = (F P) F^T, column structure
        for a in range(3):
            p0 = FP[i, a]
            p1 = FP[i, 3 + a]
            p2 = FP[i, 6 + a]
            P[i, a] = p0 + dt * p1 + h2 * p2
            P[i, 3 + a] = p1 + dt * p2
            P[i, 6 + a] = p2
        for j in range(9, n):
            P[i, j] = FP[i, j]
    add_q(P, dt, q)
    for i in range(n):
        for j in range(i):
            v = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = v
            P[j, i] = v


@njit(cache=True, error_model="numpy")
def add_q(P: np.ndarray, dt: float, q: float) -> None:
    """``P <- P + Q(dt, q)`` for the CA block."""
    dt2 = dt * dt
    dt3 = dt2 * dt
    q00 = q * dt3 * dt2 / 20.0
    q01 = q * dt2 * dt2 / 8.0
    q02 = q * dt3 / 6.0
    q11 = q * dt3 / 3.0
    q12 = q * dt2 / 2.0
    q22 = q * dt
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


@njit(cache=True, error_model="numpy")
def predict_epoch(x: np.ndarray, P: np.ndarray, FP: np.ndarray, epoch_t: np.ndarray,
                  q_steps: np.ndarray, k: int) -> float:
    """Predict ``x``, ``P`` (in place) from epoch ``k - 1`` to epoch ``k`` with the step's
    white-jerk PSD ``q_steps[k]``; returns the step (s), 0 at ``k = 0`` (nothing to do)."""
    if k == 0:
        return 0.0
    dt = epoch_t[k] - epoch_t[k - 1]
    predict_state(x, dt)
    predict_cov(P, FP, dt, q_steps[k])
    return dt

