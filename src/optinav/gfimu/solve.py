"""Solving an accelerometer array for A, ω̇ and the angular rate, vectorized over time where possible.

* :func:`solve_linear` — weighted least squares of ``f = H_lin [A; ω̇] + H_quad q`` for every epoch at once
  (one pseudo-inverse): A, ω̇ (NaN for components not solvable without the rate) and the observable
  quadratic combinations ``z = B q`` (``B`` = :attr:`Identifiability.quadratic_basis`).
* :func:`rate_integration` — the paper's integration method: ω = ω₀ + ∫ω̇ dt (trapezoid).
* :func:`rate_quadratic` — ω from the observable quadratic combinations (magnitudes; e.g. for cylinder10
  |ωx| = √((z_xy² + z_xz²)/(ωy² + ωz²))), the branch (signs) taken from the predicted rate
  ω_{k−1} + ∫ω̇: a few Gauss–Newton steps on ‖B q(ω) − z‖² with a weak prior at the prediction.
* :func:`rate_gauss_newton` — an iterated Kalman filter of ω: per epoch, Gauss–Newton on the raw outputs for
  [A, ω̇, ω] (9 unknowns) with the trapezoid from the epoch before as prior, its covariance carried.

Units: f m/s², t s, ω rad/s, ω̇ rad/s², A m/s².
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from optinav.core.validate import as_float_array, check_timestamps
from optinav.errors import OptinavError
from optinav.gfimu.array import AccelerometerArray, LINEAR_NAMES, identifiability, quadratic_products

__all__ = [
    "LinearSolution",
    "solve_linear",
    "rate_integration",
    "rate_quadratic",
    "rate_gauss_newton",
    "solve_rate",
    "solve_motion",
    "MotionSolver",
    "RateState",
    "rigid_fit",
    "RATE_METHODS",
]

RATE_METHODS = ("integration", "quadratic", "gauss-newton")
#: accelerometer noise (m/s², 1σ) assumed for weighting when the configuration gives none (≈ 10 µg)
DEFAULT_SIGMA = 1e-4


def noise_sigma(sigma, n: int) -> np.ndarray:
    """Accelerometer noise std (m/s², 1σ): one value or one per sensor, broadcast to (n,) and positive."""
    s = np.broadcast_to(as_float_array(sigma, "sigma"), (n,)).astype(float)
    if np.any(s <= 0):
        raise OptinavError("sigma must be positive", "give the accelerometer noise std in m/s^2")
    return s


def _sigma(array: AccelerometerArray, sigma) -> np.ndarray:
    if sigma is not None:
        return noise_sigma(sigma, array.n)
    return array.noise if array.noise is not None else np.full(array.n, DEFAULT_SIGMA)


@dataclass
class LinearSolution:
    """Per-epoch least-squares solution: A (T, 3) m/s², wdot (T, 3) rad/s², z (T, k) rad²/s² with
    ``z = basis @ q(ω)``; ``solvable`` marks the components of [A, ω̇] that do not need the rate."""

    A: np.ndarray
    wdot: np.ndarray
    z: np.ndarray
    basis: np.ndarray
    solvable: np.ndarray
    z_cov: np.ndarray


def _outputs(array: AccelerometerArray, f) -> np.ndarray:
    f = as_float_array(f, "f")
    if f.ndim == 1:
        f = f[None, :]
    if f.ndim != 2 or f.shape[1] != array.n:
        raise OptinavError(
            f"outputs have shape {f.shape}, expected (T, {array.n}) for {array.n} accelerometers",
            "pass one column per accelerometer of the configuration",
        )
    return f


def solve_linear(array: AccelerometerArray, acc) -> LinearSolution:
    """Weighted least squares of the array outputs for every epoch; see the module docstring.

    Parameters
    ----------
    array : AccelerometerArray
        The configuration ([A, ω̇] must be identifiable with the rate known).
    acc : (T, N) array
        Array outputs [m/s^2].

    Returns
    -------
    LinearSolution
        ``A`` [m/s^2], ``wdot`` [rad/s^2] and the observable quadratic combinations ``z`` [rad^2/s^2].
    """
    f = acc
    f = _outputs(array, f)
    ident = identifiability(array)
    ident.require(("linear",))
    w = array.weights()
    H = array.H * w[:, None]
    D = np.linalg.norm(H, axis=0)
    D = np.where(D > 0, D, 1.0)
    Pinv = np.linalg.pinv(H / D, rcond=1e-9) / D[:, None]  # (12, N): minimum-norm in scaled units
    theta = (f * w) @ Pinv.T  # (T, 12); estimable parts are unique
    solvable = np.array([n in ident.solvable_without_rate for n in LINEAR_NAMES])
    x = np.where(solvable, theta[:, :6], np.nan)
    B = ident.quadratic_basis
    z = theta[:, 6:] @ B.T
    Pq = Pinv[6:]  # z noise covariance (σ given → m/s² units)
    z_cov = B @ Pq @ Pq.T @ B.T
    return LinearSolution(A=x[:, :3], wdot=x[:, 3:], z=z, basis=B, solvable=solvable, z_cov=z_cov)


def _time(t, n) -> np.ndarray:
    t = check_timestamps(t, "t", min_count=2)
    if t.shape[0] != n:
        raise OptinavError(f"{t.shape[0]} timestamps for {n} output rows", "give one timestamp per row")
    return t


def _omega0(omega0) -> np.ndarray:
    w = as_float_array(np.zeros(3) if omega0 is None else omega0, "omega0")
    if w.shape != (3,):
        raise OptinavError(f"omega0 has shape {w.shape}, expected (3,)", "give the initial rate in rad/s")
    return w


@dataclass
class RateState:
    """What a rate method carries from one block of epochs to the next: ``omega`` (3,) rad/s at the last epoch
    solved, its time ``t`` (s; None before the first epoch, when ``omega`` is ω₀ and the first epoch takes it) and
    ``wdot`` (3,) rad/s², the method's angular acceleration there (its prediction to the next epoch uses it)."""

    omega: np.ndarray
    t: float | None = None
    wdot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    #: (3, 3) rad²/s², the Gauss–Newton filter's covariance of ``omega`` (None: the methods without one)
    cov: np.ndarray | None = None

    def steps(self, t) -> np.ndarray:
        """The step (s) before each epoch of the block ``t``: from the carried epoch, 0 before the first one."""
        return np.diff(t, prepend=t[0] if self.t is None else self.t)


def rate_integration(array: AccelerometerArray, acc, t, omega0=None) -> np.ndarray:
    """Angular rate by trapezoidal integration of the least-squares ω̇ (paper, §4).

    When ω̇ is separable from the quadratic terms (nominal cylinder10) this is one vectorized solve. Otherwise
    (e.g. a calibrated, slightly irregular geometry) each epoch first subtracts ``H_quad q(ω⁻)`` with the
    predicted rate ω⁻ = ω̂_{k−1} + ω̇̂_{k−1}Δt and solves [A; ω̇] from H_lin — the paper's compensation
    ("compute the installation-error part of the outputs, subtract it, solve with the nominal formulas")
    written for the calibrated geometry.

    Parameters
    ----------
    array : AccelerometerArray
        The configuration.
    acc : (T, N) array
        Array outputs [m/s^2].
    t : (T,) array
        Epochs [s].
    omega0 : (3,) array or None
        Initial rate [rad/s]; None: zero.

    Returns
    -------
    (T, 3) ndarray
        ω [rad/s].
    """
    f = _outputs(array, acc)
    t = _time(t, f.shape[0])
    return _integration(array, f, t, RateState(_omega0(omega0)))[0]


def _integration(array: AccelerometerArray, f, t, state: RateState) -> tuple[np.ndarray, RateState]:
    """:func:`rate_integration` of one block of epochs from ``state``: (T, 3) ω [rad/s] and the state after it.
    Before the first epoch the step is 0, so the first ω is ω₀ whatever ``state.wdot``."""
    ident = identifiability(array)
    ident.require(("linear",))
    dt = state.steps(t)
    if all(n in ident.solvable_without_rate for n in LINEAR_NAMES[3:]):
        wd = solve_linear(array, f).wdot
        inc = 0.5 * (wd + np.vstack([state.wdot, wd[:-1]])) * dt[:, None]
        w = state.omega + np.cumsum(inc, axis=0)
        return w, RateState(w[-1].copy(), float(t[-1]), wd[-1].copy())
    wts = array.weights()
    P = np.linalg.pinv(array.H_lin * wts[:, None])[3:] * wts[None, :]  # ω̇ rows (3, N)
    w, wd = _integrate_compensated(
        np.ascontiguousarray(P),
        np.ascontiguousarray(array.H_quad, dtype=float),
        np.ascontiguousarray(f, dtype=float),
        dt,
        np.array(state.omega, float),
        np.array(state.wdot, float),
    )
    return w, RateState(w[-1].copy(), float(t[-1]), wd)


@numba.njit(cache=True, nogil=True)
def _integrate_compensated(P, Hq, f, dt, w, wd):
    """The epoch loop of :func:`rate_integration` for a geometry whose ω̇ needs the quadratic terms removed:
    ω̇_k = P (f_k − H_quad q(ω⁻)) with ω⁻ = ω_{k−1} + ω̇_{k−1}Δt_k, then the trapezoid; ``w``, ``wd`` the state
    at the epoch before the block, ``dt[k]`` the step before epoch k. Returns ω (T, 3) and the last ω̇."""
    T = f.shape[0]
    out = np.empty((T, 3))
    for k in range(T):
        h = dt[k]
        wd_new = _wdot(P, Hq, f[k], w + wd * h)
        w = w + 0.5 * (wd + wd_new) * h
        wd = wd_new
        for j in range(3):  # not ``out[k] = w``: numba's row assignment compiles its shape-mismatch error (3 s)
            out[k, j] = w[j]
    return out, wd


@numba.njit(cache=True, nogil=True)
def _wdot(P, Hq, fk, w):
    """``P (f_k − H_quad q(w))`` with q the quadratic rate products (:func:`quadratic_products`)."""
    x, y, z = w[0], w[1], w[2]
    q = (x * x, y * y, z * z, x * y, x * z, y * z)
    # loops, not ``@``: numba's BLAS bindings took 2 s of compiling for two products of at most 3 × 12
    out = np.zeros(P.shape[0])
    for j in range(fk.shape[0]):
        r = fk[j]
        for m in range(6):
            r -= Hq[j, m] * q[m]
        for i in range(P.shape[0]):
            out[i] += P[i, j] * r
    return out


def _dq(w) -> np.ndarray:
    """∂q/∂ω (6 × 3)."""
    x, y, z = w
    return np.array([[2 * x, 0, 0], [0, 2 * y, 0], [0, 0, 2 * z], [y, x, 0], [z, 0, x], [0, z, y]])


def rate_quadratic(
    array: AccelerometerArray, acc, t, omega0=None, *, prior_std: float = 0.05, iterations: int = 3, sigma=None
) -> np.ndarray:
    """Angular rate from the observable quadratic combinations, branch from the predicted rate.

    Each epoch: predict ω⁻ = ω̂_{k−1} + ½(ω̇_{k−1} + ω̇_k)Δt, then Gauss–Newton on
    ``‖L (B q(ω) − z_k)‖² + ‖(ω − ω⁻)/prior_std‖²`` (L whitens z). The prior only picks the branch (the
    sign of ω, which q cannot see) and bridges epochs where the magnitudes are degenerate (e.g. ωx → 0).
    Needs ≥ 3 observable quadratic combinations.

    Parameters
    ----------
    array : AccelerometerArray
        The configuration.
    acc : (T, N) array
        Array outputs [m/s^2].
    t : (T,) array
        Epochs [s].
    omega0 : (3,) array or None
        Initial rate [rad/s]; None: zero.
    prior_std : float
        1σ of the predicted-rate prior [rad/s].
    iterations : int
        Gauss–Newton iterations per epoch.
    sigma : float, (N,) array or None
        Output noise std [m/s^2]; None: the array's noise, else :data:`DEFAULT_SIGMA`.

    Returns
    -------
    (T, 3) ndarray
        ω [rad/s].
    """
    f = _outputs(array, acc)
    t = _time(t, f.shape[0])
    return _quadratic(array, f, t, RateState(_omega0(omega0)), prior_std, iterations, sigma)[0]


def _quadratic(
    array: AccelerometerArray, f, t, state: RateState, prior_std: float = 0.05, iterations: int = 3, sigma=None
) -> tuple[np.ndarray, RateState]:
    """:func:`rate_quadratic` of one block of epochs from ``state``: (T, 3) ω [rad/s] and the state after it
    (``wdot``: the last least-squares ω̇, which the next prediction averages with its own)."""
    sol = solve_linear(array, f)
    if sol.basis.shape[0] < 3:
        raise OptinavError(
            f"configuration has {sol.basis.shape[0]} observable quadratic rate combination(s), "
            "the quadratic method needs 3",
            "use method 'integration' or 'gauss-newton'",
        )
    if not sol.solvable[3:].all():
        identifiability(array).require(("linear", "without_rate"))
    s2 = float(np.mean(_sigma(array, sigma) ** 2)) if array.noise is None else 1.0
    Lz = np.linalg.cholesky(np.linalg.inv(s2 * sol.z_cov)).T
    B = sol.basis
    out = np.empty((f.shape[0], 3))
    w = np.array(state.omega, float)
    first = 0
    if state.t is None:  # the first epoch of the log: ω₀ as given
        out[0], first = w, 1
    dt = state.steps(t)
    wd_prev = np.vstack([state.wdot, sol.wdot[:-1]])
    ip = 1.0 / prior_std
    LB, Lzk = Lz @ B, sol.z @ Lz.T  # the whitened design and observations, once for all epochs
    J = np.zeros((LB.shape[0] + 3, 3))
    J[LB.shape[0] :] = ip * np.eye(3)
    for k in range(first, f.shape[0]):
        pred = w + 0.5 * (sol.wdot[k] + wd_prev[k]) * dt[k]
        w = pred.copy()
        for _ in range(iterations):
            r = np.concatenate([LB @ quadratic_products(w) - Lzk[k], ip * (w - pred)])
            J[: LB.shape[0]] = LB @ _dq(w)
            w = w - np.linalg.lstsq(J, r, rcond=None)[0]
        out[k] = w
    return out, RateState(out[-1].copy(), float(t[-1]), sol.wdot[-1].copy())


def rate_gauss_newton(
    array: AccelerometerArray, acc, t, omega0=None, *, prior_std: float = 0.05, iterations: int = 3, sigma=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-epoch Gauss–Newton for [A, ω̇, ω] on the raw outputs with the trapezoid's rate as prior.

    Residuals ``W (f_k − H_lin [A; ω̇] − H_quad q(ω))`` (W = 1/σ_i) and ``L (ω⁻ − ω)`` with
    ω⁻ = ω̂_{k−1} + ½(ω̇̂_{k−1} + ω̇_k) Δt and L the whitening of its covariance (an iterated Kalman filter of ω,
    :func:`_gauss_newton`). Works for any configuration with rank [A, ω̇] = 6 (also when ω̇ needs the rate).

    Parameters
    ----------
    array : AccelerometerArray
        The configuration.
    acc : (T, N) array
        Array outputs [m/s^2].
    t : (T,) array
        Epochs [s].
    omega0 : (3,) array or None
        Initial rate [rad/s]; None: zero.
    prior_std : float
        1σ of ``omega0`` [rad/s].
    iterations : int
        Gauss–Newton iterations per epoch.
    sigma : float, (N,) array or None
        Output noise std [m/s^2]; None: the array's noise, else :data:`DEFAULT_SIGMA`.

    Returns
    -------
    omega : (T, 3) ndarray
        ω [rad/s].
    A : (T, 3) ndarray
        Specific force at the reference point [m/s^2].
    wdot : (T, 3) ndarray
        ω̇ [rad/s^2].
    """
    f = _outputs(array, acc)
    t = _time(t, f.shape[0])
    om, A, wd, _ = _gauss_newton(array, f, t, RateState(_omega0(omega0)), prior_std, iterations, sigma)
    return om, A, wd


#: rad/s per √s: the rate's random walk between epochs in :func:`_gauss_newton` beyond what the noise of the
#: solved ω̇ carries through the trapezoid: a floor for a geometry a little off its calibration (on calibrated
#: cylinder10s at 1 µg noise 1e-5 left ≤ 4e-4 rad/s, 1e-4 up to 1.1e-3, 1e-3 up to 3e-3 — the data's quadratic
#: terms pull the rate by the calibration's own error where the walk lets them)
RATE_WALK = 1e-5


def _gauss_newton(
    array: AccelerometerArray, f, t, state: RateState, prior_std: float = 0.05, iterations: int = 3, sigma=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, RateState]:
    """:func:`rate_gauss_newton` of one block of epochs from ``state``: ω [rad/s], A [m/s^2], ω̇ [rad/s^2] (T, 3)
    each and the state after them.

    An iterated Kalman filter of ω with [A, ω̇] solved beside it at each epoch: the prior is the trapezoid
    ω_{k−1} + ½(ω̇_{k−1} + ω̇_k)Δt (ω̇_k one of the unknowns) with the covariance carried from the epoch before plus
    what ω̇_{k−1}'s noise and :data:`RATE_WALK` add; ``prior_std`` is ω₀'s 1σ. Each Gauss–Newton step is halved
    until the cost falls: a full step near ω ≈ 0, where the quadratic terms lose the rate's sign, jumped onto the
    mirrored branch (ω → −ω) and the filter stayed there (2 rad/s wrong, exit 0)."""
    identifiability(array).require(("linear",))
    wts = 1.0 / _sigma(array, sigma)
    Hl, Hq = array.H_lin * wts[:, None], array.H_quad * wts[:, None]
    fw = f * wts
    T = f.shape[0]
    om, A, wd = np.empty((T, 3)), np.empty((T, 3)), np.empty((T, 3))
    w = np.array(state.omega, float)
    x = np.r_[np.zeros(3), state.wdot]
    P = np.eye(3) * prior_std**2 if state.cov is None else np.array(state.cov, float)
    C_wd = np.linalg.pinv(Hl.T @ Hl)[3:, 3:]  # ω̇'s covariance from one epoch's outputs (rad²/s⁴)
    first = 0
    if state.t is None:  # the first epoch of the log: ω₀ as given, [A, ω̇] by least squares with it
        x = np.linalg.lstsq(Hl, fw[0] - Hq @ quadratic_products(w), rcond=None)[0]
        om[0], A[0], wd[0] = w, x[:3], x[3:]
        first = 1
    dt = state.steps(t)
    n = array.n
    Hl_pinv = np.linalg.pinv(Hl)  # rank [A, ω̇] = 6 (required above): the start's LS solve is this fixed matrix
    J = np.zeros((n + 3, 9))
    J[:n, :6] = Hl
    for k in range(first, T):
        h = dt[k]
        wd_prev = x[3:].copy()
        Pp = P + (0.25 * h * h) * C_wd + (RATE_WALK**2 * h) * np.eye(3)
        L = np.linalg.cholesky(np.linalg.inv(Pp)).T  # whitens the prior: ‖L (ω − prior)‖
        base = w + 0.5 * h * wd_prev
        J[n:, 3:6] = -0.5 * h * L
        J[n:, 6:] = L

        def residual(xx, ww, fk=fw[k], L=L, base=base, h=h):
            return np.concatenate([fk - Hl @ xx - Hq @ quadratic_products(ww), L @ (base + 0.5 * h * xx[3:] - ww)])

        w = base + 0.5 * h * wd_prev  # the prior with ω̇_k = ω̇_{k−1}
        x = Hl_pinv @ (fw[k] - Hq @ quadratic_products(w))
        r = residual(x, w)
        cost = float(r @ r)
        for _ in range(iterations):
            J[:n, 6:] = Hq @ _dq(w)
            step = np.linalg.lstsq(J, r, rcond=None)[0]
            for _half in range(30):
                x1, w1 = x + step[:6], w + step[6:]
                r1 = residual(x1, w1)
                c1 = float(r1 @ r1)
                if c1 <= cost:
                    break
                step *= 0.5
            else:
                break
            x, w, r, cost = x1, w1, r1, c1
        J[:n, 6:] = Hq @ _dq(w)
        P = np.linalg.pinv(J.T @ J)[6:, 6:]
        om[k], A[k], wd[k] = w, x[:3], x[3:]
    return om, A, wd, RateState(om[-1].copy(), float(t[-1]), wd[-1].copy(), P)


def solve_rate(array: AccelerometerArray, acc, t, omega0=None, method: str = "integration", **options) -> np.ndarray:
    """Angular rate by ``method``.

    Parameters
    ----------
    array : AccelerometerArray
        The configuration.
    acc : (T, N) array
        Array outputs [m/s^2].
    t : (T,) array
        Epochs [s].
    omega0 : (3,) array or None
        Initial rate [rad/s]; None: zero.
    method : str
        One of :data:`RATE_METHODS`: ``"integration"``, ``"quadratic"``, ``"gauss-newton"``.
    **options
        Passed to the method's function.

    Returns
    -------
    (T, 3) ndarray
        ω [rad/s].
    """
    f = acc
    if method == "integration":
        return rate_integration(array, f, t, omega0, **options)
    if method == "quadratic":
        return rate_quadratic(array, f, t, omega0, **options)
    if method == "gauss-newton":
        return rate_gauss_newton(array, f, t, omega0, **options)[0]
    raise OptinavError(f"unknown rate method {method!r}", f"use one of {', '.join(RATE_METHODS)}")


def solve_motion(array: AccelerometerArray, acc, t, omega0=None, method: str = "integration"):
    """The motion of every epoch: ω by :func:`solve_rate`, then [A; ω̇] by weighted least squares of
    ``f − H_quad q(ω) = H_lin [A; ω̇]``. With the calibrated array
    (:meth:`~optinav.gfimu.turntable.TurntableCalibration.calibrated_array`) this is the paper's compensation of
    the installation errors (Hao & Liu 2011, §4).

    Parameters
    ----------
    array : AccelerometerArray
        The geometry the outputs are solved with.
    acc : (T, N) array_like
        Accelerometer outputs [m/s²].
    t : (T,) array_like
        Time stamps [s], strictly increasing.
    omega0 : (3,) array_like, optional
        Angular rate at ``t[0]`` [rad/s]; default at rest.
    method : str
        Rate solver, one of :data:`RATE_METHODS`.

    Returns
    -------
    Motion
        ``A`` (T, 3) specific force at the array's reference point [m/s²], ``wdot`` (T, 3) [rad/s²], ``omega``
        (T, 3) [rad/s].
    """
    f = _outputs(array, acc)
    return MotionSolver(array, omega0, method)(f, _time(t, f.shape[0]))


def rigid_fit(array: AccelerometerArray, acc, omega, P=None) -> tuple[np.ndarray, np.ndarray]:
    """[A, ω̇] (T, 6) [m/s^2, rad/s^2] by weighted least squares of ``acc − H_quad q(ω)`` (``acc`` (T, N) array
    outputs m/s², ``omega`` (T, 3) rad/s) and what the rigid-body model leaves of each output (T, N) m/s²; ``P`` the
    weighted pseudo-inverse of H_lin (6, N) if at hand."""
    if P is None:
        wts = array.weights()
        P = np.linalg.pinv(array.H_lin * wts[:, None]) * wts[None, :]
    fq = acc - quadratic_products(omega) @ array.H_quad.T
    x = fq @ P.T
    return x, fq - x @ array.H_lin.T


class MotionSolver:
    """:func:`solve_motion` block by block: each call solves the next epochs of a log with the rate method's
    state carried from the previous call, so a long log needs memory for one block, and the blocks of a log give
    its whole-array motion to rounding (``optinav apply`` of a gfimu result).

    Parameters
    ----------
    array, omega0, method
        As :func:`solve_motion` (``omega0`` the rate at the log's first epoch).
    **options
        The rate method's options (``prior_std``, ``iterations``, ``sigma``; see :func:`rate_quadratic`).

    Attributes
    ----------
    state : RateState
        The rate method's state after the epochs solved so far.
    rows : int
        Epochs solved so far.
    residual_rms : ndarray or None
        (N,) [m/s^2] RMS per output of what the rigid-body model leaves in the last call's epochs.
    """

    def __init__(self, array: AccelerometerArray, omega0=None, method: str = "integration", **options):
        if method not in RATE_METHODS:
            raise OptinavError(f"unknown rate method {method!r}", f"use one of {', '.join(RATE_METHODS)}")
        self.array, self.method, self.options = array, method, options
        self.state, self.rows = RateState(_omega0(omega0)), 0
        self.residual_rms = None
        wts = array.weights()
        self._P = np.linalg.pinv(array.H_lin * wts[:, None]) * wts[None, :]  # (6, N)

    def __call__(self, acc, t):
        """The motion of the next epochs: outputs ``acc`` (T, N) [m/s^2] at times ``t`` (T,) [s], after the
        epochs of the previous calls (strictly increasing across them too).

        Returns
        -------
        Motion
            ``A`` (T, 3) [m/s^2], ``wdot`` (T, 3) [rad/s^2], ``omega`` (T, 3) [rad/s] of these epochs.
        """
        from optinav.gfimu.errors import Motion

        f = _outputs(self.array, acc)
        prev = () if self.state.t is None else (self.state.t,)
        t = check_timestamps(np.r_[prev, as_float_array(t, "t")], "t", min_count=1, index0=self.rows - len(prev))
        t = t[len(prev) :]
        if t.shape[0] != f.shape[0]:
            raise OptinavError(f"{t.shape[0]} timestamps for {f.shape[0]} output rows", "give one timestamp per row")
        if t.shape[0] == 0:
            return Motion(t, np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)), self.array.name)
        if self.method == "integration":
            w, self.state = _integration(self.array, f, t, self.state)
        elif self.method == "quadratic":
            w, self.state = _quadratic(self.array, f, t, self.state, **self.options)
        else:
            w, _, _, self.state = _gauss_newton(self.array, f, t, self.state, **self.options)
        self.rows += t.shape[0]
        x, left = rigid_fit(self.array, f, w, self._P)
        # what the rigid-body model leaves of each output (the array has more outputs than A and ω̇ take)
        self.residual_rms = np.sqrt(np.mean(left**2, axis=0))
        return Motion(t, x[:, :3], x[:, 3:], w, f"{self.array.name or 'array'} ({self.method})")
