"""The pipeline's process-wide memory setting (``pipeline.fixed_mmap_threshold``)."""
from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from rangeproc.pipeline import fixed_mmap_threshold

#: Run in a fresh interpreter: the allocator's state of a long test session (its arenas, the
#: blocks other tests left) is not what a run starts from. Prints the KiB of resident memory
#: given back when a 16 MiB array is freed after a 24 MiB one was (which lifts glibc's own
#: threshold to 24 MiB, so that the 16 MiB array comes from the heap and stays resident).
FREED_KIB = """
import sys
import numpy as np
from rangeproc.pipeline import fixed_mmap_threshold

def rss():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))

if sys.argv[1] == "fixed":
    assert fixed_mmap_threshold()
big = np.ones(3 << 20)
del big
a = np.ones(2 << 20)
pin = np.ones(10)               # a later block: the array is not the heap top (trimmed)
before = rss()
del a
print(before - rss(), pin.sum())
"""


def _freed_kib(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", FREED_KIB, mode], capture_output=True,
                         text=True, check=True).stdout.split()
    return int(out[0])


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="glibc's mallopt only")
def test_large_arrays_freed_go_back_to_the_system():
    """With the threshold fixed, a freed 16 MiB array is returned (resident memory falls);
    without it (the negative control) glibc keeps it resident."""
    assert _freed_kib("fixed") > 12 * 1024
    assert _freed_kib("glibc") < 4 * 1024


def test_elsewhere_it_is_a_no_op():
    assert fixed_mmap_threshold() in (True, False)
