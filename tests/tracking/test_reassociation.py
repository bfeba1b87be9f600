"""Step 5 of track synthesis (``tracking.reassociation``): plots re-associated with the
smoothed objects round after round until stable, the rules of a later round, and the
ambiguous stretches with their runner-up."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from rangeproc.fusion.batch import SensorRows
from rangeproc.tracking import reassociation as ra
from rangeproc.tracking.objects import Segment
from rangeproc.tracking.plot_association import reassign_members
from rangeproc.tracking.score import ObjectTrack


# ---------------------------------------------------------------- ambiguous stretches
def test_a_run_of_close_plots_is_an_ambiguous_stretch_with_its_runner_up() -> None:
    """Object 0 owns plots 0-6; plots 1-4 score within AMBIGUITY_LLR of object 1 (margins
    1, 2, 0.5, 1): one stretch of 4 plots, runner-up 1, summed margin 4.5. Plot 6, close to
    object 2 alone, is too short a run; object 2's plots are clear; a plot the assignment
    did not give (-1) counts for nothing."""
    t = np.arange(10.0)
    llr = np.full((10, 3), -np.inf)
    llr[:7, 0] = 10.0
    llr[[1, 2, 3, 4], 1] = 10.0 - np.array([1.0, 2.0, 0.5, 1.0])
    llr[0, 1] = 2.0                                     # plot 0: a clear margin of 8
    llr[6, 2] = 9.0
    llr[7:, 2] = 12.0
    llr[7:, 0] = 0.0
    owner = np.array([0, 0, 0, 0, 0, 0, 0, 2, 2, -1])
    out = ra.ambiguous_stretches(t, llr, owner, ["A", "B", "C"], sensor=3)
    assert out == [{"object": "A", "runner_up": "B", "sensor": 3, "t0": 1.0, "t1": 4.0,
                    "n_plots": 4, "llr_margin": pytest.approx(4.5)}]
    assert ra.ambiguous_stretches(t, llr[:, :1], np.minimum(owner, 0), ["A"], 3) == []


def test_a_stretch_ends_where_the_runner_up_changes() -> None:
    """Three close plots with runner-up B, then three with runner-up C: two stretches."""
    t = np.arange(6.0)
    llr = np.full((6, 3), -np.inf)
    llr[:, 0] = 5.0
    llr[:3, 1] = 4.0
    llr[3:, 2] = 4.5
    out = ra.ambiguous_stretches(t, llr, np.zeros(6, np.int64), ["A", "B", "C"], 0)
    assert [(s["runner_up"], s["t0"], s["t1"], s["n_plots"]) for s in out] == \
        [("B", 0.0, 2.0, 3), ("C", 3.0, 5.0, 3)]


# ---------------------------------------------------------------- rounds until stable
def _fake_objects(n: int = 4) -> SimpleNamespace:
    calls: list[str] = []

    def quick_track(members, prior):
        calls.append("quick")
        return f"track{len(calls)}"

    objects = SimpleNamespace(
        tracks={"A": "trackA", "B": "trackB"},
        members={"A": [(0, np.array([0, 1]))], "B": [(0, np.array([2, 3]))]},
        rows={0: SimpleNamespace(t=np.arange(float(n)))}, priors={}, calls=calls,
        quick_track=quick_track, refined_track=lambda k: calls.append("refined"),
        sensor_ids=("SR",))
    objects.adopt = lambda k, track: objects.tracks.__setitem__(k, track) or True
    return objects


def _run_script(monkeypatch, script: list[str]):
    """reassociate_plots with each round's owners (one letter per plot, "-" for none) taken
    from ``script`` (the last repeated)."""
    objects = _fake_objects()
    rounds = iter(script + [script[-1]] * 10)

    def scripted(objects, keys, sensor, plots, refined, settled=False):
        owner = np.array([keys.index(k) if k in keys else -1 for k in next(rounds)])
        objects.members = reassign_members(objects.members, sensor, plots.rows, owner, keys)
        return owner, np.zeros((plots.rows.size, len(keys))), owner >= 0

    monkeypatch.setattr(ra, "associate_sensor", scripted)
    monkeypatch.setattr(ra, "sensor_plots", lambda objects, sensor, rows, frame, scan, tracked,
                        n, revisit, several: ra.SensorPlots(rows, frame, tracked,
                                                            np.zeros(rows.size), revisit,
                                                            several))
    seg = Segment(0, 0, np.arange(4), -1, 0.0, 3.0, True, plot=True)
    timing = SimpleNamespace(frame=np.arange(4), scan=np.arange(4), revisit=1.0, several=False)
    out = ra.reassociate_plots(objects, ["A", "B"], [seg], {}, {0: (np.arange(4), timing, [])})
    return out, objects


def test_one_round_when_the_plot_tracks_were_right(monkeypatch) -> None:
    out, objects = _run_script(monkeypatch, ["AABB"])
    assert (out.rounds, out.converged, out.moved) == (1, True, [0])
    assert objects.calls == []                            # nothing re-estimated


def test_the_objects_that_changed_are_re_estimated_and_scored_again(monkeypatch) -> None:
    """Round 1 moves plot 0 from A to B; both are re-estimated; round 2 changes nothing."""
    out, objects = _run_script(monkeypatch, ["BABB", "BABB"])
    assert (out.rounds, out.converged, out.moved) == (2, True, [1, 0])
    assert objects.calls == ["quick", "quick"]
    assert out.owners[0][1] == ["B", "A", "B", "B"]
    assert [s.tolist() for _, s in objects.members["B"]] == [[0, 2, 3]]


def test_a_cycle_stops_the_rounds(monkeypatch) -> None:
    """Round 2 returns to the plot tracks' assignment: a cycle, not convergence."""
    out, _ = _run_script(monkeypatch, ["BABB", "AABB", "BABB"])
    assert (out.rounds, out.converged) == (2, False)


def test_at_most_max_rounds(monkeypatch) -> None:
    script = ["BABB", "BBBB", "BBAB", "BBAA", "ABAA"]
    monkeypatch.setattr(ra, "MAX_ROUNDS", 3)
    out, _ = _run_script(monkeypatch, script)
    assert (out.rounds, out.converged, out.moved) == (3, False, [1, 1, 1])


def test_an_object_left_without_plots_is_dropped(monkeypatch) -> None:
    out, objects = _run_script(monkeypatch, ["BBBB", "BBBB"])
    assert "A" not in objects.tracks and out.rounds == 2 and out.converged


# ---------------------------------------------------------------- rules of a later round
def _line_track(y: float, sigma: float, t: np.ndarray) -> ObjectTrack:
    x = np.zeros((t.size, 9))
    x[:, 1] = y                                          # north of the radar, at rest
    P = np.broadcast_to(np.diag([sigma ** 2] * 3 + [1.0] * 3 + [0.1] * 3),
                        (t.size, 9, 9)).copy()
    return ObjectTrack(t, x, P, np.full(t.size, 1.0))


def _one_sensor_objects(plot_batch, ranges: list[float], tracks: dict, members: dict):
    t = np.arange(float(len(ranges)))
    rae = np.column_stack([ranges, np.zeros(t.size), np.zeros(t.size)])
    b = plot_batch(t, rae, [5.0, 1e-3, 1e-3])
    rows = SensorRows(b.t, b.model, b.z, b.sigma, b.s, b.sv, b.Qr, b.source_row, b.station,
                      b.track)
    return SimpleNamespace(rows={0: rows}, sensor_ids=("SR1",), tracks=tracks,
                           members=members, refined_track=lambda k: None,
                           adopt=lambda k, tr: True)


def _one_plot(objects) -> ra.SensorPlots:
    one = np.array([0])
    return ra.sensor_plots(objects, 0, one, one, one, np.zeros(1, bool), 0, 1.0)


@pytest.mark.parametrize("settled, expected", [(False, 1), (True, 0)])
def test_a_later_round_moves_a_plot_only_for_a_clearly_better_object(
        plot_batch, settled: bool, expected: int) -> None:
    """A plot at 1004 m held by A (at 1000 m) fits B (at 1003 m) a little better (llr gain
    below SWITCH_LLR): the first round gives it to B, a later round leaves it with A."""
    grid = np.arange(-1.0, 3.0, 0.5)
    objects = _one_sensor_objects(
        plot_batch, [1004.0], {"A": _line_track(1000.0, 1.0, grid),
                               "B": _line_track(1003.0, 1.0, grid)},
        {"A": [(0, np.array([0]))], "B": []})
    owner, llr, _ = ra.associate_sensor(objects, ["A", "B"], 0, _one_plot(objects), set(),
                                        settled=settled)
    assert 0 < llr[0, 1] - llr[0, 0] < ra.SWITCH_LLR
    assert owner.tolist() == [expected]


@pytest.mark.parametrize("settled, expected", [(False, -1), (True, 0)])
def test_a_later_round_never_drops_a_plot_no_object_gates(plot_batch, settled: bool,
                                                          expected: int) -> None:
    """A plot 200 m from its precise object A (sigma 1 m) is gated by no object: the first
    round unassigns it (A is surer than the plot), a later round keeps it where the first
    put it (a re-estimate that no longer gates a plot is not evidence against it)."""
    grid = np.arange(-1.0, 3.0, 0.5)
    objects = _one_sensor_objects(plot_batch, [1200.0],
                                  {"A": _line_track(1000.0, 1.0, grid)},
                                  {"A": [(0, np.array([0]))]})
    owner, llr, _ = ra.associate_sensor(objects, ["A"], 0, _one_plot(objects), set(),
                                        settled=settled)
    assert not np.isfinite(llr).any()
    assert owner.tolist() == [expected]
