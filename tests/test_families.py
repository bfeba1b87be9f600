"""The filter-family registry (``rangeproc.families``): one vocabulary from the config's
``processing.filter`` strings to the forward filter that runs, its parameters and its output."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import rangeproc.estimation.forward as forward
import rangeproc.estimation.imm as imm
from rangeproc.config import FILTERS, ProcessingSettings
from rangeproc.estimation.forward import FilterPrior, FilterRows, run_filter
from rangeproc.families import REGISTRY, STEPS, Family, family
from rangeproc.fusion.estimator_types import EstimatorSettings, pass_filter
from rangeproc.fusion.passes import filter_settings
from rangeproc.keys import declared
from rangeproc.models.measurement import CARTESIAN

OUTPUT_TYPES = {"FilterOutput": forward.FilterOutput, "IMMOutput": imm.IMMOutput}


def test_the_config_strings_are_the_registry() -> None:
    assert FILTERS == tuple(REGISTRY)
    assert declared(ProcessingSettings, "filter").allowed == FILTERS
    assert set(forward.FAMILIES) == set(FILTERS) - {"auto"}


@pytest.mark.parametrize("name", FILTERS)
def test_each_family_declares_keys_that_exist_with_their_units(name: str) -> None:
    f = family(name)
    fields = {fl.name for fl in dataclasses.fields(ProcessingSettings)}
    for key, unit in f.parameters:
        assert key in fields, key
        assert declared(ProcessingSettings, key).unit == unit, key
    assert set(f.adds) <= set(STEPS)
    out = OUTPUT_TYPES[f.output]
    assert set(f.outputs) <= set(out._fields)
    assert f.first in REGISTRY and not family(f.first).chooses


def test_an_unknown_family_is_named_with_the_known_ones() -> None:
    with pytest.raises(KeyError, match="unknown filter family 'kalman'.*ekf"):
        family("kalman")
    with pytest.raises(ValueError, match="unknown step"):
        Family(name="x", summary="x", adds=("telepathy",))


def test_a_pass_runs_the_declared_first_pass() -> None:
    for name, first in (("imm", "ekf"), ("stukf", "ukf"), ("auto", "ekf"), ("spline", "spline"),
                        ("askf", "askf")):
        chosen = pass_filter(ProcessingSettings(filter=name))
        assert chosen.first().name == first, name
        assert chosen.first().imm_models == (), name
    assert pass_filter(ProcessingSettings(filter="imm")).imm_models == (0, 1, 2)


def _rows(n: int = 40) -> tuple[FilterRows, FilterPrior]:
    rng = np.random.default_rng(5)
    t = np.arange(n) * 0.1
    z = np.full((n, 6), np.nan)
    z[:, :3] = np.column_stack([100.0 * t, 5.0 * t**2, np.full(n, 1000.0)]) \
        + rng.normal(0.0, 1.0, (n, 3))
    rows = FilterRows(t, np.arange(n), np.full(n, CARTESIAN), z, np.ones((n, 6)),
                      np.zeros((n, 3)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                      np.zeros(n, np.int64))
    x0 = np.zeros(9)
    x0[:3], x0[3] = z[0, :3], 100.0
    return rows, FilterPrior(x0, np.diag([4.0] * 3 + [25.0] * 3 + [1.0] * 3), np.full(n, 1.0))


@pytest.mark.parametrize("name", [f for f in FILTERS if not family(f).chooses])
def test_each_family_runs_through_run_filter_and_returns_its_declared_output(name: str) -> None:
    """The estimator's settings of each family give ``run_filter`` that family (the IMM too),
    and the output is the type it declares, with its own outputs filled."""
    st = EstimatorSettings(processing=ProcessingSettings(filter=name))
    settings = filter_settings(st, np.full(7, np.inf), 1.0 if name == "askf" else 0.0)
    assert settings.family == name
    rows, prior = _rows()
    out = run_filter(rows, prior, settings)
    assert type(out) is OUTPUT_TYPES[family(name).output]
    for field in family(name).outputs:
        assert getattr(out, field).shape[0] == len(rows.epoch_t) or field == "sigma_used", field
    assert np.isfinite(out.xf).all()


def test_the_imm_through_run_filter_is_its_kernel_bit_for_bit() -> None:
    st = EstimatorSettings(processing=ProcessingSettings(filter="imm"))
    settings = filter_settings(st, np.full(7, np.inf))
    rows, prior = _rows()
    out = run_filter(rows, prior, settings)
    codes, lam = settings.imm
    direct = imm.imm_forward(*rows, prior.x0, prior.P0, prior.q_steps, settings.gate,
                             settings.reset_after, settings.reset_inflation, np.empty((0, 9)),
                             codes, lam, np.full(3, 1.0 / 3.0))
    for a, b in zip(out, direct):
        np.testing.assert_array_equal(a, b)
