"""Rotations: round trips (hypothesis), algebraic identities, and published convention checks."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from optinav import OptinavError
from optinav.core import rotations as R

finite = st.floats(-10.0, 10.0, allow_nan=False)
vec3 = arrays(float, 3, elements=finite)
quat = arrays(float, 4, elements=st.floats(-1, 1)).filter(lambda q: np.linalg.norm(q) > 1e-3)
# pitch away from ±90° where Euler angles are singular
euler = st.tuples(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1)).map(np.array)


@given(quat)
def test_quat_dcm_round_trip(q):
    q = R.quat_canonical(R.quat_normalize(q))
    q2 = R.quat_from_dcm(R.dcm_from_quat(q))
    # w ≈ 0 leaves the sign ambiguous: compare rotations, not components
    assert R.quat_angle_between(q, q2) < 1e-7


@given(euler, st.sampled_from(["ned", "enu"]))
def test_euler_round_trip(e, conv):
    e2 = R.euler_from_dcm(R.dcm_from_euler(e, conv), conv)
    np.testing.assert_allclose(R.dcm_from_euler(e2, conv), R.dcm_from_euler(e, conv), atol=1e-12)
    np.testing.assert_allclose(e2, e, atol=1e-9)
    np.testing.assert_allclose(R.euler_from_quat(R.quat_from_euler(e, conv), conv), e, atol=1e-9)


@given(vec3.filter(lambda v: np.linalg.norm(v) < np.pi - 1e-3))
def test_rotvec_round_trip(r):
    np.testing.assert_allclose(R.rotvec_from_dcm(R.dcm_from_rotvec(r)), r, atol=1e-9)
    np.testing.assert_allclose(R.rotvec_from_quat(R.quat_from_rotvec(r)), r, atol=1e-9)


@given(quat, quat, vec3)
def test_quat_product_composes_dcms(p, q, v):
    p, q = R.quat_normalize(p), R.quat_normalize(q)
    np.testing.assert_allclose(
        R.dcm_from_quat(R.quat_multiply(p, q)), R.dcm_from_quat(p) @ R.dcm_from_quat(q), atol=1e-12
    )
    np.testing.assert_allclose(R.quat_rotate(p, v), R.dcm_from_quat(p) @ v, atol=1e-11)
    np.testing.assert_allclose(R.quat_multiply(p, R.quat_conjugate(p)), [1, 0, 0, 0], atol=1e-12)


@given(vec3, vec3)
def test_skew_is_cross_product(a, b):
    np.testing.assert_allclose(R.skew(a) @ b, np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(R.vee(R.skew(a)), a)


def test_quat_rotate_is_the_cross_product_formula_bit_for_bit():
    """quat_rotate writes its cross products out (np.cross's axis moves cost 1.8× on long arrays): the same
    products and differences as v + 2w(u×v) + u×(2u×v) with np.cross, bit for bit, under broadcasting."""
    rng = np.random.default_rng(2)
    q = R.quat_normalize(rng.normal(size=(6, 4)))
    v = rng.normal(size=(6, 3)) * 10.0 ** rng.uniform(-8, 8, (6, 1))
    for qq, vv in ((q, v), (q[0], v), (q, v[0]), (q[:, None], v[None, :4]), (q[0], v[0])):
        t = 2.0 * np.cross(qq[..., 1:], vv)
        want = vv + qq[..., :1] * t + np.cross(qq[..., 1:], t)
        got = R.quat_rotate(qq, vv)
        assert got.shape == want.shape and np.array_equal(got, want)


def test_closed_forms_of_the_filter_loops_are_scipys_bit_for_bit():
    """The fine alignment's per-step conversions without the checks and Rotation objects: the same numbers as
    dcm_from_quat (quaternions of any norm, 1e-150 … 1e150) and quat_from_rotvec (either side of scipy's series
    switch at 1e-3 rad, beyond π, zero), bit for bit."""
    rng = np.random.default_rng(5)
    q = rng.normal(size=(4000, 4)) * 10.0 ** rng.uniform(-150, 150, (4000, 1))
    assert np.array_equal(R._dcm_of_quats(q), R.dcm_from_quat(q))
    angle = np.concatenate([10.0 ** rng.uniform(-12, 1.2, 3000), 1e-3 * (1 + rng.uniform(-1e-12, 1e-12, 50)), [0.0]])
    axis = R.quat_normalize(rng.normal(size=(angle.size, 4)))[:, 1:]  # any direction, not unit
    for r in angle[:, None] * axis:
        assert np.array_equal(R._quat_of_rotvec(r), R.quat_from_rotvec(r)), r


def test_vectorized_shapes():
    rng = np.random.default_rng(0)
    e = rng.uniform(-1, 1, (4, 5, 3))
    c = R.dcm_from_euler(e)
    assert c.shape == (4, 5, 3, 3)
    assert R.quat_from_dcm(c).shape == (4, 5, 4)
    np.testing.assert_allclose(R.euler_from_dcm(c), e, atol=1e-12)
    np.testing.assert_allclose(R.rot_z(e[..., 2]), R.dcm_from_euler(e * [0, 0, 1]), atol=1e-15)


def test_enu_convention_matches_psins_a2mat():
    # PSINS a2mat with att = [pitch θ; roll γ; yaw ψ] (Yan Gongmin, PSINS toolbox), written out by hand:
    roll, pitch, yaw = 0.1, -0.2, 0.3
    si, ci, sj, cj, sk, ck = np.sin(pitch), np.cos(pitch), np.sin(roll), np.cos(roll), np.sin(yaw), np.cos(yaw)
    cnb = np.array(
        [
            [cj * ck - si * sj * sk, -ci * sk, sj * ck + si * cj * sk],
            [cj * sk + si * sj * ck, ci * ck, sj * sk - si * cj * ck],
            [-ci * sj, si, ci * cj],
        ]
    )
    np.testing.assert_allclose(R.dcm_from_euler([roll, pitch, yaw], "enu"), cnb, atol=1e-15)


def test_ned_convention_physical_meaning():
    # yaw 90° in NED: body forward axis points east
    c = R.dcm_from_euler([0, 0, np.pi / 2], "ned")
    np.testing.assert_allclose(c @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    # pitch up 30°: forward axis rises, i.e. gets a negative down component
    c = R.dcm_from_euler([0, np.radians(30), 0], "ned")
    np.testing.assert_allclose(c @ [1, 0, 0], [np.cos(np.radians(30)), 0, -0.5], atol=1e-15)


@given(euler)
def test_enu_ned_attitude_conversion(e):
    # the same physical attitude: roll and pitch agree, yaw flips sign (ENU yaw is counter-clockwise)
    c_ned = R.attitude_enu_to_ned(R.dcm_from_euler(e, "enu"))
    np.testing.assert_allclose(R.dcm_from_euler(e * [1, 1, -1], "ned"), c_ned, atol=1e-12)
    np.testing.assert_allclose(R.attitude_ned_to_enu(c_ned), R.dcm_from_euler(e, "enu"), atol=1e-12)


def test_enu_ned_vectors():
    np.testing.assert_allclose(R.enu_to_ned([1, 2, 3]), [2, 1, -3])
    np.testing.assert_allclose(R.ned_to_enu(R.enu_to_ned([1, 2, 3])), [1, 2, 3])


def test_small_angle_dcm_first_order():
    phi = np.array([1e-4, -2e-4, 3e-4])
    # exact minus first-order is second order: |φ|²/2
    err = np.abs(R.dcm_from_rotvec(phi) - R.small_angle_dcm(phi)).max()
    assert err <= 0.5 * phi @ phi * 1.01
    # rotational-INS paper eq. 4 form I − [θ×]
    th = np.array([1.0, 2.0, 3.0])
    expect = np.array([[1, th[2], -th[1]], [-th[2], 1, th[0]], [th[1], -th[0], 1]])
    np.testing.assert_allclose(R.small_angle_dcm(-th), expect)


def test_rotation_angle_small_and_large():
    for a in (1e-10, 1e-4, 1.0, 3.0):
        c = R.dcm_from_rotvec([0, a, 0])
        assert abs(R.rotation_angle(c) - a) < 1e-12 * max(1, a)


def test_orthonormalize():
    rng = np.random.default_rng(1)
    c = R.dcm_from_euler(rng.uniform(-1, 1, 3)) + 1e-3 * rng.standard_normal((3, 3))
    o = R.dcm_orthonormalize(c)
    np.testing.assert_allclose(o @ o.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(o) == pytest.approx(1.0)


def test_bad_input():
    with pytest.raises(OptinavError, match="NaN"):
        R.dcm_from_euler([np.nan, 0, 0])
    with pytest.raises(OptinavError, match="shape"):
        R.dcm_from_quat([1, 0, 0])
    with pytest.raises(OptinavError, match="zero"):
        R.quat_normalize([0, 0, 0, 0])
    with pytest.raises(OptinavError, match="convention"):
        R.dcm_from_euler([0, 0, 0], "xyz")
    with pytest.raises(OptinavError, match="zero"):
        R.rot_axis([0, 0, 0], 1.0)


def test_quat_angle_between_keeps_tiny_angles():
    q = R.quat_from_euler([0.3, -0.2, 1.0])
    # the quaternion product itself rounds at ~1e-16: a few eps of absolute tolerance
    for a in (1e-15, 1e-12, 1e-9, 0.5, 3.1):
        p = R.quat_multiply(q, R.quat_from_rotvec([0.0, 0.0, a]))
        assert R.quat_angle_between(q, p) == pytest.approx(a, rel=1e-6, abs=2e-15)
        assert R.quat_angle_between(q, -p) == pytest.approx(a, rel=1e-6, abs=2e-15)
