"""IMM filter and Kim's smoother: FilterPy's IMMEstimator, one model = that model's filter and
smoother, the switching matrix, the coordinated-turn model, and model probabilities that say
what the target did."""
import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter
from scipy.linalg import expm, logm

from rangeproc.estimation.forward import FilterSettings, run_filter
from rangeproc.estimation.imm import imm_forward
from rangeproc.estimation.imm_models import CA, CT, CV, model_matrices, switch_matrix
from rangeproc.estimation.imm_smoother import imm_smooth
from rangeproc.estimation.rts import rts_smooth
from rangeproc.fusion.passes import imm_generator
from rangeproc.models.measurement import CARTESIAN

from conftest import filter_parts

SIGMA = 5.0


def _ekf(args: tuple):  # type: ignore[no-untyped-def]
    """The single CA filter (EKF) over the same 16 kernel arguments as ``imm_forward``."""
    rows, prior, kw = filter_parts(args)
    return run_filter(rows, prior, FilterSettings(**kw))


def _rows(t: np.ndarray, pos: np.ndarray, seed: int, first_epoch: int = 0):
    """Kernel arguments for position fixes (sigma 5 m) at epochs ``first_epoch ...``; gating
    off, no divergence guard."""
    rng = np.random.default_rng(seed)
    n = len(pos)
    z = np.full((n, 6), np.nan)
    z[:, :3] = pos + rng.normal(0.0, SIGMA, (n, 3))
    x0 = np.zeros(9)
    x0[:3] = pos[0]
    return (t, np.arange(first_epoch, first_epoch + n), np.full(n, CARTESIAN), z,
            np.full((n, 6), SIGMA), np.zeros((n, 3)), np.zeros((n, 3)),
            np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64), x0, np.eye(9) * 1e4,
            np.full(len(t), 2.0), np.full(7, np.inf), 0, 1.0, np.empty((0, 9)))


def _turn(n: int = 600, dt: float = 0.1):
    """200 m/s, straight for 20 s, a 0.1 rad/s coordinated turn for 20 s, straight again."""
    t = np.arange(n) * dt
    w = np.where((t > 20.0) & (t < 40.0), 0.1, 0.0)
    ang = np.cumsum(w) * dt
    v = 200.0 * np.column_stack([np.cos(ang), np.sin(ang), 0.0 * t])
    return t, np.cumsum(v, axis=0) * dt


def test_switch_matrix_is_expm():
    lam = imm_generator(3, 7.0)
    out, work = np.empty((3, 3)), np.empty((2, 3, 3))
    for dt in (0.01, 0.5, 30.0):
        switch_matrix(lam, dt, out, work)
        np.testing.assert_allclose(out, expm(lam * dt), atol=1e-13)
        np.testing.assert_allclose(out.sum(axis=1), 1.0, atol=1e-15)


def test_coordinated_turn_model_propagates_a_turn_exactly():
    """Noise-free: the CT transition at the state's own turn rate moves a coordinated turn
    (and its centripetal acceleration) exactly; CA with zero acceleration is CV's motion."""
    w, speed, dt = 0.2, 150.0, 0.7
    x = np.array([0.0, 0.0, 100.0, speed, 0.0, 3.0, 0.0, w * speed, 0.0])
    F, Q = np.empty((9, 9)), np.empty((9, 9))
    model_matrices(CT, dt, 1.0, w, F, Q)
    y = F @ x
    ang = w * dt
    expect_p = [speed / w * np.sin(ang), speed / w * (1 - np.cos(ang)), 100.0 + 3.0 * dt]
    np.testing.assert_allclose(y[:3], expect_p, atol=1e-9)
    np.testing.assert_allclose(y[3:5], speed * np.array([np.cos(ang), np.sin(ang)]), atol=1e-9)
    np.testing.assert_allclose(y[6:8], w * speed * np.array([-np.sin(ang), np.cos(ang)]),
                               atol=1e-9)
    assert np.all(np.linalg.eigvalsh(Q) >= -1e-12)
    x_cv = x.copy()
    x_cv[6:] = 0.0
    model_matrices(CV, dt, 1.0, 0.0, F, Q)
    Fa, Qa = np.empty((9, 9)), np.empty((9, 9))
    model_matrices(CA, dt, 1.0, 0.0, Fa, Qa)
    np.testing.assert_allclose((F @ x_cv)[:6], (Fa @ x_cv)[:6], atol=1e-12)


def test_imm_equals_filterpy_imm_estimator():
    """CV + CA on linear position fixes through a turn, gating off: the combined state and
    covariance and the model probabilities equal FilterPy's IMMEstimator given the same
    per-step switching matrix (``expm(Lam dt) = M``) and model matrices, to 1e-9."""
    dt, n = 0.5, 120
    t = np.arange(n + 1) * dt
    pos = _turn(n + 1, dt)[1][1:]
    args = _rows(t, pos, seed=3, first_epoch=1)      # epoch 0: the prior, no row
    codes = np.array([CV, CA])
    M = np.array([[0.95, 0.05], [0.08, 0.92]])
    mu0 = np.array([0.6, 0.4])
    xf, Pf, _, _, mu = imm_forward(*args, codes, np.real(logm(M)) / dt, mu0, True)[:5]
    filters = []
    for code in codes:
        kf = KalmanFilter(dim_x=9, dim_z=3)
        kf.x, kf.P = args[9].copy(), args[10].copy()
        kf.F, kf.Q = np.empty((9, 9)), np.empty((9, 9))
        model_matrices(code, dt, args[11][1], 0.0, kf.F, kf.Q)
        kf.H = np.hstack([np.eye(3), np.zeros((3, 6))])
        kf.R = np.eye(3) * SIGMA**2
        filters.append(kf)
    imm = IMMEstimator(filters, mu0.copy(), M)
    for k in range(n):
        imm.predict()
        imm.update(args[3][k, :3])
        np.testing.assert_allclose(imm.mu, mu[k + 1], atol=1e-9)
        np.testing.assert_allclose(imm.x, xf[k + 1], atol=1e-9, rtol=0)
    assert mu[1:, 0].min() < 0.5 and mu[1:, 0].max() > 0.9      # both models mattered
    P = np.zeros((9, 9))
    P[np.tril_indices(9)] = Pf[-1]
    np.testing.assert_allclose(imm.P, P + np.tril(P, -1).T, atol=1e-9, rtol=0)


@pytest.mark.parametrize("code", [CV, CA])
def test_one_model_is_that_models_filter_and_smoother(code):
    """An IMM with one model is that model's Kalman filter, and Kim's smoother its RTS
    smoother (CA: rangeproc's own EKF and RTS, to 1e-9)."""
    t, pos = _turn(300)
    args = _rows(t, pos, seed=1)
    codes = np.array([code])
    out = imm_forward(*args, codes, np.zeros((1, 1)), np.ones(1), True)
    np.testing.assert_array_equal(out[4], 1.0)
    xs, Ps, mus = imm_smooth(t, out[2], out[3], out[4], out[5], args[11], codes,
                             np.zeros((1, 1)), 0.0)
    if code == CA:
        ek = _ekf(args)
        np.testing.assert_allclose(out[0], ek.xf, atol=1e-9, rtol=0)
        np.testing.assert_allclose(out[1], ek.Pf, atol=1e-9, rtol=0)
        xr, Pr, _ = rts_smooth(t, ek.xf.copy(), ek.Pf.copy(), args[11])
        np.testing.assert_allclose(xs, xr, atol=1e-8, rtol=0)
        np.testing.assert_allclose(Ps, Pr, atol=1e-8, rtol=0)
    else:                                     # CV: the textbook smoother of the CV model
        F, Q = np.empty((9, 9)), np.empty((9, 9))
        x, P = out[0].copy(), [None] * len(t)
        for k in range(len(t)):
            P[k] = np.zeros((9, 9))
            P[k][np.tril_indices(9)] = out[1][k]
            P[k] = P[k] + np.tril(P[k], -1).T
        for k in range(len(t) - 2, -1, -1):
            model_matrices(CV, t[k + 1] - t[k], args[11][k + 1], 0.0, F, Q)
            Pp = F @ P[k] @ F.T + Q
            C = P[k] @ F.T @ np.linalg.pinv(Pp)
            x[k] = out[0][k] + C @ (x[k + 1] - F @ out[0][k])
        np.testing.assert_allclose(xs[:, :6], x[:, :6], atol=1e-6, rtol=0)


def test_model_probabilities_follow_the_turn_and_the_smoother_helps():
    """CV / CA / CT on the straight-turn-straight flight: the smoothed CT probability leads
    during the turn and CV outside it; the IMM smoother beats the single CA smoother."""
    t, pos = _turn()
    args = _rows(t, pos, seed=2)
    codes = np.array([CV, CA, CT])
    lam = imm_generator(3, 10.0)
    out = imm_forward(*args, codes, lam, np.full(3, 1.0 / 3.0))
    xs, _, mus = imm_smooth(t, out[2], out[3], out[4], out[5], args[11], codes, lam, 1e-3)
    turn = (t > 23.0) & (t < 38.0)
    straight = (t > 45.0) | ((t > 3.0) & (t < 18.0))
    assert mus[turn, 2].mean() > 0.5 and mus[straight, 0].mean() > 0.6
    ek = _ekf(args)
    xr = rts_smooth(t, ek.xf.copy(), ek.Pf.copy(), args[11])[0]

    def rmse(x):
        return float(np.sqrt(((x[:, :3] - pos) ** 2).sum(axis=1).mean()))

    assert rmse(xs) < 0.97 * rmse(xr)


def test_a_component_of_zero_weight_never_reaches_the_mixture() -> None:
    """Kim's smoother leaves a pruned model's entries unset (its workspace may hold any bits,
    NaN included): the combination must skip it, not multiply it by zero. (A NaN there made
    1 run in 6 of a MISTRAM-only IMM sortie write a NaN trajectory.)"""
    from rangeproc.estimation.imm_models import combine
    X = np.array([[1.0, 2.0], [np.nan, np.inf]])
    P = np.stack([np.eye(2), np.full((2, 2), np.nan)])
    x, out, dx = np.empty(2), np.empty((2, 2)), np.empty(2)
    combine(X, P, np.array([1.0, 0.0]), x, out, dx)
    np.testing.assert_array_equal(x, [1.0, 2.0])
    np.testing.assert_array_equal(out, np.eye(2))


def test_the_combined_covariance_is_computed_only_when_asked():
    """By default the forward filter leaves out the combined filtered covariance (Kim's
    smoother and the pipeline read the models' moments): every other output keeps its bits
    (the combined mean is summed as ``combine`` sums it), and when asked for, ``Pf`` is the
    moment-matched mixture of the models' covariances."""
    t, pos = _turn()
    args = _rows(t, pos, seed=2)
    codes = np.array([CV, CA, CT])
    lam = imm_generator(3, 10.0)
    lean = imm_forward(*args, codes, lam, np.full(3, 1.0 / 3.0))
    full = imm_forward(*args, codes, lam, np.full(3, 1.0 / 3.0), True)
    assert lean[1].shape == (0, 45) and full[1].shape == (len(t), 45)
    for a, b in zip(lean[:1] + lean[2:], full[:1] + full[2:]):
        np.testing.assert_array_equal(a, b)
    il, jl = np.tril_indices(9)
    for k in (0, 250, len(t) - 1):
        P = np.zeros((3, 9, 9))
        P[:, il, jl] = full[3][k]
        P = P + np.tril(P, -1).transpose(0, 2, 1)
        dx = full[2][k] - full[0][k]
        ref = np.einsum("j,jab->ab", full[4][k], P + dx[:, :, None] * dx[:, None, :])
        np.testing.assert_allclose(full[1][k], ref[il, jl], rtol=1e-12, atol=1e-12 * ref.max())


def _radar_rows(n: int, p0: float, seed: int = 5) -> tuple:
    """imm_forward's 16 leading arguments for a radar at the origin (range sigma 5 m, angles
    2e-4 rad: rows whose variances mix 25 m^2 with 4e-8 rad^2) on a climbing circle 20 km
    out, 16 rows a second, gating off; prior position variance ``p0`` (m^2), velocity
    ``p0 / 100``, acceleration ``p0 / 1e4``."""
    from rangeproc.models.measurement import SPHERICAL
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 16.0
    ang = 250.0 / 20e3 * t + 2.0
    e, nn, u = 20e3 * np.sin(ang), 20e3 * np.cos(ang), 5e3 + 300.0 * np.sin(0.01 * t)
    rho = np.hypot(e, nn)
    sig = np.array([5.0, 2e-4, 2e-4])
    z = np.full((n, 6), np.nan)
    z[:, :3] = np.column_stack([np.hypot(rho, u), np.arctan2(e, nn), np.arctan2(u, rho)])
    z[:, :3] += rng.normal(0.0, sig, (n, 3))
    sigma = np.ones((n, 6))
    sigma[:, :3] = sig
    x0 = np.array([e[0], nn[0], u[0], 250.0 * np.cos(2.0), -250.0 * np.sin(2.0), 3.0, 0, 0, 0])
    x0 = x0 + rng.normal(0.0, [30.0] * 3 + [10.0] * 3 + [1.0] * 3)
    return (t, np.arange(n), np.full(n, SPHERICAL), z, sigma, np.zeros((n, 3)),
            np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64), x0,
            np.diag([p0] * 3 + [p0 / 1e2] * 3 + [p0 / 1e4] * 3), np.full(n, 1.0),
            np.full(7, np.inf), 0, 1.0, np.empty((0, 9)))


def _rel_to_joseph(P: np.ndarray, Pj: np.ndarray) -> float:
    """Largest difference of packed covariances (E, 45), each entry over
    ``sqrt(Pj_ii Pj_jj)`` (the correlation scale: near-zero cross terms are not inflated)."""
    il, jl = np.tril_indices(9)
    scale = np.sqrt(Pj[:, il * (il + 3) // 2] * Pj[:, jl * (jl + 3) // 2])
    return float((np.abs(P - Pj) / scale).max())


@pytest.mark.parametrize("p0", [1e4, 1e6])
def test_standard_form_agrees_with_joseph_on_radar_rows(p0):
    """The IMM's models update in the standard form ``P - K H P`` (re-symmetrised), the single
    filter in the Joseph form. On radar rows (25 m^2 against 4e-8 rad^2) from a prior of up to
    (1 km)^2, 4e4 times the range variance, the one-model IMM's covariances agree with the
    Joseph-form EKF's to 1e-9 of their correlation scale, its states to 1e-9 of their sigma,
    and every covariance (the model's and the combined) is positive definite. Negative
    control: the EKF on angles 1e-7 relative noisier is more than 1e-9 away."""
    args = _radar_rows(4000, p0)
    out = imm_forward(*args, np.array([CA]), np.zeros((1, 1)), np.ones(1), True)
    ek = _ekf(args)
    diag = [i * (i + 3) // 2 for i in range(9)]
    assert _rel_to_joseph(out[1], ek.Pf) < 1e-9
    assert _rel_to_joseph(out[3][:, 0], ek.Pf) < 1e-9
    assert (np.abs(out[0] - ek.xf) / np.sqrt(ek.Pf[:, diag])).max() < 1e-9
    il, jl = np.tril_indices(9)
    for packed in (out[1], out[3][:, 0]):
        P = np.zeros((len(packed), 9, 9))
        P[:, il, jl] = packed
        np.linalg.cholesky(P + np.tril(P, -1).transpose(0, 2, 1))   # raises if not PD
    noisier = list(args)
    noisier[4] = args[4] * (1.0 + 1e-7)
    assert _rel_to_joseph(_ekf(tuple(noisier)).Pf, ek.Pf) > 1e-9
