"""rangeproc.quantiles against scipy.stats (the oracle it replaces at start-up)."""
import numpy as np
from scipy import stats

from rangeproc.quantiles import chi2_ppf, norm_pdf, norm_ppf


def test_chi2_quantiles_equal_scipy_stats() -> None:
    p = np.array([1e-9, 0.025, 0.5, 0.975, 0.99, 1.0 - 1e-6, 1.0 - 1e-12])
    for dof in (1, 2, 3, 6, 7.5, 300, 3 * 17997):
        np.testing.assert_array_equal(chi2_ppf(p, dof), stats.chi2.ppf(p, dof))
    dofs = np.arange(1, 7)
    np.testing.assert_array_equal(chi2_ppf(0.9973, dofs), stats.chi2.ppf(0.9973, dofs))


def test_normal_quantile_and_density_equal_scipy_stats() -> None:
    p = np.array([1e-9, 0.01, 0.5, 0.95, 1.0 - 1e-9])
    np.testing.assert_array_equal(norm_ppf(p), stats.norm.ppf(p))
    x = np.linspace(-6.0, 6.0, 101)
    np.testing.assert_allclose(norm_pdf(x), stats.norm.pdf(x), rtol=1e-15, atol=0.0)
