"""Accelerometer calibration by norm observation on static poses (no turntable).

Estimators of θ = [K_xx, K_yy, K_zz, K_xy, K_xz, K_yz, b_x, b_y, b_z] (see :mod:`optinav.multipos.model`),
all through :func:`optinav.core.optimize.minimize`:

* ``"lm"`` (default), ``"gn"``, ``"trf"`` — weighted least squares on the per-pose means with the analytic
  Jacobian, started from the closed-form ellipsoid fit (:func:`initial_estimate`). Each residual is divided by
  its standard deviation ``σ_k = sqrt(ûᵀK⁻¹Σ_kK⁻ᵀû / n_k)`` (Σ_k the sample covariance of pose k), so the
  cost is a χ² and the Gauss–Newton covariance is the Cramér–Rao bound of white noise.
* ``"ga"`` — the adaptive real-coded GA of Gao & Zhang (2019), fitness 1/E with E = Σ r² (paper eq. 6–7),
  initial population drawn in a search interval around the closed-form estimate (:func:`search_interval`).
* ``"newton"`` — Newton iteration on E (Frosio et al. 2009, the paper's baseline) and ``"pso"`` — particle
  swarm in that interval; both, like the GA, start from the closed form, so raw counts with offsets far
  above the g span need no hand-set interval.

``data="means"`` (default) fits one residual per pose; ``data="samples"`` one per sample, as the paper
does — that biases ‖a‖ upward by about σ²_⊥/g (noise across the gravity direction) and costs far more.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import field

import numpy as np

from optinav.core.observability import ObservabilityReport, analyze
from optinav.core.optimize import Problem, minimize, shortfall_note
from optinav.core.results import Result
from optinav.core.validate import as_float_array, check_positive
from optinav.errors import OptinavError

from . import gates, model

METHODS = ("lm", "gn", "trf", "newton", "ga", "pso")
_CORE_METHOD = {"lm": "lm", "gn": "gauss-newton", "trf": "trf", "newton": "newton", "ga": "ga", "pso": "pso"}
#: parameters held at zero when the norm observations cannot separate the misalignments
MISALIGNMENT = (3, 4, 5)
MODELS = ("auto", "full", "diagonal")
#: default 1σ (rad) of the misalignments held at 0 (K_xy/K_xx, K_xz/K_xx, K_yz/K_yy, the frame-free upper-triangular
#: terms): a unit's six misalignments of 1σ 0.005 rad (MTi-1 class, preset mems-mti1; Gao & Zhang's six-term
#: reference RMS 0.0052) leave each held term a sum of two, 1σ 0.005·√2 = 0.0071. On the six axis poses twice
#: (MTi-1, counts) the gyro's turn residuals held on average 1.78× the power that noise and held terms of 1σ 0.005
#: give (100 seeds) and 0.89× at 0.0071 (imucal's real session 4.2× and 2.1×); RMS error/std of K_g 1.31 at 0.005,
#: 1.00 at 0.0071 (40 seeds)
HELD_MISALIGNMENT = 0.0071


@dataclasses.dataclass
class PoseStatistics:
    """Per-pose statistics of the raw accelerometer output (raw units)."""

    means: np.ndarray  # (P, 3)
    covariances: np.ndarray  # (P, 3, 3) sample covariance of one sample
    counts: np.ndarray  # (P,)


def pose_statistics(raw, index_ranges, *, valid=None) -> PoseStatistics:
    """Per-pose means and sample covariances of the raw accelerometer output, skipping invalid rows.

    Parameters
    ----------
    raw : (N, 3) array
        Accelerometer samples [raw units].
    index_ranges : (P, 2) int array_like
        Half-open sample ranges ``[i0, i1)`` of the poses.
    valid : (N,) bool array or None
        Rows to use (non-finite rows are always skipped).

    Returns
    -------
    PoseStatistics
        ``means`` (P, 3) [raw], ``covariances`` (P, 3, 3) of one sample [raw²], ``counts`` (P,).
    """
    raw = as_float_array(raw, "accelerometer samples", last_dims=(3,), finite=False)
    valid = None if valid is None else np.asarray(valid, bool)
    if valid is not None and valid.shape != raw.shape[:1]:
        raise OptinavError(
            f"valid has shape {valid.shape}, the samples {raw.shape}", "pass one valid flag per sample row"
        )
    from optinav.multipos._kernels import pose_moments_kernel  # numba: loaded on first use

    raw = np.ascontiguousarray(raw.reshape(-1, 3))
    # bounds as slicing takes them (negative, past the end)
    ranges = [slice(int(i0), int(i1)).indices(raw.shape[0])[:2] for i0, i1 in np.asarray(index_ranges, dtype=int)]
    ranges = np.array(ranges, dtype=np.int64).reshape(-1, 2)
    means, covs, counts = pose_moments_kernel(raw, ranges, np.empty(0, bool) if valid is None else valid)
    short = np.flatnonzero(counts < 2)
    if short.size:
        k = short[0]
        raise OptinavError(
            f"static pose {k} has {counts[k]} valid sample(s)",
            "lengthen the static interval or drop it from the section list",
        )
    return PoseStatistics(means, covs, counts)


def _fit_quadric(D: np.ndarray) -> np.ndarray:
    """The unit coefficient vector minimizing ‖D v‖ (smallest right singular vector)."""
    return np.linalg.svd(D, full_matrices=True)[2][-1]  # full: D may have fewer rows than columns


def initial_estimate(means, g: float, *, general: bool = True) -> np.ndarray:
    """Closed-form θ from the pose means: an algebraic ellipsoid fit (raw − b)ᵀA(raw − b) = g² with
    A = K⁻ᵀK⁻¹, K the upper-triangular Cholesky factor.

    A general ellipsoid (9 degrees of freedom) with ≥ 9 poses, an axis-aligned one (6) with ≥ 6, a sphere (4)
    with ≥ 4; fewer poses, ``general=False`` or a fit that is not an ellipsoid fall back to the next simpler
    form. Raw units need no guess: the means are normalized by their median norm first.

    Parameters
    ----------
    means : (P, 3) array
        Pose means [raw units].
    g : float
        Local gravity [m/s^2].
    general : bool
        Allow the general (misaligned) ellipsoid.

    Returns
    -------
    (9,) ndarray
        θ in the order of :data:`optinav.multipos.model.ACCEL_PARAMS`: K [raw/(m/s^2)], then b [raw].
    """
    m = as_float_array(means, "pose means", last_dims=(3,))
    P = m.shape[0]
    s = float(np.median(np.linalg.norm(m, axis=1)))
    if not s > 0:
        raise OptinavError("the accelerometer means are all zero", "check the accelerometer columns")
    c0 = m.mean(axis=0) if P < 4 else np.zeros(3)
    x = (m - c0) / s
    X, Y, Z = x.T
    one = np.ones(P)
    forms = []
    if P >= 9 and general:
        forms.append(
            (
                "general",
                np.column_stack([X * X, Y * Y, Z * Z, 2 * X * Y, 2 * X * Z, 2 * Y * Z, 2 * X, 2 * Y, 2 * Z, one]),
            )
        )
    if P >= 6:
        forms.append(("axis", np.column_stack([X * X, Y * Y, Z * Z, 2 * X, 2 * Y, 2 * Z, one])))
    if P >= 4:
        forms.append(("sphere", np.column_stack([X * X + Y * Y + Z * Z, 2 * X, 2 * Y, 2 * Z, one])))
    for form, D in forms:
        v = _fit_quadric(D)
        if form == "general":
            a, bq, c, d, e, f, p, q, r, k = v
            A = np.array([[a, d, e], [d, bq, f], [e, f, c]])
        elif form == "axis":
            a, bq, c, p, q, r, k = v
            A = np.diag([a, bq, c])
        else:
            a, p, q, r, k = v
            A = a * np.eye(3)
        lin = np.array([p, q, r])
        try:
            center = -np.linalg.solve(A, lin)
        except np.linalg.LinAlgError:
            continue
        level = center @ A @ center - k  # (x − c)ᵀA(x − c) = level
        if level == 0:
            continue
        A = A / level
        ev = np.linalg.eigvalsh(A)
        if not np.all(ev > 0):
            continue
        U = np.linalg.cholesky(A * g**2).T  # ‖K⁻¹(m − b)‖ = g ⇔ (x − c)ᵀ(s²K⁻ᵀK⁻¹/g²)(x − c) = 1, x = m/s
        K = np.linalg.inv(U) * s
        b = center * s + c0
        return model.Kb_to_theta(np.triu(K), b)
    k = s / g
    return np.array([k, k, k, 0, 0, 0, *(c0 if P < 4 else np.zeros(3))])


def search_interval(
    means, g: float, *, scale_tol: float = 0.05, bias_tol: float = 0.05, misalignment: float = 0.05, center=None
) -> tuple[np.ndarray, np.ndarray]:
    """GA/PSO search interval around the closed-form estimate, in raw units (Gao & Zhang 2019, sec. 2.2,
    invert the output model N = K·f + B for the interval; the centre here is :func:`initial_estimate`, which
    unlike the paper's per-axis extremes holds for raw counts with offsets far above the g span).

    With K⁰, b⁰ the centre (``center``, θ (9,), default the closed form): K_ii⁰(1 ± ``scale_tol``),
    b_i⁰ ± ``bias_tol``·K_ii⁰·g and off-diagonals K_ij⁰ ± ``misalignment``·K_ii⁰ (rad).
    """
    m = as_float_array(means, "pose means", last_dims=(3,))
    c = initial_estimate(m, g) if center is None else as_float_array(center, "center")
    k = np.abs(c[:3])
    half = np.r_[scale_tol * k, misalignment * k[[0, 0, 1]], bias_tol * k * g]
    return c - half, c + half


def residual_sigma(theta, stats: PoseStatistics) -> np.ndarray:
    """σ of each pose's norm residual (m/s²) from its sample covariance: sqrt(ûᵀK⁻¹Σ_kK⁻ᵀû / n_k)."""
    K, _ = model.theta_to_Kb(theta)
    u = model.corrected(theta, stats.means)
    w = np.linalg.solve(K.T, (u / np.linalg.norm(u, axis=1, keepdims=True)).T).T  # K⁻ᵀû
    var = np.einsum("ki,kij,kj->k", w, stats.covariances, w) / stats.counts
    return np.sqrt(np.maximum(var, np.finfo(float).tiny))


@dataclasses.dataclass
class AccelFit(Result):
    """One accelerometer fit: parameters, uncertainty, observability and the optimizer's trace."""

    SCHEMA = "optinav.accel_fit"
    VERSION = 2

    K: np.ndarray = field(metadata={"unit": "raw/(m/s^2)"})
    b: np.ndarray = field(metadata={"unit": "raw"})
    theta: np.ndarray = field(metadata={"unit": "raw/(m/s^2) | raw"})
    std: np.ndarray = field(metadata={"unit": "raw/(m/s^2) | raw"})
    crlb_std: np.ndarray = field(metadata={"unit": "raw/(m/s^2) | raw"})
    estimated: list = field(metadata={"unit": "-"})
    held: list = field(metadata={"unit": "-"})
    method: str = field(metadata={"unit": "-"})
    data: str = field(metadata={"unit": "-"})
    g: float = field(metadata={"unit": "m/s^2"})
    residuals: np.ndarray = field(metadata={"unit": "m/s^2"})
    residual_sigma: np.ndarray = field(metadata={"unit": "m/s^2"})
    chi2: float = field(metadata={"unit": ""})
    dof: int = field(metadata={"unit": ""})
    observability: ObservabilityReport = field(metadata={"unit": "-"})
    success: bool = field(metadata={"unit": "-"})
    message: str = field(metadata={"unit": "-"})
    nfev: int = field(metadata={"unit": ""})
    nit: int = field(metadata={"unit": ""})
    history: np.ndarray = field(metadata={"unit": "(m/s^2)^2"})
    elapsed_s: float = field(metadata={"unit": "s"})
    #: GA/PSO per-generation ``mean_cost`` and ``best_x`` (the estimated parameters, ``estimated`` order)
    trace: dict = field(default_factory=dict, metadata={"unit": "-"})
    #: distinct pose directions (poses within gates.SAME_POSE_DEG count once)
    n_distinct: int = field(default=0, metadata={"unit": ""})
    #: why parameters were held, when the model was reduced automatically ("" otherwise)
    note: str = field(default="", metadata={"unit": "-"})
    #: GA/PSO: how far the search stopped short of its objective's minimum, in std ("" otherwise)
    search_note: str = field(default="", metadata={"unit": "-"})
    #: GA/PSO: the step from ``theta`` to its objective's minimum (0 for held terms; None for local methods)
    shortfall: np.ndarray | None = field(default=None, metadata={"unit": "raw/(m/s^2) | raw"})


def _observability(J, sigma, free) -> ObservabilityReport:
    names = [model.ACCEL_PARAMS[i] for i in free]
    units = ["raw/(m/s^2)" if i < 6 else "raw" for i in free]
    return analyze(J[:, free], sigma, names=names, units=units)


def pose_directions(means, g: float) -> np.ndarray:
    """Unit gravity directions (P, 3) of the pose means from the axis-aligned closed form (robust with
    repeated poses, where the general ellipsoid is underdetermined); used to count distinct poses."""
    u = model.corrected(initial_estimate(means, g, general=False), means)
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _distinct_report(J: np.ndarray, sigma: np.ndarray, labels: np.ndarray, free) -> ObservabilityReport:
    """Observability of ``free`` from one averaged Jacobian row per distinct pose (repeats count once)."""
    n = labels.max() + 1
    Jd = np.array([J[labels == c].mean(axis=0) for c in range(n)])
    sd = np.array([np.sqrt(1.0 / np.sum(1.0 / sigma[labels == c] ** 2)) for c in range(n)])
    return _observability(Jd, sd, free)


def _choose_model(
    requested: str, J: np.ndarray, sigma: np.ndarray, labels: np.ndarray
) -> tuple[list[int], list[int], str]:
    """(estimated, held) parameter indices for model ``requested`` ("auto", "full", "diagonal") and a note
    saying why the misalignments were held (empty when they were not, or were held on request)."""
    full, diag = list(range(9)), [0, 1, 2, 6, 7, 8]
    n_distinct = int(labels.max() + 1)
    if requested != "diagonal":
        rep = _distinct_report(J, sigma, labels, full)
        if rep.full_rank and _observability(J, sigma, full).full_rank:
            return full, [], ""
        why = (
            f"{n_distinct} distinct pose directions ({len(labels)} poses; poses within {gates.SAME_POSE_DEG:g}° "
            f"count once) cannot determine all 9 accelerometer parameters: "
            + "; ".join(rep.unobservable_directions or ["rank deficient"])
        )
        if requested == "full":
            raise OptinavError(
                why,
                "add poses (>= 9 distinct directions, including ones tilted about 45° "
                "between axes), or pass --model auto or --model diagonal",
            )
        note = (
            f"{n_distinct} distinct pose directions ({len(labels)} poses; poses within "
            f"{gates.SAME_POSE_DEG:g}° count once) cannot determine the misalignments (>= 9 distinct, some "
            "tilted, are needed): K_xy, K_xz, K_yz are held at 0, scales and biases fitted"
        )
    else:
        note = ""
    rep6 = _distinct_report(J, sigma, labels, diag)
    if not rep6.full_rank:
        raise OptinavError(
            f"{n_distinct} distinct pose directions ({len(labels)} poses) cannot determine the "
            "accelerometer scale factors and biases: " + "; ".join(rep6.unobservable_directions),
            "record at least 6 distinct poses with each axis both up and down (e.g. ±x, ±y, ±z up)",
        )
    return diag, list(MISALIGNMENT), note


#: per column of K (x, y, z), its entries in θ (:data:`~optinav.multipos.model.ACCEL_PARAMS`: K_xx, K_yy, K_zz,
#: K_xy, K_xz, K_yz)
_COLUMNS = ((0,), (1, 3), (2, 4, 5))


def positive_scales(theta) -> np.ndarray:
    """θ with each column of K whose diagonal is negative negated: |K⁻¹(m − b)| is the same (K·D, D = diag(±1),
    has the inverse D·K⁻¹), so the norm fit cannot tell the signs, and a sensor's scales are positive. A clean
    session of six axis poses done twice converged to K_zz = −209 and was refused as an axis flipped."""
    th = np.array(theta, dtype=float)
    for j, idx in enumerate(_COLUMNS):
        if th[j] < 0:
            th[list(idx)] *= -1.0
    return th


def _held_response(Jw, free, held, theta, held_misalignment: float) -> tuple[np.ndarray, np.ndarray]:
    """(G, s_h) of parameters ``held`` at 0: G = −(J_fᵀWJ_f)⁻¹J_fᵀWJ_h the response of the ``free`` ones to a
    held term (``Jw`` the whitened Jacobian over all 9), s_h their 1σ [raw/(m/s^2)] from ``held_misalignment``
    [rad] (K_xy, K_xz ∝ K_xx; K_yz ∝ K_yy)."""
    G = -np.linalg.lstsq(Jw[:, free], Jw[:, held], rcond=None)[0]
    per_rad = {3: 0, 4: 0, 5: 1}
    s_h = abs(float(held_misalignment)) * np.abs(theta[[per_rad[i] for i in held]])
    return G, s_h


def parameter_covariance(fit: AccelFit, stats: PoseStatistics, held_misalignment: float = HELD_MISALIGNMENT):
    """Covariance (9 × 9) of θ [raw/(m/s^2) | raw]: the free terms' ``std`` with their Gauss–Newton correlations
    and, for terms held at 0, their prior 1σ ``held_misalignment`` [rad] with the response of the free terms to
    them (G, :func:`_held_response`), which ``std`` holds only as a variance; a held term's truth is not 0, and
    what depends on the fitted frame (the gyro's up directions) moves with it."""
    free = [i for i in range(9) if model.ACCEL_PARAMS[i] not in fit.held]
    held = [i for i in range(9) if model.ACCEL_PARAMS[i] in fit.held]
    Jw = model.norm_jacobian(fit.theta, stats.means) / residual_sigma(fit.theta, stats)[:, None]
    G, s_h = (
        _held_response(Jw, free, held, fit.theta, held_misalignment)
        if held
        else (np.zeros((len(free), 0)), np.zeros(0))
    )
    held_var = (G**2) @ s_h**2  # in fit.std already (fit_accel): its correlations are G's, not the noise's
    C = np.linalg.pinv(Jw[:, free].T @ Jw[:, free])
    d = np.sqrt(np.clip(np.diag(C), 1e-300, None))
    s = np.sqrt(np.clip(fit.std[free] ** 2 - held_var, 0.0, None))
    cov = np.zeros((9, 9))
    cov[np.ix_(free, free)] = (C / np.outer(d, d)) * np.outer(s, s) + (G * s_h**2) @ G.T
    cov[np.ix_(free, held)] = G * s_h**2
    cov[np.ix_(held, free)] = cov[np.ix_(free, held)].T
    cov[np.ix_(held, held)] = np.diag(s_h**2)
    return cov


def fit_accel(
    stats: PoseStatistics,
    g: float,
    *,
    method: str = "lm",
    model_form: str = "auto",
    data: str = "means",
    samples=None,
    x0=None,
    rng=None,
    interval=None,
    bias_instability=None,
    held_misalignment: float = HELD_MISALIGNMENT,
    **options,
) -> AccelFit:
    """Fit θ = (K, b) of ``raw = K·a + b`` to static-pose data (see the module docstring).

    Parameters
    ----------
    stats : PoseStatistics
        Per-pose raw statistics.
    g : float
        Local gravity [m/s^2].
    method : str
        One of :data:`METHODS` (``"lm"``, ``"gn"``, ``"trf"``, ``"newton"``, ``"ga"``, ``"pso"``; module docstring).
    model_form : str
        ``"auto"`` (all 9 when observable, else scales and biases with the misalignments held at 0 and
        reported), ``"full"`` (error if not observable) or ``"diagonal"``.
    data : str
        ``"means"`` or ``"samples"`` (needs ``samples``).
    samples : list of (n_k, 3) array or None
        Raw samples per pose [raw units].
    x0 : (9,) array or None
        Start θ [raw/(m/s^2), raw]; None: :func:`initial_estimate`.
    rng : int, Generator or None
        Seed or generator of a stochastic optimizer.
    interval : tuple of two (9,) arrays or None
        GA/PSO search bounds (lo, hi) of θ [raw/(m/s^2), raw]; None: :func:`search_interval`.
    bias_instability : float, (3,) array or None
        1σ of the bias drift over the session [raw units], added in quadrature to the bias std (the data
        cannot reveal a drift common to all poses).
    held_misalignment : float
        1σ of the misalignments a reduced model holds at 0 [rad]; their first-order effect on the fitted scales
        and biases is added to those stds.
    **options
        Passed to the optimizer (e.g. ``generations`` for the GA).

    Returns
    -------
    AccelFit
        K [raw/(m/s^2)] and b [raw] with std, CRLB std, observability and the optimizer's trace.
    """
    g = check_positive(g, "gravity")
    if method not in METHODS:
        raise OptinavError(f"unknown calibration method {method!r}", f"use one of {', '.join(METHODS)}")
    if model_form not in MODELS:
        raise OptinavError(f"unknown accelerometer model {model_form!r}", f"use one of {', '.join(MODELS)}")
    if data not in ("means", "samples"):
        raise OptinavError(f"data={data!r} is not understood", "use 'means' or 'samples'")
    P = stats.means.shape[0]
    if P < 6:
        raise OptinavError(
            f"{P} static pose(s) found; norm observation needs at least 6 (9 for misalignments)",
            "record more poses: each axis up and down, plus tilted poses",
        )
    t0 = time.perf_counter()
    start = initial_estimate(stats.means, g)
    sig0 = residual_sigma(start, stats)
    J0 = model.norm_jacobian(start, stats.means)
    labels = gates.distinct_directions(pose_directions(stats.means, g))
    free, held, note = _choose_model(model_form, J0, sig0, labels)
    if method in ("ga", "pso"):
        lo, hi = search_interval(stats.means, g, center=start) if interval is None else interval
    if x0 is None:
        x0 = start
    x0 = as_float_array(x0, "x0").copy()
    x0[held] = 0.0
    weighted = method in ("lm", "gn", "trf")
    if data == "samples":
        if samples is None or len(samples) != P:
            raise OptinavError("data='samples' needs the raw samples of every pose", "pass samples=[...] per pose")
        pts = np.concatenate([np.asarray(s, float) for s in samples])
        w = (
            np.concatenate([np.full(len(s), 1.0 / (sig0[k] * np.sqrt(stats.counts[k]))) for k, s in enumerate(samples)])
            if weighted
            else np.ones(len(pts))
        )
    else:
        pts = stats.means
        w = 1.0 / sig0 if weighted else np.ones(P)

    def full_theta(z):
        th = np.array(x0, dtype=float) if np.ndim(z) == 1 else np.tile(x0, (z.shape[0], 1))
        th[..., free] = z
        return th

    problem = Problem(
        residuals=lambda z: w * model.norm_residuals(full_theta(z), pts, g),
        jacobian=lambda z: w[:, None] * model.norm_jacobian(full_theta(z), pts)[:, free],
        residuals_batch=lambda Z: w * model.norm_residuals(full_theta(Z), pts, g),
        x0=x0[free],
        names=[model.ACCEL_PARAMS[i] for i in free],
        x_scale=np.maximum(np.abs(start[free]), np.abs(start[:3]).mean() * 1e-3),
        search_interval=(np.asarray(lo)[free], np.asarray(hi)[free]) if method in ("ga", "pso") else None,
    )
    if method == "pso" and "v_max" not in options:
        options["v_max"] = 0.2 * (hi - lo)[free]  # the paper's V ∈ [−1, 1] is for unit-sized parameters
    res = minimize(problem, _CORE_METHOD[method], rng=rng, **options)
    theta = positive_scales(full_theta(res.x))
    r = model.norm_residuals(theta, stats.means, g)
    sig = residual_sigma(theta, stats)
    J = model.norm_jacobian(theta, stats.means)
    rep = _observability(J, sig, list(range(9)))  # all 9: names what the poses cannot determine
    crlb = np.full(9, np.nan)
    crlb[free] = rep.crlb_std if not held else _observability(J, sig, free).crlb_std
    chi2 = float(np.sum((r / sig) ** 2))
    dof = int(P - len(free))
    add_var, extra_chi2 = np.zeros(len(free)), 0.0
    if held and held_misalignment:
        # model error of the held terms: what the free terms cannot absorb, (J_h + J_f·G)·δθ_held, is expected in χ²
        Jw = J / sig[:, None]
        G, s_h = _held_response(Jw, free, held, theta, held_misalignment)
        add_var = (G**2) @ s_h**2
        extra_chi2 = float(np.sum(((Jw[:, held] + Jw[:, free] @ G) ** 2) @ s_h**2))
    # Correlated noise shifts whole pose means, which the within-pose scatter cannot show; the a-posteriori
    # variance factor χ²/dof (never below 1; the χ² the held terms explain is not counted twice) carries it.
    std = crlb * np.sqrt(max(1.0, chi2 / (dof + extra_chi2))) if dof > 0 else crlb.copy()
    std[free] = np.sqrt(std[free] ** 2 + add_var)
    search_note, shortfall = "", None
    if res.shortfall is not None:
        shortfall = np.zeros(9)
        shortfall[free] = res.shortfall
        # where the search stopped short of its objective's minimum the noise std does not reach (GA, PSO)
        search_note = shortfall_note(res.shortfall, std[free], problem.param_names)
        std[free] = np.hypot(std[free], res.shortfall)
    if bias_instability is not None:
        # a drift common to all poses moves b without leaving a residual: only a noise model can bound it
        std[6:9] = np.hypot(std[6:9], np.broadcast_to(np.abs(as_float_array(bias_instability, "bias_instability")), 3))
    std[held] = np.nan
    K, b = model.theta_to_Kb(theta)
    return AccelFit(
        K=K,
        b=b,
        theta=theta,
        std=std,
        estimated=[model.ACCEL_PARAMS[i] for i in free],
        held=[model.ACCEL_PARAMS[i] for i in held],
        method=method,
        data=data,
        g=g,
        residuals=r,
        residual_sigma=sig,
        chi2=chi2,
        dof=dof,
        crlb_std=crlb,
        observability=rep,
        success=bool(res.success),
        message=str(res.message),
        nfev=int(res.nfev),
        nit=int(res.nit),
        history=np.asarray(res.history, float),
        elapsed_s=time.perf_counter() - t0,
        trace=dict(res.trace),
        n_distinct=int(labels.max() + 1),
        note=note,
        search_note=search_note,
        shortfall=shortfall,
    )


def efficiency(
    K, b, up_dirs, g: float, sigma: float, n_per_pose: int, n_runs: int, rng=None
) -> tuple[np.ndarray, np.ndarray]:
    """Monte Carlo RMSE/√CRLB of the default estimator (white noise σ per sample and axis, raw units).

    Pose means are drawn directly (mean of n white samples ~ N(K·g·u + b, σ²/n)), so ``n_runs`` fits take
    seconds. Returns (RMSE/√CRLB (9,), √CRLB (9,)) in θ order.
    """
    from optinav.core.validate import as_rng

    gen = as_rng(rng)
    ups = as_float_array(up_dirs, "up_dirs", last_dims=(3,))
    ups = ups / np.linalg.norm(ups, axis=1, keepdims=True)
    K, b = as_float_array(K, "K", last_dims=(3, 3)), as_float_array(b, "b", last_dims=(3,))
    th_true = model.Kb_to_theta(K, b)
    clean = np.array([K @ (g * u) + b for u in ups])
    cov = np.tile(np.eye(3) * sigma**2, (len(ups), 1, 1))
    errs, crlb = [], None
    for _ in range(int(n_runs)):
        means = clean + gen.normal(0, sigma / np.sqrt(n_per_pose), clean.shape)
        f = fit_accel(PoseStatistics(means, cov, np.full(len(ups), int(n_per_pose))), g)
        errs.append(f.theta - th_true)
        crlb = f.crlb_std if crlb is None else crlb
    return np.sqrt(np.mean(np.square(errs), axis=0)) / crlb, crlb
