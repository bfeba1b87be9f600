"""Seeded Monte Carlo of the trajectory's uncertainty with estimated calibration terms
(``make calibration-mc``).

For each seed the simulator writes a flight whose sensors carry systematic errors drawn from
the spreads :data:`SPREAD` (1-sigma, SI: radar range, azimuth and elevation biases, theodolite
angle biases, the ship radar's mount yaw and latency), and rangeproc runs it with the
registration on (the default). Two sets: the simulator's drawn trajectories (120 s), and a
real aircraft's track (:data:`RECORDED`, an A310 zero-gravity flight from ADS-B: pull-ups,
zero-g arcs, a turn; ``rangeproc simulate --trajectory``, 240 s). Per run: position RMSE, the
share of epochs inside 3 sigma (worst axis), the mean position NEES and each estimated
term's error in its sigmas. Per set: the mean NEES against the chi-square 95 % bounds of
``3 M`` degrees of freedom over ``M`` runs (a run's epochs are strongly correlated in time,
so a run counts as one sample). Usage: ``python bench/calibration_mc.py --out FILE``.
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path

import numpy as np
from meta import run_meta  # bench/ is on sys.path: scripts, not a package
from scipy.stats import chi2

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario

#: the recorded track flown by the second set: an A310 zero-gravity flight (ADS-B)
RECORDED = Path(__file__).resolve().parent / "trajectories" / "a310_zero_gravity.csv"
_MRAD = 1e-3
_ARCSEC = math.radians(1.0 / 3600.0)
#: 1-sigma spread of each injected systematic error (SI), per sensor and term
SPREAD = {
    "R1": {"range": 10.0, "azimuth": 0.5 * _MRAD, "elevation": 0.5 * _MRAD},
    "TH1": {"azimuth": 20.0 * _ARCSEC, "elevation": 20.0 * _ARCSEC},
    "S1": {"mount_yaw": math.radians(0.3), "latency": 0.040},
}


def draw_faults(seed: int) -> dict[str, dict[str, float]]:
    """Systematic errors of one run, drawn from :data:`SPREAD` (its own generator)."""
    g = np.random.default_rng(10_000 + seed)
    return {sid: {name: float(g.normal(0.0, s)) for name, s in terms.items()}
            for sid, terms in SPREAD.items()}


def one_run(seed: int, duration: float, tmp: Path, trajectory: Path | None = None) -> dict:
    folder = tmp / f"seed{seed}"
    faults = draw_faults(seed)
    cfg = simulate_scenario(folder, seed=seed, duration=duration, faults=faults,
                            trajectory=trajectory)
    out = run(cfg)
    t = evaluate_run(out.out_dir, folder / "truth.csv")["targets"]["T1"]
    z2 = []                  # estimated terms' errors in their sigmas (true 0 where none drawn)
    for sid, s in out.summary["sensors"].items():
        for name, c in (s.get("calibration") or {}).items():
            if c.get("estimate") is not None and c["sigma"]:
                z2.append((c["estimate"] - faults.get(sid, {}).get(name, 0.0)) / c["sigma"])
    return {"seed": seed, "faults": faults, "rmse": t["pos_rmse"],
            "in3": min(t["inside_3sigma_enu"]), "nees": t["nees_pos_mean"],
            "n_epochs": t["n_epochs"], "term_z": z2}


def run_set(name: str, seeds: list[int], duration: float, trajectory: Path | None) -> dict:
    """One set of runs and its summary (module docstring)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            row = one_run(seed, duration, Path(tmp), trajectory)
            rows.append(row)
            print(f"{name} seed {seed:3d}  RMSE {row['rmse']:7.3f} m  in 3σ {row['in3']:6.3f}  "
                  f"NEES {row['nees']:6.2f}  terms: mean (err/σ)^2 "
                  f"{np.mean(np.square(row['term_z'])):5.2f}", flush=True)
    m = len(rows)
    nees = float(np.mean([r["nees"] for r in rows]))
    lo, hi = (float(chi2.ppf(p, 3 * m) / m) for p in (0.025, 0.975))
    summary = {"runs": m, "nees_mean": nees, "nees_95": [lo, hi],
               "in3_min": min(r["in3"] for r in rows),
               "in3_mean": float(np.mean([r["in3"] for r in rows])),
               "runs_in3_95": int(sum(r["in3"] >= 0.95 for r in rows)),
               "rmse_mean": float(np.mean([r["rmse"] for r in rows])),
               "term_z2_mean": float(np.mean(np.concatenate([np.square(r["term_z"])
                                                              for r in rows])))}
    print(f"{name}: {m} runs: mean NEES {nees:.2f} (95 % bounds {lo:.2f}-{hi:.2f}), epochs "
          f"inside 3σ: mean {summary['in3_mean']:.3f}, worst run {summary['in3_min']:.3f}, "
          f"{summary['runs_in3_95']} runs >= 0.95; mean RMSE {summary['rmse_mean']:.3f} m")
    return {"name": name, "trajectory": None if trajectory is None else trajectory.name,
            "duration": duration, "summary": summary, "rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 17)),
                    help="seeds of the simulated flights (drawn trajectories, 120 s)")
    ap.add_argument("--recorded-seeds", type=int, nargs="*", default=list(range(1, 11)),
                    help="seeds flying the recorded track --trajectory (240 s)")
    ap.add_argument("--trajectory", type=Path, default=RECORDED,
                    help="the recorded track (rangeproc simulate --trajectory)")
    ap.add_argument("--out", type=Path, default=Path("bench/calibration_mc.json"))
    args = ap.parse_args()
    sets = [run_set("simulated", args.seeds, 120.0, None)]
    if args.recorded_seeds:
        sets.append(run_set("recorded", args.recorded_seeds, 240.0, args.trajectory))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"meta": run_meta(), "sets": sets}, indent=2) + "\n")


if __name__ == "__main__":
    main()
