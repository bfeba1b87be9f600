"""Stage 4, associate: which object every row belongs to (``tracking``: tracks cut where they
jump, plots tracked, pieces associated with declared and discovered objects, plots re-associated
with the smoothed objects), and the plots left to no object."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rangeproc.config import Config
from rangeproc.fusion.assemble import Assembled
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.initialise import Prior
from rangeproc.tracking.routing import object_rows, stray_points


@dataclass
class Associated:
    """parts_of: object id -> its row parts (handed to the fuse stage); synthesis: the
    several-objects synthesis (None with one declared target and no plots); kept: sensor id ->
    the file rows its assembled rows came from; stray: the plots no object took, for the
    report."""

    parts_of: dict
    synthesis: object | None
    kept: dict[str, np.ndarray]
    stray: object


def associate(cfg: Config, rows: dict[str, Assembled], settings: EstimatorSettings,
              priors: dict[str, Prior | None],
              tick: Callable[..., None] = lambda *a, **k: None) -> Associated:
    """Sort the assembled rows (by sensor id) into objects; ``rows`` is emptied (the object
    parts hold the data now)."""
    parts_of, synthesis = object_rows(cfg, rows, settings, priors, tick)
    kept = {sid: a.rows.source_row for sid, a in rows.items()}
    stray = stray_points(cfg, rows, synthesis)
    rows.clear()
    return Associated(parts_of, synthesis, kept, stray)
