"""Every selectable filter on a linear-Gaussian case: shapes, no input mutation, and seeded
Monte Carlo NEES of the smoothed position inside chi-square bounds."""
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import chi2

from rangeproc.config import FILTERS, ProcessingSettings
from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_target
from rangeproc.models.measurement import CARTESIAN
from rangeproc.models.motion import ca_transition_py
from rangeproc.stages.fuse import estimator_settings

Q = 4.0             # white-jerk PSD of the truth (m^2/s^5)
SIGMA = 3.0         # position fix noise (m)
DT = 0.5            # s between fixes
STEPS = 160
RUNS = 30
CHECK = np.arange(20, STEPS, 14)     # epochs whose NEES is scored (spaced: nearly independent)


def _case(seed: int):
    """A white-jerk constant-acceleration truth and its position fixes (the filters' model)."""
    rng = np.random.default_rng(seed)
    F, Qm = ca_transition_py(DT, Q)
    x = np.array([0.0, 0.0, 1000.0, 150.0, 20.0, 0.0, 0.0, 0.0, 0.0])
    truth = np.empty((STEPS, 9))
    chol = np.linalg.cholesky(Qm)
    for k in range(STEPS):
        truth[k] = x
        x = F @ x + chol @ rng.normal(size=9)
    a = empty_rows(STEPS, CARTESIAN)
    a["z"][:, :3] = truth[:, :3] + rng.normal(0.0, SIGMA, (STEPS, 3))
    a["sigma"][:, :3] = SIGMA
    t = np.arange(STEPS) * DT
    rows = SensorRows(t=t, source_row=np.arange(STEPS), station=np.full(STEPS, -1),
                      track=np.full(STEPS, -1), **a)
    return merge([(0, rows)], ("G1",)), truth


def _settings(name: str):
    proc = ProcessingSettings(filter=name, process_noise=Q, adapt_noise=False)
    return estimator_settings(SimpleNamespace(processing=proc, sensors=()))


@pytest.mark.parametrize("name", FILTERS)
def test_filter_is_consistent_on_a_linear_gaussian_case(name):
    settings = _settings(name)
    nees = []
    for run in range(RUNS):
        batch, truth = _case(100 + run)
        before = {k: getattr(batch, k).copy() for k in ("t", "z", "sigma", "s", "Qr")}
        res = fuse_target(batch, 1.0 / DT, settings)
        for k, v in before.items():                      # the input is not mutated
            np.testing.assert_array_equal(getattr(batch, k), v)
        assert res.xs.shape == (STEPS, 9) and res.Ps.shape == (STEPS, 45)
        assert res.used.shape == (STEPS, 6) and np.isfinite(res.xs).all()
        for k in CHECK:
            P = np.zeros((9, 9))
            P[np.tril_indices(9)] = res.Ps[k]
            P = P + np.tril(P, -1).T
            e = res.xs[k, :3] - truth[k, :3]
            nees.append(e @ np.linalg.solve(P[:3, :3], e))
    n = len(nees)
    lo, hi = chi2.ppf([0.0005, 0.9995], 3 * n) / n
    assert lo <= np.mean(nees) <= hi, (name, np.mean(nees), lo, hi)
