"""The ``optinav`` command: one argparse parser, subcommands registered by their modules.

Each command module defines ``register(subparsers)`` that adds its parser and sets ``func`` to a callable
``func(args) -> int``; a system's own top-level commands (``attitude``, ``gfimu analyze``) come from the
``register_commands(subparsers)`` hook of its CLI module in :mod:`optinav.registry`, and its ``simulate``,
``calibrate`` and ``batch`` entries from the other hooks there. Errors: an :class:`OptinavError` prints
``optinav: error: <cause; remedy>`` and exits 2; any other exception prints a one-line internal error and exits
1; ``--debug`` shows the traceback instead. A failure to write standard output (a full disk, ``>/dev/full``, a
closed stdout ``>&-``) is such a one-line error too, exit 2; a reader that went away (``| head``) ends quietly.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import errno
import functools
import io
import os
import sys
import textwrap
import warnings

from optinav import __version__
from optinav.cli.common import cli_wording
from optinav.errors import OptinavError, message_kind

#: stands in :data:`COMMANDS` for the systems' own top-level commands (``attitude``, ``gfimu``): the
#: ``register_commands(subparsers)`` hook of each system's CLI module in :mod:`optinav.registry`
SYSTEM_COMMANDS = "(the systems' own commands)"

#: every command of ``optinav`` in the order ``--help`` lists them, declared once: a module defining
#: ``register(subparsers)``, or :data:`SYSTEM_COMMANDS`. The ``simulate``, ``calibrate`` and ``batch`` commands
#: take their per-system entries from the registry themselves.
COMMANDS = (
    "optinav.cli.simulate",
    "optinav.cli.calibrate",
    "optinav.cli.apply",
    SYSTEM_COMMANDS,
    "optinav.cli.sun",
    "optinav.cli.reproduce",
    "optinav.cli.batch",
    "optinav.cli.allan",
    "optinav.cli.export",
    "optinav.cli.design",
    "optinav.cli.report",
)


class OneLineParser(argparse.ArgumentParser):
    """argparse with one-line errors (``optinav COMMAND: error: ...; see --help``) instead of usage + error;
    subcommand parsers inherit the class."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}; see {self.prog} --help\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="optinav",
        description="Inertial sensor calibration and attitude estimation posed as optimization problems.",
        epilog=textwrap.dedent("""\
            examples:
              optinav reproduce --quick           reproduce the studies quickly into ./optinav-report
              optinav reproduce core --out rep    one study into ./rep
              optinav COMMAND --help              help and a worked example for a command
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"optinav {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    import importlib

    from optinav.cli.common import register_system_hooks

    for name in COMMANDS:
        if name == SYSTEM_COMMANDS:
            register_system_hooks(sub, "register_commands")
        else:
            importlib.import_module(name).register(sub)
    return parser


def _parser() -> argparse.ArgumentParser:
    """The parser of :func:`main`, built again only when the registered systems changed (their commands and
    options are in it): argparse takes 20-35 ms to build its 370 options (a formatter and gettext look-ups per
    option), which a process calling main() many times paid on each call."""
    from optinav import registry

    return _parser_of(tuple(registry.systems()))


@functools.lru_cache(maxsize=1)
def _parser_of(systems: tuple) -> argparse.ArgumentParser:
    return build_parser()


def _own_defaults(args: argparse.Namespace) -> argparse.Namespace:
    """``args`` with copies of its lists, dicts and sets: a default one is the parser's object, kept for the next
    call, which a command that changes it must not see."""
    for key, value in vars(args).items():
        if isinstance(value, (list, dict, set)):
            setattr(args, key, copy.deepcopy(value))
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if sys.stderr is None:
        # a closed stderr (``2>&-``): messages go to the null device, not into stdout (where print(file=None)
        # wrote them) nor into the first file the command opens (fd 2), and not an AttributeError (isatty)
        _reserve_fd(2)
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - for the life of the process
    parser = _parser()
    args = _own_defaults(parser.parse_args(argv))
    if args.command is None:
        parser.print_help()
        return 2
    from optinav.core.progress import quiet

    stdout = sys.stdout
    sys.stdout = _Stdout(stdout)
    try:
        with quiet(args.quiet):
            return _dispatch(args)
    finally:
        sys.stdout = stdout


def _dispatch(args) -> int:
    from optinav.core.files import protect_inputs
    from optinav.core.progress import compile_note, task

    from optinav.cli.common import forget_said

    # commands that take seconds name a task; their steps (core.progress.step) advance its bar on a terminal
    label = getattr(args, "progress_task", None)
    forget_said()
    try:
        with (
            protect_inputs(_input_paths(args)),
            warnings.catch_warnings(),
            task(label) if label else contextlib.nullcontext(),
            compile_note(),
        ):
            warnings.showwarning = _one_line_warning
            code = int(args.func(args) or 0)
            # what is still buffered is written here, where a failure is reported, not at the interpreter's exit
            sys.stdout.flush()
            return code
    except OptinavError as exc:
        if args.debug:
            raise
        print(f"optinav: error: {cli_wording(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("optinav: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of our stdout went away (``optinav sun ... | head``): not an error of ours
        _drop(sys.stdout)
        return 0
    except Exception as exc:  # noqa: BLE001 - last resort: one line unless --debug
        if args.debug:
            raise
        msg = " ".join(str(exc).split()) or type(exc).__name__
        print(
            f"optinav: internal error: {type(exc).__name__}: {msg} (run with --debug for the traceback "
            "and please report it)",
            file=sys.stderr,
        )
        return 1


class _Stdout:
    """Standard output whose write failures are a one-line :class:`OptinavError` (``cannot write to standard
    output: no space left on the device``) instead of an OSError any command could meet in any ``print``; a
    closed stdout (``>&-``: Python's ``sys.stdout`` is None) fails at the first write instead of dropping it."""

    def __init__(self, stream):
        self._closed = stream is None
        if self._closed:
            _reserve_fd(1)
        self._stream = io.StringIO() if self._closed else stream

    def _fail(self, exc: OSError | None) -> OptinavError:
        from optinav.core.files import describe

        _drop(self._stream)
        if exc is None or exc.errno == errno.EBADF:
            return OptinavError(
                "cannot write to standard output: it is closed", "give the command one (a file, a pipe or /dev/null)"
            )
        return OptinavError(
            f"cannot write to standard output: {describe(exc)}", "redirect it to a file on a disk with free space"
        )

    def write(self, text: str) -> int:
        if self._closed:
            raise self._fail(None)
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise self._fail(exc) from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise self._fail(exc) from None

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _reserve_fd(fd: int) -> None:
    """Give a closed file descriptor (1 or 2) to the null device, so no file the command opens takes it (and
    worker processes writing to it do not write into that file)."""
    try:
        os.fstat(fd)
    except OSError:
        _to_null(fd)


def _drop(stream) -> None:
    """Point ``stream``'s file descriptor at the null device, so what is still buffered for it is discarded at exit
    instead of failing again (Python's "Exception ignored ..." and exit 120); a stream without one is left alone."""
    try:
        fd = stream.fileno()
    except (AttributeError, ValueError, OSError):
        return
    _to_null(fd)


def _to_null(fd: int) -> None:
    """Point the file descriptor ``fd`` at the null device (a closed one gets it as the lowest free)."""
    with contextlib.suppress(OSError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        if devnull != fd:
            os.dup2(devnull, fd)
            os.close(devnull)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """CLI users get a warning as one line like the errors, not Python's file:line and source echo; a
    :class:`optinav.errors.Note` as a note."""
    from optinav.cli.common import say

    say(message_kind(category), str(message))


#: options that name what a command writes, never what it reads
_OUTPUT_OPTIONS = {"out", "report", "truth_out", "kalibr", "gyro_out", "export"}


def _input_paths(args) -> list[str]:
    """Every string option or argument of ``args`` that names an existing file: the command's inputs, which no
    output may overwrite (see :mod:`optinav.core.files`)."""
    found = []
    for name, value in vars(args).items():
        if name in _OUTPUT_OPTIONS:
            continue
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(v, str) and v and os.path.isfile(v):
                found.append(v)
            elif isinstance(v, str) and v and os.path.isdir(v):  # a phone export's folder: the files read from it
                from optinav.io.phone import phone_export

                export = phone_export(v)
                if export is not None:
                    found += [str(export.path / m) for m in (export.acc, export.gyro, export.mag) if m]
    return found


if __name__ == "__main__":
    sys.exit(main())
