"""The Validation and performance pages, generated from the measurement files at build time.

``make accuracy``, ``make registration``, ``make calibration-mc``, ``make plan-check``,
``make range-rate``, ``make multi``, ``make harbour``, ``make autoferry`` and ``make bench`` write
``docs/measurements/<name>.json`` (each with a ``meta`` block: machine, UTC date, git commit,
command; ``bench/meta.py``). This module renders each file into a Markdown page of tables, so
that no number on those pages is copied by hand:

==========================================  ====================  =========================
page                                        measurements          made by
==========================================  ====================  =========================
validation/index.md                         all of them           (overview)
validation/accuracy.md                      accuracy.json         ``make accuracy``
validation/registration.md                  registration.json     ``make registration``
validation/calibration-uncertainty.md       calibration_mc.json   ``make calibration-mc``
validation/planning.md                      plan_check.json       ``make plan-check``
validation/range-rate.md                    range_rate.json       ``make range-rate``
validation/several-objects                  multi.json            ``make multi``
validation/harbour.md                       harbour.json          ``make harbour``
validation/real-data.md                     autoferry.json        ``make autoferry``
validation/speed.md                         bench.json            ``make bench``
==========================================  ====================  =========================

A page whose file is missing says "Not measured yet: run `make X`"; a file without a ``meta``
block (written before it existed) is rendered with the machine and date stated as unknown.

As an MkDocs hook (``hooks: [docs/hooks/validation.py]`` in ``mkdocs.yml``) the pages are
served as generated files (:func:`on_files`): nothing is written into ``docs/``. As a script,
``python docs/hooks/validation.py --out DIR`` writes them to ``DIR`` for a look without
MkDocs. The rendering needs only the standard library.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parents[1]
MEASUREMENTS = DOCS / "measurements"
GENERATED_NOTE = ("<!-- generated at build time by docs/hooks/validation.py from "
                  "docs/measurements/{file}: edit the generator, not this page -->")
DASH = "–"


# ------------------------------------------------------------------------ formatting
def fmt(value: Any, spec: str = ".3f") -> str:
    """``value`` formatted with ``spec``; a dash for None, NaN or a missing value."""
    if value is None or isinstance(value, bool):
        return DASH if value is None else ("yes" if value else "no")
    if isinstance(value, (int, float)):
        if isinstance(value, float) and not math.isfinite(value):
            return DASH if math.isnan(value) else ("∞" if value > 0 else "−∞")
        return format(value, spec)
    return str(value)


def table(headers: Sequence[str], rows: Iterable[Sequence[Any]],
          align: str | None = None) -> str:
    """A Markdown table; ``align``: one letter per column, ``l`` or ``r`` (default: the
    first column left, the others right)."""
    align = align or "l" + "r" * (len(headers) - 1)
    bar = ["---:" if a == "r" else "---" for a in align]
    lines = ["| " + " | ".join(h.replace("|", "\\|") for h in headers) + " |",
             "| " + " | ".join(bar) + " |"]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return "\n".join(lines)


def load(path: Path) -> tuple[Any, str | None]:
    """(data, None), (None, None) when the file is missing, (None, reason) when unreadable."""
    if not path.exists():
        return None, None
    try:
        return json.loads(path.read_text()), None
    except (OSError, ValueError) as exc:
        return None, f"{type(exc).__name__}: {exc}"


def rows_of(data: Any) -> list[Any]:
    """The rows of a list-valued bench result: ``{"meta", "rows"}`` or a bare list (files
    written before the meta block)."""
    if isinstance(data, dict):
        return list(data.get("rows") or [])
    return list(data or [])


def meta_of(data: Any) -> dict[str, Any] | None:
    """The ``meta`` block (``bench/meta.py``); for an older ``make bench`` file, the same
    facts from its ``machine`` block; None when the file does not say."""
    if isinstance(data, dict) and isinstance(data.get("meta"), dict):
        return data["meta"]
    if isinstance(data, dict) and isinstance(data.get("machine"), dict):
        m = data["machine"]
        return {"machine": {"cpu": m.get("processor") or m.get("machine"),
                            "cores": m.get("cpu_count"), "os": m.get("platform"),
                            "python": m.get("python"), "numpy": m.get("numpy"),
                            "numba": m.get("numba")},
                "date": m.get("timestamp"), "git_commit": m.get("git_commit"),
                "command": None}
    return None


def measured_on(data: Any, file: str, target: str) -> str:
    """The paragraph saying where, when and how the page's numbers were measured."""
    meta = meta_of(data)
    raw = f"Raw data: [`{file}`](../measurements/{file}); rerun with `make {target}`."
    if meta is None:
        return ("**Measured on:** machine and date unknown (this file has no `meta` block: "
                f"it was written before `make {target}` recorded them). " + raw)
    m = meta.get("machine") or {}
    cores = m.get("cores")
    usable = m.get("cores_usable")
    core_text = (f"{cores} cores" if cores and (usable in (None, cores))
                 else f"{usable} of {cores} cores" if cores else None)
    mem = f"{m['memory_gib']:g} GiB" if m.get("memory_gib") else None
    machine = ", ".join(p for p in (m.get("cpu"), core_text, mem, m.get("os")) if p)
    soft = ", ".join(f"{name} {m[key]}" for name, key in (
        ("Python", "python"), ("numpy", "numpy"), ("numba", "numba"),
        ("FilterPy", "filterpy"), ("Stone Soup", "stonesoup")) if m.get(key))
    date = meta.get("date") or "unknown date"
    parts = [f"**Measured on:** {machine or 'unknown machine'}"
             + (f" ({soft})" if soft else "") + f", {date.replace('T', ' ')} (UTC)"]
    if meta.get("git_commit"):
        parts.append(f"commit `{meta['git_commit']}`")
    load = m.get("load_average")
    if load:
        parts.append(f"load average {load[0]:.2f} at the end (1 min)")
    text = "; ".join(parts) + "."
    if meta.get("command"):
        text += f" Command: `{meta['command']}`."
    return text + " " + raw


def not_measured(title: str, file: str, target: str, reason: str | None = None) -> str:
    if reason:
        return (f"# {title}\n\n`docs/measurements/{file}` could not be read ({reason}). "
                f"Rerun `make {target}`.\n")
    return (f"# {title}\n\nNot measured yet: run `make {target}` (it writes "
            f"`docs/measurements/{file}`).\n")


# -------------------------------------------------------------------------- accuracy
def render_accuracy(data: Any) -> str:
    rows = rows_of(data)
    out = ["Each seed simulates a flight of a maneuvering aircraft (turns, climbs, speed "
           "changes) seen by a fixed radar, a theodolite of limited coverage, a ship radar on a "
           "rolling platform, a GPS with dropouts and a noise burst and several MISTRAM "
           "stations, with wild points. The fused trajectory is scored against the "
           "simulator's truth: 3-D position RMSE and 95th percentile, velocity RMSE, the share "
           "of output epochs whose error lies within 3 sigma on each axis (e, n, u), and the "
           "mean 3-D position NEES (3 when the sigmas are honest). The same seed is also run "
           "without the MISTRAM and theodolite files (*reduced*)."]
    groups: dict[tuple[str, float], list[dict]] = {}
    for r in rows:
        groups.setdefault((r.get("filter", "ekf"), r.get("sigma_factor", 1.0)), []).append(r)
    order = {"full": 0}
    for (name, factor), group in groups.items():
        title = f"Filter `{name}`"
        if factor != 1.0:
            title += f", stated sigmas × {factor:g}"
        group = sorted(group, key=lambda r: (order.get(r.get("case"), 1), r.get("seed", 0)))
        out.append(f"## {title}\n\n" + table(
            ["seed", "sensors", "pos RMSE (m)", "pos p95 (m)", "vel RMSE (m/s)",
             "in 3σ (e, n, u)", "NEES", "run (s)"],
            [[r.get("seed"), "all" if r.get("case") == "full" else "no MISTRAM, no theodolite",
              fmt(r.get("pos_rmse")), fmt(r.get("pos_p95")), fmt(r.get("vel_rmse")),
              ", ".join(fmt(v) for v in r.get("inside_3sigma_enu") or []),
              fmt(r.get("nees_pos_mean"), ".2f"), fmt(r.get("elapsed_s"), ".1f")]
             for r in group], "rlrrrrrr"))
    names = sorted({k[0] for k in groups})
    if len(names) > 1 and "ekf" in names:
        ekf = {(r["seed"], r["case"], r.get("sigma_factor", 1.0)): r["pos_rmse"]
               for r in rows if r.get("filter") == "ekf"}
        cols = sorted({(r["seed"], r["case"], r.get("sigma_factor", 1.0)) for r in rows},
                      key=lambda k: (k[2], k[0], order.get(k[1], 1)))

        def cell(name: str, key: tuple) -> str:
            r = next((r for r in rows if r.get("filter") == name and
                      (r["seed"], r["case"], r.get("sigma_factor", 1.0)) == key), None)
            if r is None:
                return DASH
            ratio = r["pos_rmse"] / ekf[key] if ekf.get(key) else None
            worst = min(r.get("inside_3sigma_enu") or [float("nan")])
            return f"{fmt(r['pos_rmse'])} ({fmt(ratio, '.2f')}×, {fmt(100 * worst, '.0f')} %)"
        heads = [f"seed {k[0]} {'all' if k[1] == 'full' else 'reduced'}"
                 + (f" σ×{k[2]:g}" if k[2] != 1.0 else "") for k in cols]
        out.append("## Every filter against the EKF\n\nPosition RMSE (m), its ratio to the "
                   "`ekf` row and the worst axis's share of epochs inside 3σ.\n\n"
                   + table(["filter", *heads], [[f"`{n}`", *(cell(n, k) for k in cols)]
                                                for n in names]))
    return "\n\n".join(out)


# ---------------------------------------------------------------------- registration
#: display unit of each calibration term: (unit, factor from SI)
TERM_UNITS = {"range": ("m", 1.0), "latency": ("ms", 1e3)}


def _term_unit(name: str) -> tuple[str, float]:
    return TERM_UNITS.get(name, ("mrad", 1e3))


def render_registration(data: Any) -> str:
    seeds = rows_of(data)
    out = ["Each seed simulates the flight with known sensor faults (the simulator's "
           "registration preset, `rangeproc simulate --faults registration`: radar range, "
           "azimuth and elevation biases, theodolite angle biases, a ship radar yawed on its "
           "deck with late time stamps) and without them, and runs both with the "
           "registration on and off. Every injected term's estimate is compared with the "
           "truth: the absolute error in the estimate's reported sigmas and as a share of the "
           "injected fault. Ranges in m, latencies in ms, angles in mrad."]
    worst: dict[tuple[str, str], dict[str, Any]] = {}
    for s in seeds:
        for t in s.get("terms", []):
            w = worst.setdefault((t["sensor"], t["name"]), {"true": t["true"], "sig": None,
                                                             "share": None, "n": 0, "na": 0})
            w["n"] += 1
            if t.get("estimate") is None:
                w["na"] += 1
                w["reason"] = t.get("reason")
                continue
            w["sig"] = max(w["sig"] or 0.0, t["in_sigmas"])
            w["share"] = max(w["share"] or 0.0, t["share"])
    out.append("## Per term, worst over the seeds\n\n" + table(
        ["sensor", "term", "injected", "worst error / σ", "worst error / injected",
         "seeds", "not observable"],
        [[sensor, name, f"{fmt(w['true'] * _term_unit(name)[1], '.4g')} {_term_unit(name)[0]}",
          fmt(w["sig"], ".2f"), fmt(None if w["share"] is None else 100 * w["share"], ".1f")
          + (" %" if w["share"] is not None else ""), w["n"],
          f"{w['na']} ({w.get('reason', '')})" if w["na"] else "0"]
         for (sensor, name), w in worst.items()], "llrrrrl"))
    out.append("## Per seed and term\n\n" + table(
        ["seed", "sensor", "term", "injected", "estimate", "σ", "error / σ",
         "error / injected"],
        [[s["seed"], t["sensor"], t["name"],
          f"{fmt(t['true'] * _term_unit(t['name'])[1], '.4g')} {_term_unit(t['name'])[0]}",
          (f"{fmt(t['estimate'] * _term_unit(t['name'])[1], '.4g')}"
           if t.get("estimate") is not None else f"not observable: {t.get('reason', '')}"),
          fmt(None if t.get("sigma") is None else t["sigma"] * _term_unit(t["name"])[1], ".2g"),
          fmt(t.get("in_sigmas"), ".2f"),
          (fmt(100 * t["share"], ".1f") + " %") if t.get("share") is not None else DASH]
         for s in seeds for t in s.get("terms", [])], "rllrrrrr"))

    def run(r: dict | None) -> str:
        if not r:
            return DASH
        return f"{fmt(r.get('rmse'))} / {fmt(r.get('in3'))} / {fmt(r.get('nees'), '.2f')}"

    def ratio(s: dict) -> str:
        a, b = s["runs"].get("faults_cal"), s["runs"].get("clean_nocal")
        return fmt(a["rmse"] / b["rmse"], ".2f") + "×" if a and b and b.get("rmse") else DASH
    out.append("## Fused trajectory\n\nPosition RMSE (m) / worst axis's share of epochs inside "
               "3σ / mean position NEES, for the four runs of each seed; the last column is "
               "the registered faulty run's RMSE over the fault-free run's without "
               "registration.\n\n" + table(
                   ["seed", "faults, registration on", "faults, off", "no faults, on",
                    "no faults, off", "faults on / no faults off"],
                   [[s["seed"], run(s["runs"].get("faults_cal")),
                     run(s["runs"].get("faults_nocal")), run(s["runs"].get("clean_cal")),
                     run(s["runs"].get("clean_nocal")), ratio(s)] for s in seeds]))
    return "\n\n".join(out)


# -------------------------------------------------------------------- several objects
RATIO_LIMIT, COVERAGE_LIMIT, PURITY_LIMIT = 1.25, 0.90, 0.95
#: The share of an object's epochs inside 3 sigma (least over east, north, up) the brief asks
#: of point objects and of the harbour kind's extended hulls (``bench/multi.py``).
HONEST_LIMIT, EXTENDED_HONEST_LIMIT = 0.95, 0.90


def _failing(r: dict, coverage: str = "coverage_scaled") -> bool:
    """Outside the acceptance (``bench/multi.py``), coverage read from ``coverage``; a
    moored object only when an output object follows it over half its span."""
    if r.get("role") == "moored":
        return (r.get("coverage") or 0.0) > 0.5
    return bool(r.get("swaps") or r.get("ratio") is None or r["ratio"] > RATIO_LIMIT
                or (r.get(coverage) or 0.0) < COVERAGE_LIMIT
                or (r.get("row_purity") is not None and r["row_purity"] < PURITY_LIMIT))


def render_multi(data: Any) -> str:
    rows = rows_of(data)
    errors = [r for r in rows if "error" in r]
    objs = [r for r in rows if "error" not in r]
    out = ["Each kind of the simulator's several-object scenarios (crossing aircraft, "
           "formations that split, a tracking radar's lock jumping to another object, an "
           "operator switching objects, surveillance radars with clutter, plot feeds in any "
           "order, a mix, and the benchmark's crowded scene of 10 and 20 objects, `scale-20`) "
           "is simulated over several seeds. rangeproc's output is scored "
           "against the truth with `rangeproc evaluate` (50 m cutoff), and each truth object "
           "is compared with the *true assignment*: rangeproc on the same scenario reduced to "
           "that object's own rows. Acceptance per object: no identity swap, RMSE within "
           f"{RATIO_LIMIT:g}× the true assignment's, coverage of the span the object was "
           f"observed at least {COVERAGE_LIMIT:.2f} at max(50 m, 3× the true assignment's "
           "RMSE) (*scaled cutoff*: an object only a surveillance radar sees is tracked to "
           "its plots' accuracy, not to 50 m), and its best-matching output object at least "
           f"{PURITY_LIMIT:.2f} pure in rows (the share of its radar and theodolite rows that "
           "are the object's, clutter counting against it; *extra objects*: output objects "
           "that are no truth object's best match). *Accepted at 50 m* counts the objects "
           "that would pass with the unscaled cutoff, for comparison; the true assignment's "
           "own scaled coverage tells a shortfall of the sensors and the smoother (it shares "
           "it) from one of the association (methods: Several objects, \"The benchmark's "
           "acceptance\"). Beside the acceptance, the honest-uncertainty standard: the share "
           "of each object's output epochs whose error lies inside 3 of its stated sigmas "
           f"(least over east, north, up), at least {HONEST_LIMIT:.2f} ("
           f"{EXTENDED_HONEST_LIMIT:.2f} for the harbour kind's extended hulls; moored "
           "objects not scored), with the true assignment's for comparison; one object's "
           "share over one run varies much, its errors being correlated over tens of seconds, "
           "so each kind's mean share is given too."]
    kinds: dict[str, list[dict]] = {}
    for r in objs:
        kinds.setdefault(r["kind"], []).append(r)
    for r in errors:
        kinds.setdefault(r["kind"], [])

    def summary(kind: str, group: list[dict]) -> list[Any]:
        scen = {(r["kind"], r["seed"]) for r in group} | {
            (r["kind"], r["seed"]) for r in errors if kind in ("all", r["kind"])}
        errs = sum(1 for r in errors if kind in ("all", r["kind"]))
        ratios = [r for r in group if r.get("ratio") is not None]
        worst = max(ratios, key=lambda r: r["ratio"], default=None)
        cov = [r for r in group if r.get("coverage_scaled") is not None]
        low = min(cov, key=lambda r: r["coverage_scaled"], default=None)
        gospa = {(r["kind"], r["seed"]): r["gospa_mean"] for r in group
                 if r.get("gospa_mean") is not None}
        extra = {(r["kind"], r["seed"]): r["extra_objects"] for r in group
                 if r.get("extra_objects") is not None}
        pure = [r for r in group if r.get("row_purity") is not None]
        hon = [r for r in group
               if r.get("inside_3sigma") is not None and r.get("role") != "moored"]
        honest = [r for r in hon if r["inside_3sigma"] >= (
            EXTENDED_HONEST_LIMIT if r["kind"] == "harbour" else HONEST_LIMIT)]
        return [kind, len(scen), errs, len(group), sum(int(r.get("swaps") or 0) for r in group),
                sum(1 for r in group if r.get("rmse") is None),
                f"{sum(1 for r in ratios if r['ratio'] <= RATIO_LIMIT)} of {len(group)}",
                (f"{fmt(worst['ratio'], '.2f')}× ({worst['kind']} {worst['seed']} "
                 f"{worst['object']})" if worst else DASH),
                f"{sum(1 for r in group if (r.get('coverage_observed') or 0) >= COVERAGE_LIMIT)}"
                f" of {len(group)}",
                f"{sum(1 for r in cov if r['coverage_scaled'] >= COVERAGE_LIMIT)} of {len(group)}",
                (f"{fmt(low['coverage_scaled'], '.3f')} ({low['kind']} {low['seed']} "
                 f"{low['object']})" if low else DASH),
                (f"{sum(1 for r in pure if r['row_purity'] >= PURITY_LIMIT)} of {len(pure)}"
                 if pure else DASH),
                sum(extra.values()) if extra else DASH,
                f"{sum(1 for r in group if not _failing(r, 'coverage_observed'))} of {len(group)}",
                f"{sum(1 for r in group if not _failing(r))} of {len(group)}",
                fmt(statistics.mean(gospa.values()) if gospa else None, ".1f"),
                (f"{len(honest)} of {len(hon)} (mean "
                 f"{statistics.mean(r['inside_3sigma'] for r in hon):.3f})" if hon else DASH)]
    heads = ["kind", "scenarios", "runs failed", "objects", "swaps", "unmatched",
             f"within {RATIO_LIMIT:g}×", "worst ratio", f"coverage ≥ {COVERAGE_LIMIT:.2f} at "
             "50 m", f"coverage ≥ {COVERAGE_LIMIT:.2f} scaled", "lowest coverage (scaled)",
             f"pure ≥ {PURITY_LIMIT:.2f} (rows)", "extra objects", "accepted at 50 m",
             "accepted (scaled)", "mean GOSPA (m)", "inside 3σ ≥ limit (mean share)"]
    body = [summary(k, g) for k, g in kinds.items()]
    body.append(["**all**", *summary("all", objs)[1:]])
    out.append("## Per kind\n\n" + table(heads, body, "lrrrrrrlrrlrrrrrl"))
    if errors:
        out.append("## Runs that failed\n\n" + table(
            ["kind", "seed", "error"], [[r["kind"], r["seed"], r["error"]] for r in errors],
            "lrl"))
    obj_heads = ["kind", "seed", "object", "match", "RMSE (m)", "true assignment (m)", "ratio",
                 "coverage", "coverage observed", "coverage scaled",
                 "true assignment's coverage scaled", "swaps", "fragments", "purity (rows)",
                 "inside 3σ", "true assignment inside 3σ"]

    def obj_row(r: dict) -> list[Any]:
        return [r["kind"], r["seed"], r["object"], r.get("match") or DASH,
                fmt(r.get("rmse"), ".2f"), fmt(r.get("oracle_rmse"), ".2f"),
                fmt(r.get("ratio"), ".2f"), fmt(r.get("coverage")), fmt(r.get("coverage_observed")),
                fmt(r.get("coverage_scaled")), fmt(r.get("oracle_coverage_scaled")),
                fmt(r.get("swaps"), "d"),
                fmt(r.get("fragments"), "d"), fmt(r.get("row_purity"), ".2f"),
                fmt(r.get("inside_3sigma")), fmt(r.get("oracle_inside_3sigma"))]
    failing = [r for r in objs if _failing(r)]
    out.append("## Objects outside the acceptance\n\n" + (
        table(obj_heads, [obj_row(r) for r in failing], "lrllrrrrrrrrrrrr") if failing
        else "None: every object is within the acceptance."))
    out.append("## Every object\n\n" + table(obj_heads, [obj_row(r) for r in objs],
                                             "lrllrrrrrrrrrrrr"))
    return "\n\n".join(out)


# ------------------------------------------------------------------------ harbour scenes
def render_harbour(data: Any) -> str:
    rows = rows_of(data)
    acc = data.get("acceptance") if isinstance(data, dict) else None
    gnn = any("gnn_match" in r for r in rows)
    out = ["The simulator's harbour kind (`rangeproc simulate --objects harbour`: a ferry's "
           "2.5 s scanning radar, 10 Hz lidar and cameras among a 12 m boat B1, a 30 m ship B2 "
           "that lies at a quay and then leaves, moored boats M1, M2 that never move, quay and "
           "sea clutter; hull returns from the sides facing each sensor, the GNSS antenna off "
           "the hull centre and declared nowhere, AR(1) camera bearing errors), scored by "
           "`bench/harbour.py` with `rangeproc evaluate` at a 20 m cutoff on a 5 Hz grid (an "
           "epoch without output counts as missed). Per moving object, over the span it moves "
           "in: coverage, its best match's RMSE against the antenna and against the hull "
           "centre (the difference is what the undeclared antenna costs), identity swaps, the "
           "share of epochs inside 3 sigma (east and north) and the mean position NEES. A "
           "moored object should stay a stationary return: *followed* is the share of its "
           "span an output object stays within 20 m of it." + (
               " Stone Soup's GNN (the real-data page's baseline) runs on the same plots."
               if gnn else "")]
    if acc:
        body = []
        for tracker, per_role in acc.items():
            for role, a in per_role.items():
                body.append([{"stonesoup_gnn": "Stone Soup GNN"}.get(tracker, tracker), role,
                             f"{a['accepted']} of {a['objects']}",
                             "; ".join(a["outside"]) or DASH])
        out.append("## Acceptance\n\nMoving objects: coverage of the moving span ≥ 0.90, "
                   "RMSE ≤ 8 m, no swaps, inside 3 sigma ≥ 0.90; moored objects: followed "
                   "≤ 0.5 of their span.\n\n"
                   + table(["tracker", "role", "accepted", "outside (seed object: misses)"],
                           body, "llrl"))
    heads = ["seed", "object", "role", "match", "coverage (moving)", "followed", "RMSE (m)",
             "RMSE to hull centre (m)", "antenna off centre (m)", "swaps", "inside 3σ",
             "NEES", "GOSPA (m)"]
    if gnn:
        heads += ["GNN coverage", "GNN RMSE (m)", "GNN swaps", "GNN inside 3σ"]

    def row(r: dict) -> list[Any]:
        if "error" in r:
            return [r["seed"], DASH, DASH, r["error"]] + [DASH] * (len(heads) - 4)
        got = [r["seed"], r["object"], r["role"], r.get("match") or DASH,
               fmt(r.get("coverage_moving")), fmt(r.get("followed"), ".2f"),
               fmt(r.get("rmse"), ".2f"), fmt(r.get("rmse_hull"), ".2f"),
               fmt(r.get("antenna_offset_m"), ".1f"), fmt(r.get("swaps"), "d"),
               fmt(r.get("inside_3sigma"), ".2f"), fmt(r.get("nees"), ".2f"),
               fmt(r.get("gospa_mean"), ".1f")]
        if gnn:
            got += [fmt(r.get("gnn_coverage_moving") if r.get("role") != "moored"
                        else r.get("gnn_followed")), fmt(r.get("gnn_rmse"), ".2f"),
                    fmt(r.get("gnn_swaps"), "d"), fmt(r.get("gnn_inside_3sigma"), ".2f")]
        return got
    out.append("## Every object\n\n" + table(heads, [row(r) for r in rows],
                                               "rlll" + "r" * (len(heads) - 4)))
    return "\n\n".join(out)


# ------------------------------------------------------------------------ real data
TRACKERS = (("rangeproc", "rangeproc"), ("rangeproc_no_cameras", "rangeproc, no cameras"),
            ("stonesoup", "Stone Soup GNN"), ("stonesoup_jpda", "Stone Soup JPDA"),
            ("stonesoup_rts", "Stone Soup GNN+RTS"), ("stonesoup_jpda_rts", "Stone Soup JPDA+RTS"))
#: The baselines of ``bench/autoferry.py``'s acceptance and their short names.
BASELINES = {"stonesoup": "GNN", "stonesoup_jpda": "JPDA", "stonesoup_rts": "GNN+RTS",
             "stonesoup_jpda_rts": "JPDA+RTS"}


def _score(r: dict, key: str) -> dict | None:
    """Scenario ``r``'s score of tracker ``key`` (None when it failed or did not finish):
    rangeproc with the cameras is the contract run, or the surface-plane run where that
    failed and was run (as ``bench/autoferry.py`` scores it)."""
    if key == "rangeproc":
        rc = r.get("rangeproc_contract") or {}
        if rc.get("ok"):
            return rc.get("score")
        rs = r.get("rangeproc_surface") or {}
        return rs.get("score") if rs.get("ok") else None
    run = r.get(key) or {}
    return run.get("score") if run.get("finished", True) else None


def _autoferry_trackers(results: list) -> list[tuple[str, str]]:
    """The trackers a results file has (one from before the smoothed baselines lacks them)."""
    return [(key, label) for key, label in TRACKERS
            if key == "rangeproc" or any(key in r for r in results)]


def render_autoferry(data: Any) -> str:
    results = data.get("results", []) if isinstance(data, dict) else []
    cutoff = data.get("cutoff_m", 20.0) if isinstance(data, dict) else 20.0
    trackers = _autoferry_trackers(results)
    smoothed = any(k.endswith("_rts") for k, _ in trackers)
    out = ["Real radar and lidar plots and camera bearings from the Autoferry data set "
           "([the conversion](../methods/real-data.md)), run through rangeproc (with and "
           "without the camera bearings) and through Stone Soup's GNN and JPDA trackers on the "
           "same plots" + (", each also with Stone Soup's RTS smoother run over every track "
                           "(GNN+RTS, JPDA+RTS)" if smoothed else "")
           + ", all scored by `rangeproc evaluate` against the boats' GNSS truth with "
           f"a {cutoff:g} m cutoff. RMSE: the boat's best-matching object's RMSE (m); cov: "
           "coverage; sw: identity swaps; GOSPA: mean over the scenario (m; p = 2, α = 2, "
           f"c = {cutoff:g} m). rangeproc's estimates are smoothed; Stone Soup's GNN and JPDA "
           "filtered" + (", their +RTS runs smoothed." if smoothed else ".")]
    heads = ["scenario", "boat"]
    for _, label in trackers:
        heads += [f"{label} RMSE", "cov", "sw", "GOSPA"]
    body = []
    for r in results:
        for k, boat in enumerate(("B1", "B2")):
            row: list[Any] = [r.get("scenario") if k == 0 else "", boat]
            for key, _ in trackers:
                sc = _score(r, key)
                if sc is None:
                    run = r.get(key) or {}
                    why = "timed out" if run.get("timed_out") else "failed"
                    row += [why if k == 0 else "", "", "", ""]
                    continue
                m = (sc.get("boats") or {}).get(boat, {})
                row += [fmt(m.get("best_match_rmse"), ".1f"), fmt(m.get("coverage"), ".2f"),
                        fmt(m.get("swaps"), "d"), fmt(sc.get("gospa_mean"), ".1f") if k == 0
                        else ""]
            body.append(row)
    out.append("## Per scenario and boat\n\n" + table(heads, body))
    acc = data.get("acceptance") if isinstance(data, dict) else None
    if acc:
        out += _autoferry_acceptance(acc)
    return "\n\n".join(out)


def _autoferry_acceptance(acc: dict) -> list[str]:
    """The acceptance sections of the real-data page: the per-scenario comparison, issue 41's
    acceptance lines (results files with "checks"), the per-tracker summary."""
    out = []
    per = acc.get("per_scenario", [])
    new = "checks" in acc
    keys = list(BASELINES) if new else ["stonesoup", "stonesoup_jpda"]
    names = " / ".join(BASELINES[k] for k in keys)

    def versus(row: dict, key: str, spec: str, crit: str) -> str:
        v = (row.get("values") or {}).get(key)
        if not v:
            return DASH
        others = " / ".join(fmt(v.get(k), spec) for k in keys)
        return f"{fmt(v.get('rangeproc'), spec)} vs {others} ({fmt(row.get(crit))})"
    both = "gospa_and_rmse" if new else "all"
    out.append(f"## Against every baseline\n\nPer scenario, rangeproc (with the cameras) "
               f"against Stone Soup {names}: better (strictly) on mean GOSPA, on coverage "
               "(mean over the two boats) and on best-match RMSE (mean over the two boats, a "
               "boat without a match counting as infinite). A baseline that did not finish is "
               "left out of its scenario's comparison.\n\n" + table(
                   ["scenario", "GOSPA (m)", "coverage", "best-match RMSE (m)",
                    "GOSPA and RMSE" if new else "all three"],
                   [[row.get("scenario"), versus(row, "gospa_mean", ".1f", "gospa"),
                     versus(row, "coverage_mean", ".2f", "coverage"),
                     versus(row, "best_match_rmse_mean", ".1f", "rmse"),
                     fmt(row.get(both)) + (f" ({row['note']})" if row.get("note") else "")]
                    for row in per], "rrrrl")
               + ("" if new else f"\n\nAll three hold in {acc.get('n_all_three')} of "
                                 f"{acc.get('n_scenarios')} scenarios."))
    if new:
        out.append("## Acceptance\n\nIssue 41's acceptance on these gap-counting scores, "
                   "rangeproc (with the cameras) against every baseline, the smoothed ones "
                   "included. Coverage per boat-scenario is compared with the best baseline's "
                   "in that scenario; GOSPA RMS is the square root of the mean squared GOSPA "
                   "over every epoch of the environment's scenarios.\n\n" + table(
                       ["acceptance line", "measured", "target", "met"],
                       [[c.get("name"), c.get("measured"), c.get("target"), fmt(c.get("ok"))]
                        for c in acc["checks"]], "lrrl"))
        boats = acc.get("per_boat") or []
        if boats:
            out.append("### Coverage per boat-scenario\n\n" + table(
                ["scenario", "boat", "rangeproc", "best baseline", "which", "within 0.02"],
                [[b.get("scenario"), b.get("boat"), fmt(b.get("rangeproc"), ".2f"),
                  fmt(b.get("best_baseline"), ".2f"),
                  BASELINES.get(b.get("best_baseline_key"), DASH), fmt(b.get("ok"))]
                 for b in boats], "rlrrll"))
    summary = acc.get("per_tracker", {})
    envs = sorted({e for s in summary.values() for e in (s.get("gospa_rms") or {})},
                  key=lambda e: int(e.split("-")[0]))
    rows = [[s.get("label", key), s.get("n_scenarios"), fmt(s.get("gospa_mean"), ".2f")]
            + [fmt((s.get("gospa_rms") or {}).get(e), ".1f") for e in envs]
            + [fmt(s.get("coverage_mean")), fmt(s.get("best_match_rmse_median"), ".2f"),
               s.get("n_rmse_above_30m"), s.get("swaps_total")]
            for key, s in summary.items()]
    published = acc.get("published_gospa_rms_m") or {}
    if envs and published:
        rows.append(["published: online VIMM-JIPDA", DASH, DASH]
                    + [fmt(published.get(e), ".1f") for e in envs] + [DASH] * 4)
    text = ("## Per tracker over the scenarios\n\nMean of the scenarios' mean GOSPA; "
            + ("GOSPA RMS over time pooled per environment (scenarios "
               + " and ".join(envs) + "); " if envs else "")
            + "coverage mean and median best-match RMSE over the boat-scenarios; "
            "boat-scenarios whose best-match RMSE is above 30 m (or without a match); "
            "total identity swaps.\n\n" + table(
                ["tracker", "scenarios", "GOSPA (m)"] + [f"GOSPA RMS {e} (m)" for e in envs]
                + ["coverage", "RMSE median (m)", "RMSE > 30 m", "swaps"], rows))
    if envs and published:
        text += ("\n\nThe published row, for reference: " + str(acc.get("published", ""))
                 + ", GOSPA RMS over time per environment as published there (their own "
                 "GOSPA parameters and scoring, an online tracker).")
    out.append(text)
    return out


# ---------------------------------------------------------------------------- speed
def render_speed(data: Any) -> str:
    data = data if isinstance(data, dict) else {}
    params = data.get("params") or {}
    out = ["`make bench` (`bench/bench.py`) times, in one process, the same EKF + RTS smoother "
           "(and UKF + smoother) on identical radar rows in rangeproc, FilterPy and Stone Soup, "
           "with the agreement of their results; then a whole `rangeproc run` on a simulated "
           "six-sensor sortie in a fresh process, per stage and with its peak memory; then the "
           "several-objects `scale` scenario the same way."]
    if params.get("quick"):
        out.append("!!! note \"A CI-sized run\"\n    These figures come from `bench/bench.py "
                   "--quick`: fewer kernel rows and repetitions, a "
                   f"{fmt(params.get('duration_s'), 'g')} s sortie and a "
                   f"{fmt(params.get('multi_duration_s'), 'g')} s several-objects scenario "
                   "instead of the full one-hour sortie of about two million rows and the "
                   "30-minute scenario. `make bench` measures the full sizes.")
    k = data.get("kernel")
    if k:
        us, ag = k["us_per_meas"], k.get("agreement", {})

        def agree(name: str, src: dict) -> str:
            a = src.get(name)
            return fmt(a.get("smoothed_pos_rel"), ".1e") if a else DASH
        rows = [["rangeproc (compiled)", k["rows"], fmt(us["rangeproc"], ".2f"), "1.0×", DASH],
                ["FilterPy `ExtendedKalmanFilter` + `rts_smoother`", k["rows"],
                 fmt(us["filterpy"], ".1f"), fmt(k.get("ratio_filterpy"), ".1f") + "×",
                 agree("filterpy", ag)],
                ["Stone Soup EKF + smoother, analytic Jacobian", k.get("stonesoup_rows"),
                 fmt(us["stonesoup"], ".0f"), fmt(k.get("ratio_stonesoup"), ".0f") + "×",
                 agree("stonesoup", ag)],
                ["Stone Soup, stock finite-difference Jacobian", k.get("stonesoup_rows"),
                 fmt(us.get("stonesoup_stock"), ".0f"),
                 fmt(k.get("ratio_stonesoup_stock"), ".0f") + "×", agree("stonesoup_stock", ag)]]
        heads = ["implementation", "rows", "µs per measurement", "× rangeproc",
                 "agreement (smoothed position, relative)"]
        out.append("## Filter kernels\n\n### EKF + RTS smoother\n\nOne radar (range, azimuth, "
                   f"elevation) at dt = {fmt(k.get('dt_s'), 'g')} s, filter and smoother, per "
                   "measurement row.\n\n" + table(heads, rows))
        u = k.get("ukf")
        if u:
            uu, ua = u["us_per_meas"], u.get("agreement", {})
            out.append("### UKF + unscented (RTS) smoother\n\n" + table(heads, [
                ["rangeproc (compiled)", u["rows"], fmt(uu["rangeproc"], ".2f"), "1.0×", DASH],
                ["FilterPy `UnscentedKalmanFilter` + `rts_smoother`", u["rows"],
                 fmt(uu["filterpy"], ".1f"), fmt(u.get("ratio_filterpy"), ".1f") + "×",
                 agree("filterpy_redraw", ua)],
                ["Stone Soup unscented filter + smoother", u.get("stonesoup_rows"),
                 fmt(uu["stonesoup"], ".0f"), fmt(u.get("ratio_stonesoup"), ".0f") + "×",
                 agree("stonesoup", ua)]]))
        f = k.get("filters")
        if f:
            base = {"stukf": "UKF"}
            out.append("### The further filters\n\nNo peer library offers these; the same radar "
                       "rows, filter + smoother (the spline row without its batch fit).\n\n"
                       + table(["filter", "µs per measurement", "ratio to its base row",
                                "ratio to the EKF row"],
                               [[f"`{n}`", fmt(r["us_per_meas"], ".2f"),
                                 f"{fmt(r['ratio_to_base'], '.2f')}× the "
                                 f"{base.get(n, 'EKF')}", fmt(r["ratio_to_ekf"], ".2f") + "×"]
                                for n, r in f.items()], "lrrr"))
        if k.get("rangeproc_cold_first_call_s") is not None:
            out.append(f"Compilation: the first kernel call in a fresh process with an empty "
                       f"numba cache takes {fmt(k['rangeproc_cold_first_call_s'], '.1f')} s; "
                       f"the bench process's first call (with the numba cache as it found it: "
                       f"compiled kernels are reused until their sources change) "
                       f"{fmt(k.get('rangeproc_first_call_s'), '.2f')} s.")
    for key, title in (("pipeline", "Whole pipeline: one object"),
                       ("multi", "Whole pipeline: several objects at scale")):
        p = data.get(key)
        if not p:
            continue
        gb = (p.get("peak_rss_bytes") or 0) / 1e9
        what = (f"`{p.get('kind')}` scenario, " if key == "multi" else "six-sensor sortie, ")
        lines = [[stage, fmt(s, ".2f")] for stage, s in (p.get("stages_s") or {}).items()]
        lines += [["**`rangeproc run`, process start to exit**",
                   f"**{fmt(p.get('process_wall_s'), '.1f')}**"]]
        text = (f"## {title}\n\nA {fmt(p.get('duration_s'), 'g')} s {what}"
                f"{p.get('total_rows', 0):,} rows; peak memory (VmHWM) {gb:.2f} GB; "
                f"{fmt(p.get('us_per_meas_wall'), '.1f')} µs per row (process wall clock), "
                f"{fmt(p.get('us_per_meas_run'), '.1f')} µs per row in `run()`.")
        if key == "multi":
            ratio = p.get("ratio_wall_target", p.get("ratio_wall"))
            if ratio is not None:
                text += (f" Per measurement row of the objects that is "
                         f"{fmt(ratio, '.2f')}× the single-object sortie's cost per "
                         "measurement row")
                text += (f" ({fmt(p['ratio_wall'], '.2f')}× per row of any kind)."
                         if p.get("ratio_wall") is not None else ".")
            sc = (p.get("score") or {})
            tot, g = sc.get("totals") or {}, (sc.get("gospa") or {}).get("mean")
            if tot:
                text += (f" Score against the truth: {tot.get('n_truth')} objects, "
                         f"{tot.get('n_fused')} output objects, mean GOSPA {fmt(g, '.1f')} m, "
                         f"coverage mean {fmt(tot.get('coverage_mean'), '.3f')}, "
                         f"{tot.get('swaps')} identity swaps.")
        out.append(text + "\n\n" + table(["stage", "seconds"], lines))
    if not (k or data.get("pipeline") or data.get("multi")):
        out.append("The file holds no timing section.")
    return "\n\n".join(out)


def render_calibration_mc(data: Any) -> str:
    sets = data.get("sets", []) if isinstance(data, dict) else []
    out = ["Seeded Monte Carlo of the fused trajectory's sigma once calibration terms are "
           "estimated: each run draws the sensors' systematic errors (radar range 10 m, "
           "azimuth and elevation 0.5 mrad, theodolite angles 20\", ship radar mount yaw "
           "0.3 deg and latency 40 ms, 1-sigma) and runs the default config. Two sets: the "
           "simulator's drawn flights, and a real aircraft's track (an A310 zero-gravity "
           "flight recorded by ADS-B: pull-ups, zero-g arcs, a turn) flown past the same "
           "simulated sensors (`rangeproc simulate --trajectory`). A run's epochs are "
           "correlated in time, so the NEES bounds count each run as one sample "
           "(chi-square with 3 M degrees of freedom over M runs). Honest: mean NEES inside "
           "its bounds and every run with at least 95 % of its epochs inside 3 sigma."]
    out.append("## Per set\n\n" + table(
        ["set", "runs", "mean NEES", "95 % bounds", "epochs in 3σ: mean", "worst run",
         "runs ≥ 95 %", "mean RMSE m", "terms: mean (error/σ)²"],
        [[st["name"] + (f" ({st['trajectory']})" if st.get("trajectory") else ""),
          st["summary"]["runs"], fmt(st["summary"]["nees_mean"], ".2f"),
          "–".join(fmt(b, ".2f") for b in st["summary"]["nees_95"]),
          fmt(st["summary"]["in3_mean"]), fmt(st["summary"]["in3_min"]),
          st["summary"].get("runs_in3_95"), fmt(st["summary"]["rmse_mean"]),
          fmt(st["summary"].get("term_z2_mean"), ".2f")] for st in sets], "lrrrrrrrr"))
    for st in sets:
        out.append(f"## {st['name'].capitalize()}: per run\n\n" + table(
            ["seed", "position RMSE m", "epochs in 3σ (worst axis)", "NEES",
             "terms: mean (error/σ)²"],
            [[r["seed"], fmt(r["rmse"]), fmt(r["in3"]), fmt(r["nees"], ".2f"),
              fmt(statistics.fmean(z * z for z in r["term_z"]) if r.get("term_z") else None,
                  ".2f")] for r in st.get("rows", [])]))
    if not sets:
        out.append("The file holds no sets.")
    return "\n\n".join(out)


def render_plan_check(data: Any) -> str:
    out = ["For each seed the simulator writes a flight, without sensor biases and with biases "
           "drawn as on the calibration page; `rangeproc plan` predicts its sigma from the "
           "config and the truth trajectory alone, then `rangeproc run` processes the flight. "
           "Per axis over the seeds: RMS of the achieved RMSE over RMS of the predicted sigma "
           "(1: the plan predicts the achieved error; one flight's RMSE is one draw of its "
           "calibration errors, so only the ratio over seeds means much), and the median of "
           "predicted over the run's own stated sigma. The plan gives two sigmas: with the "
           "calibration terms' uncertainty (sensors whose systematic errors are unknown, the "
           "prediction for flights with biases) and with every term known (`_calibrated`, "
           "the prediction for flights without). Without biases a run's stated sigma is "
           "conservative (it holds the calibration terms' uncertainty, and the truth has "
           "none)."]
    for name, title in (("biases", "With drawn sensor biases"), ("clean", "Without biases")):
        block = data.get(name) if isinstance(data, dict) else None
        if not block:
            continue
        summary = block.get("summary", {})
        out.append(f"## {title}\n\n" + table(
            ["axis", "RMS RMSE / RMS predicted σ", "RMS RMSE / RMS predicted σ, calibrated",
             "median predicted / stated σ"],
            [[ax.upper(), fmt(summary.get(ax, {}).get("rmse_over_predicted"), ".2f"),
              fmt(summary.get(ax, {}).get("rmse_over_calibrated"), ".2f"),
              fmt(summary.get(ax, {}).get("predicted_over_stated_median"), ".2f")]
             for ax in "enu"]) + "\n\n" + table(
            ["seed", *[f"{ax.upper()}: RMSE / predicted (calibrated) / stated (m)"
                       for ax in "enu"]],
            [[r["seed"], *[f"{fmt(r[ax]['rmse'])} / {fmt(r[ax]['predicted'])} "
                           f"({fmt(r[ax].get('predicted_calibrated'))}) / "
                           f"{fmt(r[ax]['stated'])}" for ax in "enu"]]
             for r in block.get("rows", [])]))
    return "\n\n".join(out)


def render_range_rate(data: Any) -> str:
    rows = rows_of(data)
    burst = data.get("burst_s") if isinstance(data, dict) else None
    draws = data.get("draws", 1) if isinstance(data, dict) else 1
    out = ["Each seed's flight seen by its MISTRAM stations alone, started from a given state "
           "(the truth perturbed by 10 m and 5 m/s), with the simulator's wild points"
           + (f" and a noise burst (every station x10 for {burst:g} s)" if burst else "")
           + (f", measured {draws} times (the simulator's own files, then the same flight "
              "with other draws of the sensors' sampling and noise, the initial state's "
              "perturbation and the burst)" if draws > 1 else "")
           + ". The bound: the best of three smoothers told the truth (the wild rows removed, "
           "the true noise stated, the burst's rows as a second sensor of ten times the sigma, "
           "no noise adaptation): `told_auto` (the EKF's passes, then the batch spline fit), "
           "`told_ekf` (the EKF smoother alone) and `told_spline` (the spline filter and its "
           "fit). `default` is the config without a `[processing]` section (`filter = "
           "\"auto\"`: the EKF's passes, then the batch spline fit); `ekf` forces the EKF "
           "smoother alone. Position RMSE in m"
           + (" (the RMS over the draws)" if draws > 1 else "")
           + ", its ratio to the bound, and the share of epochs inside 3 sigma (worst axis"
           + ("; the worst draw and the mean of the draws" if draws > 1 else "")
           + "). Where the position sigma is metres while one draw's error is a fraction of "
           "it (range rates fix the position weakly) two sound estimators differ by that much "
           "on one draw: the draws' RMS compares their expected error."]
    names = ("default", "ekf", "told_auto", "told_ekf", "told_spline")
    out.append(table(
        ["seed", "bound m", *[f"{n}: RMSE (× bound) / in 3σ" for n in names]],
        [[r["seed"], fmt(r["bound_pos_rmse"], ".2f"),
          *[f"{fmt(r['runs'][n]['pos_rmse'], '.2f')} ({fmt(r['runs'][n]['over_bound'], '.2f')}"
            f"×) / {fmt(r['runs'][n]['in3'])}"
            + (f" ({fmt(r['runs'][n]['in3_mean'])})" if "in3_mean" in r["runs"][n] else "")
            for n in names]] for r in rows]))
    return "\n\n".join(out)


# ----------------------------------------------------------------------------- pages
#: page -> (title, measurement file, make target, renderer)
PAGES: dict[str, tuple[str, str, str, Callable[[Any], str]]] = {
    "validation/accuracy.md": ("Accuracy on simulated flights", "accuracy.json", "accuracy",
                               render_accuracy),
    "validation/registration.md": ("Registration of sensor faults", "registration.json",
                                   "registration", render_registration),
    "validation/calibration-uncertainty.md": ("Uncertainty with estimated calibration",
                                              "calibration_mc.json", "calibration-mc",
                                              render_calibration_mc),
    "validation/planning.md": ("Planning: predicted against achieved", "plan_check.json",
                               "plan-check", render_plan_check),
    "validation/range-rate.md": ("Range rates alone", "range_rate.json", "range-rate",
                                 render_range_rate),
    "validation/several-objects.md": ("Several objects", "multi.json", "multi", render_multi),
    "validation/harbour.md": ("Harbour scenes", "harbour.json", "harbour", render_harbour),
    "validation/real-data.md": ("Real data: Autoferry", "autoferry.json", "autoferry",
                                render_autoferry),
    "validation/speed.md": ("Speed and memory", "bench.json", "bench", render_speed),
}


def render_page(uri: str, measurements: Path = MEASUREMENTS) -> str:
    """One page's Markdown from its measurement file."""
    title, file, target, render = PAGES[uri]
    data, problem = load(measurements / file)
    if data is None:
        return not_measured(title, file, target, problem)
    return (f"# {title}\n\n{GENERATED_NOTE.format(file=file)}\n\n"
            f"{measured_on(data, file, target)}\n\n{render(data)}\n")


def render_index(measurements: Path = MEASUREMENTS) -> str:
    """The overview: each page with the machine and date of its measurements."""
    rows = []
    for uri, (title, file, target, _) in PAGES.items():
        data, problem = load(measurements / file)
        meta = meta_of(data) if data is not None else None
        if data is None:
            when = "unreadable" if problem else "not measured yet"
            where = DASH
        elif meta is None:
            when, where = "unknown", "unknown"
        else:
            when = (meta.get("date") or "unknown").replace("T", " ")
            m = meta.get("machine") or {}
            where = ", ".join(str(p) for p in (m.get("cpu"), f"{m['cores']} cores"
                                               if m.get("cores") else None) if p) or "unknown"
        rows.append([f"[{title}]({Path(uri).name})", f"`make {target}`",
                     f"`docs/measurements/{file}`", when, where])
    return ("# Validation and performance\n\n" + GENERATED_NOTE.format(file="*.json") + "\n\n"
            "Every number on these pages is read from a measurement file that a `make` target "
            "writes, when the documentation is built (`docs/hooks/validation.py`); none is "
            "copied by hand. Each page states the machine, date, commit and command of its "
            "measurement. The methods measured are described in [Methods]"
            "(../methods/index.md).\n\n"
            + table(["page", "made by", "file", "measured (UTC)", "machine"], rows, "lllll")
            + "\n")


def render_all(measurements: Path = MEASUREMENTS) -> dict[str, str]:
    """Every generated page: ``{uri: markdown}``."""
    pages = {"validation/index.md": render_index(measurements)}
    pages.update({uri: render_page(uri, measurements) for uri in PAGES})
    return pages


# ----------------------------------------------------------------------- MkDocs hook
def on_files(files: Any, config: Any, **_: Any) -> Any:
    """MkDocs ``on_files``: add the generated validation pages (replacing any file of the
    same path) and leave the hook sources out of the site."""
    from mkdocs.structure.files import File   # MkDocs >= 1.6 (the docs extra)
    docs_dir = Path(config["docs_dir"])
    for f in list(files):
        uri = getattr(f, "src_uri", f.src_path).replace("\\", "/")
        if uri.startswith("hooks/"):
            files.remove(f)
    for uri, text in render_all(docs_dir / "measurements").items():
        old = files.get_file_from_path(uri)
        if old is not None:
            files.remove(old)
        files.append(File.generated(config, uri, content=text))
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--measurements", type=Path, default=MEASUREMENTS)
    ap.add_argument("--out", type=Path, help="write the pages under this folder "
                                             "(default: print them)")
    a = ap.parse_args(argv)
    for uri, text in render_all(a.measurements).items():
        if a.out:
            path = a.out / uri
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f"wrote {path}")
        else:
            print(f"===== {uri}\n{text}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
