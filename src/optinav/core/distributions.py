"""Quantiles and tails of the χ², Student t and normal distributions, from :mod:`scipy.special`.

The tests of the fits (χ² gates, outliers, confidence bands) need a handful of these numbers; :mod:`scipy.stats`
builds every distribution class on import (about 2.6 s on the test machine, longer than a calibration runs),
:mod:`scipy.special` loads in a sixth of that. Each function is the textbook identity with the regularized
incomplete gamma function or the Student / normal quantile functions of the Cephes library (the same ones
scipy.stats evaluates); tests/test_distributions.py compares them with scipy.stats.
"""

from __future__ import annotations

import numpy as np


def chi2_ppf(q, df):
    """Quantile of the χ² distribution: ``P(X ≤ x) = q`` for ``df`` degrees of freedom, ``x = 2·P⁻¹(df/2, q)``.

    Parameters
    ----------
    q : float or array
        Probability [-], 0 … 1.
    df : float or array
        Degrees of freedom [-], > 0.

    Returns
    -------
    float or ndarray
        The quantile [-].
    """
    from scipy.special import gammaincinv

    return 2.0 * gammaincinv(0.5 * np.asarray(df, float), q)


def chi2_cdf(x, df):
    """Cumulative probability of the χ² distribution, ``P(df/2, x/2)`` (regularized lower incomplete gamma).

    Parameters
    ----------
    x : float or array
        Value [-], ≥ 0.
    df : float or array
        Degrees of freedom [-], > 0.

    Returns
    -------
    float or ndarray
        ``P(X ≤ x)`` [-].
    """
    from scipy.special import gammainc

    return gammainc(0.5 * np.asarray(df, float), 0.5 * np.asarray(x, float))


def t_isf(p, df):
    """Inverse survival function of Student's t: ``P(T > x) = p`` for ``df`` degrees of freedom.

    Parameters
    ----------
    p : float or array
        Upper-tail probability [-], 0 … 1.
    df : float or array
        Degrees of freedom [-], > 0.

    Returns
    -------
    float or ndarray
        The critical value ``x`` [-].
    """
    from scipy.special import stdtrit

    return -stdtrit(np.asarray(df, float), p)  # the t distribution is symmetric: isf(p) = −ppf(p)


def norm_ppf(q):
    """Quantile of the standard normal distribution.

    Parameters
    ----------
    q : float or array
        Probability [-], 0 … 1.

    Returns
    -------
    float or ndarray
        The quantile [-].
    """
    from scipy.special import ndtri

    return ndtri(q)
