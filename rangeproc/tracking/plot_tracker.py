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
    model's PSD (:func:`manoeuvre_psd`) is ``MANOEUVRE_PSD`` (a 6 g turn begun between two
    scans stays inside the gate) from ``MANOEUVRE_SPEED`` on and falls with the square of the
    track's speed (its upper bound) to ``MANOEUVRE_FLOOR``: a boat at 4 m/s is not given a
    fighter's 480 m between two scans, which took sea clutter into its track at every missed
    scan and split it.
  - *Clutter* (:func:`clutter_density`): a spatial clutter map estimated from the sensor's
    own plots: the plots per scan in cells of ``CLUTTER_CELL_SIGMAS`` median plot sigmas
    (east, north and, for a radar that measures elevation, up), each plot's own cell counted
    without the plot itself, shrunk toward the sensor-wide density with the weight of
    ``CLUTTER_PRIOR_CELLS`` cells. Quays, moored boats and shore returns give plots in the
    same cells scan after scan, so tracks there need far stronger evidence than tracks in
    open water or open sky; cells with plots in most scans are reported as stationary
    returns (:func:`stationary_returns`).
  - *Existence* (the track score, a sequential probability ratio test): each plot a track
    takes adds ``log(PD * p(z | track) / clutter density at z)``, each missed scan (revisit)
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
  - *Initiation*: an unassigned plot starts a tentative track whose velocity is unknown up to
    ``INITIATION_SPEED`` (3 sigma), so its second plot adds little evidence unless the
    clutter is sparse.
  - *Time stamps*: a radar that stamps a whole scan with one time gives each plot a time up
    to a scan period off; that error, carried along the track's velocity, is part of the
    plot's noise (:attr:`PlotTiming.stamp_sigma`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.plots import (
    CONFIRM_SCANS,
    GATE_PROBABILITY,
    INITIATION_SPEED,
    MAX_MISSES,
    MAX_TURN_SECONDS,
    cv_predict,
    is_framed,
    is_rotating,
    revisit_period,
    scan_numbers,
)

#: White-acceleration PSD ((m/s^2)^2/s) of the cruise model: an object holding its course
#: and speed against small disturbances (a boat, an airliner in level flight; the value
#: Stone Soup's tutorials use for such targets).
CRUISE_PSD = 1.0
#: White-acceleration PSD ((m/s^2)^2/s) of the IMM's manoeuvre model: a 6 g turn begun between
#: two plots 4 s apart moves the object 480 m off its line, inside the gate of this model's
#: prediction (sqrt(q dt^3 / 3) = 160 m a component, gate 4.6 sigma), where a 3 g model loses
#: fighters turning between surveillance scans.
MANOEUVRE_PSD = 1200.0
#: The manoeuvre model's PSD scales with the square of the track's speed (``manoeuvre_psd``):
#: ``MANOEUVRE_PSD`` from this speed (m/s) on (a 6 g turn at 250 m/s is 13.5 deg/s), down to
#: ``MANOEUVRE_FLOOR`` at rest (a 1 m/s^2 manoeuvre over a few seconds).
MANOEUVRE_SPEED = 250.0
MANOEUVRE_FLOOR = 4.0
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
#: Clutter map: cells of this many median plot sigmas along each axis; each cell's density
#: shrunk toward the sensor-wide mean with the weight of this many cells (a Gamma prior).
CLUTTER_CELL_SIGMAS = 3.0
CLUTTER_PRIOR_CELLS = 1.0
#: A clutter-map cell with plots in at least this share of the scans is reported as a
#: stationary return (a moving object crosses a cell in a few scans); at most this many.
STATIONARY_SHARE = 0.5
STATIONARY_MAX = 50
#: Revisit periods (s) tried first and last by :func:`free_revisit`; the estimate is accepted
#: when it agrees with the revisit tracked with to ``REVISIT_AGREEMENT`` (relative).
REVISIT_TRIAL = 4.0
REVISIT_MAX = MAX_TURN_SECONDS
REVISIT_AGREEMENT = 0.2
#: Confirmed tracks with at least this many plots give the revisit estimate.
REVISIT_MIN_HITS = 5


@dataclass(frozen=True, slots=True)
class PlotTiming:
    """How one sensor's plots are grouped in time (module docstring: *Scans and revisits*).

    frame: (N,) int64, plots taken together (an object gives at most one plot per frame);
    scan: (N,) int64, the scan number, or for plots in no scan order the number of whole
    revisit periods since the first plot; clock: (N,) float, the same in revisits (the scan
    number itself for a scanning radar); revisit: the revisit period (s; 0 with one scan);
    order: "rotating", "framed" or "free".
    """

    frame: np.ndarray
    scan: np.ndarray
    clock: np.ndarray
    revisit: float
    order: str

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
        return PlotTiming(scan, scan, scan.astype(float), revisit_period(t, scan),
                          "framed" if framed else "rotating")
    frame = np.cumsum(np.concatenate([[False], np.diff(t) > 0.0])).astype(np.int64)
    revisit = free_revisit(t, p, R, frame, planar)
    clock = (t - t[0]) / revisit if t.size else np.zeros(0)
    return PlotTiming(frame, np.floor(clock).astype(np.int64), clock, revisit, "free")


def free_revisit(t: np.ndarray, p: np.ndarray, R: np.ndarray, frame: np.ndarray,
                 planar: bool = False) -> float:
    """Revisit period (s) of plots in no scan order (arguments as :func:`track_plots`): the
    median time between consecutive plots of the confirmed tracks with at least
    ``REVISIT_MIN_HITS`` plots, tracked with a trial revisit; tracked again with the estimate
    until the two agree to ``REVISIT_AGREEMENT`` (at most four times). A trial that confirms
    no such track is doubled, up to ``REVISIT_MAX``; with none even then, ``REVISIT_MAX``."""
    trial = REVISIT_TRIAL
    for _ in range(4):
        label = track_plots(t, p, R, frame, (t - t[0]) / trial, planar)
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


def _clutter_cells(p: np.ndarray, R: np.ndarray, planar: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clutter map's cells of plots p (N, 3) ENU m with covariances R (N, 3, 3): cell of
    each plot (N,) (an index into the occupied cells), plots per occupied cell, and the cell
    size (axes,) m: ``CLUTTER_CELL_SIGMAS`` median plot sigmas along east, north and (unless
    ``planar``) up."""
    axes = 2 if planar else 3
    sig = np.sqrt(np.maximum(np.einsum("nii->ni", R)[:, :axes], 1e-12))
    cell = CLUTTER_CELL_SIGMAS * np.median(sig, axis=0)                 # (axes,) m
    index = np.floor(p[:, :axes] / cell).astype(np.int64)
    _, inverse, counts = np.unique(index, axis=0, return_inverse=True, return_counts=True)
    return inverse.ravel(), counts, cell


def clutter_density(p: np.ndarray, R: np.ndarray, n_scans: float, planar: bool
                    ) -> np.ndarray:
    """(N,) the clutter density (plots per scan per m^2, or per m^3 unless ``planar``) at each
    plot's place: the sensor's spatial clutter map (module docstring: *Clutter map*).

    p: (N, 3) ENU m; R: (N, 3, 3) m^2; n_scans: scans (or revisits) the plots span; planar:
    the sensor measures no elevation (cells in east and north only).
    """
    axes = 2 if planar else 3
    if p.shape[0] == 0:
        return np.zeros(0)
    inverse, counts, cell = _clutter_cells(p, R, planar)
    volume = float(np.prod(cell))
    box = float(np.prod(np.ptp(p[:, :axes], axis=0) + cell))
    mean_count = p.shape[0] * volume / box                    # the sensor-wide mean per cell
    n = max(float(n_scans), 1.0)
    others = counts[inverse] - 1.0                             # the plot itself left out
    return (others + CLUTTER_PRIOR_CELLS * mean_count) / \
        ((1.0 + CLUTTER_PRIOR_CELLS) * n * volume)


def stationary_returns(p: np.ndarray, R: np.ndarray, scan: np.ndarray, planar: bool
                       ) -> list[dict[str, float]]:
    """The clutter map's cells that hold plots in at least ``STATIONARY_SHARE`` of the scans:
    quays, moored boats, shore and other stationary returns, which the track score treats as
    clutter. Each {"e", "n", "u": the mean position of its plots (range ENU m), "share": the
    share of the scans (revisits) with a plot there, "plots": its plots}, most persistent
    first, at most ``STATIONARY_MAX`` of them. Arguments as :func:`clutter_density`, with
    ``scan`` (N,) the plots' scans (:attr:`PlotTiming.scan`)."""
    usable = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
    p, R, scan = p[usable], R[usable], np.asarray(scan)[usable]
    n_scans = np.unique(scan).size
    if n_scans == 0:
        return []
    inverse, counts, _ = _clutter_cells(p, R, planar)
    scans_in = np.array([np.unique(scan[inverse == c]).size for c in range(counts.size)])
    share = scans_in / n_scans
    out = []
    for c in np.argsort(-share, kind="stable"):
        if share[c] < STATIONARY_SHARE or len(out) >= STATIONARY_MAX:
            break
        mean = p[inverse == c].mean(axis=0)
        out.append({"e": float(mean[0]), "n": float(mean[1]), "u": float(mean[2]),
                    "share": float(share[c]), "plots": int(counts[c])})
    return out


@dataclass(slots=True)
class _ImmTrack:
    """A track under way in the plot tracker's IMM: per motion model states xs (M, 6)
    [p, v] ENU, covariances Ps (M, 6, 6), model probabilities mu (M,), all at time t (s);
    the clock (scans or revisits, :class:`PlotTiming`) of its first and last plot; its
    score (log-likelihood ratio object / clutter) and the best score it reached."""

    xs: np.ndarray
    Ps: np.ndarray
    mu: np.ndarray
    t: float
    first_scan: float
    last_scan: float
    score: float = 0.0
    best: float = 0.0
    confirmed: bool = False
    rows: list[int] = field(default_factory=list)


def _imm_predict(xs: np.ndarray, Ps: np.ndarray, mu: np.ndarray, dt: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IMM interaction and prediction of K (track, plot) pairs: the tracks' per-model states
    xs (K, M, 6), covariances Ps (K, M, 6, 6) and model probabilities mu (K, M), carried dt
    (K,) s to the plots -> predicted model probabilities (K, M), states (K, M, 6) and
    covariances (K, M, 6, 6).

    Markov switching between the models with mean sojourn ``MODEL_SOJOURN`` s: over dt the
    probability to be in another model is ``(1 - exp(-M dt / tau)) / M`` (M models, every
    switch alike); the mixed initial conditions are the usual IMM moments (Blom and
    Bar-Shalom 1988)."""
    M = len(MODEL_PSD)
    other = (1.0 - np.exp(-M * np.abs(dt) / MODEL_SOJOURN)) / M     # (K,)
    Pi = other[:, None, None] * np.ones((M, M))
    Pi[:, np.arange(M), np.arange(M)] = 1.0 - (M - 1) * other[:, None]   # (K, M, M)
    joint = Pi * mu[:, :, None]                                    # i -> j, (K, M, M)
    c = joint.sum(axis=1)                                          # (K, M)
    w = joint / np.maximum(c[:, None, :], 1e-300)                  # mu_{i|j}
    x0 = np.einsum("kij,kid->kjd", w, xs)                          # (K, M, 6)
    d = xs[:, :, None, :] - x0[:, None, :, :]                      # (K, i, j, 6)
    P0 = (np.einsum("kij,kide->kjde", w, Ps)
          + np.einsum("kij,kijd,kije->kjde", w, d, d))
    xp = np.empty_like(x0)
    Pp = np.empty_like(P0)
    for m, q in enumerate(MODEL_PSD):
        if q == MANOEUVRE_PSD:             # a turn at the track's speed (manoeuvre_psd)
            q = manoeuvre_psd(x0[:, m, 3:], P0[:, m, 3:, 3:])
        xp[:, m], Pp[:, m] = cv_predict(x0[:, m], P0[:, m], dt, q)
    return c, xp, Pp


def manoeuvre_psd(v: np.ndarray, Pv: np.ndarray) -> np.ndarray:
    """(K,) white-acceleration PSD ((m/s^2)^2/s) of the IMM's manoeuvre model for tracks of
    velocity v (K, 3) m/s with covariance Pv (K, 3, 3): a manoeuvre is a turn, whose
    acceleration is the speed times the turn rate, so the PSD scales with the square of the
    speed (taken at its upper bound, |v| + 3 sigma): ``MANOEUVRE_PSD`` (a 6 g turn) at
    ``MANOEUVRE_SPEED`` and above, down to ``MANOEUVRE_FLOOR`` for an object at rest. A boat
    at 4 m/s turns at most a few tenths of a g; a model that lets it leap a fighter's 480 m
    between two scans takes the sea clutter of every missed scan into its track."""
    sigma_v = np.sqrt(np.maximum(np.einsum("kii->k", Pv) / 3.0, 0.0))
    speed = np.linalg.norm(v, axis=-1) + 3.0 * sigma_v
    return np.clip(MANOEUVRE_PSD * (speed / MANOEUVRE_SPEED) ** 2, MANOEUVRE_FLOOR,
                   MANOEUVRE_PSD)


def _candidate_pairs(xs: np.ndarray, Ps: np.ndarray, mu: np.ndarray, t_track: np.ndarray,
                     t: np.ndarray, p: np.ndarray, R: np.ndarray, gate: float,
                     stamp_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """(track index (K,), plot index (K,)) of the pairs that can pass the chi-square
    ``gate`` in some model: a conservative bound from the tracks' model spread and the
    traces of their covariances (a Mahalanobis distance within the gate puts the plot within
    ``sqrt(gate * largest eigenvalue of S)`` of a model's prediction), so that the IMM runs
    only where it can matter. xs (L, M, 6), Ps (L, M, 6, 6), mu (L, M), t_track (L,);
    t (A,), p (A, 3), R (A, 3, 3)."""
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
    centre = mean[:, None, :3] + (t[None, :] - t_track[:, None])[..., None] * mean[:, None, 3:]
    reach = spread_p[:, None] + dt * spread_v[:, None] + np.sqrt(gate * var)
    with np.errstate(invalid="ignore"):
        near = np.linalg.norm(p[None, :, :] - centre, axis=2) <= reach
    return np.nonzero(near)


def _start_imm(p: np.ndarray, R: np.ndarray, t: float, clock: float, row: int) -> _ImmTrack:
    M = len(MODEL_PSD)
    P = np.zeros((6, 6))
    P[:3, :3] = R
    P[3:, 3:] = (INITIATION_SPEED / 3.0) ** 2 * np.eye(3)   # 3 sigma = the speed bound
    x = np.concatenate([p, np.zeros(3)])
    return _ImmTrack(np.tile(x, (M, 1)), np.tile(P, (M, 1, 1)), np.full(M, 1.0 / M), t,
                     clock, clock, rows=[row])


def track_plots(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                clock: np.ndarray | None = None, planar: bool = False,
                stamp_sigma: float = 0.0) -> np.ndarray:
    """(N,) int64 track label per plot (0, 1, ... in order of first plot; -1 = clutter).

    t: (N,) s ascending; p: (N, 3) ENU m; R: (N, 3, 3) m^2; scan: (N,) the frames plots are
    assigned in (:class:`PlotTiming`; a scanning radar's scan numbers); clock: (N,) float,
    the time in scans or revisits that counts misses (default: ``scan``); planar: the sensor
    measures no elevation (the clutter map and the score in east and north only);
    stamp_sigma: the sigma (s) of a plot's time stamp about its true time (a radar that
    stamps a whole scan with one time: the scan period over sqrt(12)), carried into each
    plot's position noise along the track's velocity. See the module docstring (*Tracker*)
    for the method.
    """
    if clock is None:
        clock = np.asarray(scan, dtype=float)
    label = np.full(t.size, -1, dtype=np.int64)
    usable = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
    if not usable.all():            # plots without a position (no platform geometry)
        if usable.any():
            label[usable] = track_plots(t[usable], p[usable], R[usable], scan[usable],
                                        clock[usable], planar, stamp_sigma)
        return label
    if t.size == 0:
        return label
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    axes = 2 if planar else 3
    clutter = clutter_density(p, R, float(clock.max() - clock.min()) + 1.0, planar)
    log_pd, log_miss = np.log(DETECTION_PROBABILITY), np.log1p(-DETECTION_PROBABILITY)
    live: list[_ImmTrack] = []
    done: list[_ImmTrack] = []
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    for rows in np.split(order, bounds):
        k = float(clock[rows[0]])
        cost = np.full((rows.size, len(live)), np.inf)
        pair = np.full((len(live), rows.size), -1, dtype=np.int64)
        if live:                                     # the live tracks against the plots
            xs_l = np.stack([tr.xs for tr in live])
            Ps_l = np.stack([tr.Ps for tr in live])
            mu_l = np.stack([tr.mu for tr in live])
            t_l = np.array([tr.t for tr in live])
            pl, pa = _candidate_pairs(xs_l, Ps_l, mu_l, t_l, t[rows], p[rows], R[rows],
                                      gate, stamp_sigma)
            pair[pl, pa] = np.arange(pl.size)
        if live and pl.size:
            c, xp, Pp = _imm_predict(xs_l[pl], Ps_l[pl], mu_l[pl], t[rows][pa] - t_l[pl])
            S = Pp[..., :3, :3] + R[rows][pa][:, None]                # (K, M, 3, 3)
            if stamp_sigma > 0.0:                    # the time stamp's error, along v
                v = xp[..., 3:]
                S = S + stamp_sigma ** 2 * v[..., :, None] * v[..., None, :]
            d = p[rows][pa][:, None] - xp[..., :3]                  # (K, M, 3)
            m2 = np.einsum("kmi,kmi->km", d, np.linalg.solve(S, d[..., None])[..., 0])
            if planar:                               # the score in east and north only
                S2, d2 = S[..., :2, :2], d[..., :2]
                m2s = np.einsum("kmi,kmi->km", d2,
                                np.linalg.solve(S2, d2[..., None])[..., 0])
                logdet = np.linalg.slogdet(S2)[1]
            else:
                m2s, logdet = m2, np.linalg.slogdet(S)[1]
            with np.errstate(invalid="ignore", over="ignore"):
                loglik = -0.5 * (m2s + logdet + axes * np.log(2.0 * np.pi))  # (K, M)
                mix = np.log(np.maximum((c * np.exp(loglik)).sum(axis=1), 1e-300))
            # the gain of taking plot a into track l rather than leaving the track missed
            # and the plot to clutter or a new track: log(PD p(z) / clutter) - log(1 - PD);
            # a confirmed track takes no plot likelier clutter than its own (a tentative
            # one takes what its gate holds, and its score judges it)
            gain = log_pd + mix - np.log(clutter[rows][pa]) - log_miss          # (K,)
            confirmed = np.array([tr.confirmed for tr in live])[pl]
            ok = (m2 <= gate).any(axis=1) & ((gain > 0.0) | ~confirmed)
            cost[pa[ok], pl[ok]] = -gain[ok]
        taken = np.zeros(rows.size, dtype=bool)
        if live and rows.size and np.isfinite(cost).any():
            a_idx, j_idx = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e12))
            for a, j in zip(a_idx, j_idx):
                if not np.isfinite(cost[a, j]):
                    continue
                tr, i, q = live[j], int(rows[a]), int(pair[j, a])
                K = np.linalg.solve(S[q], Pp[q, :, :3, :]).swapaxes(-1, -2)  # (M, 6, 3)
                tr.xs = xp[q] + np.einsum("mij,mj->mi", K, d[q])
                tr.Ps = Pp[q] - K @ Pp[q, :, :3, :]
                tr.Ps = 0.5 * (tr.Ps + np.swapaxes(tr.Ps, -1, -2))
                post = c[q] * np.exp(loglik[q] - loglik[q].max())
                tr.mu = post / post.sum()
                missed = max(0.0, k - tr.last_scan - 1.0)
                tr.score += missed * log_miss + log_pd + mix[q] - np.log(clutter[i])
                tr.best = max(tr.best, tr.score)
                tr.t, tr.last_scan = float(t[i]), k
                tr.rows.append(i)
                tr.confirmed |= tr.score >= CONFIRM_SCORE
                taken[a] = True
        keep = []
        for tr in live:
            now = tr.score + max(0.0, k - tr.last_scan - 1.0) * log_miss
            expired = (now < tr.best - DELETE_DROP
                       or (not tr.confirmed and k - tr.first_scan >= CONFIRM_SCANS
                           and now <= CLUTTER_SCORE))
            (done if expired else keep).append(tr)
        live = keep
        for a in np.flatnonzero(~taken):
            i = int(rows[a])
            live.append(_start_imm(p[i], R[i], float(t[i]), k, i))
    done.extend(live)
    confirmed = sorted((tr for tr in done if tr.confirmed), key=lambda tr: tr.rows[0])
    for n, tr in enumerate(confirmed):
        label[np.asarray(tr.rows)] = n
    return label
