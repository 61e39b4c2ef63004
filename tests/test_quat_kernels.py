"""The one numba quaternion kernel set (optinav.core._quat, used by the strapdown and the attitude estimators)
against scipy's Rotation, at small angles (the series branch of the exponential) and large ones."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from optinav.core import _quat as K


def _wxyz(r: Rotation) -> np.ndarray:
    q = r.as_quat()  # scipy is scalar-last
    return np.array([q[3], q[0], q[1], q[2]])


# angles around the series/closed-form switch (0.1 rad), tiny ones and up to almost 2π
ANGLES = [0.0, 1e-12, 1e-8, 1e-4, 0.01, 0.0999, 0.1, 0.1001, 0.5, 1.0, 3.0, 6.2]


@pytest.mark.parametrize("angle", ANGLES)
def test_rotation_vector_exponential_matches_scipy(angle):
    rng = np.random.default_rng(7)
    for _ in range(20):
        axis = rng.normal(size=3)
        v = angle * axis / np.linalg.norm(axis)
        ours = np.array(K.rv2q(*v))
        ref = _wxyz(Rotation.from_rotvec(v))
        ref = ref if ref[0] * ours[0] >= 0 else -ref  # scipy returns w >= 0; exp(φ/2) has w < 0 past π
        np.testing.assert_allclose(ours, ref, rtol=0, atol=2e-16)
        assert abs(np.linalg.norm(ours) - 1.0) < 3e-16


def test_the_series_branch_is_the_exact_exponential_to_rounding():
    # just below the switch the series and the closed form agree to rounding
    v = np.array([0.3, -0.4, 1.2])
    v = v / np.linalg.norm(v) * np.sqrt(K.SERIES_N2) * (1 - 1e-12)
    n = np.linalg.norm(v)
    closed = np.r_[np.cos(n / 2), np.sin(n / 2) / n * v]
    np.testing.assert_allclose(K.rv2q(*v), closed, rtol=0, atol=1e-17)


def test_product_rotate_normalize_and_update_match_scipy():
    rng = np.random.default_rng(3)
    for _ in range(50):
        a, b = Rotation.random(random_state=rng), Rotation.random(random_state=rng)
        qa, qb = _wxyz(a), _wxyz(b)
        ab = np.array(K.qmul(*qa, *qb))
        ref = _wxyz(a * b)  # Hamilton: (a ⊗ b) rotates by b first, then a
        np.testing.assert_allclose(ab * np.sign(ab[0] * ref[0]), ref, atol=1e-15)
        v = rng.normal(size=3)
        np.testing.assert_allclose(K.qrotate(*qa, *v), a.apply(v), atol=1e-14)
        np.testing.assert_allclose(K.qrotate_inv(*qa, *v), a.inv().apply(v), atol=1e-14)
        np.testing.assert_allclose(K.qnormalize(*(2.5 * qa)), qa, atol=1e-15)
        phi, zeta = rng.normal(0, 0.05, 3), rng.normal(0, 1e-5, 3)
        ref = Rotation.from_rotvec(-zeta) * a * Rotation.from_rotvec(phi)
        got = np.array(K.qupdate(*qa, *phi, True, *zeta))
        np.testing.assert_allclose(got * np.sign(got[0] * _wxyz(ref)[0]), _wxyz(ref), atol=1e-15)
