"""Multi-object accuracy: per-epoch assignment of fused objects to truth objects, GOSPA over
time, and identity metrics (best match, coverage, identity swaps, fragmentation, purity).

Positions are in the range ENU frame (m), times in s. Fused object ids need not match truth ids
(rangeproc names discovered objects "O1", "O2", ...): objects are paired by position only.

Definitions (K evaluation epochs t_k, M truth objects, N fused objects, cutoff c in m):

- Evaluation epochs: a fixed grid, the whole multiples of the grid period T (by default the
  fused output's period: the median epoch spacing of the fused objects) from the first to the
  last epoch at which any truth object exists (the union of the truth objects' spans). Every
  epoch of a truth object's span is scored, whether or not anything was written there: an
  object left unreported for a minute, at the start, in the middle or at the end, loses that
  minute in coverage and pays c^p / alpha per epoch in GOSPA. Fused output outside the truth
  objects' overall span is not scored (no truth there).
- Truth object i exists at t_k when t_k lies inside its sample span [first, last]; its position
  there is linearly interpolated. Fused object j exists at t_k when it has a row with finite
  e, n, u at t_k (within ``EPOCH_TOL_S``), or when t_k lies between two of its consecutive rows
  at most 1.5 T apart (output at other multiples than the grid's: linearly interpolated); a
  stretch without rows longer than that is a gap, where the object does not exist.
- Assignment at t_k: the gamma minimising sum_{(i,j) in gamma} min(d_ij, c)^p over the existing
  objects (scipy ``linear_sum_assignment``, d_ij = 3-D Euclidean distance, m); pairs with
  d_ij >= c are dropped (they cost as much as one missed plus one false object).
- GOSPA (p = 2, alpha = 2), Rahmathullah, Garcia-Fernandez, Svensson, "Generalized optimal
  sub-pattern assignment metric", FUSION 2017, eq. (2) with alpha = 2:
      d_k^p = sum_{(i,j) in gamma} d_ij^p + c^p / 2 * (n_missed + n_false)
  split into localisation = sum d_ij^p, missed = c^p/2 * n_missed, false = c^p/2 * n_false
  (m^p); the reported per-epoch GOSPA is d_k = (localisation + missed + false)^(1/p) (m).
- Per truth object i (over the epochs where it exists):
  best match = the fused object assigned to it at most epochs (ties: the first fused id in sort
  order); best_match_rmse / best_match_p95 = RMS / 95th percentile of |x_best - x_i| over the
  epochs where both exist, assigned or not; assigned_rmse = RMS of d_i,gamma(i) over the epochs
  with any assigned object; coverage = (epochs with an assigned object) / (epochs it exists),
  i.e. the fraction of its span inside the fused time range with a fused object within c;
  coverage_observed = the same over the epochs inside the span the object was observed
  [first, last measurement of it] when those spans are given (``observed``): an object no
  sensor saw yet cannot be covered;
  swaps = number of changes of the assigned fused id between consecutive assigned epochs
  (unassigned epochs in between ignored); fragmentation = number of assigned stretches - 1,
  where a run of more than ``FRAGMENT_GAP_EPOCHS`` unassigned epochs starts a new stretch.
- Per fused object j (over its epochs): majority truth = the truth object assigned to it most
  often; purity = (epochs assigned to the majority truth) / (its epochs), 0 when never
  assigned; false_epochs = its epochs assigned to no truth object.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from rangeproc.errors import DataError

P = 2.0                   # GOSPA order p
ALPHA = 2.0               # GOSPA alpha (2: costs split into localisation, missed, false)
EPOCH_TOL_S = 1e-6        # fused epoch times closer than this are one epoch (s)
FRAGMENT_GAP_EPOCHS = 2   # more unassigned epochs than this in a row interrupt a stretch


@dataclass(frozen=True, kw_only=True, slots=True)
class MultiObjectEvaluation:
    """Per-epoch assignment and GOSPA terms (K epochs, M truth objects, N fused objects).

    t: (K,) s; truth_pos: (K, M, 3) m, NaN where the truth object does not exist; fused_pos:
    (K, N, 3) m, NaN where the fused object has no epoch; assigned: (K, M) index into
    ``fused_ids`` of the fused object assigned to each truth object, -1 for none; distance:
    (K, M) m, NaN where unassigned; localisation, missed, false: (K,) m^2; gospa: (K,) m.
    """

    cutoff: float
    t: np.ndarray
    truth_ids: tuple[str, ...]
    fused_ids: tuple[str, ...]
    truth_pos: np.ndarray
    fused_pos: np.ndarray
    assigned: np.ndarray
    distance: np.ndarray
    localisation: np.ndarray
    missed: np.ndarray
    false: np.ndarray
    gospa: np.ndarray


def fused_period(t: np.ndarray, ids: np.ndarray) -> float | None:
    """Median epoch spacing (s) of the objects labelled ``ids`` (R,) at times ``t`` (R,); None
    if no object has two epochs."""
    steps = [np.diff(np.unique(t[ids == i])) for i in np.unique(ids)]
    d = np.concatenate(steps) if steps else np.empty(0)
    d = d[d > EPOCH_TOL_S]
    return float(np.median(d)) if d.size else None


def grid_epochs(start: float, end: float, period: float) -> np.ndarray:
    """The evaluation grid (K,) s: whole multiples of ``period`` (s) in [start, end] s. A
    period within 1e-6 (relative) of 1 / n s for a whole n (a median of output steps) is taken
    as exactly that, so that the grid falls on the output's epochs k / n even at large times."""
    rate = 1.0 / period
    n = round(rate)
    if n >= 1 and abs(rate - n) <= 1e-6 * rate:
        k0 = math.ceil(start * n - EPOCH_TOL_S * n)
        k1 = math.floor(end * n + EPOCH_TOL_S * n)
        return np.arange(k0, k1 + 1, dtype=float) / n
    k0 = math.ceil((start - EPOCH_TOL_S) / period)
    k1 = math.floor((end + EPOCH_TOL_S) / period)
    return np.arange(k0, k1 + 1, dtype=float) * period


def fused_on_epochs(t: np.ndarray, pos: np.ndarray, epochs: np.ndarray, period: float
                    ) -> np.ndarray:
    """One fused object's positions (R, 3) m at its rows' times ``t`` (R,) s (sorted, unique)
    on the grid ``epochs`` (K,) s -> (K, 3) m: a row's own value at an epoch it lies on (within
    ``EPOCH_TOL_S``), else linear interpolation between two consecutive rows at most 1.5
    ``period`` apart; NaN elsewhere (before, after or inside a gap of its output)."""
    out = np.full((epochs.size, 3), np.nan)
    if t.size == 0:
        return out
    j = np.searchsorted(t, epochs - EPOCH_TOL_S, side="left")       # first row >= epoch
    jj = np.minimum(j, t.size - 1)
    exact = (j < t.size) & (np.abs(t[jj] - epochs) <= EPOCH_TOL_S)
    out[exact] = pos[jj[exact]]
    lo = np.maximum(j - 1, 0)
    between = ~exact & (j > 0) & (j < t.size)
    between &= (t[jj] - t[lo]) <= 1.5 * period + EPOCH_TOL_S
    if between.any():
        ta, tb = t[lo[between]], t[jj[between]]
        w = ((epochs[between] - ta) / (tb - ta))[:, None]
        out[between] = (1.0 - w) * pos[lo[between]] + w * pos[jj[between]]
    return out


def truth_on_epochs(t_truth: np.ndarray, pos_truth: np.ndarray, epochs: np.ndarray
                    ) -> np.ndarray:
    """Truth positions (M_s, 3) m sampled at ``t_truth`` (M_s,) s, linearly interpolated to
    ``epochs`` (K,) s -> (K, 3) m, NaN outside [min t_truth, max t_truth]."""
    order = np.argsort(t_truth, kind="stable")
    tt, xx = t_truth[order], pos_truth[order]
    out = np.full((epochs.size, 3), np.nan)
    inside = (epochs >= tt[0]) & (epochs <= tt[-1])
    for a in range(3):
        out[inside, a] = np.interp(epochs[inside], tt, xx[:, a])
    return out


def assign_epochs(truth_pos: np.ndarray, fused_pos: np.ndarray, cutoff: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Optimal per-epoch assignment with cutoff ``cutoff`` (m).

    truth_pos: (K, M, 3), fused_pos: (K, N, 3) m, NaN rows for absent objects. Returns
    assigned (K, M) fused index or -1, and distance (K, M) m (NaN where unassigned).
    """
    k_n, m_n, _ = truth_pos.shape
    n_n = fused_pos.shape[1]
    if m_n == 0 or n_n == 0:
        return np.full((k_n, m_n), -1), np.full((k_n, m_n), np.nan)
    d2 = np.zeros((k_n, m_n, n_n))
    for a in range(3):
        d2 += (truth_pos[:, :, None, a] - fused_pos[:, None, :, a]) ** 2
    dist = np.sqrt(d2)                                  # NaN where either object is absent
    within = dist < cutoff                              # NaN compares False
    assigned = np.where(within.any(axis=2), np.argmax(within, axis=2), -1)
    # With at most one candidate within c per truth row and per fused column, taking every
    # such pair is the unique optimum (each costs d^p < c^p = one missed + one false).
    simple = (within.sum(axis=2) <= 1).all(axis=1) & (within.sum(axis=1) <= 1).all(axis=1)
    hard = np.flatnonzero(~simple)
    if hard.size:
        ok = np.concatenate((np.isfinite(truth_pos[hard]).all(axis=2),
                             np.isfinite(fused_pos[hard]).all(axis=2)), axis=1)
        patterns, group = np.unique(ok, axis=0, return_inverse=True)
        for g, pattern in enumerate(patterns):      # epochs with the same objects present
            rows, cols = np.flatnonzero(pattern[:m_n]), np.flatnonzero(pattern[m_n:])
            ks = hard[group.ravel() == g]
            sub = dist[ks][:, rows][:, :, cols]
            cost = np.minimum(sub, cutoff) ** P     # min(d, c)^p
            assigned[ks] = -1
            for k, ck, dk in zip(ks, cost, sub):
                r, c = linear_sum_assignment(ck)
                keep = dk[r, c] < cutoff
                assigned[k, rows[r[keep]]] = cols[c[keep]]
    d_ass = np.take_along_axis(dist, np.maximum(assigned, 0)[:, :, None], axis=2)[:, :, 0]
    return assigned, np.where(assigned >= 0, d_ass, np.nan)


def multi_object_metrics(fused_t: np.ndarray, fused_id: np.ndarray, fused_pos: np.ndarray,
                         truth_t: np.ndarray, truth_id: np.ndarray, truth_pos: np.ndarray,
                         cutoff: float = 50.0, where: str = "fused output",
                         period: float | None = None) -> MultiObjectEvaluation:
    """Assign fused objects to truth objects at every evaluation epoch and compute GOSPA.

    fused_t (R,) s, fused_id (R,) str, fused_pos (R, 3) m: one row per fused object epoch
    (rows with non-finite values are ignored); truth_t (S,) s, truth_id (S,) str, truth_pos
    (S, 3) m: dense truth samples. ``where`` names the fused file in error messages.
    ``period``: the evaluation grid's period (s); None: the fused output's (module docstring),
    or the truth's sample spacing when no fused object has two epochs.
    """
    if not (math.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff must be a positive number of metres, got {cutoff}")
    ok = np.isfinite(fused_t) & np.isfinite(fused_pos).all(axis=1)
    fused_t, fused_id, fused_pos = fused_t[ok], fused_id[ok], fused_pos[ok]
    ok = np.isfinite(truth_t) & np.isfinite(truth_pos).all(axis=1)
    truth_t, truth_id, truth_pos = truth_t[ok], truth_id[ok], truth_pos[ok]
    f_ids, f_idx = np.unique(fused_id, return_inverse=True)
    t_ids, t_idx = np.unique(truth_id, return_inverse=True)
    order = np.lexsort((fused_t, f_idx))
    fused_t, f_idx, fused_pos = fused_t[order], f_idx[order], fused_pos[order]
    same = (np.diff(f_idx) == 0) & (np.diff(fused_t) <= EPOCH_TOL_S)
    if same.any():
        r = int(np.flatnonzero(same)[0])
        raise DataError(f"{where}: column 'time': target {f_ids[f_idx[r]]} has two "
                        f"rows at time {float(fused_t[r])!r}")
    if period is None:
        period = fused_period(fused_t, f_idx) or fused_period(truth_t, t_idx) or 1.0
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period must be a positive number of seconds, got {period}")
    epochs = (grid_epochs(float(truth_t.min()), float(truth_t.max()), period)
              if truth_t.size else np.empty(0))
    f_pos = np.full((epochs.size, f_ids.size, 3), np.nan)
    for j in range(f_ids.size):
        sel = f_idx == j
        f_pos[:, j] = fused_on_epochs(fused_t[sel], fused_pos[sel], epochs, period)
    seen = np.isfinite(f_pos).all(axis=2)
    tr = np.full((epochs.size, t_ids.size, 3), np.nan)
    for i in range(t_ids.size):
        sel = t_idx == i
        tr[:, i] = truth_on_epochs(truth_t[sel], truth_pos[sel], epochs)
    assigned, distance = assign_epochs(tr, f_pos, cutoff)
    n_a = (assigned >= 0).sum(axis=1)
    n_missed = np.isfinite(tr).all(axis=2).sum(axis=1) - n_a
    n_false = seen.sum(axis=1) - n_a
    loc = np.where(assigned >= 0, distance, 0.0) ** P      # sum d^p over assigned pairs
    loc = loc.sum(axis=1)
    missed = cutoff**P / ALPHA * n_missed                   # c^p / alpha per missed object
    false = cutoff**P / ALPHA * n_false                     # c^p / alpha per false object
    return MultiObjectEvaluation(
        cutoff=float(cutoff), t=epochs, truth_ids=tuple(str(x) for x in t_ids),
        fused_ids=tuple(str(x) for x in f_ids), truth_pos=tr, fused_pos=f_pos,
        assigned=assigned, distance=distance, localisation=loc, missed=missed, false=false,
        gospa=(loc + missed + false) ** (1.0 / P))


def _f(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _truth_summary(ev: MultiObjectEvaluation, i: int,
                   observed: tuple[float, float] | None = None) -> dict[str, Any]:
    exists = np.isfinite(ev.truth_pos[:, i]).all(axis=1)
    a = ev.assigned[exists, i]
    n = int(exists.sum())
    out: dict[str, Any] = {"n_epochs": n, "best_match": None, "best_match_epochs": 0,
                           "best_match_rmse": None, "best_match_p95": None,
                           "assigned_epochs": 0, "assigned_rmse": None,
                           "coverage": None, "coverage_observed": None, "swaps": 0,
                           "fragmentation": 0}
    if observed is not None:
        seen = exists & (ev.t >= observed[0]) & (ev.t <= observed[1])
        if seen.any():
            out["coverage_observed"] = float((ev.assigned[seen, i] >= 0).mean())
    if n == 0:
        return out
    ka = np.flatnonzero(a >= 0)          # assigned epochs, indices among the existing ones
    out["coverage"] = ka.size / n
    if ka.size == 0:
        return out
    seq = a[ka]
    counts = np.bincount(seq, minlength=len(ev.fused_ids))
    best = int(np.argmax(counts))
    err = np.linalg.norm(ev.fused_pos[exists, best] - ev.truth_pos[exists, i], axis=1)
    err = err[np.isfinite(err)]          # epochs where the best match exists too
    d = ev.distance[exists, i][ka]
    out.update(best_match=ev.fused_ids[best], best_match_epochs=int(counts[best]),
               best_match_rmse=_f(np.sqrt(np.mean(err**2))),
               best_match_p95=_f(np.percentile(err, 95)),
               assigned_epochs=int(ka.size), assigned_rmse=_f(np.sqrt(np.mean(d**2))),
               swaps=int(np.count_nonzero(seq[1:] != seq[:-1])),
               fragmentation=int(np.count_nonzero(np.diff(ka) - 1 > FRAGMENT_GAP_EPOCHS)))
    return out


def _fused_summary(ev: MultiObjectEvaluation, j: int) -> dict[str, Any]:
    exists = np.isfinite(ev.fused_pos[:, j]).all(axis=1)
    owner = np.full(ev.t.size, -1)
    kk, ii = np.nonzero(ev.assigned == j)
    owner[kk] = ii                        # truth object assigned to fused j at each epoch
    own = owner[exists]
    counts = np.bincount(own[own >= 0], minlength=len(ev.truth_ids))
    n = int(exists.sum())
    top = int(np.argmax(counts)) if counts.size else 0
    has = counts.size > 0 and counts[top] > 0
    return {"n_epochs": n, "majority_truth": ev.truth_ids[top] if has else None,
            "purity": float(counts[top]) / n if has and n else 0.0,
            "false_epochs": int(np.count_nonzero(own < 0))}


def summarise(ev: MultiObjectEvaluation,
              observed: Mapping[str, tuple[float, float]] | None = None) -> dict[str, Any]:
    """JSON-ready summary of ``ev``: GOSPA statistics (m; parts in m^2), per truth object and
    per fused object metrics (see the module docstring) and totals. ``observed``: truth id ->
    (first, last) time (s) it was measured, for ``coverage_observed``."""
    k = ev.t.size
    g = ev.gospa
    c2 = ev.cutoff**P / ALPHA
    gospa = {"mean": _f(g.mean()) if k else None,
             "p95": _f(np.percentile(g, 95)) if k else None,
             "max": _f(g.max()) if k else None,
             "rms": _f(np.sqrt(np.mean(g**2))) if k else None,
             "localisation_mean": _f(ev.localisation.mean()) if k else None,
             "missed_mean": _f(ev.missed.mean()) if k else None,
             "false_mean": _f(ev.false.mean()) if k else None,
             "n_missed_mean": _f(ev.missed.mean() / c2) if k else None,
             "n_false_mean": _f(ev.false.mean() / c2) if k else None}
    truth = {tid: _truth_summary(ev, i, (observed or {}).get(tid))
             for i, tid in enumerate(ev.truth_ids)}
    fused = {fid: _fused_summary(ev, j) for j, fid in enumerate(ev.fused_ids)}
    cov = [m["coverage"] for m in truth.values() if m["coverage"] is not None]
    return {
        "cutoff_m": ev.cutoff, "p": P, "alpha": ALPHA, "n_epochs": int(k),
        "time_span": [_f(ev.t[0]), _f(ev.t[-1])] if k else None,
        "gospa": gospa, "truth": truth, "fused": fused,
        "totals": {"n_truth": len(ev.truth_ids), "n_fused": len(ev.fused_ids),
                   "swaps": sum(m["swaps"] for m in truth.values()),
                   "fragmentation": sum(m["fragmentation"] for m in truth.values()),
                   "false_epochs": sum(m["false_epochs"] for m in fused.values()),
                   "coverage_mean": _f(np.mean(cov)) if cov else None,
                   "gospa_mean": gospa["mean"]},
    }


def gospa_series(ev: MultiObjectEvaluation) -> dict[str, np.ndarray]:
    """Per-epoch columns (K,): time (s), gospa (m), localisation, missed, false (m^2) and the
    numbers of truth, fused and assigned objects."""
    n_a = (ev.assigned >= 0).sum(axis=1)
    return {"time": ev.t, "gospa": ev.gospa, "localisation": ev.localisation,
            "missed": ev.missed, "false": ev.false,
            "n_truth": np.isfinite(ev.truth_pos).all(axis=2).sum(axis=1),
            "n_fused": np.isfinite(ev.fused_pos).all(axis=2).sum(axis=1), "n_assigned": n_a}


def format_multi(multi: dict[str, Any]) -> str:
    """Compact table of :func:`summarise`'s result: one line per truth object, one for GOSPA,
    one for the purity of the fused objects."""
    def num(x: float | None, fmt: str) -> str:
        return "-" if x is None else format(x, fmt)

    tot, g = multi["totals"], multi["gospa"]
    head = (f"{'truth':<8}{'best':<8}{'RMSE m':>8}{'p95 m':>8}{'asgn RMSE':>11}"
            f"{'coverage':>10}{'swaps':>7}{'frag':>6}")
    lines = [f"multi-object: {tot['n_truth']} truth, {tot['n_fused']} fused objects, "
             f"{multi['n_epochs']} epochs, cutoff {multi['cutoff_m']:g} m",
             head, "-" * len(head)]
    for tid, m in multi["truth"].items():
        lines.append(f"{tid:<8}{m['best_match'] or '-':<8}{num(m['best_match_rmse'], '.2f'):>8}"
                     f"{num(m['best_match_p95'], '.2f'):>8}{num(m['assigned_rmse'], '.2f'):>11}"
                     f"{num(m['coverage'], '.3f'):>10}{m['swaps']:>7}{m['fragmentation']:>6}")
    lines.append(f"GOSPA (p=2, alpha=2) m: mean {num(g['mean'], '.2f')}, p95 "
                 f"{num(g['p95'], '.2f')}, max {num(g['max'], '.2f')}; mean parts m^2: "
                 f"localisation {num(g['localisation_mean'], '.2f')}, missed "
                 f"{num(g['missed_mean'], '.2f')}, false {num(g['false_mean'], '.2f')}")
    lines.append("purity: " + ", ".join(
        f"{fid} {m['purity']:.2f} ({m['majority_truth'] or 'none'}"
        + (f", {m['false_epochs']} false epochs)" if m["false_epochs"] else ")")
        for fid, m in multi["fused"].items()))
    return "\n".join(lines)
