"""Monte Carlo of the norm-observation fit on noisy pose means, shared by the pose-design tests."""

import numpy as np

from optinav.core.optimize import Problem, minimize
from optinav.multipos import model


def norm_fit_errors(clean, sigma_mean, truth, g, n_runs, seed) -> np.ndarray:
    """(n_runs, 9) errors θ̂ − θ of LM fits of ``clean`` pose means (P, 3) with white noise ``sigma_mean`` added
    (seeded); every fit must converge."""
    rng = np.random.default_rng(seed)
    errs = []
    for _ in range(n_runs):
        means = clean + rng.normal(0.0, sigma_mean, clean.shape)
        res = minimize(
            Problem(
                residuals=lambda th: model.norm_residuals(th, means, g),
                jacobian=lambda th: model.norm_jacobian(th, means),
                x0=np.r_[1.0, 1.0, 1.0, 0, 0, 0, 0, 0, 0],
            ),
            "lm",
        )
        assert res.success
        errs.append(res.x - truth)
    return np.array(errs)
