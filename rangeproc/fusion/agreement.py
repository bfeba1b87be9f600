"""Does each sensor see what the others see? A sensor whose rows sit far from every other view.

A sensor with a wrong site, angle unit or clock offset still makes a smooth trajectory from its
own rows, just in the wrong place: the several-objects synthesis then reports it as an object of
its own that no other sensor sees. :func:`far_sensors` finds a sensor all of whose rows went to
one object that only it sees, while other sensors' objects are in the air at the same times,
and measures how far apart they are: the median over the sensor's epochs of the distance to the
nearest object the other sensors see. Beyond :data:`FAR_M` and :data:`FAR_SIGMAS` times the two
position sigmas combined, the sensor is reported (one line, :func:`far_line`). Nothing here
changes the estimate: a lone sensor may truly watch another object, and the line says so.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rangeproc.results import TrackEstimate

FAR_M = 1000.0       #: m, a sensor's object this far from every other view is reported
FAR_SIGMAS = 10.0    #: ... and this many combined 1-sigma position uncertainties
MIN_EPOCHS = 10      #: common epochs needed to judge


@dataclass(frozen=True)
class FarSensor:
    """Sensor ``sensor_id``'s objects ``object_ids`` (which only it sees) lie ``distance_m``
    (median, m) from the nearest object the sensors ``others`` see, over ``n_epochs`` common
    epochs."""

    sensor_id: str
    object_ids: tuple[str, ...]
    distance_m: float
    n_epochs: int
    others: tuple[str, ...]


def _sensors_of(track: TrackEstimate) -> set[str]:
    if track.sensors is None:
        return set()
    return {name for names in set(track.sensors) for name in str(names).split(",") if name}


def _sigma(track: TrackEstimate) -> np.ndarray:
    """(K,) m: root of the trace of the position covariance."""
    return np.sqrt(np.maximum(np.trace(track.P[:, :3, :3], axis1=1, axis2=2), 0.0))


def _nearest(track: TrackEstimate, others: Sequence[TrackEstimate]
             ) -> tuple[np.ndarray, np.ndarray]:
    """Per epoch of ``track``: the distance (m) to the nearest of ``others`` at that time
    (linear interpolation within each other track's span, NaN outside all) and that track's
    position sigma (m)."""
    best = np.full(track.time.size, np.inf)
    sig = np.full(track.time.size, np.nan)
    for q in others:
        if q.time.size < 2:
            continue
        inside = (track.time >= q.time[0]) & (track.time <= q.time[-1])
        if not inside.any():
            continue
        t = track.time[inside]
        pos = np.column_stack([np.interp(t, q.time, q.x[:, i]) for i in range(3)])
        d = np.full(track.time.size, np.inf)
        d[inside] = np.linalg.norm(track.x[inside, :3] - pos, axis=1)
        closer = d < best
        best[closer] = d[closer]
        sig[closer] = np.interp(track.time[closer], q.time, _sigma(q))
    best[~np.isfinite(best)] = np.nan
    return best, sig


def far_sensors(tracks: Sequence[TrackEstimate], sensor_ids: Sequence[str]) -> list[FarSensor]:
    """The sensors (of ``sensor_ids``) whose rows all went to objects no other sensor
    contributes to, lying far from every object the other sensors see at the same times."""
    seen = {tr.target_id: _sensors_of(tr) for tr in tracks}
    out = []
    for sid in sensor_ids:
        own = [tr for tr in tracks if sid in seen[tr.target_id]]
        if not own or any(seen[tr.target_id] != {sid} for tr in own):
            continue
        others = [tr for tr in tracks if sid not in seen[tr.target_id]]
        pairs = [_nearest(tr, others) + (_sigma(tr),) for tr in own]
        dist = np.concatenate([p[0] for p in pairs])
        sig = np.hypot(np.concatenate([p[2] for p in pairs]),
                       np.concatenate([p[1] for p in pairs]))
        ok = np.isfinite(dist)
        if ok.sum() < MIN_EPOCHS:
            continue
        d = float(np.median(dist[ok]))
        if d > max(FAR_M, FAR_SIGMAS * float(np.median(sig[ok]))):
            names = sorted(set().union(*(seen[tr.target_id] for tr in others)))
            out.append(FarSensor(sid, tuple(tr.target_id for tr in own), d, int(ok.sum()),
                                 tuple(names)))
    return out


def far_line(far: FarSensor, file_name: str) -> str:
    """The one line that reports a far sensor."""
    return (f"{file_name}: sensor {far.sensor_id}'s rows, converted, sit "
            f"{far.distance_m / 1e3:.3g} km (median over {far.n_epochs} epochs) from every "
            f"other sensor's view of the objects in the air at the same times "
            f"({', '.join(far.others)}) and form {_objects(far.object_ids)} that only it sees: "
            "if it watches the same object, check its site, units (angle_unit, metres) and "
            "time_offset")


def pair_line(a: FarSensor, b: FarSensor, files: dict[str, str]) -> str:
    """The one line for two sensors that only see each other's objects far away (either may
    be the wrong one)."""
    verb = "sits" if len(a.object_ids) == 1 else "sit"
    return (f"{files[a.sensor_id]} and {files[b.sensor_id]} disagree: sensor {a.sensor_id}'s "
            f"{_objects(a.object_ids)} {verb} {a.distance_m / 1e3:.3g} km (median over "
            f"{a.n_epochs} epochs) from sensor {b.sensor_id}'s {_objects(b.object_ids)}: if "
            "they watch the same object, check their sites, units (angle_unit, metres) and "
            "time_offset")


def _objects(ids: Sequence[str]) -> str:
    return f"object {ids[0]}" if len(ids) == 1 else f"objects {', '.join(ids)}"
