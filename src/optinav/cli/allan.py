"""``optinav allan DATA``: noise characterisation of a static IMU log (Allan deviation, IEEE Std 952 read-off)."""

from __future__ import annotations

import argparse
import textwrap

from optinav.cli.common import (
    add_chunk_option,
    add_gyro_file_options,
    add_counts_options,
    add_input_options,
    ReaderNotes,
    add_report_option,
    output_path,
    prepare_report,
    print_notes,
    require_files,
)
from optinav.core.files import RESULT_MARK
from optinav.errors import OptinavError


def register(sub) -> None:
    p = sub.add_parser(
        "allan",
        help="noise of a static log: Allan deviation, IEEE 952 read-off, Kalibr noise parameters",
        description=textwrap.dedent("""\
            Overlapping Allan deviation of each accelerometer and gyroscope axis of a static log with its
            68 % confidence band (chi-squared with the equivalent degrees of freedom), the IEEE Std 952
            read-off of the noise terms (white noise N at tau = 1 s on the slope -1/2, bias instability B at the
            flat minimum / 0.664, rate random walk K at tau = 3 s on the slope +1/2, quantization Q on the slope
            -1, rate ramp R at tau = sqrt(2) s on +1) and a least-squares fit of the five-term model to the whole
            curve, with 68 % intervals. A steady drift of the rate (a sensor warming up) is the ramp R, kept out of
            the random walk K (it was taken for K: 2-6 times the truth); a clear one is named in a note, and so is
            a warm-up that settles early in the log (no ramp: it still enters K), by the log's halves' K disagreeing.
            Kalibr's continuous-time noise density is N (unit/sqrt(Hz)) and its random walk K
            (unit/s/sqrt(Hz)), taken from the fit. Record hours at rest; long logs are summed in chunks.
            The random walk comes from the last octaves of the record: in simulations its 68 % interval held
            the truth 64-74 % of the time when the log ran 44 times longer than the cluster time where the curve
            turns upwards, 77-82 % at 10 times (wider intervals: there the ramp and the random walk are hard to
            tell apart), 64-76 % with a warm-up ramp (benchmarks/results_allan_coverage.md)."""),
        epilog=textwrap.dedent("""\
            example (a simulated 2-hour static log in SI units):
              optinav simulate static --out rest.csv --hours 2
              optinav allan rest.csv --out allan.json --report allan-report --kalibr imu.yaml
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "data",
        help="static log: CSV/TSV/text, NPZ, HDF5, MAT, Parquet, a ROS bag or a PX4 ULog (columns and units as in "
        "calibrate)",
    )
    p.add_argument("--out", required=True, metavar="ALLAN.json", help="result file (JSON)")
    p.add_argument(
        "--sensor",
        choices=["both", "acc", "gyro"],
        default="both",
        help="which triads to analyse (default both that the file holds)",
    )
    p.add_argument(
        "--kalibr",
        metavar="IMU.yaml",
        help="also write Kalibr's imu.yaml noise parameters (needs SI data with both triads)",
    )
    p.add_argument(
        "--rostopic",
        metavar="TOPIC",
        help="the IMU topic written into --kalibr (default: a bag's Imu topic, else /imu0)",
    )
    p.add_argument(
        "--allow-rw-bound",
        action="store_true",
        help="--kalibr: write a random walk the log only bounds even when the bound is over 1/s times the noise "
        "density (a log under about a minute at rest; refused without this)",
    )
    add_input_options(p)
    add_counts_options(p)
    add_gyro_file_options(p, "each triad analysed on its own clock and rate (not interpolated)")
    p.add_argument(
        "--fill-gaps",
        action="store_true",
        help="bridge lost samples (a time step of 2-6 intervals: a dropped sample, a line left out by "
        "--skip-bad-lines) by linear interpolation, named in a note; at most 0.1%% of the log",
    )
    add_chunk_option(
        p, "the angle sums are kept: 8 B per sample and axis (48 B with both triads; 0.5 GB per hour at 1 kHz)"
    )
    add_report_option(p)
    p.set_defaults(func=run, progress_task="allan")


def run(args) -> int:
    require_files((args.data, "data file"), (args.gyro_path, "--gyro file"))
    if args.gyro_path and args.sensor != "both":
        raise OptinavError(
            "--gyro gives the gyroscope and DATA the accelerometer: --sensor does not apply", "drop --sensor"
        )
    out = output_path(args.out, (".json",), "allan.json", mark=RESULT_MARK)
    kalibr = output_path(args.kalibr, (".yaml", ".yml"), "imu.yaml", option="--kalibr") if args.kalibr else None
    if kalibr is not None and kalibr.resolve() == out.resolve():
        raise OptinavError("--kalibr and --out name the same file", "give --kalibr another name, e.g. imu.yaml")
    prepare_report(args)
    from optinav.core.progress import step

    step("read")
    notes = ReaderNotes()
    res = _analyse(args, notes, need_kalibr=kalibr is not None)
    bounds = _random_walk_bounds(args, res, kalibr)
    step("write")
    res.to_json(out)
    notes.print()
    print_notes(res.notes)
    print(res.summary())
    print(f"optinav: result written to {out}")
    if kalibr is not None:
        from optinav.multipos.kalibr import DEFAULT_ROSTOPIC_NOTE, write_kalibr_imu_yaml

        write_kalibr_imu_yaml(kalibr, noise=res, option="--kalibr", allow_rw_bound=args.allow_rw_bound)
        print(f"optinav: Kalibr imu.yaml written to {kalibr}")
        print_notes(bounds)
        if not res.rostopic:
            print_notes([DEFAULT_ROSTOPIC_NOTE])
    if args.report:
        from optinav.reports.allan_report import write_allan_report

        print(f"optinav: report written to {write_allan_report(res, args.report)}/index.md")
    return 0


def _random_walk_bounds(args, res, kalibr) -> list[str]:
    """The notes naming Kalibr's random walks that are bounds only; a meaningless bound refused unless
    --allow-rw-bound. Checked before any file is written: a refusal leaves no allan.json beside a missing yaml."""
    if kalibr is None:
        if args.allow_rw_bound:
            raise OptinavError("--allow-rw-bound is for --kalibr", "drop --allow-rw-bound, or add --kalibr IMU.yaml")
        return []
    from optinav.multipos.kalibr import random_walk_bounds

    return random_walk_bounds(res, allow=args.allow_rw_bound)


def _analyse(args, notes: ReaderNotes, need_kalibr: bool):
    """The analysis of DATA (and of --gyro GYRODATA), with Kalibr's rostopic: --rostopic, else a bag's Imu topic."""
    from optinav.core.allan import analyse_blocks, analyse_pair

    topic = args.rostopic or ""
    stated = dict(gyro_unit_stated=args.gyro_unit is not None)
    if not args.gyro_path:
        from optinav.io.imu import reader_options, sensor_logs

        # several sensors' rows in one file: each triad on its own rows and clock, as two files are
        pair = sensor_logs(args.data, **reader_options(args, gyro_path=None, gyro_columns=None))
        if pair is not None:
            acc, gyr = (list(notes.watch([log])) for log in pair)
            if args.sensor != "both":
                return analyse_blocks(
                    acc if args.sensor == "acc" else gyr,
                    args.sensor,
                    source=str(args.data),
                    rostopic=topic,
                    need_kalibr=need_kalibr,
                    **stated,
                )
            res = analyse_pair(
                acc, gyr, sources=(str(args.data),) * 2, rostopic=topic, need_kalibr=need_kalibr, **stated
            )
            res.source = str(args.data)  # one file
            return res
    blocks = _blocks(args, args.data, args.columns, notes)
    if args.gyro_path:
        gyro = _blocks(args, args.gyro_path, args.gyro_columns, notes)
        res = analyse_pair(
            blocks,
            gyro,
            sources=(str(args.data), str(args.gyro_path)),
            rostopic=topic,
            need_kalibr=need_kalibr,
            **stated,
        )
        res.notes += gyro.filled
    else:
        res = analyse_blocks(
            blocks, args.sensor, source=str(args.data), rostopic=topic, need_kalibr=need_kalibr, **stated
        )
    res.notes += blocks.filled
    table = blocks.chunks.table  # not a placeholder: a bag's topic
    res.rostopic = res.rostopic or (table.meta.get("topic", "") if table is not None else "")
    return res


class _Watched:
    """A file's blocks with progress and their notes gathered (``fill``: lost samples bridged, noted in
    ``filled``); ``chunks`` keeps the reader (its table's meta)."""

    def __init__(self, chunks, notes: ReaderNotes, what: str, fill: bool = False):
        from optinav.core.allan import fill_gaps
        from optinav.core.progress import progress_blocks

        self.chunks, self.filled = chunks, []
        blocks = progress_blocks(chunks, what)
        self._it = notes.watch(fill_gaps(blocks, self.filled) if fill else blocks)

    def __iter__(self):
        return iter(self._it)


def _blocks(args, path, columns, notes: ReaderNotes) -> _Watched:
    """The blocks of one file read with the command's input options."""
    from optinav.io.imu import iter_imu, reader_options

    # each file on its own (the gyroscope's file is read as a second log on its own clock, not paired)
    kw = reader_options(args, columns=columns, gyro_path=None, gyro_columns=None)
    chunks = iter_imu(path, chunk_rows=args.chunk_rows, **kw)
    return _Watched(chunks, notes, "allan: read", fill=args.fill_gaps)
