"""Strapdown integration against truth: closed-form rotations, analytic coning (simulate.coning), static
navigation with Earth rate (simulate.static_positions) with and without injected sensor biases (predicted by
the linearized INS error model), a moving base (simulate.trajectory) and irregular timestamps."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm

from optinav import OptinavError
from optinav.core import earth, simulate as S, strapdown as SD
from optinav.core.rotations import (
    C_ENU_NED,
    dcm_from_euler,
    dcm_from_quat,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    rotvec_from_quat,
    skew,
)

EPS = np.finfo(float).eps
DEG = np.pi / 180
LAT = 45.0 * DEG
H = 100.0
ALGS = list(SD.CONING_ALGORITHMS)


def qerr(q, q_true):
    """Angle (rad) of q_true* ⊗ q, precise for tiny angles (atan2 form, not arccos)."""
    e = quat_multiply(quat_conjugate(q_true), q)
    return 2 * np.arctan2(np.linalg.norm(e[..., 1:], axis=-1), np.abs(e[..., 0]))


def psi(q, q_true):
    """Attitude error φ with C = (I − [φ×]) C_true, navigation axes: φ = −rotvec(q ⊗ q_true*)."""
    return -rotvec_from_quat(quat_multiply(q, quat_conjugate(q_true)))


# --- exact cases and invariants -----------------------------------------------------------------------


@pytest.mark.parametrize("coning", ALGS)
def test_fixed_axis_rotation_integrates_exactly(coning):
    # Rotation about a fixed body axis commutes with itself, so every cross product vanishes and the
    # composed rotation-vector quaternions are exact; a navigation-frame rate about a fixed axis is
    # likewise exact. Truth: q(−ω_n t) ⊗ q0 ⊗ q(ω_b t). Irregular steps exercise the per-sample dt.
    # Bound: one rounding (≈ eps) per product and renormalization per update, summed over ≤ 1000
    # updates: ≤ 1000 · 4 eps ≈ 1e-12.
    rng = np.random.default_rng(3)
    dt = rng.uniform(0.005, 0.015, 1000)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    ax_b = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    ax_n = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    w_b, w_n = 1.7, 0.05  # rad/s
    q0 = quat_from_rotvec([0.4, -0.3, 1.2])
    q = SD.attitude_update(q0, ax_b * w_b * dt[:, None], coning=coning, omega_in_n=ax_n * w_n, dt=dt)
    ti = t[SD.output_indices(dt.size, coning)]
    truth = quat_multiply(
        quat_multiply(quat_from_rotvec(-ax_n * w_n * ti[:, None]), q0), quat_from_rotvec(ax_b * w_b * ti[:, None])
    )
    assert q.shape == (ti.size, 4)
    assert np.max(qerr(q, truth)) < 1e-12
    assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1)) < 1e-14


def test_a_rate_per_sample_and_a_constant_one_share_one_compiled_kernel():
    """ω_in^n and dt given once or per sample (the same values) give the same attitude through one compiled
    signature of each kernel: the per-sample product was handed over read-only and compiled both kernels a second
    time (~1.2 s each)."""
    rng = np.random.default_rng(5)
    dth = rng.normal(0.0, 0.01, (200, 3))
    w = np.array([1e-4, -2e-4, 7e-5])
    kernels = (SD._attitude_single, SD._attitude_multi)
    for coning in ("previous", "two-sample"):
        once = SD.attitude_update([1, 0, 0, 0], dth, coning=coning, omega_in_n=w, dt=0.01)
        compiled = [set(k.signatures) for k in kernels]  # other tests of the process may have called them before
        each = SD.attitude_update(
            [1, 0, 0, 0], dth, coning=coning, omega_in_n=np.tile(w, (200, 1)), dt=np.full(200, 0.01)
        )
        assert np.max(qerr(once, each)) < 1e-14
        assert [set(k.signatures) for k in kernels] == compiled, "the per-sample form compiled a signature of its own"


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(ALGS), st.integers(1, 40), st.integers(0, 2**31 - 1))
def test_body_rotation_equivariance_and_final_only(coning, n, seed):
    # Every coning correction is built of sums and cross products, which commute with a rotation R of
    # the body axes: increments R Δθ from the initial attitude q0 ⊗ r* give q ⊗ r* exactly (to rounding:
    # ≤ 40 updates · ~10 eps). final_only returns the last row of the history.
    rng = np.random.default_rng(seed)
    dth = rng.normal(0, 0.05, (n, 3))
    q0 = quat_from_rotvec(rng.normal(0, 1, 3))
    r = quat_from_rotvec(rng.normal(0, 1, 3))
    q = SD.attitude_update(q0, dth, coning=coning)
    q2 = SD.attitude_update(quat_multiply(q0, quat_conjugate(r)), dth @ dcm_from_quat(r).T, coning=coning)
    assert np.max(qerr(q2, quat_multiply(q, quat_conjugate(r)))) < 400 * EPS
    np.testing.assert_array_equal(SD.attitude_update(q0, dth, coning=coning, final_only=True), q[-1])
    # rotation_increments (vectorized numpy) composes to the same attitude
    phi = SD.rotation_increments(dth, coning)
    qc = q0
    for p in phi:
        qc = quat_multiply(qc, quat_from_rotvec(p))
    assert qerr(q[-1], qc) < 400 * EPS


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 60), st.integers(0, 2**31 - 1))
def test_no_coning_reverses_exactly(n, seed):
    # With φ = Δθ each update is an exact rotation; replaying the negated increments backwards undoes it.
    rng = np.random.default_rng(seed)
    dth = rng.normal(0, 0.3, (n, 3))
    q0 = quat_from_rotvec(rng.normal(0, 1, 3))
    q1 = SD.attitude_update(q0, dth, coning="none", final_only=True)
    back = SD.attitude_update(q1, -dth[::-1], coning="none", final_only=True)
    assert qerr(back, q0) < 2 * n * 10 * EPS


def test_unequal_step_coefficient_is_exact_for_a_linear_rate():
    # ω(t) = a + b t: the exact rotation over each step follows from the Bortz series, whose terms beyond
    # ½∫α×ω are third order in the step (|α|²|ω|T ≈ 1e-9 rad with |ω|T ≤ 1e-3); the previous-sample
    # correction with the unequal-step coefficient reproduces ½∫α×ω = (h³/12) a×b exactly. Check the
    # correction term itself: φ_k − Δθ_k against (h_k³/12) a×b, to rounding.
    rng = np.random.default_rng(11)
    a, b = np.array([0.05, -0.02, 0.08]), np.array([0.3, 0.4, -0.1])
    h = rng.uniform(0.002, 0.02, 50)
    t = np.concatenate([[0.0], np.cumsum(h)])
    dth = a * h[:, None] + b * (t[1:] ** 2 - t[:-1] ** 2)[:, None] / 2
    phi = SD.rotation_increments(dth, "previous", dt=h)
    np.testing.assert_allclose(phi[1:] - dth[1:], (h[1:, None] ** 3 / 12) * np.cross(a, b), rtol=1e-9, atol=1e-22)
    # and the kernel applies the same coefficient
    qc = np.array([1.0, 0, 0, 0])
    for p in phi:
        qc = quat_multiply(qc, quat_from_rotvec(p))
    assert qerr(SD.attitude_update([1, 0, 0, 0], dth, dt=h, final_only=True), qc) < 200 * EPS


def test_output_indices_map_epochs():
    np.testing.assert_array_equal(SD.output_indices(7, "previous"), np.arange(8))
    np.testing.assert_array_equal(SD.output_indices(8, "two-sample"), [0, 2, 4, 6, 8])
    np.testing.assert_array_equal(SD.output_indices(7, "two-sample"), [0, 2, 4, 6, 7])
    np.testing.assert_array_equal(SD.output_indices(10, "four-sample"), [0, 4, 8, 10])


# --- coning ---------------------------------------------------------------------------------------------


def test_coning_drift_formula_leading_terms():
    # Leading-order coning drift of each algorithm, in units of Ω sin²α (λ = Ωh):
    # none λ²/12; one-sample+previous λ⁴/60; two-sample λ⁴/60 (Ignagni 1990: Ωα²(ΩT)⁴/960 with T = 2h);
    # three-sample λ⁶/280; four-sample λ⁸/1260. coning_drift_rate is exact in λ, so at small λ it must
    # reproduce these coefficients with relative error O(λ²).
    f, h, a = 1.0, 1e-3, 0.01
    lam, base = 2 * np.pi * f * h, 2 * np.pi * f * np.sin(a) ** 2
    lead = {
        "none": lam**2 / 12,
        "previous": lam**4 / 60,
        "two-sample": lam**4 / 60,
        "three-sample": lam**6 / 280,
        "four-sample": lam**8 / 1260,
    }
    for c, v in lead.items():
        assert SD.coning_drift_rate(c, a, f, h) / base == pytest.approx(-v, rel=20 * lam**2)


@pytest.mark.parametrize("coning", ALGS)
def test_coning_drift_against_analytic_coning(coning):
    # Classic coning (simulate.coning, closed-form truth), half-angle α, Ω = 2π·10 Hz, 100 Hz → λ = 0.63.
    # Theory (Ignagni 1990; coning_drift_rate): the algorithm's z-component (cone axis) per update is
    # Σ c Δθ_i×Δθ_j = 2 sin²α (1 − cos λ) Σ a_m sin mλ, the exact one is ½ sin²α (nλ − sin nλ); their
    # difference per update time is the drift D, seen as the growth of the navigation-frame z error.
    # What the first-order theory leaves out: the third-order Bortz term (1/12)∫α×(α×ω) and ½∫β×ω with
    # β = ½∫α×ω; with |α| ≤ sin α·Ωτ, ω_z = −Ω(1 − cos α) = −Ωv and |β_xy| ≤ v sin α (Ωτ)³/12 they are
    # bounded over an update of H = n h by Ω v sin²α [(ΩH)²/18 + (ΩH)³/96] per unit time. Mapping the
    # body-axis drift to navigation axes: the cone axis averages to cos α·z (a change ≤ v|D|), and the
    # transverse (body x, y) errors, which rectify into navigation z with a factor ≤ sin α. Those errors
    # are the algorithm's own x, y part — each cross product has |x,y| ≤ 2|Δθ_z||Δθ_xy| ≤ 2 v λ · sin α λ,
    # times C = Σ|c| — plus the omitted |β_xy|, giving ≤ Ω v sin²α [2Cλ/n + (ΩH)²/12]. All are order α⁴,
    # so a small α = 0.1° keeps the bound well below D even for the four-sample algorithm (≈ 16 %).
    alpha, f, rate = 0.1 * DEG, 10.0, 100.0
    tr = S.coning(alpha, f, 20.0, rate, frame="enu")
    q = SD.attitude_update(tr.q_b_n[0], tr.dtheta, coning=coning)
    idx = SD.output_indices(tr.dtheta.shape[0], coning)
    en = rotvec_from_quat(quat_multiply(q, quat_conjugate(tr.q_b_n[idx])))
    slope = np.polyfit(tr.t[idx], en, 1)[0]
    om, n = 2 * np.pi * f, SD.CONING_ALGORITHMS[coning]
    omH, v = om * n / rate, 1 - np.cos(alpha)
    drift = SD.coning_drift_rate(coning, alpha, f, 1 / rate)
    csum = {"none": 0.0, "previous": 1 / 12}.get(coning, float(np.sum(SD._CS[n])))
    lam = om / rate
    bound = om * v * np.sin(alpha) ** 2 * (omH**2 / 18 + omH**3 / 96 + 2 * csum * lam / n + omH**2 / 12) + v * abs(
        drift
    )
    assert bound < 0.2 * abs(drift)
    # the least-squares slope of rounding noise (≈ 1e-15 rad per update) over 20 s is < 1e-15 rad/s
    assert abs(slope[2] - drift) <= bound + 1e-14
    # no drift across the cone axis: the transverse errors oscillate; their fitted slope is bounded by
    # the same neglected terms
    assert np.all(np.abs(slope[:2]) <= bound + abs(drift) * 0.05 + 1e-14)
    if coning == "previous":
        d_none = SD.coning_drift_rate("none", alpha, f, 1 / rate)
        # "none" drifts at Ω sin²α λ²/12 against λ⁴/60: 5/λ² ≈ 13 times faster here
        assert abs(d_none) > 10 * abs(drift)


def test_no_coning_compensation_is_clearly_worse_on_coning():
    # First-order drift of summing rotation vectors without correction: ½ sin²α (λ − sin λ)/h ≈ Ω sin²α λ²/12.
    alpha, f, rate = 1.0 * DEG, 10.0, 100.0
    tr = S.coning(alpha, f, 10.0, rate, frame="enu")
    drifts = {}
    for c in ("none", "previous"):
        q = SD.attitude_update(tr.q_b_n[0], tr.dtheta, coning=c)
        drifts[c] = qerr(q[-1], tr.q_b_n[-1]) / tr.t[-1]
    lam = 2 * np.pi * f / rate
    expect = 0.5 * np.sin(alpha) ** 2 * (lam - np.sin(lam)) * rate
    assert drifts["none"] == pytest.approx(expect, rel=0.01)  # α⁴ and oscillation terms ≪ 1 %
    assert drifts["none"] > 10 * drifts["previous"]


# --- static navigation with Earth rate ------------------------------------------------------------------

C_STATIC = dcm_from_euler(np.radians([10.0, -5.0, 30.0]), "enu")
EPS_B = np.radians(np.array([0.01, -0.02, 0.015])) / 3600  # gyro bias, rad/s (0.01–0.02 °/h)
NAB_B = np.array([100.0, -50.0, 200.0]) * 1e-6 * 9.80665  # accelerometer bias, m/s² (50–200 μg)


@pytest.fixture(scope="module")
def static_hour():
    return S.static_positions(C_STATIC[None], 3600.0, 100.0, LAT, height_m=H, frame="enu")


def test_static_hour_error_free_stays_at_rounding_level(static_hour):
    tr = static_hour
    nav = SD.mechanize(tr.dtheta, tr.dv, tr.t, tr.q_b_n[0], tr.vel_n[0], tr.pos[0], vertical="hold", frame="enu")
    # On a static base the update is exact: q(−ω_ie T) ⊗ q ⊗ q(C_n^b ω_ie T) = q, and the rotation
    # compensation cancels the −½ζ×Δv term. Only rounding accumulates: ≤ 1 eps per update over
    # N = 3.6e5 updates, ≤ 2 N eps ≈ 8e-11 rad of tilt; through the Schuler loop a tilt φ gives at most
    # 2 g φ/ω_s in velocity (≈ 1.3e-6 m/s) and 2 g φ/ω_s² in position (≈ 1e-3 m).
    n = tr.dtheta.shape[0]
    ws = np.sqrt(earth.gravity(LAT, H) / earth.radii(LAT, H)[1])
    phi_max = 2 * n * EPS
    rm, rn = earth.radii(LAT, H)
    assert np.max(qerr(nav.q_b_n, tr.q_b_n)) < phi_max
    assert np.max(np.abs(nav.vel_n - tr.vel_n)) < 2 * 9.81 * phi_max / ws
    dp = (nav.pos - tr.pos) * [rm, rn * np.cos(LAT), 1]
    assert np.max(np.abs(dp)) < 2 * 9.81 * phi_max / ws**2
    np.testing.assert_array_equal(nav.pos[:, 2], H)
    np.testing.assert_array_equal(nav.t, tr.t)


def _error_model(lat, h, c_b_n, eps_b, nab_b):
    """Static-base linear INS error model, ENU, vertical held (Titterton & Weston §12.3; PSINS etm).

    States x = [φ_E, φ_N, φ_U, δv_E, δv_N, δL, δλ] with C = (I − [φ×]) C_true:
      φ̇  = −ω_ie×φ + δω_in − C ε,      δω_in = [−δv_N/R_M, δv_E/R_N + ... ] (below)
      δv̇ = f^n×φ − 2ω_ie×δv + C ∇,      f^n = [0, 0, g] (v = 0, so the v×δω terms vanish)
      δL̇ = δv_N/R_M,  δλ̇ = δv_E/(R_N cos L)
    Returns (A, u) of ẋ = A x + u.
    """
    w = earth.WGS84.omega_ie
    g = float(earth.gravity(lat, h))
    rm, rn = earth.radii(lat, h)
    w_ie = earth.earth_rate(lat, frame="enu")
    A = np.zeros((7, 7))
    A[0:3, 0:3] = -skew(w_ie)
    # δω_in = δω_ie + δω_en: δω_ie = [0, −ω sin L δL, ω cos L δL], δω_en = [−δv_N/R_M, δv_E/R_N, δv_E tan L/R_N]
    A[0:3, 3] = [0, 1 / rn, np.tan(lat) / rn]
    A[0:3, 4] = [-1 / rm, 0, 0]
    A[0:3, 5] = [0, -w * np.sin(lat), w * np.cos(lat)]
    A[3:5, 0:3] = skew([0, 0, g])[0:2]
    A[3:5, 3:5] = (-2 * skew(w_ie))[0:2, 0:2]
    A[5, 4] = 1 / rm
    A[6, 3] = 1 / (rn * np.cos(lat))
    u = np.zeros(7)
    u[0:3] = -c_b_n @ eps_b
    u[3:5] = (c_b_n @ nab_b)[0:2]
    return A, u


def test_static_hour_with_biases_follows_error_model(static_hour):
    tr = static_hour
    dt = tr.dt[:, None]
    nav = SD.mechanize(
        tr.dtheta + EPS_B * dt,
        tr.dv + NAB_B * dt,
        tr.t,
        tr.q_b_n[0],
        tr.vel_n[0],
        tr.pos[0],
        vertical="hold",
        frame="enu",
    )
    # The vertical channel is unstable (δḧ = 2g/R δh + ∇_U); it is held here (h = h0, v_U = 0) so the
    # horizontal Schuler/Foucault dynamics over the full hour can be compared with the linear model.
    A, u = _error_model(LAT, H, C_STATIC, EPS_B, NAB_B)
    M = np.zeros((8, 8))
    M[:7, :7], M[:7, 7] = A, u
    idx = np.arange(0, tr.t.size, 6000)  # every minute
    pred = np.array([expm(M * tk)[:7, 7] for tk in tr.t[idx]])
    meas = np.column_stack(
        [psi(nav.q_b_n[idx], tr.q_b_n[idx]), (nav.vel_n - tr.vel_n)[idx, :2], (nav.pos - tr.pos)[idx, :2]]
    )
    # The model drops products of error states (φ×Cε, (1 − cos φ) terms of the attitude error, δL² in
    # δω_ie), each relative to its linear term of order max|φ| + max|δL|; with a constant of order one
    # (3 for margin) the tolerance on every state is 3 (max|φ| + max|δL|) · its peak. Discretization
    # (100 Hz, second order) contributes ~(ω T)² ≪ 1e-6 relative.
    rel = 3 * (np.abs(pred[:, :3]).max() + np.abs(pred[:, 5]).max())
    assert rel < 3e-3
    peak = np.abs(pred).max(axis=0)
    assert np.all(np.abs(meas - pred).max(axis=0) <= rel * peak)
    # sanity of scale: the errors are far above the error-free rounding level
    assert peak[3] > 1.0 and peak[5] > 1e-4


def test_static_short_time_growth_law(static_hour):
    # Over the first minute, integrating the error model once in t with Schuler feedback to first order:
    #   φ = −ε_n t + [−∇_N, ∇_E, ∇_E tan L]/R · t²/2,
    #   δv_E = ∇_E t + g ε_N t²/2 − g ∇_E t³/(6 R_N),   δv_N = ∇_N t − g ε_E t²/2 − g ∇_N t³/(6 R_M),
    #   δL = (∇_N t²/2 − g ε_E t³/6)/R_M.
    # Left out: Earth-rate couplings (−ω_ie×φ, −2ω_ie×δv), relative ≤ 2 ω_ie t = 8.8e-3 at 60 s, and the
    # next Schuler terms, relative ≤ (ω_s t)²/12 = 4.6e-4. Tolerance: (2 ω_ie t + (ω_s t)²/12) · |pred|.
    tr = static_hour
    k = 6000
    sl = slice(0, k + 1)
    dt = tr.dt[:k, None]
    nav = SD.mechanize(
        tr.dtheta[:k] + EPS_B * dt,
        tr.dv[:k] + NAB_B * dt,
        tr.t[sl],
        tr.q_b_n[0],
        tr.vel_n[0],
        tr.pos[0],
        vertical="hold",
        frame="enu",
    )
    t = tr.t[k]
    g = float(earth.gravity(LAT, H))
    rm, rn = earth.radii(LAT, H)
    e, a = C_STATIC @ EPS_B, C_STATIC @ NAB_B
    phi = -e * t + np.array([-a[1] / rm, a[0] / rn, a[0] * np.tan(LAT) / rn]) * t**2 / 2
    dv = np.array(
        [
            a[0] * t + g * e[1] * t**2 / 2 - g * a[0] * t**3 / (6 * rn),
            a[1] * t - g * e[0] * t**2 / 2 - g * a[1] * t**3 / (6 * rm),
        ]
    )
    dlat = (a[1] * t**2 / 2 - g * e[0] * t**3 / 6) / rm
    ws2 = g / rn
    rel = 2 * earth.WGS84.omega_ie * t + ws2 * t**2 / 12
    assert np.linalg.norm(psi(nav.q_b_n[-1], tr.q_b_n[k]) - phi) <= rel * np.linalg.norm(phi)
    assert np.linalg.norm((nav.vel_n[-1] - tr.vel_n[k])[:2] - dv) <= rel * np.linalg.norm(dv)
    assert abs(nav.pos[-1, 0] - tr.pos[k, 0] - dlat) <= rel * abs(dlat)


def test_free_vertical_channel_diverges_as_cosh(static_hour):
    # Vertical accelerometer bias b only (∇^b = C_n^b [0, 0, b]): δḧ = b + k δh with k = −∂g/∂h
    # (free-air gradient, from earth.gravity), so δh = (b/k)(cosh √k t − 1), δv_U = (b/√k) sinh √k t —
    # the instability that forces vertical aiding (T&W §3.5). Left out: Coriolis coupling through δv_E,
    # relative ≤ (2 ω_ie t)²/2 = 3.8e-3 at 600 s, and the h² gravity term, relative 1.5 δh/a ≈ 5e-5.
    tr = static_hour
    k = 60000  # 600 s
    b = 1e-3
    nab = C_STATIC.T @ np.array([0.0, 0.0, b])
    nav = SD.mechanize(
        tr.dtheta[:k],
        tr.dv[:k] + nab * tr.dt[:k, None],
        tr.t[: k + 1],
        tr.q_b_n[0],
        tr.vel_n[0],
        tr.pos[0],
        vertical="free",
        frame="enu",
    )
    kg = -(earth.gravity(LAT, H + 1.0) - earth.gravity(LAT, H - 1.0)) / 2.0
    t = tr.t[: k + 1]
    dh = b / kg * (np.cosh(np.sqrt(kg) * t) - 1)
    dvu = b / np.sqrt(kg) * np.sinh(np.sqrt(kg) * t)
    rel = (2 * earth.WGS84.omega_ie * t[-1]) ** 2 / 2 + 1e-4
    assert np.max(np.abs(nav.pos[:, 2] - H - dh)) <= rel * dh[-1]
    assert np.max(np.abs(nav.vel_n[:, 2] - dvu)) <= rel * dvu[-1]
    # faster than the ½bt² of a stable channel: 2(cosh x − 1)/x² = 1.09 at x = √k t = 1.05
    assert dh[-1] > 1.08 * b * t[-1] ** 2 / 2


@pytest.mark.parametrize("earth_name", ["wgs84", "psins"])
def test_static_ned_and_psins_error_free(earth_name):
    # NED frame and the PSINS constant set through the same exact static case (bounds as above, N = 6000).
    c = dcm_from_euler(np.radians([3.0, 4.0, -120.0]), "ned")
    tr = S.static_positions(c[None], 60.0, 100.0, -0.6, height_m=20.0, lon=1.0, frame="ned", earth=earth_name)
    nav = SD.mechanize(
        tr.dtheta, tr.dv, tr.t, dcm_from_quat(tr.q_b_n[0]), tr.vel_n[0], tr.pos[0], frame="ned", earth=earth_name
    )
    n = tr.dtheta.shape[0]
    assert np.max(qerr(nav.q_b_n, tr.q_b_n)) < 2 * n * EPS
    # free vertical over 60 s: velocity rounding ≤ N eps g T-ish ≈ 1e-9 m/s, height ≤ that × 60 s
    assert np.max(np.abs(nav.vel_n - tr.vel_n)) < 1e-9
    assert np.max(np.abs(nav.pos[:, 2] - tr.pos[:, 2])) < 1e-7
    assert nav.frame == "ned" and nav.earth == earth_name


def test_gravity_kernel_equals_earth_module():
    # the numba kernel carries its own copy of the normal-gravity formulas; they must equal core.earth's
    lat = np.linspace(-1.5, 1.5, 31)
    for name in ("wgs84", "psins"):
        ep = SD._earth_params(earth.constants(name))
        for h in (-100.0, 0.0, 3000.0):
            got = np.array([SD._gravity(np.sin(x) ** 2, h, ep) for x in lat])
            np.testing.assert_allclose(got, earth.gravity(lat, h, name), rtol=4 * EPS, atol=0)


# --- moving base, irregular timestamps, frames ------------------------------------------------------


def _trajectory(rate=None, t=None, frame="enu"):
    tk = np.arange(0, 61, 10.0)
    eul = np.radians(np.column_stack([[0, 5, -5, 3, -4, 2, 0], [0, 2, -3, 1, 0, -2, 0], [0, 20, 60, 90, 60, 30, 0]]))
    pk = np.array(
        [[0, 0, 0], [30, 100, 1], [120, 180, 3], [250, 200, 2], [350, 150, 0], [420, 60, -1], [450, 0, 0]], float
    )
    return S.trajectory(tk, dcm_from_euler(eul, "enu"), pk, rate, frame, lat0=30 * DEG, height0_m=50.0, t=t)


def _nav_errors(tr, **kw):
    nav = SD.mechanize(tr.dtheta, tr.dv, tr.t, tr.q_b_n[0], tr.vel_n[0], tr.pos[0], frame=tr.frame, **kw)
    i = nav.index
    rm, rn = earth.radii(tr.pos[0, 0], tr.pos[0, 2])
    dp = (nav.pos - tr.pos[i]) * [rm, rn * np.cos(tr.pos[0, 0]), 1]
    return (np.max(qerr(nav.q_b_n, tr.q_b_n[i])), np.max(np.abs(nav.vel_n - tr.vel_n[i])), np.max(np.abs(dp)))


@pytest.fixture(scope="module")
def traj50():
    return _trajectory(50.0)


@pytest.fixture(scope="module")
def traj100():
    return _trajectory(100.0)


def _truncation_caps(tr, n=1, coning="previous"):
    """Crude global truncation-error caps from the truth motion, update interval T = n·max dt, duration t.

    Attitude: the per-update noncommutativity ½∫α×ω ≈ (T³/12) ω×ω̇ that "none" omits, summed over t/T updates
    (triangle inequality): T² t max|ω×ω̇|/12, ×1.5 for the O(T⁴) remainder and the finite-difference ω̇;
    the compensated algorithms are at least one order better, so they get the same cap times T·max|ω|.
    Velocity: the second-order update leaves per-step errors of order (T³/12)(|ȧ| + |ω||a| + |ω̇||a|),
    summed: T² t (...)/12; position adds the trapezoid error T² t |ȧ|/12 integrated once more (× t).
    These are order-of-magnitude caps; the sharp test is the convergence ratio.
    """
    T = n * float(np.max(tr.dt))
    t = float(tr.t[-1] - tr.t[0])
    dt = tr.dt[:, None]
    a = np.diff(tr.vel_n, axis=0) / dt
    jerk = np.linalg.norm(np.diff(a, axis=0) / dt[1:], axis=1).max()
    w = tr.gyr
    wd = np.diff(w, axis=0) / dt
    wn, an, wdn = (np.linalg.norm(x, axis=1).max() for x in (w, a, wd))
    att = 1.5 * T**2 * t * np.linalg.norm(np.cross(w[:-1], wd), axis=1).max() / 12
    if coning != "none":
        att *= T * wn
    vel = T**2 * t * (jerk + wn * an + wdn * an) / 12
    return att, vel, vel * t + T**2 * t**2 * jerk / 12


def test_moving_base_converges_at_second_order(traj50, traj100):
    # A car-like 60 s drive (≤ 14 m/s, ≤ 1.2 m/s², ≤ 5 °/s, turns, pitch/roll changes). The velocity and
    # position updates are second order in T (trapezoidal position, mid-interval Earth terms, sculling),
    # so halving T divides their errors by 4 (ratio in [3, 5] allows the O(T³) remainder); the attitude
    # error of the one-sample+previous algorithm falls at least as fast (it is third order).
    e50, e100 = _nav_errors(traj50), _nav_errors(traj100)
    assert np.all(np.array(e100) < _truncation_caps(traj100))
    assert e50[0] / e100[0] > 3.0
    assert 3.0 < e50[1] / e100[1] < 5.0
    assert 3.0 < e50[2] / e100[2] < 5.0


@pytest.mark.parametrize("coning", ["none", "two-sample", "four-sample"])
@pytest.mark.parametrize("sculling", [True, False])
def test_moving_base_other_algorithms(traj100, coning, sculling):
    # Same drive at 100 Hz; an n-sample algorithm updates every n·T, so its caps use T → n T.
    errs = _nav_errors(traj100, coning=coning, sculling=sculling)
    caps = _truncation_caps(traj100, SD.CONING_ALGORITHMS[coning], coning)
    assert np.all(np.array(errs) < caps)


def test_irregular_timestamps_match_regular(traj100):
    # Irregular steps uniform in [5, 15] ms (mean 10 ms, rms 10.4 ms) on the same drive: the
    # discretization error scales with T² (velocity, position) and T³ (attitude, with the unequal-step
    # coefficient of the previous-sample correction), so it must be within (15/10)² = 2.25 of the
    # regular 100 Hz error (3.4 for the attitude's T³); exact truth comes from simulate at the epochs.
    rng = np.random.default_rng(7)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.005, 0.015, 6100))])
    tr = _trajectory(t=t[t <= 60.0])
    e_irr, e_reg = _nav_errors(tr), _nav_errors(traj100)
    assert e_irr[0] <= 3.4 * e_reg[0]
    assert e_irr[1] <= 2.25 * e_reg[1]
    assert e_irr[2] <= 2.25 * e_reg[2]

    # attitude_update alone with per-sample dt and ω_in^n per sample (ω_ie + ω_en from core.earth at the
    # truth states, averaged over each step: trapezoid error ~ T³ ω̈_in N ≈ 1e-13 rad): same error laws.
    def att_only(trj):
        w_in = earth.earth_rate(trj.pos[:, 0], frame="enu") + earth.transport_rate(
            trj.pos[:, 0], trj.pos[:, 2], trj.vel_n, frame="enu"
        )
        q = SD.attitude_update(trj.q_b_n[0], trj.dtheta, omega_in_n=0.5 * (w_in[1:] + w_in[:-1]), dt=trj.dt)
        return np.max(qerr(q, trj.q_b_n))

    d_irr, d_reg = att_only(tr), att_only(traj100)
    assert d_reg < 1e-9
    assert d_irr <= 3.4 * d_reg


def test_ned_equals_enu_on_the_same_motion(traj100):
    # The mechanization is one physical computation: the NED run of the ENU drive, with the initial state
    # rotated by C_ENU^NED, must give the rotated ENU run to rounding.
    tr = traj100
    q_enu = tr.q_b_n[0]
    q_ned = quat_multiply(SD._Q_NED_TO_ENU * [1, -1, -1, -1], q_enu)
    a = SD.mechanize(tr.dtheta, tr.dv, tr.t, q_enu, tr.vel_n[0], tr.pos[0], frame="enu")
    b = SD.mechanize(tr.dtheta, tr.dv, tr.t, q_ned, C_ENU_NED @ tr.vel_n[0], tr.pos[0], frame="ned")
    np.testing.assert_allclose(dcm_from_quat(b.q_b_n), C_ENU_NED @ dcm_from_quat(a.q_b_n), atol=1e-13)
    np.testing.assert_allclose(b.vel_n, a.vel_n @ C_ENU_NED.T, atol=1e-11)
    np.testing.assert_allclose(b.pos, a.pos, rtol=0, atol=1e-12)


def test_nav_solution_json_round_trip(traj50):
    tr = traj50
    nav = SD.mechanize(
        tr.dtheta[:20], tr.dv[:20], tr.t[:21], tr.q_b_n[0], tr.vel_n[0], tr.pos[0], coning="two-sample", frame="enu"
    )
    back = SD.NavSolution.from_json(nav.to_json())
    np.testing.assert_array_equal(back.q_b_n, nav.q_b_n)
    np.testing.assert_array_equal(back.index, [0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20])
    assert back.units()["vel_n"] == "m/s" and back.coning == "two-sample"


# --- bad input ------------------------------------------------------------------------------------------

_D = np.zeros((10, 3))
_T = np.arange(11) * 0.01
_P = [0.5, 0.1, 0.0]


@pytest.mark.parametrize(
    "call",
    [
        lambda: SD.attitude_update([1, 0, 0], _D),
        lambda: SD.attitude_update([2, 0, 0, 0], _D),
        lambda: SD.attitude_update(np.ones((3, 3)), _D),
        lambda: SD.attitude_update([1, 0, 0, 0], np.zeros((10, 2))),
        lambda: SD.attitude_update([1, 0, 0, 0], np.zeros((0, 3))),
        lambda: SD.attitude_update([1, 0, 0, 0], np.full((4, 3), np.nan)),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, coning="five-sample"),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, omega_in_n=[0, 0, 1e-5]),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, omega_in_n=[0, 0, 1e-5], dt=np.ones(9)),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, omega_in_n=[0, 0, 1e-5], dt=-0.01),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, omega_in_n=np.zeros((9, 3)), dt=0.01),
        lambda: SD.attitude_update([1, 0, 0, 0], _D, dt="fast"),
        lambda: SD.mechanize(_D, np.zeros((9, 3)), _T, [1, 0, 0, 0], [0, 0, 0], _P),
        lambda: SD.mechanize(_D, _D, _T[:-1], [1, 0, 0, 0], [0, 0, 0], _P),
        lambda: SD.mechanize(_D, _D, _T[::-1], [1, 0, 0, 0], [0, 0, 0], _P),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0], _P),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0, 0], [np.pi / 2, 0, 0]),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0, 0], _P, frame="ecef"),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0, 0], _P, earth="mars"),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0, 0], _P, vertical="damped"),
        lambda: SD.mechanize(_D, _D, _T, [1, 0, 0, 0], [0, 0, 0], _P, coning="cubic"),
        lambda: SD.output_indices(0),
        lambda: SD.rotation_increments(np.zeros(3)),
        lambda: SD.rotation_increments(_D, dt=np.ones(3)),
        lambda: SD.coning_drift_rate("bad", 0.1, 1.0, 0.01),
    ],
)
def test_bad_input_raises_optinav_error(call):
    with pytest.raises(OptinavError):
        call()


@pytest.mark.parametrize("coning", ["previous", "none"])
def test_attitude_stream_blocks_are_the_whole_call_bit_for_bit(coning):
    """The quaternion and the coning state (last increment and its interval) carried across blocks of odd lengths,
    irregular steps and an Earth-rate navigation frame: the whole call's attitudes exactly."""
    rng = np.random.default_rng(4)
    n = 2000
    dth = rng.normal(0, 1e-3, (n, 3))
    dt = 0.005 + rng.uniform(0, 1e-4, n)
    w = np.array([0.0, 6.4e-5, 3.4e-5])
    q0 = np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2])
    ref = SD.attitude_update(q0, dth, coning=coning, omega_in_n=w, dt=dt)
    s = SD.AttitudeStream(q0, coning=coning, omega_in_n=w)
    parts = [s.update(dth[:0], dt[:0])]
    for a, b in ((0, 37), (37, 38), (38, 1000), (1000, n)):
        parts.append(s.update(dth[a:b], dt[a:b])[1:])
    np.testing.assert_array_equal(np.concatenate(parts), ref)
    # without the carried state (a fresh start per block) the coning term of each block's first sample is lost
    fresh = SD.AttitudeStream(ref[1000], coning=coning, omega_in_n=w).update(dth[1000:], dt[1000:])
    assert (np.abs(fresh[-1] - ref[-1]).max() > 0) == (coning == "previous")
    with pytest.raises(OptinavError, match="sample by sample"):
        SD.AttitudeStream(q0, coning="two-sample")
