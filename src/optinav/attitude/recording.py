"""One attitude recording from file to file, as ``optinav attitude`` does it and a Python user can: the sun along
the log, the polarization columns, the attitude CSV (t, q_b_n, Euler angles) and the score against a reference
orientation (a file estimated block by block: :mod:`optinav.attitude.filestream`).

The attitude CSV has the columns :data:`CSV_HEADER`: t [s] exactly (``%.17g``: bag stamps are seconds since the
epoch), q_b_n [w, x, y, z] and roll, pitch, yaw in degrees (file I/O) of the frame's Euler convention.
"""

from __future__ import annotations

import contextlib

import numpy as np

from optinav.core.rotations import DEFAULT_FRAME
from optinav.errors import OptinavError

__all__ = [
    "CSV_HEADER",
    "CSV_FORMAT",
    "TRUTH_CSV_HEADER",
    "attitude_rows",
    "flight_writer",
    "sun_along_log",
    "read_polarization",
    "pol_column_names",
    "reference_rmse",
    "score_line",
]

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


@contextlib.contextmanager
def flight_writer(path, truth_csv, truth_json=None, *, frame: str, info: dict | None = None):
    """Write a simulated flight block by block, atomically: the CSV ``optinav attitude`` reads, its true attitude
    beside it and, when named, the truth file ``batch --reference`` compares with (each file appears only when the
    ``with`` block ends without an error).

    Parameters
    ----------
    path : str or Path
        The flight's CSV (:data:`FLIGHT_HEADER`: IMU in SI, angle of polarization in degrees).
    truth_csv : str or Path
        The true attitude's CSV (:data:`TRUTH_CSV_HEADER`: t [s], q_b_n).
    truth_json : str, Path or None
        ``STEM.truth.json`` (:func:`optinav.attitude.estimators.attitude_truth`'s layout), or None.
    frame : str
        The flight's navigation frame.
    info : dict or None
        What the truth file records besides the series (seed, rate …).

    Yields
    ------
    callable
        ``write(block)``: a block of :meth:`optinav.attitude.simulate.FlightStream.blocks` (or the same arrays of a
        whole :class:`FlightData`).
    """
    from optinav.attitude.estimators import TRUTH_UNITS, attitude_truth_series
    from optinav.core.files import csv_writer
    from optinav.core.results import TruthSeriesWriter
    from optinav.core.rotations import frame_name

    with contextlib.ExitStack() as stack:
        data = stack.enter_context(csv_writer(path, FLIGHT_HEADER, "%.10g"))
        truth = stack.enter_context(csv_writer(truth_csv, TRUTH_CSV_HEADER, "%.12g"))
        series = None
        if truth_json is not None:
            head = {"frame": frame_name(frame), **(info or {})}
            series = stack.enter_context(TruthSeriesWriter(truth_json, "attitude", TRUTH_UNITS, head))

        def write(b) -> None:
            data(np.column_stack([b["t"], b["acc"], b["gyr"], np.degrees(b["aop"]), b["dop"]]))
            truth(np.column_stack([b["t"], b["q_b_n"]]))
            if series is not None:
                series.write(**attitude_truth_series(b["q_b_n"], frame))

        yield write


def sun_along_log(
    t,
    frame: str,
    *,
    lat: float | None = None,
    lon: float | None = None,
    height_m: float = 0.0,
    start_time=None,
    azimuth: float | None = None,
    elevation: float | None = None,
    t_first: float | None = None,
) -> np.ndarray:
    """Unit vector(s) to the sun along a log: a fixed sun, or the NREL SPA position at every sample.

    Parameters
    ----------
    t : (N,) array
        Sample times [s] (of the whole log, or of one block of it with ``t_first``).
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
    t_first : float or None
        Time of the log's first sample [s], which is ``start_time``; None: ``t[0]``.

    Returns
    -------
    (N, 3) or (3,) ndarray
        Unit vector(s) to the sun [-] (one for a fixed sun); the SPA elevation is refracted at 1013.25 mbar, 12 °C.
    """
    from optinav.sky import solar_position, sun_vector, utc_seconds

    fixed = azimuth is not None or elevation is not None
    if fixed and any(v is not None for v in (lat, lon, start_time)):
        raise OptinavError(
            "both a fixed sun (--sun-azimuth/--sun-elevation) and a place/time were given", "give one of them"
        )
    if fixed:
        if azimuth is None or elevation is None:
            raise OptinavError("--sun-azimuth and --sun-elevation go together", "give both")
        return sun_vector(azimuth, elevation, frame)
    if lat is None or lon is None or start_time is None:
        raise OptinavError(
            "polarization needs the sun: --lat, --lon and --start-time (or a fixed sun)",
            "add --lat DEG --lon DEG --start-time 2021-01-16T16:33:00+08:00",
        )
    t = np.asarray(t, float)
    t0 = float(utc_seconds(start_time))
    times = np.round((t0 + (t - (t[0] if t_first is None else t_first))) * 1e9).astype("datetime64[ns]")
    return solar_position(times, lat, lon, height_m, pressure=101325.0).sun_vector(frame)


def pol_column_names(columns: str) -> tuple[str, str | None]:
    """The angle and degree of polarization column names of ``--pol-columns`` (``"AOP"`` or ``"AOP,DOP"``).

    Parameters
    ----------
    columns : str
        One or two comma-separated column names.

    Returns
    -------
    aop : str
        Name of the angle of polarization column.
    dop : str or None
        Name of the degree of polarization column, None when not given.
    """
    names = [s.strip() for s in columns.split(",")]
    if len(names) not in (1, 2) or not all(names):
        raise OptinavError(f"--pol-columns {columns!r} needs AOP or AOP,DOP", "name one or two columns")
    return names[0], (names[1] if len(names) == 2 else None)


def read_polarization(
    path, columns: str, n: int, *, aop_unit: str = "rad", delimiter: str | None = None, topic: str | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
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

    names = [v for v in pol_column_names(columns) if v is not None]
    table = read_table(
        path, columns=",".join(f"{k}={v}" for k, v in zip(("aop", "dop"), names)), delimiter=delimiter, topic=topic
    )
    aop = np.asarray(table["aop"], float).reshape(-1)
    if aop.size != n:
        raise OptinavError(f"AoP column has {aop.size} rows, the IMU {n}", "check --pol-columns")
    check_aop(aop, aop_unit)
    if aop_unit == "deg":
        aop = np.radians(aop)
    return aop, (np.asarray(table["dop"], float).reshape(-1) if "dop" in table else None)


def nothing_to_score(n: int, moving: int, valid: int) -> OptinavError:
    """The error of a reference without a sample to score: of ``n`` rows, ``moving`` marked movement and ``valid``
    with a finite reference orientation (a log cut to its rest, or the optical system's lost tracking)."""
    return OptinavError(
        f"the reference has no sample to score: of {n} samples {moving} are marked movement and {valid} have a "
        "finite reference orientation (BROAD scores the movement samples with a valid opt_quat only)",
        "score a recording that holds its motion phase, or drop --reference for the attitude alone",
    )


def reference_rmse(
    q_b_n, q_ref, movement, gyr=None, dts=None, acc=None, frame: str = DEFAULT_FRAME
) -> tuple[float, float, int]:
    """BROAD's scoring of an estimate against a reference orientation (:mod:`optinav.attitude.metrics`).

    Parameters
    ----------
    q_b_n, q_ref : (N, 4) array
        Estimated and reference quaternions [w, x, y, z] [-].
    movement : (N,) bool array
        The samples to score (those with a non-finite reference are left out too).
    gyr, dts : (N, 3) and (N,) arrays or None
        The log's angular rate [rad/s] and the step before each sample [s]: a reference that turns unlike the
        gyroscope is refused (:class:`optinav.attitude.checks.ReferenceTurns`).
    acc : (N, 3) array or None
        Specific force [m/s^2]: a reference whose vertical is not the accelerometer's at rest is refused.
    frame : str
        Navigation frame of ``q_b_n`` and ``q_ref`` (``"ned"``/``"enu"``).

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

    from optinav.attitude.checks import XYZW, ReferenceTurns, warn_reference_order

    valid = np.all(np.isfinite(q_ref), axis=1)
    mask = movement & valid
    if not np.any(mask & np.all(np.isfinite(q_b_n), axis=1)):
        raise nothing_to_score(len(valid), int(np.count_nonzero(movement)), int(np.count_nonzero(valid)))
    if gyr is not None:
        turns = ReferenceTurns(frame)
        turns.add(q_ref, gyr, dts, acc)
        turns.check()
    incl = float(rmse(inclination_error(q_b_n, q_ref), mask))
    warn_reference_order(incl, float(rmse(inclination_error(q_b_n, np.asarray(q_ref)[:, XYZW]), mask)))
    return incl, float(rmse(heading_error(q_b_n, q_ref), mask)), int(mask.sum())


def score_line(score, heading_observed: bool = True) -> str:
    """The line ``optinav attitude --reference`` prints for ``score`` (inclination RMSE rad, heading RMSE rad,
    samples), in degrees; without a heading measurement (``heading_observed`` False) it says what the heading
    RMSE is (6D: 0.7° on BROAD 02 read as a heading score, 165° with --frame NED on the same estimate)."""
    import math

    line = (
        f"reference: inclination RMSE {math.degrees(score[0]):.3f} deg, heading RMSE "
        f"{math.degrees(score[1]):.3f} deg ({score[2]} movement samples with a valid reference)"
    )
    if not heading_observed:
        line += "; no heading measurement: the heading RMSE is the start's yaw offset and the gyro's drift"
    return line
