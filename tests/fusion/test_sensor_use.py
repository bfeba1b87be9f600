"""A sensor seen by several objects: its summary counts are summed over the objects and its
noise and bias combined (fusion.sensor_use), not the last object's."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from rangeproc.config import SensorSettings
from rangeproc.fusion.sensor_use import ObjectUse, sensor_use
from rangeproc.models.measurement import SPHERICAL


def _use(tid: str, n: int, sigma_range: float, rejected_az: int, gate_rows: int,
         seed: int) -> ObjectUse:
    """Object ``tid``: ``n`` rows of sensor 0 (range, azimuth, elevation measured) and 5 rows
    of another sensor 1; ``rejected_az`` rows with the azimuth rejected, ``gate_rows`` rows
    with nothing used; range residuals N(0, sigma_range)."""
    rng = np.random.default_rng(seed)
    m = n + 5
    sensor = np.r_[np.zeros(n, np.int64), np.ones(5, np.int64)]
    z = np.full((m, 6), np.nan)
    z[:, :3] = 1.0
    used = np.zeros((m, 6), bool)
    used[:, :3] = True
    used[:rejected_az, 1] = False
    used[n - gate_rows:n, :3] = False
    res = np.full((m, 6), np.nan)
    res[:, 0] = rng.normal(0.0, sigma_range, m) + (1.0 if tid == "T1" else -1.0)
    res[:, 1:3] = rng.normal(0.0, 1e-4, (m, 2))
    batch = SimpleNamespace(sensor=sensor, model=np.full(m, SPHERICAL), z=z,
                            t=np.arange(m) * 0.05, sigma=np.full((m, 6), 1.0))
    result = SimpleNamespace(batch=batch, used=used, dof=np.full(m, 3), res=res,
                             noise={(0, 0): sigma_range, (0, 1): 1e-4, (0, 2): 1e-4})
    rejected = np.zeros((n, 4), bool)
    rejected[:rejected_az, 1] = True
    rejected[n - gate_rows:, :3] = True
    residuals = SimpleNamespace(components=("range", "azimuth", "elevation", "range_rate"),
                                rejected=rejected)
    return ObjectUse(tid, result, 0, residuals)


def test_counts_are_summed_and_noise_pooled_over_the_objects():
    s = SensorSettings(id="R1", kind="radar", file=Path("R1.csv"),
                       sigma={"range": 5.0, "azimuth": 1e-4, "elevation": 1e-4})
    a = _use("T1", 300, 3.0, rejected_az=4, gate_rows=2, seed=1)
    b = _use("T2", 100, 9.0, rejected_az=7, gate_rows=1, seed=2)
    out = sensor_use(s, [a, b])
    assert out["n_used"] == 298 + 99
    assert out["n_rejected"] == 3
    assert out["n_partly_rejected"] == 4 + 7
    assert out["n_components_rejected"] == {"range": 3, "azimuth": 4 + 7 + 3, "elevation": 3,
                                            "range_rate": 0}
    # the row-weighted median of the objects' estimates: T1's 3 m (298 of 397 rows), not
    # the last object's 9 m
    assert out["noise"]["range"]["estimated"] == 3.0
    assert out["noise"]["range"]["apriori"] == 5.0
    pooled = np.r_[a.result.res[:298, 0], b.result.res[:99, 0]]
    assert out["bias"]["range"]["median_residual"] == pytest.approx(np.median(pooled))
    assert out["targets"] == ["T1", "T2"] and out["target"] == "T1"
    assert out["by_object"]["T2"]["n_used"] == 99
    assert out["by_object"]["T2"]["noise"]["range"] == 9.0
    assert out["by_object"]["T1"]["median_residual"]["range"] == pytest.approx(
        np.median(a.result.res[:298, 0]))


def test_one_object_gives_its_own_figures_and_no_by_object():
    s = SensorSettings(id="R1", kind="radar", file=Path("R1.csv"))
    a = _use("T1", 50, 2.0, rejected_az=1, gate_rows=0, seed=3)
    out = sensor_use(s, [a])
    assert out["n_used"] == 50 and out["n_partly_rejected"] == 1
    assert out["noise"]["range"]["estimated"] == 2.0
    assert "by_object" not in out


def test_an_object_of_mixed_rows_does_not_decide_the_sensors_noise():
    """Autoferry-like: three objects whose lidar ranges fit to 1 m, and two small objects that
    hold rows of several things (kilometres of residual): the sensor's noise is 1 m, not the
    row-weighted RMS (some 800 m, a unit warning's worth)."""
    from rangeproc.fusion.sensor_use import _pooled

    parts = [(0.93, np.zeros(183)), (0.68, np.zeros(110)), (1.14, np.zeros(44)),
             (2878.0, np.zeros(26)), (1173.0, np.zeros(24))]
    assert _pooled(parts) == 0.93
    rms = np.sqrt(sum(p[1].size * p[0] ** 2 for p in parts) / sum(p[1].size for p in parts))
    assert rms > 500.0                      # what the mean of the variances would have said
    assert _pooled([(2.0, np.zeros(0)), (4.0, np.zeros(0)), (9.0, np.zeros(0))]) == 4.0
    assert _pooled([(None, np.zeros(3))]) is None
