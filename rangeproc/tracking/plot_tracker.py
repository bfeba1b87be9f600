"""The multi-target tracker of a sensor's plots (``tracking.plots``: which rows are
plots, their positions), in the range ENU frame.

* **Scans and revisits** (:func:`plot_timing`). A rotating radar reports in azimuth order, so a
  scan ends where the azimuth wraps (falls by more than half a turn); a sensor that stamps a
  whole scan with one time has one scan per time stamp. Within a scan an object gives at most
  one plot. Plots in any other order (a phased-array radar revisiting each object on its own
  schedule, a feed merged from several radars) have no scans: each time stamp is taken on its
  own, and missed detections are counted in revisit periods of the sensor, the median time
  between consecutive plots of its confirmed tracks (found by tracking with a trial revisit
  until the estimate agrees with the revisit it was tracked with).
* **Tracker** (:func:`track_plots`): track-oriented, one hypothesis per track, with the
  models a tracking specialist expects (Blackman and Popoli 1999, ch. 6-7):

  - *Motion*: an interacting multiple model (IMM; Blom and Bar-Shalom 1988) of two
    constant-velocity models, cruise (white-acceleration PSD ``CRUISE_PSD``) and manoeuvre,
    with Markov switching of mean sojourn ``MODEL_SOJOURN``: a boat or an airliner in cruise
    is predicted as tightly as its plots allow, a turning fighter keeps its track. A
    manoeuvre is a turn, whose acceleration is the speed times the turn rate: the manoeuvre
    model's PSD (``models.motion.manoeuvre_psd``) is ``MANOEUVRE_PSD`` (a 6 g turn begun
    between two scans stays inside the gate) from ``MANOEUVRE_SPEED`` on and falls with the
    square of the track's speed (its upper bound) to ``MANOEUVRE_FLOOR``: a boat at 4 m/s is
    not given a fighter's 480 m between two scans, which took sea clutter into its track at
    every missed scan and split it.
  - *Clutter* (``tracking.clutter_map``): a spatial clutter map estimated from the sensor's
    own plots: the plots per scan in cells of ``CLUTTER_CELL_SIGMAS`` median plot sigmas
    (east, north and, for a radar that measures elevation, up), each plot's own cell
    counted without the plot itself and the plots of the scans around it (its object's
    own), shrunk toward the sensor-wide density with the weight of ``CLUTTER_PRIOR_CELLS``
    cells. Quays, moored boats and shore returns give plots in the same cells scan after
    scan, so tracks there need far stronger evidence than tracks in open water or open
    sky; cells with plots in most scans are reported as stationary returns
    (``clutter_map.stationary_returns``). A moored boat is such a return while it lies
    still; when it leaves, its plots move out of its cell and it is tracked from there.
  - *Existence* (the track score, a sequential probability ratio test): a track's score
    begins at the log of the new-object over the clutter density
    (``tracking.initiation.new_track_score``: 0 with the general velocity bound, lower by the
    velocity volume a narrower bound leaves out); each plot a track takes adds
    ``log(PD * p(z | track) / clutter density at z)``, each missed scan (revisit)
    ``log(1 - PD)`` (``DETECTION_PROBABILITY``); a track is confirmed when its score reaches
    ``CONFIRM_SCORE`` (false-track probability ``FALSE_TRACK_PROBABILITY``, missed-track
    probability ``MISSED_TRACK_PROBABILITY``) and ends when it falls ``DELETE_DROP`` below
    the best it reached (``MAX_MISSES`` misses in a row) or, unconfirmed, after
    ``CONFIRM_SCANS`` scans (its velocity then known) when it falls to Wald's lower threshold
    ``CLUTTER_SCORE``. Plots of tracks never confirmed are clutter.
  - *Association*: global nearest neighbour per scan (Munkres via
    ``scipy.optimize.linear_sum_assignment``) maximising the summed score gain of the pairs
    taken, ``log(PD p(z | track) / clutter density) - log(1 - PD)`` (taking the plot against
    leaving the track missed and the plot to clutter), gated at chi-square probability
    ``GATE_PROBABILITY`` in either model; a confirmed track takes no plot whose gain is
    negative (likelier clutter than its own, the case in a miss near a quay), a tentative
    track takes what its gate holds and its score judges it. GNN rather than JPDA or a
    plot-level MHT because this is post-processing: every plot is kept with its track, the
    tracks are smoothed afterwards, and the ambiguous cases (objects closer than the plot
    noise) are settled at the segment level, across sensors and gaps, by the track-oriented
    hypothesis search (``tracking.hypotheses``), which sees far more evidence than one scan.
  - *Extent* (:func:`extent_update`): a ship seen from the side gives plots anywhere along
    its hull, further off its centre than the sensor's stated noise; each track carries an
    extent variance, estimated from its own innovations by covariance matching, added to its
    plots' noise. A point target's stays near 0. For a sensor that gives several returns a
    scan, the hull is measured from the spread of its returns in each scan and two tracks
    on one hull are merged (``tracking.hull_merge``).
  - *Several returns in one scan* (:func:`_other_returns`): a lidar gives several returns of
    one hull per scan; a plot no confirmed track took, within the gate of a plot a confirmed
    track took in the same scan (the two apart by their noise and twice the track's extent),
    is a further return of that object and starts no track; only for a sensor measured to
    give several returns (most of its plots have a neighbour of the same scan within their
    noise, :func:`neighbour_share`, ``SEVERAL_RETURNS_SHARE``), so that a radar's plots and
    a formation partner among them keep their own tracks.
  - *Initiation*: an unassigned plot starts a tentative track whose velocity is unknown up to
    a bound (3 sigma) fitted to the sensor's tracks (``tracking.speed_bound``), or
    ``INITIATION_SPEED`` on stationary returns (``clutter_map.on_stationary_returns``).
  - *Stationary returns* (``tracking.stationary``): a confirmed track that never moved beyond
    one plot's noise (a quay's scatterers, a moored boat) is left as clutter.
  - *Retrodiction* (``tracking.retrodiction``): the same tracker run backward in time gives
    each track the plots before its confirmation that the forward pass left as clutter;
    where the passes exchange plots, the likelier grouping (``tracking.two_passes``); a
    forward track that held two objects in turn, split by the backward pass into two
    tracks at once, the same (``tracking.pass_splits``).
  - *Time stamps*: a radar that stamps a whole scan with one time gives each plot a time up
    to a scan period off; that error, carried along the track's velocity, is part of the
    plot's noise (:attr:`PlotTiming.stamp_sigma`).
"""
from __future__ import annotations

from functools import partial
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from rangeproc.estimation.imm_models import mix_moments, uniform_switch_matrix
from rangeproc.models.motion import MANOEUVRE_PSD, cv_predict, manoeuvre_psd
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.clutter_map import (clutter_density, neighbour_share,
                                            on_stationary_returns)
from rangeproc.tracking.initiation import new_track_score
from rangeproc.tracking.stationary import moving_tracks
from rangeproc.tracking.hull_merge import hull_tracks
from rangeproc.tracking.two_passes import both_passes
from rangeproc.tracking.track_extent import (EXTENT_MEMORY, HullSpread, extent_in_use,
                                             extent_update, pair_close)
from rangeproc.tracking.plots import (
    CONFIRM_SCANS,
    GATE_PROBABILITY,
    INITIATION_SPEED,
    MAX_MISSES,
    MAX_TURN_SECONDS,
    is_framed,
    is_rotating,
    revisit_period,
    scan_numbers,
    silent_clock,
)

#: White-acceleration PSD ((m/s^2)^2/s) of the cruise model: an object holding its course
#: and speed against small disturbances (a boat, an airliner in level flight; the value
#: Stone Soup's tutorials use for such targets).
CRUISE_PSD = 1.0
MODEL_PSD = (CRUISE_PSD, MANOEUVRE_PSD)
#: Mean time (s) an object stays in one motion model (the IMM's Markov switching).
MODEL_SOJOURN = 10.0
#: Probability that an object in view gives a plot in a scan (revisit) (the track score's
#: hit and miss terms). A surveillance radar's design value.
DETECTION_PROBABILITY = 0.9
#: Sequential probability ratio test of a track (Wald; Blackman and Popoli 1999, 6.2): the
#: probability of confirming a track of clutter and of not confirming an object's track.
FALSE_TRACK_PROBABILITY = 1e-3
MISSED_TRACK_PROBABILITY = 0.1
CONFIRM_SCORE = float(np.log((1.0 - MISSED_TRACK_PROBABILITY) / FALSE_TRACK_PROBABILITY))
CLUTTER_SCORE = float(np.log(MISSED_TRACK_PROBABILITY / (1.0 - FALSE_TRACK_PROBABILITY)))
#: A track ends when its score falls this far below the best it reached: ``MAX_MISSES``
#: misses in a row.
DELETE_DROP = float(-MAX_MISSES * np.log1p(-DETECTION_PROBABILITY))
#: Revisit periods (s) tried first and last by :func:`free_revisit`; the estimate is accepted
#: when it agrees with the revisit tracked with to ``REVISIT_AGREEMENT`` (relative).
REVISIT_TRIAL = 4.0
REVISIT_MAX = MAX_TURN_SECONDS
REVISIT_AGREEMENT = 0.2
#: Confirmed tracks with at least this many plots give the revisit estimate.
REVISIT_MIN_HITS = 5
#: A sensor gives several returns of one object per scan when at least this share of its
#: plots have another plot of the same scan within the gate of their two noises
#: (:func:`neighbour_share`); only then does a further return start no track
#: (:func:`_other_returns`). A harbour lidar's: 0.92; a radar's among boats and clutter:
#: 0.28; a surveillance radar's with a formation: 0.03.
SEVERAL_RETURNS_SHARE = 0.5


@dataclass(frozen=True, slots=True)
class PlotTiming:
    """How one sensor's plots are grouped in time (module docstring: *Scans and revisits*).

    frame: (N,) int64, plots taken together (an object gives at most one plot per frame);
    scan: (N,) int64, the scan number, or for plots in no scan order the number of whole
    revisit periods since the first plot; clock: (N,) float, the same in revisits (the scan
    number itself for a scanning radar); revisit: the revisit period (s; 0 with one scan);
    order: "rotating", "framed" or "free"; silent: (N,) float, the clock with the scans a
    sensor's silences left out counted (``tracking.plots.silent_clock``; the clock for plots
    in no scan order), which the stray-tail rule (``tracking.plot_tails``) reads; several:
    whether the sensor gives several returns of one object a frame (a lidar's hull points:
    :func:`several_returns`, set by the caller once measured; False: one).
    """

    frame: np.ndarray
    scan: np.ndarray
    clock: np.ndarray
    revisit: float
    order: str
    silent: np.ndarray
    several: bool = False

    @property
    def stamp_sigma(self) -> float:
        """Sigma (s) of a plot's time stamp about its true time: a framed radar stamps a
        whole scan with one time (uniform over the revisit: revisit / sqrt(12)); 0 else."""
        return self.revisit / np.sqrt(12.0) if self.order == "framed" else 0.0


def plot_timing(t: np.ndarray, azimuth: np.ndarray, p: np.ndarray, R: np.ndarray,
                planar: bool = False) -> PlotTiming:
    """The :class:`PlotTiming` of plots at times ``t`` (N,) s ascending, azimuth (N,) rad,
    ENU positions ``p`` (N, 3) m with covariances ``R`` (N, 3, 3) m^2 (``planar``: as for
    :func:`track_plots`)."""
    framed = is_framed(t)
    if framed or is_rotating(t, azimuth):
        scan = scan_numbers(t, azimuth)
        revisit = revisit_period(t, scan)
        return PlotTiming(scan, scan, scan.astype(float), revisit,
                          "framed" if framed else "rotating", silent_clock(t, scan, revisit))
    frame = np.cumsum(np.concatenate([[False], np.diff(t) > 0.0])).astype(np.int64)
    revisit = free_revisit(t, p, R, frame, planar)
    clock = (t - t[0]) / revisit if t.size else np.zeros(0)
    return PlotTiming(frame, np.floor(clock).astype(np.int64), clock, revisit, "free", clock)


def free_revisit(t: np.ndarray, p: np.ndarray, R: np.ndarray, frame: np.ndarray,
                 planar: bool = False) -> float:
    """Revisit period (s) of plots in no scan order (arguments as :func:`track_plots`): the
    median time between consecutive plots of the confirmed tracks with at least
    ``REVISIT_MIN_HITS`` plots, tracked with a trial revisit; tracked again with the estimate
    until the two agree to ``REVISIT_AGREEMENT`` (at most four times). A trial that confirms
    no such track is doubled, up to ``REVISIT_MAX``; with none even then, ``REVISIT_MAX``."""
    trial = REVISIT_TRIAL
    for _ in range(4):
        label = track_plots(t, p, R, frame, (t - t[0]) / trial, planar, retrodict=False)
        steps = [np.diff(t[label == k]) for k in range(int(label.max()) + 1)
                 if np.count_nonzero(label == k) >= REVISIT_MIN_HITS]
        if not steps:
            if trial >= REVISIT_MAX:
                return REVISIT_MAX
            trial = min(2.0 * trial, REVISIT_MAX)
            continue
        estimate = float(np.median(np.concatenate(steps)))
        estimate = min(max(estimate, 1e-3), REVISIT_MAX)
        if abs(estimate - trial) <= REVISIT_AGREEMENT * trial:
            return estimate
        trial = estimate
    return trial


@dataclass(slots=True)
class _ImmTrack:
    """A track under way in the plot tracker's IMM: per motion model states xs (M, 6)
    [p, v] ENU, covariances Ps (M, 6, 6), model probabilities mu (M,), all at time t (s);
    the clock (scans or revisits, :class:`PlotTiming`) of its first and last plot; its
    score (log-likelihood ratio object / clutter) and the best score it reached; its extent
    variance (m^2 per measured axis, :func:`extent_update`, signed), the mean noise
    variance of its innovations (m^2 per measured axis, the extent in use left out) and the
    spread of its returns within a scan (``track_extent.HullSpread``)."""

    xs: np.ndarray
    Ps: np.ndarray
    mu: np.ndarray
    t: float
    first_scan: float
    last_scan: float
    score: float = 0.0
    best: float = 0.0
    extent: float = 0.0
    noise: float = 0.0
    confirmed: bool = False
    rows: list[int] = field(default_factory=list)
    hull: HullSpread = field(default_factory=HullSpread)


def _imm_predict(xs: np.ndarray, Ps: np.ndarray, mu: np.ndarray, dt: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IMM interaction and prediction of K (track, plot) pairs: the tracks' per-model states
    xs (K, M, 6), covariances Ps (K, M, 6, 6) and model probabilities mu (K, M), carried dt
    (K,) s to the plots -> predicted model probabilities (K, M), states (K, M, 6) and
    covariances (K, M, 6, 6).

    Markov switching between the models with mean sojourn ``MODEL_SOJOURN`` s: over dt the
    probability to be in another model is ``(1 - exp(-M dt / tau)) / M`` (M models, every
    switch alike, ``estimation.imm_models.uniform_switch_matrix``); the mixed initial
    conditions are the IMM moments of the fusion's IMM (Blom and Bar-Shalom 1988;
    ``estimation.imm_models.mix_moments``), each model's prediction the CV model's
    (``models.motion.cv_predict``)."""
    M = len(MODEL_PSD)
    Pi = uniform_switch_matrix(dt, M, MODEL_SOJOURN)               # (K, M, M)
    c, x0, P0 = mix_moments(Pi, mu, xs, Ps)                        # (K, M), (K, M, 6), ...
    xp = np.empty_like(x0)
    Pp = np.empty_like(P0)
    for m, q in enumerate(MODEL_PSD):
        if q == MANOEUVRE_PSD:             # a turn at the track's speed (manoeuvre_psd)
            q = manoeuvre_psd(x0[:, m, 3:], P0[:, m, 3:, 3:])
        xp[:, m], Pp[:, m] = cv_predict(x0[:, m], P0[:, m], dt, q)
    return c, xp, Pp


def _candidate_pairs(xs: np.ndarray, Ps: np.ndarray, mu: np.ndarray, t_track: np.ndarray,
                     t: np.ndarray, p: np.ndarray, R: np.ndarray, gate: float,
                     stamp_sigma: float, extent: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(track index (K,), plot index (K,)) of the pairs that can pass the chi-square
    ``gate`` in some model: a conservative bound from the tracks' model spread and the
    traces of their covariances (a Mahalanobis distance within the gate puts the plot within
    ``sqrt(gate * largest eigenvalue of S)`` of a model's prediction), so that the IMM runs
    only where it can matter. xs (L, M, 6), Ps (L, M, 6, 6), mu (L, M), t_track (L,);
    t (A,), p (A, 3), R (A, 3, 3); extent (L,) the tracks' extent variances (m^2 per axis,
    :attr:`_ImmTrack.extent`)."""
    mean = np.einsum("lm,lmd->ld", mu, xs)                          # (L, 6)
    spread_p = np.linalg.norm(xs[..., :3] - mean[:, None, :3], axis=2).max(axis=1)
    spread_v = np.linalg.norm(xs[..., 3:] - mean[:, None, 3:], axis=2).max(axis=1)
    sig_p = np.sqrt(np.einsum("lmii->lm", Ps[..., :3, :3]).max(axis=1) + spread_p ** 2)
    sig_v = np.sqrt(np.einsum("lmii->lm", Ps[..., 3:, 3:]).max(axis=1) + spread_v ** 2)
    dt = np.abs(t[None, :] - t_track[:, None])                      # (L, A)
    speed = np.linalg.norm(mean[:, 3:], axis=1) + spread_v + sig_v  # (L,)
    var = ((sig_p[:, None] + dt * sig_v[:, None]) ** 2
           + max(MODEL_PSD) * dt ** 3 / 3.0
           + np.einsum("aii->a", R)[None, :]
           + (stamp_sigma * speed[:, None]) ** 2)
    if extent is not None:
        var = var + 3.0 * extent[:, None]
    centre = mean[:, None, :3] + (t[None, :] - t_track[:, None])[..., None] * mean[:, None, 3:]
    reach = spread_p[:, None] + dt * spread_v[:, None] + np.sqrt(gate * var)
    with np.errstate(invalid="ignore"):
        near = np.linalg.norm(p[None, :, :] - centre, axis=2) <= reach
    return np.nonzero(near)


def _start_imm(p: np.ndarray, R: np.ndarray, t: float, clock: float, row: int,
               speed: float = INITIATION_SPEED, axes: int = 3) -> _ImmTrack:
    """A tentative track on plot ``row``, its speed up to ``speed`` m/s (3 sigma)."""
    M = len(MODEL_PSD)
    P = np.zeros((6, 6))
    P[:3, :3] = R
    P[3:, 3:] = (speed / 3.0) ** 2 * np.eye(3)              # 3 sigma = the speed bound
    x = np.concatenate([p, np.zeros(3)])
    score = new_track_score(speed, axes)
    return _ImmTrack(np.tile(x, (M, 1)), np.tile(P, (M, 1, 1)), np.full(M, 1.0 / M), t,
                     clock, clock, score=score, best=score, rows=[row])


@dataclass(frozen=True, slots=True)
class _Gains:
    """The IMM prediction of K (track, plot) pairs and the plot's likelihood under it:
    predicted model probabilities c (K, M), states xp (K, M, 6), covariances Pp (K, M, 6, 6),
    innovation covariances S (K, M, 3, 3), innovations d (K, M, 3), Mahalanobis distances m2
    (K, M) in 3-D, per-model log-likelihoods loglik (K, M) and the mixture's mix (K,) (in
    east and north only for a planar sensor), and the score gain of taking the plot (K,):
    ``log(PD p(z) / clutter) - log(1 - PD)``; the tracks' extent variances extent (K,)
    (m^2 per measured axis, in S)."""

    c: np.ndarray
    xp: np.ndarray
    Pp: np.ndarray
    S: np.ndarray
    d: np.ndarray
    m2: np.ndarray
    loglik: np.ndarray
    mix: np.ndarray
    gain: np.ndarray
    extent: np.ndarray


def _pair_gains(xs: np.ndarray, Ps: np.ndarray, mu: np.ndarray, dt: np.ndarray,
                p: np.ndarray, R: np.ndarray, clutter: np.ndarray, planar: bool,
                stamp_sigma: float, extent: np.ndarray) -> _Gains:
    """:class:`_Gains` of K (track, plot) pairs: the tracks' xs (K, M, 6), Ps (K, M, 6, 6),
    mu (K, M) carried dt (K,) s to plots p (K, 3) with covariances R (K, 3, 3) and clutter
    density ``clutter`` (K,) (arguments as :func:`track_plots`); extent (K,) the tracks'
    extent variances (m^2 per measured axis), added to the plot's noise."""
    axes = 2 if planar else 3
    c, xp, Pp = _imm_predict(xs, Ps, mu, dt)
    S = Pp[..., :3, :3] + R[:, None]                               # (K, M, 3, 3)
    S[..., np.arange(axes), np.arange(axes)] += extent[:, None, None]
    if stamp_sigma > 0.0:                            # the time stamp's error, along v
        v = xp[..., 3:]
        S = S + stamp_sigma ** 2 * v[..., :, None] * v[..., None, :]
    d = p[:, None] - xp[..., :3]                                    # (K, M, 3)
    m2 = np.einsum("kmi,kmi->km", d, np.linalg.solve(S, d[..., None])[..., 0])
    if planar:                                       # the score in east and north only
        S2, d2 = S[..., :2, :2], d[..., :2]
        m2s = np.einsum("kmi,kmi->km", d2, np.linalg.solve(S2, d2[..., None])[..., 0])
        logdet = np.linalg.slogdet(S2)[1]
    else:
        m2s, logdet = m2, np.linalg.slogdet(S)[1]
    with np.errstate(invalid="ignore", over="ignore"):
        loglik = -0.5 * (m2s + logdet + axes * np.log(2.0 * np.pi))          # (K, M)
        mix = np.log(np.maximum((c * np.exp(loglik)).sum(axis=1), 1e-300))
    gain = (np.log(DETECTION_PROBABILITY) + mix - np.log(clutter)
            - np.log1p(-DETECTION_PROBABILITY))
    return _Gains(c, xp, Pp, S, d, m2, loglik, mix, gain, extent)


def _take(tr: _ImmTrack, g: _Gains, q: int, t: float, k: float, row: int,
          clutter: float, axes: int) -> None:
    """Update track ``tr`` with plot ``row`` (time t s, clock k, clutter density
    ``clutter``), pair ``q`` of :class:`_Gains` g: the IMM's per-model Kalman updates, model
    probabilities, the track score (missed revisits since its last plot, then the plot) and
    its extent's signed mean (:func:`extent_update`, over the ``axes`` measured axes)."""
    n, used = len(tr.rows), float(g.extent[q])
    w = 1.0 / min(n + 1, EXTENT_MEMORY)
    noise = (float(np.einsum("m,mii->", g.c[q], g.S[q, :, :axes, :axes])) / axes - used)
    tr.noise = (1.0 - w) * tr.noise + w * noise
    plot_noise = float(np.einsum("m,mii->", g.c[q], g.S[q, :, :axes, :axes]
                                 - g.Pp[q, :, :axes, :axes])) / axes - used
    tr.extent = extent_update(tr.extent, n, g.c[q], g.d[q], g.S[q], axes, used, plot_noise)
    K = np.linalg.solve(g.S[q], g.Pp[q, :, :3, :]).swapaxes(-1, -2)     # (M, 6, 3)
    tr.xs = g.xp[q] + np.einsum("mij,mj->mi", K, g.d[q])
    tr.Ps = g.Pp[q] - K @ g.Pp[q, :, :3, :]
    tr.Ps = 0.5 * (tr.Ps + np.swapaxes(tr.Ps, -1, -2))
    post = g.c[q] * np.exp(g.loglik[q] - g.loglik[q].max())
    tr.mu = post / post.sum()
    missed = max(0.0, k - tr.last_scan - 1.0)
    tr.score += (missed * np.log1p(-DETECTION_PROBABILITY) + np.log(DETECTION_PROBABILITY)
                 + g.mix[q] - np.log(clutter))
    tr.best = max(tr.best, tr.score)
    tr.t, tr.last_scan = t, k
    tr.rows.append(row)
    tr.confirmed |= tr.score >= CONFIRM_SCORE


def several_returns(p: np.ndarray, R: np.ndarray, scan: np.ndarray, planar: bool) -> bool:
    """Whether a sensor gives several returns of one object a scan: at least
    ``SEVERAL_RETURNS_SHARE`` of its plots (p (N, 3) m, R (N, 3, 3) m^2, scan (N,); plots
    without a finite position left out) have a neighbour of the same scan within the
    ``GATE_PROBABILITY`` gate of their two noises (``tracking.clutter_map.neighbour_share``)."""
    ok = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    return neighbour_share(p[ok], R[ok], scan[ok], gate, planar) >= SEVERAL_RETURNS_SHARE


def track_plots(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                clock: np.ndarray | None = None, planar: bool = False,
                stamp_sigma: float = 0.0, retrodict: bool = True,
                several: bool | None = None, tails: np.ndarray | None = None
                ) -> np.ndarray:
    """(N,) int64 track label per plot (0, 1, ... in order of first plot; -1 = clutter).

    t: (N,) s ascending; p: (N, 3) ENU m; R: (N, 3, 3) m^2; scan: (N,) the frames plots are
    assigned in (:class:`PlotTiming`; a scanning radar's scan numbers); clock: (N,) float,
    the time in scans or revisits that counts misses (default: ``scan``); planar: the sensor
    measures no elevation (the clutter map and the score in east and north only);
    stamp_sigma: the sigma (s) of a plot's time stamp about its true time (a radar that
    stamps a whole scan with one time: the scan period over sqrt(12)), carried into each
    plot's position noise along the track's velocity; retrodict: the tracks' plots before
    their confirmation found by the tracker run backward in time (``tracking.retrodiction``;
    off where only the tracks' revisits are wanted); several: :func:`several_returns` of
    these plots where the caller has it (default: computed here); tails: (N,) the clock of
    the backward pass's stray-tail rule (``PlotTiming.silent``; default ``clock``). See the
    module docstring (*Tracker*) for the method.
    """
    if clock is None:
        clock = np.asarray(scan, dtype=float)
    label = np.full(t.size, -1, dtype=np.int64)
    usable = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
    if not usable.all():            # plots without a position (no platform geometry)
        if usable.any():
            label[usable] = track_plots(
                t[usable], p[usable], R[usable], scan[usable], clock[usable], planar,
                stamp_sigma, retrodict, several, None if tails is None else tails[usable])
        return label
    if t.size == 0:
        return label
    if several is None:
        several = several_returns(p, R, scan, planar)

    def tracker(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                clock: np.ndarray, *rest: object) -> np.ndarray:
        return _track_scans(t, p, R, scan, clock, planar, stamp_sigma, several, *rest)
    if not retrodict:
        return tracker(t, p, R, scan, clock)
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    stationary = partial(on_stationary_returns, p, R, scan, planar, gate)
    return moving_tracks(both_passes(tracker, t, p, R, scan, clock, 2 if planar else 3,
                                     tails, CONFIRM_SCORE, stationary), p, R, planar)


def _track_scans(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                 clock: np.ndarray, planar: bool, stamp_sigma: float,
                 further_returns: bool, bound: np.ndarray | None = None,
                 scores: list | None = None) -> np.ndarray:
    """The tracker of :func:`track_plots` (arguments of ``tracking.two_passes.Tracker``,
    every plot usable, at least one): the label per plot (N,). With ``further_returns``
    (several returns per object a scan), a plot no confirmed track took within the pair gate
    of a plot one took in the same scan is that object's further return and starts no track
    (:func:`_other_returns`). bound: (N,) m/s, a new track's speed bound on each plot."""
    label = np.full(t.size, -1, dtype=np.int64)
    axes = 2 if planar else 3
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    clutter = clutter_density(p, R, float(clock.max() - clock.min()) + 1.0, planar, clock)
    bound = np.full(t.size, INITIATION_SPEED) if bound is None else bound
    live: list[_ImmTrack] = []
    done: list[_ImmTrack] = []
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    for rows in np.split(order, bounds):
        k = float(clock[rows[0]])
        cost = np.full((rows.size, len(live)), np.inf)
        pair = np.full((len(live), rows.size), -1, dtype=np.int64)
        g = None
        if live:                                     # the live tracks against the plots
            xs_l = np.stack([tr.xs for tr in live])
            Ps_l = np.stack([tr.Ps for tr in live])
            mu_l = np.stack([tr.mu for tr in live])
            t_l = np.array([tr.t for tr in live])
            e_l = np.array([extent_in_use(tr, axes) for tr in live])
            pl, pa = _candidate_pairs(xs_l, Ps_l, mu_l, t_l, t[rows], p[rows], R[rows],
                                      gate, stamp_sigma, e_l)
            pair[pl, pa] = np.arange(pl.size)
        if live and pl.size:
            g = _pair_gains(xs_l[pl], Ps_l[pl], mu_l[pl], t[rows][pa] - t_l[pl],
                            p[rows][pa], R[rows][pa], clutter[rows][pa], planar,
                            stamp_sigma, e_l[pl])
            # a confirmed track takes no plot likelier clutter than its own (a tentative
            # one takes what its gate holds, and its score judges it)
            confirmed = np.array([tr.confirmed for tr in live])[pl]
            ok = (g.m2 <= gate).any(axis=1) & ((g.gain > 0.0) | ~confirmed)
            cost[pa[ok], pl[ok]] = -g.gain[ok]
        taken = np.zeros(rows.size, dtype=bool)
        owner = np.full(rows.size, -1, dtype=np.int64)
        if g is not None and rows.size and np.isfinite(cost).any():
            a_idx, j_idx = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e12))
            for a, j in zip(a_idx, j_idx):
                if not np.isfinite(cost[a, j]):
                    continue
                i = int(rows[a])
                _take(live[j], g, int(pair[j, a]), float(t[i]), k, i, float(clutter[i]),
                      axes)
                taken[a] = True
                owner[a] = j
        if further_returns:
            live, owner = hull_tracks(live, owner, rows, p, R, float(t[rows[0]]), scan, gate,
                                      planar)
            taken = _one_hull_each(live, owner, taken, rows, p, R, gate, planar)
            live, taken = _other_returns(live, owner, taken, rows, p, R, gate, planar)
        keep = []
        for tr in live:
            now = tr.score + max(0.0, k - tr.last_scan - 1.0) * np.log1p(-DETECTION_PROBABILITY)
            expired = (now < tr.best - DELETE_DROP
                       or (not tr.confirmed and k - tr.first_scan >= CONFIRM_SCANS
                           and now <= CLUTTER_SCORE))
            (done if expired else keep).append(tr)
        live = keep
        for i in rows[~taken]:
            live.append(_start_imm(p[i], R[i], float(t[i]), k, int(i), bound[i], axes))
    done.extend(live)
    confirmed = sorted((tr for tr in done if tr.confirmed), key=lambda tr: tr.rows[0])
    for n, tr in enumerate(confirmed):
        label[np.asarray(tr.rows)] = n
    (scores if scores is not None else []).extend(tr.score for tr in confirmed)
    return label


def _one_hull_each(live: list[_ImmTrack], owner: np.ndarray, taken: np.ndarray,
                   rows: np.ndarray, p: np.ndarray, R: np.ndarray, gate: float,
                   planar: bool) -> np.ndarray:
    """The plots of scan ``rows`` that start no track, for a sensor that gives several
    returns of one hull a scan: ``taken`` (A,) with, in addition, each plot no track took
    that lies within the pair gate (:func:`pair_close`) of a plot of the scan that a
    tentative track took or that starts a track (the scan's untaken plots in order, the
    first of each group starting it). Two returns of one hull in the first scans would
    otherwise start two tracks that each take one return a scan, are confirmed together and
    follow the one object as two (:func:`_other_returns` settles only plots beside a
    confirmed track's). owner (A,) as for :func:`_other_returns`."""
    axes = 2 if planar else 3
    out = taken.copy()
    tentative = [b for b in np.flatnonzero(owner >= 0) if not live[owner[b]].confirmed]
    starters: list[int] = []
    for a in np.flatnonzero(~taken):
        beside = (any(pair_close(live[owner[b]], p[rows[a]], p[rows[b]], R[rows[a]],
                                  R[rows[b]], gate, axes) for b in tentative)
                  or any(pair_close(None, p[rows[a]], p[rows[b]], R[rows[a]], R[rows[b]],
                                     gate, axes) for b in starters))
        if beside:
            out[a] = True
        else:
            starters.append(int(a))     # it starts a track: the anchor of its own returns
    return out


def _other_returns(live: list[_ImmTrack], owner: np.ndarray, taken: np.ndarray,
                   rows: np.ndarray, p: np.ndarray, R: np.ndarray, gate: float,
                   planar: bool) -> tuple[list[_ImmTrack], np.ndarray]:
    """An extended object's further returns in one scan (a lidar gives several per hull):
    a plot of the scan ``rows`` that no confirmed track took, within ``gate`` of a plot a
    confirmed track took in it, the two apart by at most their noise and twice the track's
    extent (two returns of one hull, each off its centre by the extent), is that object's
    and starts no track; a tentative track that took it is dropped (a copy of the object
    begun on another return). owner (A,) the live track that took each plot of the scan
    (-1 none), taken (A,) whether one did. Returns the live tracks and the plots claimed."""
    axes = 2 if planar else 3
    confirmed = [a for a in np.flatnonzero(owner >= 0) if live[owner[a]].confirmed]
    if not confirmed:
        return live, taken
    claimed = taken.copy()
    dropped: set[int] = set()
    for a in np.flatnonzero(~np.isin(np.arange(rows.size), confirmed)):
        for b in confirmed:
            if pair_close(live[owner[b]], p[rows[a]], p[rows[b]], R[rows[a]], R[rows[b]],
                           gate, axes):
                claimed[a] = True
                if owner[a] >= 0:
                    dropped.add(int(owner[a]))
                break
    return [tr for j, tr in enumerate(live) if j not in dropped], claimed
