"""GPS rows: an empty height cell leaves east/north usable (contract: empty = not measured)."""
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pymap3d

from rangeproc.config import Geodetic, SensorSettings
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.assemble import assemble_sensor
from rangeproc.io.logs import SensorLog


def _gps_log(lat, lon, h):
    n = len(lat)
    nan = np.full(n, np.nan)
    cols = {"lat": np.asarray(lat, float), "lon": np.asarray(lon, float),
            "height": np.asarray(h, float), "ve": nan, "vn": nan, "vu": nan}
    return SensorLog("G1", "gps", np.arange(n, dtype=float), cols, np.arange(1, n + 1),
                     None, None, n)


def test_missing_height_keeps_horizontal_components_exact():
    frame = RangeFrame(Geodetic(lat=34.9, lon=-117.9, height=700.0))
    cfg = SensorSettings(id="G1", kind="gps", file=Path("G1.csv"),
                         sigma=MappingProxyType({"horizontal": 3.0, "vertical": 5.0,
                                                 "velocity": 0.2}))
    lat, lon, h = [35.2, 35.2], [-117.4, -117.4], [5000.0, np.nan]
    rows = assemble_sensor(_gps_log(lat, lon, h), cfg, frame, {}).rows
    # row 0 (full fix) and row 1 (height missing) give the same east/north in receiver axes
    np.testing.assert_allclose(rows.z[1, :2], rows.z[0, :2], atol=1e-6)
    assert np.isnan(rows.z[1, 2]) and np.isfinite(rows.z[0, 2])
    # and the full fix maps back to the true point: z = Qr p with p from pymap3d
    e, n, u = pymap3d.geodetic2enu(35.2, -117.4, 5000.0, 34.9, -117.9, 700.0)
    np.testing.assert_allclose(rows.Qr[0].T @ rows.z[0, :3], [e, n, u], atol=1e-6)
