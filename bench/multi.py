"""Several objects: the acceptance sweep of track synthesis over the simulator's kinds.

For each kind and seed: simulate (``rangeproc simulate --objects KIND``), run rangeproc, score
it with ``rangeproc evaluate`` (several objects: per truth object its best-matching output
object, RMSE, coverage, identity swaps, fragments; GOSPA), and run the *true assignment*
oracle: for every truth object, the same scenario with each radar/theodolite file reduced to
that object's rows (``truth_association.csv``) and only that object's GPS/MISTRAM, declared
as the only target. The acceptance criteria: zero swaps, coverage >= 90 % of the span the
object was observed (``coverage_observed``: from its first to its last measurement in
``truth_association.csv`` and its own GPS/MISTRAM files), RMSE within 1.25x of the oracle's,
its best-matching output object >= 95 % pure.
Coverage is printed at the 50 m cutoff and (``c.3x``) at max(50 m, 3x the oracle's RMSE):
an object only a surveillance radar sees is tracked to its plots' 100 m, not to 50 m.
Purity (``pur``) is counted on rows: the share of the output object's radar/theodolite rows
that are the truth object's (``truth_association.csv``; clutter counts against it), so that
it measures the association, not the sensors' accuracy against a cutoff. ``extra`` counts
the output objects that are no truth object's best match (fragments, false objects).

The benchmark kind ``scale`` runs with ``--scale-objects`` objects (10 and 20 by default);
its rows are labelled ``scale`` (10, the kind's default) and ``scale-N`` otherwise.

    python bench/multi.py [--kinds crossing ...] [--seeds 1 2 3] [--scale-objects 10 20]
                          [--out bench/multi.json]

The JSON is ``{"meta": ..., "rows": [...]}`` (``bench/meta.py``); ``make multi`` writes it to
docs/measurements/multi.json.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import tempfile
import time
from pathlib import Path

import pandas as pd

try:
    import tomllib
except ModuleNotFoundError:                       # Python 3.10
    import tomli as tomllib

from meta import with_meta  # bench/ is on sys.path: scripts, not a package

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import MULTI_KINDS, simulate_multi
from rangeproc.simulate.multi import DEFAULT_OBJECTS


def _blocks(text: str) -> tuple[str, list[str]]:
    parts = re.split(r"(?m)^(?=\[\[(?:sensors|targets)\]\])", text)
    return parts[0], parts[1:]


def oracle_config(scen: Path, obj: str, dst: Path) -> Path:
    """A copy of scenario ``scen`` holding only object ``obj``'s rows, declared alone."""
    shutil.copytree(scen, dst)
    assoc = pd.read_csv(scen / "truth_association.csv", keep_default_na=False)
    head, blocks = _blocks((scen / "scenario.toml").read_text())
    keep = [f'[[targets]]\nid = "{obj}"\n\n']
    for b in blocks:
        if b.startswith("[[targets]]"):
            continue
        kind = re.search(r'(?m)^kind = "(\w+)"', b).group(1)
        sid = re.search(r'(?m)^id = "([^"]+)"', b).group(1)
        if kind in ("gps", "mistram"):
            m = re.search(r'(?m)^target = "([^"]+)"', b)
            if m is None or m.group(1) != obj:
                continue
        if kind in ("radar", "theodolite"):
            fname = re.search(r'(?m)^file = "([^"]+)"', b).group(1)
            rows = assoc[(assoc.sensor == sid) & (assoc.target_id == obj)].row.to_numpy()
            if rows.size == 0:
                continue
            path = dst / fname
            if path.suffix == ".parquet":
                pd.read_parquet(path).iloc[rows].to_parquet(path, index=False)
            else:
                df = pd.read_csv(path, dtype=str, keep_default_na=False)
                df.iloc[rows].to_csv(path, index=False)
        keep.append(b)
    (dst / "scenario.toml").write_text(head + "".join(keep))
    return dst / "scenario.toml"


def observed_spans(scen: Path) -> dict[str, tuple[float, float]]:
    """Truth object -> (first, last) time (s) any sensor measured it: its radar/theodolite
    rows (``truth_association.csv``) and the GPS/MISTRAM it carries."""
    cfg = tomllib.loads((scen / "scenario.toml").read_text())
    assoc = pd.read_csv(scen / "truth_association.csv", keep_default_na=False)
    times: dict[str, list[float]] = {}
    for sen in cfg.get("sensors", []):
        path = scen / sen["file"]
        t = (pd.read_parquet(path, columns=["time"]) if path.suffix == ".parquet"
             else pd.read_csv(path, usecols=["time"]))["time"]
        if not pd.api.types.is_numeric_dtype(t):          # ISO-8601 stamps
            t = (pd.to_datetime(t, utc=True, errors="coerce")
                 - pd.Timestamp(0, tz="UTC")).dt.total_seconds()
        if sen["kind"] in ("gps", "mistram") and "target" in sen:
            times.setdefault(sen["target"], []).extend(t.dropna().to_list())
        elif sen["kind"] in ("radar", "theodolite"):
            mine = assoc[assoc.sensor == sen["id"]]
            for obj, rows in mine.groupby("target_id"):
                if obj:
                    times.setdefault(obj, []).extend(t.iloc[rows.row.to_numpy()].dropna().to_list())
    return {k: (min(v), max(v)) for k, v in times.items() if v}


def row_purity(scen: Path, out: Path) -> dict[str, float]:
    """Output object -> the share of its radar/theodolite rows that belong to its majority
    truth object (rows of clutter count against it)."""
    got = pd.read_parquet(out / "association.parquet", columns=["sensor", "row", "target_id"])
    true = pd.read_csv(scen / "truth_association.csv", keep_default_na=False)
    both = got.merge(true.rename(columns={"target_id": "true"})[["sensor", "row", "true"]],
                     on=["sensor", "row"])
    both = both[both.target_id.fillna("") != ""]
    return {str(k): float(g.true.value_counts().iloc[0] / len(g))
            for k, g in both.groupby("target_id")}


def scenarios(kinds: list[str], scale_objects: list[int]) -> list[tuple[str, str, int | None]]:
    """(label, kind, n_objects) of the sweep: kind ``scale`` once per count in
    ``scale_objects`` (labelled ``scale`` at the kind's default, else ``scale-N``)."""
    out: list[tuple[str, str, int | None]] = []
    for kind in kinds:
        if kind != "scale":
            out.append((kind, kind, None))
            continue
        for n in scale_objects:
            out.append(("scale" if n == DEFAULT_OBJECTS["scale"] else f"scale-{n}", kind, n))
    return out


def sweep(kinds: list[str], seeds: list[int], scale_objects: list[int] | None = None
          ) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, kind, n_objects in scenarios(kinds, scale_objects or [10]):
            for seed in seeds:
                scen = Path(tmp) / f"{label}_{seed}"
                config = simulate_multi(scen, kind=kind, seed=seed, n_objects=n_objects)
                t0 = time.perf_counter()
                try:
                    run(config)
                except Exception as exc:              # recorded, the sweep goes on
                    rows.append({"kind": label, "seed": seed, "error": str(exc)})
                    print(json.dumps(rows[-1]), flush=True)
                    continue
                elapsed = time.perf_counter() - t0
                spans = observed_spans(scen)
                multi = evaluate_run(scen / "out", scen / "truth.csv", cutoff=50.0,
                                     observed=spans)["multi"]
                purity = row_purity(scen, scen / "out")
                matched = {m.get("best_match") for m in multi["truth"].values()}
                extra = sum(1 for k in multi["fused"] if k not in matched)
                for obj, m in multi["truth"].items():
                    try:
                        oc = oracle_config(scen, obj, Path(tmp) / f"{label}_{seed}_{obj}")
                        run(oc)
                        om = evaluate_run(oc.parent / "out", oc.parent / "truth.csv")
                        oracle = om["targets"].get(obj, {}).get("pos_rmse")
                    except Exception as exc:
                        oracle = None
                        print(f"  oracle {obj}: {exc}")
                    rmse = m.get("best_match_rmse")
                    # covered = tracked: within the cutoff or within 3x the accuracy the
                    # true assignment reaches on this object (a surveillance-only object's
                    # 100 m are its sensor's, not an association failure)
                    scaled = max(50.0, 3.0 * oracle) if oracle else 50.0
                    cov_scaled = evaluate_run(scen / "out", scen / "truth.csv", cutoff=scaled,
                                              observed=spans)["multi"]["truth"][obj]

                    rows.append({"kind": label, "seed": seed, "object": obj,
                                 "n_objects": len(multi["truth"]),
                                 "match": m.get("best_match"), "rmse": rmse,
                                 "oracle_rmse": oracle,
                                 "ratio": (rmse / oracle) if rmse and oracle else None,
                                 "coverage": m.get("coverage"),
                                 "coverage_observed": m.get("coverage_observed"),
                                 "cutoff_scaled": scaled,
                                 "coverage_scaled": cov_scaled.get("coverage_observed"),
                                 "swaps": m.get("swaps"),
                                 "fragments": m.get("fragmentation"),
                                 "row_purity": purity.get(m.get("best_match")),
                                 "extra_objects": extra,
                                 "gospa_mean": multi["totals"].get("gospa_mean"),
                                 "run_s": round(elapsed, 2)})
                    print(json.dumps(rows[-1]), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--kinds", nargs="+", default=list(MULTI_KINDS),
                    help="simulator kinds (default: all)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--scale-objects", type=int, nargs="+", default=[10, 20],
                    help="object counts of kind scale (default: 10 and 20)")
    ap.add_argument("--out", type=Path, default=Path("bench/multi.json"))
    args = ap.parse_args()
    rows = sweep(args.kinds, args.seeds, args.scale_objects)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(with_meta(rows), indent=2) + "\n")
    print(f"\n{'kind':<16}{'seed':>5} {'object':<7}{'match':<7}{'RMSE m':>9}{'oracle':>9}"
          f"{'ratio':>7}{'cover':>7}{'c.obs':>7}{'c.3x':>7}{'swaps':>6}{'frag':>5}"
          f"{'pur':>6}{'extra':>6}")
    for r in rows:
        if "error" in r:
            print(f"{r['kind']:<16}{r['seed']:>5} error: {r['error']}")
            continue

        def f(v, fmt: str) -> str:
            return format(v, fmt) if isinstance(v, (int, float)) else "-"
        print(f"{r['kind']:<16}{r['seed']:>5} {r['object']:<7}{str(r['match']):<7}"
              f"{f(r['rmse'], '9.2f')}{f(r['oracle_rmse'], '9.2f')}{f(r['ratio'], '7.2f')}"
              f"{f(r['coverage'], '7.3f')}{f(r.get('coverage_observed'), '7.3f')}"
              f"{f(r.get('coverage_scaled'), '7.3f')}"
              f"{f(r['swaps'], '6d')}{f(r['fragments'], '5d')}"
              f"{f(r.get('row_purity'), '6.2f')}{f(r.get('extra_objects'), '6d')}")


if __name__ == "__main__":
    main()
