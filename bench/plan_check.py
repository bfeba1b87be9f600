"""Does ``rangeproc plan`` predict what a run achieves? (``make plan-check``)

For each seed the simulator writes a flight (with the sensors' systematic errors drawn as
``bench/calibration_mc.py`` draws them, or without: ``--clean``); ``rangeproc plan`` predicts
its sigma from the config and the truth trajectory alone, then ``rangeproc run`` processes
the flight. Per seed and axis: the run's position RMSE against the truth, the RMS of the
predicted sigma (with the calibration's uncertainty, and ``_calibrated``: every term known)
and of the run's own stated sigma over the run's epochs. Per axis over the seeds:
RMS(RMSE) / RMS(predicted sigma) (1 = the plan predicts the achieved error; a single
flight's RMSE is one draw of its calibration errors and noise, so only the ratio over seeds
is meaningful), the same against the calibrated prediction (the one for flights without
biases) and the median of predicted / stated sigma. Writes ``--out`` (JSON) and
``--figure`` (both sigmas and the running error of one seed, and the per-seed RMSE against
the prediction). Usage: ``python bench/plan_check.py --seeds 1 2 3 4 5 6``.
"""
from __future__ import annotations

import argparse
import json
import logging
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from calibration_mc import draw_faults  # bench/ is on sys.path: scripts, not a package
from meta import run_meta

from rangeproc.pipeline import run
from rangeproc.planning.plan import run_plan
from rangeproc.simulate import simulate_scenario

AXES = "enu"


def one_seed(seed: int, duration: float, faults: bool, tmp: Path) -> dict:
    folder = tmp / f"seed{seed}{'_faults' if faults else ''}"
    cfg = simulate_scenario(folder, seed=seed, duration=duration,
                            faults=draw_faults(seed) if faults else None)
    plan = run_plan(cfg, folder / "truth.csv").table
    out = run(cfg)
    fused = pd.read_parquet(out.out_dir / "fused.parquet")
    fused = fused[fused.target_id == "T1"]
    truth = pd.read_csv(folder / "truth.csv")
    row: dict = {"seed": seed, "faults": faults}
    series = {"time": fused.time.to_numpy()}
    for ax in AXES:
        err = fused[ax].to_numpy() - np.interp(fused.time, truth.time, truth[ax])
        predicted = np.interp(fused.time, plan.time, plan[f"sigma_{ax}"])
        known = np.interp(fused.time, plan.time, plan[f"sigma_{ax}_calibrated"])
        stated = fused[f"sigma_{ax}"].to_numpy()
        row[ax] = {"rmse": float(np.sqrt(np.mean(err ** 2))),
                   "predicted": float(np.sqrt(np.mean(predicted ** 2))),
                   "predicted_calibrated": float(np.sqrt(np.mean(known ** 2))),
                   "stated": float(np.sqrt(np.mean(stated ** 2))),
                   "predicted_over_stated_median": float(np.median(predicted / stated))}
        series[ax] = (err, predicted, known, stated)
    row["series"] = series
    return row


def summarise(rows: list[dict]) -> dict:
    out = {}
    for ax in AXES:
        rmse = np.array([r[ax]["rmse"] for r in rows])
        pred = np.array([r[ax]["predicted"] for r in rows])
        known = np.array([r[ax]["predicted_calibrated"] for r in rows])
        out[ax] = {"rmse_over_predicted": float(np.sqrt(np.mean(rmse ** 2) / np.mean(pred ** 2))),
                   "rmse_over_calibrated": float(np.sqrt(np.mean(rmse ** 2)
                                                         / np.mean(known ** 2))),
                   "predicted_over_stated_median": float(np.median(
                       [r[ax]["predicted_over_stated_median"] for r in rows]))}
    return out


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    first = rows[0]["series"]
    t = first["time"] - first["time"][0]
    for i, ax in enumerate(AXES):
        err, pred, known, stated = first[ax]
        window = max(1, int(len(t) / 60))
        run_rms = np.sqrt(pd.Series(err ** 2).rolling(window, center=True, min_periods=1)
                          .mean().to_numpy())
        a = axes[0, i]
        a.plot(t, run_rms, color="0.4", lw=1, label="run: running RMS error")
        a.plot(t, pred, color="#1f77b4", lw=1.5, label="plan: predicted σ")
        a.plot(t, known, color="#1f77b4", lw=1, ls=":", label="plan: σ, calibration known")
        a.plot(t, stated, color="#ff7f0e", lw=1, ls="--", label="run: stated σ")
        a.set_title(f"{ax.upper()}, seed {rows[0]['seed']} with drawn biases")
        a.set_xlabel("time from start (s)")
        a.set_ylabel("m")
        a.legend(fontsize=7)
        b = axes[1, i]
        for faults, marker, key, label in (
                (False, "o", "predicted_calibrated", "no biases: against σ, calibration known"),
                (True, "^", "predicted", "drawn biases: against σ")):
            sel = [r for r in rows if r["faults"] == faults]
            if sel:
                b.scatter([r[ax][key] for r in sel], [r[ax]["rmse"] for r in sel],
                          marker=marker, label=label)
        top = max(max(r[ax]["predicted"], r[ax]["rmse"]) for r in rows) * 1.1
        b.plot([0, top], [0, top], color="0.5", lw=0.8)
        b.plot([0, top], [0, 1.3 * top], color="0.8", lw=0.8, ls=":")
        b.plot([0, top], [0, 0.7 * top], color="0.8", lw=0.8, ls=":")
        b.set_xlabel(f"predicted σ {ax.upper()} (RMS over the flight, m)")
        b.set_ylabel(f"achieved RMSE {ax.upper()} (m)")
        b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 13)))
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--out", type=Path, default=Path("bench/plan_check.json"))
    ap.add_argument("--figure", type=Path, default=Path("bench/plan_check.png"))
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    sets = {}
    with tempfile.TemporaryDirectory() as tmp:
        for faults in (False, True):
            rows = [one_seed(s, args.duration, faults, Path(tmp)) for s in args.seeds]
            for r in rows:
                print(f"seed {r['seed']} {'biases' if faults else 'clean '}  " + "  ".join(
                    f"{ax}: RMSE {r[ax]['rmse']:.3f} predicted {r[ax]['predicted']:.3f} "
                    f"(calibrated {r[ax]['predicted_calibrated']:.3f}) "
                    f"stated {r[ax]['stated']:.3f}" for ax in AXES), flush=True)
            sets["biases" if faults else "clean"] = rows
    if args.figure:
        figure(sets["biases"] + sets["clean"], args.figure)
    result = {"meta": run_meta(), "duration": args.duration}
    for name, rows in sets.items():
        summary = summarise(rows)
        print(f"{name}: " + "  ".join(
            f"{ax}: RMS RMSE / RMS predicted {summary[ax]['rmse_over_predicted']:.2f} "
            f"(calibrated {summary[ax]['rmse_over_calibrated']:.2f}), "
            f"median predicted / stated {summary[ax]['predicted_over_stated_median']:.2f}"
            for ax in AXES))
        result[name] = {"summary": summary,
                        "rows": [{k: v for k, v in r.items() if k != "series"} for r in rows]}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
