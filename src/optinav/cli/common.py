"""Options shared by the data-reading commands (one spelling everywhere)."""

from __future__ import annotations

import math
from pathlib import Path

from optinav.errors import OptinavError

#: per-system CLI modules; each may define ``register_simulate(kinds)`` (a kind under ``optinav simulate``) and
#: ``register_calibrate(kinds)`` (a sensor/system under ``optinav calibrate``). Top-level commands of a system
#: (``gfimu``, ``sun``, ``attitude``) are listed in ``main.COMMAND_MODULES`` instead.
SYSTEM_MODULES = ["optinav.cli.rins", "optinav.cli.gfimu", "optinav.cli.attitude"]


def register_system_hooks(kinds, hook: str) -> None:
    """Call ``hook`` (``register_simulate``/``register_calibrate``) of every system CLI module that has it."""
    import importlib

    for name in SYSTEM_MODULES:
        fn = getattr(importlib.import_module(name), hook, None)
        if fn is not None:
            fn(kinds)


def add_input_options(p, *, gyro: bool = True) -> None:
    """--columns, --acc-unit, --gyro-unit, --time-unit, --rate, --delimiter, --datasets."""
    p.add_argument("--columns", help="names of the file's columns in order (t,ax,ay,az,gx,gy,gz; '_' skips one), "
                                     "or std=name pairs for named columns/arrays; default: recognised headers")
    p.add_argument("--acc-unit", choices=["counts", "g", "mg", "m/s^2"], help="accelerometer unit in the file "
                                                                          "(default: as declared, else m/s^2)")
    if gyro:
        p.add_argument("--gyro-unit", choices=["counts", "deg/s", "rad/s"],
                       help="gyroscope unit in the file (default: as declared, else rad/s)")
    p.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column (default s)")
    p.add_argument("--rate", type=float, help="sample rate in Hz for files without a time column")
    p.add_argument("--delimiter", help="column delimiter of text files (default: detected)")
    p.add_argument("--datasets", help="HDF5/MAT/NPZ names as std=name pairs, e.g. t=imu/time,acc=imu/acc")


def output_path(path, suffixes: tuple[str, ...] | None = None, example: str = "") -> Path:
    """``--out`` checked before any work: an allowed suffix (when ``suffixes`` is given) and an existing folder."""
    out = Path(path)
    if suffixes and out.suffix.lower() not in suffixes:
        raise OptinavError(f"--out {out} is not a {'/'.join(suffixes)} file",
                           f"name it like {example or 'out' + suffixes[0]}")
    if not out.parent.exists():
        raise OptinavError(f"the folder of --out ({out.parent}) does not exist", "create it first")
    return out


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


def write_truth(data_path, truth: dict) -> Path:
    """Write a simulation's truth beside its data as ``STEM.truth.json`` (atomically) and return that path."""
    import json

    p = Path(data_path)
    tp = p.with_name(p.stem + ".truth.json")
    tmp = tp.with_name(tp.name + ".tmp")
    tmp.write_text(json.dumps(truth, indent=2) + "\n", encoding="utf-8")
    tmp.replace(tp)
    return tp


def add_report_option(p) -> None:
    """``--report DIR`` of the commands that produce results."""
    p.add_argument("--report", metavar="DIR", help="also write plots and index.md/index.html into DIR")


def prepare_report(args) -> None:
    """Check (and create) the ``--report`` folder before any work, so a bad folder fails fast."""
    if args.report:
        from optinav.reports import prepare_report_dir

        prepare_report_dir(args.report)


def finish_report(args, write) -> None:
    """``write(folder) -> path`` the report when ``--report`` was given, and say where it is."""
    if args.report:
        print(f"optinav: report written to {write(args.report)}/index.md")
