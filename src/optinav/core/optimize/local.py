"""Local methods: Levenberg–Marquardt / trust region (scipy), Gauss–Newton, Newton, BFGS (scipy).

Each ``run_*`` takes the :class:`Evaluator`, the start point, and its keyword options, and returns a dict
of :class:`OptimizeResult` fields (``x, cost, success, message, nit, history`` …). Costs are
``E = Σ r²`` for least-squares problems.
"""

from __future__ import annotations

import numpy as np

from optinav.errors import OptinavError

from .problem import Evaluator, Problem

_EPS = np.finfo(float).eps


def _need_lsq(ev: Evaluator, method: str) -> None:
    if not ev.lsq:
        raise OptinavError(
            f"method {method!r} needs a least-squares problem (residuals)",
            "use 'newton', 'bfgs', 'pso' or 'ga' for a scalar cost",
        )


def _check_scheme(jac: str) -> str:
    if jac not in ("2-point", "3-point"):
        raise OptinavError(f"jac={jac!r} is not a finite-difference scheme", "use '2-point' or '3-point'")
    return jac


def _xnorm(ev: Evaluator, v) -> float:
    return float(np.linalg.norm(v / ev.scale))


def run_least_squares(
    ev: Evaluator,
    problem: Problem,
    x0,
    r0,
    method: str,
    *,
    ftol: float = 1e-10,
    xtol: float = 1e-10,
    gtol: float = 1e-10,
    max_nfev: int | None = None,
    jac: str = "2-point",
) -> dict:
    """``scipy.optimize.least_squares`` with method 'lm' (MINPACK) or 'trf'.

    A Jacobian evaluation marks an iteration (both methods compute one per accepted step), so the cost
    history is recorded there; finite-difference Jacobians are computed here (``jac`` scheme), so that
    MINPACK's 'lm' also goes through the counting wrapper.
    """
    _need_lsq(ev, method)
    _check_scheme(jac)
    if method == "lm":
        if problem.has_bounds():
            raise OptinavError("method 'lm' does not take bounds", "use method='trf' (or remove the bounds)")
        if ev.m < ev.n:
            raise OptinavError(
                f"method 'lm' needs at least as many residuals as parameters ({ev.m} < {ev.n})",
                "use method='trf' or add observations",
            )
    last = {"x": x0.copy(), "r": r0}
    jac_at = {"x": None, "J": None}
    history: list[float] = []

    def fun(x):
        r = ev.residuals(x)
        last["x"], last["r"] = x.copy(), r
        return r

    def jacobian(x):
        r = last["r"] if np.array_equal(x, last["x"]) else ev.residuals(x)
        E = float(r @ r)
        history.append(min(E, history[-1]) if history else E)
        J = ev.jacobian(x, r, jac)
        jac_at["x"], jac_at["J"] = x.copy(), J
        return J

    kw = dict(method=method, ftol=ftol, xtol=xtol, gtol=gtol, max_nfev=max_nfev)
    if problem.x_scale is not None:
        kw["x_scale"] = problem.x_scale
    if method == "trf":
        kw["bounds"] = (problem.lower, problem.upper)
    try:
        from scipy import optimize as _sp  # deferred: scipy costs a second at start-up

        res = _sp.least_squares(fun, x0, jac=jacobian, **kw)
    except ValueError as exc:  # scipy's own argument checks (e.g. tolerances)
        raise OptinavError(f"least_squares rejected the options ({exc})", "check the tolerances") from None
    x = res.x
    r = res.fun
    E = float(r @ r)
    if not history or E < history[-1]:
        history.append(min(E, history[-1]) if history else E)
    J = jac_at["J"] if np.array_equal(jac_at["x"], x) else ev.jacobian(x, r, jac)
    return dict(
        x=x,
        cost=E,
        success=bool(res.status > 0),
        message=str(res.message),
        nit=len(history) - 1,
        history=np.asarray(history),
        jacobian=J,
        residuals=r,
    )


def run_gauss_newton(
    ev: Evaluator,
    problem: Problem,
    x0,
    r0,
    *,
    max_iter: int = 100,
    xtol: float = 1e-10,
    ftol: float = 1e-14,
    jac: str = "2-point",
    max_halvings: int = 30,
    rcond: float | None = None,
) -> dict:
    """Gauss–Newton: ``J p = −r`` in the least-squares sense (SVD), step halving until ``E`` does not increase.

    Stops when ``‖Δx/s‖ ≤ xtol (xtol + ‖x/s‖)`` or ``E_k − E_{k+1} ≤ ftol·E_k``. A rank-deficient ``J``
    (singular value ≤ ``rcond``·σ_max, default ``max(m, n)·ε``) stops with ``success=False`` and names
    the unobservable direction. Bounds are handled by projecting each trial point onto the box.
    """
    _need_lsq(ev, "gauss-newton")
    _check_scheme(jac)
    names = problem.param_names
    x, r = x0.copy(), r0
    E = float(r @ r)
    history = [E]
    success, message = False, f"maximum number of iterations ({max_iter}) reached"
    nit = 0
    for nit in range(1, max_iter + 1):
        J = ev.jacobian(x, r, jac)
        if not np.all(np.isfinite(J)):
            message = f"the Jacobian is not finite at iteration {nit}"
            break
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        tol = (rcond if rcond is not None else max(J.shape) * _EPS) * (s[0] if s.size else 0.0)
        rank = int(np.count_nonzero(s > tol))
        if rank < ev.n:
            null = Vt[-1] if s.size == ev.n else _null_vector(J)
            top = np.argsort(-np.abs(null))[:3]
            combo = " ".join(f"{null[i]:+.2f}·{names[i]}" for i in top if abs(null[i]) > 1e-3)
            message = (
                f"Jacobian is rank-deficient (rank {rank} < {ev.n} parameters) at iteration {nit}: "
                f"the direction {combo} is not observable from these residuals"
            )
            break
        p = -Vt.T @ ((U.T @ r) / s)
        small_step = _xnorm(ev, p) <= xtol * (xtol + _xnorm(ev, x))
        alpha, accepted = 1.0, False
        for _ in range(max_halvings + 1):
            xn = ev.clip(x + alpha * p)
            rn = ev.residuals(xn)
            En = float(rn @ rn)
            if np.isfinite(En) and En <= E:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            success = small_step
            message = (
                "converged: relative step below xtol"
                if small_step
                else f"no decrease along the Gauss–Newton step after {max_halvings} halvings"
            )
            break
        step = xn - x
        dE = E - En
        x, r, E = xn, rn, En
        history.append(E)
        if _xnorm(ev, step) <= xtol * (xtol + _xnorm(ev, x)):
            success, message = True, "converged: relative step below xtol"
            break
        if dE <= ftol * history[-2]:
            success, message = True, "converged: relative cost change below ftol"
            break
    # J belongs to the point before the last step; minimize() evaluates it at the solution
    return dict(x=x, cost=E, success=success, message=message, nit=nit, history=np.asarray(history), residuals=r)


def _null_vector(J):
    _, _, Vt = np.linalg.svd(J, full_matrices=True)
    return Vt[-1]


def run_newton(
    ev: Evaluator,
    problem: Problem,
    x0,
    r0,
    E0,
    *,
    max_iter: int = 100,
    xtol: float = 1e-10,
    gtol: float = 0.0,
    damping: bool = False,
    jac: str = "2-point",
    max_halvings: int = 30,
) -> dict:
    """Newton's method on the cost: ``x ← x − H⁻¹∇E`` (Frosio et al. 2009 baseline).

    ``∇E = 2Jᵀr`` (least squares) or the problem's gradient; ``H`` exact when the problem gives
    ``hessian``, else central differences of the analytic gradient, else second differences of the cost
    (:meth:`Evaluator.hessian`). The plain step is taken as is — the cost may increase and the iteration
    may diverge or stop at a saddle. ``damping=True`` adds backtracking (Armijo) along the Newton direction
    and stops if that direction is not a descent direction; it never turns the step into Levenberg–Marquardt.
    Stops on ``‖Δx/s‖ ≤ xtol (xtol + ‖x/s‖)`` or ``‖∇E‖ ≤ gtol``; bounds by projection. ``x`` is the best
    iterate; success also requires a positive-definite Hessian at the end.
    """
    _check_scheme(jac)
    x = x0.copy()
    r = r0
    E = E0
    best = (E, x.copy(), r)
    history = [E]
    success, message = False, f"maximum number of iterations ({max_iter}) reached"
    H = None
    how = ""
    nit = 0
    for nit in range(1, max_iter + 1):
        g, _ = ev.gradient(x, r, jac)
        if gtol > 0 and np.linalg.norm(g) <= gtol:
            success, message = True, "converged: gradient norm below gtol"
            nit -= 1
            break
        H, how = ev.hessian(x)
        if not np.all(np.isfinite(H)) or not np.all(np.isfinite(g)):
            message = f"non-finite gradient or Hessian at iteration {nit}"
            break
        try:
            cond = np.linalg.cond(H)
            if not np.isfinite(cond) or cond > 1 / (ev.n * _EPS):
                raise np.linalg.LinAlgError
            p = -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            message = f"Hessian ({how}) is singular at iteration {nit}: Newton's step is undefined"
            break
        alpha = 1.0
        if damping:
            slope = float(g @ p)
            if slope >= 0:
                message = (
                    f"Hessian ({how}) is not positive definite at iteration {nit}: the Newton "
                    f"direction does not descend"
                )
                break
            for _ in range(max_halvings + 1):
                xn = ev.clip(x + alpha * p)
                rn, En = _eval(ev, xn)
                if np.isfinite(En) and En <= E + 1e-4 * alpha * slope:
                    break
                alpha *= 0.5
            else:
                if _xnorm(ev, p) <= xtol * (xtol + _xnorm(ev, x)):
                    success, message = True, "converged: relative step below xtol"
                else:
                    message = f"no sufficient decrease along the Newton direction after {max_halvings} halvings"
                break
        else:
            xn = ev.clip(x + p)
            rn, En = _eval(ev, xn)
        if not np.isfinite(En):
            message = f"the Newton step led to a non-finite cost at iteration {nit}"
            break
        step = xn - x
        x, r, E = xn, rn, En
        if E < best[0]:
            best = (E, x.copy(), r)
        history.append(best[0])
        if _xnorm(ev, step) <= xtol * (xtol + _xnorm(ev, x)):
            success, message = True, "converged: relative step below xtol"
            break
    if success and H is not None:
        lam = np.linalg.eigvalsh(0.5 * (H + H.T))
        if lam[0] <= 0:
            success = False
            message = (
                f"stopped at a stationary point that is not a minimum (Hessian eigenvalue {lam[0]:.3g}); "
                f"x is the best iterate found"
            )
    E, x, r = best
    return dict(x=x, cost=E, success=success, message=message, nit=nit, history=np.asarray(history), residuals=r)


def _eval(ev: Evaluator, x):
    if ev.lsq:
        r = ev.residuals(x)
        return r, float(r @ r)
    return None, ev.cost(x)


def run_bfgs(
    ev: Evaluator,
    problem: Problem,
    x0,
    r0,
    E0,
    *,
    gtol: float = 1e-10,
    xrtol: float = 0.0,
    max_iter: int | None = None,
    jac: str = "2-point",
) -> dict:
    """BFGS via ``scipy.optimize.minimize(method='BFGS')``, gradient ``2Jᵀr`` (analytic or finite-difference
    Jacobian) or the problem's gradient (else central differences of the cost). No bounds."""
    _check_scheme(jac)
    if problem.has_bounds():
        raise OptinavError(
            "method 'bfgs' does not take bounds",
            "use 'trf', 'gauss-newton', 'newton', 'pso' or 'ga' (or remove the bounds)",
        )
    history = [E0]
    first = {"x": x0.copy(), "r": r0}

    def fg(x):
        if first["x"] is not None and np.array_equal(x, first["x"]):
            r = first["r"]
            first["x"] = None
            E = E0
        else:
            r, E = _eval(ev, x)
        if not np.isfinite(E):
            return np.inf, np.full(ev.n, np.nan)
        g, _ = ev.gradient(x, r, jac)
        return E, g

    def callback(intermediate_result):
        history.append(min(float(intermediate_result.fun), history[-1]))

    opts = {"gtol": gtol, "xrtol": xrtol}
    if max_iter is not None:
        opts["maxiter"] = max_iter
    from scipy import optimize as _sp  # deferred, see above

    res = _sp.minimize(fg, x0, jac=True, method="BFGS", callback=callback, options=opts)
    x = res.x
    r, E = _eval(ev, x)
    success = bool(res.success)
    message = str(res.message)
    if not success and "precision loss" in message and np.isfinite(E):
        # The line search could not decrease E (gtol below the gradient's rounding/finite-difference
        # level). Accept x only if no point ±ε^(1/3)·max(|x|, s) along any coordinate is lower.
        h = _EPS ** (1 / 3) * np.maximum(np.abs(x), ev.scale)
        probe = ev.clip(np.vstack([x + np.diag(h), x - np.diag(h)]))
        if np.all(ev.cost_batch(probe) >= E):
            success = True
            message = (
                "converged to working precision: the line search cannot decrease the cost and no "
                "lower point lies one step ε^(1/3)·max(|x|, x_scale) away along any parameter"
            )
    if E < history[-1]:
        history.append(E)
    return dict(
        x=x, cost=E, success=success, message=message, nit=int(res.nit), history=np.asarray(history), residuals=r
    )
