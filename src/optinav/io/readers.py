"""Tabular data files → named numpy arrays: text (CSV/TSV/whitespace), NPZ/NPY, HDF5 and MATLAB (v4/v5, v7.3).

:func:`read_table` is the public entry; :func:`load_table` returns the :class:`Table` with the file's declared
units and metadata that :func:`optinav.io.read_imu` interprets. File formats and column naming:
docs/file-formats.md. Every bad input ends in a one-line :class:`~optinav.errors.OptinavError`; pickles are
never loaded.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import operator
import gzip
import io
import itertools
import posixpath
import re
import zlib
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = [
    "read_table",
    "load_table",
    "iter_table",
    "TableChunks",
    "parse_columns",
    "Table",
    "SUFFIXES",
    "LABEL_COLUMNS",
    "SKIP_NAMES",
    "CHUNK_ROWS",
]

#: file suffix → format (``.gz`` after a text suffix is decompressed first)
SUFFIXES: dict[str, str] = {
    ".csv": "text",
    ".tsv": "text",
    ".txt": "text",
    ".dat": "text",
    ".log": "text",
    ".npz": "npz",
    ".npy": "npy",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".mat": "mat",
    ".parquet": "parquet",
    ".pq": "parquet",
    ".bag": "rosbag",
    ".db3": "rosbag",
    ".mcap": "rosbag",
    ".ulg": "ulog",
}
#: suffixes of text files that hold no table of samples (a result, a configuration or notes passed as data):
#: refused by their suffix, where other unknown suffixes are read as text (:func:`_file_kind`)
NOT_TABLES = (".json", ".jsonl", ".yaml", ".yml", ".md", ".rst", ".html", ".htm", ".xml", ".toml", ".ini", ".cfg",
              ".py", ".ipynb", ".calib")  # fmt: skip
#: column names (normalized, see :func:`normalize_name`) whose cells may be text: kept as a str array
LABEL_COLUMNS = ("part", "label", "labels", "section", "segment", "pose", "phase")
#: positional column names that skip a column
SKIP_NAMES = ("_", "-")

_MAX_LISTED = 20
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+([eE][+-]?\d+)?$")
_BRACKET_UNIT = re.compile(r"^(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")
#: an array index 0–2 right after a name (pyulog's ``gyro_rad[0]``): the axis x–z, not a unit
_AXIS_INDEX = re.compile(r"^(.*\S)\[([012])\]\s*$")


class MissingColumn(OptinavError):
    """A column or dataset a caller named that the file lacks: ``name``, and ``found``, the names the file has (a
    caller that knows which option named it can say so)."""

    def __init__(self, cause: str, remedy: str, *, name: str, found: list):
        super().__init__(cause, remedy)
        self.name, self.found = name, found


@dataclasses.dataclass
class Table:
    """The raw content of a data file.

    ``data`` maps names (header names, ``col1..colN`` without a header, NPZ array names, HDF5/MAT paths such
    as ``imu/acc``) to 1-D columns or 2-D arrays; ``units`` maps names to units the file declares (header
    brackets ``acc_x [g]``, a units row, HDF5 ``unit`` attributes); ``meta`` holds file-level strings
    (``acc_unit``, ``gyro_unit``, ``time_unit`` from an optinav comment line, NPZ/MAT variables, HDF5
    attributes). ``table`` names the 2-D array split into ``col1..colK`` when the file held a single one.
    """

    path: Path
    kind: str
    data: dict[str, np.ndarray]
    units: dict[str, str] = dataclasses.field(default_factory=dict)
    meta: dict[str, str] = dataclasses.field(default_factory=dict)
    table: str | None = None
    table_array: np.ndarray | None = None
    skipped: dict[str, str] = dataclasses.field(default_factory=dict)
    #: index of the first row in the file (0 unless the table is one block of a streamed file)
    row0: int = 0
    #: names of a streamed binary file's arrays that are not of the blocks' length (such as a 3×3 matrix beside
    #: the samples): whole in the first block, empty in the others, so that each name's blocks join to the file's
    fixed: frozenset = frozenset()
    #: lines of a text table left out as unreadable (``skip_bad_lines``): where each was among the rows kept
    #: (``numpy.insert`` positions) and its file line number
    bad_rows: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    bad_lines: tuple = ()

    def names(self, limit: int = _MAX_LISTED) -> str:
        """The available names as one short comma list (for error messages)."""
        names = list(self.data)
        more = f", … ({len(names) - limit} more)" if len(names) > limit else ""
        text = ", ".join(names[:limit]) + more if names else "none"
        if self.table is not None:
            text += f" (columns of the {self.table_array.shape[0]}×{self.table_array.shape[1]} array {self.table!r})"
        if self.skipped:
            text += "; unreadable: " + ", ".join(f"{k} ({v})" for k, v in list(self.skipped.items())[:5])
        single = _single_values(self)
        if single:
            text += f"; single values: {single}"
        return text

    def find(self, name: str) -> str | None:
        """The key matching ``name``: exactly, without a leading '/', with '.' for '/', or case-insensitively."""
        for cand in (name, name.lstrip("/"), name.lstrip("/").replace(".", "/")):
            if cand in self.data:
                return cand
        low = [k for k in self.data if k.lower() == name.lstrip("/").lower()]
        return low[0] if len(low) == 1 else None

    def normal_names(self) -> dict[str, str]:
        """{normalized name (:func:`normalize_name`: a unit in brackets, case, spaces aside) → key} of the arrays
        now in ``data`` (a later key with the same normalized name wins)."""
        return {normalize_name(k)[0]: k for k in self.data}

    def get(self, name: str) -> np.ndarray:
        """The array called ``name`` (see :meth:`find`); a clear error listing what exists otherwise."""
        key = self.find(name)
        if key is None and self.table is not None and name.lstrip("/").lower() == self.table.lower():
            return self.table_array
        if key is None:
            if self.kind == "rosbag" and name.lstrip("/").lower() in ("mx", "my", "mz"):
                raise OptinavError(
                    f"{self.path.name} has no MagneticField topic read with its Imu topic {self.meta.get('topic')!r}",
                    "name both topics with --topic IMU,MAG, or drop --mag",
                )
            what = "column" if self.kind == "text" else "array/dataset"
            raise MissingColumn(
                f"{self.path} has no {what} named {name!r} (found: {self.names()})",
                "use one of the names found",
                name=name,
                found=list(self.data),
            )
        return self.data[key]


# --- column specifications ----------------------------------------------------------------------------------


def parse_columns(columns, what: str = "columns") -> tuple[list[str] | None, dict[str, str]]:
    """Split a column specification into positional names and ``std=name`` mappings.

    ``columns`` is a comma list (``"t,ax,ay,az,_,gx,gy,gz"`` or ``"t=time,ax=acc_x"``), a sequence of such
    entries or a mapping ``{std: name}``. Returns ``(positional or None, mapping)``; the two kinds cannot mix.
    """
    if columns is None:
        return None, {}
    if isinstance(columns, Mapping):
        items = [f"{k}={v}" for k, v in columns.items()]
    elif isinstance(columns, str):
        items = columns.split(",")
    elif isinstance(columns, Sequence):
        items = [str(c) for c in columns]
    else:
        raise OptinavError(
            f"{what} must be a comma list, a list of names or a mapping, got {type(columns).__name__}",
            f"pass e.g. {what}='t,ax,ay,az'",
        )
    items = [c.strip() for c in items]
    if not items or any(not c for c in items):
        raise OptinavError(f"{what} {columns!r} has an empty entry", "give one name per column, '_' to skip one")
    mapped = [c for c in items if "=" in c]
    if mapped and len(mapped) != len(items):
        raise OptinavError(
            f"{what} {columns!r} mixes positional names and std=name entries",
            "use either one name per column in order, or only std=name entries",
        )
    if not mapped:
        seen = [c for c in items if c not in SKIP_NAMES]
        dup = sorted({c for c in seen if seen.count(c) > 1})
        if dup:
            raise OptinavError(
                f"{what} names {', '.join(map(repr, dup))} more than once", "give each column its own name"
            )
        return items, {}
    mapping: dict[str, str] = {}
    for entry in items:
        std, _, name = (s.strip() for s in entry.partition("="))
        if not std or not name:
            raise OptinavError(f"{what} entry {entry!r} is incomplete", "write entries as std=name, e.g. t=timestamp")
        if std in mapping:
            raise OptinavError(f"{what} maps {std!r} twice", "give one source per standard name")
        mapping[std] = name
    return None, mapping


# --- public entry points ------------------------------------------------------------------------------------


def merge_datasets(mapping: dict, datasets, what: str = "columns") -> dict:
    """Add ``datasets`` (``{std: name}`` or ``"std=name,..."``) to the ``std=name`` ``mapping`` of ``what``."""
    if datasets is None:
        return mapping
    _, extra = parse_columns(datasets, "datasets")
    if not extra:
        raise OptinavError("datasets must map names to dataset paths", "pass e.g. datasets={'t': '/imu/time'}")
    for k, v in extra.items():
        if k in mapping and mapping[k] != v:
            raise OptinavError(f"{k!r} is mapped by both {what} ({mapping[k]!r}) and datasets ({v!r})", "map it once")
        mapping[k] = v
    return mapping


def read_table(
    path,
    *,
    columns=None,
    delimiter: str | None = None,
    datasets=None,
    text_columns: Sequence[str] = LABEL_COLUMNS,
    topic=None,
    skip_bad_lines: bool = False,
    rows: int | None = None,
) -> dict[str, np.ndarray]:
    r"""Read a data file into ``{name: array}``.

    Formats by suffix: ``.csv .tsv .txt .dat`` (optionally ``.gz``; header auto-detected, ``#`` comments,
    delimiter ``, \t ;`` or whitespace auto-detected), ``.npz``/``.npy`` (no pickles), ``.h5``/``.hdf5`` (h5py),
    ``.mat`` (v4/v5 via scipy, v7.3 via h5py, transposed back to MATLAB's row/column layout), ``.parquet``/``.pq``
    (pyarrow; :mod:`optinav.io.parquet`), ROS bags ``.bag``, ``.db3``, ``.mcap`` or a ROS 2 bag folder
    (rosbags; :mod:`optinav.io.rosbag`), PX4 ULog files ``.ulg`` (pyulog; :mod:`optinav.io.ulog`).

    Parameters
    ----------
    path : str or Path
        The data file (or ROS 2 bag folder).
    columns : str, sequence of str or None
        Names of the file's columns in order (``"_"``/``"-"`` skips one; a header line is then ignored), or
        ``std=name`` entries returning only those names, taken from header columns, NPZ arrays or datasets.
    delimiter : str or None
        Text delimiter; None: auto-detected.
    datasets : dict or None
        ``{std: dataset path}`` (as ``std=name`` entries; reads only those datasets of an HDF5 file).
    text_columns : sequence of str
        The only columns allowed to hold text cells (labels, returned as str arrays); elsewhere text is an error.
    topic : str or None
        A ROS bag's Imu[,MagneticField] topic; None: its only one. A ULog's topic (``vehicle_imu@1``); None:
        ``sensor_combined``.
    skip_bad_lines : bool
        Leave a text table's unreadable lines out (at most 1 % of them) instead of refusing the file.
    rows : int or None
        With ``skip_bad_lines``: the rows the IMU of the same file kept (:func:`with_lost_rows`), so that extra
        columns (magnetometer, polarization) line up with its rows.

    Returns
    -------
    dict of str to ndarray
        Every column/array under its own name (``col1..colN`` for a text file without a header or a file holding
        a single 2-D array) unless ``columns``/``datasets`` select [the file's units].
    """
    positional, mapping = parse_columns(columns)
    merge_datasets(mapping, datasets)
    table = load_table(
        path,
        names=positional,
        delimiter=delimiter,
        only=list(mapping.values()) or None,
        text_columns=text_columns,
        topic=topic,
        skip_bad_lines=skip_bad_lines,
    )
    out = {std: table.get(name) for std, name in mapping.items()} if mapping else dict(table.data)
    if rows is not None:
        out = {k: with_lost_rows(v, table.bad_rows, rows) for k, v in out.items()}
    return out


def with_lost_rows(values: np.ndarray, bad_rows: np.ndarray, rows: int) -> np.ndarray:
    """A column of a table read with ``skip_bad_lines``, with NaN rows where its unreadable lines stood when the
    IMU's rows kept them (a log without a time column keeps a lost line as a NaN row, so that the rate times
    the rows after it): ``values`` short of ``rows`` by exactly the lines left out; otherwise as it is."""
    if bad_rows.size and values.shape[0] + bad_rows.size == rows:
        return np.insert(np.asarray(values, dtype=float), bad_rows, np.nan, axis=0)
    return values


def _text_despite_suffix(path: Path, exc: OptinavError) -> OptinavError:
    """``exc`` from reading ``path`` as text, with the hint that it holds text when its suffix names a binary
    format (.npz, .mat, .h5, …); unchanged for a text suffix."""
    suffix = _suffix(path)
    if "despite its" in exc.cause or "read as text" in exc.cause:
        return exc
    if suffix not in SUFFIXES:  # none, or one optinav does not know: read as text by its content
        shown = suffix or "(none)"
        return OptinavError(f"{exc.cause} (read as text: its suffix {shown} names no format optinav reads)", exc.remedy)
    if SUFFIXES[suffix] == "text":
        return exc
    return OptinavError(f"{exc.cause} (the file holds text despite its {suffix} suffix)", exc.remedy)


def load_table(
    path,
    *,
    names: Sequence[str] | None = None,
    delimiter: str | None = None,
    only: Sequence[str] | None = None,
    text_columns: Sequence[str] = LABEL_COLUMNS,
    topic=None,
    needed=None,
    skip_bad_lines: bool = False,
    raw: bytes | None = None,
) -> Table:
    """Read ``path`` into a :class:`Table` (see :func:`read_table`).

    ``names``: positional column names (skip names dropped); ``only``: the names/dataset paths needed (lets the
    HDF5 reader read just those); ``topic``: the ROS bag topic(s) (bags only); ``needed(name)``: whether a text
    file's column is used — one that is not and holds text in the first data row is left out (a frame id
    beside the values), instead of being an error; ``skip_bad_lines``: a text table's unreadable lines (a
    garbled cell, too few or too many fields) are left out and listed in ``bad_rows``/``bad_lines`` instead of
    being an error, up to :data:`MAX_BAD_FRACTION` of its lines; ``raw``: a text table's bytes, ``path`` only
    naming it (a zip's member read in memory).
    """
    path = Path(path)
    if raw is not None:
        _check_select(path, topic)
        labels = {normalize_name(n)[0] for n in text_columns}
        return _selected(_load_text(path, raw, names, delimiter, labels, needed, skip_bad_lines), topic)
    kind, gz = _file_kind(path)
    if kind == "rosbag":
        from optinav.io.rosbag import load_bag

        _no_option(path, delimiter=delimiter, names=names)
        return load_bag(path, topic=topic)
    if kind == "ulog":
        from optinav.io.ulog import load_ulog

        _no_option(path, True, delimiter=delimiter, names=names)
        return load_ulog(path, topic=topic, skip_bad_lines=skip_bad_lines)
    _check_select(path, topic)
    if kind == "kitti_oxts":
        if names is not None or delimiter is not None:
            raise OptinavError(
                f"{path.name} is a KITTI oxts folder, read by its fields' names (ax … wz, af … wu)",
                "drop the delimiter and positional columns; map a field with std=name entries (ax=af, …)",
            )
        return _selected(_load_kitti_oxts(path), topic)
    labels = {normalize_name(n)[0] for n in text_columns}
    if kind == "text":
        try:
            table = _load_text(path, _read_bytes(path, gz), names, delimiter, labels, needed, skip_bad_lines)
        except OptinavError as exc:
            raise _text_despite_suffix(path, exc) from None
    else:
        if delimiter is not None:
            raise OptinavError(f"delimiter applies to text files, not to {path.name}", "drop the delimiter option")
        if kind == "parquet":
            from optinav.io.parquet import load_parquet

            return _selected(load_parquet(path, names=names, only=only), topic)
        if kind in ("npz", "npy"):
            table = _load_numpy(path)
        elif kind == "hdf5":
            table = _load_hdf5(path, only, matlab=False)
        else:
            table = _load_mat(path, only)
        table = _split_single_table(table)
        if names is not None:
            table = _name_table_columns(table, names)
    return _selected(table, topic)


#: the 30 values of each file of a KITTI raw ``oxts/data`` folder (the devkit's dataformat.txt): position, attitude
#: (rad), velocities; ``ax ay az`` the specific force (m/s², gravity in it) and ``wx wy wz`` the rate (rad/s) in the
#: vehicle's axes (x forward, y left, z up); ``af al au``/``wf wl wu`` the same in axes levelled to the road
KITTI_OXTS_FIELDS = (
    "lat lon alt roll pitch yaw vn ve vf vl vu ax ay az af al au wx wy wz wf wl wu "
    "pos_accuracy vel_accuracy navstat numsats posmode velmode orimode"
).split()


def _load_kitti_oxts(path: Path) -> Table:
    """A KITTI raw ``oxts`` folder as one table: ``time`` (s since the epoch, from ``timestamps.txt``, taken as
    UTC) and the 30 values of each ``data/NNNNNNNNNN.txt`` (one sample per file) under :data:`KITTI_OXTS_FIELDS`."""
    d = kitti_oxts_folder(path)
    files = sorted((d / "data").glob("*.txt"))
    stamps = [x for x in (d / "timestamps.txt").read_text(errors="replace").splitlines() if x.strip()]
    if not files or len(stamps) != len(files):
        raise OptinavError(
            f"{d}: {len(stamps)} lines in timestamps.txt for {len(files)} files in data/",
            "pass a KITTI oxts folder as extracted (one time per data file)",
        )
    rows = np.empty((len(files), len(KITTI_OXTS_FIELDS)))
    for i, f in enumerate(files):
        cells = f.read_text(errors="replace").split()
        try:
            if len(cells) != rows.shape[1]:
                raise ValueError
            rows[i] = [float(c) for c in cells]
        except ValueError:
            raise OptinavError(
                f"{f}: {len(cells)} values, not KITTI's {rows.shape[1]} numbers of an oxts sample",
                "pass a KITTI raw oxts folder as extracted",
            ) from None
    data = {"time": _epoch_seconds(d / "timestamps.txt", "time", np.array(stamps))}
    data.update({k: rows[:, j] for j, k in enumerate(KITTI_OXTS_FIELDS)})
    units = {"time": "s", **{k: "m/s^2" for k in ("ax", "ay", "az")}, **{k: "rad/s" for k in ("wx", "wy", "wz")}}
    return Table(path, "kitti_oxts", data, units, {"kitti_oxts": d.name})


def _check_select(path: Path, topic) -> None:
    """A topic given for a file that is no ROS bag: only ``NAME@ID`` (one instance of a table holding several, see
    :func:`optinav.io.imu`'s instance selection) applies."""
    if topic is not None and "@" not in str(topic):
        raise OptinavError(
            f"a topic applies to ROS bags, not to {path.name}",
            "drop --topic (NAME@ID picks one sensor of a table of several: --topic IMU@1 for ArduPilot's instance 1)",
        )


def _selected(table: Table, topic) -> Table:
    """``table`` with the ``NAME@ID`` selection recorded in ``meta['select']`` (applied by read_imu)."""
    if topic is not None:
        table.meta["select"] = str(topic)
    return table


#: lines per block of the streamed text reader (:func:`iter_table`), defined beside the atomic writers so that the
#: CLI's parser can show it without loading numpy
from optinav.core.files import CHUNK_ROWS, HDF5_MAGIC as _HDF5_MAGIC, kitti_oxts_folder  # noqa: E402


def iter_table(
    path,
    *,
    names: Sequence[str] | None = None,
    delimiter: str | None = None,
    only: Sequence[str] | None = None,
    text_columns: Sequence[str] = LABEL_COLUMNS,
    chunk_rows: int | None = None,
    topic=None,
    needed=None,
    skip_bad_lines: bool = False,
) -> "TableChunks":
    """:func:`load_table` in blocks, so that memory does not grow with the file.

    Text files (gzip too) are read line block by line block; NPY, NPZ, HDF5, MATLAB v5/v7/v7.3 and Parquet
    files a block of rows at a time (:mod:`optinav.io.arrayblocks`: arrays of another length than the samples'
    whole in the first block and empty after it, named in ``Table.fixed``); MATLAB v4 files and ROS bags come as
    a single table. The layout (header, units, preamble, delimiter) comes from the first lines;
    a bad cell fails when its block is parsed, naming its line and column; an incomplete last line is dropped and
    reported in the last block's ``meta['truncated_line']`` as :func:`load_table` does.

    Parameters
    ----------
    path : str or Path
        The data file.
    names : sequence of str or None
        Names of the file's columns in order (as ``columns`` of :func:`read_table`); None: from the header.
    delimiter : str or None
        Text delimiter; None: auto-detected.
    only : sequence of str or None
        Return only these columns.
    text_columns : sequence of str
        The only columns allowed to hold text cells.
    chunk_rows : int or None
        Rows per block; None: :data:`CHUNK_ROWS`.
    topic : str or None
        A ROS bag's Imu topic; None: its only one.
    needed : callable or None
        ``needed(name)``: whether a text file's column is used; one that is not and holds text in the first data
        row is left out (see :func:`load_table`). None: every column is parsed.
    skip_bad_lines : bool
        Leave a text table's unreadable lines out (see :func:`load_table`); each block lists its own, and the
        file's share is checked at its end.

    Returns
    -------
    TableChunks
        An iterable of :class:`Table` (``row0``: the block's first row in the file).
    """
    return TableChunks(Path(path), names, delimiter, only, text_columns, chunk_rows, topic, needed, skip_bad_lines)


class TableChunks:
    """The blocks of :func:`iter_table`; ``size`` (bytes of the file) and ``position`` (bytes read so far, of the
    compressed file for ``.gz``) tell the progress."""

    def __init__(
        self,
        path: Path,
        names,
        delimiter,
        only,
        text_columns,
        chunk_rows: int | None,
        topic=None,
        needed=None,
        skip_bad_lines: bool = False,
    ):
        chunk_rows = CHUNK_ROWS if chunk_rows is None else chunk_rows
        if int(chunk_rows) < 1:
            raise OptinavError(f"chunk_rows={chunk_rows} must be >= 1", "pass a positive number of rows")
        self.path, self.names, self.delimiter, self.only = path, names, delimiter, only
        self.text_columns, self.chunk_rows, self.topic = text_columns, int(chunk_rows), topic
        self.needed, self.skip_bad_lines = needed, skip_bad_lines
        self.kind, self.gz = _file_kind(path)
        if self.kind not in ("rosbag", "ulog"):  # as load_table: a text file read in blocks ignored it
            _check_select(path, topic)
        self.size = path.stat().st_size
        self.position = 0

    @property
    def blockwise(self) -> bool:
        """Whether the blocks are read one at a time (False: the file comes whole as one table)."""
        if self.kind == "text":
            return True
        if self.kind == "rosbag":  # (a bag the scanners do not read comes as one table)
            return self.delimiter is None and self.names is None
        if self.kind in ("kitti_oxts", "ulog"):  # a file per sample; a ULog pyulog parses whole: one table
            return False
        if self.kind == "mat":
            from optinav.io.arrayblocks import is_mat5

            plain = _mat_flavour(self.path) != "mat" or is_mat5(self.path)  # not MATLAB v4
            return plain and self.delimiter is None and self.topic is None
        return self.delimiter is None and self.topic is None

    def __iter__(self):
        if self.kind != "text":
            yield from self._binary()
            self.position = self.size
            if self.kind == "parquet":
                # what pyarrow freed goes back to the OS (its pool keeps it otherwise: ~100 MiB that a caller
                # holding the log, such as calibrate, would carry on top of it to its peak)
                import pyarrow as pa

                pa.default_memory_pool().release_unused()
            return
        try:
            yield from self._text()
        except OptinavError as exc:
            raise _text_despite_suffix(self.path, exc) from None
        except OSError as exc:  # includes gzip.BadGzipFile
            raise OptinavError(
                f"cannot read {self.path} ({exc})", "check the file (a .gz file must be gzip-compressed)"
            ) from None
        except (EOFError, zlib.error) as exc:  # truncated or corrupt gzip stream
            raise OptinavError(f"{self.path} is a damaged gzip file ({exc})", "re-export or decompress it") from None

    def _binary(self):
        def load():
            return load_table(
                self.path,
                names=self.names,
                delimiter=self.delimiter,
                only=self.only,
                text_columns=self.text_columns,
                topic=self.topic,
                skip_bad_lines=self.skip_bad_lines,
            )

        def progress(fraction: float) -> None:
            self.position = int(fraction * self.size)

        if not self.blockwise:
            yield load()  # MATLAB v4 files are read whole; the options give their errors
        elif self.kind == "rosbag":
            from optinav.io.rosbag import iter_bag

            yield from iter_bag(self.path, topic=self.topic, chunk_rows=self.chunk_rows, progress=progress)
        elif self.kind == "parquet":
            from optinav.io.parquet import iter_parquet

            yield from iter_parquet(self.path, names=self.names, chunk_rows=self.chunk_rows, progress=progress)
        else:
            from optinav.io.arrayblocks import array_blocks

            yield from array_blocks(
                self.path,
                self.kind,
                names=self.names,
                only=self.only,
                chunk_rows=self.chunk_rows,
                load=load,
                progress=progress,
            )

    def _text(self):
        path, n = self.path, self.chunk_rows
        labels = {normalize_name(c)[0] for c in self.text_columns}
        with open(path, "rb") as raw:
            src = gzip.GzipFile(fileobj=raw, mode="rb") if self.gz else raw
            if _wide(src.peek(_NOISE_BYTES)[:_NOISE_BYTES]):  # read as UTF-8 lines (the BOM consumed)
                wide = io.TextIOWrapper(src, encoding="utf-16", newline="")  # held: collected, it closes the file
                src = (line.encode("utf-8") for line in wide)
            state = {"complete": True, "start": True, "stamped": False, "sentence": None}

            def block(k: int = n) -> list[str]:
                got = list(itertools.islice(src, k))
                self.position = raw.tell()
                if not got:
                    return []
                state["complete"] = got[-1].endswith((b"\n", b"\r"))
                text = _decode(path, b"".join(got), state["start"])
                lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
                if state["start"]:
                    state["stamped"] = _monitor_stamped(lines)
                state["start"] = False
                if lines and lines[-1] == "" and text.endswith("\n"):
                    lines.pop()  # the split after the last newline
                lines = _unstamp(lines) if state["stamped"] else lines
                if state["sentence"] is None:
                    state["sentence"] = _vectornav(lines) or ""
                return _vn_fields(lines, state["sentence"]) if state["sentence"] else lines

            # the layout from the first lines (enough blocks for the preamble and ten table lines)
            head: list[str] = []
            content = 0
            while True:
                more = block()
                head += more
                for x in more:  # up to the lines wanted: a block of a large file holds a million
                    if _strip_comment(x).strip():
                        content += 1
                        if content >= _HEAD_CONTENT:
                            break
                if not more or content >= _HEAD_CONTENT:
                    break
            lay = _text_layout(path, head, self.names, self.delimiter, labels, self.needed)
            if state["stamped"]:
                lay.meta["monitor_stamps"] = "1"
            if state["sentence"]:
                lay.meta["vectornav"] = state["sentence"]
            pending = head[lay.start :]
            offset = lay.start  # file line index of pending[0]
            first = True  # pending[0] is the file's first data line
            rows = 0
            bad_total: list[tuple[int, int]] = []  # (row, line) of every line left out so far
            held = None  # the last parsed block, yielded once the next one is known (an empty last block
            nxt = block()  # may still carry the incomplete-line note)
            while pending or nxt:
                while len(pending) < n and nxt:
                    pending += nxt
                    # only the lines this block lacks (at least one: is there more?), so that what is read ahead
                    # stays under one block, not two or three blocks of text lines
                    nxt = block(max(n - len(pending), 1))
                lines, pending = pending[:n], pending[n:]
                last = not pending and not nxt
                bad = [] if self.skip_bad_lines else None
                data, truncated = _parse_block(
                    path,
                    lay,
                    lines,
                    0,
                    complete=state["complete"] or not last,
                    offset=offset,
                    first=0 if first else None,
                    bad=bad,
                )
                offset += len(lines)
                first = False
                k = len(data[lay.keep[0]])
                if bad:
                    bad_total += bad
                    _check_bad(path, bad_total, rows + k + len(bad), final=False)
                if k == 0:
                    if truncated is not None and held is not None:
                        held.meta["truncated_line"] = str(truncated)
                    continue
                if held is not None:
                    yield held
                meta = dict(lay.meta)
                if truncated is not None:
                    meta["truncated_line"] = str(truncated)
                if self.topic is not None:
                    meta["select"] = str(self.topic)
                held = Table(
                    path=path,
                    kind="text",
                    data={lay.colnames[j]: data[j] for j in lay.shown()},
                    units=dict(lay.units),
                    meta=meta,
                    row0=rows,
                )
                if bad:
                    _mark_bad(held, bad)
                rows += k + len(bad or ())  # the rows of the lines left out count: lost samples of a rate
            if held is None:
                raise OptinavError(f"{path} has a header but no data rows", "pass a file with data")
            _check_bad(path, bad_total, rows, final=True)
            yield held


def _suffix(path: Path) -> str:
    """The format suffix of ``path``, lower case: the one before a final ``.gz``."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] == ".gz":
        return suffixes[-2] if len(suffixes) > 1 else ""
    return suffixes[-1] if suffixes else ""


def _file_kind(path: Path) -> tuple[str, bool]:
    """(format, gzip-compressed?) of ``path`` from its first bytes and suffix; one-line errors for a missing,
    empty or unknown file."""
    from optinav.core.files import input_kind
    from optinav.io.rosbag import is_bag

    node = input_kind(path)
    if is_bag(path):  # a ROS 2 bag is a folder; rosbags checks the files itself
        return "rosbag", False
    if node == "dir" and kitti_oxts_folder(path) is not None:
        return "kitti_oxts", False
    if node == "dir":
        raise _folder_error(path, "data file") or OptinavError(
            f"{path} is a directory, not a data file", "pass the file inside it"
        )
    gz = path.suffix.lower() == ".gz"
    suffix = _suffix(path)
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise OptinavError(f"cannot read {path} ({exc.strerror})", "check the file and its permissions") from None
    if size == 0:
        raise OptinavError(f"data file {path} is empty", "pass a file with data rows")
    if head.startswith(b"PK\x03\x04"):
        _zip_is_npz(path)  # an .xlsx or a phone app's zip named for what it is, whatever its suffix
    try:
        kind = _sniff_kind(head, SUFFIXES.get(suffix), gz)
    except OptinavError as exc:
        raise OptinavError(f"{path.name}: {exc.cause}", exc.remedy) from None
    if kind == "gztext":
        kind, gz = "text", True
    if kind == "npz":
        _zip_is_npz(path)
    if kind is None and not gz and suffix not in NOT_TABLES and _texty(head):
        kind = "text"  # a logger's file under no table suffix (LOG0001, imu.out, run.raw): read by its content
    if kind is None or (gz and kind != "text"):
        shown = "".join(path.suffixes[-2 if gz else -1 :]) or "(none)"
        raise OptinavError(
            f"{path.name}: unknown data file type {shown}",
            f"use one of {', '.join(SUFFIXES)} (text files may end in .gz)",
        )
    return kind, gz


#: phyphox's export sets (phyphox-android DataExport.java: a CSV per set in the zip, a sheet per set in the Excel
#: export, beside meta/device.csv and meta/time.csv or the sheets "Metadata Device" and "Metadata Time"), as its
#: simple experiment names them (SimpleExperimentCreator.java: Accelerometer — "Acceleration x (m/s^2)", gravity
#: in it —, Gyroscope, Magnetometer, Linear Acceleration — gravity taken out); a built-in experiment's one set is
#: "Raw Data"
_PHYPHOX_META = ("meta/device.csv", "meta/time.csv", "Metadata Device", "Metadata Time")


def export_sets(names, header=None) -> dict | None:
    """The sensors' files of a phone app's export of several sensors — a zip's members, a folder's files or a
    workbook's sheets, ``names`` —: Sensor Logger's (TotalAcceleration.csv or AccelerometerUncalibrated.csv beside
    Gyroscope.csv — else GyroscopeUncalibrated.csv —, Magnetometer.csv or MagnetometerUncalibrated.csv; awesome-sensor-logger UNITS.md) or phyphox's
    (:data:`_PHYPHOX_META`), as ``{"what", "acc", "gyro", "mag", "single", "remedy"}``: the names of the
    accelerometer with gravity, the gyroscope and the magnetometer (None where absent), the one set to pass when
    there is no pair, and what to do when there is neither (else None); None for other names. ``header(name)``
    gives a table's first line (the sensor of phyphox's "Raw Data"). A zip may hold the export in a folder (phyphox's
    meta/ beside its sets there); a zip of several recordings' folders is named as such, not read as one."""
    groups: dict[str, list[str]] = {}
    for n in names:
        parent = posixpath.dirname(n.strip("/"))
        if posixpath.basename(parent) == "meta":
            parent = posixpath.dirname(parent)
        groups.setdefault(parent, []).append(n)
    if len(groups) <= 1 and "" in groups:
        return _export_set(names, header)
    found = {}
    for parent, members in groups.items():
        cut = len(parent) + 1 if parent else 0
        one = _export_set(
            [m.strip("/")[cut:] for m in members], None if header is None else lambda n, p=parent: header(f"{p}/{n}")
        )
        if one is not None:
            found[parent] = {k: f"{parent}/{v}" if k in _SET_FILES and v and parent else v for k, v in one.items()}
    if len(found) == 1:
        return next(iter(found.values()))
    if len(found) > 1:
        shown = ", ".join(f"{p or '.'}/" for p in sorted(found))
        return {
            **dict.fromkeys(("acc", "gyro", "mag", "single")),
            "what": f"{len(found)} recordings' exports ({shown})",
            "remedy": "pass one recording's folder",
        }
    return None


#: the keys of :func:`export_sets` that name files
_SET_FILES = ("acc", "gyro", "mag", "single")


def _export_set(names, header=None) -> dict | None:
    """:func:`export_sets` of one recording's files (at the top or under meta/)."""
    out = dict.fromkeys(("acc", "gyro", "mag", "single", "remedy"))
    base = {Path(n).name.lower(): n for n in names}
    acc = next((base[k] for k in ("totalacceleration.csv", "accelerometeruncalibrated.csv") if k in base), None)
    # an export with only the uncalibrated gyroscope holds the rates with the phone's bias estimate left in, which
    # every optinav command estimates itself
    gyro = next((base[k] for k in ("gyroscope.csv", "gyroscopeuncalibrated.csv") if k in base), None)
    if acc and gyro:  # Accelerometer.csv has gravity taken out
        mag = next((base[k] for k in ("magnetometer.csv", "magnetometeruncalibrated.csv") if k in base), None)
        return {**out, "what": "Sensor Logger's export", "acc": acc, "gyro": gyro, "mag": mag}
    if acc and "metadata.csv" in base:
        return {**out, "what": "Sensor Logger's export without Gyroscope.csv", "single": acc, "lacks": "gyroscope"}
    if not any(n.strip("/") in _PHYPHOX_META for n in names):
        return None
    # a set's file (a sheet of the Excel export is the same set's .csv in the CSV export)
    stem = {Path(n).stem.lower(): n if n.lower().endswith(".csv") else f"{n}.csv" for n in names}
    stem = {k: v for k, v in stem.items() if not v.startswith("meta/") and "metadata" not in k}
    sets = [Path(v).stem for v in stem.values()]
    out["what"] = f"phyphox's export of {len(sets)} sensor set(s) ({', '.join(sorted(sets))})"
    raw = stem.get("raw data")
    if raw is not None:
        if header is not None and "linear acceleration" in (header(raw) or "").lower():
            out["remedy"] = "it holds the linear acceleration (gravity taken out): record with 'Acceleration with g'"
        else:
            out["single"] = raw
    elif "accelerometer" in stem and "gyroscope" in stem:
        out.update(acc=stem["accelerometer"], gyro=stem["gyroscope"], mag=stem.get("magnetometer"))
    elif "accelerometer" in stem or "gyroscope" in stem:
        out["single"] = stem.get("accelerometer") or stem["gyroscope"]
    elif "linear acceleration" in stem:
        out["remedy"] = "Linear Acceleration has gravity taken out: add the Accelerometer (with g) to the experiment"
    else:
        out["remedy"] = "it holds neither an accelerometer nor a gyroscope"
    return out


def export_files(names, header=None, prefix: str = "") -> tuple[str, str] | None:
    """(what it is, what to do) for the files of a phone app's export of several sensors (:func:`export_sets`)
    when they are passed one at a time; None for other names. ``prefix`` goes before the names to pass (a
    folder's path)."""
    found = export_sets(names, header)
    if found is None:
        return None
    if found["acc"] is not None:
        times = "" if found["what"].startswith("Sensor Logger") else " (each on its own times)"
        return (
            found["what"],
            f"pass {prefix}{found['acc']} (the accelerometer with gravity) with "
            f"gyro_path={prefix}{found['gyro']}{times}",
        )
    if found.get("lacks"):
        return (
            found["what"],
            f"pass {prefix}{found['single']} for the accelerometer alone (calibrate accel, allan), or record again "
            f"with the {found['lacks']} switched on (the attitude needs both)",
        )
    return found["what"], found["remedy"] or f"pass {prefix}{found['single']}"


def _folder_error(path: Path, what: str) -> OptinavError | None:
    """The error for a folder that is a phone app's unzipped export (:func:`export_files`), else None."""
    try:
        names = [p.name for p in path.glob("*.csv")] + [f"meta/{p.name}" for p in (path / "meta").glob("*.csv")]
        if not names:  # a zip of several recordings unzipped: their folders
            names = [str(p.relative_to(path)) for p in path.glob("*/*.csv")]
            names += [str(p.relative_to(path)) for p in path.glob("*/meta/*.csv")]
    except OSError:
        return None

    def header(name):
        with open(path / name, encoding="utf-8", errors="replace") as fh:
            return fh.readline()

    found = export_files(names, header, prefix=f"{path}/")
    return None if found is None else OptinavError(f"{what} {path} is a folder, {found[0]}", found[1])


def _zip_is_npz(path: Path) -> None:
    """A zip that is not NumPy's .npz named for what it is: an Office workbook (phyphox's Excel export named as such;
    openpyxl writes the content-types entry last), a zip of CSV files (a phone app's export: the files to pass),
    anything else."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
            tables = [n for n in names if n.lower().endswith((".csv", ".txt", ".tsv"))]
            sheets = (
                re.findall(r'<sheet [^>]*name="([^"]+)"', z.read("xl/workbook.xml").decode("utf-8", "replace"))
                if "xl/workbook.xml" in names
                else []
            )

            def header(name):
                with z.open(name) as fh:
                    return fh.readline(4096).decode("utf-8", "replace")

            found = export_files(tables, header) if tables else None
    except (zipfile.BadZipFile, OSError, ValueError, KeyError):
        return  # the NPZ reader names the damage
    if not names or all(n.endswith(".npy") for n in names):
        return
    if "[Content_Types].xml" in names or any(n.startswith("xl/") for n in names):
        phyphox = export_files(sheets)
        if phyphox is not None:
            raise OptinavError(
                f"{path.name} is an Office (.xlsx) workbook, {phyphox[0].replace('export', 'Excel export', 1)}",
                "export it as 'CSV (Comma, decimal point)' instead"
                + (f", extract that zip and {phyphox[1]}" if phyphox[1].startswith("pass") else f"; {phyphox[1]}"),
            )
        raise OptinavError(f"{path.name} is an Office (.xlsx) workbook, not a data table", "save the sheet as CSV")
    if tables:
        shown = ", ".join(tables[:4]) + (", …" if len(tables) > 4 else "")
        if found is not None:
            remedy = f"extract it and {found[1]}" if found[1].startswith("pass") else found[1]
            raise OptinavError(f"{path.name} is a zip archive, {found[0]}", remedy)
        raise OptinavError(
            f"{path.name} is a zip archive of {len(tables)} text table(s) ({shown})", "extract it and pass one table"
        )
    raise OptinavError(
        f"{path.name} is a zip archive ({', '.join(names[:3])}{', …' if len(names) > 3 else ''}), not NumPy's .npz",
        "extract the data and pass it as CSV, NPZ, HDF5 or MAT",
    )


def _no_option(path: Path, ulog: bool = False, **given) -> None:
    for key, value in given.items():
        name = {"names": "positional columns (--columns t,ax,…)", "delimiter": "--delimiter"}.get(key, key)
        if value is not None:
            raise OptinavError(
                f"{name} apply to text and array files, not to the {'ULog' if ulog else 'ROS bag'} {path.name}",
                "drop them "
                + (
                    "(a ULog topic's fields are read by name)"
                    if ulog
                    else "(a bag's columns are t, ax..az, gx..gz, mx..mz)"
                ),
            )


_MAGIC = (
    (_HDF5_MAGIC, "hdf5"),
    (b"MATLAB ", "mat"),
    (b"PK\x03\x04", "npz"),
    (b"\x93NUMPY", "npy"),
    (b"\x1f\x8b", "gztext"),
    (b"PAR1", "parquet"),
    (b"ULog\x01\x12\x35", "ulog"),  # a PX4 flight log (optinav.io.ulog), whatever its suffix
)
#: signatures of formats optinav does not read, named in the error (checked after :data:`_MAGIC`)
_FOREIGN = (
    (b"SQLite format 3\x00", "an SQLite database (a ROS 2 bag is read as .db3)"),
    # a ROS 1 bag of format 2.0 and an MCAP file are read whatever their suffix (rosbag.is_bag): what is left here
    # is the older ROS 1 format (1.2) or an MCAP signature of another version
    (b"#ROSBAG", "a ROS 1 bag of another format than 2.0, the one read"),
    (b"\x89MCAP", "an MCAP file of another version than 0"),
    (b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1", "an old Excel/Office (.xls) document"),
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"%PDF", "a PDF document"),
    (b"BZh", "a bzip2 archive"),
    (b"\xfd7zXZ", "an xz archive"),
    (b"7z\xbc\xaf", "a 7-Zip archive"),
    (b"\x28\xb5\x2f\xfd", "a zstd archive"),
    (b"\x7fELF", "a program (ELF executable)"),
    (b"\xa3\x95\x80", "an ArduPilot DataFlash log"),
)

_EXPORT_REMEDY = "export the IMU data to CSV, NPZ, HDF5 or MAT (docs/file-formats.md)"
#: the export of a flight log that optinav reads as it comes out (docs/file-formats.md)
_ARDUPILOT_EXPORT = "export its IMU message: mavlogdump.py --format csv --types IMU LOG > imu.csv (read as it is)"
_LOG_REMEDY = {
    b"\xa3\x95\x80": _ARDUPILOT_EXPORT,
}
#: what to do with a bag file that is not read under its suffix
_BAG_REMEDY = {
    b"#ROSBAG": "write it anew in format 2.0 with ROS 1's rosbag (rosbag filter IN.bag OUT.bag True)",
    b"SQLite format 3\x00": f"a ROS 2 bag: give it the suffix .db3; else {_EXPORT_REMEDY}",
    b"\x89MCAP": "check that the file is whole, or write it anew (mcap recover IN.mcap -o OUT.mcap)",
}


def generic_names(n: int) -> list[str]:
    """The names of ``n`` columns that no header names: ``col1`` … ``colN``."""
    return [f"col{j + 1}" for j in range(n)]


def _sniff_kind(head: bytes, by_suffix: str | None, gz: bool) -> str | None:
    """The format from the first bytes before the suffix: binary formats by their magic numbers (MATLAB v7.3
    files start with "MATLAB" too), and a file under a binary suffix (.mat, .npz, .npy, .h5) that is text
    (MATLAB's ``save -ascii``, a CSV renamed) as text; a known foreign format (:data:`_FOREIGN`) or an
    .npz/.npy without its signature is a one-line error naming what it is; else what the suffix says."""
    if gz:
        return by_suffix
    if head.startswith(b"PK\x03\x04") and b"[Content_Types].xml" in head:  # a zip, like NPZ, but OOXML
        raise OptinavError(
            "the file is an Office (.xlsx) document, not a data table optinav reads", "save the sheet as CSV"
        )
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    for magic, what in _FOREIGN:
        if head.startswith(magic):
            raise OptinavError(
                f"the file is {what}, not a data table optinav reads",
                _BAG_REMEDY.get(magic) or _LOG_REMEDY.get(magic, _EXPORT_REMEDY),
            )
    if by_suffix in ("npz", "npy", "hdf5", "mat") and b"\x00" not in head:
        try:
            head.decode("utf-8")
            return "text"
        except UnicodeDecodeError as exc:
            if exc.start >= len(head) - 3:  # a multi-byte character cut at the end of the sample
                return "text"
    if by_suffix in ("npz", "npy"):  # MAT v4 has no signature, and HDF5 names a missing one itself
        raise OptinavError(
            f"the file is not {by_suffix.upper()} (it lacks the format's signature) and not text",
            "check that the file is complete, or give it its real extension",
        )
    return by_suffix


def normalize_name(name: str) -> tuple[str, str | None]:
    """Alias key of a column name and the unit it declares in brackets.

    ``"Acc X [m/s^2]"`` → ``("acc_x", "m/s^2")``; ``"imu/gyro"`` → ``("gyro", None)``: lower case, the last
    path component (with the one before when it is an axis: ``"/imu/angular_velocity/x"`` →
    ``"angular_velocity_x"``), spaces, dots and dashes as ``_``.
    """
    return _normalized(str(name))


@functools.lru_cache(maxsize=4096)
def _normalized(s: str) -> tuple[str, str | None]:
    # every layout detector asks again for every block of a streamed file (~20 calls per column per block)
    s = s.strip()
    unit = None
    if s.startswith("field."):  # rostopic echo -p: field.angular_velocity.x, field.header.stamp
        s = s[len("field.") :]
    ax = _AXIS_INDEX.match(s)
    m = None if ax else _BRACKET_UNIT.match(s)
    if ax:
        s = f"{ax.group(1)}_{'xyz'[int(ax.group(2))]}"
    elif m and m.group(1):
        s, unit = m.group(1), m.group(2).strip() or None
    parts = s.replace("\\", "/").rstrip("/").split("/")
    s = parts[-1]
    if len(parts) > 1 and s.lower() in ("x", "y", "z", "w") and parts[-2].strip():
        # a component of a message field (PlotJuggler: /imu/angular_velocity/x, /imu/orientation/w): alone, x
        # named nothing and w the gyroscope triad
        s = f"{parts[-2]}_{s}"
    s = re.sub(r"[\s.\-]+", "_", s.lower()).strip("_")
    return re.sub(r"_+", "_", s), unit


def find_with_unit(table, name: str, units) -> tuple[str | None, str | None]:
    """The key of column ``name`` in ``table`` (a :class:`Table`) and the unit its name declares: the name itself
    (any case; unit None), with a unit in brackets (``alpha [deg]``, ``t (ms)``) or a unit suffix (``alpha_deg``,
    ``t_ms``) among ``units`` (names a column of this kind can be in); (None, None) when there is none."""
    key = table.find(name)
    if key is not None:
        return key, None
    for k in table.data:
        base, unit = normalize_name(k)
        if unit is not None and base == name:
            return k, unit
        for u in units:
            if u.isalnum() and base == f"{name}_{u}":
                return k, u
    return None, None


# --- text -----------------------------------------------------------------------------------------------------


def _read_bytes(path: Path, gz: bool) -> bytes:
    try:
        if gz:
            with gzip.open(path, "rb") as fh:
                return fh.read()
        return path.read_bytes()
    except OSError as exc:  # includes gzip.BadGzipFile
        raise OptinavError(
            f"cannot read {path} ({exc})", "check the file (a .gz file must be gzip-compressed)"
        ) from None
    except (EOFError, ValueError) as exc:  # truncated or corrupt gzip stream
        raise OptinavError(f"{path} is a damaged gzip file ({exc})", "re-export or decompress it") from None


#: byte-order marks of UTF-16 text (Excel's "Unicode Text", Windows tools)
_UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")


#: bytes at the start of a text file within which NUL bytes are a serial capture's start-up noise
_NOISE_BYTES = 4096
#: what a line of such noise is read as (a line above the table, left out with a note)
NOISE_LINE = "(binary noise)"


#: control bytes (other than tab, line feed, form feed, carriage return) a text file's first bytes may hold, as a
#: fraction: a serial capture's boot noise; a binary format (compressed or numbers) holds about 12 %
TEXT_CONTROL_SHARE = 0.01


def _texty(head: bytes) -> bool:
    """Whether a file's first bytes are text: UTF-16 (:func:`_wide`), or no NUL and hardly any other control
    byte (:data:`TEXT_CONTROL_SHARE`)."""
    if _wide(head):
        return True
    if not head or b"\x00" in head:
        return False
    control = sum(head.count(bytes([c])) for c in range(32) if c not in (9, 10, 12, 13))
    return control <= TEXT_CONTROL_SHARE * len(head)


def _wide(head: bytes) -> bool:
    """Whether bytes that start a file are UTF-16 text: a byte-order mark, then NUL as the high byte of most
    characters (a table's digits, delimiters and names are ASCII). A mark followed by 8-bit text is a serial
    capture's boot noise that happens to begin with FF FE (or FE FF), not UTF-16."""
    if not head.startswith(_UTF16_BOMS):
        return False
    sample = head[2:402]
    high = sample[1::2] if head.startswith(b"\xff\xfe") else sample[0::2]
    return not high or high.count(0) > 0.5 * len(high)


def _bom_noise(raw: bytes) -> bytes:
    """``raw`` (the start of a file that begins with a UTF-16 byte-order mark but is no UTF-16 text) with its first
    line's noise (up to its last byte that is no printable ASCII) read as :data:`NOISE_LINE`; the rest of that line
    (a header the noise ran into) as a line of its own."""
    end = raw.find(b"\n")
    end = len(raw) if end < 0 else end
    first = raw[:end]
    bad = max(i for i, b in enumerate(first) if b >= 0x7F or (b < 0x20 and b not in b"\t\r"))
    rest = first[bad + 1 :]
    return NOISE_LINE.encode() + (b"\n" + rest if rest.strip() else b"") + raw[end:]


#: '°' in GBK, the code page of Chinese Windows (read as latin-1 it is '¡ã')
_GBK_DEGREE = "°".encode("gbk")


def _decode(path: Path, raw: bytes, start: bool = True) -> str:
    """Text of a file's bytes (``start``: they begin the file). Lines holding NUL bytes, when all lie within the
    first :data:`_NOISE_BYTES` of a file (a serial capture of a board's boot at another baud rate), are read as
    :data:`NOISE_LINE` (left out above the table, or named at their line inside it); elsewhere NULs make the
    file binary. A file is UTF-16 when :func:`_wide` says so; a byte-order mark before 8-bit text starts a line
    of noise (:func:`_bom_noise`)."""
    if start and raw.startswith(_UTF16_BOMS) and not _wide(raw[:_NOISE_BYTES]):
        raw = _bom_noise(raw)
    if start and b"\x00" in raw[:_NOISE_BYTES] and not raw.startswith(_UTF16_BOMS):
        last = raw.rfind(b"\x00")
        cut = raw.find(b"\n", last) + 1
        if last < _NOISE_BYTES and cut > 0 and raw[cut:].strip():
            noise = NOISE_LINE.encode()
            raw = b"\n".join(noise if b"\x00" in x else x for x in raw[: cut - 1].split(b"\n")) + raw[cut - 1 :]
    if start and raw.startswith(_UTF16_BOMS):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError:
            raise OptinavError(
                f"{path} starts as UTF-16 text but does not decode as UTF-16", "save it as UTF-8 CSV"
            ) from None
    head = raw[:400]
    if head and max(head[0::2].count(0), head[1::2].count(0)) > 0.9 * (len(head) // 2):
        raise OptinavError(f"{path} looks like UTF-16 text without a byte-order mark", "save it as UTF-8 CSV")
    if b"\x00" in raw:
        raise OptinavError(
            f"{path} looks binary (it contains NUL bytes), not a text table",
            "pass a CSV/TSV/text file, or give the file its real extension (.npz, .h5, .mat)",
        )
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        pass
    if _GBK_DEGREE in raw:  # a Chinese Windows tool's '(°/s)' (WitMotion's exports): GBK, else latin-1 would misread it
        try:
            return raw.decode("gbk")
        except UnicodeDecodeError:
            pass
    return raw.decode("latin-1")  # e.g. '°' written by Windows tools; only names can hold such bytes


def _delimiter_option(delimiter: str | None) -> tuple[bool, str | None]:
    """(given?, delimiter) with None meaning whitespace."""
    if delimiter is None:
        return False, None
    named = {"comma": ",", "tab": "\t", "\\t": "\t", "semicolon": ";", "whitespace": None, "space": None, " ": None}
    if delimiter in named:
        return True, named[delimiter]
    if len(delimiter) == 1 and delimiter not in '#"\n\r' and not delimiter.isalnum() and delimiter not in ".+-":
        return True, delimiter
    raise OptinavError(
        f"delimiter {delimiter!r} is not usable", "use ',', ';', 'tab' or 'whitespace' (or leave it out to auto-detect)"
    )


def _sniff(sample: list[str]) -> str | None:
    """Delimiter found on every sample line the same number of times (tab, then ';', then ','), else a guess."""
    for cand in ("\t", ";", ","):
        counts = {line.count(cand) for line in sample}
        if len(counts) == 1 and counts.pop() > 0:
            return cand
    first = sample[0]
    for cand in (",", "\t", ";"):
        if cand in first:
            return cand
    return None


#: a comment: '#' at the start of a line or after white space ("pose#1" or "#3" after a delimiter is a cell)
_COMMENT = re.compile(r"(?:^|(?<=\s))#")


def _strip_comment(line: str) -> str:
    if "#" not in line:
        return line
    m = _COMMENT.search(line)
    return line if m is None else line[: m.start()]


def _split(line: str, delim: str | None) -> list[str]:
    if delim is None:
        toks = line.split()
    elif '"' in line:
        try:
            toks = next(csv.reader([line], delimiter=delim, skipinitialspace=True))
        except (csv.Error, StopIteration):
            toks = line.split(delim)
    else:
        toks = line.split(delim)
    out = []
    for tok in toks:
        tok = tok.strip()
        if len(tok) >= 2 and tok[0] == tok[-1] == '"':
            tok = tok[1:-1].strip()
        out.append(tok)
    return out


def _is_number(tok: str) -> bool:
    if tok == "":
        return True  # an empty cell is a missing number
    try:
        float(tok)
        return True
    except ValueError:
        return False


def _is_header(tokens: list[str], following: list[str] | None) -> bool:
    """A header has a non-numeric token; when a next line exists, in a column where it is numeric or in all."""
    text = [not _is_number(t) for t in tokens]
    if not any(text):
        return False
    # an empty name (a trailing delimiter) is no number
    if following is None or len(following) != len(tokens) or all(x or t == "" for x, t in zip(text, tokens)):
        return True
    return any(t and _is_number(f) and f != "" for t, f in zip(text, following))


def _label_row(tokens: list[str], header: list[str]) -> bool:
    """A row under the header with a word in every named column (units, or a label such as Shimmer's "CAL")."""
    return len(tokens) == len(header) and all(
        (t and not _is_number(t)) or (not h and not t) for t, h in zip(tokens, header)
    )


@dataclasses.dataclass
class _Layout:
    """How a text table is laid out, from its first lines: delimiter, column names, header units, metadata of
    the comments and preamble, the index of the first data line, the kept and the text columns."""

    delim: str | None
    colnames: list[str]
    units: dict[str, str]
    meta: dict[str, str]
    start: int
    keep: list[int]
    textable: set[int]
    dates: set[int] = dataclasses.field(default_factory=set)  # date-time columns (→ s since the epoch, _epoch_seconds)
    loose: set[int] = dataclasses.field(default_factory=set)  # columns nobody reads: a text cell there is NaN
    comma: bool = False  # decimal commas (a ';' or tab file from a German or French Excel): read as points
    labelled: tuple[str, ...] | None = None  # 'name = value | …' lines: the names, in order (see _labelled)
    lax: set[int] = dataclasses.field(default_factory=set)  # date columns nobody reads: NaN where unreadable
    clocks: dict = dataclasses.field(default_factory=dict)  # a date column's day order, days counted so far …
    merged: dict = dataclasses.field(default_factory=dict)  # a time's column → its date's (two fields, one time)

    def shown(self) -> list[int]:
        """The columns of the table read: the kept ones but a date read into its time's column."""
        return [j for j in self.keep if j not in self.merged.values()]


#: the first line of an ArduPilot DataFlash log as text (Mission Planner's .log): the FMT message's own format
_DATAFLASH_TEXT = re.compile(r"^\s*FMT,\s*\d+,\s*\d+,\s*FMT,")
_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
#: a line of one sensor's triad under its label (Adafruit's BNO055 sketches: 'Accl:\tx= -0.27 |\ty= 0.04 |\tz= 9.85')
_SENSOR_LINE = re.compile(
    rf"^\s*([A-Za-z][\w ]*?)\s*:\s*x\s*[=:]\s*{_NUM}\s*[|,;]?\s*y\s*[=:]\s*{_NUM}\s*[|,;]?\s*z\s*[=:]\s*{_NUM}\s*$",
    re.IGNORECASE,
)
#: Excel's first line naming the delimiter ("sep=;" or "sep=<tab>", quoted or not)
_EXCEL_SEP = re.compile(r'^"?sep=(.)"?$')


def _text_layout(
    path: Path, lines: list[str], names: Sequence[str] | None, delimiter: str | None, labels: set[str], needed=None
) -> _Layout:
    """The :class:`_Layout` of a text file from its first lines (all lines up to the 10th after a preamble of at
    most :data:`_MAX_PREAMBLE` lines suffice); ``needed``: see :func:`load_table`."""
    given, delim = _delimiter_option(delimiter)
    comments: list[str] = []
    last_comment = -2
    content: list[int] = []  # indices of the first few non-comment, non-blank lines
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        # '//' heads an Xsens MT Manager export, '@' a HyperIMU file
        if s.startswith("#") or (not content and s.startswith(("//", "@"))):
            if not content:
                comments.append(s.lstrip("#/@").strip())
                last_comment = i
            continue
        if not _strip_comment(s).strip():
            continue
        content.append(i)
        if len(content) >= _HEAD_CONTENT:
            break
    if not content:
        raise OptinavError(f"{path} has no data rows (only blank or '#' comment lines)", "pass a file with data")
    per_sensor = [m.group(1) for i in content[:12] if (m := _SENSOR_LINE.match(lines[i]))]
    if len(per_sensor) >= 2 and len(set(per_sensor)) >= 2:
        raise OptinavError(
            f"{path.name} prints each sensor on its own line ({', '.join(dict.fromkeys(per_sensor))}: "
            f"{lines[content[0]].strip()[:40]!r}), a sample over several lines",
            "print one sample per line: a CSV row (t,ax,ay,az,gx,gy,gz) or named values ('ax:0.1,ay:0.2,…,gz:0.3')",
        )
    if _DATAFLASH_TEXT.match(lines[content[0]]):
        raise OptinavError(
            f"{path.name} is an ArduPilot DataFlash text log (FMT lines, then the rows of every message)",
            _ARDUPILOT_EXPORT,
        )
    excel = _EXCEL_SEP.match(lines[content[0]].strip())
    if excel:
        # Excel's delimiter line (a Shimmer Consensys export: '"sep=\t"'): it names the delimiter and is no row
        content = content[1:]
        if not content:
            raise OptinavError(f"{path} has no data rows after its 'sep=' line", "pass a file with data")
        if not given:
            given, delim = True, excel.group(1)
    preamble = _preamble(lines, content)
    content = content[int(preamble.pop("_preamble_lines", 0)) :]
    banner = _banner(lines, content, delim if given else None, given)
    if banner:
        shown = _strip_comment(lines[content[0]]).strip()[:40]
        preamble["banner_lines"] = f"{banner} line(s) above the table ({shown!r}{', …' if banner > 1 else ''})"
    content = content[banner:][:10]
    sample = [_strip_comment(lines[i]) for i in content]
    pairs = [_labelled(x) for x in sample[:3]]
    if pairs[0] is not None and all(p is not None and p[0] == pairs[0][0] for p in pairs):
        return _labelled_layout(path, pairs[0][0], names, content[0], preamble)
    if not given:
        delim = _sniff(sample)
    # decimal commas: only where ',' is not the delimiter, and only when some cell is a decimal-comma number
    comma = delim != "," and any(_DECIMAL_COMMA.match(t) for x in sample for t in _split(x, delim))
    if comma:
        sample = [_points(x, delim) for x in sample]
    toks0 = _split(sample[0], delim)
    is_header = _is_header(toks0, _split(sample[1], delim) if len(sample) > 1 else None)
    units: dict[str, str] = {}
    start = content[0]
    header: list[str] | None = None
    if is_header:
        header = toks0
        start = content[0] + 1
        # rows of units (or labels: Shimmer writes "CAL" rows, then units) right below the header: the last one
        # holds the units
        j = 1
        while j < min(len(sample) - 1, 3) and _label_row(_split(sample[j], delim), header):
            j += 1
        if j > 2 and not any(_is_number(t) and t for t in _split(sample[j], delim)):
            j = 2  # more rows of words follow: data this reader cannot parse, named at their own line below
        if j > 1:
            units = {h: u for h, u in zip(header, _split(sample[j - 1], delim)) if h}
            start = content[j - 1] + 1
    elif comments and last_comment == content[0] - 1:
        # numpy.savetxt writes its header as a '# a,b,c' comment: use the comment line right above the data if it fits
        cand = _split(comments[-1], delim)
        if len(cand) == len(toks0) > 1 and all(t and not _is_number(t) for t in cand):
            header = cand
    if header is None and names is None and (himu := _hyperimu_names(comments, len(toks0))):
        header = himu
        if all(_is_number(t) and float(t) == 0 for t in toks0) and len(content) > 1:
            # its first row is zeros, written before the sensors delivered a value: no sample
            start = content[1]
            preamble["hyperimu_zeros"] = "1"
    if header is not None and names is None and delim is not None and header[-1] != "":
        # rows ending in a delimiter under a header that does not (an Arduino sketch's Serial.print(",") after
        # every value): an empty last column, as when the header ends in one too
        rows = [_split(x, delim) for i, x in zip(content, sample) if i >= start]
        if rows and all(len(r) == len(header) + 1 and r[-1] == "" for r in rows):
            header = [*header, ""]
    ncol = len(header) if header is not None else len(toks0)
    # a date and a time of day as two fields ('2024-05-01 12:00:00.010' split at white space, 'Date,Time' columns):
    # one column of date-times, named by the time's header name (or the one name a header gives both), counted
    # as one by a header or columns that name one column fewer than the rows hold
    row = next((_split(x, delim) for i, x in zip(content, sample) if i >= start), None)
    pair = _date_pair(row) if row is not None and len(row) in (ncol, ncol + 1) else None
    merged: dict[int, int] = {}
    if pair is not None:
        given_names = names if names is not None else header
        if given_names is None:
            given_names = generic_names(len(row) - 1)
        if len(given_names) == len(row) - 1:
            given_names = [*given_names[:pair], "", *given_names[pair:]]
        if len(given_names) == len(row) and (names is None or not given_names[pair]):
            time_name = given_names[pair + 1] or given_names[pair] or "time"
            skipped = time_name in SKIP_NAMES
            date_name = time_name if skipped else given_names[pair] or f"{time_name}:date"
            given_names = [*given_names[:pair], date_name, time_name, *given_names[pair + 2 :]]
            if names is not None:
                names = given_names
            else:
                header = given_names
            ncol, merged = len(row), {} if skipped else {pair + 1: pair}
    if names is not None:
        if len(names) != ncol:
            shown = f"header: {','.join(header)}" if header is not None else f"first row: {','.join(toks0)}"
            raise OptinavError(
                f"columns names {len(names)} column(s) but {path.name} has {ncol} ({shown[:120]})",
                "give one name per column in order, '_' to skip one",
            )
        colnames = list(names)
    elif header is not None:
        colnames = [h if h else g for h, g in zip(header, generic_names(len(header)))]
        seen: dict[str, int] = {}
        for j, h in enumerate(colnames):
            if h in seen:
                raise OptinavError(
                    f"{path.name}: the header names column {h!r} twice (columns {seen[h] + 1} and {j + 1})",
                    "rename one, or name the columns with columns='...'",
                )
            seen[h] = j
    else:
        colnames = generic_names(ncol)
    if header is not None and names is not None:
        # names given over a header keep the header's units (its units row, or a unit in brackets: EuRoC's
        # 'timestamp [ns]'); a unit in a given name overrides
        units = {n: units.get(h) or normalize_name(h)[1] for n, h in zip(colnames, header)}
        units = {n: u for n, u in units.items() if u and n not in SKIP_NAMES}
    for j, h in enumerate(colnames):
        unit = normalize_name(h)[1]
        if unit and (h not in units or names is not None):
            units[h] = unit
    keep = [j for j, n in enumerate(colnames) if n not in SKIP_NAMES]
    if not keep:
        raise OptinavError("columns skips every column", "name at least one column")
    textable = {j for j in keep if normalize_name(colnames[j])[0] in labels}
    merged = {j: d for j, d in merged.items() if j in keep and d in keep}
    textable |= set(merged.values())  # a date read into its time's column, never a column of its own
    out: list[int] = []
    row = next((_split(x, delim) for i, x in zip(content, sample) if i >= start), None)
    row = row if row is not None and len(row) == ncol else None
    # ISO 8601 date-times (pandas' to_csv of a DatetimeIndex, many loggers): seconds since the epoch
    dates = {j for j in keep if row is not None and j not in textable and _is_stamp(row[j])}
    for j in sorted(dates):
        if header is not None and names is None and header[j] == "" and "time" not in colnames:
            colnames[j] = "time"  # pandas' to_csv of an unnamed DatetimeIndex: the samples' times
        units[colnames[j]] = "s"
    if needed is not None and row is not None:  # a column nobody reads with text in the first data row: left out
        out = [j for j in keep if not (j in textable or j in dates or _is_number(row[j]) or needed(colnames[j]))]
        keep = [j for j in keep if j not in out]
        if not keep:
            raise OptinavError(
                f"{path.name}: no column of numbers in the first data row ({lines[start].strip()[:60]!r}, "
                f"split at {'whitespace' if delim is None else repr(delim)})",
                "check the delimiter option (--delimiter), or drop it to let the file's delimiter be found",
            )
    # a column nobody reads (a logger's event or GPS-fix column) may hold text further down: NaN there, not an
    # error; its first cells were numbers or empty
    loose = (
        set()
        if needed is None
        else {j for j in keep if j not in textable and j not in dates and not needed(colnames[j])}
    )
    meta = _comment_meta(comments)
    if needed is not None and out:
        meta["text_left_out"] = ", ".join(repr(colnames[j]) for j in out)
    clocks: dict[int, dict] = {}
    if dates:
        meta["date_columns"] = "\t".join(colnames[j] for j in sorted(dates))
        rows = [r for i, x in zip(content, sample) if i >= start and len(r := _split(x, delim)) == ncol]
        days, undated = [], []
        for j in sorted(dates):
            cells = [f"{r[merged[j]]} {r[j]}" if j in merged else r[j] for r in rows]
            if (m := _STAMP.match(cells[0])) and not m.group(1):
                days.append(colnames[j])
            ends = [m.groups() for c in cells if (m := _YEAR_LAST.match(c))]
            if ends and len(ends) == len(cells):
                first, second = (np.array([float(g[k]) for g in ends]) for k in (0, 2))
                clocks[j] = {"order": _date_order(first, second, ends[0][1] == ".")}
                if clocks[j]["order"] == "?":  # only the times of day time the samples
                    days.append(colnames[j])
                    undated.append(f"{colnames[j]!r} ({cells[0].split()[0]})")
        if days:
            meta["time_of_day_columns"] = "\t".join(days)
        if undated:
            meta["undated"] = ", ".join(undated)
        if merged:
            meta["date_and_time"] = "\t".join(colnames[j] for j in merged)
    if comma:
        meta["decimal_comma"] = "1"
    meta.update(preamble)
    lay = _Layout(delim, colnames, units, meta, start, keep, textable | dates | loose, dates, loose, comma)
    lay.lax = set() if needed is None else {j for j in dates if not needed(colnames[j])}
    lay.clocks, lay.merged = clocks, merged
    return lay


def _date_pair(row: list[str]) -> int | None:
    """The index of a field holding a date alone followed by one holding a time of day alone (see
    :data:`_DATE_ONLY`), else None."""
    for j in range(len(row) - 1):
        if _DATE_ONLY.match(row[j]) and _TIME_ONLY.match(row[j + 1]):
            return j
    return None


#: one ``name = value`` or ``name: value`` pair of a labelled line (an Arduino sketch's Serial.print output)
_PAIR = re.compile(r"([A-Za-z_][\w.\[\]()/^-]*)\s*[=:]\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)(?![\w.])")
#: what may stand between the pairs of a labelled line
_PAIR_GAP = re.compile(r"^[\s|,;\t]*$")


def _labelled(line: str) -> tuple[tuple[str, ...], list[str]] | None:
    """(names, values) of a line made only of ``name = value`` / ``name: value`` pairs (at least two; between
    them ``|``, ``,``, ``;`` or white space): the classic MPU-6050 sketch's ``AcX = -1234 | AcY = 56 | …``, the
    Arduino Serial Plotter's ``ax:12,ay:5``; None for any other line."""
    pairs, end = [], 0
    for m in _PAIR.finditer(line):
        if not _PAIR_GAP.match(line[end : m.start()]):
            return None
        pairs.append(m)
        end = m.end()
    if len(pairs) < 2 or not _PAIR_GAP.match(line[end:]):
        return None
    return tuple(m.group(1) for m in pairs), [m.group(2) for m in pairs]


def _unlabel(line: str, names: tuple[str, ...]) -> str:
    """A labelled line with ``names`` as its comma-separated values; any other line as it is (a ragged or text row
    is then named at its own line)."""
    got = _labelled(line) if ("=" in line or ":" in line) else None
    return ",".join(got[1]) if got is not None and got[0] == names else line


def _labelled_layout(path: Path, labels: tuple[str, ...], names, start: int, meta: dict[str, str]) -> _Layout:
    """The layout of lines of ``name = value`` pairs from ``start`` on: the names are the columns (or ``names``)."""
    if len(set(labels)) != len(labels):
        raise OptinavError(
            f"{path.name}: its lines name {', '.join(sorted({x for x in labels if labels.count(x) > 1}))} twice",
            "give each value its own name",
        )
    if names is not None and len(names) != len(labels):
        raise OptinavError(
            f"columns names {len(names)} column(s) but the lines of {path.name} hold {len(labels)} ({', '.join(labels)})",
            "give one name per value in order, '_' to skip one",
        )
    colnames = list(names) if names is not None else list(labels)
    units = {h: u for h in colnames if (u := normalize_name(h)[1])}
    keep = [j for j, n in enumerate(colnames) if n not in SKIP_NAMES]
    if not keep:
        raise OptinavError("columns skips every column", "name at least one column")
    return _Layout(",", colnames, units, dict(meta), start, keep, set(), labelled=labels)


def _points(line: str, delim: str | None) -> str:
    """``line`` with its decimal-comma numbers written with points (other cells as they are)."""
    if "," not in line:
        return line
    toks = _split(line, delim)
    if not any(_DECIMAL_COMMA.match(t) for t in toks):
        return line
    return (delim or " ").join(t.replace(",", ".") if _DECIMAL_COMMA.match(t) else t for t in toks)


def _parse_block(
    path: Path,
    lay: _Layout,
    lines: list[str],
    start: int,
    *,
    complete: bool = True,
    offset: int = 0,
    first: int | None = None,
    bad: list | None = None,
) -> tuple[dict[int, np.ndarray], int | None]:
    """Columns of ``lines[start:]`` (numpy's C parser; the exact line parser when that fails, which names the
    line and column of a bad cell). ``offset``: file line index of ``lines[0]``; ``first``: index in ``lines`` of
    the file's first data line (None: not in this block); ``complete``: whether the file's last line ends in a
    newline (only the block holding it passes False); ``bad``: a list to collect (row, line number) of the lines
    left out as unreadable (None: such a line is an error)."""
    if lay.labelled:  # 'AcX = 12 | AcY = 5' → '12,5' where the names are the layout's (other lines as they are)
        lines = lines[:start] + [_unlabel(x, lay.labelled) for x in lines[start:]]
    if lay.comma:  # ',' is not the delimiter: every comma in a data line is a decimal one (labels' too)
        lines = lines[:start] + [x.replace(",", ".") for x in lines[start:]]
    data = _parse_fast(lines, start, lay.delim, len(lay.colnames), lay.keep, lay.textable)
    truncated = None
    if data is None:
        data, truncated = _parse_slow(
            path,
            lines,
            start,
            lay.delim,
            lay.colnames,
            lay.keep,
            lay.textable,
            complete=complete,
            offset=offset,
            first=first,
            bad=bad,
        )
    for j, d in lay.merged.items():  # '2024-05-01' and '12:00:00.010' → '2024-05-01 12:00:00.010'
        data[j] = np.char.add(np.char.add(np.asarray(data[d], dtype=str), " "), np.asarray(data[j], dtype=str))
    for j in lay.dates:
        try:
            data[j] = _epoch_seconds(path, lay.colnames[j], data[j], lay.clocks.setdefault(j, {}))
        except OptinavError:
            if j not in lay.lax:
                raise
            data[j] = np.full(len(data[j]), np.nan)  # a clock nobody reads (AndroSensor's local date-time) as NaN
    for j in lay.loose:
        data[j] = _loose_numbers(data[j])
    return data, truncated


def _loose_numbers(cells: np.ndarray) -> np.ndarray:
    """A column nobody reads as floats: its numbers, NaN for text and empty cells."""
    if cells.dtype.kind == "f":
        return cells
    cells = np.char.strip(np.asarray(cells, dtype=str))
    out = np.full(cells.shape, np.nan)
    ok = np.array([_is_number(c) and c != "" for c in cells.tolist()], dtype=bool)
    out[ok] = cells[ok].astype(float)
    return out


_DATETIME = re.compile(r"^\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?\s*(Z|[+-]\d{2}:?\d{2})?$")
#: the date-times and times of day loggers write beside ISO 8601: a date with '-' or '/' whose fields need not be
#: zero-padded (WitMotion's PC software: '2023-5-16 15:30:35.760'; RTC loggers: '2024/05/01 12:00:00.010'), the
#: milliseconds after a ':' (WitMotion's newer exports: '2024-1-5 9:3:7:250'), or a time of day alone
#: ('15:30:35.760'; seconds required): groups year, month, day, hour, minute, second, fraction digits
_STAMP = re.compile(
    r"^(?:(\d{4})[-/](\d{1,2})[-/](\d{1,2})[T ]+(\d{1,2}):(\d{1,2})(?::(\d{1,2})(?:[.:](\d{1,9}))?)?"
    r"|(\d{1,2}):(\d{2}):(\d{2})(?:[.:](\d{1,9}))?)$"
)
#: seconds of a day, and the backward step of a time-of-day column that is a day rollover (23:59:59.9 → 00:00:00.0)
#: rather than a clock set back
_DAY_S = 86400.0
_ROLLOVER_S = 43200.0


#: a date-time whose year comes last (``01/05/2024 12:00:00.010``, day or month first; ``01.05.2024 …``, day first as
#: German loggers write it): groups first field, separator, second field, year, hour, minute, second, fraction
_YEAR_LAST = re.compile(r"^(\d{1,2})([/.])(\d{1,2})\2(\d{4})[T ]+(\d{1,2}):(\d{1,2}):(\d{1,2})(?:[.:](\d{1,9}))?$")
#: a date alone and a time of day alone, the two tokens a logger may write them as (``2024-05-01 12:00:00.010`` in a
#: file split at white space, or ``Date,Time`` columns)
_DATE_ONLY = re.compile(r"^(?:\d{4}[-/]\d{1,2}[-/]\d{1,2}|\d{1,2}([/.])\d{1,2}\1\d{4})$")
_TIME_ONLY = re.compile(r"^\d{1,2}:\d{2}:\d{2}(?:[.:]\d{1,9})?$")


def _is_stamp(cell: str) -> bool:
    """Whether a cell is a date-time or a time of day :func:`_epoch_seconds` reads."""
    return bool(_DATETIME.match(cell) or _STAMP.match(cell) or _YEAR_LAST.match(cell))


def _date_order(first: np.ndarray, second: np.ndarray, dotted: bool) -> str | None:
    """Which field of year-last dates is the day: "dmy" or "mdy" where a field above 12 says so (a '.' date is
    day first), "?" where none does, None where both do (no date)."""
    day1, day2 = bool(np.any(first > 12)), bool(np.any(second > 12))
    if day1 and day2 or (dotted and day2):
        return None
    return "dmy" if day1 or dotted else "mdy" if day2 else "?"


def _epoch_seconds(path: Path, name: str, cells: np.ndarray, clock: dict | None = None) -> np.ndarray:
    """Date-time cells → float seconds since the Unix epoch (resolution about 0.2 µs today); an empty cell is NaN.

    ISO 8601 (a UTC offset applied; none: taken as UTC), or the forms of :data:`_STAMP` and :data:`_YEAR_LAST`
    (taken as UTC). A column of times of day alone gives seconds since the midnight before its first row, a
    backward step of more than 12 h being a day rollover (+24 h); so does a year-last column whose dates do not
    tell the day from the month (:func:`_year_last_fields`). ``clock`` carries the day order, the last time of day
    and the days counted from one block of a streamed file to the next."""
    cells = np.char.strip(np.asarray(cells, dtype=str))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's note that it converts a UTC offset instead of keeping it
        try:
            ns = cells.astype("datetime64[ns]")
        except ValueError as exc:
            out = _stamp_seconds(cells, clock)
            days = [] if out is not None else [c for c in cells.tolist() if _YEAR_LAST.match(c)]
            odd = [c for c in days if max(map(int, re.split("[/.]", c)[:2])) > 12]
            if odd:  # a field above 12 in either place, or in both
                raise OptinavError(
                    f"{path.name}: column {name!r} holds dates ({odd[0].split()[0]} …) that read neither day first "
                    "nor month first throughout",
                    "fix the dates, or skip the column ('_' in columns) and give --rate",
                )
            if out is None:
                raise OptinavError(
                    f"{path.name}: column {name!r} holds date-times and other text ({str(exc)[:120]})",
                    "fix the cell, or skip the column ('_' in columns)",
                ) from None
            return out
    out = ns.astype(np.int64) * 1e-9
    out[np.isnat(ns)] = np.nan
    return out


#: the two forms of :data:`_STAMP` a column holds on every row in practice, read in one pass over the column (its
#: separators made spaces for numpy's number parser) instead of cell by cell: a date with the time to the second
#: (a fraction after '.' or ':'), and a time of day alone
_STAMP_ROWS = (
    (re.compile(r"^\d{4}[-/]\d{1,2}[-/]\d{1,2}[T ]+\d{1,2}:\d{1,2}:\d{1,2}(?:[.:]\d{1,9})?$", re.M), True),
    (re.compile(_TIME_ONLY.pattern, re.M), False),
)
#: a fraction of a second after a ':' (WitMotion's '9:3:7:250'), written after a '.' for the number parser
_COLON_FRACTION = re.compile(r"(\d:\d{1,2}:\d{1,2}):(\d+)$", re.M)
_STAMP_SEPARATORS = str.maketrans({"-": " ", "/": " ", ":": " ", "T": " "})


def _stamp_fields(cells: np.ndarray) -> tuple[np.ndarray, bool] | None:
    """(n, 6) year, month, day, hour, minute, second (its fraction in it) of :data:`_STAMP` cells, NaN rows for
    empty cells, and whether they hold dates (else times of day: NaN dates); None when a cell is of another form
    or the column mixes dates with times of day."""
    filled = np.char.str_len(cells) > 0
    kept = cells[filled].tolist()
    out = np.full((cells.size, 6), np.nan)
    joined = "\n".join(kept)
    for rx, dated in _STAMP_ROWS:
        if len(rx.findall(joined)) == len(kept):
            text = _COLON_FRACTION.sub(r"\1.\2", joined).translate(_STAMP_SEPARATORS)
            k = 6 if dated else 3
            v = np.fromstring(text, sep=" ") if kept else np.zeros(0)
            if v.size == k * len(kept):
                out[filled, 6 - k :] = v.reshape(-1, k)
                return out, dated
    matches = [_STAMP.match(c) for c in kept]  # the other forms (minutes without seconds), cell by cell
    if any(m is None for m in matches) or len({m.group(1) is None for m in matches}) > 1:
        return None
    for i, m in zip(np.flatnonzero(filled), matches):
        g = m.groups()
        y, mo, d, h, mi, sec, frac = g[:7] if g[0] is not None else (None, None, None, *g[7:])
        fields = (y, mo, d, h, mi, sec or "0")
        out[i] = [np.nan if x is None else float(x) for x in fields]
        out[i, 5] += float("0." + frac) if frac else 0.0
    return out, bool(matches) and matches[0].group(1) is not None


def _stamp_seconds(cells: np.ndarray, clock: dict | None) -> np.ndarray | None:
    """Seconds of the :data:`_STAMP` cells (see :func:`_epoch_seconds`); None when a cell is of another form, or
    the column mixes dates with times of day alone."""
    clock = {} if clock is None else clock
    filled = cells[np.char.str_len(cells) > 0]
    first = str(filled[0]) if filled.size else ""
    got = _year_last_fields(cells, clock) if _YEAR_LAST.match(first) else _stamp_fields(cells)
    if got is None:
        return None
    f, dated = got
    if np.any((f[:, 3] > 23) | (f[:, 4] > 59) | (f[:, 5] >= 61)):  # (a leap second is 60.x)
        return None
    sec = f[:, 3] * 3600.0 + f[:, 4] * 60.0 + f[:, 5]
    if not dated:
        return _unroll_days(sec, clock)
    ok = np.isfinite(f[:, 0])
    y, mo, d = (np.where(ok, f[:, k], 1.0).astype(np.int64) for k in (0, 1, 2))
    if np.any((mo < 1) | (mo > 12) | (d < 1) | (d > 31)):
        return None
    # the day from numpy's calendar: months since 1970 → the first day of that month, then the day of the month
    days = ((y - 1970) * 12 + mo - 1).astype("datetime64[M]").astype("datetime64[D]").astype(np.int64) + d - 1
    return np.where(ok, days * _DAY_S + sec, np.nan)


def _year_last_fields(cells: np.ndarray, clock: dict) -> tuple[np.ndarray, bool] | None:
    """The fields of :data:`_YEAR_LAST` date-times as :func:`_stamp_fields` gives them, the day told from the month
    by ``clock["order"]`` (set from the file's first rows; else from these cells, :func:`_date_order`). Where no
    field tells ("?": all of them 12 or less), only the times of day are taken (dates NaN, read as a column of
    times of day); None when a cell is of another form."""
    filled = np.char.str_len(cells) > 0
    kept = cells[filled].tolist()
    joined = "\n".join(kept)
    if not kept or len(_YEAR_LAST_ROWS.findall(joined)) != len(kept):
        return None
    text = _YEAR_LAST_DATE.sub(r"\1 \2 \3 ", joined)
    v = np.fromstring(_COLON_FRACTION.sub(r"\1.\2", text).translate(_STAMP_SEPARATORS), sep=" ")
    if v.size != 6 * len(kept):
        return None
    v = v.reshape(-1, 6)
    order = clock.setdefault("order", _date_order(v[:, 0], v[:, 1], "." in kept[0][:6]))
    out = np.full((cells.size, 6), np.nan)
    out[filled, 3:] = v[:, 3:]
    if order in ("dmy", "mdy"):
        out[filled, 0] = v[:, 2]
        out[filled, 1:3] = v[:, [1, 0]] if order == "dmy" else v[:, [0, 1]]
    return (out, order in ("dmy", "mdy")) if order is not None else None


#: :data:`_YEAR_LAST` on every line of a column, and its date (written year, first and second field for the parser)
_YEAR_LAST_ROWS = re.compile(_YEAR_LAST.pattern, re.M)
_YEAR_LAST_DATE = re.compile(r"^(\d{1,2})[/.](\d{1,2})[/.](\d{4})[T ]+", re.M)


def _unroll_days(sec: np.ndarray, clock: dict) -> np.ndarray:
    """Times of day (s) with a day added at each backward step of more than :data:`_ROLLOVER_S` (``clock``: the
    previous block's last time of day and days, updated)."""
    ok = np.flatnonzero(np.isfinite(sec))
    if not ok.size:
        return sec
    v = sec[ok]
    prev = np.concatenate([[clock.get("last", v[0])], v[:-1]])
    days = clock.get("days", 0) + np.cumsum(v - prev < -_ROLLOVER_S)
    clock["last"], clock["days"] = float(v[-1]), int(days[-1])
    out = sec.copy()
    out[ok] = v + days * _DAY_S
    return out


#: the receive time the Arduino IDE's serial monitor puts before each line ("Show timestamp": '14:23:01.123 -> ')
_MONITOR_STAMP = re.compile(r"^\d\d:\d\d:\d\d\.\d\d\d -> ")


#: a VectorNav ASCII output sentence (``$VNYMR,+010.071,…,-00.000140*64``): its name, its fields and the checksum
#: (XOR of the bytes between '$' and '*', in hex)
_VN_SENTENCE = re.compile(r"^\$(VN[A-Z]{3}),(.*)\*([0-9A-Fa-f]{2})\s*$")


def _vectornav(lines: list[str]) -> str | None:
    """The sentence name when the first non-blank line is a VectorNav ASCII sentence (``VNYMR``), else None."""
    first = next((x for x in lines if x.strip()), "")
    m = _VN_SENTENCE.match(first.strip())
    return m.group(1) if m else None


def _vn_fields(lines: list[str], name: str) -> list[str]:
    """Each sentence ``name`` whose checksum holds reduced to its fields (``-00.053,+00.056,…``); another line (a
    damaged one, another sentence, a command's reply) is kept as it is, unreadable at its line."""
    out = []
    for x in lines:
        m = _VN_SENTENCE.match(x.strip())
        if m and m.group(1) == name:
            body = f"{name},{m.group(2)}"
            if functools.reduce(operator.xor, body.encode("latin-1", "replace"), 0) == int(m.group(3), 16):
                x = m.group(2)
        out.append(x)
    return out


def _monitor_stamped(lines: list[str]) -> bool:
    """Whether the first non-blank line carries the serial monitor's receive time (then every line's is cut off:
    the computer's receive time, in bursts of USB packets, is no sample time)."""
    first = next((x for x in lines if x.strip()), "")
    return bool(_MONITOR_STAMP.match(first))


def _unstamp(lines: list[str]) -> list[str]:
    return [_MONITOR_STAMP.sub("", x, count=1) for x in lines]


def _load_text(
    path: Path,
    raw: bytes,
    names: Sequence[str] | None,
    delimiter: str | None,
    labels: set[str],
    needed=None,
    skip_bad_lines: bool = False,
) -> Table:
    text = _decode(path, raw)
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    stamped = _monitor_stamped(lines)
    if stamped:
        lines = _unstamp(lines)
    sentence = _vectornav(lines)
    if sentence:
        lines = _vn_fields(lines, sentence)
    lay = _text_layout(path, lines, names, delimiter, labels, needed)
    if stamped:
        lay.meta["monitor_stamps"] = "1"
    if sentence:
        lay.meta["vectornav"] = sentence
    bad = [] if skip_bad_lines else None
    data, truncated = _parse_block(
        path, lay, lines, lay.start, complete=text.endswith(("\n", "\r")), first=lay.start, bad=bad
    )
    meta = dict(lay.meta)
    if truncated is not None:
        meta["truncated_line"] = str(truncated)
    table = Table(
        path=path, kind="text", data={lay.colnames[j]: data[j] for j in lay.shown()}, units=dict(lay.units), meta=meta
    )
    n = len(next(iter(table.data.values()))) if table.data else 0
    if n == 0:
        raise OptinavError(f"{path} has a header but no data rows", "pass a file with data")
    if bad:
        _check_bad(path, bad, n + len(bad), final=True)
        _mark_bad(table, bad)
    return table


#: the largest share of a text table's lines that ``skip_bad_lines`` leaves out (more: the file is not the table
#: its first lines say, or the delimiter or columns are wrong)
MAX_BAD_FRACTION = 0.01
#: line numbers named in a note or an error
_MAX_BAD_SHOWN = 5
#: what the errors of an unreadable line offer
SKIP_BAD_REMEDY = "or pass --skip-bad-lines (skip_bad_lines=True) to leave such lines out as lost samples"


def _bad_shown(bad: list) -> str:
    """``line 12`` / ``lines 12, 40, …`` of (row, line) pairs."""
    shown = ", ".join(str(x[1]) for x in bad[:_MAX_BAD_SHOWN]) + (", …" if len(bad) > _MAX_BAD_SHOWN else "")
    return f"line{'s' if len(bad) > 1 else ''} {shown}"


def _check_bad(path: Path, bad: list, lines: int, *, final: bool) -> None:
    """Refuse a table whose unreadable lines are more than :data:`MAX_BAD_FRACTION` of its ``lines`` data lines
    (one is always allowed); a block of a streamed file (``final`` False) stops early only once 100 are out."""
    if len(bad) <= 1 or len(bad) <= MAX_BAD_FRACTION * lines or (not final and len(bad) < 100):
        return
    raise OptinavError(
        f"{path.name}: {len(bad)} of {lines} data lines are unreadable ({_bad_shown(bad)}), more than "
        f"{MAX_BAD_FRACTION:.0%} --skip-bad-lines leaves out",
        "check the delimiter (--delimiter) and columns (--columns), or repair the file",
    )


def _mark_bad(table: Table, bad: list) -> None:
    """Record the (row, line) pairs of the lines left out in ``table`` (positions among its kept rows)."""
    table.bad_rows = np.asarray([r for r, _ in bad], dtype=np.int64)
    table.bad_lines = tuple(line for _, line in bad)


def _loadtxt(lines, delim, dtype, usecols=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # no comment character: numpy's would cut a cell like "pose#1" (a line with a comment goes to the exact
        # parser, which knows one)
        return np.loadtxt(lines, delimiter=delim, comments=None, dtype=dtype, ndmin=2, quotechar='"', usecols=usecols)


def _parse_fast(lines, start, delim, ncol, keep, textable) -> dict[int, np.ndarray] | None:
    """numpy's C parser; None when the file needs the exact (slow) parser: errors, empty cells, text."""
    body = lines[start:]
    try:
        arr = _loadtxt(body, delim, float)
        if arr.shape[1] != ncol:
            return None
        return {j: arr[:, j] for j in keep}
    except Exception:  # noqa: BLE001 - any parser failure falls back to the exact parser, which explains it
        pass
    if len(keep) == ncol and not textable:
        return None
    numeric = [j for j in keep if j not in textable]
    try:
        if _uniform(body, delim, ncol):
            # usecols would let ragged rows pass, hence the field count check above
            out = {}
            if numeric:
                arr = _loadtxt(body, delim, float, usecols=numeric)
                out.update({j: arr[:, k] for k, j in enumerate(numeric)})
            if textable:
                cols = sorted(textable)
                arr = _loadtxt(body, delim, str, usecols=cols)
                out.update({j: _text_column(arr[:, k]) for k, j in enumerate(cols)})
            return out
        arr = _loadtxt(body, delim, str)
        if arr.shape[1] != ncol:
            return None
        return {j: _text_column(arr[:, j]) if j in textable else arr[:, j].astype(float) for j in keep}
    except Exception:  # noqa: BLE001
        return None


def _uniform(body: list[str], delim: str | None, ncol: int) -> bool:
    """Every non-blank line has ncol fields (``delim`` None: white space between them) and no quotes or comments."""
    if delim is None:
        odd = [line for line in body if len(line.split()) != ncol or '"' in line or "#" in line]
        return all(not line.strip() for line in odd)
    k = ncol - 1
    odd = [line for line in body if line.count(delim) != k or '"' in line or "#" in line]
    return all(not line.strip() for line in odd)


def _text_column(cells: np.ndarray) -> np.ndarray:
    """A label column: numbers if every cell is one, else stripped strings."""
    cells = np.char.strip(np.asarray(cells, dtype=str))
    if cells.size and _is_number(str(cells[0])) and cells[0] != "":
        try:
            return cells.astype(float)
        except ValueError:
            pass
    return cells


def _parse_slow(
    path,
    lines,
    start,
    delim,
    colnames,
    keep,
    textable,
    *,
    complete: bool = True,
    offset: int = 0,
    first: int | None = None,
    bad: list | None = None,
) -> tuple[dict[int, np.ndarray], int | None]:
    """Line-by-line parser: exact line numbers in errors; empty cells become NaN. Without a final newline
    (``complete`` False: a logger stopped mid-write) a last line with too few fields is dropped and its line
    number returned with the columns. ``offset``: file line index of ``lines[0]`` (a block of a streamed file);
    ``first``: index of the file's first data line in ``lines`` (None: not in ``lines``); ``bad``: a list that
    collects (row, line number) of an unreadable line instead of its error (None: the error)."""
    ncol = len(colnames)
    first = -1 if first is None else first
    cols: dict[int, list] = {j: [] for j in keep}
    numeric = [j for j in keep if j not in textable]
    last = max((i for i in range(start, len(lines)) if _strip_comment(lines[i]).strip()), default=-1)
    truncated = None
    for i in range(start, len(lines)):
        s = _strip_comment(lines[i])
        if not s.strip():
            continue
        toks = _split(s, delim)
        if i == last and i > first and not complete and len(toks) < ncol:
            truncated = offset + i + 1  # a logger stopped mid-line: the row is dropped and reported, not half-read
            break
        if len(toks) != ncol:
            if bad is not None:
                bad.append((len(cols[keep[0]]), offset + i + 1))
                continue
            how = "truncated" if len(toks) < ncol else "too long"
            raise OptinavError(
                f"{path.name} line {offset + i + 1} has {len(toks)} field(s), {ncol} expected ({how} or ragged row)",
                f"fix or delete that row, or check the delimiter, {SKIP_BAD_REMEDY}",
            )
        row = {}
        for j in numeric:
            tok = toks[j]
            if tok == "":
                row[j] = np.nan
                continue
            try:
                row[j] = float(tok)
            except ValueError:
                if bad is not None:
                    break
                hint = (
                    "decimal commas are not supported: write decimal points"
                    if _DECIMAL_COMMA.match(tok)
                    else "fix the cell or skip the column ('_' in columns); text is kept only in label "
                    f"columns (part, label, section, …); {SKIP_BAD_REMEDY}"
                )
                raise OptinavError(
                    f"{path.name} line {offset + i + 1}, column {j + 1} ({colnames[j]!r}): "
                    f"{tok[:40]!r} is not a number",
                    hint,
                ) from None
        else:
            for j in textable:
                cols[j].append(toks[j])
            for j, v in row.items():
                cols[j].append(v)
            continue
        bad.append((len(cols[keep[0]]), offset + i + 1))
    out = {}
    for j in keep:
        out[j] = _text_column(np.asarray(cols[j], dtype=str)) if j in textable else np.asarray(cols[j], dtype=float)
    return out, truncated


#: longest ``key,value`` preamble (lines) looked for before the header
_MAX_PREAMBLE = 50
#: non-blank, non-comment lines that :func:`_text_layout` looks at (a preamble, then 10 table lines)
_HEAD_CONTENT = 10 + _MAX_PREAMBLE
#: a ``key,value`` line; ``key:,value`` too (a Movella DOT export: ``OutputRate:,60Hz,,,,``)
_KEY_VALUE = re.compile(r"^\s*([A-Za-z][\w .()\[\]/-]*?)\s*(?::\s*[,;\t]|[,;:=\t])\s*([^,;\t]*?)\s*[,;\t]*\s*$")
#: preamble keys (normalized) that give the sample rate in Hz
RATE_KEYS = (
    "fs",
    "rate",
    "sampling_rate",
    "sample_rate",
    "samplerate",
    "sampling_frequency",
    "rate_hz",
    "fs_hz",
    "frequency",
    "odr",
    "update_rate",
    "updaterate",
    "output_rate",
    "outputrate",  # a Movella DOT export's 'OutputRate:,60Hz'
)


def _preamble(lines: list[str], content: list[int]) -> dict[str, str]:
    """Leading ``key,value`` lines (a logger's settings: ``Fs,100``, ``device: MTi``) above a table with more
    columns; ``{key: value}``, with ``rate`` set from :data:`RATE_KEYS` (Hz). Empty when there is none."""
    out: dict[str, str] = {}
    n = 0
    for i in content[:-1]:
        m = _KEY_VALUE.match(_strip_comment(lines[i]))
        if not m or _is_number(m.group(1)) or _labelled(lines[i]) is not None:  # 'AcX = 1 | AcY = 2' is a row
            break
        out[m.group(1).strip()] = m.group(2)
        n += 1
    if n == 0 or n >= len(content):
        return {}
    rest = _strip_comment(lines[content[n]])
    if max(len(rest.split(d)) for d in (",", ";", "\t")) <= 2 and len(rest.split()) <= 2:
        return {}  # a two-column table, not a preamble
    meta = {f"preamble:{k}": v for k, v in out.items()}
    for k, v in out.items():
        _rate_entry(meta, k, v)
    meta["_preamble_lines"] = str(n)
    return meta


def _banner(lines: list[str], content: list[int], delim: str | None, given: bool) -> int:
    """How many leading ``content`` lines stand above the table with fewer fields than its rows: a serial
    monitor's start-up text (``Initializing I2C devices...``), a row cut at the start of a capture. The table is
    the first run of up to 5 lines splitting into the same number (≥ 2) of fields; a line of words right above
    a headerless run stays (it is read as the header, as before). 0 when the first line fits."""
    for s in range(min(len(content) - 1, _MAX_PREAMBLE + 1)):
        block = [_strip_comment(lines[i]) for i in content[s : s + 5]]
        d = delim if given else _sniff(block)
        counts = {len(_split(x, d)) for x in block}
        if len(counts) == 1 and (n := counts.pop()) >= 2:
            break
    else:
        return 0
    if s == 0:
        return 0
    head = [_split(_strip_comment(lines[i]), d) for i in content[: s + 1]]
    if any(len(toks) >= n for toks in head[:s]):
        return 0
    # a header with fewer names than the rows have fields: read as before; so is one that names a date and a time
    # of day in two fields as one column
    dated = len(head[s - 1]) == n - 1 and _date_pair(head[s]) is not None
    if all(not _is_number(t) for t in head[s - 1]) and (all(_is_number(t) for t in head[s]) or dated):
        s -= 1
    return s


def _rate_entry(meta: dict[str, str], key: str, value: str) -> None:
    """Set ``meta``'s rate (Hz; ``100 Hz`` is fine) and its key from a ``key: value`` line whose key is one of
    :data:`RATE_KEYS`, unless a rate is set already."""
    if normalize_name(key)[0] not in RATE_KEYS or "rate" in meta:
        return
    try:
        rate = float(value.lower().replace("hz", "").strip())
    except ValueError:
        return
    meta["rate"], meta["rate_key"] = repr(rate), key.strip()


#: HyperIMU's header line naming its sensors in the order of their triads (``@Sensors: MPLAccelerometer -
#: MPLGyroscope``; ianovir/HIMUServer README.md and HIMU-filetest.csv)
_HYPERIMU_SENSORS = re.compile(r"^sensors\s*:\s*(.+)$", re.IGNORECASE)


def _hyperimu_names(comments: list[str], ncol: int) -> list[str] | None:
    """Column names of a HyperIMU file from its ``@Sensors: A - B - …`` line: three values per sensor in that order
    (a ``timestamp`` first when the row holds one more): an accelerometer's ``ax ay az`` (not a linear
    acceleration's or gravity's), a gyroscope's ``gx gy gz``, a magnetometer's ``mx my mz``, any other sensor's
    ``NAME_x`` …; None when no such line gives ``ncol`` columns."""
    m = next((m for c in comments if (m := _HYPERIMU_SENSORS.match(c))), None)
    if m is None:
        return None
    sensors = [x.strip() for x in m.group(1).split(" - ") if x.strip()]
    if ncol not in (3 * len(sensors), 3 * len(sensors) + 1):
        return None
    names = ["timestamp"] if ncol % 3 else []
    for sensor in sensors:
        low = sensor.lower().replace(" ", "")
        stem = next(
            (
                k
                for k, hit in (("a", "accel" in low), ("g", "gyro" in low), ("m", "magnet" in low))
                if hit and not any(w in low for w in ("linear", "gravity", "uncalibrated"))
            ),
            None,
        )
        if stem is None or f"{stem}x" in names:
            stem = re.sub(r"\W+", "_", sensor) + "_"
        names += [f"{stem}{a}" for a in "xyz"]
    return names


def _comment_meta(comments: list[str]) -> dict[str, str]:
    """``# units: t=s acc=m/s^2 gyro=rad/s`` (as written by write_imu) → {time_unit, acc_unit, gyro_unit}; a
    ``key: value`` comment with a rate key (``// Update Rate: 100.0Hz``) → rate (Hz), as a preamble line."""
    meta: dict[str, str] = {}
    keys = {"t": "time_unit", "time": "time_unit", "acc": "acc_unit", "gyro": "gyro_unit"}
    for c in comments:
        kv = _KEY_VALUE.match(c)
        if kv:
            _rate_entry(meta, kv.group(1), kv.group(2))
        period = re.match(r"^samplingtime\s*:\s*(\d+(?:\.\d*)?)\s*ms$", c.replace(" ", "").lower())
        if period and float(period.group(1)) > 0 and "rate" not in meta:  # HyperIMU's '@ SamplingTime: 100ms'
            meta["rate"], meta["rate_key"] = repr(1000.0 / float(period.group(1))), "SamplingTime"
        m = re.search(r"\bunits?\s*:\s*(.*)$", c, re.IGNORECASE)
        if not m:
            continue
        for k, v in re.findall(r"([A-Za-z_]\w*)\s*=\s*([^\s,;]+)", m.group(1)):
            if k.lower() in keys:
                meta[keys[k.lower()]] = v
    return meta


# --- numpy, HDF5, MATLAB ------------------------------------------------------------------------------------


def _convert(arr) -> tuple[str, object]:
    """Classify a loaded array: ("array", ndarray) | ("meta", str) | ("fields", {name: ndarray}) | ("skip", why)."""
    a = np.asarray(arr)
    if a.dtype.names:
        fields = {}
        for name in a.dtype.names:
            kind, val = _convert(a[name])
            if kind == "array":
                fields[name] = val
        return ("fields", fields) if fields else ("skip", "no numeric fields")
    k = a.dtype.kind
    if k in "biuf":
        a = a.astype(float)
    elif k == "M":
        a = a.astype("datetime64[ns]").astype(np.int64) * 1e-9
    elif k == "m":
        a = a.astype("timedelta64[ns]").astype(np.int64) * 1e-9
    elif k in "US":
        a = np.char.decode(a, "utf-8", "replace") if k == "S" else a
        a = np.char.strip(a.astype(str))
    elif k == "O":
        try:
            items = [x.decode("utf-8", "replace") if isinstance(x, bytes) else x for x in a.ravel()]
        except Exception:  # noqa: BLE001
            return "skip", "object array"
        if all(isinstance(x, str) for x in items):
            a = np.asarray([x.strip() for x in items], dtype=str).reshape(a.shape)
        else:
            return "skip", "object array"
    else:
        return "skip", f"unsupported dtype {a.dtype}"
    if a.ndim == 0:
        return "meta", str(a.item())
    if a.ndim == 2 and 1 in a.shape and a.size > 1:
        a = a.reshape(-1)
    if a.ndim > 2:
        return "skip", f"{a.ndim}-D"
    if a.size == 1:
        return "meta", str(a.reshape(-1)[0])
    if a.size == 0:
        return "skip", "empty"
    return "array", a


def _add(table: Table, name: str, arr) -> None:
    kind, val = _convert(arr)
    if kind == "array":
        table.data[name] = val
    elif kind == "meta":
        table.meta[name.split("/")[-1]] = val
    elif kind == "fields":
        for k, v in val.items():
            table.data[f"{name}/{k}" if name else k] = v
    else:
        table.skipped[name] = val


def _load_numpy(path: Path) -> Table:
    kind = path.suffix.lower()[1:]
    table = Table(path=path, kind=kind, data={})
    try:
        obj = np.load(path, allow_pickle=False)
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise OptinavError(
                f"{path} holds pickled data (or is not an NPZ/NPY file); optinav never loads pickles",
                "save plain numeric arrays with numpy.savez / numpy.save",
            ) from None
        raise OptinavError(f"{path} is not a readable {kind.upper()} file ({exc})", "re-save it with numpy") from None
    except Exception as exc:  # noqa: BLE001 - zipfile/format errors of a damaged file
        raise OptinavError(
            f"{path} is not a readable {kind.upper()} file ({type(exc).__name__}: {exc})",
            "re-save it with numpy.savez / numpy.save",
        ) from None
    if isinstance(obj, np.ndarray):
        _add(table, path.stem, obj)
        # a structured .npy is a table whose fields are the columns
        table.data = {k.split("/", 1)[-1] if "/" in k else k: v for k, v in table.data.items()}
        return table
    with obj:
        for name in obj.files:
            try:
                arr = obj[name]
            except ValueError as exc:
                if "pickle" in str(exc).lower():
                    raise OptinavError(
                        f"{path}: array {name!r} is pickled (object dtype); optinav never loads pickles",
                        "save it as a numeric or string array",
                    ) from None
                raise OptinavError(f"{path}: array {name!r} is unreadable ({exc})", "re-save the file") from None
            except Exception as exc:  # noqa: BLE001
                raise OptinavError(
                    f"{path}: array {name!r} is unreadable ({type(exc).__name__}: {exc})", "re-save the file"
                ) from None
            _add(table, name, arr)
    _check_nonempty(table)
    return table


def _h5py():
    try:
        import h5py
    except ImportError:
        raise OptinavError(
            "reading HDF5 and MATLAB v7.3 files needs h5py, which is not installed", "pip install 'optinav[hdf5]'"
        ) from None
    return h5py


def _h5_open(path: Path, only: Sequence[str] | None, *, matlab: bool):
    """(open h5py file, Table with the file attributes as ``meta``, dataset paths to read) of an HDF5 or MATLAB
    v7.3 file: ``only``'s datasets, else all (MATLAB's ``#refs#`` left out); one-line errors."""
    h5py = _h5py()
    table = Table(path=path, kind="mat73" if matlab else "hdf5", data={})
    try:
        fh = h5py.File(path, "r")
    except Exception as exc:  # noqa: BLE001 - OSError for non-HDF5 files, others for damaged ones
        raise OptinavError(f"{path} is not a readable HDF5 file ({exc})", "check that the file is complete") from None
    try:
        for k, v in fh.attrs.items():
            if isinstance(v, (bytes, str, np.bytes_, np.str_)):
                table.meta[k] = v.decode("utf-8", "replace") if isinstance(v, (bytes, np.bytes_)) else str(v)
            elif np.size(v) == 1 and np.asarray(v).dtype.kind in "iuf":
                table.meta[k] = repr(float(np.asarray(v).ravel()[0]))  # e.g. a sampling_rate attribute
        found: list[str] = []
        objects: dict[str, str] = {}  # MATLAB objects (MCOS: timetable, table, string …), opaque without MATLAB

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not (matlab and name.startswith("#")):
                if matlab and "MATLAB_object_decode" in obj.attrs:
                    objects[name] = f"{name} ({_matlab_class(obj)})"
                else:
                    found.append(name)

        fh.visititems(visit)
        if objects and not only:
            from optinav.io.arrayblocks import mat_objects_error

            raise mat_objects_error(path, list(objects.values()))
        wanted = found
        if only:
            wanted = []
            for name in only:
                key = _h5_find(fh, found, name, h5py)
                if key in objects:
                    from optinav.io.arrayblocks import mat_objects_error

                    raise mat_objects_error(path, [objects[key]])
                if key is None:
                    listed = ", ".join(found[:_MAX_LISTED]) + (" …" if len(found) > _MAX_LISTED else "")
                    raise OptinavError(
                        f"{path} has no dataset {name!r} (datasets: {listed or 'none'})",
                        "use one of the dataset paths listed",
                    )
                wanted.append(key)
    except OptinavError:
        fh.close()
        raise
    except Exception as exc:  # noqa: BLE001 - h5py raises many types for damaged files
        fh.close()
        raise h5_damaged(path, exc) from None
    return fh, table, wanted


def h5_damaged(path: Path, exc: Exception) -> OptinavError:
    return OptinavError(
        f"{path}: could not read the HDF5 content ({type(exc).__name__}: {exc})", "check that the file is complete"
    )


def _h5_unit(ds) -> str | None:
    """A dataset's ``unit``/``units`` attribute."""
    unit = ds.attrs.get("unit", ds.attrs.get("units"))
    if isinstance(unit, (bytes, np.bytes_)):
        unit = unit.decode("utf-8", "replace")
    return unit if isinstance(unit, str) else None


def _load_hdf5(path: Path, only: Sequence[str] | None, *, matlab: bool) -> Table:
    fh, table, wanted = _h5_open(path, only, matlab=matlab)
    h5py = _h5py()
    try:
        with fh:
            for name in wanted:
                ds = fh[name]
                arr = _h5_read(fh, ds, matlab, h5py)
                if arr is None:
                    table.skipped[name] = "unsupported MATLAB/HDF5 type"
                    continue
                _add(table, name, arr)
                unit = _h5_unit(ds)
                if unit is not None and name in table.data:
                    table.units[name] = unit
    except OptinavError:
        raise
    except Exception as exc:  # noqa: BLE001 - h5py raises many types for damaged files
        raise h5_damaged(path, exc) from None
    _check_nonempty(table)
    return table


def _h5_find(fh, found: list[str], name: str, h5py) -> str | None:
    for cand in (name.lstrip("/"), name.lstrip("/").replace(".", "/")):
        if cand in found:
            return cand
        obj = fh.get(cand)
        if obj is not None and isinstance(obj, h5py.Dataset):
            return obj.name.lstrip("/")
    low = [f for f in found if f.lower() == name.lstrip("/").lower()]
    return low[0] if len(low) == 1 else None


def _matlab_class(ds) -> str:
    """A MATLAB v7.3 dataset's ``MATLAB_class`` attribute ("double", "char", "cell" …; "" without one)."""
    cls = ds.attrs.get("MATLAB_class", b"")
    return cls.decode() if isinstance(cls, (bytes, np.bytes_)) else str(cls)


def _h5_read(fh, ds, matlab: bool, h5py, sel=()):
    """A dataset's value (``sel``: an h5py selection of it, such as a block of rows); MATLAB v7.3 data are
    transposed back and chars/cells of strings decoded."""
    if not matlab:
        if ds.dtype.kind == "O" and h5py.check_string_dtype(ds.dtype) is None:
            return None  # references or other object data
        return ds[sel]
    cls = _matlab_class(ds)
    if ds.attrs.get("MATLAB_empty", 0):
        return None
    if cls == "char":
        codes = np.asarray(ds[sel]).T  # rows × characters in MATLAB layout
        codes = np.atleast_2d(codes)
        rows = ["".join(map(chr, r)).rstrip() for r in codes.astype(np.int64)]
        return np.asarray(rows[0] if len(rows) == 1 else rows, dtype=str)
    if cls == "cell":
        refs = np.asarray(ds[sel]).T.ravel()
        items = []
        for ref in refs:
            val = _h5_read(fh, fh[ref], True, h5py)
            if val is None or np.asarray(val).dtype.kind != "U" or np.asarray(val).ndim != 0:
                return None
            items.append(str(val))
        return np.asarray(items, dtype=str)
    if ds.dtype.kind not in "biuf":
        return None
    return np.asarray(ds[sel]).T


def _mat_flavour(path: Path) -> str:
    """ "mat73" (MATLAB v7.3, HDF5 inside), "hdf5" (a plain HDF5 file named .mat) or "mat" (v4/v5)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(520)
    except OSError as exc:
        raise OptinavError(f"cannot read {path} ({exc.strerror})", "check the file and its permissions") from None
    if head.startswith(b"MATLAB 7.3") or head[512:520] == _HDF5_MAGIC:
        return "mat73"
    return "hdf5" if head.startswith(_HDF5_MAGIC) else "mat"


def _load_mat(path: Path, only: Sequence[str] | None) -> Table:
    flavour = _mat_flavour(path)
    if flavour != "mat":
        return _load_hdf5(path, only, matlab=flavour == "mat73")
    import scipy.io

    from optinav.io.arrayblocks import check_mat5

    check_mat5(path)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mat = scipy.io.loadmat(path, simplify_cells=True)
    except Exception as exc:  # noqa: BLE001 - scipy raises many types for damaged or foreign files
        raise OptinavError(
            f"{path} is not a readable MATLAB file ({type(exc).__name__}: {str(exc)[:120]})",
            "save it from MATLAB with save(..., '-v7') or '-v7.3'",
        ) from None
    table = Table(path=path, kind="mat", data={})
    for key, value in mat.items():
        if not key.startswith("__"):
            _mat_walk(table, key, value)
    _check_nonempty(table)
    return table


def _mat_walk(table: Table, prefix: str, value) -> None:
    """Add a MATLAB v4/v5 variable as scipy.io.loadmat(simplify_cells=True) returns it: structs as ``a/b``,
    cells of strings or numbers as arrays (other cells skipped), strings as metadata, arrays as columns."""
    if isinstance(value, dict):
        for k, v in value.items():
            _mat_walk(table, f"{prefix}/{k}" if prefix else k, v)
    elif isinstance(value, (list, tuple)):
        if value and all(isinstance(v, str) for v in value):
            _add(table, prefix, np.asarray([v.strip() for v in value], dtype=str))
        elif value and all(isinstance(v, (int, float, np.number)) for v in value):
            _add(table, prefix, np.asarray(value, dtype=float))
        else:
            table.skipped[prefix] = "cell array"
    elif isinstance(value, str):
        table.meta[prefix.split("/")[-1]] = value
    else:
        _add(table, prefix, value)


def _check_nonempty(table: Table) -> None:
    if not table.data:
        extra = f" (unreadable: {table.names()})" if table.skipped else ""
        single = _single_values(table)
        if single:
            raise OptinavError(
                f"{table.path} holds a single sample ({single} are one value each, read as the file's settings)",
                "record more than one sample",
            )
        raise OptinavError(
            f"{table.path} holds no numeric arrays{extra}",
            "save the data as numeric arrays (one per quantity, or one samples × columns matrix)",
        )


def _single_values(table: Table, limit: int = 6) -> str:
    """The names of the file's one-value numeric entries (read as settings, like a rate), for messages."""
    names = []
    for k, v in table.meta.items():
        try:
            float(v)
        except (TypeError, ValueError):
            continue
        names.append(k)
    return ", ".join(names[:limit]) + (", …" if len(names) > limit else "")


def _split_single_table(table: Table) -> Table:
    """A file whose only numeric array is 2-D with several columns becomes columns col1..colK."""
    numeric = [k for k, v in table.data.items() if v.dtype.kind == "f"]
    if len(numeric) == 1 and table.data[numeric[0]].ndim == 2 and table.data[numeric[0]].shape[1] >= 2:
        name = numeric[0]
        arr = table.data.pop(name)
        cols = dict(zip(generic_names(arr.shape[1]), arr.T))
        table.data = {**cols, **table.data}
        table.table, table.table_array = name, arr
    return table


def _name_table_columns(table: Table, names: Sequence[str]) -> Table:
    if table.table is None:
        raise OptinavError(
            f"{table.path.name} holds named arrays ({table.names()}), not one samples × columns table, "
            "so positional column names do not apply",
            "use std=name entries, e.g. columns='t=time'",
        )
    cols = [k for k in table.data if re.fullmatch(r"col\d+", k)]
    if len(cols) != len(names):
        raise OptinavError(
            f"columns names {len(names)} column(s) but {table.table!r} in {table.path.name} has "
            f"{len(cols)} (is it stored transposed?)",
            "give one name per column in order, '_' to skip one",
        )
    data = {n: table.data[c] for n, c in zip(names, cols) if n not in SKIP_NAMES}
    data.update({k: v for k, v in table.data.items() if k not in cols})
    table.data = data
    return table
