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
would meet VQF's untuned defaults. ``python benchmarks/bench_attitude_cv.py [--quick] [--json FILE]``.
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
from optinav.attitude.metrics import inclination_error, rmse

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


def _iframe_run(tr, cfg: dict, offline: bool) -> np.ndarray:
    return estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", offline=offline, checks=False, **cfg)


def _vqf_run(tr, cfg: dict, offline: bool) -> np.ndarray:
    import vqf

    g, a = np.ascontiguousarray(tr.gyr), np.ascontiguousarray(tr.acc)
    if offline:
        return vqf.offlineVQF(g, a, None, tr.dt, dict(cfg))["quat6D"]
    return vqf.VQF(tr.dt, **cfg).updateBatch(g, a)["quat6D"]


def _scores(trials, grid, run_one) -> dict[str, np.ndarray]:
    """Inclination RMSE (deg) per (grid point, trial), online and offline."""
    return {
        mode: np.array(
            [
                [
                    np.degrees(rmse(inclination_error(run_one(tr, cfg, offline), tr.q_ref), tr.eval_mask))
                    for tr in trials
                ]
                for cfg in grid
            ]
        )
        for mode, offline in (("6D online", False), ("6D offline", True))
    }


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


def _vqf_rows(trials, groups, quick: bool) -> list[dict]:
    """VQF tuned by the same leave-one-group-out procedure as iframe (its grid: :func:`grids`)."""
    try:
        import vqf  # noqa: F401
    except ImportError:
        return []
    grid = grids(quick)["vqf"]
    err = _scores(trials, grid, _vqf_run)
    rows = []
    for mode, e in err.items():
        cv, chosen = logo_cv(e, groups)
        grp = f"attitude vqf {mode}, leave-one-BROAD-group-out CV over {len(trials)} trials"
        row = dict(group=grp, metric="cross-validated mean inclination RMSE", unit="deg")
        rows.append(
            {
                **row,
                "method": f"vqf, grid of {len(grid)} (tauAcc, biasSigmaMotion, restBiasEstEnabled)",
                "value": float(cv.mean()),
            }
        )
        if mode == "6D offline":
            _, on_chosen = logo_cv(err["6D online"], groups)
            held = np.array([e[on_chosen[g], i] for i, g in enumerate(groups)])
            rows.append({**row, "method": "vqf, grid point chosen on the online error", "value": float(held.mean())})
        rows.append(
            {
                **row,
                "method": "vqf defaults",
                "metric": "training mean inclination RMSE",
                "value": float(e[grid.index(VQF_DEFAULTS)].mean()),
            }
        )
        rows.append(
            {
                **row,
                "method": "best grid point on all trials",
                "metric": "training mean inclination RMSE",
                "value": float(e.mean(axis=1).min()),
            }
        )
        for g, k in chosen.items():
            for key, unit in (("tauAcc", "s"), ("biasSigmaMotion", "deg/s"), ("restBiasEstEnabled", "")):
                v = grid[k].get(key, 0.0) if grid[k]["motionBiasEstEnabled"] or key != "biasSigmaMotion" else 0.0
                rows.append(
                    {**row, "method": f"fold without {g}", "metric": f"chosen {key}", "value": float(v), "unit": unit}
                )
    return rows


def run(quick: bool) -> list[dict]:
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    if len(paths) < 3 or not (folder / "trials.json").is_file():
        return []
    trials = [load_broad(p) for p in paths]
    groups = _groups(folder, [p.stem for p in paths])
    grid = grids(quick)["iframe"]
    default = {k: IFRAME_DEFAULTS[k] for k in grid[0]}
    err = _scores(trials, grid, _iframe_run)
    rows = []
    for mode, e in err.items():
        cv, chosen = logo_cv(e, groups)
        grp = f"attitude iframe {mode}, leave-one-BROAD-group-out CV over {len(trials)} trials"
        rows.append(
            {
                "group": grp,
                "method": f"iframe, grid of {len(grid)} (tau_acc, bias_motion, motion_max_gyr)",
                "metric": "cross-validated mean inclination RMSE",
                "value": float(cv.mean()),
                "unit": "deg",
            }
        )
        if mode == "6D offline":
            # the options are the filter's, shared by both modes: chosen on the online error of the other groups
            _, on_chosen = logo_cv(err["6D online"], groups)
            held = np.array([e[on_chosen[g], i] for i, g in enumerate(groups)])
            rows.append(
                {
                    "group": grp,
                    "method": "iframe, grid point chosen on the online error",
                    "metric": "cross-validated mean inclination RMSE",
                    "value": float(held.mean()),
                    "unit": "deg",
                }
            )
        rows.append(
            {
                "group": grp,
                "method": "iframe defaults",
                "metric": "training mean inclination RMSE",
                "value": float(e[grid.index(default)].mean()),
                "unit": "deg",
            }
        )
        rows.append(
            {
                "group": grp,
                "method": "best grid point on all trials",
                "metric": "training mean inclination RMSE",
                "value": float(e.mean(axis=1).min()),
                "unit": "deg",
            }
        )
        for g, k in chosen.items():
            rows.append(
                {
                    "group": grp,
                    "method": f"fold without {g}",
                    "metric": "chosen tau_acc",
                    "value": grid[k]["tau_acc"],
                    "unit": "s",
                }
            )
            rows.append(
                {
                    "group": grp,
                    "method": f"fold without {g}",
                    "metric": "chosen bias_motion",
                    "value": grid[k]["bias_motion"],
                    "unit": "rad/s*sqrt(s)",
                }
            )
            rows.append(
                {
                    "group": grp,
                    "method": f"fold without {g}",
                    "metric": "chosen motion_max_gyr",
                    "value": grid[k]["motion_max_gyr"],
                    "unit": "rad/s",
                }
            )
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
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smaller grid")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    for r in rows:
        print(f"{r['group']} | {r['method']} | {r['metric']}: {r['value']:.4g} {r['unit']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
