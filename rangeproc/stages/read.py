"""Stage 1, read: every sensor file into a :class:`~rangeproc.io.logs.SensorLog` (SI units,
radians, sorted by time; ``io.readers``), through the C library's allocator rather than
Arrow's own pool (``io.memory``: what the parse frees stays usable by the stages after)."""
from __future__ import annotations

from collections.abc import Callable


from rangeproc.config import Config
from rangeproc.io.logs import SensorLog
from rangeproc.io.memory import system_arrow_pool
from rangeproc.io.readers import read_sensor


def read_all(cfg: Config, tick: Callable[..., None] = lambda *a, **k: None
             ) -> dict[str, SensorLog]:
    """Stage 1: read every sensor file (SensorLog per sensor id)."""
    logs = {}
    with system_arrow_pool():
        for s in cfg.sensors:
            logs[s.id] = read_sensor(s)
            tick(1, s.id)
    return logs
