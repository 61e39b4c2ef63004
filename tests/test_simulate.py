"""Motion simulation against truth: analytic specific force and rate, closed-form coning, independent ODE
integration, independent quadrature. Tolerances are rounding levels: every quantity is analytic."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad, solve_ivp

from optinav import OptinavError
from optinav.core import earth, simulate as S
from optinav.core.results import Result
from optinav.core.rotations import (
    unit_axis,
    dcm_from_euler,
    dcm_from_quat,
    dcm_from_rotvec,
    quat_angle_between,
    quat_multiply,
    rot_axis,
    rot_x,
    rot_y,
    rot_z,
    rotation_angle,
    rotvec_from_dcm,
)

# the reference quadratures ask for tolerances at the rounding level; QUADPACK warns when it reaches it
pytestmark = pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")

LAT = np.radians(39.9)
DEG = np.pi / 180


def body(v_n, c_b_n):
    """C_n^b v^n for stacks."""
    return np.einsum("mji,...j->mi", c_b_n, v_n) if np.ndim(v_n) == 1 else np.einsum("mji,mj->mi", c_b_n, v_n)


# --- static -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("frame", ["enu", "ned"])
@pytest.mark.parametrize("earth_name", ["wgs84", "psins"])
def test_static_six_positions_truth(frame, earth_name):
    h = 250.0
    tr = S.static_positions(
        S.six_positions(frame), 5.0, 50.0, LAT, height_m=h, frame=frame, earth=earth_name, transition=2.0
    )
    c = tr.C_b_n
    rest = tr.labels >= 0
    g_n = earth.gravity_vector(LAT, h, frame, earth_name)
    w_ie = earth.earth_rate(LAT, frame, earth_name)
    # at rest v = a = 0, so f^b = C_n^b(−g^n) and ω_ib^b = C_n^b ω_ie^n (mechanization with v = 0)
    np.testing.assert_allclose(tr.acc[rest], body(-g_n, c)[rest], rtol=0, atol=1e-13)
    np.testing.assert_allclose(
        np.linalg.norm(tr.acc, axis=1), earth.gravity(LAT, h, earth_name), rtol=1e-15, atol=4e-15
    )
    np.testing.assert_allclose(tr.gyr[rest], body(w_ie, c)[rest], rtol=0, atol=1e-19)
    # intervals with both ends in one rest: constant integrand, so the increment is value × dt
    both = (tr.labels[:-1] == tr.labels[1:]) & rest[:-1]
    np.testing.assert_allclose(tr.dtheta[both], tr.gyr[:-1][both] * tr.dt[both, None], rtol=0, atol=1e-21)
    np.testing.assert_allclose(tr.dv[both], tr.acc[:-1][both] * tr.dt[both, None], rtol=0, atol=1e-15)
    # each pose is held exactly, and names read as a technician expects
    for p in range(6):
        np.testing.assert_allclose(c[tr.segment(p)] - S.six_positions(frame)[p], 0, atol=1e-15)
    assert tr.segment_names == [
        "x up, y north",
        "x down, y north",
        "y up, z north",
        "y down, z north",
        "z up, y north",
        "z down, y north",
    ]
    # the accelerometer reads +g along the body axis that points up
    up = tr.acc[tr.segment(0)]
    assert np.all(up[:, 0] > 9.79)


def test_static_frames_describe_the_same_motion():
    kw = dict(dwell=[3.0, 4.0, 2.0], rate_hz=20.0, lat=LAT, transition=[1.5, 2.5])
    cs_enu = np.stack(
        [
            dcm_from_euler([0.1, -0.2, 0.3], "enu"),
            S.orientation_from_up("-x", frame="enu"),
            S.orientation_from_up("y", "-x", frame="enu"),
        ]
    )
    cs_ned = np.stack([np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1.0]]) @ c for c in cs_enu])
    a = S.static_positions(cs_enu, frame="enu", **kw)
    b = S.static_positions(cs_ned, frame="ned", **kw)
    # body quantities do not depend on the navigation frame the attitude is written in
    for name in ("gyr", "acc", "dtheta", "dv"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert a.segment_names == b.segment_names


def test_static_transition_is_smooth_and_lands_exactly():
    c0 = S.orientation_from_up("z", frame="enu")
    c1 = S.orientation_from_up("x", frame="enu") @ rot_x(0.3)
    tr = S.static_positions([c0, c1], [2.0, 2.0], 200.0, LAT, earth="none", transition=3.0, frame="enu")
    moving = np.flatnonzero(tr.labels == -1)
    w = tr.gyr
    # rate profile starts and ends at zero: the epochs around the transition have a small rate
    assert np.linalg.norm(w[moving[0]]) < 1e-3 and np.linalg.norm(w[moving[-1]]) < 1e-3
    assert np.max(np.linalg.norm(w, axis=1)) > 0.5
    # the rotation is about a single body axis (shortest arc): all rates parallel to the rotation vector
    rv = rotvec_from_dcm(c0.T @ c1)
    axis = rv / np.linalg.norm(rv)
    np.testing.assert_allclose(np.cross(w[moving], axis), 0, atol=1e-14)
    # Earth-free: the increments over the transition sum to the rotation vector (closed form)
    np.testing.assert_allclose(tr.dtheta.sum(0), rv, atol=1e-14)
    np.testing.assert_allclose(tr.C_b_n[tr.segment(1)] - c1, 0, atol=2e-15)


def test_orientation_from_up_and_describe():
    for frame in ("enu", "ned"):
        up_n = np.array([0, 0, 1.0]) if frame == "enu" else np.array([0, 0, -1.0])
        north_n = np.array([0, 1.0, 0]) if frame == "enu" else np.array([1.0, 0, 0])
        for up, north in [("x", "y"), ("-y", "x"), ("z", "-x"), ([0, 0, -1], [1, 0, 0])]:
            c = S.orientation_from_up(up, north, frame)
            np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-15)
            assert np.linalg.det(c) == pytest.approx(1.0)
            np.testing.assert_allclose(c @ unit_axis(up), up_n, atol=1e-15)
            np.testing.assert_allclose(c @ unit_axis(north), north_n, atol=1e-15)
    c = S.orientation_from_up("z", frame="enu") @ rot_y(np.radians(30))
    assert S.describe_pose(c, frame="enu") == "z up, tilted 30° about y, y north"
    assert S.describe_pose(S.orientation_from_up("-y", "x", frame="enu"), frame="enu") == "y down, x north"
    # turning the level pose 90° counter-clockwise (seen from above) about z brings x to north
    assert (
        S.describe_pose(S.orientation_from_up("z", frame="enu") @ rot_z(np.radians(90)), frame="enu") == "z up, x north"
    )
    assert (
        S.describe_pose(S.orientation_from_up("z", frame="enu") @ rot_z(np.radians(30)), frame="enu")
        == "z up, y at azimuth 330.00°"
    )
    with pytest.raises(OptinavError):
        S.orientation_from_up("x", "x", frame="enu")


@settings(max_examples=30, deadline=None)
@given(st.floats(-3, 3), st.floats(-1.5, 1.5), st.floats(-3, 3), st.floats(-1.5, 1.5), st.floats(-500, 5000))
def test_static_gravity_norm_any_pose(roll, pitch, yaw, lat, h):
    # |f| = normal gravity and f·(C_n^b up) = g in any pose at any site (f^b = C_n^b(−g^n), C orthogonal)
    c = dcm_from_euler([roll, pitch, yaw], "ned")
    tr = S.static_positions(c, 1.0, 4.0, lat, height_m=h, frame="ned")
    g = earth.gravity(lat, h)
    np.testing.assert_allclose(np.linalg.norm(tr.acc, axis=1), g, rtol=2e-16 * 8)
    np.testing.assert_allclose(tr.acc @ (c.T @ [0, 0, -1.0]), g, rtol=1e-15)


# --- coning -------------------------------------------------------------------------------------------------

BETA, FREQ = np.radians(2.0), 3.0


def test_coning_attitude_integrates_the_rate():
    # independent check: integrate q̇ = ½ q ⊗ [0, ω(t)] with a high-order RK at tight tolerance
    dur = 2.0 / FREQ
    tr = S.coning(BETA, FREQ, dur, 200.0, phase=0.4, frame="enu")
    q0 = tr.q_b_n[0]

    def rhs(t, q):
        w = S.coning_rate(BETA, FREQ, t, 0.4)
        return 0.5 * quat_multiply(q, np.concatenate([[0.0], w]))

    sol = solve_ivp(rhs, (0, dur), q0, method="DOP853", t_eval=tr.t, rtol=1e-13, atol=1e-14)
    err = quat_angle_between(sol.y.T, tr.q_b_n)
    assert np.max(err) < 1e-11  # ODE tolerance level; the closed form itself is exact
    # the rate stored in the truth is the rate of the closed-form attitude
    np.testing.assert_allclose(tr.gyr, S.coning_rate(BETA, FREQ, tr.t, 0.4), atol=1e-15)


def test_coning_increments_equal_quadrature_of_rate():
    tr = S.coning(BETA, FREQ, 1.0, 50.0, frame="enu")
    # closed-form Δθ against adaptive quadrature of ω(t), component by component
    for k in [0, 7, 33, 49]:
        for i in range(3):
            val, _ = quad(lambda t: S.coning_rate(BETA, FREQ, t)[i], tr.t[k], tr.t[k + 1], epsabs=1e-16, epsrel=1e-14)
            assert abs(tr.dtheta[k, i] - val) < 1e-14
    # inertial case without gravity: zero specific force
    assert np.all(tr.acc == 0) and np.all(tr.dv == 0)
    # the body z axis sweeps a cone of half-angle β about the reference z axis
    z_n = tr.C_b_n[:, :, 2]
    np.testing.assert_allclose(np.arccos(np.clip(z_n[:, 2], -1, 1)), BETA, atol=1e-7)  # arccos ~ 1e-8 precision
    np.testing.assert_allclose(np.linalg.norm(z_n[:, :2], axis=1), np.sin(BETA), atol=1e-15)


@pytest.mark.parametrize("h_frac", [1.0, 0.1, 0.37])
def test_coning_noncommutativity_closed_form(h_frac):
    # ½∫α×ω over [t0, t0 + h]: integrate the augmented ODE α̇ = ω, ċ = ½ α × ω independently
    t0, h = 0.123, h_frac / FREQ
    beta = np.radians(10.0)

    def rhs(t, y):
        w = S.coning_rate(beta, FREQ, t, 0.2)
        return np.concatenate([w, 0.5 * np.cross(y[:3], w)])

    sol = solve_ivp(rhs, (t0, t0 + h), np.zeros(6), method="DOP853", rtol=1e-13, atol=1e-16)
    closed = S.coning_noncommutativity(beta, FREQ, t0, t0 + h, 0.2)
    np.testing.assert_allclose(sol.y[3:, -1], closed, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(sol.y[:3, -1], S.coning_increment(beta, FREQ, t0, t0 + h, 0.2), atol=1e-13)
    if h_frac == 1.0:
        # over one cone period the z term is the classic coning drift π sin²β (Savage §7.1.1)
        assert closed[2] == pytest.approx(np.pi * np.sin(beta) ** 2, rel=1e-14)


def test_coning_with_earth_rate_and_gravity():
    c0 = dcm_from_euler([0.2, -0.1, 1.0], "enu")
    tr = S.coning(BETA, FREQ, 1.0, 100.0, earth="wgs84", lat=LAT, height_m=100.0, initial=c0, frame="enu")
    ref = S.coning(BETA, FREQ, 1.0, 100.0, initial=c0, frame="enu")
    c = tr.C_b_n
    np.testing.assert_allclose(c, ref.C_b_n, atol=1e-15)
    # static base: ω_ib = ω_cone + C_n^b ω_ie, f = C_n^b(−g)
    w_ie = earth.earth_rate(LAT, frame="enu")
    np.testing.assert_allclose(tr.gyr - ref.gyr, body(w_ie, c), atol=1e-19)
    np.testing.assert_allclose(tr.acc, body(-earth.gravity_vector(LAT, 100.0, frame="enu"), c), atol=1e-14)
    # increments of the Earth-rate and gravity parts against adaptive quadrature on a few intervals
    for k in [0, 42, 99]:

        def integrand(t, i, vec):
            c_t = c0 @ dcm_from_quat(S.coning_attitude(BETA, FREQ, t))  # C_b^n = C_0 C_cone(t)
            return (c_t.T @ vec)[i]

        for i in range(3):
            e_w, _ = quad(integrand, tr.t[k], tr.t[k + 1], args=(i, w_ie), epsabs=1e-22, epsrel=1e-13)
            e_f, _ = quad(
                integrand,
                tr.t[k],
                tr.t[k + 1],
                args=(i, -earth.gravity_vector(LAT, 100.0, frame="enu")),
                epsabs=1e-16,
                epsrel=1e-14,
            )
            # the difference of two ~6e-4 rad increments carries ~1e-19 rad of rounding
            assert abs(tr.dtheta[k, i] - ref.dtheta[k, i] - e_w) < 5e-19
            assert abs(tr.dv[k, i] - e_f) < 1e-14


# --- turntable ------------------------------------------------------------------------------------------


def cosine_theta(tau, T, A):
    """Independent copy of the raised-cosine profile: θ̇ = (A/T)(1 − cos 2πτ/T) integrated from 0."""
    return A * (tau / T - np.sin(2 * np.pi * tau / T) / (2 * np.pi))


C0 = dcm_from_euler([0.1, 0.2, 0.3], "enu")
SCHEDULE = [
    S.Rest(2.0),
    S.Rotate("z", 90 * DEG, 3.0),
    S.Rest(1.0),
    S.Rotate("x", -180 * DEG, 4.0, frame="nav", profile="trapezoid", accel_time=1.0),
    S.Rest(1.0),
    S.Rotate([1, 1, 0], 30 * DEG, 2.0, profile="quintic"),
    S.Rest(0.5),
]


def test_turntable_attitudes_and_earth_free_angles():
    tr = S.turntable(SCHEDULE, 50.0, LAT, initial=C0, earth="none", frame="enu")
    c = tr.C_b_n
    c2 = C0 @ rot_z(90 * DEG)  # body-axis rotation: C = C_0 R(θ)
    c4 = rot_x(-180 * DEG) @ c2  # nav-axis rotation: C = R(θ) C_0
    c6 = c4 @ rot_axis(np.array([1, 1, 0]) / np.sqrt(2), 30 * DEG)
    for lab, ref in [(0, C0), (2, c2), (4, c4), (6, c6)]:
        np.testing.assert_allclose(c[tr.segment(lab)] - ref, 0, atol=1e-12)
    # with ω_ie = 0 the body rate is θ̇ about a body-fixed axis, so Σ Δθ over the move is angle × axis
    for lab, axis in [
        (1, [0, 0, 90 * DEG]),
        (3, c2.T @ [-180 * DEG, 0, 0]),
        (5, np.array([1, 1, 0]) / np.sqrt(2) * 30 * DEG),
    ]:
        k0, k1 = tr.segment(lab)[[0, -1]]
        np.testing.assert_allclose(tr.dtheta[k0 - 1 : k1 + 1].sum(0), axis, atol=1e-14)
    assert tr.segment_names[1] == "rotate +90° about z_b" and tr.segment_names[3] == "rotate -180° about x_n"
    assert tr.segment_names[5] == "rotate +30° about [0.707, 0.707, 0.000]_b"
    # rates: zero at rest, peak 2A/T for the cosine, A/(T − T_a) for the trapezoid plateau
    assert np.all(tr.gyr[tr.segment(0)] == 0)
    assert np.max(np.abs(tr.gyr[tr.segment(1), 2])) == pytest.approx(2 * 90 * DEG / 3.0, rel=1e-12)
    plateau = tr.segment(3)[(tr.t[tr.segment(3)] > 2 + 3 + 1 + 1.0) & (tr.t[tr.segment(3)] < 2 + 3 + 1 + 3.0)]
    np.testing.assert_allclose(np.linalg.norm(tr.gyr[plateau], axis=1), np.pi / 3.0, rtol=1e-14)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1),
    st.floats(-7, 7).filter(lambda a: abs(a) > 1e-3),
    st.floats(0.2, 5.0),
    st.sampled_from(S._PROFILES),
    st.sampled_from(["body", "nav"]),
    st.floats(3.0, 60.0),
)
def test_turntable_any_rotation(axis, angle, duration, profile, frame, rate):
    # Earth-free rotation about a fixed axis: the end attitude is C_0 R(angle) (body) or R(angle) C_0 (nav) and the
    # increments over the move sum to angle × (body axis), whatever the profile and the sampling
    sched = [S.Rest(0.3), S.Rotate(axis, angle, duration, frame=frame, profile=profile), S.Rest(0.3)]
    total = 0.6 + duration
    t = np.linspace(0.0, total, int(total * rate) + 2)  # irregular w.r.t. the schedule, ends with it
    tr = S.turntable(sched, None, 0.0, initial=C0, earth="none", t=t, frame="enu")
    u = np.asarray(axis) / np.linalg.norm(axis)
    end = C0 @ rot_axis(u, angle) if frame == "body" else rot_axis(u, angle) @ C0
    np.testing.assert_allclose(tr.C_b_n[-1] - end, 0, atol=1e-14)
    u_b = u if frame == "body" else C0.T @ u
    np.testing.assert_allclose(tr.dtheta.sum(0), angle * u_b, atol=1e-14)


def test_turntable_ned_equals_enu():
    m = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1.0]])  # C_ENU^NED
    sched_ned = [
        S.Rotate(m @ unit_axis(r.axis), r.angle, r.duration, r.frame, r.profile, r.accel_time)
        if isinstance(r, S.Rotate) and r.frame == "nav"
        else r
        for r in SCHEDULE
    ]
    a = S.turntable(SCHEDULE, 10.0, LAT, initial=C0, frame="enu")
    b = S.turntable(sched_ned, 10.0, LAT, initial=m @ C0, frame="ned")
    for name in ("gyr", "acc", "dtheta", "dv"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), atol=1e-14)
    np.testing.assert_allclose(b.C_b_n, m @ a.C_b_n, atol=1e-15)
    # poses are described in body words (frame-independent); nav axes in the user's frame (east = x_n = y_n)
    assert a.segment_names[::2] == b.segment_names[::2]
    assert a.segment_names[3] == "rotate -180° about x_n" and b.segment_names[3] == "rotate -180° about y_n"


def test_turntable_increments_with_earth_rate_against_quadrature():
    # Σ Δθ over the cosine move equals ∫(ω_nb + C_n^b ω_ie) dt evaluated by adaptive quadrature of an
    # independent model: C(t) = C_0 R_z(θ(t)), ω_nb = θ̇ e_z
    sched = [S.Rest(1.0), S.Rotate("z", 90 * DEG, 3.0), S.Rest(1.0)]
    tr = S.turntable(sched, 10.0, LAT, height_m=30.0, initial=C0, frame="enu")
    w_ie = earth.earth_rate(LAT, frame="enu")
    g = earth.gravity_vector(LAT, 30.0, frame="enu")

    def model(t):
        tau = np.clip(t - 1.0, 0, 3.0)
        th = cosine_theta(tau, 3.0, 90 * DEG)
        thd = 90 * DEG / 3.0 * (1 - np.cos(2 * np.pi * tau / 3.0)) if 0 < tau < 3 else 0.0
        c = C0 @ rot_z(th)
        return c.T @ w_ie + np.array([0, 0, thd]), c.T @ (-g)

    for k in [5, 10, 11, 17, 25, 38]:
        for i in range(3):
            w_q, _ = quad(lambda t: model(t)[0][i], tr.t[k], tr.t[k + 1], epsabs=1e-17, epsrel=1e-14)
            f_q, _ = quad(lambda t: model(t)[1][i], tr.t[k], tr.t[k + 1], epsabs=1e-14, epsrel=1e-14)
            assert abs(tr.dtheta[k, i] - w_q) < 1e-15
            assert abs(tr.dv[k, i] - f_q) < 1e-13
    k0, k1 = tr.segment(1)[[0, -1]]
    total, _ = quad(lambda t: model(t)[0][2], tr.t[k0 - 1], tr.t[k1 + 1], epsabs=1e-16, epsrel=1e-14, limit=200)
    assert tr.dtheta[k0 - 1 : k1 + 1, 2].sum() == pytest.approx(total, abs=1e-14)


def test_quadrature_error_against_16_node_rule(monkeypatch):
    # state and show the error: 8-node Gauss–Legendre vs 16 nodes on the same panels, 1 Hz sampling so that a
    # whole move falls in a few intervals (the hardest case for the panel rule)
    def run(rate):
        return S.turntable(SCHEDULE, rate, LAT, initial=C0, frame="enu")

    a = [run(1.0), run(10.0)]
    x, w = np.polynomial.legendre.leggauss(16)
    monkeypatch.setattr(S, "_GL_X", x)
    monkeypatch.setattr(S, "_GL_W", w)
    monkeypatch.setattr(S, "GL_ORDER", 16)
    b = [run(1.0), run(10.0)]
    for p, q in zip(a, b):
        # |dtheta| ≤ 0.2 rad and |dv| ≤ 10 m/s: agreement to a few ulp, i.e. both rules are at rounding level
        assert np.max(np.abs(p.dtheta - q.dtheta)) < 2e-16
        assert np.max(np.abs(p.dv - q.dv)) < 1e-13


def test_irregular_epochs():
    rng = np.random.default_rng(7)
    t = np.sort(np.concatenate([[0.0, 12.5], rng.uniform(0, 12.5, 300)]))
    tr = S.turntable(SCHEDULE, None, LAT, initial=C0, earth="none", t=t, frame="enu")
    np.testing.assert_array_equal(tr.t, t)
    # Earth-free, single-axis moves: the increments telescope, so their total equals the composed rotation's
    # net angle sum along each body axis in turn; check the first move alone
    k = np.flatnonzero((t[:-1] < 5.0) & (t[1:] > 2.0))
    inside = (t[k[0]] >= 0) & (t[k[-1] + 1] <= 6.0)
    assert inside
    np.testing.assert_allclose(tr.dtheta[k].sum(0), [0, 0, 90 * DEG], atol=1e-14)
    co = S.coning(BETA, FREQ, 1.0, None, t=t[t <= 1.0], frame="enu")
    tt = co.t
    np.testing.assert_allclose(co.dtheta, S.coning_increment(BETA, FREQ, tt[:-1], tt[1:]), atol=1e-17)
    st_ = S.static_positions(S.six_positions(frame="enu"), 2.0, None, LAT, t=t[t <= 12.0], frame="enu")
    both = st_.labels[:-1] == st_.labels[1:]
    np.testing.assert_allclose(st_.dv[both], st_.acc[:-1][both] * st_.dt[both, None], atol=1e-14)


# --- gimbal chain ----------------------------------------------------------------------------------------

C_MIS = rot_x(20e-6) @ rot_y(-15e-6)  # small non-orthogonality between the gimbal axes
C_IMU = dcm_from_euler([0.01, -0.02, 0.5], "enu")
OUTER = S.AxisSchedule([S.Move(1.0, 2.0, np.pi), S.Move(5.0, 3.0, -np.pi / 2, "trapezoid", 0.5)])
INNER = S.AxisSchedule([S.Move(2.0, 2.0, np.pi / 2, "quintic"), S.Move(8.0, 1.0, np.pi)], initial=0.3)


def chain(t):
    a, b = OUTER(t), INNER(t)
    return S.chain_attitude(
        [np.eye(3), C_MIS, C_IMU], ["z", "y"], np.stack([a[0], b[0]]), np.stack([a[1], b[1]]), np.stack([a[2], b[2]])
    )


def test_chain_rate_is_the_derivative_of_the_attitude():
    t = np.linspace(0.5, 9.5, 37)
    brk = np.array(OUTER.breakpoints + INNER.breakpoints)
    t = t[np.min(np.abs(t[:, None] - brk), axis=1) > 1e-3]  # a difference across a rate kink is not a derivative
    h = 1e-5
    c, w, wd = chain(t)
    cp, wp, _ = chain(t + h)
    cm, wm, _ = chain(t - h)
    # central differences: truncation h²/6 |ω''| ≲ 1e-9 (|ω''| < 50 rad/s³), rounding eps/h ≈ 2e-11
    w_fd = np.stack([skew_inv(c[k].T @ (cp[k] - cm[k]) / (2 * h)) for k in range(t.size)])
    np.testing.assert_allclose(w, w_fd, atol=2e-8)
    np.testing.assert_allclose(wd, (wp - wm) / (2 * h), atol=2e-6)  # ω''' h²/6 with |ω'''| < 1e3 rad/s⁴
    # the chain is C_0 R_z(α) C_1 R_y(β) C_2 exactly
    a, b = OUTER(t)[0], INNER(t)[0]
    np.testing.assert_allclose(c, rot_z(a) @ C_MIS @ rot_y(b) @ C_IMU, atol=1e-15)


def skew_inv(m):
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def test_gimbal_dual_axis_truth():
    tr = S.gimbal([np.eye(3), C_MIS, C_IMU], ["z", "y"], [OUTER, INNER], 10.0, 20.0, LAT, earth="wgs84", frame="enu")
    c = tr.C_b_n
    # rest segments: 0–1 s, 4–5 s, 9–10 s (moves overlap between 1 and 4 s, and 5–9 s is one motion)
    assert np.unique(tr.labels).tolist() == [-1, 0, 1, 2]
    np.testing.assert_allclose(tr.t[tr.segment(1)][[0, -1]], [4.0, 5.0])
    np.testing.assert_allclose(
        c[tr.segment(2)] - rot_z(np.pi / 2) @ C_MIS @ rot_y(0.3 + 1.5 * np.pi) @ C_IMU, 0, atol=1e-14
    )
    rest = tr.labels >= 0
    np.testing.assert_allclose(tr.acc[rest], body(-earth.gravity_vector(LAT, frame="enu"), c)[rest], atol=1e-13)
    assert tr.segment_names[1].startswith("θ1 = 180°, θ2 = 107.19°: ")
    # increments against adaptive quadrature of the chain's rate (verified above) plus the Earth rate
    w_ie = earth.earth_rate(LAT, frame="enu")
    for k in [22, 30, 41, 79, 130, 165]:
        for i in range(3):

            def wib(t):
                cc, ww, _ = chain(np.array([t]))
                return ww[0, i] + (cc[0].T @ w_ie)[i]

            val, _ = quad(
                wib,
                tr.t[k],
                tr.t[k + 1],
                epsabs=1e-16,
                epsrel=1e-14,
                limit=200,
                points=[x for x in OUTER.breakpoints + INNER.breakpoints if tr.t[k] < x < tr.t[k + 1]] or None,
            )
            assert abs(tr.dtheta[k, i] - val) < 1e-14


def test_gimbal_single_axis_equals_turntable_and_callable_angles():
    sched = [S.Rest(1.0), S.Rotate("y", 1.0, 2.0), S.Rest(1.0)]
    tt = S.turntable(sched, 25.0, LAT, initial=C0, frame="enu")
    ax = S.AxisSchedule([S.Move(1.0, 2.0, 1.0)])
    gm = S.gimbal([C0, np.eye(3)], ["y"], [ax], 4.0, 25.0, LAT, frame="enu")
    for name in ("q_b_n", "gyr", "acc", "dtheta", "dv"):
        np.testing.assert_allclose(getattr(gm, name), getattr(tt, name), atol=1e-15)

    # a plain callable: sinusoidal oscillation about two axes; increments against adaptive quadrature
    def osc(t, amp=0.2, f=1.3):
        p = 2 * np.pi * f * np.asarray(t, float)
        return amp * np.sin(p), amp * 2 * np.pi * f * np.cos(p), -amp * (2 * np.pi * f) ** 2 * np.sin(p)

    gm = S.gimbal(
        [np.eye(3), np.eye(3), C_IMU],
        ["z", "x"],
        [osc, lambda t: osc(t, 0.1, 0.7)],
        3.0,
        10.0,
        LAT,
        earth="none",
        frame="enu",
    )
    assert gm.segment_names == ["gimbal motion"] and np.all(gm.labels == 0)

    def w_model(t):
        a, b = osc(t), osc(t, 0.1, 0.7)
        return S.chain_attitude([np.eye(3), np.eye(3), C_IMU], ["z", "x"], [[a[0]], [b[0]]], [[a[1]], [b[1]]])[1][0]

    for k in [0, 13, 29]:
        for i in range(3):
            val, _ = quad(lambda t: w_model(t)[i], gm.t[k], gm.t[k + 1], epsabs=1e-16, epsrel=1e-14)
            assert abs(gm.dtheta[k, i] - val) < 1e-14


def test_lever_arm_centripetal_and_tangential():
    # turning about body z by θ(t): a point at r = [L, 0, 0] feels f = [−θ̇² L, θ̈ L, 0] (no gravity, inertial)
    L = 0.05
    sched = [S.Rest(0.5), S.Rotate("z", 2 * np.pi, 2.0), S.Rest(0.5)]
    tr = S.turntable(sched, 100.0, 0.0, earth="none", lever_arm=[L, 0, 0], frame="enu")
    tau = np.clip(tr.t - 0.5, 0, 2.0)
    A, T = 2 * np.pi, 2.0
    thd = A / T * (1 - np.cos(2 * np.pi * tau / T))
    thdd = 2 * np.pi * A / T**2 * np.sin(2 * np.pi * tau / T)
    np.testing.assert_allclose(tr.acc, np.stack([-(thd**2) * L, thdd * L, 0 * tau], 1), atol=1e-14)
    # ∫ θ̈ L dt over the move is the change in tangential speed: zero; ∫ −θ̇² L dt = −L ∫θ̇² = −L (3/2) A²/T
    np.testing.assert_allclose(tr.dv.sum(0), [-L * 1.5 * A**2 / T, 0, 0], atol=1e-14)


# --- trajectory ------------------------------------------------------------------------------------------


def knots(seed=3, n=7):
    rng = np.random.default_rng(seed)
    tk = np.arange(n) * 1.0
    att = dcm_from_euler(np.cumsum(rng.normal(0, 0.3, (n, 3)), 0), "enu")
    pos = np.cumsum(rng.normal(0, 15, (n, 3)), 0)
    pos[0] = 0
    return tk, att, pos


def test_trajectory_passes_through_knots():
    tk, att, pos = knots()
    tr = S.trajectory(tk, att, pos, 20.0, lat0=0.7, lon0=2.0, height0_m=50.0, frame="enu")
    idx = np.searchsorted(tr.t, tk)
    np.testing.assert_allclose(tr.C_b_n[idx], att, atol=1e-15)
    # the geodetic positions map back to the tangent-frame knots (ECEF rounding 6.4e6 m × 2e-16 ≈ 1e-9 m)
    r0 = earth.geodetic_to_ecef(0.7, 2.0, 50.0)
    r = earth.geodetic_to_ecef(tr.pos[idx, 0], tr.pos[idx, 1], tr.pos[idx, 2])
    np.testing.assert_allclose((r - r0) @ earth.dcm_e_to_n(0.7, 2.0, frame="enu").T, pos, atol=5e-9)
    ned = S.trajectory(
        tk,
        np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1.0]]) @ att,
        pos[:, [1, 0, 2]] * [1, 1, -1],
        20.0,
        frame="ned",
        lat0=0.7,
        lon0=2.0,
        height0_m=50.0,
    )
    for name in ("gyr", "acc", "dtheta", "dv", "pos"):
        np.testing.assert_allclose(getattr(ned, name), getattr(tr, name), atol=1e-12)
    np.testing.assert_allclose(ned.vel_n, tr.vel_n[:, [1, 0, 2]] * [1, 1, -1], atol=1e-12)


def test_trajectory_end_velocities_are_in_the_frame_axes():
    tk, att, pos = knots()
    v0, v1 = np.array([3.0, -1.0, 0.5]), np.array([-2.0, 4.0, -1.5])  # ENU
    enu = S.trajectory(tk, att, pos, 20.0, lat0=0.7, bc_type=((1, v0), (1, v1)), frame="enu")
    swap = [1, 0, 2], np.array([1, 1, -1])
    ned = S.trajectory(
        tk,
        np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1.0]]) @ att,
        pos[:, swap[0]] * swap[1],
        20.0,
        frame="ned",
        lat0=0.7,
        bc_type=((1, v0[swap[0]] * swap[1]), (1, v1[swap[0]] * swap[1])),
    )
    np.testing.assert_allclose(ned.acc, enu.acc, atol=1e-12)
    np.testing.assert_allclose(ned.vel_n[0], v0[swap[0]] * swap[1], atol=1e-6)


def test_trajectory_velocity_and_position_derivatives():
    tk, att, pos = knots()
    lat0 = 0.7
    t = np.linspace(2.3, 2.5, 201)  # 1 kHz inside one knot interval
    tr = S.trajectory(tk, att, pos, None, lat0=lat0, lon0=2.0, height0_m=50.0, t=t, frame="enu")
    c = tr.C_b_n
    lat, h, v = tr.pos[:, 0], tr.pos[:, 2], tr.vel_n
    w_ie, w_en = earth.earth_rate(lat, frame="enu"), earth.transport_rate(lat, h, v, frame="enu")
    # invert the mechanization: a^n = C_b^n f^b − (2ω_ie + ω_en) × v + g
    a = np.einsum("mij,mj->mi", c, tr.acc) - np.cross(2 * w_ie + w_en, v) + earth.gravity_vector(lat, h, frame="enu")
    # central difference of v^n: v is (nearly) quadratic inside a knot interval (cubic position spline; the
    # frame turns at ~1e-5 rad/s), so the truncation error is negligible and rounding is ~1e-11 m/s²
    dv_fd = (v[2:] - v[:-2]) / (t[2:] - t[:-2])[:, None]
    np.testing.assert_allclose(a[1:-1], dv_fd, atol=1e-8)
    # position derivative: [L̇, λ̇, ḣ] = position_rate(v). Fourth-order central difference with a 10 ms step
    # (exact for the cubic spline up to the slow frame rotation); the geodetic position carries the ECEF rounding
    # (6.4e6 m × 1.1e-16 ≈ 1e-9 m), amplified by 18/(12 × 10 ms) to ≈ 2e-7 m/s and 3e-14 rad/s
    p, tp = tr.pos[::10], t[::10]
    p_fd = (-p[4:] + 8 * p[3:-1] - 8 * p[1:-3] + p[:-4]) / (12 * (tp[1] - tp[0]))
    rate = earth.position_rate(lat, h, v, frame="enu")[::10][2:-2]
    np.testing.assert_allclose(p_fd[:, :2], rate[:, :2], rtol=0, atol=1e-13)
    np.testing.assert_allclose(p_fd[:, 2], rate[:, 2], rtol=0, atol=1e-6)
    # ω_ib − ω_nb = C_n^b(ω_ie + ω_en)
    tn = S.trajectory(tk, att, pos, None, lat0=lat0, lon0=2.0, height0_m=50.0, t=t, earth="none", frame="enu")
    np.testing.assert_allclose(tr.gyr - tn.gyr, body(w_ie + w_en, c), atol=1e-17)


def test_trajectory_increments_integrate_back_to_attitude():
    tk, att, pos = knots(5)
    coarse = S.trajectory(tk, att, pos, 4.0, lat0=0.3, earth="none", frame="enu")
    fine = S.trajectory(tk, att, pos, 1000.0, lat0=0.3, earth="none", frame="enu")
    # re-sampling: the fine increments sum to the coarse ones (both exact)
    np.testing.assert_allclose(fine.dtheta.reshape(-1, 250, 3).sum(1), coarse.dtheta, atol=2e-14)
    np.testing.assert_allclose(fine.dv.reshape(-1, 250, 3).sum(1), coarse.dv, atol=1e-12)
    # attitude from the fine increments with the two-sample coning correction (Savage 7.1.1-15); the residual
    # per step is O(|ω|²|ω̇| dt⁴) ≈ 1e-13 rad, so over 6000 steps < 1e-9 rad
    d = fine.dtheta
    phi = d.copy()
    phi[1:] += np.cross(d[:-1], d[1:]) / 12
    c = fine.C_b_n[0]
    out = [c]
    steps = dcm_from_rotvec(phi)
    for k in range(len(d)):
        c = c @ steps[k]
        out.append(c)
    err = rotation_angle(np.swapaxes(np.array(out), -1, -2) @ fine.C_b_n)
    assert np.max(err) < 1e-8


def test_trajectory_lever_arm():
    # f at a lever arm r equals f + ω̇_ib × r + ω_ib × (ω_ib × r); ω̇ here from central differences of ω_ib
    tk, att, pos = knots()
    t = np.linspace(3.1, 3.2, 101)
    r = np.array([0.3, -0.2, 0.1])
    a = S.trajectory(tk, att, pos, None, lat0=0.7, t=t, frame="enu")
    b = S.trajectory(tk, att, pos, None, lat0=0.7, t=t, lever_arm=r, frame="enu")
    w = a.gyr
    wd = (w[2:] - w[:-2]) / (t[2:] - t[:-2])[:, None]  # error h²/6 |ω'''| ≈ 1e-7 · 10
    expect = a.acc[1:-1] + np.cross(wd, r) + np.cross(w[1:-1], np.cross(w[1:-1], r))
    np.testing.assert_allclose(b.acc[1:-1], expect, atol=1e-6)


def test_rate_of_the_navigation_frame_derivative():
    # ω̇_in^n used for the lever-arm term, against a fourth-order central difference of ω_ie^n + ω_en^n along a
    # fast (≈ 300 m/s) trajectory; step 10 ms, truncation (h⁴/30)|ω_in^(5)| is negligible, rounding of
    # ω_en ≈ 5e-5 rad/s is ≈ 1e-20 × 18/(0.12 s) ≈ 2e-18 rad/s²
    tk = np.arange(5) * 2.0
    pos = np.array([[0, 0, 0], [500, 300, 50], [1100, 500, 80], [1600, 900, 60], [2000, 1500, 20.0]])
    att = np.stack([np.eye(3)] * 5)
    t = np.linspace(3.0, 3.4, 41)
    tr = S.trajectory(tk, att, pos, None, lat0=1.2, t=t, frame="enu")
    lat, h, v = tr.pos[:, 0], tr.pos[:, 2], tr.vel_n
    a = (
        np.einsum("mij,mj->mi", tr.C_b_n, tr.acc)
        - np.cross(2 * earth.earth_rate(lat, frame="enu") + earth.transport_rate(lat, h, v, frame="enu"), v)
        + earth.gravity_vector(lat, h, frame="enu")
    )
    w = earth.earth_rate(lat, frame="enu") + earth.transport_rate(lat, h, v, frame="enu")
    w_fd = (-w[4:] + 8 * w[3:-1] - 8 * w[1:-3] + w[:-4]) / (12 * (t[1] - t[0]))
    np.testing.assert_allclose(S._omega_in_dot(tr.pos, v, a, "wgs84")[2:-2], w_fd, rtol=1e-6, atol=1e-15)
    assert np.max(np.abs(w_fd)) > 1e-8  # the check is not vacuous


# --- results and bad input --------------------------------------------------------------------------------


def test_json_round_trip(tmp_path):
    tr = S.turntable(SCHEDULE[:3], 5.0, LAT, initial=C0, frame="enu")
    back = Result.from_json(tr.to_json(tmp_path / "truth.json"))
    assert isinstance(back, S.ImuTruth)
    for name in ("t", "q_b_n", "pos", "vel_n", "gyr", "acc", "dtheta", "dv", "labels"):
        np.testing.assert_array_equal(getattr(back, name), getattr(tr, name))
    assert back.segment_names == tr.segment_names and back.frame == "enu" and back.earth == "wgs84"
    assert back.rate_hz == pytest.approx(5.0) and back.C_b_n.shape == (len(tr.t), 3, 3)
    assert tr.units()["dv"] == "m/s" and tr.units()["gyr"] == "rad/s"


@pytest.mark.parametrize(
    "call",
    [
        lambda: S.static_positions(S.six_positions(), 0.0, 10, LAT),  # zero dwell
        lambda: S.static_positions(S.six_positions(), [1.0, np.nan, 1, 1, 1, 1], 10, LAT),  # NaN
        lambda: S.static_positions(S.six_positions() * 1.01, 1.0, 10, LAT),  # not orthonormal
        lambda: S.static_positions(-S.six_positions(), 1.0, 10, LAT),  # reflections
        lambda: S.static_positions(S.six_positions(), 1.0, 10, LAT, frame="nwu"),  # unknown frame
        lambda: S.static_positions(S.six_positions(), 1.0, 10, LAT, earth="grs67"),  # unknown Earth set
        lambda: S.static_positions(S.six_positions(), 1.0, 10, 39.9),  # latitude in degrees
        lambda: S.static_positions(S.six_positions(), 1.0, 10, LAT, transition=-1.0),
        lambda: S.static_positions(S.six_positions(), 1.0, 10, LAT, gravity=[0, 0, -9.8]),  # gravity with Earth
        lambda: S.static_positions(S.six_positions(), 1.0, None, LAT, t=[0.0, 0.2, 0.1]),  # unsorted
        lambda: S.static_positions(S.six_positions(), 1.0, None, LAT, t=[0.0, 0.1, 0.1]),  # duplicate
        lambda: S.static_positions(S.six_positions(), 1.0, None, LAT, t=[0.0, 7.0]),  # beyond the schedule
        lambda: S.static_positions(S.six_positions(), 1.0, 0.0, LAT),  # zero rate
        lambda: S.static_positions(S.six_positions(), 1.0, None, LAT),  # neither rate nor epochs
        lambda: S.turntable([S.Rotate("w", 1.0, 1.0)], 10, LAT),  # unknown axis
        lambda: S.turntable([S.Rotate("z", 1.0, 1.0, profile="step")], 10, LAT),
        lambda: S.turntable([S.Rotate("z", 1.0, 1.0, profile="trapezoid", accel_time=0.6)], 10, LAT),
        lambda: S.turntable([S.Rotate("z", 1.0, 1.0, frame="lab")], 10, LAT),
        lambda: S.turntable([S.Rotate([0, 0, 0], 1.0, 1.0)], 10, LAT),
        lambda: S.turntable([S.Rest(np.nan)], 10, LAT),
        lambda: S.turntable([], 10, LAT),
        lambda: S.AxisSchedule([S.Move(0.0, 2.0, 1.0), S.Move(1.0, 1.0, 1.0)]),  # overlapping moves
        lambda: S.gimbal([np.eye(3)], ["z"], [0.0], 1.0, 10, LAT),  # missing fixed DCM
        lambda: S.coning(np.radians(200), 1.0, 1.0, 100),
        lambda: S.coning(0.01, -1.0, 1.0, 100),
        lambda: S.trajectory([0, 1, 1], np.stack([np.eye(3)] * 3), np.zeros((3, 3)), 10, lat0=0.1),
        lambda: S.trajectory([0, 1, 2], np.stack([np.eye(3)] * 2), np.zeros((3, 3)), 10, lat0=0.1),
    ],
)
def test_bad_input_raises_optinav_error(call):
    with pytest.raises(OptinavError):
        call()


def test_trajectory_sampler_windows_join_as_one_spline():
    """Splined window by window (64 knots of overlap), the motion is the one spline through all knots to rounding;
    one window is :func:`trajectory`'s motion exactly."""
    rng = np.random.default_rng(3)
    K = 301
    tk = np.linspace(0.0, 30.0, K)
    c = dcm_from_euler(np.cumsum(rng.normal(0, 0.05, (K, 3)), axis=0), "ned")
    pos = np.cumsum(np.cumsum(rng.normal(0, 0.05, (K, 3)), axis=0), axis=0)
    bc = ((1, np.array([1.0, 0.0, 0.0])), (1, np.array([0.0, 1.0, 0.0])))
    site = dict(lat0=0.6, lon0=2.0, height0_m=30.0, bc_type=bc)
    whole = S.trajectory(tk, c, pos, 100.0, frame="ned", **site)
    one = S.TrajectorySampler(tk, c, pos, "ned", **site)
    assert one.windows == 1
    gyr, acc, q = one.states(whole.t)
    assert np.array_equal(gyr, whole.gyr) and np.array_equal(acc, whole.acc) and np.array_equal(q, whole.q_b_n)
    windowed = S.TrajectorySampler(tk, c, pos, "ned", window_knots=37, **site)
    assert windowed.windows == 9
    gyr, acc, q = windowed.states(whole.t)
    np.testing.assert_allclose(gyr, whole.gyr, rtol=0, atol=1e-12)
    np.testing.assert_allclose(acc, whole.acc, rtol=0, atol=1e-10)
    np.testing.assert_allclose(q, whole.q_b_n, rtol=0, atol=1e-13)
    # any order of epochs, windows rebuilt as needed
    idx = rng.permutation(whole.t.size)[:200]
    np.testing.assert_allclose(windowed.states(whole.t[idx])[1], whole.acc[idx], rtol=0, atol=1e-10)
