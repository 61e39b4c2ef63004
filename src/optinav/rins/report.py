"""The report of a rotational-INS calibration (``optinav calibrate rins --report``, ``optinav report``): the
angles with their std (numbers, formatted when written), the vehicle-attitude RMSE before/after compensation and,
with the recording, the extracted attitude change before and after (Li et al. 2023, eqs. 12-14)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.errors import OptinavError
from optinav.reports.report import Figure, StudyResult, Table, write_report
from optinav.rins.calibrate import RinsCalibration, attitude_errors, prepare
from optinav.rins.model import PARAM_NAMES


def rins_tables(res: RinsCalibration) -> list[Table]:
    """The angle table (rad; None = not observable individually, then the observable combinations) and the
    attitude RMSE table (deg)."""
    rows = [[nm, res.angles.get(nm), res.angles_std.get(nm)] for nm in PARAM_NAMES]
    rows += [[c["name"], c["value"], c.get("std")] for c in res.combinations if " " in c["name"]]
    return [
        Table(
            "Angles [rad] (— = not observable individually)",
            ["angle", "value [rad]", "std [rad]"],
            rows,
            formats=[None, "{:.6e}", "{:.2e}"],
        ),
        Table(
            "Vehicle attitude RMSE [deg]",
            ["", "roll", "pitch", "yaw"],
            [["before", *res.rmse_before_deg], ["after", *res.rmse_after_deg]],
            formats=[None] + ["{:.4g}"] * 3,
        ),
    ]


def _angles_figure(res: RinsCalibration) -> Figure:
    """The observable angles and combinations with ±2σ (what the result alone shows)."""
    rows = [(nm, res.angles.get(nm), res.angles_std.get(nm)) for nm in PARAM_NAMES]
    rows += [(c["name"], c["value"], c.get("std")) for c in res.combinations if " " in c["name"]]
    rows = [(nm, v, s) for nm, v, s in rows if v is not None]

    def draw(fig):
        ax = fig.add_subplot(111)
        x = np.arange(len(rows))
        ax.errorbar(x, [v * 1e3 for _, v, _ in rows], yerr=[2e3 * (s or 0.0) for *_, s in rows], fmt="o", capsize=3)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_xticks(x, [nm for nm, *_ in rows], fontsize=8)
        ax.set_ylabel("angle ± 2σ [mrad]")
        ax.grid(alpha=0.3)

    return Figure("rins_angles.png", "observable non-orthogonality angles and combinations with ±2σ", draw)


def _error_figure(res: RinsCalibration, prep) -> Figure:
    t = prep.t[1:] - prep.t[0]
    before = np.degrees(attitude_errors(prep, np.zeros(6)))
    after = np.degrees(attitude_errors(prep, res.p))

    def draw(fig):
        axs = fig.subplots(3, 1, sharex=True)
        for k, nm in enumerate(("roll", "pitch", "yaw")):
            axs[k].plot(t, before[:, k], "r", lw=0.8, label="uncompensated")
            axs[k].plot(t, after[:, k], "g", lw=0.8, label=f"compensated ({res.method})")
            axs[k].set_ylabel(f"{nm} [deg]")
            axs[k].grid(alpha=0.3)
        axs[0].legend(fontsize=7)
        axs[-1].set_xlabel("time since navigation start [s]")

    return Figure(
        "attitude_error.png",
        "extracted vehicle attitude change (error) before and after compensation",
        draw,
        (7.0, 6.0),
    )


def _check_same_recording(res: RinsCalibration, prep, data) -> None:
    """``--data`` must be the recording ``res`` was calibrated from: its uncompensated attitude change (RMS of
    [roll, pitch, yaw], deg) is the result's ``rmse_before_deg`` within 10 % (another session gave a figure of its
    own errors beside the result's numbers, exit 0)."""
    if len(res.rmse_before_deg) != 3:
        return
    seen = np.degrees(np.sqrt(np.mean(attitude_errors(prep, np.zeros(6)) ** 2, axis=0)))
    if not np.allclose(seen, res.rmse_before_deg, rtol=0.1, atol=1e-6):
        raise OptinavError(
            f"{data} gives an uncompensated attitude change of {np.round(seen, 4).tolist()} deg RMS [roll, pitch, "
            f"yaw], the result {np.round(res.rmse_before_deg, 4).tolist()}: not the recording it was calibrated from",
            "pass the recording the result was calibrated from with --data",
        )


def rins_report(res: RinsCalibration, out_dir, data=None, options=None) -> Path:
    """Write the report of ``res`` into ``out_dir``; ``data``: the recording it was calibrated from (adds the
    attitude-change figure; read block by block), read with ``options`` (:class:`optinav.rins.unit.RinsOptions`, default the
    latitude and alignment window the result was calibrated with)."""
    figures = [_angles_figure(res)]
    if data is not None:
        from optinav.rins.unit import RinsOptions, read

        # read as the calibration did: its site (a file without lat_deg needed --lat), alignment window and epochs
        rate = res.residual_rate_hz if np.isfinite(res.residual_rate_hz) else RinsOptions.residual_rate_hz
        o = options or RinsOptions(lat_deg=res.lat_deg, align_s=res.align_s, residual_rate_hz=rate)
        # the figure needs the residual epochs only: no gyro re-integrations
        prep = prepare(
            read(data, o), residual_rate=o.residual_rate_hz, align_s=o.align_s, gyro_misalignment=0, gyro_scale=0
        )
        _check_same_recording(res, prep, data)
        figures.append(_error_figure(res, prep))
    study = StudyResult(
        name="rins-calibration",
        title=f"Rotational-INS non-orthogonality ({res.method})",
        description="; ".join(res.observability.get("statements", [])),
        tables=rins_tables(res),
        figures=figures,
    )
    return write_report([study], out_dir, title="optinav calibrate rins")
