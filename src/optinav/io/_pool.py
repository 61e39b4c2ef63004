"""The readers' helper threads: one per CPU the process may run on, at most 4, created on first use.

The compiled kernels they run release the GIL (numba ``nogil``; the codecs' decompressors), so a reader can hand
half of its work to one. None on a single CPU: the caller then does the work in turn.
"""

from __future__ import annotations

import os

_POOL: list = []
#: the number of helper threads (0 until the pool exists)
WORKERS = [0]


def helper():
    """The shared ThreadPoolExecutor, or None when the process may run on one CPU only."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    if cpus < 2:
        return None
    if not _POOL:
        from concurrent.futures import ThreadPoolExecutor

        WORKERS[0] = min(cpus, 4)
        _POOL.append(ThreadPoolExecutor(max_workers=WORKERS[0], thread_name_prefix="optinav-io"))
    return _POOL[0]
