"""Calibrate a multi-position session from a raw log: static intervals → accelerometer → gyroscope → result.

``calibrate`` is what ``optinav calibrate accel`` runs. Steps:

1. Rows with NaN/inf are dropped and counted; saturated samples (``acc_range``/``gyro_range`` in raw units,
   or, for raw counts, values at a 16/24/32-bit full scale) are excluded from the pose means and counted.
2. Static intervals: a section list (manual override) or the moving-variance detector. With the automatic
   threshold every candidate threshold of :func:`optinav.multipos.static.threshold_candidates` is scored by
   a quick fit: the reduced χ² (χ²/dof, residuals normalized by their within-pose noise, so it does not
   reward fewer intervals); among candidates whose reduced χ² is acceptable (≤ the 99 % χ² point, or ≤ 1.5 ×
   the best) the one with the most intervals, then the most static time, wins.
3. Accelerometer: :func:`optinav.multipos.accel.fit_accel` (closed-form start, then the chosen method).
4. Gyroscope (when given): :func:`optinav.multipos.gyro.calibrate_gyro` on the same intervals, with the
   gravity directions measured by the calibrated accelerometer.

``read_session_file(path, FileOptions(...))`` reads one log and ``calibrate_data`` calibrates it with the options
of ``optinav calibrate accel`` (same names) — the CLI command and ``optinav batch calibrate accel`` both run these
two; ``calibrate_file`` chains them for library users.
"""

from __future__ import annotations

import dataclasses
import time
from typing import NamedTuple

import numpy as np

from optinav.core.earth import WGS84
from optinav.core.files import CHUNK_ROWS
from optinav.core.earth import gravity as normal_gravity
from optinav.core.progress import progress_blocks, step
from optinav.core.results import convergence, gate
from optinav.core.units import G_STANDARD, factor
from optinav.core.validate import as_float_array, check_positive, check_timestamps, mask_runs
from optinav.errors import OptinavError, SwappedAxes
from optinav.io import iter_imu, raw_units
from optinav.io.imu import reader_options

from . import accel, gates, model, static
from .result import CalibrationResult

OMEGA_E = WGS84.omega_ie
_INT_BITS = (16, 24, 32)


def count_range(raw) -> tuple[float, float]:
    """Full scale (lo, hi) of the integer type that raw counts (N, 3) were written in, inferred from their
    range: unsigned (offset binary) 0 … 2^k − 1 when no sample is negative, else signed −2^(k−1) … 2^(k−1) − 1,
    with k the smallest of 16, 24, 32 bits that holds every sample."""
    x = np.asarray(raw, float).reshape(-1)
    lo, hi = np.inf, -np.inf
    for a in range(0, x.size, static._BLOCK):  # in blocks: no copy of the log
        xb = x[a : a + static._BLOCK]
        xb = xb[np.isfinite(xb)]
        if xb.size:
            lo, hi = min(lo, float(xb.min())), max(hi, float(xb.max()))
    if lo > hi:
        return -np.inf, np.inf
    for k in _INT_BITS:
        if lo >= 0 and hi <= 2.0**k - 1:
            return 0.0, 2.0**k - 1
        if lo >= -(2.0 ** (k - 1)) and hi <= 2.0 ** (k - 1) - 1:
            return -(2.0 ** (k - 1)), 2.0 ** (k - 1) - 1
    return -np.inf, np.inf


def gyro_full_scale_note(gyro_raw, K, flags: str = "--rate, --time-unit") -> str | None:
    """For a gyro in raw counts (no nominal scale to check K against): the full scale (deg/s) its fitted K
    implies for the integer type of the counts, for the user to compare with the sensor's range setting — a
    wrong time base scales every K alike. None when the type is not known."""
    lo, hi = count_range(gyro_raw)
    if not np.all(np.isfinite((lo, hi))):
        return None
    half = (hi - lo + 1.0) / 2.0
    fs = np.degrees(half / np.abs(np.diag(np.asarray(K, float))))
    bits = int(round(np.log2(hi - lo + 1.0)))
    return (
        f"the gyro scales in counts imply a full scale of ±{', ±'.join(f'{v:.4g}' for v in fs)} deg/s (x, y, z) for "
        f"{bits}-bit counts; if the sensor was set to another range, the time base is off by that ratio ({flags})"
    )


def saturated_mask(raw, limit=None, *, counts: bool = False, per_axis: bool = False) -> np.ndarray:
    """Rows (N,) with any axis at or beyond the full scale (``per_axis``: (N, 3), each axis): ``limit`` (raw units) is ±R (a scalar or one per
    axis) or a span (lo, hi); without it, raw ``counts`` saturate at the ends of the integer type they were
    written in (:func:`count_range`: never at mid-scale, so an unsigned ADC resting near 32768 is not
    saturated), and other units are not judged. A value within a few ulp of the limit counts as at it: deg/s or
    g read into SI and back differ from the text by an ulp (a gyro clipped at 30 °/s read 29.999999999999996)."""
    raw = np.asarray(raw, float)
    if limit is None:
        if not counts:
            return np.zeros(raw.shape if per_axis else raw.shape[0], bool)
        lo, hi = count_range(raw)
    elif isinstance(limit, tuple) and len(limit) == 2:
        lo, hi = float(limit[0]), float(limit[1])
    else:
        lim = np.broadcast_to(np.abs(as_float_array(limit, "range")), (3,))
        lo, hi = -lim, lim
    tol = 8 * np.finfo(float).eps * np.maximum(np.abs(lo), np.abs(hi))
    with np.errstate(invalid="ignore"):
        at = (raw <= lo + tol) | (raw >= hi - tol)
    return at if per_axis else np.any(at, axis=1)


def clipped_gyro_rows(gyr: np.ndarray, dt: float) -> np.ndarray:
    """Rows (N,) at an axis's extreme in runs that look saturated (the attitude input check's rule,
    :func:`optinav.attitude.checks.saturated_extremes`: flat for ≥ 3 samples and entered or left steeply, at least
    two runs or one of ≥ 5), whatever the unit: a gyro clipped at ±50 °/s, not at its integer type's ends, left
    K_xx 4 % low with exit 0. ``dt`` the median step (s)."""
    from optinav.attitude.checks import saturated_extremes

    out = np.zeros(gyr.shape[0], bool)
    for _, _, _, idx, _ in saturated_extremes(gyr, dt, min_peak=np.finfo(float).tiny):
        out[idx] = True
    return out


def _clipped_rows(acc: np.ndarray, t: np.ndarray, ranges: np.ndarray, notes: list) -> np.ndarray:
    """Rows of the static poses in which an axis reads the log's extreme value of that axis in every sample: a
    sensor clipped at its range (noise always moves an unclipped axis), whatever the unit; a note per axis."""
    out = np.zeros(acc.shape[0], bool)
    lo, hi = np.nanmin(acc, axis=0), np.nanmax(acc, axis=0)
    for i0, i1 in ranges:
        seg = acc[i0:i1]
        if seg.shape[0] <= 10:
            continue
        for j in range(3):
            v = seg[:, j]
            if v[0] in (lo[j], hi[j]) and np.all(v == v[0]):
                out[i0:i1] = True
                notes.append(
                    f"the static pose at {t[i0]:.4g}–{t[i1 - 1]:.4g} s: the accelerometer's {'xyz'[j]} axis reads "
                    f"{v[0]:.6g} in every sample, the log's extreme (clipped at the sensor's range)"
                )
                break
    return out


#: a sample of a still pose this many robust σ from the pose's median on an axis is a tap or bump, not noise
#: (imucal's real poses: at most 4.5σ)
TAP_SIGMA = 8.0
#: the taps of a pose are refused when they move its mean by more than this many σ of the mean's white noise
TAP_MEAN_SIGMA = 3.0


def pose_taps(x: np.ndarray, ranges) -> list[tuple[int, int, int, float, float]]:
    """The still poses (``ranges`` (P, 2) sample ranges of ``x`` (N, 3), any unit) whose mean a few samples far
    from the rest move: samples beyond :data:`TAP_SIGMA` robust σ of the pose's median (σ by clipping at 5σ, so the
    spikes do not inflate it) that shift the mean by more than :data:`TAP_MEAN_SIGMA` σ/√n. Per such pose: (pose
    index, samples, first and last row, largest shift of the mean in σ/√n, largest deviation [unit of ``x``])."""
    out = []
    for k, (i0, i1) in enumerate(np.asarray(ranges, int)):
        seg = x[i0:i1]
        seg = seg[np.all(np.isfinite(seg), axis=1)]
        if seg.shape[0] < 10:
            continue
        dev = seg - np.median(seg, axis=0)
        sig = np.std(dev, axis=0)
        for _ in range(5):
            sig = np.array([np.std(dev[np.abs(dev[:, j]) <= 5.0 * sig[j], j]) for j in range(3)])
        # quantized counts may sit on one value: half the smallest step is the floor of σ
        steps = np.abs(dev[dev != 0])
        sig = np.maximum(sig, 0.5 * float(steps.min()) if steps.size else 0.0)
        if not np.all(sig > 0):
            continue
        spike = np.abs(dev) > TAP_SIGMA * sig
        if not spike.any():
            continue
        shift = np.abs(np.where(spike, dev, 0.0).sum(axis=0)) / seg.shape[0] / (sig / np.sqrt(seg.shape[0]))
        if shift.max() > TAP_MEAN_SIGMA:
            rows = np.flatnonzero(spike.any(axis=1))
            first, last = int(i0 + rows[0]), int(i0 + rows[-1])
            out.append((k, int(rows.size), first, last, float(shift.max()), float(np.abs(dev[spike]).max())))
    return out


#: a static pose whose gravity direction moves by more than this many σ of its noise (first third against last
#: third) and by more than MIN_CREEP_DEG is not static: it creeps or tilts slowly, below the variance detector
CREEP_SIGMA = 6.0
#: smallest pose creep (degrees) that counts: imucal's real poses settle by up to 0.05°, and its turns about the
#: vertical (static to an accelerometer alone) wobble by 0.1–0.2°; a uniform creep φ shortens the pose mean by
#: g·φ²/24, 3e-5 m/s² at 0.5° (below a pose mean's noise), 5e-4 m/s² at 2°
MIN_CREEP_DEG = 0.5


def pose_creep(acc: np.ndarray, ranges: np.ndarray, correct=None) -> tuple[np.ndarray, np.ndarray]:
    """Per static pose, the angle (rad) between the mean accelerometer direction of its first and last third,
    and that angle's 1σ noise (rad) from the detrended samples (lag-1 correlation taken into account).
    ``correct`` maps raw samples (n, 3) to offset-free ones (a first calibration): raw counts with an offset
    (an unsigned ADC at 32768) would shrink every angle."""
    ang, sig = np.zeros(len(ranges)), np.full(len(ranges), np.inf)
    for k, (i0, i1) in enumerate(ranges):
        seg = acc[i0:i1]
        seg = seg[np.all(np.isfinite(seg), axis=1)]
        if correct is not None and seg.shape[0]:
            seg = correct(seg)
        n = seg.shape[0] // 3
        if n < 5:
            continue
        a0, a1 = seg[:n].mean(axis=0), seg[-n:].mean(axis=0)
        ang[k] = np.arccos(np.clip(a0 @ a1 / (np.linalg.norm(a0) * np.linalg.norm(a1)), -1.0, 1.0))
        x = np.arange(seg.shape[0]) - 0.5 * (seg.shape[0] - 1)
        r = seg - seg.mean(axis=0) - np.outer(x, (x @ (seg - seg.mean(axis=0))) / (x @ x))
        rho = np.clip(np.sum(r[1:] * r[:-1]) / max(np.sum(r * r), 1e-300), 0.0, 0.95)
        # σ of one axis' third-mean difference across the pose direction, per unit of |a|
        sig[k] = np.sqrt(np.mean(r * r) * 2.0 / n * (1 + rho) / (1 - rho)) / np.linalg.norm(a0)
    return ang, sig


def creeping(ang: np.ndarray, sig: np.ndarray) -> np.ndarray:
    """The poses (bool) whose :func:`pose_creep` angle is beyond CREEP_SIGMA σ of its noise and MIN_CREEP_DEG."""
    return (ang > CREEP_SIGMA * sig) & (ang > np.radians(MIN_CREEP_DEG))


def _drop_creeping(acc, ranges, t_int, st: accel.PoseStatistics, notes: list, g: float, gyro=None) -> tuple:
    """The static poses that hold still (:func:`pose_creep`, offset-free by the closed-form ellipsoid fit of the
    pose means ``st``), their time intervals and statistics; a note per pose left out. More than a third left
    out, or fewer than 6 left: an error naming the first (or an accelerometer and a gyro column that look swapped,
    by the ``gyro``'s pose means: :func:`gates.swapped_axis`)."""
    theta0 = accel.initial_estimate(st.means, g)
    ang, sig = pose_creep(acc, ranges, (lambda x: model.corrected(theta0, x)) if np.all(np.isfinite(theta0)) else None)
    bad = creeping(ang, sig)
    for k in np.flatnonzero(bad):
        notes.append(
            f"static pose {k + 1} ({t_int[k][0]:.4g}–{t_int[k][1]:.4g} s) left out: gravity moves by "
            f"{np.degrees(ang[k]):.2g}° within it ({ang[k] / sig[k]:.0f}σ of its noise), a slow creep or tilt"
        )
    n_bad, n = int(np.count_nonzero(bad)), ranges.shape[0]
    if n_bad and (n - n_bad < 6 or n_bad > n / 3):
        k = int(np.flatnonzero(bad)[0])
        if swap := gates.swapped_axis(st.means, None if gyro is None else static.pose_means(gyro, ranges)):
            raise OptinavError(
                f"{n_bad} of {n} static poses are not still — {swap}", "name the columns in their order with --columns"
            )
        raise OptinavError(
            f"{n_bad} of {n} static poses are not still (pose {k + 1}, {t_int[k][0]:.4g}–{t_int[k][1]:.4g} s: "
            f"gravity moves by {np.degrees(ang[k]):.2g}° within it)"
            + (f"; {n - n_bad} remain, norm observation needs at least 6" if n - n_bad < 6 else ""),
            "hold each pose still (let it settle before the rest); else check the static intervals "
            "(--threshold, --sections)",
        )
    keep = ~bad
    return ranges[keep], t_int[keep], accel.PoseStatistics(st.means[keep], st.covariances[keep], st.counts[keep])


def _drop_saturated(ranges: np.ndarray, t_int: np.ndarray, valid: np.ndarray, notes: list) -> tuple:
    """The static poses with at least half their samples below the accelerometer's full scale; a note per pose
    left out. Fewer than 6 left: an error naming the range."""
    frac = np.array([np.mean(valid[i0:i1]) if i1 > i0 else 0.0 for i0, i1 in ranges])
    out = np.flatnonzero(frac < 0.5)
    for k in out:
        notes.append(
            f"static pose {k + 1} ({t_int[k][0]:.4g}–{t_int[k][1]:.4g} s) left out: {1 - frac[k]:.0%} of its samples "
            "at the accelerometer's full scale"
        )
    if out.size and ranges.shape[0] - out.size < 6:
        raise OptinavError(
            f"{out.size} of {ranges.shape[0]} static poses are at the accelerometer's full scale, "
            f"{ranges.shape[0] - out.size} remain: norm observation needs at least 6",
            "record with a larger accelerometer range (or check --acc-range)",
        )
    keep = frac >= 0.5
    return ranges[keep], t_int[keep]


#: relative std of standard gravity as the local g when neither g nor the latitude is given: normal gravity
#: spans 9.780 (equator) to 9.832 m/s² (poles), ±0.3 % of 9.80665, taken as uniform
G_UNKNOWN_REL_STD = 0.003 / np.sqrt(3.0)


def local_gravity(g=None, lat=None, height_m: float = 0.0) -> tuple[float, str]:
    """Gravity magnitude (m/s²) and how it was obtained: given ``g``, normal gravity at ``lat`` (rad) and
    ``height_m`` (m), or standard."""
    if g is not None:
        g = check_positive(g, "gravity")
        if not 9.7 < g < 9.9:
            raise OptinavError(
                f"gravity {g:g} m/s^2 is not above 9.7 and below 9.9 (Earth's surface: 9.76 on equatorial peaks to "
                "9.83 at the poles)",
                "give the local gravity in m/s^2, or --latitude and --height for normal gravity",
            )
        return g, "given"
    if lat is not None:
        lat = float(lat)
        if not -np.pi / 2 <= lat <= np.pi / 2:
            raise OptinavError(f"latitude {lat:g} rad is outside ±π/2", "give the latitude in rad (CLI: degrees)")
        deg = float(np.degrees(lat))
        # --latitude 0.86 (49.3° in radians) gave normal gravity 0.3 % low and every accelerometer scale with it,
        # 12-16 std off with exit 0: a latitude within ±π/2 degrees reads as radians too, and nothing in the data
        # tells the two apart
        rad = (
            f"; if {deg:g} is the latitude in radians, it is {np.degrees(deg):.4g}°: --latitude takes degrees"
            if 0.0 < abs(deg) <= np.pi / 2
            else ""
        )
        return float(normal_gravity(lat, float(height_m))), f"normal gravity at {deg:.10g}°, {height_m:g} m{rad}"
    return G_STANDARD, "standard gravity, by default"


def _select_threshold(t, acc, gyro, g, valid, *, window_s, min_duration_s, acc_unit, gyro_unit):
    cands = static.threshold_candidates(
        t,
        acc,
        gyr=gyro,
        window_s=window_s,
        min_duration_s=min_duration_s,
        acc_unit=acc_unit,
        gyro_unit=gyro_unit,
        keep_variance=False,
    )
    scores = []
    seen = {}
    for k, det in enumerate(cands.detections):
        key = tuple(np.asarray(det.index_ranges).ravel())
        if key in seen:
            scores.append(seen[key])
            continue
        red, dof = np.nan, 0
        if det.n_intervals >= 6:
            try:
                st = accel.pose_statistics(acc, det.index_ranges, valid=valid)
                fit = accel.fit_accel(st, g)
                red, dof = (fit.chi2 / fit.dof, fit.dof) if fit.dof > 0 else (np.nan, 0)
            except OptinavError:
                pass
        seen[key] = (red, dof)
        scores.append((red, dof))
    red = np.array([s[0] for s in scores])
    dof = np.array([s[1] for s in scores])
    ok = np.isfinite(red)
    if not np.any(ok):
        return cands.default, {
            "rule": "default (no candidate had >= 7 intervals to score)",
            "thresholds": cands.thresholds,
            "n_intervals": cands.n_intervals,
        }
    from optinav.core.distributions import chi2_ppf  # deferred: a bad input file is reported before scipy loads

    limit = np.where(dof > 0, chi2_ppf(0.99, np.maximum(dof, 1)) / np.maximum(dof, 1), np.inf)
    good = ok & ((red <= limit) | (red <= 1.5 * np.nanmin(red)))
    order = sorted(np.flatnonzero(good), key=lambda k: (cands.n_intervals[k], cands.static_time_s[k]))
    best = int(order[-1])
    return cands.detections[best], {
        "rule": "most intervals with an acceptable reduced chi-square",
        "thresholds": cands.thresholds,
        "n_intervals": cands.n_intervals,
        "reduced_chi2": red,
        "chosen": best,
    }


def _sections_on_kept_rows(sections, keep: np.ndarray, method: str, lost: tuple | None = None):
    """Sections given by sample index (imucal's section list, a label column's ranges) moved onto the rows left
    once the non-finite ones are dropped: the indices count the rows as written, so every section after an empty
    row pointed one row later (10 empty cells in a pose: gyro K_zz 1.1 % off, exit 0). Sections in seconds are
    returned as given (they select by time). ``lost``: (why, remedy) of a section left without rows, when they
    were left out for another reason than non-finite values."""
    pos = np.concatenate([[0], np.cumsum(keep)])  # kept rows before each row as written
    if (
        isinstance(sections, dict)
        and method == "ferraris"
        and all(isinstance(v, (tuple, list)) and len(v) == 2 for v in sections.values())
    ):
        rows = [(str(n), int(a), int(b)) for n, (a, b) in sections.items()]  # a label column's ranges
    else:
        rows, kind, _ = static._load_sections(sections)
        if kind != "index":
            return sections
    moved = {}
    for name, a, b in rows:
        if not (0 <= a < b <= keep.size):
            return sections  # out of the log: the section check names it
        if pos[b] == pos[a]:
            why, remedy = lost or (
                "holds no sample with finite values",
                "fill or cut the empty rows, or give the sections in seconds (--sections FILE)",
            )
            raise OptinavError(f"section {name!r} (rows {a}-{b - 1}) {why}", remedy)
        i0, i1 = int(pos[a]), int(pos[b])
        # the Ferraris route takes {name: (i0, i1)}; the section list reads a pair as seconds, so imucal's layout
        moved[name] = (i0, i1) if method == "ferraris" else {"start": i0, "end": i1}
    return moved


def _sections_on_file_rows(sections, rows: np.ndarray, method: str):
    """Sections by sample index, which count the data file's rows, moved onto the samples read where the reader
    left rows out (``rows``: each sample's row in the file, :attr:`SessionData.rows`): an accelerometer file whose
    first rows lie before the gyroscope file's first sample (:func:`_sections_on_kept_rows`). Sections in seconds
    are returned as given."""
    given, kind, _ = static._load_sections(sections)
    if kind != "index":
        return sections
    keep = np.zeros(max([int(rows[-1]) + 1] + [int(b) for _, _, b in given]), bool)
    keep[rows] = True
    lost = (
        "lies where the log has no sample: those rows were left out (outside the gyroscope file's span)",
        "give the gyroscope file of the whole recording, or the sections in seconds (--sections FILE)",
    )
    return _sections_on_kept_rows(sections, keep, method, lost)


def calibrate(
    t,
    acc,
    gyr=None,
    *,
    acc_unit: str = "m/s^2",
    gyro_unit: str = "rad/s",
    g=None,
    lat=None,
    height_m: float = 0.0,
    method: str = "lm",
    model_form: str = "auto",
    data: str = "means",
    sections=None,
    window_s: float = 1.0,
    min_duration_s: float = static.MIN_STATIC_S,
    threshold=None,
    acc_range=None,
    gyro_range=None,
    gyro_bias="local",
    rng=None,
    source: str = "",
    method_options: dict | None = None,
    acc_bias_instability=None,
    rest=None,
    allow_unobservable: bool = False,
    rotation_angle: float = -2 * np.pi,
    pose_alignment: float = np.radians(1.0),
    held_misalignment: float = accel.HELD_MISALIGNMENT,
    gyro_g_sensitivity=None,
    gyro_bias_instability=None,
    gyro_bias_corr_time: float = float("inf"),
    gyr_clock=None,
) -> CalibrationResult:
    """Calibrate the accelerometer (and gyroscope) of a multi-position log; see the module docstring.

    K and b come out in raw units per SI unit. Every fit passes the gates of :mod:`optinav.multipos.gates` or
    raises; notes (gravity source, held parameters, dropped turns) are in ``quality["notes"]``.

    Parameters
    ----------
    t : (N,) array
        Sample times [s].
    acc : (N, 3) array
        Accelerometer output [acc_unit].
    gyr : (N, 3) array or None
        Gyroscope output [gyro_unit].
    acc_unit, gyro_unit : str
        Names of the raw units ("counts" or any unit).
    g : float or None
        Local gravity [m/s^2]; None: from ``lat``/``height_m`` (or standard gravity, noted).
    lat : float or None
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    method : str
        Accelerometer optimizer (:func:`optinav.multipos.accel.fit_accel`).
    model_form : str
        ``"auto"``, ``"full"`` or ``"diagonal"`` (:func:`optinav.multipos.accel.fit_accel`).
    data : str
        ``"means"`` or ``"samples"``.
    sections : list, dict, str or None
        Manual static sections: (t0, t1) pairs [s] or a file (:func:`optinav.multipos.static.sections_from_list`),
        or the {name: (i0, i1)} dict of :func:`optinav.multipos.ferraris.sections_from_labels`; None: detected.
    window_s : float
        Moving-variance window of the static detection [s].
    min_duration_s : float
        Shortest static interval kept [s].
    threshold : float or None
        Static-detection variance threshold [acc_unit²]; None: automatic.
    acc_range, gyro_range : float, (2,) array or None
        Saturation limits ±R or (lo, hi) [raw units] (:func:`saturated_mask`).
    gyro_bias : str or (3,) array
        "local" (default: during each turn the bias interpolated between the two rests it joins, the session
        mean reported, its std that of the session's bias), "static" (mean over the static poses), "rest"
        (mean over ``rest``), "estimate" (jointly with K_g) or a 3-vector [gyro_unit].
    rng : int, Generator or None
        Seed or generator of a stochastic optimizer, and of the Ferraris method's Monte Carlo std (None: 0).
    source : str
        Recorded in the result.
    method_options : dict or None
        Options of the accelerometer optimizer (e.g. ``generations``).
    acc_bias_instability : float, (3,) array or None
        1σ accelerometer bias drift over the session [acc_unit], added to the bias std.
    rest : (2,) tuple or None
        Initial rest window (t0, t1) [s] of ``gyro_bias="rest"``; None: the first static interval.
    allow_unobservable : bool
        Hold gyro directions the turns do not determine instead of failing.
    rotation_angle : float
        The Ferraris turn [rad] (imucal's −2π).
    pose_alignment : float
        Ferraris: 1σ of the alignment of each pose and turn axis with the sensor axes [rad]; a pose tilted by δ
        moves the misalignments of its column by δ·K_ii/√2 (turns: δ·K_ii), which the std then includes.
    held_misalignment : float
        1σ of misalignments a reduced model holds at 0 [rad] (their model error enters the stds of the scales
        and biases).
    gyro_g_sensitivity : float or None
        1σ of the unmodelled gyro g-sensitivity [gyro_unit per m/s^2], added to the gyro bias and K std. With the
        default "local" bias and none given, a g-sensitivity the rest biases reveal (they follow the specific
        force) enters instead, with a note.
    gyro_bias_instability : float, (3,) array or None
        1σ gyro bias drift over the session [gyro_unit], added to the bias std; with "local" the stationary σ of
        a Gauss–Markov bias of correlation time ``gyro_bias_corr_time``, and the bias std is then against the
        long-term bias instead of this session's. The gyro bias std also holds the neglected Earth rate.
    gyro_bias_corr_time : float
        Correlation time of that Gauss–Markov bias [s] (default ∞: a constant offset per run).
    gyr_clock : (t_g (M,) array, gyr_g (M, 3) array) or None
        The gyroscope's own sample times [s] and samples [gyro_unit] where ``gyr`` holds them interpolated onto
        ``t`` (a second file on its own clock, :attr:`optinav.io.ImuLog.gyr_clock`): Ferraris judges each turn's
        glitches and takes its integral on them (interpolation smooths samples by a share that follows the two
        clocks' phase). None: ``gyr`` are the gyroscope's samples.

    Returns
    -------
    CalibrationResult
        K [raw/SI] and b [raw] of each triad with std, CRLB std and observability, gates and notes.
    """
    gyro = gyr
    t_start = time.perf_counter()
    t = as_float_array(t, "time", finite=False)
    acc = as_float_array(acc, "accelerometer data", last_dims=(3,), finite=False)
    if acc.ndim != 2 or t.ndim != 1 or acc.shape[0] != t.shape[0]:
        raise OptinavError(
            f"time ({t.shape}) and accelerometer ({acc.shape}) data do not match",
            "give one time stamp per accelerometer sample",
        )
    if gyro is not None:
        gyro = as_float_array(gyro, "gyroscope data", last_dims=(3,), finite=False)
        if gyro.shape != acc.shape:
            raise OptinavError(
                f"gyroscope data {gyro.shape} and accelerometer data {acc.shape} differ in length",
                "give both sensors on the same time column",
            )
    finite = np.isfinite(t) & np.all(np.isfinite(acc), axis=1)
    if gyro is not None:
        finite &= np.all(np.isfinite(gyro), axis=1)
    n_nan = int(np.count_nonzero(~finite))
    if n_nan:
        if sections is not None:
            sections = _sections_on_kept_rows(sections, finite, method)
        t, acc = t[finite], acc[finite]
        gyro = gyro[finite] if gyro is not None else None
    t = check_timestamps(t, "time", min_count=10)
    g, g_source = local_gravity(g, lat, height_m)
    notes = [
        f"g = {g:.6g} m/s^2 ({g_source})"
        + (
            ": give --gravity or --latitude for the local value (it differs from standard gravity by up to 0.3 %; "
            "the accelerometer scales' std includes that, 0.17 %)"
            if g_source.startswith("standard")
            else ""
        )
    ]
    sat_a = saturated_mask(acc, acc_range, counts=acc_unit == "counts")
    sat_g = saturated_mask(gyro, gyro_range, counts=gyro_unit == "counts") if gyro is not None else None
    if gyro is not None and gyro_range is None and method != "ferraris":  # Ferraris checks its turns itself
        sat_g |= clipped_gyro_rows(gyro, float(np.median(np.diff(t[: min(t.size, 65537)]))))
    valid = ~sat_a
    if not np.any(valid):
        # which axes: one stuck at the rail (a dead or unplugged axis) was reported as the whole sensor
        full = saturated_mask(acc, acc_range, counts=acc_unit == "counts", per_axis=True).all(axis=0)
        at = [ax for ax, f in zip("xyz", full) if f]
        where = f" (axis {', '.join(at)} in all of them: a dead or disconnected axis?)" if 0 < len(at) < 3 else ""
        raise OptinavError(
            f"every accelerometer sample is at the full scale{where}", "check --acc-range or --acc-unit, and the sensor"
        )
    rest_norm = float(np.median(_row_norms(acc, valid), overwrite_input=True))
    if gyro is not None and "counts" not in (acc_unit, gyro_unit):
        gn = _row_norms(gyro, valid)
        gyro_cv = float(np.std(gn) / np.mean(gn)) if gn.size and np.mean(gn) > 0 else float("nan")
        gates.check_swapped_triads(rest_norm, acc_unit, float(np.median(gn)), g, gyro_cv)
    gates.check_acc_unit(rest_norm, acc_unit, g, gyr=None if gyro_unit == "counts" else gyro)

    if method == "ferraris":
        return _ferraris(
            t,
            acc,
            gyro,
            sections,
            g,
            g_source,
            acc_unit,
            gyro_unit,
            n_nan,
            sat_a,
            t_start,
            source,
            notes,
            float(rotation_angle),
            float(pose_alignment),
            sat_g,
            rng=rng,
            gyr_clock=gyr_clock,
            range_stated=gyro_range is not None,
        )
    selection = {}
    step("detect static intervals")
    rot_names: list[str] = []  # imucal's rotation sections, which only the Ferraris method uses
    if sections is not None:
        sl = static.sections_from_list(sections, t)
        keep = [k for k, name in enumerate(sl.names) if not str(name).endswith("_rot")]  # imucal's rotations
        rot_names = [str(name) for name in sl.names if str(name).endswith("_rot")]
        ranges = np.asarray(sl.index_ranges, int)[keep]
        t_int, how = np.asarray(sl.t_intervals, float)[keep], "manual sections"
    elif threshold is not None:
        det = static.detect_static(
            t,
            acc,
            gyr=gyro,
            window_s=window_s,
            threshold=threshold,
            min_duration_s=min_duration_s,
            acc_unit=acc_unit,
            gyro_unit=gyro_unit,
        )
        ranges, t_int, how = np.asarray(det.index_ranges, int), np.asarray(det.t_intervals, float), "threshold"
    else:
        det, selection = _select_threshold(
            t,
            acc,
            gyro,
            g,
            valid,
            window_s=window_s,
            min_duration_s=min_duration_s,
            acc_unit=acc_unit,
            gyro_unit=gyro_unit,
        )
        ranges, t_int, how = np.asarray(det.index_ranges, int), np.asarray(det.t_intervals, float), "automatic"
        selection["threshold"] = det.threshold
    # what finds the still stretches, to name those shorter than --min-duration if a pose direction is missing
    still = None if sections is not None else (det.threshold, det.gyro_threshold, det.window_s, det.trim_s)
    det = None  # its moving variances (16 B per row) are not needed further
    if len(ranges) < 6 and sections is None:
        levels = static._levels(static.moving_variance(t, acc, window_s), f"({acc_unit})^2")
        raise OptinavError(
            f"only {len(ranges)} static interval(s) of at least {min_duration_s:g} s found (acc {levels}; threshold "
            f"{float(selection.get('threshold') or threshold or np.nan):.3g}); norm observation needs at least 6 poses",
            "check that the log holds >= 6 still poses and that --rate (or the time column) is right (the "
            "intervals' lengths come from it), or try a longer --window, a --threshold, a shorter --min-duration, or "
            "give the poses by hand with --sections",
        )
    clipped: list[str] = []
    n_detected = len(ranges)
    ranges, t_int = _drop_saturated(ranges, t_int, valid & ~_clipped_rows(acc, t, ranges, clipped), notes)
    n_clipped = n_detected - len(ranges)
    notes.extend(clipped)
    ranges, t_int, st = _drop_creeping(
        acc, ranges, t_int, accel.pose_statistics(acc, ranges, valid=valid), notes, g, gyro
    )
    samples = [acc[i0:i1][valid[i0:i1]] for i0, i1 in ranges] if data == "samples" else None
    step(f"fit accelerometer ({method}) and gates")
    gate_log: list[dict] = []
    try:
        fit = _fit_accel_gated(
            st,
            g,
            notes,
            acc_unit=acc_unit,
            method=method,
            model_form=model_form,
            data=data,
            gate_log=gate_log,
            samples=samples,
            rng=rng,
            bias_instability=acc_bias_instability,
            held_misalignment=held_misalignment,
            **(method_options or {}),
        )
    except OptinavError as exc:
        if clipped and "distinct pose directions" in exc.cause:
            # the pose missing was left out as clipped: --min-duration cannot bring it back
            raise type(exc)(
                f"{exc.cause} — {len(clipped)} pose(s) left out as clipped: {clipped[0]}",
                "record with a larger accelerometer range (--acc-range states it)",
            ) from None
        short = _short_still(still, t, acc, gyro, min_duration_s) if "distinct pose directions" in exc.cause else []
        if swap := gates.swapped_axis(st.means, None if gyro is None else static.pose_means(gyro, ranges)):
            raise type(exc)(f"{exc.cause} — {swap}", "name the columns in their order with --columns") from None
        if not short and (narrow := gates.narrow_axes(st.means)):
            # poses that all lie near one direction: a fit that fails then fails for that (a 25° cone around
            # z up was told 'did not converge, pass --model diagonal', which failed alike)
            raise type(exc)(
                f"{exc.cause} — {narrow}",
                "record poses with each axis both up and down (e.g. ±x, ±y, ±z up; optinav design plans them)",
            ) from None
        # samples lost in a move join the poses on either side into one interval: a direction goes missing
        gaps = _time_gap_words(t) if "distinct pose directions" in exc.cause else ""
        if not short and gaps:
            raise type(exc)(f"{exc.cause} — {gaps}", "log without losing samples, or record the poses again") from None
        if not short:
            raise
        # a pose held shorter than --min-duration was left out, and may be the direction missing: name it
        when = "; ".join(f"{a:.4g}–{b:.4g} s" for a, b in short[:5]) + (", …" if len(short) > 5 else "")
        longest = max(b - a for a, b in short)
        raise type(exc)(
            f"{exc.cause} — {len(short)} still stretch(es) shorter than --min-duration {min_duration_s:g} s were "
            f"left out ({when})" + (f"; {gaps}" if gaps else ""),
            f"pass --min-duration {max(0.5, np.floor(longest * 2) / 2):g} to take them"
            + (f"; or {exc.remedy}" if exc.remedy else ""),
        ) from None
    if how == "automatic":
        _check_left_out_rests(t, acc, gyro, ranges, valid, fit, g, window_s, min_duration_s, acc_unit, gyro_unit)
    if acc_bias_instability is None and (dn := _acc_drift_note(t, ranges, st, fit, g, acc_unit)):
        notes.append(dn)
    used = np.zeros(len(t), bool)
    for i0, i1 in ranges:
        used[i0:i1] = True
    used &= valid
    resid = _row_norms(acc, used, fit.theta)
    used = None
    resid -= g  # in place: (‖·‖ − g)² as one array, not three of 8 B per static row
    residual_rms = float(np.sqrt(np.mean(np.square(resid, out=resid))))
    resid = None

    K_std = np.zeros((3, 3))
    for j, (r, c) in enumerate(model.K_INDEX):
        K_std[r, c] = fit.std[j]
    if g_source.startswith("standard"):
        # the scales are relative to the g assumed: an unknown local g (normal gravity spans ±0.3 % of standard
        # gravity) scales K by as much, far beyond the fit's own std on a good session
        K_std = np.hypot(K_std, np.abs(fit.K) * G_UNKNOWN_REL_STD)
    acc_entry = {
        "K": fit.K,
        "b": fit.b,
        "K_std": K_std,
        "b_std": fit.std[6:9],
        "form": "upper-triangular",
        "estimated": fit.estimated,
        "held": fit.held,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "crlb_std": fit.crlb_std,
        "paper": model.to_paper(fit.K, fit.b, g),
        "held_std_rad": held_misalignment if fit.held else None,
    }
    obs = fit.observability
    observability = {
        "accelerometer": {
            "rank": obs.rank,
            "n_params": obs.n_params,
            "singular_values": obs.singular_values,
            "unobservable": list(obs.unobservable_directions),
            "statements": list(obs.statements),
            "distinct_poses": fit.n_distinct,
        }
    }
    observability.update(
        {k: observability["accelerometer"][k] for k in ("rank", "n_params", "singular_values", "unobservable")}
    )
    gyro_entry = None
    excluded = {"nan_rows": n_nan, "saturated_acc": int(np.count_nonzero(sat_a))}
    if gyro is not None:
        from . import gyro as gyro_cal

        excluded["saturated_gyro"] = int(np.count_nonzero(sat_g))
        drop = _saturated_turns(t, sat_g, ranges, notes)
        excluded["saturated_turns"] = len(drop)
        saturated = list(drop)
        gapped = [k for k in _turns_that_lost_samples(t, ranges) if k not in drop]
        excluded["gap_turns"] = len(gapped)
        if gapped:
            notes.append(f"{_gap_words(t, ranges, gapped)}: those turns are left out of the gyro calibration")
        drop = drop + gapped
        # a gyro glitch inside a turn (a sample 300 deg/s off in a move of imucal's session: K 4.4 std off, exit 0)
        # turns gravity by its share: the turn is left out (the others observe K), as the Ferraris rotations repair it
        glitched = _glitched_turns(t, gyro, ranges, drop, gyro_unit, notes, gyr_clock)
        excluded["glitch_turns"] = len(glitched)
        drop = drop + glitched
        up = model.corrected(fit.theta, st.means)
        up /= np.linalg.norm(up, axis=1, keepdims=True)
        step("fit gyroscope and gates")
        # a pose the unit turned in is no rest for the gyro: left out, the turns on either side joined
        rests, drop = _turning_rests(t, gyro, ranges, up, drop, g, gyro_unit, notes, gyr_clock)
        g_ranges, up = ranges[rests], up[rests]
        rows3 = (3 * rests[:, None] + np.arange(3)).ravel()  # their rows in the up directions' covariance
        excluded["turning_rests"] = int(len(ranges) - rests.size)
        if isinstance(gyro_bias, str) and gyro_bias == "rest" and rest is None:
            # the initial rest: the first static interval, before any turn
            rest = (float(t[ranges[0, 0]]), float(t[ranges[0, 1] - 1]))
            notes.append(
                f"gyro bias from the initial rest, the first static interval {rest[0]:.6g}-{rest[1]:.6g} s "
                "(--rest T0 T1 to choose another window)"
            )
        tg, wg, rg = _on_own_clock(t, gyro, g_ranges, gyr_clock)
        ucov = _up_cov(fit, st, held_misalignment)[np.ix_(rows3, rows3)]
        unoise = _up_noise(fit, st)[rests]

        def fit_gyro(drop):
            return gyro_cal.calibrate_gyro(
                tg,
                wg,
                rg,
                up,
                bias=gyro_bias,
                rest=rest,
                rng=rng,
                allow_unobservable=allow_unobservable,
                drop_transitions=drop,
                g_sensitivity_std=gyro_g_sensitivity,
                gravity=g,
                unit=gyro_unit,
                bias_instability=gyro_bias_instability,
                bias_corr_time=gyro_bias_corr_time,
                up_cov=ucov,
                up_noise=unoise,
            )

        try:
            gc = fit_gyro(drop)
            n_drop = len(drop)
            gc, drop = _without_flat_topped_turns(fit_gyro, gc, tg, wg, rg, drop, gyro_unit, notes)
            excluded["flat_topped_turns"] = len(drop) - n_drop
        except OptinavError as exc:
            if rot_names and not (gapped or saturated or n_clipped):
                # imucal's section list: its six poses alone, with the rotations left out, cannot calibrate the
                # gyro ('add poses' was all the error said, and the log holds the turns)
                raise type(exc)(
                    f"{exc.cause} — the sections' rotations {', '.join(rot_names)} are not used by --method "
                    f"{method}, only their {len(ranges)} poses",
                    "pass --method ferraris for imucal's sections, or drop --sections to find the rests between "
                    "the rotations",
                ) from None
            if not (gapped or saturated or n_clipped):
                raise
            # the turns left out for their time gaps or a saturated gyro are why the gyro cannot be calibrated:
            # say so (a swap named stays named: no second hint is added)
            why, fix = [], []
            if saturated:
                why.append(f"the gyroscope saturates in {len(saturated)} turn(s)")
                fix.append("turn more slowly (or check --gyro-range and --gyro-unit)")
            if gapped:
                why.append(_gap_words(t, ranges, gapped))
                fix.append("log without dropping samples during the turns")
            if n_clipped:
                # poses at the accelerometer's full scale are left out, and the turns into them with them
                why.append(f"{n_clipped} static pose(s) at the accelerometer's full scale")
                fix.append("record with a larger accelerometer range (--acc-range states it)")
            raise type(exc)(
                f"{exc.cause} — {'; '.join(why)}, left out of the gyro calibration",
                f"{', '.join(fix)}, or record the turns again; --no-gyro calibrates the accelerometer alone",
            ) from None
        gate_log += _gyro_gates(gc, gyro_unit)
        gate_log += _gyro_frame_gate(gc, held_misalignment if fit.held else None, notes)
        if fit.held:
            gate_log.append(_held_frame_gate(gc, held_misalignment))
        _note_turn_sampling(gc.turn_sampling, 1.0 / float(np.median(np.diff(tg))), notes)
        if gyro_unit == "counts" and (fs := gyro_full_scale_note(gyro, gc.K)):
            notes.append(fs)
        if gc.unobservable:
            notes.append(
                "gyroscope directions the turns do not determine are held at the initial guess: "
                + "; ".join(gc.unobservable)
            )
        if gc.g_sensitivity_source == "rests":
            notes.append(
                f"the gyro rest biases follow the specific force (g-sensitivity ≈ {gc.g_sensitivity:.3g} raw "
                "per m/s^2 per element, 1-sigma): its effect is in the gyro K and b std; pass "
                "--gyro-g-sensitivity to state the datasheet value"
            )
        if (
            gc.bias_mode == "local"
            and gyro_bias_instability is None
            and (dn := _gyro_drift_note(t, gyro, g_ranges, up, g, gc, gyro_unit))
        ):
            notes.append(dn)
        # Earth rate is neglected (module docs): "local" and "static" include what the rests hold of it, "estimate"
        # has it in the scatter of the rest means it fits; one rest window holds the projection of Ω_E in one
        # pose, of unknown heading: Ω_E·K_ii/√3 per axis (a random direction)
        b_std = (
            gc.b_std
            if gc.bias_mode in ("local", "static", "estimate")
            else np.hypot(gc.b_std, OMEGA_E * np.abs(np.diag(gc.K)) / np.sqrt(3.0))
        )
        gyro_entry = {
            "K": gc.K,
            "b": gc.b,
            "K_std": gc.K_std,
            "b_std": b_std,
            "form": "full",
            "residual_rms_rad": gc.residual_rms,
            "residual_noise_ratio": gc.noise_ratio,
            "std_widening": gc.std_widening,
            "n_transitions": gc.n_transitions,
            "bias_mode": gc.bias_mode,
            "unobservable": list(gc.unobservable),
        }
        gobs = gc.observability
        observability["gyroscope"] = {
            "rank": gobs.rank,
            "n_params": gobs.n_params,
            "singular_values": gobs.singular_values,
            "unobservable": list(gobs.unobservable_directions),
        }
    quality = {
        "n_poses": int(len(ranges)),
        "pose_residual_rms": float(np.sqrt(np.mean(fit.residuals**2))),
        "chi2": fit.chi2,
        "dof": fit.dof,
        "interval_selection": how,
        "gravity_source": g_source,
        "optimizer_success": fit.success,
        "optimizer_message": fit.message,
        "nfev": fit.nfev,
        "data": data,
        "notes": notes,
    }
    if selection:
        quality["threshold_selection"] = selection
    units = {
        "accelerometer_raw": acc_unit,
        "accelerometer": "m/s^2",
        "time": "s",
        "residual_rms": "m/s^2",
        "gravity": "m/s^2",
        "K": "raw per SI unit",
        "b": "raw",
    }
    if gyro is not None:
        units.update({"gyroscope_raw": gyro_unit, "gyroscope": "rad/s"})
    return CalibrationResult(
        accelerometer=acc_entry,
        gyroscope=gyro_entry,
        units=units,
        gravity=g,
        residual_rms=residual_rms,
        static_intervals=t_int,
        observability=observability,
        method=method,
        elapsed_s=time.perf_counter() - t_start,
        excluded=excluded,
        quality=quality,
        source=source,
        gates=gate_log,
        convergence=convergence(
            fit.success, evaluations=fit.nfev, message="; ".join(filter(None, (fit.message, fit.search_note)))
        ),
    )


def _up_cov(fit: accel.AccelFit, st: accel.PoseStatistics, held_misalignment: float) -> np.ndarray:
    """Covariance (3P × 3P) of the pose up directions u_k = K⁻¹(m_k − b)/‖·‖ from the accelerometer fit's own
    uncertainty (:func:`accel.parameter_covariance`: its std with the Gauss–Newton correlations, and misalignments
    held at 0 at their prior ``held_misalignment`` [rad]), to first order: common to all poses, so the gyro's turn
    residuals cannot show it (a design whose poses span little — a cone — turns it into the gyro scales; a held
    misalignment shears the six axis poses' directions, and the turns between them, against each other)."""
    cov = accel.parameter_covariance(fit, st, held_misalignment)
    used = np.flatnonzero(np.diag(cov) > 0)

    def up(theta):
        a = model.corrected(theta, st.means)
        return (a / np.linalg.norm(a, axis=1, keepdims=True)).reshape(-1)

    u0 = up(fit.theta)
    D = np.empty((u0.size, used.size))
    for c, i in enumerate(used):
        h = 1e-6 * max(abs(float(fit.theta[i])), float(np.mean(np.abs(fit.theta[:3]))) * 1e-3)
        th = fit.theta.copy()
        th[i] += h
        D[:, c] = (up(th) - u0) / h
    return D @ cov[np.ix_(used, used)] @ D.T


def _up_noise(fit: accel.AccelFit, st: accel.PoseStatistics) -> np.ndarray:
    """Covariance (P, 3, 3) of each pose's up direction u_k = a_k/‖a_k‖, a_k = K⁻¹(m_k − b), from the noise of its
    mean (sample covariance / count, raw), independent from pose to pose: (I − u uᵀ)K⁻¹(Σ_k/n_k)K⁻ᵀ(I − u uᵀ)/‖a_k‖²."""
    Ki = np.linalg.inv(np.asarray(fit.K, float))
    a = model.corrected(fit.theta, st.means)
    nrm = np.linalg.norm(a, axis=1)
    u = a / nrm[:, None]
    P = np.eye(3)[None] - u[:, :, None] * u[:, None, :]
    ca = Ki[None] @ (st.covariances / np.maximum(st.counts, 1)[:, None, None]) @ Ki.T[None]
    return P @ ca @ P / (nrm**2)[:, None, None]


def _row_norms(raw, rows, theta=None) -> np.ndarray:
    """‖x‖ of the selected ``rows`` (N,) bool of ``raw`` (N, 3), x = raw or, with ``theta``, the corrected
    K⁻¹(raw − b); computed in blocks (each row on its own: the same numbers as on the whole array), so the
    memory is the result (8 B per selected row), not copies of the log."""
    out = np.empty(int(np.count_nonzero(rows)))
    k = 0
    for a in range(0, raw.shape[0], static._BLOCK):
        x = raw[a : a + static._BLOCK][rows[a : a + static._BLOCK]]
        if theta is not None:
            x = model.corrected(theta, x)
        out[k : k + x.shape[0]] = np.linalg.norm(x, axis=1)
        k += x.shape[0]
    return out


class SearchStoppedShort(OptinavError):
    """A GA/PSO fit whose residual fails the gate where the minimum its search was heading for passes it: the
    optimizer's, not the data's (no fallback to a smaller model)."""


def _fit_accel_gated(
    st, g, notes: list, *, acc_unit: str, model_form: str, gate_log: list | None = None, **kw
) -> accel.AccelFit:
    """:func:`accel.fit_accel` that passes the gates; with ``model_form="auto"`` a full model that fails one
    falls back to the diagonal model with a note naming the cause. The passed gates are appended to
    ``gate_log``."""
    gate_log = [] if gate_log is None else gate_log
    fit = accel.fit_accel(st, g, model_form=model_form, **kw)
    try:
        gate_log += _accel_gates(fit, st, acc_unit)
    except OptinavError as exc:
        if model_form != "auto" or fit.held or isinstance(exc, SearchStoppedShort):
            raise
        fit = accel.fit_accel(st, g, model_form="diagonal", **kw)
        gate_log += _accel_gates(fit, st, acc_unit)
        notes.append(
            f"the full accelerometer model failed ({exc.cause}); the misalignments K_xy, K_xz, K_yz are "
            "held at 0 (scales and biases fitted; --model full insists on the full model)"
        )
    else:
        if fit.note:
            notes.append(fit.note)
    if fit.search_note:
        notes.append(f"the {fit.method.upper()} search {fit.search_note}; more --generations or --method lm go further")
    return fit


def _accel_gates(fit: accel.AccelFit, st: accel.PoseStatistics, acc_unit: str) -> list[dict]:
    """Convergence, residual and plausibility gates of an accelerometer fit (:mod:`optinav.multipos.gates`);
    raises on the first that fails, else returns their outcomes (:func:`optinav.core.results.gate`)."""
    if not fit.success or not np.all(np.isfinite(fit.theta)) or not np.all(np.isfinite(fit.residuals)):
        raise OptinavError(
            f"the {fit.method} fit of the accelerometer did not converge ({fit.message}; {fit.nfev} evaluations)",
            ("pass --model diagonal" + (" or --method lm" if fit.method != "lm" else ""))
            + ", or check the static intervals (--threshold, --sections) and the units (--acc-unit)",
        )
    rms = float(np.sqrt(np.mean(fit.residuals**2)))
    if rms > gates.MAX_RESIDUAL_G * fit.g and fit.shortfall is not None:
        near = float(np.sqrt(np.mean(model.norm_residuals(fit.theta + fit.shortfall, st.means, fit.g) ** 2)))
        if near <= gates.MAX_RESIDUAL_G * fit.g:
            # the poses fit one model: the search ended before it (GA/PSO with few generations)
            raise SearchStoppedShort(
                f"the {fit.method.upper()} search stopped short of the minimum of its objective: residual RMS of "
                f"|a| - g {rms:.3g} m/s^2 where the minimum it was heading for has {near:.3g} "
                f"({fit.message})",
                "pass more --generations, or --method lm",
            )
    if rms > gates.MAX_RESIDUAL_G * fit.g:
        k = int(np.argmax(np.abs(fit.residuals)))
        # an axis without any noise in a pose sits at a limit: a sensor clipped at its range reads the same
        # value in every sample
        var = np.diagonal(st.covariances, axis1=1, axis2=2)
        # at the poses' extreme of that axis: a quiet axis reading one count mid-range is quantization, not clipping
        extreme = (st.means == st.means.max(axis=0)) | (st.means == st.means.min(axis=0))
        flat = np.argwhere((var == 0) & (st.counts[:, None] > 10) & extreme)
        if flat.size:
            p, j = (int(x) for x in flat[0])
            raise OptinavError(
                f"the poses do not fit one accelerometer model (residual RMS of |a| - g {rms:.3g} m/s^2): in pose "
                f"{p + 1} axis {'xyz'[j]} reads {st.means[p, j]:.6g} in every sample ({len(flat)} pose-axes so): "
                "clipped at the sensor's range",
                "record with a larger accelerometer range, or mark it with --acc-range so that those poses are "
                "left out",
            )
        raise OptinavError(
            f"the poses do not fit one accelerometer model: residual RMS of |a| - g is {rms:.3g} "
            f"m/s^2 (pose {k + 1}: {fit.residuals[k]:+.3g} m/s^2; noise of a pose mean "
            f"{float(np.median(fit.residual_sigma)):.2g} m/s^2)",
            "check for motion inside the static intervals (a lower --threshold, a longer "
            "--min-duration, or --sections)",
        )
    # counts have no nominal scale: the axes are judged against each other
    nominal = float(np.median(np.abs(np.diag(fit.K)))) if acc_unit == "counts" else 1.0 / factor(acc_unit)
    gates.check_matrix(fit.K, nominal, "accelerometer", acc_unit, option="--acc-unit", columns_flag="--columns")
    u = model.corrected(fit.theta, st.means)
    v = (st.means - fit.b) / np.diag(fit.K)
    cosang = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    ang = np.degrees(np.arccos(np.clip(cosang, -1, 1)))
    if np.max(ang) > gates.MAX_TURN_DEG:
        k = int(np.argmax(ang))
        raise OptinavError(
            f"the calibration turns pose {k + 1} by {ang[k]:.3g}° away from its raw direction "
            f"(> {gates.MAX_TURN_DEG:g}°): an implausible misalignment",
            "pass --model diagonal",
        )
    return [
        gate("acc optimizer converged", fit.success, None, kind="true"),
        gate("acc residual rms of |a| - g", rms, gates.MAX_RESIDUAL_G * fit.g, unit="m/s^2"),
        gate("acc largest turn of a pose", float(np.max(ang)), gates.MAX_TURN_DEG, unit="deg"),
    ]


def _short_still(still, t, acc, gyro, min_duration_s: float) -> list[tuple[float, float]]:
    """The still stretches (s) at the detection's ``still`` = (threshold, gyro threshold, window s, trim s) that
    are at least 0.5 s long but shorter than ``min_duration_s``, which the detection left out (a pose held 1.9 s
    under the default 2 s: its direction went missing and the error asked for poses that were recorded)."""
    if still is None or still[0] is None or min_duration_s <= 0.5:
        return []
    thr, gthr, window_s, trim_s = still
    mask = static.moving_variance(t, acc, window_s) <= thr
    if gyro is not None and gthr is not None:
        mask &= static.moving_variance(t, gyro, window_s) <= gthr
    r = static.intervals_from_mask(t, mask, min_duration_s=0.5, trim_s=float(trim_s or 0.0))
    return [(float(t[a]), float(t[b - 1])) for a, b in r if t[b - 1] - t[a] < min_duration_s]


#: samples missing from a turn (its duration over the sample step, less the samples it holds) from which the
#: turn is left out; stamping jitter bunches the stamps without changing the count
LOST_SAMPLES = 1.5


def _turns_that_lost_samples(t, ranges) -> list[int]:
    """Transitions (k: interval k → k+1) that lost samples: the gyro's integral over them is unknown (4 samples
    lost in a jerky hand turn left gyro K_xx 1.6 % off, 6 std, with exit 0)."""
    h = _typical_step(t)
    out = []
    for k in range(len(ranges) - 1):
        a, b = int(ranges[k][1]) - 1, int(ranges[k + 1][0])
        if b > a and _lost(t, a, b, h) > LOST_SAMPLES:
            out.append(k)
    return out


def _lost(t, a: int, b: int, h: float) -> float:
    """Samples missing between rows a and b (b > a): the time between them over the step ``h``, less the rows."""
    return float((t[b] - t[a]) / h - (b - a))


def _typical_step(t) -> float:
    """The sample step (s): the mean of the steps within 3 medians (stamps rounded to a coarse tick have a median
    a tick off the step, jittered stamps steps well beyond it; gaps of two lost samples and more are left out)."""
    d = np.diff(t[: min(t.size, 65537)])
    med = float(np.median(d))
    return float(np.mean(d[d <= 3.0 * med]))


def _time_gap_words(t) -> str:
    """'the log has N time gap(s) (the first X s at t = Y s): …' for steps beyond 1.75× the typical one, or ''."""
    h = _typical_step(t)
    dt = np.diff(np.asarray(t, float))
    gaps = np.flatnonzero(dt > 1.75 * h)
    if not gaps.size:
        return ""
    i = int(gaps[0])
    return (
        f"the log has {gaps.size} time gap(s) (the first {dt[i]:.3g} s at t = {t[i]:.6g} s): samples lost in a move "
        "join the poses on either side into one"
    )


def _gap_words(t, ranges, ks) -> str:
    """'samples lost (step h s) in N turn(s) (t0–t1 s: n; …)'."""
    h = _typical_step(t)
    parts = []
    for k in ks[:5]:
        a, b = int(ranges[k][1]) - 1, int(ranges[k + 1][0])
        parts.append(f"{t[a]:.4g}–{t[b]:.4g} s: {_lost(t, a, b, h):.0f}")
    more = ", …" if len(ks) > 5 else ""
    return f"samples lost (step {h:.3g} s) in {len(ks)} turn(s) ({'; '.join(parts)}{more})"


def _saturated_turns(t, sat_g, ranges, notes: list) -> list[int]:
    """Transitions (indices k: interval k → k+1) during which the gyro saturates; a saturated static interval
    is an error (its bias and the pose would be wrong)."""
    if sat_g is None or not np.any(sat_g):
        return []
    for i0, i1 in ranges:
        if np.any(sat_g[i0:i1]):
            i = i0 + int(np.flatnonzero(sat_g[i0:i1])[0])
            raise OptinavError(
                f"the gyroscope is at its full scale at rest (t = {t[i]:.6g} s)", "check --gyro-range and --gyro-unit"
            )
    drop = [k for k in range(len(ranges) - 1) if np.any(sat_g[ranges[k][1] : ranges[k + 1][0]])]
    if drop:
        when = ", ".join(f"{t[ranges[k][1]]:.4g}–{t[ranges[k + 1][0]]:.4g} s" for k in drop[:5])
        notes.append(
            f"the gyroscope saturates during {len(drop)} turn(s) ({when}{', …' if len(drop) > 5 else ''}); "
            "those turns are left out of the gyro calibration (turn more slowly, or raise the range)"
        )
    return drop


#: turns sampled slower than this are not judged for glitches: imucal's moves at 25.6 and 12.8 Hz (its 102.4-Hz
#: session decimated) hold a real 40 deg/s burst in one sample, 129× the departures around it; at 51.2 and 102.4 Hz
#: none
GLITCH_MIN_RATE_HZ = 50.0


def _finite_clock(gyr_clock) -> tuple[np.ndarray, np.ndarray]:
    """A gyro file's own (times (M,) s, samples (M, 3)) (:func:`calibrate`'s ``gyr_clock``), its rows with a
    non-finite time or sample left out."""
    tg, wg = (np.asarray(v, float) for v in gyr_clock)
    ok = np.isfinite(tg) & np.all(np.isfinite(wg), axis=1)
    return tg[ok], wg[ok]


def _on_own_clock(t, gyro, ranges, gyr_clock):
    """The gyro fit's times, samples and static intervals (P, 2) on the gyroscope's own samples where it has them
    (``gyr_clock``, :func:`calibrate`): interpolated onto the accelerometer's rows a linear interpolant's kinks at a
    hand turn's jerks, sampled at another phase, move each turn's integral (imucal's recording with its gyro at 0.9x
    the rate: K_yy 0.64 std off the one file's). Each interval keeps the gyro samples within its rows' times; the
    rows where an interval would hold none, or without ``gyr_clock``."""
    if gyr_clock is None:
        return t, gyro, ranges
    tg, wg = _finite_clock(gyr_clock)
    r = np.asarray(ranges, int)
    rg = np.column_stack([np.searchsorted(tg, t[r[:, 0]]), np.searchsorted(tg, t[r[:, 1] - 1], "right")])
    if tg.size < 2 or np.any(rg[:, 1] - rg[:, 0] < 2) or np.any(rg[1:, 0] < rg[:-1, 1]):
        return t, gyro, ranges
    return tg, wg, rg


#: a turn whose gyro reaches an axis's extreme over all turns and stays within PLATEAU_SIGMA of its rest noise there
#: for ≥ 3 samples may be clipped without a flat top (a calibrated output, the sensor axis clipped before the
#: calibration mixed the axes): those turns are left out where the others then fit PLATEAU_GAIN× better
PLATEAU_SIGMA, PLATEAU_GAIN = 6.0, 3.0


def _plateau_turns(gyro, ranges, drop) -> dict[tuple[int, float], list[int]]:
    """Per gyro axis and sign whose extreme over the turns between the rests ``ranges`` (P, 2; those in ``drop`` not
    judged) some turn holds for ≥ 3 samples within :data:`PLATEAU_SIGMA` of the axis's noise at rest: (axis, extreme
    raw) → those turns. ``gyro`` (N, 3) raw."""
    noise = np.median([gyro[a:b].std(axis=0) for a, b in ranges], axis=0)
    turns = [(k, int(ranges[k, 1]), int(ranges[k + 1, 0])) for k in range(len(ranges) - 1) if k not in drop]
    turns = [(k, a, b) for k, a, b in turns if b > a]
    out: dict[tuple[int, float], list[int]] = {}
    for j in range(3):
        for sgn in (1.0, -1.0):
            if not turns:
                break
            peak = max(float(np.max(sgn * gyro[a:b, j])) for _, a, b in turns)
            top = [
                k for k, a, b in turns if np.count_nonzero(sgn * gyro[a:b, j] >= peak - PLATEAU_SIGMA * noise[j]) >= 3
            ]
            if top:
                out[j, sgn * peak] = top
    return out


def _without_flat_topped_turns(fit_gyro, gc, t, gyro, ranges, drop, unit: str, notes: list) -> tuple:
    """The gyro fit ``gc`` again without the turns that top out on an axis's extreme (:func:`_plateau_turns`),
    one axis and sign at a time (a group that holds a turn missing gravity by PLATEAU_GAIN× the others' median),
    the one whose turns left out make the others fit best first, while that fit is
    :data:`PLATEAU_GAIN`× better and K stays determined, with a note; else ``gc`` as it is (a turntable's constant
    rate tops out alike, and fits). ``fit_gyro(drop)`` refits with the turns ``drop`` left out. A simulated gyro
    clipped at 50 °/s before its calibration matrix (no flat top) left K 3-5 % off with exit 0. Returns (fit, the
    turns left out). Turns are kept where the residuals are within what the modelled error sources predict
    (:func:`gyro.residual_limit` at :data:`GYRO_RESIDUAL_P`), or their excess lies in the accelerometer frame's
    directions (:func:`_frame_excess`: held misalignments larger than stated, which the frame gate judges): the six
    axis poses twice lost their two 180° turns about z so in 3 of 40 seeds, and the turns left could not show the
    shear (with --held-misalignment 0.0005, K 10-18 std off with exit 0)."""
    from . import gyro as gyro_cal

    for _ in range(6):
        fr, f_limit = _frame_excess(gc)
        if gc.noise_ratio <= gyro_cal.residual_limit(gc.noise_terms, GYRO_RESIDUAL_P) or (
            fr > f_limit and gc.noise_terms["noise_factor"] < fr
        ):
            return gc, drop
        best = None
        groups = _plateau_turns(gyro, ranges, drop)
        for j in range(3):  # a range clips both signs: their turns together too
            both = [ks for (i, _), ks in groups.items() if i == j]
            if len(both) == 2:
                groups[j, np.nan] = sorted(set(both[0]) | set(both[1]))
        # only a group that holds a turn missing gravity by PLATEAU_GAIN× the others' median is refitted without
        kept = [k for k in range(len(ranges) - 1) if k not in drop]
        miss = dict(zip(kept, np.abs(np.asarray(gc.transition_residuals, float))))
        for (j, v), ks in groups.items():
            others = [m for k, m in miss.items() if k not in ks]
            if not others or max(miss.get(k, 0.0) for k in ks) < PLATEAU_GAIN * float(np.median(others)):
                continue
            try:
                alt = fit_gyro(sorted(set(drop) | set(ks)))
            except OptinavError:
                continue
            if (
                not alt.unobservable
                and alt.sigma * PLATEAU_GAIN <= gc.sigma
                and (best is None or alt.sigma < best[0].sigma)
            ):
                best = (alt, j, v, ks)
        if best is None:
            return gc, drop
        alt, j, v, ks = best
        when = ", ".join(f"{t[ranges[k, 1]]:.4g}–{t[ranges[k + 1, 0]]:.4g} s" for k in ks[:4])
        top = "extremes" if np.isnan(v) else f"extreme {v:+.4g} {unit}"
        notes.append(
            f"{len(ks)} turn(s) top out on the gyro {'xyz'[j]}'s {top} ({when}{', …' if len(ks) > 4 else ''}) "
            f"and miss gravity: the other turns fit {gc.sigma / alt.sigma:.0f}x better without them "
            f"({np.degrees(alt.sigma):.2g}° against {np.degrees(gc.sigma):.2g}°): clipped above the range, left out of "
            "the gyro calibration (turn more slowly, or state the range with --gyro-range)"
        )
        gc, drop = alt, sorted(set(drop) | set(ks))
    return gc, drop


def _merge_turns(drop, k: int, n: int) -> list[int]:
    """Transition indices ``drop`` (transition i: rest i → i + 1, of ``n`` rests) after rest k is left out: the two
    turns into and out of it become one, left out when either was."""
    out = set()
    for i in drop:
        if i < k - 1:
            out.add(i)
        elif i > k:
            out.add(i - 1)
        elif 0 < k < n - 1:
            out.add(k - 1)  # the first or last rest's one turn goes with it
    return sorted(out)


def _turning_rests(t, gyro, ranges, up, drop, g: float, unit: str, notes: list, gyr_clock=None) -> tuple:
    """The indices of the static poses (``ranges`` (P, 2), ``up`` (P, 3)) whose gyro mean the others predict, and
    the turns to leave out (``drop``) renumbered for them: a rest the others do not (:func:`gyro.rest_outlier`) is
    left out with a note, its turns in and out joined (the gyro integrates whatever moved in between), and the
    test is made again. A slow turn about
    the vertical during a pose (0.5 °/s for 60 s in one of 12) moved the bias 38 std, exit 0: the accelerometer
    cannot see it. More than a third of the rests, or fewer than :data:`gyro.MIN_TRANSITIONS` + 1 left: an error."""
    from . import gyro as gyro_cal

    tg, wg, rg = _on_own_clock(t, gyro, ranges, gyr_clock)
    means, sems, _ = gyro_cal._stats(wg, rg)
    tc = np.array([tg[a:b].mean() for a, b in rg])
    keep = np.arange(len(ranges))
    while keep.size > gyro_cal.MIN_TRANSITIONS + 1:
        hit = gyro_cal.rest_outlier(means[keep], sems[keep], tc[keep], up[keep], g)
        if hit is None:
            break
        k, j, d, z = hit
        a, b = int(ranges[keep[k], 0]), int(ranges[keep[k], 1]) - 1
        where = f"static pose {keep[k] + 1} ({t[a]:.4g}–{t[b]:.4g} s)"
        why = (
            f"its gyro {'xyz'[j]} mean differs from what the other rests give by {d:+.3g} {unit} ({z:.0f}× their "
            "scatter): the unit turned during it (slowly about the vertical, which the accelerometer cannot see), or "
            "the gyro bias jumped"
        )
        if 3 * (len(ranges) - keep.size + 1) > len(ranges):
            raise OptinavError(
                f"{len(ranges) - keep.size + 1} of {len(ranges)} static poses are no rest for the gyro ({where}: {why})",
                "hold the unit still in each pose (turn only between them); else give the rests by hand (--sections)",
            )
        notes.append(f"{where} left out of the gyro calibration: {why}; the turns on either side are joined")
        drop = _merge_turns(drop, k, keep.size)
        keep = np.delete(keep, k)
    return keep, drop


def _glitched_turns(t, gyro, ranges, drop, unit: str, notes: list, gyr_clock=None) -> list[int]:
    """The turns between consecutive static intervals (``ranges`` (P, 2) rows; those in ``drop`` not judged) whose
    gyro holds a glitch by the tests of the Ferraris rotations (:func:`ferraris.find_glitch`: a run of 1-3 samples
    that leaves the turn and comes back far beyond its own roughness), with a note per turn: the fit carries gravity
    through each turn, so a glitch moves K by its share of that turn. With ``gyr_clock`` (:func:`calibrate`) the
    gyroscope's own samples in each turn are judged (interpolated rows between them are lines through them: a gyro
    file at half the rate, every other row on a sample, had real jerks 'far beyond' in 8 of imucal's 9 turns)."""
    from . import ferraris

    out = []
    tg, wg = (t, np.asarray(gyro, float)) if gyr_clock is None else (np.asarray(v, float) for v in gyr_clock)
    if _typical_step(tg) > 1.0 / GLITCH_MIN_RATE_HZ:
        return out
    for k in range(len(ranges) - 1):
        if k in drop:
            continue
        a, b = np.searchsorted(tg, [t[int(ranges[k, 1])], t[int(ranges[k + 1, 0])]])
        if b - a < ferraris.GLITCH_MIN_SAMPLES:
            continue
        hit = ferraris.find_glitch(wg[a:b])
        if hit is None:
            continue
        why, i, L, c = hit
        size = float(np.mean(wg[a + i : a + i + L, c]) - 0.5 * (wg[a + i - 1, c] + wg[a + i + L, c]))
        out.append(k)
        notes.append(
            f"{L} gyro {'xyz'[c]} sample(s) at t = {tg[a + i]:.6g} s, in the turn {tg[a]:.6g}-{tg[min(b, tg.size - 1)]:.6g} s, depart "
            f"from it by {size:.4g} {unit} and come back ({why}): a glitch; that turn is left out of the gyro calibration"
        )
    return out


def _gyro_drift_note(t, gyr, ranges, up, g: float, gc, unit: str) -> str | None:
    """A note when the gyro rest biases follow a trend in time beyond their scatter (χ², p < 0.001) and its span
    over the session exceeds 3× the b std: ``--gyro-bias local`` tracks the drift through the turns and reports the
    session mean with the std of that mean, so a bias that went 0.06 → 0.56 °/s over imucal's session was reported
    b_z 0.284 ± 0.0012 °/s without a word (probe). ``ranges`` the rests, ``up`` (P, 3) their unit specific force,
    ``unit`` the gyro's raw unit."""
    from .gyro import _rest_regression

    tc = np.array([t[i0:i1].mean() for i0, i1 in ranges])
    reg = _rest_regression(static.pose_means(gyr, ranges), tc, np.asarray(up, float), g)
    if reg is None:
        return None
    big = reg["drift_significant"] & (reg["drift_span"] > 3.0 * np.asarray(gc.b_std, float))
    if not big.any():
        return None
    j = int(np.argmax(np.where(big, reg["drift_span"] / np.asarray(gc.b_std, float), -np.inf)))
    return (
        f"the gyro bias drifts during the session: on gyro {'xyz'[j]} the rest biases follow a trend spanning "
        f"{reg['drift_span'][j]:.3g} {unit} over {tc[-1] - tc[0]:.4g} s ({reg['drift_span'][j] / gc.b_std[j]:.0f}× the b "
        "std); the turns use the bias of the rests around them, and b is the session mean with the std of that "
        "mean, not the bias at another time (let the sensor warm up, or pass --gyro-bias-instability to put the "
        "drift in the std)"
    )


#: the pose residuals' trend in time, per accelerometer axis, in σ (noise, or the misfit the trend leaves when larger)
#: before the accelerometer is taken to drift; and its span over the session in b std
ACC_DRIFT_SIGMA = 5.0
ACC_DRIFT_SPAN_B_STD = 3.0


def _acc_drift_note(t, ranges, st, fit, g: float, unit: str) -> str | None:
    """A note when the poses' norm residuals follow a bias trending linearly in time on one axis: per axis the fit's
    linearised model (:func:`model.norm_jacobian`, weighted by each pose's noise) gains a bias rate, and the note
    comes when that rate differs from zero by :data:`ACC_DRIFT_SIGMA` σ (its σ from the noise, scaled up by the
    misfit the rate leaves when that exceeds the noise) and its span over the poses exceeds
    :data:`ACC_DRIFT_SPAN_B_STD` × the b std. The fit reports the session's mean bias: acc_x drifting by 2 mg
    over a simulated session gave b 3.8 std off the bias at its start with no word. Poses visited once cannot tell
    a drift from a pose-dependent error that happens to follow their order; the misfit scaling keeps a model
    error from reading as a drift, and with fewer poses than parameters + 2 no test is made. Not called when
    --acc-bias-instability states a drift."""
    free = np.flatnonzero(np.isfinite(fit.std))
    n = len(ranges)
    if n < free.size + 2:
        return None
    tc = np.array([t[i0:i1].mean() for i0, i1 in ranges])
    tau = tc - tc.mean()
    sig = accel.residual_sigma(fit.theta, st)
    y = model.norm_residuals(fit.theta, st.means, g) / sig
    Jf = model.norm_jacobian(fit.theta, st.means) / sig[:, None]
    best = None
    for j in range(3):
        A = np.c_[Jf[:, free], Jf[:, 6 + j] * tau]
        x, *_ = np.linalg.lstsq(A, y, rcond=None)
        e = y - A @ x
        scale = max(1.0, float(e @ e) / (n - A.shape[1]))
        std = float(np.sqrt(np.linalg.pinv(A.T @ A)[-1, -1] * scale))
        # the residual asks b to move by -x·τ: the bias itself moved by +x·τ relative to the fit's mean
        span = -float(x[-1]) * (tc[-1] - tc[0])
        z = abs(float(x[-1])) / std
        b_std = float(fit.std[6 + j])
        if z > ACC_DRIFT_SIGMA and abs(span) > ACC_DRIFT_SPAN_B_STD * b_std and (best is None or z > best[1]):
            best = (j, z, span, b_std)
    if best is None:
        return None
    j, z, span, b_std = best
    # raw → m/s² (K⁻¹ of the bias step) → mg
    mg = span * float(np.linalg.norm(np.linalg.solve(np.asarray(fit.K, float), np.eye(3)[j]))) / (G_STANDARD * 1e-3)
    minutes = (tc[-1] - tc[0]) / 60.0
    return (
        f"the accelerometer drifts during the session: on acc {'xyz'[j]} the pose residuals follow a bias trend of "
        f"{span:+.3g} {unit} ({mg:+.2g} mg) over the poses' {minutes:.3g} min ({mg / minutes:+.2g} mg/min, {z:.0f} std; "
        f"{abs(span) / b_std:.0f}× the b std); b is the session's mean bias, not the bias at its start or end "
        "(let the sensor warm up before recording, keep sessions short, or repeat the first pose at the end; "
        "--acc-bias-instability states the drift in the std)"
    )


def _gyro_gates(gc, gyro_unit: str) -> list[dict]:
    """Convergence, residual and plausibility gates of a gyro fit (:mod:`optinav.multipos.gates`); raises on
    the first that fails, else returns their outcomes."""
    if not gc.success or not (np.all(np.isfinite(gc.K)) and np.all(np.isfinite(gc.b)) and np.isfinite(gc.residual_rms)):
        raise OptinavError(
            f"the gyroscope fit did not converge ({gc.message})",
            "check the static intervals (--threshold, --sections) and --gyro-unit",
        )
    nominal = float(np.median(np.abs(np.diag(gc.K)))) if gyro_unit == "counts" else 1.0 / factor(gyro_unit)
    gates.check_matrix(
        gc.K, nominal, "gyroscope", gyro_unit, option="--gyro-unit", columns_flag="--columns or --gyro-columns"
    )
    if gc.residual_rms > gates.MAX_GYRO_RESIDUAL_RAD:
        raise OptinavError(
            f"the turns do not carry gravity onto the next pose: residual RMS "
            f"{np.degrees(gc.residual_rms):.3g}° (accepted {np.degrees(gates.MAX_GYRO_RESIDUAL_RAD):.3g}°)",
            (
                ""
                if gc.bias_mode == "local"
                else "for a gyro bias that drifts during the session pass --gyro-bias local; else "
            )
            + "check for motion inside the static intervals (--threshold, "
            "--sections) and the time column (--rate, --time-unit)",
        )
    return [
        gate("gyr optimizer converged", gc.success, None, kind="true"),
        gate(
            "gyr residual rms of the carried gravity direction",
            gc.residual_rms,
            gates.MAX_GYRO_RESIDUAL_RAD,
            unit="rad",
        ),
    ]


#: chance that a correct session's turn residuals in the accelerometer frame's directions exceed the limit of
#: :func:`_gyro_frame_gate` (six axis poses twice, MTi-1, held terms at the default 1σ: 0 of 100 sessions refused)
GYRO_RESIDUAL_P = 1e-4
#: a widening of the gyro K std by the χ² scaling from which a note says so (below it the gyro entry records it)
WIDENING_NOTE = 1.1


def _frame_excess(gc) -> tuple[float, float]:
    """The gyro fit ``gc``'s turn residuals in the accelerometer frame's directions over their prediction
    (:func:`gyro._frame_split`) and the limit that prediction exceeds with probability :data:`GYRO_RESIDUAL_P`
    (:func:`gyro.residual_limit`; (0, inf) where the frame's directions are below the noise)."""
    from . import gyro as gyro_cal

    t = gc.noise_terms
    if not t.get("frame_total", 0.0) > 0:
        return 0.0, float("inf")
    moments = {"total": t["frame_total"], "c2": t["frame_c2"], "c3": t["frame_c3"]}
    return float(t["frame_ratio"]), gyro_cal.residual_limit(moments, GYRO_RESIDUAL_P)


def _gyro_frame_gate(gc, held_misalignment: float | None, notes: list) -> list[dict]:
    """The gyro's turn residuals in the accelerometer frame's directions against what the modelled error sources
    predict there (:func:`gyro._frame_split`: the frame's error — its fit and its misalignments held at 0 at 1σ
    ``held_misalignment`` rad, None: none held — and the measured noise, at the level the other directions show):
    refused beyond the limit the prediction exceeds with probability :data:`GYRO_RESIDUAL_P`
    (:func:`gyro.residual_limit`), naming --held-misalignment where terms are held. A noise the rests do not show
    (a bias that wanders between them) raises every direction alike, and K's std follows the residuals (σ̂, and the
    χ² scaling of the stated sources in :func:`gyro.calibrate_gyro`), with a note when that widens an element's std
    :data:`WIDENING_NOTE` times or more. Returns the gate's outcome ([] where the frame's directions are below the
    noise)."""
    q = gc.noise_ratio
    words = (
        f"the gyro's turns between the poses leave {q:.3g}× the residual (Σ‖r‖²) that its noise at rest, the Earth "
        "rate and the stated error sources predict"
    )
    held = held_misalignment is not None
    fr, limit = _frame_excess(gc)
    # the held terms' 1σ that makes the frame's prediction match its share of the residuals
    implied = held_misalignment * float(np.sqrt(max(fr, 1.0))) if held else 0.0
    out = []
    if np.isfinite(limit):
        if fr > limit:
            raise OptinavError(
                f"{words}, {fr:.3g}× in the directions of the accelerometer's frame (accepted {limit:.3g}×, p = "
                f"{GYRO_RESIDUAL_P:g}): "
                + (
                    f"the accelerometer misalignments held at 0 shear the poses by more than their 1σ "
                    f"{held_misalignment:g} rad (the turns imply about {implied:.2g} rad)"
                    if held
                    else "the accelerometer's calibration turns the poses by more than its std"
                ),
                f"state their 1σ with --held-misalignment (about {implied:.2g}, or the datasheet's), or record tilted "
                "poses that observe the misalignments (optinav design plans them)"
                if held
                else "check the static intervals (--threshold, --sections) and the accelerometer's columns",
            )
        out.append(gate("gyr turn residuals in the accelerometer frame's directions over their prediction", fr, limit))
    if gc.std_widening >= WIDENING_NOTE:
        notes.append(
            f"{words}: the gyro K std is widened up to {gc.std_widening:.3g}× (χ² scaling)"
            + (
                f"; the turns imply held misalignments of about {implied:.2g} rad (--held-misalignment states their 1σ)"
                if held and fr > 1
                else ""
            )
        )
    return out


def _held_frame_gate(gc, held_misalignment: float) -> dict:
    """The gyro K (``gc``) fitted in the frame of an accelerometer whose misalignments are held at 0 (1σ
    ``held_misalignment`` rad, in its std through the up directions, ``gc.up_K_std``): refused when that share
    of an element's std exceeds :data:`gyro.MAX_STD` of the scale (a held misalignment shears the six axis poses
    against each other, and the turns between them by as much: 20 mrad left K_g 2.6 % off); else the gate's
    outcome."""
    from . import gyro as gyro_cal

    up = np.zeros(1) if gc.up_K_std is None else gc.up_K_std
    worst = float(np.max(up[np.isfinite(up)], initial=0.0)) / gc.k0
    if worst > gyro_cal.MAX_STD:
        raise OptinavError(
            f"the gyro K is not determined: std up to {100 * worst:.3g} % of the scale (accepted "
            f"{100 * gyro_cal.MAX_STD:g} %), from the accelerometer misalignments held at 0 (1σ "
            f"{held_misalignment:g} rad) that shear the poses the turns are fitted to",
            "record tilted poses that observe the misalignments (optinav design plans them), or state the "
            "datasheet's --held-misalignment",
        )
    return gate("gyr K std from the held accelerometer misalignments", worst, gyro_cal.MAX_STD, unit="k0")


def _misnamed_poses(means: np.ndarray, names: list) -> str | None:
    """The Ferraris pose sections (``names`` x_p … z_a) whose mean specific force (``means`` (6, 3), raw, less the
    six poses' mean: their offset) lies along another axis or sign than the name says, in words; None when each
    lies along its own. imucal's section list with x_p and y_p swapped was refused as "RMS of |a| - g is
    8.84e+03 m/s^2"."""
    d = means - means.mean(axis=0)
    out = []
    for nm, v in zip(names, d):
        axis, sign = str(nm)[0], 1.0 if str(nm).endswith("_p") else -1.0
        k = int(np.argmax(np.abs(v)))
        if "xyz"[k] != axis or np.sign(v[k]) != sign:
            out.append(f"{nm}'s gravity lies along {'+' if v[k] > 0 else '-'}{'xyz'[k]}")
    if not out:
        return None
    return "the sections do not hold the poses their names say: " + ", ".join(out)


def _turn_angle(angle: float) -> float | None:
    """A turn's angle (deg) as a technician states it: the multiple of 90° within 2 % of ``angle``, else None."""
    r = 90.0 * round(angle / 90.0)
    return r if r and abs(angle / r - 1.0) < 0.02 else None


#: the gyro bias of the three Ferraris pose pairs (mean of x_p and x_a, …) may differ by this many σ of their
#: noise (plus twice the Earth rate, which the poses see by their heading) before the bias is taken to drift
FERRARIS_BIAS_DRIFT_SIGMA = 5.0


#: a Ferraris rotation section whose gyro turns less than this share of the median of the three, or about its
#: own axis less than this share of its turn, holds no turn of its own (when the other two do)
MIN_ROTATION_SHARE = 0.25


def _check_rotations_turn(t, gyro, gyr_b, names: list, idx: np.ndarray) -> None:
    """Error when one rotation section (x_rot, y_rot, z_rot) holds no turn about its axis while the other two do:
    the gyro's angle in it (raw·s, bias removed) is below :data:`MIN_ROTATION_SHARE` of the median of the three,
    or mostly about another axis (a section on a rest or on the move between poses was refused as 'the gyroscope
    fit is implausible … check the column order'; probe). Swapped gyro columns turn every section off its axis:
    left to the swap check."""
    where = {str(n): k for k, n in enumerate(names)}
    dt = np.diff(t, append=t[-1] + (t[-1] - t[-2] if t.size > 1 else 0.0))
    vec = []
    for n in ("x_rot", "y_rot", "z_rot"):
        i0, i1 = idx[where[n]]
        vec.append(((gyro[i0:i1] - gyr_b) * dt[i0:i1, None]).sum(axis=0))
    vec = np.array(vec)
    size = np.linalg.norm(vec, axis=1)
    typical = float(np.median(size))
    own = np.abs(np.diag(vec)) / np.maximum(size, 1e-300)
    bad = (size < MIN_ROTATION_SHARE * typical) | (own < 1.0 - MIN_ROTATION_SHARE)
    if typical <= 0 or np.count_nonzero(bad) != 1:
        return
    j = int(np.flatnonzero(bad)[0])
    a = int(np.argmax(np.abs(vec[j])))
    n = ("x_rot", "y_rot", "z_rot")[j]
    raise OptinavError(
        f"the section {n} does not hold the turn about {'xyz'[j]}: the gyro turns {size[j] / typical:.2g}× as far in it as in "
        f"the median rotation section, {own[j]:.0%} of it about {'xyz'[j]} (mostly about {'xyz'[a]})",
        f"let the section {n} span the turn about {'xyz'[j]}, from rest to rest (--sections, or the label column)",
    )


def _check_ferraris_bias_drift(gyro, names: list, idx: np.ndarray, gyr_K, unit: str) -> None:
    """Error when the gyro bias of the pose pairs x_p/x_a, y_p/y_a, z_p/z_a differs beyond their noise: the
    closed form takes one bias, the poses' mean, for the three rotations after them, so a bias that drifts
    (warm-up) scales K_g (0.5 °/s over imucal's session: K_zz 0.27 % off at 17 std, exit 0)."""
    from .ferraris import _mean_cov, _step, quantized_mean_var

    where = {str(n): k for k, n in enumerate(names)}
    # a gyro whose noise is below its step reads each pose with a quantization bias of its own (0.2 counts of noise:
    # pose pairs 6 std apart by the noise alone, refused as a drifting bias)
    step = _step([np.asarray(gyro[slice(*r)], float) for r in idx])
    pair_mean, pair_var = [], []
    for ax in "xyz":
        poses = [np.asarray(gyro[slice(*idx[where[f"{ax}_{s}"]])], float) for s in "pa"]
        pair_mean.append((poses[0].mean(axis=0) + poses[1].mean(axis=0)) / 2)
        c = [_mean_cov(x) for x in poses]
        pair_var.append(sum(np.diag(ci[0]) + quantized_mean_var(ci[2], step) for ci in c) / 4)
    m, v = np.array(pair_mean), np.array(pair_var)
    earth = 2.0 * OMEGA_E * np.abs(np.diag(gyr_K))
    worst, where_ = 0.0, None
    for i, k in ((0, 1), (0, 2), (1, 2)):
        excess = (np.abs(m[i] - m[k]) - earth) / np.sqrt(v[i] + v[k])
        j = int(np.argmax(excess))
        if excess[j] > worst:
            worst, where_ = float(excess[j]), j
    if worst > FERRARIS_BIAS_DRIFT_SIGMA:
        j = where_
        raise OptinavError(
            f"the gyro bias drifts during the session: on gyro {'xyz'[j]} the pose pairs x, y, z give "
            f"{', '.join(f'{b:.4g}' for b in m[:, j])} {unit} ({worst:.0f} std apart), and the closed form takes "
            "their mean for the rotations (a gyro warming up)",
            "let the sensor warm up and record again, or drop --method ferraris: the default fit takes each turn's "
            "gyro bias from the rests around it (--gyro-bias local)",
        )


#: a still rest outside the six Ferraris poses may read |a| this many σ (its noise and the calibration's std) off g
#: before the accelerometer is taken to drift
FERRARIS_ACC_DRIFT_SIGMA = 5.0


def _still_rests(t, acc, gyr) -> list[tuple[int, int]]:
    """The still stretches (sample ranges) the static detection finds in a Ferraris log, none when it finds none:
    the rests the accelerometer-drift and turn-bias checks judge by (detected once for both)."""
    try:
        return [(int(a), int(b)) for a, b in np.asarray(static.detect_static(t, acc, gyr=gyr).index_ranges, int)]
    except OptinavError:
        return []


def _ferraris_rest_norms(acc, rests, poses, correct, K, K_std, b_std, g: float) -> list[tuple[int, int, float, float]]:
    """The still ``rests`` (:func:`_still_rests`) of the log outside the six Ferraris ``poses`` ((6, 2) sample
    ranges; the pauses of a turn in steps, the rests before and after the rotations): per rest (i0, i1, |a| − g
    [m/s²], that difference in σ).
    ``correct`` maps raw acc (n, 3) to m/s²; σ combines the rest's noise (lag-1 correlation included) and the
    calibration's ``K_std`` (3, 3, raw per m/s²) and ``b_std`` (3,) raw along the rest's direction. The closed form
    fits the six poses exactly, so a bias that drifts leaves no residual there; a rest at another time does."""
    Kinv_t = np.linalg.inv(np.asarray(K, float)).T
    out = []
    for i0, i1 in rests:
        if np.any((poses[:, 0] < i1) & (poses[:, 1] > i0)) or i1 - i0 < 10:
            continue
        a = correct(acc[i0:i1])
        a = a[np.all(np.isfinite(a), axis=1)]
        m = a.mean(axis=0)
        u = m / np.linalg.norm(m)
        r = a @ u - m @ u
        rho = np.clip(np.sum(r[1:] * r[:-1]) / max(float(r @ r), 1e-300), 0.0, 0.95)
        var_rest = float(r @ r) / r.size**2 * (1 + rho) / (1 - rho)
        v = Kinv_t @ u  # d|a| = -vᵀ(δK·g·u + δb)
        var_cal = float(np.sum(v**2 * (np.asarray(b_std) ** 2 + g**2 * (np.asarray(K_std) ** 2 @ u**2))))
        d = float(np.linalg.norm(m) - g)
        out.append((int(i0), int(i1), d, abs(d) / np.sqrt(var_rest + var_cal)))
    return out


def _check_ferraris_acc_drift(t, acc, rests, poses, fc, K_std, b_std, g: float, gate_log: list, notes: list) -> None:
    """Error when a still rest outside the six poses reads |a| off g beyond :data:`FERRARIS_ACC_DRIFT_SIGMA` σ
    (:func:`_ferraris_rest_norms`): each axis' bias and scale come from its two poses alone, so an accelerometer
    that drifts (warm-up: 0.05 m/s² over imucal's session) leaves the six poses exact and the result biased (b_x
    0.5441 ± 0.00046 for a bias that went from 0.537 to 0.587, exit 0). Else a gate is logged (with a rest), or a
    note when the log holds no rest to judge by (a file of cut sections: acc_x drifting by 20 counts over imucal's
    annotated session moved b_x from −6.02 to −3.78 ± 0.15 counts without a word)."""
    norms = _ferraris_rest_norms(acc, rests, poses, fc.correct_acc, fc.acc_K, K_std, b_std, g)
    if not norms:
        notes.append(
            "the accelerometer drift check could not run: the log holds no still rest outside the six poses (a file "
            "of cut sections?), and the closed form fits the poses exactly whatever the bias did between them; "
            "record still rests before and after the rotations (as imucal's example session does) to have it checked"
        )
        return
    i0, i1, d, z = max(norms, key=lambda r: r[3])
    if z > FERRARIS_ACC_DRIFT_SIGMA:
        raise OptinavError(
            _drift_cause(t, i0, i1, d, z, fc.correct_acc(acc[i0:i1]), "outside the six poses")
            + ", while the closed form fits the six poses exactly with the bias and scale of their times (a sensor "
            "warming up)",
            "let the sensor warm up and record again, or drop --method ferraris: the default fit takes every rest "
            "(--acc-bias-instability states a drift in its std)",
        )
    gate_log.append(gate("acc largest |a| - g of a rest outside the poses, in std", z, FERRARIS_ACC_DRIFT_SIGMA))


def _drift_cause(t, i0: int, i1: int, d: float, z: float, corrected: np.ndarray, where: str) -> str:
    """The start of a drift error: the still rest ``i0:i1`` (its up axis from the ``corrected`` specific force),
    ``where`` it lies, its |a| − g ``d`` (m/s²) after the calibration and ``z`` (std)."""
    u = corrected.mean(axis=0)
    j = int(np.argmax(np.abs(u)))
    return (
        f"the accelerometer drifts during the session: the still rest at {t[i0]:.4g}–{t[i1 - 1]:.4g} s "
        f"({'+-'[int(u[j] < 0)]}{'xyz'[j]} up, {where}) reads |a| {d:+.3g} m/s^2 off g after the calibration "
        f"({z:.0f} std of its noise and the calibration's std)"
    )


def _check_left_out_rests(t, acc, gyro, ranges, valid, fit, g, window_s, min_duration_s, acc_unit, gyro_unit) -> None:
    """Error when a still rest that the automatic threshold left out of the fit reads |a| off g beyond
    :data:`FERRARIS_ACC_DRIFT_SIGMA` σ after the calibration (:func:`_ferraris_rest_norms`). The threshold takes the
    most rests whose fit has an acceptable χ², so the rests that would show a drift were the ones left out: imucal's
    session with acc_z drifting by 0.1 m/s² lost its last two rests (84 and 97 s) and gave b_z 0.4488 ± 0.0034
    (0.3983 ± 0.0025 undrifted) with exit 0. Rests with clipped or invalid rows are not judged."""
    try:
        det = static.detect_static(
            t, acc, gyr=gyro, window_s=window_s, min_duration_s=min_duration_s, acc_unit=acc_unit, gyro_unit=gyro_unit
        )
    except OptinavError:
        return
    bad = ~np.asarray(valid, bool) | _clipped_rows(acc, t, np.asarray(det.index_ranges, int), [])
    rests = [(int(a), int(b)) for a, b in np.asarray(det.index_ranges, int) if not bad[a:b].any()]
    K_std = np.zeros((3, 3))
    for j, (r, c) in enumerate(model.K_INDEX):
        K_std[r, c] = fit.std[j]
    K_std = np.nan_to_num(K_std)  # (a held misalignment has no std)

    def correct(raw):
        return np.linalg.solve(fit.K, (raw - fit.b).T).T

    norms = _ferraris_rest_norms(
        acc, rests, np.asarray(ranges, int), correct, fit.K, K_std, np.nan_to_num(fit.std[6:9]), g
    )
    if not norms:
        return
    i0, i1, d, z = max(norms, key=lambda r: r[3])
    if z > FERRARIS_ACC_DRIFT_SIGMA:
        raise OptinavError(
            _drift_cause(t, i0, i1, d, z, correct(acc[i0:i1]), "left out of the fit because the poses do not agree")
            + ": the fit holds the bias of the other rests' times (a sensor warming up)",
            "let the sensor warm up and record again, or pass --acc-bias-instability with the drift to state it in "
            "the std",
        )


#: a Ferraris pose pair's mean direction may lie this many σ (the --pose-alignment of two poses, and their noise)
#: off its axis before a pose is taken to be held tilted
POSE_PAIR_SIGMA = 3.5


def _check_ferraris_pose_pairs(fc, acc, ranges, pose_alignment: float) -> dict:
    """Error when the two poses of an axis are not opposite: their mean output less the bias, K_a⁻¹((U₊ + U₋)/2 − b)
    across the axis, is g times their mean tilt, which the closed form takes for a misalignment (one pose 5° off
    moved K_yx by 3.6 std and K_xx by 12 std with exit 0). Its σ is ``pose_alignment`` (rad, 1σ per pose) over
    √2 and the poses' noise (``acc`` raw, ``ranges`` (6, 2) of x_p … z_a); beyond :data:`POSE_PAIR_SIGMA` σ the
    error names the pair and --pose-alignment; else the gate's outcome is returned."""
    U = fc.acc_static_means
    Kinv = np.linalg.inv(fc.acc_K)
    worst, where = 0.0, (0, 0.0)
    for j in range(3):
        f = Kinv @ ((U[2 * j] + U[2 * j + 1]) / 2 - fc.acc_b) / fc.gravity  # ≈ the pair's mean tilt (rad)
        tilt = float(np.hypot(*np.delete(f, j)))
        var = sum(np.mean(np.var(acc[i0:i1], axis=0)) / (i1 - i0) for i0, i1 in ranges[2 * j : 2 * j + 2])
        noise = np.sqrt(var) / 2 / fc.gravity / float(np.median(np.abs(np.diag(fc.acc_K))))
        z = tilt / np.hypot(pose_alignment / np.sqrt(2.0), noise)
        if z > worst:
            worst, where = z, (j, tilt)
    j, tilt = where
    if worst > POSE_PAIR_SIGMA:
        ax = "xyz"[j]
        raise OptinavError(
            f"the poses {ax}_p and {ax}_a are not opposite: their mean direction lies {np.degrees(tilt):.2g}° off "
            f"the {ax} axis ({worst:.0f} std for poses placed within {np.degrees(pose_alignment):.2g}°), a pose held "
            "tilted, which the closed form takes for a misalignment of the sensor",
            "place the poses flat against a square edge and record again, or state the placement error with "
            f"--pose-alignment {max(1.0, np.ceil(np.degrees(tilt) * np.sqrt(2.0))):g} (degrees; it enters the std)",
        )
    return gate("acc largest tilt of a pose pair's mean direction, in std", worst, POSE_PAIR_SIGMA)


def _turn_axis_tilts(fc, acc, ranges: dict, turns: list) -> list[tuple[str, int, float]]:
    """Per rotation (``turns``: :func:`ferraris.check_rotations`' outcome, ``ranges`` name → (i0, i1)): its name,
    axis j and the angle (rad) between the axis it turned about and the sensor's j axis, both in the calibrated
    accelerometer's frame. About a vertical axis (the accelerometer does not see the turn) the axis is gravity's mean
    direction; about an axis the accelerometer sees turn, gravity sweeps the plane across the axis, whose normal
    (the least-variance direction of gravity's unit direction over the section) is the axis."""
    out = []
    for j, r in enumerate(turns):
        i0, i1 = ranges[r["name"]]
        f = fc.correct_acc(acc[i0:i1])
        u = f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-300)
        u = u[np.all(np.isfinite(u), axis=1)]
        if np.isfinite(r["acc_turn_deg"]):
            m = np.linalg.eigh(np.cov(u.T))[1][:, 0]  # (eigenvalues ascending)
        else:
            m = np.mean(u, axis=0)
        out.append((r["name"], j, float(np.arctan2(np.linalg.norm(np.delete(m, j)), abs(m[j])))))
    return out


def _check_ferraris_turn_axes(tilts: list, pose_alignment: float) -> dict | None:
    """Error when a rotation turned about an axis off its sensor axis (``tilts``: :func:`_turn_axis_tilts`) beyond
    :data:`POSE_PAIR_SIGMA` × ``pose_alignment`` (rad): the closed form takes the gyro's turn for one about that axis,
    so a turn about an axis tilted by δ puts sin δ into K_g's column as a misalignment and lowers its scale by
    1 − cos δ (imucal's z_rot turned about an axis 10° off: K_yz −10.1 ± 0.98, K_zz −1.5 %, exit 0; its real turns:
    ≤ 0.42°, the annotated session's ≤ 1.4°). Returns the gate's outcome (None: no rotation)."""
    pose_alignment = max(float(pose_alignment), np.radians(0.1))  # (0 given: a turn placed within 0.1°)
    if not tilts:
        return None
    name, j, tilt = max(tilts, key=lambda x: x[2])
    worst = tilt / pose_alignment
    if worst > POSE_PAIR_SIGMA:
        raise OptinavError(
            f"the rotation {name} turned about an axis {np.degrees(tilt):.2g}° off the sensor's {'xyz'[j]} axis "
            f"(gravity shows the turn's axis that far from it; {worst:.0f} std for a placement within "
            f"{np.degrees(pose_alignment):.2g}°): the closed form would take the tilt for a gyro misalignment and "
            f"lower K_{'xyz'[j] * 2} by {1 - np.cos(tilt):.2%}",
            "turn the sensor flat against a square edge about its own axis and record again, or state the placement "
            f"error with --pose-alignment {np.ceil(np.degrees(tilt)):g} (degrees; the std then holds the tilt)",
        )
    return gate("gyr largest tilt of a rotation axis from its sensor axis, in std", worst, POSE_PAIR_SIGMA)


#: a step of a turn against the accelerometer's (:func:`ferraris.turn_step`) is refused when it moves its K_jj by more
#: than this many std (a step beyond the noise that moves K less is harmless)
TURN_STEP_K_SIGMA = 3.0


def _check_ferraris_turn_steps(t, acc, gyr, ranges: dict, turns: list, fc, K_std) -> dict:
    """Error when the gyro's turn in a rotation the accelerometer sees (about an axis off gravity) steps against the
    gravity the accelerometer measures (:func:`ferraris.turn_step`, beyond :data:`ferraris.STEP_SIGMA` of the
    section's spread) by an angle that moves that column's scale K_jj beyond :data:`TURN_STEP_K_SIGMA` of its std
    ``K_std``: a glitch amid the turn's own jerks, which the gyro's tests by departure and isolation cannot tell from
    the turn (one sample 0.5 rad/s off in a simulated hand turn: K_jj 5 std off, exit 0). ``ranges`` name →
    (i0, i1); ``turns`` :func:`ferraris.check_rotations`' outcome. Returns the gate's outcome: the largest such shift
    in std (0 when no step is beyond the noise)."""
    from . import ferraris

    worst = 0.0
    for j, r in enumerate(turns):
        if not np.isfinite(r["acc_turn_deg"]):
            continue  # about a vertical axis the accelerometer sees no turn
        i0, i1 = ranges[r["name"]]
        f = fc.correct_acc(acc[i0:i1])
        ratio, step, row = ferraris.turn_step(t[i0:i1], f, fc.correct_gyro(gyr[i0:i1], f))
        if ratio <= ferraris.STEP_SIGMA:
            continue
        z = abs(step) / abs(float(fc.expected_angle[j])) * abs(fc.gyr_K[j, j]) / max(float(K_std[j, j]), 1e-300)
        if z > TURN_STEP_K_SIGMA:
            ax = "xyz"[j]
            raise OptinavError(
                f"in {r['name']} the gyro's turn steps by {np.degrees(step):+.3g}° against the gravity the "
                f"accelerometer sees, at t = {t[i0 + row]:.6g} s ({ratio:.0f}× the section's spread of such steps): "
                f"a glitch amid the turn's jerks, which scales K_{ax * 2} by its share of the turn ({z:.0f} std)",
                f"record the turn {r['name']} again, or drop --method ferraris and --sections (the default fit finds "
                "the rests and judges each turn between them)",
            )
        worst = max(worst, z)
    return gate(
        "gyr largest K_jj shift from a turn stepping against the accelerometer, in std", worst, TURN_STEP_K_SIGMA
    )


def _check_ferraris_turn_bias(
    t, acc, gyr, rests, names: list, idx: np.ndarray, fc, K_std, unit: str, gate_log: list
) -> None:
    """Error when the gyro bias at the rests around a rotation (the still stretches nearest before and after it:
    a pose, or a rest outside the poses) differs from the poses' bias ``fc.gyr_b`` by more than the Earth rate, so
    much that the rotation's K_g column moves beyond :data:`FERRARIS_BIAS_DRIFT_SIGMA` of its std ``K_std``: the
    closed form integrates each turn with the poses' bias (a bias step of 0.3 °/s after imucal's poses: K_zz 57.05
    for 57.19, 16 std, exit 0; the three pose pairs agree, so the pair check cannot see it). Else a gate."""
    from . import ferraris

    where = {str(n): k for k, n in enumerate(names)}
    turns = [idx[where[n]] for n in ferraris.ROTATIONS]

    def in_turns(a: int, b: int) -> int:
        return sum(max(0, min(b, int(i1)) - max(a, int(i0))) for i0, i1 in turns)

    # a still stretch mostly inside a rotation section is a turntable's constant rate, no rest: the plateau of a
    # motorized y_rot (8 s at 45 deg/s) was z_rot's rest before, refused as the bias changing by 799 counts
    rests = [r for r in rests if 2 * in_turns(*r) <= r[1] - r[0]]
    rests = rests + [tuple(idx[where[n]]) for n in ferraris.POSES]
    earth = OMEGA_E * np.abs(np.diag(fc.gyr_K))
    worst, info = 0.0, None
    for j, rot in enumerate(ferraris.ROTATIONS):
        i0, i1 = idx[where[rot]]
        before = [r for r in rests if r[1] <= i0]
        after = [r for r in rests if r[0] >= i1]
        near = ([max(before, key=lambda r: r[1])] if before else []) + ([min(after)] if after else [])
        if not near:
            continue
        bias = [gyr[a:b].mean(axis=0) - fc.gyr_G @ fc.correct_acc(acc[a:b]).mean(axis=0) for a, b in near]
        shift = np.mean(bias, axis=0) - fc.gyr_b
        beyond = np.sign(shift) * np.maximum(np.abs(shift) - earth, 0.0)
        # the turn integrates the bias error over its duration: column j of K_g moves by that over the angle
        dK = beyond * float(fc.rotation_duration[j]) / abs(float(fc.expected_angle[j]))
        z = np.abs(dK) / np.maximum(K_std[:, j], 1e-300)
        i = int(np.argmax(z))
        if z[i] > worst:
            worst, info = float(z[i]), (rot, j, i, near, float(shift[i]), float(dK[i]))
    if worst > FERRARIS_BIAS_DRIFT_SIGMA:
        rot, j, i, near, shift, dK = info
        when = " and ".join(f"{t[a]:.4g}–{t[b - 1]:.4g} s" for a, b in near)
        raise OptinavError(
            f"the gyro bias changes during the session: around {rot} (the rests at {when}) gyro {'xyz'[i]} reads "
            f"{shift:+.3g} {unit} off the poses' bias, beyond the Earth rate, and the closed form integrates the turn "
            f"with the poses' bias: K_g[{'xyz'[i]}, {'xyz'[j]}] would be {dK:+.3g} off ({worst:.0f} "
            "std)",
            "let the sensor warm up and record again, or drop --method ferraris: the default fit takes each turn's "
            "gyro bias from the rests around it (--gyro-bias local)",
        )
    gate_log.append(
        gate("gyr largest shift of K_g by the bias around a rotation, in std", worst, FERRARIS_BIAS_DRIFT_SIGMA)
    )


def _check_pose_turns(pt, stated: float, rate: float) -> None:
    """Refuse a Ferraris fit whose rotations' K_g does not carry gravity from pose to pose (:func:`ferraris.
    pose_turns`: factor beyond MAX_POSE_TURN and MIN_POSE_TURN_SIGMA std); ``stated`` deg, ``rate`` Hz."""
    off = pt.factor - 1.0
    if abs(off) <= pt.limit:
        return
    angle = stated / pt.factor
    near = _turn_angle(angle)
    head = (
        f"the gyro's turns between the {pt.transitions + 1} poses need K_g ×{pt.factor:.4f} (± {pt.std:.2g}) to carry "
    )
    if near is not None:
        raise OptinavError(
            f"{head}gravity from pose to pose: the rotations turned by about {angle:.4g}°, not the stated {stated:g}°",
            f"pass --rotation-angle {near:g}",
        )
    # no technician's angle: the integration of the turns, not the angle
    raise OptinavError(
        f"{head}gravity from pose to pose: the turns integrated over the rotation sections are off by {off:+.1%} "
        f"({rate:.3g} Hz)",
        "check --rate and --time-unit (a rate too low for the turns integrates them short), --rotation-angle, "
        "and that each rotation section runs from rest to rest (--sections)",
    )


def _note_turn_sampling(share: float, rate: float, notes: list) -> None:
    """A note where the gyro's noise at rest shows no anti-alias filter and the rotations hold content near the
    Nyquist frequency (:func:`ferraris.turn_sampling`: that content carried to the sample rate at the slowest decay
    a turn's rate can have, 1/f, is in K_g's std). ``share`` that uncertainty as a share of each turn, ``rate`` the
    gyro's sample rate [Hz]."""
    if not share > 0.0:
        return
    why = (
        f"the gyro's noise at rest stays white up to the Nyquist frequency ({rate / 2:.3g} Hz: no anti-alias filter), so "
        "what the hand turns held at the sample rate folded into their integrals"
    )
    notes.append(
        f"{why}: K_g's std includes ±{share:.2g} of each turn for it (the turns' content near the Nyquist frequency "
        "carried to the sample rate as a jump in rate's would be, the slowest a turn's spectrum falls off; a vibration "
        "line near a multiple of the sample rate folds beyond it); record at the sensor's own rate, or low-pass before "
        "decimating, to take it out"
    )


def _check_pose_turn_axes(pt, stated: float) -> None:
    """Refuse a Ferraris fit one of whose rotation sections scaled its gyro axis off what carries gravity from pose
    to pose (:func:`ferraris.pose_turn_axes`, where no common factor does); ``stated`` deg."""
    off = pt.off()
    if not off:
        return
    j = max(off, key=lambda k: abs(pt.factors[k] - 1.0))
    a = "xyz"[j]
    others = ", ".join(f"{'xyz'[k]} ×{pt.factors[k]:.4f}" for k in range(3) if k != j)
    raise OptinavError(
        f"the gyro's turns between the {pt.transitions + 1} poses need K_{a}{a} ×{pt.factors[j]:.4f} (± "
        f"{pt.std[j]:.2g}; {others}) to carry gravity from pose to pose: the turn integrated over {a}_rot is "
        f"{1.0 / pt.factors[j] - 1.0:+.1%} off the stated {stated:g}° — rows lost or repeated inside it (a log "
        "without time stamps or a sample counter cannot show them), or a section that misses part of its turn",
        f"check the rows of {a}_rot in the log, and that the section runs from rest to rest (--sections)",
    )


#: a Ferraris turn's samples at the gyro's extreme are a constant rate held (a turntable's, read by a gyro whose
#: noise is below a count: flat at the log's extreme like a clipped peak), not a clip, where the turn holds it,
#: within this share of the rate (or two of the output's quanta), over at least half of its motion (its samples
#: above a tenth of the rate), reaching it once in each burst of motion
PLATEAU_TOL = 0.01
#: ... and whose rate rises to it and falls from it at a steady or settling pace: the mean step of the second half
#: of each ramp within this factor of the first half's (a motor's straight ramps 1.00-1.02, a jerk-limited one 0.75;
#: a smooth turn clipped at 0.2-0.7 of its peak still speeds up at the rail, 1.3-1.6: clipped at 0.5-0.6, its K_g
#: 22-32 % small passed as a constant rate with exit 0)
RAMP_SPEEDUP = 1.2
#: a run of k samples at the gyro's extreme, entered or left steeply, is a clip where the turn's own moving samples
#: repeat so seldom (a share p of their steps) that k − 1 repeats in a row, p^(k−1), have less than this chance (a
#: logger that holds samples, like BROAD's gyro in 4-12 % of its steps, repeats at a peak too)
HOLD_CHANCE = 1e-3


#: deg/s, the full scales MEMS gyros are set to; a 16-bit output rails at the scale itself (32767 counts at 131
#: counts per deg/s: 250.1) or, at ST's round sensitivities (8.75 mdps per count at 250), GYRO_RAIL_ST times it
GYRO_RANGES_DPS = (125.0, 245.0, 250.0, 300.0, 400.0, 500.0, 1000.0, 2000.0, 4000.0)
GYRO_RAIL_ST = 32767 * 0.00875 / 250.0


def at_gyro_rail(value: float, unit: str) -> bool:
    """Whether a gyro reading ``value`` [``unit``, not counts] lies within 0.3 % of where a MEMS gyro set to a
    common full scale rails (:data:`GYRO_RANGES_DPS`): a turn flat there is taken for clipped, not for a turntable's
    constant rate (--gyro-range states the range where a turntable ran at exactly that rate)."""
    if unit == "counts" or not np.isfinite(value):
        return False
    dps = abs(float(value)) * factor(unit) * 180.0 / np.pi
    rails = np.array(GYRO_RANGES_DPS)
    return bool(np.any(np.abs(dps / np.r_[rails, GYRO_RAIL_ST * rails] - 1.0) <= 0.003))


def clipped_turn_rows(gyr, acc, names, idx, gyr_b, dt: float, rail_unit: str | None = None) -> np.ndarray:
    """Rows (N,) of the Ferraris rotation sections (``names`` ending in _rot, half-open ``idx`` rows) where the gyro
    reads its full scale, judged from the samples, so that a stated range too large hides none: per axis and sign,
    the turns' samples at the log's extreme once that shows itself a rail — in a turn, a run of k ≥ 3 samples at it
    (≥ 5 where the log reaches the value only there: a natural peak reaches its value once) entered or left within
    the motion by a step beyond a natural peak's (> 0.5 % of the rate and 5 of the output's quanta, or flat ≥ 0.1 s
    where the quantum is below 0.1 % of it: the steps of :func:`optinav.attitude.checks.steep_runs`), in a turn
    whose other moving samples repeat too seldom to hold k − 1 repeats by chance (:data:`HOLD_CHANCE`); or outside
    the turns by the attitude input check's rule (:func:`optinav.attitude.checks.saturated_extremes`: a clip on the
    moves between the poses shows the rail a single sample of a turn reaches). A rate a turn holds over most of its
    motion is a constant rate, not a rail (:data:`PLATEAU_TOL`, :data:`RAMP_SPEEDUP`), unless the rail shows itself
    elsewhere, or sits where a gyro set to a common range rails (:func:`at_gyro_rail`, with ``rail_unit`` the gyro's
    unit; None: not judged, the range stated). ``gyr`` (N, 3) raw, ``acc`` (N, 3) (a whole sample repeated is one
    the logger held), ``gyr_b`` (3,) the raw bias, ``dt`` the sample step [s]."""
    from optinav.attitude.checks import axis_steps, quantum, saturated_extremes

    turns = [(int(a), int(b)) for nm, (a, b) in zip(names, idx) if str(nm).endswith("_rot")]
    n = gyr.shape[0]
    out, rails, whole = np.zeros(n, bool), {}, np.column_stack([gyr, acc])
    for j in range(3):
        x = gyr[:, j]
        q = quantum(axis_steps(x))
        fastest = max((float(np.nanmax(np.abs(x[i0:i1] - gyr_b[j]))) for i0, i1 in turns if i1 > i0), default=0.0)
        for sgn in (1.0, -1.0):
            m = float(np.nanmax(sgn * x))
            rate = m - sgn * float(gyr_b[j])
            # an extreme no turn moves towards (the rest's noise) is no rail
            if not (np.isfinite(m) and rate > 0.1 * fastest):
                continue
            y = sgn * (x - gyr_b[j])
            at = sgn * x >= m - 1e-9 * max(abs(m), 1.0)
            # a natural peak reaches its value once, a rail every peak beyond it: a lone run of 3-4 samples is no
            # evidence (BROAD's gyro axes hold a sample 3-4 times in 0.1 % of their moving steps, peaks too)
            shortest = 3 if len(mask_runs(at)) > 1 else 5
            # a flat turn at a common range's rail is a clip, not a constant rate (unless the range was stated)
            plateau = rail_unit is None or not at_gyro_rail(m, rail_unit)
            shown = False
            for i0, i1 in turns:
                if at[i0:i1].any():
                    shown = shown or _turn_rail(y[i0:i1], at[i0:i1], whole[i0:i1], rate, q, dt, shortest, plateau)
            rails[j, sgn] = m, at, shown
    # the rail shown outside the turns (a turntable faster than the range reads flat at it too)
    between = np.ones(n, bool)
    for i0, i1 in turns:
        between[i0:i1] = False
    for j, sgn, m, _, _ in saturated_extremes(np.where(between[:, None], gyr, np.nan), dt, acc=acc):
        if (j, sgn) in rails and m == rails[j, sgn][0]:
            rails[j, sgn] = (m, rails[j, sgn][1], True)
    for m, at, shown in rails.values():
        if shown:
            for i0, i1 in turns:
                out[i0:i1] |= at[i0:i1]
    return out


def _constant_rate(y, moving, rate: float, tol: float) -> np.ndarray:
    """The samples of a turn ``y`` (towards its extreme ``rate``, bias removed; ``moving`` above a tenth of it)
    that hold a constant rate at the extreme within ``tol`` (:data:`PLATEAU_TOL`, :data:`RAMP_SPEEDUP`), or none."""
    near = moving & (y >= rate - tol)
    if 2 * np.count_nonzero(near) < np.count_nonzero(moving):
        return np.zeros_like(near)
    for a, b in mask_runs(moving):
        stretch = mask_runs(near[a:b])
        if len(stretch) > 1:
            return np.zeros_like(near)
        for ramp in () if len(stretch) == 0 else (y[a : a + stretch[0, 0]], y[a + stretch[0, 1] : b][::-1]):
            d = np.diff(np.r_[ramp, rate])
            if d.size >= 4 and np.mean(d[d.size // 2 :]) > RAMP_SPEEDUP * np.mean(d[: d.size // 2]):
                return np.zeros_like(near)
    return near


def _turn_rail(y, at, rows, rate: float, q: float, dt: float, shortest: int, plateau: bool = True) -> bool:
    """Whether a turn's samples ``y`` (its rate towards the extreme ``rate``, bias removed) show a rail in their
    runs ``at`` the extreme of ``shortest`` samples or more (see :func:`clipped_turn_rows`); ``rows`` the turn's
    whole samples (gyro and accelerometer: a run over which all repeat is one the logger held); ``plateau`` False:
    a constant rate held at the extreme is judged as a rail too."""
    moving = y > 0.1 * rate
    near = _constant_rate(y, moving, rate, max(PLATEAU_TOL * rate, 2.0 * q)) if plateau else np.zeros_like(moving)
    at, moving = at & ~near, moving & ~near
    off = moving & ~at
    both = off[1:] & off[:-1]
    p = (np.count_nonzero(np.diff(y)[both] == 0) + 1) / (np.count_nonzero(both) + 1)
    for s, e in mask_runs(at):
        if e - s < shortest or s == 0 or e == y.size or p ** (e - s - 1) >= HOLD_CHANCE:
            continue
        if np.all(rows[s:e] == rows[s]):
            continue
        # a turn that starts or stops abruptly at its top (a hand turn against a stop) enters or leaves it steeply,
        # so only a step within the motion counts
        into = y[s] - y[s - 1] if y[max(s - 2, 0) : s].min() > 0.1 * rate else 0.0
        out_of = y[e - 1] - y[e] if y[e : e + 2].min() > 0.1 * rate else 0.0
        if max(into, out_of) > max(0.005 * rate, 5.0 * q) or ((e - s) * dt >= 0.1 and q < 0.001 * rate):
            return True
    return False


def _ferraris_saturation(t, acc, gyro, sat_a, sat_g, names, idx, gyr_b, rail_unit: str | None = None) -> None:
    """One-line errors for a sensor at its full scale inside a Ferraris section (outside them it is harmless):
    the accelerometer (integer type or --acc-range), the gyro likewise or, in a turn, at a rail its samples show
    (:func:`clipped_turn_rows`, with or without --gyro-range: a clipped peak makes the turn's integral fall short,
    K too small); ``rail_unit`` the gyro's unit where a flat turn at a common range's rail is a clip (no range
    stated), else None."""
    sat_g = np.zeros(gyro.shape[0], bool) if sat_g is None else sat_g.copy()
    sat_g |= clipped_turn_rows(gyro, acc, names, idx, gyr_b, _typical_step(t), rail_unit)
    for what, sat, flag in (("accelerometer", sat_a, "--acc-range"), ("gyroscope", sat_g, "--gyro-range")):
        for nm, (i0, i1) in zip(names, idx):
            n = int(np.count_nonzero(sat[i0:i1]))
            if n:
                k = i0 + int(np.flatnonzero(sat[i0:i1])[0])
                turning = str(nm).endswith("_rot") and what == "gyroscope"
                raise OptinavError(
                    f"the {what} is at its full scale in {n} samples of the section {nm} (from t = {t[k]:.6g} s)"
                    + (": the turn was faster than its range, so its integral falls short" if turning else ""),
                    ("turn more slowly or record with a larger range" if turning else "cut them from the section")
                    + f" ({flag} states the range)",
                )


def _sections_that_lost_samples(t, names, idx) -> list[str]:
    """A note per rotation section that lost samples (its duration over the sample step, less the samples it
    holds, :data:`LOST_SAMPLES`): its integral bridges the gap (:func:`optinav.multipos.ferraris._gap_variance`), and a
    section list in sample indices made on the log before samples were lost no longer covers the turn (5 lost rows shifted imucal's
    x_rot: gyro K_xx 1.9 % off, exit 0)."""
    h = _typical_step(t)
    out = []
    for nm, (i0, i1) in zip(names, idx):
        if not str(nm).endswith("_rot") or i1 - i0 < 2:
            continue
        lost = _lost(t, i0, i1 - 1, h)
        if lost > LOST_SAMPLES:
            k = int(np.argmax(np.diff(t[i0:i1])))
            out.append(
                f"{nm}: about {lost:.0f} samples lost inside the turn (the longest step {t[i0 + k + 1] - t[i0 + k]:.3g} s "
                f"at t = {t[i0 + k]:.6g} s): the turn's integral bridges it with the mean of the rates on both sides, "
                "and the gyro std includes the turn's own rate changes over as long; a section list in sample indices "
                "must count the rows of this log (--sections)"
            )
    return out


#: fewest samples of a Ferraris pose section: its within-pose scatter gives the std (see ferraris.ferraris_std) and
#: the clipping check (:func:`_clipped_rows`) judges poses of more than 10
MIN_FERRARIS_POSE_SAMPLES = 11


def _ferraris(
    t,
    acc,
    gyro,
    sections,
    g,
    g_source,
    acc_unit,
    gyro_unit,
    n_nan,
    sat_a,
    t_start,
    source,
    notes,
    rotation_angle,
    pose_alignment=np.radians(1.0),
    sat_g=None,
    *,
    rng=None,
    gyr_clock=None,
    range_stated: bool = False,
):
    """The closed-form Ferraris calibration (6 axis poses + 3 rotations named as imucal names them), gated;
    ``rng`` seeds the Monte Carlo std (None: 0, so that a run repeats); ``gyr_clock`` as :func:`calibrate`;
    ``range_stated``: --gyro-range was given (a turn flat at a common range's rail is then a constant rate)."""
    from . import ferraris

    if gyro is None or sections is None:
        raise OptinavError(
            "the Ferraris method needs gyroscope data and the nine named sections "
            "(x_p, x_a, y_p, y_a, z_p, z_a, x_rot, y_rot, z_rot)",
            "give the gyro columns and either a label column naming the sections or --sections FILE",
        )
    sl = static.sections_from_list(sections, t) if not isinstance(sections, dict) else None
    if sl is None:
        names = list(sections)
        idx = np.array([sections[n] for n in names], int)
        t_iv = np.column_stack([t[idx[:, 0]], t[idx[:, 1] - 1]])
    else:
        sl.as_dict()  # sections without a name, or a name given twice, are named as such
        names, idx, t_iv = list(sl.names), np.asarray(sl.index_ranges, int), np.asarray(sl.t_intervals, float)
    names = [ferraris.section_name(n) for n in names]
    twice = sorted({n for n in names if n in ferraris.SECTIONS and names.count(n) > 1})
    if twice:
        raise OptinavError(f"the sections name {', '.join(twice)} twice", "give each Ferraris section once")
    ranges = {n: (int(i0), int(i1)) for n, (i0, i1) in zip(names, idx)}
    glitch, fixed = None, []
    inside = bool(np.all((0 <= idx[:, 0]) & (idx[:, 0] < idx[:, 1]) & (idx[:, 1] <= len(t))))
    if inside:
        # (ranges out of the log are refused by ferraris_from_sections)
        poses = {n: tuple(idx[names.index(n)]) for n in names if n in ferraris.POSES}
        acc, spikes = ferraris.repair_pose_spikes(acc, poses, t, "accelerometer", acc_unit)
        gyro, more = ferraris.repair_pose_spikes(gyro, poses, t, "gyro", gyro_unit)
        notes.extend(spikes + more)
    own = None if gyr_clock is None else _finite_clock(gyr_clock)
    repaired_own = None
    if inside and all(n in names for n in ferraris.ROTATIONS):
        try:
            if own is None:
                repaired, fixed = ferraris.repair_rotation_glitches(
                    gyro, {n: tuple(idx[names.index(n)]) for n in names}, t, gyro_unit
                )
            else:
                # judged on the gyroscope's own samples: interpolated onto the accelerometer's times, a sample
                # keeps its noise where a row meets it and is averaged between, so the departures around a real
                # jerk of a hand turn changed with the clocks' phase (a gyro file at half the rate, every other row
                # on a sample: a jerk of x_rot 18997x the departures around it, refused as a glitch; at 0.9x 25x),
                # and a spike of the file spread over two rows (300 deg/s unseen, K_yy 18 std off)
                tg, wg = own
                span = {
                    n: tuple(np.searchsorted(tg, [t[idx[names.index(n)][0]], t[idx[names.index(n)][1] - 1]]))
                    for n in ferraris.ROTATIONS
                }
                span = {n: (int(a), int(b) + 1) for n, (a, b) in span.items()}
                repaired_own, fixed = ferraris.repair_rotation_glitches(wg, span, tg, gyro_unit)
                repaired = gyro.copy()  # (the poses keep their repaired spikes)
                for n in ferraris.ROTATIONS:
                    i0, i1 = idx[names.index(n)]
                    repaired[i0:i1] = np.column_stack([np.interp(t[i0:i1], tg, repaired_own[:, j]) for j in range(3)])
        except OptinavError as e:
            glitch = e

    def closed_form(gyr, gyr_own=None if own is None else own[1]):
        return ferraris.ferraris_from_sections(
            t,
            acc,
            gyr,
            ranges,
            gravity=g,
            expected_angle=rotation_angle,
            with_std=True,
            rng=0 if rng is None else rng,
            gyr_clock=None if own is None else (own[0], gyr_own),
        )

    fc, std = closed_form(gyro)
    _ferraris_saturation(t, acc, gyro, sat_a, sat_g, names, idx, fc.gyr_b, None if range_stated else gyro_unit)
    # a clipped turn is named as such above; a spike or dropout inside a turn after it
    if glitch is not None:
        raise glitch
    if fixed:
        gyro = repaired
        notes.extend(fixed)
        fc, std = closed_form(gyro, repaired_own)
    # the six poses: a section of another name is not the closed form's and is not judged as a pose (one that
    # spans a move was refused as 'the Ferraris pose extra is not still', and entered the poses' turns; probe)
    static_idx = [k for k, nm in enumerate(names) if str(nm) in ferraris.POSES]
    few = [k for k in static_idx if idx[k][1] - idx[k][0] < MIN_FERRARIS_POSE_SAMPLES]
    if few:
        # a pose of 1 or 2 samples has no scatter to give a std: K and b were written with a null std, exit 0
        k = few[0]
        raise OptinavError(
            f"the Ferraris pose {names[k]} holds {idx[k][1] - idx[k][0]} sample(s) ({t_iv[k][0]:.6g}–{t_iv[k][1]:.6g} s): "
            "too few to tell its noise (and its std), or whether it was still",
            f"let the section span the whole still pose, at least {MIN_FERRARIS_POSE_SAMPLES} samples (--sections, "
            "or the label column)",
        )
    clipped: list[str] = []
    if np.any(_clipped_rows(acc, t, idx[static_idx], clipped)):
        # without --acc-range a clipped pose went through: acc K_xx 0.960 for 0.997 at 1100 std, exit 0
        raise OptinavError(
            clipped[0].replace("the static pose at", "the Ferraris pose at"),
            "record with a larger accelerometer range: the closed form needs all six poses (--acc-range states it)",
        )
    notes.extend(_sections_that_lost_samples(t, names, idx))
    for x, what, unit in ((acc, "accelerometer", acc_unit), (gyro, "gyro", gyro_unit)):
        for k, n, i, last, shift, peak in pose_taps(x, idx[static_idx])[:1]:
            # a tap on the table inside a pose, or a section that runs into the move, moved the pose mean, K and b
            # with it, silently (the std only widened; b_y -0.066 for -0.616 ± 0.37 with y_a 2.4 s too long)
            nm, when = names[static_idx[k]], f"{t[i]:.6g}" + (f"–{t[last]:.6g}" if last > i else "")
            raise OptinavError(
                f"the Ferraris pose {nm} is not still at t = {when} s: {n} {what} sample(s) up to {peak:.3g} {unit} "
                f"off the pose's median (a tap or bump, or the move into or out of the pose) move its mean by "
                f"{shift:.0f}× the noise of the mean",
                f"let the section {nm} hold only the still part of the pose (--sections, or the label column)",
            )
    ang, sig = pose_creep(acc, idx[static_idx], fc.correct_acc)
    bad = np.flatnonzero(creeping(ang, sig))
    if bad.size:
        k = int(bad[0])
        raise OptinavError(
            f"the Ferraris pose {names[static_idx[k]]} is not still: gravity moves by {np.degrees(ang[k]):.2g}° "
            "within it (a slow creep or tilt; its gyro rate enters the gyro bias and g-sensitivity)",
            "let the section hold only the still part of the pose (--sections, or the label column)",
        )
    a = fc.correct_acc(acc)
    mask = np.zeros(len(t), bool)
    for i0, i1 in idx[static_idx]:
        mask[i0:i1] = True
    residual_rms = float(np.sqrt(np.mean((np.linalg.norm(a[mask], axis=1) - g) ** 2)))
    # gates: the six poses agree on g, both matrices are plausible, the turns go the stated way
    pose_rms = float(np.sqrt(np.mean((fc.acc_static_norm - g) ** 2)))
    if pose_rms > gates.MAX_RESIDUAL_G * g:
        swap = gates.swapped_axis(*(static.pose_means(x, idx[static_idx]) for x in (acc, gyro)))
        if not swap and (
            named := _misnamed_poses(static.pose_means(acc, idx[static_idx]), [names[k] for k in static_idx])
        ):
            raise OptinavError(
                f"the six Ferraris poses disagree on g: {named} (sections swapped in the list?)",
                "give each section the pose it holds (--sections, or the label column)",
            )
        raise OptinavError(
            f"the six Ferraris poses disagree on g: RMS of |a| - g is {pose_rms:.3g} m/s^2"
            + (f" — {swap}" * bool(swap)),
            "name the columns in their order with --columns"
            if swap
            else "check that the sections x_p … z_a hold still poses in imucal's order (--sections)",
        )
    acc_nominal = float(np.median(np.abs(np.diag(fc.acc_K)))) if acc_unit == "counts" else 1.0 / factor(acc_unit)
    gates.check_matrix(
        fc.acc_K,
        acc_nominal,
        "accelerometer",
        acc_unit,
        option="--acc-unit",
        columns_flag="--columns, or the section names",
    )
    gate_pairs = _check_ferraris_pose_pairs(fc, acc, idx[[names.index(n) for n in ferraris.POSES]], pose_alignment)
    poses = idx[sorted(static_idx, key=lambda k: idx[k][0])]
    dirs = np.array([a[i0:i1].mean(axis=0) for i0, i1 in poses])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    stated = float(np.degrees(fc.expected_angle[0]))
    if np.all(np.diag(fc.gyr_K) < 0):
        pt = ferraris.pose_turns(-fc.gyr_K, -fc.gyr_b, t, dirs, gyro, poses)
        # the angle the poses' turns give, not merely the other sign (180 was told -180, which then failed)
        angle = -stated / pt.factor if pt else -stated
        raise OptinavError(
            f"the three rotations turn the other way than --rotation-angle {stated:g} says (every gyro scale is "
            "negative)" + (f"; the gyro's turns between the poses give {angle:.4g}°" if pt else ""),
            f"pass --rotation-angle {_turn_angle(angle) or round(angle, 1):g}",
        )
    gyro_flags = "--columns or --gyro-columns, the rotation sections' names (x_rot, y_rot, z_rot), or --rotation-angle"
    # swapped sections or axes first (no nominal: the shape of K only), then the turns: a section that misses part
    # of its turn scales K_g by the share it holds (0.6 s short of a hand turn: K_zz 0.79×), which the scale's
    # gate would blame on the time base
    _check_rotations_turn(t, gyro, fc.gyr_b, names, idx)
    gates.check_matrix(fc.gyr_K, None, "gyroscope", gyro_unit, option="--gyro-unit", columns_flag=gyro_flags)
    section_ranges = {n: tuple(idx[k]) for k, n in enumerate(names)}
    turns = ferraris.check_rotations(fc, t, acc, gyro, section_ranges)
    tilts = _turn_axis_tilts(fc, acc, section_ranges, turns)
    gate_axes = _check_ferraris_turn_axes(tilts, pose_alignment)
    step_s = float(np.median(np.diff(t)))
    gyro_clipped = clipped_gyro_rows(gyro, step_s)
    if sat_g is not None:
        gyro_clipped |= sat_g
    pt = (t, gyro, poses, gyro_clipped, step_s)
    if own is not None:
        # the turns between the poses on the gyroscope's own samples too: on the interpolated rows imucal's
        # recording with its gyroscope at 0.9x the rate gave lambda 0.9973 +- 0.0012 (one file: 0.9977 +- 0.0011),
        # which widened K_g's std 1.7x; on its own samples 0.9977 +- 0.0011
        tg, wg = own[0], own[1] if repaired_own is None else repaired_own
        po = np.column_stack([np.searchsorted(tg, t[poses[:, 0]]), np.searchsorted(tg, t[poses[:, 1] - 1], "right")])
        if np.all(po[:, 1] > po[:, 0]):
            step_g = float(np.median(np.diff(tg)))
            pt = (
                tg,
                wg,
                po,
                clipped_gyro_rows(wg, step_g) | (np.interp(tg, t, gyro_clipped.astype(float)) > 0),
                step_g,
            )
    pose_turn = ferraris.pose_turns(fc.gyr_K, fc.gyr_b, pt[0], dirs, pt[1], pt[2], pt[3])
    if pose_turn:
        _check_pose_turns(pose_turn, stated, 1.0 / pt[4])
    elif axes := ferraris.pose_turn_axes(fc.gyr_K, fc.gyr_b, pt[0], dirs, pt[1], pt[2], pt[3]):
        _check_pose_turn_axes(axes, stated)  # (no axis off: the axes' turns checked the angle)
    elif unseen := [r["name"] for r in turns if not np.isfinite(r["acc_turn_deg"])]:
        # a file of cut sections with the turns about vertical axes: --rotation-angle 180 for imucal's 360° turns
        # doubled K_g with exit 0 and no word (the angle is what the closed form scales K_g by)
        notes.append(
            f"the rotation angle {stated:g}° is taken as stated for {', '.join(unseen)}: the accelerometer does not "
            "see those turns (about a vertical axis) and no turns between the poses check it (none recorded, as in a "
            "file of cut sections, or they do not carry gravity from pose to pose); K_g scales with it, so check "
            "--rotation-angle"
        )
    _note_turn_sampling(std["gyr_turn_sampling"], 1.0 / pt[4], notes)
    if std["gyr_images"] > 0.0:
        notes.append(
            "the gyro file's noise at rest varies with its samples' phase on the accelerometer's clock as a linear "
            "interpolation's does: its samples were interpolated from samples on that clock, and each turn's integral "
            f"holds the interpolant's image of the turn: K_g's std includes up to ±{std['gyr_images']:.2g} of a turn "
            "for it; give the gyroscope's own samples to take it out"
        )
    gyro_nominal = float(np.median(np.abs(np.diag(fc.gyr_K)))) if gyro_unit == "counts" else 1.0 / factor(gyro_unit)
    _check_ferraris_bias_drift(gyro, names, idx, fc.gyr_K, gyro_unit)
    gates.check_matrix(
        fc.gyr_K,
        gyro_nominal,
        "gyroscope",
        gyro_unit,
        option="--gyro-unit",
        columns_flag=gyro_flags,
        # one axis off alone is rather a rotation section that holds part of its turn (z_rot ending in a pause
        # between the 90° steps of imucal's turn gave K_zz 0.72× and named only the time base; probe)
        time_flags="--rate, --time-unit, or the turn angle --rotation-angle; with one axis off alone, its rotation "
        "section may hold only part of the turn: let it span the whole turn from rest to rest (--sections)",
    )
    if gyro_unit == "counts" and (fs := gyro_full_scale_note(gyro, fc.gyr_K, "--rate, --time-unit, --rotation-angle")):
        notes.append(fs)
    gate_log = [
        gate("acc pose residual rms of |a| - g", pose_rms, gates.MAX_RESIDUAL_G * g, unit="m/s^2"),
        gate_pairs,
        *([gate_axes] if gate_axes else []),
        gate(
            "gyr largest turn outside a rotation section",
            float(np.radians(max(r["missed_deg"] for r in turns))),
            float(ferraris.MAX_MISSED_TURN * np.min(np.abs(fc.expected_angle))),
            unit="rad",
        ),
    ]
    if pose_turn:
        gate_log.append(
            gate(
                "gyr turns between the poses: |factor on K_g - 1|",
                abs(pose_turn.factor - 1.0),
                pose_turn.limit,
            )
        )
    seen = [abs(r["acc_turn_deg"] - np.degrees(fc.expected_angle[k])) for k, r in enumerate(turns)]
    if np.any(np.isfinite(seen)):
        gate_log.append(
            gate(
                "gyr largest difference of the turn the accelerometer sees from the stated angle",
                float(np.radians(np.nanmax(seen))),
                float(np.radians(ferraris.MAX_TURN_MISMATCH_DEG)),
                unit="rad",
            )
        )
    # beyond the noise: an unknown local g scales K_a, a turn the sections missed (below the gate) scales that
    # column of K_g, and the Earth rate (ignored by the method) is in every rest of b_g
    acc_K_std = std["acc_K"]
    if g_source.startswith("standard"):
        acc_K_std = np.hypot(acc_K_std, np.abs(fc.acc_K) * G_UNKNOWN_REL_STD)
    missed = np.radians([r["missed_deg"] for r in turns]) / np.abs(fc.expected_angle)
    # the accelerometer measured the turn about a horizontal axis: its difference from the stated angle (below
    # the gate) scales that column of K_g as a missed turn does
    seen = np.array([r["acc_turn_deg"] for r in turns], float) - np.degrees(fc.expected_angle)
    missed = np.hypot(missed, np.where(np.isfinite(seen), np.radians(seen), 0.0) / np.abs(fc.expected_angle))
    if pose_turn:
        # the poses' turns (below the gate) disagree with the stated angle by that share beyond their noise
        missed = np.hypot(missed, max(abs(pose_turn.factor - 1.0) - 2.0 * pose_turn.std, 0.0))
    gyr_K_std = np.hypot(std["gyr_K"], np.abs(fc.gyr_K) * missed[None, :])
    gyr_b_std = np.hypot(std["gyr_b"], OMEGA_E * np.abs(np.diag(fc.gyr_K)) / np.sqrt(3.0))
    # a pose tilted by δ across its axis j reads K·g·δ on the other axes: column j's misalignments move by
    # K_ii·(δ_up − δ_down)/2 (K_jj·δ²/2 on the diagonal); a turn about an axis off by δ moves column j by K_ii·δ
    sa = float(pose_alignment)
    off = 1.0 - np.eye(3)
    tilt = np.abs(np.diag(fc.acc_K))[:, None] * (off * sa / np.sqrt(2.0) + np.eye(3) * sa**2 / 2)
    acc_K_std = np.hypot(acc_K_std, tilt)
    # a turn about an axis δ off reads K_jj·cos δ: the placement's σ²/2, or the loss of the tilt measured if larger
    # (a 3° tilt passes the tilt test at 1° placement and left K_zz 8.7 std low with exit 0)
    loss = np.zeros(3)
    for _, j, off_axis in tilts:
        loss[j] = 1.0 - np.cos(off_axis)
    diag = np.diag(np.maximum(sa**2 / 2, loss))
    gyr_K_std = np.hypot(gyr_K_std, np.abs(np.diag(fc.gyr_K))[:, None] * (off * sa + diag))
    # a glitch in a turn raises its content near the Nyquist frequency, and so the turn-sampling term of the std it
    # is judged against (one sample 0.5 rad/s off: K_xx 1.2 std off, no refusal): judged without that term
    each = std["gyr_turn_sampling_each"]
    samp = np.where(np.isfinite(each), each, 0.0) * np.abs(np.diag(fc.gyr_K))
    step_std = gyr_K_std.copy()
    np.fill_diagonal(step_std, np.sqrt(np.maximum(np.diag(gyr_K_std) ** 2 - samp**2, 0.0)))
    gate_log.append(_check_ferraris_turn_steps(t, acc, gyro, section_ranges, turns, fc, step_std))
    # an unknown local g scales K and every rest's |a| alike: it is no part of a rest's difference from g (with it,
    # a drift of 0.05 m/s² passed when --gravity was not given)
    rests = _still_rests(t, acc, gyro)
    _check_ferraris_turn_bias(t, acc, gyro, rests, names, idx, fc, gyr_K_std, gyro_unit, gate_log)
    _check_ferraris_acc_drift(
        t, acc, rests, idx[static_idx], fc, np.hypot(std["acc_K"], tilt), std["acc_b"], g, gate_log, notes
    )
    # G = (up − down pose)/2g also takes the Earth rate's change between the two poses, at most 2Ω_E per axis
    # (vertical part: sign flip; horizontal: heading): uniform within ±Ω_E·K_ii/g
    gyr_G_std = np.hypot(std["gyr_G"], (OMEGA_E * np.abs(np.diag(fc.gyr_K)) / (g * np.sqrt(3.0)))[:, None])
    acc_entry = {
        "K": fc.acc_K,
        "b": fc.acc_b,
        "K_std": acc_K_std,
        "b_std": std["acc_b"],
        "form": "full",
        "estimated": ["K (9)", "b (3)"],
        "held": [],
    }
    gyro_entry = {
        "K": fc.gyr_K,
        "b": fc.gyr_b,
        "G": fc.gyr_G,
        "K_std": gyr_K_std,
        "b_std": gyr_b_std,
        "G_std": gyr_G_std,
        "form": "full",
    }
    units = {
        "accelerometer_raw": acc_unit,
        "accelerometer": "m/s^2",
        "gyroscope_raw": gyro_unit,
        "gyroscope": "rad/s",
        "time": "s",
        "residual_rms": "m/s^2",
        "gravity": "m/s^2",
        "K": "raw per SI unit",
        "b": "raw",
        "G": "gyro raw per m/s^2",
    }
    return CalibrationResult(
        accelerometer=acc_entry,
        gyroscope=gyro_entry,
        units=units,
        gravity=g,
        residual_rms=residual_rms,
        static_intervals=t_iv[static_idx],
        observability={
            "note": "closed form: 6 axis poses and 3 rotations of known angle determine every parameter "
            "exactly; the std is the noise of the poses and turns through the closed form (Monte Carlo), with "
            "an unknown local g, a turn missed by the sections, the Earth rate in the bias and G, and the "
            "alignment of the poses and turn axes (--pose-alignment); the turns are taken as exactly the "
            "stated angle (--rotation-angle)",
            "unobservable": [],
        },
        method="ferraris",
        elapsed_s=time.perf_counter() - t_start,
        excluded={"nan_rows": n_nan, "saturated_acc": 0},
        quality={
            "gravity_source": g_source,
            "sections": names,
            "pose_residual_rms": pose_rms,
            "rotation_angle_deg": np.degrees(fc.expected_angle).tolist(),
            "rotations": turns,
            "pose_turn_factor": None if pose_turn is None else pose_turn.factor,
            "pose_turn_factor_std": None if pose_turn is None else pose_turn.std,
            "notes": notes,
        },
        source=source,
        gates=gate_log,
        convergence=convergence(None, message="closed form"),
    )


@dataclasses.dataclass(frozen=True)
class FileOptions:
    """How to read and calibrate one log: the options of ``optinav calibrate accel``, same names and units
    (``gyro_path``/``gyro_columns``: a second file holding the gyroscope; ``datasets``: "std=name,..." text;
    ``gravity`` m/s², ``lat_deg`` degrees, ``height_m`` m, ``window``/``min_duration`` s, ``rest`` (t0, t1) s,
    ranges (±R, or a (lo, hi) span) and ``threshold`` in raw units; ``method`` None: chosen with the data,
    :func:`resolve_method`). Picklable, so batch workers receive it as is."""

    columns: str | None = None
    gyro_path: str | None = None
    gyro_columns: str | None = None
    no_gyro: bool = False
    acc_unit: str | None = None
    gyro_unit: str | None = None
    time_unit: str | None = None
    rate_hz: float | None = None
    delimiter: str | None = None
    datasets: str | None = None
    topic: str | None = None
    skip_bad_lines: bool = False
    gravity: float | None = None
    lat_deg: float | None = None
    height_m: float = 0.0
    method: str | None = None
    model: str = "auto"
    fit_samples: bool = False
    sections: str | None = None
    window: float = 1.0
    min_duration: float = 2.0
    threshold: float | None = None
    acc_range: float | None = None
    gyro_range: float | None = None
    gyro_bias: str = "local"
    rest: tuple | None = None
    allow_unobservable: bool = False
    rotation_angle: float = -360.0
    pose_alignment: float = 1.0
    acc_bias_instability: float | None = None
    held_misalignment: float = accel.HELD_MISALIGNMENT
    gyro_g_sensitivity: float | None = None
    gyro_bias_instability: float | None = None
    gyro_bias_corr_time: float = float("inf")
    generations: int | None = None
    seed: int = 0
    hold_out: int | None = None

    def check(self) -> None:
        """Reject contradictory options before any file is read."""
        if self.rest is not None and self.gyro_bias != "rest":
            raise OptinavError(
                "--rest T0 T1 sets the window of --gyro-bias rest", "add --gyro-bias rest, or drop --rest"
            )
        for name, flag in (
            ("acc_bias_instability", "--acc-bias-instability"),
            ("held_misalignment", "--held-misalignment"),
            ("gyro_g_sensitivity", "--gyro-g-sensitivity"),
            ("gyro_bias_instability", "--gyro-bias-instability"),
            ("pose_alignment", "--pose-alignment"),
        ):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v >= 0):
                raise OptinavError(f"{flag} {v!r} is not a finite number >= 0", f"give {flag} as a 1-sigma value")
        if not (np.isfinite(self.rotation_angle) and self.rotation_angle != 0):
            raise OptinavError(
                f"--rotation-angle {self.rotation_angle!r} is not a non-zero angle",
                "give the Ferraris turn in degrees, e.g. --rotation-angle -360",
            )
        if self.lat_deg is not None and not -90 <= self.lat_deg <= 90:
            raise OptinavError(f"--latitude {self.lat_deg:g} is outside ±90°", "give the latitude in degrees")
        if self.generations is not None and self.method not in ("ga", "pso"):
            raise OptinavError("--generations applies to --method ga or pso only", "drop --generations")
        if self.method is None:
            return  # chosen with the data (:func:`resolve_method`), which checks again
        # options one route does not use were dropped silently: --acc-bias-instability 0.05 with --method ferraris
        # left the bias std at 0.00046 m/s^2, --gyro-bias local did not follow a drift (probe)
        ferraris = self.method == "ferraris"
        unused = [
            "--" + f.name.replace("_", "-")
            for f in dataclasses.fields(self)
            if (f.name in _FERRARIS_ONLY) != ferraris
            and f.name in _FERRARIS_ONLY + _NORM_ONLY
            and not _same(getattr(self, f.name), f.default)
        ]
        if unused:
            route = "--method ferraris (closed form on the nine sections)" if ferraris else f"--method {self.method}"
            other = "the norm-model methods" if ferraris else "--method ferraris"
            raise OptinavError(
                f"{route} does not use {', '.join(unused)}: {'they apply' if len(unused) > 1 else 'it applies'} to "
                f"{other}",
                f"drop {', '.join(unused)}" + ("" if ferraris else ", or pass --method ferraris"),
            )


#: FileOptions fields only the Ferraris closed form uses, and those only the norm-model fits (and their gyro fit) use
_FERRARIS_ONLY = ("rotation_angle", "pose_alignment")
_NORM_ONLY = (
    "model",
    "fit_samples",
    "window",
    "min_duration",
    "threshold",
    "gyro_bias",
    "allow_unobservable",
    "acc_bias_instability",
    "held_misalignment",
    "gyro_g_sensitivity",
    "gyro_bias_instability",
    "gyro_bias_corr_time",
)


def _same(a, b) -> bool:
    """An option's value equals its default (floats by value, inf included)."""
    try:
        return a == b or (a is not None and b is not None and float(a) == float(b))
    except (TypeError, ValueError):
        return False


class SessionData(NamedTuple):
    """A log's samples in the file's own units (the units K and b are stated in)."""

    t: np.ndarray
    acc: np.ndarray
    acc_unit: str
    gyr: np.ndarray | None
    gyro_unit: str | None
    labels: np.ndarray | None = None
    notes: tuple = ()
    #: rows per step of the file's sample counter where it steps by more than one on nearly every row (a
    #: decimated log timed by the counter at --rate), else 1
    counter_step: int = 1
    #: each sample's data row in the file where the reader left rows out (ImuLog.row), else None
    rows: np.ndarray | None = None
    #: the gyroscope's own (times s, samples in gyro_unit) where it was interpolated onto ``t`` (ImuLog.gyr_clock)
    gyr_clock: tuple | None = None


def read_session_file(path, options: FileOptions, chunk_rows: int = CHUNK_ROWS) -> SessionData:
    """Read a log for calibration: accelerometer (required) and gyroscope (unless ``no_gyro``) in raw units.

    Text logs are read in blocks (:func:`optinav.io.iter_imu`, the same values as :func:`optinav.io.read_imu`)
    and only time, accelerometer, gyroscope and labels are kept, so the peak while reading is those arrays plus
    one block of ``chunk_rows`` rows, not the parsed table (about 530 B per row before)."""
    o = options
    blocks = iter_imu(path, chunk_rows=chunk_rows, **reader_options(o))
    parts = {key: _Gather() for key in ("t", "acc", "gyro")}
    labels: list = []
    counter: list = []
    file_rows: list = []
    start = None
    acc_unit = gyro_unit = None
    notes: list = []
    clock = None
    for log in progress_blocks(blocks, "read"):
        if log.acc is None:
            from optinav.io.imu import headphone_error

            raise headphone_error(blocks) or OptinavError(
                f"{path} has no accelerometer columns", "name them with --columns t,ax,ay,az,..."
            )
        acc, acc_unit = raw_units(log, "acc")
        gyro, gyro_unit = (None, None) if o.no_gyro or log.gyr is None else raw_units(log, "gyro")
        if gyro is not None and log.gyr_clock is not None:  # (a second file is read in one block)
            clock = (log.gyr_clock[0], raw_units(log, "gyro", log.gyr_clock[1])[0])
        # the rows of the whole file from the bytes per row since the first block (text files: the reader reads
        # ahead, so the position is not that of the rows yielded; other formats are read whole at once)
        rows = 0
        if start is None:
            start = (blocks.rows, blocks.position)
        elif blocks.position > start[1]:
            rows = blocks.size * (blocks.rows - start[0]) / (blocks.position - start[1])
        for key, value in (("t", log.t), ("acc", acc), ("gyro", gyro)):
            if value is not None:
                parts[key].add(value, int(rows * 1.02) + len(value))
        if log.labels is not None:
            labels.append(log.labels)
        if getattr(log, "sample", None) is not None:
            counter.append(np.asarray(log.sample))
        if getattr(log, "row", None) is not None:
            file_rows.append(np.asarray(log.row))
        notes += log.notes
    t = parts["t"].array()
    step = 1
    if o.rate_hz and counter:
        lab = np.concatenate(labels) if labels else None
        t, step = _counter_time(t, np.concatenate(counter), o.rate_hz, notes, lab)
    return SessionData(
        t,
        parts["acc"].array(),
        acc_unit,
        parts["gyro"].array(),
        gyro_unit,
        np.concatenate(labels) if labels else None,
        tuple(notes),
        step,
        np.concatenate(file_rows) if file_rows else None,
        clock,
    )


def _counter_time(t: np.ndarray, sample: np.ndarray, rate_hz: float, notes: list, labels=None) -> tuple:
    """Times from the file's sample counter where the time came from ``--rate`` (``t`` uniform) and the counter
    skips values, and the counter's step k per row where nearly every row steps by the same k > 1 (else 1): rows
    lost by the logger are then gaps in time, which the turns' integrals bridge and note (20 rows lost at a hand
    turn's peak left gyro K_xx 6.5 % off with exit 0). Only skips inside a labelled
    section (anywhere, without labels) place rows; any other step of the counter (a wrap, a reset, the meeting of
    sections cut from a longer log) counts as one sample, as before."""
    if sample.shape != t.shape or t.size < 3:
        return t, 1
    if not np.allclose(np.diff(t), 1.0 / rate_hz, rtol=1e-9, atol=0.0):
        return t, 1  # a time column: it already places the rows
    s = np.asarray(sample, float)
    if not (np.all(np.isfinite(s)) and np.all(s == np.round(s))):
        return t, 1
    d = np.diff(s)
    skip = d > 1
    if not skip.any():
        return t, 1
    inside = skip if labels is None or len(labels) != len(s) else skip & (labels[1:] == labels[:-1])
    if not inside.any():
        return t, 1  # skips only where labelled sections meet: a file cut to its sections, judged as it is
    steps = np.where(inside, d, 1.0)
    k = int(np.median(d))
    k = k if k > 1 and np.mean(d == k) > 0.9 else 1
    if k > 1:
        # every row k counts on: a decimated log, whose row rate is not --rate (an annotated session's every 4th
        # row with --rate 51.2, its row rate, gave K_g 3.97× with exit 0)
        notes.append(
            f"the sample counter steps by {k} on nearly every row: --rate {rate_hz:g} is taken as the counter's rate, "
            f"so the rows come at {rate_hz / k:.4g} Hz; if {rate_hz:g} Hz is the rate of the rows, pass "
            f"--rate {rate_hz * k:g}"
        )
    elif inside.any():
        notes.append(
            f"the sample counter skips {int(np.sum(d[inside] - 1))} samples at {int(inside.sum())} place(s) (the "
            f"largest, {int(d[inside].max()) - 1}, after row {int(np.flatnonzero(inside)[np.argmax(d[inside])])}): "
            "the rows are timed by it at --rate"
        )
    t = t[0] + np.concatenate([[0.0], np.cumsum(steps)]) / rate_hz
    return t, k


class _Gather:
    """The blocks of one field copied into one array as they come. Its size is the caller's estimate of the whole
    log's rows (grown ×1.5 when too small), and only the rows written are touched, so the resident memory is
    the rows read: no list of blocks to concatenate (two copies), and the block arrays, left on the heap between
    the parser's temporaries, do not fragment it (about 35 B per row of resident memory that was never given
    back)."""

    def __init__(self):
        self.buf, self.n = None, 0

    def add(self, block: np.ndarray, rows: int) -> None:
        need = self.n + len(block)
        if self.buf is None:
            self.buf = np.empty((max(rows, need),) + block.shape[1:], block.dtype)
        elif need > len(self.buf):
            grown = np.empty((max(need, int(1.5 * len(self.buf)), rows),) + self.buf.shape[1:], self.buf.dtype)
            grown[: self.n] = self.buf[: self.n]
            self.buf = grown
        self.buf[self.n : need] = block
        self.n = need

    def array(self) -> np.ndarray | None:
        return None if self.buf is None else self.buf[: self.n]


def resolve_method(options: FileOptions, data: SessionData) -> FileOptions:
    """``options`` with the method chosen when it is None: 'ferraris' for a log with a gyroscope, without
    ``sections``, cut to imucal's nine sections (every row labelled ``x_p … z_rot``, all nine there: its annotated
    sessions, which have no turns between the poses for the norm fit's gyro), else 'lm' (a continuous log with
    the sections labelled keeps its turns); checked for options the chosen route does not use."""
    if options.method is not None:
        return options
    from .ferraris import labels_name_sections

    ferraris = options.sections is None and data.gyr is not None and labels_name_sections(data.labels)
    o = dataclasses.replace(options, method="ferraris" if ferraris else "lm")
    o.check()
    return o


def calibrate_data(data: SessionData, options: FileOptions, source: str = "") -> CalibrationResult:
    """:func:`calibrate` of ``data`` with ``options`` (the method chosen by :func:`resolve_method` when None)."""
    options.check()
    o = resolve_method(options, data)
    method_options = {} if o.generations is None else {"generations": o.generations}
    sections = o.sections
    if sections is not None and data.rows is not None:
        sections = _sections_on_file_rows(sections, data.rows, o.method)
    if sections is None and o.method == "ferraris":
        from .ferraris import sections_from_labels

        sections = sections_from_labels(data.labels)
    try:
        res = _calibrate_data(data, o, sections, method_options, source)
    except OptinavError as exc:
        swap = swapped_triads(data.acc, data.gyr)
        if swap is not None and not isinstance(exc, SwappedAxes):  # the unit check names it already
            raise OptinavError(f"{exc.cause} ({swap})", "swap the triads' columns (--columns)") from exc
        if data.counter_step > 1 and o.rate_hz and _passes_at_row_rate(data, o, sections, method_options, source):
            k, r = data.counter_step, o.rate_hz
            raise OptinavError(
                f"the sample counter steps by {k} on nearly every row, so --rate {r:g} was taken as its rate and the "
                f"rows as {r / k:.4g} Hz; timed so, the calibration fails ({exc.cause}), with the rows at {r:g} Hz "
                "it passes its gates",
                f"if {r:g} Hz is the rate of the rows, pass --rate {r * k:g}",
            ) from exc
        if data.counter_step > 1 and o.rate_hz and not isinstance(exc, SwappedAxes):
            # the note that says how the rows were timed is lost with the error (a decimated annotated session at
            # --rate 51.2, its rows' rate, refused for its turns at 12.8 Hz without a word of the counter)
            k, r = data.counter_step, o.rate_hz
            raise OptinavError(
                f"{exc.cause} (the sample counter steps by {k} on nearly every row, so --rate {r:g} was taken as its "
                f"rate and the rows as {r / k:.4g} Hz)",
                f"{exc.remedy}; if {r:g} Hz is the rate of the rows, pass --rate {r * k:g}" if exc.remedy else None,
            ) from exc
        raise
    res.quality["notes"] = list(data.notes) + list(res.quality.get("notes", []))
    return res if o.hold_out is None else hold_out(data, o, res, o.hold_out, source)


#: an "accelerometer" whose norm varies above SWAP_CV_ACC (gates.STEADY_NORM_CV: an accelerometer's stays within
#: a few %, a gyro's is above 1) with a "gyro" SWAP_RATIO times steadier is the other way round
SWAP_CV_ACC = gates.STEADY_NORM_CV
SWAP_RATIO = 5.0


def swapped_triads(acc, gyr) -> str | None:
    """Words naming the triads as swapped when the accelerometer columns vary in norm like a gyro's and the gyro
    columns hold a steady norm like an accelerometer's, else None (raw counts show no unit to tell them apart).

    Parameters
    ----------
    acc, gyr : (N, 3) arrays or None
        The columns read as accelerometer and gyroscope [any unit].

    Returns
    -------
    str or None
        The words, or None.
    """
    if acc is None or gyr is None or len(acc) < 10:
        return None

    def cv(x):
        n = np.linalg.norm(np.asarray(x, float), axis=1)
        n = n[np.isfinite(n)]
        return float(np.std(n) / np.mean(n)) if n.size > 9 and np.mean(n) > 0 else float("nan")

    ca, cg = cv(acc), cv(gyr)
    if not (ca > SWAP_CV_ACC and ca > SWAP_RATIO * cg):
        return None
    return (
        f"the accelerometer columns' norm varies by {ca:.0%} like a gyro's over rests and turns, the gyroscope "
        f"columns' by {cg:.1%} like an accelerometer's reading g: are the two triads swapped?"
    )


def _passes_at_row_rate(data: SessionData, o: FileOptions, sections, method_options, source) -> bool:
    """Whether the calibration passes its gates with the rows of a decimated log (``data.counter_step`` k > 1)
    timed at --rate instead of at --rate / k: the counter's reading of --rate failed, and this tells an
    ambiguous rate (a gyro scale k× its nominal was named "raw counts?" or a turn angle) from another cause."""
    t = data.t[0] + (data.t - data.t[0]) / data.counter_step
    try:
        _calibrate_data(data._replace(t=t), o, sections, method_options, source)
    except OptinavError:
        return False
    return True


def _calibrate_data(data: SessionData, o: FileOptions, sections, method_options, source) -> CalibrationResult:
    return calibrate(
        data.t,
        data.acc,
        data.gyr,
        acc_unit=data.acc_unit,
        gyro_unit=data.gyro_unit or "rad/s",
        g=o.gravity,
        lat=None if o.lat_deg is None else np.radians(o.lat_deg),
        height_m=o.height_m,
        method=o.method,
        model_form=o.model,
        data="samples" if o.fit_samples else "means",
        sections=sections,
        window_s=o.window,
        min_duration_s=o.min_duration,
        threshold=o.threshold,
        acc_range=o.acc_range,
        gyro_range=o.gyro_range,
        gyro_bias=o.gyro_bias,
        rng=o.seed,
        source=source,
        method_options=method_options,
        rest=o.rest,
        allow_unobservable=o.allow_unobservable,
        rotation_angle=np.radians(o.rotation_angle),
        pose_alignment=np.radians(o.pose_alignment),
        acc_bias_instability=o.acc_bias_instability,
        held_misalignment=o.held_misalignment,
        gyro_g_sensitivity=o.gyro_g_sensitivity,
        gyro_bias_instability=o.gyro_bias_instability,
        gyro_bias_corr_time=o.gyro_bias_corr_time,
        gyr_clock=data.gyr_clock,
    )


def hold_out(
    data: SessionData, options: FileOptions, res: CalibrationResult, k: int, source: str = ""
) -> CalibrationResult:
    """Refit without static pose ``k`` of ``res`` and check the calibration on it (an out-of-sample check).

    Parameters
    ----------
    data : SessionData
        The session ``res`` was fitted to.
    options : FileOptions
        Its options.
    res : CalibrationResult
        The fit on every pose.
    k : int
        The pose left out, 1-based in time order.
    source : str
        The data's name, for the result.

    Returns
    -------
    CalibrationResult
        The refit, with ``quality["held_out"]``: ``pose``, ``t0_s``/``t1_s`` [s], ``norm_error_m_s2`` (|corrected
        mean specific force| − g at the held-out pose [m/s^2]), ``n_used`` and ``rms_used_m_s2`` (the same over the
        poses used [m/s^2]).
    """
    poses = np.asarray(res.static_intervals, float)
    if options.method == "ferraris":
        raise OptinavError(
            "--hold-out needs a norm-model fit; the ferraris method uses its 9 named sections",
            "drop --hold-out or use another --method",
        )
    if not 1 <= k <= len(poses):
        raise OptinavError(f"--hold-out {k}: the log has {len(poses)} static poses", f"pass K from 1 to {len(poses)}")
    fit = calibrate_data(
        data,
        dataclasses.replace(options, hold_out=None, sections=[tuple(p) for i, p in enumerate(poses) if i != k - 1]),
        source=source,
    )

    def error(t0: float, t1: float) -> float:
        inside = (data.t >= t0) & (data.t <= t1)
        return float(np.linalg.norm(fit.correct_accel(data.acc[inside].mean(axis=0, keepdims=True))[0]) - fit.gravity)

    used = np.array([error(*p) for p in fit.static_intervals])
    fit.quality["held_out"] = {
        "pose": k,
        "t0_s": float(poses[k - 1, 0]),
        "t1_s": float(poses[k - 1, 1]),
        "norm_error_m_s2": error(*poses[k - 1]),
        "n_used": int(used.size),
        "rms_used_m_s2": float(np.sqrt(np.mean(used**2))),
    }
    return fit


def calibrate_file(path, options: FileOptions | None = None) -> CalibrationResult:
    """Read ``path`` and calibrate it (what ``optinav calibrate accel`` does, without writing files)."""
    options = FileOptions() if options is None else options
    options.check()
    return calibrate_data(read_session_file(path, options), options, source=str(path))
