"""Consider analysis of calibration terms: which corrections to apply, and what the terms left
uncorrected add to the trajectory's covariance.

The registration (``estimation.registration``) reduces the joint least squares of a trajectory
correction ``dx`` and calibration increments ``c`` (p,) to the terms' information ``S`` and
right-hand side ``s`` with the trajectory free, and the trajectory's sensitivity
``Xc = Nxx^-1 Nxc`` (``dx = xb - Xc c``). With a weak prior ``Lambda = diag(1 / sigma_0^2)``
the joint estimate is ``c_hat = J^-1 s``, ``J = S + Lambda``, its covariance ``J^-1``.

Only the significant terms (set A) correct the rows; the others (set U: insignificant
estimates, and optionally terms the data cannot determine) stay at zero. Correcting A with
its joint estimate while U stays at zero mixes two models; the consistent estimate of A *given*
``c_U = 0`` is the conditional solve (Tapley, Schutz & Born 2004, *Statistical Orbit
Determination*, sec. 6.3, consider parameters; Bierman 1977, *Factorization Methods for
Discrete Sequential Estimation*, ch. VIII)::

    c_A = J_AA^-1 (s_A - J_AU u),    u = the increment that takes U to zero.

Its error is ``e_A = J_AA^-1 n_A + J_AA^-1 J_AU w`` with ``w`` the true values of U, so the
trajectory's error ``-Xc_A e_A + Xc_U w`` has the covariance::

    Xc_A J_AA^-1 Xc_A^T + D Sigma_w D^T,    D = Xc_U - Xc_A J_AA^-1 J_AU,

``Sigma_w = E[w w^T | data] = J^-1_UU + w_hat w_hat^T`` from the joint posterior of *every*
candidate term under its a-priori spread ``sigma_0``, also those the data do not determine on
their own: so an undetermined term counts with its prior spread except along the
combinations the data fix (a ship radar's deck azimuth bias and its mount yaw act alike; the
data fix their sum, and their difference moves the trajectory little). The cross-covariance
of ``n_A`` and ``w`` (both come from the same data) is neglected. With U empty this is the
joint covariance ``Xc J^-1 Xc^T``.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class ConsiderSplit(NamedTuple):
    """What the rows are corrected by and what the calibration adds to the trajectory.

    applied: (p,) the corrections (SI) the rows carry after this solve: the conditional
        estimate for the applied terms, 0 elsewhere.
    node_cov: (G, 9, 9) the covariance the calibration's uncertainty adds to the trajectory
        at the nodes (m, m/s, m/s^2 blocks of the CA state).
    """

    applied: np.ndarray
    node_cov: np.ndarray


def consider_split(S: np.ndarray, s: np.ndarray, prior_sigma: np.ndarray, total: np.ndarray,
                   apply: np.ndarray, Xc: np.ndarray) -> ConsiderSplit:
    """The conditional corrections of the applied terms and the consider covariance.

    Args:
        S: (p, p) information of the increments with the trajectory free; s: (p,) its
            right-hand side (``estimation.registration.solve_joint``).
        prior_sigma: (p,) the prior's sigmas (SI) of the terms: their a-priori spread.
        total: (p,) the corrections the rows already carry (before this solve).
        apply: (p,) bool: the terms that correct the rows.
        Xc: (G, 9, p) the trajectory's sensitivity to the increments at the nodes.

    Returns:
        :class:`ConsiderSplit`.
    """
    p = len(total)
    J = S + np.diag(1.0 / prior_sigma ** 2)
    J = 0.5 * (J + J.T)
    A = np.flatnonzero(apply)
    U = np.flatnonzero(~apply)
    applied = np.zeros(p)
    node_cov = np.zeros((Xc.shape[0], Xc.shape[1], Xc.shape[1]))
    D = Xc[:, :, U]
    if len(A):
        chol = np.linalg.cholesky(J[np.ix_(A, A)])

        def solve(b: np.ndarray) -> np.ndarray:
            return np.linalg.solve(chol.T, np.linalg.solve(chol, b))

        J_AU = J[np.ix_(A, U)]
        applied[A] = total[A] + solve(s[A] + J_AU @ total[U])   # u = -total_U
        W = np.linalg.solve(chol, Xc[:, :, A].transpose(0, 2, 1))   # L^-1 Xc_A^T (G, |A|, 9)
        node_cov += W.transpose(0, 2, 1) @ W
        if len(U):
            D = D - Xc[:, :, A] @ solve(J_AU)
    if len(U):
        cov_full = np.linalg.inv(J)                 # the joint posterior of every term
        true_U = total[U] + (cov_full @ s)[U]
        sig_w = cov_full[np.ix_(U, U)] + np.outer(true_U, true_U)
        node_cov += D @ sig_w @ D.transpose(0, 2, 1)
    return ConsiderSplit(applied, 0.5 * (node_cov + node_cov.transpose(0, 2, 1)))
