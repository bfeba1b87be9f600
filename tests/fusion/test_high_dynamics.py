"""Dynamics the simulator never produces: a boosting, dog-legging missile seen by one radar.

The adaptive process noise (likelihood start, local EM) must keep the fused track honest:
errors inside the 3-sigma envelope through a 15 g boost and a 10 g lateral manoeuvre.
"""
import numpy as np

from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_target
from rangeproc.models.measurement import SPHERICAL


def _missile(dt=1e-3, duration=60.0):
    t = np.arange(0.0, duration, dt)
    acc = np.zeros((len(t), 3))
    ramp = np.clip(t / 0.5, 0, 1) * np.clip((8.0 - t) / 0.5, 0, 1)        # boost 0-8 s
    acc[:, 0] += 100.0 * ramp
    acc[:, 2] += 110.0 * ramp
    acc[:, 2] -= 9.81
    turn = np.clip((t - 30.0) / 0.5, 0, 1) * np.clip((35.0 - t) / 0.5, 0, 1)  # 10 g dog-leg
    acc[:, 1] += 98.0 * turn
    vel = np.array([50.0, 0.0, 30.0]) + np.cumsum(acc, axis=0) * dt
    pos = np.array([-5e3, -5e3, 100.0]) + np.cumsum(vel, axis=0) * dt
    return t, pos, vel


def _radar_rows(rng, t, pos, vel, rate=20.0):
    k = np.arange(0, len(t), int(round(1.0 / (rate * (t[1] - t[0])))))
    n = len(k)
    site = np.array([10e3, 0.0, 50.0])
    d = pos[k] - site
    r = np.linalg.norm(d, axis=1)
    sig = np.array([5.0, 3e-4, 3e-4])
    a = empty_rows(n, SPHERICAL)
    a["z"][:, 0] = r + sig[0] * rng.standard_normal(n)
    a["z"][:, 1] = np.arctan2(d[:, 0], d[:, 1]) + sig[1] * rng.standard_normal(n)
    a["z"][:, 2] = np.arcsin(d[:, 2] / r) + sig[2] * rng.standard_normal(n)
    a["sigma"][:, :3] = sig
    a["s"][:] = site
    rows = SensorRows(t=t[k], source_row=np.arange(n), station=np.full(n, -1),
                      track=np.full(n, -1), **a)
    return merge([(0, rows)], ("R1",)), k


def test_boost_and_dogleg_stay_inside_three_sigma():
    rng = np.random.default_rng(12)
    t, pos, vel = _missile()
    batch, _ = _radar_rows(rng, t, pos, vel)
    res = fuse_target(batch, 10.0)
    g = res.grid
    te = res.epoch_t[g]
    truth = np.column_stack([np.interp(te, t, pos[:, i]) for i in range(3)])
    err = res.xs[g, :3] - truth
    n = res.xs.shape[1]
    sig = np.empty((g.sum(), 3))
    from rangeproc.estimation.linalg import unpack_many
    P = unpack_many(res.Ps[g], n)
    sig[:] = np.sqrt(np.diagonal(P, axis1=1, axis2=2)[:, :3])
    inside = (np.abs(err) <= 3 * sig).mean(axis=0)
    assert inside.min() > 0.9, inside
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 15.0
    # the process noise adapted: far larger during the boost than in the ballistic coast
    q_boost = np.median(res.q[(res.epoch_t > 1) & (res.epoch_t < 7)])
    q_coast = np.median(res.q[(res.epoch_t > 15) & (res.epoch_t < 25)])
    assert q_boost > 5 * q_coast
