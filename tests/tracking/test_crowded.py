"""Crowded scenes: plot tracks of one object that overlap only by a coasting tail may be one
object (``objects.same_sensor_conflict``); the several-objects benchmark kind ``scale``
keeps every object one object."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_multi
from rangeproc.tracking.links import conflicts
from rangeproc.tracking.objects import Segment, member_conflict, same_sensor_conflict


def plot_track(sid: int, scans: list[int], sensor: int = 0, revisit: float = 4.0) -> Segment:
    """A plot track holding one plot in each of ``scans`` (times: scan x revisit s)."""
    s = np.asarray(scans, dtype=np.int64)
    return Segment(sid, sensor, np.arange(s.size), -1, float(s[0] * revisit),
                   float(s[-1] * revisit), True, True, s)


def test_a_coasting_tail_sharing_one_scan_is_no_conflict() -> None:
    """Track A follows an object to scan 15, misses 5 scans, takes a stray plot in scan 21;
    the tracker started B on the object in scan 17. They overlap in time (68-84 s) but share
    one scan: they may be one object. Two tracks holding plots of the same scans throughout
    (two objects side by side), a plot track and a tracked segment of one sensor, and two
    tracked segments overlapping in time conflict, as before."""
    a = plot_track(0, [*range(0, 16), 21])
    b = plot_track(1, list(range(17, 40)))
    assert a.t0 <= b.t1 and b.t0 <= a.t1                      # they overlap in time
    assert not same_sensor_conflict(a, b) and not same_sensor_conflict(b, a)
    two = plot_track(2, [*range(17, 21), 22, 23])             # shares scans 17-20, 22, 23
    assert same_sensor_conflict(b, two)
    assert same_sensor_conflict(a, plot_track(3, [15, 21]))   # two common scans
    other_sensor = plot_track(4, list(range(17, 40)), sensor=1)
    assert not same_sensor_conflict(b, other_sensor)
    tracked = Segment(5, 0, np.arange(10), 7, 60.0, 90.0, True)
    assert same_sensor_conflict(a, tracked) and same_sensor_conflict(tracked, tracked)
    assert not same_sensor_conflict(tracked, Segment(6, 0, np.arange(10), 8, 91.0, 99.0, True))
    assert conflicts([a, b, two]) == [(1, 2)]
    assert not member_conflict(None, "O1", b, {"O1": [a]})
    assert member_conflict(None, "O1", two, {"O1": [a, b]})


def _split_objects(folder) -> dict[str, dict[str, int]]:
    """Truth objects whose rows went to more than one output object: their rows per output."""
    got = pd.read_parquet(folder / "out" / "association.parquet")
    true = pd.read_csv(folder / "truth_association.csv", keep_default_na=False)
    table = got.merge(true.rename(columns={"target_id": "true"})[["sensor", "row", "true"]],
                      on=["sensor", "row"])
    table = table[(table.true != "") & (table.target_id.fillna("") != "")]
    out = {}
    for obj, mine in table.groupby("true"):
        counts = mine.target_id.value_counts()
        if counts.size > 1:
            out[str(obj)] = counts.to_dict()
    return out


def test_the_benchmark_scene_keeps_every_object_one_object(tmp_path) -> None:
    """scale, seed 1 (10 objects, 120 s; three tracking radars handing their tracks over
    between aircraft, SR1's plots of all ten among 20 clutter plots a scan): SR1's plot
    track of U5 lost it at 71 s, coasted and took a stray plot at 91 s, while the tracker
    had started a new track on U5 at 75 s. The two overlapped in time, sharing one scan, and
    two overlapping segments of one sensor could not be one object: the new track and 8 of
    U5's plots became an object of their own after R1 handed U5 over (an identity swap)."""
    run(simulate_multi(tmp_path, kind="scale", seed=1))
    assert _split_objects(tmp_path) == {}
    multi = evaluate_run(tmp_path / "out", tmp_path / "truth.csv")["multi"]
    assert all(m["swaps"] == 0 for m in multi["truth"].values())
    assert len(multi["fused"]) == len(multi["truth"])


def _surveillance_window(src, dst, start: float, end: float) -> None:
    """``dst``: scene ``src`` reduced to its surveillance radar SR1 between ``start`` and
    ``end`` s from the truth's first epoch (no targets declared), with its truth."""
    text = (src / "scenario.toml").read_text()
    head, *blocks = re.split(r"(?m)^(?=\[\[(?:sensors|targets)\]\])", text)
    sr1 = [b for b in blocks if b.startswith("[[sensors]]") and 'id = "SR1"' in b]
    dst.mkdir()
    (dst / "scenario.toml").write_text(head + "".join(sr1))
    truth = pd.read_csv(src / "truth.csv")
    t0 = float(truth.time.min())
    plots = pd.read_csv(src / "SR1.csv", dtype=str, keep_default_na=False)
    t = plots.time.astype(float) - t0
    keep = np.flatnonzero((t >= start) & (t <= end))
    plots.iloc[keep].to_csv(dst / "SR1.csv", index=False)
    true = pd.read_csv(src / "truth_association.csv", keep_default_na=False)
    true = true[true.sensor == "SR1"].set_index("row").loc[keep].reset_index(drop=True)
    true.insert(1, "row", np.arange(keep.size))
    true.to_csv(dst / "truth_association.csv", index=False)
    near = (truth.time - t0 >= start - 5.0) & (truth.time - t0 <= end + 5.0)
    truth[near].to_csv(dst / "truth.csv", index=False)


def test_a_plot_track_that_coasted_onto_another_object_is_cut(tmp_path) -> None:
    """scale, seed 1, 600 s, SR1's plots alone over 60-220 s: SR1's track of U2 lost it at
    126 s, coasted 4 scans and took U6 3.4 km away at 142 s (U6's own track had lost it in
    a hard turn), then followed U6. As one segment it was one object holding U2's plots
    before the gap and U6's after (purity 0.58). Cut where its first plot after the coast
    left the cruise model's gate (``tracking.plot_jumps``), each piece goes to the object it
    continues."""
    src = tmp_path / "scene"
    simulate_multi(src, kind="scale", seed=1, duration=600.0)
    _surveillance_window(src, tmp_path / "window", 60.0, 220.0)
    run(tmp_path / "window" / "scenario.toml")
    got = pd.read_parquet(tmp_path / "window" / "out" / "association.parquet")
    true = pd.read_csv(tmp_path / "window" / "truth_association.csv", keep_default_na=False)
    both = got.merge(true.rename(columns={"target_id": "true"})[["sensor", "row", "true"]],
                     on=["sensor", "row"])
    both = both[(both.target_id.fillna("") != "") & (both.true != "")]
    purity = {k: g.true.value_counts().iloc[0] / len(g) for k, g in both.groupby("target_id")}
    assert len(purity) >= 8                              # the window's objects are found
    assert min(purity.values()) >= 0.95, purity
    assert _split_objects(tmp_path / "window") == {}
