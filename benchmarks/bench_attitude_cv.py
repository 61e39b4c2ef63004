"""Leave-one-group-out cross-validation of the ``iframe`` defaults on the BROAD trials in shared/.

The defaults of ``optinav.attitude.estimate`` were developed on the BROAD trials in
``../shared/data/attitude/broad`` (Laidig et al. 2021, CC BY 4.0); their mean error there is a training score.
This benchmark scores the choice honestly: for a grid of the parameters the 6D estimate is sensitive to
(``tau_acc`` in s, ``bias_motion`` in rad/s·√s, ``motion_max_gyr`` in rad/s, 0 = no limit; all
rate-independent), every BROAD group (BROAD's own
``trials.json``: motion, speed and disturbance categories) is held out in turn, the grid point with the best mean
on the other groups is chosen, and the held-out trials are scored with it. Rows: the cross-validated mean
inclination RMSE (BROAD metric, movement samples) online and offline (offline also with the grid point chosen on
the online error, the options being the filter's), beside the defaults' training mean, and the chosen grid point
per fold; and the option ``latency`` (not a default) chosen among 0, h/2, h the same way.

VQF (the comparison of the README) gets the same procedure: a grid of the same size around its defaults on its
own options of the same roles — ``tauAcc`` (s, the same values as iframe's ``tau_acc``), the motion bias
estimation (off, or ``biasSigmaMotion`` at 0.4, 1 and 2 times its default in °/s, as iframe's ``bias_motion``
grid is 0, 0.4, 1 and 2 times its default) and, as the third two-valued axis, ``restBiasEstEnabled`` — the
same folds, the same choice by the other groups' mean. Without it, iframe's defaults (developed on these trials)
would meet VQF's untuned defaults.

The 9D heading (heading RMSE, BROAD metric) the same way, both methods' 6D options at their defaults: each
method's grid varies its own three magnetometer options its mean heading error moves most with (measured, see
:data:`IFRAME_MAG`) by the same factors of its own defaults — the heading correction's time constant ×0.5, ×0.71,
×1, ×1.41, ×2, the two rejection options ×0.5, ×1, ×2 (45 points each; iframe ``tau_mag``, ``mag_norm_th``,
``mag_dip_th``, with the offline heading's ``tau_mag_smooth`` scaled as ``tau_mag``; VQF ``tauMag``,
``magRejectionFactor``, ``magDipTh``). Rows per fold also give the held-out
group's heading with the chosen point and with the defaults. ``--no-mag`` skips this part, ``--wide`` takes
×0.25 … ×4 on all three (343 points each, whether the grid's edges capped a choice).
``python benchmarks/bench_attitude_cv.py [--quick] [--no-mag] [--wide] [--json FILE]`` (progress on stderr).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
from pathlib import Path

import numpy as np

from optinav.attitude import estimate_q
from optinav.attitude.data import load_broad
from optinav.attitude.iframe import IFRAME_DEFAULTS
from optinav.attitude.metrics import heading_error, inclination_error, rmse

#: the shared data folder: ../shared/data relative to the project root ($OPTINAV_SHARED_DATA overrides)
SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))


_CATEGORIES = ("motion", "speed", "disturbance")  # the trial groups of BROAD's trials.json that define a fold
_D2R = np.pi / 180.0


def _groups(folder: Path, names: list[str]) -> list[str]:
    """Fold label of every trial: its level-2 BROAD groups of the motion/speed/disturbance categories."""
    meta = json.loads((folder / "trials.json").read_text())
    cat = {g["name"]: g["category"] for g in meta["groups"]}
    return ["+".join(sorted(g for g in meta["trials"][n]["groups"] if cat.get(g) in _CATEGORIES)) for n in names]


_TAU = (3.0, 4.0, 5.0)  # s, both methods' accelerometer low-pass time constant
#: VQF's motion bias σ (°/s): off, and ×0.4, ×1, ×2 of its default 0.1 (as iframe's bias_motion grid)
_VQF_MOTION = {True: (0.0, 0.1), False: (0.0, 0.04, 0.1, 0.2)}


def _grid(quick: bool) -> list[dict]:
    bm = (0.0, 0.05 * _D2R) if quick else (0.0, 0.02 * _D2R, 0.05 * _D2R, 0.1 * _D2R)  # 0 and ×0.4, ×1, ×2
    mg = (0.0, 2.0)  # no limit, and the former default 2 rad/s
    return [{"tau_acc": t, "bias_motion": b, "motion_max_gyr": m} for t, b, m in itertools.product(_TAU, bm, mg)]


def _vqf_grid(quick: bool) -> list[dict]:
    """VQF's grid of the same size and roles as :func:`_grid` (module docstring); ``biasSigmaMotion`` in °/s."""
    out = []
    for t, sm, rest in itertools.product(_TAU, _VQF_MOTION[quick], (True, False)):
        cfg = {"tauAcc": t, "motionBiasEstEnabled": sm > 0, "restBiasEstEnabled": rest}
        if sm > 0:
            cfg["biasSigmaMotion"] = sm
        out.append(cfg)
    return out


#: VQF's defaults of the options its grid varies (biasSigmaMotion in °/s)
VQF_DEFAULTS = {"tauAcc": 3.0, "motionBiasEstEnabled": True, "restBiasEstEnabled": True, "biasSigmaMotion": 0.1}


def grids(quick: bool) -> dict[str, list[dict]]:
    """The grid each method is tuned on, its defaults included (the same number of points for every method)."""
    out = {"iframe": _grid(quick), "vqf": _vqf_grid(quick)}
    iframe_default = {k: IFRAME_DEFAULTS[k] for k in out["iframe"][0]}
    for name, default in (("iframe", iframe_default), ("vqf", VQF_DEFAULTS)):
        if default not in out[name]:
            out[name].append(default)
    return out


#: the magnetometer options of each method's 9D grid, the ones its mean heading RMSE on BROAD moves most with
#: (each alone ×0.5 / ×2 from the defaults, 6D options at theirs; mean 1.946° / 2.212° at the defaults): iframe
#: tau_mag +0.13 / +0.19°, mag_norm_th −0.04 / +0.40°, mag_dip_th +0.02 / +0.08° (mag_new_time, tau_mag_ref,
#: mag_current_tau < 0.01°); VQF tauMag +0.38 / −0.07°, magRejectionFactor +0.28 / −0.14°, magDipTh +0.09 /
#: +0.04° (magDistRejectionEnabled off +0.33°, the factor's extreme; magCurrentTau +0.02 / +0.07°, magNormTh,
#: magRefTau, magNewTime, magMaxRejectionTime < 0.01°). The same roles: the heading correction's time
#: constant, the dip gate, and the rejection option the method is most sensitive to
IFRAME_MAG, IFRAME_MAG_UNITS = ("tau_mag", "mag_norm_th", "mag_dip_th"), ("s", "", "rad")
VQF_MAG, VQF_MAG_UNITS = ("tauMag", "magRejectionFactor", "magDipTh"), ("s", "", "deg")
#: iframe's offline heading has its own time constant: it moves with the heading's, by the same factor (VQF's
#: offline mode has one ``tauMag`` for both), so the grid keeps the size of VQF's
IFRAME_MAG_TIED = {"tau_mag_smooth": "tau_mag"}
#: VQF's defaults of the options its 9D grid varies (magDipTh in °)
VQF_MAG_DEFAULTS = {"tauMag": 9.0, "magRejectionFactor": 2.0, "magDipTh": 10.0}
#: factors of every 9D grid around each method's own defaults: the time constant, then the two rejection options
_MAG_TAU_F = {True: (1.0, 2**0.5), False: (0.5, 2**-0.5, 1.0, 2**0.5, 2.0)}
_MAG_REJ_F = {True: (1.0, 2.0), False: (0.5, 1.0, 2.0)}
#: ``--wide``: whether the grid's edges capped a choice, ×0.25 … ×4 on all three options (343 points)
_MAG_WIDE_F = (0.25, 0.5, 2**-0.5, 1.0, 2**0.5, 2.0, 4.0)


def mag_grids(quick: bool, wide: bool = False) -> dict[str, list[dict]]:
    """Each method's 9D grid: the same factors of its own defaults (:data:`IFRAME_MAG`, :data:`VQF_MAG`)."""
    out = {}
    fac = (_MAG_WIDE_F,) * 3 if wide else (_MAG_TAU_F[quick], _MAG_REJ_F[quick], _MAG_REJ_F[quick])
    for name, keys, default in (
        ("iframe", IFRAME_MAG, iframe_mag_defaults()),
        ("vqf", VQF_MAG, VQF_MAG_DEFAULTS),
    ):
        out[name] = [{k: default[k] * x for k, x in zip(keys, fs)} for fs in itertools.product(*fac)]
    for p in out["iframe"]:
        p.update({k: IFRAME_DEFAULTS[k] * p[a] / IFRAME_DEFAULTS[a] for k, a in IFRAME_MAG_TIED.items()})
    return out


def iframe_mag_defaults() -> dict:
    """iframe's defaults of the options its 9D grid sets (:data:`IFRAME_MAG` and :data:`IFRAME_MAG_TIED`)."""
    return {k: IFRAME_DEFAULTS[k] for k in (*IFRAME_MAG, *IFRAME_MAG_TIED)}


def _iframe_run(tr, cfg: dict, offline: bool, nine: bool = False) -> np.ndarray:
    mag = tr.mag if nine else None
    return estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=offline, checks=False, **cfg)


def _vqf_run(tr, cfg: dict, offline: bool, nine: bool = False) -> np.ndarray:
    import vqf

    g, a = np.ascontiguousarray(tr.gyr), np.ascontiguousarray(tr.acc)
    m, out = (np.ascontiguousarray(tr.mag), "quat9D") if nine else (None, "quat6D")
    if offline:
        return vqf.offlineVQF(g, a, m, tr.dt, dict(cfg))[out]
    return vqf.VQF(tr.dt, **cfg).updateBatch(g, a, m)[out]


def _scores(trials, grid, run_one, nine: bool = False, name: str = "") -> dict[str, np.ndarray]:
    """RMSE (deg) per (grid point, trial), online and offline: inclination (6D) or, ``nine``, heading (9D)."""
    dims, err = ("9D", heading_error) if nine else ("6D", inclination_error)
    out = {}
    for mode, offline in (("online", False), ("offline", True)):
        print(f"  {name} {dims} {mode}: {len(grid)} grid points x {len(trials)} trials", file=sys.stderr, flush=True)
        out[f"{dims} {mode}"] = np.array(
            [
                [np.degrees(rmse(err(run_one(tr, cfg, offline, nine), tr.q_ref), tr.eval_mask)) for tr in trials]
                for cfg in grid
            ]
        )
    return out


def logo_cv(err: np.ndarray, groups: list[str]) -> tuple[np.ndarray, dict]:
    """``err`` (configs, trials): per-trial held-out errors and the chosen config index per held-out group."""
    g = np.asarray(groups)
    out = np.empty(err.shape[1])
    chosen = {}
    for grp in dict.fromkeys(groups):
        test = g == grp
        k = int(np.argmin(err[:, ~test].mean(axis=1)))
        out[test] = err[k, test]
        chosen[grp] = k
    return out, chosen


def _cv_rows(name: str, label: str, err: dict, groups: list[str], grid: list[dict], default: dict, values) -> list:
    """Rows of one method's leave-one-group-out CV; ``err`` mode → (grid points, trials) RMSE in deg, ``label``
    the grid's options, ``values(cfg)`` the (option, value, unit) of a chosen point. An offline mode is also
    scored at the point its online mode chose (the options are the filter's, shared by both modes)."""
    rows = []
    for mode, e in err.items():
        metric = "heading RMSE" if mode.startswith("9D") else "inclination RMSE"
        cv, chosen = logo_cv(e, groups)
        row = {"group": f"attitude {name} {mode}, leave-one-BROAD-group-out CV over {e.shape[1]} trials", "unit": "deg"}
        rows.append(
            {
                **row,
                "method": f"{name}, grid of {len(grid)} ({label})",
                "metric": f"cross-validated mean {metric}",
                "value": float(cv.mean()),
            }
        )
        online = mode.replace("offline", "online")
        if online != mode and online in err:
            _, on_chosen = logo_cv(err[online], groups)
            held = np.array([e[on_chosen[g], i] for i, g in enumerate(groups)])
            rows.append(
                {
                    **row,
                    "method": f"{name}, grid point chosen on the online error",
                    "metric": f"cross-validated mean {metric}",
                    "value": float(held.mean()),
                }
            )
        d = grid.index(default)
        for method, v in ((f"{name} defaults", e[d].mean()), ("best grid point on all trials", e.mean(axis=1).min())):
            rows.append({**row, "method": method, "metric": f"training mean {metric}", "value": float(v)})
        g = np.asarray(groups)
        for grp, k in chosen.items():
            fold = {**row, "method": f"fold without {grp}"}
            for key, v, unit in values(grid[k]):
                rows.append({**fold, "metric": f"chosen {key}", "value": float(v), "unit": unit})
            if mode.startswith("9D"):  # whether the held-out group itself prefers the chosen point to the defaults
                for what, j in (("chosen point", k), ("defaults", d)):
                    v = e[j, g == grp].mean()
                    rows.append({**fold, "metric": f"held-out mean {metric}, {what}", "value": float(v)})
    return rows


def _iframe_values(cfg: dict) -> list:
    return [
        ("tau_acc", cfg["tau_acc"], "s"),
        ("bias_motion", cfg["bias_motion"], "rad/s*sqrt(s)"),
        ("motion_max_gyr", cfg["motion_max_gyr"], "rad/s"),
    ]


def _vqf_values(cfg: dict) -> list:
    sm = cfg.get("biasSigmaMotion", 0.0) if cfg["motionBiasEstEnabled"] else 0.0
    return [
        ("tauAcc", cfg["tauAcc"], "s"),
        ("biasSigmaMotion", sm, "deg/s"),
        ("restBiasEstEnabled", cfg["restBiasEstEnabled"], ""),
    ]


def _mag_values(names: tuple, units: tuple):
    return lambda cfg: [(k, cfg[k], u) for k, u in zip(names, units)]


def _vqf_rows(trials, groups, quick: bool) -> list[dict]:
    """VQF tuned by the same leave-one-group-out procedure as iframe (its grid: :func:`grids`)."""
    grid = grids(quick)["vqf"]
    err = _scores(trials, grid, _vqf_run, name="vqf")
    label = "tauAcc, biasSigmaMotion, restBiasEstEnabled"
    return _cv_rows("vqf", label, err, groups, grid, VQF_DEFAULTS, _vqf_values)


def _mag_rows(trials, groups, quick: bool, with_vqf: bool, wide: bool = False) -> list[dict]:
    """The 9D heading of each method tuned alike on its magnetometer options (:func:`mag_grids`), 6D options at
    their defaults."""
    rows = []
    grid = mag_grids(quick, wide)
    for name, run_one, names, units, default in (
        ("iframe", _iframe_run, IFRAME_MAG, IFRAME_MAG_UNITS, iframe_mag_defaults()),
        ("vqf", _vqf_run, VQF_MAG, VQF_MAG_UNITS, VQF_MAG_DEFAULTS),
    ):
        if name == "vqf" and not with_vqf:
            continue
        err = _scores(trials, grid[name], run_one, nine=True, name=name)
        rows += _cv_rows(name, ", ".join(names), err, groups, grid[name], default, _mag_values(names, units))
    return rows


def run(quick: bool, mag: bool = True, wide: bool = False) -> list[dict]:
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    if len(paths) < 3 or not (folder / "trials.json").is_file():
        return []
    trials = [load_broad(p) for p in paths]
    groups = _groups(folder, [p.stem for p in paths])
    grid = grids(quick)["iframe"]
    default = {k: IFRAME_DEFAULTS[k] for k in grid[0]}
    err = _scores(trials, grid, _iframe_run, name="iframe")
    label = "tau_acc, bias_motion, motion_max_gyr"
    rows = _cv_rows("iframe", label, err, groups, grid, default, _iframe_values)
    try:
        import vqf  # noqa: F401

        with_vqf = True
    except ImportError:
        with_vqf = False
    if with_vqf:
        rows += _vqf_rows(trials, groups, quick)
    # the option ``latency`` (not a default): how late the IMU's samples are, chosen among 0, h/2, h the same way.
    # Every BROAD group shares one IMU and one synchronization, so this CV cannot show that it transfers.
    lat = (0.0, 0.5, 1.0)
    for mode, offline in (("6D online", False), ("6D offline", True)):
        e = np.array(
            [
                [
                    np.degrees(
                        rmse(
                            inclination_error(
                                estimate_q(
                                    tr.gyr, tr.acc, tr.dt, frame="ENU", offline=offline, checks=False, latency=s * tr.dt
                                ),
                                tr.q_ref,
                            ),
                            tr.eval_mask,
                        )
                    )
                    for tr in trials
                ]
                for s in lat
            ]
        )
        cv, chosen = logo_cv(e, groups)
        grp = f"attitude iframe {mode}, option latency in (0, h/2, h), leave-one-BROAD-group-out CV"
        rows.append(
            {
                "group": grp,
                "method": "iframe defaults + latency chosen per fold",
                "metric": "cross-validated mean inclination RMSE",
                "value": float(cv.mean()),
                "unit": "deg",
            }
        )
        for name, f in (("smallest", min), ("largest", max)):
            rows.append(
                {
                    "group": grp,
                    "method": f"{name} over the folds",
                    "metric": "chosen latency",
                    "value": f(lat[k] for k in chosen.values()),
                    "unit": "samples",
                }
            )
    if mag:
        rows += _mag_rows(trials, groups, quick, with_vqf, wide)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smaller grid")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    ap.add_argument("--no-mag", action="store_true", help="skip the 9D heading (magnetometer options)")
    ap.add_argument("--wide", action="store_true", help="9D: x0.25 ... x4 on every option (343 points, slow)")
    args = ap.parse_args(argv)
    rows = run(args.quick, mag=not args.no_mag, wide=args.wide)
    for r in rows:
        print(f"{r['group']} | {r['method']} | {r['metric']}: {r['value']:.4g} {r['unit']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
