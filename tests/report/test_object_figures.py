"""Tests of the per-object figures: objects.png (who saw which object when) and map.png."""
from __future__ import annotations

import time
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pandas as pd
import pytest

from rangeproc.report import write_report
from rangeproc.report.common import STYLE, save_figure
from rangeproc.report.objects import (
    MAX_STRAY,
    RESOLUTION,
    UNASSIGNED,
    bridged_runs,
    find_relays,
    find_swaps,
    object_segments,
    plot_object_timeline,
    plot_map,
)
from rangeproc.results import SensorResiduals, TrackEstimate

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
T_START = 345_600.0
OBJECTS = ("T1", "T2", "O1")


def make_object(target_id: str, t_from: float, t_to: float, *, e0: float, n0: float,
                heading: float, sensors: str, bridged: tuple[float, float] | None = None,
                dt: float = 0.1) -> TrackEstimate:
    """A straight climbing track on a uniform grid; ``bridged``: (from, to) s since T_START
    with no data (data_gap grows to the middle of it), 0.05 s elsewhere."""
    t = T_START + np.arange(t_from, t_to, dt)
    k = t.size
    s = t - T_START - t_from
    x = np.zeros((k, 9))
    x[:, 0] = e0 + 250.0 * np.cos(heading) * s
    x[:, 1] = n0 + 250.0 * np.sin(heading) * s + 300.0 * np.sin(s / 20.0)
    x[:, 2] = 2_000.0 + 10.0 * s
    x[:, 3:6] = np.gradient(x[:, 0:3], t, axis=0) if k > 1 else 250.0
    P = np.tile(np.diag(np.r_[np.full(3, 9.0), np.ones(6)]), (k, 1, 1))
    gap = np.full(k, 0.05)
    names = np.full(k, sensors, dtype=object)
    if bridged is not None:
        a, b = T_START + bridged[0], T_START + bridged[1]
        inside = (t > a) & (t < b)
        gap[inside] = np.minimum(t[inside] - a, b - t[inside])
        names[inside] = ""
    return TrackEstimate(target_id=target_id, time=t, x=x, P=P,
                         n_sensors=np.where(names == "", 0, 1).astype(np.int64),
                         lat=np.full(k, 35.0), lon=np.full(k, -117.0), height=x[:, 2],
                         sensors=names, data_gap=gap)


def make_tracks() -> list[TrackEstimate]:
    return [make_object("T1", 0.0, 120.0, e0=0.0, n0=0.0, heading=0.3, sensors="R1,G1",
                        bridged=(50.0, 62.0)),
            make_object("T2", 0.0, 120.0, e0=5_000.0, n0=-8_000.0, heading=1.2, sensors="R1"),
            make_object("O1", 20.0, 100.0, e0=-10_000.0, n0=12_000.0, heading=-0.4,
                        sensors="R2")]


def _rows(sensor: str, t0: float, t1: float, rate: float, target: str, segment: int,
          reason: str, rng: np.random.Generator) -> pd.DataFrame:
    t = T_START + np.arange(t0, t1, 1.0 / rate) + rng.normal(0.0, 1e-3, 1)
    return pd.DataFrame({"sensor": sensor, "time": t, "target_id": target,
                         "segment": np.int64(segment), "reason": reason})


def make_association(rng: np.random.Generator) -> pd.DataFrame:
    """Radar R1 and theodolite R2 on three objects: R1 swaps from T1 to T2 at 40 s; R2 takes
    over T1 after its bridged gap (relay) and T2 at 90 s (relay), R1 took T2 over from R2
    by its swap (relay); clutter, a segment no object
    fits, angle-only plots and edited rows stay unassigned."""
    parts = [
        _rows("R1", 0.0, 40.0, 5.0, "T1", 0, "associated", rng),
        _rows("R1", 40.2, 80.0, 5.0, "T2", 1, "associated", rng),       # the swap
        _rows("R1", 20.0, 100.0, 5.0, "O1", 2, "associated", rng),
        _rows("R1", 100.0, 105.0, 5.0, "", 3, "no object fits", rng),
        _rows("R2", 0.0, 35.0, 20.0, "T2", 4, "associated", rng),
        _rows("R2", 62.0, 120.0, 20.0, "T1", 5, "associated", rng),     # relay R1 -> R2
        _rows("R2", 90.0, 120.0, 20.0, "T2", 6, "associated", rng),     # relay R1 -> R2
    ]
    clutter = T_START + np.sort(rng.uniform(0.0, 120.0, 2_000))
    parts.append(pd.DataFrame({"sensor": "R1", "time": clutter, "target_id": "",
                               "segment": np.int64(-1), "reason": "clutter"}))
    parts.append(pd.DataFrame({"sensor": "R1", "time": T_START + np.sort(rng.uniform(0, 120, 200)),
                               "target_id": "", "segment": np.int64(-1),
                               "reason": "angle-only plot"}))
    edited = T_START + rng.uniform(0, 120, 40)
    edited[:5] = np.nan
    parts.append(pd.DataFrame({"sensor": "R2", "time": edited, "target_id": "",
                               "segment": np.int64(-1),
                               "reason": "removed before association (see edits.parquet)"}))
    table = pd.concat(parts, ignore_index=True)
    # as association_table writes it: sensor by sensor (config order), in file row order
    table = table.sort_values(["sensor", "time"], kind="stable").reset_index(drop=True)
    table.insert(1, "row", table.groupby("sensor").cumcount().astype(np.int64))
    return table[["sensor", "row", "time", "target_id", "segment", "reason"]]


def make_stray(rng: np.random.Generator, m: int = 50_000) -> np.ndarray:
    return np.column_stack([rng.uniform(-25e3, 40e3, m), rng.uniform(-20e3, 30e3, m),
                            rng.uniform(0, 5e3, m)])


SITES = {"R1": np.array([2_000.0, -3_000.0, 10.0]), "R2": np.array([-6_000.0, 9_000.0, 50.0])}


def assert_good_png(path: Path) -> None:
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 400 and img.shape[1] > 800
    flat = img.reshape(-1, img.shape[2])
    assert np.unique(flat[:: max(1, flat.shape[0] // 50_000)], axis=0).shape[0] > 10
    assert 10_000 < path.stat().st_size < 400_000


def _texts(fig) -> list[str]:  # type: ignore[no-untyped-def]
    return [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]


def test_segments_swaps_relays_and_bridged_runs_are_found() -> None:
    table = make_association(np.random.default_rng(1))
    segs = object_segments(table)
    assert list(segs["segment"]) == [0, 1, 2, 3, 4, 5, 6]
    assert list(segs["target_id"]) == ["T1", "T2", "O1", "", "T2", "T1", "T2"]
    assert list(segs["rows"]) == [200, 199, 400, 25, 700, 1160, 600]
    swaps = find_swaps(segs, 2.0)
    assert swaps[["sensor", "from_id", "to_id"]].values.tolist() == [["R1", "T1", "T2"]]
    assert 39.7 < swaps["t_end"].iloc[0] - T_START < 40.0
    assert swaps["t_start"].iloc[0] - T_START == pytest.approx(40.2, abs=0.01)
    # a pause longer than the limit is a new acquisition, not a swap
    assert find_swaps(segs, 0.1).empty
    relays = find_relays(segs)
    got = sorted(map(tuple, relays[["target_id", "from_sensor", "to_sensor"]].values.tolist()))
    # T2: R2 lost it at 35 s, R1 (swapped over) took it at 40.2 s, R2 again at 90 s
    assert got == [("T1", "R1", "R2"), ("T2", "R1", "R2"), ("T2", "R2", "R1")]
    t1 = relays[relays["target_id"] == "T1"].iloc[0]
    assert t1["t_start"] - T_START == pytest.approx(62.0, abs=0.01)
    runs = bridged_runs(make_tracks()[0])
    assert runs.shape == (1, 2)
    np.testing.assert_allclose(runs[0] - T_START, [51.1, 60.9], atol=0.051)
    assert bridged_runs(make_tracks()[1]).shape == (0, 2)


def test_object_timeline_lanes_swap_relays_and_bridged(tmp_path: Path) -> None:
    import matplotlib

    rng = np.random.default_rng(2)
    tracks, table = make_tracks(), make_association(rng)
    with matplotlib.rc_context(STYLE):
        fig = plot_object_timeline(table, tracks, T_START)
        ax = fig.axes[0]
        lanes = [t.get_text().split("\n")[0] for t in ax.get_yticklabels()]
        assert lanes == [*OBJECTS, UNASSIGNED]
        swap = [a for a in ax.collections if a.get_gid() == "swap"]
        assert len(swap) == 1 and len(swap[0].get_segments()) == 1
        (seg,) = swap[0].get_segments()
        assert 39.8 < seg[0, 0] < 40.2 and seg[0, 1] > seg[1, 1]    # drawn from T1 down to T2
        relay = [a for a in ax.collections if a.get_gid() == "relay"]
        assert len(relay) == 1 and len(relay[0].get_segments()) == 3
        bridged = [a for a in ax.collections if a.get_gid() == "bridged"]
        assert len(bridged) == 1                                   # T1 only
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        assert legend[:3] == ["R1", "R2", "G1 (names its object)"]
        assert any(x.startswith("swap") for x in legend)
        assert any(x.startswith("relay") for x in legend)
        assert any(x.startswith("bridged") for x in legend)
        texts = " ".join(_texts(fig))
        assert "3 objects" in texts and "7 segments (6 on objects)" in texts
        assert "1 swap," in texts and "3 relays" in texts
        assert "clutter 2,000" in texts and "angle-only plot 200" in texts
        assert "no object fits 25" in texts
        assert ax.get_xlabel().startswith("time from start")
        assert_good_png(save_figure(fig, tmp_path / "objects.png"))


def test_plan_one_line_per_object_with_bridged_dashes_and_grey_clutter(tmp_path: Path) -> None:
    import matplotlib

    rng = np.random.default_rng(3)
    tracks = make_tracks()
    with matplotlib.rc_context(STYLE):
        fig = plot_map(tracks, make_stray(rng), SITES)
        ax = fig.axes[0]
        labelled = [ln for ln in ax.get_lines() if ln.get_label() in OBJECTS]
        assert [ln.get_label() for ln in labelled] == list(OBJECTS)
        assert len({ln.get_color() for ln in labelled}) == 3
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert legend[:3] == list(OBJECTS) and "start" in legend and "end" in legend
        dashed = [ln for ln in ax.get_lines() if ln.get_gid() == "bridged"]
        assert len(dashed) == 1 and dashed[0].get_color() == labelled[0].get_color()
        e = dashed[0].get_xdata()
        assert 5 <= np.isfinite(e).sum() <= 120                    # about the 12 s gap only
        stray = [ln for ln in ax.get_lines() if ln.get_gid() == "stray"]
        assert len(stray) == 1 and len(stray[0].get_xdata()) == MAX_STRAY
        assert any("50,000" in x and "drawn" in x for x in legend)
        assert ax.get_xlabel() == "east [km]" and ax.get_ylabel() == "north [km]"
        assert ax.get_aspect() == 1.0
        assert_good_png(save_figure(fig, tmp_path / "map.png"))


def test_two_million_rows_draw_in_bounded_work(tmp_path: Path, capsys) -> None:
    """2 million association rows: drawing work is bounded by the pixel grid. Wall time is
    printed for the record, not asserted (house style: timing belongs in ``make bench``)."""
    import matplotlib

    rng = np.random.default_rng(4)
    n_obj, rate, span = 3, 60.0, 3_600.0
    parts = []
    seg = 0
    for s, sensor in enumerate(("R1", "R2")):
        for k in range(n_obj):
            for a in np.arange(0.0, span, 600.0):            # six segments per object
                t = T_START + a + np.arange(0.0, 590.0, 1.0 / rate) + 0.003 * (k + s)
                parts.append((sensor, t, OBJECTS[(k + s + int(a // 1800)) % n_obj], seg))
                seg += 1
    n_assoc = sum(p[1].size for p in parts)
    n_clutter = 2_000_000 - n_assoc
    table = pd.DataFrame({
        "sensor": np.concatenate([np.full(p[1].size, p[0], dtype=object) for p in parts]
                                 + [rng.choice(np.array(["R1", "R2"], dtype=object),
                                               n_clutter)]),
        "row": np.arange(2_000_000, dtype=np.int64),
        "time": np.concatenate([p[1] for p in parts]
                               + [T_START + rng.uniform(0, span, n_clutter)]),
        "target_id": np.concatenate([np.full(p[1].size, p[2], dtype=object) for p in parts]
                                    + [np.full(n_clutter, "", dtype=object)]),
        "segment": np.concatenate([np.full(p[1].size, p[3]) for p in parts]
                                  + [np.full(n_clutter, -1)]).astype(np.int64),
        "reason": np.concatenate([np.full(p[1].size, "associated", dtype=object)
                                  for p in parts]
                                 + [np.full(n_clutter, "clutter", dtype=object)])})
    assert len(table) == 2_000_000 and n_clutter > 500_000
    tracks = [make_object(name, 0.0, span, e0=4e3 * k, n0=0.0, heading=0.5 * k,
                          sensors="R1,R2", bridged=(1000.0, 1030.0))
              for k, name in enumerate(OBJECTS)]
    stray = make_stray(rng, n_clutter)
    start = time.perf_counter()
    with matplotlib.rc_context(STYLE):
        fig = plot_object_timeline(table, tracks, T_START)
        n_bars = sum(len(c.get_paths()) for c in fig.axes[0].collections)
        timeline = save_figure(fig, tmp_path / "objects.png")
        map_fig = plot_map(tracks, stray, None)
        n_stray = sum(len(ln.get_xdata()) for ln in map_fig.axes[0].get_lines()
                      if ln.get_gid() == "stray")
        plan = save_figure(map_fig, tmp_path / "map.png")
    elapsed = time.perf_counter() - start
    with capsys.disabled():
        print(f"\n[objects.png + map.png, 2,000,000 association rows, {n_clutter:,} stray "
              f"plots: {elapsed:.2f} s]")
    # every sub-row draws at most one bar per time cell; plots are thinned
    assert n_bars <= (n_obj + 1) * 2 * RESOLUTION
    assert n_stray == MAX_STRAY
    assert_good_png(timeline)
    assert_good_png(plan)


def _residuals(rng: np.random.Generator) -> list[SensorResiduals]:
    t = T_START + np.arange(0.0, 120.0, 0.2)
    res = rng.standard_normal((t.size, 3)) * [5.0, 2e-4, 2e-4]
    return [SensorResiduals(sensor_id="R1", kind="radar", target_id="T1",
                            components=("range", "azimuth", "elevation"),
                            units=("m", "rad", "rad"), time=t, residual=res,
                            sigma=np.tile([5.0, 2e-4, 2e-4], (t.size, 1)),
                            rejected=np.zeros((t.size, 3), bool), nis=np.ones(t.size))]


def test_write_report_adds_object_figures_only_with_association_rows(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    tracks, residuals = make_tracks(), _residuals(rng)
    cal = {"R1": {"range": {"estimate": 15.1, "sigma": 0.2, "unit": "m", "applied": True}}}
    before = [p.name for p in write_report(tmp_path / "a", tracks, residuals, sites=SITES,
                                           calibration=cal)]
    assert before == ["trajectory.png", "residuals_R1.png", "consistency.png", "coverage.png",
                      "calibration.png"]
    empty = make_association(rng).iloc[:0]
    same = [p.name for p in write_report(tmp_path / "b", tracks, residuals, sites=SITES,
                                         calibration=cal, association=empty,
                                         stray=make_stray(rng, 10))]
    assert same == before
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == sorted(before)
    seen: list[str] = []
    paths = write_report(tmp_path / "c", tracks, residuals, sites=SITES, calibration=cal,
                         association=make_association(rng), stray=make_stray(rng, 1_000),
                         progress=seen.append)
    assert [p.name for p in paths] == ["trajectory.png", "residuals_R1.png", "consistency.png",
                                       "coverage.png", "objects.png", "map.png",
                                       "calibration.png"]
    assert len(seen) == len(paths)
    for p in paths[4:6]:
        assert_good_png(p)
    # without stray plots the plan is still drawn
    paths = write_report(tmp_path / "d", tracks, residuals, association=make_association(rng))
    assert "map.png" in [p.name for p in paths]


def test_edge_cases_do_not_crash(tmp_path: Path) -> None:
    import matplotlib

    rng = np.random.default_rng(6)
    table = make_association(rng)
    only_clutter = table[table["target_id"] == ""]
    one_row = table.iloc[:1]
    with matplotlib.rc_context(STYLE):
        cases = {
            "no_tracks": (table, []),
            "only_clutter": (only_clutter, make_tracks()),
            "one_row": (one_row, []),
            "no_provenance": (table, [TrackEstimate(**{**{f: getattr(tr, f)
                                                        for f in tr.__slots__},
                                                     "sensors": None, "data_gap": None})
                                      for tr in make_tracks()]),
            "one_epoch": (table, [make_object("T1", 0.0, 0.1, e0=0.0, n0=0.0, heading=0.0,
                                              sensors="R1")]),
        }
        for name, (assoc, tracks) in cases.items():
            fig = plot_object_timeline(assoc, tracks, T_START)
            assert save_figure(fig, tmp_path / f"{name}_t.png").read_bytes()[:8] == PNG_SIGNATURE
            fig = plot_map(tracks, make_stray(rng, 0), None)
            assert save_figure(fig, tmp_path / f"{name}_p.png").read_bytes()[:8] == PNG_SIGNATURE
        fig = plot_map([], np.full((3, 3), np.nan), {"X": np.array([np.nan, 0, 0])})
        save_figure(fig, tmp_path / "nothing.png")


def test_bridged_runs_less_than_the_join_apart_are_drawn_as_one() -> None:
    from rangeproc.report.objects import joined_runs
    runs = np.array([[0.0, 3.0], [4.0, 7.0], [7.5, 9.0], [20.0, 22.0], [27.1, 30.0]])
    np.testing.assert_array_equal(joined_runs(runs, 5.0),
                                  [[0.0, 9.0], [20.0, 22.0], [27.1, 30.0]])
    np.testing.assert_array_equal(joined_runs(runs[:1], 5.0), runs[:1])
    assert joined_runs(np.zeros((0, 2)), 5.0).shape == (0, 2)
