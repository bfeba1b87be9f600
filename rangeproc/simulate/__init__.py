"""Scenario simulator with truth: maneuvering aircraft, range sensors, contract files.

Independent of the processing code (frames/models/estimation/readers) on purpose, so that it
checks them. Entry points: :func:`simulate_scenario` (one object) and :func:`simulate_multi`
(several objects: crossings, formations, lock jumps, operator switches, plots with clutter).
"""
from rangeproc.simulate.scenario import (
    FAULT_PRESETS,
    FAULTS,
    ISSUE8_FAULTS,
    REGISTRATION_FAULTS,
    draw_scenario,
    resolve_faults,
    simulate_scenario,
)
from rangeproc.simulate.multi import KINDS as MULTI_KINDS
from rangeproc.simulate.multi import draw_multi, simulate_multi

__all__ = ["FAULTS", "FAULT_PRESETS", "ISSUE8_FAULTS", "MULTI_KINDS", "REGISTRATION_FAULTS",
           "draw_multi", "draw_scenario", "resolve_faults", "simulate_multi",
           "simulate_scenario"]      # ISSUE8_FAULTS: REGISTRATION_FAULTS's former name
