"""Strong tracking: multiple suboptimal fading factors on the predicted covariance (Ye and Cui).

Ye and Cui (sec. 2) make their UKF a *strong tracking* filter: a fading matrix
``Lambda_k = diag(lambda^1 .. lambda^n)`` inflates the predicted covariance whenever the
innovations are larger than the filter predicts, which forces the residual sequence back
towards orthogonality (the strong tracking principle). The document's equations were lost in
extraction; they are reconstructed here from the strong tracking literature it cites
(Zhou & Frank, "Strong tracking filtering of nonlinear time-varying stochastic systems with
coloured noise", Int. J. Control 65 (1996); Zhou, Xi & Zhang, "Suboptimal fading extended
Kalman filtering for nonlinear systems", Control & Decision 5 (1990); the UKF form of
Wang, Sun & Zhou, "Strong tracking UKF", 2008):

    V_k   = eps_1 eps_1^T                              (k = 1)
          = (rho V_{k-1} + eps_k eps_k^T) / (1 + rho)  (k > 1), forgetting factor rho = 0.95
    N_k   = V_k - beta R_k - H_k Q_k H_k^T              (beta >= 1: weakening factor)
    M_k   = F P_{k-1|k-1} F^T H_k^T H_k
    c_k   = tr(N_k) / sum_i alpha^i M_k,ii             (alpha^i >= 1: prior ratios)
    lambda^i = alpha^i c_k  if alpha^i c_k > 1  else 1
    P_{k|k-1} = Lambda^(1/2) F P_{k-1|k-1} F^T Lambda^(1/2) + Q_k

(the symmetric square-root placement keeps ``P_{k|k-1}`` symmetric; Zhou's ``Lambda F P F^T``
is not). How it is fitted to a multi-sensor batch filter:

* the filter works in whitened coordinates (``R = I``, ``update.gated_update``), and all rows
  of one epoch (one time stamp, whatever their sensors) form the stacked measurement vector of
  that step, so ``eps`` is their stacked whitened innovation at the unfaded prediction and
  ``tr(beta R) = beta m`` for its ``m`` components. Only traces of V and N enter c_k, so V is
  kept as a scalar: the forgetting average of the mean squared whitened innovation per
  component (the stacked vector's size changes from epoch to epoch with the sensors in it);
* ``H`` is the measurement Jacobian at the prediction for both updates (for the UKF it stands
  in for the statistical linearisation ``P_xz^T P^-1`` of the STUKF papers; they agree to first
  order and the fading factor is a scalar heuristic on top of either);
* the factor is computed and applied once per epoch, before its rows update; a row failing
  the chi-square gate (a wild point) is left out of V and of ``M``: strong tracking is meant
  for abrupt *state* changes, which make the innovations grow before they trip the gate, not
  for outliers;
* an epoch fades only when the state uncertainty is a real part of its innovation variance
  (:data:`STF_MIN_SIGNAL`): noise-dominated rows cannot reveal a model error;
* and only when one of its rows fixes the position by itself (a GPS fix, a radar's range and
  angles): a factor on the whole covariance discards information that the epoch's rows must
  be able to restore, and range rates or angles alone cannot (on MISTRAM alone, fading let the
  weakly observed position wander 145 km off);
* a warm-up: nothing fades before :data:`STF_WARMUP` epochs have entered V;
* factors are capped at :data:`MAX_FADING` and stored per epoch so that the RTS smoother uses
  the very predicted covariance the filter used (``estimation.rts``): the offline counterpart.

Fading acts on the kinematic block (position, velocity, acceleration; ratios ``alpha`` per
block); extra constant states are not faded.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import N_OBSERVED, add_q
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace
from rangeproc.models.measurement import N_COMPONENTS, innovation, measure
from rangeproc.models.motion import N_KINEMATIC, white_jerk_q

#: Epochs that enter V before any may fade: the filter's start-up transient (innovations
#: of a track still converging from its first fixes) is not a model error, and fading it would
#: cut the smoother's start off from the data that follow.
STF_WARMUP = 20

#: Least predicted-state share of an epoch's whitened innovation variance, ``tr(M) / m``, for
#: the epoch to fade: where the state's uncertainty is a small fraction of the noise, V's short
#: memory cannot tell a model error from noise, and the few-percent excesses it sees would be
#: blown up by ``c = tr(N) / tr(M)`` into large factors on the whole state.
STF_MIN_SIGNAL = 0.1

#: Upper bound of a fading factor: one epoch may inflate the covariance by at most this.
MAX_FADING = 1e4

#: Layout of the ``stf`` parameter array of strong tracking's loop (``estimation.forward_loop``).
STF_RHO, STF_BETA, STF_ALPHA = 0, 1, 2
#: Length of ``stf``: rho, beta and the prior ratios of position, velocity, acceleration.
STF_LEN = 5


def fading_params(forgetting: float, weakening: float,
                  ratios: tuple[float, float, float]) -> np.ndarray:
    """The ``stf`` argument of strong tracking's loop (``FilterSettings.fading``; layout
    ``STF_*``): forgetting factor rho, weakening factor beta and the prior ratios alpha of
    position, velocity, acceleration."""
    stf = np.empty(STF_LEN)
    stf[STF_RHO] = forgetting
    stf[STF_BETA] = weakening
    stf[STF_ALPHA:STF_LEN] = ratios
    return stf


@njit(cache=True, error_model="numpy")
def fading_factors(stf: np.ndarray, v_mean: float, m: int, G: np.ndarray, P: np.ndarray,
                   dt: float, q: float, lam: np.ndarray) -> bool:
    """Fading factors ``lam`` (9,) for one epoch (module docstring); True when any exceeds 1.

    Args:
        stf: (5,) rho, beta, alpha_position, alpha_velocity, alpha_acceleration.
        v_mean: V_k / m, the forgetting average of the mean squared whitened innovation.
        m: measured components of the epoch. G: (6, 6) ``H^T H`` of its whitened Jacobian
            rows (position, velocity columns). P: (n, n) the unfaded prediction
            ``F P F^T + Q``. dt, q: the step (s) and its white-jerk PSD (m^2/s^5).
    """
    for i in range(N_KINEMATIC):
        lam[i] = 1.0
    tr_n = m * (v_mean - stf[STF_BETA]) - _qg_trace(G, dt, q, 1.0, 1.0)   # - tr(H Q H^T)
    if tr_n <= 0.0:
        return False
    # sum_i alpha^i M_ii with M = (P - Q) H^T H: H^T H is zero outside position and velocity,
    # so only i, j < 6 contribute (the acceleration block gets lambda = alpha c all the same)
    denom = -_qg_trace(G, dt, q, stf[STF_ALPHA], stf[STF_ALPHA + 1])
    for i in range(N_OBSERVED):
        mii = 0.0
        for j in range(N_OBSERVED):
            mii += P[i, j] * G[j, i]
        denom += stf[STF_ALPHA + i // 3] * mii
    if not denom > STF_MIN_SIGNAL * m:
        return False
    c = tr_n / denom
    faded = False
    for i in range(N_KINEMATIC):
        v = stf[STF_ALPHA + i // 3] * c
        if v > 1.0:
            lam[i] = min(v, MAX_FADING)
            faded = True
    return faded


@njit(cache=True, error_model="numpy")
def _qg_trace(G: np.ndarray, dt: float, q: float, ap: float, av: float) -> float:
    """``sum_i alpha^i (Q G)_ii`` with ``alpha`` = ``ap`` on position, ``av`` on velocity and
    ``G = H^T H`` (6, 6): with unit ratios, ``tr(H Q H^T)``."""
    qpp, qpv, _, qvv, _, _ = white_jerk_q(dt, q)
    acc = 0.0
    for ax in range(3):
        gpv = G[ax, 3 + ax]
        acc += ap * (qpp * G[ax, ax] + qpv * gpv) + av * (qpv * gpv + qvv * G[3 + ax, 3 + ax])
    return acc


@njit(cache=True, error_model="numpy")
def apply_fading(P: np.ndarray, lam: np.ndarray, dt: float, q: float) -> None:
    """``P <- Lambda^(1/2) (P - Q) Lambda^(1/2) + Q`` in place on the kinematic block, with
    ``P`` the unfaded prediction and ``Q = Q(dt, q)`` (so ``P - Q = F P F^T``)."""
    n = P.shape[0]
    add_q(P, dt, -q)
    for i in range(n):
        li = np.sqrt(lam[i]) if i < N_KINEMATIC else 1.0
        for j in range(n):
            lj = np.sqrt(lam[j]) if j < N_KINEMATIC else 1.0
            P[i, j] *= li * lj
    add_q(P, dt, q)


@njit(cache=True, nogil=True, error_model="numpy")
def epoch_innovations(i0: int, meas_epoch: np.ndarray, model: np.ndarray, z: np.ndarray,
                      sigma: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                      x: np.ndarray, P: np.ndarray, gate: np.ndarray, G: np.ndarray,
                      h: np.ndarray, H: np.ndarray, y6: np.ndarray, Hw: np.ndarray,
                      S: np.ndarray, t: np.ndarray, b: np.ndarray) -> tuple[float, int, bool]:
    """Whitened innovations at the unfaded prediction ``x, P`` of all rows of one epoch.

    The epoch's rows (from ``i0`` while ``meas_epoch`` is the same) form one stacked
    measurement vector with ``R = I`` after whitening. Rows whose chi-square
    ``eps^T (H P H^T + I)^-1 eps`` exceeds ``gate`` are left out (wild points). Fills ``G``
    (6, 6) with ``H^T H`` and ``b`` (6,) with ``H^T eps`` of the rows kept (the stacked
    information form; also Zhou et al.'s anomaly test, ``estimation.spline_filter``) and returns
    ``(eps^T eps, m)`` over them, and whether a kept row fixes the position by itself (three
    position components: a GPS fix, or a radar's range, azimuth and elevation).
    ``h, y6`` (6,), ``H`` (6, n), ``Hw`` (6, 6), ``S`` (6, 6), ``t`` (6, 1) work arrays.
    """
    for a in range(N_OBSERVED):
        b[a] = 0.0
        for c in range(N_OBSERVED):
            G[a, c] = 0.0
    e2_sum = 0.0
    m_sum = 0
    fixes = False
    i = i0
    k = meas_epoch[i0]
    while i < meas_epoch.shape[0] and meas_epoch[i] == k:
        measure(model[i], x, s[i], sv[i], Qr[i], h, H)
        innovation(model[i], z[i], h, y6)
        m = 0
        e2 = 0.0
        for c in range(N_COMPONENTS):
            if math.isnan(z[i, c]) or not sigma[i, c] > 0.0:
                continue
            inv = 1.0 / sigma[i, c]
            for j in range(N_OBSERVED):
                Hw[m, j] = H[c, j] * inv
            t[m, 0] = y6[c] * inv
            e2 += t[m, 0] * t[m, 0]
            m += 1
        i += 1
        if m == 0:
            continue
        for a in range(m):                               # S = Hw P Hw^T + I
            for c in range(a + 1):
                acc = 0.0
                for j in range(N_OBSERVED):
                    for l in range(N_OBSERVED):
                        acc += Hw[a, j] * P[j, l] * Hw[c, l]
                S[a, c] = acc
                S[c, a] = acc
            S[a, a] += 1.0
        for a in range(m):                               # keep eps: nis needs it after solve
            y6[a] = t[a, 0]
        if not cholesky_inplace(S, m):
            continue
        chol_solve_inplace(S, m, t, np.int64(1))
        nis = 0.0
        for a in range(m):
            nis += y6[a] * t[a, 0]
        if nis > gate[m]:
            continue
        e2_sum += e2
        m_sum += m
        fixes = fixes or (not math.isnan(z[i - 1, 0]) and not math.isnan(z[i - 1, 1])
                          and not math.isnan(z[i - 1, 2]))
        for a in range(m):                               # G += Hw^T Hw, b += Hw^T eps
            for j in range(N_OBSERVED):
                b[j] += Hw[a, j] * y6[a]
                for l in range(N_OBSERVED):
                    G[j, l] += Hw[a, j] * Hw[a, l]
    return e2_sum, m_sum, fixes
