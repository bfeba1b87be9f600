"""The divergence guard: its per-row bookkeeping, covariance reset and limits (used by the
shared forward loop, ``estimation.forward_loop``, and ``estimation.imm``).

When one sensor's rows keep failing the gate, the filter re-opens the kinematic covariance so
the track can re-acquire; these are the reset itself, its ceilings and the rule for partly
accepted rows. See :class:`rangeproc.estimation.forward.FilterSettings` (``reset_after``).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rangeproc.models.motion import N_KINEMATIC

#: Cap of the divergence guard's covariance inflation: an absurd innovation (an impossible
#: value that slipped past editing) must not blow the covariance up to where the next updates
#: lose positive definiteness to rounding.
MAX_RESET_INFLATION = 1e6
#: Ceilings of the divergence guard: it never inflates a position sigma beyond
#: ``RESET_CEILING[0]`` m, a velocity sigma beyond ``[1]`` m/s, an acceleration sigma beyond
#: ``[2]`` m/s^2 (a track that lost its object is then "anywhere near here", which is all a
#: re-acquisition needs). Without them, a sensor whose rows keep failing the gate (an
#: angle-only sensor on another object, which no inflation can bring back) inflated the
#: covariance every ``reset_after`` rows, compounding to 1e87 m^2 until rounding made it
#: indefinite and the smoother failed ("predicted covariance not positive definite in RTS").
RESET_CEILING = (1.0e4, 1.0e3, 1.0e2)


@njit(cache=True, nogil=True, error_model="numpy")
def reset_covariance(P: np.ndarray, factor: float) -> None:
    """The divergence guard's reset of ``P`` (n, n) in place: every kinematic variance
    multiplied by ``factor`` but not beyond its ``RESET_CEILING`` (one that is already beyond
    stays), and every covariance of a kinematic state with another state dropped
    (calibration states keep their own block).

    A track that lost its object has no trustworthy correlation left: the position-velocity
    correlation the model built while coasting would turn the first position fix after
    re-acquisition into a velocity error of (fix offset) / (coast time), hundreds of m/s
    after a manoeuvre, which then locks the track onto a wrong line of sight (the accepted
    range and elevation hold it while every azimuth is rejected). Each state is capped on
    its own: one common factor, held down by an acceleration variance near its ceiling,
    left a position 10 km off with a 400 m sigma.
    """
    n = P.shape[0]
    kin = min(n, N_KINEMATIC)
    for a in range(kin):
        for b in range(n):
            if b != a:
                P[a, b] = 0.0
                P[b, a] = 0.0
        ceiling = RESET_CEILING[a // 3] ** 2
        P[a, a] = max(P[a, a], min(P[a, a] * factor, ceiling))


#: A row the gate accepts only in part counts for the divergence guard when its whole-row
#: chi-square exceeds this many times the gate: far beyond a wild component, it is a track
#: that the accepted components (an elevation after a manoeuvre) can no longer hold.
PARTIAL_DIVERGENCE = 10.0


@njit(cache=True, nogil=True, error_model="numpy")
def guard_row(nis: float, accepted: bool, mask: int, m: int, gate: np.ndarray, k: int,
              sensor: int, consecutive: np.ndarray, resets: np.ndarray, reset_after: int,
              reset_inflation: float, P: np.ndarray) -> bool:
    """Count one gated row of ``sensor`` for the divergence guard; reset ``P`` when due.

    A row counts when it was rejected, or accepted only in part with a chi-square ``nis``
    above ``PARTIAL_DIVERGENCE`` times the gate of its ``m`` components (other sensors' rows
    may be accepted in between: an angle-only sensor can keep "agreeing" with a track that
    drifted along its line of sight; nor does a radar's accepted elevation hold a track whose
    range and azimuth it rejects after a manoeuvre). When one sensor has ``reset_after``
    consecutive counted rows, the kinematic covariance is multiplied by
    ``max(reset_inflation, 4 nis / gate)`` (at most ``MAX_RESET_INFLATION``, never beyond
    ``RESET_CEILING``, and at most once per epoch ``k``: thousands of rows sharing one time
    stamp must not compound it) so the track re-acquires instead of rejecting that sensor for
    ever, and every sensor's count restarts. ``reset_after = 0`` disables it.

    ``consecutive`` (sensors,) int64: each sensor's count; ``resets`` (2,) int64: the number
    of resets so far and the epoch of the last (-1: none), both updated. Returns whether it
    reset.
    """
    if accepted and (mask == 0 or nis <= PARTIAL_DIVERGENCE * gate[m]):
        consecutive[sensor] = 0
        return False
    consecutive[sensor] += 1
    if reset_after > 0 and consecutive[sensor] >= reset_after and resets[1] != k:
        reset_covariance(P, min(max(reset_inflation, 4.0 * nis / gate[m]), MAX_RESET_INFLATION))
        consecutive[:] = 0
        resets[0] += 1
        resets[1] = k
        return True
    return False
