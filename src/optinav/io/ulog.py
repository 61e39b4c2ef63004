"""PX4 flight logs (ULog, ``.ulg``) → a :class:`~optinav.io.readers.Table` of one uORB topic, read with ``pyulog``.

``pyulog`` (pure Python, ``pip install 'optinav[ulog]'``) parses the whole log; only the IMU and magnetometer
topics are kept. A topic's fields come under the names ``ulog2csv`` gives them (``gyro_rad[0]``, ``timestamp``), so
that :func:`optinav.io.imu._px4` reads a ``.ulg`` exactly as pyulog's CSV export of it (PX4's msg definitions:
``timestamp``/``timestamp_sample`` in µs since boot, body axes FRD):

- ``sensor_combined`` (the default): ``gyro_rad`` rad/s and ``accelerometer_m_s2`` m/s² at ``timestamp``;
- ``vehicle_imu``: the increments ``delta_angle`` (rad), ``delta_velocity`` (m/s) over ``delta_*_dt`` (µs) at
  ``timestamp_sample``;
- ``sensor_accel`` with ``sensor_gyro``: the raw sensors ``x, y, z`` (m/s², rad/s), each at its own
  ``timestamp_sample`` (the gyroscope interpolated onto the accelerometer's times, as a second file's);
- ``vehicle_magnetometer`` (``magnetometer_ga``) or ``sensor_mag`` (``x, y, z``), gauss, on its own times, for
  ``optinav attitude --mag`` (:func:`ulog_mag`).

``--topic`` is a comma list of such topics (``sensor_accel,sensor_gyro,sensor_mag``), each ``NAME`` or ``NAME@K``
for instance (multi_id) K of a topic logged several times; a topic logged several times and named without its
instance is refused, listing the instances.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["ULOG_SUFFIXES", "ULOG_MAGIC", "is_ulog", "load_ulog", "ulog_pair", "ulog_mag", "UlogTopic"]

ULOG_SUFFIXES = (".ulg",)
#: the first 7 bytes of every ULog file (then the version byte and the start time, uint64 µs)
ULOG_MAGIC = b"ULog\x01\x12\x35"
_INSTALL = "pip install 'optinav[ulog]'"
_EXPORT = "ulog2csv LOG.ulg (…_sensor_combined_0.csv reads as it is)"
#: role of each topic read: one table with both sensors, one sensor each, or the magnetometer
_ROLES = {
    "sensor_combined": "imu",
    "vehicle_imu": "imu",
    "sensor_accel": "acc",
    "sensor_gyro": "gyro",
    "vehicle_magnetometer": "mag",
    "sensor_mag": "mag",
}
#: the magnetometer's fields (gauss) of each magnetometer topic
_MAG_FIELDS = {"vehicle_magnetometer": [f"magnetometer_ga[{k}]" for k in range(3)], "sensor_mag": ["x", "y", "z"]}


def is_ulog(path) -> bool:
    """True for a ULog: a ``.ulg`` path, or a file that starts with :data:`ULOG_MAGIC` (a log renamed)."""
    p = Path(path)
    if p.suffix.lower() in ULOG_SUFFIXES:
        return True
    try:
        with open(p, "rb") as fh:
            return fh.read(len(ULOG_MAGIC)) == ULOG_MAGIC
    except OSError:
        return False


def _pyulog():
    try:
        from pyulog import ULog
    except ImportError:
        raise OptinavError(
            "reading PX4 ULog files needs the pyulog library, which is not installed",
            f"{_INSTALL}, or export the log's topics with {_EXPORT}",
        ) from None
    return ULog


def _parse_topic(path: Path, topic) -> dict:
    """{role: (name, multi_id or None)} of a ``--topic`` comma list (empty for None)."""
    if topic is None:
        return {}
    items = [s.strip() for s in (topic.split(",") if isinstance(topic, str) else topic)]
    out: dict = {}
    for item in items:
        name, at, ident = item.partition("@")
        role = _ROLES.get(name)
        if role is None or (at and not ident.isdigit()):
            raise OptinavError(
                f"--topic {topic!r}: {item!r} is not a PX4 IMU or magnetometer topic this reads from {path.name}",
                "name sensor_combined, vehicle_imu, sensor_accel,sensor_gyro and optionally vehicle_magnetometer or "
                "sensor_mag, each NAME or NAME@INSTANCE (e.g. vehicle_imu@1)",
            )
        if role in out:
            raise OptinavError(f"--topic {topic!r} names two {role} topics", "name one topic of each kind")
        out[role] = (name, int(ident) if at else None)
    if "imu" in out and ({"acc", "gyro"} & set(out)):
        raise OptinavError(
            f"--topic {topic!r} names {out['imu'][0]} and a raw sensor topic",
            "name either one IMU topic (sensor_combined, vehicle_imu) or sensor_accel,sensor_gyro",
        )
    if ("acc" in out) != ("gyro" in out):
        have, lack = ("sensor_accel", "sensor_gyro") if "acc" in out else ("sensor_gyro", "sensor_accel")
        raise OptinavError(
            f"--topic {topic!r} names {have} without {lack}", "name both: --topic sensor_accel,sensor_gyro"
        )
    return out


@dataclasses.dataclass
class _Log:
    """The IMU and magnetometer topics of one parsed ULog: ``data`` {(name, multi_id): {field: array}},
    ``damaged``: what pyulog reported of damage it skipped."""

    path: Path
    data: dict
    damaged: str

    def listing(self) -> str:
        names = [f"{n}@{k} ({v['timestamp'].size} msgs)" for (n, k), v in sorted(self.data.items())]
        return ", ".join(names) or "none"

    def pick(self, name: str, ident: int | None, given: bool) -> tuple[str, int]:
        """The (name, multi_id) of topic ``name`` (instance ``ident``, None: its only one); ``given``: named with
        --topic (else a default)."""
        inst = sorted(k for n, k in self.data if n == name)
        if not self.data:
            damage = f" (pyulog: {self.damaged})" if self.damaged else ""
            raise OptinavError(
                f"{self.path.name} holds no message of an IMU or magnetometer topic ({', '.join(_ROLES)}){damage}: "
                "a log cut short, damaged, or logged without them",
                "check that the log was copied whole; pyulog's ulog_info LOG.ulg lists what it holds",
            )
        if not inst:
            what = "has no topic" if given else "has no default topic"
            raise OptinavError(
                f"{self.path.name} {what} {name!r} (IMU and magnetometer topics: {self.listing()})",
                "pass one of the listed topics with --topic (NAME or NAME@INSTANCE; sensor_accel,sensor_gyro as a "
                "pair)",
            )
        if ident is None and len(inst) > 1:
            shown = ", ".join(f"{name}@{k} ({self.data[(name, k)]['timestamp'].size} msgs)" for k in inst)
            raise OptinavError(
                f"{self.path.name} logs {len(inst)} instances of {name!r} ({shown}): several sensors",
                f"pick one with --topic {name}@{inst[0]}",
            )
        if ident is not None and ident not in inst:
            raise OptinavError(
                f"{self.path.name} has no instance {ident} of {name!r} (instances: {', '.join(map(str, inst))})",
                f"pick one with --topic {name}@{inst[0]}",
            )
        return name, inst[0] if ident is None else ident


#: the last log parsed, ``[(key, topics, _Log)]``: ``attitude LOG.ulg --mag`` reads the IMU's topic, then the
#: magnetometer's, and pyulog parses the whole file each time (3.7 s per hour of a 250-Hz log, twice). Every IMU and
#: magnetometer topic is parsed at once and kept for the next read of the same, unchanged file
_LAST: list = []


def _read(path: Path, names, skip_bad: bool = False) -> _Log:
    """The topics ``names`` of the ULog ``path`` (all their instances), parsed by pyulog; one-line errors for a file
    that is not a readable ULog, and for one pyulog found damaged unless ``skip_bad`` (``--skip-bad-lines``: what
    it recovers is read, the damage in ``damaged``): it skips what it cannot read and, without a sync marker after
    the damage, everything after it (half of a log read with exit 0). The last log parsed is reused (:data:`_LAST`)."""
    if not path.exists():
        raise OptinavError(f"data file {path} does not exist", "check the path")
    try:
        st = path.stat()
        key = (str(path.resolve()), st.st_mtime_ns, st.st_size, bool(skip_bad))
    except OSError:
        key = None
    names = set(names)
    if key is not None and _LAST and _LAST[0][0] == key and names <= _LAST[0][1]:
        return _LAST[0][2]
    names |= set(_ROLES)
    _LAST.clear()  # the previous log's arrays are let go before this one is parsed
    ULog = _pyulog()
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            log = ULog(str(path), list(names), disable_str_exceptions=True)
    except Exception as exc:  # noqa: BLE001 - pyulog raises its own, struct, index and value errors on damage
        raise OptinavError(
            f"{path.name} is not a readable ULog ({' '.join(str(exc).split())[:200] or type(exc).__name__})",
            f"check that the log was copied whole; else export its topics with {_EXPORT}",
        ) from None
    data = {}
    for d in log.data_list:
        if "timestamp" in d.data:
            data[(d.name, int(d.multi_id))] = d.data
    damaged = " ".join(out.getvalue().split())[:200] if log.file_corruption else ""
    if log.file_corruption and not damaged:
        damaged = "damaged messages skipped"
    if damaged and not skip_bad:
        raise OptinavError(
            f"{path.name} is damaged: pyulog skipped messages it could not read ({damaged}), and what follows the "
            "damage may be lost with them",
            "pass --skip-bad-lines to read what pyulog recovers (a note names the damage); check that the log was "
            "copied whole",
        )
    parsed = _Log(path, data, damaged)
    if key is not None:
        _LAST.append((key, names, parsed))
    return parsed


def _table(path: Path, log: _Log, key: tuple[str, int]):
    """The Table of topic instance ``key``: every numeric field as float64 under pyulog's name, the times in µs."""
    from optinav.io.readers import Table

    fields = log.data[key]
    # copies: the parsed log is kept for the next read (_LAST), and a reader may change its table in place
    data = {k: np.array(v, dtype=np.float64) for k, v in fields.items() if np.asarray(v).dtype.kind in "iuf"}
    units = {k: "us" for k in ("timestamp", "timestamp_sample") if k in data}
    meta = {"px4_topic": key[0], "ulog_topic": f"{key[0]}@{key[1]}"}
    if log.damaged:
        meta["ulog_damaged"] = log.damaged
    return Table(path, "ulog", data, units, meta)


def load_ulog(path, *, topic=None, skip_bad_lines: bool = False):
    """The Table of the IMU topic of the ULog ``path``: ``topic`` as ``--topic`` (its IMU item), default
    ``sensor_combined`` (see the module docs); the fields under pyulog's names, read by :func:`optinav.io.read_imu`
    as pyulog's CSV export of the topic. A pair of raw sensor topics is read by :func:`ulog_pair` instead. A log
    pyulog finds damaged is refused unless ``skip_bad_lines``."""
    path = Path(path)
    wanted = _parse_topic(path, topic)
    if "acc" in wanted:
        raise OptinavError(
            f"sensor_accel and sensor_gyro of {path.name} are two topics on their own times, not one table",
            "read them with optinav.io.read_imu (or any command) and --topic sensor_accel,sensor_gyro",
        )
    name, ident = wanted.get("imu", ("sensor_combined", None))
    log = _read(path, set(_ROLES) | {name}, skip_bad_lines)
    return _table(path, log, log.pick(name, ident, "imu" in wanted))


@dataclasses.dataclass(frozen=True)
class UlogTopic:
    """One topic instance of a ULog read as a file of its own (the accelerometer or the gyroscope of a raw pair):
    ``ulog`` (the log) and ``key`` (name, multi_id)."""

    ulog: Path
    key: tuple
    log: _Log = dataclasses.field(compare=False, repr=False)

    @property
    def path(self) -> Path:
        """The topic as messages and notes name it (``LOG.ulg:sensor_gyro@0``)."""
        return self.ulog.with_name(f"{self.ulog.name}:{self.key[0]}@{self.key[1]}")

    def load(self, *, names=None, delimiter=None, **_):
        """The topic's Table (the other keywords of :func:`~optinav.io.readers.load_table` do not apply)."""
        if names is not None or delimiter is not None:
            raise OptinavError(
                f"positional columns and a delimiter apply to text files, not to the ULog {self.ulog.name}",
                "drop them (a ULog's fields are read by name)",
            )
        return _table(self.path, self.log, self.key)


def ulog_pair(path, topic, skip_bad_lines: bool = False) -> tuple[UlogTopic, UlogTopic] | None:
    """(accelerometer, gyroscope) topics of a ULog when ``topic`` names ``sensor_accel`` and ``sensor_gyro``; None
    for anything else. ``skip_bad_lines`` as :func:`load_ulog`."""
    if topic is None or not isinstance(path, str | Path) or not is_ulog(path):
        return None
    path = Path(path)
    wanted = _parse_topic(path, topic)
    if "acc" not in wanted:
        return None
    log = _read(path, {wanted["acc"][0], wanted["gyro"][0]}, skip_bad_lines)
    return tuple(UlogTopic(path, log.pick(*wanted[r], True), log) for r in ("acc", "gyro"))


def ulog_mag(path, topic=None, skip_bad_lines: bool = False):
    """The magnetometer of the ULog ``path`` on its own time stamps (:class:`optinav.io.imu.MagSamples`, gauss):
    the magnetometer topic of ``topic``, else ``vehicle_magnetometer``, else ``sensor_mag`` (its only instance).
    ``skip_bad_lines`` as :func:`load_ulog`."""
    from optinav.core.validate import check_timestamps
    from optinav.io.imu import MagSamples

    path = Path(path)
    wanted = _parse_topic(path, topic).get("mag")
    log = _read(path, set(_MAG_FIELDS), skip_bad_lines)
    if wanted is None:
        present = [n for n in _MAG_FIELDS if any(k[0] == n for k in log.data)]
        if not present:
            raise OptinavError(
                f"{path.name} logs no magnetometer (vehicle_magnetometer, sensor_mag; IMU and magnetometer topics: "
                f"{log.listing()})",
                "drop --mag (the heading then follows the gyro)",
            )
        wanted = (present[0], None)
    key = log.pick(*wanted, True)
    fields = log.data[key]
    tkey = "timestamp_sample" if "timestamp_sample" in fields else "timestamp"
    t = check_timestamps(
        np.asarray(fields[tkey], np.float64) * 1e-6, f"{tkey} of {key[0]}@{key[1]} in {path.name}", min_count=2
    )
    mag = np.column_stack([np.asarray(fields[f], np.float64) for f in _MAG_FIELDS[key[0]]])
    # sensor_mag is the sensor's own output, before CAL_MAG* (its offsets) and the board rotation
    calibrated = (
        "read the calibrated vehicle_magnetometer (--topic IMU,vehicle_magnetometer)" if key[0] == "sensor_mag" else ""
    )
    return MagSamples(t, mag, f"{path.name} (topic {key[0]}@{key[1]}, gauss)", calibrated)
