"""``summary.json`` declared: every section of a run's summary as a typed record.

A run's ``summary.json`` is one JSON object; each of its sections (the top level, a sensor's
entry, its row accounting, an object's entry, the association) is declared here once, as a
``TypedDict`` whose keys carry what they hold (:class:`Doc`, in ``Annotated``). The stages
build each section as its record (``stages.products``, ``stages.accounting``,
``fusion.sensor_use``, ``fusion.calibration_summary``, ``fusion.edit_audit``,
``tracking.routing``, ``pipeline``); the readers (``report.page``, ``report.headline``,
``timescale.from_summary``, ``campaign.summary``) read the same records. The outputs page's
tables of ``summary.json`` are generated from these declarations
(``rangeproc.summary_reference``), and ``tests/test_summary_types.py`` holds a run's summary
and the page against them.

A ``TypedDict`` is a plain ``dict`` at run time, so the JSON written is exactly the dict the
stages build: a key that only some runs have (a platform sensor's ``no_platform_geometry``,
a configured ``time_offset``) is ``NotRequired``, never written as null. Units are SI.

(No ``from __future__ import annotations`` here: ``TypedDict`` tells ``NotRequired`` keys
only from evaluated annotations.)
"""
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Annotated, Any, NotRequired, Required, TypedDict


@dataclass(frozen=True, slots=True)
class Doc:
    """What a key of ``summary.json`` holds, as the outputs page says it (one Markdown cell).
    Consecutive keys annotated with the same ``Doc`` object share one row of the page."""

    what: str


# --- sub-records (documented in their parent's row) ---------------------------------------

class ConfigRecord(TypedDict):
    """``config``: the run's config file."""

    file: Annotated[str, Doc("absolute path of the config")]
    sha256: Annotated[str, Doc("SHA-256 of its bytes (hex)")]


class InputRecord(TypedDict):
    """``inputs.<sensor id>``: a sensor's data file."""

    file: Annotated[str, Doc("the data file")]
    sha256: Annotated[str, Doc("SHA-256 of its bytes (hex)")]


class TimeScaleRecord(TypedDict):
    """``time_scale``: the calendar of the run's times (``timescale.TimeScale.as_dict``)."""

    calendar: Annotated[str, Doc("`utc` or `unknown`")]
    basis: Annotated[str, Doc("`unix`, or how the epoch was found")]
    epoch: Annotated[str | None, Doc("the UTC instant of time 0 (ISO 8601), or null")]
    t0: Annotated[float | None, Doc("the first time (s), or null")]


class RejectedPoint(TypedDict):
    """One entry of ``rejected_points.shown`` (``fusion.edit_audit.rejected_examples``)."""

    sensor: Annotated[str, Doc("sensor id")]
    row: Annotated[int, Doc("1-based data row in its file")]
    time: Annotated[float | None, Doc("s, range time scale")]
    component: Annotated[str, Doc("the component, `*` for the whole row")]
    value: Annotated[float | None, Doc("the value in the file's unit")]
    residual: Annotated[float | None, Doc("the residual in the file's unit")]
    unit: Annotated[str, Doc("the file's unit")]
    reason: Annotated[str, Doc("why it was rejected")]


class RejectedPoints(TypedDict):
    """``rejected_points``: every rejected point counted, the first ones listed."""

    n: Annotated[int, Doc("every rejected point")]
    shown: Annotated[list[RejectedPoint], Doc("the first 50 in time order")]


class EditExample(TypedDict):
    """One entry of ``sensors.<id>.edit_examples`` (``editing.record.EditRecord.examples``)."""

    row: Annotated[int, Doc("1-based file row")]
    time: Annotated[float, Doc("s, range time scale")]
    component: Annotated[str, Doc("the component or file column, `*` for the whole row")]
    reason: Annotated[str, Doc("the edit's reason")]
    value: Annotated[float | None, Doc("the value, SI")]


class NoiseEntry(TypedDict):
    """``sensors.<id>.noise.<component>`` (``fusion.sensor_use``)."""

    unit: Annotated[str, Doc("SI unit")]
    apriori: Annotated[float | None, Doc("the config's sigma")]
    estimated: Annotated[float | None, Doc("the noise the data show")]
    correlation: Annotated[float, Doc("lag-1 correlation of the residuals")]
    discount: Annotated[float, Doc("the factor the rows' sigma carries for correlated errors")]


class BiasEntry(TypedDict):
    """``sensors.<id>.bias.<component>`` (``fusion.sensor_use``)."""

    unit: Annotated[str, Doc("SI unit")]
    median_residual: Annotated[float | None, Doc("median residual, a quick bias indicator")]


class CalibrationTerm(TypedDict, total=False):
    """``sensors.<id>.calibration.<term>`` (``fusion.calibration_summary``): an estimate, an
    unobservable term or one not estimated; only the keys of its case are written."""

    estimate: Annotated[float | None, Doc("the estimate (SI), null when unobservable")]
    sigma: Annotated[float | None, Doc("its 1-sigma")]
    unit: Annotated[str, Doc("SI unit")]
    applied: Annotated[bool, Doc("significant: the measurements were corrected for it")]
    given: Annotated[float, Doc("a known correction from the config, included")]
    unobservable: Annotated[str, Doc("why the data cannot separate it")]
    not_estimated: Annotated[str, Doc("why it was not estimated")]


class TimeOffsetRecord(TypedDict):
    """``sensors.<id>.time_offset`` (``fusion.calibration_summary.time_offset_summary``)."""

    value: Annotated[float, Doc("the configured offset (s)")]
    unit: Annotated[str, Doc("`s`")]
    role: Annotated[str, Doc("clock scale alignment, or known latency correction")]
    instant: NotRequired[Annotated[str, Doc("the instant a clock alignment names")]]


class ObjectUseRecord(TypedDict):
    """``sensors.<id>.by_object.<object id>`` (``fusion.sensor_use``)."""

    n_used: Annotated[int, Doc("rows used")]
    noise: Annotated[dict[str, float | None], Doc("estimated sigma per component, SI")]
    median_residual: Annotated[dict[str, float | None], Doc("median residual per component")]


class ProcessNoiseRecord(TypedDict):
    """``targets.<id>.process_noise_q``."""

    unit: Annotated[str, Doc("`m^2/s^5`")]
    median: Annotated[float, Doc("median over the epochs")]
    p95: Annotated[float, Doc("95th percentile")]
    max: Annotated[float, Doc("largest")]


class FilterRecord(TypedDict):
    """``targets.<id>.filter``."""

    configured: Annotated[str, Doc("`[processing] filter`")]
    used: Annotated[str, Doc("what ran")]
    why: Annotated[str, Doc("why it ran")]


class ManeuverNormRecord(TypedDict):
    """``targets.<id>.maneuver_norm``."""

    unit: Annotated[str, Doc("`m/s^2`")]
    given: Annotated[float | None, Doc("the configured norm")]
    imposed: Annotated[float | None, Doc("the norm imposed")]


class SegmentRecord(TypedDict):
    """One of ``association.objects.<id>.segments``."""

    segment: Annotated[int, Doc("the piece's number (association.parquet's `segment`)")]
    sensor: Annotated[str, Doc("sensor id")]
    track_id: Annotated[Any, Doc("the sensor's track id, or null for plots")]
    rows: Annotated[int, Doc("rows in the piece")]
    t0: Annotated[float, Doc("first time (s)")]
    t1: Annotated[float, Doc("last time (s)")]


class AssociatedObject(TypedDict):
    """``association.objects.<id>``."""

    discovered: Annotated[bool, Doc("not declared in the config")]
    segments: Annotated[list[SegmentRecord], Doc("its pieces")]


class AnglePlots(TypedDict):
    """``association.angle_plots.<sensor id>``."""

    n_rows: Annotated[int, Doc("angle-only rows")]
    n_associated: Annotated[int, Doc("those associated")]
    fraction_used: Annotated[float | None, Doc("their share")]


# --- the sections the outputs page tables -------------------------------------------------

class RowsSummary(TypedDict):
    """``sensors.<id>.rows`` (``stages.accounting.rows_summary``)."""

    read: Annotated[int, Doc("data rows in the file (as `n_read`)")]
    used: Annotated[int, Doc("rows of which some component entered an object's fusion (an "
                             "INS: its rows kept)")]
    no_measurement: Annotated[int, Doc(
        "rows with every measurement cell empty (an INS row: an attitude or position cell "
        "empty)")]
    rejected: Annotated[dict[str, int], Doc(
        "per reason, rows removed whole before estimation or with every component edited (the "
        "reasons of [edits.parquet](#editsparquet): `duplicate`, `repeated stamp`, `time`, "
        "`limit`, `speed`, `pre-edit`, `isolated`), and `gate`: rows the estimator measured "
        "and used no component of")]
    no_platform_geometry: NotRequired[Annotated[int, Doc(
        "(platform sensors) rows outside the INS log's span or in its gaps")]]
    not_associated: NotRequired[Annotated[dict[str, int], Doc(
        "(radars and theodolites) per reason of [association.parquet](#associationparquet), "
        "rows no object took: `no object fits`, `clutter`, `angle-only plot`, `segment too "
        "short to start an object`")]]
    not_started: Annotated[int, Doc("rows of a span where no object could be started")]


_KIND_FILE = Doc("the sensor's kind and data file")
_SPAN = Doc("the time span of the sensor's rows (s)")
_TARGETS = Doc("the first object the sensor measured, and every object it measured")


class ScreenedSensor(TypedDict):
    """The part of ``sensors.<id>`` that reading and screening know
    (``stages.products.sensor_summaries``; ``n_no_platform_geometry`` and ``n_unstarted`` are
    counted by the products stage)."""

    kind: Annotated[str, _KIND_FILE]
    file: Annotated[str, _KIND_FILE]
    n_read: Annotated[int, Doc("rows in the file")]
    n_rows: Annotated[int, Doc("rows with at least one measured component")]
    n_edited: Annotated[dict[str, int], Doc(
        "rows or components removed before estimation, per reason (`duplicate`, `repeated "
        "stamp`, `time`, `limit`, `speed`, `pre-edit`, `isolated`; see "
        "[edits.parquet](#editsparquet))")]
    edit_examples: Annotated[list[EditExample], Doc(
        "a few of those edits: `row` (1-based file row), `time`, `component`, `reason`, "
        "`value`")]
    n_no_platform_geometry: Annotated[int, Doc(
        "rows of a platform sensor outside its INS's time span (not used)")]
    n_unstarted: Annotated[int, Doc(
        "rows in spans where no track could be started (not used)")]
    t_first: Annotated[float | None, _SPAN]
    t_last: Annotated[float | None, _SPAN]


class SensorUse(TypedDict, total=False):
    """The part of ``sensors.<id>`` that the objects' use of its rows gives
    (``fusion.sensor_use.sensor_use``). A sensor no object used (an INS) has only ``n_used``
    and ``n_rejected`` (screening's: an INS's rows kept, else 0)."""

    n_used: Required[Annotated[int, Doc("rows the estimation used (at least one component)")]]
    n_rejected: Required[Annotated[int, Doc("rows with measurements of which none was used")]]
    n_partly_rejected: Annotated[int, Doc("used rows of which some component was rejected")]
    n_components_rejected: Annotated[dict[str, int], Doc(
        "rejected components per component name")]
    noise: Annotated[dict[str, NoiseEntry], Doc(
        "per component: `apriori` (the config's sigma, SI) and `estimated` (the noise the data "
        "show, SI), with its `unit`; `correlation`, the lag-1 correlation of its residuals "
        "(consecutive rows of one object), and `discount`, the factor its rows' sigma carries "
        "for errors correlated in time (1 for white ones; "
        "[Editing](methods/editing.md#noise-estimation))")]
    bias: Annotated[dict[str, BiasEntry], Doc(
        "per component: `median_residual` (SI) and its `unit`, a quick bias indicator")]
    target: Annotated[str, _TARGETS]
    targets: Annotated[list[str], _TARGETS]
    by_object: Annotated[dict[str, ObjectUseRecord], Doc(
        "with several objects: per object, its `n_used` rows, `noise` (estimated sigma per "
        "component, SI) and `median_residual` per component")]


class EditCounts(TypedDict):
    """The part of ``sensors.<id>`` counted from ``edits.parquet``
    (``fusion.edit_audit.edit_summary``)."""

    n_rejected_points: Annotated[int, Doc("every rejected component, of any reason")]
    n_rejected_by_reason: Annotated[dict[str, int], Doc(
        "the same per reason (`gate` and the editing reasons)")]
    n_down_weighted: Annotated[int, Doc(
        "components used with a weight below 2/3 of their sensor's "
        "([edits.parquet](#editsparquet))")]
    n_down_weighted_by_reason: Annotated[dict[str, int], Doc(
        "the same per reason (`burst`, `residual`)")]
    n_down_weighted_expected: Annotated[float, Doc(
        "how many down-weightings Gaussian noise of the estimated sigma would give: far fewer "
        "than `n_down_weighted` means real outliers or bursts")]


class SensorSummary(ScreenedSensor, SensorUse, EditCounts):
    """``sensors.<id>``: one sensor's counts and estimates, built by the stages in turn:
    :class:`ScreenedSensor` (screen), :class:`SensorUse`, ``calibration`` and ``time_offset``
    (products), :class:`EditCounts` and ``rows`` (write)."""

    rows: Annotated[RowsSummary, Doc(
        "where every row of the file went; the numbers add up to `read` (below)")]
    calibration: NotRequired[Annotated[dict[str, CalibrationTerm], Doc(
        "per systematic error term (`range`, `azimuth`, `elevation`, `latency`, `mount_roll`, "
        "`mount_pitch`, `mount_yaw`): `estimate`, `sigma` (1-sigma), `unit` (SI) and "
        "`applied` (significant, so the measurements were corrected for it); or "
        "`estimate`/`sigma` null with an `unobservable` reason. Names and signs: "
        "[data contract](contract.md#4-outputs)")]]
    time_offset: NotRequired[Annotated[TimeOffsetRecord, Doc(
        "when configured: its `value` (s), `unit`, `role` (clock scale alignment, or known "
        "latency correction) and, for an instant, the `instant` it names")]]


_T_SPAN = Doc("the first and last output epoch (s)")


class ExtentRecord(TypedDict):
    """``targets.<id>.extent_sigma_m``: a hull's fitted spread (m, 1 sigma)."""

    along: Annotated[float, Doc("along the heading (m)")]
    across: Annotated[float, Doc("across the heading (m)")]


class TargetSummary(TypedDict):
    """``targets.<id>``: one object's span, gaps and estimation figures
    (``stages.products._target_summary``)."""

    t_start: Annotated[float | None, _T_SPAN]
    t_end: Annotated[float | None, _T_SPAN]
    n_epochs: Annotated[int, Doc("output epochs")]
    spans: Annotated[list[list[float]], Doc(
        "the spans estimated separately, `[start, end]` (s)")]
    gaps: Annotated[list[list[float]], Doc(
        "stretches without a used measurement, `[start, end]` (s)")]
    unwritten: Annotated[list[list[float]], Doc(
        "stretches `[first, last]` (s) of output epochs not written because the object's own "
        "position rows reject the trajectory there ([Estimators: support]"
        "(methods/estimators.md#support)); empty when every epoch is written")]
    max_gap_s: Annotated[float, Doc("the gap (s) beyond which an object is split into spans")]
    process_noise_q: Annotated[ProcessNoiseRecord, Doc(
        "the estimated manoeuvre level (white-jerk PSD, m²/s⁵): `median`, `p95`, `max`")]
    filter: Annotated[FilterRecord, Doc(
        "the forward filter: `configured` (`[processing] filter`), `used` (what ran: with "
        "`\"auto\"`, `\"ekf+spline-fit\"` for an object measured by range rates alone (the EKF's "
        "passes, then the batch spline fit), else `\"ekf\"`) and `why`")]
    divergence_resets: Annotated[int, Doc(
        "how often the filter's covariance was re-opened after a run of rejections")]
    maneuver_norm: Annotated[ManeuverNormRecord, Doc(
        "`given` and `imposed` manoeuvre acceleration norm (m/s², `filter = \"askf\"` only; "
        "else null)")]
    max_sigma_position_m: Annotated[float | None, Doc(
        "the largest 1-sigma position uncertainty of any axis (m)")]
    reference_sigma_m: Annotated[float, Doc(
        "for an object measured by plots of radars or lidars alone: the 1-sigma spread (m, per "
        "horizontal axis) of the reference point about the returns that the sensors' stated "
        "sigmas show ([Several objects: output](methods/several-objects.md#7-output)); 0 "
        "otherwise")]
    extent_sigma_m: Annotated[ExtentRecord, Doc(
        "for the same objects: the hull's 1-sigma spread (m) about the centre of the returns "
        "fitted from the plots, `along` and `across` the heading: the upper confidence bound "
        "(95 %) of the fit, at most the plots' whole spread about the track (small against "
        "the noise for a point seen by many plots, e.g. an aircraft); the position covariance "
        "carries the largest of this, `reference_sigma_m`, `persistent_offset_sigma_m` and "
        "`return_spread_sigma_m` per axis, turned with the heading")]
    persistent_offset_sigma_m: Annotated[ExtentRecord, Doc(
        "for the same objects: the 1-sigma offset (m) of the returns from the track that "
        "persists from one scan to the next (the hull's points the sensors see, not their "
        "noise), `along` and `across` the heading, the largest over the plot sensors (0 and 0 "
        "where not significant, e.g. an aircraft)")]
    return_spread_sigma_m: Annotated[float, Doc(
        "for the same objects: the 1-sigma spread (m, on each horizontal axis) of the reference "
        "point about the track that the returns within one scan of a sensor giving several "
        "returns per object a scan (a lidar) show: the object's plot and its further returns "
        "about their mean, the largest direction's, doubled in variance (the reference and the "
        "point the track follows are two points of one hull); 0 without such a sensor")]


_SCORES = Doc("the chosen association's likelihood score, the best alternative's, whether the "
              "search was exhaustive, and how many searches ran")


class RunnerUp(TypedDict):
    """``association.runner_up``: the best alternative association."""

    score: Annotated[float, Doc("its likelihood score")]
    search: Annotated[int, Doc("the search it came from")]


class AssociationSummary(TypedDict):
    """``association``: how radar and theodolite rows were associated with objects
    (``tracking.routing.association_summary``); a run without several objects has only
    ``n_segments``, ``objects``, ``score``, ``runner_up`` and ``exact``."""

    n_segments: Annotated[int, Doc(
        "pieces the radar and theodolite tracks and plots were cut into")]
    n_unassigned_segments: NotRequired[Annotated[int, Doc(
        "pieces given to no object (clutter, too short)")]]
    objects: Annotated[dict[str, AssociatedObject], Doc(
        "per object: `discovered` (not declared in the config) and its `segments` (`segment`, "
        "`sensor`, `track_id`, `rows`, `t0`, `t1`)")]
    score: Annotated[float | None, _SCORES]
    runner_up: Annotated[RunnerUp | None, _SCORES]
    exact: Annotated[bool, _SCORES]
    n_searches: NotRequired[Annotated[int, _SCORES]]
    angle_plots: NotRequired[Annotated[dict[str, AnglePlots], Doc(
        "per sensor with angle-only plots (no range): `n_rows`, `n_associated`, "
        "`fraction_used`")]]
    stationary_returns: NotRequired[Annotated[dict[str, list[dict[str, float]]], Doc(
        "per plot sensor, the places with returns in most scans (quays, moored boats, shore)")]]
    plot_rounds: NotRequired[Annotated[dict[str, Any], Doc(
        "the rounds of re-associating plots with the smoothed objects: `rounds`, `converged`, "
        "`moved_plots` per round")]]
    ambiguous_plots: NotRequired[Annotated[list[dict[str, Any]], Doc(
        "stretches where another object came close to a plot's: object, runner-up, sensor, "
        "times, plots, margin")]]


_VERSIONS = Doc("the versions that made the run")


class RunSummary(TypedDict):
    """``summary.json``: one JSON object (``pipeline.run_summary``)."""

    rangeproc_version: Annotated[str, _VERSIONS]
    python: Annotated[str, _VERSIONS]
    numpy: Annotated[str, _VERSIONS]
    config: Annotated[ConfigRecord, Doc("the config's `file` (absolute path) and `sha256`")]
    inputs: Annotated[dict[str, InputRecord], Doc(
        "per sensor id, its data `file` and `sha256`")]
    sensors: Annotated[dict[str, SensorSummary], Doc(
        "per sensor id, its counts and estimates (below)")]
    targets: Annotated[dict[str, TargetSummary], Doc(
        "per object id, its span, gaps and estimation figures (below)")]
    association: Annotated[AssociationSummary, Doc(
        "how radar and theodolite rows were associated with objects (below)")]
    rejected_points: Annotated[RejectedPoints, Doc(
        "the rejected measurements shown on the report page: their total `n` and the first 50 "
        "in time order (`shown`: `sensor`, `row`, `time`, `component`, `value`, `residual`, "
        "`unit`, `reason`), values in the files' units")]
    warnings: Annotated[list[str], Doc("the run's warnings, one line each, as printed on stderr")]
    time_scale: Annotated[TimeScaleRecord, Doc(
        "the calendar of the run's times: `calendar` (`utc` or `unknown`), `basis` (`unix`, or "
        "how the epoch was found), `epoch` (the UTC instant of time 0, or null) and `t0` (the "
        "first time)")]
    elapsed_s: Annotated[float, Doc("the run's wall time (s)")]
    stage_seconds: Annotated[dict[str, float], Doc(
        "wall time per stage (read, screen, assemble, associate, fuse, products, write, "
        "report)")]


#: The sections the outputs page tables, in its order: (name in the page's marker, record).
DOCUMENTED = (("summary", RunSummary), ("sensors", SensorSummary), ("rows", RowsSummary),
              ("targets", TargetSummary), ("association", AssociationSummary))


@dataclass(frozen=True, slots=True)
class Declared:
    """One declared key of a record: its name, type (``Annotated`` and ``NotRequired``
    removed), whether every summary has it, and its :class:`Doc`."""

    name: str
    type: Any
    required: bool
    doc: Doc | None


def declared_keys(record: type) -> tuple[Declared, ...]:
    """The keys of TypedDict ``record`` in declaration order (bases first)."""
    hints = typing.get_type_hints(record, include_extras=True)
    out = []
    for name, tp in hints.items():
        while typing.get_origin(tp) in (NotRequired, Required):
            tp = typing.get_args(tp)[0]
        doc = None
        if typing.get_origin(tp) is Annotated:
            doc = next((m for m in tp.__metadata__ if isinstance(m, Doc)), None)
            tp = typing.get_args(tp)[0]
        out.append(Declared(name, tp, name in record.__required_keys__, doc))
    return tuple(out)


def _record_of(tp: Any) -> tuple[type | None, bool]:
    """(the TypedDict a value of type ``tp`` is, or holds per key or item; whether it is held
    per key of a mapping or per item of a list)."""
    if typing.is_typeddict(tp):
        return tp, False
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is dict and len(args) == 2 and typing.is_typeddict(args[1]):
        return args[1], True
    if origin is list and args and typing.is_typeddict(args[0]):
        return args[0], True
    if args:                                  # X | None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1 and typing.is_typeddict(inner[0]):
            return inner[0], False
    return None, False


def disagreements(value: Any, record: type = RunSummary, where: str = "") -> Iterator[str]:
    """Where the JSON object ``value`` (a ``summary.json`` read back) and the declaration of
    ``record`` part: a key written but not declared, a required key missing, a record that is
    not an object, a null where the declaration allows none. Recurses into every declared
    record (per key of a mapping, per item of a list)."""
    if not isinstance(value, dict):
        yield f"{where.rstrip('.') or '.'}: not an object"
        return
    keys = {d.name: d for d in declared_keys(record)}
    for name in value:
        if name not in keys:
            yield f"{where}{name}: written but not declared in {record.__name__}"
    for name, d in keys.items():
        if name not in value:
            if d.required:
                yield f"{where}{name}: declared required in {record.__name__} but missing"
            continue
        sub, many = _record_of(d.type)
        item = value[name]
        if item is None:
            if d.type is not Any and type(None) not in typing.get_args(d.type):
                yield f"{where}{name}: null, declared {getattr(d.type, '__name__', d.type)}"
            continue
        if sub is None:
            continue
        if not many:
            yield from disagreements(item, sub, f"{where}{name}.")
        elif isinstance(item, dict):
            for k, v in item.items():
                yield from disagreements(v, sub, f"{where}{name}.{k}.")
        else:
            for k, v in enumerate(item):
                yield from disagreements(v, sub, f"{where}{name}[{k}].")
