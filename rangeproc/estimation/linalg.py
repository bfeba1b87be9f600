"""Small dense linear algebra for the compiled recursions (numba, no Python objects).

Covariances are stored packed (lower triangle, row-major: P[0,0], P[1,0], P[1,1], P[2,0], ...)
so that a stored history of ``E`` epochs needs ``E * n (n + 1) / 2`` doubles.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit



@njit(cache=True, error_model="numpy")
def pack(P: np.ndarray, out: np.ndarray) -> None:
    """Store the lower triangle of symmetric ``P`` (n, n) into ``out`` (n(n+1)/2,)."""
    pack_n(P, out, P.shape[0])


@njit(cache=True, error_model="numpy", inline="always")
def pack_n(P: np.ndarray, out: np.ndarray, n: int) -> None:
    """:func:`pack` of the leading (n, n) block, inlined (a compile-time ``n`` in the
    caller fixes the loops' size)."""
    k = 0
    for i in range(n):
        for j in range(i + 1):
            out[k] = 0.5 * (P[i, j] + P[j, i])
            k += 1


@njit(cache=True, error_model="numpy")
def unpack(p: np.ndarray, out: np.ndarray) -> None:
    """Inverse of :func:`pack`: fill the full symmetric ``out`` (n, n)."""
    unpack_n(p, out, out.shape[0])


@njit(cache=True, error_model="numpy", inline="always")
def unpack_n(p: np.ndarray, out: np.ndarray, n: int) -> None:
    """:func:`unpack` into the leading (n, n) block, inlined (a compile-time ``n`` in the
    caller fixes the loops' size)."""
    k = 0
    for i in range(n):
        for j in range(i + 1):
            out[i, j] = p[k]
            out[j, i] = p[k]
            k += 1


def diagonal_entries(first: int, count: int) -> tuple[int, ...]:
    """The packed entries (:func:`pack`: diagonal ``i`` at ``i (i + 3) / 2``) of the
    variances ``P[i, i]``, ``i = first .. first + count - 1``."""
    return tuple(i * (i + 3) // 2 for i in range(first, first + count))


def packed_diagonal(Ps: np.ndarray, first: int, count: int) -> np.ndarray:
    """(K, count) the variances ``P[i, i]``, ``i = first .. first + count - 1``, of packed
    covariances ``Ps`` (K, n(n+1)/2) (:func:`diagonal_entries`)."""
    return np.asarray(Ps)[:, list(diagonal_entries(first, count))]


def unpack_many(Ps: np.ndarray, n: int, m: int | None = None) -> np.ndarray:
    """Unpack (K, n(n+1)/2) packed covariances (:func:`pack`'s row-by-row lower triangle)
    into their leading (K, m, m) blocks (m = n by default; the first m(m+1)/2 packed entries
    are that block). Compiled and without the GIL: a quick trajectory's 18,000 epochs took
    15 ms by numpy fancy indexing, which held the GIL the other threads' kernels wait for."""
    m = n if m is None else m
    lead = np.asarray(Ps, dtype=np.float64)[:, :m * (m + 1) // 2]
    return _unpack_rows(np.ascontiguousarray(lead), m)


@njit(cache=True, error_model="numpy", nogil=True)
def _unpack_rows(Ps: np.ndarray, m: int) -> np.ndarray:
    out = np.empty((Ps.shape[0], m, m))
    for r in range(Ps.shape[0]):
        unpack(Ps[r], out[r])
    return out


@njit(cache=True, error_model="numpy")
def cholesky_inplace(S: np.ndarray, m: int) -> bool:
    """Lower Cholesky factor of the leading (m, m) block of ``S``, in place. False if not PD."""
    for j in range(m):
        d = S[j, j]
        for k in range(j):
            d -= S[j, k] * S[j, k]
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        S[j, j] = d
        for i in range(j + 1, m):
            v = S[i, j]
            for k in range(j):
                v -= S[i, k] * S[j, k]
            S[i, j] = v / d
        for i in range(j):
            S[i, j] = 0.0
    return True


@njit(cache=True, error_model="numpy")
def chol_solve_inplace(L: np.ndarray, m: int, B: np.ndarray, ncols: int) -> None:
    """Solve ``(L L^T) X = B`` for the leading (m, ncols) block of ``B``, in place.

    Row-oriented so the innermost loop runs over contiguous columns of ``B``.
    """
    for i in range(m):                           # forward: L Y = B
        for k in range(i):
            lik = L[i, k]
            for c in range(ncols):
                B[i, c] -= lik * B[k, c]
        inv = 1.0 / L[i, i]
        for c in range(ncols):
            B[i, c] *= inv
    for i in range(m - 1, -1, -1):               # backward: L^T X = Y
        for k in range(i + 1, m):
            lki = L[k, i]
            for c in range(ncols):
                B[i, c] -= lki * B[k, c]
        inv = 1.0 / L[i, i]
        for c in range(ncols):
            B[i, c] *= inv
