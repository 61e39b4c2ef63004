"""Optimizers behind one interface: ``minimize(Problem(...), method=..., **options, rng=None)``.

Every calibration/attitude problem in optinav is an objective solved here. Least-squares problems give
residuals ``r(x)`` and use the cost ``E(x) = Σ r²`` (no ½); scalar problems give ``cost(x)``.
Methods: ``"lm"``, ``"trf"`` (scipy ``least_squares``), ``"gauss-newton"``, ``"newton"`` (Frosio et al.
2009 baseline), ``"bfgs"`` (scipy), ``"pso"`` (rotational-INS paper), ``"ga"`` (Gao & Zhang 2019 adaptive
GA with Srinivas–Patnaik probabilities; fitness 1/E). Results are :class:`OptimizeResult`
(schema ``optinav.optimize_result``) with the per-iteration best cost in ``history``.
"""

from .api import METHODS, method_options, minimize, shortfall_note
from .ga import adaptive_probability, fitness
from .problem import OptimizeResult, Problem
from .pso import pso_velocity

__all__ = [
    "METHODS",
    "OptimizeResult",
    "Problem",
    "adaptive_probability",
    "fitness",
    "method_options",
    "minimize",
    "pso_velocity",
    "shortfall_note",
]
