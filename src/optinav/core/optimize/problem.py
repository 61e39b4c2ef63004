"""The optimization problem, its result, and the counting evaluator every method goes through.

Cost convention for least-squares problems: ``E(x) = Σ r_i(x)²`` (no ½; ``scipy.optimize.least_squares``
reports ½E, this module never does). Its gradient is ``2 Jᵀr`` and its Gauss–Newton Hessian ``2 JᵀJ``.
The genetic algorithm's fitness (Gao & Zhang 2019) is ``1/E``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import field
from typing import Any

import numpy as np

from optinav.core.results import Result
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

_EPS = np.finfo(float).eps


def finite_mean(costs) -> float:
    """Mean of the finite costs of a population (inf when none is finite), for the per-generation traces."""
    ok = np.isfinite(costs)
    return float(costs[ok].mean()) if ok.any() else float("inf")


@dataclasses.dataclass
class Problem:
    """An objective for :func:`optinav.core.optimize.minimize`.

    Either a least-squares problem (``residuals``, cost ``E = Σ r²``) or a scalar one (``cost``); not both.

    residuals: ``r(x) -> (m,)``.  jacobian: analytic ``∂r/∂x -> (m, n)`` (else finite differences).
    residuals_batch: ``R(X (P, n)) -> (P, m)``, a whole swarm/population in one call (else a loop);
    also used for finite-difference Jacobians.
    cost: scalar ``E(x)`` for problems that are not least squares; gradient: its ``∇E -> (n,)``;
    cost_batch: ``E(X (P, n)) -> (P,)``.  hessian: ``∇²E -> (n, n)`` (either kind of problem).
    x0: start (n,); may be omitted when ``search_interval`` is given (then its midpoint).
    bounds: ``(lb, ub)``, scalars or (n,) arrays, ±inf allowed; lb < ub required.
    search_interval: ``(lb, ub)`` where PSO/GA draw their initial population (must be finite; defaults to
    the bounds).  names: parameter names (for messages and results).
    x_scale: characteristic size of each parameter (scalar or (n,)); sets finite-difference steps and
    the step-size stopping tests, and is passed to ``least_squares`` (``'jac'`` allowed there).
    """

    residuals: Callable | None = None
    x0: Any = None
    jacobian: Callable | None = None
    residuals_batch: Callable | None = None
    cost: Callable | None = None
    gradient: Callable | None = None
    cost_batch: Callable | None = None
    hessian: Callable | None = None
    bounds: Any = None
    search_interval: Any = None
    names: Sequence[str] | None = None
    x_scale: Any = None

    def __post_init__(self):
        _check_callables(self)
        si = None
        if self.search_interval is not None:
            si = _pair(self.search_interval, "search_interval", None)
        if self.x0 is None:
            if si is None or si[0].ndim != 1:
                raise OptinavError("Problem has no x0", "pass x0 (or a search_interval of (n,) arrays)")
            if not (np.all(np.isfinite(si[0])) and np.all(np.isfinite(si[1]))):
                raise OptinavError("Problem has no x0 and an infinite search_interval", "pass x0")
            self.x0 = 0.5 * (si[0] + si[1])
        x0 = as_float_array(self.x0, "x0")
        if x0.ndim != 1 or x0.size == 0:
            raise OptinavError(
                f"x0 must be a non-empty 1-D vector, got shape {x0.shape}", "pass one value per parameter"
            )
        self.x0 = x0
        n = x0.size
        lb, ub = (
            _pair(self.bounds, "bounds", n) if self.bounds is not None else (np.full(n, -np.inf), np.full(n, np.inf))
        )
        if np.any(lb >= ub):
            i = int(np.flatnonzero(lb >= ub)[0])
            raise OptinavError(
                f"bounds for {self._name(i)} have lb = {lb[i]:.6g} >= ub = {ub[i]:.6g}",
                "give lb < ub for every parameter (remove a fixed parameter from x)",
            )
        if np.any((x0 < lb) | (x0 > ub)):
            i = int(np.flatnonzero((x0 < lb) | (x0 > ub))[0])
            raise OptinavError(
                f"x0 is outside the bounds: {self._name(i)} = {x0[i]:.6g} not in [{lb[i]:.6g}, {ub[i]:.6g}]",
                "start inside the bounds",
            )
        self.bounds = (lb, ub) if self.bounds is not None else None
        if si is not None:
            si = _pair(self.search_interval, "search_interval", n)
            if np.any(si[0] >= si[1]):
                i = int(np.flatnonzero(si[0] >= si[1])[0])
                raise OptinavError(
                    f"search_interval for {self._name(i)} has lb = {si[0][i]:.6g} >= ub = {si[1][i]:.6g}",
                    "give lb < ub for every parameter",
                )
            self.search_interval = si
        if self.names is not None:
            names = [str(s) for s in self.names]
            if len(names) != n:
                raise OptinavError(f"names has {len(names)} entries but x0 has {n}", "give one name per parameter")
            self.names = names
        if self.x_scale is not None and not (isinstance(self.x_scale, str) and self.x_scale == "jac"):
            s = as_float_array(self.x_scale, "x_scale")
            if s.ndim > 1 or (s.ndim == 1 and s.size != n) or np.any(s <= 0):
                raise OptinavError(
                    f"x_scale must be a positive scalar or {n} positive values",
                    "pass the typical size of each parameter",
                )
            self.x_scale = np.broadcast_to(s, (n,)).astype(float)
        elif isinstance(self.x_scale, str) and self.x_scale != "jac":
            raise OptinavError(f"x_scale={self.x_scale!r} is not understood", "pass numbers or 'jac'")

    @property
    def n(self) -> int:
        """Number of parameters."""
        return int(self.x0.size)

    @property
    def is_least_squares(self) -> bool:
        return self.residuals is not None

    @property
    def lower(self) -> np.ndarray:
        return self.bounds[0] if self.bounds is not None else np.full(self.n, -np.inf)

    @property
    def upper(self) -> np.ndarray:
        return self.bounds[1] if self.bounds is not None else np.full(self.n, np.inf)

    @property
    def param_names(self) -> list[str]:
        return list(self.names) if self.names is not None else [f"x[{i}]" for i in range(self.n)]

    def _name(self, i: int) -> str:
        return self.names[i] if self.names is not None and len(self.names) > i else f"x[{i}]"

    def has_bounds(self) -> bool:
        """Whether the problem has finite bounds.

        Returns
        -------
        bool
            True when any bound is finite.
        """
        return bool(np.any(np.isfinite(self.lower)) or np.any(np.isfinite(self.upper)))

    def population_interval(self) -> tuple[np.ndarray, np.ndarray]:
        """Finite box for PSO/GA: the search interval clipped to the bounds (or the bounds themselves).

        Returns
        -------
        lo, hi : (n,) ndarray
            Box corners [parameter units].
        """
        lb, ub = self.lower, self.upper
        if self.search_interval is None:
            if not (np.all(np.isfinite(lb)) and np.all(np.isfinite(ub))):
                raise OptinavError(
                    "PSO/GA need a finite box to draw the population from, but the bounds are "
                    "infinite and no search_interval is given",
                    "pass Problem(search_interval=(lb, ub)) or finite bounds",
                )
            return lb.copy(), ub.copy()
        lo = np.maximum(self.search_interval[0], lb)
        hi = np.minimum(self.search_interval[1], ub)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise OptinavError(
                "PSO/GA need a finite box to draw the population from, but the search_interval "
                "is infinite where the bounds are",
                "give a finite search_interval",
            )
        if np.any(lo >= hi):
            i = int(np.flatnonzero(lo >= hi)[0])
            raise OptinavError(
                f"search_interval for {self._name(i)} does not overlap the bounds",
                "give a search interval inside the bounds",
            )
        return lo, hi


def _check_callables(p: Problem) -> None:
    for name in ("residuals", "jacobian", "residuals_batch", "cost", "gradient", "cost_batch", "hessian"):
        v = getattr(p, name)
        if v is not None and not callable(v):
            raise OptinavError(f"Problem.{name} is not callable", f"pass a function for {name}")
    if p.residuals is None and p.cost is None:
        raise OptinavError("Problem has neither residuals nor cost", "pass residuals=f (least squares) or cost=f")
    if p.residuals is not None and p.cost is not None:
        raise OptinavError(
            "Problem has both residuals and cost", "pass residuals (cost is then Σ r²) or cost, not both"
        )
    if p.residuals is None and (p.jacobian is not None or p.residuals_batch is not None):
        raise OptinavError("Problem has a jacobian/residuals_batch but no residuals", "pass residuals as well")
    if p.cost is None and (p.gradient is not None or p.cost_batch is not None):
        raise OptinavError(
            "Problem has a gradient/cost_batch but no cost",
            "for a least-squares problem give jacobian/residuals_batch instead",
        )


def _pair(v, name: str, n: int | None) -> tuple[np.ndarray, np.ndarray]:
    try:
        lo, hi = v
    except (TypeError, ValueError):
        raise OptinavError(f"{name} must be a pair (lb, ub)", f"pass {name}=(lb, ub)") from None
    lo = as_float_array(lo, f"{name} lb", finite=False)
    hi = as_float_array(hi, f"{name} ub", finite=False)
    if np.isnan(lo).any() or np.isnan(hi).any():
        raise OptinavError(f"{name} contains NaN", "use ±inf for an open side")
    if n is None:
        return lo, hi
    out = []
    for a, side in ((lo, "lb"), (hi, "ub")):
        if a.ndim > 1 or (a.ndim == 1 and a.size != n):
            raise OptinavError(
                f"{name} {side} has shape {a.shape} but x0 has {n} parameter(s)",
                "give a scalar or one value per parameter (check the size of x0)",
            )
        out.append(np.broadcast_to(a, (n,)).astype(float))
    return out[0], out[1]


@dataclasses.dataclass
class OptimizeResult(Result):
    """Outcome of :func:`minimize`.

    ``cost`` is ``E = Σ r²`` (least squares) or the scalar cost; ``history[k]`` is the best cost after
    iteration/generation ``k`` (``history[0]`` at the start), non-increasing. ``nfev`` counts every
    residual/cost evaluation (finite-difference ones and each swarm member included), ``njev`` every
    Jacobian/gradient evaluation. ``jacobian`` is ∂r/∂x at ``x`` (least-squares problems): pass it to
    :func:`optinav.core.observability.analyze` for rank, covariance and named unobservable combinations.
    """

    SCHEMA = "optinav.optimize_result"
    VERSION = 2
    x: np.ndarray = field(metadata={"unit": "parameter units"})
    cost: float = field(metadata={"unit": "residual units^2"})
    success: bool = field(metadata={"unit": "-"})
    message: str = field(metadata={"unit": "-"})
    method: str = field(metadata={"unit": "-"})
    nit: int = field(default=0, metadata={"unit": ""})
    nfev: int = field(default=0, metadata={"unit": ""})
    njev: int = field(default=0, metadata={"unit": ""})
    history: np.ndarray = field(default_factory=lambda: np.zeros(0), metadata={"unit": "residual units^2"})
    elapsed: float = field(default=0.0, metadata={"unit": "s"})
    jacobian: np.ndarray | None = field(default=None, metadata={"unit": "residual units / parameter units"})
    residuals: np.ndarray | None = field(default=None, metadata={"unit": "residual units"})
    names: list | None = field(default=None, metadata={"unit": "-"})
    options: dict = field(default_factory=dict, metadata={"unit": "-"})
    #: per-generation traces of the population methods: ``mean_cost`` (G+1,) and ``best_x`` (G+1, n)
    trace: dict = field(default_factory=dict, metadata={"unit": "-"})
    #: population methods on least squares: the step from ``x`` to the minimum a local least-squares search
    #: started at ``x`` finds on the same problem (zeros where it finds no lower cost), i.e. how far the search
    #: stopped short of its objective's minimum; None for local methods or where not measured
    shortfall: np.ndarray | None = field(default=None, metadata={"unit": "parameter units"})


class Evaluator:
    """Counts every evaluation and supplies costs, Jacobians, gradients and Hessians.

    Finite differences: forward steps ``h = √ε·max(|x|, s)``, central ``h = ε^(1/3)·max(|x|, s)``
    (``s`` = x_scale, default 1), flipped/one-sided near a bound so no point leaves the bounds.
    """

    def __init__(self, problem: Problem):
        self.p = problem
        self.n = problem.n
        self.lsq = problem.is_least_squares
        self.lb, self.ub = problem.lower, problem.upper
        xs = problem.x_scale
        self.scale = np.ones(self.n) if xs is None or isinstance(xs, str) else np.asarray(xs, float)
        self.nfev = 0
        self.njev = 0
        self.m: int | None = None
        self._checked_jac = False
        self._checked_batch = False

    # ------------------------------------------------------------------ evaluations
    def residuals(self, x) -> np.ndarray:
        self.nfev += 1
        return np.asarray(self.p.residuals(x), dtype=float).reshape(-1)

    def residuals_batch(self, X) -> np.ndarray:
        X = np.atleast_2d(X)
        self.nfev += X.shape[0]
        if self.p.residuals_batch is None:
            return np.stack([np.asarray(self.p.residuals(x), dtype=float).reshape(-1) for x in X])
        R = np.asarray(self.p.residuals_batch(X), dtype=float)
        if not self._checked_batch:
            self._checked_batch = True
            if R.shape != (X.shape[0], self.m):
                raise OptinavError(
                    f"residuals_batch returned shape {R.shape} for {X.shape[0]} points, "
                    f"expected ({X.shape[0]}, {self.m})",
                    "return one residual row per point",
                )
        return R

    def cost(self, x) -> float:
        if self.lsq:
            r = self.residuals(x)
            return float(r @ r)
        self.nfev += 1
        return float(self.p.cost(x))

    def cost_batch(self, X) -> np.ndarray:
        """Costs of P points (P, n) -> (P,); non-finite costs become +inf."""
        X = np.atleast_2d(X)
        if self.lsq:
            R = self.residuals_batch(X)
            c = np.einsum("ij,ij->i", R, R)
        elif self.p.cost_batch is not None:
            self.nfev += X.shape[0]
            c = np.asarray(self.p.cost_batch(X), dtype=float).reshape(-1)
            if c.shape != (X.shape[0],):
                raise OptinavError(
                    f"cost_batch returned {c.size} values for {X.shape[0]} points", "return one cost per point"
                )
        else:
            self.nfev += X.shape[0]
            c = np.array([float(self.p.cost(x)) for x in X])
        return np.where(np.isfinite(c), c, np.inf)

    def start(self, x0) -> tuple[np.ndarray | None, float]:
        """Evaluate at x0 with clear errors for wrong sizes and NaN; return (residuals or None, cost)."""
        what = "residuals" if self.lsq else "cost"
        try:
            if self.lsq:
                self.nfev += 1
                raw = np.asarray(self.p.residuals(x0.copy()), dtype=float)
            else:
                self.nfev += 1
                raw = np.asarray(self.p.cost(x0.copy()), dtype=float)
        except (IndexError, ValueError, TypeError) as exc:
            raise OptinavError(
                f"evaluating {what} at x0 failed ({type(exc).__name__}: {exc})",
                f"check that x0 has the {self.n} parameter(s) the {what} function expects",
            ) from None
        if self.lsq:
            if raw.ndim != 1 or raw.size == 0:
                raise OptinavError(
                    f"residuals(x0) has shape {raw.shape}, expected (m,)", "return a 1-D vector of residuals"
                )
            if not np.all(np.isfinite(raw)):
                bad = int(np.count_nonzero(~np.isfinite(raw)))
                raise OptinavError(
                    f"residuals at x0 contain {bad} NaN/infinite value(s)", "start from a valid x0 or fix the data"
                )
            self.m = raw.size
            return raw, float(raw @ raw)
        if raw.size != 1 or not np.isfinite(raw).all():
            raise OptinavError(f"cost(x0) is {raw!r}, not a finite scalar", "start from a valid x0")
        return None, float(raw.reshape(()))

    # ------------------------------------------------------------------ derivatives
    def _steps(self, x, rel):
        h = rel * np.maximum(np.abs(x), self.scale)
        return (x + h) - x  # exactly representable steps

    def _fd_points(self, x, scheme):
        """Perturbed points and the coefficients combining their values into derivatives."""
        n = self.n
        if scheme == "2-point":
            h = self._steps(x, np.sqrt(_EPS))
            out = x + h > self.ub
            h = np.where(out, -h, h)
            return x + np.diag(h), h
        h = self._steps(x, _EPS ** (1 / 3))
        hp = np.where(x + h > self.ub, 0.0, h)  # one-sided near a bound
        hm = np.where(x - h < self.lb, 0.0, h)
        return np.vstack([x + np.diag(hp), x - np.diag(hm)]), (hp, hm, n)

    def jacobian(self, x, r=None, scheme: str = "2-point") -> np.ndarray:
        """∂r/∂x (m, n): analytic when the problem has one, else finite differences."""
        self.njev += 1
        x = np.asarray(x, dtype=float)
        if self.p.jacobian is not None:
            J = np.asarray(self.p.jacobian(x), dtype=float)
            if not self._checked_jac:
                self._checked_jac = True
                if J.shape != (self.m, self.n):
                    raise OptinavError(
                        f"jacobian returned shape {J.shape}, expected ({self.m}, {self.n})",
                        "return ∂r/∂x with one row per residual and one column per parameter",
                    )
            return J
        if scheme == "2-point":
            if r is None:
                r = self.residuals(x)
            X, h = self._fd_points(x, scheme)
            R = self.residuals_batch(X)
            return ((R - r) / h[:, None]).T
        X, (hp, hm, n) = self._fd_points(x, scheme)
        R = self.residuals_batch(X)
        if np.any(hp == 0) or np.any(hm == 0):
            if r is None:
                r = self.residuals(x)
            Rp = np.where((hp == 0)[:, None], r, R[:n])
            Rm = np.where((hm == 0)[:, None], r, R[n:])
        else:
            Rp, Rm = R[:n], R[n:]
        return ((Rp - Rm) / (hp + hm)[:, None]).T

    def gradient(self, x, r=None, scheme: str = "2-point") -> tuple[np.ndarray, np.ndarray | None]:
        """(∇E, J or None). Least squares: ``2 Jᵀr``; scalar: analytic gradient or central differences."""
        x = np.asarray(x, dtype=float)
        if self.lsq:
            if r is None:
                r = self.residuals(x)
            J = self.jacobian(x, r, scheme)
            return 2.0 * J.T @ r, J
        self.njev += 1
        if self.p.gradient is not None:
            return np.asarray(self.p.gradient(x), dtype=float).reshape(self.n), None
        X, (hp, hm, n) = self._fd_points(x, "3-point")
        c = self.cost_batch(X)
        if np.any(hp == 0) or np.any(hm == 0):
            c0 = self.cost(x)
            cp = np.where(hp == 0, c0, c[:n])
            cm = np.where(hm == 0, c0, c[n:])
        else:
            cp, cm = c[:n], c[n:]
        return (cp - cm) / (hp + hm), None

    def has_analytic_gradient(self) -> bool:
        return self.p.jacobian is not None if self.lsq else self.p.gradient is not None

    def hessian(self, x, scheme: str = "3-point") -> tuple[np.ndarray, str]:
        """∇²E and how it was obtained.

        Exact if the problem has ``hessian``; else central differences of the analytic gradient
        (``2Jᵀr`` with the analytic Jacobian, or ``gradient``), step ``ε^(1/3)·max(|x|, s)``; else second
        differences of the cost, step ``ε^(1/4)·max(|x|, s)`` (2n² cost evaluations, batched).
        Within one step of a bound the stencil's centre is moved inside so that no point leaves the bounds.
        """
        x = np.asarray(x, dtype=float)
        n = self.n
        if self.p.hessian is not None:
            H = np.asarray(self.p.hessian(x), dtype=float)
            if H.shape != (n, n):
                raise OptinavError(f"hessian returned shape {H.shape}, expected ({n}, {n})", "return ∇²E")
            return H, "exact"
        if self.has_analytic_gradient():
            h = self._steps(x, _EPS ** (1 / 3))
            x = self._inside(x, h)
            H = np.empty((n, n))
            for j in range(n):
                e = np.zeros(n)
                e[j] = h[j]
                gp, _ = self.gradient(x + e)
                gm, _ = self.gradient(x - e)
                H[:, j] = (gp - gm) / (2 * h[j])
            return 0.5 * (H + H.T), "central differences of the analytic gradient"
        h = self._steps(x, _EPS**0.25)
        x = self._inside(x, h)
        iu, ju = np.triu_indices(n, 1)
        E = np.eye(n) * h
        pts = [x + E, x - E]
        if iu.size:
            a, b = E[iu], E[ju]
            pts += [x + a + b, x + a - b, x - a + b, x - a - b]
        c = self.cost_batch(np.vstack(pts))
        c0 = self.cost(x)
        H = np.diag((c[:n] - 2 * c0 + c[n : 2 * n]) / h**2)
        if iu.size:
            k = iu.size
            q = c[2 * n :].reshape(4, k)
            H[iu, ju] = H[ju, iu] = (q[0] - q[1] - q[2] + q[3]) / (4 * h[iu] * h[ju])
        return H, "second differences of the cost"

    def _inside(self, x, h):
        room = (self.ub - self.lb) > 2 * h
        return np.where(room, np.clip(x, self.lb + h, self.ub - h), x)

    def clip(self, x) -> np.ndarray:
        return np.minimum(np.maximum(x, self.lb), self.ub)
