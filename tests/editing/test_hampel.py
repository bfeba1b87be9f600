"""Hampel pre-edit: wild values removed with reason ``pre-edit``, good data left alone."""
from __future__ import annotations

from types import MappingProxyType

import numpy as np
import pytest

from rangeproc.editing.hampel import hampel_flags, noise_floor, pre_edit, wild_values
from rangeproc.editing.record import EditRecord
from rangeproc.io.logs import SensorLog


def series_flags(t, x, k=7, threshold=6.0):
    return hampel_flags(np.asarray(t, float), np.asarray(x, float), k, threshold,
                        noise_floor(np.asarray(x, float)))


def test_noise_floor_sees_the_noise_not_a_quadratic_trend() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(20_000) * 0.05
    x = 3.0 * t ** 2 - 400.0 * t + rng.normal(0.0, 2.0, t.size)
    assert noise_floor(x) == pytest.approx(2.0, rel=0.05)


def test_clean_fast_ramp_and_slow_hard_turn_are_not_edited() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(20_000) * 0.05                    # range closing at 300 m/s, 20 Hz, 5 m noise
    assert not series_flags(t, 40_000.0 - 300.0 * t + rng.normal(0, 5.0, t.size)).any()
    t = np.arange(3_000) * 1.0                       # 1 Hz fixes of a 6 g turn at 250 m/s
    omega = 60.0 / 250.0
    x = 250.0 / omega * np.sin(omega * t) + rng.normal(0, 3.0, t.size)
    assert not series_flags(t, x).any()


def test_spikes_and_a_run_at_the_start_are_edited_and_nothing_else() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(2_000) * 0.05
    x = 30_000.0 + 250.0 * t + 0.5 * t ** 2 + rng.normal(0, 5.0, t.size)
    wild = [*range(6), 300, 301, 1200, 1999]         # a 6-sample run at track start, a pair,
    x[wild] += np.array([200.0] * 6 + [-150.0, 180.0, 90.0, -300.0])   # spikes, the last row
    assert np.flatnonzero(series_flags(t, x)).tolist() == wild


def test_quantised_readings_are_not_edited() -> None:
    t = np.arange(5_000) * 0.1
    x = np.round(0.3 * np.sin(0.01 * t), 2)          # steps of one quantum, mostly constant
    assert not series_flags(t, x).any()


def test_a_series_shorter_than_one_window_is_left_alone() -> None:
    t = np.arange(10) * 1.0
    x = np.zeros(10)
    x[5] = 1e6
    assert not series_flags(t, x).any()


def radar(r, az, track_id=None) -> SensorLog:
    n = len(r)
    cols = {"range": np.asarray(r, float), "azimuth": np.asarray(az, float),
            "elevation": np.full(n, 0.2), "range_rate": np.full(n, np.nan)}
    return SensorLog(sensor_id="R1", kind="radar", time=np.arange(n) * 0.05,
                     columns=MappingProxyType(cols), row=np.arange(1, n + 1),
                     track_id=track_id, station=None, n_read=n)


def test_pre_edit_records_each_component_and_skips_plots() -> None:
    rng = np.random.default_rng(4)
    n = 400
    r = 20_000.0 + 5.0 * rng.standard_normal(n)
    az = np.mod(np.linspace(6.2, 6.4, n), 2 * np.pi) + 1e-4 * rng.standard_normal(n)
    r[[10, 200]] += 500.0
    az[100] += 0.05                                  # across the 0/2pi wrap: unwrapped first
    rec = EditRecord()
    out = pre_edit(radar(r, az), rec)
    assert np.flatnonzero(np.isnan(out.columns["range"])).tolist() == [10, 200]
    assert np.flatnonzero(np.isnan(out.columns["azimuth"])).tolist() == [100]
    assert rec.counts("R1") == {"pre-edit": 3}
    assert [(e.reason, e.component, e.rows.tolist()) for e in rec.edits] == [
        ("pre-edit", "range", [11, 201]), ("pre-edit", "azimuth", [101])]
    plots = np.full(n, -1)
    assert not wild_values(radar(r, az, plots), "range", 7, 6.0).any()
    rec = EditRecord()
    log = radar(r, az)
    assert pre_edit(log, rec, half_width=0) is log and not rec.edits


def test_series_are_per_track() -> None:
    rng = np.random.default_rng(5)
    n = 300
    track = np.repeat([1, 2], n // 2)
    r = np.where(track == 1, 10_000.0, 50_000.0) + 5.0 * rng.standard_normal(n)
    r[::2] += 0.0                                    # two interleaved objects would look wild
    order = np.argsort(np.tile(np.arange(n // 2), 2), kind="stable")
    log = radar(r[order], np.full(n, 1.0), track[order])
    assert not wild_values(log, "range", 7, 6.0).any()


def test_a_noise_burst_is_left_to_the_smoother() -> None:
    rng = np.random.default_rng(6)
    t = np.arange(3_000) * 0.05
    noise = rng.normal(0, 5.0, t.size)
    noise[1000:1060] *= 15.0                         # 3 s of jamming: 15x the noise
    x = 20_000.0 - 200.0 * t + noise
    x[2000] += 400.0                                 # a wild value outside the burst
    assert np.flatnonzero(series_flags(t, x)).tolist() == [2000]


def _flags_by_sorting_every_window(t, x, half_width, threshold, floor):
    """The Hampel identifier written directly (each window's slopes and values sorted anew),
    the reference for the kernel's sliding sorted window of slopes."""
    from rangeproc.editing.hampel import BURST_RATIO, QUARTILE_TO_SIGMA
    from rangeproc.editing.robust import MAD_TO_SIGMA

    n, w = len(x), 2 * half_width + 1
    out = np.zeros(n, dtype=bool)
    if n < w:
        return out
    step = max(1, half_width // 2)

    def median(a):
        a = np.sort(a)
        h = len(a) // 2
        return a[h] if len(a) % 2 else 0.5 * (a[h - 1] + a[h])

    for i in range(n):
        lo = min(max(i - half_width, 0), n - w)
        j = np.arange(lo, lo + w - step)
        dt = t[j + step] - t[j]
        ok = dt > 0.0
        v = median((x[j + step][ok] - x[j][ok]) / dt[ok]) if ok.any() else 0.0
        vals = x[lo:lo + w] - v * (t[lo:lo + w] - t[i])
        centre = median(vals)
        if abs(x[i] - centre) <= threshold * floor:
            continue
        dev = np.sort(np.abs(vals - centre))
        spread = MAD_TO_SIGMA * median(dev)
        quiet = QUARTILE_TO_SIGMA * dev[(w - 1) // 4] <= BURST_RATIO * floor
        out[i] = quiet and abs(x[i] - centre) > threshold * max(spread, floor)
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_sliding_window_kernel_flags_what_sorting_every_window_flags(seed):
    """Repeated times (dt = 0 slopes left out), tied (quantised) values, wild points, a ramp
    and a step: the same flags as the direct definition, row by row."""
    rng = np.random.default_rng(seed)
    n = 3000
    t = np.cumsum(rng.choice([0.0, 0.01, 0.02, 0.05], n, p=[0.05, 0.6, 0.3, 0.05]))
    x = 3.0 * t + np.round(rng.normal(0.0, 1.0, n), 1)          # ties from the rounding
    x[n // 2:] += 40.0                                          # a step
    wild = rng.choice(n, 60, replace=False)
    x[wild] += rng.choice([-1, 1], 60) * rng.uniform(8.0, 50.0, 60)
    for k in (3, 7):
        got = hampel_flags(t, x, k, 6.0, 0.5)
        ref = _flags_by_sorting_every_window(t, x, k, 6.0, 0.5)
        np.testing.assert_array_equal(got, ref)
        assert got.sum() > 20
