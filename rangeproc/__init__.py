"""rangeproc: fuse flight-test range tracking logs into best-estimate trajectories.

Offline batch post-processing: read per-sensor logs (radar, theodolite, GPS, MISTRAM, INS),
edit wild points, stabilise moving-platform measurements, filter and smooth all sensors in one
centralised estimator, and write the fused trajectory per target with its uncertainty.

The docstrings cite the published methods rangeproc implements by author and year:

* Zhou, Wang & Zhu 2001: self-adaptive spline filter for trajectory determination by velocity
  (range-rate) measurement, Journal of National University of Defense Technology, 2001 (6),
  38-41 (``filter = "spline"``, the batch spline fit).
* Ye and Cui: strong-tracking UKF with multiple fading factors for GPS/SINS deep integration
  (``filter = "stukf"``, the UKF's sigma points).
* Song, Liu, Shen, Dai & Tan 2011: improved Sage-Husa adaptive Kalman filter for target
  location from an airborne electro-optical platform (``filter = "sage-husa"``).
* He 2015: "Study on Trajectory Algorithm of Motion Platform", Hans Publishers (the
  constant-acceleration model, the per-sensor EKF, moving-platform stabilisation,
  cooperative-target registration, track synthesis and relay).
* Zhai, Zhao & Zhang 2019: patent CN109581356A, constrained filter tracking of a space target
  with a constant-magnitude maneuver (``filter = "askf"``, the maneuver-norm constraint).
"""

__version__ = "0.1.0"

# Before pyarrow (or anything else) starts a thread: every thread allocates from the C
# library's main heap, whose freed pages the stages hand back (rangeproc.parallel).
from rangeproc.parallel import one_heap as _one_heap  # noqa: E402

_one_heap()

# Before any kernel module is imported: numba's cache goes to a folder keyed to the kernels'
# sources (rangeproc.kernel_cache), so an edited helper never loads a stale kernel.
from rangeproc.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache()
