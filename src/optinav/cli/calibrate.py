"""``optinav calibrate accel``: multi-position calibration of a raw log (accelerometer, and gyroscope if present)."""

from __future__ import annotations

import argparse
import math
import sys
import textwrap

from optinav.cli.common import (
    ANGLE,
    COUNT,
    HEIGHT,
    LATITUDE,
    NON_NEGATIVE,
    POSITIVE,
    SEED,
    TIME,
    add_chunk_option,
    add_gyro_file_options,
    add_input_options,
    add_report_option,
    finish_report,
    output_path,
    prepare_report,
    print_notes,
    register_system_hooks,
)
from optinav.core.files import RESULT_MARK
from optinav.errors import OptinavError

METHOD_NAMES = ("lm", "gn", "trf", "newton", "ga", "pso", "ferraris")


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="calibrate sensors or a system from a log (multi-position IMU, rotational INS, gyro-free array)",
        description="Calibrate an accelerometer and gyroscope from static poses (accel), the gimbal "
        "non-orthogonality of a dual-axis rotational INS (rins), or the installation errors of a "
        "gyro-free accelerometer array on a turntable (gfimu).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = p.add_subparsers(dest="sensor", metavar="SENSOR", title="sensors")
    a = kinds.add_parser(
        "accel",
        help="accelerometer by norm observation; gyroscope from the turns between poses",
        description=textwrap.dedent("""\
            Accelerometer calibration by norm observation on static poses (Gao & Zhang 2019), default method
            Levenberg–Marquardt on the per-pose means with analytic Jacobian; GA/Newton/PSO for comparison;
            'ferraris' = closed form for 6 axis poses + 3 rotations named as imucal names them (x_p … z_rot),
            from a label column of the log (then the default) or --sections.
            With gyroscope data the gyro scale, misalignment and bias come from the turns between poses
            (imu_tk's method). The result is raw = K·x + b per sensor (x in m/s^2 or rad/s, raw in the
            file's unit); see docs/file-formats.md."""),
        epilog=textwrap.dedent("""\
            example (a simulated session, then its calibration):
              optinav simulate accel-multipos --out session.csv --acc-unit counts --gyro-unit deg/s
              optinav calibrate accel session.csv --latitude 38.88 --height 35 --out result.json --report rep
              optinav apply result.json session.csv --out corrected.csv
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    a.add_argument("data", help="log file: CSV/TSV/text, NPZ, HDF5, MAT, Parquet, a ROS bag or a PX4 ULog (--topic)")
    add_gyro_file_options(a)
    add_calibration_options(a)
    a.add_argument("--out", required=True, metavar="RESULT.json", help="result file (JSON)")
    a.add_argument(
        "--export",
        action="append",
        default=[],
        metavar="FMT:FILE",
        help="also write the calibration for another tool: imucal:cal.json, kalibr:imu.yaml or "
        "imu_tk:acc.calib,gyro.calib (repeatable; see optinav export --help)",
    )
    add_report_option(a)
    a.set_defaults(func=run_accel, progress_task="calibrate accel")
    register_system_hooks(kinds, "register_calibrate")
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def add_batch_options(p) -> None:
    """``optinav batch calibrate accel``: the options of ``calibrate accel`` (registry hook)."""
    add_calibration_options(p)


def add_apply_options(g) -> None:
    """``optinav apply`` of a multi-position calibration: how the raw log is read (registry hook; destinations
    are the fields of :class:`optinav.multipos.apply.ApplyOptions`)."""
    g.add_argument(
        "--gyro-cal", metavar="FILE", help="imu_tk's gyroscope parameter file (RESULT is then its accelerometer file)"
    )
    add_input_options(g, unit_default=("the calibration's", "the calibration's"))
    add_chunk_option(g)


def calibrate_unit(args, name: str) -> int:
    """``optinav calibrate SYSTEM``: the system's options from ``args``, checked, then its ``run_unit`` on
    ``args.data`` (what ``optinav batch calibrate`` runs per unit); writes the result and ``--report``."""
    from optinav import registry
    from optinav.cli.common import system_options
    from optinav.core.progress import step

    system = registry.SYSTEMS[name]
    out = output_path(args.out, (".json",), "RESULT.json", mark=RESULT_MARK)
    prepare_report(args)
    options = system_options(system, args)
    system.load("check")(options)
    if not getattr(args, "quiet", False):
        print(f"optinav: calibrating {args.data} ({options.method}) ...", file=sys.stderr)
    res, _ = system.load("run_unit")(args.data, options)
    step("write")
    res.to_json(out)
    print(res.summary())
    print(f"optinav: result written to {out}")
    finish_report(args, lambda d: system.load("report")(res, d, args.data, options))
    return 0


def add_calibration_options(a) -> None:
    """The reading and estimation options of ``calibrate accel`` (shared with ``batch calibrate accel``);
    their destinations are the fields of :class:`optinav.multipos.calibrate.FileOptions`."""
    a.add_argument("--no-gyro", action="store_true", help="ignore gyroscope columns in DATA")
    add_input_options(a)
    grav = a.add_mutually_exclusive_group()
    grav.add_argument("--gravity", type=POSITIVE, metavar="G", help="local gravity in m/s^2")
    grav.add_argument(
        "--latitude", dest="lat_deg", type=LATITUDE, metavar="DEG", help="latitude in degrees (normal gravity)"
    )
    a.add_argument(
        "--height", dest="height_m", type=HEIGHT, metavar="M", help="height in m with --latitude (default 0)"
    )
    a.add_argument(
        "--method",
        choices=METHOD_NAMES,
        help="estimator (default lm; ferraris for a log cut to imucal's nine sections x_p … z_rot, every row labelled)",
    )
    a.add_argument(
        "--model",
        choices=["auto", "full", "diagonal"],
        default="auto",
        help="accelerometer model: auto (9 parameters when observable, else scales and biases), "
        "full (9, error if not observable), diagonal (6)",
    )
    a.add_argument(
        "--fit-samples",
        action="store_true",
        help="fit every sample instead of the pose means (as the paper does; biased by sigma^2/g)",
    )
    a.add_argument(
        "--sections",
        metavar="FILE",
        help="static sections by hand: 'start end' lines in s, JSON, or imucal's section list (sample indices)",
    )
    a.add_argument(
        "--hold-out",
        type=int,
        metavar="K",
        help="leave static pose K (1-based, in time order) out of the fit and print how the calibration "
        "does on it: |a| - g of the held-out pose beside the rms over the poses used (an "
        "out-of-sample check; kept in the result's quality.held_out)",
    )
    a.add_argument("--window", type=POSITIVE, default=1.0, metavar="S", help="moving-variance window (default 1 s)")
    a.add_argument(
        "--min-duration",
        type=NON_NEGATIVE,
        default=2.0,
        metavar="S",
        help="shortest static interval kept (default 2 s)",
    )
    a.add_argument(
        "--threshold",
        type=POSITIVE,
        help="static threshold on the acc moving variance (raw units^2); default automatic",
    )
    a.add_argument(
        "--acc-range",
        type=full_scale,
        metavar="R|LO:HI",
        help="accelerometer full scale in raw units: R for ±R (e.g. 32768 for signed 16-bit counts) or "
        "a span LO:HI (e.g. 0:65535 for unsigned 16-bit); samples at or beyond it count as saturated "
        "(default for counts: the ends of the 16/24/32-bit signed or unsigned type the data fit)",
    )
    a.add_argument(
        "--gyro-range",
        type=full_scale,
        metavar="R|LO:HI",
        help="gyroscope full scale in raw units, like --acc-range; turns that saturate are left out",
    )
    a.add_argument(
        "--gyro-bias",
        choices=["static", "local", "rest", "estimate"],
        default="local",
        help="gyro bias during each turn from the two rests it joins (local, the default: follows a bias "
        "that drifts), one mean over the static intervals (static), the initial rest (rest: the first "
        "static interval, or --rest T0 T1), "
        "or estimated with K",
    )
    a.add_argument(
        "--rest",
        nargs=2,
        type=TIME,
        metavar=("T0", "T1"),
        help="rest window in s for --gyro-bias rest (default the first static interval)",
    )
    a.add_argument(
        "--rotation-angle",
        type=ANGLE,
        default=-360.0,
        metavar="DEG",
        help="--method ferraris: the angle of each of the three turns in degrees (default -360, imucal's "
        "clockwise full turn seen from the axis tip)",
    )
    a.add_argument(
        "--pose-alignment",
        type=NON_NEGATIVE,
        default=1.0,
        metavar="DEG",
        help="--method ferraris: 1-sigma of how well each pose and turn axis lines up with the sensor axes, in "
        "degrees (default 1: placed by hand against a table or box; 0.1 for a precise jig); enters the std of "
        "the misalignments, which a tilted pose fakes one for one",
    )
    a.add_argument(
        "--acc-bias-instability",
        type=NON_NEGATIVE,
        metavar="RAW",
        help="1-sigma accelerometer bias drift over the session in raw units (datasheet bias "
        "instability or run-to-run), added to the bias std: the poses cannot reveal a common drift",
    )
    a.add_argument(
        "--held-misalignment",
        type=NON_NEGATIVE,
        metavar="RAD",
        help="1-sigma of the misalignments the diagonal model holds at 0 (default 0.0071 rad: six MEMS "
        "misalignments of 0.005 rad each, two in each held term); their model error enters the scale and "
        "bias std and the gyro's",
    )
    a.add_argument(
        "--gyro-bias-instability",
        type=NON_NEGATIVE,
        metavar="RAW",
        help="1-sigma gyro bias drift in raw units (stationary sigma of a Gauss-Markov bias, see "
        "--gyro-bias-corr-time; or run-to-run), added to the gyro bias std, which is then against the "
        "long-term bias: a drift common to all rests leaves no trace in them",
    )
    a.add_argument(
        "--gyro-bias-corr-time",
        type=POSITIVE,
        default=float("inf"),
        metavar="S",
        help="correlation time in s of the Gauss-Markov bias that --gyro-bias-instability gives the "
        "stationary 1-sigma of (default inf: a constant offset per run); with --gyro-bias local the "
        "std adds what the session's mean keeps of it",
    )
    a.add_argument(
        "--gyro-g-sensitivity",
        type=NON_NEGATIVE,
        metavar="RAW",
        help="1-sigma gyro g-sensitivity per element in raw gyro units per m/s^2 (datasheet), which the "
        "model leaves out; added to the gyro bias and K std",
    )
    a.add_argument(
        "--allow-unobservable",
        action="store_true",
        help="hold the gyro parameters the turns do not determine at their initial guess instead of "
        "stopping (they are listed in the result)",
    )
    a.add_argument("--generations", type=COUNT, help="GA/PSO generations (default: the optimizer's)")
    a.add_argument("--seed", type=SEED, default=0, help="random seed for GA/PSO (default 0)")


def full_scale(text: str):
    """``R`` (±R) or ``LO:HI`` (a span) in raw units → float or (lo, hi); argparse type of --acc/--gyro-range."""
    try:
        if ":" in text:
            lo, hi = (float(v) for v in text.split(":"))
            if lo < hi and math.isfinite(lo) and math.isfinite(hi):
                return (lo, hi)
        else:
            r = float(text)
            if r > 0 and math.isfinite(r):
                return r
    except ValueError:
        pass
    raise argparse.ArgumentTypeError(f"{text!r} is not R > 0 or LO:HI with LO < HI (raw units)")


def run_accel(args) -> int:
    from optinav.core.progress import step
    from optinav.cli.common import file_options
    from optinav.multipos.calibrate import calibrate_data, read_session_file, resolve_method

    out = output_path(args.out, (".json",), "RESULT.json", mark=RESULT_MARK)
    exports = distinct_outputs(out, [parse_export(spec) for spec in args.export])
    prepare_report(args)
    options = file_options(args)
    options.check()
    step("read")
    data = read_session_file(args.data, options)
    options = resolve_method(options, data)
    counts = [s for s, u in (("--acc-lsb", data.acc_unit), ("--gyro-lsb", data.gyro_unit)) if u == "counts"]
    if counts and any(fmt == "kalibr" for fmt, *_ in exports):
        # refused before the work: Kalibr's M is relative to the driver's conversion to m/s² and rad/s
        raise OptinavError(
            "--export kalibr of a calibration in raw counts needs the driver's sensitivity (Kalibr reads m/s^2 and "
            "rad/s)",
            f"drop it here and run optinav export RESULT.json --to kalibr {' '.join(f'{c} ...' for c in counts)}",
        )
    _say_calibrating(args, len(data.t), options.method)
    res = calibrate_data(data, options, source=str(args.data))
    step("write")
    res.to_json(out)
    print_notes(res.quality.get("notes", []))
    print(res.summary())
    print(f"optinav: result written to {out}")
    if exports:
        from optinav.multipos.exchange import export_calibration

        for fmt, path, gyro_path in exports:
            for p in export_calibration(res, fmt, path, gyro_out=gyro_path, option="--export"):
                print(f"optinav: {fmt} file written to {p}")
    from optinav.reports.calibration_report import write_calibration_report

    finish_report(args, lambda d: write_calibration_report(res, data.t, data.acc, data.gyr, d))
    return 0


def _say_calibrating(args, n: int, method: str) -> None:
    """The console line before the fit: how many samples, which method (and why, when the data chose it)."""
    if not getattr(args, "quiet", False):
        why = (
            ": the log is cut to the nine sections its labels name"
            if args.method is None and method == "ferraris"
            else ""
        )
        print(f"optinav: calibrating {n} samples from {args.data} ({method}{why}) ...", file=sys.stderr)


def distinct_outputs(out, exports: list) -> list:
    """``exports`` (of :func:`parse_export`) when no two outputs, --out included, name one file (the last would
    silently replace the other: a result file turned into an imucal file)."""
    from pathlib import Path

    from optinav.errors import OptinavError

    seen = {Path(out).resolve(): "--out"}
    for fmt, *paths in exports:
        for p in (q for q in paths if q is not None):
            key = Path(p).resolve()
            if key in seen:
                raise OptinavError(
                    f"--export {fmt} names {p}, which {seen[key]} writes too", "give each output file its own name"
                )
            seen[key] = f"--export {fmt}"
    return exports


def parse_export(spec: str):
    """``FMT:FILE`` of --export (imu_tk takes ``ACC,GYRO``) → (format, path, gyro path or None), the paths checked
    before any work."""
    from optinav.cli.common import output_path
    from optinav.errors import OptinavError
    from optinav.multipos.exchange import FORMATS

    fmt, sep, rest = spec.partition(":")
    if not sep or fmt not in FORMATS or not rest:
        raise OptinavError(
            f"--export {spec!r} is not FMT:FILE with FMT one of {', '.join(FORMATS)}",
            "write e.g. --export imucal:cal.json or --export imu_tk:acc.calib,gyro.calib",
        )
    paths = rest.split(",") if fmt == "imu_tk" else [rest]
    if len(paths) > 2 or not all(paths):
        raise OptinavError(f"--export {spec!r} names {len(paths)} files", "imu_tk takes ACC,GYRO; others one file")
    from optinav.core.files import imu_tk_file

    mark = imu_tk_file if fmt == "imu_tk" else None
    checked = [output_path(p, option="--export", mark=mark) for p in paths]
    return fmt, checked[0], checked[1] if len(checked) > 1 else None
