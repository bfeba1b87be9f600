"""Centralised multi-sensor estimation of one target: all rows through one EKF + RTS smoother.

Stages (each a function of arrays; numerics in the compiled kernels):

0. spans: the rows are cut wherever the target goes unobserved for longer than ``max_gap``;
   each span is estimated on its own (own start, own process noise) and has output epochs
   only inside it, so a long gap (or a stray time stamp that survived editing) costs no
   memory, no output rows and no numerical trouble from a covariance grown over hours;
1. epochs: the union of row times and output-grid times, so the smoother estimates the state
   exactly at the grid epochs (no interpolation between measurement epochs);
2. noise pre-edit: a-priori sigmas raised to difference-based estimates (``fusion.noise``);
3. initialisation from the first position fixes (``fusion.initialise``); rows long before
   them (angles, range rates) are estimated backwards in time from the smoothed state at the
   first fix (``fusion.lead_in``);
4. process noise: when not configured, the white-jerk PSD is chosen by maximising the
   innovation likelihood over a logarithmic grid, then made time-varying in the refinement
   passes from the smoother's EM statistic (``estimation.tuning``);
5. filter + smoother, residuals; then ``noise_passes`` refinement passes, each one
   re-linearising every measurement at the previous smoothed trajectory (iterated extended
   Kalman smoother, i.e. a Gauss-Newton step on the whole flight: Bell, "The iterated Kalman
   smoother as a Gauss-Newton method", SIAM J. Optim. 1994), and, with ``adapt_noise``,
   re-estimating the measurement noise from the residuals (global and burst-local) and the
   local process noise (EM); before each refinement pass, when configured, refraction is
   removed from the rows (``fusion.refraction_rows``, once) and the sensors' biases, latency
   and mount misalignment are registered and removed (``fusion.registration``), and the
   calibration's uncertainty is finally added to the output epochs' covariance. When the
   first registration corrects the rows, q is searched again on them (the first search saw
   the sensors' biases as motion: ``docs/methods/estimators.md``, step 3). When the last
   registration still moves the rows (``SETTLED_SHIFT``), up to ``SETTLING_PASSES`` more
   passes estimate the noise from a track fit to the corrected rows (``fusion.refinement``).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import NamedTuple

import numpy as np

from rangeproc.errors import NumericalError
from rangeproc.estimation.constraint import estimate_norm
from rangeproc.estimation.imm_models import CA, CV, MODEL_NAMES
from rangeproc.estimation.linalg import unpack
from rangeproc.fusion.batch import MeasurementBatch, concat_batches
from rangeproc.fusion.estimator_types import EstimatorSettings, FusionResult, PassFilter
from rangeproc.fusion.filter_choice import EKF_SPLINE_FIT, choose_filter
from rangeproc.fusion.initialise import NoPositionFix, Prior, initial_state, prior_at
from rangeproc.fusion.lockout import clean_restart, lockout_time
from rangeproc.fusion.lead_in import (
    forward_in_time,
    lead_in_rows,
    reversed_prior,
    time_reversed,
)
from rangeproc.fusion.noise import correlation_factors, difference_sigma, discounted_sigma
from rangeproc.fusion.passes import PassResult, constraint_agrees, imm_start, run_pass
from rangeproc.fusion.refinement import PassInputs, Refinement, refine, searched_q
from rangeproc.fusion.registration import apply_increments, calibration_covariance
from rangeproc.fusion.support import unsupported_time
from rangeproc.fusion.thinning import PassRows, thinned_pass_rows, thinning_stride
from rangeproc.quantiles import chi2_ppf

log = logging.getLogger(__name__)

#: The lead-in's models (``_fuse_with_lead_in``): constant velocity and constant acceleration.
LEAD_IN_MODELS = (CV, CA)
#: Packed entries of the kinematic 9x9 block (the first of the packed lower triangle).
N_PACKED_NODE = 45
#: Output epochs at a time whose covariance gets the calibration's (``_result``): the
#: additions' copies (2 x 360 B an epoch) stay at 3 MiB, not 25 MiB for a one-hour sortie.
CAL_BLOCK_EPOCHS = 4096
#: Cuts of one span at gate lock-outs of sparse plots at most (``fusion.lockout``).
MAX_LOCKOUT_CUTS = 4



def gate_thresholds(probability: float) -> np.ndarray:
    """(7,) chi-square thresholds indexed by degrees of freedom (index 0 unused)."""
    g = np.full(7, np.inf)
    g[1:] = chi2_ppf(probability, np.arange(1, 7))
    return g


def output_grid(t_first: float, t_last: float, rate_hz: float) -> np.ndarray:
    """Uniform grid (s) at ``rate_hz`` on whole multiples of the period within [first, last]."""
    k0 = int(np.ceil(t_first * rate_hz - 1e-9))
    k1 = int(np.floor(t_last * rate_hz + 1e-9))
    return np.arange(k0, k1 + 1, dtype=np.float64) / rate_hz


def span_slices(t: np.ndarray, max_gap: float) -> list[slice]:
    """Cut ascending row times ``t`` (s) wherever a step exceeds ``max_gap`` (s)."""
    cuts = (np.flatnonzero(np.diff(t) > max_gap) + 1).tolist()
    bounds = [0, *cuts, len(t)]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def fuse_target(batch: MeasurementBatch, rate_hz: float,
                settings: EstimatorSettings = EstimatorSettings(),
                tick: Callable[..., None] = lambda *a, **k: None,
                prior: Prior | None = None) -> FusionResult:
    """Estimate one target's trajectory from its measurement batch (see module docstring).

    Each span (stage 0) is estimated by :func:`fuse_span`; a span that cannot be started (no
    position fix in it) is left out with a warning and its rows counted in ``n_unstarted``.
    ``tick(n, note)`` advances ``1 + noise_passes`` in all (progress display). ``prior``: a
    given state of the target, used by the span nearest to its time when that span has no
    position fix to start from.

    Raises:
        NoPositionFix: no span can be started (the first span's reason).
    """
    used, why = choose_filter(settings.processing.filter, batch)
    chosen = (settings.with_processing(filter="ekf").with_filter(PassFilter(spline_fit=True))
              if used == EKF_SPLINE_FIT else settings.with_processing(filter=used))
    result = _fuse_spans(batch, rate_hz, chosen, tick, prior)
    log.info("filter %s: %s", used, why)
    return replace(result, filter_used=(used, why))


def _fuse_spans(batch: MeasurementBatch, rate_hz: float, settings: EstimatorSettings,
                tick: Callable[..., None], prior: Prior | None) -> FusionResult:
    slices = span_slices(batch.t, settings.processing.max_gap)
    if prior is not None:
        dist = [max(batch.t[sl.start] - prior.t, prior.t - batch.t[sl.stop - 1], 0.0)
                for sl in slices]
        with_prior = int(np.argmin(dist))
    if len(slices) == 1:
        parts = _fuse_cut(batch, rate_hz, settings, tick, prior)
        if len(parts) > 1:
            return _concat(parts, {})
        return replace(parts[0], spans=((float(batch.t[0]), float(batch.t[-1])),))
    done: list[FusionResult] = []
    unstarted: dict[int, int] = {}
    first_error: NoPositionFix | None = None
    ticked = 0.0
    for j, sl in enumerate(slices):
        part = batch.rows(sl)
        share = len(part) / len(batch)

        def span_tick(n: int = 1, note: str = "", share: float = share) -> None:
            nonlocal ticked
            before = int(ticked)
            ticked += n * share
            if int(ticked) > before:
                tick(int(ticked) - before, note)

        try:
            done.extend(_fuse_cut(part, rate_hz, settings, span_tick,
                                  prior if prior is not None and j == with_prior else None))
        except NoPositionFix as exc:
            first_error = first_error or exc
            log.warning("span %.3f to %.3f s (%d rows) left out: %s", part.t[0], part.t[-1],
                        len(part), exc)
            for i, c in zip(*np.unique(part.sensor, return_counts=True)):
                unstarted[int(i)] = unstarted.get(int(i), 0) + int(c)
    if not done:
        assert first_error is not None
        raise first_error
    n_passes = 1 + settings.processing.noise_passes
    if int(ticked) < n_passes:
        tick(n_passes - int(ticked), "")
    return _concat(done, unstarted)


def _fuse_cut(batch: MeasurementBatch, rate_hz: float, settings: EstimatorSettings,
              tick: Callable[..., None], prior: Prior | None) -> list[FusionResult]:
    """:func:`fuse_span` of one span, cut where its track was locked out of its sparse plots
    (``fusion.lockout``): the rows before and from the cut are estimated each on its own,
    and the later part is checked again (at most ``MAX_LOCKOUT_CUTS`` cuts). The cut stands
    when the later part alone follows its plots (``lockout.clean_restart``); a part that
    cannot be started from its own fixes also leaves the span as it was. Returns the parts'
    results in time order (one when nothing was cut)."""
    done: list[FusionResult] = []
    rows, result = batch, fuse_span(batch, rate_hz, settings, tick, prior)
    gate = gate_thresholds(settings.processing.gate_probability)
    quiet = lambda *a, **k: None                                   # noqa: E731
    for _ in range(MAX_LOCKOUT_CUTS if settings.restart_lockouts else 0):
        t_cut = lockout_time(result, gate)
        if t_cut is None:
            break
        k = int(np.searchsorted(rows.t, t_cut, side="left"))
        try:
            tail = fuse_span(rows.rows(slice(k, None)), rate_hz, settings, quiet)
            if not clean_restart(tail, result, gate, t_cut):
                break
            head = fuse_span(rows.rows(slice(0, k)), rate_hz, settings, quiet,
                             prior if not done else None)
        except NoPositionFix:
            break
        log.info("span %.3f to %.3f s: track locked out of its plots at %.3f s; estimated "
                 "again from there", rows.t[0], rows.t[-1], t_cut)
        done.append(head)
        rows, result = rows.rows(slice(k, None)), tail
    done.append(result)
    return done


def _concat(parts: list[FusionResult], unstarted: dict[int, int]) -> FusionResult:
    """One result from the results of consecutive spans."""
    offsets = np.cumsum([0] + [len(p.epoch_t) for p in parts[:-1]])
    noise: dict[tuple[int, int], float] = {}
    weight: dict[tuple[int, int], int] = {}
    for p in parts:                       # row-weighted mean variance of each sensor's noise
        for key, sig in p.noise.items():
            n = int((p.batch.sensor == key[0]).sum())
            noise[key] = noise.get(key, 0.0) + n * sig * sig
            weight[key] = weight.get(key, 0) + n
    noise = {k: float(np.sqrt(v / max(weight[k], 1))) for k, v in noise.items()}

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts])

    return FusionResult(
        epoch_t=cat("epoch_t"), xs=cat("xs"), Ps=cat("Ps"), grid=cat("grid"),
        batch=concat_batches([p.batch for p in parts]),
        meas_epoch=np.concatenate([p.meas_epoch + o for p, o in zip(parts, offsets)]),
        used=cat("used"), nis=cat("nis"), dof=cat("dof"), res=cat("res"), hph=cat("hph"),
        q=cat("q"), noise=noise, n_resets=sum(p.n_resets for p in parts),
        spans=tuple((float(p.batch.t[0]), float(p.batch.t[-1])) for p in parts),
        n_unstarted=unstarted, maneuver_norm=parts[0].maneuver_norm,
        model_prob=cat("model_prob") if parts[0].model_prob is not None else None,
        down_weight=cat("down_weight") if parts[0].down_weight is not None else None,
        model_names=parts[0].model_names,
        calibration=tuple(c for p in parts for c in p.calibration))


def fuse_span(batch: MeasurementBatch, rate_hz: float,
              settings: EstimatorSettings = EstimatorSettings(),
              tick: Callable[..., None] = lambda *a, **k: None,
              prior: Prior | None = None, *, grid_t: np.ndarray | None = None,
              from_prior: bool = False) -> FusionResult:
    """Estimate the trajectory over one span of rows (stages 1-5 of the module docstring).

    The track starts from the span's first position fixes; only when there are none (e.g.
    range rates alone), or with ``from_prior``, from ``prior`` moved to the first epoch. Rows
    more than ``LEAD_IN_S`` before the first fix are estimated backwards from it
    (``fusion.lead_in``, :func:`_fuse_with_lead_in`). ``grid_t``: the output epochs (s),
    default the grid at ``rate_hz`` over the rows. ``tick(n, note)`` is called once per pass
    (progress display).

    Raises:
        NoPositionFix: no position fix and no prior.
    """
    if grid_t is None and not from_prior:
        lead = lead_in_rows(batch)
        if lead:
            try:
                return _fuse_with_lead_in(batch, lead, rate_hz, settings, tick)
            except NumericalError as exc:     # the forward start from the first row stands
                log.warning("lead-in of %d rows before the first fix: %s; started at the "
                            "first row", lead, exc)
    if grid_t is None:
        grid_t = output_grid(float(batch.t[0]), float(batch.t[-1]), rate_hz)
    p, family = settings.processing, settings.family
    if p.adapt_noise:
        batch = batch.with_sigma(difference_sigma(batch))
    full = PassRows.of(batch, grid_t)
    work = thinned_pass_rows(full, grid_t, p.noise_passes)   # the passes before the last one
    if work.kept is not None:
        log.info("long span: %d rows; passes 1 to %d on %d of them (each series thinned evenly,"
                 " by %d at most), the final pass on every row", len(batch), p.noise_passes,
                 len(work.kept), thinning_stride(len(batch), p.noise_passes))
    x0, P0, started = _start_state(batch, float(full.epoch_t[0]), prior, from_prior)
    gate = gate_thresholds(p.gate_probability)
    q = _first_q(full, work, x0, P0, gate, settings)
    # askf: the first pass is unconstrained (the constraint needs the maneuver's direction,
    # which the data give): the refinement passes impose it, linearised at its smoothed track
    rho = p.maneuver_norm if "norm-constraint" in family.family.adds else None
    # the first pass of the IMM is the constant-acceleration EKF (it starts the IMM's models),
    # of the strong-tracking UKF the UKF (fading is for model errors the refined noise and
    # process noise leave, not for a track still converging from its start)
    first_pass = _first_pass_call(work, x0, P0, q, gate, settings)
    first = first_pass()
    if p.adapt_noise and p.process_noise is None and settings.discount_first_pass:
        start = _FirstPass(batch, full, work, q, first_pass, first)
        batch, full, work, q, first_pass, first = _white_or_discounted(start, grid_t, x0, P0,
                                                                       gate, settings)
        del start       # it holds the white pass: let it go with ``first`` below
    if "norm-constraint" in family.family.adds and rho is None:
        rho = estimate_norm(first.xs[work.grid][:, 6:9])
        log.info("askf: maneuver norm %s", "not usable (unconstrained)" if rho is None
                 else f"{rho:.3g} m/s^2 (estimated)")
    tick(1, "pass 1")
    inp = PassInputs(full=full, gate=gate, settings=settings, fix=(x0, P0),
                     start=imm_start(first, x0, P0) if family.imm_models else (x0, P0))
    # the askf check refines the first pass once more, unconstrained; otherwise the first
    # pass's arrays (track, covariances, residuals: most of a span's memory) are let go as
    # soon as the refinement has moved on from them
    again = [(first, first_pass)] if rho is not None and p.noise_passes > 0 else []
    box = [(first, first_pass)]
    del first
    st = refine(inp, box, work, q, rho, tick)
    if again:
        free = refine(inp, again, work, q, None, lambda *a, **k: None)
        if not constraint_agrees(st.out, free.out, rho):
            rho, st = None, free
    return _result(st, full, settings, rho, (float(full.epoch_t[0]), x0, P0) if started
                   else None)


class _FirstPass(NamedTuple):
    """A span's rows with their sigmas, on its epochs (``full``) and as the passes before
    the last one use them (``work``), the process noise (E,) and the first pass (its call
    and result)."""

    batch: MeasurementBatch
    full: PassRows
    work: PassRows
    q: np.ndarray
    run: Callable[[], PassResult]
    out: PassResult


def _white_or_discounted(white: _FirstPass, grid_t: np.ndarray, x0: np.ndarray,
                         P0: np.ndarray, gate: np.ndarray, settings: EstimatorSettings
                         ) -> _FirstPass:
    """The first pass with every error taken as white (``white``) or, where that pass
    leaves stretches of the span unsupported by its own position rows (``fusion.support``:
    no output would be written there) and sensors' residuals are correlated in time
    (``fusion.noise.correlation_factors``), the process noise searched again and the pass
    run again with those rows discounted: whichever leaves less time unsupported (a tie
    keeps the white pass)."""
    before = unsupported_time(white.work.batch, white.out.used, white.out.res)
    if before <= 0.0:
        return white
    factors = correlation_factors(white.work.batch, white.out.res, white.out.used)
    if not factors:
        return white
    p = settings.processing
    batch = white.batch.with_sigma(discounted_sigma(white.batch, factors))
    full = PassRows.of(batch, grid_t)
    work = thinned_pass_rows(full, grid_t, p.noise_passes)
    q = _first_q(full, work, x0, P0, gate, settings)
    run = _first_pass_call(work, x0, P0, q, gate, settings)
    again = _FirstPass(batch, full, work, q, run, run())
    after = unsupported_time(white.work.batch, again.out.used, again.out.res)
    log.info("pass 1: errors correlated in time (%s): %.1f s unsupported white, %.1f s "
             "discounted", ", ".join(f"{batch.sensor_ids[s]}[{c}] x{f:.2f}"
                                     for (s, c), f in factors.items()), before, after)
    return again if after < before else white


def _first_pass_call(work: PassRows, x0: np.ndarray, P0: np.ndarray, q: np.ndarray,
                     gate: np.ndarray, settings: EstimatorSettings) -> Callable[[], PassResult]:
    """The first pass over ``work``'s rows from (x0, P0) with process noise ``q`` (E,), by
    the family's first filter, as a call that runs it (again)."""
    return partial(run_pass, work.batch, work.epoch_t, work.meas_epoch, x0, P0, q, gate,
                   settings.with_filter(settings.family.first()), np.empty((0, x0.shape[0])))


def _start_state(batch: MeasurementBatch, t0: float, prior: Prior | None, from_prior: bool
                 ) -> tuple[np.ndarray, np.ndarray, bool]:
    """The state (n,) and covariance (n, n) at the span's first epoch ``t0`` (s): from its
    first position fixes, or (none there, or ``from_prior``) from ``prior`` moved to ``t0``;
    True when from the prior (it then enters the spline fit).

    Raises:
        NoPositionFix: no position fix and no prior.
    """
    try:
        if from_prior:
            raise NoPositionFix("started from the given state")
        x0, P0 = initial_state(batch, t0)
        return x0, P0, False
    except NoPositionFix:
        if prior is None:
            raise
        x0, P0 = prior_at(prior, t0)
        return x0, P0, True


def _first_q(full: PassRows, work: PassRows, x0: np.ndarray, P0: np.ndarray,
             gate: np.ndarray, settings: EstimatorSettings) -> np.ndarray:
    """The first pass's process noise (E,) on ``work``'s epochs (m^2/s^5): the configured
    one, or the maximum-likelihood search over every row (the same on a thinned span)."""
    p = settings.processing
    if p.process_noise is not None:
        return np.full(len(work.epoch_t), p.process_noise)
    q0, q = searched_q(full.batch, full.epoch_t, x0, P0, gate, settings)
    if work.kept is not None:
        q = q[np.searchsorted(full.epoch_t, work.epoch_t)]
    log.info("pass 1: q = %.3g m^2/s^5 (maximum likelihood), local median %.3g", q0,
             float(np.median(q)))
    return q


def _result(st: Refinement, full: PassRows, settings: EstimatorSettings, rho: float | None,
            spline_prior: tuple[float, np.ndarray, np.ndarray] | None) -> FusionResult:
    """The span's result from its last refinement pass: the spline fit for the families that
    ask for it, the calibration's uncertainty added to the output epochs' covariance."""
    out, family, p = st.out, settings.family, settings.processing
    epoch_t, meas_epoch, grid = full.epoch_t, full.meas_epoch, full.grid
    xs, Ps, res, hph = out.xs, out.Ps, out.res, out.hph
    if family.fits_spline:                   # Zhou et al.'s post-flight batch spline fit
        from rangeproc.fusion.spline_refine import spline_refine   # scipy.interpolate: 0.1 s
        anomalies = out.knots if out.knots is not None else np.empty(0)
        xs, Ps, res, hph = spline_refine(
            out.batch, epoch_t, meas_epoch, xs, Ps, out.used, res, hph, st.q_used, anomalies,
            p.spline_knot_spacing, spline_prior)
    if st.cal is not None:         # the calibration's uncertainty is the trajectory's too
        at = np.flatnonzero(grid)
        for lo in range(0, len(at), CAL_BLOCK_EPOCHS):    # copies of a block, not of all
            k = at[lo:lo + CAL_BLOCK_EPOCHS]
            Ps[k, :N_PACKED_NODE] += calibration_covariance(st.cal, epoch_t[k])
    return FusionResult(epoch_t=epoch_t, xs=xs, Ps=Ps, grid=grid, batch=out.batch,
                        meas_epoch=meas_epoch, used=out.used, nis=out.nis, dof=out.dof,
                        res=res, hph=hph, q=st.q_used, noise=st.noise, n_resets=out.resets,
                        maneuver_norm=rho, model_prob=out.model_prob, down_weight=st.why,
                        model_names=tuple(MODEL_NAMES[c] for c in family.imm_models),
                        calibration=(st.cal,) if st.cal is not None else ())


def _fuse_with_lead_in(batch: MeasurementBatch, lead: int, rate_hz: float,
                       settings: EstimatorSettings, tick: Callable[..., None]) -> FusionResult:
    """One span whose first ``lead`` rows come before its first position fix
    (``fusion.lead_in``): the rest is estimated from the fix on, then the lead-in backwards in
    time from the smoothed state at the fix, on the span's output grid, by
    :data:`LEAD_IN_MODELS`' IMM (or the configured IMM's models) with its own process noise,
    and with the calibration the rest applied (biases and mount; a latency's correction needs
    the rows' rates and is not carried over).

    Why an IMM: angles alone do not range the object, so the lead-in's track is the fix's
    state carried back by the motion model. The constant-acceleration model alone carries the
    acceleration estimated at the fix back over the whole lead-in (0.1 m/s^2 is 54 m over
    33 s) and its local process noise grows where the range is unobserved; a straight flight
    needs the constant-velocity model, a turn the other; the IMM lets the data choose
    (tested in ``tests/fusion/test_lead_in.py``).
    """
    t_fix = float(batch.t[lead])
    grid_t = output_grid(float(batch.t[0]), float(batch.t[-1]), rate_hz)
    rest = fuse_span(batch.rows(slice(lead, None)), rate_hz, settings, tick,
                     grid_t=grid_t[grid_t >= t_fix])
    n = rest.xs.shape[1]
    P = np.empty((n, n))
    unpack(rest.Ps[0], P)
    prior = reversed_prior(float(rest.epoch_t[0]), rest.xs[0], P)
    early = batch.rows(slice(0, lead))
    for cal in rest.calibration:
        early = apply_increments(early, cal.terms, cal.applied, np.zeros((lead, 4)))
    lead_grid = grid_t[grid_t < t_fix]
    backwards = fuse_span(time_reversed(early), rate_hz,
                          replace(settings.with_filter(settings.family.lead_in(LEAD_IN_MODELS)),
                                  calibration=()),
                          prior=prior, grid_t=np.ascontiguousarray(-lead_grid[::-1]),
                          from_prior=True)
    backwards = forward_in_time(backwards)
    if not settings.family.imm_models:        # the rest has no model probabilities
        backwards = replace(backwards, model_prob=None, model_names=())
    both = _concat([backwards, rest], {})
    return replace(both, spans=((float(batch.t[0]), float(batch.t[-1])),),
                   maneuver_norm=rest.maneuver_norm)
