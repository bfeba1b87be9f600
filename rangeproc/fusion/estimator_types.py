"""The centralised estimator's types: which forward filter a pass runs (:class:`PassFilter`,
:func:`pass_filter`: a family of ``rangeproc.families``), the estimator's settings
(:class:`EstimatorSettings`) and its result (:class:`FusionResult`), kept below the algorithm
(``fusion.centralised``) so that the modules that read a result (products, audits,
summaries) need not import the algorithm."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from rangeproc.estimation.imm_models import MODEL_NAMES
from rangeproc.families import REGISTRY, Family, family
from rangeproc.estimation.tuning import MAX_SEARCH_ROWS
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.refraction_rows import RefractionSettings
from rangeproc.fusion.registration import Calibration, SensorCalibration
from rangeproc.settings import ProcessingSettings


@dataclass(frozen=True, kw_only=True, slots=True)
class PassFilter:
    """The forward filter a pass runs: a family of the registry (``rangeproc.families``), the
    estimator's reading of ``processing.filter`` (:func:`pass_filter`), with what a pass may
    change (the first pass runs the family's declared ``first_pass``, :meth:`first`; the
    lead-in runs the IMM, :meth:`lead_in`).

    family: the registry's family (its update, parameters, steps and output).
    imm_models: model codes of the IMM (``estimation.imm_models``: CV, CA, CT) when the family
        is the IMM; empty otherwise. Its first pass is the EKF; the refinement passes run the
        IMM from that pass's smoothed first state (``imm_start``) with its process noise;
        ``noise_passes = 0`` leaves the EKF. ``processing.imm_sojourn``: mean time (s) in a
        model before a switch.
    spline_fit: the batch spline fit after the passes although the family declares none
        (``filter = "auto"`` on range rates alone: the EKF's, ``fusion.filter_choice``).
    """

    family: Family = REGISTRY["ekf"]
    imm_models: tuple[int, ...] = ()
    spline_fit: bool = False

    @property
    def name(self) -> str:
        """The family's ``processing.filter`` string."""
        return self.family.name

    @property
    def fits_spline(self) -> bool:
        """The batch spline fit follows the passes (the family's, or ``spline_fit``)."""
        return self.family.spline_fit or self.spline_fit

    def first(self) -> PassFilter:
        """The filter of the first pass: the family's declared ``first_pass``."""
        first = family(self.family.first)
        return replace(self, family=first, imm_models=self.imm_models if first.name == "imm"
                       else ())

    def lead_in(self, default_models: tuple[int, ...]) -> PassFilter:
        """The IMM of a lead-in before the first fix: the configured IMM's models, else
        ``default_models``."""
        return replace(self, family=REGISTRY["imm"],
                       imm_models=self.imm_models or default_models)


def pass_filter(p: ProcessingSettings) -> PassFilter:
    """The forward filter that ``p.filter`` names ("auto" runs the EKF until ``fuse_target``
    has chosen, ``fusion.filter_choice``)."""
    chosen = family(p.filter)
    if chosen.chooses:
        chosen = family(chosen.first)
    return PassFilter(family=chosen, imm_models=tuple(MODEL_NAMES.index(m) for m in p.imm_models)
                      if chosen.name == "imm" else ())


@dataclass(frozen=True, kw_only=True, slots=True)
class EstimatorSettings:
    """Settings of the centralised estimator.

    processing: the config's ``[processing]`` section (``settings.ProcessingSettings``, where
        each key is declared): the estimator reads its fields by name (``gate_probability``,
        ``noise_passes``, ``adapt_noise``, ``process_noise``, ``max_gap``, the filter's own).
    filter_override: the forward filter of the passes when not the one ``processing.filter``
        names (the first pass, the lead-in, "auto"'s choice); :attr:`family` is the one in
        force.
    q_grid: candidate q values for the likelihood search of ``process_noise`` when not given
        (maximum likelihood over ``q_grid`` first, then local EM updates over ``q_window``
        seconds); q_search_rows: at most this many rows (evenly spread) in it, or
        ``tuning.MIN_SEARCH_RATE_HZ`` per second of the span when that is more.
    q_window: window (s) of the local process-noise estimate.
    reset_after / reset_inflation: divergence guard of the filter (see
        ``estimation.forward.FilterSettings``).
    ukf: the UKF's ``(alpha, beta, kappa)``, kappa = 3 - n per Ye and Cui.
    calibration: what the registration may estimate per sensor index (``fusion.registration``;
        empty: no calibration); refraction: the refraction removed from the rows
        (``fusion.refraction_rows``; None: none).
    restart_lockouts: cut a span where its track was locked out of its sparse plots and
        estimate the parts on their own (``fusion.lockout``); the track synthesis's quick
        trajectories leave it off (``pipeline``: an association trial is no output).
    discount_first_pass: run the first pass again with the rows of sensors whose first-pass
        residuals are correlated in time discounted, where that fits more of the span's
        position rows (``fusion.centralised``); the association's trials leave it off (a
        trial that fits only with its rows discounted is a hint that they are two objects').
    """

    processing: ProcessingSettings = ProcessingSettings()
    filter_override: PassFilter | None = None
    q_grid: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2, 5, 8))
    q_window: float = 2.0
    q_search_rows: int = MAX_SEARCH_ROWS
    reset_after: int = 50
    reset_inflation: float = 100.0
    ukf: tuple[float, float, float] = (1.0, 2.0, 3.0 - 9)
    calibration: tuple[SensorCalibration | None, ...] = ()
    refraction: RefractionSettings | None = None
    restart_lockouts: bool = True
    discount_first_pass: bool = True

    @property
    def family(self) -> PassFilter:
        """The forward filter of the passes: ``filter_override``, else
        ``processing.filter``'s."""
        return self.filter_override or pass_filter(self.processing)

    def with_processing(self, **changes: object) -> EstimatorSettings:
        """These settings with ``[processing]`` values changed (``ProcessingSettings`` fields)."""
        return replace(self, processing=replace(self.processing, **changes))

    def with_filter(self, chosen: PassFilter) -> EstimatorSettings:
        """These settings with the passes' forward filter ``chosen``."""
        return replace(self, filter_override=chosen)


@dataclass(frozen=True, slots=True)
class FusionResult:
    """Smoothed estimate of one target and the per-row bookkeeping.

    epoch_t: (E,) s; xs: (E, n); Ps: (E, n(n+1)/2) packed covariance; grid: (E,) bool, True at
    output-grid epochs; batch: the rows with the sigmas finally used; meas_epoch: (N,);
    used: (N, 6) bool, component measured and accepted by the gate in the final pass;
    nis, dof: (N,) row innovation chi-square and measured components; res, hph: (N, 6) smoothed
    residuals and explained variance; q: (E,) white-jerk PSD used on the step ending at each
    epoch (m^2/s^5); noise: global sigma estimate per
    (sensor index, component); n_resets: divergence-guard resets in the final pass;
    spans: ((t_first, t_last), ...) s of the estimated spans; n_unstarted: rows per sensor
    index of spans that could not be started (no position fix) and are not in ``batch``;
    maneuver_norm: the norm (m/s^2) the constrained ASKF imposed, None when unconstrained;
    model_prob: (E, r) the IMM's smoothed model probabilities, model_names their models (None
    and () for the other filters); down_weight: (N, 6) int8, why the final pass's sigma of a
    component exceeds its sensor's global noise estimate (``fusion.noise.BURST`` / ``HUBER``;
    None without noise adaptation); filter_used: (the forward filter run, why): the
    configured one, or ``filter = "auto"``'s choice (``fusion.filter_choice``).
    """

    epoch_t: np.ndarray
    xs: np.ndarray
    Ps: np.ndarray
    grid: np.ndarray
    batch: MeasurementBatch
    meas_epoch: np.ndarray
    used: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    res: np.ndarray
    hph: np.ndarray
    q: np.ndarray
    noise: dict[tuple[int, int], float]
    n_resets: int
    spans: tuple[tuple[float, float], ...] = ()
    n_unstarted: dict[int, int] = field(default_factory=dict)
    maneuver_norm: float | None = None
    model_prob: np.ndarray | None = None
    model_names: tuple[str, ...] = ()
    down_weight: np.ndarray | None = None
    calibration: tuple[Calibration, ...] = ()
    filter_used: tuple[str, str] = ("", "")
