"""Memory a long sortie's stages let go of, handed back to the operating system.

Arrow's default pool (mimalloc or jemalloc in the pyarrow wheels) keeps what a CSV parse
freed for Arrow's own later use: memory that NumPy, numba and the rest of the run cannot
reuse and that stays resident to the end (20 to 30 MiB of the read stage's peak on the
bench sorties, side by side). :func:`system_arrow_pool` reads through the C library's
allocator instead, whose freed blocks the rest of the run does reuse; :func:`release_freed`
returns the whole free pages of that heap to the system (glibc ``malloc_trim(0)``; a no-op
where the C library has none). Arrow's own ``release_unused`` of its system pool does not
(pyarrow 26: the resident set of a fragmented heap stays as it is).

Neither changes a value: both decide only where freed bytes wait.
"""
from __future__ import annotations

import ctypes
import ctypes.util
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pyarrow as pa


def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim``, or None (another C library, or none found)."""
    name = ctypes.util.find_library("c")
    try:
        return getattr(ctypes.CDLL(name), "malloc_trim", None) if name else None
    except OSError:
        return None


_TRIM = _malloc_trim()


def release_freed() -> bool:
    """Hand the free pages of the C heap back to the system (glibc ``malloc_trim(0)``): a
    stage boundary's freed arrays then leave the resident set rather than wait, fragmented,
    for reuse. Costs a walk of the heap's free lists (milliseconds) and a page fault for
    each page touched again. False where there is no ``malloc_trim`` (nothing done)."""
    if _TRIM is None:
        return False
    _TRIM(0)
    return True


@contextmanager
def system_arrow_pool() -> Iterator[None]:
    """Within: Arrow allocates through the C library's allocator (``pa.system_memory_pool``);
    on leaving, the default pool is restored and the freed pages released
    (:func:`release_freed`). Arrays made within keep their buffers' pool; nothing is
    copied. The default pool is the process's: Arrow work in another thread meanwhile
    allocates from the system pool too (its values are the same)."""
    before = pa.default_memory_pool()
    pa.set_memory_pool(pa.system_memory_pool())
    try:
        yield
    finally:
        pa.set_memory_pool(before)
        release_freed()
