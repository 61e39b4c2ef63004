"""Allan deviation of inertial sensor records and the IEEE Std 952 read-off of noise coefficients.

``allan_deviation`` computes the overlapping Allan deviation of rate samples (ω rad/s, f m/s²) or of
increments (Δθ, Δv) at cluster times τ = m·dt, with an approximate confidence interval from the
equivalent degrees of freedom (EDF) of the estimate. ``noise_parameters_from_allan`` reads the noise
coefficients off the log-log curve as IEEE Std 952-1997 Annex C does (slopes −1, −1/2, 0, +1/2, +1),
``fit_noise_model`` fits the five-term model (with the rate ramp) to the whole curve (generalized least squares with the covariance of
the estimates for the fitted noise, :func:`allan_variance_covariance`; not biased by neighbouring terms as the
read-off is), and
``allan_deviation_model`` gives the theoretical curve of each term (used to check simulations). A long log read
in blocks is folded into an :class:`AngleAccumulator` and passed to ``allan_deviation_from_angle``;
:class:`AllanAnalysis` is the result of ``optinav allan``, computed from a log's blocks by :func:`analyse_blocks`
(and :func:`kalibr_noise` its Kalibr keys).

Frequency-stability names of the noise terms (rate ↔ fractional frequency, angle ↔ phase):
quantization = white PM (α = 2), white rate noise (ARW / VRW) = white FM (α = 0), bias instability =
flicker FM (α = −1), rate random walk = random-walk FM (α = −2); α is the exponent of the rate PSD. The rate
ramp (frequency drift) is deterministic: no PSD, σ(τ) = Rτ/√2.

References: IEEE Std 952-1997, Annex C; W. J. Riley, *Handbook of Frequency Stability Analysis*,
NIST SP 1065 (2008), eq. (11) (overlapping Allan variance) and Table 5 (simple EDF formulas, after
Howe, Allan & Barnes 1981 / Stein 1985).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from dataclasses import dataclass, field

import numpy as np

from optinav.core.results import Result
from optinav.core.units import G_STANDARD, GRAVITY_OUT, GRAVITY_OUT_REMEDY, factor
from optinav.core.validate import as_float_array, check_positive, mask_runs
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
    VERSION = 2

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
    ``bias_instability`` B in [u], ``random_walk`` K in [u]/√s, ``quantization`` Q in [u]·s (rad or m/s),
    ``rate_ramp`` R in [u]/s.
    Each ``*_tau`` is the τ range midpoint the value was read at, each ``*_rel_sigma`` its approximate
    relative 1σ uncertainty, 1/√(2·EDF) of the best point used (points at neighbouring τ are correlated,
    so pooling them would overstate the precision), and each ``*_interval`` [lower, upper] (shape (2,) or
    (2, k)) the ``confidence`` interval of the coefficient from the χ² law with that EDF. The intervals
    cover sampling error only: the read-off is also biased by the neighbouring noise terms (up to 7 % at
    the slope tolerance 0.125); :func:`fit_noise_model` is not.
    """

    SCHEMA = "optinav.allan_noise_parameters"
    VERSION = 2

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
    #: two-sided ``confidence`` interval of each coefficient from the χ² law of the point it was read at
    white_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]*sqrt(s)"})
    bias_instability_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]"})
    random_walk_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]/sqrt(s)"})
    quantization_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]*s"})
    confidence: float = field(default=0.683, metadata={"unit": "1"})
    #: rate ramp R off the slope +1 line at τ = √2 s; None in a read-off written before it was read
    rate_ramp: np.ndarray = field(default=None, metadata={"unit": "[unit]/s"})
    rate_ramp_tau: np.ndarray = field(default=None, metadata={"unit": "s"})
    rate_ramp_rel_sigma: np.ndarray = field(default=None, metadata={"unit": "1"})
    rate_ramp_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]/s"})


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
    edf = np.select(
        [alpha == 2, alpha == 1, alpha == 0, alpha == -1], [white_pm, flicker_pm, white_fm, flicker_fm], rw_fm
    )
    # the formulas are asymptotic; near m = N/2 a few of them reach zero or become undefined
    return np.where(np.isfinite(edf), np.maximum(edf, 1.0), 1.0)


def local_slope(tau, adev, *, span: float = 2.0) -> np.ndarray:
    """Log-log slope d ln σ / d ln τ at each τ, fitted over the points within a factor ``span`` in τ.

    A fixed span in τ (rather than neighbouring points) makes the slope independent of the τ spacing.

    Parameters
    ----------
    tau : (n_tau,) array
        Cluster times [s].
    adev : (n_tau,) or (n_tau, k) array
        Allan deviation [any unit]; non-positive values give NaN.
    span : float
        Factor in τ of the fitting window [-].

    Returns
    -------
    ndarray
        Slopes, shaped like ``adev`` [-].
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
            w[max(i - 1, 0) : i + 2] = True
        x = lt[w] - lt[w].mean()
        y = la[w]
        out[i] = (x @ (y - y.mean(axis=0))) / (x @ x) if x @ x > 0 else np.nan
    return out


def _alpha_from_slopes(tau: np.ndarray, adev: np.ndarray) -> np.ndarray:
    """Noise type per point from the local log-log slope of the deviation (rounded to a power law).

    Phase noise (α = 2, slope −1: quantization in rate data) is a short-τ term: it is kept only for the points
    before the first frequency-noise one. Further out a slope of −1 is the fluctuation of an estimate from a few
    clusters (the last two points of a record decide the slope there), and white-PM's EDF, about N/2 at any m,
    would give that point the weight of the whole record; it is taken as white FM, the steepest frequency noise.
    """
    if tau.size < 2:
        return np.zeros(adev.shape, dtype=int)
    slope = local_slope(tau, adev)
    mu = np.clip(np.rint(2.0 * np.nan_to_num(slope, nan=-0.5)), -2, 1).astype(int)  # variance slope
    alpha = np.select([mu == -2, mu == -1, mu == 0], [2, 0, -1], -2)
    past_pm = np.cumsum(alpha != 2, axis=0) > 0  # at or after the first frequency-noise point
    return np.where((alpha == 2) & past_pm, 0, alpha)


#: rows of θ differenced at a time: bounds the temporary memory of long records (≈ 8 MB per column)
CHUNK_ROWS = 1 << 20


class AngleAccumulator:
    """θ_k = Σ_{i<k} (x_i − offset)·dt (rates) or Σ (x_i − offset) (increments), built block by block, so a long
    log can be read in chunks and forgotten (only θ, one float per sample and column, is kept).

    ``offset`` (k,): subtracted from every sample; it leaves the second differences of θ unchanged but keeps θ
    small, avoiding cancellation (default: the first block's mean). ``add(block)`` appends (n_i, k) samples;
    :func:`allan_deviation_from_angle` computes the deviation.
    """

    def __init__(self, dt: float, *, kind: str = "rate", offset=None):
        if kind not in _KINDS:
            raise OptinavError(f"kind must be 'rate' or 'increment', got {kind!r}", "pass kind='rate' or 'increment'")
        if np.ndim(dt) != 0:
            raise OptinavError(
                "the Allan deviation needs one regular sample interval dt",
                "resample an irregular log to a constant rate first",
            )
        self.dt = check_positive(dt, "dt")
        self.kind = kind
        self.offset = None if offset is None else np.asarray(offset, float).ravel()
        self._blocks: list[np.ndarray] = []
        self._carry: np.ndarray | None = None
        self.n = 0

    def add(self, block) -> None:
        """Append a block of samples.

        Parameters
        ----------
        block : (n_i,) or (n_i, k) array
            Rates [rate unit] or increments [angle unit], as the accumulator's ``kind``.
        """
        X = as_float_array(block, "x")
        X = X[:, None] if X.ndim == 1 else X
        if X.ndim != 2 or X.shape[0] == 0:
            raise OptinavError(f"a block has shape {X.shape}; expected (n, k) samples", "pass one column per axis")
        if self.offset is None:
            self.offset = X.mean(axis=0)
        if self._carry is None:
            self._carry = np.zeros(X.shape[1])
        if X.shape[1] != self._carry.size or self.offset.size != X.shape[1]:
            raise OptinavError(
                f"a block has {X.shape[1]} columns, the first had {self._carry.size}", "pass blocks of the same columns"
            )
        scale = self.dt if self.kind == "rate" else 1.0
        for a in range(0, X.shape[0], CHUNK_ROWS):
            th = np.cumsum((X[a : a + CHUNK_ROWS] - self.offset) * scale, axis=0)
            th += self._carry
            self._carry = th[-1].copy()
            self._blocks.append(th)
        self.n += X.shape[0]

    def set_dt(self, dt: float) -> None:
        """Replace the sample interval once the whole log is known (θ of rates is rescaled to match).

        Parameters
        ----------
        dt : float
            Sample interval [s].
        """
        dt = check_positive(dt, "dt")
        if self.kind == "rate" and self._carry is not None:
            for th in self._blocks:
                th *= dt / self.dt
            self._carry = self._carry * (dt / self.dt)
        self.dt = dt

    def theta(self) -> np.ndarray:
        """θ with θ_0 = 0 (the blocks joined once; later calls reuse the joined array).

        Returns
        -------
        (n + 1, k) ndarray
            θ [rate unit × s].
        """
        if self._carry is None:
            raise OptinavError("no samples were added", "add the log's blocks first")
        if len(self._blocks) != 1 or self._blocks[0].shape[0] != self.n + 1:
            self._blocks = [np.concatenate([np.zeros((1, self._carry.size))] + self._blocks)]
        return self._blocks[0]


def _overlapping_avar(theta: np.ndarray, dt: float, m: np.ndarray, progress_desc: str | None) -> np.ndarray:
    """Overlapping Allan variance (n_tau, k) at cluster sizes m from θ (n+1, k), chunk by chunk."""
    from optinav.core.progress import progress

    n, k = theta.shape[0] - 1, theta.shape[1]
    jobs = [(i, int(mi), a) for i, mi in enumerate(m) for a in range(0, n + 1 - 2 * int(mi), CHUNK_ROWS)]
    sums = np.zeros((m.size, k))
    for i, mi, a in progress(jobs, total=len(jobs), desc=progress_desc or "", enabled=None if progress_desc else False):
        b = min(a + CHUNK_ROWS, n + 1 - 2 * mi)
        d = theta[a + 2 * mi : b + 2 * mi] - 2.0 * theta[a + mi : b + mi] + theta[a:b]
        sums[i] += np.einsum("ij,ij->j", d, d)
    return sums / (2.0 * ((m * dt) ** 2 * (n + 1 - 2 * m)))[:, None]


def allan_deviation(
    x,
    dt,
    taus=None,
    *,
    kind: str = "rate",
    noise: str = "auto",
    confidence: float = 0.683,
    unit: str = "",
    progress_desc: str | None = None,
) -> AllanDeviation:
    """Overlapping Allan deviation of regularly sampled rate or increment data.

    The angle θ_k = Σ x·dt (or Σ Δ) is formed with cumulative sums and
    σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²(N + 1 − 2m)) (NIST SP 1065 eq. 11). Long records (hours at
    1 kHz) are summed in chunks of :data:`CHUNK_ROWS` rows, so the memory beyond θ (one (N+1, k) array) stays
    bounded.

    Parameters
    ----------
    x : (N,) or (N, k) array
        Rates (``kind="rate"``, e.g. [rad/s]) or increments over dt (``kind="increment"``, e.g. [rad]).
    dt : float
        Sample interval [s] (regular sampling; resample irregular logs first).
    taus : array or None
        Cluster times [s] (rounded to multiples m of dt, 1 ≤ m ≤ N/2); None: octave-spaced m = 1, 2, 4, … ≤ N/4.
    kind : str
        ``"rate"`` or ``"increment"``.
    noise : str
        Noise type assumed for the EDF: "auto" (per point from the local slope), "white", "flicker",
        "random_walk" or "quantization".
    confidence : float
        Two-sided probability of [lower, upper] [-] (0.683 ≈ 1σ), from the χ² distribution with the EDF:
        σ² ∈ [edf·s²/χ²_{(1+c)/2}, edf·s²/χ²_{(1−c)/2}] (NIST SP 1065 §5.3).
    unit : str
        Name of the rate unit, recorded in the result.
    progress_desc : str or None
        Show a progress bar over the chunks with this label.

    Returns
    -------
    AllanDeviation
        τ [s], deviation and its interval [rate unit of x], EDF.
    """
    if kind not in _KINDS:
        raise OptinavError(f"kind must be 'rate' or 'increment', got {kind!r}", "pass kind='rate' or 'increment'")
    if np.ndim(dt) != 0:
        raise OptinavError(
            "allan_deviation needs one regular sample interval dt", "resample an irregular log to a constant rate first"
        )
    dt = check_positive(dt, "dt")
    x = as_float_array(x, "x")
    if x.ndim not in (1, 2):
        raise OptinavError(f"x must be (N,) or (N, k), got shape {x.shape}", "pass one column per axis")
    one_d = x.ndim == 1
    X = x[:, None] if one_d else x
    if X.shape[0] < 4:
        raise OptinavError(f"x has {X.shape[0]} samples; the Allan deviation needs at least 4", "record a longer log")
    acc = AngleAccumulator(dt, kind=kind, offset=X.mean(axis=0))
    acc.add(X)
    res = allan_deviation_from_angle(
        acc, taus, noise=noise, confidence=confidence, unit=unit, progress_desc=progress_desc
    )
    if one_d:
        for name in ("adev", "lower", "upper", "edf", "alpha"):
            setattr(res, name, getattr(res, name)[:, 0])
    return res


def allan_deviation_from_angle(
    angle: AngleAccumulator,
    taus=None,
    *,
    noise: str = "auto",
    confidence: float = 0.683,
    unit: str = "",
    progress_desc: str | None = None,
) -> AllanDeviation:
    """:func:`allan_deviation` of the samples gathered in an :class:`AngleAccumulator` (a streamed log).

    Parameters
    ----------
    angle : AngleAccumulator
        The gathered θ.
    taus, noise, confidence, unit, progress_desc
        As :func:`allan_deviation` (taus [s]).

    Returns
    -------
    AllanDeviation
        Arrays (n_tau, k): τ [s], deviation [rate unit].
    """
    from optinav.core import distributions as dist  # lazily: a bad file is reported before scipy loads

    if noise != "auto" and noise not in NOISE_ALPHA:
        raise OptinavError(f"unknown noise type {noise!r}", f"use 'auto' or one of {sorted(NOISE_ALPHA)}")
    if not 0.0 < float(confidence) < 1.0:
        raise OptinavError(f"confidence must lie in (0, 1), got {confidence!r}", "pass e.g. 0.683 for 1σ")
    n, dt, kind = angle.n, angle.dt, angle.kind
    if n < 4:
        raise OptinavError(f"the record has {n} samples; the Allan deviation needs at least 4", "record a longer log")
    if taus is None:
        m = 2 ** np.arange(int(np.floor(np.log2(max(n // 4, 1)))) + 1)
    else:
        t = as_float_array(taus, "taus").ravel()
        if t.size == 0 or np.any(t <= 0):
            raise OptinavError("taus must be positive cluster times in s", "pass e.g. taus=[0.1, 1, 10]")
        m = np.unique(np.rint(t / dt).astype(np.int64))
        if m[0] < 1 or m[-1] > n // 2:
            raise OptinavError(
                f"taus must lie between dt = {dt:.6g} s and N·dt/2 = {n // 2 * dt:.6g} s",
                "choose cluster times the record can resolve",
            )
    avar = _overlapping_avar(angle.theta(), dt, m, progress_desc)
    tau = m * dt
    adev = np.sqrt(avar)
    if noise == "auto":
        alpha = _alpha_from_slopes(tau, adev)
    else:
        alpha = np.full(adev.shape, NOISE_ALPHA[noise], dtype=int)
    edf = _edf(n + 1, m[:, None], alpha)
    c = float(confidence)
    lower = np.sqrt(edf * avar / dist.chi2_ppf(0.5 * (1 + c), edf))
    upper = np.sqrt(edf * avar / dist.chi2_ppf(0.5 * (1 - c), edf))
    return AllanDeviation(
        tau=tau,
        adev=adev,
        lower=lower,
        upper=upper,
        edf=edf,
        alpha=alpha,
        m=m,
        dt=dt,
        n_samples=int(n),
        confidence=c,
        kind=kind,
        unit=unit,
    )


def allan_deviation_model(
    tau,
    *,
    white=0.0,
    bias_instability=0.0,
    random_walk=0.0,
    quantization=0.0,
    rate_ramp=0.0,
    gm_sigma=0.0,
    gm_tau=1.0,
) -> np.ndarray:
    """Theoretical Allan deviation of independent noise terms (root of the sum of their variances).

    IEEE Std 952-1997 Annex C: white N → N²/τ; bias instability B → (2 ln 2/π)·B² (the flat asymptote for τ ≫ the
    flicker cut-off time); rate random walk K → K²τ/3; quantization Q → 3Q²/τ²; rate ramp R → R²τ²/2. First-order Gauss–Markov with
    stationary σ and correlation time T_c: 2σ²T_c/τ · [1 − T_c/(2τ)(3 − 4e^{−τ/T_c} + e^{−2τ/T_c})]
    (N. El-Sheimy et al., IEEE Trans. Instrum. Meas. 57(1), 2008, eq. 20 with q_c² = 2σ²/T_c).

    Parameters
    ----------
    tau : float or array
        Cluster times [s].
    white : float
        N [u·√s] (u the rate unit: rad/s or m/s²).
    bias_instability : float
        B [u].
    random_walk : float
        K [u/√s].
    quantization : float
        Q [u·s].
    rate_ramp : float
        R [u/s], a steady drift of the rate.
    gm_sigma : float
        Gauss–Markov stationary σ [u].
    gm_tau : float
        Gauss–Markov correlation time T_c [s].

    Returns
    -------
    ndarray
        σ(τ) [u].
    """
    tau = as_float_array(tau, "tau")
    if np.any(tau <= 0):
        raise OptinavError("tau must be positive", "pass cluster times in s")
    avar = (
        white**2 / tau
        + FLICKER_FLOOR**2 * bias_instability**2
        + random_walk**2 * tau / 3.0
        + 3.0 * quantization**2 / tau**2
        + rate_ramp**2 * tau**2 / 2.0
    )
    if gm_sigma:
        gm_tau = check_positive(gm_tau, "gm_tau")
        x = tau / gm_tau
        with np.errstate(over="ignore"):
            # series near x → 0 avoids cancellation: 1 − (3 − 4e^{−x} + e^{−2x})/(2x) = x²/3 − x³/4 + …
            bracket = np.where(
                x < 1e-3,
                x**2 / 3.0 - x**3 / 4.0 + 7.0 * x**4 / 60.0,
                1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x),
            )
        avar = avar + 2.0 * gm_sigma**2 / x * bracket
    return np.sqrt(avar)


def _runs(mask: np.ndarray) -> list[slice]:
    """Contiguous True runs of a 1-D mask."""
    return [slice(i, j) for i, j in mask_runs(mask)]


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


def noise_parameters_from_allan(
    result: AllanDeviation, *, tol: float = 0.125, min_edf: float = 10.0
) -> AllanNoiseParameters:
    """Read N, B, K and Q off an Allan deviation (IEEE Std 952-1997 Annex C, Fig. C.2).

    The local slope is fitted over a factor 2 in τ either side (:func:`local_slope`); only points with
    EDF ≥ ``min_edf`` (relative 1σ ≤ 1/√(2·min_edf) ≈ 22 %) are read, because a slope from the last few clusters
    is too noisy to name a noise type. Of the runs of consecutive points within ``tol`` of a slope, the one with
    the largest total EDF is used. White noise N: the slope −1/2 line fitted on that run, evaluated at τ = 1 s.
    Bias instability B: the lowest deviation of the flat (slope 0) run divided by √(2 ln 2/π) = 0.664. Rate random
    walk K: the slope +1/2 line at τ = 3 s. Quantization Q: the slope −1 line at τ = √3 s. Rate ramp R: the slope +1
    line at τ = √2 s. A term whose slope does not appear is NaN.

    Parameters
    ----------
    result : AllanDeviation
        The deviation.
    tol : float
        Slope tolerance [-].
    min_edf : float
        Smallest equivalent degrees of freedom of a point read [-].

    Returns
    -------
    AllanNoiseParameters
        N [u·√s], B [u], K [u/√s], Q [u·s], R [u/s] with u the rate unit.
    """
    if not isinstance(result, AllanDeviation):
        raise OptinavError(
            "noise_parameters_from_allan needs the result of allan_deviation", "call allan_deviation(x, dt) first"
        )
    tol = check_positive(tol, "tol")
    tau = np.asarray(result.tau, dtype=float)
    if tau.size < 3:
        raise OptinavError(
            f"the Allan deviation has {tau.size} cluster time(s); at least 3 are needed",
            "compute it at more cluster times",
        )
    adev = np.asarray(result.adev, dtype=float)
    edf = np.asarray(result.edf, dtype=float)
    one_d = adev.ndim == 1
    A, E = (adev[:, None], edf[:, None]) if one_d else (adev, edf)
    k = A.shape[1]
    names = ("white", "bias_instability", "random_walk", "quantization", "rate_ramp")
    out = {name + suffix: np.full(k, np.nan) for name in names for suffix in ("", "_tau", "_rel_sigma")}
    log_tau = np.log(tau)
    slopes = local_slope(tau, A)
    for j in range(k):
        if np.any(A[:, j] <= 0):
            continue  # a zero deviation (constant data) has no noise to read
        log_adev = np.log(A[:, j])
        slope, e = slopes[:, j], E[:, j]
        eligible = e >= min_edf
        for name, target, at in (
            ("white", -0.5, 1.0),
            ("random_walk", 0.5, 3.0),
            ("quantization", -1.0, math.sqrt(3)),
            ("rate_ramp", 1.0, math.sqrt(2)),
        ):
            v, t, r = _line_read(log_tau, log_adev, slope, e, target, tol, at, eligible)
            out[name][j], out[name + "_tau"][j], out[name + "_rel_sigma"][j] = v, t, r
        runs = _runs(eligible & (np.abs(slope) <= tol))
        if runs:
            sl = max(runs, key=lambda r: float(np.sum(e[r])))
            i = sl.start + int(np.argmin(A[sl, j]))
            out["bias_instability"][j] = A[i, j] / FLICKER_FLOOR
            out["bias_instability_tau"][j] = tau[i]
            out["bias_instability_rel_sigma"][j] = 1.0 / math.sqrt(2.0 * e[i])
    c = float(result.confidence)
    for name in names:
        out[name + "_interval"] = _chi2_interval(out[name], out[name + "_rel_sigma"], c)
    if one_d:
        out = {key: (val[:, 0] if key.endswith("_interval") else float(val[0])) for key, val in out.items()}
    return AllanNoiseParameters(**out, unit=result.unit, confidence=c)


def _chi2_interval(value: np.ndarray, rel_sigma: np.ndarray, confidence: float) -> np.ndarray:
    """(2, k) interval of a deviation-like value read at a point of EDF 1/(2·rel_sigma²)."""
    from optinav.core import distributions as dist  # lazily: a bad file is reported before scipy loads

    value, rel = np.asarray(value, float), np.asarray(rel_sigma, float)
    out = np.full((2, value.size), np.nan)
    ok = np.isfinite(value) & np.isfinite(rel) & (rel > 0)
    if np.any(ok):
        edf = 1.0 / (2.0 * rel[ok] ** 2)
        out[0, ok] = value[ok] * np.sqrt(edf / dist.chi2_ppf(0.5 * (1 + confidence), edf))
        out[1, ok] = value[ok] * np.sqrt(edf / dist.chi2_ppf(0.5 * (1 - confidence), edf))
    return out


@dataclass(eq=False)
class AllanNoiseFit(Result):
    """Noise coefficients fitted to the whole Allan variance curve (see :func:`fit_noise_model`).

    Units as :class:`AllanNoiseParameters` (data in rate unit ``[u]``: N [u]·√s, B [u], K [u]/√s, Q [u]·s, R [u]/s);
    arrays (k,) per column, or floats for one series. ``*_std`` is the 1σ of the coefficient (delta method
    from the variance coefficient), ``*_interval`` [lower, upper] the ``confidence`` interval (the variance
    coefficients c the fit does not reject at that level, square-rooted; see :func:`fit_noise_model`): a term
    fitted to zero has the lower bound 0, an upper bound no finite value reaches is inf. ``chi2_dof`` is the weighted residual per degree of freedom (≈ 1 when the five-term model fits).
    """

    SCHEMA = "optinav.allan_noise_fit"
    VERSION = 2

    white: np.ndarray = field(metadata={"unit": "[unit]*sqrt(s)"})
    bias_instability: np.ndarray = field(metadata={"unit": "[unit]"})
    random_walk: np.ndarray = field(metadata={"unit": "[unit]/sqrt(s)"})
    quantization: np.ndarray = field(metadata={"unit": "[unit]*s"})
    white_std: np.ndarray = field(metadata={"unit": "[unit]*sqrt(s)"})
    bias_instability_std: np.ndarray = field(metadata={"unit": "[unit]"})
    random_walk_std: np.ndarray = field(metadata={"unit": "[unit]/sqrt(s)"})
    quantization_std: np.ndarray = field(metadata={"unit": "[unit]*s"})
    white_interval: np.ndarray = field(metadata={"unit": "[unit]*sqrt(s)"})
    bias_instability_interval: np.ndarray = field(metadata={"unit": "[unit]"})
    random_walk_interval: np.ndarray = field(metadata={"unit": "[unit]/sqrt(s)"})
    quantization_interval: np.ndarray = field(metadata={"unit": "[unit]*s"})
    chi2_dof: np.ndarray = field(metadata={"unit": "1"})
    confidence: float = field(default=0.683, metadata={"unit": "1"})
    unit: str = field(default="", metadata={"unit": "-"})
    #: relative model error f on the Allan variance added to the EDF's 2/EDF where the misfit was significant
    model_floor: np.ndarray = field(default=None, metadata={"unit": "1"})
    #: rate ramp R (a steady drift of the rate, e.g. while the sensor warms up), its std and interval; None in a
    #: fit written before the ramp was a term
    rate_ramp: np.ndarray = field(default=None, metadata={"unit": "[unit]/s"})
    rate_ramp_std: np.ndarray = field(default=None, metadata={"unit": "[unit]/s"})
    rate_ramp_interval: np.ndarray = field(default=None, metadata={"unit": "[unit]/s"})
    #: R² over its std with every term free (K's column too, where NNLS held K at 0): the ramp note's test
    rate_ramp_z: np.ndarray = field(default=None, metadata={"unit": "1"})


#: terms of the Allan-variance model, in the order of the fit's columns: σ²(τ) = Σ c_i·basis_i(τ)
FIT_TERMS = ("quantization", "white", "bias_instability", "random_walk", "rate_ramp")

#: significance of the χ² misfit above which the fit adds a model error (:func:`fit_noise_model`): below it the
#: five-term model is taken as exact and the EDF alone weighs the points
FIT_MISFIT_P = 0.1


_STENCIL = np.array([1.0, -2.0, 1.0])  # θ_{k} − 2θ_{k+m} + θ_{k+2m}
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_SHORT_PIECE = 64  # pieces up to this many lags are summed term by term


def _generalized_covariance(term: int, lag: np.ndarray, dt: float) -> np.ndarray:
    """Generalized covariance of θ (rate·s) at |lag| samples for a unit variance coefficient of the white (1),
    flicker (2) or random-walk (3) term: −dt·|s|/2, dt²·s²·ln|s|/(2π) and dt³·|s|³/12 (each gives its basis
    1/τ, 2 ln2/π and τ/3 through the second difference; terms in s⁰…s² cancel in it)."""
    if term == 1:
        return -0.5 * dt * lag
    if term == 2:
        return dt**2 / (2.0 * np.pi) * lag**2 * np.log(np.where(lag > 0, lag, 1.0))
    return dt**3 * lag**3 / 12.0


def _stencil_covariances(k, ma, mb, dt: float) -> np.ndarray:
    """(4, …) Cov(d_a(0), d_b(k)) of the second differences d_a at cluster size ma and d_b at mb, k samples
    apart, for a unit coefficient of each term (quantization: white θ of unit variance)."""
    C = np.zeros((4,) + np.shape(k))
    for p, sp in enumerate((0.0, ma, 2 * ma)):
        for q, sq in enumerate((0.0, mb, 2 * mb)):
            lag = np.abs(k + sq - sp)
            cc = _STENCIL[p] * _STENCIL[q]
            C[0] += cc * (lag == 0)
            for term in (1, 2, 3):
                C[term] += cc * _generalized_covariance(term, lag, dt)
    return C


def _pieces(lo: int, hi: int, nodes, scale: int) -> list:
    """Break points of [lo, hi] at ``nodes`` (where the summand is not smooth), long pieces split geometrically
    from both ends (flicker's covariances decay like k⁻², not polynomially)."""
    pts = sorted({lo, hi, *[x for x in nodes if lo < x < hi]})
    out = [pts[0]]
    for x0, x1 in zip(pts[:-1], pts[1:]):
        s, left, right = scale, [x0], [x1]
        while right[-1] - left[-1] > 4 * s:
            left.append(left[-1] + s)
            right.append(right[-1] - s)
            s *= 2
        out += left[1:] + right[::-1]
    return out


def _pair_counts(k, na, nb):
    """Number of estimator terms (i, j), 0 ≤ i < na, 0 ≤ j < nb, with j − i = k."""
    return np.maximum(0.0, np.minimum(na - 1, nb - 1 - k) - np.maximum(0.0, -k) + 1)


@functools.lru_cache(maxsize=32)
def _avar_covariance_terms(m: tuple, n_samples: int, dt: float) -> np.ndarray:
    """S (5, 5, T, T): Cov(σ̂²(m_a), σ̂²(m_b)) = Σ_pq c_p c_q S[p, q, a, b] for a Gaussian noise of variance
    coefficients c = (Q², N², B², K²) plus a rate ramp R² (the order of :data:`FIT_TERMS`), overlapping estimator
    of ``n_samples``.

    Isserlis: Cov(Σ_i d_a,i², Σ_j d_b,j²) = 2 Σ_ij Cov(d_a,i, d_b,j)², summed over the lag k = j − i with the
    number of pairs at each lag; the covariances of the second differences come from the generalized covariance
    of θ of each term (exact for white θ, white and random-walk rate; flicker from its continuous-time s² ln s).
    The lag sum runs piece by piece between the points where the summand is not smooth: term by term for short
    pieces, else Euler–Maclaurin (Gauss–Legendre integral, end values, first-derivative correction); checked
    against the direct sum to 1e-3 and against Monte Carlo covariances of simulated records.
    """
    m = np.asarray(m, np.int64)
    nn = (int(n_samples) + 1 - 2 * m).astype(float)
    ia, ib = np.triu_indices(m.size)
    npair = ia.size
    k0, k1, owner, inner, inner_owner = [], [], [], [], []
    for idx in range(npair):
        ma, mb, na, nb = int(m[ia[idx]]), int(m[ib[idx]]), int(nn[ia[idx]]), int(nn[ib[idx]])
        nodes = {sp - sq for sp in (0, ma, 2 * ma) for sq in (0, mb, 2 * mb)} | {0, nb - na}
        pts = np.array(_pieces(-(na - 1), nb - 1, nodes, max(8, max(ma, mb) // 2)), float)
        k0.append(pts[:-1])
        k1.append(pts[1:])
        owner.append(np.full(pts.size - 1, idx))
        inner.append(pts[1:-1])
        inner_owner.append(np.full(pts.size - 2, idx))
    k0, k1, owner = np.concatenate(k0), np.concatenate(k1), np.concatenate(owner)
    inner, inner_owner = np.concatenate(inner), np.concatenate(inner_owner)
    span = k1 - k0
    long = span > _SHORT_PIECE
    a0, a1, L, lo_owner = k0[long], k1[long], span[long], owner[long]
    k_gl = (0.5 * (a0 + a1))[:, None] + (0.5 * L)[:, None] * _GL_X
    w_gl = (0.5 * L)[:, None] * _GL_W
    k_end = np.stack([a0, a0 + 1, a1 - 1, a1], axis=1)
    w_end = np.broadcast_to([0.5 + 1 / 12, -1 / 12, -1 / 12, 0.5 + 1 / 12], k_end.shape)
    count = span[~long].astype(np.int64) + 1
    first = np.repeat(k0[~long], count)
    k_short = first + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
    k = np.concatenate([k_gl.ravel(), k_end.ravel(), k_short, inner])
    # the shared end of two pieces is summed by both: once subtracted
    w = np.concatenate([w_gl.ravel(), w_end.ravel(), np.ones(k_short.size), -np.ones(inner.size)])
    p = np.concatenate(
        [np.repeat(lo_owner, _GL_X.size), np.repeat(lo_owner, 4), np.repeat(owner[~long], count), inner_owner]
    )
    mf = m.astype(float)
    w = w * _pair_counts(k, nn[ia][p], nn[ib][p])
    C = _stencil_covariances(k, mf[ia][p], mf[ib][p], dt)
    M = np.zeros((npair, 4, 4))
    for a in range(1, 4):
        for b in range(a, 4):
            M[:, a, b] = M[:, b, a] = np.bincount(p, w * C[a] * C[b], minlength=npair)
    # quantization: its covariance is non-zero only at the lags where two stencil nodes meet, summed exactly
    sa = np.stack([np.zeros(npair), mf[ia], 2 * mf[ia]], 1)
    sb = np.stack([np.zeros(npair), mf[ib], 2 * mf[ib]], 1)
    ks = (sa[:, :, None] - sb[:, None, :]).reshape(npair, 9)
    once = (ks[:, :, None] == ks[:, None, :]).sum(-1)  # a lag reached by several node pairs counts once
    wk = _pair_counts(ks, nn[ia][:, None], nn[ib][:, None]) / once
    Cs = _stencil_covariances(ks, mf[ia][:, None], mf[ib][:, None], dt)
    M[:, 0, :] = M[:, :, 0] = (Cs[0] * Cs * wk).sum(-1).T
    # a rate ramp R is deterministic: every second difference at m is μ = R·τ² (θ_k = R·dt²·k(k−1)/2), so it adds
    # no variance of its own, only 4·μ_a·μ_b·Cov(d_a,i, d_b,j) to each pair: R² times the plain sum of the
    # noise's covariances over the pairs (μ/τ² = R), split between S[ramp, p] and S[p, ramp]
    lin = np.zeros((npair, 4))
    for a in range(1, 4):
        lin[:, a] = np.bincount(p, w * C[a], minlength=npair)
    lin[:, 0] = (Cs[0] * wk).sum(-1)
    norm = 2.0 / (nn[ia] * nn[ib] * 4.0 * (mf[ia] * mf[ib]) ** 2 * dt**4)
    S = np.zeros((5, 5, m.size, m.size))
    S[:4, :4, ia, ib] = (M * norm[:, None, None]).transpose(1, 2, 0)
    half = (lin * (0.5 / (nn[ia] * nn[ib]))[:, None]).T
    for q in range(4):
        S[4, q, ia, ib] = S[q, 4, ia, ib] = half[q]
    S[:, :, ib, ia] = S[:, :, ia, ib]
    S.setflags(write=False)
    return S


def allan_variance_covariance(
    result: AllanDeviation, *, white=0.0, bias_instability=0.0, random_walk=0.0, quantization=0.0, rate_ramp=0.0
) -> np.ndarray:
    """Covariance of the overlapping Allan-variance estimates of ``result`` (its cluster sizes and record length)
    for Gaussian noise with the given coefficients (as :func:`allan_deviation_model`; rate unit of the data).

    Parameters
    ----------
    result : AllanDeviation
        Gives m, dt and the number of samples.
    white, bias_instability, random_walk, quantization, rate_ramp : float
        N [u·√s], B [u], K [u/√s], Q [u·s], R [u/s] (a deterministic drift).

    Returns
    -------
    (T, T) ndarray
        Cov(σ̂²(τ_a), σ̂²(τ_b)) [u⁴].
    """
    c = np.array([quantization, white, bias_instability, random_walk, rate_ramp], float) ** 2
    return _mixture_covariance(
        c, _avar_covariance_terms(tuple(int(x) for x in result.m), int(result.n_samples), float(result.dt))
    )


def _mixture_covariance(c: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Σ_pq c_p c_q S[p, q]: the estimates' covariance for variance coefficients ``c`` (the terms of ``S``)."""
    return np.einsum("p,q,pqab->ab", c, c, S)


def _whitener(c: np.ndarray, S: np.ndarray, basis: np.ndarray, floor: float, least: np.ndarray) -> np.ndarray:
    """L⁻¹ of the Cholesky factor of the estimates' covariance for coefficients ``c`` (S over the fitted terms),
    each variance raised by the relative model error ``floor`` (f²·model², correlated as the estimates) and by
    ``least``² (a curve that is zero somewhere has no finite weights)."""
    cov = _mixture_covariance(c, S) + np.diag(least**2)
    d0 = np.sqrt(np.diag(cov))
    d = np.sqrt(d0**2 + (floor * (basis @ c)) ** 2)
    R = cov / np.outer(d0, d0)
    # neighbouring estimates of a long white-noise record are correlated to within rounding of 1 (and the lag
    # sums approximate): a matrix a hair from positive definite gets the smallest diagonal jitter that makes it so
    # (1 M samples at 1 kHz of white noise and random walk ended in an internal error)
    for eps in (1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        try:
            C = np.linalg.cholesky(R * np.outer(d, d) + np.diag((eps * d) ** 2))
            break
        except np.linalg.LinAlgError:
            continue
    else:
        w, V = np.linalg.eigh(R)
        C = V * np.sqrt(np.maximum(w, 1e-4 * w.max()))[None, :] * d[:, None]
    return np.linalg.inv(C)


#: cluster size beyond which the sampled-flicker factor is taken as 1 (its excess is 2.4e-4 at m = 64, ∝ 1/m²)
_FLICKER_EXACT_M = 256


def flicker_avar_factor(m) -> np.ndarray:
    """Allan variance of *sampled* flicker rate noise at cluster size m, relative to the IEEE 952 floor 2 ln2·B²/π.

    Rate samples of one-sided PSD B²/(π f) up to the Nyquist frequency have the Allan variance
    ∫₀^{1/2} B²/(π u) · 2 sin⁴(π u m)/(m² sin²(π u)) du (u = f·dt; the transfer function of the overlapping
    second difference of the summed samples, NIST SP 1065 §A), which is 1.189 times the floor at m = 1, 1.089 at
    m = 2, 1.029 at m = 4 and → 1 as m grows. The five-term fit uses it so that the excess at the shortest τ is
    not taken for white noise.

    Parameters
    ----------
    m : int or array of int
        Cluster size [samples].

    Returns
    -------
    ndarray
        The ratio to the floor [-], shaped like ``m``.
    """
    m = np.asarray(m, dtype=float)
    out = np.ones(m.shape)
    for mi in np.unique(m[m <= _FLICKER_EXACT_M]):
        out[m == mi] = _sampled_flicker(float(mi))
    return out


@functools.lru_cache(maxsize=None)
def _sampled_flicker(m: float) -> float:
    """:func:`flicker_avar_factor` at one cluster size (kept: every fit and interval asks for the same few m, and
    the sum takes 400·m + 4000 points)."""
    k = int(400 * m + 4000)
    u = (np.arange(k) + 0.5) * (0.5 / k)  # midpoint rule; the integrand is smooth and → 0 at u = 0
    g = 2.0 * np.sin(np.pi * u * m) ** 4 / (m**2 * np.sin(np.pi * u) ** 2) / (np.pi * u)
    return float(g.sum() * (0.5 / k) / FLICKER_FLOOR**2)


def _fit_basis(tau: np.ndarray, m: np.ndarray) -> np.ndarray:
    return np.column_stack(
        [3.0 / tau**2, 1.0 / tau, FLICKER_FLOOR**2 * flicker_avar_factor(m), tau / 3.0, tau**2 / 2.0]
    )


def _fit_column(y, e, S, basis, floor, iterations, nnls):
    """One generalized NNLS fit of the variance coefficients: (coefficients, model curve, whitener, χ²/dof).
    Started from the EDF-weighted fit, the covariance then comes from the fitted coefficients."""
    least = 1e-9 * np.abs(y)
    W = np.diag(1.0 / (np.maximum(np.abs(y), np.finfo(float).tiny) * np.sqrt(2.0 / e)))
    c, _ = nnls(W @ basis, W @ y)
    for _ in range(iterations):
        L = _whitener(c, S, basis, floor, least)
        new, _ = nnls(L @ basis, L @ y)
        if np.any(new > 0):
            c = new
    L = _whitener(c, S, basis, floor, least)
    model = basis @ c
    r = L @ (y - model)
    return c, model, L, float(r @ r) / max(y.size - basis.shape[1], 1)


def _inverted_interval(y, e, S, basis, c, free, i, floor, inflate, z) -> tuple[float, float]:
    """[lower, upper] of the variance coefficient c_i: every value c ≥ 0 with |ĉ_i − c| ≤ z·σ_i(c), where σ_i(c) is
    the std of ĉ_i when the true curve is the fit with c_i = c (its covariance, the other terms as fitted). An
    upper bound that no finite value reaches (σ_i growing as fast as c/z) is inf."""
    from scipy import optimize  # lazily: a bad file is reported before scipy loads

    cols = free.copy()
    cols[i] = True
    ci = float(c[i])
    # a curve that is 0 somewhere (the term the only one there, tried at 0) has no finite weights: keep its
    # variance a small fraction above 0, relative to the fitted curve
    least = 1e-9 * (basis @ c) * np.sqrt(2.0 / e)

    def sigma(v: float) -> float:
        cc = c.copy()
        cc[i] = v
        Aw = _whitener(cc, S, basis, floor, least) @ basis[:, cols]
        k = int(np.sum(cols[:i]))
        return math.sqrt(max(np.linalg.pinv(Aw.T @ Aw)[k, k], 0.0) * inflate)

    def h(v: float, sign: float) -> float:
        return sign * (v - ci) - z * sigma(v)

    lower = 0.0
    if ci > 0 and h(0.0, -1.0) > 0:
        lower = optimize.brentq(h, 0.0, ci, args=(-1.0,), xtol=1e-9 * ci, rtol=1e-6)  # scale-free: c may be 1e-16
    s0 = sigma(ci)
    step = max(z * s0, ci, np.finfo(float).tiny)
    hi = ci + step
    for _ in range(60):
        if h(hi, 1.0) >= 0:
            return lower, optimize.brentq(h, ci, hi, args=(1.0,), xtol=1e-9 * hi, rtol=1e-6)
        hi = ci + (hi - ci) * 4.0
    return lower, math.inf


def _past_the_filter(result: AllanDeviation, n_terms: int) -> AllanDeviation:
    """The deviation from the first cluster time (below 1 s) whose local slope is white noise's or steeper
    (≤ −0.48) on every axis: the points before it lie below the white-noise line, the rate low-pass filtered inside the sensor (a
    DLPF, an anti-alias filter), which no term of the model has; fitted, they pulled N 30-45 % low (1 kHz, 40 Hz
    filter) with intervals excluding the truth. A deviation that never falls so steeply (flicker or random walk
    from the first point) is kept whole, and so is one that would keep too few points."""
    adev = np.asarray(result.adev, float)
    A = adev[:, None] if adev.ndim == 1 else adev
    tau = np.asarray(result.tau, float)
    slope = local_slope(tau, A)
    first = [int(np.argmax(col <= -0.48)) if np.any(col <= -0.48) else 0 for col in slope.T]
    i0 = max(first)
    # a filter's corner lies above 1 Hz: a steep point only further out is a noisy slope of flicker, not a filter
    if i0 == 0 or tau[i0] > 1.0 or tau.size - i0 <= n_terms + 1:
        return result
    cut = {n: getattr(result, n)[i0:] for n in ("tau", "adev", "lower", "upper", "edf", "alpha", "m")}
    return dataclasses.replace(result, **cut)


def fit_noise_model(result: AllanDeviation, *, terms=FIT_TERMS, iterations: int = 4) -> AllanNoiseFit:
    """Fit σ²(τ) = 3Q²/τ² + N²/τ + (2 ln2/π)·B² + K²τ/3 + R²τ²/2 (IEEE Std 952-1997 Annex C) to an Allan deviation.

    The rate ramp R (slope +1) is a deterministic drift of the rate (a sensor warming up over the log): without
    its term the fit took it for random walk (a ramp of 3·K/√h over a 1-h log: K 1.6× the truth, its 68 % interval
    excluding it on two of three axes). Its covariance is the noise's, crossed with the ramp's constant second
    differences (:func:`_avar_covariance_terms`). The model is linear in (Q², N², B², K², R²): non-negative generalized least squares (scipy ``nnls``) with the
    covariance of the Allan-variance estimates for the fitted mixture (:func:`allan_variance_covariance`: exact
    second moments of the overlapping estimator of this record length, every pair of cluster times, so the
    crossings between terms and the correlation of neighbouring points are right), started from the EDF weights
    and iterated so the covariance comes from the model rather than the noisy estimate. The B² column is the Allan variance of *sampled* flicker noise
    (:func:`flicker_avar_factor`: 19 % above the floor at m = 1), so its short-τ excess is not taken for white
    noise. Cluster times before the curve first falls as white noise's (below 1 s: a sensor's low-pass filter) are
    left out (:func:`_past_the_filter`). Where the misfit is significant (χ² above its 1 − :data:`FIT_MISFIT_P` quantile: anti-alias filters,
    Gauss–Markov bumps, real sensors) a relative model error f on every variance (f²·model² added to it) is raised until
    χ²/dof = 1 (``model_floor``); an exact model keeps f = 0, which a fixed floor made 5 times too wide for N.
    The std of a free term comes from the covariance over the free terms' columns alone: a term NNLS holds at
    zero is fixed there (an active constraint), not a trade-off that widens the others (counting it up to doubled
    the other terms' std where quantization, not simulated, was fitted to 0). The interval of a coefficient is
    the set of values the fit does not reject: every c ≥ 0 with |ĉ − c| ≤ z·σ(c), σ(c) the std ĉ would have if the
    curve were the fit with that coefficient set to c (a score-type interval). Its width follows the value tried,
    not the estimate: a Wald or χ² interval scaled by ĉ itself covered K 54 % of the time where the record ends
    near the random-walk upturn (ĉ_K then weighs the last points against the flat flicker term with weights of
    both signs, so it is neither χ²-shaped nor of a relative spread independent of ĉ). Unlike the slope read-off
    the fit is not biased by the neighbouring terms. Coverage of the 68 % intervals on simulated logs: ``benchmarks/results_allan_coverage.md``.

    Parameters
    ----------
    result : AllanDeviation
        The deviation.
    terms : sequence of str
        The terms to fit (others held at 0).
    iterations : int
        Reweighting iterations.

    Returns
    -------
    AllanNoiseFit
        N [u·√s], B [u], K [u/√s], Q [u·s], R [u/s] with their std (u the rate unit).
    """
    from optinav.core import distributions as dist  # lazily: a bad file is reported before scipy loads
    from scipy.optimize import nnls

    if not isinstance(result, AllanDeviation):
        raise OptinavError("fit_noise_model needs the result of allan_deviation", "call allan_deviation(x, dt) first")
    if terms is FIT_TERMS and np.size(result.tau) <= len(FIT_TERMS):
        terms = FIT_TERMS[:-1]  # five cluster times fit the four noise terms, not the ramp too (a short log)
    unknown = set(terms) - set(FIT_TERMS)
    if unknown or not terms:
        raise OptinavError(f"unknown noise term(s) {sorted(unknown)}", f"choose from {', '.join(FIT_TERMS)}")
    use = np.array([t in terms for t in FIT_TERMS])
    result = _past_the_filter(result, int(use.sum()))
    tau = np.asarray(result.tau, float)
    if tau.size <= int(use.sum()):
        raise OptinavError(
            f"the Allan deviation has {tau.size} cluster times, too few to fit {int(use.sum())} terms",
            "compute it at more cluster times (a longer record)",
        )
    adev = np.asarray(result.adev, float)
    edf = np.asarray(result.edf, float)
    one_d = adev.ndim == 1
    A2, E = (adev[:, None] ** 2, edf[:, None]) if one_d else (adev**2, edf)
    k = A2.shape[1]
    basis = _fit_basis(tau, np.asarray(result.m, float))[:, use]
    z = float(dist.norm_ppf(0.5 * (1 + float(result.confidence))))
    coef = np.zeros((len(FIT_TERMS), k))
    cstd = np.full((len(FIT_TERMS), k), np.nan)
    chi2 = np.full(k, np.nan)
    floor = np.zeros(k)
    bounds = np.zeros((len(FIT_TERMS), 2, k))
    ramp_z = np.zeros(k)
    dof = max(tau.size - int(use.sum()), 1)
    S = _avar_covariance_terms(tuple(int(x) for x in result.m), int(result.n_samples), float(result.dt))
    S = S[np.ix_(use, use)]
    for j in range(k):
        y, e = A2[:, j], E[:, j]
        if not np.all(np.isfinite(y)) or np.all(y <= 0):
            continue
        c, model, L, chi2[j] = _fit_column(y, e, S, basis, 0.0, iterations, nnls)
        if chi2[j] * dof > dist.chi2_ppf(1.0 - FIT_MISFIT_P, dof):
            # a significant misfit: the model's own relative error f on the variance, raised until χ²/dof = 1
            lo_f, hi_f = 1e-4, 1.0
            for _ in range(30):
                mid = math.sqrt(lo_f * hi_f)
                if _fit_column(y, e, S, basis, mid, iterations, nnls)[3] > 1.0:
                    lo_f = mid
                else:
                    hi_f = mid
            floor[j] = hi_f
            c, model, L, chi2[j] = _fit_column(y, e, S, basis, hi_f, iterations, nnls)
        Aw = L @ basis
        var = np.diag(np.linalg.pinv(Aw.T @ Aw))
        if use[-1]:
            # the ramp's significance with every term free: where NNLS holds K at 0 the ramp takes the random
            # walk's upturn, and its std without K's column made 1 % of ramp-free axes "drift steadily"
            ramp_z[j] = c[-1] / math.sqrt(max(var[-1] * max(chi2[j], 1.0), np.finfo(float).tiny))
        free = c > 0
        if free.any() and not free.all():
            # the terms NNLS held at zero are fixed there: the free terms' covariance is that of the fit over
            # their columns alone (a zero term's own std stays the unconstrained one)
            var = var.copy()
            var[free] = np.diag(np.linalg.pinv(Aw[:, free].T @ Aw[:, free]))
        inflate = max(chi2[j], 1.0)
        coef[use, j] = c
        cstd[use, j] = np.sqrt(np.maximum(var, 0.0) * inflate)
        for i in range(c.size):
            bounds[np.flatnonzero(use)[i], :, j] = _inverted_interval(y, e, S, basis, c, free, i, floor[j], inflate, z)
    value = np.sqrt(coef)
    with np.errstate(divide="ignore", invalid="ignore"):
        std = np.where(value > 0, cstd / (2.0 * value), np.sqrt(cstd))
    lo, hi = np.sqrt(bounds[:, 0]), np.sqrt(bounds[:, 1])
    out = {}
    for i, name in enumerate(FIT_TERMS):
        if not use[i]:
            out[name], out[name + "_std"] = np.zeros(k), np.zeros(k)
            out[name + "_interval"] = np.zeros((2, k))
        else:
            out[name], out[name + "_std"] = value[i], std[i]
            out[name + "_interval"] = np.vstack([lo[i], hi[i]])
    out["chi2_dof"] = chi2
    out["model_floor"] = floor
    out["rate_ramp_z"] = ramp_z
    if one_d:
        out = {key: (val[:, 0] if key.endswith("_interval") else float(val[0])) for key, val in out.items()}
    return AllanNoiseFit(**out, confidence=float(result.confidence), unit=result.unit)


#: the noise terms of :meth:`AllanAnalysis.summary`: (field, label, unit suffix appended to the data's rate unit)
NOISE_TERMS = (
    ("white", "white noise N (ARW/VRW)", "*sqrt(s)"),
    ("bias_instability", "bias instability B", ""),
    ("random_walk", "random walk K (RRW/AcRW)", "/sqrt(s)"),
    ("quantization", "quantization Q", "*s"),
    ("rate_ramp", "rate ramp R", "/s"),
)


@dataclass(eq=False)
class AllanAnalysis(Result):
    """The noise characterisation of an IMU log (``optinav allan``), per sensor.

    ``accelerometer`` / ``gyroscope``: None or ``{"deviation": AllanDeviation, "read_off":
    AllanNoiseParameters, "fit": AllanNoiseFit}`` of the three axes, in the data's rate unit (``unit`` of each;
    m/s² and rad/s for SI data). ``kalibr``: the continuous-time noise in Kalibr's convention from the fit —
    ``*_noise_density`` = N (m/s²/√Hz, rad/s/√Hz), ``*_random_walk`` = K (m/s³/√Hz, rad/s²/√Hz), the largest
    axis (a filter tuned with it is not over-confident on any axis; an upper bound where ``*_random_walk_detected``
    is false, :func:`kalibr_noise`), and ``update_rate`` (Hz).
    """

    SCHEMA = "optinav.allan"
    VERSION = 2

    accelerometer: dict | None = field(default=None, metadata={"unit": "m/s^2 | counts"})
    gyroscope: dict | None = field(default=None, metadata={"unit": "rad/s | counts"})
    rate_hz: float = field(default=float("nan"), metadata={"unit": "Hz"})
    n_samples: int = field(default=0, metadata={"unit": "1"})
    duration_s: float = field(default=float("nan"), metadata={"unit": "s"})
    kalibr: dict = field(default_factory=dict, metadata={"unit": "Kalibr's (see the docstring)"})
    source: str = field(default="", metadata={"unit": "-"})
    rostopic: str = field(default="", metadata={"unit": "-"})
    #: what the numbers rest on that the user should know (a log too short for B and K, ...)
    notes: list = field(default_factory=list, metadata={"unit": "-"})

    def __post_init__(self):
        # Kalibr's numbers (written into IMU.yaml by optinav export --noise): numbers >= 0 or null, named on
        # loading when damaged (text or a list ended in an internal TypeError)
        from optinav.core.results import InvalidResult, nested_number

        for k, v in list(self.kalibr.items()):
            if k == "update_rate" or k.endswith(("_noise_density", "_random_walk")):
                x = nested_number(v, f"kalibr.{k}", none=True)
                if x is not None and not (math.isfinite(x) and x >= 0):
                    raise InvalidResult(f"field 'kalibr.{k}' is {x!r}, not a number >= 0")
                self.kalibr[k] = x

    def sensor(self, name: str) -> dict | None:
        """The analysis of one sensor.

        Parameters
        ----------
        name : str
            ``"accelerometer"`` or ``"gyroscope"``.

        Returns
        -------
        dict or None
            Its deviation and noise parameters, or None when the log had no such sensor.
        """
        return self.accelerometer if name == "accelerometer" else self.gyroscope

    def summary(self) -> str:
        """Plain-text table of the fitted noise terms per axis with their 68 % intervals.

        Returns
        -------
        str
            The table, units in brackets.
        """
        lines = [
            f"optinav allan: {self.n_samples} samples at {self.rate_hz:.6g} Hz over {self.duration_s / 3600:.3g} h"
        ]
        for name in ("accelerometer", "gyroscope"):
            d = self.sensor(name)
            if d is None:
                continue
            fit, ro = d["fit"], d["read_off"]
            unit = fit.unit or "unit"
            lines.append(f"{name} (fit of the five-term model; IEEE 952 read-off in brackets):")
            for key, label, suffix in NOISE_TERMS:
                if getattr(fit, key) is None:
                    continue  # a fit written before the rate ramp was a term
                v = np.atleast_1d(getattr(fit, key))
                iv = np.asarray(getattr(fit, key + "_interval")).reshape(2, -1)
                r = np.atleast_1d(getattr(ro, key))
                # a term the read-off does not see is said so (it printed "nan"), as the report does
                seen = [f"{x:.3g}" if np.isfinite(x) else "not seen" for x in r]
                cells = [f"{'xyz'[j]} {v[j]:.4g} [{iv[0, j]:.3g}, {iv[1, j]:.3g}] ({seen[j]})" for j in range(v.size)]
                lines.append(f"  {label} [{unit}{suffix}]: " + "; ".join(cells))
        return "\n".join(lines)


#: s, a static log shorter than this gets a note that its bias instability and random walk are not reliable
SHORT_LOG_S = 1800.0

#: a fitted rate ramp this many of its std above 0 (R² against σ of R² with every term free, ``rate_ramp_z``) gets a
#: note: 3 of 1200 simulated axes of white + flicker + random walk without a ramp (1 h-2 h logs, the worst seeds
#: of a sweep of 400 logs), 97 % of axes whose rate a ramp moved by 10·K·√T over the log, 15 % at 5·K·√T
RAMP_NOTE_Z = 3.0


#: confidence of the halves' random-walk intervals that must lie apart (and HALVES_RATIO between their values) for
#: the log to be named not stationary
HALVES_CONFIDENCE = 0.99
HALVES_RATIO = 2.0


class _ThetaSlice:
    """Rows ``a`` … ``b`` of an :class:`AngleAccumulator`'s θ as one (the second differences need no offset)."""

    def __init__(self, acc: AngleAccumulator, a: int, b: int):
        self.n, self.dt, self.kind = b - a, acc.dt, acc.kind
        self._theta = acc.theta()[a : b + 1]

    def theta(self) -> np.ndarray:
        return self._theta


def _halves_note(name: str, acc: AngleAccumulator, unit: str) -> str | None:
    """A note naming the axes whose random walk K differs between the log's two halves (their
    :data:`HALVES_CONFIDENCE` intervals apart, the values :data:`HALVES_RATIO` apart), or None: a warm-up that
    settles early in the log (an exponential drift of the bias) has no ramp's slope, and the whole log's fit took
    it for random walk — 3.3× K over 3.6 h with its interval excluding the truth, and no word."""
    half = acc.n // 2
    fits = []
    for a, b in ((0, half), (half, 2 * half)):
        ad = allan_deviation_from_angle(_ThetaSlice(acc, a, b), confidence=HALVES_CONFIDENCE, unit=unit)
        if ad.tau.size <= len(FIT_TERMS):
            return None
        fits.append(fit_noise_model(ad))
    K = [np.atleast_1d(f.random_walk) for f in fits]
    lo = [np.asarray(f.random_walk_interval).reshape(2, -1)[0] for f in fits]
    hi = [np.asarray(f.random_walk_interval).reshape(2, -1)[1] for f in fits]
    cells = []
    for j in range(K[0].size):
        for p, q in ((0, 1), (1, 0)):
            if lo[p][j] > hi[q][j] and K[p][j] > HALVES_RATIO * K[q][j]:
                cells.append(f"{'xyz'[j]} K = {K[0][j]:.3g} in the first half, {K[1][j]:.3g} in the second")
    if not cells:
        return None
    return (
        f"the {name}'s random walk differs between the log's halves ({'; '.join(cells)} {unit or 'unit'}/√s; "
        f"{HALVES_CONFIDENCE:.0%} intervals apart): its noise is not stationary (a warm-up at the start?), and K "
        "of the whole log mixes the two: analyse the log without its start, or record after the warm-up"
    )


def _ramp_note(name: str, fit: AllanNoiseFit, span: float) -> str | None:
    """A note naming the axes of ``name`` whose fit found a clear rate ramp (a steady drift), or None."""
    if fit.rate_ramp is None:
        return None
    R = np.atleast_1d(np.asarray(fit.rate_ramp, float))
    if fit.rate_ramp_z is not None:
        z = np.atleast_1d(np.asarray(fit.rate_ramp_z, float))
    else:
        sd = np.atleast_1d(np.asarray(fit.rate_ramp_std, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(R > 0, R / (2.0 * sd), 0.0)  # R² / σ(R²), σ(R²) = 2·R·σ_R
    axes = [j for j in range(R.size) if np.isfinite(z[j]) and z[j] >= RAMP_NOTE_Z]
    if not axes:
        return None
    unit = fit.unit or "unit"
    cells = ", ".join(f"{'xyz'[j]} R = {R[j]:.3g} {unit}/s ({R[j] * span:.3g} {unit} over the log)" for j in axes)
    return (
        f"the {name} rate drifts steadily ({cells}; a sensor warming up?): the drift is fitted as the rate ramp R, "
        "and K is the random walk about it, so Kalibr's random walk leaves it out: record after the warm-up, or "
        "give the filter that drift"
    )


#: Kalibr's key prefix and continuous-time units of each sensor (noise density, random walk)
KALIBR_UNITS = {
    "accelerometer": ("m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)"),
    "gyroscope": ("rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"),
}


def kalibr_noise(fit: AllanNoiseFit, sensor: str) -> dict:
    """Kalibr's noise entries of a fit in SI units, the largest axis of each.

    The random walk is the largest fitted K when every axis shows one; else the largest upper end of the axes'
    intervals, a bound for every axis (``{sensor}_random_walk_detected`` False). An interval without an upper
    end (a record too short to bound it) is refused.

    Parameters
    ----------
    fit : AllanNoiseFit
        Fit of the sensor's Allan deviation (SI data).
    sensor : str
        ``"accelerometer"`` or ``"gyroscope"``.

    Returns
    -------
    dict
        ``{sensor}_noise_density`` (N) and ``{sensor}_random_walk`` (K) [:data:`KALIBR_UNITS`], and
        ``{sensor}_random_walk_detected``.
    """
    N = np.atleast_1d(np.asarray(fit.white, float))
    K = np.atleast_1d(np.asarray(fit.random_walk, float))
    K_hi = np.asarray(fit.random_walk_interval, float).reshape(2, -1)[1]
    detected = bool(np.all(K > 0))
    # one rule for all axes: an axis's upper end beside another's fitted K (taken when larger) was neither the
    # largest K nor a bound on every axis
    K_used = K if detected else K_hi
    if not np.all(np.isfinite(K_used)):
        raise OptinavError(
            f"the {sensor} random walk is not bounded by this record (its 68 % interval has no upper end)",
            "record longer at rest (hours) for Kalibr's random walk",
        )
    return {
        f"{sensor}_noise_density": float(np.nanmax(N)),
        f"{sensor}_random_walk": float(np.nanmax(K_used)),
        f"{sensor}_random_walk_detected": detected,
    }


#: largest departure of one sample interval from the median before the log counts as having gaps
MAX_JITTER = 0.5


class _RegularTiming:
    """Regular-sampling check of a streamed time column: every interval within :data:`MAX_JITTER` of the first
    block's median; the interval used is the mean over the whole log."""

    def __init__(self):
        self.t0 = self.t_last = self.dt0 = None
        self.n = 0
        self.bad = 0
        self.first_bad = None

    def add(self, t) -> None:
        t = np.asarray(t, float)
        if t.size == 0:
            return
        joined = t if self.t_last is None else np.concatenate(([self.t_last], t))
        d = np.diff(joined)
        if self.dt0 is None and d.size:
            self.dt0 = float(np.median(d))
        if self.dt0 is not None and d.size:
            bad = np.abs(d - self.dt0) > MAX_JITTER * self.dt0
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                if self.first_bad is None:
                    self.first_bad = (float(joined[i + 1]), float(d[i]))
                self.bad += int(bad.sum())
        if self.t0 is None:
            self.t0 = float(t[0])
        self.t_last = float(t[-1])
        self.n += t.size

    def check_length(self) -> None:
        if self.n < 64:
            raise OptinavError(
                f"the log has {self.n} samples; an Allan deviation needs thousands (hours at rest)",
                "record a longer static log",
            )

    def check(self) -> float:
        self.check_length()
        if self.bad:
            t, d = self.first_bad
            raise OptinavError(
                f"the log is not regularly sampled: {self.bad} interval(s) differ from the median "
                f"{self.dt0:.6g} s by more than {MAX_JITTER:.0%}, first at t = {t:.6g} s ({d:.6g} s)",
                f"pass --fill-gaps when the gaps are lost samples (up to {FILL_MAX_LOST} in a row are bridged), or cut "
                "the log at the gap and analyse the longest regular part (or, when only the time stamps are bad and no "
                "sample is missing, skip the time column ('_' in columns) and pass rate_hz=HZ)",
            )
        # the mean interval of a regular log: the median of rounded time stamps would be off in the 12th digit
        return (self.t_last - self.t0) / (self.n - 1)


#: the longest run of lost samples :func:`fill_gaps` bridges, and the largest share of the log they may make up: a
#: bridged sample carries no noise, so 0.1 % lowers the white-noise variance by 0.1 % at most
FILL_MAX_LOST = 5
FILL_MAX_SHARE = 0.001


def fill_gaps(blocks, notes: list):
    """The blocks of a static log with its lost samples put back (``optinav allan --fill-gaps``): a time step of
    k = 2 … :data:`FILL_MAX_LOST` + 1 times the first block's median step (within a quarter step) is k − 1 lost
    samples (a logger's dropped sample, a line left out by ``--skip-bad-lines``), bridged by linear interpolation
    in time and value, also across blocks; other steps pass unchanged (the timing check judges them). Beyond
    :data:`FILL_MAX_SHARE` of the samples bridged the log is refused; the bridging is appended to ``notes``.

    Parameters
    ----------
    blocks : iterable of ImuLog
        The log in order.
    notes : list of str
        Receives one note when samples were bridged.

    Yields
    ------
    ImuLog
        Each block, lost samples inserted.
    """
    dt0 = None
    prev = None  # the last row of the block before: (t, acc row or None, gyr row or None)
    lost = gaps = n = 0
    first = None
    for log in blocks:
        t = np.asarray(log.t, float)
        if t.size == 0:
            yield log
            continue
        if dt0 is None and t.size > 1:
            dt0 = float(np.median(np.diff(t)))
        vals = {k: getattr(log, k) for k in ("acc", "gyr") if getattr(log, k) is not None}
        if prev is not None and dt0:
            jt = np.concatenate(([prev[0]], t))
            jv = {k: np.vstack([prev[1][k][None], v]) for k, v in vals.items()}
        else:
            jt, jv = t, dict(vals)
        d = np.diff(jt) / dt0 if dt0 else np.zeros(0)
        k = np.rint(d)
        whole = np.abs(d - k) <= 0.25
        longer = np.flatnonzero((k > FILL_MAX_LOST + 1) & whole)
        if longer.size:
            # the timing check's "pass --fill-gaps" was the only word on such a gap, with --fill-gaps passed
            i = int(longer[0])
            raise OptinavError(
                f"{int(k[i]) - 1} samples are lost in a row after t = {jt[i]:.6g} s: --fill-gaps bridges at most "
                f"{FILL_MAX_LOST} in a row (bridged samples carry no noise)",
                "cut the log at the gap and analyse the longest part (or each part on its own)",
            )
        where = np.flatnonzero((k >= 2) & (k <= FILL_MAX_LOST + 1) & whole)
        if where.size:
            m = (k[where] - 1).astype(np.int64)  # samples lost in each gap
            base = np.repeat(where, m)  # the row before each lost sample
            frac = np.concatenate([np.arange(1, c + 1) / (c + 1) for c in m])
            at = base + 1  # inserted before the row after the gap: every row read stays as it was

            def bridged(a):
                a = np.asarray(a, float)
                f = frac.reshape((-1,) + (1,) * (a.ndim - 1))
                return np.insert(a, at, a[base] + (a[base + 1] - a[base]) * f, axis=0)

            new_t = bridged(jt)
            new_v = {key: bridged(v) for key, v in jv.items()}
            added = int((k[where] - 1).sum())
            if first is None:
                first = float(jt[where[0]])
            lost += added
            gaps += where.size
            if prev is not None:  # the row of the block before is not this block's
                new_t = new_t[1:]
                new_v = {key: v[1:] for key, v in new_v.items()}
            log = dataclasses.replace(log, t=new_t, **new_v, labels=None, sample=None)
        n += log.t.size
        prev = (float(log.t[-1]), {key: np.asarray(getattr(log, key))[-1].copy() for key in vals})
        yield log
    if lost and lost > FILL_MAX_SHARE * n:
        raise OptinavError(
            f"{lost} lost samples in {gaps} gaps ({lost / n:.2%} of the log) are more than --fill-gaps bridges "
            f"({FILL_MAX_SHARE:.1%}): bridged samples carry no noise and would lower the deviation",
            "analyse the longest regular part of the log",
        )
    if lost:
        notes.append(
            f"{lost} lost sample(s) in {gaps} gap(s), the first after t = {first:.6g} s, bridged by linear interpolation "
            f"(--fill-gaps; {lost / n:.3%} of the log)"
        )


class _AtRest:
    """What the specific force of a log analysed at rest must show (m/s², summed block by block): a mean norm
    near g — else the unit is not m/s² (a log in g read as m/s² gave noise densities 9.8× too small, exit 0) —
    and a gravity direction that stays put: |mean a| / mean |a| ≥ :data:`_REST_RATIO` (0.98: turned by less
    than about 23° between two halves); a moving log has no Allan deviation of its noise."""

    def __init__(self):
        self.sum, self.norm, self.n, self.counts, self.whole = np.zeros(3), 0.0, 0, False, True

    def add(self, a: np.ndarray, counts: bool = False) -> None:
        """One block (m/s², or raw counts: then only the direction is judged — a moving log in counts gave noise
        figures with exit 0)."""
        self.whole = self.whole and bool(np.all(a == np.round(a)))
        self.sum += a.sum(axis=0)
        self.norm += float(np.sqrt(np.einsum("ij,ij->i", a, a)).sum())
        self.n += a.shape[0]
        self.counts = self.counts or counts

    def check(self) -> None:
        if not self.n:
            return
        mean = self.norm / self.n
        if not self.counts and not 0.3 * G_STANDARD < mean < 3.0 * G_STANDARD:
            unit = "g" if 0.3 < mean < 3.0 else "mg" if 300.0 < mean < 3000.0 else None
            # whole numbers are a raw log's (2048 counts/g looked like mg, and --acc-unit mg then gave N 2× off)
            counts = self.whole and unit != "g"
            if mean < 0.3 and not self.whole:
                raise OptinavError(
                    f"the accelerometer's mean norm is {mean:.3g} m/s², not about 9.8 at rest, in no unit; {GRAVITY_OUT}",
                    GRAVITY_OUT_REMEDY,
                )
            raise OptinavError(
                f"the accelerometer's mean norm is {mean:.3g} m/s², not about 9.8 at rest"
                + (f": it looks like {unit}" if unit else "")
                + (
                    f"{' or' if unit else ': it looks like'} raw counts (its samples are whole numbers)"
                    if counts
                    else ""
                ),
                "declare the unit with --acc-unit "
                + (
                    "counts (then calibrate and apply for SI noise), --acc-lsb LSB_PER_G (SI by its datasheet "
                    "sensitivity)" + (f", or --acc-unit {unit}" if unit else "")
                    if counts
                    else unit or "(g, mg, m/s^2, counts)"
                ),
            )
        ratio = float(np.linalg.norm(self.sum / self.n)) / mean
        if ratio < _REST_RATIO:
            raise OptinavError(
                f"the gravity direction moves in this log (|mean a| / mean |a| = {ratio:.3f}): it is not a log at "
                "rest, and the Allan deviation of a moving sensor is not its noise",
                "record the sensor still (or cut the static part out of the log)",
            )


class _GyroAtRest:
    """What a gyro in rad/s at rest must show (summed block by block): a mean rate within :data:`GYRO_REST_MAX`
    (20 °/s, the largest zero-rate offset a MEMS data sheet allows) and a white noise density N within
    :data:`GYRO_N_MAX` (0.17 °/s/√Hz, several times the noisiest MEMS gyro's) — a log in deg/s read as rad/s is
    57× beyond both (imucal's session: 34 °/s and 0.33 °/s/√Hz; its N would have gone into a Kalibr file)."""

    def __init__(self):
        self.sum, self.d2, self.n, self.nd, self.last, self.whole = np.zeros(3), 0.0, 0, 0, None, True
        self.declared = "rad/s"  # the file's unit, converted to rad/s before the sums

    def add(self, g: np.ndarray) -> None:
        if not g.shape[0]:
            return
        self.whole = self.whole and bool(np.all(g == np.round(g)))
        x = g if self.last is None else np.vstack([self.last, g])
        d = np.diff(x, axis=0)
        self.d2 += float(np.einsum("ij,ij->", d, d))
        self.nd += d.shape[0]
        self.sum += g.sum(axis=0)
        self.n += g.shape[0]
        self.last = g[-1:].copy()

    def check(self, dt: float, stated: bool = False) -> str | None:
        """Refuse a gyro beyond any MEMS's at rest; with the unit ``stated`` by the user (--gyro-unit), a note
        naming the numbers instead: a noisy gyro in rad/s told to declare deg/s got every number 57× too small."""
        if not self.n or not self.nd:
            return None
        rate = float(np.linalg.norm(self.sum / self.n))
        # white noise of per-sample std σ: first differences have variance 2σ² per axis; N = σ·√dt
        dens = float(np.sqrt(self.d2 / (2.0 * 3.0 * self.nd) * dt))
        if rate > GYRO_REST_MAX or dens > GYRO_N_MAX:
            if self.declared == "counts":  # read by a datasheet sensitivity (--gyro-lsb)
                raise OptinavError(
                    f"the gyro reads {rate:.3g} rad/s at rest with a noise density of {dens:.3g} rad/s/√Hz as read "
                    f"by its sensitivity, beyond any MEMS gyro (at most {GYRO_REST_MAX:.2g} rad/s at rest, "
                    f"{GYRO_N_MAX:.2g} rad/s/√Hz)",
                    "check --gyro-lsb (counts per deg/s, from the datasheet at the range the logger set)",
                )
            # the finer units that make both plausible: mdps declared deg/s was told "deg/s read as rad/s", the unit
            # already given
            k = factor(self.declared)
            finer = [
                u
                for u in ("deg/s", "mdps")
                if factor(u) < k and rate * factor(u) / k <= GYRO_REST_MAX and dens * factor(u) / k <= GYRO_N_MAX
            ]
            # whole numbers are a raw log's: counts read as deg/s gave N 16× off with exit 0
            looks = (
                "looks like raw counts (its samples are whole numbers)"
                if self.whole
                else f"looks like {finer[0]} read as {self.declared}"
                if finer
                else f"is in a finer unit than {self.declared} (mdps? raw counts?)"
            )
            if stated:
                return (
                    f"the gyro reads {rate:.3g} rad/s at rest with a noise density of {dens:.3g} rad/s/√Hz as declared "
                    f"in {self.declared} (--gyro-unit), beyond any MEMS gyro (at most {GYRO_REST_MAX:.2g} rad/s at "
                    f"rest, {GYRO_N_MAX:.2g} rad/s/√Hz): analysed as declared; if it is not this gyro, it {looks}"
                )
            other = f"--gyro-unit {finer[0]}" if finer else "--gyro-unit mdps for millidegrees per second"
            # a gyro that is this noisy in the unit read had no way through
            other += f", or --gyro-unit {self.declared} if it is {self.declared} (then analysed with a note)"
            raise OptinavError(
                f"the gyro reads {rate:.3g} rad/s at rest with a noise density of {dens:.3g} rad/s/√Hz as declared in "
                f"{self.declared}, beyond any MEMS gyro (at most {GYRO_REST_MAX:.2g} rad/s at rest, "
                f"{GYRO_N_MAX:.2g} rad/s/√Hz): it {looks}",
                "declare the unit with "
                + (
                    "--gyro-unit counts (then calibrate and apply for SI noise), --gyro-lsb LSB_PER_DEG_S (SI by its "
                    f"datasheet sensitivity), {other}"
                    if self.whole
                    else other
                ),
            )


#: the motion check's window (s): means over it are compared between neighbours
STILL_WINDOW_S = 1.0
#: how far (in robust σ of the differences of neighbouring window means) a jump may go in a log at rest: real rests
#: (BROAD's nine, imucal's twelve poses, simulated hours of white + flicker + random walk + ramp + quantization)
#: reach 22; five seconds of hand motion in BROAD's rests reach 340-32 000, a 10-s turn of a simulated log 1300
STILL_Z = 50.0


def _check_still(name: str, acc: AngleAccumulator, t0: float, unit: str, step=None) -> None:
    """Refuse a log that moves somewhere in it: the means over :data:`STILL_WINDOW_S` (a sixteenth of a shorter
    log) of an axis jump between neighbours by more than :data:`STILL_Z` robust σ of such jumps. A few seconds of
    motion in an hour at rest leave the gravity direction's mean in place (:class:`_AtRest`), and the Allan fit then
    took the motion for noise: N = 0 with K 10⁴× the truth, exit 0 (BROAD's rests joined by 5 s of motion).
    ``step`` (k,): the data's resolution (smallest step between samples); the scatter is taken no smaller than
    step/√window, as means of samples that rarely leave one count differ by rounding only (a rest in counts with
    noise below a count was refused at 3e14 σ)."""
    dt = acc.dt
    w = max(1, int(round(min(STILL_WINDOW_S, acc.n * dt / 16.0) / dt)))
    nw = acc.n // w
    if nw < 8:
        return
    d = np.diff(acc.theta()[: nw * w + 1 : w], n=2, axis=0)  # differences of neighbouring window sums
    d -= np.median(d, axis=0)  # a steady drift of the rate is no motion
    s = 1.4826 * np.median(np.abs(d), axis=0)
    if step is not None:
        s = np.maximum(
            s, np.where(np.isfinite(step), step, 0.0) * (acc.dt if acc.kind == "rate" else 1.0) * math.sqrt(w)
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(s > 0, np.abs(d) / np.where(s > 0, s, 1.0), 0.0)
    rows, cols = np.nonzero(z > STILL_Z)
    if rows.size == 0:
        return
    i, j = int(rows[0]), int(cols[0])  # the first window that jumps
    scale = 1.0 / (w * dt) if acc.kind == "rate" else 1.0 / w
    ta, tb = t0 + (i + 1) * w * dt, t0 + (int(rows.max()) + 1) * w * dt
    raise OptinavError(
        f"the {name} is not at rest throughout: its {w * dt:.3g}-s mean on {'xyz'[j] if d.shape[1] == 3 else j} "
        f"jumps by {d[i, j] * scale:.3g} {unit or 'unit'} at t = {ta:.6g} s ({z[i, j]:.0f}× the scatter of the rest)"
        + (f", and moves until t = {tb:.6g} s" if tb > ta else "")
        + ": the Allan deviation of a moving sensor is not its noise",
        f"cut the static part out of the log (before t = {ta:.6g} s or after t = {tb:.6g} s), or record the sensor "
        "still",
    )


#: a slow change of pose (:func:`_check_tilt`): gravity's direction in the accelerometer's 1-s means turning by
#: at least TILT_MIN_DEG within TILT_SPAN_S, and by TILT_Z times the median such turn of the log. A 1° nudge over
#: 10 s in a 40-min simulated rest gave the accelerometer K 2.9× the truth and a gyro B read-off, exit 0 (0.2°: K
#: 7 % high); a rest's own noise and drift turn it by 0.01-0.02° in 10 s (an accelerometer random walk of
#: 1e-3 m/s²/√s: 0.018°), a warm-up's bias ramp by far less
TILT_MIN_DEG, TILT_SPAN_S, TILT_Z = 0.1, 10.0, 20.0


def _check_tilt(angles: dict, units: dict, t0: float) -> None:
    """Refuse a log at rest whose pose changes slowly — a nudge, a cable pulling, a base settling: too slow for the
    jump check (:func:`_check_still`) and the spread check, it went into the Allan deviation as bias drift and random
    walk. Judged on the direction of the accelerometer's 1-s means (any unit: an angle), turned through over
    :data:`TILT_SPAN_S`; the gyroscope's turn there, when it is analysed too, is named beside it."""
    acc = angles.get("accelerometer")
    if acc is None:
        return
    dt = acc.dt
    w = max(1, int(round(min(STILL_WINDOW_S, acc.n * dt / 16.0) / dt)))
    nw = acc.n // w
    lag = max(1, int(round(TILT_SPAN_S / (w * dt))))
    if nw < 4 * lag:
        return
    A = np.diff(acc.theta()[: nw * w + 1 : w], axis=0) / (w * (dt if acc.kind == "rate" else 1.0)) + acc.offset
    u = A / (np.linalg.norm(A, axis=1, keepdims=True) + 1e-300)
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", u[lag:], u[:-lag]), -1.0, 1.0)))
    i = int(np.argmax(turn))
    if turn[i] < TILT_MIN_DEG or turn[i] < TILT_Z * float(np.median(turn)):
        return
    ta, tb = t0 + i * w * dt, t0 + (i + lag) * w * dt
    gyro = ""
    g = angles.get("gyroscope")
    if g is not None and g.n == acc.n and g.kind == "rate" and units.get("gyroscope") in ("rad/s", "deg/s"):
        phi = g.theta()[: nw * w + 1 : w]
        d = phi[i + lag] - phi[i] - np.median(phi[lag:] - phi[:-lag], axis=0)  # less the rate it turns at throughout
        turned = float(np.linalg.norm(d)) * (180.0 / math.pi if units["gyroscope"] == "rad/s" else 1.0)
        gyro = f"; the gyroscope turns by {turned:.2g}° there"
    raise OptinavError(
        f"the sensor is not at rest throughout: gravity's direction turns by {turn[i]:.2g}° between t = {ta:.6g} s "
        f"and {tb:.6g} s ({turn[i] / max(float(np.median(turn)), 1e-12):.0f}× its median turn in {lag * w * dt:.3g} s"
        f"{gyro}; a nudge, a cable pulling, a base settling): the Allan deviation would take the tilt for drift",
        f"cut the static part out of the log (before t = {ta:.6g} s or after t = {tb:.6g} s), or fix the sensor to "
        "a stable base",
    )


#: how far the variance within one window may rise above the median window's in a log at rest: undisturbed rests
#: (imucal's twelve poses, BROAD's three untouched ones, simulated hours of white + flicker + random walk + ramp +
#: quantization) reach 3.7; BROAD's six rests touched in their first or last seconds reach 23-450 (their gyro N up
#: to 6× the untouched rests')
STILL_SPREAD = 10.0
#: s, the sub-window whose sums the spread check keeps (16 per second: 1.5 kB per second with both triads)
_SPREAD_STEP_S = 1.0 / 16.0


class _Spread:
    """Sums of x and x² at every :data:`_SPREAD_STEP_S` of a streamed triad, for the variance within windows."""

    def __init__(self):
        self.step = self.off = self.last = None
        self.c = None
        self.n = 0
        self.marks: list[np.ndarray] = []
        self.q = None  # per axis the smallest step between neighbouring samples: the data's resolution

    def add(self, x: np.ndarray, dt0: float | None) -> None:
        if self.step is None:
            self.step = max(1, int(round(_SPREAD_STEP_S / dt0))) if dt0 else 16
            self.off = x[0].copy()
            self.c = np.zeros(2 * x.shape[1])
            self.q = np.full(x.shape[1], np.inf)
        steps = np.abs(np.diff(x if self.last is None else np.vstack([self.last, x]), axis=0))
        self.q = np.minimum(self.q, np.where(steps > 0, steps, np.inf).min(axis=0, initial=np.inf))
        self.last = x[-1:].copy()
        y = x - self.off  # keeps x² small: no cancellation in the variance
        cs = np.cumsum(np.hstack([y, y * y]), axis=0) + self.c
        at = np.flatnonzero((self.n + np.arange(1, len(y) + 1)) % self.step == 0)
        if at.size:
            self.marks.append(cs[at])
        self.c = cs[-1]
        self.n += len(y)

    def check(self, name: str, t0: float, dt: float, unit: str) -> None:
        """Refuse a log whose spread within some window rises :data:`STILL_SPREAD` times over the median window's:
        a sensor touched, shaken or handled there (the mean may not move: BROAD's rests touched at their ends gave
        N up to 6× the untouched rests', exit 0)."""
        if not self.marks:
            return
        S = np.vstack([np.zeros((1, self.c.size))] + self.marks)
        k = self.c.size // 2
        m = max(1, int(round(min(STILL_WINDOW_S, self.n * dt / 16.0) / (self.step * dt))))
        nw = (S.shape[0] - 1) // m
        if nw < 8:
            return
        w = m * self.step
        # windows from the start and, where the log does not end on one, from the end (a touch in its last second)
        starts = np.unique(np.r_[np.arange(nw) * m, S.shape[0] - 1 - m * np.arange(nw, 0, -1)])
        sums = S[starts + m] - S[starts]
        var = (sums[:, k:] - sums[:, :k] ** 2 / w) / w
        # no smaller than one step of resolution in a window (samples that rarely leave one count)
        med = np.maximum(np.median(var, axis=0), np.where(np.isfinite(self.q), self.q, 0.0) ** 2 / w)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(med > 0, var / np.where(med > 0, med, 1.0), 0.0)
        rows, cols = np.nonzero(r > STILL_SPREAD)
        if rows.size == 0:
            return
        i, j = int(rows[0]), int(cols[0])
        ta, tb = t0 + starts[i] * self.step * dt, t0 + (starts[rows.max()] + m) * self.step * dt
        raise OptinavError(
            f"the {name} is not at rest throughout: from t = {ta:.6g} s to {tb:.6g} s its spread within "
            f"{w * dt:.3g}-s windows rises to {math.sqrt(r[i, j]):.0f}× the rest's on {'xyz'[j] if k == 3 else j} "
            f"(it was touched or shaken there; {math.sqrt(med[j]):.3g} {unit or 'unit'} in the rest): the Allan "
            "deviation of a disturbed sensor is not its noise",
            f"cut the static part out of the log (before t = {ta:.6g} s or after t = {tb:.6g} s), or record the "
            "sensor undisturbed",
        )


#: the largest mean rate (rad/s) of a gyro at rest that is taken to be in rad/s (20 °/s)
GYRO_REST_MAX = np.radians(20.0)
#: the largest white noise density (rad/s/√Hz) of a gyro in rad/s (0.17 °/s/√Hz)
GYRO_N_MAX = 3e-3


#: |mean a| / mean |a| of a log at rest: 1 − (noise/g)²/2; below this the gravity direction moved (cos 11.5°)
_REST_RATIO = 0.98


def _check_alive(spans: dict, units: dict) -> None:
    """Refuse an axis that reads one value in every sample: it has no noise to analyse (a dead axis, a column the
    logger fills with 0, or noise below one step of its resolution) — its N came out 0 [0, 0] with exit 0."""
    for name, (lo, hi) in spans.items():
        dead = [j for j in range(np.size(lo)) if lo[j] == hi[j]]
        if dead:
            axes = ", ".join(f"{'xyz'[j] if np.size(lo) == 3 else j} = {lo[j]:.6g}" for j in dead)
            raise OptinavError(
                f"the {name} reads one value in every sample ({axes} {units.get(name) or ''}): no noise to analyse "
                "(a dead axis, a column that is not the sensor's, or noise below one step of its resolution)",
                "check --columns, or analyse the other triad alone with --sensor "
                + ("gyro" if name == "accelerometer" else "acc"),
            )


def analyse_blocks(
    blocks,
    sensor: str = "both",
    *,
    source: str = "",
    rostopic: str = "",
    need_kalibr: bool = False,
    kalibr_sensors: tuple = ("accelerometer", "gyroscope"),
    gyro_unit_stated: bool = False,
):
    """The noise characterisation of a static log given in blocks (what ``optinav allan`` computes).

    Each block is folded into the angle sums and dropped, so memory holds one float per sample and axis.

    Parameters
    ----------
    blocks : iterable of ImuLog
        The log's blocks in order, e.g. :func:`optinav.io.iter_imu` (regular sampling, no NaN).
    sensor : str
        ``"both"``, ``"acc"`` or ``"gyro"``: the triads analysed.
    source, rostopic : str
        Recorded in the result (``rostopic`` for the Kalibr file).
    need_kalibr : bool
        Refuse at the first block unless the triads of ``kalibr_sensors`` (both) are there in SI units.
    kalibr_sensors : tuple of str
        The triads ``need_kalibr`` asks of these blocks (one, when the other comes from a second file).
    gyro_unit_stated : bool
        The gyro's unit was stated by the user (``--gyro-unit``): a gyro beyond any MEMS's at rest in it gets a
        note, not a refusal.

    Returns
    -------
    AllanAnalysis
        Per sensor the Allan deviation, the IEEE 952 read-off and the five-term fit; Kalibr's noise keys.
    """
    timing = _RegularTiming()
    at_rest = _AtRest()
    gyro_rest = _GyroAtRest()
    angles: dict = {}
    units: dict[str, str] = {}
    spans: dict = {}  # per sensor the (min, max) of each axis
    spreads: dict = {}  # per sensor the sums for the variance within windows
    for log in blocks:
        if not angles:
            present = {"accelerometer": (log.acc, log.acc_unit), "gyroscope": (log.gyr, log.gyro_unit)}
            wanted = {"both": ("accelerometer", "gyroscope"), "acc": ("accelerometer",), "gyro": ("gyroscope",)}[sensor]
            if need_kalibr:
                missing = [n for n in kalibr_sensors if present[n][0] is None or n not in wanted]
                counts = [n for n in kalibr_sensors if present[n][1] == "counts"]
                if missing or counts:
                    raise OptinavError(
                        "--kalibr: Kalibr needs both triads in SI units, and the log has "
                        + (f"no {missing[0]} selected" if missing else f"the {counts[0]} in raw counts"),
                        "calibrate the unit and analyse the output of optinav apply (m/s^2, rad/s), with --sensor both"
                        + (
                            "; or read the counts by their datasheet sensitivity (--acc-lsb, --gyro-lsb)"
                            if counts
                            else ""
                        ),
                    )
            for name in wanted:
                if present[name][0] is not None:
                    angles[name] = AngleAccumulator(1.0)
                    units[name] = present[name][1]
            if not angles:
                held = [n for n in present if present[n][0] is not None]
                if held and sensor != "both":  # the other triad: a pair of files given the wrong way round
                    raise OptinavError(
                        f"{source or 'the log'} holds the {held[0]}, not the {wanted[0]}",
                        "give the accelerometer's file as DATA and the gyroscope's with --gyro (or --sensor for one "
                        "file)",
                    )
                raise OptinavError(
                    f"{source or 'the log'} has no {'data' if sensor == 'both' else sensor + ' data'} to analyse",
                    "check --columns (t,ax,ay,az,gx,gy,gz) or --sensor",
                )
        timing.add(log.t)
        for name, acc in angles.items():
            x = log.acc if name == "accelerometer" else log.gyr
            if x is None:
                raise OptinavError(f"a block of {source or 'the log'} lacks the {name}", "check --columns")
            if not np.all(np.isfinite(x)):
                bad = np.flatnonzero(~np.all(np.isfinite(x), axis=1))
                raise OptinavError(
                    f"the {name} data have {bad.size} row(s) with NaN or inf in a block of the log, the first at "
                    f"t = {log.t[bad[0]]:.6g} s",
                    "cut the bad rows out of the log (the Allan deviation needs a gap-free record)",
                )
            if len(x):
                acc.add(x)
                lo, hi = spans.get(name, (x[0], x[0]))
                spans[name] = (np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0)))
                spreads.setdefault(name, _Spread()).add(x, timing.dt0)
        if log.acc is not None and len(log.acc) and np.all(np.isfinite(log.acc)):
            at_rest.add(log.acc, counts=log.acc_unit == "counts")  # the gyro's analysis too needs the log at rest
        if "gyroscope" in angles and log.gyro_unit == "rad/s":
            gyro_rest.declared = log.gyro_input_unit or "rad/s"  # "counts": read by a sensitivity (--gyro-lsb)
            gyro_rest.add(log.gyr)
    if not angles:
        raise OptinavError(f"{source or 'the log'} holds no samples", "pass a static log")
    at_rest.check()
    timing.check_length()  # 3 samples of a quantized log read one value: too short, not a dead axis
    _check_alive(spans, units)
    dt = timing.check()
    for name, acc in angles.items():
        acc.set_dt(dt)
        _check_still(name, acc, timing.t0, units[name], spreads[name].q)
        spreads[name].check(name, timing.t0, dt, units[name])
    _check_tilt(angles, units, timing.t0)
    # after the jumps: one corrupted sample of 30 rad/s was taken for a log in deg/s
    gyro_note = gyro_rest.check(dt, stated=gyro_unit_stated)
    out = {}
    kal = {}
    sensor_notes = []
    for name in list(angles):
        acc = angles.pop(name)  # θ is dropped once its deviation is computed
        ad = allan_deviation_from_angle(acc, unit=units[name], progress_desc=f"Allan deviation ({name})")
        if timing.t_last - timing.t0 >= SHORT_LOG_S:
            sensor_notes.append(_halves_note(name, acc, units[name]))
        del acc
        if ad.tau.size < 5:
            raise OptinavError(
                f"the log spans {timing.t_last - timing.t0:.3g} s, too short for the noise terms "
                f"({ad.tau.size} cluster times)",
                "record at least a few minutes at rest (hours for the bias instability and random walk)",
            )
        fit = fit_noise_model(ad)
        out[name] = {"deviation": ad, "read_off": noise_parameters_from_allan(ad), "fit": fit}
        sensor_notes.append(_ramp_note(name, fit, float(timing.t_last - timing.t0)))
        if units[name] in ("m/s^2", "rad/s"):
            try:
                kal.update(kalibr_noise(fit, name))
            except OptinavError:
                if need_kalibr:  # without --kalibr, an unbounded random walk only leaves Kalibr's keys out
                    raise
    kal["update_rate"] = 1.0 / dt
    span = float(timing.t_last - timing.t0)
    notes = []
    if span < SHORT_LOG_S:
        # 30-s logs gave K 29-86× the truth with 68 % intervals 10× off it (flicker taken for a random walk):
        # the figures stand, the note says what they rest on
        notes.append(
            f"the log spans {span / 60:.3g} min: the bias instability B and random walk K need hours at rest (their "
            f"τ reach a tenth of the log, here {span / 10:.3g} s): K mostly takes flicker noise here, and neither K "
            "nor its interval is reliable (N is)"
        )
    notes += [n for n in (gyro_note, *sensor_notes) if n]
    return AllanAnalysis(
        accelerometer=out.get("accelerometer"),
        gyroscope=out.get("gyroscope"),
        rate_hz=1.0 / dt,
        n_samples=int(timing.n),
        duration_s=float(timing.t_last - timing.t0),
        kalibr=kal,
        source=source,
        rostopic=rostopic,
        notes=notes,
    )


def analyse_pair(
    acc_blocks,
    gyro_blocks,
    *,
    sources: tuple = ("", ""),
    rostopic: str = "",
    need_kalibr: bool = False,
    gyro_unit_stated: bool = False,
):
    """:func:`analyse_blocks` of an accelerometer and a gyroscope logged in two files, each on its own clock
    (a phone app's file per sensor): each triad's deviation comes from its own samples and rate — none is
    interpolated onto the other's times, which would low-pass its noise.

    Parameters
    ----------
    acc_blocks, gyro_blocks : iterable of ImuLog
        The accelerometer's and the gyroscope's logs in blocks (regular sampling, no NaN).
    sources : (str, str)
        The two files' names (recorded and named in the messages).
    rostopic : str
        Recorded for the Kalibr file.
    need_kalibr : bool
        Refuse unless both triads are in SI units.
    gyro_unit_stated : bool
        As :func:`analyse_blocks`'s.

    Returns
    -------
    AllanAnalysis
        The accelerometer's analysis beside the gyroscope's; ``rate_hz``, ``n_samples``, ``duration_s`` and
        Kalibr's ``update_rate`` are the accelerometer file's, a note names the gyroscope's when they differ.
    """
    kw = dict(need_kalibr=need_kalibr)
    a = analyse_blocks(acc_blocks, "acc", source=sources[0], kalibr_sensors=("accelerometer",), **kw)
    g = analyse_blocks(
        gyro_blocks, "gyro", source=sources[1], kalibr_sensors=("gyroscope",), gyro_unit_stated=gyro_unit_stated, **kw
    )
    names = [os.path.basename(s) or s for s in sources]
    notes = [f"accelerometer ({names[0]}): {n}" for n in a.notes] + [f"gyroscope ({names[1]}): {n}" for n in g.notes]
    if abs(g.rate_hz / a.rate_hz - 1.0) > 0.01:
        notes.append(
            f"the gyroscope ({names[1]}) ran at {g.rate_hz:.6g} Hz over {g.duration_s / 3600:.3g} h, the "
            f"accelerometer at {a.rate_hz:.6g} Hz: Kalibr's update_rate is the accelerometer's; set it to the rate "
            "of the Imu messages Kalibr reads"
        )
    kal = {k: v for k, v in {**a.kalibr, **g.kalibr}.items() if k != "update_rate"}
    return AllanAnalysis(
        accelerometer=a.accelerometer,
        gyroscope=g.gyroscope,
        rate_hz=a.rate_hz,
        n_samples=a.n_samples,
        duration_s=a.duration_s,
        kalibr={**kal, "update_rate": a.kalibr["update_rate"]},
        source=f"{sources[0]} + {sources[1]}",
        rostopic=rostopic,
        notes=notes,
    )
