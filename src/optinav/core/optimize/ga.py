"""Real-coded adaptive genetic algorithm (Gao & Zhang 2019, MEMS accelerometer norm-observation calibration).

Fitness ``f = 1/E`` (E = Σ r²). One generation:

1. **Selection** — uniform ranking (Bäck's (μ, λ) uniform ranking): the best ``μ = ⌈selection_fraction·M⌉``
   individuals are each picked with probability 1/μ (with replacement), the rest never; M parents are drawn
   and paired in order.
2. **Crossover** — with probability ``Pc`` a pair (a, b) becomes ``λa + (1−λ)b`` and ``(1−λ)a + λb``,
   λ ~ U(0, 1) per pair (arithmetic crossover); otherwise the parents are copied.
3. **Mutation** — each gene j of an offspring is mutated independently with probability ``Pm`` (the
   real-coded counterpart of Srinivas–Patnaik's per-bit rate) by Michalewicz's non-uniform mutation inside
   the search interval [lo_j, hi_j]: ``v + Δ(t, hi_j − v)`` or ``v − Δ(t, v − lo_j)`` (each side with
   probability ½), ``Δ(t, y) = y (1 − u^((1 − t/T)^b))``, u ~ U(0, 1), t = generation − 1,
   T = generations, b = ``mutation_shape`` — large early, vanishing late (fine-tuning).
   ``mutation="uniform"`` re-draws the gene uniformly in [lo_j, hi_j] instead. ``Pm`` is floored at
   ``pm_min`` (default 0.005, our addition): the formulas give Pc = Pm = 0 to every copy of the best
   individual, and without a floor the population freezes within ~20 generations (measured on a 6-D
   smooth problem: errors 100× larger). ``pm_min=0`` gives the pure formulas.
4. **Elitism** — if no offspring beats the previous best individual, it replaces the worst offspring.

Adaptive probabilities, Srinivas & Patnaik (IEEE Trans. SMC 24(4), 1994):
``Pc = k1 (fmax − f′)/(fmax − favg)`` if ``f′ ≥ favg`` else ``k3``; ``Pm = k2 (fmax − f)/(fmax − favg)`` if
``f ≥ favg`` else ``k4``; k1 = k3 = 1, k2 = k4 = 0.5. ``f′`` is the larger fitness of the two parents,
``f`` the fitness of the offspring to be mutated (evaluated after crossover); fmax and favg are those of
the current population. Offspring fitter than fmax get 0. When ``fmax = favg`` (a population of identical
fitness) the formula is 0/0 and the below-average rates ``k3``/``k4`` are used, which re-diversifies a
collapsed population while elitism keeps its best member.

The population never leaves the search interval (convex crossover, in-interval mutation).

``operators="paper"`` uses the operators as Gao & Zhang describe them instead of steps 2–3: crossover
exchanges part of the chromosomes (with probability Pc a pair swaps the genes after a random cut point) and
mutation acts per individual (with probability Pm an offspring gets one gene, chosen at random, re-drawn
uniformly in its search interval); selection, the adaptive Pc/Pm, the fitness 1/E and elitism are shared.
"""

from __future__ import annotations

import math

import numpy as np

from optinav.core.progress import in_task, progress
from optinav.core.validate import check_positive
from optinav.errors import OptinavError

from .problem import Evaluator, Problem, finite_mean

_FMIN_COST = 1e-300  # E below this counts as 1e-300 so that 1/E and sums of it stay finite


def adaptive_probability(fit, fmax: float, favg: float, k_high: float, k_low: float) -> np.ndarray:
    """Srinivas–Patnaik rate: ``k_high (fmax − f)/(fmax − favg)`` if ``f ≥ favg`` else ``k_low``, in [0, 1].

    ``(k_high, k_low) = (k1, k3)`` with ``f = f′`` gives Pc; ``(k2, k4)`` with the individual's fitness gives Pm.
    ``fmax == favg`` → ``k_low`` (see the module docstring).

    Parameters
    ----------
    fit : float or array
        Fitness values f [1/cost].
    fmax, favg : float
        Largest and mean fitness of the population [1/cost].
    k_high, k_low : float
        Rates [-].

    Returns
    -------
    ndarray
        Probabilities [-].
    """
    f = np.asarray(fit, dtype=float)
    spread = fmax - favg
    if not spread > 0:
        return np.clip(np.full(f.shape, float(k_low)), 0.0, 1.0)
    p = np.where(f >= favg, k_high * (fmax - f) / spread, k_low)
    return np.clip(p, 0.0, 1.0)


def fitness(E) -> np.ndarray:
    """GA fitness ``1/E``; non-finite costs get 0.

    Parameters
    ----------
    E : array
        Costs [cost units].

    Returns
    -------
    ndarray
        Fitness [1/cost].
    """
    E = np.asarray(E, dtype=float)
    return np.where(np.isfinite(E), 1.0 / np.maximum(E, _FMIN_COST), 0.0)


def run_ga(
    ev: Evaluator,
    problem: Problem,
    rng: np.random.Generator,
    *,
    population: int = 50,
    generations: int = 200,
    k1: float = 1.0,
    k2: float = 0.5,
    k3: float = 1.0,
    k4: float = 0.5,
    selection_fraction: float = 0.5,
    mutation: str = "non-uniform",
    mutation_shape: float = 2.0,
    pm_min: float = 0.005,
    ftol: float | None = None,
    stall_generations: int = 20,
    operators: str = "optinav",
) -> dict:
    """Adaptive GA; ``ftol`` (off by default) stops once the best cost improved by less than ``ftol·E``
    over ``stall_generations`` generations. ``operators``: "optinav" (arithmetic crossover, per-gene
    non-uniform mutation) or "paper" (gene exchange, per-individual mutation; module docstring)."""
    n = ev.n
    M = int(population)
    G = int(generations)
    if M < 4 or G < 1:
        raise OptinavError(
            f"GA needs population >= 4 and generations >= 1 (got {M}, {G})",
            "increase the population or the number of generations",
        )
    if not 0 < selection_fraction <= 1:
        raise OptinavError(f"selection_fraction = {selection_fraction!r} must be in (0, 1]", "e.g. 0.5")
    if operators not in ("optinav", "paper"):
        raise OptinavError(f"operators={operators!r} is unknown", "use 'optinav' or 'paper'")
    if mutation not in ("non-uniform", "uniform"):
        raise OptinavError(f"mutation={mutation!r} is unknown", "use 'non-uniform' or 'uniform'")
    for name, val in (("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)):
        if not 0 <= val <= 1:
            raise OptinavError(f"{name} = {val!r} must be in [0, 1]", "Srinivas–Patnaik use k1 = k3 = 1, k2 = k4 = 0.5")
    check_positive(mutation_shape, "mutation_shape")
    if not 0 <= pm_min <= 1:
        raise OptinavError(f"pm_min = {pm_min!r} must be in [0, 1]", "e.g. 0.005, or 0 for the pure formulas")
    if ftol is not None:
        check_positive(ftol, "ftol")
    lo, hi = problem.population_interval()
    mu = max(2, math.ceil(selection_fraction * M))
    npairs = (M + 1) // 2

    P = lo + (hi - lo) * rng.random((M, n))
    E = ev.cost_batch(P)
    b = int(np.argmin(E))
    best_x, best_E = P[b].copy(), float(E[b])
    history = [best_E]
    mean_cost, best_xs = [finite_mean(E)], [best_x.copy()]
    message = f"completed {G} generations"
    g = 0
    for g in progress(range(1, G + 1), total=G, desc="GA generations", enabled=None if in_task() else False):
        fit = fitness(E)
        fmax, favg = float(fit.max()), float(fit.mean())
        order = np.argsort(E, kind="stable")
        pool = order[rng.integers(0, mu, size=2 * npairs)]
        a, bb = pool[0::2], pool[1::2]
        pc = adaptive_probability(np.maximum(fit[a], fit[bb]), fmax, favg, k1, k3)
        cross = rng.random(npairs) < pc
        A, B = P[a], P[bb]
        if operators == "paper":
            # gene exchange: the genes after a random cut point (1..n−1) swap between the parents
            swap = cross[:, None] & (np.arange(n)[None, :] >= rng.integers(1, max(n, 2), size=(npairs, 1)))
            C1, C2 = np.where(swap, B, A), np.where(swap, A, B)
        else:
            lam = rng.random((npairs, 1))
            C1 = np.where(cross[:, None], lam * A + (1 - lam) * B, A)
            C2 = np.where(cross[:, None], (1 - lam) * A + lam * B, B)
        kids = np.vstack([C1, C2])[:M]
        kidE = np.concatenate([E[a], E[bb]])[:M]
        # identical parents give identical children: nothing new to evaluate
        new = np.concatenate([cross, cross])[:M] & np.concatenate([np.any(A != B, axis=1)] * 2)[:M]
        if new.any():
            kidE[new] = ev.cost_batch(kids[new])

        pm = np.maximum(adaptive_probability(fitness(kidE), fmax, favg, k2, k4), pm_min)
        if operators == "paper":
            # per individual: with probability Pm one gene, chosen at random, is re-drawn in its interval
            mut = (rng.random(M) < pm)[:, None] & (np.arange(n)[None, :] == rng.integers(0, n, size=(M, 1)))
        else:
            mut = rng.random((M, n)) < pm[:, None]
        u = rng.random((M, n))
        up = rng.random((M, n)) < 0.5
        if mut.any():
            if mutation == "uniform" or operators == "paper":
                v = lo + (hi - lo) * u
            else:
                shrink = 1.0 - u ** ((1.0 - (g - 1) / G) ** mutation_shape)
                v = np.where(up, kids + shrink * (hi - kids), kids - shrink * (kids - lo))
            kids = np.where(mut, np.clip(v, lo, hi), kids)
            i = np.flatnonzero(mut.any(axis=1))
            kidE[i] = ev.cost_batch(kids[i])

        k = int(np.argmin(kidE))
        if kidE[k] < best_E:
            best_x, best_E = kids[k].copy(), float(kidE[k])
        else:
            w = int(np.argmax(kidE))
            kids[w], kidE[w] = best_x, best_E
        P, E = kids, kidE
        history.append(best_E)
        mean_cost.append(finite_mean(E))
        best_xs.append(best_x.copy())
        if ftol is not None and g >= stall_generations:
            old = history[-1 - stall_generations]
            if old - best_E <= ftol * old:
                message = (
                    f"stopped at generation {g}: best cost improved by less than ftol in "
                    f"{stall_generations} generations"
                )
                break
    success = bool(np.isfinite(best_E))
    if not success:
        message = "no individual had a finite cost"
    return dict(
        x=best_x,
        cost=best_E,
        success=success,
        message=message,
        nit=g,
        history=np.asarray(history),
        trace={"mean_cost": np.asarray(mean_cost), "best_x": np.asarray(best_xs)},
    )
