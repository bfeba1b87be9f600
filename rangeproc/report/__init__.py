"""PNG report figures a range engineer reads first: trajectory, per-sensor residuals,
consistency (NIS, normalised residuals) and coverage timeline. Entry point: ``write_report``."""
from rangeproc.report.figures import write_report

__all__ = ["write_report"]
