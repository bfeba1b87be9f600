"""Independent geodesy for the simulator tests (pyproj, not the code under test)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyproj
from scipy.interpolate import CubicHermiteSpline

TO_ECEF = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
TO_GEO = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)


def ecef(lat, lon, h) -> np.ndarray:
    """(M, 3) ECEF (m) of WGS-84 points (deg, deg, m)."""
    x, y, z = TO_ECEF.transform(np.atleast_1d(lon), np.atleast_1d(lat), np.atleast_1d(h))
    return np.column_stack((x, y, z))


def enu_basis(lat, lon) -> np.ndarray:
    """(M, 3, 3): rows = east, north, up unit vectors in ECEF."""
    la, lo = np.radians(np.atleast_1d(lat)), np.radians(np.atleast_1d(lon))
    sl, cl, so, co = np.sin(la), np.cos(la), np.sin(lo), np.cos(lo)
    z = np.zeros_like(la)
    return np.stack((np.stack((-so, co, z), -1), np.stack((-sl * co, -sl * so, cl), -1),
                     np.stack((cl * co, cl * so, sl), -1)), axis=1)


def truth_splines(folder: Path) -> tuple[CubicHermiteSpline, CubicHermiteSpline]:
    """Position and velocity (range ENU) of ``folder/truth.csv`` as C1 splines of time (s)."""
    truth = pd.read_csv(folder / "truth.csv")
    t = truth["time"].to_numpy()
    p = CubicHermiteSpline(t, truth[["e", "n", "u"]].to_numpy(),
                           truth[["ve", "vn", "vu"]].to_numpy())
    v = CubicHermiteSpline(t, truth[["ve", "vn", "vu"]].to_numpy(),
                           truth[["ae", "an", "au"]].to_numpy())
    return p, v
