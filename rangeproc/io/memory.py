"""Memory a long sortie's stages let go of, handed back to the operating system.

Arrow's default pool (mimalloc or jemalloc in the pyarrow wheels) keeps what a CSV parse
freed for Arrow's own later use: memory that NumPy, numba and the rest of the run cannot
reuse and that stays resident to the end (20 to 30 MiB of the read stage's peak on the
bench sorties, side by side). :func:`system_arrow_pool` reads through the C library's
allocator instead, whose freed blocks the rest of the run does reuse; :func:`release_freed`
returns the whole free pages of that heap to the system (glibc ``malloc_trim(0)``; a no-op
where the C library has none). Arrow's own ``release_unused`` of its system pool does not
(pyarrow 26: the resident set of a fragmented heap stays as it is).

Threads (``rangeproc.parallel``: the row chunks, the process-noise candidates, objects side by
side) allocate from the main heap too (``rangeproc.parallel.one_heap``, at
``import rangeproc``): on heaps of their own (glibc's default, up to 8 per core) what they
freed stayed resident between the trims.

None of these changes a value: they decide only where freed bytes wait.
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pyarrow as pa

from rangeproc.parallel import libc_function

_TRIM = libc_function("malloc_trim")


def release_freed() -> bool:
    """Hand the free pages of the C heap back to the system (glibc ``malloc_trim(0)``): a
    stage boundary's freed arrays then leave the resident set rather than wait, fragmented,
    for reuse. Costs a walk of the heap's free lists (milliseconds) and a page fault for
    each page touched again. False where there is no ``malloc_trim`` (nothing done)."""
    if _TRIM is None:
        return False
    _TRIM(0)
    return True


#: Rows of a span or object from which its steps also hand the free pages back between them
#: (:func:`release_freed_between`). A step of a 298,000-row span frees tens of MiB that the
#: next one would otherwise lay its arrays over (its final pass's peak 593 -> 537 MiB with the
#: trim before it, one run); an object of the several-objects scenario (about 30,000 rows)
#: frees a few, and the trims cost it 30 % more system time (pages faulted in again) for no
#: lower peak.
BETWEEN_STEPS_ROWS = 100_000


def release_freed_between(n_rows: int) -> bool:
    """:func:`release_freed` between two steps of a span or object of ``n_rows`` rows, when it
    has at least :data:`BETWEEN_STEPS_ROWS` (False: nothing done)."""
    return n_rows >= BETWEEN_STEPS_ROWS and release_freed()


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
