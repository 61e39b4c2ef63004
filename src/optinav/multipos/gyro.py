"""Gyroscope calibration from a multi-position session without a turntable (Tedaldi, Pretto & Menegatti 2014).

Forward model of the gyro triad (the optinav calibration convention)::

    raw = K·ω + b,     ω = K⁻¹(raw − b)

``ω`` is the true angular rate (rad/s) in the frame of the gravity directions ``u`` (the calibrated
accelerometer's frame), ``raw`` the output in the input units (counts, deg/s, …), ``K`` (3×3, full: scale
factors and all six misalignments; raw units per rad/s) and ``b`` (raw units).

Observation (Tedaldi et al., ICRA 2014, §IV-B, eqs. 17–19): the device rests in static intervals
k = 0 … K−1 and is turned by hand between them. ``u_k`` is the unit specific-force ("up") direction of
interval k in the body frame, measured by the calibrated accelerometer. Integrating the corrected gyro over
the motion from the last sample of interval k to the first of interval k+1 gives the body rotation
``C_k = C_{b(k+1)}^{b(k)}``; with the right K and b the gravity direction carried along must land on the
measured one::

    r_k(θ) = C_k(θ)ᵀ u_k − u_{k+1}        (3 components, stacked over the K−1 transitions)

The component of r_k along u_{k+1} is of second order (both vectors are unit), so each transition gives
two constraints: ``n_transitions ≥ 5`` for the 9 entries of K (one spare for the noise estimate).

Integration. Samples may be irregular: rates ω_j = K⁻¹(raw_j − b) are turned into trapezoidal increments
``Δθ_j = ½(ω_j + ω_{j+1})(t_{j+1} − t_j)`` and composed with
:func:`optinav.core.strapdown.attitude_update` using ``coning="previous"`` (the default), whose
coefficient adapts to unequal steps (the multi-sample algorithms assume equal steps within a group).
All transitions go through one numba call: the increment between two transitions is set to zero, which
also zeroes the coning cross term, and ``C_k`` is ``q(start)* ⊗ q(end)``.

Initial guess without hand-set numbers: ``K₀ = k₀·I`` where ``k₀`` comes from a 1-D search. The raw
rotation of transition k (``‖∫(raw − b)dt‖`` in raw·s) over the gravity-direction change ``α_k`` bounds
the scale from above, ``k̂ = ΣΘ_k/Σα_k``; the cost ``Σ‖r‖²`` of ``K = k·I`` is scanned on a log grid
over ``[k̂/20, 2k̂]`` and refined by bounded 1-D minimization. The full K (and b) then follow by
Levenberg–Marquardt (default) or Gauss–Newton / trust region through :func:`optinav.core.optimize.minimize`
with finite-difference Jacobians. The first fit carries a weak pull to the initial guess,
``σ_ref·(θ − θ₀)/(0.1·k₀)`` (``σ_ref`` the residual noise, so ±10 % scale / ±0.1 rad misalignment), so
that directions the data do not fix cannot wander off to fit noise while the rank is judged; a full-rank
problem is then refit without it (the reported K and b carry no prior).

Bias modes: ``"static"`` — mean raw gyro over all static intervals (fixed); ``"local"`` — during each turn the
bias interpolated linearly in time between the means of the two static intervals it joins (a bias that drifts
during the session; the default of ``calibrate accel``; the session mean is reported, its std from the rests:
:func:`_local_bias_var`); ``"rest"`` — mean over a
rest window ``(t0, t1)`` s (fixed); ``"estimate"`` — b fitted with K, with each static interval's mean
added as three residuals ``(m_k − b)/s_k`` (``s_k`` the standard error of the mean from the interval's
sample scatter, white noise assumed) and the angle residuals weighted by ``1/σ̂`` from a first fit with
the static bias; both groups are then rescaled to a unit variance factor (variance components, up to three
passes), since the static means also scatter by the projected Earth rate and g-sensitivity, which the
sample scatter does not show; a 3-vector — b fixed to it.

Uncertainty. ``σ̂² = Σ‖r_k‖²/(2T − n)`` (the residual-estimated noise per tangential component, T
transitions, n fitted parameters); covariance ``σ̂²(JᵀJ)⁻¹`` (Gauss–Newton at the solution; on the
observable subspace, from :func:`optinav.core.observability.analyze`). With a fixed bias from data the
bias' standard error is propagated into K (``G Σ_b Gᵀ`` with ``G = −(JᵀJ)⁻¹Jᵀ ∂r/∂b``). In
``"estimate"`` mode the joint whitened residuals give the variance factor. Where the gyro's noise at rest shows
no anti-alias filter, each turn's integral also errs by its sampling (:func:`_turn_sampling`, the Ferraris
route's term): propagated into K, and the residual power it explains taken out of σ̂ (counted once).

Residuals against the noise. What the fitted residuals should hold is predicted from each modelled source
(:func:`_expected_residuals`): the gyro's white noise and quantization as the rests show them, over each turn
(:func:`_turn_noise`), the rest biases' noise, the Earth rate the model neglects (:func:`_earth_rate`), the up
directions' noise per pose and common to them (``up_cov``: the accelerometer's frame, with its held
misalignments), the turns' sampling and a g-sensitivity, each after the fit absorbed what it can. ``noise_ratio``
q = Σ‖r_k‖² over that prediction; where q > 1 the stated sources' share of K's covariance (all but σ̂'s) is scaled
by q (χ² scaling; ``std_widening`` the largest widening of a K std). The frame's directions are judged apart
(:func:`_frame_split`, :func:`residual_limit`): held misalignments larger than stated show there alone.

Earth rate is neglected: the navigation frame turns by at most ``Ω_E·T_k`` during transition k, and a bias
taken from static data absorbs the projected Earth rate (at most ``Ω_E`` rad/s), which integrates to at
most ``Ω_E·T_k`` more; so each transition's residual is off by at most ``β_k = 2·Ω_E·T_k`` (≈ 2.9e-4 rad
for a 2 s turn). :attr:`GyroCalibration.earth_rate_param_bound` propagates ``β`` to first order into each
parameter (``Σ_k ‖(J⁺)_{i,k}‖ β_k``, and ``‖K_i,:‖·Ω_E`` for a static bias).

Observability. A parameter combination whose standard deviation would exceed ``max_std`` (in units of
``k₀`` for K, i.e. 5 % of the scale or 50 mrad of misalignment by default; ``0.01·k₀`` rad/s for b) counts
as unobservable. A rank-deficient fit raises :class:`OptinavError` naming the combinations and the body
axes about which rotations are missing, unless ``allow_unobservable=True``: then those directions are held
at the initial guess, fitted on the observable subspace only, and listed in ``unobservable``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize as _sp

from optinav.core import earth as _earth
from optinav.core.observability import DEFAULT_REL_TOL, ObservabilityReport, analyze
from optinav.core.optimize import Problem, minimize
from optinav.core.results import Result
from optinav.core.validate import as_float_array, as_rng, check_timestamps
from optinav.multipos.transitions import Transitions
from optinav.errors import OptinavError, SwappedAxes

__all__ = [
    "GYRO_PARAMS",
    "GyroCalibration",
    "calibrate_gyro",
    "theta_to_Kb",
    "Kb_to_theta",
    "transition_residuals",
    "MIN_TRANSITIONS",
]

#: parameter names in θ order: K row-major (K_ij: raw axis i per unit true rate about axis j), then b
GYRO_PARAMS = ("K_xx", "K_xy", "K_xz", "K_yx", "K_yy", "K_yz", "K_zx", "K_zy", "K_zz", "b_x", "b_y", "b_z")
#: the source of the turn residuals that the accelerometer's frame puts there (its fit and held misalignments)
FRAME = "accelerometer frame"
#: fewest transitions: 2 constraints each for the 9 entries of K, plus one for the noise estimate
MIN_TRANSITIONS = 5
#: std [units of k₀ for K] beyond which a combination counts as undetermined (module docstring, Observability)
MAX_STD = 0.05
BIAS_MODES = ("static", "local", "rest", "estimate")
METHODS = ("lm", "gauss-newton", "trf")
_CONING = ("previous", "none")
_UNIT_TOL = 0.05  # |‖u‖ − 1| accepted for the up directions (they are normalized afterwards)
_B_SCALE = 0.01  # rad/s: the magnitude b is judged at (x_scale, observability threshold)
_PRIOR_K = 0.1  # std (units of k₀) of the pull to K₀ in the first, regularized fit
_PRIOR_B = 1.0  # the same for b (rad/s × k₀): loose, b is fixed by the static means
_COEF_TOL = 1e-2  # couplings below 1 % (scaled units) are left out of the words: weak noise-driven mixing


def theta_to_Kb(theta) -> tuple[np.ndarray, np.ndarray]:
    """θ (12,) → K (3, 3) and b (3,)."""
    th = np.asarray(theta, dtype=float)
    return th[:9].reshape(3, 3).copy(), th[9:12].copy()


def Kb_to_theta(K, b) -> np.ndarray:
    """K (3, 3), b (3,) → θ (12,) in :data:`GYRO_PARAMS` order."""
    K = as_float_array(K, "K", last_dims=(3, 3))
    b = as_float_array(b, "b", last_dims=(3,))
    return np.concatenate([K.reshape(-1), b])


@dataclass
class GyroCalibration(Result):
    """Gyro K (raw per rad/s) and b (raw) from gravity-direction matching; see the module docstring.

    ``covariance`` is over θ = (K row-major, b) in :data:`GYRO_PARAMS` order; ``std`` entries are ``inf``
    for parameters that are not individually observable and 0 for a bias given by the user.
    """

    SCHEMA = "optinav.gyro_calibration"
    VERSION = 2

    K: np.ndarray = field(metadata={"unit": "raw/(rad/s)"})
    b: np.ndarray = field(metadata={"unit": "raw"})
    K_std: np.ndarray = field(metadata={"unit": "raw/(rad/s)"})
    b_std: np.ndarray = field(metadata={"unit": "raw"})
    covariance: np.ndarray = field(metadata={"unit": "param^2"})
    residual_rms: float = field(metadata={"unit": "rad"})
    transition_residuals: np.ndarray = field(metadata={"unit": "rad"})
    transition_angles: np.ndarray = field(metadata={"unit": "rad"})
    transition_durations: np.ndarray = field(metadata={"unit": "s"})
    n_transitions: int = field(metadata={"unit": ""})
    sigma: float = field(metadata={"unit": "rad"})
    dof: int = field(metadata={"unit": ""})
    k0: float = field(metadata={"unit": "raw/(rad/s)"})
    observability: ObservabilityReport = field(metadata={"unit": "-"})
    unobservable: list = field(metadata={"unit": "-"})
    earth_rate_bound: np.ndarray = field(metadata={"unit": "rad"})
    earth_rate_param_bound: np.ndarray = field(metadata={"unit": "param"})
    method: str = field(metadata={"unit": "-"})
    bias_mode: str = field(metadata={"unit": "-"})
    coning: str = field(metadata={"unit": "-"})
    success: bool = field(metadata={"unit": "-"})
    message: str = field(metadata={"unit": "-"})
    nfev: int = field(metadata={"unit": ""})
    elapsed_s: float = field(metadata={"unit": "s"})
    #: 1σ per element of the gyro g-sensitivity in the std (given, or revealed by the rests in "local" mode)
    g_sensitivity: float | None = field(default=None, metadata={"unit": "raw/(m/s^2)"})
    g_sensitivity_source: str = field(default="none", metadata={"unit": "-"})
    #: the turns' sampling error in the std (no anti-alias filter), as a share of each turn (RMS; 0: none)
    turn_sampling: float = field(default=0.0, metadata={"unit": "-"})
    #: the share of K_std from the up directions' covariance (``up_cov``: the accelerometer's frame; None: none)
    up_K_std: np.ndarray | None = field(default=None, metadata={"unit": "raw/(rad/s)"})
    #: Σ‖r_k‖² of the turn residuals over what the modelled error sources predict for it (1 on average;
    #: :func:`_expected_residuals`); above 1 the stated sources' share of the K covariance is scaled by it
    noise_ratio: float = field(default=float("nan"), metadata={"unit": "-"})
    #: the predicted Σ‖r_k‖² per source and the moments of its distribution (:func:`_expected_residuals`)
    noise_terms: dict = field(default_factory=dict, metadata={"unit": "rad^2"})
    #: the largest factor by which that scaling widened an element's K std (1: none)
    std_widening: float = field(default=1.0, metadata={"unit": "-"})

    def correct(self, gyro_raw) -> np.ndarray:
        """Calibrated rate ω = K⁻¹(raw − b), rad/s, for raw (..., 3)."""
        raw = as_float_array(gyro_raw, "gyro_raw", last_dims=(3,))
        return np.linalg.solve(np.asarray(self.K), (raw - np.asarray(self.b)).reshape(-1, 3).T).T.reshape(raw.shape)

    def scale_misalignment(self) -> tuple[np.ndarray, np.ndarray]:
        """Relative scale factors ``diag(K)/k`` (k = mean diagonal) and misalignments ``K_ij/K_ii`` (rad)."""
        K = np.asarray(self.K)
        d = np.diag(K)
        return d / d.mean(), K / d[:, None] - np.eye(3)

    def summary(self) -> str:
        K, Ks = np.asarray(self.K), np.asarray(self.K_std)
        lines = [
            f"Gyro calibration ({self.method}, bias {self.bias_mode}): {self.n_transitions} transitions, "
            f"residual RMS {self.residual_rms:.3g} rad, σ̂ {self.sigma:.3g} rad ({self.dof} dof), "
            f"{self.elapsed_s:.3g} s"
        ]
        for i in range(3):
            row = "  ".join(f"{K[i, j]:12.6g} ± {Ks[i, j]:.2g}" for j in range(3))
            lines.append(f"  K[{'xyz'[i]}] = {row}  raw/(rad/s)")
        lines.append("  b = " + ", ".join(f"{v:.6g} ± {s:.2g}" for v, s in zip(self.b, self.b_std)) + " raw")
        if self.unobservable:
            lines.append("  held at the initial guess (unobservable): " + "; ".join(self.unobservable))
        lines.append(f"  Earth rate neglected: ≤ {np.max(self.earth_rate_bound):.2g} rad per transition")
        return "\n".join(lines)


# ------------------------------------------------------------------------------------------------------
# input handling
# ------------------------------------------------------------------------------------------------------


def _intervals(static_intervals, t: np.ndarray, units: str) -> np.ndarray:
    iv = as_float_array(static_intervals, "static_intervals", last_dims=(2,))
    if iv.ndim != 2:
        raise OptinavError(
            f"static_intervals has shape {iv.shape}, expected (K, 2)", "pass one [start, end) pair per static interval"
        )
    n = t.size
    if units == "samples":
        if np.any(iv != np.round(iv)):
            raise OptinavError(
                "static_intervals are not whole sample indices",
                "pass integer [i0, i1) index pairs, or interval_units='s' for times",
            )
        idx = iv.astype(np.int64)
    elif units == "s":
        if np.any(iv[:, 1] <= iv[:, 0]):
            k = int(np.flatnonzero(iv[:, 1] <= iv[:, 0])[0])
            raise OptinavError(
                f"static interval {k} ends before it starts ({iv[k, 0]:.6g} s → {iv[k, 1]:.6g} s)",
                "give [t0, t1] with t0 < t1",
            )
        idx = np.stack([np.searchsorted(t, iv[:, 0], "left"), np.searchsorted(t, iv[:, 1], "right")], 1)
    else:
        raise OptinavError(f"interval_units={units!r} is not understood", "use 'samples' or 's'")
    bad = (idx[:, 0] < 0) | (idx[:, 1] > n)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise OptinavError(
            f"static interval {k} [{idx[k, 0]}, {idx[k, 1]}) is outside the {n} samples",
            "give sample ranges within the log",
        )
    short = idx[:, 1] - idx[:, 0] < 2
    if np.any(short):
        k = int(np.flatnonzero(short)[0])
        raise OptinavError(
            f"static interval {k} holds {max(int(idx[k, 1] - idx[k, 0]), 0)} sample(s)",
            "give each static interval at least two samples",
        )
    over = idx[1:, 0] < idx[:-1, 1]
    if np.any(over):
        k = int(np.flatnonzero(over)[0])
        what = "overlaps" if idx[k + 1, 0] >= idx[k, 0] else "starts before"
        raise OptinavError(
            f"static interval {k + 1} {what} interval {k} "
            f"([{idx[k + 1, 0]}, {idx[k + 1, 1]}) vs [{idx[k, 0]}, {idx[k, 1]}))",
            "pass disjoint intervals sorted in time",
        )
    return idx


def _up_dirs(up_dirs, n_int: int) -> np.ndarray:
    u = as_float_array(up_dirs, "up_dirs", last_dims=(3,))
    if u.ndim != 2 or u.shape[0] != n_int:
        raise OptinavError(
            f"up_dirs has shape {u.shape}, expected ({n_int}, 3) for {n_int} static intervals",
            "give one gravity direction per static interval",
        )
    nrm = np.linalg.norm(u, axis=1)
    bad = np.abs(nrm - 1.0) > _UNIT_TOL
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise OptinavError(
            f"up_dirs[{k}] has norm {nrm[k]:.4g}, not a unit vector",
            "normalize the mean calibrated specific force of each interval",
        )
    return u / nrm[:, None]


def _choice(value, options, name: str) -> str:
    v = str(value).lower() if isinstance(value, str) else None
    if v not in options:
        raise OptinavError(f"{name}={value!r} is not understood", f"use one of {', '.join(map(repr, options))}")
    return v


# ------------------------------------------------------------------------------------------------------
# the model
# ------------------------------------------------------------------------------------------------------


def transition_residuals(
    t, gyro_raw, static_intervals, up_dirs, K, b, *, interval_units: str = "samples", coning: str = "previous"
) -> np.ndarray:
    """Residuals r_k = C_kᵀu_k − u_{k+1} (T, 3) of a given K (raw per rad/s) and b (raw); see the module doc."""
    t = check_timestamps(t, "t")
    raw = _raw(gyro_raw, t.size)
    idx = _intervals(static_intervals, t, _choice(interval_units, ("samples", "s"), "interval_units"))
    u = _up_dirs(up_dirs, idx.shape[0])
    tr = Transitions(t, raw, idx, u, _choice(coning, _CONING, "coning"))
    return tr.residuals(as_float_array(K, "K", last_dims=(3, 3)), as_float_array(b, "b", last_dims=(3,)))


def _raw(gyro_raw, n: int) -> np.ndarray:
    raw = as_float_array(gyro_raw, "gyro_raw", last_dims=(3,))
    if raw.ndim != 2 or raw.shape[0] != n:
        raise OptinavError(
            f"gyro_raw has shape {raw.shape}, expected ({n}, 3) to match t", "pass one gyro sample per timestamp"
        )
    return raw


def _angles(r: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """Angle between the predicted (r + u1) and measured (u1) directions, rad."""
    p = r + u1
    return np.arctan2(np.linalg.norm(np.cross(p, u1), axis=1), np.einsum("ij,ij->i", p, u1))


def _scale_guess(tr: Transitions, b: np.ndarray) -> float:
    """k₀ of K = k₀·I by a log-grid scan and a bounded 1-D refinement (see the module docstring)."""
    theta = tr.raw_rotation(b)
    alpha = np.arccos(np.clip(np.einsum("ij,ij->i", tr.u0, tr.u1), -1.0, 1.0))
    if alpha.sum() < np.radians(5.0) or theta.sum() <= 0:
        raise OptinavError(
            f"the transitions change the gravity direction by only {np.degrees(alpha.sum()):.3g}° "
            "in total, so the gyro scale cannot be found",
            "turn the device between poses so that the up axis changes (e.g. flips about x, y, z)",
        )
    k_hat = theta.sum() / alpha.sum()
    _check_axes(tr, b, k_hat)

    def cost(s):
        r = tr.residuals(np.exp(s) * np.eye(3), b)
        return float(np.sum(r * r))

    grid = np.log(k_hat) + np.linspace(np.log(1 / 20), np.log(2.0), 49)
    c = np.array([cost(s) for s in grid])
    i = int(np.argmin(c))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = _sp.minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 1e-9})
    s = res.x if res.fun <= c[i] else grid[i]
    return float(np.exp(s))


def _check_axes(tr: Transitions, b: np.ndarray, k: float) -> None:
    """Axis-swap diagnosis: the cost of K = k·P for the 48 signed axis permutations P; a clearly better P than
    the identity means the gyro columns are swapped or flipped against the accelerometer's (a local fit from
    K ∝ I cannot reach a permutation)."""
    from optinav.multipos import gates

    perms = gates.signed_permutations()  # the identity first
    costs = tr.permutation_costs(k, b, perms)
    i = int(np.argmin(np.where(np.isnan(costs), np.inf, costs)))  # the first smallest; a NaN never the best
    c_id = costs[0]
    if i != 0 and costs[i] < 0.1 * c_id:
        raise SwappedAxes(
            "the gyroscope axes look swapped or flipped against the accelerometer's: "
            + gates.describe_permutation(perms[i], "gyroscope", "accelerometer frame")
            + f" (turn residual {np.sqrt(costs[i] / len(tr.u0)):.2g} vs "
            f"{np.sqrt(c_id / len(tr.u0)):.2g} as labelled)",
            "fix the column order or signs (--columns or --gyro-columns)",
        )


def _stats(raw, idx):
    """Per-interval means (K, 3), standard errors of the means (K, 3) and sample counts (K,)."""
    n = idx[:, 1] - idx[:, 0]
    m = np.array([raw[i0:i1].mean(0) for i0, i1 in idx])
    s = np.array([raw[i0:i1].std(0, ddof=1) for i0, i1 in idx]) / np.sqrt(n)[:, None]
    return m, s, n


def _missing_axes(rep: ObservabilityReport) -> str:
    cols = set()
    for d in rep.unobservable_directions:
        for j, ax in enumerate("xyz"):
            if any(f"K_{r}{ax}" in d for r in "xyz"):
                cols.add(j)
    bias = any("b_" in d for d in rep.unobservable_directions)
    if cols:
        ax = ["xyz"[j] for j in sorted(cols)]
        axes = ax[0] if len(ax) == 1 else ", ".join(ax[:-1]) + " and " + ax[-1]
        txt = (
            f"add poses whose transitions rotate about the body {axes} {'axes' if len(cols) > 1 else 'axis'} "
            f"(e.g. flip the device about {axes} so that gravity moves in the plane normal to it)"
        )
    else:
        txt = "add transitions about other axes and between more different poses"
    if bias:
        txt += "; give longer static intervals or a bias vector"
    return txt + ", or pass --allow-unobservable to hold what the turns do not determine"


# ------------------------------------------------------------------------------------------------------
# the calibration
# ------------------------------------------------------------------------------------------------------


def calibrate_gyro(
    t,
    gyro_raw,
    static_intervals,
    up_dirs,
    *,
    bias="static",
    rest=None,
    method: str = "lm",
    x0=None,
    rng=None,
    interval_units: str = "samples",
    coning: str = "previous",
    allow_unobservable: bool = False,
    max_std: float = MAX_STD,
    drop_transitions=(),
    g_sensitivity_std: float | None = None,
    gravity: float = 9.80665,
    unit: str | None = None,
    bias_instability=None,
    bias_corr_time: float = float("inf"),
    up_cov=None,
    up_noise=None,
) -> GyroCalibration:
    """Gyro K and b of ``raw = K·ω + b`` from static intervals and the turns between them.

    Parameters
    ----------
    t : (N,) array
        Sample times [s], strictly increasing (irregular steps are fine).
    gyro_raw : (N, 3) array
        Gyro output [raw units] (counts, deg/s, …: K and b come out in those units).
    static_intervals : (K, 2) array
        Static intervals in time order, disjoint: sample index pairs ``[i0, i1)`` (``interval_units="samples"``)
        or times ``[t0, t1]`` [s] (``interval_units="s"``).
    up_dirs : (K, 3) array
        Unit specific-force direction of each interval in the body frame [-] (normalized mean of the calibrated
        accelerometer); defines the frame of ω.
    bias : str or (3,) array
        "static", "local", "rest", "estimate" (:data:`BIAS_MODES`) or a 3-vector [raw units] (module docstring).
    rest : (2,) tuple or None
        The rest window (t0, t1) [s] of ``bias="rest"``.
    method : str
        "lm" (default), "gauss-newton" or "trf" (:func:`optinav.core.optimize.minimize`).
    x0 : (3, 3) or (12,) array or None
        Initial K [raw/(rad/s)], or θ = (K row-major, b) [raw/(rad/s), raw]; None: the 1-D scale step.
    rng : int, Generator or None
        Passed to the optimizer (the local methods are deterministic).
    interval_units : str
        ``"samples"`` or ``"s"``: the units of ``static_intervals``.
    coning : str
        "previous" (default, adapts to irregular steps) or "none".
    allow_unobservable : bool
        Hold unobservable directions at the initial guess instead of raising.
    max_std : float
        Combinations with a larger standard deviation [k₀ for K, 0.01·k₀ for b] are treated as unobservable.
    drop_transitions : sequence of int
        Indices k of transitions (interval k → k+1) left out, e.g. where the gyro saturates.
    g_sensitivity_std : float or None
        1σ of each element of the gyro g-sensitivity [raw per m/s^2] (datasheet), which the model leaves out.
        A fixed bias then holds G·f̄ (f̄ the mean specific force of the rests), added to the bias variance; each
        turn sees G·(f − f̄), at most σ·g per axis, propagated into K like a bias error ("local": G·g·(u(t) − the
        interpolation chord) along the integrated turn, to first order; when not given, the σ the rest biases
        reveal if they follow the specific force, :func:`_rest_regression`).
    gravity : float
        Magnitude of f̄ along the mean up direction [m/s^2].
    unit : str or None
        The declared unit of ``gyro_raw`` ("rad/s", "deg/s", "counts"); when given, the turns are checked against
        the gravity-direction changes before the fit (:func:`optinav.multipos.gates.check_gyro_turns`).
    bias_instability : float, (3,) array or None
        1σ of a bias drift over the session [raw units] (datasheet in-run bias instability, or run-to-run),
        added to the bias variance. With ``bias="local"`` it is the stationary σ of a first-order Gauss–Markov
        bias of correlation time ``bias_corr_time``, and the variance added is what the session's mean over its
        rests keeps of it (:func:`_local_bias_var`): the std is then against the unit's long-term bias, without it
        against the bias of this session (the mean of the bias over the static intervals).
    bias_corr_time : float
        Correlation time of that Gauss–Markov bias [s] (default ∞: a constant offset per run).
    up_cov : (3K, 3K) array or None
        Covariance of the up directions (row-major) [-] that is common to the poses — from the accelerometer's own
        calibration: its errors turn every pose's direction together, which the turn residuals cannot show;
        propagated into K and b to first order. Independent noise per pose is in the residuals already.
    up_noise : (K, 3, 3) array or None
        Covariance of each up direction's own noise [-] (independent from pose to pose, e.g. the pose mean's
        noise through the accelerometer calibration); used only to predict the turn residuals (``noise_ratio``).

    Returns
    -------
    GyroCalibration
        K [raw/(rad/s)] and b [raw] with covariance, std and observability.
    """
    t_start = time.perf_counter()
    t = check_timestamps(t, "t", min_count=4)
    raw = _raw(gyro_raw, t.size)
    units = _choice(interval_units, ("samples", "s"), "interval_units")
    idx = _intervals(static_intervals, t, units)
    u = _up_dirs(up_dirs, idx.shape[0])
    method = _choice(method, METHODS, "method")
    coning = _choice(coning, _CONING, "coning")
    try:
        max_std = float(max_std)
    except (TypeError, ValueError):
        max_std = float("nan")
    if not (np.isfinite(max_std) and max_std > 0):
        raise OptinavError(f"max_std must be a positive number, got {max_std!r}", "pass e.g. 0.05")
    drop = {int(k) for k in np.ravel(drop_transitions)}
    keep = np.array([k for k in range(idx.shape[0] - 1) if k not in drop], int)
    n_tr = keep.size
    if n_tr < MIN_TRANSITIONS:
        raise OptinavError(
            f"{n_tr} transition(s) usable between {idx.shape[0]} static intervals, at least "
            f"{MIN_TRANSITIONS} are needed (each gives 2 constraints on the 9 entries of K, "
            "plus one for the noise estimate)",
            f"record at least {MIN_TRANSITIONS + 1} static poses with turns about all three axes",
        )
    gen = as_rng(rng)

    # --- bias
    means, sems, counts = _stats(raw, idx)
    if isinstance(bias, str):
        mode = _choice(bias, BIAS_MODES, "bias")
        b_fixed = None
    else:
        mode = "given"
        b_fixed = as_float_array(bias, "bias", last_dims=(3,))
        if b_fixed.shape != (3,):
            raise OptinavError(f"bias has shape {b_fixed.shape}, expected (3,)", "pass one bias per axis (raw)")
    if rest is not None and mode != "rest":
        raise OptinavError(
            f"rest was given but bias={bias if mode != 'given' else 'a vector'!r}",
            "pass bias='rest' to use the rest window, or drop rest",
        )
    b_cov = np.zeros((3, 3))
    if mode == "rest":
        if rest is None:
            raise OptinavError("bias='rest' needs the rest window", "pass rest=(t0, t1) in s")
        w = as_float_array(rest, "rest")
        if w.shape != (2,) or not w[1] > w[0]:
            raise OptinavError(f"rest must be (t0, t1) with t0 < t1 in s, got {w.tolist()}", "pass rest=(t0, t1)")
        sel = (t >= w[0]) & (t <= w[1])
        if np.count_nonzero(sel) < 2:
            raise OptinavError(
                f"the rest window [{w[0]:.6g}, {w[1]:.6g}] s holds {np.count_nonzero(sel)} sample(s)",
                "give a window inside the log with at least two samples",
            )
        b_fixed = raw[sel].mean(0)
        b_cov = np.diag(raw[sel].var(0, ddof=1) / np.count_nonzero(sel))
    elif mode in ("static", "local", "estimate"):
        b_static = (counts[:, None] * means).sum(0) / counts.sum()
        b_cov = np.diag((counts[:, None] ** 2 * sems**2).sum(0) / counts.sum() ** 2)
        if mode == "static":
            b_fixed = b_static
        elif mode == "local":
            b_fixed = b_static  # replaced by the per-sample interpolation once the turns are cut out
    b_init = b_fixed if b_fixed is not None else b_static

    tr = Transitions(t, raw, idx, u, coning, keep)
    if mode == "local":
        # a drifting bias: during a turn, the bias interpolated linearly in time between the means of the two
        # rests it joins (exact for a linear drift); the session mean is reported, with the spread of the rest
        # means as its std (the bias at any one time is within it)
        tc = np.array([t[i0:i1].mean() for i0, i1 in idx])
        k0_, k1_ = keep[tr.seg], keep[tr.seg] + 1
        f = ((tr.t_rows - tc[k0_]) / (tc[k1_] - tc[k0_]))[:, None]
        b_fixed = means[k0_] + f * (means[k1_] - means[k0_])
        chord = u[k0_] + f * (u[k1_] - u[k0_])  # the specific force the interpolated bias assumes (units of g)
        b_init = b_fixed
        b_cov = np.diag(np.mean(sems**2, axis=0) / 2)  # one turn's bias: the mean of two rests (propagated)

    if unit is not None:
        # before any fit: the turns must agree with the gravity-direction changes in the declared unit
        from . import gates

        theta_perp, alpha = tr.turn_angles(b_init)
        noise = float(np.median(sems * np.sqrt(counts)[:, None])) * np.sqrt(float(np.median(tr.h)) * tr.durations)
        gates.check_gyro_turns(theta_perp, alpha, noise, tr.t_rows[tr.starts], tr.t_rows[tr.ends], unit)

    # --- initial guess
    if x0 is None:
        k0 = _scale_guess(tr, b_init)
        K0 = k0 * np.eye(3)
    else:
        xa = as_float_array(x0, "x0")
        if xa.shape == (3, 3):
            K0 = xa
        elif xa.shape == (12,):
            K0, bx = theta_to_Kb(xa)
            if mode == "estimate":
                b_init = bx
        else:
            raise OptinavError(f"x0 has shape {xa.shape}, expected K (3, 3) or θ (12,)", "pass the initial K")
        if abs(np.linalg.det(K0)) <= 1e-12 * np.abs(K0).max() ** 3:
            raise OptinavError("x0 is a singular K", "pass an invertible initial K (raw per rad/s)")
        k0 = float(np.abs(np.diag(K0)).mean())

    n_par = 12 if mode == "estimate" else 9
    names = list(GYRO_PARAMS[:n_par])
    scales = np.array([k0] * 9 + [k0 * _B_SCALE] * 3)[:n_par]
    param_units = (["raw/(rad/s)"] * 9 + ["raw"] * 3)[:n_par]

    def split(p):
        if mode == "estimate":
            return p[:9].reshape(3, 3), p[9:12]
        return p.reshape(3, 3), b_fixed

    def angle_res(p):
        K, b = split(p)
        try:
            return tr.residuals(K, b).reshape(-1)
        except np.linalg.LinAlgError:
            return np.full(3 * n_tr, 2.0)

    p_guess = np.concatenate([K0.reshape(-1), b_init]) if mode == "estimate" else K0.reshape(-1)
    prior_sd = np.array([_PRIOR_K * k0] * 9 + [_PRIOR_B * k0] * 3)[:n_par]

    # --- fit (in "estimate" a first fit with the static bias sets the weight 1/σ̂ of the angle residuals)
    sigma_w = 1.0
    p_start = p_guess
    nfev = 0
    if mode == "estimate":

        def ang_static(p):
            return angle_res(np.concatenate([p, b_static]))

        pre, n_ev = _fit_regularized(
            ang_static, K0.reshape(-1), K0.reshape(-1), prior_sd[:9], 2 * n_tr - 9, names[:9], scales[:9], method, gen
        )
        nfev += n_ev
        sigma_w = max(_sigma_hat(ang_static(pre.x), 2 * n_tr - 9), 1e-12)
        p_start = np.concatenate([pre.x, b_init])
        # the static means scatter about one b by more than their noise when the projected Earth rate or
        # g-sensitivity exceed it: scale that group to a unit variance factor before weighing it
        zs = (means - b_static) / sems
        wts = {"a": sigma_w, "s": max(1.0, float(np.sqrt(np.sum(zs * zs) / max(zs.size - 3, 1))))}

        def residuals(p):
            return np.concatenate([angle_res(p) / wts["a"], ((means - p[9:12]) / (sems * wts["s"])).reshape(-1)])
    else:
        residuals = angle_res

    n_res_eff = 2 * n_tr + (3 * idx.shape[0] if mode == "estimate" else 0)
    dof = n_res_eff - n_par
    res_a, n_ev = _fit_regularized(residuals, p_guess, p_start, prior_sd, dof, names, scales, method, gen)
    nfev += n_ev
    r_a = residuals(res_a.x)
    J_a = np.asarray(res_a.jacobian)[: r_a.size]
    rep = _report(J_a, r_a, dof, names, param_units, scales, max_std)
    if rep.full_rank:
        res = _fit(residuals, res_a.x, names, scales, method, gen)
        nfev += res.nfev
        if mode == "estimate":
            # variance components: rescale each group to a unit variance factor (the static means also carry
            # the projected Earth rate and g-sensitivity, which their sample scatter does not show)
            for _ in range(3):
                ra, rs = res.residuals[: 3 * n_tr], res.residuals[3 * n_tr :]
                fa = float(ra @ ra) / max(2 * n_tr - 9, 1)
                fs = float(rs @ rs) / max(3 * idx.shape[0] - 3, 1)
                if fa <= 0 or fs <= 0 or 0.8 < fa / fs < 1.25:
                    break
                wts["a"] *= np.sqrt(fa)
                wts["s"] *= np.sqrt(fs)
                res = _fit(residuals, res.x, names, scales, method, gen)
                nfev += res.nfev
            sigma_w = wts["a"]
            sems = sems * wts["s"]
        p_hat, J, r_fin = res.x, np.asarray(res.jacobian), np.asarray(res.residuals)
        rep = _report(J, r_fin, dof, names, param_units, scales, max_std)
        J_a, r_a = J, r_fin
    unobservable: list[str] = []
    if not rep.full_rank:
        unobservable = list(rep.unobservable_directions)
        # an under-determined design still fits its turns to the noise (≤ 1.5° RMS for a consumer MEMS gyro);
        # turns that miss by tens of degrees are triads that disagree, which no choice of held parameters fixes
        miss = float(np.degrees(np.sqrt(np.mean(angle_res(res_a.x) ** 2))))
        if miss > _MISMATCH_DEG:
            raise SwappedAxes(
                f"the gyro's turns between the poses do not match how the accelerometer's gravity moved: they miss "
                f"by {miss:.0f}° RMS after the best fit (noise gives about 1°)",
                "an axis of one triad is flipped or two are swapped (check the columns' order and signs: both "
                "triads right-handed, in the same body axes), or a 'static' pose moved (--threshold, --sections)",
            )
        if not allow_unobservable:
            raise OptinavError(
                f"gyro calibration is rank-deficient (rank {rep.rank}/{n_par}); unobservable: "
                + "; ".join(unobservable),
                _missing_axes(rep),
            )
        # hold the null directions at the initial guess: fit only along the observable subspace
        Js = (J_a / _sigma_hat(r_a, dof)) * scales[None, :]
        _, _, vt = np.linalg.svd(Js, full_matrices=True)
        basis = (vt[: rep.rank].T) * scales[:, None]

        def sub(z):
            return residuals(p_guess + basis @ z)

        res = _fit(sub, np.zeros(rep.rank), [f"z{i}" for i in range(rep.rank)], np.ones(rep.rank), method, gen)
        nfev += res.nfev
        p_hat = p_guess + basis @ res.x
        r_fin = residuals(p_hat)
        J = _jac(residuals, p_hat, scales, r_fin)
        dof = n_res_eff - rep.rank
        rep = _report(J, r_fin, dof, names, param_units, scales, max_std)

    # --- uncertainty
    sig_hat = _sigma_hat(r_fin, dof)
    cov_fit = np.asarray(rep.covariance)
    K_hat, b_hat = split(p_hat)
    cov = np.zeros((12, 12))
    cov[:n_par, :n_par] = cov_fit
    A = _pinv(J, scales, rep.rank)  # n_par × m, on the observable subspace
    r_ang = tr.residuals(K_hat, b_hat)
    # what the turn residuals should hold: each modelled error source as a square root (3T × m, rad)
    sources = {"gyro noise": _turn_noise(tr, raw, idx, K_hat)}
    if mode == "estimate":
        sigma_ang = sigma_w * sig_hat
    else:
        sigma_ang = sig_hat
        cov[9:, 9:] = b_cov
        if mode in ("static", "local", "rest"):
            b_ref = b_hat if mode != "local" else b_static
            Jb = _jac(
                lambda bb: tr.residuals(K_hat, b_hat + (bb - b_ref)).reshape(-1),
                b_ref,
                np.full(3, k0 * _B_SCALE),
                r_ang.reshape(-1),
            )
            G = -A @ Jb
            # a static bias holds G·f̄ and each turn sees G·(f − f̄), up to σ·g per axis ("local": below)
            sg_turn = abs(float(g_sensitivity_std or 0.0)) * gravity if mode != "local" else 0.0
            b_prop = b_cov + np.eye(3) * sg_turn**2
            sources["rest biases"] = Jb @ _sqrt_psd(b_prop)
            cov[:9, :9] += G @ b_prop @ G.T
            cov[:9, 9:] = G @ b_cov
            cov[9:, :9] = cov[:9, 9:].T
    g_sens = g_sensitivity_std
    g_sens_source = "given" if g_sensitivity_std else "none"
    # residual power (Σr²) that a modelled error source puts there: counted once, in its own term, not in σ̂ too
    explained = 0.0
    b_turn = b_fixed if mode == "local" else b_hat
    samp_share, samp = _turn_sampling(tr, raw, idx, K_hat, b_turn, k0)
    if samp is not None:
        # δr = Js·δΘ per transition; in "estimate" the angle residuals are weighted by 1/σ_w
        dr = np.zeros((J.shape[0], samp.shape[1]))
        dr[: 3 * n_tr] = samp / (sigma_w if mode == "estimate" else 1.0)
        M_s = A @ dr
        sources["sampling"] = samp
        cov[:n_par, :n_par] += M_s @ M_s.T
        P_s = dr - J @ M_s
        explained += float(np.sum(P_s * P_s))
    if mode == "static":
        # the mean of the rests holds each rest's Earth rate, which points a different way in each pose: the
        # session-mean model of "local" without its drift terms (a full Ω_E·K_ii bound overstated it 4-5×)
        cov[9:, 9:] = np.diag(_local_bias_var(sems, counts / counts.sum(), u, None, K_hat))
    elif mode == "estimate":
        # the fitted b is close to the mean of the rests and holds their Earth rate as that does; the fit's std
        # alone was 25 % small in Monte Carlo runs (RMS error/std 1.33)
        cov[9:, 9:] += np.diag(_local_bias_var(np.zeros_like(sems), counts / counts.sum(), u, None, K_hat))
    if mode == "local":
        # the session-mean bias: rest-mean noise and the rests' own scatter (Earth rate), plus a stated drift model
        w_rest = counts / counts.sum()
        reg = _rest_regression(means, tc, u, gravity)
        cov[9:, 9:] = np.diag(_local_bias_var(sems, w_rest, u, tc, K_hat, bias_instability, bias_corr_time))
        if not g_sensitivity_std and reg is not None and reg["g_significant"]:
            # the rest biases follow the specific force: the data reveal a g-sensitivity the model leaves out
            g_sens, g_sens_source = reg["g_sigma"], "rests"
        if g_sens:
            # a g-sensitivity G enters linearly: b̂ holds G·g·ū (ū the rests' mean up direction), and each turn's
            # interpolated bias misses G·g·(u(t) − chord(t)); first-order propagation of the 9 elements of G
            ubar = w_rest @ u
            dev = (tr.gravity_path(K_hat, b_fixed) - chord) * gravity
            r0 = r_ang.reshape(-1)
            hg = k0 * _B_SCALE * 1e-3 / gravity
            J_G = np.empty((r0.size, 9))
            for i in range(3):
                for j in range(3):
                    bb = b_fixed.copy()
                    bb[:, i] += hg * dev[:, j]
                    J_G[:, 3 * i + j] = (tr.residuals(K_hat, bb).reshape(-1) - r0) / hg
            L = np.zeros((12, 9))
            L[:9] = A @ J_G
            # the part of G's turn errors that K cannot absorb is already in σ̂ (the residuals): count it once
            P = J_G - J @ L[:9]
            sources["g-sensitivity"] = float(g_sens) * J_G
            explained += float(g_sens) ** 2 * float(np.sum(P * P))
            for i in range(3):
                L[9 + i, 3 * i : 3 * i + 3] = gravity * ubar
            cov += float(g_sens) ** 2 * (L @ L.T)
    sig2 = sig_hat**2
    keep_fit = 1.0
    if explained > 0.0 and sig2 > 0:
        keep_fit = max(sig2 - explained / max(dof, 1), 0.0) / sig2
        cov[:n_par, :n_par] -= (1.0 - keep_fit) * cov_fit
    if mode != "local" and bias_instability is not None and mode != "given":
        # a drift common to the whole session leaves no trace in the rests: only a noise model can bound it
        cov[9:, 9:] += np.diag(np.broadcast_to(np.square(np.asarray(bias_instability, float)), (3,)))
    if g_sensitivity_std and mode != "local":
        sg = abs(float(g_sensitivity_std)) * float(gravity)
        fbar = (counts[:, None] * u).sum(0) / counts.sum() if mode != "rest" else np.ones(1)
        cov[9:, 9:] += np.eye(3) * sg**2 * float(fbar @ fbar)
    up_K_std = None
    if up_cov is not None:
        Ju = tr.up_jacobian(K_hat, b_hat, u.shape[0])
        if mode == "estimate":
            Ju = Ju / wts["a"]
        Ju = np.vstack([Ju, np.zeros((A.shape[1] - Ju.shape[0], Ju.shape[1]))])
        M = A @ Ju
        up_K = M @ np.asarray(up_cov, float) @ M.T
        cov[:n_par, :n_par] += up_K
        # the share of it K cannot absorb (a held accelerometer misalignment's shear) also raises σ̂; left there:
        # taken out, the coverage on the six axis poses twice was worse (RMS error/std 1.49 for 1.40) and the
        # std of imucal's K_zz 10 % smaller
        up_K_std = np.sqrt(np.clip(np.diag(up_K)[:9], 0.0, None)).reshape(3, 3)
        sources[FRAME] = tr.up_jacobian(K_hat, b_hat, u.shape[0]) @ _sqrt_psd(np.asarray(up_cov, float))
    if up_noise is not None:
        un = np.asarray(up_noise, float)
        L = np.zeros((3 * un.shape[0], 3 * un.shape[0]))
        for i, c in enumerate(un):
            L[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = _sqrt_psd(c)
        sources["pose directions"] = tr.up_jacobian(K_hat, b_hat, u.shape[0]) @ L
    sources["Earth rate"] = _earth_rate(tr, K_hat, np.broadcast_to(b_turn, tr.raw.shape), mode == "local")
    noise_terms, M_n, M_f = _expected_residuals(
        sources, J, A, 3 * n_tr, sigma_w if mode == "estimate" else 1.0, mode == "estimate"
    )
    noise_ratio = float(np.sum(r_ang * r_ang)) / noise_terms["total"]
    # (each r_k's component along u_{k+1} is of second order, outside the sources' linear model: left out)
    r_tan = r_ang - np.einsum("ij,ij->i", r_ang, tr.u1)[:, None] * tr.u1
    noise_terms.update(_frame_split(r_tan, M_n, M_f))
    std_before = np.sqrt(np.clip(np.diag(cov)[:9], 0.0, None))
    if noise_ratio > 1.0:
        # χ² scaling: the residuals hold more than the sources predict, so the stated sources' sizes are taken as
        # √q too small and their share of K's covariance is scaled by q (the fit's own share, from σ̂, follows the
        # residuals already); the six axis poses twice (MTi-1, 40 seeds, --held-misalignment 0.005 where the unit's
        # held terms spread 0.0071): RMS error/std of K_g 1.31 → 1.03
        cov[:9, :9] += (noise_ratio - 1.0) * (cov[:9, :9] - keep_fit * cov_fit[:9, :9])
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    obs = np.ones(12, dtype=bool)
    obs[:n_par] = np.asarray(rep.observable, dtype=bool)
    std = np.where(obs, std, np.inf)
    widened = std[:9] / np.where(std_before > 0, std_before, np.inf)
    std_widening = float(np.max(widened[np.isfinite(widened)], initial=1.0))

    # --- Earth-rate bound (first order, see the module docstring)
    om = _earth.constants("wgs84").omega_ie
    beta = 2.0 * om * tr.durations
    bound = np.zeros(12)
    Aa = A[:, : 3 * n_tr].reshape(n_par, n_tr, 3)
    scale_ang = 1.0 / sigma_w if mode == "estimate" else 1.0
    bound[:n_par] = np.linalg.norm(Aa, axis=2) @ beta * scale_ang
    row_norm = np.linalg.norm(K_hat, axis=1)
    if mode == "estimate":
        As = np.abs(A[:, 3 * n_tr :]).reshape(n_par, idx.shape[0], 3)
        bound[:n_par] += np.einsum("pki,ki->p", As, (row_norm * om)[None, :] / sems)
    elif mode in ("static", "local", "rest"):
        bound[9:] = row_norm * om
    bound[~obs] = np.inf

    angles = _angles(r_ang, tr.u1)
    rot_ang = 2.0 * np.arctan2(
        np.linalg.norm(tr.rotations(K_hat, b_hat)[:, 1:], axis=1), np.abs(tr.rotations(K_hat, b_hat)[:, 0])
    )
    return GyroCalibration(
        K=K_hat.copy(),
        b=np.asarray(b_static if mode == "local" else b_hat, dtype=float).copy(),
        K_std=std[:9].reshape(3, 3),
        b_std=std[9:].copy(),
        covariance=cov,
        residual_rms=float(np.sqrt(np.mean(angles**2))),
        transition_residuals=angles,
        transition_angles=rot_ang,
        transition_durations=tr.durations.copy(),
        n_transitions=int(n_tr),
        sigma=float(sigma_ang),
        dof=int(dof),
        k0=float(k0),
        observability=rep,
        unobservable=unobservable,
        earth_rate_bound=beta,
        earth_rate_param_bound=bound,
        method=method,
        bias_mode=mode,
        coning=coning,
        success=bool(res.success),
        message=str(res.message),
        nfev=int(nfev),
        elapsed_s=time.perf_counter() - t_start,
        g_sensitivity=float(g_sens) if g_sens else None,
        g_sensitivity_source=g_sens_source,
        turn_sampling=float(samp_share),
        up_K_std=up_K_std,
        noise_ratio=noise_ratio,
        noise_terms=noise_terms,
        std_widening=std_widening,
    )


def _turn_sampling(tr: Transitions, raw, idx, K, b, k0: float) -> tuple[float, np.ndarray | None]:
    """The turns' sampling error where the gyro's noise at rest shows no anti-alias filter
    (:func:`optinav.multipos.ferraris.turn_sampling_std`: the content near the Nyquist frequency carried to the sample
    rate at 1/f folds into each turn's integral), as independent sources in the residuals: (3T, 3T), column 3k + i
    the change of the residuals by turn k's 1σ error of its integral about axis i (spread over the turn as a bias),
    and that error as a share of each turn (RMS over the turns); (0, None) with a filter or no content to judge.
    ``b`` (3,) or one per row of ``tr`` [raw]; ``k0`` the scale [raw/(rad/s)] that sets the difference step.
    imucal's session on every 4th row (25.6 Hz, no filter): K_yy 2.6 std off the full rate's with exit 0 without it."""
    from .ferraris import turn_sampling_std

    n = tr.keep.size
    turns = []
    for s, e in zip(tr.starts, tr.ends):
        h = tr.h[s:e]
        turns.append((tr.raw[s : e + 1], np.r_[h, h[-1:]]))
    std = turn_sampling_std(turns, [raw[i0:i1] for i0, i1 in idx])
    if std is None:
        return 0.0, None
    b_rows = np.broadcast_to(np.asarray(b, float), tr.raw.shape).copy()
    r0 = tr.residuals(K, b_rows)
    hs = k0 * _B_SCALE * 1e-3
    out = np.zeros((3 * n, 3 * n))
    for i in range(3):
        bb = b_rows.copy()
        bb[:, i] += hs / tr.durations[tr.seg]  # each turn's integral about axis i moved by hs [raw·s]
        d = (tr.residuals(K, bb) - r0) / hs
        for k in range(n):
            out[3 * k : 3 * k + 3, 3 * k + i] = d[k] * std[i, k]
    size = np.maximum(tr.raw_rotation(b_rows), 1e-300)
    share = float(np.sqrt(np.mean(np.sum(std**2, axis=0) / size**2)))
    return share, out


def _rest_regression(means, tc, u, gravity: float) -> dict | None:
    """Per axis, the rest means regressed on a quadratic in time (the drift the interpolation tracks) and on the
    specific force ``g·u_k`` (a g-sensitivity, and the vertical Earth rate, which each pose projects as ``u_k``):
    ``m_k = c₀ + c₁x + c₂x² + G·g·u_k + e_k``. Returns the residual variance ``s2`` (3,) of ``e_k`` (white noise,
    the horizontal Earth rate, drift the quadratic misses), ``G`` (3, 3, raw per m/s²), the pooled 1σ per element of G beyond its
    estimation noise (``g_sigma``) and whether G differs from zero (χ², 9 dof, p < 0.001); the span (3,) raw of the
    time trend over the rests (``drift_span``) and whether it differs from zero (``drift_significant``, χ², 2 dof,
    p < 0.001); None below 8 rests."""
    from optinav.core.distributions import chi2_ppf

    n = means.shape[0]
    if n < 8:
        return None
    X = _rest_design(tc, u, gravity)
    x = X[:, 1]
    XtX_inv = np.linalg.pinv(X.T @ X)
    coef = XtX_inv @ X.T @ means
    dof = n - np.linalg.matrix_rank(X)
    if dof < 2:
        return None
    s2 = ((means - X @ coef) ** 2).sum(0) / dof
    G = coef[3:].T  # row i: axis i's sensitivity to f_x, f_y, f_z
    var_G = s2[:, None] * np.diag(XtX_inv)[None, 3:]  # (3, 3)
    stat = float(np.sum(G**2 / np.maximum(var_G, 1e-300)))
    g_sigma = float(np.sqrt(max(np.mean(G**2 - var_G), 0.0)))
    # the time trend per axis: its span over the rests and its χ² (2 dof) against the residual scatter
    grid = np.linspace(x.min(), x.max(), 201)
    trend = np.outer(grid, coef[1]) + np.outer(grid**2, coef[2])
    C = np.linalg.pinv(XtX_inv[1:3, 1:3])
    drift_chi2 = np.array([coef[1:3, j] @ C @ coef[1:3, j] / max(s2[j], 1e-300) for j in range(3)])
    return {
        "s2": s2,
        "G": G,
        "g_sigma": g_sigma,
        "g_significant": bool(stat > chi2_ppf(0.999, 9)) and g_sigma > 0,
        "drift_span": np.ptp(trend, axis=0),
        "drift_significant": drift_chi2 > chi2_ppf(0.999, 2),
    }


def _rest_design(tc, u, gravity: float) -> np.ndarray:
    """Regressors of the rest means (P, 6): 1, x, x² (x the rest's centre time scaled to its span) and ``g·u_k``,
    the model of :func:`_rest_regression`."""
    x = (tc - tc.mean()) / max(float(np.ptp(tc)), 1e-12)
    return np.column_stack([np.ones(tc.size), x, x * x, gravity * np.asarray(u, float)])


#: two-sided false-alarm probability of :func:`rest_outlier` over all rests and axes of a session
REST_OUTLIER_P = 1e-4


def rest_outlier(means, sems, tc, u, gravity: float) -> tuple[int, int, float, float] | None:
    """The rest whose gyro mean the other rests do not predict (a unit that turned slowly about the vertical during
    a pose, which its accelerometer cannot see, or a bias that jumped): per rest k and axis j the deleted residual
    ``d = m_kj − X_k·β̂₍k₎`` of the model of :func:`_rest_regression` fitted without rest k (11 rests or more;
    8-10: without the drift terms; fewer: their mean alone), studentized by the others' scatter about their fit
    (at least rest k's own noise ``sems``) and the prediction's leverage; flagged beyond Student's t at :data:`REST_OUTLIER_P` over all rests and
    axes (Bonferroni). Returns (k, j, d [raw], t) of the largest, or None. ``means``, ``sems`` (P, 3) [raw],
    ``tc`` (P,) [s], ``u`` (P, 3) unit up directions [-]."""
    from optinav.core.distributions import t_isf

    means, sems = np.asarray(means, float), np.asarray(sems, float)
    n = means.shape[0]
    X = _rest_design(np.asarray(tc, float), u, gravity)
    # as many terms as leave the others' scatter a few degrees of freedom: drift and g-sensitivity, then the
    # g-sensitivity alone, then their mean
    X = X if n >= 11 else X[:, [0, 3, 4, 5]] if n >= 8 else X[:, :1]
    best = None
    for k in range(n):
        o = np.arange(n) != k
        Xo = X[o]
        rank = np.linalg.matrix_rank(Xo)
        dof = int(o.sum()) - rank
        if dof < 2:
            return None
        inv = np.linalg.pinv(Xo.T @ Xo)
        beta = inv @ Xo.T @ means[o]
        s2 = np.maximum(((means[o] - Xo @ beta) ** 2).sum(0) / dof, sems[k] ** 2)
        d = means[k] - X[k] @ beta
        tk = np.abs(d) / np.sqrt(s2 * (1.0 + float(X[k] @ inv @ X[k])) + sems[k] ** 2)
        j = int(np.argmax(tk))
        crit = float(t_isf(REST_OUTLIER_P / (2 * 3 * n), dof))
        if tk[j] > crit and (best is None or tk[j] / crit > best[3] / best[4]):
            best = (k, j, float(d[j]), float(tk[j]), crit)
    return None if best is None else best[:4]


def _local_bias_var(sems, w, u, tc, K, bias_instability=None, corr_time: float = float("inf")) -> np.ndarray:
    """Variance (3,) of the session-mean bias of ``bias="local"`` (raw²): ``b̂ = Σ w_k m_k`` (w_k the rests' sample
    shares) against the mean of the bias over the rests (the session's bias).

    The interpolation tracks a drift and the reported mean is the session's, so neither a drift nor the spread of
    the rest means (which a drift or a g-sensitivity puts there) is an error of it. What is: the white noise of the
    rest means, ``Σ w_k² s_k²``, and the Earth rate each rest holds (Ω_E·K_ii at most per axis): its horizontal
    part points a different way in each pose (heading unknown: a random direction, ``Σ w_k²·(Ω_E K_ii)²/3``), its
    vertical part along ``u_k`` in every pose (``|ū|²·(Ω_E K_ii)²/3``, ū = Σ w_k u_k). A given
    ``bias_instability`` σ (raw) is the stationary 1σ of a first-order Gauss–Markov bias of correlation time
    ``corr_time`` (s): the session mean then differs from the long-term bias by
    ``σ²·Σ_kl w_k w_l exp(−|t_k − t_l|/τ)`` (σ² for τ = ∞, a run-to-run offset), which is added (the std is then
    against the long-term bias). Monte Carlo check: :mod:`optinav.multipos.uncertainty`."""
    w = np.asarray(w, float)
    ubar = w @ u
    earth2 = (_earth.constants("wgs84").omega_ie * np.abs(np.diag(K))) ** 2 / 3.0
    var = (w[:, None] ** 2 * sems**2).sum(0) + earth2 * (float(w @ w) + float(ubar @ ubar))
    if bias_instability is not None:
        tau = float(corr_time)
        E = np.exp(-np.abs(tc[:, None] - tc[None, :]) / tau) if np.isfinite(tau) else np.ones((tc.size, tc.size))
        var = var + np.square(np.asarray(bias_instability, float)) * float(w @ E @ w)
    return var


def _sigma_hat(r, dof: int) -> float:
    """σ̂ = √(Σr²/dof) (the radial residual components are ~0, so dof counts 2 per transition)."""
    r = np.asarray(r)
    return float(np.sqrt(r @ r / dof)) if dof > 0 else float("nan")


def _fit(residuals, p0, names, scales, method, gen):
    prob = Problem(residuals=residuals, x0=np.asarray(p0, dtype=float), names=list(names), x_scale=scales)
    opts = {"max_iter": 50} if method == "gauss-newton" else {}
    return minimize(prob, method, rng=gen, **opts)


def _fit_regularized(residuals, p_guess, p_start, prior_sd, dof, names, scales, method, gen):
    """Fit with a weak pull to the initial guess, ``σ_ref·(p − p_guess)/prior_sd`` appended to the residuals.

    Directions the data do not fix would otherwise wander off to fit noise, which spoils σ̂ and the Jacobian
    the rank is judged on. ``σ_ref`` puts the pull in the residuals' units: first the RMS residual at the
    start (an overestimate, so a weaker pull), then σ̂ of that first fit. The caller refits without the pull.
    """
    r0 = np.asarray(residuals(p_start))
    sig = float(np.sqrt(r0 @ r0 / r0.size))
    x, nfev = np.asarray(p_start, dtype=float), 0
    for _ in range(2):
        s_ref = sig if np.isfinite(sig) and sig > 0 else 1.0

        def fun(p, s_ref=s_ref):
            return np.concatenate([residuals(p), s_ref * (p - p_guess) / prior_sd])

        res = _fit(fun, x, names, scales, method, gen)
        nfev += res.nfev
        x = res.x
        sig = _sigma_hat(residuals(x), dof)
    return res, nfev


def _pinv(J, scales, rank: int) -> np.ndarray:
    """Pseudo-inverse of J truncated to its ``rank`` strongest directions in scaled units (u = p/scales)."""
    U, s, vt = np.linalg.svd(J * scales[None, :], full_matrices=False)
    return (scales[:, None] * vt[:rank].T / s[:rank]) @ U[:, :rank].T


def _jac(fun, p, scales, r0):
    """Forward-difference Jacobian with steps √ε·max(|p|, scale) (same rule as the optimizer's)."""
    h = np.sqrt(np.finfo(float).eps) * np.maximum(np.abs(p), scales)
    J = np.empty((r0.size, p.size))
    for j in range(p.size):
        e = np.zeros(p.size)
        e[j] = h[j]
        J[:, j] = (np.asarray(fun(p + e)).reshape(-1) - r0) / h[j]
    return J


#: the RMS angle (deg) by which fitted turns may miss the accelerometer's poses before the triads are taken to
#: disagree (an axis flipped or two swapped: 26-36° in simulated sessions, noise 0.3-1.4°)
_MISMATCH_DEG = 10.0


def _report(J, r, dof, names, units, scales, max_std) -> ObservabilityReport:
    """analyze() with σ̂ from the residuals and a rank threshold of std ≤ max_std in units of ``scales``."""
    sig = _sigma_hat(r, dof)
    if not np.isfinite(sig) or sig <= 0:
        sig = 1e-300 if np.isfinite(sig) else 1.0
    Js = (J / sig) * scales[None, :]
    s = np.linalg.svd(Js, compute_uv=False)
    if s.size == 0 or s[0] <= 0:
        raise OptinavError(
            "the transitions carry no information on the gyro parameters", "turn the device between the static poses"
        )
    rel = min(max(1.0 / (max_std * s[0]), DEFAULT_REL_TOL), 0.999)
    return analyze(J, sigma=sig, names=names, units=units, scales=scales, rel_tol=rel, coef_tol=_COEF_TOL)


def _sqrt_psd(C) -> np.ndarray:
    """A square root L (n, n) of a symmetric positive semi-definite C: L·Lᵀ = C (negative eigenvalues clipped)."""
    w, V = np.linalg.eigh(0.5 * (C + C.T))
    return V * np.sqrt(np.clip(w, 0.0, None))


def _turn_noise(tr: Transitions, raw, idx, K) -> np.ndarray:
    """Square root (3T × 3T) [rad] of the turn residuals' covariance from the gyro's own noise: per turn k the white
    noise the rests show (:func:`ferraris.white_noise`: per-sample variance, lag-1 correlation taken into account)
    summed over its steps (Σh²), and the readings' quantization bias (:func:`ferraris.quantized_mean_var`) over its
    duration, both in rad by K⁻¹ (K [raw/(rad/s)]) and taken as isotropic (the mean over the axes): the rotation
    error δφ_k moves r_k by u_{k+1} × δφ_k."""
    from .ferraris import _mean_cov, _step, quantized_mean_var, white_noise

    rests = [raw[i0:i1] for i0, i1 in idx]
    stats = [_mean_cov(x) for x in rests]
    Ki = np.linalg.inv(K)
    white = float(np.trace(Ki @ np.diag(white_noise(stats)) @ Ki.T)) / 3.0
    q = quantized_mean_var(np.median([c[2] for c in stats], axis=0), _step(rests))
    quant = float(np.trace(Ki @ np.diag(q) @ Ki.T)) / 3.0
    h2 = np.array([float(tr.h[s:e] @ tr.h[s:e]) for s, e in zip(tr.starts, tr.ends)])
    sd = np.sqrt(white * h2 + quant * tr.durations**2)
    out = np.zeros((3 * sd.size, 3 * sd.size))
    for k, (x, y, z) in enumerate(tr.u1):
        out[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = sd[k] * np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return out


def _earth_rate(tr: Transitions, K, b_rows, local: bool) -> np.ndarray:
    """Square root (3T × 3C) [rad] of the turn residuals' covariance from the Earth rate the model neglects, over
    C chains of consecutive turns. In a turn the body turns against the Earth-fixed gravity at ω_ib − Ω_E^b(t),
    while the bias taken from the rests holds Ω_E^b as it was in them (``local``: interpolated between the two
    rests; else none of it); Ω_E's direction in a chain's first pose is unknown (the heading), taken as random
    (1σ Ω_E/√3 per axis) and carried from turn to turn by the fitted rotations. ``b_rows`` the bias per row
    [raw], K [raw/(rad/s)]. On 18 simulated poses (MTi-1, 5-s turns) 0.08 mrad per turn of 0.4."""
    from optinav.core.rotations import quat_conjugate, quat_rotate

    om = _earth.constants("wgs84").omega_ie
    qc = quat_conjugate(tr.path(K, b_rows))
    r0 = tr.residuals(K, b_rows)
    f = ((tr.t_rows - tr.t_rows[tr.starts][tr.seg]) / tr.durations[tr.seg])[:, None]
    n = tr.keep.size
    D = np.empty((n, 3, 3))  # D[k, :, i]: r_k per Ω_E along axis i of turn k's first pose
    for i, e in enumerate(np.eye(3)):
        ob = quat_rotate(qc, np.broadcast_to(e, (qc.shape[0], 3)))  # Ω_E^b(t) / Ω_E
        held = (1.0 - f) * e + f * ob[tr.ends][tr.seg] if local else 0.0
        D[:, :, i] = (tr.residuals(K, b_rows - om * (ob - held) @ K.T) - r0) / om
    qk = quat_conjugate(tr.rotations(K, b_rows))
    Ct = np.stack([quat_rotate(qk, np.broadcast_to(e, (n, 3))) for e in np.eye(3)], axis=-1)  # C_kᵀ
    chains: list[np.ndarray] = []
    for k in range(n):
        if k == 0 or tr.keep[k] != tr.keep[k - 1] + 1:
            chains.append(np.zeros((3 * n, 3)))
            P = np.eye(3)
        chains[-1][3 * k : 3 * k + 3] = D[k] @ P
        P = Ct[k] @ P  # Ω_E in the next turn's first pose
    return np.hstack(chains) * (om / np.sqrt(3.0))


def _expected_residuals(sources: dict, J, A, n_ang: int, sigma_w: float, static_rows: bool):
    """What the fitted turn residuals should hold: per source (a square root S, 3T × m [rad]: the residuals move
    by S·z, z ~ N(0, I)) its expected Σ‖r_k‖² [rad²] after the fit absorbed what it can (I − J·A, A the fit's
    pseudo-inverse over the weighted residuals J, ``n_ang`` angle rows of weight 1/``sigma_w``; ``static_rows``:
    the rest means' rows of ``bias="estimate"``, unit variance, as the source "rest biases"), ``total`` their sum
    and ``c2``, ``c3`` = tr M², tr M³ [rad⁴, rad⁶] of the residuals' covariance M (the moments of Σ‖r_k‖² =
    Σ λ_i z_i² that :func:`residual_limit` needs); and M split into the accelerometer frame's share and the rest's
    (3T × 3T each, rad²)."""
    m = J.shape[0]
    out = {}
    M = {FRAME: np.zeros((n_ang, n_ang)), "noise": np.zeros((n_ang, n_ang))}
    if static_rows and m > n_ang:
        sources = {**sources, "rest biases": None}
    for name, S in sources.items():
        Sw = np.zeros((m, m - n_ang if S is None else S.shape[1]))
        if S is None:
            Sw[n_ang:] = np.eye(m - n_ang)
        else:
            Sw[:n_ang] = S / sigma_w
        Ps = (Sw - J @ (A @ Sw))[:n_ang] * sigma_w
        out[name] = float(np.sum(Ps * Ps))
        M[FRAME if name == FRAME else "noise"] += Ps @ Ps.T
    lam = np.clip(np.linalg.eigvalsh(M[FRAME] + M["noise"]), 0.0, None)
    out.update(total=float(lam.sum()), c2=float(lam @ lam), c3=float(lam**2 @ lam))
    return out, M["noise"], M[FRAME]


#: a direction of the residuals is the accelerometer frame's where its variance there exceeds this share of the
#: measured noise's mean variance per direction (:func:`_frame_split`)
FRAME_LEVEL = 0.1


def _frame_split(r, M_n, M_f) -> dict:
    """The turn residuals r (3T,) [rad] split between the accelerometer frame's directions Π (the span of the
    eigenvectors of M_f, its covariance [rad²], above :data:`FRAME_LEVEL` × the noise's mean variance per
    direction) and the rest: ``noise_factor`` s_n = ‖(I − Π)r‖² over what M_n (the measured noise's covariance)
    predicts there, not below 1 (the rests' noise is a floor); the frame's part ``frame_ratio`` = ‖Π r‖² over its
    prediction ``frame_total`` = tr Π(s_n·M_n + M_f)Π [rad²], and that prediction's moments ``frame_c2``,
    ``frame_c3`` (:func:`residual_limit`). A noise the rests do not show (a bias that wanders) raises both parts
    alike and cancels; held misalignments larger than their stated 1σ raise the frame's alone."""
    r = np.asarray(r, float).reshape(-1)
    w, V = np.linalg.eigh(M_f)
    d = np.linalg.eigvalsh(M_n)
    level = float(np.mean(d[d > 1e-6 * max(float(d.max()), 1e-300)])) if np.any(d > 0) else 0.0
    F = V[:, w > FRAME_LEVEL * level]
    rf = F.T @ r
    rest = float(r @ r - rf @ rf)
    Mn_f = F.T @ M_n @ F
    e_rest = float(np.trace(M_n) - np.trace(Mn_f))
    sn = max(1.0, rest / e_rest) if e_rest > 0 else 1.0
    lam = np.clip(np.linalg.eigvalsh(sn * Mn_f + F.T @ M_f @ F), 0.0, None)
    e_f = float(lam.sum())
    return {
        "noise_factor": sn,
        "frame_ratio": float(rf @ rf) / e_f if e_f > 0 else 0.0,
        "frame_total": e_f,
        "frame_c2": float(lam @ lam),
        "frame_c3": float(lam**2 @ lam),
    }


def residual_limit(terms: dict, p: float) -> float:
    """The ratio Σ‖r_k‖²/E (E = ``terms["total"]``, :func:`_expected_residuals`) that the modelled sources exceed
    with probability ``p``: Σ λ_i z_i² by Pearson's three-moment χ² (as in Imhof, Biometrika 48, 1961: c₁ +
    (χ²_h(1 − p) − h)·√(c₂/h), h = c₂³/c₃²), which on the six axis poses twice (h ≈ 1.6) left 0.11 % of
    400 000 draws beyond its 0.1 % point where two moments (Satterthwaite) left 0.18 %; inf without a prediction."""
    from optinav.core.distributions import chi2_ppf

    c1, c2, c3 = terms["total"], terms["c2"], terms["c3"]
    if not (c1 > 0 and c2 > 0 and c3 > 0):
        return float("inf")
    h = c2**3 / c3**2
    return float(1.0 + (chi2_ppf(1.0 - p, h) - h) * np.sqrt(c2 / h) / c1)
