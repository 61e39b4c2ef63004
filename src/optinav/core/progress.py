"""Progress display for long work: a one-line meter on stderr, silent when not wanted.

``progress(iterable, total=None, desc="", enabled=None)`` yields the items; ``enabled=None`` shows the
meter only when stderr is a terminal and ``OPTINAV_QUIET`` is unset (the CLI's ``--quiet`` sets it).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress_enabled() -> bool:
    """Whether progress output is wanted by default."""
    return not os.environ.get("OPTINAV_QUIET") and sys.stderr.isatty()


def progress(iterable: Iterable[T], total: int | None = None, desc: str = "",
             enabled: bool | None = None, min_interval: float = 0.2) -> Iterator[T]:
    """Iterate over ``iterable`` while printing ``desc  k/total  pct  elapsed  eta`` to stderr."""
    show = progress_enabled() if enabled is None else enabled
    if total is None:
        try:
            total = len(iterable)  # type: ignore[arg-type]
        except TypeError:
            total = None
    if not show:
        yield from iterable
        return
    start = last = time.perf_counter()
    k = 0
    for k, item in enumerate(iterable, 1):
        yield item
        now = time.perf_counter()
        if now - last >= min_interval or (total is not None and k == total):
            last = now
            _draw(desc, k, total, now - start)
    sys.stderr.write("\n")
    sys.stderr.flush()


def _draw(desc: str, k: int, total: int | None, elapsed: float) -> None:
    if total:
        frac = k / total
        eta = elapsed / frac - elapsed if frac > 0 else 0.0
        bar = "#" * int(20 * frac)
        line = f"\r{desc} [{bar:<20}] {k}/{total} {100 * frac:5.1f}% {elapsed:6.1f}s eta {eta:6.1f}s"
    else:
        line = f"\r{desc} {k} {elapsed:6.1f}s"
    sys.stderr.write(line)
    sys.stderr.flush()
