"""``optinav simulate``: write simulated datasets (with truth) in the formats the other commands read."""

from __future__ import annotations

import argparse
import textwrap

from optinav.errors import OptinavError
from optinav.cli.common import (HEIGHT, LATITUDE, NON_NEGATIVE, POSITIVE, RATE, SEED, check_memory, number,
                                output_path,
                                register_system_hooks, truth_path, write_truth)


def register(sub) -> None:
    p = sub.add_parser("simulate", help="write a simulated dataset with its truth",
                       description="Simulate sessions and write them as data files plus a truth JSON.",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    kinds = p.add_subparsers(dest="kind", metavar="KIND", title="datasets")
    a = kinds.add_parser(
        "accel-multipos", help="a static multi-position calibration session (accelerometer + gyroscope)",
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
        formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("--out", required=True, metavar="DATA", help="output data file")
    a.add_argument("--scheme", default="paper12", choices=["paper12", "six", "18"],
                   help="pose scheme: the paper's 12 positions (default), the six axis poses, or 18 poses")
    a.add_argument("--preset", default="mems-mti1", help="IMU preset (default mems-mti1)")
    a.add_argument("--truth", default="draw", choices=["draw", "paper"],
                   help="draw the unit's errors from the preset, or use the paper's Table 2 accelerometer")
    a.add_argument("--dwell", type=POSITIVE, default=60.0, metavar="S", help="dwell per pose in s (default 60)")
    a.add_argument("--transition", type=POSITIVE, default=4.0, metavar="S", help="turn duration in s (default 4)")
    a.add_argument("--rest", type=POSITIVE, default=10.0, metavar="S", help="initial rest in s (default 10)")
    a.add_argument("--rate", type=RATE, metavar="HZ", help="sample rate (default the preset's)")
    a.add_argument("--jitter", type=number(0.0, 0.5, what="a fraction of the step"), default=0.0,
                   help="timestamp jitter as a fraction of the step")
    a.add_argument("--acc-unit", choices=["counts", "g", "m/s^2"], default="m/s^2")
    a.add_argument("--gyro-unit", choices=["counts", "deg/s", "rad/s"], default="rad/s")
    a.add_argument("--latitude", type=LATITUDE, default=38.88, metavar="DEG")
    a.add_argument("--height", type=HEIGHT, default=35.0, metavar="M")
    a.add_argument("--seed", type=SEED, default=0)
    a.set_defaults(func=run_accel_multipos, progress_task="simulate accel-multipos")
    st = kinds.add_parser(
        "static", help="a static log for noise characterisation (optinav allan), with the true noise terms",
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
        formatter_class=argparse.RawDescriptionHelpFormatter)
    st.add_argument("--out", required=True, metavar="DATA", help="output data file")
    st.add_argument("--hours", type=POSITIVE, default=1.0, help="duration in h (default 1)")
    st.add_argument("--preset", default="mems-mti1", help="IMU preset of the white noise and bias instability "
                                                          "(default mems-mti1)")
    st.add_argument("--rate", type=RATE, metavar="HZ", help="sample rate (default the preset's)")
    st.add_argument("--gyro-rrw", type=NON_NEGATIVE, default=0.0, metavar="DEG/H/SQRT(H)",
                    help="gyro rate random walk in deg/h/sqrt(h) (default 0)")
    st.add_argument("--accel-rrw", type=NON_NEGATIVE, default=0.0, metavar="UG/SQRT(S)",
                    help="accelerometer random walk in ug/sqrt(s) (default 0)")
    st.add_argument("--acc-unit", choices=["g", "m/s^2"], default="m/s^2")
    st.add_argument("--gyro-unit", choices=["deg/s", "rad/s"], default="rad/s")
    st.add_argument("--seed", type=SEED, default=0)
    st.set_defaults(func=run_static, progress_task="simulate static")
    register_system_hooks(kinds, "register_simulate")
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_accel_multipos(args) -> int:
    import numpy as np

    from optinav.core.progress import step
    from optinav.core.units import factor
    from optinav.io import ImuLog, write_imu
    from optinav.multipos.simulate import simulate

    out = output_path(args.out)
    truth_path(out)
    from optinav.core.imu_model import preset
    from optinav.multipos.simulate import SCHEMES

    rate = args.rate or preset(args.preset).sample_rate
    # measured (benchmarks/bench_memory.py, 1 M and 3 M rows): about 615 B per sample at the peak now that the
    # log is written block by block, 900 with margin
    check_memory(rate * (args.rest + len(SCHEMES[args.scheme]) * (args.dwell + args.transition)), 900,
                 "this session", "shorten --dwell/--rest/--transition or lower --rate")
    step("simulate")
    s = simulate(args.scheme, spec=args.preset, dwell_s=args.dwell, rate_hz=args.rate,
                 transition_s=args.transition, rest_s=args.rest, lat=np.radians(args.latitude),
                 height_m=args.height, truth=args.truth, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                 jitter=args.jitter, rng=args.seed)
    # the log holds SI or counts; write_imu converts SI back to the requested file unit
    acc = s.acc if args.acc_unit in ("counts", "m/s^2") else s.acc * factor(args.acc_unit)
    gyro = s.gyro if args.gyro_unit in ("counts", "rad/s") else s.gyro * factor(args.gyro_unit)
    log = ImuLog(t=s.t, acc=acc, gyr=gyro, acc_unit="counts" if args.acc_unit == "counts" else "m/s^2",
                 gyro_unit="counts" if args.gyro_unit == "counts" else "rad/s", source="optinav simulate")
    step("write")
    write_imu(out, log, acc_unit=None if args.acc_unit == "counts" else args.acc_unit,
              gyro_unit=None if args.gyro_unit == "counts" else args.gyro_unit)
    from optinav.multipos.result import session_truth

    info = {"model": "raw = K x + b",
             "units": {"accelerometer_raw": args.acc_unit, "accelerometer": "m/s^2",
                       "gyroscope_raw": args.gyro_unit, "gyroscope": "rad/s", "time": "s"},
             "accelerometer": {"K": s.acc_K.tolist(), "b": s.acc_b.tolist(),
                               "noise_sigma": s.acc_noise_sigma, "bias_instability": s.acc_bias_instability},
             "gyroscope": {"K": s.gyro_K.tolist(), "b": s.gyro_b.tolist()},
             "gravity": s.gravity, "latitude_deg": args.latitude, "height_m": args.height,
             "static_intervals": s.static_intervals.tolist(), "up_dirs": s.up_dirs.tolist(),
             "poses": s.descriptions, "seed": args.seed, "preset": args.preset, "truth": args.truth}
    tp = write_truth(out, session_truth(s.acc_K, s.acc_b, s.gyro_K, s.gyro_b, acc_unit=args.acc_unit,
                                        gyro_unit=args.gyro_unit, info=info))
    print(f"optinav: wrote {len(s.t)} samples ({len(s.up_dirs)} poses) to {out} and the truth to {tp}")
    for k, d in enumerate(s.descriptions, 1):
        print(f"  pose {k:2d}: {d}")
    return 0


def run_static(args) -> int:
    """``optinav simulate static``: white + flicker + random-walk noise at rest, SI truth beside the data."""
    import numpy as np

    from optinav.core.earth import gravity
    from optinav.core.imu_model import flicker_noise, preset, random_walk, white_noise
    from optinav.core.progress import step
    from optinav.core.results import Parameter, Truth
    from optinav.core.units import to_si
    from optinav.io import ImuLog, write_imu

    out = output_path(args.out)
    truth_path(out)
    spec = preset(args.preset)
    rate = args.rate or spec.sample_rate
    n = int(round(args.hours * 3600 * rate))
    # measured: about 350 B per sample at the peak (the flicker FFT of one triad), 600 with margin
    check_memory(n, 600, "this log", "shorten --hours or lower --rate")
    if n < 1000:
        raise OptinavError(f"{args.hours:g} h at {rate:g} Hz is {n} samples; a noise log needs thousands",
                           "raise --hours")
    dt = 1.0 / rate
    rng = np.random.default_rng(args.seed)
    terms = {"accelerometer": (spec.accel_vrw, spec.accel_bias_instability,
                               np.full(3, to_si(args.accel_rrw, "ug/sqrt(s)"))),
             "gyroscope": (spec.gyro_arw, spec.gyro_bias_instability,
                           np.full(3, to_si(args.gyro_rrw, "deg/h/sqrt(h)")))}
    data = {}
    step("simulate")
    for name, (N, B, K) in terms.items():
        data[name] = white_noise(n, N, dt, rng) + flicker_noise(n, B, dt, rng) + random_walk(n, K, dt, rng)
    g = float(gravity(np.radians(45.0), 0.0))
    acc = data["accelerometer"] + np.array([0.0, 0.0, g])
    log = ImuLog(t=np.arange(n) * dt, acc=acc, gyr=data["gyroscope"], source="optinav simulate static")
    step("write")
    write_imu(out, log, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit)
    units = {"accelerometer": {"white": "m/s/sqrt(s)", "bias_instability": "m/s^2", "random_walk": "m/s^2/sqrt(s)"},
             "gyroscope": {"white": "rad/sqrt(s)", "bias_instability": "rad/s", "random_walk": "rad/s/sqrt(s)"}}
    short = {"accelerometer": "acc", "gyroscope": "gyr"}
    # the common truth layout (one parameter per sensor, term and axis) and the noise terms in their own layout
    params = {f"{short[name]}_{term}_{ax}": Parameter(float(v[i]), units[name][term])
              for name, (N, B, K) in terms.items()
              for term, v in (("white", N), ("bias_instability", B), ("random_walk", K))
              for i, ax in enumerate("xyz")}
    truth = Truth("allan", params, {
        "kind": "static", "units": units,
        **{name: {"white": N.tolist(), "bias_instability": B.tolist(), "random_walk": K.tolist()}
           for name, (N, B, K) in terms.items()},
        "rate_hz": rate, "gravity": g, "preset": args.preset, "seed": args.seed})
    tp = write_truth(out, truth)
    print(f"optinav: wrote {n} samples ({args.hours:g} h at {rate:g} Hz) to {out} and the truth to {tp}")
    return 0
