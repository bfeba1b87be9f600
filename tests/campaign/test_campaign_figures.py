"""The per-sensor campaign figure (``campaign.figures``): its fixed layout keeps every text
inside the picture and clear of the panels, whatever the sortie names and panel count."""
from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
import pytest

from rangeproc.campaign.figures import plot_sensor, write_sensor_figures
from rangeproc.report.common import STYLE


def sensor_rows(sorties: list[str], n_terms: int) -> pd.DataFrame:
    """Rows of one radar over ``sorties`` with range noise and ``n_terms`` calibration terms."""
    rng = np.random.default_rng(3)
    n = len(sorties)
    table = {"sortie": sorties, "status": "done", "sensor": "R1", "kind": "radar",
             "noise_range": rng.uniform(5, 8, n), "noise_range_apriori": 7.0}
    for name in ("range", "azimuth", "elevation", "latency", "mount_roll")[:n_terms]:
        table[f"cal_{name}"] = rng.normal(0, 1e-3, n)
        table[f"cal_{name}_sigma"] = 1e-3
        table[f"cal_{name}_moved"] = rng.random(n) < 0.2
    return pd.DataFrame(table)


@pytest.mark.parametrize("sorties, n_terms", [
    (["s1", "s2", "s3"], 1),                                  # one column, flat labels
    ([f"2026-03-{d:02d}-flight-{d:03d}-repeat" for d in range(1, 25)], 5),   # long, rotated
])
def test_texts_stay_inside_the_figure(sorties, n_terms):
    with matplotlib.rc_context(STYLE):                     # as write_sensor_figures draws
        fig = plot_sensor(sensor_rows(sorties, n_terms), "R1")
        renderer = fig.canvas.get_renderer()
        fig.draw(renderer)
    box = fig.bbox
    texts = [t for ax in fig.axes
             for t in (ax.get_xticklabels() + ax.get_yticklabels()
                       + [ax.xaxis.label, ax.yaxis.label, ax.title])
             if t.get_visible() and t.get_text()]
    texts += [fig._suptitle]
    assert texts
    for t in texts:
        ext = t.get_window_extent(renderer)
        assert box.x0 - 1 <= ext.x0 and ext.x1 <= box.x1 + 1, t.get_text()
        assert box.y0 - 1 <= ext.y0 and ext.y1 <= box.y1 + 1, t.get_text()
    # sortie labels only under the bottom panel of each column, none over a panel below
    panels = [ax.get_window_extent(renderer) for ax in fig.axes]
    for ax in fig.axes:
        for t in ax.get_xticklabels():
            if t.get_visible() and t.get_text():
                ext = t.get_window_extent(renderer)
                assert not any(ext.overlaps(p) for p in panels), t.get_text()


def test_one_file_per_estimated_sensor(tmp_path):
    rows = sensor_rows(["a", "b"], 2)
    ins = pd.DataFrame({"sortie": ["a", "b"], "status": "done", "sensor": "INS1",
                        "kind": "ins"})
    written = write_sensor_figures(pd.concat([rows, ins], ignore_index=True), tmp_path)
    assert written == [tmp_path / "sensor_R1.png"]
    assert written[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob("*.tmp*"))
