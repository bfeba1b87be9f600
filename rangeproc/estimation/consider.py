"""Consider analysis of calibration terms: what the terms' uncertainty, and the terms left
uncorrected, add to the trajectory's covariance.

The registration (``estimation.registration``) reduces the joint least squares of a trajectory
correction ``dx`` and calibration increments ``c`` (p,) to the terms' information ``S`` and
right-hand side ``s`` with the trajectory free, and the trajectory's sensitivity
``Xc = Nxx^-1 Nxc`` (``dx = xb - Xc c``). With the prior ``Lambda = diag(1 / sigma_0^2)``
(the terms' a-priori spread) the joint posterior of the increments is Gaussian::

    c ~ N(c_hat, J^-1),    J = S + Lambda,    c_hat = J^-1 s.

Given ``c`` the trajectory's posterior is ``xb - Xc c`` with the smoother's covariance
``Nxx^-1``, independent of ``c`` (the Schur-complement factorisation of the joint normal
matrix). The rows are corrected by some increments ``a`` (the significant terms' estimates,
the others left at zero); the trajectory the smoother returns is then ``xb - Xc a`` and its
error ``Xc (c - a)`` plus the smoother's own. Over the posterior of ``c`` that error has the
second moment::

    Nxx^-1 + Xc (J^-1 + m m^T) Xc^T,    m = c_hat - a,

whatever ``a`` is: every term counts with its posterior covariance (an undetermined term at
its prior spread except along the combinations the data fix: a ship radar's deck azimuth bias
and its mount yaw act alike, the data fix their sum, and their difference moves the
trajectory little), and a term left uncorrected also with the square of its estimate. This is
the consider covariance of Tapley, Schutz & Born 2004, *Statistical Orbit Determination*,
sec. 6.3 (Bierman 1977, *Factorization Methods for Discrete Sequential Estimation*, ch. VIII),
written for the corrections actually applied: with every term applied at its estimate
(``m = 0``) it is the joint covariance ``Xc J^-1 Xc^T``.
"""
from __future__ import annotations

import numpy as np


def consider_covariance(S: np.ndarray, s: np.ndarray, prior_sigma: np.ndarray,
                        total: np.ndarray, applied: np.ndarray, Xc: np.ndarray) -> np.ndarray:
    """The covariance the calibration's uncertainty adds to the trajectory at the nodes.

    Args:
        S: (p, p) information of the increments with the trajectory free; s: (p,) its
            right-hand side (``estimation.registration.solve_joint``), at rows that carry the
            corrections ``total``.
        prior_sigma: (p,) the prior's sigmas (SI) of the terms: their a-priori spread.
        total: (p,) the corrections (SI) the rows carry during this solve.
        applied: (p,) the corrections (SI) the rows will carry after it (0 for a term left
            uncorrected).
        Xc: (G, 9, p) the trajectory's sensitivity to the increments at the nodes.

    Returns:
        (G, 9, 9) the covariance (m, m/s, m/s^2 blocks of the CA state) to add to the
        smoother's at the nodes: ``Xc (J^-1 + m m^T) Xc^T`` (module docstring).
    """
    J = S + np.diag(1.0 / prior_sigma ** 2)
    J_inv = np.linalg.inv(0.5 * (J + J.T))
    m = total + J_inv @ s - applied               # posterior mean minus what the rows carry
    second = J_inv + np.outer(m, m)
    node_cov = Xc @ second @ Xc.transpose(0, 2, 1)
    return 0.5 * (node_cov + node_cov.transpose(0, 2, 1))
