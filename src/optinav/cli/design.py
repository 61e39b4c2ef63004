"""``optinav design``: a pose plan for a multi-position calibration (poses, dwell, turns, predicted precision)."""

from __future__ import annotations

import argparse
import sys
import textwrap

from optinav.cli.common import NON_NEGATIVE, POSITIVE, RATE, SEED, number, output_path
from optinav.errors import OptinavError


#: design's targets (1-sigma): flag, range, what for the error, metavar, help
_TARGETS = (
    ("--target-scale", 1e-3, 1e6, "a scale-factor target in ppm", "PPM", "accelerometer scale factor 1-sigma, ppm"),
    (
        "--target-misalignment",
        1e-6,
        1e3,
        "a misalignment target in mrad",
        "MRAD",
        "accelerometer misalignment 1-sigma, mrad",
    ),
    ("--target-bias", 1e-6, 1e4, "a bias target in mg", "MG", "accelerometer bias 1-sigma, mg"),
    ("--target-gyro-bias", 1e-6, 1e6, "a gyro bias target in deg/h", "DEG/H", "gyro bias 1-sigma from all rest, deg/h"),
)


def register(sub) -> None:
    p = sub.add_parser(
        "design",
        help="a pose plan for a technician: poses, rest time, turns and the precision they give",
        description=textwrap.dedent("""\
            Plan a multi-position calibration session: N static poses chosen D-, E- or A-optimally for the
            accelerometer (norm model), in a short turning order; each pose in words (which face of the unit
            points up) and in a figure; the rest time per pose from the noise to reach target standard
            deviations; the predicted 1-sigma of every accelerometer and gyroscope parameter; and the turns
            between poses, from which the gyroscope is calibrated. Noise: --allan (the JSON of optinav allan,
            or any JSON with Kalibr's accelerometer_noise_density / gyroscope_noise_density), the densities
            themselves, or a --preset sensor class. Method and approximations: src/optinav/multipos/plan.py."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav design --poses 12 --preset mems-mti1 --target-bias 0.5 --out plan.md --figure plan.png
              optinav design --poses 15 --criterion A --acc-noise-density 1e-3 --gyro-noise-density 1e-4 \\
                  --target-scale 100 --out plan.json
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--poses",
        type=number(9, 26, integer=True, what="a number of poses (9..26)"),
        default=12,
        help="number of static poses, 9..26 (default 12)",
    )
    p.add_argument(
        "--criterion",
        choices=["D", "E", "A"],
        default="D",
        help="D: max log det of the information, E: best worst-determined combination, A: smallest sum "
        "of variances (default D)",
    )
    noise = p.add_argument_group("noise (one of; default --preset mems-mti1)")
    noise.add_argument(
        "--allan", metavar="ALLAN.json", help="noise densities from optinav allan's JSON or Kalibr's imu.yaml"
    )
    noise.add_argument(
        "--acc-noise-density",
        type=number(1e-12, 10.0, what="a noise density in m/s^2/sqrt(Hz)"),
        metavar="M/S^2/√HZ",
        help="accelerometer white-noise density in m/s^2/sqrt(Hz) (= m/s/sqrt(s))",
    )
    noise.add_argument(
        "--gyro-noise-density",
        type=number(1e-12, 1.0, what="a noise density in rad/s/sqrt(Hz)"),
        metavar="RAD/S/√HZ",
        help="gyroscope white-noise density in rad/s/sqrt(Hz) (= rad/sqrt(s))",
    )
    noise.add_argument(
        "--gyro-g-sensitivity",
        type=NON_NEGATIVE,
        metavar="RAD/S/(M/S^2)",
        help="gyroscope g-sensitivity 1-sigma per element in rad/s per m/s^2 (datasheet 'linear acceleration "
        "sensitivity'; 0.1 deg/s/g = 1.78e-4); default the preset's",
    )
    # no choices= here: the preset table lives in numerical code that --help must not import
    noise.add_argument(
        "--preset",
        metavar="NAME",
        help="sensor class of optinav.core.imu_model: rlg-nav (navigation-grade RLG), "
        "tactical-mems (ADIS16495 class), mems-mti1 (industrial MEMS), mpu6000 (consumer MEMS)",
    )
    tg = p.add_argument_group("rest time: --dwell, or targets (1-sigma) that set it")
    tg.add_argument("--dwell", type=POSITIVE, metavar="S", help="rest per pose in s (default 30 without targets)")
    # targets far below any sensor's reach would need rest beyond any count (an overflow): bounded here
    for flag, lo, hi, what, metavar, text in _TARGETS:
        tg.add_argument(flag, type=number(lo, hi, what=what), metavar=metavar, help=f"{text} ({lo:g}..{hi:g})")
    p.add_argument(
        "--rate", dest="rate_hz", type=RATE, default=100.0, metavar="HZ", help="sample rate in Hz (default 100)"
    )
    p.add_argument(
        "--turn-rate",
        type=POSITIVE,
        default=45.0,
        metavar="DEG/S",
        help="how fast the technician turns the unit, deg/s (default 45)",
    )
    p.add_argument(
        "--max-dwell",
        type=POSITIVE,
        metavar="S",
        help="refuse a --dwell or targets needing more rest per pose (the Allan minimum of the sensor; default: "
        "that of the --allan result, else 600)",
    )
    p.add_argument("--seed", type=SEED, default=0, help="seed of the pose search (default 0)")
    p.add_argument("--out", metavar="PLAN.md|.json", help="write the plan as Markdown (.md) or JSON (.json)")
    p.add_argument("--figure", metavar="PLAN.png", help="draw the poses into a PNG")
    p.set_defaults(func=run, progress_task="design")


def run(args) -> int:
    out = output_path(args.out, (".md", ".json"), "PLAN.md") if args.out else None
    fig = output_path(args.figure, (".png",), "PLAN.png", "--figure") if args.figure else None
    targets = {
        "scale_ppm": args.target_scale,
        "misalignment_mrad": args.target_misalignment,
        "bias_mg": args.target_bias,
    }
    if args.dwell is not None and (any(v is not None for v in targets.values()) or args.target_gyro_bias):
        raise OptinavError("--dwell and a --target-* option both set the rest time", "pass one of them")
    from optinav.multipos.plan import plan_g_sensitivity, plan_max_dwell, plan_noise, plan_poses, plot_plan

    acc, gyro, text = plan_noise(args.allan, args.preset, args.acc_noise_density, args.gyro_noise_density)
    g_sens, g_text = plan_g_sensitivity(
        args.allan, args.preset, args.gyro_g_sensitivity, args.acc_noise_density is not None
    )
    if gyro is not None and g_text:
        text = text[:-1] + "; " + g_text + ")"
    plan = plan_poses(
        args.poses,
        criterion=args.criterion,
        acc_noise_density=acc,
        gyro_noise_density=gyro,
        noise_source=text,
        rate_hz=args.rate_hz,
        dwell_s=args.dwell,
        targets=targets,
        gyro_bias_deg_h=args.target_gyro_bias,
        turn_rate_deg_s=args.turn_rate,
        max_dwell_s=(cap := plan_max_dwell(args.allan, args.max_dwell))[0],
        max_dwell_note=cap[1],
        rng=args.seed,
        gyro_g_sensitivity=g_sens if gyro is not None else 0.0,
    )
    for note in plan.notes:
        print(f"optinav: note: {note}", file=sys.stderr)
    print(plan.summary())
    if out is not None:
        if out.suffix.lower() == ".json":
            plan.to_json(out)
        else:
            from optinav.core.files import write_text

            write_text(out, plan.markdown())
        print(f"optinav: plan written to {out}")
    if fig is not None:
        plot_plan(plan, fig)
        print(f"optinav: figure written to {fig}")
    return 0
