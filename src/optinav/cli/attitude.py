"""``optinav attitude``: attitude from a gyroscope + accelerometer log (+ skylight polarization) to CSV."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from optinav.cli.common import (add_chunk_option, add_input_options, add_report_option, check_memory,
                                finish_report, output_path, parse_floats, prepare_report, truth_path, write_truth)
from optinav.core.files import atomic_open, check_sidecar, write_csv
from optinav.errors import OptinavError

METHOD_NAMES = ("iframe", "qn", "gd", "cg", "mekf")


def register_commands(sub) -> None:
    """The system's top-level command (registry hook)."""
    register(sub)


def register(sub) -> None:
    p = sub.add_parser(
        "attitude", help="attitude (quaternion, roll/pitch/yaw) from gyro + accelerometer (+ polarization)",
        description=textwrap.dedent("""\
            Estimate the attitude q_b^n of every sample from a gyroscope + accelerometer log with iframe
            (default: accelerometer filtered in an almost-inertial frame, rest detection, gyro bias, optional
            magnetometer with --mag, --offline smoothing; after VQF, Laidig & Seel 2023), the quasi-Newton
            filter of Jin et al. 2021 (qn), gradient descent (gd, Madgwick), conjugate gradient (cg) or a
            multiplicative EKF with gyro bias (mekf; the default with --pol-columns). gd/cg/qn/mekf run as
            published unless --input-stage. Without polarization or magnetometer the roll and pitch are
            observed and the heading follows the gyro. With --pol-columns the file's angle of
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
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", help="log file: CSV/TSV/text, NPZ, HDF5, MAT, Parquet or a ROS bag (--topic)")
    add_input_options(p)
    p.add_argument("--method", choices=METHOD_NAMES, help="estimator (default iframe; mekf with --pol-columns)")
    p.add_argument("--offline", action="store_true",
                   help="iframe: use the whole recording (forward-backward); default online (no future sample)")
    p.add_argument("--input-stage", action="store_true",
                   help="gd/cg/qn/mekf: gyro bias and accelerometer filtering of iframe before the method")
    p.add_argument("--mag", action="store_true",
                   help="iframe: heading from the magnetometer (BROAD: imu_mag; else columns mx,my,mz)")
    p.add_argument("--mag-columns", metavar="MX,MY,MZ", help="names of the magnetometer columns (implies --mag)")
    p.add_argument("--allow-gaps", action="store_true",
                   help="restart the estimate after a time gap instead of refusing the file")
    p.add_argument("--reference", action="store_true",
                   help="score against the file's reference orientation (BROAD: opt_quat, movement): "
                        "inclination and heading RMSE")
    p.add_argument("--frame", choices=["NED", "ENU"], default="NED",
                   help="navigation frame (default NED; body forward-right-down)")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator option in SI units, e.g. gain=0.1 (repeatable; see docs/methods/attitude.md)")
    p.add_argument("--q0-deg", metavar="ROLL,PITCH,YAW",
                   help="initial roll, pitch, yaw in deg (default: levelled from the first sample, heading "
                        "from polarization if available, else 0)")
    pol = p.add_argument_group("polarization (optional)")
    pol.add_argument("--pol-columns", metavar="AOP[,DOP]",
                     help="names of the angle-of-polarization column (and degree of polarization) in DATA; "
                          "NaN = no sample")
    pol.add_argument("--aop-unit", choices=["rad", "deg"], default="rad", help="unit of the AoP column")
    pol.add_argument("--lat", type=float, metavar="DEG", help="latitude, deg (sun position)")
    pol.add_argument("--lon", type=float, metavar="DEG", help="longitude, deg east (sun position)")
    pol.add_argument("--height", type=float, default=0.0, metavar="M", help="height, m (default 0)")
    pol.add_argument("--start-time", metavar="ISO8601", help="time of t = 0 with UTC offset")
    pol.add_argument("--sun-azimuth", type=float, metavar="DEG", help="fixed sun azimuth, deg from north to east")
    pol.add_argument("--sun-elevation", type=float, metavar="DEG", help="fixed sun elevation, deg")
    pol.add_argument("--min-dop", type=float, default=0.05, help="skip samples with a lower DoP (default 0.05)")
    p.add_argument("--out", required=True, metavar="ATTITUDE.csv", help="output CSV")
    add_chunk_option(p)
    add_report_option(p)
    p.set_defaults(func=run, progress_task="attitude")


class _OptionsAction(argparse.Action):
    """--option KEY=VALUE, repeatable, into a dict of numbers."""

    def __call__(self, parser, namespace, value, option_string=None):
        try:
            new = _options([value])
        except OptinavError as exc:
            parser.error(str(exc))
        setattr(namespace, self.dest, {**(getattr(namespace, self.dest, None) or {}), **new})


def add_batch_options(p) -> None:
    """``optinav batch attitude``: the options of ``optinav attitude`` a folder shares (registry hook;
    destinations are the fields of :class:`optinav.attitude.unit.AttitudeOptions`)."""
    add_input_options(p)
    p.add_argument("--method", choices=METHOD_NAMES, help="estimator (default iframe)")
    p.add_argument("--offline", action="store_true", help="iframe: use the whole recording (forward-backward)")
    p.add_argument("--input-stage", action="store_true",
                   help="gd/cg/qn/mekf: gyro bias and accelerometer filtering of iframe before the method")
    p.add_argument("--mag", action="store_true", help="iframe: heading from the magnetometer")
    p.add_argument("--mag-columns", metavar="MX,MY,MZ", help="names of the magnetometer columns (implies --mag)")
    p.add_argument("--allow-gaps", action="store_true", help="restart the estimate after a time gap")
    p.add_argument("--frame", choices=["NED", "ENU"], default="NED", help="navigation frame (default NED)")
    p.add_argument("--option", dest="options", action=_OptionsAction, default={}, metavar="KEY=VALUE",
                   help="estimator option in SI units, e.g. gain=0.1 (repeatable)")


def _options(items) -> dict:
    out = {}
    for item in items:
        k, _, v = item.partition("=")
        if not v:
            raise OptinavError(f"--option {item!r} is not KEY=VALUE", "write e.g. --option gain=0.1")
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise OptinavError(f"--option {item!r}: {v!r} is not a number", "give options as numbers") from None
    return out


def _sun(args, t, frame):
    import numpy as np

    fixed = args.sun_azimuth is not None or args.sun_elevation is not None
    place = any(v is not None for v in (args.lat, args.lon, args.start_time))
    if fixed and place:
        raise OptinavError("both a fixed sun (--sun-azimuth/--sun-elevation) and a place/time were given",
                           "give one of them")
    from optinav.sky import solar_position_deg, sun_vector

    if fixed:
        if args.sun_azimuth is None or args.sun_elevation is None:
            raise OptinavError("--sun-azimuth and --sun-elevation go together", "give both")
        return sun_vector(np.radians(args.sun_azimuth), np.radians(args.sun_elevation), frame)
    if args.lat is None or args.lon is None or args.start_time is None:
        raise OptinavError("polarization needs the sun: --lat, --lon and --start-time (or a fixed sun)",
                           "add --lat DEG --lon DEG --start-time 2021-01-16T16:33:00+08:00")
    from optinav.sky.sun import utc_seconds

    t0 = float(utc_seconds(args.start_time))
    times = np.round((t0 + (t - t[0])) * 1e9).astype("datetime64[ns]")
    sp = solar_position_deg(times, args.lat, args.lon, args.height, pressure_mbar=1013.25)
    return sp.sun_vector(frame)


#: the attitude CSV's columns t, q, Euler: t exactly (bag stamps are s since the epoch; %.9g rounded them to 100 s)
_CSV_FORMAT = ["%.17g"] + ["%.9g"] * 7


def _read_log(args):
    """(t, gyr, acc, mag or None, reference or None): :func:`optinav.attitude.unit.read_log`."""
    from optinav.attitude.unit import AttitudeOptions, read_log

    o = AttitudeOptions(mag=args.mag, mag_columns=args.mag_columns, columns=args.columns, acc_unit=args.acc_unit,
                        gyro_unit=args.gyro_unit, time_unit=args.time_unit, rate=args.rate,
                        delimiter=args.delimiter, datasets=args.datasets, topic=args.topic)
    return read_log(args.data, o, reference=args.reference)


def run(args) -> int:
    import numpy as np

    from optinav.core.progress import step

    from optinav.attitude import PolarizationMeasurement, estimate
    from optinav.attitude.checks import check_aop
    from optinav.core.rotations import euler_from_quat, frame_name, quat_from_euler

    from optinav.attitude.estimators import _method
    from optinav.attitude.estimators import _options as check_options

    options = _options(args.option)
    method = _method(args.method, True if args.pol_columns else None)
    check_options(method, options)  # fail before reading the data
    out = output_path(args.out, (".csv",), "ATTITUDE.csv")
    if out.exists() and out.resolve() == Path(args.data).resolve():
        raise OptinavError(f"--out {out} is the input file", "write the attitude to another file")
    prepare_report(args)
    if args.reference and frame_name(args.frame) != "enu":  # before the estimate, not after it
        raise OptinavError("the BROAD reference is body -> ENU", "use --frame ENU with --reference")
    q0 = None
    if args.q0_deg:
        e = parse_floats(args.q0_deg, 3, "--q0-deg", "ROLL,PITCH,YAW")
        q0 = quat_from_euler(np.radians(e), frame_name(args.frame))
    if not args.pol_columns and any(v is not None for v in (args.lat, args.lon, args.start_time, args.sun_azimuth,
                                                             args.sun_elevation)):
        raise OptinavError("sun options were given without --pol-columns", "add --pol-columns AOP[,DOP] or drop them")
    if _streams(args):
        return _run_stream(args, method, options, q0, out)
    step("read")
    t, gyr, acc, mag, ref = _read_log(args)
    step("checks")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise OptinavError(f"the time column of {args.data} is not strictly increasing",
                           "sort the log or fix its time column")
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.01))
    pol = None
    if args.pol_columns:
        from optinav.io.readers import read_table

        names = [s.strip() for s in args.pol_columns.split(",")]
        if len(names) not in (1, 2):
            raise OptinavError(f"--pol-columns {args.pol_columns!r} needs AOP or AOP,DOP", "name one or two columns")
        table = read_table(args.data, columns=",".join(f"{k}={v}" for k, v in zip(("aop", "dop"), names)),
                           delimiter=args.delimiter, topic=args.topic)
        aop = np.asarray(table["aop"], float).reshape(-1)
        if aop.size != t.size:
            raise OptinavError(f"AoP column has {aop.size} rows, the IMU {t.size}", "check --pol-columns")
        if args.aop_unit == "deg":
            aop = np.radians(aop)
        else:
            check_aop(aop)
        dop = np.asarray(table["dop"], float).reshape(-1) if "dop" in table else None
        pol = PolarizationMeasurement(aop, _sun(args, t, args.frame), dop=dop, frame=args.frame,
                                      min_dop=args.min_dop)
    if not getattr(args, "quiet", False):
        print(f"optinav: attitude of {t.size} samples from {args.data} ({method}) ...", file=sys.stderr)
    step(f"estimate ({method})")
    res = estimate(gyr, acc, dt, pol=pol, method=method, frame=args.frame, q0=q0, mag=mag,
                   offline=args.offline, input_stage=args.input_stage, allow_gaps=args.allow_gaps,
                   **options)
    eul = np.degrees(euler_from_quat(res.q, frame_name(args.frame)))
    table = np.column_stack([t, res.q, eul])
    header = "t,qw,qx,qy,qz,roll_deg,pitch_deg,yaw_deg"
    step("write")
    write_csv(out, table, header, _CSV_FORMAT)
    print(res.summary())
    score = None
    if args.reference:
        score = _score(res.q, *ref)
        print(f"reference: inclination RMSE {score[0]:.3f} deg, heading RMSE {score[1]:.3f} deg "
              f"({score[2]} movement samples with a valid reference)")
    print(f"optinav: attitude written to {out}")
    finish_report(args, lambda d: _report(res, t, eul, args.data, d, score))
    return 0


def _streams(args) -> bool:
    """Whether the log is estimated block by block: online estimation of an IMU log without what needs the
    whole recording at once (--offline, polarization, magnetometer, BROAD reference, --report plots)."""
    from optinav.attitude.data import is_broad

    whole = (args.offline or args.pol_columns or args.mag or args.mag_columns or args.reference or args.report)
    return not whole and not (is_broad(args.data) and not args.columns and not args.datasets)


_HEADER = "t,qw,qx,qy,qz,roll_deg,pitch_deg,yaw_deg"


def _run_stream(args, method, options, q0, out) -> int:
    """The attitude of a log read twice block by block: pass 1 gathers what the physics checks judge (three
    floats per sample for exact medians), pass 2 estimates with the filter's state carried from block to block
    and writes each block's rows; the output is renamed into place only after every check passed, so the file
    is the in-memory path's, byte for byte."""
    import numpy as np

    from optinav.attitude.stream import StreamChecks, StreamEstimator
    from optinav.core.progress import progress_blocks, step
    from optinav.core.rotations import euler_from_quat, frame_name
    from optinav.io.imu import iter_imu

    estimator = StreamEstimator(method, frame=args.frame, q0=q0, input_stage=args.input_stage, **options)

    def blocks(desc):
        # two rows at least: the first block's first step comes from its first two times
        chunks = iter_imu(args.data, columns=args.columns, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                          time_unit=args.time_unit, rate_hz=args.rate, datasets=args.datasets or None,
                          delimiter=args.delimiter, chunk_rows=max(args.chunk_rows, 2), topic=args.topic)
        prev = None
        for log in progress_blocks(chunks, desc):
            if log.acc is None or log.gyr is None:
                raise OptinavError(f"{args.data} needs accelerometer and gyroscope columns",
                                   "name them with --columns t,ax,ay,az,gx,gy,gz")
            if log.acc_unit == "counts" or log.gyro_unit == "counts":
                raise OptinavError("the log is in raw counts",
                                   "calibrate first (optinav apply) or give --acc-unit/--gyro-unit")
            t = log.t
            first = t[0] - (t[1] - t[0] if t.size > 1 else 0.01) if prev is None else prev
            prev = t[-1]
            yield chunks.rows - len(log), log, np.diff(t, prepend=first)

    step("checks")
    checks, bad = StreamChecks(), 0
    for _, log, dts in blocks("attitude: checks"):
        bad += int(np.count_nonzero(~log.finite))
        if not bad:
            checks.add(log.gyr, log.acc, dts)
    if bad:
        raise OptinavError(f"{args.data} has {bad} rows with NaN accelerometer/gyro values",
                           "remove or interpolate them first")
    checks.finish_first()
    gaps = checks.gaps
    if not getattr(args, "quiet", False):
        print(f"optinav: attitude of {checks.n} samples from {args.data} ({method}) ...", file=sys.stderr)
    step(f"estimate ({method}), write")  # one pass does both
    with atomic_open(out, "w", newline="\n") as fh:
        fh.write(_HEADER + "\n")
        for row0, log, dts in blocks(f"attitude: {method}"):
            checks.collect(row0, log.gyr, log.acc, dts)
            if gaps.size and not args.allow_gaps:
                continue  # refused below, after the checks that come first
            # a time gap starts a new segment whose first step is the median one
            cuts = gaps[(gaps >= row0) & (gaps < row0 + len(log))] - row0
            dts = dts.copy()
            dts[cuts] = checks.median_dt
            qs = []
            for k, (a, b) in enumerate(zip(np.r_[0, cuts], np.r_[cuts, len(log)])):
                if k:
                    estimator.restart()
                if b > a:
                    qs.append(estimator.run(log.gyr[a:b], log.acc[a:b], dts[a:b]))
            q = np.concatenate(qs)
            eul = np.degrees(euler_from_quat(q, frame_name(args.frame)))
            np.savetxt(fh, np.column_stack([log.t, q, eul]), delimiter=",", fmt=_CSV_FORMAT)
        checks.finish_second(args.frame)
        if gaps.size and not args.allow_gaps:
            i = int(gaps[0])
            raise OptinavError(f"time gap of {checks.gap_steps[0]:.3g} s before sample {i} ({gaps.size} gap(s)): "
                               "integrating the gyro across it would be wrong",
                               "pass --allow-gaps (allow_gaps=True) to restart the estimate after each gap")
    print(estimator.summary())
    print(f"optinav: attitude written to {out}")
    return 0


def _score(q, q_ref, movement):
    """BROAD inclination and heading RMSE (deg) over movement samples with a finite reference."""
    import numpy as np

    from optinav.attitude.metrics import heading_error, inclination_error, rmse

    mask = movement & np.all(np.isfinite(q_ref), axis=1)
    return (float(np.degrees(rmse(inclination_error(q, q_ref), mask))),
            float(np.degrees(rmse(heading_error(q, q_ref), mask))), int(mask.sum()))


def _report(res, t, eul, source, out_dir, score=None):
    import numpy as np

    from optinav.reports.report import Figure, StudyResult, Table, write_report

    rows = [["method", res.method], ["frame", res.frame], ["samples", int(t.size)],
            ["polarization used", res.pol_used]]
    rows += [[f"polarization skipped: {k}", v] for k, v in res.pol_skipped.items()]
    rows += [["accelerometer threshold hits", res.acc_threshold_hits]]
    if score is not None:
        rows += [["inclination RMSE vs reference [deg]", f"{score[0]:.3f}"],
                 ["heading RMSE vs reference [deg]", f"{score[1]:.3f}"]]
    if res.gyro_bias is not None:
        rows.append(["final gyro bias [deg/s]", " ".join(f"{v:.4f}" for v in np.degrees(res.gyro_bias))])

    def draw(fig):
        axs = fig.subplots(3, 1, sharex=True)
        for k, name in enumerate(("roll", "pitch", "yaw")):
            axs[k].plot(t, eul[:, k], lw=0.8)
            axs[k].set_ylabel(f"{name} [deg]")
            axs[k].grid(alpha=0.3)
        axs[-1].set_xlabel("t [s]")

    study = StudyResult(name="attitude", title=f"Attitude of {Path(source).name} ({res.method})",
                        description=res.summary(),
                        tables=[Table("Estimation summary", ["item", "value"], rows)],
                        figures=[Figure("attitude_euler.png", f"Roll, pitch, yaw ({res.frame})", draw, (8, 6))])
    return write_report([study], out_dir, title="optinav attitude")


def register_simulate(kinds) -> None:
    """``optinav simulate flight``: a UAV flight with a skylight-polarization sensor (Jin et al. 2021 setup)."""
    p = kinds.add_parser(
        "flight", help="a UAV flight (MPU-6000 IMU + zenith polarization sensor) at the paper's place and time",
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
              (a zenith polarization angle fixes the heading only up to 180°: --q0-deg gives the
              initial attitude the simulator printed)
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, metavar="DATA.csv", help="output CSV")
    p.add_argument("--kind", choices=["static", "dynamic"], default="dynamic", help="flight (default dynamic)")
    p.add_argument("--duration", type=float, default=60.0, metavar="S", help="duration in s (default 60)")
    p.add_argument("--rate", type=float, default=100.0, metavar="HZ", help="sample rate (default 100)")
    p.add_argument("--gyro-bias", metavar="BX,BY,BZ", help="constant residual gyro bias, deg/s (default none)")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=run_simulate_flight, progress_task="simulate flight")


def run_simulate_flight(args) -> int:
    import numpy as np

    from optinav.core.progress import step

    from optinav.attitude.simulate import simulate

    out = output_path(args.out, (".csv",), "flight.csv")
    # measured: about 2500 B per sample at the peak, 4000 with margin
    check_memory(args.duration * args.rate, 4000, "this flight", "shorten --duration or lower --rate")
    truth = check_sidecar(out.with_name(out.stem + ".truth.csv"), "t,qw,qx,qy,qz\n")
    truth_path(out)
    bias = np.radians(parse_floats(args.gyro_bias, 3, "--gyro-bias", "BX,BY,BZ")) if args.gyro_bias else None
    step("simulate")
    d = simulate(args.kind, duration_s=args.duration, rate_hz=args.rate, gyro_bias=bias, rng=args.seed)
    cols = np.column_stack([d.t, d.acc, d.gyr, np.degrees(d.aop), d.dop])
    head = "# units: t=s acc=m/s^2 gyro=rad/s\nt,ax,ay,az,gx,gy,gz,aop_deg,dop"
    step("write")
    write_csv(out, cols, head, "%.10g")
    write_csv(truth, np.column_stack([d.t, d.q_b_n]), "t,qw,qx,qy,qz", "%.12g")
    from optinav.attitude.estimators import attitude_truth

    write_truth(out, attitude_truth(d.q_b_n, d.frame, {"kind": args.kind, "seed": args.seed, "rate_hz": args.rate,
                                                         "start_time": str(d.start_time)}))
    e0 = np.degrees(d.euler[0])
    print(f"optinav: wrote {len(d.t)} samples ({args.kind}, start {d.start_time}) to {out} and the true "
          f"attitude to {truth}; initial roll, pitch, yaw [deg]: {e0[0]:.1f}, {e0[1]:.1f}, {e0[2]:.1f}",
          file=sys.stderr)
    return 0
