"""``optinav export RESULT.json --to imu_tk|imucal|kalibr --out FILE``: a calibration in another tool's format."""

from __future__ import annotations

import argparse
import textwrap

from optinav.cli.common import POSITIVE, RATE, load_option_result, output_path, print_notes, require_files
from optinav.errors import OptinavError

FORMATS = ("imu_tk", "imucal", "kalibr")
_SUFFIXES = {"imucal": (".json",), "kalibr": (".yaml", ".yml")}
#: the --out example named when its suffix is wrong
_EXAMPLES = {"imucal": "cal.json", "kalibr": "imu.yaml"}


def register(sub) -> None:
    p = sub.add_parser(
        "export",
        help="write a calibration for imu_tk, imucal or Kalibr",
        description=textwrap.dedent("""\
            Write a calibration in the format another tool reads. RESULT: RESULT.json of optinav calibrate, an
            imucal export (JSON or HDF5) or imu_tk's accelerometer file (--gyro-cal: its gyroscope file), e.g.
            imucal's Ferraris calibration as Kalibr's imu.yaml. The formats:
              imu_tk  two text files (T, S, B of CalibratedTriad): --out for the accelerometer, --gyro-out for
                      the gyroscope; no g-sensitivity, outputs in m/s^2 and rad/s
              imucal  FerrarisCalibrationInfo JSON (both triads and K_ga; outputs m/s^2 and deg/s)
              kalibr  imu.yaml with Kalibr's scale-misalignment model (M, A, C_gyro_i; Kalibr's frame is the
                      accelerometer's lower-triangular frame, its rotation from optinav's is kept as C_i_s) and
                      the noise keys of an optinav allan result (--noise). Kalibr stores no biases.
            optinav apply reads the imu_tk and imucal files back."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav export result.json --to imucal --out cal.json
              optinav export result.json --to imu_tk --out acc.calib --gyro-out gyro.calib
              optinav export result.json --to kalibr --noise allan.json --rostopic /imu0 --out imu.yaml
              optinav export imucal_cal.json --to kalibr --noise allan.json --out imu.yaml
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "result", help="RESULT.json of optinav calibrate, an imucal JSON/HDF5 export or imu_tk's accelerometer file"
    )
    p.add_argument("--gyro-cal", metavar="FILE", help="imu_tk's gyroscope file (RESULT is then its accelerometer file)")
    p.add_argument("--to", required=True, choices=FORMATS, help="target format")
    p.add_argument("--out", required=True, metavar="FILE", help="output file (imu_tk: the accelerometer's)")
    p.add_argument("--gyro-out", metavar="FILE", help="imu_tk: the gyroscope's parameter file")
    p.add_argument("--noise", metavar="ALLAN.json", help="kalibr: noise parameters from optinav allan")
    p.add_argument("--rostopic", metavar="TOPIC", help="kalibr: the IMU topic (default: the allan result's)")
    p.add_argument(
        "--rate", dest="rate_hz", type=RATE, metavar="HZ", help="kalibr: update_rate (default: the allan result's)"
    )
    p.add_argument(
        "--allow-rw-bound",
        action="store_true",
        help="kalibr: write a random walk the allan log only bounds even when the bound is over 1/s times the "
        "noise density (refused without this)",
    )
    p.add_argument(
        "--acc-unit",
        choices=["counts", "g", "mg", "m/s^2"],
        help="kalibr: the raw unit the accelerometer calibration was made from, where the file does not say it "
        "(imu_tk's files, imucal's before 2.0)",
    )
    p.add_argument(
        "--gyro-unit",
        choices=["counts", "deg/s", "mdps", "rad/s"],
        help="kalibr: the raw unit the gyroscope calibration was made from, where the file does not say it",
    )
    p.add_argument(
        "--acc-lsb",
        type=POSITIVE,
        metavar="LSB_PER_G",
        help="kalibr, an accelerometer calibrated in counts: its driver's sensitivity (e.g. 2048 at ±16 g)",
    )
    p.add_argument(
        "--gyro-lsb",
        type=POSITIVE,
        metavar="LSB_PER_DEG_S",
        help="kalibr, a gyroscope calibrated in counts: its driver's sensitivity (e.g. 16.4 at ±2000 °/s)",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    require_files((args.result, "result file"), (args.gyro_cal, "--gyro-cal file"), (args.noise, "allan result"))
    if args.to != "kalibr":
        for flag, value in (
            ("--noise", args.noise),
            ("--rostopic", args.rostopic),
            ("--rate", args.rate_hz),
            ("--acc-lsb", args.acc_lsb),
            ("--gyro-lsb", args.gyro_lsb),
            ("--acc-unit", args.acc_unit),
            ("--gyro-unit", args.gyro_unit),
            ("--allow-rw-bound", args.allow_rw_bound or None),
        ):
            if value is not None:
                raise OptinavError(f"{flag} is for --to kalibr", f"drop {flag}")
    if args.to != "imu_tk" and args.gyro_out:
        raise OptinavError("--gyro-out is for --to imu_tk (its second file)", "drop --gyro-out")
    from optinav.core.files import imu_tk_file

    mark = imu_tk_file if args.to == "imu_tk" else None
    out = output_path(args.out, _SUFFIXES.get(args.to), _EXAMPLES.get(args.to, ""), mark=mark)
    gyro_out = output_path(args.gyro_out, option="--gyro-out", mark=mark) if args.gyro_out else None
    if gyro_out is not None and gyro_out.resolve() == out.resolve():
        raise OptinavError("--gyro-out and --out name the same file", "give the gyroscope file another name")
    from optinav.multipos.exchange import export_calibration, load_export_source

    res = load_export_source(args.result, args.gyro_cal, args.to, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit)
    noise = None
    if args.noise:
        from optinav.core.allan import AllanAnalysis

        noise = load_option_result(AllanAnalysis, args.noise, "--noise", _NOISE_NEEDS)
    from optinav.multipos.kalibr import counts_per_si

    cps = counts_per_si(args.acc_lsb, args.gyro_lsb)
    for path in export_calibration(
        res,
        args.to,
        out,
        gyro_out=gyro_out,
        noise=noise,
        rostopic=args.rostopic,
        update_rate=args.rate_hz,
        counts_per_si=cps,
        allow_rw_bound=args.allow_rw_bound,
    ):
        print(f"optinav: {args.to} file written to {path}")
    print_notes(_notes(args, res, noise))
    return 0


#: what --noise takes
_NOISE_NEEDS = "the ALLAN.json that optinav allan writes with --out (not its --kalibr YAML)"


def _notes(args, res, noise) -> list[str]:
    """What the written file does not say: held parameters, Kalibr's default topic, Kalibr without noise keys."""
    from optinav.multipos.exchange import held_note
    from optinav.multipos.kalibr import DEFAULT_ROSTOPIC_NOTE

    notes = [n for n in (held_note(res, args.to),) if n]
    # what the noise rests on (a log too short for K put 170x the truth into imu.yaml with no word)
    notes += [f"--noise {args.noise}: {n}" for n in (noise.notes if noise is not None else [])]
    if args.to == "kalibr" and noise is not None:
        from optinav.multipos.kalibr import random_walk_bounds

        notes += random_walk_bounds(noise, allow=True)
    if args.to == "kalibr" and noise is not None and not (args.rostopic or noise.rostopic):
        notes.append(DEFAULT_ROSTOPIC_NOTE)
    if args.to == "kalibr" and noise is None:
        notes.append(
            "no --noise given, so the file lacks Kalibr's noise keys (run optinav allan on a static log and pass its "
            "result)"
        )
    return notes
