"""Bridging the gaps between an object's spans: a least-squares fit with honest uncertainty.

A target unobserved for longer than ``max_gap`` is estimated as separate spans (each with
its own start; ``fusion.centralised``). When the same object is seen again (a relay between
sensors, or the same sensor after a long outage), He 2015 fills the discontinuity by a
least-squares fit of the track on both sides. Here that fit is the weighted least-squares
state of the constant-acceleration motion given both ends: at an epoch t inside the gap
[t_a, t_b] the forward prediction from the last state of the earlier span,
``x_f = F(t - t_a) x_a``, ``P_f = F P_a Fᵀ + Q(t - t_a)``, and the backward prediction from
the first state of the later span, ``x_r = F(t - t_b) x_b``,
``P_r = F(t - t_b) (P_b + Q(t_b - t)) F(t - t_b)ᵀ`` (the later state's likelihood carried back
through the motion and its noise), are combined in information form:
``P = (P_f⁻¹ + P_r⁻¹)⁻¹``, ``x = P (P_f⁻¹ x_f + P_r⁻¹ x_r)`` (the two-filter smoother
across a gap without data; the spans' estimates are independent).
``Q`` is the white-jerk noise with the larger of the two ends' process noise, so the
uncertainty grows towards the middle of the gap as the motion model says it must, plus the
white-acceleration noise of a manoeuvre (``models.motion.manoeuvre_psd``: the PSD the plot
trackers' manoeuvre model gives an object of the larger of the two ends' speeds): the
ends' process noise describes how the object moved while it was seen, and nothing says it
kept to that while unseen. A manoeuvre is a turn, bounded by the speed, so a boat's bridge
widens by metres where an aircraft's widens by hundreds (docs/methods/estimators.md, "Gaps
between spans", with the measured case). Gaps longer than ``max_seconds`` are left empty (an
object seen again hours later is not drawn across the sky).
"""
from __future__ import annotations

import numpy as np

from rangeproc.models.motion import (
    axes_blocks,
    ca_steps,
    manoeuvre_psd,
    white_acceleration_q,
)


def ca_transition(dt: np.ndarray) -> np.ndarray:
    """(M, 9, 9) constant-acceleration transitions over ``dt`` (M,) s, state [p, v, a]
    (``models.motion.ca_steps``)."""
    return axes_blocks(ca_steps(np.atleast_1d(np.asarray(dt, dtype=float)))[0])


def _manoeuvre_blocks(a: np.ndarray, q: float) -> np.ndarray:
    """(M, 3, 3) per-axis white-acceleration noise of position and velocity over ``a`` (M,)
    s >= 0 with PSD ``q`` ((m/s^2)^2/s) (``models.motion.white_acceleration_q``; the
    acceleration takes none)."""
    q00, q01, q11 = white_acceleration_q.py_func(a, q)
    B = np.zeros((a.size, 3, 3))
    B[:, 0, 0], B[:, 0, 1], B[:, 1, 0], B[:, 1, 1] = q00, q01, q01, q11
    return B


def gap_noise(dt: np.ndarray, q: float, qm: float) -> np.ndarray:
    """(M, 9, 9) the bridge's process noise over ``|dt|`` (M,) s: white jerk of PSD ``q``
    (m^2/s^5) plus the manoeuvre's white acceleration of PSD ``qm`` ((m/s^2)^2/s), summed per
    axis and spread over the axes once (``models.motion.ca_steps``, :func:`_manoeuvre_blocks`)."""
    a = np.abs(np.atleast_1d(np.asarray(dt, dtype=float)))
    return axes_blocks(ca_steps(a, q)[1] + _manoeuvre_blocks(a, qm))


def _fit(t: np.ndarray, ta: float, xa: np.ndarray, Pa: np.ndarray, tb: float,
         xb: np.ndarray, Pb: np.ndarray, q: float, qm: float
         ) -> tuple[np.ndarray, np.ndarray]:
    """(M, 9) states and (M, 9, 9) covariances at times ``t`` (M,) inside the gap, with
    white-jerk PSD ``q`` and manoeuvre PSD ``qm`` (module docstring)."""
    Ff, Fr = ca_transition(t - ta), ca_transition(t - tb)
    xf = Ff @ xa
    Pf = Ff @ Pa @ np.transpose(Ff, (0, 2, 1)) + gap_noise(t - ta, q, qm)
    xr = Fr @ xb
    Pr = Fr @ (Pb + gap_noise(tb - t, q, qm)) @ np.transpose(Fr, (0, 2, 1))
    If, Ir = np.linalg.inv(Pf), np.linalg.inv(Pr)
    P = np.linalg.inv(If + Ir)
    P = 0.5 * (P + np.transpose(P, (0, 2, 1)))
    x = np.einsum("mij,mj->mi", P, np.einsum("mij,mj->mi", If, xf)
                  + np.einsum("mij,mj->mi", Ir, xr))
    return x, P


def bridge_gaps(t: np.ndarray, x: np.ndarray, P: np.ndarray, q: np.ndarray, rate_hz: float,
                max_seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Output epochs with the gaps between spans filled (module docstring).

    Args:
        t: (K,) s output-grid epochs (whole multiples of 1/rate_hz; a step longer than 1.5
            periods is a gap between spans); x: (K, 9); P: (K, 9, 9); q: (K,) m^2/s^5.
        max_seconds: longest gap filled.
    Returns:
        (t, x, P, filled) with the new epochs inserted in time order; ``filled`` (K',) bool
        marks them.
    """
    period = 1.0 / rate_hz
    gaps = np.flatnonzero(np.diff(t) > 1.5 * period)
    if gaps.size == 0:
        return t, x, P, np.zeros(t.size, dtype=bool)
    parts_t, parts_x, parts_P, parts_f = [], [], [], []
    start = 0
    for g in gaps:
        parts_t.append(t[start:g + 1])
        parts_x.append(x[start:g + 1])
        parts_P.append(P[start:g + 1])
        parts_f.append(np.zeros(g + 1 - start, dtype=bool))
        ta, tb = t[g], t[g + 1]
        if tb - ta <= max_seconds:
            k0, k1 = int(round(ta * rate_hz)) + 1, int(round(tb * rate_hz)) - 1
            tt = np.arange(k0, k1 + 1, dtype=float) / rate_hz
            if tt.size:
                ends = [g, g + 1]
                qm = float(manoeuvre_psd(x[ends, 3:6], P[ends, 3:6, 3:6]).max())
                xs, Ps = _fit(tt, ta, x[g], P[g], tb, x[g + 1], P[g + 1],
                              float(max(q[g], q[g + 1])), qm)
                parts_t.append(tt)
                parts_x.append(xs)
                parts_P.append(Ps)
                parts_f.append(np.ones(tt.size, dtype=bool))
        start = g + 1
    parts_t.append(t[start:])
    parts_x.append(x[start:])
    parts_P.append(P[start:])
    parts_f.append(np.zeros(t.size - start, dtype=bool))
    return (np.concatenate(parts_t), np.concatenate(parts_x), np.concatenate(parts_P),
            np.concatenate(parts_f))
