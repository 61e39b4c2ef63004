"""One attitude recording from file to file, as ``optinav attitude`` does it and a Python user can: the sun along
the log, the polarization columns, the attitude CSV (t, q_b_n, Euler angles), a file estimated block by block,
and the score against a reference orientation.

The attitude CSV has the columns :data:`CSV_HEADER`: t [s] exactly (``%.17g``: bag stamps are seconds since the
epoch), q_b_n [w, x, y, z] and roll, pitch, yaw in degrees (file I/O) of the frame's Euler convention.
"""

from __future__ import annotations

import numpy as np

from optinav.core.files import CHUNK_ROWS
from optinav.errors import OptinavError

__all__ = ["CSV_HEADER", "CSV_FORMAT", "TRUTH_CSV_HEADER", "attitude_rows", "write_flight", "sun_along_log",
           "read_polarization", "reference_rmse", "estimate_stream"]

#: the attitude CSV's header and its column formats (t exactly; %.9g rounded bag stamps to 100 s)
CSV_HEADER = "t,qw,qx,qy,qz,roll_deg,pitch_deg,yaw_deg"
CSV_FORMAT = ["%.17g"] + ["%.9g"] * 7
#: the true attitude beside a simulated flight (``STEM.truth.csv``): t [s], q_b_n; its header starts the file
TRUTH_CSV_HEADER = "t,qw,qx,qy,qz"
#: the simulated flight's CSV: IMU in SI, angle of polarization in degrees (NaN: not measured), degree of pol.
FLIGHT_HEADER = "# units: t=s acc=m/s^2 gyro=rad/s\nt,ax,ay,az,gx,gy,gz,aop_deg,dop"


def attitude_rows(t, q_b_n, frame: str) -> np.ndarray:
    """The attitude CSV's rows (N, 8): t [s], q_b_n, roll, pitch, yaw [deg] (Euler angles of ``frame``)."""
    from optinav.core.rotations import euler_from_quat, frame_name

    return np.column_stack([t, q_b_n, np.degrees(euler_from_quat(q_b_n, frame_name(frame)))])


def write_flight(path, flight, truth_csv) -> None:
    """Write a simulated flight (:func:`optinav.attitude.simulate`) as the CSV ``optinav attitude`` reads
    (:data:`FLIGHT_HEADER`) to ``path`` and its true attitude (:data:`TRUTH_CSV_HEADER`) to ``truth_csv``."""
    from optinav.core.files import write_csv

    write_csv(path, np.column_stack([flight.t, flight.acc, flight.gyr, np.degrees(flight.aop), flight.dop]),
              FLIGHT_HEADER, "%.10g")
    write_csv(truth_csv, np.column_stack([flight.t, flight.q_b_n]), TRUTH_CSV_HEADER, "%.12g")


def sun_along_log(t, frame: str, *, lat: float | None = None, lon: float | None = None, height_m: float = 0.0,
                  start_time=None, azimuth: float | None = None, elevation: float | None = None) -> np.ndarray:
    """Unit vector(s) to the sun in ``frame`` for a log of times ``t`` (s): a fixed sun (``azimuth`` from north
    to east and ``elevation``, rad; one vector) or the NREL SPA position at every sample of a log that started at
    ``start_time`` (ISO 8601 with UTC offset, or what :func:`optinav.sky.utc_seconds` takes) at geodetic ``lat``,
    ``lon`` (rad) and ``height_m``, refracted for standard pressure (N, 3)."""
    from optinav.sky import solar_position, sun_vector, utc_seconds

    fixed = azimuth is not None or elevation is not None
    if fixed and any(v is not None for v in (lat, lon, start_time)):
        raise OptinavError("both a fixed sun (--sun-azimuth/--sun-elevation) and a place/time were given",
                           "give one of them")
    if fixed:
        if azimuth is None or elevation is None:
            raise OptinavError("--sun-azimuth and --sun-elevation go together", "give both")
        return sun_vector(azimuth, elevation, frame)
    if lat is None or lon is None or start_time is None:
        raise OptinavError("polarization needs the sun: --lat, --lon and --start-time (or a fixed sun)",
                           "add --lat DEG --lon DEG --start-time 2021-01-16T16:33:00+08:00")
    t = np.asarray(t, float)
    t0 = float(utc_seconds(start_time))
    times = np.round((t0 + (t - t[0])) * 1e9).astype("datetime64[ns]")
    return solar_position(times, lat, lon, height_m, pressure=101325.0).sun_vector(frame)


def read_polarization(path, columns: str, n: int, *, aop_unit: str = "rad", delimiter: str | None = None,
                      topic: str | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """(aop rad, dop or None) of the ``columns`` "AOP[,DOP]" of ``path`` (one row per IMU sample, ``n`` of them);
    ``aop_unit`` "rad" or "deg" (the file's); NaN marks a sample without polarization."""
    from optinav.attitude.checks import check_aop
    from optinav.io.readers import read_table

    names = [s.strip() for s in columns.split(",")]
    if len(names) not in (1, 2):
        raise OptinavError(f"--pol-columns {columns!r} needs AOP or AOP,DOP", "name one or two columns")
    table = read_table(path, columns=",".join(f"{k}={v}" for k, v in zip(("aop", "dop"), names)),
                       delimiter=delimiter, topic=topic)
    aop = np.asarray(table["aop"], float).reshape(-1)
    if aop.size != n:
        raise OptinavError(f"AoP column has {aop.size} rows, the IMU {n}", "check --pol-columns")
    if aop_unit == "deg":
        aop = np.radians(aop)
    else:
        check_aop(aop)
    return aop, (np.asarray(table["dop"], float).reshape(-1) if "dop" in table else None)


def reference_rmse(q_b_n, q_ref, movement) -> tuple[float, float, int]:
    """(inclination RMSE rad, heading RMSE rad, samples used) of ``q_b_n`` against ``q_ref`` over the
    ``movement`` samples with a finite reference (BROAD's scoring, :mod:`optinav.attitude.metrics`)."""
    from optinav.attitude.metrics import heading_error, inclination_error, rmse

    mask = movement & np.all(np.isfinite(q_ref), axis=1)
    return (float(rmse(inclination_error(q_b_n, q_ref), mask)), float(rmse(heading_error(q_b_n, q_ref), mask)),
            int(mask.sum()))


def estimate_stream(path, out, options, *, q0=None, chunk_rows: int = CHUNK_ROWS, announce=None) -> str:
    """Estimate the attitude of the log ``path`` block by block and write the attitude CSV to ``out``; returns
    the estimator's summary line. ``options``: :class:`optinav.attitude.unit.AttitudeOptions` (online methods,
    no magnetometer); ``announce(n)`` is called with the number of samples once the first pass checked them.

    The log is read twice: pass 1 gathers what the physics checks judge (three floats per sample for exact
    medians), pass 2 estimates with the filter's state carried from block to block and writes each block's rows;
    the output is renamed into place only after every check passed, so the file is the in-memory path's
    (:func:`optinav.attitude.estimate` + :func:`attitude_rows`), byte for byte."""
    from optinav.attitude.estimators import _method
    from optinav.attitude.stream import StreamChecks, StreamEstimator
    from optinav.core.files import csv_writer
    from optinav.core.progress import progress_blocks, step
    from optinav.io.imu import iter_imu

    o = options
    method = _method(o.method, None)
    estimator = StreamEstimator(method, frame=o.frame, q0=q0, input_stage=o.input_stage, **dict(o.options))

    def blocks(desc):
        # two rows at least: the first block's first step comes from its first two times
        chunks = iter_imu(path, columns=o.columns, acc_unit=o.acc_unit, gyro_unit=o.gyro_unit,
                          time_unit=o.time_unit, rate_hz=o.rate, datasets=o.datasets or None,
                          delimiter=o.delimiter, chunk_rows=max(chunk_rows, 2), topic=o.topic)
        prev = None
        for log in progress_blocks(chunks, desc):
            if log.acc is None or log.gyr is None:
                raise OptinavError(f"{path} needs accelerometer and gyroscope columns",
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
        raise OptinavError(f"{path} has {bad} rows with NaN accelerometer/gyro values",
                           "remove or interpolate them first")
    checks.finish_first()
    gaps = checks.gaps
    if announce is not None:
        announce(checks.n)
    step(f"estimate ({method}), write")  # one pass does both
    with csv_writer(out, CSV_HEADER, CSV_FORMAT) as write:
        for row0, log, dts in blocks(f"attitude: {method}"):
            checks.collect(row0, log.gyr, log.acc, dts)
            if gaps.size and not o.allow_gaps:
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
            write(attitude_rows(log.t, np.concatenate(qs), o.frame))
        checks.finish_second(o.frame)
        if gaps.size and not o.allow_gaps:
            i = int(gaps[0])
            raise OptinavError(f"time gap of {checks.gap_steps[0]:.3g} s before sample {i} ({gaps.size} gap(s)): "
                               "integrating the gyro across it would be wrong",
                               "pass --allow-gaps (allow_gaps=True) to restart the estimate after each gap")
    return estimator.summary()
