"""``optinav simulate rins`` and ``optinav calibrate rins``: dual-axis rotational INS gimbal non-orthogonality."""

from __future__ import annotations

import argparse
import textwrap

from optinav.core.files import SIMULATED
from optinav.cli.common import (
    COUNT,
    LATITUDE,
    NON_NEGATIVE,
    POSITIVE,
    RATE,
    SEED,
    add_report_option,
    check_disk,
    check_memory,
    output_path,
    parse_floats,
    require_files,
    truth_path,
    write_truth,
)


def register_simulate(kinds) -> None:
    p = kinds.add_parser(
        "rins",
        help="a dual-axis rotational INS session with gimbal non-orthogonality (static base)",
        description=textwrap.dedent("""\
            A static alignment phase, then a gimbal rotation scheme (default the PSINS improved 16-position
            sequence), recorded by a navigation-grade RLG IMU (paper Table 1) at 200 Hz with inner/outer encoder
            angles. Writes DATA (.npz, .csv or .h5; columns t, dtheta_x..z [rad], dv_x..z [m/s], alpha, beta
            [rad]) and DATA's stem + '.truth.json' with the six true angles in rad. A .csv is generated and
            written block by block (memory does not grow with the session); .npz and .h5 hold whole arrays (about
            80 B per sample in memory) and are refused up front when they would not fit."""),
        epilog=textwrap.dedent("""\
            example:
              (the paper's Table 3 angles, read as radians)
              optinav simulate rins --nonorth=-0.000279,-0.000963,-0.002212,0.000721,-0.000806,-0.009205 --out rins.npz
              optinav calibrate rins rins.npz --out result.json
            schemes: psins16 (default), dual4, single4 (inner axis only), or steps such as 'Z+180,Y-180,Z-180,Y+180'
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--nonorth",
        required=True,
        metavar="TX,TY,TZ,EX,EY,EZ",
        help="true theta_x,theta_y,theta_z,eta_x,eta_y,eta_z (in --unit); write --nonorth=-1e-4,... "
        "when the first value is negative",
    )
    p.add_argument("--unit", choices=["rad", "deg"], default="rad", help="unit of --nonorth (default rad)")
    p.add_argument("--scheme", default="psins16", help="rotation scheme (default psins16)")
    p.add_argument("--cycles", type=COUNT, default=1, help="repetitions of the scheme (default 1)")
    p.add_argument("--move", type=POSITIVE, default=10.0, metavar="S", help="duration of each 180° move (default 10 s)")
    p.add_argument("--dwell", type=POSITIVE, default=50.0, metavar="S", help="rest after each move (default 50 s)")
    p.add_argument(
        "--align", type=POSITIVE, default=600.0, metavar="S", help="initial static alignment (default 600 s)"
    )
    p.add_argument(
        "--rate", dest="rate_hz", type=RATE, default=200.0, metavar="HZ", help="sample rate (default 200 Hz)"
    )
    p.add_argument("--lat", type=LATITUDE, default=28.2, metavar="DEG", help="latitude in degrees (default 28.2)")
    p.add_argument(
        "--gyro-misalignment-arcsec",
        type=NON_NEGATIVE,
        metavar="ARCSEC",
        help="1σ of each gyro misalignment term (default the preset's 5)",
    )
    p.add_argument("--gyro-scale-ppm", type=NON_NEGATIVE, metavar="PPM", help="1σ gyro scale error (default 2)")
    p.add_argument(
        "--lock-error-arcsec",
        type=NON_NEGATIVE,
        default=0.0,
        metavar="ARCSEC",
        help="1σ gimbal stop error not seen by the encoders (default 0)",
    )
    p.add_argument("--wobble-arcsec", type=NON_NEGATIVE, default=0.0, metavar="ARCSEC", help="axis wobble amplitude")
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument("--out", required=True, metavar="DATA", help="output file (.npz, .csv, .h5)")
    p.set_defaults(func=run_simulate, progress_task="simulate rins")


def _parse_nonorth(text: str, unit: str) -> "np.ndarray":  # noqa: F821 - numpy is imported inside (a fast --help)
    import numpy as np

    v = np.asarray(parse_floats(text, 6, "--nonorth", "THETA_X,THETA_Y,THETA_Z,ETA_X,ETA_Y,ETA_Z"))
    return np.radians(v) if unit == "deg" else v


#: bytes per row of a session written as CSV (nine %.17g columns; measured: 191 B per row), with margin
TEXT_BYTES_PER_ROW = 220
#: peak memory per row of a session written to NPZ/HDF5, whose blocks are gathered into whole arrays before
#: writing (measured: 78 B per row over a fixed ~260 MiB; the columns are 72 B), with margin
BINARY_BYTES_PER_ROW = 150


def run_simulate(args) -> int:
    """``optinav simulate rins``: CSV generated and written block by block; NPZ/HDF5 gathered, then written."""
    import numpy as np

    from optinav.core.progress import progress, step
    from optinav.rins.calibrate import simulation_truth
    from optinav.rins.io import file_format, rins_csv_writer, write_rins
    from optinav.rins.simulate import RinsStream

    out = output_path(args.out, mark=SIMULATED)
    truth_path(out)
    kind = file_format(out, writing=True)
    p = _parse_nonorth(args.nonorth, args.unit)
    arc = np.radians(1 / 3600)
    step("simulate")
    stream = RinsStream(
        p,
        scheme=args.scheme,
        cycles=args.cycles,
        move_s=args.move,
        dwell_s=args.dwell,
        align_s=args.align,
        rate_hz=args.rate_hz,
        lat=np.radians(args.lat),
        gyro_misalignment=None if args.gyro_misalignment_arcsec is None else args.gyro_misalignment_arcsec * arc,
        gyro_scale=None if args.gyro_scale_ppm is None else args.gyro_scale_ppm * 1e-6,
        lock_sigma=args.lock_error_arcsec * arc,
        wobble=args.wobble_arcsec * arc,
        rng=args.seed,
    )
    remedy = "shorten --align/--dwell/--move, fewer --cycles or a lower --rate"
    blocks = progress(stream.blocks(), total=stream.n_blocks(), desc="simulate rins")
    if kind == "csv":
        check_disk(stream.n, TEXT_BYTES_PER_ROW, out, "this session", remedy)
        with rins_csv_writer(out, stream.lat, stream.height_m) as write:
            for block in blocks:
                write(*block)
    else:
        # NPZ/HDF5 hold whole arrays: the blocks are gathered before writing (CSV streams, memory bounded)
        check_memory(stream.n, BINARY_BYTES_PER_ROW, "this session", "write .csv, or " + remedy)
        write_rins(out, stream.gather(blocks))
    step("truth")
    truth = simulation_truth(stream.data(), seed=args.seed, lat_deg=args.lat, encoders=stream.encoder_samples())
    tp = write_truth(out, truth)
    print(
        f"optinav: wrote {stream.n} samples ({stream.n / args.rate_hz:.0f} s at {args.rate_hz:g} Hz, "
        f"{len(stream.info['steps'])} moves) to {out} and the truth to {tp}"
    )
    return 0


def register_calibrate(kinds) -> None:
    p = kinds.add_parser(
        "rins",
        help="gimbal non-orthogonality of a dual-axis rotational INS (static base)",
        description=textwrap.dedent("""\
            Calibrate the six non-orthogonality angles of Li et al. (2023) from a static-base recording: alignment
            on the initial rest, strapdown C_s^n, then the vehicle-attitude change of eqs. 12-14 minimized by
            'lm' (default: Levenberg-Marquardt with the analytic Jacobian on the observable subspace), 'pso' (as
            published), 'axis' (rotation-axis vectors from the gyros) or 'none' (uncompensated). Angles that are
            not observable (for +-180 deg dual-axis schemes theta_z - eta_z and eta_y) are written as null."""),
        epilog=textwrap.dedent("""\
            example:
              (the paper's Table 3 angles, read as radians)
              optinav simulate rins --nonorth=-0.000279,-0.000963,-0.002212,0.000721,-0.000806,-0.009205 --out rins.npz
              optinav calibrate rins rins.npz --method lm --out result.json --report rep
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "data",
        help="data file (.csv .txt .tsv .dat, .npz, .h5, .mat, …) with t (or time), dtheta_x..z, dv_x..z, alpha, beta",
    )
    add_batch_options(p)
    p.add_argument("--out", required=True, metavar="RESULT.json", help="result file (JSON)")
    add_report_option(p)
    p.set_defaults(func=run_calibrate, progress_task="calibrate rins")


def add_batch_options(p) -> None:
    """``optinav batch calibrate rins``: the options of ``calibrate rins`` (registry hook; destinations are the
    fields of :class:`optinav.rins.unit.RinsOptions`)."""
    p.add_argument("--method", choices=["lm", "pso", "axis", "none"], default="lm", help="method (default lm)")
    p.add_argument(
        "--lat", dest="lat_deg", type=LATITUDE, metavar="DEG", help="latitude in degrees (default: from each file)"
    )
    p.add_argument(
        "--align",
        dest="align_s",
        type=POSITIVE,
        metavar="S",
        help="longest alignment window (default: the initial rest)",
    )
    p.add_argument(
        "--residual-rate",
        dest="residual_rate_hz",
        type=RATE,
        default=10.0,
        metavar="HZ",
        help="epochs per second of the attitude residuals (default 10)",
    )
    p.add_argument("--seed", type=SEED, default=0, help="random seed of PSO (default 0)")
    p.add_argument(
        "--gyro-misalignment-arcsec",
        dest="gyro_misalignment_arcsec",
        type=NON_NEGATIVE,
        default=5.0,
        metavar="ARCSEC",
        help="1σ of the gyro triad's uncalibrated misalignment in the std (default 5, a navigation-grade RLG)",
    )
    p.add_argument(
        "--gyro-scale-ppm",
        dest="gyro_scale_ppm",
        type=NON_NEGATIVE,
        default=2.0,
        metavar="PPM",
        help="1σ of its uncalibrated scale errors in the std (default 2)",
    )


def add_apply_options(g) -> None:
    """``optinav apply`` of a rins result: how the recording is aligned (registry hook; destinations are fields
    of :class:`optinav.rins.unit.RinsOptions`)."""
    g.add_argument(
        "--lat", dest="lat_deg", type=LATITUDE, metavar="DEG", help="latitude in degrees (default: from the file)"
    )
    g.add_argument(
        "--align",
        dest="align_s",
        type=POSITIVE,
        metavar="S",
        help="longest alignment window (default: the initial rest)",
    )


#: peak memory per row of ``calibrate rins`` on a text file, read block by block in two passes (measured at 200 Hz
#: with 10 Hz residual epochs: 65 B per row above a fixed ~300 MiB — per residual epoch C_s^n, the encoder angles,
#: the gimbal rotations and the 9 gyro re-integrations as quaternions, plus the fit's Jacobian), with margin
CALIBRATE_BYTES_PER_ROW = 100
#: NPZ and HDF5 are read whole by their libraries in each pass: their columns (72 B per row) and the increments
#: joined (48 B per row) on top, with margin
CALIBRATE_BINARY_BYTES_PER_ROW = 300


def run_calibrate(args) -> int:
    require_files((args.data, "data file"))
    from optinav.cli.calibrate import calibrate_unit
    from optinav.rins.io import file_format, row_estimate

    binary = file_format(args.data) != "csv"
    check_memory(
        row_estimate(args.data),
        CALIBRATE_BINARY_BYTES_PER_ROW if binary else CALIBRATE_BYTES_PER_ROW,
        f"calibrating {args.data}",
        "calibrate a shorter part of the recording (the alignment rest and whole rotation cycles)",
    )

    return calibrate_unit(args, "rins")
