"""rangeproc: fuse flight-test range tracking logs into best-estimate trajectories.

Offline batch post-processing: read per-sensor logs (radar, theodolite, GPS, MISTRAM, INS),
edit wild points, stabilise moving-platform measurements, filter and smooth all sensors in one
centralised estimator, and write the fused trajectory per target with its uncertainty.
"""

__version__ = "0.1.0"
