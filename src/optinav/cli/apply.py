"""``optinav apply RESULT.json DATA --out FILE``: correct raw data with a calibration result."""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

from optinav.cli.common import add_chunk_option, add_input_options, output_path, require_files
from optinav.errors import OptinavError


def register(sub) -> None:
    p = sub.add_parser(
        "apply", help="apply a calibration result to raw data",
        description=textwrap.dedent("""\
            Correct raw data with RESULT.json: a = K⁻¹(raw − b) (m/s^2) and ω = K_g⁻¹(raw − G·a − b_g) (rad/s).
            The calibration may also be an imucal JSON export or an imu_tk parameter file of the accelerometer
            (with --gyro-cal for imu_tk's gyroscope file); the format is recognised from the content.
            The data are read in the raw units the calibration was made in (as recorded in RESULT.json or
            imucal's from_*_unit; imu_tk records none) unless --acc-unit/--gyro-unit say otherwise. The output
            holds t and the corrected triads in SI units (format by extension: .csv, .tsv, .txt, .npz, .h5, .mat)."""),
        epilog=textwrap.dedent("""\
            example:
              optinav apply result.json session.csv --out corrected.csv
              optinav apply acc.calib session.csv --gyro-cal gyro.calib --out corrected.csv
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("result", help="RESULT.json of optinav calibrate, an imucal JSON or an imu_tk accelerometer file")
    p.add_argument("data", help="raw data file")
    p.add_argument("--out", required=True, metavar="FILE", help="corrected data file")
    p.add_argument("--gyro-cal", metavar="FILE", help="imu_tk's gyroscope parameter file (RESULT is then its "
                                                      "accelerometer file)")
    add_input_options(p)
    add_chunk_option(p)
    p.set_defaults(func=run)


def run(args) -> int:
    require_files((args.result, "result file"), (args.data, "data file"), (args.gyro_cal, "--gyro-cal file"))
    from optinav.core.progress import progress_blocks
    from optinav.io import ImuLog
    from optinav.io.imu import iter_imu, open_imu_writer
    from optinav.multipos.exchange import load_calibration

    out = output_path(args.out)
    res = load_calibration(args.result, args.gyro_cal)
    for sensor, entry, key in (("accelerometer", res.accelerometer, "accelerometer_raw"),
                               ("gyroscope", res.gyroscope, "gyroscope_raw")):
        if entry is not None:
            check_plausible_K(sensor, entry, res.units.get(key))
    acc_unit = args.acc_unit or (res.units.get("accelerometer_raw") if res.accelerometer else None)
    gyro_unit = args.gyro_unit or (res.units.get("gyroscope_raw") if res.gyroscope else None)
    blocks = iter_imu(args.data, columns=args.columns, acc_unit=acc_unit, gyro_unit=gyro_unit,
                      time_unit=args.time_unit, rate_hz=args.rate, datasets=args.datasets or None,
                      delimiter=args.delimiter, chunk_rows=args.chunk_rows, topic=args.topic)
    source = f"optinav apply {Path(args.result).name} {Path(args.data).name}"
    # block by block: read, correct, append to the (temporary, renamed at the end) output, so memory does not
    # grow with the log; a bad row fails when its block is read and leaves no output
    with open_imu_writer(out) as writer:
        for log in progress_blocks(blocks, "apply"):
            acc, gyro = _corrected(res, log, args)
            writer.write(ImuLog(t=log.t, acc=acc, gyr=gyro, acc_unit="m/s^2", gyro_unit="rad/s", source=source,
                                labels=log.labels))
    print(f"optinav: wrote {writer.rows} corrected samples to {out} (m/s^2, rad/s)")
    return 0


def _corrected(res, log, args):
    """One block's corrected (acc m/s^2, gyro rad/s), None for a sensor the result or the data lack."""
    from optinav.io import raw_units

    acc = gyro = None
    if res.accelerometer is not None and log.acc is not None:
        raw, unit = raw_units(log, "acc")
        _check_unit("accelerometer", unit, res.units.get("accelerometer_raw"))
        acc = res.correct_accel(raw)
    if res.gyroscope is not None and log.gyr is not None:
        raw, unit = raw_units(log, "gyro")
        _check_unit("gyroscope", unit, res.units.get("gyroscope_raw"))
        gyro = res.correct_gyro(raw, acc)
    if acc is None and gyro is None:
        raise OptinavError(f"{args.data} has no data for the sensors in {args.result}",
                           "check --columns (t,ax,ay,az,gx,gy,gz)")
    return acc, gyro


#: accepted ratio of a calibrated scale to its nominal value (1 / the SI factor of the raw unit); MEMS scale
#: errors are percent, so a factor 2 only lets through what cannot be a calibration of that unit
SCALE_FACTOR = 2.0
#: raw counts per SI unit that any real ADC and range give (16 to 32 bits, ranges 0.5 g to 400 g, 10 to 5000 °/s)
COUNTS_PER_SI = (1e-2, 1e9)
#: largest condition number of K: misalignments are degrees at most, so K is close to a scaled identity
MAX_COND = 10.0


def check_plausible_K(sensor: str, entry: dict, raw_unit: str | None) -> None:
    """Refuse a calibration whose K/b cannot be a sensor's (non-finite, ill-conditioned, scale far from the raw
    unit's nominal, e.g. K = 1e300 of a damaged file): applied, it would write plausible-looking garbage."""
    import numpy as np

    from optinav.core.units import factor

    K, b = np.asarray(entry["K"], float), np.asarray(entry["b"], float)
    cause = None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(b))):
        cause = "K or b is not finite"
    elif np.linalg.cond(K) > MAX_COND:
        cause = f"K has condition number {np.linalg.cond(K):.3g} (> {MAX_COND:g}: axes nearly parallel)"
    else:
        scale = np.abs(np.diag(K))
        if raw_unit in (None, "counts"):
            lo, hi = COUNTS_PER_SI
        else:
            nominal = 1.0 / factor(raw_unit)
            lo, hi = nominal / SCALE_FACTOR, nominal * SCALE_FACTOR
        if np.any(scale < lo) or np.any(scale > hi):
            cause = (f"the scales diag(K) = {', '.join(f'{v:.4g}' for v in scale)} {raw_unit or 'raw'} per SI unit "
                     f"are outside {lo:.3g}..{hi:.3g}")
    if cause:
        raise OptinavError(f"the {sensor} calibration is implausible: {cause}",
                           "re-run optinav calibrate on this unit (the result file may be damaged or of another unit)")


def _check_unit(sensor: str, unit: str, expected: str | None) -> None:
    if expected and unit != expected:
        raise OptinavError(f"the {sensor} data are in {unit} but the calibration was made in {expected}",
                           f"pass data in {expected} (or --{'acc' if sensor[0] == 'a' else 'gyro'}-unit {expected})")
