"""Stage 3, assemble: every non-INS row with its sensor's geometry in the range frame (a fixed
site's axes, a GPS receiver's local ENU, a platform's deck axes from its INS;
``fusion.assemble``)."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rangeproc.config import Config
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.assemble import Assembled, assemble_sensor
from rangeproc.io.logs import SensorLog
from rangeproc.parallel import thread_map




def assemble_all(cfg: Config, frame: RangeFrame, logs: dict[str, SensorLog],
                 tick: Callable[..., None] = lambda *a, **k: None) -> dict[str, Assembled]:
    """Stage 3: measurement rows with geometry for every non-INS sensor (sensors side by side
    in threads, ``rangeproc.parallel``)."""
    ins = {s.id: logs[s.id] for s in cfg.sensors if s.kind == "ins"}
    sensors = [s for s in cfg.sensors if s.kind != "ins"]
    out = {}
    for s, rows in zip(sensors, thread_map(lambda s: assemble_sensor(logs[s.id], s, frame, ins),
                                           sensors, cost=lambda s: len(logs[s.id]))):
        out[s.id] = rows
        tick(1, s.id)
    return out


def sensor_sites(cfg: Config, frame: RangeFrame, rows: dict[str, Assembled]
                 ) -> dict[str, np.ndarray]:
    """Each sensor's position for the report (range ENU m): a fixed site (3,), a platform
    sensor's decimated track (K, 3), each MISTRAM station (3,)."""
    sites: dict[str, np.ndarray] = {}
    for s in cfg.sensors:
        if s.site is not None:
            sites[s.id] = frame.site(s.site)[0].reshape(3)
        elif s.platform is not None and s.id in rows and len(rows[s.id].rows.t):
            track = rows[s.id].rows.s                  # platform sensor track, decimated
            sites[s.id] = track[::max(1, len(track) // 2000)].copy()
        for st in s.stations:
            sites[st.id] = frame.site(st.site)[0].reshape(3)
    return sites
