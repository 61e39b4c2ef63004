"""ROS bags → a :class:`~optinav.io.readers.Table`: ``sensor_msgs/msg/Imu`` and ``sensor_msgs/msg/MagneticField``.

ROS 1 ``.bag`` files and ROS 2 bags (a folder with ``metadata.yaml``, or a bare ``.db3``/``.mcap`` file) are read
with the ``rosbags`` library (pure Python, no ROS installation; ``pip install 'optinav[ros]'``). One Imu topic
gives the columns ``t`` (header stamp, s), ``ax ay az`` (``linear_acceleration``, m/s²) and ``gx gy gz``
(``angular_velocity``, rad/s); a MagneticField topic adds ``mx my mz`` (tesla) interpolated linearly onto the
Imu stamps. Topic choice, time base and errors: docs/file-formats.md.

The raw messages of a topic come in blocks straight from the storage (:mod:`optinav.io.bagscan`; rosbags'
iteration when the scanners do not read the bag) and are decoded from their fixed byte layout by a compiled
gather (:mod:`optinav.io._bagkernels`; checked against ``rosbags``' own deserializer on the first message) into
(n, 3) arrays; messages of another length are deserialized one by one. Plain ROS 1 bags, MCAP files and sqlite3
files are decoded whole, each chunk (or block of pages) walked and gathered in one compiled call while its bytes
are in cache, with a helper thread (batches of chunks or sqlite3 leaf pages to whichever thread is free:
:func:`_whole`, :func:`_sqlite_fused`); anything they decline
goes through the blocks. :func:`iter_bag` gives the same table in
blocks of messages (two passes over the storage), so that memory does not grow with the bag.
"""

from __future__ import annotations

import copy
import functools
import itertools
import sys
import warnings
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["BAG_SUFFIXES", "is_bag", "load_bag", "iter_bag", "IMU_TYPE", "MAG_TYPE"]

#: file suffixes of bags (ROS 1 .bag, ROS 2 storage files); a ROS 2 bag folder holds a metadata.yaml
BAG_SUFFIXES = (".bag", ".db3", ".mcap")
IMU_TYPE = "sensor_msgs/msg/Imu"
MAG_TYPE = "sensor_msgs/msg/MagneticField"
_INSTALL = "pip install 'optinav[ros]'"
#: messages decoded per numpy block (bounds the raw bytes held at once to a few MB)
_BLOCK = 16384
#: fewer bytes than the smallest serialized Imu / MagneticField message with its record header
_MIN_MSG_BYTES = 64


def is_bag(path) -> bool:
    """True for a path that names a ROS bag: a ``.bag``/``.db3``/``.mcap`` file, a folder with ``metadata.yaml``, or
    a file under another suffix that starts as a ROS 1 bag or an MCAP file does (``X.bag.active``)."""
    from optinav.io.bagrepair import bag_kind

    p = Path(path)
    if p.suffix.lower() in BAG_SUFFIXES:
        return True
    if p.is_dir():
        return (p / "metadata.yaml").is_file() or bool(_storage_files(p))
    return p.is_file() and bag_kind(p) is not None


def _storage_files(folder: Path) -> list[Path]:
    """The rosbag2 storage files (.db3, .mcap) in ``folder``, by name."""
    try:
        return sorted(p for p in folder.iterdir() if p.suffix.lower() in (".db3", ".mcap") and p.is_file())
    except OSError:
        return []


def _split_order(files: list[Path]) -> list[Path]:
    """A split recording's storage files in the recorder's order: ``NAME_0``, ``NAME_1``, … ``NAME_10`` by number
    (by name they sort ``NAME_10`` before ``NAME_2``); files not so named, by name."""
    import re

    numbered = [re.fullmatch(r"(.*)_(\d+)", f.stem) for f in files]
    if len(files) > 1 and all(numbered) and len({m.group(1) for m in numbered}) == 1:
        return [f for _, f in sorted(zip((int(m.group(2)) for m in numbered), files))]
    return sorted(files)


def _reindexed_twin(path: Path) -> Path | None:
    """For a rosbag2 folder without metadata.yaml (``ros2 bag record`` writes it when the recording closes): a
    folder of its storage files in the recorder's order (:func:`_split_order`), each as the storage readers read it
    (an MCAP file that did not close closed by :func:`optinav.io.bagrepair.repair`, a .db3 with messages in its
    write-ahead log a checkpointed copy, a link to any other), with the metadata.yaml that ``ros2 bag reindex``
    writes (topics, types and counts from each file), and a warning; None for anything else."""
    if not path.is_dir() or (path / "metadata.yaml").is_file():
        return None
    files = _split_order(_storage_files(path))
    if not files:
        raise OptinavError(
            f"{path} is a folder without metadata.yaml, not a ROS 2 bag",
            "pass the bag folder, its .db3/.mcap file, or a ROS 1 .bag file",
        )
    if len({f.suffix.lower() for f in files}) > 1:
        raise OptinavError(
            f"{path} holds both .db3 and .mcap files ({', '.join(f.name for f in files)}) and no metadata.yaml: not "
            "one recording",
            "pass one of the files",
        )

    def make(folder: Path) -> tuple[Path, str]:
        twin = folder / path.name
        twin.mkdir()
        notes = [w for f in files if (w := _storage_copy(f, twin / f.name))]
        _write_metadata(twin, [twin / f.name for f in files])
        names = (
            f"its one file {files[0].name}"
            if len(files) == 1
            else (f"its {len(files)} files {', '.join(f.name for f in files)} in this order")
        )
        said = f"{path.name} has no metadata.yaml (its recording did not close): read from {names}"
        return twin, "; ".join([said, *notes])

    # every file a dependency: a recording still running grows its last file, not the folder's time
    return _copy_once(path, make, [*files, *(w for f in files for _, w in _logged(f))])


def _storage_copy(src: Path, dst: Path) -> str | None:
    """``src`` (one rosbag2 storage file) as the storage readers read it, at ``dst``: closed, checkpointed or linked
    (:func:`_reindexed_twin`); what was done when more than a link, in words."""
    from optinav.io import bagrepair

    if src.suffix.lower() == ".mcap" and bagrepair.bag_kind(src) == "mcap" and bagrepair.needs_repair(src, "mcap"):
        return _closed_copy(src, dst, "mcap")
    logged = _logged(src)
    if logged:
        _folded_copy(src, logged[0][1], dst)
        return f"{src.name}'s write-ahead log ({logged[0][1].stat().st_size} bytes) folded into a copy"
    _link(src, dst)
    return None


def _closed_copy(src: Path, dst: Path, kind: str) -> str:
    """The closed copy of the ROS 1 or MCAP bag ``src`` that did not close (:func:`optinav.io.bagrepair.repair`)
    at ``dst``, and what it kept in words; one that holds nothing readable is refused."""
    from optinav.io import bagrepair

    try:
        return bagrepair.repair(src, dst, kind).words(src.name)
    except bagrepair.NotFast as exc:
        raise OptinavError(
            f"{src.name} is not a readable ROS bag: {exc} (a recording that did not close, or a copy cut short)",
            "check that the file is the whole bag",
        ) from None


def _link(src: Path, dst: Path) -> None:
    """``dst`` a symbolic link to ``src`` (or, where there are none, a copy)."""
    import shutil

    try:
        dst.symlink_to(src.resolve())
    except OSError:  # no symbolic links here (Windows without the right): a copy
        shutil.copyfile(src, dst)


def _folded_copy(db: Path, wal: Path, dst: Path) -> None:
    """A copy at ``dst`` of the sqlite3 file ``db`` with its write-ahead log ``wal`` folded in (:func:`_checkpoint`)."""
    import shutil

    shutil.copyfile(db, dst)
    shutil.copyfile(wal, dst.with_name(dst.name + "-wal"))
    _checkpoint(dst)


def _write_metadata(folder: Path, files: list[Path]) -> None:
    """The metadata.yaml of the rosbag2 bag whose storage ``files`` are in ``folder``, as ``ros2 bag reindex``
    writes it: each topic's type and message count, the start and duration, from rosbags' reader of each file."""
    from ruamel.yaml import YAML

    AnyReader = _rosbags()
    topics: dict = {}
    start, end = [], []
    for f in files:
        try:
            with AnyReader([f]) as reader:
                for con in reader.connections:
                    seen = topics.setdefault(con.topic, {"type": con.msgtype, "count": 0})
                    if seen["type"] != con.msgtype:
                        raise OptinavError(
                            f"topic {con.topic} is {seen['type']} in one file of {folder.name} and {con.msgtype} in "
                            f"{f.name}: not one recording",
                            "pass one of the files",
                        )
                    seen["count"] += con.msgcount
                if reader.message_count:
                    start.append(reader.start_time)
                    end.append(reader.end_time)
        except OptinavError:
            raise
        except Exception as exc:  # noqa: BLE001 - rosbags raises its own errors and OS/struct errors on damaged files
            raise OptinavError(
                f"{f.name} is not a readable ROS bag ({_why(exc)})",
                "check that the bag was closed properly (ros2 bag reindex FOLDER)",
            ) from None
    t0 = min(start, default=0)
    info = {
        "version": 4,
        "storage_identifier": "mcap" if files[0].suffix.lower() == ".mcap" else "sqlite3",
        "relative_file_paths": [f.name for f in files],
        "duration": {"nanoseconds": max(end, default=t0) - t0},
        "starting_time": {"nanoseconds_since_epoch": t0},
        "message_count": sum(t["count"] for t in topics.values()),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": name,
                    "type": t["type"],
                    "serialization_format": "cdr",
                    "offered_qos_profiles": "",
                },
                "message_count": t["count"],
            }
            for name, t in topics.items()
        ],
        "compression_format": "",
        "compression_mode": "",
    }
    YAML(typ="safe").dump({"rosbag2_bagfile_information": info}, folder / "metadata.yaml")


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise OptinavError("reading ROS bags needs the rosbags library, which is not installed", _INSTALL) from None
    return AnyReader


def _parse_topics(topic) -> list[str]:
    if topic is None:
        return []
    items = [s.strip() for s in (topic.split(",") if isinstance(topic, str) else topic)]
    if not items or any(not s for s in items) or len(items) > 2:
        raise OptinavError(
            f"--topic {topic!r} is not one Imu topic, optionally followed by one MagneticField topic",
            "write --topic /imu or --topic /imu,/mag",
        )
    return items


def load_bag(path, *, topic=None, only=None):
    """Read the Imu (and MagneticField) topic of the bag ``path`` into a Table (see the module docs).

    ``topic``: ``"/imu"`` or ``"/imu,/mag"`` (a comma list or sequence); None picks the bag's only Imu topic and
    its only MagneticField topic if it has exactly one. ``only`` is accepted for symmetry with the other readers.
    """
    path = Path(path)
    if not path.exists():
        raise OptinavError(f"data file {path} does not exist", "check the path")
    if path.is_file() and path.stat().st_size == 0:
        raise OptinavError(f"data file {path} is empty", "pass a complete bag")
    wanted = _parse_topics(topic)
    AnyReader = _rosbags()
    _metadata.cache_clear()  # parsed once in this read; the next read parses its own (a read's time holds its parse)
    twin = _readable_twin(path)
    if twin is not None:
        return _as_path(path, twin, lambda: load_bag(twin, topic=topic))
    got = _ros1_quick(path, wanted) if path.is_file() and path.suffix.lower() == ".bag" else _sqlite_quick(path, wanted)
    if got is None:
        try:
            reader = AnyReader([path])
            reader.open()
        except Exception as exc:  # noqa: BLE001 - rosbags raises its own errors and OS/struct errors on damaged files
            raise OptinavError(
                f"{path.name} is not a readable ROS bag ({_why(exc)})",
                "check that the bag was closed properly (ros2 bag reindex / rosbag reindex)",
            ) from None
        try:
            topics = _reader_topics(reader)
            got = _read(reader, path, topics, *_choose(path, topics, wanted))
        finally:
            try:
                reader.close()
            except Exception:  # noqa: BLE001 - closing a damaged bag may fail again; the first error was reported
                pass
    (imu_topic, imu), mag = got
    t, t_log, (gyr, acc), own = _stamps_mended(path, imu_topic, *imu)
    gyr, acc = (None if k in _unmeasured(path, imu_topic, (gyr, acc)) else v for k, v in enumerate((gyr, acc)))
    if mag is None:
        return _bag_table(path, imu_topic, _time_base(path, imu_topic, t, t_log, own=own), gyr, acc, None, None, 0)
    mag_topic, mag = mag
    tm, tm_log, b, own_m = _stamps_mended(path, mag_topic, *mag)
    # one clock for both topics: a topic on its log times beside one on header stamps is offset by the delay
    # between stamping and logging (0.4 s: yaw off by up to 19°)
    both = own and own_m
    t = _time_base(path, imu_topic, t, t_log, both, mag_topic, own=own)
    tm = _time_base(path, mag_topic, tm, tm_log, both, imu_topic, own=own_m)
    _check_mag_overlap(path, imu_topic, (float(t[0]), float(t[-1])), mag_topic, tm)
    return _bag_table(path, imu_topic, t, gyr, acc, mag_topic, (tm, b[0]), 0)


def _logged(path: Path) -> list[tuple[Path, Path]]:
    """(db3, its write-ahead log) of each rosbag2 sqlite3 file of ``path`` (a .db3 or a bag folder) with a non-empty
    ``X.db3-wal`` beside it (a recording in WAL mode — ``--storage-preset-profile resilient`` — still running or that
    did not close): its newest messages are only in the log, which neither the scanners nor rosbags read."""
    files = [path] if path.is_file() else sorted(path.glob("*.db3")) if path.is_dir() else []
    out = []
    for f in files:
        wal = f.with_name(f.name + "-wal")
        if f.suffix.lower() == ".db3" and wal.is_file() and wal.stat().st_size > 0:
            out.append((f, wal))
    return out


def _folded_twin(path: Path) -> Path | None:
    """A copy of a sqlite3 bag whose write-ahead log holds messages (:func:`_logged`), in a temporary folder with
    the log folded in by SQLite itself (a checkpoint of the copy: the input is never written), with a warning;
    None for any other bag."""
    logged = _logged(path)
    if not logged:
        return None

    def fold(folder: Path) -> tuple[Path, str]:
        import shutil

        dst = folder / path.name
        if path.is_dir():
            dst.mkdir()
            for f in path.iterdir():
                if f.is_file() and not f.name.endswith("-shm"):
                    shutil.copyfile(f, dst / f.name)
            for f, _ in logged:
                _checkpoint(dst / f.name)
        else:
            _folded_copy(path, logged[0][1], dst)
        sizes = ", ".join(f"{w.name}: {w.stat().st_size} bytes" for _, w in logged)
        return dst, (
            f"{path.name} has a write-ahead log ({sizes}) with messages not yet in the database (a recording still "
            "running, or one that did not close): read from a copy with the log folded in"
        )

    return _copy_once(path, fold, [w for _, w in logged])


def _checkpoint(db: Path) -> None:
    """Fold the write-ahead log beside the sqlite3 file ``db`` (a copy) into it, by SQLite itself."""
    import sqlite3

    try:
        con = sqlite3.connect(f"file:{db}?mode=rw", uri=True)
        try:
            con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            con.execute("PRAGMA journal_mode=DELETE")
        finally:
            con.close()
    except sqlite3.Error as exc:
        raise OptinavError(
            f"{db.name} with its write-ahead log is not a readable database ({exc})",
            "check that the .db3 and its -wal file were copied whole, together",
        ) from None


def _file_compressed(path: Path) -> tuple[dict, list[Path]] | None:
    """(bag information, its files) of a rosbag2 bag compressed file by file with zstd (``ros2 bag record
    --compression-mode file``); None for anything else."""
    got = _bag_info(path)
    if got is None:
        return None
    info, files = got
    mode, fmt = (str(info.get(k, "") or "").lower() for k in ("compression_mode", "compression_format"))
    if mode != "file" or fmt != "zstd" or info.get("storage_identifier") not in ("sqlite3", "mcap") or not files:
        return None
    return (info, files) if all(f.suffix == ".zstd" and f.is_file() for f in files) else None


def _bag_info(path: Path) -> tuple[dict, list[Path]] | None:
    """(``rosbag2_bagfile_information`` of the folder's metadata.yaml, its storage files beside it); None for a
    file, or a metadata file this does not read (rosbags' reader then decides)."""
    if not path.is_dir():
        return None
    try:
        info = copy.deepcopy(_metadata((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"])
        return info, [path / Path(f).name for f in info["relative_file_paths"]]
    except Exception:  # noqa: BLE001 - a metadata file this does not read: rosbags' reader decides
        return None


@functools.lru_cache(maxsize=8)
def _metadata(text: str):
    """A rosbag2 metadata.yaml's text parsed (safe YAML), once per text in a read (:func:`load_bag` clears it):
    the read asks for it twice, and a parse costs 15 ms."""
    from ruamel.yaml import YAML  # rosbags' own dependency

    return YAML(typ="safe").load(text)


def _inflated_twin(path: Path) -> Path | None:
    """A bag compressed file by file, each file inflated into a temporary folder of the same name (as rosbags'
    reader does), to be read as a plain bag by the storage's decoders — rosbags' message by message iteration took
    2.5–6 µs a message, these 0.6 µs; None when ``path`` is not such a bag."""
    got = _file_compressed(path)
    if got is None:
        return None
    info, files = got

    def inflate(folder: Path) -> tuple[Path, None]:
        import shutil

        from ruamel.yaml import YAML

        from optinav.io.bagscan import zstd_module

        zstd = zstd_module()
        plain = folder / path.name
        plain.mkdir()
        for f in files:
            try:
                with f.open("rb") as src, zstd.open(src, "rb") as z, (plain / f.stem).open("wb") as dst:
                    shutil.copyfileobj(z, dst, 1 << 20)
                    _written_out(dst)
            except (zstd.ZstdError, EOFError) as exc:  # EOFError: a truncated file
                raise OptinavError(
                    f"{path.name} is not a readable ROS bag: {f.name} is not a complete zstd file ({_why(exc)})",
                    "check that the bag was closed properly and copied whole",
                ) from None
        plain_info = dict(info, compression_mode="", compression_format="")
        plain_info["relative_file_paths"] = [Path(f).stem for f in info["relative_file_paths"]]
        plain_info["files"] = [
            dict(e, path=Path(e["path"]).stem) for e in info.get("files") or [] if isinstance(e, dict)
        ]
        YAML(typ="safe").dump({"rosbag2_bagfile_information": plain_info}, plain / "metadata.yaml")
        return plain, None

    return _copy_once(path, inflate, files)


#: the readable copies or links made in this process, newest last, by (path, size, modification time): a command
#: that reads its input twice (the attitude stream's two passes) repairs it and says so once; each is removed when
#: it leaves this list or at exit
_TWINS: dict = {}
_TWINS_KEPT = 2


def _readable_twin(path: Path) -> Path | None:
    """What to read for the bag ``path`` when the storage readers do not read it as it is (:func:`_reindexed_twin`,
    :func:`_folded_twin`, :func:`_inflated_twin`, :func:`_repaired_twin`), else None."""
    return _reindexed_twin(path) or _folded_twin(path) or _inflated_twin(path) or _repaired_twin(path)


def _repaired_twin(path: Path) -> Path | None:
    """For a ROS 1 or MCAP file under another suffix (``X.bag.active``), a link named for its format, which
    rosbags' reader goes by; for one whose recording did not close, the copy :func:`optinav.io.bagrepair.repair`
    writes into a temporary folder, with a warning of what was left out; None for anything else."""
    from optinav.io import bagrepair

    if not path.is_file():
        return None
    kind = bagrepair.bag_kind(path)
    if kind is None:
        return None
    broken = bagrepair.needs_repair(path, kind)
    if not broken and path.suffix.lower() == bagrepair.SUFFIX[kind]:
        return None

    def make(folder: Path) -> tuple[Path, str | None]:
        twin = folder / (path.name + bagrepair.SUFFIX[kind])
        if broken:
            return twin, _closed_copy(path, twin, kind)
        _link(path, twin)
        return twin, None

    return _copy_once(path, make)


def _as_path(path: Path, twin: Path, step):
    """``step()`` (a read of ``twin``, the readable copy or link of ``path``) with its errors and warnings naming
    ``path``; tables it returns name ``path``."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            table = step()
        except OptinavError as exc:
            raise type(exc)(
                exc.cause.replace(twin.name, path.name), exc.remedy and exc.remedy.replace(twin.name, path.name)
            ) from None
    for w in said:
        warnings.warn(str(w.message).replace(twin.name, path.name), w.category, stacklevel=6)
    if table is not None:
        table.path = path
    return table


def _copy_once(path: Path, make, deps=()) -> Path:
    """The readable copy (or link) of ``path`` that ``make(folder)`` writes into a new temporary folder and returns
    with its warning (or None, no warning), made once while it stays in :data:`_TWINS` (keyed by the path, size and
    modification time of ``path`` and of the files ``deps`` it also depends on)."""
    import tempfile

    key = tuple((str(p.resolve()), st.st_size, st.st_mtime_ns) for p in (path, *deps) for st in (p.stat(),))
    if key in _TWINS and _TWINS[key][1].exists():
        _TWINS[key] = _TWINS.pop(key)
        return _TWINS[key][1]
    folder = tempfile.TemporaryDirectory(prefix="optinav-bag-")
    try:
        twin, said = make(Path(folder.name))
    except OSError as exc:
        folder.cleanup()
        raise OptinavError(
            f"cannot write a readable copy of {path.name} into a temporary folder ({exc.strerror or exc})",
            "check that the bag is readable and that TMPDIR points at a disk with room for a copy of it "
            "(uncompressed, for a compressed bag)",
        ) from None
    except BaseException:
        folder.cleanup()
        raise
    if said:
        warnings.warn(said, stacklevel=6)
    _TWINS[key] = (folder, twin)
    while len(_TWINS) > _TWINS_KEPT:
        _TWINS.pop(next(iter(_TWINS)))[0].cleanup()
    return twin


def _written_out(fh) -> None:
    """Put a file just written on disk and out of the OS cache: read back through a map while still cached as
    written, its pages stayed in the resident set (1 M messages: 350 MB more at the peak, the file's size) where
    a file read from disk costs the block being decoded only."""
    import os

    fh.flush()
    os.fsync(fh.fileno())
    if hasattr(os, "posix_fadvise"):
        os.posix_fadvise(fh.fileno(), 0, 0, os.POSIX_FADV_DONTNEED)


def _read(reader, path: Path, topics: dict, imu_topic: str, mag_topic: str | None) -> tuple:
    """((imu topic, its (stamps, log times, values)), (mag topic, its …) or None)."""
    for name in (imu_topic, mag_topic):
        if name is not None:
            _one_publisher(reader, path, name, topics[name])
    imu = (imu_topic, _read_topic(reader, path, imu_topic, topics[imu_topic]))
    mag = None if mag_topic is None else (mag_topic, _read_topic(reader, path, mag_topic, topics[mag_topic]))
    return imu, mag


@functools.cache
def _store(name: str):
    """``rosbags``' type store ``Stores.<name>``, one per process: it compiles a type's deserializer on first use
    (about 30 ms for sensor_msgs/Imu), which a new store would do again for every bag read. Only read here."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(getattr(Stores, name))


class _Ros1Types:
    """``rosbags``' ROS 1 (Noetic) type store as the deserializer of a ROS 1 bag read without opening rosbags'
    reader (whose opening reads every index entry in Python, ~7 µs a message)."""

    is2 = False
    index = None  # the bag's index (bagscan.ros1_index), set by _ros1_setup

    def __init__(self):
        self.store = _store("ROS1_NOETIC")
        self.readers = (self,)

    def md5(self, msgtype: str) -> str | None:
        try:
            return self.store.generate_msgdef(msgtype)[1]
        except Exception:  # noqa: BLE001 - a type the store does not hold
            return None

    def deserialize(self, raw: bytes, msgtype: str):
        return self.store.deserialize_ros1(raw, msgtype)


class _Ros2Types(_Ros1Types):
    """``rosbags``' ROS 2 type store as the deserializer of a ROS 2 sqlite3 bag read without opening rosbags'
    reader (whose opening counts every topic's messages with a join over the whole table)."""

    is2 = True

    def __init__(self):
        self.store = _store("LATEST")
        self.readers = (self,)

    def deserialize(self, raw: bytes, msgtype: str):
        return self.store.deserialize_cdr(raw, msgtype)


def _deserializer(reader, msgtype: str):
    """The deserializer of ``msgtype`` for ``reader``: the process's ROS 2 type store (:func:`_store`, its code
    for the type generated once) when ``reader`` is a rosbags reader of a ROS 2 bag whose own type store (built from
    the bag's definitions at each opening: generating the code for sensor_msgs/Imu again cost 10-16 ms a read)
    defines the type and every type in it field for field as that store does; else ``reader``."""
    own = getattr(reader, "typestore", None)
    if own is None or not getattr(reader, "is2", False):
        return reader
    try:
        from rosbags.interfaces import Nodetype

        ref = _store("LATEST")
        if own is ref:
            return reader
        todo, seen = [msgtype], set()
        while todo:
            name = todo.pop()
            if name in seen:
                continue
            seen.add(name)
            if name not in ref.fielddefs or own.fielddefs.get(name) != ref.fielddefs[name]:
                return reader
            for _, desc in ref.fielddefs[name][1]:
                while desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE):  # an array's element type
                    desc = desc[1][0]
                if desc[0] == Nodetype.NAME:
                    todo.append(desc[1])
    except Exception:  # noqa: BLE001 - a rosbags without these names: its reader deserializes
        return reader
    return _Ros2Types()


def _sqlite_files(path: Path) -> list[Path] | None:
    """The .db3 files of an uncompressed rosbag2 sqlite3 bag (a bare .db3 file, or a folder whose
    metadata.yaml names them); None for anything else."""
    if path.is_file():
        return [path] if path.suffix.lower() == ".db3" else None
    got = _bag_info(path)
    if got is None:
        return None
    info, files = got
    plain = str(info.get("compression_mode", "") or "").lower() in ("", "none")
    if info.get("storage_identifier") == "sqlite3" and plain and files and all(f.suffix == ".db3" for f in files):
        return files if all(f.is_file() for f in files) else None
    return None


def _sqlite_quick(path: Path, wanted: list[str]):
    """The topics of a ROS 2 sqlite3 bag read from its files (:func:`optinav.io.bagscan.sqlite_topics`, the
    ``messages`` b-tree scanned by :mod:`optinav.io.bagscan`), the messages checked against rosbags' ROS 2 type
    store; None when that does not apply (rosbags reads)."""
    from optinav.io import bagscan

    files = _sqlite_files(path)
    if files is None:
        return None
    try:
        got = _sqlite_setup(path, files, wanted)
    except OptinavError:  # the error lists the topics with their counts: rosbags' reader counts them
        return None
    if got is None:
        return None
    types, topics, chosen = got
    try:
        out = []
        for j, name in enumerate(chosen):
            if name is None:
                out.append(None)
                continue
            fused = _sqlite_fused(types, path, files, name, topics[name])
            if fused is not None:
                out.append((name, fused))
                continue
            # an estimate of the topic's messages from the first block: the decoder's arrays grow past it
            rows = []
            gens = [bagscan.sqlite_blocks(f, name, rows) for f in files]
            first = [next(g, None) for g in gens]
            blocks = itertools.chain.from_iterable(
                itertools.chain([b], g) for b, g in zip(first, gens) if b is not None
            )
            size = sum(f.stat().st_size for f in files)
            topics[name]["count"] = min(sum(rows), size // _MIN_MSG_BYTES) if any(first) else 0
            topics[name]["grow"] = True
            if j == 1 and len(wanted) < 2 and topics[name]["count"] == 0:
                out.append(None)  # the MagneticField topic picked, not named, is empty: the Imu topic alone
                continue
            _require_messages(path, name, topics[name]["count"])
            out.append((name, _read_topic(types, path, name, topics[name], blocks=blocks)))
        return tuple(out)
    except OptinavError:
        raise
    except Exception:  # noqa: BLE001 - NotFast, or a file the scanner does not read: rosbags' reader decides
        return None


def _sqlite_fused(types, path: Path, files: list[Path], name: str, info: dict):
    """(header stamps s, log times s, values) of topic ``name`` decoded page by page by
    :func:`optinav.io.bagscan.sqlite_decode`, or None (then the blocks read it)."""
    from optinav.io import bagscan

    dec = _Decoder(types, False, info["type"], 0, grow=True)

    def reserve(kept: int, need: int):
        if need > dec.count:
            dec.done = kept
            dec._resize(need)
        return dec.stamp, dec.logt, dec.vals[0], dec.vals[-1]

    try:
        n = bagscan.sqlite_decode(files, name, dec.kernel_layout, reserve)
    except Exception:  # noqa: BLE001 - anything it does not read: the blocks read it (or name the damage)
        return None
    if not n:
        return None
    return _kept(dec, path, name, n, info.get("frame"))


def _ordered(stamp: np.ndarray, logt: np.ndarray, vals: tuple) -> tuple:
    """(stamps s, log times ns, values) in log-time order, as rosbags yields them (ties: as stored)."""
    if np.any(logt[1:] < logt[:-1]):
        order = np.argsort(logt, kind="stable")
        stamp, logt, vals = stamp[order], logt[order], tuple(v[order] for v in vals)
    return stamp, logt, vals


def _ros1_quick(path: Path, wanted: list[str]):
    """The topics of the ROS 1 bag ``path`` read from its own index and chunks (:mod:`optinav.io.bagscan`), the
    messages checked against Noetic's definitions by md5sum; None when that does not apply (rosbags reads)."""
    from optinav.io import bagscan

    got = _ros1_setup(path, wanted)
    if got is None:
        return None
    types, topics, chosen = got
    try:
        return _read(types, path, topics, *chosen)
    except bagscan.NotFast:
        return None


def _ros1_setup(path: Path, wanted: list[str]):
    """(deserializer, topics, (Imu topic, MagneticField topic or None)) of the ROS 1 bag ``path`` from its own
    index; None when the index scanner does not read it or a chosen topic's definition is not Noetic's (by
    md5sum). The topic choice's errors raise."""
    from optinav.io import bagscan

    try:
        idx = bagscan.ros1_index(path)
        types = _Ros1Types()
        types.index = idx
    except Exception:  # noqa: BLE001 - anything the index scanner does not read: rosbags' reader decides
        return None
    topics = _ros1_topics(idx)
    chosen = _choose(path, topics, wanted)
    if any(name is not None and topics[name]["md5"] != {types.md5(topics[name]["type"])} for name in chosen):
        return None
    return types, topics, chosen


def _sqlite_setup(path: Path, files: list[Path], wanted: list[str]):
    """(deserializer, topics, (Imu topic, MagneticField topic or None)) of a ROS 2 sqlite3 bag from its files;
    None when the scanner does not read them or a chosen topic is not CDR-serialized. The topic choice's errors
    raise."""
    try:
        types, topics = _Ros2Types(), _sqlite_topic_types(files)
    except Exception:  # noqa: BLE001 - anything the scanner does not read: rosbags' reader decides
        return None
    chosen = _choose(path, topics, wanted)
    if any(name is not None and topics[name]["fmt"] != {"cdr"} for name in chosen):
        return None
    return types, topics, chosen


def _one_publisher(reader, path: Path, topic: str, info: dict) -> None:
    """Refuse a ROS 1 topic written by several connections at once — two publishers (two IMU drivers, one driver
    started twice) whose messages interleave: read together they were one IMU at twice the rate with no word
    (their stamps interleaved and increased). Each connection is read on its own; the messages that repeat one of
    another connection (the same publisher recorded twice: :func:`_without_copies` leaves them out) do not count,
    nor do connections one after the other (a driver restarted)."""
    cons = info["cons"]
    if len(cons) < 2 or getattr(reader, "is2", True):
        return
    index = getattr(reader, "index", None)
    parts = []
    for c in cons:
        n = c.msgcount if index is None else index["counts"].get(c, 0)
        if n:
            parts.append((c, _read_topic(reader, path, topic, dict(info, cons=[c], count=n))))
    if len(parts) < 2:
        return
    stamp = np.concatenate([p[1][0] for p in parts])
    logt = np.concatenate([p[1][1] for p in parts])
    vals = tuple(np.concatenate([p[1][2][k] for p in parts]) for k in range(len(parts[0][1][2])))
    own = ~_copies(stamp, vals)
    label = np.repeat(np.arange(len(parts)), [p[1][0].size for p in parts])
    spans = sorted(
        (int(logt[m].min()), int(logt[m].max()), k) for k in range(len(parts)) if (m := own & (label == k)).any()
    )
    for (_, end, a), (start, _, b) in zip(spans, spans[1:]):
        if start <= end:
            names = [str(index["callers"].get(parts[k][0], "") if index else parts[k][0].ext.callerid) for k in (a, b)]
            raise OptinavError(
                f"topic {topic!r} of {path.name} was published by {len(spans)} connections whose messages interleave "
                f"(callerids {names[0] or '?'} and {names[1] or '?'}): two IMUs, or one driver running twice",
                f"keep one publisher: rosbag filter IN.bag OUT.bag "
                f'\'topic != "{topic}" or m._connection_header["callerid"] == "{names[0]}"\'',
            )


def _ros1_topics(idx: dict) -> dict:
    """Topic → {type, connections, count, md5 sums} of a ROS 1 bag's index (:func:`optinav.io.bagscan.ros1_index`)."""
    topics: dict = {}
    for conn, (name, msgtype, md5) in idx["conns"].items():
        msgtype = msgtype if "/msg/" in msgtype else msgtype.replace("/", "/msg/", 1)
        d = topics.setdefault(name, {"type": msgtype, "cons": [], "count": 0, "md5": set()})
        d["cons"].append(conn)
        d["count"] += idx["counts"].get(conn, 0)
        d["md5"].add(md5)
    return topics


def _reader_topics(reader) -> dict:
    """Topic → {type, connections, count} of an open rosbags reader."""
    topics: dict = {}
    for con in reader.connections:
        topics.setdefault(con.topic, {"type": con.msgtype, "cons": [], "count": 0})
        topics[con.topic]["cons"].append(con)
        topics[con.topic]["count"] += con.msgcount
    return topics


def _sqlite_topic_types(files: list[Path]) -> dict:
    """Topic → {type, serialization formats} of a ROS 2 sqlite3 bag's files (counts come when read)."""
    from optinav.io import bagscan

    topics: dict = {}
    for f in files:
        for name, msgtype, fmt in bagscan.sqlite_topics(f):
            if not all(isinstance(v, str) for v in (name, msgtype, fmt)):  # a damaged topics table
                raise ValueError(f"topic row {(name, msgtype, fmt)!r}")
            d = topics.setdefault(name, {"type": msgtype, "cons": [], "count": None, "fmt": set()})
            d["fmt"].add(fmt)
    return topics


def _why(exc: Exception) -> str:
    return " ".join(str(exc).split())[:200] or type(exc).__name__


def _listing(topics: dict) -> str:
    return ", ".join(f"{k} ({v['type'].replace('/msg/', '/')}, {v['count']} msgs)" for k, v in topics.items()) or "none"


def _choose(path: Path, topics: dict, wanted: list[str]) -> tuple[str, str | None]:
    """The Imu topic and the MagneticField topic (or None) to read: the one named, else the bag's only one when
    it is not known to be empty (it was an error naming that topic, even with the Imu topic named). A name
    ``TOPIC@FRAME`` reads only the topic's messages whose header frame_id is FRAME (``topics[TOPIC]["frame"]``)."""
    wanted = [_want_frame(topics, name) for name in wanted]
    for name in wanted:
        if name not in topics:
            raise OptinavError(
                f"{path.name} has no topic {name!r} (topics: {_listing(topics)})",
                "pass one of the listed topics with --topic",
            )
    imu = [k for k, v in topics.items() if v["type"] == IMU_TYPE]
    mag = [k for k, v in topics.items() if v["type"] == MAG_TYPE]
    if wanted:
        imu_topic = wanted[0]
        if topics[imu_topic]["type"] != IMU_TYPE:
            raise OptinavError(
                f"topic {imu_topic!r} of {path.name} holds {topics[imu_topic]['type']}, not "
                f"{IMU_TYPE} (Imu topics: {', '.join(imu) or 'none'})",
                "pass an Imu topic first with --topic (a MagneticField topic may follow: /imu,/mag)",
            )
        mag_topic = wanted[1] if len(wanted) == 2 else (mag[0] if len(mag) == 1 else None)
        mag_topic = None if len(wanted) < 2 and mag_topic and topics[mag_topic]["count"] == 0 else mag_topic
        if len(wanted) == 2 and topics[mag_topic]["type"] != MAG_TYPE:
            raise OptinavError(
                f"topic {mag_topic!r} of {path.name} holds {topics[mag_topic]['type']}, not {MAG_TYPE}",
                "pass a MagneticField topic second in --topic, or only the Imu topic",
            )
    else:
        filled = [k for k in imu if topics[k]["count"] != 0]  # (None: not counted yet, may hold messages)
        if len(imu) > 1 and len(filled) == 1:
            # an IMU advertised but never published beside the one that did: that one (it was "pick one with
            # --topic", though only one can be read)
            empty = [k for k in imu if k not in filled]
            warnings.warn(
                f"{path.name}: Imu topic {filled[0]!r} read; {', '.join(map(repr, empty))} hold(s) no messages",
                stacklevel=3,
            )
            imu = filled
        if len(imu) != 1:
            what = "no" if not imu else f"{len(imu)}"
            raise OptinavError(
                f"{path.name} has {what} {IMU_TYPE} topics (topics: {_listing(topics)})",
                "pick one with --topic TOPIC" if imu else "record the IMU as sensor_msgs/Imu",
            )
        imu_topic = imu[0]
        # the only MagneticField topic, when it has messages (an advertised magnetometer that never published)
        mag_topic = mag[0] if len(mag) == 1 and topics[mag[0]]["count"] != 0 else None
    for name in (imu_topic, mag_topic):
        if name is not None:
            _require_messages(path, name, topics[name]["count"])
    return imu_topic, mag_topic


def _want_frame(topics: dict, item: str) -> str:
    """The topic of a ``--topic`` item, ``TOPIC`` or ``TOPIC@FRAME`` ('@' is not in ROS names); a frame_id
    asked for is noted in ``topics[TOPIC]["frame"]``."""
    name, at, frame = item.partition("@")
    if at and name in topics:
        topics[name]["frame"] = frame
    return name if at else item


def _require_messages(path: Path, name: str, count) -> None:
    """Refuse a topic without messages (``count`` None: not counted yet, sqlite3 bags count when read)."""
    if count == 0:
        raise OptinavError(f"topic {name!r} of {path.name} holds no messages", "pass a topic with messages")


# --- decoding -------------------------------------------------------------------------------------------------


def _layout(raw: bytes, ros1: bool, msgtype: str) -> tuple | None:
    """(dtype of one message, field names of the values, string length, the header's frame_id bytes) for
    messages of ``len(raw)`` bytes and that frame_id; None when the layout is not the plain little-endian one this
    decoder knows."""
    n = len(raw)
    if ros1:
        if n < 16:
            return None
        slen = int.from_bytes(raw[12:16], "little")
        pos, sec, nsec = 16 + slen, 4, 8
    else:
        # CDR: 4-byte encapsulation header (00 01 = little endian), then the payload; float64 aligned to 8 in it
        if n < 16 or raw[0:2] != b"\x00\x01":
            return None
        slen = int.from_bytes(raw[12:16], "little")
        pos = 16 + slen
        pos = 4 + -(-(pos - 4) // 8) * 8
        sec, nsec = 4, 8
    if msgtype == IMU_TYPE:
        # orientation (4) + covariance (9) precede angular_velocity; its covariance (9) precedes linear_acceleration
        fields = {"g": pos + 13 * 8, "a": pos + 13 * 8 + 12 * 8}
        end = fields["a"] + 12 * 8
        names = ("g", "a")
    else:
        fields = {"m": pos}
        end = pos + 12 * 8
        names = ("m",)
    if end != n:
        return None
    spec = {
        "names": ["sec", "nsec", "len"] + list(names),
        "offsets": [sec, nsec, 12] + [fields[k] for k in names],
        "formats": ["<i4" if not ros1 else "<u4", "<u4", "<u4"] + ["(3,)<f8"] * len(names),
        "itemsize": n,
    }
    return np.dtype(spec), names, slen, raw[16 : 16 + slen]


def _frame_name(frame: bytes, ros1: bool) -> str:
    """The header frame_id of its bytes in a message (CDR strings end in a NUL that the name does not hold)."""
    if not ros1 and frame.endswith(b"\0"):
        frame = frame[:-1]
    return frame.decode("utf-8", "replace")


def _slow(reader, raw: bytes, msgtype: str) -> tuple[float, np.ndarray, str]:
    """(header stamp s, values, header frame_id) of one message by rosbags' deserializer."""
    msg = reader.deserialize(raw, msgtype)
    st = msg.header.stamp
    # ROS 1 time is uint32 seconds; rosbags' deserializer gives int32 (stamps after 2038-01-19 were negative)
    sec = st.sec % 2**32 if not getattr(reader, "is2", True) else st.sec
    if msgtype == IMU_TYPE:
        w, f = msg.angular_velocity, msg.linear_acceleration
        v = [w.x, w.y, w.z, f.x, f.y, f.z]
    else:
        b = msg.magnetic_field
        v = [b.x, b.y, b.z]
    return sec + st.nanosec * 1e-9, np.asarray(v, dtype=float), str(msg.header.frame_id)


def _read_topic(reader, path: Path, topic: str, info: dict, blocks=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(header stamps s, log times s, values) of every message of ``topic``, in log-time order: Imu values are
    ``[gx gy gz ax ay az]``, MagneticField ``[mx my mz]``. The raw bytes come in blocks from the storage itself
    (:mod:`optinav.io.bagscan`) or, when it does not read this bag, from ``rosbags``' iteration."""
    from optinav.io import bagscan

    msgtype, count = info["type"], info["count"]
    size = sum(f.stat().st_size for f in path.iterdir() if f.is_file()) if path.is_dir() else path.stat().st_size
    # more messages than the stored bytes hold uncompressed: compressed storage (chunks or the whole file; a
    # quantized IMU compresses tenfold), or a damaged index. Allocate for what the bytes hold, grow as messages
    # come, and require the index's count at the end.
    cap = max(size // _MIN_MSG_BYTES, 1)
    packed = count > cap
    grow = info.get("grow", False) or packed  # grow: count is an estimate (sqlite3) or beyond the bytes
    dec = _Decoder(reader, not getattr(reader, "is2", True), msgtype, min(count, cap), grow=grow)
    done = None
    if blocks is None and not packed and _whole(reader, path, topic, info, dec):
        done = dec.done = count
    fast = None if done is not None else bagscan.blocks(reader, path, topic) if blocks is None else blocks
    if fast is not None:
        try:
            done = dec.run(fast, strict=True)
        except bagscan.Damaged:  # where rosbags would read it wrong
            raise
        except Exception:  # noqa: BLE001 - anything the scanners do not read: rosbags reads it (and names damage)
            done = None
        if done is not None and done != count and blocks is None:
            done = None
    if done is None and not hasattr(reader, "messages"):
        raise bagscan.NotFast(f"topic {topic!r}")  # no rosbags reader open: the caller opens one
    if done is None:
        try:
            done = dec.run(_rosbags_blocks(reader, info), strict=False)
        except OptinavError:
            raise
        except Exception as exc:  # noqa: BLE001 - damaged chunks, decompression errors, truncated files
            raise OptinavError(
                f"{path.name} is not a readable ROS bag: topic {topic!r} fails after {dec.done} "
                f"message(s) ({_why(exc)})",
                "check that the bag was closed properly (ros2 bag reindex / rosbag reindex)",
            ) from None
    if (dec.done > count and not grow) or (packed and dec.done != count):
        raise OptinavError(
            f"topic {topic!r} of {path.name} holds {dec.done} messages, its index says {count}",
            "reindex the bag (ros2 bag reindex / rosbag reindex)",
        )
    if done == 0:
        raise OptinavError(f"topic {topic!r} of {path.name} holds no readable messages", "pass a topic with messages")
    # the storage's record order; rosbags yields log-time order
    return _kept(dec, path, topic, done, info.get("frame"))


def _kept(dec, path: Path, topic: str, n: int, frame: str | None) -> tuple:
    """(stamps s, log times ns, values) of the decoder's first ``n`` rows of the frame_id kept
    (:meth:`_Decoder.frame_rows`), in log-time order."""
    stamp, logt, vals = dec.stamp[:n], dec.logt[:n], dec.values(n)
    keep = dec.frame_rows(path, topic, n, frame)
    if keep is not None:
        stamp, logt, vals = stamp[keep], logt[keep], tuple(v[keep] for v in vals)
    return _ordered(stamp, logt, vals)


def _whole(reader, path: Path, topic: str, info: dict, dec) -> bool:
    """Decode every message of ``topic`` into the decoder's arrays (``info["count"]`` rows) by the storage's
    compiled decoder — a plain ROS 1 bag read through its own index (:func:`optinav.io.bagscan.ros1_decode`), or
    an MCAP file (:func:`optinav.io.bagscan.mcap_decode`): each chunk walked and gathered in one call while in
    cache, two threads. False when neither applies or it declines: the blocks read the topic."""
    from optinav.io import bagscan

    if sys.byteorder != "little":
        return False
    out = (dec.stamp, dec.logt, dec.vals[0], dec.vals[-1])
    try:
        if getattr(reader, "index", None) is not None:
            cons = np.array(sorted(info["cons"]), dtype=np.int64)
            return bagscan.ros1_decode(path, reader.index, cons, dec.kernel_layout, out)
        mcap = bagscan.mcap_file(reader)
        return mcap is not None and bagscan.mcap_decode(mcap, topic, dec.kernel_layout, out)
    except bagscan.Damaged:  # where rosbags would read it wrong
        raise
    except Exception:  # noqa: BLE001 - anything it does not read: the blocks read it (or name the damage)
        return False


def _rosbags_blocks(reader, info: dict):
    """``rosbags``' iteration in blocks of ``_BLOCK`` messages (the loop only collects)."""
    chunk, times = [], []
    for _, t_log, raw in reader.messages(connections=info["cons"]):
        chunk.append(raw)
        times.append(t_log)
        if len(chunk) == _BLOCK:
            yield _joined(chunk, times)
            chunk, times = [], []
    if chunk:
        yield _joined(chunk, times)


def _joined(chunk: list, times: list):
    size = np.fromiter(map(len, chunk), dtype=np.int64, count=len(chunk))
    off = np.zeros_like(size)
    np.cumsum(size[:-1], out=off[1:])
    return b"".join(chunk), off, size, np.asarray(times, dtype=np.int64)


class _Decoder:
    """Decodes blocks ``(buf, off, size, logt)`` into preallocated stamp, log-time and value arrays (Imu: gyr and
    acc, MagneticField: mag, (n, 3) each): messages of the fixed layout with a compiled gather
    (:func:`optinav.io._bagkernels.gather`; numpy on a big-endian host), the others with ``rosbags``'
    deserializer. ``grow``: ``count`` is an estimate and the arrays grow past it."""

    def __init__(self, reader, ros1: bool, msgtype: str, count: int, *, grow: bool = False):
        self.ros1, self.msgtype, self.count, self.grow = ros1, msgtype, count, grow
        #: what deserializes a message (the first's layout check, the messages of another layout)
        self.types = _deserializer(reader, msgtype)
        self.done = 0
        #: the value groups (0 angular velocity, 1 linear acceleration) the first message marks as not measured
        self.unmeasured: tuple = ()
        #: the header frame_ids met, in order; ``fid`` holds each row's index in it
        self.frames: list[str] = []
        self._alloc(count)

    def _mark(self, first: bytes) -> None:
        """Note the Imu value groups whose covariance's element 0 is -1 in the message ``first``: no such data
        (sensor_msgs/Imu's definition; an accelerometer-only unit publishes zeros as its angular velocity)."""
        if self.msgtype != IMU_TYPE:
            return
        try:
            msg = self.types.deserialize(first, IMU_TYPE)
            covs = (msg.angular_velocity_covariance, msg.linear_acceleration_covariance)
            self.unmeasured = tuple(k for k, c in enumerate(covs) if c[0] == -1)
        except Exception:  # noqa: BLE001 - the deserializer fails: the main loop reports it
            pass

    def values(self, n: int) -> tuple:
        """The first ``n`` rows of each value group (views), those marked not measured NaN."""
        vals = tuple(v[:n] for v in self.vals)
        for k in self.unmeasured:
            vals[k][:] = np.nan
        return vals

    def _alloc(self, count: int) -> None:
        self.count = count
        self.stamp = np.empty(count)
        self.logt = np.empty(count, dtype=np.int64)
        self.vals = tuple(np.empty((count, 3)) for _ in range(2 if self.msgtype == IMU_TYPE else 1))
        self.fid = np.zeros(count, dtype=np.int32)

    def _resize(self, count: int) -> None:
        old = self.stamp, self.logt, self.vals, self.fid
        self._alloc(count)
        n = self.done
        self.stamp[:n], self.logt[:n], self.fid[:n] = old[0][:n], old[1][:n], old[3][:n]
        for v, w in zip(self.vals, old[2]):
            v[:n] = w[:n]

    def run(self, blocks, *, strict: bool) -> int:
        """Decode every block from row 0; the number of messages. ``strict``: more messages than the index
        counts raise at once (the caller then reads through rosbags), instead of being counted and reported."""
        self.done, layout = 0, None
        for buf, off, size, logt in blocks:
            n = size.size
            if self.done + n > self.count and self.grow:
                self._resize(max(2 * self.count, self.done + n))
            if self.done + n > self.count:
                if strict:
                    raise ValueError("more messages than the index counts")
                self.done += n
                continue
            u8 = np.frombuffer(buf, dtype=np.uint8)
            if layout is None:
                first = bytes(u8[off[0] : off[0] + size[0]])
                self._mark(first)
                layout = _layout(first, self.ros1, self.msgtype)
                if layout is not None and not _layout_agrees(self.types, first, layout, self.msgtype):
                    layout = None
                layout = layout or False  # False: every message through rosbags' deserializer
            rows = slice(self.done, self.done + n)
            self.logt[rows] = logt
            if layout:
                other = self._fast(u8, off, size, layout)
                self.fid[rows] = self._code(_frame_name(layout[3], self.ros1))
            else:
                _inside(u8, off, size)
                other = np.ones(n, dtype=bool)
            for j in np.flatnonzero(other):
                raw = bytes(u8[off[j] : off[j] + size[j]])
                t, v, frame = _slow(self.types, raw, self.msgtype)
                self.fid[self.done + j] = self._code(frame)
                self.stamp[self.done + j] = t
                for k, arr in enumerate(self.vals):
                    arr[self.done + j] = v[3 * k : 3 * k + 3]
            self.done += n
        return self.done

    def kernel_layout(self, first: bytes) -> np.ndarray | None:
        """The layout of the message ``first`` as the compiled gather takes it (itemsize, sec offset, signed sec,
        string length offset, string length, triad offsets a and b; b −1 for one triad), when it is the fixed
        layout and rosbags' deserializer reads the same values from it; else None."""
        self._mark(first)
        layout = _layout(first, self.ros1, self.msgtype)
        if layout is None or not _layout_agrees(self.types, first, layout, self.msgtype):
            return None
        if self._code(_frame_name(layout[3], self.ros1)) != 0:
            return None  # every row the kernel fills is of frame 0
        return self._kernel_args(layout)

    def _code(self, frame: str) -> int:
        if frame not in self.frames:
            self.frames.append(frame)
        return self.frames.index(frame)

    def frame_rows(self, path: Path, topic: str, n: int, frame: str | None) -> np.ndarray | None:
        """The rows of the first ``n`` to keep: those of the header frame_id ``frame`` when one is asked for
        (``--topic TOPIC@FRAME``), else all (None). Refuses a topic whose messages of several frame_ids
        interleave — two IMUs publishing on one topic, read as one at the sum of their rates (runs of one frame_id
        after another, as from a driver restarted under another frame_id, fewer than twice the frame_ids: kept)."""
        fid = self.fid[:n]
        if frame is not None:
            if frame not in self.frames:
                raise OptinavError(
                    f"topic {topic!r} of {path.name} has no message with frame_id {frame!r} "
                    f"(its frame_ids: {', '.join(map(repr, self.frames))})",
                    f"pass one of them: --topic {topic}@FRAME",
                )
            return np.flatnonzero(fid == self.frames.index(frame))
        if len(self.frames) < 2:
            return None
        order = np.argsort(self.logt[:n], kind="stable")
        if int(np.count_nonzero(np.diff(fid[order]))) < 2 * len(self.frames):
            return None
        counts = np.bincount(fid, minlength=len(self.frames))
        listing = ", ".join(f"{f!r} ({c} msgs)" for f, c in zip(self.frames, counts.tolist()))
        raise OptinavError(
            f"topic {topic!r} of {path.name} interleaves the messages of {len(self.frames)} header frame_ids "
            f"({listing}): several IMUs publishing on one topic, which read as one are none of them",
            f"read one of them: --topic {topic}@{self.frames[int(np.argmax(counts))]}",
        )

    def _kernel_args(self, layout) -> np.ndarray:
        dtype, names, slen, frame = layout
        o = [dtype.fields[k][1] for k in names] + [-1]
        args = [dtype.itemsize, dtype.fields["sec"][1], not self.ros1, dtype.fields["len"][1], slen, o[0], o[1]]
        return np.array(args + list(frame), dtype=np.int64)

    def _fast(self, u8: np.ndarray, off: np.ndarray, size: np.ndarray, layout) -> np.ndarray:
        """Decode the messages of ``layout`` at rows ``done…``; the mask of the others."""
        if sys.byteorder == "little":
            from optinav.io import _bagkernels as kern

            lay = self._kernel_args(layout)
            return kern.gather(
                u8,
                off,
                size,
                *lay[:2],
                bool(lay[2]),
                *lay[3:7],
                lay[7:],
                self.stamp,
                self.vals[0],
                self.vals[-1],
                self.done,
            )
        dtype, names, slen, _ = layout  # frame_ids not compared on this (big-endian) path
        _inside(u8, off, size)
        fast = size == dtype.itemsize
        arr = _gather(u8, off[fast], dtype)
        same = arr["len"] == slen  # same size but another string length: a layout of its own
        if not same.all():
            fast[np.flatnonzero(fast)[~same]] = False
            arr = arr[same]
        at = np.flatnonzero(fast) + self.done
        self.stamp[at] = arr["sec"] + arr["nsec"] * 1e-9
        for j, k in enumerate(names):
            self.vals[j][at] = arr[k]
        return ~fast


def _inside(u8: np.ndarray, off: np.ndarray, size: np.ndarray) -> None:
    """Refuse a block whose messages reach outside its bytes (the scanner's offsets: never read past them)."""
    if off.size and (off.min() < 0 or size.min() < 0 or (off + size).max() > u8.size):
        raise ValueError("a message outside its block")


def _gather(u8: np.ndarray, off: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The records of ``dtype`` starting at the byte offsets ``off`` of ``u8``: a strided view of ``u8`` when the
    offsets are evenly spaced (a run of like records), else a gathered copy."""
    size = dtype.itemsize
    if off.size == 0:
        return np.empty(0, dtype=dtype)
    step = np.diff(off)
    if off.size == 1 or (np.all(step == step[0]) and step[0] >= size):
        return np.ndarray(
            (off.size,), dtype=dtype, buffer=u8, offset=int(off[0]), strides=(size if off.size == 1 else int(step[0]),)
        )
    # scattered records: only the fields' bytes are gathered, into a packed copy with the same field names
    from optinav.io.bagscan import windows

    names = sorted(dtype.names, key=lambda k: dtype.fields[k][1])
    packed = np.dtype({"names": names, "formats": [dtype.fields[k][0] for k in names]})
    out = np.empty(off.size, dtype=packed)
    raw = out.view(np.uint8).reshape(off.size, packed.itemsize)
    # runs of adjacent fields (stamp and string length) are gathered at once
    runs = []
    for k in names:
        at, n, pk = dtype.fields[k][1], dtype.fields[k][0].itemsize, packed.fields[k][1]
        if runs and runs[-1][0] + runs[-1][1] == at:
            runs[-1][1] += n
        else:
            runs.append([at, n, pk])
    for at, n, pk in runs:
        raw[:, pk : pk + n] = windows(u8, off + at, n)
    return out


def _layout_agrees(reader, raw: bytes, layout, msgtype: str) -> bool:
    """The numpy decoding of ``raw`` equals rosbags' deserializer (guards the byte offsets above)."""
    try:
        t_ref, v_ref, f_ref = _slow(reader, raw, msgtype)
    except Exception:  # noqa: BLE001 - the deserializer itself fails: let the main loop report it
        return True
    arr = np.frombuffer(raw, dtype=layout[0])
    v = np.concatenate([arr[k] for k in layout[1]], axis=1)[0]
    t = float(arr["sec"][0] + arr["nsec"][0] * 1e-9)
    same_frame = layout[3] in (f_ref.encode(), f_ref.encode() + b"\0")
    return bool(np.array_equal(v, v_ref, equal_nan=True) and t == t_ref and same_frame)


def _stamps_ok(stamp: np.ndarray) -> bool:
    """Header stamps (s) that are set and strictly increasing."""
    # strictly increasing from a positive first stamp is all positive; a comparison, not a diff (a third the time)
    return bool(stamp.size and stamp[0] > 0 and np.all(stamp[1:] > stamp[:-1]))


def _stamp_fault(stamp: np.ndarray) -> str:
    """What keeps header stamps (s, log-time order) from being set and strictly increasing, in words."""
    if np.all(stamp == 0):
        return "zero"
    step = np.diff(stamp)
    faults = [
        f"{k} of {stamp.size} {what}"
        for k, what in (
            (int(np.sum(stamp == 0)), "zero"),
            (int(np.sum(stamp < 0)), "negative"),
            (int(np.sum(step == 0)), "equal to the one before"),
            (int(np.sum(step < 0)), "earlier than the one before"),
        )
        if k
    ]
    what = "not strictly increasing" if np.any(step <= 0) else "not all positive"
    return f"{what} ({', '.join(faults)})"


def _copies(stamp: np.ndarray, vals: tuple) -> np.ndarray:
    """(n,) True for the messages with the header stamp (s) and values of an earlier one (in the given order)."""
    order = np.argsort(stamp, kind="stable")  # equal stamps stay in the given order: the first is not a copy
    s = stamp[order]
    same = s[1:] == s[:-1]
    for v in vals:
        w = v[order]
        same &= np.all((w[1:] == w[:-1]) | (np.isnan(w[1:]) & np.isnan(w[:-1])), axis=1)
    out = np.zeros(stamp.size, dtype=bool)
    out[order[1:][same]] = True
    return out


#: messages logged out of their stamps' order are put in stamp order when the receive delay (log time − header
#: stamp) spreads by at most REORDER_MAX_S (s; beyond it the stamps may come from a clock that jumped) and at
#: most REORDER_MAX_BACK of the stamps step back in log order (a few messages late; a clock running backwards or
#: stamps unrelated to the order steps back at half the messages or more): otherwise the log times decide
REORDER_MAX_S, REORDER_MAX_BACK = 1.0, 0.25


def _stamps_mended(path: Path, topic: str, stamp: np.ndarray, logt: np.ndarray, vals: tuple) -> tuple:
    """(stamps s, log times ns, values, whether those stamps are set and strictly increasing: :func:`_stamps_ok`)
    of a topic read whole: copies left out (:func:`_without_copies`), then in stamp order
    (:func:`_in_stamp_order`); the time base then judges the stamps."""
    if _stamps_ok(stamp):  # nothing to mend (the verdict once: each pass over 3.6 M stamps costs 3 ms)
        return stamp, logt, vals, True
    stamp, logt, vals = _in_stamp_order(path, topic, *_without_copies(path, topic, stamp, logt, vals))
    return stamp, logt, vals, _stamps_ok(stamp)


def _in_stamp_order(path: Path, topic: str, stamp: np.ndarray, logt: np.ndarray, vals: tuple) -> tuple:
    """(stamps s, log times ns, values) in header-stamp order when the messages were only logged out of it —
    delivered late or out of order (best-effort transport, a driver publishing in bursts): the stamps, sorted, are
    set and strictly increasing, the receive delay varies by at most ``REORDER_MAX_S`` and at most
    ``REORDER_MAX_BACK`` of the stamps step back. They went to the log times with a warning (the transport's
    jitter on every sample). Anything else is returned as it is."""
    if stamp.size < 2 or _stamps_ok(stamp) or not np.all(stamp > 0):
        return stamp, logt, vals
    order = np.argsort(stamp, kind="stable")
    delay = logt * 1e-9 - stamp
    back = float(np.mean(np.diff(stamp) < 0))
    if not _stamps_ok(stamp[order]) or float(np.ptp(delay)) > REORDER_MAX_S or back > REORDER_MAX_BACK:
        return stamp, logt, vals
    late = int(np.count_nonzero(order != np.arange(order.size)))
    warnings.warn(
        f"{path.name}: {late} of the {stamp.size} messages of {topic!r} were logged out of their header stamps' "
        f"order (receive delay {1e3 * float(np.min(delay)):.3g}–{1e3 * float(np.max(delay)):.3g} ms); read in "
        "stamp order",
        stacklevel=3,
    )
    return stamp[order], logt[order], tuple(v[order] for v in vals)


def _without_copies(path: Path, topic: str, stamp: np.ndarray, logt: np.ndarray, vals: tuple) -> tuple:
    """(stamps s, log times ns, values) without the messages that repeat an earlier one — the same header stamp
    and values: one publisher recorded on two connections, a bag merged with a copy of itself, a message resent —
    when those copies are all that keeps the stamps from being set and strictly increasing; they carry nothing
    new, and kept they doubled samples on the log times (with a warning that named the stamps only). Anything
    else is returned as it is (the time base then decides), so is a topic whose stamps are fine."""
    if stamp.size < 2 or _stamps_ok(stamp) or not np.all(stamp > 0):
        return stamp, logt, vals
    keep = ~_copies(stamp, vals)
    if keep.all() or not _stamps_ok(stamp[keep]):
        return stamp, logt, vals
    warnings.warn(
        f"{path.name}: {int(stamp.size - keep.sum())} of the {stamp.size} messages of {topic!r} repeat an earlier message (the "
        "same header stamp and values: recorded twice) and are left out",
        stacklevel=3,
    )
    return stamp[keep], logt[keep], tuple(v[keep] for v in vals)


def _unmeasured(path: Path, topic: str, vals: tuple, finite=None) -> set:
    """The Imu value groups (0 angular velocity, 1 linear acceleration) NaN in every message of ``topic`` — not
    measured (covariance element 0 at -1, see :meth:`_Decoder.values`, or NaN published), so not read: an
    accelerometer-only unit's zero angular velocity was read as a gyroscope at rest (attitude with exit 0).
    ``finite``: whether each group has a number anywhere, when the values come in blocks. Warns for each."""
    if finite is None:
        finite = [bool(v.size and (not np.isnan(v.flat[0]) or not np.all(np.isnan(v)))) for v in vals]
    out = {k for k, ok in enumerate(finite) if not ok}
    for k in sorted(out):
        what = ("angular velocity", "gyroscope") if k == 0 else ("linear acceleration", "accelerometer")
        warnings.warn(
            f"{path.name}: {topic!r} marks its {what[0]} as not measured (covariance element 0 = -1, or NaN in every "
            f"message): read without {what[1]} data",
            stacklevel=3,
        )
    return out


def _time_base(
    path: Path,
    topic: str,
    stamp: np.ndarray,
    t_log: np.ndarray,
    ok: bool | None = None,
    other: str | None = None,
    *,
    own: bool | None = None,
) -> np.ndarray:
    """Header stamps (s) when they are set and strictly increasing (``own``: that verdict for these when known,
    ``ok``: for every topic read together); else the bag's log (receive) times ``t_log`` (ns, converted to s only
    then), with a warning — naming ``other``, the topic whose stamps made it so, when this one's own are fine."""
    own = _stamps_ok(stamp) if own is None else own
    if own and ok is not False:
        return stamp
    fault = _stamp_fault(stamp) if not own else f"fine, but those of {other!r} are not"
    _log_times_distinct(path, topic, fault, t_log)
    if own:
        _one_clock_warning(path, other, topic, stacklevel=5)
    else:
        _log_time_warning(path, topic, fault)
    return t_log * 1e-9


def _log_times_distinct(path: Path, topic: str, fault: str, t_log: np.ndarray) -> None:
    """Refuse log times (ns, in order) that repeat when they are to be the time: the stamps are ``fault``; the
    error named a time column and --columns/--rate, neither of which a bag takes (a recorder on a simulated
    clock logs several messages at one tick)."""
    same = int(np.sum(np.diff(t_log) == 0))
    if same:
        raise OptinavError(
            f"{path.name}: the header stamps of {topic!r} are {fault}, and the bag's log times cannot replace them: "
            f"{same} of {t_log.size} equal the one before (a recorder on a simulated clock)",
            "have the driver stamp its messages, or export the topic (values only) and give its rate with --rate",
        )


def _check_mag_overlap(path: Path, imu_topic: str, span: tuple, mag_topic: str, tm: np.ndarray) -> None:
    """Warn when a MagneticField topic's times never meet the Imu topic's ``span`` (s): a driver stamping on
    another clock leaves the magnetometer NaN at every IMU sample (``attitude --mag`` then refuses it; without
    --mag nothing needs it)."""
    if tm.size and (float(np.max(tm)) < span[0] or float(np.min(tm)) > span[1]):
        warnings.warn(
            f"{path.name}: the times of {mag_topic!r} ({float(np.min(tm)):.6g}–{float(np.max(tm)):.6g} s) never meet "
            f"those of {imu_topic!r} ({span[0]:.6g}–{span[1]:.6g} s): the two topics are stamped on different "
            "clocks, and the magnetometer reads NaN at every IMU sample",
            stacklevel=4,
        )


def _one_clock_warning(path: Path, bad: str, topic: str, stacklevel: int) -> None:
    """``topic``'s own stamps are fine, but ``bad``'s are not: both are read on the bag's log times."""
    warnings.warn(
        f"{path.name}: the header stamps of {bad!r} are not usable, so {topic!r} too is read on the bag's log times "
        "(one clock for both topics)",
        stacklevel=stacklevel,
    )


def _log_time_warning(path: Path, topic: str, why: str) -> None:
    warnings.warn(
        f"{path.name}: the header stamps of {topic!r} are {why}; using the bag's log times instead "
        "(receive times, with their jitter)",
        stacklevel=4,
    )


def _resample(t_src: np.ndarray, v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``v(t_src)`` linearly interpolated at ``t``; the end values held up to two sample intervals beyond the span
    of ``t_src`` (the magnetometer starting a moment after the IMU), NaN farther out."""
    order = np.argsort(t_src, kind="stable")
    ts, vs = t_src[order], v[order]
    out = np.interp(t, ts, vs)
    reach = 2.0 * float(np.median(np.diff(ts))) if ts.size > 1 else 0.0
    out[(t < ts[0] - reach) | (t > ts[-1] + reach)] = np.nan
    return out


# --- block by block -------------------------------------------------------------------------------------------


def iter_bag(path, *, topic=None, chunk_rows: int, progress=None):
    """:func:`load_bag` in tables of ``chunk_rows`` Imu messages, so that memory does not grow with the bag:
    two passes over the storage's blocks (:mod:`optinav.io.bagscan`), the first decoding only to choose the time
    base (header stamps when all are set and increasing, else log times, as :func:`load_bag`) and to count, the
    second yielding the tables; a MagneticField topic is read whole and interpolated onto each table's stamps. A
    bag the scanners do not read, log times out of the storage's order, a count that differs from the index, header
    stamps neither fine nor all zero (copies to leave out), or at most ``chunk_rows`` messages: one table from
    :func:`load_bag`. ``progress(fraction)`` after each table."""
    path = Path(path)
    twin = _readable_twin(path) if path.exists() else None
    if twin is not None:  # the copy streamed like any bag (a recovered hours-long recording in bounded memory)
        tables = iter_bag(twin, topic=topic, chunk_rows=chunk_rows, progress=progress)
        while (table := _as_path(path, twin, lambda: next(tables, None))) is not None:
            yield table
        return
    plan = _stream_plan(path, _parse_topics(topic))
    if plan is None:
        yield load_bag(path, topic=topic)
        return
    try:
        yield from _stream(path, plan, int(chunk_rows), progress, topic)
    finally:
        plan["close"]()


def _stream_plan(path: Path, wanted: list[str]) -> dict | None:
    """How to read ``path`` block by block (types, topics chosen, a block source per topic), or None."""
    from optinav.io import bagscan

    if sys.byteorder != "little" or not path.exists() or any("@" in k for k in wanted):
        return None  # (a frame_id asked for: read whole, the frames sorted out there)
    try:
        if path.is_file() and path.suffix.lower() == ".bag":
            got = _ros1_setup(path, wanted)
            if got is None:
                return None
            types, topics, (imu, mag) = got
            if any(len(topics[k]["cons"]) > 1 for k in (imu, mag) if k is not None):
                return None  # several publishers: load_bag reads each (_one_publisher)
            blocks = lambda name: bagscan.blocks(types, path, name)  # noqa: E731
            return {"types": types, "ros1": True, "topics": topics, "imu": imu, "mag": mag, "count": True,
                    "blocks": blocks, "close": lambda: None}  # fmt: skip
        files = _sqlite_files(path)
        if files is not None:
            got = _sqlite_setup(path, files, wanted)
            if got is None:
                return None
            types, topics, (imu, mag) = got
            blocks = lambda name: itertools.chain.from_iterable(bagscan.sqlite_blocks(f, name) for f in files)  # noqa: E731
            return {"types": types, "ros1": False, "topics": topics, "imu": imu, "mag": mag, "count": False,
                    "blocks": blocks, "close": lambda: None}  # fmt: skip
        reader = _rosbags()([path])
        reader.open()
    except Exception:  # noqa: BLE001 - anything the scanners or rosbags do not read: load_bag names it
        return None
    try:
        topics = _reader_topics(reader)
        imu, mag = _choose(path, topics, wanted)
        if bagscan.blocks(reader, path, imu) is None:
            raise bagscan.NotFast("rosbags' iteration")
    except Exception:  # noqa: BLE001 - a bag the scanners do not read (or a topic error load_bag gives)
        reader.close()
        return None
    return {"types": reader, "ros1": False, "topics": topics, "imu": imu, "mag": mag, "count": True,
            "blocks": lambda name: bagscan.blocks(reader, path, name), "close": reader.close}  # fmt: skip


def _decoded(plan: dict, name: str):
    """(stamps s, log times ns, values) of each storage block of topic ``name``; valid until the next."""
    dec = _Decoder(plan["types"], plan["ros1"], plan["topics"][name]["type"], _BLOCK, grow=True)
    for block in plan["blocks"](name):
        n = dec.run([block], strict=False)
        if len(dec.frames) > 1:
            raise ValueError("several frame_ids")  # read whole: load_bag keeps one or refuses
        yield dec.stamp[:n], dec.logt[:n], dec.values(n)


def _stream(path: Path, plan: dict, chunk_rows: int, progress, topic):
    name = plan["imu"]
    # first pass: the time base and the count, and the magnetometer whole (anything unexpected: read whole)
    total, prev_s, prev_l, stamps_ok, zero, mag, same_l = 0, -np.inf, None, True, True, None, False
    first_s = first_l = None
    try:
        finite = [False, False]
        for stamp, logt, vals in _decoded(plan, name):
            if not stamp.size:
                continue
            finite = [f or not np.all(np.isnan(v)) for f, v in zip(finite, vals)]
            if first_s is None:
                first_s, first_l = float(stamp[0]), int(logt[0])
            if (prev_l is not None and logt[0] < prev_l) or np.any(logt[1:] < logt[:-1]):
                raise ValueError("log times out of the storage's order")
            stamps_ok = stamps_ok and bool(stamp[0] > prev_s and np.all(np.diff(stamp) > 0) and np.all(stamp > 0))
            zero = zero and not np.any(stamp)
            same_l = same_l or (prev_l is not None and logt[0] == prev_l) or bool(np.any(logt[1:] == logt[:-1]))
            prev_s, prev_l = float(stamp[-1]), int(logt[-1])
            total += stamp.size
        if plan["mag"] is not None:  # a few values per Imu message at most
            parts = [(s.copy(), lt.copy(), v[0].copy()) for s, lt, v in _decoded(plan, plan["mag"])]
            mag = tuple(np.concatenate([p[j] for p in parts]) for j in range(3)) if parts else None
            if mag is None or not mag[0].size or np.any(mag[1][1:] < mag[1][:-1]):
                raise ValueError("no magnetometer messages, or out of the storage's order")
            if plan["count"] and mag[0].size != plan["topics"][plan["mag"]]["count"]:
                raise ValueError("magnetometer messages other than the index counts")
    except Exception:  # noqa: BLE001 - load_bag reads it (through rosbags if need be) and names any damage
        yield load_bag(path, topic=topic)
        return
    count = plan["topics"][name]["count"]
    # stamps neither fine nor all zero: copies to leave out, and their faults named, need the whole topic
    if total <= chunk_rows or (plan["count"] and total != count) or not (stamps_ok or zero) or (zero and same_l):
        yield load_bag(path, topic=topic)
        return
    drop = _unmeasured(path, name, (), finite)
    if mag is not None:
        stamp, logt, (b,), mag_ok = _stamps_mended(path, plan["mag"], *mag[:2], (mag[2],))
        mag = stamp, logt, b
    else:
        mag_ok = True
    if not stamps_ok:
        _log_time_warning(path, name, "zero")
    elif not mag_ok:  # one clock for both topics (see load_bag)
        _one_clock_warning(path, plan["mag"], name, stacklevel=4)
        stamps_ok = False
    if mag is not None:
        mag = (_time_base(path, plan["mag"], mag[0], mag[1], stamps_ok and mag_ok, name, own=mag_ok), mag[2])
        span = (first_s, prev_s) if stamps_ok else (first_l * 1e-9, prev_l * 1e-9)
        _check_mag_overlap(path, name, span, plan["mag"], mag[0])
    try:  # second pass (the first read the same blocks: an error here is the storage changing under it)
        yield from _tables(path, plan, chunk_rows, progress, total, stamps_ok, mag, drop)
    except OptinavError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise OptinavError(f"{path.name} is not a readable ROS bag ({_why(exc)})", "read it again") from None


def _tables(path: Path, plan: dict, chunk_rows: int, progress, total: int, stamps_ok: bool, mag, drop: set):
    """The second pass of :func:`iter_bag`: the tables of ``chunk_rows`` messages (without the value groups
    ``drop``, see :func:`_unmeasured`)."""
    name = plan["imu"]
    held, have, done = [], 0, 0
    for stamp, logt, (gyr, acc) in _decoded(plan, name):
        held.append((stamp.copy() if stamps_ok else logt * 1e-9, gyr.copy(), acc.copy()))  # the decoder reuses them
        have += stamp.size
        while have >= chunk_rows or (have and done + have == total):
            k = min(chunk_rows, have)
            t, g, a = (np.concatenate([h[j] for h in held]) for j in range(3))
            rest = (t[k:], g[k:], a[k:])
            held, have = ([rest] if rest[0].size else []), rest[0].size
            done += k
            if progress is not None:
                progress(done / total)
            g, a = (None if j in drop else v[:k] for j, v in enumerate((g, a)))
            yield _bag_table(path, name, t[:k], g, a, plan["mag"], mag, done - k)
    if done != total:  # the storage changed between the passes
        raise OptinavError(f"{path.name} changed while it was read ({done} of {total} messages)", "read it again")


def _bag_table(path: Path, topic: str, t, gyr, acc, mag_topic, mag, row0: int):
    """The :func:`load_bag` table of the messages ``t``, ``gyr``, ``acc`` ((n, 3) each, or None: not measured;
    the columns are their views, which read_imu takes back whole), from row ``row0``; ``mag``: the whole (stamps,
    values) of the MagneticField topic, interpolated onto ``t``."""
    from optinav.io.readers import Table

    table = Table(path=path, kind="rosbag", data={"t": t}, row0=row0)
    for tri, p, unit in ((acc, "a", "m/s^2"), (gyr, "g", "rad/s")):
        if tri is not None:
            for j, a in enumerate("xyz"):
                table.data[f"{p}{a}"] = tri[:, j]
                table.units[f"{p}{a}"] = unit
    table.units["t"] = "s"
    table.meta.update({"topic": topic, "frame": "sensor_msgs/Imu"})
    if mag is not None:
        for j, a in enumerate("xyz"):
            table.data[f"m{a}"] = _resample(mag[0], mag[1][:, j], t)
            table.units[f"m{a}"] = "T"
        table.meta["mag_topic"] = mag_topic
    return table
