"""``optinav batch calibrate accel DIR``: calibrate every unit's log in a folder in parallel, one row per unit."""

from __future__ import annotations

import argparse
import textwrap

from optinav.cli.calibrate import add_calibration_options


def register(sub) -> None:
    p = sub.add_parser(
        "batch", help="calibrate every unit's log in a folder, in parallel (local processes or a dask cluster)",
        description="Run a calibration on every data file of a folder and collect one table row per unit.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    what = p.add_subparsers(dest="batch_command", metavar="COMMAND", title="commands")
    c = what.add_parser("calibrate", help="calibrate a folder of logs",
                        description="Calibrate a folder of logs, one unit per file.",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    kinds = c.add_subparsers(dest="sensor", metavar="SENSOR", title="sensors")
    a = kinds.add_parser(
        "accel", help="multi-position accelerometer (and gyroscope) calibration of every unit",
        description=textwrap.dedent("""\
            Run `optinav calibrate accel` (same options) on every unit's log in DIR in parallel and write one
            row per unit to RESULTS.csv or RESULTS.parquet: status, error text, K and b with their std, quality
            figures. A unit is one data file directly in DIR (.csv .tsv .txt .dat, optionally .gz, .npz .npy .h5
            .hdf5 .mat; hidden files and *.truth.json skipped), in sorted order. A corrupt unit is recorded as
            failed and the others continue. Finished rows go to RESULTS.csv.journal.jsonl as they finish; a re-run
            with the same --out skips units whose file (name, size, mtime) and options are unchanged, so a killed
            run loses nothing already finished. Local processes by default; --scheduler ADDRESS runs on a
            dask.distributed cluster (pip install 'optinav[dask]'; workers must see DIR at the same path).
            A worker that dies only loses its own unit (the others are run again); workers exit with the batch.
            Exit status 1 when any unit failed or was lost. See docs/batch.md."""),
        epilog=textwrap.dedent("""\
            example (three simulated units, calibrated on 2 local processes, then resumed):
              mkdir units
              optinav simulate accel-multipos --out units/u1.csv --dwell 10 --seed 1
              optinav simulate accel-multipos --out units/u2.csv --dwell 10 --seed 2
              optinav simulate accel-multipos --out units/u3.csv --dwell 10 --seed 3
              optinav batch calibrate accel units --latitude 38.88 --height 35 --out results.csv --workers 2
              optinav batch calibrate accel units --latitude 38.88 --height 35 --out results.csv
            on a dask cluster:  optinav batch calibrate accel units --out results.parquet --scheduler tcp://host:8786
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("dir", metavar="DIR", help="folder with one data file per unit")
    a.add_argument("--out", required=True, metavar="RESULTS.csv|.parquet",
                   help="results table (.parquet needs pip install 'optinav[parquet]')")
    a.add_argument("--workers", type=int, metavar="N",
                   help="local worker processes (default: the number of cores; 0 = in this process)")
    a.add_argument("--scheduler", metavar="ADDRESS",
                   help="dask.distributed scheduler, e.g. tcp://10.0.0.5:8786 (instead of local processes)")
    a.add_argument("--fresh", action="store_true", help="ignore the journal of --out and recompute every unit")
    a.add_argument("--retry-failed", action="store_true",
                   help="recompute units that failed before (by default only a changed file is retried)")
    add_calibration_options(a)
    a.set_defaults(func=run_batch_accel)
    c.set_defaults(func=lambda args: (c.print_help(), 2)[1])
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_batch_accel(args) -> int:
    from optinav.batch import run_batch
    from optinav.multipos.calibrate import FileOptions

    s = run_batch(args.dir, args.out, FileOptions.from_args(args), workers=args.workers, scheduler=args.scheduler,
                  fresh=args.fresh, retry_failed=args.retry_failed)
    print(s.summary())
    print(f"optinav: results written to {s.out} (journal {s.journal.name})")
    return 1 if s.n_failed else 0  # a failed or lost unit is not a successful batch
