"""Test helper: a copy of a CSV log with some columns clipped, as a sensor at the end of its range writes them."""

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
