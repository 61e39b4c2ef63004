"""Binary data files (NPY, NPZ, HDF5, MATLAB v5/v7 and v7.3) read in row blocks for :func:`optinav.io.iter_table`.

A file's arrays are grouped by their number of samples (rows; a 1×N or N×1 array is a vector of N); the length
holding the most bytes is the blocks' length, and each array of that length is read a block of rows at a time
(HDF5 slices, seek-and-read of NPY data, a sequential read of each NPZ member, compressed or not; a MATLAB
v5/v7 numeric matrix from its column-major data, a compressed one first inflated into a scratch file). Every other
array (a 3×3 matrix beside the samples, a vector at another rate) comes whole in the first block and empty in
the others (:attr:`~optinav.io.readers.Table.fixed`), scalars as metadata in every block: each name's blocks join
to what :func:`~optinav.io.readers.load_table` returns. A file of at most one block, or one these readers do
not handle (object arrays, a .npy version they do not know, MATLAB v4), is read whole by ``load_table``, which also gives
its errors.
"""

from __future__ import annotations

import dataclasses
import struct
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["array_blocks", "block_bounds", "check_mat5", "is_mat5", "mat5_names", "sample_axis"]


def block_bounds(n: int, chunk_rows: int) -> list[tuple[int, int]]:
    """The ``[a, b)`` row ranges of ``n`` rows in blocks of at most ``chunk_rows`` (at least 2), none of a single
    row (a lone row would read as a scalar, a 1×3 row as a vector of 3): a last block of one row takes one from
    the block before."""
    step = max(int(chunk_rows), 2)
    out = [(a, min(a + step, n)) for a in range(0, n, step)]
    if len(out) > 1 and out[-1][1] - out[-1][0] == 1:
        (a, b), _ = out[-2:]
        out[-2:] = [(a, b - 1), (b - 1, n)] if b - a > 2 else [(a, n)]
    return out


def sample_axis(shape: tuple[int, ...]) -> tuple[int, int] | None:
    """(axis, samples) of an array as :func:`optinav.io.readers._convert` sees it: a vector's length (a 1×N or
    N×1 matrix is one), else the rows of a matrix; None for a scalar, a single value or a >2-D array."""
    size = int(np.prod(shape, dtype=np.int64))
    if size <= 1 or len(shape) not in (1, 2):
        return None
    if len(shape) == 2 and 1 in shape:
        return (1 if shape[0] == 1 else 0), size
    return 0, int(shape[0])


@dataclasses.dataclass
class _Item:
    """One array of a file: ``rows`` samples along its sample axis (None: not a sample array), ``read(a, b)``
    rows a:b as the whole-file reader would hold them before conversion (None: only whole), ``whole()``."""

    name: str
    rows: int | None
    nbytes: int
    read: Callable[[int, int], np.ndarray] | None
    whole: Callable[[], np.ndarray | None]
    unit: str | None = None
    #: how a whole value joins the table (default :func:`optinav.io.readers._add`; MATLAB v5: structs, cells)
    add: Callable | None = None


@dataclasses.dataclass
class _Source:
    table: object  # the Table template: kind, meta, skipped
    items: list[_Item]
    close: Callable[[], None]
    fixed_keys: dict = dataclasses.field(default_factory=dict)  # item name → its table keys (not sliced)
    fixed_empty: dict = dataclasses.field(default_factory=dict)  # table key → its empty array


def array_blocks(path: Path, kind: str, *, names, only, chunk_rows: int, load, progress=None):
    """The tables of ``path`` (format ``kind``) a block of ``chunk_rows`` rows at a time (module docs); ``load()``
    reads the file whole (small files, formats not handled here). ``progress(fraction)`` after each block."""
    from optinav.io.readers import _check_nonempty, _name_table_columns, _split_single_table

    try:
        src = _open(path, kind, only)
    except OptinavError:
        raise
    except Exception:  # noqa: BLE001 - a damaged file: the whole-file reader names the problem
        src = None
    if src is None:
        yield load()
        return
    try:
        lengths: dict[int, int] = {}
        for it in src.items:
            if it.rows is not None and it.read is not None:
                lengths[it.rows] = lengths.get(it.rows, 0) + it.nbytes
        n = max(lengths, key=lengths.get) if lengths else 0
        if n <= chunk_rows:
            src.close()
            yield load()
            return
        for a, b in block_bounds(n, chunk_rows):
            table = _block(src, n, a, b, path)
            if a == 0:
                _check_nonempty(table)
            table = _split_single_table(table)
            if names is not None:
                table = _name_table_columns(table, names)
            if progress is not None:
                progress(b / n)
            yield table
    finally:
        src.close()


def _block(src: _Source, n: int, a: int, b: int, path: Path):
    """The table of rows a:b (the blocks' length ``n``); the arrays of other lengths whole when ``a`` is 0."""
    from optinav.io.readers import Table, _add

    tpl = src.table
    table = Table(path=path, kind=tpl.kind, data={}, meta=dict(tpl.meta), skipped=dict(tpl.skipped), row0=a)
    for it in src.items:
        sliced = it.rows == n and it.read is not None
        if not sliced and a > 0:  # whole in the first block: empty here
            table.data.update({k: src.fixed_empty[k] for k in src.fixed_keys[it.name]})
            continue
        try:
            arr = it.read(a, b) if sliced else it.whole()
        except OptinavError:
            raise
        except Exception as exc:  # noqa: BLE001 - h5py/zipfile/zlib errors of a damaged file
            raise OptinavError(
                f"{path}: could not read {it.name!r} ({type(exc).__name__}: {' '.join(str(exc).split())[:160]})",
                "check that the file is complete",
            ) from None
        before = set(table.data)
        if arr is None:
            table.skipped[it.name] = "unsupported MATLAB/HDF5 type"
        else:
            (it.add or _add)(table, it.name, arr)
        if not sliced:
            src.fixed_keys[it.name] = [k for k in table.data if k not in before]
            src.fixed_empty.update({k: table.data[k][:0] for k in src.fixed_keys[it.name]})
    for it in src.items:
        if it.unit is not None and it.name in table.data:
            table.units[it.name] = it.unit
    if a == 0:  # what the other arrays add to the metadata holds for every block
        tpl.meta, tpl.skipped = dict(table.meta), dict(table.skipped)
    table.fixed = frozenset(k for keys in src.fixed_keys.values() for k in keys)
    return table


def _open(path: Path, kind: str, only) -> _Source | None:
    from optinav.io.readers import _mat_flavour

    if kind == "npy":
        return _npy(path)
    if kind == "npz":
        return _npz(path)
    if kind == "hdf5":
        return _hdf5(path, only, matlab=False)
    if kind == "mat":
        flavour = _mat_flavour(path)
        if flavour != "mat":
            return _hdf5(path, only, matlab=flavour == "mat73")
        check_mat5(path)  # the blocks read variables through scipy, which walks every variable's header
        return _mat5(path)
    return None


# --- HDF5 and MATLAB v7.3 -----------------------------------------------------------------------------------


def _hdf5(path: Path, only, *, matlab: bool) -> _Source:
    from optinav.io.readers import _h5_open, _h5py

    h5py = _h5py()
    fh, table, wanted = _h5_open(path, only, matlab=matlab)
    try:
        return _Source(table, _h5_items(fh, wanted, matlab, h5py), fh.close)
    except Exception:
        fh.close()
        raise


def _h5_items(fh, wanted, matlab: bool, h5py) -> list[_Item]:
    from optinav.io.readers import _h5_read, _h5_unit, _matlab_class

    items = []
    for name in wanted:
        ds = fh[name]
        shape = tuple(ds.shape)[::-1] if matlab else tuple(ds.shape)  # MATLAB's layout is the transpose
        if matlab:
            cls = _matlab_class(ds)
            plain = not ds.attrs.get("MATLAB_empty", 0) and (cls in ("char", "cell") or ds.dtype.kind in "biuf")
            if cls == "char":  # a char matrix: one string per row
                found = (0, shape[0]) if plain and len(shape) == 2 and shape[0] >= 2 else None
            else:
                found = sample_axis(shape) if plain else None
        else:
            plain = not (ds.dtype.kind == "O" and h5py.check_string_dtype(ds.dtype) is None)
            found = sample_axis(shape) if plain and (ds.dtype.names is None or len(shape) == 1) else None
        whole = lambda ds=ds: _h5_read(fh, ds, matlab, h5py)
        if found is None:
            items.append(_Item(name, None, 0, None, whole, _h5_unit(ds)))
            continue
        axis, rows = found
        h5axis = len(shape) - 1 - axis if matlab else axis

        def read(a, b, ds=ds, h5axis=h5axis, ndim=len(shape)):
            return _h5_read(
                fh, ds, matlab, h5py, tuple(slice(a, b) if i == h5axis else slice(None) for i in range(ndim))
            )

        items.append(_Item(name, rows, int(ds.size) * ds.dtype.itemsize, read, whole, _h5_unit(ds)))
    return items


# --- NPY and NPZ --------------------------------------------------------------------------------------------


def _header(fp) -> tuple[tuple[int, ...], bool, np.dtype] | None:
    """(shape, fortran_order, dtype) of the .npy stream ``fp`` positioned at its start; None for a version these
    readers do not know or an object dtype (the whole-file reader gives its error)."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fp)
        if version == (1, 0):
            shape, fortran, dtype = fmt.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, fortran, dtype = fmt.read_array_header_2_0(fp)
        else:
            return None
    except Exception:  # noqa: BLE001 - not an NPY stream: the whole-file reader names the problem
        return None
    if dtype.hasobject:
        return None
    return tuple(shape), bool(fortran), dtype


class _Rows:
    """Rows of one .npy array read from a stream: sequentially (``seekable``: from any row, and a Fortran-order
    matrix a column at a time), the stream opened on first use by ``opener`` and positioned by ``data0``."""

    def __init__(self, opener, data0: int, shape, fortran: bool, dtype, seekable: bool):
        self.opener, self.data0, self.shape, self.dtype = opener, data0, shape, dtype
        self.fortran = fortran and len(shape) == 2 and 1 not in shape
        self.seekable, self.fp, self.at = seekable, None, 0
        axis = sample_axis(shape)
        self.axis = 0 if axis is None else axis[0]
        self.row = int(np.prod(shape, dtype=np.int64)) // max(int(shape[self.axis]), 1)  # values per row

    def _stream(self):
        if self.fp is None:
            self.fp = self.opener()
            self.fp.seek(self.data0)
            self.at = 0
        return self.fp

    def _take(self, count: int) -> np.ndarray:
        nbytes = count * self.dtype.itemsize
        buf = self.fp.read(nbytes)
        if len(buf) != nbytes:
            raise OptinavError("the file ends inside its data (truncated)", "re-save or re-copy the file")
        return np.frombuffer(buf, self.dtype)

    def read(self, a: int, b: int) -> np.ndarray:
        fp = self._stream()
        shape = list(self.shape)
        shape[self.axis] = b - a
        if self.fortran:  # column j of an (n, m) Fortran matrix is contiguous
            n, cols = self.shape[0], []
            for j in range(self.shape[1]):
                fp.seek(self.data0 + (j * n + a) * self.dtype.itemsize)
                cols.append(self._take(b - a))
            return np.column_stack(cols)
        if a != self.at:
            if not self.seekable:
                raise RuntimeError(f"rows {a}: blocks must be read in order")
            fp.seek(self.data0 + a * self.row * self.dtype.itemsize)
        out = self._take((b - a) * self.row).reshape(shape)
        self.at = b
        return out

    def close(self) -> None:
        if self.fp is not None:
            self.fp.close()
            self.fp = None


def _npy_item(name: str, opener, seekable: bool, whole) -> tuple[_Item, _Rows] | None:
    with opener() as fp:
        head = _header(fp)
        data0 = fp.tell()
    if head is None:
        return None
    shape, fortran, dtype = head
    found = sample_axis(shape) if dtype.names is None or len(shape) == 1 else None
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if found is None:
        return _Item(name, None, nbytes, None, whole), None
    rows = _Rows(opener, data0, shape, fortran, dtype, seekable)
    if rows.fortran and not seekable:
        # a Fortran-order matrix inside a compressed member cannot be read by rows: whole, then cut
        cache = {}

        def read(a, b):
            if "arr" not in cache:
                cache["arr"] = whole()
            return cache["arr"][a:b]

        return _Item(name, found[1], nbytes, read, whole), None
    return _Item(name, found[1], nbytes, rows.read, whole), rows


def _npy(path: Path) -> _Source | None:
    from optinav.io.readers import Table

    def opener():
        return open(path, "rb")

    def whole():
        return np.load(path, allow_pickle=False)

    try:
        got = _npy_item(path.stem, opener, True, whole)
    except OSError:
        return None
    if got is None or got[0].read is None:
        return None
    item, rows = got
    if rows is not None and path.stat().st_size < rows.data0 + item.nbytes:
        return None  # truncated: the whole-file reader names it
    if rows is not None and rows.dtype.names is not None:
        # a structured .npy is a table whose fields are the columns (load_table names them without the stem)
        item.name = ""
    return _Source(Table(path=path, kind="npy", data={}), [item], rows.close if rows else (lambda: None))


def _npz(path: Path) -> _Source | None:
    from optinav.io.readers import Table

    try:
        zf = zipfile.ZipFile(path)
    except Exception:  # noqa: BLE001 - the whole-file reader names the problem
        return None
    items, streams = [], []
    try:
        for info in zf.infolist():
            if not info.filename.endswith(".npy"):
                zf.close()
                return None
            name = info.filename[:-4]

            def opener(info=info):
                return zf.open(info)

            def whole(info=info):
                with zf.open(info) as fp:
                    return np.lib.format.read_array(fp, allow_pickle=False)

            got = _npy_item(name, opener, info.compress_type == zipfile.ZIP_STORED, whole)
            if got is None:
                zf.close()
                return None
            items.append(got[0])
            if got[1] is not None:
                streams.append(got[1])
    except Exception:  # noqa: BLE001 - a damaged archive: the whole-file reader names the problem
        zf.close()
        return None

    def close():
        for s in streams:
            s.close()
        zf.close()

    return _Source(Table(path=path, kind="npz", data={}), items, close)


# --- MATLAB v5/v7 (not v7.3) --------------------------------------------------------------------------------

#: MAT v5 data types of numeric data → numpy kinds (byte order added)
_MI = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 9: "f8", 12: "i8", 13: "u8"}
_MI_MATRIX, _MI_COMPRESSED = 14, 15
#: numeric array classes (mxDOUBLE_CLASS … mxUINT64_CLASS)
_MX_NUMERIC = range(6, 16)
#: variables smaller than this are read whole (scipy.io.loadmat) [bytes of data]
_MAT_STREAM_BYTES = 1 << 20


def _mat5_endian(head: bytes) -> str | None:
    """The byte order ("<" or ">") of a MATLAB v5/v7 file from its 128-byte header (the endian mark IM or MI);
    None for anything else."""
    if len(head) < 128 or head[126:128] not in (b"IM", b"MI"):
        return None
    return "<" if head[126:128] == b"IM" else ">"


def is_mat5(path: Path) -> bool:
    """Whether ``path`` is a MATLAB v5/v7 file (its 128-byte header ends in the endian mark IM or MI)."""
    try:
        with open(path, "rb") as fh:
            return _mat5_endian(fh.read(128)) is not None
    except OSError:
        return False


def mat5_names(path: Path) -> list[str] | None:
    """The variable names of a MATLAB v5/v7 file, from the variables' headers (nothing read whole); None for a
    file this reader does not walk (v4, v7.3, damaged)."""
    if not is_mat5(path):
        return None
    src = _mat5(Path(path))
    if src is None:
        return None
    src.close()
    return [it.name for it in src.items]


def _element(buf: bytes, off: int, e: str) -> tuple[int, int, int, int]:
    """(type, bytes, data offset, next offset) of the MAT v5 data element at ``off`` (small elements too)."""
    typ, n = struct.unpack_from(e + "II", buf, off)
    if typ >> 16:  # small data element: bytes in the upper half, data in the tag's second word
        return typ & 0xFFFF, typ >> 16, off + 4, off + 8
    return typ, n, off + 8, off + 8 + (n + 7) // 8 * 8


def _variables(fh, e: str, size: int, limit: int):
    """(byte offset, element type, bytes, head) of each top-level data element of an open MAT v5 file: ``head``
    its first bytes from the tag, up to ``limit`` (a compressed element inflated: up to ``limit`` bytes, from all
    of it when it is at most ``limit`` bytes, else from its first 64 KiB). A damaged compressed stream raises
    zlib.error."""
    pos = 128
    while pos + 8 <= size:
        fh.seek(pos)
        typ, n = struct.unpack(e + "II", fh.read(8))
        if typ == _MI_COMPRESSED:
            head = zlib.decompressobj().decompress(fh.read(n if n <= limit else 1 << 16), limit)
        else:
            fh.seek(pos)
            head = fh.read(min(n + 8, limit))
        yield pos, typ, n, head
        pos += 8 + n


@dataclasses.dataclass
class _MatrixHead:
    """The header of a miMATRIX element: the types and sizes of its array-flags, dimensions and name elements as
    found (``dims`` None when that element is not int32 values), and the offset of the data that follows."""

    flags_type: int
    flags_bytes: int
    flags: int
    dims_type: int
    dims: tuple | None
    name_type: int
    name: str
    data: int

    @property
    def cls(self) -> int:
        return self.flags & 0xFF


def _matrix_head(buf: bytes, e: str) -> _MatrixHead | None:
    """The header of the miMATRIX element whose tag starts ``buf`` (None: another element, or an empty one);
    struct.error when ``buf`` ends inside it."""
    typ, n, off, _ = _element(buf, 0, e)
    if typ != _MI_MATRIX or n == 0:
        return None
    ftyp, fn, d, off = _element(buf, off, e)
    flags = struct.unpack_from(e + "I", buf, d)[0]
    dtyp, dn, d, off = _element(buf, off, e)
    dims = struct.unpack_from(e + f"{dn // 4}i", buf, d) if dtyp == 5 and dn >= 8 and dn % 4 == 0 else None
    ntyp, nn, d, off = _element(buf, off, e)
    return _MatrixHead(ftyp, fn, flags, dtyp, dims, ntyp, buf[d : d + nn].decode("latin-1"), off)


def _numeric_matrix(buf: bytes, e: str):
    """(dims, name, real-part type, bytes, data offset) of a real numeric matrix whose element starts ``buf``;
    None for any other variable."""
    h = _matrix_head(buf, e)
    if h is None or h.dims is None or h.cls not in _MX_NUMERIC or h.flags & 0x800:
        return None
    typ, n, d, _ = _element(buf, h.data, e)
    return tuple(h.dims), h.name, typ, n, d


#: MAT v5 data types a char array's data may have, with their byte sizes (0: variable, UTF-8)
_MI_CHAR = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 16: 0, 17: 2, 18: 4}


def check_mat5(path: Path) -> None:
    """Refuse a MATLAB v5/v7 file whose variable headers contradict themselves (flags, array class, the data
    type and size of a numeric or char array against its dimensions) before scipy.io.loadmat reads it: its
    compiled reader crashes the process on such headers (a flipped flags byte, a data-type code out of range).
    Variables of up to 1 MiB are checked whole (the elements of cell, struct and sparse arrays too; a compressed
    one inflated), larger ones on their headers (a compressed one on its first 8 KiB). One-line
    :class:`OptinavError`."""
    limit = 1 << 20
    with open(path, "rb") as fh:
        e = _mat5_endian(fh.read(128))
        if e is None:
            return
        objects: list[str] = []
        try:
            for pos, typ, n, head in _variables(fh, e, path.stat().st_size, limit):
                obj = _mcos_object(head, e)
                if obj is not None:
                    objects.append(obj)
                    continue
                if typ != _MI_COMPRESSED:
                    whole = n + 8 <= limit
                else:  # whole when the inflated element ends inside the head
                    whole = len(head) >= 8 and struct.unpack_from(e + "I", head, 4)[0] + 8 <= len(head)
                why = _mat5_header_fault(head, e, whole)
                if why:
                    raise OptinavError(
                        f"{path.name} is not a readable MATLAB file (the variable at byte {pos}: {why})",
                        "save it again from MATLAB (save(..., '-v7') or '-v7.3')",
                    )
        except zlib.error:
            return  # scipy raises its own (Python) error for a damaged stream
    if objects:
        raise mat_objects_error(path, objects)


def mat_objects_error(path: Path, objects: list[str]) -> OptinavError:
    """The error for a MATLAB file (v5/v7 or v7.3) holding MATLAB objects, ``NAME (CLASS)`` each: the MATLAB lines
    that save their numbers as plain arrays."""
    return OptinavError(
        f"{path.name} holds MATLAB objects, which only MATLAB reads ({', '.join(objects)}; MATLAB Mobile's sensor "
        "log keeps each sensor as a timetable)",
        "save their numbers in MATLAB: t = posixtime(Acceleration.Timestamp); acc = Acceleration{:,:}; "
        "save('acc.mat','t','acc'); t = posixtime(AngularVelocity.Timestamp); gyro = AngularVelocity{:,:}; "
        "save('gyro.mat','t','gyro'); then give acc.mat with gyro_path=gyro.mat",
    )


def _mcos_object(buf: bytes, e: str) -> str | None:
    """``NAME (CLASS)`` of a top-level MATLAB object (an opaque array of MATLAB's class system, MCOS: a
    ``timetable``, ``table``, ``string``, ``datetime``) whose miMATRIX element starts ``buf``; None for any other
    element. Its header holds the variable's name, ``MCOS`` and the class name where an array holds dimensions and
    a name (what scipy.io.loadmat returns for it, a MatlabOpaque named 'None', holds no numbers)."""
    try:
        typ, n, off, _ = _element(buf, 0, e)
        if typ != _MI_MATRIX or n == 0:
            return None
        _, _, d, off = _element(buf, off, e)
        if struct.unpack_from(e + "I", buf, d)[0] & 0xFF != 17:
            return None
        parts = []
        for _ in range(3):
            ptyp, pn, d, off = _element(buf, off, e)
            if ptyp != 1:
                return None
            parts.append(buf[d : d + pn].decode("latin-1"))
    except struct.error:
        return None
    return f"{parts[0]} ({parts[2]})" if parts[1] == "MCOS" else None


#: nesting of cell and struct arrays that :func:`_mat5_header_fault` follows
_MAT5_DEPTH = 16


def _mat5_header_fault(buf: bytes, e: str, whole: bool, depth: int = 0) -> str | None:
    """What is wrong with the miMATRIX element at the start of ``buf`` (None: nothing seen); ``whole``: ``buf``
    holds the element entirely (its imaginary part and the elements of a cell or struct array are checked too,
    each inside its parent)."""
    try:
        h = _matrix_head(buf, e)
        if h is None:
            return None  # not a variable scipy reads as an array (it skips or names it), or an empty one
        if h.flags_type != 6 or h.flags_bytes != 8:
            return "array flags of another type or size"
        if not 1 <= h.cls <= 17 or (h.flags >> 8) & ~0x0E & 0xFF:
            return f"array flags {h.flags:#x}"
        if h.dims is None:
            return "dimensions of another type or size"
        if min(h.dims) < 0:
            return f"negative dimensions {h.dims}"
        if h.name_type != 1:
            return "a name of another type"
        count = int(np.prod(h.dims, dtype=np.int64))
        if h.cls in _MX_NUMERIC or h.cls == 4:
            rtyp, rn, _, off = _element(buf, h.data, e)
            sizes = _MI_CHAR if h.cls == 4 else {k: np.dtype(v).itemsize for k, v in _MI.items()}
            if rtyp not in sizes:
                return f"data of type {rtyp} for array class {h.cls}"
            if sizes[rtyp] and rn != count * sizes[rtyp]:
                return f"{rn} bytes of data for dimensions {h.dims}"
            if h.flags & 0x800 and whole:
                ityp, inn, _, _ = _element(buf, off, e)
                if ityp not in sizes or (sizes[ityp] and inn != count * sizes[ityp]):
                    return "a complex array without its imaginary part"
        elif h.cls in (1, 2, 3) and whole:
            return _mat5_children_fault(buf, h, count, e, depth)
        elif h.cls == 5:
            return _mat5_sparse_fault(buf, h, e, whole)
    except struct.error:
        return "a header cut short" if whole else None
    return None


def _mat5_sparse_fault(buf: bytes, h: _MatrixHead, e: str, whole: bool) -> str | None:
    """What is wrong with the sparse array (class 5) whose header is ``h``: row indices ``ir`` and column
    starts ``jc`` (int32, ``jc`` one more than the columns, from 0 up to the entries), the values (and the
    imaginary part) one per row index; the indices checked when ``buf`` holds the element whole."""
    if len(h.dims) != 2:
        return f"a sparse array of dimensions {h.dims}"
    rows, cols = h.dims
    ityp, inn, i0, off = _element(buf, h.data, e)
    jtyp, jn, j0, off = _element(buf, off, e)
    if ityp != 5 or inn % 4 or jtyp != 5 or jn != 4 * (cols + 1):
        return f"sparse indices of types {ityp}/{jtyp} and {inn}/{jn} bytes for dimensions {h.dims}"
    nnz = inn // 4
    sizes = {k: np.dtype(v).itemsize for k, v in _MI.items()}
    for part in ("values", "imaginary values") if h.flags & 0x800 else ("values",):
        vtyp, vn, _, off = _element(buf, off, e)
        if vtyp not in sizes or vn != nnz * sizes[vtyp]:
            return f"sparse {part} of type {vtyp} and {vn} bytes for {nnz} entries"
    if whole:
        ir = np.frombuffer(buf, e + "i4", nnz, i0)
        jc = np.frombuffer(buf, e + "i4", cols + 1, j0)
        if jc[0] != 0 or jc[-1] > nnz or np.any(np.diff(jc) < 0) or (nnz and (ir.min() < 0 or ir.max() >= rows)):
            return "sparse indices out of order or out of range"
    return None


def _mat5_children_fault(buf: bytes, h: _MatrixHead, count: int, e: str, depth: int) -> str | None:
    """What is wrong with the elements of the cell (class 1), struct (2) or object (3) array whose header is
    ``h`` in ``buf`` (the whole element): each must be a miMATRIX element inside its parent, itself sound."""
    if depth >= _MAT5_DEPTH:
        return f"cell or struct arrays nested more than {_MAT5_DEPTH} deep"
    end = 8 + struct.unpack_from(e + "I", buf, 4)[0]
    off, n_children = h.data, count
    if h.cls != 1:
        if h.cls == 3:  # the class name before the fields
            off = _element(buf, off, e)[3]
        ltyp, ln, d, off = _element(buf, off, e)
        if ltyp != 5 or ln != 4:
            return "struct field-name length of another type or size"
        width = struct.unpack_from(e + "i", buf, d)[0]
        ntyp, nn, _, off = _element(buf, off, e)
        if ntyp != 1 or width < 0 or (width == 0 and nn) or (width and nn % width):
            return f"struct field names of {nn} bytes for names of {width}"
        n_children = count * (nn // width) if width else 0
    for k in range(n_children):
        if off + 8 > end:
            return f"{n_children - k} of {n_children} elements missing"
        typ, n = struct.unpack_from(e + "II", buf, off)
        if typ != _MI_MATRIX or off + 8 + n > end:
            return f"element {k} of {n_children} is not an array inside its parent"
        why = _mat5_header_fault(buf[off : off + 8 + n], e, True, depth + 1)
        if why:
            return f"element {k}: {why}"
        off += 8 + n
    return None


def _mat5(path: Path) -> _Source | None:
    """The variables of a MATLAB v5/v7 file: numeric matrices of at least :data:`_MAT_STREAM_BYTES` read by rows
    from their column-major data (a compressed one inflated into a scratch file on first use), every other
    variable whole through scipy.io.loadmat; None when the file is not one this reader walks."""
    from optinav.io.readers import Table, _mat_walk

    try:
        size = path.stat().st_size
        fh = open(path, "rb")
    except OSError:
        return None
    items, closers = [], [fh.close]

    def close():
        for c in closers:
            c()

    try:
        e = _mat5_endian(fh.read(128))
        if e is None:
            close()
            return None
        for pos, typ, n, head in _variables(fh, e, size, 1 << 13):
            if typ >> 16 or typ not in (_MI_MATRIX, _MI_COMPRESSED) or pos + 8 + n > size:
                close()
                return None  # not a variable this reader walks: load_table reads (or refuses) the file
            found = _numeric_matrix(head, e) if len(head) >= 8 else None
            if found is not None and found[2] in _MI and found[3] >= _MAT_STREAM_BYTES and sample_axis(found[0]):
                items.append(_mat5_item(path, fh, pos, typ == _MI_COMPRESSED, found, e, closers))
                continue
            h = _matrix_head(head, e) if len(head) >= 8 else None
            if h is None or not h.name:
                close()
                return None
            items.append(_Item(h.name, None, 0, None, (lambda name=h.name: _loadmat(path, name)), add=_mat_walk))
    except (OSError, struct.error, zlib.error, UnicodeDecodeError):
        close()
        return None
    return _Source(Table(path=path, kind="mat", data={}), items, close)


def _loadmat(path: Path, name: str):
    import warnings

    import scipy.io

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scipy.io.loadmat(path, variable_names=[name], simplify_cells=True)[name]


def _mat5_item(path: Path, fh, pos: int, compressed: bool, found, e: str, closers: list) -> _Item:
    """A numeric matrix read by rows: the column-major data of MATLAB (a vector contiguous)."""
    import tempfile

    dims, name, typ, nbytes, d = found
    dtype = np.dtype(e + _MI[typ])
    if int(np.prod(dims, dtype=np.int64)) * dtype.itemsize != nbytes:
        raise struct.error("the data do not fill the dimensions")

    def opener():
        if not compressed:
            return open(path, "rb")
        # inflate the element once into a scratch file (bounded output per call: data that compress well)
        scratch = tempfile.TemporaryFile()
        z = zlib.decompressobj()
        fh.seek(pos + 4)
        left = struct.unpack(e + "I", fh.read(4))[0]
        while left:
            chunk = fh.read(min(1 << 20, left))
            if not chunk:
                raise OptinavError(f"{path.name}: {name!r} ends early", "check that the file is complete")
            left -= len(chunk)
            while chunk:
                scratch.write(z.decompress(chunk, 1 << 24))
                chunk = z.unconsumed_tail
        scratch.write(z.flush())
        scratch.seek(0)
        return scratch

    data0 = d if compressed else pos + d
    rows = _Rows(opener, data0, dims, True, dtype, True)
    closers.append(rows.close)
    return _Item(name, sample_axis(dims)[1], nbytes, rows.read, lambda: _loadmat(path, name))
