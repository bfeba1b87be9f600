"""Metrics of a fused run against truth (RMSE, percentiles, 3-sigma coverage, NEES)."""
from rangeproc.evaluate.metrics import evaluate_run, format_report

__all__ = ["evaluate_run", "format_report"]
