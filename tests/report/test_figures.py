"""Tests of the PNG report: files written, valid non-blank PNGs, safe names, atomicity,
decimation, edge cases."""
from __future__ import annotations

from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from rangeproc.report import figures as figmod
from rangeproc.report import write_report
from rangeproc.report.common import decimate_indices, merge_sensors, safe_name, save_figure
from rangeproc.report.consistency import window_nis
from rangeproc.report.timeline import used_spans
from rangeproc.results import SensorResiduals, TrackEstimate

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def make_track(rng: np.random.Generator, target_id: str = "T1", k: int = 600,
               t_start: float = 345_600.0, dt: float = 0.1, e0: float = 0.0) -> TrackEstimate:
    """A climbing turn with a coasting gap of n_sensors = 0, on a uniform grid."""
    t = t_start + dt * np.arange(k)
    s = (t - t_start) / max(t[-1] - t_start, 1.0)
    x = np.zeros((k, 9))
    x[:, 0] = e0 + 20_000.0 * np.sin(2.0 * s)
    x[:, 1] = 15_000.0 * (1.0 - np.cos(2.0 * s))
    x[:, 2] = 1_000.0 + 8_000.0 * s
    x[:, 3:6] = np.gradient(x[:, 0:3], t, axis=0) if k > 1 else 250.0
    wobble = 1.0 + 0.3 * np.sin(12.0 * s + rng.uniform(0, 6))[:, None]
    sig = np.column_stack([3.0 + s, 4.0 + s, 8.0 + 2 * s]) * wobble
    P = np.zeros((k, 9, 9))
    P[:, np.arange(3), np.arange(3)] = sig**2
    P[:, np.arange(3, 9), np.arange(3, 9)] = 1.0
    ns = np.repeat(rng.integers(1, 5, size=k // 50 + 1), 50)[:k]
    ns[::10] += 1  # a 1 Hz sensor on the 10 Hz grid
    ns[k // 3: k // 3 + k // 20] = 0
    return TrackEstimate(target_id=target_id, time=t, x=x, P=P, n_sensors=ns.astype(np.int64),
                         lat=np.full(k, 35.0), lon=np.full(k, -117.0), height=x[:, 2] + 700.0)


def make_residuals(rng: np.random.Generator, sensor_id: str, kind: str, n: int,
                   t_start: float = 345_600.0, span: float = 60.0,
                   target_id: str = "T1") -> SensorResiduals:
    """Noise residuals with a gap, wild points (rejected) and an unmeasured component."""
    comps = {"radar": (("range", "azimuth", "elevation", "range_rate"),
                       ("m", "rad", "rad", "m/s"), (6.0, 2e-4, 2e-4, 0.5)),
             "gps": (("e", "n", "u", "ve", "vn", "vu"), ("m",) * 3 + ("m/s",) * 3,
                     (2.5, 2.5, 5.0, 0.15, 0.15, 0.15)),
             "mistram": (("range_rate",), ("m/s",), (0.03,))}[kind]
    names, units, sig = comps
    t = t_start + np.linspace(0.0, span, n, endpoint=False) + rng.normal(0, 1e-3, n)
    t = np.sort(t[rng.random(n) > 0.03])  # regular sampling with dropouts
    t = t[(t < t_start + 0.4 * span) | (t > t_start + 0.5 * span)]  # a gap
    n = t.size
    sigma = np.tile(np.asarray(sig), (n, 1))
    burst = (t > t_start + 0.65 * span) & (t < t_start + 0.75 * span)
    sigma[burst] *= 3.0  # noise burst, followed by the adaptive noise estimate
    res = rng.standard_normal((n, len(names))) * sigma
    rejected = rng.random(n) < 0.02
    res[rejected] *= rng.choice([5.0, 300.0], size=(int(rejected.sum()), 1))
    if kind == "radar":
        res[:, 3] = np.nan  # range_rate not measured
        sigma[:, 3] = np.nan
    nis = np.nansum((res / sigma) ** 2, axis=1)
    station = rng.integers(0, 3, n).astype(np.int64) if kind == "mistram" else None
    return SensorResiduals(sensor_id=sensor_id, kind=kind, target_id=target_id,
                           components=names, units=units, time=t, residual=res, sigma=sigma,
                           rejected=rejected, nis=nis, station=station)


def assert_good_png(path: Path) -> None:
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200
    flat = img.reshape(-1, img.shape[2])
    assert np.unique(flat[:: max(1, flat.shape[0] // 50_000)], axis=0).shape[0] > 10
    assert path.stat().st_size < 400_000


@pytest.fixture()
def scenario() -> tuple[list[TrackEstimate], list[SensorResiduals], dict[str, np.ndarray]]:
    rng = np.random.default_rng(1)
    tracks = [make_track(rng)]
    residuals = [make_residuals(rng, "R1", "radar", 3_000),
                 make_residuals(rng, "S 1/a", "radar", 500),
                 make_residuals(rng, "G1", "gps", 600),
                 make_residuals(rng, "MISTRAM", "mistram", 2_000)]
    ship = np.column_stack([np.linspace(-5e3, 5e3, 50), np.full(50, -8e3), np.zeros(50)])
    sites = {"R1": np.array([12_000.0, 3_000.0, 10.0]), "S_SHIP": ship}
    return tracks, residuals, sites


def test_writes_all_figures_as_valid_pngs(tmp_path: Path, scenario) -> None:
    tracks, residuals, sites = scenario
    seen: list[str] = []
    paths = write_report(tmp_path / "report", tracks, residuals, sites=sites,
                         progress=seen.append)
    names = sorted(p.name for p in paths)
    assert names == sorted(["trajectory.png", "consistency.png", "coverage.png",
                            "residuals_R1.png", "residuals_S_1_a.png", "residuals_G1.png",
                            "residuals_MISTRAM.png"])
    for p in paths:
        assert p.parent == tmp_path / "report"
        assert_good_png(p)
    assert len(seen) == len(paths)
    assert not list((tmp_path / "report").glob("*.tmp"))
    assert not list((tmp_path / "report").glob(".*"))


def test_odd_sensor_ids_give_safe_unique_names() -> None:
    assert safe_name("S 1/a") == "S_1_a"
    assert safe_name("../x") == "x"
    assert safe_name("") == "unnamed"
    names = figmod.residual_file_names(["S 1/a", "S_1_a", "s:1:a", "R1"])
    assert names == ["residuals_S_1_a.png", "residuals_S_1_a_2.png", "residuals_s_1_a_3.png",
                     "residuals_R1.png"]
    assert all("/" not in n and " " not in n for n in names)


def test_exception_midway_leaves_no_temp_file(tmp_path: Path, scenario,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    tracks, residuals, sites = scenario
    calls = {"n": 0}
    real = figmod.plot_residuals

    def fail_second(view, t0, *rest):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        if calls["n"] == 2:
            raise RuntimeError("boom")
        return real(view, t0, *rest)

    monkeypatch.setattr(figmod, "plot_residuals", fail_second)
    with pytest.raises(RuntimeError, match="boom"):
        write_report(tmp_path, tracks, residuals, sites=sites)
    # the figures are drawn by this process and a forked child (costliest first), each
    # failing at its own second residual figure: which figures were finished depends on
    # their timing, but each finished one is whole, the rest absent, and no temporary file
    # is left
    names = sorted(p.name for p in tmp_path.iterdir())
    residual = [n for n in names if n.startswith("residuals_")]
    assert set(names) - set(residual) <= {"trajectory.png", "consistency.png", "coverage.png"}
    assert 1 <= len(residual) <= 2
    for n in names:
        assert_good_png(tmp_path / n)


def test_failure_while_writing_removes_temp_file(tmp_path: Path, scenario,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    from rangeproc.report import common

    tracks, residuals, _ = scenario
    real = common.write_palette_png

    def half_write(rgba, dst):  # type: ignore[no-untyped-def]
        real(rgba, dst)
        Path(dst).write_bytes(Path(dst).read_bytes()[:100])  # truncated, then the disk fills
        raise OSError("disk full")

    monkeypatch.setattr(common, "write_palette_png", half_write)
    (tmp_path / "trajectory.png").write_bytes(b"old")
    with pytest.raises(OSError, match="disk full"):
        write_report(tmp_path, tracks, residuals)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trajectory.png"]
    assert (tmp_path / "trajectory.png").read_bytes() == b"old"


def test_decimation_keeps_every_rejected_point_and_bounds_the_rest() -> None:
    rng = np.random.default_rng(7)
    n = 500_000
    y = rng.standard_normal(n)
    y[rng.random(n) < 0.01] = np.nan
    keep = rng.random(n) < 0.05
    spikes = rng.choice(n, 20, replace=False)
    y[spikes] = 1e3  # unrejected spikes must survive through the bucket extremes
    idx = decimate_indices(y, max_points=20_000, keep=keep)
    assert np.all(np.diff(idx) > 0)
    kept = np.zeros(n, dtype=bool)
    kept[idx] = True
    assert np.all(kept[keep & np.isfinite(y)])
    assert not np.any(kept & ~np.isfinite(y))
    assert (kept & ~keep).sum() <= 20_000
    assert np.all(kept[spikes[~keep[spikes]]])
    small = decimate_indices(np.arange(10.0), max_points=20_000)
    np.testing.assert_array_equal(small, np.arange(10))


def test_window_nis_band_matches_chi_square() -> None:
    from scipy import stats

    t = np.arange(100.0)
    dof = np.where(np.arange(100) % 2 == 0, 3, 1)
    nis = dof.astype(float)
    t_mid, mean, expect, lo, hi = window_nis(t, nis, dof, 10)
    assert t_mid.size == 10
    np.testing.assert_allclose(expect, 2.0)
    np.testing.assert_allclose(mean, 2.0)
    np.testing.assert_allclose(lo, stats.chi2.ppf(0.025, 20) / 10)
    np.testing.assert_allclose(hi, stats.chi2.ppf(0.975, 20) / 10)


def test_used_spans_merge_small_gaps() -> None:
    t = np.concatenate([np.arange(0, 10, 0.1), np.arange(10.15, 20, 0.1), np.arange(30, 31, 0.1)])
    s, e = used_spans(t, gap=0.3)
    np.testing.assert_allclose(s, [0.0, 30.0])
    np.testing.assert_allclose(e, [t[t < 20][-1], t[-1]])


def test_same_sensor_for_two_targets_is_one_figure(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    a = make_residuals(rng, "R1", "radar", 300, target_id="T1")
    b = make_residuals(rng, "R1", "radar", 200, target_id="T2")
    (view,) = merge_sensors([a, b])
    assert view.time.size == a.time.size + b.time.size
    assert np.all(np.diff(view.time) >= 0)
    assert view.targets == ("T1", "T2") and view.group_names == ("T1", "T2")
    tracks = [make_track(rng, "T1"), make_track(rng, "T2", e0=5_000.0)]
    paths = write_report(tmp_path, tracks, [a, b])
    assert sorted(p.name for p in paths) == ["consistency.png", "coverage.png",
                                             "residuals_R1.png", "trajectory.png"]
    for p in paths:
        assert_good_png(p)


def _empty(sensor_id: str) -> SensorResiduals:
    return SensorResiduals(sensor_id=sensor_id, kind="radar", target_id="T1",
                           components=("range", "azimuth"), units=("m", "rad"),
                           time=np.zeros(0), residual=np.zeros((0, 2)), sigma=np.zeros((0, 2)),
                           rejected=np.zeros(0, bool), nis=np.zeros(0))


def test_edge_cases_do_not_crash(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    all_nan = make_residuals(rng, "NAN", "radar", 50)
    all_nan = SensorResiduals(**{**{f: getattr(all_nan, f) for f in all_nan.__slots__},
                                 "residual": np.full_like(all_nan.residual, np.nan),
                                 "nis": np.full(all_nan.time.size, np.nan)})
    one = make_residuals(rng, "ONE", "gps", 1)
    one_rej = SensorResiduals(**{**{f: getattr(one, f) for f in one.__slots__},
                                 "rejected": np.ones(1, bool)})
    cases = {
        "no_tracks": ([], [make_residuals(rng, "R1", "radar", 100)]),
        "nothing": ([], []),
        "one_epoch": ([make_track(rng, k=1)], [_empty("E")]),
        "mixed": ([make_track(rng, k=2)], [_empty("E"), all_nan, one, one_rej]),
    }
    for name, (tracks, residuals) in cases.items():
        out = tmp_path / name
        paths = write_report(out, tracks, residuals, sites={"X": np.array([np.nan, 0, 0])})
        expected = 3 + len({r.sensor_id for r in residuals})
        assert len(paths) == expected, name
        for p in paths:
            assert p.read_bytes()[:8] == PNG_SIGNATURE
            assert mpimg.imread(p).std() > 0.0, (name, p.name)


def test_figures_do_not_touch_global_matplotlib_state(tmp_path: Path, scenario) -> None:
    import matplotlib

    tracks, residuals, _ = scenario
    before = (matplotlib.get_backend(), dict(matplotlib.rcParams))
    write_report(tmp_path, tracks, residuals[:1])
    assert (matplotlib.get_backend(), dict(matplotlib.rcParams)) == before


def test_window_nis_windows_do_not_span_gaps() -> None:
    t = np.concatenate([np.arange(25.0), 100.0 + np.arange(12.0)])
    dof = np.full(t.size, 2)
    nis = np.where(t < 50, 1.0, 3.0)
    t_mid, mean, expect, lo, hi = window_nis(t, nis, dof, 10, gap=5.0)
    # stretch 1: 25 rows -> windows of 10 and 15 rows; stretch 2: 12 rows -> one window
    np.testing.assert_allclose(t_mid, [4.5, 17.0, 105.5])
    np.testing.assert_allclose(mean, [1.0, 1.0, 3.0])
    np.testing.assert_allclose(expect, 2.0)
    assert np.all(lo < expect) and np.all(hi > expect)


def test_y_range_ignores_a_single_wild_point_but_fits_the_sigma_band() -> None:
    from rangeproc.report.residuals import _limit

    rng = np.random.default_rng(11)
    r = rng.standard_normal(10_000)
    r[17] = 1e6  # one wild point that the gate let through
    half = _limit(r, np.array([5e5]), np.full(r.size, 3.0))
    assert 5.0 < half < 7.5  # ~6 robust spreads, not 1e6
    burst = np.where(np.arange(r.size) < 500, 30.0, 3.0)  # 5 % of rows in a 10x noise burst
    r[:500] *= 10.0
    assert 30.0 <= _limit(r, np.zeros(0), burst) <= 33.0  # the burst's 3-sigma band fits


def test_binned_extreme_matches_a_loop() -> None:
    from rangeproc.report.common import binned_extreme

    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(0, 10, 500))
    t = t[(t < 4) | (t > 6)]
    v = rng.standard_normal(t.size)
    v[::7] = np.nan
    edges = np.linspace(-1, 11, 25)
    got = binned_extreme(t, v, edges, "max")
    for i in range(24):
        sel = (t >= edges[i]) & (t < edges[i + 1]) & np.isfinite(v)
        expect = v[sel].max() if sel.any() else np.nan
        np.testing.assert_equal(got[i], expect)


def test_calibration_figure_draws_estimates_and_lists_what_was_not_estimated(
        tmp_path: Path) -> None:
    from rangeproc.report.calibration import _notes, _rows, plot_calibration
    cal = {"R1": {"range": {"estimate": 15.1, "sigma": 0.2, "unit": "m", "applied": True},
                  "azimuth": {"estimate": 1e-5, "sigma": 2e-5, "unit": "rad",
                              "applied": False, "given": 1e-4},
                  "latency": {"estimate": None, "sigma": None,
                              "unobservable": "no absolute reference"}},
           "G1": {"latency": {"estimate": None, "sigma": None, "unobservable": "reference"}},
           "S1": {"mount_yaw": {"estimate": None, "sigma": None, "unit": "rad",
                                "not_estimated": "opted out"}}}
    assert [n for n, _ in _rows(cal, "m")] == ["R1 range"]
    assert [n for n, _ in _rows(cal, "rad")] == ["R1 azimuth"]
    assert _notes(cal) == ["R1 latency: no absolute reference", "G1 latency: reference"]
    fig = plot_calibration(cal)
    axes = [ax for ax in fig.axes if ax.get_xlabel()]
    assert [ax.get_xlabel() for ax in axes] == ["range bias (m)",
                                                "angle bias, mount angle (mrad)"]
    path = save_figure(fig, tmp_path / "calibration.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # nothing estimated at all still gives a figure
    save_figure(plot_calibration({"G1": cal["G1"]}), tmp_path / "empty.png")
