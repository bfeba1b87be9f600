"""Plausibility of a sensor's angle unit: do its angle values fit the ``angle_unit`` it was given?

Angles are read in the sensor's configured unit (data contract section 1: ``deg``, ``rad`` or
``mil``, 6400 mil per circle). A file written in another unit is a common hand-made mistake and
silently wrong: radians read as degrees are all within 6.3 degrees, degrees read as radians are
mostly impossible. The values alone say which units they can be in (:func:`fitting_units`):

* a *circular* angle (azimuth, yaw, roll) lies within [-C/2, C] for a full circle C,
* an *elevation-like* angle (elevation, pitch) within [-C/4, C/4],

each with :data:`TOLERANCE` of the circle for noise. Two verdicts follow (:func:`angle_unit_check`):

* **impossible**: more than :data:`IMPOSSIBLE_FRACTION` of a column's values lie outside what
  the configured unit allows (elevations of 9 "rad", azimuths of 5,000 "deg"): the file cannot
  be meant so; :class:`~rangeproc.errors.DataError` naming the file, the column, the values and
  the unit they fit.
* **suspect**: every angle of the sensor also fits a smaller unit (radians in a degree file,
  degrees in a mil file) and at least :data:`MIN_VALUES` non-zero values were measured:
  possible (a target that stays within 6 degrees of north, low on the horizon) but unlikely;
  a one-line
  :class:`UnitSuspicion` that the pipeline reports, joined with the geometry check of
  ``fusion.sensor_geometry`` when the sensor's rows also sit far from the other sensors'.
  A zero is zero in every unit, so zeros are no evidence: an INS whose attitude is all zero
  (a platform whose rows are already north-referenced and level, as in converted plot data)
  is not suspected, and a column of zeros is left out of the suspicion's line.
"""
from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rangeproc.config import SensorSettings
from rangeproc.errors import DataError
from rangeproc.io.logs import SensorLog
from rangeproc.settings import ANGLE_TO_RADIANS

#: Full circle in each unit.
CIRCLE = {"rad": 2.0 * math.pi, "deg": 360.0, "mil": 6400.0}
#: Units from the smallest full circle to the largest.
BY_SIZE = ("rad", "deg", "mil")
#: Angle columns per kind, as (circular, elevation-like).
ANGLE_COLUMNS = {"radar": (("azimuth",), ("elevation",)),
                 "theodolite": (("azimuth",), ("elevation",)),
                 "ins": (("roll", "yaw"), ("pitch",))}
TOLERANCE = 0.01            #: share of a circle by which a value may overshoot its unit's range
IMPOSSIBLE_FRACTION = 0.5   #: share of values outside the unit that makes a column impossible
MIN_VALUES = 5              #: values needed before a whole sensor is suspected


@dataclass(frozen=True)
class UnitSuspicion:
    """A sensor whose every angle also fits the smaller unit ``likely``: ``finding`` says so
    (file, configured unit, the values' ranges); :attr:`text` is the warning line, the finding
    with its advice."""

    sensor_id: str
    configured: str
    likely: str
    finding: str

    @property
    def text(self) -> str:
        return f"{self.finding} (set angle_unit = \"{self.likely}\" if so)"


def _fits(values: np.ndarray, unit: str, circular: bool) -> np.ndarray:
    """(N,) bool: which values lie within the range ``unit`` allows for the column type."""
    c = CIRCLE[unit]
    tol = TOLERANCE * c
    if circular:
        return (values >= -0.5 * c - tol) & (values <= c + tol)
    return np.abs(values) <= 0.25 * c + tol


def fitting_units(values: np.ndarray, circular: bool) -> tuple[str, ...]:
    """The units (smallest circle first) in which every finite value of ``values`` (as
    written in the file) is a possible angle of its type."""
    v = values[np.isfinite(values)]
    return tuple(u for u in BY_SIZE if _fits(v, u, circular).all())


def _file_values(log: SensorLog, name: str, unit: str) -> np.ndarray:
    """The column ``name`` as written in the file (the log holds radians)."""
    v = log.columns[name]
    return v[np.isfinite(v)] / ANGLE_TO_RADIANS[unit]


def _range_text(v: np.ndarray) -> str:
    return f"[{v.min():.4g}, {v.max():.4g}]"


def _check_swapped(found: dict[str, tuple[np.ndarray, bool]], unit: str, name: str) -> None:
    """DataError when the elevation column is impossible in ``unit`` but would fit as the
    azimuth and the azimuth column as the elevation: the two columns look swapped."""
    if "azimuth" not in found or "elevation" not in found:
        return
    az, el = found["azimuth"][0], found["elevation"][0]
    if not (az.size and el.size) or np.mean(~_fits(el, unit, False)) <= IMPOSSIBLE_FRACTION:
        return
    if _fits(az, unit, False).all() and _fits(el, unit, True).all():
        raise DataError(
            f"{name}: columns 'azimuth' and 'elevation' look swapped: the elevations "
            f"{_range_text(el)} cannot be elevations in {unit}, but fit azimuths, and the "
            f"azimuths {_range_text(az)} fit elevations")


def angle_unit_check(log: SensorLog, s: SensorSettings) -> UnitSuspicion | None:
    """Check the angle columns of one sensor's log against its ``angle_unit``.

    Returns a :class:`UnitSuspicion` when every non-zero angle (at least :data:`MIN_VALUES`
    of them) also fits a smaller unit, else None.

    Raises:
        DataError: a column whose values mostly cannot be in the configured unit, naming the
            file, the column, the values' range and the unit they fit.
    """
    groups = ANGLE_COLUMNS.get(log.kind)
    if groups is None:
        return None
    unit = s.angle_unit
    columns = [(name, circular) for circular, names in zip((True, False), groups)
               for name in names]
    found = {name: (_file_values(log, name, unit), circular) for name, circular in columns}
    _check_swapped(found, unit, s.file.name)
    for name, (v, circular) in found.items():
        if v.size and np.mean(~_fits(v, unit, circular)) > IMPOSSIBLE_FRACTION:
            fit = fitting_units(v, circular)
            hint = (f"; they fit {fit[0]} (set angle_unit = \"{fit[0]}\" if so)" if fit
                    else "")
            raise DataError(
                f"{s.file.name}: column '{name}': {np.mean(~_fits(v, unit, circular)):.0%} of "
                f"the values lie outside what angle_unit = \"{unit}\" allows (values in "
                f"{_range_text(v)}){hint}")
    # a zero fits every unit: only non-zero values say anything about the unit
    measured = {name: (v[v != 0.0], c) for name, (v, c) in found.items() if (v != 0.0).any()}
    if not measured or sum(v.size for v, _ in measured.values()) < MIN_VALUES:
        return None
    smaller = BY_SIZE[:BY_SIZE.index(unit)]
    common = [u for u in smaller
              if all(u in fitting_units(v, c) for v, c in measured.values())]
    if not common:
        return None
    likely = common[-1] if unit == "mil" else common[0]
    ranges = ", ".join(f"every {name} within {_range_text(v)}"
                       for name, (v, _) in measured.items())
    return UnitSuspicion(
        s.id, unit, likely,
        f"{s.file.name}: angle_unit = \"{unit}\" but {ranges}: the values look like {likely}")


def angle_unit_checks(sensors: Sequence[SensorSettings], logs: Mapping[str, SensorLog]
                      ) -> dict[str, UnitSuspicion]:
    """:func:`angle_unit_check` of every sensor (read logs by id); the suspicions by id.

    Raises:
        DataError: the first sensor (config order) with an impossible angle column.
    """
    found = {}
    for s in sensors:
        if (suspicion := angle_unit_check(logs[s.id], s)) is not None:
            found[s.id] = suspicion
    return found


#: A stated sigma this many times larger or smaller than the noise the data show is reported:
#: beyond any conservative margin, the size of a unit mistake (a sigma in degrees for a
#: radian file is 57x, in mrad 1000x).
SIGMA_RATIO = 10.0


def absent_columns(log: SensorLog) -> frozenset[str]:
    """The measurement columns of ``log`` that hold no value at all (absent from the file or
    empty in every row): a sensor states nothing about them, whatever rows the estimator
    makes in their place (a 2-D radar's elevation 0, ``fusion.assemble``)."""
    return frozenset(name for name, v in log.columns.items() if not np.isfinite(v).any())


def stated_sigma_line(s: SensorSettings, noise: Mapping[str, Mapping],
                      absent: Collection[str] = ()) -> str | None:
    """One line when a stated a-priori sigma of sensor ``s`` is more than
    :data:`SIGMA_RATIO` times larger or smaller than the noise estimated from its residuals
    (``noise``: ``summary.json``'s ``sensors.<id>.noise``, SI), shown in the sensor's units;
    None when every stated sigma is plausible. Components in ``absent`` (columns the file
    does not measure, :func:`absent_columns`) are not checked: their stated sigma is not
    used, and their residuals are not the sensor's."""
    off = []
    for name, n in noise.items():
        if name in absent:
            continue
        stated, found = n.get("apriori"), n.get("estimated")
        if not stated or not found or not np.isfinite(found) or found <= 0.0:
            continue
        ratio = stated / found
        if max(ratio, 1.0 / ratio) > SIGMA_RATIO:
            scale, unit = ((1.0 / ANGLE_TO_RADIANS[s.angle_unit], s.angle_unit)
                           if n.get("unit") == "rad" else (1.0, n.get("unit", "")))
            off.append(f"{name} {stated * scale:.3g} {unit} is {ratio:.3g}x the "
                       f"{found * scale:.3g} {unit} its residuals show")
    if not off:
        return None
    return (f"{s.file.name}: stated sigma {'; '.join(off)}: sigmas are 1-sigma in the "
            "sensor's units (angle_unit for angles, m, m/s)")
