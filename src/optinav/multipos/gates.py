"""Quality gates of a multi-position calibration: a fit that fails one ends in a one-line error, never a result.

After each fit (:mod:`optinav.multipos.calibrate`):

* **distinct poses** — poses whose gravity directions lie within :data:`SAME_POSE_DEG` of each other count
  once in the rank test (a pose repeated after a 360° turn adds noise averaging, not a new direction), so the
  misalignments are judged observable only from ≥ 9 distinct directions that determine them;
* **convergence** — the optimizer reports success (an evaluation limit hit is a failure);
* **residual** — the pose residual RMS is within :data:`MAX_RESIDUAL_G` × g: a larger one means motion in a
  "static" interval or data that no ellipsoid fits (the within-pose noise already inflates the std); the gyro's
  turn residuals within :data:`MAX_GYRO_RESIDUAL_RAD`, and in the accelerometer frame's directions within what the
  noise and the frame's error (held misalignments at their --held-misalignment 1σ) predict
  (:func:`optinav.multipos.calibrate._gyro_frame_gate`, p = 10⁻⁴); an excess below that widens the gyro std;
* **plausibility** — diagonal scales within ×:data:`SCALE_FACTOR` of the nominal scale of the declared unit
  (×:data:`ACC_SCALE_FACTOR` for an accelerometer in m/s², g or mg: beyond it raw counts were read as that unit;
  ×:data:`GYRO_SCALE_FACTOR` for a gyroscope in deg/s or rad/s: beyond it the time base is wrong),
  couplings ``|K_ij|/K_ii`` ≤ :data:`MAX_COUPLING`, corrected pose directions within :data:`MAX_TURN_DEG` of
  the raw ones (no axis swap or sign flip), and for the gyroscope a K close to a positive diagonal; when it is
  close to a signed axis permutation instead, :func:`axis_permutation` names it (48 signed permutations).

Units are checked against physics: the rest norm of the accelerometer in the declared unit must be near g
(:func:`check_acc_unit`), and the gyro scale near 1 in the declared unit (a factor 57.3 is a deg/rad mix-up).
"""

from __future__ import annotations

import itertools

import numpy as np

from optinav.core.units import DEG, GRAVITY_OUT, GRAVITY_OUT_REMEDY, factor
from optinav.core.rotations import describe_permutation  # noqa: F401 - its home before core
from optinav.errors import OptinavError, SwappedAxes

#: poses closer than this (degrees) count as one direction in the rank test
SAME_POSE_DEG = 10.0
#: largest accepted RMS of the pose residuals |a| − g, as a fraction of g
MAX_RESIDUAL_G = 0.01
#: diagonal scale factors must lie within nominal/SCALE_FACTOR … nominal·SCALE_FACTOR
SCALE_FACTOR = 1.5
#: a gyro declared in a physical unit (deg/s, rad/s) reads its rate to a few % (datasheet sensitivity tolerance);
#: a diagonal scale outside nominal/GYRO_SCALE_FACTOR … nominal·GYRO_SCALE_FACTOR means a wrong time base
#: (--rate, --time-unit) or turn angle, which scale the integrated turns, not the sensor
GYRO_SCALE_FACTOR = 1.15
#: an accelerometer declared in a physical unit (m/s², g, mg) reads g to a few % (sensitivity tolerance ±1–5 %);
#: a diagonal scale outside nominal/ACC_SCALE_FACTOR … nominal·ACC_SCALE_FACTOR is raw counts read as that unit
#: (an ADIS16470's 800 per g declared mg: 0.82×, which calibrated with exit 0) or a wrong conversion upstream
ACC_SCALE_FACTOR = 1.15
#: largest accepted |K_ij| / K_ii (misalignment or cross-coupling, rad)
MAX_COUPLING = 0.2
#: largest accepted angle (degrees) between a corrected pose direction and its raw direction
MAX_TURN_DEG = 20.0
#: largest accepted RMS (rad) of the gyro transition residuals (angle between carried and measured gravity)
MAX_GYRO_RESIDUAL_RAD = 0.05
#: accelerometer rest norm / g outside 1/UNIT_TOL … UNIT_TOL is a unit error
UNIT_TOL = 1.3
#: gyro turn angle (perpendicular to gravity, declared unit) / gravity-direction change outside
#: 1/TURN_UNIT_TOL … TURN_UNIT_TOL is a unit error (geometry alone gives 1 … π/2 for turns up to 180°)
TURN_UNIT_TOL = 2.5
#: transitions whose gravity direction changes by less than this (degrees) are not used in the turn check
MIN_TURN_DEG = 20.0
#: a transition whose gyro rotation is within this many noise σ of zero saw no turn
NO_TURN_SIGMA = 5.0

_ACC_UNITS = ("m/s^2", "g", "mg")
_GYRO_UNITS = ("rad/s", "deg/s", "mdps")


def distinct_directions(dirs, tol: float = float(np.radians(SAME_POSE_DEG))) -> np.ndarray:
    """Cluster label (P,) of each direction (P, 3): greedy, a direction joins the first cluster whose first
    member is within ``tol`` (rad); labels count 0, 1, … in order of first appearance."""
    d = np.asarray(dirs, float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    cos_tol = np.cos(tol)
    reps: list[np.ndarray] = []
    labels = np.empty(len(d), int)
    for k, u in enumerate(d):
        for j, r in enumerate(reps):
            if u @ r >= cos_tol:
                labels[k] = j
                break
        else:
            labels[k] = len(reps)
            reps.append(u)
    return labels


def nominal_acc_scale(unit: str, rest_norm: float, g: float) -> float:
    """Nominal K_ii (raw per m/s²) of an accelerometer in ``unit``; for counts, the median rest norm / g."""
    return rest_norm / g if unit == "counts" else 1.0 / factor(unit)


#: how far from g a rest norm in a physical unit (g, mg, m/s²) may read when that unit is guessed for an undeclared
#: one: a sensor in such a unit reads g within a few % (uncalibrated MEMS scale tolerance ±3 %); farther, raw counts
#: are named first
PHYSICAL_SCALE_TOL = 0.1

#: a raw accelerometer reads g as more counts than this (8-bit at ±16 g: 8); a norm at rest below it that no unit
#: makes g is an acceleration with gravity taken out
FEW_COUNTS = 5.0


def check_acc_unit(rest_norm: float, unit: str, g: float, option: str = "--acc-unit", gyr=None) -> None:
    """One-line error when the rest norm (in ``unit``) contradicts g: names the likely unit; when that is raw
    counts and the gyroscope columns ``gyr`` (read in a physical unit) hold whole numbers too, names their flag as well."""
    if unit == "counts" or not np.isfinite(rest_norm):
        return
    si = rest_norm * factor(unit)
    if 1 / UNIT_TOL < si / g < UNIT_TOL:
        return
    likely = [u for u in _ACC_UNITS if 1 / UNIT_TOL < rest_norm * factor(u) / g < UNIT_TOL]
    if not likely and si < g / UNIT_TOL and rest_norm < FEW_COUNTS:
        raise OptinavError(
            f"the accelerometer reads {rest_norm:.4g} {unit} at rest ({si:.4g} m/s^2, g = {g:.5g}): no unit makes "
            f"that g and it is too small for counts; {GRAVITY_OUT}",
            GRAVITY_OUT_REMEDY,
        )
    guess = likely[0] if likely else "counts"
    what, remedy = ("raw counts?" if guess == "counts" else f"data in {guess}?"), f"pass {option} {guess}"
    off = 0.0 if guess == "counts" else abs(rest_norm * factor(guess) / g - 1.0)
    if off > PHYSICAL_SCALE_TOL:
        # a sensor in a physical unit reads g within a few %: 800 (an ADIS16470's counts per g) as mg is 0.82 g
        what = (
            f"raw counts? ({rest_norm:.4g} per g; read as {guess} it would be {rest_norm * factor(guess) / g:.3g} g, "
            f"{off:.0%} off)"
        )
        remedy = f"pass {option} counts (or {option} {guess} if the data are in {guess})"
    if guess == "counts" and _whole_numbers(gyr):
        # the gyro's unit check comes only after the fit: one more run to learn what the file already shows
        remedy += "; the gyroscope columns hold whole numbers too: if they are counts, add --gyro-unit counts"
    raise OptinavError(
        f"the accelerometer reads {rest_norm:.4g} {unit} at rest ({si:.4g} m/s^2, g = {g:.5g}): {what}", remedy
    )


def _whole_numbers(x, rows: int = 10_000) -> bool:
    """Whether the finite values of the first ``rows`` rows of ``x`` are whole numbers, not all within ±1."""
    if x is None:
        return False
    v = np.asarray(x[:rows], float)
    v = v[np.isfinite(v)]
    return v.size > 0 and bool(np.all(v == np.round(v))) and float(np.max(np.abs(v))) > 1


#: coefficient of variation of an accelerometer's norm over a calibration log: it reads g in every pose and
#: stays within a few % during hand turns (imucal's sessions: 0.04, 0.08); a gyro's is above 1 (rest against turns)
STEADY_NORM_CV = 0.2


def check_swapped_triads(acc_norm: float, acc_unit: str, gyro_norm: float, g: float, gyro_cv: float = 0.0) -> None:
    """One-line error when the accelerometer columns do not read g but the gyroscope columns would, in the
    accelerometer's unit, with a steady norm (``gyro_cv``, std/mean of their norms, ≤ STEADY_NORM_CV) like an
    accelerometer's (median norms in the columns' raw units): the two triads are swapped (the unit errors that
    would follow led from --acc-unit counts to a fit that did not converge). A gyro in raw counts whose rest
    reading happens to be near g's number varies like a gyro over the turns: not a swap (its unit is named next)."""
    if 1 / UNIT_TOL < acc_norm * factor(acc_unit) / g < UNIT_TOL or not gyro_cv <= STEADY_NORM_CV:
        return
    if 1 / UNIT_TOL < gyro_norm * factor(acc_unit) / g < UNIT_TOL:
        raise SwappedAxes(
            f"the accelerometer columns read {acc_norm:.4g} {acc_unit} and the gyroscope columns {gyro_norm:.4g} "
            "(median norms): the two triads look swapped",
            "check the column order (--columns t,ax,ay,az,gx,gy,gz; for HDF5/MAT/NPZ --datasets acc=NAME,gyro=NAME)",
        )


#: an axis whose pose means span less than this share of the widest axis's span is hardly turned by the poses:
#: its scale and bias cannot be told apart (a good session turns each axis up and down, a span of 2 g each)
MIN_AXIS_SPAN = 0.25


def _narrow(span: np.ndarray) -> list[int]:
    """The axes whose span of pose means is below :data:`MIN_AXIS_SPAN` of the widest axis's (none when no span)."""
    top = float(span.max())
    return [j for j in range(3) if span[j] < MIN_AXIS_SPAN * top] if top > 0 else []


def narrow_axes(means) -> str | None:
    """Words naming the axes that the poses hardly turn (span of the pose means (P, 3), raw units, below
    :data:`MIN_AXIS_SPAN` of the widest axis's span; an offset such as an unsigned ADC's cancels), or None."""
    m = np.asarray(means, float)
    span = np.ptp(m, axis=0) if m.shape[0] else np.zeros(3)
    if not np.all(np.isfinite(span)):
        return None
    narrow = _narrow(span)
    if not narrow:
        return None
    rel = span / span.max()
    return "the poses hardly turn the " + ", ".join(
        f"{'xyz'[j]} axis (its pose means span {rel[j]:.2g}× the {'xyz'[int(np.argmax(span))]} axis's)" for j in narrow
    )


def swapped_axis(acc_means, gyr_means) -> str | None:
    """Words naming an accelerometer axis and a gyro axis whose columns look swapped, or None: across the static
    poses (means (P, 3), raw units) the accelerometer axis hardly varies (below :data:`MIN_AXIS_SPAN` of its
    widest axis) while one gyro axis varies at least a third as widely as that and 20 times more than the other
    gyro axes — gravity's projection read through the gyro's column (a gyro at rest reads its bias and the Earth
    rate in every pose). acc_x and gyr_x swapped was told the poses hardly turn x, or disagree on g (probe)."""
    if gyr_means is None:
        return None
    a, w = np.asarray(acc_means, float), np.asarray(gyr_means, float)
    if a.shape[0] < 2 or w.shape != a.shape or not (np.all(np.isfinite(a)) and np.all(np.isfinite(w))):
        return None
    sa, sw = np.ptp(a, axis=0), np.ptp(w, axis=0)
    top = float(sa.max())
    narrow = _narrow(sa)
    k = int(np.argmax(sw))
    if len(narrow) != 1 or sw[k] < top / 3 or sw[k] < 20 * np.sort(sw)[-2]:
        return None
    j = narrow[0]
    return (
        f"the accelerometer's {'xyz'[j]} and the gyroscope's {'xyz'[k]} columns look swapped: across the poses the "
        f"gyro's {'xyz'[k]} varies {sw[k] / top:.2g}× as widely as the accelerometer's widest axis, as gravity "
        f"would, while the accelerometer's {'xyz'[j]} hardly varies"
    )


def signed_permutations() -> list[np.ndarray]:
    """The 48 signed axis permutations (3×3, one ±1 per row and column), the identity first."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            P = np.zeros((3, 3))
            P[range(3), perm] = signs
            out.append(P)
    return out


def axis_permutation(K) -> tuple[np.ndarray, float]:
    """The signed axis permutation P (3×3, one ±1 per row and column; 48 of them) closest to K up to a positive
    scale per row, and how much of K it explains (Σ|K_i,p(i)| / Σ|K_ij|, 1 for an exact permutation)."""
    K = np.asarray(K, float)
    A = np.abs(K) / np.maximum(np.abs(K).max(axis=1, keepdims=True), np.finfo(float).tiny)
    best, score = np.eye(3), -np.inf
    for perm in itertools.permutations(range(3)):
        s = sum(A[i, perm[i]] for i in range(3))
        if s > score:
            score, best = s, perm
    P = np.zeros((3, 3))
    for i, j in enumerate(best):
        P[i, j] = np.sign(K[i, j]) or 1.0
    return P, float(sum(abs(K[i, best[i]]) for i in range(3)) / np.abs(K).sum())


def check_matrix(
    K,
    nominal: float | None,
    sensor: str,
    unit: str,
    *,
    option: str,
    columns_flag: str,
    time_flags: str = "--rate, --time-unit",
) -> None:
    """Plausibility of a fitted K (raw per SI unit): diagonal positive and within ×SCALE_FACTOR of ``nominal``
    (None: not checked; a gyroscope in deg/s or rad/s within ×GYRO_SCALE_FACTOR, else ``time_flags`` are
    named), couplings ≤ MAX_COUPLING; a K close to a signed axis permutation is named as such."""
    K = np.asarray(K, float)
    d = np.diag(K)
    coupling = np.abs(K - np.diag(d)) / np.maximum(np.abs(d)[:, None], np.finfo(float).tiny)
    if np.any(d <= 0) or np.any(coupling > MAX_COUPLING):
        P, share = axis_permutation(K)
        if share > 0.8 and not np.allclose(P, np.eye(3)):
            raise SwappedAxes(
                (
                    f"the {sensor} axes look swapped or flipped against the accelerometer's: "
                    if sensor != "accelerometer"
                    else "the accelerometer axes look swapped or flipped against the poses' order: "
                )
                + f"{describe_permutation(P, sensor, 'accelerometer frame')}",
                f"fix the column order or signs ({columns_flag})",
            )
        i, j = np.unravel_index(int(np.argmax(np.where(np.isfinite(coupling), coupling, np.inf))), (3, 3))
        raise OptinavError(
            f"the {sensor} fit is implausible: K_{'xyz'[i]}{'xyz'[j]}/K_{'xyz'[i]}{'xyz'[i]} = "
            f"{coupling[i, j]:.3g} (> {MAX_COUPLING:g}) or a non-positive scale "
            f"(diagonal {', '.join(f'{v:.4g}' for v in d)})",
            f"check the static intervals (--threshold, --sections) and the column order ({columns_flag})",
        )
    if nominal is None:
        return
    ratio = d / nominal
    bad = (ratio > SCALE_FACTOR) | (ratio < 1 / SCALE_FACTOR)
    if sensor == "gyroscope" and unit in _GYRO_UNITS and not np.any(bad):
        off = (ratio > GYRO_SCALE_FACTOR) | (ratio < 1 / GYRO_SCALE_FACTOR)
        if np.any(off):
            k = int(np.flatnonzero(off)[0])
            raise OptinavError(
                f"the gyroscope scale K_{'xyz'[k]}{'xyz'[k]} is {ratio[k]:.3g}× its nominal value in {unit} "
                f"(diagonal {', '.join(f'{r:.3g}' for r in ratio)}×; a gyro reads within "
                f"×{GYRO_SCALE_FACTOR:g}): the turns were integrated over a wrong time base or angle",
                f"check the sample rate or time column ({time_flags})",
            )
        return
    if sensor == "accelerometer" and unit in _ACC_UNITS and not np.any(bad):
        off = (ratio > ACC_SCALE_FACTOR) | (ratio < 1 / ACC_SCALE_FACTOR)
        if np.any(off):
            k = int(np.flatnonzero(off)[0])
            per_g = float(np.median(d)) * 9.80665
            raise OptinavError(
                f"the accelerometer scale K_{'xyz'[k]}{'xyz'[k]} is {ratio[k]:.3g}× its nominal value in {unit} "
                f"(diagonal {', '.join(f'{r:.3g}' for r in ratio)}×; an accelerometer reads g within "
                f"×{ACC_SCALE_FACTOR:g}): not data in {unit} — raw counts ({per_g:.4g} per g) or a wrong conversion",
                f"pass {option} counts (it also takes a sensor whose scale is truly that far off)",
            )
        return
    if not np.any(bad):
        return
    if sensor == "gyroscope":
        r = float(np.median(d))
        likely = [u for u in _GYRO_UNITS if u != unit and 1 / SCALE_FACTOR < r * factor(u) < SCALE_FACTOR]
        if likely:
            raise OptinavError(
                f"the gyroscope scale is {float(np.median(ratio)):.3g}× its nominal value in {unit}: "
                f"the data look like {likely[0]}",
                f"pass {option} {likely[0]}",
            )
        # more than TURN_UNIT_TOL raw per deg/s: no SI unit is that coarse (data declared counts already are: one
        # axis off the others' scale then told "raw counts?; pass --gyro-unit counts", probe)
        if unit != "counts" and r * factor("deg/s") > TURN_UNIT_TOL:
            raise OptinavError(
                f"the gyroscope scale is {float(np.median(ratio)):.3g}× its nominal value in {unit}: "
                f"raw counts? ({r * factor('deg/s'):.3g} per deg/s)",
                f"pass {option} counts (and --gyro-range if the full scale is not the integer type's)",
            )
    k = int(np.flatnonzero(bad)[0])
    raise OptinavError(
        f"the {sensor} scale K_{'xyz'[k]}{'xyz'[k]} = {d[k]:.4g} raw per SI unit is {ratio[k]:.3g}× "
        f"its nominal value {nominal:.4g} in {unit} (accepted ×{1 / SCALE_FACTOR:.2g}…×{SCALE_FACTOR:g})",
        f"check {option}"
        + (
            f", the time base ({time_flags}: a wrong one scales K by its factor)"
            if sensor == "gyroscope" and unit in _GYRO_UNITS
            else ""
        )
        + " and the static intervals (--threshold, --sections)"
        + (", or use --model diagonal" if sensor == "accelerometer" else ""),
    )


def check_gyro_turns(theta_perp, alpha, noise, t0, t1, unit: str, option: str = "--gyro-unit") -> None:
    """The gyro's view of each turn against the accelerometer's, before any gyro fit.

    ``theta_perp`` (T,): raw rotation of each transition perpendicular to gravity (raw·s, bias removed),
    ``alpha`` (T,): the gravity-direction change between the two poses (rad), ``noise`` (T,): 1σ of
    ``theta_perp`` from the gyro's rest noise, ``t0``/``t1``: transition start/end times (s). A transition that
    moves gravity by ≥ :data:`MIN_TURN_DEG` while the gyro sees no turn (within :data:`NO_TURN_SIGMA` σ) means a
    log cut between poses or rows out of time order. In a physical ``unit`` the median ratio of turn angle to
    gravity change must lie within ×:data:`TURN_UNIT_TOL` of 1; a factor 57.3 names deg/s vs rad/s, others raw
    counts (a unit in counts has no nominal scale, so only the first test applies)."""
    theta_perp, alpha = np.asarray(theta_perp, float), np.asarray(alpha, float)
    big = alpha >= np.radians(MIN_TURN_DEG)
    still = big & (theta_perp < NO_TURN_SIGMA * np.asarray(noise, float))
    if np.any(still):
        k = np.flatnonzero(still)
        when = ", ".join(f"{t0[i]:.4g}–{t1[i]:.4g} s ({np.degrees(alpha[i]):.0f}°)" for i in k[:3])
        raise OptinavError(
            f"in {k.size} of {alpha.size} transitions gravity moves between the poses but the "
            f"gyroscope sees no turn ({when}{', …' if k.size > 3 else ''}): the log is cut between "
            "the poses, or its rows are not in time order",
            "for a file of cut Ferraris sections use --method ferraris (sections from a label column "
            "or --sections), or --no-gyro; else check the time column (--rate, --time-unit) and the "
            "row order",
        )
    use = big & ~still
    if unit == "counts" or np.count_nonzero(use) < 2:
        return
    k_raw = float(np.median(theta_perp[use] / alpha[use]))  # raw units per rad/s of turn rate
    ratio = k_raw * factor(unit)
    if 1 / TURN_UNIT_TOL <= ratio <= TURN_UNIT_TOL:
        return
    likely = [u for u in _GYRO_UNITS if u != unit and 1 / TURN_UNIT_TOL <= k_raw * factor(u) <= TURN_UNIT_TOL]
    what = f"the data look like {likely[0]}" if likely else f"raw counts? ({k_raw * DEG:.3g} per deg/s)"
    cause = (
        f"the gyroscope turns {ratio:.3g}× as far as gravity does between the poses in {unit} (median of "
        f"{np.count_nonzero(use)} turns, perpendicular to gravity): {what}"
    )
    raise OptinavError(
        cause,
        f"pass {option} {likely[0]}"
        if likely
        else f"pass {option} counts (and --gyro-range if the full scale is not the integer type's)",
    )
