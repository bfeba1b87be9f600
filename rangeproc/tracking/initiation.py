"""The initial score of a new plot track (issue 41; used by ``tracking.plot_tracker``): the
density of new objects against that of clutter, held fixed per unit of velocity space so that
a new track's velocity bound confines its gate without changing the evidence it needs.
"""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plots import INITIATION_SPEED


def new_track_score(speed: float, axes: int) -> float:
    """The initial score (log-likelihood ratio object / clutter) of a new track whose velocity
    is unknown up to ``speed`` m/s (3 sigma), scored over ``axes`` axes (2 for a planar
    sensor): ``axes * ln(speed / INITIATION_SPEED)``, 0 with the general bound.

    A track's score begins at ``ln(beta_NT / beta_FA)`` (Blackman and Popoli 1999, 6.2), the
    density of new objects over that of clutter at its first plot. The tracker takes it as
    1 for a track with the general bound (``INITIATION_SPEED``) and holds the density of new
    objects fixed per unit of velocity space: a track whose velocity prior is narrower by
    ``speed / INITIATION_SPEED`` stands for the objects of that smaller velocity volume
    only (``(speed / INITIATION_SPEED) ** axes`` of them), while its second plot's
    likelihood (near the prior's peak) is higher by the inverse. The two cancel, so a
    track's plots confirm it as fast whatever the bound, as long as its speed lies within
    it: a narrower bound confines a new track's gate but does not by itself make clutter
    look like an object (with a 20 m/s bound and a score begun at 0, patches of sea clutter
    were confirmed in a few plots: tests/tracking/test_track_score.py)."""
    return float(axes * np.log(speed / INITIATION_SPEED))
