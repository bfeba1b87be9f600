"""The IMM's structured nine-state covariance prediction (``imm_models.structured_covariance``,
taken by ``sparse_covariance`` when the model's code is given) gives the general sparse
product's bits for every model, turn rate and step, in place or not, and is F P F^T + Q."""
import numpy as np
import pytest

from rangeproc.estimation.imm_models import (
    CA,
    CT,
    CV,
    MAX_TURN_RATE,
    dense_predict,
    model_matrices,
    sparse_covariance,
)

#: turn rates: none, below the CT model's small-rate branch, ordinary, the bound, negative
RATES = (0.0, 1e-12, 0.03, MAX_TURN_RATE, -0.2)


def _case(code: int, w: float, dt: float, seed: int):
    F, Q = np.empty((9, 9)), np.empty((9, 9))
    model_matrices(code, dt, 2.5, w, F, Q)
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(9, 9)) * rng.uniform(0.1, 100.0, 9)
    return F, Q, A @ A.T + np.eye(9)


def _run(F, Q, P, code, in_place):
    T = np.empty((9, 9))
    if in_place:
        out = P.copy()
        sparse_covariance(F, Q, out, T, out, 9, code)
    else:
        out = np.empty((9, 9))
        sparse_covariance(F, Q, P, T, out, 9, code)
    return T, out


@pytest.mark.parametrize("code", [CV, CA, CT])
@pytest.mark.parametrize("in_place", [False, True])
def test_structured_product_is_the_sparse_product_bit_for_bit(code, in_place):
    for seed, (w, dt) in enumerate((w, dt) for w in RATES for dt in (0.0625, 0.013, 1.7)):
        F, Q, P = _case(code, w, dt, seed)
        T0, P0 = _run(F, Q, P, -1, in_place)                # general: tests every entry
        T1, P1 = _run(F, Q, P, code, in_place)              # structured
        assert np.array_equal(T0, T1) and np.array_equal(P0, P1), (code, w, dt)
        ref = F @ P @ F.T + Q                                # and it is the maths
        assert np.allclose(P1, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
        assert np.array_equal(P1, P1.T)


def test_a_matrix_outside_the_declared_pattern_is_caught():
    """Negative control: a CT transition predicted as if it were CA misses the horizontal
    velocity coupling; the comparison above fails for it."""
    F, Q, P = _case(CT, 0.1, 0.0625, 3)
    _, general = _run(F, Q, P, -1, False)
    _, wrong = _run(F, Q, P, CA, False)
    assert not np.allclose(general, wrong, rtol=1e-6)


def test_the_called_prediction_keeps_the_general_path():
    """``dense_predict`` (no model code) runs the general product: the same bits."""
    F, Q, P = _case(CT, 0.05, 0.0625, 4)
    x = np.arange(9.0)
    xt, T = np.empty(9), np.empty((9, 9))
    P2 = P.copy()
    dense_predict(F, Q, x, P2, xt, T)
    _, ref = _run(F, Q, P, CT, False)
    assert np.array_equal(P2, ref)
