"""A run compiles only what its filter family uses (issue 44 item 6).

Checked in a fresh interpreter with an empty kernel cache (a kernel loaded from the cache
leaves its callees' dispatchers without signatures, so only a compiling run shows what it
compiles): after an EKF forward pass, no other family's loop is made, the dispatchers of
the other families' steps and the unscented moments hold no signature, and the general
gated update holds exactly one (the fast path's per-component re-gating calls it with the
general rows' argument types instead of compiling an update of its own). The negative
control then calls one of those dispatchers in the same process and must see it counted.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: The dispatchers an EKF run must not compile: ``module:name``.
UNUSED = ("rangeproc.estimation.fading:epoch_innovations",
          "rangeproc.estimation.fading:fading_factors",
          "rangeproc.estimation.fading:apply_fading",
          "rangeproc.estimation.adaptive:sh_adapt",
          "rangeproc.estimation.spline_filter:epoch_chi2",
          "rangeproc.estimation.constraint:norm_update",
          "rangeproc.estimation.moments:row_moments",
          "rangeproc.estimation.moments:ukf_moments")

_CHILD = """
import importlib, json, sys
import numpy as np
sys.path.insert(0, {tests!r})
from test_fast_path import _rows
from rangeproc.estimation import imm
from rangeproc.estimation.adaptive import sh_adapt
from rangeproc.estimation.forward import FilterSettings, run_filter
from rangeproc.estimation.forward_loop import _KERNELS
from rangeproc.estimation.update import update_row
rows, prior = _rows(200)
run_filter(rows, prior, FilterSettings(np.full(7, np.inf)))

def report():
    out = {{"loops": sorted("%s/%d" % k for k in _KERNELS), "imm": len(imm._KERNELS),
            "update_row": len(update_row.signatures)}}
    for name in {names!r}:
        mod, attr = name.split(":")
        out[name] = len(getattr(importlib.import_module(mod), attr).signatures)
    return out

ekf = report()
sh_adapt(0, np.zeros(6, np.int64), 1, np.ones(6), np.zeros(6), np.zeros(6, np.int64),
         np.zeros((6, 2)), 0, False)
print(json.dumps({{"ekf": ekf, "control": report()}}))
"""


def _compiled() -> dict:
    code = _CHILD.format(tests=str(ROOT / "tests" / "estimation"), names=list(UNUSED))
    with tempfile.TemporaryDirectory() as cache:      # empty: everything compiles here
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, RANGEPROC_CACHE_DIR=cache,
                   PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [
                       os.environ.get("PYTHONPATH")])]))
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_an_ekf_run_compiles_no_other_familys_kernel_and_one_update() -> None:
    got = _compiled()
    ekf, control = got["ekf"], got["control"]
    assert ekf.pop("loops") == ["ekf/9"] and ekf.pop("imm") == 0
    assert ekf.pop("update_row") == 1      # the fast path's re-gating and the general rows
    assert ekf == dict.fromkeys(UNUSED, 0)
    # negative control: a dispatcher compiled in the process is counted
    assert control["rangeproc.estimation.adaptive:sh_adapt"] == 1
