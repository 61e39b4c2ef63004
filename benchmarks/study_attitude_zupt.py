"""Study (issue 12): does a zero-velocity (ZUPT) error-state smoother beat ``iframe`` on the BROAD trials?

Idea: between two detected rests the velocity integrated from the navigation-frame specific force plus gravity
must return to zero — exact for every device — and a tilt error δθ makes it drift by g × δθ · t, so the ZUPT at
the end of a motion reveals the tilt during it. A weak bounded-velocity prior in motion (pseudo-measurement
v = 0 with density ``qv`` in m/√s, the white-noise limit of an Ornstein–Uhlenbeck velocity) is the continuous
analogue of iframe's low-pass in the almost-inertial frame. Model (navigation frame, q_true = exp(δθ) ⊗ q_nom):

    δθ_k = δθ_{k−1} − u_k − C_k δb h + w_θ      (u_k: the rotation the nominal made beyond its own strapdown)
    δb_k = δb_{k−1} − Δb_nom,k + w_b             (gyro bias error; Δb_nom the nominal's bias step)
    v_k  = v_{k−1} + (C_k f_k − g·up − [C_k f_k ×] δθ − C_k δa) h + w_v
    δa   constant (optional accelerometer bias, body axes)

with C_k, b_nom from iframe (online or offline) as the linearization point only: the known inputs u_k and
Δb_nom make the model the gyro strapdown itself, so the nominal adds no information. Pseudo-measurements v = 0:
at iframe's rest flag with density ``rzupt``, in motion with ``qv``. Forward Kalman filter (online) and RTS
backward pass (offline); the output is exp(δθ) ⊗ q_nom. Parameters in physical units (rate-independent
densities): gyro noise ``arw`` (rad/√s), bias random walk, velocity noise ``qa`` (m/s/√s), ``qv``, ``rzupt``.

Protocol: the grid point is chosen by leave-one-BROAD-group-out CV (the folds of bench_attitude_cv.py); per-trial
numbers beside iframe and VQF on the same run; a half-rate copy of trial 02 checks rate independence.
``python benchmarks/study_attitude_zupt.py [--json FILE] [--md FILE]``. Results: study_attitude_zupt.md.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_attitude_cv import SHARED, _groups, logo_cv  # noqa: E402

from optinav.attitude.data import load_broad  # noqa: E402
from optinav.attitude.iframe import run_iframe  # noqa: E402
from optinav.attitude.metrics import inclination_error, rmse  # noqa: E402
from optinav.core.rotations import (  # noqa: E402
    dcm_from_quat,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    rotvec_from_quat,
)

_D2R = np.pi / 180.0
_UP = np.array([0.0, 0.0, 1.0])  # BROAD is ENU
#: fixed physical values (not tuned): initial σ of tilt (rad), bias error (rad/s), velocity (m/s); bias random
#: walk (rad/s/√s); velocity density at rest (m/√s)
P0 = (1.0 * _D2R, 0.1 * _D2R, 0.1)
BRW = 0.001 * _D2R
RZUPT = 0.003
GRID = {"arw": (0.01 * _D2R, 0.05 * _D2R), "qa": (0.003, 0.01), "qv": (0.1, 0.3, 3.0)}


@numba.njit(cache=True)
def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@numba.njit(cache=True)
def _transition(F, C, f, h, ns):
    F[:] = np.eye(ns)
    F[0:3, 3:6] = -C * h
    F[6:9, 0:3] = -_skew(f) * h
    if ns == 12:
        F[6:9, 9:12] = -C * h


@numba.njit(cache=True)
def _eskf(C, f, u, db, rest, h, g_up, p0, qd, r_motion, r_rest, smooth):
    """Error-state filter [δθ, δb, v(, δa)] (qd: per-second process variances, len 9 or 12); returns the filtered
    states, or the RTS-smoothed ones when ``smooth``."""
    n = C.shape[0]
    ns = qd.shape[0]
    x = np.zeros(ns)
    P = np.diag(p0)
    xf = np.zeros((n, ns))
    m = n if smooth else 1
    Pf = np.zeros((m, ns, ns))
    xp = np.zeros((m, ns))
    Pp = np.zeros((m, ns, ns))
    F = np.eye(ns)
    for k in range(n):
        if k > 0:
            _transition(F, C[k], f[k], h, ns)
            x = F @ x
            x[0:3] -= u[k]
            x[3:6] -= db[k]
            x[6:9] += (f[k] - g_up) * h
            P = F @ P @ F.T + np.diag(qd * h)
        if smooth:
            xp[k] = x
            Pp[k] = P
        r = (r_rest if rest[k] else r_motion) / h
        for j in range(6, 9):
            s = P[j, j] + r
            K = P[:, j] / s
            x = x - K * x[j]
            P = P - np.outer(K, P[j, :])
        xf[k] = x
        if smooth:
            Pf[k] = P
    if not smooth:
        return xf
    xs = xf.copy()
    for k in range(n - 2, -1, -1):
        _transition(F, C[k + 1], f[k + 1], h, ns)
        G = Pf[k] @ F.T @ np.linalg.inv(Pp[k + 1])
        xs[k] = xf[k] + G @ (xs[k + 1] - xp[k + 1])
    return xs


def zupt_correct(run, gyr, acc, dt, *, smooth, arw, qa, qv, acc_bias=0.0):
    """q_b^n of the ZUPT filter (``smooth``: RTS smoother) linearized at the iframe run ``run``."""
    q_nom, b_nom, rest = run.q_b_n, run.gyr_bias, run.rest
    n = gyr.shape[0]
    C = dcm_from_quat(q_nom)
    f = np.einsum("nij,nj->ni", C, acc)
    # the specific force at rest sets g (the accelerometer's own scale), else the standard value
    g = float(np.median(np.linalg.norm(acc[rest], axis=1))) if rest.sum() > 10 else 9.81
    prop = quat_multiply(q_nom[:-1], quat_from_rotvec((gyr[1:] - b_nom[1:]) * dt))
    u = np.zeros((n, 3))
    u[1:] = rotvec_from_quat(quat_multiply(q_nom[1:], quat_conjugate(prop)))
    db = np.zeros((n, 3))
    db[1:] = np.diff(b_nom, axis=0)
    p0 = np.repeat(np.array(P0) ** 2, 3)
    qd = np.repeat([arw**2, BRW**2, qa**2], 3)
    if acc_bias > 0:
        p0 = np.concatenate([p0, np.full(3, acc_bias**2)])
        qd = np.concatenate([qd, np.zeros(3)])
    x = _eskf(C, f, u, db, rest, dt, g * _UP, p0, qd, qv**2, RZUPT**2, smooth)
    return quat_multiply(quat_from_rotvec(x[:, :3]), q_nom)


def _score(q, tr_q_ref, mask) -> float:
    return float(np.degrees(rmse(inclination_error(q, tr_q_ref), mask)))


def _half_rate(tr):
    """Trial at half rate: gyro and accelerometer averaged over sample pairs (a mean over the interval, as the
    convention assumes), the reference and mask at the later sample."""
    n = tr.gyr.shape[0] // 2 * 2
    avg = lambda x: 0.5 * (x[0:n:2] + x[1:n:2])  # noqa: E731
    return avg(tr.gyr), avg(tr.acc), 2.0 * tr.dt, tr.q_ref[1:n:2], tr.eval_mask[1:n:2]


def run() -> dict:
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    if len(paths) < 3:
        return {}
    trials = [load_broad(p) for p in paths]
    names = [p.stem[:2] for p in paths]
    groups = _groups(folder, [p.stem for p in paths])
    combos = [dict(zip(GRID, c)) for c in itertools.product(*GRID.values())]
    out = {"trials": names, "grid": combos, "modes": {}}
    for mode, off in (("online", False), ("offline", True)):
        noms = [run_iframe(tr.gyr, tr.acc, np.array([tr.dt]), frame="ENU", offline=off) for tr in trials]
        base = [_score(r.q_b_n, tr.q_ref, tr.eval_mask) for r, tr in zip(noms, trials)]
        t0 = time.perf_counter()
        err = np.array(
            [
                [
                    _score(zupt_correct(r, tr.gyr, tr.acc, tr.dt, smooth=off, **c), tr.q_ref, tr.eval_mask)
                    for r, tr in zip(noms, trials)
                ]
                for c in combos
            ]
        )
        secs = (time.perf_counter() - t0) / (len(combos) * sum(tr.gyr.shape[0] for tr in trials))
        cv, chosen = logo_cv(err, groups)
        best = int(np.argmin(err.mean(axis=1)))
        rows = {
            "iframe (default)": base,
            "ZUPT filter, CV": cv.tolist(),
            "ZUPT filter, best on all": err[best].tolist(),
        }
        # 12 states: + accelerometer bias (σ 0.02 m/s²), at the all-trials best grid point
        rows["ZUPT + acc bias, best grid point"] = [
            _score(
                zupt_correct(r, tr.gyr, tr.acc, tr.dt, smooth=off, acc_bias=0.02, **combos[best]),
                tr.q_ref,
                tr.eval_mask,
            )
            for r, tr in zip(noms, trials)
        ]
        out["modes"][mode] = {
            "rows": rows,
            "grid_errors": err.tolist(),
            "chosen": {g: combos[k] for g, k in chosen.items()},
            "best": combos[best],
            "s_per_sample": secs,
        }
    try:
        import vqf

        c = np.ascontiguousarray
        out["modes"]["online"]["rows"]["VQF online"] = [
            _score(vqf.VQF(tr.dt).updateBatch(c(tr.gyr), c(tr.acc))["quat6D"], tr.q_ref, tr.eval_mask) for tr in trials
        ]
        out["modes"]["offline"]["rows"]["VQF offline"] = [
            _score(vqf.offlineVQF(c(tr.gyr), c(tr.acc), None, tr.dt)["quat6D"], tr.q_ref, tr.eval_mask) for tr in trials
        ]
    except ImportError:
        pass
    # rate independence: trial 02 at its rate and at half, iframe and the ZUPT filter at the all-trials best point
    half = {}
    for mode, off in (("online", False), ("offline", True)):
        cfg = out["modes"][mode]["best"]
        tr = trials[0]
        for label, (g, a, dt, qr, mk) in (
            ("full", (tr.gyr, tr.acc, tr.dt, tr.q_ref, tr.eval_mask)),
            ("half", _half_rate(tr)),
        ):
            r = run_iframe(g, a, np.array([dt]), frame="ENU", offline=off)
            half[f"{mode} {label} iframe"] = _score(r.q_b_n, qr, mk)
            half[f"{mode} {label} ZUPT"] = _score(zupt_correct(r, g, a, dt, smooth=off, **cfg), qr, mk)
    out["simulated"] = simulated(out)
    out["rate_check_trial"] = names[0]
    out["rate_check"] = half
    return out


def _smooth(rng, t, f_lo, f_hi, n_terms=4):
    """Sum of sinusoids with random frequencies (Hz) and phases, unit peak over ``t``."""
    f = rng.uniform(f_lo, f_hi, n_terms)
    ph = rng.uniform(0.0, 2.0 * np.pi, n_terms)
    x = np.sum(np.sin(2.0 * np.pi * f[:, None] * t[None, :] + ph[:, None]), axis=0)
    return x / np.max(np.abs(x))


def simulated_hand(rng, *, breaks: bool, duration=120.0, rate_hz=200.0):
    """Hand-held motion with rests (``breaks``: 6 s of motion, 3 s still, repeated; else one motion between 5 s
    rests), ENU. Truth: body rate ω (peak 2 rad/s, 0.2–1.5 Hz), velocity v (peak 0.5 m/s, zero at every rest);
    q_b_n from the rate samples (each the mean over the interval ending at the sample, the estimators'
    convention). IMU: constant gyro bias (σ 0.3 °/s per axis), gyro noise 0.01 °/s/√Hz, accelerometer noise
    300 µg/√Hz and constant bias (σ 0.01 m/s²). Returns gyr, acc, dt, q_true."""
    h = 1.0 / rate_hz
    t = np.arange(int(duration * rate_hz)) * h
    if breaks:
        ph = (t - 5.0) % 9.0
        env = np.where((t > 5.0) & (t < duration - 5.0), np.clip(np.minimum(ph, 6.0 - ph), 0.0, 1.0), 0.0)
    else:
        env = np.clip(np.minimum(t - 5.0, duration - 5.0 - t), 0.0, 1.0)
    env = env * env * (3.0 - 2.0 * env)  # C¹ ramps of 1 s
    w = 2.0 * np.stack([_smooth(rng, t, 0.2, 1.5) for _ in range(3)], axis=1) * env[:, None]
    v = 0.5 * np.stack([_smooth(rng, t, 0.1, 1.0) for _ in range(3)], axis=1) * env[:, None]
    a = np.gradient(v, h, axis=0)
    q = np.empty((t.size, 4))
    q[0] = [1.0, 0.0, 0.0, 0.0]
    for k in range(1, t.size):
        q[k] = quat_multiply(q[k - 1], quat_from_rotvec(w[k] * h))
    C = dcm_from_quat(q)
    f = np.einsum("nji,nj->ni", C, a + 9.81 * _UP)
    gyr = w + rng.normal(0.0, 0.3 * _D2R, 3) + rng.normal(0.0, 0.01 * _D2R * np.sqrt(rate_hz), w.shape)
    acc = f + rng.normal(0.0, 0.01, 3) + rng.normal(0.0, 300e-6 * 9.81 * np.sqrt(rate_hz), f.shape)
    return gyr, acc, h, q


def simulated(res: dict, seeds=(1, 2, 3)) -> dict:
    """iframe vs the ZUPT filter (the all-trials best grid point of each mode) on simulated hand motion with and
    without breaks: mean inclination RMSE [deg] over the motion samples of three seeds."""
    out = {}
    for breaks in (True, False):
        for mode, off in (("online", False), ("offline", True)):
            cfg = res["modes"][mode]["best"]
            e_i, e_z = [], []
            for seed in seeds:
                gyr, acc, h, q = simulated_hand(np.random.default_rng(seed), breaks=breaks)
                moving = np.linalg.norm(gyr - np.median(gyr[:100], axis=0), axis=1) > 0.05
                r = run_iframe(gyr, acc, np.array([h]), frame="ENU", offline=off)
                e_i.append(_score(r.q_b_n, q, moving))
                e_z.append(_score(zupt_correct(r, gyr, acc, h, smooth=off, **cfg), q, moving))
            key = f"{'with' if breaks else 'no'} breaks, {mode}"
            out[key] = {"iframe": float(np.mean(e_i)), "ZUPT filter": float(np.mean(e_z))}
    return out


def markdown(res: dict) -> str:
    names = res["trials"]
    lines = [
        "| mode | method | " + " | ".join(names) + " | mean |",
        "|---|---|" + "---|" * (len(names) + 1),
    ]
    for mode, m in res["modes"].items():
        for meth, v in m["rows"].items():
            lines.append(f"| {mode} | {meth} | " + " | ".join(f"{x:.3f}" for x in v) + f" | **{np.mean(v):.3f}** |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=None, help="write the results as JSON")
    ap.add_argument("--md", default=None, help="write the Markdown table")
    args = ap.parse_args(argv)
    res = run()
    if not res:
        print("no BROAD trials in", SHARED / "attitude" / "broad")
        return 0
    md = markdown(res)
    print(md)
    for mode, m in res["modes"].items():
        print(
            mode, "best on all:", m["best"], "chosen per fold:", m["chosen"], f"{m['s_per_sample'] * 1e9:.0f} ns/sample"
        )
    print("simulated hand motion", res["simulated"])
    print("rate check", res["rate_check_trial"], {k: round(v, 3) for k, v in res["rate_check"].items()})
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2) + "\n")
    if args.md:
        Path(args.md).write_text(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
