"""Study ``core``: checks of the shared core against published values and analytic truth.

Each section is a function ``(quick, rng) -> (tables, checks, figures, summary)``; the numbers come from
references (NIMA TR8350.2, PSINS glv, Ignagni 1990, IEEE Std 952) or exact identities.
"""

from __future__ import annotations

import numpy as np

from optinav.core.progress import step
from optinav.core import alignment, allan, earth, imu_model, rotations, simulate, strapdown
from optinav.reports.report import Check, Figure, Headline, StudyResult, Table, register_study


def _earth_section(quick, rng):
    lats = np.radians(np.arange(0, 91, 15.0))
    g_w = earth.gravity(lats)
    g_p = earth.gravity(lats, earth="psins")
    rows = [[float(np.degrees(la)), f"{a:.10f}", f"{b:.10f}", float((b - a) / 9.80665e-6)] for la, a, b in zip(lats, g_w, g_p)]
    table = Table("Normal gravity at sea level: WGS-84 (Somigliana) vs PSINS formula",
                  ["latitude [deg]", "WGS-84 [m/s²]", "PSINS [m/s²]", "PSINS − WGS-84 [μg]"], rows,
                  "Reference: NIMA TR8350.2 γ_e = 9.7803253359, γ_p = 9.8321849378 m/s².")
    checks = [Check("WGS-84 γ at equator − TR8350.2", abs(earth.gravity(0.0) - 9.7803253359), 1e-9, "m/s²"),
              Check("WGS-84 γ at pole − TR8350.2", abs(earth.gravity(np.pi / 2) - 9.8321849378), 1e-8, "m/s²"),
              Check("max |PSINS − WGS-84| gravity", float(np.max(np.abs(g_p - g_w)) / 9.80665e-6), 10.0, "μg")]

    def draw(fig):
        ax = fig.add_subplot(111)
        la = np.linspace(0, 90, 181)
        ax.plot(la, (earth.gravity(np.radians(la), earth="psins") - earth.gravity(np.radians(la))) / 9.80665e-6)
        ax.set_xlabel("latitude [deg]")
        ax.set_ylabel("PSINS − WGS-84 gravity [μg]")
        ax.grid(True)

    fig = Figure("core_gravity_models.png", "Difference of the PSINS gravity formula from WGS-84 normal gravity", draw)
    return [table], checks, [fig], {"gravity_wgs84": g_w, "gravity_psins": g_p}


def _rotation_section(quick, rng):
    n = 20_000 if quick else 200_000
    e = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-np.pi, np.pi, n)])
    rows, checks = [], []
    for conv in ("ned", "enu"):
        c = rotations.dcm_from_euler(e, conv)
        err_e = np.max(np.abs(rotations.euler_from_quat(rotations.quat_from_dcm(c), conv) - e))
        err_o = np.max(np.abs(c @ np.swapaxes(c, -1, -2) - np.eye(3)))
        rows.append([conv, n, float(err_e), float(err_o)])
        checks.append(Check(f"Euler→DCM→quat→Euler round trip ({conv})", float(err_e), 1e-9, "rad"))
    table = Table("Rotation conversions on random attitudes", ["convention", "samples", "max round-trip error [rad]",
                                                                "max |CCᵀ − I|"], rows)
    return [table], checks, [], {}


def _imu_noise_section(quick, rng):
    """Allan deviation of simulated MTi-1-class gyro noise: the IEEE 952 read-off recovers the spec."""
    spec = imu_model.preset("mems-mti1")
    unit = spec.draw(rng, errors=False)
    hours = 2.0 if quick else 6.0
    n, dt = int(hours * 3600 * spec.sample_rate), 1.0 / spec.sample_rate
    w = unit.gyro_noise.sample(n, dt, rng)[:, 0]  # rad/s, x axis
    ad = allan.allan_deviation(w, dt, kind="rate")
    par = allan.noise_parameters_from_allan(ad)
    arw_true, bi_true = float(spec.gyro_arw[0]), float(spec.gyro_bias_instability[0])
    arw_est, bi_est = float(np.atleast_1d(par.white)[0]), float(np.atleast_1d(par.bias_instability)[0])
    deg_h = 180 / np.pi * 3600
    rows = [["ARW [deg/√h]", arw_true * 180 / np.pi * 60, arw_est * 180 / np.pi * 60,
             100 * (arw_est / arw_true - 1)],
            ["bias instability [deg/h]", bi_true * deg_h, bi_est * deg_h, 100 * (bi_est / bi_true - 1)]]
    table = Table(f"Gyro noise read from the Allan deviation of {hours:g} h of simulated MTi-1-class data",
                  ["term", "spec", "read off", "difference [%]"], rows,
                  "IEEE Std 952 Annex C read-off; bias instability simulated as a Gauss–Markov process.")
    # EDF-based: white noise at τ ≈ 1 s has thousands of degrees of freedom (≈1 %); the flat floor of a
    # Gauss–Markov process is read at τ ~ 2τ_c with far fewer (≈10–30 %)
    checks = [Check("ARW read-off error", abs(arw_est / arw_true - 1) * 100, 5.0, "%"),
              Check("bias-instability read-off error", abs(bi_est / bi_true - 1) * 100, 35.0, "%")]

    def draw(fig):
        ax = fig.add_subplot(111)
        ax.loglog(ad.tau, ad.adev * deg_h, "o-", ms=3, label="simulated")
        ax.fill_between(ad.tau, ad.lower * deg_h, ad.upper * deg_h, alpha=0.3, label="68 % interval")
        model = allan.allan_deviation_model(ad.tau, white=arw_true, gm_sigma=unit.gyro_noise.gm_sigma[0],
                                            gm_tau=unit.gyro_noise.gm_tau[0])
        ax.loglog(ad.tau, model * deg_h, "k--", label="model")
        ax.set_xlabel("τ [s]")
        ax.set_ylabel("Allan deviation [deg/h]")
        ax.grid(True, which="both", alpha=0.4)
        ax.legend()

    return [table], checks, [Figure("core_allan_gyro.png", "Allan deviation of simulated MTi-1-class gyro noise",
                                    draw)], {"arw_rel_error": arw_est / arw_true - 1,
                                             "bias_instability_rel_error": bi_est / bi_true - 1}


def _alignment_section(quick, rng):
    """Static alignment of a navigation-grade unit: coarse and Kalman fine alignment vs the theoretical limits."""
    frame, lat, h = "enu", np.radians(34.25), 400.0
    spec = imu_model.preset("rlg-nav")
    unit = spec.draw(rng)
    c_true = rotations.dcm_from_euler([0.002, -0.003, 1.1], frame)
    T = 300.0 if quick else 900.0
    truth = simulate.static_positions(c_true[None], T, 100.0, lat, h, frame=frame)
    meas = unit.apply(truth.dtheta, truth.dv, truth.dt, rng=rng, kind="increment")
    span = truth.t[-1] - truth.t[0]
    coarse = alignment.coarse_alignment(meas.accel.sum(0) / span, meas.gyro.sum(0) / span, lat, h, frame)
    fine = alignment.fine_alignment(truth.t, meas.gyro, meas.accel, lat, h, frame=frame,
                                    gyro_white=unit.gyro_noise.white[0], accel_white=unit.accel_noise.white[0],
                                    gyro_bias_std=float(spec.gyro_bias[0]), accel_bias_std=float(spec.accel_bias[0]),
                                    gyro_bias_instability=unit.gyro_noise.gm_sigma[0],
                                    gyro_bias_tau=unit.gyro_noise.gm_tau[0],
                                    accel_bias_instability=unit.accel_noise.gm_sigma[0],
                                    accel_bias_tau=unit.accel_noise.gm_tau[0])
    limit = alignment.alignment_limits(c_true @ unit.gyro.bias, c_true @ unit.accel.bias, lat, h, frame)
    e_c = alignment.attitude_error(coarse.dcm_b_n, c_true)
    e_f = alignment.attitude_error(fine.dcm_b_n, c_true)
    g = float(earth.gravity(lat, h))
    sig = np.array([unit.accel_noise.white[0] / g, unit.accel_noise.white[0] / g,
                    unit.gyro_noise.white[0] / (earth.WGS84.omega_ie * np.cos(lat))]) / np.sqrt(span)
    instab = np.abs(alignment.alignment_limits(np.full(3, unit.gyro_noise.gm_sigma[0]),
                                               np.full(3, unit.accel_noise.gm_sigma[0]), lat, h, frame))
    arcsec = 180 / np.pi * 3600
    rows = [[ax, limit[i] * arcsec, e_c[i] * arcsec, e_f[i] * arcsec, fine.attitude_std[i] * arcsec,
             sig[i] * arcsec] for i, ax in enumerate(["east (level)", "north (level)", "up (heading)"])]
    table = Table(f"Static alignment of an rlg-nav unit, {span:g} s at 34.25° N (errors φ, arcsec)",
                  ["axis", "theoretical limit", "coarse", "Kalman fine", "Kalman 1σ", "noise 1σ over window"], rows,
                  "Limit: level = ∇/g, heading = −ε_E/(ω_ie cos L) + ∇_E tan L/g from the unit's drawn biases. "
                  "Kalman heading (gyrocompassing) reads the tilt rate and is limited by the in-run accelerometer "
                  "drift (Gauss–Markov, modelled in the filter), so averaging (coarse) can beat it on a drifting "
                  "unit; the filter's σ states its accuracy.")
    tol = 4 * sig + 3 * instab
    checks = [Check(f"|coarse − limit| / tolerance, {ax}", float(abs(e_c[i] - limit[i]) / tol[i]), 1.0)
              for i, ax in enumerate(["east", "north", "up"])]
    checks += [Check(f"|fine − limit| / tolerance, {ax}", float(abs(e_f[i] - limit[i]) / tol[i]), 1.0)
               for i, ax in enumerate(["east", "north"])]
    # gyrocompass heading is limited by the accelerometer bias drift, which the filter models: its σ must be honest
    checks.append(Check("|fine heading error| / (3 Kalman σ)", float(abs(e_f[2]) / (3 * fine.attitude_std[2])), 1.0,
                        note=f"the heading error itself ({e_f[2] * arcsec:+.0f}″) is far beyond the bias limit "
                             f"({limit[2] * arcsec:+.0f}″): in {span:g} s gyrocompassing is limited by the "
                             "accelerometer bias drift, and the filter says so through its σ"))

    def draw(fig):
        e_hist = np.array([alignment.attitude_error(rotations.dcm_from_euler(e, frame), c_true)
                           for e in fine.history_euler]) * arcsec
        s_hist = fine.history_attitude_std * arcsec
        for i, name in enumerate(["east tilt", "north tilt", "heading"]):
            ax = fig.add_subplot(1, 3, i + 1)
            ax.plot(fine.history_t, e_hist[:, i], label="error")
            ax.fill_between(fine.history_t, -3 * s_hist[:, i], 3 * s_hist[:, i], alpha=0.25, label="±3σ")
            ax.axhline(limit[i] * arcsec, color="k", ls="--", label="limit")
            ax.set_title(name)
            ax.set_xlabel("t [s]")
            if i == 0:
                ax.set_ylabel("φ [arcsec]")
                ax.legend(fontsize=7)
            # the axis holds the error, the limit and the ±3σ band once the filter has left its initial spread
            settled = fine.history_t >= fine.history_t[0] + 0.2 * (fine.history_t[-1] - fine.history_t[0])
            lim = 1.15 * max(abs(limit[i]) * arcsec, np.max(np.abs(e_hist[settled, i])),
                             3 * np.max(s_hist[settled, i]))
            ax.set_ylim(-lim, lim)

    fig = Figure("core_fine_alignment.png", "Kalman fine alignment: error, ±3σ and the theoretical limit", draw,
                 size=(10.0, 3.5))
    return [table], checks, [fig], {"alignment_limit_rad": limit, "coarse_error_rad": e_c, "fine_error_rad": e_f}


def _strapdown_section(quick, rng):
    """Attitude drift of each coning algorithm under exact coning motion vs Ignagni's theory."""
    alpha, freq, rate = np.radians(0.1), 10.0, 200.0
    duration = 5.0 if quick else 50.0
    truth = simulate.coning(alpha, freq, duration, rate)
    per = int(round(rate / freq))  # samples per cone period
    deg_h = 180 / np.pi * 3600
    rows, checks, drift = [], [], {}
    for alg in strapdown.CONING_ALGORITHMS:
        q = strapdown.attitude_update(truth.q_b_n[0], truth.dtheta, coning=alg)
        idx = strapdown.output_indices(truth.dtheta.shape[0], alg)
        # whole cone periods (periodic error terms cancel) that also close a full group of the algorithm (the
        # trailing partial group is integrated by a lower-order step, whose one-off error would bias the slope)
        keep = (idx % per == 0) & (idx % strapdown.CONING_ALGORITHMS[alg] == 0)
        c_true = rotations.dcm_from_quat(truth.q_b_n[idx[keep]])
        c_est = rotations.dcm_from_quat(q[keep])
        err_n = np.einsum("kij,kj->ki", c_true, rotations.rotvec_from_dcm(np.swapaxes(c_true, -1, -2) @ c_est))
        # drift = slope of the error about the cone axis; a fit removes the start-up offset of "previous"
        measured = float(np.polyfit(truth.t[idx[keep]], err_n[:, 2], 1)[0])
        theory = strapdown.coning_drift_rate(alg, alpha, freq, 1.0 / rate)
        drift[alg] = measured
        rel = abs(measured - theory) / abs(theory) * 100
        rows.append([alg, theory * deg_h, measured * deg_h, rel])
        # the theory is first order in sin²α; its O(α⁴) remainder is < 1e-4 relative for the low-order
        # algorithms but up to ~20 % for the 3- and 4-sample ones, whose leading term is tiny
        high = alg in ("three-sample", "four-sample")
        checks.append(Check(f"coning drift vs theory ({alg})", rel, 25.0 if high else 1.0, "%",
                            note="the theory is first order in sin²α; its remainder is a large part of this "
                                 "algorithm's tiny drift" if high and rel > 1.0 else ""))
    table = Table(f"Coning drift, half-angle 0.1°, {freq:g} Hz cone, {rate:g} Hz updates",
                  ["algorithm", "theory [deg/h]", "measured [deg/h]", "difference [%]"], rows,
                  "Theory: Ignagni (1990), first order in sin²α, exact in Ωh; truth: closed-form coning; drift = "
                  "slope of the error about the cone axis at whole cone periods.")
    return [table], checks, [], {"coning_drift_rad_s": drift}


SECTIONS = [_earth_section, _rotation_section, _imu_noise_section, _strapdown_section, _alignment_section]


@register_study("core")
def core_study(quick: bool = True, rng=None) -> StudyResult:
    rng = np.random.default_rng(rng)
    res = StudyResult("core", "Shared core checks",
                      "Earth model against NIMA TR8350.2 and the PSINS formula; rotation conversions against exact "
                      "identities; Allan deviation of simulated gyro noise against its spec; coning drift of the strapdown "
                      "algorithms against Ignagni's theory; static alignment against its theoretical limits.")
    for section in SECTIONS:
        step(section.__name__.strip("_").replace("_section", ""))
        tables, checks, figures, summary = section(quick, rng)
        res.tables += tables
        res.checks += checks
        res.figures += figures
        res.summary.update(summary)
    by_name = {c.name: c for c in res.checks}
    res.headline = [
        Headline("WGS-84 normal gravity at the equator − TR8350.2", "m/s²", None, None,
                 float(by_name["WGS-84 γ at equator − TR8350.2"].value)),
        Headline("ARW read off the Allan deviation − spec", "%", None, None,
                 100 * float(res.summary["arw_rel_error"])),
        Headline("worst coning drift − Ignagni theory (previous-sample and two-sample)", "%", None, None,
                 max(float(c.value) for c in res.checks if c.name.startswith("coning drift vs theory")
                     and ("previous" in c.name or "two-sample" in c.name)))]
    return res
