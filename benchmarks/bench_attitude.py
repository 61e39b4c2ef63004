"""Attitude estimators on real recordings: optinav beside VQF, imufusion and ahrs on the BROAD trials.

Data: every BROAD trial in ``../shared/data/attitude/broad`` ($OPTINAV_SHARED_DATA; Laidig et al. 2021, CC BY
4.0), gyro + accelerometer (6D) and + magnetometer (9D), default options of every method, BROAD's metric
(inclination / heading RMSE over the movement samples with a valid optical reference). Rows, per trial and
mean: 6D online inclination, 6D offline inclination, 9D heading. Methods: optinav iframe (default; online,
offline, 9D online and offline), the published gd/cg/qn/mekf (as published, and qn/mekf with the input stage), VQF 2.x online
(``VQF.updateBatch``) and offline (``offlineVQF``), imufusion's AHRS (its example's settings), ahrs Madgwick
(gain 0.033) and Mahony (defaults) — the comparison methods are the ``bench`` extra. Throughput in samples/s,
side by side in one run: batch on trial 02 tiled to ≥ 1 M samples, and streaming (one Python call per sample,
20 000 samples) for optinav's AttitudeFilter, VQF and imufusion. Targets (issue 12): online ≤ 0.55°, offline
≤ 0.44°, 9D heading ≤ 2.0°, no trial > 1.5°; ≥ 2 M samples/s batch, ≥ 300 k updates/s streaming.
``python benchmarks/bench_attitude.py [--quick] [--json FILE] [--md FILE]`` writes JSON and a Markdown table.

Timing: every method here integrates the sample gyr[k] over the interval (t[k−1], t[k]] and outputs the attitude
at t[k] (VQF and optinav with the exact exponential, the others to first order); none shifts its output. On
BROAD that output lags the optical reference by about half a sample (1.75 ms at 286 Hz; measured, see
docs/attitude.md), a property of the recording's timing, not of any method. Separate rows ("timing-aligned,
oracle") score every 6D method's output predicted forward by the same h/2 with the raw gyro,
q[k] ⊗ exp(gyr[k]·h/2); they show what the timing costs and are not a method's result.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from optinav.attitude import AttitudeFilter, estimate_q
from optinav.attitude.data import load_broad
from optinav.attitude.metrics import heading_error, inclination_error, rmse
from optinav.core.rotations import quat_from_rotvec, quat_multiply

#: the shared data folder: ../shared/data relative to the project root ($OPTINAV_SHARED_DATA overrides)
SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))


def _trials(quick: bool):
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    return [load_broad(p) for p in (paths[:3] if quick else paths)]


def _methods():
    """name → (kind, fn(gyr, acc, mag, dt) -> q (N, 4) body → ENU); kind: 6d, 6d-offline or 9d."""
    m = {
        "optinav iframe": ("6d", lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", checks=False)),
        "optinav iframe offline": (
            "6d-offline",
            lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", offline=True, checks=False),
        ),
        "optinav iframe 9D": ("9d", lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", mag=mg, checks=False)),
        "optinav iframe offline 9D": (
            "9d",
            lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", mag=mg, offline=True, checks=False),
        ),
    }
    for meth in ("gd", "cg", "qn", "mekf"):
        m[f"optinav {meth} (as published)"] = (
            "6d",
            lambda g, a, mg, dt, meth=meth: estimate_q(
                g, a, dt, frame="ENU", method=meth, input_stage=False, checks=False
            ),
        )
    for meth in ("qn", "mekf"):
        m[f"optinav {meth} + input stage"] = (
            "6d",
            lambda g, a, mg, dt, meth=meth: estimate_q(
                g, a, dt, frame="ENU", method=meth, input_stage=True, checks=False
            ),
        )
    try:
        import vqf

        c = np.ascontiguousarray
        m["vqf online"] = ("6d", lambda g, a, mg, dt: vqf.VQF(dt).updateBatch(c(g), c(a))["quat6D"])
        m["vqf offline"] = ("6d-offline", lambda g, a, mg, dt: vqf.offlineVQF(c(g), c(a), None, dt)["quat6D"])
        m["vqf online 9D"] = ("9d", lambda g, a, mg, dt: vqf.VQF(dt).updateBatch(c(g), c(a), c(mg))["quat9D"])
        m["vqf offline 9D"] = ("9d", lambda g, a, mg, dt: vqf.offlineVQF(c(g), c(a), c(mg), dt)["quat9D"])
    except ImportError:
        pass
    try:
        import imufusion

        def fusion(g, a, mg, dt, use_mag=False):
            # the settings of imufusion's own example (gain 0.5, 2000 °/s, rejection 10°/10°, 5 s timeout) in the
            # ENU convention of BROAD's reference; its bare defaults switch the rejections off
            ahrs_ = imufusion.Ahrs()
            settings = imufusion.AhrsSettings()
            settings.convention = imufusion.CONVENTION_ENU
            settings.sample_rate = 1.0 / dt
            settings.gyroscope_range = 2000.0
            settings.acceleration_rejection = 10.0
            settings.magnetic_rejection = 10.0
            settings.rejection_timeout = int(5.0 / dt)
            ahrs_.set_settings(settings)
            out = np.empty((g.shape[0], 4))
            gd, ad = np.degrees(g), a / 9.81  # imufusion: deg/s and g
            for i in range(g.shape[0]):
                if use_mag:
                    ahrs_.update(gd[i], ad[i], mg[i])
                else:
                    ahrs_.update_no_magnetometer(gd[i], ad[i])
                out[i] = ahrs_.get_quaternion()
            return out

        m["imufusion"] = ("6d", fusion)
        m["imufusion 9D"] = ("9d", lambda g, a, mg, dt: fusion(g, a, mg, dt, True))
    except ImportError:
        pass
    try:
        import ahrs

        m["ahrs Madgwick (0.033)"] = (
            "6d",
            lambda g, a, mg, dt: ahrs.filters.Madgwick(gyr=g, acc=a, frequency=1 / dt, gain=0.033).Q,
        )
        m["ahrs Mahony"] = ("6d", lambda g, a, mg, dt: ahrs.filters.Mahony(gyr=g, acc=a, frequency=1 / dt).Q)
    except ImportError:
        pass
    return m


def _best_time(fn, reps: int) -> float:
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _throughput(tr, quick: bool) -> list[dict]:
    rows = []
    k = int(np.ceil((200_000 if quick else 1_000_000) / tr.gyr.shape[0]))
    g, a = np.tile(tr.gyr, (k, 1)), np.tile(tr.acc, (k, 1))
    group = f"attitude batch throughput (BROAD {tr.name} tiled to {g.shape[0]} samples, 6D)"
    batch = {
        "optinav iframe": lambda: estimate_q(g, a, tr.dt, frame="ENU", checks=False),
        "optinav iframe (with input checks)": lambda: estimate_q(g, a, tr.dt, frame="ENU"),
        # the streaming filter's chunk, judged on its first seconds (checks.StartChecks)
        "optinav AttitudeFilter.update_batch": lambda: AttitudeFilter(tr.rate_hz, frame="ENU").update_batch(g, a),
    }
    for meth in ("gd", "qn", "mekf"):  # the names of the accuracy rows: the default (input stage) and as published
        for stage, label in ((True, "+ input stage"), (False, "(as published)")):
            batch[f"optinav {meth} {label}"] = lambda meth=meth, stage=stage: estimate_q(
                g, a, tr.dt, frame="ENU", method=meth, input_stage=stage, checks=False
            )
    try:
        import vqf

        batch["vqf online"] = lambda: vqf.VQF(tr.dt).updateBatch(g, a)
    except ImportError:
        pass
    estimate_q(g[:100], a[:100], tr.dt, frame="ENU", checks=False)  # numba cache
    for name, fn in batch.items():
        rows.append(
            {
                "group": group,
                "method": name,
                "metric": "throughput",
                "unit": "samples/s",
                "value": g.shape[0] / _best_time(fn, 1 if quick else 3),
            }
        )
    n = 20_000
    gl, al = [tuple(x) for x in tr.gyr[:n]], [tuple(x) for x in tr.acc[:n]]
    group = f"attitude streaming (one Python call per sample, {n} samples)"

    def ours():
        f = AttitudeFilter(tr.rate_hz, frame="ENU")
        for i in range(n):
            f.update(gl[i], al[i])

    stream = {"optinav AttitudeFilter.update": ours}
    try:
        import vqf

        ga, aa = np.ascontiguousarray(tr.gyr[:n]), np.ascontiguousarray(tr.acc[:n])

        def v():
            f = vqf.VQF(tr.dt)
            for i in range(n):
                f.update(ga[i], aa[i])

        stream["vqf VQF.update"] = v
    except ImportError:
        pass
    try:
        import imufusion

        gd, ad = np.degrees(tr.gyr[:n]), tr.acc[:n] / 9.81

        def fu():
            f = imufusion.Ahrs()
            for i in range(n):
                f.update_no_magnetometer(gd[i], ad[i])

        stream["imufusion Ahrs.update_no_magnetometer"] = fu
    except ImportError:
        pass
    ours()
    for name, fn in stream.items():
        rows.append(
            {
                "group": group,
                "method": name,
                "metric": "throughput",
                "unit": "updates/s",
                "value": n / _best_time(fn, 1 if quick else 3),
            }
        )
    return rows


def run(quick: bool) -> list[dict]:
    trials = _trials(quick)
    if not trials:
        return []
    rows = []
    kinds = {
        "6d": ("6D online", "inclination RMSE", inclination_error),
        "6d-offline": ("6D offline", "inclination RMSE", inclination_error),
        "9d": ("9D", "heading RMSE", heading_error),
    }
    for name, (kind, fn) in _methods().items():
        label, metric, err = kinds[kind]
        vals, aligned = [], []
        for tr in trials:
            if quick and name.startswith(("ahrs", "imufusion")):
                continue
            q = fn(tr.gyr, tr.acc, tr.mag, tr.dt)
            v = float(np.degrees(rmse(err(q, tr.q_ref), tr.eval_mask)))
            vals.append(v)
            rows.append(
                {
                    "group": f"attitude {label}, BROAD {tr.name}",
                    "method": name,
                    "metric": metric,
                    "value": v,
                    "unit": "deg",
                }
            )
            if kind != "9d":
                qa = quat_multiply(q, quat_from_rotvec(tr.gyr * (0.5 * tr.dt)))
                aligned.append(float(np.degrees(rmse(err(qa, tr.q_ref), tr.eval_mask))))
        if vals:
            rows.append(
                {
                    "group": f"attitude {label}, mean of {len(vals)} BROAD trials",
                    "method": name,
                    "metric": metric,
                    "value": float(np.mean(vals)),
                    "unit": "deg",
                }
            )
            rows.append(
                {
                    "group": f"attitude {label}, worst of {len(vals)} BROAD trials",
                    "method": name,
                    "metric": metric,
                    "value": float(np.max(vals)),
                    "unit": "deg",
                }
            )
        if aligned:
            rows.append(
                {
                    "group": f"attitude {label}, timing-aligned (output + h/2, oracle), mean of "
                    f"{len(aligned)} BROAD trials",
                    "method": name,
                    "metric": metric,
                    "value": float(np.mean(aligned)),
                    "unit": "deg",
                }
            )
    rows += _throughput(trials[0], quick)
    return rows


def markdown(rows: list[dict]) -> str:
    """Means, worst trials and throughput as one Markdown table per group (methods side by side)."""
    out = []
    groups = [g for i, g in enumerate(r["group"] for r in rows) if g not in [r["group"] for r in rows][:i]]

    def per_trial(g):
        return g.startswith(("attitude 6D", "attitude 9D")) and "mean of" not in g and "worst of" not in g

    for grp in groups:
        if per_trial(grp):
            continue
        out.append(f"**{grp}**\n\n| method | value |\n|---|---|")
        for r in rows:
            if r["group"] == grp:
                out.append(f"| {r['method']} | {r['value']:.4g} {r['unit']} ({r['metric']}) |")
        out.append("")
    names = sorted({r["method"] for r in rows if per_trial(r["group"])})
    trials = sorted({r["group"].split("BROAD ")[1] for r in rows if per_trial(r["group"])})
    for label in ("6D online", "6D offline", "9D"):
        sel = [r for r in rows if r["group"].startswith(f"attitude {label}, BROAD")]
        if not sel:
            continue
        meths = [n for n in names if any(r["method"] == n for r in sel)]
        out.append(f"**{label} per trial [deg]**\n\n| trial | " + " | ".join(meths) + " |\n|---|" + "---|" * len(meths))
        for t in trials:
            vals = {r["method"]: r["value"] for r in sel if r["group"].endswith(t)}
            out.append(f"| {t} | " + " | ".join(f"{vals[m]:.3f}" if m in vals else "" for m in meths) + " |")
        out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="three trials, fewer repetitions")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    ap.add_argument("--md", default=None, help="write the Markdown tables")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    md = markdown(rows)
    print(md)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    if args.md:
        Path(args.md).write_text(md + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
