"""``summary.json`` ``sensors.<id>.calibration``: the registration's result per sensor, in the
data contract's names, SI units and signs (section 4).

Each term is ``{"estimate", "sigma", "unit"}`` plus ``"applied"`` (the rows were corrected:
the estimate is significant, ``fusion.registration.SIGNIFICANCE``) and ``"given"`` (a known
correction from the config, included in the estimate); a term the data cannot separate is
``{"estimate": null, "sigma": null, "unobservable": reason}``; a term the config opted out of
is ``{"estimate": given or null, "sigma": null, "unit", "not_estimated": reason}``.
``latency`` is the residual latency after the configured ``time_offset`` (contract section 4),
never the offset itself, which is reported apart (:func:`time_offset_summary`). Estimates
of the same sensor from several spans or targets are combined by inverse variance.
"""
from __future__ import annotations

import datetime as _dt
from collections.abc import Sequence

import numpy as np

from rangeproc.config import SensorSettings, calibration_terms
from rangeproc.fusion.registration import UNIT, Calibration, SensorCalibration
from rangeproc.summary_types import CalibrationTerm, TimeOffsetRecord

GPS_REFERENCE = "GPS is the absolute reference of position and time"
MISTRAM_REFERENCE = "no GPS on this target: MISTRAM is the time reference"


def sensor_terms(s: SensorSettings) -> tuple[str, ...]:
    """The calibration terms the contract reports for this sensor."""
    return calibration_terms(s.kind, s.platform is not None)


def _given(s: SensorSettings, name: str) -> float:
    """The known correction of a term from the config. The latency has none here: the
    configured ``time_offset`` is applied to the stamps before anything else and reported on
    its own (:func:`time_offset_summary`); ``latency`` is the residual the data show after it."""
    return 0.0 if name == "latency" else s.calibration.get(name, 0.0)


#: s: a configured ``time_offset`` at least this large aligns a clock scale (seconds of day or
#: of the GPS week onto the Unix scale of ISO-stamped files); a smaller one corrects a known
#: latency. Only the wording of the summary and the page depends on it.
CLOCK_ALIGNMENT_S = 3600.0


def time_offset_summary(s: SensorSettings) -> TimeOffsetRecord | None:
    """``summary.json`` ``sensors.<id>.time_offset``: the configured offset (s) added to the
    sensor's stamps, what it does, and the instant it names when it aligns a clock scale; None
    when no offset is configured."""
    if s.time_offset == 0.0:
        return None
    if abs(s.time_offset) < CLOCK_ALIGNMENT_S:
        return {"value": s.time_offset, "unit": "s", "role": "known latency correction"}
    return {"value": s.time_offset, "unit": "s", "role": "clock scale alignment",
            "instant": (_dt.datetime.fromtimestamp(s.time_offset, _dt.timezone.utc)
                        .isoformat().replace("+00:00", "Z"))}


def _estimates(index: int, name: str, cals: Sequence[Calibration]
               ) -> tuple[list[tuple[float, float, bool]], str]:
    """(estimate, variance, applied) of each solve that estimated the term, and the first
    reason of a solve that did not."""
    found, reason = [], ""
    for cal in cals:
        for k, term in enumerate(cal.terms):
            if term.sensor != index or term.name != name:
                continue
            if cal.reason[k] == "":
                found.append((float(cal.estimate[k]), float(cal.cov[k, k]),
                              bool(cal.applied[k] != 0.0)))
            else:
                reason = reason or cal.reason[k]
    return found, reason


def calibration_summary(s: SensorSettings, index: int, spec: SensorCalibration | None,
                        cals: Sequence[Calibration]) -> dict[str, CalibrationTerm]:
    """The ``calibration`` entry of sensor ``s`` (index ``index``) from the registrations
    ``cals`` of every span it took part in; ``spec`` what it was allowed to estimate (None:
    registration off)."""
    out: dict[str, CalibrationTerm] = {}
    for name in sensor_terms(s):
        given = _given(s, name)
        extra = {"given": given} if given != 0.0 else {}
        if spec is None or name not in spec.names:
            if s.kind == "gps":
                out[name] = {"estimate": None, "sigma": None, "unobservable": GPS_REFERENCE}
            elif s.kind == "mistram" and spec is not None:
                out[name] = {"estimate": None, "sigma": None,
                             "unobservable": MISTRAM_REFERENCE}
            else:
                why = "registration off ([processing] calibration = false)" if spec is None \
                    else "not asked for (the sensor's calibrate key)"
                out[name] = {"estimate": given if given else None, "sigma": None,
                             "unit": UNIT[name], "not_estimated": why, **extra}
            continue
        found, reason = _estimates(index, name, cals)
        if not found and not reason:        # never measured (a theodolite without laser)
            continue
        if not found:
            out[name] = {"estimate": None, "sigma": None, "unobservable": reason, **extra}
            continue
        est = np.array([f[0] for f in found])
        var = np.maximum(np.array([f[1] for f in found]), 1e-300)
        mean = float(np.sum(est / var) / np.sum(1.0 / var))
        out[name] = {"estimate": given + mean, "sigma": float(np.sqrt(1.0 / np.sum(1.0 / var))),
                     "unit": UNIT[name], "applied": any(f[2] for f in found), **extra}
    return out
