"""Study ``accel-ga``: Gao & Zhang (2019), MEMS accelerometer calibration by norm observation and an adaptive GA.

Reproduces the paper's Tables 1 to 4 and Figs. 4 and 5 on a simulated MTi-1 whose accelerometer has the paper's
"traditional multi-position" values (Table 2) as truth, with the MTi-1 datasheet noise (white noise and bias
instability) and the 12 positions recovered from Table 1. The paper's GA is rebuilt with its own operators
(uniform ranking selection, gene exchange crossover, per-individual mutation, adaptive Pc and Pm, fitness 1/E
summed over the positions); optinav's GA variant (arithmetic crossover, per-gene non-uniform mutation), the
Newton baseline and optinav's default (Levenberg–Marquardt on the pose means, analytic Jacobian) run on the same
session. The paper's numbers are measured on a real unit against a reference calibration, ours against
simulation truth, so they agree in kind (who beats whom, by what order), not digit for digit; the findings
table says which of the paper's head-to-head findings this reproduces.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from optinav.core import rotations
from optinav.core.progress import step
from optinav.core.imu_model import TriadErrors, preset
from optinav.core.observability import rmse_ratio_band
from optinav.core.simulate import static_positions
from optinav.multipos import accel, design, model
from optinav.multipos.simulate import paper_accelerometer, simulate
from optinav.reports.report import (
    Cell,
    Check,
    Figure,
    Headline,
    Limit,
    StudyResult,
    Table,
    quantity,
    register_study,
    value_at,
)

NAMES = ["B_x", "B_y", "B_z", "S_xx", "S_yy", "S_zz", "M_xy", "M_xz", "M_yz"]
#: the units of the paper's parameters: biases, scale factors (per 1 g input), misalignments
NAME_UNITS = {"B": "m/s²", "S": "", "M": "rad"}
#: Table 2 of the paper: relative errors (%) of Newton and of the GA against the reference calibration
PAPER_REL_ERR = {
    "newton": [-0.146, -0.554, 1.451, 0.000204, 0.0104, 0.414, None, None, None],
    "ga": [-0.017, 0.019, -0.051, 0.007, 0.004, 0.0003, 10.69, -53.64, -21.37],
}
PAPER_TIME_S = {"ga": 164.28, "newton": 421.92}
#: Table 4: mean static attitude error after calibration (deg), pitch and roll
PAPER_LEVEL_DEG = {"traditional": (0.015, 0.109), "newton": (0.24, -0.191), "ga": (0.062, -0.051)}
RATE_HZ = 100.0
#: seeds of each GA (quick, full run): one set, the optinav-operator GA (no claim rests on it; 5× the
#: evaluations) on its first few. The paper's GA's worst scale-factor error spreads over 0.17–1.7 % across
#: seeds (30 seeds, 200 generations): a median over 9 seeds falls within ±20 % of the 30 seeds' median
GA_SEEDS = {"ga": {True: 9, False: 15}, "ga_optinav": {True: 3, False: 3}}
GA_POPULATION = 50  # optinav's GA default, the population of Table 2's note
#: the paper's parameter groups: biases, scale factors, misalignments (indices of NAMES)
PARTS = {"bias": slice(0, 3), "scale": slice(3, 6), "misalignment": slice(6, 9)}
#: the calibrations of the levelling test (Table 4), by the key of their fit (None: uncalibrated)
LEVELLING = {
    "uncalibrated": None,
    "Newton": "newton",
    "adaptive GA": "ga",
    "adaptive GA, optinav operators": "ga_optinav",
    "optinav LM": "lm",
}

LIMITS = {
    "table1_singular_values": Limit(
        1.5e-3,
        reason="the paper prints 3 decimals (±5e-4) and g itself is only known "
        "as 29.405/3 from its table (±2e-4 per unit)",
    ),
    "table1_ranks": Limit(0, unit="mismatches", reason="the rank is exact: it must equal the paper's for every N"),
    "design_ratio": Limit(
        1.0, ">=", reason="the designed scheme must see the misalignments at least as well as the paper's 12 positions"
    ),
    "lm_z": Limit(
        4.0, reason="4σ of the reported std: a Gaussian error exceeds it over 9 parameters with probability 6e-4"
    ),
    "lm_speed_quick": Limit(
        10.0,
        ">=",
        "×",
        reason="a few milliseconds for LM against ≈ 0.14 s for 200 generations of the GA (quick run, median over its "
        "seeds): ≈ 50× alone (100–320× while the population's residuals were numpy temporaries, 4× slower; under "
        "the test suite's load the ratio fell to less than half); 10× keeps the claim with room for a loaded machine",
    ),
    "lm_speed": Limit(
        50.0,
        ">=",
        "×",
        reason="LM against 500 generations of the GA on 60 s poses: ≈ 170× alone (GA 1.4 s, LM 8 ms); 50× keeps the "
        "claim with room for a loaded machine",
    ),
    "lm_vs_ga_scale": Limit(1.0, reason="LM reaches the least-squares minimum the GA can only approach"),
    "levelling": Limit(
        None, unit="deg", reason="4σ of the tilt error from the fit's std and the test pose's bias instability"
    ),
    "efficiency_max": Limit(
        None,
        reason="the 99 % band of RMSE/√CRLB of an efficient estimator over the runs, "
        "Bonferroni over the 9 parameters (at least 1.1)",
    ),
    "efficiency_min": Limit(None, ">=", reason="the lower end of the same 99 % band"),
}


def _paper_vector(K, b, g) -> np.ndarray:
    p = model.to_paper(K, b, g)
    return np.r_[p["B"], p["S"], p["M_xy"], p["M_xz"], p["M_yz"]]


def _per_parameter(v, unit=None) -> dict:
    """A vector in the paper's parameterization as ``{name: quantity}`` (each parameter with its own unit)."""
    return {nm: quantity(x, NAME_UNITS[nm[0]] if unit is None else unit) for nm, x in zip(NAMES, v)}


def _level(f) -> tuple[float, float]:
    """Pitch and roll (deg) of the sensor frame from the mean specific force (x right, y forward, z up)."""
    f = np.asarray(f, float)
    return (float(np.degrees(np.arctan2(f[1], np.hypot(f[0], f[2])))), float(np.degrees(np.arctan2(-f[0], f[2]))))


# --- computation --------------------------------------------------------------------------------------------


def _table1() -> dict:
    """Rank and singular values of the observability matrix vs the number of positions, and the largest
    difference from the paper's Table 1."""
    ours = design.observability_vs_n(design.PAPER_SCHEME_UP, design.PAPER_G)
    diffs = []
    for n, s in zip(ours.n_positions, ours.singular_values):
        sv_p = np.asarray(design.PAPER_TABLE1[int(n)][1], float)
        d = np.abs(s[: sv_p.size] - sv_p)
        d[sv_p < 1e-3] = 0.0  # the paper's 1.715e-7 is a numerical zero; ours is ~1e-15
        diffs.append(float(d.max()))
    return {
        "ours": ours,
        "diff": diffs,
        "worst": max([0.0, *diffs]),
        "rank_mismatches": float(
            np.sum(ours.rank != np.array([design.PAPER_TABLE1[int(n)][0] for n in ours.n_positions]))
        ),
    }


def _design(sigma, rate, dwell) -> dict:
    """Predicted 1σ of the paper's 12 positions and of D- and E-optimal 12-pose schemes."""
    out = {"paper12": design.evaluate_scheme(design.PAPER_SCHEME_UP[:12], sigma=sigma, rate_hz=rate, dwell_s=dwell)}
    for crit in ("D", "E"):
        out[crit] = design.design_scheme(12, criterion=crit, sigma=sigma, rate_hz=rate, dwell_s=dwell)
    return out


def _fits(quick, rng) -> dict:
    """One simulated session, calibrated by both GAs, Newton and LM (the fits and their run times), and the
    levelling test of Table 4."""
    dwell = 10.0 if quick else 60.0
    sess = simulate("paper12", spec="mems-mti1", truth="paper", dwell_s=dwell, rng=rng)
    g = sess.gravity
    idx = np.array(
        [[np.searchsorted(sess.t, a), np.searchsorted(sess.t, b, side="right")] for a, b in sess.static_intervals]
    )
    st = accel.pose_statistics(sess.acc, idx)
    samples = [sess.acc[i0:i1] for i0, i1 in idx]
    fits = {}
    gens = 200 if quick else 500
    # a GA's result depends on its seed: both GAs run on one fixed set of seeds (drawn once, the same for
    # both), and the study reports the median run (worst scale-factor error) and the spread over the seeds
    seeds = [int(x) for x in rng.integers(0, 2**31, size=GA_SEEDS["ga"][quick])]
    truth_theta = model.Kb_to_theta(sess.acc_K, sess.acc_b)
    ga_runs = {}
    for key, ops in (("ga", "paper"), ("ga_optinav", "optinav")):
        key_seeds = seeds[: GA_SEEDS[key][quick]]
        step(f"GA ({ops} operators, {len(key_seeds)} seeds)")
        runs = []
        for seed in key_seeds:
            t0 = time.perf_counter()
            f = accel.fit_accel(
                st,
                g,
                method="ga",
                data="samples",
                samples=samples,
                rng=seed,
                generations=gens,
                population=GA_POPULATION,
                operators=ops,
            )
            f.elapsed_s = time.perf_counter() - t0
            runs.append(f)
        rel = np.array([100 * (_paper_vector(f.K, f.b, g) - _paper_vector(sess.acc_K, sess.acc_b, g)) for f in runs])
        rel /= _paper_vector(sess.acc_K, sess.acc_b, g)
        worst = {part: np.abs(rel[:, sl]).max(axis=1) for part, sl in PARTS.items()}
        median_run = int(np.argsort(worst["scale"])[len(runs) // 2])
        fits[key] = runs[median_run]
        fits[key].elapsed_s = float(np.median([f.elapsed_s for f in runs]))  # the time: median over the seeds
        ga_runs[key] = {
            "seeds": key_seeds,
            "worst": worst,
            "elapsed": np.array([f.elapsed_s for f in runs]),
            "nfev": np.array([f.nfev for f in runs]),
            "median_run": median_run,
            "final_error": np.array([np.abs(f.theta - truth_theta).max() for f in runs]),
        }
    step("Newton and LM")
    t0 = time.perf_counter()
    fits["newton"] = accel.fit_accel(st, g, method="newton", data="samples", samples=samples)
    fits["newton"].elapsed_s = time.perf_counter() - t0
    # LM takes milliseconds, so one scheduler hiccup could be most of a single timing: the best of five
    # (the fit is deterministic) is its cost
    lm_times = []
    for _ in range(5):
        t0 = time.perf_counter()
        fits["lm"] = accel.fit_accel(st, g, method="lm", bias_instability=sess.acc_bias_instability)
        lm_times.append(time.perf_counter() - t0)
    fits["lm"].elapsed_s = min(lm_times)
    truth = _paper_vector(sess.acc_K, sess.acc_b, g)
    vec = {k: _paper_vector(f.K, f.b, g) for k, f in fits.items()}
    budget = {k: {"generations": gens, "population": GA_POPULATION, "evaluations": ga_runs[k]["nfev"]} for k in ga_runs}
    budget.update({k: {"iterations": fits[k].nit, "evaluations": np.array([fits[k].nfev])} for k in ("newton", "lm")})
    lm = fits["lm"]
    # Table 4: levelling with each calibration on a static test pose outside the calibration set
    unit = preset("mems-mti1").draw(rng)
    unit = dataclasses.replace(unit, acc=TriadErrors.from_matrix("accel", sess.acc_K, sess.acc_b))
    c = rotations.dcm_from_euler(np.radians([3.0, -5.0, 30.0]), convention="enu")
    tr = static_positions(c[None], 60.0, 100.0, np.radians(38.88), height_m=35.0, frame="enu")
    meas = unit.apply(tr.gyr, tr.acc, rng=rng)
    p0, r0 = _level(tr.acc.mean(axis=0))
    lev = {}
    for name, key in LEVELLING.items():
        K, b = (np.eye(3), np.zeros(3)) if key is None else (fits[key].K, fits[key].b)
        p, r = _level(np.linalg.solve(K, meas.acc.mean(axis=0) - b))
        lev[name] = (p - p0, r - r0)
    # tilt error ≈ bias error / g ⊕ misalignment error ⊕ the test pose's own bias drift / g (rad)
    sig_tilt = np.sqrt(
        (np.max(lm.std[6:9]) / (g * lm.K[0, 0])) ** 2
        + np.max(lm.std[3:6] / lm.K[0, 0]) ** 2
        + (np.max(unit.acc_noise.gm_sigma) / g) ** 2
    )
    ga = fits["ga"]
    lo, hi = accel.search_interval(st.means, g)
    return {
        "dwell": dwell,
        "generations": gens,
        "fits": fits,
        "ga_runs": ga_runs,
        "budget": budget,
        "truth": truth,
        "vec": vec,
        "rel": {k: 100 * (v - truth) / truth for k, v in vec.items()},
        "std": np.r_[lm.std[6:9], lm.std[:3] * g, lm.std[3:6] / np.diag(lm.K)[[0, 0, 1]]],
        "levelling": lev,
        "levelling_limit": float(4 * np.degrees(sig_tilt)),
        # the GA's convergence: fitness per generation and the best individual against the truth, scaled by
        # the search interval
        "ga_history": ga.history,
        "ga_mean_cost": ga.trace["mean_cost"],
        "ga_convergence": (ga.trace["best_x"] - model.Kb_to_theta(sess.acc_K, sess.acc_b)) / (hi - lo),
    }


def _findings(rel, fits, lev) -> list[dict]:
    """The paper's head-to-head findings, each against the same-session numbers (reproduced or not, and why)."""
    ab = {k: np.abs(v) for k, v in rel.items()}
    bias_ratio = float(np.median(ab["newton"][:3] / np.maximum(ab["ga"][:3], 1e-12)))
    scale_ratio = float(np.median(ab["newton"][3:6] / np.maximum(ab["ga"][3:6], 1e-12)))
    time_ratio = fits["ga"].elapsed_s / fits["newton"].elapsed_s
    mis_ratio = float(np.max(ab["newton"][6:9]) / max(np.max(ab["ga"][6:9]), 1e-12))
    lev_n = float(np.max(np.abs(lev["Newton"])))
    lev_ratio = lev_n / max(float(np.max(np.abs(lev["adaptive GA"]))), 1e-12)
    same_min = (
        "Newton converges to the least-squares minimum of the same objective (smooth, one minimum near "
        "the start); a GA can only approach that minimum, so it cannot be more accurate"
    )
    rows = [
        (
            "GA biases 1–3 orders of magnitude more accurate than Newton's",
            "≥ 10",
            bias_ratio,
            bias_ratio >= 10,
            same_min,
        ),
        (
            "GA scale factors 1–3 orders of magnitude more accurate than Newton's",
            "≥ 10",
            scale_ratio,
            scale_ratio >= 10,
            same_min,
        ),
        (
            "GA 61 % faster than Newton (time GA / Newton)",
            0.39,
            time_ratio,
            time_ratio <= 0.5,
            "a matter of implementation and data size, not of the methods: a Newton iteration here differences "
            "the analytic gradient 18 times for its Hessian on every sample, the GA evaluates population × "
            "generations residuals in one compiled pass, so the ratio falls as the poses get longer (above 1 on the "
            "quick run's 10-s poses, below 0.5 on the full run's 60-s ones); LM needs milliseconds for the same minimum",
        ),
        (
            "Newton fails on the misalignments (max rel. error Newton / GA)",
            "failed",
            mis_ratio,
            mis_ratio >= 10,
            "the 12 positions observe the misalignments (full rank); Newton from the interval centre converges "
            "on them as on the rest",
        ),
        (
            "Newton levelling error ≈ 0.24°, ≈ 4× the GA's (ratio Newton / GA)",
            3.9,
            lev_ratio,
            lev_ratio >= 2,
            f"with both at the same minimum the levelling errors agree (Newton {lev_n:.3f}°)",
        ),
    ]
    return [{"finding": f, "paper": p, "ours": v, "reproduced": bool(ok), "reason": why} for f, p, v, ok, why in rows]


def _efficiency(quick, rng) -> dict:
    """Monte Carlo of the default estimator on white noise: RMSE/√CRLB per parameter, and the band an efficient
    estimator's ratio falls in."""
    n_runs = 200 if quick else 1000
    rate, dwell = RATE_HZ, 10.0 if quick else 60.0
    spec = preset("mems-mti1")
    g = 9.80167
    K, b = paper_accelerometer(g)
    ups = design.design_scheme(12, criterion="D").up_dirs
    sigma = float(np.max(spec.acc_vrw) * np.sqrt(rate))
    eff, _ = accel.efficiency(K, b, ups, g, sigma, int(dwell * rate), n_runs, rng)
    # where an efficient estimator's ratio falls 99 % of the time for all 9 parameters together (Bonferroni)
    lo, hi = rmse_ratio_band(n_runs, 1 - 0.01 / 9)
    return {"n_runs": n_runs, "rate": rate, "dwell": dwell, "sigma": sigma, "efficiency": eff, "band": (lo, hi)}


def compute(quick: bool, rng) -> dict:
    """Every number of the study, in the order the parts draw from ``rng``."""
    spec = preset("mems-mti1")
    sigma = float(np.max(spec.acc_vrw) * np.sqrt(RATE_HZ))  # per sample at 100 Hz
    n = {"quick": quick}
    step("Table 1")
    n["table1"] = _table1()
    step("pose design")
    n["design"] = _design(sigma, RATE_HZ, 60.0)
    step("Tables 2-4")
    n.update(_fits(quick, rng))
    n["findings"] = _findings(n["rel"], n["fits"], n["levelling"])
    step("efficiency")
    n["efficiency"] = _efficiency(quick, rng)
    return n


def _design_ratio(n) -> float:
    d = n["design"]
    return float(np.max(d["paper12"].predicted_std[3:6]) / np.max(d["D"].predicted_std[3:6]))


def _spread(v) -> str:
    """A median and its range over seeds, ``[median, min, max]``, as 'median [min, max]'."""
    return f"{v[0]:.3g} [{v[1]:.3g}, {v[2]:.3g}]"


def _worst(v, sl) -> float:
    return float(np.max(np.abs(np.asarray(v)[sl])))


def summary(n) -> dict:
    """The numbers of ``summary.json``, each with its unit."""
    return {
        "table1_max_abs_diff": quantity(n["table1"]["worst"], ""),
        "design_misalignment_std_ratio": quantity(_design_ratio(n), ""),
        "truth": _per_parameter(n["truth"]),
        "estimate": {k: _per_parameter(v) for k, v in n["vec"].items()},
        "relative_error": {k: quantity(v, "%") for k, v in n["rel"].items()},
        "time": {k: quantity(f.elapsed_s, "s") for k, f in n["fits"].items()},
        "levelling_error": {k: quantity(v, "deg") for k, v in n["levelling"].items()},
        "findings_reproduced": quantity(sum(f["reproduced"] for f in n["findings"]), ""),
        "ga_seeds": {
            k: {
                "seeds": quantity(np.array(r["seeds"], dtype=float), ""),
                **{f"worst_{part}_error": quantity(v, "%") for part, v in r["worst"].items()},
                "elapsed": quantity(r["elapsed"], "s"),
                "median_run": quantity(r["median_run"], ""),
            }
            for k, r in n["ga_runs"].items()
        },
        "budget": {
            k: {
                nm: quantity(np.asarray(v, dtype=float), "generations" if nm == "generations" else "")
                for nm, v in b.items()
            }
            for k, b in n["budget"].items()
        },
        "efficiency": quantity(n["efficiency"]["efficiency"], ""),
    }


# --- checks -------------------------------------------------------------------------------------------------


def checks(n) -> list[Check]:
    rel, fits, eff = n["rel"], n["fits"], n["efficiency"]
    z = (n["vec"]["lm"] - n["truth"]) / n["std"]
    lo, hi = eff["band"]
    return [
        Check.against("Table 1: max |singular value − paper|", n["table1"]["worst"], LIMITS["table1_singular_values"]),
        Check.against("Table 1: ranks equal the paper's", n["table1"]["rank_mismatches"], LIMITS["table1_ranks"]),
        Check.against(
            "D-optimal 12 poses vs paper's 12: misalignment σ ratio (paper/designed)",
            _design_ratio(n),
            LIMITS["design_ratio"],
        ),
        Check.against("LM: max |error|/σ over the 9 parameters", float(np.max(np.abs(z))), LIMITS["lm_z"]),
        Check.against(
            "LM faster than the GA (time ratio)",
            fits["ga"].elapsed_s / fits["lm"].elapsed_s,
            LIMITS["lm_speed_quick" if n["quick"] else "lm_speed"],
        ),
        Check.against(
            "LM scale error vs GA scale error (max |rel. err| ratio)",
            float(np.max(np.abs(rel["lm"][3:6])) / max(np.max(np.abs(rel["ga"][3:6])), 1e-12)),
            LIMITS["lm_vs_ga_scale"],
        ),
        Check.against(
            "LM levelling error (max |pitch|, |roll|), limit 4σ from the fit's std and the test pose's "
            "bias instability",
            float(np.max(np.abs(n["levelling"]["optinav LM"]))),
            LIMITS["levelling"],
            at=n["levelling_limit"],
        ),
        Check.against("max RMSE/√CRLB", float(eff["efficiency"].max()), LIMITS["efficiency_max"], at=max(hi, 1.1)),
        Check.against("min RMSE/√CRLB", float(eff["efficiency"].min()), LIMITS["efficiency_min"], at=lo),
    ]


# --- tables -------------------------------------------------------------------------------------------------


def tables(n) -> list[Table]:
    t1, fits, vec, rel, truth, std = n["table1"], n["fits"], n["vec"], n["rel"], n["truth"], n["std"]
    ours = t1["ours"]
    out = [
        Table(
            "Table 1 — rank and singular values of Q = [H; HA; …; HA⁸] vs the number of positions",
            ["N", "rank (ours)", "rank (paper)", "singular values (ours)", "max |ours − paper|"],
            [
                [int(N), int(r), int(design.PAPER_TABLE1[int(N)][0]), list(s), d]
                for N, r, s, d in zip(ours.n_positions, ours.rank, ours.singular_values, t1["diff"])
            ],
            "Positions: the sequence recovered from the printed table; "
            f"g = {design.PAPER_G:.5f} m/s². N = 3 is rank deficient, N ≥ 4 full rank for this linear "
            "model (3 outputs per pose). Our estimator observes only the norm (1 scalar per pose), so "
            "it needs N ≥ 9 — see the design table.",
            formats=[None, None, None, "{:.3f}", "{:.1e}"],
        )
    ]
    label = {"paper12": "paper's 12 positions", "D": "D-optimal 12", "E": "E-optimal 12"}
    out.append(
        Table(
            "Pose-scheme design for the norm model (predicted 1σ, MTi-1 white noise, 60 s per pose)",
            ["scheme", "max σ(K_ii) [ppm]", "max σ(K_ij) [µrad]", "max σ(b) [µg]", "poses"],
            [
                [
                    label[k],
                    np.max(d.predicted_std[:3]) * 1e6,
                    np.max(d.predicted_std[3:6]) * 1e6,
                    np.max(d.predicted_std[6:9]) * 1e6 / 9.80665,
                    "; ".join(d.descriptions),
                ]
                for k, d in n["design"].items()
            ],
            "The paper's 12 positions repeat +x up and include three axis pairs only, so the norm model "
            "sees the misalignments weakly; the designed schemes use 45° and corner poses.",
            formats=[None, "{:.1f}", "{:.1f}", "{:.1f}"],
        )
    )
    rows = [
        [
            nm,
            float(truth[j]),
            float(vec["newton"][j]),
            float(rel["newton"][j]),
            PAPER_REL_ERR["newton"][j],
            float(vec["ga"][j]),
            float(rel["ga"][j]),
            PAPER_REL_ERR["ga"][j],
            float(rel["ga_optinav"][j]),
            float(vec["lm"][j]),
            float(std[j]),
            float(rel["lm"][j]),
        ]
        for j, nm in enumerate(NAMES)
    ]
    out.append(
        Table(
            "Table 2: calibration results and relative errors (%) against the truth",
            [
                "parameter",
                "truth (paper ref.)",
                "Newton",
                "Newton rel. err [%]",
                "paper Newton [%]",
                "GA (paper's operators)",
                "GA rel. err [%]",
                "paper GA [%]",
                "GA, optinav operators, rel. err [%]",
                "optinav LM",
                "LM std",
                "LM rel. err [%]",
            ],
            rows,
            f"Simulated MTi-1 (datasheet noise incl. bias instability), 12 positions × {n['dwell']:g} s at "
            f"100 Hz, one session for all methods. B in m/s², S per 1 g input, M in rad. Both GAs "
            f"({n['generations']} generations, population 50) and Newton fit every sample (as in the paper), "
            "LM the pose means (the same least-squares minimum, weighted). The paper's Newton failed on the "
            "misalignments (empty cells).",
        )
    )
    rows = []
    for key, label in (("ga", "adaptive GA (paper's operators)"), ("ga_optinav", "adaptive GA (optinav operators)")):
        r, b = n["ga_runs"][key], n["budget"][key]
        spread = [
            Cell([float(np.median(r["worst"][p])), float(r["worst"][p].min()), float(r["worst"][p].max())], _spread)
            for p in PARTS
        ]
        rows.append(
            [
                label,
                len(r["seeds"]),
                *spread,
                f"{b['population']} × {b['generations']} generations",
                float(np.median(b["evaluations"])),
                float(np.median(r["elapsed"])),
            ]
        )
    for key, label in (("newton", "Newton (samples)"), ("lm", "optinav LM (pose means)")):
        w = [Cell(_worst(rel[key], sl), "{:.3g}") for sl in PARTS.values()]
        b = n["budget"][key]
        rows.append(
            [
                label,
                1,
                *w,
                f"{b['iterations']} iterations (to convergence)",
                float(b["evaluations"][0]),
                fits[key].elapsed_s,
            ]
        )
    out.append(
        Table(
            "Every method's budget and, for the GAs, the spread over seeds",
            [
                "method",
                "seeds",
                "worst |bias err.| [%] median [min, max]",
                "worst |scale err.| [%] median [min, max]",
                "worst |misal. err.| [%] median [min, max]",
                "budget",
                "objective evaluations (median)",
                "time [s] (median)",
            ],
            rows,
            "The same session and the same start (the closed-form estimate, the centre of the GAs' search interval) "
            f"for every method; both GAs run on one set of seeds (the paper's GA on {len(n['ga_runs']['ga']['seeds'])}, "
            f"optinav's on the first {len(n['ga_runs']['ga_optinav']['seeds'])}) with the same population and "
            "generations (the paper's operators evaluate fewer new individuals: identical children are not "
            "re-evaluated); Newton and LM are deterministic and run to convergence. Table 2, "
            "the levelling and the findings use each GA's median run (worst scale-factor error).",
            formats=[None, None, None, None, None, None, "{:.0f}", "{:.3g}"],
        )
    )
    out.append(
        Table(
            "Table 3 — computation time",
            ["method", "time [s] (optinav)", "time [s] (paper)"],
            [
                ["adaptive GA (paper's operators)", fits["ga"].elapsed_s, PAPER_TIME_S["ga"]],
                ["adaptive GA (optinav operators)", fits["ga_optinav"].elapsed_s, None],
                ["Newton", fits["newton"].elapsed_s, PAPER_TIME_S["newton"]],
                ["optinav LM (pose means)", fits["lm"].elapsed_s, None],
            ],
            "Paper: MATLAB on the authors' PC; optinav: this machine.",
        )
    )
    paper_lev = {"Newton": PAPER_LEVEL_DEG["newton"], "adaptive GA": PAPER_LEVEL_DEG["ga"]}
    out.append(
        Table(
            "Table 4: static levelling error after calibration (deg)",
            ["calibration", "pitch error", "roll error", "paper pitch", "paper roll"],
            [[name, *e, *paper_lev.get(name, (None, None))] for name, e in n["levelling"].items()],
            "A 60 s static test pose (roll 3°, pitch −5°) outside the calibration set; pitch/roll from "
            "the mean corrected specific force. The paper's 'traditional' reference: 0.015 / 0.109.",
        )
    )
    out.append(
        Table(
            "The paper's head-to-head findings, checked on the same session",
            ["paper's finding", "paper", "optinav (same data)", "reproduced", "reason"],
            [
                [
                    f["finding"],
                    f["paper"],
                    f["ours"],
                    f["reproduced"],
                    "reproduced on this session" if f["reproduced"] else f["reason"],
                ]
                for f in n["findings"]
            ],
            "GA = the paper's operators, as rebuilt; ratios are medians over the axes where stated.",
        )
    )
    e = n["efficiency"]
    out.append(
        Table(
            f"Efficiency of the default estimator: RMSE/√CRLB over {e['n_runs']} Monte Carlo runs",
            ["parameter"] + list(model.ACCEL_PARAMS),
            [["RMSE/√CRLB", *e["efficiency"]]],
            f"D-optimal 12 poses, {e['dwell']:g} s each at {e['rate']:g} Hz, white noise σ = "
            f"{e['sigma']:.4g} m/s² per sample.",
            formats=[None] + ["{:.3f}"] * len(model.ACCEL_PARAMS),
        )
    )
    return out


# --- figures ------------------------------------------------------------------------------------------------


def figures(n) -> list[Figure]:
    ours = n["table1"]["ours"]

    def draw_sv(fig):
        ax = fig.add_subplot(111)
        for j in range(9):
            ax.semilogy(ours.n_positions, np.maximum(ours.singular_values[:, j], 1e-8), "-", lw=1)
            pv = [design.PAPER_TABLE1[int(N)][1][j] for N in ours.n_positions]
            ax.semilogy(ours.n_positions, np.maximum(pv, 1e-8), "k.", ms=4)
        ax.set_xlabel("number of positions N")
        ax.set_ylabel("singular value")
        ax.set_title("Singular values of Q vs N (lines: optinav, dots: paper Table 1)")
        ax.grid(True, which="both", alpha=0.3)

    def draw_fit(fig):
        ax = fig.add_subplot(111)
        gen = np.arange(len(n["ga_history"]))
        ax.semilogy(gen, 1 / n["ga_history"], label="best fitness 1/E")
        ax.semilogy(gen, 1 / n["ga_mean_cost"], label="1 / population mean of E")
        ax.set_xlabel("generation")
        ax.set_ylabel("fitness [1/(m/s²)²]")
        ax.set_title("Adaptive GA with the paper's operators: fitness (paper Fig. 4)")
        ax.legend()
        ax.grid(True, alpha=0.3)

    def draw_conv(fig):
        ax = fig.add_subplot(111)
        for j, nm in enumerate(model.ACCEL_PARAMS):
            ax.plot(n["ga_convergence"][:, j], label=nm, lw=1)
        ax.set_xlabel("generation")
        ax.set_ylabel("(best − truth) / search-interval width")
        ax.set_title("GA with the paper's operators: parameter convergence (paper Fig. 5)")
        ax.legend(ncol=3, fontsize=7)
        ax.grid(True, alpha=0.3)

    return [
        Figure(
            "accel_ga_singular_values.png",
            "Singular values of the observability matrix vs the number of "
            "positions: optinav (lines) and the paper's Table 1 (dots)",
            draw_sv,
        ),
        Figure(
            "accel_ga_fitness.png",
            "Best and mean fitness of the adaptive GA (paper's operators) per generation",
            draw_fit,
        ),
        Figure(
            "accel_ga_convergence.png",
            "Convergence of the GA's best individual, per parameter (paper's "
            "operators): gene exchange only recombines values the population "
            "already holds, and the adaptive mutation rate of the fitter half "
            "is near zero, so the search advances in rare steps between long plateaus",
            draw_conv,
        ),
    ]


def headline(s) -> list[Headline]:
    """The headline rows, from the summary's quantities."""
    rel = lambda m: value_at(s, f"relative_error.{m}")  # noqa: E731
    lev = lambda m: float(np.max(np.abs(value_at(s, f"levelling_error.{m}"))))  # noqa: E731
    ga_median = lambda part: float(np.median(value_at(s, f"ga_seeds.ga.worst_{part}_error")))  # noqa: E731
    n_seeds = len(value_at(s, "ga_seeds.ga.seeds"))
    pga = [x for x in PAPER_REL_ERR["ga"] if x is not None]
    return [
        Headline(
            "worst bias relative error",
            "%",
            _worst(pga, PARTS["bias"]),
            ga_median("bias"),
            _worst(rel("lm"), PARTS["bias"]),
            f"rebuild = GA with the paper's operators, median over {n_seeds} seeds; best = LM (deterministic); "
            "same session",
        ),
        Headline(
            "worst scale-factor relative error",
            "%",
            _worst(pga, PARTS["scale"]),
            ga_median("scale"),
            _worst(rel("lm"), PARTS["scale"]),
            f"GA: median over {n_seeds} seeds",
        ),
        Headline(
            "calibration time",
            "s",
            PAPER_TIME_S["ga"],
            value_at(s, "time.ga"),
            value_at(s, "time.lm"),
            f"paper: MATLAB; ours: this machine (GA: median over {n_seeds} seeds; LM: best of 5)",
        ),
        Headline(
            "worst levelling error",
            "deg",
            max(map(abs, PAPER_LEVEL_DEG["ga"])),
            lev("adaptive GA"),
            lev("optinav LM"),
            "GA: its median run (worst scale-factor error)",
        ),
        Headline(
            "paper's head-to-head findings reproduced (of 5)",
            "",
            None,
            float(value_at(s, "findings_reproduced")),
            None,
            "see the findings table",
        ),
    ]


@register_study("accel-ga")
def run(quick: bool = False, rng=None) -> StudyResult:
    n = compute(quick, np.random.default_rng(rng))
    s = summary(n)
    return StudyResult(
        name="accel-ga",
        title="MEMS accelerometer calibration by norm observation "
        "(Gao & Zhang 2019, adaptive GA): the paper's GA rebuilt, against "
        "Newton and LM",
        description=__doc__.split("\n\n", 1)[1].replace("\n", " "),
        tables=tables(n),
        checks=checks(n),
        figures=figures(n),
        summary=s,
        headline=headline(s),
    )
