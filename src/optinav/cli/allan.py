"""``optinav allan DATA``: noise characterisation of a static IMU log (Allan deviation, IEEE Std 952 read-off)."""

from __future__ import annotations

import argparse
import sys
import textwrap

from optinav.cli.common import add_input_options, add_report_option, output_path, prepare_report, require_files
from optinav.errors import OptinavError

#: largest departure of one sample interval from the median before the log counts as having gaps
MAX_JITTER = 0.5


def register(sub) -> None:
    p = sub.add_parser(
        "allan", help="noise of a static log: Allan deviation, IEEE 952 read-off, Kalibr noise parameters",
        description=textwrap.dedent("""\
            Overlapping Allan deviation of each accelerometer and gyroscope axis of a static log with its
            68 % confidence band (chi-squared with the equivalent degrees of freedom), the IEEE Std 952
            read-off of the noise terms (white noise N at tau = 1 s on the slope -1/2, bias instability B at the
            flat minimum / 0.664, rate random walk K at tau = 3 s on the slope +1/2, quantization Q on the slope
            -1) and a least-squares fit of the four-term model to the whole curve, with 68 % intervals.
            Kalibr's continuous-time noise density is N (unit/sqrt(Hz)) and its random walk K
            (unit/s/sqrt(Hz)), taken from the fit. Record hours at rest; long logs are summed in chunks.
            The random walk comes from the last octaves of the record: its interval is reliable when the log
            runs 10 times longer than the cluster time where the curve turns upwards (at 3 times, the 68 %
            interval held the truth about half the time in simulations)."""),
        epilog=textwrap.dedent("""\
            example (a simulated 2-hour static log in SI units):
              optinav simulate static --out rest.csv --hours 2
              optinav allan rest.csv --out allan.json --report allan-report --kalibr imu.yaml
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("data", help="static log: CSV/TSV/text, NPZ, HDF5 or MAT (columns and units as in calibrate)")
    p.add_argument("--out", required=True, metavar="ALLAN.json", help="result file (JSON)")
    p.add_argument("--sensor", choices=["both", "acc", "gyro"], default="both",
                   help="which triads to analyse (default both that the file holds)")
    p.add_argument("--kalibr", metavar="IMU.yaml", help="also write Kalibr's imu.yaml noise parameters (needs SI data "
                                                        "with both triads)")
    p.add_argument("--rostopic", metavar="TOPIC", help="the IMU topic written into --kalibr (e.g. /imu0)")
    add_input_options(p)
    add_report_option(p)
    p.set_defaults(func=run, progress_task="allan")


def run(args) -> int:
    require_files((args.data, "data file"))
    out = output_path(args.out, (".json",), "allan.json")
    kalibr = output_path(args.kalibr, (".yaml", ".yml"), "imu.yaml", option="--kalibr") if args.kalibr else None
    if kalibr is not None and kalibr.resolve() == out.resolve():
        raise OptinavError("--kalibr and --out name the same file", "give --kalibr another name, e.g. imu.yaml")
    prepare_report(args)
    from optinav.core.progress import step
    from optinav.io import read_imu

    step("read")
    log = read_imu(args.data, columns=args.columns, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                   time_unit=args.time_unit, rate=args.rate, datasets=args.datasets or None, delimiter=args.delimiter)
    if kalibr is not None and not (log.acc is not None and log.gyro is not None and log.acc_unit == "m/s^2"
                                   and log.gyro_unit == "rad/s" and args.sensor == "both"):
        raise OptinavError("--kalibr: Kalibr needs both triads in SI units, and the log has "
                           f"{'no accelerometer' if log.acc is None else 'no gyroscope' if log.gyro is None else 'raw counts' if 'counts' in (log.acc_unit, log.gyro_unit) else 'only one triad selected'}",
                           "calibrate the unit and analyse the output of optinav apply (m/s^2, rad/s), with "
                           "--sensor both")
    res = analyse(log, args.sensor, source=str(args.data), rostopic=args.rostopic or "")
    step("write")
    res.to_json(out)
    print(summary(res))
    print(f"optinav: result written to {out}")
    if kalibr is not None:
        from optinav.multipos.kalibr import write_kalibr_imu_yaml

        write_kalibr_imu_yaml(kalibr, noise=res, option="--kalibr")
        print(f"optinav: Kalibr imu.yaml written to {kalibr}")
    if args.report:
        from optinav.reports.allan_report import write_allan_report

        print(f"optinav: report written to {write_allan_report(res, args.report)}/index.md")
    return 0


def analyse(log, sensor: str = "both", *, source: str = "", rostopic: str = ""):
    """:class:`~optinav.core.allan.AllanAnalysis` of an :class:`~optinav.io.ImuLog` (regular sampling, no NaN)."""
    import numpy as np

    from optinav.core.allan import AllanAnalysis, allan_deviation, fit_noise_model, kalibr_noise, \
        noise_parameters_from_allan

    t = np.asarray(log.t, float)
    if t.size < 64:
        raise OptinavError(f"the log has {t.size} samples; an Allan deviation needs thousands (hours at rest)",
                           "record a longer static log")
    dts = np.diff(t)
    dt = float(np.median(dts))
    # the mean interval of a regular log: the median of rounded time stamps would be off in the 12th digit
    bad = np.abs(dts - dt) > MAX_JITTER * dt
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise OptinavError(f"the log is not regularly sampled: {int(bad.sum())} interval(s) differ from the median "
                           f"{dt:.6g} s by more than {MAX_JITTER:.0%}, first at t = {t[i]:.6g} s ({dts[i]:.6g} s)",
                           "cut the log at the gap and analyse the longest regular part (or pass --rate to "
                           "ignore a file's bad time stamps)")
    dt = float(t[-1] - t[0]) / (t.size - 1)
    triads = []
    if sensor in ("both", "acc") and log.acc is not None:
        triads.append(("accelerometer", log.acc, log.acc_unit))
    if sensor in ("both", "gyro") and log.gyro is not None:
        triads.append(("gyroscope", log.gyro, log.gyro_unit))
    if not triads:
        raise OptinavError(f"{source or 'the log'} has no {'data' if sensor == 'both' else sensor + ' data'} "
                           "to analyse", "check --columns (t,ax,ay,az,gx,gy,gz) or --sensor")
    out = {}
    kal = {}
    for name, x, unit in triads:
        if not np.all(np.isfinite(x)):
            n_bad = int(np.count_nonzero(~np.all(np.isfinite(x), axis=1)))
            raise OptinavError(f"the {name} data have {n_bad} row(s) with NaN or inf",
                               "cut the bad rows out of the log (the Allan deviation needs a gap-free record)")
        ad = allan_deviation(x, dt, unit=unit, progress_desc=f"Allan deviation ({name})")
        if ad.tau.size < 5:
            raise OptinavError(f"the log spans {t[-1] - t[0]:.3g} s, too short for the noise terms "
                               f"({ad.tau.size} cluster times)", "record at least a few minutes at rest (hours for "
                                                                 "the bias instability and random walk)")
        fit = fit_noise_model(ad)
        out[name] = {"deviation": ad, "read_off": noise_parameters_from_allan(ad), "fit": fit}
        if unit in ("m/s^2", "rad/s"):
            kal.update(kalibr_noise(fit, name))
    kal["update_rate"] = 1.0 / dt
    return AllanAnalysis(accelerometer=out.get("accelerometer"), gyroscope=out.get("gyroscope"), rate_hz=1.0 / dt,
                         n_samples=int(t.size), duration_s=float(t[-1] - t[0]), kalibr=kal, source=source,
                         rostopic=rostopic)


#: (field, label, unit suffix appended to the data's rate unit)
TERMS = (("white", "white noise N (ARW/VRW)", "*sqrt(s)"), ("bias_instability", "bias instability B", ""),
         ("random_walk", "random walk K (RRW/AcRW)", "/sqrt(s)"), ("quantization", "quantization Q", "*s"))


def summary(res) -> str:
    """Plain-text table of the fitted noise terms per axis with their 68 % intervals."""
    import numpy as np

    lines = [f"optinav allan: {res.n_samples} samples at {res.rate_hz:.6g} Hz over {res.duration_s / 3600:.3g} h"]
    for name in ("accelerometer", "gyroscope"):
        d = res.sensor(name)
        if d is None:
            continue
        fit, ro = d["fit"], d["read_off"]
        unit = fit.unit or "unit"
        lines.append(f"{name} (fit of the four-term model; IEEE 952 read-off in brackets):")
        for key, label, suffix in TERMS:
            v = np.atleast_1d(getattr(fit, key))
            iv = np.asarray(getattr(fit, key + "_interval")).reshape(2, -1)
            r = np.atleast_1d(getattr(ro, key))
            cells = [f"{'xyz'[j]} {v[j]:.4g} [{iv[0, j]:.3g}, {iv[1, j]:.3g}] ({r[j]:.3g})" for j in range(v.size)]
            lines.append(f"  {label} [{unit}{suffix}]: " + "; ".join(cells))
    return "\n".join(lines)
