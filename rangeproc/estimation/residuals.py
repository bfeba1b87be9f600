"""Post-fit residuals of every measurement row against smoothed states (compiled)."""
from __future__ import annotations

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import N_OBSERVED
from rangeproc.estimation.linalg import unpack
from rangeproc.models.measurement import N_COMPONENTS, innovation, measure
from rangeproc.parallel import row_chunks, thread_map


def smoothed_residuals(meas_epoch: np.ndarray, model: np.ndarray, z: np.ndarray,
                       s: np.ndarray, sv: np.ndarray, Qr: np.ndarray, xs: np.ndarray,
                       Ps: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Residuals ``z - h(x_s)`` and the variance of ``h`` explained by the state.

    Args:
        meas_epoch: (N,) epoch index per row; model, z, s, sv, Qr: the batch arrays;
        xs: (E, n) smoothed states; Ps: (E, n(n+1)/2) packed smoothed covariances, or None
        for the residuals alone (the covariances are then not read: a caller may have let
        them go).

    Returns:
        res (N, 6): residuals (azimuth wrapped, NaN where not measured);
        hph (N, 6): diag(H P_s H^T), the part of the residual variance removed by the fit
        (E[res^2] = sigma^2 - hph for a consistent smoother); None when ``Ps`` is None.
        ``res`` does not depend on ``Ps``: the same values either way.

    Rows are independent: long inputs are computed in row chunks side by side
    (``rangeproc.parallel.row_chunks``), with the same values.
    """
    N = meas_epoch.shape[0]
    explain = Ps is not None
    # every entry written by the kernel (NaN where not measured), in the row chunks' threads;
    # without Ps, hph has no rows and the kernel neither reads Ps nor writes hph
    res = np.empty((N, N_COMPONENTS))
    hph = np.empty((N if explain else 0, N_COMPONENTS))
    cov = Ps if explain else np.empty((0, 0))
    thread_map(lambda r: _residuals_into(meas_epoch[r], model[r], z[r], s[r], sv[r], Qr[r],
                                         xs, cov, res[r], hph[r] if explain else hph),
               row_chunks(N))
    return res, (hph if explain else None)


@njit(cache=True, nogil=True, error_model="numpy")
def _residuals_into(meas_epoch: np.ndarray, model: np.ndarray, z: np.ndarray,
                    s: np.ndarray, sv: np.ndarray, Qr: np.ndarray, xs: np.ndarray,
                    Ps: np.ndarray, res: np.ndarray, hph: np.ndarray) -> None:
    """:func:`smoothed_residuals` of the given rows, written into ``res`` and ``hph`` (N, 6)
    (NaN where not measured); ``hph`` with no rows: the residuals alone (``Ps`` not read)."""
    N = meas_epoch.shape[0]
    n = xs.shape[1]
    explain = hph.shape[0] > 0
    h = np.empty(N_COMPONENTS)
    H = np.empty((N_COMPONENTS, n))
    P = np.empty((n, n))
    y = np.empty(N_COMPONENTS)
    last = -1
    for i in range(N):
        k = meas_epoch[i]
        if explain and k != last:
            unpack(Ps[k], P)
            last = k
        measure(model[i], xs[k], s[i], sv[i], Qr[i], h, H)
        innovation(model[i], z[i], h, y)
        for c in range(N_COMPONENTS):
            if not np.isnan(y[c]):
                res[i, c] = y[c]
                if explain:
                    acc = 0.0                          # (H P H^T)_cc, H sparse
                    for a in range(N_OBSERVED):
                        ha = H[c, a]
                        if ha != 0.0:
                            for b in range(N_OBSERVED):
                                acc += ha * P[a, b] * H[c, b]
                    hph[i, c] = acc
            else:
                res[i, c] = np.nan
                if explain:
                    hph[i, c] = np.nan
