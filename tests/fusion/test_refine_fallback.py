"""A refinement pass that fails (a numerical error, or the divergence guard firing more often)
leaves the pass it refines as the result: that pass is let go while the next runs and done
again from its inputs, so the kept track must be exactly the one first computed."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from rangeproc.errors import NumericalError
from rangeproc.fusion import centralised, refinement
from rangeproc.fusion.centralised import fuse_span
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.settings import ProcessingSettings

from conftest import gps_line_batch


def _gps_batch(seed: int):
    """A minute of 4 Hz GPS rows on an accelerating line, their sigma stated too small (the
    refinement moves it)."""
    return gps_line_batch(np.arange(0.0, 60.0, 0.25), np.random.default_rng(seed), noise=3.0,
                          velocity=(100.0, 50.0, -2.0), accel=(1.0, 0.0, 0.0))


@pytest.mark.parametrize("fail_call, kept_call", [(2, 0), (3, 1)])
@pytest.mark.parametrize("how", ["error", "resets"])
def test_the_refined_pass_is_done_again_and_kept_when_its_refinement_fails(
        monkeypatch, caplog, fail_call, kept_call, how):
    calls = []
    real = centralised.run_pass

    def spy(*args, **kwargs):
        out = real(*args, **kwargs)
        calls.append(out)
        if len(calls) == fail_call:
            if how == "error":
                raise NumericalError("injected failure")
            return out._replace(resets=out.resets + 3)
        return out

    monkeypatch.setattr(centralised, "run_pass", spy)       # the first pass
    monkeypatch.setattr(refinement, "run_pass", spy)        # the refinement passes
    with caplog.at_level(logging.WARNING, logger="rangeproc.fusion.refinement"):
        res = fuse_span(_gps_batch(3), 2.0,
                        EstimatorSettings(processing=ProcessingSettings(noise_passes=2)))
    assert "the pass it refines is kept" in caplog.text
    assert len(calls) == fail_call + 1                  # the kept pass was done once more
    again, first = calls[-1], calls[kept_call]
    np.testing.assert_array_equal(again.xs, first.xs)
    np.testing.assert_array_equal(again.Ps, first.Ps)
    np.testing.assert_array_equal(res.xs, first.xs)
    np.testing.assert_array_equal(res.nis, first.nis)
    np.testing.assert_array_equal(res.res, first.res)   # GPS rows: nothing corrected since


def test_without_a_failure_each_pass_runs_once(monkeypatch):
    calls = []
    real = centralised.run_pass

    def spy(*args, **kwargs):
        calls.append(real(*args, **kwargs))
        return calls[-1]

    monkeypatch.setattr(centralised, "run_pass", spy)       # the first pass
    monkeypatch.setattr(refinement, "run_pass", spy)        # the refinement passes
    res = fuse_span(_gps_batch(3), 2.0,
                    EstimatorSettings(processing=ProcessingSettings(noise_passes=2)))
    assert len(calls) == 3
    np.testing.assert_array_equal(res.xs, calls[-1].xs)


def test_the_first_pass_is_let_go_while_the_refinement_runs(monkeypatch):
    # the first pass's covariances (the largest arrays of a span that is not thinned) are
    # not held while the refinement passes run: nothing keeps them once the first refinement
    # has its inputs (the white-or-discounted check must not hold them either)
    import gc
    import weakref
    first_ps: list = []
    alive_in_refinement: list[bool] = []
    real = centralised.run_pass

    def first_spy(*args, **kwargs):
        out = real(*args, **kwargs)
        first_ps.append(weakref.ref(out.Ps))
        return out

    def refinement_spy(*args, **kwargs):
        gc.collect()
        alive_in_refinement.append(first_ps[0]() is not None)
        return real(*args, **kwargs)

    monkeypatch.setattr(centralised, "run_pass", first_spy)
    monkeypatch.setattr(refinement, "run_pass", refinement_spy)
    settings = EstimatorSettings(processing=ProcessingSettings(noise_passes=2))
    assert settings.discount_first_pass and settings.processing.adapt_noise
    fuse_span(_gps_batch(3), 2.0, settings)
    assert len(first_ps) == 1 and alive_in_refinement == [False, False]


def test_each_refinement_pass_starts_on_handed_back_pages(monkeypatch):
    # before a refinement pass runs, the pass it refines is let go and the free pages handed
    # back (io.memory.release_freed_between, on a long span): its arrays do not land on the
    # pages the registration and the noise estimate freed, resident since the last tick
    import gc
    import weakref
    events: list = []
    made: list = []
    real = refinement.run_pass

    def pass_spy(*args, **kwargs):
        events.append("pass")
        out = real(*args, **kwargs)
        made.append(weakref.ref(out.Ps))
        return out

    def trim_spy(n_rows: int) -> bool:
        gc.collect()
        events.append(("trim", sum(r() is not None for r in made)))
        return True

    monkeypatch.setattr(refinement, "run_pass", pass_spy)
    monkeypatch.setattr(refinement, "release_freed_between", trim_spy)
    fuse_span(_gps_batch(3), 2.0, EstimatorSettings(processing=ProcessingSettings(noise_passes=2)))
    assert events == [("trim", 0), "pass", ("trim", 0), "pass"]
