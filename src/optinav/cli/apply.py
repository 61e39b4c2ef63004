"""``optinav apply RESULT.json DATA --out FILE``: apply a calibration result to data. Built from
:mod:`optinav.registry`: the result file's schema selects the system (imucal and imu_tk files are
multi-position calibrations), whose ``apply`` reference does the work; each system's CLI module adds its
options with ``add_apply_options(group)``."""

from __future__ import annotations

import argparse
import importlib
import textwrap

from optinav import registry
from optinav.cli.common import output_path, require_files
from optinav.errors import OptinavError


def register(sub) -> None:
    p = sub.add_parser(
        "apply",
        help="apply a calibration result to data (the result file selects the system)",
        description=textwrap.dedent("""\
            Apply RESULT.json to DATA; the result's schema (optinav.<system>.calibration) selects what is done:
              accel (multipos): raw triads corrected, a = K⁻¹(raw − b) (m/s^2), ω = K_g⁻¹(raw − G·a − b_g)
                (rad/s), block by block. RESULT may also be an imucal JSON export or an imu_tk accelerometer
                file (--gyro-cal for its gyroscope file); the data are read in the raw units the calibration was
                made in unless the file or --acc-unit/--gyro-unit say otherwise (physical units are converted to
                the calibration's; counts against a physical unit are refused). Output by extension (.csv .tsv
                .txt .npz .h5 .mat).
              rins: the vehicle attitude of a recording with the gimbal non-orthogonality compensated (CSV: t,
                q_b_n, roll/pitch/yaw in degrees, ENU).
              gfimu: the array outputs solved with the calibrated geometry, the paper's compensation of the
                installation errors (CSV: t, specific force ax..az m/s^2, rate gx..gz rad/s, wdot_x..z rad/s^2).
            An attitude estimate has nothing to apply."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav apply result.json session.csv --out corrected.csv
              optinav apply acc.calib session.csv --gyro-cal gyro.calib --out corrected.csv
              optinav apply rins_result.json rins.npz --out attitude.csv
              optinav apply gfimu_result.json flight.csv --omega0 2,0.2,0 --out motion.csv
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("result", help="RESULT.json of optinav calibrate (or an imucal JSON / imu_tk accelerometer file)")
    p.add_argument("data", help="data file")
    p.add_argument("--out", required=True, metavar="FILE", help="output file")
    owned = {}  # system name -> [(dest, flag, default)] of the options its hook added
    for system in registry.systems():
        hook = getattr(importlib.import_module(system.cli), "add_apply_options", None) if system.cli else None
        if hook is not None:
            before = len(p._actions)
            hook(p.add_argument_group(f"{system.command} results"))
            owned[system.name] = [(a.dest, a.option_strings[0], a.default) for a in p._actions[before:]]
    p.set_defaults(func=run, apply_owned=owned)


def run(args) -> int:
    from optinav.cli.common import system_options

    require_files(
        (args.result, "result file"), (args.data, "data file"), (getattr(args, "gyro_cal", None), "--gyro-cal file")
    )
    system, res = registry.for_result(args.result)
    if system.apply is None:
        raise OptinavError(
            f"{args.result} is {'an' if system.kind[0] in 'aeiou' else 'a'} {system.name} "
            f"{system.kind} ({system.help}): there is nothing to apply to data",
            f"use it as it is, e.g. optinav report {args.result}",
        )
    _refuse_foreign_options(args, system)
    out = output_path(args.out, mark=_own_output(system))
    options = system_options(system, args, "apply_options") if system.apply_options else None
    print("optinav: " + system.load("apply")(args.result, args.data, out, options))
    return 0


def _own_output(system):
    """``check_replace``'s mark of what apply writes for ``system``: the multi-position log's source line, or the
    header of the system's table (``APPLY_COLUMNS`` beside its apply function), so a rerun replaces its own output."""
    columns = getattr(importlib.import_module(system.apply.partition(":")[0]), "APPLY_COLUMNS", None)
    return lambda head: (
        b"source: optinav apply" in head or (columns is not None and head.startswith(columns.encode() + b"\n"))
    )


def _refuse_foreign_options(args, system) -> None:
    """An option of another system's results given for this one would be silently ignored: refuse it."""
    for name, options in args.apply_owned.items():
        for dest, flag, default in options if name != system.name else ():
            if getattr(args, dest) != default:
                raise OptinavError(
                    f"{flag} is for {registry.SYSTEMS[name].command} results, {args.result} is a "
                    f"{system.name} {system.kind}",
                    f"drop {flag}",
                )
