"""Accuracy sweep (``make accuracy``): simulate seeds, run rangeproc, evaluate against truth.

For every seed: the full scenario and the same scenario without the MISTRAM and theodolite
files (graceful degradation), with every filter asked for (``--filters``, default the EKF) and
the stated sigmas scaled by ``--sigma-factor`` (1 = the simulator's true sigmas; its GPS has a
noise burst of 8-12 s). Prints one table and writes ``--out`` (default bench/reproduce.json;
``make accuracy``: docs/measurements/accuracy.json) as ``{"meta": ..., "rows": [...]}``
(``bench/meta.py``). Usage:
``python bench/reproduce.py --seeds 1 2 3 --filters ekf imm --sigma-factor 2``.
"""
from __future__ import annotations

import argparse
import json
import re
import tempfile
import time
from pathlib import Path

from meta import with_meta  # bench/ is on sys.path: scripts, not a package

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario


def drop_sensors(config: Path, kinds: tuple[str, ...], dst: Path) -> Path:
    """Copy a config without the [[sensors]] tables of the given kinds."""
    text = config.read_text()
    blocks = re.split(r"(?m)^(?=\[\[sensors\]\])", text)
    keep = [b for b in blocks if not any(re.search(rf'(?m)^kind = "{k}"', b) for k in kinds)]
    dst.write_text("".join(keep))
    return dst


def variant(config: Path, dst: Path, *, name: str, sigma_factor: float) -> Path:
    """A copy of ``config`` with ``[processing] filter = name``, the stated sigmas scaled by
    ``sigma_factor`` and its own output folder."""
    text = config.read_text()
    if sigma_factor != 1.0:
        def scale(m: re.Match) -> str:
            return "sigma = {" + re.sub(r"= ([0-9.eE+-]+)",
                                        lambda v: f"= {float(v.group(1)) * sigma_factor!r}",
                                        m.group(1)) + "}"
        text = re.sub(r"sigma = \{([^}]*)\}", scale, text)
    text = re.sub(r'(?m)^dir = ".*"', f'dir = "{dst.stem}_out"', text)
    dst.write_text(text + f'\n[processing]\nfilter = "{name}"\n')
    return dst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--filters", nargs="+", default=["ekf"])
    ap.add_argument("--sigma-factor", type=float, default=1.0)
    ap.add_argument("--out", type=Path, default=Path("bench/reproduce.json"))
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            scen = Path(tmp) / f"seed{seed}"
            cfg = simulate_scenario(scen, seed=seed, duration=args.duration)
            reduced = drop_sensors(cfg, ("mistram", "theodolite"), scen / "reduced.toml")
            for name in args.filters:
                for label, base in (("full", cfg), ("no MISTRAM/theodolite", reduced)):
                    c = variant(base, scen / f"{base.stem}_{name}.toml", name=name,
                                sigma_factor=args.sigma_factor)
                    t0 = time.perf_counter()
                    out = run(c)
                    elapsed = time.perf_counter() - t0
                    mt = evaluate_run(out.out_dir, scen / "truth.csv")["targets"]["T1"]
                    rows.append({"seed": seed, "filter": name, "case": label,
                                 "sigma_factor": args.sigma_factor,
                                 "elapsed_s": round(elapsed, 2), **{k: mt[k] for k in (
                                     "pos_rmse", "pos_p95", "vel_rmse", "vel_p95",
                                     "inside_3sigma_enu", "nees_pos_mean")}})
                    print(json.dumps(rows[-1]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(with_meta(rows), indent=2) + "\n")
    print(f"\nstated sigmas x{args.sigma_factor:g}")
    print(f"{'seed':>4} {'filter':<10} {'case':<24} {'pos RMSE':>9} {'pos p95':>8} "
          f"{'vel RMSE':>9} {'in 3σ (e,n,u)':>20} {'NEES':>6}")
    for r in rows:
        ins = ",".join(f"{v:.3f}" for v in r["inside_3sigma_enu"])
        print(f"{r['seed']:>4} {r['filter']:<10} {r['case']:<24} {r['pos_rmse']:9.3f} "
              f"{r['pos_p95']:8.3f} {r['vel_rmse']:9.3f} {ins:>20} {r['nees_pos_mean']:6.2f}")


if __name__ == "__main__":
    main()
