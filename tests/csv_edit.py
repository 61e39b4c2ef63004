"""Test helpers: a copy of a CSV log with some columns clipped, as a sensor at the end of its range writes them, or
with a column drifting, as a sensor warming up does."""

from pathlib import Path

import numpy as np


def clip_columns(src: Path, dst: Path, names: tuple[str, ...], limit: float) -> Path:
    """Write ``src`` to ``dst`` with the columns ``names`` clipped to ±``limit`` (their header is the first line
    that is no '#' comment: optinav's comment lines before it are kept)."""
    lines = Path(src).read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if ln and not ln.startswith("#"))
    cols = [c.strip() for c in lines[head].split(",")]
    idx = [cols.index(c) for c in names]
    out = lines[: head + 1]
    for ln in lines[head + 1 :]:
        v = ln.split(",")
        for j in idx:
            v[j] = repr(float(np.clip(float(v[j]), -limit, limit)))
        out.append(",".join(v))
    Path(dst).write_text("\n".join(out) + "\n")
    return Path(dst)


def drift_column(src: Path, dst: Path, name: str, drift: float) -> Path:
    """Write the CSV log ``src`` (a header line, then rows) to ``dst`` with ``drift`` (the column's unit) added to
    the column ``name`` linearly from 0 at the first row to ``drift`` at the last."""
    head, *rows = Path(src).read_text().splitlines()
    c = head.split(",").index(name)
    out = [head]
    for i, row in enumerate(rows):
        v = row.split(",")
        v[c] = repr(float(v[c]) + drift * i / (len(rows) - 1))
        out.append(",".join(v))
    Path(dst).write_text("\n".join(out) + "\n")
    return Path(dst)


def add_to_rows(src: Path, dst: Path, name: str, rows: range, delta: float) -> Path:
    """Write the CSV log ``src`` (a header line, then rows) to ``dst`` with ``delta`` added to the column ``name`` in
    the data rows ``rows`` (0: the first row after the header): a spike, or a dropout when it cancels the value."""
    head, *lines = Path(src).read_text().splitlines()
    c = head.split(",").index(name)
    for i in rows:
        v = lines[i].split(",")
        v[c] = repr(float(v[c]) + delta)
        lines[i] = ",".join(v)
    Path(dst).write_text("\n".join([head, *lines]) + "\n")
    return Path(dst)
