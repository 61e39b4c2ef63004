"""Study ``rins-pso``: Li, Yu, Wei & Luo, "Optimal calibration method for nonorthogonal errors in dual-axis
rotational RLG INS", Infrared and Laser Engineering 52(6) 20230148, 2023.

Reproduced by simulation (the paper's data are not public): a static base at 28.2° N, an alignment phase, one
PSINS improved 16-position cycle at 200 Hz, the rlg-nav IMU of the paper's Table 1 (5″ residual gyro
misalignment), and the two effects the paper names as its dominant residual: a gimbal lock (electric lock)
error of 10″ (1σ) at every stop, unseen by the encoders, and an axis wobble of 10″ amplitude. A second session
with 30″ gyro misalignment shows the effect the paper blames for the previous method's weakness. True angles:
the paper's Table 3 read as radians (see the units finding). All methods calibrate the same session with the
same residual epochs; PSO runs as published (no tuning), LM and the previous method have nothing to tune.
Outputs: Table 4 for all methods beside the paper's, the PSO convergence curves (Fig. 5), the attitude error
curves (Figs. 6 to 8), the Monte Carlo of PSO (Fig. 10) and the observability.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.core.progress import progress, step
from optinav.core.rotations import dcm_from_euler
from optinav.core.validate import as_rng
from optinav.reports.report import Check, Figure, Headline, StudyResult, Table, register_study
from optinav.rins.calibrate import attitude_errors, calibrate, prepare
from optinav.rins.model import PARAM_NAMES, residuals, sensor_attitude
from optinav.rins.simulate import PAPER_TABLE3, simulate

#: Table 4 of the paper, RMSE [deg] as [roll, pitch, yaw] (the paper lists pitch, roll, yaw)
PAPER_TABLE4 = {"none": [0.0779, 0.2025, 0.9263], "axis": [0.0200, 0.0252, 0.0129], "pso": [0.0054, 0.0027, 0.0024]}
PAPER_MC_SPREAD_DEG = 0.0013
LABEL = {"none": "uncompensated", "axis": "previous method (axis vectors)", "pso": "PSO (paper)",
         "lm": "LM, observable subspace (optinav)"}
ARCSEC = np.radians(1 / 3600)
#: the paper-like unmodelled effects of the study's sessions (rad): lock error 1σ and wobble amplitude
LOCK, WOBBLE = 10 * ARCSEC, 10 * ARCSEC


def _units_finding(rate=5.0):
    """Uncompensated RMSE of a noise-free chain with Table 3 read as degrees and as radians."""
    d = simulate(np.zeros(6), noise=False, imu_errors=False, rate_hz=rate, align_s=600.0)
    k = d.t >= 600.0
    a, b = d.alpha[k], d.beta[k]
    cb = dcm_from_euler(np.radians([0.5, -0.3, 30.0]), "enu")
    out = {}
    for name, p in (("deg", np.radians(PAPER_TABLE3)), ("rad", PAPER_TABLE3)):
        cs = sensor_attitude(np.broadcast_to(cb, (a.size, 3, 3)), a, b, p)
        r = residuals(cs, a, b, np.zeros(6)).reshape(-1, 3)
        out[name] = np.degrees(np.sqrt(np.mean(r**2, axis=0)))
    return out


@register_study("rins-pso")
def run(quick: bool = False, rng=None) -> StudyResult:
    t_start = time.perf_counter()
    gen = as_rng(0 if rng is None else rng)
    truth = PAPER_TABLE3.copy()  # radians (units finding)
    dwell, align = (20.0, 300.0) if quick else (50.0, 600.0)
    step("simulate the session")
    data = simulate(truth, scheme="psins16", move_s=10.0, dwell_s=dwell, align_s=align, rate_hz=200.0,
                    lock_sigma=LOCK, wobble=WOBBLE, rng=gen)
    rr = 2.0 if quick else 10.0
    prep = prepare(data, residual_rate=rr)
    sys_kw = dict(gyro_misalignment=5 * ARCSEC)
    step("previous method and LM")
    res = {m: calibrate(method=m, prep=prep, rng=gen, search=0.02, **sys_kw) for m in ("none", "axis", "lm")}
    # PSO Monte Carlo (random initial swarms) on 2 Hz residual epochs
    step("PSO Monte Carlo")
    n_mc = 4 if quick else 50
    prep_mc = prep if rr == 2.0 else prepare(data, residual_rate=2.0, sa=prep.full)
    mc = [calibrate(method="pso", prep=prep_mc, rng=gen, search=0.02, **sys_kw)
          for _ in progress(range(n_mc), desc="PSO runs")]
    res["pso"] = mc[0] if rr == 2.0 else calibrate(method="pso", prep=prep, rng=gen, search=0.02, **sys_kw)
    lm_mc = calibrate(method="lm", prep=prep_mc, **sys_kw)
    pso_small = calibrate(method="pso", prep=prep_mc, rng=gen, search=0.02, small_angle=True, **sys_kw)
    units = _units_finding()
    # sensitivity to the gyro triad's misalignment (30″ 1σ): axis method vs LM
    step("30″ gyro misalignment session")
    data30 = simulate(truth, scheme="psins16", move_s=10.0, dwell_s=dwell, align_s=align, rate_hz=200.0,
                      gyro_misalignment=30 * ARCSEC, lock_sigma=LOCK, wobble=WOBBLE, rng=gen)
    prep30 = prepare(data30, residual_rate=rr)
    res30 = {m: calibrate(method=m, prep=prep30, gyro_misalignment=30 * ARCSEC) for m in ("none", "axis", "lm")}

    nrm = lambda r: float(np.linalg.norm(r.rmse_after_deg))  # noqa: E731
    ratio_axis, ratio_lm = nrm(res["axis"]) / nrm(res["pso"]), nrm(res["lm"]) / nrm(res["pso"])
    ratio_paper = float(np.linalg.norm(PAPER_TABLE4["axis"]) / np.linalg.norm(PAPER_TABLE4["pso"]))

    # --- tables --------------------------------------------------------------------------------------------
    rows = []
    for m in ("none", "axis", "pso", "lm"):
        paper = PAPER_TABLE4.get(m, ["—"] * 3)
        rows.append([LABEL[m], *paper, *[round(x, 5) for x in res[m].rmse_after_deg], round(res[m].elapsed_s, 3)])
    rows.append(["PSO, small-angle particles (eqs. 10–11), 2 Hz epochs", "—", "—", "—",
                 *[round(x, 5) for x in pso_small.rmse_after_deg], round(pso_small.elapsed_s, 3)])
    t4 = Table("Table 4: vehicle attitude RMSE [deg], paper vs this simulation",
               ["method", "paper roll", "paper pitch", "paper yaw", "ours roll", "ours pitch", "ours yaw",
                "time [s]"], rows,
               note=f"{data.t[-1] - align:.0f} s after a {align:.0f} s alignment; residual epochs {rr:g} Hz; "
                    "true angles = Table 3 read as radians; gyro misalignment 5″ (1σ); lock error "
                    f"{LOCK / ARCSEC:g}″ (1σ) and wobble {WOBBLE / ARCSEC:g}″. All methods on the same session. "
                    f"Here the previous method's RMSE is {ratio_axis:.2f}× PSO's (paper: "
                    f"{ratio_paper:.1f}×) and LM's {ratio_lm:.2f}× PSO's: the paper's advantage of PSO over the "
                    "previous method is not reproduced; with the lock error and wobble all three methods end near "
                    "the paper's PSO level, which these unmodelled effects set.")
    t30 = Table("Gyro misalignment 30″ (1σ): vehicle attitude RMSE [deg]", ["method", "roll", "pitch", "yaw"],
                [[LABEL[m], *[round(x, 5) for x in res30[m].rmse_after_deg]] for m in ("none", "axis", "lm")],
                note="The gyros' misalignment turns the measured rotations, so it biases the axis vectors and the "
                     "strapdown attitude alike; the residual attitude error it leaves cannot be removed by the six "
                     "gimbal angles.")
    arows = []
    for i, nm in enumerate(PARAM_NAMES):
        arows.append([nm, float(truth[i]), *[res[m].angles[nm] for m in ("axis", "pso", "lm")]])
    for c in res["lm"].combinations:
        if " " in c["name"]:
            tv = float(np.dot(c["coefficients"], truth))
            vals = [next(x["value"] for x in res[m].combinations if x["name"] == c["name"])
                    for m in ("axis", "pso", "lm")]
            arows.append([c["name"], tv, *[float(v) for v in vals]])
    tang = Table("Table 3: calibrated angles [rad] (— = not observable)", ["angle", "truth", "axis", "PSO", "LM"],
                 arows, note="theta_z − eta_z and eta_y do not change the attitude change of eq. 12 (rank 4/6): "
                             "the paper's separate values of theta_z, eta_z and eta_y are not determined by its data.")
    raw = np.array([r.options["p_raw"] for r in mc])
    spread = {"theta_z+eta_z": float(np.std(raw[:, 2] + raw[:, 5])),
              "theta_z-eta_z": float(np.std(raw[:, 2] - raw[:, 5])),
              "eta_y": float(np.std(raw[:, 4])), "theta_x": float(np.std(raw[:, 0]))}
    mc_rmse = np.array([r.rmse_after_deg for r in mc])
    tmc = Table(f"Monte Carlo of PSO ({n_mc} random initial swarms, Fig. 10)",
                ["quantity", "value"],
                [*[[f"RMSE {a}, mean over runs [deg]", float(x)] for a, x in zip(("roll", "pitch", "yaw"),
                                                                                    mc_rmse.mean(0))],
                 ["RMSE spread max−min (norm) [deg]", float(np.ptp(np.linalg.norm(mc_rmse, axis=1)))],
                 ["paper: spread within [deg] (one run of 50 fluctuating)", PAPER_MC_SPREAD_DEG],
                 *[[f"std of PSO's raw {k} over runs [rad]", v] for k, v in spread.items()]])
    tu = Table("Units finding: uncompensated RMSE [deg] of the noise-free chain with Table 3's angles",
               ["reading of Table 3", "roll", "pitch", "yaw"],
               [["degrees (as labelled)", *np.round(units["deg"], 5)], ["radians", *np.round(units["rad"], 5)],
                ["paper Table 4, uncompensated", *PAPER_TABLE4["none"]]],
               note="Read as radians, Table 3 reproduces Table 4's uncompensated roll and yaw within 1 % and pitch "
                    "within a factor 1.8; read as degrees the errors are 50–100× too small. Table 3 is in radians.")
    tobs = Table("Observability of the six angles (first-order Jacobian, 16-position scheme)", ["", "value"],
                 [["rank", res["lm"].observability["rank"]],
                  ["singular values (scaled by 1 mrad)",
                   " ".join(f"{x:.3g}" for x in res["lm"].observability["singular_values"])],  # one cell
                  *[["statement", s] for s in res["lm"].observability["statements"]]])

    # --- checks ----------------------------------------------------------------------------------------------
    f = lambda r: float(np.linalg.norm(r.rmse_after_deg))  # noqa: E731
    checks = [Check("|observability rank − 4| (theory: rank 4, null = theta_z − eta_z, eta_y)",
                    abs(res["lm"].observability["rank"] - 4), 0),
              Check("LM attitude RMSE / PSO attitude RMSE (same residual epochs)", f(lm_mc) / min(f(r) for r in mc),
                    1.0 + 1e-9),
              # PSO as published does not always converge in 150 generations (docs/methods/rins.md): the check
              # asks that most runs do; the fraction itself is the finding, reported beside the paper's 49 of 50
              Check("PSO Monte Carlo: fraction of runs within 0.0013° of the best (paper: 49 of 50; "
                    "finding, must exceed one half)",
                    float(np.mean(np.linalg.norm(mc_rmse, axis=1) - np.linalg.norm(mc_rmse, axis=1).min()
                                  <= PAPER_MC_SPREAD_DEG)), 0.5, kind=">="),
              Check("LM attitude RMSE / axis-method attitude RMSE", f(res["lm"]) / f(res["axis"]), 1.0),
              Check("LM / axis-method attitude RMSE, 30″ gyro misalignment", f(res30["lm"]) / f(res30["axis"]), 1.0),
              Check("LM attitude RMSE / uncompensated", f(res["lm"]) / f(res["none"]), 0.05),
              Check("|ln(yaw RMSE uncompensated, Table 3 as radians / paper)| (expect ≈ 0)",
                    abs(np.log(units["rad"][2] / PAPER_TABLE4["none"][2])), np.log(1.2)),
              Check("yaw RMSE uncompensated, Table 3 as degrees / paper (expect ≪ 1)",
                    units["deg"][2] / PAPER_TABLE4["none"][2], 0.1)]
    for c in res["lm"].combinations:
        tv = float(np.dot(c["coefficients"], truth))
        checks.append(Check(f"LM |{c['name']} − truth| / reported std", abs(c["value"] - tv) / c["std"], 4.0))
    if n_mc >= 3:
        checks.append(Check("PSO spread of unobservable theta_z − eta_z / observable theta_z + eta_z",
                            spread["theta_z-eta_z"] / max(spread["theta_z+eta_z"], 1e-12), 10.0, kind=">="))

    # --- figures ---------------------------------------------------------------------------------------------
    t = prep.t[1:] - prep.t[0]
    curves = {m: np.degrees(attitude_errors(prep, res[m].p)) for m in ("none", "axis", "pso", "lm")}
    colors = {"none": "r", "axis": "b", "pso": "g", "lm": "k"}

    def conv(fig):
        ax = fig.add_subplot(111)
        for r in mc:
            ax.semilogy(r.fitness_history_deg, lw=0.7, color="g", alpha=0.6)
        ax.axhline(np.sqrt(np.sum(np.square(lm_mc.rmse_after_deg))), color="k", ls="--", label="LM optimum")
        ax.set_xlabel("generation")
        ax.set_ylabel("fitness F [deg]")
        ax.legend()

    styles = {"none": "-", "axis": "-", "pso": "--", "lm": ":"}

    def att(k):
        def draw(fig):
            # |error| on a log axis: the calibrated curves sit 100× below the uncompensated one
            ax = fig.add_subplot(111)
            for m in ("none", "axis", "pso", "lm"):
                ax.semilogy(t, np.maximum(np.abs(curves[m][:, k]), 1e-6), colors[m], ls=styles[m], lw=0.9,
                            label=LABEL[m])
            ax.set_xlabel("time since navigation start [s]")
            ax.set_ylabel(f"|{('roll', 'pitch', 'yaw')[k]} error| [deg]")
            ax.grid(True, which="major", alpha=0.3)
            ax.legend(fontsize=7)
        return draw

    def mcfig(fig):
        ax = fig.add_subplot(111)
        from matplotlib.ticker import MaxNLocator

        for k, nm in enumerate(("roll", "pitch", "yaw")):
            line, = ax.plot(np.arange(1, n_mc + 1), mc_rmse[:, k], "o-", ms=3, label=f"PSO, {nm}")
            ax.axhline(lm_mc.rmse_after_deg[k], color=line.get_color(), ls="--", lw=0.8, label=f"LM, {nm}")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("Monte Carlo run")
        ax.set_ylabel("attitude RMSE [deg]")
        ax.legend(fontsize=7, ncol=3)

    figs = [Figure("rins_fig5_convergence.png", "Fig. 5: PSO fitness over generations (each MC run)", conv),
            *[Figure(f"rins_fig{6 + k}_{nm}.png", f"Fig. {6 + k}: vehicle {nm} error by method", att(k))
              for k, nm in enumerate(("roll", "pitch", "yaw"))],
            Figure("rins_fig10_montecarlo.png", "Fig. 10: attitude RMSE of the PSO Monte Carlo runs", mcfig)]
    summary = {"rmse_deg": {m: res[m].rmse_after_deg for m in res}, "elapsed_s": {m: res[m].elapsed_s for m in res},
               "units_rmse_deg": {k: v.tolist() for k, v in units.items()}, "pso_mc_rmse_deg": mc_rmse.tolist(),
               "pso_raw_spread_rad": spread, "speedup_lm_vs_pso": res["pso"].elapsed_s / max(res["lm"].elapsed_s, 1e-9)}
    headline = [Headline("attitude RMSE (norm of roll, pitch, yaw), PSO", "deg",
                         float(np.linalg.norm(PAPER_TABLE4["pso"])), nrm(res["pso"]), nrm(res["lm"]),
                         "rebuild = PSO as published, best = LM; same session and residual epochs"),
                Headline("previous method RMSE / PSO RMSE", "×", ratio_paper, ratio_axis, None,
                         "not reproduced: the previous method is about as good as PSO here"),
                Headline("LM RMSE / PSO RMSE", "×", None, None, ratio_lm, ""),
                Headline("calibration time, PSO vs LM", "s", None, res["pso"].elapsed_s, res["lm"].elapsed_s, "")]
    summary.update({"ratio_axis_over_pso": ratio_axis, "ratio_lm_over_pso": ratio_lm,
                    "ratio_axis_over_pso_paper": ratio_paper, "lock_sigma_rad": LOCK, "wobble_rad": WOBBLE})
    return StudyResult(
        name="rins-pso", headline=headline, title="Dual-axis rotational INS gimbal non-orthogonality: PSO vs axis method vs LM",
        description=(__doc__ or "").split("\n\n", 1)[1].replace("\n", " "),
        tables=[t4, t30, tang, tu, tmc, tobs], checks=checks, figures=figs, summary=summary,
        elapsed=time.perf_counter() - t_start)
