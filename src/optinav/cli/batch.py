"""``optinav batch calibrate accel|rins|gfimu DIR`` and ``optinav batch attitude DIR``: every recording of a
folder through one system, in parallel, one row per unit. Built from :mod:`optinav.registry`: each system's CLI
module adds its options with ``add_batch_options(parser)``."""

from __future__ import annotations

import argparse
import importlib
import textwrap

from optinav import registry

_COMMON = """
    A unit is one data file directly in DIR (.csv .tsv .txt .dat .log, optionally .gz, .npz .npy .h5 .hdf5 .mat
    .parquet .pq, ROS bags .bag .db3 .mcap, PX4 logs .ulg) or a ROS 2 bag folder (with metadata.yaml, or
    without: a recording that did not close); hidden files and STEM.truth.* skipped), in sorted order. A
    failing unit is recorded as failed and the others continue. Finished rows go to RESULTS.csv.journal.jsonl
    as they finish; a re-run with the same --out skips units whose file (name, size, mtime) and options are
    unchanged, so a killed run loses nothing already finished. Local processes by default; --scheduler ADDRESS
    runs on a dask.distributed cluster (pip install 'optinav[dask]'; workers must see DIR at the same path). A
    worker that dies only loses its own unit; workers exit with the batch. Columns: docs/batch.md. Exit status 1
    when any unit failed or was lost."""

_EXAMPLES = {
    "accel": """\
        example (three simulated units, calibrated on 2 local processes, then resumed):
          mkdir units
          optinav simulate accel-multipos --out units/u1.csv --dwell 10 --seed 1
          optinav simulate accel-multipos --out units/u2.csv --dwell 10 --seed 2
          optinav simulate accel-multipos --out units/u3.csv --dwell 10 --seed 3
          optinav batch calibrate accel units --latitude 38.88 --height 35 --out results.csv --workers 2
          optinav batch calibrate accel units --latitude 38.88 --height 35 --out results.csv
        on a dask cluster:  optinav batch calibrate accel units --out results.parquet --scheduler tcp://host:8786
        """,
    "rins": """\
        example:
          optinav simulate rins --nonorth=1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4 --scheme dual4 --out units/r1.npz
          optinav batch calibrate rins units --out results.csv --reference
        """,
    "gfimu": """\
        example:
          optinav simulate gfimu-turntable --builtin cylinder10 --seed 1 --out units/t1.npz
          optinav batch calibrate gfimu units --builtin cylinder10 --out results.csv --reference
        """,
    "attitude": """\
        example:
          optinav simulate flight --kind static --duration 20 --seed 1 --out flights/f1.csv
          optinav batch attitude flights --method mekf --out results.csv --reference
        BROAD trials as published:  optinav batch attitude broad/ --frame ENU --mag --offline --reference --out r.csv
        """,
}


def _add_common(p) -> None:
    p.add_argument("dir", metavar="DIR", help="folder with one data file per unit")
    p.add_argument(
        "--out",
        required=True,
        metavar="RESULTS.csv|.parquet",
        help="results table (.parquet needs pip install 'optinav[parquet]')",
    )
    p.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local worker processes (default: the number of cores; 0 = in this process)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask.distributed scheduler, e.g. tcp://10.0.0.5:8786 (instead of local processes)",
    )
    p.add_argument("--fresh", action="store_true", help="ignore the journal of --out and recompute every unit")
    p.add_argument(
        "--retry-failed",
        action="store_true",
        help="recompute units that failed before (by default only a changed file is retried)",
    )
    p.add_argument(
        "--reference",
        action="store_true",
        help="score each unit against the truth beside it (STEM.truth.json; attitude also "
        "STEM.truth.csv or a BROAD trial's reference), where there is one",
    )


def _system_parser(sub, system: registry.System):
    p = sub.add_parser(
        system.command,
        help=system.help,
        description=textwrap.fill(
            f"Run `optinav {'calibrate ' if system.kind == 'calibration' else ''}{system.command}` (same options) "
            "on every unit's recording in DIR in parallel and write one row per unit to RESULTS.csv or .parquet: "
            "status, error text, every parameter with its std and CRLB std, convergence, quality gates. "
            + " ".join(_COMMON.split()),
            110,
        ),
        epilog=textwrap.dedent(_EXAMPLES.get(system.command, "")),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_common(p)
    if system.kind == "calibration":
        p.add_argument(
            "--results-dir",
            metavar="FOLDER",
            help="also write each ok unit's result JSON there as UNIT.json (what `optinav calibrate --out` writes: "
            "for `optinav export` and `optinav apply`)",
        )
        p.add_argument(
            "--lot-alpha",
            type=float,
            default=0.01,
            metavar="P",
            help="the lot check's false-alarm probability (default 0.01; 0 = off): units whose parameters stand "
            "out from the other ok units (≥ 5) are flagged for review (column lot_outlier); a raw-count scale "
            "beyond ×1.5 of the lot's median fails its unit",
        )
    if system.cli:
        hook = getattr(importlib.import_module(system.cli), "add_batch_options", None)
        if hook is not None:
            hook(p)
    p.set_defaults(func=run_batch_command, batch_system=system.name)
    return p


def register(sub) -> None:
    p = sub.add_parser(
        "batch",
        help="run every recording of a folder through a system, in parallel (local processes or dask)",
        description="Run a calibration or an estimate on every data file of a folder; one table row per unit.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    what = p.add_subparsers(dest="batch_command", metavar="COMMAND", title="commands")
    c = what.add_parser(
        "calibrate",
        help="calibrate a folder of recordings",
        description="Calibrate a folder of recordings, one unit per file.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = c.add_subparsers(dest="sensor", metavar="SYSTEM", title="systems")
    for system in registry.systems("calibration"):
        _system_parser(kinds, system)
    for system in registry.systems("estimate"):
        _system_parser(what, system)
    c.set_defaults(func=lambda args: (c.print_help(), 2)[1])
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_batch_command(args) -> int:
    from optinav.batch import run_batch
    from optinav.cli.common import system_options

    system = registry.SYSTEMS[args.batch_system]
    options = system_options(system, args)
    s = run_batch(
        args.dir,
        args.out,
        options,
        system=system.name,
        reference=args.reference,
        workers=args.workers,
        scheduler=args.scheduler,
        fresh=args.fresh,
        retry_failed=args.retry_failed,
        results_dir=getattr(args, "results_dir", None),
        lot_alpha=getattr(args, "lot_alpha", 0.01),
    )
    print(s.summary())
    print(f"optinav: results written to {s.out} (journal {s.journal.name})")
    if s.results_dir is not None:
        print(f"optinav: each ok unit's result JSON in {s.results_dir}")
    return 1 if s.n_failed else 0  # a failed or lost unit is not a successful batch
