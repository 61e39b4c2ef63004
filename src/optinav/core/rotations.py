"""Rotations: direction-cosine matrices, quaternions, Euler angles and rotation vectors.

Conventions (docs/conventions.md): ``C_a^b`` maps a-frame vectors into frame b; an attitude is ``C_b^n``.
Quaternions are scalar-first ``[w, x, y, z]`` Hamilton quaternions with ``q_b^n ⊗ v_b ⊗ q_b^n* = v_n``.
Every function is vectorized over leading dimensions: a vector is ``(..., 3)``, a matrix ``(..., 3, 3)``,
a quaternion ``(..., 4)``. Conversions are a thin layer over :class:`scipy.spatial.transform.Rotation`.

Euler conventions (angles always returned and accepted as ``[roll, pitch, yaw]`` in rad):

* ``"ned"`` (default): body forward-right-down, navigation north-east-down;
  ``C_b^n = R_z(yaw) R_y(pitch) R_x(roll)``; yaw clockwise from north seen from above.
* ``"enu"``: body right-forward-up, navigation east-north-up (PSINS);
  ``C_b^n = R_z(yaw) R_x(pitch) R_y(roll)``; yaw counter-clockwise from north (heading = −yaw).

``R_x, R_y, R_z`` are the active rotation matrices :func:`rot_x`, :func:`rot_y`, :func:`rot_z`.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

_EULER_SEQ = {"ned": "ZYX", "enu": "ZXY"}

#: navigation-frame names, as :func:`frame_name` returns them (docs/conventions.md, "Frames")
FRAMES = ("enu", "ned")
#: the one default navigation frame of every function and result taking ``frame`` (aerospace: body
#: forward-right-down, navigation north-east-down); code reproducing PSINS (rins, the studies) passes ``"enu"``
#: explicitly (docs/conventions.md, "Spelling and defaults")
DEFAULT_FRAME = "ned"


def frame_name(frame, what: str = "navigation frame") -> str:
    """The navigation frame as its one spelling; every function taking ``frame`` (or an Euler ``convention``)
    checks it here.

    Parameters
    ----------
    frame : str
        ``"enu"`` or ``"ned"`` in any case; anything else raises :class:`OptinavError`.
    what : str
        Named in the error message.

    Returns
    -------
    str
        ``"enu"`` or ``"ned"``.
    """
    f = str(frame).strip().lower()
    if f not in FRAMES:
        raise OptinavError(f"unknown {what} {frame!r}", "use 'enu' or 'ned' (either case)")
    return f


#: C_ENU^NED: maps ENU vectors to NED (and, being symmetric and involutory, NED to ENU).
C_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: C_RFU^FRD: maps right-forward-up body vectors to forward-right-down (same matrix as C_ENU_NED).
C_RFU_FRD = C_ENU_NED.copy()


def _flat(x: np.ndarray, tail: int) -> tuple[np.ndarray, tuple[int, ...]]:
    lead = x.shape[: x.ndim - tail]
    return x.reshape((-1,) + x.shape[x.ndim - tail :]), lead


def skew(v) -> np.ndarray:
    """Skew-symmetric cross-product matrix ``[v×]`` with ``[v×] u = v × u``.

    Parameters
    ----------
    v : (..., 3) array
        Vector(s) [any unit].

    Returns
    -------
    (..., 3, 3) ndarray
        ``[v×]`` [unit of v].
    """
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def vee(m) -> np.ndarray:
    """Inverse of :func:`skew` (uses the antisymmetric part).

    Parameters
    ----------
    m : (..., 3, 3) array
        Matrix [any unit].

    Returns
    -------
    (..., 3) ndarray
        The vector [unit of m].
    """
    m = np.asarray(m, dtype=float)
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1)


def small_angle_dcm(phi) -> np.ndarray:
    """First-order rotation matrix ``I + [φ×]`` of a small rotation vector φ.

    The matrices of the form ``I − [θ×]`` used for non-orthogonality angles (e.g. the rotational-INS paper,
    eqs. 4–5) are ``small_angle_dcm(-θ)``.

    Parameters
    ----------
    phi : (..., 3) array
        Rotation vector [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        ``I + [φ×]`` [-].
    """
    return np.eye(3) + skew(phi)


def rot_x(angle) -> np.ndarray:
    """Active rotation about x: [[1,0,0],[0,c,−s],[0,s,c]].

    Parameters
    ----------
    angle : float or array
        Angle(s) [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrices [-].
    """
    a = np.asarray(angle, dtype=float)
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle) -> np.ndarray:
    """Active rotation about y: [[c,0,s],[0,1,0],[−s,0,c]].

    Parameters
    ----------
    angle : float or array
        Angle(s) [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrices [-].
    """
    a = np.asarray(angle, dtype=float)
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle) -> np.ndarray:
    """Active rotation about z: [[c,−s,0],[s,c,0],[0,0,1]].

    Parameters
    ----------
    angle : float or array
        Angle(s) [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrices [-].
    """
    a = np.asarray(angle, dtype=float)
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def unit_axis(axis, name: str = "axis") -> np.ndarray:
    """Unit 3-vector from a vector or an axis name.

    Parameters
    ----------
    axis : str or (3,) array
        A vector [any unit] or a name: "x", "-y", "+z" (suffixes "_b"/"_n" ignored).
    name : str
        Named in error messages.

    Returns
    -------
    (3,) ndarray
        Unit vector [-].
    """
    if isinstance(axis, str):
        return _axis_from_name(axis)
    a = as_float_array(axis, name, last_dims=(3,))
    if a.ndim != 1:
        raise OptinavError(f"{name} must be one 3-vector, got shape {a.shape}", "pass e.g. [0, 0, 1] or 'z'")
    n = np.linalg.norm(a)
    if n == 0:
        raise OptinavError(f"{name} is the zero vector", "give a non-zero rotation axis")
    return a / n


_AXES = {"x": 0, "y": 1, "z": 2}


def _axis_from_name(s: str) -> np.ndarray:
    key = s.strip().lower()
    sign = -1.0 if key.startswith("-") else 1.0
    key = key.lstrip("+-").removesuffix("_b").removesuffix("_n")
    if key not in _AXES:
        raise OptinavError(f"unknown axis {s!r}", "use 'x', 'y', 'z' with an optional sign, or a 3-vector")
    v = np.zeros(3)
    v[_AXES[key]] = sign
    return v


def rot_axis(axis, angle) -> np.ndarray:
    """Active rotation about ``axis``, vectorized over ``angle``.

    Parameters
    ----------
    axis : str or (3,) array
        A vector [any unit] or a name like "-z".
    angle : float or array
        Angle(s) [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrices [-].
    """
    return dcm_from_rotvec(unit_axis(axis) * np.asarray(angle, dtype=float)[..., None])


# --- quaternion algebra -------------------------------------------------------------------------------


def quat_multiply(p, q) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions, broadcasting over leading dims.

    Parameters
    ----------
    p, q : (..., 4) array
        Quaternions [w, x, y, z] [-].

    Returns
    -------
    (..., 4) ndarray
        ``p ⊗ q`` [-].
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        -1,
    )


def quat_conjugate(q) -> np.ndarray:
    """Conjugate ``[w, −x, −y, −z]`` (the inverse of a unit quaternion).

    Parameters
    ----------
    q : (..., 4) array
        Quaternion(s) [-].

    Returns
    -------
    (..., 4) ndarray
        The conjugate [-].
    """
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_normalize(q) -> np.ndarray:
    """Unit quaternion with the same direction; a zero quaternion is an error.

    Parameters
    ----------
    q : (..., 4) array
        Quaternion(s) [-].

    Returns
    -------
    (..., 4) ndarray
        Unit quaternion(s) [-].
    """
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n == 0):
        raise OptinavError("cannot normalize a zero quaternion", "check the attitude input")
    return q / n


def quat_canonical(q) -> np.ndarray:
    """The same rotation with ``w ≥ 0`` (q and −q are one rotation).

    Parameters
    ----------
    q : (..., 4) array
        Quaternion(s) [-].

    Returns
    -------
    (..., 4) ndarray
        Quaternion(s) with w ≥ 0 [-].
    """
    q = np.asarray(q, dtype=float)
    return np.where(q[..., :1] < 0, -q, q)


def quat_rotate(q, v) -> np.ndarray:
    """Rotate vectors: ``C(q) v`` for unit ``q``; broadcasts (..., 4) with (..., 3).

    Parameters
    ----------
    q : (..., 4) array
        Unit quaternion(s) [-].
    v : (..., 3) array
        Vector(s) [any unit].

    Returns
    -------
    (..., 3) ndarray
        ``C(q) v`` [unit of v].
    """
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = (q[..., 1], q[..., 2], q[..., 3])
    t = 2.0 * _cross(u, (v[..., 0], v[..., 1], v[..., 2]))
    return v + q[..., :1] * t + _cross(u, (t[..., 0], t[..., 1], t[..., 2]))


def _cross(a, b) -> np.ndarray:
    """a × b of component triples, stacked on a last axis: the products and differences of ``np.cross`` (bit for
    bit the same) without its axis moves and copies, which took 1.8× the time of quat_rotate on long arrays."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]], axis=-1)


# --- conversions (thin layer over scipy) ------------------------------------------------------------


def _rotation():
    """scipy's Rotation class, imported on first use: scipy.spatial costs a second at start-up, and a command
    reports a bad input file before that (issue 17)."""
    from scipy.spatial.transform import Rotation

    return Rotation


def _dcm_of_quats(q) -> np.ndarray:
    """``C`` of (n, 4) quaternions known to be finite and nonzero: scipy's normalization and matrix written out,
    bit for bit :func:`dcm_from_quat` without its checks and Rotation object (tests/test_rotations.py). For loops
    over short steps, where those cost more than the arithmetic (the fine alignment's filter)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n = np.sqrt(x * x + y * y + z * z + w * w)
    w, x, y, z = w / n, x / n, y / n, z / n
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    c = np.empty((q.shape[0], 3, 3))
    c[:, 0, 0], c[:, 0, 1], c[:, 0, 2] = x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)
    c[:, 1, 0], c[:, 1, 1], c[:, 1, 2] = 2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)
    c[:, 2, 0], c[:, 2, 1], c[:, 2, 2] = 2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2
    return c


def _quat_of_rotvec(r) -> np.ndarray:
    """:func:`quat_from_rotvec` of one finite rotation vector (3,) without its checks and Rotation object, bit for
    bit (scipy's series 1/2 − θ²/48 + θ⁴/3840 for sin(θ/2)/θ up to θ = 1e-3 rad; tests/test_rotations.py)."""
    x, y, z = float(r[0]), float(r[1]), float(r[2])
    angle = math.sqrt(x * x + y * y + z * z)
    if angle <= 1e-3:
        a2 = angle * angle
        s = 0.5 - a2 / 48 + a2 * a2 / 3840
    else:
        s = math.sin(angle / 2) / angle
    q = np.array([math.cos(angle / 2), s * x, s * y, s * z])
    return -q if q[0] < 0 else q


def _rot_from_quat(q) -> tuple[Rotation, tuple[int, ...]]:
    q = as_float_array(q, "quaternion", last_dims=(4,))
    flat, lead = _flat(q, 1)
    if np.any(np.linalg.norm(flat, axis=-1) == 0):
        raise OptinavError("quaternion of zero norm", "check the attitude input")
    return _rotation().from_quat(flat, scalar_first=True), lead


def _rot_from_dcm(c) -> tuple[Rotation, tuple[int, ...]]:
    c = as_float_array(c, "direction-cosine matrix", last_dims=(3, 3))
    flat, lead = _flat(c, 2)
    return _rotation().from_matrix(flat), lead


def _rot_from_rotvec(r) -> tuple[Rotation, tuple[int, ...]]:
    r = as_float_array(r, "rotation vector", last_dims=(3,))
    flat, lead = _flat(r, 1)
    return _rotation().from_rotvec(flat), lead


def _rot_from_euler(angles, convention) -> tuple[Rotation, tuple[int, ...]]:
    seq = _seq(convention)
    a = as_float_array(angles, "Euler angles", last_dims=(3,))
    flat, lead = _flat(a, 1)
    return _rotation().from_euler(seq, flat[:, [2, 1, 0]]), lead


def _seq(convention: str) -> str:
    return _EULER_SEQ[frame_name(convention, "Euler convention")]


def _out_quat(r: Rotation, lead) -> np.ndarray:
    return quat_canonical(r.as_quat(scalar_first=True)).reshape(lead + (4,))


def _out_dcm(r: Rotation, lead) -> np.ndarray:
    return r.as_matrix().reshape(lead + (3, 3))


def _out_rotvec(r: Rotation, lead) -> np.ndarray:
    return r.as_rotvec().reshape(lead + (3,))


def _out_euler(r: Rotation, lead, convention) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: scipy still returns a valid triple
        e = r.as_euler(_seq(convention))
    return e[:, [2, 1, 0]].reshape(lead + (3,))


def dcm_from_quat(q) -> np.ndarray:
    """Quaternion ``q_b^n`` (normalized first) → ``C_b^n``.

    Parameters
    ----------
    q : (..., 4) array
        Quaternion(s) [w, x, y, z] [-].

    Returns
    -------
    (..., 3, 3) ndarray
        DCM(s) [-].
    """
    return _out_dcm(*_rot_from_quat(q))


def quat_from_dcm(c) -> np.ndarray:
    """``C_b^n`` → unit quaternion with ``w ≥ 0`` (a non-orthogonal input is projected to the nearest rotation).

    Parameters
    ----------
    c : (..., 3, 3) array
        DCM(s) [-].

    Returns
    -------
    (..., 4) ndarray
        Quaternion(s) [w, x, y, z] [-].
    """
    return _out_quat(*_rot_from_dcm(c))


def dcm_from_rotvec(r) -> np.ndarray:
    """Rotation vector (axis × angle) → DCM, exact (Rodrigues).

    Parameters
    ----------
    r : (..., 3) array
        Rotation vector(s) [rad].

    Returns
    -------
    (..., 3, 3) ndarray
        DCM(s) [-].
    """
    return _out_dcm(*_rot_from_rotvec(r))


def rotvec_from_dcm(c) -> np.ndarray:
    """DCM → rotation vector with angle in [0, π].

    Parameters
    ----------
    c : (..., 3, 3) array
        DCM(s) [-].

    Returns
    -------
    (..., 3) ndarray
        Rotation vector(s) [rad].
    """
    return _out_rotvec(*_rot_from_dcm(c))


def quat_from_rotvec(r) -> np.ndarray:
    """Rotation vector → unit quaternion (``w ≥ 0``).

    Parameters
    ----------
    r : (..., 3) array
        Rotation vector(s) [rad].

    Returns
    -------
    (..., 4) ndarray
        Quaternion(s) [w, x, y, z] [-].
    """
    return _out_quat(*_rot_from_rotvec(r))


def rotvec_from_quat(q) -> np.ndarray:
    """Unit quaternion → rotation vector with angle in [0, π].

    Parameters
    ----------
    q : (..., 4) array
        Quaternion(s) [w, x, y, z] [-].

    Returns
    -------
    (..., 3) ndarray
        Rotation vector(s) [rad].
    """
    return _out_rotvec(*_rot_from_quat(q))


def dcm_from_euler(angles, convention: str = "ned") -> np.ndarray:
    """``[roll, pitch, yaw]`` → ``C_b^n`` in the given convention (module docstring).

    Parameters
    ----------
    angles : (..., 3) array
        [roll, pitch, yaw] [rad].
    convention : str
        ``"ned"`` or ``"enu"``.

    Returns
    -------
    (..., 3, 3) ndarray
        ``C_b^n`` [-].
    """
    return _out_dcm(*_rot_from_euler(angles, convention))


def euler_from_dcm(c, convention: str = "ned") -> np.ndarray:
    """``C_b^n`` → ``[roll, pitch, yaw]``; the middle angle is in [−π/2, π/2].

    Parameters
    ----------
    c : (..., 3, 3) array
        ``C_b^n`` [-].
    convention : str
        ``"ned"`` or ``"enu"``.

    Returns
    -------
    (..., 3) ndarray
        [roll, pitch, yaw] [rad].
    """
    return _out_euler(*_rot_from_dcm(c), convention)


def quat_from_euler(angles, convention: str = "ned") -> np.ndarray:
    """``[roll, pitch, yaw]`` → unit quaternion ``q_b^n`` (``w ≥ 0``).

    Parameters
    ----------
    angles : (..., 3) array
        [roll, pitch, yaw] [rad].
    convention : str
        ``"ned"`` or ``"enu"``.

    Returns
    -------
    (..., 4) ndarray
        ``q_b^n`` [w, x, y, z] [-].
    """
    return _out_quat(*_rot_from_euler(angles, convention))


def euler_from_quat(q, convention: str = "ned") -> np.ndarray:
    """Unit quaternion ``q_b^n`` → ``[roll, pitch, yaw]``.

    Parameters
    ----------
    q : (..., 4) array
        ``q_b^n`` [w, x, y, z] [-].
    convention : str
        ``"ned"`` or ``"enu"``.

    Returns
    -------
    (..., 3) ndarray
        [roll, pitch, yaw] [rad].
    """
    return _out_euler(*_rot_from_quat(q), convention)


def dcm_orthonormalize(c) -> np.ndarray:
    """Nearest rotation matrix in the Frobenius norm (polar decomposition by SVD).

    Parameters
    ----------
    c : (..., 3, 3) array
        Matrix [-].

    Returns
    -------
    (..., 3, 3) ndarray
        Rotation matrix [-].
    """
    c = as_float_array(c, "direction-cosine matrix", last_dims=(3, 3))
    u, _, vt = np.linalg.svd(c)
    d = np.sign(np.linalg.det(u @ vt))
    u[..., :, 2] *= d[..., None]
    return u @ vt


def rotation_angle(c) -> np.ndarray:
    """Angle of the rotation ``C``; for an error ``C_1ᵀ C_2`` it is the attitude error.

    Parameters
    ----------
    c : (..., 3, 3) array
        Rotation matrix [-].

    Returns
    -------
    ndarray
        Angle in [0, π] [rad].
    """
    c = np.asarray(c, dtype=float)
    tr = np.trace(c, axis1=-2, axis2=-1)
    # arctan2 form keeps precision for small angles where arccos((tr-1)/2) loses it
    s = np.linalg.norm(vee(c), axis=-1)
    return np.arctan2(s, 0.5 * (tr - 1.0))


def quat_angle_between(q1, q2) -> np.ndarray:
    """Angle of the rotation taking ``q1`` to ``q2``, sign-invariant.

    Parameters
    ----------
    q1, q2 : (..., 4) array
        Unit quaternions [-].

    Returns
    -------
    ndarray
        Angle in [0, π] [rad].
    """
    e = quat_multiply(quat_conjugate(quat_normalize(q1)), quat_normalize(q2))
    # atan2 of the vector part keeps precision for tiny angles where arccos(w) loses it below ~1e-8 rad
    return 2.0 * np.arctan2(np.linalg.norm(e[..., 1:], axis=-1), np.abs(e[..., 0]))


# --- ENU / NED -----------------------------------------------------------------------------------------


def enu_to_ned(v) -> np.ndarray:
    """Vector(s) in ENU → NED: ``[e, n, u] → [n, e, −u]``.

    Parameters
    ----------
    v : (..., 3) array
        Vector(s) [any unit].

    Returns
    -------
    (..., 3) ndarray
        The same vector(s) in NED [unit of v].
    """
    return np.asarray(v, dtype=float) @ C_ENU_NED.T


def ned_to_enu(v) -> np.ndarray:
    """Vector(s) in NED → ENU: ``[n, e, d] → [e, n, −d]``.

    Parameters
    ----------
    v : (..., 3) array
        Vector(s) [any unit].

    Returns
    -------
    (..., 3) ndarray
        The same vector(s) in ENU [unit of v].
    """
    return np.asarray(v, dtype=float) @ C_ENU_NED.T


def attitude_enu_to_ned(c_b_n_enu) -> np.ndarray:
    """``C_b^n`` with b = right-forward-up, n = ENU → ``C_b'^n'`` with b' = forward-right-down, n' = NED.

    Parameters
    ----------
    c_b_n_enu : (..., 3, 3) array
        Attitude in the ENU convention [-].

    Returns
    -------
    (..., 3, 3) ndarray
        Attitude in the NED convention [-].
    """
    return C_ENU_NED @ np.asarray(c_b_n_enu, dtype=float) @ C_RFU_FRD.T


def attitude_ned_to_enu(c_b_n_ned) -> np.ndarray:
    """Inverse of :func:`attitude_enu_to_ned`.

    Parameters
    ----------
    c_b_n_ned : (..., 3, 3) array
        Attitude in the NED convention [-].

    Returns
    -------
    (..., 3, 3) ndarray
        Attitude in the ENU convention [-].
    """
    return C_ENU_NED.T @ np.asarray(c_b_n_ned, dtype=float) @ C_RFU_FRD


def attitude_in_frame(q_b_n, frame_from: str, frame_to: str) -> np.ndarray:
    """The attitude of the same body axes in another navigation frame: q_b^to = q_from^to ⊗ q_b^from (ENU ↔ NED is
    π about (1, 1, 0)/√2; unlike :func:`attitude_ned_to_enu` the body axes are kept, they are the sensor's).

    Parameters
    ----------
    q_b_n : (..., 4) array
        Attitude(s) q_b^n [w, x, y, z] [-] in ``frame_from``.
    frame_from, frame_to : str
        Navigation frames (``"ned"``/``"enu"``, either case).

    Returns
    -------
    (..., 4) ndarray
        The attitude(s) in ``frame_to`` [-] (the input, as floats, when the frames are one).
    """
    q = np.asarray(q_b_n, dtype=float)
    if frame_name(frame_from) == frame_name(frame_to):
        return q
    return quat_multiply(quat_from_dcm(C_ENU_NED), q)  # C_ENU_NED is its own inverse


def signed_permutations(*, proper_only: bool = False) -> list[np.ndarray]:
    """The 48 signed axis permutations (3×3, one ±1 per row and column; the 24 rotations among them with
    ``proper_only``), the identity first: the ways a triad's columns can be swapped or flipped.

    Parameters
    ----------
    proper_only : bool
        Only the rotations (determinant +1).

    Returns
    -------
    list of (3, 3) ndarray
        The matrices P [-]; a raw triad reading ``P @ x`` of the true ``x``.
    """
    import itertools

    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            P = np.zeros((3, 3))
            P[np.arange(3), perm] = signs
            if not proper_only or np.linalg.det(P) > 0:
                out.append(P)
    return out


def describe_permutation(P, sensor: str, frame: str) -> str:
    """'gyroscope x reads -y, …' for a signed axis permutation ``P`` (rows: the sensor's raw axes, columns: the
    ``frame``'s axes): the axes a swapped or flipped column order puts where.

    Parameters
    ----------
    P : (3, 3) array
        One ±1 per row and column [-].
    sensor, frame : str
        Names for the text.

    Returns
    -------
    str
        The raw axes that do not read their own axis, and what they read.
    """
    parts = []
    for i in range(3):
        j = int(np.flatnonzero(P[i])[0])
        if i != j or P[i, j] < 0:
            parts.append(f"{sensor} {'xyz'[i]} reads {'-' if P[i, j] < 0 else '+'}{'xyz'[j]}")
    return f"{', '.join(parts)} of the {frame}"
