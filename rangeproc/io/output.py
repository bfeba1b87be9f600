"""Output tables of DATA_CONTRACT section 4 (pandas lives at the edges only)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from rangeproc.results import STATE_NAMES, TrackEstimate

#: Columns beyond the contract's minimum: velocity sigmas and position covariances (m^2), so
#: that evaluation can compute a full 3-D NEES; provenance: the contributing sensors, the time
#: to the nearest used measurement (s) and whether the epoch lies in a bridged gap.
EXTRA_COLUMNS = ("sigma_ve", "sigma_vn", "sigma_vu", "cov_en", "cov_eu", "cov_nu",
                 "sensors", "data_gap_s", "bridged")
#: An epoch farther than this (s) from any used measurement is bridged (no supporting data:
#: the smoother's prediction across a gap, its covariance growing with the process noise).
BRIDGED_SECONDS = 1.0


def fused_table(tracks: Sequence[TrackEstimate]) -> pd.DataFrame:
    """One row per target per output epoch, sorted by target_id then time (contract sec. 4)."""
    frames = []
    for tr in sorted(tracks, key=lambda t: t.target_id):
        k = len(tr.time)
        cols: dict[str, object] = {"target_id": np.full(k, tr.target_id, dtype=object),
                                   "time": tr.time, "lat": tr.lat, "lon": tr.lon,
                                   "height": tr.height}
        for i, name in enumerate(STATE_NAMES):
            cols[name] = tr.x[:, i]
        d = np.sqrt(np.maximum(np.diagonal(tr.P, axis1=1, axis2=2), 0.0))
        cols.update(sigma_e=d[:, 0], sigma_n=d[:, 1], sigma_u=d[:, 2])
        cols["n_sensors"] = tr.n_sensors.astype(np.int64)
        cols.update(sigma_ve=d[:, 3], sigma_vn=d[:, 4], sigma_vu=d[:, 5],
                    cov_en=tr.P[:, 0, 1], cov_eu=tr.P[:, 0, 2], cov_nu=tr.P[:, 1, 2])
        k_sensors = tr.sensors if tr.sensors is not None else np.full(k, "", dtype=object)
        gap = tr.data_gap if tr.data_gap is not None else np.zeros(k)
        cols.update(sensors=k_sensors, data_gap_s=gap, bridged=gap > BRIDGED_SECONDS)
        for name, prob in tr.model_prob.items():        # filter = "imm": one column per model
            cols[f"p_{name}"] = prob
        frames.append(pd.DataFrame(cols))
    if not frames:
        return pd.DataFrame(columns=["target_id", "time", "lat", "lon", "height",
                                     *STATE_NAMES, "sigma_e", "sigma_n", "sigma_u",
                                     "n_sensors", *EXTRA_COLUMNS])
    df = pd.concat(frames, ignore_index=True)
    df["target_id"] = df["target_id"].astype(str)
    df["sensors"] = df["sensors"].astype(str)
    return df
