"""Stage 2, screen: absurd but parseable data removed before estimation, with a reason per edit
(``editing.screen``: time checks, physical limits, speed test, Hampel pre-edit), and the angle
columns checked against their unit (``editing.units``)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from rangeproc.config import Config
from rangeproc.editing.record import EditRecord
from rangeproc.editing.screen import screen_logs
from rangeproc.editing.units import UnitSuspicion, angle_unit_checks
from rangeproc.io.logs import SensorLog


@dataclass(frozen=True)
class Screened:
    """The screened logs by sensor id, the edit record of what was removed, and the sensors
    whose angles also fit a smaller unit (judged again after fusion, ``stages.products``)."""

    logs: dict[str, SensorLog]
    edits: EditRecord
    unit_suspicions: dict[str, UnitSuspicion]


def screen(cfg: Config, raw: dict[str, SensorLog],
           tick: Callable[..., None] = lambda *a, **k: None) -> Screened:
    """Screen every sensor's read log (``raw``, by id).

    Raises:
        DataError: angle values impossible in their unit, impossible time stamps, a sensor on
            another clock scale than the others.
    """
    suspicions = angle_unit_checks(cfg.sensors, raw)
    edits = EditRecord()
    logs = screen_logs(cfg, raw, edits, tick)
    return Screened(logs, edits, suspicions)
