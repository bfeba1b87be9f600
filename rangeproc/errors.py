"""Exception hierarchy. The library raises these; only ``cli.py`` maps them to exit codes."""
from __future__ import annotations

import errno
import os


class RangeprocError(Exception):
    """Base class of every error rangeproc raises on purpose."""


class ConfigError(RangeprocError):
    """The config is unusable. The message names the config file and the key at fault."""


class DataError(RangeprocError):
    """An input data file is unusable. The message names the file and the row/column at fault."""


class NumericalError(RangeprocError):
    """An estimator failed numerically (non-finite state, covariance not positive definite)."""


class OutputError(RangeprocError):
    """An output cannot be written: the disk or quota is full, the file system is read-only,
    the folder is not writable. The message names the path and the operating system's cause:
    ``cannot write out/fused.parquet: No space left on device``."""

    def __init__(self, path: object, cause: str) -> None:
        super().__init__(path, cause)     # both in args: it pickles (the report's child process)
        self.path = str(path)
        self.cause = cause

    def __str__(self) -> str:
        return f"cannot write {self.path}: {self.cause}"


#: ``errno`` values of an operating-system failure to write an output: the disk or the quota is
#: full, the file too large, the file system read-only, the folder not writable, an I/O error.
WRITE_ERRNOS = frozenset({errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC), errno.EFBIG,
                          errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO})


def write_failure(exc: BaseException, path: object) -> OutputError | None:
    """``exc`` as an :class:`OutputError` naming ``path`` when it is an operating-system failure
    to write (:data:`WRITE_ERRNOS`); None for anything else. The cause is the OS's own words for
    the errno (pyarrow wraps them in a longer message of its own)."""
    if isinstance(exc, OSError) and exc.errno in WRITE_ERRNOS:
        return OutputError(path, os.strerror(exc.errno))
    return None
