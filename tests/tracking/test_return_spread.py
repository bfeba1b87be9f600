"""The spread of an extended object's returns within a scan: further returns are the free
plots near the object's plot of the same scan, their pooled spread recovers a hull's, and a
sensor with one plot per object a scan (a radar, an aircraft) gives none."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.fusion.reference_point import spread_extent
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.return_spread import further_returns, object_spreads, scan_spread

GATE = float(chi2_ppf(0.9999, 3))


def _scans(seed: int, n_scans: int, length: float, per_scan: int, noise: float = 0.3,
           stated: float = 6.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A ship of ``length`` m heading east at 100 m north of a lidar, ``per_scan`` returns a
    scan drawn uniformly along its hull (plus ``noise`` m), the first of each held by the
    object "O1", and one clutter plot a scan 400 m away; stated sigma ``stated`` m per axis
    (the returns' spread against GNSS, spanning the hull). Returns p (N, 3), R (N, 3, 3),
    scan (N,), owner (N,)."""
    g = np.random.default_rng(seed)
    p, scan, owner = [], [], []
    for s in range(n_scans):
        x0 = 3.0 * s * 0.1                                  # 3 m/s at 10 Hz
        along = g.uniform(-0.5, 0.5, per_scan) * length
        for k, a in enumerate(along):
            p.append([x0 + a + g.normal(0, noise), 100.0 + g.normal(0, noise), 0.0])
            scan.append(s)
            owner.append("O1" if k == 0 else "")
        p.append([x0 + 400.0, 100.0, 0.0])
        scan.append(s)
        owner.append("")
    n = len(p)
    R = np.tile(np.diag([stated**2, stated**2, 1.0]), (n, 1, 1))
    return np.array(p), R, np.array(scan), np.array(owner, dtype=object)


def test_the_free_plots_of_the_hull_are_its_further_returns():
    p, R, scan, owner = _scans(1, 50, length=30.0, per_scan=5)
    further = further_returns(p, R, scan, owner, GATE)
    hull = (owner == "") & (np.abs(p[:, 0] - 0.3 * scan) < 100.0)
    assert (further[hull] == "O1").mean() > 0.95
    assert (further[~hull & (owner == "")] == "").all()      # the clutter 400 m off
    assert (further[owner == "O1"] == "").all()              # its own plots are not further


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_hulls_spread_is_recovered(seed):
    p, R, scan, owner = _scans(seed, 200, length=30.0, per_scan=5)
    S = object_spreads(p, R, scan, owner, GATE)["O1"]
    assert math.sqrt(np.linalg.eigvalsh(S)[-1]) == pytest.approx(30.0 / math.sqrt(12.0),
                                                                  rel=0.15)
    e = spread_extent(S)                                      # two points of one hull
    assert e.along == e.across == pytest.approx(2.0 * np.linalg.eigvalsh(S)[-1])


def test_one_plot_a_scan_gives_none():
    # negative control: a radar's one plot per object a scan (the same hull): nothing to pool
    p, R, scan, owner = _scans(4, 200, length=30.0, per_scan=1)
    assert object_spreads(p, R, scan, owner, GATE) == {}
    assert spread_extent(None).along == 0.0


def test_a_point_target_spreads_by_its_noise_only():
    # several returns of a point (a lidar on a buoy): the spread is the noise, not a hull
    p, R, scan, owner = _scans(5, 200, length=0.0, per_scan=4, noise=0.3)
    S = scan_spread(p, scan, (owner == "O1") | (further_returns(p, R, scan, owner, GATE)
                                                 == "O1"))
    assert math.sqrt(np.linalg.eigvalsh(S)[-1]) == pytest.approx(0.3, rel=0.2)
