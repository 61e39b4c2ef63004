"""Installation errors of an accelerometer array and their effect on the solved angular rate.

Per accelerometer i (Hao & Liu 2011, §2): position error ``Δr_i`` (m, body xyz) and two direction angles
(rad) in the sensor's local frame ``(e1, e2, e3)``: e1 = nominal sensing direction, e2 = unit(ẑ × e1)
(for e1 = ±ẑ: e2 = x̂), e3 = e1 × e2. For a sensor along +x this is (x, y, z): Δα is the angle of the
sensing axis out of the xOy plane, Δβ the angle of its xOy projection from x. Exact direction

    θ = cos Δα cos Δβ e1 + cos Δα sin Δβ e2 + sin Δα e3

(the paper's text says "about z by Δβ, then about x by Δα", but a turn about x leaves the x axis where it is;
its stated small-angle result θ = [1, Δβ, Δα]ᵀ is the first-order form of the spherical angles above).
``small_angle=True`` uses θ = e1 + Δβ e2 + Δα e3 (not normalized, as in the paper).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optinav.core.rotations import dcm_from_quat
from optinav.core.simulate import coning_attitude, coning_rate
from optinav.core.validate import as_float_array, as_rng
from optinav.errors import OptinavError
from optinav.gfimu.array import AccelerometerArray

__all__ = [
    "local_frames",
    "InstallationErrors",
    "direction",
    "direction_derivatives",
    "perturb",
    "errors_from_geometry",
    "Motion",
    "coning_motion",
    "spinning_motion",
    "error_effect",
    "COEFFICIENT_NAMES",
]

COEFFICIENT_NAMES = ("dr_x", "dr_y", "dr_z", "dalpha", "dbeta")


def local_frames(directions) -> np.ndarray:
    """(N, 3, 3) rows e1, e2, e3 of each sensor's local frame (see the module docstring)."""
    e1 = np.asarray(directions, float)
    e1 = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(np.array([0.0, 0.0, 1.0]), e1)
    n = np.linalg.norm(e2, axis=-1, keepdims=True)
    along_z = n[:, 0] < 1e-9
    e2 = np.where(along_z[:, None], np.array([1.0, 0.0, 0.0]), e2 / np.where(n > 0, n, 1.0))
    e3 = np.cross(e1, e2)
    return np.stack([e1, e2, e3], axis=1)


def direction(frames, dalpha, dbeta, small_angle: bool = False) -> np.ndarray:
    """Actual sensing directions (N, 3) for angles Δα, Δβ (N,) rad in ``frames`` (N, 3, 3)."""
    a, b = np.asarray(dalpha, float), np.asarray(dbeta, float)
    if small_angle:
        c = np.stack([np.ones_like(a), b, a], -1)
    else:
        c = np.stack([np.cos(a) * np.cos(b), np.cos(a) * np.sin(b), np.sin(a)], -1)
    return np.einsum("nk,nkj->nj", c, frames)


def direction_derivatives(frames, dalpha, dbeta) -> tuple[np.ndarray, np.ndarray]:
    """∂θ/∂Δα and ∂θ/∂Δβ (each (N, 3)) of the exact direction."""
    a, b = np.asarray(dalpha, float), np.asarray(dbeta, float)
    da = np.stack([-np.sin(a) * np.cos(b), -np.sin(a) * np.sin(b), np.cos(a)], -1)
    db = np.stack([-np.cos(a) * np.sin(b), np.cos(a) * np.cos(b), np.zeros_like(a)], -1)
    return np.einsum("nk,nkj->nj", da, frames), np.einsum("nk,nkj->nj", db, frames)


@dataclass
class InstallationErrors:
    """Δr (N, 3) m, Δα (N,) rad, Δβ (N,) rad; ``vector()`` orders them per sensor as COEFFICIENT_NAMES."""

    dr: np.ndarray
    dalpha: np.ndarray
    dbeta: np.ndarray

    def __post_init__(self):
        self.dr = as_float_array(self.dr, "dr", last_dims=(3,)).reshape(-1, 3)
        n = self.dr.shape[0]
        self.dalpha = np.broadcast_to(as_float_array(self.dalpha, "dalpha"), (n,)).astype(float)
        self.dbeta = np.broadcast_to(as_float_array(self.dbeta, "dbeta"), (n,)).astype(float)

    @property
    def n(self) -> int:
        return self.dr.shape[0]

    @classmethod
    def uniform(cls, n: int, dr: float = 0.001, dangle: float = 0.01) -> "InstallationErrors":
        """The paper's case: the same error on every sensor.

        Parameters
        ----------
        n : int
            Number of sensors.
        dr : float
            Position error Δr on every axis [m].
        dangle : float
            Direction errors Δα = Δβ [rad].

        Returns
        -------
        InstallationErrors
            The errors.
        """
        return cls(np.full((n, 3), dr), np.full(n, dangle), np.full(n, dangle))

    @classmethod
    def random(cls, n: int, dr_std: float = 0.001, angle_std: float = 0.01, rng=None) -> "InstallationErrors":
        """Errors drawn from zero-mean normal distributions.

        Parameters
        ----------
        n : int
            Number of sensors.
        dr_std : float
            1σ of each position error [m].
        angle_std : float
            1σ of Δα and Δβ [rad].
        rng : int, Generator or None
            Seed or generator.

        Returns
        -------
        InstallationErrors
            The errors.
        """
        g = as_rng(rng)
        return cls(g.normal(0, dr_std, (n, 3)), g.normal(0, angle_std, n), g.normal(0, angle_std, n))

    @classmethod
    def zeros(cls, n: int) -> "InstallationErrors":
        """No installation error.

        Parameters
        ----------
        n : int
            Number of sensors.

        Returns
        -------
        InstallationErrors
            Zero errors.
        """
        return cls(np.zeros((n, 3)), np.zeros(n), np.zeros(n))

    @classmethod
    def from_vector(cls, v) -> "InstallationErrors":
        """Errors from the stacked vector of :meth:`vector`.

        Parameters
        ----------
        v : (5n,) array
            Per sensor (Δr_x, Δr_y, Δr_z [m], Δα, Δβ [rad]).

        Returns
        -------
        InstallationErrors
            The errors.
        """
        v = np.asarray(v, float).reshape(-1, 5)
        return cls(v[:, :3], v[:, 3], v[:, 4])

    def vector(self) -> np.ndarray:
        """The errors stacked per sensor, in the order of :meth:`names`.

        Returns
        -------
        (5n,) ndarray
            (Δr_x, Δr_y, Δr_z [m], Δα, Δβ [rad]) per sensor.
        """
        return np.column_stack([self.dr, self.dalpha, self.dbeta]).ravel()

    @staticmethod
    def names(n: int) -> list[str]:
        """Names of the entries of :meth:`vector`.

        Parameters
        ----------
        n : int
            Number of sensors.

        Returns
        -------
        list of str
            ``"<coefficient>_<sensor>"``, sensors numbered from 1.
        """
        return [f"{c}_{i + 1}" for i in range(n) for c in COEFFICIENT_NAMES]


def perturb(nominal: AccelerometerArray, errors: InstallationErrors, small_angle: bool = False) -> AccelerometerArray:
    """The actual array: positions r + Δr, directions rotated by Δα, Δβ in each local frame.

    Parameters
    ----------
    nominal : AccelerometerArray
        The design geometry.
    errors : InstallationErrors
        One set per sensor.
    small_angle : bool
        First-order rotation of the directions.

    Returns
    -------
    AccelerometerArray
        The perturbed array.
    """
    if errors.n != nominal.n:
        raise OptinavError(
            f"{errors.n} sets of installation errors for {nominal.n} accelerometers", "give one set per accelerometer"
        )
    th = direction(local_frames(nominal.directions), errors.dalpha, errors.dbeta, small_angle)
    if small_angle:
        # keep the paper's unnormalized small-angle direction; AccelerometerArray would reject |θ| ≠ 1
        arr = AccelerometerArray(
            nominal.positions + errors.dr, th / np.linalg.norm(th, axis=1)[:, None], nominal.noise, nominal.name
        )
        arr.directions = th
        return arr
    return AccelerometerArray(nominal.positions + errors.dr, th, nominal.noise, nominal.name)


def errors_from_geometry(nominal: AccelerometerArray, positions, directions) -> InstallationErrors:
    """Installation errors that turn ``nominal`` into the given geometry (exact angles)."""
    fr = local_frames(nominal.directions)
    th = np.asarray(directions, float)
    th = th / np.linalg.norm(th, axis=1, keepdims=True)
    c = np.einsum("nkj,nj->nk", fr, th)
    return InstallationErrors(
        np.asarray(positions, float) - nominal.positions,
        np.arcsin(np.clip(c[:, 2], -1, 1)),
        np.arctan2(c[:, 1], c[:, 0]),
    )


# ------------------------------------------------------------------------------------------------------------
# motions and the effect of the errors
# ------------------------------------------------------------------------------------------------------------


@dataclass
class Motion:
    """Body motion sampled at ``t`` (T,) s: A (T, 3) m/s², wdot (T, 3) rad/s², omega (T, 3) rad/s."""

    t: np.ndarray
    A: np.ndarray
    wdot: np.ndarray
    omega: np.ndarray
    name: str = ""


def coning_motion(
    duration: float = 100.0,
    dt: float = 0.01,
    half_angle: float = np.radians(10.0),
    frequency: float = 0.5,
    gravity: float | None = None,
) -> Motion:
    """Classic coning (``optinav.core.simulate.coning_rate``; Savage §7.1.1) and its exact ω̇.

    A = 0 (a free body, as for a projectile where only drag acts) unless ``gravity`` is given: then the specific
    force of a body whose centre rests, ``A = C_n^b [0, 0, g]``.

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample step [s].
    half_angle : float
        Cone half-angle [rad].
    frequency : float
        Coning frequency [Hz].
    gravity : float or None
        g [m/s^2] of a resting centre; None: A = 0.

    Returns
    -------
    Motion
        ``t`` [s], ``A`` [m/s^2], ``wdot`` [rad/s^2], ``omega`` [rad/s].
    """
    t = np.arange(0.0, duration + 0.5 * dt, dt)
    w = coning_rate(half_angle, frequency, t)
    om = 2 * np.pi * frequency
    p = om * t
    sb = np.sin(half_angle)
    wdot = om * om * np.stack([-sb * np.cos(p), -sb * np.sin(p), np.zeros_like(p)], -1)
    if gravity is None:
        A = np.zeros_like(w)
    else:
        C = dcm_from_quat(coning_attitude(half_angle, frequency, t))  # C_b^n
        A = np.einsum("tji,j->ti", C, np.array([0.0, 0.0, gravity]))
    return Motion(t, A, wdot, w, f"coning {np.degrees(half_angle):.3g}°, {frequency:.3g} Hz")


def spinning_motion(
    duration: float = 200.0,
    dt: float = 0.01,
    spin: float = 2.0,
    nutation: float = 0.2,
    frequency: float = 0.2,
    drag: float = 0.5,
) -> Motion:
    """Spinning projectile: ω = [spin, n cos Ωt, n sin Ωt] with drag along −x.

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample step [s].
    spin : float
        Spin rate about body x [rad/s].
    nutation : float
        Nutation amplitude n on y/z [rad/s].
    frequency : float
        Nutation frequency Ω/2π [Hz].
    drag : float
        Drag deceleration along −x [m/s^2].

    Returns
    -------
    Motion
        ``t`` [s], ``A`` [m/s^2], ``wdot`` [rad/s^2], ``omega`` [rad/s].
    """
    t = np.arange(0.0, duration + 0.5 * dt, dt)
    om = 2 * np.pi * frequency
    w = np.stack([np.full_like(t, spin), nutation * np.cos(om * t), nutation * np.sin(om * t)], -1)
    wdot = np.stack([np.zeros_like(t), -nutation * om * np.sin(om * t), nutation * om * np.cos(om * t)], -1)
    A = np.zeros_like(w)
    A[:, 0] = -drag
    return Motion(t, A, wdot, w, f"spinning projectile {spin:.3g} rad/s")


def error_effect(
    nominal: AccelerometerArray,
    actual: AccelerometerArray,
    motion: Motion,
    method: str = "integration",
    noise: float = 0.0,
    rng=None,
    solver_array: AccelerometerArray | None = None,
) -> np.ndarray:
    """Rate error when ``actual`` measures ``motion`` and the solver assumes ``solver_array``.

    Parameters
    ----------
    nominal : AccelerometerArray
        The design geometry (the solver's array by default, i.e. uncompensated).
    actual : AccelerometerArray
        The array that measures.
    motion : Motion
        The true motion.
    method : str
        Rate solver, one of :data:`optinav.gfimu.solve.RATE_METHODS`.
    noise : float
        White output noise std [m/s^2].
    rng : int, Generator or None
        Seed or generator of the noise.
    solver_array : AccelerometerArray or None
        The array the solver assumes (pass the calibrated array to compensate); None: ``nominal``.

    Returns
    -------
    (T, 3) ndarray
        Estimated minus true rate [rad/s].
    """
    from optinav.gfimu.solve import solve_rate

    f = actual.outputs(motion.A, motion.wdot, motion.omega)
    if noise > 0:
        f = f + as_rng(rng).normal(0.0, noise, f.shape)
    w = solve_rate(solver_array if solver_array is not None else nominal, f, motion.t, motion.omega[0], method)
    return w - motion.omega
