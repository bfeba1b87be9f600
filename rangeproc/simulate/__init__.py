"""Scenario simulator with truth: maneuvering aircraft, range sensors, contract files.

Independent of the processing code (frames/models/estimation/readers) on purpose, so that it
checks them. Entry point: :func:`simulate_scenario`.
"""
from rangeproc.simulate.scenario import (
    FAULT_PRESETS,
    FAULTS,
    ISSUE8_FAULTS,
    draw_scenario,
    resolve_faults,
    simulate_scenario,
)

__all__ = ["FAULTS", "FAULT_PRESETS", "ISSUE8_FAULTS", "draw_scenario", "resolve_faults",
           "simulate_scenario"]
