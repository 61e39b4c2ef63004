"""The ``--report DIR`` of ``optinav calibrate``: parameter tables, residuals and plots of one calibration.

``pose_statistics`` computes the numbers, ``tables`` and ``figures`` present them, ``write_calibration_report``
writes the folder (``summary.json`` with units).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.reports.report import Cell, Figure, StudyResult, Table, quantity, write_report


def _value_std(d) -> str:
    """``value ± std`` (one standard deviation), or the value alone where the std is unknown."""
    v, s = d["value"], d["std"]
    if s is None or not np.isfinite(s):
        return f"{v:.8g}"
    return f"{v:.8g} ± {s:.2g}"


def _triad_table(name: str, d: dict, raw_unit: str, si_unit: str) -> Table:
    K, b = np.asarray(d["K"]), np.asarray(d["b"])
    Ks = np.asarray(d.get("K_std", np.full((3, 3), np.nan)), float)
    bs = np.asarray(d.get("b_std", np.full(3, np.nan)), float)
    rows = [
        [f"row {'xyz'[i]}"]
        + [Cell({"value": float(K[i, j]), "std": float(Ks[i, j])}, _value_std) for j in range(3)]
        + [Cell({"value": float(b[i]), "std": float(bs[i])}, _value_std)]
        for i in range(3)
    ]
    note = f"raw = K·x + b, x in {si_unit}, raw in {raw_unit}; ± one standard deviation."
    if d.get("held"):
        note += f" Held at 0 (not observable from these poses): {', '.join(d['held'])}."
    return Table(f"{name}: K [{raw_unit} per {si_unit}] and b [{raw_unit}]", ["", "x", "y", "z", "b"], rows, note)


def pose_statistics(res, t, acc) -> list[dict]:
    """Per static pose of ``res``: its interval (s), samples, mean and std of the corrected |a| − g (m/s²) and the
    up direction in the sensor frame."""
    a, g = res.correct_accel(np.asarray(acc, float)), res.gravity
    out = []
    for t0, t1 in np.asarray(res.static_intervals, float):
        m = (t >= t0) & (t <= t1) & np.all(np.isfinite(a), axis=1)
        n = np.linalg.norm(a[m], axis=1)
        out.append(
            {
                "t0": float(t0),
                "t1": float(t1),
                "samples": int(m.sum()),
                "norm_error_mean": float(n.mean() - g),
                "norm_std": float(n.std()),
                "up": a[m].mean(axis=0) / np.linalg.norm(a[m].mean(axis=0)),
            }
        )
    return out


def tables(res, poses) -> list[Table]:
    """Parameter, static-interval, observability and quality tables of ``res``."""
    out = [_triad_table("Accelerometer", res.accelerometer, res.units.get("accelerometer_raw", "raw"), "m/s²")]
    if res.gyroscope is not None:
        out.append(_triad_table("Gyroscope", res.gyroscope, res.units.get("gyroscope_raw", "raw"), "rad/s"))
    out.append(
        Table(
            "Static intervals: corrected |a| − g per pose",
            [
                "pose",
                "t0 [s]",
                "t1 [s]",
                "samples",
                "mean |a| − g [m/s²]",
                "std |a| [m/s²]",
                "up direction (sensor frame)",
            ],
            [
                [k + 1, p["t0"], p["t1"], p["samples"], p["norm_error_mean"], p["norm_std"], p["up"]]
                for k, p in enumerate(poses)
            ]
            or [[k + 1, t0, t1, None, None, None, None] for k, (t0, t1) in enumerate(res.static_intervals)],
            note=""
            if poses
            else "The samples, |a| − g and up directions are those of the log: pass it with --data to list them.",
            formats=[None, "{:.2f}", "{:.2f}", None, "{:+.3e}", "{:.3e}", "{:+.3f}"],
        )
    )
    obs = res.observability or {}
    orows = [[k, Cell(v, str)] for k, v in obs.items() if k not in ("accelerometer", "gyroscope")]
    for sensor in ("accelerometer", "gyroscope"):
        o = obs.get(sensor)
        if o:
            orows.append(
                [
                    f"{sensor} rank",
                    Cell({"rank": o.get("rank"), "of": o.get("n_params")}, lambda d: f"{d['rank']} of {d['of']}"),
                ]
            )
            for u in o.get("unobservable", []) or []:
                orows.append([f"{sensor} unobservable", u])
    out.append(Table("Observability", ["item", "value"], orows))
    q = [[k, Cell(v, str)] for k, v in (res.quality or {}).items() if k != "threshold_selection"]
    q += [[f"excluded {k}", Cell(v, str)] for k, v in (res.excluded or {}).items()]
    q += [
        ["residual rms of |a| − g (static samples)", Cell(res.residual_rms, "{:.4g} m/s²")],
        ["method", res.method],
        ["elapsed", Cell(res.elapsed_s, "{:.3f} s")],
    ]
    out.append(Table("Quality", ["item", "value"], q))
    return out


def figures(res, t, acc, poses) -> list[Figure]:
    """The corrected norm over the log and the mean norm residual of each pose."""
    a, g = res.correct_accel(acc), res.gravity

    def draw_norm(fig):
        ax = fig.add_subplot(111)
        ax2 = ax.twinx()
        ax2.plot(t, np.linalg.norm(acc, axis=1), color="0.7", lw=0.6, label="raw |output|")
        ax2.set_ylabel(f"raw |output| [{res.units.get('accelerometer_raw', 'raw')}]", color="0.5")
        ax.plot(t, np.linalg.norm(a, axis=1) - g, lw=0.6, label="corrected |a| − g")
        for p in poses:
            ax.axvspan(p["t0"], p["t1"], color="tab:green", alpha=0.15, lw=0)
        ax.set_ylim(-0.05 * g, 0.05 * g)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("|a| − g [m/s²]")
        ax.set_title("Accelerometer norm; static intervals shaded")
        ax.grid(True)

    def draw_res(fig):
        ax = fig.add_subplot(111)
        ax.bar(np.arange(1, len(poses) + 1), [p["norm_error_mean"] for p in poses])
        ax.set_xlabel("pose")
        ax.set_ylabel("mean |a| − g [m/s²]")
        ax.set_title("Norm residual per pose after calibration")
        ax.grid(True, axis="y")

    return [
        Figure("calibration_norm.png", "Norm of the corrected specific force minus g over the log", draw_norm),
        Figure("calibration_pose_residuals.png", "Mean norm residual of each static pose", draw_res),
    ]


def write_calibration_report(res, t, acc, gyro, out_dir) -> Path:
    """Write index.md/index.html, summary.json and PNGs describing ``res`` (a CalibrationResult)."""
    t, acc = np.asarray(t, float), np.asarray(acc, float)
    poses = pose_statistics(res, t, acc)
    raw = res.units.get("accelerometer_raw", "raw")
    study = StudyResult(
        name="calibration",
        title=f"Calibration of {res.source or 'a log'} ({res.method})",
        description=res.summary().replace("\n", "  \n"),
        tables=tables(res, poses),
        figures=figures(res, t, acc, poses),
        summary={
            "accelerometer_K": quantity(res.accelerometer["K"], f"{raw} per m/s²"),
            "accelerometer_b": quantity(res.accelerometer["b"], raw),
            "residual_rms": quantity(res.residual_rms, "m/s²"),
            "pose_norm_error_mean": quantity([p["norm_error_mean"] for p in poses], "m/s²"),
        },
    )
    return write_report([study], out_dir, title="optinav calibration")
