"""``optinav simulate``: write simulated datasets (with truth) in the formats the other commands read."""

from __future__ import annotations

import argparse
import textwrap

from optinav.core.files import SIMULATED
from optinav.cli.common import (
    HEIGHT,
    LATITUDE,
    NON_NEGATIVE,
    POSITIVE,
    RATE,
    SEED,
    check_disk,
    check_memory,
    load_option_result,
    number,
    output_path,
    register_system_hooks,
    truth_path,
    write_truth,
)


#: peak memory per sample of a session written to NPZ/HDF5/MAT, whose blocks are gathered before writing: the
#: gathered and the concatenated samples (t, acc, gyr: 56 B each) and the unit conversion, with margin
BINARY_BYTES_PER_ROW = 300
#: bytes per row of a session written as text (measured: 1.33 GB for 10 M rows in m/s^2 and rad/s)
TEXT_BYTES_PER_ROW = 133


def register(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help="write a simulated dataset with its truth",
        description="Simulate sessions and write them as data files plus a truth JSON.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = p.add_subparsers(dest="kind", metavar="KIND", title="datasets")
    a = kinds.add_parser(
        "accel-multipos",
        help="a static multi-position calibration session (accelerometer + gyroscope)",
        description=textwrap.dedent("""\
            A rest period, then static poses joined by smooth turns, recorded by a unit drawn from an IMU
            preset (default the MTi-1 class of Gao & Zhang 2019). Writes DATA (format by extension: .csv,
            .tsv, .txt, .npz, .h5, .mat) and DATA's stem + '.truth.json' with the true K and b of each triad
            (raw = K·x + b, raw in the written units) and the true static intervals."""),
        epilog=textwrap.dedent("""\
            example:
              optinav simulate accel-multipos --out session.csv --acc-unit counts --gyro-unit deg/s --seed 1
              optinav calibrate accel session.csv --latitude 38.88 --height 35 --out result.json
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    a.add_argument("--out", required=True, metavar="DATA", help="output data file")
    poses = a.add_mutually_exclusive_group()
    poses.add_argument(
        "--scheme",
        choices=["paper12", "six", "18"],
        help="pose scheme: the paper's 12 positions (default), the six axis poses, or 18 poses",
    )
    poses.add_argument(
        "--plan",
        metavar="PLAN.json",
        help="follow a pose plan of optinav design (--out plan.json): its poses in its order and "
        "its rest time per pose (--dwell overrides it)",
    )
    a.add_argument("--preset", default="mems-mti1", help="IMU preset (default mems-mti1)")
    a.add_argument(
        "--truth",
        default="draw",
        choices=["draw", "paper"],
        help="draw the unit's errors from the preset, or use the paper's Table 2 accelerometer",
    )
    a.add_argument("--dwell", type=POSITIVE, metavar="S", help="dwell per pose in s (default 60, or the plan's)")
    a.add_argument(
        "--transition", type=POSITIVE, metavar="S", help="turn duration in s (default 4, or each of the plan's turns)"
    )
    a.add_argument("--rest", type=POSITIVE, default=10.0, metavar="S", help="initial rest in s (default 10)")
    a.add_argument("--rate", dest="rate_hz", type=RATE, metavar="HZ", help="sample rate (default the preset's)")
    a.add_argument(
        "--jitter",
        type=number(0.0, 0.5, what="a fraction of the step"),
        default=0.0,
        help="timestamp jitter as a fraction of the step",
    )
    a.add_argument("--acc-unit", choices=["counts", "g", "m/s^2"], default="m/s^2")
    a.add_argument("--gyro-unit", choices=["counts", "deg/s", "rad/s"], default="rad/s")
    a.add_argument("--latitude", type=LATITUDE, default=38.88, metavar="DEG")
    a.add_argument("--height", dest="height_m", type=HEIGHT, default=35.0, metavar="M")
    a.add_argument("--seed", type=SEED, default=0)
    a.set_defaults(func=run_accel_multipos, progress_task="simulate accel-multipos")
    st = kinds.add_parser(
        "static",
        help="a static log for noise characterisation (optinav allan), with the true noise terms",
        description=textwrap.dedent("""\
            An IMU at rest (z up, gravity along +z, no rotation) with the noise of a preset: white noise
            (ARW/VRW), bias instability as flicker (1/f) noise of the datasheet coefficient B (the IEEE 952
            term, whose Allan floor is 0.664·B) and an optional rate/acceleration random walk. Writes DATA and
            DATA's stem + '.truth.json' with the true N, B and K of each triad in SI units."""),
        epilog=textwrap.dedent("""\
            example:
              optinav simulate static --out rest.csv --hours 2 --gyro-rrw 20
              optinav allan rest.csv --out allan.json --kalibr imu.yaml
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    st.add_argument("--out", required=True, metavar="DATA", help="output data file")
    st.add_argument(
        "--hours",
        type=number(0.0, 1e5, lo_open=True, what="a duration in h"),
        default=1.0,
        help="duration in h, up to 1e5 (default 1)",
    )
    st.add_argument(
        "--preset", default="mems-mti1", help="IMU preset of the white noise and bias instability (default mems-mti1)"
    )
    st.add_argument("--rate", dest="rate_hz", type=RATE, metavar="HZ", help="sample rate (default the preset's)")
    st.add_argument(
        "--gyro-rrw",
        type=NON_NEGATIVE,
        default=0.0,
        metavar="DEG/H/SQRT(H)",
        help="gyro rate random walk in deg/h/sqrt(h) (default 0)",
    )
    st.add_argument(
        "--accel-rrw",
        type=NON_NEGATIVE,
        default=0.0,
        metavar="UG/SQRT(S)",
        help="accelerometer random walk in ug/sqrt(s) (default 0)",
    )
    st.add_argument("--acc-unit", choices=["g", "m/s^2"], default="m/s^2")
    st.add_argument("--gyro-unit", choices=["deg/s", "rad/s"], default="rad/s")
    st.add_argument("--seed", type=SEED, default=0)
    st.set_defaults(func=run_static, progress_task="simulate static")
    register_system_hooks(kinds, "register_simulate")
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_accel_multipos(args) -> int:
    import numpy as np

    from optinav.core.progress import progress, step
    from optinav.io.imu import open_imu_writer
    from optinav.multipos.plan import PosePlan
    from optinav.multipos.simulate import SessionStream

    out = output_path(args.out, mark=SIMULATED)
    truth_path(out)
    scheme, dwell, orientations, turns = args.scheme or "paper12", args.dwell or 60.0, None, args.transition or 4.0
    if args.plan:
        plan = load_option_result(PosePlan, args.plan, "--plan", "the plan.json of optinav design --out plan.json")
        scheme, dwell = np.asarray(plan.up_dirs, float), args.dwell or float(plan.dwell_s)
        orientations = np.asarray(plan.orientations, float)  # its headings too: the turns the plan predicts from
        # and their durations: the gyro noise of a turn grows with its time (4-s turns for the plan's 1.3 s gave a
        # gyro scale 1.3-2.6x worse than the plan predicted)
        turns = args.transition or [float(t["duration_s"]) for t in plan.turns]
    step("simulate")
    stream = SessionStream(
        scheme,
        spec=args.preset,
        dwell_s=dwell,
        rate_hz=args.rate_hz,
        transition_s=turns,
        rest_s=args.rest,
        lat=np.radians(args.latitude),
        height_m=args.height_m,
        truth=args.truth,
        acc_unit=args.acc_unit,
        gyro_unit=args.gyro_unit,
        jitter=args.jitter,
        orientations=orientations,
        rng=args.seed,
    )
    remedy = "shorten --dwell/--rest/--transition or lower --rate"
    if out.suffix.lower() in (".csv", ".tsv", ".txt"):
        check_disk(stream.n, TEXT_BYTES_PER_ROW, out, "this session", remedy)
    else:
        # NPZ/HDF5/MAT hold whole arrays: the blocks are gathered before writing (text streams, memory bounded)
        check_memory(stream.n, BINARY_BYTES_PER_ROW, "this session", "write .csv, or " + remedy)
    with open_imu_writer(
        out,
        acc_unit=None if args.acc_unit == "counts" else args.acc_unit,
        gyro_unit=None if args.gyro_unit == "counts" else args.gyro_unit,
    ) as writer:
        for log in progress(stream.log_blocks(), total=stream.n_blocks(), desc="simulate accel-multipos"):
            writer.write(log)
    step("truth")
    s = stream.session()
    tp = write_truth(
        out,
        s.truth(
            {"latitude_deg": args.latitude, "height_m": args.height_m},
            {"seed": args.seed, "preset": args.preset, "truth": args.truth},
        ),
    )
    print(f"optinav: wrote {stream.n} samples ({len(s.up_dirs)} poses) to {out} and the truth to {tp}")
    for k, d in enumerate(s.descriptions, 1):
        print(f"  pose {k:2d}: {d}")
    return 0


def run_static(args) -> int:
    """``optinav simulate static``: white + flicker + random-walk noise at rest, SI truth beside the data."""
    from optinav.core.imu_model import StaticLogStream, preset
    from optinav.core.progress import progress, step
    from optinav.core.units import to_si
    from optinav.io import ImuLog, open_imu_writer

    out = output_path(args.out, mark=SIMULATED)
    truth_path(out)
    rate = args.rate_hz or preset(args.preset).rate_hz
    stream = StaticLogStream(
        args.hours * 3600,
        args.preset,
        rate_hz=rate,
        acc_random_walk=to_si(args.accel_rrw, "ug/sqrt(s)"),
        gyr_random_walk=to_si(args.gyro_rrw, "deg/h/sqrt(h)"),
        seed=args.seed,
    )
    remedy = "shorten --hours or lower --rate"
    if out.suffix.lower() in (".csv", ".tsv", ".txt"):
        check_disk(stream.n, TEXT_BYTES_PER_ROW, out, "this log", remedy)
    else:
        # NPZ/HDF5/MAT hold whole arrays: the blocks are gathered before writing (text streams, memory bounded)
        check_memory(stream.n, BINARY_BYTES_PER_ROW, "this log", "write .csv, or " + remedy)
    step("simulate")
    with open_imu_writer(out, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit) as writer:
        for t, acc, gyr in progress(stream.blocks(), total=stream.n_blocks(), desc="simulate static"):
            writer.write(ImuLog(t=t, acc=acc, gyr=gyr, source="optinav simulate static"))
    tp = write_truth(out, stream.truth)
    print(f"optinav: wrote {stream.n} samples ({args.hours:g} h at {rate:g} Hz) to {out} and the truth to {tp}")
    return 0
