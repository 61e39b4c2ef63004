"""Monte Carlo check of the reported accelerometer uncertainty: RMS(error / reported std) per parameter group.

A reported std is honest when the errors it describes have RMS(error/std) ≈ 1 over many seeded runs (a 100-run
estimate of an RMS ratio of 1 has a 99 % band of about 0.8 … 1.25). Each run draws the pose means of a session
directly — mean of n white samples per pose, ``N(K·g·u_k + b_k, σ²/n)`` — so 100 runs take seconds, and fits
them with :func:`optinav.multipos.accel.fit_accel` as ``calibrate accel`` does. Configurations
(:data:`CONFIGS`) cover the models the CLI offers: full, diagonal with the misalignments held at 0 (drawn
with the 1σ given by ``--held-misalignment``), the six axis poses (auto → held) and a bias that drifts over the
session (an offset common to all poses with the 1σ given by ``--acc-bias-instability``: run-to-run or a drift
before the first pose, which no residual can reveal).
"""

from __future__ import annotations

import numpy as np

from optinav.core.validate import as_rng

from . import accel, model
from .simulate import SCHEMES

#: configurations: scheme, model, true misalignment 1σ (rad), common bias offset 1σ (m/s²); ``held_std`` (rad,
#: default the true 1σ) is the --held-misalignment given to the fit (0: the model error of held terms ignored)
CONFIGS = {
    "full, white noise": {"scheme": "18", "model": "full", "misalignment": 0.005, "drift": 0.0},
    "diagonal, misalignments held": {"scheme": "18", "model": "diagonal", "misalignment": 0.005, "drift": 0.0},
    "diagonal, held terms ignored (before)": {
        "scheme": "18",
        "model": "diagonal",
        "misalignment": 0.005,
        "drift": 0.0,
        "held_std": 0.0,
    },
    "six poses (auto: held)": {"scheme": "six", "model": "auto", "misalignment": 0.005, "drift": 0.0},
    "full, bias offset (instability)": {"scheme": "18", "model": "full", "misalignment": 0.005, "drift": 3e-3},
}
GROUPS = {"scale": [0, 1, 2], "misalignment": [3, 4, 5], "bias": [6, 7, 8]}
G = 9.80167
SIGMA = 120e-6 * 9.80665 * 10.0  # m/s² per sample: 120 µg/√Hz at 100 Hz (MTi-1 class)
N_PER_POSE = 1000


def run_config(config: dict, n_runs: int = 100, rng=0) -> dict[str, float]:
    """RMS(error/std) per group in :data:`GROUPS` (held parameters are left out) over ``n_runs`` seeded runs."""
    gen = as_rng(rng)
    ups = SCHEMES[config["scheme"]]
    ups = ups / np.linalg.norm(ups, axis=1, keepdims=True)
    P = len(ups)
    cov = np.tile(np.eye(3) * SIGMA**2, (P, 1, 1))
    z = {k: [] for k in GROUPS}
    for _ in range(int(n_runs)):
        k = 1.0 + gen.normal(0, 2e-3, 3)
        m = gen.normal(0, config["misalignment"], 3)
        K = np.array([[k[0], k[0] * m[0], k[0] * m[1]], [0, k[1], k[1] * m[2]], [0, 0, k[2]]])
        b = gen.normal(0, 0.1, 3)
        # a bias offset common to the whole session (run-to-run, or a drift before the first pose)
        drift = gen.normal(0, config["drift"], 3) if config["drift"] else np.zeros(3)
        means = np.array([K @ (G * u) for u in ups]) + b + drift + gen.normal(0, SIGMA / np.sqrt(N_PER_POSE), (P, 3))
        st = accel.PoseStatistics(means, cov, np.full(P, N_PER_POSE))
        fit = accel.fit_accel(
            st,
            G,
            model_form=config["model"],
            bias_instability=config["drift"] or None,
            held_misalignment=config.get("held_std", config["misalignment"]),
        )
        err = fit.theta - model.Kb_to_theta(K, b)
        for name, idx in GROUPS.items():
            ok = [i for i in idx if np.isfinite(fit.std[i])]
            z[name].extend(err[ok] / fit.std[ok])
    return {name: float(np.sqrt(np.mean(np.square(v)))) if v else float("nan") for name, v in z.items()}


def run_all(n_runs: int = 100, rng=0) -> dict[str, dict[str, float]]:
    """:func:`run_config` of every configuration in :data:`CONFIGS` with the same seed."""
    return {name: run_config(cfg, n_runs, rng) for name, cfg in CONFIGS.items()}


def _session_gyro_bias(s, unit, seed: int, drawn: bool, intervals=None) -> np.ndarray:
    """The unit's mean gyro bias over the static samples of simulated session ``s`` (raw): its constant bias plus
    the mean of its Gauss–Markov drift there — over the static intervals the calibration used (``intervals``,
    (t0, t1) s; what ``local`` reports the bias of), else over the simulated poses. The drift is redrawn from ``seed`` as
    :class:`~optinav.multipos.simulate.SessionStream` draws it (the unit first when ``drawn``, then the key of the
    per-sample draws, of which the Gauss–Markov bias takes its own stream)."""
    from optinav.core.imu_model import ImuModel, MeasurementStream, TriadNoise, draw_key

    gen = np.random.default_rng(seed)
    if drawn:
        unit = unit.draw(gen)
    n = s.t.size
    d = np.r_[np.diff(s.t), 1.0 / unit.rate_hz]
    nz = unit.gyro_noise
    drift_only = ImuModel(gyro_noise=TriadNoise(gm_sigma=nz.gm_sigma, gm_tau=nz.gm_tau), rate_hz=unit.rate_hz)
    drift = MeasurementStream(drift_only, draw_key(gen))(np.zeros((n, 3)), np.zeros((n, 3)), d)[0]
    rest = s.labels >= 0
    if intervals is not None:
        rest = np.zeros(n, bool)
        for t0, t1 in np.asarray(intervals, float):
            rest |= (s.t >= t0) & (s.t <= t1)
    fg = float(np.mean(np.diag(s.gyr_K))) / float(np.mean(np.diag(unit.gyr.K)))
    return s.gyr_b + drift[rest].mean(0) * fg


#: gyro g-sensitivity 1σ per element (rad/s per m/s², ≈ 0.1 °/s/g) of :func:`gyro_g_sensitivity_study`
GYRO_G_SENSITIVITY = 1.8e-4


def gyro_g_sensitivity_study(n_runs: int = 30, rng=0, only=None) -> dict[str, dict[str, float]]:
    """RMS(error/std) of the gyro bias and K when the unit has a g-sensitivity the model leaves out, without
    and with ``--gyro-g-sensitivity`` (the true 1σ): full simulated sessions (18 poses, 8 s dwell, counts). The
    bias error is against the session's bias at zero specific force (:func:`_session_gyro_bias`: the unit's bias
    plus the mean of its 10 °/h drift over the rests), the quantity ``local`` reports without
    ``--gyro-bias-instability``. ``only``: the names of the rows to run (default both)."""
    import dataclasses

    from optinav.core.imu_model import TriadErrors, preset

    from .calibrate import calibrate
    from .simulate import simulate

    gen = as_rng(rng)
    z = {"gyro, g-sensitivity ignored": ([], []), "gyro, --gyro-g-sensitivity": ([], [])}
    for _ in range(int(n_runs)):
        seed = int(gen.integers(2**31))
        g2 = np.random.default_rng(seed)
        unit = preset("mems-mti1").draw(g2)
        gy = unit.gyr
        unit = dataclasses.replace(
            unit,
            gyr=TriadErrors(
                "gyro",
                bias=gy.bias,
                scale=gy.scale,
                misalignment=gy.misalignment,
                g_sensitivity=g2.normal(0, GYRO_G_SENSITIVITY, (3, 3)),
            ),
        )
        s = simulate("18", spec=unit, dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="counts", rng=seed)
        _, Q = model.upper_triangular_form(s.acc_K)
        Kg = s.gyr_K @ Q.T
        for name, opt in zip(list(z), (None, GYRO_G_SENSITIVITY * float(np.mean(np.diag(s.gyr_K))))):
            if only is not None and name not in set(only):
                continue
            r = calibrate(s.t, s.acc, s.gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity, gyro_g_sensitivity=opt)
            b_true = _session_gyro_bias(s, unit, seed, drawn=False, intervals=r.static_intervals)
            z[name][0].extend((r.gyroscope["b"] - b_true) / r.gyroscope["b_std"])
            z[name][1].extend(((r.gyroscope["K"] - Kg) / r.gyroscope["K_std"]).ravel())
    return {
        name: {
            "scale": float(np.sqrt(np.mean(np.square(k)))),
            "misalignment": None,
            "bias": float(np.sqrt(np.mean(np.square(b)))),
        }
        for name, (b, k) in z.items()
        if b
    }


#: the initial rest (s) of the simulated sessions (rest_s = 5 s) that ``--gyro-bias rest`` is given
REST_WINDOW = (0.5, 4.5)

#: in-run gyro bias instability (°/h, datasheet B; Gauss–Markov, τ 100 s) of the drifting unit of
#: :func:`gyro_drift_study` — ten times the MTi-1's, a consumer-grade MEMS gyro
DRIFTING_GYRO_DEG_H = 100.0


def gyro_drift_study(n_runs: int = 30, rng=0, only=None) -> dict[str, dict[str, float]]:
    """RMS(error/std) of the gyro bias and K under a bias that drifts in the run (first-order Gauss–Markov of the
    MTi-1 preset: its own 10 °/h, and :data:`DRIFTING_GYRO_DEG_H`): the default ``--gyro-bias local``, the
    former default ``static``, ``rest`` (the initial rest, :data:`REST_WINDOW`; its error against the bias over that
    window), ``estimate``, and ``local`` with ``--gyro-bias-instability`` (the process's stationary 1σ) and
    ``--gyro-bias-corr-time`` (its τ). Without the instability option the bias error is against the session's bias
    (:func:`_session_gyro_bias`), with it against the unit's long-term bias. Full simulated sessions (18 poses,
    8 s dwell, counts), as :func:`gyro_g_sensitivity_study`."""
    from optinav.core.imu_model import GM_SIGMA_PER_BIAS_INSTABILITY, preset
    from optinav.core.units import DEG

    from .calibrate import calibrate
    from .simulate import simulate

    gen = as_rng(rng)
    hi = f"{DRIFTING_GYRO_DEG_H:g} °/h"
    cases = [
        ("gyro, bias 10 °/h (MTi-1), local (default)", 10.0, "local", False),
        ("gyro, bias 10 °/h (MTi-1), rest (initial rest)", 10.0, "rest", False),
        ("gyro, bias 10 °/h (MTi-1), estimate", 10.0, "estimate", False),
        (f"gyro, bias {hi}, static (the former default)", DRIFTING_GYRO_DEG_H, "static", False),
        (f"gyro, bias {hi}, local (default)", DRIFTING_GYRO_DEG_H, "local", False),
        (f"gyro, bias {hi}, local + --gyro-bias-instability", DRIFTING_GYRO_DEG_H, "local", True),
    ]
    if only is not None:  # a subset of the rows (by name)
        cases = [c for c in cases if c[0] in set(only)]
    z = {name: ([], []) for name, *_ in cases}
    for _ in range(int(n_runs)):
        seed = int(gen.integers(2**31))
        for B in sorted({c[1] for c in cases}):
            spec = preset("mems-mti1", gyro_bias_instability=(B, "deg/h"))
            s = simulate("18", spec=spec, dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="counts", rng=seed)
            _, Q = model.upper_triangular_form(s.acc_K)
            Kg = s.gyr_K @ Q.T
            for name, b_case, mode, given in cases:
                if b_case != B:
                    continue
                inst = GM_SIGMA_PER_BIAS_INSTABILITY * B * DEG / 3600 * float(np.mean(np.diag(s.gyr_K)))
                rest = REST_WINDOW if mode == "rest" else None
                r = calibrate(
                    s.t,
                    s.acc,
                    s.gyr,
                    acc_unit="counts",
                    gyro_unit="counts",
                    g=s.gravity,
                    gyro_bias=mode,
                    gyro_bias_instability=inst if given else None,
                    gyro_bias_corr_time=float(np.mean(spec.gyro_bias_corr_time)),
                    rest=rest,
                )
                b_true = (
                    s.gyr_b
                    if given
                    else _session_gyro_bias(s, spec, seed, drawn=True, intervals=[rest] if rest else r.static_intervals)
                )
                z[name][0].extend((r.gyroscope["b"] - b_true) / r.gyroscope["b_std"])
                z[name][1].extend(((r.gyroscope["K"] - Kg) / r.gyroscope["K_std"]).ravel())
    return {
        name: {
            "scale": float(np.sqrt(np.mean(np.square(k)))),
            "misalignment": None,
            "bias": float(np.sqrt(np.mean(np.square(b)))),
        }
        for name, (b, k) in z.items()
    }


def table(results: dict[str, dict[str, float]]) -> str:
    """A markdown table of :func:`run_all` results."""
    lines = ["| configuration | " + " | ".join(GROUPS) + " |", "|---|" + "---|" * len(GROUPS)]
    for name, row in results.items():
        lines.append(
            f"| {name} | "
            + " | ".join(
                "in K" if row[g] is None else "held" if not np.isfinite(row[g]) else f"{row[g]:.2f}" for g in GROUPS
            )
            + " |"
        )
    return "\n".join(lines)
