"""Writing output files safely: one atomic writer for every output, and inputs that are never overwritten.

Every file optinav writes goes through :func:`atomic_path` (or the helpers built on it): a unique temporary file
in the target's folder, written, fsynced and renamed over the target with :func:`os.replace`, so a reader sees
the old file or the new one, never half of one; on failure the temporary file is removed and the OS error
becomes a one-line :class:`OptinavError` naming the path and the cause. ``os.replace`` replaces a symlink at the
target rather than following it.

The CLI registers the files a command reads with :func:`protect_inputs`; while they are registered, any write
that would land on one of them (same path, symlink or hard link) is refused, so ``--out`` equal to an input
cannot destroy it.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Iterable, Iterator

from optinav.errors import OptinavError

#: (st_dev, st_ino) → path as given, of the files the running command reads
_PROTECTED: dict[tuple[int, int], str] = {}

_CAUSES = {
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.ENOSPC: "no space left on the device",
    errno.EFBIG: "the file-size limit was reached (disk full or ulimit -f)",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EISDIR: "it is a folder",
    errno.ENOTDIR: "a part of its folder path is a file",
    errno.ENOENT: "its folder does not exist",
    errno.ENAMETOOLONG: "the name is too long",
}


#: lines per block of the streamed text reader (:func:`optinav.io.iter_table`): about 100 B of text and 8 B per
#: parsed cell each, so a block holds some tens of MB whatever the file's length
CHUNK_ROWS = 200_000


def describe(exc: OSError) -> str:
    """The cause of an OS error in words ("the file system is read-only", ...).

    Parameters
    ----------
    exc : OSError
        The error.

    Returns
    -------
    str
        The cause.
    """
    return _CAUSES.get(exc.errno or -1) or (exc.strerror or type(exc).__name__)


def os_error(path, exc: OSError, option: str = "--out") -> OptinavError:
    """The one-line error for an OS failure while writing ``path``.

    Parameters
    ----------
    path : str or Path
        The file being written.
    exc : OSError
        The failure.
    option : str
        The CLI option that names the output (for the remedy).

    Returns
    -------
    OptinavError
        The error to raise.
    """
    return OptinavError(f"cannot write {path}: {describe(exc)}", f"choose a writable {option} with free space")


def _key(path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino)


@contextlib.contextmanager
def protect_inputs(paths: Iterable) -> Iterator[None]:
    """While active, refuse every write onto one of ``paths`` (existing regular files; others are ignored).

    Parameters
    ----------
    paths : iterable of str or Path
        The input files.

    Yields
    ------
    None
        Inside the block the inputs are protected.
    """
    added = []
    for p in paths:
        k = _key(p)
        if k is not None and os.path.isfile(p) and k not in _PROTECTED:
            _PROTECTED[k] = str(p)
            added.append(k)
    try:
        yield
    finally:
        for k in added:
            _PROTECTED.pop(k, None)


def input_at(path) -> str | None:
    """The protected input that ``path`` would overwrite (same file, symlink or hard link).

    Parameters
    ----------
    path : str or Path
        A prospective output.

    Returns
    -------
    str or None
        The input, or None.
    """
    k = _key(path)
    return _PROTECTED.get(k) if k is not None else None


def check_output(path, option: str = "--out") -> Path:
    """Check before any work that ``path`` can be written: not an input, not a folder, its folder exists, is a folder
    and is writable.

    Parameters
    ----------
    path : str or Path
        The output file.
    option : str
        The CLI option that names it (for the remedy).

    Returns
    -------
    Path
        ``path``.
    """
    out = Path(path)
    src = input_at(out)
    if src is not None:
        raise OptinavError(
            f"{option} {out} is the input {src}: writing it would destroy the input", f"choose another {option}"
        )
    if out.is_dir():
        raise OptinavError(f"{option} {out} is a folder", f"give a file name for {option}")
    _refuse_special(out, option)
    parent = out.parent
    if not parent.exists():
        # a regular file somewhere up the path makes it "does not exist" too; say which
        for up in parent.parents:
            if up.exists():
                if not up.is_dir():
                    raise OptinavError(
                        f"the folder of {option} ({parent}) lies below the file {up}", f"choose another {option}"
                    )
                break
        raise OptinavError(f"the folder of {option} ({parent}) does not exist", "create it first")
    if not parent.is_dir():
        raise OptinavError(f"the folder of {option} ({parent}) is a file", f"choose another {option}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OptinavError(f"cannot write {out}: the folder {parent} is not writable", f"choose a writable {option}")
    return out


#: suffixes of files optinav reads as data or configuration: an existing one is replaced by an output only when
#: optinav wrote it (:func:`check_replace`)
DATA_SUFFIXES = frozenset(
    {
        ".csv",
        ".txt",
        ".tsv",
        ".dat",
        ".gz",
        ".npz",
        ".npy",
        ".h5",
        ".hdf5",
        ".mat",
        ".parquet",
        ".json",
        ".yaml",
        ".yml",
        ".bag",
        ".mcap",
        ".db3",
    }
)
#: ``mark`` of :func:`check_replace` for the data files ``optinav simulate`` writes (their truth beside them)
SIMULATED = "simulated"
#: ``mark`` of :func:`check_replace` for result JSON (a simulator's truth is no result)
RESULT_MARK = b'"schema": "optinav.'


def imu_tk_file(head: bytes) -> bool:
    """``mark`` of :func:`check_replace` for imu_tk's parameter files: numbers only, opening with imu_tk's
    misalignment matrix T (three rows of three numbers, 1 on the diagonal) and a blank line. A whitespace-separated
    numeric log (imu_tk's own data files, ``t ax ay az``) was replaced by ``--to imu_tk --out`` with exit 0 when
    numbers only were asked (probe).

    Parameters
    ----------
    head : bytes
        The first bytes of the file (256 hold T).

    Returns
    -------
    bool
        Whether they are numbers and white space only and begin as imu_tk's parameter file does.
    """
    if not re.fullmatch(rb"[\s0-9eE.+-]*", head):
        return False
    lines = head.replace(b"\r", b"").split(b"\n")
    if len(lines) < 5 or lines[3].strip():
        return False
    rows = [ln.split() for ln in lines[:3]]
    return all(len(r) == 3 for r in rows) and all(rows[i][i] == b"1" for i in range(3))


#: the signature every HDF5 file starts with
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def is_hdf5(path) -> bool:
    """Whether the file ``path`` starts with the HDF5 signature (False when it cannot be read).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    bool
        Whether its first 8 bytes are :data:`HDF5_MAGIC`.
    """
    return _head(Path(path), 8) == HDF5_MAGIC


def _head(path: Path, n: int) -> bytes | None:
    """The first ``n`` bytes of the file ``path``; None when it cannot be read."""
    try:
        with open(path, "rb") as fh:
            return fh.read(n)
    except OSError:
        return None


def check_replace(path, option: str = "--out", mark: bytes | str | None = None) -> None:
    """Refuse to replace an existing data file that is not what the command writes (a raw log, a sections list, a
    simulator's truth): ``optinav attitude flight.csv --out mp.csv`` replaced a simulated log, exit 0.

    Parameters
    ----------
    path : str or Path
        The output file.
    option : str
        The CLI option that names it.
    mark : bytes, str, callable or None
        What the command writes: bytes its files hold in their first 256 (:data:`RESULT_MARK`, a table's header),
        :data:`SIMULATED` (a data file with ``STEM.truth.json`` beside it), a test of the first bytes
        (:func:`imu_tk_file`), or None (any file that names optinav in its first bytes). Empty files and files of
        other suffixes than :data:`DATA_SUFFIXES` (reports, figures) are replaced.
    """
    out = Path(path)
    if out.suffix.lower() not in DATA_SUFFIXES:
        return
    head = _head(out, 256) if out.is_file() else None
    if not head:
        return  # no file, an empty one, or unreadable (the write names the cause)
    schema = next((ln for ln in head.splitlines() if b'"schema"' in ln), b"")
    if mark == SIMULATED:
        ours = out.with_name(out.stem + ".truth.json").is_file()
    elif mark == RESULT_MARK:
        ours = mark in head and b"truth" not in schema
    elif callable(mark):
        ours = bool(mark(head))
    elif isinstance(mark, bytes):
        ours = mark in head
    else:
        ours = b"optinav" in head and b"truth" not in schema
    if ours:
        return
    first = (schema or head.split(b"\n", 1)[0])[:60].decode("utf-8", "replace").strip()
    raise OptinavError(
        f"{option} {out} exists and is not a file this command writes (it begins {first!r}): it would be replaced",
        f"choose another {option}, or remove the file first",
    )


def _refuse_special(out: Path, option: str, named: str | None = None, remedy: str | None = None) -> None:
    """A named pipe, device or socket at the output path is refused: the atomic write (a file renamed over it)
    would replace it with a regular file (a FIFO a reader waits on was unlinked, exit 0; /dev/null as root)."""
    import stat

    try:
        mode = os.stat(out).st_mode
    except OSError:
        return
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        kind = "a named pipe" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        raise OptinavError(
            f"{named or f'{option} {out}'} is {kind}, not a file", remedy or f"give a file name for {option}"
        )


@contextlib.contextmanager
def atomic_path(path, option: str = "--out") -> Iterator[Path]:
    """A unique temporary path beside ``path`` (same suffix, so format-by-suffix writers work).

    When the block ends without error the file is fsynced and renamed to ``path``, otherwise removed. OS errors
    become a one-line :class:`OptinavError`; a protected input at ``path`` is refused.

    Parameters
    ----------
    path : str or Path
        The output file.
    option : str
        The CLI option that names it (for the remedy).

    Yields
    ------
    Path
        The temporary path to write.
    """
    path = Path(path)
    src = input_at(path)
    if src is not None:
        raise OptinavError(
            f"{option} {path} is the input {src}: writing it would destroy the input", f"choose another {option}"
        )
    _refuse_special(path, option)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent or ".")
        os.close(fd)
    except OSError as exc:
        raise os_error(path, exc, option) from None
    tmp = Path(tmp)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        # mkstemp makes the file private (0600); give it the permissions an ordinary new file would get
        try:
            mode = os.stat(path).st_mode & 0o777
        except OSError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        raise os_error(path, exc, option) from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


@contextlib.contextmanager
def scratch_file(path, option: str = "--out") -> Iterator:
    """A unique temporary binary file beside the output ``path`` (the same folder, so the same disk), open for
    reading and writing, and removed when the block ends, with or without error; OS errors become a one-line
    :class:`OptinavError` naming ``path``.

    Parameters
    ----------
    path : str or Path
        The output the scratch data serve (its folder holds the file).
    option : str
        The CLI option that names it.

    Yields
    ------
    file object
        The open scratch file (binary, read and write).
    """
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".scratch", dir=path.parent or ".")
    except OSError as exc:
        raise os_error(path, exc, option) from None
    # POSIX: unnamed at once (only the open file is used), so a process killed with SIGKILL — a batch worker when
    # its batch is killed — leaves no file behind (each left 200 B per sample of an --offline log in the temp folder)
    named = True
    if os.name == "posix":
        with contextlib.suppress(OSError):
            os.unlink(tmp)
            named = False
    try:
        with os.fdopen(fd, "w+b") as fh:
            yield fh
    except OSError as exc:
        raise os_error(path, exc, option) from None
    finally:
        if named:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", option: str = "--out", **kwargs) -> Iterator:
    """:func:`atomic_path` opened as a file.

    Parameters
    ----------
    path : str or Path
        The output file.
    mode : str
        ``"w"`` or ``"wb"`` (text defaults to UTF-8).
    option : str
        The CLI option that names it.
    **kwargs
        Passed to ``open``.

    Yields
    ------
    file object
        The open temporary file.
    """
    if "b" not in mode:
        kwargs.setdefault("encoding", "utf-8")
    with atomic_path(path, option) as tmp:
        try:
            with open(tmp, mode, **kwargs) as fh:
                yield fh
        except OSError as exc:
            raise os_error(path, exc, option) from None


def write_text(path, text: str, option: str = "--out") -> Path:
    """Write ``text`` to ``path`` atomically (UTF-8).

    Parameters
    ----------
    path : str or Path
        The output file.
    text : str
        The content.
    option : str
        The CLI option that names it.

    Returns
    -------
    Path
        The file written.
    """
    with atomic_open(path, "w", option, newline="\n") as fh:
        fh.write(text)
    return Path(path)


#: lists of at least this many values go through :func:`_number_list_text` in :func:`json_text`
_LONG_LIST = 32
#: placeholder of such a list in the skeleton json.dumps writes (a string no result holds; checked)
_LIST_MARK = "@@optinav-numbers:"


def _plain_numbers(values: list) -> bool:
    """True when every leaf of the nested list is a finite float, an int (not a bool) or None."""
    for v in values:
        t = type(v)
        if t is float:
            if v - v != 0.0:  # inf or NaN: json.dumps(allow_nan=False) must refuse it
                return False
        elif t is list:
            if not _plain_numbers(v):
                return False
        elif t is not int and v is not None:
            return False
    return True


def _number_list_text(values: list, level: int, indent: str) -> str:
    """The text json.dumps writes for a nested list of plain numbers at indentation ``level``."""
    if not values:
        return "[]"
    inner = "\n" + indent * (level + 1)
    items = [
        _number_list_text(v, level + 1, indent) if type(v) is list else "null" if v is None else repr(v) for v in values
    ]
    return "[" + inner + ("," + inner).join(items) + "\n" + indent * level + "]"


def json_text(data, indent: int = 2) -> str:
    """``json.dumps(data, indent=indent, allow_nan=False)``, the same text, with the long lists of plain numbers
    (a result's arrays) joined from their reprs: json's indented encoder is pure Python, about 2 µs a number
    (seconds for the estimate of a long log). The rest goes through json.dumps, with each such list as a
    placeholder string put back at its line's indentation.

    Parameters
    ----------
    data : Any
        Plain JSON types.
    indent : int, str or None
        Spaces per level (a string or None: json.dumps's own handling).

    Returns
    -------
    str
        The JSON text.
    """
    if type(indent) is not int:  # None (compact) or a string: json.dumps as it is
        return json.dumps(data, indent=indent, allow_nan=False)
    lists: list[list] = []

    def skeleton(node):
        if type(node) is dict:
            return {k: skeleton(v) for k, v in node.items()}
        if type(node) is list:
            if len(node) >= _LONG_LIST and _plain_numbers(node):
                lists.append(node)
                return f"{_LIST_MARK}{len(lists) - 1}@@"
            return [skeleton(v) for v in node]
        return node

    head = skeleton(data)
    text = json.dumps(head, indent=indent, allow_nan=False)
    if not lists:
        return text
    if text.count(_LIST_MARK) != len(lists):  # a string of the data holds the mark: no placeholders
        return json.dumps(data, indent=indent, allow_nan=False)
    pad = " " * indent

    def put(m: re.Match) -> str:
        line = end = text.rfind("\n", 0, m.start()) + 1
        while text[end] == " ":
            end += 1
        level = (end - line) // indent if indent else 0
        return _number_list_text(lists[int(m.group(1))], level, pad)

    return re.sub(f'"{_LIST_MARK}(\\d+)@@"', put, text)


def write_json(path, data, option: str = "--out", **kwargs) -> Path:
    """Write ``data`` as indented JSON (strict: no NaN) to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        The output file.
    data : dict or list
        Plain JSON types.
    option : str
        The CLI option that names it.
    **kwargs
        Passed to ``json.dumps``.

    Returns
    -------
    Path
        The file written.
    """
    text = json.dumps(data, indent=2, allow_nan=False, **kwargs) if kwargs else json_text(data)
    return write_text(path, text + "\n", option)


def write_csv(
    path, table, header: str, fmt: str = "%.17g", *, comments: str = "", delimiter: str = ",", option: str = "--out"
) -> Path:
    """Write a 2-D numeric ``table`` as delimited text with ``header`` (lines prefixed by ``comments``) atomically.

    Parameters
    ----------
    path : str or Path
        The output file.
    table : (N, k) array
        The values [as the header's columns state].
    header : str
        The header line(s).
    fmt : str
        Number format.
    comments : str
        Prefix of the header lines.
    delimiter : str
        Column delimiter.
    option : str
        The CLI option that names it.

    Returns
    -------
    Path
        The file written.
    """
    head = comments + header.replace("\n", "\n" + comments) if header else ""
    with csv_writer(path, head, fmt, delimiter=delimiter, option=option) as write:
        write(table)
    return Path(path)


@contextlib.contextmanager
def csv_writer(path, header: str, fmt="%.17g", *, delimiter: str = ",", option: str = "--out") -> Iterator:
    """A delimited text file written block by block, atomically (:func:`atomic_open`).

    Parameters
    ----------
    path : str or Path
        The file; it appears only when the ``with`` block ends without an error.
    header : str
        The first line(s), written as given; empty: none.
    fmt : str or list of str
        ``numpy.savetxt`` format: one, or one per column.
    delimiter : str
        Column delimiter.
    option : str
        The CLI option named in errors.

    Yields
    ------
    callable
        ``write(table)`` appends the rows of a 2-D numeric block.
    """

    with atomic_open(path, "w", option, newline="\n") as fh:
        if header:
            fh.write(header + "\n")
        yield lambda table: _savetxt(fh, table, fmt, delimiter)


def _savetxt(fh, table, fmt, delimiter: str) -> None:
    """``numpy.savetxt(fh, table, delimiter=delimiter, fmt=fmt)``, the same text, formatted 4096 rows at a time with
    one ``%`` (savetxt formats and writes row by row: 0.66 s for 60 000 rows of 10 columns, this 0.38 s)."""
    import numpy as np

    x = np.asarray(table)
    if x.ndim == 1:
        x = x[:, None]
    if isinstance(fmt, str):
        row = delimiter.join([fmt] * x.shape[-1]) if fmt.count("%") == 1 else fmt
    else:
        row = delimiter.join(fmt) if isinstance(fmt, (list, tuple)) and len(fmt) == x.shape[-1] else ""
    if x.ndim != 2 or x.dtype.kind not in "biuf" or not x.shape[1] or row.count("%") != x.shape[1]:
        np.savetxt(fh, table, delimiter=delimiter, fmt=fmt)  # its own handling and errors
        return
    row += "\n"
    for i in range(0, x.shape[0], 4096):
        block = x[i : i + 4096]
        fh.write((row * block.shape[0]) % tuple(block.ravel().tolist()))


def check_sidecar(path, signature: str, option: str = "--out") -> Path:
    """Check a file written beside the main output (e.g. ``x.truth.json``).

    Refuse to replace an existing file that does not start with ``signature`` (i.e. one optinav did not write),
    and any protected input.

    Parameters
    ----------
    path : str or Path
        The sidecar file.
    signature : str
        The start of a file optinav wrote.
    option : str
        The CLI option that names the main output.

    Returns
    -------
    Path
        ``path``.
    """
    p = Path(path)
    src = input_at(p)
    if src is not None:
        raise OptinavError(f"{p} (written beside {option}) is the input {src}", f"choose another {option}")
    if p.is_dir():
        raise OptinavError(f"{p} (written beside {option}) is a folder", f"choose another {option}")
    # before it is read: a pipe would block
    _refuse_special(p, option, f"{p} (written beside {option})", f"move it away or choose another {option}")
    if p.exists():
        head = _head(p, len(signature.encode()) + 64) or b""
        if not head.lstrip().startswith(signature.encode()):
            raise OptinavError(
                f"{p} exists and was not written by optinav; writing beside {option} would replace it",
                f"move it away or choose another {option}",
            )
    return p


# --- reading small text inputs (results, configurations, section lists) -----------------------------------

#: deeper JSON than this is not something optinav wrote (its files nest a few levels)
MAX_JSON_DEPTH = 64


def input_kind(path, what: str = "data file", remedy: str = "check the path") -> str:
    """What an input path is, or a one-line :class:`OptinavError` naming ``what``: missing, not to be looked at
    (a folder on the way without permission), or neither a regular file nor a folder — a named pipe or a device,
    whose reading would block or never end.

    Parameters
    ----------
    path : str or Path
        The input.
    what : str
        What it is, for the message.
    remedy : str
        What to do when it is missing, for the message.

    Returns
    -------
    str
        ``"file"`` or ``"dir"``.
    """
    import stat

    p = Path(path)
    try:
        mode = p.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        raise OptinavError(f"{what} {p} does not exist", remedy) from None
    except OSError as exc:
        raise OptinavError(f"cannot read {what} {p} ({describe(exc)})", "check the file and its permissions") from None
    if stat.S_ISDIR(mode):
        return "dir"
    if stat.S_ISREG(mode):
        return "file"
    kind = "a named pipe" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
    raise OptinavError(f"{what} {p} is {kind}, not a file", "save the data to a file and pass that")


def kitti_oxts_folder(path) -> Path | None:
    """The KITTI raw ``oxts`` folder that ``path`` is (``timestamps.txt`` beside ``data/NNNNNNNNNN.txt``), or
    whose ``data`` folder it is; None otherwise.

    Parameters
    ----------
    path : str or Path
        A folder.

    Returns
    -------
    Path or None
        The ``oxts`` folder.
    """
    p = Path(path)
    for d in (p, p.parent):
        if (d / "timestamps.txt").is_file() and (d / "data").is_dir() and (p == d or p.name == "data"):
            return d
    return None


def read_text(path, what: str = "file", remedy: str = "check the path") -> str:
    """The UTF-8 text of ``path``; a missing file, a folder, an OS error or bytes that are not UTF-8 become a one-line
    :class:`OptinavError` naming ``what``.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for the message.
    remedy : str
        What to do, for the message.

    Returns
    -------
    str
        The text.
    """
    p = Path(path)
    if input_kind(p, what, remedy) == "dir":
        raise OptinavError(f"{what} {p} is a folder", "pass a file")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise OptinavError(f"cannot read {what} {p}: {exc.strerror or exc}", "check the file's permissions") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise OptinavError(
            f"{what} {p} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            "pass the text file optinav or your tool wrote, saved as UTF-8",
        ) from None


def parse_json(text: str, src: str, remedy: str):
    """``json.loads(text)`` with every parser failure as a one-line :class:`OptinavError` naming ``src``.

    Failures: syntax, nesting deeper than :data:`MAX_JSON_DEPTH`, numbers too long to convert.

    Parameters
    ----------
    text : str
        The JSON text.
    src : str
        Where it came from, for the message.
    remedy : str
        What to do, for the message.

    Returns
    -------
    Any
        The parsed value.
    """
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise OptinavError(f"{src} is not valid JSON ({exc.msg} at line {exc.lineno})", remedy) from None
    except RecursionError:
        raise OptinavError(f"{src} is JSON nested too deeply to read", remedy) from None
    except ValueError as exc:  # e.g. an integer literal with thousands of digits
        raise OptinavError(f"{src} is not readable JSON ({' '.join(str(exc).split())[:80]})", remedy) from None
    # the containers only go on the stack (every number did, seconds on long logs); one at the deepest level
    # allowed must be empty, as its values would be a level deeper
    stack = [(data, 1)] if isinstance(data, (dict, list)) else []
    while stack:
        node, depth = stack.pop()
        if depth > MAX_JSON_DEPTH or (depth == MAX_JSON_DEPTH and node):
            raise OptinavError(f"{src} is JSON nested more than {MAX_JSON_DEPTH} levels deep", remedy)
        values = node.values() if isinstance(node, dict) else node
        stack.extend((v, depth + 1) for v in values if isinstance(v, (dict, list)))
    return data
