"""The compiled IMM against plain references where its loops take shortcuts: the forward
filter's model matrices rebuilt only when the step, the PSD or the turn rate changes
(irregular steps and a changing PSD: FilterPy's IMMEstimator given each step's matrices),
and Kim's smoother's single-pair models (a model whose pairs all but one were pruned takes
that pair's step as its mixture) against a numpy Kim smoother that mixes every model's
pairs. Each with a negative control: the reference given the shortcut's mistake fails."""
import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter
from scipy.linalg import expm

from rangeproc.estimation.imm import imm_forward
from rangeproc.estimation.imm_models import CA, CT, CV, model_matrices
from rangeproc.estimation.imm_smoother import imm_smooth
from rangeproc.fusion.passes import imm_generator
from rangeproc.models.measurement import CARTESIAN

SIGMA = 5.0


def _turn(t: np.ndarray) -> np.ndarray:
    """Positions (len(t), 3): 200 m/s, straight, a 0.1 rad/s turn from 20 to 40 s, straight."""
    w = np.where((t > 20.0) & (t < 40.0), 0.1, 0.0)
    ang = np.concatenate([[0.0], np.cumsum(w[1:] * np.diff(t))])
    v = 200.0 * np.column_stack([np.cos(ang), np.sin(ang), 0.0 * t])
    return np.concatenate([[[0.0, 0.0, 0.0]], np.cumsum(v[1:] * np.diff(t)[:, None], axis=0)])


def _args(t: np.ndarray, q: np.ndarray, seed: int) -> tuple:
    """imm_forward's 16 leading arguments: a position fix (sigma 5 m) at every epoch but the
    first (the prior's), gating off, no divergence guard."""
    pos = _turn(t)[1:]
    n = len(pos)
    z = np.full((n, 6), np.nan)
    z[:, :3] = pos + np.random.default_rng(seed).normal(0.0, SIGMA, (n, 3))
    x0 = np.zeros(9)
    return (t, np.arange(1, n + 1), np.full(n, CARTESIAN), z, np.full((n, 6), SIGMA),
            np.zeros((n, 3)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
            np.zeros(n, np.int64), x0, np.eye(9) * 1e4, q, np.full(7, np.inf), 0, 1.0,
            np.empty((0, 9)))


def _irregular(n: int = 160):
    """Steps alternating 0.25 / 0.4 s with runs of equal steps, and a PSD that changes every
    25 epochs (2, 30, 2, ...): the rebuilt-when-changed matrices must follow both."""
    steps = np.where((np.arange(n) // 7) % 2 == 0, 0.25, 0.4)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    q = np.where((np.arange(n + 1) // 25) % 2 == 0, 2.0, 30.0)
    return t, q


def _filterpy_imm(args: tuple, codes: np.ndarray, lam: np.ndarray, mu0: np.ndarray,
                  q_of_step) -> tuple[np.ndarray, np.ndarray]:
    """FilterPy's IMMEstimator stepped with each step's switch matrix and model matrices
    (PSD ``q_of_step(k)`` for the step ending at epoch k): (combined states, mu)."""
    t = args[0]
    filters = []
    for _ in codes:
        kf = KalmanFilter(dim_x=9, dim_z=3)
        kf.x, kf.P = args[9].copy(), args[10].copy()
        kf.F, kf.Q = np.empty((9, 9)), np.empty((9, 9))
        kf.H = np.hstack([np.eye(3), np.zeros((3, 6))])
        kf.R = np.eye(3) * SIGMA**2
        filters.append(kf)
    imm = IMMEstimator(filters, mu0.copy(), expm(lam * (t[1] - t[0])))
    xs, mus = [], []
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        imm.M = expm(lam * dt)               # FilterPy mixes with the M of its last update:
        imm._compute_mixing_probabilities()  # redone with this step's
        for kf, code in zip(filters, codes):
            model_matrices(code, dt, q_of_step(k), 0.0, kf.F, kf.Q)
        imm.predict()
        imm.update(args[3][k - 1, :3])
        xs.append(imm.x.copy())
        mus.append(imm.mu.copy())
    return np.array(xs), np.array(mus)


def test_forward_matrices_follow_irregular_steps_and_a_changing_psd() -> None:
    t, q = _irregular()
    args = _args(t, q, seed=4)
    codes = np.array([CV, CA])
    lam = imm_generator(2, 5.0)
    mu0 = np.array([0.5, 0.5])
    out = imm_forward(*args, codes, lam, mu0)
    ref_x, ref_mu = _filterpy_imm(args, codes, lam, mu0, lambda k: q[k])
    scale = np.abs(ref_x).max(axis=0)
    assert np.max(np.abs(out[0][1:] - ref_x) / scale) < 1e-9
    np.testing.assert_allclose(out[4][1:], ref_mu, atol=1e-9, rtol=0)
    # negative control: matrices built once, at the first step's PSD, are far off
    stale_x, _ = _filterpy_imm(args, codes, lam, mu0, lambda k: q[1])
    assert np.max(np.abs(out[0][1:] - stale_x) / scale) > 1e-6


def _unpack(p: np.ndarray, n: int) -> np.ndarray:
    P = np.zeros((n, n))
    P[np.tril_indices(n)] = p
    return P + np.tril(P, -1).T


def _mixture(w: np.ndarray, X: list, P: list) -> tuple[np.ndarray, np.ndarray]:
    x = sum(wi * Xi for wi, Xi in zip(w, X) if wi != 0.0)
    Pm = sum(wi * (Pi + np.outer(Xi - x, Xi - x)) for wi, Xi, Pi in zip(w, X, P) if wi != 0.0)
    return x, Pm


def _kim_reference(t, xm, Pm, mu, omega, q, codes, lam, prune, heaviest_only=False):
    """Kim's smoother in numpy, every model's surviving pairs mixed by their weights
    (``heaviest_only``: the negative control, the single-pair shortcut taken where it does
    not hold, a model with several pairs smoothed by its heaviest pair alone). Returns (xs,
    mus, count of models smoothed from one pair, count from several)."""
    E, r, n = xm.shape
    xs = np.empty((E, n))
    mus = np.empty((E, r))
    Xn = [xm[E - 1, i].copy() for i in range(r)]
    Pn = [_unpack(Pm[E - 1, i], n) for i in range(r)]
    mus[E - 1] = mu[E - 1]
    xs[E - 1] = _mixture(mus[E - 1], Xn, Pn)[0]
    singles = multi = 0
    F, Q = np.empty((n, n)), np.empty((n, n))
    for k in range(E - 2, -1, -1):
        dt = t[k + 1] - t[k]
        Pi = expm(lam * dt)
        c = np.maximum(Pi.T @ mu[k], 1e-300)
        W = mu[k][:, None] * Pi * mus[k + 1][None, :] / c[None, :]
        total = W.sum()
        mus[k] = W.sum(axis=1) / total
        W[(W < prune * mus[k][:, None] * total) | (mus[k][:, None] < prune)] = 0.0
        Xk, Pk, wc = [None] * r, [None] * r, np.zeros(r)
        for j in range(r):
            kept = np.flatnonzero(W[j])
            if kept.size == 0:
                continue
            singles += kept.size == 1
            multi += kept.size > 1
            if heaviest_only:
                kept = kept[np.argmax(W[j, kept]):][:1]
            Pf = _unpack(Pm[k, j], n)
            X, P = [], []
            for i in kept:
                model_matrices(codes[i], dt, q[k + 1], omega[k + 1, i], F, Q)
                Pp = F @ Pf @ F.T + Q
                C = Pf @ F.T @ np.linalg.inv(Pp)
                X.append(xm[k, j] + C @ (Xn[i] - F @ xm[k, j]))
                P.append(Pf + C @ (Pn[i] - Pp) @ C.T)
            Xk[j], Pk[j] = _mixture(W[j, kept] / W[j, kept].sum(), X, P)
            wc[j] = mus[k, j]
        wc /= wc.sum()
        xs[k], Ps = _mixture(wc, [x if x is not None else 0.0 for x in Xk],
                             [p if p is not None else 0.0 for p in Pk])
        for j in range(r):
            Xn[j], Pn[j] = (Xk[j], Pk[j]) if wc[j] > 0.0 else (xs[k], Ps)
    return xs, mus, singles, multi


def test_kim_smoother_single_pair_models_agree_with_the_full_mixture() -> None:
    t = np.arange(601) * 0.1
    args = _args(t, np.full(len(t), 2.0), seed=2)
    codes = np.array([CV, CA, CT])
    lam = imm_generator(3, 10.0)
    out = imm_forward(*args, codes, lam, np.full(3, 1.0 / 3.0))
    xm, Pm, mu, omega = out[2], out[3], out[4], out[5]
    prune = 1e-3
    xs, _, mus = imm_smooth(t, xm, Pm, mu, omega, args[11], codes, lam, prune)
    ref_x, ref_mu, singles, multi = _kim_reference(t, xm, Pm, mu, omega, args[11], codes,
                                                   lam, prune)
    assert singles > 100 and multi > 100            # both of the smoother's paths ran
    scale = np.abs(ref_x).max(axis=0)
    assert np.max(np.abs(xs - ref_x) / scale) < 1e-9
    np.testing.assert_allclose(mus, ref_mu, atol=1e-12, rtol=0)
    # negative control: the shortcut where it does not hold (several pairs, the heaviest alone)
    bad_x = _kim_reference(t, xm, Pm, mu, omega, args[11], codes, lam, prune,
                           heaviest_only=True)[0]
    assert np.max(np.abs(xs - bad_x) / scale) > 1e-6
