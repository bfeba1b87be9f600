"""The centralised estimator's types: which forward filter a pass runs (:class:`FilterFamily`,
:func:`filter_family`), the estimator's settings (:class:`EstimatorSettings`) and its result
(:class:`FusionResult`), kept below the algorithm (``fusion.centralised``) so that the
modules that read a result (products, audits, summaries) need not import the algorithm."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from rangeproc.estimation.forward import EKF, UKF
from rangeproc.estimation.imm_models import MODEL_NAMES
from rangeproc.estimation.tuning import MAX_SEARCH_ROWS
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.refraction_rows import RefractionSettings
from rangeproc.fusion.registration import Calibration, SensorCalibration
from rangeproc.settings import ProcessingSettings


@dataclass(frozen=True, kw_only=True, slots=True)
class FilterFamily:
    """Which forward filter a pass runs: the estimator's reading of ``processing.filter``
    (:func:`filter_family`). A pass may switch parts off (the first pass runs neither the IMM
    nor strong tracking; the lead-in runs the IMM alone).

    method: measurement update, ``EKF`` or ``UKF`` (``estimation.forward``).
    sage_husa: improved Sage-Husa adaptive measurement noise in the filter over windows of
        ``processing.sage_husa_window`` rows (``estimation.adaptive``), removing the noise
        mean too with ``processing.sage_husa_mean``.
    askf: the augmented-state filter of patent CN109581356A with the maneuver-norm constraint
        on the acceleration block, imposed in the refinement passes (linearised at the
        previous smoothed track; the first pass is unconstrained, ``noise_passes = 0`` leaves
        it so): ``processing.maneuver_norm`` (m/s^2) when given, else estimated from the first
        pass's smoothed accelerations (``estimation.constraint.estimate_norm``); without a
        usable norm the unconstrained ASKF (the constant-acceleration EKF).
    strong_tracking: Ye and Cui's strong tracking (``filter = "stukf"``,
        ``estimation.fading``) with ``processing.stukf_forgetting``, ``stukf_weakening`` and
        ``stukf_ratios``.
    imm_models: model codes of the IMM (``estimation.imm``: CV, CA, CT); empty = no IMM. Its
        first pass is the EKF; the refinement passes run the IMM (EKF updates) from that
        pass's smoothed first state (``imm_start``) with its process noise (the models carry
        the dynamics the local EM would otherwise follow); ``noise_passes = 0`` leaves the
        EKF. ``processing.imm_sojourn``: mean time (s) in a model before a switch.
    spline: Zhou et al.'s self-adaptive spline filter (``filter = "spline"``,
        ``estimation.spline_filter``): jerk input per segment, anomaly test (probability
        ``processing.spline_anomaly_probability``), adapted R and jerk at anomalies, then the
        batch cubic B-spline fit (``estimation.spline_fit``) on the anomaly knots plus regular
        knots (``processing.spline_knot_spacing``) replaces the smoothed track
        (``fusion.spline_refine``).
    spline_fit: that batch spline fit after the passes of another filter (``filter = "auto"``
        on range rates alone: the EKF's, ``fusion.filter_choice``).
    """

    method: int = EKF
    sage_husa: bool = False
    askf: bool = False
    strong_tracking: bool = False
    imm_models: tuple[int, ...] = ()
    spline: bool = False
    spline_fit: bool = False


def filter_family(p: ProcessingSettings) -> FilterFamily:
    """The forward filter that ``p.filter`` names (``settings.FILTERS``; "auto" runs the
    EKF until ``fuse_target`` has chosen, ``fusion.filter_choice``)."""
    f = p.filter
    return FilterFamily(method=UKF if f in ("ukf", "stukf") else EKF, sage_husa=f == "sage-husa",
                        askf=f == "askf", strong_tracking=f == "stukf",
                        imm_models=tuple(MODEL_NAMES.index(m) for m in p.imm_models)
                        if f == "imm" else (), spline=f == "spline")


@dataclass(frozen=True, kw_only=True, slots=True)
class EstimatorSettings:
    """Settings of the centralised estimator.

    processing: the config's ``[processing]`` section (``settings.ProcessingSettings``, where
        each key is declared): the estimator reads its fields by name (``gate_probability``,
        ``noise_passes``, ``adapt_noise``, ``process_noise``, ``max_gap``, the filter's own).
    family_override: the forward filter of the passes when not the one ``processing.filter``
        names (the first pass, the lead-in); :attr:`family` is the one in force.
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
    """

    processing: ProcessingSettings = ProcessingSettings()
    family_override: FilterFamily | None = None
    q_grid: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2, 5, 8))
    q_window: float = 2.0
    q_search_rows: int = MAX_SEARCH_ROWS
    reset_after: int = 50
    reset_inflation: float = 100.0
    ukf: tuple[float, float, float] = (1.0, 2.0, 3.0 - 9)
    calibration: tuple[SensorCalibration | None, ...] = ()
    refraction: RefractionSettings | None = None

    @property
    def family(self) -> FilterFamily:
        """The forward filter of the passes: ``family_override``, else
        ``processing.filter``'s."""
        return self.family_override or filter_family(self.processing)

    def with_processing(self, **changes: object) -> EstimatorSettings:
        """These settings with ``[processing]`` values changed (``ProcessingSettings`` fields)."""
        return replace(self, processing=replace(self.processing, **changes))

    def with_family(self, **changes: object) -> EstimatorSettings:
        """These settings with parts of the forward filter changed (``FilterFamily`` fields)."""
        return replace(self, family_override=replace(self.family, **changes))


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
