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
    """The attitude CSV's rows.

    Parameters
    ----------
    t : (N,) array
        Sample times [s].
    q_b_n : (N, 4) array
        Attitude quaternions [w, x, y, z] [-].
    frame : str
        Navigation frame of the Euler angles (``"ned"``/``"enu"``, either case).

    Returns
    -------
    (N, 8) ndarray
        t [s], q_b_n [-], roll, pitch, yaw [deg] (degrees: file I/O).
    """
    from optinav.core.rotations import euler_from_quat, frame_name

    return np.column_stack([t, q_b_n, np.degrees(euler_from_quat(q_b_n, frame_name(frame)))])


def write_flight(path, flight, truth_csv) -> None:
    """Write a simulated flight as the CSV ``optinav attitude`` reads and its true attitude beside it, atomically.

    Parameters
    ----------
    path : str or Path
        The flight's CSV (:data:`FLIGHT_HEADER`: IMU in SI, angle of polarization in degrees).
    flight : FlightData
        What :func:`optinav.attitude.simulate` returns.
    truth_csv : str or Path
        The true attitude's CSV (:data:`TRUTH_CSV_HEADER`: t [s], q_b_n).
    """
    from optinav.core.files import write_csv

    write_csv(path, np.column_stack([flight.t, flight.acc, flight.gyr, np.degrees(flight.aop), flight.dop]),
              FLIGHT_HEADER, "%.10g")
    write_csv(truth_csv, np.column_stack([flight.t, flight.q_b_n]), TRUTH_CSV_HEADER, "%.12g")


def sun_along_log(t, frame: str, *, lat: float | None = None, lon: float | None = None, height_m: float = 0.0,
                  start_time=None, azimuth: float | None = None, elevation: float | None = None) -> np.ndarray:
    """Unit vector(s) to the sun along a log: a fixed sun, or the NREL SPA position at every sample.

    Parameters
    ----------
    t : (N,) array
        Sample times [s]; the first one is ``start_time``.
    frame : str
        Navigation frame of the vectors (``"ned"``/``"enu"``, either case).
    lat, lon : float or None
        Geodetic latitude and longitude (east positive) of the place [rad].
    height_m : float
        Height above the ellipsoid [m] (parallax only).
    start_time : str, datetime64 or None
        Time of the first sample: ISO 8601 with UTC offset, or what :func:`optinav.sky.utc_seconds` takes.
    azimuth, elevation : float or None
        A fixed sun instead of the place and time: azimuth from north towards east, elevation [rad].

    Returns
    -------
    (N, 3) or (3,) ndarray
        Unit vector(s) to the sun [-] (one for a fixed sun); the SPA elevation is refracted at 1013.25 mbar, 12 °C.
    """
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
    """The polarization columns of a log.

    Parameters
    ----------
    path : str or Path
        The log (any table :func:`optinav.io.readers.read_table` reads).
    columns : str
        ``"AOP"`` or ``"AOP,DOP"``: the names of the angle (and degree) of polarization columns.
    n : int
        Rows expected (the IMU's samples).
    aop_unit : str
        Unit of the angle column in the file, ``"rad"`` or ``"deg"``.
    delimiter, topic : str or None
        As for :func:`optinav.io.read_imu`.

    Returns
    -------
    aop : (n,) ndarray
        Angle of polarization [rad]; NaN marks a sample without polarization.
    dop : (n,) ndarray or None
        Degree of polarization [-], None without a DOP column.
    """
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
    """BROAD's scoring of an estimate against a reference orientation (:mod:`optinav.attitude.metrics`).

    Parameters
    ----------
    q_b_n, q_ref : (N, 4) array
        Estimated and reference quaternions [w, x, y, z] [-].
    movement : (N,) bool array
        The samples to score (those with a non-finite reference are left out too).

    Returns
    -------
    inclination_rmse : float
        [rad]
    heading_rmse : float
        [rad]
    n : int
        Samples scored.
    """
    from optinav.attitude.metrics import heading_error, inclination_error, rmse

    mask = movement & np.all(np.isfinite(q_ref), axis=1)
    return (float(rmse(inclination_error(q_b_n, q_ref), mask)), float(rmse(heading_error(q_b_n, q_ref), mask)),
            int(mask.sum()))


def estimate_stream(path, out, options, *, q0=None, chunk_rows: int = CHUNK_ROWS, announce=None) -> str:
    """Estimate the attitude of a log block by block and write the attitude CSV, memory not growing with the log.

    Parameters
    ----------
    path : str or Path
        The IMU log (what :func:`optinav.io.iter_imu` reads, SI units).
    out : str or Path
        The attitude CSV (:data:`CSV_HEADER`), written atomically.
    options : AttitudeOptions
        :class:`optinav.attitude.unit.AttitudeOptions` (an online method; no magnetometer).
    q0 : (4,) array or None
        Initial attitude [-]; None: levelled from the first samples.
    chunk_rows : int
        Rows read at a time.
    announce : callable or None
        ``announce(n)`` is called with the number of samples once the first pass has checked them.

    Returns
    -------
    str
        The estimator's summary line.

    Notes
    -----
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
