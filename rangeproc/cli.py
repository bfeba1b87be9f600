"""Command-line interface: a thin click layer over the library.

Each command parses options, calls one library function and turns library errors into exit
codes: 2 for unusable input or config (one line on stderr naming the file and the row, column
or key), 3 for a numerical failure, 5 for an output that cannot be written (a full disk, a
read-only or not writable folder: one line naming the path and the cause), 1 for anything
unexpected.
"""
from __future__ import annotations

import contextlib
import functools
import logging
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NoReturn

import click

from rangeproc import __version__
from rangeproc.errors import (ConfigError, DataError, NumericalError, OutputError,
                              RangeprocError, write_failure)
from rangeproc.run_warnings import NOTE

EXIT_INPUT = 2
EXIT_NUMERICAL = 3
EXIT_OUTPUT = 5          # an output could not be written (disk full, read-only, not permitted)
EXIT_INTERNAL = 1


def _fail(message: str, code: int) -> None:
    click.echo(f"rangeproc: error: {message}".replace("\n", " "), err=True)
    sys.exit(code)


class DeferredLog(logging.Handler):
    """Holds the library's log lines until the command ends: they are written to stderr after
    a success and dropped after a failure, so that a failed command's stderr is exactly its one
    error line (the error says what failed; ``--debug`` streams every line as it comes)."""

    def __init__(self) -> None:
        super().__init__(NOTE)
        self.setFormatter(logging.Formatter("rangeproc: %(levelname)s: %(message)s"))
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))

    def settle(self, success: bool) -> None:
        """Write the held lines (success) or drop them (failure)."""
        lines, self.lines = self.lines, []
        if success:
            for line in lines:
                click.echo(line, err=True)


def _settle_log(success: bool) -> None:
    for handler in logging.getLogger().handlers:
        if isinstance(handler, DeferredLog):
            handler.settle(success)


def library_errors(func: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator: map rangeproc exceptions to one-line messages and exit codes."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            result = func(*args, **kwargs)
            _settle_log(True)
            return result
        except BaseException:
            _settle_log(False)
            raise

    @functools.wraps(func)
    def mapped(*args: Any, **kwargs: Any) -> Any:
        try:
            return wrapper(*args, **kwargs)
        except (ConfigError, DataError) as exc:
            _fail(str(exc), EXIT_INPUT)
        except NumericalError as exc:
            _fail(str(exc), EXIT_NUMERICAL)
        except OutputError as exc:
            _fail(str(exc), EXIT_OUTPUT)
        except RangeprocError as exc:
            _fail(str(exc), EXIT_INTERNAL)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        except Exception as exc:
            failure = write_failure(exc, getattr(exc, "filename", None) or "the outputs")
            if failure is not None:        # an OS failure to write that no writer named
                _fail(str(failure), EXIT_OUTPUT)
            if logging.getLogger().isEnabledFor(logging.DEBUG):
                raise
            _fail(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for the "
                  "traceback)", EXIT_INTERNAL)

    return mapped


class DebugStream(logging.StreamHandler):  # type: ignore[type-arg]
    """``--debug``: every log line streamed to stderr as it comes."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)
        self.setFormatter(logging.Formatter("rangeproc: %(levelname)s: %(message)s"))


def configure_logging(debug: bool) -> None:
    """Debug: every line to stderr as it comes (:class:`DebugStream`), level DEBUG; else
    WARNING lines and notes (``run_warnings.NOTE``) held by a :class:`DeferredLog`. Replaces
    the handlers a previous call (an earlier in-process invocation, or the group before its
    command's ``--debug``) added."""
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, (DeferredLog, DebugStream))]:
        root.removeHandler(handler)
    if debug:
        root.setLevel(logging.DEBUG)
        root.addHandler(DebugStream())
    else:
        root.setLevel(NOTE)
        root.addHandler(DeferredLog())
    for noisy in ("numba", "matplotlib", "PIL"):
        logging.getLogger(noisy).setLevel(logging.WARNING)


def debug_option(func: Callable[..., Any]) -> Callable[..., Any]:
    """Shared ``--debug`` of every command, so that ``rangeproc COMMAND ... --debug`` works as
    ``rangeproc --debug COMMAND ...`` does (the group's own ``--debug`` stays)."""
    def turn_on(ctx: click.Context, param: click.Parameter, value: bool) -> None:
        if value:
            configure_logging(True)

    return click.option("--debug", is_flag=True, expose_value=False, callback=turn_on,
                        help="Verbose logging and full tracebacks (as rangeproc --debug).")(func)


def quiet_option(func: Callable[..., Any]) -> Callable[..., Any]:
    """Shared ``--quiet`` option: no progress output."""
    return click.option("--quiet", "-q", is_flag=True,
                        help="No progress output and no first-run compiling notice (progress "
                             "bars are also left out when stderr is not a terminal).")(
        func)


class TerminalBars:
    """One progress bar per pipeline stage on stderr (used only on a terminal)."""

    WIDTH = 28

    def __init__(self) -> None:
        self._total = 1
        self._done = 0

    def _draw(self, stage: str, note: str, end: str = "") -> None:
        frac = min(1.0, self._done / max(self._total, 1))
        fill = int(round(frac * self.WIDTH))
        bar = "#" * fill + "-" * (self.WIDTH - fill)
        click.echo(f"\r{stage:<9}[{bar}] {self._done}/{self._total} {note:<24}", err=True,
                   nl=False)
        if end:
            click.echo(end, err=True, nl=False)

    def start(self, stage: str, total: int) -> None:
        self._total, self._done = max(total, 1), 0
        self._draw(stage, "")

    def advance(self, stage: str, n: int = 1, note: str = "") -> None:
        self._done += n
        self._draw(stage, note)

    def finish(self, stage: str, seconds: float) -> None:
        self._done = self._total
        self._draw(stage, f"{seconds:.2f} s", end="\n")


def _clock(quiet: bool) -> Any:
    """The run's stage clock: progress bars on a terminal, silent under ``--quiet`` or when
    stderr is no terminal."""
    from rangeproc.progress import StageClock

    if quiet or not sys.stderr.isatty():
        return StageClock()
    return StageClock(display=TerminalBars())


@contextlib.contextmanager
def compile_notice(quiet: bool) -> Iterator[None]:
    """While the command runs: one line on stderr the first time a kernel is compiled rather
    than loaded (the first run of an installation waits a minute or more for it), whatever
    stderr is (a terminal, a pipe under make or CI, a notebook's capture); on a terminal it
    first clears the progress bar's line. Nothing under ``--quiet``."""
    if quiet:
        yield
        return
    from rangeproc.kernel_cache import compilation_announced

    clear = "\r\033[K" if sys.stderr.isatty() else ""
    with compilation_announced(lambda line: click.echo(f"{clear}rangeproc: {line}", err=True)):
        yield


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="rangeproc")
@click.option("--debug", is_flag=True, help="Verbose logging and full tracebacks.")
def main(debug: bool) -> None:
    """rangeproc: fuse flight-test range tracking logs into best-estimate trajectories.

    Reads per-sensor logs (radar, theodolite, GPS, MISTRAM, INS) named by a TOML config,
    rejects wild points, stabilises moving-platform measurements, filters and smooths all
    sensors together and writes the fused trajectory per target with its uncertainty.
    """
    configure_logging(debug)


@main.command("run")
@click.argument("config", type=click.Path(path_type=Path))
@quiet_option
@debug_option
@library_errors
def run_cmd(config: Path, quiet: bool) -> None:
    """Process one flight described by CONFIG (TOML, see docs/contract.md).

    Writes fused.parquet, summary.json and report/*.png into the config's [output].dir, then
    (unless --quiet) a headline: each object's epochs, span and 1-sigma position uncertainty,
    the number of warnings and the report page's path.
    Exit status 0 on success, 2 for unusable input or config, 3 for a numerical failure, 5
    when an output cannot be written (one line naming the path and the cause: disk full,
    folder read-only or not permitted; no partial output is left).
    """
    from rangeproc.pipeline import run
    from rangeproc.report.headline import headline

    with compile_notice(quiet):
        out = run(config, clock=_clock(quiet))
    if not quiet:
        click.echo(f"wrote {len(out.written)} files to {out.out_dir}")
        page = next((p for p in out.written if p.name == "index.html"), None)
        for line in headline(out.summary, out.tracks, page):
            click.echo(line)


@main.command("plan")
@click.argument("config", type=click.Path(path_type=Path))
@click.argument("trajectory", type=click.Path(path_type=Path))
@click.option("--seed", type=int, default=1, show_default=True,
              help="Seed of the noise on the planned rows (the prediction hardly depends on it).")
@quiet_option
@debug_option
@library_errors
def plan_cmd(config: Path, trajectory: Path, seed: int, quiet: bool) -> None:
    """Predict the accuracy a planned flight can achieve with CONFIG's sensors.

    TRAJECTORY is the planned track (CSV or Parquet in the truth format of `rangeproc
    evaluate`: time; e, n, u or lat, lon, height; optional ve, vn, vu). Every sensor of
    CONFIG measures it with its site or platform (from its INS file), its sigmas and its rate
    (the file's, `rate_hz`, or the kind's default); the run's own smoother and registration
    estimate it. Writes plan.parquet (predicted 1-sigma position and velocity per output
    epoch, the sensors that carry it, weak geometry), plan.json (the calibration terms the
    flight makes observable) and plan.png into the config's [output] dir.
    """
    from rangeproc.planning.plan import format_plan, run_plan

    with compile_notice(quiet):
        out = run_plan(config, trajectory, seed=seed)
    if not quiet:
        for line in format_plan(out):
            click.echo(line)


@main.command("simulate")
@click.argument("out_dir", type=click.Path(path_type=Path))
@click.option("--seed", type=int, default=1, show_default=True, help="Random seed.")
@click.option("--duration", type=float, default=120.0, show_default=True,
              help="Flight duration (s).")
@click.option("--sensors", default="all", show_default=True,
              help="Comma-separated sensor ids to write (e.g. R1,G1), or 'all'.")
@click.option("--rate-scale", type=float, default=1.0, show_default=True,
              help="Multiplies every sensor's sample rate (0 < x <= 20), e.g. for benchmarks: "
                   "an hour at 1.0 is ~0.64 M rows.")
@click.option("--faults", default="none", show_default=True,
              help="Systematic sensor faults: a preset ('none'; 'registration': R1 range +15 m, "
                   "azimuth/elevation +0.5 mrad, TH1 azimuth +20\", elevation -20\", S1 "
                   "mount_yaw +0.3 deg, latency +0.040 s), or a JSON object / JSON file "
                   "{sensor_id: {name: value}} with the data contract's names, signs and SI "
                   "units. Written to truth_calibration.json.")
@click.option("--objects", "objects", default=None, metavar="KIND",
              help="Several objects instead of one: crossing, formation, lock-jump, "
                   "operator-switch, surveillance, phased-array (plots not in azimuth order: "
                   "each object revisited every 2 s), merged-feed (one plot file of two "
                   "rotating radars at different sites), mixed or scale (the several-objects "
                   "benchmark: 10 objects, SR1, tracking radars R1-R3, GPS on four; e.g. "
                   "--duration 1800) or harbour (a ferry's radar, lidar and cameras among "
                   "boats with extended hulls, a ship leaving a quay, moored boats, quays and "
                   "sea clutter, written like the Autoferry recordings). "
                   "Objects with GPS are declared "
                   "targets, the others are not; also writes truth_association.csv and "
                   "truth_events.json. Not combined with --sensors, --rate-scale, --faults.")
@click.option("--n-objects", type=int, default=None,
              help="With --objects: how many objects (default: drawn within the kind's range; "
                   "scale: 10).")
@click.option("--trajectory", type=click.Path(path_type=Path, exists=True, dir_okay=False),
              default=None, metavar="FILE",
              help="Fly a recorded track (CSV or Parquet in the truth format of `rangeproc "
                   "evaluate`: time; e, n, u or lat, lon, height; optional ve, vn, vu) instead "
                   "of the seed's drawn trajectory: smoothed, its centre placed 25 km from the "
                   "range origin, at most --duration seconds of it. Not with --objects.")
@quiet_option
@debug_option
@library_errors
def simulate_cmd(out_dir: Path, seed: int, duration: float, sensors: str, rate_scale: float,
                 faults: str, objects: str | None, n_objects: int | None,
                 trajectory: Path | None, quiet: bool) -> None:
    """Write a simulated scenario with truth into OUT_DIR.

    A maneuvering aircraft seen by a fixed radar, a theodolite, a ship-borne radar with INS,
    target GPS and MISTRAM stations, with realistic noise, dropouts, bursts and wild points.
    Writes the sensor files, scenario.toml (a contract-only config) and truth.csv (and, with
    --faults, the injected systematic errors as truth_calibration.json). With --trajectory,
    the aircraft flies a recorded track (an ADS-B or GPS log, a planned trajectory). With
    --objects, a multi-object scenario of that kind (tracks that jump, surveillance plots with
    clutter, in azimuth order or not).
    """
    from rangeproc.simulate import resolve_faults, simulate_multi, simulate_scenario

    if objects is None:
        if n_objects is not None:
            raise ConfigError("simulate: --n-objects needs --objects KIND")
        path = simulate_scenario(out_dir, seed=seed, duration=duration, sensors=sensors,
                                 rate_scale=rate_scale, faults=resolve_faults(faults),
                                 trajectory=trajectory)
    else:
        extra = [name for name, given in (("--sensors", sensors != "all"),
                                          ("--rate-scale", rate_scale != 1.0),
                                          ("--trajectory", trajectory is not None),
                                          ("--faults", faults.strip().lower() != "none"))
                 if given]
        if extra:
            raise ConfigError(f"simulate: --objects cannot be combined with {extra[0]}")
        path = simulate_multi(out_dir, kind=objects, seed=seed, duration=duration,
                              n_objects=n_objects)
    if not quiet:
        click.echo(f"wrote scenario {path}")


@main.command("evaluate")
@click.argument("out_dir", type=click.Path(path_type=Path))
@click.argument("truth", type=click.Path(path_type=Path))
@click.option("--cutoff", type=click.FloatRange(min=0.0, min_open=True), default=50.0,
              show_default=True,
              help="Multi-object assignment and GOSPA cutoff distance (m).")
@click.option("--origin", "origin", default=None, metavar="LAT,LON,HEIGHT",
              help="Range origin (WGS-84 degrees, degrees, metres above the ellipsoid) for a "
                   "truth in lat, lon, height; overrides the [range] origin of the run's "
                   "config (named in OUT_DIR/summary.json).")
@debug_option
@library_errors
def evaluate_cmd(out_dir: Path, truth: Path, cutoff: float, origin: str | None) -> None:
    """Compare OUT_DIR/fused.parquet with a TRUTH trajectory (CSV or Parquet).

    Prints position/velocity RMSE, 95th percentiles, the fraction of epochs inside 3 sigma and
    the normalised estimation error squared per target; saves OUT_DIR/evaluation.json.
    With several objects (fused ids need not match truth ids), also assigns fused objects to
    truth objects by position at every epoch (within --cutoff) and prints per truth object the
    best-matching fused object, its RMSE, coverage, identity swaps and fragmentation, and the
    GOSPA metric over time (per-epoch values in OUT_DIR/evaluation_gospa.parquet).

    \b
    TRUTH columns (a header row; other columns are ignored):
      time            float seconds on the fused output's time scale, or
                      ISO-8601 with Z or a UTC offset (read as Unix seconds,
                      as in the sensor files); one form per column
      e, n, u         position in the range ENU frame (m), or
      lat, lon, height  WGS-84 degrees and metres above the ellipsoid,
                      converted with the range origin (--origin, else the
                      run's config); with both, e, n, u is used
      ve, vn, vu      optional velocity (m/s): range ENU with e, n, u, local
                      ENU at the point with lat, lon, height; without them
                      velocity is not evaluated
      target_id       optional; without it the file is one object

    Truth is interpolated linearly to the fused epochs within its time span, never beyond;
    the epochs evaluated and those without truth are counted per target. Exit status 2, with
    one line naming the file, 1-based data row and column, for a bad truth cell; also for a
    geodetic truth without an origin, and for truth and fused times that do not overlap.
    """
    from rangeproc.evaluate import evaluate_run, format_report
    from rangeproc.evaluate.origin import parse_origin
    from rangeproc.io.writers import write_json

    metrics = evaluate_run(out_dir, truth, cutoff=cutoff,
                           series_path=Path(out_dir) / "evaluation_gospa.parquet",
                           origin=parse_origin(origin) if origin is not None else None,
                           require_overlap=True)
    write_json(metrics, Path(out_dir) / "evaluation.json")
    click.echo(format_report(metrics))


EXIT_SORTIES_FAILED = 4


@main.command("campaign")
@click.argument("campaign", type=click.Path(path_type=Path))
@click.option("--scheduler", metavar="ADDRESS", default=None,
              help="Run on an existing Dask cluster (e.g. tcp://10.0.0.5:8786) instead of "
                   "worker processes on this machine.")
@click.option("--workers", type=int, default=None,
              help="Worker processes of the local cluster (default: one per core).")
@click.option("--force", is_flag=True,
              help="Rerun every sortie, also those whose outputs match their inputs.")
@quiet_option
@debug_option
@library_errors
def campaign_cmd(campaign: Path, scheduler: str | None, workers: int | None, force: bool,
                 quiet: bool) -> None:
    """Run every sortie of CAMPAIGN as `rangeproc run` would, in parallel on a Dask cluster.

    CAMPAIGN is a TOML file listing sortie configs ([output] dir = "records", then
    [[sorties]] tables with config = "flights/f101.toml" and an optional id), or a folder:
    every *.toml in it is a sortie (id: the file stem), and so is every sub-folder holding a
    config.toml (id: the sub-folder's name); the folder's records go to FOLDER/campaign.
    Each sortie writes its outputs where its config's [output].dir says.

    A sortie that fails is recorded with its one-line reason and the others go on; a rerun
    skips sorties whose outputs exist and match their config and input hashes. Writes
    campaign.json into the campaign's output folder. Exit status 0 when every sortie is
    done, 4 when some failed, 2 for an unusable campaign file, 5 when the campaign's
    records cannot be written (disk full, folder read-only or not permitted).
    """
    from rangeproc.campaign import load_campaign, run_campaign

    spec = load_campaign(campaign)
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers: must be at least 1, got {workers}")
    clock = _clock(quiet)
    with compile_notice(quiet), clock.stage("campaign", len(spec.sorties)) as tick:
        result = run_campaign(spec, scheduler=scheduler, workers=workers, resume=not force,
                              tick=tick)
    counts = result.counts()
    if not quiet:
        click.echo(f"campaign: {counts['done']} done, {counts['skipped']} skipped (up to "
                   f"date), {counts['failed']} failed in {result.seconds:.1f} s on "
                   f"{result.cluster}; records in {result.out_dir / 'campaign.json'}")
    for o in result.failed:
        click.echo(f"rangeproc: sortie {o.id} failed: {o.reason}", err=True)
    if result.failed:
        sys.exit(EXIT_SORTIES_FAILED)


class ExportCommand(click.Command):
    """``export``: a format name left over as an extra argument (``--format kml czml``) gets
    a hint on how to ask for several formats."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        given = list(args)                        # click's parser consumes ``args``
        try:
            return super().parse_args(ctx, args)
        except click.UsageError as exc:
            if "extra argument" in exc.message and any(
                    a.lower() in ("kml", "czml", "csv", "acmi", "acmi-zip") for a in given):
                exc.message += (" (several formats: --format kml --format czml, or "
                                "--format kml,czml)")
            raise


@main.command("export", cls=ExportCommand)
@click.argument("out_dir", type=click.Path(path_type=Path))
@click.option("--format", "formats", multiple=True, metavar="kml|czml|csv|acmi|acmi-zip",
              help="Format to write (repeat or comma-separate for several; default: kml, "
                   "czml, csv and acmi). acmi-zip: the ACMI text zipped, fused.zip.acmi.")
@click.option("--epoch", default=None, metavar="ISO",
              help="UTC instant of time 0 on the range's time scale (ISO 8601 with Z or an "
                   "offset, e.g. 2026-05-11T00:00:00Z for seconds of day). Default: the run's "
                   "[output] epoch, else the times are read as Unix seconds (with a warning "
                   "when they are not: they then fall on 1970-01-01).")
@click.option("--interval", type=float, default=0.0, show_default=True,
              help="KML, CZML and ACMI: at most one epoch per this many seconds per object "
                   "(0: every epoch).")
@quiet_option
@debug_option
@library_errors
def export_cmd(out_dir: Path, formats: tuple[str, ...], epoch: str | None,
               interval: float, quiet: bool) -> None:
    """Write OUT_DIR/fused.parquet as fused.kml (Google Earth), fused.czml (Cesium),
    fused.csv (spreadsheets) and fused.acmi (Tacview; zipped: fused.zip.acmi) beside it.

    KML: a time-stamped track per object with its 1-sigma uncertainty per epoch. CZML:
    time-tagged positions per object with a 3-sigma uncertainty ellipsoid. CSV: the fused
    table with a UTC column. ACMI: each object's time-tagged position and the sensors' sites
    (from the config the run's summary.json names). Exit status 2 for a missing or unreadable
    fused.parquet or a bad option.
    """
    from rangeproc.interchange import DEFAULT_FORMATS, export_run

    chosen = [f.strip().lower() for spec in formats for f in spec.split(",") if f.strip()]
    written = export_run(out_dir, chosen or DEFAULT_FORMATS, epoch=epoch, interval_s=interval)
    if not quiet:
        click.echo(f"wrote {', '.join(str(p) for p in written)}")


def leave(code: int) -> NoReturn:
    """End the process with exit status ``code`` without the interpreter's teardown.

    Every output is written, closed and renamed into place before a command returns, so
    nothing is left for the teardown to do but free memory one object at a time and unload
    the compiled kernels: 0.9 s after a sample-sized run, more after a large one. Standard
    streams and logging handlers are flushed first.
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):                 # a closed or broken pipe
            pass
    logging.shutdown()
    os._exit(code)


def entry() -> NoReturn:
    """The ``rangeproc`` console command: :func:`main`, then :func:`leave` with its exit
    status (an uncaught exception or Ctrl-C still ends the ordinary way)."""
    try:
        main()
        code = 0
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            code = exc.code or 0
        else:                                          # sys.exit("message")
            print(exc.code, file=sys.stderr)
            code = 1
    leave(code)


if __name__ == "__main__":  # pragma: no cover
    entry()
