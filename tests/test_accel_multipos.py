"""Accelerometer norm-observation calibration: model, closed form, estimators, observability."""

import numpy as np
import pytest

from optinav.errors import OptinavError
from optinav.multipos import accel, model

G = 9.80167
S45 = np.sqrt(0.5)
#: the 12 positions recovered from Gao & Zhang's Table 1 (specific-force direction in the sensor frame)
PAPER12 = np.array(
    [
        (1, 0, 0),
        (0, 1, 0),
        (0, 0, 1),
        (0, 0, -1),
        (0, -1, 0),
        (1, 0, 0),
        (S45, -S45, 0),
        (S45, 0, S45),
        (0, -S45, S45),
        (-S45, S45, 0),
        (-S45, 0, -S45),
        (0, S45, -S45),
    ]
)
SIX = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], float)
CORNERS = np.array([(sx, sy, sz) for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]) / np.sqrt(3)
SCHEME18 = np.vstack([SIX, CORNERS, [(S45, S45, 0), (-S45, 0, S45), (0, S45, -S45), (S45, 0, -S45)]])


def truth_counts():
    """A raw-count unit (~2048 counts/g) with the paper's misalignments and a large bias."""
    K, b = model.from_paper([9.80518, 9.78718, 9.77107], -0.0058, 0.00522, 0.00393, [0.0, 0.0, 0.0], G)
    return K * 208.8, np.array([-6.0, -48.3, -29.0])


def simulate(K, b, ups, n=500, sigma=1.5, rng=0):
    rng = np.random.default_rng(rng)
    raws = [K @ (G * u) + b + rng.normal(0, sigma, (n, 3)) for u in ups]
    idx = np.array([[k * n, (k + 1) * n] for k in range(len(ups))])
    return np.concatenate(raws), idx, raws


def test_jacobian_matches_finite_differences():
    K, b = truth_counts()
    th = model.Kb_to_theta(K, b)
    means = np.array([K @ (G * u) + b for u in SCHEME18]) + 3.0
    J = model.norm_jacobian(th, means)
    Jn = np.empty_like(J)
    for j in range(9):
        h = 1e-6 * max(abs(th[j]), 1.0)
        e = np.zeros(9)
        e[j] = h
        Jn[:, j] = (model.norm_residuals(th + e, means, G) - model.norm_residuals(th - e, means, G)) / (2 * h)
    np.testing.assert_allclose(J, Jn, rtol=1e-6, atol=1e-7 * np.abs(J).max())  # FD round-off


def test_population_residuals_match_single():
    K, b = truth_counts()
    th = model.Kb_to_theta(K, b)
    means = np.array([K @ (G * u) + b for u in PAPER12])
    pop = th + np.random.default_rng(1).normal(0, 1e-3, (7, 9)) * np.abs(th).max()
    R = model.norm_residuals(pop, means, G)
    for i in range(7):
        np.testing.assert_allclose(R[i], model.norm_residuals(pop[i], means, G), rtol=1e-12, atol=1e-12)


def test_population_residuals_are_the_norm_observation_by_a_general_solver():
    """The population kernel (a GA on every static sample) gives ‖K⁻¹(m − b)‖ − g as numpy's general solver does,
    for each of 50 θ at 5000 points, and 0 at the truth on noise-free poses."""
    K, b = truth_counts()
    th = model.Kb_to_theta(K, b)
    rng = np.random.default_rng(2)
    pts = rng.normal(0, 1.0, (5000, 3)) @ K.T * G + b
    pop = th + rng.normal(0, 1e-3, (50, 9)) * np.abs(th).max()
    R = model.norm_residuals(pop, pts, G)
    assert R.shape == (50, 5000)
    for i in (0, 17, 49):
        Ki, bi = model.theta_to_Kb(pop[i])
        ref = np.linalg.norm(np.linalg.solve(Ki, (pts - bi).T), axis=0) - G
        np.testing.assert_allclose(R[i], ref, rtol=1e-12, atol=1e-12 * G)
    means = np.array([K @ (G * u) + b for u in PAPER12])
    np.testing.assert_allclose(model.norm_residuals(th, means, G), 0.0, atol=1e-12 * G)


def test_paper_parameter_conversion_round_trip():
    K, b = model.from_paper([9.80518, 9.78718, 9.77107], -0.0058, 0.00522, 0.00393, [0.11646, 0.0361, 0.13644], G)
    p = model.to_paper(K, b, G)
    np.testing.assert_allclose(p["S"], [9.80518, 9.78718, 9.77107], rtol=1e-14)
    assert p["M_xy"] == pytest.approx(-0.0058) and p["M_xz"] == pytest.approx(0.00522)
    assert p["M_yz"] == pytest.approx(0.00393)
    with pytest.raises(OptinavError, match="below the diagonal"):
        model.Kb_to_theta(K + np.tril(np.ones((3, 3)), -1) * 1e-3, b)


@pytest.mark.parametrize("ups", [SCHEME18, PAPER12[[0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11]]])
def test_closed_form_is_exact_without_noise(ups):
    K, b = truth_counts()
    means = np.array([K @ (G * u) + b for u in ups])
    th = accel.initial_estimate(means, G)
    np.testing.assert_allclose(th, model.Kb_to_theta(K, b), rtol=1e-9, atol=1e-7)


def test_closed_form_axis_aligned_from_six_poses():
    K = np.diag([210.0, 205.0, 199.0])
    b = np.array([12.0, -30.0, 4.0])
    means = np.array([K @ (G * u) + b for u in SIX])
    th = accel.initial_estimate(means, G)
    np.testing.assert_allclose(th, model.Kb_to_theta(K, b), rtol=1e-10, atol=1e-8)


def test_lm_recovers_truth_within_reported_sigma_and_std_is_honest():
    """Monte Carlo: normalized errors of the default estimator have unit RMS (std = CRLB is honest)."""
    K, b = truth_counts()
    th_true = model.Kb_to_theta(K, b)
    z = []
    for seed in range(60):
        raw, idx, _ = simulate(K, b, SCHEME18, n=300, sigma=2.0, rng=seed)
        fit = accel.fit_accel(accel.pose_statistics(raw, idx), G)
        assert fit.success and fit.held == []
        assert np.all(fit.std >= fit.crlb_std)
        z.append((fit.theta - th_true) / fit.crlb_std)
    z = np.array(z)
    assert np.all(np.abs(z) < 5.5)
    rms = np.sqrt(np.mean(z**2, axis=0))
    # 60 runs: the RMS of a unit normal lies in [0.75, 1.25] with > 99 % probability per parameter
    assert np.all((rms > 0.7) & (rms < 1.3)), rms


def test_pose_statistics_skip_invalid_and_non_finite_rows():
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, SCHEME18, rng=5)
    raw = raw.copy()
    valid = np.ones(len(raw), bool)
    valid[idx[0, 0] + 3] = False
    raw[idx[1, 0] + 2, 1] = np.nan
    st = accel.pose_statistics(raw, idx, valid=valid)
    for k, (i0, i1) in enumerate(idx):
        x = raw[i0:i1][valid[i0:i1] & np.all(np.isfinite(raw[i0:i1]), axis=1)]
        np.testing.assert_array_equal(st.means[k], x.mean(axis=0))
        np.testing.assert_allclose(st.covariances[k], np.cov(x.T, ddof=1), rtol=1e-12)
        assert st.counts[k] == len(x)
    assert st.counts[0] == idx[0, 1] - idx[0, 0] - 1 and st.counts[1] == idx[1, 1] - idx[1, 0] - 1
    with pytest.raises(OptinavError, match="valid has shape"):
        accel.pose_statistics(raw, idx, valid=valid[:-1])
    valid[idx[2, 0] : idx[2, 1] - 1] = False
    with pytest.raises(OptinavError, match="static pose 2 has 1 valid sample"):
        accel.pose_statistics(raw, idx, valid=valid)


@pytest.mark.parametrize("method", ["gn", "trf", "newton"])
def test_local_methods_agree_with_lm(method):
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, SCHEME18, rng=3)
    st = accel.pose_statistics(raw, idx)
    ref = accel.fit_accel(st, G)
    fit = accel.fit_accel(st, G, method=method)
    if method == "newton":  # unweighted cost from the interval centre: same optimum up to the weighting
        assert np.all(np.abs(fit.theta - ref.theta) < 3 * ref.std)
    else:
        np.testing.assert_allclose(fit.theta, ref.theta, rtol=1e-7, atol=1e-6 * ref.std.min())


@pytest.mark.parametrize("method", ["ga", "pso"])
def test_population_methods_reach_the_optimum_neighbourhood(method):
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, PAPER12, rng=4)
    st = accel.pose_statistics(raw, idx)
    lo, hi = accel.search_interval(st.means, G)
    th_true = model.Kb_to_theta(K, b)
    assert np.all((th_true > lo) & (th_true < hi))
    fit = accel.fit_accel(st, G, method=method, rng=7)
    ref = accel.fit_accel(st, G, method="lm")
    assert fit.history[-1] <= fit.history[0]
    # scale factors within 0.5 %, biases within 1 % of full scale: the paper's GA accuracy class
    np.testing.assert_allclose(fit.theta[:3], ref.theta[:3], rtol=5e-3)
    assert np.all(np.abs(fit.theta[6:] - ref.theta[6:]) < 0.01 * G * ref.theta[:3])
    again = accel.fit_accel(st, G, method=method, rng=7)
    np.testing.assert_array_equal(again.theta, fit.theta)


def test_fitting_samples_biases_the_scale_by_2sigma2_over_g2():
    """Per sample E‖a + n‖ ≈ g + σ²/g; least squares on samples solves E[‖u‖²] = g·E‖u‖, i.e. a scale
    (g² + 3σ²)/(g² + σ²) ≈ 1 + 2σ²/g² too large (isotropic noise σ per axis). Pose means remove it."""
    K = np.eye(3)
    b = np.zeros(3)
    sigma = 0.4  # m/s²: exaggerated so the σ²/g bias dominates the noise of the estimate
    raw, idx, raws = simulate(K, b, SCHEME18, n=2000, sigma=sigma, rng=5)
    st = accel.pose_statistics(raw, idx)
    means_fit = accel.fit_accel(st, G)
    sample_fit = accel.fit_accel(st, G, data="samples", samples=raws)
    bias = np.mean(sample_fit.theta[:3]) - 1.0
    assert bias == pytest.approx(2 * sigma**2 / G**2, rel=0.15)
    assert abs(np.mean(means_fit.theta[:3]) - 1.0) < 0.2 * sigma**2 / G**2


def test_six_axis_poses_hold_misalignments_and_say_so():
    K = np.array([[208.5, 1.5, -2.3], [0, 208.0, 4.9], [0, 0, 214.8]])
    b = np.array([-6.0, -48.3, -29.0])
    raw, idx, _ = simulate(K, b, SIX, rng=6)
    fit = accel.fit_accel(accel.pose_statistics(raw, idx), G)
    assert fit.held == ["K_xy", "K_xz", "K_yz"]
    assert np.all(np.isnan(fit.std[3:6])) and np.all(fit.std[[0, 1, 2, 6, 7, 8]] > 0)
    assert not fit.observability.full_rank
    text = " ".join(fit.observability.unobservable_directions)
    assert "K_xy" in text and "K_xz" in text and "K_yz" in text
    # the observable part is still right: scales within 0.3 % (misalignment leaks in at second order)
    np.testing.assert_allclose(np.diag(fit.K), np.diag(K), rtol=3e-3)
    with pytest.raises(OptinavError, match="cannot determine all 9"):
        accel.fit_accel(accel.pose_statistics(raw, idx), G, model_form="full")


def test_too_few_or_degenerate_poses_are_errors():
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, SIX[:5], rng=7)
    with pytest.raises(OptinavError, match="at least 6"):
        accel.fit_accel(accel.pose_statistics(raw, idx), G)
    # eight poses, all with the z axis horizontal: K_zz and b_z cannot be told apart from nothing
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    flat = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(8)])
    raw, idx, _ = simulate(K, b, flat, rng=8)
    with pytest.raises(OptinavError, match="K_zz|b_z"):
        accel.fit_accel(accel.pose_statistics(raw, idx), G)


def test_unknown_method_and_data_are_errors():
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, SCHEME18, n=50, rng=9)
    st = accel.pose_statistics(raw, idx)
    with pytest.raises(OptinavError, match="unknown calibration method"):
        accel.fit_accel(st, G, method="simplex")
    with pytest.raises(OptinavError, match="samples"):
        accel.fit_accel(st, G, data="samples")


def test_efficiency_monte_carlo_is_near_one():
    """The default estimator attains the CRLB (white noise): RMSE/√CRLB inside the 99.9 % band of 150 runs."""
    from optinav.core.observability import rmse_ratio_band

    K, b = truth_counts()
    eff, crlb = accel.efficiency(K, b, SCHEME18, G, 2.0, 400, 150, rng=11)
    lo, hi = rmse_ratio_band(150, 0.999)
    assert np.all((eff > lo) & (eff < hi)), eff
    assert np.all(crlb > 0)


def test_diagonal_model_is_honoured_and_unknown_models_are_errors():
    K, b = truth_counts()
    raw, idx, _ = simulate(K, b, SCHEME18, rng=12)
    st = accel.pose_statistics(raw, idx)
    fit = accel.fit_accel(st, G, model_form="diagonal")  # all 9 observable, 6 asked for
    assert fit.held == ["K_xy", "K_xz", "K_yz"] and np.all(fit.theta[3:6] == 0)
    with pytest.raises(OptinavError, match="unknown accelerometer model"):
        accel.fit_accel(st, G, model_form="triangular")
