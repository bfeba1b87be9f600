"""Refraction removed from rows: measurements made with the refraction model's own forward
direction (``frames.refraction.apparent``) come back to the geometric values."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.frames.refraction import apparent
from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.refraction_rows import RefractionSettings, refraction_corrections
from rangeproc.models.measurement import SPHERICAL, measure_py


@pytest.mark.parametrize("model", ["4/3", "exponential"])
def test_refracted_rows_return_to_the_geometric_angles_and_range(model):
    rng = np.random.default_rng(3)
    n = 200
    targets = np.column_stack([rng.uniform(-60e3, 60e3, n), rng.uniform(5e3, 80e3, n),
                               rng.uniform(200.0, 12e3, n)])
    site = np.array([100.0, -200.0, 30.0])
    a = empty_rows(n, SPHERICAL)
    truth = np.zeros((n, 3))
    xs = np.zeros((n, 9))
    xs[:, :3] = targets
    for i in range(n):
        h, _ = measure_py(SPHERICAL, xs[i], site, np.zeros(3), np.eye(3))
        truth[i] = h[:3]
    el_app, r_app = apparent(truth[:, 2], truth[:, 0], 700.0 + site[2], model, 313.0)
    a["z"][:, :3] = np.column_stack([r_app, truth[:, 1], el_app])
    a["s"][:] = site
    rows = SensorRows(t=np.arange(n, dtype=float), source_row=np.arange(n),
                      station=np.full(n, -1), track=np.full(n, -1), **a)
    batch = merge([(0, rows)], ("R1",))
    out = refraction_corrections(batch, xs, np.arange(n), RefractionSettings(
        model, (313.0,), (False,), 700.0))
    assert np.abs(el_app - truth[:, 2]).max() > 1e-3            # refraction was there
    np.testing.assert_allclose(out.z[:, 2], truth[:, 2], atol=2e-6)
    np.testing.assert_allclose(out.z[:, 1], truth[:, 1], atol=1e-9)
    np.testing.assert_allclose(out.z[:, 0], truth[:, 0], atol=0.02)
    # a sensor without refractivity is left alone
    same = refraction_corrections(batch, xs, np.arange(n), RefractionSettings(
        model, (0.0,), (False,), 700.0))
    assert same is batch
