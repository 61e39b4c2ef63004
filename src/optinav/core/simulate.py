"""Motion and exact IMU truth: attitude, angular rate, specific force and their increments.

Every generator returns an :class:`ImuTruth` built from an *analytic* motion: the attitude ``C_b^n(t)``, its body
rate ``ω_nb^b(t)`` (from the attitude's analytic derivative, never by differencing samples) and the position,
velocity and acceleration. The IMU quantities follow from the local-level mechanization equations
(Titterton & Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., eqs. 3.41 and 3.46):

    ω_ib^b = ω_nb^b + C_n^b (ω_ie^n + ω_en^n)
    f^b    = C_n^b (a^n + (2 ω_ie^n + ω_en^n) × v^n − g^n),    a^n = d v^n / dt,

with ``g`` the normal (plumb-bob) gravity, ``ω_ie`` and ``ω_en`` from :mod:`optinav.core.earth`. ``earth="none"``
makes the navigation frame inertial: no Earth rate, no transport rate and no gravity unless ``gravity`` is given.

Increments ``dtheta[k] = ∫ ω_ib^b dt`` and ``dv[k] = ∫ f^b dt`` over ``(t[k], t[k+1]]`` are exact to rounding:

* closed form for the ``ω_nb`` part where it exists (rotation about a fixed axis: ``Δθ · axis``; classic coning:
  Savage, *Strapdown Analytics* 2nd ed., §7.1.1);
* otherwise composite Gauss–Legendre quadrature of order :data:`GL_ORDER` (= 8 nodes, exact for polynomials of
  degree 15) on panels that never straddle a break of smoothness (segment ends, the corners of a trapezoid rate
  profile, spline knots) and are short enough that the integrand turns by at most ~1 rad per panel, so the
  quadrature error bound ``h^17 (8!)^4 / (17 (16!)^3) max|g^(16)|`` ≈ ``1.7e-23 h |g|`` is below rounding
  (``tests/test_simulate.py`` compares with 16-node quadrature on a 1 Hz and a 10 Hz turntable run: the
  increments agree to 3e-17 rad and 4e-15 m/s, i.e. to rounding).

Rest segments on a static base have constant ``ω_ib`` and ``f``; their increments are ``value · dt``.

Navigation frame: ``frame="ned"`` (the default) or ``"enu"``. Inputs (orientations, nav-frame axes, position
offsets) are in that frame; internally everything is computed in ENU and converted at the boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from optinav.core import earth as _earth
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.rotations import (
    C_ENU_NED,
    DEFAULT_FRAME,
    dcm_from_quat,
    dcm_orthonormalize,
    frame_name,
    quat_canonical,
    quat_from_dcm,
    quat_multiply,
    rot_axis,
    rotvec_from_dcm,
    unit_axis,
)
from optinav.core.validate import as_float_array, check_positive, check_timestamps
from optinav.errors import OptinavError

__all__ = [
    "ImuTruth",
    "GL_ORDER",
    "static_positions",
    "static_positions_sampler",
    "RateSampler",
    "TrajectorySampler",
    "orientation_from_up",
    "six_positions",
    "describe_pose",
    "Rest",
    "Rotate",
    "turntable",
    "Move",
    "AxisSchedule",
    "chain_attitude",
    "gimbal",
    "gimbal_sampler",
    "IncrementSampler",
    "coning",
    "coning_attitude",
    "coning_rate",
    "coning_increment",
    "coning_noncommutativity",
    "trajectory",
    "rate_profile",
]

#: Number of Gauss–Legendre nodes per quadrature panel.
GL_ORDER = 8
_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_ORDER)
_CHUNK = 20000  # panels evaluated at once (20000 × 8 nodes × 9 doubles ≈ 11 MB per DCM stack)
_ORTHO_TOL = 1e-6


# --- result ---------------------------------------------------------------------------------------------


@dataclass
class ImuTruth(Result):
    """Simulated truth of an IMU's motion and its ideal (error-free) outputs.

    Epochs ``t[0..N]``; ``dtheta[k]``, ``dv[k]`` integrate the body-frame rate and specific force over
    ``(t[k], t[k+1]]``. ``gyr`` (rad/s) is ω_ib^b and ``acc`` (m/s²) the specific force f^b at the epochs, both
    in body axes. ``labels[k]`` indexes ``segment_names`` (-1 in transitions). Version 2 renamed the version-1
    fields ``omega_ib_b``/``f_b`` to ``gyr``/``acc`` (version-1 files still load).
    """

    SCHEMA = "optinav.imu_truth"
    VERSION = 3

    t: np.ndarray = field(metadata={"unit": "s"})
    frame: str = field(metadata={"unit": "-"})
    earth: str = field(metadata={"unit": "-"})
    q_b_n: np.ndarray = field(metadata={"unit": ""})
    pos: np.ndarray = field(metadata={"unit": "rad, rad, m"})
    vel_n: np.ndarray = field(metadata={"unit": "m/s"})
    gyr: np.ndarray = field(metadata={"unit": "rad/s"})
    acc: np.ndarray = field(metadata={"unit": "m/s^2"})
    dtheta: np.ndarray = field(metadata={"unit": "rad"})
    dv: np.ndarray = field(metadata={"unit": "m/s"})
    labels: np.ndarray = field(metadata={"unit": ""})
    segment_names: list = field(metadata={"unit": "-"})

    @property
    def dt(self) -> np.ndarray:
        """Epoch spacing ``t[k+1] − t[k]`` (s), shape (N,)."""
        return np.diff(self.t)

    @property
    def C_b_n(self) -> np.ndarray:
        """Attitude ``C_b^n`` at the epochs, shape (N+1, 3, 3)."""
        return dcm_from_quat(self.q_b_n)

    @property
    def rate_hz(self) -> float:
        """Nominal sample rate (Hz): the inverse of the median epoch spacing."""
        return float(1.0 / np.median(np.diff(self.t)))

    def segment(self, label: int) -> np.ndarray:
        """Indices of the epochs labelled ``label``.

        Parameters
        ----------
        label : int
            Segment label (index into ``segment_names``).

        Returns
        -------
        int ndarray
            Epoch indices.
        """
        return np.flatnonzero(self.labels == label)


register_legacy(ImuTruth, ImuTruth.SCHEMA, 1, lambda d: nested_kwargs(ImuTruth, d, {"omega_ib_b": "gyr", "f_b": "acc"}))


# --- small validated inputs --------------------------------------------------------------------------------


def _check_earth(earth) -> str:
    if isinstance(earth, _earth.EarthConstants):
        return earth.name.lower()
    name = str(earth).lower()
    if name == "none":
        return name
    _earth.constants(name)  # raises OptinavError for an unknown set
    return name


def _check_lat(lat, name="lat") -> float:
    v = float(as_float_array(lat, name))
    if abs(v) > math.pi / 2:
        raise OptinavError(f"{name} = {v:.6g} is outside [−π/2, π/2]", "give latitude in radians")
    return v


def _scalar(x, name) -> float:
    a = as_float_array(x, name)
    if a.ndim != 0:
        raise OptinavError(f"{name} must be a scalar, got shape {a.shape}", f"pass one number for {name}")
    return float(a)


def _as_dcms(c, name: str) -> np.ndarray:
    """(…, 3, 3) rotation matrices; near-orthonormal input (error < 1e-6) is projected, others rejected."""
    c = as_float_array(c, name, last_dims=(3, 3))
    err = np.abs(np.swapaxes(c, -1, -2) @ c - np.eye(3)).max(axis=(-2, -1))
    det = np.linalg.det(c)
    if np.any(err > _ORTHO_TOL) or np.any(det <= 0):
        i = int(np.argmax(np.where(det <= 0, np.inf, err))) if c.ndim > 2 else 0
        raise OptinavError(
            f"{name}{f'[{i}]' if c.ndim > 2 else ''} is not a rotation matrix "
            f"(|CᵀC − I| = {float(np.max(err)):.2g}, det = {float(np.min(det)):.6g})",
            "build it with rotations.dcm_from_euler, rot_axis or orientation_from_up",
        )
    return dcm_orthonormalize(c)


def _to_enu(c_b_n, frame):
    """C_b^n in the user's frame → C_b^ENU (C_ENU_NED is symmetric and involutory)."""
    return c_b_n if frame == "enu" else C_ENU_NED @ c_b_n


def _from_enu(c_b_enu, frame):
    """C_b^ENU → C_b^n in the user's frame."""
    return c_b_enu if frame == "enu" else C_ENU_NED @ c_b_enu


def _vec_to_enu(v, frame):
    return v if frame == "enu" else np.asarray(v, float) @ C_ENU_NED.T


# --- rate profiles -----------------------------------------------------------------------------------------

_PROFILES = ("cosine", "trapezoid", "quintic")


def rate_profile(profile: str, tau, duration: float, angle: float, accel_time: float | None = None):
    """Angle, rate and angular acceleration of a smooth move by ``angle`` in ``duration``.

    Profiles, all starting and ending at zero rate and integrating to exactly ``angle``:

    * ``"cosine"``: raised-cosine rate ``θ̇ = (A/T)(1 − cos 2πτ/T)``, peak ``2A/T``;
    * ``"trapezoid"``: constant angular acceleration for ``accel_time``, constant rate ``A/(T − T_a)``,
      constant deceleration;
    * ``"quintic"``: minimum-jerk ``θ = A(10u³ − 15u⁴ + 6u⁵)``, u = τ/T (zero rate and acceleration at both ends).

    Parameters
    ----------
    profile : str
        ``"cosine"``, ``"trapezoid"`` or ``"quintic"``.
    tau : float or array
        Time since the move started [s] (clipped to [0, duration]).
    duration : float
        Length T [s].
    angle : float
        Total angle A [rad].
    accel_time : float or None
        Trapezoid acceleration time T_a [s]; None: T/4.

    Returns
    -------
    theta, theta_dot, theta_ddot : ndarray
        Shaped like ``tau`` [rad, rad/s, rad/s^2].
    """
    T, A = float(duration), float(angle)
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, T)
    if profile == "cosine":
        u = tau / T
        s, c = np.sin(2 * np.pi * u), np.cos(2 * np.pi * u)
        return A * (u - s / (2 * np.pi)), A / T * (1.0 - c), 2 * np.pi * A / T**2 * s
    if profile == "quintic":
        u = tau / T
        return (
            A * u**3 * (10 - 15 * u + 6 * u**2),
            A / T * 30 * u**2 * (1 - u) ** 2,
            A / T**2 * 60 * u * (1 - u) * (1 - 2 * u),
        )
    if profile == "trapezoid":
        ta = T / 4 if accel_time is None else float(accel_time)
        w = A / (T - ta)
        s = T - tau
        up, down = tau < ta, tau > T - ta
        th = np.where(up, w * tau**2 / (2 * ta), np.where(down, A - w * s**2 / (2 * ta), w * (tau - ta / 2)))
        rt = np.where(up, w * tau / ta, np.where(down, w * s / ta, w))
        ac = np.where(up, w / ta, np.where(down, -w / ta, 0.0))
        return th, rt, ac
    raise OptinavError(f"unknown rate profile {profile!r}", f"use one of {', '.join(_PROFILES)}")


def _check_profile(profile, duration, accel_time):
    if profile not in _PROFILES:
        raise OptinavError(f"unknown rate profile {profile!r}", f"use one of {', '.join(_PROFILES)}")
    if profile == "trapezoid" and accel_time is not None:
        ta = float(accel_time)
        if not (0 < ta <= duration / 2):
            raise OptinavError(
                f"trapezoid accel_time {ta:.6g} s is outside (0, duration/2 = {duration / 2:.6g} s]",
                "shorten the acceleration phase or lengthen the move",
            )


def _profile_breaks(profile, duration, accel_time) -> list[float]:
    if profile == "trapezoid":
        ta = duration / 4 if accel_time is None else float(accel_time)
        return [ta, duration - ta] if ta < duration / 2 else [ta]
    return []


def _profile_peak_rate(profile, duration, angle, accel_time) -> float:
    A, T = abs(angle), duration
    if profile == "cosine":
        return 2 * A / T
    if profile == "quintic":
        return 1.875 * A / T
    ta = T / 4 if accel_time is None else float(accel_time)
    return A / (T - ta)


# --- joint angle functions --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Move:
    """One move of a gimbal axis: turn by ``angle`` (rad) in ``duration`` (s) starting at ``start`` (s)."""

    start: float
    duration: float
    angle: float
    profile: str = "cosine"
    accel_time: float | None = None


class AxisSchedule:
    """Analytic angle of one gimbal axis: ``initial`` plus a sequence of non-overlapping :class:`Move` s.

    Calling it with times (s) returns ``(θ, θ̇, θ̈)``; ``breakpoints`` lists the times where θ̈ may jump and
    ``moving`` the ``(start, end)`` of each move. Use it as an angle function of :func:`gimbal`.
    """

    def __init__(self, moves: Sequence[Move] = (), initial: float = 0.0):
        self.initial = _scalar(initial, "initial angle")
        self.moves = sorted(moves, key=lambda m: m.start)
        end = -np.inf
        for m in self.moves:
            start = _scalar(m.start, "move start")
            d = check_positive(m.duration, "move duration")
            _scalar(m.angle, "move angle")
            _check_profile(m.profile, d, m.accel_time)
            if start < end - 1e-12:
                raise OptinavError(
                    f"move starting at {start:.6g} s overlaps the previous one (ends {end:.6g} s)",
                    "schedule the moves of one axis one after another",
                )
            end = start + d
        self._starts = np.array([m.start for m in self.moves], dtype=float)
        self._cum = np.concatenate([[0.0], np.cumsum([m.angle for m in self.moves])])

    @property
    def moving(self) -> list[tuple[float, float]]:
        return [(m.start, m.start + m.duration) for m in self.moves]

    @property
    def breakpoints(self) -> list[float]:
        out = []
        for m in self.moves:
            out += [m.start, m.start + m.duration] + [
                m.start + b for b in _profile_breaks(m.profile, m.duration, m.accel_time)
            ]
        return out

    @property
    def max_rate(self) -> float:
        return max([_profile_peak_rate(m.profile, m.duration, m.angle, m.accel_time) for m in self.moves], default=0.0)

    @property
    def min_duration(self) -> float:
        return min([m.duration for m in self.moves], default=np.inf)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        th = np.full(t.shape, self.initial)
        rt = np.zeros(t.shape)
        ac = np.zeros(t.shape)
        if not self.moves:
            return th, rt, ac
        i = np.searchsorted(self._starts, t, side="right") - 1  # last move started at or before t
        before = i < 0
        ic = np.clip(i, 0, None)
        th = th + np.where(before, 0.0, self._cum[ic])  # angle of the moves before move i
        ends = self._starts + np.array([m.duration for m in self.moves])
        done = ~before & (t >= ends[ic])
        th[done] += self._cum[ic[done] + 1] - self._cum[ic[done]]  # move i completed
        active = np.flatnonzero(~before & ~done)
        for k, sel in _groups(ic[active]):
            sel = active[sel]
            m = self.moves[k]
            a, r, c = rate_profile(m.profile, t[sel] - m.start, m.duration, m.angle, m.accel_time)
            th[sel] += a
            rt[sel] = r
            ac[sel] = c
        return th, rt, ac


def _groups(idx):
    """Yield (value, indices) for each distinct value of the integer array ``idx``."""
    idx = np.asarray(idx)
    if idx.size == 0:
        return
    order = np.argsort(idx, kind="stable")
    vals = idx[order]
    cut = np.flatnonzero(np.diff(vals)) + 1
    for grp in np.split(order, cut):
        yield int(idx[grp[0]]), grp


class _SegmentAngle:
    """θ(t) of one profile move in absolute time (a one-move schedule with a known closed form)."""

    def __init__(self, t0, duration, angle, profile, accel_time):
        self.t0, self.duration, self.angle = t0, duration, angle
        self.profile, self.accel_time = profile, accel_time

    def __call__(self, t):
        return rate_profile(self.profile, np.asarray(t, float) - self.t0, self.duration, self.angle, self.accel_time)


def chain_attitude(fixed, axes, theta, theta_dot, theta_ddot=None):
    """Attitude and body rate of a gimbal chain ``C = C_0 R_1(θ_1) C_1 R_2(θ_2) C_2 … R_k(θ_k) C_k``.

    With ``B_i = C_i R_{i+1} C_{i+1} … C_k`` (everything after joint i), ``Ċ = C [ω×]`` gives
    ``ω = Σ_i θ̇_i B_iᵀ a_i``; differentiating, ``ω̇ = Σ_i (θ̈_i B_iᵀ a_i − θ̇_i ω_{B_i} × B_iᵀ a_i)`` where
    ``ω_{B_i} = Σ_{j>i} θ̇_j B_jᵀ a_j`` is the rate of ``B_i`` (so ``d(B_iᵀ a)/dt = −ω_{B_i} × B_iᵀ a``).

    Parameters
    ----------
    fixed : sequence of k+1 (3, 3) array
        Constant DCMs [-] (exact rotations: build small misalignments with ``rot_axis`` or ``dcm_from_rotvec``,
        not ``I − [θ×]``).
    axes : sequence of k (3,) array
        Unit joint axes [-], ``R_i(θ) = rot_axis(axes[i], θ)``.
    theta : (k, M) array
        Joint angles [rad].
    theta_dot : (k, M) array
        Joint rates [rad/s].
    theta_ddot : (k, M) array or None
        Joint accelerations [rad/s^2].

    Returns
    -------
    C : (M, 3, 3) ndarray
        Chain attitude [-].
    omega : (M, 3) ndarray
        Body rate of the chain's last frame relative to the frame ``C`` maps into [rad/s].
    omega_dot : (M, 3) ndarray
        Its derivative [rad/s^2].
    """
    k = len(axes)
    if len(fixed) != k + 1:
        raise OptinavError(
            f"a chain with {k} joint(s) needs {k + 1} fixed DCMs, got {len(fixed)}",
            "give C_0 … C_k (use np.eye(3) where frames coincide)",
        )
    theta = np.atleast_2d(np.asarray(theta, float))
    theta_dot = np.atleast_2d(np.asarray(theta_dot, float))
    theta_ddot = np.zeros_like(theta) if theta_ddot is None else np.atleast_2d(np.asarray(theta_ddot, float))
    m = theta.shape[1] if k else 1
    axes = [unit_axis(a) for a in axes]
    B = np.broadcast_to(np.asarray(fixed[k], float), (m, 3, 3)).copy()
    omega = np.zeros((m, 3))  # rate of B (the tail of the chain) in its own last frame
    omega_dot = np.zeros((m, 3))
    for i in range(k - 1, -1, -1):
        u = np.einsum("mji,j->mi", B, axes[i])  # B_iᵀ a_i
        omega_dot = omega_dot + theta_ddot[i][:, None] * u - theta_dot[i][:, None] * np.cross(omega, u)
        omega = omega + theta_dot[i][:, None] * u
        B = np.asarray(fixed[i], float) @ rot_axis(axes[i], theta[i]) @ B
    return B, omega, omega_dot


# --- attitude pieces ----------------------------------------------------------------------------------------


class _Piece:
    """Attitude on [t0, t1] in ENU: ``attitude(t) → (C_b^n, ω_nb^b, ω̇_nb^b)``."""

    static = False
    max_step = np.inf
    breakpoints: Sequence[float] = ()

    def __init__(self, t0, t1, label):
        self.t0, self.t1, self.label = float(t0), float(t1), int(label)

    def omega_nb_integral(self, ta, tb):  # closed-form ∫ω_nb^b dt, or None when only quadrature works
        return None


class _Fixed(_Piece):
    static = True

    def __init__(self, t0, t1, label, c):
        super().__init__(t0, t1, label)
        self.c = c

    def attitude(self, t):
        n = np.size(t)
        return np.broadcast_to(self.c, (n, 3, 3)).copy(), np.zeros((n, 3)), np.zeros((n, 3))

    def omega_nb_integral(self, ta, tb):
        return np.zeros((np.size(ta), 3))


class _Chain(_Piece):
    def __init__(self, t0, t1, label, fixed, axes, angles, *, breakpoints=(), max_step=np.inf):
        super().__init__(t0, t1, label)
        self.fixed, self.axes, self.angles = fixed, [unit_axis(a) for a in axes], angles
        self.breakpoints = [b for b in breakpoints if t0 < b < t1]
        self.max_step = max_step

    def attitude(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        if not self.angles:
            c = np.asarray(self.fixed[0], float)
            return np.broadcast_to(c, (t.size, 3, 3)).copy(), np.zeros((t.size, 3)), np.zeros((t.size, 3))
        vals = [f(t) for f in self.angles]
        th = np.array([v[0] for v in vals])
        return chain_attitude(self.fixed, self.axes, th, np.array([v[1] for v in vals]), np.array([v[2] for v in vals]))

    def omega_nb_integral(self, ta, tb):
        if len(self.axes) != 1:
            return None
        # one joint: ω_nb^b = θ̇ C_1ᵀ a with C_1 constant, so ∫ω dt = C_1ᵀ a (θ(t_b) − θ(t_a)) exactly
        u = np.asarray(self.fixed[1], float).T @ self.axes[0]
        dth = self.angles[0](np.asarray(tb, float))[0] - self.angles[0](np.asarray(ta, float))[0]
        return np.asarray(dth)[..., None] * u


class _Coning(_Piece):
    def __init__(self, t0, t1, label, c0, beta, omega, phase):
        super().__init__(t0, t1, label)
        self.c0, self.beta, self.omega, self.phase = c0, beta, omega, phase
        self.q0 = quat_from_dcm(c0)
        self.max_step = 1.0 / abs(omega)

    def attitude(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        q = quat_multiply(self.q0, coning_attitude(self.beta, self.omega / (2 * np.pi), t, self.phase))
        w = coning_rate(self.beta, self.omega / (2 * np.pi), t, self.phase)
        p = self.omega * t + self.phase
        wd = self.omega**2 * np.sin(self.beta) * np.stack([-np.cos(p), -np.sin(p), np.zeros_like(p)], -1)
        return dcm_from_quat(q), w, wd

    def quat(self, t):
        return quat_multiply(self.q0, coning_attitude(self.beta, self.omega / (2 * np.pi), t, self.phase))

    def omega_nb_integral(self, ta, tb):
        return coning_increment(self.beta, self.omega / (2 * np.pi), ta, tb, self.phase)


class _Spline(_Piece):
    def __init__(self, t0, t1, label, spline, knots, max_step):
        super().__init__(t0, t1, label)
        self.spline = spline
        self.breakpoints = [k for k in knots if t0 < k < t1]
        self.max_step = max_step

    def attitude(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        return (self.spline(t).as_matrix(), np.atleast_2d(self.spline(t, 1)), np.atleast_2d(self.spline(t, 2)))


# --- translation ---------------------------------------------------------------------------------------


class _FixedPosition:
    """A static base: position constant, velocity and acceleration zero."""

    breakpoints: Sequence[float] = ()
    max_step = np.inf

    def __init__(self, lat, lon, h):
        self.p = np.array([lat, lon, h], float)

    def evaluate(self, t):
        n = np.size(t)
        z = np.zeros((n, 3))
        return np.broadcast_to(self.p, (n, 3)).copy(), z, z.copy()


class _TangentSpline:
    """Position as a spline p(t) (m) in the ENU tangent frame at (lat0, lon0, h0), mapped exactly to geodetic.

    ``r^e = r0^e + C_t^e p``, so ``v^e = C_t^e ṗ`` and ``v^n = C_e^n v^e`` at the current position;
    ``a^n = d v^n/dt = C_e^n C_t^e p̈ − ω_en^n × v^n`` because ``Ċ_e^n = −[ω_en^n ×] C_e^n``.
    With ``earth="none"`` the tangent frame itself is the (inertial) navigation frame: ``v^n = ṗ``, ``a^n = p̈``;
    positions are still reported as geodetic coordinates on the WGS-84 ellipsoid, for bookkeeping only.
    """

    def __init__(self, spline, lat0, lon0, h0, earth, knots):
        self.spline, self.earth = spline, earth
        self.geo = "wgs84" if earth == "none" else earth
        self.r0 = _earth.geodetic_to_ecef(lat0, lon0, h0, self.geo)
        self.c_t_e = _earth.dcm_e_to_n(lat0, lon0, "enu").T
        self.breakpoints = list(knots)
        self.max_step = np.inf

    def evaluate(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        p, v, a = self.spline(t), self.spline(t, 1), self.spline(t, 2)
        pos = _earth.ecef_to_geodetic(self.r0 + p @ self.c_t_e.T, self.geo)
        if self.earth == "none":
            return pos, v, a
        c_e_n = _earth.dcm_e_to_n(pos[:, 0], pos[:, 1], "enu")
        v_n = np.einsum("mij,jk,mk->mi", c_e_n, self.c_t_e, v)
        w_en = _earth.transport_rate(pos[:, 0], pos[:, 2], v_n, "enu", self.earth)
        a_n = np.einsum("mij,jk,mk->mi", c_e_n, self.c_t_e, a) - np.cross(w_en, v_n)
        return pos, v_n, a_n


def _omega_in_dot(pos, v, a, earth):
    """d/dt of the components of ω_in^n = ω_ie^n + ω_en^n (ENU), for the lever-arm term ω̇_ib.

    ω_ie^n = Ω[0, cos L, sin L]; ω_en^n = [−v_N/R_m, v_E/R_n, v_E tan L / R_n] with R_m = R_M(L) + h,
    R_n = R_N(L) + h; dR_N/dL = a e² sinL cosL / w³, dR_M/dL = 3 a (1 − e²) e² sinL cosL / w⁵, w² = 1 − e² sin²L,
    L̇ = v_N / R_m, ḣ = v_U.
    """
    e = _earth.constants(earth)
    lat, h = pos[:, 0], pos[:, 2]
    ve, vn, vu = v[:, 0], v[:, 1], v[:, 2]
    ae, an = a[:, 0], a[:, 1]
    s, c = np.sin(lat), np.cos(lat)
    w = np.sqrt(1 - e.e2 * s**2)
    rm, rn = _earth.radii(lat, h, e)
    ldot = vn / rm
    rm_dot = 3 * e.a * (1 - e.e2) * e.e2 * s * c / w**5 * ldot + vu
    rn_dot = e.a * e.e2 * s * c / w**3 * ldot + vu
    tan = s / c
    d_en = np.stack(
        [
            -(an * rm - vn * rm_dot) / rm**2,
            (ae * rn - ve * rn_dot) / rn**2,
            (ae * tan + ve * ldot / c**2) / rn - ve * tan * rn_dot / rn**2,
        ],
        -1,
    )
    d_ie = e.omega_ie * np.stack([np.zeros_like(lat), -s * ldot, c * ldot], -1)
    return d_ie + d_en


# --- the motion and its IMU outputs -------------------------------------------------------------------------


class _Motion:
    """Consecutive attitude pieces plus a translation, in ENU; knows how to produce exact IMU truth."""

    def __init__(self, pieces, translation, frame, earth, names, gravity_n=None):
        self.pieces, self.translation = pieces, translation
        self.frame, self.earth, self.names = frame, earth, list(names)
        self.starts = np.array([p.t0 for p in pieces])
        self.t_end = pieces[-1].t1
        g = np.zeros(3) if gravity_n is None else _vec_to_enu(np.asarray(gravity_n, float), frame)
        self.gravity_enu = g

    # --- evaluation at arbitrary times inside [0, t_end]
    def piece_index(self, t, prefer_static=True):
        t = np.atleast_1d(t)
        i = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        if prefer_static and len(self.pieces) > 1:
            # an epoch on the boundary of a rest and a move belongs to the rest (the rate is zero there)
            static = np.array([p.static for p in self.pieces])
            at_start = (t == self.starts[i]) & (i > 0)
            move_back = at_start & static[np.clip(i - 1, 0, None)] & ~static[i]
            i = np.where(move_back, i - 1, i)
        return i

    def attitude(self, t, idx=None):
        t = np.atleast_1d(np.asarray(t, float))
        idx = self.piece_index(t) if idx is None else idx
        c = np.empty((t.size, 3, 3))
        w = np.empty((t.size, 3))
        wd = np.empty((t.size, 3))
        for k, sel in _groups(idx):
            c[sel], w[sel], wd[sel] = self.pieces[k].attitude(t[sel])
        return c, w, wd

    def kinematics(self, t, idx=None, lever_arm=None):
        """ω_ib^b, f^b (at the lever arm when given), ω_nb^b, C_b^n, pos, v^n at times t (ENU)."""
        c, w_nb, wd_nb = self.attitude(t, idx)
        pos, v, a = self.translation.evaluate(t)
        c_n_b = np.swapaxes(c, -1, -2)
        if self.earth == "none":
            w_in = np.zeros_like(v)
            f_n = a - self.gravity_enu
        else:
            lat, h = pos[:, 0], pos[:, 2]
            w_ie = _earth.earth_rate(lat, "enu", self.earth)
            w_en = _earth.transport_rate(lat, h, v, "enu", self.earth)
            w_in = w_ie + w_en
            f_n = a + np.cross(2 * w_ie + w_en, v) - _earth.gravity_vector(lat, h, "enu", self.earth)
        w_in_b = np.einsum("mij,mj->mi", c_n_b, w_in)
        w_ib = w_nb + w_in_b
        f_b = np.einsum("mij,mj->mi", c_n_b, f_n)
        if lever_arm is not None:
            # f at body point r: f + ω̇_ib × r + ω_ib × (ω_ib × r) (rigid body; gravity gradient neglected);
            # ω̇_ib^b = ω̇_nb^b − ω_nb^b × C_n^b ω_in^n + C_n^b ω̇_in^n since Ċ_n^b = −[ω_nb^b ×] C_n^b
            wd_ib = wd_nb - np.cross(w_nb, w_in_b)
            if self.earth != "none" and not isinstance(self.translation, _FixedPosition):
                wd_ib = wd_ib + np.einsum("mij,mj->mi", c_n_b, _omega_in_dot(pos, v, a, self.earth))
            r = lever_arm
            f_b = f_b + np.cross(wd_ib, r) + np.cross(w_ib, np.cross(w_ib, r))
        return w_ib, f_b, w_nb, c, pos, v

    # --- increments
    def increments(self, t, lever_arm=None):
        """Exact ∫ω_ib^b dt and ∫f^b dt over each (t[k], t[k+1]]; see the module docstring."""
        n = t.size - 1
        breaks = [p.t0 for p in self.pieces[1:]]
        for p in self.pieces:
            breaks += list(p.breakpoints)
        breaks += list(self.translation.breakpoints)
        breaks = np.unique(np.asarray(breaks, float))
        breaks = breaks[(breaks > t[0]) & (breaks < t[-1])]
        s = np.union1d(t, breaks)
        parent = np.searchsorted(t, s[:-1], side="right") - 1
        mid = 0.5 * (s[:-1] + s[1:])
        idx = self.piece_index(mid, prefer_static=False)
        static_piece = np.array([p.static for p in self.pieces])
        step = np.array([min(p.max_step, self.translation.max_step) for p in self.pieces])
        moving_base = not isinstance(self.translation, _FixedPosition)
        is_static = static_piece[idx] & (not moving_base)
        length = np.diff(s)
        m = np.where(is_static, 1, np.ceil(length / step[idx] - 1e-9)).astype(int)
        m = np.maximum(m, 1)

        dtheta = np.zeros((n, 3))
        dv = np.zeros((n, 3))
        # closed-form ∫ω_nb per sub-interval where the piece has one
        closed = np.zeros(len(self.pieces), bool)
        for k, sel in _groups(idx):
            val = self.pieces[k].omega_nb_integral(s[:-1][sel], s[1:][sel])
            if val is not None:
                closed[k] = True
                np.add.at(dtheta, parent[sel], val)

        # static sub-intervals: constant integrand, one midpoint evaluation (exact)
        if np.any(is_static):
            j = np.flatnonzero(is_static)
            w_ib, f_b, w_nb, *_ = self.kinematics(mid[j], idx[j], lever_arm)
            np.add.at(dtheta, parent[j], (w_ib - w_nb) * length[j, None])
            np.add.at(dv, parent[j], f_b * length[j, None])

        # moving sub-intervals: m panels each, GL_ORDER nodes per panel
        j = np.flatnonzero(~is_static)
        if j.size:
            pj = np.repeat(j, m[j])
            first = np.cumsum(m[j]) - m[j]
            within = np.arange(pj.size) - np.repeat(first, m[j])
            h = length[pj] / m[pj]
            a = s[pj] + within * h
            a = np.where(within == m[pj] - 1, s[pj + 1] - h, a)  # last panel ends exactly on the sub-interval end
            for c0 in range(0, pj.size, _CHUNK):
                sl = slice(c0, c0 + _CHUNK)
                aa, hh, jj = a[sl], h[sl], pj[sl]
                tau = (aa + 0.5 * hh)[:, None] + (0.5 * hh)[:, None] * _GL_X[None, :]
                pid = np.repeat(idx[jj], GL_ORDER)
                w_ib, f_b, w_nb, *_ = self.kinematics(tau.ravel(), pid, lever_arm)
                w_q = w_ib - np.where(closed[pid][:, None], w_nb, 0.0)
                wts = (0.5 * hh)[:, None] * _GL_W[None, :]
                ith = np.einsum("pq,pqc->pc", wts, w_q.reshape(-1, GL_ORDER, 3))
                ifb = np.einsum("pq,pqc->pc", wts, f_b.reshape(-1, GL_ORDER, 3))
                np.add.at(dtheta, parent[jj], ith)
                np.add.at(dv, parent[jj], ifb)
        return dtheta, dv

    def labels(self, t):
        idx = self.piece_index(t)
        return np.array([self.pieces[i].label for i in idx], dtype=np.int64)

    def in_frame(self, c, v):
        """C_b^ENU and v^ENU in the motion's frame."""
        return (C_ENU_NED @ c, v @ C_ENU_NED.T) if self.frame == "ned" else (c, v)

    def simulate(self, t, lever_arm=None, quat=None) -> ImuTruth:
        t = np.asarray(t, float)
        w_ib, f_b, _, c, pos, v = self.kinematics(t, lever_arm=lever_arm)
        dtheta, dv = self.increments(t, lever_arm)
        c, v = self.in_frame(c, v)
        q = (
            quat_from_dcm(c)
            if quat is None
            else quat_canonical(quat if self.frame == "enu" else quat_multiply(_Q_ENU_NED, quat))
        )
        return ImuTruth(
            t=t,
            frame=self.frame,
            earth=self.earth,
            q_b_n=q,
            pos=pos,
            vel_n=v,
            gyr=w_ib,
            acc=f_b,
            dtheta=dtheta,
            dv=dv,
            labels=self.labels(t),
            segment_names=list(self.names),
        )


_Q_ENU_NED = np.array([0.0, np.sqrt(0.5), np.sqrt(0.5), 0.0])  # quaternion of C_ENU_NED (π about [1,1,0]/√2)


def _epochs(duration, rate, t):
    """Epochs: ``t`` if given (checked, inside [0, duration]), else k/rate for k = 0 … ⌊duration·rate⌋."""
    if t is not None:
        t = check_timestamps(t, "t")
        tol = 1e-9 * max(1.0, duration)
        if t[0] < -tol or t[-1] > duration + tol:
            raise OptinavError(
                f"epochs span [{t[0]:.6g}, {t[-1]:.6g}] s, outside the motion's [0, {duration:.6g}] s",
                "give epochs within the schedule's duration",
            )
        return np.clip(t, 0.0, duration)
    if rate is None:
        raise OptinavError("neither a sample rate nor epochs were given", "pass rate_hz (Hz) or t (s)")
    rate = check_positive(rate, "rate_hz")
    return np.arange(_intervals(duration, rate) + 1) / rate


def _intervals(duration, rate) -> int:
    """Sample intervals of ``duration`` [s] at ``rate`` [Hz] (epochs k/rate, k = 0 … n), at least one."""
    n = int(math.floor(duration * rate + 1e-9))
    if n < 1:
        raise OptinavError(
            f"duration {duration:.6g} s at {rate:.6g} Hz gives fewer than two epochs",
            "raise the sample rate or lengthen the motion",
        )
    return n


def _lever(lever_arm):
    if lever_arm is None:
        return None
    r = as_float_array(lever_arm, "lever_arm", last_dims=(3,))
    if r.ndim != 1:
        raise OptinavError(f"lever_arm must be one 3-vector (m), got shape {r.shape}", "pass [x, y, z] in m")
    return r


def _site(lat, lon, h, earth):
    lat = _check_lat(lat)
    lon, h = _scalar(lon, "lon"), _scalar(h, "height_m")
    return _FixedPosition(lat, lon, h)


def _gravity_arg(gravity, earth):
    if gravity is None:
        return None
    if earth != "none":
        raise OptinavError(
            "gravity can only be given with earth='none'",
            "drop gravity (the Earth model supplies it) or set earth='none'",
        )
    g = as_float_array(gravity, "gravity", last_dims=(3,))
    if g.ndim != 1:
        raise OptinavError(f"gravity must be one 3-vector g^n (m/s²), got shape {g.shape}", "pass [gx, gy, gz]")
    return g


# --- pose helpers -------------------------------------------------------------------------------------------

_UP = {"enu": np.array([0.0, 0.0, 1.0]), "ned": np.array([0.0, 0.0, -1.0])}
_NORTH = {"enu": np.array([0.0, 1.0, 0.0]), "ned": np.array([1.0, 0.0, 0.0])}
_DEFAULT_NORTH = {0: "y", 1: "z", 2: "y"}


def orientation_from_up(up, north=None, frame=DEFAULT_FRAME) -> np.ndarray:
    """``C_b^n`` of a level pose: body axis ``up`` points up, body axis ``north`` points north.

    Parameters
    ----------
    up : str or (3,) array
        Body axis name (``"x"``, ``"-z"``, …) or body vector [-].
    north : str, (3,) array or None
        Body axis pointing north, perpendicular to ``up``; None: ``y`` when x or z is up, ``z`` when y is up.
    frame : str
        ``"enu"`` or ``"ned"``.

    Returns
    -------
    (3, 3) ndarray
        ``C_b^n`` [-].
    """
    frame = frame_name(frame)
    u = unit_axis(up, "up")
    if north is None:
        north = _DEFAULT_NORTH[int(np.argmax(np.abs(u)))]
    nb = unit_axis(north, "north")
    if abs(u @ nb) > 1e-9:
        raise OptinavError(
            f"up axis {up!r} and north axis {north!r} are not perpendicular",
            "choose a north axis at right angles to the up axis",
        )
    e_b = np.cross(nb, u)  # body vector pointing east (ENU: east = north × up)
    body = np.stack([e_b, nb, u], 1)  # body coordinates of the E, N, U directions
    c_b_enu = body.T  # C_b^n maps body coordinates to ENU: rows are the E, N, U directions in body coordinates
    return C_ENU_NED @ c_b_enu if frame == "ned" else c_b_enu


def six_positions(frame=DEFAULT_FRAME) -> np.ndarray:
    """The standard six-position set: +x, −x, +y, −y, +z, −z up (default north axes).

    Parameters
    ----------
    frame : str
        ``"enu"`` or ``"ned"``.

    Returns
    -------
    (6, 3, 3) ndarray
        ``C_b^n`` [-].
    """
    return np.stack([orientation_from_up(a, frame=frame) for a in ("x", "-x", "y", "-y", "z", "-z")])


def _fmt_deg(x):
    d = math.degrees(x)
    return f"{d:.0f}" if abs(d - round(d)) < 1e-6 else f"{d:.2f}"


def describe_pose(C_b_n, frame=DEFAULT_FRAME) -> str:
    """Words a technician can follow: the body axis up/down, any tilt, and which axis faces north.

    E.g. ``"x up, y north"``, ``"z down, tilted 45° about y, x east"``.

    Parameters
    ----------
    C_b_n : (3, 3) array
        Attitude [-].
    frame : str
        ``"enu"`` or ``"ned"``.

    Returns
    -------
    str
        The description.
    """
    frame = frame_name(frame)
    c = _to_enu(np.asarray(C_b_n, float), frame)
    up_b = c.T @ _UP["enu"]
    k = int(np.argmax(np.abs(up_b)))
    s = 1.0 if up_b[k] > 0 else -1.0
    name = "xyz"[k]
    text = f"{name} {'up' if s > 0 else 'down'}"
    tilt = math.acos(min(1.0, abs(up_b[k])))
    if tilt > 1e-9:
        # C = C_up R(ax, tilt) gives up_b = R(ax, −tilt) s e_k, hence ax ∥ up_b × s e_k
        ax = np.cross(up_b, s * np.eye(3)[k])
        ax /= np.linalg.norm(ax)
        j = int(np.argmax(np.abs(ax)))
        if abs(abs(ax[j]) - 1) < 1e-9:
            text += f", tilted {_fmt_deg(tilt)}° about {'-' if ax[j] < 0 else ''}{'xyz'[j]}"
        else:
            ax = np.round(ax, 3) + 0.0  # + 0.0 turns −0.0 into 0.0
            text += f", tilted {_fmt_deg(tilt)}° about [{ax[0]:.3f}, {ax[1]:.3f}, {ax[2]:.3f}]"
    # heading: the most horizontal remaining body axis, named by its compass direction
    others = [i for i in range(3) if i != k]
    horiz = np.linalg.norm(c[:2, others], axis=0)  # E, N extent of the other two axes
    cand = [i for i, hz in zip(others, horiz) if hz >= horiz.max() - 1e-9]
    az_of = {i: math.degrees(math.atan2(c[0, i], c[1, i])) % 360 for i in cand}  # clockwise from north
    i2 = min(cand, key=lambda i: min(az_of[i], 360 - az_of[i]))  # of equally level axes, the one nearest north
    az = az_of[i2]
    dirs = {0: "north", 90: "east", 180: "south", 270: "west"}
    near = min(dirs, key=lambda d: min(abs(az - d), 360 - abs(az - d)))
    if min(abs(az - near), 360 - abs(az - near)) < 1e-6:
        text += f", {'xyz'[i2]} {dirs[near]}"
    else:
        text += f", {'xyz'[i2]} at azimuth {az:.2f}°"
    return text


# --- generators ----------------------------------------------------------------------------------------------


def static_positions(
    orientations,
    dwell,
    rate_hz,
    lat,
    height_m=0.0,
    lon=0.0,
    frame=DEFAULT_FRAME,
    earth="wgs84",
    transition=None,
    *,
    transition_profile="cosine",
    names=None,
    t=None,
    lever_arm=None,
    gravity=None,
) -> ImuTruth:
    """Static multi-position test: dwell at each pose, optionally turning smoothly between poses.

    Labels are the position index, -1 in transitions; ``segment_names`` describe each pose in words.

    Parameters
    ----------
    orientations : (P, 3, 3) array
        Attitudes ``C_b^n`` [-] in ``frame`` (:func:`orientation_from_up`, :func:`six_positions` or
        ``rotations.dcm_from_euler``).
    dwell : float or (P,) array
        Dwell per pose [s].
    rate_hz : float
        Sample rate [Hz].
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    lon : float
        Longitude [rad].
    frame : str
        ``"enu"`` or ``"ned"`` (module docstring).
    earth : str or EarthConstants
        Constant set, or ``"none"`` for an inertial navigation frame.
    transition : float, (P−1,) array or None
        Duration of a shortest-arc rotation about a fixed body axis between poses [s]; None: the pose changes
        instantly between two epochs (the increments across a jump are those of the piecewise-constant attitude,
        so prefer a transition).
    transition_profile : str
        Zero-rate-at-both-ends profile (:func:`rate_profile`).
    names : sequence of str or None
        Pose names; None: :func:`describe_pose`.
    t : (N+1,) array or None
        Epochs [s from the start], overriding ``rate_hz``.
    lever_arm : (3,) array or None
        Body position of the sensor relative to the reference point [m] (f adds ω̇×r + ω×(ω×r)).
    gravity : (3,) array or None
        Gravity g^n [m/s^2] in ``frame`` for ``earth="none"``; None: no gravity there.

    Returns
    -------
    ImuTruth
        Epochs [s], attitude, ``gyr`` [rad/s], ``acc`` [m/s^2] and exact increments [rad, m/s].
    """
    motion = _static_motion(
        orientations, dwell, lat, height_m, lon, frame, earth, transition, transition_profile, names, gravity
    )
    return motion.simulate(_epochs(motion.t_end, rate_hz, t), _lever(lever_arm))


class RateSampler:
    """The ideal rates of a motion at any epochs, for a log generated block by block (:func:`static_positions_sampler`).

    ``sampler(t)`` gives ``(gyr, acc, labels)`` at the epochs ``t`` [s] (clipped to [0, ``duration``]): ω_ib^b
    [rad/s], f^b [m/s^2] and the segment labels, as :func:`static_positions` gives them at those epochs.
    """

    def __init__(self, motion, lever_arm=None):
        self._motion, self._lever = motion, lever_arm
        self.duration = float(motion.t_end)
        self.segment_names = list(motion.names)

    def _each_window(self, t):
        """(rows, motion, its epochs) covering the epochs ``t``: one motion here (windows in a subclass)."""
        yield slice(None), self._motion, np.clip(np.atleast_1d(np.asarray(t, float)), 0.0, self.duration)

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = np.size(t)
        gyr, acc, labels = np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int64)
        for rows, motion, tw in self._each_window(t):
            gyr[rows], acc[rows] = motion.kinematics(tw, lever_arm=self._lever)[:2]
            labels[rows] = motion.labels(tw)
        return gyr, acc, labels

    def states(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ideal outputs and the attitude at epochs, as :class:`ImuTruth` holds them.

        Parameters
        ----------
        t : (n,) array
            Epochs [s] (clipped to [0, ``duration``]).

        Returns
        -------
        gyr : (n, 3) ndarray
            ω_ib^b [rad/s].
        acc : (n, 3) ndarray
            f^b [m/s^2].
        q_b_n : (n, 4) ndarray
            Attitude [w, x, y, z] in the motion's frame [-].
        """
        n = np.size(t)
        gyr, acc, q = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4))
        for rows, motion, tw in self._each_window(t):
            w_ib, f_b, _, c, _, v = motion.kinematics(tw, lever_arm=self._lever)
            gyr[rows], acc[rows], q[rows] = w_ib, f_b, quat_from_dcm(motion.in_frame(c, v)[0])
        return gyr, acc, q


def static_positions_sampler(orientations, dwell, lat, *, lever_arm=None, **options) -> RateSampler:
    """The motion of :func:`static_positions` as a :class:`RateSampler`: its rates at epochs given block by block,
    so that a long log need not be held at once (no increments, attitude or epochs are kept).

    Parameters
    ----------
    orientations, dwell, lat, lever_arm
        As :func:`static_positions`.
    **options
        Its other keywords but ``rate_hz`` and ``t``: ``height_m``, ``lon``, ``frame``, ``earth``, ``transition``,
        ``transition_profile``, ``names``, ``gravity``.

    Returns
    -------
    RateSampler
        ``sampler(t) -> (gyr [rad/s], acc [m/s^2], labels)``; ``sampler.duration`` [s].
    """
    kw = dict(height_m=0.0, lon=0.0, frame=DEFAULT_FRAME, earth="wgs84", transition=None)
    kw.update(transition_profile="cosine", names=None, gravity=None)
    unknown = sorted(set(options) - set(kw))
    if unknown:
        raise OptinavError(f"static_positions_sampler takes no {unknown[0]!r}", f"use one of {', '.join(kw)}")
    kw.update(options)
    return RateSampler(_static_motion(orientations, dwell, lat, **kw), _lever(lever_arm))


def _static_motion(
    orientations, dwell, lat, height_m, lon, frame, earth, transition, transition_profile, names, gravity
):
    """The motion of :func:`static_positions` (its arguments, checked here)."""
    h = height_m
    frame, earth = frame_name(frame), _check_earth(earth)
    cs = _as_dcms(orientations, "orientations")
    if cs.ndim == 2:
        cs = cs[None]
    P = cs.shape[0]
    dw = (
        np.broadcast_to(as_float_array(dwell, "dwell"), (P,)) if np.ndim(dwell) == 0 else as_float_array(dwell, "dwell")
    )
    if dw.shape != (P,):
        raise OptinavError(f"dwell has {dw.size} values for {P} positions", "give one dwell or one per position")
    if np.any(dw <= 0):
        raise OptinavError(f"dwell must be positive, got {float(dw.min()):.6g} s", "give each position a dwell > 0")
    if transition is None:
        tr = None
    else:
        tr = (
            np.broadcast_to(as_float_array(transition, "transition"), (max(P - 1, 0),))
            if np.ndim(transition) == 0
            else as_float_array(transition, "transition")
        )
        if tr.shape != (max(P - 1, 0),):
            raise OptinavError(
                f"transition has {tr.size} values for {P - 1} transitions", "give one duration or one per transition"
            )
        if np.any(tr <= 0):
            raise OptinavError("transition durations must be positive", "give durations > 0 or transition=None")
        _check_profile(transition_profile, 1.0, None)
    if names is not None and len(names) != P:
        raise OptinavError(f"{len(names)} names for {P} positions", "give one name per position")
    site = _site(lat, lon, h, earth)
    g = _gravity_arg(gravity, earth)
    c_enu = np.stack([_to_enu(c, frame) for c in cs])
    pieces, t0 = [], 0.0
    for p in range(P):
        pieces.append(_Fixed(t0, t0 + dw[p], p, c_enu[p]))
        t0 += dw[p]
        if tr is not None and p < P - 1:
            d = float(tr[p])
            rv = rotvec_from_dcm(c_enu[p].T @ c_enu[p + 1])  # shortest arc in the body frame
            ang = float(np.linalg.norm(rv))
            if ang < 1e-15:
                pieces.append(_Fixed(t0, t0 + d, -1, c_enu[p]))
            else:
                f = _SegmentAngle(t0, d, ang, transition_profile, None)
                step = 1.0 / (_profile_peak_rate(transition_profile, d, ang, None) + 2 * np.pi / d)
                pieces.append(_Chain(t0, t0 + d, -1, [c_enu[p], np.eye(3)], [rv / ang], [f], max_step=step))
            t0 += d
    seg_names = list(names) if names is not None else [describe_pose(c, frame) for c in cs]
    return _Motion(pieces, site, frame, earth, seg_names, g)


@dataclass(frozen=True)
class Rest:
    """Hold the current attitude for ``duration`` s."""

    duration: float
    name: str | None = None


@dataclass(frozen=True)
class Rotate:
    """Turn by ``angle`` (rad) in ``duration`` (s) about ``axis`` ("x", "-z", or a 3-vector).

    ``frame="body"``: the axis is fixed in the body (``C(t) = C_0 R(θ(t))``); ``"nav"``: fixed in the navigation
    frame / lab (``C(t) = R(θ(t)) C_0``). ``profile``: see :func:`rate_profile`.
    """

    axis: object
    angle: float
    duration: float
    frame: str = "body"
    profile: str = "cosine"
    accel_time: float | None = None
    name: str | None = None


def _axis_words(axis, frame):
    v = unit_axis(axis)
    j = int(np.argmax(np.abs(v)))
    sub = "b" if frame == "body" else "n"
    if abs(abs(v[j]) - 1) < 1e-12:
        return f"{'-' if v[j] < 0 else ''}{'xyz'[j]}_{sub}"
    v = np.round(v, 3) + 0.0
    return f"[{v[0]:.3f}, {v[1]:.3f}, {v[2]:.3f}]_{sub}"


def turntable(
    schedule,
    rate_hz,
    lat,
    height_m=0.0,
    initial=None,
    frame=DEFAULT_FRAME,
    earth="wgs84",
    *,
    lon=0.0,
    t=None,
    lever_arm=None,
    gravity=None,
) -> ImuTruth:
    """A turntable / gimbal schedule of :class:`Rest` and :class:`Rotate` segments on a static base.

    Labels are the segment index; ``segment_names`` give each segment in words (the pose at rest, the rotation
    otherwise). For two axes turning at once use :func:`gimbal`.

    Parameters
    ----------
    schedule : sequence of Rest and Rotate
        The segments (nav-frame rotation axes in ``frame``).
    rate_hz : float
        Sample rate [Hz].
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    initial : (3, 3) array or None
        ``C_b^n`` at t = 0 [-] in ``frame``; None: identity.
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set, or ``"none"``.
    lon : float
        Longitude [rad].
    t : (N+1,) array or None
        Epochs [s], overriding ``rate_hz``.
    lever_arm : (3,) array or None
        Body position of the sensor relative to the reference point [m] (f adds ω̇×r + ω×(ω×r)).
    gravity : (3,) array or None
        Gravity g^n [m/s^2] in ``frame`` for ``earth="none"``; None: no gravity there.

    Returns
    -------
    ImuTruth
        Epochs [s], attitude, ``gyr`` [rad/s], ``acc`` [m/s^2] and exact increments [rad, m/s].
    """
    rate, h = rate_hz, height_m
    frame, earth = frame_name(frame), _check_earth(earth)
    if not schedule:
        raise OptinavError("the turntable schedule is empty", "give a list of Rest and Rotate segments")
    c = np.eye(3) if initial is None else _as_dcms(initial, "initial")
    if c.ndim != 2:
        raise OptinavError("initial must be one 3×3 attitude", "pass a single C_b^n")
    c = _to_enu(c, frame)
    site = _site(lat, lon, h, earth)
    g = _gravity_arg(gravity, earth)
    pieces, names, t0 = [], [], 0.0
    for i, seg in enumerate(schedule):
        if isinstance(seg, Rest):
            d = check_positive(seg.duration, f"schedule[{i}] duration")
            pieces.append(_Fixed(t0, t0 + d, i, c))
            names.append(seg.name or f"rest, {describe_pose(_from_enu(c, frame), frame)}")
        elif isinstance(seg, Rotate):
            d = check_positive(seg.duration, f"schedule[{i}] duration")
            ang = _scalar(seg.angle, f"schedule[{i}] angle")
            if seg.frame not in ("body", "nav"):
                raise OptinavError(f"schedule[{i}] frame {seg.frame!r} is unknown", "use 'body' or 'nav'")
            _check_profile(seg.profile, d, seg.accel_time)
            a = unit_axis(seg.axis, f"schedule[{i}] axis")
            f = _SegmentAngle(t0, d, ang, seg.profile, seg.accel_time)
            brk = [t0 + b for b in _profile_breaks(seg.profile, d, seg.accel_time)]
            step = 1.0 / (_profile_peak_rate(seg.profile, d, ang, seg.accel_time) + 2 * np.pi / d)
            if seg.frame == "body":
                fixed, ax = [c, np.eye(3)], a
                c_end = c @ rot_axis(a, ang)
            else:
                ax = _vec_to_enu(a, frame)
                fixed = [np.eye(3), c]
                c_end = rot_axis(ax, ang) @ c
            pieces.append(_Chain(t0, t0 + d, i, fixed, [ax], [f], breakpoints=brk, max_step=step))
            names.append(
                seg.name or f"rotate {'+' if ang >= 0 else ''}{_fmt_deg(ang)}° about {_axis_words(seg.axis, seg.frame)}"
            )
            c = dcm_orthonormalize(c_end)
        else:
            raise OptinavError(f"schedule[{i}] is a {type(seg).__name__}", "use Rest(...) and Rotate(...) segments")
        t0 += d
    motion = _Motion(pieces, site, frame, earth, names, g)
    return motion.simulate(_epochs(t0, rate, t), _lever(lever_arm))


def gimbal(
    fixed,
    axes,
    angles,
    duration,
    rate_hz,
    lat,
    height_m=0.0,
    frame=DEFAULT_FRAME,
    earth="wgs84",
    *,
    lon=0.0,
    t=None,
    breakpoints=(),
    max_step=None,
    lever_arm=None,
    gravity=None,
) -> ImuTruth:
    """Exact truth of a gimbal chain ``C_b^n(t) = C_0 R_1(θ_1(t)) C_1 … R_k(θ_k(t)) C_k`` on a static base.

    Labels: rest intervals (all schedules at rest) are numbered 0, 1, …; motion is -1 (with plain callables the
    whole run is segment 0).

    Parameters
    ----------
    fixed : sequence of k+1 (3, 3) array
        Constant DCMs [-] (``C_0`` maps into the navigation frame ``frame``).
    axes : sequence of k str or (3,) array
        Joint axes (names or vectors [-], in the frame after the preceding fixed DCM).
    angles : sequence of k
        An :class:`AxisSchedule`, a constant [rad], or a callable ``t → (θ, θ̇, θ̈)`` [rad, rad/s, rad/s^2]
        (θ̈ only for lever arms).
    duration : float
        Length [s].
    rate_hz : float
        Sample rate [Hz] (or epochs ``t``).
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set, or ``"none"``.
    lon : float
        Longitude [rad].
    t : (N+1,) array or None
        Epochs [s].
    breakpoints : sequence of float
        For plain callables: times where θ̈ jumps [s].
    max_step : float or None
        Longest quadrature panel [s]: short enough that every angle function is smooth on it and the chain turns
        by < 1 rad (default: the median epoch spacing, shortened to 1/(1.5 max Σ|θ̇|) with the rates sampled at
        the epochs).
    lever_arm : (3,) array or None
        Body position of the sensor relative to the reference point [m] (f adds ω̇×r + ω×(ω×r)).
    gravity : (3,) array or None
        Gravity g^n [m/s^2] in ``frame`` for ``earth="none"``; None: no gravity there.

    Returns
    -------
    ImuTruth
        Epochs [s], attitude, ``gyr`` [rad/s], ``acc`` [m/s^2] and exact increments [rad, m/s].
    """
    motion, tt = _gimbal_motion(
        fixed,
        axes,
        angles,
        duration,
        lat,
        height_m,
        frame,
        earth,
        lon,
        breakpoints,
        max_step,
        gravity,
        lambda: _epochs(duration, rate_hz, t),
    )
    return motion.simulate(tt, _lever(lever_arm))


def _gimbal_motion(
    fixed, axes, angles, duration, lat, height_m, frame, earth, lon, breakpoints, max_step, gravity, epochs
):
    """The motion of :func:`gimbal` (its arguments, checked here) and its epochs: ``epochs()`` (called once, after
    the checks), or None, in which case plain angle callables need ``max_step``."""
    h = height_m
    frame, earth = frame_name(frame), _check_earth(earth)
    duration = check_positive(duration, "duration")
    k = len(axes)
    if len(angles) != k:
        raise OptinavError(f"{len(angles)} angle functions for {k} axes", "give one angle function per axis")
    fx = [_as_dcms(c, f"fixed[{i}]") for i, c in enumerate(fixed)]
    if len(fx) != k + 1:
        raise OptinavError(
            f"a chain with {k} joint(s) needs {k + 1} fixed DCMs, got {len(fx)}",
            "give C_0 … C_k (use np.eye(3) where frames coincide)",
        )
    fx[0] = _to_enu(fx[0], frame)
    funcs, brk, peak, schedules_only = [], list(breakpoints), 0.0, True
    for i, a in enumerate(angles):
        if isinstance(a, AxisSchedule):
            funcs.append(a)
            brk += a.breakpoints
            peak += a.max_rate + (2 * np.pi / a.min_duration if a.moves else 0.0)
        elif callable(a):
            funcs.append(a)
            schedules_only = False
        else:
            funcs.append(AxisSchedule([], initial=_scalar(a, f"angles[{i}]")))
    site = _site(lat, lon, h, earth)
    g = _gravity_arg(gravity, earth)
    tt = epochs()
    step = 1.0 / peak if peak > 0 else np.inf
    if max_step is not None:
        step = check_positive(max_step, "max_step")
    elif not schedules_only:
        if tt is None:
            raise OptinavError(
                "a gimbal with plain angle callables needs max_step here", "pass max_step [s] (e.g. the sample step)"
            )
        est = sum(float(np.max(np.abs(np.asarray(f(tt)[1], float)))) for f in funcs)
        step = min(step, float(np.median(np.diff(tt))), 1.0 / (1.5 * est + 1e-12))

    # pieces: rest intervals (every schedule at rest) and motion between them
    if schedules_only:
        moving = sorted(iv for f in funcs for iv in f.moving)
        merged = []
        for s0, s1 in moving:
            if merged and s0 <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], s1)
            else:
                merged.append([s0, s1])
        pieces, names, t0, label = [], [], 0.0, 0
        for s0, s1 in merged + [[duration, duration]]:
            s0, s1 = min(max(s0, 0.0), duration), min(max(s1, 0.0), duration)
            if s0 > t0:
                th = [float(f(np.array([t0]))[0][0]) for f in funcs]
                c_rest = chain_attitude(fx, axes, np.array(th)[:, None], np.zeros((k, 1)))[0][0]
                p = _Fixed(t0, s0, label, c_rest)
                pieces.append(p)
                angles_txt = ", ".join(f"θ{i + 1} = {_fmt_deg(x)}°" for i, x in enumerate(th))
                names.append(f"{angles_txt}: {describe_pose(_from_enu(c_rest, frame), frame)}")
                label += 1
            if s1 > s0:
                pieces.append(_Chain(s0, s1, -1, fx, axes, funcs, breakpoints=brk, max_step=step))
            t0 = max(t0, s1)
        if not pieces:
            pieces = [_Chain(0.0, duration, -1, fx, axes, funcs, breakpoints=brk, max_step=step)]
    else:
        pieces = [_Chain(0.0, duration, 0, fx, axes, funcs, breakpoints=brk, max_step=step)]
        names = ["gimbal motion"]
    return _Motion(pieces, site, frame, earth, names, g), tt


class IncrementSampler:
    """The exact increments of a motion over any consecutive epochs, for a log generated block by block
    (:func:`gimbal_sampler`; :class:`RateSampler` gives rates).

    ``sampler(t)`` gives ``(dtheta, dv)`` over ``(t[k], t[k+1]]`` for increasing epochs ``t`` (m+1) [s] within
    [0, ``duration``]: ∫ω_ib^b dt [rad] and ∫f^b dt [m/s] (m, 3), as the whole run's rows over those intervals
    (breaks of smoothness inside them are handled). The run's epochs are ``k / rate_hz``, k = 0 … ``n``
    (:meth:`epochs`), as the function the sampler stands for gives them.
    """

    def __init__(self, motion, rate_hz: float, lever_arm=None):
        self._motion, self._lever = motion, lever_arm
        self.duration = float(motion.t_end)
        self.rate_hz = check_positive(rate_hz, "rate_hz")
        #: sample intervals (rows) of the run: epochs 0 … n
        self.n = _intervals(self.duration, self.rate_hz)
        self.segment_names = list(motion.names)

    def epochs(self, i0: int, i1: int) -> np.ndarray:
        """Epochs ``i0`` … ``i1 − 1`` of the run (the same values as the whole run's).

        Parameters
        ----------
        i0, i1 : int
            First and one-past-last epoch index [-].

        Returns
        -------
        (i1 − i0,) ndarray
            Epochs [s].
        """
        return np.arange(i0, i1) / self.rate_hz

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray]:
        return self._motion.increments(np.asarray(t, float), self._lever)


def gimbal_sampler(fixed, axes, angles, duration, rate_hz, lat, *, lever_arm=None, **options) -> IncrementSampler:
    """The motion of :func:`gimbal` as an :class:`IncrementSampler`: its exact increments over epochs given block by
    block, so that a long run need not be held at once (no epochs, attitude or rates are kept).

    Parameters
    ----------
    fixed, axes, angles, duration, rate_hz, lat, lever_arm
        As :func:`gimbal`.
    **options
        Its other keywords but ``t``: ``height_m``, ``frame``, ``earth``, ``lon``, ``breakpoints``, ``max_step``
        (needed with plain angle callables: the default estimate samples the whole run), ``gravity``.

    Returns
    -------
    IncrementSampler
        ``sampler(t) -> (dtheta [rad], dv [m/s])``; ``sampler.n`` rows, ``sampler.epochs(i0, i1)`` [s].
    """
    kw = dict(height_m=0.0, frame=DEFAULT_FRAME, earth="wgs84", lon=0.0, breakpoints=(), max_step=None, gravity=None)
    unknown = sorted(set(options) - set(kw))
    if unknown:
        raise OptinavError(f"gimbal_sampler takes no {unknown[0]!r}", f"use one of {', '.join(kw)}")
    kw.update(options)
    motion, _ = _gimbal_motion(
        fixed,
        axes,
        angles,
        duration,
        lat,
        kw["height_m"],
        kw["frame"],
        kw["earth"],
        kw["lon"],
        kw["breakpoints"],
        kw["max_step"],
        kw["gravity"],
        lambda: None,
    )
    return IncrementSampler(motion, rate_hz, _lever(lever_arm))


# --- coning ---------------------------------------------------------------------------------------------


def coning_attitude(half_angle, frequency, t, phase=0.0) -> np.ndarray:
    """Classic coning attitude ``q(t)`` of the body relative to the reference frame (Savage §7.1.1).

    The body turns by the cone half-angle β about the reference-frame axis ``u(t) = [cos p, sin p, 0]``,
    ``p = Ωt + phase``, Ω = 2π·frequency: ``q = [cos(β/2), sin(β/2) cos p, sin(β/2) sin p, 0]``, so the body z
    axis sweeps a cone of half-angle β about the reference z axis.

    Parameters
    ----------
    half_angle : float
        Cone half-angle β [rad].
    frequency : float
        Coning frequency Ω/2π [Hz].
    t : float or array
        Times [s].
    phase : float
        Phase [rad].

    Returns
    -------
    (..., 4) ndarray
        q [w, x, y, z] [-].
    """
    p = 2 * np.pi * frequency * np.asarray(t, float) + phase
    c, s = math.cos(half_angle / 2), math.sin(half_angle / 2)
    return np.stack([np.full_like(p, c), s * np.cos(p), s * np.sin(p), np.zeros_like(p)], -1)


def coning_rate(half_angle, frequency, t, phase=0.0) -> np.ndarray:
    """Body rate of classic coning, ``ω = 2 q* ⊗ q̇`` = ``Ω[−sin β sin p, sin β cos p, −(1 − cos β)]``.

    Derivation: ``q̇ = [0, sin(β/2) u̇]`` with ``u·u̇ = 0``, ``u × u̇ = Ω e_z``, hence
    ``ω = 2 (cos(β/2) sin(β/2) u̇ − sin²(β/2) Ω e_z)``.

    Parameters
    ----------
    half_angle, frequency, t, phase
        As :func:`coning_attitude` [rad, Hz, s, rad].

    Returns
    -------
    (..., 3) ndarray
        ω [rad/s].
    """
    om = 2 * np.pi * frequency
    p = om * np.asarray(t, float) + phase
    sb, vc = math.sin(half_angle), 1.0 - math.cos(half_angle)
    return om * np.stack([-sb * np.sin(p), sb * np.cos(p), np.full_like(p, -vc)], -1)


def coning_increment(half_angle, frequency, t0, t1, phase=0.0) -> np.ndarray:
    """Closed-form ``Δθ = ∫_{t0}^{t1} ω dt`` of classic coning:
    ``[sin β (cos p1 − cos p0), sin β (sin p1 − sin p0), −Ω (1 − cos β)(t1 − t0)]``.

    Parameters
    ----------
    half_angle, frequency, phase
        As :func:`coning_attitude` [rad, Hz, rad].
    t0, t1 : float or array
        Interval ends [s].

    Returns
    -------
    (..., 3) ndarray
        Δθ [rad].
    """
    om = 2 * np.pi * frequency
    t0, t1 = np.asarray(t0, float), np.asarray(t1, float)
    p0, p1 = om * t0 + phase, om * t1 + phase
    sb, vc = math.sin(half_angle), 1.0 - math.cos(half_angle)
    return np.stack([sb * (np.cos(p1) - np.cos(p0)), sb * (np.sin(p1) - np.sin(p0)), -om * vc * (t1 - t0)], -1)


def coning_noncommutativity(half_angle, frequency, t0, t1, phase=0.0) -> np.ndarray:
    """Closed form of ``½ ∫_{t0}^{t1} α(t) × ω(t) dt``, ``α(t) = ∫_{t0}^{t} ω``, for classic coning.

    This is the second term of the Bortz rotation-vector series that summing Δθ omits (Savage §7.1.1,
    Ignagni 1990). With h = t1 − t0, p_i = Ω t_i + phase, s = sin β, v = 1 − cos β:

    * z: ``½ s² (Ωh − sin Ωh)`` — the classic coning drift, constant for every interval of equal length;
    * x: ``½ Ω v s [2 (cos p1 − cos p0)/Ω + h (sin p0 + sin p1)]``;
    * y: ``½ Ω v s [2 (sin p1 − sin p0)/Ω − h (cos p0 + cos p1)]``.

    Parameters
    ----------
    half_angle, frequency, phase
        As :func:`coning_attitude` [rad, Hz, rad].
    t0, t1 : float or array
        Interval ends [s].

    Returns
    -------
    (..., 3) ndarray
        The term [rad].
    """
    om = 2 * np.pi * frequency
    t0, t1 = np.asarray(t0, float), np.asarray(t1, float)
    h = t1 - t0
    p0, p1 = om * t0 + phase, om * t1 + phase
    s, v = math.sin(half_angle), 1.0 - math.cos(half_angle)
    x = om * v * s * (2 * (np.cos(p1) - np.cos(p0)) / om + h * (np.sin(p0) + np.sin(p1)))
    y = om * v * s * (2 * (np.sin(p1) - np.sin(p0)) / om - h * (np.cos(p0) + np.cos(p1)))
    z = s**2 * (om * h - np.sin(om * h))
    return 0.5 * np.stack([x, y, z], -1)


def coning(
    half_angle,
    frequency,
    duration,
    rate_hz,
    earth="none",
    *,
    frame=DEFAULT_FRAME,
    lat=0.0,
    height_m=0.0,
    lon=0.0,
    initial=None,
    phase=0.0,
    gravity=None,
    t=None,
    lever_arm=None,
) -> ImuTruth:
    """Classic coning motion with closed-form attitude, rate and increments (Savage, Strapdown Analytics §7.1.1).

    ``C_b^n(t) = C_0 · C(q_cone(t))`` with :func:`coning_attitude`; ``ω_nb^b`` is :func:`coning_rate` and its
    increments :func:`coning_increment` (exact). With ``earth="none"`` the navigation frame is inertial and,
    unless ``gravity`` is given, the specific force is zero; with an Earth model the base is static at
    (lat, lon, h) and the Earth-rate part of ``dtheta`` and ``dv`` come from quadrature.

    Parameters
    ----------
    half_angle : float
        Cone half-angle β [rad].
    frequency : float
        Coning frequency [Hz].
    duration : float
        Length [s].
    rate_hz : float
        Sample rate [Hz].
    earth : str or EarthConstants
        ``"none"`` (default) or a constant set.
    frame : str
        ``"enu"`` or ``"ned"``.
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    lon : float
        Longitude [rad].
    initial : (3, 3) array or None
        ``C_0`` [-]; None: identity.
    phase : float
        Phase of the cone axis at t = 0 [rad].
    gravity : (3,) array or None
        Gravity g^n [m/s^2] for ``earth="none"``.
    t : (N+1,) array or None
        Epochs [s], overriding ``rate_hz``.
    lever_arm : (3,) array or None
        Body position of the sensor relative to the reference point [m].

    Returns
    -------
    ImuTruth
        Epochs [s], attitude, ``gyr`` [rad/s], ``acc`` [m/s^2] and exact increments [rad, m/s].
    """
    rate, h = rate_hz, height_m
    frame, earth = frame_name(frame), _check_earth(earth)
    beta = _scalar(half_angle, "half_angle")
    if not (0 <= beta < np.pi):
        raise OptinavError(f"cone half-angle {beta:.6g} rad is outside [0, π)", "give the half-angle in radians")
    freq = check_positive(frequency, "frequency")
    duration = check_positive(duration, "duration")
    phase = _scalar(phase, "phase")
    c0 = np.eye(3) if initial is None else _as_dcms(initial, "initial")
    c0 = _to_enu(c0, frame)
    site = _site(lat, lon, h, earth)
    g = _gravity_arg(gravity, earth)
    piece = _Coning(0.0, duration, 0, c0, beta, 2 * np.pi * freq, phase)
    name = f"coning, half-angle {math.degrees(beta):.4g}°, {freq:.6g} Hz"
    motion = _Motion([piece], site, frame, earth, [name], g)
    tt = _epochs(duration, rate, t)
    return motion.simulate(tt, _lever(lever_arm), quat=piece.quat(tt))


# --- trajectory -----------------------------------------------------------------------------------------


def _bc_to_enu(bc_type, frame):
    """Derivative end conditions given in ``frame`` axes, in the ENU axes the spline is built in."""
    if isinstance(bc_type, str):
        return bc_type
    out = []
    for end in bc_type:
        if isinstance(end, str):
            out.append(end)
            continue
        order, value = end
        v = np.asarray(value, dtype=float)
        out.append((order, _vec_to_enu(v, frame) if v.shape == (3,) else v))
    return tuple(out)


def _trajectory_knots(t_knots, attitude_knots, position_knots, frame, earth, lat0, lon0, height0_m, gravity):
    """The checked knots of :func:`trajectory`: times, C_b^n (K, 3, 3) and positions (K, 3) in ``frame``."""
    frame, earth = frame_name(frame), _check_earth(earth)
    tk = check_timestamps(t_knots, "t_knots")
    K = tk.size
    if abs(tk[0]) > 1e-12:
        raise OptinavError(f"t_knots starts at {tk[0]:.6g} s", "start the knots at t = 0")
    att = np.asarray(attitude_knots, dtype=float)
    if att.shape == (K, 4):
        q = as_float_array(att, "attitude_knots", last_dims=(4,))
        if np.any(np.abs(np.linalg.norm(q, axis=-1) - 1) > _ORTHO_TOL):
            raise OptinavError("attitude_knots quaternions are not unit quaternions", "normalize them")
        cs = dcm_from_quat(q)
    elif att.shape == (K, 3, 3):
        cs = _as_dcms(att, "attitude_knots")
    else:
        raise OptinavError(
            f"attitude_knots has shape {att.shape}, expected ({K}, 3, 3) or ({K}, 4)", "give one attitude per knot"
        )
    pk = as_float_array(position_knots, "position_knots", last_dims=(3,))
    if pk.shape != (K, 3):
        raise OptinavError(f"position_knots has shape {pk.shape}, expected ({K}, 3)", "give one position per knot")
    site = (_check_lat(lat0, "lat0"), _scalar(lon0, "lon0"), _scalar(height0_m, "height0_m"))
    return tk, cs, pk, frame, earth, site, _gravity_arg(gravity, earth)


def _trajectory_motion(tk, cs, pk, bc_type, frame, earth, site, gravity) -> "_Motion":
    """The :class:`_Motion` of :func:`trajectory` through knots ``tk`` (from 0) with C_b^n ``cs`` and positions
    ``pk`` in ``frame`` and end conditions ``bc_type`` already in ENU axes."""
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import Rotation, RotationSpline

    K = tk.size
    cs = np.stack([_to_enu(c, frame) for c in cs])
    pk = _vec_to_enu(pk, frame)
    rs = RotationSpline(tk, Rotation.from_matrix(cs))
    try:
        ps = CubicSpline(tk, pk, axis=0, bc_type=bc_type)
    except ValueError as exc:
        raise OptinavError(f"cannot build the position spline ({exc})", "check bc_type and the knots") from None
    duration = float(tk[-1])
    # panel length: at most 1 rad of body rotation per panel, estimated on a fine grid (in slices: memory), and the
    # knot spacing
    fine = np.linspace(0, duration, 64 * K)
    wmax = max(
        float(np.max(np.linalg.norm(np.atleast_2d(rs(fine[i : i + 65536], 1)), axis=-1)))
        for i in range(0, fine.size, 65536)
    )
    step = min(float(np.min(np.diff(tk))), 1.0 / (1.5 * wmax + 1e-12))
    piece = _Spline(0.0, duration, 0, rs, tk, step)
    trans = _TangentSpline(ps, *site, earth, tk[1:-1])
    return _Motion([piece], trans, frame, earth, ["trajectory"], gravity)


#: knots per window of :class:`TrajectorySampler` (a longer trajectory is splined window by window) and the knots
#: each window's splines extend beyond it: a cubic spline's dependence on a knot decays by 2 − √3 ≈ 0.27 per knot,
#: so 64 knots away it is ~1e-37, far below rounding: the windows join as one spline through all knots would
TRAJECTORY_WINDOW_KNOTS = 16384
TRAJECTORY_WINDOW_PAD = 64


class TrajectorySampler(RateSampler):
    """The motion of :func:`trajectory` at any epochs, for a long log generated block by block: the splines are
    built over windows of :data:`TRAJECTORY_WINDOW_KNOTS` knots (each extended by :data:`TRAJECTORY_WINDOW_PAD`
    knots on both sides, so it agrees with one spline through all knots to rounding), one window at a time, so
    memory does not grow with the number of knots beyond the knots themselves; with no more knots than one window
    it is :func:`trajectory`'s motion exactly.

    ``sampler(t)`` and :meth:`states` as :class:`RateSampler` (labels 0: one segment). Epochs are best given in
    increasing order (one window is kept built).

    Parameters
    ----------
    t_knots, attitude_knots, position_knots, frame, earth, lat0, lon0, height0_m, bc_type, lever_arm, gravity
        As :func:`trajectory`.
    window_knots : int
        Knots per window.
    """

    def __init__(
        self,
        t_knots,
        attitude_knots,
        position_knots,
        frame=DEFAULT_FRAME,
        earth="wgs84",
        *,
        lat0,
        lon0=0.0,
        height0_m=0.0,
        bc_type="not-a-knot",
        lever_arm=None,
        gravity=None,
        window_knots: int = TRAJECTORY_WINDOW_KNOTS,
    ):
        tk, cs, pk, frame, earth, site, g = _trajectory_knots(
            t_knots, attitude_knots, position_knots, frame, earth, lat0, lon0, height0_m, gravity
        )
        self._knots, self._frame, self._earth, self._site, self._g = (tk, cs, pk), frame, earth, site, g
        bc = _bc_to_enu(bc_type, frame)
        self._bc = (bc, bc) if isinstance(bc, str) else tuple(bc)
        self._lever = _lever(lever_arm)
        self._w = max(int(window_knots), 1)
        self.windows = -(-(tk.size - 1) // self._w)
        self.duration = float(tk[-1])
        self.segment_names = ["trajectory"]
        self._built = (-1, None, 0.0)

    def _window_motion(self, j: int):
        if self._built[0] != j:
            tk, cs, pk = self._knots
            last = tk.size - 1
            a = 0 if j == 0 else j * self._w - TRAJECTORY_WINDOW_PAD
            b = last if j == self.windows - 1 else (j + 1) * self._w + TRAJECTORY_WINDOW_PAD
            a, b = max(a, 0), min(b, last)
            bc = (self._bc[0] if a == 0 else "not-a-knot", self._bc[1] if b == last else "not-a-knot")
            t0 = float(tk[a])
            tw = tk[a : b + 1] - t0 if a else tk[: b + 1]
            motion = _trajectory_motion(
                tw, cs[a : b + 1], pk[a : b + 1], bc, self._frame, self._earth, self._site, self._g
            )
            self._built = (j, motion, t0)
        return self._built[1], self._built[2]

    def _each_window(self, t):
        t = np.clip(np.atleast_1d(np.asarray(t, float)), 0.0, self.duration)
        tk = self._knots[0]
        starts = tk[np.arange(self.windows) * self._w]
        j = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, self.windows - 1)
        for w in np.unique(j):
            sel = np.flatnonzero(j == w)
            motion, t0 = self._window_motion(int(w))
            yield sel, motion, t[sel] - t0


def trajectory(
    t_knots,
    attitude_knots,
    position_knots,
    rate_hz,
    frame=DEFAULT_FRAME,
    earth="wgs84",
    *,
    lat0,
    lon0=0.0,
    height0_m=0.0,
    bc_type="not-a-knot",
    t=None,
    lever_arm=None,
    gravity=None,
) -> ImuTruth:
    """Smooth vehicle motion through knots: attitude by ``scipy.spatial.transform.RotationSpline``, position by a
    cubic spline in the tangent frame at (lat0, lon0, height0_m).

    The spline's rate and angular acceleration are analytic (body frame); the position maps exactly to lat/lon/h
    through ECEF; ``v^n`` and ``a^n`` are analytic (see ``_TangentSpline``), and ω_ib^b, f^b follow from the
    mechanization equations. Increments: Gauss–Legendre quadrature between knots.

    Parameters
    ----------
    t_knots : (K,) array
        Knot times from 0 [s].
    attitude_knots : (K, 3, 3) or (K, 4) array
        ``C_b^n`` or ``q_b^n`` [-] in ``frame``.
    position_knots : (K, 3) array
        Positions in the local tangent frame at the origin (axes of ``frame``) [m].
    rate_hz : float
        Sample rate [Hz].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.
    lat0, lon0 : float
        Origin [rad].
    height0_m : float
        Origin height [m].
    bc_type : str or tuple
        Passed to ``scipy.interpolate.CubicSpline`` (``"clamped"`` starts and stops at rest); derivative values of
        an explicit ``((order, value), (order, value))`` pair are in the axes of ``frame``.
    t : (N+1,) array or None
        Epochs [s], overriding ``rate_hz``.
    lever_arm : (3,) array or None
        Body position of the sensor relative to the reference point [m] (f adds ω̇×r + ω×(ω×r)).
    gravity : (3,) array or None
        Gravity g^n [m/s^2] in ``frame`` for ``earth="none"``; None: no gravity there.

    Returns
    -------
    ImuTruth
        Epochs [s], attitude, ``gyr`` [rad/s], ``acc`` [m/s^2] and exact increments [rad, m/s].
    """
    tk, cs, pk, frame, earth, site, g = _trajectory_knots(
        t_knots, attitude_knots, position_knots, frame, earth, lat0, lon0, height0_m, gravity
    )
    motion = _trajectory_motion(tk, cs, pk, _bc_to_enu(bc_type, frame), frame, earth, site, g)
    return motion.simulate(_epochs(float(tk[-1]), rate_hz, t), _lever(lever_arm))
