"""Heading on BROAD recordings that start in motion: every trial cut to start some seconds after its motion.

Data: every BROAD trial in ``../shared/data/attitude/broad`` ($OPTINAV_SHARED_DATA; Laidig et al. 2021, CC BY
4.0). Each trial is cut to start ``START_S`` seconds (10, 30, 60) after its first movement sample and to end 10 s
before its last, so the recording has no rest at either end (the whole trials start and end at rest, where the
gyro bias is learned). Rows, per trial and mean per start (BROAD metric, movement samples with a valid optical
reference; default options): ``heading RMSE`` of optinav iframe online and offline 9D and, with the ``bench`` extra,
VQF 2.x online and offline 9D (``VQF.updateBatch``, ``offlineVQF``); ``6D heading drift RMSE``, the heading error
less its value at the first sample with a reference (a 6D heading has no absolute reference: how far the gyro and
its bias estimate carry it), of optinav iframe online and offline 6D and VQF online and offline 6D; ``inclination
RMSE`` of optinav iframe online 6D and VQF online 6D. ``python benchmarks/bench_attitude_cuts.py [--starts
10,30,60] [--json FILE]`` (progress on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from optinav.attitude import estimate_q
from optinav.attitude.data import load_broad
from optinav.attitude.metrics import earth_error_quaternion, heading_error, inclination_error, rmse

#: the shared data folder: ../shared/data relative to the project root ($OPTINAV_SHARED_DATA overrides)
SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))

START_S = (10.0, 30.0, 60.0)  # s after the first movement sample
END_S = 10.0  # s before the last movement sample


def cut(trial, start_s: float, end_s: float = END_S) -> slice:
    """Samples of ``trial`` from ``start_s`` s after its first movement sample to ``end_s`` s before its last."""
    mv = np.flatnonzero(trial.eval_mask)
    return slice(int(mv[0] + start_s / trial.dt), int(mv[-1] - end_s / trial.dt))


def heading_drift(q, q_ref, mask) -> float:
    """RMSE (rad) over ``mask`` of the heading error (BROAD's, signed and unwrapped) less its value at the first
    sample with a reference: the drift of a heading that has no absolute reference (6D)."""
    e = earth_error_quaternion(q, q_ref)
    psi = 2.0 * np.arctan2(e[:, 3], e[:, 0])
    ok = np.isfinite(psi)
    i = np.arange(psi.size)
    psi = np.unwrap(np.interp(i, i[ok], psi[ok]))
    d = psi - psi[np.flatnonzero(ok)[0]]
    return float(np.sqrt(np.mean(d[ok & mask] ** 2)))


def _methods() -> dict:
    """name → (metric, fn(gyr, acc, mag, dt) -> q (N, 4) body → ENU)."""
    h, d, i = "heading RMSE", "6D heading drift RMSE", "inclination RMSE"
    m = {
        "optinav iframe 9D": (h, lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", mag=mg, checks=False)),
        "optinav iframe offline 9D": (
            h,
            lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", mag=mg, offline=True, checks=False),
        ),
        "optinav iframe 6D": (d, lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", checks=False)),
        "optinav iframe offline 6D": (
            d,
            lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", offline=True, checks=False),
        ),
        "optinav iframe 6D inclination": (i, lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", checks=False)),
    }
    try:
        import vqf
    except ImportError:
        print("vqf absent (pip install '.[bench]'): its rows are left out", file=sys.stderr)
    else:
        c = np.ascontiguousarray

        def online(key):
            def fn(g, a, mg, dt):
                v = vqf.VQF(dt)
                return v.updateBatch(c(g), c(a), c(mg))[key]

            return fn

        m["vqf online 9D"] = (h, online("quat9D"))
        m["vqf offline 9D"] = (h, lambda g, a, mg, dt: vqf.offlineVQF(c(g), c(a), c(mg), dt)["quat9D"])
        m["vqf online 6D"] = (d, online("quat6D"))
        m["vqf offline 6D"] = (d, lambda g, a, mg, dt: vqf.offlineVQF(c(g), c(a), None, dt)["quat6D"])
        m["vqf online 6D inclination"] = (i, online("quat6D"))
    return m


_METRICS = {"heading RMSE": heading_error, "inclination RMSE": inclination_error}


def run(starts=START_S) -> list[dict]:
    """Rows {start_s, method, metric, trial → RMSE (deg), mean}."""
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    trials = {p.stem[:2]: load_broad(p) for p in paths}
    methods = _methods()
    rows = []
    for s0 in starts:
        for name, (metric, fn) in methods.items():
            print(f"  +{s0:g} s: {name}", file=sys.stderr)
            row = {"start_s": s0, "method": name, "metric": metric}
            for key, tr in trials.items():
                sl = cut(tr, s0)
                q = fn(tr.gyr[sl], tr.acc[sl], tr.mag[sl], tr.dt)
                ref, mask = tr.q_ref[sl], tr.eval_mask[sl]
                if metric in _METRICS:
                    row[key] = float(np.degrees(rmse(_METRICS[metric](q, ref), mask)))
                else:
                    row[key] = float(np.degrees(heading_drift(q, ref, mask)))
            row["mean"] = float(np.mean([row[k] for k in trials]))
            rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", default=",".join(f"{s:g}" for s in START_S), help="s after the first motion")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    args = ap.parse_args(argv)
    rows = run([float(x) for x in args.starts.split(",")])
    keys = [k for k in rows[0] if k not in ("start_s", "method", "metric")]
    print("| start | method | metric | " + " | ".join(keys) + " |")
    print("|---|---|---|" + "---|" * len(keys))
    for r in rows:
        cells = " | ".join(f"{r[k]:.3f}" for k in keys)
        print(f"| +{r['start_s']:g} s | {r['method']} | {r['metric']} | {cells} |")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
