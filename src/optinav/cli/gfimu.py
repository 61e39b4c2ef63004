"""``optinav gfimu analyze``, ``optinav simulate gfimu-turntable`` and ``optinav calibrate gfimu``.

Gyro-free IMU (accelerometer array): identifiability of a configuration, simulation of the turntable
calibration of Hao & Liu (2011) and the calibration of the 5 installation errors per accelerometer.
"""

from __future__ import annotations

import argparse
import math
import textwrap

from optinav.cli.common import (
    NON_NEGATIVE,
    POSITIVE,
    RATE,
    SEED,
    add_report_option,
    check_disk,
    check_memory,
    number,
    output_path,
    parse_floats,
    require_files,
    truth_path,
    write_truth,
)
from optinav.core.files import SIMULATED
from optinav.errors import OptinavError


#: fastest turntable rate accepted (rad/s, about 480 rpm): beyond it the centripetal terms dwarf gravity
MAX_TABLE_RATE = 50.0


def _load_array(config: str | None, builtin_name: str | None):
    from optinav.gfimu.unit import GfimuOptions

    return GfimuOptions(config=config, builtin=builtin_name).array()


# ------------------------------------------------------------------------------------------------------------
# optinav gfimu analyze
# ------------------------------------------------------------------------------------------------------------


def register_commands(sub) -> None:
    """The system's top-level command (registry hook)."""
    register(sub)


def register(sub) -> None:
    p = sub.add_parser(
        "gfimu",
        help="gyro-free IMU: identifiability of an accelerometer array",
        description="Gyro-free IMU (accelerometer array) tools.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    cmds = p.add_subparsers(dest="gfimu_command", metavar="COMMAND", title="commands")
    a = cmds.add_parser(
        "analyze",
        help="what an accelerometer configuration can solve",
        description=textwrap.dedent("""\
            Identifiability of an N-accelerometer array, f_i = θ_iᵀ(A + ω̇×r_i + ω×(ω×r_i)): the rank of the
            part linear in [A, ω̇], the rank with the six quadratic rate terms, how many quadratic combinations
            are observable and which components of A and ω̇ are solvable without knowing ω.
            CONFIG.json: {"accelerometers": [{"position": [x, y, z] (m), "direction": [x, y, z] (unit),
            "noise": σ (m/s², optional)}, ...]}. A configuration that cannot solve [A, ω̇] even with the rate
            known is an error naming what cannot be solved (--allow-deficient writes the analysis anyway)."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav gfimu analyze --builtin cylinder10 --out cyl.json
              optinav gfimu analyze my_array.json
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    a.add_argument("config", nargs="?", metavar="CONFIG.json", help="configuration file")
    a.add_argument("--builtin", choices=["cylinder10"], help="a built-in configuration instead of CONFIG.json")
    a.add_argument("--out", metavar="FILE", help="write the analysis as JSON")
    a.add_argument(
        "--allow-deficient", action="store_true", help="report a rank-deficient configuration instead of failing"
    )
    a.set_defaults(func=run_analyze)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_analyze(args) -> int:
    require_files((args.config, "configuration file"))
    from optinav.core.files import write_json
    from optinav.core.results import plain
    from optinav.gfimu.array import identifiability

    arr = _load_array(args.config, args.builtin)
    out = output_path(args.out, (".json",), "analysis.json", mark=b'"n_accelerometers"') if args.out else None
    idf = identifiability(arr)
    if not args.allow_deficient:
        idf.require(("linear",))
    data = idf.to_summary()
    data["positions_m"] = arr.positions.tolist()
    data["directions"] = arr.directions.tolist()
    if out:
        write_json(out, plain(data))  # non-finite numbers (an unsolvable term's std) as null
    print(idf.summary())
    if out:
        print(f"optinav: analysis written to {out}")
    return 0


# ------------------------------------------------------------------------------------------------------------
# optinav simulate gfimu-turntable
# ------------------------------------------------------------------------------------------------------------


def register_simulate(kinds) -> None:
    s = kinds.add_parser(
        "gfimu-turntable",
        help="turntable calibration data of a gyro-free accelerometer array",
        description=textwrap.dedent("""\
            The six calibration cases of Hao & Liu (2011): the array on a wedge of angle γ on a horizontal
            turntable at constant rate, table axis in the body x–z, y–z and x–y planes (mountings 1, 2, 3), two
            rates each; gravity included, Earth rate neglected. Installation errors: the paper's (Δr = 1 mm on
            every axis, Δα = Δβ = 0.01 rad) or random. Writes DATA (.npz, .csv or .h5: t, f1..fN or f, case,
            mounting, table_rate (rad/s), wedge (rad), gravity (m/s²)) and DATA's stem + '.truth.json'. A .csv is
            generated and written block by block (memory does not grow with the data set; about 15 B per output
            and row on disk, refused up front when it would not fit); .npz and .h5 hold whole arrays (about
            8 B per output and row plus 60 B in memory) and are refused up front when they would not fit."""),
        epilog=textwrap.dedent("""\
            example:
              optinav simulate gfimu-turntable --builtin cylinder10 --rates 0.5,1.0 --out tt.npz --seed 1
              optinav calibrate gfimu tt.npz --builtin cylinder10 --out result.json --report rep
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    s.add_argument("--config", metavar="CONFIG.json", help="array configuration (default --builtin cylinder10)")
    s.add_argument("--builtin", choices=["cylinder10"], help="built-in configuration")
    s.add_argument("--out", required=True, metavar="DATA", help="output data file (.npz, .csv, .h5)")
    s.add_argument("--rates", default="0.5,1.0", metavar="W1,W2", help="table rates in rad/s (default 0.5,1.0)")
    s.add_argument(
        "--wedge-deg",
        type=number(0.0, 90.0, lo_open=True, what="a wedge angle in degrees"),
        default=30.0,
        metavar="DEG",
        help="wedge angle γ (default 30)",
    )
    s.add_argument(
        "--errors",
        choices=["paper", "random"],
        default="paper",
        help="installation errors: the paper's uniform ones (default) or random (1 mm, 0.01 rad std)",
    )
    s.add_argument(
        "--noise",
        type=NON_NEGATIVE,
        default=1e-6 * 9.80665,
        metavar="M/S2",
        help="accelerometer white noise std per sample (default 1 µg)",
    )
    s.add_argument("--sample-rate", type=RATE, default=100.0, metavar="HZ", help="sample rate (default 100)")
    s.add_argument("--duration", type=POSITIVE, default=10.0, metavar="S", help="seconds per case (default 10)")
    s.add_argument("--offset", metavar="X,Y,Z", help="array centre from the table axis, body m (default 0)")
    s.add_argument("--seed", type=SEED, default=0)
    s.set_defaults(func=run_simulate, progress_task="simulate gfimu-turntable")


def text_bytes_per_row(n_accelerometers: int) -> int:
    """Bytes on disk per CSV row of ``optinav simulate gfimu-turntable`` assumed by its up-front check: measured
    182-184 B per row for 10 accelerometers (about 15 B per output, 35 B for t, case, mounting, table_rate, wedge and
    gravity), assumed 20 B per output + 80 B."""
    return 20 * n_accelerometers + 80


def binary_bytes_per_row(n_accelerometers: int) -> int:
    """Peak memory per row of ``optinav simulate gfimu-turntable`` to NPZ/HDF5 assumed by its up-front check: the
    blocks gathered into whole arrays (t, the N outputs, mounting, rate: 8 N + 24 B) and the file's columns built on
    writing (case, mounting, wedge, gravity); measured 145 B per row over a fixed ~120 MiB for 10 accelerometers,
    assumed 12 B per output + 100 B."""
    return 12 * n_accelerometers + 100


def run_simulate(args) -> int:
    """``optinav simulate gfimu-turntable``: CSV generated and written block by block; NPZ/HDF5 gathered, then
    written."""
    from optinav.core.progress import progress, step
    from optinav.gfimu.errors import InstallationErrors
    from optinav.gfimu.turntable import TurntableStream, turntable_csv_writer, turntable_truth

    arr = _load_array(args.config, args.builtin or (None if args.config else "cylinder10"))
    out = output_path(args.out, (".npz", ".csv", ".h5", ".hdf5"), "data.npz", mark=SIMULATED)
    truth_path(out)
    rates = parse_floats(args.rates, None, "--rates", "W1,W2")
    if not all(0 < w <= MAX_TABLE_RATE for w in rates):
        raise OptinavError(
            f"--rates {args.rates}: table rates must be in (0, {MAX_TABLE_RATE:g}] rad/s",
            "give turntable rates in rad/s, e.g. --rates 0.5,1.0",
        )
    e = (
        InstallationErrors.uniform(arr.n)
        if args.errors == "paper"
        else InstallationErrors.random(arr.n, rng=args.seed + 1)
    )
    off = parse_floats(args.offset, 3, "--offset", "X,Y,Z") if args.offset else None
    step("simulate")
    stream = TurntableStream(
        arr,
        e,
        rates=rates,
        gamma=math.radians(args.wedge_deg),
        rate_hz=args.sample_rate,
        duration=args.duration,
        noise=args.noise,
        offset=off,
        rng=args.seed,
    )
    remedy = "shorten --duration or lower --sample-rate"
    blocks = progress(stream.blocks(), total=stream.n_blocks(), desc="simulate gfimu-turntable")
    if out.suffix.lower() == ".csv":
        check_disk(stream.n, text_bytes_per_row(arr.n), out, "this data set", remedy)
        with turntable_csv_writer(out, arr.n, stream.gamma, stream.gravity) as write:
            for block in blocks:
                write(*block)
    else:
        # NPZ/HDF5 hold whole arrays: the blocks are gathered before writing (CSV streams, memory bounded)
        check_memory(stream.n, binary_bytes_per_row(arr.n), "this data set", "write .csv, or " + remedy)
        stream.gather(blocks).save(out)
    step("truth")
    tp = write_truth(
        out,
        turntable_truth(
            e,
            {
                "noise_m_s2": args.noise,
                "offset_m": off,
                "rates_rad_s": rates,
                "wedge_deg": args.wedge_deg,
                "samples_per_case": stream.n_case,
            },
        ),
    )
    print(f"optinav: {stream.n} samples ({stream.n // stream.n_case} cases) written to {out}, truth to {tp}")
    return 0


# ------------------------------------------------------------------------------------------------------------
# optinav calibrate gfimu
# ------------------------------------------------------------------------------------------------------------


def register_calibrate(kinds) -> None:
    c = kinds.add_parser(
        "gfimu",
        help="installation errors of a gyro-free accelerometer array from turntable data",
        description=textwrap.dedent("""\
            Estimate the position (Δr, m) and direction (Δα, Δβ, rad) installation errors of every
            accelerometer of an array from the six turntable cases of Hao & Liu (2011). Default: nonlinear
            least squares over the case means (Levenberg–Marquardt, analytic Jacobian) with covariance and
            CRLB; --method closed-form: the paper's differences between the two rates. DATA as written by
            `optinav simulate gfimu-turntable` (docs/methods/gfimu.md)."""),
        epilog=textwrap.dedent("""\
            example:
              optinav simulate gfimu-turntable --builtin cylinder10 --out tt.npz
              optinav calibrate gfimu tt.npz --builtin cylinder10 --out result.json
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    c.add_argument("data", metavar="DATA", help="turntable data (.npz, .csv, .h5)")
    add_batch_options(c)
    c.add_argument("--out", required=True, metavar="RESULT.json", help="result file (JSON)")
    add_report_option(c)
    c.set_defaults(func=run_calibrate, progress_task="calibrate gfimu")


def _offset(text: str):
    """--offset of the batch: 'unknown', 'zero', 'estimate' or X,Y,Z in m (argparse type)."""
    t = text.strip()
    if t in ("unknown", "zero", "estimate"):
        return t
    try:
        return tuple(parse_floats(t, 3, "--offset", "X,Y,Z"))
    except OptinavError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_batch_options(p) -> None:
    """``optinav batch calibrate gfimu``: the options of ``calibrate gfimu`` (registry hook; destinations are
    the fields of :class:`optinav.gfimu.unit.GfimuOptions`)."""
    p.add_argument("--config", metavar="CONFIG.json", help="nominal array configuration")
    p.add_argument("--builtin", choices=["cylinder10"], help="built-in nominal configuration")
    p.add_argument("--method", choices=["lm", "closed-form"], default="lm", help="estimator (default lm)")
    p.add_argument(
        "--offset",
        type=_offset,
        default="unknown",
        metavar="X,Y,Z",
        help="measured array centre from the table axis, body m; 'zero' for a centred array (absolute dr); "
        "default unknown: dr relative to their mean, the common shift is not observable",
    )
    p.add_argument(
        "--rate-unit",
        choices=["rad/s", "deg/s"],
        default="rad/s",
        help="unit of the table_rate column (default rad/s, as optinav writes it)",
    )
    p.add_argument("--noise", type=POSITIVE, metavar="M/S2", help="accelerometer noise std (default: from the data)")
    p.add_argument(
        "--rate-accuracy",
        type=NON_NEGATIVE,
        default=0.0,
        metavar="REL",
        help="relative 1σ of the table rates, e.g. 1e-4 (default 0: exact); a rate error moves the positions by "
        "2e·r, which the data cannot tell apart, so it goes into their std",
    )


def add_apply_options(g) -> None:
    """``optinav apply`` of a gfimu result: how the motion is solved (registry hook; destinations are the
    fields of :class:`optinav.gfimu.unit.GfimuApplyOptions`)."""
    g.add_argument(
        "--omega0",
        type=_vector,
        metavar="X,Y,Z",
        help="angular rate at the first sample in rad/s (default 0: the array starts at rest)",
    )
    # the methods are checked by the library (optinav.gfimu.solve.RATE_METHODS; importing it here would load
    # numpy for every --help)
    g.add_argument(
        "--rate-method",
        default="integration",
        metavar="METHOD",
        help="how the angular rate is solved: integration (default, the paper's), gauss-newton (a Kalman filter of "
        "the rate on the outputs: holds at high rates where the integration drifts; ~0.3 ms a sample) or quadratic "
        "(an ideal geometry only, such as the nominal cylinder10: not a calibrated one)",
    )


def _vector(text: str):
    """X,Y,Z (argparse type)."""
    try:
        return tuple(parse_floats(text, 3, "--omega0", "X,Y,Z"))
    except OptinavError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def run_calibrate(args) -> int:
    require_files((args.data, "data file"), (args.config, "configuration file"))
    from optinav.cli.calibrate import calibrate_unit

    return calibrate_unit(args, "gfimu")
