"""Stage 5, fuse: the estimator's settings from the config and the centralised filter and
smoother over every object's rows (``fusion.centralised``), objects side by side."""
from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from rangeproc.config import Config, TargetSettings
from rangeproc.errors import DataError
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.batch import merge
from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.estimator_types import EstimatorSettings, FusionResult
from rangeproc.fusion.initialise import NoPositionFix, Prior, given_prior
from rangeproc.fusion.refraction_rows import RefractionSettings
from rangeproc.fusion.registration import SensorCalibration
from rangeproc.parallel import thread_map
from rangeproc.tracking.routing import (
    target_of,
)


log = logging.getLogger(__name__)


def estimator_settings(cfg: Config) -> EstimatorSettings:
    """The estimator's settings: the ``[processing]`` section (read by name; the forward
    filter follows from ``processing.filter``) with what the sensors add, the calibration
    terms and the refraction."""
    return EstimatorSettings(processing=cfg.processing,
                             calibration=calibration_specs(cfg) if cfg.processing.calibration
                             else (), refraction=refraction_settings(cfg))


def refraction_settings(cfg: Config) -> RefractionSettings | None:
    """The refraction removed from the rows (``processing.refraction``; None for "none"):
    each radar's ``refractivity``, each theodolite's ``optical_refractivity``."""
    p = cfg.processing
    if p.refraction == "none":
        return None
    surface_n = {"radar": p.refractivity, "theodolite": p.optical_refractivity}
    return RefractionSettings(model=p.refraction,
                              surface_n=tuple(surface_n.get(s.kind, 0.0) for s in cfg.sensors),
                              moving=tuple(s.platform is not None for s in cfg.sensors),
                              origin_height=cfg.origin.height)


def calibration_specs(cfg: Config) -> tuple[SensorCalibration | None, ...]:
    """What the registration may estimate per sensor (index as in ``cfg.sensors``): the
    config's ``calibrate`` terms; GPS is the absolute reference of position and time, and
    MISTRAM's latency is estimated only against a GPS on the same target."""
    with_gps = {target_of(s, cfg) for s in cfg.sensors if s.kind == "gps"}
    specs: list[SensorCalibration | None] = []
    for s in cfg.sensors:
        names = s.calibrate
        if s.kind == "gps" or (s.kind == "mistram" and target_of(s, cfg) not in with_gps):
            names = ()
        specs.append(SensorCalibration(s.kind, s.platform is not None, names)
                     if s.kind != "ins" else None)
    return tuple(specs)


def target_prior(target: TargetSettings, frame: RangeFrame) -> Prior | None:
    """The target's ``initial`` state in the range ENU frame, or None."""
    init = target.initial
    if init is None:
        return None
    p = init.position
    return given_prior(init.time, frame.to_enu(p.lat, p.lon, p.height).reshape(3),
                            np.asarray(init.velocity), init.sigma_position, init.sigma_velocity)


def _needs_initial(cfg: Config, target_id: str, why: str) -> DataError:
    """Exit-2 error for a target whose data cannot start a track: show the key to give."""
    index = next((i for i, t in enumerate(cfg.targets) if t.id == target_id), 0)
    return DataError(
        f"{cfg.path.name}: targets[{index}].initial: target {target_id}: {why}; give its "
        f"state, e.g. [[targets]] id = \"{target_id}\" initial = {{ time = ..., lat = ..., "
        "lon = ..., height = ..., ve = ..., vn = ..., vu = ..., sigma_position = 10.0, "
        "sigma_velocity = 5.0 }")


def fuse_objects(cfg: Config, parts_of: dict, sensor_ids: tuple[str, ...],
                 settings: EstimatorSettings, priors: dict[str, Prior],
                 tick: Callable[..., None]) -> list[tuple[str, FusionResult]]:
    """Stage 5: the centralised smoother over every object's rows, objects side by side in
    threads (``rangeproc.parallel``; the results do not depend on the thread count).

    parts_of: object id -> its row parts (emptied as objects are handed out); returns
    (object id, result) in ``parts_of``'s order, leaving out objects without measurements or
    (undeclared ones) without a position fix. A declared target without a position fix is an
    exit-2 error."""
    order = list(parts_of)
    jobs = []
    for oid in order:
        parts = parts_of.pop(oid)
        if not parts:
            log.warning("target %s: no measurements", oid)
            tick(1 + settings.processing.noise_passes, oid)
        else:
            jobs.append((oid, parts))

    def fuse_one(oid: str, parts: list) -> FusionResult | None:
        batch = merge(parts, sensor_ids)
        parts.clear()
        try:
            return fuse_target(batch, cfg.output.rate_hz, settings,
                               tick=lambda n=1, note="", t=oid: tick(n, f"{t} {note}"),
                               prior=priors.get(oid))
        except NoPositionFix as exc:
            if oid in priors:
                raise _needs_initial(cfg, oid, str(exc)) from None
            log.warning("object %s left out: %s", oid, exc)
            return None

    results = dict(zip([oid for oid, _ in jobs],
                       thread_map(lambda job: fuse_one(*job), jobs,
                                  cost=lambda job: sum(len(rows.t) for _, rows in job[1]))))
    return [(oid, results[oid]) for oid in order if results.get(oid) is not None]
