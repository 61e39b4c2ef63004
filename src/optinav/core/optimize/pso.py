"""Particle swarm optimization as used for the rotational-INS calibration (global-best PSO).

Per generation, with r1, r2 ~ U(0, 1) drawn per particle and per dimension::

    V ← ω V + c1 r1 (pbest − X) + c2 r2 (gbest − X),   V clamped to [Vmin, Vmax]
    X ← X + V,                                         X clamped to the bounds

Paper defaults: ω = 0.8, c1 = c2 = 2, V ∈ [−1, 1], N = 20 particles, G = 150 generations. The velocity
limits are in parameter units: for parameters of size ~1e-3 scale them to the search interval
(e.g. ``v_max = 0.2·(ub − lb)``), otherwise the swarm moves by whole intervals per step.
The initial swarm is uniform in the search interval, initial velocities uniform in [Vmin, Vmax].
The whole swarm is evaluated as one (N, n) array (``residuals_batch``/``cost_batch``).
"""

from __future__ import annotations

import numpy as np

from optinav.core.progress import in_task, progress
from optinav.core.validate import check_positive
from optinav.errors import OptinavError

from .problem import Evaluator, Problem, finite_mean


def pso_velocity(V, X, pbest, gbest, r1, r2, *, w: float, c1: float, c2: float, v_min, v_max) -> np.ndarray:
    """One velocity update ``clip(ωV + c1 r1 (pbest − X) + c2 r2 (gbest − X), Vmin, Vmax)``.

    Parameters
    ----------
    V, X : (N, n) array
        Velocities and positions of the particles [parameter units].
    pbest : (N, n) array
        Personal bests [parameter units].
    gbest : (n,) array
        Global best [parameter units].
    r1, r2 : (N, n) array
        Uniform random numbers in [0, 1) [-].
    w : float
        Inertia weight ω [-].
    c1, c2 : float
        Acceleration coefficients [-].
    v_min, v_max : float or (n,) array
        Velocity clamp [parameter units].

    Returns
    -------
    (N, n) ndarray
        New velocities [parameter units].
    """
    V = w * V + c1 * r1 * (pbest - X) + c2 * r2 * (gbest - X)
    return np.clip(V, v_min, v_max)


def _limits(v, n, name):
    a = np.asarray(v, dtype=float)
    if a.ndim > 1 or (a.ndim == 1 and a.size != n) or not np.all(np.isfinite(a)):
        raise OptinavError(f"{name} must be a finite scalar or {n} values", f"check {name}")
    return np.broadcast_to(a, (n,)).astype(float)


def run_pso(
    ev: Evaluator,
    problem: Problem,
    rng: np.random.Generator,
    *,
    n_particles: int = 20,
    generations: int = 150,
    w: float = 0.8,
    c1: float = 2.0,
    c2: float = 2.0,
    v_max=1.0,
    v_min=None,
    ftol: float | None = None,
    stall_generations: int = 20,
) -> dict:
    """Global-best PSO; ``ftol`` (off by default) stops once the best cost improved by less than
    ``ftol·E`` over ``stall_generations`` generations."""
    n = ev.n
    n_particles = int(n_particles)
    generations = int(generations)
    if n_particles < 2 or generations < 1:
        raise OptinavError(
            f"PSO needs n_particles >= 2 and generations >= 1 (got {n_particles}, {generations})",
            "increase the swarm or the number of generations",
        )
    vmax = _limits(v_max, n, "v_max")
    vmin = -vmax if v_min is None else _limits(v_min, n, "v_min")
    if np.any(vmin >= vmax):
        raise OptinavError("v_min must be below v_max in every dimension", "check the velocity clamp")
    for name, val in (("w", w), ("c1", c1), ("c2", c2)):
        if not np.isfinite(val) or val < 0:
            raise OptinavError(f"PSO coefficient {name} = {val!r} must be finite and >= 0", f"check {name}")
    if ftol is not None:
        check_positive(ftol, "ftol")
    lo, hi = problem.population_interval()
    X = lo + (hi - lo) * rng.random((n_particles, n))
    V = vmin + (vmax - vmin) * rng.random((n_particles, n))
    f = ev.cost_batch(X)
    pbest, pbest_f = X.copy(), f.copy()
    k = int(np.argmin(pbest_f))
    gbest, gbest_f = pbest[k].copy(), float(pbest_f[k])
    history = [gbest_f]
    mean_cost, best_xs = [finite_mean(f)], [gbest.copy()]
    message = f"completed {generations} generations"
    g = 0
    for g in progress(
        range(1, generations + 1), total=generations, desc="PSO generations", enabled=None if in_task() else False
    ):
        r1 = rng.random((n_particles, n))
        r2 = rng.random((n_particles, n))
        V = pso_velocity(V, X, pbest, gbest, r1, r2, w=w, c1=c1, c2=c2, v_min=vmin, v_max=vmax)
        X = ev.clip(X + V)
        f = ev.cost_batch(X)
        better = f < pbest_f
        pbest[better], pbest_f[better] = X[better], f[better]
        k = int(np.argmin(pbest_f))
        if pbest_f[k] < gbest_f:
            gbest, gbest_f = pbest[k].copy(), float(pbest_f[k])
        history.append(gbest_f)
        mean_cost.append(finite_mean(f))
        best_xs.append(gbest.copy())
        if ftol is not None and g >= stall_generations:
            old = history[-1 - stall_generations]
            if old - gbest_f <= ftol * old:
                message = (
                    f"stopped at generation {g}: best cost improved by less than ftol in "
                    f"{stall_generations} generations"
                )
                break
    success = bool(np.isfinite(gbest_f))
    if not success:
        message = "no particle had a finite cost"
    return dict(
        x=gbest,
        cost=gbest_f,
        success=success,
        message=message,
        nit=g,
        history=np.asarray(history),
        trace={"mean_cost": np.asarray(mean_cost), "best_x": np.asarray(best_xs)},
    )
