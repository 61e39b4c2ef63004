"""All optimizers side by side on a 9-parameter accelerometer norm-observation calibration.

Problem (built inline, Frosio et al. 2009 / Gao & Zhang 2019 style): a static accelerometer reads
``y_k = K a_k + b`` with ``‖a_k‖ = g`` in 18 orientations; ``K`` lower-triangular (3 scale factors,
3 non-orthogonality terms), ``b`` the bias. Residual ``r_k = ‖K⁻¹(y_k − b)‖ − g``; the data are noise-free, so
the least-squares optimum is the truth and the parameter error measures the optimizer alone.
Local methods start at the nominal ``K = I, b = 0`` with the analytic Jacobian; PSO/GA search the box
scale ∈ [0.95, 1.05], misalignment ∈ [−0.01, 0.01], bias ∈ [−0.2, 0.2] m/s² (PSO velocity clamp
0.2× the box width). Rows per method: wall time to solution (median of repeats; PSO/GA: median over
seeds), residual evaluations per second, evaluations, final cost, max scale/misalignment and bias errors.
"""

from __future__ import annotations


import numpy as np

from optinav.core.optimize import Problem, minimize

G = 9.80665
_TRI = ((0, 0), (1, 1), (2, 2), (1, 0), (2, 0), (2, 1))  # K entries carried by x[0:6]


def _k_batch(X):
    K = np.zeros((X.shape[0], 3, 3))
    for j, (a, b) in enumerate(_TRI):
        K[:, a, b] = X[:, j]
    return K


def make_problem(n_orient: int = 18, seed: int = 0):
    rng = np.random.default_rng(seed)
    # orientations spread over the sphere (Fibonacci lattice, randomly rotated)
    i = np.arange(n_orient) + 0.5
    phi = np.arccos(1 - 2 * i / n_orient)
    th = np.pi * (1 + 5**0.5) * i
    u = np.column_stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    a = G * u @ q.T
    truth = np.array([1.012, 0.991, 1.006, 2.0e-3, -1.5e-3, 0.8e-3, 0.08, -0.05, 0.12])
    y = a @ _k_batch(truth[None])[0].T + truth[6:]

    def res_batch(X):
        X = np.atleast_2d(X)
        d = y[None, :, :] - X[:, None, 6:]
        uu = np.linalg.solve(_k_batch(X)[:, None], d[..., None])[..., 0]
        return np.linalg.norm(uu, axis=-1) - G

    def res(x):
        return res_batch(x)[0]

    def jac(x):
        K = _k_batch(np.atleast_2d(x))[0]
        Ki = np.linalg.inv(K)
        uu = (y - x[6:]) @ Ki.T
        w = (uu / np.linalg.norm(uu, axis=1, keepdims=True)) @ Ki  # rows: Kᵀ⁻¹ u/‖u‖
        J = np.empty((y.shape[0], 9))
        for j, (r, c) in enumerate(_TRI):
            J[:, j] = -w[:, r] * uu[:, c]
        J[:, 6:] = -w
        return J

    lo = np.array([0.95] * 3 + [-0.01] * 3 + [-0.2] * 3)
    hi = np.array([1.05] * 3 + [0.01] * 3 + [0.2] * 3)
    names = ["kxx", "kyy", "kzz", "kyx", "kzx", "kzy", "bx", "by", "bz"]
    pr = Problem(
        res,
        np.r_[1.0, 1.0, 1.0, 0, 0, 0, 0, 0, 0],
        jacobian=jac,
        residuals_batch=res_batch,
        search_interval=(lo, hi),
        names=names,
    )
    return pr, truth, hi - lo


def run(quick: bool) -> list[dict]:
    pr, truth, width = make_problem()
    group = "optimize accel-norm 9 params, 18 orientations"
    repeats = 3 if quick else 7
    seeds = 3 if quick else 10
    configs = [
        ("lm", {}),
        ("trf", {}),
        ("gauss-newton", {}),
        ("newton", {}),
        ("bfgs", {}),
        ("pso", dict(v_max=0.2 * width)),
        ("ga", {}),
    ]
    rows = []

    def row(method, metric, value, unit):
        rows.append({"group": group, "method": method, "metric": metric, "value": float(value), "unit": unit})

    for method, opts in configs:
        runs = []
        n_runs = seeds if method in ("pso", "ga") else repeats
        for k in range(n_runs):
            # the method's own time: GA/PSO's shortfall (a local search after them) is not counted in it
            r = minimize(pr, method, rng=k, **opts)
            runs.append((r.elapsed, r))
        order = np.argsort([t for t, _ in runs])
        t_med, r_med = runs[order[len(order) // 2]]
        err = np.array([np.abs(r.x - truth) for _, r in runs])
        row(method, "time to solution", t_med, "s")
        row(method, "evaluations per second", r_med.nfev / t_med, "1/s")
        row(method, "residual evaluations", r_med.nfev, "")
        row(method, "final cost (median)", np.median([r.cost for _, r in runs]), "(m/s^2)^2")
        row(method, "max scale/misalignment error", err[:, :6].max(), "")
        row(method, "max bias error", err[:, 6:].max(), "m/s^2")
        row(method, "success rate", np.mean([r.success for _, r in runs]), "")
        if method in ("pso", "ga"):
            # how far from the minimum of its own objective the search ended (a local search from its best)
            short = np.array([np.abs(r.shortfall) for _, r in runs])
            row(method, "max scale/misalignment shortfall", short[:, :6].max(), "")
            row(method, "max bias shortfall", short[:, 6:].max(), "m/s^2")
    return rows


if __name__ == "__main__":
    for r in run(quick=True):
        print(f"{r['method']:<13} {r['metric']:<30} {r['value']:>12.4g} {r['unit']}")
