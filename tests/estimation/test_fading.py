"""Strong tracking (seed 001): fading factors, the faded filter, its smoother, and stukf = ukf
when fading cannot trigger."""
import numpy as np
import pytest

from rangeproc.estimation.fading import MAX_FADING, STF_WARMUP, fading_factors
from rangeproc.estimation.forward import EKF, UKF, FilterSettings, run_filter
from rangeproc.estimation.linalg import unpack
from rangeproc.estimation.rts import rts_smooth
from rangeproc.models.measurement import CARTESIAN
from rangeproc.models.motion import ca_transition_py

from conftest import filter_parts

UKF_PARAMS = np.array([1.0, 2.0, -6.0])
STF = np.array([0.95, 3.0, 1.0, 1.0, 1.0])


def _manoeuvre(seed: int = 1, n: int = 300, dt: float = 0.1):
    """Position fixes (1 m noise) of a target that starts a 40 m/s^2 turn at 15 s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    pos = np.zeros((n, 3))
    pos[:, 0] = 100.0 * t + np.where(t > 15.0, 20.0 * (t - 15.0) ** 2, 0.0)
    z = np.full((n, 6), np.nan)
    z[:, :3] = pos + rng.normal(0.0, 1.0, (n, 3))
    x0 = np.zeros(9)
    x0[3] = 100.0
    args = (t, np.arange(n), np.full(n, CARTESIAN), z, np.ones((n, 6)), np.zeros((n, 3)),
            np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64), x0,
            np.eye(9) * 10.0, np.full(n, 1.0), np.full(7, np.inf), 0, 1.0, np.empty((0, 9)))
    return t, pos, args


def _rmse(x: np.ndarray, pos: np.ndarray) -> float:
    return float(np.sqrt(((x[:, :3] - pos) ** 2).sum(axis=1).mean()))


def _full(p: np.ndarray) -> np.ndarray:
    out = np.empty((9, 9))
    unpack(p, out)
    return out


def test_factor_formula_by_hand():
    """c = tr(N) / sum alpha^i M_ii with N = V - beta R - H Q H^T, M = F P F^T H^T H
    (whitened, q = 0 so Q vanishes): one position component, P = diag(4)."""
    G = np.zeros((6, 6))
    G[0, 0] = 1.0                                       # one whitened row observing east
    P = np.eye(9) * 4.0
    lam = np.empty(9)
    stf = np.array([0.95, 2.0, 1.0, 1.0, 3.0])
    assert fading_factors(stf, 10.0, 1, G, P, 0.1, 0.0, lam)
    c = (10.0 - 2.0) / 4.0
    np.testing.assert_allclose(lam, [c] * 6 + [3.0 * c] * 3)
    assert not fading_factors(stf, 1.5, 1, G, P, 0.1, 0.0, lam)     # V below beta R
    np.testing.assert_array_equal(lam, 1.0)
    assert fading_factors(stf, 1e9, 1, G, P, 0.1, 0.0, lam)
    assert lam.max() == MAX_FADING


@pytest.mark.parametrize("method", [EKF, UKF])
def test_fading_follows_the_manoeuvre_and_the_smoother_is_exact(method):
    """Under-modelled process noise (q = 1 against a 40 m/s^2 onset): the faded filter fades at
    the onset and tracks better; its RTS smoother equals the textbook smoother of the model the
    filter ran (P_pred = L^1/2 F P F^T L^1/2 + Q) to 1e-9."""
    t, pos, args = _manoeuvre()
    rows, prior, kw = filter_parts(args)
    plain = run_filter(rows, prior, FilterSettings(method=method, ukf=UKF_PARAMS, **kw))
    xf0, Pf0 = plain.xf, plain.Pf
    out = run_filter(rows, prior, FilterSettings(method=method, ukf=UKF_PARAMS, fading=STF, **kw))
    xf, Pf, fade = out.xf, out.Pf, out.fade
    faded_t = t[fade.max(axis=1) > 1.0]
    assert faded_t.size and faded_t.min() > t[STF_WARMUP]
    assert np.any((faded_t > 15.0) & (faded_t < 17.0))
    assert _rmse(xf, pos) < 0.75 * _rmse(xf0, pos)
    xs, Ps, _ = rts_smooth(t, xf.copy(), Pf.copy(), args[11], True, False, fade)
    xr, Pr = xf.copy(), [_full(p) for p in Pf]
    for k in range(len(t) - 2, -1, -1):
        F, Q = ca_transition_py(t[k + 1] - t[k], args[11][k + 1])
        root = np.sqrt(fade[k + 1])
        P_pred = root[:, None] * (F @ Pr[k] @ F.T) * root[None, :] + Q
        C = Pr[k] @ F.T @ np.linalg.inv(P_pred)
        xr[k] = xf[k] + C @ (xr[k + 1] - F @ xf[k])
        Pr[k] = Pr[k] + C @ (Pr[k + 1] - P_pred) @ C.T
    np.testing.assert_allclose(xs, xr, atol=1e-9)
    np.testing.assert_allclose(np.stack([_full(p) for p in Ps]), np.stack(Pr), atol=1e-9)
    xs0 = rts_smooth(t, xf0.copy(), Pf0.copy(), args[11])[0]
    assert _rmse(xs, pos) < _rmse(xs0, pos)


def test_without_fading_stukf_is_the_ukf():
    """A weakening factor that V can never exceed: the strong-tracking UKF is the UKF to 1e-10
    (same arithmetic, no factor ever differs from 1)."""
    t, pos, args = _manoeuvre(seed=2)
    never = np.array([0.95, 1e300, 1.0, 1.0, 1.0])
    rows, prior, kw = filter_parts(args)
    a = run_filter(rows, prior, FilterSettings(method=UKF, ukf=UKF_PARAMS, fading=never, **kw))
    b = run_filter(rows, prior, FilterSettings(method=UKF, ukf=UKF_PARAMS, **kw))
    np.testing.assert_array_equal(a.fade, 1.0)
    np.testing.assert_allclose(a.xf, b.xf, atol=1e-10, rtol=0)
    np.testing.assert_allclose(a.Pf, b.Pf, atol=1e-10, rtol=0)
