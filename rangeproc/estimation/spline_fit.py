"""Batch (post-flight) cubic B-spline trajectory fit: weighted least squares by Gauss-Newton.

Zhou et al. 2001 (introduction, refs. [1, 3-5]) note that offline processing of range-rate
data is done by batch non-linear regression on a spline trajectory with well-placed knots; its
sec. 1.2 (citing [1]) represents the position on ``[T_s, T_e]`` by a cubic spline with interior
knots ``T_1 < ... < T_{N-1}``, the jerk ``S_i`` being constant on each knot interval. This is
that batch counterpart of the adaptive spline filter, for every sensor kind of
:mod:`rangeproc.models.measurement` (range rate: Zhou et al. 2001 eqs. 1-2, white noise eq. 4):

* ``p(t) = sum_j c_j B_j(t)`` (range ENU, m), ``v = sum_j c_j B_j'``, ``a = sum_j c_j B_j''``,
  ``B_j`` the cubic B-splines on the clamped knots ``[T_s]*4 + interior + [T_e]*4``;
* minimise ``chi2(c) = sum ((z - h(x(t; c))) / sigma)^2`` (azimuth residuals wrapped), plus an
  optional Gaussian prior on ``(p, v)`` at one time, by Gauss-Newton with step halving;
* unknowns flattened coefficient-major, index ``3 j + axis`` (E, N, U) = ``coef.ravel()``. A row
  involves 4 consecutive ``c_j`` (12 contiguous unknowns), so ``J^T W J`` is banded and is
  accumulated directly in band storage by a compiled loop: O(rows) time and memory, a banded
  Cholesky solve, and the covariance band by selected inversion, all O(n_coef).

Regularisation (the documented choice): a pseudo-observation ``S_{i+1} - S_i = 0`` on the jerk
jump at every interior knot, weighted ``1e-10 x`` the mean diagonal of the data normal matrix.
Like Zhou et al.'s filter, which keeps ``S_i`` until an anomaly says otherwise, a gap in the data
spanning several knot intervals (otherwise singular) is bridged by continuing the jerk: the
normal matrix stays definite and the gap's covariance comes out large but finite. Where data
exist the bias is negligible (nanometres in the tests). A problem still singular (e.g. no
position information at all) gets a ridge (damping toward the current estimate) and a
RuntimeWarning; its unobservable directions then carry huge variances.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.interpolate import BSpline
from scipy.linalg import LinAlgError, cho_solve_banded, cholesky_banded, solve_triangular

from rangeproc.models.measurement import CARTESIAN, N_COMPONENTS, SPHERICAL, innovation, measure

_BW = 12            # half bandwidth of the normal matrix (jerk-jump rows couple 5 coefficients)
_JERK_EPS = 1e-10   # weight of the jerk-jump regularisation relative to the data information
_PIVOT_TOL = 1e-14  # Cholesky pivot^2 / diagonal below this = numerically singular


@dataclass(frozen=True)
class SplineFit:
    """A fitted trajectory.

    knots: full clamped knot vector (s); coef: (n_coef, 3) ENU control points (m);
    cov: scipy.sparse CSR (3 n_coef, 3 n_coef) covariance of ``coef.ravel()`` (index
    ``3 j + axis``); only the band ``|i - k| <= 12`` is computed (exact there, by selected
    inversion), which holds every entry that :meth:`evaluate` needs; chi2: whitened residual sum
    of squares of the measurements (and prior) at the solution; dof: used components (+6 with a
    prior) minus ``3 n_coef``; n_iter: Gauss-Newton steps; converged: convergence reached.
    """

    knots: np.ndarray
    coef: np.ndarray
    cov: sp.csr_array
    chi2: float
    dof: int
    n_iter: int
    converged: bool

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States (T, 9) ``[p, v, a]`` (m, m/s, m/s^2, range ENU) and their covariances
        (T, 9, 9) at times ``t`` (T,) s, which must lie inside ``[knots[0], knots[-1]]``.
        Costs O(T): only the 12x12 covariance block of the 4 active coefficients is used."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.size and (t.min() < self.knots[0] or t.max() > self.knots[-1]):
            raise ValueError(f"evaluation times outside the fitted span "
                             f"[{self.knots[0]}, {self.knots[-1]}] s")
        span, bas = _basis(self.knots, t, 3)
        idx = 3 * (span[:, None] - 3) + np.arange(12)                       # (T, 12)
        M = np.einsum("tdq,ae->tdaqe", bas, np.eye(3)).reshape(len(t), 9, 12)
        x = np.einsum("tik,tk->ti", M, self.coef.ravel()[idx])
        diags = [self.cov.diagonal(k) for k in range(12)]
        C = np.empty((len(t), 12, 12))
        for p in range(12):
            for q in range(p, 12):
                C[:, p, q] = C[:, q, p] = diags[q - p][idx[:, p]]
        return x, M @ C @ M.transpose(0, 2, 1)


def _basis(knots: np.ndarray, t: np.ndarray, nder: int) -> tuple[np.ndarray, np.ndarray]:
    """Knot span ``mu`` (T,) (active B_j: j = mu-3..mu) and ``bas`` (T, nder, 4): derivative
    ``d`` of ``B_{mu-3+q}`` at ``t``. scipy evaluates all 4 at once: spline ``r`` has
    coefficients ``[j % 4 == r]``, and exactly one active ``j`` has each residue."""
    n_coef = len(knots) - 4
    span = np.clip(np.searchsorted(knots, t, side="right") - 1, 3, n_coef - 1)
    sel = np.zeros((n_coef, 4))
    sel[np.arange(n_coef), np.arange(n_coef) % 4] = 1.0
    spl = BSpline(knots, sel, 3)
    cols = (span[:, None] - 3 + np.arange(4)) % 4
    bas = np.empty((len(t), nder, 4))
    for d in range(nder):
        bas[:, d, :] = np.take_along_axis(spl(t, nu=d), cols, axis=1)
    return span, bas


@njit(cache=True, nogil=True, error_model="numpy")
def _accumulate(coef, span, bas, model, z, sigma, s, sv, Qr, used, abT, g):
    """Add the rows' whitened Gauss-Newton normal equations at ``coef`` (3 n_coef,) to
    ``abT`` (n, BW+1) (``abT[k, BW+i-k] = N[i, k]``, i <= k) and ``g = J^T W r``; returns chi2.
    dh/dc_{j,axis} = H[:, axis] B_j(t) + H[:, 3+axis] B_j'(t)."""
    bw = abT.shape[1] - 1
    x, a = np.zeros(9), np.empty(12)
    h, y, H = np.empty(N_COMPONENTS), np.empty(N_COMPONENTS), np.empty((N_COMPONENTS, 9))
    chi2 = 0.0
    for i in range(span.shape[0]):
        if not used[i].any():
            continue
        base = 3 * (span[i] - 3)
        for d in range(3):
            for ax in range(3):
                acc = 0.0
                for q in range(4):
                    acc += bas[i, d, q] * coef[base + 3 * q + ax]
                x[3 * d + ax] = acc
        measure(model[i], x, s[i], sv[i], Qr[i], h, H)
        innovation(model[i], z[i], h, y)                 # z - h, azimuth wrapped
        for c in range(N_COMPONENTS):
            if not used[i, c]:
                continue
            w = 1.0 / sigma[i, c]
            r = y[c] * w
            chi2 += r * r
            for q in range(4):
                b0, b1 = bas[i, 0, q] * w, bas[i, 1, q] * w
                for ax in range(3):
                    a[3 * q + ax] = H[c, ax] * b0 + H[c, 3 + ax] * b1
            for p in range(12):
                if a[p] == 0.0:
                    continue
                g[base + p] += a[p] * r
                for q in range(p, 12):
                    abT[base + q, bw + p - q] += a[p] * a[q]
    return chi2


@njit(cache=True, nogil=True, error_model="numpy")
def _band_inverse(cb):
    """Band of ``N^-1`` from the upper band Cholesky factor ``cb`` (N = U^T U, LAPACK upper
    form ``cb[bw+i-k, k] = U[i, k]``), same form; O(n bw^2) (Takahashi recurrence from
    ``U Z = U^-T``: ``Z_ij = (delta_ij / U_ii - sum_{k>i} U_ik Z_kj) / U_ii``)."""
    bw, n = cb.shape[0] - 1, cb.shape[1]
    zb = np.zeros_like(cb)
    for i in range(n - 1, -1, -1):
        kmax = min(i + bw, n - 1)
        for j in range(kmax, i - 1, -1):
            acc = 1.0 / cb[bw, i] if j == i else 0.0
            for k in range(i + 1, kmax + 1):
                zkj = zb[bw + k - j, j] if k <= j else zb[bw + j - k, k]
                acc -= cb[bw + i - k, k] * zkj
            zb[bw + i - j, j] = acc / cb[bw, i]
    return zb


def _band_of(S: sp.spmatrix, bw: int) -> np.ndarray:
    """Symmetric sparse ``S`` -> transposed upper band form (n, bw+1)."""
    out = np.zeros((S.shape[0], bw + 1))
    for k in range(bw + 1):
        out[k:, bw - k] = S.diagonal(k)
    return out


def _factor(abT: np.ndarray) -> np.ndarray:
    """Cholesky factor (LAPACK upper band form) of the band matrix ``abT``; a singular matrix
    gets a growing ridge ``mu * mean(diag)`` (RuntimeWarning)."""
    ab = np.ascontiguousarray(abT.T)
    diag, bw = ab[-1].copy(), ab.shape[0] - 1
    for mu in (0.0, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        if mu:
            ab[-1] = diag + mu * max(diag.mean(), 1e-300)
        try:
            cb = cholesky_banded(ab, lower=False)
        except LinAlgError:
            continue
        if np.all(cb[bw] ** 2 >= _PIVOT_TOL * ab[-1]):
            if mu:
                warnings.warn(f"spline fit: singular normal matrix (unobservable directions), "
                              f"ridge {mu:g} x mean diagonal added", RuntimeWarning, stacklevel=3)
            return cb
    raise LinAlgError("spline fit: normal matrix not positive definite even with a ridge")


def _jerk_penalty(knots: np.ndarray) -> sp.csr_array:
    """``R^T R`` (n_coef, n_coef): R maps one axis' coefficients to the jerk jumps
    ``S_{mu+1} - S_mu`` at the interior knots (Zhou et al. 2001 sec. 1.2: S_i constant per
    interval)."""
    n_coef = len(knots) - 4
    mids = 0.5 * (knots[3:n_coef] + knots[4:n_coef + 1])         # one per knot interval
    _, b3 = _basis(knots, mids, 4)
    m, q = np.divmod(np.arange(4 * (n_coef - 4)), 4)           # knot m: spans m+3 | m+4
    R = sp.csr_array((np.r_[-b3[m, 3, q], b3[m + 1, 3, q]], (np.r_[m, m], np.r_[m + q, m + 1 + q])),
                     shape=(n_coef - 4, n_coef))
    return sp.csr_array(R.T @ R)


def _clean_knots(interior, t_lo: float, t_hi: float) -> np.ndarray:
    """Clamped knot vector: interior knots sorted, kept strictly inside the span, and those
    within 1e-9 of the span of the previous one dropped."""
    k, eps = np.unique(np.asarray(interior, dtype=float)), 1e-9 * (t_hi - t_lo)
    k = k[(k > t_lo + eps) & (k < t_hi - eps)]
    return np.r_[[t_lo] * 4, k[np.r_[True, np.diff(k) > eps][:len(k)]], [t_hi] * 4]


def fit_spline(t, model, z, sigma, s, sv, Qr, *, interior_knots, x_init=None, use=None,
               max_iter=20, tol=1e-9, prior=None) -> SplineFit:
    """Fit a cubic B-spline trajectory to measurement rows (MeasurementBatch layout).

    Args:
        t (N,) s; model (N,) int; z (N, 6) SI, NaN = not measured; sigma (N, 6) 1-sigma;
        s, sv (N, 3) sensor position (m) / velocity (m/s), range ENU; Qr (N, 3, 3).
        A component is used when z is finite, sigma > 0, ``use`` (N, 6) bool (if given) is
        True and, for SPHERICAL rows, its index is < 4.
        interior_knots: knot times (s), e.g. a filter's anomaly times plus a regular grid;
            sorted, deduplicated, those outside the data span dropped. The span is that of
            the used rows (and the prior time).
        x_init: optional (N, 9) state per row (e.g. a smoothed track); the initial coefficients
            are its positions' linear least-squares spline fit. Without it, the initial spline
            is the linear fit to the CARTESIAN rows (GPS position fixes: that model is linear,
            one step is exact), or, without those, the prior's constant-velocity line.
        max_iter, tol: Gauss-Newton stops when the relative chi2 decrease or the predicted
            decrease ``g^T dc`` (relative to max(chi2, 1)) falls below ``tol``.
        prior: optional ``(t0, x0 (>=6,), P0 (>=6, >=6))``: Gaussian prior on ``[p, v]`` at
            ``t0`` (m, m/s), added as 6 whitened rows ``L^-1 (x0 - x(t0))``, ``P0 = L L^T``.
    """
    t, z, sigma, s, sv, Qr = (np.ascontiguousarray(a, dtype=float)
                              for a in (t, z, sigma, s, sv, Qr))
    model = np.ascontiguousarray(model, dtype=np.int64)
    with np.errstate(invalid="ignore"):
        used = np.isfinite(z) & (sigma > 0)
    if use is not None:
        used &= np.asarray(use, dtype=bool)
    used[model == SPHERICAL, 4:] = False
    rows = used.any(axis=1)
    times = np.r_[t[rows], [float(prior[0])] if prior is not None else []]
    if times.size == 0 or times.max() <= times.min():
        raise ValueError("spline fit: no used measurement rows spanning a time interval")
    knots = _clean_knots(interior_knots, times.min(), times.max())
    normal = _Normal(knots, t, (model, z, sigma, s, sv, Qr), prior)
    c = _initial_coefficients(normal, used, x_init, prior)
    c, chi2, abT, n_iter, converged = _gauss_newton(normal, c, used, max_iter, tol)
    zb = _band_inverse(_factor(abT))
    ks = range(-_BW, _BW + 1)
    cov = sp.diags([zb[_BW - abs(k), abs(k):] for k in ks], list(ks), format="csr")
    dof = int(used.sum()) + (6 if prior is not None else 0) - normal.n
    return SplineFit(knots=knots, coef=c.reshape(-1, 3), cov=sp.csr_array(cov),
                     chi2=float(chi2), dof=dof, n_iter=n_iter, converged=converged)


class _Normal:
    """The penalised least-squares problem of one fit: the rows' B-spline basis, the jerk
    penalty and the prior's whitened rows; :meth:`assemble` gives the objective and the
    banded normal equations at a coefficient vector (flat, ``3 j + axis``)."""

    def __init__(self, knots: np.ndarray, t: np.ndarray, rows: tuple, prior) -> None:
        self.knots, self.t, self.rows, self.prior = knots, t, rows, prior
        self.n = 3 * (len(knots) - 4)
        self.span, self.bas = _basis(knots, t, 3)
        self.pen1 = _jerk_penalty(knots)
        self.pen = sp.csr_array(sp.kron(self.pen1, sp.eye(3)))      # flat order 3 j + axis
        self.pen_band = _band_of(self.pen, _BW)
        if prior is not None:
            sp0, b0 = _basis(knots, np.array([float(prior[0])]), 2)
            self.pbase = 3 * (sp0[0] - 3)
            M6 = np.einsum("dq,ae->daqe", b0[0], np.eye(3)).reshape(6, 12)
            L = np.linalg.cholesky(np.asarray(prior[2], dtype=float)[:6, :6])
            self.A_p = solve_triangular(L, M6, lower=True)
            self.x0_w = solve_triangular(L, np.asarray(prior[1], dtype=float)[:6], lower=True)
            self.AtA = self.A_p.T @ self.A_p

    def assemble(self, c: np.ndarray, mask: np.ndarray, lam: float | None) -> tuple:
        """Objective, chi2, normal band and gradient at flattened coefficients ``c``, the
        rows' components in ``mask`` (N, 6); ``lam``: the penalty's weight (None: chosen
        here, once per fit, relative to the data's information)."""
        n = self.n
        abT, g = np.zeros((n, _BW + 1)), np.zeros(n)
        chi2 = _accumulate(c, self.span, self.bas, *self.rows, mask, abT, g)
        if self.prior is not None:
            pb = self.pbase
            r = self.x0_w - self.A_p @ c[pb:pb + 12]
            chi2 += r @ r
            g[pb:pb + 12] += self.A_p.T @ r
            for k in range(12):                                  # A^T A into the band
                abT[pb + k, _BW - k:] += self.AtA[:k + 1, k]
        if lam is None:                                          # fixed once per fit
            dn = abT[:, _BW]
            lam = _JERK_EPS * max(dn.mean(), 1e-300) / max(self.pen_band[:, _BW].mean(),
                                                           1e-300)
        pc = self.pen @ c
        return chi2 + lam * (c @ pc), chi2, abT + lam * self.pen_band, g - lam * pc, lam


def _solve(abT: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The solution of the banded normal equations ``abT`` (upper band form) for ``g``."""
    return cho_solve_banded((_factor(abT), False), g)


def _initial_coefficients(normal: _Normal, used: np.ndarray, x_init, prior) -> np.ndarray:
    """The Gauss-Newton start (flat coefficients): the linear least-squares spline of
    ``x_init``'s positions, else the linear fit to the CARTESIAN rows (exact in one step),
    else the prior's constant-velocity line (see :func:`fit_spline`)."""
    knots, t = normal.knots, normal.t
    model = normal.rows[0]
    if x_init is not None:            # linear LS of x_init positions: one step from c = 0
        pos = np.asarray(x_init, dtype=float)[:, :3]
        ok = np.isfinite(pos).all(axis=1) & (t >= knots[0]) & (t <= knots[-1])
        D = sp.csr_array(BSpline.design_matrix(t[ok], knots, 3))
        Nd, pb = _band_of(D.T @ D, 4), _band_of(normal.pen1, 4)   # per axis, half bw 4
        lam0 = _JERK_EPS * Nd[:, 4].mean() / max(pb[:, 4].mean(), 1e-300)
        return _solve(Nd + lam0 * pb, D.T @ pos[ok]).ravel()
    if (used & (model == CARTESIAN)[:, None]).any():    # CARTESIAN rows: exact in one step
        mask = used & (model == CARTESIAN)[:, None]
        _, _, abT, g, _ = normal.assemble(np.zeros(normal.n), mask, None)
        return _solve(abT, g)
    if prior is not None:           # constant-velocity line through the prior (Greville)
        xi = (knots[1:-3] + knots[2:-2] + knots[3:-1]) / 3.0
        x0 = np.asarray(prior[1], dtype=float)
        return (x0[:3] + (xi[:, None] - float(prior[0])) * x0[3:6]).ravel()
    raise ValueError("spline fit: give x_init, CARTESIAN position rows or a prior")


def _gauss_newton(normal: _Normal, c: np.ndarray, used: np.ndarray, max_iter: int,
                  tol: float) -> tuple:
    """Gauss-Newton with step halving from ``c``; returns the coefficients, chi2, the
    normal band at them, the iterations and whether it converged (see :func:`fit_spline`)."""
    obj, chi2, abT, g, lam = normal.assemble(c, used, None)
    converged, n_iter = False, 0
    while n_iter < max_iter and not converged:
        dc = _solve(abT, g)
        small = g @ dc <= tol * max(obj, 1.0)          # GN-predicted decrease negligible
        step, trial = 1.0, None
        while step > 1e-6:                             # step halving (none once converged)
            trial = normal.assemble(c + step * dc, used, lam)
            if trial[0] <= obj:
                break
            step, trial = (0.0 if small else 0.5 * step), None
        if trial is None:
            converged = bool(small)
            break
        n_iter += 1
        converged = bool(small or obj - trial[0] <= tol * obj)
        c = c + step * dc
        obj, chi2, abT, g, _ = trial
    return c, chi2, abT, n_iter, converged
