"""Study ``core``: checks of the shared core against published values and analytic truth.

The computation (``compute``) returns numbers per section (earth, rotations, IMU noise, coning, alignment), SI
units unless a key names another; ``LIMITS`` holds every acceptance limit with its reason; ``tables``, ``checks``,
``figures`` and ``headline`` turn the numbers into the report. References: NIMA TR8350.2, PSINS glv, Ignagni
1990, IEEE Std 952, or exact identities.
"""

from __future__ import annotations

import numpy as np

from optinav.core.progress import step
from optinav.core import alignment, allan, earth, imu_model, rotations, simulate, strapdown
from optinav.reports.report import (
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

MICRO_G = 9.80665e-6  # m/s² per μg
ARCSEC = 180 / np.pi * 3600  # arcsec per rad
DEG_H = 180 / np.pi * 3600  # (deg/h) per (rad/s)
#: the reference values of NIMA TR8350.2 (m/s²)
TR8350_GAMMA_E, TR8350_GAMMA_P = 9.7803253359, 9.8321849378
AXES = ("east", "north", "up")

LIMITS = {
    "gravity_equator": Limit(
        1e-9, unit="m/s²", reason="TR8350.2 prints γ_e to 10 decimals; Somigliana's formula reproduces it to rounding"
    ),
    "gravity_pole": Limit(
        1e-8, unit="m/s²", reason="TR8350.2 prints γ_p to 10 decimals; the formula's constants are themselves rounded"
    ),
    "psins_vs_wgs84": Limit(
        10.0,
        unit="μg",
        reason="the PSINS formula is a truncated series for the same "
        "ellipsoid: it departs from Somigliana's by a few μg (8 μg at "
        "the pole)",
    ),
    "euler_round_trip": Limit(
        1e-9,
        unit="rad",
        reason="exact identities in double precision; pitch is kept within ±1.5 rad, away from gimbal lock",
    ),
    "arw_readoff": Limit(
        5.0,
        unit="%",
        reason="white noise at τ ≈ 1 s has thousands of degrees of freedom (≈1 % spread of the Allan deviation)",
    ),
    "bias_instability_readoff": Limit(
        35.0,
        unit="%",
        reason="the flat floor of a Gauss–Markov process is read at τ ~ 2τ_c with few degrees of freedom (≈10–30 %)",
    ),
    "coning": Limit(
        1.0,
        unit="%",
        reason="Ignagni's theory is first order in sin²α; its O(α⁴) remainder is "
        "< 1e-4 relative for the low-order algorithms",
    ),
    "coning_high_order": Limit(
        25.0,
        unit="%",
        reason="the O(α⁴) remainder of the theory is up to ~20 % of the tiny drift of the 3- and 4-sample algorithms",
    ),
    "alignment": Limit(
        1.0,
        reason="tolerance = 4σ of the sensor noise averaged over the window + 3× the effect "
        "of the bias instability, about the theoretical limit",
    ),
    "fine_heading": Limit(
        1.0,
        reason="gyrocompass heading is limited by the accelerometer bias drift, which the "
        "filter models: the error must lie within its 3σ",
    ),
}


# --- computation --------------------------------------------------------------------------------------------


def _earth(quick, rng) -> dict:
    """Normal gravity (m/s²) of WGS-84 and of the PSINS formula every 15° of latitude, and on a fine grid."""
    lats = np.radians(np.arange(0, 91, 15.0))
    lat_fine = np.radians(np.linspace(0, 90, 181))
    return {
        "lat": lats,
        "g_wgs84": earth.gravity(lats),
        "g_psins": earth.gravity(lats, earth="psins"),
        "g_equator": float(earth.gravity(0.0)),
        "g_pole": float(earth.gravity(np.pi / 2)),
        "lat_fine": lat_fine,
        "psins_minus_wgs84_fine": earth.gravity(lat_fine, earth="psins") - earth.gravity(lat_fine),
    }


def _rotations(quick, rng) -> dict:
    """Largest Euler → DCM → quaternion → Euler round-trip error (rad) and |CCᵀ − I| per convention."""
    n = 20_000 if quick else 200_000
    e = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-np.pi, np.pi, n)])
    out = {"samples": n}
    for conv in ("ned", "enu"):
        c = rotations.dcm_from_euler(e, conv)
        out[conv] = {
            "round_trip": float(np.max(np.abs(rotations.euler_from_quat(rotations.quat_from_dcm(c), conv) - e))),
            "orthogonality": float(np.max(np.abs(c @ np.swapaxes(c, -1, -2) - np.eye(3)))),
        }
    return out


def _imu_noise(quick, rng) -> dict:
    """Allan deviation of simulated MTi-1-class gyro noise and its IEEE 952 read-off against the spec (rad/s)."""
    spec = imu_model.preset("mems-mti1")
    unit = spec.draw(rng, errors=False)
    hours = 2.0 if quick else 6.0
    n, dt = int(hours * 3600 * spec.rate_hz), 1.0 / spec.rate_hz
    w = unit.gyro_noise.sample(n, dt, rng)[:, 0]  # rad/s, x axis
    ad = allan.allan_deviation(w, dt, kind="rate")
    par = allan.noise_parameters_from_allan(ad)
    arw_true = float(spec.gyro_arw[0])
    return {
        "hours": hours,
        "arw_true": arw_true,
        "bi_true": float(spec.gyro_bias_instability[0]),
        "arw_est": float(np.atleast_1d(par.white)[0]),
        "bi_est": float(np.atleast_1d(par.bias_instability)[0]),
        "adev": ad,
        "model": allan.allan_deviation_model(
            ad.tau, white=arw_true, gm_sigma=unit.gyro_noise.gm_sigma[0], gm_tau=unit.gyro_noise.gm_tau[0]
        ),
    }


def _alignment(quick, rng) -> dict:
    """Static alignment of a navigation-grade unit: coarse and Kalman fine alignment errors and the theoretical
    limits (rad, east/north/up), with the tolerance the noise and bias instability allow."""
    frame, lat, h = "enu", np.radians(34.25), 400.0
    spec = imu_model.preset("rlg-nav")
    unit = spec.draw(rng)
    c_true = rotations.dcm_from_euler([0.002, -0.003, 1.1], frame)
    T = 300.0 if quick else 900.0
    truth = simulate.static_positions(c_true[None], T, 100.0, lat, h, frame=frame)
    meas = unit.apply(truth.dtheta, truth.dv, truth.dt, rng=rng, kind="increment")
    span = truth.t[-1] - truth.t[0]
    coarse = alignment.coarse_alignment(meas.acc.sum(0) / span, meas.gyr.sum(0) / span, lat, h, frame)
    fine = alignment.fine_alignment(
        truth.t,
        meas.gyr,
        meas.acc,
        lat,
        h,
        frame=frame,
        gyro_white=unit.gyro_noise.white[0],
        acc_white=unit.acc_noise.white[0],
        gyro_bias_std=float(spec.gyro_bias[0]),
        acc_bias_std=float(spec.acc_bias[0]),
        gyro_bias_instability=unit.gyro_noise.gm_sigma[0],
        gyro_bias_tau=unit.gyro_noise.gm_tau[0],
        acc_bias_instability=unit.acc_noise.gm_sigma[0],
        acc_bias_tau=unit.acc_noise.gm_tau[0],
    )
    limit = alignment.alignment_limits(c_true @ unit.gyr.bias, c_true @ unit.acc.bias, lat, h, frame)
    g = float(earth.gravity(lat, h))
    sig = np.array(
        [
            unit.acc_noise.white[0] / g,
            unit.acc_noise.white[0] / g,
            unit.gyro_noise.white[0] / (earth.WGS84.omega_ie * np.cos(lat)),
        ]
    ) / np.sqrt(span)
    instab = np.abs(
        alignment.alignment_limits(
            np.full(3, unit.gyro_noise.gm_sigma[0]), np.full(3, unit.acc_noise.gm_sigma[0]), lat, h, frame
        )
    )
    e_hist = np.array(
        [alignment.attitude_error(rotations.dcm_from_euler(e, frame), c_true) for e in fine.history_euler]
    )
    return {
        "span": span,
        "limit": limit,
        "coarse": alignment.attitude_error(coarse.C_b_n, c_true),
        "fine": alignment.attitude_error(fine.C_b_n, c_true),
        "fine_std": fine.attitude_std,
        "noise_std": sig,
        "tolerance": 4 * sig + 3 * instab,
        "history_t": fine.history_t,
        "history_error": e_hist,
        "history_std": fine.history_attitude_std,
    }


def _coning(quick, rng) -> dict:
    """Attitude drift (rad/s) of each coning algorithm under exact coning motion and Ignagni's theory."""
    alpha, freq, rate = np.radians(0.1), 10.0, 200.0
    duration = 5.0 if quick else 50.0
    truth = simulate.coning(alpha, freq, duration, rate, frame="enu")
    per = int(round(rate / freq))  # samples per cone period
    out = {"freq": freq, "rate": rate, "theory": {}, "measured": {}}
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
        out["measured"][alg] = float(np.polyfit(truth.t[idx[keep]], err_n[:, 2], 1)[0])
        out["theory"][alg] = strapdown.coning_drift_rate(alg, alpha, freq, 1.0 / rate)
    return out


SECTIONS = {
    "earth": _earth,
    "rotation": _rotations,
    "imu_noise": _imu_noise,
    "strapdown": _coning,
    "alignment": _alignment,
}


def compute(quick: bool, rng) -> dict:
    """Every section's numbers, in the order the sections draw from ``rng``."""
    out = {}
    for label, section in SECTIONS.items():
        step(label)
        out[label] = section(quick, rng)
    return out


def _coning_difference_pct(n) -> dict[str, float]:
    c = n["strapdown"]
    return {alg: abs(c["measured"][alg] - c["theory"][alg]) / abs(c["theory"][alg]) * 100 for alg in c["theory"]}


def summary(n) -> dict:
    """The numbers of ``summary.json``, each with its unit."""
    e, imu, al, c = n["earth"], n["imu_noise"], n["alignment"], n["strapdown"]
    return {
        "gravity_wgs84": quantity(e["g_wgs84"], "m/s²"),
        "gravity_psins": quantity(e["g_psins"], "m/s²"),
        "gravity_equator_minus_tr8350": quantity(abs(e["g_equator"] - TR8350_GAMMA_E), "m/s²"),
        "gravity_latitude": quantity(np.degrees(e["lat"]), "deg"),
        "euler_round_trip_error": {conv: quantity(n["rotation"][conv]["round_trip"], "rad") for conv in ("ned", "enu")},
        "arw_rel_error": quantity(imu["arw_est"] / imu["arw_true"] - 1, ""),
        "bias_instability_rel_error": quantity(imu["bi_est"] / imu["bi_true"] - 1, ""),
        "coning_drift": {alg: quantity(v, "rad/s") for alg, v in c["measured"].items()},
        "coning_drift_theory": {alg: quantity(v, "rad/s") for alg, v in c["theory"].items()},
        "coning_drift_difference": {alg: quantity(v, "%") for alg, v in _coning_difference_pct(n).items()},
        "alignment_limit": quantity(al["limit"], "rad"),
        "coarse_error": quantity(al["coarse"], "rad"),
        "fine_error": quantity(al["fine"], "rad"),
        "fine_std": quantity(al["fine_std"], "rad"),
    }


# --- checks -------------------------------------------------------------------------------------------------


def checks(n) -> list[Check]:
    e, imu, al = n["earth"], n["imu_noise"], n["alignment"]
    out = [
        Check.against(
            "WGS-84 γ at equator − TR8350.2", abs(e["g_equator"] - TR8350_GAMMA_E), LIMITS["gravity_equator"]
        ),
        Check.against("WGS-84 γ at pole − TR8350.2", abs(e["g_pole"] - TR8350_GAMMA_P), LIMITS["gravity_pole"]),
        Check.against(
            "max |PSINS − WGS-84| gravity",
            np.max(np.abs(e["g_psins"] - e["g_wgs84"])) / MICRO_G,
            LIMITS["psins_vs_wgs84"],
        ),
    ]
    out += [
        Check.against(
            f"Euler→DCM→quat→Euler round trip ({conv})", n["rotation"][conv]["round_trip"], LIMITS["euler_round_trip"]
        )
        for conv in ("ned", "enu")
    ]
    out += [
        Check.against("ARW read-off error", abs(imu["arw_est"] / imu["arw_true"] - 1) * 100, LIMITS["arw_readoff"]),
        Check.against(
            "bias-instability read-off error",
            abs(imu["bi_est"] / imu["bi_true"] - 1) * 100,
            LIMITS["bias_instability_readoff"],
        ),
    ]
    for alg, rel in _coning_difference_pct(n).items():
        high = alg in ("three-sample", "four-sample")
        out.append(
            Check.against(
                f"coning drift vs theory ({alg})",
                rel,
                LIMITS["coning_high_order" if high else "coning"],
                note="the theory is first order in sin²α; its remainder is a large part of this algorithm's tiny drift"
                if high and rel > 1.0
                else "",
            )
        )
    out += [
        Check.against(
            f"|coarse − limit| / tolerance, {ax}",
            abs(al["coarse"][i] - al["limit"][i]) / al["tolerance"][i],
            LIMITS["alignment"],
        )
        for i, ax in enumerate(AXES)
    ]
    out += [
        Check.against(
            f"|fine − limit| / tolerance, {ax}",
            abs(al["fine"][i] - al["limit"][i]) / al["tolerance"][i],
            LIMITS["alignment"],
        )
        for i, ax in enumerate(AXES[:2])
    ]
    out.append(
        Check.against(
            "|fine heading error| / (3 Kalman σ)",
            abs(al["fine"][2]) / (3 * al["fine_std"][2]),
            LIMITS["fine_heading"],
            note=f"the heading error itself ({al['fine'][2] * ARCSEC:+.0f}″) is far beyond the bias "
            f"limit ({al['limit'][2] * ARCSEC:+.0f}″): in {al['span']:g} s gyrocompassing is "
            "limited by the accelerometer bias drift, and the filter says so through its σ",
        )
    )
    return out


# --- tables -------------------------------------------------------------------------------------------------


def tables(n) -> list[Table]:
    e, imu, c, al = n["earth"], n["imu_noise"], n["strapdown"], n["alignment"]
    rel = _coning_difference_pct(n)
    to = lambda x: x * 180 / np.pi * 60  # noqa: E731  rad/√s → deg/√h
    return [
        Table(
            "Normal gravity at sea level: WGS-84 (Somigliana) vs PSINS formula",
            ["latitude [deg]", "WGS-84 [m/s²]", "PSINS [m/s²]", "PSINS − WGS-84 [μg]"],
            [
                [float(np.degrees(la)), a, b, float((b - a) / MICRO_G)]
                for la, a, b in zip(e["lat"], e["g_wgs84"], e["g_psins"])
            ],
            f"Reference: NIMA TR8350.2 γ_e = {TR8350_GAMMA_E}, γ_p = {TR8350_GAMMA_P} m/s².",
            formats=[None, "{:.10f}", "{:.10f}"],
        ),
        Table(
            "Rotation conversions on random attitudes",
            ["convention", "samples", "max round-trip error [rad]", "max |CCᵀ − I|"],
            [
                [
                    conv,
                    n["rotation"]["samples"],
                    n["rotation"][conv]["round_trip"],
                    n["rotation"][conv]["orthogonality"],
                ]
                for conv in ("ned", "enu")
            ],
        ),
        Table(
            f"Gyro noise read from the Allan deviation of {imu['hours']:g} h of simulated MTi-1-class data",
            ["term", "spec", "read off", "difference [%]"],
            [
                ["ARW [deg/√h]", to(imu["arw_true"]), to(imu["arw_est"]), 100 * (imu["arw_est"] / imu["arw_true"] - 1)],
                [
                    "bias instability [deg/h]",
                    imu["bi_true"] * DEG_H,
                    imu["bi_est"] * DEG_H,
                    100 * (imu["bi_est"] / imu["bi_true"] - 1),
                ],
            ],
            "IEEE Std 952 Annex C read-off; bias instability simulated as a Gauss–Markov process.",
        ),
        Table(
            f"Coning drift, half-angle 0.1°, {c['freq']:g} Hz cone, {c['rate']:g} Hz updates",
            ["algorithm", "theory [deg/h]", "measured [deg/h]", "difference [%]"],
            [[alg, c["theory"][alg] * DEG_H, c["measured"][alg] * DEG_H, rel[alg]] for alg in c["theory"]],
            "Theory: Ignagni (1990), first order in sin²α, exact in Ωh; truth: closed-form coning; drift = "
            "slope of the error about the cone axis at whole cone periods.",
        ),
        Table(
            f"Static alignment of an rlg-nav unit, {al['span']:g} s at 34.25° N (errors φ, arcsec)",
            ["axis", "theoretical limit", "coarse", "Kalman fine", "Kalman 1σ", "noise 1σ over window"],
            [
                [
                    ax,
                    al["limit"][i] * ARCSEC,
                    al["coarse"][i] * ARCSEC,
                    al["fine"][i] * ARCSEC,
                    al["fine_std"][i] * ARCSEC,
                    al["noise_std"][i] * ARCSEC,
                ]
                for i, ax in enumerate(["east (level)", "north (level)", "up (heading)"])
            ],
            "Limit: level = ∇/g, heading = −ε_E/(ω_ie cos L) + ∇_E tan L/g from the unit's drawn biases. "
            "Kalman heading (gyrocompassing) reads the tilt rate and is limited by the in-run accelerometer "
            "drift (Gauss–Markov, modelled in the filter), so averaging (coarse) can beat it on a drifting "
            "unit; the filter's σ states its accuracy.",
        ),
    ]


# --- figures ------------------------------------------------------------------------------------------------


def figures(n) -> list[Figure]:
    e, imu, al = n["earth"], n["imu_noise"], n["alignment"]

    def draw_gravity(fig):
        ax = fig.add_subplot(111)
        ax.plot(np.degrees(e["lat_fine"]), e["psins_minus_wgs84_fine"] / MICRO_G)
        ax.set_xlabel("latitude [deg]")
        ax.set_ylabel("PSINS − WGS-84 gravity [μg]")
        ax.grid(True)

    def draw_allan(fig):
        ad = imu["adev"]
        ax = fig.add_subplot(111)
        ax.loglog(ad.tau, ad.adev * DEG_H, "o-", ms=3, label="simulated")
        ax.fill_between(ad.tau, ad.lower * DEG_H, ad.upper * DEG_H, alpha=0.3, label="68 % interval")
        ax.loglog(ad.tau, imu["model"] * DEG_H, "k--", label="model")
        ax.set_xlabel("τ [s]")
        ax.set_ylabel("Allan deviation [deg/h]")
        ax.grid(True, which="both", alpha=0.4)
        ax.legend()

    def draw_alignment(fig):
        t, e_hist, s_hist = al["history_t"], al["history_error"] * ARCSEC, al["history_std"] * ARCSEC
        limit = al["limit"] * ARCSEC
        for i, name in enumerate(["east tilt", "north tilt", "heading"]):
            ax = fig.add_subplot(1, 3, i + 1)
            ax.plot(t, e_hist[:, i], label="error")
            ax.fill_between(t, -3 * s_hist[:, i], 3 * s_hist[:, i], alpha=0.25, label="±3σ")
            ax.axhline(limit[i], color="k", ls="--", label="limit")
            ax.set_title(name)
            ax.set_xlabel("t [s]")
            if i == 0:
                ax.set_ylabel("φ [arcsec]")
                ax.legend(fontsize=7)
            # the axis holds the error, the limit and the ±3σ band once the filter has left its initial spread
            settled = t >= t[0] + 0.2 * (t[-1] - t[0])
            lim = 1.15 * max(abs(limit[i]), np.max(np.abs(e_hist[settled, i])), 3 * np.max(s_hist[settled, i]))
            ax.set_ylim(-lim, lim)

    return [
        Figure(
            "core_gravity_models.png",
            "Difference of the PSINS gravity formula from WGS-84 normal gravity",
            draw_gravity,
        ),
        Figure("core_allan_gyro.png", "Allan deviation of simulated MTi-1-class gyro noise", draw_allan),
        Figure(
            "core_fine_alignment.png",
            "Kalman fine alignment: error, ±3σ and the theoretical limit",
            draw_alignment,
            size=(10.0, 3.5),
        ),
    ]


def headline(s) -> list[Headline]:
    """The headline rows, from the summary's quantities."""
    rel = {alg: q["value"] for alg, q in s["coning_drift_difference"].items()}
    return [
        Headline(
            "WGS-84 normal gravity at the equator − TR8350.2",
            "m/s²",
            None,
            None,
            value_at(s, "gravity_equator_minus_tr8350"),
        ),
        Headline("ARW read off the Allan deviation − spec", "%", None, None, 100 * value_at(s, "arw_rel_error")),
        Headline(
            "worst coning drift − Ignagni theory (previous-sample and two-sample)",
            "%",
            None,
            None,
            max(v for alg, v in rel.items() if "previous" in alg or "two-sample" in alg),
        ),
    ]


@register_study("core")
def core_study(quick: bool = True, rng=None) -> StudyResult:
    n = compute(quick, np.random.default_rng(rng))
    s = summary(n)
    return StudyResult(
        "core",
        "Shared core checks",
        "Earth model against NIMA TR8350.2 and the PSINS formula; rotation conversions against exact "
        "identities; Allan deviation of simulated gyro noise against its spec; coning drift of the "
        "strapdown algorithms against Ignagni's theory; static alignment against its theoretical "
        "limits.",
        tables=tables(n),
        checks=checks(n),
        figures=figures(n),
        summary=s,
        headline=headline(s),
    )
