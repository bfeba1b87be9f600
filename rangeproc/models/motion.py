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

The constant-velocity (CV) model of the plot tracker and of the IMM's CV and CT models is the
per-axis ``[[1, dt], [0, 1]]`` on (position, velocity), driven by white acceleration of PSD
``q`` (m^2/s^3): ``Q1 = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` (same reference, sec. 6.2.2),
``white_acceleration_q``. Each noise block is written once, in a form numba compiles for the
fusion's kernels and numpy runs over arrays (``.py_func``) for the trackers of ``tracking/``
(:func:`cv_predict`), so both evaluate the same expressions.
"""
from __future__ import annotations

import numpy as np
from numba import njit

N_KINEMATIC = 9


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def white_jerk_q(dt, q):
    """The white-jerk process noise ``q Q1(dt)`` of one axis: its six distinct entries
    ``(q00, q01, q02, q11, q12, q22)`` = ``q (dt^5/20, dt^4/8, dt^3/6, dt^3/3, dt^2/2, dt)``
    (m^2, m^2/s, m^2/s^2, m^2/s^2, m^2/s^3, m^2/s^4 for ``q`` in m^2/s^5, ``dt`` >= 0 in s).

    The one definition of the CA model's process noise: the filters, smoothers, IMM, strong
    tracking, registration and the trackers of ``tracking/`` all take it from here. ``dt``
    and ``q`` may be scalars or arrays of one shape (the entries are then arrays). A
    backward step (``dt`` < 0, ``estimation.kernels.add_q``) has the noise ``D Q1(|dt|) D``
    with ``D = diag(1, -1, 1)``.
    """
    dt2 = dt * dt
    dt3 = dt2 * dt
    return (q * dt3 * dt2 / 20.0, q * dt2 * dt2 / 8.0, q * dt3 / 6.0, q * dt3 / 3.0,
            q * dt2 / 2.0, q * dt)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def white_acceleration_q(dt, q):
    """The white-acceleration process noise ``q Q1(dt)`` of one axis of the CV model: its
    three distinct entries ``(q00, q01, q11)`` = ``q (dt^3/3, dt^2/2, dt)`` (m^2, m^2/s,
    m^2/s^2 for ``q`` in m^2/s^3, ``dt`` >= 0 in s).

    The one definition of the CV model's process noise: the IMM's CV and CT models
    (``estimation.imm_models``) compile it, the plot tracker (:func:`cv_predict`) runs it
    over arrays (``white_acceleration_q.py_func``; ``dt`` and ``q`` scalars or arrays of one
    shape). A backward step (``dt`` < 0) has the noise ``D Q1(|dt|) D`` with
    ``D = diag(1, -1)``: ``q01`` changes sign.
    """
    dt2 = dt * dt
    return q * (dt2 * dt) / 3.0, q * dt2 / 2.0, q * dt


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def ca_axis_step(p0: float, p1: float, p2: float, dt: float,
                 h2: float) -> tuple[float, float, float]:
    """``F1 (p0, p1, p2)``: one axis's CA transition ``F1(dt)`` applied to a vector of
    (position, velocity, acceleration) entries, ``h2 = dt^2 / 2`` (passed in so callers
    compute it once). The one CA prediction: ``F P`` column by column and ``(F P) F^T`` row
    by row are this step (``estimation.kernels``, ``tracking.segments``)."""
    return p0 + dt * p1 + h2 * p2, p1 + dt * p2, p2


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
    q00, q01, q02, q11, q12, q22 = white_jerk_q(dt, q)
    q1 = np.empty((3, 3))
    q1[0, 0] = q00
    q1[0, 1] = q01
    q1[0, 2] = q02
    q1[1, 1] = q11
    q1[1, 2] = q12
    q1[2, 2] = q22
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


def ca_steps(dt: np.ndarray, q: float | np.ndarray = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis CA blocks of many steps for array code: ``F1`` (M, 3, 3) from
    :func:`ca_axis_step` and ``q Q1`` (M, 3, 3) from :func:`white_jerk_q`, for steps ``dt``
    (M,) s >= 0 and PSD ``q`` (m^2/s^5; a scalar or (M,)). The numpy form of
    :func:`ca_blocks` (``fusion.bridge``, ``estimation.registration``)."""
    dt = np.asarray(dt, dtype=float)
    one, zero = np.ones_like(dt), np.zeros_like(dt)
    h2 = 0.5 * dt * dt
    cols = [ca_axis_step.py_func(*e, dt, h2) for e in ((one, zero, zero), (zero, one, zero),
                                                      (zero, zero, one))]
    F1 = np.stack([np.stack(c, -1) for c in cols], -1)
    q00, q01, q02, q11, q12, q22 = (np.broadcast_to(v, dt.shape)
                                    for v in white_jerk_q.py_func(dt, q))
    Q1 = np.stack([np.stack([q00, q01, q02], -1), np.stack([q01, q11, q12], -1),
                   np.stack([q02, q12, q22], -1)], -2)
    return F1, Q1


def axes_blocks(B: np.ndarray) -> np.ndarray:
    """(M, 3, 3) per-axis blocks -> (M, 9, 9) state blocks ``B (x) I3`` (state index
    ``3 * order + axis``: position, velocity, acceleration, each e, n, u)."""
    out = np.einsum("mij,ab->miajb", B, np.eye(3))
    return out.reshape(B.shape[0], N_KINEMATIC, N_KINEMATIC)


def ca_transition_py(dt: float, q: float, n: int = N_KINEMATIC) -> tuple[np.ndarray, np.ndarray]:
    """Python-callable CA transition (same code), for tests and initialisation."""
    return ca_transition(n, float(dt), float(q))


def cv_predict(x: np.ndarray, P: np.ndarray, dt: np.ndarray, q: float | np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Constant-velocity prediction of states x (..., 6) ``[e, n, u, ve, vn, vu]`` (m, m/s)
    and covariances P (..., 6, 6) over dt (...) s, either sign, with white-acceleration PSD
    q (m^2/s^3; a scalar or an array of dt's shape): ``F x``, ``F P F^T + Q`` with
    ``F = [[1, dt], [0, 1]] (x) I3`` and ``Q`` the blocks of :func:`white_acceleration_q`
    (of ``|dt|``; a backward step's velocity terms change sign). Numpy, vectorised over the
    leading axes (the trackers' K tracks or (track, plot) pairs)."""
    dt = np.asarray(dt, dtype=float)
    q00, q01, q11 = white_acceleration_q.py_func(np.abs(dt), q)
    q01 = np.copysign(q01, dt)                              # D Q1(|dt|) D backwards
    F = np.broadcast_to(np.eye(6), (*dt.shape, 6, 6)).copy()
    Q = np.zeros((*dt.shape, 6, 6))
    for k in range(3):
        F[..., k, k + 3] = dt
        Q[..., k, k] = q00
        Q[..., k, k + 3] = Q[..., k + 3, k] = q01
        Q[..., k + 3, k + 3] = q11
    return np.einsum("...ij,...j->...i", F, x), F @ P @ np.swapaxes(F, -1, -2) + Q


#: White-acceleration PSD ((m/s^2)^2/s) of the IMM's manoeuvre model: a 6 g turn begun between
#: two plots 4 s apart moves the object 480 m off its line, inside the gate of this model's
#: prediction (sqrt(q dt^3 / 3) = 160 m a component, gate 4.6 sigma), where a 3 g model loses
#: fighters turning between surveillance scans.
MANOEUVRE_PSD = 1200.0
#: The manoeuvre model's PSD scales with the square of the track's speed (``manoeuvre_psd``):
#: ``MANOEUVRE_PSD`` from this speed (m/s) on (a 6 g turn at 250 m/s is 13.5 deg/s), down to
#: ``MANOEUVRE_FLOOR`` at rest (a 1 m/s^2 manoeuvre over a few seconds).
MANOEUVRE_SPEED = 250.0
MANOEUVRE_FLOOR = 4.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def speed_manoeuvre_psd(speed, var_v):
    """The manoeuvre model's white-acceleration PSD ((m/s^2)^2/s) for an object of speed
    ``speed`` (m/s) whose velocity has the mean per-axis variance ``var_v`` (m^2/s^2): the
    one definition (:func:`manoeuvre_psd`), compiled where one state is scored
    (``tracking.score``), over arrays through ``py_func`` (scalars or arrays of one shape)."""
    bound = speed + 3.0 * np.sqrt(np.maximum(var_v, 0.0))
    return np.minimum(np.maximum(MANOEUVRE_PSD * (bound / MANOEUVRE_SPEED) ** 2,
                                 MANOEUVRE_FLOOR), MANOEUVRE_PSD)


def manoeuvre_psd(v: np.ndarray, Pv: np.ndarray) -> np.ndarray:
    """(K,) white-acceleration PSD ((m/s^2)^2/s) of the IMM's manoeuvre model for tracks of
    velocity v (K, 3) m/s with covariance Pv (K, 3, 3): a manoeuvre is a turn, whose
    acceleration is the speed times the turn rate, so the PSD scales with the square of the
    speed (taken at its upper bound, |v| + 3 sigma): ``MANOEUVRE_PSD`` (a 6 g turn) at
    ``MANOEUVRE_SPEED`` and above, down to ``MANOEUVRE_FLOOR`` for an object at rest. A boat
    at 4 m/s turns at most a few tenths of a g; a model that lets it leap a fighter's 480 m
    between two scans takes the sea clutter of every missed scan into its track
    (:func:`speed_manoeuvre_psd`)."""
    return speed_manoeuvre_psd.py_func(np.linalg.norm(v, axis=-1),
                                       np.einsum("kii->k", Pv) / 3.0)
