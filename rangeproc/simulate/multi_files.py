"""Files of a multi-object scenario: scenario.toml, truth.csv, truth_association.csv and
truth_events.json (see :mod:`rangeproc.simulate.multi`)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from rangeproc.simulate import multi_sensors as ms
from rangeproc.simulate import sensors as sn
from rangeproc.simulate.files import text_column
from rangeproc.simulate.scenario import _geo_toml, _sigma_units, _toml, trajectory_truth

TRUTH_ASSOCIATION = "truth_association.csv"
TRUTH_EVENTS = "truth_events.json"


@dataclass(frozen=True, slots=True)
class MultiScenario:
    """Everything drawn for one kind and seed; ``ids[k]`` names object k (T.. declared, U..
    undeclared); sensors in config order."""

    kind: str
    seed: int
    world: ms.World
    ids: tuple[str, ...]
    sensors: tuple[ms.Sensor, ...]
    events: tuple[dict[str, Any], ...]




def sensor_entry(spec: ms.Sensor, ids: tuple[str, ...]) -> dict[str, object]:
    """The ``[[sensors]]`` table of one sensor (contract keys; angles in its unit)."""
    deg = sn.ANGLE_SCALE["deg"]
    e: dict[str, object] = {"id": spec.sid}
    if isinstance(spec, ms.SiteSensor):
        e.update(kind=spec.kind, file=spec.file, site=spec.site, angle_unit=spec.unit,
                 sigma=_sigma_units(spec.sigma, sn.ANGLE_SCALE[spec.unit]))
    elif isinstance(spec, ms.PLOT_SENSORS):
        e.update(kind="radar", file=spec.file, site=spec.site, angle_unit="deg",
                 sigma=_sigma_units(spec.sigma, deg))
    elif isinstance(spec, ms.ShipRadar):
        e.update(kind="radar", file=spec.file, platform="SHIP_INS", lever_arm=list(spec.lever),
                 angle_unit="deg", sigma=_sigma_units(spec.sigma, deg))
    elif isinstance(spec, ms.ShipIns):
        att = spec.sigma["attitude"] * deg
        e.update(kind="ins", file=spec.file, angle_unit="deg",
                 sigma={"roll": att, "pitch": att, "yaw": att,
                        "position": spec.sigma["position"]})
    elif isinstance(spec, ms.GpsReceiver):
        e.update(kind="gps", file=spec.file, target=ids[spec.obj], sigma=dict(spec.sigma))
    else:
        e.update(kind="mistram", file=spec.file, target=ids[spec.obj],
                 sigma={"range_rate": spec.sigma},
                 stations=[{"id": s, "lat": g.lat, "lon": g.lon, "height": g.height}
                           for s, g in spec.stations])
    e["time_offset"] = getattr(spec, "offset", 0.0)
    return e


def config_text(sc: MultiScenario, written: list[ms.Sensor]) -> str:
    """scenario.toml: contract sections and keys only; targets = the declared objects."""
    w = sc.world
    lines = [f"# simulated multi-object scenario (rangeproc.simulate), kind {sc.kind}, seed "
             f"{sc.seed}, duration {w.duration:g} s; truth in truth.csv and "
             f"{TRUTH_ASSOCIATION}", "",
             "[range]", f"origin = {_geo_toml(w.origin)}", "", "[output]", 'dir = "out"',
             "rate_hz = 10.0"]
    for tid in sorted(i for i in sc.ids if i.startswith("T")):
        lines += ["", "[[targets]]", f"id = {_toml(tid)}"]
    for spec in written:
        lines += ["", "[[sensors]]"] + [f"{k} = {_toml(val)}"
                                        for k, val in sensor_entry(spec, sc.ids).items()]
    return "\n".join(lines) + "\n"


def truth_table(sc: MultiScenario) -> dict[str, np.ndarray]:
    """truth.csv columns of every object (sorted by target_id, then time)."""
    w = sc.world
    parts = [trajectory_truth(w.flights[k], sc.ids[k], w.origin, w.t0 + w.duration)
             for k in sorted(range(len(sc.ids)), key=lambda k: sc.ids[k])]
    return {c: np.concatenate([p[c] for p in parts]) for c in parts[0]}


def association_table(sc: MultiScenario, tables: list[tuple[ms.Sensor, ms.SensorTable]]
                      ) -> dict[str, Any]:
    """truth_association.csv: sensor, row (0-based data row of its file), target_id (empty =
    clutter), wild (1 = a wild error was injected) of every radar/theodolite row."""
    sid: list[str] = []
    tid: list[str | None] = []
    rows, wild = [], []
    for spec, tab in tables:
        if tab.obj is None or tab.wild is None:
            continue
        sid += [spec.sid] * tab.obj.size
        tid += [sc.ids[k] if k >= 0 else None for k in tab.obj]
        rows.append(np.arange(tab.obj.size, dtype=np.int64))
        wild.append(tab.wild.astype(np.int64))
    return {"sensor": text_column(list(sid)), "row": np.concatenate(rows),
            "target_id": text_column(tid), "wild": np.concatenate(wild)}


def events_json(sc: MultiScenario) -> str:
    """truth_events.json: kind, seed, objects (declared or not) and events with object ids."""
    def named(e: dict[str, Any]) -> dict[str, Any]:
        out = dict(e)
        for key in ("from", "to"):
            if key in out:
                out[key] = sc.ids[out[key]]
        if "objects" in out:
            out["objects"] = [sc.ids[k] for k in out["objects"]]
        return out

    doc = {"kind": sc.kind, "seed": sc.seed,
           "objects": {i: {"declared": i.startswith("T")} for i in sorted(sc.ids)},
           "events": [named(e) for e in sc.events]}
    return json.dumps(doc, indent=2) + "\n"
