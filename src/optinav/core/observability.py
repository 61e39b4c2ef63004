"""Observability and uncertainty: rank, named (un)observable combinations, covariance, CRLB, Monte Carlo.

Every calibration reports these from its residual Jacobian ``J`` (m × n, at the solution) and the
measurement noise (σ scalar, per-residual σ vector, or full covariance ``R``):

* :func:`fisher_information` — ``F = Jᵀ R⁻¹ J`` (Gauss–Markov model; Kay, *Fundamentals of Statistical
  Signal Processing: Estimation Theory*, 1993, eq. 3.31/Thm 3.2 for the linear Gaussian model).
* :func:`analyze` → :class:`ObservabilityReport` — numerical rank, singular values, condition number,
  null space, the (un)observable parameter combinations in words, covariance on the observable subspace,
  Cramér–Rao bound, correlations, ``summary()``.
* :func:`observability_matrix`, :func:`observability_svd` — stripped observability matrix of a
  piecewise-constant linear system, ``Q = [H₁; H₁A₁; …; H₁A₁^{k-1}; H₂; …]`` (Goshen-Meskin &
  Bar-Itzhack, IEEE T-AES 28(4), 1992), and its SVD rank test, used to design position schemes.
* :func:`monte_carlo` → :class:`MonteCarloResult` — seeded study of estimators: bias, RMSE,
  RMSE/√CRLB, failures, runtime, optional NEES.
* :func:`nees`, :func:`nees_test` — normalized estimation error squared and its χ² consistency band
  (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and Navigation*, 2001, §5.4.2).

Rank decisions and column scaling
---------------------------------
Parameters come in different units (m/s², rad, dimensionless scale factors), so the singular values of
``J`` depend on those units. Before judging rank, the whitened Jacobian ``R^{-1/2} J`` is scaled by
column: ``u = p / scales`` (parameter over its expected magnitude). With ``scales=None`` (default) each
column is normalized to unit length, i.e. ``scales[i]`` is the standard deviation parameter ``i`` would
have if it were the only unknown; then the rank decision is exactly invariant to the units of the
parameters. A singular value ``s_k`` of the scaled matrix counts toward the rank iff
``s_k > rel_tol · s_max``. The default ``rel_tol = 1e-6`` lies well above the ~1e-8 relative error of a
forward-difference Jacobian (so a truly unobservable direction is never counted as observable) while a
direction 10⁶ times weaker than the strongest one is, for calibration purposes, not determined at all.

Covariance on the observable subspace
-------------------------------------
With rank ``r < n`` only combinations ``cᵀp`` with ``c`` orthogonal to the null space are estimable. The
reported covariance is ``D (D F D)⁺_r D`` (``D = diag(scales)``, ``⁺_r`` the pseudo-inverse truncated to
the ``r`` retained singular values): for every estimable ``c``, ``cᵀ P c`` is the variance of ``cᵀp̂``
and does not depend on the generalized inverse chosen. Its diagonal entries for parameters that are not
individually observable are NOT variances; :attr:`ObservabilityReport.std` is ``inf`` there.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from optinav.core.progress import progress as _progress
from optinav.core.results import Result
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

__all__ = [
    "DEFAULT_REL_TOL",
    "DEFAULT_COEF_TOL",
    "fisher_information",
    "analyze",
    "ObservabilityReport",
    "observability_matrix",
    "observability_svd",
    "ObservabilitySVD",
    "monte_carlo",
    "MonteCarloResult",
    "nees",
    "nees_test",
    "NeesResult",
    "rmse_ratio_band",
]

DEFAULT_REL_TOL = 1e-6  #: singular values ≤ rel_tol·s_max of the column-scaled matrix are treated as zero
DEFAULT_COEF_TOL = 1e-6  #: coupling coefficients (scaled units) below this are treated as zero in the words


# ----------------------------------------------------------------------------------------------------------
# input handling
# ----------------------------------------------------------------------------------------------------------


def _as_matrix(J, name: str = "J") -> np.ndarray:
    J = as_float_array(J, name)
    if J.ndim != 2 or J.shape[0] < 1 or J.shape[1] < 1:
        raise OptinavError(
            f"{name} must be a non-empty 2-D matrix (residuals × parameters), got shape {J.shape}",
            "pass the Jacobian of the residual vector",
        )
    return J


def _whiten(J: np.ndarray, sigma, R, *, name: str = "J") -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
    """Return ``R^{-1/2} J`` and the same whitening as a function (R = L Lᵀ, whitening = L⁻¹)."""
    m = J.shape[0]
    if R is not None:
        if sigma is not None:
            raise OptinavError("both sigma and R were given", "pass either the noise std sigma or the covariance R")
        R = as_float_array(R, "R")
        if R.shape != (m, m):
            raise OptinavError(
                f"R has shape {R.shape}, expected ({m}, {m}) for {m} residuals",
                "pass one covariance entry per pair of residuals",
            )
        if not np.allclose(R, R.T, rtol=1e-10, atol=0.0):
            raise OptinavError("R is not symmetric", "pass a symmetric covariance matrix")
        try:
            L = np.linalg.cholesky(R)
        except np.linalg.LinAlgError:
            raise OptinavError("R is not positive definite", "pass a positive definite noise covariance") from None

        from scipy import linalg as sla  # deferred: scipy costs a second at start-up (a bad-file error comes first)

        def w(x):
            return sla.solve_triangular(L, x, lower=True)

        return w(J), w
    s = as_float_array(1.0 if sigma is None else sigma, "sigma")
    if s.ndim == 2:
        raise OptinavError("sigma is a matrix", "pass a full noise covariance as R=..., sigma is a standard deviation")
    if s.ndim > 1 or (s.ndim == 1 and s.shape[0] != m):
        raise OptinavError(
            f"sigma has shape {s.shape}, expected a scalar or ({m},)",
            "pass one noise standard deviation, or one per residual",
        )
    if np.any(s <= 0):
        raise OptinavError("sigma must be positive", "pass the measurement noise standard deviation (> 0)")
    if s.ndim == 0:
        inv = 1.0 / float(s)
        return J * inv, lambda x: x * inv
    inv_v = 1.0 / s
    return J * inv_v[:, None], lambda x: x * (inv_v if x.ndim == 1 else inv_v[:, None])


def _names(names, n: int) -> list[str]:
    if names is None:
        return [f"p{i}" for i in range(n)]
    names = [str(x) for x in names]
    if len(names) != n:
        raise OptinavError(f"{len(names)} names given for {n} parameters", "pass one name per Jacobian column")
    if len(set(names)) != n:
        raise OptinavError("parameter names are not unique", "give every parameter its own name")
    return names


def _units(units, n: int) -> list[str]:
    if units is None:
        return [""] * n
    units = [str(u) for u in units]
    if len(units) != n:
        raise OptinavError(f"{len(units)} units given for {n} parameters", "pass one unit string per parameter")
    return units


def _rel_tol(rel_tol, name: str = "rel_tol") -> float:
    try:
        t = float(rel_tol)
    except (TypeError, ValueError):
        t = float("nan")
    if not (0.0 < t < 1.0):
        raise OptinavError(f"{name} must be in (0, 1), got {rel_tol!r}", "pass e.g. 1e-6")
    return t


def _scales(scales, Jw: np.ndarray) -> np.ndarray:
    n = Jw.shape[1]
    if scales is None:
        norms = np.linalg.norm(Jw, axis=0)
        # a zero column is unobservable whatever its scale; 1 keeps the arithmetic finite
        return np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 1.0)
    d = as_float_array(scales, "scales")
    if d.ndim == 0:
        d = np.full(n, float(d))
    if d.shape != (n,):
        raise OptinavError(
            f"scales has shape {d.shape}, expected ({n},)",
            "pass one expected magnitude per parameter, or None for automatic scaling",
        )
    if np.any(d <= 0):
        raise OptinavError("scales must be positive", "pass each parameter's expected magnitude (> 0)")
    return d


# ----------------------------------------------------------------------------------------------------------
# linear algebra
# ----------------------------------------------------------------------------------------------------------


def _svd_right(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (length n, zero-padded) and full right singular vectors Vᵀ (n × n) of A (m × n)."""
    m, n = A.shape
    if m > n:
        # R of a QR has the same singular values and right vectors; avoids an m × n U for long residual vectors
        A = np.linalg.qr(A, mode="r")
    elif m < n:
        A = np.vstack([A, np.zeros((n - m, n))])
    _, s, vt = np.linalg.svd(A)
    return s, vt


def _rank(s: np.ndarray, rel_tol: float) -> int:
    if s.size == 0 or s[0] <= 0:
        return 0
    return int(np.count_nonzero(s > rel_tol * s[0]))


def rref(M, tol: float = 1e-9) -> np.ndarray:
    """Reduced row echelon form (Gauss–Jordan with partial pivoting); entries below ``tol`` become zero.

    The RREF of a row space is unique, so it gives a canonical, readable basis; if the space splits into
    parts acting on disjoint parameter sets, its RREF rows do too.
    """
    A = np.array(M, dtype=float, copy=True)
    rows, cols = A.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        i = r + int(np.argmax(np.abs(A[r:, c])))
        if abs(A[i, c]) <= tol:
            A[r:, c] = 0.0
            continue
        A[[r, i]] = A[[i, r]]
        A[r] /= A[r, c]
        for k in range(rows):
            if k != r and A[k, c] != 0.0:
                A[k] -= A[k, c] * A[r]
        r += 1
    A = A[:r]
    A[np.abs(A) < tol] = 0.0
    return A


def _orthonormal(B: np.ndarray) -> np.ndarray:
    if B.shape[1] == 0:
        return B.copy()
    q, _ = np.linalg.qr(B)
    return q


def format_combination(coef, names: Sequence[str], *, normalize: bool = False) -> str:
    """``[1, -0.71]`` → ``'b_x − 0.71·M_xy'`` (3 significant digits; the first term carries the sign).

    ``normalize`` first divides by the first nonzero coefficient, so that parameter reads with coefficient 1."""
    coef = np.asarray(coef, dtype=float)
    if normalize:
        coef = _pivot_normalize(coef[None])[0]
    parts = []
    for c, nm in zip(coef, names):
        if c == 0.0:
            continue
        mag = abs(c)
        term = nm if np.isclose(mag, 1.0, rtol=5e-4, atol=0.0) else f"{mag:.3g}·{nm}"
        if not parts:
            parts.append(term if c > 0 else f"−{term}")
        else:
            parts.append(f"{'+' if c > 0 else '−'} {term}")
    return " ".join(parts) if parts else "0"


def _pivot_normalize(rows: np.ndarray) -> np.ndarray:
    out = rows.copy()
    for k in range(out.shape[0]):
        nz = np.flatnonzero(out[k])
        if nz.size:
            out[k] /= out[k, nz[0]]
    return out


@dataclass
class _Structure:
    rank: int
    s: np.ndarray  # scaled singular values, length n
    vt: np.ndarray  # right singular vectors of the scaled matrix (u coordinates)
    null_u: np.ndarray  # n × (n - rank), orthonormal, u coordinates
    null_p: np.ndarray  # n × (n - rank), orthonormal, parameter coordinates
    observable: np.ndarray  # bool (n,), individually observable
    unobservable: list[str]  # each unobservable direction in words
    combinations: list[str]  # observable combinations of coupled parameters in words
    statements: list[str]  # everything, one sentence per line


def _structure(Js: np.ndarray, d: np.ndarray, names: list[str], rel_tol: float, coef_tol: float) -> _Structure:
    """Rank, null space and the words, from the column-scaled matrix ``Js`` (u = p / d)."""
    n = Js.shape[1]
    s, vt = _svd_right(Js)
    r = _rank(s, rel_tol)
    null_u = vt[r:].T.copy()
    null_p = _orthonormal(d[:, None] * null_u)
    unobs_words: list[str] = []
    comb_words: list[str] = []
    observable = np.ones(n, dtype=bool)
    statements: list[str] = []
    if r < n:
        N = rref(null_u.T, coef_tol)  # canonical null basis, u coordinates
        support = N != 0.0
        observable = ~support.any(axis=0)
        for row in N:
            unobs_words.append(format_combination(_pivot_normalize((d * row)[None])[0], names))
        # coupled groups: parameters linked through a common null direction (union–find over the RREF rows)
        parent = list(range(n))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        for row in support:
            idx = np.flatnonzero(row)
            for j in idx[1:]:
                parent[find(j)] = find(idx[0])
        groups: dict[int, list[int]] = {}
        for i in np.flatnonzero(~observable):
            groups.setdefault(find(int(i)), []).append(int(i))
        for g in sorted(groups.values()):
            B = N[:, g][support[:, g].any(axis=1)]
            sb, vtb = _svd_right(B)
            rb = _rank(sb, 1e-10)
            est = vtb[rb:]  # estimable functionals on g, u coordinates
            if est.shape[0] == 0:
                continue  # every parameter of g is then a single-parameter unobservable direction itself
            est = rref(est, coef_tol)
            est_p = _pivot_normalize(est / d[g][None, :])  # cᵀu = (c/d)ᵀp
            words = [format_combination(row, [names[i] for i in g]) for row in est_p]
            comb_words.extend(words)
        statements = [f"unobservable: {w}" for w in unobs_words]
        if observable.any():
            statements.append("individually observable: " + ", ".join(np.asarray(names)[observable]))
        if comb_words:
            lab = "combination" if len(comb_words) == 1 else "combinations"
            statements.append(f"observable only as the {lab}: " + "; ".join(comb_words))
    else:
        statements = ["all parameters individually observable"]
    return _Structure(r, s, vt, null_u, null_p, observable, unobs_words, comb_words, statements)


# ----------------------------------------------------------------------------------------------------------
# Fisher information, analyze
# ----------------------------------------------------------------------------------------------------------


def fisher_information(J, sigma=None, *, R=None) -> np.ndarray:
    """Fisher information ``Jᵀ R⁻¹ J`` of residuals with Jacobian ``J``; Gaussian noise (Kay 1993, Thm 3.2).

    Parameters
    ----------
    J : (m, n) array
        Residual Jacobian ∂r/∂p [residual units per parameter unit].
    sigma : float, (m,) array or None
        Noise standard deviation [residual units], scalar or per residual; None: 1.
    R : (m, m) array or None
        Full noise covariance [residual units²] instead of ``sigma``.

    Returns
    -------
    (n, n) ndarray
        Fisher information [1/parameter units²].
    """
    J = _as_matrix(J)
    Jw, _ = _whiten(J, sigma, R)
    F = Jw.T @ Jw
    return 0.5 * (F + F.T)


@dataclass
class ObservabilityReport(Result):
    """Observability and uncertainty of a least-squares estimate (see the module docstring).

    Units: ``param`` stands for each parameter's own unit (``param_units``); matrices are in
    param_i·param_j. ``covariance``/``std`` use the a-posteriori variance factor when it was estimated,
    ``crlb``/``crlb_std`` always use the given noise (a-priori).
    """

    SCHEMA = "optinav.observability"
    VERSION = 2

    names: list = field(metadata={"unit": "-"})
    param_units: list = field(metadata={"unit": "-"})
    n_residuals: int = field(metadata={"unit": ""})
    rank: int = field(metadata={"unit": ""})
    rel_tol: float = field(metadata={"unit": ""})
    scales: np.ndarray = field(metadata={"unit": "param"})
    singular_values: np.ndarray = field(metadata={"unit": ""})
    condition_number: float = field(metadata={"unit": ""})
    null_space: np.ndarray = field(metadata={"unit": ""})
    observable: np.ndarray = field(metadata={"unit": "-"})
    unobservable_directions: list = field(metadata={"unit": "-"})
    observable_combinations: list = field(metadata={"unit": "-"})
    statements: list = field(metadata={"unit": "-"})
    fisher: np.ndarray = field(metadata={"unit": "1/param^2"})
    covariance: np.ndarray = field(metadata={"unit": "param^2"})
    std: np.ndarray = field(metadata={"unit": "param"})
    crlb: np.ndarray = field(metadata={"unit": "param^2"})
    crlb_std: np.ndarray = field(metadata={"unit": "param"})
    correlation: np.ndarray = field(metadata={"unit": ""})
    variance_factor: float | None = field(default=None, metadata={"unit": ""})
    dof: int = field(default=0, metadata={"unit": ""})
    sigma_estimated: bool = field(default=False, metadata={"unit": "-"})

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def full_rank(self) -> bool:
        return self.rank == self.n_params

    def _coef(self, c) -> np.ndarray:
        c = as_float_array(c, "combination")
        if c.shape != (self.n_params,):
            raise OptinavError(
                f"combination has shape {c.shape}, expected ({self.n_params},)", "pass one coefficient per parameter"
            )
        return c

    def is_estimable(self, c, tol: float = DEFAULT_COEF_TOL) -> bool:
        """Whether ``cᵀp`` is observable (``c`` orthogonal to the null space, judged in scaled units).

        Parameters
        ----------
        c : (n,) array
            Combination coefficients [1/parameter units].
        tol : float
            Tolerance [-].

        Returns
        -------
        bool
            True when observable.
        """
        c = self._coef(c)
        if self.null_space.shape[1] == 0:
            return True
        cu = np.asarray(self.scales) * c
        nu = _orthonormal(np.asarray(self.null_space) / np.asarray(self.scales)[:, None])
        norm = np.linalg.norm(cu)
        return bool(norm == 0 or np.linalg.norm(nu.T @ cu) <= tol * norm)

    def combination_std(self, c, *, crlb: bool = False) -> float:
        """Standard deviation of ``cᵀp̂`` (``inf`` if the combination is not observable).

        Parameters
        ----------
        c : (n,) array
            Combination coefficients [1/parameter units].
        crlb : bool
            From the CRLB instead of the covariance.

        Returns
        -------
        float
            The std [units of cᵀp].
        """
        c = self._coef(c)
        if not self.is_estimable(c):
            return float("inf")
        P = self.crlb if crlb else self.covariance
        return float(np.sqrt(max(c @ P @ c, 0.0)))

    def summary(self) -> str:
        """Readable text: rank line, the words, a per-parameter table, singular values, strong correlations.

        Returns
        -------
        str
            The text.
        """
        n = self.n_params
        cond = "inf" if not np.isfinite(self.condition_number) else f"{self.condition_number:.3g}"
        lines = [
            f"Observability: {n} parameters, {self.n_residuals} residuals, rank {self.rank}/{n} "
            f"(singular values of the column-scaled Jacobian > {self.rel_tol:.0e}·max), "
            f"condition number {cond}"
        ]
        lines += ["  " + s for s in self.statements]
        if self.unobservable_directions:
            lines.append(
                "  (changing the parameters in proportion to the coefficients of an unobservable "
                "direction leaves the residuals unchanged)"
            )
        if self.variance_factor is not None:
            how = "applied to the covariance" if self.sigma_estimated else "not applied"
            lines.append(
                f"  a-posteriori variance factor {self.variance_factor:.4g} "
                f"(σ̂/σ = {np.sqrt(self.variance_factor):.4g}, {self.dof} dof; {how})"
            )
        w = max(9, *(len(s) for s in self.names))
        lines.append(f"  {'parameter':<{w}}  {'std':>11}  {'CRLB std':>11}  {'unit':<10} status")
        for i, nm in enumerate(self.names):
            status = "observable" if self.observable[i] else "coupled/unobservable"
            lines.append(
                f"  {nm:<{w}}  {_fmt(self.std[i]):>11}  {_fmt(self.crlb_std[i]):>11}  "
                f"{self.param_units[i]:<10} {status}"
            )
        sv = " ".join(f"{x:.3g}" for x in np.asarray(self.singular_values))
        lines.append(f"  scaled singular values: {sv}")
        C = np.asarray(self.correlation)
        pairs = [
            (abs(C[i, j]), i, j)
            for i in range(n)
            for j in range(i + 1, n)
            if np.isfinite(C[i, j]) and abs(C[i, j]) >= 0.9
        ]
        if pairs:
            pairs.sort(reverse=True)
            txt = ", ".join(f"{self.names[i]}/{self.names[j]} {C[i, j]:+.3f}" for _, i, j in pairs[:8])
            lines.append(f"  strong correlations (|ρ| ≥ 0.9): {txt}")
        return "\n".join(lines)


def _fmt(x: float) -> str:
    return "inf" if not np.isfinite(x) else f"{x:.4g}"


def analyze(
    J,
    sigma=None,
    *,
    R=None,
    names: Sequence[str] | None = None,
    units: Sequence[str] | None = None,
    rel_tol: float = DEFAULT_REL_TOL,
    scales=None,
    residuals=None,
    estimate_sigma: bool = False,
    coef_tol: float = DEFAULT_COEF_TOL,
) -> ObservabilityReport:
    """Observability and uncertainty of parameters ``p`` from the residual Jacobian ``J = ∂r/∂p``.

    Parameters
    ----------
    J : (m, n) array
        Residual Jacobian [residual units per parameter unit].
    sigma : float, (m,) array or None
        Measurement noise std [residual units], scalar or per residual; None: 1.
    R : (m, m) array or None
        Full noise covariance [residual units²] instead of ``sigma``.
    names, units : sequence of str or None
        Parameter names and unit strings (for the words and ``summary()``).
    rel_tol : float
        Rank tolerance relative to the largest singular value of the column-scaled, whitened Jacobian [-].
    scales : float, (n,) array or None
        Expected magnitude of each parameter [parameter units]; None normalizes each column (unit-invariant). A
        column that is zero only up to rounding is then scaled up and looks observable: pass ``scales`` when a
        parameter may be structurally unobservable.
    residuals : (m,) array or None
        Residual vector at the solution [residual units], for the a-posteriori variance factor
        ``s² = rᵀR⁻¹r / (m − rank)``.
    estimate_sigma : bool
        Multiply the covariance by s².
    coef_tol : float
        Coupling coefficients below this (in scaled units) count as zero when naming combinations [-].

    Returns
    -------
    ObservabilityReport
        Rank, null space, unobservable combinations in words, covariance and CRLB std [parameter units].
    """
    J = _as_matrix(J)
    m, n = J.shape
    names_ = _names(names, n)
    units_ = _units(units, n)
    tol = _rel_tol(rel_tol)
    ctol = _rel_tol(coef_tol, "coef_tol")
    Jw, white = _whiten(J, sigma, R)
    d = _scales(scales, Jw)
    Js = Jw * d[None, :]
    st = _structure(Js, d, names_, tol, ctol)
    r = st.rank

    s_r = st.s[:r]
    Vr = st.vt[:r].T
    P_u = (Vr / s_r**2) @ Vr.T
    crlb = d[:, None] * P_u * d[None, :]
    crlb = 0.5 * (crlb + crlb.T)

    vf = None
    dof = m - r
    if residuals is not None:
        res = as_float_array(residuals, "residuals")
        if res.shape != (m,):
            raise OptinavError(f"residuals has shape {res.shape}, expected ({m},)", "pass the residual vector of J")
        if dof > 0:
            rw = white(res)
            vf = float(rw @ rw) / dof
    if estimate_sigma:
        if residuals is None:
            raise OptinavError("estimate_sigma=True needs the residuals", "pass residuals=... at the solution")
        if vf is None:
            raise OptinavError(
                f"no redundancy to estimate sigma ({m} residuals, rank {r})",
                "collect more measurements or pass the known sigma",
            )
    cov = crlb * vf if (estimate_sigma and vf is not None) else crlb.copy()

    obs = st.observable
    diag_c = np.clip(np.diag(cov), 0.0, None)
    diag_b = np.clip(np.diag(crlb), 0.0, None)
    std = np.where(obs, np.sqrt(diag_c), np.inf)
    crlb_std = np.where(obs, np.sqrt(diag_b), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.sqrt(diag_c)
        corr = cov / np.outer(sd, sd)
    ok = obs & (sd > 0)
    corr[~ok, :] = np.nan
    corr[:, ~ok] = np.nan
    corr[np.diag_indices(n)] = np.where(ok, 1.0, np.nan)
    corr = np.clip(corr, -1.0, 1.0)

    s_full = st.s
    cond = float(s_full[0] / s_full[-1]) if s_full[-1] > 0 and r == n else float("inf")
    return ObservabilityReport(
        names=names_,
        param_units=units_,
        n_residuals=m,
        rank=r,
        rel_tol=tol,
        scales=d,
        singular_values=s_full,
        condition_number=cond,
        null_space=st.null_p,
        observable=obs,
        unobservable_directions=st.unobservable,
        observable_combinations=st.combinations,
        statements=st.statements,
        fisher=0.5 * (Jw.T @ Jw + (Jw.T @ Jw).T),
        covariance=cov,
        std=std,
        crlb=crlb,
        crlb_std=crlb_std,
        correlation=corr,
        variance_factor=vf,
        dof=dof,
        sigma_estimated=bool(estimate_sigma),
    )


# ----------------------------------------------------------------------------------------------------------
# state-space observability
# ----------------------------------------------------------------------------------------------------------


def observability_matrix(H_blocks, A=None, order: int | None = None) -> np.ndarray:
    """Stripped observability matrix ``Q = [H₁; H₁A₁; …; H₁A₁^{order-1}; H₂; H₂A₂; …]``.

    For a piecewise-constant system the rank of this stripped matrix equals that of the total one when
    null(Q_j) ⊆ null(A_j) (Goshen-Meskin & Bar-Itzhack 1992).

    Parameters
    ----------
    H_blocks : (p, n) array or sequence of them
        Measurement matrices, one per segment/position [measurement per state units].
    A : (n, n) array, sequence of them or None
        None (static: only the H blocks are stacked), one system matrix (continuous ``F`` or discrete ``Φ``)
        shared by all segments, or one per segment [1/s for F, - for Φ].
    order : int or None
        Powers per segment; None: n (enough by Cayley–Hamilton).

    Returns
    -------
    (rows, n) ndarray
        Q [measurement per state units].
    """
    try:
        arr = np.asarray(H_blocks, dtype=float)
    except (TypeError, ValueError):
        arr = None  # ragged: a sequence of blocks with different row counts
    if arr is not None and arr.ndim == 2:
        H_list = [_as_matrix(arr, "H")]
    elif arr is not None and arr.ndim != 3:
        raise OptinavError(
            f"H_blocks has shape {arr.shape}, expected a matrix (p, n) or a list of them",
            "pass H (p × n) or a list of measurement matrices",
        )
    else:
        try:
            H_list = [_as_matrix(H, f"H_blocks[{k}]") for k, H in enumerate(H_blocks)]
        except TypeError:
            raise OptinavError(
                "H_blocks is not a matrix or a sequence of matrices", "pass H (p × n) or a list of them"
            ) from None
        if not H_list:
            raise OptinavError("H_blocks is empty", "pass at least one measurement matrix")
    n = H_list[0].shape[1]
    for k, H in enumerate(H_list):
        if H.shape[1] != n:
            raise OptinavError(
                f"H_blocks[{k}] has {H.shape[1]} columns, the first has {n}",
                "all measurement matrices act on the same state vector",
            )
    if A is None:
        return np.vstack(H_list)
    A_arr = as_float_array(A, "A")
    if A_arr.ndim == 2:
        A_list = [A_arr] * len(H_list)
    elif A_arr.ndim == 3 and A_arr.shape[0] == len(H_list):
        A_list = list(A_arr)
    else:
        raise OptinavError(
            f"A has shape {A_arr.shape}, expected ({n}, {n}) or ({len(H_list)}, {n}, {n})",
            "pass one system matrix, or one per H block",
        )
    for k, Ak in enumerate(A_list):
        if Ak.shape != (n, n):
            raise OptinavError(f"A has shape {Ak.shape}, expected ({n}, {n})", "A must be square in the states")
    if order is None:
        order = n
    if int(order) != order or order < 1:
        raise OptinavError(f"order must be a positive integer, got {order!r}", "pass e.g. the number of states")
    rows = []
    for H, Ak in zip(H_list, A_list):
        blk = H
        for _ in range(int(order)):
            rows.append(blk)
            blk = blk @ Ak
    return np.vstack(rows)


@dataclass
class ObservabilitySVD(Result):
    """Rank and singular values of an observability matrix; words as in :class:`ObservabilityReport`."""

    SCHEMA = "optinav.observability_svd"
    VERSION = 2

    names: list = field(metadata={"unit": "-"})
    rank: int = field(metadata={"unit": ""})
    rel_tol: float = field(metadata={"unit": ""})
    scales: np.ndarray = field(metadata={"unit": "state"})
    singular_values: np.ndarray = field(metadata={"unit": ""})
    condition_number: float = field(metadata={"unit": ""})
    null_space: np.ndarray = field(metadata={"unit": ""})
    observable: np.ndarray = field(metadata={"unit": "-"})
    statements: list = field(metadata={"unit": "-"})

    @property
    def full_rank(self) -> bool:
        return self.rank == len(self.names)

    def summary(self) -> str:
        """Readable text: rank, singular values, unobservable combinations.

        Returns
        -------
        str
            The text.
        """
        sv = " ".join(f"{x:.4g}" for x in np.asarray(self.singular_values))
        cond = "inf" if not np.isfinite(self.condition_number) else f"{self.condition_number:.4g}"
        return "\n".join(
            [
                f"Observability matrix: {len(self.names)} states, rank {self.rank}, condition number {cond}",
                f"  singular values: {sv}",
            ]
            + ["  " + s for s in self.statements]
        )


def observability_svd(
    Q,
    *,
    names: Sequence[str] | None = None,
    rel_tol: float = DEFAULT_REL_TOL,
    scales=None,
    coef_tol: float = DEFAULT_COEF_TOL,
) -> ObservabilitySVD:
    """Numerical rank, singular values and null space of an observability matrix ``Q``.

    Parameters
    ----------
    Q : (rows, n) array
        Observability matrix [measurement per state units].
    names : sequence of str or None
        State names.
    rel_tol : float
        Rank tolerance relative to the largest singular value [-].
    scales : float, (n,) array or None
        As in :func:`analyze` (None: unit-length columns); ``scales=1.0`` gives the raw singular values of ``Q``
        as usually tabulated in papers [state units].
    coef_tol : float
        Coupling coefficients below this count as zero when naming combinations [-].

    Returns
    -------
    ObservabilitySVD
        Rank, singular values and the unobservable combinations in words.
    """
    Q = _as_matrix(Q, "Q")
    n = Q.shape[1]
    names_ = _names(names, n)
    d = _scales(scales, Q)
    st = _structure(Q * d[None, :], d, names_, _rel_tol(rel_tol), _rel_tol(coef_tol, "coef_tol"))
    s = st.s
    cond = float(s[0] / s[-1]) if st.rank == n and s[-1] > 0 else float("inf")
    return ObservabilitySVD(
        names=names_,
        rank=st.rank,
        rel_tol=float(rel_tol),
        scales=d,
        singular_values=s,
        condition_number=cond,
        null_space=st.null_p,
        observable=st.observable,
        statements=st.statements,
    )


# ----------------------------------------------------------------------------------------------------------
# NEES
# ----------------------------------------------------------------------------------------------------------


def nees(errors, covariance) -> np.ndarray:
    """Normalized estimation error squared ``eₖᵀ Pₖ⁻¹ eₖ``.

    Parameters
    ----------
    errors : (N, n) array
        Estimation errors [parameter units].
    covariance : (n, n) or (N, n, n) array
        Their covariance [parameter units²].

    Returns
    -------
    (N,) ndarray
        NEES [-].
    """
    e = as_float_array(errors, "errors")
    if e.ndim == 1:
        e = e[None, :]
    if e.ndim != 2:
        raise OptinavError(f"errors has shape {e.shape}, expected (N, n)", "pass one error vector per row")
    N, n = e.shape
    P = as_float_array(covariance, "covariance")
    if P.shape == (n, n):
        P = np.broadcast_to(P, (N, n, n))
    elif P.shape != (N, n, n):
        raise OptinavError(
            f"covariance has shape {P.shape}, expected ({n}, {n}) or ({N}, {n}, {n})",
            "pass one covariance, or one per error vector",
        )
    try:
        L = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        raise OptinavError("a covariance is not positive definite", "pass positive definite covariances") from None
    z = np.linalg.solve(L, e[..., None])[..., 0]
    return np.einsum("ki,ki->k", z, z)


@dataclass
class NeesResult(Result):
    """Average NEES and its two-sided χ² acceptance band (Bar-Shalom et al. 2001, §5.4.2)."""

    SCHEMA = "optinav.nees"
    VERSION = 2

    anees: float = field(metadata={"unit": ""})
    lower: float = field(metadata={"unit": ""})
    upper: float = field(metadata={"unit": ""})
    n_samples: int = field(metadata={"unit": ""})
    dim: int = field(metadata={"unit": ""})
    confidence: float = field(metadata={"unit": ""})
    consistent: bool = field(metadata={"unit": "-"})

    def summary(self) -> str:
        """One line: ANEES, its band and the verdict.

        Returns
        -------
        str
            The line.
        """
        verdict = (
            "consistent"
            if self.consistent
            else ("covariance too optimistic" if self.anees > self.upper else "covariance too pessimistic")
        )
        return (
            f"ANEES {self.anees:.4g} over {self.n_samples} samples of dimension {self.dim}; "
            f"{100 * self.confidence:g}% band [{self.lower:.4g}, {self.upper:.4g}]: {verdict}"
        )


def nees_test(errors, covariance, confidence: float = 0.99) -> NeesResult:
    """Consistency test: N·ANEES ~ χ²(N·n) for independent Gaussian errors with the right covariance.

    Parameters
    ----------
    errors, covariance
        As :func:`nees` [parameter units, parameter units²].
    confidence : float
        Two-sided confidence of the band [-].

    Returns
    -------
    NeesResult
        ANEES [-] and its acceptance band.
    """
    q = nees(errors, covariance)
    dim = np.asarray(errors, dtype=float).shape[-1]
    N = q.size
    lo, hi = _chi2_band(N * dim, N, confidence)
    a = float(np.mean(q))
    return NeesResult(
        anees=a,
        lower=float(lo),
        upper=float(hi),
        n_samples=N,
        dim=dim,
        confidence=float(confidence),
        consistent=bool(lo <= a <= hi),
    )


def rmse_ratio_band(n_runs: int, confidence: float = 0.99) -> tuple[float, float]:
    """Band of RMSE/√CRLB for an unbiased efficient Gaussian estimator over ``n_runs`` runs.

    N·RMSE²/CRLB ~ χ²(N) (a sum of N squared standard normals), so the ratio lies in
    [√(χ²_{α/2}(N)/N), √(χ²_{1-α/2}(N)/N)] with probability ``confidence``.

    Parameters
    ----------
    n_runs : int
        N.
    confidence : float
        Probability of the band [-].

    Returns
    -------
    lo, hi : float
        The band [-].
    """
    if n_runs < 1:
        return float("nan"), float("nan")
    lo, hi = _chi2_band(n_runs, n_runs, confidence)
    return float(np.sqrt(lo)), float(np.sqrt(hi))


def _chi2_band(dof: int, n: int, confidence: float) -> tuple[float, float]:
    """Two-sided ``confidence`` band of χ²(dof)/n: the mean of n squared-normal sums over dof/n dimensions."""
    if not (0.0 < confidence < 1.0):
        raise OptinavError(f"confidence must be in (0, 1), got {confidence!r}", "pass e.g. 0.99")
    from optinav.core import distributions as dist  # deferred, see above

    return (float(dist.chi2_ppf((1 - confidence) / 2, dof) / n), float(dist.chi2_ppf((1 + confidence) / 2, dof) / n))


# ----------------------------------------------------------------------------------------------------------
# Monte Carlo
# ----------------------------------------------------------------------------------------------------------


@dataclass
class MonteCarloResult(Result):
    """Per-estimator statistics of a Monte Carlo study; errors are estimate − truth in parameter units."""

    SCHEMA = "optinav.monte_carlo"
    VERSION = 2

    names: list = field(metadata={"unit": "-"})
    estimators: list = field(metadata={"unit": "-"})
    n_runs: int = field(metadata={"unit": ""})
    seed: Any = field(metadata={"unit": "-"})
    errors: dict = field(metadata={"unit": "param"})  # name → (n_runs, n), NaN rows for failures
    bias: dict = field(metadata={"unit": "param"})
    rmse: dict = field(metadata={"unit": "param"})
    std: dict = field(metadata={"unit": "param"})
    rmse_over_crlb: dict = field(metadata={"unit": ""})
    n_failures: dict = field(metadata={"unit": ""})
    failure_messages: dict = field(metadata={"unit": "-"})
    mean_runtime: dict = field(metadata={"unit": "s"})
    crlb_std: np.ndarray | None = field(default=None, metadata={"unit": "param"})
    nees: dict = field(default_factory=dict, metadata={"unit": "-"})  # name → NeesResult (if covariances)

    def n_success(self, name: str) -> int:
        """Runs in which estimator ``name`` gave a valid estimate.

        Parameters
        ----------
        name : str
            Estimator name.

        Returns
        -------
        int
            The count.
        """
        return self.n_runs - int(self.n_failures[name])

    def summary(self, confidence: float = 0.99) -> str:
        """Readable table: bias, RMSE and RMSE/√CRLB per estimator and parameter.

        Parameters
        ----------
        confidence : float
            Confidence of the RMSE/√CRLB band shown [-].

        Returns
        -------
        str
            The table.
        """
        w = max(9, *(len(s) for s in self.names))
        lines = [f"Monte Carlo: {self.n_runs} runs, seed {self.seed}"]
        for est in self.estimators:
            ok = self.n_success(est)
            lines.append(f"{est}: {ok}/{self.n_runs} succeeded, mean runtime {1e3 * self.mean_runtime[est]:.3g} ms")
            for msg in self.failure_messages.get(est, [])[:3]:
                lines.append(f"    failure: {msg}")
            ratio = self.rmse_over_crlb.get(est)
            head = f"  {'parameter':<{w}}  {'bias':>11}  {'RMSE':>11}"
            if ratio is not None:
                head += f"  {'RMSE/√CRLB':>11}"
            lines.append(head)
            for i, nm in enumerate(self.names):
                row = f"  {nm:<{w}}  {_fmt(self.bias[est][i]):>11}  {_fmt(self.rmse[est][i]):>11}"
                if ratio is not None:
                    row += f"  {_fmt(ratio[i]):>11}"
                lines.append(row)
            if ratio is not None and ok > 0:
                lo, hi = rmse_ratio_band(ok, confidence)
                lines.append(
                    f"  ({100 * confidence:g}% band of RMSE/√CRLB for an efficient estimator: [{lo:.3f}, {hi:.3f}])"
                )
            if est in self.nees and self.nees[est] is not None:
                lines.append("  " + self.nees[est].summary())
        return "\n".join(lines)


def _child_generators(rng, n_runs: int) -> tuple[list[np.random.Generator], Any]:
    seed = None
    if rng is None or isinstance(rng, (int, np.integer)):
        seed = None if rng is None else int(rng)
        base = np.random.default_rng(rng)
    elif isinstance(rng, np.random.SeedSequence):
        seed = rng.entropy
        base = np.random.default_rng(rng)
    elif isinstance(rng, np.random.Generator):
        base = rng
    else:
        raise OptinavError(
            f"rng must be a numpy Generator, SeedSequence or int seed, got {type(rng).__name__}",
            "pass e.g. rng=np.random.default_rng(1)",
        )
    try:
        children = base.spawn(n_runs)
    except (TypeError, AttributeError, ValueError):
        # a Generator built without a SeedSequence cannot spawn: derive one from its stream
        ss = np.random.SeedSequence(base.integers(0, 2**63, size=4))
        children = [np.random.default_rng(c) for c in ss.spawn(n_runs)]
    return children, seed


def _call_estimator(fn, data, n: int):
    """One estimator call → (estimate or None, covariance or None, runtime, failure message or None)."""
    t0 = time.perf_counter()
    try:
        out = fn(data)
    except Exception as exc:  # noqa: BLE001 - any failure of one estimator in one run is counted, not fatal
        dt = time.perf_counter() - t0
        return None, None, dt, f"{type(exc).__name__}: {exc}".strip()
    dt = time.perf_counter() - t0
    P = None
    if isinstance(out, tuple) and len(out) == 2:
        out, P = out
    try:
        x = np.asarray(out, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return None, None, dt, f"returned a non-numeric value of type {type(out).__name__}"
    if x.shape != (n,):
        return None, None, dt, f"returned shape {np.shape(out)}, expected ({n},)"
    if not np.all(np.isfinite(x)):
        return None, None, dt, "returned non-finite values"
    if P is not None:
        P = np.asarray(P, dtype=float)
        if P.shape != (n, n) or not np.all(np.isfinite(P)):
            return None, None, dt, f"returned a covariance of shape {P.shape} or with non-finite values"
    return x, P, dt, None


def _mc_run(make_data, estimators: Mapping[str, Callable], truth, n: int | None, gen: np.random.Generator):
    """One Monte Carlo run; a pure function of its generator, so runs can go to worker processes."""
    data = make_data(gen)
    if truth is None:
        if not (isinstance(data, tuple) and len(data) == 2):
            raise OptinavError(
                "truth is None but make_data did not return (data, truth)",
                "pass truth=..., or return (data, truth) from make_data",
            )
        data, t = data
        t = as_float_array(t, "truth from make_data").reshape(-1)
    else:
        t = truth
    if n is not None and t.shape != (n,):
        raise OptinavError(f"truth has shape {t.shape}, expected ({n},)", "return one true value per parameter")
    return t, {name: _call_estimator(fn, data, t.size) for name, fn in estimators.items()}


def monte_carlo(
    make_data: Callable[[np.random.Generator], Any],
    estimators: Mapping[str, Callable],
    truth,
    n_runs: int,
    rng=None,
    progress: bool = True,
    crlb=None,
    names: Sequence[str] | None = None,
    nees_confidence: float = 0.99,
) -> MonteCarloResult:
    """Seeded Monte Carlo comparison of estimators against the truth.

    An exception, a wrong shape or a non-finite estimate counts as a failure (message kept), never aborts the
    study. Run ``k`` uses the ``k``-th child generator spawned from ``rng`` (same seed → identical results;
    independent streams per run; every estimator of a run sees the same data).

    Parameters
    ----------
    make_data : callable
        ``make_data(rng) -> data``, or ``(data, truth)`` when ``truth`` is None.
    estimators : mapping of str to callable
        Name → ``f(data)`` returning the estimate (n,) or ``(estimate, covariance)`` (then NEES is reported).
    truth : (n,) array or None
        True parameters [parameter units].
    n_runs : int
        Number of runs.
    rng : int, Generator or None
        Seed or generator.
    progress : bool
        Show the core progress meter when stderr is a terminal.
    crlb : (n, n) array, (n,) array, ObservabilityReport or None
        CRLB covariance [parameter units²], its diagonal of variances, or a report (its ``crlb_std``).
    names : sequence of str or None
        Parameter names.
    nees_confidence : float
        Confidence of the NEES band [-].

    Returns
    -------
    MonteCarloResult
        Per estimator: errors (estimate − truth), bias, RMSE (includes the bias) [parameter units], failures.
    """
    if not isinstance(n_runs, (int, np.integer)) or n_runs < 1:
        raise OptinavError(f"n_runs must be a positive integer, got {n_runs!r}", "pass e.g. n_runs=500")
    if not isinstance(estimators, Mapping) or not estimators:
        raise OptinavError("estimators must be a non-empty dict name → callable", "pass {'name': fn, ...}")
    for k, fn in estimators.items():
        if not callable(fn):
            raise OptinavError(f"estimator {k!r} is not callable", "pass functions data → estimate")
    if not callable(make_data):
        raise OptinavError("make_data is not callable", "pass a function rng → data")
    t_fixed = None if truth is None else as_float_array(truth, "truth").reshape(-1)
    n = None if t_fixed is None else t_fixed.size
    if n is not None and names is not None:
        _names(names, n)

    crlb_std = None
    if crlb is not None:
        if isinstance(crlb, ObservabilityReport):
            crlb_std = np.asarray(crlb.crlb_std, dtype=float)
            if names is None:
                names = crlb.names
        else:
            c = as_float_array(crlb, "crlb", finite=False)
            if c.ndim == 2 and c.shape[0] == c.shape[1]:
                c = np.diag(c)
            if c.ndim != 1 or np.any(np.isnan(c)) or np.any(c <= 0):
                raise OptinavError(
                    "crlb must be an (n, n) covariance or (n,) positive variances",
                    "pass the CRLB covariance, e.g. ObservabilityReport.crlb",
                )
            crlb_std = np.sqrt(c)
        if n is not None and crlb_std.shape != (n,):
            raise OptinavError(f"crlb is for {crlb_std.size} parameters, truth has {n}", "pass matching sizes")

    gens, seed = _child_generators(rng, int(n_runs))
    enabled = None if progress else False
    est_names = list(estimators)
    rows: list[tuple[np.ndarray, dict]] = []
    for k in _progress(range(int(n_runs)), total=int(n_runs), desc="Monte Carlo", enabled=enabled):
        t, out = _mc_run(make_data, estimators, t_fixed, n, gens[k])
        if n is None:
            n = t.size
        elif t.size != n:
            raise OptinavError(
                f"truth of run {k} has {t.size} parameters, earlier runs had {n}",
                "return the same parameter vector every run",
            )
        rows.append((t, out))

    assert n is not None
    names_ = _names(names, n)
    if crlb_std is not None and crlb_std.shape != (n,):
        raise OptinavError(f"crlb is for {crlb_std.size} parameters, estimates have {n}", "pass matching sizes")

    errors, bias, rmse, std, ratio, fails, msgs, runtime, nees_res = {}, {}, {}, {}, {}, {}, {}, {}, {}
    for name in est_names:
        E = np.full((n_runs, n), np.nan)
        covs: list[np.ndarray | None] = []
        nfail = 0
        mlist: list[str] = []
        tsum = 0.0
        for k, (t, out) in enumerate(rows):
            x, P, dt, msg = out[name]
            tsum += dt
            if msg is not None:
                nfail += 1
                if msg not in mlist and len(mlist) < 10:
                    mlist.append(msg)
                continue
            E[k] = x - t
            covs.append(P)
        good = E[~np.isnan(E).any(axis=1)]
        if good.shape[0]:
            b = good.mean(axis=0)
            rm = np.sqrt(np.mean(good**2, axis=0))
            sd = good.std(axis=0, ddof=1) if good.shape[0] > 1 else np.full(n, np.nan)
        else:
            b = rm = sd = np.full(n, np.nan)
        errors[name], bias[name], rmse[name], std[name] = E, b, rm, sd
        if crlb_std is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio[name] = np.where(np.isfinite(crlb_std), rm / crlb_std, np.nan)
        fails[name], msgs[name], runtime[name] = nfail, mlist, tsum / n_runs
        if covs and all(P is not None for P in covs):
            try:
                nees_res[name] = nees_test(good, np.stack(covs), nees_confidence)
            except OptinavError:
                nees_res[name] = None
    return MonteCarloResult(
        names=names_,
        estimators=est_names,
        n_runs=int(n_runs),
        seed=seed,
        errors=errors,
        bias=bias,
        rmse=rmse,
        std=std,
        rmse_over_crlb=ratio if crlb_std is not None else {},
        n_failures=fails,
        failure_messages=msgs,
        mean_runtime=runtime,
        crlb_std=crlb_std,
        nees=nees_res,
    )
