"""Progress display for long work (tqdm bars on stderr), silent when not wanted.

``progress(iterable, total=None, desc="", enabled=None)`` yields the items behind a bar; ``enabled=None``
shows it only when stderr is a terminal and output is not silenced: inside ``with quiet():`` (the CLI's
``--quiet``) or with the environment variable ``OPTINAV_QUIET`` set (e.g. for a whole benchmark run).
``task(desc)`` opens a bar for a job made of named steps (``optinav reproduce`` opens one per study) and
``step(label)`` advances the innermost open task, so a study reports its steps without knowing who shows them.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar


T = TypeVar("T")

_TASKS: list = []  # open task bars, innermost last
_LOOPS: list = []  # open loop bars of progress()


_QUIET: list[bool] = [False]  # the innermost quiet() setting, last


@contextlib.contextmanager
def quiet(enabled: bool = True):
    """No progress output (and no log lines of :func:`is_quiet` callers) inside the block when ``enabled``; the
    previous setting is restored after it, so one CLI call does not silence the next.

    Parameters
    ----------
    enabled : bool
        Silence output inside the block.

    Yields
    ------
    None
    """
    _QUIET.append(bool(enabled))
    try:
        yield
    finally:
        _QUIET.pop()


def is_quiet() -> bool:
    """Whether progress and log output is silenced: :func:`quiet` or the ``OPTINAV_QUIET`` environment variable.

    Returns
    -------
    bool
        True when silenced.
    """
    return _QUIET[-1] or bool(os.environ.get("OPTINAV_QUIET"))


def tqdm(*args, **kwargs):
    """tqdm's bar, imported on first use (tqdm.auto costs a fifth of a second at start-up, before a command can
    report a bad input file).

    Parameters
    ----------
    *args, **kwargs
        What ``tqdm.auto.tqdm`` takes.

    Returns
    -------
    tqdm.auto.tqdm
        The bar.
    """
    from tqdm.auto import tqdm as bar

    return bar(*args, **kwargs)


def progress_enabled() -> bool:
    """Whether progress output is wanted by default (stderr is a terminal and output is not silenced).

    Returns
    -------
    bool
        True to show bars.
    """
    return not is_quiet() and sys.stderr.isatty()


def progress(
    iterable: Iterable[T],
    total: int | None = None,
    desc: str = "",
    enabled: bool | None = None,
    min_interval: float = 0.2,
) -> Iterator[T]:
    """Iterate over ``iterable`` behind a progress bar (``desc  k/total  elapsed  eta``) on stderr.

    Parameters
    ----------
    iterable : iterable
        The items.
    total : int or None
        Their number, when ``len`` does not tell.
    desc : str
        Label.
    enabled : bool or None
        Show the bar; None: :func:`progress_enabled`.
    min_interval : float
        Shortest time between redraws [s].

    Yields
    ------
    object
        The items of ``iterable``.
    """
    show = progress_enabled() if enabled is None else enabled
    if not show:
        yield from iterable
        return
    # nested under an open task: the bar goes below it and disappears when done
    with tqdm(
        iterable,
        total=total,
        desc=desc,
        file=sys.stderr,
        mininterval=min_interval,
        dynamic_ncols=True,
        leave=not _TASKS,
        position=len(_TASKS) or None,
    ) as bar:
        _LOOPS.append(bar)
        try:
            yield from bar
        finally:
            _LOOPS.remove(bar)


@contextlib.contextmanager
def task(desc: str, total: int | None = None, enabled: bool | None = None):
    """A bar for one job of named steps; ``step(label)`` inside advances it (see the module docstring).

    Parameters
    ----------
    desc : str
        Label.
    total : int or None
        Number of steps, if known.
    enabled : bool or None
        Show the bar; None: :func:`progress_enabled`.

    Yields
    ------
    tqdm
        The bar.
    """
    show = progress_enabled() if enabled is None else enabled
    bar = tqdm(
        total=total,
        desc=desc,
        file=sys.stderr,
        disable=not show,
        dynamic_ncols=True,
        bar_format="{desc}: {n_fmt} steps, {elapsed}{postfix}" if total is None else None,
    )
    _TASKS.append(bar)
    try:
        yield bar
    finally:
        _TASKS.remove(bar)
        bar.close()


def progress_blocks(blocks, desc: str = "", enabled: bool | None = None) -> Iterator:
    """Iterate over the blocks of a streamed file behind a bar of the bytes read (``desc  MB/MB  elapsed  eta``).

    Parameters
    ----------
    blocks : iterable
        With ``size`` and ``position`` in bytes, such as :func:`optinav.io.iter_imu`.
    desc : str
        Label.
    enabled : bool or None
        Show the bar; None: :func:`progress_enabled`.

    Yields
    ------
    object
        The blocks.
    """
    show = progress_enabled() if enabled is None else enabled
    if not show:
        yield from blocks
        return
    with tqdm(
        total=blocks.size,
        desc=desc,
        file=sys.stderr,
        unit="B",
        unit_scale=True,
        dynamic_ncols=True,
        leave=not _TASKS,
        position=len(_TASKS) or None,
        mininterval=0.2,
    ) as bar:
        _LOOPS.append(bar)
        try:
            for block in blocks:
                bar.update(blocks.position - bar.n)
                yield block
        finally:
            _LOOPS.remove(bar)


def in_task() -> bool:
    """Whether a task is open and no loop bar runs inside it: library loops (GA/PSO generations) show a bar only then,
    i.e. from the CLI and not once per run of an outer loop.

    Returns
    -------
    bool
        True inside a task without a loop bar.
    """
    return bool(_TASKS) and not _LOOPS


def step(label: str) -> None:
    """Mark the start of step ``label`` of the innermost open task (no-op outside a task).

    Parameters
    ----------
    label : str
        The step's name.
    """
    if _TASKS:
        bar = _TASKS[-1]
        bar.set_postfix_str(label, refresh=False)
        bar.update(1)


#: what :func:`compile_note` says
COMPILE_NOTE = (
    "optinav: compiling the numerical kernels (once after installing or upgrading; later runs load them from "
    "numba's cache) ..."
)


@contextlib.contextmanager
def compile_note(after_s: float = 1.5, enabled: bool | None = None, stream=None):
    """Say once, on stderr, when numba compiles for longer than ``after_s`` s inside the block: the first run after
    installing compiles the kernels (the attitude filter's 15-20 s), and a command silent that long looks hung.
    numba is not imported for it (a bad input file is reported before numba loads): a watcher thread registers a
    listener on numba's compile events (``numba.core.event``) once something else has imported numba.

    Parameters
    ----------
    after_s : float
        Compile time [s] before the note.
    enabled : bool or None
        Watch; None: :func:`progress_enabled` (a terminal, not silenced).
    stream : file or None
        Where the note goes (None: stderr, above any open bar).

    Yields
    ------
    None
    """
    show = progress_enabled() if enabled is None else enabled
    if not show:
        yield
        return
    state = {"since": None, "depth": 0, "said": False}
    stop = threading.Event()
    hooked = []

    def on_start(_event):
        if state["depth"] == 0:
            state["since"] = time.monotonic()
        state["depth"] += 1

    def on_end(_event):
        state["depth"] = max(state["depth"] - 1, 0)
        if state["depth"] == 0:
            state["since"] = None

    def say():
        if stream is None and (_TASKS or _LOOPS):
            from tqdm.auto import tqdm as bars

            bars.write(COMPILE_NOTE, file=sys.stderr)  # above the open bars
        else:
            print(COMPILE_NOTE, file=sys.stderr if stream is None else stream, flush=True)
        state["said"] = True

    def hook() -> bool:
        ev = sys.modules.get("numba.core.event")
        if ev is None or not all(hasattr(ev, k) for k in ("Listener", "register", "unregister")):
            return False  # numba not (yet wholly) imported
        methods = {"on_start": staticmethod(on_start), "on_end": staticmethod(on_end)}
        listener = type("_CompileWatch", (ev.Listener,), methods)()
        ev.register("numba:compile", listener)
        hooked.append((ev, listener))
        return True

    def watch():
        while not state["said"] and not stop.wait(min(0.05, max(after_s / 4, 0.005))):
            if not hooked and not hook():
                continue
            since = state["since"]
            if since is not None and time.monotonic() - since >= after_s:
                say()

    hook()  # at once where numba is loaded already; else the watcher, as soon as it is (before its first compile)
    thread = threading.Thread(target=watch, name="optinav-compile-note", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        for ev, listener in hooked:
            ev.unregister("numba:compile", listener)
