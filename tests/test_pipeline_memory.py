"""The pipeline's process-wide memory setting (``pipeline.fixed_mmap_threshold``)."""
from __future__ import annotations

import platform
import sys

import numpy as np
import pytest

from rangeproc.pipeline import fixed_mmap_threshold


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="glibc's mallopt only")
def test_large_arrays_freed_go_back_to_the_system():
    """With the threshold fixed, a freed 16 MiB array is returned (resident memory falls)
    even after a larger block was freed before it (which lifts glibc's own threshold to
    24 MiB: the 16 MiB array would then come from the heap and stay resident)."""
    def rss() -> int:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))

    assert fixed_mmap_threshold()
    big = np.ones(3 << 20)          # 24 MiB, freed: glibc alone would lift its threshold
    del big
    a = np.ones(2 << 20)            # 16 MiB, touched
    pin = np.ones(10)               # a later block: the array is not the heap top (trimmed)
    before = rss()
    del a
    assert before - rss() > 12 * 1024          # KiB
    assert pin.sum() == 10.0


def test_elsewhere_it_is_a_no_op():
    assert fixed_mmap_threshold() in (True, False)
