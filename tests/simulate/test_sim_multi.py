"""simulate_multi: multi-object scenarios with truth (crossing, formation, lock-jump,
operator-switch, surveillance, phased-array, merged-feed, mixed).

Checks are independent of the simulator's geometry code: measurements are recomputed from
truth.csv (cubic Hermite interpolation per object) and the config's sites with pyproj; files
are read with rangeproc's own reader (``load_config`` + ``read_sensor``, as
``stages.read.read_all``).
"""
from __future__ import annotations

import filecmp
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomllib
from click.testing import CliRunner
from scipy.interpolate import CubicHermiteSpline

from rangeproc.cli import main
from rangeproc.config import load_config
from rangeproc.errors import ConfigError
from rangeproc.io.readers import read_sensor
from rangeproc.simulate import MULTI_KINDS, draw_multi, simulate_multi
from rangeproc.simulate import multi_sensors as ms
from rangeproc.tracking.plots import is_rotating
from geo_oracle import ecef, enu_basis

DUR, SEEDS = 90.0, (3, 4)  # odd seeds: GPS seconds of week; even: ISO GPS stamps
TO_RAD = {"deg": math.pi / 180.0, "rad": 1.0, "mil": 2.0 * math.pi / 6400.0}
KINDS = [k for k in MULTI_KINDS if k not in ("scale", "harbour")]  # test_simulate_scale.py,
# test_sim_harbour.py
PLOT_SENSORS = ("SR1", "PA1", "PF1")  # plots: no track_id (surveillance, phased array, feed)


def wrap(a: np.ndarray) -> np.ndarray:
    """Angle difference (rad) wrapped to [-pi, pi)."""
    return np.mod(a + math.pi, 2 * math.pi) - math.pi


class Run:
    """One simulated folder: config, files, truth per object, association truth."""

    def __init__(self, cfg_path: Path):
        self.dir = cfg_path.parent
        self.cfg = tomllib.loads(cfg_path.read_text())
        self.sensor = {s["id"]: s for s in self.cfg["sensors"]}
        o = self.cfg["range"]["origin"]
        self.o_ecef = ecef(o["lat"], o["lon"], o["height"])[0]
        self.o_rot = enu_basis(o["lat"], o["lon"])[0]
        self.truth = pd.read_csv(self.dir / "truth.csv")
        self.assoc = pd.read_csv(self.dir / "truth_association.csv", dtype={"target_id": str})
        tid = self.assoc["target_id"]
        self.assoc["target_id"] = tid.astype(object).where(tid.notna(), None)  # clutter: None
        self.events = json.loads((self.dir / "truth_events.json").read_text())
        self.ids = sorted(self.truth["target_id"].unique())
        self.spline = {}
        for tid, grp in self.truth.groupby("target_id"):
            t = grp["time"].to_numpy()
            self.spline[tid] = CubicHermiteSpline(t, grp[["e", "n", "u"]].to_numpy(),
                                                  grp[["ve", "vn", "vu"]].to_numpy())

    def read(self, sid: str) -> tuple[pd.DataFrame, np.ndarray]:
        """The sensor's rows (file order) and their measurement times (stamp + offset, s)."""
        path = self.dir / self.sensor[sid]["file"]
        df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
        if pd.api.types.is_numeric_dtype(df["time"]):
            t = df["time"].to_numpy(float)
        else:
            t = (pd.to_datetime(df["time"], utc=True).dt.as_unit("ns").astype("int64")
                 .to_numpy() / 1e9)
        return df, t + self.sensor[sid]["time_offset"]

    def labels(self, sid: str) -> pd.DataFrame:
        a = self.assoc[self.assoc["sensor"] == sid]
        assert a["row"].tolist() == list(range(len(a))), sid
        return a.reset_index(drop=True)

    def pos(self, tid: str, t: np.ndarray) -> np.ndarray:
        """(M, 3) range ENU position of object tid at times t."""
        return self.spline[tid](t)

    def site_rae(self, sid: str, tid: str, t: np.ndarray) -> np.ndarray:
        """(M, 3) true range (m), azimuth, elevation (rad) of object tid from a fixed site."""
        return self.rae_from(self.sensor[sid]["site"], tid, t)

    def rae_from(self, site: dict, tid: str, t: np.ndarray) -> np.ndarray:
        """(M, 3) true range (m), azimuth, elevation (rad) of object tid from ``site`` (lat,
        lon, height)."""
        x = self.o_ecef + self.pos(tid, t) @ self.o_rot
        d = x - ecef(site["lat"], site["lon"], site["height"])
        enu = d @ enu_basis(site["lat"], site["lon"])[0].T
        return np.column_stack((np.linalg.norm(d, axis=1),
                                np.mod(np.arctan2(enu[:, 0], enu[:, 1]), 2 * math.pi),
                                np.arctan2(enu[:, 2], np.hypot(enu[:, 0], enu[:, 1]))))

    def measured_rae(self, sid: str, df: pd.DataFrame) -> np.ndarray:
        """(M, 3) measured range (m; NaN if absent), azimuth, elevation (rad)."""
        unit = TO_RAD[self.sensor[sid].get("angle_unit", "deg")]
        rng = df["range"].to_numpy(float) if "range" in df else np.full(len(df), np.nan)
        return np.column_stack((rng, df["azimuth"].to_numpy(float) * unit,
                                df["elevation"].to_numpy(float) * unit))

    def sigmas(self, sid: str) -> np.ndarray:
        """(3,) a-priori sigma of range (m; inf if not ranged), azimuth, elevation (rad)."""
        s = self.sensor[sid]
        unit = TO_RAD[s.get("angle_unit", "deg")]
        return np.array([s["sigma"].get("range", np.inf), s["sigma"]["azimuth"] * unit,
                         s["sigma"]["elevation"] * unit])

    def normalised(self, sid: str, df: pd.DataFrame, t: np.ndarray, tid: str) -> np.ndarray:
        """(M, 3) |measured - true(tid)| / sigma per component (NaN where not measured)."""
        d = self.measured_rae(sid, df) - self.site_rae(sid, tid, t)
        d[:, 1] = wrap(d[:, 1])
        return np.abs(d) / self.sigmas(sid)

    def fixed_sites(self) -> list[str]:
        return [s["id"] for s in self.cfg["sensors"]
                if s["kind"] in ("radar", "theodolite") and "site" in s]


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return tmp_path_factory.mktemp("multi")


@pytest.fixture(scope="module", params=[(k, s) for k in KINDS for s in SEEDS],
                ids=lambda p: f"{p[0]}-{p[1]}")
def run(request, root):
    kind, seed = request.param
    return Run(simulate_multi(root / f"{kind}_{seed}", kind=kind, seed=seed, duration=DUR))


def _runs(root: Path, kind: str, seeds) -> list[Run]:
    return [Run(simulate_multi(root / f"{kind}{s}", kind=kind, seed=s, duration=DUR))
            for s in seeds]


# ------------------------------------------------------------------------------------------
# every kind
# ------------------------------------------------------------------------------------------

def test_files_parse_with_rangeproc_reader(run):
    conf = load_config(run.dir / "scenario.toml")
    kinds = {}
    for s in conf.sensors:
        log = read_sensor(s)
        kinds[s.id] = s.kind
        assert log.n_read == len(run.read(s.id)[0]) > 0, s.id
        if s.kind in ("radar", "theodolite"):
            assert log.n_read == len(run.labels(s.id)), s.id
            assert log.track_id is not None, s.id
            if s.id in PLOT_SENSORS:  # plots: every track_id cell empty
                assert np.all(log.track_id == -1)
            else:
                assert np.all(log.track_id >= 0), s.id
    assert set(run.assoc["sensor"]) == {k for k, v in kinds.items() if v in ("radar",
                                                                             "theodolite")}
    assert "R1" in kinds and sum(v == "gps" for v in kinds.values()) >= 1
    lo = run.truth["time"].min()
    for sid in kinds:  # radar/theodolite files interleave objects sorted by time
        _, t = run.read(sid)
        assert t.min() >= lo - 1e-6
        if kinds[sid] != "mistram":
            assert np.all(np.diff(t) >= 0), sid


def test_undeclared_objects_not_in_config(run):
    declared = [t["id"] for t in run.cfg["targets"]]
    assert declared == sorted(i for i in run.ids if i.startswith("T")) and declared
    undeclared = [i for i in run.ids if i.startswith("U")]
    assert undeclared, "every kind has an object without GPS"
    assert set(run.ids) == set(declared) | set(undeclared)
    carried = {s["target"] for s in run.cfg["sensors"] if s["kind"] in ("gps", "mistram")}
    assert carried == set(declared)
    for tid, obj in run.events["objects"].items():
        assert obj["declared"] == (tid in declared)
    assert list(run.truth.columns[:8]) == ["target_id", "time", "e", "n", "u", "ve", "vn", "vu"]
    # undeclared objects are seen by some radar/theodolite
    assert set(undeclared) <= set(run.assoc["target_id"].dropna())


def test_association_maps_rows_to_true_object(run):
    """Non-wild labelled rows of every fixed-site sensor lie within 6 sigma of their object
    (every measured component); against the other objects most rows do not."""
    rng = np.random.default_rng(0)
    for sid in run.fixed_sites():
        df, t = run.read(sid)
        lab = run.labels(sid)
        ok = lab["target_id"].notna().to_numpy() & (lab["wild"].to_numpy() == 0)
        assert ok.sum() > 20, sid
        for tid in lab["target_id"].dropna().unique():
            rows = np.flatnonzero(ok & (lab["target_id"] == tid).to_numpy())
            rows = rows if rows.size <= 400 else np.sort(rng.choice(rows, 400, replace=False))
            z = run.normalised(sid, df.iloc[rows], t[rows], tid)
            assert np.nanmax(z) < 6.0, (sid, tid, np.nanmax(z))
            for other in set(run.ids) - {tid}:  # sensitivity: the wrong object fits badly
                zo = np.nanmax(run.normalised(sid, df.iloc[rows], t[rows], other), axis=1)
                assert np.mean(zo < 6.0) < 0.5, (sid, tid, other)
        wild = lab["wild"].to_numpy() == 1
        assert wild.sum() >= 1 or sid in PLOT_SENSORS, sid


def test_same_seed_identical_files(root):
    a = simulate_multi(root / "same_a", kind="mixed", seed=11, duration=60.0).parent
    b = simulate_multi(root / "same_b", kind="mixed", seed=11, duration=60.0).parent
    c = simulate_multi(root / "same_c", kind="mixed", seed=12, duration=60.0).parent
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {"truth.csv", "truth_association.csv", "scenario.toml", "SR1.csv"} <= set(names)
    for name in names:
        assert filecmp.cmp(a / name, b / name, shallow=False), name
    assert not filecmp.cmp(a / "R1.csv", c / "R1.csv", shallow=False)
    assert not list(root.rglob("*.tmp"))


# ------------------------------------------------------------------------------------------
# per kind
# ------------------------------------------------------------------------------------------

def _min_distance(run: Run, a: str, b: str) -> tuple[float, float]:
    """Closest approach (m) of objects a and b in truth.csv, and its time (s)."""
    ta = run.truth[run.truth["target_id"] == a]
    tb = run.truth[run.truth["target_id"] == b]
    assert np.array_equal(ta["time"].to_numpy(), tb["time"].to_numpy())
    d = np.linalg.norm(ta[["e", "n", "u"]].to_numpy() - tb[["e", "n", "u"]].to_numpy(), axis=1)
    i = int(np.argmin(d))
    return float(d[i]), float(ta["time"].iloc[i])


def test_crossing_really_crosses(root):
    for r in _runs(root, "crossing", (1, 2, 4, 5)):
        (ev,) = [e for e in r.events["events"] if e["event"] == "crossing"]
        first, others = ev["objects"][0], ev["objects"][1:]
        assert 2 <= len(ev["objects"]) <= 3 and set(ev["objects"]) == set(r.ids)
        for other in others:
            d, t = _min_distance(r, first, other)
            assert 100.0 < d < 500.0, (r.dir.name, other, d)
            assert abs(t - ev["time"]) < 3.0
        # far apart at the start: they converge, cross and separate
        t0 = r.truth["time"].min()
        for other in others:
            p0 = r.pos(first, np.array([t0 + 1.0])) - r.pos(other, np.array([t0 + 1.0]))
            assert np.linalg.norm(p0) > 3e3


def test_formation_flies_close_then_splits(root):
    for r in _runs(root, "formation", (1, 2, 3)):
        (ev,) = [e for e in r.events["events"] if e["event"] == "split"]
        members = ev["objects"]
        t_lo = r.truth["time"].min()
        before = np.linspace(t_lo + 1.0, ev["time"], 20)
        t_end = r.truth["time"].max() - 1.0
        for i, a in enumerate(members):
            for b in members[i + 1:]:
                d = np.linalg.norm(r.pos(a, before) - r.pos(b, before), axis=1)
                assert 80.0 < d.min() and d.max() < 500.0 and np.ptp(d) < 1.0, (a, b)
                end = np.linalg.norm(r.pos(a, np.array([t_end])) - r.pos(b, np.array([t_end])))
                assert end > 1000.0, (r.dir.name, a, b, end)


def test_lock_jump_changes_object_exactly_as_labelled(root):
    """R1's jumping track: its rows carry one track_id; the labels change object exactly at the
    events, and the measurements follow the labelled object (not the other one) wherever the
    two are resolvable."""
    seen_back = False
    for r in _runs(root, "lock-jump", (1, 2, 3, 4, 6)):
        jumps = [e for e in r.events["events"]
                 if e["event"] == "track_change" and e["sensor"] == "R1"]
        assert jumps and jumps[0]["gap"] == 0.0 and all(e["track_id_from"] == e["track_id_to"]
                                                        for e in jumps)
        seen_back |= len(jumps) == 2
        tid = jumps[0]["track_id_from"]
        df, t = r.read("R1")
        lab = r.labels("R1")
        mine = (df["track_id"] == tid).to_numpy()
        seq = lab["target_id"][mine].to_numpy()
        changes = np.flatnonzero(seq[1:] != seq[:-1]) + 1
        assert len(changes) == len(jumps)
        for i, e in zip(changes, jumps):
            assert (seq[i - 1], seq[i]) == (e["from"], e["to"])
            assert t[mine][i - 1] < e["time"] - e["gap"] + 1e-6 and e["time"] <= t[mine][i]
        a, b = jumps[0]["from"], jumps[0]["to"]
        assert a.startswith("T") and b != a
        ok = mine & (lab["wild"].to_numpy() == 0)
        za = np.nanmax(r.normalised("R1", df[ok], t[ok], a), axis=1)
        zb = np.nanmax(r.normalised("R1", df[ok], t[ok], b), axis=1)
        is_a = lab["target_id"][ok].to_numpy() == a
        resolvable = (za > 20) | (zb > 20)
        assert np.all(np.where(is_a, za, zb) < 6.0)
        assert np.all(np.where(is_a, zb, za)[resolvable] > 6.0)
        assert resolvable[is_a].sum() > 50 and resolvable[~is_a].sum() > 50
    assert seen_back  # one of the seeds re-acquires the first object


def test_operator_switch_moves_theodolite(root):
    for r in _runs(root, "operator-switch", (1, 2, 3, 4)):
        (ev,) = [e for e in r.events["events"] if e["event"] == "track_change"]
        assert ev["sensor"] == "TH1" and 1.0 <= ev["gap"] <= 5.0
        df, t = r.read("TH1")
        lab = r.labels("TH1")["target_id"].to_numpy()
        assert set(lab) == {ev["from"], ev["to"]}
        before, after = t < ev["time"] - ev["gap"], t >= ev["time"]
        assert np.all(lab[before] == ev["from"]) and np.all(lab[after] == ev["to"])
        assert not np.any(~before & ~after)  # nothing while the operator slews
        assert np.all(df["track_id"][before] == ev["track_id_from"])
        assert np.all(df["track_id"][after] == ev["track_id_to"])
        assert before.sum() > 20 and after.sum() > 20


def test_surveillance_plots_and_clutter(root):
    for r in _runs(root, "surveillance", (1, 2)):
        df, t = r.read("SR1")
        lab = r.labels("SR1")
        assert df["track_id"].isna().all()  # plots: empty track_id cells
        clutter = lab["target_id"].isna().to_numpy()
        scans = (t.max() - t.min()) / 4.0
        assert 12.0 < clutter.sum() / scans < 28.0  # Poisson, mean 20 per 4 s scan
        assert np.all(lab["wild"][clutter] == 0)
        # clutter does not sit on any object
        for tid in r.ids:
            z = np.nanmax(r.normalised("SR1", df[clutter], t[clutter], tid), axis=1)
            assert np.mean(z < 6.0) < 0.01
        objects = lab["target_id"].dropna()
        assert 3 <= len(r.ids) <= 5 and objects.nunique() >= 2
        per_obj = objects.value_counts()
        assert per_obj.max() <= scans + 2  # at most one plot per object per scan (+ ends)
        # azimuths sweep clockwise within a scan: about one wrap per 4 s
        az = r.measured_rae("SR1", df)[:, 1]
        wraps = np.sum(np.diff(az) < -math.pi)
        assert abs(wraps - scans) <= 2
        assert is_rotating(t, az)  # (the plot tracker's test: the kinds below fail it)
        tracked = {s for s in r.labels("R1")["target_id"]}
        assert 1 <= len(tracked) <= 2


def _spec(kind: str, seed: int, sid: str, duration: float = DUR) -> ms.Sensor:
    """The drawn parameters of sensor ``sid`` (revisit, periods, phases, sites: not in the
    contract's scenario.toml)."""
    sc = draw_multi(kind, seed, duration)
    (spec,) = [s for s in sc.sensors if s.sid == sid]
    return spec


def _backward_share(az: np.ndarray) -> float:
    """Share of consecutive rows whose azimuth (rad) steps backwards (by less than a half
    turn: a wrap forward past north is not a step back)."""
    return float(np.mean(np.mod(np.diff(az), 2 * math.pi) > math.pi))


def test_phased_array_plots_in_no_azimuth_order(root):
    """PA1: plots (no track_id) of every object about every revisit (2 s) on the object's own
    schedule, rows jumping between objects (not a rotating radar's sweep: ``is_rotating``
    says no), each with its own time stamp; Poisson clutter at random times."""
    for seed in (1, 2):
        (r,) = _runs(root, "phased-array", (seed,))
        spec = _spec("phased-array", seed, "PA1")
        assert isinstance(spec, ms.PhasedArray) and spec.revisit == 2.0
        df, t = r.read("PA1")
        lab = r.labels("PA1")
        assert r.sensor["PA1"]["kind"] == "radar" and "SR1" not in r.sensor
        assert df["track_id"].isna().all()
        assert np.all(np.diff(t) >= 0)  # sorted by time ...
        assert np.unique(t).size >= 0.99 * t.size  # ... each plot its own stamp
        az = r.measured_rae("PA1", df)[:, 1]
        assert not is_rotating(t, az)
        assert _backward_share(az) > 0.3
        objects = lab["target_id"].to_numpy()
        labelled = objects[lab["target_id"].notna().to_numpy()]
        assert np.mean(labelled[1:] != labelled[:-1]) > 0.5  # consecutive plots jump objects
        assert 3 <= len(r.ids) <= 5 and set(labelled) == set(r.ids)
        phases = []
        for tid in r.ids:
            mine = t[objects == tid]
            step = np.diff(mine)
            assert abs(np.median(step) - spec.revisit) < 0.2 * spec.revisit, (tid, step)
            assert step.min() > (1 - 2 * spec.jitter) * spec.revisit - 1e-6, tid
            assert mine.size > 0.75 * (DUR / spec.revisit), tid  # Pd 0.9, always in coverage
            phases.append(np.mod(mine - r.truth["time"].min(), spec.revisit))
        # the objects' schedules differ (own phase): not all on one common grid
        centre = np.array([np.angle(np.mean(np.exp(2j * math.pi * ph / spec.revisit)))
                           for ph in phases])
        assert np.abs(np.angle(np.exp(1j * (centre[:, None] - centre)))).max() > 0.2
        clutter = lab["target_id"].isna().to_numpy()
        expected = spec.clutter * DUR / spec.revisit
        assert 0.8 * expected < clutter.sum() < 1.2 * expected
        assert np.all(lab["wild"][clutter] == 0)
        for tid in r.ids:  # clutter does not sit on any object
            z = np.nanmax(r.normalised("PA1", df[clutter], t[clutter], tid), axis=1)
            assert np.mean(z < 6.0) < 0.01
        # the labels are right: within 6 sigma of the true object (wild rows aside) ...
        ok = ~clutter & (lab["wild"].to_numpy() == 0)
        for tid in r.ids:
            rows = ok & (objects == tid)
            assert np.nanmax(r.normalised("PA1", df[rows], t[rows], tid)) < 6.0, tid
        # ... and the sigmas are the declared ones (not smaller, not larger)
        z = np.vstack([r.normalised("PA1", df[ok & (objects == k)], t[ok & (objects == k)], k)
                       for k in r.ids])
        rms = np.sqrt(np.nanmean(z**2, axis=0))
        assert np.all((rms > 0.8) & (rms < 1.2)), rms


def _on_sweep(t: np.ndarray, az: np.ndarray, t0: float, radar: ms.Surveillance,
              tol: float = 1e-5) -> np.ndarray:
    """(M,) bool: time t (s) is when ``radar``'s beam points at azimuth az (rad, at its site):
    t = t0 + phase + period (k + az / 2 pi) for an integer k (within tol of a turn; the
    file's 1 us stamps and the truth interpolation are good to 1e-7)."""
    u = (t - t0 - radar.phase) / radar.period - az / (2 * math.pi)
    return np.abs(u - np.round(u)) < tol


def _reference_to_site(ref: dict, site: dict, rae: np.ndarray) -> np.ndarray:
    """(M,) azimuth (rad) from ``site`` of points at range, azimuth, elevation ``rae`` (M, 3)
    from ``ref`` (both lat, lon, height), through pyproj's ECEF."""
    r, az, el = rae.T
    enu = np.column_stack((r * np.cos(el) * np.sin(az), r * np.cos(el) * np.cos(az),
                           r * np.sin(el)))
    x = ecef(ref["lat"], ref["lon"], ref["height"])[0] + enu @ enu_basis(ref["lat"],
                                                                         ref["lon"])[0]
    d = (x - ecef(site["lat"], site["lon"], site["height"])) @ enu_basis(site["lat"],
                                                                           site["lon"])[0].T
    return np.mod(np.arctan2(d[:, 0], d[:, 1]), 2 * math.pi)


def test_merged_feed_interleaves_two_radars(root):
    """PF1: one file of two rotating radars (A, the declared site, every 4 s; B 3-8 km away,
    every 5 s). Every object plot lies on exactly one radar's sweep (the time its beam points
    at the object from its own site), both radars see every object, clutter comes from both,
    every plot is range/azimuth/elevation from A within the radar's sigmas, the declared
    sigmas cover both radars, and the merged azimuths are not one sweep."""
    for seed in (1, 2):
        (r,) = _runs(root, "merged-feed", (seed,))
        spec = _spec("merged-feed", seed, "PF1")
        assert isinstance(spec, ms.MergedFeed)
        a, b = spec.radars
        assert (a.period, b.period) == (4.0, 5.0) and a.phase != b.phase
        ref = r.sensor["PF1"]["site"]
        assert (ref["lat"], ref["lon"], ref["height"]) == (a.site.lat, a.site.lon,
                                                           a.site.height)
        site_a = {"lat": a.site.lat, "lon": a.site.lon, "height": a.site.height}
        site_b = {"lat": b.site.lat, "lon": b.site.lon, "height": b.site.height}
        sep = np.linalg.norm(ecef(*site_a.values()) - ecef(*site_b.values()))
        assert 2.5e3 < sep < 8.5e3
        declared = r.sigmas("PF1")  # the larger of the two radars' sigmas, per component
        own_a, own_b = (np.array([radar.sigma[k] for k in ("range", "azimuth", "elevation")])
                        for radar in (a, b))
        np.testing.assert_allclose(declared, np.maximum(own_a, own_b), rtol=1e-9)
        df, t = r.read("PF1")
        lab = r.labels("PF1")
        assert df["track_id"].isna().all() and np.all(np.diff(t) >= 0)
        rae = r.measured_rae("PF1", df)
        assert not is_rotating(t, rae[:, 1]) and _backward_share(rae[:, 1]) > 0.2
        t0 = r.truth["time"].min()
        objects = lab["target_id"].to_numpy()
        wild = lab["wild"].to_numpy() == 1
        for tid in r.ids:
            rows = objects == tid
            tt = t[rows]
            from_a = _on_sweep(tt, r.rae_from(site_a, tid, tt)[:, 1], t0, a)
            from_b = _on_sweep(tt, r.rae_from(site_b, tid, tt)[:, 1], t0, b)
            assert np.all(from_a | from_b), tid
            assert np.mean(from_a & from_b) < 0.02, tid
            assert from_a.sum() > 0.7 * DUR / a.period, tid  # Pd 0.9, always in coverage
            assert from_b.sum() > 0.7 * DUR / b.period, tid
            # each radar's own lattice: one plot per scan, at its period
            for radar, mine in ((a, from_a), (b, from_b)):
                k = np.round((tt[mine] - t0 - radar.phase) / radar.period)
                assert np.all(np.diff(k) >= 1), (tid, radar.sid)
            # converted to A's site: within 6 sigma of the object seen from A, with the
            # radar's own sigmas; far off seen from B's site (a real conversion)
            ok = ~wild[rows]
            for radar, own, mine in ((a, own_a, from_a), (b, own_b, from_b)):
                sel = np.flatnonzero(rows)[mine & ok]
                for site, fits in ((site_a, True), (site_b, False)):
                    d = rae[sel] - r.rae_from(site, tid, t[sel])
                    d[:, 1] = wrap(d[:, 1])
                    z = np.nanmax(np.abs(d) / own, axis=1)
                    if fits:
                        assert z.max() < 6.0, (tid, radar.sid)
                    else:
                        assert np.mean(z > 6.0) > 0.9, (tid, radar.sid)
        # clutter of both radars (no noise): on A's sweep at its azimuth from A, or on B's at
        # its azimuth from B (converted back through pyproj)
        clutter = lab["target_id"].isna().to_numpy()
        assert np.all(lab["wild"][clutter] == 0)
        c_a = _on_sweep(t[clutter], rae[clutter, 1], t0, a)
        c_b = _on_sweep(t[clutter], _reference_to_site(ref, site_b, rae[clutter]), t0, b)
        assert np.all(c_a | c_b)
        for radar, mine in ((a, c_a), (b, c_b)):
            expected = radar.clutter * DUR / radar.period
            assert 0.8 * expected < mine.sum() < 1.2 * expected, radar.sid


@pytest.mark.parametrize("kind,sid", [("phased-array", "PA1"), ("merged-feed", "PF1")])
def test_plot_kinds_same_seed_identical_files(root, kind, sid):
    a = simulate_multi(root / f"{kind}_same_a", kind=kind, seed=11, duration=60.0).parent
    b = simulate_multi(root / f"{kind}_same_b", kind=kind, seed=11, duration=60.0).parent
    c = simulate_multi(root / f"{kind}_same_c", kind=kind, seed=12, duration=60.0).parent
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {"truth.csv", "truth_association.csv", "truth_events.json", "scenario.toml",
            "R1.csv", f"{sid}.csv"} <= set(names)
    for name in names:
        assert filecmp.cmp(a / name, b / name, shallow=False), name
    assert not filecmp.cmp(a / f"{sid}.csv", c / f"{sid}.csv", shallow=False)


def test_noise_free_measurements_exact(root):
    """noise=False: every labelled fixed-site row equals the truth geometry of its object."""
    r = Run(simulate_multi(root / "exact", kind="mixed", seed=5, duration=60.0, noise=False))
    for sid in r.fixed_sites():
        df, t = r.read(sid)
        lab = r.labels(sid)
        assert lab["wild"].sum() == 0
        for tid in lab["target_id"].dropna().unique():
            rows = (lab["target_id"] == tid).to_numpy()
            d = r.measured_rae(sid, df[rows]) - r.site_rae(sid, tid, t[rows])
            ranged = np.isfinite(d[:, 0])
            np.testing.assert_allclose(d[ranged, 0], 0, atol=2e-3, err_msg=f"{sid} {tid}")
            np.testing.assert_allclose(wrap(d[:, 1]), 0, atol=2e-8, err_msg=f"{sid} {tid}")
            np.testing.assert_allclose(d[:, 2], 0, atol=2e-8, err_msg=f"{sid} {tid}")


# ------------------------------------------------------------------------------------------
# arguments and CLI
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs,needle", [
    (dict(kind="swarm"), "objects='swarm'"),
    (dict(kind="crossing", n_objects=4), "n_objects=4"),
    (dict(kind="surveillance", n_objects=2), "n_objects=2"),
    (dict(kind="mixed", duration=10.0), "duration=10.0"),
    (dict(kind="mixed", duration=float("nan")), "duration=nan"),
])
def test_bad_arguments(tmp_path, kwargs, needle):
    with pytest.raises(ConfigError, match="simulate: ") as info:
        simulate_multi(tmp_path / "x", seed=1, **{"duration": 60.0, **kwargs})
    assert needle in str(info.value)
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("kind,n", [("crossing", 3), ("formation", 4), ("surveillance", 5),
                                    ("mixed", 2)])
def test_n_objects(tmp_path, kind, n):
    r = Run(simulate_multi(tmp_path, kind=kind, seed=2, duration=40.0, n_objects=n))
    assert len(r.ids) == n


def test_cli_objects(tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["simulate", str(tmp_path / "a"), "--objects", "lock-jump",
                               "--seed", "4", "--duration", "60", "-q"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "a" / "truth_association.csv").is_file()
    direct = simulate_multi(tmp_path / "b", kind="lock-jump", seed=4, duration=60.0).parent
    for name in ("R1.csv", "scenario.toml", "truth_association.csv"):
        assert filecmp.cmp(tmp_path / "a" / name, direct / name, shallow=False), name
    for args, needle in ((["--objects", "swarm"], "objects='swarm'"),
                         (["--objects", "mixed", "--faults", "registration"], "--faults"),
                         (["--objects", "mixed", "--sensors", "R1"], "--sensors"),
                         (["--n-objects", "3"], "--n-objects needs --objects")):
        res = runner.invoke(main, ["simulate", str(tmp_path / "e"), *args])
        assert res.exit_code == 2, res.output
        assert res.stderr.startswith("rangeproc: error: simulate: ") and needle in res.stderr
        assert res.stderr.count("\n") == 1
    assert not (tmp_path / "e").exists()
    # the help names every kind (click may wrap a name at its hyphen)
    res = runner.invoke(main, ["simulate", "--help"])
    assert res.exit_code == 0
    listed = re.sub(r"\s+", "", res.output)
    assert all(kind in listed for kind in MULTI_KINDS), res.output
    # without --objects: today's single-object scenario, no association truth
    res = runner.invoke(main, ["simulate", str(tmp_path / "s"), "--duration", "20", "-q"])
    assert res.exit_code == 0 and not (tmp_path / "s" / "truth_association.csv").exists()
