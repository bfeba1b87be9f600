"""The warnings of one run, collected for ``summary.json``, the report page and the terminal.

Every plausibility warning rangeproc gives goes through :mod:`logging` (one line each, on
stderr). :func:`collect_warnings` also keeps the lines of one run so that the outputs show them
to an engineer who never saw the terminal. Lines are kept from the thread that runs the
pipeline and from rangeproc's own worker threads (named ``rangeproc...``, see
:mod:`rangeproc.parallel`); a campaign runs one sortie per worker process.
"""
from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: Level of a note: a fact about a valid input said once on stderr (a CSV file read in
#: another dialect than the contract's), between INFO and WARNING; not a warning, so not
#: collected by :func:`collect_warnings` nor counted in the run's warnings.
NOTE = 25
logging.addLevelName(NOTE, "note")


class _Collector(logging.Handler):
    def __init__(self, owner: int) -> None:
        super().__init__(logging.WARNING)
        self.owner = owner
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.thread != self.owner and not (record.threadName or "").startswith("rangeproc"):
            return
        line = record.getMessage()
        if line not in self.lines:          # one line per fact, however often it was logged
            self.lines.append(line)


@contextmanager
def collect_warnings() -> Iterator[list[str]]:
    """Within the block, every WARNING (or worse) logged under the ``rangeproc`` logger is also
    appended, once, to the yielded list (the message without level or logger name)."""
    handler = _Collector(threading.get_ident())
    logger = logging.getLogger("rangeproc")
    logger.addHandler(handler)
    try:
        yield handler.lines
    finally:
        logger.removeHandler(handler)
