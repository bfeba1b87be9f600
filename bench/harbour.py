"""The harbour kind, scored as the several-objects issues accept it (issues 41 and 42).

For each seed: ``rangeproc simulate --objects harbour`` (a ferry's 2.5 s scanning radar, 10 Hz
lidar and cameras among a 12 m boat ``B1``, a 30 m ship ``B2`` that lies at a quay and then
leaves, moored boats ``M1``/``M2`` that never move, quay and sea clutter;
:mod:`rangeproc.simulate.harbour`), rangeproc's run, and ``rangeproc evaluate`` against the
truth (the boats' GNSS antennas) with the assignment cutoff :data:`CUTOFF_M` (20 m, as
``bench/autoferry.py`` scores the recordings this kind is built like). The truth's
``truth_events.json`` gives each object's role and the span it moves in.

Per moving object (a boat or the ship), over the span it moves in:

* ``coverage_moving``: the share of the 5 Hz epochs of that span at which an output object is
  assigned to it within the cutoff (an epoch with no output counts as missed);
* ``rmse``: its best-matching output object's RMSE against the antenna, and ``rmse_hull``
  against the hull's centre (the same output object): the antenna lies up to 0.4 of the
  length off the centre and is declared nowhere, so ``rmse - rmse_hull`` is what an
  undeclared antenna costs (``antenna_offset_m``: its distance from the centre);
* ``swaps`` and ``fragments``; ``inside_3sigma`` (east and north mean: the share of the best
  match's epochs whose error lies inside 3 sigma) and ``nees`` (mean position NEES).

A moored object is no object to follow (issue 41: quays and moored boats that never move stay
stationary returns): ``followed`` is the share of its span at which an output object is within
the cutoff of it, and it is accepted when that is at most :data:`FOLLOWED_LIMIT`.

Acceptance per moving object: coverage of its moving span >= :data:`COVERAGE_LIMIT`, best
match within :data:`RMSE_LIMIT_M`, no swaps (issue 41), inside 3 sigma >= :data:`INSIDE_LIMIT`
(issue 42). With ``--gnn``, Stone Soup's GNN (``bench/autoferry.py``'s baseline, on the same
radar and lidar plots) is scored the same way beside it (``gnn_*``; about a minute a seed).

    python bench/harbour.py [--seeds 1 2 ... 10] [--gnn] [--out bench/harbour.json]
    python bench/harbour.py --summarise docs/measurements/harbour.json

The JSON is ``{"meta": ..., "rows": [...], "acceptance": ...}`` (``bench/meta.py``);
``make harbour`` writes it to docs/measurements/harbour.json.
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import pandas as pd

# bench/ is on sys.path: scripts, not a package
from meta import add_result_arguments, summarised, with_meta

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_multi

#: assignment cutoff (m): a boat's returns spread over its hull, as on the recordings
CUTOFF_M = 20.0
#: the acceptance: coverage of the moving span, best-match RMSE (m), share inside 3 sigma
COVERAGE_LIMIT, RMSE_LIMIT_M, INSIDE_LIMIT = 0.90, 8.0, 0.90
#: a moored object is followed (made an object of) above this share of its span
FOLLOWED_LIMIT = 0.5
SEEDS = list(range(1, 11))


def hull_truth(scen: Path) -> Path:
    """``truth.csv`` with each object's hull centre (``hull_e``, ``hull_n``) as its position,
    written beside it as ``truth_hull.csv``."""
    truth = pd.read_csv(scen / "truth.csv")
    truth["e"], truth["n"] = truth["hull_e"], truth["hull_n"]
    path = scen / "truth_hull.csv"
    truth.to_csv(path, index=False)
    return path


def _mean2(x: list[float | None] | None) -> float | None:
    return (x[0] + x[1]) / 2 if x and x[0] is not None and x[1] is not None else None


def score(out: Path, scen: Path, events: dict[str, Any], prefix: str = "") -> dict[str, dict]:
    """Per truth object the figures of the module docstring for the output in ``out``, keys
    prefixed with ``prefix`` (``"gnn_"`` for the baseline)."""
    objects = events["objects"]
    moving = {k: tuple(v["moving"]) for k, v in objects.items() if v.get("moving")}
    res = evaluate_run(out, scen / "truth.csv", cutoff=CUTOFF_M, observed=moving)
    hull = evaluate_run(out, hull_truth(scen), cutoff=CUTOFF_M, observed=moving)["multi"]
    scores: dict[str, dict] = {}
    for obj, m in res["multi"]["truth"].items():
        t = res["targets"].get(obj, {})
        hm = hull["truth"].get(obj, {})
        scores[obj] = {
            f"{prefix}match": m.get("best_match"),
            f"{prefix}coverage_moving": m.get("coverage_observed") if obj in moving else None,
            f"{prefix}followed": None if obj in moving else m.get("coverage"),
            f"{prefix}rmse": m.get("best_match_rmse"),
            f"{prefix}rmse_hull": (hm.get("best_match_rmse")
                                   if hm.get("best_match") == m.get("best_match") else None),
            f"{prefix}swaps": m.get("swaps"), f"{prefix}fragments": m.get("fragmentation"),
            f"{prefix}inside_3sigma": _mean2(t.get("inside_3sigma_enu")),
            f"{prefix}nees": t.get("nees_pos_mean"),
            f"{prefix}gospa_mean": res["multi"]["gospa"]["mean"],
            f"{prefix}n_objects": res["multi"]["totals"]["n_fused"]}
    return scores


def seed_rows(seed: int, work: Path, gnn: bool) -> list[dict]:
    """Simulate, run and score seed ``seed`` under ``work``: one row per truth object."""
    scen = work / f"harbour_{seed}"
    config = simulate_multi(scen, kind="harbour", seed=seed)
    events = json.loads((scen / "truth_events.json").read_text())
    t0 = time.perf_counter()
    try:
        run(config)
    except Exception as exc:                              # recorded, the sweep goes on
        return [{"seed": seed, "error": f"{type(exc).__name__}: {exc}"}]
    elapsed = time.perf_counter() - t0
    scores = score(scen / "out", scen, events)
    if gnn:
        from autoferry import run_stonesoup
        run_stonesoup(scen, work / f"gnn_{seed}")
        for obj, s in score(work / f"gnn_{seed}", scen, events, "gnn_").items():
            scores[obj].update(s)
    rows = []
    for obj, s in scores.items():
        o = events["objects"][obj]
        lever = o.get("antenna_lever_arm_m") or [0.0, 0.0]
        rows.append({"seed": seed, "object": obj, "role": o.get("role"),
                     "length_m": o.get("length_m"),
                     "antenna_offset_m": round(math.hypot(*lever), 2), **s,
                     "run_s": round(elapsed, 2)})
    return rows


def misses(r: dict, prefix: str = "") -> list[str]:
    """The criteria row ``r`` misses (empty: accepted)."""
    if "error" in r:
        return ["run failed"]
    if r["role"] == "moored":
        return (["followed"] if (r.get(f"{prefix}followed") or 0.0) > FOLLOWED_LIMIT
                else [])
    out = []
    if (r.get(f"{prefix}coverage_moving") or 0.0) < COVERAGE_LIMIT:
        out.append("coverage")
    rmse = r.get(f"{prefix}rmse")
    if rmse is None or rmse > RMSE_LIMIT_M:
        out.append("rmse")
    if r.get(f"{prefix}swaps"):
        out.append("swaps")
    inside = r.get(f"{prefix}inside_3sigma")
    if inside is None or inside < INSIDE_LIMIT:
        out.append("3 sigma")
    return out


def acceptance(rows: list[dict], prefix: str = "") -> dict[str, dict]:
    """Per role: objects, accepted, each criterion's passes, the objects outside and why."""
    out: dict[str, dict] = {}
    for r in rows:
        role = r.get("role", "run")
        a = out.setdefault(role, {"objects": 0, "accepted": 0, "outside": []})
        a["objects"] += 1
        miss = misses(r, prefix)
        a["accepted"] += not miss
        if miss:
            a["outside"].append(f"{r['seed']} {r.get('object', '')}: {', '.join(miss)}")
    return out


def _f(v: Any, fmt: str) -> str:
    width = int(fmt.split(".")[0].rstrip("dfg") or 0)
    return format(v, fmt) if isinstance(v, (int, float)) else "-".rjust(width)


def print_tables(rows: list[dict]) -> None:
    """The per-object table and the acceptance per role (stdout: a bench script's report)."""
    gnn = any("gnn_match" in r for r in rows)
    print(f"\n{'seed':>4} {'obj':<4}{'role':<7}{'match':<6}{'cov.mv':>7}{'foll':>6}"
          f"{'RMSE':>7}{'hull':>7}{'ant':>6}{'swaps':>6}{'in3s':>6}{'NEES':>7}{'GOSPA':>7}"
          + (f"{'GNN cov':>8}{'RMSE':>7}{'swaps':>6}{'in3s':>6}" if gnn else ""))
    for r in rows:
        if "error" in r:
            print(f"{r['seed']:>4} error: {r['error']}")
            continue
        print(f"{r['seed']:>4} {r['object']:<4}{r['role']:<7}{str(r['match']):<6}"
              f"{_f(r['coverage_moving'], '7.3f')}{_f(r['followed'], '6.2f')}"
              f"{_f(r['rmse'], '7.2f')}{_f(r['rmse_hull'], '7.2f')}"
              f"{_f(r['antenna_offset_m'], '6.1f')}{_f(r['swaps'], '6d')}"
              f"{_f(r['inside_3sigma'], '6.2f')}{_f(r['nees'], '7.2f')}"
              f"{_f(r['gospa_mean'], '7.2f')}"
              + (f"{_f(r.get('gnn_coverage_moving'), '8.3f')}{_f(r.get('gnn_rmse'), '7.2f')}"
                 f"{_f(r.get('gnn_swaps'), '6d')}{_f(r.get('gnn_inside_3sigma'), '6.2f')}"
                 if gnn else ""))
    print(f"\nAcceptance (moving objects: coverage of the moving span >= {COVERAGE_LIMIT:g} at "
          f"{CUTOFF_M:g} m, RMSE <= {RMSE_LIMIT_M:g} m, no swaps, inside 3 sigma >= "
          f"{INSIDE_LIMIT:g}; moored: followed <= {FOLLOWED_LIMIT:g} of the span)")
    for name, prefix in (("rangeproc", ""),) + ((("Stone Soup GNN", "gnn_"),) if gnn else ()):
        for role, a in acceptance(rows, prefix).items():
            print(f"{name:<15}{role:<8}{a['accepted']:>3} of {a['objects']:<3} "
                  f"{'; '.join(a['outside'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=SEEDS)
    ap.add_argument("--gnn", action="store_true", help="also score Stone Soup's GNN")
    add_result_arguments(ap, Path("bench/harbour.json"))
    args = ap.parse_args()
    if summarised(args.summarise, print_tables):
        return
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="harbour-") as tmp:
        for seed in args.seeds:
            rows.extend(seed_rows(seed, Path(tmp), args.gnn))
            print(f"seed {seed}: " + ", ".join(
                f"{r.get('object')} {'ok' if not misses(r) else '/'.join(misses(r))}"
                for r in rows if r["seed"] == seed), flush=True)
    result = with_meta(rows)
    result["acceptance"] = {"rangeproc": acceptance(rows)}
    if args.gnn:
        result["acceptance"]["stonesoup_gnn"] = acceptance(rows, "gnn_")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print_tables(rows)


if __name__ == "__main__":
    main()
