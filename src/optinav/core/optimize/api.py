"""``minimize(problem, method, **options)``: one entry point for every optimizer."""

from __future__ import annotations

import dataclasses
import inspect
import time

import numpy as np

from optinav.core.validate import as_rng
from optinav.errors import OptinavError

from . import ga, local, pso
from .problem import Evaluator, OptimizeResult, Problem

METHODS = ("lm", "trf", "gauss-newton", "newton", "bfgs", "pso", "ga")

_RUNNERS = {
    "lm": local.run_least_squares,
    "trf": local.run_least_squares,
    "gauss-newton": local.run_gauss_newton,
    "newton": local.run_newton,
    "bfgs": local.run_bfgs,
    "pso": pso.run_pso,
    "ga": ga.run_ga,
}


def method_options(method: str) -> dict:
    """The options ``method`` takes and their defaults.

    Parameters
    ----------
    method : str
        A method of :func:`minimize`.

    Returns
    -------
    dict
        Option name → default.
    """
    if method not in _RUNNERS:
        raise OptinavError(f"unknown optimization method {method!r}", f"use one of {', '.join(METHODS)}")
    sig = inspect.signature(_RUNNERS[method])
    return {k: p.default for k, p in sig.parameters.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}


def minimize(
    problem: Problem, method: str = "trf", *, rng=None, final_jacobian: bool = True, **options
) -> OptimizeResult:
    """Minimize ``problem``'s cost (``E = Σ r²`` for least squares) with ``method``.

    Methods (options in parentheses; see :func:`method_options`):

    * ``"lm"`` / ``"trf"`` — Levenberg–Marquardt (MINPACK) / trust-region reflective via
      ``scipy.optimize.least_squares`` (ftol, xtol, gtol, max_nfev, jac); 'trf' takes bounds.
    * ``"gauss-newton"`` — own Gauss–Newton with step halving (max_iter, xtol, ftol, jac, max_halvings, rcond).
    * ``"newton"`` — plain Newton on E, optional ``damping`` (max_iter, xtol, gtol, damping, jac, max_halvings).
    * ``"bfgs"`` — ``scipy.optimize.minimize(method='BFGS')`` (gtol, xrtol, max_iter, jac); no bounds.
    * ``"pso"`` — particle swarm (n_particles, generations, w, c1, c2, v_max, v_min, ftol, stall_generations).
    * ``"ga"`` — adaptive real-coded GA (population, generations, k1..k4, selection_fraction, mutation,
      mutation_shape, pm_min, ftol, stall_generations, operators "optinav" or "paper").

    Parameters
    ----------
    problem : Problem
        Cost or residuals, start, bounds, optional Jacobian.
    method : str
        One of the methods above.
    rng : int, Generator or None
        Drives PSO/GA: the same seed gives the same result.
    final_jacobian : bool
        For least-squares problems, make sure ``result.jacobian`` holds ∂r/∂x at the solution (one more Jacobian
        evaluation for methods that do not produce it).
    **options
        The method's options; ``jac`` selects the finite-difference scheme ('2-point' or '3-point') used when
        the problem has no analytic Jacobian.

    Returns
    -------
    OptimizeResult
        Solution x [parameter units], cost, convergence and trace.
    """
    if not isinstance(problem, Problem):
        raise OptinavError(
            f"minimize needs a Problem, got {type(problem).__name__}",
            "wrap the objective in optinav.core.optimize.Problem(...)",
        )
    if not isinstance(method, str) or method.lower() not in _RUNNERS:
        raise OptinavError(f"unknown optimization method {method!r}", f"use one of {', '.join(METHODS)}")
    method = method.lower()
    problem = dataclasses.replace(problem)  # re-validate: fields may have been changed since construction
    defaults = method_options(method)
    unknown = sorted(set(options) - set(defaults))
    if unknown:
        raise OptinavError(
            f"method {method!r} has no option(s) {', '.join(unknown)}",
            f"its options are {', '.join(defaults) or 'none'}",
        )
    used = {**defaults, **options}
    gen = as_rng(rng)

    t0 = time.perf_counter()
    ev = Evaluator(problem)
    x0 = problem.x0.copy()
    r0, E0 = ev.start(x0)
    runner = _RUNNERS[method]
    if method in ("lm", "trf"):
        out = runner(ev, problem, x0, r0, method, **options)
    elif method == "gauss-newton":
        out = runner(ev, problem, x0, r0, **options)
    elif method in ("newton", "bfgs"):
        out = runner(ev, problem, x0, r0, E0, **options)
    else:
        out = runner(ev, problem, gen, **options)
    x = np.asarray(out["x"], dtype=float)
    if ev.lsq and final_jacobian and out.get("jacobian") is None and np.isfinite(out["cost"]):
        scheme = options.get("jac", "2-point")
        r = out.get("residuals")
        if r is None:
            r = ev.residuals(x)
            out["residuals"] = r
        out["jacobian"] = ev.jacobian(x, r, scheme)
    elapsed = time.perf_counter() - t0
    shortfall = None
    if method in ("pso", "ga") and ev.lsq and np.isfinite(out["cost"]):
        shortfall = _shortfall(problem, x, float(out["cost"]))
    return OptimizeResult(
        x=x,
        cost=float(out["cost"]),
        success=bool(out["success"]),
        message=str(out["message"]),
        method=method,
        nit=int(out["nit"]),
        nfev=int(ev.nfev),
        njev=int(ev.njev),
        history=np.asarray(out["history"], dtype=float),
        elapsed=elapsed,
        jacobian=out.get("jacobian"),
        residuals=out.get("residuals"),
        names=problem.param_names,
        trace=out.get("trace", {}),
        options={k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in used.items()},
        shortfall=shortfall,
    )


def _shortfall(problem: Problem, x: np.ndarray, cost: float) -> np.ndarray | None:
    """The step from a population search's best ``x`` to the least-squares minimum that Levenberg–Marquardt
    ('trf' within bounds) started at ``x`` finds on the same problem; zeros where it finds no lower cost, None
    where it fails. A search that ran out of generations stops short by an amount its own spread does not show
    (PSO at its defaults 1.7 std on imucal's session); its evaluations are not counted in ``nfev``/``elapsed``."""
    p = dataclasses.replace(problem, x0=x)
    ev = Evaluator(p)
    try:
        r0, _ = ev.start(x)
        out = local.run_least_squares(ev, p, x.copy(), r0, "trf" if p.has_bounds() or ev.m < ev.n else "lm")
    except (OptinavError, ValueError, np.linalg.LinAlgError):
        return None
    if not np.isfinite(out["cost"]) or not np.all(np.isfinite(out["x"])):
        return None
    return np.asarray(out["x"], float) - x if out["cost"] < cost else np.zeros_like(x)


def shortfall_note(shortfall, std, names) -> str:
    """The words for a population search's :attr:`~OptimizeResult.shortfall` against the std it is added to:
    the parameter it is largest on, in that std.

    Parameters
    ----------
    shortfall, std : (n,) array_like
        The shortfall and the std without it [parameter units].
    names : list of str
        The parameters' names.

    Returns
    -------
    str
        E.g. "stopped 2.1 std short of its objective's minimum on K_zz (added to the std)".
    """
    z = np.abs(np.asarray(shortfall, float)) / np.asarray(std, float)
    z = np.where(np.isfinite(z), z, 0.0)
    k = int(np.argmax(z))
    return f"stopped {z[k]:.2g} std short of its objective's minimum on {names[k]} (added to the std)"
