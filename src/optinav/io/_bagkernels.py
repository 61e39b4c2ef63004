"""Compiled record walkers of :mod:`optinav.io.bagscan` and the field gather of :mod:`optinav.io.rosbag`.

One pass per chunk or block of pages over the storage's bytes (numba, ``cache=True``): a record of the wanted
topic adds its message's offset, size and log time to preallocated arrays; anything these walkers do not expect
returns a status, and the caller raises :class:`~optinav.io.bagscan.NotFast` (``rosbags`` then reads the topic).
Layouts: MCAP (mcap.dev/spec), ROS 1 bag 2.0 (wiki.ros.org/Bags/Format/2.0), SQLite table b-tree leaves
(sqlite.org/fileformat2.html). Replaces numpy run finding whose per-run calls and passes over the bytes cost more
than the walk. Integers and floats are loaded straight from the bytes (unaligned, little-endian: the scanners
run these only on a little-endian host).
"""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

_NJ = dict(cache=True, nogil=True)


def _loader(nbtype, lltype):
    """An intrinsic ``load(u8, pos)``: the value of ``nbtype`` in the bytes of ``u8`` from ``pos`` — one
    unaligned load, where numba's indexing would load byte by byte, each with a negative-index check. The callers
    keep ``pos`` within the array."""

    @intrinsic
    def load(typingctx, arr, pos):
        def codegen(context, builder, signature, values):
            ary = context.make_array(signature.args[0])(context, builder, values[0])
            ptr = builder.gep(ary.data, [values[1]])
            return builder.load(builder.bitcast(ptr, lltype.as_pointer()), align=1)

        return nbtype(arr, pos), codegen

    return load


_u8 = _loader(types.uint8, ir.IntType(8))
_u16 = _loader(types.uint16, ir.IntType(16))
_u32 = _loader(types.uint32, ir.IntType(32))
_i64 = _loader(types.int64, ir.IntType(64))
_f8 = _loader(types.float64, ir.DoubleType())

#: statuses of the walkers (0: the range is done); ROOM: the decoders' output arrays are full
OK, CHANNEL, TRUNCATED, MALFORMED, FULL, ROWID_ORDER, TIME_ORDER, SPAN, ROOM = 0, 1, 2, 3, 4, 5, 6, 7, 8


@numba.njit(**_NJ)
def touch(buf, start, stop):
    """Read one byte of every 64 of ``buf[start:stop]`` in order (returns their sum): the map's pages fault in and
    the lines stream into the cache at the memory's bandwidth, so the walk that follows (a chain of dependent
    loads, one record's length giving the next record's place) finds them there instead of waiting on each."""
    s = np.int64(0)
    for i in range(max(start, 0), min(stop, buf.size), 64):
        s += _u8(buf, i)
    return s


@numba.njit(**_NJ)
def touch_pages(buf, pages, psize):
    """:func:`touch` for the pages ``pages`` (numbers from 1) of ``psize`` bytes."""
    s = np.int64(0)
    for pg in pages:
        s += touch(buf, (pg - 1) * psize, pg * psize)
    return s


@numba.njit(**_NJ)
def mcap_walk(buf, pos, end, chans, off, size, logt, k, t0, t1):
    """Records of an MCAP chunk's ``buf[pos:end]``: Message ``0x05`` of a channel with ``chans[id]`` set adds
    (data offset, data size, log time) at row ``k``. Returns (status, pos, k): CHANNEL stops at a Channel
    record for the caller to read; TRUNCATED/MALFORMED a record that does not fit; FULL the arrays; SPAN a log
    time outside the chunk's message span ``[t0, t1]`` (unless both are 0: not set)."""
    spanned = t0 != 0 or t1 != 0
    if pos < 0 or end > buf.size or chans.size < 1 << 16:  # the loads below are unchecked
        return MALFORMED, pos, k
    while pos < end:
        if pos + 9 > end:
            return TRUNCATED, pos, k
        n = _i64(buf, pos + 1)
        if n < 0 or n > end - pos - 9:
            return MALFORMED, pos, k
        op = _u8(buf, pos)
        if op == 0x05 and n >= 22:
            if chans[_u16(buf, pos + 9)]:
                if k == off.size:
                    return FULL, pos, k
                t = _i64(buf, pos + 15)
                if spanned and (t < t0 or t > t1):
                    return SPAN, pos, k
                off[k] = pos + 31
                size[k] = n - 22
                logt[k] = t
                k += 1
        elif op == 0x04:
            return CHANNEL, pos, k
        pos += 9 + n
    return OK, pos, k


@numba.njit(**_NJ)
def _is(buf, a, b, name):
    """The bytes ``buf[a:b]`` equal ``name``."""
    if b - a != name.size:
        return False
    for j in range(name.size):
        if buf[a + j] != name[j]:
            return False
    return True


@numba.njit(**_NJ)
def _eq(buf, a, b, n):
    """``buf[a:a + n]`` equals ``buf[b:b + n]`` (eight bytes at a time)."""
    j = 0
    while j + 8 <= n:
        if _i64(buf, a + j) != _i64(buf, b + j):
            return False
        j += 8
    while j < n:
        if _u8(buf, a + j) != _u8(buf, b + j):
            return False
        j += 1
    return True


_OP, _CONN, _TIME = (np.frombuffer(s, dtype=np.uint8).copy() for s in (b"op", b"conn", b"time"))


@numba.njit(**_NJ)
def _fields(buf, p, he, a, b):
    """The ROS 1 record header fields ``buf[p:he]`` (``len u32, name=value`` each): (ok, op, start and length of
    the value of field ``a``, of field ``b``); op the ``op`` byte (−1 absent, −2 not one byte), a start −1 for a
    field absent. A field's last occurrence counts. ok False for fields that do not parse."""
    op, sa, la, sb, lb = -1, np.int64(-1), np.int64(0), np.int64(-1), np.int64(0)
    while p < he:
        if p + 4 > he:
            return False, op, sa, la, sb, lb
        q = p + 4 + np.int64(_u32(buf, p))
        if q > he:
            return False, op, sa, la, sb, lb
        eq = p + 4
        while eq < q and buf[eq] != 0x3D:  # "="
            eq += 1
        if eq >= q:
            return False, op, sa, la, sb, lb
        if _is(buf, p + 4, eq, _OP):
            op = buf[eq + 1] if q - eq - 1 == 1 else -2
        elif _is(buf, p + 4, eq, a):
            sa, la = eq + 1, q - eq - 1
        elif _is(buf, p + 4, eq, b):
            sb, lb = eq + 1, q - eq - 1
        p = q
    return True, op, sa, la, sb, lb


@numba.njit(**_NJ)
def _u32_field(buf, start, n):
    """A u32 field's value (−1 absent, −2 not four bytes)."""
    if start < 0:
        return np.int64(-1)
    return np.int64(_u32(buf, start)) if n == 4 else np.int64(-2)


@numba.njit(**_NJ)
def ros1_walk(buf, pos, end, conns, off, size, logt, k):
    """Records of a ROS 1 chunk's ``buf[pos:end]`` (``header_len u32, fields (len u32, name=value)…, data_len
    u32, data``): a message data record (op ``0x02``) of a connection in ``conns`` adds (data offset, data size,
    log time ns from the ``time`` field sec u32, nsec u32) at row ``k``. A field's last occurrence counts, as in
    :func:`optinav.io.bagscan._fields`; a header equal to the topic's last message's but for the time value is
    not parsed again. Returns (status, pos, k)."""
    connn, timen = _CONN, _TIME
    ref, ref_t = np.int64(-1), np.int64(0)  # header start and time value offset of the topic's last message
    if pos < 0 or end > buf.size:  # the loads below are unchecked
        return MALFORMED, pos, k
    while pos < end:
        if pos + 4 > end:
            return TRUNCATED, pos, k
        hlen = np.int64(_u32(buf, pos))
        he = pos + 4 + hlen
        if he + 4 > end:
            return TRUNCATED, pos, k
        ds = he + 4
        de = ds + np.int64(_u32(buf, he))
        if de > end:
            return TRUNCATED, pos, k
        same = ref >= 0 and hlen == np.int64(_u32(buf, ref))  # then both headers lie within the chunk
        if (
            same
            and _eq(buf, ref + 4, pos + 4, ref_t - 4)
            and _eq(buf, ref + ref_t + 8, pos + ref_t + 8, hlen - ref_t - 4)
        ):
            # byte for byte the header of the topic's last message (same length word) but the time value: the
            # same fields, not parsed again
            if k == off.size:
                return FULL, pos, k
            off[k] = ds
            size[k] = de - ds
            logt[k] = np.int64(_u32(buf, pos + ref_t)) * 1_000_000_000 + np.int64(_u32(buf, pos + ref_t + 4))
            k += 1
            ref = pos
            pos = de
            continue
        ok, op, cs, cl, ts, tl = _fields(buf, pos + 4, he, connn, timen)
        if not ok:
            return MALFORMED, pos, k
        conn = _u32_field(buf, cs, cl)
        tpos = ts if ts < 0 or tl == 8 else np.int64(-2)
        if op < 0:
            return MALFORMED, pos, k
        if op == 0x02:
            if conn < 0:
                return MALFORMED, pos, k
            mine = False
            for c in conns:
                mine |= c == conn
            if mine:
                if tpos < 0:
                    return MALFORMED, pos, k
                if k == off.size:
                    return FULL, pos, k
                off[k] = ds
                size[k] = de - ds
                logt[k] = np.int64(_u32(buf, tpos)) * 1_000_000_000 + np.int64(_u32(buf, tpos + 4))
                k += 1
                ref, ref_t = pos, tpos - pos
        pos = de
    return OK, pos, k


_COMPRESSION, _SIZE, _NONE = (np.frombuffer(s, dtype=np.uint8).copy() for s in (b"compression", b"size", b"none"))


@numba.njit(**_NJ)
def ros1_chunk(buf, pos, end):
    """The ROS 1 chunk record at ``buf[pos:end]``: (status, data start, data stop). OK only for a chunk (op
    ``0x05``) stored uncompressed (``compression=none``) whose ``size`` field, when present, is its data's
    length; else MALFORMED (the caller reads that chunk another way)."""
    compn, sizen, nonen = _COMPRESSION, _SIZE, _NONE
    if pos < 0 or end > buf.size or pos + 4 > end:
        return MALFORMED, pos, pos
    he = pos + 4 + np.int64(_u32(buf, pos))
    if he + 4 > end:
        return MALFORMED, pos, pos
    ds = he + 4
    de = ds + np.int64(_u32(buf, he))
    if de > end:
        return MALFORMED, pos, pos
    ok, op, cs, cl, ss, sl = _fields(buf, pos + 4, he, compn, sizen)
    if not ok:
        return MALFORMED, pos, pos
    plain = cs >= 0 and _is(buf, cs, cs + cl, nonen)
    csize = _u32_field(buf, ss, sl)
    if op != 0x05 or not plain or csize == -2 or (csize >= 0 and csize != de - ds):
        return MALFORMED, pos, pos
    return OK, ds, de


_COUNT = np.frombuffer(b"count", dtype=np.uint8).copy()


@numba.njit(**_NJ)
def ros1_tails(buf, pos, nxt, conns):
    """The messages of the connections ``conns`` in each ROS 1 chunk at ``pos[i]`` by its index data records (op
    ``0x04``: ``conn``, ``count`` fields), which follow the chunk record up to the next chunk ``nxt[i]`` (other
    records there are skipped). Returns (status, counts): MALFORMED for records that do not end at ``nxt[i]``."""
    connn, countn = _CONN, _COUNT
    counts = np.zeros(pos.size, dtype=np.int64)
    for i in range(pos.size):
        end = nxt[i]
        p = pos[i]
        if p < 0 or end > buf.size or p + 4 > end:
            return MALFORMED, counts
        he = p + 4 + np.int64(_u32(buf, p))
        if he + 4 > end:
            return MALFORMED, counts
        q = he + 4 + np.int64(_u32(buf, he))  # past the chunk record
        while q < end:
            if q + 4 > end:
                return MALFORMED, counts
            he = q + 4 + np.int64(_u32(buf, q))
            if he + 4 > end:
                return MALFORMED, counts
            de = he + 4 + np.int64(_u32(buf, he))
            if de > end:
                return MALFORMED, counts
            ok, op, cs, cl, ns, nl = _fields(buf, q + 4, he, connn, countn)
            if not ok:
                return MALFORMED, counts
            conn, cnt = _u32_field(buf, cs, cl), _u32_field(buf, ns, nl)
            if op == 0x04:
                if conn < 0 or cnt < 0:
                    return MALFORMED, counts
                for c in conns:
                    if c == conn:
                        counts[i] += cnt
            q = de
        if q != end:
            return MALFORMED, counts
    return OK, counts


@numba.njit(**_NJ)
def ros1_decode(buf, chunks, end, expect, row0, conns, off, size, logt, lay, stamp, va, vb, out_logt):
    """Walk and decode the uncompressed ROS 1 chunks at the offsets ``chunks`` (records before ``end``): each
    chunk's bytes read in order (:func:`touch`), its messages of ``conns`` found (:func:`ros1_walk`, into the
    scratch ``off``/``size``/``logt``), which must number ``expect[i]`` (the chunk info's count), then gathered
    (:func:`gather`, layout ``lay`` = itemsize, sec offset, signed sec, length offset, string length, triad
    offsets a and b) into rows ``row0[i]…`` of ``stamp``, ``va``, ``vb`` and ``out_logt``. Returns (status,
    chunks done, sum of the bytes read): MALFORMED for a chunk that is not plain or does not walk, FULL for a
    count other than ``expect``, CHANNEL for a message of another layout (the caller then reads another way)."""
    seen = np.int64(0)
    for i in range(chunks.size):
        status, ds, de = ros1_chunk(buf, chunks[i], end)
        if status != OK:
            return status, i, seen
        n = expect[i]
        if n < 0 or n + 1 > off.size or row0[i] < 0 or row0[i] + n > stamp.size:
            return FULL, i, seen
        seen += touch(buf, ds, de)  # used: the loads stay
        status, _, k = ros1_walk(buf, ds, de, conns, off[: n + 1], size[: n + 1], logt[: n + 1], 0)
        if status != OK:
            return status, i, seen
        if k != n:
            return FULL, i, seen
        other = gather(buf, off[:k], size[:k], lay[0], lay[1], lay[2] != 0, lay[3], lay[4], lay[5], lay[6], lay[7:],
                       stamp, va, vb, row0[i])  # fmt: skip
        for j in range(k):
            if other[j]:
                return CHANNEL, i, seen
            out_logt[row0[i] + j] = logt[j]
    return OK, chunks.size, seen


@numba.njit(**_NJ)
def _varint(buf, p, lim):
    """(value, bytes) of the SQLite varint at ``p`` (at most 8 bytes here, none past ``lim``); bytes 0: longer or
    past ``lim``."""
    v = np.int64(0)
    for j in range(8):
        if p + j >= lim:
            return v, 0
        b = np.int64(_u8(buf, p + j))
        v = (v << np.int64(7)) | (b & 0x7F)
        if b < 0x80:
            return v, j + 1
    return v, 0


@numba.njit(**_NJ)
def _be(buf, p, n):
    """Big-endian two's-complement integer of ``n`` (0–8) bytes at ``p``."""
    if n == 0:
        return np.int64(0)
    v = np.int64(-1) if _u8(buf, p) >= 0x80 else np.int64(0)
    for j in range(n):
        v = (v << np.int64(8)) | np.int64(_u8(buf, p + j))
    return v


#: SQLite serial type → bytes of an integer field (7 is a float, ≥ 10 reserved or a string)
_INT_BYTES = np.array([0, 1, 2, 3, 4, 6, 8, -1, 0, 0], dtype=np.int64)


@numba.njit(**_NJ)
def sqlite_walk(buf, pages, psize, usable, ids, off, size, logt, last):
    """The cells of the table b-tree leaf ``pages`` (type 13, header 8 bytes) in key order, each ``payload size,
    rowid`` varints and a record ``header size, serial types…`` of (id — stored NULL —, topic_id, timestamp, data
    blob): a cell whose topic id is in ``ids`` adds (data offset in the file, data size, timestamp) at the next
    row. ``last``: (rowid, timestamp) of the previous block's last cell and message, updated. Returns (status,
    cells, rows): MALFORMED for a page, cell or record of another layout or a message on overflow pages,
    ROWID_ORDER for rowids not increasing, TIME_ORDER for message timestamps that decrease in rowid order."""
    intb = _INT_BYTES
    nbytes = buf.size
    cells = 0
    k = 0
    # the topic's last message: record start, bytes of its header and topic id, payload size, stamp bytes, data size
    ref, ref_n, ref_psz, ref_b2, ref_dlen = np.int64(-1), np.int64(0), np.int64(0), np.int64(0), np.int64(0)
    for pg in pages:
        base = (pg - 1) * psize
        if pg < 1 or base + psize > nbytes or buf[base] != 13:
            return MALFORMED, cells, k
        cnt = (np.int64(buf[base + 3]) << 8) | buf[base + 4]
        if 8 + 2 * cnt > psize:  # the cell pointers past their page
            return MALFORMED, cells, k
        cells += cnt
        for c in range(cnt):
            q = base + 8 + 2 * c
            ptr = (np.int64(buf[q]) << 8) | buf[q + 1]
            if ptr < 8 + 2 * cnt or ptr >= psize:
                return MALFORMED, cells, k
            at = base + ptr
            lim = min(at + 48, nbytes)  # the fields before the blob lie in the cell's first 48 bytes
            psz, n1 = _varint(buf, at, lim)
            rid, n2 = _varint(buf, at + n1, lim)
            rec = at + n1 + n2
            hs, n3 = _varint(buf, rec, lim)
            if n1 == 0 or n2 == 0 or n3 == 0:
                return MALFORMED, cells, k
            if rid <= last[0]:
                return ROWID_ORDER, cells, k
            last[0] = rid
            if ref >= 0 and psz == ref_psz and rec + ref_n + ref_b2 <= lim and _eq(buf, ref, rec, ref_n):
                # record header and topic id byte for byte the topic's last message's, same payload size: the same
                # serial types, not parsed again
                if rec + psz > base + psize:
                    return MALFORMED, cells, k
                p = rec + ref_n
                t = _be(buf, p, ref_b2)
                if t < last[1]:
                    return TIME_ORDER, cells, k
                last[1] = t
                if k == off.size:
                    return FULL, cells, k
                off[k] = p + ref_b2
                size[k] = ref_dlen
                logt[k] = t
                k += 1
                continue
            p = rec + n3
            t0, n = _varint(buf, p, lim)
            p += n
            t1, n4 = _varint(buf, p, lim)
            p += n4
            t2, n5 = _varint(buf, p, lim)
            p += n5
            t3, n6 = _varint(buf, p, lim)
            p += n6
            if n == 0 or n4 == 0 or n5 == 0 or n6 == 0 or p != rec + hs or t0 != 0 or t1 > 9 or t2 > 9:
                return MALFORMED, cells, k
            b1, b2 = intb[t1], intb[t2]
            if b1 < 0 or b2 < 0 or p + b1 + b2 > lim:
                return MALFORMED, cells, k
            topic = _be(buf, p, b1) + (1 if t1 == 9 else 0)
            mine = False
            for i in ids:
                mine |= i == topic
            if not mine:
                continue
            dlen = (t3 - 12) // 2
            if t3 < 12 or t3 % 2 == 1 or psz != hs + b1 + b2 + dlen or psz > usable - 35:
                return MALFORMED, cells, k
            if rec + psz > base + psize:  # the payload past its page: a damaged pointer or size
                return MALFORMED, cells, k
            t = _be(buf, p + b1, b2)
            if t < last[1]:
                return TIME_ORDER, cells, k
            last[1] = t
            if k == off.size:
                return FULL, cells, k
            off[k] = p + b1 + b2
            size[k] = dlen
            logt[k] = t
            k += 1
            ref, ref_n, ref_psz, ref_b2, ref_dlen = rec, p + b1 - rec, psz, b2, dlen
    return OK, cells, k


@numba.njit(**_NJ)
def sqlite_children(buf, pages, psize, out):
    """The child page numbers of the table b-tree interior ``pages`` (numbers from 1; type 5, a 12-byte header) in
    key order — each cell's left child (its first 4 bytes, big-endian), then the page's right-most pointer (header
    bytes 8-11) — written to ``out`` from 0. Returns their count; −1 for a page outside ``buf`` or of another type,
    −2 for a cell pointer outside its page, −3 when ``out`` is too small."""
    k = np.int64(0)
    for pg in pages:
        base = (pg - 1) * psize
        if pg < 1 or base + psize > buf.size or buf[base] != 5:
            return np.int64(-1)
        cnt = (np.int64(buf[base + 3]) << 8) | buf[base + 4]
        if 12 + 2 * cnt > psize:
            return np.int64(-2)
        if k + cnt + 1 > out.size:
            return np.int64(-3)
        for c in range(cnt):
            q = base + 12 + 2 * c
            ptr = (np.int64(buf[q]) << 8) | buf[q + 1]
            if ptr < 12 + 2 * cnt or ptr + 4 > psize:
                return np.int64(-2)
            out[k] = _be(buf, base + ptr, 4)
            k += 1
        out[k] = _be(buf, base + 8, 4)
        k += 1
    return k


@numba.njit(**_NJ)
def sqlite_cells(buf, pages, psize):
    """The cells of the table b-tree leaf ``pages`` (numbers from 1) of ``psize`` bytes by each page header's cell
    count (bytes 3-4, big-endian), as :func:`sqlite_walk` reads it: at least the messages the walk finds there (as
    many when every cell is the topic's). −1 for a page outside ``buf``."""
    n = np.int64(0)
    for pg in pages:
        base = (pg - 1) * psize
        if pg < 1 or base + psize > buf.size:
            return np.int64(-1)
        n += (np.int64(buf[base + 3]) << 8) | buf[base + 4]
    return n


@numba.njit(**_NJ)
def mcap_decode(buf, chunks, chans, off, size, logt, lay, stamp, va, vb, out_logt, row, crc_checked):
    """:func:`mcap_walk` and :func:`gather` over the MCAP Chunk records at ``chunks`` (offsets of their opcode),
    each stored uncompressed and without a CRC (or with one the caller checked: ``crc_checked``), read in order
    first (:func:`touch`), walked into the scratch
    ``off``/``size``/``logt`` (Channel records in a chunk are skipped: ``chans`` comes from the summary),
    gathered while in cache into rows ``row…`` (``lay``: see :func:`ros1_decode`). Returns (status, chunks done,
    rows filled, sum of the bytes read): MALFORMED for a compressed or CRC-checked chunk or one that does not
    parse, FULL when the scratch is too small for a chunk, ROOM when the output is, CHANNEL for a message of
    another layout, SPAN as the walker."""
    seen = np.int64(0)
    for i in range(chunks.size):
        pos = chunks[i]
        if pos < 0 or pos + 9 + 40 > buf.size or buf[pos] != 0x06:
            return MALFORMED, i, row, seen
        n = _i64(buf, pos + 1)
        if n < 40 or n > buf.size - pos - 9:
            return MALFORMED, i, row, seen
        s = pos + 9
        t0, t1 = _i64(buf, s), _i64(buf, s + 8)
        usize, crc, clen = _i64(buf, s + 16), _u32(buf, s + 24), _u32(buf, s + 28)
        p = s + 32
        if clen != 0 or (crc != 0 and not crc_checked) or t0 < 0 or t1 < 0 or p + 8 > s + n:
            return MALFORMED, i, row, seen
        rlen = _i64(buf, p)
        if rlen < 0 or rlen != usize or rlen > s + n - p - 8:
            return MALFORMED, i, row, seen
        ds, de = p + 8, p + 8 + rlen
        seen += touch(buf, ds, de)  # used: the loads stay
        k, q = 0, ds
        while True:
            status, q, k = mcap_walk(buf, q, de, chans, off, size, logt, k, t0, t1)
            if status != CHANNEL:
                break
            q += 9 + _i64(buf, q + 1)  # the walker checked that it fits
        if status != OK:
            return status, i, row, seen
        if row + k > stamp.size or row + k > out_logt.size:
            return ROOM, i, row, seen
        other = gather(buf, off[:k], size[:k], lay[0], lay[1], lay[2] != 0, lay[3], lay[4], lay[5], lay[6], lay[7:],
                       stamp, va, vb, row)  # fmt: skip
        for j in range(k):
            if other[j]:
                return CHANNEL, i, row, seen
            out_logt[row + j] = logt[j]
        row += k
    return OK, chunks.size, row, seen


@numba.njit(**_NJ)
def sqlite_decode(buf, pages, psize, usable, ids, block, off, size, logt, last, lay, stamp, va, vb, out_logt, row):
    """:func:`sqlite_walk` and :func:`gather` over the leaf ``pages``, ``block`` pages at a time (read in order
    first, :func:`touch_pages`; walked into the scratch ``off``/``size``/``logt``, which must hold a block's
    cells; gathered while in cache) into rows ``row…`` of ``stamp``, ``va``, ``vb``, ``out_logt`` (``lay``: see
    :func:`ros1_decode`). Returns (status, pages done, rows filled, sum of the bytes read): ROOM when the next
    block does not fit the output (``last`` as before that block: decode again from there), CHANNEL for a message
    of another layout, the walker's status otherwise."""
    seen = np.int64(0)
    for b in range(0, pages.size, block):
        pg = pages[b : b + block]
        seen += touch_pages(buf, pg, psize)  # used: the loads stay
        l0, l1 = last[0], last[1]
        status, _, k = sqlite_walk(buf, pg, psize, usable, ids, off, size, logt, last)
        if status != OK:
            return status, b, row, seen
        if row + k > stamp.size or row + k > out_logt.size:
            last[0], last[1] = l0, l1
            return ROOM, b, row, seen
        other = gather(buf, off[:k], size[:k], lay[0], lay[1], lay[2] != 0, lay[3], lay[4], lay[5], lay[6], lay[7:],
                       stamp, va, vb, row)  # fmt: skip
        for j in range(k):
            if other[j]:
                return CHANNEL, b, row, seen
            out_logt[row + j] = logt[j]
        row += k
    return OK, pages.size, row, seen


@numba.njit(**_NJ)
def gather(buf, off, size, itemsize, o_sec, signed_sec, o_len, slen, o_a, o_b, frame, stamp, va, vb, row0):
    """Messages ``buf[off[i]:off[i] + size[i]]`` of the fixed layout (``itemsize`` bytes, string length ``slen``
    at ``o_len``, the string's bytes — the header's frame_id — those of ``frame`` unless it is empty): stamp (sec u32 or i32 at ``o_sec``, nsec u32 after it, s) and the float64 triads at ``o_a``
    into ``va`` and, unless ``o_b`` < 0, at ``o_b`` into ``vb`` ((n, 3) arrays), written at row ``row0 + i``.
    Returns the mask of the messages of another layout (left for the deserializer)."""
    if o_len + 4 + frame.size > itemsize or o_sec + 8 > itemsize or o_a + 24 > itemsize or o_b + 24 > itemsize:
        raise ValueError("a field outside the message layout")  # the loads below are unchecked
    n = off.size
    other = np.zeros(n, dtype=np.bool_)
    # the frame_id's bytes as little-endian 8-byte words and a tail: one load and compare per word
    words = np.zeros(frame.size // 8, dtype=np.int64)
    for j in range(words.size * 8):
        words[j // 8] |= np.int64(frame[j] & 0xFF) << np.int64(8 * (j % 8))
    for i in range(n):
        p = off[i]
        if p < 0 or size[i] < 0 or p + size[i] > buf.size:
            raise ValueError("a message outside its block")  # the scanner's offsets: never read past them
        if size[i] != itemsize or np.int64(_u32(buf, p + o_len)) != slen:
            other[i] = True
            continue
        # another frame_id (a second IMU publishing on the topic) is a layout of its own for the caller
        q = p + o_len + 4
        for j in range(words.size):
            if _i64(buf, q + 8 * j) != words[j]:
                other[i] = True
                break
        for j in range(words.size * 8, frame.size):
            if buf[q + j] != frame[j]:
                other[i] = True
                break
        if other[i]:
            continue
        sec = np.int64(_u32(buf, p + o_sec))
        if signed_sec and sec >= 2**31:
            sec -= 2**32
        r = row0 + i
        stamp[r] = sec + np.int64(_u32(buf, p + o_sec + 4)) * 1e-9
        q = p + o_a
        va[r, 0], va[r, 1], va[r, 2] = _f8(buf, q), _f8(buf, q + 8), _f8(buf, q + 16)
        if o_b >= 0:
            q = p + o_b
            vb[r, 0], vb[r, 1], vb[r, 2] = _f8(buf, q), _f8(buf, q + 8), _f8(buf, q + 16)
    return other


@numba.njit(**_NJ)
def zstd_sizes(buf, off, size, content):
    """The content size of each Zstandard frame ``buf[off[i]:off[i] + size[i]]`` from its header (RFC 8878
    §3.1.1: magic, frame header descriptor, window descriptor, dictionary id, frame content size) into
    ``content``. Returns −1, or the first message ``i`` that is not a frame header with a content size."""
    for i in range(off.size):
        a, n = off[i], size[i]
        if a < 0 or n < 6 or a + n > buf.size or _u32(buf, a) != 0xFD2FB528:
            return i
        fhd = np.int64(buf[a + 4])
        flag, single, did = fhd >> 6, (fhd >> 5) & 1, fhd & 3
        if (fhd >> 3) & 1:  # reserved bit
            return i
        h = a + 5 + (1 - single) + (0 if did == 0 else 1 << (did - 1))
        w = (1 if single else 0) if flag == 0 else 1 << flag
        if w == 0 or h + w > a + n:
            return i
        v = np.int64(0)
        for j in range(w):
            v |= np.int64(buf[h + j]) << (8 * j)
        content[i] = v + 256 if w == 2 else v
        if content[i] < 0:
            return i
    return -1


@numba.njit(**_NJ)
def zstd_inflate(call, ctx, src, off, size, dst, doff, dsize):
    """Inflate the Zstandard frames ``src[off[i]:off[i] + size[i]]`` into ``dst[doff[i]:doff[i] + dsize[i]]`` by
    ``call`` = libzstd's ``ZSTD_decompressDCtx`` (a ctypes function of five ``size_t``: the context ``ctx``, the
    destination, its capacity, the source, its size). Returns −1, or the first frame outside the arrays, that
    fails or that inflates to another size."""
    s, d = src.ctypes.data, dst.ctypes.data
    for i in range(off.size):
        if off[i] < 0 or size[i] < 0 or off[i] + size[i] > src.size or doff[i] < 0 or doff[i] + dsize[i] > dst.size:
            return i
        if call(ctx, d + doff[i], dsize[i], s + off[i], size[i]) != dsize[i]:
            return i
    return -1


def warm() -> None:
    """Load every kernel (numba's start and the cached machine code, about a second in a fresh process) on a
    few bytes, with the argument types the scanners pass: lets a benchmark time a read apart from that start."""
    buf = np.frombuffer(bytes(64), dtype=np.uint8)  # read-only, as the file map and decompressed chunks are
    i64 = np.zeros(4, dtype=np.int64)
    touch(buf, 0, 64)
    touch_pages(buf, i64[:0], 64)
    mcap_walk(buf, 0, 0, np.zeros(1 << 16, dtype=np.bool_), i64, i64, i64, 0, 0, 0)
    ros1_walk(buf, 0, 0, i64, i64, i64, i64, 0)
    ros1_tails(buf, i64[:0], i64[:0], i64)
    mcap_decode(buf, i64[:0], np.zeros(1 << 16, dtype=np.bool_), i64, i64, i64, np.zeros(7, dtype=np.int64),
                np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), i64, 0, False)  # fmt: skip
    sqlite_decode(buf, i64[:0], 64, 64, i64, 1, i64, i64, i64, i64[:2], np.zeros(7, dtype=np.int64), np.zeros(1),
                  np.zeros((1, 3)), np.zeros((1, 3)), i64, 0)  # fmt: skip
    sqlite_walk(buf, i64[:0], 64, 64, i64, i64, i64, i64, i64[:2])
    sqlite_cells(buf, i64[:0], 64)
    sqlite_children(buf, i64[:0], 64, i64)
    v = np.zeros((1, 3))
    ros1_decode(
        buf, i64[:0], 64, i64[:0], i64[:0], i64, i64, i64, i64, np.zeros(7, dtype=np.int64), np.zeros(1), v, v, i64
    )
    v = np.zeros((1, 3))
    gather(buf, i64[:0], i64[:0], 64, 0, True, 8, 0, 16, -1, i64[:0], np.zeros(1), v, v, 0)
    zstd_sizes(buf, i64[:0], i64[:0], i64[:0])


@numba.njit(**_NJ)
def alternation_sums(x, mean, m2):
    """Every other row's departure from the mean of its two neighbours, h_i = x[2i+1] − (x[2i] + x[2i+2])/2, over
    the pairs whose K (≤ 8) values are all finite: their count (returned), per column their mean (``mean``, (K,))
    and sum of squared deviations from it (``m2``, (K,)); one pass of sums shifted by the first finite h (no
    cancellation for a mean far from 0), no (N, K) temporaries (the two-IMU check of a bag topic ran full-size
    array operations: 120 ms per million messages, more than the decode)."""
    k = (x.shape[0] - 1) // 2
    nc = x.shape[1]
    if nc == 3:  # a triad: the same sums in scalars (kept in registers: half the time)
        return _alternation_sums3(x, mean, m2, np.empty(2))
    h = np.empty(8)
    h0 = np.empty(8)
    s1 = np.zeros(8)
    s2 = np.zeros(8)
    count = 0
    for i in range(k):
        s = 0.0
        for c in range(nc):
            h[c] = x[2 * i + 1, c] - 0.5 * (x[2 * i, c] + x[2 * i + 2, c])
            s += h[c]
        if s - s != 0.0:  # a NaN or inf among them
            continue
        if count == 0:
            for c in range(nc):
                h0[c] = h[c]
        count += 1
        for c in range(nc):
            d = h[c] - h0[c]
            s1[c] += d
            s2[c] += d * d
    for c in range(nc):
        mean[c] = 0.0
        m2[c] = 0.0
        if count:
            mean[c] = h0[c] + s1[c] / count
            m2[c] = max(s2[c] - s1[c] * s1[c] / count, 0.0)
    return count


@numba.njit(**_NJ)
def alternation_range(x, mean, m2, bounds):
    """:func:`alternation_sums` of an (N, 3) array, and (min, max) of all its values in ``bounds`` ((2,); NaN when
    one is NaN) in the same pass: the range the value check of a bag topic's triad takes (a pass of its own cost
    as much again)."""
    return _alternation_sums3(x, mean, m2, bounds)


@numba.njit(**_NJ)
def _alternation_sums3(x, mean, m2, bounds):
    """:func:`alternation_range`: the sums operation for operation as :func:`alternation_sums` (the same results
    to the bit)."""
    k = (x.shape[0] - 1) // 2
    s1a = s1b = s1c = s2a = s2b = s2c = 0.0
    r0 = r1 = r2 = 0.0
    # a minimum and a maximum per column: six short chains, not two of six steps each (a fifth of the time)
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    nan = False
    count = 0
    for i in range(k):
        a0, a1, a2 = x[2 * i, 0], x[2 * i, 1], x[2 * i, 2]
        b0, b1, b2 = x[2 * i + 1, 0], x[2 * i + 1, 1], x[2 * i + 1, 2]
        lo0, lo1, lo2 = min(lo0, min(a0, b0)), min(lo1, min(a1, b1)), min(lo2, min(a2, b2))
        hi0, hi1, hi2 = max(hi0, max(a0, b0)), max(hi1, max(a1, b1)), max(hi2, max(a2, b2))
        ha = b0 - 0.5 * (a0 + x[2 * i + 2, 0])
        hb = b1 - 0.5 * (a1 + x[2 * i + 2, 1])
        hc = b2 - 0.5 * (a2 + x[2 * i + 2, 2])
        s = 0.0 + ha + hb + hc
        if s - s != 0.0:  # a NaN or inf among them (a NaN of row 2i + 2 is the next pair's or the tail's)
            nan = nan or a0 != a0 or a1 != a1 or a2 != a2 or b0 != b0 or b1 != b1 or b2 != b2
            continue
        if count == 0:
            r0, r1, r2 = ha, hb, hc
        count += 1
        d = ha - r0
        s1a += d
        s2a += d * d
        d = hb - r1
        s1b += d
        s2b += d * d
        d = hc - r2
        s1c += d
        s2c += d * d
    lo, hi = min(lo0, lo1, lo2), max(hi0, hi1, hi2)
    for j in range(max(2 * k, 0), x.shape[0]):  # the rows from the last pair's end on
        for c in range(3):
            v = x[j, c]
            lo, hi, nan = min(lo, v), max(hi, v), nan or v != v
    bounds[0], bounds[1] = (np.nan, np.nan) if nan else (lo, hi)
    mean[0] = mean[1] = mean[2] = 0.0
    m2[0] = m2[1] = m2[2] = 0.0
    if count:
        mean[0], mean[1], mean[2] = r0 + s1a / count, r1 + s1b / count, r2 + s1c / count
        m2[0] = max(s2a - s1a * s1a / count, 0.0)
        m2[1] = max(s2b - s1b * s1b / count, 0.0)
        m2[2] = max(s2c - s1c * s1c / count, 0.0)
    return count
