"""Allan deviation of inertial sensor records and the IEEE Std 952 read-off of noise coefficients.

``allan_deviation`` computes the overlapping Allan deviation of rate samples (ω rad/s, f m/s²) or of
increments (Δθ, Δv) at cluster times τ = m·dt, with an approximate confidence interval from the
equivalent degrees of freedom (EDF) of the estimate. ``noise_parameters_from_allan`` reads the noise
coefficients off the log-log curve as IEEE Std 952-1997 Annex C does (slopes −1, −1/2, 0, +1/2), and
``allan_deviation_model`` gives the theoretical curve of each term (used to check simulations).

Frequency-stability names of the noise terms (rate ↔ fractional frequency, angle ↔ phase):
quantization = white PM (α = 2), white rate noise (ARW / VRW) = white FM (α = 0), bias instability =
flicker FM (α = −1), rate random walk = random-walk FM (α = −2); α is the exponent of the rate PSD.

References: IEEE Std 952-1997, Annex C; W. J. Riley, *Handbook of Frequency Stability Analysis*,
NIST SP 1065 (2008), eq. (11) (overlapping Allan variance) and Table 5 (simple EDF formulas, after
Howe, Allan & Barnes 1981 / Stein 1985).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from optinav.core.results import Result
from optinav.core.validate import as_float_array, check_positive
from optinav.errors import OptinavError

#: √(2 ln 2 / π): the Allan-deviation floor of flicker (bias-instability) noise is 0.664·B (IEEE 952 C.1.3).
FLICKER_FLOOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Peak of the Allan deviation of a first-order Gauss–Markov process divided by its stationary σ, reached at
#: T = GM_ADEV_PEAK_TAU_RATIO·τ_c (maximum of :func:`allan_deviation_model`'s GM term; checked in the tests).
GM_ADEV_PEAK_RATIO = 0.6173642831
GM_ADEV_PEAK_TAU_RATIO = 1.8926177

#: noise-type name → power-law exponent α of the rate PSD, used for the EDF.
NOISE_ALPHA = {"quantization": 2, "white": 0, "flicker": -1, "random_walk": -2}
_KINDS = ("rate", "increment")


@dataclass(eq=False)
class AllanDeviation(Result):
    """Overlapping Allan deviation; arrays are (n_tau,) for one series or (n_tau, k) for k columns.

    ``unit`` names the rate unit of the data (e.g. "rad/s"); ``adev``, ``lower``, ``upper`` are in it.
    """

    SCHEMA = "optinav.allan_deviation"
    VERSION = 1

    tau: np.ndarray = field(metadata={"unit": "s"})
    adev: np.ndarray = field(metadata={"unit": "[unit]"})
    lower: np.ndarray = field(metadata={"unit": "[unit]"})
    upper: np.ndarray = field(metadata={"unit": "[unit]"})
    edf: np.ndarray = field(metadata={"unit": "1"})
    alpha: np.ndarray = field(metadata={"unit": "1"})
    m: np.ndarray = field(metadata={"unit": "1"})
    dt: float = field(metadata={"unit": "s"})
    n_samples: int = field(metadata={"unit": "1"})
    confidence: float = field(metadata={"unit": "1"})
    kind: str = field(default="rate", metadata={"unit": "-"})
    unit: str = field(default="", metadata={"unit": "-"})


@dataclass(eq=False)
class AllanNoiseParameters(Result):
    """Noise coefficients read off an Allan deviation (IEEE Std 952-1997 Annex C); NaN = not observed.

    With data in rate unit ``[u]`` (rad/s or m/s²): ``white`` N in [u]·√s (ARW rad/√s, VRW m/s/√s),
    ``bias_instability`` B in [u], ``random_walk`` K in [u]/√s, ``quantization`` Q in [u]·s (rad or m/s).
    Each ``*_tau`` is the τ range midpoint the value was read at, each ``*_rel_sigma`` its approximate
    relative 1σ uncertainty, 1/√(2·EDF) of the best point used (points at neighbouring τ are correlated,
    so pooling them would overstate the precision).
    """

    SCHEMA = "optinav.allan_noise_parameters"
    VERSION = 1

    white: np.ndarray = field(metadata={"unit": "[unit]*sqrt(s)"})
    bias_instability: np.ndarray = field(metadata={"unit": "[unit]"})
    random_walk: np.ndarray = field(metadata={"unit": "[unit]/sqrt(s)"})
    quantization: np.ndarray = field(metadata={"unit": "[unit]*s"})
    white_tau: np.ndarray = field(metadata={"unit": "s"})
    bias_instability_tau: np.ndarray = field(metadata={"unit": "s"})
    random_walk_tau: np.ndarray = field(metadata={"unit": "s"})
    quantization_tau: np.ndarray = field(metadata={"unit": "s"})
    white_rel_sigma: np.ndarray = field(metadata={"unit": "1"})
    bias_instability_rel_sigma: np.ndarray = field(metadata={"unit": "1"})
    random_walk_rel_sigma: np.ndarray = field(metadata={"unit": "1"})
    quantization_rel_sigma: np.ndarray = field(metadata={"unit": "1"})
    unit: str = field(default="", metadata={"unit": "-"})


def _edf(n_phase: int, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """EDF of the overlapping Allan variance, NIST SP 1065 Table 5; ``n_phase`` phase (angle) points."""
    n = float(n_phase)
    m = np.asarray(m, dtype=float)
    alpha = np.asarray(alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        white_pm = (n + 1) * (n - 2 * m) / (2 * (n - m))
        flicker_pm = np.exp(np.sqrt(np.log((n - 1) / (2 * m)) * np.log((2 * m + 1) * (n - 1) / 4)))
        white_fm = (3 * (n - 1) / (2 * m) - 2 * (n - 2) / n) * 4 * m**2 / (4 * m**2 + 5)
        flicker_fm = np.where(m == 1, 2 * (n - 2) / (2.3 * n - 4.9), 5 * n**2 / (4 * m * (n + 3 * m)))
        rw_fm = (n - 2) / (m * (n - 3) ** 2) * ((n - 1) ** 2 - 3 * m * (n - 1) + 4 * m**2)
    edf = np.select([alpha == 2, alpha == 1, alpha == 0, alpha == -1], [white_pm, flicker_pm, white_fm, flicker_fm],
                    rw_fm)
    # the formulas are asymptotic; near m = N/2 a few of them reach zero or become undefined
    return np.where(np.isfinite(edf), np.maximum(edf, 1.0), 1.0)


def local_slope(tau, adev, *, span: float = 2.0) -> np.ndarray:
    """Log-log slope d ln σ / d ln τ at each τ, fitted over the points within a factor ``span`` in τ.

    A fixed span in τ (rather than neighbouring points) makes the slope independent of the τ spacing.
    adev: (n_tau,) or (n_tau, k); non-positive values give NaN.
    """
    lt = np.log(np.asarray(tau, dtype=float))
    a = np.asarray(adev, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        la = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), np.nan)
    out = np.full(a.shape, np.nan)
    half = math.log(span) * (1 + 1e-9)
    for i in range(lt.size):
        w = np.abs(lt - lt[i]) <= half
        if np.count_nonzero(w) < 2:
            w = np.zeros_like(w)
            w[max(i - 1, 0):i + 2] = True
        x = lt[w] - lt[w].mean()
        y = la[w]
        out[i] = (x @ (y - y.mean(axis=0))) / (x @ x) if x @ x > 0 else np.nan
    return out


def _alpha_from_slopes(tau: np.ndarray, adev: np.ndarray) -> np.ndarray:
    """Noise type per point from the local log-log slope of the deviation (rounded to a power law)."""
    if tau.size < 2:
        return np.zeros(adev.shape, dtype=int)
    slope = local_slope(tau, adev)
    mu = np.clip(np.rint(2.0 * np.nan_to_num(slope, nan=-0.5)), -2, 1).astype(int)  # variance slope
    return np.select([mu == -2, mu == -1, mu == 0], [2, 0, -1], -2)


def allan_deviation(x, dt, taus=None, *, kind: str = "rate", noise: str = "auto", confidence: float = 0.683,
                    unit: str = "") -> AllanDeviation:
    """Overlapping Allan deviation of regularly sampled rate or increment data.

    x: (N,) or (N, k) samples — rates (``kind="rate"``, e.g. rad/s) or increments over dt
    (``kind="increment"``, e.g. rad); the deviation is in the rate unit either way.
    dt: sample interval in s (regular sampling; resample irregular logs first).
    taus: cluster times in s (rounded to multiples m of dt, 1 ≤ m ≤ N/2); default octave-spaced
    m = 1, 2, 4, … ≤ N/4.
    noise: noise type assumed for the EDF — "auto" (per point from the local slope), "white",
    "flicker", "random_walk" or "quantization".
    confidence: two-sided probability of [lower, upper] (0.683 ≈ 1σ), from the χ² distribution with the
    EDF: σ² ∈ [edf·s²/χ²_{(1+c)/2}, edf·s²/χ²_{(1−c)/2}] (NIST SP 1065 §5.3).

    The angle θ_k = Σ x·dt (or Σ Δ) is formed with cumulative sums and
    σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²(N + 1 − 2m)) (NIST SP 1065 eq. 11).
    """
    if kind not in _KINDS:
        raise OptinavError(f"kind must be 'rate' or 'increment', got {kind!r}", "pass kind='rate' or 'increment'")
    if noise != "auto" and noise not in NOISE_ALPHA:
        raise OptinavError(f"unknown noise type {noise!r}", f"use 'auto' or one of {sorted(NOISE_ALPHA)}")
    if not 0.0 < float(confidence) < 1.0:
        raise OptinavError(f"confidence must lie in (0, 1), got {confidence!r}", "pass e.g. 0.683 for 1σ")
    if np.ndim(dt) != 0:
        raise OptinavError("allan_deviation needs one regular sample interval dt",
                           "resample an irregular log to a constant rate first")
    dt = check_positive(dt, "dt")
    x = as_float_array(x, "x")
    if x.ndim not in (1, 2):
        raise OptinavError(f"x must be (N,) or (N, k), got shape {x.shape}", "pass one column per axis")
    one_d = x.ndim == 1
    X = x[:, None] if one_d else x
    n = X.shape[0]
    if n < 4:
        raise OptinavError(f"x has {n} samples; the Allan deviation needs at least 4", "record a longer log")

    if taus is None:
        m = 2 ** np.arange(int(np.floor(np.log2(max(n // 4, 1)))) + 1)
    else:
        t = as_float_array(taus, "taus").ravel()
        if t.size == 0 or np.any(t <= 0):
            raise OptinavError("taus must be positive cluster times in s", "pass e.g. taus=[0.1, 1, 10]")
        m = np.unique(np.rint(t / dt).astype(np.int64))
        if m[0] < 1 or m[-1] > n // 2:
            raise OptinavError(f"taus must lie between dt = {dt:.6g} s and N·dt/2 = {n // 2 * dt:.6g} s",
                               "choose cluster times the record can resolve")
    # removing the mean leaves the second differences unchanged but keeps θ small, avoiding cancellation
    inc = (X - X.mean(axis=0)) * (dt if kind == "rate" else 1.0)
    theta = np.zeros((n + 1, X.shape[1]))
    np.cumsum(inc, axis=0, out=theta[1:])
    avar = np.empty((m.size, X.shape[1]))
    for i, mi in enumerate(m):
        d = theta[2 * mi:] - 2.0 * theta[mi:n + 1 - mi] + theta[:n + 1 - 2 * mi]
        avar[i] = np.einsum("ij,ij->j", d, d) / (2.0 * (mi * dt) ** 2 * (n + 1 - 2 * mi))
    tau = m * dt
    adev = np.sqrt(avar)
    if noise == "auto":
        alpha = _alpha_from_slopes(tau, adev)
    else:
        alpha = np.full(adev.shape, NOISE_ALPHA[noise], dtype=int)
    edf = _edf(n + 1, m[:, None], alpha)
    c = float(confidence)
    lower = np.sqrt(edf * avar / stats.chi2.ppf(0.5 * (1 + c), edf))
    upper = np.sqrt(edf * avar / stats.chi2.ppf(0.5 * (1 - c), edf))
    if one_d:
        adev, lower, upper, edf, alpha = adev[:, 0], lower[:, 0], upper[:, 0], edf[:, 0], alpha[:, 0]
    return AllanDeviation(tau=tau, adev=adev, lower=lower, upper=upper, edf=edf, alpha=alpha, m=m, dt=dt,
                          n_samples=int(n), confidence=c, kind=kind, unit=unit)


def allan_deviation_model(tau, *, white=0.0, bias_instability=0.0, random_walk=0.0, quantization=0.0,
                          gm_sigma=0.0, gm_tau=1.0) -> np.ndarray:
    """Theoretical Allan deviation of independent noise terms (root of the sum of their variances).

    IEEE Std 952-1997 Annex C: white N → N²/τ; bias instability B → (2 ln 2/π)·B² (the flat asymptote
    for τ ≫ the flicker cut-off time); rate random walk K → K²τ/3; quantization Q → 3Q²/τ².
    First-order Gauss–Markov with stationary σ and correlation time T_c:
    2σ²T_c/τ · [1 − T_c/(2τ)(3 − 4e^{−τ/T_c} + e^{−2τ/T_c})] (N. El-Sheimy et al., IEEE Trans. Instrum.
    Meas. 57(1), 2008, eq. 20 with q_c² = 2σ²/T_c).
    """
    tau = as_float_array(tau, "tau")
    if np.any(tau <= 0):
        raise OptinavError("tau must be positive", "pass cluster times in s")
    avar = white**2 / tau + FLICKER_FLOOR**2 * bias_instability**2 + random_walk**2 * tau / 3.0 \
        + 3.0 * quantization**2 / tau**2
    if gm_sigma:
        gm_tau = check_positive(gm_tau, "gm_tau")
        x = tau / gm_tau
        with np.errstate(over="ignore"):
            # series near x → 0 avoids cancellation: 1 − (3 − 4e^{−x} + e^{−2x})/(2x) = x²/3 − x³/4 + …
            bracket = np.where(x < 1e-3, x**2 / 3.0 - x**3 / 4.0 + 7.0 * x**4 / 60.0,
                               1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x))
        avar = avar + 2.0 * gm_sigma**2 / x * bracket
    return np.sqrt(avar)


def _runs(mask: np.ndarray) -> list[slice]:
    """Contiguous True runs of a 1-D mask."""
    idx = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return [slice(i, j) for i, j in zip(idx[::2], idx[1::2])]


def _line_read(log_tau, log_adev, slope, edf, target, tol, at_tau, eligible):
    """Value at ``at_tau`` of the line of slope ``target`` fitted on the most informative run of points
    whose local slope is within ``tol`` of the target."""
    runs = _runs(eligible & (np.abs(slope - target) <= tol))
    if not runs:
        return np.nan, np.nan, np.nan
    sl = max(runs, key=lambda r: float(np.sum(edf[r])))
    # log-deviation variance ≈ 1/(2·edf): weight the intercepts by edf
    c = np.average(log_adev[sl] - target * log_tau[sl], weights=edf[sl])
    value = math.exp(c + target * math.log(at_tau))
    tau_mid = math.exp(0.5 * (log_tau[sl.start] + log_tau[sl.stop - 1]))
    return value, tau_mid, 1.0 / math.sqrt(2.0 * float(np.max(edf[sl])))


def noise_parameters_from_allan(result: AllanDeviation, *, tol: float = 0.125, min_edf: float = 10.0
                                ) -> AllanNoiseParameters:
    """Read N, B, K and Q off an Allan deviation (IEEE Std 952-1997 Annex C, Fig. C.2).

    The local slope is fitted over a factor 2 in τ either side (:func:`local_slope`); only points with
    EDF ≥ ``min_edf`` (relative 1σ ≤ 1/√(2·min_edf) ≈ 22 %) are read, because a slope from the last few
    clusters is too noisy to name a noise type. Of the runs of consecutive points within ``tol`` of a
    slope, the one with the largest total EDF is used.
    White noise N: the slope −1/2 line fitted on that run, evaluated at τ = 1 s. Bias instability B:
    the lowest deviation of the flat (slope 0) run divided by √(2 ln 2/π) = 0.664. Rate random walk K:
    the slope +1/2 line at τ = 3 s. Quantization Q: the slope −1 line at τ = √3 s. A term whose slope
    does not appear is NaN.
    """
    if not isinstance(result, AllanDeviation):
        raise OptinavError("noise_parameters_from_allan needs the result of allan_deviation",
                           "call allan_deviation(x, dt) first")
    tol = check_positive(tol, "tol")
    tau = np.asarray(result.tau, dtype=float)
    if tau.size < 3:
        raise OptinavError(f"the Allan deviation has {tau.size} cluster time(s); at least 3 are needed",
                           "compute it at more cluster times")
    adev = np.asarray(result.adev, dtype=float)
    edf = np.asarray(result.edf, dtype=float)
    one_d = adev.ndim == 1
    A, E = (adev[:, None], edf[:, None]) if one_d else (adev, edf)
    k = A.shape[1]
    out = {name: np.full(k, np.nan) for name in
           ("white", "bias_instability", "random_walk", "quantization", "white_tau", "bias_instability_tau",
            "random_walk_tau", "quantization_tau", "white_rel_sigma", "bias_instability_rel_sigma",
            "random_walk_rel_sigma", "quantization_rel_sigma")}
    log_tau = np.log(tau)
    slopes = local_slope(tau, A)
    for j in range(k):
        if np.any(A[:, j] <= 0):
            continue  # a zero deviation (constant data) has no noise to read
        log_adev = np.log(A[:, j])
        slope, e = slopes[:, j], E[:, j]
        eligible = e >= min_edf
        for name, target, at in (("white", -0.5, 1.0), ("random_walk", 0.5, 3.0),
                                 ("quantization", -1.0, math.sqrt(3))):
            v, t, r = _line_read(log_tau, log_adev, slope, e, target, tol, at, eligible)
            out[name][j], out[name + "_tau"][j], out[name + "_rel_sigma"][j] = v, t, r
        runs = _runs(eligible & (np.abs(slope) <= tol))
        if runs:
            sl = max(runs, key=lambda r: float(np.sum(e[r])))
            i = sl.start + int(np.argmin(A[sl, j]))
            out["bias_instability"][j] = A[i, j] / FLICKER_FLOOR
            out["bias_instability_tau"][j] = tau[i]
            out["bias_instability_rel_sigma"][j] = 1.0 / math.sqrt(2.0 * e[i])
    if one_d:
        out = {key: float(val[0]) for key, val in out.items()}
    return AllanNoiseParameters(**out, unit=result.unit)
