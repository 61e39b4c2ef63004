"""IMU error and noise models: one linear deterministic model per sensor triad plus optional noise.

Deterministic part of a triad (accelerometer or gyroscope), in the sensor's output axes::

    y = K x + b  (+ G f for a gyroscope),   K = diag(1 + s) · (I + M)

x is the true input (ω rad/s or f m/s²), b the bias, s the scale-factor errors (dimensionless), M the
misalignment (zero diagonal, small angles in rad) and G the gyro g-sensitivity (rad/s per m/s²) acting on
the true specific force f. Index meaning: ``M[i, j]`` (M_ij) is the sensitivity of sensor axis i to input
axis j, so ``M_xy`` is row x, column y. With this factorization K_ij = (1 + s_i)·M_ij, which is the
accelerometer paper's E_ij = S_ii·M_ij with S_ii = 1 + s_i (Gao & Zhang, MEMS accelerometer calibration
by adaptive genetic algorithm, eq. 1). The upper-triangular form keeps only M_xy, M_xz, M_yz (K upper
triangular), the parametrization identifiable from norm observations. For increments (Δθ rad, Δv m/s
over an interval dt) the same model reads Δy = K Δx + b·dt (+ G Δv).

Noise part (each optional, independent per axis, added to the output in the sensor axes): white noise of
density N (ARW rad/√s, VRW m/s/√s = m/s²/√Hz) with σ = N/√dt on rates and N·√dt on increments; bias
instability as a first-order Gauss–Markov process (stationary σ, correlation time τ, exact
discretization φ = exp(−dt/τ)); rate / acceleration random walk K (σ of a step = K·√dt); then
saturation (clip at the measurement range, flags returned) and quantization (LSB on the rate or on the
increment, the residual carried to the next sample as integrating outputs do). dt may vary per sample.

Two levels: :class:`ImuSpec` is a 1σ engineering specification (a datasheet); ``spec.draw(rng)`` draws
one unit, an :class:`ImuModel`, whose ``apply`` turns true motion into measurements and whose
``compensate`` inverts the deterministic part exactly. :func:`preset` returns the specs of the sensors
the optinav papers use. Everything here is SI; engineering units enter only through
:meth:`ImuSpec.from_units` and the keyword overrides of :func:`preset` as ``(value, unit)`` pairs.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numba import njit

from optinav.core.allan import FLICKER_FLOOR, GM_ADEV_PEAK_RATIO, flicker_avar_factor
from optinav.core.results import Parameter, Result, Truth, nested_kwargs, register_legacy
from optinav.core.units import to_si
from optinav.core.validate import as_float_array, as_rng, check_positive
from optinav.errors import OptinavError

KINDS = ("rate", "increment")
#: Gauss–Markov σ per unit of datasheet bias instability B: makes the process's Allan-deviation peak
#: (0.617σ at 1.89τ) equal the flicker floor 0.664·B that IEEE Std 952 reads B from.
GM_SIGMA_PER_BIAS_INSTABILITY = FLICKER_FLOOR / GM_ADEV_PEAK_RATIO

_RATE_UNIT = {"gyro": "rad/s", "accel": "m/s^2"}


# ----------------------------------------------------------------------------------------------------------
# small private helpers (general; candidates for core.validate)
# ----------------------------------------------------------------------------------------------------------


def _check_kind(kind: str, name: str = "kind") -> str:
    if kind not in KINDS:
        raise OptinavError(f"{name} must be 'rate' or 'increment', got {kind!r}", f"pass {name}='rate' or 'increment'")
    return kind


def _dt(dt, shape: tuple[int, ...], name: str = "dt") -> np.ndarray:
    """dt as an array broadcast to ``shape`` (the sample shape): a scalar or one value per sample, all > 0."""
    if dt is None:
        raise OptinavError(f"{name} is required here", f"pass {name} in s (a scalar or one value per sample)")
    d = as_float_array(dt, name)
    if np.any(d <= 0):
        raise OptinavError(
            f"{name} must be positive, got a minimum of {float(np.min(d)):.6g} s", "pass the sample intervals in s"
        )
    try:
        return np.broadcast_to(d, shape)
    except ValueError:
        raise OptinavError(
            f"{name} has shape {d.shape}, expected a scalar or {shape}", "pass one interval per sample"
        ) from None


def _vec3(x, name: str, *, nonneg: bool = False, allow_inf: bool = False) -> np.ndarray:
    """A scalar or a 3-vector as a float (3,) array."""
    a = as_float_array(x, name, finite=not allow_inf)
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,):
        raise OptinavError(
            f"{name} has shape {a.shape}, expected a scalar or 3 values (x, y, z)", "pass one value or one per axis"
        )
    if np.any(np.isnan(a)):
        raise OptinavError(f"{name} contains NaN", f"pass a valid {name}")
    if nonneg and np.any(a < 0):
        raise OptinavError(f"{name} must not be negative, got {a.tolist()}", f"pass |{name}| (a 1σ value or a density)")
    return a.copy()


def _nonneg_scalar(x, name: str) -> float:
    v = float(as_float_array(x, name))
    if v < 0:
        raise OptinavError(f"{name} must not be negative, got {v!r}", f"pass a valid {name}")
    return v


def _samples(x, name: str) -> np.ndarray:
    a = as_float_array(x, name, last_dims=(3,))
    if a.ndim != 2:
        raise OptinavError(f"{name} has shape {a.shape}, expected (N, 3) samples", "pass one row per sample")
    return a


# ----------------------------------------------------------------------------------------------------------
# deterministic triad model
# ----------------------------------------------------------------------------------------------------------

_M6_INDEX = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
_M3_INDEX = ((0, 1), (0, 2), (1, 2))


def misalignment_matrix(m6) -> np.ndarray:
    """3×3 zero-diagonal misalignment from the 6 terms [M_xy, M_xz, M_yx, M_yz, M_zx, M_zy].

    Parameters
    ----------
    m6 : (6,) array
        Misalignment terms [rad].

    Returns
    -------
    (3, 3) ndarray
        M [rad].
    """
    m6 = as_float_array(m6, "misalignment", last_dims=(6,))
    if m6.ndim != 1:
        raise OptinavError(f"misalignment has shape {m6.shape}, expected (6,)", "pass 6 misalignment terms")
    M = np.zeros((3, 3))
    for v, (i, j) in zip(m6, _M6_INDEX):
        M[i, j] = v
    return M


def upper_misalignment_matrix(m3) -> np.ndarray:
    """3×3 strictly upper-triangular misalignment from [M_xy, M_xz, M_yz].

    Parameters
    ----------
    m3 : (3,) array
        Misalignment terms [rad].

    Returns
    -------
    (3, 3) ndarray
        M [rad].
    """
    m3 = as_float_array(m3, "misalignment", last_dims=(3,))
    if m3.ndim != 1:
        raise OptinavError(f"misalignment has shape {m3.shape}, expected (3,)", "pass M_xy, M_xz, M_yz")
    M = np.zeros((3, 3))
    for v, (i, j) in zip(m3, _M3_INDEX):
        M[i, j] = v
    return M


@dataclass(eq=False)
class TriadErrors(Result):
    """Deterministic errors of one sensor triad: ``y = K x + b (+ G f)``, ``K = diag(1 + s)(I + M)``.

    ``sensor`` is "gyro" (b in rad/s, G allowed) or "accel" (b in m/s², G must be zero). See the module
    docstring for the index meaning of M. Constructors: the fields directly (M as a 3×3 zero-diagonal
    matrix), :meth:`from_six`, :meth:`from_upper_triangular`, :meth:`from_matrix`, :meth:`ideal`.
    """

    SCHEMA = "optinav.triad_errors"
    VERSION = 2

    sensor: str = field(metadata={"unit": "-"})
    bias: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"unit": "rad/s (gyro) | m/s^2 (accel)"})
    scale: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"unit": "1"})
    misalignment: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)), metadata={"unit": "rad"})
    g_sensitivity: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)), metadata={"unit": "rad/s/(m/s^2)"})

    def __post_init__(self):
        if self.sensor not in _RATE_UNIT:
            raise OptinavError(
                f"sensor must be 'gyro' or 'accel', got {self.sensor!r}", "pass sensor='gyro' or 'accel'"
            )
        self.bias = _vec3(self.bias, "bias")
        self.scale = _vec3(self.scale, "scale")
        M = as_float_array(self.misalignment, "misalignment", last_dims=(3, 3))
        G = as_float_array(self.g_sensitivity, "g_sensitivity", last_dims=(3, 3))
        if M.ndim != 2 or G.ndim != 2:
            raise OptinavError("misalignment and g_sensitivity must be single 3×3 matrices", "pass 3×3 arrays")
        if np.any(np.diag(M) != 0):
            raise OptinavError(
                f"misalignment has a non-zero diagonal {np.diag(M).tolist()}",
                "put scale-factor errors in scale and keep M's diagonal zero",
            )
        if self.sensor == "accel" and np.any(G != 0):
            raise OptinavError(
                "g_sensitivity is a gyroscope error but was given for an accelerometer",
                "leave g_sensitivity zero for sensor='accel'",
            )
        self.misalignment, self.g_sensitivity = M.copy(), G.copy()
        if np.any(1.0 + self.scale <= 0):
            raise OptinavError(
                f"scale-factor errors {self.scale.tolist()} make a gain 1 + s ≤ 0",
                "pass scale errors as small fractions (e.g. 2e-6 for 2 ppm)",
            )
        if np.linalg.cond(self.K) > 1e8:
            raise OptinavError(
                "the triad matrix K = diag(1+s)(I+M) is singular or ill-conditioned",
                "check the misalignment: its terms are small angles in rad",
            )

    # -- constructors -------------------------------------------------------------------------------------
    @classmethod
    def ideal(cls, sensor: str) -> "TriadErrors":
        """An error-free triad.

        Parameters
        ----------
        sensor : str
            ``"gyro"`` or ``"accel"``.

        Returns
        -------
        TriadErrors
            K = I, b = 0.
        """
        return cls(sensor=sensor)

    @classmethod
    def from_six(
        cls, sensor: str, bias=0.0, scale=0.0, misalignment=(0, 0, 0, 0, 0, 0), g_sensitivity=None
    ) -> "TriadErrors":
        """From bias, scale errors and the 6 misalignment terms [M_xy, M_xz, M_yx, M_yz, M_zx, M_zy].

        Parameters
        ----------
        sensor : str
            ``"gyro"`` or ``"accel"``.
        bias : float or (3,) array
            Bias [rad/s or m/s^2].
        scale : float or (3,) array
            Scale-factor errors [-].
        misalignment : (6,) array
            Misalignment terms [rad].
        g_sensitivity : (3, 3) array or None
            Gyro g-sensitivity G [rad/s per m/s^2].

        Returns
        -------
        TriadErrors
            The triad.
        """
        return cls(
            sensor=sensor,
            bias=bias,
            scale=scale,
            misalignment=misalignment_matrix(misalignment),
            g_sensitivity=np.zeros((3, 3)) if g_sensitivity is None else g_sensitivity,
        )

    @classmethod
    def from_upper_triangular(
        cls, sensor: str, bias=0.0, scale=0.0, misalignment=(0, 0, 0), g_sensitivity=None
    ) -> "TriadErrors":
        """Upper-triangular form: bias, scale errors and [M_xy, M_xz, M_yz]; K is upper triangular.

        Parameters
        ----------
        sensor, bias, scale, g_sensitivity
            As :meth:`from_six` [-, rad/s or m/s^2, -, rad/s per m/s^2].
        misalignment : (3,) array
            Misalignment terms [rad].

        Returns
        -------
        TriadErrors
            The triad.
        """
        return cls(
            sensor=sensor,
            bias=bias,
            scale=scale,
            misalignment=upper_misalignment_matrix(misalignment),
            g_sensitivity=np.zeros((3, 3)) if g_sensitivity is None else g_sensitivity,
        )

    @classmethod
    def from_matrix(cls, sensor: str, K, bias=0.0, g_sensitivity=None) -> "TriadErrors":
        """From a 3×3 K (factored exactly: s_i = K_ii − 1, M_ij = K_ij / K_ii) and a bias.

        Parameters
        ----------
        sensor : str
            ``"gyro"`` or ``"accel"``.
        K : (3, 3) array
            Scale and misalignment matrix [-].
        bias : float or (3,) array
            Bias [rad/s or m/s^2].
        g_sensitivity : (3, 3) array or None
            Gyro g-sensitivity G [rad/s per m/s^2].

        Returns
        -------
        TriadErrors
            The triad.
        """
        K = as_float_array(K, "K", last_dims=(3, 3))
        if K.ndim != 2:
            raise OptinavError(f"K has shape {K.shape}, expected (3, 3)", "pass one 3×3 matrix")
        d = np.diag(K).copy()
        if np.any(d <= 0):
            raise OptinavError(f"K has a non-positive diagonal {d.tolist()}", "pass a gain matrix close to identity")
        M = K / d[:, None]
        np.fill_diagonal(M, 0.0)
        return cls(
            sensor=sensor,
            bias=bias,
            scale=d - 1.0,
            misalignment=M,
            g_sensitivity=np.zeros((3, 3)) if g_sensitivity is None else g_sensitivity,
        )

    # -- derived ------------------------------------------------------------------------------------------
    @property
    def K(self) -> np.ndarray:
        """Scale-factor and misalignment matrix diag(1 + s)(I + M)."""
        return (1.0 + self.scale)[:, None] * (np.eye(3) + self.misalignment)

    @property
    def misalignment6(self) -> np.ndarray:
        """[M_xy, M_xz, M_yx, M_yz, M_zx, M_zy] (rad)."""
        return np.array([self.misalignment[i, j] for i, j in _M6_INDEX])

    @property
    def is_upper_triangular(self) -> bool:
        """True when M (hence K) has no terms below the diagonal (the 3-term form)."""
        return bool(np.all(np.tril(self.misalignment) == 0))

    # -- model --------------------------------------------------------------------------------------------
    def _offset(self, shape, dt, f, kind: str, name_f: str) -> np.ndarray:
        kind = _check_kind(kind)
        off = np.broadcast_to(self.bias, shape)
        if kind == "increment":
            off = off * _dt(dt, shape[:-1])[..., None]
        if np.any(self.g_sensitivity != 0):
            if f is None:
                raise OptinavError(
                    "this gyro has g-sensitivity, so the specific force is needed",
                    f"pass {name_f} (m/s² for rates, m/s for increments)",
                )
            f = as_float_array(f, name_f, last_dims=(3,))
            if f.shape != tuple(shape):
                raise OptinavError(
                    f"{name_f} has shape {f.shape}, expected {tuple(shape)} like the gyro samples",
                    "pass one specific-force sample per gyro sample",
                )
            off = off + f @ self.g_sensitivity.T
        return off

    def apply(self, x, *, dt=None, acc=None, kind: str = "rate") -> np.ndarray:
        """Truth → measured: ``K x + b (+ G f)`` for rates, ``K Δx + b·dt (+ G Δv)`` for increments.

        Parameters
        ----------
        x : (..., 3) array
            True rates [rad/s or m/s^2] or increments [rad or m/s].
        dt : float, array or None
            Intervals [s]; needed for increments.
        acc : (..., 3) array or None
            True specific force [m/s^2] (Δv [m/s] for increments), needed when the gyro has g-sensitivity.
        kind : str
            ``"rate"`` or ``"increment"``.

        Returns
        -------
        (..., 3) ndarray
            Measured outputs [units of x].
        """
        x = as_float_array(x, "x", last_dims=(3,))
        return x @ self.K.T + self._offset(x.shape, dt, acc, kind, "acc")

    def compensate(self, y, *, dt=None, acc=None, kind: str = "rate") -> np.ndarray:
        """Measured → corrected: ``K⁻¹ (y − b − G f)`` (exact inverse of :meth:`apply`).

        For a gyro with g-sensitivity pass the compensated accelerometer output as ``acc``;
        :meth:`ImuModel.compensate` does so, which makes the inversion exact without noise.

        Parameters
        ----------
        y : (..., 3) array
            Measured rates [rad/s or m/s^2] or increments [rad or m/s].
        dt : float, array or None
            Intervals [s]; needed for increments.
        acc : (..., 3) array or None
            Compensated specific force [m/s^2] (Δv [m/s] for increments).
        kind : str
            ``"rate"`` or ``"increment"``.

        Returns
        -------
        (..., 3) ndarray
            Corrected outputs [units of y].
        """
        y = as_float_array(y, "y", last_dims=(3,))
        r = y - self._offset(y.shape, dt, acc, kind, "acc")
        return np.linalg.solve(self.K, r.reshape(-1, 3).T).T.reshape(y.shape)


# ----------------------------------------------------------------------------------------------------------
# stochastic processes (rate-equivalent values per sample; multiply by dt for increments)
# ----------------------------------------------------------------------------------------------------------


@njit(cache=True)
def _ar1_kernel(w, phi, sigma, state, fresh, groups):  # pragma: no cover - compiled
    # first-order Gauss–Markov sequences, column j of w (n, k) the unit normals of sequence j; phi (n, k) per sample
    # or (1, k) constant; state (k,) the values before w[0] (ignored when fresh: a stationary start), left at the
    # last values; out (n, groups): the sequences of group g (columns g·k/groups …) summed in column order (groups
    # = k: each its own column). The branches are outside the loops and each group's sum is one accumulator: the
    # same additions in the same order as one `out[i, j // per] += b` per value, at half its time (the 75 flicker
    # sequences of a static record)
    n, k = w.shape
    per = k // groups
    gain = sigma * np.sqrt(1.0 - phi[0] * phi[0])
    out = np.empty((n, groups))
    i0 = 0
    if fresh and n > 0:
        for g in range(groups):
            acc = 0.0
            for j in range(g * per, (g + 1) * per):
                b = sigma[j] * w[0, j]  # stationary start
                state[j] = b
                acc += b
            out[0, g] = acc
        i0 = 1
    if phi.shape[0] == 1:
        for i in range(i0, n):
            for g in range(groups):
                acc = 0.0
                for j in range(g * per, (g + 1) * per):
                    b = phi[0, j] * state[j] + gain[j] * w[i, j]
                    state[j] = b
                    acc += b
                out[i, g] = acc
    else:
        for i in range(i0, n):
            for g in range(groups):
                acc = 0.0
                for j in range(g * per, (g + 1) * per):
                    p = phi[i, j]
                    b = p * state[j] + sigma[j] * np.sqrt(1.0 - p * p) * w[i, j]
                    state[j] = b
                    acc += b
                out[i, g] = acc
    return out


@njit(cache=True)
def _quantize_carry_kernel(v, h, residual):  # pragma: no cover - compiled
    # residual (k,): the rounding residual carried into v[0]; left at the one after the last sample
    n, k = v.shape
    out = np.empty_like(v)
    for j in range(k):
        r = residual[j]
        for i in range(n):
            step = h[i, j]
            if step > 0.0:
                u = v[i, j] + r
                q = step * np.floor(u / step + 0.5)
                r = u - q
                out[i, j] = q
            else:
                out[i, j] = v[i, j]
        residual[j] = r
    return out


def white_noise(n: int, density, dt, rng=None, *, kind: str = "rate") -> np.ndarray:
    """White noise of density N per axis: σ = N/√dt (rates), N·√dt (increments).

    Parameters
    ----------
    n : int
        Samples.
    density : float or (3,) array
        N [rad/√s or m/s/√s].
    dt : float or (n,) array
        Intervals [s].
    rng : int, Generator or None
        Seed or generator.
    kind : str
        ``"rate"`` or ``"increment"``.

    Returns
    -------
    (n, 3) ndarray
        Noise [rad/s, m/s^2, or rad, m/s for increments].
    """
    kind = _check_kind(kind)
    N = _vec3(density, "noise density", nonneg=True)
    return _white(as_rng(rng).standard_normal((n, 3)), N, _dt(dt, (n,)), kind)


def _white(w, N, d, kind: str) -> np.ndarray:
    """Unit normals ``w`` (n, 3) as white noise of density N over intervals d (:func:`white_noise`)."""
    return w * (N[None, :] * (1.0 / np.sqrt(d) if kind == "rate" else np.sqrt(d))[:, None])


def gauss_markov(n: int, sigma, tau, dt, rng=None) -> np.ndarray:
    """First-order Gauss–Markov process at the sample epochs, started stationary.

    x_k = φ_k x_{k−1} + σ√(1 − φ_k²) w_k with φ_k = exp(−dt_k/τ) — the exact discretization, so the stationary σ
    and the autocorrelation exp(−|Δt|/τ) hold for any (irregular) dt_k, the interval ending at sample k.

    Parameters
    ----------
    n : int
        Samples.
    sigma : float or (3,) array
        Stationary 1σ per axis [rad/s or m/s^2].
    tau : float or (3,) array
        Correlation time(s) [s].
    dt : float or (n,) array
        Intervals [s].
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    (n, 3) ndarray
        The process [units of sigma].
    """
    s = _vec3(sigma, "Gauss-Markov sigma", nonneg=True)
    t = _vec3(tau, "Gauss-Markov tau", allow_inf=True)
    if np.any(t <= 0):
        raise OptinavError(f"Gauss-Markov correlation time must be positive, got {t.tolist()}", "pass tau in s")
    return _gauss_markov(as_rng(rng).standard_normal((n, 3)), s, t, _dt(dt, (n,)), np.zeros(3), True)


def _gauss_markov(w, sigma, tau, d, state, fresh: bool) -> np.ndarray:
    """Unit normals ``w`` (n, 3) as the Gauss–Markov process of :func:`gauss_markov`, continued from ``state`` (3,)
    (updated in place to the last value), or started stationary when ``fresh``."""
    phi = np.exp(-d[:, None] / tau[None, :])
    return _ar1_kernel(np.ascontiguousarray(w), np.ascontiguousarray(phi), sigma, state, fresh, w.shape[1])


def random_walk(n: int, density, dt, rng=None) -> np.ndarray:
    """Random walk b_k = b_{k−1} + K√dt_k w_k from b_{−1} = 0.

    Parameters
    ----------
    n : int
        Samples.
    density : float or (3,) array
        K [rad/s/√s or m/s²/√s].
    dt : float or (n,) array
        Intervals [s].
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    (n, 3) ndarray
        The walk [rad/s or m/s^2].
    """
    K = _vec3(density, "random-walk density", nonneg=True)
    return _random_walk_from(as_rng(rng).standard_normal((n, 3)), K, _dt(dt, (n,)), np.zeros(3))


def _random_walk_from(w, K, d, state) -> np.ndarray:
    """Unit normals ``w`` (n, 3) as the random walk of :func:`random_walk`, continued from ``state`` (3,) (updated
    in place to the last value)."""
    x = np.cumsum(w * K[None, :] * np.sqrt(d)[:, None], axis=0)
    x += state
    if len(x):
        state[:] = x[-1]
    return x


_random_walk = random_walk  # static_noise's keyword of the same name hides the function


def _ar1_avar(m, tau) -> np.ndarray:
    """(M, K) Allan variance at cluster sizes ``m`` (M,) of unit-variance AR(1) sequences x_i = φ x_{i−1} + √(1 − φ²) w_i,
    φ = exp(−1/τ), correlation times ``tau`` (K,) in samples.

    AVAR(m) = (4 S(m) − S(2m)) / (2m²) with S(m) = Σ_{i,j<m} φ^|i−j| the variance of an m-sample sum, which is
    (m + φ (2m(1 − φ) − (1 − φ^m)(3 − φ^m)) / (1 − φ)²) / m² in closed form; for m/τ < 0.001 its Taylor series in 1/τ
    (m/τ·(2m²/3 + 1/3) − m⁴/(2τ²) + …)/m², whose closed form cancels there.
    """
    m = np.asarray(m, dtype=float)[:, None]
    a = 1.0 / np.asarray(tau, dtype=float)[None, :]
    x = m * a
    u, e1 = -np.expm1(-a), -np.expm1(-x)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        closed = (m + np.exp(-a) * (2.0 * m * u - e1 * (2.0 + e1)) / u**2) / m**2
    series = (a * (2 * m**3 / 3 + m / 3) - a**2 * m**4 / 2 + a**3 * (7 * m**5 / 30 - m**3 / 18 - m / 90)) / m**2
    return np.where(x < 1e-3, series, closed)


#: flicker noise (:func:`_flicker_design`): the shortest correlation time of its poles [samples] (one per octave
#: above it), the taps of its FIR, and the fraction of the equal octave variance its poles faster than the FIR's
#: length carry (the FIR adds the rest of the spectrum there, so it must stay positive)
_FLICKER_TAU0 = 2.0
_FLICKER_TAPS = 4096
_FLICKER_FAST_SHARE = 0.99
#: frequency grid of the FIR's design [points]
_FLICKER_GRID = 1 << 20


def _ar1_psd(f, tau, var) -> np.ndarray:
    """Two-sided PSD at frequencies ``f`` [cycles/sample] of the sum of AR(1) sequences of correlation times ``tau``
    [samples] and variances ``var``: Σ σ²(1 − φ²)/|1 − φ e^{−i2πf}|², φ = exp(−1/τ)."""
    s2 = 2.0 * np.sin(np.pi * np.asarray(f, float)) ** 2  # 1 − cos 2πf
    out = np.zeros_like(s2)
    for t, v in zip(np.asarray(tau, float), np.asarray(var, float)):  # one pole at a time: no (n_f, K) array
        # |1 − φe^{−i2πf}|² = (1 − φ)² + 2φ(1 − cos 2πf), with 1 − φ from expm1 (φ → 1 for slow poles)
        u, phi = -math.expm1(-1.0 / t), math.exp(-1.0 / t)
        out += v * -math.expm1(-2.0 / t) / (u * u + 2.0 * phi * s2)
    return out


def _fir_avar(h, m) -> np.ndarray:
    """Allan variance at cluster sizes ``m`` of unit white noise filtered by the FIR ``h``: AVAR(m) =
    (4 S(m) − S(2m)) / 2m², S(m) = Σ_{|j|<m} (m − |j|) r_j from its autocovariance r_j = Σ_k h_k h_{k+j}."""
    h = np.asarray(h, float)
    L = h.size
    nfft = 1 << int(np.ceil(np.log2(2 * L)))
    r = np.fft.irfft(np.abs(np.fft.rfft(h, nfft)) ** 2, nfft)[:L]
    j = np.arange(L)
    c0, c1 = np.cumsum(r[1:]), np.cumsum(j[1:] * r[1:])

    def S(mm):
        k = np.minimum(mm - 1, L - 1).astype(int)  # lags 1 … k inside the FIR's support
        s0 = np.where(k > 0, c0[np.maximum(k - 1, 0)], 0.0)
        s1 = np.where(k > 0, c1[np.maximum(k - 1, 0)], 0.0)
        return mm * r[0] + 2.0 * (mm * s0 - s1)

    m = np.asarray(m, float)
    return (4.0 * S(m) - S(2.0 * m)) / (2.0 * m**2)


@functools.lru_cache(maxsize=64)
def _flicker_design(poles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flicker noise of B = 1 as a zero-phase FIR on one white sequence plus ``poles`` AR(1) sequences, one per
    octave of correlation time from ``_FLICKER_TAU0`` samples: (correlation times [samples], variances [B²], FIR
    taps [B]). Their sum has the Allan variance of sampled flicker (:func:`flicker_avar_factor` × 2 ln2 B²/π, the
    one-sided PSD B²/(π f) up to the Nyquist frequency).

    Equal variances B² ln 2/π per octave make a sum of first-order processes 1/f between its end corners; alone,
    its Allan variance misses the sampled-flicker curve by up to 2 % at m ≤ 4, which biased N by half its σ in long
    simulated records. So the poles faster than the FIR's length carry 99 % of that variance, and the FIR carries the
    rest of the spectrum (B²/(2π|f|) minus all the poles', positive there) from 1/``_FLICKER_TAPS`` up to Nyquist,
    its edges Hann-tapered; the slower poles' variances are then fitted (non-negative least squares, pulled towards
    the equal variance) to the Allan variance left at m ≥ taps/8. Exact Allan variance of the sum (closed forms,
    :func:`_ar1_avar`, :func:`_fir_avar`) against the sampled-flicker curve: within 0.005 % at m ≤ 4, 0.05 % up to
    m = 64, 0.2 % up to τ_max/64.
    """
    from scipy.optimize import nnls

    L = _FLICKER_TAPS
    tau = _FLICKER_TAU0 * 2.0 ** np.arange(poles)
    var = np.full(poles, np.log(2.0) / np.pi)
    fast = tau < L
    var[fast] *= _FLICKER_FAST_SHARE
    f = np.fft.rfftfreq(_FLICKER_GRID, 1.0)
    target = np.zeros_like(f)
    target[1:] = 1.0 / (2.0 * np.pi * f[1:])
    rest = np.where(f >= 1.0 / L, target - _ar1_psd(f, tau, var), 0.0)
    if np.any(rest < 0):  # pragma: no cover - a design change, not an input, could cause it
        raise AssertionError("flicker design: the fast poles exceed the 1/f spectrum")
    h0 = np.fft.irfft(np.sqrt(rest), n=_FLICKER_GRID)
    h = np.concatenate([h0[-(L // 2) :], h0[: L // 2]])
    edge = np.abs(np.arange(L) - L // 2) / (L // 2)  # 0 at the centre, 1 at the ends; the outer quarter tapered
    h *= np.where(edge < 0.75, 1.0, 0.5 * (1.0 + np.cos(np.pi * (edge - 0.75) / 0.25)))
    m = np.unique(np.round(np.geomspace(L / 8, max(tau[-1] / 64, L), 200)))
    target_avar = FLICKER_FLOOR**2 * flicker_avar_factor(m)
    left = target_avar - _fir_avar(h, m) - _ar1_avar(m, tau[fast]) @ var[fast]
    # pulled towards the equal variance (weight 10⁻³), as the slowest poles otherwise trade a large variance for the
    # last few per mille of the curve (a near-constant offset of several B)
    k, reg, equal = int(np.count_nonzero(~fast)), np.sqrt(1e-3), np.log(2.0) / np.pi
    if k:  # a record shorter than taps/128 has no slow pole (and scipy's nnls must not get an empty matrix)
        A = np.vstack([_ar1_avar(m, tau[~fast]) / target_avar[:, None], reg * np.eye(k) / equal])
        var[~fast] = nnls(A, np.concatenate([left / target_avar, np.full(k, reg)]))[0]
    return tau, var, h


def _flicker_poles(n: int) -> int:
    """Poles of the flicker design for an n-sample record: the slowest correlation time ≥ 128 n samples, so the
    Allan variance is flat up to τ = 2n·dt, past the last cluster time of the record."""
    return int(np.ceil(np.log2(128.0 * max(n, 2) / _FLICKER_TAU0))) + 1


def flicker_noise(n: int, bias_instability, dt: float, rng=None) -> np.ndarray:
    """Flicker (1/f) rate noise of IEEE 952 bias-instability coefficient B per axis.

    The PSD is IEEE Std 952-1997 C.1.3's (B²/2π)/f, two-sided (one-sided B²/(π f)), from well below 1/(n·dt) to the
    Nyquist frequency, as an FIR on white noise plus first-order Gauss–Markov sequences one octave apart
    (:class:`StaticNoiseStream`, :func:`_flicker_design`): its Allan variance is the sampled-flicker curve,
    2·ln2·B²/π (the flat 0.664·B) beyond a few samples up to τ = 2n·dt (NIST SP 1065 Table 3: σ² = 2 ln2 · h₋₁ for
    the one-sided h₋₁/f). Regular sampling only.

    Parameters
    ----------
    n : int
        Samples.
    bias_instability : float or (3,) array
        B [rad/s or m/s^2].
    dt : float
        Sample interval [s].
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    (n, 3) ndarray
        Noise [units of B].
    """
    n = int(n)
    if n < 2:
        raise OptinavError(f"flicker noise needs at least 2 samples, got {n}", "pass n >= 2")
    return StaticNoiseStream(n, dt, bias_instability=bias_instability, key=draw_key(rng)).gather()


def draw_key(rng) -> int:
    """One key for :class:`SampleDraws` drawn from a seed or generator (a simulation draws it right after the
    unit's errors, so a seed keeps giving the same unit).

    Parameters
    ----------
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    int
        The key, in [0, 2^63).
    """
    return int(as_rng(rng).integers(2**63))


def static_noise(n: int, dt: float, *, white=0.0, bias_instability=0.0, random_walk=0.0, rng=None) -> np.ndarray:
    """(n, 3) rate noise of a unit at rest: white N + flicker B + random walk K per axis (IEEE Std 952 terms,
    SI: N in [u]·√s, B in [u], K in [u]/√s for rate unit [u]), as ``optinav simulate static`` records it.

    The whole of :class:`StaticNoiseStream` (one key drawn from ``rng``): the Allan deviation of the flicker term is
    IEEE 952's flat 0.664·B up to past the last cluster time τ = n·dt/4.

    Parameters
    ----------
    n : int
        Samples.
    dt : float
        Sample interval [s].
    white, bias_instability, random_walk : float or (3,) array
        N [u·√s], B [u], K [u/√s] per axis.
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    (n, 3) ndarray
        Rate noise [u] (rad/s or m/s^2).
    """
    stream = StaticNoiseStream(
        n, dt, white=white, bias_instability=bias_instability, random_walk=random_walk, key=draw_key(rng)
    )
    return stream.gather()


def saturate(y, limit, dt=None, *, kind: str = "rate") -> tuple[np.ndarray, np.ndarray]:
    """Clip outputs at the measurement range; increments saturate where their mean rate Δ/dt exceeds it.

    Parameters
    ----------
    y : (N, 3) array
        Outputs [rad/s, m/s^2, or rad, m/s for increments].
    limit : float or (3,) array
        Range as a rate [rad/s or m/s^2] (inf: none).
    dt : float, (N,) array or None
        Intervals [s], for increments.
    kind : str
        ``"rate"`` or ``"increment"``.

    Returns
    -------
    clipped : (N, 3) ndarray
        Outputs [units of y].
    flags : (N, 3) bool ndarray
        True exactly where |rate| > limit.
    """
    kind = _check_kind(kind)
    y = _samples(y, "y")
    lim = _vec3(limit, "range", allow_inf=True)
    if np.any(lim <= 0):
        raise OptinavError(f"range must be positive, got {lim.tolist()}", "pass the full-scale range (inf for none)")
    bound = np.broadcast_to(lim, y.shape) if kind == "rate" else lim[None, :] * _dt(dt, (y.shape[0],))[:, None]
    flags = np.abs(y) > bound
    return np.clip(y, -bound, bound), flags


def quantize(
    y, lsb, dt=None, *, kind: str = "rate", lsb_kind: str = "rate", carry: bool = True, residual=None
) -> np.ndarray:
    """Quantize outputs to the LSB per axis (0: off).

    With ``carry`` the rounding residual of each sample is added to the next one, as the increment outputs of
    integrating sensors do, so the running sum of the outputs never departs from the running sum of the inputs by
    more than half an LSB (half of LSB·dt for a rate LSB). Without it each sample is rounded on its own (register
    outputs of MEMS rate sensors).

    Parameters
    ----------
    y : (N, 3) array
        Outputs [rad/s, m/s^2, or rad, m/s for increments].
    lsb : float or (3,) array
        LSB [rate or increment units, per ``lsb_kind``].
    dt : float, (N,) array or None
        Intervals [s], used when ``kind`` or ``lsb_kind`` is a rate.
    kind : str
        ``"rate"`` or ``"increment"``: what ``y`` is (kept in the output).
    lsb_kind : str
        ``"rate"`` or ``"increment"``: what the LSB is.
    carry : bool
        Carry the rounding residual to the next sample.
    residual : (3,) float ndarray or None
        With ``carry``: the residual carried into the first sample [increment units], updated in place to the one
        after the last (so a long log quantized block by block equals it quantized at once); None: zero.

    Returns
    -------
    (N, 3) ndarray
        Quantized outputs [units of y].
    """
    kind = _check_kind(kind)
    _check_kind(lsb_kind, "lsb_kind")
    y = _samples(y, "y")
    q = _vec3(lsb, "lsb", nonneg=True)
    if not np.any(q > 0):
        return y.copy()
    if not carry and kind == lsb_kind:
        return _round_to(y, np.broadcast_to(q, y.shape))
    # otherwise work on the integral (increment) scale, where the carried residual is an angle/velocity
    d = _dt(dt, (y.shape[0],))[:, None] if "rate" in (kind, lsb_kind) else None
    v = y * d if kind == "rate" else y
    h = np.empty(y.shape)  # writable whatever the broadcast: one compiled signature of the kernel
    h[...] = q[None, :] * d if lsb_kind == "rate" else q
    if carry:
        r = np.zeros(3) if residual is None else residual
        out = _quantize_carry_kernel(np.ascontiguousarray(v), h, r)
    else:
        out = _round_to(v, h)
    return out / d if kind == "rate" else out


def _round_to(v: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Round to the nearest multiple of ``step`` (half up, like the carry kernel); step 0 = unchanged."""
    on = step > 0
    return np.where(on, step * np.floor(v / np.where(on, step, 1.0) + 0.5), v)


@dataclass(eq=False)
class TriadNoise(Result):
    """Noise parameters of one triad (per axis, SI; 0 switches a term off).

    white: density N (rad/√s gyro ARW, m/s/√s accel VRW); gm_sigma / gm_tau: Gauss–Markov bias
    instability (stationary σ in rad/s or m/s², correlation time in s); random_walk: rate/acceleration
    random walk (rad/s/√s, m/s²/√s); range: measurement range as a rate (inf = none); lsb: resolution
    (a rate or an increment per ``lsb_kind``); carry: carry the quantization residual.
    """

    SCHEMA = "optinav.triad_noise"
    VERSION = 2

    white: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"unit": "rad/sqrt(s) | m/s/sqrt(s)"})
    gm_sigma: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"unit": "rad/s | m/s^2"})
    gm_tau: np.ndarray = field(default_factory=lambda: np.full(3, np.inf), metadata={"unit": "s"})
    random_walk: np.ndarray = field(
        default_factory=lambda: np.zeros(3), metadata={"unit": "rad/s/sqrt(s) | m/s^2/sqrt(s)"}
    )
    range: np.ndarray = field(default_factory=lambda: np.full(3, np.inf), metadata={"unit": "rad/s | m/s^2"})
    lsb: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"unit": "rad/s | m/s^2 | rad | m/s"})
    lsb_kind: str = field(default="rate", metadata={"unit": "-"})
    carry: bool = field(default=True, metadata={"unit": "-"})

    def __post_init__(self):
        self.white = _vec3(self.white, "white noise density", nonneg=True)
        self.gm_sigma = _vec3(self.gm_sigma, "gm_sigma", nonneg=True)
        self.gm_tau = _vec3(self.gm_tau, "gm_tau", allow_inf=True)
        self.random_walk = _vec3(self.random_walk, "random_walk", nonneg=True)
        self.range = _vec3(self.range, "range", allow_inf=True)
        self.lsb = _vec3(self.lsb, "lsb", nonneg=True)
        _check_kind(self.lsb_kind, "lsb_kind")
        self.carry = bool(self.carry)
        if np.any(self.gm_tau <= 0) or np.any((self.gm_sigma > 0) & ~np.isfinite(self.gm_tau)):
            raise OptinavError(
                f"gm_tau must be a positive finite correlation time, got {self.gm_tau.tolist()}",
                "pass the bias-instability correlation time in s",
            )
        if np.any(self.range <= 0):
            raise OptinavError(f"range must be positive, got {self.range.tolist()}", "pass inf for no saturation")

    def sample(self, n: int, dt, rng=None) -> np.ndarray:
        """Rate-equivalent noise: white + Gauss–Markov + random walk (multiply by dt for increments).

        Parameters
        ----------
        n : int
            Samples.
        dt : float or (n,) array
            Intervals [s].
        rng : int, Generator or None
            Seed or generator.

        Returns
        -------
        (n, 3) ndarray
            Noise [rad/s or m/s^2].
        """
        rng = as_rng(rng)
        d = _dt(dt, (n,))
        e = np.zeros((n, 3))
        if np.any(self.white > 0):
            e += white_noise(n, self.white, d, rng, kind="rate")
        if np.any(self.gm_sigma > 0):
            e += gauss_markov(n, self.gm_sigma, self.gm_tau, d, rng)
        if np.any(self.random_walk > 0):
            e += random_walk(n, self.random_walk, d, rng)
        return e

    def digitize(self, y, dt, *, kind: str = "rate", residual=None) -> tuple[np.ndarray, np.ndarray]:
        """Saturate then quantize outputs.

        Parameters
        ----------
        y : (N, 3) array
            Outputs [rad/s, m/s^2, or rad, m/s for increments].
        dt : float or (N,) array
            Intervals [s].
        kind : str
            ``"rate"`` or ``"increment"``.
        residual : (3,) float ndarray or None
            The quantization residual carried in and out [units of y] (:func:`quantize`).

        Returns
        -------
        outputs : (N, 3) ndarray
            Digitized outputs [units of y].
        flags : (N, 3) bool ndarray
            Saturation flags.
        """
        y, flags = saturate(y, self.range, dt, kind=kind)
        q = quantize(y, self.lsb, dt, kind=kind, lsb_kind=self.lsb_kind, carry=self.carry, residual=residual)
        return q, flags


# ----------------------------------------------------------------------------------------------------------
# one unit: ImuModel
# ----------------------------------------------------------------------------------------------------------


@dataclass(eq=False)
class ImuMeasurement(Result):
    """Simulated IMU outputs: rates (rad/s, m/s²) or increments (rad, m/s) per ``kind``; per-axis saturation flags.

    Version 2 renamed the version-1 fields ``gyro``/``accel``/``accel_saturated`` to ``gyr``/``acc``/``acc_saturated``
    (version-1 files still load)."""

    SCHEMA = "optinav.imu_measurement"
    VERSION = 2

    gyr: np.ndarray = field(metadata={"unit": "rad/s (rate) | rad (increment)"})
    acc: np.ndarray = field(metadata={"unit": "m/s^2 (rate) | m/s (increment)"})
    gyro_saturated: np.ndarray = field(metadata={"unit": "1"})
    acc_saturated: np.ndarray = field(metadata={"unit": "1"})
    dt: np.ndarray = field(metadata={"unit": "s"})
    kind: str = field(default="rate", metadata={"unit": "-"})


@dataclass(eq=False)
class ImuCompensated(Result):
    """IMU outputs corrected for the deterministic errors (same ``kind`` and units as the input).

    Version 2 renamed the version-1 fields ``gyro``/``accel`` to ``gyr``/``acc`` (version-1 files still load)."""

    SCHEMA = "optinav.imu_compensated"
    VERSION = 2

    gyr: np.ndarray = field(metadata={"unit": "rad/s (rate) | rad (increment)"})
    acc: np.ndarray = field(metadata={"unit": "m/s^2 (rate) | m/s (increment)"})
    kind: str = field(default="rate", metadata={"unit": "-"})


@dataclass(eq=False)
class ImuModel(Result):
    """One IMU unit: deterministic errors of both triads (``gyr``, ``acc``) and their noise parameters (SI).

    Version 2 renamed the version-1 fields ``gyro``/``accel`` to ``gyr``/``acc``;
    version 3 renamed ``accel_noise``/``sample_rate`` to ``acc_noise``/``rate_hz``; earlier versions still load.
    """

    SCHEMA = "optinav.imu_model"
    VERSION = 3

    gyr: TriadErrors = field(default_factory=lambda: TriadErrors.ideal("gyro"), metadata={"unit": "-"})
    acc: TriadErrors = field(default_factory=lambda: TriadErrors.ideal("accel"), metadata={"unit": "-"})
    gyro_noise: TriadNoise = field(default_factory=TriadNoise, metadata={"unit": "-"})
    acc_noise: TriadNoise = field(default_factory=TriadNoise, metadata={"unit": "-"})
    rate_hz: float = field(default=100.0, metadata={"unit": "Hz"})
    name: str = field(default="custom", metadata={"unit": "-"})

    def __post_init__(self):
        for attr, sensor, cls in (
            ("gyr", "gyro", TriadErrors),
            ("acc", "accel", TriadErrors),
            ("gyro_noise", None, TriadNoise),
            ("acc_noise", None, TriadNoise),
        ):
            v = getattr(self, attr)
            if not isinstance(v, cls):
                raise OptinavError(f"ImuModel.{attr} must be a {cls.__name__}", f"build it with {cls.__name__}(...)")
            if sensor and v.sensor != sensor:
                raise OptinavError(
                    f"ImuModel.{attr} describes a {v.sensor}", f"pass TriadErrors(sensor='{sensor}', ...)"
                )
        self.rate_hz = check_positive(self.rate_hz, "rate_hz")

    def _dt(self, dt, n: int) -> np.ndarray:
        return np.array(_dt(1.0 / self.rate_hz if dt is None else dt, (n,)), dtype=float)

    def apply(self, gyr, acc, dt=None, rng=None, *, kind: str = "rate", noise: bool = True) -> ImuMeasurement:
        """Truth → measured outputs. Order: deterministic errors, noise, saturation, quantization.

        The g-sensitivity acts on the true specific force.

        Parameters
        ----------
        gyr : (N, 3) array
            True angular rate [rad/s] at the sample epochs, or with ``kind="increment"`` Δθ [rad] over each interval.
        acc : (N, 3) array
            True specific force [m/s^2], or with ``kind="increment"`` Δv [m/s].
        dt : float, (N,) array or None
            Intervals [s]; None: 1/rate_hz.
        rng : int, Generator or None
            Seed or generator.
        kind : str
            ``"rate"`` or ``"increment"``.
        noise : bool
            Include the random terms (saturation and quantization stay either way).

        Returns
        -------
        ImuMeasurement
            Outputs in the units of the input and per-axis saturation flags.
        """
        kind = _check_kind(kind)
        w, f = _samples(gyr, "gyr"), _samples(acc, "acc")
        if w.shape != f.shape:
            raise OptinavError(
                f"gyr {w.shape} and acc {f.shape} have different shapes",
                "pass the same number of gyro and accel samples",
            )
        n = w.shape[0]
        d = self._dt(dt, n)
        ya = self.acc.apply(f, dt=d, kind=kind)
        yg = self.gyr.apply(w, dt=d, acc=f, kind=kind)
        if noise:
            rng = as_rng(rng)
            scale = 1.0 if kind == "rate" else d[:, None]
            yg = yg + self.gyro_noise.sample(n, d, rng) * scale
            ya = ya + self.acc_noise.sample(n, d, rng) * scale
        yg, sg = self.gyro_noise.digitize(yg, d, kind=kind)
        ya, sa = self.acc_noise.digitize(ya, d, kind=kind)
        return ImuMeasurement(gyr=yg, acc=ya, gyro_saturated=sg, acc_saturated=sa, dt=d, kind=kind)

    def compensate(self, gyr, acc, dt=None, *, kind: str = "rate") -> ImuCompensated:
        """Measured → corrected (inverse of the deterministic part of :meth:`apply`).

        The accelerometers are compensated first; the gyro g-sensitivity is then removed with the compensated specific
        force, so without noise the result equals the truth to rounding.

        Parameters
        ----------
        gyr : (N, 3) array
            Measured rate [rad/s] or Δθ [rad].
        acc : (N, 3) array
            Measured specific force [m/s^2] or Δv [m/s].
        dt : float, (N,) array or None
            Intervals [s], used for increments (bias·dt); None: 1/rate_hz.
        kind : str
            ``"rate"`` or ``"increment"``.

        Returns
        -------
        ImuCompensated
            Corrected outputs in the units of the input.
        """
        kind = _check_kind(kind)
        yg, ya = _samples(gyr, "gyr"), _samples(acc, "acc")
        if yg.shape != ya.shape:
            raise OptinavError(
                f"gyr {yg.shape} and acc {ya.shape} have different shapes",
                "pass the same number of gyro and accel samples",
            )
        d = self._dt(dt, yg.shape[0])
        fa = self.acc.compensate(ya, dt=d, kind=kind)
        wg = self.gyr.compensate(yg, dt=d, acc=fa, kind=kind)
        return ImuCompensated(gyr=wg, acc=fa, kind=kind)


# ----------------------------------------------------------------------------------------------------------
# long logs block by block: draws indexed by sample, ImuModel.apply with its noise states carried
# ----------------------------------------------------------------------------------------------------------

#: samples per block of :class:`SampleDraws`: a fixed length in samples, so the draws of a sample do not depend on
#: how a caller splits a long simulation into blocks
DRAW_BLOCK = 1 << 16


class SampleDraws:
    """Random draws indexed by sample: ``take(i0, i1)`` gives the draws of samples [i0, i1), the same whatever
    blocks a long simulation is generated in.

    The draws of sample i are row ``i mod DRAW_BLOCK`` of the ``(DRAW_BLOCK, width)`` array that the generator of
    ``SeedSequence(key, spawn_key=(stream, i // DRAW_BLOCK))`` draws first (the last block drawn is kept).

    Parameters
    ----------
    key : int
        Entropy of the simulation (e.g. drawn from the caller's generator).
    stream : int
        Which process of the simulation (independent draws per stream).
    width : int
        Values per sample.
    dist : str
        ``"normal"`` (standard normal) or ``"uniform"`` ([0, 1)).
    """

    def __init__(self, key: int, stream: int, width: int = 3, dist: str = "normal"):
        if dist not in ("normal", "uniform"):
            raise OptinavError(f"unknown distribution {dist!r}", "use 'normal' or 'uniform'")
        self.key, self.stream, self.width, self.dist = int(key), int(stream), int(width), dist
        self._j, self._gen, self._block, self._drawn = -1, None, None, 0

    def _rows(self, j: int, upto: int) -> np.ndarray:
        """Block j with at least its first ``upto`` rows drawn. A generator fills arrays in order, so drawing a
        block's rows as far as asked, then on, gives the bits of drawing the whole block at once; a short log then
        draws its own samples, not the block's 65 536 rows (75 per sample for flicker)."""
        if j != self._j:
            seq = np.random.SeedSequence(self.key, spawn_key=(self.stream, j))
            self._gen = np.random.Generator(np.random.PCG64(seq))
            self._j, self._block, self._drawn = j, np.empty((DRAW_BLOCK, self.width)), 0
        if upto > self._drawn:
            rows = self._block[self._drawn : upto]
            if self.dist == "normal":
                self._gen.standard_normal(out=rows)
            else:
                self._gen.random(out=rows)
            self._drawn = upto
        return self._block

    def take(self, i0: int, i1: int) -> np.ndarray:
        """The draws of samples ``i0`` … ``i1 − 1``.

        Parameters
        ----------
        i0, i1 : int
            First and one-past-last sample index [-].

        Returns
        -------
        (i1 − i0, width) ndarray
            The draws [-] (standard normal or uniform on [0, 1)).
        """
        out = np.empty((max(i1 - i0, 0), self.width))
        pos = i0
        while pos < i1:
            j = pos // DRAW_BLOCK
            a, b = pos - j * DRAW_BLOCK, min(i1 - j * DRAW_BLOCK, DRAW_BLOCK)
            out[pos - i0 : pos - i0 + b - a] = self._rows(j, b)[a:b]
            pos += b - a
        return out


class StaticNoiseStream:
    """Rate noise of a unit at rest — white N + flicker B + random walk K per axis (IEEE Std 952 terms) — generated
    block by block with its states carried, so that memory does not grow with the length of the log
    (``optinav simulate static``; :func:`static_noise` gathers it).

    The flicker term is a zero-phase FIR of 4096 taps on one white sequence plus first-order Gauss–Markov sequences,
    one per octave of correlation time from two samples to 128 times the record (:func:`_flicker_design`): its Allan
    variance is the sampled-flicker curve of the four-term fit (flat 0.664·B beyond a few samples) within 0.005 % at
    m ≤ 4 and 0.2 % up to τ = 2n·dt. Unlike one FFT over the whole record, both parts continue sample by sample
    (the FIR keeps its last 4095 draws, the sequences their values). Each process draws
    its normals by sample index (:class:`SampleDraws`), so the output does not depend on the blocks asked for.

    Parameters
    ----------
    n : int
        Samples of the whole log (sets the slowest flicker pole).
    dt : float
        Sample interval [s].
    white, bias_instability, random_walk : float or (3,) array
        N [u·√s], B [u], K [u/√s] per axis, for the rate unit [u] (rad/s or m/s^2).
    key : int
        Entropy of the draws.
    stream0 : int
        First of the four :class:`SampleDraws` streams used (white, flicker poles, random walk, flicker FIR).
    """

    def __init__(
        self, n: int, dt: float, *, white=0.0, bias_instability=0.0, random_walk=0.0, key: int = 0, stream0: int = 0
    ):
        self.n, self.dt, self.samples = int(n), check_positive(dt, "dt"), 0
        self.N = _vec3(white, "white noise density", nonneg=True)
        self.B = _vec3(bias_instability, "bias instability", nonneg=True)
        self.K = _vec3(random_walk, "random-walk density", nonneg=True)
        self._white = SampleDraws(key, stream0) if np.any(self.N > 0) else None
        self._rw = SampleDraws(key, stream0 + 2) if np.any(self.K > 0) else None
        self._rw_state = np.zeros(3)
        self._flicker = None
        if np.any(self.B > 0):
            tau, var, self._fir = _flicker_design(_flicker_poles(self.n))
            # the poles of the three axes side by side (column a·K + k: pole k of axis a), φ constant
            self._phi = np.tile(np.exp(-1.0 / tau), 3)[None, :]
            self._sigma = np.tile(np.sqrt(var), 3)
            self._flicker = SampleDraws(key, stream0 + 1, width=3 * tau.size)
            self._fl_white = SampleDraws(key, stream0 + 3)
            self._fir_spectrum: dict[int, np.ndarray] = {}
            self._fl_state = np.zeros(3 * tau.size)

    def take(self, size: int) -> np.ndarray:
        """The next ``size`` samples (fewer at the end of the log).

        Parameters
        ----------
        size : int
            Samples wanted [-].

        Returns
        -------
        (m, 3) ndarray
            Rate noise [u].
        """
        i0 = self.samples
        i1 = min(i0 + int(size), self.n)
        m = max(i1 - i0, 0)
        x = np.zeros((m, 3))
        d = np.full(m, self.dt)
        if self._white is not None:
            x += _white(self._white.take(i0, i1), self.N, d, "rate")
        if self._flicker is not None and m:
            fl = _ar1_kernel(self._flicker.take(i0, i1), self._phi, self._sigma, self._fl_state, i0 == 0, 3)
            # the FIR's output at sample i uses the draws i … i + taps − 1 of its own stream (stationary from i = 0)
            u = self._fl_white.take(i0, i1 + self._fir.size - 1)
            nfft = 1 << int(np.ceil(np.log2(len(u))))
            if nfft not in self._fir_spectrum:  # one per FFT length: every full block shares it
                self._fir_spectrum[nfft] = np.fft.rfft(self._fir, nfft)[:, None]
            conv = np.fft.irfft(np.fft.rfft(u, nfft, axis=0) * self._fir_spectrum[nfft], nfft, axis=0)
            x += self.B * (fl + conv[self._fir.size - 1 : self._fir.size - 1 + m])
        if self._rw is not None:
            x += _random_walk_from(self._rw.take(i0, i1), self.K, d, self._rw_state)
        self.samples = i1
        return x

    def gather(self) -> np.ndarray:
        """The rest of the log in one array.

        Returns
        -------
        (m, 3) ndarray
            Rate noise [u].
        """
        return np.concatenate(
            [self.take(DRAW_BLOCK) for _ in range(-(-(self.n - self.samples) // DRAW_BLOCK))] or [np.zeros((0, 3))]
        )


class _TriadStream:
    """One triad's noise, saturation and quantization continued over consecutive blocks (:class:`MeasurementStream`)."""

    def __init__(self, noise: TriadNoise, key: int, stream0: int):
        self.noise = noise
        self.white = SampleDraws(key, stream0) if np.any(noise.white > 0) else None
        self.gm = SampleDraws(key, stream0 + 1) if np.any(noise.gm_sigma > 0) else None
        self.rw = SampleDraws(key, stream0 + 2) if np.any(noise.random_walk > 0) else None
        self.gm_state, self.rw_state, self.residual = np.zeros(3), np.zeros(3), np.zeros(3)

    def __call__(self, y, d, i0: int, kind: str = "rate", noise: bool = True) -> tuple[np.ndarray, np.ndarray]:
        i1, nz = i0 + len(y), self.noise
        if noise:
            e = np.zeros_like(y)  # rate-equivalent, as TriadNoise.sample: times dt for increments
            if self.white is not None:
                e += _white(self.white.take(i0, i1), nz.white, d, "rate")
            if self.gm is not None:
                e += _gauss_markov(self.gm.take(i0, i1), nz.gm_sigma, nz.gm_tau, d, self.gm_state, i0 == 0)
            if self.rw is not None:
                e += _random_walk_from(self.rw.take(i0, i1), nz.random_walk, d, self.rw_state)
            y = y + (e if kind == "rate" else e * d[:, None])
        return nz.digitize(y, d, kind=kind, residual=self.residual)


class MeasurementStream:
    """:meth:`ImuModel.apply` of a long log, block by block: deterministic errors, noise, saturation and
    quantization, with the Gauss–Markov and random-walk states and the quantization residuals carried from one block
    to the next, and the draws of each sample taken from :class:`SampleDraws` of ``key`` — so the outputs of a log
    do not depend on the blocks it is generated in, and memory does not grow with its length.

    Parameters
    ----------
    model : ImuModel
        The unit.
    key : int
        Entropy of the noise draws.
    kind : str
        ``"rate"`` (rad/s, m/s^2) or ``"increment"`` (Δθ rad, Δv m/s over each interval; noise scaled by dt), as
        :meth:`ImuModel.apply`.
    noise : bool
        Include the random terms (saturation and quantization stay either way).

    Examples
    --------
    >>> stream = MeasurementStream(model, key)            # doctest: +SKIP
    >>> for gyr, acc, dt in blocks:                       # doctest: +SKIP
    ...     meas_gyr, meas_acc = stream(gyr, acc, dt)
    """

    def __init__(self, model: ImuModel, key: int, *, kind: str = "rate", noise: bool = True):
        self.model, self.samples = model, 0
        self.kind, self.noise = _check_kind(kind), bool(noise)
        self._gyr = _TriadStream(model.gyro_noise, key, 0)
        self._acc = _TriadStream(model.acc_noise, key, 3)
        #: saturated axis samples so far, per triad (the count of ImuMeasurement's flags)
        self.gyro_saturated, self.acc_saturated = 0, 0

    def __call__(self, gyr, acc, dt) -> tuple[np.ndarray, np.ndarray]:
        """The next block's measured outputs.

        Parameters
        ----------
        gyr : (n, 3) array
            True angular rate [rad/s] at the block's epochs, or Δθ [rad] over each interval (``kind="increment"``).
        acc : (n, 3) array
            True specific force [m/s^2], or Δv [m/s].
        dt : (n,) array
            Interval ending each sample's noise step (the increment's interval) [s].

        Returns
        -------
        gyr : (n, 3) ndarray
            Measured rate [rad/s] or Δθ [rad].
        acc : (n, 3) ndarray
            Measured specific force [m/s^2] or Δv [m/s].
        """
        w, f = _samples(gyr, "gyr"), _samples(acc, "acc")
        d = self.model._dt(dt, w.shape[0])
        i0, kind = self.samples, self.kind
        ya = self.model.acc.apply(f, dt=d, kind=kind)
        yg = self.model.gyr.apply(w, dt=d, acc=f, kind=kind)
        yg, sg = self._gyr(yg, d, i0, kind, self.noise)
        ya, sa = self._acc(ya, d, i0, kind, self.noise)
        self.gyro_saturated += int(np.count_nonzero(sg))
        self.acc_saturated += int(np.count_nonzero(sa))
        self.samples += w.shape[0]
        return yg, ya


#: field renames of earlier versions of the layouts above (old name → new), per (schema, version)
_RENAMED = {
    (ImuMeasurement, 1): {"gyro": "gyr", "accel": "acc", "accel_saturated": "acc_saturated"},  # old names
    (ImuCompensated, 1): {"gyro": "gyr", "accel": "acc"},  # old names
    (ImuModel, 2): {"accel_noise": "acc_noise", "sample_rate": "rate_hz"},  # old names
    (ImuModel, 1): {"gyro": "gyr", "accel": "acc", "accel_noise": "acc_noise", "sample_rate": "rate_hz"},
}  # old names
for (_cls, _version), _rename in _RENAMED.items():
    register_legacy(_cls, _cls.SCHEMA, _version, lambda d, c=_cls, r=_rename: nested_kwargs(c, d, r))


# ----------------------------------------------------------------------------------------------------------
# specification level: ImuSpec, presets
# ----------------------------------------------------------------------------------------------------------


def _vfield(unit: str, default=0.0):
    return field(default_factory=lambda: np.full(3, float(default)), metadata={"unit": unit})


@dataclass(eq=False)
class ImuSpec(Result):
    """1σ engineering specification of an IMU type (SI; per-axis values are (3,) arrays, a scalar is broadcast).

    Deterministic 1σ values (drawn once per unit): ``*_bias`` (turn-on bias repeatability), ``*_scale``,
    ``*_misalignment`` (each off-diagonal term; ``misalignment_form`` "full" draws all six, "upper" only
    M_xy, M_xz, M_yz), ``gyro_g_sensitivity`` (each of the 9 terms). In-run terms: ``*_bias_instability``
    B (datasheet in-run bias stability, the IEEE 952 flicker coefficient) simulated as Gauss–Markov with
    correlation time ``*_bias_corr_time`` and σ = 1.076·B so that its Allan-deviation peak is the
    flicker floor 0.664·B; ``gyro_arw`` / ``acc_vrw`` white-noise densities; ``gyro_rrw`` /
    ``acc_rrw`` random walks; ``*_range`` (inf = none); ``*_lsb`` resolution (a rate or an increment
    per ``lsb_kind``; 0 = none); ``rate_hz``. Version 2 renamed ``sample_rate`` to ``rate_hz`` and ``accel_*`` to
    ``acc_*`` (version-1 files still load).
    """

    SCHEMA = "optinav.imu_spec"
    VERSION = 2

    name: str = field(default="custom", metadata={"unit": "-"})
    rate_hz: float = field(default=100.0, metadata={"unit": "Hz"})
    gyro_bias: np.ndarray = _vfield("rad/s")
    gyro_bias_instability: np.ndarray = _vfield("rad/s")
    gyro_bias_corr_time: np.ndarray = _vfield("s", 100.0)
    gyro_scale: np.ndarray = _vfield("1")
    gyro_misalignment: float = field(default=0.0, metadata={"unit": "rad"})
    gyro_g_sensitivity: float = field(default=0.0, metadata={"unit": "rad/s/(m/s^2)"})
    gyro_arw: np.ndarray = _vfield("rad/sqrt(s)")
    gyro_rrw: np.ndarray = _vfield("rad/s/sqrt(s)")
    gyro_range: np.ndarray = _vfield("rad/s", np.inf)
    gyro_lsb: np.ndarray = _vfield("rad/s | rad")
    acc_bias: np.ndarray = _vfield("m/s^2")
    acc_bias_instability: np.ndarray = _vfield("m/s^2")
    acc_bias_corr_time: np.ndarray = _vfield("s", 100.0)
    acc_scale: np.ndarray = _vfield("1")
    acc_misalignment: float = field(default=0.0, metadata={"unit": "rad"})
    acc_vrw: np.ndarray = _vfield("m/s/sqrt(s)")
    acc_rrw: np.ndarray = _vfield("m/s^2/sqrt(s)")
    acc_range: np.ndarray = _vfield("m/s^2", np.inf)
    acc_lsb: np.ndarray = _vfield("m/s^2 | m/s")
    lsb_kind: str = field(default="rate", metadata={"unit": "-"})
    quantization_carry: bool = field(default=True, metadata={"unit": "-"})
    misalignment_form: str = field(default="full", metadata={"unit": "-"})
    source: str = field(default="", metadata={"unit": "-"})

    def __post_init__(self):
        self.rate_hz = check_positive(self.rate_hz, "rate_hz")
        for s in ("gyro", "acc"):
            for name in ("bias", "bias_instability", "scale", "lsb", "rrw", "arw" if s == "gyro" else "vrw"):
                key = f"{s}_{name}"
                setattr(self, key, _vec3(getattr(self, key), key, nonneg=True))
            for key in (f"{s}_range", f"{s}_bias_corr_time"):
                v = _vec3(getattr(self, key), key, allow_inf=True)
                if np.any(v <= 0):
                    raise OptinavError(f"{key} must be positive, got {v.tolist()}", f"pass a positive {key}")
                setattr(self, key, v)
            unbounded = ~np.isfinite(getattr(self, f"{s}_bias_corr_time"))
            if np.any(unbounded & (getattr(self, f"{s}_bias_instability") > 0)):
                raise OptinavError(
                    f"{s}_bias_corr_time must be finite when {s}_bias_instability is set",
                    "pass a correlation time in s",
                )
            setattr(self, f"{s}_misalignment", _nonneg_scalar(getattr(self, f"{s}_misalignment"), f"{s}_misalignment"))
        self.gyro_g_sensitivity = _nonneg_scalar(self.gyro_g_sensitivity, "gyro_g_sensitivity")
        _check_kind(self.lsb_kind, "lsb_kind")
        self.quantization_carry = bool(self.quantization_carry)
        if self.misalignment_form not in ("full", "upper"):
            raise OptinavError(
                f"misalignment_form must be 'full' or 'upper', got {self.misalignment_form!r}",
                "pass 'full' (6 terms) or 'upper' (M_xy, M_xz, M_yz)",
            )

    @classmethod
    def from_units(cls, **fields) -> "ImuSpec":
        """Build from field values given as SI numbers or ``(value, unit)`` pairs in any unit of
        :data:`optinav.core.units.UNITS`, e.g. ``gyro_arw=(0.0005, "deg/sqrt(h)")``.

        Parameters
        ----------
        **fields
            ImuSpec fields [SI or (value, unit)].

        Returns
        -------
        ImuSpec
            The spec (SI).
        """
        return cls(**_convert_fields(fields))

    def replace(self, **fields) -> "ImuSpec":
        """A copy with some fields replaced.

        Parameters
        ----------
        **fields
            ImuSpec fields [SI or (value, unit)].

        Returns
        -------
        ImuSpec
            The new spec (SI).
        """
        return dataclasses.replace(self, **_convert_fields(fields))

    def draw(self, rng=None, *, errors: bool = True) -> ImuModel:
        """Draw one unit: deterministic errors ~ N(0, 1σ spec) and its noise.

        Parameters
        ----------
        rng : int, Generator or None
            Seed or generator.
        errors : bool
            Draw the deterministic errors (False: zero).

        Returns
        -------
        ImuModel
            The unit (SI).
        """
        rng = as_rng(rng)

        def triad(sensor: str) -> TriadErrors:
            if not errors:
                return TriadErrors.ideal(sensor)
            s = "gyro" if sensor == "gyro" else "acc"  # the field stem of the sensor
            bias = rng.normal(0.0, 1.0, 3) * getattr(self, f"{s}_bias")
            scale = rng.normal(0.0, 1.0, 3) * getattr(self, f"{s}_scale")
            sig = getattr(self, f"{s}_misalignment")
            G = rng.normal(0.0, self.gyro_g_sensitivity, (3, 3)) if s == "gyro" else None
            if self.misalignment_form == "upper":
                return TriadErrors.from_upper_triangular(sensor, bias, scale, rng.normal(0.0, sig, 3), G)
            return TriadErrors.from_six(sensor, bias, scale, rng.normal(0.0, sig, 6), G)

        def noise(s: str, white: str) -> TriadNoise:
            return TriadNoise(
                white=getattr(self, f"{s}_{white}"),
                gm_sigma=GM_SIGMA_PER_BIAS_INSTABILITY * getattr(self, f"{s}_bias_instability"),
                gm_tau=getattr(self, f"{s}_bias_corr_time"),
                random_walk=getattr(self, f"{s}_rrw"),
                range=getattr(self, f"{s}_range"),
                lsb=getattr(self, f"{s}_lsb"),
                lsb_kind=self.lsb_kind,
                carry=self.quantization_carry,
            )

        return ImuModel(
            gyr=triad("gyro"),
            acc=triad("accel"),
            gyro_noise=noise("gyro", "arw"),
            acc_noise=noise("acc", "vrw"),
            rate_hz=self.rate_hz,
            name=self.name,
        )


register_legacy(
    ImuSpec,
    ImuSpec.SCHEMA,
    1,
    lambda d: nested_kwargs(
        ImuSpec,
        d,
        {"sample_rate": "rate_hz", **{k: "acc_" + k[len("accel_") :] for k in d["fields"] if k.startswith("accel_")}},
    ),
)  # old names


def _convert_fields(fields: dict) -> dict:
    names = {f.name for f in dataclasses.fields(ImuSpec)}
    out = {}
    for key, value in fields.items():
        if key not in names:
            raise OptinavError(f"ImuSpec has no field {key!r}", f"use one of: {', '.join(sorted(names))}")
        if isinstance(value, tuple) and len(value) == 2 and isinstance(value[1], str):
            value = to_si(value[0], value[1])
        out[key] = value
    return out


def _rlg_nav() -> ImuSpec:
    """Navigation-grade ring-laser-gyro IMU of the dual-axis rotational INS paper (shared/seeds/000, Table 1).

    From the paper: gyro drift stability 0.005 °/h (→ in-run bias instability, and, as the paper's only
    bias figure, also the turn-on bias 1σ), gyro random walk 0.0005 °/√h (ARW), gyro scale-factor
    stability 2 ppm, accelerometer bias stability 20 μg (turn-on 1σ and in-run instability), 200 Hz.
    Chosen here (not in the paper; typical of navigation-grade RLG / quartz-accelerometer IMUs):
    accelerometer VRW 10 μg/√Hz, accelerometer scale factor 20 ppm, residual misalignment 5″ on both
    triads, no g-sensitivity (RLGs are g-insensitive), bias correlation times 300 s, ranges ±400 °/s and
    ±20 g, no quantization (set ``gyro_lsb``/``acc_lsb`` with ``lsb_kind="increment"`` for pulse outputs).
    """
    return ImuSpec.from_units(
        name="rlg-nav",
        rate_hz=200.0,
        gyro_bias=(0.005, "deg/h"),
        gyro_bias_instability=(0.005, "deg/h"),
        gyro_bias_corr_time=300.0,
        gyro_scale=(2, "ppm"),
        gyro_misalignment=(5, "arcsec"),
        gyro_arw=(0.0005, "deg/sqrt(h)"),
        gyro_range=(400, "deg/s"),
        acc_bias=(20, "ug"),
        acc_bias_instability=(20, "ug"),
        acc_bias_corr_time=300.0,
        acc_scale=(20, "ppm"),
        acc_misalignment=(5, "arcsec"),
        acc_vrw=(10, "ug/sqrt(Hz)"),
        acc_range=(20, "g"),
        lsb_kind="increment",
        source="dual-axis rotational laser INS paper, Table 1 (gyro 0.005 deg/h, 0.0005 deg/sqrt(h), 2 ppm; "
        "accel 20 ug; 200 Hz); other values chosen, see optinav.core.imu_model._rlg_nav",
    )


def _mems_mti1() -> ImuSpec:
    """Xsens MTi-1 class MEMS IMU, the unit of the MEMS accelerometer calibration paper (shared/seeds/004).

    Datasheet values (Xsens MTi 1-series datasheet, as tabulated in "Characteristics of IMU Xsens MTI-1
    sensors", reference-global.com/article/10.2478/tar-2023-0022; the Xsens PDF itself could not be
    retrieved): gyro range ±2000 °/s, in-run bias stability 10 °/h, noise density 0.007 °/s/√Hz;
    accelerometer range ±16 g, in-run bias stability 0.03 mg, noise density 120 μg/√Hz.
    Deterministic 1σ values sized after the errors the paper calibrates on its MTi-1 (Table 2: biases
    0.04–0.14 m/s², scale factors within 0.4 %, misalignments 0.004–0.006 rad): accelerometer bias
    0.1 m/s², scale 0.2 %, misalignment 0.005 rad; the same scale and misalignment for the gyros with a
    0.1 °/s bias (chosen). Chosen as well: bias correlation times 100 s, 100 Hz, floating-point outputs
    (no quantization), no g-sensitivity.
    """
    return ImuSpec.from_units(
        name="mems-mti1",
        rate_hz=100.0,
        gyro_bias=(0.1, "deg/s"),
        gyro_bias_instability=(10, "deg/h"),
        gyro_bias_corr_time=100.0,
        gyro_scale=(0.2, "%"),
        gyro_misalignment=0.005,
        gyro_arw=(0.007, "deg/s/sqrt(Hz)"),
        gyro_range=(2000, "deg/s"),
        acc_bias=0.1,
        acc_bias_instability=(0.03, "mg"),
        acc_bias_corr_time=100.0,
        acc_scale=(0.2, "%"),
        acc_misalignment=0.005,
        acc_vrw=(120, "ug/sqrt(Hz)"),
        acc_range=(16, "g"),
        source="Xsens MTi 1-series datasheet (gyro 2000 deg/s, 10 deg/h, 0.007 deg/s/sqrt(Hz); accel 16 g, "
        "0.03 mg, 120 ug/sqrt(Hz)); deterministic errors after the MEMS calibration paper, Table 2",
    )


def _mpu6000() -> ImuSpec:
    """InvenSense MPU-6000 class MEMS IMU, the unit of the polarization attitude paper (shared/seeds/002).

    Datasheet PS-MPU-6000A-00 rev. 3.4 (2013), §6.1–6.2, FS_SEL = 0 and AFS_SEL = 0: gyro ±250 °/s,
    131 LSB/(°/s), rate noise spectral density 0.005 °/s/√Hz, initial zero-rate tolerance ±20 °/s,
    sensitivity tolerance ±3 %, cross-axis sensitivity ±2 %, linear-acceleration sensitivity 0.1 °/s/g;
    accelerometer ±2 g, 16384 LSB/g, noise 400 μg/√Hz, zero-g tolerance ±50 mg (x, y) and ±80 mg (z),
    calibration tolerance ±3 %, cross-axis ±2 %. The typical ± tolerances are taken as 1σ (uncalibrated
    part). Not in the datasheet: in-run bias instability 4.6 °/h (τ = 500 s) and 36 μg (τ = 800 s) from
    D. Greenheck, MSc thesis, Marquette University 2009, §2.2 (as used by AirSim's ImuSimpleParams);
    100 Hz (chosen). Outputs are 16-bit registers rounded independently (rate LSB, no carry).
    """
    return ImuSpec.from_units(
        name="mpu6000",
        rate_hz=100.0,
        gyro_bias=(20, "deg/s"),
        gyro_bias_instability=(4.6, "deg/h"),
        gyro_bias_corr_time=500.0,
        gyro_scale=(3, "%"),
        gyro_misalignment=(2, "%"),
        gyro_g_sensitivity=(0.1, "deg/s/g"),
        gyro_arw=(0.005, "deg/s/sqrt(Hz)"),
        gyro_range=(250, "deg/s"),
        gyro_lsb=(1 / 131, "deg/s"),
        acc_bias=([50, 50, 80], "mg"),
        acc_bias_instability=(36, "ug"),
        acc_bias_corr_time=800.0,
        acc_scale=(3, "%"),
        acc_misalignment=(2, "%"),
        acc_vrw=(400, "ug/sqrt(Hz)"),
        acc_range=(2, "g"),
        acc_lsb=(1 / 16384, "g"),
        lsb_kind="rate",
        quantization_carry=False,
        source="InvenSense PS-MPU-6000A-00 rev 3.4 (FS_SEL=0, AFS_SEL=0); bias instability: Greenheck 2009",
    )


def _tactical_mems() -> ImuSpec:
    """Tactical-grade MEMS IMU, the class of the Analog Devices ADIS16495-2 (±450 °/s).

    Datasheet figures of that class (ADIS16495 data sheet, Analog Devices, "Specifications" table; recalled, the PDF
    could not be retrieved here to re-check the digits): gyro in-run bias stability 0.8 °/h, angular random walk
    0.09 °/√h; accelerometer (±8 g) in-run bias stability 3.2 μg, velocity random walk 0.008 m/s/√h. Tactical
    grade is 0.1–10 °/h gyro bias instability (Titterton & Weston, *Strapdown Inertial Navigation Technology*, 2nd
    ed., Table 1.1 / §1.3 grades); these numbers sit at its better end. Chosen (not from the datasheet): turn-on
    bias 1σ 0.2 °/s and 2 mg, scale 0.05 %, misalignment 0.5 mrad (a factory-calibrated unit's residuals),
    bias correlation times 300 s, 200 Hz, floating-point outputs, no g-sensitivity.
    """
    return ImuSpec.from_units(
        name="tactical-mems",
        rate_hz=200.0,
        gyro_bias=(0.2, "deg/s"),
        gyro_bias_instability=(0.8, "deg/h"),
        gyro_bias_corr_time=300.0,
        gyro_scale=(0.05, "%"),
        gyro_misalignment=5e-4,
        gyro_arw=(0.09, "deg/sqrt(h)"),
        gyro_range=(450, "deg/s"),
        acc_bias=(2, "mg"),
        acc_bias_instability=(3.2, "ug"),
        acc_bias_corr_time=300.0,
        acc_scale=(0.05, "%"),
        acc_misalignment=5e-4,
        acc_vrw=(0.008, "m/s/sqrt(h)"),
        acc_range=(8, "g"),
        source="ADIS16495-2 class (gyro 0.8 deg/h, 0.09 deg/sqrt(h); accel 3.2 ug, 0.008 m/s/sqrt(h)); "
        "deterministic errors chosen, see optinav.core.imu_model._tactical_mems",
    )


_PRESETS = {"rlg-nav": _rlg_nav, "tactical-mems": _tactical_mems, "mems-mti1": _mems_mti1, "mpu6000": _mpu6000}
PRESETS = tuple(_PRESETS)


def preset(name: str, **overrides) -> ImuSpec:
    """The :class:`ImuSpec` of a named sensor class, with optional field overrides.

    Names: "rlg-nav" (navigation-grade RLG IMU of the rotational-INS paper), "tactical-mems" (ADIS16495 class),
    "mems-mti1" (Xsens MTi-1), "mpu6000" (InvenSense MPU-6000); the sources are in the docstrings of ``_rlg_nav``,
    ``_tactical_mems``, ``_mems_mti1`` and ``_mpu6000`` and in the spec's ``source`` field.

    Parameters
    ----------
    name : str
        Preset name.
    **overrides
        ImuSpec fields [SI or (value, unit)], e.g. ``preset("mpu6000", rate_hz=500, gyro_range=(2000, "deg/s"))``.

    Returns
    -------
    ImuSpec
        The spec (SI).
    """
    try:
        build = _PRESETS[name]
    except (KeyError, TypeError):
        raise OptinavError(f"unknown IMU preset {name!r}", f"use one of: {', '.join(PRESETS)}") from None
    spec = build()
    return spec.replace(**overrides) if overrides else spec


class StaticLog(NamedTuple):
    """A simulated IMU at rest: ``t`` (s), ``acc`` (N, 3) m/s², ``gyr`` (N, 3) rad/s and the noise terms as a
    :class:`~optinav.core.results.Truth` (system "allan")."""

    t: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    truth: Truth


#: SI units of the noise terms of a static log, per sensor
_STATIC_UNITS = {
    "accelerometer": {"white": "m/s/sqrt(s)", "bias_instability": "m/s^2", "random_walk": "m/s^2/sqrt(s)"},
    "gyroscope": {"white": "rad/sqrt(s)", "bias_instability": "rad/s", "random_walk": "rad/s/sqrt(s)"},
}


class StaticLogStream:
    """An IMU at rest with known noise terms, for noise characterisation, generated block by block
    (``optinav simulate static``; :func:`simulate_static` gathers it).

    z up, gravity along +z (normal gravity at latitude 45°), no rotation; the noise of the preset ``spec``:
    white noise (VRW/ARW), bias instability as flicker (1/f) noise of the datasheet coefficient B (IEEE Std 952;
    Allan floor 0.664·B, up to past the last cluster time: :class:`StaticNoiseStream`), and a random walk. The
    draws of each sample are indexed by sample (key ``seed``), so the log does not depend on the block length.

    Parameters
    ----------
    duration_s : float
        Length of the log [s] (at least 1000 samples).
    spec : str
        Preset name (:func:`preset`).
    rate_hz : float or None
        Sample rate [Hz]; None: the preset's.
    acc_random_walk : float
        Accelerometer random walk on every axis [m/s^2/sqrt(s)].
    gyr_random_walk : float
        Gyroscope rate random walk on every axis [rad/s/sqrt(s)].
    seed : int
        Seed of the draws (recorded in the truth).

    Attributes
    ----------
    n : int
        Samples of the log.
    rate_hz : float
        Sample rate [Hz].
    truth : Truth
        Each noise term per sensor and axis in SI units (system "allan").
    """

    def __init__(
        self,
        duration_s: float,
        spec: str = "mems-mti1",
        *,
        rate_hz: float | None = None,
        acc_random_walk: float = 0.0,
        gyr_random_walk: float = 0.0,
        seed: int = 0,
    ):
        from optinav.core.earth import gravity

        s = preset(spec)
        self.rate_hz = float(rate_hz or s.rate_hz)
        self.n = n = int(round(duration_s * self.rate_hz))
        if n < 1000:
            raise OptinavError(
                f"{duration_s / 3600:g} h at {self.rate_hz:g} Hz is {n} samples; a noise log needs thousands",
                "raise --hours",
            )
        self.dt = 1.0 / self.rate_hz
        terms = {
            "accelerometer": (s.acc_vrw, s.acc_bias_instability, np.full(3, float(acc_random_walk))),
            "gyroscope": (s.gyro_arw, s.gyro_bias_instability, np.full(3, float(gyr_random_walk))),
        }
        self._acc, self._gyr = (
            StaticNoiseStream(n, self.dt, white=N, bias_instability=B, random_walk=K, key=int(seed), stream0=4 * i)
            for i, (N, B, K) in enumerate(terms.values())
        )
        self.gravity = float(gravity(np.radians(45.0), 0.0))
        short = {"accelerometer": "acc", "gyroscope": "gyr"}
        # the common truth layout (one parameter per sensor, term and axis) and the noise terms in their own layout
        params = {
            f"{short[name]}_{term}_{ax}": Parameter(float(v[i]), _STATIC_UNITS[name][term])
            for name, (N, B, K) in terms.items()
            for term, v in (("white", N), ("bias_instability", B), ("random_walk", K))
            for i, ax in enumerate("xyz")
        }
        self.truth = Truth(
            "allan",
            params,
            {
                "kind": "static",
                "units": _STATIC_UNITS,
                **{
                    name: {"white": N.tolist(), "bias_instability": B.tolist(), "random_walk": K.tolist()}
                    for name, (N, B, K) in terms.items()
                },
                "rate_hz": self.rate_hz,
                "gravity": self.gravity,
                "preset": spec,
                "seed": seed,
            },
        )

    def n_blocks(self, size: int = DRAW_BLOCK) -> int:
        """Blocks of ``size`` samples in the log.

        Parameters
        ----------
        size : int
            Samples per block [-].

        Returns
        -------
        int
            Number of blocks [-].
        """
        return -(-self.n // int(size))

    def blocks(self, size: int = DRAW_BLOCK):
        """The log block by block, in one pass (the noise states are carried from block to block).

        Parameters
        ----------
        size : int
            Samples per block [-] (the last may be shorter).

        Yields
        ------
        t : (m,) ndarray
            Time [s].
        acc : (m, 3) ndarray
            Specific force [m/s^2].
        gyr : (m, 3) ndarray
            Angular rate [rad/s].
        """
        g = np.array([0.0, 0.0, self.gravity])
        for i0 in range(0, self.n, int(size)):
            acc, gyr = self._acc.take(size), self._gyr.take(size)
            yield (i0 + np.arange(len(acc))) * self.dt, acc + g, gyr


def simulate_static(duration_s: float, spec: str = "mems-mti1", **options) -> StaticLog:
    """An IMU at rest with known noise terms, for noise characterisation: the whole :class:`StaticLogStream`.

    Parameters
    ----------
    duration_s : float
        Length [s].
    spec : str
        Preset name.
    **options
        The keywords of :class:`StaticLogStream`: ``rate_hz`` [Hz] (None: the preset's), ``acc_random_walk``
        [m/s^2/sqrt(s)], ``gyr_random_walk`` [rad/s/sqrt(s)], ``seed``.

    Returns
    -------
    StaticLog
        t [s], acc [m/s^2], gyr [rad/s] and the truth: each term per sensor and axis in SI units.
    """
    stream = StaticLogStream(duration_s, spec, **options)
    t, acc, gyr = (np.concatenate(x) for x in zip(*stream.blocks()))
    return StaticLog(t, acc, gyr, stream.truth)
