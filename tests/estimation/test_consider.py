"""Consider analysis of calibration terms (``estimation.consider``), by seeded Monte Carlo on
a linear-Gaussian joint problem of a trajectory (two 9-state nodes) and four calibration
terms: the truth drawn from the priors, some terms corrected by their estimate and the others
left at zero, and the trajectory's error against its covariance with every term considered."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from rangeproc.estimation.consider import consider_covariance

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


def _joint(S, s):
    return np.linalg.solve(S + np.diag(1.0 / SIGMA0 ** 2), s)


def _conditional(S, s, apply):
    """The applied terms' estimate given the others zero (another admissible choice)."""
    J = S + np.diag(1.0 / SIGMA0 ** 2)
    A = np.flatnonzero(apply)
    out = np.zeros(P)
    out[A] = np.linalg.solve(J[np.ix_(A, A)], s[A])
    return out


def _nees(apply, runs: int = 400, choice: str = "joint", covariance: str = "full") -> float:
    """Mean per-node NEES (9 dof) of the trajectory over ``runs`` seeded draws: the terms in
    ``apply`` corrected by their joint (or conditional) estimate, the others left at zero."""
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
        est = _joint(S, s) if choice == "joint" else _conditional(S, s, apply)
        c_used = np.where(apply, est, 0.0)
        node_cov = consider_covariance(S, s, SIGMA0, total, c_used, Xc3)
        J_inv = np.linalg.inv(S + np.diag(1.0 / SIGMA0 ** 2))
        if covariance == "applied only":    # the former treatment: the applied terms' share
            node_cov = Xc3 @ np.where(np.outer(apply, apply), J_inv, 0.0) @ Xc3.transpose(0, 2, 1)
        elif covariance == "no square":     # every term's covariance, not the estimates' square
            node_cov = Xc3 @ J_inv @ Xc3.transpose(0, 2, 1)
        err = (xb - Xc @ c_used - x_true).reshape(G, NX)
        for k in range(G):
            C = Pxx[k * NX:(k + 1) * NX, k * NX:(k + 1) * NX] + node_cov[k]
            out.append(err[k] @ np.linalg.solve(C, err[k]))
    return float(np.mean(out))


def _bounds(runs: int = 400) -> tuple[float, float]:
    n = runs * G                          # the two nodes are correlated: bounds a little wide
    return chi2.ppf(0.001, NX * n) / n, chi2.ppf(0.999, NX * n) / n


@pytest.mark.parametrize("choice", ["joint", "conditional"])
@pytest.mark.parametrize("apply", [
    np.array([True, True, True, True]),     # every term applied: the joint covariance
    np.array([True, True, False, False]),   # two left at zero, their truth not
    np.array([False, True, True, False]),   # one of two alike terms left
    np.array([False, False, False, False]),  # nothing applied
])
def test_trajectory_nees_is_chi_square_whatever_the_rows_are_corrected_by(apply, choice):
    lo, hi = _bounds()
    assert lo <= _nees(apply, choice=choice) <= hi


@pytest.mark.parametrize("covariance", ["applied only", "no square"])
def test_leaving_out_a_share_of_the_terms_left_uncorrected_is_overconfident(covariance):
    """The negative controls: adding only the applied terms' covariance (the former
    treatment), or every term's covariance without the square of the estimates of the terms
    left at zero, fails the same test."""
    lo, hi = _bounds()
    assert _nees(np.array([True, True, False, False]), covariance=covariance) > hi


def test_all_applied_at_the_estimate_adds_the_joint_covariance():
    Hx, Hc = _problem(3)
    y = np.random.default_rng(4).normal(size=M)
    S, s, Xc, _, _ = _solve(Hx, Hc, y)
    J = S + np.diag(1.0 / SIGMA0 ** 2)
    total = np.array([0.3, -0.2, 0.0, 0.1])
    Xc3 = Xc.reshape(G, NX, P)
    got = consider_covariance(S, s, SIGMA0, total, total + np.linalg.solve(J, s), Xc3)
    want = Xc3 @ np.linalg.inv(J) @ Xc3.transpose(0, 2, 1)
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_a_term_left_uncorrected_adds_the_square_of_its_estimate():
    """Rows that carry 0.7 of term 2 from a previous solve, now left uncorrected: the
    covariance grows by the trajectory's share of the whole estimate, carried or not."""
    Hx, Hc = _problem(5)
    c_true = np.array([1.0, -2.0, 0.5, 0.0])
    total = np.array([0.0, 0.0, 0.7, 0.0])
    y = Hx @ np.zeros(G * NX) + Hc @ (c_true - total)       # the rows hold 0.7 of term 2
    S, s, Xc, _, _ = _solve(Hx, Hc, y)
    Xc3 = Xc.reshape(G, NX, P)
    c_hat = total + np.linalg.solve(S + np.diag(1.0 / SIGMA0 ** 2), s)
    assert c_hat == pytest.approx(c_true, abs=0.05)
    kept = consider_covariance(S, s, SIGMA0, total, c_hat, Xc3)
    left = consider_covariance(S, s, SIGMA0, total, np.where([1, 1, 0, 1], c_hat, 0.0), Xc3)
    want = Xc3[:, :, 2:3] @ Xc3[:, :, 2:3].transpose(0, 2, 1) * c_hat[2] ** 2
    assert left - kept == pytest.approx(want, rel=1e-9, abs=1e-12)
