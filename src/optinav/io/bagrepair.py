"""Bag files whose recording did not close, made readable as ``rosbag reindex`` and ``mcap recover`` would make
them — into a copy (:func:`repair`), never beside the input.

* ROS 1 (``X.bag.active``, or any bag whose header holds no index position: the recorder was killed, the disk
  filled, the power went). Bags/Format/2.0: after the bag header come chunk records (op 0x05), each followed by one
  index data record (op 0x04) per connection in it; a connection record (op 0x07) sits in the chunk before that
  connection's first message; the index a closed bag ends with (connection records, one chunk info record, op
  0x06, per chunk) and its position in the header are written only when the bag closes. The writer leaves a chunk's
  sizes at 0 until the chunk closes, so an unfinished last chunk is read up to its last complete message record
  (when uncompressed: a compressed stream cut anywhere is left out). The copy gets the index.
* MCAP (``ros2 bag record`` stopped without closing its file: no summary, footer or closing magic): the complete
  records of the data section are kept and closed by a Data End, the summary the writer would have written for
  them (the Schema and Channel records, a Chunk Index per chunk from the Message Index records after it, the
  Statistics; where a chunk has none, no summary, which MCAP allows) and the Footer.
"""

from __future__ import annotations

import mmap
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from optinav.io.bagscan import (
    _MCAP_MAGIC,
    _ROS1_MAGIC,
    _U16,
    _U32,
    _U64,
    NotFast,
    _decompress,
    _fields,
    _mcap_head,
    _op,
    _record,
    _release,
    record_head,
)

__all__ = ["SUFFIX", "NotFast", "Repair", "bag_kind", "needs_repair", "repair"]

_HEAD = len(_ROS1_MAGIC) + 4096 + 64  # the version line and the bag header record (padded to 4096 bytes)
_TIME = struct.Struct("<II")
#: an index data entry (version 1): the message's time and its offset in the chunk's data
_ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("off", "<u4")])
#: bytes copied at a time (released from the resident set after)
_PIECE = 1 << 26
#: the suffix under which the bag readers take each kind
SUFFIX = {"ros1": ".bag", "mcap": ".mcap"}


@dataclass
class Repair:
    """What :func:`repair` kept of a bag: ``kind`` "ros1" or "mcap"; ``chunks`` whole chunks kept; ``recovered``
    messages of an unfinished chunk kept; ``dropped`` bytes at the end left out and ``why`` (what they held)."""

    kind: str
    chunks: int
    recovered: int
    dropped: int
    why: str

    def words(self, name: str) -> str:
        """One line for the user: what was read of the bag ``name``."""
        how, lacks = ("reindexed", "index") if self.kind == "ros1" else ("closed", "summary or footer")
        chunks = f"{self.chunks} complete chunk" + ("s" if self.chunks != 1 else "")
        text = (
            f"{name} has no {lacks} (a recording that did not close, or a copy cut short): read from a {how} copy "
            f"of its {chunks}"
        )
        if self.recovered:
            text += f" and the {self.recovered} complete messages of its unfinished last chunk"
        if self.dropped:
            text += f"; its last {self.dropped} bytes ({self.why}) are left out"
        return text


def bag_kind(path: Path) -> str | None:
    """The kind of a file that starts with a bag format's magic, whatever its suffix: "ros1" or "mcap"; else
    None."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(_ROS1_MAGIC))
    except OSError:
        return None
    if head.startswith(_ROS1_MAGIC):
        return "ros1"
    if head.startswith(_MCAP_MAGIC):
        return "mcap"
    return None


def needs_repair(path: Path, kind: str) -> bool:
    """Whether the bag file ``path`` of ``kind`` did not close: a ROS 1 header without a valid index position, an
    MCAP file that does not end in the magic."""
    with open(path, "rb") as fh:
        head = fh.read(_HEAD)
        fh.seek(0, 2)
        size = fh.tell()
        if kind == "mcap":
            fh.seek(max(0, size - len(_MCAP_MAGIC)))
            return size < 2 * len(_MCAP_MAGIC) or fh.read() != _MCAP_MAGIC
    try:
        f, _, first = _record(head, len(_ROS1_MAGIC), len(head))
        index_pos = _U64.unpack_from(head, f[b"index_pos"][0])[0]
    except (NotFast, KeyError, struct.error):
        return size < _HEAD  # a file that ends within its header; another header the readers name
    return not first <= index_pos < size


def repair(src: Path, dst: Path, kind: str) -> Repair:
    """Write the closed copy of the bag ``src`` (``kind`` "ros1" or "mcap") to ``dst``. Raises :class:`NotFast`
    when nothing of it can be read (no complete chunk, no bag header)."""
    with open(src, "rb") as fh:
        if not fh.seek(0, 2):
            raise NotFast("it is empty")
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        with open(dst, "wb") as out:
            return _ros1(mm, out) if kind == "ros1" else _mcap(mm, out)
    finally:
        mm.close()


# --- ROS 1 ----------------------------------------------------------------------------------------------------


def _u32(buf, f: dict, key: bytes) -> int:
    a, b = f.get(key, (0, 0))
    if b - a != 4:
        raise NotFast(f"no 4-byte {key.decode()} field")
    return _U32.unpack_from(buf, a)[0]


def _walk(buf, start: int, end: int) -> tuple[dict, dict, int]:
    """The message and connection records of a chunk's data ``buf[start:end]`` up to the first that is not
    complete: ({conn: entries (:data:`_ENTRY`)}, {conn: the connection record's bytes}, where the walk
    stopped)."""
    index: dict = {}
    conns: dict = {}
    pos = start
    while pos < end:
        try:
            f, _, de = _record(buf, pos, end)
            op = _op(buf, f)
            conn = _u32(buf, f, b"conn")
            if op == 0x02:
                a, b = f.get(b"time", (0, 0))
                if b - a != 8:
                    break
                index.setdefault(conn, []).append((*_TIME.unpack_from(buf, a), pos - start))
            elif op == 0x07:
                conns[conn] = bytes(buf[pos:de])
            else:
                break
        except NotFast:
            break
        pos = de
    return {c: np.array(e, dtype=_ENTRY) for c, e in index.items()}, conns, pos


def _index_data(buf, f: dict, ds: int, de: int) -> tuple[int, np.ndarray]:
    """(conn, entries (:data:`_ENTRY`)) of an index data record (version 1: 12 bytes a message)."""
    count = _u32(buf, f, b"count")
    if _u32(buf, f, b"ver") != 1 or de - ds != 12 * count:
        raise NotFast("an index data record of another version or size")
    return _u32(buf, f, b"conn"), np.frombuffer(buf[ds:de], dtype=_ENTRY).copy()


def _record_bytes(fields: list[tuple[bytes, bytes]], data: bytes) -> bytes:
    head = b"".join(_U32.pack(len(k) + 1 + len(v)) + k + b"=" + v for k, v in fields)
    return _U32.pack(len(head)) + head + _U32.pack(len(data)) + data


def _chunks(mm, first: int) -> tuple[list[dict], dict, int, str]:
    """The chunks of a ROS 1 bag from ``first`` on: [{pos, ds, de (data span), kind, end (after its index
    records), index {conn: entries}, open}], the connection records met at the top level, where the readable part
    ends, and what follows it ("" when nothing)."""
    size = len(mm)
    chunks: list[dict] = []
    conns: dict = {}
    pos, why = first, ""
    while pos < size:
        try:
            f, ds, de = record_head(mm, pos, size)
            op = _op(mm, f)
            if de > size and op != 0x05:
                raise NotFast("an unfinished record")
        except NotFast:
            why = "an unfinished record"
            break
        if op == 0x05:
            kind = bytes(mm[slice(*f.get(b"compression", (0, 0)))]).decode("ascii", "replace")
            usize = _u32(mm, f, b"size") if b"size" in f else None
            # still open when the recording stopped (its sizes not written yet), or cut short (a copy that stopped)
            if (de == ds and not usize) or de > size:
                if kind not in ("", "none"):
                    why = f"its unfinished {kind}-compressed last chunk"
                    break
                index, found, stop = _walk(mm, ds, size)
                chunks.append({"pos": pos, "ds": ds, "de": stop, "kind": kind, "end": stop, "index": index,
                               "open": True, "found": found})  # fmt: skip
                pos = stop
                why = "an unfinished record" if stop < size else ""
                break
            chunks.append({"pos": pos, "ds": ds, "de": de, "kind": kind, "end": de, "index": {}, "open": False})
        elif op == 0x04 and chunks:
            try:
                conn, entries = _index_data(mm, f, ds, de)
            except NotFast:
                why = "an index record it cannot read"
                break
            chunks[-1]["index"][conn] = entries
            chunks[-1]["end"] = de
        elif op == 0x07:
            try:
                conns[_u32(mm, f, b"conn")] = bytes(mm[pos:de])
            except NotFast:
                why = "a connection record it cannot read"
                break
        elif op != 0x06:  # chunk infos of a close cut short are written anew
            why = f"a record of op {op:#04x} where chunks were expected"
            break
        _release(mm, pos, de)  # only headers were read: the resident set does not grow with the bag
        pos = de
    return chunks, conns, pos, why


def _read_chunk(mm, c: dict) -> tuple[dict, dict]:
    """The walk (:func:`_walk`) of a whole closed chunk, decompressed if need be."""
    if c["kind"] in ("", "none"):
        buf, start, end = mm, c["ds"], c["de"]
    else:
        buf = _decompress(c["kind"], bytes(mm[c["ds"] : c["de"]]))
        start, end = 0, len(buf)
    index, found, stop = _walk(buf, start, end)
    if stop != end:
        raise NotFast("a chunk whose records do not parse")
    return index, found


def _ros1(mm, out) -> Repair:
    size = len(mm)
    head_end = min(size, _HEAD)
    try:
        f, _, first = _record(mm, len(_ROS1_MAGIC), head_end)
    except NotFast:
        raise NotFast("it ends within its header") from None
    if _op(mm, f) != 0x03:
        raise NotFast("no bag header")
    chunks, conns, stop, why = _chunks(mm, first)
    # the index records of a chunk tell its connections without reading it; a chunk is read where a connection
    # first appears (its connection record is inside), and the last chunk always (its index may be cut short)
    for k, c in enumerate(chunks):
        if c["open"]:
            conns.update(c.pop("found"))
            continue
        if k == len(chunks) - 1 or not c["index"] or set(c["index"]) - set(conns):
            index, found = _read_chunk(mm, c)
            conns.update(found)
            c["index"], c["walked"] = index, True
    for c in chunks:  # messages of a connection whose record is nowhere cannot be decoded
        c["index"] = {conn: e for conn, e in c["index"].items() if conn in conns and e.size}
    chunks = [c for c in chunks if c["index"]]
    if not chunks:
        raise NotFast("it holds no complete chunk")
    out.write(memoryview(mm)[:first])
    infos = []
    for c in chunks:
        at = out.tell()
        if c["open"] or c.get("walked"):
            head = bytearray(mm[c["pos"] : c["ds"]])
            if c["open"]:  # the sizes the writer fills in when the chunk closes
                hf = _fields(head, 4, len(head) - 4)
                head[hf[b"size"][0] : hf[b"size"][1]] = _U32.pack(c["de"] - c["ds"])
                head[-4:] = _U32.pack(c["de"] - c["ds"])
            out.write(head)
            out.write(memoryview(mm)[c["ds"] : c["de"]])
            for conn in sorted(c["index"]):
                e = c["index"][conn]
                fields = [(b"op", b"\x04"), (b"ver", _U32.pack(1)), (b"conn", _U32.pack(conn)),
                          (b"count", _U32.pack(len(e)))]  # fmt: skip
                out.write(_record_bytes(fields, e.tobytes()))
        else:
            out.write(memoryview(mm)[c["pos"] : c["end"]])
        _release(mm, c["pos"], c["end"])
        infos.append((at, c["index"]))
    index_pos = out.tell()
    for conn in sorted(conns):
        out.write(conns[conn])
    for at, index in infos:
        e = np.concatenate(list(index.values()))
        ns = e["sec"].astype(np.uint64) * np.uint64(10**9) + e["nsec"]
        t0, t1 = e[int(np.argmin(ns))], e[int(np.argmax(ns))]
        fields = [
            (b"op", b"\x06"),
            (b"ver", _U32.pack(1)),
            (b"chunk_pos", _U64.pack(at)),
            (b"start_time", _TIME.pack(int(t0["sec"]), int(t0["nsec"]))),
            (b"end_time", _TIME.pack(int(t1["sec"]), int(t1["nsec"]))),
            (b"count", _U32.pack(len(index))),
        ]
        out.write(_record_bytes(fields, b"".join(struct.pack("<II", c, len(e)) for c, e in sorted(index.items()))))
    for key, value in ((b"index_pos", _U64.pack(index_pos)), (b"conn_count", _U32.pack(len(conns))),
                       (b"chunk_count", _U32.pack(len(infos)))):  # fmt: skip
        if key in f and f[key][1] - f[key][0] == len(value):
            out.seek(f[key][0])
            out.write(value)
    recovered = sum(e.size for c in chunks if c["open"] for e in c["index"].values())
    whole = sum(not c["open"] for c in chunks)
    return Repair("ros1", whole, recovered, size - stop, why)


# --- MCAP -----------------------------------------------------------------------------------------------------


def _mcap_scan(mm) -> tuple[list[dict], dict, int, str]:
    """The complete top-level records of an MCAP data section: its chunks, [{pos, end (of the Chunk record), kind
    (compression), data (the span of its records, compressed or not), usize (uncompressed size), span (message
    start and end times), index {channel: offset of its Message Index record}, index_len (bytes of those),
    counts {channel: messages}}], the Schema and Channel records outside chunks ({(op, id): record bytes}), where
    the complete records end, and what follows ("" when nothing)."""
    size = len(mm)
    pos, chunks, top, why = len(_MCAP_MAGIC), [], {}, ""
    while pos < size:
        if pos + 9 > size:
            why = "an unfinished record"
            break
        op, n = mm[pos], _U64.unpack_from(mm, pos + 1)[0]
        if op in (0x0F, 0x02):  # Data End or Footer: the data section ends here
            why = "a summary cut short"
            break
        end = pos + 9 + n
        if end > size:
            why = "an unfinished chunk" if op == 0x06 else "an unfinished record"
            break
        if op == 0x06:
            try:
                kind, data, usize, _, span = _mcap_head(mm, pos + 9, n)
            except NotFast:
                why = "a chunk it cannot read"
                break
            if not isinstance(data, tuple):  # compressed: the records' span, not a copy of them
                data = (end - len(data), end)
            chunks.append({"pos": pos, "end": end, "kind": kind, "data": data, "usize": usize, "span": span,
                           "index": {}, "index_len": 0, "counts": {}})  # fmt: skip
        elif op == 0x07 and chunks and chunks[-1]["end"] + chunks[-1]["index_len"] == pos:
            c = chunks[-1]
            chan = _U16.unpack_from(mm, pos + 9)[0]
            c["index"][chan] = pos
            c["counts"][chan] = _U32.unpack_from(mm, pos + 11)[0] // 16
            c["index_len"] += end - pos
        elif op in (0x03, 0x04):
            top[(op, _U16.unpack_from(mm, pos + 9)[0])] = bytes(mm[pos:end])
        _release(mm, pos, end)
        pos = end
    return chunks, top, pos, why


def _inner(mm, c: dict, wanted: set) -> dict:
    """The Schema and Channel records inside the chunk ``c`` ({(op, id): record bytes}) of those ``wanted``."""
    if c["kind"] in ("", "none"):
        buf, pos, end = mm, *c["data"]
    else:
        buf = _decompress(c["kind"], bytes(mm[slice(*c["data"])]))
        pos, end = 0, len(buf)
    found = {}
    while pos + 9 <= end:
        op, n = buf[pos], _U64.unpack_from(buf, pos + 1)[0]
        if pos + 9 + n > end:
            break
        if op in (0x03, 0x04) and (op, _U16.unpack_from(buf, pos + 9)[0]) in wanted:
            found[(op, _U16.unpack_from(buf, pos + 9)[0])] = bytes(buf[pos : pos + 9 + n])
        pos += 9 + n
    return found


def _summary(mm, chunks: list[dict], top: dict) -> bytes | None:
    """The summary section of the complete chunks — their Schema and Channel records, a Chunk Index per chunk and
    the Statistics — or None where a chunk has no Message Index records or a channel's records are nowhere (the
    file is then closed without one)."""
    if not chunks or any(not c["index"] for c in chunks):
        return None
    have = dict(top)
    channels = set()
    for c in chunks:
        new = {(0x04, ch) for ch in c["index"]} - set(have)
        if new:
            have.update(_inner(mm, c, new))
            schemas = {(0x03, _U16.unpack_from(have[k], 11)[0]) for k in new if k in have}
            have.update(_inner(mm, c, schemas - set(have)))
        channels |= set(c["index"])
    if any((0x04, ch) not in have for ch in channels):
        return None
    schemas = {_U16.unpack_from(have[(0x04, ch)], 11)[0] for ch in channels} - {0}
    if any((0x03, sid) not in have for sid in schemas):
        return None

    def string(text: bytes) -> bytes:
        return _U32.pack(len(text)) + text

    def record(op: int, body: bytes) -> bytes:
        return bytes([op]) + _U64.pack(len(body)) + body

    out = [have[(0x03, sid)] for sid in sorted(schemas)] + [have[(0x04, ch)] for ch in sorted(channels)]
    for c in chunks:
        offsets = b"".join(_U16.pack(ch) + _U64.pack(off) for ch, off in sorted(c["index"].items()))
        stored = c["data"][1] - c["data"][0]
        body = (struct.pack("<QQQQ", *c["span"], c["pos"], c["end"] - c["pos"]) + _U32.pack(len(offsets)) + offsets
                + _U64.pack(c["index_len"]) + string(c["kind"].encode()) + struct.pack("<QQ", stored, c["usize"]))  # fmt: skip
        out.append(record(0x08, body))
    counts: dict = {}
    for c in chunks:
        for ch, k in c["index"].items():
            counts[ch] = counts.get(ch, 0) + c["counts"][ch]
    per = b"".join(_U16.pack(ch) + _U64.pack(k) for ch, k in sorted(counts.items()))
    stats = (_U64.pack(sum(counts.values())) + _U16.pack(len(schemas)) + struct.pack("<IIII", len(channels), 0, 0,
             len(chunks)) + struct.pack("<QQ", min(c["span"][0] for c in chunks), max(c["span"][1] for c in chunks))
             + _U32.pack(len(per)) + per)  # fmt: skip
    out.append(record(0x0B, stats))
    return b"".join(out)


def _mcap(mm, out) -> Repair:
    chunks, top, keep, why = _mcap_scan(mm)
    if not chunks:
        raise NotFast("it holds no complete chunk")
    summary = _summary(mm, chunks, top)
    for a in range(0, keep, _PIECE):
        out.write(memoryview(mm)[a : min(keep, a + _PIECE)])
        _release(mm, a, a + _PIECE)
    out.write(bytes([0x0F]) + _U64.pack(4) + _U32.pack(0))  # Data End, no CRC
    start = out.tell() if summary else 0
    if summary:
        out.write(summary)
    out.write(bytes([0x02]) + _U64.pack(20) + struct.pack("<QQI", start, 0, 0))  # Footer: no summary offsets
    out.write(_MCAP_MAGIC)
    return Repair("mcap", len(chunks), 0, len(mm) - keep, why)
