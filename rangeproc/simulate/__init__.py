"""Scenario simulator with truth: maneuvering aircraft, range sensors, contract files.

Independent of the processing code (frames/models/estimation/readers) on purpose, so that it
checks them. Entry point: :func:`simulate_scenario`.
"""
from rangeproc.simulate.scenario import draw_scenario, simulate_scenario

__all__ = ["draw_scenario", "simulate_scenario"]
