"""Registration: every sensor's biases, latency and mount misalignment, with the target's GPS
(and MISTRAM) as the absolute reference (He 2015 sec. 3.2, cooperative-target registration).

Between the smoother's passes (``fusion.centralised``), :func:`register` solves the joint
least squares of a correction to the smoothed track and the calibration terms of all sensors
(``estimation.registration``: the Gauss-Newton step of an augmented-state smoother with
constant calibration states, solved through the Schur complement of the calibration border),
robustly (iteratively re-weighted: each sensor component's noise scale from its post-fit
residuals, Huber weights, wild points out), and decides what the data can separate:

* **reference**: without GPS or MISTRAM rows of the target nothing is absolute (every bias
  could be the trajectory's), so nothing is estimated;
* **observability**: with each term scaled by its a-priori plausible size (``PRIOR_SIGMA``),
  a direction of the terms whose posterior variance stays above ``UNOBSERVABLE_RATIO**2`` of
  the prior is not determined by the data. Of the terms spanning it, one is left out (a
  latency before a bias before a mount angle, ``PREFERENCE``: on a platform, an antenna's yaw
  on its deck and an azimuth bias are the same error) and the solve repeated; the term is
  reported with the reason and the result is what it would be without it.

The estimates are applied to the measurement rows (biases subtracted; latency as
``z + latency * dh/dt``; the mount rotation applied to the row's sensor axes exactly) and the
next pass runs on the corrected rows, linearised anew: the registration repeats before every
refinement pass, each solve estimating what is left. Sign conventions are the data contract's
(section 4): a bias is measured minus true, latency is time stamp minus true time, mount angles
rotate the sensor's axes relative to the INS body axes in the attitude's 3-2-1 sense.
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from rangeproc.editing.robust import robust_spread
from rangeproc.estimation.registration import (
    LATENCY_SLOT,
    MOUNT_SLOT,
    N_NODE,
    N_SLOTS,
    SLOTS,
    normal_equations,
    postfit,
    process_blocks,
    solve_joint,
)
from rangeproc.estimation.consider import consider_covariance
from rangeproc.fusion.assemble import deck_turn
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.io.memory import release_freed_between
from rangeproc.models.measurement import SPHERICAL

log = logging.getLogger(__name__)

#: A-priori plausible size (1-sigma, SI) of each term: the scale of the observability test and
#: a weak prior (its information is 1e-6 of a usable estimate's).
PRIOR_SIGMA = {"range": 100.0, "azimuth": 0.02, "elevation": 0.02, "latency": 0.2,
               "mount_roll": 0.02, "mount_pitch": 0.02, "mount_yaw": 0.02}
UNIT = {"range": "m", "azimuth": "rad", "elevation": "rad", "latency": "s",
        "mount_roll": "rad", "mount_pitch": "rad", "mount_yaw": "rad"}
#: Which term a degenerate direction gives up first (lowest first). A platform sensor measures
#: in its own deck axes, so its angle offsets and its mount rotation act alike (a yaw of the
#: mount is exactly an offset of every deck azimuth, whatever the ship does): there the mount,
#: which the INS alignment defines, is kept and the angle bias given up; a fixed sensor has
#: no mount terms.
PREFERENCE = {"latency": 0, "range": 1, "azimuth": 1, "elevation": 1, "mount_roll": 2,
              "mount_pitch": 2, "mount_yaw": 2}
#: A term is estimated when the data bring its posterior sigma under this share of its prior.
UNOBSERVABLE_RATIO = 0.1
#: An estimated term corrects the rows when it differs from zero by this many of its sigmas
#: (a significance test: an insignificant correction would only add its own error, which is
#: systematic over the whole flight). The uncertainty of every term, applied, insignificant
#: (with the square of its estimate) or undetermined (at its ``PRIOR_SIGMA``), enters the
#: trajectory's covariance (``estimation.consider``).
SIGNIFICANCE = 3.0
#: Most nodes of the trajectory correction (output-grid epochs, thinned evenly beyond this).
#: The biases are constant and the correction between nodes smooth: 5,000 nodes (one per
#: 0.36 s on a 30-minute object) move the estimates of the 30-minute `scale` scenario by
#: < 0.1 of their sigmas against 20,000 and cost a quarter (its fuse stage 5.4 -> 3.9 s);
#: flights up to 500 s at 10 Hz (every `make accuracy` flight) are not thinned at all.
MAX_NODES = 5000
#: Robust re-weighting: passes, Huber threshold, and the normalised residual beyond which a
#: component is left out (also, before the first solve, its distance from the median of its
#: sensor component in robust sigmas).
IRLS_PASSES = 2
#: Why no term is estimated for an object without GPS or MISTRAM rows.
NO_REFERENCE = "no absolute reference (GPS or MISTRAM rows of this target)"
HUBER_K = 3.0
WILD = 6.0
PRE_WILD = 8.0
#: Rows a sensor component needs before its terms are estimated.
MIN_ROWS = 20
REFERENCE_KINDS = ("gps", "mistram")


@dataclass(frozen=True, slots=True)
class SensorCalibration:
    """What may be estimated for one sensor: ``kind``, ``moving`` (on a platform: mount terms
    and the platform's rotation in the latency's rate), ``names`` (of :data:`SLOTS`, after
    the config's opt-outs)."""

    kind: str
    moving: bool
    names: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Term:
    """One calibration term: sensor index, name (:data:`SLOTS`), slot index."""

    sensor: int
    name: str
    slot: int


@dataclass(frozen=True, slots=True)
class Calibration:
    """The registration of one span after its last solve.

    terms: the candidate terms; estimate (p,) SI, the joint estimates (0 where not
    estimated); applied (p,) the corrections in the rows (the significant terms' estimates,
    0 elsewhere); cov (p, p) the joint covariance of the estimated ones (0 elsewhere);
    reason: per term, '' when estimated, else why not; node_t (G,) and node_cov (G, 9, 9):
    the trajectory covariance the calibration's uncertainty adds at the nodes
    (``estimation.consider``: every term's posterior covariance, and the terms left
    uncorrected with the square of their estimate).
    """

    terms: tuple[Term, ...]
    estimate: np.ndarray
    applied: np.ndarray
    cov: np.ndarray
    reason: tuple[str, ...]
    node_t: np.ndarray
    node_cov: np.ndarray

    @property
    def estimated(self) -> np.ndarray:
        """(p,) bool: the terms the data determine."""
        return np.array([r == "" for r in self.reason], dtype=bool)


def candidate_terms(batch: MeasurementBatch, specs: tuple[SensorCalibration | None, ...]
                    ) -> tuple[tuple[Term, ...], np.ndarray]:
    """The terms of the sensors in ``batch`` whose components were measured at all, and per
    term the rows that measured them."""
    terms, rows_of = [], []
    for i in np.unique(batch.sensor):
        spec = specs[int(i)] if int(i) < len(specs) else None
        if spec is None:
            continue
        rows = batch.sensor == i
        measured = (np.isfinite(batch.z[rows]) & (batch.model[rows] == SPHERICAL)[:, None]
                    ).sum(axis=0)
        for name in spec.names:
            slot = SLOTS.index(name)
            if slot < 3:
                n = measured[slot]
            elif slot == LATENCY_SLOT:
                n = measured[:4].max()
            else:
                n = measured[1:3].max() if spec.moving else 0
            if n > 0:
                terms.append(Term(int(i), name, slot))
                rows_of.append(int(n))
    return tuple(terms), np.array(rows_of, dtype=np.int64)


def _slots_table(terms: tuple[Term, ...], n_sensors: int) -> np.ndarray:
    slots = np.full((max(n_sensors, 1), N_SLOTS), -1, dtype=np.int64)
    for k, term in enumerate(terms):
        slots[term.sensor, term.slot] = k
    return slots


def _nodes(epoch_t: np.ndarray, grid: np.ndarray) -> np.ndarray:
    node_t = epoch_t[grid]
    if len(node_t) < 2:
        node_t = epoch_t[[0, -1]] if len(epoch_t) > 1 else epoch_t
    stride = int(np.ceil(len(node_t) / MAX_NODES))
    return np.unique(np.concatenate([node_t[::stride], node_t[-1:]]))


def nearest_index(node_t: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(M,) int64 index of the time in ``node_t`` (G,) ascending nearest to each of ``t`` (M,)
    (the earlier one on a tie)."""
    k = np.clip(np.searchsorted(node_t, t), 1, max(len(node_t) - 1, 1))
    left = node_t[k - 1]
    right = node_t[np.minimum(k, len(node_t) - 1)]
    return np.where(np.abs(t - left) <= np.abs(right - t), k - 1, k).astype(np.int64) \
        .clip(0, len(node_t) - 1)


def axes_rate(batch: MeasurementBatch, moving: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Rate of change (1/s) of the sensor axes ``Qr`` of platform rows, by central differences
    over each sensor's rows: ``(index (N,) into rates or -1, rates (M, 3, 3))``."""
    index = np.full(len(batch), -1, dtype=np.int64)
    parts = []
    m = 0
    for i in np.flatnonzero(moving):
        rows = np.flatnonzero(batch.sensor == i)
        if len(rows) < 2:
            continue
        t, Q = batch.t[rows], batch.Qr[rows]
        prev = np.concatenate([[0], np.arange(len(rows) - 1)])
        nxt = np.concatenate([np.arange(1, len(rows)), [len(rows) - 1]])
        dt = t[nxt] - t[prev]
        rate = (Q[nxt] - Q[prev]) / np.where(dt > 0, dt, np.inf)[:, None, None]
        parts.append(rate)
        index[rows] = m + np.arange(len(rows))
        m += len(rows)
    rates = np.concatenate(parts) if parts else np.zeros((1, 3, 3))
    return index, np.ascontiguousarray(rates)


def _weights(groups: list[np.ndarray], r: np.ndarray, base: np.ndarray, first: bool
             ) -> np.ndarray:
    """(N, 6) weights 1/sigma^2 from residuals ``r`` of the rows of each sensor (``groups``):
    per sensor component, ``base`` sigmas rescaled to the residuals' robust scale, Huber
    down-weighting, wild values left out. On the ``first`` solve ``r`` are pre-fit residuals
    (a bias still in them): only values far from their sensor component's median are left
    out, at the stated sigmas."""
    w = np.zeros(r.shape)
    for rows in groups:                  # one component of one sensor at a time, gathered
        for c in range(r.shape[1]):      # on its own (a long sortie's sensor: tens of MiB)
            sc = base[rows, c]
            u = r[rows, c] / sc
            have = np.isfinite(u) & (sc > 0)
            if np.count_nonzero(have) < 3:
                continue
            if first:
                med = np.median(u[have])
                scale = max(robust_spread(u[have], max_samples=100_000), 1e-12)
                keep = have & (np.abs(u - med) <= PRE_WILD * scale)
                w[rows[keep], c] = 1.0 / sc[keep] ** 2
                continue
            f = max(robust_spread(u[have], max_samples=100_000), 0.2)
            un = np.where(have, np.abs(u) / f, np.inf)
            keep = un <= WILD
            huber = np.minimum(1.0, HUBER_K / np.maximum(un[keep], 1e-12))
            w[rows[keep], c] = huber / (f * sc[keep]) ** 2
    return w


def _select(S: np.ndarray, s_prior: np.ndarray, terms: tuple[Term, ...],
            sensor_ids: tuple[str, ...], n_rows: np.ndarray) -> list[str]:
    """Reasons (``''`` = estimated) from the information ``S`` (p, p) of the terms with the
    trajectory free (see module docstring, observability); ``n_rows`` (p,) measured rows of
    each term (too few: not estimated)."""
    reason = ["" if n >= MIN_ROWS and S[k, k] > 0 else f"too few measured rows ({n})"
              for k, n in enumerate(n_rows)]
    Sn = S * np.outer(s_prior, s_prior) + np.eye(len(terms))      # prior-scaled, with prior
    while True:
        act = [k for k in range(len(terms)) if reason[k] == ""]
        if not act:
            return reason
        C = np.linalg.inv(Sn[np.ix_(act, act)])
        lam, V = np.linalg.eigh(0.5 * (C + C.T))
        if lam[-1] <= UNOBSERVABLE_RATIO ** 2:
            return reason
        v = np.abs(V[:, -1])
        part = [act[j] for j in np.flatnonzero(v >= 0.3 * v.max())]
        drop = min(part, key=lambda k: (PREFERENCE[terms[k].name], -v[act.index(k)]))
        others = [f"{sensor_ids[terms[k].sensor]} {terms[k].name}" for k in part if k != drop]
        ratio = float(np.sqrt(C[act.index(drop), act.index(drop)]))
        reason[drop] = (
            f"not separable from {', '.join(others)} over this flight's geometry"
            if others else "not separable from the trajectory: no other sensor's data "
            "fix it") + f" (posterior/prior sigma {ratio:.2f})"


def register(batch: MeasurementBatch, xs: np.ndarray, res: np.ndarray, epoch_t: np.ndarray,
             meas_epoch: np.ndarray, grid: np.ndarray, q: np.ndarray,
             specs: tuple[SensorCalibration | None, ...],
             previous: Calibration | None = None
             ) -> tuple[Calibration, np.ndarray, np.ndarray]:
    """One registration solve at the smoothed track ``xs`` (E, n) of rows ``batch`` (already
    corrected by ``previous``; its ``sigma`` the pass's) with residuals ``res`` (N, 6) there.

    ``q`` (E,) the smoother's white-jerk PSD per step. Returns the updated
    :class:`Calibration`, the increments (p,) of the corrections to apply to the rows, and the
    rates ``dh/dt`` (N, 4) of each row's components at ``xs`` (for the latency correction).
    """
    terms, n_rows = candidate_terms(batch, specs)
    if previous is not None:
        terms = previous.terms
    p = len(terms)
    total = previous.applied.copy() if previous is not None else np.zeros(p)
    node_t = _nodes(epoch_t, grid)
    if p == 0:                        # nothing to estimate (e.g. range rates alone)
        return _unsolved(terms, total, total, total, "", node_t, len(batch))
    has_ref = bool(np.isin(batch.sensor, [i for i, sp in enumerate(specs)
                                          if sp is not None and sp.kind in REFERENCE_KINDS]).any())
    if not has_ref:                   # nothing is estimable: no solve (an undeclared object of
        return _unsolved(terms, total, np.zeros(p), total, NO_REFERENCE, node_t,  # radars
                         len(batch))                                           # only)
    node = nearest_index(node_t, batch.t)
    moving = np.array([bool(sp is not None and sp.moving) for sp in specs], dtype=bool)
    mv_index, rates = axes_rate(batch, moving)
    slots = _slots_table(terms, len(batch.sensor_ids))
    x_node = np.ascontiguousarray(xs[np.searchsorted(epoch_t, node_t), :N_NODE])
    q_node = np.maximum(q[np.searchsorted(epoch_t, node_t)][1:], 1e-6)
    diag, upper, rhs = process_blocks(node_t, q_node, x_node)
    diag[0] += np.diag(np.repeat([1e-6, 1e-4, 1e-4], 3))      # weak start (m, m/s, m/s^2)
    problem = _Problem(args=(meas_epoch, node, node_t, batch.t, batch.model),
                       geo=(batch.s, batch.sv, batch.Qr, mv_index, rates, batch.sensor, slots,
                            xs),
                       diag=diag, upper=upper, rhs=rhs,
                       s_prior=np.array([PRIOR_SIGMA[t.name] for t in terms]))
    try:
        S, s, Xc, dc, cov, reason, rate = _irls(batch, res, terms, n_rows, problem)
    except np.linalg.LinAlgError:
        log.warning("registration skipped: the joint normal matrix is not positive "
                    "definite (an ill-conditioned track); rows left uncorrected")
        return _unsolved(terms, total, total, total, "registration failed: the joint normal "
                         "matrix of track and terms is not positive definite (an "
                         "ill-conditioned track)", node_t, len(batch))
    estimate = total + dc
    sigma = np.sqrt(np.diag(cov))
    significant = (dc != 0.0) & (np.abs(estimate) > SIGNIFICANCE * sigma)
    applied = np.where(significant, estimate, 0.0)
    node_cov = consider_covariance(S, s, problem.s_prior, total, applied, Xc)
    for k, term in enumerate(terms):
        if reason[k] == "":
            log.info("registration: %s %s %+.4g +- %.2g %s%s", batch.sensor_ids[term.sensor],
                     term.name, estimate[k], sigma[k], UNIT[term.name],
                     "" if applied[k] else " (not significant: rows not corrected)")
    cal = Calibration(terms, estimate, applied, cov, tuple(reason), node_t, node_cov)
    return cal, applied - total, rate


class _Problem(NamedTuple):
    """The registration's joint least-squares problem at one track: the rows' epoch, node,
    time and model (``args``), their geometry and term slots (``geo``), the track's process
    blocks (``diag``, ``upper``, ``rhs``) and the terms' prior sigmas ``s_prior`` (p,)."""

    args: tuple
    geo: tuple
    diag: np.ndarray
    upper: np.ndarray
    rhs: np.ndarray
    s_prior: np.ndarray


def _irls(batch: MeasurementBatch, res: np.ndarray, terms: tuple[Term, ...],
          n_rows: np.ndarray, problem: _Problem) -> tuple:
    """The joint solve of track and terms, re-weighted ``IRLS_PASSES`` times from the post-
    fit residuals (wild points out). Returns the terms' information ``S`` (p, p) and vector
    ``s`` (p,), the track's sensitivity ``Xc`` (K, 9, p), the increments ``dc`` (p,), their
    covariance (p, p), each term's reason for not being estimated ("" when it is) and the
    rows' rates (N, 4).

    Raises:
        numpy.linalg.LinAlgError: the joint normal matrix is not positive definite.
    """
    pr, p = problem, len(terms)
    groups = [np.flatnonzero(batch.sensor == i) for i in np.unique(batch.sensor)]
    release_freed_between(len(batch))   # the set-up's freed pages, before the weights
    weight = _weights(groups, res, batch.sigma, True)   # stated sigmas, wild points out
    for it in range(IRLS_PASSES):
        if it:
            release_freed_between(len(batch))   # the re-weighting's, before the solve's
        Nxx, Nxc, Ncc, bx, bc, _ = normal_equations(*pr.args, batch.z, weight, *pr.geo, p,
                                                    residuals=False)
        if it == IRLS_PASSES - 1:
            weight = None               # the last solve's (N, 6) weights are not read again
        S, s, Xc, xb = solve_joint(Nxx + pr.diag, pr.upper, Nxc, Ncc, bx + pr.rhs, bc)
        del Nxx, Nxc, Ncc, bx, bc
        dc = np.zeros(p)
        reason = _select(S, pr.s_prior, terms, batch.sensor_ids, n_rows)
        act = [k for k in range(p) if reason[k] == ""]
        cov = np.zeros((p, p))
        if act:
            info = S[np.ix_(act, act)] + np.diag(1.0 / pr.s_prior[act] ** 2)
            cov[np.ix_(act, act)] = np.linalg.inv(info)
            dc[act] = cov[np.ix_(act, act)] @ s[act]
        if it < IRLS_PASSES - 1:        # re-weight from the post-fit residuals (the last
            weight = None               # weights let go first: (N, 6))
            post, _ = postfit(*pr.args, *pr.geo, res, xb - Xc @ dc, dc)
            weight = _weights(groups, post, batch.sigma, False)
            del post
    # the rows' rates (N, 4) after the solves, not held through them: they depend on the
    # track only (the design's latency column), not on the solution
    _, rate = postfit(*pr.args, *pr.geo, res, np.zeros((len(pr.args[2]), N_NODE)),
                      np.zeros(p))
    return S, s, Xc, dc, cov, reason, rate


def _unsolved(terms: tuple[Term, ...], estimate: np.ndarray, applied: np.ndarray,
              previous: np.ndarray, why: str, node_t: np.ndarray, n_rows: int
              ) -> tuple[Calibration, np.ndarray, np.ndarray]:
    """A registration without a solve (no term, no reference, or a failed solve): every term
    with the reason ``why``, no covariance; the increments to ``applied`` from the
    ``previous`` corrections (p,), no rates (n_rows, 4)."""
    p = len(terms)
    return (Calibration(terms, estimate, applied, np.zeros((p, p)), (why,) * p, node_t,
                        np.zeros((len(node_t), N_NODE, N_NODE))),
            applied - previous, np.zeros((n_rows, 4)))


def row_rates(batch: MeasurementBatch, xs: np.ndarray, epoch_t: np.ndarray,
              meas_epoch: np.ndarray, grid: np.ndarray,
              specs: tuple[SensorCalibration | None, ...], terms: tuple[Term, ...]
              ) -> np.ndarray:
    """(N, 4) the rate ``dh/dt`` of each row's components at the track ``xs`` (E, n), as
    :func:`register` returns it (for :func:`apply_increments`' latency correction of rows
    the registration did not solve with)."""
    node_t = _nodes(epoch_t, grid)
    moving = np.array([bool(sp is not None and sp.moving) for sp in specs], dtype=bool)
    mv_index, rates = axes_rate(batch, moving)
    slots = _slots_table(terms, len(batch.sensor_ids))
    _, rate = postfit(meas_epoch, nearest_index(node_t, batch.t), node_t, batch.t, batch.model,
                      batch.s, batch.sv, batch.Qr, mv_index, rates, batch.sensor, slots, xs,
                      np.zeros((len(batch), 6)), np.zeros((len(node_t), N_NODE)),
                      np.zeros(len(terms)))
    return rate


def apply_increments(batch: MeasurementBatch, terms: tuple[Term, ...], dc: np.ndarray,
                     rate: np.ndarray) -> MeasurementBatch:
    """The batch with the calibration increments ``dc`` removed from its rows (new ``z`` and,
    when a mount term moves, ``Qr`` arrays; the others shared).

    Biases are subtracted; a latency ``L`` moves a component to its value at the time stamp,
    ``z + L dh/dt`` (``rate`` (N, 4) from :func:`register`); a mount rotation ``M`` turns the
    row's sensor axes: ``Qr <- P M^T P Qr`` (P: deck <-> FRD axes).
    """
    z = batch.z.copy()
    Qr = batch.Qr
    mounts: dict[int, np.ndarray] = {}
    for k, term in enumerate(terms):
        if dc[k] == 0.0:
            continue
        rows = (batch.sensor == term.sensor) & (batch.model == SPHERICAL)
        if term.slot < 3:
            z[rows, term.slot] -= dc[k]
        elif term.slot == LATENCY_SLOT:
            z[rows, :4] += dc[k] * rate[rows]
        else:
            mounts.setdefault(term.sensor, np.zeros(3))[term.slot - MOUNT_SLOT] = dc[k]
    if mounts:
        Qr = batch.Qr.copy()
        for sensor, (roll, pitch, yaw) in mounts.items():
            rows = batch.sensor == sensor
            Qr[rows] = np.einsum("ij,njk->nik", deck_turn(roll, pitch, yaw), Qr[rows])
    return replace(batch, z=z, Qr=np.ascontiguousarray(Qr))


def row_shift(before: np.ndarray, after: np.ndarray, sigma: np.ndarray,
              sensor: np.ndarray) -> float:
    """How far a correction moved the rows, in their sigmas: the largest, over sensor
    components, RMS of ``(after - before) / sigma`` over the rows where both are finite.

    before, after: (N, 6) the residuals of the rows at one track before and after the
    correction (their difference is the rows' shift, mount rotations included); sigma (N, 6)
    the rows' sigmas; sensor (N,) their sensor index. 0.0 when nothing moved.
    """
    shift = (after - before) / sigma
    worst = 0.0
    for i in np.unique(sensor):
        d = shift[sensor == i]
        ok = np.isfinite(d)
        n = ok.sum(axis=0)
        sq = np.where(ok, d, 0.0) ** 2
        if n.any():
            worst = max(worst, float(np.sqrt(sq.sum(axis=0)[n > 0] / n[n > 0]).max()))
    return worst


def calibration_covariance(cal: Calibration, t: np.ndarray,
                           columns: Sequence[int] | None = None) -> np.ndarray:
    """(M, 45) packed 9x9 trajectory covariance added by the calibration's uncertainty at
    times ``t`` (M,) s (the nearest node's, ``Calibration.node_cov``); with ``columns``
    (indices into the 45 packed entries) only those, (M, len(columns)): the same values."""
    i, j = np.tril_indices(N_NODE)
    if columns is not None:
        i, j = i[list(columns)], j[list(columns)]
    packed = cal.node_cov[:, i, j]
    return packed[nearest_index(cal.node_t, t)]


def spans_calibration_covariance(cals: Sequence[Calibration], t: np.ndarray,
                                 columns: Sequence[int] | None = None) -> np.ndarray:
    """(M, 45) packed 9x9 covariance the calibrations of a result's spans add at times ``t``
    (M,) s: each span's :func:`calibration_covariance` within its nodes' time range, as the
    fusion added it to that span's output epochs; 0 outside every span. ``columns``: only
    those packed entries, (M, len(columns)) (a caller that reads a few: an hour's output
    epochs are 12 MiB in all 45)."""
    width = N_NODE * (N_NODE + 1) // 2 if columns is None else len(columns)
    out = np.zeros((len(t), width))
    for cal in cals:
        if len(cal.node_t):
            inside = (t >= cal.node_t[0]) & (t <= cal.node_t[-1])
            out[inside] += calibration_covariance(cal, t[inside], columns)
    return out
