"""optinav.core.distributions (scipy.special identities) against scipy.stats (test-only oracle)."""

import numpy as np
import pytest
from scipy import stats

from optinav.core import distributions as dist


@pytest.mark.parametrize("df", [1, 2, 3.5, 9, 40, 1000])
def test_chi2_quantiles_and_probabilities_are_scipy_stats(df):
    q = np.array([1e-9, 1e-4, 0.005, 0.16, 0.5, 0.84, 0.99, 0.999, 1 - 1e-7])
    np.testing.assert_allclose(dist.chi2_ppf(q, df), stats.chi2.ppf(q, df), rtol=1e-10)
    x = stats.chi2.ppf(q, df)
    np.testing.assert_allclose(dist.chi2_cdf(x, df), stats.chi2.cdf(x, df), rtol=1e-10, atol=1e-300)
    np.testing.assert_allclose(dist.chi2_ppf(0.99, np.array([1, 5, df])), stats.chi2.ppf(0.99, [1, 5, df]), rtol=1e-10)


@pytest.mark.parametrize("df", [1, 2, 5, 7, 30, 1e4])
def test_student_t_critical_values_are_scipy_stats(df):
    p = np.array([1e-9, 2.8e-6, 1e-3, 0.025, 0.3, 0.5, 0.9])
    np.testing.assert_allclose(dist.t_isf(p, df), stats.t.isf(p, df), rtol=1e-9, atol=1e-12)


def test_normal_quantiles_are_scipy_stats():
    q = np.array([1e-12, 0.025, 0.5, 0.8413447460685429, 0.975])
    np.testing.assert_allclose(dist.norm_ppf(q), stats.norm.ppf(q), rtol=1e-12, atol=1e-15)
    assert dist.norm_ppf(0.8413447460685429) == pytest.approx(1.0, rel=1e-12)
