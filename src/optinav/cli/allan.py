"""``optinav allan DATA``: noise characterisation of a static IMU log (Allan deviation, IEEE Std 952 read-off)."""

from __future__ import annotations

import argparse
import textwrap

from optinav.cli.common import (add_chunk_option, add_input_options, add_report_option, output_path, prepare_report,
                                require_files)
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
    add_chunk_option(p)
    add_report_option(p)
    p.set_defaults(func=run, progress_task="allan")


def run(args) -> int:
    require_files((args.data, "data file"))
    out = output_path(args.out, (".json",), "allan.json")
    kalibr = output_path(args.kalibr, (".yaml", ".yml"), "imu.yaml", option="--kalibr") if args.kalibr else None
    if kalibr is not None and kalibr.resolve() == out.resolve():
        raise OptinavError("--kalibr and --out name the same file", "give --kalibr another name, e.g. imu.yaml")
    prepare_report(args)
    from optinav.core.progress import progress_blocks, step
    from optinav.io.imu import iter_imu

    step("read")
    blocks = iter_imu(args.data, columns=args.columns, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                      time_unit=args.time_unit, rate_hz=args.rate, datasets=args.datasets or None,
                      delimiter=args.delimiter, chunk_rows=args.chunk_rows, topic=args.topic)
    res = analyse_blocks(progress_blocks(blocks, "allan: read"), args.sensor, source=str(args.data),
                         rostopic=args.rostopic or "", need_kalibr=kalibr is not None)
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
    return analyse_blocks([log], sensor, source=source, rostopic=rostopic)


class _Timing:
    """Regular-sampling check of a streamed time column: every interval within :data:`MAX_JITTER` of the first
    block's median; the interval used is the mean over the whole log."""

    def __init__(self):
        self.t0 = self.t_last = self.dt0 = None
        self.n = 0
        self.bad = 0
        self.first_bad = None

    def add(self, t) -> None:
        import numpy as np

        t = np.asarray(t, float)
        if t.size == 0:
            return
        joined = t if self.t_last is None else np.concatenate(([self.t_last], t))
        d = np.diff(joined)
        if self.dt0 is None and d.size:
            self.dt0 = float(np.median(d))
        if self.dt0 is not None and d.size:
            bad = np.abs(d - self.dt0) > MAX_JITTER * self.dt0
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                if self.first_bad is None:
                    self.first_bad = (float(joined[i + 1]), float(d[i]))
                self.bad += int(bad.sum())
        if self.t0 is None:
            self.t0 = float(t[0])
        self.t_last = float(t[-1])
        self.n += t.size

    def check(self) -> float:
        if self.n < 64:
            raise OptinavError(f"the log has {self.n} samples; an Allan deviation needs thousands (hours at rest)",
                               "record a longer static log")
        if self.bad:
            t, d = self.first_bad
            raise OptinavError(f"the log is not regularly sampled: {self.bad} interval(s) differ from the median "
                               f"{self.dt0:.6g} s by more than {MAX_JITTER:.0%}, first at t = {t:.6g} s ({d:.6g} s)",
                               "cut the log at the gap and analyse the longest regular part (or pass --rate to "
                               "ignore a file's bad time stamps)")
        # the mean interval of a regular log: the median of rounded time stamps would be off in the 12th digit
        return (self.t_last - self.t0) / (self.n - 1)


def analyse_blocks(blocks, sensor: str = "both", *, source: str = "", rostopic: str = "", need_kalibr: bool = False):
    """:class:`~optinav.core.allan.AllanAnalysis` of a log given as :class:`~optinav.io.ImuLog` blocks (e.g.
    :func:`optinav.io.iter_imu`): each block is folded into the angle sums and dropped, so memory holds one float
    per sample and axis. ``need_kalibr``: refuse at the first block unless both triads are in SI units."""
    import numpy as np

    from optinav.core.allan import (AllanAnalysis, AngleAccumulator, allan_deviation_from_angle, fit_noise_model,
                                    kalibr_noise, noise_parameters_from_allan)

    timing = _Timing()
    angles: dict = {}
    units: dict[str, str] = {}
    for log in blocks:
        if not angles:
            present = {"accelerometer": (log.acc, log.acc_unit), "gyroscope": (log.gyr, log.gyro_unit)}
            wanted = {"both": ("accelerometer", "gyroscope"), "acc": ("accelerometer",), "gyro": ("gyroscope",)}[sensor]
            if need_kalibr:
                missing = [n for n in ("accelerometer", "gyroscope") if present[n][0] is None or n not in wanted]
                counts = [n for n in ("accelerometer", "gyroscope") if present[n][1] == "counts"]
                if missing or counts:
                    raise OptinavError("--kalibr: Kalibr needs both triads in SI units, and the log has "
                                       + (f"no {missing[0]} selected" if missing else f"the {counts[0]} in raw counts"),
                                       "calibrate the unit and analyse the output of optinav apply (m/s^2, rad/s), "
                                       "with --sensor both")
            for name in wanted:
                if present[name][0] is not None:
                    angles[name] = AngleAccumulator(1.0)
                    units[name] = present[name][1]
            if not angles:
                raise OptinavError(f"{source or 'the log'} has no {'data' if sensor == 'both' else sensor + ' data'} "
                                   "to analyse", "check --columns (t,ax,ay,az,gx,gy,gz) or --sensor")
        timing.add(log.t)
        for name, acc in angles.items():
            x = log.acc if name == "accelerometer" else log.gyr
            if x is None:
                raise OptinavError(f"a block of {source or 'the log'} lacks the {name}", "check --columns")
            if not np.all(np.isfinite(x)):
                n_bad = int(np.count_nonzero(~np.all(np.isfinite(x), axis=1)))
                raise OptinavError(f"the {name} data have {n_bad} row(s) with NaN or inf near t = {log.t[0]:.6g} s",
                                   "cut the bad rows out of the log (the Allan deviation needs a gap-free record)")
            if len(x):
                acc.add(x)
    if not angles:
        raise OptinavError(f"{source or 'the log'} holds no samples", "pass a static log")
    dt = timing.check()
    out = {}
    kal = {}
    for name in list(angles):
        acc = angles.pop(name)  # θ is dropped once its deviation is computed
        acc.set_dt(dt)
        ad = allan_deviation_from_angle(acc, unit=units[name], progress_desc=f"Allan deviation ({name})")
        del acc
        if ad.tau.size < 5:
            raise OptinavError(f"the log spans {timing.t_last - timing.t0:.3g} s, too short for the noise terms "
                               f"({ad.tau.size} cluster times)", "record at least a few minutes at rest (hours for "
                                                                 "the bias instability and random walk)")
        fit = fit_noise_model(ad)
        out[name] = {"deviation": ad, "read_off": noise_parameters_from_allan(ad), "fit": fit}
        if units[name] in ("m/s^2", "rad/s"):
            kal.update(kalibr_noise(fit, name))
    kal["update_rate"] = 1.0 / dt
    return AllanAnalysis(accelerometer=out.get("accelerometer"), gyroscope=out.get("gyroscope"), rate_hz=1.0 / dt,
                         n_samples=int(timing.n), duration_s=float(timing.t_last - timing.t0), kalibr=kal,
                         source=source, rostopic=rostopic)


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
