"""Motion models: discrete transition and process noise over the state vector.

The kinematic state is the 9-state constant-acceleration (CA) model of He 2015 eq. (1):
``x = [e, n, u, ve, vn, vu, ae, an, au]`` in the range ENU frame (m, m/s, m/s^2), driven by
white jerk with power spectral density ``q`` (m^2/s^5) per axis. States beyond the first nine
(sensor biases, latencies in later work) are random constants: identity transition, zero
process noise, so the kernels take ``n >= 9``.

The transition is a Kronecker product ``F = F1(dt) (x) I3`` of the 3x3 per-axis block
``F1 = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]`` and the noise is ``Q = q Q1(dt) (x) I3`` with
``Q1 = [[dt^5/20, dt^4/8, dt^3/6], [dt^4/8, dt^3/3, dt^2/2], [dt^3/6, dt^2/2, dt]]``
(Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking*, sec. 6.2.3).
"""
from __future__ import annotations

import numpy as np
from numba import njit

N_KINEMATIC = 9


@njit(cache=True, nogil=True, error_model="numpy")
def ca_blocks(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis blocks (F1, Q1) of the CA model, each (3, 3); Q1 already scaled by ``q``."""
    f1 = np.empty((3, 3))
    f1[0, 0] = 1.0
    f1[0, 1] = dt
    f1[0, 2] = 0.5 * dt * dt
    f1[1, 0] = 0.0
    f1[1, 1] = 1.0
    f1[1, 2] = dt
    f1[2, 0] = 0.0
    f1[2, 1] = 0.0
    f1[2, 2] = 1.0
    dt2 = dt * dt
    dt3 = dt2 * dt
    q1 = np.empty((3, 3))
    q1[0, 0] = q * dt3 * dt2 / 20.0
    q1[0, 1] = q * dt2 * dt2 / 8.0
    q1[0, 2] = q * dt3 / 6.0
    q1[1, 1] = q * dt3 / 3.0
    q1[1, 2] = q * dt2 / 2.0
    q1[2, 2] = q * dt
    q1[1, 0] = q1[0, 1]
    q1[2, 0] = q1[0, 2]
    q1[2, 1] = q1[1, 2]
    return f1, q1


@njit(cache=True, nogil=True, error_model="numpy")
def ca_transition(n: int, dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Full (n, n) transition F and process noise Q for step ``dt`` (s), ``q`` (m^2/s^5).

    Kinematic block ``F1 (x) I3`` with states ordered position, velocity, acceleration (each
    e, n, u); extra states (index >= 9) are constants.
    """
    f1, q1 = ca_blocks(dt, q)
    F = np.eye(n)
    Q = np.zeros((n, n))
    for i in range(3):
        for j in range(3):
            for ax in range(3):
                F[3 * i + ax, 3 * j + ax] = f1[i, j]
                Q[3 * i + ax, 3 * j + ax] = q1[i, j]
    return F, Q


def ca_transition_py(dt: float, q: float, n: int = N_KINEMATIC) -> tuple[np.ndarray, np.ndarray]:
    """Python-callable CA transition (same code), for tests and initialisation."""
    return ca_transition(n, float(dt), float(q))
