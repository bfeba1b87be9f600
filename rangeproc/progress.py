"""Stage timing and progress display for long runs.

A :class:`StageClock` times each pipeline stage (``read``, ``assemble``, ``fuse``, ``write``,
``report``) and forwards progress to a display. The CLI chooses the display: a per-stage
progress bar on a terminal, nothing under ``--quiet`` or when stderr is not a TTY. The library
never prints.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Protocol


class Display(Protocol):
    """Receives stage boundaries and progress ticks."""

    def start(self, stage: str, total: int) -> None: ...

    def advance(self, stage: str, n: int = 1, note: str = "") -> None: ...

    def finish(self, stage: str, seconds: float) -> None: ...


class SilentDisplay:
    """The default display: shows nothing."""

    def start(self, stage: str, total: int) -> None:
        pass

    def advance(self, stage: str, n: int = 1, note: str = "") -> None:
        pass

    def finish(self, stage: str, seconds: float) -> None:
        pass


@dataclass
class StageClock:
    """Wall-clock seconds per stage, accumulated; forwards events to ``display``."""

    display: Display = field(default_factory=SilentDisplay)
    seconds: dict[str, float] = field(default_factory=dict)

    @contextmanager
    def stage(self, name: str, total: int = 1) -> Iterator[Callable[..., None]]:
        """Time a stage; yields ``tick(n=1, note="")`` to report progress inside it."""
        self.display.start(name, total)
        t0 = time.perf_counter()

        def tick(n: int = 1, note: str = "") -> None:
            self.display.advance(name, n, note)

        try:
            yield tick
        finally:
            dt = time.perf_counter() - t0
            self.seconds[name] = self.seconds.get(name, 0.0) + dt
            self.display.finish(name, dt)
