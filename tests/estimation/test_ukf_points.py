"""The unscented moments reuse the centre's h at sigma points that move no position.

On a row measuring only position components (range, angles; a Cartesian position) the points
of the lower Cholesky factor's columns 3.. keep the centre's position, and
``moments.ukf_moments`` copies the centre's ``h`` there instead of evaluating it. Checked
against ``h`` evaluated at every point (``measure_py``), and for the moments' bits: a row
that also measures a range rate evaluates every point, and its position components must give
the same bits as the row without it.
"""
import numpy as np
import pytest

from rangeproc.estimation.moments import ukf_moments
from rangeproc.estimation.update import row_workspace
from rangeproc.models.measurement import CARTESIAN, N_COMPONENTS, SPHERICAL, measure_py

UKF = np.array([1.0, 2.0, -6.0])


def _moments(model: int, idx: list[int], seed: int = 3):
    """(y, C, Z) of the components ``idx`` and each point's h (19, 6) with the points."""
    rng = np.random.default_rng(seed)
    n = 9
    x = np.array([-3e3, 12e3, 2e3, 40.0, -150.0, 5.0, 1.0, -2.0, 0.5])
    A = rng.standard_normal((n, n))
    P = A @ A.T + np.diag([400.0] * 3 + [25.0] * 3 + [1.0] * 3)
    s, sv, Qr = np.array([100.0, -50.0, 10.0]), np.zeros(3), np.eye(3)
    z = np.full(N_COMPONENTS, np.nan)
    z[:4] = [12.5e3, 2.9, 0.16, -120.0]
    ws = row_workspace(n)
    h, H, y6, y, idx_a = ws[0], ws[1], ws[2], ws[3], ws[4]
    C, Z, L, Zs, xs = ws[7], ws[8], ws[19], ws[20], ws[21]
    for a, c in enumerate(idx):
        idx_a[a] = c
    assert ukf_moments(model, z, s, sv, Qr, x, P, idx_a, len(idx), UKF, L, Zs, xs, h, H, y6,
                       y, C, Z)
    points = [x] + [x + L[:, c] for c in range(n)] + [x - L[:, c] for c in range(n)]
    h_all = np.array([measure_py(model, p, s, sv, Qr)[0] for p in points])
    m = len(idx)
    return y[:m].copy(), C[:m].copy(), Z[:m, :m].copy(), Zs.copy(), h_all


@pytest.mark.parametrize("model", [SPHERICAL, CARTESIAN])
@pytest.mark.parametrize("idx", [[0, 1, 2], [1, 2], [0, 1, 2, 3], [3]])
def test_every_point_has_its_own_h(model, idx):
    *_, Zs, h_all = _moments(model, idx)
    got, want = Zs[:, idx], h_all[:, idx]
    if model == SPHERICAL and 1 in idx:                  # azimuths unwrapped around point 0
        a = idx.index(1)
        want[:, a] = want[0, a] + (want[:, a] - want[0, a] + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-12)


@pytest.mark.parametrize("model", [SPHERICAL, CARTESIAN])
def test_copied_points_give_the_evaluated_bits(model):
    y3, C3, Z3, *_ = _moments(model, [0, 1, 2])          # 12 of 19 points copied
    y4, C4, Z4, *_ = _moments(model, [0, 1, 2, 3])       # every point evaluated
    assert np.array_equal(y3, y4[:3])
    assert np.array_equal(C3, C4[:3])
    assert np.array_equal(Z3, Z4[:3, :3])
