"""Study (issue 12): what bounds iframe's 6D inclination on the BROAD trials?

iframe's tilt is the specific force low-passed in the almost-inertial frame of the bias-corrected gyro. Five
measurements, each on the nine trials in ``../shared/data/attitude/broad`` (BROAD's inclination RMSE over the
movement samples, degrees), ask where the remaining error comes from:

A. **The low-pass family.** The tilt of a causal low-pass of the specific force carried into the frame of iframe's
   offline (smoothed) gyro bias — a proxy of the online filter without its corrections' feedback — for Butterworth
   orders 2–4, Bessel orders 2–3 and second-order sections of damping ζ 0.5–1, each over time constants 3–6 s.
   A second-order low-pass is the steady-state Kalman filter of a gravity random walk beside an
   Ornstein–Uhlenbeck velocity (pseudo-measurement v = 0), a third-order one adds a bounded position: the grid
   spans those models too.
B. **Where the error lives in frequency:** iframe's online and offline errors split by zero-phase filters into
   below 0.2 Hz, 0.2–2 Hz and above 2 Hz (RMS of each band; their squares add up to about the total's).
C. **A constant misalignment:** the body-fixed rotation that best fits each trial's offline estimate to the
   reference (least squares, an oracle a filter cannot have): how much of the error one constant explains.
D. **The accelerometer against the reference:** the specific force the reference predicts (its orientation and
   the optical position's acceleration, both low-passed at 2 Hz) against the measured one, the horizontal part of
   their disagreement below 0.2 Hz (navigation frame). A filter anchored on the accelerometer cannot get below
   this at low frequency without knowing the acceleration (the lever arm from the markers to the IMU and the
   2-Hz smoothing leave it an estimate, meaningful on the trials without fast motion).
E. **The bias:** the proxy of A (Butterworth 2, 4 s) in the frame of a constant bias fitted to the reference's
   1-s rotations instead of iframe's.

``python benchmarks/study_attitude_floor.py [--json FILE] [--md FILE]``. Results: study_attitude_floor.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import bessel, bilinear, butter, filtfilt, lfilter, lfilter_zi

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_attitude_cv import SHARED  # noqa: E402

import optinav.attitude._iframe as _k  # noqa: E402
from optinav.attitude.data import load_broad  # noqa: E402
from optinav.attitude.iframe import run_iframe  # noqa: E402
from optinav.attitude.metrics import inclination_error  # noqa: E402
from optinav.core.rotations import (  # noqa: E402
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_rotate,
    rotvec_from_quat,
)

_UP = np.array([0.0, 0.0, 1.0])  # BROAD is ENU
G = 9.81
#: the low-pass family of A: (kind, order or damping ζ, time constant s)
FAMILY = (
    [("butterworth", o, t) for o in (2, 3, 4) for t in (3.0, 4.0, 5.0, 6.0)]
    + [("bessel", o, t) for o in (2, 3) for t in (3.0, 4.0, 5.0)]
    + [("second order ζ", z, t) for z in (0.5, 0.6, 0.85, 1.0) for t in (3.5, 4.0, 4.5, 5.0)]
)
BANDS_HZ = (0.2, 2.0)


def _rms(x, m) -> float:
    return float(np.sqrt(np.mean(x[m] ** 2)))


def _lowpass(kind: str, p: float, tau: float, h: float):
    """(b, a) of a causal low-pass at iframe's cutoff √2/(2π τ) (``p``: order, or damping ζ of a second order)."""
    fc = np.sqrt(2.0) / (2.0 * np.pi * tau)
    if kind == "butterworth":
        return butter(int(p), 2.0 * fc * h)
    if kind == "bessel":
        return bessel(int(p), 2.0 * fc * h, norm="delay")
    wn = 2.0 * np.pi * fc
    return bilinear([wn**2], [1.0, 2.0 * p * wn, wn**2], fs=1.0 / h)


def _tilt_error(frame_q, acc, q_ref, ba, h) -> np.ndarray:
    """Inclination error (deg, N) of the up direction given by the causal low-pass ``ba`` of the specific force in
    the frame ``frame_q`` (started steady at the mean of the first 4 s, as iframe's low-pass starts)."""
    b, a = ba
    f_i = quat_rotate(frame_q, acc)
    x0 = f_i[: int(4.0 / h)].mean(axis=0)
    zi = lfilter_zi(b, a)
    lp = np.column_stack([lfilter(b, a, f_i[:, j], zi=zi * x0[j])[0] for j in range(3)])
    up_b = quat_rotate(quat_conjugate(frame_q), lp)
    ref_up = quat_rotate(quat_conjugate(q_ref), _UP)
    c = np.sum(up_b * ref_up, axis=1) / np.linalg.norm(up_b, axis=1)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def _frame(gyr, bias, dts) -> np.ndarray:
    q = np.empty((gyr.shape[0], 4))
    _k.strapdown(np.ascontiguousarray(gyr), np.ascontiguousarray(bias), dts, q, np.array([1.0, 0.0, 0.0, 0.0]))
    return q


def _bands(err, mask, h) -> list[float]:
    x = np.where(np.isfinite(err), err, 0.0)
    lo, hi = (filtfilt(*butter(2, 2.0 * f * h), x) for f in BANDS_HZ)
    return [_rms(lo, mask), _rms(hi - lo, mask), _rms(x - hi, mask)]


def _constant_rotation(q, q_ref, mask) -> tuple[float, np.ndarray]:
    idx = np.flatnonzero(mask)[::10]

    def res(x):
        return inclination_error(quat_multiply(q[idx], np.repeat(quat_from_rotvec(x)[None], idx.size, 0)), q_ref[idx])

    x = least_squares(res, np.zeros(3)).x
    e = np.degrees(inclination_error(quat_multiply(q, np.repeat(quat_from_rotvec(x)[None], q.shape[0], 0)), q_ref))
    return _rms(e, mask & np.isfinite(e)), np.degrees(x)


def _optical_position(path: Path) -> np.ndarray:
    """BROAD's ``opt_pos`` (N, 3) m, read beside :func:`load_broad` (which leaves it out)."""
    if path.suffix == ".mat":
        from scipy.io import loadmat

        return np.asarray(loadmat(path, variable_names=["opt_pos"])["opt_pos"], float)
    import h5py

    with h5py.File(path, "r") as f:
        return np.asarray(f["opt_pos"][()], float)


def _acc_floor(tr, pos, h) -> float:
    """Horizontal disagreement (deg RMS below 0.2 Hz, navigation frame) of the measured specific force and the one
    the reference predicts from its orientation and the optical position (NaN rows interpolated, their
    neighbourhood of 1 s left out)."""
    q = tr.q_ref
    ok = np.all(np.isfinite(q), 1) & np.all(np.isfinite(pos), 1)
    i = np.arange(q.shape[0])
    qf = np.column_stack([np.interp(i, i[ok], q[ok, j]) for j in range(4)])
    qf /= np.linalg.norm(qf, axis=1)[:, None]
    pf = np.column_stack([np.interp(i, i[ok], pos[ok, j]) for j in range(3)])
    b, a = butter(2, 2.0 * 2.0 * h)
    an = np.gradient(np.gradient(filtfilt(b, a, pf, axis=0), h, axis=0), h, axis=0)
    f_pred = filtfilt(b, a, quat_rotate(quat_conjugate(qf), an + G * _UP), axis=0)
    f_meas = filtfilt(b, a, tr.acc, axis=0)
    e = np.cross(f_pred / np.linalg.norm(f_pred, axis=1)[:, None], f_meas / np.linalg.norm(f_meas, axis=1)[:, None])
    slow = filtfilt(*butter(2, 2.0 * BANDS_HZ[0] * h), quat_rotate(qf, e), axis=0)
    keep = tr.eval_mask & (np.convolve(~ok, np.ones(int(1.0 / h)), "same") == 0)
    return float(np.degrees(np.sqrt(np.mean(np.sum(slow[keep, :2] ** 2, axis=1)))))


def _reference_bias(tr, h) -> np.ndarray:
    """Constant gyro bias (rad/s) from the reference: the median over 1-s windows of the rotation the gyro makes
    beyond the reference's, per second."""
    n = tr.gyr.shape[0]
    k = int(round(1.0 / h))
    qg = _frame(tr.gyr, np.zeros((n, 3)), np.atleast_1d(tr.dt))
    ok = np.all(np.isfinite(tr.q_ref), 1)
    i0 = np.arange(0, n - k, k)
    i0 = i0[ok[i0] & ok[i0 + k]]
    d_ref = quat_multiply(quat_conjugate(tr.q_ref[i0]), tr.q_ref[i0 + k])
    d_gyr = quat_multiply(quat_conjugate(qg[i0]), qg[i0 + k])
    return np.median(rotvec_from_quat(quat_multiply(quat_conjugate(d_ref), d_gyr)), axis=0) / (k * h)


def run() -> dict:
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.iterdir() if p.suffix in (".hdf5", ".mat"))
    if not paths:
        raise SystemExit(f"no BROAD trials in {folder}")
    meta = json.loads((folder / "trials.json").read_text())
    trials = {}
    for p in paths:
        t0 = time.perf_counter()
        tr = load_broad(p)
        dts = np.atleast_1d(tr.dt).astype(float)
        h = float(np.mean(dts))
        mask = tr.eval_mask & np.all(np.isfinite(tr.q_ref), axis=1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            on = run_iframe(tr.gyr, tr.acc, dts, frame="ENU")
            off = run_iframe(tr.gyr, tr.acc, dts, frame="ENU", offline=True)
        e_on, e_off = (np.degrees(inclination_error(r.q_b_n, tr.q_ref)) for r in (on, off))
        frame = _frame(tr.gyr, off.gyr_bias, dts)
        fam = [_rms(_tilt_error(frame, tr.acc, tr.q_ref, _lowpass(*v, h), h), mask) for v in FAMILY]
        b_ref = _reference_bias(tr, h)
        ref_frame = _frame(tr.gyr, np.repeat(b_ref[None], tr.gyr.shape[0], 0), dts)
        bw = _lowpass("butterworth", 2, 4.0, h)
        oracle, rot = _constant_rotation(off.q_b_n, tr.q_ref, mask)
        trials[p.name[:2]] = {
            "slow": "slow" in meta["trials"].get(p.stem, {}).get("groups", []),
            "online": _rms(e_on, mask),
            "offline": _rms(e_off, mask),
            "online_bands": _bands(e_on, mask, h),
            "offline_bands": _bands(e_off, mask, h),
            "family": fam,
            "offline_less_constant_rotation": oracle,
            "constant_rotation_deg": rot.tolist(),
            "acc_vs_reference_slow": _acc_floor(tr, _optical_position(p), h),
            "proxy_reference_bias": _rms(_tilt_error(ref_frame, tr.acc, tr.q_ref, bw, h), mask),
            "reference_bias_deg_s": np.degrees(b_ref).tolist(),
            "offline_bias_mean_deg_s": np.degrees(off.gyr_bias.mean(axis=0)).tolist(),
        }
        print(f"{p.name[:2]}: {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    return {"family": [list(v) for v in FAMILY], "bands_hz": list(BANDS_HZ), "trials": trials}


def _md(res: dict) -> str:
    tr = res["trials"]
    names = list(tr)

    def mean(key, i=None):
        return float(np.mean([tr[n][key] if i is None else tr[n][key][i] for n in names]))

    head = "| | " + " | ".join(names) + " | mean |\n|---|" + "---|" * (len(names) + 1) + "\n"

    def row(label, key, i=None, fmt="{:.3f}"):
        vals = [tr[n][key] if i is None else tr[n][key][i] for n in names]
        return f"| {label} | " + " | ".join(fmt.format(v) for v in vals) + f" | **{np.mean(vals):.3f}** |\n"

    fam = np.array([tr[n]["family"] for n in names])
    order = np.argsort(fam.mean(axis=0))
    out = ["# Study: what bounds iframe's 6D inclination on BROAD (issue 12)\n\n"]
    out.append(
        "Script: `python benchmarks/study_attitude_floor.py --json benchmarks/study_attitude_floor.json --md "
        "benchmarks/study_attitude_floor.md` (method in its docstring). Nine BROAD trials, BROAD's inclination "
        "RMSE over the movement samples [deg].\n\n"
    )
    out.append("## Per trial\n\n" + head)
    out.append(row("iframe online", "online") + row("iframe offline", "offline"))
    for i, band in enumerate(("< 0.2 Hz", "0.2–2 Hz", "> 2 Hz")):
        out.append(row(f"online, {band}", "online_bands", i))
    for i, band in enumerate(("< 0.2 Hz", "0.2–2 Hz", "> 2 Hz")):
        out.append(row(f"offline, {band}", "offline_bands", i))
    out.append(row("offline less its best constant rotation (oracle)", "offline_less_constant_rotation"))
    slow = [n for n in names if tr[n]["slow"]]
    vals = [
        f"{tr[n]['acc_vs_reference_slow']:.3f}" if tr[n]["slow"] else f"({tr[n]['acc_vs_reference_slow']:.1f})"
        for n in names
    ]
    floor = np.mean([tr[n]["acc_vs_reference_slow"] for n in slow])
    off_slow = np.mean([tr[n]["offline_bands"][0] for n in slow])
    out.append(
        "| accelerometer vs reference, horizontal < 0.2 Hz (BROAD's slow trials; in brackets where fast motion's "
        "lever arm makes it meaningless) | " + " | ".join(vals) + f" | **{floor:.3f}** (slow) |\n"
    )
    out.append(
        row("proxy, Butterworth 2 / 4 s, iframe's offline bias", "family", FAMILY.index(("butterworth", 2, 4.0)))
    )
    out.append(row("proxy, the same with the reference's constant bias", "proxy_reference_bias"))
    out.append("\n## The low-pass family (proxy, mean and worst trial)\n\n| low-pass | p | τ [s] | mean | worst |\n")
    out.append("|---|---|---|---|---|\n")
    for j in order:
        kind, p, t = FAMILY[j]
        out.append(f"| {kind} | {p:g} | {t:g} | {fam[:, j].mean():.4f} | {fam[:, j].max():.3f} |\n")
    best, base = fam.mean(axis=0)[order[0]], fam.mean(axis=0)[FAMILY.index(("butterworth", 2, 4.0))]
    out.append(
        f"\nBest {FAMILY[order[0]]} {best:.4f}° against iframe's own (Butterworth 2, 4 s) {base:.4f}° "
        f"({100 * (best / base - 1):+.1f} %); online mean {mean('online'):.4f}°, offline {mean('offline'):.4f}°.\n"
    )
    out.append(
        f"On BROAD's slow trials ({', '.join(slow)}) the accelerometer and the reference disagree below 0.2 Hz by "
        f"{floor:.3f}° (horizontal, navigation frame) where iframe's offline error below 0.2 Hz is {off_slow:.3f}°.\n"
    )
    return "".join(out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--md", type=Path)
    args = ap.parse_args(argv)
    res = run()
    text = _md(res)
    print(text)
    if args.json:
        args.json.write_text(json.dumps(res, indent=1) + "\n")
    if args.md:
        args.md.write_text(text)


if __name__ == "__main__":
    main()
