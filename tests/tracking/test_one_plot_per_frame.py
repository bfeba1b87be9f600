"""An object takes at most one plot per frame of a plot sensor (tracking.synthesis)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rangeproc.tracking.reassociation import one_plot_per_frame as _one_plot_per_frame


def test_an_object_keeps_its_gated_plot_of_a_frame_and_lets_the_others_go() -> None:
    objects = SimpleNamespace(tracks={})                # no trajectory: the gate decides
    rows = np.arange(7)
    frame = np.array([0, 0, 1, 1, 1, 2, 2])
    owner = np.array([0, 0, 0, 1, 0, 1, -1])
    gated = np.array([False, True, False, True, False, True, False])
    out = _one_plot_per_frame(objects, ["A", "B"], None, rows, owner, gated, frame)
    assert out.tolist() == [-1, 0, 0, 1, -1, 1, -1]
    for j in (0, 1):                                    # one plot per object and frame
        held = frame[out == j]
        assert held.size == np.unique(held).size
