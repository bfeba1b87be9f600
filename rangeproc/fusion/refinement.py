"""The refinement passes of one span (``fusion.centralised``, stage 5).

Each pass re-linearises every measurement at the previous smoothed trajectory (iterated
extended Kalman smoother, a Gauss-Newton step on the whole flight: Bell, "The iterated Kalman
smoother as a Gauss-Newton method", SIAM J. Optim. 1994). Before each pass, when configured,
refraction is removed from the rows (once, at the first pass's geometry), the sensors' biases,
latency and mount misalignment are registered and removed (``fusion.registration``), and,
with ``adapt_noise``, the measurement noise is estimated again from the residuals
(``fusion.noise``) and the local process noise from the smoother's EM statistic
(``estimation.tuning``). A long span's passes before the last run on thinned rows; the last
one on every row (``fusion.thinning``).

What one pass hands to the next is a :class:`Refinement` (the rows as corrected so far, the
latest pass and how to redo it, the process noise, the noise and calibration found so far);
what every pass starts from is a :class:`PassInputs`.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from rangeproc.errors import NumericalError
from rangeproc.estimation.tuning import local_process_noise, search_rows, start_process_noise
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.noise import residual_sigma
from rangeproc.fusion.passes import (
    PassResult,
    corrected_residuals,
    run_pass,
    without_covariances,
)
from rangeproc.fusion.refraction_rows import refraction_corrections
from rangeproc.fusion.registration import (
    Calibration,
    apply_increments,
    register,
    row_shift,
)
from rangeproc.fusion.thinning import Expanded, PassRows, carry_to_every_row
from rangeproc.io.memory import release_freed_between

log = logging.getLogger(__name__)

#: Rows the registration moves after the last refinement pass by more than this (their
#: largest RMS shift of one sensor component, in its sigmas, ``registration.row_shift``)
#: leave that pass's track fit to rows no longer there: every sensor's noise estimated from
#: its residuals would carry the shift (a late radar's pull on the track read as a clean
#: theodolite's noise), so up to ``SETTLING_PASSES`` more passes run on the corrected rows.
SETTLED_SHIFT = 0.1
SETTLING_PASSES = 2


@dataclass(frozen=True)
class PassInputs:
    """What every refinement pass of one span starts from.

    ``full``: the span's rows on its epochs (every row); ``start``: the state (n,) and
    covariance (n, n) the passes start from (the IMM's when the family mixes models);
    ``fix``: the state and covariance at the first position fix (the process-noise search
    starts there); ``gate`` (7,): the chi-square thresholds by degrees of freedom.
    """

    full: PassRows
    start: tuple[np.ndarray, np.ndarray]
    fix: tuple[np.ndarray, np.ndarray]
    gate: np.ndarray
    settings: EstimatorSettings


@dataclass
class Refinement:
    """The state one refinement pass hands to the next.

    ``rows``: the rows of the passes (thinned, or every row); ``batch``: those rows as
    corrected so far (refraction, calibration, noise); ``out``: the latest pass and
    ``redo``: the call that runs it again from its inputs; ``q``: the next pass's process
    noise (E,) (m^2/s^5), ``q_used``: ``out``'s, ``q_next``: a searched one waiting for the
    next pass; ``expanded``: a thinned pass carried to every row (before the final pass);
    ``noise``: the estimated sigma per (sensor, component); ``cal``: the calibration so far;
    ``why`` (N, M) int8: each row component's down-weighting reason (``fusion.noise``).
    """

    rows: PassRows
    batch: MeasurementBatch
    out: PassResult | None
    redo: Callable[[], PassResult]
    q: np.ndarray
    q_used: np.ndarray
    why: np.ndarray
    q_next: np.ndarray | None = None
    expanded: Expanded | None = None
    noise: dict[tuple[int, int], float] = field(default_factory=dict)
    cal: Calibration | None = None


def searched_q(batch: MeasurementBatch, epoch_t: np.ndarray, x0: np.ndarray, P0: np.ndarray,
               gate: np.ndarray, settings: EstimatorSettings) -> tuple[float, np.ndarray]:
    """``estimation.tuning.start_process_noise`` over the span's rows (its epochs
    ``epoch_t``) with the settings' q grid, divergence guard and search rows."""
    return start_process_noise(batch, epoch_t, x0, P0, gate, settings.q_grid,
                               settings.reset_after, settings.reset_inflation,
                               max_rows=search_rows(float(epoch_t[-1] - epoch_t[0]),
                                                    settings.q_search_rows))


def refine(inp: PassInputs, box: list[tuple[PassResult, Callable[[], PassResult]]],
           rows: PassRows, q: np.ndarray, rho: float | None,
           tick: Callable[..., None]) -> Refinement:
    """The refinement passes from the pass in ``box`` (taken out of it, so that its arrays
    are let go once refined) on ``rows`` with process noise ``q`` (E,), constrained to the
    manoeuvre norm ``rho`` (m/s^2) when given. ``tick(n, note)``: progress, ``noise_passes``
    in all. Returns the state after the last pass (its ``out`` on every row)."""
    p = inp.settings.processing
    out, redo = box.pop()
    st = Refinement(rows=rows, batch=rows.batch, out=out, redo=redo, q=q, q_used=q,
                    why=np.zeros(inp.full.batch.z.shape, dtype=np.int8))
    del out
    k, last = 0, p.noise_passes - 1      # last: the final pass's step (settling adds)
    while k <= last:
        if st.rows.kept is not None and k == p.noise_passes - 1:   # the final pass: all rows
            _every_row(st, inp, rho)
        elif inp.settings.refraction is not None and k == 0:   # geometry of the first pass
            st.batch = refraction_corrections(st.batch, st.out.xs, st.rows.meas_epoch,
                                              inp.settings.refraction)
            corrected = np.flatnonzero(np.asarray(inp.settings.refraction.surface_n) > 0)
            st.out = st.out._replace(res=_residuals_of(st, corrected))
        # the pass refined here is not the result (the next pass replaces it): its
        # covariances go before the registration and the noise estimate allocate theirs
        st.out = without_covariances(st.out)
        if inp.settings.calibration:
            last = _register(st, inp, k, last)
        _next_noise(st, inp, k)
        if not _next_pass(st, inp, k, rho, tick):
            break
        k += 1
    if st.rows.kept is not None:       # stopped on a thinned pass: it is redone on every row
        _every_row(st, inp, rho)
        st.out = st.redo()
        st.why = np.zeros(inp.full.batch.z.shape, dtype=np.int8)
    return st


def _every_row(st: Refinement, inp: PassInputs, rho: float | None) -> None:
    """The last thinned pass carried to every row (module ``fusion.thinning``)."""
    st.expanded, st.batch, st.out, before, st.q, st.q_next = carry_to_every_row(
        inp.full, st.rows, st.out, st.q, st.noise, st.cal, inp.settings, inp.gate)
    st.redo = partial(run_pass, before, inp.full.epoch_t, inp.full.meas_epoch, *inp.start,
                      st.q, inp.gate, inp.settings, st.expanded.xs, rho or 0.0)
    st.q_used, st.rows = st.q, inp.full


def _residuals_of(st: Refinement, sensors) -> np.ndarray:
    """The latest pass's residuals with those of the rows of ``sensors`` recomputed."""
    if st.expanded is None:
        return corrected_residuals(st.batch, sensors, st.out, st.rows.meas_epoch)
    res = st.out.res.copy()
    at = np.flatnonzero(np.isin(st.batch.sensor, list(sensors)))
    res[at] = st.expanded.residuals(st.batch, st.rows.meas_epoch, at)[0]
    return res


def _register(st: Refinement, inp: PassInputs, k: int, last: int) -> int:
    """Register the sensors at the latest pass (step ``k``) and correct the rows; returns
    the final step, one later when the correction moved the rows after the last pass."""
    p, rows = inp.settings.processing, st.rows
    st.cal, dc, rate = register(st.batch, st.out.xs, st.out.res, rows.epoch_t,
                                rows.meas_epoch, rows.grid, st.q, inp.settings.calibration,
                                st.cal)
    if not dc.any():
        return last
    st.batch = apply_increments(st.batch, st.cal.terms, dc, rate)   # same track, new rows
    moved = [t.sensor for t, d in zip(st.cal.terms, dc) if d != 0.0]
    res_before = st.out.res
    st.out = st.out._replace(res=_residuals_of(st, moved))
    shift = row_shift(res_before, st.out.res, st.batch.sigma, st.batch.sensor)
    if (k == last and p.adapt_noise and shift > SETTLED_SHIFT
            and last < p.noise_passes - 1 + SETTLING_PASSES):
        last += 1   # the track was fit to rows since moved: noise anew
        log.info("registration moved the rows by %.2g sigma after the last "
                 "pass: one more, its noise from the corrected rows", shift)
    if k == 0 and p.process_noise is None:   # q anew on the corrected rows
        q0, st.q_next = searched_q(st.batch, rows.epoch_t, *inp.fix, inp.gate, inp.settings)
        log.info("registration corrected the rows: q = %.3g m^2/s^5 (maximum "
                 "likelihood again)", q0)
    return last


def _next_noise(st: Refinement, inp: PassInputs, k: int) -> None:
    """The measurement noise from the latest pass's residuals (``adapt_noise``) and the
    next pass's process noise (searched again, or local from the EM statistic)."""
    p = inp.settings.processing
    if p.adapt_noise:
        sigma, st.noise, st.why = residual_sigma(st.batch, st.out.res, st.out.hph,
                                                 st.out.used)
        st.batch = st.batch.with_sigma(sigma)
    if st.q_next is not None:
        st.q, st.q_next = st.q_next, None
    elif p.process_noise is None and st.out.em is not None:
        st.q = local_process_noise(st.rows.epoch_t, st.out.em, window=inp.settings.q_window,
                                   ceiling=max(inp.settings.q_grid))
    log.info("pass %d: median q = %.3g m^2/s^5", k + 2, float(np.median(st.q)))


def _next_pass(st: Refinement, inp: PassInputs, k: int, rho: float | None,
               tick: Callable[..., None]) -> bool:
    """Run refinement pass ``k + 2``; False when it failed or lost the object (the pass it
    refines is then kept and the refinement stops)."""
    p = inp.settings.processing
    # the pass refined here is let go before the next runs (its covariances and residuals:
    # 0.5 GB of the 2M-row sortie's peak); should the next fail, it is done again from its
    # inputs (the same values), its residuals taken at the rows as corrected since
    resets_before, q_before, redo_before = st.out.resets, st.q_used, st.redo
    st.redo = partial(run_pass, st.batch, st.rows.epoch_t, st.rows.meas_epoch, *inp.start,
                      st.q, inp.gate, inp.settings, st.out.xs, rho or 0.0)
    st.expanded = st.out = None
    # its pages, and those the registration and the noise estimate freed, handed back
    release_freed_between(len(st.batch))
    try:
        st.out = st.redo()
        failed = ""
    except NumericalError as exc:       # the pass before stands (its track is sound)
        failed = str(exc)
    st.q_used = st.q
    tick(1 if k < p.noise_passes else 0, f"pass {k + 2}")
    if not failed and (rho is not None or st.out.resets <= resets_before):
        return True
    # it lost the object: keep the pass before (a constrained pass is judged by
    # passes.constraint_agrees)
    log.warning("pass %d: %s; the pass it refines is kept", k + 2, failed or (
        f"the divergence guard fired {st.out.resets} times against "
        f"{resets_before} in the pass it refines"))
    st.out = None
    st.out = redo_before()
    st.out = st.out._replace(res=corrected_residuals(
        st.batch, range(len(st.batch.sensor_ids)), st.out, st.rows.meas_epoch))
    st.q_used = q_before
    if k + 1 < p.noise_passes:
        tick(p.noise_passes - k - 1, "")
    return False
