"""Options shared by the data-reading commands (one spelling everywhere)."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

from optinav.errors import OptinavError


def shared_data_dir() -> Path:
    """The shared data folder: ``$OPTINAV_SHARED_DATA`` if set, else ``../shared/data`` relative to the project
    root (the folder holding ``src/optinav``; a source tree or an editable install)."""
    import os

    env = os.environ.get("OPTINAV_SHARED_DATA")
    if env:
        return Path(env)
    import optinav

    return (Path(optinav.__file__).resolve().parents[2] / ".." / "shared" / "data").resolve()


def register_system_hooks(kinds, hook: str) -> None:
    """Call ``hook`` (``register_simulate``/``register_calibrate``/``register_commands``) of the CLI module of
    every system in :mod:`optinav.registry` that defines it."""
    import importlib

    from optinav import registry

    seen = set()
    for system in registry.systems():
        if system.cli and system.cli not in seen:
            seen.add(system.cli)
            fn = getattr(importlib.import_module(system.cli), hook, None)
            if fn is not None:
                fn(kinds)


def number(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    integer: bool = False,
    what: str = "a number",
):
    """An argparse ``type=`` that accepts a finite number in [lo, hi] (lo excluded when ``lo_open``); anything
    else is a one-line argparse error naming the valid range."""
    import argparse

    def parse(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} is not finite")
        if (lo is not None and (v < lo or (lo_open and v == lo))) or (hi is not None and v > hi):
            lo_s = "" if lo is None else (f"> {lo:g}" if lo_open else f">= {lo:g}")
            hi_s = "" if hi is None else f"<= {hi:g}"
            bounds = " and ".join(filter(None, (lo_s, hi_s)))
            raise argparse.ArgumentTypeError(f"{text} is out of range (must be {bounds})")
        return v

    parse.__name__ = what  # argparse names the type in its "invalid ... value" message
    return parse


#: argparse types of the physical quantities every command takes (degrees and metres at the CLI)
LATITUDE = number(-90.0, 90.0, what="a latitude in degrees")
LONGITUDE = number(-180.0, 360.0, what="a longitude in degrees")
#: height above the ellipsoid: from the deepest ocean floor to the top of the normal-gravity model's use
HEIGHT = number(-11_000.0, 100_000.0, what="a height in m")
ELEVATION = number(-90.0, 90.0, what="an elevation in degrees")
POSITIVE = number(0.0, lo_open=True, what="a positive number")
NON_NEGATIVE = number(0.0, what="a number >= 0")
COUNT = number(1, integer=True, what="an integer >= 1")
SEED = number(0, integer=True, what="a seed (integer >= 0)")
#: sample rates (Hz): what an IMU or a logger can record
RATE = number(0.0, 1e6, lo_open=True, what="a rate in Hz")
#: a time in a log (s) and an angle (degrees): any finite number (NaN or inf reached the library as data)
TIME = number(what="a time in s")
ANGLE = number(what="an angle in degrees")


def available_memory() -> int:
    """Bytes of memory available to a new allocation (Linux MemAvailable; elsewhere the free physical pages)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import os

        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 1 << 40


def check_memory(n_rows: float, bytes_per_row: float, what: str, remedy: str) -> None:
    """Refuse up front a simulation of ``n_rows`` samples whose estimated peak memory (``bytes_per_row`` each,
    measured for that simulator) does not fit in half the available memory, with the estimate in the message."""
    need, have = float(n_rows) * bytes_per_row, available_memory()
    if not math.isfinite(need) or need > 0.5 * have:
        raise OptinavError(
            f"{what} would need {n_rows:.3g} samples, about {need / 2**30:.3g} GiB of memory "
            f"({have / 2**30:.3g} GiB available)",
            remedy,
        )


def check_disk(n_rows: float, bytes_per_row: float, path, what: str, remedy: str) -> None:
    """Refuse up front a streamed output of ``n_rows`` rows (``bytes_per_row`` each, measured for that writer) that
    does not fit in the free space of ``path``'s folder, with the estimate in the message."""
    import shutil

    need = float(n_rows) * bytes_per_row
    try:
        have = shutil.disk_usage(Path(path).parent or ".").free
    except OSError:
        return  # the writer reports the OS error itself
    if not math.isfinite(need) or need > have:
        raise OptinavError(
            f"{what} would need {n_rows:.3g} samples, about {need / 2**30:.3g} GiB on disk "
            f"({have / 2**30:.3g} GiB free where --out goes)",
            remedy,
        )


def add_counts_options(p) -> None:
    """--acc-lsb, --gyro-lsb: raw counts read as SI by their datasheet sensitivity (commands that need SI units)."""
    p.add_argument(
        "--acc-lsb",
        type=POSITIVE,
        metavar="LSB_PER_G",
        help="an accelerometer in raw counts read as m/s^2 by its datasheet sensitivity (e.g. 2048 at ±16 g): a "
        "nominal conversion, no calibration",
    )
    p.add_argument(
        "--gyro-lsb",
        type=POSITIVE,
        metavar="LSB_PER_DEG_S",
        help="a gyroscope in raw counts read as rad/s by its datasheet sensitivity (e.g. 16.4 at ±2000 °/s)",
    )


def add_input_options(p, *, gyro: bool = True, unit_default: tuple[str, str] = ("m/s^2", "rad/s")) -> None:
    """--columns, --acc-unit, --gyro-unit, --time-unit, --rate, --delimiter, --datasets, --topic, --skip-bad-lines;
    ``unit_default``
    names the units of a file that declares none, in the help."""
    p.add_argument(
        "--columns",
        help="names of the file's columns in order (t,ax,ay,az,gx,gy,gz; '_' skips one; '-' before a sensor's "
        "name reads it negated: t,-ax,-ay,-az,…), or std=name pairs for named columns/arrays (ax=-NAME); "
        "default: recognised headers",
    )
    p.add_argument(
        "--acc-unit",
        choices=["counts", "g", "mg", "m/s^2"],
        help=f"accelerometer unit in the file (default: as declared, else {unit_default[0]})",
    )
    if gyro:
        p.add_argument(
            "--gyro-unit",
            choices=["counts", "deg/s", "mdps", "rad/s"],
            help=f"gyroscope unit in the file (default: as declared, else {unit_default[1]})",
        )
    p.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column (default s)")
    p.add_argument(
        "--rate", dest="rate_hz", type=RATE, metavar="HZ", help="sample rate in Hz for files without a time column"
    )
    p.add_argument("--delimiter", help="column delimiter of text files (default: detected)")
    p.add_argument("--datasets", help="HDF5/MAT/NPZ names as std=name pairs, e.g. t=imu/time,acc=imu/acc")
    p.add_argument(
        "--skip-bad-lines",
        action="store_true",
        help="text files: leave unreadable lines (a garbled cell, a cut or merged line) out as lost samples, "
        "with a note naming them (at most 1%% of the lines; without a time column they stay as NaN rows); a damaged "
        "PX4 ULog: read what pyulog recovers, with a note",
    )
    p.add_argument(
        "--topic",
        metavar="IMU[,MAG]",
        help="ROS bag (.bag, .db3, .mcap or a ROS 2 bag folder): the "
        "sensor_msgs/Imu topic, optionally a MagneticField topic "
        "after a comma (default: the bag's only Imu topic); TOPIC@FRAME reads "
        "only the messages of header frame_id FRAME (several IMUs on one topic); for a table of several "
        "sensors in alternate rows, NAME@ID reads one: ArduPilot's instance (IMU@1, ACC@0, GYR@2 of a mavlogdump "
        "CSV) or a frame_id column's FRAME (@FRAME); PX4 ULog (.ulg): the uORB topic(s) (default sensor_combined; "
        "vehicle_imu, the pair sensor_accel,sensor_gyro, and for --mag vehicle_magnetometer or sensor_mag; NAME@K "
        "for instance K of a topic logged several times)",
    )


def add_gyro_file_options(
    p, how: str = "the same rows, or its own time column (interpolated onto the accelerometer's)"
) -> None:
    """--gyro GYRODATA (destination ``gyro_path``) and --gyro-columns: the gyroscope in a second file, read as
    ``how`` says."""
    p.add_argument("--gyro", dest="gyro_path", metavar="GYRODATA", help=f"gyroscope in a second file: {how}")
    p.add_argument("--gyro-columns", help="column names of GYRODATA (like --columns)")


def add_chunk_option(p, keeps: str | None = None) -> None:
    """--chunk-rows: rows of a text log read and parsed at a time; ``keeps``: what the command holds per sample
    beyond them (None: nothing, so memory does not grow with the log's length)."""
    from optinav.core.files import CHUNK_ROWS

    grows = (
        "memory grows with N, not with the log's length"
        if keeps is None
        else f"the text is read N rows at a time, and {keeps}"
    )
    p.add_argument(
        "--chunk-rows",
        type=COUNT,
        default=CHUNK_ROWS,
        metavar="N",
        help=f"rows of a text log processed at a time (default {CHUNK_ROWS}); {grows}",
    )


def output_path(
    path, suffixes: tuple[str, ...] | None = None, example: str = "", option: str = "--out", mark=None
) -> Path:
    """``--out`` checked before any work: an allowed suffix (when ``suffixes`` is given), not an input of the
    command, not a folder, in an existing writable folder, not a data file of another kind than ``mark`` says the
    command writes (:func:`optinav.core.files.check_replace`)."""
    from optinav.core.files import check_output, check_replace

    out = Path(path)
    if suffixes and out.suffix.lower() not in suffixes:
        raise OptinavError(
            f"{option} {out} is not a {'/'.join(suffixes)} file", f"name it like {example or 'out' + suffixes[0]}"
        )
    check_output(out, option)
    check_replace(out, option, mark)
    return out


#: the ``what`` of :func:`require_files` that names one sensor's file → its option: a phone export given there is
#: refused (it is read whole, as the data file)
ONE_SENSOR = {"--gyro file": "--gyro", "gyroscope file": "--gyro", "magnetometer file": "--mag-file"}


def require_files(*items: tuple[str | None, str]) -> None:
    """``(path, what)`` pairs that must name existing files, checked before a command imports its numerical
    modules (seconds of imports), so a mistyped name fails at once. ``None`` paths are skipped; a phone export
    where one sensor's file is wanted (:data:`ONE_SENSOR`) is refused."""
    from optinav.core.files import input_kind, kitti_oxts_folder
    from optinav.io.phone import refuse_as_one_sensor
    from optinav.io.rosbag import is_bag

    for path, what in items:
        if path is not None and what in ONE_SENSOR:
            refuse_as_one_sensor(path, ONE_SENSOR[what])
        if path is not None and input_kind(path, what) == "dir" and not is_bag(path) and not kitti_oxts_folder(path):
            from optinav.io.phone import phone_export

            if phone_export(path) is not None:  # a phone app's unzipped export, read file by file
                continue
            from optinav.io.readers import _folder_error

            raise _folder_error(Path(path), what) or OptinavError(f"{what} {Path(path)} is a folder", "check the path")


def load_option_result(cls, path, option: str, needs: str):
    """The result file an option takes, loaded as ``cls``; an error names the option and what it needs (a design
    plan given to export --noise was told to 'upgrade optinav', a plan.md given to simulate --plan to 'pass an
    unmodified optinav result file', neither naming the option).

    Parameters
    ----------
    cls : type
        The :class:`optinav.core.results.Result` subclass expected.
    path : str or Path
        The file.
    option : str
        The option that named the file, e.g. ``"--noise"``.
    needs : str
        What the option takes, e.g. ``"the ALLAN.json that optinav allan wrote"``.

    Returns
    -------
    Result
        The loaded result.
    """
    try:
        return cls.from_json(path)
    except OptinavError as exc:
        # the loader's own remedy stays (a damaged file: 'pass an unmodified optinav result file'); the option's need
        # follows it
        raise OptinavError(
            f"{option} {path}: {exc.cause}", (f"{exc.remedy}; " if exc.remedy else "") + f"{option} takes {needs}"
        ) from None


def parse_floats(text: str, n: int | None, option: str, names: str = "") -> list[float]:
    """``"0.5,1.0"`` → ``[0.5, 1.0]`` for a comma-list option: finite numbers, exactly ``n`` of them when given.

    ``names`` (e.g. ``"ROLL,PITCH,YAW"``) is the spelling shown in the error's remedy."""
    form = names or ",".join(["X"] * (n or 2))
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise OptinavError(f"{option} {text!r} is not a comma list of numbers", f"write {option} {form}") from None
    if n is not None and len(vals) != n:
        raise OptinavError(f"{option} needs {n} numbers ({form}), got {len(vals)}", f"write {option} {form}")
    if not all(math.isfinite(v) for v in vals):
        raise OptinavError(f"{option} has a non-finite number", "give finite numbers")
    return vals


def parse_key_values(items, option: str = "--option") -> dict:
    """Repeated ``KEY=VALUE`` options (e.g. ``--option gain=0.1``) → ``{key: float}``."""
    out = {}
    for item in items:
        k, _, v = item.partition("=")
        if not v:
            raise OptinavError(f"{option} {item!r} is not KEY=VALUE", f"write e.g. {option} gain=0.1")
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise OptinavError(f"{option} {item!r}: {v!r} is not a number", "give options as numbers") from None
    return out


#: how every truth file written by :func:`write_truth` starts (so an existing one may be replaced)
TRUTH_SIGNATURE = '{\n  "schema": "optinav.'


def truth_path(data_path) -> Path:
    """``STEM.truth.json`` beside ``data_path``, checked before any work: an existing file there is replaced only
    when optinav wrote it."""
    from optinav.core.files import check_sidecar

    p = Path(data_path)
    return check_sidecar(p.with_name(p.stem + ".truth.json"), TRUTH_SIGNATURE)


def write_truth(data_path, truth) -> Path:
    """Write a simulation's :class:`~optinav.core.results.Truth` beside its data as ``STEM.truth.json``
    (atomically) and return that path."""
    tp = truth_path(data_path)
    truth.to_json(tp)
    return tp


def options_from_args(cls, args, **given):
    """The library's options dataclass ``cls`` from parsed arguments: every field the namespace carries under the
    same name, ``given`` taking precedence (the library never sees the argparse namespace)."""
    kw = {f.name: getattr(args, f.name) for f in dataclasses.fields(cls) if hasattr(args, f.name)}
    return cls(**{**kw, **given})


def file_options(args):
    """:class:`optinav.multipos.calibrate.FileOptions` of ``optinav calibrate accel`` / ``batch calibrate accel``:
    ``--rest T0 T1`` as a tuple, ``--height`` (None when not given) only with ``--latitude``, and
    ``--held-misalignment`` not given as the library's default."""
    from optinav.multipos.calibrate import FileOptions

    height, rest = getattr(args, "height_m", None), getattr(args, "rest", None)
    held = getattr(args, "held_misalignment", None)
    if height is not None and getattr(args, "lat_deg", None) is None:
        raise OptinavError(
            "--height without --latitude has no effect (it sets the normal gravity's height)",
            "add --latitude DEG, or drop --height",
        )
    return options_from_args(
        FileOptions,
        args,
        height_m=0.0 if height is None else height,
        rest=None if rest is None else tuple(float(v) for v in rest),
        held_misalignment=FileOptions.held_misalignment if held is None else held,  # (the library's default)
    )


def system_options(system, args, key: str = "options"):
    """The options object a registered system's ``key`` entry (``options`` or ``apply_options``) names, from
    parsed arguments; the multi-position calibration's :func:`file_options` adapts its ``--rest``/``--height``."""
    cls = system.load(key)
    from optinav.multipos.calibrate import FileOptions

    return file_options(args) if cls is FileOptions else options_from_args(cls, args)


def add_report_option(p) -> None:
    """``--report DIR`` of the commands that produce results."""
    p.add_argument("--report", metavar="DIR", help="also write plots and index.md/index.html into DIR")


def prepare_report(args) -> None:
    """Check the ``--report`` folder before any work, so a bad folder fails fast; it is created only when the
    report is written, so a run that fails leaves no folder behind."""
    if args.report:
        from optinav.reports import check_report_dir
        from optinav.reports.report import report_writes

        for opt, other in _other_outputs(args):  # files the command writes before the report
            if Path(args.report).resolve() == Path(other).resolve():
                raise OptinavError(
                    f"--report {args.report} names the {opt} file", "give the report a folder of its own"
                )
            if report_writes(args.report, other):
                raise OptinavError(
                    f"{opt} {other} is a file the report writes into --report {args.report}: the report would "
                    "replace it",
                    "give each output file its own name",
                )
        check_report_dir(args.report)


def _other_outputs(args) -> list[tuple[str, str]]:
    """(option, path) of every output file of ``args`` besides the report: --out, --kalibr, --gyro-out and each
    path of ``--export FMT:FILE[,GYRO]`` (repeatable)."""
    found = []
    for opt in ("out", "kalibr", "gyro_out"):
        value = getattr(args, opt, None)
        if isinstance(value, (str, Path)) and str(value):
            found.append(("--" + opt.replace("_", "-"), str(value)))
    exports = getattr(args, "export", None) or []
    for spec in [exports] if isinstance(exports, str) else exports:
        fmt, sep, paths = str(spec).partition(":")
        found.extend(("--export " + fmt, q) for q in (paths if sep else spec).split(",") if q)
    return found


#: the library's keyword arguments named in its messages, as the command line spells them
_FLAGS = {
    "rate_hz": "--rate",
    "time_unit": "--time-unit",
    "acc_unit": "--acc-unit",
    "gyro_unit": "--gyro-unit",
    "gyro_columns": "--gyro-columns",
    "gyro_path": "--gyro",
    "mag_columns": "--mag-columns",
    "columns": "--columns",
    "delimiter": "--delimiter",
}
_KEYWORD = re.compile(r"(?<![\w-])(" + "|".join(_FLAGS) + r")=")


def cli_wording(message: str) -> str:
    """A library message as the command line's user reads it: ``time_unit=...`` → ``--time-unit ...``."""
    return _KEYWORD.sub(lambda m: _FLAGS[m.group(1)] + " ", message)


#: the warnings and notes said on the console by the command running (kind, message): its --report keeps them
_SAID: list[tuple[str, str]] = []


def forget_said() -> None:
    """Start a command's record of what it said (:func:`said`)."""
    _SAID.clear()


def said() -> list[tuple[str, str]]:
    """The (kind, message) of every warning and note the running command has said on stderr, in order."""
    return list(_SAID)


def say(kind: str, message: str) -> None:
    """``optinav: KIND: MESSAGE`` on stderr, one line, kept for the command's report (:func:`said`)."""
    import sys

    text = cli_wording(" ".join(str(message).split()))
    _SAID.append((kind, text))
    try:
        print(f"optinav: {kind}: {text}", file=sys.stderr)
    except OSError:  # stderr closed (a pipe to `head`): the warning is lost, as with Python's own showwarning;
        pass  # a batch unit failed "internal error: BrokenPipeError" and was journaled so


def finish_report(args, write) -> None:
    """``write(folder) -> path`` the report when ``--report`` was given, with the warnings and notes said on the
    console before it (:func:`said`), and say where it is."""
    if args.report:
        from optinav.reports.report import console_said

        with console_said(said()):
            where = write(args.report)
        print(f"optinav: report written to {where}/index.md")


class ReaderNotes:
    """The notes of the logs read block by block (:attr:`optinav.io.ImuLog.notes`: the rate's source, a text
    column left out, an incomplete last line), each once: ``watch(blocks)`` passes the blocks through,
    ``print()`` writes them to stderr as calibrate does."""

    def __init__(self):
        self.notes: list[str] = []

    def watch(self, blocks):
        for log in blocks:
            self.notes.extend(n for n in log.notes if n not in self.notes)
            yield log

    def print(self) -> None:
        print_notes(self.notes)


def print_notes(notes) -> None:
    """Each note on stderr as ``optinav: note: …`` (kept for the command's report)."""
    for note in notes:
        say("note", note)
