"""Consider analysis of calibration terms (``estimation.consider``), by seeded Monte Carlo on
a linear-Gaussian joint problem of a trajectory (two 9-state nodes) and four calibration
terms: the truth drawn from the priors, the applied terms' conditional estimate, and the
trajectory's error against its covariance with the terms left uncorrected considered."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from rangeproc.estimation.consider import consider_split

G, NX, P, M = 2, 9, 4, 80
SIGMA0 = np.array([2.0, 1.5, 1.0, 0.5])            # the terms' a-priori spread


def _problem(seed: int):
    g = np.random.default_rng(seed)
    Hx = g.normal(size=(M, G * NX))
    Hc = g.normal(size=(M, P))
    Hc[:, 3] = 0.9 * Hc[:, 2] + 0.1 * g.normal(size=M)    # two terms nearly alike
    return Hx, Hc


def _solve(Hx, Hc, y):
    """The joint normal equations' reduction (as ``solve_joint``), weak prior on x."""
    Nxx = Hx.T @ Hx + 1e-6 * np.eye(G * NX)
    Nxc, Ncc = Hx.T @ Hc, Hc.T @ Hc
    bx, bc = Hx.T @ y, Hc.T @ y
    Xc = np.linalg.solve(Nxx, Nxc)
    xb = np.linalg.solve(Nxx, bx)
    S = Ncc - Nxc.T @ Xc
    s = bc - Nxc.T @ xb
    return S, s, Xc, xb, np.linalg.inv(Nxx)


def _nees(apply, runs: int = 400, joint_as_before: bool = False) -> float:
    """Mean per-node NEES (9 dof) of the trajectory over ``runs`` seeded draws."""
    Hx, Hc = _problem(1)
    g = np.random.default_rng(2)
    x_true = g.normal(size=G * NX)
    total = np.zeros(P)
    out = []
    for _ in range(runs):
        c_true = g.normal(0.0, SIGMA0)
        y = Hx @ x_true + Hc @ c_true + g.normal(size=M)
        S, s, Xc, xb, Pxx = _solve(Hx, Hc, y)
        Xc3 = Xc.reshape(G, NX, P)
        split = consider_split(S, s, SIGMA0, total, apply, Xc3)
        c_used = split.applied
        node_cov = split.node_cov
        if joint_as_before:                 # the joint estimate applied, its covariance only
            J = S + np.diag(1.0 / SIGMA0 ** 2)
            cov = np.linalg.inv(J)
            c_used = np.where(apply, cov @ s, 0.0)
            cov = np.where(np.outer(apply, apply), cov, 0.0)
            node_cov = Xc3 @ cov @ Xc3.transpose(0, 2, 1)
        err = (xb - Xc @ c_used - x_true).reshape(G, NX)
        for k in range(G):
            C = Pxx[k * NX:(k + 1) * NX, k * NX:(k + 1) * NX] + node_cov[k]
            out.append(err[k] @ np.linalg.solve(C, err[k]))
    return float(np.mean(out))


def _bounds(runs: int = 400) -> tuple[float, float]:
    n = runs * G                          # the two nodes are correlated: bounds a little wide
    return chi2.ppf(0.001, NX * n) / n, chi2.ppf(0.999, NX * n) / n


@pytest.mark.parametrize("apply", [
    np.array([True, True, True, True]),     # every term applied: the joint covariance
    np.array([True, True, False, False]),   # two left at zero, their truth not
    np.array([False, True, True, False]),   # one of two alike terms left: the other absorbs
    np.array([False, False, False, False]),  # nothing applied
])
def test_trajectory_nees_is_chi_square_with_terms_left_uncorrected(apply):
    lo, hi = _bounds()
    assert lo <= _nees(apply) <= hi


def test_the_joint_estimate_with_only_its_covariance_is_overconfident():
    """The negative control: applying the joint estimates of some terms and adding only their
    covariance (the former treatment) fails the same test."""
    lo, hi = _bounds()
    assert _nees(np.array([True, True, False, False]), joint_as_before=True) > hi


def test_all_applied_equals_the_joint_estimate_and_covariance():
    Hx, Hc = _problem(3)
    y = np.random.default_rng(4).normal(size=M)
    S, s, Xc, _, _ = _solve(Hx, Hc, y)
    J = S + np.diag(1.0 / SIGMA0 ** 2)
    total = np.array([0.3, -0.2, 0.0, 0.1])
    split = consider_split(S, s, SIGMA0, total, np.ones(P, dtype=bool), Xc.reshape(G, NX, P))
    assert split.applied == pytest.approx(total + np.linalg.solve(J, s), rel=1e-10)
    Xc3 = Xc.reshape(G, NX, P)
    want = Xc3 @ np.linalg.inv(J) @ Xc3.transpose(0, 2, 1)
    assert split.node_cov == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_terms_left_uncorrected_take_their_corrections_out():
    """A term applied before (``total``) and left now is taken back to zero: the applied
    terms' estimate is conditional on it being zero."""
    Hx, Hc = _problem(5)
    c_true = np.array([1.0, -2.0, 0.0, 0.0])
    y = Hx @ np.zeros(G * NX) + Hc @ c_true
    S, s, Xc, _, _ = _solve(Hx, Hc, y - Hc @ np.array([0.0, 0.0, 0.7, 0.0]))  # rows hold 0.7
    split = consider_split(S, s, np.full(P, 1e3), np.array([0.0, 0.0, 0.7, 0.0]),
                           np.array([True, True, False, False]), Xc.reshape(G, NX, P))
    assert split.applied == pytest.approx([1.0, -2.0, 0.0, 0.0], abs=1e-6)
