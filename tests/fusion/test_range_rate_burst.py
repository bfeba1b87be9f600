"""Range rates alone through a noise burst: MISTRAM alone on the sample flight from a given
state, every station's noise x10 for 10 s, against smoothers told the truth (the simulator's
wild rows removed against the exact range rates from truth.csv, the true noise stated, the
burst's rows a second sensor of ten times the sigma, no noise adaptation)."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.config import load_config
from rangeproc.editing.robust import MAD_TO_SIGMA
from rangeproc.evaluate import evaluate_run
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.pipeline import run
from tests.conftest import SAMPLE_DATA
from tests.fusion.test_range_rate_only import mistram_only_config

BURST_FACTOR, BURST_S, WILD_SIGMAS = 10.0, 10.0, 5.0


def exact_range_rates(folder: Path, rows: pd.DataFrame) -> np.ndarray:
    """Each row's range rate from the truth (m/s): ``(p - s) . v / |p - s|``."""
    cfg = load_config(folder / "scenario.toml")
    mistram = next(s for s in cfg.sensors if s.kind == "mistram")
    frame = RangeFrame(cfg.origin)
    sites = {st.id: frame.site(st.site)[0].reshape(3) for st in mistram.stations}
    truth = pd.read_csv(folder / "truth.csv")
    t = rows.time.to_numpy()
    p = np.column_stack([np.interp(t, truth.time, truth[a]) for a in "enu"])
    v = np.column_stack([np.interp(t, truth.time, truth["v" + a]) for a in "enu"])
    d = p - np.stack([sites[s] for s in rows.station])
    return np.einsum("ij,ij->i", d, v) / np.linalg.norm(d, axis=1)


def _scenario(folder: Path) -> tuple[Path, Path]:
    """The default config (MISTRAM alone, a given state) on rows with a burst, and the told
    config; returns both paths."""
    shutil.copytree(SAMPLE_DATA, folder, ignore=shutil.ignore_patterns("out", ".*"))
    config = mistram_only_config(folder, initial=True)
    rows = pd.read_csv(folder / "MISTRAM.csv")
    err = rows.range_rate.to_numpy() - exact_range_rates(folder, rows)
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(err - np.median(err))))   # the true noise
    t0 = rows.time.min() + 0.45 * (rows.time.max() - rows.time.min())
    burst = ((rows.time >= t0) & (rows.time < t0 + BURST_S)).to_numpy()
    extra = np.random.default_rng(3).normal(0.0, sigma * np.sqrt(BURST_FACTOR ** 2 - 1.0),
                                            burst.sum())
    rows.loc[burst, "range_rate"] += extra
    err[burst] += extra
    rows.to_csv(folder / "MISTRAM.csv", index=False)
    wild = np.abs(err) > WILD_SIGMAS * sigma * np.where(burst, BURST_FACTOR, 1.0)
    assert 0 < wild.sum() < 0.1 * len(rows)          # the simulator's wild points are there
    rows[~wild & ~burst].to_csv(folder / "MISTRAM_told.csv", index=False)
    rows[~wild & burst].to_csv(folder / "MISTRAM_burst.csv", index=False)
    told = folder / "told.toml"
    told.write_text(told_config(config.read_text(), sigma, burst=True).replace(
        'dir = "out"', 'dir = "out_told"') + '\n[processing]\nadapt_noise = false\n')
    return config, told


def told_config(text: str, sigma: float, *, burst: bool) -> str:
    """A MISTRAM-only config's text told the truth: its rows from ``MISTRAM_told.csv`` with
    the true ``sigma`` (m/s) and, with ``burst``, the burst's rows from ``MISTRAM_burst.csv``
    as a second MISTRAM sensor of :data:`BURST_FACTOR` times the sigma."""
    text = re.sub(r"sigma = \{ range_rate = [\d.]+ \}", f"sigma = {{ range_rate = {sigma} }}",
                  text.replace('file = "MISTRAM.csv"', 'file = "MISTRAM_told.csv"'))
    if burst:
        block = re.search(r'(?s)\[\[sensors\]\]\nid = "MISTRAM"\n.*?(?=\n\[|\Z)',
                          text).group(0)
        text += "\n" + (block.replace('id = "MISTRAM"', 'id = "MISTRAM_BURST"')
                        .replace("MISTRAM_told.csv", "MISTRAM_burst.csv")
                        .replace(f"range_rate = {sigma} ",
                                 f"range_rate = {BURST_FACTOR * sigma} ")) + "\n"
    return text


def test_range_rates_alone_through_a_noise_burst_stay_near_the_bound(tmp_path):
    config, told = _scenario(tmp_path / "sample")
    truth = tmp_path / "sample" / "truth.csv"
    default = evaluate_run(run(config).out_dir, truth)["targets"]["T1"]
    bound = []
    for name, extra in (("told_fit", ""), ("told_ekf", 'filter = "ekf"\n')):
        path = told.with_name(f"{name}.toml")
        path.write_text(told.read_text().replace('dir = "out_told"', f'dir = "out_{name}"')
                        + extra)
        bound.append(evaluate_run(run(path).out_dir, truth)["targets"]["T1"]["pos_rmse"])
    assert default["pos_rmse"] <= 1.3 * min(bound), (default["pos_rmse"], bound)
    assert min(default["inside_3sigma_enu"]) >= 0.95, default
