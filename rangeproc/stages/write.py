"""Stage 7, write: the output folder, the staging folder whose contents are published only
when every output is complete, and the tables (``fused.parquet``, ``edits.parquet``,
``association.parquet``, the exports)."""
from __future__ import annotations

import errno
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


from rangeproc.config import Config
from rangeproc.errors import ConfigError, OutputError, write_failure
from rangeproc.interchange import EXPORT_FILES, export_run
from rangeproc.io.output import fused_table
from rangeproc.io.writers import write_parquet
from rangeproc.results import TrackEstimate




#: Staging folders are named ``<prefix><pid of the run>-<random>``.
STAGING_PREFIX = ".rangeproc-staging-"


def remove_orphaned_staging(out_dir: Path) -> None:
    """Remove staging folders in ``out_dir`` left by runs on this host whose process no longer
    exists (killed with SIGKILL, e.g. a campaign worker lost mid-sortie: its ``finally``
    never ran). A live run's folder is left alone."""
    for folder in out_dir.glob(f"{STAGING_PREFIX}*"):
        pid = folder.name[len(STAGING_PREFIX):].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (PermissionError, OSError):
            pass                                         # alive, or not ours to judge


@contextmanager
def staged_outputs(out_dir: Path) -> Iterator[Path]:
    """Yield a hidden staging folder inside ``out_dir``; publish its contents on success.

    Every output of a run is first written into the staging folder; only when all of them are
    complete are they moved into place (``report/`` swapped as a whole, ``fused.parquet``,
    ``edits.parquet``, ``association.parquet``, the exports of ``[output] export``, then
    ``summary.json`` last, each by an atomic rename). A run that
    fails at any stage therefore leaves the previous run's outputs untouched and no partial or
    mixed set behind. An operating-system failure to write (a full disk, a read-only folder:
    ``errors.write_failure``) is an :class:`OutputError` naming the output's published
    path in ``out_dir``, not its staged one.
    """
    remove_orphaned_staging(out_dir)
    try:
        stage = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-", dir=out_dir))
    except OSError as exc:
        if (failure := write_failure(exc, out_dir)) is None:
            raise
        raise failure from exc

    def published(path: str | Path) -> Path:
        """Where a staged path is published (other paths unchanged)."""
        path = Path(path)
        return out_dir / path.relative_to(stage) if path.is_relative_to(stage) else path

    try:
        yield stage
        old = stage / ".old-report"
        if (out_dir / "report").exists():
            os.replace(out_dir / "report", old)
        os.replace(stage / "report", out_dir / "report")
        os.replace(stage / "fused.parquet", out_dir / "fused.parquet")
        os.replace(stage / "edits.parquet", out_dir / "edits.parquet")
        os.replace(stage / "association.parquet", out_dir / "association.parquet")
        for name in EXPORT_FILES:                    # [output] export, when asked for
            if (stage / name).exists():
                os.replace(stage / name, out_dir / name)
        os.replace(stage / "summary.json", out_dir / "summary.json")
    except OutputError as exc:                   # written in the stage: name the final path
        raise OutputError(published(exc.path), exc.cause) from exc.__cause__
    except OSError as exc:                       # a rename into place
        failure = write_failure(exc, published(exc.filename2 or exc.filename or out_dir))
        if failure is None:
            raise
        raise failure from exc
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def check_output_dir(cfg: Config) -> None:
    """Fail fast, before any processing and without creating anything, when ``[output].dir``
    cannot be a writable directory: an existing file (ConfigError), or a folder on the way that
    is not writable or on a read-only file system (OutputError naming it and the cause)."""
    out_dir = cfg.output.dir
    probe = out_dir
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise ConfigError(f"{cfg.path.name}: output.dir: {probe} exists and is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):      # read-only file system or no permission
        read_only = hasattr(os, "statvfs") and os.statvfs(probe).f_flag & os.ST_RDONLY
        raise OutputError(probe, os.strerror(errno.EROFS if read_only else errno.EACCES))


def make_output_dir(cfg: Config) -> Path:
    """Create ``[output].dir`` (just before the first write)."""
    out_dir = cfg.output.dir
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        if (failure := write_failure(exc, out_dir)) is not None:
            raise failure from exc
        raise ConfigError(f"{cfg.path.name}: output.dir: cannot create {out_dir}: "
                          f"{exc.strerror or exc}") from exc
    return out_dir


def write_tables(stage: Path, cfg: Config, tracks: list[TrackEstimate], edit_rows,
                 association) -> list[Path]:
    """``fused.parquet``, ``edits.parquet`` and ``association.parquet`` into the staging folder
    ``stage``, and the exports ``[output] export`` asks for (KML, CZML, CSV, ACMI); returns the
    exports' staged paths."""
    table = fused_table(tracks)
    write_parquet(table, stage / "fused.parquet")
    write_parquet(edit_rows, stage / "edits.parquet")
    write_parquet(association, stage / "association.parquet")
    if not cfg.output.export:
        return []
    return list(export_run(stage, cfg.output.export, epoch=cfg.output.epoch,
                           title=f"rangeproc {cfg.path.stem}", table=table, config=cfg))
