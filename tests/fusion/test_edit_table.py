"""edits.parquet: every removed, rejected or down-weighted measurement component with its
reason, row in its file and residual; the summary counts agree with it."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from rangeproc.fusion.edit_table import EDIT_COLUMNS

CONFIG = "scenario.toml"


def test_every_edit_and_rejection_is_in_edits_parquet(scenario, cli, explain) -> None:
    """A radar range of 1e308 on data row 101 (a physical-limit edit) and the run's own gate
    rejections: edits.parquet names each with its file row and reason, and its counts per
    sensor, reason and component are the summary's."""
    df = pd.read_csv(scenario / "R1.csv")
    wild = 100
    df.loc[wild, "range"] = 1e308
    df.to_csv(scenario / "R1.csv", index=False, float_format="%.17g")
    res = cli(["run", "--quiet", scenario / CONFIG])
    assert res.exit_code == 0, explain(res)
    edits = pd.read_parquet(scenario / "out" / "edits.parquet")
    summary = json.loads((scenario / "out" / "summary.json").read_text())
    assert tuple(edits.columns) == EDIT_COLUMNS
    limit = edits[edits.reason == "limit"]
    assert len(limit) == 1 and limit.iloc[0]["sensor"] == "R1"
    assert limit.iloc[0]["row"] == wild + 1 and limit.iloc[0]["value"] == 1e308
    assert abs(limit.iloc[0]["time"] - df.loc[wild, "time"]) < 1e-6
    for sid, ss in summary["sensors"].items():
        mine = edits[edits.sensor == sid]
        screened = mine[~mine.reason.isin(["gate", "burst", "residual"])]
        screened = screened.reason.value_counts().to_dict()
        assert screened == ss["n_edited"], sid
        gated = mine[mine.reason == "gate"].component.value_counts().to_dict()
        expected = {k: v for k, v in ss.get("n_components_rejected", {}).items() if v}
        assert gated == expected, sid
    gate = edits[edits.reason == "gate"]
    assert len(gate) > 0
    assert np.isfinite(gate.residual).all() and np.isfinite(gate.normalised_residual).all()
    # a component the gate rejected lies far out in its predicted spread
    assert np.median(np.abs(gate.normalised_residual)) > 3.0
    assert not ((edits.sensor == "R1") & (edits.row == wild + 1) & (edits.reason == "gate")
                & (edits.component == "range")).any()
    assert (gate.weight == 0).all() and (edits[edits.reason == "limit"].weight == 0).all()
    # the sample's GPS noise burst: its fixes are down-weighted, not rejected
    burst = edits[(edits.reason == "burst") & (edits.sensor == "G1")]
    assert len(burst) > 10 and (burst.weight < 0.5).all()
    huber = edits[edits.reason == "residual"]
    assert (huber.weight < 1.0).all() and (np.abs(huber.normalised_residual) > 1.5).mean() > 0.9
