"""The ``--report DIR`` of ``optinav calibrate``: parameter tables, residuals and plots of one calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.reports.report import StudyResult, Table, Figure, write_report


def _fmt(v, s=None) -> str:
    if s is None or not np.isfinite(s):
        return f"{v:.8g}"
    return f"{v:.8g} ± {s:.2g}"


def _triad_table(name: str, d: dict, raw_unit: str, si_unit: str) -> Table:
    K, b = np.asarray(d["K"]), np.asarray(d["b"])
    Ks = np.asarray(d.get("K_std", np.full((3, 3), np.nan)), float)
    bs = np.asarray(d.get("b_std", np.full(3, np.nan)), float)
    rows = [[f"row {'xyz'[i]}"] + [_fmt(K[i, j], Ks[i, j]) for j in range(3)] + [_fmt(b[i], bs[i])]
            for i in range(3)]
    note = f"raw = K·x + b, x in {si_unit}, raw in {raw_unit}; ± one standard deviation."
    if d.get("held"):
        note += f" Held at 0 (not observable from these poses): {', '.join(d['held'])}."
    return Table(f"{name}: K [{raw_unit} per {si_unit}] and b [{raw_unit}]", ["", "x", "y", "z", "b"], rows, note)


def write_calibration_report(res, t, acc, gyro, out_dir) -> Path:
    """Write index.md/index.html, summary.json and PNGs describing ``res`` (a CalibrationResult)."""
    t = np.asarray(t, float)
    acc = np.asarray(acc, float)
    a = res.correct_accel(acc)
    g = res.gravity
    tables = [_triad_table("Accelerometer", res.accelerometer, res.units.get("accelerometer_raw", "raw"), "m/s²")]
    if res.gyroscope is not None:
        tables.append(_triad_table("Gyroscope", res.gyroscope, res.units.get("gyroscope_raw", "raw"), "rad/s"))
    iv = np.asarray(res.static_intervals, float)
    rows = []
    for k, (t0, t1) in enumerate(iv):
        m = (t >= t0) & (t <= t1) & np.all(np.isfinite(a), axis=1)
        n = np.linalg.norm(a[m], axis=1)
        up = a[m].mean(axis=0) / np.linalg.norm(a[m].mean(axis=0))
        rows.append([k + 1, f"{t0:.2f}", f"{t1:.2f}", int(m.sum()), f"{n.mean() - g:+.3e}", f"{n.std():.3e}",
                     " ".join(f"{x:+.3f}" for x in up)])
    tables.append(Table("Static intervals: corrected |a| − g per pose", ["pose", "t0 [s]", "t1 [s]", "samples",
                                                                       "mean |a| − g [m/s²]", "std |a| [m/s²]",
                                                                       "up direction (sensor frame)"], rows))
    obs = res.observability or {}
    orows = [[k, str(v)] for k, v in obs.items() if k not in ("accelerometer", "gyroscope")]
    for sensor in ("accelerometer", "gyroscope"):
        o = obs.get(sensor)
        if o:
            orows.append([f"{sensor} rank", f"{o.get('rank')} of {o.get('n_params')}"])
            for u in o.get("unobservable", []) or []:
                orows.append([f"{sensor} unobservable", u])
    tables.append(Table("Observability", ["item", "value"], orows))
    q = [[k, str(v)] for k, v in (res.quality or {}).items() if k != "threshold_selection"]
    q += [[f"excluded {k}", str(v)] for k, v in (res.excluded or {}).items()]
    q += [["residual rms of |a| − g (static samples)", f"{res.residual_rms:.4g} m/s²"],
          ["method", res.method], ["elapsed", f"{res.elapsed_s:.3f} s"]]
    tables.append(Table("Quality", ["item", "value"], q))

    def draw_norm(fig):
        ax = fig.add_subplot(111)
        raw_n = np.linalg.norm(acc, axis=1)
        ax2 = ax.twinx()
        ax2.plot(t, raw_n, color="0.7", lw=0.6, label="raw |output|")
        ax2.set_ylabel(f"raw |output| [{res.units.get('accelerometer_raw', 'raw')}]", color="0.5")
        ax.plot(t, np.linalg.norm(a, axis=1) - g, lw=0.6, label="corrected |a| − g")
        for t0, t1 in iv:
            ax.axvspan(t0, t1, color="tab:green", alpha=0.15, lw=0)
        ax.set_ylim(-0.05 * g, 0.05 * g)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("|a| − g [m/s²]")
        ax.set_title("Accelerometer norm; static intervals shaded")
        ax.grid(True)

    def draw_res(fig):
        ax = fig.add_subplot(111)
        vals = [float(r[4]) for r in rows]
        ax.bar(np.arange(1, len(vals) + 1), vals)
        ax.set_xlabel("pose")
        ax.set_ylabel("mean |a| − g [m/s²]")
        ax.set_title("Norm residual per pose after calibration")
        ax.grid(True, axis="y")

    figures = [Figure("calibration_norm.png", "Norm of the corrected specific force minus g over the log", draw_norm),
               Figure("calibration_pose_residuals.png", "Mean norm residual of each static pose", draw_res)]
    study = StudyResult(name="calibration", title=f"Calibration of {res.source or 'a log'} ({res.method})",
                        description=res.summary().replace("\n", "  \n"), tables=tables, figures=figures,
                        summary={"accelerometer_K": res.accelerometer["K"], "accelerometer_b": res.accelerometer["b"],
                                 "residual_rms": res.residual_rms})
    return write_report([study], out_dir, title="optinav calibration")
