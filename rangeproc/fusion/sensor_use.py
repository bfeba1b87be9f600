"""How the fused objects used one sensor's rows: ``summary.json``'s per-sensor counts, noise and
bias, over every object the sensor's rows went to.

A sensor that sees several objects contributes to each object's fusion, and each fusion
estimates the sensor's noise from its own residuals. The summary gives the sensor's totals
(row and component counts summed over the objects) and one noise and bias per component,
combined over the objects:

* ``noise.<component>.estimated``: the median of the objects' estimates ``s_k`` weighted by the
  used components ``n_k`` of each (the estimate that the objects holding half the sensor's used
  rows or more agree with): a sensor's noise is one, whatever it saw, and an object that holds
  rows of several things (residuals of kilometres on a few dozen rows) says more about that
  object than about the sensor, so it does not decide the sensor's noise nor raise a unit
  warning (``by_object`` still shows it);
* ``bias.<component>.median_residual``: the median of the used residuals of every object
  together;
* ``noise.<component>.correlation``: the lag-1 correlation of the sensor's normalised final
  residuals, consecutive rows of one object (``fusion.noise.lag_correlation``), pooled over the
  objects like the sigma, and ``noise.<component>.discount``: the factor its rows' sigma
  carries for it (``fusion.noise.correlation_discount``; 1 for errors white in time).

With more than one object, ``by_object`` gives each object's own rows used, noise estimate and
median residual per component, so that a sensor whose noise differs between objects (one
near, one far) can be read object by object.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rangeproc.config import SensorSettings
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.fusion.noise import correlation_discount, lag_correlation
from rangeproc.models.measurement import COMPONENTS
from rangeproc.results import SensorResiduals
from rangeproc.summary_types import BiasEntry, NoiseEntry, SensorUse

#: Summary noise key of each measured component (its a-priori sigma's name in the config).
SIGMA_KEY = {"e": "horizontal", "n": "horizontal", "u": "vertical", "ve": "velocity",
             "vn": "velocity", "vu": "velocity"}


@dataclass(frozen=True, slots=True)
class ObjectUse:
    """Object ``target_id``'s fusion ``result``, in which the sensor is ``index``, and that
    sensor's residuals in it."""

    target_id: str
    result: FusionResult
    index: int
    residuals: SensorResiduals


def _component_stats(use: ObjectUse
                     ) -> dict[str, tuple[str, float | None, np.ndarray, float]]:
    """Per measured component of the sensor in one object: (unit, estimated sigma or None,
    the used residuals (K,), their lag-1 correlation)."""
    res, i = use.result, use.index
    at = np.flatnonzero(res.batch.sensor == i)       # the sensor's rows, in time order
    model = int(res.batch.model[at[0]])
    names, units = COMPONENTS[model]
    t = res.batch.t[at]
    out = {}
    for c, (name, unit) in enumerate(zip(names, units)):
        # one column gathered at a time, not the rows' (n, 6) measurements and residuals
        # (a long sortie's sensor: 12 MiB resident again at the products' end)
        if not np.isfinite(res.batch.z[at, c]).any():
            continue
        r = res.res[at, c]
        used = res.used[at, c] & np.isfinite(r)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = r / res.batch.sigma[at, c]
        rho = lag_correlation(t, u, used)
        out[name] = (unit, res.noise.get((i, c)), r[used], rho)
    return out


def _pooled(parts: Sequence[tuple[float | None, np.ndarray]]) -> float | None:
    """The median of the sigmas s weighted by the rows n of each (sigma s, residuals of n
    rows): the smallest s whose objects, with those of smaller s, hold at least half the rows
    (the plain median of the sigmas when no object used a row); None without any."""
    n = np.array([r.size for s, r in parts if s is not None and np.isfinite(s)], float)
    s = np.array([s for s, _ in parts if s is not None and np.isfinite(s)], float)
    if s.size == 0:
        return None
    if n.sum() == 0:
        n = np.ones_like(s)
    order = np.argsort(s, kind="stable")
    cum = np.cumsum(n[order])
    return float(s[order][np.searchsorted(cum, 0.5 * cum[-1])])


def sensor_use(s: SensorSettings, uses: Sequence[ObjectUse]) -> SensorUse:
    """The summary entries of sensor ``s`` from its uses by the objects (in output order):
    ``n_used``, ``n_rejected`` (rows measured but with no component used), ``n_partly_rejected``
    (rows used with a component rejected), ``n_components_rejected`` (per component), ``noise``,
    ``bias`` (module docstring), ``target`` (the first object), ``targets`` and, with several
    objects, ``by_object`` (``summary_types.SensorUse``)."""
    n_used = n_rejected = n_partly = 0
    comp_rejected: dict[str, int] = {}
    stats = []
    for u in uses:
        sel = u.result.batch.sensor == u.index
        used_rows = u.result.used[sel].any(axis=1)
        measured = u.result.dof[sel] > 0
        n_used += int(used_rows.sum())
        n_rejected += int((measured & ~used_rows).sum())
        n_partly += int((used_rows & u.residuals.rejected.any(axis=1)).sum())
        for j, name in enumerate(u.residuals.components):
            comp_rejected[name] = comp_rejected.get(name, 0) + int(u.residuals.rejected[:, j].sum())
        stats.append(_component_stats(u))
    noise: dict[str, NoiseEntry] = {}
    bias: dict[str, BiasEntry] = {}
    for name in dict.fromkeys(n for st in stats for n in st):
        parts = [st[name] for st in stats if name in st]
        unit = parts[0][0]
        pooled = np.concatenate([p[2] for p in parts])
        n = np.array([p[2].size for p in parts], float)
        rho = float(np.sum(n * [p[3] for p in parts]) / n.sum()) if n.sum() else 0.0
        noise[name] = {"unit": unit, "apriori": s.sigma.get(SIGMA_KEY.get(name, name)),
                       "estimated": _pooled([(p[1], p[2]) for p in parts]),
                       "correlation": round(rho, 4),
                       "discount": round(correlation_discount(rho), 4)}
        bias[name] = {"unit": unit,
                      "median_residual": float(np.median(pooled)) if pooled.size else None}
    out: SensorUse = {
        "n_used": n_used, "n_rejected": n_rejected, "n_partly_rejected": n_partly,
        "n_components_rejected": comp_rejected, "noise": noise, "bias": bias,
        "target": uses[0].target_id, "targets": [u.target_id for u in uses]}
    if len(uses) > 1:
        out["by_object"] = {
            u.target_id: {
                "n_used": int(u.result.used[u.result.batch.sensor == u.index].any(axis=1).sum()),
                "noise": {name: v[1] for name, v in st.items()},
                "median_residual": {name: float(np.median(v[2])) if v[2].size else None
                                    for name, v in st.items()}}
            for u, st in zip(uses, stats)}
    return out
