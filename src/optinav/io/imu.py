"""IMU logs: accelerometer and gyroscope samples read from data files into an :class:`ImuLog`, and written back.

:func:`read_imu` finds the standard quantities ``t, ax, ay, az, gx, gy, gz`` (also ``acc``/``gyro`` as N×3
arrays, a ``sample`` counter and a ``label`` column) by name or common alias, converts ``g`` and ``deg/s`` to SI
and keeps raw ``counts`` as they are (the calibrator then estimates the scale). Formats, aliases and units:
docs/file-formats.md.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.units import G_STANDARD, factor, from_si
from optinav.core.validate import check_positive, check_timestamps
from optinav.errors import OptinavError
from optinav.io.phone import ExportMember, phone_export, refuse_as_one_sensor
from optinav.io.ulog import UlogTopic, ulog_pair
from optinav.io.readers import (
    CHUNK_ROWS,
    LABEL_COLUMNS,
    RATE_KEYS,
    SKIP_NAMES,
    Table,
    generic_names,
    iter_table,
    load_table,
    merge_datasets,
    normalize_name,
    parse_columns,
)

__all__ = [
    "ImuLog",
    "read_imu",
    "iter_imu",
    "ImuChunks",
    "write_imu",
    "open_imu_writer",
    "ImuWriter",
    "read_mag",
    "MagSamples",
    "ACC_UNITS",
    "GYRO_UNITS",
    "TIME_UNITS",
    "STANDARD_NAMES",
    "ALIASES",
]

#: accepted accelerometer unit spellings → canonical unit
ACC_UNITS = {
    "counts": "counts",
    "count": "counts",
    "raw": "counts",
    "lsb": "counts",
    "a.u.": "counts",
    "g": "g",
    "mg": "mg",
    "milli-g": "mg",
    "m/s^2": "m/s^2",
    "m/s2": "m/s^2",
    "m/s²": "m/s^2",
    "m/s/s": "m/s^2",
    "m s^-2": "m/s^2",
    "m/(s^2)": "m/s^2",  # Shimmer Consensys
    "m/(s²)": "m/s^2",
}
#: accepted gyroscope unit spellings → canonical unit
GYRO_UNITS = {
    "counts": "counts",
    "count": "counts",
    "raw": "counts",
    "lsb": "counts",
    "a.u.": "counts",
    "deg/s": "deg/s",
    "dps": "deg/s",
    "°/s": "deg/s",
    "deg/sec": "deg/s",
    "degrees/s": "deg/s",
    "rad/s": "rad/s",
    "rad/sec": "rad/s",
    "rad s^-1": "rad/s",
    "deg s^-1": "deg/s",
    "mdps": "mdps",
    "mdeg/s": "mdps",
    "millidegrees/s": "mdps",
    "mdeg/sec": "mdps",
}
#: time units → seconds per unit
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: the remedy of a duplicate timestamp in an IMU log: the commands reading it can skip the time column and take
#: the rate instead (``columns``/``rate_hz`` from Python)
COARSE_TIME_REMEDY = (
    "drop duplicated samples; a time column too coarse for the rate (whole ms at hundreds of Hz) can be "
    "skipped with '_' in --columns, the sample rate given with --rate"
)


def _duplicate_remedy(table) -> str:
    """The remedy of a duplicate timestamp in ``table``: a ULog's fields are read by name (no '_' in --columns)."""
    if table.kind == "ulog":
        return "export the topic with ulog2csv LOG.ulg and drop the duplicated rows of its CSV"
    return COARSE_TIME_REMEDY


_TIME_SPELLINGS = {
    "s": "s",
    "sec": "s",
    "secs": "s",
    "seconds": "s",
    "ms": "ms",
    "msec": "ms",
    "us": "us",
    "usec": "us",
    "µs": "us",
    "μs": "us",
    "ns": "ns",
    "nsec": "ns",
}
_CANONICAL = {
    "acc": ("counts", "g", "mg", "m/s^2"),
    "gyro": ("counts", "deg/s", "mdps", "rad/s"),
    "time": ("s", "ms", "us", "ns"),
}

#: the names read_imu understands: time, accelerometer and gyroscope components, N×3 triads, counter, labels
STANDARD_NAMES = ("t", "ax", "ay", "az", "gx", "gy", "gz", "acc", "gyro", "sample", "label")
_COMPONENTS = {"acc": ("ax", "ay", "az"), "gyro": ("gx", "gy", "gz")}


def _build_aliases() -> dict[str, tuple[str, str | None]]:
    """Normalized column name → (standard name, time unit the name implies)."""
    al: dict[str, tuple[str, str | None]] = {n: (n, None) for n in STANDARD_NAMES}
    for n in (
        "time",
        "times",
        "timestamp",
        "timestamps",
        "time_stamp",
        "time_s",
        "t_s",
        "timestamp_s",
        "sec",
        "secs",
        "seconds",
        "elapsed",
        "elapsed_time",
    ):
        al[n] = ("t", None)
    for unit in ("ms", "us", "ns"):
        for n in (f"time_{unit}", f"t_{unit}", f"timestamp_{unit}", unit):
            al[n] = ("t", unit)
    al["millis"], al["micros"] = ("t", "ms"), ("t", "us")  # Arduino's clocks
    al["timeus"] = al["sampleus"] = ("t", "us")  # ArduPilot's DataFlash messages: TimeUS, SampleUS (µs since boot)
    al["header_stamp"] = ("t", "ns")  # rostopic echo -p prints the header stamp in ns
    al["time_since_start_in_ms"] = ("t", "ms")  # AndroSensor (Android)
    for n in (
        "n_samples",
        "n_sample",
        "sample",
        "samples",
        "sample_index",
        "sample_idx",
        "sample_number",
        "sample_nr",
        "samplenumber",
        "packet_counter",
        "packetcounter",
        "counter",
        "index",
        "idx",
    ):
        al[n] = ("sample", None)
    for n in ("part", "label", "labels", "section", "segment", "pose", "phase"):
        al[n] = ("label", None)
    acc_prefix = (
        "a",
        "acc",
        "accel",
        "accl",
        "accelerometer",
        "acceleration",
        "f",
        "sf",
        "specific_force",
        "lin_acc",
        "linear_acceleration",
        "imu_acc",
        "accelerometer_m_s2",  # PX4 sensor_combined (pyulog's CSV)
        "ac",  # the classic MPU-6050 Arduino sketch: AcX = … | GyX = …
        "acce",  # RIDI's CSV, RoNIN's HDF5 (Android's accelerometer, gravity in it)
    )
    gyro_prefix = (
        "g",
        "gyr",
        "gyro",
        "gyros",
        "gyroscope",
        "w",
        "omega",
        "rate",
        "angular_velocity",
        "angular_rate",
        "ang_vel",
        "angvel",
        "imu_gyro",
        "imu_gyr",  # BROAD's datasets
        "gyro_rad",  # PX4 sensor_combined (pyulog's CSV)
        "gy",
        "as",  # WitMotion's register names (AsX: angular speed)
    )
    for std, prefixes in (("a", acc_prefix), ("g", gyro_prefix)):
        for p in prefixes:
            for axis in "xyz":
                al[f"{p}{axis}"] = al[f"{p}_{axis}"] = (f"{std}{axis}", None)
    for axis in "xyz":  # the ASL/EuRoC dataset format (EuRoC, TUM-VI): a_RS_S_x, w_RS_S_x of the sensor S
        al[f"a_rs_s_{axis}"], al[f"w_rs_s_{axis}"] = (f"a{axis}", None), (f"g{axis}", None)
        # Analog Devices' iSensor register names (ADIS164xx/165xx evaluation exports): X_ACCL_OUT, X_GYRO_OUT
        al[f"{axis}_accl_out"], al[f"{axis}_gyro_out"] = (f"a{axis}", None), (f"g{axis}", None)
    for n in (
        "acc",
        "accel",
        "accelerometer",
        "acceleration",
        "f",
        "f_b",
        "specific_force",
        "sf",
        "linear_acceleration",
        "imu_acc",
        "acce",
    ):
        al[n] = ("acc", None)
    for n in (
        "gyro",
        "gyr",
        "gyros",
        "gyroscope",
        "omega",
        "w",
        "omega_ib_b",
        "angular_velocity",
        "angular_rate",
        "imu_gyro",
        "imu_gyr",
    ):
        al[n] = ("gyro", None)
    return al


#: normalized column name (see :func:`optinav.io.readers.normalize_name`) → (standard name, implied time unit)
ALIASES = _build_aliases()


# --- result -------------------------------------------------------------------------------------------------


@dataclass
class ImuLog(Result):
    """IMU samples read from a file.

    ``t`` (N,) in s, strictly increasing (irregular spacing allowed); ``acc`` (N, 3) in m/s² or raw counts and
    ``gyr`` (N, 3) in rad/s or raw counts, as ``acc_unit``/``gyro_unit`` say (None when the file had no such
    triad); ``acc_input_unit``/``gyro_input_unit`` are the units of the file (``g``, ``deg/s``, … before the
    conversion to SI). Rows with NaN/inf in ``acc``/``gyr`` are kept; ``nan_rows`` counts them.
    ``labels`` (N,) str or int section labels, ``sample`` (N,) the file's sample counter (never used as time).
    ``row`` (N,) each sample's data row in the (accelerometer's) file where the reader left rows out (those outside
    a second file's span, or in a pause of both), else None: sample indices counted on the file's rows (imucal's
    section list) are moved onto the samples by it.
    ``gyr_clock`` (not saved with the log): ``(t_g, gyr_g)``, the gyroscope's own sample times (M,) [s] and samples
    (M, 3) [gyro_unit] where it came from a second file on its own clock and ``gyr`` holds it linearly interpolated
    onto ``t``, else None; interpolation low-passes the samples by a share that follows the phase of the two clocks,
    so a turn's glitches are judged and its integral taken on these.
    Version 2 renamed the version-1 field ``gyro`` to ``gyr`` (version-1 files still load).
    """

    SCHEMA: ClassVar[str] = "optinav.imu_log"
    VERSION: ClassVar[int] = 3

    t: np.ndarray = field(metadata={"unit": "s"})
    acc: np.ndarray | None = field(default=None, metadata={"unit": "acc_unit"})
    gyr: np.ndarray | None = field(default=None, metadata={"unit": "gyro_unit"})
    acc_unit: str = field(default="m/s^2", metadata={"unit": "-"})
    gyro_unit: str = field(default="rad/s", metadata={"unit": "-"})
    source: str = field(default="", metadata={"unit": "-"})
    n_rows_read: int = field(default=0, metadata={"unit": ""})
    nan_rows: int = field(default=0, metadata={"unit": ""})
    labels: np.ndarray | None = field(default=None, metadata={"unit": "-"})
    sample: np.ndarray | None = field(default=None, metadata={"unit": ""})
    row: np.ndarray | None = field(default=None, metadata={"unit": ""})
    acc_input_unit: str | None = field(default=None, metadata={"unit": "-"})
    gyro_input_unit: str | None = field(default=None, metadata={"unit": "-"})
    #: what the reader inferred or left out (rate from the file, an incomplete last line), one line each
    notes: list = field(default_factory=list, metadata={"unit": "-"})
    #: the gyroscope on its own clock where ``gyr`` was interpolated from it (class docstring); not a field
    gyr_clock: ClassVar[tuple | None] = None

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        if self.t.ndim != 1:
            raise OptinavError(
                f"ImuLog.t must be one-dimensional, got shape {self.t.shape}", "pass one time per sample"
            )
        n = self.t.size
        for name in ("acc", "gyr"):
            v = getattr(self, name)
            if v is not None:
                v = np.asarray(v, dtype=float)
                if v.shape != (n, 3):
                    raise OptinavError(
                        f"ImuLog.{name} has shape {v.shape}, expected ({n}, 3)", "pass one triad per sample"
                    )
                setattr(self, name, v)
        for name in ("labels", "sample", "row"):
            v = getattr(self, name)
            if v is not None:
                v = np.asarray(v)
                if v.shape != (n,):
                    raise OptinavError(f"ImuLog.{name} has shape {v.shape}, expected ({n},)", "pass one per sample")
                setattr(self, name, v)
        for name, allowed in (("acc_unit", ("counts", "m/s^2")), ("gyro_unit", ("counts", "rad/s"))):
            if getattr(self, name) not in allowed:
                raise OptinavError(f"ImuLog.{name} is {getattr(self, name)!r}", f"use one of {', '.join(allowed)}")

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def finite(self) -> np.ndarray:
        """(N,) True where every used acc/gyro value is finite (the rows the calibrator can use)."""
        ok = np.ones(self.t.size, dtype=bool)
        for v in (self.acc, self.gyr):
            if v is not None:
                # one sum, finite only if every cell is (no temporary arrays); else, or if it overflows, per row
                with np.errstate(over="ignore", invalid="ignore"):
                    total = v.sum()
                if not np.isfinite(total):
                    ok &= np.all(np.isfinite(v), axis=1)
        return ok

    @property
    def rate_hz(self) -> float:
        """Median sample rate (Hz) from the timestamps."""
        return float(1.0 / np.median(np.diff(self.t))) if self.t.size > 1 else float("nan")

    def select(self, rows) -> "ImuLog":
        """The samples picked by ``rows`` (``nan_rows`` recounted).

        Parameters
        ----------
        rows : bool array, int array or slice
            A mask of N booleans, increasing indices or a slice.

        Returns
        -------
        ImuLog
            The selected samples, same units.
        """
        if isinstance(rows, slice):
            idx = np.arange(self.t.size)[rows]
        else:
            rows = np.asarray(rows)
            if rows.dtype == bool:
                if rows.shape != self.t.shape:
                    raise OptinavError(
                        f"mask has shape {rows.shape}, the log has {self.t.size} samples", "pass one boolean per sample"
                    )
                idx = np.flatnonzero(rows)
            elif rows.dtype.kind in "iu":
                idx = rows.reshape(-1)
                if idx.size and (idx.min() < -self.t.size or idx.max() >= self.t.size):
                    raise OptinavError("row index out of range", f"use indices below {self.t.size}")
            else:
                raise OptinavError(f"cannot select rows with a {rows.dtype} array", "pass a boolean mask or indices")
        if idx.size > 1 and np.any(np.diff(np.where(idx < 0, idx + self.t.size, idx)) <= 0):
            raise OptinavError("selected rows are not increasing", "select rows in time order, each once")
        take = lambda v: None if v is None else v[idx]  # noqa: E731
        out = ImuLog(
            t=self.t[idx],
            acc=take(self.acc),
            gyr=take(self.gyr),
            acc_unit=self.acc_unit,
            gyro_unit=self.gyro_unit,
            source=self.source,
            n_rows_read=self.n_rows_read,
            nan_rows=0,
            labels=take(self.labels),
            sample=take(self.sample),
            row=take(self.row),
            acc_input_unit=self.acc_input_unit,
            gyro_input_unit=self.gyro_input_unit,
        )
        out.nan_rows = int(np.count_nonzero(~out.finite))
        if self.gyr_clock is not None:
            out.gyr_clock = self.gyr_clock  # the gyroscope's own samples, whatever rows of t are kept
        return out

    def summary(self) -> str:
        """One line: samples, duration, rate, units, NaN rows, source.

        Returns
        -------
        str
            The line.
        """
        span = float(self.t[-1] - self.t[0]) if self.t.size else 0.0
        parts = [f"{self.t.size} samples over {span:.6g} s (median {self.rate_hz:.6g} Hz)"]
        if self.acc is not None:
            parts.append(
                f"acc in {self.acc_unit}"
                + (f" (file: {self.acc_input_unit})" if self.acc_input_unit not in (None, self.acc_unit) else "")
            )
        if self.gyr is not None:
            parts.append(
                f"gyro in {self.gyro_unit}"
                + (f" (file: {self.gyro_input_unit})" if self.gyro_input_unit not in (None, self.gyro_unit) else "")
            )
        parts.append(f"{self.nan_rows} row(s) with NaN")
        return ", ".join(parts) + (f"; from {self.source}" if self.source else "")


register_legacy(ImuLog, ImuLog.SCHEMA, 1, lambda d: nested_kwargs(ImuLog, d, {"gyro": "gyr"}))


# --- reading ------------------------------------------------------------------------------------------------


@dataclass
class _Part:
    """What one file contributes: raw arrays, their names and the units the file declares."""

    path: Path
    table: Table
    n: int
    t: np.ndarray | None = None
    t_name: str | None = None
    acc: np.ndarray | None = None
    gyro: np.ndarray | None = None
    labels: np.ndarray | None = None
    sample: np.ndarray | None = None
    row: np.ndarray | None = None  # the rows kept, where some were left out (ImuLog.row)
    declared: dict = field(default_factory=lambda: {"acc": {}, "gyro": {}, "time": {}})
    #: units a column's name implies (``header.stamp``: ns), which an option overrides: source → unit, by kind
    implied: dict = field(default_factory=lambda: {"acc": {}, "gyro": {}, "time": {}})
    srcs: dict = field(default_factory=dict)  # kind → the source names of its three components
    used: set = field(default_factory=set)  # the names of every array taken
    finite: set = field(default_factory=set)  # the kinds whose every value is known to be finite
    #: the gyroscope's own (times s, samples) where it was interpolated onto the accelerometer's times
    gyro_clock: tuple | None = None


def _canonical(kind: str, unit: str, option: str) -> str:
    """Canonical spelling of a unit option (``acc``: counts|g|m/s^2, ``gyro``: counts|deg/s|rad/s, ``time``)."""
    table = ACC_UNITS if kind == "acc" else GYRO_UNITS if kind == "gyro" else _TIME_SPELLINGS
    key = str(unit).strip()
    for cand in (key, key.lower()):
        if cand in table:
            return table[cand]
    raise OptinavError(f"unknown {option} {unit!r}", f"use one of: {', '.join(_CANONICAL[kind])}")


def _resolve_unit(kind: str, given: str | None, part: _Part, option: str, default: str, notes=None) -> str:
    """The unit of one quantity: the option, else what the file declares, else what a column's name implies (the
    option overrides that: ``header.stamp`` in s was refused against --time-unit s), else ``default``; conflicts
    are errors, but for an option that contradicts the file's declaration where ``notes`` (a list) takes a note:
    a header in the wrong unit was refused with the option the unit checks named, and could not be read."""
    declared = {}
    stated = part.declared[kind] if given is not None or part.declared[kind] else part.implied[kind]
    for src, unit in stated.items():
        try:
            declared[src] = _canonical(kind, unit, option)
        except OptinavError:
            if given is None:
                raise OptinavError(
                    f"{part.path.name}: {src} declares the unit {unit!r}, which optinav does not "
                    f"convert (accepted: {', '.join(_CANONICAL[kind])})",
                    f"convert the file, or pass {option}=... to state the unit",
                ) from None
    if given is not None:
        off = {src: unit for src, unit in declared.items() if unit != given}
        if off and notes is not None:
            units = "/".join(sorted(set(off.values())))
            notes.append(f"{part.path.name}: {', '.join(off)} declare {units}; {option}={given} overrides that")
            return given
        for src, unit in declared.items():
            if unit != given:
                raise OptinavError(
                    f"{part.path.name}: {src} declares {unit} but {option}={given!r} was passed",
                    f"drop {option} or correct the file",
                )
        return given
    units = set(declared.values())
    if len(units) > 1:
        shown = ", ".join(f"{s}: {u}" for s, u in declared.items())
        raise OptinavError(
            f"{part.path.name} declares different {kind} units ({shown})",
            f"convert the file to one unit, or pass {option}=... to override",
        )
    return units.pop() if units else default


def _std(name: str, what: str) -> str:
    hit = ALIASES.get(normalize_name(name)[0])
    if hit is None:
        raise OptinavError(
            f"{what}: {name!r} is not a standard name",
            f"use {', '.join(STANDARD_NAMES)} (or an alias) on the left of '='",
        )
    return hit[0]


#: the standard names a '-' in ``columns`` may negate: a sensor's axes or its N×3 array
_SIGNED = ("ax", "ay", "az", "gx", "gy", "gz", "acc", "gyro")


def _unsigned(entry: str, what: str) -> tuple[str, bool]:
    """(``entry`` without a leading sign, whether that sign was '-')."""
    if entry[:1] not in ("-", "+") or len(entry) == 1:
        return entry, False
    name = entry[1:].strip()
    if not name or name in SKIP_NAMES:
        raise OptinavError(f"{what} entry {entry!r} signs no column", "put '-' before a sensor column, e.g. -az")
    return name, entry[0] == "-"


def _negated_std(key: str, name: str, what: str) -> str:
    """The standard name ``key`` whose column ``name`` a '-' negates, checked: a sensor axis or triad, and not
    Core Motion's acceleration (read negated already)."""
    base = normalize_name(name)[0]
    if base[:-1] in (_CM_ACC, *_CM_SPLIT):
        raise OptinavError(
            f"{what}: {name!r} is Core Motion's acceleration, which is read negated already (minus the specific force)",
            f"drop the '-' before {name!r}",
        )
    hit = ALIASES.get(normalize_name(key)[0])
    if hit is None or hit[0] not in _SIGNED:
        raise OptinavError(
            f"{what}: '-{name}' negates {key!r}, which is no accelerometer or gyroscope column",
            "put '-' only before sensor columns (ax..az, gx..gz, acc, gyro)",
        )
    return hit[0]


def _signed_columns(columns, what: str) -> tuple[list[str] | None, dict, list[str]]:
    """:func:`~optinav.io.readers.parse_columns` of ``columns`` whose entries may carry a sign (``t,-ax,ay,…``,
    ``ax=-NAME``: that column read negated, for an axis mounted flipped or a logger that logs minus the specific
    force): (positional names, std=name mapping, the standard names negated)."""
    positional, mapping = parse_columns(columns, what)
    negated = []
    if positional is not None:
        for i, entry in enumerate(positional):
            positional[i], minus = _unsigned(entry, what)
            if minus:
                negated.append(_negated_std(positional[i], positional[i], what))
    for key, entry in mapping.items():
        mapping[key], minus = _unsigned(entry, what)
        if minus:
            negated.append(_negated_std(key, mapping[key], what))
    return positional, mapping, negated


def _part_spec(
    columns, datasets, what: str, topic=None, skip_bad_lines=False
) -> tuple[list[str] | None, dict, list[str], dict]:
    """(positional names, std=name mapping, the standard names read negated, keyword arguments of
    load_table/iter_table) of a column option."""
    positional, mapping, negated = _signed_columns(columns, what)
    if datasets is not None:
        _, arrays, more = _signed_columns(datasets, "datasets")
        merge_datasets(mapping, arrays or datasets, what)
        negated += more
    label_sources = tuple(name for key, name in mapping.items() if _std(key, what) == "label")
    sources = set(mapping.values())

    def needed(name: str) -> bool:  # a column read_imu takes (a text column it does not is left out)
        if name in sources:
            return True
        return not (_local_clock(name) or _temperature(name)) and (
            normalize_name(name)[0] in ALIASES or normalize_name(name)[0] in FRAME_COLUMNS
        )

    return (
        positional,
        mapping,
        negated,
        {
            "names": positional,
            "only": list(mapping.values()) or None,
            "text_columns": LABEL_COLUMNS + FRAME_COLUMNS + SENSOR_COLUMNS + label_sources,
            "topic": topic,
            "needed": needed,
            "skip_bad_lines": bool(skip_bad_lines),
        },
    )


def _read_part(
    path, columns, datasets, delimiter, need: str | None, what: str, topic=None, skip_bad_lines=False
) -> _Part:
    _, mapping, negated, kw = _part_spec(columns, datasets, what, topic, skip_bad_lines)
    if isinstance(path, ExportMember | UlogTopic):  # a phone export's file, a ULog's topic: read in memory
        return _part_of(path.path, path.load(delimiter=delimiter, **kw), mapping, need, what, negated=negated)
    return _part_of(path, load_table(path, delimiter=delimiter, **kw), mapping, need, what, negated=negated)


#: columns at least this long are interleaved by the compiled kernel (shorter ones by numpy: no numba start)
_COMPILED_ROWS = 1 << 18


def _long(tri: np.ndarray) -> bool:
    """A long contiguous float64 triad: what the compiled passes over a triad take."""
    return tri.shape[0] >= _COMPILED_ROWS and tri.dtype == np.float64 and tri.flags.c_contiguous


def _range(tri: np.ndarray) -> tuple[float, float] | None:
    """(min, max) of a long contiguous float64 triad (NaN when any value is NaN), else None (the value check then
    takes them on its own)."""
    if not _long(tri):
        return None
    flat = tri.reshape(-1)
    return float(flat.min()), float(flat.max())  # vectorized, NaN when any value is NaN: faster than one scalar pass


def _gyro_triad_ahead(found: dict, alternate: bool = False):
    """The gyro's :func:`_triad` (``alternate`` passed on) started in a thread of :mod:`optinav.io._pool`
    when both triads are long columns (the compiled interleave or range pass releases the GIL, so the acc's runs
    at once), else None."""
    cols = [found[c][1] for c in _COMPONENTS["gyro"] if c in found]
    acc = [c for c in _COMPONENTS["acc"] if c in found]
    if len(cols) != 3 or len(acc) != 3 or "gyro" in found or "acc" in found or cols[0].ndim != 1:
        return None
    if cols[0].size < _COMPILED_ROWS:  # numba's start is not worth it
        return None
    from optinav.io._pool import helper

    pool = helper()
    return None if pool is None else pool.submit(_triad, cols, alternate)


def _triad(cols: list[np.ndarray], alternate: bool = False) -> tuple:
    """The (n, 3) array of three columns, (min, max) of its values when it was computed on the way (NaN
    when any value is NaN; None: not computed), and its :func:`alternation` when ``alternate`` and it was computed
    in the same pass (else None): a view of the memory they share when they are the columns 0, 1,
    2 of one row-major (n, 3) array (a reader's array handed out as column views, e.g. a ROS bag's; its range by
    :func:`_range`, or with ``alternate`` by the two-sensor check's pass), else a copy (the strided copy costs
    about as much as decoding the bag; a long float64 one is compiled, with the
    range, :func:`optinav.io._colkernels.interleave3`)."""
    a = cols[0]
    base, item = a.base, a.itemsize
    ptr = [c.__array_interface__["data"][0] for c in cols]
    if (
        base is not None
        and all(c.base is base and c.ndim == 1 and c.dtype == a.dtype and c.shape == a.shape for c in cols)
        and all(c.strides == (3 * item,) for c in cols)
        and ptr == [ptr[0], ptr[0] + item, ptr[0] + 2 * item]
    ):
        tri = np.lib.stride_tricks.as_strided(a, shape=(a.shape[0], 3), strides=(3 * item, item))
        if alternate and _long(tri):
            bounds = np.empty(2)
            alt = alternation(tri, bounds)
            return tri, (float(bounds[0]), float(bounds[1])), alt
        return tri, _range(tri), None
    if a.ndim == 1 and a.size >= _COMPILED_ROWS and all(c.dtype == np.float64 and c.shape == a.shape for c in cols):
        from optinav.io._colkernels import interleave3

        out = np.empty((a.size, 3))
        return out, interleave3(*cols, out), None
    return np.column_stack(cols), None, None


def _kalibr_csv(table: Table, found: dict, candidates: dict, implied: dict) -> None:
    """Kalibr's IMU CSV (``kalibr_bagcreater``: ``timestamp,omega_x..z,alpha_x..z``; ns, rad/s, m/s²), where
    ``alpha`` is the accelerometer: its columns become ``ax..az`` and its timestamp ns, when the file holds
    omega and alpha triads and nothing else looks like an accelerometer."""
    norm = table.normal_names()
    if not all(f"{p}_{a}" in norm for p in ("omega", "alpha") for a in "xyz"):
        return
    if any(k in found or k in candidates for k in ("ax", "ay", "az", "acc")):
        return
    for a in "xyz":
        candidates[f"a{a}"] = norm[f"alpha_{a}"]
    key = candidates.get("t")
    if key is not None and "t" not in found and normalize_name(key)[0] == "timestamp":
        implied.setdefault(key, "ns")


def _ardupilot_imu(table: Table) -> set[str]:
    """ArduPilot's IMU, ACC and GYR messages as ``mavlogdump.py --format csv --types IMU`` writes them
    (``timestamp,TimeUS,I,GyrX..GyrZ,AccX..AccZ,EG,EA,T,…``; ACC/GYR: ``timestamp,TimeUS,I,SampleUS,AccX..``; rad/s,
    m/s²): the time is SampleUS where there is one, else TimeUS (µs since boot); the names of the other columns
    that look like a time (mavlogdump's wall clock ``timestamp``, the temperature ``T``, TimeUS beside SampleUS)
    are returned to be passed over. Several IMUs interleaved in the instance column ``I`` are refused: read as
    one log, their rows alternate between sensors with exit 0."""
    msg, inst = _ardupilot_message(table)
    if msg is None:
        return set()
    norm = table.normal_names()
    if inst is not None and table.data[inst].dtype.kind == "f" and table.data[inst].ndim == 1:
        ids = np.unique(table.data[inst][np.isfinite(table.data[inst])])
        if ids.size > 1:
            shown = ", ".join(f"{v:g}" for v in ids[:_MAX_IDS])
            raise OptinavError(
                f"{table.path.name}: column {inst!r} holds {ids.size} IMU instances ({shown}) in alternate rows; "
                "read as one log they would mix the sensors",
                f"read one with --topic {msg}@{ids[0]:g} (topic='{msg}@{ids[0]:g}'), or export one: mavlogdump.py "
                f"--format csv --types {msg} --condition '{msg}.I=={ids[0]:g}' LOG.bin",
            )
    return {norm[k] for k in ("t", "timestamp", "timeus" if "sampleus" in norm else "") if k in norm}


def _ardupilot_message(table: Table) -> tuple[str | None, str | None]:
    """(message name IMU/ACC/GYR, its instance column or None) of a mavlogdump CSV of ArduPilot's IMU, ACC or GYR
    message (TimeUS and a GyrX..Z or AccX..Z triad); (None, None) for another table."""
    norm = table.normal_names()
    triads = [p for p in ("gyr", "acc") if all(f"{p}{a}" in norm for a in "xyz")]
    if "timeus" not in norm or not triads:
        return None, None
    return ("IMU" if len(triads) == 2 else triads[0].upper()), norm.get("i", norm.get("instance"))


def _select_instance(table: Table) -> None:
    """Keep the rows of one sensor of a table holding several in alternate rows, as ``--topic NAME@ID``
    (``table.meta['select']``) names it: ArduPilot's instance column (``I``/``Instance``; NAME the message IMU,
    ACC or GYR, or empty) or a ``frame_id`` column (``rostopic echo -p`` of a topic two IMUs publish: ID the
    frame_id, as a bag's ``TOPIC@FRAME``). Every column of the table's length is cut to those rows."""
    sel = table.meta.get("select")
    if sel is None:
        return
    name, _, ident = sel.rpartition("@")
    name, ident = name.strip(), ident.strip()
    msg, inst = _ardupilot_message(table)
    frame = next((k for k in table.data if normalize_name(k)[0] in FRAME_COLUMNS), None)
    if inst is not None:
        if name and name.upper() != msg:
            raise OptinavError(
                f"--topic {sel}: {table.path.name} holds ArduPilot's {msg} message, not {name}",
                f"write --topic {msg}@{ident}",
            )
        try:
            keep = table.data[inst] == float(ident)
        except ValueError:
            raise OptinavError(
                f"--topic {sel}: ArduPilot's instance is a number, not {ident!r}", f"write e.g. --topic {msg}@0"
            ) from None
        what = f"{inst} == {ident}"
        cells = table.data[inst]
    elif frame is not None:
        cells = table.data[frame].astype(str)
        keep, what = cells == ident, f"{frame} == {ident!r}"
    else:
        raise OptinavError(
            f"--topic {sel}: {table.path.name} has no instance column (ArduPilot's I) or frame_id column to pick rows by",
            "drop --topic",
        )
    if cells.size and not keep.any():
        found = np.unique(cells)
        shown = ", ".join(f"{v:g}" if isinstance(v, float) else repr(str(v)) for v in found[:_MAX_IDS].tolist())
        raise OptinavError(
            f"--topic {sel}: no row of {table.path.name} has {what} (found: {shown})", "pick one of the values found"
        )
    n = cells.shape[0]
    table.data = {k: v[keep] if v.ndim and v.shape[0] == n else v for k, v in table.data.items()}


_MAX_IDS = 8
#: columns naming each row's sensor frame (``rostopic echo -p``'s field.header.frame_id), normalized
FRAME_COLUMNS = ("frame_id", "header_frame_id")


def _one_frame(table: Table) -> None:
    """Refuse rows of several sensor frames interleaved in one file (a topic carrying several IMUs, echoed to
    CSV): read as one log their rows alternate between sensors with exit 0. Runs of one frame after another (a
    driver restarted under another frame_id), fewer than twice the frames, are kept, as a bag's are."""
    for key, arr in table.data.items():
        if normalize_name(key)[0] in FRAME_COLUMNS and arr.ndim == 1 and arr.size:
            cells = arr.astype(str)
            frames = np.unique(cells)
            if frames.size > 1 and 1 + np.count_nonzero(cells[1:] != cells[:-1]) >= 2 * frames.size:
                shown = ", ".join(map(repr, frames[:_MAX_IDS].tolist()))
                raise OptinavError(
                    f"{table.path.name}: column {key!r} holds {frames.size} sensor frames ({shown}) in alternate "
                    "rows; read as one log they would mix the sensors",
                    f"read one with --topic @{frames[0]} (its rows alone), or the bag itself with --topic TOPIC@FRAME",
                )


#: columns naming each row's sensor in a "long" log, one row per sensor sample (``time, sensor, x, y, z``: custom
#: loggers, Android event dumps), normalized
SENSOR_COLUMNS = ("sensor", "sensor_type", "sensortype", "sensor_name", "sensorname", "type")
#: a long log's shared value columns, normalized
_LONG_AXES = (("x", "y", "z"), ("value_x", "value_y", "value_z"), ("values_0", "values_1", "values_2"))
#: a long log's sensor names (lower case, letters and digits only, Android's ``android.sensor.`` dropped) → triad
_SENSOR_KINDS = {
    **dict.fromkeys(("acc", "accel", "acce", "accl", "accelerometer", "accelerometers"), "acc"),
    **dict.fromkeys(("gyr", "gyro", "gyros", "gyroscope", "gyroscopes"), "gyro"),
    **dict.fromkeys(("mag", "magn", "magnetometer", "magneticfield", "compass"), "mag"),
    **dict.fromkeys(("accelerometeruncalibrated", "accuncalibrated"), "acc uncalibrated"),
    **dict.fromkeys(("gyroscopeuncalibrated", "gyrouncalibrated"), "gyro uncalibrated"),
    **dict.fromkeys(("magneticfielduncalibrated", "magnetometeruncalibrated"), "mag uncalibrated"),
}
#: Android's sensor type numbers (android.hardware.Sensor.TYPE_*) of the triads, in a numeric type column
_ANDROID_TYPES = {
    1: "acc",
    4: "gyro",
    2: "mag",
    35: "acc uncalibrated",
    16: "gyro uncalibrated",
    14: "mag uncalibrated",
}
#: the standard names of each triad's axes, and the triad in words
_TRIAD_NAMES = {"acc": ("ax", "ay", "az"), "gyro": ("gx", "gy", "gz"), "mag": ("mx", "my", "mz")}
_TRIAD_WORDS = {"acc": "accelerometer", "gyro": "gyroscope", "mag": "magnetometer"}


def _sensor_kind(value) -> str | None:
    """The triad a long log's sensor name (or Android type number) names, None for another sensor."""
    if isinstance(value, (int, float, np.integer, np.floating)):
        return _ANDROID_TYPES.get(int(value)) if float(value).is_integer() else None
    key = re.sub(r"[^a-z0-9]", "", str(value).strip().lower().removeprefix("android.sensor."))
    return _SENSOR_KINDS.get(key)


def _long_log(table: Table, keep: tuple[str, ...]) -> bool:
    """:func:`_long_rows`; when the table is no long log, a text column of :data:`SENSOR_COLUMNS` (a device's name
    on every row) is left out with a note, as any text column nothing reads."""
    if _long_rows(table, keep):
        return True
    text = [k for k in list(table.data) if normalize_name(k)[0] in SENSOR_COLUMNS and table.data[k].dtype.kind in "USO"]
    for k in text:
        table.data.pop(k)
        table.units.pop(k, None)
    if text:
        shown = ", ".join(map(repr, text))
        was = table.meta.get("text_left_out")
        table.meta["text_left_out"] = f"{was}, {shown}" if was else shown
    return False


def _long_rows(table: Table, keep: tuple[str, ...]) -> bool:
    """A long log (one row per sensor sample: a :data:`SENSOR_COLUMNS` column naming the sensor, shared value
    columns x, y, z) rewritten in place as one triad per sensor — ``ax…``, ``gx…``, ``mx…``, NaN on the other
    sensors' rows, as a multi record's blank cells — keeping the rows of the triads ``keep`` ("acc", "gyro",
    "mag"); a triad's uncalibrated rows stand in for it only where its calibrated ones are absent. True when it
    was one (``table.meta["long_log"]`` says how it was read). Numeric type columns are read as Android's."""
    norm = table.normal_names()
    col = next((norm[k] for k in SENSOR_COLUMNS if k in norm), None)
    axes = next((tuple(norm[a] for a in names) for names in _LONG_AXES if all(a in norm for a in names)), None)
    imu = ("ax", "ay", "az", "acc", "gx", "gy", "gz", "gyro")
    if col is None or axes is None or any(ALIASES.get(k, ("",))[0] in imu for k in norm):
        return False  # columns named for a triad are read as such (x, y, z beside them: a position, say)
    labels = np.asarray(table.data[col])
    if labels.ndim != 1:
        return False
    values = np.unique(labels)
    if values.size < 2:
        return False  # one value on every row names no sensor per row (a packet type)
    kinds = {v: _sensor_kind(v) for v in values.tolist()}
    if not any(k is not None and k.split()[0] in ("acc", "gyro") for k in kinds.values()):
        return False
    chosen = {}  # triad → the label values read as it
    for triad in ("acc", "gyro", "mag"):
        own = [v for v, k in kinds.items() if k == triad] or [
            v for v, k in kinds.items() if k == f"{triad} uncalibrated"
        ]
        if own:
            chosen[triad] = own
    rows = {t: np.isin(labels, v) for t, v in chosen.items() if t in keep}
    kept = np.zeros(labels.size, bool)
    for r in rows.values():
        kept |= r
    n = labels.size
    x = [np.asarray(table.data[a], float) for a in axes]
    for a in (col, *axes):
        table.data.pop(a)
        table.units.pop(a, None)
    for t, r in rows.items():
        for name, v in zip(_TRIAD_NAMES[t], x):
            table.data[name] = np.where(r, v, np.nan)
    table.data = {k: v[kept] if v.ndim and v.shape[0] == n else v for k, v in table.data.items()}

    def shown(v) -> str:  # Android's type numbers as written, not as floats
        return f"{int(v)} (Android's type)" if isinstance(v, float) and v.is_integer() else str(v)

    read = "; ".join(f"{', '.join(map(shown, chosen[t]))} as the {_TRIAD_WORDS[t]}" for t in chosen if t in keep)
    other = [shown(v) for v in values.tolist() if not any(v in vs for t, vs in chosen.items() if t in keep)]
    whose = "the magnetometer's" if keep == ("mag",) else "the accelerometer's or gyroscope's"
    table.meta["long_log"] = f"column {col!r} naming each row's sensor: {read or 'none read'}" + (
        f" (the rows of {', '.join(other[:6])}{', …' if len(other) > 6 else ''} are not {whose})" if other else ""
    )
    return True


def _px4(table: Table, found: dict, candidates: dict, implied: dict) -> None:
    """PX4's uORB topics as pyulog's ``ulog2csv`` writes them (``log_0_sensor_combined_0.csv``,
    ``…_vehicle_imu_0.csv``): ``timestamp`` and ``timestamp_sample`` are µs since boot (the sample's stamp is the
    time where there is one). vehicle_imu holds increments over its integration period: ``delta_angle[0..2]`` (rad)
    over ``delta_angle_dt`` and ``delta_velocity[0..2]`` (m/s) over ``delta_velocity_dt`` (µs) become the mean
    rate and specific force of each period. A ``.ulg`` read directly (:mod:`optinav.io.ulog`) gives the same
    names, and its raw ``sensor_accel``/``sensor_gyro`` topics are read by :func:`_px4_raw`."""
    norm = table.normal_names()
    _px4_raw(table, found, candidates)
    inc = {
        kind: ([norm.get(f"{name}_{a}") for a in "xyz"], norm.get(f"{name}_dt"))
        for kind, name in (("g", "delta_angle"), ("a", "delta_velocity"))
    }
    combined = any(all(f"{p}_{a}" in norm for a in "xyz") for p in ("gyro_rad", "accelerometer_m_s2"))
    imu = any(all(keys) and dt for keys, dt in inc.values())
    if not (combined or imu or table.meta.get("px4_topic") in _PX4_RAW):
        return
    rel = norm.get("accelerometer_timestamp_relative")
    acc_keys = [norm.get(f"accelerometer_m_s2_{a}") for a in "xyz"]
    if rel is not None and all(acc_keys) and table.data[rel].dtype.kind == "f":
        # SensorCombined.msg: RELATIVE_TIMESTAMP_INVALID "means the associated sensor values are invalid"
        bad = table.data[rel] == PX4_RELATIVE_TIMESTAMP_INVALID
        if bad.any():
            for key in acc_keys:
                table.data[key] = np.where(bad, np.nan, table.data[key])
            table.meta["px4_acc_invalid"] = str(int(np.count_nonzero(bad)))
    for kind, (keys, dt) in inc.items():
        if not (all(keys) and dt) or any(f"{kind}{a}" in found or f"{kind}{a}" in candidates for a in "xyz"):
            continue
        period = table.data[dt] * 1e-6
        with np.errstate(divide="ignore", invalid="ignore"):
            for a, key in zip("xyz", keys):
                name = f"{key} / {dt}"
                table.data[name] = np.where(period > 0, table.data[key] / period, np.nan)
                candidates[f"{kind}{a}"] = name
    if "t" not in found:
        key = norm.get("timestamp_sample") or norm.get("timestamp")
        if key is not None and candidates.get("t", key) in (key, norm.get("timestamp")):
            candidates["t"] = key
            implied.setdefault(key, "us")


#: sensor_combined's accelerometer_timestamp_relative of a row whose accelerometer values are invalid (0x7fffffff)
PX4_RELATIVE_TIMESTAMP_INVALID = 2147483647

#: PX4's raw sensor topics, one sensor each (x, y, z at timestamp_sample): the standard names of their axes
_PX4_RAW = {"sensor_accel": "a", "sensor_gyro": "g"}


def _px4_raw(table: Table, found: dict, candidates: dict) -> None:
    """PX4's ``sensor_accel`` (m/s²) or ``sensor_gyro`` (rad/s): fields ``x, y, z``, which name no sensor by
    themselves, read as the topic's sensor when the ULog reader says which topic it is (``meta["px4_topic"]``)."""
    kind = _PX4_RAW.get(table.meta.get("px4_topic", ""))
    if kind is None or _sensor_named(found, candidates):
        return
    norm = table.normal_names()
    if all(a in norm for a in "xyz"):
        for a in "xyz":
            candidates[f"{kind}{a}"] = norm[a]


#: iOS Core Motion's triads as SensorLog names them (normalized, axis letter after): the raw accelerometer and
#: its device-motion split (userAcceleration + gravity, both in g), the raw and the device-motion gyroscope (rad/s)
_CM_ACC, _CM_SPLIT, _CM_GYRO = "accelerometeracceleration", ("motionuseracceleration", "motiongravity"), "gyrorotation"
_CM_NAMES = {_CM_SPLIT[0]: "userAcceleration (gravity taken out)", _CM_SPLIT[1]: "gravity"}
_CM_TIME = {_CM_ACC: "accelerometertimestamp", _CM_SPLIT[0]: "motiontimestamp", _CM_GYRO: "gyrotimestamp"}


def _headerless(table: Table) -> bool:
    """Whether no header named ``table``'s columns (``col1`` … ``colN``: :func:`optinav.io.readers.generic_names`)."""
    return list(table.data) == generic_names(len(table.data))


def _sensor_named(found: dict, candidates: dict, *more: str) -> bool:
    """Whether a column was already taken (mapped or by its name) for a sensor component or triad (or ``more``)."""
    return any(k in found or k in candidates for k in ("ax", "ay", "az", "acc", "gx", "gy", "gz", "gyro", *more))


def _columns_example(table: Table) -> tuple[str, str]:
    """(an example ``columns``, a remark after it) for a table the readers found no sensor in: one name per column
    of a file without a header (4 columns: a time and one sensor; 6/7: both sensors, with a time first), else the
    full list."""
    k = len(table.data)
    if _headerless(table):
        if k == 4:
            return "t,ax,ay,az", " and the gyroscope's file as gyro_path=GYRODATA (one sensor per file)"
        if k in (6, 7):
            return ",".join(["t"] * (k == 7) + ["ax", "ay", "az", "gx", "gy", "gz"]), ""
        if k > 7:  # one name per column: a wider file (OxIOD's 16, KITTI's oxts 30) gets '_' for the rest
            return "t,ax,ay,az,gx,gy,gz" + ",_" * (k - 7), f" for its {k} columns, each name where its column stands"
    return "t,ax,ay,az,gx,gy,gz", ""


def _one_sensor_columns(table: Table, found: dict, candidates: dict, need: str | None) -> None:
    """A file of one sensor of a pair (``need``: "acc" for the main file beside ``gyro_path``, "gyro" for that one)
    without a header: 4 columns are imu_tk's layout (``timestamp x y z``, its "Matlab matrix" .mat text files), 3
    the triad alone, when nothing else names a column and (4 columns) the first never decreases. Read so, named
    in the file's notes (``table.meta["one_sensor_layout"]``)."""
    if need not in ("acc", "gyro") or found or candidates:
        return
    keys = list(table.data)
    if len(keys) not in (3, 4) or not _headerless(table):
        return
    cols = [table.data[k] for k in keys]
    if any(c.ndim != 1 or c.dtype.kind != "f" for c in cols):
        return
    names = [f"{need[0]}{a}" for a in "xyz"]
    if len(keys) == 4:
        t = cols[0][np.isfinite(cols[0])]
        if t.size < 2 or np.any(np.diff(t) < 0):
            return
        names = ["t", *names]
    for std, key in zip(names, keys):
        found[std] = (key, table.data[key])
    table.meta["one_sensor_layout"] = ",".join(names)


#: a Shimmer Consensys column (normalized): the device's prefix, the signal, an axis, calibrated (``_cal``)
_SHIMMER = re.compile(
    r"^(.*?)_?(accel_ln|accel_wr|accel|gyro|timestamp_unix|timestampsync_unix|timestamp)(?:_([xyz]))?_cal$"
)
#: Shimmer's signals in the order they are taken: the low-noise accelerometer before the wide-range one, the Unix
#: timestamp before the synchronized one and the one since the start
_SHIMMER_ORDER = {
    "a": ("accel_ln", "accel", "accel_wr"),
    "g": ("gyro",),
    "t": ("timestamp_unix", "timestampsync_unix", "timestamp"),
}


def _shimmer(table: Table, found: dict, candidates: dict) -> None:
    """A Shimmer Consensys export: ``Shimmer_40AC_Accel_LN_X_CAL``, ``…_Accel_WR_X_CAL``, ``…_Gyro_X_CAL``,
    ``…_Timestamp_Unix_CAL`` (the device's name first; units in the row under the header: ms, m/(s^2), deg/s). The
    low-noise accelerometer is taken (the wide-range one named in ``table.meta["shimmer_passed"]``), the gyroscope,
    and the Unix timestamp, when nothing else names a sensor and one device's prefix heads every such column."""
    if _sensor_named(found, candidates, "t"):
        return
    hits: dict[tuple[str, str | None], str] = {}
    prefixes = set()
    for key in table.data:
        m = _SHIMMER.match(normalize_name(key)[0])
        if m:
            prefixes.add(m.group(1))
            hits[(m.group(2), m.group(3))] = key
    if len(prefixes) != 1:
        return
    taken: list[str] = []
    for kind, signals in _SHIMMER_ORDER.items():
        for sig in signals:
            keys = [hits.get((sig, a)) for a in "xyz"] if kind != "t" else [hits.get((sig, None))]
            if all(keys):
                for a, key in zip("xyz" if kind != "t" else "t", keys):
                    candidates[a if kind == "t" else f"{kind}{a}"] = key
                taken.append(sig)
                break
    if "accel_ln" in taken and all(("accel_wr", a) in hits for a in "xyz"):
        table.meta["shimmer_passed"] = hits[("accel_wr", "x")]


#: the fields of VectorNav's ASCII sentences that hold the IMU (VN-100/200/300 user manuals): (first accelerometer
#: field, first gyroscope field, number of fields); accelerometer in m/s², gyroscope in rad/s, magnetometer in gauss
_VN_LAYOUT = {"VNYMR": (6, 9, 12), "VNQMR": (7, 10, 13), "VNMAR": (3, 6, 9), "VNIMU": (3, 6, 11), "VNACC": (0, None, 3)}


def _vectornav_fields(table: Table, found: dict, candidates: dict) -> None:
    """A capture of VectorNav ASCII sentences (``$VNYMR,yaw,pitch,roll,magX..Z,accelX..Z,gyroX..Z*CS``, checksum
    held, ``table.meta["vectornav"]`` the sentence): its fields ``col1…`` named by the sentence's layout."""
    layout = _VN_LAYOUT.get(table.meta.get("vectornav", ""))
    keys = list(table.data)
    if layout is None or found or candidates or len(keys) != layout[2] or not _headerless(table):
        return
    for kind, first in zip("ag", layout[:2]):
        if first is not None:
            for j, a in enumerate("xyz"):
                candidates[f"{kind}{a}"] = keys[first + j]
                table.units.setdefault(keys[first + j], "m/s^2" if kind == "a" else "rad/s")


def _xsens_sdi(table: Table, found: dict, candidates: dict) -> None:
    """Xsens' strapdown-integrated increments (MT Manager's and a Movella DOT's exports: ``dq_W … dq_Z``, the
    orientation increment over one output period, and ``dv[1] … dv[3]``, the velocity increment in m/s, its axes
    counted from 1) become the mean rate (rad/s) and specific force (m/s²) of each period; the period is one over
    the rate the export states (``OutputRate:,60Hz``, ``// Update Rate: 100.0Hz``)."""
    if _sensor_named(found, candidates):
        return
    low = {k.strip().lower(): k for k in table.data}
    dq = [low.get(f"dq_{c}") for c in "wxyz"]
    dv = [low.get(f"dv[{i}]") for i in (1, 2, 3)]
    if not (all(dq) or all(dv)):
        return
    # without a stated rate the increments stay per period: the rate given or the time's step scales them (_log_of)
    rate = float(table.meta.get("rate", 1.0))
    if all(dv):
        for a, key in zip("xyz", dv):
            name = f"{key} * rate" if "rate" in table.meta else f"{key} per period"
            table.data[name] = table.data[key] * rate  # type: ignore[index]
            table.units[name] = "m/s^2"
            candidates[f"a{a}"] = name
    if all(dq):
        w, v = table.data[dq[0]], np.column_stack([table.data[k] for k in dq[1:]])  # type: ignore[index]
        half = np.linalg.norm(v, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(half > 0, 2.0 * np.arctan2(half, w) / half, 2.0) * rate  # rotation vector per second
        for j, a in enumerate("xyz"):
            name = f"{dq[j + 1]} as rad/s" if "rate" in table.meta else f"{dq[j + 1]} per period"
            table.data[name] = v[:, j] * scale
            table.units[name] = "rad/s"
            candidates[f"g{a}"] = name
    if "rate" in table.meta:
        table.meta["xsens_sdi"] = f"{rate:g}"
    else:
        table.meta["xsens_per_period"] = "1"


#: Xsens' SampleTimeFine: a 32-bit tick counter, µs on a Movella DOT, 100 µs (10 kHz) on an MTi, which wraps at
#: 2^32 ticks (an MTi 10/100 after one day, 864e6 ticks)
_STF_TICKS = {"1 µs": 1e-6, "100 µs": 1e-4}
_STF_WRAPS = (2.0**32, 864e6)
#: preamble keys of a Movella DOT export (``DeviceTag:,1``, ``OutputRate:,60Hz``): its SampleTimeFine is in µs
_DOT_KEYS = ("devicetag", "outputrate", "measurement_mode", "firmwareversion", "appversion", "syncstatus")


def _date_time(table: Table, found: dict, candidates: dict) -> None:
    """The one column of ISO 8601 date-times (read as s since the epoch, ``table.meta["date_columns"]``) as the
    time when nothing else names one (``datetime``, ``Date``, ``UTC``: names no alias takes for a time)."""
    if "t" in found or "t" in candidates or "date_columns" not in table.meta:
        return
    keys = [k for k in table.meta["date_columns"].split("\t") if k in table.data]
    if len(keys) == 1 and _sensor_named(found, candidates):
        candidates["t"] = keys[0]


def _xsens_time(table: Table, found: dict, candidates: dict) -> None:
    """Xsens' ``SampleTimeFine`` as the time when nothing else names one and it holds a number on every row: its
    wraps unwrapped (:data:`_STF_WRAPS`), in s when its tick is known (a DOT export's µs; else the rate the export
    states fits one tick), else in ticks (``table.meta["stf_tick"]`` unset: the rate given decides, _log_of)."""
    if "t" in found or "t" in candidates:
        return
    key = next((k for k in table.data if normalize_name(k)[0] == "sampletimefine"), None)
    if key is None or not _sensor_named(found, candidates):
        return
    v = np.asarray(table.data[key], dtype=float)
    if v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v)):
        return
    d = np.diff(v)
    back = np.flatnonzero(d < 0)
    if back.size:
        step = float(np.median(d[d > 0])) if np.any(d > 0) else 0.0
        # an MTi 10/100 wraps after one day: the value before its wrap is within a step of 864e6 ticks
        add = np.where(v[back] + 2 * step >= _STF_WRAPS[1], _STF_WRAPS[1], _STF_WRAPS[0])
        add = np.where(v[back] >= _STF_WRAPS[1] + 2 * step, _STF_WRAPS[0], add)
        jump = np.zeros(v.size)
        jump[back + 1] = add
        v = v + np.cumsum(jump)
    keys = {normalize_name(k.removeprefix("preamble:"))[0] for k in table.meta if k.startswith("preamble:")}
    tick = "1 µs" if keys & set(_DOT_KEYS) else None
    if tick is None and "rate" in table.meta and v.size > 1:
        step = float(np.median(np.diff(v))) * float(table.meta["rate"])
        tick = next((k for k, f in _STF_TICKS.items() if abs(step * f - 1.0) <= 0.01), None)
        if tick is None:  # ticks that fit no tick at the stated rate: the rate times the samples, as before
            return
    name = f"{key} unwrapped"
    if tick is not None:
        table.data[name] = v * _STF_TICKS[tick]
        table.units[name] = "s"
        table.meta["stf_tick"] = tick
    else:
        table.data[name] = v
    table.meta["stf"] = key
    candidates["t"] = name


def _ronin(table: Table) -> set[str]:
    """RoNIN's ``data.hdf5``: ``synced/time`` (s), ``synced/acce`` and ``synced/gyro`` (N×3, m/s² and rad/s, on that
    one clock) are the log; the other arrays named like a time or a sensor (``raw/imu/gyro``, ``synced/gyro_uncalib``
    …, each on its own clock) are passed over, named in ``table.meta["ronin"]``."""
    if not all(k in table.data for k in ("synced/time", "synced/acce", "synced/gyro")):
        return set()
    keep = {"synced/time", "synced/acce", "synced/gyro"}
    out = {k for k in table.data if k not in keep and normalize_name(k)[0] in ALIASES}
    table.meta["ronin"] = "1"
    return out


def _android_linear(table: Table) -> set[str]:
    """The columns of Android's linear acceleration (``LINEAR ACCELERATION X (m/s²)``: gravity taken out) in a
    file that holds the accelerometer (``ACCELEROMETER X``) too, as AndroSensor writes them: passed over, named in
    ``table.meta["gravity_free"]``. (ROS's ``linear_acceleration`` holds gravity, and stands alone.)"""
    norm = table.normal_names()
    if not all(f"accelerometer_{a}" in norm for a in "xyz"):
        return set()
    keys = {norm[f"linear_acceleration_{a}"] for a in "xyz" if f"linear_acceleration_{a}" in norm}
    if keys:
        table.meta["gravity_free"] = norm["linear_acceleration_x"] if len(keys) == 1 else ", ".join(sorted(keys))
    return keys


#: Physics Toolbox Sensor Suite's columns (normalized): its g-force meter ``gFx``… (the specific force in g, gravity
#: in it), beside which its ``ax``… are the linear accelerometer's (m/s², gravity taken out)
_PTB_GFORCE, _PTB_LINEAR = ("gfx", "gfy", "gfz"), ("ax", "ay", "az")


def _gforce_linear(table: Table) -> set[str]:
    """The linear accelerometer's columns (``ax``…, gravity taken out) of a Physics Toolbox export that holds its
    g-force meter (``gFx``…) too (``time,gFx,gFy,gFz,ax,ay,az,wx,wy,wz,…``): passed over, named in
    ``table.meta["gravity_free"]``; :func:`_gforce` takes the g-force meter."""
    norm = table.normal_names()
    if not all(k in norm for k in _PTB_GFORCE) or not all(k in norm for k in _PTB_LINEAR):
        return set()
    keys = {norm[k] for k in _PTB_LINEAR}
    table.meta["gravity_free"] = ", ".join(norm[k] for k in _PTB_LINEAR)
    return keys


def _gforce(table: Table, found: dict, candidates: dict) -> None:
    """Physics Toolbox's g-force meter ``gFx, gFy, gFz`` (the specific force over g, +1 up on z for a phone lying
    face up; ``time,gFx,gFy,gFz,TgF`` alone or beside its other sensors) as the accelerometer, in g unless its
    columns state a unit, when nothing else was taken for it."""
    if any(k in found or k in candidates for k in ("ax", "ay", "az", "acc")):
        return
    norm = table.normal_names()
    if not all(k in norm for k in _PTB_GFORCE):
        return
    for a, k in zip("xyz", _PTB_GFORCE):
        key = norm[k]
        if not (table.units.get(key) or normalize_name(key)[1]):
            table.units[key] = "g"
        candidates[f"a{a}"] = key


#: Physics Toolbox's gyroscope (rad/s) beside its g-force meter: a multi record, several sensors in one file
_PTB_GYRO = ("wx", "wy", "wz")


def _sensor_rows(v: np.ndarray) -> np.ndarray:
    """The rows of a multi record that hold a new sample of the triad ``v`` (N×3): its rows not left blank where
    others are (the other sensors' rows), else the rows where it differs from the row above (the other sensors'
    rows repeat its last sample; exact zeros before its first)."""
    finite = np.all(np.isfinite(v), axis=1)
    if not finite.all():
        return finite
    new = np.ones(v.shape[0], bool)
    new[1:] = np.any(v[1:] != v[:-1], axis=1)
    nonzero = np.any(v != 0, axis=1)
    new[: int(np.argmax(nonzero)) if nonzero.any() else v.shape[0]] = False
    return new


def _multi_record(part: _Part) -> bool:
    """Whether ``part`` holds Physics Toolbox's g-force meter and gyroscope (``gFx…``, ``wx…``) with a time column:
    its multi record, each row written when one of its sensors gives a sample (:func:`_split_sensors`)."""
    if "long_log" in part.table.meta:  # read whole: a block may hold one sensor's rows only
        return True
    names = {k: [normalize_name(s)[0] for s in part.srcs.get(k, ())] for k in ("acc", "gyro")}
    return part.t is not None and names["acc"] == list(_PTB_GFORCE) and names["gyro"] == list(_PTB_GYRO)


def _split_sensors(part: _Part) -> _Part | None:
    """Physics Toolbox Sensor Suite's multi record (``time,gFx,gFy,gFz,…,wx,wy,wz,…``; each row written at one
    sensor's sample, the other sensors' cells blank, or holding their last sample and 0 before their first:
    d33pk3rn3l/Navigation_23FS_ETHZ read_sensor_output.py, the 0.0000 rows of a multi record's start in
    vehicle-classification README's example) read as two sensors on their own rows: ``part`` is cut to the
    accelerometer's rows and the gyroscope's part returned on its own rows and times (None when every row holds a
    sample of both). Read as one log, the rows would pair each sample with a repeated or a blank one."""
    if not _multi_record(part):
        return None
    if "long_log" in part.table.meta:
        if part.t is None:
            raise OptinavError(
                f"{part.path.name}: each row is one sensor's sample ({part.table.meta['long_log']}), and without a "
                "time column the sensors' samples cannot be put in time",
                "keep the time column of the log (its name: t, time, timestamp, …)",
            )
        if part.acc is None or part.gyro is None:
            return None  # one triad's rows only: its samples
    rows = {"accelerometer": _sensor_rows(part.acc), "gyroscope": _sensor_rows(part.gyro)}
    if all(r.all() for r in rows.values()):
        return None
    for kind, r in rows.items():
        if np.count_nonzero(r) < 2:
            raise OptinavError(
                f"{part.path.name}: a multi record whose {kind} holds {np.count_nonzero(r)} sample(s)",
                "record for longer, with the sensor switched on in the app",
            )
    ra, rg = rows["accelerometer"], rows["gyroscope"]
    n = part.n
    table = part.table
    gyro = _Part(
        path=part.path,
        table=Table(path=table.path, kind=table.kind, data=table.data, units=table.units),
        n=int(np.count_nonzero(rg)),
        t=part.t[rg],
        t_name=part.t_name,
        gyro=part.gyro[rg],
        declared=part.declared,
        implied=part.implied,
        srcs={"gyro": part.srcs["gyro"]},
        used=part.used,
    )
    part.t, part.acc, part.gyro = part.t[ra], part.acc[ra], gyro.gyro  # gyro: as a second file's, on its own times
    for name in ("labels", "sample"):
        v = getattr(part, name)
        if v is not None:
            setattr(part, name, v[ra])
    part.n = int(np.count_nonzero(ra))
    part.finite.discard("gyro")
    on = f"{part.n} of its {n} rows, the gyroscope on its {gyro.n}"
    if "long_log" in table.meta:
        table.meta["long_log"] += f"; the accelerometer on {on}"
    else:
        table.meta["multi_record"] = on
    return gyro


#: Sensor Logger's files (one per sensor: ``time`` in ns since the epoch, ``seconds_elapsed``, then ``z, y, x``;
#: tszheichoi/awesome-sensor-logger UNITS.md, COORDINATES.md) by name: the sensor of the ones optinav reads, or why
#: the file is none of them
_SENSOR_LOGGER = {
    "gyroscope": "g",
    "gyroscopeuncalibrated": "g",
    "totalacceleration": "a",
    "accelerometer": "Sensor Logger's acceleration with gravity taken out (the phone's user acceleration)",
    "gravity": "Sensor Logger's gravity vector (the phone's estimate of where down is), not the accelerometer",
    "magnetometer": "Sensor Logger's magnetometer (µT), not the accelerometer or gyroscope",
    "magnetometeruncalibrated": "Sensor Logger's magnetometer (µT), not the accelerometer or gyroscope",
}


def _sensor_logger(table: Table, found: dict, candidates: dict) -> None:
    """A Sensor Logger file (``time, seconds_elapsed, z, y, x``): its axes name no sensor, its file name does
    (``Gyroscope.csv``, ``TotalAcceleration.csv``; a copy's `` (1)`` after it is fine). ``Accelerometer.csv``
    (gravity taken out), ``Gravity.csv`` and the magnetometer's are refused naming what they hold, and
    ``AccelerometerUncalibrated.csv`` naming the columns and unit to read it with: Sensor Logger writes it in g and
    as minus the specific force on iOS by default, in m/s² as it is on Android (and on iOS with "Standardise Units &
    Frames")."""
    norm = table.normal_names()
    if _sensor_named(found, candidates) or not {"x", "y", "z"} <= set(norm):
        return
    stem = re.sub(r"\s*\(\d+\)$", "", table.path.name.split(".")[0]).lower()
    hit = _SENSOR_LOGGER.get(stem)
    if hit in ("a", "g"):
        for a in "xyz":
            candidates[f"{hit}{a}"] = norm[a]
        table.meta["sensor_logger"] = "accelerometer" if hit == "a" else "gyroscope"
        return
    cols = ",".join(f"a{a}={{s}}{norm[a]}" for a in "xyz")
    if hit is not None:
        mine = f" (a file of another app that holds gravity: columns='{cols.format(s='')}')" if stem[0] == "a" else ""
        raise OptinavError(
            f"{table.path.name} is {hit}",
            "read TotalAcceleration.csv (Android) or AccelerometerUncalibrated.csv, which hold gravity, as the "
            f"accelerometer, and Gyroscope.csv as gyro_path=GYRODATA{mine}",
        )
    if stem == "accelerometeruncalibrated":
        xyz = np.column_stack([table.data[norm[a]][:1000] for a in "xyz"])
        xyz = xyz[np.all(np.isfinite(xyz), axis=1)]
        size = float(np.median(np.linalg.norm(xyz, axis=1))) if xyz.size else float("nan")
        seen = f"its norm reads {size:.3g}" + (
            ", so g: iOS" if 0.5 < size < 2 else ", so m/s^2" if 5 < size < 20 else ""
        )
        raise OptinavError(
            f"{table.path.name}: Sensor Logger writes its uncalibrated accelerometer in g and as minus the specific "
            f"force on iOS (by default), in m/s^2 as it is on Android or with 'Standardise Units & Frames' ({seen})",
            f"say which: columns='{cols.format(s='-')}' acc_unit='g' (iOS), or columns='{cols.format(s='')}' "
            "acc_unit='m/s^2'",
        )


def _wrist_motion_split(table: Table) -> set[str]:
    """The user acceleration's columns (``accelerationX``…, gravity taken out) of Sensor Logger's
    ``WristMotion.csv`` (the watch's Core Motion device motion: ``rotationRateX``…, ``gravityX``…,
    ``accelerationX``…, ``quaternionW``…): passed over, :func:`_wrist_motion` sums them with gravity."""
    norm = {normalize_name(k)[0] for k in table.data}
    if not table.path.name.lower().startswith("wristmotion") or "seconds_elapsed" not in norm:
        return set()
    if not all(f"{p}{a}" in norm for p in ("rotationrate", "gravity", "acceleration") for a in "xyz"):
        return set()
    return {k for k in table.data if normalize_name(k)[0] in ("accelerationx", "accelerationy", "accelerationz")}


def _wrist_motion(table: Table, found: dict, candidates: dict) -> None:
    """Sensor Logger's ``WristMotion.csv`` (awesome-sensor-logger UNITS.md, COORDINATES.md): the gyroscope is
    ``rotationRate`` (rad/s); the accelerometer is ``acceleration + gravity`` — by default in g and in Core
    Motion's sign (minus the specific force: negated), with "Standardise Units & Frames" in m/s² as it is. Its
    gravity, a unit vector of either, tells which (norm 1 or 9.81 in every row)."""
    if not _wrist_motion_split(table) or _sensor_named(found, candidates):
        return
    norm = table.normal_names()
    grav = np.column_stack([table.data[norm[f"gravity{a}"]] for a in "xyz"])
    size = np.linalg.norm(grav, axis=1)
    size = size[np.isfinite(size)]
    standard = bool(size.size and np.all(np.abs(size - G_STANDARD) < 0.1 * G_STANDARD))
    if not size.size or not (standard or np.all(np.abs(size - 1.0) < 0.1)):
        raise OptinavError(
            f"{table.path.name}: its gravity's norm is neither 1 (g, Sensor Logger's default) nor 9.81 (m/s^2, "
            "'Standardise Units & Frames') in every row, so the unit and sign of its acceleration are unknown",
            "map the columns yourself: columns='gx=rotationRateX,…' and an accelerometer with gravity",
        )
    for a in "xyz":
        user, g = norm[f"acceleration{a}"], norm[f"gravity{a}"]
        name = f"({user} + {g})" if standard else f"-({user} + {g})"
        total = table.data[user] + table.data[g]
        table.data[name] = total if standard else -total
        table.units[name] = "m/s^2" if standard else "g"
        candidates[f"a{a}"] = name
        candidates[f"g{a}"] = norm[f"rotationrate{a}"]
    table.meta["wrist_motion"] = "m/s^2, as it is" if standard else "g, negated (Core Motion's sign)"


def _headphone_split(table: Table) -> set[str]:
    """Sensor Logger's ``Headphone.csv`` (AirPods' motion, awesome-sensor-logger UNITS.md: ``rotationRateX…`` in
    rad/s, ``accelerationX…`` with gravity taken out, in g — in m/s² with "Standardise Units & Frames" —,
    ``gravityX…`` in m/s² either way, ``quaternionW…``, ``devicelocation``): its acceleration and gravity columns,
    passed over (nothing in the file says the acceleration's unit, so no sum of the two is the specific force);
    :func:`_headphone` takes its gyroscope. Named in ``table.meta["headphone"]``."""
    norm = {normalize_name(k)[0] for k in table.data}
    if not table.path.name.lower().startswith("headphone") or "seconds_elapsed" not in norm:
        return set()
    if not all(f"{p}{a}" in norm for p in ("rotationrate", "gravity", "acceleration") for a in "xyz"):
        return set()
    table.meta["headphone"] = table.path.name
    return {k for k in table.data if normalize_name(k)[0][:-1] in ("acceleration", "gravity")}


def _headphone(table: Table, found: dict, candidates: dict) -> None:
    """The gyroscope ``rotationRate`` (rad/s) of Sensor Logger's ``Headphone.csv`` (:func:`_headphone_split`): the
    headphones' own IMU, another device than the phone's."""
    if "headphone" not in table.meta or _sensor_named(found, candidates):
        return
    norm = table.normal_names()
    for a in "xyz":
        candidates[f"g{a}"] = norm[f"rotationrate{a}"]


#: the headphones' motion is another device than the phone: never paired with the phone's sensors
HEADPHONE = (
    "{name} is Sensor Logger's headphone motion (AirPods), another device than the phone, and holds no accelerometer "
    "with gravity (its acceleration has gravity taken out, in g or m/s² as 'Standardise Units & Frames' was set)",
    "read it on its own (optinav allan {name}: its gyroscope), and the phone's TotalAcceleration.csv with "
    "gyro_path=Gyroscope.csv for the attitude or a calibration",
)


def _headphone_refusal(name: str) -> OptinavError:
    """:data:`HEADPHONE` for the file ``name``."""
    return OptinavError(*(x.format(name=name) for x in HEADPHONE))


def headphone_error(chunks) -> OptinavError | None:
    """The error for a command that needs an accelerometer given Sensor Logger's ``Headphone.csv``
    (:data:`HEADPHONE`; ``chunks`` the :class:`ImuChunks` that read it), else None."""
    name = None if chunks.table is None else chunks.table.meta.get("headphone")
    return None if name is None else _headphone_refusal(name)


#: a UTC offset in brackets after a time column's name: MetaWear's MetaBase ``time (-08:00)``, the local clock as text
_UTC_OFFSET = re.compile(r"^(?:utc|gmt)?\s*[+-]\d{1,2}(?::?\d{2})?$", re.IGNORECASE)


def _local_clock(name: str) -> bool:
    """Whether column ``name`` is a time of day named with its UTC offset (``time (-08:00)``, MetaBase's local
    clock as text, ``2023-11-14T14.13.20.000``): not the samples' time, which the file holds beside it."""
    base, unit = normalize_name(name)
    return base in ("time", "timestamp") and unit is not None and bool(_UTC_OFFSET.match(unit.strip()))


#: units in brackets after ``T`` that make it a temperature (WitMotion's ``T(°)``, ``T (°C)``), not the time
_TEMPERATURE_UNITS = ("°", "°c", "℃", "c", "degc", "deg c", "°f", "k")


def _temperature(name: str) -> bool:
    """Whether column ``name`` is a temperature named ``T``/``t`` with a temperature unit (``T(°)``), not the time."""
    base, unit = normalize_name(name)
    return base == "t" and unit is not None and unit.strip().lower() in _TEMPERATURE_UNITS


#: WitMotion's column of the sensor's own clock (its PC software: ``ChipTime``; newer exports: ``Chip Time()``)
_CHIP_TIME = ("chiptime", "chip_time")


def _chip_time(table: Table, found: dict, candidates: dict) -> None:
    """WitMotion's ``ChipTime`` (date-times of the sensor's clock, its 0x50 time packet) as the time when the file
    holds it and nothing was mapped to ``t``: its ``time`` column is the computer's receive time, in bursts of USB
    packets. Named in ``table.meta["chip_time"]``."""
    if "t" in found or not _sensor_named(found, candidates):
        return
    key = next((k for k in table.data if normalize_name(k)[0] in _CHIP_TIME), None)
    if key is None or key not in table.meta.get("date_columns", "").split("\t"):
        return
    prev = candidates.get("t")
    candidates["t"] = key
    table.meta["chip_time"] = f"{key!r} (the sensor's clock) read as the time" + (
        f"; {prev!r} (the computer's receive time) passed over" if prev else ""
    )


def _axes_by_unit(table: Table, found: dict, candidates: dict) -> None:
    """One sensor per file, its axes named ``x-axis (g)`` … (MetaWear's MetaBase: ``epoch (ms), time (-08:00),
    elapsed (s), x-axis (deg/s), …``) or ``x (deg/s)``: the unit in brackets, the same on all three, says which
    sensor (an accelerometer's or a gyroscope's unit; raw counts or a field's unit say nothing). Nothing else in
    the file may look like a sensor."""
    if _sensor_named(found, candidates):
        return
    axes: dict[str, tuple[str, str | None]] = {}
    for key in table.data:
        base, unit = normalize_name(key)
        if base in ("x", "y", "z", "x_axis", "y_axis", "z_axis"):
            if base[0] in axes:
                return
            axes[base[0]] = (key, table.units.get(key) or unit)
    units = {u.strip().lower() if u else None for _, u in axes.values()}
    if len(axes) != 3 or len(units) != 1:
        return
    unit = units.pop()
    acc, gyro = ACC_UNITS.get(unit or ""), GYRO_UNITS.get(unit or "")
    if acc == gyro or "counts" in (acc, gyro):  # no unit, or counts: either sensor
        return
    for a in "xyz":
        candidates[f"{'a' if acc else 'g'}{a}"] = axes[a][0]


def _coremotion(table: Table, found: dict, candidates: dict) -> None:
    """iOS Core Motion as SensorLog logs it (``accelerometerAccelerationX(G)``, ``gyroRotationX(rad/s)``,
    ``motionUserAccelerationX(G)``, ``motionGravityX(G)``, ``…Timestamp_sinceReboot(s)``). Core Motion's
    acceleration is minus the specific force (a phone lying face up reads z = -1 g), so the accelerometer is
    negated, a column mapped by name too; without the raw accelerometer it is -(userAcceleration + gravity). The
    gyroscope is gyroRotation, else motionRotationRate; the time the accelerometer's (else the gyro's) stamp."""
    norm = table.normal_names()

    def triad(prefix: str) -> list[str] | None:
        keys = [norm.get(prefix + a) for a in "xyz"]
        return keys if all(keys) else None  # type: ignore[return-value]

    done = []
    for std in ("ax", "ay", "az"):
        name, arr = found.get(std, (None, None))
        base = None if name is None else normalize_name(name)[0]
        if base and base[:-1] in _CM_SPLIT:
            raise OptinavError(
                f"{table.path.name}: {name!r} ({std}) is Core Motion's {_CM_NAMES[base[:-1]]}, not the accelerometer",
                "map accelerometerAcceleration (X/Y/Z), or drop --columns: userAcceleration + gravity is summed",
            )
        if base and base[:-1] == _CM_ACC:
            found[std] = (name, -arr)
            done.append(name)
    source = None
    if not any(k in found or k in candidates for k in ("ax", "ay", "az", "acc")):
        raw, user, grav = triad(_CM_ACC), triad(_CM_SPLIT[0]), triad(_CM_SPLIT[1])
        if raw or (user and grav):
            source = _CM_ACC if raw else _CM_SPLIT[0]
            for a, key in zip("xyz", raw or user):
                other = None if raw else grav["xyz".index(a)]  # type: ignore[index]
                name = f"-{key}" if other is None else f"-({key} + {other})"
                table.data[name] = -table.data[key] if other is None else -(table.data[key] + table.data[other])
                unit = table.units.get(key) or normalize_name(key)[1]
                if unit:
                    table.units[name] = unit
                candidates[f"a{a}"] = name
                done.append(name)
    gyro = None
    if not any(k in found or k in candidates for k in ("gx", "gy", "gz", "gyro")):
        gyro = triad(_CM_GYRO) or triad("motionrotationrate")
        for a, key in zip("xyz", gyro or ()):
            candidates[f"g{a}"] = key
    if "t" not in found and "t" not in candidates:
        src = source or (None if gyro is None else _CM_GYRO if triad(_CM_GYRO) else _CM_SPLIT[0])
        t = None if src is None else norm.get(_CM_TIME[src] + "_sincereboot")
        if t is not None:
            candidates["t"] = t
    if done:
        table.meta["coremotion"] = ", ".join(done[:3]) + (" …" if len(done) > 3 else "")


def _split_stamp(table: Table, found: dict, candidates: dict, implied: dict) -> None:
    """A ROS 2 stamp stored as two integer columns (``header.stamp.sec`` and ``header.stamp.nanosec``, a struct
    ``header {stamp {sec, nanosec}}`` flattened, or bare ``sec`` and ``nanosec``) becomes the time, ``sec +
    nanosec·1e-9`` s as a bag's header stamp is read, when nothing else is the time (the file was refused as one
    without time, pass --rate) or the time is that ``sec`` (whole seconds: duplicate timestamps)."""
    norm = table.normal_names()
    pairs = {
        k[: -len("sec")]: (norm[k], norm[k[: -len("sec")] + frac])
        for k in norm
        if k == "sec" or k.endswith("_sec")
        for frac in ("nanosec", "nsec")
        if k[: -len("sec")] + frac in norm
    }
    if len(pairs) > 1:
        pairs = {k: v for k, v in pairs.items() if k.endswith("header_stamp_")}
    if len(pairs) != 1 or "t" in found:
        return
    sec, frac = next(iter(pairs.values()))
    if candidates.get("t", sec) != sec:  # another time column
        return
    if any(table.data[k].dtype.kind != "f" or table.data[k].ndim != 1 for k in (sec, frac)):
        return
    name = f"{sec} + {frac}"
    table.data[name] = table.data[sec] + table.data[frac] * 1e-9
    candidates["t"] = name
    implied[name] = "s"


def _unreadable_triad(table: Table, found: dict) -> None:
    """Refuse a file whose accelerometer or gyroscope is only in a column the reader left out as unreadable (a
    Parquet list column of varying length, an HDF5 dataset of three dimensions): the log was read without that
    sensor and with no word."""
    for key, why in table.skipped.items():
        hit = ALIASES.get(normalize_name(key)[0])
        kind = next((k for k, comps in _COMPONENTS.items() if hit and hit[0] in (k, *comps)), None)
        if kind is not None and kind not in found and not any(c in found for c in _COMPONENTS[kind]):
            raise OptinavError(
                f"{table.path.name}: {key!r} looks like the {'accelerometer' if kind == 'acc' else 'gyroscope'} "
                f"but cannot be read ({why})",
                "store it as one row of 3 numbers per sample, or leave it out with '_' in --columns",
            )


#: a unit written after an axis's name (``acc_x_mg``, ``gyro_x_dps``), normalized, and the unit it is
_NAME_UNITS = {
    "mg": "mg",
    "g": "g",
    "ms2": "m/s^2",
    "mps2": "m/s^2",
    "m_s2": "m/s^2",
    "mdps": "mdps",
    "dps": "deg/s",
    "degs": "deg/s",
    "deg_s": "deg/s",
    "rads": "rad/s",
    "rad_s": "rad/s",
}
#: words before an axis's name that name no other quantity (``imu_ax``, ``imu0_gx``, ``raw_ax``)
_NAME_PREFIX = re.compile(r"^(imu\d*|sensor\d*|raw|data|meas)_")


def _loose_alias(key: str) -> tuple[str | None, str | None]:
    """(standard name, unit) of a column named like a triad's axis after a word of :data:`_NAME_PREFIX` or
    before a unit of :data:`_NAME_UNITS` (``imu_ax``, ``acc_x_mg``); (None, None) otherwise. The unit must be
    one of that triad's."""
    base = _NAME_PREFIX.sub("", normalize_name(key)[0], count=1)
    hit = ALIASES.get(base)
    if hit is not None:
        return hit[0], None
    for suffix, unit in _NAME_UNITS.items():
        hit = ALIASES.get(base.removesuffix("_" + suffix)) if base.endswith("_" + suffix) else None
        kind = next((k for k, comps in _COMPONENTS.items() if hit and hit[0] in comps), None)
        if kind is not None and unit in _CANONICAL[kind]:
            return hit[0], unit
    return None, None


def _candidate(table: Table, candidates: dict, std: str, key: str) -> None:
    """Take column ``key`` for the standard name ``std``; a second column for it is an error naming both."""
    if std in candidates:
        raise OptinavError(
            f"{table.path.name}: columns {candidates[std]!r} and {key!r} both look like {std!r}",
            f"say which one with columns='{std}={candidates[std]}' (or skip one with '_')",
        )
    candidates[std] = key


def _part_of(
    path, table: Table, mapping: dict, need: str | None, what: str, *, block: bool = False, negated=()
) -> _Part:
    """What ``table`` holds for read_imu; ``block``: one block of a streamed file (a column may be empty there,
    the file's check of that is the caller's); ``negated``: the standard names read negated."""
    found: dict[str, tuple[str, np.ndarray]] = {}  # std → (source name, array)
    implied: dict[str, str] = {}
    for key, name in mapping.items():
        std = _std(key, what)
        if std in found:
            raise OptinavError(f"{what} maps {std!r} twice", "give one source per standard name")
        found[std] = (name, table.get(name))
    mapped_sources = {table.find(n) for n in mapping.values()}
    candidates: dict[str, str] = {}
    _select_instance(table)
    passed_over = _ardupilot_imu(table) | _android_linear(table) | _gforce_linear(table) | _wrist_motion_split(table)
    passed_over |= _headphone_split(table)
    passed_over |= _ronin(table)
    _one_frame(table)
    if not mapping:
        _long_log(table, ("acc", "gyro"))
    loose = []  # columns named like a triad's axis only with a word before it or a unit after it
    for key in table.data:
        if key in mapped_sources or key in SKIP_NAMES or key in passed_over:
            continue
        hit = ALIASES.get(normalize_name(key)[0])
        if hit is None:
            loose.append(key)
        if hit is None or hit[0] in found or _local_clock(key) or _temperature(key):
            continue
        _candidate(table, candidates, hit[0], key)
        if hit[1]:
            implied[key] = hit[1]
    exact = set(found) | set(candidates)
    for key in loose:
        if _local_clock(key) or _temperature(key):
            continue
        std, unit = _loose_alias(key)
        kind = next((k for k, comps in _COMPONENTS.items() if std in comps), None)
        if kind is None or any(c in exact for c in (kind, *_COMPONENTS[kind])):
            continue  # a triad named exactly elsewhere: a raw_ax beside ax is not it
        _candidate(table, candidates, std, key)
        if unit:
            table.units.setdefault(key, unit)
    _kalibr_csv(table, found, candidates, implied)
    _px4(table, found, candidates, implied)
    if {"acce_x", "linacce_x"} <= {normalize_name(k)[0] for k in table.data}:
        key = candidates.get("t")  # RIDI's CSV: Android's event time, ns
        if key is not None and normalize_name(key)[0] == "time":
            implied.setdefault(key, "ns")
    if "seconds_elapsed" in {normalize_name(k)[0] for k in table.data}:
        key = candidates.get("t")  # Sensor Logger: time in ns since the epoch beside seconds_elapsed
        if key is not None and normalize_name(key)[0] == "time":
            implied.setdefault(key, "ns")
        _wrist_motion(table, found, candidates)
        _headphone(table, found, candidates)
        _sensor_logger(table, found, candidates)
    _coremotion(table, found, candidates)
    _split_stamp(table, found, candidates, implied)
    _shimmer(table, found, candidates)
    _vectornav_fields(table, found, candidates)
    _xsens_sdi(table, found, candidates)
    _xsens_time(table, found, candidates)
    _chip_time(table, found, candidates)
    _date_time(table, found, candidates)
    _one_sensor_columns(table, found, candidates, need)
    _axes_by_unit(table, found, candidates)
    _gforce(table, found, candidates)
    for std, key in candidates.items():
        found[std] = (key, table.data[key])
    _unreadable_triad(table, found)
    # a file holding one samples × 3 matrix named like a triad ("acc", "gyro")
    if table.table is not None and not (set(found) & {"acc", "gyro", "ax", "gx"}):
        hit = ALIASES.get(normalize_name(table.table)[0])
        if hit and hit[0] in _COMPONENTS and table.table_array.shape[1] == 3:
            found[hit[0]] = (table.table, table.table_array)
    used = {name for name, _ in found.values()}
    _negate(table, found, negated, what)
    part = _Part(path=Path(path), table=table, n=0, used=used)
    lengths: dict[str, int] = {}
    for std, (name, arr) in found.items():
        if std not in ("acc", "gyro") and arr.ndim != 1:
            raise OptinavError(
                f"{part.path.name}: {std!r} must be one column but {name!r} has shape {arr.shape}",
                f"map {std} to a single column/vector",
            )
        if std not in ("label",) and arr.dtype.kind != "f":
            raise OptinavError(
                f"{part.path.name}: {name!r} ({std}) holds text, not numbers",
                "map the standard name to a numeric column",
            )
        lengths[name] = arr.shape[0]
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"{k}: {v}" for k, v in lengths.items())
        raise OptinavError(
            f"{part.path.name}: the columns have different lengths ({shown})",
            "pass columns/arrays with one value per sample",
        )
    # a bag topic's two-sensor check (_one_source) takes each long triad in the value range's pass
    two = table.kind == "rosbag" and table.row0 == 0
    ahead = _gyro_triad_ahead(found, two)
    alternations = {}
    for kind in ("acc", "gyro"):
        comps = [c for c in _COMPONENTS[kind] if c in found]
        if comps and kind in found:
            raise OptinavError(
                f"{part.path.name}: both {found[kind][0]!r} and component columns "
                f"({', '.join(found[c][0] for c in comps)}) look like {kind}",
                f"say which with columns='{comps[0]}=...' or skip one",
            )
        if comps and len(comps) < 3:
            missing = [c for c in _COMPONENTS[kind] if c not in found]
            raise OptinavError(
                f"{part.path.name}: found {', '.join(f'{c} ({found[c][0]!r})' for c in comps)} but no "
                f"{', '.join(missing)} column (found: {table.names()})",
                f"name the missing column(s), e.g. columns='{missing[0]}=...'",
            )
        if kind in found:
            name, arr = found[kind]
            if arr.ndim != 2 or arr.shape[1] != 3:
                hint = " (transpose it)" if arr.ndim == 2 and arr.shape[0] == 3 else ""
                raise OptinavError(
                    f"{part.path.name}: {name!r} has shape {arr.shape}, expected (N, 3){hint}",
                    f"store {kind} as one row per sample, or map ax/ay/az-style columns",
                )
            tri, bounds = arr, _range(arr)
            srcs = [name]
        elif comps:
            tri, bounds, alt = (
                ahead.result() if kind == "gyro" and ahead else _triad([found[c][1] for c in _COMPONENTS[kind]], two)
            )
            if alt is not None:
                alternations[kind] = alt
            srcs = [found[c][0] for c in _COMPONENTS[kind]]
        else:
            continue
        _check_values(part.path, kind, tri, srcs, row0=table.row0, empty_ok=block, bounds=bounds)
        if bounds is not None and np.isfinite(bounds[0]) and np.isfinite(bounds[1]):
            part.finite.add(kind)
        setattr(part, kind, tri)
        part.srcs[kind] = srcs
        for s in srcs:
            unit = table.units.get(s) or normalize_name(s)[1]
            if unit:
                part.declared[kind][f"column {s!r}"] = unit
        if f"{kind}_unit" in table.meta:
            part.declared[kind]["the file's unit record"] = table.meta[f"{kind}_unit"]
    if "t" in found:
        part.t_name, part.t = found["t"]
        if part.t_name in table.meta.get("time_of_day_columns", "").split("\t"):
            table.meta["day_time"] = part.t_name
        elif "date_columns" in table.meta and part.t_name in table.meta["date_columns"].split("\t"):
            table.meta["date_time"] = part.t_name
        unit = table.units.get(part.t_name) or normalize_name(part.t_name)[1]
        if unit:
            part.declared["time"][f"column {part.t_name!r}"] = unit
        elif implied.get(part.t_name):
            part.implied["time"][f"column {part.t_name!r}"] = implied[part.t_name]
    if "time_unit" in table.meta:
        part.declared["time"]["the file's unit record"] = table.meta["time_unit"]
    if "label" in found:
        part.labels = _labels(part.path, *found["label"])
    if "sample" in found:
        s = found["sample"][1]
        part.sample = s.astype(np.int64) if np.all(np.isfinite(s)) and np.all(s == np.round(s)) else s
    part.n = next(iter(lengths.values())) if lengths else 0
    if two:
        _one_source(part, table, alternations)
    if "select" in table.meta and part.t is None and lengths:
        raise OptinavError(
            f"--topic {table.meta['select']}: {part.path.name} has no time column, so the rows kept could not be timed",
            "name the time column (--columns t=NAME) to read one sensor's rows",
        )
    if table.bad_rows.size and part.t is None:
        _lost_rows(part, table.bad_rows)
    if need is not None and "headphone" in table.meta:  # paired with another file: the phone's
        raise _headphone_refusal(part.path.name)
    if (need is not None and getattr(part, need) is None) or (part.acc is None and part.gyro is None):
        kind = {"acc": "accelerometer", "gyro": "gyroscope"}.get(need, "accelerometer or gyroscope")
        other = {"acc": "gyro", "gyro": "acc"}.get(need or "")
        if other and getattr(part, other) is not None and not mapping:
            # the pair given the wrong way round (phone apps, MetaWear: a file per sensor)
            held = "gyroscope" if other == "gyro" else "accelerometer"
            raise OptinavError(
                f"{part.path.name} has no {kind} data: it holds the {held} ({', '.join(part.srcs[other])})",
                "give the accelerometer's file first and the gyroscope's as gyro_path=GYRODATA",
            )
        names = "ax, ay, az" if need == "acc" else "gx, gy, gz" if need == "gyro" else "ax..az, gx..gz"
        bare = {n: k for n, k in table.normal_names().items() if n in ("x", "y", "z")}
        if len(bare) == 3:
            # one sensor per file, its axes named x, y, z (Sensor Logger, many phone apps): which sensor is unsaid
            pairs = ",".join(f"{{0}}{a}={bare[a]}" for a in "xyz")
            raise OptinavError(
                f"{part.path.name}: columns {', '.join(bare.values())} do not say which sensor they hold",
                f"name it: columns='{pairs.format('a')}' for an accelerometer, '{pairs.format('g')}' for a gyroscope",
            )
        raise OptinavError(
            f"{part.path.name} has no {kind} data ({names}; found: {table.names()})",
            "use standard names or aliases in the header, or pass columns='{}'{} (one name per column, '_' to skip) "
            "or std=name entries".format(*_columns_example(table)),
        )
    return part


def _negate(table: Table, found: dict, negated, what: str) -> None:
    """The columns of the standard names ``negated`` (a '-' in ``what``) read negated, named ``-NAME``, and
    listed in ``table.meta["negated"]``."""
    for std in negated:
        if std not in found:
            raise OptinavError(
                f"{what} negates {std!r}, but no column of {table.path.name} was read as {std!r}",
                f"put the '-' before the name that stands for {std}",
            )
        name, arr = found[std]
        found[std] = (f"-{name}", -arr)
        unit = table.units.get(name) or normalize_name(name)[1]
        if unit:
            table.units[f"-{name}"] = unit
    if negated:
        table.meta["negated"] = ", ".join(found[std][0] for std in negated)


#: standard errors by which every other sample's mean departure from its neighbours' must exceed, on some axis, for
#: a bag topic to hold two sensors in alternate messages (one sensor, moving or not, stays within a few: BROAD's
#: nine trials reach 4.2; two units whose biases differ by 0.05 m/s^2 or 0.003 rad/s, interleaved, 45 and more)
_ALTERNATE_Z = 20.0
#: pairs of messages needed before the check says anything
_ALTERNATE_MIN = 100


def alternation(x: np.ndarray, bounds: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """How far every other sample departs from the mean of its two neighbours, per axis: (that mean over its
    standard error, the mean itself [unit of ``x``]) of an (N, K) array; zeros when fewer than
    :data:`_ALTERNATE_MIN` pairs are finite. Two sensors in alternate rows give their bias difference there, one
    sensor (a straight trend cancels) nothing but noise. ``bounds``: a (2,) array that takes (min, max) of a
    non-empty (N, 3) ``x`` (NaN when a value is NaN), from the same pass."""
    zero = np.zeros(x.shape[1])
    if (x.shape[0] - 1) // 2 < _ALTERNATE_MIN:
        if bounds is not None:
            bounds[:] = x.min(), x.max()
        return zero, zero
    from optinav.io._bagkernels import alternation_range, alternation_sums

    mean, m2 = np.zeros(x.shape[1]), np.zeros(x.shape[1])
    x = np.ascontiguousarray(x, dtype=float)
    n = alternation_sums(x, mean, m2) if bounds is None else alternation_range(x, mean, m2, bounds)
    if n < _ALTERNATE_MIN:
        return zero, zero
    se = np.sqrt(m2 / n) / np.sqrt(n)
    return np.abs(mean) / np.where(se > 0, se, np.inf), mean


def _one_source(part: _Part, table: Table, known: dict | None = None) -> None:
    """Refuse a bag topic whose messages alternate between two sensors under one frame_id (two IMU drivers
    publishing one topic: rosbag2 keeps no publisher per message, so neither a connection nor a frame_id tells
    them apart, and read as one they were one IMU at twice the rate with exit 0). The sign: every other sample
    minus the mean of its two neighbours (a straight trend cancels) has a mean far beyond its standard error on
    some axis (:data:`_ALTERNATE_Z`), i.e. the two sensors' bias difference; one sensor's has none. ``known``:
    kind → its :func:`alternation` where already taken (:func:`_triad`)."""
    from optinav.io._pool import helper

    known = known or {}
    kinds = [(k, u, getattr(part, k)) for k, u in (("acc", "m/s^2"), ("gyro", "rad/s"))]
    kinds = [(k, u, x) for k, u, x in kinds if x is not None and x.ndim == 2]
    pool = helper() if len(kinds) == 2 and kinds[1][2].shape[0] >= _COMPILED_ROWS else None
    if pool is None or kinds[1][0] in known:
        ahead = None
    else:
        ahead = pool.submit(alternation, kinds[1][2])  # compiled, GIL released: both at once
    for i, (kind, unit, x) in enumerate(kinds):
        if kind in known:
            z, mean = known[kind]
        else:
            z, mean = ahead.result() if i == 1 and ahead is not None else alternation(x)
        j = int(np.argmax(z))
        if z[j] > _ALTERNATE_Z:
            raise OptinavError(
                f"{part.path.name}: the messages of topic {table.meta.get('topic', '?')!r} alternate between two "
                f"sensors (every other {kind} {'xyz'[j]} departs from its neighbours by {mean[j]:.3g} {unit} on "
                f"average, {z[j]:.0f} standard errors): two IMUs publish there under one frame_id, and the bag "
                "keeps no publisher per message to tell them apart",
                "record each IMU on its own topic or frame_id (then --topic TOPIC or TOPIC@FRAME picks one)",
            )


def _lost_rows(part: _Part, rows: np.ndarray) -> None:
    """Put the rows of the lines left out as unreadable back as lost samples (NaN; the label of the row before, a
    counter NaN) at
    ``rows`` (``numpy.insert`` positions), so that a rate times the rows after them as it did before."""
    for kind in ("acc", "gyro"):
        v = getattr(part, kind)
        if v is not None:
            setattr(part, kind, np.insert(np.asarray(v, dtype=float), rows, np.nan, axis=0))
    if part.labels is not None:
        part.labels = np.insert(part.labels, rows, part.labels[np.clip(rows - 1, 0, max(part.labels.size - 1, 0))])
    if part.sample is not None:
        part.sample = np.insert(np.asarray(part.sample, dtype=float), rows, np.nan)
    part.n += rows.size
    part.finite.clear()


def _labels(path: Path, name: str, arr: np.ndarray) -> np.ndarray:
    if arr.ndim != 1:
        raise OptinavError(f"{path.name}: label {name!r} has shape {arr.shape}", "store one label per sample")
    if arr.dtype.kind == "f":
        if not (np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))):
            raise OptinavError(
                f"{path.name}: label column {name!r} holds non-integer numbers",
                "use text or integer labels, or skip the column with '_'",
            )
        return arr.astype(np.int64)
    return arr.astype(str)


#: largest magnitude accepted in an accelerometer or gyroscope cell (any unit, counts included)
MAX_VALUE = 1e12


def _value_names(srcs: list[str]) -> list[str]:
    return srcs if len(srcs) == 3 else [f"{srcs[0]}[:, {j}]" for j in range(3)]


def _no_number(path: Path, kind: str, name: str) -> OptinavError:
    return OptinavError(
        f"{path.name}: the {kind} column {name!r} holds no number (all cells empty or NaN)",
        "check the column names (--columns) or fill the column",
    )


def _check_values(
    path: Path,
    kind: str,
    tri: np.ndarray,
    srcs: list[str],
    *,
    row0: int = 0,
    empty_ok: bool = False,
    bounds: tuple[float, float] | None = None,
) -> None:
    """A column without a single number (unless ``empty_ok``: a block of a streamed file), or a finite cell beyond
    :data:`MAX_VALUE` (1e308 …), is an error; NaN and inf mark missing samples (rows the calibration drops and
    counts). ``row0``: index of the first row in the file; ``bounds``: (min, max) of ``tri`` when known (NaN if
    any value is NaN)."""
    if tri.size:
        lo, hi = bounds if bounds is not None else (tri.min(), tri.max())
        if hi <= MAX_VALUE and lo >= -MAX_VALUE:  # no NaN/inf/huge cell: the usual case
            return
    names = _value_names(srcs)
    for j in range(3):
        col = tri[:, j]
        if col.size and not empty_ok and np.all(np.isnan(col)):
            raise _no_number(path, kind, names[j])
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(np.isfinite(col) & (np.abs(col) > MAX_VALUE))
        if bad.size:
            more = f" ({bad.size} such cell(s))" if not empty_ok else ""
            raise OptinavError(
                f"{path.name}: the {kind} column {names[j]!r} holds {col[bad[0]]:g} in data row "
                f"{row0 + bad[0] + 1}{more}, not a sensor reading",
                "fix or delete those rows (an empty cell or NaN marks a missing sample)",
            )


#: largest relative difference between --rate and the rate a file states that is taken as the same rate (a rate
#: refined from a clock, 99.98 for a stated 100 Hz); beyond it the two contradict
RATE_AGREE = 1e-3


def _file_rate(table: Table) -> tuple[float, str] | None:
    """The sample rate (Hz) a file states: a ``key,value`` preamble line or an HDF5 attribute (``Fs``, ``rate``,
    ``sampling_rate`` …) or a scalar NPZ/MAT variable of such a name; None when it states none."""
    if "rate" in table.meta:
        return float(table.meta["rate"]), f"the preamble line {table.meta.get('rate_key', 'rate')!r}"
    for k, v in table.meta.items():
        if normalize_name(k)[0] in RATE_KEYS:
            try:
                return float(v), f"the attribute {k!r}"
            except ValueError:
                continue
    for k, v in table.data.items():
        if normalize_name(k)[0] in RATE_KEYS and np.size(v) == 1 and np.asarray(v).dtype.kind in "iuf":
            return float(np.asarray(v).ravel()[0]), f"the variable {k!r}"
    return None


#: the keywords of :func:`read_imu`/:func:`iter_imu` that the commands' option objects (AttitudeOptions,
#: FileOptions, ApplyOptions, the allan command's arguments) carry under the same names
READ_OPTIONS = (
    "columns",
    "acc_unit",
    "gyro_unit",
    "time_unit",
    "rate_hz",
    "datasets",
    "delimiter",
    "topic",
    "gyro_path",
    "gyro_columns",
    "skip_bad_lines",
    "acc_lsb",
    "gyro_lsb",
)


def reader_options(o, **over) -> dict:
    """The keywords of :func:`read_imu`/:func:`iter_imu` from ``o``'s attributes of the same names
    (:data:`READ_OPTIONS`, those it has; an empty ``datasets`` is None), then ``over``."""
    kw = {k: getattr(o, k) for k in READ_OPTIONS if hasattr(o, k)}
    if "datasets" in kw:
        kw["datasets"] = kw["datasets"] or None
    kw.update(over)
    return kw


def read_imu(
    path,
    *,
    columns=None,
    gyro_path=None,
    gyro_columns=None,
    acc_unit: str | None = None,
    gyro_unit: str | None = None,
    time_unit: str | None = None,
    rate_hz: float | None = None,
    datasets=None,
    delimiter: str | None = None,
    topic=None,
    unit_defaults: tuple[str, str] | None = None,
    skip_bad_lines: bool = False,
    acc_lsb: float | None = None,
    gyro_lsb: float | None = None,
) -> ImuLog:
    """Read accelerometer and/or gyroscope samples into an :class:`ImuLog`.

    Units: None means what the file declares (header ``acc_x [g]``, a units row, the ``# units:`` line of
    :func:`write_imu`, NPZ/MAT/HDF5 unit records) or else m/s^2, rad/s, s; an option contradicting the file is an
    error. ``g``, ``mg`` and ``deg/s`` are converted to SI, counts kept. Names and aliases: docs/file-formats.md.

    Parameters
    ----------
    path : str or Path
        The data file (formats of :func:`optinav.io.read_table`), or a phone app's export of several sensors (its
        zip or folder, :mod:`optinav.io.phone`): its accelerometer file with its gyroscope file as ``gyro_path``.
    columns : str, sequence of str or None
        The file's columns in order (standard names ``t, ax, ay, az, gx, gy, gz, sample, label`` or aliases,
        ``_`` skips), or ``std=name`` entries (``"t=Zeit,ax=AccX"``, also ``acc=imu/acc`` for an N×3 array);
        None: recognised by alias.
    gyro_path : str, Path or None
        A second file with the gyroscope: the same rows, or its own time column (interpolated linearly onto the
        accelerometer's times; rows outside its span left out, a gap refused).
    gyro_columns : str, sequence of str or None
        ``columns`` of ``gyro_path``.
    acc_unit : str or None
        Accelerometer unit of the file: counts, g, mg or m/s^2.
    gyro_unit : str or None
        Gyroscope unit of the file: counts, deg/s or rad/s.
    time_unit : str or None
        Time unit of the file: s, ms, us or ns.
    rate_hz : float or None
        Sample rate [Hz] giving ``t = arange(N)/rate_hz`` for files without a time column (a sample counter is
        not a time).
    datasets : dict or None
        ``{std: path}`` for HDF5/MAT/NPZ (like ``std=name``).
    delimiter : str or None
        Text delimiter; None: auto-detected.
    topic : str or None
        A ROS bag's Imu topic (``"/imu"``); None: its only one (:mod:`optinav.io.rosbag`). A PX4 ULog's topic
        (``vehicle_imu@1``, or the pair ``sensor_accel,sensor_gyro``); None: ``sensor_combined``
        (:mod:`optinav.io.ulog`).

    unit_defaults : (str, str) or None
        The accelerometer and gyroscope units of a file that declares none and for which no unit is passed
        (default m/s^2 and rad/s; ``optinav apply`` passes the calibration's raw units).
    skip_bad_lines : bool
        Leave a text table's unreadable lines out (a garbled cell, too few or too many fields: a serial capture's
        corrupted line) instead of refusing the file, with a note naming them; at most 1 % of its lines. With a
        time column the rows are gone (the times keep the timing); without one they are NaN rows (lost samples)
        where they stood, so that the rate still times the rows after them.
    acc_lsb, gyro_lsb : float or None
        Datasheet sensitivities of a log in raw counts [counts per g, counts per deg/s]: its counts are read as
        m/s^2 and rad/s by them (a driver's nominal conversion, no calibration; a note says so). Either implies that
        triad's unit is counts.

    Returns
    -------
    ImuLog
        ``t`` [s], ``acc`` [m/s^2 or counts], ``gyr`` [rad/s or counts].
    """
    export = phone_export(path)
    if export is not None:  # the accelerometer and gyroscope files of a phone app's export, paired as gyro_path
        if gyro_path is not None:
            raise OptinavError(
                f"{export.path.name} is {export.what}, which holds the gyroscope ({export.gyro})",
                "drop gyro_path (--gyro): the export's gyroscope is read",
            )
        path, gyro_path = export.member(export.acc), export.member(export.gyro)
    pair = ulog_pair(path, topic, skip_bad_lines)
    if pair is not None:  # a ULog's sensor_accel and sensor_gyro, each on its own times, paired as gyro_path
        if gyro_path is not None:
            raise OptinavError(f"--topic {topic} reads the gyroscope of {Path(path).name}", "drop gyro_path (--gyro)")
        path, gyro_path = pair
    opts = _imu_options(
        acc_unit, gyro_unit, time_unit, rate_hz, gyro_path, gyro_columns, unit_defaults, acc_lsb, gyro_lsb
    )
    need = "acc" if gyro_path is not None else None
    main = _read_part(path, columns, datasets, delimiter, need, "columns", topic, skip_bad_lines)
    parts = [main]
    split = _split_sensors(main)  # several sensors' rows in one file: main cut to the accelerometer's
    if split is not None and gyro_path is None:
        parts.append(split)
    if gyro_path is not None:
        refuse_as_one_sensor(gyro_path, "--gyro")
        gpart = _read_part(gyro_path, gyro_columns, None, delimiter, "gyro", "gyro_columns", None, skip_bad_lines)
        parts.append(gpart)
        main.gyro, main.declared["gyro"] = gpart.gyro, gpart.declared["gyro"]
        gpart.acc = None
    log = _log_of(parts, *opts)
    if export is not None:
        log.source = str(export.path)
        log.notes.insert(0, export.note())
    return log


def multi_record(path, **kw) -> bool:
    """Whether ``path`` holds several sensors' rows in one file (Physics Toolbox's multi record,
    :func:`_split_sensors`), judged on its first rows: its samples are then not its rows, and a column beside the
    IMU (a magnetometer) is not on the accelerometer's rows. ``kw`` as :func:`read_imu` (without ``gyro_path``)."""
    from optinav.io.readers import _file_kind

    try:
        if _file_kind(Path(path))[0] != "text":  # the app writes CSV; a bag's or an archive's first rows cost more
            return False
    except OptinavError:
        return False  # read_imu names what is wrong with the file
    _, mapping, negated, tkw = _part_spec(
        kw.get("columns"), kw.get("datasets"), "columns", kw.get("topic"), kw.get("skip_bad_lines", False)
    )
    blocks = iter(iter_table(Path(path), delimiter=kw.get("delimiter"), chunk_rows=64, **tkw))
    try:
        first = next(blocks, None)
        part = None if first is None else _part_of(path, first, mapping, None, "columns", block=True, negated=negated)
    except OptinavError:
        return False  # read_imu names what is wrong with the file
    finally:
        blocks.close()
    return part is not None and _multi_record(part)


def sensor_logs(path, **kw) -> tuple[ImuLog, ImuLog] | None:
    """The accelerometer and the gyroscope of a file holding several sensors' rows (Physics Toolbox's multi record,
    :func:`_split_sensors`) as two logs, each on its own rows and clock: what the Allan deviation needs (either
    interpolated onto the other's times is low-passed); None for another file, of which only the first rows are
    read; a phone export's accelerometer and gyroscope files (:mod:`optinav.io.phone`) each on its own clock.
    ``kw`` as :func:`read_imu` (without ``gyro_path``)."""
    export = phone_export(path)
    skip = kw.get("skip_bad_lines", False)
    pair = ulog_pair(path, kw.get("topic"), skip)
    if pair is None and export is None and not multi_record(path, **kw):
        return None
    opts = _imu_options(
        kw.get("acc_unit"), kw.get("gyro_unit"), kw.get("time_unit"), kw.get("rate_hz"), None, None,
        kw.get("unit_defaults"), kw.get("acc_lsb"), kw.get("gyro_lsb"),
    )  # fmt: skip
    if pair is not None or export is not None:  # two files or topics, each sensor on its own clock
        if pair is not None:  # a ULog's raw accelerometer and gyroscope topics, read by their fields' names
            sources = [("acc", pair[0], None, None, None), ("gyro", pair[1], None, None, None)]
        else:
            d, topic = kw.get("delimiter"), kw.get("topic")
            sources = [
                ("acc", export.member(export.acc), kw.get("columns"), d, topic),
                ("gyro", export.member(export.gyro), None, d, topic),
            ]
        logs = []
        for need, source, columns, delimiter, topic in sources:
            part = _read_part(source, columns, None, delimiter, need, "columns", topic, skip)
            setattr(part, "gyro" if need == "acc" else "acc", None)
            logs.append(_log_of([part], *opts))
        if export is not None:
            logs[0].notes.insert(0, export.note())
        return logs[0], logs[1]
    main = _read_part(
        path, kw.get("columns"), kw.get("datasets"), kw.get("delimiter"), None, "columns", kw.get("topic"), skip
    )
    gyro = _split_sensors(main)
    if gyro is None:
        return None
    main.gyro = None
    return _log_of([main], *opts), _log_of([gyro], *opts)


#: what to do with a magnetometer (or any column read beside the IMU by its row) of a multi record
MULTI_RECORD_BESIDE = (
    "a Physics Toolbox multi record writes each row at one sensor's sample, so a column read beside the IMU row by "
    "row (--pol-columns, or --mag-columns beside a --gyro file) is not on the accelerometer's rows",
    "drop those columns (its magnetometer Bx, By, Bz is read on its own rows with --mag alone)",
)


def _scaled(x, k: float):
    """``x`` times ``k``; ``x`` itself for 1 (no copy of a long log)."""
    return x if k == 1.0 else x * k


def _si_factor(unit: str, lsb: float | None, per: str) -> float:
    """What a triad read in ``unit`` is multiplied by to be kept: SI for a physical unit, counts as they are, or
    by their sensitivity ``lsb`` (counts per ``per``: "g", "deg/s") into SI."""
    if unit == "counts":
        return factor(per) / lsb if lsb else 1.0
    return factor(unit)


def _imu_options(
    acc_unit, gyro_unit, time_unit, rate, gyro_path, gyro_columns, unit_defaults=None, acc_lsb=None, gyro_lsb=None
):
    acc_u = None if acc_unit is None else _canonical("acc", acc_unit, "acc_unit")
    gyro_u = None if gyro_unit is None else _canonical("gyro", gyro_unit, "gyro_unit")
    for lsb, name, unit, kind in ((acc_lsb, "acc_lsb", acc_u, "acc"), (gyro_lsb, "gyro_lsb", gyro_u, "gyro")):
        if lsb is None:
            continue
        check_positive(lsb, name)
        if unit not in (None, "counts"):
            raise OptinavError(
                f"{name} (--{name.replace('_', '-')}) reads {'an accelerometer' if kind == 'acc' else 'a gyroscope'} "
                f"in raw counts, not one in {unit}",
                f"drop {name} or {kind}_unit (--{kind}-unit)",
            )
    acc_u = "counts" if acc_lsb is not None else acc_u  # a sensitivity is given for counts
    gyro_u = "counts" if gyro_lsb is not None else gyro_u
    time_u = None if time_unit is None else _canonical("time", time_unit, "time_unit")
    if rate is not None:
        rate = check_positive(rate, "rate_hz")
    if gyro_columns is not None and gyro_path is None:
        raise OptinavError("gyro_columns was given without gyro_path", "pass gyro_path, or put the names in columns")
    acc_d, gyro_d = ("m/s^2", "rad/s") if unit_defaults is None else unit_defaults
    acc_d = _canonical("acc", acc_d or "m/s^2", "acc_unit")
    gyro_d = _canonical("gyro", gyro_d or "rad/s", "gyro_unit")
    return acc_u, gyro_u, time_u, rate, acc_d, gyro_d, acc_lsb, gyro_lsb


def _log_of(
    parts: list[_Part],
    acc_u,
    gyro_u,
    time_u,
    rate,
    acc_d: str = "m/s^2",
    gyro_d: str = "rad/s",
    acc_lsb: float | None = None,
    gyro_lsb: float | None = None,
    *,
    row0: int = 0,
    prev_t: float | None = None,
    block: bool = False,
) -> ImuLog:
    """The :class:`ImuLog` of the parts read (main file, optional gyro file). A block of a streamed file
    (``block``) starts at row ``row0`` after the time ``prev_t`` (s) of the previous block's last row. Counts with a
    datasheet sensitivity ``acc_lsb`` (per g) / ``gyro_lsb`` (per deg/s) are read as m/s² / rad/s."""
    notes: list[str] = []
    main = parts[0]
    given, rate = rate, _stf_rate(main, rate)
    times = []
    for p in parts:
        if p.t is not None and _coarse_clock(p, rate, time_u, notes, first=row0 == 0):
            p.t = None  # --rate times the samples, the stamps agreeing with it
        if p.t is not None:
            if rate is not None:
                raise OptinavError(
                    f"{p.path.name} has a time column ({p.t_name!r}) and rate_hz={rate:g} was given too",
                    "drop the rate, or skip the time column with '_' in columns",
                )
            unit = _resolve_unit("time", time_u, p, "time_unit", "s")
            times.append((p, p.t if TIME_UNITS[unit] == 1.0 else p.t * TIME_UNITS[unit]))
    if len(times) == 2 and prev_t is None:
        # each file's clock on its own before they are merged: a gyro file timed in ms beside an accelerometer's
        # in s overlapped it for its first 0.1 s and was interpolated as a constant ('the gyroscope is at its full
        # scale in 324 samples of the section y_rot', exit 2, the clock unnamed)
        steps = [float(np.median(np.diff(t[:65537]))) for _, t in times if t.size > 1]
        # (a median step of 0, every sample written twice, is refused as duplicates just below, not divided by)
        plausible = [m <= 0.0 or _RATE_RANGE[0] * m <= 1.0 for m in steps]
        for k, (p, t) in enumerate(times):
            what = f"time column {p.t_name!r} of {p.path.name}"
            _check_time_unit(
                check_timestamps(t, what, min_count=2, duplicate_remedy=_duplicate_remedy(p.table)),
                what,
                defaulted=time_u is None and not p.declared["time"] and not p.implied["time"],
                own=("--columns", "--gyro-columns")[k] if any(plausible) else None,
            )
    if len(times) == 2 and not _same_times(*times):
        if block:
            _check_same_time(*times)  # a block of a streamed log is not interpolated: the error names the rows
        times = [_gyro_onto_acc_times(main, *times, notes)]
        parts[1].n = main.n
    if len(parts) == 2 and parts[0].n != parts[1].n:
        raise OptinavError(
            f"{parts[0].path.name} has {parts[0].n} rows but {parts[1].path.name} has {parts[1].n}",
            "the accelerometer and gyroscope files must hold the same samples (or both a time column)",
        )
    if times:
        p, t = times[0]
        what = f"time column {p.t_name!r} of {p.path.name}"
        if prev_t is None:
            remedy = _duplicate_remedy(p.table)
            t = check_timestamps(t, what, min_count=1 if block else 2, duplicate_remedy=remedy)
            _check_time_unit(t, what, defaulted=time_u is None and not p.declared["time"] and not p.implied["time"])
            stated = _file_rate(main.table)
            if stated is not None and t.size > 1:
                # a preamble rate that the time column contradicts was passed over in silence (probe)
                steps = float(np.median(np.diff(t[: min(t.size, 65537)])))
                if steps > 0 and not abs(stated[0] * steps - 1.0) <= 0.01:
                    notes.append(
                        f"{main.path.name} states {stated[0]:g} Hz in {stated[1]} but its time column {p.t_name!r} steps at "
                        f"{1.0 / steps:.6g} Hz: the time column is used"
                    )
        else:
            if "stf_tick" in main.table.meta and t.size and t[0] <= prev_t:
                t = _stf_block_wrap(t, prev_t, _STF_TICKS[main.table.meta["stf_tick"]])
            check_timestamps(
                np.concatenate([[prev_t], t]),
                what,
                min_count=1,
                index0=row0 - 1,
                duplicate_remedy=_duplicate_remedy(p.table),
            )
    elif rate is None and _file_rate(main.table) is None:
        if "xsens_per_period" in main.table.meta:
            raise OptinavError(
                f"{main.path.name}: Xsens' increments (dq_*, dv[*]) are per output period, and neither the export "
                "nor a time column (SampleTimeFine) states the period",
                "pass --rate HZ (the output rate), or export Acc_* and Gyr_*",
            )
        raise OptinavError(
            f"{main.path.name} has no time column (found: {main.table.names()})",
            "pass --rate HZ (the sampling rate) or name the time column (t, time, timestamp, …)",
        )
    else:
        stated = _file_rate(main.table)
        if rate is None:
            rate, where = stated
            rate = check_positive(rate, f"the sample rate in {where} of {main.path.name}")
            if row0 == 0:
                notes.append(f"sample rate {rate:g} Hz from {where} of {main.path.name}")
        elif stated is not None and not abs(stated[0] - rate) <= RATE_AGREE * abs(rate):
            # --rate 50 for a file stating 100 Hz was taken as it stood: a gyro in counts came out 2× off with
            # exit 0 (probe); a time column beside --rate is refused alike
            raise OptinavError(
                f"{main.path.name} states {stated[0]:g} Hz in {stated[1]} but --rate {rate:g} was given",
                "drop --rate to use the file's rate, or correct the file",
            )
        t = (np.arange(main.n) + row0) / rate if row0 else np.arange(main.n) / rate
        if not block:
            check_timestamps(t, f"{main.path.name}")
    if "xsens_per_period" in main.table.meta:
        _per_period(main, given, t, block, notes)
    acc = gyro = None
    acc_in = gyro_in = None
    if main.acc is not None:
        acc_in = _resolve_unit("acc", acc_u, main, "acc_unit", acc_d, notes if row0 == 0 else [])
        acc = _scaled(main.acc, _si_factor(acc_in, acc_lsb, "g"))
        if acc_in == "counts" and acc_lsb and row0 == 0:
            notes.append(
                f"accelerometer counts read as m/s^2 by {acc_lsb:g} per g (a nominal sensitivity, no calibration)"
            )
    if main.gyro is not None:
        gpart = parts[-1]
        gyro_in = _resolve_unit(
            "gyro", gyro_u, gpart if len(parts) == 2 else main, "gyro_unit", gyro_d, notes if row0 == 0 else []
        )
        k = _si_factor(gyro_in, gyro_lsb, "deg/s")
        if gyro_in == "counts" and gyro_lsb and row0 == 0:
            notes.append(
                f"gyroscope counts read as rad/s by {gyro_lsb:g} per deg/s (a nominal sensitivity, no calibration)"
            )
        gyro = _scaled(main.gyro, k)
        if main.gyro_clock is not None:
            tg, own = main.gyro_clock
            main.gyro_clock = (tg, _scaled(own, k))
    log = ImuLog(
        t=t,
        acc=acc,
        gyr=gyro,
        acc_unit="counts" if acc_in == "counts" and not acc_lsb else "m/s^2",
        gyro_unit="counts" if gyro_in == "counts" and not gyro_lsb else "rad/s",
        source=" + ".join(dict.fromkeys(str(p.path) for p in parts)),
        n_rows_read=main.n,
        labels=main.labels,
        sample=main.sample,
        row=main.row,
        acc_input_unit=acc_in,
        gyro_input_unit=gyro_in,
        notes=notes,
    )
    if main.gyro_clock is not None:
        log.gyr_clock = main.gyro_clock
    for p in parts:
        if row0 == 0:  # what a reader assumed about the file, once: the first block's notes
            notes.extend(
                f"{p.path.name}: {note.format(v=p.table.meta[key], n=len(p.table.data))}"
                for key, note in _LAYOUT_NOTES.items()
                if key in p.table.meta
            )
        if p.table.bad_lines:
            from optinav.io.readers import _bad_shown

            bad = list(zip(p.table.bad_rows.tolist(), p.table.bad_lines))
            kept = (
                "left out (the time column keeps the timing)"
                if p.t is not None
                else "read as lost samples (NaN rows) where they stood, so that the rate times the rows after them"
            )
            notes.append(f"{p.path.name}: {len(bad)} unreadable {_bad_shown(bad)} {kept}")
        if "truncated_line" in p.table.meta:
            notes.append(
                f"{p.path.name}: the last line ({p.table.meta['truncated_line']}) is incomplete and was left out"
            )
    # no row to count when the interleave's range showed every value finite (a unit factor keeps them so)
    known = all(kind in main.finite for kind, v in (("acc", main.acc), ("gyro", main.gyro)) if v is not None)
    log.nan_rows = 0 if known else int(np.count_nonzero(~log.finite))
    return log


#: the first samples whose steps tell a clock coarser than the samples (:func:`_coarse_clock`)
_COARSE_HEAD = 4097


def _coarse_clock(p: _Part, rate: float | None, time_u, notes: list, *, first: bool) -> bool:
    """Whether ``p``'s time column is a clock coarser than its samples (most of its steps zero: a GPS
    time of day to the second in a 100 Hz log), which ``rate`` (Hz) then times instead, named in ``notes`` (when
    ``first``: the first block of a file). Refused without a rate, or when the rate contradicts the stamps: the
    samples between the first and the last change of stamp over the time between them give its rate. Told from
    the first :data:`_COARSE_HEAD` samples."""
    head = p.t[:_COARSE_HEAD]
    step = np.diff(head[np.isfinite(head)])
    if step.size < 2 or 2 * np.count_nonzero(step == 0) <= step.size:
        # a later block of a file whose first block's clock was set aside for the rate (a time column beside a
        # rate is refused otherwise) is timed alike
        return not first and rate is not None
    t = p.t[np.isfinite(p.t)]
    step = np.diff(t)
    unit = TIME_UNITS[_resolve_unit("time", time_u, p, "time_unit", "s")]
    moved = np.flatnonzero(step != 0) + 1  # the first sample of each new stamp
    res = float(np.median(step[step != 0])) * unit if moved.size else float("nan")
    clock = None
    if moved.size >= 2 and t[moved[-1]] > t[moved[0]]:
        clock = (moved[-1] - moved[0]) / ((t[moved[-1]] - t[moved[0]]) * unit)
    what = f"{p.path.name}: its time column {p.t_name!r}"
    held = f"steps of {res:.3g} s" if np.isfinite(res) else "one stamp"
    each = (moved[-1] - moved[0]) / (moved.size - 1) if moved.size >= 2 else t.size
    shared = f"{each:.0f} samples a stamp"
    if rate is None:
        raise OptinavError(
            f"{what} is a clock coarser than the samples ({held}, about {shared}), which it cannot time",
            "pass --rate HZ (the sampling rate"
            + (f"; its stamps say about {clock:.4g} Hz)" if clock is not None else ")")
            + ", the column is then set aside",
        )
    if clock is not None:
        tol = max(RATE_AGREE, 2.0 / (moved[-1] - moved[0]))  # a change of stamp is placed to a sample
        if not abs(rate / clock - 1.0) <= tol:
            raise OptinavError(
                f"{what} ({held}) says {clock:.6g} Hz but --rate {rate:g} was given (or the log lost samples, "
                "which a clock this coarse cannot place)",
                f"pass the rate the stamps say (--rate {clock:.6g}) if the sensor samples at it; lost samples "
                "need a finer time column",
            )
    for key in ("day_time", "date_time"):  # (not the time: no note that it was read as one)
        p.table.meta.pop(key, None)
    if first:
        agree = f"; its stamps agree, {clock:.6g} Hz" if clock is not None else ""
        notes.append(f"{what} ({held}, {shared}) set aside: --rate {rate:g} times the samples{agree}")
    return True


def _stf_rate(main: _Part, rate: float | None) -> float | None:
    """The rate to time ``main`` with when its time is Xsens' SampleTimeFine (:func:`_xsens_time`): None (the
    ticks time it, converted to s here when only ``rate`` tells their tick); a ``rate`` that fits neither tick is
    refused. Any other file: ``rate`` as given."""
    table = main.table
    if main.t is None or "stf" not in table.meta or not main.t_name.endswith(" unwrapped"):
        return rate
    key, tick = table.meta["stf"], table.meta.get("stf_tick")
    step = float(np.median(np.diff(main.t))) if main.t.size > 1 else float("nan")
    if rate is None:
        if tick is None:
            raise OptinavError(
                f"{main.path.name}: the tick of {key!r} is not known (µs on a Movella DOT, 100 µs on an MTi) and "
                "the export states no rate",
                "pass --rate HZ (the output rate), or export with its settings lines",
            )
        return None
    if tick is None:  # the rate decides the tick: its step must fit one of the two
        tick = next((k for k, f in _STF_TICKS.items() if abs(step * f * rate - 1.0) <= 0.01), None)
        if tick is not None:
            main.t = main.t * _STF_TICKS[tick]
            step *= _STF_TICKS[tick]
            table.meta["stf_tick"] = tick
    elif not abs(step * rate - 1.0) <= 0.01:
        tick = None
    if tick is None:
        raise OptinavError(
            f"{main.path.name}: rate_hz={rate:g} contradicts its time column {key!r}, which steps "
            + (f"{step:.6g} s ({1.0 / step:.6g} Hz)" if "stf_tick" in table.meta else f"{step:.6g} ticks")
            + (" (µs on a Movella DOT, 100 µs on an MTi)" if "stf_tick" not in table.meta else ""),
            "drop the rate (the time column times the samples), or skip the time column with '_' in columns",
        )
    return None


def _stf_block_wrap(t: np.ndarray, prev_t: float, tick: float) -> np.ndarray:
    """``t`` (s) of a block of SampleTimeFine whose counter wrapped since the previous block's last time ``prev_t``
    (s): the wrap (:data:`_STF_WRAPS` ticks) that puts its first sample nearest one step after ``prev_t``."""
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    wraps = [w * tick * np.ceil((prev_t - t[0]) / (w * tick) + 1e-12) for w in _STF_WRAPS]
    return t + min(wraps, key=lambda w: abs(t[0] + w - prev_t - step))


def _per_period(main: _Part, rate: float | None, t: np.ndarray, block: bool, notes: list) -> None:
    """Xsens' increments read per output period (:func:`_xsens_sdi` without a stated rate) as rates: times the
    rate given, else one over the median step of the time column."""
    if rate is None:
        d = np.diff(t)
        d = d[d < 1.5 * np.median(d)] if d.size else d  # the mean step (ticks rounded to µs), lost samples left out
        rate = 1.0 / float(np.mean(d)) if d.size else float("nan")
        where = f"the step of its time column {main.table.meta.get('stf', main.t_name)!r}"
    else:
        where = "the rate given"
    if not np.isfinite(rate):
        raise OptinavError(
            f"{main.path.name}: Xsens' increments (dq_*, dv[*]) are per output period, and one row does not time it",
            "pass --rate HZ (the output rate), or export Acc_* and Gyr_*",
        )
    for kind in ("acc", "gyro"):
        if getattr(main, kind) is not None:
            setattr(main, kind, getattr(main, kind) * rate)
    if not block or t.size and main.table.row0 == 0:
        notes.append(f"{main.path.name}: {_LAYOUT_NOTES['xsens_sdi'].format(v=f'{rate:.6g}')} ({where})")


#: notes of what a reader assumed about a file (the key its Table's ``meta`` holds when it did): ``{v}`` the value
#: there, ``{n}`` the number of columns read
_LAYOUT_NOTES = {
    "decimal_comma": "decimal commas read as decimal points (',' is not its delimiter)",
    "monitor_stamps": "the serial monitor's receive times ('14:23:01.123 -> ') were cut off",
    "banner_lines": "{v} were left out",
    "one_sensor_layout": "no header; its {n} columns read as {v} (one sensor per file, as imu_tk's data; name them "
    "with --columns/--gyro-columns if not)",
    "coremotion": "Core Motion's acceleration is minus the specific force: read as {v}",
    "negated": "read negated as the columns option asks: {v}",
    "ulog_topic": "PX4 topic {v} read (pyulog)",
    "px4_acc_invalid": "{v} rows whose accelerometer_timestamp_relative is PX4's RELATIVE_TIMESTAMP_INVALID (their "
    "accelerometer values invalid) read as NaN",
    "ulog_damaged": "damaged, read as pyulog recovers it (--skip-bad-lines): {v}; messages after the damage may be "
    "lost, and a gap they leave is checked as any gap",
    "kitti_oxts": "KITTI's oxts folder read: times from timestamps.txt (taken as UTC), ax..az and wx..wz in the "
    "vehicle's axes (x forward, y left, z up; --frame ENU), one sample per data/ file",
    "date_time": "its date-times {v!r} read as the time (s since 1970-01-01 UTC; a stamp without a UTC offset is "
    "taken as UTC)",
    "chip_time": "WitMotion's {v}",
    "date_and_time": "its dates and times of day, two fields a row, read as one column of date-times {v!r}",
    "undated": "the dates of {v} do not tell the day from the month (neither field is above 12 in its first rows): "
    "only their times of day are read",
    "day_time": "its times of day {v!r} read as the time (s since the midnight before its first row; a step back "
    "of more than 12 h read as the next day)",
    "stf_tick": "Xsens' SampleTimeFine read as the time, in ticks of {v} (its 32-bit wraps unwrapped)",
    "shimmer_passed": "Shimmer's low-noise accelerometer (Accel_LN) read; the wide-range one ({v} …) was passed "
    "over (map it with --columns ax=…,ay=…,az=…)",
    "xsens_sdi": "Xsens' increments dq_*/dv[*] read as the mean rate and specific force of each 1/{v}-s period",
    "vectornav": "VectorNav ${v} sentences read by their fields (checksums held)",
    "ronin": "RoNIN's synced/time, synced/acce and synced/gyro read (raw/ left aside)",
    "hyperimu_zeros": "HyperIMU's first row, zeros written before the sensors gave a value, left out",
    "wrist_motion": "Sensor Logger's WristMotion read: rotationRate as the gyroscope, acceleration + gravity as "
    "the accelerometer, in {v}",
    "sensor_logger": "Sensor Logger's file read by its name as the {v} (its columns z, y, x are the axes)",
    "gravity_free": "{v} (the phone's linear acceleration, gravity taken out) passed over for the accelerometer",
    "headphone": "Sensor Logger's headphone motion read as its own IMU: rotationRate the gyroscope (rad/s); its "
    "acceleration (gravity taken out) and gravity passed over, no accelerometer",
    "multi_record": "Physics Toolbox's multi record (each row one sensor's sample, the others' cells blank or "
    "repeated): the accelerometer read on {v}",
    "long_log": "one row per sensor sample, {v}",
    "text_left_out": "column(s) {v} hold text and were left out (map one with label=NAME in columns if it names "
    "the poses)",
}


#: sample rates (Hz) an IMU log can have: a time column read as seconds because nothing states its unit, whose
#: median step gives a rate below the first, is as likely in ms (a logger's millis() at 1 kHz reads as 1 Hz, a
#: 4 kHz log's 0.25 ms steps as 4 Hz), µs or ns, so its unit must be stated; one whose stated unit gives a rate
#: above the second is misstated
_RATE_RANGE = (10.0, 1e7)


def _check_time_unit(t: np.ndarray, what: str, *, defaulted: bool, own: str | None = None) -> None:
    """Refuse times whose median step (over the first 65 536) gives an implausible IMU rate (:data:`_RATE_RANGE`);
    below the range only when the unit was not stated (``--time-unit s`` accepts a slow log). ``own``: the option
    naming this file's columns, for one of two files whose other clock is right (``--time-unit`` sets both)."""
    if t.size < 2:
        return
    step = float(np.median(np.diff(t[:65537])))
    rate = 1.0 / step
    low, high = _RATE_RANGE
    low *= 1 - 1e-9  # a 10 Hz log's steps written as decimals (0.1, 0.2, …) have a median step a hair over 0.1
    if low <= rate <= high or (rate < low and not defaulted):
        return
    fits = [u for u, f in TIME_UNITS.items() if f != 1.0 and low <= 1.0 / (step * f) <= 1e5] if defaulted else []
    hint = f"pass --time-unit {'|'.join(fits)}" if fits else "pass the right --time-unit (s, ms, us, ns)"
    if own is not None and fits:
        # --time-unit sets both files' unit, and the other file's clock is right
        hint = f"name its time column with the unit in {own} (t_{fits[0]} in its place, the other names as they are)"
    elif rate < low:
        hint += " (or --time-unit s if that rate is right)"
    read = "read as seconds (no unit stated)" if defaulted else "in its stated unit"
    raise OptinavError(f"{what} steps {step:.3g} s {read}: a {rate:.3g} Hz IMU log", hint)


def iter_imu(
    path,
    *,
    columns=None,
    gyro_path=None,
    gyro_columns=None,
    acc_unit: str | None = None,
    gyro_unit: str | None = None,
    time_unit: str | None = None,
    rate_hz: float | None = None,
    datasets=None,
    delimiter: str | None = None,
    chunk_rows: int = CHUNK_ROWS,
    topic=None,
    unit_defaults: tuple[str, str] | None = None,
    skip_bad_lines: bool = False,
    acc_lsb: float | None = None,
    gyro_lsb: float | None = None,
) -> "ImuChunks":
    """:func:`read_imu` in blocks of at most ``chunk_rows`` samples.

    The blocks' concatenation equals what :func:`read_imu` returns (same values, units, checks and notes: the rate
    note on the first block, the incomplete-last-line note on the last). Text, NPY, NPZ, HDF5, MATLAB v7.3 and
    Parquet files are read block by block (:func:`optinav.io.iter_table`), so memory does not grow with their
    length; MATLAB v4 files, ROS bags, a separate ``gyro_path`` and a file whose time or sensor arrays are not
    all of one length are read whole and then cut.

    Parameters
    ----------
    path, columns, gyro_path, gyro_columns, acc_unit, gyro_unit, time_unit, datasets, delimiter, topic, unit_defaults
    acc_lsb, gyro_lsb
        As :func:`read_imu`.
    skip_bad_lines : bool
        As :func:`read_imu`; each block notes its own lines left out.
    rate_hz : float or None
        Sample rate [Hz] for files without a time column, as :func:`read_imu`.
    chunk_rows : int
        Samples per block.

    Returns
    -------
    ImuChunks
        An iterable of :class:`ImuLog`.
    """
    return ImuChunks(
        path,
        columns=columns,
        gyro_path=gyro_path,
        gyro_columns=gyro_columns,
        acc_unit=acc_unit,
        gyro_unit=gyro_unit,
        time_unit=time_unit,
        rate_hz=rate_hz,
        datasets=datasets,
        delimiter=delimiter,
        chunk_rows=chunk_rows,
        topic=topic,
        unit_defaults=unit_defaults,
        skip_bad_lines=skip_bad_lines,
        acc_lsb=acc_lsb,
        gyro_lsb=gyro_lsb,
    )


class _WholeRead:
    """What :class:`ImuChunks` knows of a source read whole by :func:`read_imu` (a phone export): its size."""

    blockwise = False

    def __init__(self, size: int):
        self.size, self.position = size, 0


class ImuChunks:
    """The blocks of :func:`iter_imu`; ``size``/``position`` (bytes of the file, read so far) tell the progress
    and ``rows`` the samples yielded so far."""

    def __init__(self, path, *, chunk_rows: int | None = None, **kw):
        self.path, self.kw = Path(path), kw
        self.opts = _imu_options(
            kw["acc_unit"],
            kw["gyro_unit"],
            kw["time_unit"],
            kw["rate_hz"],
            kw["gyro_path"],
            kw["gyro_columns"],
            kw.get("unit_defaults"),
            kw.get("acc_lsb"),
            kw.get("gyro_lsb"),
        )
        _, self.mapping, self.negated, tkw = _part_spec(
            kw["columns"], kw["datasets"], "columns", kw.get("topic"), kw.get("skip_bad_lines", False)
        )
        self.chunk_rows = CHUNK_ROWS if chunk_rows is None else int(chunk_rows)
        export = phone_export(self.path)
        if export is not None:  # a phone export: its files read whole and paired (read_imu), then cut
            self.tables = _WholeRead(export.size)
        else:
            self.tables = iter_table(self.path, delimiter=kw["delimiter"], chunk_rows=self.chunk_rows, **tkw)
        self.size, self.rows = self.tables.size, 0
        #: the raw table of the block last yielded (None for files read whole): its other columns
        self.table = None

    @property
    def position(self) -> int:
        return self.tables.position

    def _whole(self):
        log = read_imu(self.path, **self.kw)
        self.tables.position = self.size
        yield from self._pieces(log)

    def _pieces(self, log: ImuLog):
        """``log`` in pieces of at most ``chunk_rows`` samples (its notes with the first)."""
        if len(log) <= self.chunk_rows:
            self.rows += len(log)
            yield log
            return
        for a in range(0, len(log), self.chunk_rows):
            part = log.select(slice(a, a + self.chunk_rows))
            part.notes = list(log.notes) if a == 0 else []
            self.rows += len(part)
            yield part

    def __iter__(self):
        if not self.tables.blockwise or self.kw["gyro_path"] is not None:
            yield from self._whole()
            return
        prev_t = None
        seen: dict[str, np.ndarray] = {}  # kind → which components held a number so far
        part = None
        tables = iter(self.tables)
        for table in tables:
            try:
                part = _part_of(self.path, table, self.mapping, None, "columns", block=True, negated=self.negated)
            except OptinavError:
                if not (table.row0 == 0 and table.fixed):
                    raise
                part = None
            if table.row0 == 0 and part is not None and _multi_record(part):
                # several sensors' rows in one file: each sensor's rows found over the whole file (read_imu)
                tables.close()
                yield from self._whole()
                return
            if table.row0 == 0 and table.fixed and (part is None or part.used & table.fixed):
                # an array taken is not of the samples' length: read whole (read_imu's result or error)
                tables.close()
                yield from self._whole()
                return
            log = _log_of([part], *self.opts, row0=table.row0, prev_t=prev_t, block=True)
            for kind in ("acc", "gyro"):
                v = getattr(part, kind)
                if v is not None:
                    seen[kind] = seen.get(kind, np.zeros(3, bool)) | ~np.all(np.isnan(v), axis=0)
            prev_t = float(log.t[-1])
            # a file that came whole (a bag the scanners do not read, MATLAB v4) is cut: its table is not the
            # pieces' (None, as for the files read whole)
            self.table = table if len(log) <= self.chunk_rows else None
            yield from self._pieces(log)
        for kind, ok in seen.items():
            if not ok.all():
                raise _no_number(self.path, kind, _value_names(part.srcs[kind])[int(np.argmin(ok))])
        if self.rows < 2:
            what = f"time column {part.t_name!r} of {self.path.name}" if part.t is not None else f"{self.path.name}"
            raise OptinavError(f"{what} has {self.rows} sample(s), at least 2 are needed", "record a longer log")


def _times_differ(ta: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """The samples whose times (s, same shape) differ beyond 1e-12 relative (equal or NaN in both: the same)."""
    with np.errstate(invalid="ignore"):
        return ~(np.abs(ta - tb) <= 1e-12 * np.maximum(1.0, np.abs(ta))) & ~((ta == tb) | (np.isnan(ta) & np.isnan(tb)))


def _same_times(a, b) -> bool:
    """Whether two parts' times (part, s) are the same samples (:func:`_times_differ` nowhere)."""
    return a[1].shape == b[1].shape and not np.any(_times_differ(a[1], b[1]))


#: a gyroscope step longer than this many median steps (the longer of the two files') is a gap the interpolation
#: onto the accelerometer's times does not bridge
GYRO_GAP_STEPS = 5.0


def _gyro_onto_acc_times(main: _Part, a: tuple, g: tuple, notes: list) -> tuple:
    """The gyroscope of a second file with its own time stamps (phones and apps log each sensor on its own:
    Sensor Logger, phyphox) interpolated linearly onto the accelerometer's: the rows of ``main`` outside the
    gyroscope's span are left out, a gap in the gyroscope is refused, ``notes`` say what was done. Returns the
    accelerometer's (part, times s) kept."""
    (pa, ta), (pg, tg) = a, g
    ta = check_timestamps(
        ta, f"time column {pa.t_name!r} of {pa.path.name}", duplicate_remedy=_duplicate_remedy(pa.table)
    )
    tg = check_timestamps(
        tg, f"time column {pg.t_name!r} of {pg.path.name}", duplicate_remedy=_duplicate_remedy(pg.table)
    )
    lo, hi = max(ta[0], tg[0]), min(ta[-1], tg[-1])
    keep = (ta >= lo) & (ta <= hi)
    if np.count_nonzero(keep) < 2:
        raise OptinavError(
            f"the times of {pa.path.name} ({ta[0]:.6g}–{ta[-1]:.6g} s) and {pg.path.name} ({tg[0]:.6g}–{tg[-1]:.6g} s) "
            "do not overlap",
            "pass the accelerometer and gyroscope files of one recording, their times on one clock",
        )
    step = max(float(np.median(np.diff(ta))), float(np.median(np.diff(tg))))
    i0, i1 = int(np.searchsorted(tg, lo, "right")) - 1, int(np.searchsorted(tg, hi, "left")) + 1
    d = np.diff(tg[max(i0, 0) : i1])
    paused = 0
    for k in max(i0, 0) + np.flatnonzero(d > GYRO_GAP_STEPS * step):
        a, b = np.searchsorted(ta, [tg[k], tg[k + 1]], side="right")
        inside = ta[a:b][ta[a:b] < tg[k + 1]]
        # both sensors paused (phyphox's pause, a logger's hiccup): the accelerometer's rows in the gyroscope's
        # gap are only those at its edges, left out; the accelerometer's own gap is then judged as any log's
        edge = GYRO_GAP_STEPS * step
        if inside.size and np.any((inside > tg[k] + edge) & (inside < tg[k + 1] - edge)):
            raise OptinavError(
                f"{pg.path.name}: the gyroscope has no sample from t = {tg[k]:.6g} s to {tg[k + 1]:.6g} s, within "
                f"the accelerometer's times: interpolating it onto them would invent {tg[k + 1] - tg[k]:.3g} s of "
                "rates",
                "cut the recording at the gap, or pass files holding the same samples",
            )
        keep[a : a + inside.size] = False
        paused += inside.size
    gyro = np.asarray(main.gyro, float)
    main.gyro_clock = (tg, gyro)
    main.gyro = np.column_stack([np.interp(ta[keep], tg, gyro[:, j]) for j in range(gyro.shape[1])])
    for name in ("acc", "labels", "sample"):
        v = getattr(main, name)
        if v is not None:
            setattr(main, name, v[keep])
    if not keep.all():
        # sample indices count the file's rows: with 10 leading rows left out imucal's section list pointed 10 rows
        # late (gyro K_zz 1.1 % off, 68 std, exit 0)
        main.row = np.flatnonzero(keep) if main.row is None else main.row[keep]
    n = int(np.count_nonzero(keep))
    dropped = main.n - n
    main.n = n
    main.finite.discard("gyro")
    notes.append(
        f"the gyroscope of {pg.path.name} ({tg.size} samples, {1.0 / float(np.median(np.diff(tg))):.4g} Hz) was "
        f"interpolated onto the time stamps of {pa.path.name} ({1.0 / float(np.median(np.diff(ta))):.4g} Hz)"
        + (
            f"; {dropped - paused} accelerometer rows outside the gyroscope's span were left out"
            if dropped > paused
            else ""
        )
        + (f"; {paused} at the edges of a pause of both sensors, where the gyroscope has no sample" if paused else "")
    )
    return pa, ta[keep]


#: a magnetometer whose median step is longer than this many of the IMU's is slower than it (phones' nominal rates
#: jitter by a few per cent): each of its samples goes on one IMU row, else it is interpolated onto the IMU's times
MAG_SLOWER = 1.1
#: a magnetometer whose median step is longer than this many of the IMU's is on another time unit (a ms column
#: read as s is 1000 times its rate ratio; a phone's or autopilot's magnetometer runs at 1/2 to 1/160 of the IMU)
MAG_CLOCK_RATIO = 500.0


@dataclass
class MagSamples:
    """A magnetometer on its own time stamps (a file of its own, a phone export's Magnetometer.csv, the magnetometer
    rows of a multi record): ``t`` (M,) [s, strictly increasing, the IMU's clock], ``mag`` (M, 3) [the file's unit,
    µT for the phone apps], ``source`` (what was read, for the notes), ``calibrated``: where the same sensor's
    calibrated field is, for a magnetometer known to carry its hard-iron offset (Sensor Logger's
    MagnetometerUncalibrated.csv, PX4's sensor_mag); empty for the others."""

    t: np.ndarray
    mag: np.ndarray
    source: str
    calibrated: str = ""

    @property
    def step(self) -> float:
        """The median step between its samples [s]."""
        return float(np.median(np.diff(self.t)))

    def slower(self, imu_step: float) -> bool:
        """Whether it is slower than the IMU (its median step more than :data:`MAG_SLOWER` of the IMU's).

        Parameters
        ----------
        imu_step : float
            The IMU's median step [s].

        Returns
        -------
        bool
            True: each sample goes on one row (:meth:`on_rows`).
        """
        return self.step > MAG_SLOWER * imu_step

    def on_rows(self, t, imu_step: float, t_before: float = -np.inf, t_after: float = np.inf) -> np.ndarray:
        """The magnetometer on the IMU's rows, NaN where it gives none (the attitude filter skips such rows and
        weighs a sample by the time since the previous one).

        No sample is invented: slower than the IMU (:meth:`slower`), each sample goes on its nearest row only,
        within ``imu_step`` of it (the nearer of two on one row wins; one in a gap of the IMU is left out); as fast
        or faster, it is interpolated linearly onto ``t`` (a faster field is smooth on the IMU's step), NaN
        outside its span and across its gaps (a step longer than :data:`GYRO_GAP_STEPS` of its median).

        Parameters
        ----------
        t : (N,) array
            The IMU rows' times [s]: a whole log, or a block of one.
        imu_step : float
            The IMU's median step [s].
        t_before, t_after : float
            The times of the rows just before and after a block [s] (a sample nearer to those is theirs);
            -inf and inf for a whole log.

        Returns
        -------
        (N, 3) ndarray
            The field on the rows [the file's unit], NaN rows without a sample.
        """
        t = np.asarray(t, float)
        out = np.full((t.size, 3), np.nan)
        if not t.size:
            return out
        if self.slower(imu_step):
            i0, i1 = np.searchsorted(self.t, [t_before, t_after])
            s, m = self.t[i0:i1], self.mag[i0:i1]
            tt = np.concatenate([[t_before], t, [t_after]])
            k = np.clip(np.searchsorted(tt, s), 1, tt.size - 1)
            j = np.where(s - tt[k - 1] <= tt[k] - s, k - 1, k)  # the nearest row (of the block with its neighbours)
            dist = np.abs(tt[j] - s)
            ok = (j >= 1) & (j <= t.size) & (dist <= imu_step)
            rows, dist, m = j[ok] - 1, dist[ok], m[ok]
            order = np.lexsort((dist, rows))
            _, first = np.unique(rows[order], return_index=True)
            pick = order[first]
            out[rows[pick]] = m[pick]
            return out
        for a in range(3):
            out[:, a] = np.interp(t, self.t, self.mag[:, a])
        k = np.clip(np.searchsorted(self.t, t, "right"), 1, self.t.size - 1)
        gap = self.t[k] - self.t[k - 1] > GYRO_GAP_STEPS * self.step
        out[(t < self.t[0]) | (t > self.t[-1]) | gap] = np.nan
        return out

    def check_clock(self, t0: float, t1: float, imu_step: float) -> None:
        """Refuse a magnetometer whose time stamps do not fit the IMU's span ``t0``..``t1`` [s]: its span covers
        under half of the IMU's while most of its samples lie outside it (another clock), or its samples are over
        :data:`MAG_CLOCK_RATIO` of the IMU's steps apart (another unit: a file's ms read as s put 1 of 1000 samples
        on a 40 s flight's rows, 9D with exit 0). An IMU log cut from the magnetometer's recording fits.

        Parameters
        ----------
        t0, t1 : float
            The IMU's first and last time [s].
        imu_step : float
            The IMU's median step [s].
        """
        cover = min(t1, float(self.t[-1])) - max(t0, float(self.t[0]))
        inside = int(np.count_nonzero((self.t >= t0 - imu_step) & (self.t <= t1 + imu_step)))
        other_clock = cover < 0.5 * (t1 - t0) and 2 * inside < self.t.size
        if other_clock or self.step > MAG_CLOCK_RATIO * imu_step:
            raise OptinavError(
                f"magnetometer of {self.source}: its time stamps ({self.t[0]:.6g} to {self.t[-1]:.6g} s, "
                f"{self.step:.3g} s apart) do not fit the IMU's ({t0:.6g} to {t1:.6g} s, {imu_step:.3g} s apart; "
                f"{inside} of its {self.t.size} samples within): another clock or another time unit",
                "put its time column on the IMU's clock in seconds or name its unit (e.g. 't (ms)'), or drop --mag",
            )

    def note(self, imu_step: float, rows: int, n: int) -> str:
        """What was done, for the attitude's notes.

        Parameters
        ----------
        imu_step : float
            The IMU's median step [s].
        rows, n : int
            The IMU rows that hold a sample, of its ``n`` rows.

        Returns
        -------
        str
            The note, with both rates.
        """
        how = (
            "each sample put on its nearest IMU row (NaN between: no sample invented)"
            if self.slower(imu_step)
            else "interpolated linearly onto the IMU's times"
        )
        return (
            f"magnetometer of {self.source}: {self.t.size} samples at {1.0 / self.step:.4g} Hz on its own time "
            f"stamps, {how}: {rows} of the {n} IMU rows ({1.0 / imu_step:.4g} Hz) hold a sample"
        )


#: name stems of a magnetometer triad (normalized, the axis letter after, with or without '_'): what ``--mag`` finds
#: without --mag-columns (``Mag X (uT)``, ``magnetometer_x``, Xsens' ``Mag_X``, ``magneticField_x``, BROAD's
#: ``imu_mag``). Not Physics Toolbox's ``Bx``: a B is as often a bias or a body axis, so that one is only suggested
MAG_STEMS = ("m", "mag", "magn", "magnetometer", "magnetic", "magnetic_field", "magneticfield", "imu_mag", "compass")


def mag_triad(found: list) -> dict | None:
    """{mx, my, mz} → the file's magnetometer columns among ``found`` by :data:`MAG_STEMS` (a unit in brackets, case
    and spaces aside, :func:`optinav.io.readers.normalize_name`); None unless exactly one stem gives all three axes
    (two triads, e.g. a calibrated and a raw magnetometer, are for --mag-columns to choose)."""
    keys = {normalize_name(c)[0]: c for c in found}
    hits = []
    for stem in MAG_STEMS:
        for sep in ("", "_"):
            cols = [keys.get(f"{stem}{sep}{a}") for a in "xyz"]
            if all(cols) and cols not in hits:
                hits.append(cols)
    if len(hits) != 1:
        return None
    return dict(zip(("mx", "my", "mz"), hits[0]))


def mag_names(mag_columns: str | None) -> tuple[list[str], np.ndarray]:
    """(the magnetometer's three column names of ``--mag-columns``, or the one name of its (N, 3) array; (3,) the
    signs of its axes [-]): a '-' before a name reads that axis negated (``mx,-my,mz``: an axis mounted flipped;
    before one array's name: the whole array)."""
    entries = [s.strip() for s in (mag_columns or "mx,my,mz").split(",")]
    names = [s[1:].strip() if s[:1] in "+-" else s for s in entries]
    if len(names) not in (1, 3) or not all(names):
        raise OptinavError(
            f"--mag-columns {mag_columns!r} needs three names or one (N×3) array",
            "write e.g. mx,my,mz, or mag for an N×3 array",
        )
    signs = [-1.0 if s[:1] == "-" else 1.0 for s in entries]
    return names, np.array(signs * 3 if len(signs) == 1 else signs)


def read_mag(
    source,
    *,
    columns=None,
    time_unit: str | None = None,
    delimiter: str | None = None,
    skip_bad_lines: bool = False,
    multi_record: bool = False,
) -> MagSamples:
    """The magnetometer of a file (or a phone export's member) with its own time column, as :class:`MagSamples`.

    Parameters
    ----------
    source : str, Path or ExportMember
        The file.
    columns : str or None
        Its magnetometer's three columns, or the name of its (N, 3) array ('-' before one reads it negated, as
        ``--mag-columns``); None: one triad by the usual names (``mx``, ``mag_x``, ``Magnetic field x (µT)``,
        ``magneticField_x`` …), else a phone app's bare ``x, y, z``, else Physics Toolbox's ``Bx, By, Bz``.
    time_unit : str or None
        The time column's unit when the file does not say it (s, ms, us, ns; default s; Sensor Logger's ``time``
        is ns).
    delimiter : str or None
        Text delimiter; None: auto-detected.
    skip_bad_lines : bool
        As :func:`read_imu`.
    multi_record : bool
        The file is Physics Toolbox's multi record (a row at each sensor's sample): only the rows that hold a new
        magnetometer sample are taken (as its accelerometer's and gyroscope's are).

    Returns
    -------
    MagSamples
        ``t`` [s], ``mag`` [the file's unit].
    """
    refuse_as_one_sensor(source, "--mag-file")
    path = source.path if isinstance(source, ExportMember) else Path(source)
    kw = {
        "delimiter": delimiter,
        "skip_bad_lines": bool(skip_bad_lines),
        "text_columns": LABEL_COLUMNS + SENSOR_COLUMNS,
    }
    table = source.load(**kw) if isinstance(source, ExportMember) else load_table(path, **kw)
    long = columns is None and _long_log(table, ("mag",))  # its rows of the magnetometer, as mx, my, mz
    found = list(table.data)
    if columns is not None:
        names, signs = mag_names(columns)
    else:
        signs = np.ones(3)
        triad = mag_triad(found)
        norm = table.normal_names()
        if triad is None and {"x", "y", "z"} <= set(norm):
            triad = {f"m{a}": norm[a] for a in "xyz"}  # a phone app's file of one sensor
        if triad is None and {"bx", "by", "bz"} <= set(norm) and multi_record:
            triad = {f"m{a}": norm[f"b{a}"] for a in "xyz"}  # Physics Toolbox: the field B
        if triad is None:
            raise OptinavError(
                f"{path.name}: no magnetometer columns found (found: {table.names()})",
                "name its three columns with --mag-columns X,Y,Z",
            )
        names = [triad[k] for k in ("mx", "my", "mz")]
    missing = [n for n in names if table.find(n) is None]
    if missing:
        raise OptinavError(
            f"{path.name} has no column named {missing[0]!r} (found: {table.names()})",
            "name the magnetometer's columns of that file with mag_columns=X,Y,Z",
        )
    mapping = {"gyro": names[0]} if len(names) == 1 else dict(zip(("gx", "gy", "gz"), names))
    part = _part_of(path, table, mapping, "gyro", "mag_columns")  # the time column found as for the IMU
    if part.t is None:
        raise OptinavError(
            f"{path.name} has no time column beside its magnetometer, which must carry its own time stamps",
            "pass a magnetometer file with a time column, or the magnetometer's columns of the IMU's file "
            "with --mag-columns",
        )
    unit = _resolve_unit("time", None if time_unit is None else _canonical("time", time_unit, "time_unit"), part,
                         "time_unit", "s")  # fmt: skip
    t = np.asarray(part.t, float) * TIME_UNITS[unit]
    mag = np.asarray(part.gyro, float) * signs
    what = f"{path.name} (columns {', '.join(names)})"
    if multi_record and not long:  # a long log's rows are the magnetometer's samples already
        rows = _sensor_rows(mag)
        if np.count_nonzero(rows) < 2:
            raise OptinavError(
                f"{path.name}: a multi record whose magnetometer holds {np.count_nonzero(rows)} sample(s)",
                "record for longer with the magnetometer switched on in the app, or drop --mag",
            )
        t, mag = t[rows], mag[rows]
        what = f"{path.name} (columns {', '.join(names)}, the rows of a new sample)"
    # its own time stamps are what puts each sample on a row: no rate or skipped time column can stand in
    t = check_timestamps(t, f"time column {part.t_name!r} of {path.name}")
    # Sensor Logger's uncalibrated field (Android's TYPE_MAGNETIC_FIELD_UNCALIBRATED) keeps its hard-iron offset
    raw = path.name.lower() == "magnetometeruncalibrated.csv"
    return MagSamples(t, mag, what, "record with the calibrated magnetometer (Magnetometer.csv)" if raw else "")


def _check_same_time(a, b) -> None:
    (pa, ta), (pb, tb) = a, b
    where = f"time columns of {pa.path.name} ({pa.t_name!r}) and {pb.path.name} ({pb.t_name!r})"
    if ta.shape != tb.shape:
        raise OptinavError(
            f"{where} differ in length: {ta.size} vs {tb.size} samples", "pass files holding the same samples"
        )
    bad = _times_differ(ta, tb)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise OptinavError(
            f"{where} differ: {int(np.count_nonzero(bad))} sample(s), first at row {i + 1}: "
            f"{float(ta[i])!r} s vs {float(tb[i])!r} s",
            "resample both files onto the same time stamps",
        )


# --- writing ------------------------------------------------------------------------------------------------

_WRITE_TEXT = {".csv": ",", ".tsv": "\t", ".txt": " ", ".dat": " "}
_WRITE_FORMATS = (*_WRITE_TEXT, ".npz", ".h5", ".hdf5", ".mat")


def _out_values(log: ImuLog, kind: str, unit: str | None) -> tuple[np.ndarray | None, str]:
    v = log.acc if kind == "acc" else log.gyr
    have = getattr(log, f"{kind}_unit")
    if unit is None:
        return v, have
    unit = _canonical(kind, unit, f"{kind}_unit")
    if v is None:
        return None, unit
    if (have == "counts") != (unit == "counts"):
        raise OptinavError(
            f"the log's {kind} is in {have} and cannot be written in {unit}",
            f"write it in {have}" + (" (calibrate it first)" if have == "counts" else ""),
        )
    return (v if unit in ("counts", have) else from_si(v, unit)), unit


def write_imu(path, log: ImuLog, *, acc_unit: str | None = None, gyro_unit: str | None = None) -> Path:
    """Write ``log`` to ``path`` atomically, so that :func:`read_imu` reads it back with the same values.

    ``.csv`` / ``.tsv`` / ``.txt`` (comma, tab, space): a comment line with the units (``# units: t=s
    acc=m/s^2 gyro=rad/s``), a header of standard names ``t,[sample,]ax,ay,az,gx,gy,gz[,label]`` and rows in the
    shortest exact form (exact round trip); ``.npz``: arrays ``t``, ``acc``, ``gyro``, ``sample``, ``labels`` and
    the strings ``acc_unit``, ``gyro_unit``, ``time_unit``; ``.h5``/``.hdf5`` (h5py): the same as datasets and
    root attributes; ``.mat`` (v5): the same as variables.

    Parameters
    ----------
    path : str or Path
        Output file; never an existing input.
    log : ImuLog
        The samples.
    acc_unit : str or None
        Accelerometer unit to write (m/s^2 or g) for an SI log; counts are written as counts.
    gyro_unit : str or None
        Gyroscope unit to write (rad/s or deg/s) for an SI log.

    Returns
    -------
    Path
        The file written.
    """
    if not isinstance(log, ImuLog):
        raise OptinavError(f"write_imu needs an ImuLog, got {type(log).__name__}", "read or build an ImuLog first")
    path = _check_out(path)
    from optinav.core.files import atomic_path

    with atomic_path(path) as tmp:
        _write_whole(tmp, log, acc_unit, gyro_unit)
    return path


def _check_out(path) -> Path:
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _WRITE_FORMATS:
        raise OptinavError(
            f"cannot write {path.name}: unknown file type {path.suffix or '(none)'}",
            f"use one of {', '.join(_WRITE_FORMATS)}",
        )
    if not path.parent.is_dir():
        raise OptinavError(f"directory {path.parent} does not exist", "create it first")
    return path


def _write_whole(tmp: Path, log: ImuLog, acc_unit, gyro_unit) -> None:
    suffix = tmp.suffix.lower()
    acc, acc_u = _out_values(log, "acc", acc_unit)
    gyro, gyro_u = _out_values(log, "gyro", gyro_unit)
    if suffix in _WRITE_TEXT:
        _write_text(tmp, log, acc, gyro, acc_u, gyro_u, _WRITE_TEXT[suffix])
    elif suffix == ".npz":
        arrays = _arrays(log, acc, gyro, acc_u, gyro_u)
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
    elif suffix == ".mat":
        import scipy.io

        arrays = _arrays(log, acc, gyro, acc_u, gyro_u)
        # column vectors as MATLAB keeps them; text labels become a char matrix (one padded row per sample)
        arrays = {k: (v.reshape(-1, 1) if v.ndim == 1 and v.dtype.kind != "U" else v) for k, v in arrays.items()}
        scipy.io.savemat(tmp, arrays, do_compression=True)
    else:
        from optinav.io.readers import _h5py

        h5py = _h5py()
        arrays = _arrays(log, acc, gyro, acc_u, gyro_u)
        with h5py.File(tmp, "w") as fh:
            for k, v in arrays.items():
                if v.ndim == 0:
                    fh.attrs[k] = str(v)
                elif v.dtype.kind == "U":
                    fh.create_dataset(k, data=v.astype(object), dtype=h5py.string_dtype())
                else:
                    fh.create_dataset(k, data=v)


def _arrays(log, acc, gyro, acc_u, gyro_u) -> dict[str, np.ndarray]:
    out = {"t": log.t}
    if acc is not None:
        out["acc"] = acc
        out["acc_unit"] = np.asarray(acc_u)
    if gyro is not None:
        out["gyro"] = gyro
        out["gyro_unit"] = np.asarray(gyro_u)
    if log.sample is not None:
        out["sample"] = np.asarray(log.sample)
    if log.labels is not None:
        lab = np.asarray(log.labels)
        out["labels"] = lab.astype(str) if lab.dtype.kind in "OSU" else lab
    out["time_unit"] = np.asarray("s")
    return out


def _text_head(log: ImuLog, acc, gyro, acc_u, gyro_u, delim: str, n: int | None) -> str:
    from optinav import __version__

    names = ["t"] + (["sample"] if log.sample is not None else []) + (["ax", "ay", "az"] if acc is not None else [])
    names += (["gx", "gy", "gz"] if gyro is not None else []) + (["label"] if log.labels is not None else [])
    units = ["t=s"] + ([f"acc={acc_u}"] if acc is not None else []) + ([f"gyro={gyro_u}"] if gyro is not None else [])
    count = f" ({n} samples)" if n is not None else ""
    head = [
        f"# optinav {__version__} IMU log{count}; source: {log.source or '-'}".replace("\n", " "),
        f"# units: {' '.join(units)}",
        delim.join(names),
    ]
    return "\n".join(head) + "\n"


def _text_columns(log: ImuLog, acc, gyro) -> list[np.ndarray]:
    cols = [log.t]
    if log.sample is not None:
        cols.append(np.asarray(log.sample, dtype=float))
    if acc is not None:
        cols += [acc[:, 0], acc[:, 1], acc[:, 2]]
    if gyro is not None:
        cols += [gyro[:, 0], gyro[:, 1], gyro[:, 2]]
    return cols


def _integral(cols: list[np.ndarray]) -> list[bool]:
    """Which columns hold only integers (counts, sample), written without ".0"."""
    return [bool(np.all(np.isfinite(c)) and np.all(c == np.round(c)) and np.all(np.abs(c) < 2**53)) for c in cols]


def _text_rows(
    path: Path, log: ImuLog, acc, gyro, delim: str, integral: list[bool] | None = None, rows: slice = slice(None)
) -> str:
    """The lines of ``rows`` of the log (``integral``: per column, default judged on those rows)."""
    cols = [c[rows] for c in _text_columns(log, acc, gyro)]
    labels = None
    if log.labels is not None:
        labels = np.asarray(log.labels)[rows]
        if labels.dtype.kind in "OSU":
            labels = labels.astype(str)
            forbidden = f'#"\n\r{delim}'
            bad = [str(x) for x in np.unique(labels) if x != x.strip() or not x or any(c in x for c in forbidden)]
            if bad:
                raise OptinavError(
                    f"label {bad[0]!r} cannot be written to a {path.suffix} file (empty, or holds the "
                    "delimiter, '#', a quote or surrounding spaces)",
                    "rename the labels or write .npz",
                )
            labels = list(labels)
        else:
            labels = [str(int(x)) for x in labels]
    # shortest repr that reads back to the same double; integer columns (counts, sample) without ".0"
    integral = _integral(cols) if integral is None else integral
    fmt = delim.join("%d" if i else "%r" for i in integral)
    table = np.column_stack(cols)
    if labels is None:
        # one % for the block, not one per row: the same text, a fifth faster (as files.csv_writer)
        return ((fmt + "\n") * table.shape[0]) % tuple(table.ravel().tolist()) if table.shape[0] else ""
    body = [f"{fmt % tuple(r)}{delim}{lab}" for r, lab in zip(table.tolist(), labels)]
    return "\n".join(body) + "\n" if body else ""


def _write_text(path: Path, log: ImuLog, acc, gyro, acc_u, gyro_u, delim: str) -> None:
    integral = _integral(_text_columns(log, acc, gyro))
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(_text_head(log, acc, gyro, acc_u, gyro_u, delim, len(log)))
        # formatted block by block: the text of a whole long log would take about 1 kB per row
        for a in range(0, len(log), CHUNK_ROWS):
            fh.write(_text_rows(path, log, acc, gyro, delim, integral, slice(a, a + CHUNK_ROWS)))


class ImuWriter:
    """Write an IMU log block by block (see :func:`open_imu_writer`): ``write(block)`` appends an
    :class:`ImuLog` whose fields (acc, gyro, sample, labels) are those of the first block."""

    def __init__(self, path: Path, tmp: Path, acc_unit, gyro_unit):
        self.path, self.tmp, self.acc_unit, self.gyro_unit = path, tmp, acc_unit, gyro_unit
        self.suffix = path.suffix.lower()
        self.rows, self._fh, self._blocks, self._kinds = 0, None, [], None

    def write(self, log: ImuLog) -> None:
        kinds = tuple(getattr(log, k) is not None for k in ("acc", "gyr", "sample", "labels"))
        if self._kinds is None:
            self._kinds = kinds
        elif kinds != self._kinds:
            raise OptinavError("the blocks of one IMU log differ in their fields", "write blocks of one log")
        self.rows += len(log)
        if self.suffix not in _WRITE_TEXT:  # binary formats hold whole arrays: gathered, written at the end
            self._blocks.append(log)
            return
        acc, acc_u = _out_values(log, "acc", self.acc_unit)
        gyro, gyro_u = _out_values(log, "gyro", self.gyro_unit)
        delim = _WRITE_TEXT[self.suffix]
        if self._fh is None:
            self._fh = open(self.tmp, "w", encoding="utf-8", newline="\n")
            self._fh.write(_text_head(log, acc, gyro, acc_u, gyro_u, delim, None))
        self._fh.write(_text_rows(self.path, log, acc, gyro, delim))

    def _close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            return
        if not self._blocks:
            raise OptinavError(f"no samples to write to {self.path}", "pass a log with samples")
        first = self._blocks[0]
        cat = lambda k: None if getattr(first, k) is None else np.concatenate([getattr(b, k) for b in self._blocks])
        log = ImuLog(
            t=cat("t"),
            acc=cat("acc"),
            gyr=cat("gyr"),
            acc_unit=first.acc_unit,
            gyro_unit=first.gyro_unit,
            source=first.source,
            labels=cat("labels"),
            sample=cat("sample"),
        )
        self._blocks = []
        _write_whole(self.tmp, log, self.acc_unit, self.gyro_unit)


@contextlib.contextmanager
def open_imu_writer(path, *, acc_unit: str | None = None, gyro_unit: str | None = None):
    """A context giving an :class:`ImuWriter` for ``path``, written atomically (nothing under ``path`` unless the
    block ends without error).

    Text formats are written block by block (memory does not grow with the log; the first comment line then holds
    no sample count), NPZ/HDF5/MAT gathered and written at the end.

    Parameters
    ----------
    path, acc_unit, gyro_unit
        As :func:`write_imu`.

    Yields
    ------
    ImuWriter
        ``write(log)`` appends an :class:`ImuLog` block.
    """
    path = _check_out(path)
    from optinav.core.files import atomic_path

    with atomic_path(path) as tmp:
        w = ImuWriter(path, tmp, acc_unit, gyro_unit)
        try:
            yield w
        finally:
            if w._fh is not None:
                w._fh.close()
        w._close()


def raw_units(log, kind: str, values=None) -> tuple[np.ndarray, str]:
    """The log's values in the file's own unit (the unit a calibration's K and b are expressed in).

    Readers convert g and deg/s to SI; a calibration is stated in the user's raw unit, so convert back.

    Parameters
    ----------
    log : ImuLog
        Samples as read.
    kind : str
        ``"acc"`` or ``"gyro"``.
    values : (M, 3) array or None
        Other samples of that triad [the log's unit] (the gyroscope's own, ``gyr_clock``); None: the log's.

    Returns
    -------
    values : (N, 3) ndarray or None
        The triad [the file's unit].
    unit : str
        That unit.
    """
    if values is None:
        values = log.acc if kind == "acc" else log.gyr
    unit = log.acc_unit if kind == "acc" else log.gyro_unit
    file_unit = (log.acc_input_unit if kind == "acc" else log.gyro_input_unit) or unit
    if file_unit == unit or values is None:
        return values, unit
    return values / factor(file_unit), file_unit
