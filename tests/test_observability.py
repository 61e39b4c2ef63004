"""Observability, covariance, CRLB, Monte Carlo and NEES checked against analytic truth.

Statistical tolerances are derived from the sampling distributions (stated at each test) with a
family-wise false-failure probability of about 1e-3 for an arbitrary seed; the seeds are fixed, so the
tests are deterministic.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from optinav.core.observability import (
    MonteCarloResult,
    ObservabilityReport,
    analyze,
    fisher_information,
    monte_carlo,
    nees,
    nees_test,
    observability_matrix,
    observability_svd,
)
from optinav.errors import OptinavError

ALPHA = 1e-3  # family-wise false-failure probability of each statistical test


def _regression(m=40, n=3, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(m, n)) + np.array([1.0, 0.0, 0.0])[:n]
    theta = np.array([1.0, -2.0, 0.5])[:n]
    return X, theta


def _unit_vec(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _same_direction(a, b, tol=1e-10):
    a, b = _unit_vec(a), _unit_vec(b)
    return min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < tol


# ---------------------------------------------------------------------------------------------------
# Fisher information and CRLB of the linear Gaussian model: exactly σ²(XᵀX)⁻¹ (Kay 1993, Thm 3.5)
# ---------------------------------------------------------------------------------------------------


def test_crlb_linear_regression_scalar_vector_and_full_noise():
    X, _ = _regression()
    m, n = X.shape
    sigma = 0.3
    rep = analyze(X, sigma=sigma, names=["a", "b", "c"])
    C = sigma**2 * np.linalg.inv(X.T @ X)
    assert rep.rank == n and rep.full_rank
    np.testing.assert_allclose(rep.crlb, C, rtol=1e-10, atol=0)
    np.testing.assert_allclose(rep.covariance, C, rtol=1e-10, atol=0)
    np.testing.assert_allclose(rep.crlb_std, np.sqrt(np.diag(C)), rtol=1e-10)
    np.testing.assert_allclose(rep.fisher, X.T @ X / sigma**2, rtol=1e-12)
    np.testing.assert_allclose(rep.correlation, C / np.sqrt(np.outer(np.diag(C), np.diag(C))), atol=1e-10)
    assert rep.statements == ["all parameters individually observable"]

    s = np.linspace(0.1, 1.0, m)
    np.testing.assert_allclose(analyze(X, sigma=s).crlb, np.linalg.inv(X.T @ (X / s[:, None] ** 2)), rtol=1e-9)
    np.testing.assert_allclose(fisher_information(X, s), X.T @ (X / s[:, None] ** 2), rtol=1e-12)

    rng = np.random.default_rng(3)
    B = rng.normal(size=(m, m))
    R = B @ B.T + m * np.eye(m)
    Ri = np.linalg.inv(R)
    np.testing.assert_allclose(fisher_information(X, R=R), X.T @ Ri @ X, rtol=1e-9)
    np.testing.assert_allclose(analyze(X, R=R).crlb, np.linalg.inv(X.T @ Ri @ X), rtol=1e-8)


def test_a_posteriori_variance_factor():
    # Textbook OLS: σ̂² = RSS/(m−n), cov = σ̂²(XᵀX)⁻¹ whatever sigma was supplied.
    X, theta = _regression(m=400)
    m, n = X.shape
    rng = np.random.default_rng(11)
    sigma = 0.25
    y = X @ theta + sigma * rng.normal(size=m)
    th, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ th
    rss = float(r @ r)
    rep = analyze(X, sigma=7.0, residuals=r, estimate_sigma=True)
    np.testing.assert_allclose(rep.covariance, rss / (m - n) * np.linalg.inv(X.T @ X), rtol=1e-9)
    np.testing.assert_allclose(rep.crlb, 49.0 * np.linalg.inv(X.T @ X), rtol=1e-9)  # a-priori σ kept
    assert rep.dof == m - n
    # with the right σ the factor satisfies (m−n)·vf ~ χ²(m−n)
    vf = analyze(X, sigma=sigma, residuals=r).variance_factor
    k = m - n
    assert stats.chi2.ppf(ALPHA / 2, k) / k < vf < stats.chi2.ppf(1 - ALPHA / 2, k) / k


# ---------------------------------------------------------------------------------------------------
# Monte Carlo against the CRLB
# ---------------------------------------------------------------------------------------------------


def _mc_setup(sigma=0.5, lam=20.0):
    X, theta = _regression(m=30)
    n = X.shape[1]
    XtX = X.T @ X
    C = sigma**2 * np.linalg.inv(XtX)
    A = np.linalg.inv(XtX + lam * np.eye(n))

    def make_data(rng):
        return X @ theta + sigma * rng.normal(size=X.shape[0])

    def ols(y):
        return np.linalg.solve(XtX, X.T @ y)

    def ridge(y):
        return A @ (X.T @ y)

    return X, theta, C, A, XtX, make_data, ols, ridge


def test_monte_carlo_ols_efficient_and_ridge_biased():
    sigma, lam = 0.5, 20.0
    X, theta, C, A, XtX, make_data, ols, ridge = _mc_setup(sigma, lam)
    n = theta.size
    N = 400
    rep = analyze(X, sigma=sigma, names=["a", "b", "c"])
    mc = monte_carlo(make_data, {"ols": ols, "ridge": ridge}, theta, N, rng=42, crlb=rep)
    assert mc.names == ["a", "b", "c"]
    assert mc.n_failures == {"ols": 0, "ridge": 0}
    a = ALPHA / (4 * n)  # Bonferroni over 4 checks × n parameters

    # OLS errors ~ N(0, C) exactly → N·RMSE_i²/C_ii ~ χ²(N), mean_i ~ N(0, C_ii/N)
    lo, hi = np.sqrt(stats.chi2.ppf([a / 2, 1 - a / 2], N) / N)
    assert np.all((mc.rmse_over_crlb["ols"] > lo) & (mc.rmse_over_crlb["ols"] < hi))
    np.testing.assert_allclose(mc.rmse_over_crlb["ols"], mc.rmse["ols"] / np.sqrt(np.diag(C)), rtol=1e-9)
    z = stats.norm.ppf(1 - a / 2)
    assert np.all(np.abs(mc.bias["ols"]) < z * np.sqrt(np.diag(C) / N))

    # ridge: E[θ̂] − θ = (A XᵀX − I)θ, Cov = σ² A XᵀX A; mean error − bias ~ N(0, Cov/N)
    beta = (A @ XtX - np.eye(n)) @ theta
    Cr = sigma**2 * A @ XtX @ A
    se = np.sqrt(np.diag(Cr) / N)
    assert np.all(np.abs(beta) > 10 * se)  # the bias is large enough to be seen at this N
    assert np.all(np.abs(mc.bias["ridge"] - beta) < z * se)
    # N·RMSE²/var ~ noncentral χ²(N, N·β²/var)
    nc = N * beta**2 / np.diag(Cr)
    r2 = N * mc.rmse["ridge"] ** 2 / np.diag(Cr)
    assert np.all((r2 > stats.ncx2.ppf(a / 2, N, nc)) & (r2 < stats.ncx2.ppf(1 - a / 2, N, nc)))
    # the biased estimator is visibly worse than the CRLB allows for an unbiased one
    assert np.all(mc.rmse_over_crlb["ridge"][np.abs(beta) / np.sqrt(np.diag(C)) > 3] > hi)
    assert mc.mean_runtime["ols"] > 0
    text = mc.summary()
    assert "ols" in text and "ridge" in text and "RMSE/√CRLB" in text


def test_monte_carlo_seeding_is_reproducible_and_runs_independent():
    _, theta, _, _, _, make_data, ols, _ = _mc_setup()
    r1 = monte_carlo(make_data, {"ols": ols}, theta, 20, rng=7, progress=False)
    r2 = monte_carlo(make_data, {"ols": ols}, theta, 20, rng=np.random.default_rng(7), progress=False)
    r3 = monte_carlo(make_data, {"ols": ols}, theta, 20, rng=8, progress=False)
    np.testing.assert_array_equal(r1.errors["ols"], r2.errors["ols"])
    assert not np.allclose(r1.errors["ols"], r3.errors["ols"])
    # each run has its own stream: no two runs share an error vector
    E = r1.errors["ols"]
    assert len({tuple(row) for row in E}) == E.shape[0]
    # round trip through JSON
    back = MonteCarloResult.from_json(r1.to_json())
    np.testing.assert_array_equal(back.errors["ols"], r1.errors["ols"])
    assert back.n_failures == r1.n_failures and back.seed == 7


def test_monte_carlo_failures_are_counted_not_fatal():
    def make_data(rng):
        return rng.normal(size=3)

    def flaky(d):
        if d[0] > 0:
            raise OptinavError("no solution")
        return d

    def crashy(d):
        return 1 / 0

    ests = {"ok": lambda d: d, "flaky": flaky, "crashy": crashy, "short": lambda d: d[:2], "nan": lambda d: d * np.nan}
    N = 50
    mc = monte_carlo(make_data, ests, np.zeros(3), N, rng=1, progress=True)
    d0 = mc.errors["ok"][:, 0]  # truth is zero, so the errors are the data
    assert mc.n_failures["ok"] == 0
    assert mc.n_failures["flaky"] == int(np.count_nonzero(d0 > 0)) > 0
    np.testing.assert_array_equal(mc.errors["flaky"][d0 <= 0], mc.errors["ok"][d0 <= 0])
    assert np.all(np.isnan(mc.errors["flaky"][d0 > 0]))
    for name in ("crashy", "short", "nan"):
        assert mc.n_failures[name] == N
        assert np.all(np.isnan(mc.rmse[name]))
    assert "ZeroDivisionError" in mc.failure_messages["crashy"][0]
    assert "no solution" in mc.failure_messages["flaky"][0]
    assert "shape" in mc.failure_messages["short"][0]
    assert "failure" in mc.summary()


def test_monte_carlo_truth_from_make_data():
    def make_data(rng):
        t = rng.uniform(-5, 5, size=2)
        return (t + 0.1 * rng.normal(size=2), t), t

    mc = monte_carlo(make_data, {"first": lambda d: d[0]}, None, 300, rng=3, crlb=np.full(2, 0.01))
    # errors are N(0, 0.1²) whatever the random truth: N·RMSE²/0.01 ~ χ²(300)
    a = ALPHA / 2
    lo, hi = np.sqrt(stats.chi2.ppf([a / 2, 1 - a / 2], 300) / 300)
    assert np.all((mc.rmse_over_crlb["first"] > lo) & (mc.rmse_over_crlb["first"] < hi))


# ---------------------------------------------------------------------------------------------------
# rank deficiency: null space, words, covariance on the observable subspace
# ---------------------------------------------------------------------------------------------------


def test_equal_columns():
    rng = np.random.default_rng(5)
    j1, j3 = rng.normal(size=(2, 25, 1))
    rep = analyze(np.hstack([j1, j1, j3]), sigma=0.1, names=["a", "b", "c"])
    assert rep.rank == 2 and not rep.full_rank
    assert rep.null_space.shape == (3, 1)
    assert _same_direction(rep.null_space[:, 0], [1, -1, 0])
    assert rep.unobservable_directions == ["a − b"]
    assert rep.observable_combinations == ["a + b"]
    np.testing.assert_array_equal(rep.observable, [False, False, True])
    assert np.isinf(rep.condition_number)
    assert np.all(np.isinf(rep.std[:2])) and np.isfinite(rep.std[2])
    assert "individually observable: c" in rep.statements


def _coupled(alpha=1 / 0.71, seed=9):
    rng = np.random.default_rng(seed)
    m = 30
    jb = rng.normal(size=m)
    O = rng.normal(size=(m, 2))
    J = np.column_stack([jb, alpha * jb, O])  # residual depends on b + α·M only
    return J, jb, O


def test_bias_misalignment_coupling_words_and_reparametrized_covariance():
    alpha = 1 / 0.71
    J, jb, O = _coupled(alpha)
    sig = np.linspace(0.05, 0.2, J.shape[0])
    names = ["b_x", "M_xy", "s_x", "s_y"]
    rep = analyze(J, sigma=sig, names=names, units=["m/s^2", "", "", ""])
    assert rep.rank == 3
    # J·δ = 0 for δ ∝ (1, −0.71, 0, 0)
    assert _same_direction(rep.null_space[:, 0], [1, -0.71, 0, 0])
    assert rep.unobservable_directions == ["b_x − 0.71·M_xy"]
    assert rep.observable_combinations == ["b_x + 1.41·M_xy"]
    assert rep.statements == [
        "unobservable: b_x − 0.71·M_xy",
        "individually observable: s_x, s_y",
        "observable only as the combination: b_x + 1.41·M_xy",
    ]
    # explicit reparametrization: q = (b + α·M, s_x, s_y), J_red = [jb, O] has full rank
    Jr = np.column_stack([jb, O]) / sig[:, None]
    Cr = np.linalg.inv(Jr.T @ Jr)
    c = np.array([1.0, alpha, 0, 0])
    assert rep.is_estimable(c) and not rep.is_estimable([1.0, 0, 0, 0])
    np.testing.assert_allclose(rep.combination_std(c), np.sqrt(Cr[0, 0]), rtol=1e-9)
    np.testing.assert_allclose(c @ rep.covariance[:, 2:], Cr[0, 1:], rtol=1e-9)
    np.testing.assert_allclose(rep.covariance[2:, 2:], Cr[1:, 1:], rtol=1e-9)
    np.testing.assert_allclose(rep.std[2:], np.sqrt(np.diag(Cr)[1:]), rtol=1e-9)
    assert np.all(np.isinf(rep.std[:2])) and np.all(np.isnan(rep.correlation[:2]))
    assert rep.combination_std([1.0, 0, 0, 0]) == np.inf
    # estimable variances do not depend on the generalized inverse (user scales)
    rep2 = analyze(J, sigma=sig, names=names, scales=[1e-3, 10.0, 1.0, 0.1])
    assert rep2.rank == 3
    np.testing.assert_allclose(rep2.combination_std(c), np.sqrt(Cr[0, 0]), rtol=1e-8)
    text = rep.summary()
    assert "b_x − 0.71·M_xy" in text and "rank 3/4" in text and "m/s^2" in text
    back = ObservabilityReport.from_json(rep.to_json())
    np.testing.assert_array_equal(back.std, rep.std)
    np.testing.assert_array_equal(back.correlation, rep.correlation)
    assert back.statements == rep.statements


def test_norm_only_accelerometer_rotation_is_unobservable():
    # r_k = ‖(I + M) a_k + b‖ − g linearized at M = 0, b = 0: ∂r/∂b = u_k, ∂r/∂M_ij = u_i a_j. The norm is
    # invariant to rotations, so the antisymmetric part of M (three directions) is unobservable.
    rng = np.random.default_rng(2)
    g = 9.80665
    U = rng.normal(size=(24, 3))
    U /= np.linalg.norm(U, axis=1)[:, None]
    a = g * U
    J = np.column_stack([U] + [U[:, i] * a[:, j] for i in range(3) for j in range(3)])
    ax = "xyz"
    names = [f"b_{c}" for c in ax] + [f"M_{p}{q}" for p in ax for q in ax]
    rep = analyze(J, sigma=1e-3, names=names)
    assert rep.rank == 9
    K = np.zeros((12, 3))
    for k, (i, j) in enumerate([(0, 1), (0, 2), (1, 2)]):
        K[3 + 3 * i + j, k], K[3 + 3 * j + i, k] = 1 / np.sqrt(2), -1 / np.sqrt(2)
    np.testing.assert_allclose(rep.null_space @ rep.null_space.T, K @ K.T, atol=1e-10)
    assert rep.unobservable_directions == ["M_xy − M_yx", "M_xz − M_zx", "M_yz − M_zy"]
    assert rep.observable_combinations == ["M_xy + M_yx", "M_xz + M_zx", "M_yz + M_zy"]
    assert np.array_equal(np.flatnonzero(rep.observable), [0, 1, 2, 3, 7, 11])


def test_zero_column_is_not_observable_at_all():
    rng = np.random.default_rng(4)
    J = np.column_stack([rng.normal(size=10), np.zeros(10)])
    rep = analyze(J, names=["x", "dead"])
    assert rep.rank == 1
    assert rep.statements == ["unobservable: dead", "individually observable: x"]
    assert rep.observable_combinations == []
    assert np.isinf(rep.std[1]) and np.isfinite(rep.std[0])


# ---------------------------------------------------------------------------------------------------
# column scaling: the rank decision does not depend on parameter units
# ---------------------------------------------------------------------------------------------------


def test_rank_independent_of_units():
    rng = np.random.default_rng(6)
    J = rng.normal(size=(20, 3))
    k = np.array([1e3, 1e6, 1.0])  # parameters now in mm, μrad, and unchanged
    Jk = J / k  # ∂r/∂(k·p) = (∂r/∂p)/k
    assert analyze(J).rank == 3 and analyze(Jk).rank == 3
    assert analyze(Jk, scales=1.0).rank == 2  # unscaled, the μrad column looks negligible
    np.testing.assert_allclose(analyze(Jk).std, k * analyze(J).std, rtol=1e-9)
    # user scales (expected magnitudes) converted with the units give identical singular values
    mag = np.array([0.1, 1e-4, 2.0])
    np.testing.assert_allclose(
        analyze(Jk, scales=k * mag).singular_values, analyze(J, scales=mag).singular_values, rtol=1e-10
    )
    # a deficient Jacobian stays deficient in any units, with the null direction converted
    Jd = J.copy()
    Jd[:, 1] = Jd[:, 0]
    rd, rdk = analyze(Jd), analyze(Jd / k)
    assert rd.rank == rdk.rank == 2
    assert _same_direction(rdk.null_space[:, 0], k * rd.null_space[:, 0])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), logk=st.lists(st.floats(-8, 8), min_size=4, max_size=4), deficient=st.booleans())
def test_rank_and_std_invariant_under_units(seed, logk, deficient):
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(12, 4))
    if deficient:
        J[:, 3] = J[:, 0] - 2 * J[:, 1]
    k = 10.0 ** np.array(logk)
    r0, r1 = analyze(J), analyze(J / k)
    assert r0.rank == r1.rank == (3 if deficient else 4)
    np.testing.assert_array_equal(r0.observable, r1.observable)
    fin = np.isfinite(r0.std)
    np.testing.assert_allclose(r1.std[fin], (k * r0.std)[fin], rtol=1e-6)


# ---------------------------------------------------------------------------------------------------
# state-space observability matrix
# ---------------------------------------------------------------------------------------------------


def test_double_integrator():
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    Q = observability_matrix(np.array([[1.0, 0.0]]), A)
    np.testing.assert_array_equal(Q, [[1, 0], [0, 1]])
    r = observability_svd(Q, names=["p", "v"], scales=1.0)
    assert r.rank == 2 and r.full_rank
    np.testing.assert_allclose(r.singular_values, [1, 1])
    Qv = observability_matrix([[0.0, 1.0]], A)
    np.testing.assert_array_equal(Qv, [[0, 1], [0, 0]])
    rv = observability_svd(Qv, names=["p", "v"])
    assert rv.rank == 1
    assert _same_direction(rv.null_space[:, 0], [1, 0])
    assert rv.statements == ["unobservable: p", "individually observable: v"]
    assert "rank 1" in rv.summary()
    # a scaled measurement gives proportional raw singular values
    np.testing.assert_allclose(
        observability_svd(observability_matrix([[2.0, 0.0]], A), scales=1.0).singular_values, [2, 2]
    )


def test_positions_separate_bias_from_scale_factor():
    # z_k = b + g_k·s at static positions (A = 0): one position cannot separate b and s, two can.
    g = 9.80665
    one = observability_svd(observability_matrix([[[1.0, g]]]), names=["b", "s"])
    assert one.rank == 1
    assert one.statements == ["unobservable: b − 0.102·s", "observable only as the combination: b + 9.81·s"]
    two = observability_matrix([[[1.0, g]], [[1.0, -g]]], A=np.zeros((2, 2, 2)), order=1)
    np.testing.assert_array_equal(two, [[1, g], [1, -g]])
    assert observability_svd(two).rank == 2
    # A per block: the second block's powers use its own A
    A2 = np.stack([np.zeros((2, 2)), np.array([[0.0, 1.0], [0.0, 0.0]])])
    Q = observability_matrix([np.array([[0.0, 1.0]]), np.array([[1.0, 0.0]])], A2, order=2)
    np.testing.assert_array_equal(Q, [[0, 1], [0, 0], [1, 0], [0, 1]])


# ---------------------------------------------------------------------------------------------------
# NEES
# ---------------------------------------------------------------------------------------------------


def test_nees_values_and_consistency_band():
    np.testing.assert_allclose(nees([[1.0, 2.0]], np.diag([1.0, 4.0])), [2.0])
    rng = np.random.default_rng(12)
    n, N = 3, 500
    B = rng.normal(size=(n, n))
    P = B @ B.T + np.eye(n)
    e = rng.normal(size=(N, n)) @ np.linalg.cholesky(P).T  # e ~ N(0, P)
    # N·ANEES ~ χ²(N·n) with the true P (Bar-Shalom et al. 2001, §5.4.2)
    ok = nees_test(e, P, confidence=1 - ALPHA)
    assert ok.consistent and ok.lower < n < ok.upper
    np.testing.assert_allclose([ok.lower, ok.upper], stats.chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], N * n) / N, rtol=1e-12)
    optimistic = nees_test(e, P / 4)  # ANEES ≈ 4n
    assert not optimistic.consistent and optimistic.anees > optimistic.upper
    assert "optimistic" in optimistic.summary()
    pessimistic = nees_test(e, 4 * P)
    assert not pessimistic.consistent and pessimistic.anees < pessimistic.lower
    assert nees_test(e, np.broadcast_to(P, (N, n, n))).anees == pytest.approx(ok.anees, rel=1e-12)


def test_monte_carlo_nees_of_honest_and_overconfident_covariance():
    sigma = 0.5
    X, theta, C, _, _, make_data, ols, _ = _mc_setup(sigma)
    ests = {"honest": lambda y: (ols(y), C), "overconfident": lambda y: (ols(y), C / 4)}
    mc = monte_carlo(make_data, ests, theta, 300, rng=5, nees_confidence=1 - ALPHA)
    assert mc.nees["honest"].consistent
    assert not mc.nees["overconfident"].consistent
    assert "ANEES" in mc.summary()


# ---------------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call",
    [
        lambda J: analyze(np.where(np.eye(5, 3) > 0, np.nan, J)),
        lambda J: analyze(J, sigma=0.0),
        lambda J: analyze(J, sigma=-1.0),
        lambda J: analyze(J, sigma=np.r_[np.ones(4), 0.0]),
        lambda J: analyze(J, sigma=np.ones(3)),
        lambda J: analyze(J, sigma=np.eye(5)),
        lambda J: analyze(J, R=-np.eye(5)),
        lambda J: analyze(J, R=np.eye(4)),
        lambda J: analyze(J, sigma=1.0, R=np.eye(5)),
        lambda J: analyze(J, names=["a", "b"]),
        lambda J: analyze(J, names=["a", "a", "b"]),
        lambda J: analyze(J, units=["m"]),
        lambda J: analyze(J, rel_tol=0.0),
        lambda J: analyze(J, scales=[1.0, -1.0, 1.0]),
        lambda J: analyze(J, scales=[1.0, 1.0]),
        lambda J: analyze(J, estimate_sigma=True),
        lambda J: analyze(J, residuals=np.ones(4)),
        lambda J: analyze(J[:3], residuals=np.ones(3), estimate_sigma=True),
        lambda J: analyze(J[:, 0]),
        lambda J: analyze("abc"),
        lambda J: fisher_information(J, sigma=0),
        lambda J: observability_matrix([J, J[:, :2]]),
        lambda J: observability_matrix(J, A=np.eye(2)),
        lambda J: observability_matrix(J, A=np.eye(3), order=0),
        lambda J: observability_matrix([]),
        lambda J: nees(J, np.eye(2)),
        lambda J: nees(J, -np.eye(3)),
        lambda J: monte_carlo(lambda r: 0, {"x": lambda d: d}, np.zeros(3), 0),
        lambda J: monte_carlo(lambda r: 0, {}, np.zeros(3), 5),
        lambda J: monte_carlo(lambda r: 0, {"x": 3}, np.zeros(3), 5),
        lambda J: monte_carlo(lambda r: 0, {"x": lambda d: d}, np.zeros(3), 5, rng="seed"),
        lambda J: monte_carlo(lambda r: 0, {"x": lambda d: d}, np.zeros(3), 5, crlb=np.ones(2)),
        lambda J: monte_carlo(lambda r: 0, {"x": lambda d: d}, np.zeros(3), 5, names=["a"]),
        lambda J: monte_carlo(lambda r: 0, {"x": lambda d: d}, None, 5),
    ],
)
def test_bad_input(call):
    J = np.random.default_rng(0).normal(size=(5, 3))
    with pytest.raises(OptinavError):
        call(J)
