"""Accuracy and consistency of a fused trajectory against truth.

``evaluate_run(out_dir, truth_path)`` reads ``out_dir/fused.parquet`` (data contract section 4)
and a truth table (:mod:`rangeproc.evaluate.truth`: ``time`` as float seconds or ISO-8601,
position as ``e, n, u`` in range ENU or ``lat, lon, height`` converted with the range origin,
optional ``ve, vn, vu`` and ``target_id``), linearly interpolates truth to the fused epochs
that lie inside the truth span (never beyond it), and returns per-target errors (range ENU
frame, m and m/s; velocity metrics None when the truth has no velocity) and position NEES.
NEES uses the full 3x3 position covariance when the fused file has ``cov_en, cov_eu, cov_nu``,
else the diagonal ``sigma_e/n/u``. Successive epochs are correlated, so the chi-square bounds
of the mean NEES are reported for reference, not as a test.

With several objects (more than one target id in truth or fused output, or a fused id that truth
lacks, e.g. a discovered object "O1"), the result also has a "multi" entry: fused objects are
assigned to truth objects by position at every epoch, with GOSPA over time and identity metrics
(see :mod:`rangeproc.evaluate.multi`).
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from rangeproc.quantiles import chi2_ppf

from rangeproc.errors import DataError, NumericalError
from rangeproc.evaluate.multi import format_multi, gospa_series, multi_object_metrics, summarise
from rangeproc.evaluate.truth import Truth, check_overlap, load_truth, span_text
from rangeproc.io.writers import write_parquet
from rangeproc.settings import Geodetic

FUSED_COLUMNS = ("target_id", "time", "e", "n", "u", "ve", "vn", "vu",
                 "sigma_e", "sigma_n", "sigma_u")
COV_COLUMNS = ("cov_en", "cov_eu", "cov_nu")


def _read(path: Path, required: tuple[str, ...]) -> pd.DataFrame:
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: cannot read table: {exc}") from exc
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DataError(f"{path}: missing column '{missing[0]}' (need {', '.join(required)})")
    if df.empty:
        raise DataError(f"{path}: no data rows (need columns {', '.join(required)})")
    for c in required:
        if c == "target_id" or pd.api.types.is_numeric_dtype(df[c]):
            continue
        num = pd.to_numeric(df[c], errors="coerce")
        bad = np.flatnonzero(num.isna().to_numpy() & df[c].notna().to_numpy())
        if bad.size:
            raise DataError(f"{path}: column '{c}' row {bad[0]}: not a number "
                            f"({df[c].iloc[bad[0]]!r})")
        df[c] = num.astype(float)
    return df


def interpolate_truth(t_truth: np.ndarray, x_truth: np.ndarray, t: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of truth x_truth (M, k) at times t (n,) -> ((n, k), inside (n,)).

    Rows of t outside [t_truth.min(), t_truth.max()] are flagged False (values are NaN)."""
    order = np.argsort(t_truth, kind="stable")
    tt, xx = t_truth[order], x_truth[order]
    inside = (t >= tt[0]) & (t <= tt[-1])
    out = np.full((t.size, xx.shape[1]), np.nan)
    for j in range(xx.shape[1]):
        out[inside, j] = np.interp(t[inside], tt, xx[:, j])
    return out, inside


def position_covariance(df: pd.DataFrame) -> np.ndarray:
    """(N, 3, 3) ENU position covariance (m^2) from sigma_* and optional cov_* columns."""
    sig = df[["sigma_e", "sigma_n", "sigma_u"]].to_numpy(float)
    cov = np.zeros((len(df), 3, 3))
    cov[:, [0, 1, 2], [0, 1, 2]] = sig**2
    if all(c in df.columns for c in COV_COLUMNS):
        for (i, j), c in zip(((0, 1), (0, 2), (1, 2)), COV_COLUMNS):
            cov[:, i, j] = cov[:, j, i] = df[c].to_numpy(float)
    return cov


_NO_VELOCITY = {"vel_rmse": None, "vel_rmse_enu": None, "vel_p95": None}


def error_metrics(pos_err: np.ndarray, vel_err: np.ndarray | None, cov: np.ndarray,
                  where: str = "") -> dict[str, Any]:
    """Metrics of position errors (N, 3) m, velocity errors (N, 3) m/s (None: the truth has no
    velocity, velocity metrics None) and position covariance (N, 3, 3) m^2."""
    n = pos_err.shape[0]
    if n == 0:
        return {"n_epochs": 0, "pos_rmse": None, "pos_rmse_enu": None, "pos_p95": None,
                **_NO_VELOCITY, "inside_3sigma_enu": None, "nees_pos_mean": None,
                "nees_pos_chi2_95": None, "nees_dof": None}
    pos_norm = np.linalg.norm(pos_err, axis=1)
    sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    # an axis the output states no variance for at any epoch (a 2-D tracker's sigma_u = 0)
    # is left out of the NEES, whose degrees of freedom are the other axes
    axes = np.flatnonzero((sigma > 0).any(axis=0))
    axes = axes if axes.size else np.arange(3)
    e, c = pos_err[:, axes], cov[:, axes][:, :, axes]
    try:
        # NEES_k = e_k^T P_k^-1 e_k (3 dof, or the axes with variance)
        nees = np.einsum("ni,ni->n", e, np.linalg.solve(c, e[:, :, None])[:, :, 0])
    except np.linalg.LinAlgError as exc:
        raise NumericalError(f"{where}: singular position covariance in fused output") from exc
    lo, hi = chi2_ppf([0.025, 0.975], axes.size * n) / n
    return {
        "n_epochs": int(n),
        "pos_rmse": _f(np.sqrt(np.mean(pos_norm**2))),
        "pos_rmse_enu": [_f(x) for x in np.sqrt(np.mean(pos_err**2, axis=0))],
        "pos_p95": _f(np.percentile(pos_norm, 95)),
        **(_NO_VELOCITY if vel_err is None else _velocity_metrics(vel_err)),
        "inside_3sigma_enu": [_f(x) for x in np.mean(np.abs(pos_err) <= 3 * sigma, axis=0)],
        "nees_pos_mean": _f(np.mean(nees)),
        "nees_pos_chi2_95": [_f(lo), _f(hi)],
        "nees_dof": int(axes.size),
    }


def _velocity_metrics(vel_err: np.ndarray) -> dict[str, Any]:
    """RMSE (norm and per axis) and 95th percentile of velocity errors (N, 3) m/s, N > 0."""
    vel_norm = np.linalg.norm(vel_err, axis=1)
    return {"vel_rmse": _f(np.sqrt(np.mean(vel_norm**2))),
            "vel_rmse_enu": [_f(x) for x in np.sqrt(np.mean(vel_err**2, axis=0))],
            "vel_p95": _f(np.percentile(vel_norm, 95))}


def _f(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def evaluate_run(out_dir: Path, truth_path: Path, cutoff: float = 50.0,
                 series_path: Path | None = None,
                 observed: Mapping[str, tuple[float, float]] | None = None, *,
                 origin: Geodetic | None = None, require_overlap: bool = False
                 ) -> dict[str, Any]:
    """Compare ``out_dir/fused.parquet`` with truth; JSON-serialisable result.

    Returns {"fused": path, "truth": path, "truth_format": :meth:`Truth.describe`,
    "targets": {target_id: metrics}, "unmatched": [target ids of fused that truth lacks]};
    metrics as :func:`error_metrics` plus the epoch counts of :func:`target_metrics`
    (n_epochs counts the fused epochs inside the truth span with finite state and sigmas).
    A truth without ``target_id`` is one object: it is compared with the fused target when
    there is one, else named "T1". A geodetic truth is converted with ``origin`` (deg, deg, m)
    when given, else with the ``[range] origin`` of the run's config (``out_dir/summary.json``).
    ``require_overlap``: DataError naming both time spans when no fused epoch lies in the
    truth's span (else every target reports 0 epochs). For several objects also "multi":
    :func:`rangeproc.evaluate.multi.summarise` with assignment cutoff ``cutoff``
    (m); then, if ``series_path`` is given, the per-epoch GOSPA table
    (:func:`rangeproc.evaluate.multi.gospa_series`) is written there as Parquet and
    "multi"["gospa"]["series_file"] names it. ``observed``: truth id -> (first, last) time
    (s) it was measured, for each object's ``coverage_observed``.
    """
    fused_path, truth_path = Path(out_dir) / "fused.parquet", Path(truth_path)
    fused = _read(fused_path, FUSED_COLUMNS)
    truth = load_truth(truth_path, Path(out_dir), origin)
    if require_overlap:
        check_overlap(fused["time"].to_numpy(float), truth, fused_path.name)
    fused_ids = fused["target_id"].astype(str)
    truth_ids = _truth_ids(truth, fused_ids)
    result: dict[str, Any] = {"fused": str(fused_path), "truth": str(truth_path),
                              "truth_format": truth.describe(), "targets": {},
                              "unmatched": [],
                              "calibration_terms": estimated_terms(Path(out_dir))}
    for tid, grp in fused.groupby(fused_ids, sort=True):
        sel = truth_ids == tid
        if not sel.any():
            result["unmatched"].append(tid)
            continue
        result["targets"][tid] = target_metrics(grp, truth, sel, f"{fused_path}: target {tid}")
    if len(np.unique(truth_ids)) > 1 or fused_ids.nunique() > 1 or result["unmatched"]:
        ev = multi_object_metrics(
            fused["time"].to_numpy(float), _str_array(fused_ids),
            fused[["e", "n", "u"]].to_numpy(float), truth.time, truth_ids, truth.pos,
            cutoff=cutoff, where=str(fused_path))
        result["multi"] = summarise(ev, observed)
        _match_by_assignment(result, fused, fused_ids, truth, truth_ids, str(fused_path))
        if series_path is not None:
            write_parquet(pd.DataFrame(gospa_series(ev)), series_path)
            result["multi"]["gospa"]["series_file"] = str(series_path)
    return result


def _match_by_assignment(result: dict[str, Any], fused: pd.DataFrame, fused_ids: pd.Series,
                         truth: Truth, truth_ids: np.ndarray, where: str) -> None:
    """Per-object errors for truth objects whose id no fused object carries (a truth naming
    its boats B1, B2 against discovered objects O1, T1): each is compared with its best match
    of the several-objects assignment (``multi.truth.<id>.best_match``) and entered in
    ``result["targets"]`` under the truth id with ``fused_id`` naming the match; fused objects
    matched so leave ``result["unmatched"]``."""
    matched = set()
    for tid, m in result["multi"]["truth"].items():
        fid = m.get("best_match")
        if tid in result["targets"] or fid is None:
            continue
        grp = fused[fused_ids == fid]
        metrics = target_metrics(grp, truth, truth_ids == tid, f"{where}: target {fid}")
        result["targets"][tid] = {"fused_id": fid, **metrics}
        matched.add(fid)
    result["unmatched"] = [f for f in result["unmatched"] if f not in matched]


#: A mean position NEES under half its expected 3 (the sigma more than 1.4 times the RMS
#: error) gets a line on why, where the run estimated calibration terms (format_report).
LOW_NEES = 1.5


def estimated_terms(out_dir: Path) -> int:
    """How many calibration terms the run in ``out_dir`` estimated (``summary.json``:
    ``sensors.<id>.calibration.<name>.estimate`` not null); 0 without a readable summary."""
    try:
        sensors = json.loads((out_dir / "summary.json").read_text()).get("sensors") or {}
        return sum(1 for s in sensors.values() if isinstance(s, dict)
                   for c in (s.get("calibration") or {}).values()
                   if isinstance(c, dict) and c.get("estimate") is not None)
    except (OSError, ValueError, AttributeError):
        return 0


def _truth_ids(truth: Truth, fused_ids: pd.Series) -> np.ndarray:
    """(S,) str id of each truth row: the file's, or for a file without ids the only fused
    target's id ("T1" when the fused output has several)."""
    if truth.target_id is not None:
        return truth.target_id
    only = fused_ids.unique()
    return np.full(truth.time.size, str(only[0]) if only.size == 1 else "T1")


def target_metrics(grp: pd.DataFrame, truth: Truth, sel: np.ndarray, where: str
                   ) -> dict[str, Any]:
    """:func:`error_metrics` of one fused target (rows ``grp``) against the truth rows ``sel``
    (S,) bool, with its epoch counts: n_fused_epochs (its rows), n_without_truth (outside the
    truth span), n_not_finite (inside, but non-finite state or sigma), truth_span [s, s]."""
    t = grp["time"].to_numpy(float)
    cols = ["e", "n", "u"] + (["ve", "vn", "vu"] if truth.vel is not None else [])
    x_truth = truth.pos[sel] if truth.vel is None else np.hstack((truth.pos[sel],
                                                                   truth.vel[sel]))
    ref, inside = interpolate_truth(truth.time[sel], x_truth, t)
    est = grp[cols].to_numpy(float)
    cov = position_covariance(grp)
    ok = inside & np.isfinite(est).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
    err = est[ok] - ref[ok]
    out = error_metrics(err[:, :3], err[:, 3:] if truth.vel is not None else None, cov[ok],
                        where)
    out.update(n_fused_epochs=int(t.size), n_without_truth=int((~inside).sum()),
               n_not_finite=int((inside & ~ok).sum()),
               truth_span=[float(truth.time[sel].min()), float(truth.time[sel].max())])
    return out


def _str_array(ids: pd.Series) -> np.ndarray:
    """Target ids as a NumPy unicode array (fast to sort, unlike an object array)."""
    codes, names = pd.factorize(ids, use_na_sentinel=False)
    return np.asarray(names, dtype=str)[codes]


def format_report(metrics: dict[str, Any]) -> str:
    """Human-readable table of :func:`evaluate_run`'s result."""
    head = (f"{'target':<8}{'epochs':>8}  {'pos RMSE m (E/N/U)':<26}{'pos p95':>8}  "
            f"{'vel RMSE m/s (E/N/U)':<26}{'vel p95':>8}  {'in 3sigma E/N/U':<17}"
            f"{'NEES':>7}  {'95% bounds':<13}")
    fmt = metrics.get("truth_format")
    lines = [f"fused: {metrics.get('fused', '?')}",
             f"truth: {metrics.get('truth', '?')}" + (f" ({_format_text(fmt)})" if fmt else ""),
             head, "-" * len(head)]
    for key, m in metrics.get("targets", {}).items():
        tid = f"{key}>{m['fused_id']}" if m.get("fused_id") else key
        if not m["n_epochs"]:
            lines.append(f"{tid:<8}{0:>8}  (no fused epoch inside the truth span)")
            continue
        pe, ve, ins = m["pos_rmse_enu"], m["vel_rmse_enu"], m["inside_3sigma_enu"]
        pos = f"{m['pos_rmse']:.2f} ({pe[0]:.2f}/{pe[1]:.2f}/{pe[2]:.2f})"
        vel = ("n/a" if m["vel_rmse"] is None
               else f"{m['vel_rmse']:.3f} ({ve[0]:.3f}/{ve[1]:.3f}/{ve[2]:.3f})")
        vel_p95 = "n/a" if m["vel_p95"] is None else f"{m['vel_p95']:.3f}"
        inside = f"{ins[0]:.3f}/{ins[1]:.3f}/{ins[2]:.3f}"
        lo, hi = m["nees_pos_chi2_95"]
        lines.append(f"{tid:<8}{m['n_epochs']:>8}  {pos:<26}{m['pos_p95']:>8.2f}  {vel:<26}"
                     f"{vel_p95:>8}  {inside:<17}{_num(m['nees_pos_mean']):>7}  "
                     f"[{lo:.2f}, {hi:.2f}]")
    lines += [_epochs_text(tid, m) for tid, m in metrics.get("targets", {}).items()
              if "n_fused_epochs" in m]
    matched = [f"{tid} by {m['fused_id']}" for tid, m in metrics.get("targets", {}).items()
               if m.get("fused_id")]
    if matched:
        lines.append("truth objects scored by their best-matching output object "
                     f"(truth>output): {', '.join(matched)}")
    if fmt and not fmt["velocity"]:
        lines.append("velocity not evaluated: the truth has no ve, vn, vu columns")
    if metrics.get("unmatched"):
        lines.append("unmatched (no truth): " + ", ".join(metrics["unmatched"]))
    lines.append("NEES: mean position NEES (3 dof, consistent ~3); bounds assume independent "
                 "epochs (successive epochs are correlated).")
    low = [tid for tid, m in metrics.get("targets", {}).items()
           if m.get("n_epochs") and m.get("nees_pos_mean") is not None
           and m["nees_pos_mean"] < LOW_NEES]
    if low and metrics.get("calibration_terms"):
        lines.append(f"NEES under {LOW_NEES:g} ({', '.join(low)}): the stated sigma includes the "
                     f"uncertainty of the {metrics['calibration_terms']} calibration terms the "
                     "run estimated (summary.json: sensors.<id>.calibration), also of those it "
                     "found insignificant and left uncorrected; on data without systematic "
                     "errors that sigma is conservative.")
    if "multi" in metrics:
        lines += ["", format_multi(metrics["multi"])]
    return "\n".join(lines)


def _num(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.2f}"


def _format_text(fmt: dict[str, Any]) -> str:
    """The truth's columns and, for a geodetic truth, the origin used and its source."""
    text = fmt["position"] + (", ve, vn, vu" if fmt["velocity"] else "")
    if fmt.get("origin"):
        lat, lon, h = fmt["origin"]
        text += f"; range origin {lat:g}, {lon:g}, {h:g} m from {fmt['origin_source']}"
    return text


def _epochs_text(tid: str, m: dict[str, Any]) -> str:
    """How many of a target's fused epochs were evaluated, and why the others were not."""
    text = (f"epochs {tid}: {m['n_epochs']} of {m['n_fused_epochs']} fused epochs evaluated, "
            f"{m['n_without_truth']} without truth")
    if m.get("n_not_finite"):
        text += f", {m['n_not_finite']} with a non-finite state or sigma"
    return text + f"; truth span {span_text(*m['truth_span'])}"
