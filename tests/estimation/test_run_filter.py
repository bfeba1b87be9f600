"""``run_filter``: the typed entry runs the shared loop's specialisation of one filter family,
refuses settings that combine families, and a run compiles (or loads) only the one it uses."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rangeproc.estimation.fading import fading_params
from rangeproc.estimation.forward import (
    EKF,
    UKF,
    FilterOutput,
    FilterPrior,
    FilterRows,
    FilterSettings,
    run_filter,
)
from rangeproc.estimation.spline_filter import spline_params
from rangeproc.models.measurement import CARTESIAN

GATE = np.full(7, np.inf)
STF = fading_params(0.95, 3.0, (1.0, 1.0, 1.0))


def _line(n: int = 60, seed: int = 3) -> tuple[FilterRows, FilterPrior, np.ndarray]:
    """Position fixes (1 m noise) of a target flying east at 100 m/s, 10 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    truth = np.column_stack([100.0 * t, np.zeros(n), np.full(n, 1000.0)])
    z = np.full((n, 6), np.nan)
    z[:, :3] = truth + rng.normal(0.0, 1.0, (n, 3))
    sigma = np.ones((n, 6))
    rows = FilterRows(t, np.arange(n), np.full(n, CARTESIAN), z, sigma, np.zeros((n, 3)),
                      np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64))
    x0 = np.zeros(9)
    x0[:3] = z[0, :3]
    x0[3] = 100.0
    prior = FilterPrior(x0, np.diag([4.0] * 3 + [25.0] * 3 + [1.0] * 3), np.full(n, 1.0))
    return rows, prior, truth


@pytest.mark.parametrize(("settings", "family"), [
    (FilterSettings(GATE), "ekf"),
    (FilterSettings(GATE, maneuver_norm=1.0), "askf"),
    (FilterSettings(GATE, method=UKF), "ukf"),
    (FilterSettings(GATE, adapt_window=20), "sage-husa"),
    (FilterSettings(GATE, method=UKF, fading=STF), "stukf"),
    (FilterSettings(GATE, spline=spline_params(0.999)), "spline"),
])
def test_each_family_runs_its_kernel_and_names_its_outputs(settings: FilterSettings,
                                                           family: str) -> None:
    rows, prior, truth = _line()
    assert settings.family == family
    out = run_filter(rows, prior, settings)
    assert isinstance(out, FilterOutput)
    n, E = len(rows.meas_epoch), len(rows.epoch_t)
    assert out.xf.shape == (E, 9) and out.Pf.shape == (E, 45)
    assert out.nis.shape == out.dof.shape == out.rejected.shape == out.ll_rows.shape == (n,)
    assert np.all(out.dof == 3) and out.n_resets == 0
    assert out.loglik == pytest.approx(out.ll_rows.sum())
    err = np.linalg.norm(out.xf[20:, :3] - truth[20:], axis=1)
    assert np.sqrt(np.mean(err ** 2)) < 2.0
    assert out.sigma_used.shape == ((n, 6) if family == "sage-husa" else (0, 6))
    assert out.fade.shape == ((E, 9) if family in ("stukf", "spline") else (0, 9))
    assert out.jerk.shape == ((E, 3) if family == "spline" else (0, 3))
    assert out.knot.shape == ((E,) if family == "spline" else (0,))


def test_the_ekf_and_ukf_kernels_agree_on_linear_rows() -> None:
    """Cartesian fixes are linear in the state: both updates are the Kalman update."""
    rows, prior, _ = _line()
    a = run_filter(rows, prior, FilterSettings(GATE, method=EKF))
    b = run_filter(rows, prior, FilterSettings(GATE, method=UKF))
    np.testing.assert_allclose(a.xf, b.xf, atol=1e-8, rtol=0)
    np.testing.assert_allclose(a.Pf, b.Pf, atol=1e-8, rtol=1e-9)


@pytest.mark.parametrize("settings", [
    FilterSettings(GATE, adapt_window=20, fading=STF),
    FilterSettings(GATE, fading=STF, spline=spline_params(0.999)),
    FilterSettings(GATE, adapt_window=20, spline=spline_params(0.999)),
])
def test_settings_that_combine_families_are_refused(settings: FilterSettings) -> None:
    rows, prior, _ = _line()
    with pytest.raises(ValueError, match="at most one of them runs"):
        run_filter(rows, prior, settings)


def test_a_maneuver_norm_needs_the_ekf_and_x_lin_the_epochs() -> None:
    rows, prior, _ = _line()
    with pytest.raises(ValueError, match="maneuver norm"):
        run_filter(rows, prior, FilterSettings(GATE, method=UKF, maneuver_norm=1.0))
    with pytest.raises(ValueError, match="x_lin has 3 rows"):
        run_filter(rows, prior._replace(x_lin=np.zeros((3, 9))), FilterSettings(GATE))


def test_linearising_at_the_truth_changes_nothing_on_linear_rows() -> None:
    rows, prior, _ = _line()
    plain = run_filter(rows, prior, FilterSettings(GATE))
    at = run_filter(rows, prior._replace(x_lin=plain.xf), FilterSettings(GATE))
    np.testing.assert_allclose(plain.xf, at.xf, atol=1e-9, rtol=0)


def test_a_run_loads_only_the_kernel_of_its_family() -> None:
    """In a fresh process, the EKF leaves the other families' specialisations of the shared
    loop unmade and uncompiled (unloaded)."""
    code = (
        f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from test_run_filter import _line, GATE\n"
        "from rangeproc.estimation import forward_loop\n"
        "from rangeproc.estimation.forward import FilterSettings, run_filter\n"
        "rows, prior, _ = _line()\n"
        "run_filter(rows, prior, FilterSettings(GATE))\n"
        "for (name, n), k in forward_loop._KERNELS.items():\n"
        "    print(f'{name}/{n}', len(k.signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=300).stdout
    counts = dict(line.split() for line in out.splitlines())
    assert counts == {"ekf/9": "1"}


def test_the_specialised_loops_load_from_the_cache_in_a_fresh_process() -> None:
    """A second fresh process loads the EKF's and the IMM's specialised loops from the
    cache the first one filled (a compiled helper in a closure cell made numba miss it and
    recompile in every process)."""
    code = (
        f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "import numpy as np\n"
        "from test_run_filter import _line, GATE\n"
        "from rangeproc.estimation import forward_loop, imm\n"
        "from rangeproc.estimation.forward import FilterSettings, run_filter\n"
        "rows, prior, _ = _line()\n"
        "run_filter(rows, prior, FilterSettings(GATE))\n"
        "run_filter(rows, prior, FilterSettings(GATE, imm=(np.array([0, 1]), "
        "np.array([[-0.1, 0.1], [0.1, -0.1]]))))\n"
        "for k in (forward_loop._KERNELS[('ekf', 9)], imm._KERNELS[9]):\n"
        "    print(sum(k.stats.cache_misses.values()))\n")
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True, timeout=600).stdout
    assert out.split() == ["0", "0"]
