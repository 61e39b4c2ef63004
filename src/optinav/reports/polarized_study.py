"""Study ``polarized``: Jin et al. (2021), MIMU + skylight-polarization attitude by quasi-Newton optimization.

Reproduces the paper's static test (Table 1: mean and spread of the attitude angles) and dynamic test
(Tables 2–3: maximum absolute error and RMS per angle) for gradient descent (Madgwick, ahrs's gain 0.033),
conjugate gradient (same gain), the published quasi-Newton filter and optinav's MEKF with gyro-bias states,
on flights of :func:`optinav.attitude.simulate.simulate_flight` (MPU6000 noise, zenith-viewing point-source
sensor, Rayleigh sky, the sun by the SPA at the paper's place and times). The gyro carries a residual bias of
(0.3, −0.2, 0.25) °/s (an MPU6000 after the autopilot's start-up calibration). The paper's table values are
not in the available text (only its claims: static alike; dynamic QN 50 % lower error than GD and 37–50 %
lower than CG), so the tables put those claims beside our numbers. The paper's reference was the autopilot's
own attitude, ours is simulation truth.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.core.units import G_STANDARD
from optinav.reports.report import Check, Figure, StudyResult, Table, register_study

METHODS = ("gd", "cg", "qn", "mekf")
LABELS = {"gd": "GD (Madgwick)", "cg": "CG", "qn": "QN (paper)", "mekf": "MEKF + gyro bias"}
ANGLES = ("roll", "pitch", "yaw")
GYRO_BIAS_DEG_S = (0.3, -0.2, 0.25)
#: the paper's claims (abstract, §3.2): QN error reduction in the dynamic test
PAPER_QN_VS_GD = 50.0
PAPER_QN_VS_CG = (37.0, 50.0)
#: the paper's quoted sun angles (deg): elevation, azimuth (convention not stated)
PAPER_SUN = {"static": (26.12, -0.8), "dynamic": (2.64, -143.16)}
#: QN settings for the flight (chosen on a different seed than the study's): the default β₀ = 0.5/s suits
#: slow rotations (BROAD); a UAV with 4 m/s² manoeuvres needs a smaller base step
QN_FLIGHT = {"gain": 0.1, "rate_gain": 0.1}
ACCEL_LEVEL = 4.0  # m/s², the simulated manoeuvres


def _mekf_options(spec, dyn: bool, pol_sigma: float) -> dict:
    """MEKF noise from the sensor spec; in flight the manoeuvre accelerations are added as accelerometer noise."""
    rate = spec.sample_rate
    acc_white = float(spec.accel_vrw[0]) * np.sqrt(rate) / G_STANDARD
    acc = float(np.hypot(acc_white, ACCEL_LEVEL / G_STANDARD)) if dyn else acc_white
    tau = float(spec.gyro_bias_corr_time[0])
    bias_rw = float(spec.gyro_bias_instability[0]) * np.sqrt(2.0 / tau)
    return {"gyro_noise": float(spec.gyro_arw[0]), "acc_noise": acc, "bias_noise": max(bias_rw, 1e-6),
            "pol_noise": pol_sigma, "init_bias_std": np.radians(0.5)}


def _run_flight(kind, duration, seed):
    from optinav.attitude import estimate_attitude
    from optinav.attitude.metrics import euler_errors
    from optinav.sky.polarization import wrap_axial
    from optinav.attitude.simulate import simulate_flight
    from optinav.core.imu_model import preset
    from optinav.core.rotations import quat_conjugate, quat_multiply, rotvec_from_quat

    d = simulate_flight(kind, duration_s=duration, rng=seed, gyro_bias=np.radians(GYRO_BIAS_DEG_S))
    pol = d.polarization()
    ok = np.isfinite(d.aop) & np.isfinite(d.aop_true)
    pol_sigma = float(np.std(wrap_axial(d.aop[ok] - d.aop_true[ok])))
    out = {"data": d, "pol_sigma": pol_sigma}
    for m in METHODS:
        opts = dict(QN_FLIGHT) if m == "qn" else {}
        if m == "mekf":
            opts = _mekf_options(preset("mpu6000").replace(sample_rate=1.0 / d.dt), kind == "dynamic", pol_sigma)
        t0 = time.perf_counter()
        r = estimate_attitude(d.gyr, d.acc, d.dt, pol=pol, method=m, frame=d.frame, q0=d.q_true[0], **opts)
        el = time.perf_counter() - t0
        e = np.degrees(euler_errors(r.q, d.q_true, d.frame))
        out[m] = {"res": r, "err": e, "elapsed": el, "options": opts}
        if m == "mekf":
            rv = rotvec_from_quat(quat_multiply(quat_conjugate(d.q_true), r.q))
            out[m]["nees"] = np.sum((rv / r.att_std) ** 2, axis=1)
    return out


@register_study("polarized")
def run(quick: bool = False, rng=None) -> StudyResult:
    from optinav.attitude.metrics import error_statistics

    t_start = time.perf_counter()
    seed0 = 11 if rng is None or not isinstance(rng, (int, np.integer)) else int(rng)
    dur_s, dur_d = (60.0, 60.0) if quick else (300.0, 180.0)
    seeds = [seed0, seed0 + 1, seed0 + 2] if quick else [seed0 + k for k in range(6)]
    skip_s = 500  # the first 5 s: the simulated vehicle rests, the estimators settle from the true start

    static = _run_flight("static", dur_s, seed0)
    dyn = [_run_flight("dynamic", dur_d, s) for s in seeds]
    tables, checks, figures, summary = [], [], [], {}

    # conditions
    rows = []
    for kind, run_ in (("static", static), ("dynamic", dyn[0])):
        d = run_["data"]
        rows.append([kind, d.start_time, f"{np.degrees(np.mean(d.sun_elevation)):.2f}",
                     f"{np.degrees(np.mean(d.sun_azimuth)):.2f}", f"{PAPER_SUN[kind][0]:.2f}",
                     f"{PAPER_SUN[kind][1]:.2f}", f"{np.degrees(run_['pol_sigma']):.3f}",
                     f"{d.metadata['max_rate_deg_s']:.0f}", f"{d.metadata['max_specific_force_m_s2']:.1f}"])
    tables.append(Table("Test conditions (Dalian, 121.528255° E, 38.8814192° N, 35 m)",
                        ["test", "start (local)", "sun elevation [deg] (SPA)", "sun azimuth [deg] (SPA, from N to E)",
                         "paper elevation [deg]", "paper azimuth [deg]", "AoP noise σ [deg]",
                         "max rate [deg/s]", "max |f| [m/s²]"], rows,
                        "The paper's quoted sun angles disagree with the SPA at those local times (issue 6); "
                        "the simulation uses the SPA. Static: 1°, −2°, 30° held; dynamic: random manoeuvres "
                        f"(accelerations up to {ACCEL_LEVEL:g} m/s², tilts ±30°, turns up to 45 °/s)."))

    # Table 1: static
    rows = []
    st = {}
    for m in METHODS:
        s = error_statistics(static[m]["err"][skip_s:])
        st[m] = s
        for k, a in enumerate(ANGLES):
            rows.append([LABELS[m], a, f"{s['mean'][k]:+.4f}", f"{s['std'][k]:.4f}", f"{s['max_abs'][k]:.4f}",
                         f"{s['rms'][k]:.4f}"])
    tables.append(Table(f"Table 1 — static test: attitude error statistics [deg] ({dur_s:g} s at 100 Hz)",
                        ["method", "angle", "mean", "std", "max |e|", "RMS"], rows,
                        "Paper (Table 1, values not in the source text): the three optimization methods show no "
                        "obvious difference in the static test and stay close to the reference. Here GD and CG "
                        "agree; QN as published has no gyro-bias state and corrects in proportion to the error, so "
                        "the residual gyro bias b leaves a constant error ≈ b/β₀ (not reproduced: 'alike')."))
    worst_static = max(float(np.max(st[m]["rms"])) for m in ("gd", "cg", "mekf"))
    # GD chatters by ≤ 2·β·dt = 0.038° around the optimum and rejects the bias (its step has a fixed rate 2β);
    # with the sensor noise the static RMS stays well below 0.2°
    checks.append(Check("static: worst RMS of GD, CG, MEKF (any angle)", worst_static, 0.2, "deg"))
    checks.append(Check("static: GD and CG alike (|difference| of their worst-angle RMS)",
                        abs(float(np.max(st["gd"]["rms"]) - np.max(st["cg"]["rms"]))), 0.1, "deg"))
    # QN corrects in proportion to the error: a constant gyro bias b leaves the error b/β₀ per body axis
    pred = np.asarray(GYRO_BIAS_DEG_S) / QN_FLIGHT["gain"]
    ratio = st["qn"]["mean"] / pred
    checks.append(Check("static: QN mean error / (gyro bias/β₀), smallest over the axes", float(ratio.min()), 0.7,
                        "", ">="))
    checks.append(Check("static: QN mean error / (gyro bias/β₀), largest over the axes", float(ratio.max()), 1.3))
    summary["static_qn_bias_ratio"] = ratio.tolist()
    nees_static = float(np.mean(static["mekf"]["nees"][skip_s:]))
    checks.append(Check("static: MEKF mean NEES (3 dof; consistent ≈ 3) ≤ 3·3", nees_static, 9.0))
    checks.append(Check("static: MEKF mean NEES ≥ 3/3", nees_static, 1.0, "", ">="))
    summary["static_rms_deg"] = {m: st[m]["rms"].tolist() for m in METHODS}
    summary["static_mekf_nees"] = nees_static

    # Tables 2-3: dynamic
    dyn_stats = {m: [error_statistics(r[m]["err"][skip_s:]) for r in dyn] for m in METHODS}
    per_seed = {m: np.array([st["rms"] for st in dyn_stats[m]]) for m in METHODS}
    per_seed_max = {m: np.array([st["max_abs"] for st in dyn_stats[m]]) for m in METHODS}
    rows2, rows3 = [], []
    for m in METHODS:
        mx, rm = per_seed_max[m].mean(0), per_seed[m].mean(0)
        rows2.append([LABELS[m]] + [f"{v:.3f}" for v in mx])
        rows3.append([LABELS[m]] + [f"{v:.3f}" for v in rm])

    def improvement(a, b):  # % by which a is lower than b, averaged over seeds
        return 100.0 * (1.0 - (a / b)).mean(0)

    imp_gd = improvement(per_seed["qn"], per_seed["gd"])
    imp_cg = improvement(per_seed["qn"], per_seed["cg"])
    imp_gd_max = improvement(per_seed_max["qn"], per_seed_max["gd"])
    imp_cg_max = improvement(per_seed_max["qn"], per_seed_max["cg"])
    rows2.append(["QN vs GD: lower by [%] (paper ≈ 50)"] + [f"{v:+.0f}" for v in imp_gd_max])
    rows2.append(["QN vs CG: lower by [%] (paper 37–50)"] + [f"{v:+.0f}" for v in imp_cg_max])
    rows3.append(["QN vs GD: lower by [%] (paper ≈ 50)"] + [f"{v:+.0f}" for v in imp_gd])
    rows3.append(["QN vs CG: lower by [%] (paper 37–50)"] + [f"{v:+.0f}" for v in imp_cg])
    note = (f"Mean over {len(seeds)} simulated flights of {dur_d:g} s (first 5 s excluded). "
            "QN settings for the flight: "
            f"β₀ = {QN_FLIGHT['gain']}/s, κ = {QN_FLIGHT['rate_gain']} (chosen on another seed); GD/CG: β = 0.033. "
            "QN's proportional correction leaves a heading error of (z gyro bias)/β₀, which GD's normalized step "
            "(a bang-bang correction of rate 2β) does not; the MEKF estimates the bias.")
    tables.append(Table("Table 2 — dynamic test: maximum absolute error [deg]", ["method", *ANGLES], rows2, note))
    tables.append(Table("Table 3 — dynamic test: RMS error [deg]", ["method", *ANGLES], rows3, note))
    tilt = lambda m: per_seed[m][:, :2]  # noqa: E731
    checks.append(Check("dynamic: QN roll/pitch RMS lower than GD's in every flight (max ratio QN/GD)",
                        float(np.max(tilt("qn") / tilt("gd"))), 1.0))
    checks.append(Check("dynamic: QN roll/pitch RMS lower than CG's in every flight (max ratio QN/CG)",
                        float(np.max(tilt("qn") / tilt("cg"))), 1.0))
    checks.append(Check("dynamic: MEKF RMS lower than GD's, every angle and flight (max ratio MEKF/GD)",
                        float(np.max(per_seed["mekf"] / per_seed["gd"])), 1.0))
    checks.append(Check("dynamic: polarization keeps the heading: worst yaw RMS of any method", float(
        max(per_seed[m][:, 2].max() for m in METHODS)), 5.0, "deg"))
    nees_dyn = float(np.mean([np.mean(r["mekf"]["nees"][skip_s:]) for r in dyn]))
    summary.update({"dynamic_rms_deg": {m: per_seed[m].mean(0).tolist() for m in METHODS},
                    "dynamic_max_abs_deg": {m: per_seed_max[m].mean(0).tolist() for m in METHODS},
                    "qn_vs_gd_rms_lower_pct": imp_gd.tolist(), "qn_vs_cg_rms_lower_pct": imp_cg.tolist(),
                    "dynamic_mekf_nees": nees_dyn,
                    "elapsed_per_method_s": {m: dyn[0][m]["elapsed"] for m in METHODS}})

    # figures
    d0 = dyn[0]

    def draw_dyn(fig):
        t = d0["data"].t
        axs = fig.subplots(3, 1, sharex=True)
        for k, a in enumerate(ANGLES):
            for m in METHODS:
                axs[k].plot(t, d0[m]["err"][:, k], lw=0.7, label=LABELS[m])
            axs[k].set_ylabel(f"{a} error [deg]")
            axs[k].grid(alpha=0.3)
        axs[0].legend(fontsize=7, ncol=4)
        axs[-1].set_xlabel("t [s]")
        axs[0].set_title("Dynamic test: attitude errors (cf. the paper's Fig. 6)")

    def draw_static(fig):
        t = static["data"].t
        axs = fig.subplots(3, 1, sharex=True)
        for k, a in enumerate(ANGLES):
            for m in METHODS:
                axs[k].plot(t[skip_s:], static[m]["err"][skip_s:, k], lw=0.7, label=LABELS[m])
            axs[k].set_ylabel(f"{a} error [deg]")
            axs[k].grid(alpha=0.3)
        axs[0].legend(fontsize=7, ncol=4)
        axs[-1].set_xlabel("t [s]")
        axs[0].set_title("Static test: attitude errors (cf. the paper's Fig. 4)")

    def draw_bars(fig):
        ax = fig.add_subplot(111)
        w = 0.2
        for j, m in enumerate(METHODS):
            ax.bar(np.arange(3) + (j - 1.5) * w, per_seed[m].mean(0), w, yerr=per_seed[m].std(0), label=LABELS[m])
        ax.set_xticks(range(3), ANGLES)
        ax.set_ylabel("RMS error [deg]")
        ax.set_title(f"Dynamic test: RMS error, mean ± std over {len(seeds)} flights")
        ax.legend(fontsize=8)
        ax.grid(axis="y", alpha=0.3)

    def draw_mekf(fig):
        t = d0["data"].t
        r = d0["mekf"]
        axs = fig.subplots(3, 1, sharex=True)
        for k, a in enumerate(ANGLES):
            axs[k].plot(t, r["err"][:, k], lw=0.7, label="Euler error")
            axs[k].plot(t, 3 * np.degrees(r["res"].att_std[:, k]), "k--", lw=0.7, label="±3σ (body axis)")
            axs[k].plot(t, -3 * np.degrees(r["res"].att_std[:, k]), "k--", lw=0.7)
            axs[k].set_ylabel(f"{a} [deg]")
            axs[k].grid(alpha=0.3)
        axs[0].legend(fontsize=7)
        axs[-1].set_xlabel("t [s]")
        axs[0].set_title("MEKF error and its 3σ (dynamic flight)")

    figures += [Figure("polarized_dynamic_errors.png", "Dynamic flight: roll, pitch, yaw errors of GD, CG, QN, MEKF",
                       draw_dyn, (8, 7)),
                Figure("polarized_static_errors.png", "Static test: roll, pitch, yaw errors", draw_static, (8, 7)),
                Figure("polarized_dynamic_rms.png", "Dynamic RMS per angle and method", draw_bars, (7, 4)),
                Figure("polarized_mekf_sigma.png", "MEKF error with its ±3σ", draw_mekf, (8, 7))]
    return StudyResult(
        name="polarized", title="Jin et al. 2021 — MIMU + skylight polarization attitude: GD vs CG vs QN vs MEKF",
        description=__doc__.split("\n\n", 1)[1].replace("\n", " "), tables=tables, checks=checks, figures=figures,
        summary=summary, elapsed=time.perf_counter() - t_start)
