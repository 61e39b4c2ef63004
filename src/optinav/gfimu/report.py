"""The report of a gyro-free array calibration (``optinav calibrate gfimu --report``, ``optinav report``): every
installation error with its std and CRLB (numbers, formatted when written) and the scheme's observability."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.errors import OptinavError
from optinav.gfimu.turntable import TurntableCalibration
from optinav.reports.report import Cell, Figure, StudyResult, Table, write_report

#: the five installation errors of one accelerometer and the scale each is shown in (mm, mrad)
COEFFICIENTS = ("dr_x", "dr_y", "dr_z", "dalpha", "dbeta")


def _estimate_text(v: dict) -> str:
    return f"{v['value']:+.4f} ± {v['std']:.2g} (CRLB {v['crlb']:.2g})"


def gfimu_tables(res: TurntableCalibration) -> list[Table]:
    """One row per accelerometer: each installation error as ``{value, std, crlb}`` in mm or mrad (``held``
    where the fit did not estimate it)."""
    est, std, crlb = (np.asarray(a, float) for a in (res.estimate, res.std, res.crlb_std))
    idx = {nm: k for k, nm in enumerate(res.names)}

    def cell(name):
        k = idx.get(name)
        if k is None:
            return "held"
        return Cell({"value": est[k] * 1e3, "std": std[k] * 1e3, "crlb": crlb[k] * 1e3}, _estimate_text)

    rows = [[i + 1, *(cell(f"{c}_{i + 1}") for c in COEFFICIENTS)] for i in range(len(res.dalpha))]
    return [
        Table(
            "Installation errors: estimate ± std (CRLB); positions in mm, directions in mrad",
            ["sensor", *COEFFICIENTS],
            rows,
            note=f"rank {res.rank}/{res.n_params}; residual RMS {res.residual_rms:.3g} σ; "
            f"samples per case {np.asarray(res.samples_per_case).astype(int).tolist()}",
        )
    ]


def _figure(res: TurntableCalibration) -> Figure:
    n = len(res.dalpha)
    est, std = np.asarray(res.estimate, float), np.asarray(res.std, float)
    idx = {nm: k for k, nm in enumerate(res.names)}

    def draw(fig):
        axs = fig.subplots(2, 1)
        for ax, group, unit in ((axs[0], COEFFICIENTS[:3], "mm"), (axs[1], COEFFICIENTS[3:], "mrad")):
            for j, c in enumerate(group):
                ks = [idx[f"{c}_{i + 1}"] for i in range(n) if f"{c}_{i + 1}" in idx]
                x = np.arange(len(ks)) + 1 + (j - (len(group) - 1) / 2) * 0.2
                ax.errorbar(x, est[ks] * 1e3, yerr=2 * std[ks] * 1e3, fmt="o", ms=3, capsize=2, label=c)
            ax.set_ylabel(f"estimate ± 2σ [{unit}]")
            ax.ticklabel_format(axis="y", useOffset=False)
            ax.legend(fontsize=7, ncol=3)
            ax.grid(alpha=0.3)
        axs[1].set_xlabel("accelerometer")

    return Figure("installation_errors.png", "installation errors with ±2σ", draw, (7.5, 6.0))


#: the case means of --data fit the result's geometry with a residual beyond this multiple of the result's own:
#: another recording (its own: 1.0; another simulated unit of the same array, seeds and samples per case alike:
#: 30-60)
FIT_RATIO = 3.0


def _check_same_data(res: TurntableCalibration, data) -> None:
    """``--data`` names the recording in the report's title: it must be turntable data of ``res``'s array with its
    samples per case (a rotational-INS file was named the source, exit 0), whose case means the calibrated geometry
    predicts as well as the calibration's own residual (another unit's data with the same cases was titled the
    source of the result's errors, exit 0)."""
    import numpy as np

    from optinav.gfimu.array import AccelerometerArray
    from optinav.gfimu.turntable import nominal_case_means, read_cases

    tc = read_cases(data, len(res.dalpha))
    counts = [int(x) for x in tc.cases.count]
    if counts != [int(x) for x in res.samples_per_case]:
        raise OptinavError(
            f"{data} has {counts} samples per case, the result {[int(x) for x in res.samples_per_case]}: not the "
            "turntable data it was calibrated from",
            "pass the data the result was calibrated from with --data",
        )
    cm = tc.cases
    # the geometry as fitted: the common shift the gauge took out of every dr put back, each case at its mounting's
    # offset
    shift = np.asarray(res.common_shift_m if res.common_shift_m is not None else np.zeros(3), float)
    mounts = sorted({int(m) for m in cm.mounting})
    offs = np.asarray(res.offsets, float).reshape(-1, 3)
    if offs.shape[0] != len(mounts):
        return
    case_offsets = np.array([offs[mounts.index(int(m))] for m in cm.mounting])
    array = AccelerometerArray(np.asarray(res.positions, float) + shift, np.asarray(res.directions, float))
    pred = nominal_case_means(array, cm, tc.gamma, tc.gravity, case_offsets)
    r = (pred - cm.mean) * np.sqrt(cm.count)[:, None] / np.asarray(res.sigma, float)[None, :]
    rms = float(np.sqrt(np.mean(r * r)))
    if res.residual_rms > 0 and rms > FIT_RATIO * max(res.residual_rms, 1.0):
        raise OptinavError(
            f"the case means of {data} leave {rms:.3g} σ RMS with the result's geometry, {rms / res.residual_rms:.0f}× "
            f"the calibration's own {res.residual_rms:.3g} σ: not the turntable data it was calibrated from (another "
            "unit's or another session's)",
            "pass the data the result was calibrated from with --data (optinav apply solves another recording)",
        )


def gfimu_report(res: TurntableCalibration, out_dir, data=None, options=None) -> Path:
    """Write the report of ``res`` into ``out_dir`` (``data``: the recording's name for the title, checked to be
    the turntable data of the result: its samples per case; everything plotted is in the result)."""
    if data is not None:
        _check_same_data(res, data)
    source = f" from {Path(data).name}" if data is not None else ""
    study = StudyResult(
        name="gfimu-calibration",
        title=f"Gyro-free array installation errors ({res.method}){source}",
        description="; ".join(res.statements),
        tables=gfimu_tables(res),
        figures=[_figure(res)],
    )
    return write_report([study], out_dir, title="optinav calibrate gfimu")
