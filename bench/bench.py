"""Benchmark: the filter kernels against FilterPy and Stone Soup, and the whole pipeline.

``make bench`` (``python bench/bench.py``) runs, in order:

1. Kernel benchmark (``bench/peers.py``): one radar range/azimuth/elevation data set, the same
   constant-acceleration EKF + RTS smoother run by rangeproc (compiled; first call timed on
   its own, then two untimed calls, ``HEAP_WARMUP``, then the median of ``--reps`` calls),
   FilterPy (``--kernel-steps`` rows) and Stone
   Soup (its first ``--stonesoup-steps`` rows; rangeproc is rerun on that prefix for the
   agreement). Prints microseconds per measurement row, the ratios, and the agreement of
   filtered and smoothed positions. Then the UKF row: the same data with rangeproc's
   unscented update (sigma points alpha 1, beta 2, kappa -6) + RTS smoother, FilterPy's
   UnscentedKalmanFilter + its rts_smoother (as shipped, timed; and with sigma points redrawn
   from the predicted moments, for the agreement) and Stone Soup's UnscentedKalmanPredictor/
   Updater + UnscentedKalmanSmoother (on the Stone Soup prefix).
2. Pipeline benchmark: simulates a sortie (all six sensors, ``--duration`` s, about ``--rows``
   rows in all: the simulator's sample rates times a ``rate_scale`` chosen from the rows of a
   scale-1 probe, since rows grow linearly with it; cached in ``bench/data/`` with a stamp of
   seed, duration, rate scale and simulator source hash), then runs
   ``rangeproc.pipeline.run`` -- what ``rangeproc run`` calls -- in a fresh subprocess
   (``--pipeline-only``) so that its peak resident memory is the pipeline's own (after a
   warm-up subprocess on a 60 s sortie, so numba compilation is not timed). Reports the
   stage seconds (read, assemble, fuse, write, report), the fuse stage broken down by the
   functions it calls (``breakdown.FUSE_PARTS``: merging the rows, process-noise search,
   filter + smoother passes with their forward filter, smoother and residuals, registration,
   noise estimates, the thinned pass carried to every row, ...; what they leave is
   ``unattributed_s`` in the JSON), the process wall time from interpreter start to exit,
   microseconds per measurement row, and memory.
3. Several objects at scale (issue 9): simulates kind ``scale`` (``rangeproc simulate
   --objects scale``: 10 objects, surveillance radar SR1 with a 4 s scan and 20 clutter plots
   per scan, tracking radars R1-R3 at 20 Hz per track, GPS on four objects; ``--multi-duration``
   s, cached in ``bench/data/`` like the sortie), runs the whole pipeline in a fresh subprocess
   the same way (after a warm-up on a 60 s ``scale`` scenario; stage seconds include
   ``associate``), and prints its rows, wall time, microseconds per row and their ratio to the
   single-object pipeline's (from this run, or from the previous results file when
   ``--skip-pipeline``), against the issue's < 3x: per measurement row of the objects (the
   sortie's INS attitude rows, a quarter of its rows and nearly free, left out of its count;
   the verdict) and per row of any kind (printed beside it). Then scores the output against
   truth.csv with ``rangeproc.evaluate`` (several objects: per truth object RMSE, coverage, identity
   swaps; GOSPA), so that the speed is not bought with wrong answers.

Writes every number plus machine info to ``--out`` (default ``bench/results.json``; ``make
bench``: ``docs/measurements/bench.json``), with the ``meta`` block of ``bench/meta.py``, and
prints the previous file's headline numbers, if there was one, for comparison. ``--quick`` is
the CI size
(a 300 s sortie at the simulator's own rates unless ``--rows`` or ``--rate-scale`` is given,
and a 300 s ``scale`` scenario). ``--skip-kernel``, ``--skip-pipeline`` and ``--skip-multi``
each leave out one of the three parts.
Nothing here asserts a time: the acceptance lines print PASS/FAIL for the lead to read.
"""
from __future__ import annotations

import argparse
import datetime as dt
import functools
import hashlib
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
sys.path.insert(0, str(BENCH))

import peers  # noqa: E402  (bench/ is put on sys.path just above)
from breakdown import Breakdown, print_breakdown, remainders, rss_and_peak  # noqa: E402
from meta import run_meta  # noqa: E402

#: acceptance figures of the speed issue (they supersede the earlier kernel and campaign
#: issues' figures): EKF + RTS per measurement and its ratios, the UKF, the one-hour
#: two-million-row sortie end to end and its peak memory on the 2-core machine
TARGET_US, TARGET_FP, TARGET_SS, TARGET_AGREE = 1.5, 30.0, 500.0, 1e-8
TARGET_UKF_US, TARGET_UKF_FP = 3.0, 150.0
TARGET_WALL_S, TARGET_PEAK_GB, TARGET_ROWS = 12.0, 1.2, 2_000_000
#: several objects at scale: simulator kind, scenario length (s), limit on (us per measurement
#: row) / (single-object pipeline's us per measurement row; measurement rows are those of the
#: sensors that measure an object, not the INS attitude rows of a platform, which the
#: several-objects scenario has none of and the sortie has 560k), GOSPA / assignment cutoff (m)
MULTI_KIND, MULTI_DURATION_S, TARGET_MULTI_RATIO, MULTI_CUTOFF_M = "scale", 1800.0, 3.0, 50.0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="CI size: 300 s sortie, 5,000 kernel rows, 500 Stone Soup rows, "
                         "300 s several-objects scenario")
    ap.add_argument("--duration", type=float, help="sortie length (s); default 3600")
    ap.add_argument("--seed", type=int, default=1, help="simulator and kernel-data seed")
    ap.add_argument("--rows", type=int,
                    help=f"measurement rows of the sortie, all six sensors (sets the sample-rate "
                         f"scale); default {TARGET_ROWS:_} (quick: the simulator's rates)")
    ap.add_argument("--rate-scale", type=float,
                    help="sample-rate scale of the sortie (overrides --rows)")
    ap.add_argument("--kernel-steps", type=int, help="kernel rows (rangeproc, FilterPy); 20000")
    ap.add_argument("--stonesoup-steps", type=int, help="Stone Soup rows; default 2000")
    ap.add_argument("--reps", type=int, help="timed rangeproc kernel calls (median); 5")
    ap.add_argument("--peer-reps", type=int,
                    help="timed FilterPy / Stone Soup runs (median); default 3 (quick: 1)")
    ap.add_argument("--multi-duration", type=float,
                    help=f"length (s) of the several-objects '{MULTI_KIND}' scenario; default "
                         f"{MULTI_DURATION_S:g} (quick: 300)")
    ap.add_argument("--skip-kernel", action="store_true",
                    help="leave out the kernel benchmark (part 1)")
    ap.add_argument("--skip-pipeline", action="store_true",
                    help="leave out the single-object pipeline benchmark (part 2); the "
                         "several-objects one still runs (add --skip-multi for the kernels "
                         "only) and takes its single-object reference from --out")
    ap.add_argument("--skip-multi", action="store_true",
                    help="leave out the several-objects benchmark (part 3)")
    ap.add_argument("--out", type=Path, default=BENCH / "results.json")
    ap.add_argument("--pipeline-only", type=Path, metavar="CONFIG", help=argparse.SUPPRESS)
    ap.add_argument("--json-out", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--first-call-only", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    quick = a.quick
    a.duration = a.duration or (300.0 if quick else 3600.0)
    a.multi_duration = a.multi_duration or (300.0 if quick else MULTI_DURATION_S)
    if a.rows is None and a.rate_scale is None:
        a.rows = None if quick else TARGET_ROWS
    a.kernel_steps = a.kernel_steps or (5000 if quick else 20000)
    a.stonesoup_steps = min(a.stonesoup_steps or (500 if quick else 2000), a.kernel_steps)
    a.reps = a.reps or (3 if quick else 5)
    a.peer_reps = a.peer_reps or (1 if quick else 3)
    return a


# ------------------------------------------------------------------------------- kernels
def _timed(fn, *args, reps: int = 1):
    """(median seconds over ``reps`` calls, last result)."""
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn(*args)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def cold_first_call(n: int) -> dict:
    """Import + first kernel call in a fresh process with an empty numba cache: what the
    very first run after installing pays to compile (s)."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--first-call-only",
                              "--kernel-steps", str(n)], env=env, capture_output=True,
                             text=True, check=True, cwd=ROOT).stdout
    return json.loads(out.strip().splitlines()[-1])


def first_call_child(n: int) -> None:
    t0 = time.perf_counter()
    import rangeproc.estimation.forward
    import rangeproc.estimation.rts  # noqa: F401
    t1 = time.perf_counter()
    args = peers.rangeproc_inputs(peers.radar_data(n))
    t2 = time.perf_counter()
    peers.rangeproc_kernel(args)
    print(json.dumps({"import_s": t1 - t0, "first_call_s": time.perf_counter() - t2}))


#: Untimed calls after the first, each holding the previous call's result as the timed calls
#: do: the heap then already holds two results. Without them the first two timed calls of the
#: process's first row (the EKF's) wrote ~900 fresh pages each (the heap growing), 0.4-0.9 us
#: per row of page faults in a median of three, which the rows timed later did not pay.
HEAP_WARMUP = 2


def minor_faults() -> int:
    """Minor page faults of this process so far (first writes to fresh pages)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def time_rangeproc(args, reps: int, kernel=peers.rangeproc_kernel
                   ) -> tuple[float, float, list[float], peers.Estimates]:
    """First call (compilation from the cache), :data:`HEAP_WARMUP` untimed calls, then the
    median of ``reps`` timed calls of the rangeproc ``kernel``; returns (first_s, median_s,
    all times, estimates of the last call). The timed calls' minor page faults are printed
    when there were any."""
    first_s, out = _timed(kernel, args)
    for _ in range(HEAP_WARMUP):
        _, out = _timed(kernel, args)
    times = []
    faults = minor_faults()
    for _ in range(reps):
        s, out = _timed(kernel, args)
        times.append(s)
    faults = minor_faults() - faults
    if faults:
        print(f"bench: {faults} minor page faults in {reps} timed rangeproc calls", flush=True)
    return first_s, statistics.median(times), times, peers.rangeproc_estimates(out)


def kernel_bench(a: argparse.Namespace) -> dict:
    """rangeproc vs FilterPy vs Stone Soup on the same radar rows (see bench/peers.py)."""
    d = peers.radar_data(a.kernel_steps, a.seed)
    n = len(d.t)
    first_s, rp_s, times, rp = time_rangeproc(peers.rangeproc_inputs(d), a.reps)
    fp_s, fp = _timed(peers.filterpy_run, d, reps=a.peer_reps)
    ds = d.head(a.stonesoup_steps)
    rp_head = peers.rangeproc_estimates(peers.rangeproc_kernel(peers.rangeproc_inputs(ds)))
    ss_stock_s, ss_stock = _timed(peers.stonesoup_run, peers.stonesoup_inputs(ds),
                                  reps=a.peer_reps)
    ss_s, ss = _timed(peers.stonesoup_run, peers.stonesoup_inputs(ds, analytic=True),
                      reps=a.peer_reps)
    m = len(ds.t)
    cold = cold_first_call(a.kernel_steps)
    ukf = ukf_bench(a, d, ds, rp)
    adaptive = filter_rows(a, d, rp_s / n * 1e6, ukf["us_per_meas"]["rangeproc"])
    us = {"rangeproc": rp_s / n * 1e6, "filterpy": fp_s / n * 1e6,
          "stonesoup": ss_s / m * 1e6, "stonesoup_stock": ss_stock_s / m * 1e6}
    return {
        "rows": n, "stonesoup_rows": m, "dt_s": peers.DT, "q": d.q,
        "sigma_range_m": float(peers.SIGMA[0]), "sigma_angle_rad": float(peers.SIGMA[1]),
        "rangeproc_first_call_s": first_s, "rangeproc_cold_import_s": cold["import_s"],
        "rangeproc_cold_first_call_s": cold["first_call_s"],
        "rangeproc_times_s": times, "filterpy_s": fp_s, "stonesoup_s": ss_s,
        "stonesoup_stock_s": ss_stock_s, "us_per_meas": us,
        "ratio_filterpy": us["filterpy"] / us["rangeproc"],
        "ratio_stonesoup": us["stonesoup"] / us["rangeproc"],
        "ratio_stonesoup_stock": us["stonesoup_stock"] / us["rangeproc"],
        "stonesoup_model_check": peers.stonesoup_model_check(d.q),
        "agreement": {"filterpy": peers.agreement(rp, fp),
                      "stonesoup": peers.agreement(rp_head, ss),
                      "stonesoup_stock": peers.agreement(rp_head, ss_stock)},
        "ukf": ukf,
        "filters": adaptive,
    }


def filter_rows(a: argparse.Namespace, d: peers.RadarData, ekf_us: float, ukf_us: float
                ) -> dict:
    """One row per further selectable filter on the same radar rows (filter + RTS smoother,
    µs per measurement, and the ratio to the row of the filter it extends: EKF, or UKF for
    stukf): no peer library offers these. The spline row is seed 000's forward filter with
    its anomaly test and jerk input + the smoother (the batch B-spline fit that follows in the
    pipeline is not part of the kernel row)."""
    from rangeproc.config import ProcessingSettings
    from rangeproc.estimation.forward import EKF, UKF
    from rangeproc.estimation.spline_filter import spline_params
    p = ProcessingSettings()
    stf = np.array([p.stukf_forgetting, p.stukf_weakening, *p.stukf_ratios])
    spl = spline_params(p.spline_anomaly_probability)
    rows = {}
    for name, method, adapt, norm, fading, spline, base_us in (
            ("stukf", UKF, 0, 0.0, stf, None, ukf_us),
            ("sage-husa", EKF, p.sage_husa_window, 0.0, None, None, ekf_us),
            ("askf", EKF, 0, 1.0, None, None, ekf_us),
            ("spline", EKF, 0, 0.0, None, spl, ekf_us)):
        first_s, s, times, _ = time_rangeproc(
            peers.rangeproc_inputs(d, method, adapt, norm, fading, spline), a.reps)
        us = s / len(d.t) * 1e6
        rows[name] = {"us_per_meas": us, "ratio_to_base": us / base_us,
                      "ratio_to_ekf": us / ekf_us, "first_call_s": first_s, "times_s": times}
    from rangeproc.fusion.passes import imm_generator
    from rangeproc.settings import IMM_MODELS
    codes = np.array([IMM_MODELS.index(m) for m in p.imm_models])
    imm_args = (*peers.rangeproc_inputs(d).imm_args(), codes,
                imm_generator(len(codes), p.imm_sojourn), np.full(len(codes), 1 / len(codes)))
    first_s, s, times, _ = time_rangeproc(imm_args, a.reps, peers.rangeproc_imm_kernel)
    us = s / len(d.t) * 1e6
    rows["imm"] = {"us_per_meas": us, "ratio_to_base": us / ekf_us, "ratio_to_ekf": us / ekf_us,
                   "first_call_s": first_s, "times_s": times, "models": list(p.imm_models)}
    return rows


def ukf_bench(a: argparse.Namespace, d: peers.RadarData, ds: peers.RadarData,
              rp_ekf: peers.Estimates) -> dict:
    """The UKF row: rangeproc (method UKF) vs FilterPy's and Stone Soup's UKF + smoother on
    the same rows as the EKF row (Stone Soup on the prefix ``ds``)."""
    from rangeproc.estimation.forward import UKF
    n, m = len(d.t), len(ds.t)
    first_s, rp_s, times, rp = time_rangeproc(peers.rangeproc_inputs(d, UKF), a.reps)
    fp_s, fp = _timed(peers.filterpy_ukf_run, d, reps=a.peer_reps)
    fp_redraw_s, fp_redraw = _timed(peers.filterpy_ukf_run, d, True)
    rp_head = peers.rangeproc_estimates(
        peers.rangeproc_kernel(peers.rangeproc_inputs(ds, UKF)))
    ss_in = peers.stonesoup_inputs(ds)
    ss_s, ss = _timed(peers.stonesoup_ukf_run, ss_in, reps=a.peer_reps)
    ss_lin = peers.stonesoup_ukf_linear_mean(ss_in)
    us = {"rangeproc": rp_s / n * 1e6, "filterpy": fp_s / n * 1e6,
          "filterpy_redraw": fp_redraw_s / n * 1e6, "stonesoup": ss_s / m * 1e6}
    return {
        "rows": n, "stonesoup_rows": m, "alpha_beta_kappa": peers.UKF_PARAMS.tolist(),
        "rangeproc_first_call_s": first_s, "rangeproc_times_s": times,
        "filterpy_s": fp_s, "filterpy_redraw_s": fp_redraw_s, "stonesoup_s": ss_s,
        "us_per_meas": us,
        "ratio_filterpy": us["filterpy"] / us["rangeproc"],
        "ratio_stonesoup": us["stonesoup"] / us["rangeproc"],
        "filterpy_redraw_vs_shipped_m": float(max(np.abs(fp.xf - fp_redraw.xf).max(),
                                                  np.abs(fp.xs - fp_redraw.xs).max())),
        "agreement": {"filterpy": peers.agreement(rp, fp),
                      "filterpy_redraw": peers.agreement(rp, fp_redraw),
                      "stonesoup": peers.agreement(rp_head, ss),
                      "stonesoup_linear_angle_mean": peers.agreement(rp_head, ss_lin),
                      "rangeproc_ekf": peers.agreement(rp, rp_ekf)},
    }


# ------------------------------------------------------------------------------ pipeline
def probe_rows(seed: int, duration: float) -> int:
    """Rows (all six sensors) the simulator writes for this sortie at rate scale 1, counted
    from the noise-free columns without writing files (~0.3 s for an hour)."""
    from rangeproc.simulate.scenario import SENSOR_IDS, build_columns, draw_scenario
    sc = draw_scenario(seed, duration)
    return sum(build_columns(sc, sid, noise=False)["time"].size for sid in SENSOR_IDS)


def choose_rate_scale(a: argparse.Namespace) -> tuple[float, int | None]:
    """(sample-rate scale, rows of the scale-1 probe or None): ``--rate-scale`` if given, else
    ``--rows`` / probe rows (rows are linear in the scale) rounded to 3 significant digits so
    the cache key is stable; 1.0 when neither is set (``--quick``)."""
    if a.rate_scale is not None:
        return a.rate_scale, None
    if a.rows is None:
        return 1.0, None
    base = probe_rows(a.seed, a.duration)
    scale = float(f"{a.rows / base:.3g}")
    if not 0.0 < scale <= 20.0:
        sys.exit(f"bench: --rows {a.rows:_} needs rate scale {scale:g} on this {a.duration:g} s "
                 f"sortie ({base:_} rows at scale 1); the simulator allows (0, 20]")
    return scale, base


def file_rows(folder: Path) -> dict[str, int]:
    """Data rows of each sensor file in a sortie folder (CSV lines minus the header; the
    truth files truth.csv, truth_association.csv left out)."""
    import pyarrow.parquet as pq
    rows = {}
    for f in sorted(folder.iterdir()):
        if f.suffix == ".parquet":
            rows[f.stem] = pq.ParquetFile(f).metadata.num_rows
        elif f.suffix == ".csv" and not f.name.startswith("truth"):
            with open(f, "rb") as fh:
                rows[f.stem] = sum(chunk.count(b"\n") for chunk in iter(
                    functools.partial(fh.read, 1 << 24), b"")) - 1
    return rows


def scenario(seed: int, duration: float, rate_scale: float = 1.0, objects: str | None = None
             ) -> tuple[Path, float | None]:
    """Simulated sortie in bench/data/, reused when its stamp matches; (config, simulate s).
    ``objects``: a multi-object kind (``rangeproc simulate --objects``) instead of the
    single-object sortie (rate_scale must then be 1)."""
    src = hashlib.sha256()
    for f in sorted((ROOT / "rangeproc" / "simulate").glob("*.py")):
        src.update(f.read_bytes())
    stamp = {"seed": seed, "duration": duration, "rate_scale": rate_scale, "sensors": "all",
             "simulator_sha256": src.hexdigest()}
    if objects is not None:
        stamp["objects"] = objects
    scaled = "" if rate_scale == 1.0 else f"_x{rate_scale:g}"
    folder = BENCH / "data" / f"{objects or 'sortie'}_seed{seed}_{duration:g}s{scaled}"
    cfg, stamp_file = folder / "scenario.toml", folder / "stamp.json"
    if cfg.exists() and stamp_file.exists() and json.loads(stamp_file.read_text()) == stamp:
        return cfg, None
    t0 = time.perf_counter()
    if objects is not None:
        from rangeproc.simulate import simulate_multi
        shutil.rmtree(folder, ignore_errors=True)  # a stale sensor file would be read too
        cfg = simulate_multi(folder, kind=objects, seed=seed, duration=duration)
    else:
        from rangeproc.simulate import simulate_scenario
        cfg = simulate_scenario(folder, seed=seed, duration=duration, rate_scale=rate_scale)
    stamp_file.write_text(json.dumps(stamp))
    return cfg, time.perf_counter() - t0


def peak_rss_bytes() -> int:
    """Peak resident memory of this process image. Linux: VmHWM of /proc/self/status, which
    starts afresh at exec; ``ru_maxrss`` would also count the parent's peak (Linux carries it
    across fork + exec), so it is only the fallback (KiB on Linux, bytes on macOS)."""
    got = rss_and_peak()
    if got is not None:
        return got[1]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def pipeline_child(config: Path, json_out: Path) -> None:
    """Runs inside the fresh subprocess: import, run the pipeline, record time and memory."""
    t0 = time.perf_counter()
    from rangeproc.pipeline import run
    from rangeproc.progress import StageClock
    import_s = time.perf_counter() - t0
    base = peak_rss_bytes()
    where = Breakdown()
    where.wrap_fuse_parts()
    t0 = time.perf_counter()
    out = run(config, clock=StageClock(display=where))
    run_s = time.perf_counter() - t0
    peak = where.peak_rss() or peak_rss_bytes()
    sensors = out.summary["sensors"]
    rows = {sid: int(s.get("n_read", s["n_rows"])) for sid, s in sensors.items()}
    json_out.write_text(json.dumps({
        "import_s": import_s, "run_s": run_s, "stages_s": out.timings,
        "breakdown": where.records(), "unattributed_s": remainders(where.records()),
        "rows": rows,
        "target_rows": sum(r for sid, r in rows.items() if sensors[sid]["kind"] != "ins"),
        "baseline_rss_bytes": base, "peak_rss_bytes": peak}))


def _pipeline_subprocess(cfg: Path, json_out: Path) -> tuple[float, dict]:
    """Run :func:`pipeline_child` in a fresh interpreter; (wall s from spawn to exit, record)."""
    t0 = time.perf_counter()
    code = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--pipeline-only",
                           str(cfg), "--json-out", str(json_out)], cwd=ROOT).returncode
    wall = time.perf_counter() - t0
    if code != 0:
        sys.exit(f"bench: the pipeline subprocess failed (exit {code}) on {cfg}; "
                 "its traceback is above")
    record = json.loads(json_out.read_text())
    json_out.unlink()
    return wall, record


def pipeline_bench(a: argparse.Namespace) -> dict:
    """Warm-up run on a 60 s sortie (fills the numba cache, so no compile time is timed),
    then the timed run on the ``--duration`` sortie."""
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder) / "pipeline.json"
        warm_s, _ = _pipeline_subprocess(scenario(a.seed, 60.0)[0], tmp)
        scale, base = choose_rate_scale(a)
        cfg, sim_s = scenario(a.seed, a.duration, scale)
        written = file_rows(cfg.parent)
        print(f"bench: sortie {cfg.parent.name}: rate scale x{scale:g}"
              + (f" ({base:,} rows at x1, target {a.rows:,})" if base else "")
              + f" -> {sum(written.values()):,} rows written", flush=True)
        wall, r = _pipeline_subprocess(cfg, tmp)
    return {"config": str(cfg.relative_to(ROOT)), "duration_s": a.duration,
            "rate_scale": scale, "probe_rows_scale1": base, "target_rows_requested": a.rows,
            **pipeline_record(cfg, written, sim_s, warm_s, wall, r),
            "score": sortie_score(cfg)}


def sortie_score(cfg: Path) -> dict:
    """The timed run's trajectory against the sortie's truth.csv (``rangeproc.evaluate``, in
    this process, not timed): position and velocity RMSE, NEES and its 95 % bounds, 3-sigma
    coverage, so a faster run is seen to be as accurate (the long-sortie decision: within
    5 % of the previous RMSE, NEES within its bounds)."""
    from rangeproc.evaluate import evaluate_run
    metrics = evaluate_run(cfg.parent / "out", cfg.parent / "truth.csv")
    t = next(iter(metrics["targets"].values()))
    return {k: t[k] for k in ("n_epochs", "pos_rmse", "pos_rmse_enu", "vel_rmse",
                              "vel_rmse_enu", "nees_pos_mean", "nees_pos_chi2_95",
                              "inside_3sigma_enu")}


def pipeline_record(cfg: Path, written: dict[str, int], sim_s: float | None, warm_s: float,
                    wall: float, r: dict) -> dict:
    """The figures of one timed pipeline subprocess (``r`` from :func:`pipeline_child`, wall
    s) on the scenario ``cfg``: rows, input size, microseconds per row (run() and process
    wall), memory per row."""
    inputs = [p for p in cfg.parent.iterdir() if p.suffix in (".csv", ".parquet")
              and not p.name.startswith("truth")]
    n = sum(r["rows"].values())
    extra = r["peak_rss_bytes"] - r["baseline_rss_bytes"]
    return {"file_rows": written, "simulate_s": sim_s, "warmup_wall_s": warm_s,
            "process_wall_s": wall, **r,
            "total_rows": n, "input_bytes": sum(p.stat().st_size for p in inputs),
            "us_per_meas_run": r["run_s"] / n * 1e6, "us_per_meas_wall": wall / n * 1e6,
            "us_per_target_row_wall": wall / r["target_rows"] * 1e6,
            "peak_above_baseline_bytes_per_meas": extra / n}


def single_reference(res: dict, previous: Path) -> dict | None:
    """The single-object pipeline figures the several-objects run is compared with: this
    run's (``res["pipeline"]``), else the previous results file's pipeline (or the reference
    that file's own several-objects run used); None when there is none."""
    keys = ("us_per_meas_wall", "us_per_meas_run", "total_rows", "duration_s",
            "process_wall_s", "run_s", "target_rows", "us_per_target_row_wall")
    if "pipeline" in res:
        return {"source": "this run", **{k: res["pipeline"][k] for k in keys}}
    try:
        old = json.loads(previous.read_text())
    except (OSError, ValueError):
        return None
    when = old.get("machine", {}).get("timestamp", "?")
    if "pipeline" in old:
        p = old["pipeline"]
        if "target_rows" in p and "us_per_target_row_wall" not in p:     # older files
            p["us_per_target_row_wall"] = p["process_wall_s"] / p["target_rows"] * 1e6
        return {"source": f"{previous.name} of {when}", **{k: p[k] for k in keys if k in p}}
    ref = old.get("multi", {}).get("single_object_reference")
    return dict(ref) if ref else None


def multi_bench(a: argparse.Namespace, reference: dict | None) -> dict:
    """Several objects at scale: warm-up on a 60 s ``scale`` scenario (its tracking code is
    compiled too), the timed pipeline subprocess on the ``--multi-duration`` one, then the
    multi-object score against truth.csv (in this process, not timed with the run)."""
    from rangeproc.evaluate import evaluate_run
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder) / "pipeline.json"
        warm_s, _ = _pipeline_subprocess(scenario(a.seed, 60.0, objects=MULTI_KIND)[0], tmp)
        cfg, sim_s = scenario(a.seed, a.multi_duration, objects=MULTI_KIND)
        written = file_rows(cfg.parent)
        sim = "reused" if sim_s is None else f"simulated in {sim_s:.1f} s"
        print(f"bench: several objects {cfg.parent.name} ({sim}) -> "
              f"{sum(written.values()):,} rows written", flush=True)
        wall, r = _pipeline_subprocess(cfg, tmp)
        # context: one object over the same 30 minutes at the simulator's own rates (about
        # as many rows), so the same fixed costs per run (imports, report figures)
        one, one_sim = scenario(a.seed, a.multi_duration, 1.0)
        one_wall, one_r = _pipeline_subprocess(one, tmp)
        same_length = {"config": str(one.relative_to(ROOT)), "duration_s": a.multi_duration,
                       **pipeline_record(one, file_rows(one.parent), one_sim, 0.0, one_wall,
                                         one_r)}
    rec = {"config": str(cfg.relative_to(ROOT)), "kind": MULTI_KIND,
           "duration_s": a.multi_duration, "rate_scale": 1.0,
           **pipeline_record(cfg, written, sim_s, warm_s, wall, r)}
    rec["same_length_single"] = {k: same_length[k] for k in (
        "config", "duration_s", "total_rows", "process_wall_s", "run_s", "us_per_meas_wall",
        "us_per_meas_run")}
    rec["ratio_wall_same_length"] = (rec["us_per_meas_wall"]
                                     / same_length["us_per_meas_wall"])
    t0 = time.perf_counter()
    metrics = evaluate_run(cfg.parent / "out", cfg.parent / "truth.csv", cutoff=MULTI_CUTOFF_M)
    rec["evaluate_s"] = time.perf_counter() - t0
    multi = metrics["multi"]
    rec["score"] = {k: multi[k] for k in ("cutoff_m", "n_epochs", "gospa", "truth", "fused",
                                          "totals")}
    rec["single_object_reference"] = reference
    if reference:
        rec["ratio_wall"] = rec["us_per_meas_wall"] / reference["us_per_meas_wall"]
        if "us_per_target_row_wall" in reference:
            rec["ratio_wall_target"] = (rec["us_per_target_row_wall"]
                                        / reference["us_per_target_row_wall"])
        rec["ratio_run"] = rec["us_per_meas_run"] / reference["us_per_meas_run"]
    return rec


# ------------------------------------------------------------------------------- output
def machine() -> dict:
    import numba
    info = {"platform": platform.platform(), "machine": platform.machine(),
            "processor": platform.processor(), "cpu_count": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__,
            "numba": numba.__version__,
            "timestamp": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")}
    for mod in ("filterpy", "stonesoup"):
        try:
            info[mod] = __import__(mod).__version__
        except ImportError:
            info[mod] = None
    try:
        git = ["git", "-C", str(ROOT)]
        commit = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run(git + ["status", "--porcelain"], capture_output=True,
                               text=True, check=True).stdout.strip()
        info["git_commit"] = commit + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        info["git_commit"] = None
    return info


def _ok(flag: bool) -> str:
    return "PASS" if flag else "FAIL"


def print_table(rows: list) -> None:
    """One kernel table: (name, rows, us/meas, ratio or None, agreement dict or None) each."""
    print(f"{'implementation':<36}{'rows':>7}{'us/meas':>11}{'x rangeproc':>13}"
          f"{'|dx| smoothed (m)':>19}{'relative':>10}")
    for name, n, u, ratio, a in rows:
        tail = (f"{ratio:12.1f}x{a['smoothed_pos_abs_m']:19.2e}{a['smoothed_pos_rel']:10.1e}"
                if a else f"{'1.0x':>13}{'-':>19}{'-':>10}")
        print(f"{name:<36}{n:>7}{u:11.2f}{tail}")


def print_agreement(ag: dict, peers_: tuple[str, ...], width: int) -> None:
    """One line per peer: filtered/smoothed position and sigma agreement with rangeproc."""
    for peer in peers_:
        a = ag[peer]
        print(f"agreement vs {peer:<{width}} filtered {a['filtered_pos_abs_m']:.2e} m "
              f"(rel {a['filtered_pos_rel']:.1e}), smoothed {a['smoothed_pos_abs_m']:.2e} m "
              f"(rel {a['smoothed_pos_rel']:.1e}), smoothed sigma rel "
              f"{a['smoothed_sigma_rel']:.1e}")


def print_kernel(k: dict) -> None:
    us, ag = k["us_per_meas"], k["agreement"]
    print(f"\nKernel: CA EKF + RTS smoother, one radar (range/azimuth/elevation), "
          f"dt = {k['dt_s']} s, q = {k['q']} m^2/s^5")
    rows = [("rangeproc (numba)", k["rows"], us["rangeproc"], None, None),
            ("FilterPy EKF + rts_smoother", k["rows"], us["filterpy"], k["ratio_filterpy"],
             ag["filterpy"]),
            ("Stone Soup EKF+smoother, analytic H", k["stonesoup_rows"], us["stonesoup"],
             k["ratio_stonesoup"], ag["stonesoup"]),
            ("  same, stock finite-difference H", k["stonesoup_rows"], us["stonesoup_stock"],
             k["ratio_stonesoup_stock"], ag["stonesoup_stock"])]
    print_table(rows)
    print_agreement(ag, ("filterpy", "stonesoup", "stonesoup_stock"), 16)
    mc = k["stonesoup_model_check"]
    print(f"Stone Soup models vs rangeproc: max|dF| {mc['F']:.1e}, max|dQ| {mc['Q']:.1e} "
          f"(ConstantAcceleration noise_diff_coeff = q is the same white-jerk Q), "
          f"max|dh| {mc['h']:.1e} (fed [E, pi/2 - A, R])")
    print("The stock Stone Soup row differs for a known reason: stonesoup.functions.jacobian "
          "steps 1e8*spacing(x), and np.spacing is negative for negative x, so those steps "
          "are floored to 1e-8 m and the Jacobian carries ~1e-4 relative round-off; the "
          "headline row gives it the analytic Jacobian (same maths as rangeproc/FilterPy).")
    print(f"rangeproc compile (empty numba cache, fresh process): import "
          f"{k['rangeproc_cold_import_s']:.2f} s + first call "
          f"{k['rangeproc_cold_first_call_s']:.2f} s; with the cache: first call "
          f"{k['rangeproc_first_call_s']:.3f} s; then median of {len(k['rangeproc_times_s'])}"
          f" calls: {us['rangeproc']:.2f} us/meas")
    if "ukf" in k:
        print_ukf(k["ukf"])
    if "filters" in k:
        print("\nKernel, one row per further filter (same rows, filter + RTS smoother; no peer "
              "library offers these):")
        for name, f in k["filters"].items():
            print(f"  {name:<12} {f['us_per_meas']:6.2f} us/meas  {f['ratio_to_ekf']:.2f}x the "
                  "EKF row")


def print_ukf(u: dict) -> None:
    us, ag = u["us_per_meas"], u["agreement"]
    al, be, ka = u["alpha_beta_kappa"]
    print(f"\nKernel, UKF row: same data, unscented update (alpha {al:g}, beta {be:g}, "
          f"kappa {ka:g}: lambda = alpha^2 (n + kappa) - n in all three) + smoother")
    rows = [("rangeproc UKF + RTS (numba)", u["rows"], us["rangeproc"], None, None),
            ("FilterPy UKF + rts_smoother", u["rows"], us["filterpy"], u["ratio_filterpy"],
             ag["filterpy"]),
            ("Stone Soup UKF + UKF smoother", u["stonesoup_rows"], us["stonesoup"],
             u["ratio_stonesoup"], ag["stonesoup"])]
    print_table(rows)
    print_agreement(ag, ("filterpy", "filterpy_redraw", "stonesoup",
                         "stonesoup_linear_angle_mean"), 28)
    same = u["filterpy_redraw_vs_shipped_m"]
    print(f"FilterPy as shipped vs with sigma points redrawn from the predicted moments before "
          f"each update (as rangeproc): max|dx| {same:.1e} m"
          + (" -- identical: this FilterPy's predict() already redraws them (1.4.x reused the"
             " points propagated through fx, which do not carry Q)" if same == 0.0 else
             " -- they differ only because the shipped update reuses the propagated points")
          + f"; redraw variant {us['filterpy_redraw']:.0f} us/meas (timed once). Both draw the "
          "first row's points from the prior (FilterPy's constructor leaves them zero).")
    print("Stone Soup averages angles circularly (atan2 of weighted sines and cosines) where "
          "rangeproc and FilterPy here average the azimuths unwrapped around the central "
          "point; with rangeproc's mean patched in (stonesoup_linear_angle_mean, untimed) the "
          "same Stone Soup code agrees to round-off, so the Stone Soup row's difference is "
          "that choice, largest while P0 is wide.")
    e = ag["rangeproc_ekf"]
    print(f"rangeproc UKF vs its EKF on these rows: filtered {e['filtered_pos_abs_m']:.2e} m, "
          f"smoothed {e['smoothed_pos_abs_m']:.2e} m (how far the two updates differ on this "
          f"geometry, not an error measure); "
          f"UKF first call {u['rangeproc_first_call_s']:.3f} s, then median of "
          f"{len(u['rangeproc_times_s'])} calls: {us['rangeproc']:.2f} us/meas")


def print_pipeline(p: dict, title: str = "Pipeline") -> None:
    sim = "reused" if p["simulate_s"] is None else f"simulated in {p['simulate_s']:.1f} s"
    rows = ", ".join(f"{k} {v:,}" for k, v in p["rows"].items())
    what = "scenario" if "kind" in p else "sortie"
    print(f"\n{title}: {p['config']} ({p['duration_s']:g} s {what} at x{p['rate_scale']:g} "
          f"sample rates, {sim}; warm-up run "
          f"{p['warmup_wall_s']:.1f} s)")
    print(f"rows read {p['total_rows']:,} ({rows}); target measurement rows (non-INS) "
          f"{p['target_rows']:,}; input files {p['input_bytes'] / 1e6:.1f} MB")
    print("where the time and memory go (RSS at the stage's or part's start, its peak, at "
          "its end):")
    print_breakdown(p["breakdown"], sum(p["stages_s"].values()))
    print(f"{'run() total':<22}{p['run_s']:9.2f}   ({p['us_per_meas_run']:.2f} us/meas)")
    print(f"{'imports':<22}{p['import_s']:9.2f}")
    print(f"{'process wall':<22}{p['process_wall_s']:9.2f}   ({p['us_per_meas_wall']:.2f} us/meas;"
          f" interpreter start to exit, as `rangeproc run`)")
    print(f"peak RSS {p['peak_rss_bytes'] / 2**20:.0f} MiB (after imports "
          f"{p['baseline_rss_bytes'] / 2**20:.0f} MiB; "
          f"{p['peak_above_baseline_bytes_per_meas']:.0f} B per row above that)")
    sc = p.get("score")
    if sc and "pos_rmse" in sc:         # (the several-objects record's score is its own)
        lo, hi = sc["nees_pos_chi2_95"]
        print(f"against truth.csv: position RMSE {sc['pos_rmse']:.3f} m, velocity RMSE "
              f"{sc['vel_rmse']:.4f} m/s, NEES {sc['nees_pos_mean']:.2f} (95 % bounds "
              f"{lo:.2f} to {hi:.2f}), inside 3 sigma "
              + "/".join(f"{v:.3f}" for v in sc["inside_3sigma_enu"]) + " (E/N/U)")


def multi_ratio_line(m: dict) -> str:
    """'rows, wall, us/row vs the single-object run's us/row = ratio' of the several-objects
    record ``m`` (no ratio when there is no single-object reference)."""
    ref = m.get("single_object_reference")
    head = (f"{m['total_rows']:,} rows, wall {m['process_wall_s']:.1f} s, "
            f"{m['us_per_meas_wall']:.1f} us/row")
    if not ref:
        return head + "; no single-object pipeline figure to compare with (run without " \
                      "--skip-pipeline once)"
    line = (head + f" vs single object {ref['us_per_meas_wall']:.1f} us/row "
            f"({ref['total_rows']:,} rows, {ref['duration_s']:g} s sortie, {ref['source']}): "
            f"{m['ratio_wall']:.2f}x")
    if "ratio_wall_target" in m:
        line += (f"; per measurement row of the objects (the sortie's "
                 f"{ref['total_rows'] - ref['target_rows']:,} INS attitude rows left out of its "
                 f"count): {m['us_per_target_row_wall']:.1f} vs "
                 f"{ref['us_per_target_row_wall']:.1f} us/row = {m['ratio_wall_target']:.2f}x")
    return line


def print_multi(m: dict) -> None:
    """The several-objects run: the pipeline table, the ratio line, the multi-object score."""
    from rangeproc.evaluate.multi import format_multi
    print_pipeline(m, f"Several objects ({m['kind']})")
    print(f"per row: {multi_ratio_line(m)}"
          + (f"; run() alone {m['us_per_meas_run']:.1f} vs "
             f"{m['single_object_reference']['us_per_meas_run']:.1f} us/row = "
             f"{m['ratio_run']:.2f}x" if m.get("single_object_reference") else ""))
    one = m.get("same_length_single")
    if one:
        print(f"context: one object over the same {one['duration_s']:g} s at x1 rates "
              f"({one['total_rows']:,} rows, wall {one['process_wall_s']:.1f} s): "
              f"{one['us_per_meas_wall']:.1f} us/row, so several objects cost "
              f"{m['ratio_wall_same_length']:.2f}x per row of a run of that length "
              "(the acceptance line uses the 2 M-row sortie, the stricter reference)")
    print(f"Score against truth.csv (rangeproc.evaluate, {m['evaluate_s']:.1f} s; RMSE of the "
          "best-matching output object):")
    print(format_multi(m["score"]))


#: Issue figures of the further filters: (name, ratio key, the row it is relative to, limit
#: or None when the issue sets none).
FILTER_TARGETS = (("stukf", "ratio_to_base", "the UKF row", 2.0),
                  ("sage-husa", "ratio_to_ekf", "the EKF row", 2.0),
                  ("imm", "ratio_to_ekf", "the EKF row", 4.0),
                  ("askf", "ratio_to_ekf", "the EKF row", None),
                  ("spline", "ratio_to_ekf", "the EKF row", None))


def print_acceptance(res: dict) -> None:
    print("\nAcceptance (issue figures)")
    k, p = res.get("kernel"), res.get("pipeline")
    if k:
        us = k["us_per_meas"]["rangeproc"]
        worst = max(k["agreement"][x]["smoothed_pos_rel"] for x in ("filterpy", "stonesoup"))
        worst = max(worst, *(k["agreement"][x]["filtered_pos_rel"]
                             for x in ("filterpy", "stonesoup")))
        print(f"  kernel <= {TARGET_US} us/meas: {us:.2f}  {_ok(us <= TARGET_US)}")
        print(f"  >= {TARGET_FP:g}x FilterPy: {k['ratio_filterpy']:.1f}x  "
              f"{_ok(k['ratio_filterpy'] >= TARGET_FP)}")
        print(f"  >= {TARGET_SS:g}x Stone Soup: {k['ratio_stonesoup']:.0f}x  "
              f"{_ok(k['ratio_stonesoup'] >= TARGET_SS)} (identical maths; "
              f"{k['ratio_stonesoup_stock']:.0f}x vs its stock finite-difference Jacobian)")
        print(f"  agreement <= {TARGET_AGREE:g} (relative position): {worst:.1e}  "
              f"{_ok(worst <= TARGET_AGREE)}")
    if k and "ukf" in k:
        u = k["ukf"]
        uus = u["us_per_meas"]["rangeproc"]
        ua = u["agreement"]["filterpy"]
        uworst = max(ua["filtered_pos_rel"], ua["smoothed_pos_rel"])
        print(f"  UKF + unscented smoother <= {TARGET_UKF_US:g} us/meas: {uus:.2f}  "
              f"{_ok(uus <= TARGET_UKF_US)}")
        print(f"  UKF >= {TARGET_UKF_FP:g}x FilterPy: {u['ratio_filterpy']:.0f}x  "
              f"{_ok(u['ratio_filterpy'] >= TARGET_UKF_FP)} ({u['ratio_stonesoup']:.0f}x "
              f"Stone Soup)")
        print(f"  UKF agreement with FilterPy <= {TARGET_AGREE:g} (relative position; not an "
              f"issue figure): {uworst:.1e}  {_ok(uworst <= TARGET_AGREE)}")
    f = k.get("filters", {}) if k else {}
    for name, ratio, base, limit in FILTER_TARGETS:
        if name in f:
            r = f[name][ratio]
            label = f"  {name}" + (f" ({len(f[name]['models'])} models)" if name == "imm" else "")
            print(f"{label} <= {limit:g}x {base}: {r:.2f}x  {_ok(r <= limit)}" if limit else
                  f"{label}: {r:.2f}x {base} (no issue figure)")
    if p:
        full = p["duration_s"] >= 3600.0
        tag = (lambda f: _ok(f)) if full else (lambda f: "n/a (not the one-hour sortie)")
        print(f"  end to end < {TARGET_WALL_S:g} s: {p['process_wall_s']:.1f} s  "
              f"{tag(p['process_wall_s'] < TARGET_WALL_S)}")
        print(f"  peak memory < {TARGET_PEAK_GB:g} GB: {p['peak_rss_bytes'] / 1e9:.2f} GB  "
              f"{tag(p['peak_rss_bytes'] < TARGET_PEAK_GB * 1e9)}")
        print(f"  ~{TARGET_ROWS / 1e6:g} M measurements per hour: "
              f"{p['total_rows'] / p['duration_s'] * 3600 / 1e6:.2f} M/h "
              f"{_ok(p['total_rows'] / p['duration_s'] * 3600 >= 0.9 * TARGET_ROWS)}"
              f" (sample rates x{p['rate_scale']:g})")
    m = res.get("multi")
    if m:
        full = m["duration_s"] >= MULTI_DURATION_S
        ratio = m.get("ratio_wall_target", m.get("ratio_wall"))
        verdict = ("n/a" if ratio is None else
                   _ok(ratio < TARGET_MULTI_RATIO) if full else
                   f"n/a (not the {MULTI_DURATION_S:g} s scenario)")
        tot = m["score"]["totals"]
        print(f"  several objects ({m['kind']}, {m['duration_s']:g} s, "
              f"{tot['n_truth']} objects) < {TARGET_MULTI_RATIO:g}x the single-object us per "
              "measurement row (verdict on the objects' measurement rows; INS attitude rows "
              "are not measurements of an object): "
              f"{multi_ratio_line(m)}  {verdict}")
        g = m["score"]["gospa"]["mean"]
        print(f"    (score: GOSPA mean {g:.2f} m, coverage mean {tot['coverage_mean']:.3f}, "
              f"{tot['swaps']} swaps, {tot['n_fused']} output objects; no issue figure)"
              if g is not None else "    (score: no epochs)")


def print_previous(path: Path, res: dict) -> None:
    """Headline numbers of the previous results file, for comparison over time."""
    if not path.exists():
        return
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    when = old.get("machine", {}).get("timestamp", "?")
    parts = []
    if "kernel" in old and "kernel" in res:
        parts.append(f"kernel {old['kernel']['us_per_meas']['rangeproc']:.2f} -> "
                     f"{res['kernel']['us_per_meas']['rangeproc']:.2f} us/meas")
        if "ukf" in old["kernel"] and "ukf" in res["kernel"]:
            parts.append(f"UKF kernel {old['kernel']['ukf']['us_per_meas']['rangeproc']:.2f} -> "
                         f"{res['kernel']['ukf']['us_per_meas']['rangeproc']:.2f} us/meas")
    if "pipeline" in old and "pipeline" in res:
        parts.append(f"pipeline wall {old['pipeline']['process_wall_s']:.1f} -> "
                     f"{res['pipeline']['process_wall_s']:.1f} s "
                     f"({old['pipeline']['duration_s']:g} -> {res['pipeline']['duration_s']:g}"
                     " s sortie)")
        was, now = old["pipeline"].get("score"), res["pipeline"].get("score")
        if was and now:
            parts.append(f"its position RMSE {was['pos_rmse']:.3f} -> {now['pos_rmse']:.3f} m,"
                         f" velocity {was['vel_rmse']:.4f} -> {now['vel_rmse']:.4f} m/s")
    if "multi" in old and "multi" in res:
        parts.append(f"several objects {old['multi']['us_per_meas_wall']:.1f} -> "
                     f"{res['multi']['us_per_meas_wall']:.1f} us/row "
                     f"({old['multi']['duration_s']:g} -> {res['multi']['duration_s']:g} s)")
    if parts:
        print(f"\nvs previous {path.name} ({when}): " + "; ".join(parts))


def main(argv: list[str] | None = None) -> None:
    a = parse_args(argv)
    if a.pipeline_only:
        pipeline_child(a.pipeline_only, a.json_out)
        from rangeproc.cli import leave
        leave(0)                    # as the `rangeproc` command ends (no interpreter teardown)
    if a.first_call_only:
        first_call_child(a.kernel_steps)
        return
    res: dict = {"machine": machine(), "params": {
        "quick": a.quick, "seed": a.seed, "duration_s": a.duration, "rows": a.rows,
        "rate_scale": a.rate_scale, "multi_duration_s": a.multi_duration,
        "kernel_steps": a.kernel_steps, "stonesoup_steps": a.stonesoup_steps, "reps": a.reps,
        "peer_reps": a.peer_reps}}
    if not a.skip_kernel:
        res["kernel"] = kernel_bench(a)
        print_kernel(res["kernel"])
    if not a.skip_pipeline:
        res["pipeline"] = pipeline_bench(a)
        print_pipeline(res["pipeline"])
    if not a.skip_multi:
        res["multi"] = multi_bench(a, single_reference(res, a.out))
        print_multi(res["multi"])
    print_acceptance(res)
    print_previous(a.out, res)
    res = {"meta": run_meta(peers=("filterpy", "stonesoup")), **res}
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(res, indent=2) + "\n")
    print(f"\nwrote {a.out.relative_to(ROOT) if a.out.is_relative_to(ROOT) else a.out}")


if __name__ == "__main__":
    main()
