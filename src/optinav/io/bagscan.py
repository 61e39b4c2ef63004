"""The raw bytes of one topic's messages read from the bag's storage in blocks, beside ``rosbags``' iteration.

``rosbags`` yields one Python tuple per message; at 1 kHz over an hour (3.6 M messages) that iteration, not the
decoding, is what reading a bag costs. These scanners read the storage by its published layout and hand
:mod:`optinav.io.rosbag` blocks ``(buf, off, size, logt)`` — message ``i`` is ``buf[off[i]:off[i] + size[i]]``,
logged at ``logt[i]`` ns — one per chunk (or per ``_LEAVES`` leaf pages), the records walked by the compiled
kernels of :mod:`optinav.io._bagkernels` over the file mapped read-only (a block's arrays are reused for the
next one). Each chunk's bytes are first read in order (:func:`optinav.io._bagkernels.touch`: the pages fault
in at the memory's bandwidth) and unmapped once decoded, so the resident set holds one chunk of the file:

- MCAP (mcap.dev/spec, major version 0): records ``opcode u8, length u64, content``; Channel ``0x04``
  (id u16, schema id u16, topic, message encoding, …), Message ``0x05`` (channel id u16, sequence u32, log time
  u64, publish time u64, data), Chunk ``0x06`` (start, end, uncompressed size u64, CRC-32 u32, compression,
  records u64 + bytes; none, lz4 frame or zstd), Data End ``0x0F``; the summary's Chunk Index ``0x08`` records
  (after the Footer ``0x02``'s summary offset) say which chunks hold the topic, and only those are read.
- ROS 1 bag 2.0 (wiki.ros.org/Bags/Format/2.0): records ``header_len u32, fields (len u32, name=value)…,
  data_len u32, data``; op ``0x03`` bag header (``index_pos``), ``0x05`` chunk (``compression`` none/bz2/lz4,
  ``size``), ``0x07`` connection (``conn``, ``topic``; data: ``type``, ``md5sum``, …), ``0x06`` chunk info
  (``chunk_pos``; data: conn u32, count u32 pairs), ``0x04`` index data after each chunk (``conn``,
  ``count``), ``0x02`` message data (``conn``, ``time`` = sec u32, nsec u32). Only the chunks that hold the
  topic are read, after their chunk infos are checked against the index data records. An uncompressed bag is
  decoded whole by :func:`ros1_decode` (each chunk walked and gathered in one compiled call, two threads).

Chunks compressed with a slow codec (bz2, zstd) are inflated by helper threads ahead of the walk (:func:`_ahead`).

- ROS 2 sqlite3 (sqlite.org/fileformat2.html): the table b-tree of rosbag2's ``messages`` (id INTEGER PRIMARY
  KEY, topic_id, timestamp, data), found through the standard library's ``sqlite3`` opened read-only; its interior
  pages parsed with numpy, its leaf cells walked one by one (payload size, rowid, record header, topic id,
  timestamp). SQLite's own row-by-row fetch costs more than the whole scan (measured: 15.7 s for 3.6 M rows
  with ``fetchmany``, against pyarrow's 0.5 s for the same table in Parquet).

A ROS 2 bag recorded with ``--compression-mode message`` (each message one Zstandard frame) is read through the
same scanners, each block's frames inflated at once (:func:`_inflated`).

``rosbags`` stays the reader of record: :func:`blocks` returns None — or a scanner raises :class:`NotFast` part
way — for anything else (ROS 2 bags compressed file by file, unchunked MCAP, unknown chunk compression, a sqlite3
file with a write-ahead log or overflow pages, a layout that does not parse, a big-endian host); the caller then
reads the topic through ``rosbags``, which also reports damage.
"""

from __future__ import annotations

import functools
import itertools
import os
import struct
import sys
import zlib
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["NotFast", "blocks", "ros1_index", "sqlite_blocks", "sqlite_topics", "windows"]

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")


class NotFast(Exception):
    """The storage holds something these scanners do not read: read the topic through rosbags instead."""


class Damaged(OptinavError):
    """The storage contradicts itself where rosbags' reader would give a wrong answer: refused, not handed on."""


def blocks(reader, path: Path, topic: str):
    """An iterator over the blocks of ``topic`` (see the module docs), or None when the bag is not one these
    scanners read. ``reader``: the open ``rosbags`` AnyReader of ``path`` (or a stand-in with ``readers`` and
    ``is2``)."""
    readers = getattr(reader, "readers", None)
    if not readers or len(readers) != 1 or sys.byteorder != "little":  # the walkers load little-endian words
        return None
    if not getattr(reader, "is2", True):
        return _ros1(Path(path), topic, getattr(reader, "index", None)) if Path(path).is_file() else None
    sub = readers[0]
    try:
        mode = sub.compression_mode
        if mode and (mode != "message" or sub.compression_format != "zstd" or _libzstd() is None):
            return None  # file-compressed, or no libzstd to inflate messages in a compiled loop: rosbags'
    except Exception:  # noqa: BLE001 - an attribute rosbags may rename: fall back to its iteration
        return None
    storage = getattr(sub, "storage", None)
    files = [getattr(s, "path", None) for s in getattr(storage, "storages", [storage])]
    if not files or not all(isinstance(f, Path) and f.is_file() for f in files):
        return None
    suffixes = {f.suffix for f in files}
    if suffixes == {".mcap"}:
        raw = itertools.chain.from_iterable(_mcap(f, topic) for f in files)
    elif suffixes == {".db3"}:
        raw = itertools.chain.from_iterable(sqlite_blocks(f, topic) for f in files)
    else:
        return None
    return _inflated(raw) if mode else raw


# --- blocks from the compiled walkers -------------------------------------------------------------------------


class _Rows:
    """Reused (offset, size, log time) arrays a walker fills for one chunk or block of pages: a block handed on is
    valid until the next is asked for (the decoder copies what it keeps)."""

    def __init__(self):
        self.off = self.size = self.logt = np.empty(0, dtype=np.int64)
        self.chans = np.zeros(1 << 16, dtype=np.bool_)  # MCAP: the topic's channel ids

    def room(self, n: int) -> None:
        if self.off.size < n:
            n = max(n, 2 * self.off.size)
            self.off, self.size, self.logt = (np.empty(n, dtype=np.int64) for _ in range(3))

    def block(self, buf, k: int):
        if k == 0:
            return None
        return buf, self.off[:k], self.size[:k], self.logt[:k]


class _Unmap:
    """Unmaps the decoded ranges of a map (:func:`_release`) a few MB at a time: one call per chunk costs more
    than the unmapping itself."""

    def __init__(self, mm, span: int = 8 << 20):
        self.mm, self.span, self.lo, self.hi = mm, span, None, 0

    def add(self, start: int, stop: int) -> None:
        self.lo = start if self.lo is None else min(self.lo, start)
        self.hi = max(self.hi, stop)
        if self.hi - self.lo >= self.span:
            self.flush()

    def flush(self) -> None:
        if self.lo is not None:
            _release(self.mm, self.lo, self.hi)
        self.lo, self.hi = None, 0


def _walked(status: int, where: str) -> None:
    from optinav.io import _bagkernels as kern

    if status != kern.OK:
        why = {kern.TRUNCATED: "truncated", kern.MALFORMED: "malformed", kern.FULL: "too many"}.get(status, "odd")
        raise NotFast(f"a {why} record in {where}")


def _decompress(kind: str, data: bytes) -> bytes:
    if kind in ("", "none"):
        return data
    if kind == "bz2":
        import bz2

        return bz2.decompress(data)
    if kind == "lz4":
        from lz4.frame import decompress  # rosbags' own dependency

        return decompress(data)
    if kind == "zstd":
        return zstd_module().decompress(data)
    raise NotFast(f"chunk compression {kind!r}")


def _inflated(raw):
    """The blocks of a bag recorded with ``--compression-mode message`` (each message one Zstandard frame),
    inflated into one buffer per block at the content sizes the frame headers state, by libzstd in a compiled loop
    (:func:`optinav.io._bagkernels.zstd_inflate`, a decompression context of its own per read; 0.25 µs a
    message, where a Python decompressor per message costs 12 µs: its context). A frame without a content size
    raises :class:`NotFast`, one that fails or inflates to another size ValueError — rosbags then reads the topic,
    and names the damage."""
    from optinav.io import _bagkernels as kern

    call, create, free = _libzstd()
    ctx = create()
    if not ctx:
        raise NotFast("libzstd gave no decompression context")
    try:
        for buf, off, size, logt in raw:
            u8 = np.frombuffer(buf, dtype=np.uint8)
            content = np.empty(size.size, dtype=np.int64)
            bad = kern.zstd_sizes(u8, off, size, content)
            if bad >= 0:
                raise NotFast(f"message {bad} of a block is not a Zstandard frame with its content size")
            new = np.zeros_like(content)
            np.cumsum(content[:-1], out=new[1:])
            out = np.empty(int(content.sum()), dtype=np.uint8)
            bad = kern.zstd_inflate(call, ctx, u8, off, size, out, new, content)
            if bad >= 0:
                raise ValueError(f"message {bad} of a block does not inflate to the size its frame states")
            yield out, new, content, logt.copy()
    finally:
        free(ctx)


@functools.cache
def _libzstd():
    """(``ZSTD_decompressDCtx`` as a ctypes function of five ``size_t``, ``ZSTD_createDCtx``, ``ZSTD_freeDCtx``)
    of the system's libzstd, or None without one."""
    import ctypes
    import ctypes.util

    try:
        lib = ctypes.CDLL(ctypes.util.find_library("zstd") or "libzstd.so.1")
        create, free, decompress = lib.ZSTD_createDCtx, lib.ZSTD_freeDCtx, lib.ZSTD_decompressDCtx
    except (OSError, AttributeError):
        return None
    create.restype = ctypes.c_void_p
    free.argtypes = [ctypes.c_void_p]
    sz = ctypes.c_size_t  # pointers passed as size_t: the same register on the platforms numba supports
    return ctypes.CFUNCTYPE(sz, sz, sz, sz, sz, sz)(ctypes.cast(decompress, ctypes.c_void_p).value), create, free


def crc32(buf) -> int:
    """The CRC-32 (ISO-HDLC, zlib's) of the bytes ``buf`` (a contiguous buffer: bytes, a numpy uint8 array, a map's
    slice): by libdeflate's ``libdeflate_crc32`` when the system has it (carry-less multiplication: 13-14 GB/s
    on this machine, where zlib 1.2.13's table method gives 4.2 GB/s — an mcap bag's chunk CRCs cost a third of
    its read), else by :func:`zlib.crc32`. Both release the GIL."""
    fn = _libdeflate_crc32()
    if fn is None:
        return zlib.crc32(buf)
    a = np.frombuffer(buf, dtype=np.uint8)
    return fn(0, a.ctypes.data, a.size) if a.size else 0


@functools.cache
def _libdeflate_crc32():
    """``libdeflate_crc32(crc u32, buffer, size) -> u32`` of the system's libdeflate as a ctypes function (ctypes
    releases the GIL for the call), or None without one."""
    import ctypes
    import ctypes.util

    try:
        fn = ctypes.CDLL(ctypes.util.find_library("deflate") or "libdeflate.so.0").libdeflate_crc32
    except (OSError, AttributeError):
        return None
    fn.restype, fn.argtypes = ctypes.c_uint32, [ctypes.c_uint32, ctypes.c_void_p, ctypes.c_size_t]
    return fn


def zstd_module():
    """The standard library's zstd (Python ≥ 3.14) or its backport (rosbags' own dependency before)."""
    try:
        from compression import zstd  # Python >= 3.14
    except ImportError:
        from backports import zstd
    return zstd


# --- MCAP -----------------------------------------------------------------------------------------------------


def _mcap_channel(buf: bytes, pos: int, topic: str, chans: set) -> None:
    """A Channel record's content at ``pos``: its id joins ``chans`` when it carries ``topic`` in CDR."""
    cid = _U16.unpack_from(buf, pos)[0]
    p = pos + 4
    n = _U32.unpack_from(buf, p)[0]
    name = bytes(buf[p + 4 : p + 4 + n]).decode("utf-8", "replace")
    p += 4 + n
    n = _U32.unpack_from(buf, p)[0]
    enc = bytes(buf[p + 4 : p + 4 + n]).decode("utf-8", "replace")
    if name == topic and enc == "cdr":
        chans.add(cid)


def _mcap_index(fh, topic: str):
    """(ids of the CDR channels of ``topic``, offsets of the chunks that hold one of them, for each such chunk the
    offsets of its Message Index records of those channels) from the summary section (Channel and Chunk Index
    ``0x08`` records: start, end, chunk offset u64, length u64, message index offsets map<u16, u64>, …); None
    without a summary or without the topic's channels in it."""
    fh.seek(0, 2)
    size = fh.tell()
    if size < 2 * len(_MCAP_MAGIC) + 29:
        return None
    fh.seek(size - len(_MCAP_MAGIC) - 29)
    tail = fh.read(29 + len(_MCAP_MAGIC))
    if tail[-8:] != _MCAP_MAGIC or tail[0] != 0x02:
        return None
    start, offsets_start = _U64.unpack_from(tail, 9)[0], _U64.unpack_from(tail, 17)[0]
    end = offsets_start or size - len(_MCAP_MAGIC) - 29
    if not len(_MCAP_MAGIC) < start < end:
        return None
    fh.seek(start)
    buf = fh.read(end - start)
    chans, chunks = set(), []
    pos = 0
    while pos + 9 <= len(buf):
        op, n = buf[pos], _U64.unpack_from(buf, pos + 1)[0]
        if op == 0x04:
            _mcap_channel(buf, pos + 9, topic, chans)
        elif op == 0x08:
            m = _U32.unpack_from(buf, pos + 41)[0]
            held = dict(struct.iter_unpack("<HQ", buf[pos + 45 : pos + 45 + m]))
            chunks.append((_U64.unpack_from(buf, pos + 25)[0], held, buf[pos + 9 : pos + 25]))
        pos += 9 + n
    if not chans:
        return None
    mine = sorted((off, [held[c] for c in chans if c in held], t) for off, held, t in chunks if held.keys() & chans)
    for off, _, times in mine:
        _chunk_index_agrees(fh, off, times)
    return chans, [off for off, _, _ in mine], [m for _, m, _ in mine]


def _chunk_index_agrees(fh, off: int, times: bytes) -> None:
    """Refuse a summary whose Chunk Index gives a chunk other message start/end times than the Chunk record's own
    header: the file contradicts itself, and rosbags' reader, which orders the chunks by the index's times, then
    leaves messages out without a word (found by a one-byte damage fuzz: 4048 of 7000 messages)."""
    fh.seek(off)
    head = fh.read(25)
    if len(head) == 25 and head[0] == 0x06 and head[9:25] != times:
        (t0, t1), (i0, i1) = struct.unpack("<QQ", head[9:25]), struct.unpack("<QQ", times)
        raise Damaged(
            f"{Path(fh.name).name} is not a readable ROS bag: its summary gives the chunk at byte {off} the message "
            f"times [{i0}, {i1}] ns, the chunk itself [{t0}, {t1}] ns",
            "rebuild the summary from the chunks (mcap recover FILE -o FIXED.mcap)",
        )


def _mcap(path: Path, topic: str):
    """The blocks of ``topic``: the chunks the summary's chunk index lists for its channels, or, without a
    summary, every chunk of the data section in turn; read from the file mapped read-only (uncompressed chunks in
    place, each unmapped again once decoded)."""
    with open(path, "rb") as fh:
        if fh.read(8) != _MCAP_MAGIC:
            raise NotFast("no MCAP magic")
        idx = _mcap_index(fh, topic)
    mm, u8 = _map(path)
    rows = _Rows()
    if idx is not None:
        chans, offsets, _ = idx
        spans = []
        for off in offsets:
            if off + 9 > u8.size or u8[off] != 0x06:
                raise NotFast("no chunk at a chunk index's offset")
            n = _U64.unpack_from(mm, off + 1)[0]
            if off + 9 + n > u8.size:
                raise NotFast("truncated chunk")
            spans.append((off, off + 9 + n))
        done = _Unmap(mm)
        heads = ((o, e, _mcap_head(mm, o + 9, e - o - 9)) for o, e in spans)
        for (off, end, item), raw in _ahead(heads, _mcap_work, lambda h: h[2][0] in _SLOW_CODECS):
            yield from _mcap_chunk(mm, u8, item, raw, topic, chans, rows)
            done.add(off, end)  # decoded by now
        done.flush()
        return
    chans: set = set()
    pos, done = 8, _Unmap(mm)
    while True:
        if pos + 9 > u8.size:
            raise NotFast("no Data End record")
        op, n = u8[pos], _U64.unpack_from(mm, pos + 1)[0]
        if op in (0x0F, 0x02):  # Data End, or a Footer straight after the data
            done.flush()
            return
        if op == 0x05:
            raise NotFast("messages outside chunks")
        if pos + 9 + n > u8.size:
            raise NotFast("truncated record")
        if op == 0x04:
            _mcap_channel(mm, pos + 9, topic, chans)
        elif op == 0x06:
            item = _mcap_head(mm, pos + 9, n)
            yield from _mcap_chunk(mm, u8, item, _mcap_work((None, None, item)), topic, chans, rows)
            done.add(pos, pos + 9 + n)  # decoded by now
        pos += 9 + n


def mcap_file(reader) -> Path | None:
    """The one MCAP file of an open ``rosbags`` reader whose storage is not compressed as a whole or by message,
    else None."""
    readers = getattr(reader, "readers", None)
    if not readers or len(readers) != 1 or not getattr(reader, "is2", False):
        return None
    try:
        if readers[0].compression_mode:
            return None
        storage = readers[0].storage
        files = [getattr(st, "path", None) for st in getattr(storage, "storages", [storage])]
    except Exception:  # noqa: BLE001 - attributes rosbags may rename: the blocks decide
        return None
    if len(files) != 1 or not isinstance(files[0], Path) or files[0].suffix != ".mcap" or not files[0].is_file():
        return None
    return files[0]


def mcap_decode(path: Path, topic: str, layout, out: tuple) -> bool:
    """Decode every message of ``topic`` in the MCAP file ``path`` into ``out`` = (stamps s, log times ns, triads
    a, triads b; as many rows as the topic has messages) by :func:`optinav.io._bagkernels.mcap_decode`: the
    chunks the summary's chunk index lists for the topic, each chunk's rows from its Message Index records (one
    per channel: 16 bytes a message), in batches (:func:`_rounds`: two threads). ``layout``: see
    :func:`ros1_decode`. A chunk's CRC-32, when it has one, is checked before it is walked. False — nothing to
    trust in ``out`` — for a file without a summary, compressed chunks, a CRC that does not match, counts other than
    the message indexes', another layout, or anything that does not parse: the blocks (:func:`blocks`) read those."""
    from optinav.io import _bagkernels as kern

    stamp, logt, va, vb = out
    # the few bytes of each chunk's header and message indexes are read with pread, not from the map: a kernel
    # that caches the file in large folios maps a whole folio (up to the chunk) for one byte touched, and one
    # byte per chunk then put the whole file in the resident set before the first round was decoded
    with open(path, "rb") as fh:
        if fh.read(8) != _MCAP_MAGIC:
            return False
        idx = _mcap_index(fh, topic)
        if idx is None or not idx[1] or not stamp.size:
            return False
        pos = np.array(idx[1], dtype=np.int64)
        expect = np.zeros(pos.size, dtype=np.int64)
        for i, offs in enumerate(idx[2]):  # Message Index: opcode 0x07, length u64, channel u16, records u32 + 16 each
            for m in offs:
                head = os.pread(fh.fileno(), 15, m)
                if len(head) != 15 or head[0] != 0x07:
                    return False
                n = _U32.unpack_from(head, 11)[0]
                if n % 16:
                    return False
                expect[i] += n // 16
        if int(expect.sum()) != stamp.size or np.any(np.diff(pos) <= 0):
            return False
        # chunks that carry a CRC-32 (the mcap library's default; rosbag2 turns it off): checked (crc32), which
        # releases the GIL, in the thread that then walks them
        crcs = _mcap_crcs(fh.fileno(), pos)
    if crcs is None:
        return False
    chans = np.zeros(1 << 16, dtype=np.bool_)
    chans[list(idx[0])] = True
    mm, u8 = _map(path)
    row0 = np.zeros(pos.size + 1, dtype=np.int64)
    np.cumsum(expect, out=row0[1:])
    checked = bool(np.any(crcs[:, 2]))
    scratch = [tuple(np.empty(int(expect.max()) + 1, dtype=np.int64) for _ in range(3)) for _ in range(2)]
    # the layout from the first chunk's first message (the chunk walked, nothing gathered into no rows: ROOM)
    no = np.zeros(7, dtype=np.int64)
    if checked and not _crcs_match(u8, crcs[:1]):
        return False
    status, *_ = kern.mcap_decode(u8, pos[:1], chans, *scratch[0], no, stamp[:0], va[:0], vb[:0], logt[:0], 0, checked)
    if status != kern.ROOM:
        return False
    off, size, _ = scratch[0]
    lay = layout(bytes(u8[off[0] : off[0] + size[0]]))
    if lay is None:
        return False

    def run(a: int, b: int, buf: tuple, _) -> bool:
        # rows row0[a]:row0[b], no more: the kernel stops with ROOM past them; a chunk with a CRC is checked
        # right before it is walked (its bytes then in cache)
        for c, d in ((i, i + 1) for i in range(a, b)) if checked else ((a, b),):
            if checked and not _crcs_match(u8, crcs[c:d]):
                return False
            lim = slice(0, row0[d])
            got = kern.mcap_decode(
                u8, pos[c:d], chans, *buf, lay, stamp[lim], va[lim], vb[lim], logt[lim], row0[c], checked
            )
            if got[0] != kern.OK or got[2] != row0[d]:
                return False
        return True

    return _rounds(mm, _cuts(pos, np.append(pos[1:], u8.size)), run, scratch)


def _mcap_crcs(fd: int, pos: np.ndarray) -> np.ndarray | None:
    """(records start, end, CRC-32 or 0) of the uncompressed Chunk records at ``pos`` of the file ``fd``
    (:func:`_mcap_head` on each header, read with pread); None when one is compressed or does not parse (the
    kernel checks each header again)."""
    out = np.zeros((pos.size, 3), dtype=np.int64)
    for i, p in enumerate(pos.tolist()):
        head = os.pread(fd, 9 + 80, p)  # opcode, length, the header up to a compression name of 40 bytes
        if len(head) < 9 or head[0] != 0x06:
            return None
        try:
            kind, data, _, crc, _ = _mcap_head(head, 9, _U64.unpack_from(head, 1)[0])
        except (NotFast, struct.error):
            return None
        if kind not in ("", "none"):
            return None
        out[i] = data[0] + p, data[1] + p, crc
    return out


def _crcs_match(u8: np.ndarray, rows: np.ndarray) -> bool:
    """Whether each chunk's records ``u8[start:end]`` (rows: start, end, CRC; 0: none) have their CRC-32."""
    return all(not c or crc32(u8[a:b]) == c for a, b, c in rows.tolist())


def _mcap_head(mm, start: int, n: int) -> tuple:
    """The Chunk record whose content is ``mm[start:start + n]`` (the file map, or a header read on its own):
    (compression, its records' bytes (a copy when compressed) or their span in the file, uncompressed size, CRC,
    message span)."""
    if n < 40:
        raise NotFast("truncated chunk")
    usize, crc = _U64.unpack_from(mm, start + 16)[0], _U32.unpack_from(mm, start + 24)[0]
    clen = _U32.unpack_from(mm, start + 28)[0]
    if 32 + clen + 8 > n:
        raise NotFast("truncated chunk")
    kind = bytes(mm[start + 32 : start + 32 + clen]).decode("ascii", "replace")
    p = start + 32 + clen
    rlen = _U64.unpack_from(mm, p)[0]
    if p + 8 + rlen > start + n:
        raise NotFast("chunk records beyond the chunk")
    # a log time outside the chunk's own message span is damage (rosbags then reads the bag, as it would)
    top = np.iinfo(np.int64).max
    span = tuple(min(_U64.unpack_from(mm, start + k)[0], top) for k in (0, 8))  # (0, 0): span not set
    plain = kind in ("", "none")
    return kind, (p + 8, p + 8 + rlen) if plain else mm[p + 8 : p + 8 + rlen], usize, crc, span


def _mcap_work(entry) -> bytes | None:
    """A compressed chunk's records decompressed and checked (size, CRC); None for an uncompressed chunk (checked
    where it lies, in the file)."""
    kind, data, usize, crc, _ = entry[2]
    if kind in ("", "none"):
        return None
    buf = _decompress(kind, data)
    if len(buf) != usize or (crc and crc32(buf) != crc):
        raise NotFast("chunk size or CRC mismatch")
    return buf


def _mcap_chunk(mm, u8: np.ndarray, item: tuple, buf: bytes | None, topic: str, chans: set, rows: _Rows):
    """The block (if any) of a Chunk record (:func:`_mcap_head`'s ``item``; ``buf``: its records decompressed,
    or None when they lie uncompressed in the file)."""
    kind, data, usize, crc, span = item
    if buf is None:
        raw = u8[data[0] : data[1]]
        if raw.size != usize or (crc and crc32(raw) != crc):
            raise NotFast("chunk size or CRC mismatch")
        out = _mcap_records(mm, u8, data[0], data[1], topic, chans, rows, False, span)
    else:
        b8 = np.frombuffer(buf, dtype=np.uint8)  # just written: in cache
        out = _mcap_records(buf, b8, 0, b8.size, topic, chans, rows, True, span)
    if out is not None:
        yield out


def _mcap_records(buf, u8: np.ndarray, pos: int, end: int, topic: str, chans: set, rows: _Rows, touched, span):
    """The block of the chunk records ``u8[pos:end]`` (``buf``: the same bytes for :mod:`struct`), walked by
    :func:`optinav.io._bagkernels.mcap_walk`; a Channel record in the chunk is read here and the walk goes on.
    ``span``: the chunk's (start, end) log times."""
    from optinav.io import _bagkernels as kern

    rows.room((end - pos) // 31 + 1)  # a Message record holds at least 31 bytes
    mask = rows.chans
    mask[list(chans)] = True
    if not touched:
        kern.touch(u8, pos, end)
    k = 0
    while True:
        status, pos, k = kern.mcap_walk(u8, pos, end, mask, rows.off, rows.size, rows.logt, k, *span)
        if status != kern.CHANNEL:
            break
        _mcap_channel(buf, pos + 9, topic, chans)
        mask[list(chans)] = True
        pos += 9 + _U64.unpack_from(buf, pos + 1)[0]
    if status == kern.SPAN:
        raise NotFast("a message's log time outside its chunk's span")
    _walked(status, "an MCAP chunk")
    return rows.block(u8, k)


# --- ROS 1 ----------------------------------------------------------------------------------------------------


def _fields(buf: bytes, start: int, end: int) -> dict:
    """A ROS 1 record header ``buf[start:end]``: field name → (start, stop) of its value in ``buf``."""
    out = {}
    p = start
    while p < end:
        if p + 4 > end:
            raise NotFast("truncated header field")
        q = p + 4 + _U32.unpack_from(buf, p)[0]
        eq = buf.find(b"=", p + 4, q)
        if q > end or eq < 0:
            raise NotFast("malformed header field")
        out[bytes(buf[p + 4 : eq])] = (eq + 1, q)
        p = q
    return out


def _record(buf: bytes, pos: int, end: int) -> tuple[dict, int, int]:
    """(header fields, data start, data stop) of the ROS 1 record at ``pos``, whole before ``end``."""
    f, ds, de = record_head(buf, pos, end)
    if de > end:
        raise NotFast("truncated record")
    return f, ds, de


def record_head(buf: bytes, pos: int, end: int) -> tuple[dict, int, int]:
    """(header fields, data start, data stop as the record declares it — maybe beyond ``end``: a file cut short)
    of the ROS 1 record at ``pos``; raises :class:`NotFast` when its header is not whole before ``end``."""
    if pos + 4 > end:
        raise NotFast("truncated record")
    he = pos + 4 + _U32.unpack_from(buf, pos)[0]
    if he + 4 > end:
        raise NotFast("truncated record")
    return _fields(buf, pos + 4, he), he + 4, he + 4 + _U32.unpack_from(buf, he)[0]


def _op(buf: bytes, f: dict) -> int:
    a, b = f.get(b"op", (0, 0))
    if b - a != 1:
        raise NotFast("record without op")
    return buf[a]


def ros1_index(path: Path) -> dict:
    """The index of the ROS 1 bag ``path`` from its connection and chunk info records (after ``index_pos``):
    ``{"first": offset of the first record after the bag header, "index_pos": …, "conns": {conn id: (topic,
    type, md5sum)}, "callers": {conn id: the publishing node (callerid, "" when not recorded)}, "counts": {conn id:
    messages}, "chunks": [(chunk offset, {conn id: messages in it}), …]}``
    (chunks in file order). Raises
    :class:`NotFast` when the bag is not one this reads."""
    with open(path, "rb") as fh:
        data = fh.read(len(_ROS1_MAGIC) + 4096 + 64)
        if not data.startswith(_ROS1_MAGIC):
            raise NotFast("not a ROS 1 bag 2.0")
        f, _, first = _record(data, len(_ROS1_MAGIC), len(data))
        if _op(data, f) != 0x03 or b"index_pos" not in f:
            raise NotFast("no bag header")
        index_pos = _U64.unpack_from(data, f[b"index_pos"][0])[0]
        fh.seek(0, 2)
        if not first <= index_pos < fh.tell():
            raise NotFast("unindexed bag")
        fh.seek(index_pos)
        tail = fh.read()
    conns, callers, counts, chunks = {}, {}, {}, []
    pos = 0
    while pos < len(tail):
        f, ds, de = _record(tail, pos, len(tail))
        op = _op(tail, f)
        if op == 0x07:
            d = _fields(tail, ds, de)
            conn = _U32.unpack_from(tail, f[b"conn"][0])[0]
            conns[conn] = tuple(
                bytes(tail[slice(*g[k])]).decode("utf-8", "replace")
                for g, k in ((f, b"topic"), (d, b"type"), (d, b"md5sum"))
            )
            callers[conn] = bytes(tail[slice(*d[b"callerid"])]).decode("utf-8", "replace") if b"callerid" in d else ""
        elif op == 0x06:
            held: dict = {}
            for conn, n in struct.iter_unpack("<II", tail[ds:de]):
                counts[conn] = counts.get(conn, 0) + n
                held[conn] = held.get(conn, 0) + n
            chunks.append((_U64.unpack_from(tail, f[b"chunk_pos"][0])[0], held))
        pos = de
    if not conns:
        raise NotFast("no connection records")
    chunks.sort(key=lambda c: c[0])
    return {
        "first": first,
        "index_pos": index_pos,
        "conns": conns,
        "callers": callers,
        "counts": counts,
        "chunks": chunks,
    }


def _ros1_selected(idx: dict, u8: np.ndarray, conns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(offsets, message counts of ``conns``) of the chunks whose chunk info lists one of ``conns``, after checking
    every chunk's count of ``conns`` by its chunk info against its index data records
    (:func:`optinav.io._bagkernels.ros1_tails`): a damaged chunk info (a connection id or count changed) would
    otherwise skip a chunk of the topic and still add up. Raises :class:`NotFast` when they disagree."""
    from optinav.io import _bagkernels as kern

    wanted = set(conns.tolist())
    pos = np.array([p for p, _ in idx["chunks"]], dtype=np.int64)
    info = np.array([sum(held.get(c, 0) for c in wanted) for _, held in idx["chunks"]], dtype=np.int64)
    if not pos.size or np.any(np.diff(pos) <= 0) or pos[0] < idx["first"] or idx["index_pos"] > u8.size:
        raise NotFast("chunk offsets out of order or outside the data")
    status, tails = kern.ros1_tails(u8, pos, np.append(pos[1:], idx["index_pos"]), conns)
    if status != kern.OK or not np.array_equal(tails, info):
        raise NotFast("chunk infos other than the chunks' index records")
    held = info > 0
    return pos[held], info[held]


def _ros1(path: Path, topic: str, idx: dict | None = None):
    """The blocks of ``topic``: only the chunks whose chunk info lists one of its connections are read, from the
    file mapped read-only (uncompressed chunks are walked in place, not copied, and unmapped once decoded).
    ``idx``: the bag's :func:`ros1_index`, if read already."""
    idx = ros1_index(path) if idx is None else idx
    conns = np.array(sorted(c for c, v in idx["conns"].items() if v[0] == topic), dtype=np.int64)
    mm, u8 = _map(path)
    rows, done = _Rows(), _Unmap(mm)
    selected = _ros1_selected(idx, u8, conns)[0].tolist()

    def chunks():
        """(offset, end, (compression, bytes, size) of a compressed chunk or None, data span) of each chunk."""
        for pos in selected:
            if not idx["first"] <= pos < idx["index_pos"]:
                raise NotFast("chunk offset outside the data")
            f, ds, de = _record(mm, pos, idx["index_pos"])
            if _op(mm, f) != 0x05:
                raise NotFast("no chunk at a chunk info's offset")
            kind = bytes(mm[slice(*f.get(b"compression", (0, 0)))]).decode("ascii", "replace")
            size = _U32.unpack_from(mm, f[b"size"][0])[0] if b"size" in f else None
            if kind in ("", "none"):
                if size is not None and de - ds != size:
                    raise NotFast("chunk size mismatch")
                yield pos, de, None, (ds, de)
            else:
                yield pos, de, (kind, mm[ds:de], size), None

    for (pos, de, _, span), buf in _ahead(
        chunks(), _ros1_inflate, lambda c: c[2] is not None and c[2][0] in _SLOW_CODECS
    ):
        if buf is None:
            out = _ros1_records(u8, *span, conns, rows)
        else:
            out = _ros1_records(np.frombuffer(buf, dtype=np.uint8), 0, len(buf), conns, rows, touched=True)
        if out is not None:
            yield out
        done.add(pos, de)  # decoded by now
    done.flush()


def _ros1_inflate(item) -> bytes | None:
    """The decompressed data of a compressed ROS 1 chunk of :func:`_ros1` (None for a plain one)."""
    if item[2] is None:
        return None
    kind, data, size = item[2]
    buf = _decompress(kind, data)
    if size is not None and len(buf) != size:
        raise NotFast("chunk size mismatch")
    return buf


#: chunk compressions inflated by the helper threads (:func:`_ahead`); lz4 inflates at several GB/s, faster than
#: handing a chunk to another thread and back costs (measured: 1 M Imu messages in lz4 chunks 0.17 s in turn, 0.28 s
#: handed off; bz2 6.1 s -> 3.5 s, zstd 0.50 s -> 0.39 s on two CPUs)
_SLOW_CODECS = ("bz2", "zstd")


def _ahead(items, work, needs):
    """``(item, work(item))`` for each of ``items`` in order; ``work`` (decompression: the codecs release the GIL)
    runs in the helper threads (:func:`_helper`) up to twice their number of items ahead, so that several chunks
    inflate at once while this thread walks and gathers; ``needs(item)`` False: ``work`` runs here when the item
    comes (an uncompressed chunk: nothing to do). Without helper threads: in turn."""
    pool = _helper()
    if pool is None:
        for item in items:
            yield item, work(item)
        return
    from collections import deque

    queue: deque = deque()
    try:
        for item in items:
            queue.append((item, pool.submit(work, item) if needs(item) else None))
            if len(queue) > 2 * _workers():
                first, job = queue.popleft()
                yield first, work(first) if job is None else job.result()
        while queue:
            first, job = queue.popleft()
            yield first, work(first) if job is None else job.result()
    finally:
        for _, job in queue:  # the reader stopped early: drop what has not started
            if job is not None:
                job.cancel()


def _ros1_records(u8: np.ndarray, pos: int, end: int, conns: np.ndarray, rows: _Rows, touched=False):
    """The block of the records ``u8[pos:end]`` (offsets relative to ``u8``), walked by
    :func:`optinav.io._bagkernels.ros1_walk` (``touched``: in cache already)."""
    from optinav.io import _bagkernels as kern

    rows.room((end - pos) // 8 + 1)  # a record holds at least its two length words
    if not touched:
        kern.touch(u8, pos, end)
    status, pos, k = kern.ros1_walk(u8, pos, end, conns, rows.off, rows.size, rows.logt, 0)
    _walked(status, "a ROS 1 chunk")
    return rows.block(u8, k)


#: bytes of chunks (or sqlite3 leaf pages) decoded per batch of :func:`_rounds` (each thread takes the next batch
#: when it is done with one): the map's pages are released after each, so the resident set holds about a batch of
#: the file per thread
_ROUND = 8 << 20


def ros1_decode(path: Path, idx: dict, conns: np.ndarray, layout, out: tuple) -> bool:
    """Decode every message of the connections ``conns`` of the ROS 1 bag ``path`` (its :func:`ros1_index`
    ``idx``) into ``out`` = (stamps s, log times ns, triads a, triads b: arrays of the connections' count of rows,
    in chunk order) by :func:`optinav.io._bagkernels.ros1_decode`: the chunks in batches of about ``_ROUND`` bytes
    taken in turn by this thread and a helper thread when the process may run on two CPUs (:func:`_rounds`; the
    kernels release the GIL), each batch's pages unmapped after it. ``layout(first message bytes)``: the gather layout
    (7 int64, see the kernel) or None. False — nothing to trust in ``out`` — when a chunk is compressed, a chunk's
    count differs from its chunk info, a message has another layout, or the bag does not parse: the caller then
    reads the blocks (:func:`blocks`), which handle all of these."""
    from optinav.io import _bagkernels as kern

    mm, u8 = _map(path)
    try:
        pos, expect = _ros1_selected(idx, u8, conns)
    except NotFast:
        return False
    stamp, logt, va, vb = out
    if not pos.size or int(expect.sum()) != stamp.size or np.any(pos >= idx["index_pos"]):
        return False
    row0 = np.zeros(pos.size, dtype=np.int64)
    np.cumsum(expect[:-1], out=row0[1:])
    end = idx["index_pos"]
    scratch = [tuple(np.empty(int(expect.max()) + 1, dtype=np.int64) for _ in range(3)) for _ in range(2)]
    # the layout from the first message of the first chunk
    status, ds, de = kern.ros1_chunk(u8, pos[0], end)
    if status != kern.OK:
        return False
    off, size, lt = scratch[0]
    status, _, k = kern.ros1_walk(u8, ds, de, conns, off, size, lt, 0)
    lay = layout(bytes(u8[off[0] : off[0] + size[0]])) if status == kern.OK and k else None
    if lay is None:
        return False

    def run(a: int, b: int, buf: tuple, _) -> bool:
        got = kern.ros1_decode(u8, pos[a:b], end, expect[a:b], row0[a:b], conns, *buf, lay, stamp, va, vb, logt)
        return got[0] == kern.OK

    # round boundaries by the chunks' offsets (a chunk and its index records lie between two offsets)
    return _rounds(mm, _cuts(pos, np.append(pos[1:], end)), run, scratch)


def _cuts(pos: np.ndarray, nxt: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Batches of about ``_ROUND`` bytes of the chunks at ``pos`` (increasing; each ending before ``nxt``) for
    :func:`_rounds`: (first chunk, chunk after the last, first byte, byte after the last)."""
    cuts = [0]
    while cuts[-1] < pos.size:
        a = cuts[-1]
        cuts.append(max(int(np.searchsorted(pos, pos[a] + _ROUND, side="left")), a + 1))
    return [(a, b, int(pos[a]), int(nxt[b - 1])) for a, b in zip(cuts[:-1], cuts[1:])]


def _rounds(mm, batches: list, run, scratch: list, claim=None) -> bool:
    """Decode ``batches`` = [(a, b, first byte, byte after the last)] in turn by this thread and, when there is
    one, a helper thread (the other ``scratch``): whichever is free takes the next batch, so a thread slowed by
    other work on the machine decodes fewer and neither waits for the other between batches. ``run(a, b, scratch,
    token)`` decodes units ``a:b`` into their own rows (True when they are done right); ``claim(a, b)``, called by
    the thread that took the batch (the batches are taken in order), returns its token (its first row) or None to
    hand out no more batches (the caller then decodes the rest). Each batch's bytes are unmapped after it."""
    import threading
    from concurrent.futures import wait

    todo, lock, failed = iter(batches), threading.Lock(), []

    def work(buf: tuple) -> None:
        nonlocal todo
        while not failed:
            with lock:
                a, b, lo, hi = next(todo, (0, 0, 0, 0))
            if a == b:
                return
            token = None if claim is None else claim(a, b)
            if claim is not None and token is None:
                with lock:
                    todo = iter(())
                return
            ok = False
            try:
                ok = run(a, b, buf, token)
            finally:  # a batch that fails or raises stops the other thread too
                if not ok:
                    failed.append((a, b))
            if not ok:
                return
            _release(mm, lo, hi)  # decoded by now

    pool = _helper()
    job = pool.submit(work, scratch[1]) if pool is not None and len(batches) > 1 else None
    try:
        work(scratch[0])
    finally:
        # a helper that has not started (its CPU busy with other work) is not waited for; one that has is: never
        # leave it reading a map this returns from
        idle = job is None or job.cancel()
        if not idle:
            wait([job])
    if not idle:
        job.result()  # its exception, if any
    return not failed


def _helper():
    """The readers' helper threads (:func:`optinav.io._pool.helper`): :func:`_rounds` hands batches to one,
    :func:`_ahead` inflates chunks in all; None on one CPU."""
    from optinav.io._pool import helper

    return helper()


def _workers() -> int:
    from optinav.io._pool import WORKERS

    return WORKERS[0]


# --- ROS 2 sqlite3 ----------------------------------------------------------------------------------------------


def _connect(path: Path):
    import sqlite3
    from urllib.parse import quote

    return sqlite3.connect(f"file:{quote(str(path.resolve()))}?mode=ro", uri=True)  # read-only: never written


def sqlite_topics(path: Path) -> list[tuple[str, str, str]]:
    """(name, type, serialization format) of every topic of the rosbag2 sqlite3 file ``path``, from its
    ``topics`` table read with the standard library (read-only)."""
    con = _connect(path)
    try:
        return [tuple(r) for r in con.execute("SELECT name, type, serialization_format FROM topics ORDER BY id")]
    finally:
        con.close()


def _sqlite_meta(path: Path, topic: str):
    """(CDR topic ids of ``topic``, root page of ``messages``, page size) from rosbag2's tables, read with the
    standard library opened read-only; None for another schema."""
    con = _connect(path)
    try:
        ids = [
            i
            for i, f in con.execute("SELECT id, serialization_format FROM topics WHERE name=?", (topic,))
            if f == "cdr"
        ]
        root = con.execute("SELECT rootpage, sql FROM sqlite_master WHERE type='table' AND name='messages'").fetchone()
        cols = [(c[1], c[2].upper(), c[5]) for c in con.execute("PRAGMA table_info(messages)")]
        psize = con.execute("PRAGMA page_size").fetchone()[0]
    finally:
        con.close()
    want = [("id", "INTEGER", 1), ("topic_id", "INTEGER", 0), ("timestamp", "INTEGER", 0), ("data", "BLOB", 0)]
    if not ids or root is None or cols != want or "WITHOUT ROWID" in root[1].upper():
        return None
    return set(ids), int(root[0]), int(psize)


def sqlite_blocks(path: Path, topic: str, rows: list | None = None):
    """The blocks of ``topic`` in a rosbag2 sqlite3 file, read from the table b-tree of ``messages`` by the
    file format (sqlite.org/fileformat2.html): interior pages (type 5) give the leaves (type 13) in rowid order,
    each leaf cell ``payload size, rowid`` varints and a record ``header size, serial types…, values`` of
    (id — the rowid, stored NULL —, topic_id, timestamp, data blob). Every page of a level is parsed at once with
    numpy, the leaves walked by a compiled kernel; a file with a write-ahead log, overflow pages for the topic, log
    times that decrease in rowid order, or anything unexpected raises :class:`NotFast`. ``rows``: a list an
    estimate of the topic's messages (for preallocation; the reader grows its arrays past it) is appended to
    before the first block."""
    yield from _sqlite_leaves(*sqlite_leaves(path, topic), rows)


def sqlite_leaves(path: Path, topic: str) -> tuple:
    """(mmap, its bytes, the leaf pages of ``messages`` in rowid order, page size, usable bytes per page, the
    topic's ids) of a rosbag2 sqlite3 file; :class:`NotFast` when the file is not one the scanner reads (see
    :func:`sqlite_blocks`)."""
    from optinav.io import _bagkernels as kern

    if sys.byteorder != "little":
        raise NotFast("a big-endian host: the walkers load little-endian words")
    wal = path.with_name(path.name + "-wal")
    if wal.exists() and wal.stat().st_size > 0:
        raise NotFast("a write-ahead log beside the database")
    meta = _sqlite_meta(path, topic)
    if meta is None:
        raise NotFast("not rosbag2's messages table")
    ids, root, psize = meta
    mm, u8 = _map(path)
    if bytes(u8[:16]) != b"SQLite format 3\x00" or u8.size % psize:
        raise NotFast("not an SQLite 3 database")
    usable = psize - int(u8[20])
    npages = u8.size // psize
    level = np.array([root], dtype=np.int64)
    while True:
        if np.any(level < 2) or np.any(level > npages):
            raise NotFast("a page number outside the file")
        if u8[(level[0] - 1) * psize] == 13:  # the leaves: the walker checks each page's type
            break
        # each page's children (the left child of every cell in key order, then the right-most pointer), in
        # slices whose pages are unmapped again after each: reading every interior page would otherwise map much
        # of the file at once where the kernel caches it in large folios
        nxt, n = np.empty(level.size * ((psize - 12) // 6 + 1), dtype=np.int64), 0
        for i in range(0, level.size, 4096):
            p = level[i : i + 4096]
            k = kern.sqlite_children(u8, p, psize, nxt[n:])
            _release(mm, int(p.min() - 1) * psize, int(p.max()) * psize)
            if k == -1:
                raise NotFast("not a table b-tree page")
            if k < 0:
                raise NotFast("a cell pointer outside its page")
            n += k
        level = nxt[:n].copy()
    return mm, u8, level, psize, usable, np.array(sorted(ids), dtype=np.int64)


def sqlite_decode(files: list[Path], topic: str, layout, reserve) -> int | None:
    """Decode every message of ``topic`` in the rosbag2 sqlite3 ``files`` (in turn) by
    :func:`optinav.io._bagkernels.sqlite_decode`: leaf pages in batches of about ``_ROUND`` bytes taken by
    whichever of two threads is free (:func:`_rounds`), ``_LEAVES`` pages walked and gathered at a time, each
    batch's pages unmapped after it. A batch is decoded from the row after the cells of the batches before it
    (their page headers' counts, summed in batch order as each is taken: at least their messages, as many when
    every cell is the topic's), its rows then moved down where other topics' cells came before; the order across
    batches (rowids, log times) is checked after. ``layout(first message bytes)``: the gather layout or None;
    ``reserve(rows kept, rows needed)``: the output (stamps, log times ns, triads a, triads b) with room for ``rows
    needed``, its first ``rows kept`` rows kept (when a batch would pass it, the batches taken so far are
    finished, the output grown at the cells per page so far, and the rest taken alike). The number of messages, or None — nothing to trust in the output — for
    anything the blocks (:func:`sqlite_blocks`) handle otherwise (other layouts, rowids or log times out of order,
    pages that do not parse; and a file without the topic's messages)."""
    import threading

    from optinav.io import _bagkernels as kern

    row, lay = 0, None
    last = np.array([-1, np.iinfo(np.int64).min], dtype=np.int64)
    for f in files:
        try:
            mm, u8, leaves, psize, usable, ids = sqlite_leaves(f, topic)
        except NotFast:
            return None
        scratch = [tuple(np.empty(_LEAVES * ((psize - 8) // 6 + 1), dtype=np.int64) for _ in range(3)) for _ in "ab"]
        # the first block with messages: the layout (from the first file's first message) and an estimate of the
        # rows (its messages per page)
        probe, k, b, cells = last.copy(), 0, 0, 0
        while k == 0 and b < leaves.size:
            status, c, k = kern.sqlite_walk(u8, leaves[b : b + _LEAVES], psize, usable, ids, *scratch[0], probe)
            if status != kern.OK:
                return None
            b, cells = b + _LEAVES, cells + c
        if k == 0:
            return None
        if lay is None:
            off, size = scratch[0][0], scratch[0][1]
            lay = layout(bytes(u8[off[0] : off[0] + size[0]]))
            if lay is None:
                return None
        per = max(_ROUND // psize, _LEAVES)
        est = k / min(leaves.size, b)  # messages per page
        # room for the estimate and one batch's cells more: a batch is placed by its cells' count
        slack = int(np.ceil(cells / min(leaves.size, b) * per))
        out = reserve(row, row + int(np.ceil(est * leaves.size)) + slack + 16)
        cut = np.arange(0, leaves.size, per)
        lo, hi = (np.minimum.reduceat(leaves, cut) - 1) * psize, np.maximum.reduceat(leaves, cut) * psize
        spans = [(i, min(i + per, leaves.size), x, y) for i, x, y in zip(cut.tolist(), lo.tolist(), hi.tolist())]
        seen = [b, cells]  # pages and cells counted so far: the rate the output grows by
        while spans:
            cap, taken, done = min(a.shape[0] for a in out), {}, {}
            # each batch's first row: the first batch's, then the one before's plus its cells, as their counts come
            # in (each thread counts the batch it took, reading its pages first); ``front``: the first batch whose
            # place is not known yet, ``halt``: the first one that does not fit (or has a page outside the file)
            after = dict(zip([a for a, *_ in spans], [a for a, *_ in spans[1:]] + [leaves.size]))
            cond, counts, front, halt = threading.Condition(), {}, [spans[0][0]], [leaves.size]
            starts = {spans[0][0]: row}

            def claim(i: int, j: int):
                try:
                    c = int(kern.sqlite_cells(u8, leaves[i:j], psize))
                except BaseException:  # the other thread may wait for this count: it stops instead
                    with cond:
                        halt[0] = min(halt[0], i)
                        cond.notify_all()
                    raise
                with cond:
                    counts[i] = c
                    while front[0] in counts and front[0] < halt[0]:
                        f = front[0]
                        if counts[f] < 0 or starts[f] + counts[f] > cap:  # decoded in a later pass, if at all
                            halt[0] = f
                            break
                        starts[after[f]], front[0] = starts[f] + counts[f], after[f]
                    cond.notify_all()
                    cond.wait_for(lambda: i < front[0] or i >= halt[0])
                    if i >= halt[0]:
                        return None
                    taken[i] = (starts[i], c)
                    return starts[i]

            def run(i: int, j: int, buf: tuple, at: int) -> bool:
                mine = np.array([-1, np.iinfo(np.int64).min], dtype=np.int64)
                lim = slice(0, at + taken[i][1])  # the batch's own rows, no more
                status, _, end, _ = kern.sqlite_decode(u8, leaves[i:j], psize, usable, ids, _LEAVES, *buf, mine,
                                                       lay, out[0][lim], out[2][lim], out[3][lim], out[1][lim], at)  # fmt: skip
                done[i] = (end - at, mine)
                return status == kern.OK

            if not _rounds(mm, spans, run, scratch, claim):
                return None
            for i, j, _, _ in spans[: len(taken)]:
                # the order across batches: the first page's rowids after the batch before's, and the log times
                at, (n, mine) = taken[i][0], done[i]
                probe = last.copy()
                if kern.sqlite_walk(u8, leaves[i : i + 1], psize, usable, ids, *scratch[0], probe)[0] != kern.OK:
                    return None
                if n and out[1][at] < last[1]:
                    return None
                if n and at > row:  # other topics' cells in the batches before: onto the rows after theirs
                    for arr in {id(a): a for a in out}.values():  # one triad (MagneticField): one array
                        arr[row : row + n] = arr[at : at + n]
                row += n
                last[0], last[1] = mine[0], max(last[1], mine[1])
                seen[0], seen[1] = seen[0] + j - i, seen[1] + taken[i][1]
            spans = spans[len(taken) :]
            if spans:  # past the reservation: the output grown for the next batch and the rest at the rate so far
                i, j = spans[0][:2]
                c = int(kern.sqlite_cells(u8, leaves[i:j], psize))
                if c < 0:
                    return None
                rest = int(np.ceil(seen[1] / max(seen[0], 1) * (leaves.size - j)))
                out = reserve(row, row + c + rest + slack + 16)
    return row


def _sqlite_leaves(mm, u8: np.ndarray, leaves: np.ndarray, psize: int, usable: int, ids: np.ndarray, rows):
    """The blocks of the leaf pages ``leaves`` (rowid order), ``_LEAVES`` pages at a time through
    :func:`optinav.io._bagkernels.sqlite_walk`, each block's pages unmapped again once decoded. ``rows``: see
    :func:`sqlite_blocks`; the first block's messages per page scaled to every leaf stand for the count."""
    from optinav.io import _bagkernels as kern

    got = _Rows()
    got.room(min(leaves.size, _LEAVES) * ((psize - 8) // 6 + 1))  # a cell: 2-byte pointer and 4 bytes at least
    last = np.array([-1, np.iinfo(np.int64).min], dtype=np.int64)
    done = _Unmap(mm)
    for b in range(0, leaves.size, _LEAVES):
        pages = leaves[b : b + _LEAVES]
        kern.touch_pages(u8, pages, psize)
        status, _, k = kern.sqlite_walk(u8, pages, psize, usable, ids, got.off, got.size, got.logt, last)
        if status == kern.ROWID_ORDER:
            raise NotFast("rowids out of order")
        # rosbags reads log times through the timestamp index, which a damaged table can contradict: the table's
        # order is trusted only where it is the index's (non-decreasing), else rosbags reads the bag
        if status == kern.TIME_ORDER:
            raise NotFast("log times out of order in the messages table")
        _walked(status, "a sqlite3 leaf page")
        if rows is not None:
            rows.append(-(-k * leaves.size // pages.size) + 16)
            rows = None
        out = got.block(u8, k)
        if out is not None:
            yield out
        done.add(int(pages.min() - 1) * psize, int(pages.max()) * psize)  # decoded by now
    done.flush()


def windows(u8: np.ndarray, start: np.ndarray, width: int) -> np.ndarray:
    """(n, width) copy of the ``width`` bytes of ``u8`` from each of ``start`` (zero past the end): one gather of
    ``width``-byte items from a view that starts an item at every byte."""
    over = start + width > u8.size
    if over.any():  # the last few: from a zero-padded copy of the file's tail
        lo = int(start[over].min())
        tail = np.zeros(u8.size - lo + width, dtype=np.uint8)
        tail[: u8.size - lo] = u8[lo:]
        out = np.empty((start.size, width), dtype=np.uint8)
        out[~over] = windows(u8, start[~over], width)
        out[over] = windows(tail, start[over] - lo, width)
        return out
    items = np.ndarray((u8.size - width + 1,), dtype=f"V{width}", buffer=u8, strides=(1,))
    return items[start].view(np.uint8).reshape(start.size, width)


#: leaf pages per block of a sqlite3 scan: half a MB, so the walk and the decoder find the block's bytes still in
#: cache (measured on 3.6 M messages: 1024 pages per block 0.94 s in the kernels, 128 pages 0.56 s)
_LEAVES = 128


def _map(path: Path):
    """(mmap, numpy bytes) of ``path`` mapped read-only."""
    import mmap

    with open(path, "rb") as fh:
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    return mm, np.frombuffer(mm, dtype=np.uint8)


def _release(mm, start: int, stop: int) -> None:
    """Unmap the pages of ``mm[start:stop]`` already read (they stay in the OS cache; a later read maps them
    again): the resident set holds the block being decoded, not the whole file."""
    import mmap

    advice = getattr(mmap, "MADV_DONTNEED", None)
    start -= start % mmap.PAGESIZE
    if advice is None or stop <= start:
        return
    try:
        mm.madvise(advice, start, min(stop, len(mm)) - start)
    except (OSError, ValueError):  # an OS without madvise on file maps: the pages stay mapped
        pass
