"""Memory a long sortie's stages let go of, handed back to the operating system.

Arrow's default pool (mimalloc or jemalloc in the pyarrow wheels) keeps what a CSV parse
freed for Arrow's own later use: memory that NumPy, numba and the rest of the run cannot
reuse and that stays resident to the end (about 50 MB on the 2-million-row bench sortie,
30 MB on a 298,000-row one). :func:`system_arrow_pool` reads through the C library's
allocator instead, whose freed blocks the rest of the run does reuse; :func:`release_freed`
returns the whole free pages of that heap to the system (glibc ``malloc_trim(0)``, through
Arrow's system pool, a no-op elsewhere).

Neither changes a value: both decide only where freed bytes wait.
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pyarrow as pa


def release_freed() -> None:
    """Hand the free pages of the C heap back to the system (glibc ``malloc_trim(0)``): a
    stage boundary's freed arrays then leave the resident set rather than wait for reuse.
    Costs a walk of the heap's free lists (milliseconds) and a page fault for each page
    touched again."""
    pa.system_memory_pool().release_unused()


@contextmanager
def system_arrow_pool() -> Iterator[None]:
    """Within: Arrow allocates through the C library's allocator (``pa.system_memory_pool``);
    on leaving, the default pool is restored and the freed pages released
    (:func:`release_freed`). Arrays made within keep their buffers' pool; nothing is
    copied."""
    before = pa.default_memory_pool()
    pa.set_memory_pool(pa.system_memory_pool())
    try:
        yield
    finally:
        pa.set_memory_pool(before)
        release_freed()
