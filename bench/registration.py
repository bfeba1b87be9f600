"""Registration acceptance sweep (``make registration``): sensor faults injected with truth.

For every seed the simulator writes the scenario twice, with the registration preset's faults
(``rangeproc simulate --faults registration``: radar range/azimuth/elevation biases, theodolite
angle biases, a ship radar yawed 0.3 deg on its deck with time stamps 40 ms late) and without;
each is run with the registration on (the default) and off. Printed per seed: every injected term's
estimate against truth (in its sigmas and as a share of its size), and the fused position
RMSE, share of epochs inside 3 sigma (worst axis) and NEES of the four runs. Usage:
``python bench/registration.py --seeds 1 2 3 4 5``; writes ``--out`` (default
bench/registration.json; ``make registration``: docs/measurements/registration.json) as
``{"meta": ..., "rows": [...]}`` (``bench/meta.py``).
"""
from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from meta import with_meta  # bench/ is on sys.path: scripts, not a package

from rangeproc.evaluate import evaluate_run
from rangeproc.pipeline import run
from rangeproc.simulate import REGISTRATION_FAULTS, simulate_scenario


def with_registration(config: Path, on: bool) -> Path:
    """A copy of ``config`` with ``[processing] calibration`` set and its own output folder."""
    dst = config.with_name(f"{config.stem}_{'cal' if on else 'nocal'}.toml")
    text = config.read_text().replace('dir = "out"', f'dir = "out_{dst.stem}"')
    dst.write_text(text + f"\n[processing]\ncalibration = {'true' if on else 'false'}\n")
    return dst


def score(out_dir: Path, truth: Path) -> dict:
    t = evaluate_run(out_dir, truth)["targets"]["T1"]
    return {"rmse": t["pos_rmse"], "in3": min(t["inside_3sigma_enu"]),
            "nees": t["nees_pos_mean"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--out", type=Path, default=Path("bench/registration.json"))
    args = ap.parse_args()
    report = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            row: dict = {"seed": seed, "terms": [], "runs": {}}
            for faulted in (True, False):
                folder = Path(tmp) / f"seed{seed}_{'faults' if faulted else 'clean'}"
                cfg = simulate_scenario(folder, seed=seed, duration=args.duration,
                                        faults=REGISTRATION_FAULTS if faulted else None)
                for on in (True, False):
                    out = run(with_registration(cfg, on))
                    key = f"{'faults' if faulted else 'clean'}_{'cal' if on else 'nocal'}"
                    row["runs"][key] = score(out.out_dir, folder / "truth.csv")
                    if faulted and on:
                        sensors = out.summary["sensors"]
                        truth = json.loads((folder / "truth_calibration.json").read_text())
                        for sid, terms in truth.items():
                            for name, true in terms.items():
                                got = sensors[sid]["calibration"][name]
                                est, sig = got["estimate"], got["sigma"]
                                row["terms"].append({
                                    "sensor": sid, "name": name, "true": true,
                                    "estimate": est, "sigma": sig,
                                    "in_sigmas": None if est is None else abs(est - true) / sig,
                                    "share": None if est is None else abs(est - true) / abs(true),
                                    "reason": got.get("unobservable", "")})
            report.append(row)
            print(json.dumps(row))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(with_meta(report), indent=2) + "\n")
    print(f"\n{'seed':>4} {'sensor':<6} {'term':<10} {'true':>10} {'estimate':>10} "
          f"{'sigma':>9} {'|err|/σ':>8} {'|err|/true':>10}")
    for row in report:
        for t in row["terms"]:
            if t["estimate"] is None:
                print(f"{row['seed']:>4} {t['sensor']:<6} {t['name']:<10} {t['true']:10.4g} "
                      f"unobservable: {t['reason']}")
                continue
            print(f"{row['seed']:>4} {t['sensor']:<6} {t['name']:<10} {t['true']:10.4g} "
                  f"{t['estimate']:10.4g} {t['sigma']:9.2g} {t['in_sigmas']:8.2f} "
                  f"{t['share']:10.1%}")
    print(f"\n{'seed':>4} {'run':<14} {'pos RMSE m':>10} {'in 3σ':>7} {'NEES':>6}")
    for row in report:
        for key, r in row["runs"].items():
            print(f"{row['seed']:>4} {key:<14} {r['rmse']:10.3f} {r['in3']:7.3f} "
                  f"{r['nees']:6.2f}")
        runs = row["runs"]
        print(f"{row['seed']:>4} ratios: faults+cal / clean+nocal "
              f"{runs['faults_cal']['rmse'] / runs['clean_nocal']['rmse']:.2f}, "
              f"clean+cal / clean+nocal "
              f"{runs['clean_cal']['rmse'] / runs['clean_nocal']['rmse']:.3f}")


if __name__ == "__main__":
    main()
