"""Row helpers of the passes, rewritten for speed: the same values as the rules they
implement (``fusion.passes.component_use``)."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.passes import component_use


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

