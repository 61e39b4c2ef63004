"""One turntable recording of a gyro-free accelerometer array, as :mod:`optinav.batch` runs it (registry:
``gfimu``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from optinav.core.progress import step
from optinav.errors import OptinavError
from optinav.gfimu.array import AccelerometerArray, builtin, identifiability
from optinav.gfimu.turntable import TurntableCalibration, calibrate, g_unit, read_cases


@dataclasses.dataclass
class GfimuOptions:
    """The options of ``optinav calibrate gfimu``: the nominal array (``config`` file or ``builtin`` name),
    ``method`` ("lm" or "closed-form"), ``offset`` ("unknown": Δr relative to their mean; "zero": centred on the
    table axis; "estimate"; or the measured (x, y, z) in m),
    ``rate_unit`` of the table_rate column ("rad/s" or "deg/s"), ``noise`` accelerometer std in m/s² (None:
    from the data), ``rate_accuracy`` the table rates' relative 1σ (0: exact; in the std)."""

    config: str | None = None
    builtin: str | None = None
    method: str = "lm"
    offset: str | tuple = "unknown"
    rate_unit: str = "rad/s"
    noise: float | None = None
    rate_accuracy: float = 0.0

    def array(self) -> AccelerometerArray:
        """The nominal array: the configuration file or the built-in one."""
        if self.config and self.builtin:
            raise OptinavError("both CONFIG.json and --builtin were given", "pass one of them")
        if self.builtin:
            return builtin(self.builtin)
        if not self.config:
            raise OptinavError(
                "no configuration given", "pass CONFIG.json (--config in a batch) or --builtin cylinder10"
            )
        return AccelerometerArray.load(self.config)


def check(options: GfimuOptions) -> None:
    if options.method not in ("lm", "closed-form"):
        raise OptinavError(f"unknown calibration method {options.method!r}", "use 'lm' or 'closed-form'")
    if options.rate_unit not in ("rad/s", "deg/s"):
        raise OptinavError(f"--rate-unit {options.rate_unit!r}", "use rad/s or deg/s")
    if not (0.0 <= options.rate_accuracy < 0.1):
        raise OptinavError(
            f"--rate-accuracy {options.rate_accuracy:g} is not a relative accuracy in [0, 0.1)",
            "give the table rates' relative 1σ, e.g. 1e-4",
        )
    identifiability(options.array()).require(("linear",))


def run_unit(path, options: GfimuOptions, reference: bool = False) -> tuple[TurntableCalibration, dict]:
    """Read and calibrate ``path`` (what ``optinav calibrate gfimu`` does); extra columns: samples, rank,
    residual RMS (in σ)."""
    step("read")
    # the fit needs the per-case means only: summarized while reading, so memory does not grow with the log
    factor = np.pi / 180.0 if options.rate_unit == "deg/s" else 1.0
    data = read_cases(path, options.array().n, factor)
    offset = options.offset if isinstance(options.offset, str) else np.asarray(options.offset, float)
    step(f"fit ({options.method})")
    res = calibrate(
        options.array(),
        data,
        method=options.method,
        offset=offset,
        sigma=options.noise,
        rate_accuracy=options.rate_accuracy,
    )
    return res, {
        "n_samples": int(data.samples),
        "rank": int(res.rank),
        "n_params": int(res.n_params),
        "residual_rms_sigma": float(res.residual_rms),
    }


@dataclasses.dataclass
class GfimuApplyOptions:
    """How ``optinav apply`` solves an array recording: ``omega0`` the angular rate at the first sample (rad/s,
    (x, y, z); None: at rest) and ``rate_method`` one of :data:`optinav.gfimu.solve.RATE_METHODS`."""

    omega0: tuple | None = None
    rate_method: str = "integration"


#: a solved rate beyond this (rad/s, 11 000 °/s) is a diverging integration, not a motion
MAX_RATE = 200.0


def _check_motion(m, data_path, first: bool) -> None:
    """The solved motion must be finite and below :data:`MAX_RATE` (two output columns swapped made the rate
    integration diverge to 1e227 rad/s, then NaN, with exit 0); the first block's specific force must not read
    1 (or 1000) where it reads about g in m/s² (outputs in g or mg: a rate 3× too small with exit 0)."""
    ok = np.isfinite(m.omega).all(axis=1) & np.isfinite(m.A).all(axis=1)
    big = ok & np.any(np.abs(np.where(ok[:, None], m.omega, 0.0)) > MAX_RATE, axis=1)
    bad = np.flatnonzero(~ok | big)
    if bad.size:
        raise OptinavError(
            f"the rate solution of {Path(data_path).name} diverges at t = {m.t[bad[0]]:.6g} s (a rate beyond "
            f"{MAX_RATE:g} rad/s or not finite): the outputs contradict the calibrated geometry",
            "check the order of the output columns f1..fN against the configuration, --omega0, and that t is in "
            "seconds (or its name gives the unit: t [ms])",
        )
    if first and m.A.shape[0]:
        med = float(np.median(np.linalg.norm(m.A, axis=1)))
        unit = g_unit(med)
        if unit is not None:
            raise OptinavError(
                f"the specific force solved from {Path(data_path).name} reads {med:.4g} (median |A| of the first "
                f"{m.A.shape[0]} samples): the outputs look like {unit}, not m/s^2",
                "convert the accelerometer outputs to m/s^2",
            )


#: the outputs' misfit to the calibrated rigid-body model beyond this many times the noise measured at
#: calibration (median over the outputs, per block) is another array or swapped columns, not a motion
MAX_MISFIT = 30.0


#: the outputs left after one is left out fit when their misfit is within this many times the calibration's noise
#: (a correct recording: 0.5-0.6; a wrong --omega0 left 12-18 whichever output was left out, and one was named)
LEFT_OUT_FIT = 3.0
#: a misfit beyond this many times the noise (below MAX_MISFIT) is refused when one output left out lets the others
#: fit: a faulty sensor (a bias of 0.002 m/s² on f5, 29×, gave a rate 0.013 rad/s off after 1 s, exit 0)
SUSPECT_MISFIT = 5.0


def _check_fit(residual_rms, sigma, data_path, culprit=None, refit=None, method: str = "integration") -> None:
    """The array's outputs must fit the calibrated geometry (the model's residual per output against the noise the
    calibration measured): two columns swapped gave a plausible-looking wrong rate until it diverged. ``culprit``
    (called only on a misfit beyond :data:`SUSPECT_MISFIT`) gives the output whose removal lets the others fit
    (:func:`_culprit`): named beyond :data:`MAX_MISFIT`, and refused from SUSPECT_MISFIT on. ``refit`` (called
    first) gives the misfit of the method's rate and of the Gauss–Newton rate on the same epochs
    (:func:`_refit`): where the latter fits, the method's rate drifted, not a sensor."""
    if residual_rms is None or sigma is None:
        return
    sigma = np.asarray(sigma, float)
    if sigma.shape != residual_rms.shape or not np.all(sigma > 0):
        return
    ratio = float(np.median(residual_rms / sigma))
    if ratio <= SUSPECT_MISFIT:
        return
    # at a 2 rad/s spin the integration's rate drifted 0.012 rad/s: 16x the noise, and a sensor was blamed
    again = refit() if refit is not None else None
    if again is not None and again[1] <= LEFT_OUT_FIT < SUSPECT_MISFIT < again[0]:
        raise OptinavError(
            f"the {method} method's rate drifted off the outputs of {Path(data_path).name}: with it the rigid-body "
            f"model leaves {again[0]:.3g}× the noise measured at calibration, with the Gauss–Newton rate on the same "
            f"epochs {again[1]:.3g}× (the outputs fit the calibrated geometry)",
            "use --rate-method gauss-newton (or check --omega0, the rate at the log's first sample)",
        )
    # the least-squares residual of one faulty output spreads onto the others (and through the rate onto all):
    # the output left out is named, not the largest residual (a bias on f5 was named f6)
    best = culprit() if culprit is not None else None
    one = best is not None and best[1] <= LEFT_OUT_FIT
    if not one and ratio <= MAX_MISFIT:
        return
    where = (
        f"without f{best[0] + 1} the others fit ({best[1]:.3g}× the noise): f{best[0] + 1} is off"
        if one
        else "no one output left out makes the others fit"
    )
    raise OptinavError(
        f"the outputs of {Path(data_path).name} do not fit the calibrated geometry: the rigid-body model leaves "
        f"{ratio:.3g}× the noise measured at calibration (median over the outputs; {where})",
        "check --omega0 (the rate at the log's first sample; default: at rest), the order of the output "
        "columns f1..fN against the configuration, and that this is the calibrated array",
    )


#: the leave-one-out solves of :func:`_culprit` take at most this many epochs of a block (the rate methods are
#: Python loops, ≈ 1 s per 10⁴ epochs: ten solves of a 200 000-row block took minutes)
CULPRIT_EPOCHS = 2000


def _refit(array, f, t, omega, method: str, sigma) -> tuple[float, float] | None:
    """(the method's misfit, the Gauss–Newton rate's) — median over the outputs of the residual RMS over ``sigma``
    (N,) m/s² — on the :data:`CULPRIT_EPOCHS` epochs up to the worst fitted one of the block ``f`` (T, N) m/s² at
    ``t`` (T,) s, whose rate the method gave as ``omega`` (T, 3) rad/s; the filter starts from the method's rate
    there. None for the Gauss–Newton method itself."""
    from optinav.gfimu.solve import MotionSolver, rigid_fit

    if method == "gauss-newton":
        return None
    sigma = np.asarray(sigma, float)
    res = rigid_fit(array, f, omega)[1] / sigma
    k = int(np.argmax(np.sum(res * res, axis=1)))
    a = max(0, k + 1 - CULPRIT_EPOCHS)
    mine = float(np.median(np.sqrt(np.mean(res[a : k + 1] ** 2, axis=0))))
    solver = MotionSolver(array, omega[a], "gauss-newton")
    with np.errstate(over="ignore", invalid="ignore"):
        solver(f[a : k + 1], t[a : k + 1])
    theirs = float(np.median(solver.residual_rms / sigma))
    return (mine, theirs) if np.isfinite(theirs) else None


def _culprit(array, f, t, state, method: str, sigma) -> tuple[int, float] | None:
    """Leave-one-out: per output k, the block ``f`` (T, N) m/s² at ``t`` (T,) s (its first
    :data:`CULPRIT_EPOCHS`) solved again without it from the rate state before the block; the k whose removal
    leaves the others the smallest misfit (median residual RMS over ``sigma`` (N,) m/s²) and that misfit, or None
    when no array of N − 1 outputs can be solved."""
    import copy

    from optinav.gfimu.solve import MotionSolver

    f, t = f[:CULPRIT_EPOCHS], t[:CULPRIT_EPOCHS]
    best = None
    for k in range(array.n):
        keep = np.arange(array.n) != k
        noise = None if array.noise is None else np.asarray(array.noise)[keep]
        try:
            solver = MotionSolver(
                AccelerometerArray(array.positions[keep], array.directions[keep], noise), None, method
            )
            solver.state = copy.deepcopy(state)
            with np.errstate(over="ignore", invalid="ignore"):
                solver(f[:, keep], t)
        except OptinavError:
            continue
        r = solver.residual_rms / np.asarray(sigma, float)[keep]
        if np.all(np.isfinite(r)) and (best is None or float(np.median(r)) < best[1]):
            best = (k, float(np.median(r)))
    return best


#: the header of the table ``optinav apply`` writes for this system (how it knows its own output again)
APPLY_COLUMNS = "t,ax,ay,az,gx,gy,gz,wdot_x,wdot_y,wdot_z"


def apply_file(result_path, data_path, out, options: GfimuApplyOptions | None = None) -> str:
    """``optinav apply`` for a gfimu result: solve the array outputs of ``data_path`` (t and f1..fN, or an array
    f, m/s²) with the calibrated geometry (the paper's compensation) and write ``out`` (CSV): t (s), specific
    force A at the array's reference point ax, ay, az (m/s²), angular rate gx, gy, gz (rad/s) and angular
    acceleration wdot_x..z (rad/s²); returns the one-line account. Text logs are read, solved and written block
    by block (:class:`~optinav.gfimu.solve.MotionSolver` carries the rate between blocks), so memory does not grow
    with the log; ``out`` appears only when every block was solved."""
    import copy

    from optinav.core.files import csv_writer
    from optinav.core.progress import progress_blocks
    from optinav.gfimu.solve import RATE_METHODS, MotionSolver
    from optinav.gfimu.turntable import array_outputs
    from optinav.io.imu import TIME_UNITS
    from optinav.io.readers import find_with_unit, iter_table

    o = options or GfimuApplyOptions()
    if o.rate_method not in RATE_METHODS:
        raise OptinavError(f"unknown rate method {o.rate_method!r}", f"--rate-method one of {', '.join(RATE_METHODS)}")
    if Path(out).suffix.lower() not in (".csv", ".txt"):
        raise OptinavError(f"--out {out}: this result's output is a CSV table", "name it FILE.csv")
    res = TurntableCalibration.from_json(result_path)
    solver = MotionSolver(res.calibrated_array(), o.omega0, o.rate_method)
    blocks = iter_table(data_path)
    with csv_writer(out, APPLY_COLUMNS, "%.12g") as write:
        for tab in progress_blocks(blocks, "apply: gfimu"):
            key, unit = find_with_unit(tab, "t", TIME_UNITS)  # t in s, or a unit in its name: t [ms], t_us
            unit = unit or tab.units.get(key) if key is not None else None
            if key is None or (unit is not None and unit not in TIME_UNITS):
                raise OptinavError(
                    f"{data_path} has no time column t" + (f" in s, ms, us or ns ({key} is in {unit})" if key else ""),
                    "add a column t in s (or name its unit: t [ms], t_us)",
                )
            f = array_outputs(tab, data_path, len(res.dalpha))
            first, state = solver.rows == 0, copy.deepcopy(solver.state)
            with np.errstate(over="ignore", invalid="ignore"):  # a diverging solution is named below
                m = solver(f, np.asarray(tab.get(key), float) * TIME_UNITS.get(unit, 1.0))
            _check_motion(m, data_path, first)
            tt = m.t
            _check_fit(
                solver.residual_rms,
                res.sigma,
                data_path,
                lambda: _culprit(solver.array, f, tt, state, o.rate_method, res.sigma),  # noqa: B023 (called here)
                lambda: _refit(solver.array, f, tt, m.omega, o.rate_method, res.sigma),  # noqa: B023 (called here)
                o.rate_method,
            )
            write(np.column_stack([m.t, m.A, m.omega, m.wdot]))
        if solver.rows < 2:  # as the whole-log solve: a rate needs two epochs (the file is not written)
            raise OptinavError(f"{data_path} has {solver.rows} sample(s), at least 2 are needed", "record a longer log")
    return (
        f"wrote the motion of {solver.rows} samples to {out}, solved with the calibrated geometry of "
        f"{len(res.dalpha)} accelerometers ({o.rate_method}; m/s^2, rad/s, rad/s^2)"
    )
