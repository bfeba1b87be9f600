"""The compiled rotation kernels against scipy.spatial.transform (the oracle): Euler angles
to matrices, rotation vectors between samples (tiny, ordinary and near-pi turns) and slerp."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from rangeproc.frames.rotation_kernels import euler_matrices, relative_rotvecs, slerp_matrices


def test_euler_matrices_are_scipys_intrinsic_zyx():
    rng = np.random.default_rng(1)
    r, p, y = rng.uniform(-np.pi, np.pi, 500), rng.uniform(-1.5, 1.5, 500), \
        rng.uniform(-np.pi, np.pi, 500)
    np.testing.assert_allclose(euler_matrices(r, p, y),
                               Rotation.from_euler("ZYX", np.column_stack([y, p, r])).as_matrix(),
                               atol=1e-15)


def _turns(rng: np.random.Generator) -> np.ndarray:
    """(K, 3, 3) a series whose consecutive turns span 1e-12 rad to just under pi."""
    angles = np.concatenate([[0.0, 1e-12, 1e-8, 1e-5, 9e-5, 1.1e-4, 1e-3, 0.1, 1.0, 3.0,
                              np.pi - 1e-6, np.pi - 1e-9], rng.uniform(0.0, np.pi, 200)])
    axes = rng.normal(size=(angles.size, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    steps = Rotation.from_rotvec(axes * angles[:, None])
    out = [Rotation.from_rotvec(rng.normal(size=3))]
    for s in steps:
        out.append(out[-1] * s)
    return Rotation.concatenate(out).as_matrix(), axes * angles[:, None]


def test_relative_rotvecs_recover_each_turn():
    rng = np.random.default_rng(2)
    M, turns = _turns(rng)
    d = relative_rotvecs(M)
    ref = (Rotation.from_matrix(M[:-1]).inv() * Rotation.from_matrix(M[1:])).as_rotvec()
    np.testing.assert_allclose(d, turns, atol=2e-7)       # near pi: the sign of the axis
    near_pi = np.linalg.norm(turns, axis=1) > np.pi - 1e-5  # is ill-posed; elsewhere exact
    np.testing.assert_allclose(d[~near_pi], turns[~near_pi], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(d[~near_pi], ref[~near_pi], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), np.linalg.norm(turns, axis=1),
                               rtol=1e-9, atol=1e-15)


def test_slerp_matrices_are_scipys_slerp():
    rng = np.random.default_rng(3)
    M, _ = _turns(rng)
    t = np.cumsum(rng.uniform(0.01, 0.02, len(M)))
    keep = np.linalg.norm(relative_rotvecs(M), axis=1) < np.pi - 1e-5   # scipy's ambiguity
    tq = np.sort(rng.uniform(t[0], t[-1], 3000))
    k = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
    frac = (tq - t[k]) / (t[k + 1] - t[k])
    ours = slerp_matrices(M, relative_rotvecs(M), k, frac)
    ref = Slerp(t, Rotation.from_matrix(M))(tq).as_matrix()
    ok = keep[k]
    np.testing.assert_allclose(ours[ok], ref[ok], atol=1e-12)
    np.testing.assert_allclose(ours @ np.swapaxes(ours, 1, 2), np.broadcast_to(np.eye(3),
                               ours.shape), atol=1e-12)            # rotations, every one
    np.testing.assert_allclose(slerp_matrices(M, relative_rotvecs(M), np.arange(len(M) - 1),
                                              np.ones(len(M) - 1)), M[1:], atol=1e-12)
