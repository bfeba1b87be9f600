"""The IMM interaction is written once (``estimation.imm_models``): the compiled form of the
fusion's IMM and the numpy form of the plot tracker give the same bits, FilterPy's IMM mixes
alike, and the plot tracker's IMM prediction is the fusion's (switching, mixing, CV model)."""
import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter
from scipy.linalg import expm

from rangeproc.estimation.imm_models import (
    CV,
    dense_predict,
    mix,
    mix_moments,
    model_matrices,
    switch_matrix,
    uniform_switch_matrix,
)
from rangeproc.fusion.passes import imm_generator
from rangeproc.tracking import plot_tracker as pt


def _tracks(K: int, r: int, n: int, seed: int):
    """K tracks of r models: states (K, r, n), covariances (K, r, n, n), probabilities (K, r),
    switch matrices (K, r, r) of random steps."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(K, r, n)) * 30.0
    A = rng.normal(size=(K, r, n, n))
    P = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    mu = rng.uniform(size=(K, r))
    mu /= mu.sum(axis=1, keepdims=True)
    return X, P, mu, uniform_switch_matrix(rng.uniform(0.0, 20.0, K), r, 7.0)


def test_numpy_mixing_is_the_compiled_mixing_bit_for_bit():
    K, r, n = 40, 3, 9
    X, P, mu, Pi = _tracks(K, r, n, seed=1)
    c, X0, P0 = mix_moments(Pi, mu, X, P)
    cc, w, XX, PP, dx = np.empty(r), np.empty(r), np.empty((r, n)), np.empty((r, n, n)), \
        np.empty(n)
    for k in range(K):
        mix(Pi[k], mu[k], X[k], P[k], cc, w, XX, PP, dx)
        np.testing.assert_array_equal(cc, c[k])
        np.testing.assert_array_equal(XX, X0[k])
        np.testing.assert_array_equal(PP, P0[k])


def test_mixing_equals_filterpy_imm_estimator():
    """FilterPy's IMMEstimator with identity models (F = I, Q = 0): after its predict each
    filter holds its mixed start and ``cbar`` the predicted model probabilities."""
    K, r, n = 5, 2, 4
    X, P, mu, Pi = _tracks(K, r, n, seed=2)
    c, X0, P0 = mix_moments(Pi, mu, X, P)
    for k in range(K):
        filters = []
        for j in range(r):
            kf = KalmanFilter(dim_x=n, dim_z=1)
            kf.x, kf.P, kf.Q = X[k, j].copy(), P[k, j].copy(), np.zeros((n, n))
            filters.append(kf)
        imm = IMMEstimator(filters, mu[k].copy(), Pi[k])
        imm.predict()
        np.testing.assert_allclose(imm.cbar, c[k], rtol=1e-14)
        for j in range(r):
            np.testing.assert_allclose(filters[j].x, X0[k, j], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(filters[j].P, P0[k, j], rtol=1e-12, atol=1e-12)
    # negative control: without the spread of the means the covariances are not FilterPy's
    without = np.einsum("kij,kide->kjde", Pi * mu[:, :, None] / c[:, None, :], P)
    assert np.abs(without - P0).max() > 1.0


def test_a_model_of_zero_weight_never_reaches_the_mixture():
    """A model no track can switch from (weight 0) adds nothing, even where its state is not
    a number: the numpy form skips it as the compiled ``combine`` does."""
    X = np.array([[[1.0, 2.0], [np.nan, np.inf]]])
    P = np.stack([np.eye(2), np.full((2, 2), np.nan)])[None]
    Pi = np.array([[[1.0, 0.0], [0.3, 0.7]]])
    c, X0, P0 = mix_moments(Pi, np.array([[1.0, 0.0]]), X, P)
    np.testing.assert_array_equal(X0[0, 0], [1.0, 2.0])
    np.testing.assert_array_equal(P0[0, 0], np.eye(2))
    np.testing.assert_array_equal(c, [[1.0, 1e-300]])


@pytest.mark.parametrize("r", [2, 3])
def test_uniform_switch_matrix_is_expm_of_the_generator(r):
    lam = imm_generator(r, 7.0)
    out, work = np.empty((r, r)), np.empty((2, r, r))
    dt = np.array([0.01, 0.5, 30.0, -2.0])
    got = uniform_switch_matrix(dt, r, 7.0)
    for k, d in enumerate(dt):
        np.testing.assert_allclose(got[k], expm(lam * abs(d)), rtol=0, atol=1e-14)
        switch_matrix(lam, abs(d), out, work)
        np.testing.assert_allclose(got[k], out, rtol=0, atol=1e-13)


def test_plot_tracker_prediction_is_the_fusion_imm_prediction():
    """The plot tracker's IMM step over K (track, plot) pairs equals, pair by pair, the fusion
    IMM's compiled pieces: the switch matrix of the generator, the mixing, and each model's CV
    prediction (9 states, position-velocity block) with the tracker's PSD."""
    K, M = 12, len(pt.MODEL_PSD)
    rng = np.random.default_rng(4)
    X6, P6, mu, _ = _tracks(K, M, 6, seed=3)
    X6[..., 3:] = rng.uniform(-300.0, 300.0, (K, M, 3))     # slow boats to fast jets
    dt = rng.uniform(0.5, 12.0, K)
    c, xp, Pp = pt._imm_predict(X6, P6, mu, dt)
    lam = imm_generator(M, pt.MODEL_SOJOURN)
    Pi, work = np.empty((M, M)), np.empty((2, M, M))
    cc, w, dx = np.empty(M), np.empty(M), np.empty(9)
    F, Q, xt, T = np.empty((9, 9)), np.empty((9, 9)), np.empty(9), np.empty((9, 9))
    for k in range(K):
        X9, P9 = np.zeros((M, 9)), np.tile(np.eye(9), (M, 1, 1))
        X9[:, :6], P9[:, :6, :6] = X6[k], P6[k]
        X0, P0 = np.empty((M, 9)), np.empty((M, 9, 9))
        switch_matrix(lam, dt[k], Pi, work)
        mix(Pi, mu[k], X9, P9, cc, w, X0, P0, dx)
        np.testing.assert_allclose(cc, c[k], rtol=1e-13)
        for m, q in enumerate(pt.MODEL_PSD):
            if q == pt.MANOEUVRE_PSD:
                q = pt.manoeuvre_psd(X0[None, m, 3:6], P0[None, m, 3:6, 3:6])[0]
            model_matrices(CV, dt[k], q, 0.0, F, Q)
            dense_predict(F, Q, X0[m], P0[m], xt, T)
            np.testing.assert_allclose(X0[m, :6], xp[k, m], rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(P0[m, :6, :6], Pp[k, m], rtol=1e-11, atol=1e-7)
