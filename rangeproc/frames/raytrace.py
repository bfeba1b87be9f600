"""The compiled ray trace of ``frames.refraction``: rays through a spherically stratified
atmosphere (4/3-earth linear or exponential refractivity), integrated with Runge-Kutta steps
in blocks of rows so the stage loops vectorise. Model equations, units and sign conventions
are in ``frames.refraction``'s docstring; this module holds only the numerics.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Model code of the exponential atmosphere (0: the linear 4/3-earth profile).
EXPONENTIAL = 1
#: Ray-trace path scales ell after which the ray flies straight.
EXIT_SCALES = 40.0

_BLOCK = 128  # rows traced together: the stage loops over a block vectorise (SIMD)


@njit(cache=True, error_model="numpy")
def _exp(z: float) -> float:
    """``exp(z)`` for ``z`` in [-40, 40] (clamped), relative error < 2e-8, vectorisable.

    ``(Taylor_10(z / 64))^64``: libm's ``exp`` would keep the ray-trace loops scalar. The
    clamp only matters far above the atmosphere (``exp(-40)`` ~ 4e-18) or underground.
    """
    z = min(max(z, -40.0), 40.0)
    w = z * (1.0 / 64.0)
    p = 1.0 + w * (1.0 + w * (1.0 / 2.0 + w * (1.0 / 6.0 + w * (1.0 / 24.0 + w * (
        1.0 / 120.0 + w * (1.0 / 720.0 + w * (1.0 / 5040.0 + w * (1.0 / 40320.0 + w * (
            1.0 / 362880.0 + w * (1.0 / 3628800.0))))))))))
    p *= p
    p *= p
    p *= p
    p *= p
    p *= p
    return p * p


@njit(cache=True, nogil=True, error_model="numpy")
def trace_kernel(el: np.ndarray, rng: np.ndarray, r0s: np.ndarray, nss: np.ndarray,
                  pars: np.ndarray, kind: int, steps: int, out: np.ndarray) -> None:
    """Trace every row; ``out[:, k]`` = true elevation, true range, bending, end height,
    central angle.

    All inputs 1-D of one length: apparent elevation, electrical range, site radius, site
    refractivity, and ``pars`` the inverse scale height (1/m, exponential) or the index gradient
    magnitude (1/m, clipped linear). The state is the site-centred position (x horizontal, y up)
    and the unit tangent (u, v) of the ray; classical RK4 in the electrical path length ``L``
    with steps growing geometrically, ``L_k = ell (q^(k/steps) - 1)``, ``q = 1 + R / ell``.
    The system is autonomous in ``L`` and the steps sum exactly to ``R``, so a straight ray in
    vacuum is integrated without error. Rows are processed in blocks with one loop per RK stage.
    """
    n = el.shape[0]
    b = _BLOCK
    px = np.empty(b)
    py = np.empty(b)
    pu = np.empty(b)
    pv = np.empty(b)
    kx = np.zeros(b)   # stage slopes; zeros so that stage 1 (c = 0) never sees 0 * NaN
    ky = np.zeros(b)
    ku = np.zeros(b)
    kv = np.zeros(b)
    ax = np.empty(b)
    ay = np.empty(b)
    au = np.empty(b)
    av = np.empty(b)
    dls = np.empty(b)
    grow = np.empty(b)
    done = np.empty(b)
    lgeo = np.empty(b)
    r0b = np.empty(b)
    nsb = np.empty(b)
    parb = np.empty(b)
    for b0 in range(0, n, b):
        m = min(b, n - b0)
        for j in range(m):
            i = b0 + j
            e = el[i]
            r0 = r0s[i]
            nsm = nss[i] * 1.0e-6
            par = pars[i]
            # path length over which the index changes: a scale height (half the linear
            # layer), stretched by the Earth's curvature at low elevation
            scale = 1.0 / par if kind == EXPONENTIAL else max(0.5 * nsm / par, 1.0)
            s_e = math.sin(e)
            ell = scale / math.sqrt(s_e * s_e + 2.0 * scale / r0)
            # geometric steps up to EXIT_SCALES * ell at most, beyond which the air has ended
            # (40 scale heights up even for a grazing ray) and the ray runs straight
            lgeo[j] = min(max(rng[i], 0.0), EXIT_SCALES * ell)
            lnq = math.log1p(lgeo[j] / ell)
            grow[j] = math.exp(lnq / steps)
            dls[j] = ell * math.expm1(lnq / steps)    # first step; then x grow per step
            done[j] = 0.0
            px[j] = 0.0
            py[j] = 0.0
            pu[j] = math.cos(e)
            pv[j] = s_e
            r0b[j] = r0
            nsb[j] = nsm
            parb[j] = par
        for k in range(steps):
            if k == steps - 1:
                for j in range(m):
                    dls[j] = lgeo[j] - done[j]
            for stage in range(4):
                c = 0.0 if stage == 0 else (0.5 if stage < 3 else 1.0)
                wgt = 2.0 if stage == 1 or stage == 2 else 1.0
                for j in range(m):
                    d = c * dls[j]
                    x = px[j] + d * kx[j]
                    y = py[j] + d * ky[j]
                    tu = pu[j] + d * ku[j]
                    tv = pv[j] + d * kv[j]
                    r0 = r0b[j]
                    par = parb[j]
                    rho = r0 + y
                    r = math.sqrt(x * x + rho * rho)
                    h = r - r0                    # height above the site
                    if kind == EXPONENTIAL:
                        nm1 = nsb[j] * _exp(-h * par)
                        dn = -nm1 * par
                    else:
                        nm1 = max(nsb[j] - par * h, 0.0)
                        dn = -par if nm1 > 0.0 else 0.0
                    inv_n = 1.0 - nm1 * (1.0 - nm1 * (1.0 - nm1))   # 1/n to 1e-14
                    g = dn / r
                    gx = g * x
                    gy = g * rho
                    gt = gx * tu + gy * tv
                    inv_n2 = inv_n * inv_n
                    # dp/dL = t / n, dt/dL = (grad n - (grad n . t) t) / n^2
                    dx = tu * inv_n
                    dy = tv * inv_n
                    du = (gx - gt * tu) * inv_n2
                    dv = (gy - gt * tv) * inv_n2
                    kx[j] = dx
                    ky[j] = dy
                    ku[j] = du
                    kv[j] = dv
                    if stage == 0:
                        ax[j] = dx
                        ay[j] = dy
                        au[j] = du
                        av[j] = dv
                    else:
                        ax[j] += wgt * dx
                        ay[j] += wgt * dy
                        au[j] += wgt * du
                        av[j] += wgt * dv
            for j in range(m):
                w = dls[j] / 6.0
                px[j] += w * ax[j]
                py[j] += w * ay[j]
                pu[j] += w * au[j]
                pv[j] += w * av[j]
                done[j] += dls[j]
                dls[j] *= grow[j]
        for j in range(m):
            i = b0 + j
            rest = max(rng[i], 0.0) - lgeo[j]      # straight flight beyond the atmosphere
            tn = rest / math.sqrt(pu[j] * pu[j] + pv[j] * pv[j])
            x = px[j] + pu[j] * tn
            y = py[j] + pv[j] * tn
            rho = r0b[j] + y
            r = math.sqrt(x * x + rho * rho)
            big_l = rng[i]
            out[i, 0] = math.atan2(y, x) if big_l > 0.0 else el[i]
            out[i, 1] = math.sqrt(x * x + y * y)
            out[i, 2] = el[i] - math.atan2(pv[j], pu[j])
            out[i, 3] = (x * x + y * (2.0 * r0b[j] + y)) / (r + r0b[j])
            out[i, 4] = math.atan2(x, rho)
            if not big_l >= 0.0:              # negative or NaN range
                for c in range(5):
                    out[i, c] = np.nan
