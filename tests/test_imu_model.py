"""IMU error and noise models: exact inversion, error-matrix forms, noise statistics, digitization, presets.

Statistical tolerances are derived from the sampling distributions named next to each test; every
random test uses a fixed seed, and the false-alarm probability of each bound is stated.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats

from optinav import OptinavError
from optinav.core.allan import FLICKER_FLOOR, allan_deviation, noise_parameters_from_allan
from optinav.core.imu_model import (
    PRESETS,
    GM_SIGMA_PER_BIAS_INSTABILITY,
    ImuMeasurement,
    ImuModel,
    ImuSpec,
    TriadErrors,
    TriadNoise,
    gauss_markov,
    misalignment_matrix,
    preset,
    quantize,
    saturate,
    upper_misalignment_matrix,
    white_noise,
)
from optinav.core.results import Result

DEG = math.pi / 180
G0 = 9.80665

# ------------------------------------------------------------------------------------------------------------
# deterministic model
# ------------------------------------------------------------------------------------------------------------

_small = st.floats(-0.1, 0.1, allow_nan=False)
_vec = arrays(float, 3, elements=st.floats(-10, 10, allow_nan=False))


@st.composite
def triads(draw, sensor="gyro"):
    """Well-conditioned triads: |s| ≤ 0.2 and |M_ij| ≤ 0.1 keep cond(K) below ~2."""
    scale = draw(arrays(float, 3, elements=st.floats(-0.2, 0.2)))
    m6 = draw(arrays(float, 6, elements=_small))
    bias = draw(_vec)
    G = draw(arrays(float, (3, 3), elements=st.floats(-0.01, 0.01))) if sensor == "gyro" else None
    return TriadErrors.from_six(sensor, bias, scale, m6, G)


def _tol(*arrays_):
    # solve/multiply in double precision: errors of a few ulp of the largest magnitude involved
    return 1e-12 * max(1.0, *(float(np.max(np.abs(a))) for a in arrays_))


@settings(max_examples=60, deadline=None)
@given(
    triads("gyro"),
    arrays(float, (5, 3), elements=st.floats(-100, 100)),
    arrays(float, (5, 3), elements=st.floats(-100, 100)),
    arrays(float, 5, elements=st.floats(1e-4, 1.0)),
    st.sampled_from(["rate", "increment"]),
)
def test_triad_apply_compensate_are_inverses(tri, x, f, dt, kind):
    y = tri.apply(x, dt=dt, acc=f, kind=kind)
    assert np.allclose(tri.compensate(y, dt=dt, acc=f, kind=kind), x, rtol=0, atol=_tol(x, y, tri.bias, f))
    x2 = tri.compensate(x, dt=dt, acc=f, kind=kind)  # and the other way round
    assert np.allclose(tri.apply(x2, dt=dt, acc=f, kind=kind), x, rtol=0, atol=_tol(x, x2, tri.bias, f))


@settings(max_examples=40, deadline=None)
@given(
    triads("gyro"),
    triads("accel"),
    arrays(float, (4, 3), elements=st.floats(-10, 10)),
    arrays(float, (4, 3), elements=st.floats(-50, 50)),
    st.sampled_from(["rate", "increment"]),
    st.floats(1e-3, 0.1),
)
def test_imu_model_apply_compensate_identity(gyro, accel, w, f, kind, dt):
    """Noise-free, no saturation/quantization: compensate∘apply = id (g-sensitivity uses compensated f)."""
    model = ImuModel(gyr=gyro, acc=accel)
    meas = model.apply(w, f, dt, kind=kind, noise=False)
    comp = model.compensate(meas.gyr, meas.acc, dt, kind=kind)
    assert np.allclose(comp.acc, f, rtol=0, atol=_tol(f, meas.acc, accel.bias))
    assert np.allclose(comp.gyr, w, rtol=0, atol=_tol(w, meas.gyr, gyro.bias, f))
    back = model.apply(comp.gyr, comp.acc, dt, kind=kind, noise=False)  # apply∘compensate = id
    assert np.allclose(back.gyr, meas.gyr, rtol=0, atol=_tol(w, meas.gyr, gyro.bias, f))


def test_six_term_form_reproduces_paper_products():
    s = np.array([0.01, -0.02, 0.003])
    m6 = np.array([1e-3, -2e-3, 3e-3, -4e-3, 5e-3, -6e-3])  # M_xy, M_xz, M_yx, M_yz, M_zx, M_zy
    tri = TriadErrors.from_six("accel", bias=[0.1, 0.2, 0.3], scale=s, misalignment=m6)
    K = tri.K
    names = {(0, 1): 0, (0, 2): 1, (1, 0): 2, (1, 2): 3, (2, 0): 4, (2, 1): 5}
    for (i, j), k in names.items():
        assert K[i, j] == pytest.approx((1 + s[i]) * m6[k], rel=1e-15)  # E_ij = S_ii·M_ij
    assert np.allclose(np.diag(K), 1 + s, rtol=1e-15, atol=0)
    assert tri.misalignment[0, 1] == m6[0] and tri.misalignment[2, 1] == m6[5]  # M_xy row x col y
    assert np.array_equal(tri.misalignment6, m6)
    assert np.array_equal(misalignment_matrix(m6), tri.misalignment)
    # a raw K factors back into the same s and M
    back = TriadErrors.from_matrix("accel", K, bias=tri.bias)
    assert np.allclose(back.scale, s, atol=1e-15) and np.allclose(back.misalignment, tri.misalignment, atol=1e-17)


def test_upper_triangular_form():
    tri = TriadErrors.from_upper_triangular("accel", scale=[0.01, 0.02, 0.03], misalignment=[1e-3, 2e-3, 3e-3])
    K = tri.K
    assert np.all(np.tril(K, -1) == 0) and tri.is_upper_triangular
    assert K[0, 1] == pytest.approx(1.01 * 1e-3) and K[0, 2] == pytest.approx(1.01 * 2e-3)
    assert K[1, 2] == pytest.approx(1.02 * 3e-3)
    assert np.array_equal(upper_misalignment_matrix([1e-3, 2e-3, 3e-3])[[0, 0, 1], [1, 2, 2]], [1e-3, 2e-3, 3e-3])
    spec = preset("mems-mti1", misalignment_form="upper")
    for seed in range(5):
        unit = spec.draw(seed)
        assert unit.acc.is_upper_triangular and unit.gyr.is_upper_triangular


def test_increment_bias_scales_with_dt():
    tri = TriadErrors("gyro", bias=[1e-3, -2e-3, 3e-3])
    dt = np.array([0.01, 0.02, 0.5])
    y = tri.apply(np.zeros((3, 3)), dt=dt, kind="increment")
    assert np.allclose(y, dt[:, None] * tri.bias)


# ------------------------------------------------------------------------------------------------------------
# noise
# ------------------------------------------------------------------------------------------------------------


def _chi2_bounds(dof, p=1e-6):
    """Two-sided bounds of (Σ z²)/dof for dof standard normals z, each side with probability p/2."""
    return stats.chi2.ppf(p / 2, dof) / dof, stats.chi2.ppf(1 - p / 2, dof) / dof


@pytest.mark.parametrize("kind", ["increment", "rate"])
def test_white_noise_std_matches_density(kind):
    """Σ e²/σ² over n zero-mean Gaussian samples is χ²(n): the ratio (Σe²/n)/σ² lies within the χ²
    quantiles at p = 1e-6 (about ±2.2 % for n = 1e5); σ = N√dt (increments) or N/√dt (rates)."""
    N = np.array([1e-3, 2e-3, 5e-4])  # rad/√s
    n, dt = 100_000, 0.005
    model = ImuModel(gyro_noise=TriadNoise(white=N))
    meas = model.apply(np.zeros((n, 3)), np.zeros((n, 3)), dt, rng=1, kind=kind)
    sigma = N * (math.sqrt(dt) if kind == "increment" else 1 / math.sqrt(dt))
    lo, hi = _chi2_bounds(n)
    ratio = np.mean(meas.gyr**2, axis=0) / sigma**2
    assert np.all((lo < ratio) & (ratio < hi)), ratio
    assert np.all(meas.acc == 0)


def test_white_noise_irregular_dt():
    """With dt varying per sample each increment has σ_k = N√dt_k: e_k/σ_k are i.i.d. N(0,1) (χ² bound)."""
    rng = np.random.default_rng(2)
    n = 50_000
    dt = rng.uniform(0.001, 0.05, n)
    e = white_noise(n, 0.01, dt, rng=3, kind="increment")
    z2 = (e / (0.01 * np.sqrt(dt))[:, None]) ** 2
    lo, hi = _chi2_bounds(n)
    assert np.all((lo < z2.mean(0)) & (z2.mean(0) < hi))


def test_gauss_markov_stationary_std_and_autocorrelation():
    """AR(1) with φ = exp(−dt/τ) = 0.905 and n = 2e5: the sample variance has relative s.d.
    √(2(1+φ²)/(n(1−φ²))) ≈ 1.0 %, so the std is within 5·0.5 % = 2.5 % (5σ); the lag-1 sample
    autocorrelation has s.d. √((1−φ²)/n) ≈ 0.00095 (Bartlett), bound 5σ ≈ 0.0048."""
    sigma, tau, dt, n = np.array([1e-4, 2e-4, 3e-4]), 0.1, 0.01, 200_000
    x = gauss_markov(n, sigma, tau, dt, rng=4)
    phi = math.exp(-dt / tau)
    var_rel_sd = math.sqrt(2 * (1 + phi**2) / (n * (1 - phi**2)))
    assert np.all(np.abs(x.std(axis=0) / sigma - 1) < 5 * 0.5 * var_rel_sd)
    r1 = np.array([np.corrcoef(x[:-1, j], x[1:, j])[0, 1] for j in range(3)])
    assert np.all(np.abs(r1 - phi) < 5 * math.sqrt((1 - phi**2) / n))


def test_gauss_markov_exact_with_irregular_dt():
    """Exact discretization: the innovations (x_k − φ_k x_{k−1})/(σ√(1−φ_k²)) with φ_k = exp(−dt_k/τ)
    are i.i.d. N(0,1) whatever dt_k is (χ² bound at p = 1e-6), and x_0/σ too (stationary start)."""
    rng = np.random.default_rng(5)
    n, sigma, tau = 60_000, 2.0, 0.3
    dt = rng.uniform(0.001, 1.0, n)
    x = gauss_markov(n, sigma, tau, dt, rng=6)
    phi = np.exp(-dt[1:] / tau)[:, None]
    z = (x[1:] - phi * x[:-1]) / (sigma * np.sqrt(1 - phi**2))
    lo, hi = _chi2_bounds(z.shape[0])
    assert np.all((lo < (z**2).mean(0)) & ((z**2).mean(0) < hi))
    assert abs(float(np.mean(z))) < 5 / math.sqrt(z.size)


def test_rate_random_walk_allan_slope_and_level():
    """Rate random walk K: the Allan deviation is K√(τ/3) (IEEE 952 C.1.4). For the sampled walk the
    variance is K²τ/3 + K²dt/(6m) (1/(2m²) relative), so only m ≥ 16 (< 0.2 %) is used. Each estimate
    lies in the χ² interval of the RW-FM EDF at confidence 1 − 1e-4; the slope +1/2 read-off at
    τ = 3 s lies within 4× its relative 1σ."""
    K, dt, n = 1e-4, 0.1, 2**16
    model = ImuModel(gyro_noise=TriadNoise(random_walk=K))
    y = model.apply(np.zeros((n, 3)), np.zeros((n, 3)), dt, rng=7).gyr
    ad = allan_deviation(y, dt, taus=dt * 2 ** np.arange(4, 15), noise="random_walk", confidence=1 - 1e-4)
    truth = K * np.sqrt(ad.tau / 3)[:, None]
    assert np.all((ad.lower < truth) & (truth < ad.upper))
    p = noise_parameters_from_allan(ad)
    assert np.all(np.abs(p.random_walk / K - 1) < 4 * p.random_walk_rel_sigma)
    assert np.all(np.isnan(p.white))


def test_bias_instability_mapping_reads_back_from_allan():
    """A spec's bias instability B becomes a Gauss–Markov σ = 1.076·B whose Allan peak is 0.664·B, so the
    IEEE 952 read-off returns B: within the flat region (|slope| ≤ 0.125) the model curve lies within
    2.6 % below the peak, plus 4× the read-off's relative 1σ of sampling error."""
    B = 1e-4
    spec = ImuSpec(gyro_bias_instability=B, gyro_bias_corr_time=1.0, rate_hz=20.0)
    unit = spec.draw(0)
    assert unit.gyro_noise.gm_sigma == pytest.approx(np.full(3, B * GM_SIGMA_PER_BIAS_INSTABILITY))
    assert GM_SIGMA_PER_BIAS_INSTABILITY == pytest.approx(FLICKER_FLOOR / 0.6173642831)
    n = 100_000
    y = unit.apply(np.zeros((n, 3)), np.zeros((n, 3)), rng=8).gyr
    ad = allan_deviation(y, 1 / spec.rate_hz, taus=0.05 * 2 ** np.arange(0, 14, 0.25))
    p = noise_parameters_from_allan(ad)
    rel = p.bias_instability / B
    assert np.all((rel > 0.974 - 4 * p.bias_instability_rel_sigma) & (rel < 1 + 4 * p.bias_instability_rel_sigma))


# ------------------------------------------------------------------------------------------------------------
# saturation and quantization
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["rate", "increment"])
def test_saturation_flags_exactly_samples_beyond_range(kind):
    rng = np.random.default_rng(9)
    n = 2000
    dt = rng.uniform(0.005, 0.02, n)
    w = rng.uniform(-2.5, 2.5, (n, 3)) * (dt[:, None] if kind == "increment" else 1.0)
    gyro = TriadErrors.from_six(
        "gyro", bias=[0.1, -0.2, 0.05], scale=[0.01, 0.0, -0.02], misalignment=[1e-3, 0, 0, 2e-3, 0, -1e-3]
    )
    rng_lim = np.array([1.0, 1.5, 2.0])
    model = ImuModel(gyr=gyro, gyro_noise=TriadNoise(range=rng_lim))
    meas = model.apply(w, np.zeros((n, 3)), dt, kind=kind, noise=False)
    ideal = gyro.apply(w, dt=dt, kind=kind)
    ideal_rate = ideal / dt[:, None] if kind == "increment" else ideal
    expected = np.abs(ideal_rate) > rng_lim
    assert expected.any() and (~expected).any()
    assert np.array_equal(meas.gyro_saturated, expected)
    bound = rng_lim * (dt[:, None] if kind == "increment" else 1.0)
    assert np.allclose(meas.gyr[expected], (np.sign(ideal) * bound)[expected], rtol=1e-15, atol=0)
    assert np.array_equal(meas.gyr[~expected], ideal[~expected])
    assert not meas.acc_saturated.any()


def test_quantized_increment_sum_stays_within_one_lsb():
    """With the residual carried, Σ q_k − Σ Δ_k = −r_k with |r_k| ≤ LSB/2 at every k."""
    rng = np.random.default_rng(10)
    n, lsb = 20_000, np.array([1e-5, 3e-5, 7e-6])
    dt = rng.uniform(0.004, 0.006, n)
    v = rng.normal(2e-5, 4e-5, (n, 3))
    q = quantize(v, lsb, dt, kind="increment", lsb_kind="increment", carry=True)
    k = np.rint(q / lsb)
    assert np.allclose(q, k * lsb, rtol=1e-12, atol=0)  # integer multiples of the LSB
    drift = np.abs(np.cumsum(q, 0) - np.cumsum(v, 0))
    assert np.all(drift <= lsb * (0.5 + 1e-6))
    # rate outputs with a rate LSB: the integral Σ y dt keeps within LSB·dt/2 as well
    y = v / dt[:, None]
    yq = quantize(y, lsb, dt, kind="rate", lsb_kind="rate", carry=True)
    assert np.allclose(yq, np.rint(yq / lsb) * lsb, rtol=1e-12, atol=0)
    assert np.all(np.abs(np.cumsum((yq - y) * dt[:, None], 0)) <= lsb * dt[:, None] * (0.5 + 1e-6))
    # without carry every sample is rounded on its own, and the integral error grows
    yr = quantize(y, lsb, dt, kind="rate", lsb_kind="rate", carry=False)
    assert np.all(np.abs(yr - y) <= lsb / 2 * (1 + 1e-12))


def test_rate_and_increment_lsbs_share_one_compiled_kernel():
    """A rate LSB (scaled by each dt) and an increment LSB reach the carry kernel as the same array type: the rate
    LSB's was a read-only view and compiled the kernel a second time. Both keep the carried sum within LSB/2."""
    from optinav.core.imu_model import _quantize_carry_kernel

    rng = np.random.default_rng(11)
    dt = rng.uniform(0.004, 0.006, 500)
    v = rng.normal(2e-5, 4e-5, (500, 3))
    lsb = np.array([1e-5, 3e-5, 7e-6])
    q = quantize(v, lsb, dt, kind="increment", lsb_kind="increment", carry=True)
    assert np.all(np.abs(np.cumsum(q - v, 0)) <= lsb * (0.5 + 1e-6))
    compiled = set(_quantize_carry_kernel.signatures)  # other tests of the process may have called it before
    y = v / dt[:, None]
    yq = quantize(y, lsb, dt, kind="rate", lsb_kind="rate", carry=True)
    assert np.all(np.abs(np.cumsum((yq - y) * dt[:, None], 0)) <= lsb * dt[:, None] * (0.5 + 1e-6))
    assert set(_quantize_carry_kernel.signatures) == compiled, "the rate LSB compiled a signature of its own"


def test_quantization_through_model():
    spec = ImuSpec(gyro_lsb=(1e-4), acc_lsb=1e-3, lsb_kind="increment", rate_hz=200.0)
    unit = spec.draw(errors=False)
    rng = np.random.default_rng(11)
    n = 5000
    w, f = rng.normal(0, 0.3, (n, 3)) / 200, rng.normal(0, 2.0, (n, 3)) / 200
    meas = unit.apply(w, f, kind="increment", noise=False)
    assert np.all(np.abs(np.cumsum(meas.gyr - w, 0)) <= 1e-4 * (0.5 + 1e-6))
    assert np.all(np.abs(np.cumsum(meas.acc - f, 0)) <= 1e-3 * (0.5 + 1e-6))


# ------------------------------------------------------------------------------------------------------------
# specification level
# ------------------------------------------------------------------------------------------------------------


def test_presets_convert_published_numbers():
    rlg = preset("rlg-nav")
    assert rlg.gyro_bias_instability == pytest.approx(np.full(3, 2.4240684e-8), rel=1e-7)  # 0.005 °/h
    assert rlg.gyro_arw == pytest.approx(np.full(3, 0.0005 * DEG / 60))  # 0.0005 °/√h = 1.4544e-7 rad/√s
    assert rlg.gyro_arw[0] == pytest.approx(1.4544410e-7, rel=1e-7)
    assert rlg.gyro_scale == pytest.approx(np.full(3, 2e-6))
    assert rlg.acc_bias == pytest.approx(np.full(3, 1.96133e-4))  # 20 μg
    assert rlg.rate_hz == 200.0

    mti = preset("mems-mti1")
    assert mti.gyro_arw[0] == pytest.approx(0.007 * DEG)  # 1.2217e-4 rad/s/√Hz
    assert mti.gyro_bias_instability[0] == pytest.approx(4.8481368e-5, rel=1e-7)  # 10 °/h
    assert mti.acc_vrw[0] == pytest.approx(120e-6 * G0)  # 1.1768e-3 m/s²/√Hz
    assert mti.acc_bias_instability[0] == pytest.approx(2.941995e-4, rel=1e-6)  # 0.03 mg
    assert mti.gyro_range[0] == pytest.approx(2000 * DEG) and mti.acc_range[0] == pytest.approx(16 * G0)

    mpu = preset("mpu6000")
    assert mpu.gyro_arw[0] == pytest.approx(8.7266463e-5, rel=1e-7)  # 0.005 °/s/√Hz
    assert mpu.acc_vrw[0] == pytest.approx(3.92266e-3)  # 400 μg/√Hz
    assert mpu.gyro_lsb[0] == pytest.approx(DEG / 131)  # 131 LSB/(°/s)
    assert mpu.acc_lsb[0] == pytest.approx(G0 / 16384)  # 16384 LSB/g
    assert mpu.gyro_range[0] == pytest.approx(250 * DEG) and mpu.acc_range[0] == pytest.approx(2 * G0)
    assert mpu.acc_bias == pytest.approx([0.05 * G0, 0.05 * G0, 0.08 * G0])  # ±50/50/80 mg
    assert mpu.gyro_bias[0] == pytest.approx(20 * DEG)
    assert mpu.gyro_g_sensitivity == pytest.approx(0.1 * DEG / G0)
    tac = preset("tactical-mems")  # ADIS16495 class: 0.8 °/h, 0.09 °/√h; 3.2 μg, 0.008 m/s/√h
    assert tac.gyro_bias_instability[0] == pytest.approx(0.8 * DEG / 3600)
    assert tac.gyro_arw[0] == pytest.approx(0.09 * DEG / 60)
    assert tac.acc_bias_instability[0] == pytest.approx(3.2e-6 * G0)
    assert tac.acc_vrw[0] == pytest.approx(0.008 / 60)
    assert set(PRESETS) == {"rlg-nav", "tactical-mems", "mems-mti1", "mpu6000"}


def test_preset_overrides_and_round_trip():
    spec = preset("mpu6000", rate_hz=500, gyro_range=(2000, "deg/s"), acc_lsb=(1 / 2048, "g"))
    assert spec.rate_hz == 500 and spec.gyro_range[2] == pytest.approx(2000 * DEG)
    assert spec.acc_lsb[0] == pytest.approx(G0 / 2048)
    back = Result.from_json(spec.to_json())
    assert isinstance(back, ImuSpec) and np.array_equal(back.gyro_range, spec.gyro_range)
    unit = spec.draw(3)
    again = ImuModel.from_json(unit.to_json())
    assert np.array_equal(again.gyr.K, unit.gyr.K) and np.array_equal(again.acc_noise.range, unit.acc_noise.range)
    n = 10
    meas = unit.apply(np.zeros((n, 3)), np.tile([0, 0, G0], (n, 1)), rng=1)
    assert isinstance(Result.from_json(meas.to_json()), ImuMeasurement)


def test_draw_statistics_match_spec():
    """Over n = 1500 drawn units, Σb²/(nσ²) and Σs²/(nσ²) follow χ²(n)/n (bounds at p = 1e-6)."""
    spec = ImuSpec(gyro_bias=1e-3, acc_scale=[1e-3, 2e-3, 3e-3], gyro_misalignment=1e-3)
    n = 1500
    rng = np.random.default_rng(12)
    units = [spec.draw(rng) for _ in range(n)]
    b = np.array([u.gyr.bias for u in units])
    s = np.array([u.acc.scale for u in units])
    m = np.array([u.gyr.misalignment6 for u in units])
    lo, hi = _chi2_bounds(n)
    for r in ((b**2).mean(0) / 1e-6, (s**2).mean(0) / spec.acc_scale**2, (m**2).mean(0) / 1e-6):
        assert np.all((lo < r) & (r < hi)), r
    assert np.all([np.all(u.acc.bias == 0) for u in units[:5]])


# ------------------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------------------


def test_bad_input_raises_optinav_error():
    model = ImuModel()
    z = np.zeros((4, 3))
    bad = z.copy()
    bad[1, 2] = np.nan
    cases = [
        lambda: model.apply(bad, z, 0.01),
        lambda: model.apply(np.zeros((4, 2)), z, 0.01),
        lambda: model.apply(z, np.zeros((5, 3)), 0.01),
        lambda: model.apply(z, z, -0.01),
        lambda: model.apply(z, z, np.ones(3) * 0.01),
        lambda: model.apply(z, z, 0.01, kind="delta"),
        lambda: model.compensate(z, bad),
        lambda: TriadNoise(white=-1e-3),
        lambda: TriadNoise(gm_sigma=1e-3),  # no correlation time
        lambda: ImuSpec(gyro_arw=-1.0),
        lambda: ImuSpec(acc_vrw=[1.0, np.nan, 1.0]),
        lambda: ImuSpec(lsb_kind="bits"),
        lambda: preset("adxl345"),
        lambda: preset("mpu6000", gyro_noise_density=1.0),
        lambda: preset("mpu6000", gyro_range=(250, "furlong")),
        lambda: TriadErrors("gyro", misalignment=np.eye(3)),
        lambda: TriadErrors("accel", g_sensitivity=np.ones((3, 3))),
        lambda: TriadErrors("magnetometer"),
        lambda: TriadErrors("gyro", scale=[-1.0, 0, 0]),
        lambda: TriadErrors.from_six("gyro", misalignment=[1, 1, 1, 1, 1, 1]),  # singular K
        lambda: TriadErrors.from_matrix("gyro", -np.eye(3)),
        lambda: TriadErrors.from_six("gyro", misalignment=[1e-3] * 5),
        lambda: TriadErrors("gyro", g_sensitivity=np.eye(3) * 1e-3).apply(z),  # f missing
        lambda: TriadErrors("gyro").apply(z, kind="increment"),  # dt missing
        lambda: saturate(z, 0.0),
        lambda: quantize(z, [-1, 0, 0]),
        lambda: ImuSpec().draw(rng="seed"),
    ]
    for case in cases:
        with pytest.raises(OptinavError):
            case()
