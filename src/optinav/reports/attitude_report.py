"""The ``--report DIR`` of ``optinav attitude``: the estimation summary (numbers, formatted when written) and
the roll, pitch, yaw of the estimate."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.attitude.methods import variant
from optinav.reports.report import Cell, Figure, StudyResult, Table, break_wraps, write_report


def _fixed(decimals: int):
    """A cell format: every number with ``decimals`` decimals, space-separated."""
    return lambda v: " ".join(f"{x:.{decimals}f}" for x in np.atleast_1d(v))


def _variant(res) -> str:
    """The variant that ran (:func:`~optinav.attitude.methods.variant`): 'qn as published', 'iframe offline', …"""
    return variant(res.method, offline=res.offline, input_stage=res.input_stage)


def attitude_tables(res, n_samples: int, score=None) -> list[Table]:
    """The estimation summary of an :class:`~optinav.attitude.AttitudeEstimate` of ``n_samples`` samples;
    ``score``: (inclination RMSE rad, heading RMSE rad, samples) against a reference, or None. Cells hold
    numbers (degrees, as the report shows them); the text is written at render time."""
    stage = "built in" if res.method == "iframe" else "on" if res.input_stage else "off (as published)"
    rows = [
        ["method", _variant(res)],
        ["input stage", stage],
        ["frame", res.frame],
        ["samples", int(n_samples)],
        ["polarization used", res.pol_used],
    ]
    rows += [[f"polarization skipped: {k}", v] for k, v in res.pol_skipped.items()]
    branch = getattr(res, "pol_branch_rms", None)  # the heading branch chosen by the data (None: not decided)
    if branch is not None:
        rows.append(
            ["heading branch: AoP residual RMS, taken / other [deg]", Cell(np.degrees(branch).tolist(), _fixed(2))]
        )
    rows += [["accelerometer threshold hits", res.acc_threshold_hits]]
    used = getattr(res, "mag_used", None)  # per-sample flags (in memory) or a count (streamed); None: no magnetometer
    if used is not None:
        k = int(np.count_nonzero(used)) if np.ndim(used) else int(used)
        # of the rows holding a sample: a magnetometer slower than the IMU has NaN rows between (not rejections)
        m = getattr(res, "mag_rows", None) or int(n_samples)
        rows.append(["magnetometer samples used [%]", Cell(100.0 * k / max(m, 1), _fixed(1))])
        # the heading's north: magnetic (0) or true, the field turned by the declination given
        rows.append(["magnetic declination, east positive [deg]", Cell(np.degrees(res.declination), _fixed(2))])
    if score is not None:
        rows += [
            ["inclination RMSE vs reference [deg]", Cell(float(np.degrees(score[0])), _fixed(3))],
            ["heading RMSE vs reference [deg]", Cell(float(np.degrees(score[1])), _fixed(3))],
        ]
    if res.gyr_bias is not None:
        rows.append(["final gyro bias [deg/s]", Cell(np.degrees(res.gyr_bias).tolist(), _fixed(4))])
    return [Table("Estimation summary", ["item", "value"], rows)]


def write_attitude_report(
    res, t, eul_deg, source, out_dir, score=None, n_samples: int | None = None, errors=None
) -> Path:
    """Write index.md/index.html, summary.json and the Euler-angle figure of an attitude estimate into
    ``out_dir``: ``t`` (s) and ``eul_deg`` (m, 3) roll, pitch, yaw in degrees (every k-th sample of a long log:
    ``n_samples``, default m, is the estimate's length); ``score`` as in :func:`attitude_tables`; ``errors`` the
    same samples' (m, 2) inclination and heading error against the reference [deg] (NaN: not scored), drawn as a
    second figure; ``res`` an :class:`~optinav.attitude.AttitudeEstimate` or
    :class:`~optinav.attitude.filestream.StreamedEstimate`."""
    n = len(t) if n_samples is None else int(n_samples)
    every = "" if n <= len(t) else f"; one sample in {-(-n // max(len(t), 1))} of {n}"

    t = np.asarray(t, float)
    t0 = float(t[0]) if t.size else 0.0
    # from the first sample: a time column since the epoch (1.7e9 s) drew an axis of "+1.73e9" and ticks that
    # all read the same
    since = f"t − {t0:.3f} s [s]" if abs(t0) >= 1e4 else "t [s]"
    t = t - t0 if abs(t0) >= 1e4 else t

    def draw(fig):
        axs = fig.subplots(3, 1, sharex=True)
        for k, name in enumerate(("roll", "pitch", "yaw")):
            axs[k].plot(*break_wraps(t, eul_deg[:, k]), lw=0.8)  # no vertical lines across ±180°
            axs[k].set_ylabel(f"{name} [deg]")
            axs[k].grid(alpha=0.3)
        axs[-1].set_xlabel(since)

    figures = [Figure("attitude_euler.png", f"Roll, pitch, yaw ({res.frame}{every})", draw, (8, 6))]
    err = None if errors is None else np.asarray(errors, float)
    if err is not None and score is not None and np.isfinite(err).any():

        def draw_errors(fig):
            axs = fig.subplots(2, 1, sharex=True)
            for k, name in enumerate(("inclination", "heading")):
                axs[k].plot(t, err[:, k], lw=0.8)  # NaN (not scored) breaks the line
                axs[k].set_ylabel(f"{name} error [deg]")
                axs[k].set_ylim(bottom=0.0)
                axs[k].grid(alpha=0.3)
            axs[-1].set_xlim(t[0], t[-1]) if t.size > 1 else None  # the Euler figure's time span
            axs[-1].set_xlabel(since)

        rms = f"RMSE {np.degrees(score[0]):.3f}° inclination, {np.degrees(score[1]):.3f}° heading"
        caption = f"Error against the reference: the scored samples (movement, valid reference; {rms}{every})"
        if "yaw" in res.unobservable():  # 6D: a number, but of the initial yaw and the gyro's drift
            caption += "; no heading measurement: the heading error is the start's yaw offset and the gyro's drift"
        figures.append(Figure("attitude_error.png", caption, draw_errors, (8, 5)))
    study = StudyResult(
        name="attitude",
        title=f"Attitude of {Path(source).name} ({_variant(res)})",
        description=res.summary(),
        tables=attitude_tables(res, n, score),
        figures=figures,
        elapsed=float(getattr(res, "elapsed_s", 0.0) or 0.0),  # the estimate's time (a streamed run keeps none)
    )
    return write_report([study], out_dir, title="optinav attitude")
