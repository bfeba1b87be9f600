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
stays symmetric positive semi-definite by construction.

It also returns the EM statistic of the process noise (Shumway & Stoffer 1982): for each step
the expected squared acceleration increment given all data,
``E[(a_{k+1} - a_k)^2 | Z] = (da_s)^2 + P_{k+1|N} + P_{k|N} - 2 P_{k+1,k|N}`` averaged over the
three axes, with the lag-one covariance ``P_{k+1,k|N} = P_{k+1|N} C_k^T``. Under the
white-jerk model its expectation is ``q dt``, so windowed sums give a local q.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace, pack, unpack
from rangeproc.models.motion import ca_transition


@njit(cache=True)
def rts_smooth(epoch_t: np.ndarray, xf: np.ndarray, Pf: np.ndarray, q_steps: np.ndarray):
    """Smooth filtered states.

    Args:
        epoch_t: (E,) epoch times (s); xf: (E, n) filtered states; Pf: (E, n(n+1)/2) packed
            filtered covariances; q_steps: (E,) white-jerk PSD (m^2/s^5) of the step ending at
            each epoch (``q_steps[0]`` unused), the same the filter used.

    Returns:
        xs (E, n), Ps (E, n(n+1)/2) packed smoothed states and covariances, and
        em (E,) the EM acceleration-increment statistic of the step ending at each epoch
        (m^2/s^4, ``em[0] = 0``).
    """
    E, n = xf.shape
    xs = xf.copy()
    Ps = Pf.copy()
    em = np.zeros(E)
    P_f = np.empty((n, n))
    P_next = np.empty((n, n))
    unpack(Pf[E - 1], P_next)
    for k in range(E - 2, -1, -1):
        F, Q = ca_transition(n, epoch_t[k + 1] - epoch_t[k], q_steps[k + 1])
        unpack(Pf[k], P_f)
        FP = F @ P_f                                   # (n, n)
        P_pred = FP @ F.T + Q
        x_pred = F @ xf[k]
        # C^T = P_pred^-1 F P_f  (P_pred symmetric positive definite)
        L = P_pred.copy()
        if not cholesky_inplace(L, n):
            raise FloatingPointError("predicted covariance not positive definite in RTS")
        Ct = FP.copy()
        chol_solve_inplace(L, n, Ct, n)
        C = Ct.T
        xs[k] = xf[k] + C @ (xs[k + 1] - x_pred)
        A = np.eye(n) - C @ F
        P_s = A @ P_f @ A.T + C @ (Q + P_next) @ Ct
        pack(P_s, Ps[k])
        cross = P_next @ Ct                            # P_{k+1,k|N}
        acc = 0.0
        for ax in range(6, 9):
            d = xs[k + 1, ax] - xs[k, ax]
            acc += d * d + P_next[ax, ax] + P_s[ax, ax] - 2.0 * cross[ax, ax]
        em[k + 1] = acc / 3.0
        unpack(Ps[k], P_next)
    return xs, Ps, em
