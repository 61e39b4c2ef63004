"""``optinav report RESULT.json [...] --out DIR|FILE.md``: the report of any system's result file, built by the
system's ``report`` reference in :mod:`optinav.registry` (the file's schema selects the system)."""

from __future__ import annotations

import argparse
import textwrap

from optinav.cli.common import RATE
from optinav.errors import OptinavError


def register(sub) -> None:
    p = sub.add_parser(
        "report",
        help="report of result files of any system (tables and figures)",
        description=textwrap.dedent("""\
            Write the report of each RESULT.json (any system; its schema selects the report): the result's
            parameters with their std, observability and quality, and the system's figures. --data gives the
            recording a result came from (one per result, in order) for the figures that need it (the corrected
            norm of a multi-position log, the attitude change of a rotational INS, the angles of an attitude
            estimate). --out DIR writes DIR/index.md, index.html, summary.json and PNGs (several results: one
            sub-folder each and DIR/index.md linking them); --out FILE.md writes one Markdown file with the rest in
            FILE_files/."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav report result.json --data session.csv --out rep
              optinav report rins_result.json gfimu_result.json --out calibrations.md
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("results", nargs="+", metavar="RESULT.json", help="result files of optinav")
    p.add_argument(
        "--data",
        action="append",
        default=[],
        metavar="DATA",
        help="the recording of a result (repeatable, one per result in order)",
    )
    p.add_argument(
        "--rate",
        dest="rate_hz",
        type=RATE,
        metavar="HZ",
        help="sampling rate of --data recordings without a time column (multi-position and attitude results)",
    )
    p.add_argument(
        "--time-unit",
        dest="time_unit",
        choices=("s", "ms", "us", "ns"),
        help="unit of the --data recordings' time column, as given to calibrate or attitude (default s)",
    )
    p.add_argument(
        "--columns",
        metavar="SPEC",
        help="columns of the --data recordings, as given to calibrate or attitude (e.g. t,ax,ay,az,gx,gy,gz)",
    )
    p.add_argument(
        "--gyro",
        dest="gyro_path",
        action="append",
        default=[],
        metavar="GYRODATA",
        help="the gyroscope's file of a --data recording logged in two files, as given to calibrate or attitude "
        "(repeatable, one per --data in order)",
    )
    p.add_argument("--topic", metavar="TOPIC", help="the IMU topic of --data bags, as given to calibrate or attitude")
    p.add_argument("--out", required=True, metavar="DIR|FILE.md", help="report folder or Markdown file")
    p.set_defaults(func=run)


def run(args) -> int:
    from optinav.cli.common import require_files
    from optinav.reports.report import report_option
    from optinav.reports.result_report import write_result_reports

    require_files(*((r, "result file") for r in args.results), *((d, "--data file") for d in args.data))
    if args.rate_hz is not None and not args.data:
        raise OptinavError("--rate is the sampling rate of the --data recordings", "give --data, or drop --rate")
    if args.time_unit is not None and not args.data:
        raise OptinavError("--time-unit is the unit of the --data recordings' time", "give --data, or drop --time-unit")
    for flag, value in (("--columns", args.columns), ("--gyro", args.gyro_path or None), ("--topic", args.topic)):
        if value is not None and not args.data:
            raise OptinavError(f"{flag} reads the --data recordings", f"give --data, or drop {flag}")
    if args.gyro_path and len(args.gyro_path) != len(args.data):
        raise OptinavError(
            f"{len(args.gyro_path)} --gyro files for {len(args.data)} --data recordings", "give one --gyro per --data"
        )
    require_files(*((g, "--gyro file") for g in args.gyro_path))
    reading = {"columns": args.columns, "topic": args.topic}
    with report_option("--out"):
        written = write_result_reports(
            args.results,
            args.out,
            args.data,
            args.rate_hz,
            time_unit=args.time_unit,
            reading=reading,
            gyro=args.gyro_path,
        )
    print(f"optinav: report written to {written}")
    return 0
