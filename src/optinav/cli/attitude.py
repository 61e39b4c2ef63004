"""``optinav attitude``: attitude from a gyroscope + accelerometer log (+ skylight polarization) to CSV."""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from pathlib import Path

from optinav.cli.common import (
    ELEVATION,
    HEIGHT,
    LATITUDE,
    LONGITUDE,
    POSITIVE,
    RATE,
    SEED,
    add_chunk_option,
    add_gyro_file_options,
    add_counts_options,
    add_input_options,
    add_report_option,
    check_disk,
    check_memory,
    finish_report,
    number,
    options_from_args,
    output_path,
    parse_floats,
    parse_key_values,
    prepare_report,
    print_notes,
    require_files,
    truth_path,
)
from optinav.core.files import SIMULATED, check_sidecar, write_csv
from optinav.errors import OptinavError

METHOD_NAMES = ("iframe", "qn", "gd", "cg", "mekf")


#: help of --drop-nan (optinav attitude and batch attitude)
DROP_NAN_HELP = (
    "leave out rows with a NaN accelerometer/gyro value as lost samples instead of refusing the file (implied by "
    "--skip-bad-lines, which leaves unreadable lines out so)"
)


def register_commands(sub) -> None:
    """The system's top-level command (registry hook)."""
    register(sub)


def register(sub) -> None:
    p = sub.add_parser(
        "attitude",
        help="attitude (quaternion, roll/pitch/yaw) from gyro + accelerometer (+ polarization)",
        description=textwrap.dedent("""\
            Estimate the attitude q_b^n of every sample from a gyroscope + accelerometer log with iframe
            (default: accelerometer filtered in an almost-inertial frame, rest detection, gyro bias, optional
            magnetometer with --mag, --offline smoothing; after VQF, Laidig & Seel 2023), the quasi-Newton
            filter of Jin et al. 2021 (qn), gradient descent (gd, Madgwick), conjugate gradient (cg) or a
            multiplicative EKF with gyro bias (mekf; the default with --pol-columns alone online; iframe takes
            --pol-columns too, and is the default with --mag or --offline). gd/cg/qn/mekf run after
            iframe's input stage unless --no-input-stage (then exactly as published). Without polarization or
            magnetometer the roll and pitch are observed and the heading follows the gyro. With --pol-columns the file's angle of
            polarization (a zenith-viewing sensor, reference axis forward; see docs/methods/attitude.md)
            corrects the heading; the sun comes from --lat/--lon/--start-time (NREL SPA at every sample)
            or from --sun-azimuth/--sun-elevation. Output CSV columns: t [s], qw, qx, qy, qz,
            roll_deg, pitch_deg, yaw_deg (Euler angles of --frame: NED = forward-right-down body, yaw
            clockwise from north; ENU = right-forward-up body, yaw counter-clockwise from north)."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav attitude imu.csv --columns t,ax,ay,az,gx,gy,gz --gyro-unit deg/s --out att.csv
              optinav attitude flight.csv --method mekf --pol-columns aop,dop --aop-unit deg \\
                  --lat 38.8814192 --lon 121.528255 --start-time 2021-01-16T16:33:00+08:00 \\
                  --out att.csv --report rep
              optinav attitude 02_undisturbed_slow_rotation_B.hdf5 --frame ENU --mag --offline \\
                  --reference --out att.csv   (a BROAD trial, scored against its optical reference)
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("data", help="log file: CSV/TSV/text, NPZ, HDF5, MAT, Parquet, a ROS bag or a PX4 ULog (--topic)")
    add_input_options(p)
    add_counts_options(p)
    add_gyro_file_options(p)
    p.add_argument("--method", choices=METHOD_NAMES, help="estimator (default iframe; mekf with --pol-columns alone)")
    p.add_argument(
        "--offline",
        action="store_true",
        help="iframe: use the whole recording (forward-backward); default online (no future sample)",
    )
    p.add_argument(
        "--input-stage",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="gd/cg/qn/mekf: iframe's gyro bias and accelerometer filtering before the method (default); "
        "--no-input-stage runs them exactly as published",
    )
    p.add_argument(
        "--mag",
        action="store_true",
        help="iframe: heading from the magnetometer (BROAD: imu_mag; else columns mx,my,mz or one triad by the usual "
        "names: mag_x, 'Mag X (uT)', magnetometer_x, magneticField_x, ...)",
    )
    p.add_argument(
        "--mag-columns",
        metavar="MX,MY,MZ",
        help="names of the magnetometer columns ('-' before one reads it negated), or of its N×3 array (implies --mag)",
    )
    _add_hard_iron(p)
    _add_declination(p, "option", [])
    p.add_argument(
        "--mag-file",
        dest="mag_path",
        metavar="MAGDATA",
        help="the magnetometer in a file of its own with a time column on the IMU's clock (implies --mag; "
        "--mag-columns names its columns): a slower one is put each sample on its nearest IMU row, a faster one "
        "interpolated; a phone export's Magnetometer.csv and a Physics Toolbox multi record's Bx,By,Bz are read so "
        "with --mag",
    )
    p.add_argument(
        "--allow-gaps", action="store_true", help="restart the estimate after a time gap instead of refusing the file"
    )
    p.add_argument("--drop-nan", action="store_true", help=DROP_NAN_HELP)
    p.add_argument(
        "--reference",
        action="store_true",
        help="score against the file's reference orientation (BROAD: opt_quat, movement; a simulated flight: "
        "STEM.truth.csv beside it): inclination and heading RMSE",
    )
    p.add_argument(
        "--frame", choices=["NED", "ENU"], default="NED", help="navigation frame (default NED; body forward-right-down)"
    )
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="estimator option in SI units, e.g. gain=0.1 (repeatable; see docs/methods/attitude.md)",
    )
    p.add_argument(
        "--q0-deg",
        metavar="ROLL,PITCH,YAW",
        help="initial roll, pitch, yaw in deg (default: levelled from the first sample, heading from polarization "
        "on the branch the log's tilting shows, refused when it shows none, or from the magnetometer, else 0)",
    )
    pol = p.add_argument_group("polarization (optional)")
    pol.add_argument(
        "--pol-columns",
        metavar="AOP[,DOP]",
        help="names of the angle-of-polarization column (and degree of polarization) in DATA; NaN = no sample",
    )
    pol.add_argument("--aop-unit", choices=["rad", "deg"], default="rad", help="unit of the AoP column")
    pol.add_argument("--lat", type=LATITUDE, metavar="DEG", help="latitude, deg (sun position)")
    pol.add_argument("--lon", type=LONGITUDE, metavar="DEG", help="longitude, deg east (sun position)")
    pol.add_argument("--height", dest="height_m", type=HEIGHT, default=0.0, metavar="M", help="height, m (default 0)")
    pol.add_argument("--start-time", metavar="ISO8601", help="time of t = 0 with UTC offset")
    pol.add_argument(
        "--sun-azimuth",
        type=number(-360.0, 360.0, what="an azimuth in degrees"),
        metavar="DEG",
        help="fixed sun azimuth, deg from north to east",
    )
    pol.add_argument("--sun-elevation", type=ELEVATION, metavar="DEG", help="fixed sun elevation, deg")
    pol.add_argument(
        "--min-dop",
        type=number(0.0, 1.0, what="a degree of polarization in [0, 1]"),
        default=0.05,
        help="skip samples with a lower DoP (default 0.05)",
    )
    p.add_argument("--out", required=True, metavar="ATTITUDE.csv", help="output CSV")
    add_chunk_option(p)
    add_report_option(p)
    p.set_defaults(func=run, progress_task="attitude")


class _OptionsAction(argparse.Action):
    """--option KEY=VALUE, repeatable, into a dict of numbers."""

    def __call__(self, parser, namespace, value, option_string=None):
        try:
            new = parse_key_values([value])
        except OptinavError as exc:
            parser.error(str(exc))
        setattr(namespace, self.dest, {**(getattr(namespace, self.dest, None) or {}), **new})


def _hard_iron_arg(text: str) -> tuple:
    """--mag-hard-iron BX,BY,BZ as three finite numbers."""
    try:
        return tuple(parse_floats(text, 3, "--mag-hard-iron", "BX,BY,BZ"))
    except OptinavError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _add_hard_iron(p) -> None:
    p.add_argument(
        "--mag-hard-iron",
        type=_hard_iron_arg,
        metavar="BX,BY,BZ",
        help="the magnetometer's hard-iron offset (its unit) to subtract from every row (write --mag-hard-iron=-1,2,3 "
        "when the first is negative); default: an offset the field shows is fitted from the whole recording and "
        "subtracted with --offline, and online fitted from past samples (the magnetometer used once that fit holds; "
        "refused when it never does)",
    )


#: help of --declination-deg (optinav attitude and batch attitude)
DECLINATION_HELP = (
    "iframe: the magnetic declination in deg, east positive (magnetic north east of true north, as the World "
    "Magnetic Model gives it; west negative): the magnetometer's heading is turned to the true one (default 0: "
    "magnetic heading)"
)
DECLINATION = number(-180.0, 180.0, what="an angle in degrees")


def _add_declination(p, dest: str, default) -> None:
    """--declination-deg into the estimator options of ``dest`` (``attitude``'s --option list, ``batch attitude``'s
    option dict, its ``default``)."""
    p.add_argument(
        "--declination-deg",
        type=DECLINATION,
        metavar="DEG",
        help=DECLINATION_HELP,
        dest=dest,
        default=default,
        action=_DeclinationAction,
    )


class _DeclinationAction(argparse.Action):
    """--declination-deg DEG as the estimator option ``declination`` (rad): one more KEY=VALUE item of
    ``attitude``'s --option list, or a key of ``batch attitude``'s option dict (as --option sets them: the last
    given wins)."""

    def __call__(self, parser, namespace, value, option_string=None):
        rad, old = math.radians(value), getattr(namespace, self.dest, None)
        new = [*old, f"declination={rad!r}"] if isinstance(old, list) else {**(old or {}), "declination": rad}
        setattr(namespace, self.dest, new)


def add_batch_options(p) -> None:
    """``optinav batch attitude``: the options of ``optinav attitude`` a folder shares (registry hook;
    destinations are the fields of :class:`optinav.attitude.unit.AttitudeOptions`)."""
    add_input_options(p)
    add_counts_options(p)
    p.add_argument("--method", choices=METHOD_NAMES, help="estimator (default iframe)")
    p.add_argument("--offline", action="store_true", help="iframe: use the whole recording (forward-backward)")
    p.add_argument(
        "--input-stage",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="gd/cg/qn/mekf: iframe's gyro bias and accelerometer filtering before the method (default); "
        "--no-input-stage runs them exactly as published",
    )
    p.add_argument("--mag", action="store_true", help="iframe: heading from the magnetometer")
    p.add_argument(
        "--mag-columns",
        metavar="MX,MY,MZ",
        help="names of the magnetometer columns ('-' before one reads it negated), or of its N×3 array (implies --mag)",
    )
    _add_hard_iron(p)
    _add_declination(p, "options", {})
    p.add_argument("--allow-gaps", action="store_true", help="restart the estimate after a time gap")
    p.add_argument("--drop-nan", action="store_true", help=DROP_NAN_HELP)
    p.add_argument("--frame", choices=["NED", "ENU"], default="NED", help="navigation frame (default NED)")
    p.add_argument(
        "--option",
        dest="options",
        action=_OptionsAction,
        default={},
        metavar="KEY=VALUE",
        help="estimator option in SI units, e.g. gain=0.1 (repeatable)",
    )


def _checked(args):
    """(method, estimator options, q0 or None, output path): the arguments checked before any data is read."""
    import numpy as np

    from optinav.attitude.methods import _method
    from optinav.attitude.methods import _options as check_options
    from optinav.core.rotations import frame_name, quat_from_euler

    options = parse_key_values(args.option)
    # the magnetometer as AttitudeOptions.uses_mag takes it: with polarization it (or --offline) makes iframe the default
    method = _method(
        args.method,
        True if args.pol_columns else None,
        bool(args.mag or args.mag_columns or getattr(args, "mag_path", None)),
        args.offline,
    )
    check_options(method, options)
    from optinav.attitude.recording import CSV_HEADER

    out = output_path(args.out, (".csv",), "ATTITUDE.csv", mark=CSV_HEADER.encode())
    if out.exists() and out.resolve() == Path(args.data).resolve():
        raise OptinavError(f"--out {out} is the input file", "write the attitude to another file")
    prepare_report(args)
    q0 = None
    if args.q0_deg:
        e = parse_floats(args.q0_deg, 3, "--q0-deg", "ROLL,PITCH,YAW")
        q0 = quat_from_euler(np.radians(e), frame_name(args.frame))
    if not args.pol_columns and any(
        v is not None for v in (args.lat, args.lon, args.start_time, args.sun_azimuth, args.sun_elevation)
    ):
        raise OptinavError("sun options were given without --pol-columns", "add --pol-columns AOP[,DOP] or drop them")
    return method, options, q0, out


def _polarization(args, t):
    """The polarization measurement of ``--pol-columns`` with the sun of the place/time or fixed-sun options."""
    from optinav.attitude import PolarizationMeasurement
    from optinav.attitude.recording import read_polarization, sun_along_log

    aop, dop = read_polarization(
        args.data, args.pol_columns, t.size, aop_unit=args.aop_unit, delimiter=args.delimiter, topic=args.topic
    )
    sun = sun_along_log(t, args.frame, **_sun(args))
    return PolarizationMeasurement(aop, sun, dop=dop, frame=args.frame, min_dop=args.min_dop)


def _sun(args) -> dict:
    """The sun options of :func:`optinav.attitude.recording.sun_along_log`, in radians."""
    rad = [None if v is None else math.radians(v) for v in (args.lat, args.lon, args.sun_azimuth, args.sun_elevation)]
    return dict(
        lat=rad[0], lon=rad[1], height_m=args.height_m, start_time=args.start_time, azimuth=rad[2], elevation=rad[3]
    )


def _announce(args, method):
    """What the command says on stderr before the estimate (nothing with --quiet)."""
    if not getattr(args, "quiet", False):
        return lambda n: print(f"optinav: attitude of {n} samples from {args.data} ({method}) ...", file=sys.stderr)
    return lambda n: None


def run(args) -> int:
    from optinav.attitude.recording import CSV_FORMAT, CSV_HEADER, attitude_rows, reference_rmse, score_line
    from optinav.attitude.unit import AttitudeOptions, read_log, steps
    from optinav.core.progress import step
    from optinav.core.rotations import attitude_in_frame

    method, options, q0, out = _checked(args)
    require_files((args.data, "data file"), (args.gyro_path, "gyroscope file"), (args.mag_path, "magnetometer file"))
    o = options_from_args(AttitudeOptions, args, options=options)
    if _streams(args):
        return _run_stream(args, o, q0, out, _announce(args, method))
    step("read")
    t, gyr, acc, mag, ref = read_log(args.data, o, reference=args.reference)
    step("checks")
    dt = steps(t, args.data)
    pol = _polarization(args, t) if args.pol_columns else None
    _announce(args, method)(t.size)
    from optinav.attitude import estimate  # the kernels load once the log is read and checked
    from optinav.reports.attitude_report import write_attitude_report

    step(f"estimate ({method})")
    res = estimate(
        gyr,
        acc,
        dt,
        pol=pol,
        method=method,
        frame=args.frame,
        q0=q0,
        mag=mag,
        mag_hard_iron=o.mag_hard_iron,
        offline=args.offline,
        input_stage=args.input_stage,
        allow_gaps=args.allow_gaps,
        **options,
    )
    table = attitude_rows(t, res.q_b_n, args.frame)
    step("write")
    write_csv(out, table, CSV_HEADER, CSV_FORMAT)
    print(res.summary())
    q_enu = attitude_in_frame(res.q_b_n, args.frame, "enu")  # BROAD's reference is body -> ENU
    score = reference_rmse(q_enu, *ref, gyr, dt, acc, "enu") if args.reference else None
    if score is not None:
        print(score_line(score, "yaw" not in res.unobservable()))
    print(f"optinav: attitude written to {out}")
    finish_report(args, lambda d: write_attitude_report(res, t, table[:, 5:], args.data, d, score))
    return 0


def _streams(args) -> bool:
    """Whether the log is estimated block by block: always (--offline smoothing streams through a scratch file beside
    --out; --report keeps the summary's fields and every k-th row for its figure). The in-memory path below is the
    reference the streamed one is compared with byte for byte (tests/test_stream.py switches it on)."""
    return True


#: rows of roll, pitch and yaw the --report figure shows at most (every k-th row of a longer log)
REPORT_POINTS = 200_000


def _run_stream(args, options, q0, out, announce) -> int:
    """The attitude of a log read block by block (:func:`optinav.attitude.filestream.stream_attitude`)."""
    from optinav.attitude.filestream import pol_columns, stream_attitude
    from optinav.attitude.unit import reference_sources

    pol = (
        pol_columns(args.pol_columns, args.frame, aop_unit=args.aop_unit, min_dop=args.min_dop, **_sun(args))
        if args.pol_columns
        else None
    )
    run = stream_attitude(
        args.data,
        out,
        options,
        q0=q0,
        pol=pol,
        **reference_sources(args.data, options, args.reference, required=True),  # BROAD, or a simulator's truth
        chunk_rows=args.chunk_rows,
        announce=lambda n, m: announce(n),
        figure_points=REPORT_POINTS if args.report else 0,
    )
    print_notes(run.notes)
    print(run.summary)
    if run.score is not None:
        from optinav.attitude.recording import score_line

        print(score_line(run.score, "yaw" not in run.estimate.unobservable()))
    print(f"optinav: attitude written to {out}")
    if args.report:
        from optinav.reports.attitude_report import write_attitude_report

        t, eul = run.figure
        finish_report(
            args,
            lambda d: write_attitude_report(
                run.estimate, t, eul, args.data, d, run.score, n_samples=run.n, errors=run.figure_errors
            ),
        )
    return 0


def register_simulate(kinds) -> None:
    """``optinav simulate flight``: a UAV flight with a skylight-polarization sensor (Jin et al. 2021 setup)."""
    p = kinds.add_parser(
        "flight",
        help="a UAV flight (MPU-6000 IMU + zenith polarization sensor) at the paper's place and time",
        description=textwrap.dedent("""\
            A static or manoeuvring flight at Dalian (121.528255° E, 38.8814192° N, 35 m) at the paper's
            local times (static 2021-01-17 10:34, dynamic 2021-01-16 16:33, +08:00), recorded by an
            MPU-6000-class IMU and a zenith-viewing 3-channel polarization sensor (Rayleigh sky, sun by the
            NREL SPA). Writes a CSV with t [s], ax, ay, az [m/s^2], gx, gy, gz [rad/s] (body forward-right-
            down), aop_deg (angle of polarization, deg, NaN when not measured) and dop, plus STEM.truth.csv
            (t, qw, qx, qy, qz: the true q_b^n, NED) for comparing `optinav attitude`'s output, and STEM.truth.json
            (the truth in the result layout: q_b_n, roll, pitch, yaw; docs/results.md)."""),
        epilog=textwrap.dedent("""\
            example:
              optinav simulate flight --kind dynamic --duration 30 --seed 1 --out flight.csv
              optinav attitude flight.csv --method mekf --pol-columns aop_deg,dop --aop-unit deg \\
                  --lat 38.8814192 --lon 121.528255 --start-time 2021-01-16T16:33:00+08:00 \\
                  --q0-deg 0,0,-111 --out att.csv
              (a zenith polarization angle fixes the heading only up to 180°: without --q0-deg the
              flight's tilting picks the branch and a level log is refused; here --q0-deg gives the
              initial attitude the simulator printed)
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", required=True, metavar="DATA.csv", help="output CSV")
    p.add_argument("--kind", choices=["static", "dynamic"], default="dynamic", help="flight (default dynamic)")
    p.add_argument("--duration", type=POSITIVE, default=60.0, metavar="S", help="duration in s (default 60)")
    p.add_argument("--rate", dest="rate_hz", type=RATE, default=100.0, metavar="HZ", help="sample rate (default 100)")
    p.add_argument("--gyro-bias", metavar="BX,BY,BZ", help="constant residual gyro bias, deg/s (default none)")
    p.add_argument("--seed", type=SEED, default=0)
    p.set_defaults(func=run_simulate_flight, progress_task="simulate flight")


#: peak disk use per sample of ``simulate flight`` (measured: the CSV ~150 B, the truth CSV ~85 B, the truth JSON
#: ~155 B, held twice while it is assembled from its scratch files), with margin
FLIGHT_DISK_BYTES_PER_ROW = 700
#: memory per knot (0.1 s apart) of the dynamic trajectory, which is held whole (measured ~230 B), with margin
FLIGHT_BYTES_PER_KNOT = 400


def run_simulate_flight(args) -> int:
    import numpy as np

    from optinav.attitude.recording import TRUTH_CSV_HEADER, flight_writer
    from optinav.attitude.simulate import FlightStream
    from optinav.core.progress import progress, step
    from optinav.core.rotations import euler_from_quat

    out = output_path(args.out, (".csv",), "flight.csv", mark=SIMULATED)
    truth = check_sidecar(out.with_name(out.stem + ".truth.csv"), TRUTH_CSV_HEADER + "\n")
    truth_json = truth_path(out)
    remedy = "shorten --duration or lower --rate"
    if args.kind == "dynamic":
        check_memory(args.duration / 0.1, FLIGHT_BYTES_PER_KNOT, "this flight's trajectory", "shorten --duration")
    check_disk(args.duration * args.rate_hz, FLIGHT_DISK_BYTES_PER_ROW, out, "this flight", remedy)
    bias = np.radians(parse_floats(args.gyro_bias, 3, "--gyro-bias", "BX,BY,BZ")) if args.gyro_bias else None
    step("simulate")
    stream = FlightStream(args.kind, duration_s=args.duration, rate_hz=args.rate_hz, gyro_bias=bias, rng=args.seed)
    info = {"kind": args.kind, "seed": args.seed, "rate_hz": args.rate_hz, "start_time": str(stream.start_time)}
    q0 = None
    with flight_writer(out, truth, truth_json, frame=stream.frame, info=info) as write:
        for block in progress(stream.blocks(), total=stream.n_blocks(), desc="simulate flight"):
            q0 = block["q_b_n"][0] if q0 is None else q0
            write(block)
    e0 = np.degrees(euler_from_quat(q0, stream.frame))
    print(
        f"optinav: wrote {stream.n} samples ({args.kind}, start {stream.start_time}) to {out} and the true "
        f"attitude to {truth}; initial roll, pitch, yaw [deg]: {e0[0]:.1f}, {e0[1]:.1f}, {e0[2]:.1f}",
        file=sys.stderr,
    )
    return 0
