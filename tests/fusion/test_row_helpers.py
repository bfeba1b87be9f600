"""Row helpers of the passes and the start, rewritten for speed: the same values as the
rules they implement (``fusion.passes.component_use``, ``fusion.initialise.fixes_at``)."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.initialise import fix_rows, fixes_at, position_fixes
from rangeproc.fusion.passes import component_use
from rangeproc.models.measurement import CARTESIAN, SPHERICAL


def test_component_use_reads_bit_c_of_each_rows_mask():
    rng = np.random.default_rng(5)
    z = rng.normal(size=(2000, 6))
    z[rng.random(z.shape) < 0.3] = np.nan
    for dtype, high in ((np.int64, 1 << 40), (np.int32, 1 << 20), (np.uint8, 255)):
        rejected = rng.integers(0, high, 2000).astype(dtype)
        rejected[:10] = 0
        expected = np.isfinite(z) & ((rejected[:, None] >> np.arange(6)) & 1 == 0)
        got = component_use(z, rejected)
        assert got.dtype == bool and np.array_equal(got, expected)
        # a control: bit c rejects component c (and only it)
        one = np.zeros(2000, dtype=dtype)
        one[0] = 1 << 2
        use = component_use(np.zeros((2000, 6)), one)
        assert not use[0, 2] and use[0, [0, 1, 3, 4, 5]].all() and use[1:].all()


def test_fixes_of_a_subset_of_rows_are_those_of_every_row():
    rng = np.random.default_rng(6)
    parts = []
    for i, model in enumerate((CARTESIAN, SPHERICAL)):
        n = 300
        a = empty_rows(n, model)
        if model == CARTESIAN:
            a["z"][:, :3] = rng.normal(0.0, 5e3, (n, 3))
            a["sigma"][:, :3] = 3.0
        else:
            a["z"][:, :3] = np.column_stack([rng.uniform(1e3, 5e4, n), rng.uniform(-3, 3, n),
                                             rng.uniform(0.01, 0.5, n)])
            a["z"][rng.random(n) < 0.2, 2] = np.nan          # rows without elevation
            a["sigma"][:, :3] = (7.0, 1e-3, 1e-3)
            a["s"][:] = (100.0, -200.0, 30.0)
        parts.append((i, SensorRows(t=np.sort(rng.uniform(0, 60, n)), source_row=np.arange(n),
                                    station=np.full(n, -1), track=np.full(n, -1), **a)))
    batch = merge(parts, ("G1", "R1"))
    rows, pos, acc = position_fixes(batch)
    r, cart, plane = fix_rows(batch)
    assert np.array_equal(rows, r) and len(rows) < len(batch)
    take = np.sort(rng.choice(len(rows), 40, replace=False))
    p, a = fixes_at(batch, rows[take], cart[take], plane[take])
    assert np.array_equal(p, pos[take]) and np.array_equal(a, acc[take])
