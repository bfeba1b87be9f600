"""Joint least squares of a trajectory correction and constant sensor calibration terms.

The registration problem of He 2015 (cooperative-target spatial registration), posed as the
Gauss-Newton step of the batch MAP estimate that an augmented-state smoother (kinematic state
plus constant calibration states) would give, but solved as a sparse linear system so that
its cost does not grow with the square of the number of calibration terms:

* unknowns: ``dx_g`` (9,) corrections of the linearisation track at ``G`` nodes (a subset of
  the smoother's epochs) and ``c`` (p,) calibration terms (all sensors together);
* measurement rows: each measured component ``k`` of a row at time ``t`` with residual
  ``r = z - h(x_bar(t))`` gives ``r = h_k F(t - t_g) dx_g + a_k c + v``, ``v ~ N(0, 1/w)``,
  ``g`` the node nearest in time, ``h_k`` the row's Jacobian (``models.measurement``), ``F``
  the constant-acceleration transition and ``a_k`` the sensitivity of the component to the
  calibration terms of its sensor (:func:`row_design`);
* process rows: between consecutive nodes ``dx_{g+1} - F dx_g + e_g ~ N(0, Q_g)`` with
  ``e_g = x_bar_{g+1} - F x_bar_g`` and the white-jerk ``Q`` of the smoother's local ``q``
  (``models.motion``): the same dynamics the smoother assumes.

The normal matrix is block tridiagonal in the nodes (9x9 blocks) bordered by ``p`` dense
columns; it is solved by a banded Cholesky factorisation of the node part and the Schur
complement of the border (:func:`solve_joint`), which also yields the covariance of ``c`` and
the sensitivity of each node's state to ``c`` (to add the calibration's uncertainty to the
trajectory's).

Calibration slots per sensor (``SLOTS``): biases of range, azimuth, elevation (measured minus
true), latency (time stamp minus true time: the row measured the state at ``t - latency``, so
``dz/dlatency = -dh/dt``, including the platform's motion and rotation) and the mount rotation
(roll, pitch, yaw of the sensor's axes relative to the INS body axes: ``d_sensor = M^T d_body``
with ``M ~ I + [theta x]``, so ``dd_sensor/dtheta = [d_body x]``).
"""
from __future__ import annotations

import numpy as np
from numba import njit
from scipy.linalg import cho_solve_banded, cholesky_banded

from rangeproc.models.measurement import N_COMPONENTS, SPHERICAL, innovation, measure
from rangeproc.models.motion import axes_blocks, ca_steps
from rangeproc.parallel import row_chunks, thread_map

#: Calibration slots of a sensor, in the order of the ``slots`` table (-1 = not estimated).
SLOTS = ("range", "azimuth", "elevation", "latency", "mount_roll", "mount_pitch", "mount_yaw")
N_SLOTS = len(SLOTS)
LATENCY_SLOT = 3
MOUNT_SLOT = 4
N_NODE = 9


@njit(cache=True, error_model="numpy")
def row_design(model: int, x: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
               Qdot: np.ndarray, moving: bool, dt: float, h: np.ndarray, H: np.ndarray,
               hrow: np.ndarray, arow: np.ndarray) -> None:
    """Design rows of one measurement row linearised at ``x`` (the track at the row's time).

    ``hrow`` (6, 9): sensitivity of each component to the node state ``dx_g`` at ``dt``
    (s) before the row (``H F(dt)``); ``arow`` (6, 7): sensitivity to the calibration slots
    (:data:`SLOTS`). ``Qdot`` (3, 3): rate of change of ``Qr`` (1/s), used when ``moving``
    (a platform sensor). Also fills ``h`` (6,) and ``H`` (6, n) (:func:`measure`).
    """
    measure(model, x, s, sv, Qr, h, H)
    h2 = 0.5 * dt * dt
    for c in range(N_COMPONENTS):
        for a in range(3):
            hp = H[c, a]
            hv = H[c, 3 + a]
            hrow[c, a] = hp
            hrow[c, 3 + a] = hp * dt + hv
            hrow[c, 6 + a] = hp * h2 + hv * dt
        for j in range(N_SLOTS):
            arow[c, j] = 0.0
    if model != SPHERICAL:
        return
    p0 = x[0] - s[0]
    p1 = x[1] - s[1]
    p2 = x[2] - s[2]
    d0 = Qr[0, 0] * p0 + Qr[0, 1] * p1 + Qr[0, 2] * p2       # d = Qr (p - s), sensor axes
    d1 = Qr[1, 0] * p0 + Qr[1, 1] * p1 + Qr[1, 2] * p2
    d2 = Qr[2, 0] * p0 + Qr[2, 1] * p1 + Qr[2, 2] * p2
    # deck axes (right, forward, up) -> body FRD: u = P d with P = [[0,1,0],[1,0,0],[0,0,-1]]
    u0, u1, u2 = d1, d0, -d2
    for c in range(3):                                          # range, azimuth, elevation
        arow[c, c] = 1.0
        # dh/dd = H_p Qr^T (Qr orthogonal)
        g0 = H[c, 0] * Qr[0, 0] + H[c, 1] * Qr[0, 1] + H[c, 2] * Qr[0, 2]
        g1 = H[c, 0] * Qr[1, 0] + H[c, 1] * Qr[1, 1] + H[c, 2] * Qr[1, 2]
        g2 = H[c, 0] * Qr[2, 0] + H[c, 1] * Qr[2, 1] + H[c, 2] * Qr[2, 2]
        rate = 0.0
        for a in range(3):
            rate += H[c, a] * (x[3 + a] - sv[a]) + H[c, 3 + a] * x[6 + a]
        if moving:
            # the sensor axes turn with the platform: d' = Qdot (p - s) + Qr (v - sv)
            q0 = Qdot[0, 0] * p0 + Qdot[0, 1] * p1 + Qdot[0, 2] * p2
            q1 = Qdot[1, 0] * p0 + Qdot[1, 1] * p1 + Qdot[1, 2] * p2
            q2 = Qdot[2, 0] * p0 + Qdot[2, 1] * p1 + Qdot[2, 2] * p2
            rate += g0 * q0 + g1 * q1 + g2 * q2
            # mount: dh/dtheta = (P g) x u  (see module docstring)
            w0, w1, w2 = g1, g0, -g2
            arow[c, MOUNT_SLOT] = w1 * u2 - w2 * u1
            arow[c, MOUNT_SLOT + 1] = w2 * u0 - w0 * u2
            arow[c, MOUNT_SLOT + 2] = w0 * u1 - w1 * u0
        arow[c, LATENCY_SLOT] = -rate
    # range rate: no bias slot; it does not turn with the axes; its rate is the range
    # acceleration seen from the (unaccelerated) sensor
    rate = 0.0
    for a in range(3):
        rate += H[3, a] * (x[3 + a] - sv[a]) + H[3, 3 + a] * x[6 + a]
    arow[3, LATENCY_SLOT] = -rate


#: Row chunks of :func:`normal_equations` (fixed, so that its sums' rounding does not depend
#: on the machine's core count).
NORMAL_CHUNKS = 2


def normal_equations(meas_epoch: np.ndarray, node: np.ndarray, node_t: np.ndarray,
                     t: np.ndarray, model: np.ndarray, z: np.ndarray, weight: np.ndarray,
                     s: np.ndarray, sv: np.ndarray, Qr: np.ndarray, moving_row: np.ndarray,
                     Qdot: np.ndarray, sensor: np.ndarray, slots: np.ndarray,
                     xs: np.ndarray, n_par: int, *, residuals: bool = True
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                np.ndarray | None]:
    """Accumulate the measurement part of the normal equations.

    Args:
        meas_epoch: (N,) epoch of each row in ``xs`` (E, n >= 9), the linearisation track;
        node: (N,) node of each row, ``node_t`` (G,) node times (s), ``t`` (N,) row times;
        model, z, s, sv, Qr, sensor: the batch arrays; weight: (N, 6) 1/sigma^2 per
        component (0 = left out); moving_row: (N,) index into ``Qdot`` (M, 3, 3) or -1;
        slots: (n_sensors, 7) global index of each calibration slot or -1.

    Returns:
        Nxx (G, 9, 9), Nxc (G, 9, p), Ncc (p, p), bx (G, 9), bc (p,), and the pre-fit
        residuals ``r`` (N, 6) (NaN where not measured; None with ``residuals=False``,
        which neither allocates nor writes them).

    Long inputs are summed in :data:`NORMAL_CHUNKS` row chunks side by side.
    """
    r = np.full((t.shape[0] if residuals else 0, N_COMPONENTS), np.nan)
    parts = thread_map(lambda k: _normal_rows(
        meas_epoch[k], node[k], node_t, t[k], model[k], z[k], weight[k], s[k], sv[k], Qr[k],
        moving_row[k], Qdot, sensor[k], slots, xs, n_par, r[k] if residuals else r),
        row_chunks(t.shape[0], NORMAL_CHUNKS))
    Nxx, Nxc, Ncc, bx, bc = parts[0]
    for more in parts[1:]:
        for total, part in zip((Nxx, Nxc, Ncc, bx, bc), more):
            total += part
    return Nxx, Nxc, Ncc, bx, bc, r if residuals else None


@njit(cache=True, nogil=True, error_model="numpy")
def _normal_rows(meas_epoch: np.ndarray, node: np.ndarray, node_t: np.ndarray,
                 t: np.ndarray, model: np.ndarray, z: np.ndarray, weight: np.ndarray,
                 s: np.ndarray, sv: np.ndarray, Qr: np.ndarray, moving_row: np.ndarray,
                 Qdot: np.ndarray, sensor: np.ndarray, slots: np.ndarray,
                 xs: np.ndarray, n_par: int, r: np.ndarray):
    """:func:`normal_equations` of the given rows: its sums, the residuals written into ``r``
    (N, 6; NaN-filled by the caller), or not at all when ``r`` has no rows."""
    G = node_t.shape[0]
    N = t.shape[0]
    Nxx = np.zeros((G, N_NODE, N_NODE))
    Nxc = np.zeros((G, N_NODE, n_par))
    Ncc = np.zeros((n_par, n_par))
    bx = np.zeros((G, N_NODE))
    bc = np.zeros(n_par)
    keep_r = r.shape[0] > 0
    h = np.empty(N_COMPONENTS)
    H = np.empty((N_COMPONENTS, xs.shape[1]))
    y = np.empty(N_COMPONENTS)
    hrow = np.empty((N_COMPONENTS, N_NODE))
    arow = np.empty((N_COMPONENTS, N_SLOTS))
    idx = np.empty(N_SLOTS, dtype=np.int64)
    val = np.empty(N_SLOTS)
    for i in range(N):
        g = node[i]
        mv = moving_row[i]
        row_design(model[i], xs[meas_epoch[i]], s[i], sv[i], Qr[i], Qdot[max(mv, 0)],
                   mv >= 0, t[i] - node_t[g], h, H, hrow, arow)
        innovation(model[i], z[i], h, y)
        for c in range(N_COMPONENTS):
            if np.isnan(y[c]):
                continue
            if keep_r:
                r[i, c] = y[c]
            w = weight[i, c]
            if not w > 0.0:
                continue
            m = 0
            for j in range(N_SLOTS):
                k = slots[sensor[i], j]
                if k >= 0 and arow[c, j] != 0.0:
                    idx[m] = k
                    val[m] = arow[c, j]
                    m += 1
            wr = w * y[c]
            for a in range(N_NODE):
                wa = w * hrow[c, a]
                bx[g, a] += wa * y[c]
                for b in range(a + 1):
                    Nxx[g, a, b] += wa * hrow[c, b]
                for q in range(m):
                    Nxc[g, a, idx[q]] += wa * val[q]
            for q in range(m):
                bc[idx[q]] += val[q] * wr
                for q2 in range(m):
                    Ncc[idx[q], idx[q2]] += w * val[q] * val[q2]
    for g in range(G):
        for a in range(N_NODE):
            for b in range(a):
                Nxx[g, b, a] = Nxx[g, a, b]
    return Nxx, Nxc, Ncc, bx, bc


def postfit(meas_epoch: np.ndarray, node: np.ndarray, node_t: np.ndarray, t: np.ndarray,
            model: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
            moving_row: np.ndarray, Qdot: np.ndarray, sensor: np.ndarray, slots: np.ndarray,
            xs: np.ndarray, r: np.ndarray, dx: np.ndarray, c: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Post-fit residuals ``r - h F dx_g - a c`` (N, 6) and, per row, the rate of each
    component ``dh/dt`` (N, 4) at the linearisation track (for the latency correction).

    Arguments as :func:`normal_equations`; ``r`` (N, 6) its pre-fit residuals, ``dx`` (G, 9)
    and ``c`` (p,) the solution. Rows are independent: long inputs are computed in row
    chunks side by side, with the same values.
    """
    N = t.shape[0]
    out = np.full((N, N_COMPONENTS), np.nan)
    rate = np.zeros((N, 4))
    thread_map(lambda k: _postfit_rows(
        meas_epoch[k], node[k], node_t, t[k], model[k], s[k], sv[k], Qr[k], moving_row[k],
        Qdot, sensor[k], slots, xs, r[k], dx, c, out[k], rate[k]), row_chunks(N))
    return out, rate


@njit(cache=True, nogil=True, error_model="numpy")
def _postfit_rows(meas_epoch: np.ndarray, node: np.ndarray, node_t: np.ndarray, t: np.ndarray,
                  model: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                  moving_row: np.ndarray, Qdot: np.ndarray, sensor: np.ndarray,
                  slots: np.ndarray, xs: np.ndarray, r: np.ndarray, dx: np.ndarray,
                  c: np.ndarray, out: np.ndarray, rate: np.ndarray) -> None:
    """:func:`postfit` of the given rows into ``out`` (N, 6; NaN-filled by the caller) and
    ``rate`` (N, 4; zeros)."""
    N = t.shape[0]
    h = np.empty(N_COMPONENTS)
    H = np.empty((N_COMPONENTS, xs.shape[1]))
    hrow = np.empty((N_COMPONENTS, N_NODE))
    arow = np.empty((N_COMPONENTS, N_SLOTS))
    for i in range(N):
        g = node[i]
        mv = moving_row[i]
        row_design(model[i], xs[meas_epoch[i]], s[i], sv[i], Qr[i], Qdot[max(mv, 0)],
                   mv >= 0, t[i] - node_t[g], h, H, hrow, arow)
        for k in range(4):
            rate[i, k] = -arow[k, LATENCY_SLOT]
        for k in range(N_COMPONENTS):
            if np.isnan(r[i, k]):
                continue
            acc = r[i, k]
            for a in range(N_NODE):
                acc -= hrow[k, a] * dx[g, a]
            for j in range(N_SLOTS):
                q = slots[sensor[i], j]
                if q >= 0:
                    acc -= arow[k, j] * c[q]
            out[i, k] = acc


def process_blocks(node_t: np.ndarray, q: np.ndarray, x_node: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Normal-equation terms of the process rows between consecutive nodes.

    ``node_t`` (G,) s, ``q`` (G-1,) white-jerk PSD (m^2/s^5) of each step, ``x_node`` (G, 9)
    the linearisation track at the nodes. Returns the additions to the diagonal blocks
    (G, 9, 9), the super-diagonal blocks ``N[g, g+1]`` (G-1, 9, 9) and the right-hand side
    (G, 9).
    """
    G = len(node_t)
    diag = np.zeros((G, N_NODE, N_NODE))
    rhs = np.zeros((G, N_NODE))
    if G < 2:
        return diag, np.zeros((0, N_NODE, N_NODE)), rhs
    F1, Q1 = ca_steps(np.diff(node_t), q)
    Qi = np.linalg.inv(Q1)
    F, W = axes_blocks(F1), axes_blocks(Qi)
    FtW = np.einsum("gji,gjk->gik", F, W)                     # F^T Q^-1
    diag[:-1] += np.einsum("gij,gjk->gik", FtW, F)
    diag[1:] += W
    upper = -FtW                                                 # N[g, g+1]
    e = x_node[1:] - np.einsum("gij,gj->gi", F, x_node[:-1])
    rhs[:-1] += np.einsum("gij,gj->gi", FtW, e)
    rhs[1:] -= np.einsum("gij,gj->gi", W, e)
    return diag, upper, rhs


def banded_lower(diag: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Lower banded storage (18, 9G) of the symmetric block-tridiagonal matrix with diagonal
    blocks ``diag`` (G, 9, 9) and super-diagonal blocks ``upper`` (G-1, 9, 9)
    (``ab[i - j, j] = N[i, j]``, scipy's ``cholesky_banded(lower=True)`` layout)."""
    G = diag.shape[0]
    ab = np.zeros((2 * N_NODE, N_NODE * G))
    r, c = np.tril_indices(N_NODE)
    cols = (N_NODE * np.arange(G))[:, None] + c[None, :]
    ab[(r - c)[None, :].repeat(G, 0), cols] = diag[:, r, c]
    if G > 1:
        rr, cc = np.meshgrid(np.arange(N_NODE), np.arange(N_NODE), indexing="ij")
        rr, cc = rr.ravel(), cc.ravel()                 # lower block N[g+1, g][rr, cc]
        cols = (N_NODE * np.arange(G - 1))[:, None] + cc[None, :]
        ab[(N_NODE + rr - cc)[None, :].repeat(G - 1, 0), cols] = upper[:, cc, rr]
    return ab


def solve_joint(node_diag: np.ndarray, node_upper: np.ndarray, Nxc: np.ndarray,
                Ncc: np.ndarray, bx: np.ndarray, bc: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Factor the node part and form the Schur complement of the calibration border.

    Args: the normal equations ``[[Nxx, Nxc], [Nxc^T, Ncc]] [dx; c] = [bx; bc]`` with ``Nxx``
    block tridiagonal (``node_diag`` (G, 9, 9), ``node_upper`` (G-1, 9, 9)), ``Nxc``
    (G, 9, p), ``Ncc`` (p, p), ``bx`` (G, 9), ``bc`` (p,).

    Returns ``(S, s, Xc, xb)``: the Schur complement ``S = Ncc - Nxc^T Nxx^-1 Nxc`` (p, p)
    (the information of ``c`` with the trajectory free) and ``s = bc - Nxc^T Nxx^-1 bx``, so
    that ``c = S^-1 s`` for any subset of ``c`` (taking the sub-blocks: the other terms fixed
    at zero); ``Xc = Nxx^-1 Nxc`` (G, 9, p) and ``xb = Nxx^-1 bx`` (G, 9), so that
    ``dx = xb - Xc c``.

    Raises:
        numpy.linalg.LinAlgError: the node part is singular (no data fix the trajectory).
    """
    G, p = Nxc.shape[0], Nxc.shape[2]
    cb = cholesky_banded(banded_lower(node_diag, node_upper), lower=True)
    rhs = np.concatenate([Nxc.reshape(G * N_NODE, p), bx.reshape(G * N_NODE, 1)], axis=1)
    sol = cho_solve_banded((cb, True), rhs)
    Xc = sol[:, :p].reshape(G, N_NODE, p)
    xb = sol[:, p].reshape(G, N_NODE)
    flat = Nxc.reshape(G * N_NODE, p)
    S = Ncc - flat.T @ sol[:, :p]
    s = bc - flat.T @ sol[:, p]
    return 0.5 * (S + S.T), s, Xc, xb
