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
from optinav.multipos.simulate import PAPER_REFERENCE, simulate
from optinav.reports.report import Check, Figure, Headline, StudyResult, Table, register_study

NAMES = ["B_x", "B_y", "B_z", "S_xx", "S_yy", "S_zz", "M_xy", "M_xz", "M_yz"]
#: Table 2 of the paper: relative errors (%) of Newton and of the GA against the reference calibration
PAPER_REL_ERR = {"newton": [-0.146, -0.554, 1.451, 0.000204, 0.0104, 0.414, None, None, None],
                 "ga": [-0.017, 0.019, -0.051, 0.007, 0.004, 0.0003, 10.69, -53.64, -21.37]}
PAPER_TIME_S = {"ga": 164.28, "newton": 421.92}
#: Table 4: mean static attitude error after calibration (deg), pitch and roll
PAPER_LEVEL_DEG = {"traditional": (0.015, 0.109), "newton": (0.24, -0.191), "ga": (0.062, -0.051)}


def _paper_vector(K, b, g) -> np.ndarray:
    p = model.to_paper(K, b, g)
    return np.r_[p["B"], p["S"], p["M_xy"], p["M_xz"], p["M_yz"]]


def _level(f) -> tuple[float, float]:
    """Pitch and roll (deg) of the sensor frame from the mean specific force (x right, y forward, z up)."""
    f = np.asarray(f, float)
    return (float(np.degrees(np.arctan2(f[1], np.hypot(f[0], f[2])))),
            float(np.degrees(np.arctan2(-f[0], f[2]))))


def _table1(rng):
    ours = design.observability_vs_n(design.PAPER_SCHEME_UP, design.PAPER_G)
    rows, worst = [], 0.0
    for n, r, s in zip(ours.n_positions, ours.rank, ours.singular_values):
        rank_p, sv_p = design.PAPER_TABLE1[int(n)]
        sv_p = np.asarray(sv_p, float)
        d = np.abs(s[:sv_p.size] - sv_p)
        d[sv_p < 1e-3] = 0.0  # the paper's 1.715e-7 is a numerical zero; ours is ~1e-15
        worst = max(worst, float(d.max()))
        rows.append([int(n), int(r), int(rank_p), " ".join(f"{x:.3f}" for x in s), f"{d.max():.1e}"])
    table = Table("Table 1 — rank and singular values of Q = [H; HA; …; HA⁸] vs the number of positions",
                  ["N", "rank (ours)", "rank (paper)", "singular values (ours)", "max |ours − paper|"], rows,
                  "Positions: the sequence recovered from the printed table; "
                  f"g = {design.PAPER_G:.5f} m/s². N = 3 is rank deficient, N ≥ 4 full rank for this linear "
                  "model (3 outputs per pose). Our estimator observes only the norm (1 scalar per pose), so "
                  "it needs N ≥ 9 — see the design table.")
    # printed to 3 decimals (±5e-4) and g itself is only known as 29.405/3 from the table (±2e-4 per unit)
    checks = [Check("Table 1: max |singular value − paper|", worst, 1.5e-3),
              Check("Table 1: ranks equal the paper's", float(np.sum(ours.rank != np.array(
                  [design.PAPER_TABLE1[int(n)][0] for n in ours.n_positions]))), 0, "mismatches")]

    def draw(fig):
        ax = fig.add_subplot(111)
        for j in range(9):
            ax.semilogy(ours.n_positions, np.maximum(ours.singular_values[:, j], 1e-8), "-", lw=1)
            pv = [design.PAPER_TABLE1[int(n)][1][j] for n in ours.n_positions]
            ax.semilogy(ours.n_positions, np.maximum(pv, 1e-8), "k.", ms=4)
        ax.set_xlabel("number of positions N")
        ax.set_ylabel("singular value")
        ax.set_title("Singular values of Q vs N (lines: optinav, dots: paper Table 1)")
        ax.grid(True, which="both", alpha=0.3)

    fig = Figure("accel_ga_singular_values.png", "Singular values of the observability matrix vs the number of "
                                                 "positions: optinav (lines) and the paper's Table 1 (dots)", draw)
    return [table], checks, [fig], {"table1_max_abs_diff": worst}


def _design(sigma, rate, dwell):
    rows = []
    paper = design.evaluate_scheme(design.PAPER_SCHEME_UP[:12], sigma=sigma, rate_hz=rate, dwell_s=dwell)
    out = {"paper12": paper}
    for crit in ("D", "E"):
        out[crit] = design.design_scheme(12, criterion=crit, sigma=sigma, rate_hz=rate, dwell_s=dwell)
    for name, d in out.items():
        std = d.predicted_std
        rows.append([{"paper12": "paper's 12 positions", "D": "D-optimal 12", "E": "E-optimal 12"}[name],
                     f"{np.max(std[:3]) * 1e6:.1f}", f"{np.max(std[3:6]) * 1e6:.1f}",
                     f"{np.max(std[6:9]) * 1e6 / 9.80665:.1f}", "; ".join(d.descriptions)])
    table = Table("Pose-scheme design for the norm model (predicted 1σ, MTi-1 white noise, 60 s per pose)",
                  ["scheme", "max σ(K_ii) [ppm]", "max σ(K_ij) [µrad]", "max σ(b) [µg]", "poses"], rows,
                  "The paper's 12 positions repeat +x up and include three axis pairs only, so the norm model "
                  "sees the misalignments weakly; the designed schemes use 45° and corner poses.")
    ratio = float(np.max(out["paper12"].predicted_std[3:6]) / np.max(out["D"].predicted_std[3:6]))
    checks = [Check("D-optimal 12 poses vs paper's 12: misalignment σ ratio (paper/designed)", ratio, 1.0, "",
                    ">=")]
    return [table], checks, [], {"design_misalignment_std_ratio": ratio}


def _tables_2_to_4(quick, rng):
    dwell = 10.0 if quick else 60.0
    sess = simulate("paper12", spec="mems-mti1", truth="paper", dwell_s=dwell, rng=rng)
    g = sess.gravity
    truth = _paper_vector(sess.acc_K, sess.acc_b, g)
    idx = np.array([[np.searchsorted(sess.t, a), np.searchsorted(sess.t, b, side="right")]
                    for a, b in sess.static_intervals])
    st = accel.pose_statistics(sess.acc, idx)
    samples = [sess.acc[i0:i1] for i0, i1 in idx]
    fits = {}
    gens = 200 if quick else 500
    for key, ops in (("ga", "paper"), ("ga_optinav", "optinav")):
        step(f"GA ({ops} operators)")
        t0 = time.perf_counter()
        fits[key] = accel.fit_accel(st, g, method="ga", data="samples", samples=samples, rng=rng,
                                    generations=gens, operators=ops)
        fits[key].elapsed_s = time.perf_counter() - t0
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
    vec = {k: _paper_vector(f.K, f.b, g) for k, f in fits.items()}
    rel = {k: 100 * (v - truth) / truth for k, v in vec.items()}
    std_p = np.r_[fits["lm"].std[6:9], fits["lm"].std[:3] * g,
                  fits["lm"].std[3:6] / np.diag(fits["lm"].K)[[0, 0, 1]]]
    rows = []
    for j, nm in enumerate(NAMES):
        pe = [PAPER_REL_ERR[m][j] for m in ("newton", "ga")]
        rows.append([nm, float(truth[j]), float(vec["newton"][j]), float(rel["newton"][j]), pe[0],
                     float(vec["ga"][j]), float(rel["ga"][j]), pe[1], float(rel["ga_optinav"][j]),
                     float(vec["lm"][j]), float(std_p[j]), float(rel["lm"][j])])
    t2 = Table("Table 2: calibration results and relative errors (%) against the truth",
               ["parameter", "truth (paper ref.)", "Newton", "Newton rel. err [%]", "paper Newton [%]",
                "GA (paper's operators)", "GA rel. err [%]", "paper GA [%]", "GA, optinav operators, rel. err [%]",
                "optinav LM", "LM std", "LM rel. err [%]"], rows,
               f"Simulated MTi-1 (datasheet noise incl. bias instability), 12 positions × {dwell:g} s at 100 Hz, "
               f"one session for all methods. B in m/s², S per 1 g input, M in rad. Both GAs ({gens} generations, "
               "population 50) and Newton fit every sample (as in the paper), LM the pose means (the same "
               "least-squares minimum, weighted). The paper's Newton failed on the misalignments (empty cells).")
    t3 = Table("Table 3 — computation time", ["method", "time [s] (optinav)", "time [s] (paper)"],
               [["adaptive GA (paper's operators)", fits["ga"].elapsed_s, PAPER_TIME_S["ga"]],
                ["adaptive GA (optinav operators)", fits["ga_optinav"].elapsed_s, None],
                ["Newton", fits["newton"].elapsed_s, PAPER_TIME_S["newton"]],
                ["optinav LM (pose means)", fits["lm"].elapsed_s, None]],
               "Paper: MATLAB on the authors' PC; optinav: this machine.")

    # Table 4: levelling with each calibration on a static test pose outside the calibration set
    unit = preset("mems-mti1").draw(rng)
    unit = dataclasses.replace(unit, accel=TriadErrors.from_matrix("accel", sess.acc_K, sess.acc_b))
    c = rotations.dcm_from_euler(np.radians([3.0, -5.0, 30.0]), convention="enu")
    tr = static_positions(c[None], 60.0, 100.0, np.radians(38.88), height_m=35.0)
    meas = unit.apply(tr.omega_ib_b, tr.f_b, rng=rng)
    f_true = tr.f_b.mean(axis=0)
    p0, r0 = _level(f_true)
    lrows, lev = [], {}
    for name, (K, b) in {"uncalibrated": (np.eye(3), np.zeros(3)), "Newton": (fits["newton"].K, fits["newton"].b),
                         "adaptive GA": (fits["ga"].K, fits["ga"].b),
                         "adaptive GA, optinav operators": (fits["ga_optinav"].K, fits["ga_optinav"].b),
                         "optinav LM": (fits["lm"].K, fits["lm"].b)
                         }.items():
        f = np.linalg.solve(K, meas.accel.mean(axis=0) - b)
        p, r = _level(f)
        lev[name] = (p - p0, r - r0)
        paper = {"Newton": PAPER_LEVEL_DEG["newton"], "adaptive GA": PAPER_LEVEL_DEG["ga"]}.get(name)
        lrows.append([name, p - p0, r - r0, None if paper is None else paper[0], None if paper is None else paper[1]])
    t4 = Table("Table 4: static levelling error after calibration (deg)",
               ["calibration", "pitch error", "roll error", "paper pitch", "paper roll"], lrows,
               "A 60 s static test pose (roll 3°, pitch −5°) outside the calibration set; pitch/roll from the mean "
               "corrected specific force. The paper's 'traditional' reference: 0.015 / 0.109.")
    z = (vec["lm"] - truth) / std_p
    lm = fits["lm"]
    # tilt error ≈ bias error / g ⊕ misalignment error ⊕ the test pose's own bias drift / g (rad)
    sig_tilt = np.sqrt((np.max(lm.std[6:9]) / (g * lm.K[0, 0])) ** 2 + np.max(lm.std[3:6] / lm.K[0, 0]) ** 2
                       + (np.max(unit.accel_noise.gm_sigma) / g) ** 2)
    lev_limit = float(4 * np.degrees(sig_tilt))
    checks = [Check("LM: max |error|/σ over the 9 parameters", float(np.max(np.abs(z))), 4.0),
              Check("LM faster than the GA (time ratio)", fits["ga"].elapsed_s / fits["lm"].elapsed_s,
                    100.0 if quick else 1000.0, "×", ">="),
              Check("LM scale error vs GA scale error (max |rel. err| ratio)",
                    float(np.max(np.abs(rel["lm"][3:6])) / max(np.max(np.abs(rel["ga"][3:6])), 1e-12)), 1.0, "",
                    "<="),
              Check("LM levelling error (max |pitch|, |roll|), limit 4σ from the fit's std and the test pose's "
                    "bias instability", float(np.max(np.abs(lev["optinav LM"]))), lev_limit, "deg")]
    ga = fits["ga"]

    def draw_fit(fig):
        ax = fig.add_subplot(111)
        gen = np.arange(len(ga.history))
        ax.semilogy(gen, 1 / ga.history, label="best fitness 1/E")
        ax.semilogy(gen, 1 / ga.trace["mean_cost"], label="1 / population mean of E")
        ax.set_xlabel("generation")
        ax.set_ylabel("fitness [1/(m/s²)²]")
        ax.set_title("Adaptive GA with the paper's operators: fitness (paper Fig. 4)")
        ax.legend()
        ax.grid(True, alpha=0.3)

    def draw_conv(fig):
        ax = fig.add_subplot(111)
        bx = ga.trace["best_x"]
        th_true = model.Kb_to_theta(sess.acc_K, sess.acc_b)
        lo, hi = accel.search_interval(st.means, g)
        for j, nm in enumerate(model.ACCEL_PARAMS):
            ax.plot((bx[:, j] - th_true[j]) / (hi[j] - lo[j]), label=nm, lw=1)
        ax.set_xlabel("generation")
        ax.set_ylabel("(best − truth) / search-interval width")
        ax.set_title("GA with the paper's operators: parameter convergence (paper Fig. 5)")
        ax.legend(ncol=3, fontsize=7)
        ax.grid(True, alpha=0.3)

    figs = [Figure("accel_ga_fitness.png", "Best and mean fitness of the adaptive GA (paper's operators) per "
                                           "generation", draw_fit),
            Figure("accel_ga_convergence.png", "Convergence of the GA's best individual, per parameter (paper's "
                                               "operators): gene exchange only recombines values the population "
                                               "already holds, and the adaptive mutation rate of the fitter half "
                                               "is near zero, so the search stalls early", draw_conv)]
    summary = {"truth": truth, "relative_error_percent": {k: v for k, v in rel.items()},
               "time_s": {k: f.elapsed_s for k, f in fits.items()}, "levelling_error_deg": lev}
    t5, found = _findings(rel, fits, lev)
    summary["findings_reproduced"] = found
    return [t2, t3, t4, t5], checks, figs, summary


def _findings(rel, fits, lev):
    """The paper's head-to-head findings, each against the same-session numbers (reproduced or not, and why)."""
    ab = {k: np.abs(v) for k, v in rel.items()}
    bias_ratio = float(np.median(ab["newton"][:3] / np.maximum(ab["ga"][:3], 1e-12)))
    scale_ratio = float(np.median(ab["newton"][3:6] / np.maximum(ab["ga"][3:6], 1e-12)))
    time_ratio = fits["ga"].elapsed_s / fits["newton"].elapsed_s
    mis_ratio = float(np.max(ab["newton"][6:9]) / max(np.max(ab["ga"][6:9]), 1e-12))
    lev_n = float(np.max(np.abs(lev["Newton"])))
    lev_ratio = lev_n / max(float(np.max(np.abs(lev["adaptive GA"]))), 1e-12)
    same_min = ("Newton converges to the least-squares minimum of the same objective (smooth, one minimum near "
                "the start); a GA can only approach that minimum, so it cannot be more accurate")
    rows = [["GA biases 1–3 orders of magnitude more accurate than Newton's", "≥ 10",
             bias_ratio, bias_ratio >= 10, same_min],
            ["GA scale factors 1–3 orders of magnitude more accurate than Newton's", "≥ 10",
             scale_ratio, scale_ratio >= 10, same_min],
            ["GA 61 % faster than Newton (time GA / Newton)", "0.39", time_ratio, time_ratio <= 0.5,
             "a Newton step on 9 parameters costs a few evaluations of the objective with its analytic "
             "derivatives; the GA needs population × generations evaluations"],
            ["Newton fails on the misalignments (max rel. error Newton / GA)", "failed", mis_ratio,
             mis_ratio >= 10, "the 12 positions observe the misalignments (full rank); Newton from the "
             "interval centre converges on them as on the rest"],
            ["Newton levelling error ≈ 0.24°, ≈ 4× the GA's (ratio Newton / GA)", "3.9", lev_ratio,
             lev_ratio >= 2, f"with both at the same minimum the levelling errors agree (Newton {lev_n:.3f}°)"]]
    for r in rows:
        if r[3]:
            r[4] = "reproduced on this session"
        r[3] = "yes" if r[3] else "no"
    table = Table("The paper's head-to-head findings, checked on the same session",
                  ["paper's finding", "paper", "optinav (same data)", "reproduced", "reason"], rows,
                  "GA = the paper's operators, as rebuilt; ratios are medians over the axes where stated.")
    return table, int(sum(r[3] == "yes" for r in rows))


def _efficiency(quick, rng):
    """Monte Carlo of the default estimator on white noise: RMSE/√CRLB per parameter."""
    n_runs = 200 if quick else 1000
    rate, dwell = 100.0, 10.0 if quick else 60.0
    spec = preset("mems-mti1")
    g = 9.80167
    K, b = model.from_paper(PAPER_REFERENCE["S"], PAPER_REFERENCE["M_xy"], PAPER_REFERENCE["M_xz"],
                            PAPER_REFERENCE["M_yz"], PAPER_REFERENCE["B"], g)
    ups = design.design_scheme(12, criterion="D").up_dirs
    sigma = float(np.max(spec.accel_vrw) * np.sqrt(rate))
    eff, _ = accel.efficiency(K, b, ups, g, sigma, int(dwell * rate), n_runs, rng)
    table = Table(f"Efficiency of the default estimator: RMSE/√CRLB over {n_runs} Monte Carlo runs",
                  ["parameter"] + list(model.ACCEL_PARAMS), [["RMSE/√CRLB"] + [f"{x:.3f}" for x in eff]],
                  f"D-optimal 12 poses, {dwell:g} s each at {rate:g} Hz, white noise σ = {sigma:.4g} m/s² per sample.")
    # where an efficient estimator's ratio falls 99 % of the time for all 9 parameters together (Bonferroni)
    lo, hi = rmse_ratio_band(n_runs, 1 - 0.01 / 9)
    return [table], [Check("max RMSE/√CRLB", float(eff.max()), max(hi, 1.1)),
                     Check("min RMSE/√CRLB", float(eff.min()), lo, "", ">=")], [], {"efficiency": eff}


@register_study("accel-ga")
def run(quick: bool = False, rng=None) -> StudyResult:
    rng = np.random.default_rng(rng)
    res = StudyResult(name="accel-ga", title="MEMS accelerometer calibration by norm observation "
                                              "(Gao & Zhang 2019, adaptive GA): the paper's GA rebuilt, against Newton and LM",
                      description=__doc__.split("\n\n", 1)[1].replace("\n", " "))
    spec = preset("mems-mti1")
    sigma = float(np.max(spec.accel_vrw) * np.sqrt(100.0))  # per sample at 100 Hz
    parts = (("Table 1", _table1), ("pose design", lambda rng_: _design(sigma, 100.0, 60.0)),
             ("Tables 2-4", lambda rng_: _tables_2_to_4(quick, rng_)),
             ("efficiency", lambda rng_: _efficiency(quick, rng_)))
    for label, part in parts:
        step(label)
        tables, checks, figs, summary = part(rng)
        res.tables += tables
        res.checks += checks
        res.figures += figs
        res.summary.update(summary)
    rel, t, lev = res.summary["relative_error_percent"], res.summary["time_s"], res.summary["levelling_error_deg"]
    worst = lambda v, sl: float(np.max(np.abs(np.asarray(v)[sl])))  # noqa: E731
    pga = {k: [x for x in v if x is not None] for k, v in PAPER_REL_ERR.items()}
    res.headline = [
        Headline("worst bias relative error", "%", worst(pga["ga"], slice(0, 3)), worst(rel["ga"], slice(0, 3)),
                 worst(rel["lm"], slice(0, 3)), "rebuild = GA with the paper's operators; best = LM; same session"),
        Headline("worst scale-factor relative error", "%", worst(pga["ga"], slice(3, 6)),
                 worst(rel["ga"], slice(3, 6)), worst(rel["lm"], slice(3, 6)), ""),
        Headline("calibration time", "s", PAPER_TIME_S["ga"], t["ga"], t["lm"], "paper: MATLAB; ours: this machine"),
        Headline("worst levelling error", "deg", max(map(abs, PAPER_LEVEL_DEG["ga"])),
                 float(np.max(np.abs(lev["adaptive GA"]))), float(np.max(np.abs(lev["optinav LM"]))), ""),
        Headline("paper's head-to-head findings reproduced (of 5)", "", None,
                 float(res.summary["findings_reproduced"]), None, "see the findings table")]
    return res
