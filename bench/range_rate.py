"""Range rates alone against the bound (``make range-rate``).

For each seed the simulator writes a flight (with its MISTRAM wild points); the config keeps
MISTRAM alone and a given initial state (the truth at the first row, perturbed by draws of its
stated sigmas, 10 m and 5 m/s: ``tests/fusion/test_range_rate_only.py``). Runs:

* ``default``: the config as it is (``filter = "auto"``: the EKF's passes, then the batch
  spline fit);
* ``ekf``: ``filter = "ekf"`` (the EKF smoother alone);
* three references told the truth: the wild rows removed (those more than 5 true sigmas from
  the noise-free simulation; in the burst, of the burst's sigma), the true noise stated (the
  burst's rows as a second MISTRAM sensor with ten times the sigma), noise adaptation off,
  with the EKF smoother and the batch spline fit (``told_auto``), the EKF smoother alone
  (``told_ekf``) and the spline filter with its fit (``told_spline``); the best of the three
  is the bound a run is measured against.

Besides the simulator's wild points every station's noise is multiplied by 10 for ``--burst``
seconds (default 10) from 45 % of the flight.

Each flight is measured ``--draws`` times (default 4): the simulator's own files for the
seed, then the same flight with other draws of the sensors' sampling and noise, the initial
state's perturbation and the burst's noise. Per run and draw: position and velocity RMSE, the
share of epochs inside 3 sigma (worst axis), the ratio of the position RMSE to the bound's;
per run over the draws: the RMS of the position RMSE and its ratio to the bound's RMS, the
worst and mean share inside 3 sigma. Usage: ``python bench/range_rate.py --seeds 1 2 3 4 5 6
--out FILE``.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from meta import run_meta  # bench/ is on sys.path: scripts, not a package

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import simulate_scenario
from rangeproc.simulate.scenario import draw_scenario

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))                # tests.*
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fusion"))
from test_range_rate_burst import (  # noqa: E402  (the tests' own burst and told config)
    BURST_FACTOR,
    WILD_SIGMAS,
    told_config,
)
from test_range_rate_only import mistram_only_config  # noqa: E402  (the tests' own config)



def score(cfg: Path, truth: Path) -> dict:
    out = run(cfg)
    t = evaluate_run(out.out_dir, truth)["targets"]["T1"]
    return {"pos_rmse": t["pos_rmse"], "vel_rmse": t["vel_rmse"],
            "in3": min(t["inside_3sigma_enu"]),
            "filter": out.summary["targets"]["T1"]["filter"]["used"]}


def variant(base: str, folder: Path, name: str, extra: str, text: str | None = None) -> Path:
    path = folder / f"{name}.toml"
    path.write_text((text or base).replace('dir = "out"', f'dir = "out_{name}"') + extra)
    return path


def one_draw(seed: int, draw: int, duration: float, tmp: Path, burst_s: float = 0.0) -> dict:
    """The runs of one flight (``seed``) on one draw of its sensors' noise: draw 0 is the
    simulator's own files for the seed; draw k > 0 the same flight measured again
    (``simulate_scenario(noise_seed=...)``), with its own initial-state perturbation and
    burst noise."""
    noise_seed = None if draw == 0 else 1000 * seed + draw
    folder, exact = tmp / f"s{seed}_{draw}", tmp / f"x{seed}_{draw}"
    simulate_scenario(folder, seed=seed, duration=duration, noise_seed=noise_seed)
    simulate_scenario(exact, seed=seed, duration=duration, noise=False, sensors="MISTRAM",
                      noise_seed=noise_seed)
    base = mistram_only_config(folder, initial=True, seed=noise_seed or seed).read_text()
    sigma = draw_scenario(seed, duration).mistram_sigma
    rows = pd.read_csv(folder / "MISTRAM.csv")
    burst = np.zeros(len(rows), dtype=bool)
    if burst_s > 0.0:                     # every station's noise x BURST_FACTOR for burst_s
        t0 = rows.time.min() + 0.45 * (rows.time.max() - rows.time.min())
        burst = ((rows.time >= t0) & (rows.time < t0 + burst_s)).to_numpy()
        extra = sigma * np.sqrt(BURST_FACTOR ** 2 - 1.0)
        rng = np.random.default_rng(seed if draw == 0 else (seed, draw))
        rows.loc[burst, "range_rate"] += rng.normal(0.0, extra, burst.sum())
        rows.to_csv(folder / "MISTRAM.csv", index=False)
    key = ["time", "station"] if "station" in rows.columns else ["time"]
    both = rows.merge(pd.read_csv(exact / "MISTRAM.csv"), on=key, suffixes=("", "_exact"))
    in_burst = np.zeros(len(both), dtype=bool)
    if burst_s > 0.0:                     # told the burst: its rows a sensor of their own
        t0b, t1b = rows.time[burst].min(), rows.time[burst].max()
        in_burst = np.array((both.time >= t0b) & (both.time <= t1b))
    # wild: more than WILD_SIGMAS of the row's own true sigma (ten times more in the burst)
    # from the noise-free simulation: the simulator's gross errors, not the burst's noise
    true_sigma = sigma * np.where(in_burst, BURST_FACTOR, 1.0)
    wild = np.array((both.range_rate - both.range_rate_exact).abs()) > WILD_SIGMAS * true_sigma
    both.loc[~wild & ~in_burst, rows.columns].to_csv(folder / "MISTRAM_told.csv", index=False)
    if in_burst.any():
        both.loc[~wild & in_burst, rows.columns].to_csv(folder / "MISTRAM_burst.csv",
                                                        index=False)
    told = told_config(base, sigma, burst=bool(in_burst.any()))
    truth = folder / "truth.csv"
    runs = {
        "default": score(variant(base, folder, "default", ""), truth),
        "ekf": score(variant(base, folder, "ekf", '\n[processing]\nfilter = "ekf"\n'), truth),
        "told_auto": score(variant(base, folder, "told_auto", "\n[processing]\n"
                                   "adapt_noise = false\n", told), truth),
        "told_ekf": score(variant(base, folder, "told_ekf", '\n[processing]\nfilter = "ekf"\n'
                                  "adapt_noise = false\n", told), truth),
        "told_spline": score(variant(base, folder, "told_spline", "\n[processing]\nfilter = "
                                     '"spline"\nadapt_noise = false\n', told), truth)}
    bound = min(runs[k]["pos_rmse"] for k in ("told_auto", "told_ekf", "told_spline"))
    for r in runs.values():
        r["over_bound"] = r["pos_rmse"] / bound
    return {"draw": draw, "noise_seed": noise_seed, "wild_rows": int(wild.sum()),
            "rows": int(len(both)), "bound_pos_rmse": bound, "runs": runs}


def one_seed(seed: int, duration: float, tmp: Path, burst_s: float = 0.0,
             draws: int = 1) -> dict:
    """Every run of one flight over ``draws`` draws of its sensors' noise. A run's figures
    over the draws: the RMS of its position RMSE, that over the bound's (the best of the
    three told smoothers by the same RMS), the worst and mean share inside 3 sigma. A flight
    whose position sigma is metres while each draw's error is a fraction of it (range rates
    alone fix the position weakly) gives ratios of one draw that say little: the draws'
    RMS compares the estimators' expected error."""
    each = [one_draw(seed, k, duration, tmp, burst_s) for k in range(draws)]
    runs = {}
    for name in each[0]["runs"]:
        per = [d["runs"][name] for d in each]
        runs[name] = {"pos_rmse": float(np.sqrt(np.mean([r["pos_rmse"] ** 2 for r in per]))),
                      "vel_rmse": float(np.sqrt(np.mean([r["vel_rmse"] ** 2 for r in per]))),
                      "in3": min(r["in3"] for r in per),
                      "in3_mean": float(np.mean([r["in3"] for r in per])),
                      "filter": per[0]["filter"]}
    bound = min(runs[k]["pos_rmse"] for k in ("told_auto", "told_ekf", "told_spline"))
    for r in runs.values():
        r["over_bound"] = r["pos_rmse"] / bound
    return {"seed": seed, "burst_s": burst_s, "draws": each, "bound_pos_rmse": bound,
            "runs": runs}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--burst", type=float, default=10.0,
                    help="seconds of a MISTRAM noise burst (x10) at 45 %% of the flight; 0: none")
    ap.add_argument("--draws", type=int, default=4,
                    help="draws of each flight's sensor noise (the first: the simulator's "
                         "own files for the seed)")
    ap.add_argument("--out", type=Path, default=Path("bench/range_rate.json"))
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            row = one_seed(seed, args.duration, Path(tmp), args.burst, args.draws)
            rows.append(row)
            for d in row["draws"]:
                print(f"  seed {seed} draw {d['draw']}: " + "  ".join(
                    f"{k} {r['pos_rmse']:.2f} m ({r['over_bound']:.2f}x) in 3σ {r['in3']:.3f}"
                    for k, r in d["runs"].items()), flush=True)
            print(f"seed {seed}: bound {row['bound_pos_rmse']:.2f} m  " + "  ".join(
                f"{k} ({r['filter']}): {r['pos_rmse']:.2f} m ({r['over_bound']:.2f}x) "
                f"in 3σ {r['in3']:.3f}" for k, r in row["runs"].items()), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"meta": run_meta(), "duration": args.duration,
                                    "burst_s": args.burst, "draws": args.draws,
                                    "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
