"""Result containers passed from the estimation stages to writers, reports and evaluation."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: State layout of the 9-state constant-acceleration model, range ENU frame, SI units.
STATE_NAMES = ("e", "n", "u", "ve", "vn", "vu", "ae", "an", "au")


@dataclass(frozen=True, slots=True)
class TrackEstimate:
    """Smoothed trajectory of one target sampled on the output grid.

    time: (K,) s; x: (K, 9) state [e, n, u, ve, vn, vu, ae, an, au] in range ENU (m, m/s,
    m/s^2); P: (K, 9, 9) state covariance; n_sensors: (K,) int64, distinct sensors with a used
    measurement within the output interval around each epoch; lat, lon (deg), height (m):
    (K,) geodetic position; spans: ((t_first, t_last), ...) s, the separately estimated spans
    (the target was unobserved for longer than the gap limit between them: no epochs there);
    model_prob: the IMM's smoothed probability (K,) of each model by name (empty otherwise);
    sensors: (K,) str, the ids of those sensors, comma-separated (provenance); data_gap: (K,)
    s from the epoch to the nearest used measurement of any sensor (large inside a bridged gap);
    achievable: (K, 3) m, the 1-sigma position the instruments allow along this trajectory
    (``fusion.achievable``; NaN inside a bridged gap), None when not computed; unwritten:
    ((t_first, t_last), ...) s, the output epochs of each stretch left out because the
    object's own position rows reject the trajectory there (``fusion.support``).
    """

    target_id: str
    time: np.ndarray
    x: np.ndarray
    P: np.ndarray
    n_sensors: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    height: np.ndarray
    spans: tuple[tuple[float, float], ...] = ()
    model_prob: dict[str, np.ndarray] = field(default_factory=dict)
    sensors: np.ndarray | None = None
    data_gap: np.ndarray | None = None
    achievable: np.ndarray | None = None
    unwritten: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True, slots=True)
class SensorResiduals:
    """Post-fit residuals of one sensor against the smoothed trajectory.

    components: names of the measured components, e.g. ("range", "azimuth", "elevation",
    "range_rate") or ("e", "n", "u", "ve", "vn", "vu") (GPS, receiver-local ENU) or
    ("range_rate",). units: one unit string per component ("m", "rad", "m/s").
    time: (N,) s; residual: (N, m) measured minus smoothed prediction in SI units, angles wrapped
    to (-pi, pi], NaN where the component was not measured; sigma: (N, m) the 1-sigma noise the
    estimator used for each component (after noise adaptation); rejected: (N, m) bool, True
    where the gate rejected that component as a wild point (the rest of the row may be used);
    nis: (N,) float filter innovation chi-square of the row (NaN when not computed);
    target_id: the target the rows belong to; station: (N,) int64 MISTRAM station index or None.
    """

    sensor_id: str
    kind: str
    target_id: str
    components: tuple[str, ...]
    units: tuple[str, ...]
    time: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    rejected: np.ndarray
    nis: np.ndarray
    station: np.ndarray | None = None
