"""Large JSON files whose bulk is a few long numeric arrays (a simulated truth's per-sample series) read without
holding them: :func:`skeleton` parses the file with its long arrays at one nesting depth replaced by markers,
and :class:`ArrayRows` reads one such array's elements block by block. Memory stays at a few MB per block
whatever the arrays' length; the structure (strings, escapes, nesting) is found with vectorized scans.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["skeleton", "ArrayRows", "Region"]

_BLOCK = 1 << 23  #: bytes scanned at a time
_OPEN = {ord("["): 1, ord("{"): 1, ord("]"): -1, ord("}"): -1}


@dataclasses.dataclass
class Region:
    """An array cut out of the file: bytes ``start`` (its ``[``) to ``end`` (its ``]``, inclusive)."""

    start: int
    end: int

    @property
    def marker(self) -> str:
        return f"@@array:{self.start}@@"


def _strings(buf: np.ndarray, in_str: bool, escaped: bool) -> tuple[np.ndarray, bool, bool]:
    """The mask of bytes of ``buf`` inside JSON strings (quotes included), the string state carried across
    blocks: a loop over the quotes and backslashes only (none inside numeric arrays)."""
    marks = np.flatnonzero((buf == ord('"')) | (buf == ord("\\")))
    toggles = []  # byte index where a string starts (even entries) or ends (odd entries)
    if in_str:
        toggles.append(0)
    skip = 0 if escaped else -1  # the byte a backslash escapes
    for i in marks.tolist():
        if i == skip:
            continue
        if buf[i] == ord("\\"):
            if in_str:
                skip = i + 1
            continue
        in_str = not in_str
        toggles.append(i if in_str else i + 1)
    escaped = skip == buf.size
    if len(toggles) % 2:
        toggles.append(buf.size)
    edges = np.zeros(buf.size + 1, np.int8)
    t = np.asarray(toggles, np.int64).reshape(-1, 2)
    np.add.at(edges, t[:, 0], 1)
    np.add.at(edges, t[:, 1], -1)
    return np.cumsum(edges[:-1]) > 0, in_str, escaped


def skeleton(path, *, depth: int, min_bytes: int = 1 << 16, what: str = "JSON file", remedy: str = "") -> tuple:
    """(parsed value, {marker: Region}) of the JSON file ``path`` with every array of at least ``min_bytes``
    bytes that opens at nesting ``depth`` (1: inside the top-level value) replaced by the string marker
    :attr:`Region.marker`; one-line errors naming ``what``.

    Parameters
    ----------
    path : str or Path
        The file.
    depth : int
        Nesting depth of the arrays to cut (the ``[`` takes the depth from ``depth - 1`` to ``depth``).
    min_bytes : int
        Shorter arrays stay in place.
    what, remedy : str
        For the error messages.

    Returns
    -------
    tuple
        (the parsed value with markers for the cut arrays, {marker: Region}).
    """
    from optinav.core.files import parse_json

    path = Path(path)
    regions, keep = [], []
    level, in_str, escaped, start, pos = 0, False, False, None, 0
    try:
        with open(path, "rb") as fh:
            while chunk := fh.read(_BLOCK):
                buf = np.frombuffer(chunk, np.uint8)
                mask, in_str, escaped = _strings(buf, in_str, escaped)
                idx = np.flatnonzero(np.isin(buf, (91, 93, 123, 125)) & ~mask)
                delta = np.where((buf[idx] == 91) | (buf[idx] == 123), 1, -1)
                after = level + np.cumsum(delta)
                opens = idx[(buf[idx] == 91) & (after == depth)]
                closes = idx[(buf[idx] == 93) & (after == depth - 1)]
                events = sorted([(int(i), 1) for i in opens] + [(int(i), -1) for i in closes])
                for i, kind in events:
                    if kind == 1:
                        start = pos + i
                    elif start is not None:
                        regions.append(Region(start, pos + i))
                        start = None
                level = int(after[-1]) if after.size else level
                pos += buf.size
    except OSError as exc:
        raise OptinavError(
            f"cannot read {what} {path} ({exc.strerror})", "check the file and its permissions"
        ) from None
    big = [r for r in regions if r.end - r.start + 1 >= min_bytes]
    # the text without the long arrays (their markers instead), parsed as usual
    with open(path, "rb") as fh:
        at = 0
        for r in big:
            keep.append(fh.read(r.start - at))
            keep.append(json.dumps(r.marker).encode())
            fh.seek(r.end + 1)
            at = r.end + 1
        keep.append(fh.read())
    try:
        text = b"".join(keep).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise OptinavError(f"{what} {path} is not UTF-8 text (byte {exc.start})", remedy or "pass the file") from None
    return parse_json(text, f"{what} {path}", remedy), {r.marker: r for r in big}


class ArrayRows:
    """The elements of one array of a JSON file (a :class:`Region`), read in order a block at a time: numbers,
    ``null`` as NaN, each element a number or a fixed-shape nested list (the first element's shape)."""

    def __init__(self, path, region: Region, what: str = "JSON array"):
        self.path, self.region, self.what = Path(path), region, what
        self.fh = open(self.path, "rb")
        self.fh.seek(region.start + 1)
        self.left = region.end - region.start - 1  # bytes between the brackets not read yet
        self.text = b""  # bytes read, not yet parsed
        self.shape: tuple[int, ...] | None = None
        self.buf = None  # parsed elements not yet taken
        self.rows = 0  # elements taken

    def _more(self) -> bool:
        """Parse the next block of elements into ``buf``; False at the end of the array."""
        while True:
            if self.left:
                got = self.fh.read(min(_BLOCK, self.left))
                self.left -= len(got)
                self.text += got
                if not got:
                    raise OptinavError(f"{self.what} in {self.path} ends early", "pass an unmodified file")
            cut = self._boundary(self.text) if self.left else len(self.text)
            if cut or not self.left:
                break
        body, self.text = self.text[:cut], self.text[cut + 1 :] if self.left else b""
        if not body.strip():
            return False
        if self.shape is None:
            commas = self._commas(body)
            first = body[: int(commas[0])] if commas.size else body
            try:
                self.shape = np.shape(json.loads(first.replace(b"null", b"0").decode()))
            except ValueError:
                raise OptinavError(
                    f"{self.what} in {self.path} is not a numeric array", "pass an unmodified file"
                ) from None
        flat = body.translate(None, b"[]\n\r\t ").replace(b"null", b"nan").split(b",")
        try:
            vals = np.array(flat).astype(float)
        except ValueError:
            raise OptinavError(
                f"{self.what} in {self.path} holds something other than numbers", "pass an unmodified file"
            ) from None
        width = int(np.prod(self.shape, dtype=np.int64))
        elements = self._commas(body).size + 1
        brackets = sum(int(np.prod(self.shape[:k], dtype=np.int64)) for k in range(len(self.shape)))
        if vals.size != elements * width or body.count(b"[") != elements * brackets:
            raise OptinavError(
                f"{self.what} in {self.path} has elements of different shapes", "pass an unmodified file"
            )
        vals = vals.reshape((-1, *self.shape))
        self.buf = vals if self.buf is None or not len(self.buf) else np.concatenate([self.buf, vals])
        return True

    @staticmethod
    def _commas(text: bytes) -> np.ndarray:
        """Indices of the commas between top-level elements in ``text``."""
        buf = np.frombuffer(text, np.uint8)
        idx = np.flatnonzero((buf == 44) | (buf == 91) | (buf == 93))
        level = np.cumsum(np.where(buf[idx] == 91, 1, np.where(buf[idx] == 93, -1, 0)))
        return idx[(buf[idx] == 44) & (level == 0)]

    @classmethod
    def _boundary(cls, text: bytes) -> int:
        """Index of the last comma between two top-level elements in ``text`` (0: none yet)."""
        top = cls._commas(text)
        return int(top[-1]) if top.size else 0

    def take(self, n: int) -> np.ndarray:
        """The next elements.

        Parameters
        ----------
        n : int
            How many (fewer at the end of the array).

        Returns
        -------
        ndarray
            (k, *shape), k ≤ n [the values as written].
        """
        while (self.buf is None or len(self.buf) < n) and (self.left or self.text):
            if not self._more():
                break
        buf = self.buf if self.buf is not None else np.empty((0,))
        out, self.buf = buf[:n], buf[n:]
        self.rows += len(out)
        return out

    def count_rest(self) -> int:
        """The number of elements not taken yet (reads them).

        Returns
        -------
        int
            The elements left.
        """
        k = 0
        while True:
            got = self.take(1 << 20)
            if not len(got):
                return k
            k += len(got)

    def close(self) -> None:
        """Close the file."""
        self.fh.close()
