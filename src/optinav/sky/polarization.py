"""Skylight polarization: Rayleigh single scattering, the Berry singularity model, a point-source sensor.

Conventions (shared with :mod:`optinav.attitude.measurement`):

* Vectors may be in any frame; ``sun`` is the unit vector towards the sun, ``view`` the unit viewing direction
  (from the observer into the sky).
* Rayleigh single scattering: scattering angle γ = ∠(sun, view); degree of polarization
  d = d_max·sin²γ/(1 + cos²γ); the E-vector is perpendicular to the scattering plane, E ∝ sun × view.
* Sensor frame m: ``Z_m`` = viewing direction, ``X_m`` = reference axis, ``Y_m = Z_m × X_m``. The angle of
  polarization is α = atan2(E·Y_m, E·X_m), wrapped to [−π/2, π/2) — an axial angle, defined mod π.
  For a zenith-viewing sensor (view = Z_m) with the sun vector s_m in the sensor frame,
  E_m ∝ s_m × z = [s_y, −s_x, 0], α = atan2(−s_x, s_y) (mod π).
* Degeneracies: when the sun is on the viewing axis (or opposite to it, the antisolar point) s × v = 0 and
  the E-vector is undefined: the functions return E = 0, α = NaN and d = 0 there (``valid`` False).

References: Rayleigh (Strutt 1871); Berry, Dennis & Lee, "Polarization singularities in the clear sky",
New J. Phys. 6, 162 (2004), §3 (w(ζ) with four neutral points; d = |w|/(2 − |w|) reduces to Rayleigh when
the neutral-point separation δ → 0); Jin et al. (2021) for the sensor frame m. Sensor: Malus law with
finite extinction ratio (principal transmittances k1 = 1, k2 = 1/ER) and per-channel gain/offset errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optinav.core.units import DEG
from optinav.core.validate import as_float_array, as_rng
from optinav.errors import OptinavError

__all__ = [
    "DEFAULT_D_MAX",
    "DEFAULT_NEUTRAL_DISTANCE",
    "SkyPolarization",
    "scattering_angle",
    "rayleigh_dop",
    "sky_polarization",
    "aop_in_sensor",
    "zenith_aop",
    "wrap_axial",
    "PointSensor",
    "PolarizationReading",
]

#: maximum degree of polarization of a clear sky (chosen; measured clear-sky maxima are 0.6–0.85)
DEFAULT_D_MAX = 0.75
#: angular separation δ of the Babinet and Brewster neutral points (Berry et al. 2004 fit ≈ 20–40°; chosen)
DEFAULT_NEUTRAL_DISTANCE = 30.0 * DEG
#: |sun × view| below this is treated as the degenerate sun/antisun direction
_DEGENERATE = 1e-9


def wrap_axial(angle) -> np.ndarray:
    """Wrap an axial angle to [−π/2, π/2).

    Parameters
    ----------
    angle : float or array
        Angle [rad].

    Returns
    -------
    ndarray
        The wrapped angle [rad].
    """
    a = np.asarray(angle, dtype=float)
    return (a + 0.5 * np.pi) % np.pi - 0.5 * np.pi


def _unit(x, name) -> np.ndarray:
    a = as_float_array(x, name, last_dims=(3,))
    n = np.linalg.norm(a, axis=-1)
    if np.any(np.abs(n - 1.0) > 1e-6):
        raise OptinavError(
            f"{name} is not a unit vector (norm {float(np.max(np.abs(n - 1))) + 1:.6g})", f"normalize {name}"
        )
    return a / n[..., None]


def scattering_angle(sun, view) -> np.ndarray:
    """Scattering angle γ (rad) between unit vectors ``sun`` and ``view`` (any common frame), shape (...)."""
    s, v = np.broadcast_arrays(_unit(sun, "sun"), _unit(view, "view"))
    # atan2 of |s×v| and s·v keeps full precision near 0 and π
    return np.arctan2(np.linalg.norm(np.cross(s, v), axis=-1), np.sum(s * v, axis=-1))


def rayleigh_dop(gamma, d_max: float = DEFAULT_D_MAX) -> np.ndarray:
    """Rayleigh degree of polarization d_max·sin²γ/(1 + cos²γ) at scattering angle γ (rad)."""
    g = np.asarray(gamma, dtype=float)
    return d_max * np.sin(g) ** 2 / (1.0 + np.cos(g) ** 2)


@dataclass
class SkyPolarization:
    """E-vector (unit, in the frame of the inputs; 0 where undefined), degree of polarization, scattering
    angle γ (rad) and the validity mask of a sky-polarization evaluation."""

    e: np.ndarray
    dop: np.ndarray
    gamma: np.ndarray
    valid: np.ndarray = field(repr=False)


def _check_dmax(d_max) -> float:
    d = float(d_max)
    if not 0.0 <= d <= 1.0:
        raise OptinavError(f"d_max = {d} is outside [0, 1]", "pass a maximum degree of polarization in [0, 1]")
    return d


def sky_polarization(
    sun,
    view,
    *,
    model: str = "rayleigh",
    d_max: float = DEFAULT_D_MAX,
    up=None,
    neutral_distance: float = DEFAULT_NEUTRAL_DISTANCE,
) -> SkyPolarization:
    """Polarization of skylight seen in direction ``view`` with the sun at ``sun`` (unit vectors, one frame).

    ``model="rayleigh"``: E ∝ sun × view, d = d_max·sin²γ/(1 + cos²γ). ``model="berry"``: the
    Berry–Dennis–Lee
    (2004) pattern with the Babinet/Brewster neutral points δ = ``neutral_distance`` (rad) apart on the solar
    meridian around the sun (and their antipodes, Arago and the fourth point); needs ``up`` (the zenith in the
    frame of the vectors). δ → 0 gives Rayleigh exactly. Returns :class:`SkyPolarization`.
    """
    d_max = _check_dmax(d_max)
    s, v = np.broadcast_arrays(_unit(sun, "sun"), _unit(view, "view"))
    cross = np.cross(s, v)
    norm = np.linalg.norm(cross, axis=-1)
    gamma = np.arctan2(norm, np.sum(s * v, axis=-1))
    m = str(model).lower()
    if m == "rayleigh":
        valid = norm > _DEGENERATE
        e = np.where(valid[..., None], cross / np.where(valid, norm, 1.0)[..., None], 0.0)
        dop = np.where(valid, rayleigh_dop(gamma, d_max), 0.0)
        return SkyPolarization(e=e, dop=dop, gamma=gamma, valid=valid)
    if m == "berry":
        if up is None:
            raise OptinavError(
                "the Berry model needs the zenith direction", "pass up=[0, 0, -1] for NED, [0, 0, 1] for ENU"
            )
        return _berry(s, v, _unit(up, "up"), float(neutral_distance), d_max, gamma)
    raise OptinavError(f"unknown sky model {model!r}", "use 'rayleigh' or 'berry'")


def _berry(s, v, up, delta, d_max, gamma) -> SkyPolarization:
    if not 0.0 <= delta < np.pi / 2:
        raise OptinavError(f"neutral_distance = {delta} rad is outside [0, π/2)", "pass δ in rad, e.g. 0.5")
    up = np.broadcast_to(up, s.shape)
    # local sky frame: z = zenith, x = horizontal towards the sun's azimuth (any horizontal when sun at zenith)
    sh = s - np.sum(s * up, axis=-1, keepdims=True) * up
    nh = np.linalg.norm(sh, axis=-1, keepdims=True)
    alt = np.cross(up, np.where(np.abs(up[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    x = np.where(nh > 1e-12, sh / np.maximum(nh, 1e-300), alt / np.linalg.norm(alt, axis=-1, keepdims=True))
    y = np.cross(up, x)
    theta_s = np.arccos(np.clip(np.sum(s * up, axis=-1), -1.0, 1.0))  # sun zenith angle
    vx, vy, vz = np.sum(v * x, axis=-1), np.sum(v * y, axis=-1), np.sum(v * up, axis=-1)
    if np.any(vz <= -1 + 1e-9):
        raise OptinavError("a viewing direction points to the nadir", "the Berry model covers the sky above")
    zeta = (vx + 1j * vy) / (1.0 + vz)  # stereographic projection from the nadir: |ζ| = tan(θ/2)
    # neutral points on the solar meridian (real axis): Babinet above the sun, Brewster below (Berry §3)
    z_bab = np.tan((theta_s - delta / 2) / 2).astype(complex)
    z_bre = np.tan((theta_s + delta / 2) / 2).astype(complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        z_ara = -1.0 / np.conj(z_bre)
        z_4 = -1.0 / np.conj(z_bab)
        num = -4.0 * (zeta - z_bab) * (zeta - z_bre) * (zeta - z_ara) * (zeta - z_4)
        den = (1.0 + np.abs(zeta) ** 2) ** 2 * np.abs(z_bab - z_4) * np.abs(z_bre - z_ara)
        w = num / den
    aw = np.abs(w)
    valid = np.isfinite(aw) & (aw > 1e-12)
    beta = 0.5 * np.angle(w)  # E-vector direction in the ζ plane (conformal map: angles carry over)
    # tangent vector on the sphere: dP/dζ applied to e^{iβ}, P(ζ) the inverse stereographic projection
    a, b = zeta.real, zeta.imag
    d = 1.0 + a * a + b * b
    dpx = np.stack([(2 * d - 4 * a * a), -4 * a * b, -4 * a], axis=-1) / (d * d)[..., None]
    dpy = np.stack([-4 * a * b, (2 * d - 4 * b * b), -4 * b], axis=-1) / (d * d)[..., None]
    t = np.cos(beta)[..., None] * dpx + np.sin(beta)[..., None] * dpy  # in (x, y, up) coordinates
    e = t[..., :1] * x + t[..., 1:2] * y + t[..., 2:3] * up
    e = e / np.maximum(np.linalg.norm(e, axis=-1, keepdims=True), 1e-300)
    e = np.where(valid[..., None], e, 0.0)
    dop = np.where(valid, d_max * aw / (2.0 - aw), 0.0)
    return SkyPolarization(e=e, dop=dop, gamma=gamma, valid=valid)


def aop_in_sensor(e_m) -> np.ndarray:
    """Angle of polarization α = atan2(E_y, E_x) in [−π/2, π/2) of E-vector(s) given in the sensor frame m
    (NaN where E = 0)."""
    e = as_float_array(e_m, "e_m", last_dims=(3,))
    bad = np.hypot(e[..., 0], e[..., 1]) < _DEGENERATE
    return np.where(bad, np.nan, wrap_axial(np.arctan2(e[..., 1], e[..., 0])))


def zenith_aop(sun_m) -> np.ndarray:
    """Rayleigh AoP (rad, [−π/2, π/2)) seen by a sensor viewing along Z_m, sun unit vector ``sun_m`` in frame m:
    E_m ∝ s_m × z = [s_y, −s_x, 0] → α = atan2(−s_x, s_y); NaN when the sun is on the Z_m axis."""
    s = as_float_array(sun_m, "sun_m", last_dims=(3,))
    bad = np.hypot(s[..., 0], s[..., 1]) < _DEGENERATE
    return np.where(bad, np.nan, wrap_axial(np.arctan2(-s[..., 0], s[..., 1])))


# --- point-source sensor ----------------------------------------------------------------------------------


@dataclass
class PolarizationReading:
    """Output of :meth:`PointSensor.measure`: angle (rad, [−π/2, π/2)) and degree of polarization, the
    estimated total intensity, and the raw channel values (..., K)."""

    aop: np.ndarray
    dop: np.ndarray
    intensity: np.ndarray
    channels: np.ndarray


@dataclass
class PointSensor:
    """Point-source polarization sensor with K = 3 or 4 polarizer channels (orientations ψ_k from X_m towards
    Y_m, rad).

    Channel k (Malus law, principal transmittances 1 and 1/ER):
    I_k = I/2·[(1 + 1/ER) + (1 − 1/ER)·d·cos 2(α − ψ_k)];
    output y_k = gain_k·I_k + offset_k + n_k with n_k ~ N(0, (noise·I)²) (``noise`` relative to the intensity).
    :meth:`invert` solves the Stokes vector (S0, S1, S2) by least squares with the *nominal* model (the known
    extinction ratio, and ``assumed_gain``/``assumed_offset``, by default 1 and 0), so uncalibrated channel
    errors bias α and d as they would on a real sensor. Defaults (chosen): 0/60/120°, ER = 100, noise 0.2 %
    (≈0.1° AoP at d = 0.5 with 3 channels).
    """

    psi: np.ndarray = field(default_factory=lambda: np.array([0.0, 60.0, 120.0]) * DEG)
    extinction_ratio: float = 100.0
    gain: np.ndarray | None = None
    offset: np.ndarray | None = None
    noise: float = 0.002
    intensity: float = 1.0
    assumed_gain: np.ndarray | None = None
    assumed_offset: np.ndarray | None = None

    def __post_init__(self):
        self.psi = as_float_array(self.psi, "psi").ravel()
        k = self.psi.size
        if k not in (3, 4):
            raise OptinavError(
                f"a point sensor needs 3 or 4 polarizer channels, got {k}",
                "pass psi=(0, 60, 120) deg or (0, 45, 90, 135) deg in rad",
            )
        c = np.stack([np.cos(2 * self.psi), np.sin(2 * self.psi)])
        if np.linalg.matrix_rank(c, tol=1e-6) < 2:
            raise OptinavError(
                "the polarizer orientations do not resolve the angle (collinear in 2ψ)",
                "use orientations spread over 180°",
            )
        er = float(self.extinction_ratio)
        if not er > 1.0:
            raise OptinavError(f"extinction_ratio = {er} must be > 1", "pass e.g. 100 (or np.inf for ideal)")
        self.extinction_ratio = er
        for name, default in (("gain", 1.0), ("offset", 0.0), ("assumed_gain", 1.0), ("assumed_offset", 0.0)):
            val = getattr(self, name)
            val = np.full(k, default) if val is None else np.broadcast_to(as_float_array(val, name), (k,)).copy()
            setattr(self, name, val)
        if np.any(self.gain <= 0) or np.any(self.assumed_gain <= 0):
            raise OptinavError("channel gains must be positive", "pass gains near 1")
        if not (self.noise >= 0 and np.isfinite(self.noise)):
            raise OptinavError(f"noise = {self.noise} must be >= 0", "pass the relative intensity noise, e.g. 0.002")
        if not self.intensity > 0:
            raise OptinavError(f"intensity = {self.intensity} must be > 0", "pass a positive intensity")

    @classmethod
    def four_channel(cls, **kw) -> "PointSensor":
        """A 0/45/90/135° sensor."""
        return cls(psi=np.array([0.0, 45.0, 90.0, 135.0]) * DEG, **kw)

    @classmethod
    def with_random_errors(cls, gain_sigma: float, offset_sigma: float, rng=None, **kw) -> "PointSensor":
        """A sensor whose channel gains are 1 + N(0, gain_sigma²) and offsets N(0, (offset_sigma·I)²)."""
        rng = as_rng(rng)
        s = cls(**kw)
        k = s.psi.size
        return cls(
            **{
                **kw,
                "gain": 1.0 + rng.normal(0.0, gain_sigma, k),
                "offset": rng.normal(0.0, offset_sigma * s.intensity, k),
            }
        )

    @property
    def _eta(self) -> tuple[float, float]:
        inv = 0.0 if np.isinf(self.extinction_ratio) else 1.0 / self.extinction_ratio
        return 1.0 + inv, 1.0 - inv

    def design(self) -> np.ndarray:
        """Nominal (K, 3) matrix mapping Stokes (S0, S1, S2) to ideal channel intensities."""
        a, b = self._eta
        return 0.5 * np.stack([np.full_like(self.psi, a), b * np.cos(2 * self.psi), b * np.sin(2 * self.psi)], axis=1)

    def channels(self, aop, dop, rng=None, *, noise: bool = True, draws=None) -> np.ndarray:
        """Raw channel outputs (..., K) for true angle ``aop`` (rad, frame m) and degree ``dop``; the noise from
        ``rng``, or from ``draws`` (..., K) standard normal draws when given (a simulation drawn by sample index)."""
        al = np.asarray(aop, dtype=float)
        d = np.asarray(dop, dtype=float)
        al, d = np.broadcast_arrays(np.where(np.isfinite(al), al, 0.0), np.where(np.isfinite(al), d, 0.0))
        if np.any((d < 0) | (d > 1)):
            raise OptinavError("dop outside [0, 1]", "pass a degree of polarization in [0, 1]")
        stokes = self.intensity * np.stack([np.ones_like(d), d * np.cos(2 * al), d * np.sin(2 * al)], axis=-1)
        ideal = stokes @ self.design().T
        y = ideal * self.gain + self.offset
        if noise and self.noise > 0:
            sigma = self.noise * self.intensity
            if draws is None:
                y = y + as_rng(rng).normal(0.0, sigma, y.shape)
            else:
                z = np.asarray(draws, float)
                if z.shape != y.shape:
                    raise OptinavError(f"draws have shape {z.shape}, the channels {y.shape}", "pass one per channel")
                y = y + sigma * z
        return y

    def invert(self, y) -> PolarizationReading:
        """Least-squares Stokes inversion of channel outputs (..., K) with the nominal sensor model."""
        y = as_float_array(y, "y", last_dims=(self.psi.size,))
        z = (y - self.assumed_offset) / self.assumed_gain
        s = z @ np.linalg.pinv(self.design()).T  # (..., 3)
        s0 = s[..., 0]
        p = np.hypot(s[..., 1], s[..., 2])
        aop = wrap_axial(0.5 * np.arctan2(s[..., 2], s[..., 1]))
        with np.errstate(divide="ignore", invalid="ignore"):
            dop = np.where(s0 > 0, p / s0, np.nan)
        return PolarizationReading(aop=aop, dop=dop, intensity=s0, channels=y)

    def measure(self, aop, dop, rng=None, *, noise: bool = True, draws=None) -> PolarizationReading:
        """Channels then inversion: the sensor's measured angle and degree of polarization (``draws``: as
        :meth:`channels`)."""
        return self.invert(self.channels(aop, dop, rng, noise=noise, draws=draws))

    def aop_sigma(self, dop) -> np.ndarray:
        """Theoretical 1σ AoP noise (rad) from the channel noise (small-noise, ideal gains): the LS covariance
        of (S1, S2) projected across the polarization direction, σ_α = ½·σ_⊥/(I·d)."""
        cov = np.linalg.inv(self.design().T @ self.design()) * (self.noise * self.intensity) ** 2
        # equally spaced channels give an isotropic (S1, S2) covariance; use its mean variance otherwise
        var_perp = 0.5 * (cov[1, 1] + cov[2, 2])
        return 0.5 * np.sqrt(var_perp) / (self.intensity * np.asarray(dop, dtype=float))
