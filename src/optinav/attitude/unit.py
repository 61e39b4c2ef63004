"""One attitude recording, as :mod:`optinav.batch` (and ``optinav attitude``) reads and estimates it
(registry: ``attitude``)."""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from optinav.attitude.methods import _method, _options
from optinav.core.rotations import DEFAULT_FRAME, frame_name
from optinav.errors import OptinavError

if TYPE_CHECKING:
    from optinav.attitude.filestream import StreamedEstimate


#: the error of a log in raw counts without a sensitivity to read them by
RAW_COUNTS = (
    "the log is in raw counts",
    "calibrate first (optinav apply), give --acc-unit/--gyro-unit, or read the counts by their datasheet "
    "sensitivity with --acc-lsb/--gyro-lsb",
)


@dataclasses.dataclass
class AttitudeOptions:
    """The options of ``optinav attitude`` that a folder of recordings shares: ``method`` (None: iframe),
    ``frame`` ("ned"/"enu", either case), ``offline``, ``input_stage``, ``mag`` (use the magnetometer: BROAD's
    imu_mag or ``mag_columns``, default mx,my,mz), ``mag_hard_iron`` (the magnetometer's offset to subtract,
    its unit; None: an uncalibrated one is refused online, fitted and subtracted offline), ``allow_gaps``,
    ``drop_nan`` (rows with a NaN accelerometer or gyro value are lost samples, left out; the time steps over them;
    implied by ``skip_bad_lines``, whose unreadable lines are such rows), ``options`` (estimator options, SI), and
    the
    reading options of :func:`optinav.io.read_imu` (``columns``, units, ``time_unit``, ``rate_hz`` Hz, ``delimiter``,
    ``datasets``, ``gyro_path`` and ``gyro_columns``: the gyroscope in a second file, ``skip_bad_lines``,
    ``acc_lsb``/``gyro_lsb``: counts per g / per deg/s of a log in raw counts);
    ``mag_path``: the magnetometer in a file of its own, on its own time stamps (:func:`separate_mag`; its columns
    ``mag_columns``)."""

    method: str | None = None
    frame: str = DEFAULT_FRAME
    offline: bool = False
    input_stage: bool = True
    mag: bool = False
    mag_columns: str | None = None
    mag_hard_iron: tuple | None = None
    allow_gaps: bool = False
    drop_nan: bool = False
    options: dict = dataclasses.field(default_factory=dict)
    columns: str | None = None
    acc_unit: str | None = None
    gyro_unit: str | None = None
    time_unit: str | None = None
    rate_hz: float | None = None
    delimiter: str | None = None
    datasets: str | None = None
    topic: str | None = None
    gyro_path: str | None = None
    gyro_columns: str | None = None
    skip_bad_lines: bool = False
    mag_path: str | None = None
    acc_lsb: float | None = None
    gyro_lsb: float | None = None

    def __post_init__(self):
        # one spelling, so that "NED" from the CLI and "ned" from Python are the same batch job (options hash)
        self.frame = frame_name(self.frame)

    @property
    def uses_mag(self) -> bool:
        """Whether the estimate takes a magnetometer: ``mag``, ``mag_columns`` or ``mag_path``."""
        return self.mag or bool(self.mag_columns) or self.mag_path is not None

    @property
    def drops_nan(self) -> bool:
        """Whether rows with a NaN accelerometer or gyro value are left out as lost samples: ``drop_nan``, or
        ``skip_bad_lines`` (a file without a time column gets a NaN row for each line it leaves out, so that the
        rate times the rows after it; asking for those lines to be left out asks for their rows to be)."""
        return self.drop_nan or self.skip_bad_lines

    def resolved_options(self) -> dict:
        """The method and every option it runs with, defaults filled in (and the input stage's, when it runs):
        part of the batch options hash, so units journaled before a default changed its value or meaning (mekf's
        per-sample acc_noise became acc_noise_density, the same default 0.01 at every rate) are recomputed."""
        from optinav.attitude.methods import IFRAME_DEFAULTS

        m = _method(self.method, None)
        out = {"method": m, "options": _options(m, dict(self.options))}
        if self.input_stage and m != "iframe":
            out["input_stage"] = dict(IFRAME_DEFAULTS)
        for opts in out.values():
            # added since with 0, the estimate as before: unset, it hashes as before it existed (journals current)
            if isinstance(opts, dict) and opts.get("declination", 1.0) == 0.0:
                del opts["declination"]
        return out


def check(options: AttitudeOptions) -> None:
    if _options(_method(options.method, None), dict(options.options)).get("declination") and not options.uses_mag:
        from optinav.attitude.methods import declination_without_mag

        raise declination_without_mag()


def refuse_unused_mag_topic(path, options: AttitudeOptions) -> None:
    """Refuse a magnetometer topic of a ULog or a ROS bag named in ``topic`` without ``mag``: the estimate left it
    out, 6D with exit 0 (``attitude LOG.ulg --topic vehicle_magnetometer@1``, ``attitude BAG --topic /imu,/mag``)."""
    o = options
    if o.uses_mag or not o.topic:
        return
    from optinav.io.rosbag import _parse_topics, is_bag
    from optinav.io.ulog import _parse_topic, is_ulog

    shown = None
    if is_ulog(path):
        named = _parse_topic(Path(path), o.topic).get("mag")
        if named is not None:
            shown = named[0] if named[1] is None else f"{named[0]}@{named[1]}"
    elif is_bag(path):
        items = _parse_topics(o.topic)
        shown = items[1] if len(items) == 2 else None
    if shown is not None:
        raise OptinavError(
            f"--topic names the magnetometer topic {shown} of {Path(path).name}, and --mag was not given: the "
            "estimate would leave it out",
            f"add --mag (9D), or drop {shown} from --topic (6D)",
        )


def read_log(path, options: AttitudeOptions, *, reference: bool = False):
    """(t s, gyr rad/s, acc m/s², mag or None, (q_ref, movement) or None) from a BROAD trial as published
    (its optical reference when ``reference``) or any IMU log in SI units."""
    from optinav.attitude.data import check_broad_shapes, has_reference, is_broad, load_broad

    o = options
    want_mag = o.uses_mag
    refuse_unused_mag_topic(path, o)
    broad = is_broad(path) and not o.columns and not o.datasets
    if reference and not (broad and has_reference(path)):
        raise OptinavError(
            f"{path} is not a BROAD file with opt_quat and movement", "drop --reference or pass a BROAD trial"
        )
    if broad:
        if o.mag_path is not None:
            raise OptinavError(f"{Path(path).name} is a BROAD trial, which holds its magnetometer", "drop --mag-file")
        tr = load_broad(path, o)
        if reference:
            shapes = {"imu_gyr": tr.gyr.shape, "opt_quat": tr.q_ref.shape, "movement": tr.movement.shape}
            check_broad_shapes(Path(path).name, shapes)
        t = np.arange(tr.gyr.shape[0]) / tr.rate_hz
        return t, tr.gyr, tr.acc, tr.mag if want_mag else None, (tr.q_ref, tr.movement)
    from optinav.io import read_imu
    from optinav.io.imu import reader_options
    from optinav.io.readers import read_table

    log = read_imu(path, **reader_options(o))
    if log.acc is None or log.gyr is None:
        raise OptinavError(
            f"{path} needs accelerometer and gyroscope columns", "name them with --columns t,ax,ay,az,gx,gy,gz"
        )
    if log.acc_unit == "counts" or log.gyro_unit == "counts":
        raise OptinavError(*RAW_COUNTS)
    ok = log.finite
    if not np.all(ok) and not o.drops_nan:
        raise OptinavError(*nan_rows_error(path, int(np.count_nonzero(~ok))))
    mag = None
    own = separate_mag(path, o) if want_mag else None
    if own is not None:
        step = float(np.median(np.diff(log.t)))
        own.check_clock(float(log.t[0]), float(log.t[-1]), step)
        mag = own.on_rows(log.t, step)
    elif want_mag:
        from optinav.attitude.filestream import _column
        from optinav.io.imu import mag_names, mag_triad
        from optinav.io.readers import MissingColumn

        names, signs = mag_names(o.mag_columns)
        keys = ["mag"] if len(names) == 1 else ["mx", "my", "mz"]

        def mag_table(names):
            return read_table(
                path,
                columns=",".join(f"{k}={v}" for k, v in zip(keys, names)),
                delimiter=o.delimiter,
                topic=o.topic,
                skip_bad_lines=o.skip_bad_lines,
                rows=log.t.size,
            )

        try:
            tab = mag_table(names)
        except MissingColumn as exc:  # --mag alone: the magnetometer's usual names (as the streamed path finds them)
            found = mag_triad(exc.found) if o.mag_columns is None else None
            if found is None:
                raise
            tab = mag_table([found[k] for k in keys])
        mag = np.column_stack([_column(k, tab[k]) for k in keys]) * signs
        if mag.shape[0] != log.t.size:
            raise OptinavError(f"the magnetometer has {mag.shape[0]} rows, the IMU {log.t.size}", "check --mag-columns")
    if not np.all(ok):
        warnings.warn(nan_rows_note(int(np.count_nonzero(~ok)), o), stacklevel=2)
        return log.t[ok], log.gyr[ok], log.acc[ok], None if mag is None else mag[ok], None
    return log.t, log.gyr, log.acc, mag, None


def separate_mag(path, options: AttitudeOptions):
    """The magnetometer of the log ``path`` that is on its own time stamps, as
    :class:`optinav.io.imu.MagSamples` (its samples are put on the IMU's rows by
    :meth:`~optinav.io.imu.MagSamples.on_rows`): ``mag_path`` (columns ``mag_columns``, else found by name), else
    with ``mag``/``mag_columns`` a phone export's magnetometer file (Sensor Logger's Magnetometer.csv, else
    MagnetometerUncalibrated.csv; phyphox's Magnetometer.csv; µT), a PX4 ULog's magnetometer topic (gauss,
    :func:`optinav.io.ulog.ulog_mag`) or the magnetometer rows of Physics Toolbox's multi record (Bx, By, Bz, µT);
    None when the magnetometer is read from the IMU's rows (columns of its file). One known to carry its hard-iron
    offset (MagnetometerUncalibrated.csv, sensor_mag) is refused, without ``mag_hard_iron``, when the recording turns
    it too little for the offset to be fitted (:func:`optinav.attitude.checks.check_offset_seen`)."""
    own = _separate_mag(path, options)
    if own is not None and own.calibrated and options.mag_hard_iron is None:
        from optinav.attitude.checks import check_offset_seen

        check_offset_seen(own.mag, own.source, own.calibrated)
    return own


def _separate_mag(path, options: AttitudeOptions):
    from optinav.io.imu import multi_record, read_mag, reader_options
    from optinav.io.phone import phone_export
    from optinav.io.ulog import is_ulog, ulog_mag

    o = options
    kw = dict(columns=o.mag_columns, time_unit=o.time_unit, delimiter=o.delimiter, skip_bad_lines=o.skip_bad_lines)
    if o.mag_path is not None:
        return read_mag(o.mag_path, **kw)
    if not o.uses_mag:
        return None
    if is_ulog(path):  # a PX4 log's magnetometer topic, on its own time stamps
        if o.mag_columns:
            raise OptinavError(
                f"--mag-columns names columns of a table; {Path(path).name} is a ULog",
                "drop --mag-columns: name the magnetometer topic with --topic (vehicle_magnetometer or sensor_mag)",
            )
        return ulog_mag(path, o.topic, o.skip_bad_lines)
    export = phone_export(path)
    if export is not None:
        if export.mag is None:
            raise OptinavError(
                f"{export.path.name} is {export.what} without a magnetometer file",
                "record with the magnetometer switched on, or drop --mag (the heading then follows the gyro)",
            )
        return read_mag(export.member(export.mag), **kw)
    if o.gyro_path is None and multi_record(path, **reader_options(o)):
        return read_mag(path, multi_record=True, **kw)
    return None


def nan_rows_error(path, n: int) -> tuple[str, str]:
    """(message, remedy) of a log with ``n`` rows holding a NaN accelerometer or gyro value."""
    return (
        f"{path} has {n} rows with NaN accelerometer/gyro values",
        "remove or interpolate them first, or pass --drop-nan to leave them out as lost samples",
    )


def nan_rows_note(n: int, o: AttitudeOptions) -> str:
    """The note of ``n`` rows left out as lost samples, naming the option that asked for it."""
    flag = "--drop-nan" if o.drop_nan else "--skip-bad-lines"
    return f"{n} rows with NaN accelerometer/gyro values left out ({flag}): lost samples, the time steps over them"


def steps(t, path="") -> np.ndarray:
    """The step before each sample (s), the first one repeated: what :func:`estimate` takes as dt."""
    t = np.asarray(t, float)
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise OptinavError(
            f"the time column of {path} is not strictly increasing", "sort the log or fix its time column"
        )
    return np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.01))


def reference_sources(path, options: AttitudeOptions, reference: bool, *, required: bool = False) -> dict:
    """What a log is scored against with ``reference``, as keywords of
    :func:`optinav.attitude.filestream.stream_attitude`: a BROAD trial's optical reference, else a simulator's
    ``STEM.truth.csv`` beside the log (and ``STEM.truth.json``, compared too and naming the truth's frame); none
    without ``reference``. ``required``: no reference to score against is an error (``optinav attitude
    --reference``), not an unscored unit (``batch --reference`` scores "where there is one")."""
    from optinav.attitude.data import is_broad
    from optinav.attitude.filestream import _TruthSeries
    from optinav.core.results import TruthSeriesReader

    p, o = Path(path), options
    broad = is_broad(p) and not o.columns and not o.datasets
    truth_csv = p.with_name(p.stem + ".truth.csv")
    truth_json = p.with_name(p.stem + ".truth.json")
    if reference and required and not broad and not truth_csv.is_file():
        raise OptinavError(
            f"{path} is not a BROAD trial (opt_quat, movement) and has no {truth_csv.name} beside it",
            "drop --reference, or pass a BROAD trial or a log written by optinav simulate flight",
        )
    return dict(
        reference=reference and broad,
        truth_csv=truth_csv if reference and not broad and truth_csv.is_file() else None,
        truth=TruthSeriesReader(truth_json, _TruthSeries.SERIES) if reference and truth_json.is_file() else None,
    )


def run_unit(path, options: AttitudeOptions, reference: bool = False) -> tuple[StreamedEstimate, dict]:
    """Estimate the attitude of ``path`` block by block (:func:`optinav.attitude.filestream.stream_attitude`, no
    output file), so a unit's memory does not grow with its log; extra columns: samples, duration (s), and with
    ``reference`` the inclination and heading RMSE (deg) against the recording's reference (BROAD) or its
    simulated truth (``STEM.truth.csv``), over the samples where it is valid. With ``reference`` a simulated
    ``STEM.truth.json`` beside it is compared too (:attr:`StreamedEstimate.truth_comparison`; its per-sample
    series read block by block beside the log)."""
    from optinav.attitude.filestream import stream_attitude
    from optinav.core import files

    p, o = Path(path), options
    run = stream_attitude(p, None, o, **reference_sources(p, o, reference), chunk_rows=files.CHUNK_ROWS, progress=False)
    # how the unit was estimated, beside "method": tables of several runs (online/offline, 6D/9D, input stage,
    # NED/ENU) merged for a comparison told their rows apart only by the options hash
    extra = {
        "n_samples": int(run.n),
        "duration_s": float(run.duration_s),
        "frame": o.frame,
        "offline": bool(o.offline),
        "input_stage": bool(o.input_stage or _method(o.method, None) == "iframe"),
        "mag": o.uses_mag,
    }
    # the offset subtracted from an uncalibrated magnetometer, and from which row the field was used less the one
    # fitted online (before it the field as measured, or the heading the gyro's): the summary line says so, the table did not
    e = run.estimate
    if e.mag_hard_iron is not None:
        extra.update(zip(("mag_hard_iron_x", "mag_hard_iron_y", "mag_hard_iron_z"), map(float, e.mag_hard_iron)))
        if e.mag_hard_iron_from is not None:
            extra["mag_hard_iron_from"] = int(e.mag_hard_iron_from)
    if e.declination:  # the heading true, the field turned by it (its column only where one was given)
        extra["declination_deg"] = float(np.degrees(e.declination))
    if run.score is not None:
        inclination, heading, n = run.score
        extra.update(
            inclination_rmse_deg=float(np.degrees(inclination)),
            heading_rmse_deg=float(np.degrees(heading)),
            n_reference=n,
        )
    if run.notes:  # what attitude prints beside the numbers (rows left out, a gyro file interpolated, …)
        extra["notes"] = " | ".join(run.notes)
    return run.estimate, extra
