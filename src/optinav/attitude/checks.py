"""Physics checks of attitude inputs before any estimate: time gaps, units, swapped triads, clipping, frame.

Each failed check ends in an :class:`OptinavError` naming the cause and the CLI flag that helps (no silently
wrong attitude); the frame check warns once (an upside-down start is possible).
"""

from __future__ import annotations

import functools
import itertools
import warnings
from dataclasses import dataclass, replace

import numpy as np

from optinav.attitude.methods import IFRAME_DEFAULTS
from optinav.core.rotations import frame_name
from optinav.core.units import G_STANDARD, factor
from optinav.core.validate import mask_runs
from optinav.errors import OptinavError

__all__ = [
    "find_gaps",
    "check_imu",
    "check_aop",
    "check_frame",
    "check_mag",
    "FrameWarning",
    "MagnetometerWarning",
    "TimeBaseWarning",
    "ClippingWarning",
]

#: a step this many times the median step (and longer than MIN_GAP_S) is a gap
GAP_FACTOR = 5.0
MIN_GAP_S = 0.5


class FrameWarning(UserWarning):
    """The accelerometer at rest contradicts the chosen navigation frame."""


class MagnetometerWarning(UserWarning):
    """The magnetometer's field norm follows the orientation: an uncalibrated (hard-iron) magnetometer."""


class TimeBaseWarning(UserWarning):
    """The gyro holds gravity best a few percent off its declared time base: the rate, the time column or the
    gyro's scale may be off by that much."""


class ReferenceWarning(UserWarning):
    """A reference orientation that looks stored in another quaternion order."""


#: [x, y, z, w] read as [w, x, y, z]: the reference's columns in the order that undoes it
XYZW = [3, 0, 1, 2]


def warn_reference_order(rmse: float, rmse_xyzw: float) -> None:
    """Warn once when the inclination against the reference is far off (> 20°) yet within a quarter of that, and
    below 5°, with its quaternions read as [x, y, z, w] (scipy's order) instead of [w, x, y, z]."""
    if rmse > np.radians(20.0) and rmse_xyzw < min(0.25 * rmse, np.radians(5.0)):
        warnings.warn(
            f"the reference scores {np.degrees(rmse):.3g}° inclination RMSE but {np.degrees(rmse_xyzw):.3g}° read "
            "as [x, y, z, w]: its quaternions look stored scalar-last; reorder them to [w, x, y, z] (BROAD's "
            "opt_quat order)",
            ReferenceWarning,
            stacklevel=2,
        )


#: the reference's turn over windows of REF_TURN_WINDOW_S [s] is compared with the gyro's where the gyro turns faster
#: than REF_TURN_MIN_RATE [rad/s]; more than REF_TURN_SHARE of at least REF_TURN_MIN_WINDOWS such windows over
#: REF_TURN_OFF [rad] apart: the reference is not q_b^n of this log. The nine BROAD trials: median 0.9-2.8°, at most
#: 0.4 % of the windows over 30°; their opt_quat stored [x, y, z, w] or conjugated (q_n^b): median 95° and 172°, all
#: windows over 30° (and scored 14° and 11° of inclination, status ok)
REF_TURN_WINDOW_S = 0.035
REF_TURN_MIN_RATE = 1.0
REF_TURN_OFF = np.radians(30.0)
REF_TURN_SHARE = 0.5
REF_TURN_MIN_WINDOWS = 100
#: still samples (|ω| below REF_STILL_RATE [rad/s], ||a| − g| below REF_STILL_ACC [m/s²]) compare the reference's
#: vertical with the accelerometer's (the nine trials: median 0.3-0.4°, at most 1.6 % over 10°); a NED truth
#: scored as ENU is 180° off and scored 175° of inclination RMSE with exit 0 (its STEM.truth.json left out)
REF_STILL_RATE = 0.1
REF_STILL_ACC = 0.5


class ReferenceTurns:
    """Whether a reference orientation turns as the gyroscope does, accumulated over blocks of a log: :meth:`add`
    each block, then :meth:`check` (a reference stored in another quaternion order, conjugated or of another log
    scores a wrong but plausible inclination RMSE; the heading and vertical at rest may not show it)."""

    #: the reference as given, conjugated (q_n^b), read as [x, y, z, w]
    READINGS = ("as given", "conjugate", "xyzw")

    def __init__(self, frame: str | None = None):
        self.n = 0
        self.off = np.zeros(len(self.READINGS), dtype=np.int64)
        self.frame = None if frame is None else frame_name(frame)
        self.still = self.tilted = 0  # still samples; those whose reference vertical is off the accelerometer's

    def add(self, q_ref, gyr, dts, acc=None) -> None:
        """One block: ``q_ref`` (n, 4) q_b^n [-] (NaN rows: no reference), ``gyr`` (n, 3) rad/s, ``dts`` (n,) the
        step before each sample [s]; with ``acc`` (n, 3) m/s² and the filter's ``frame``, the reference's vertical
        is compared with the accelerometer's where the body is still."""
        from optinav.core.rotations import quat_conjugate, quat_multiply, rotvec_from_quat

        if acc is not None and self.frame is not None:
            self._vertical(q_ref, gyr, acc)
        q = np.asarray(q_ref, float)
        h = np.asarray(dts, float)
        good = h[np.isfinite(h) & (h > 0)]
        if not good.size:
            return
        step = float(np.median(good))
        lag = max(1, int(round(REF_TURN_WINDOW_S / step)))
        if q.shape[0] <= lag + 1:
            return
        c = np.cumsum(np.vstack([np.zeros(3), np.asarray(gyr, float) * h[:, None]]), axis=0)
        turn = c[lag + 1 :] - c[1:-lag]  # the gyro's turn from sample i to i + lag
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
        q0, q1 = q[:-lag], q[lag:]
        fast = np.isfinite(q0).all(axis=1) & np.isfinite(q1).all(axis=1) & np.isfinite(turn).all(axis=1)
        fast &= np.linalg.norm(turn, axis=1) > REF_TURN_MIN_RATE * lag * step
        if not np.any(fast):
            return
        g = turn[fast] / np.linalg.norm(turn[fast], axis=1, keepdims=True)
        for j, (a, b) in enumerate(((q0, q1), (quat_conjugate(q0), quat_conjugate(q1)), (q0[:, XYZW], q1[:, XYZW]))):
            r = rotvec_from_quat(quat_multiply(quat_conjugate(a[fast]), b[fast]))
            nr = np.linalg.norm(r, axis=1)
            cos = np.sum(r * g, axis=1) / np.where(nr > 0, nr, 1.0)
            self.off[j] += int(np.count_nonzero((nr == 0) | (cos < np.cos(REF_TURN_OFF))))
        self.n += int(np.count_nonzero(fast))

    def _vertical(self, q_ref, gyr, acc) -> None:
        from optinav.attitude.measurement import up_vector
        from optinav.core.rotations import quat_conjugate, quat_rotate

        q, a = np.asarray(q_ref, float), np.asarray(acc, float)
        na = np.linalg.norm(a, axis=1)
        still = np.isfinite(q).all(axis=1) & (np.linalg.norm(gyr, axis=1) < REF_STILL_RATE)
        still &= np.abs(na - G_STANDARD) < REF_STILL_ACC
        if not np.any(still):
            return
        qs = q[still] / np.linalg.norm(q[still], axis=1, keepdims=True)
        up_b = quat_rotate(quat_conjugate(qs), up_vector(self.frame))  # where a resting accelerometer reads +g
        cos = np.sum(up_b * a[still], axis=1) / na[still]
        self.still += int(np.count_nonzero(still))
        self.tilted += int(np.count_nonzero(cos < np.cos(REF_TURN_OFF)))

    def check(self) -> None:
        """Raise :class:`OptinavError` when the reference turns unlike the gyroscope in most windows, or its vertical
        is not the accelerometer's in most still samples."""
        if self.still >= REF_TURN_MIN_WINDOWS and self.tilted > REF_TURN_SHARE * self.still:
            raise OptinavError(
                f"the reference orientation's vertical is more than {np.degrees(REF_TURN_OFF):.0f}° from the "
                f"accelerometer's in {100.0 * self.tilted / self.still:.0f} % of {self.still} still samples: it is "
                f"not q_b^n in the {self.frame.upper()} frame (another navigation frame, or of other sensor axes)",
                "estimate in the reference's frame (--frame), or keep the simulator's STEM.truth.json, which names "
                "it, beside STEM.truth.csv",
            )
        if self.n < REF_TURN_MIN_WINDOWS or self.off[0] <= REF_TURN_SHARE * self.n:
            return
        share = 100.0 * self.off[0] / self.n
        fits = [k for k in (1, 2) if self.off[k] <= REF_TURN_SHARE * self.n * 0.1]
        why = {1: "it looks conjugated (q_n^b, navigation -> body)", 2: "it looks stored scalar-last [x, y, z, w]"}
        cause = "; ".join(why[k] for k in fits) or "it is not q_b^n of this log's sensor axes, or not time-aligned"
        raise OptinavError(
            f"the reference orientation turns unlike the gyroscope: in {share:.0f} % of {self.n} windows of "
            f"{1e3 * REF_TURN_WINDOW_S:.0f} ms its turn is more than {np.degrees(REF_TURN_OFF):.0f}° from the gyro's, "
            f"so its RMSE would score nothing: {cause}",
            "store the reference as q_b^n [w, x, y, z] (body -> navigation, BROAD's opt_quat), or drop --reference",
        )


class InitialAttitudeWarning(UserWarning):
    """A given initial attitude q0 contradicts the vertical the accelerometer shows at the start."""


def check_q0(q0: np.ndarray, acc: np.ndarray, frame: str) -> None:
    """Warn once when ``q0`` (q_b^n, unit) tilts more than 30° from the vertical of the first 20 samples'
    specific force (when they are steady and read about g: a start at rest), naming [x, y, z, w] storage when
    that order fits within 10° (a scalar-last q0 tilted the start by 111° on a simulated flight, and gd kept 74°
    of it, silently)."""
    from optinav.attitude.measurement import up_vector
    from optinav.core.rotations import quat_conjugate, quat_rotate

    w = acc[: max(1, min(acc.shape[0], 20))]
    a = w.mean(axis=0)
    na = float(np.linalg.norm(a))
    # judged only on a start at rest: the first 20 samples steady and reading g (a start in motion tilts the body
    # within them — a right q0 was warned about by 34°)
    if not np.isfinite(na) or abs(na - G_STANDARD) > 0.1 * G_STANDARD or float(np.max(np.ptp(w, axis=0))) > 0.5:
        return
    up = up_vector(frame)

    def tilt(q):
        b = quat_rotate(quat_conjugate(np.asarray(q, float)), up)
        return float(np.degrees(np.arccos(np.clip(b @ a / na, -1.0, 1.0))))

    ang = tilt(q0)
    if ang <= 30.0:
        return
    alt = tilt(np.asarray(q0, float)[XYZW])
    warnings.warn(
        f"q0 tilts {ang:.0f}° from the vertical the accelerometer shows at the start"
        + (
            f"; read as [x, y, z, w] it fits within {alt:.0f}°: it looks stored scalar-last (scipy's order); "
            "reorder it to [w, x, y, z]"
            if alt < 10.0
            else "; check its frame and convention (q_b^n, [w, x, y, z])"
        ),
        InitialAttitudeWarning,
        stacklevel=5,  # estimate()'s caller (check_q0 < imu_checks < estimate < _timed)
    )


def gap_limit(step: float) -> float:
    """The longest step (s) that is no time gap, for a typical step ``step`` (s): GAP_FACTOR × it, at least
    MIN_GAP_S."""
    return max(GAP_FACTOR * step, MIN_GAP_S)


#: rad: a step that lost samples (beyond LOST_STEPS typical steps, short of a gap by its length) across which the
#: gyro's turn is uncertain by more than this is refused unless gaps are allowed (then bridged: the tilt recovers
#: better than from a restart, the heading carries it). The rate changed across it by |Δω|, and the step integrated
#: at either end's rate differs by |Δω|·dt/2 (:func:`lost_turns`), about the error the estimate makes there: on
#: BROAD's nine, 57 samples (0.2 s) dropped in motion 4-53° in the median (a 0.2-s dropout in 07 ran at 157°
#: heading RMSE with exit 0), 10 samples (38 ms) 0.5-4°, 3 samples 0.06-0.5°
GAP_TURN = float(np.radians(2.0))


class LostSamplesWarning(UserWarning):
    """Samples lost where the gyro turned: bridged, the heading carries the uncertainty of the turn across them."""


def _turn_uncertainty(after: np.ndarray, before: np.ndarray, dts) -> np.ndarray:
    """rad: |ω_after − ω_before|·dt/2, the difference of a step integrated at either end's rate."""
    return _norm(after - before) * np.broadcast_to(dts, (after.shape[0],)) / 2.0


def lost_turns(gyr: np.ndarray, dts: np.ndarray, prev=None) -> np.ndarray:
    """rad per row: :func:`_turn_uncertainty` of ``gyr`` (n, 3) rad/s over its steps ``dts`` (n,) s (row 0 against
    ``prev`` (3,), else 0)."""
    g = np.asarray(gyr, float)
    before = np.concatenate([g[:1] if prev is None else np.asarray(prev, float).reshape(1, 3), g[:-1]])
    return _turn_uncertainty(g, before, dts)


def find_gaps(dts: np.ndarray) -> np.ndarray:
    """Indices i whose step dt[i] (from sample i−1, s) is a time gap: beyond :func:`gap_limit` of the median."""
    if dts.shape[0] < 3:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(dts > gap_limit(float(np.median(dts[1:]))))


def uncertain_steps(dts: np.ndarray, gyr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, rad): the steps ``dts`` (n,) s that lost samples (beyond LOST_STEPS of the median, no gap by
    :func:`find_gaps`) across which the turn of ``gyr`` (n, 3) rad/s is uncertain beyond :data:`GAP_TURN`, and that
    uncertainty (:func:`lost_turns`)."""
    if dts.shape[0] < 3 or gyr.shape[0] != dts.shape[0]:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    step = float(np.median(dts[1:]))
    k = np.flatnonzero((dts > LOST_STEPS * step) & (dts <= gap_limit(step)))
    k = k[k > 0]
    u = _turn_uncertainty(gyr[k], gyr[k - 1], dts[k])
    return k[u > GAP_TURN], u[u > GAP_TURN]


def gap_error(step_s: float, index: int, count: int) -> OptinavError:
    """The refusal of a recording with ``count`` time gaps, the first a step of ``step_s`` s before sample
    ``index``."""
    return OptinavError(
        f"time gap of {step_s:.3g} s before sample {index} ({count} gap(s)): integrating the gyro across it would "
        "be wrong",
        "pass --allow-gaps (allow_gaps=True) to restart the estimate after each gap",
    )


def lost_error(step_s: float, index: int, turns: np.ndarray) -> OptinavError:
    """The refusal of steps that lost samples where the turn across them is uncertain (``turns`` rad, the first a
    step of ``step_s`` s before sample ``index``; :func:`uncertain_steps`)."""
    return OptinavError(
        f"samples lost before sample {index} (a step of {step_s:.3g} s; {turns.size} such step(s)) where the gyro's "
        f"turn across them is uncertain by {np.degrees(turns[0]):.3g}° (up to {np.degrees(turns.max()):.3g}°): the "
        "heading after them would be off by about that",
        "pass --allow-gaps (allow_gaps=True) to bridge them (the tilt recovers; the heading carries their "
        "uncertainty), or log without dropouts",
    )


def lost_warning(turns: np.ndarray) -> None:
    """Say that steps which lost samples where the turn across them is uncertain (``turns`` rad) were bridged."""
    warnings.warn(
        f"{turns.size} step(s) that lost samples bridged where the gyro's turn across them is uncertain by up to "
        f"{np.degrees(turns.max()):.3g}° (in all {np.degrees(turns.sum()):.3g}°): the heading carries that",
        LostSamplesWarning,
        stacklevel=4,
    )


#: gyro unit factors tried against the declared unit (the check sees rad/s): ×π/180 (deg/s declared rad/s) and
#: ×180/π (rad/s declared deg/s)
_SCALES = {
    1.0: "",
    np.pi / 180: "deg/s declared rad/s: --gyro-unit deg/s",
    180 / np.pi: "rad/s declared deg/s: --gyro-unit rad/s",
}


@dataclass(frozen=True)
class UnitHint:
    """What the gyro-unit check found (:func:`gyro_unit_hint`): ``kind`` "unit" (a unit factor ``scale`` of π/180 or
    180/π), "time" (the gyro needs another ``scale``: the time steps or the gyro's scale are off by it) or "axes"
    (the signed permutation ``P``, at the unit factor ``scale``); ``scale`` multiplies the gyro as declared;
    ``words``: what was seen, for the message; ``rate_hz``: the sample rate the data imply for a "time" hint."""

    kind: str
    scale: float
    words: str = ""
    P: np.ndarray | None = None
    rate_hz: float = float("nan")
    #: the factor is only roughly known (a log too short for the 2-s means)
    rough: bool = False
    #: a few percent (SCALE_WARN or more) that the refusal's gates do not take: said, not refused (:func:`_few_percent`)
    warn: bool = False


#: a step longer than this many median steps has lost samples (the unit check judges the stretches between)
LOST_STEPS = 1.75

#: the shortest window (s) on which the gyro's unit is judged by how gravity turns (three of its 2-s means)
UNIT_MIN_S = 6.0

#: the largest constant gyro bias (rad/s, 5 °/s) the unit check allows for: a MEMS gyro's bias can drift gravity
#: in the gyro-integrated frame by tens of degrees over its window — as much as a wrong unit on a body that hardly
#: turns (BROAD trial 11 with 2 °/s on x: 0.20 rad, refused as deg/s declared rad/s)
UNIT_BIAS_MAX = np.radians(5.0)


def _means_window(dts: np.ndarray, n: int, span: float = 2.0) -> int:
    """Samples in the ``span``-s (2 s) moving means of the unit checks (at most half of the ``n`` samples)."""
    w = max(2, int(round(span / float(np.median(dts)))))
    return w if n > w else max(2, n // 2)


def _moving_means(x: np.ndarray, w: int) -> np.ndarray:
    """The ``w``-sample moving means (M, 3) of ``x`` (n, 3)."""
    c = np.cumsum(np.vstack([np.zeros(3), x]), axis=0)
    return (c[w:] - c[:-w]) / w


def _spreads(
    gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray, w: int, spread: bool = True
) -> tuple[float, np.ndarray, np.ndarray]:
    """The per-sample spread (rad; NaN without ``spread``), the unit 2-s means (M, 3) of the specific force carried
    into the frame the gyro rates ``gyr`` (rad/s) integrate to, and those means' norms (M,)
    (:func:`_kernels.gravity_means`)."""
    from optinav.attitude._kernels import gravity_means

    def c(x):
        return np.ascontiguousarray(x, dtype=float)

    ms, u, nm = gravity_means(c(gyr), c(acc), c(dts), w, spread)
    return float(np.sqrt(ms)), u, nm


def _kept_share(nm: np.ndarray, acc: np.ndarray) -> float:
    """The share of gravity the specific force's 2-s means keep in the gyro-integrated frame: their median norm
    ``nm`` over the median norm of ``acc`` (n, 3) m/s² or g, the smaller."""
    return float(np.median(nm)) / max(min(float(np.median(_norm(acc))), G_STANDARD), 1e-300)


def _drift(u: np.ndarray) -> float:
    """RMS angle (rad) of unit vectors about their mean direction."""
    mu = u.mean(axis=0)
    cos_mu = u @ mu / (np.linalg.norm(mu) + 1e-300)
    return float(np.sqrt(np.mean(np.arccos(np.clip(cos_mu, -1.0, 1.0)) ** 2)))


def _gravity_spread(
    gyr: np.ndarray,
    acc: np.ndarray,
    dts: np.ndarray,
    scale: float,
    fit_bias: bool = False,
    span: float = 2.0,
    per_sample: bool = True,
) -> tuple[float, float, np.ndarray]:
    """How well the gyro (× scale) explains how gravity turns in the body: the RMS angle (rad) between the
    specific force carried into the gyro-integrated frame and its 2-s moving mean, and the RMS angle of those
    2-s means about their mean over the window (translation averages out of them: a wrong scale leaves gravity
    wandering in the frame by tens of degrees, a right one by the bias's drift). ``fit_bias``: the second is
    taken with the constant bias (at most UNIT_BIAS_MAX, two Gauss–Newton steps from zero) that steadies the
    means most — a bias is no unit error, and a gyro 57× too large cannot be steadied by one. ``span``: the
    means' length (s) instead of 2 s. Third: the 2-s means' norms (m/s², :func:`_kept_share` judges them).
    Without ``per_sample`` the first is NaN (not computed)."""
    w = _means_window(dts, gyr.shape[0], span)
    g = gyr * scale
    spread, u, nm = _spreads(g, acc, dts, w, per_sample)
    if not fit_bias:
        return spread, _drift(u), nm
    b = np.zeros(3)
    eps = 1e-3 * UNIT_BIAS_MAX
    ub = u
    for _ in range(2):
        r0 = (ub - ub.mean(axis=0)).ravel()
        J = np.empty((r0.size, 3))
        for i in range(3):
            db = b.copy()
            db[i] += eps
            ui = _spreads(g - db, acc, dts, w, False)[1]
            J[:, i] = ((ui - ui.mean(axis=0)).ravel() - r0) / eps
        b = b + np.linalg.lstsq(J, -r0, rcond=None)[0]
        nb = float(np.linalg.norm(b))
        if nb > UNIT_BIAS_MAX:
            b *= UNIT_BIAS_MAX / nb
        ub = _spreads(g - b, acc, dts, w, False)[1]
    return spread, min(_drift(u), _drift(ub)), nm


#: the gyro-unit check looks at this many seconds of the recording, where the gyro turns most
UNIT_WINDOW_S = 20.0


def _norm(x: np.ndarray) -> np.ndarray:
    """Row norms of an (N, 3) array (cheaper than np.linalg.norm on long recordings)."""
    return np.sqrt(np.einsum("ij,ij->i", x, x))


def _turning_window(ng: np.ndarray, dts: np.ndarray) -> slice:
    """The UNIT_WINDOW_S-long stretch with the largest gyro-integrated angle (the whole recording if shorter);
    the choice does not depend on the gyro's unit factor."""
    n = ng.shape[0]
    dt = float(np.median(dts))
    w = int(np.ceil(UNIT_WINDOW_S / dt)) if dt > 0 else n
    if n <= w:
        return slice(0, n)
    c = np.concatenate([[0.0], np.cumsum(ng)])
    i = int(np.argmax(c[w:] - c[:-w]))
    return slice(i, i + w)


#: samples per bin of the accelerometer sums that locate where gravity turns most in the body
TILT_BIN = 64
#: the bins are merged to about this many seconds before the angles between neighbours are summed
TILT_BIN_S = 0.5


def tilt_sums(acc: np.ndarray, row0: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Bin numbers (k,) and specific-force sums (k, 3) of the TILT_BIN-sample bins a block starting at row
    ``row0`` touches (a bin split between blocks is summed again by :func:`tilting_window`)."""
    if not acc.shape[0]:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    bins, first = _bin_starts(acc.shape[0], row0)
    return bins, np.add.reduceat(acc, first, axis=0)


def _bin_starts(n: int, row0: int, size: int = TILT_BIN) -> tuple[np.ndarray, np.ndarray]:
    """Bin numbers and first rows (both (k,)) of the ``size``-sample bins that a block of ``n`` > 0 rows starting
    at row ``row0`` touches: the block's first row, then every ``size``-th global row (no sort needed)."""
    first = np.arange((-row0) % size, n, size)
    if first.size == 0 or first[0] != 0:
        first = np.concatenate([[0], first])
    return row0 // size + np.arange(first.size), first


def _grouped_tilt_sums(bins: np.ndarray, sums: np.ndarray, m: int) -> np.ndarray:
    """The specific-force sums (k, 3) of ``m`` consecutive TILT_BIN-sample bins, from :func:`tilt_sums`'s per-block
    bins (a bin split between two blocks is summed again here)."""
    tot = np.zeros((int(bins.max()) + 1, 3))
    np.add.at(tot, bins, sums)
    k = tot.shape[0] // m
    return tot[: k * m].reshape(k, m, 3).sum(axis=1)


def tilting_window(bins: np.ndarray, sums: np.ndarray, n: int, dt: float) -> slice:
    """The UNIT_WINDOW_S-long stretch (of ``n`` samples, step ``dt`` s) in which the mean specific force turns
    most in the body (the angles between consecutive ~TILT_BIN_S means summed): the poses and flips of a
    calibration session, where the most gyro turning is a spin about the vertical that gravity does not see.
    ``bins``/``sums`` from :func:`tilt_sums` over the whole log (in any number of blocks)."""
    w = int(np.ceil(UNIT_WINDOW_S / dt)) if dt > 0 else n
    if n <= w or bins.size == 0:
        return slice(0, n)
    m, ang = tilt_steps(bins, sums, dt)
    wb = max(1, w // (m * TILT_BIN))
    if ang.size <= wb:
        return slice(0, w)
    c = np.concatenate([[0.0], np.cumsum(ang)])
    j = int(np.argmax(c[wb:] - c[:-wb]))
    start = min(j * m * TILT_BIN, n - w)
    return slice(start, start + w)


def tilt_steps(bins: np.ndarray, sums: np.ndarray, dt: float) -> tuple[int, np.ndarray]:
    """(m, angles): the angles (rad) between consecutive means of the specific force over ``m`` TILT_BIN-sample
    bins (~TILT_BIN_S s; ``bins``/``sums`` from :func:`tilt_sums`, step ``dt`` s): how far gravity turns in the
    body, whatever the gyro's unit."""
    m = max(1, int(round(TILT_BIN_S / (TILT_BIN * dt))))
    mean = _grouped_tilt_sums(bins, sums, m)
    u = mean / (_norm(mean)[:, None] + 1e-300)
    return m, np.arccos(np.clip(np.einsum("ij,ij->i", u[1:], u[:-1]), -1.0, 1.0))


def gyro_unit_hint(
    gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray, ng: np.ndarray | None = None, alt=None, units_only: bool = False
) -> UnitHint | None:
    """None when the declared unit explains the turning of gravity best (or nothing turns), else a hint. Judged on
    the UNIT_WINDOW_S s where the gyro turns most and on those where gravity turns most in the body (the
    strapdowns' cost is independent of the recording's length). ``ng``: the gyro's row norms if already
    computed; ``alt(scale, sl)``: the gyro of rows ``sl`` (rad/s) had the raw data been ``scale`` × what they
    are (a calibrated gyro: its bias is not scaled with them), default ``gyr[sl]·scale``."""
    ng = _norm(gyr) if ng is None else ng
    for sl in unit_windows(ng, dts, *tilt_sums(acc)):
        a = None if alt is None else (lambda s, sl=sl: alt(s, sl))
        d = dts[sl] if dts.shape[0] > 1 else dts
        hint = _unit_hint_window(gyr[sl], acc[sl], d, float(np.max(ng[sl])), a, units_only)
        if hint:
            return hint
    return None


def unit_windows(ng: np.ndarray, dts: np.ndarray, bins: np.ndarray, sums: np.ndarray) -> list[slice]:
    """The windows the gyro unit is judged on: where the gyro turns most, and where gravity turns most in the
    body (one when they overlap by half)."""
    a = _turning_window(ng, dts)
    b = tilting_window(bins, sums, ng.shape[0], float(np.median(dts)))
    overlap = min(a.stop, b.stop) - max(a.start, b.start)
    return [a] if overlap >= 0.5 * (a.stop - a.start) else [a, b]


#: a body still for 2 s (accelerometer steady) cannot turn about a horizontal axis faster than this (rad/s,
#: 5.7 °/s): a deg/s gyro declared rad/s (a 0.2 °/s bias reads 0.2 rad/s and tilts the estimate tens of
#: degrees), or a bias far beyond the 2 °/s the estimators track
STILL_RATE = 0.1


def _still_turn(g, a, d) -> tuple[float, float]:
    """The largest mean gyro rate (rad/s) about an axis ⊥ the specific force, less half the rate about it, over
    2-s windows in which the accelerometer is steady (per-axis std < 0.1 m/s², |a| within 5 % of g): a turn
    there would tilt gravity in the body. (A steady turn keeps |a| up to 5 % over g — a centripetal pull of
    ≤ 0.32 g — and turns ⊥ the specific force at ≤ 0.32 × the rate about it: never counted.) Also the fraction
    of the windows whose accelerometer is steady, whatever its norm."""
    w = max(2, int(round(2.0 / float(np.median(d)))))
    k = g.shape[0] // w
    if k == 0:
        return 0.0, 0.0
    ab = a[: k * w].reshape(k, w, 3)
    gm = g[: k * w].reshape(k, w, 3).mean(axis=1)
    am = ab.mean(axis=1)
    na = _norm(am)
    steady = np.sqrt(np.sum(ab.var(axis=1), axis=1)) < 0.1
    still = steady & (np.abs(na - G_STANDARD) < 0.05 * G_STANDARD)
    if not np.any(still):
        return 0.0, float(np.mean(steady))
    u = am[still] / na[still, None]
    par = np.sum(gm[still] * u, axis=1)
    perp = _norm(gm[still] - par[:, None] * u)
    return float(np.max(perp - 0.5 * np.abs(par))), float(np.mean(steady))


def _unit_hint_window(g, a, d, window_max: float, alt=None, units_only: bool = False) -> UnitHint | None:
    """The hint of :func:`gyro_unit_hint` on one window; ``alt(scale)``: the window's gyro (rad/s) had the raw
    data been ``scale`` × what they are (default ``g·scale``; a calibration's bias is not scaled with them)."""
    k = g.shape[0]
    still, steady = _still_turn(g, a, d)
    if still > STILL_RATE:
        return UnitHint(
            "unit",
            np.pi / 180,
            f"the gyro turns at {still:.3g} rad/s about a horizontal axis while the accelerometer shows the body still",
        )
    if window_max * max(_SCALES) * float(np.median(d)) * k < 0.5:
        return None  # too little rotation to tell
    if d.shape[0] > 1:
        # the longest stretch without lost samples: across a gap the strapdown turns by the rate after it for the
        # whole gap, which no unit factor explains (a correct rad/s log with 0.36 s lost in motion was refused as
        # deg/s, and as rad/s when declared deg/s)
        cut = np.flatnonzero(d > LOST_STEPS * float(np.median(d)))
        if cut.size:
            edges = np.concatenate([[0], cut, [k]])
            i = int(np.argmax(np.diff(edges)))
            sl = slice(int(edges[i]), int(edges[i + 1]))
            g, a, d = g[sl], a[sl], d[sl]
            k = g.shape[0]
            if alt is not None:
                alt0 = alt
                alt = lambda s, sl=sl: alt0(s)[sl]  # noqa: E731
            if k * float(np.median(d)) < 2 * UNIT_MIN_S:
                # a stretch of three 2-s means: a gyro 57× too large spun gravity steady there and a correct
                # rad/s log with four short gaps was refused; the unit is judged elsewhere or not at all
                return None
    if k * float(np.median(d)) < UNIT_MIN_S:
        # too few 2-s means to tell a translation from a turn (1 s of BROAD's fast translation: refused); only a
        # gyro far too slow for the turns gravity makes is named (time in 100-µs ticks read as µs: exit 0)
        return None if units_only else (_slip_hint(g, a, d) or _short_time_hint(g, a, d))
    if steady >= 0.9:
        # a specific force steady in the body while the gyro turns is a steady turn (its centripetal pull turning
        # with the heading) as much as a still body with a small bias: how gravity turns cannot tell the unit
        return None
    if _perp_share(g, a, d) < PERP_SHARE_MIN:
        # a body that turns mostly about the vertical (a car) does not turn gravity: a gyro 57× too large spun the
        # frame fast enough to average the car's sustained accelerations out of the 2-s means and was taken for the
        # right unit (simulated level-car logs: 9 of 36 refused as rad/s declared deg/s)
        return None if units_only else _vertical_turns_axes_hint(g, a, d)
    spreads = {s: _gravity_spread(g if s == 1.0 else (g * s if alt is None else alt(s)), a, d, 1.0) for s in _SCALES}
    # a gyro too large spins the frame so fast that the 2-s means average gravity away but for its part along the
    # spin's axis, which stays put: steady means that keep under GRAVITY_SHARE of gravity hold nothing and are no
    # evidence for their scale (BROAD 29, 10 s turning at 7.4 rad/s RMS: ×180/π kept 29 % of gravity and its means
    # drifted 0.021 rad against the declared unit's 0.076 with all of it kept, and was refused as rad/s declared
    # deg/s)
    spreads = {s: v for s, v in spreads.items() if s == 1.0 or not _kept_share(v[2], a) < GRAVITY_SHARE}
    # per sample; then the drift of the 2-s means (translation averaged out), counted beyond 0.2 rad (11°) in
    # the window: what a gyro bias of 0.5 °/s drifts in 20 s, on a body that hardly turns, stays below
    for i, floor in ((0, 0.0), (1, 0.2)):
        spread = {s: v[i] for s, v in spreads.items()}
        best = min(spread, key=spread.get)
        if best != np.pi / 180:
            floor = 0.0  # the floor allows for a bias, which cannot steady a gyro that reads 57× too small
        if i == 1 and best == np.pi / 180 and spread[1.0] > max(2.0 * spread[best] + 0.02, floor):
            # against a gyro too small to turn anything, the declared unit may carry a constant bias (a MEMS
            # gyro's few °/s drift gravity as far as a slow body turns); the tiny alternative gets none (a
            # bias would explain the body's own turning). Against the ×57 alternative a bias cannot help.
            spread[1.0] = _gravity_spread(g, a, d, 1.0, fit_bias=True, per_sample=False)[1]
        if best != 1.0 and spread[1.0] > max(2.0 * spread[best] + 0.02, floor):
            if best == np.pi / 180 and not units_only:
                # a gyro too small to turn anything explains gravity better than the declared one also when the
                # declared one turns about the wrong axes (gx and gy swapped: "deg/s declared rad/s", and the
                # flag that hint names gave garbage with exit 0)
                other = _time_hint(g, a, d, spread[best]) or _axes_hint(g, a, d, spread[best])
                if other:
                    return other
            return UnitHint("unit", best)
    if units_only:
        return None
    # the gyro's rotations against the accelerometer's turns, bin by bin, where they correlate: a rate 3.5× too high
    # on slow rotation left gravity drifting within the 2-s means' tolerance (65° on BROAD 03's first minute)
    return _time_or_axes_hint(g, a, d, spreads[1.0][1]) or _short_time_hint(g, a, d)


#: how gravity drifts in the body over the unit window (rad, RMS of its 2-s means about their mean) below which
#: the gyro's time base and axes cannot be judged
CONSISTENCY_STILL = 0.3
#: the drift (rad) of gravity in the declared gyro's frame beyond which the time base and axes are questioned,
#: and below which an alternative must bring it: the nine BROAD trials as declared 0.025-0.105 (a simulated
#: dynamic flight's sustained accelerations up to 0.23), a gyro 2× too large ≥ 0.22, axes swapped ≥ 0.16
CONSISTENCY_BAD = 0.2
#: words for the time-base factors off by 2: the gyro integrated over steps twice too long (a time column at half
#: the rate, or --rate twice too small) and half as long
_TIME_SCALES = {0.5: "twice", 2.0: "half"}
#: a factor within this ratio of π/180 or 180/π is the gyro's unit (the unit hint names it), and one within it of 1
#: is no finding in a window or where gravity hardly turns in the body (its factor is rough there)
SCALE_NEAR = 1.1
#: over the whole log, where gravity turns in the body (≥ LONG_BODY), a factor beyond this ratio of 1 found where the
#: declared gyro drifts gravity by less than SCALE_DRIFT is a finding (beyond SCALE_PRECISION where it drifts
#: more): the nine BROAD trials as declared find 0.997-1.006 or no better; with their rate 3-9 % off they ran with
#: exit 0 at 1.4-8.3° inclination RMSE, 7.7° and 27° heading with the magnetometer (a datasheet's 300 Hz for
#: 285.7), and trial 29 (fast rotation) at 8.5° with it 2 % off. Under 3 % the attitude is off by less than about
#: the drift itself, and a consumer gyro's own scale or an internal oscillator's rate is often off by 1-2 %
SCALE_FOUND = 1.03
#: a whole-log factor beyond this ratio of 1 (up to SCALE_NEAR) that is not refused and holds gravity with at most
#: SCALE_WARN_RATIO of the declared gyro's drift (bias fitted) is said in a warning (the attitude runs as declared): the nine BROAD
#: trials as declared find 0.995-1.008 at 0.67-0.99 of their drift (16, fast translation, 1.022 at 0.77); with their
#: rate 1.5-3 % off 02, 03 and 33 find 0.36-0.48 (1.4-3.4° inclination RMSE), 24 0.51-0.63, 07 0.40-0.83
SCALE_WARN, SCALE_WARN_RATIO = 1.0125, 0.6
#: the whole-log factor's precision (the nine BROAD trials as declared: within 0.6 % of 1): a unit window shows the
#: declared time base only where it holds gravity better than this much more or less of the gyro does
SCALE_PRECISION = 1.005
#: (rad) the declared gyro's drift of gravity over the whole log (5-s means, bias fitted) beyond which a factor
#: beyond SCALE_PRECISION is a finding: BROAD 33 (a magnet on the board, turning at ~2 rad/s) with its rate 3 %
#: off drifts 0.107 and ran at 5.4° with exit 0, 29 (fast rotation) 1-2 % off 0.3-0.7 at 4-8.5°; the nine as
#: declared 0.008-0.043
SCALE_DRIFT = 0.1
#: the time/scale search runs this far (×) below the estimate from the angles gravity turns through (translation
#: only adds to those angles, so the estimate is mostly high: 1.1-4× on the nine BROAD trials) and 1.5× above it
SCALE_BELOW, SCALE_ABOVE = 5.0, 1.5
#: factors that slips of the time base give (a rate twice or half the true one, a time unit off by 10 or a power of
#: 1000), taken over the search's best when their drift is within ROUND_SCALE_TOL of it
_ROUND_SCALES = (0.5, 2.0, 0.1, 10.0, 1e-3, 1e3, 1e-6, 1e6, 1e-9, 1e9)
ROUND_SCALE_TOL = 1.2
#: another factor on the gyro must leave at most this share of the declared gyro's drift (bias fitted): the nine
#: BROAD trials as declared ≥ 1.02 (their best factor within ±30 % of 1, or no better), with their time base off by
#: 20-40 % 0.04-0.39 (where rotation shows it; translation and vibration cannot tell: 0.5-1.0)
TIME_RATIO = 0.4


def _drift_of(g, a, d) -> float:
    return _gravity_spread(g, a, d, 1.0, per_sample=False)[1]


def _body_turn(a, d, span: float = 2.0) -> float:
    """How far gravity turns in the body: the RMS angle (rad) of the specific force's ``span``-s moving means about
    their mean direction."""
    m = _moving_means(a, _means_window(d, a.shape[0], span))
    return _drift(m / (_norm(m)[:, None] + 1e-300))


def _declared_holds(g, a, d, drift1: float, near: float = SCALE_NEAR) -> bool:
    """The declared gyro, whose drift of gravity's 2-s means is ``drift1``, holds gravity within
    :data:`CONSISTENCY_BAD` and better than ``near`` (10 %) more or less of it."""
    return drift1 <= CONSISTENCY_BAD and all(_drift_of(g * s, a, d) >= drift1 for s in (1 / near, near))


def _axes_hint(g, a, d, beat: float) -> UnitHint | None:
    """A hint naming the signed axis permutation of the gyro (at its declared scale, or with the unit factor
    π/180 or 180/π) that explains how gravity turns within :data:`CONSISTENCY_BAD` and clearly better than
    ``beat`` (the best drift without a permutation), else None."""
    from optinav.core.rotations import describe_permutation, signed_permutations

    best, drift = None, np.inf
    for scale in (1.0, np.pi / 180, 180 / np.pi):
        for P in signed_permutations()[1:]:
            v = _drift_of(g @ P * scale, a, d)  # raw row g = P ω: ω = Pᵀ g, as rows g @ P
            if v < drift:
                best, drift = (P, scale), v
    if best is None or not (drift < CONSISTENCY_BAD and drift < 0.75 * beat):
        return None
    P, scale = best
    return UnitHint("axes", scale, describe_permutation(P, "gyro", "accelerometer axes"), P)


def _bin_turns(g, a, dt: float, m: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Per bin of ``m`` samples: the specific force's mean direction u (k, 3) and the gyro's rotation θ (k, 3, rad);
    None under three bins."""
    k = g.shape[0] // m
    if k < 3:
        return None
    am = a[: k * m].reshape(k, m, 3).mean(axis=1)
    u = am / (_norm(am)[:, None] + 1e-300)
    return u, g[: k * m].reshape(k, m, 3).sum(axis=1) * dt


def _perp(th: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The part of each rotation θ (n, 3) ⊥ its unit direction u (n, 3)."""
    return th - np.einsum("ij,ij->i", th, u)[:, None] * u


def _between_bins(u: np.ndarray, th: np.ndarray) -> np.ndarray:
    """The gyro's rotation from one bin's centre to the next, ⊥ the two bins' mean direction (k − 1, 3)."""
    um = u[:-1] + u[1:]
    um /= _norm(um)[:, None] + 1e-300
    return _perp(0.5 * (th[:-1] + th[1:]), um)


def _turn_scale(g, a, d) -> float | None:
    """The factor by which the gyro (rad/s) turns gravity less than the accelerometer sees it turn: the angles
    between consecutive 0.1-s mean specific-force directions over the gyro's rotation ⊥ to them, summed (None when
    the gyro hardly turns or gravity turns by less than :data:`SHORT_TURN` rad in all). Translation only adds to
    the accelerometer's angles: 1.1-4× the true factor on the nine BROAD trials' unit windows."""
    dt = float(np.median(d))
    bins = _bin_turns(g, a, dt, max(1, int(round(0.1 / dt))))
    if bins is None:
        return None
    u, th = bins
    perp = float(np.sum(_norm(_between_bins(u, th))))
    alpha = float(np.sum(np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0))))
    return alpha / perp if perp > 1e-6 and alpha > SHORT_TURN else None


#: a short log (under UNIT_MIN_S) is refused when its gyro, correlated with the accelerometer's turns, turns gravity
#: beyond SHORT_SCALE times as far or less far as the accelerometer sees (:func:`_rotation_fit`): correct 5-20 s cuts
#: of the nine BROAD trials 0.62-1.97 (1-99 % 0.69-1.42), their rate off by 3.5 2.1-7.7 (1 %-max) and 0.25-0.38
SHORT_SCALE = 2.5
#: gravity must turn through this many rad in all before :func:`_turn_scale` gives a factor
SHORT_TURN = 0.5


#: the gyro's rotation ⊥ gravity and the accelerometer's own turn, bin by bin, must agree at least this well
#: (correlation of the two rotation vectors) before a short log's scale is judged: translation, a lever arm's pull
#: and vibration turn the accelerometer's means without the gyro (BROAD 07's fast rotation, 27's vibration, a car:
#: ratios 28× to hundreds of times with the gyro right)
SHORT_CORRELATION = 0.7


#: the share of the gyro's rotation ⊥ gravity (0.1-s bins) below which how gravity turns cannot judge the gyro: the
#: nine BROAD trials' unit windows 0.64-0.96, a level car turning and braking 0.14-0.25
PERP_SHARE_MIN = 0.4


def _perp_share(g, a, d) -> float:
    """The gyro's rotation ⊥ the specific force's 0.1-s mean direction over its whole rotation, summed over bins."""
    dt = float(np.median(d))
    bins = _bin_turns(g, a, dt, max(1, int(round(0.1 / dt))))
    if bins is None:
        return 1.0  # (reached only by windows of 6 s and more)
    u, th = bins
    total = float(np.sum(_norm(th)))
    return float(np.sum(_norm(_perp(th, u)))) / total if total > 0 else 1.0


#: bins :func:`_rotation_fit` needs at one bin length
ROTATION_FIT_BINS = 30


def _rotation_fit(g, a, d) -> tuple[float, float]:
    """(scale, correlation) of the accelerometer's turns on the gyro's: per bin, the rotation vector that takes one
    mean specific-force direction to the next against the gyro's rotation ⊥ to them (a body-frame vector turns
    against the body: u × u' ≈ −θ⊥); the least-squares factor and the correlation of the two, for bins of 0.1 s
    as declared and 10 and 100 times fewer samples (a time base 100× off makes a declared 0.1 s ten seconds), the
    best correlated."""
    dt = float(np.median(d))
    best = (float("nan"), 0.0)
    for span in (0.1, 0.01, 0.001):
        m = max(1, int(round(span / dt)))
        if g.shape[0] // m < ROTATION_FIT_BINS:
            continue  # too few turns to tell a lever arm's pull from a gyro off by a factor (2-s cuts: refused)
        fit = _rotation_fit_bins(g, a, dt, m)
        if fit[1] > best[1]:
            best = fit
    return best


def _rotation_fit_bins(g, a, dt: float, m: int) -> tuple[float, float]:
    """:func:`_rotation_fit` with bins of ``m`` samples."""
    bins = _bin_turns(g, a, dt, m)
    if bins is None:
        return float("nan"), 0.0
    u, th = bins
    tp = _between_bins(u, th)
    r = -np.cross(u[:-1], u[1:])
    rt, tt, rr = float(np.sum(r * tp)), float(np.sum(tp * tp)), float(np.sum(r * r))
    if tt <= 0 or rr <= 0:
        return float("nan"), 0.0
    return (rt / tt if rt > 0 else float("inf")), rt / np.sqrt(rr * tt)


def _short_time_hint(g, a, d) -> UnitHint | None:
    """The "time" hint of a window too short for the 2-s means: a gyro whose rotations match the accelerometer's
    turns (:data:`SHORT_CORRELATION`) by a factor beyond :data:`SHORT_SCALE` either way (the factor is rough: the
    message names the time base and the gyro's unit alike)."""
    s0, corr = _rotation_fit(g, a, d)
    if not (corr >= SHORT_CORRELATION and abs(np.log(s0)) > np.log(SHORT_SCALE)):
        return None
    return UnitHint(
        "time",
        s0,
        f"the gyro, over these time steps, turns gravity about ×{1 / s0:.2g} as far as the accelerometer sees it turn",
        rate_hz=1.0 / (s0 * float(np.median(d))),
        rough=True,
    )


#: the slip of a time unit by a power of 1000 (ms read as µs, µs as ns) tried on a log too short as declared for the
#: 2-s means: BROAD 07 at 57 Hz with its ms time column declared µs (183 s read as 0.18 s) ran with exit 0 at 35°
TIME_SLIP = 1000.0


def _slip_hint(g, a, d) -> UnitHint | None:
    """The "time" hint of a log too short as declared for the 2-s means whose samples, :data:`TIME_SLIP` times
    further apart, would span :data:`UNIT_MIN_S` at an IMU's rate: where the gyro explains how gravity turns with
    those steps (2-s means, a constant bias allowed) within :data:`CONSISTENCY_BAD` and in :data:`TIME_RATIO` of
    the declared steps' drift (the same means), else None."""
    dt = float(np.median(d))
    slow = d * TIME_SLIP
    if g.shape[0] * dt * TIME_SLIP < UNIT_MIN_S or dt * TIME_SLIP > 1.0 / RATE_RANGE_HZ[0]:
        return None
    declared = _gravity_spread(g, a, slow, 1.0 / TIME_SLIP, per_sample=False)[1]
    drift = _gravity_spread(g, a, slow, 1.0, fit_bias=True, per_sample=False)[1]
    if not (drift < CONSISTENCY_BAD and drift < TIME_RATIO * declared):
        return None
    return _time_words(TIME_SLIP, dt)


def _time_hint(g, a, d, beat: float) -> UnitHint | None:
    """A "time" hint when one factor on the gyro (a sample rate or time unit off by it, or a gyro scale) explains
    how gravity turns within :data:`CONSISTENCY_BAD` and in :data:`TIME_RATIO` of the drift ``beat`` leaves, else
    None: searched (steps of 2.3 %) about the factor the turning angles give (:func:`_turn_scale`); none near π/180
    or 180/π (the gyro's unit) or 1."""
    s0 = _turn_scale(g, a, d)
    if s0 is None:
        return None
    grid = s0 * np.logspace(
        -np.log10(SCALE_BELOW), np.log10(SCALE_ABOVE), int(100 * np.log10(SCALE_BELOW * SCALE_ABOVE)) + 1
    )
    drift = np.array([_drift_of(g * s, a, d) for s in grid])
    i = int(np.argmin(drift))
    s, best = float(grid[i]), float(drift[i])
    if not (best < CONSISTENCY_BAD and best < TIME_RATIO * beat):
        return None
    s = _round_scale(s, best, lambda f: _drift_of(g * f, a, d), grid[0], grid[-1])
    if any(abs(np.log(s / u)) < np.log(SCALE_NEAR) for u in _SCALES):
        return None
    return _time_words(s, float(np.median(d)))


def _round_scale(s: float, best: float, drift, lo: float, hi: float, extra: tuple = ()) -> float:
    """The usual slip (a rate halved, a time unit off by a power of 1000 or 10, or the factors ``extra``) nearest
    ``s`` in [lo, hi] whose ``drift(f)`` is within ROUND_SCALE_TOL of ``best`` (a flight's sustained accelerations
    move the minimum: a time base off by 2 was found at ×1.62), else ``s``."""
    for f in sorted(_ROUND_SCALES + extra, key=lambda f: abs(np.log(f / s))):
        if lo <= f <= hi and drift(f) <= ROUND_SCALE_TOL * best:
            return f
    return s


def _time_words(s: float, dt: float) -> UnitHint:
    """The "time" hint of a gyro that needs the factor ``s`` (declared step ``dt`` s)."""
    half = next((w for f, w in _TIME_SCALES.items() if abs(np.log(s / f)) < np.log(1.05)), None)
    words = (
        f"the time steps look {half} as long as they are (the gyro turns gravity ×{1 / s:.3g} as far as the "
        "accelerometer sees)"
        if half
        else f"the gyro, over these time steps, turns gravity ×{1 / s:.3g} as far as the accelerometer sees it turn"
    )
    return UnitHint("time", s, words, rate_hz=1.0 / (s * dt))


def _vertical_turns_axes_hint(g, a, d) -> UnitHint | None:
    """The axes hint of a window whose gyro turns mostly about the vertical, which cannot tell the unit: where
    gravity still turns in the body and the declared gyro (bias fitted) leaves it drifting beyond
    :data:`CONSISTENCY_BAD`, a signed permutation that holds it (:func:`_axes_hint`). imucal's session with the
    accelerometer's x negated passed attitude and apply with exit 0: its window of turns about the vertical and
    one 90° move drifts gravity 1.27 rad as declared, 0.05 with the axes matched, and the other windows turn
    gravity about x only or by 180° (a flipped axis keeps both ends of such a move)."""
    if _body_turn(a, d) < CONSISTENCY_STILL:
        return None
    drift1 = _gravity_spread(g, a, d, 1.0, fit_bias=True, per_sample=False)[1]
    return _axes_hint(g, a, d, drift1) if drift1 > CONSISTENCY_BAD else None


def _time_or_axes_hint(g, a, d, drift1: float) -> UnitHint | None:
    """When the declared gyro does not explain how gravity turns in the body (while it does turn): a time base off
    or scale off, or axes swapped or flipped, where one of them explains it clearly better; None otherwise. Judged on the drift of the 2-s means
    of gravity in the gyro-integrated frame (translation averaged out), the declared gyro with the constant bias
    that steadies it most."""
    if _declared_holds(g, a, d, drift1):
        return None  # the declared gyro steadies gravity well, better than 10 % more or less of it
    if _body_turn(a, d) < CONSISTENCY_STILL:
        return None  # gravity hardly turns in the body: nothing to judge by
    drift1 = _gravity_spread(g, a, d, 1.0, fit_bias=True, per_sample=False)[1]
    # a rate 40 % too high steadied gravity within 0.15 rad on fast rotation (BROAD 07: 13.5° with exit 0):
    # the time base is judged also below CONSISTENCY_BAD, against a stricter share
    time = _time_hint(g, a, d, drift1)
    if time:
        return time
    if drift1 <= CONSISTENCY_BAD:
        return None
    # nothing that explains it is no evidence: a dynamic flight's sustained accelerations leave a correct gyro's
    # drift (0.17-0.23 rad) near gravity's own in the body (0.23-0.32)
    return _axes_hint(g, a, d, drift1)


#: the whole log's time base is judged (:func:`long_time_hint`) when its gap-free pieces last at least this long
#: (declared s): over minutes a gyro off by a factor leaves gravity wandering in the gyro-integrated frame even where
#: translation hides it over the unit windows' 20 s (BROAD's fast translation with --rate 100, 400 or 1000 for its
#: 285.7 Hz: 66, 13 and 28° with exit 0)
LONG_MIN_S = 30.0
#: pieces (declared s) with a gyro bias of their own (a MEMS gyro's bias moves over an hour); shorter gap-free
#: stretches than LONG_PIECE_MIN_S are left out
LONG_PIECE_S, LONG_PIECE_MIN_S = 300.0, 20.0
#: the whole-log check sums the samples in bins of at least LONG_BIN_S (declared s), at most LONG_BINS_MAX bins,
#: unless the gyro's RMS rate turns a bin further than LONG_BIN_TURN rad (then up to LONG_BINS_TURNING bins): the
#: accelerometer averaged over a turning bin biased the factor found on BROAD's fast rotation by 12 % at 0.26 rad
LONG_BIN_S, LONG_BINS_MAX, LONG_BIN_TURN, LONG_BINS_TURNING = 0.02, 5000, 0.1, 50000
#: the declared gyro is first judged on at most this many bins (merged from the finer ones): BROAD 02 tiled to 1 M
#: samples drifts 0.021 rad on its 48 000 bins, 0.056 on 16 000, 0.18 on 4 800
LONG_PRETEST_BINS = 20000
#: the moving means (declared s) of gravity in the gyro-integrated frame: at a rate 2.9× too low 2 s are 0.7 s, and
#: BROAD's fast translation left 0.2 rad about the right factor at 2 s, 0.06 at 5 s
LONG_MEANS_S = 5.0
#: the declared gyro must leave gravity drifting by at least this much (rad, RMS of the 5-s means about their mean,
#: the bias from rest and fitted) before another factor is searched: the nine BROAD trials as declared 0.008-0.043
#: with the bias fitted (their best factor 0.997-1.006, or none better), with their rate 3 % off 0.026-0.93 and 5 %
#: off 0.036-1.03 (0.1 let 3-9 % through at 1.4-8.3° inclination RMSE with exit 0)
LONG_FLOOR = 0.03
#: where gravity turns (≥ LONG_BODY), from this drift (rad) on a factor of a few percent is searched for a warning
#: only (:data:`SCALE_WARN`): the nine BROAD trials with their rate 1.5-2 % off drift 0.016-0.066 (1.3-3.4°
#: inclination RMSE), as declared 0.008-0.043
WARN_FLOOR = 0.015
#: gravity must turn in the body by at least this much (rad, its 5-s means about their mean) to judge by
LONG_BODY = 0.15
#: where it turns less (a body that mostly turns about the vertical: BROAD 11 and 27, 0.02-0.05), the declared
#: gyro must drift gravity by at least LONG_FLOOR with the rest bias and LOW_BODY_FLOOR with the fitted one (those
#: trials as declared 0.05, 0.02 and 0.012-0.013; at --rate 100, 200 for their 285.7 Hz 0.65-0.80 and 0.21-0.22,
#: fitted 0.42-0.57 and 0.076-0.088) and the factor found must hold it better than
#: LOW_BODY_TINY × the drift of a gyro that says nothing (10⁻³ of it): a real minimum, not the plateau of a
#: gyro scaled away (--rate 200 ran at 3.3° and 18.7° heading with exit 0; --rate 100 was named "deg/s declared
#: rad/s", whose flag ran at 5.1°)
LOW_BODY_FLOOR, LOW_BODY_TINY = 0.05, 0.7
#: ... and the declared gyro must drift gravity at least this many times as far as a gyro scaled to nothing does
#: (those trials as declared 0.3-0.4×, at --rate 100/200 2.1-12×)
LOW_BODY_TINY_WORSE = 1.5
#: where gravity hardly turns, a declared gyro drifting it by at least this much (rad; and LOW_BODY_TINY_WORSE ×
#: a gyro scaled to nothing) is searched for swapped or flipped axes (:func:`_long_axes_hint`; a factor still needs
#: LOW_BODY_FLOOR): BROAD 27's accelerometer with x and y swapped or x negated drifts 0.040-0.042 rad as declared,
#: 0.012 with the gyro's axes turned to match (exit 0 at 3.6° before); the nine trials as declared 0.012-0.013
LOW_AXES_FLOOR = 0.03
#: a rest (for the gyro bias): over 1 s (declared) the binned gyro's std (rad/s) and norm and the accelerometer's
#: std (m/s²) below these
REST_GYR_STD, REST_GYR, REST_ACC_STD = 0.02, 0.1, 0.1


def check_time_base(windows, whole, gyro_unit: str | None, share: float, axes=None) -> None:
    """The gyro's unit and time base: first the order of its axes judged axis by axis over the whole log
    (``axes()``: :func:`axes_turn_hint`), then :func:`check_gyro_unit` on each unit window (``windows``: (gyr, acc,
    steps, peak norm) each), then, unless a window shows the declared factor (:func:`window_holds`), the whole log's
    hint ``whole()`` (:func:`long_time_hint`, computed once, also for a window's unit finding); ``share``: the
    :func:`gravity_share` (NaN: no still window, gravity judged in the gyro-integrated frame)."""
    # before the windows: a window that saw turns about one or two axes names an order of the gyro's axes that fits
    # those (imucal's session with its accelerometer's y negated was named a mirrored frame, all three negated)
    hint = axes() if axes is not None else None
    if hint:
        raise unit_error(hint, gyro_unit)
    long = functools.cache(whole)
    held = False
    for g, a, d, peak in windows:
        check_gyro_unit(g, a, d, peak, gyro_unit, moving=not share >= 0.0, long=long)
        held = held or window_holds(g, a, d)
    hint = None if held else long()
    if hint and hint.warn:
        warn_time_base(hint)
    elif hint:
        raise unit_error(hint, gyro_unit)


def warn_time_base(hint: UnitHint) -> None:
    """Say a whole-log factor of a few percent (:func:`long_time_hint`'s ``warn`` hint): the attitude runs as declared."""
    warnings.warn(
        f"over the whole log the gyro turns gravity ×{1 / hint.scale:.4g} as far as the accelerometer sees it turn: "
        f"the sample rate or the time column may be off by about {_percent(hint.scale)}, or the gyro's "
        f"scale is; the attitude is computed as declared (its tilt can be off by a degree or more); check --rate (the "
        f"data fit about {hint.rate_hz:.4g} Hz) or the time column, or calibrate the gyro",
        TimeBaseWarning,
        stacklevel=4,
    )


def window_holds(g: np.ndarray, a: np.ndarray, d: np.ndarray) -> bool:
    """Whether a unit window shows the declared time base: gravity turns in the body there (its 2-s means drift by
    ≥ :data:`CONSISTENCY_STILL`) and the declared gyro holds it in the gyro-integrated frame (≤
    :data:`CONSISTENCY_BAD`) better than :data:`SCALE_PRECISION` (0.5 %) more or less of it. Then the whole-log check
    (:func:`long_time_hint`, 0.15 s per million samples) has nothing to add.

    Parameters
    ----------
    g, a : ndarray
        The window's gyro (rad/s) and specific force (m/s²), (k, 3).
    d : ndarray
        Its steps (s), (k,) or one.

    Returns
    -------
    bool
        Whether the declared factor is the local best where gravity turns.
    """
    if g.shape[0] * float(np.median(d)) < UNIT_MIN_S or _body_turn(a, d) < CONSISTENCY_STILL:
        return False
    return _declared_holds(g, a, d, _drift_of(g, a, d), SCALE_PRECISION)


def long_bin_rows(n: int, dt: float, rms_rate: float) -> int:
    """Samples per bin of the whole-log time-base check (:func:`time_bins`) for ``n`` samples of step ``dt`` s whose
    gyro's RMS norm is ``rms_rate`` (rad/s)."""
    m = max(1, int(round(LONG_BIN_S / dt)), int(np.ceil(n / LONG_BINS_MAX)))
    turning = max(1, int(LONG_BIN_TURN / (rms_rate * dt + 1e-300)), int(np.ceil(n / LONG_BINS_TURNING)))
    return min(m, turning)


def time_bins(gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray, m: int, row0: int = 0):
    """Bin numbers (k,) and per-bin sums (k, 8) of the ``m``-sample bins a block starting at row ``row0`` touches:
    the gyro's rotation Σω·dt (rad, 3), Σdt (s), the specific force Σa (m/s², 3) and the samples (a bin split
    between blocks appears twice: :func:`merge_bins` adds them)."""
    n = gyr.shape[0]
    start = np.arange((-row0) % m, n, m)
    if not start.size or start[0]:
        start = np.concatenate([[0], start])
    count = np.diff(np.append(start, n)).astype(float)
    if np.size(dts) == 1:  # one step: no n-row products
        h = float(np.ravel(dts)[0])
        rot, span = np.add.reduceat(gyr, start, axis=0) * h, count * h
    else:
        d = np.asarray(dts, dtype=float)
        rot, span = np.add.reduceat(gyr * d[:, None], start, axis=0), np.add.reduceat(d, start)
    return (row0 + start) // m, np.column_stack([rot, span, np.add.reduceat(acc, start, axis=0), count])


def merge_bins(bins: np.ndarray, sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`time_bins` of consecutive blocks concatenated, each bin once."""
    b, inv = np.unique(bins, return_inverse=True)
    out = np.zeros((b.shape[0], sums.shape[1]))
    np.add.at(out, inv, sums)
    return b, out


def _rest_bias(g: np.ndarray, a: np.ndarray, T: np.ndarray) -> np.ndarray | None:
    """The median gyro (rad/s) over the binned samples (rates g, specific force a, durations T) where the body
    rests for 1 s (:data:`REST_GYR_STD`, :data:`REST_GYR`, :data:`REST_ACC_STD`); None under 1 s of rest."""
    w = max(3, int(round(1.0 / float(np.median(T)))))
    if g.shape[0] < 2 * w:
        return None

    def moving(x):
        m = _moving_means(x, w)
        return np.sqrt(np.maximum(_moving_means(x * x, w) - m * m, 0.0).sum(axis=1)), m

    sg, mg = moving(g)
    sa = moving(a)[0]
    rest = (sg < REST_GYR_STD) & (sa < REST_ACC_STD) & (_norm(mg) < REST_GYR)
    return np.median(mg[rest], axis=0) if np.count_nonzero(rest) >= w else None


def _long_pieces(bins: np.ndarray, sums: np.ndarray, gap_bins: np.ndarray, debias: bool = True) -> list[tuple]:
    """The gap-free pieces (rates rad/s less their rest bias unless not ``debias``, specific force, durations) of
    the merged bins."""
    T = sums[:, 3]
    ok = (T > 0) & ~np.isin(bins, gap_bins)
    g = np.divide(sums[:, :3], T[:, None], out=np.zeros((T.shape[0], 3)), where=ok[:, None])
    a = sums[:, 4:7] / np.maximum(sums[:, 7:8], 1.0)
    pieces = []
    for i, j in mask_runs(ok):
        span = float(T[i:j].sum())
        if span >= LONG_PIECE_MIN_S:
            pieces += np.array_split(np.arange(i, j), int(np.ceil(span / LONG_PIECE_S)))
    if not pieces or sum(float(T[p].sum()) for p in pieces) < LONG_MIN_S:
        return []
    if not debias:
        return [(g[p], a[p], T[p]) for p in pieces]
    every = _rest_bias(g[ok], a[ok], T[ok])
    out = []
    for p in pieces:
        b = _rest_bias(g[p], a[p], T[p])
        b = every if b is None else b
        out.append((g[p] - (0.0 if b is None else b), a[p], T[p]))
    return out


def _long_drift(pieces: list[tuple], s: float, fit_bias: bool = False) -> float:
    """RMS over the pieces (weighted by their bins) of gravity's drift (rad) in the frame the gyro × ``s``
    integrates to (:func:`_gravity_spread`, :data:`LONG_MEANS_S`-s means)."""
    v = [_gravity_spread(g * s, a, T, 1.0, fit_bias, LONG_MEANS_S, False)[1] ** 2 for g, a, T in pieces]
    return float(np.sqrt(np.average(v, weights=[g.shape[0] for g, _, _ in pieces])))


def _scan(pieces: list[tuple], scales: np.ndarray, fit_bias: bool = False) -> tuple[float, float]:
    """(factor, drift) of the scan's best and, Brent's bounded search, between its neighbours."""
    from scipy.optimize import minimize_scalar

    drift = np.array([_long_drift(pieces, s, fit_bias) for s in scales])
    i = int(np.argmin(drift))
    lo, hi = np.log(scales[max(i - 1, 0)]), np.log(scales[min(i + 1, scales.shape[0] - 1)])
    r = minimize_scalar(lambda x: _long_drift(pieces, np.exp(x), fit_bias), bounds=(lo, hi), method="bounded")
    return (float(np.exp(r.x)), float(r.fun)) if r.fun < drift[i] else (float(scales[i]), float(drift[i]))


def whole_log_bins(
    gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray, ng: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`merge_bins` of a whole log (by blocks of 2²⁰ rows) and its gap bins, for :func:`long_time_hint`
    (empty bins for a log under LONG_MIN_S); ``ng``: the gyro's row norms if already computed."""
    n, dt = gyr.shape[0], float(np.median(dts))
    if n * dt < LONG_MIN_S:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 8)), np.zeros(0, dtype=np.int64)
    ng = _norm(gyr) if ng is None else ng
    m = long_bin_rows(n, dt, float(np.sqrt(np.mean(ng * ng))))
    step = 1 << 20
    parts = [
        time_bins(gyr[i : i + step], acc[i : i + step], dts[i : i + step] if dts.shape[0] > 1 else dts, m, i)
        for i in range(0, n, step)
    ]
    return (*merge_bins(*(np.concatenate(x) for x in zip(*parts))), np.unique(find_gaps(dts) // m))


def long_time_hint(bins: np.ndarray, sums: np.ndarray, gap_bins: np.ndarray, dt: float) -> UnitHint | None:
    """A "time" (or "unit") hint from the whole log when one factor on the gyro holds gravity in the gyro-integrated
    frame over minutes far better than the declared gyro does, else None. ``bins``/``sums``: :func:`merge_bins`;
    ``gap_bins``: bins holding a time gap (left out, the pieces split there); ``dt``: the median declared step (s).
    Searched: a coarse grid (×1.15, 10⁻³-10³) with its three best minima scanned by 1 %, and from the factor the
    turning angles give (:func:`_turn_scale`) ×0.4-1.25 by 0.5 % (a body that turns through hundreds of radians
    holds gravity only within 1 % of the right factor)."""
    if not bins.shape[0]:
        return None
    # first on at most LONG_PRETEST_BINS bins (fine bins on fast rotation cost 10× as much): a declared gyro that
    # holds gravity there holds it on the fine bins too (coarser bins only add to the drift)
    f = int(np.ceil(bins.shape[0] / LONG_PRETEST_BINS))
    if f > 1:
        coarse = _long_pieces(*merge_bins(bins // f, sums), np.unique(gap_bins // f))
        # (the rest bias alone first: the fitted one only lowers the drift, at 9× the cost)
        if not coarse or not _drifts_enough(coarse) or _long_drift(coarse, 1.0, True) < WARN_FLOOR:
            return None
    pieces = _long_pieces(bins, sums, gap_bins)
    if not pieces or not _drifts_enough(pieces):
        return None  # (the fitted bias only lowers the drift, at 9× the cost)
    body = _pieces_body(pieces)
    declared = _long_drift(pieces, 1.0, fit_bias=True)
    if declared < (WARN_FLOOR if body >= LONG_BODY else LOW_AXES_FLOOR):
        return None
    grid = np.exp(np.arange(np.log(1e-3), np.log(1e3), np.log(1.15)))
    if body < LONG_BODY:
        # a gyro that turns gravity no more than one scaled to nothing may be right (a flight's sustained
        # accelerations): the search (≈ 0.3 s a log) runs only where the declared one does clearly worse
        tiny = _long_drift(pieces, grid[0], fit_bias=True)
        if declared < LOW_BODY_TINY_WORSE * tiny:
            return None
        if declared < LOW_BODY_FLOOR:
            return _long_axes_hint(pieces, declared, body, tiny)
    if body >= LONG_BODY and declared < LONG_FLOOR:
        # below the floor a factor is only said, and one beyond 4 % drifts gravity beyond it (the nine at 5 % off:
        # 0.036-1.03)
        s, _ = _scan(pieces, np.exp(np.linspace(-0.04, 0.04, 17)))
        return _few_percent(pieces, s, _long_drift(pieces, s, fit_bias=True), declared, dt)
    if body >= LONG_BODY and declared < SCALE_DRIFT:
        # gravity turns and the declared gyro holds it this well: a factor within SCALE_NEAR is scanned, by 0.5 %
        # (the nine at 0.92 / 1.085 × their rate drift 0.07-1.2); a larger one is searched from SCALE_DRIFT, as it
        # was from the former floor of 0.1 (the grid's 400 factors cost 0.3-0.6 s a log: BROAD 16 as declared)
        found = [_scan(pieces, np.exp(np.linspace(-np.log(SCALE_NEAR), np.log(SCALE_NEAR), 39)))]
    else:
        coarse = np.array([_long_drift(pieces, s) for s in grid])
        inner = (coarse <= np.roll(coarse, 1)) & (coarse <= np.roll(coarse, -1))
        found = [
            _scan(pieces, grid[i] * 1.15 ** np.linspace(-1.0, 1.0, 29))
            for i in sorted(np.flatnonzero(inner), key=lambda i: coarse[i])[:3]
        ]
        s0 = _turn_scale(*(np.concatenate(x) for x in zip(*pieces)))
        if s0 is not None:
            found.append(_scan(pieces, s0 * np.exp(np.arange(np.log(0.4), np.log(1.25), 0.005))))
    s, _ = min(found, key=lambda x: x[1])
    best = _long_drift(pieces, s, fit_bias=True)
    if body < LONG_BODY:
        # gravity hardly turns: the rest bias leaves the minimum off by up to 20 % (BROAD 11 at --rate 200: 336 Hz
        # for 285.7), so it is found again with the fitted bias; any gyro scaled towards 0 holds gravity about as
        # well as it turns, so the factor must be a clear minimum below that plateau, and is named as rough
        s, best = _scan(pieces, s * np.exp(np.arange(np.log(0.5), np.log(1.6), 0.05)), fit_bias=True)
        if not (best < TIME_RATIO * declared and best < LOW_BODY_TINY * tiny):
            return _long_axes_hint(pieces, declared, body, tiny)
    elif not (best < TIME_RATIO * declared and best < CONSISTENCY_BAD and best < 0.5 * body):
        hint = _long_axes_hint(pieces, declared, body)
        return hint if hint or declared >= SCALE_DRIFT else _few_percent(pieces, s, best, declared, dt)
    elif abs(np.log(s)) < np.log(SCALE_NEAR):
        # a few percent: the factor again with the fitted bias, which the rest bias leaves ~1 % off (BROAD 02 at a
        # rate 5 % high: 0.941 for 0.952), as the rate it names must be right to that
        s, best = _scan(pieces, s * np.exp(np.linspace(-0.02, 0.02, 9)), fit_bias=True)
    rough = body < LONG_BODY  # (its factor is named as found, not rounded to a usual slip)
    near = SCALE_NEAR if rough else SCALE_FOUND if declared < SCALE_DRIFT else SCALE_PRECISION
    if abs(np.log(s)) < np.log(near):
        return _few_percent(pieces, s, best, declared, dt) if near == SCALE_FOUND else None
    if not rough:
        units = (np.pi / 180, 180 / np.pi)
        s = _round_scale(s, best, lambda f: _long_drift(pieces, f, fit_bias=True), grid[0], grid[-1], units)
    unit = next((u for u in _SCALES if u != 1.0 and abs(np.log(s / u)) < np.log(SCALE_NEAR)), None)
    return replace(UnitHint("unit", unit) if unit else _time_words(s, dt), rough=rough)


def _few_percent(pieces: list[tuple], s: float, best: float, declared: float, dt: float) -> UnitHint | None:
    """The warning hint (``warn``) of a whole log whose gyro holds gravity best a few percent off the declared factor
    (:data:`SCALE_WARN` up to :data:`SCALE_NEAR`) at :data:`SCALE_WARN_RATIO` of the declared drift or less, else
    None; ``s``, ``best``: the search's factor and its drift (bias fitted), found again here with the fitted bias
    (which the rest bias leaves ~1 % off) where they pass."""
    # (the rest bias leaves the factor up to 1 % nearer 1: the nine as declared end here, at no further cost)
    if abs(np.log(s)) < np.log(SCALE_WARN) - 0.01 or best > SCALE_WARN_RATIO * declared:
        return None
    s, best = _scan(pieces, s * np.exp(np.linspace(-0.02, 0.02, 9)), fit_bias=True)
    if not np.log(SCALE_WARN) <= abs(np.log(s)) < np.log(SCALE_NEAR) or best > SCALE_WARN_RATIO * declared:
        return None
    return replace(_time_words(s, dt), warn=True)


def _pieces_body(pieces: list[tuple]) -> float:
    """How far gravity turns in the body over the pieces (rad, RMS of :func:`_body_turn` with
    :data:`LONG_MEANS_S`-s means, weighted by their bins)."""
    body = [_body_turn(a, T, LONG_MEANS_S) ** 2 for _, a, T in pieces]
    return float(np.sqrt(np.average(body, weights=[p[0].shape[0] for p in pieces])))


def _drifts_enough(pieces: list[tuple]) -> bool:
    """Whether the declared gyro with the rest bias drifts gravity far enough for the whole-log search:
    :data:`LONG_FLOOR` (:data:`LOW_AXES_FLOOR` where gravity hardly turns in the body, < :data:`LONG_BODY`), or
    :data:`WARN_FLOOR` where it turns (a factor of a few percent is then only said)."""
    drift = _long_drift(pieces, 1.0)
    if drift >= min(LONG_FLOOR, LOW_AXES_FLOOR):
        return True
    return drift >= WARN_FLOOR and _pieces_body(pieces) >= LONG_BODY


def _long_axes_hint(pieces: list[tuple], declared: float, body: float, tiny: float | None = None) -> UnitHint | None:
    """The "axes" hint of the whole log (:func:`long_time_hint`'s pieces and judgement): the signed permutation of
    the gyro's axes that holds gravity in the gyro-integrated frame, where no factor does, else None. BROAD 16's
    gyro negated ran with exit 0 at 75°: its fast translation hides gravity's turning over the unit windows (0.23
    rad), the whole log drifts 0.99 rad as declared and 0.03 with the signs back. ``tiny``: where gravity hardly
    turns in the body, the drift of a gyro scaled to nothing — the permutation must hold gravity clearly better
    than it (:data:`LOW_BODY_TINY`), as a factor must: BROAD 11 and 27 (turning about the vertical) with two gyro
    axes swapped or one negated ran at 4-11° with exit 0; as declared they drift 0.16-0.23 rad, with the axes
    back 0.012-0.013, a gyro scaled to nothing 0.027-0.036."""
    from optinav.core.rotations import describe_permutation, signed_permutations

    perms = signed_permutations()[1:]
    i = int(np.argmin([_long_drift([(g @ P, a, T) for g, a, T in pieces], 1.0) for P in perms]))
    P = perms[i]
    best = _long_drift([(g @ P, a, T) for g, a, T in pieces], 1.0, fit_bias=True)
    if tiny is not None:
        if not (best < TIME_RATIO * declared and best < LOW_BODY_TINY * tiny):
            return None
    elif not (best < TIME_RATIO * declared and best < CONSISTENCY_BAD and best < 0.5 * body):
        return None
    return UnitHint("axes", 1.0, describe_permutation(P, "gyro", "accelerometer axes"), P)


#: s, the bins in which :func:`axes_turn_hint` compares the gyro's rotation with the turn of gravity in the body:
#: shorter bins let a hand's tremor turn the accelerometer's means (imucal's session in 0.08-s bins took its gyro's y
#: for negated), longer ones average over the 90° turns between poses
AXES_BIN_S = 0.3
#: a bin's mean specific force is taken as gravity's direction where its norm is within this share of g (translation
#: and a lever arm's pull turn it otherwise)
AXES_GRAVITY_TOL = 0.1
#: an order of the gyro's axes other than the declared one is named where it beats every other order by at least
#: AXES_Z standard errors of the turns that tell the two apart, takes at least AXES_BETA of them (1 where it is
#: right, −1 where the other is) and correlates with gravity's turns at SHORT_CORRELATION or better. BROAD's nine
#: trials and imucal's two sessions as recorded, whole and cut into 5-80 s at up to seven starts, at their rate and
#: a third and a sixth of it (783 logs): the best other order reaches 0.43 of these bounds (the least of its two
#: ratios); imucal's example session with one axis of either triad negated 1.45-1.61, the order that undoes it
AXES_Z, AXES_BETA = 5.0, 0.5
#: the neighbouring bins holding gravity (30 s of them) below which no order is named: the standard errors of fewer
#: pairs are themselves uncertain (a 10-s cut of imucal's session at a third of its rate, 30 pairs, took its gyro's
#: y and z for swapped at 5.05 of them)
AXES_MIN_PAIRS = 100


def axes_bin_rows(dt: float) -> int:
    """Samples per bin of :func:`axes_turn_hint` at the step ``dt`` s (:data:`AXES_BIN_S`)."""
    return max(1, int(round(AXES_BIN_S / dt)))


def axes_turn_hint(bins: np.ndarray, sums: np.ndarray, m: int, dt: float) -> UnitHint | None:
    """The "axes" hint of the whole log judged body axis by body axis: a signed order P of the gyro's axes (one of
    the 48) under which the gyro turns gravity in the body as the accelerometer sees it turn, where the declared
    order does not. Between neighbouring bins a body-frame vector turns against the body, u × u′ ≈ −θ⊥, so each
    axis's turns are judged on their own: a negated accelerometer axis turns gravity the wrong way about the two
    other axes, a negated gyro axis about its own — where the body turns about those axes, wherever in the log.
    The unit windows judge 20 s, which may hold turns about one or two axes only (imucal's session with its
    accelerometer's x negated: turns about x and the vertical, exit 0). ``bins``/``sums``: :func:`time_bins` of
    ``m``-sample bins (:func:`axes_bin_rows`, merged), ``dt`` the median step (s)."""
    from optinav.core.rotations import describe_permutation

    found = axes_turn_margin(bins, sums, m, dt)
    if found is None or found[1] < 1.0:
        return None
    P = found[0]
    return UnitHint("axes", 1.0, describe_permutation(P, "gyro", "accelerometer axes"), P)


def axes_turn_margin(bins: np.ndarray, sums: np.ndarray, m: int, dt: float) -> tuple[np.ndarray, float] | None:
    """(P, margin) of :func:`axes_turn_hint`: the signed order P ≠ identity of the gyro's axes whose rotations
    correlate best with gravity's turns in the body (at least :data:`SHORT_CORRELATION`), and how clearly it beats
    every other order — the least over them of β / :data:`AXES_BETA` and β / (:data:`AXES_Z` × its standard error),
    β the share of the turns telling the two apart that P takes (the accelerometer's turns regressed on what the
    two orders share and on where they differ: 1 where P is right, −1 where the other is); P is named from 1. None
    where the declared order correlates best, the correlation is lower, fewer than AXES_MIN_PAIRS neighbouring
    bins hold gravity, or no turn tells P from another order (an axis never turned about). 1.7 ms per million
    samples where the declared order is best (the bins, :func:`time_bins`, 5.6 ms)."""
    from optinav.core.rotations import signed_permutations

    if bins.shape[0] < 3:
        return None
    count, span = sums[:, 7], sums[:, 3]
    a = sums[:, 4:7] / np.maximum(count, 1.0)[:, None]
    na = _norm(a)
    good = (count == m) & (span <= LOST_STEPS * m * dt) & (np.abs(na - G_STANDARD) < AXES_GRAVITY_TOL * G_STANDARD)
    u = a / (na[:, None] + 1e-300)
    th = 0.5 * (sums[:-1, :3] + sums[1:, :3])
    keep = good[:-1] & good[1:] & (np.diff(bins) == 1) & (_norm(th) <= MAG_TURN_STEP)
    if np.count_nonzero(keep) < AXES_MIN_PAIRS:
        return None
    u0, u1, th = u[:-1][keep], u[1:][keep], th[keep]
    r = -np.cross(u0, u1)  # the accelerometer's turn: ⊥ the pair's mean direction um
    um = u0 + u1
    um /= _norm(um)[:, None] + 1e-300
    perms = np.array(signed_permutations())
    A = np.einsum("pab,ab->p", perms, th.T @ r)  # Σ r·T_P, T_P = (θ P)⊥um (r ⊥ um)
    b = int(np.argmax(A))
    if b == 0:
        return None  # the declared order turns gravity best (a correct log ends here)
    k = th.shape[0]
    # Σ over pairs of T_P·T_Q as one 9×9 product: the 48×48 orders then cost nothing per pair
    proj = (np.eye(3)[None] - um[:, :, None] * um[:, None, :]).reshape(k, 9)
    W = ((th[:, :, None] * th[:, None, :]).reshape(k, 9).T @ proj).reshape(3, 3, 3, 3)  # [a, d, b, c]
    G = np.einsum("pab,qdc,adbc->pq", perms, perms, W)
    rr = float(np.sum(r * r))
    if A[b] < SHORT_CORRELATION * np.sqrt(rr * G[b, b]):
        return None
    margin = np.inf
    for q in range(perms.shape[0]):
        if q == b:
            continue
        # r ≈ α c + β d, c and d what P and Q share and where they differ
        cc, dd = 0.25 * (G[b, b] + 2 * G[b, q] + G[q, q]), 0.25 * (G[b, b] - 2 * G[b, q] + G[q, q])
        cd, rc, rd = 0.25 * (G[b, b] - G[q, q]), 0.5 * (A[b] + A[q]), 0.5 * (A[b] - A[q])
        if dd <= 1e-9 * G[b, b]:
            return None  # no turn tells P from Q
        det = cc * dd - cd * cd
        if cc <= 1e-9 * dd or det <= 1e-12 * cc * dd:  # Q = −P: they share nothing
            beta, var = rd / dd, 1.0 / dd
            ssr = rr - 2 * beta * rd + beta * beta * dd
        else:
            alpha, beta, var = (rc * dd - rd * cd) / det, (rd * cc - rc * cd) / det, cc / det
            ssr = rr - 2 * (alpha * rc + beta * rd) + alpha * alpha * cc + 2 * alpha * beta * cd + beta * beta * dd
        se = np.sqrt(max(ssr, 0.0) / (2 * k) * var)  # r has two degrees of freedom per pair
        margin = min(margin, beta / AXES_BETA, beta / (AXES_Z * se + 1e-300))
    return perms[b], float(margin)


def check_imu(
    gyr: np.ndarray,
    acc: np.ndarray,
    dts: np.ndarray,
    *,
    gyro_range: float | None = None,
    gyro_unit: str | None = None,
    rest: np.ndarray | None = None,
) -> None:
    """Refuse inputs whose magnitudes contradict their declared units (acc m/s², gyr rad/s), swapped triads, an
    axis of either triad negated or out of order (:func:`axes_turn_hint`), an accelerometer without gravity and a
    clipped (saturated) gyro. ``gyro_range`` rad/s: the sensor's range if
    known; ``gyro_unit``: the unit the gyro was declared in before it was converted (named in the messages; None:
    not known, the messages name the usual deg/s ↔ rad/s mix-up); ``rest``: a bias (3,) rad/s the gyro reads at
    rest (:func:`rest_offset`), taken off before its unit, time base and axes are judged."""
    na = _norm(acc)
    ng = _norm(gyr)
    dt = float(np.median(dts))
    check_rate(dt)
    head = slice(0, DEAD_HEAD_ROWS)
    noisy = (noisy_axes(gyr[head]), noisy_axes(acc[head]))
    extremes = np.stack([axis_extremes(gyr), axis_extremes(acc)])
    check_dead_axes(extremes, gyr.shape[0], noisy)
    held = HeldRows()
    held.add(gyr, acc)
    held.check(dt, noisy)
    wraps = Wraps()
    wraps.add(gyr, dts)
    wraps.check()
    stuck = StuckAxes()
    stuck.add(gyr, acc)
    stuck.check(dt, extremes, noisy)
    bins, sums = tilt_sums(acc)
    share = gravity_share(bins, sums, dt, na, ng)
    low = (float(np.percentile(na, LOW_PERCENTILE)), float(np.percentile(ng, LOW_PERCENTILE)))
    check_norms(float(np.median(na)), float(np.median(ng)), float(np.max(ng)), gyro_unit, share, low)
    rows = scale_bin_rows(dt)
    # before the time base and the axes: a gyro off the accelerometer's clock was named "axes swapped"
    check_gyro_lag(*field_rate_sums(gyr, acc, rows), rows * dt)
    gu = gyr if rest is None else gyr - rest  # (the windows and bins are placed by the gyro as read)
    # window by window as a streamed log is (StreamChecks.finish_second): no still window, gravity judged there too
    windows = (
        (gu[sl], acc[sl], dts[sl] if dts.shape[0] > 1 else dts, float(np.max(ng[sl])))
        for sl in unit_windows(ng, dts, bins, sums)
    )
    m = axes_bin_rows(dt)
    axes = lambda: axes_turn_hint(*time_bins(gu, acc, dts, m), m, dt)  # noqa: E731
    whole = lambda: long_time_hint(*whole_log_bins(gu, acc, dts, ng), dt)  # noqa: E731
    check_time_base(windows, whole, gyro_unit, share, axes)
    _check_clipping(gyr, gyro_range, dt, acc)


def axis_extremes(x: np.ndarray) -> np.ndarray:
    """Per axis of ``x`` (n, 3) the largest of +x and of −x (3, 2), column by column: numpy reduces a strided
    column 8x faster than an (n, 3) array along axis 0 (that took half of :func:`check_imu`'s time)."""
    return np.array([[x[:, k].max(), -x[:, k].min()] for k in range(x.shape[1])])


#: samples from which a triad's axis that reads one value in all of them, while another axis of it varies, is dead
DEAD_MIN_ROWS = 100
#: the first rows of a log on which the other axes' noise is judged (:func:`noisy_axes`)
DEAD_HEAD_ROWS = 4096


def noisy_axes(x: np.ndarray) -> np.ndarray:
    """Which axes of ``x`` (m, 3; a log's first rows) carry a sensor's noise: their second differences as large as
    half their first ones, or their third as large as :data:`NOISE_D3` × their second (white noise: √3× and 1.83×;
    a noise-free simulated motion's are far smaller, 0.02-0.8×). In motion the first differences are the motion's
    (BROAD's gyros from 5 s into it: 0.32-0.64×), the third still the noise's (1.44-1.86×): a log that starts in
    motion was judged noise-free, and its dead or frozen axes were not judged."""
    if x.shape[0] < 10:
        return np.zeros(x.shape[1], bool)
    d1 = np.abs(np.diff(x, axis=0))
    d2 = np.abs(np.diff(x, 2, axis=0))
    d3 = np.abs(np.diff(x, 3, axis=0))
    m1, m2 = np.nanmean(d1, axis=0), np.nanmean(d2, axis=0)
    return (m1 > 0) & ((m2 > 0.5 * m1) | (np.nanmean(d3, axis=0) > NOISE_D3 * m2))


#: the ratio of mean |third| to mean |second| differences from which an axis carries noise (:func:`noisy_axes`)
NOISE_D3 = 1.2


def check_dead_axes(extremes: np.ndarray, n: int, noisy) -> None:
    """Refuse a gyro or accelerometer axis that reads one value in every sample of the log (its largest and smallest
    equal; ``extremes`` (2, 3, 2): per triad and axis the largest of +x and of −x, :func:`axis_extremes`, rad/s and
    m/s²) while another axis of the triad varies with a sensor's noise (``noisy``: (gyro, accelerometer) (3,) bool, :func:`noisy_axes`; a noise-free
    simulated yaw keeps its gyro's x and y at 0), from :data:`DEAD_MIN_ROWS` samples (``n``): BROAD 02 with its
    gyro's x at 0 ran at 75.6° inclination RMSE with exit 0 (0.39° as recorded), with its accelerometer's y at 0
    at 5.6°."""
    if n < DEAD_MIN_ROWS:
        return
    for name, ext, unit, loud in zip(("gyro", "accelerometer"), extremes, ("rad/s", "m/s^2"), noisy):
        dead = ext[:, 0] == -ext[:, 1]
        if dead.any() and np.any(np.asarray(loud) & ~dead):
            k = int(np.argmax(dead))
            raise OptinavError(
                f"{name} axis {'xyz'[k]} reads {float(ext[k, 0]):.6g} {unit} in every one of the {n} samples while its "
                "other axes vary: a dead axis, or a column that is not the sensor's",
                "check the columns (--columns) and the sensor; no attitude is reliable without that axis",
            )


#: s: a whole sample (gyro and accelerometer) repeated this long while its gyro reads a turn (≥ HELD_TURN rad/s)
#: or its accelerometer 0 on three axes is a logger that stalled or padded: BROAD 02 with every channel held for 2 s
#: in motion ran at 5.2° inclination and 39.5° heading RMSE with exit 0 (0.39° and 0.70° as recorded), for 10 s at
#: 30.8°, with 2 s of zeros at 81.5° heading. No sensor repeats a turn bit for bit (a body at rest may repeat a
#: coarsely logged sample: not judged)
HELD_S, HELD_TURN = 0.5, 0.1


class HeldRows:
    """The longest run of a whole sample (gyro and accelerometer) repeated while its gyro reads a turn
    (:data:`HELD_TURN`) or its accelerometer 0 on three axes, over the blocks of a log fed in order (:meth:`add`);
    :meth:`check` refuses one of :data:`HELD_S` or more."""

    def __init__(self):
        self.n, self.last, self.start, self.length = 0, None, 0, 0
        self.best = (0, 0, 0.0, 0.0)  # rows, first row, the held gyro's and accelerometer's norms (rad/s, m/s²)

    def add(self, gyr: np.ndarray, acc: np.ndarray) -> None:
        n = gyr.shape[0]
        if not n:
            return
        same = np.zeros(n, bool)  # row i repeats row i − 1 (NaN never does)
        same[0] = self.last is not None and bool(np.all(gyr[0] == self.last[0]) and np.all(acc[0] == self.last[1]))
        same[1:] = True
        for x in (gyr, acc):  # (column by column: faster than np.all along axis 1 of an (n, 3) comparison)
            for k in range(3):
                same[1:] &= x[1:, k] == x[:-1, k]
        for a, b in mask_runs(same):
            start, rows = (self.start, self.length + b) if a == 0 else (self.n + a - 1, b - a + 1)
            turn, force = float(np.linalg.norm(gyr[b - 1])), float(np.linalg.norm(acc[b - 1]))
            # (an accelerometer at exactly 0 on three axes is no sample: a logger's padding)
            if (turn >= HELD_TURN or force == 0.0) and rows > self.best[0]:
                self.best = (rows, start, turn, force)
            if b == n:
                self.start, self.length = start, rows
        if not same[-1]:
            self.start, self.length = self.n + n - 1, 1
        self.last = (gyr[-1].copy(), acc[-1].copy())
        self.n += n

    def check(self, dt: float, noisy) -> None:
        """Refuse the longest run from :data:`HELD_S` (``dt`` the median step, s) in a log whose sensors show their
        noise (``noisy``: :func:`noisy_axes` of the gyro and the accelerometer; a noise-free simulated turn at a
        constant rate repeats its sample throughout)."""
        rows, start, turn, force = self.best
        if rows >= max(5, HELD_S / dt) and any(np.any(x) for x in noisy):
            raise OptinavError(
                f"rows {start + 1}-{start + rows} repeat one whole sample for {rows * dt:.3g} s (gyro {turn:.3g} rad/s, "
                f"accelerometer {force:.3g} m/s^2; no sensor repeats a turn bit for bit, nor reads 0 on three axes): a "
                "logger that stalled, or filled samples it lost with the last one or zeros",
                "remove those rows (the time column then shows the gap), or record again",
            )


#: a magnetometer that holds its reading this long (s) while the gyro turns the body this far (rad, ∫|ω|dt):
#: one stuck from mid-motion to the end ran at 15-35° heading RMSE with exit 0, a dead axis (always 0) at
#: 29-144°. BROAD's magnetometers repeat a sample for at most 14 rows (0.05 s) between their updates
MAG_HELD_S, MAG_HELD_TURN = 2.0, 1.0


class MagHeld:
    """The longest stretch over which the magnetometer repeats one reading — the whole sample, or one axis while
    its others change — while the gyro turns the body (:data:`MAG_HELD_S`, :data:`MAG_HELD_TURN`), over the blocks
    of a log fed in order (:meth:`add`; rows without a field are skipped, their turn counted); :meth:`check`
    refuses it: no field stays the same in a turning body."""

    def __init__(self):
        self.n = 0
        self.prev = None  # the last finite magnetometer row
        self.pending = np.zeros(2)  # turn (rad) and time (s) since that row
        # per column (axis x, y, z; 3 the whole sample): the open run (first row, turn, time, other axes changed)
        self.open: list = [None] * 4
        self.best = [(0.0, 0.0, 0, c, 0.0) for c in range(4)]  # per column: turn, time, first row, column, value
        self.rows = self.repeats = 0  # rows with a field, and those repeating the one before (:meth:`hold_s`)

    def add(self, gyr: np.ndarray, mag: np.ndarray, dts: np.ndarray) -> None:
        """One block: gyr (n, 3) rad/s, mag (n, 3) any unit (NaN rows: no sample), dts (n,) or (1,) s."""
        n = gyr.shape[0]
        if not n:
            return
        inc = np.column_stack([_norm(gyr) * np.broadcast_to(dts, (n,)), np.broadcast_to(dts, (n,))])
        cum = np.cumsum(inc, axis=0)
        idx = np.flatnonzero(np.isfinite(mag).all(axis=1))
        if not idx.size:
            self.pending += cum[-1]
            self.n += n
            return
        m = mag[idx]
        seg = np.diff(np.vstack([np.zeros((1, 2)), cum[idx]]), axis=0)  # turn and time since the finite row before
        seg[0] += self.pending
        prev = np.vstack([np.full((1, 3), np.nan) if self.prev is None else self.prev[None, :], m[:-1]])
        eq = m == prev
        self.rows += len(idx)
        self.repeats += int(np.count_nonzero(eq.all(axis=1)))
        cs = np.vstack([np.zeros((1, 2)), np.cumsum(seg, axis=0)])  # the runs' turn and time, from sums
        for c in range(4):
            same = eq.all(axis=1) if c == 3 else eq[:, c]
            other = np.zeros(len(idx), bool) if c == 3 else (~eq[:, [j for j in range(3) if j != c]]).any(axis=1)
            runs = mask_runs(same)
            if not runs.size:
                self.open[c] = None
                continue
            # all runs at once (a magnetometer slower than the IMU repeats its sample between updates: thousands
            # of short runs a block, a Python loop over them was most of an estimate's input checks)
            a, b = runs[:, 0], runs[:, 1]
            turn, time = (cs[b] - cs[a]).T
            co = np.r_[0, np.cumsum(other)]
            changed = co[b] > co[a]
            start = self.n + idx[a] - 1
            if a[0] == 0 and self.open[c] is not None:  # the run left open by the block before goes on
                s0, t0, ti0, o0 = self.open[c]
                start[0], turn[0], time[0], changed[0] = s0, turn[0] + t0, time[0] + ti0, changed[0] or o0
            ok = np.flatnonzero(changed) if c < 3 else np.arange(len(runs))
            if ok.size:
                j = ok[np.argmax(turn[ok])]  # the first of the longest turns, as a run-by-run pass kept it
                if turn[j] > self.best[c][0]:
                    self.best[c] = (float(turn[j]), float(time[j]), int(start[j]), c, float(m[a[j], min(c, 2)]))
            last = (int(start[-1]), float(turn[-1]), float(time[-1]), bool(changed[-1]))
            self.open[c] = last if b[-1] == len(idx) else None
        self.prev = m[-1].copy()
        self.pending = cum[-1] - cum[idx[-1]]
        self.n += n

    def hold_s(self, dt: float) -> float:
        """How late (s) the field is on average on the rows it fills by repeating a reading between its updates (a
        magnetometer slower than the IMU held on its rows, ``dt`` s a row): each reading held L rows is (L − 1)/2
        rows old on average; 0 where each row with a field has a reading of its own."""
        if self.rows <= self.repeats:
            return 0.0
        return 0.5 * (self.rows / (self.rows - self.repeats) - 1.0) * dt

    def check(self) -> None:
        # the whole sample first: an axis's run of a stuck sample began with the axis's own repeats before it
        held = [b for b in (self.best[3], *self.best[:3]) if b[1] >= MAG_HELD_S and b[0] >= MAG_HELD_TURN]
        if not held:
            return
        turn, time, start, c, value = held[0] if held[0][3] == 3 else max(held)
        what = (
            "the magnetometer repeats one reading"
            if c == 3
            else f"magnetometer axis {'xyz'[c]} reads {value:.6g} while its other axes change"
        )
        raise OptinavError(
            f"{what} for {time:.3g} s from row {start + 1} while the gyro turns the body {np.degrees(turn):.0f}°: "
            "no field holds still in a turning body — "
            + (
                "a magnetometer that stopped, or a logger holding its last value" if c == 3 else "a dead or frozen axis"
            ),
            "check the magnetometer and --mag-columns, or drop --mag (6D)",
        )


#: a gyro axis whose reading flips sign between two samples, both beyond WRAP_SHARE of its largest |reading|, from
#: WRAP_MIN rad/s (below the smallest common range, 125 °/s): readings that wrap around at the range. BROAD 07 with
#: its counts wrapped at ±250 °/s ran at 52° with exit 0; the nine trials as recorded flip at ≤ 0.16 of their
#: largest (24's taps), a wrap at ≥ 0.99. (An accelerometer's taps flip at up to 0.78: not judged.)
WRAP_SHARE, WRAP_MIN = 0.75, 2.0


class Wraps:
    """The largest sign flip between consecutive gyro samples per axis (the smaller of the two magnitudes) over
    the blocks of a log fed in order (:meth:`add`); :meth:`check` refuses one that wraps (:data:`WRAP_SHARE`)."""

    def __init__(self):
        self.n, self.last = 0, None
        self.peak = np.zeros(3)  # largest |reading| per axis (rad/s)
        self.flip = np.zeros(3)  # largest flip per axis (rad/s), its first row and the two readings
        self.row = np.zeros(3, np.int64)
        self.pair = np.zeros((3, 2))

    def add(self, gyr: np.ndarray, dts: np.ndarray | None = None) -> None:
        """A block of gyro rows (n, 3) rad/s; with its steps ``dts`` (n,) s a flip across a step that lost samples
        (beyond LOST_STEPS of the block's median) is a turn the body made meanwhile, not judged (a 0.2-s dropout in
        BROAD 07 was named a wrap)."""
        n = gyr.shape[0]
        if not n:
            return
        a = np.abs(gyr)
        neg = np.signbit(gyr)
        m = np.minimum(a[1:], a[:-1])
        m *= neg[1:] != neg[:-1]  # (only sign flips count)
        lost0 = False
        if dts is not None and np.shape(dts)[0] == n and n >= 3:
            lost = np.asarray(dts) > LOST_STEPS * float(np.median(dts))
            m *= ~lost[1:, None]
            lost0 = bool(lost[0])
        for k in range(3):  # (column by column: numpy reduces a strided column 8x faster than along axis 0)
            self.peak[k] = np.fmax(self.peak[k], np.nanmax(a[:, k]))
            if self.last is not None and not lost0 and np.signbit(self.last[k]) != neg[0, k]:
                self._keep(k, min(abs(self.last[k]), a[0, k]), self.n - 1, self.last[k], gyr[0, k])
            if n > 1:
                i = int(np.argmax(m[:, k]))
                self._keep(k, m[i, k], self.n + i, gyr[i, k], gyr[i + 1, k])
        self.last = gyr[-1].copy()
        self.n += n

    def _keep(self, k: int, size: float, row: int, a: float, b: float) -> None:
        if size > self.flip[k]:
            self.flip[k], self.row[k], self.pair[k] = size, row, (a, b)

    def check(self) -> None:
        wrapped = (self.flip >= WRAP_SHARE * self.peak) & (self.peak >= WRAP_MIN)
        if wrapped.any():
            k = int(np.argmax(wrapped))
            (a, b), r, top = self.pair[k], int(self.row[k]), float(self.peak[k])
            raise OptinavError(
                f"gyro axis {'xyz'[k]} jumps from {a:+.4g} to {b:+.4g} rad/s between rows {r + 1} and {r + 2}, both "
                f"near its largest reading {top:.4g} rad/s ({np.degrees(top):.4g} deg/s): readings that wrap around at "
                "the sensor's range (counts read as the wrong integer type, or an offset added in too few bits), no "
                "turn a body makes",
                "read the counts as signed integers of the sensor's width before scaling them (or record with a "
                "larger range)",
            )


#: one axis of a triad holding its value bit for bit this long (s), and for more rows than chance gives at the
#: share of steps it repeats in the log (p^(rows − 1)·n < STUCK_CHANCE), while the triad's other axes show motion
#: (the gyro's turn at STUCK_TURN rad/s, the accelerometer's other axes moving over STUCK_FORCE m/s²): an axis that
#: froze. BROAD 02 with its gyro's x frozen for 10 s in motion ran at 27° with exit 0, its accelerometer's z at
#: 23°; the nine hold an axis at most 10 samples (35 ms). A quiet axis of a coarsely quantized sensor repeats at
#: rest, and in a turn about another axis, as often as its share says: not judged (a gyro axis at exactly 0 alike,
#: a driver's dead band)
STUCK_S, STUCK_CHANCE, STUCK_TURN, STUCK_FORCE = 0.5, 1e-6, 0.1, 1.0
_STUCK_MIN = 16  # rows from which a run is looked at


class StuckAxes:
    """Per axis of the gyro and the accelerometer, the longest run of one value held while the triad's other axes
    show motion, over the blocks of a log fed in order (:meth:`add`), and how often each axis repeats from one
    sample to the next; :meth:`check` refuses a run beyond chance (:data:`STUCK_S`, :data:`STUCK_CHANCE`)."""

    def __init__(self):
        self.n = 0
        self.repeats = np.zeros((2, 3), np.int64)  # steps where the axis repeats its value
        self.best = np.zeros((2, 3, 3))  # rows, first row, value of the longest run in motion
        self.motion = np.zeros((2, 3))  # the other axes' motion in that run (rad/s, m/s²)
        self.last: list = [None, None]  # per triad: the last row
        # per triad and axis, the run that reaches the last row: first row, rows, motion (turn; force max, min x2)
        self.open = np.zeros((2, 3, 6))

    def add(self, gyr: np.ndarray, acc: np.ndarray) -> None:
        n = gyr.shape[0]
        if not n:
            return
        for t, x in enumerate((gyr, acc)):
            last = self.last[t]
            same = np.empty((n, 3), bool)  # row i holds row i - 1's value
            same[0] = False if last is None else x[0] == last
            np.equal(x[1:], x[:-1], out=same[1:])
            # a run of _STUCK_MIN rows within the block needs x[i] = x[i + _STUCK_MIN - 1]: the runs are walked only
            # where that holds somewhere, or a run comes in from the last block or goes on into the next (column by
            # column: numpy reduces a strided column 8x faster than along axis 0)
            m = _STUCK_MIN - 1
            for k in range(3):
                self.repeats[t, k] += np.count_nonzero(same[:, k])
                cand = n > m and np.count_nonzero(x[m:, k] == x[: n - m, k]) > 0
                if cand or same[0, k] or same[-1, k]:
                    self._runs(t, k, x, same[:, k])
                else:
                    self._open_last(t, k, x, n)
            self.last[t] = x[-1].copy()
        self.n += n

    def _runs(self, t: int, k: int, x: np.ndarray, same: np.ndarray) -> None:
        n = x.shape[0]
        o = [j for j in range(3) if j != k]
        runs = mask_runs(same)
        carried = bool(runs.shape[0]) and runs[0, 0] == 0 and self.n > 0
        first = runs[:, 0] - 1  # the run's first row in the block (its value's first sample)
        rows = runs[:, 1] - first
        if carried:
            rows[0] += int(self.open[t, k, 1]) - 1
        long = np.flatnonzero(rows >= _STUCK_MIN)
        if long.size:
            lo, hi = np.maximum(first[long], 0), runs[long, 1]
            edges = np.column_stack([lo, hi]).ravel()
            if t == 0:
                turn = np.hypot(x[:, o[0]], x[:, o[1]])
                moved = np.maximum.reduceat(turn, edges[:-1] if hi[-1] == n else edges)[::2]
            else:
                e = edges[:-1] if hi[-1] == n else edges
                up = [np.maximum.reduceat(x[:, j], e)[::2] for j in o]
                dn = [np.minimum.reduceat(x[:, j], e)[::2] for j in o]
            for i, r in enumerate(long):
                if t == 0:
                    m = float(moved[i])
                    if carried and r == 0:
                        m = max(m, self.open[t, k, 2])
                else:
                    hs, ls = [up[0][i], up[1][i]], [dn[0][i], dn[1][i]]
                    if carried and r == 0:
                        hs = [max(hs[0], self.open[t, k, 2]), max(hs[1], self.open[t, k, 3])]
                        ls = [min(ls[0], self.open[t, k, 4]), min(ls[1], self.open[t, k, 5])]
                    m = float(max(hs[0] - ls[0], hs[1] - ls[1]))
                start = self.open[t, k, 0] if carried and r == 0 else self.n + first[r]
                value = x[max(first[r], 0), k]
                # a gyro axis at exactly 0 too: a driver's dead band zeroes it in turns about the other axes often,
                # and the chance test of check() lets that pass (a frozen 0 in motion ran 68° off with exit 0)
                if m >= (STUCK_TURN, STUCK_FORCE)[t] and rows[r] > self.best[t, k, 0]:
                    self.best[t, k] = (rows[r], start, value)
                    self.motion[t, k] = m
        # the run that reaches the block's last row stays open for the next block
        if runs.shape[0] and runs[-1, 1] == n:
            r = runs.shape[0] - 1
            a = max(int(first[r]), 0)
            start = self.open[t, k, 0] if carried and r == 0 else self.n + first[r]
            seg = x[a:, :]
            if t == 0:
                m = float(np.hypot(seg[:, o[0]], seg[:, o[1]]).max())
                prev = self.open[t, k, 2] if carried and r == 0 else 0.0
                self.open[t, k] = (start, rows[r], max(m, prev), 0, 0, 0)
            else:
                h = [float(seg[:, j].max()) for j in o]
                lw = [float(seg[:, j].min()) for j in o]
                if carried and r == 0:
                    h = [max(h[0], self.open[t, k, 2]), max(h[1], self.open[t, k, 3])]
                    lw = [min(lw[0], self.open[t, k, 4]), min(lw[1], self.open[t, k, 5])]
                self.open[t, k] = (start, rows[r], h[0], h[1], lw[0], lw[1])
        else:
            self._open_last(t, k, x, n)

    def _open_last(self, t: int, k: int, x: np.ndarray, n: int) -> None:
        """The block's last row (of ``n``) opens a run of one row on axis k of triad t."""
        v = x[-1, [j for j in range(3) if j != k]]
        turn = float(np.hypot(v[0], v[1]))
        self.open[t, k] = (self.n + n - 1, 1, turn, 0, 0, 0) if t == 0 else (self.n + n - 1, 1, v[0], v[1], v[0], v[1])

    def check(self, dt: float, extremes: np.ndarray, noisy) -> None:
        """Refuse the longest run held in motion from :data:`STUCK_S` (``dt`` the median step, s) beyond chance, on
        an axis that carries a sensor's noise (``noisy``: :func:`noisy_axes` of the gyro and the accelerometer) and
        not at its largest or smallest reading (``extremes`` (2, 3, 2): per triad and axis the largest of +x and
        of −x): a clip, which the clipping checks judge."""
        steps = max(self.n - 1, 1)
        for t, (name, unit, what) in enumerate(
            (("gyro", "rad/s", "turn up to"), ("accelerometer", "m/s^2", "move over"))
        ):
            for k in range(3):
                rows, start, value = self.best[t, k]
                rest = steps - (rows - 1)  # the steps outside the run
                p = max(self.repeats[t, k] - (rows - 1), 0) / max(rest, 1)
                if (
                    rows < max(5, STUCK_S / dt)
                    or rest < DEAD_MIN_ROWS
                    or not noisy[t][k]
                    or value in (extremes[t, k, 0], -extremes[t, k, 1])
                    or (p > 0 and (rows - 1) * np.log(p) + np.log(self.n) > np.log(STUCK_CHANCE))
                ):
                    continue
                a = int(start)
                raise OptinavError(
                    f"{name} axis {'xyz'[k]} reads {value:.6g} {unit} in rows {a + 1}-{a + int(rows)} ({rows * dt:.3g} s) "
                    f"while its other axes {what} {self.motion[t, k]:.3g} {unit}: an axis that froze (elsewhere it "
                    f"repeats its value in {p:.0%} of the steps)",
                    "cut those rows out of the log, or record again; no attitude is reliable through them",
                )


#: sample rates (Hz) an IMU log can have: outside, the time column's unit or --rate is wrong
RATE_RANGE_HZ = (0.5, 100_000.0)


def check_rate(dt: float) -> None:
    """Refuse a median step ``dt`` (s) no IMU samples at (:data:`RATE_RANGE_HZ`): an epoch in ns read as s gave
    steps of 3.5e6 s, integrated with exit 0."""
    lo, hi = RATE_RANGE_HZ
    if not (1.0 / hi <= dt <= 1.0 / lo):
        raise OptinavError(
            f"the samples are {dt:.3g} s apart ({1.0 / dt:.3g} Hz), no IMU's rate: the time column's unit is wrong",
            "give the time column's unit (--time-unit s, ms, us or ns) or the sample rate (--rate)",
        )


#: in the 2-s windows where the gyro turns by less than GRAVITY_STILL_TURN rad, an accelerometer with gravity keeps
#: its norm in the window's mean (the nine BROAD trials: 0.98-1.0 of the median norm), a linear-acceleration output
#: (gravity removed by the phone or the IMU's fusion) keeps little of it: below this share it is refused
GRAVITY_SHARE = 0.5
GRAVITY_STILL_TURN = 0.2


def gravity_share(bins: np.ndarray, sums: np.ndarray, dt: float, na, ng: np.ndarray) -> float:
    """The median norm of the specific force's ~2-s means, over the windows in which the gyro turns by less than
    :data:`GRAVITY_STILL_TURN` rad (there gravity keeps its direction in the body), divided by the median norm
    or g, the smaller (``na``: the row norms or their median); ``bins``/``sums`` from :func:`tilt_sums`, ``ng`` the gyro's row norms
    (rad/s). NaN when no window is that still (or the log is shorter than 2 s)."""
    m = max(1, int(round(2.0 / (TILT_BIN * dt)))) if dt > 0 else 1
    if bins.size == 0:
        return float("nan")
    means = _grouped_tilt_sums(bins, sums, m) / (m * TILT_BIN)
    k = min(means.shape[0], ng.shape[0] // (m * TILT_BIN))
    if k == 0:
        return float("nan")
    means = means[:k]
    turn = ng[: k * m * TILT_BIN].reshape(k, m * TILT_BIN).sum(axis=1) * dt  # bounds the angle turned
    still = turn < GRAVITY_STILL_TURN
    # against g where the norm is larger: vibration of 2 g on a still mount doubles the median norm, not gravity
    med = min(float(np.median(na)) if np.ndim(na) else float(na), G_STANDARD)
    if not np.any(still) or med <= 0:
        return float("nan")
    return float(np.median(_norm(means[still]))) / med


#: a gyro's largest range, rad/s (4000 °/s): a peak beyond it is in another unit than declared
GYRO_MAX_RAD_S = 70.0

#: percentile of the row norms that tells a gyro from an accelerometer: a gyro at rest reads near zero, an
#: accelerometer reads g in any orientation (only free fall takes it near zero)
LOW_PERCENTILE = 5.0


def check_norms(
    med_a: float,
    med_g: float,
    peak: float,
    gyro_unit: str | None = None,
    share: float = float("nan"),
    low: tuple[float, float] = (float("nan"), float("nan")),
) -> None:
    """The part of :func:`check_imu` judged on the median norms of acc (m/s²) and gyr (rad/s), the gyro's peak
    norm and the accelerometer's :func:`gravity_share`: swapped triads, gravity removed, an accelerometer not in
    m/s² (a median over 3 g by gravity's norm where the gyro is still; with no still window that is left to
    :func:`check_gyro_unit`), a gyro beyond any range (``gyro_unit`` the declared one); ``low``: the
    :data:`LOW_PERCENTILE` of the acc and gyr row norms (NaN: not known)."""
    # swapped: the gyro columns read about g, and the accelerometer's are small or, where its norm falls near zero
    # (a gyro at rest) while the gyro's never does (an accelerometer), a fast-turning gyro's (BROAD 29, median
    # 3.6 rad/s: its swap was blamed on a linear-acceleration output)
    rest_like = low[0] < 0.1 * med_a and low[1] > 0.5 * med_g
    if (med_a < 0.3 * G_STANDARD or rest_like) and 0.3 * G_STANDARD < med_g < 3 * G_STANDARD:
        raise OptinavError(
            f"the accelerometer reads {med_a:.3g} and the gyro {med_g:.3g} (median norms): the two triads look swapped",
            "check the column order of --columns (t,ax,ay,az,gx,gy,gz), or for HDF5/MAT/NPZ --datasets (acc=NAME,gyro=NAME)",
        )
    if share < GRAVITY_SHARE:
        # a phone's linear acceleration was hinted as "g", and --acc-unit g then ran at 77°
        raise _gravity_removed(share, med_a, "while the gyro is still")
    if med_a < 0.3 * G_STANDARD:
        raise _acc_unit_error(med_a)
    if med_a > 3 * G_STANDARD and share >= 0.0:
        # a body shaken by several g reads so in m/s² (BROAD 16, 5 s from 56 s: median 38 m/s²): judged on gravity,
        # the still windows' 2-s means; without one, in the gyro-integrated frame (_check_moving_gravity)
        gravity = share * G_STANDARD
        if gravity > 3 * G_STANDARD:
            raise _acc_unit_error(med_a, gravity, "where the gyro is still")
    if peak > GYRO_MAX_RAD_S and gyro_unit == "counts":  # read by a datasheet sensitivity
        raise OptinavError(
            f"the gyro peaks at {np.degrees(peak):.3g} deg/s as read by its sensitivity, beyond any gyro's range",
            LSB_REMEDY,
        )
    if peak > GYRO_MAX_RAD_S:
        declared = peak / factor(gyro_unit or "rad/s")  # the number in the file
        if gyro_unit in (None, "rad/s") and declared * factor("deg/s") <= GYRO_MAX_RAD_S:
            raise OptinavError(
                f"the gyro peaks at {peak:.0f} rad/s: it looks like deg/s declared rad/s",
                "declare the unit with --gyro-unit deg/s",
            )
        # as deg/s beyond any range too (imucal's annotated session, counts: 8877): told deg/s, the user was refused
        # once more before hearing of counts
        acc = f"; the accelerometer's median norm {med_a:.4g} is not g either" if med_a > 3 * G_STANDARD else ""
        raise OptinavError(
            f"the gyro peaks at {np.degrees(peak):.3g} deg/s as declared in {gyro_unit or 'rad/s'} ({declared:.4g} "
            f"in the file), beyond any gyro's range: the data are in a finer unit (mdps? raw counts?){acc}",
            "pass --gyro-unit mdps for millidegrees per second; raw counts need their calibration first "
            "(optinav calibrate accel, then optinav apply), or their datasheet sensitivity (--gyro-lsb, --acc-lsb)",
        )


#: the remedy of a gyro in counts whose datasheet sensitivity (--gyro-lsb) contradicts the data
LSB_REMEDY = "check --gyro-lsb: counts per deg/s, from the datasheet at the range the logger set"


def unit_error(hint: UnitHint, gyro_unit: str | None = None) -> OptinavError:
    """The error of a hint of :func:`gyro_unit_hint` for a gyro declared in ``gyro_unit`` (converted to rad/s
    before the check; None: not known; "counts": read by a datasheet sensitivity): names the flag that fixes what
    was found, never the unit the user already gave."""
    if gyro_unit == "counts" and hint.kind != "axes":
        seen = hint.words or f"the gyro turns gravity ×{1.0 / hint.scale:.3g} as far as the accelerometer sees it turn"
        return OptinavError(
            f"{seen}: the gyro read by its sensitivity does not turn as gravity turns in the body; the time column, "
            "the sample rate or the sensitivity is off by that factor",
            f"{LSB_REMEDY}; or --rate, --time-unit",
        )
    if hint.kind == "time" and abs(np.log(hint.scale)) < np.log(SCALE_NEAR):
        # a few percent: a datasheet's nominal rate for the device's own, or a gyro whose scale is off by that much
        return OptinavError(
            f"{hint.words}: the sample rate or the time column is off by {_percent(hint.scale)}, or the gyro's "
            "scale is",
            f"check --rate (the data fit {hint.rate_hz:.4g} Hz) or the time column; a gyro whose scale is off needs "
            "its calibration (optinav calibrate, then optinav apply)",
        )
    if hint.kind == "time":
        return OptinavError(
            f"{hint.words}: the time column, the sample rate or the gyro's unit is off by that factor",
            f"check --rate (the data fit {'roughly ' if hint.rough else ''}{hint.rate_hz:.3g} Hz) or the time "
            f"column's unit (--time-unit), or --gyro-unit{_unit_and_rate(hint, gyro_unit)} (raw counts need their "
            "calibration, optinav apply)",
        )
    mirrored = hint.kind == "axes" and hint.P is not None and np.array_equal(hint.P, -np.eye(3))
    perm = (MIRROR_HINT if mirrored else f"{AXES_HINT}: {hint.words}") if hint.kind == "axes" else ""
    fix = MIRROR_REMEDY if mirrored else "fix the gyro's column order or signs (--columns)"
    if hint.kind == "axes" and hint.P is not None and not mirrored and np.linalg.det(hint.P) < 0:
        fix = f"fix the gyro's column order or signs (--columns t,ax,ay,az,{_column_names(hint.P, 'g')})"
    if hint.kind == "axes" and hint.P is not None and not mirrored and np.linalg.det(hint.P) > 0:
        perm, fix = _either_triad(hint.P, hint.words)
    seen = f" ({hint.words})" if hint.kind == "unit" and hint.words else ""
    if hint.scale == 1.0:
        return OptinavError(perm, fix)
    want = "deg/s" if hint.scale < 1.0 else "rad/s"
    seen_as = gyro_unit or "rad/s"  # the library takes rad/s: what it was declared in before is not known
    if gyro_unit is None:
        gyro_unit = "rad/s" if want == "deg/s" else "deg/s"
    if gyro_unit == ("rad/s" if want == "deg/s" else "deg/s"):
        # the usual mix-up: the other of the two units explains it
        if perm:
            return OptinavError(
                f"{perm}, and {want} declared {gyro_unit}",
                f"{fix}, and pass --gyro-unit {want}",
            )
        factor = "π/180" if want == "deg/s" else "180/π"
        extra = ""
        if seen:
            extra = f" ({hint.words}" + (
                "; if it is in rad/s, that bias is beyond any the estimators track: subtract it first)"
                if want == "deg/s"
                else ")"
            )
        return OptinavError(
            f"the gyro in {seen_as} does not explain how gravity turns in the body, a unit factor of {factor} does",
            f"it looks like {want} declared {gyro_unit}: --gyro-unit {want}{extra}",
        )
    more = "57× more" if hint.scale < 1.0 else "57× less"
    return OptinavError(
        (f"{perm}: " if perm else "")
        + f"the gyro declared {gyro_unit} reads {more} than turns gravity in the body{seen}",
        "check --gyro-unit: the data are in another unit (raw counts need their calibration, optinav apply)",
    )


def _percent(scale: float) -> str:
    """How far (%) a factor near 1 is from it."""
    return f"{abs(scale - 1.0) * 100:.2g} %"


def _unit_and_rate(hint: UnitHint, gyro_unit: str | None) -> str:
    """For a "time" factor beyond 10× that a unit factor (π/180, 180/π) brings within 3× of 1: the other unit and
    the rate the data fit with it (BROAD at --rate 200, its rad/s declared deg/s, was told "the data fit 4.98 Hz")."""
    if abs(np.log(hint.scale)) < np.log(10.0):
        return ""
    for u, want in ((np.pi / 180, "deg/s"), (180 / np.pi, "rad/s")):
        if abs(np.log(hint.scale / u)) < np.log(3.0) and gyro_unit != want:
            return f" {want} (the data then fit {hint.rate_hz * u:.3g} Hz)"
    return ""


#: the axes hint's first words
AXES_HINT = "the gyro axes look swapped or flipped"


def _either_triad(P: np.ndarray, words: str) -> tuple[str, str]:
    """(cause, remedy) of a gyro that reads the rotation ``P`` (det +1; ``words`` say it) of the accelerometer's
    axes: so reads a gyro with two axes flipped or its columns in another order, and as well an accelerometer with
    one axis negated or two swapped — a mirror image of the gyro's frame, in which a rotation (a pseudovector)
    reads −Pᵀ: its raw axes read M = −Pᵀ of the gyro's. Gravity cannot tell the two apart, and fixing the wrong
    one gives a consistent pair that turns as a mirror image of the body (BROAD 02 with its accelerometer's x
    negated was told to fix the gyro's y and z: 58° inclination RMSE with exit 0). The triad with fewer axes off is
    named first; the remedy gives the --columns of both for a file of columns t,ax,ay,az,gx,gy,gz."""
    from optinav.core.rotations import describe_permutation

    M = -P.T
    acc_words = describe_permutation(M, "accelerometer", "gyro axes")
    gyro_fix = f"the gyro's (--columns t,ax,ay,az,{_column_names(P, 'g')})"
    acc_fix = f"the accelerometer's (--columns t,{_column_names(M, 'a')},gx,gy,gz)"
    off = lambda Q: int(np.count_nonzero(np.diag(Q) != 1.0))  # noqa: E731
    acc_first = off(M) < off(P)
    first, second = (acc_fix, gyro_fix) if acc_first else (gyro_fix, acc_fix)
    return (
        f"{AXES_HINT}: {words}; or the accelerometer's, one axis negated or two swapped (a mirror image, which "
        f"gravity cannot tell from that): {acc_words}",
        f"fix the column order or signs of {first}, or if that triad is right, of {second}; for the one you fix "
        "wrongly the pair turns as a mirror image of the body",
    )


def _column_names(Q: np.ndarray, stem: str) -> str:
    """The --columns of a triad whose raw column i holds ±(true axis j) (the signed permutation ``Q``), e.g.
    ``-gx,gy,gz``."""
    js = [int(np.flatnonzero(row)[0]) for row in Q]
    return ",".join(("-" if Q[i, j] < 0 else "") + stem + "xyz"[j] for i, j in enumerate(js))


#: a gyro that reads every axis negated against the accelerometer: so reads a gyro whose three signs are flipped,
#: and so read both triads in one left-handed frame (two axes swapped, or one negated, in both: a rotation is a
#: pseudovector, it changes sign under a mirror that the specific force follows). Gravity cannot tell the two apart
MIRROR_HINT = (
    "the gyro turns the opposite way to how gravity turns in the accelerometer's axes (all three of its axes "
    "negated): both sensors in one left-handed (mirrored) frame read so, as does a gyro with its three signs flipped"
)
MIRROR_REMEDY = (
    "if the frame is mirrored, swap two axes of every sensor alike (--columns, e.g. t,ay,ax,az,gy,gx,gz[,my,mx,mz]) "
    "or negate one axis of each (t,-ax,ay,az,-gx,gy,gz); if only the gyro's signs are flipped, negate its three "
    "columns (--columns t,ax,ay,az,-gx,-gy,-gz)"
)


def inertial_gravity_share(g: np.ndarray, a: np.ndarray, d: np.ndarray) -> float:
    """The median norm of the specific force's 2-s means in the gyro-integrated (almost inertial) frame, over its
    median norm or g, the smaller: gravity stays put there while the body moves (the nine BROAD trials' unit
    windows ≥ 0.9), a linear-acceleration output averages out (NaN for a window under 4 s)."""
    w = _means_window(d, g.shape[0])
    if g.shape[0] < 2 * w:
        return float("nan")
    return _kept_share(_spreads(g, a, d, w, False)[2], a)


def _acc_unit_error(med_a: float, gravity: float = float("nan"), where: str = "") -> OptinavError:
    """The accelerometer not in m/s²: its median norm ``med_a`` and, where judged (``where``), gravity's norm (its
    2-s means') ``gravity`` are not about g."""
    unit = "g" if 0.3 < med_a < 3 else "another unit"
    seen = f" and its 2-s means {where} {gravity:.3g}" if gravity >= 0.0 else ""
    return OptinavError(
        f"the accelerometer's median norm is {med_a:.3g} m/s²{seen}, not about 9.8: it looks like {unit}",
        "declare the unit with --acc-unit (g, mg, m/s^2)",
    )


def _gravity_removed(share: float, med_a: float, where: str) -> OptinavError:
    return OptinavError(
        f"{where}, the accelerometer's 2-s means keep {share:.0%} of its norm (median {med_a:.3g} m/s²): gravity "
        "looks removed (a linear-acceleration output), and the attitude is judged by it",
        "give the accelerometer's own output, with gravity (not 'linear acceleration' or 'user acceleration')",
    )


def check_gyro_unit(
    g: np.ndarray,
    a: np.ndarray,
    d: np.ndarray,
    window_max: float,
    gyro_unit: str | None = None,
    moving: bool = False,
    long=None,
) -> None:
    """The gyro-unit check of :func:`check_imu` on the samples of its window (gyr g, acc a, steps d, all (k, ·))
    whose largest gyro norm is ``window_max`` (a log streamed in blocks gathers them); ``gyro_unit`` as declared;
    ``moving``: the log had no still window, so gravity is judged in the gyro-integrated frame here; ``long()``:
    the whole log's hint (:func:`long_time_hint`), which names what the window took for the gyro's unit."""
    hint = _unit_hint_window(g, a, d, window_max)
    if hint and hint.kind in ("unit", "axes") and long is not None:
        # 20 s of fast translation took a rate 1.4× too high for deg/s declared rad/s (BROAD 16 at --rate 200),
        # and that flag ran at 35° with exit 0; over minutes the time base shows. Likewise a window's axes with a
        # unit factor (BROAD 33 at --rate 100: "gyro y reads +z, z reads +y, and rad/s declared deg/s"), where the
        # whole log holds gravity with the axes as they are at the factor of the rate
        other = long()
        if other is not None and not other.warn and abs(np.log(other.scale / hint.scale)) > np.log(1.5):
            hint = other
    if hint:
        raise unit_error(hint, gyro_unit)
    if moving:
        _check_moving_gravity(g, a, d)


def _check_moving_gravity(g: np.ndarray, a: np.ndarray, d: np.ndarray) -> None:
    """A log in motion throughout has no still window to judge gravity by (:func:`gravity_share` NaN): a
    linear-acceleration output of 20-60 s of BROAD's motion ran with exit 0 at 48-110°. Judged in the
    gyro-integrated frame instead, once the gyro's unit has passed."""
    share = inertial_gravity_share(g, a, d)
    med_a = float(np.median(_norm(a)))
    if share < GRAVITY_SHARE:
        raise _gravity_removed(
            share,
            med_a,
            "in the gyro-integrated frame (which holds gravity only if the gyro's unit and time base are right: "
            "check --rate and --gyro-unit too)",
        )
    # the accelerometer's unit where its median norm is over 3 g (check_norms left it to gravity's norm here): a
    # shaken body's gravity stays about g in this frame (BROAD 16's 5-s cuts: 9.4-10.3 m/s² at medians up to
    # 38), a unit's factor does not; a window too short to judge (NaN) is judged on its median norm
    gravity = share * min(med_a, G_STANDARD)
    if gravity > 3 * G_STANDARD or (not gravity >= 0.0 and med_a > 3 * G_STANDARD):
        raise _acc_unit_error(med_a, gravity, "in the gyro-integrated frame")


#: samples of each axis from which its quantum (the output's least significant bit) is estimated
QUANTUM_ROWS = 4096


def quantum(steps: np.ndarray) -> float:
    """The output's least significant bit (one axis) from steps between consecutive samples (``steps``, a few
    thousand, any order): the largest q of which nearly all non-zero steps are whole multiples (q = the smallest
    step / k, k ≤ 10) — a fast signal never steps by one q, yet all its steps are multiples; 0 for float data."""
    d = np.abs(np.asarray(steps, float))
    d = d[np.isfinite(d) & (d > 0)]
    if d.size < 8:
        return 0.0
    d0 = float(np.min(d))
    for k in range(1, 11):
        q = d0 / k
        r = d / q
        if np.median(r) > 1e4:  # steps of 10⁴ quanta and more: float data (any step is a multiple of a tiny one)
            break
        if np.mean(np.abs(r - np.round(r)) < 0.02) > 0.99:
            return q
    return 0.0


def axis_steps(x: np.ndarray, count: int = QUANTUM_ROWS) -> np.ndarray:
    """Up to ``count`` steps between consecutive samples of ``x`` ((n,) or (n, 3)), spread over it (without
    differencing the whole array)."""
    x = np.asarray(x, float)
    i = np.arange(0, x.shape[0] - 1, max(1, (x.shape[0] - 1) // count))[:count]
    return x[i + 1] - x[i]


def _check_clipping(gyr: np.ndarray, gyro_range: float | None, dt: float, acc: np.ndarray | None = None) -> None:
    """A saturated axis sits at one extreme value for ≥ 3 consecutive samples and enters or leaves that plateau
    steeply (a step > 0.5 % of the limit and > 5 quanta of the output), or stays there ≥ 0.1 s (an output whose
    quantum is below 0.1 % of the peak): a natural peak
    of quantized data is flat too, but briefly, and is reached by steps of a few quanta (a plateau of three
    samples within one quantum bounds the curvature: data logged in whole deg/s at 286 Hz enter a 411 °/s peak
    by 3 °/s). ``dt`` s: the median step."""
    # < 57 °/s: no realistic range saturates there (without a stated range)
    for k, sgn, m, _, steep in saturated_extremes(
        gyr, dt, min_peak=1.0 if gyro_range is None else -np.inf, limit=gyro_range, acc=acc
    ):
        raise clipped(k, sgn * m, steep)
    if acc is not None:
        found = [
            (k, sgn * m, idx.size, steep)
            for k, sgn, m, idx, steep in saturated_extremes(acc, dt, min_peak=ACC_CLIP_MIN, acc=gyr)
        ]
        acc_clipped(found, acc.shape[0])


def saturated_extremes(gyr: np.ndarray, dt: float, *, min_peak: float = -np.inf, limit=None, acc=None):
    """Yield (axis k, sign ±1, extreme m, the indices at it, the runs that look saturated) for each axis and sign
    of ``gyr`` (N, 3, any unit) whose samples at its extreme (and at ≥ 0.999 ``limit``, a stated range) form runs
    that look saturated (:func:`steep_runs`, with the output's quantum); extremes below ``min_peak`` are not
    judged; ``acc`` (N, 3): a run where the whole sample repeats is a held one. ``dt`` s: the median step."""
    for k in range(3):
        x = gyr[:, k]
        for sgn in (1.0, -1.0):
            y = sgn * x
            m = float(np.nanmax(y))
            if not (np.isfinite(m) and m >= min_peak):
                continue
            at = y >= m - 1e-9 * max(m, 1.0)
            if limit is not None:
                at |= y >= 0.999 * limit
            idx = np.flatnonzero(at)

            def held(s, e):
                return acc is not None and bool(np.all(gyr[s:e] == gyr[s]) and np.all(acc[s:e] == acc[s]))

            steep = steep_runs(idx, y.__getitem__, y.size, m, dt, held=held)
            if steep:  # the output's quantum can only clear it (rarely asked: it costs a pass over the axis)
                steep = steep_runs(idx, y.__getitem__, y.size, m, dt, quantum(axis_steps(x)), held)
            if steep:
                yield k, sgn, m, idx, steep


def steep_runs(idx: np.ndarray, y_at, n: int, m: float, dt: float, q: float = 0.0, held=None) -> int:
    """The runs of ≥ 3 consecutive samples at an axis's extreme ``m`` (``idx``: the sorted indices of the
    samples there, few) that look saturated (see :func:`_check_clipping`); ``y_at(i)`` the (signed) axis value
    of sample i of ``n``, asked only for ``idx`` and their neighbours; ``q`` the axis's quantum. ``held(s, e)``
    True: the whole sample (gyro and accelerometer) repeats over the run [s, e) — a logger holding its last
    sample, not a clip (one axis saturates while the other channels go on; BROAD trial 24 holds a sample four
    times at 3.2 rad/s)."""
    brk = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([idx[:1], idx[brk + 1]])
    ends = np.concatenate([idx[brk] + 1, idx[-1:] + 1])  # run [s, e)
    steep, longest = 0, 0
    for s, e in zip(starts, ends):
        if e - s < 3 or (held is not None and held(s, e)):
            continue
        step_in = y_at(s) - y_at(s - 1) if s > 0 else 0.0
        step_out = y_at(e - 1) - y_at(e) if e < n else 0.0
        # a long plateau is a clip only where the output is fine against the peak: data logged coarsely (whole
        # deg/s) stay within one quantum over a slow peak for a long time
        if max(step_in, step_out) > max(0.005 * m, 5.0 * q) or ((e - s) * dt >= 0.1 and q < 0.001 * m):
            steep += 1
            longest = max(longest, e - s)
    # one run of 3-4 samples is no evidence: a sharp natural peak tops out so (5 s of BROAD trial 11 was refused
    # at 1.16 rad/s, its range beyond 1.6), and so short a clip costs the attitude only the excess over it
    return steep if steep >= 2 or longest >= 5 else 0


#: m/s², an accelerometer's extreme below this (1.5 g) is not judged for clipping (no range is below ±2 g): BROAD 16
#: (fast translation) with its accelerometer clipped at ±2 / ±3 / ±4 g ran at 15.8 / 10.1 / 6.0° inclination RMSE
#: with exit 0 (0.49° as recorded)
ACC_CLIP_MIN = 1.5 * 9.80665


#: an accelerometer clipped in at least this share of the samples is refused, in fewer warned: BROAD 16 (sustained
#: accelerations) clipped at ±8 g in 0.19 % ran 0.11° worse, at ±4 / ±2 g in 3.7 / 14 % 5.5 / 15° worse; 29 (fast
#: rotation) at ±2 g in 1.6 % and 24 (taps) in 0.012-0.2 % as recorded (brief peaks average out in the tilt's low-pass)
ACC_CLIP_SHARE = 0.02


class ClippingWarning(UserWarning):
    """An accelerometer clipped in a few of the samples: the tilt takes a wrong specific force there."""


def acc_clipped(found: list, n: int) -> None:
    """Refuse an accelerometer clipped in :data:`ACC_CLIP_SHARE` of the ``n`` samples or more, warn below:
    ``found`` (axis, signed limit m/s², samples at it, flat runs) per clipped axis and sign."""
    if not found:
        return
    share = sum(f[2] for f in found) / max(n, 1)
    k, limit, _, steep = max(found, key=lambda f: f[2])
    if share >= ACC_CLIP_SHARE:
        raise clipped(k, limit, steep, "accelerometer")
    warnings.warn(
        f"accelerometer axis {'xyz'[k]} is clipped at {limit:.4g} m/s^2 ({steep} flat run(s) of ≥ 3 samples at the "
        f"limit; {share:.2%} of the samples at a limit): the tilt takes a wrong specific force there (sustained "
        "accelerations turn it by degrees, brief peaks little); record with a larger accelerometer range",
        ClippingWarning,
        stacklevel=4,
    )


def clipped(k: int, limit: float, steep: int, sensor: str = "gyro") -> OptinavError:
    unit = "rad/s" if sensor == "gyro" else "m/s^2"
    return OptinavError(
        f"{sensor} axis {'xyz'[k]} is clipped at {limit:.4g} {unit} ({steep} flat run(s) of ≥ 3 samples at the limit)",
        f"record with a larger {sensor} range; no attitude is reliable through saturation",
    )


def check_aop(aop: np.ndarray, unit: str = "rad") -> None:
    """The angle of polarization as read (``aop`` in its declared ``unit``, "rad" or "deg"): AoP lies in [−π, π]
    rad, so values beyond 2π are degrees declared rad; values in "degrees" that never leave ±π/2 yet span more than
    one of them (:data:`AOP_RAD_SPAN`) over :data:`AOP_MIN_ROWS` samples are radians declared deg (its 37-84°
    errors passed with exit 0)."""
    a = np.asarray(aop, float)
    a = a[np.isfinite(a)]
    if a.size:
        aop_range(float(a.min()), float(a.max()), a.size, unit)


#: samples, and span (in the declared unit) of an AoP column in "degrees" within ±π/2 judged to be radians
AOP_MIN_ROWS = 50
AOP_RAD_SPAN = 1.0


def aop_range(lo: float, hi: float, n: int, unit: str = "rad") -> None:
    """:func:`check_aop` from the column's smallest and largest finite value and their count (a log read block
    by block gathers them)."""
    if unit == "deg":
        if max(abs(lo), abs(hi)) > 360.0:
            raise OptinavError(
                f"the angle of polarization in degrees reaches {max(abs(lo), abs(hi)):.6g}, beyond ±360°: a fill "
                "value for missing samples?",
                "write missing samples as NaN (an empty cell)",
            )
        if n >= AOP_MIN_ROWS and max(abs(lo), abs(hi)) <= 1.01 * np.pi / 2 and hi - lo >= AOP_RAD_SPAN:
            raise OptinavError(
                f"the angle of polarization in degrees stays within {lo:.3g}…{hi:.3g}, inside ±π/2, over {n} "
                "samples: it looks like radians declared deg",
                "declare the unit with --aop-unit rad",
            )
        return
    if max(abs(lo), abs(hi)) > 2 * np.pi:
        raise OptinavError(
            f"the angle of polarization reaches {max(abs(lo), abs(hi)):.1f}, beyond 2π rad: it "
            "looks like degrees declared rad",
            "declare the unit with --aop-unit deg",
        )


#: the frame warning's other remedy: an accelerometer that logs minus the specific force reads the other sign of
#: gravity on every axis, which the data alone cannot tell from the other frame (negating a triad commutes with
#: every rotation, so the gyro turns it alike either way)
NEGATED_ACC = (
    "; or, if body z is as the frame has it and the logger records minus the specific force (Apple's Core Motion: "
    "a phone face up reads −1 g on z), negate the accelerometer's columns, e.g. --columns t,-ax,-ay,-az,gx,gy,gz"
)


#: the frame check counts the samples whose specific force is within FRAME_LEVEL_NORM of g (no acceleration to
#: speak of) and within FRAME_LEVEL_Z (cosine, 26°) of body +z or −z: the body lies level, right way up or not
FRAME_LEVEL_NORM = 0.1
FRAME_LEVEL_Z = 0.9
#: it warns where those against the frame add up to FRAME_MIN_S [s] and FRAME_RATIO times those with it. Judged
#: on the first 200 samples, a body turning over and over (BROAD 02 at a third of its rate, 5 s from 90.7 s: 1.2 s
#: level upside down, 1.1 s upright) was told to use the other frame, as were 25 other 5-40-s cuts of the rotating
#: trials (every 2.5 s, at 285.7, 95 and 100 Hz); none is now (at most 1.9 s level upside down where upright less
#: than a third of that). Declared in the other frame, every whole trial is still warned about, and 65 % of the
#: 7 374 cuts (71 % before: a short cut in motion seldom lies level for 3 s)
FRAME_MIN_S = 3.0
FRAME_RATIO = 3.0


def frame_counts(acc: np.ndarray, na: np.ndarray | None = None) -> np.ndarray:
    """The samples of ``acc`` (n, 3) m/s² (row norms ``na`` if known) that lie level with body z up and with it
    down (:data:`FRAME_LEVEL_NORM`, :data:`FRAME_LEVEL_Z`): (2,) int [up, down]."""
    na = _norm(acc) if na is None else na
    with np.errstate(invalid="ignore"):
        level = np.abs(na - G_STANDARD) < FRAME_LEVEL_NORM * G_STANDARD
        z = acc[:, 2]
        lim = FRAME_LEVEL_Z * na
        return np.array([np.count_nonzero(level & (z > lim)), np.count_nonzero(level & (z < -lim))])


def check_frame(acc: np.ndarray | None, frame: str, mean=None, dt: float | None = None, counts=None) -> None:
    """Warn once when the body lies level against the frame (a body at rest reads +g along body up) far longer than
    with it — NED bodies are forward-right-down (z reads −g level), ENU bodies right-forward-up (z reads +g) — and
    the whole recording's mean specific force (``mean``, default the mean of ``acc``) leans the same way: at least
    :data:`FRAME_MIN_S` s (with the sample step ``dt`` s; None: not judged) and :data:`FRAME_RATIO` times the level
    time with it. ``counts``: :func:`frame_counts` of the whole recording when ``acc`` (n, 3) m/s² is not given.
    A body turning over and over (a cut), or one that starts upside down and then turns upright, is no frame
    mistake."""
    frame = frame_name(frame)
    up, down = frame_counts(np.asarray(acc, float)) if counts is None else counts
    if mean is None:
        m = np.mean(acc, axis=0)
        if not np.all(np.isfinite(m)):  # NaN rows (lost samples): nanmean is ten times slower, only then
            m = np.nanmean(acc, axis=0)
    else:
        m = np.asarray(mean, float)
    norm = float(np.linalg.norm(m))
    if not (np.all(np.isfinite(m)) and norm > 0):
        return
    against, along = (up, down) if frame == "ned" else (down, up)
    zm = m[2] / norm
    if (frame == "ned" and zm <= 0.0) or (frame == "enu" and zm >= 0.0):
        return
    if against == 0 or against < FRAME_RATIO * along or (dt is not None and against * dt < FRAME_MIN_S):
        return
    seen = f" ({against * dt:.3g} s; {along * dt:.3g} s the other way)" if dt is not None else ""
    if frame == "ned":
        warnings.warn(
            f"the accelerometer reads +g along body z where the body lies level{seen}: that is an up-pointing z "
            "(right-forward-up body), not NED's forward-right-down; use --frame ENU (frame='ENU')" + NEGATED_ACC,
            FrameWarning,
            stacklevel=3,
        )
    else:
        warnings.warn(
            f"the accelerometer reads −g along body z where the body lies level{seen}: that is a down-pointing z "
            "(forward-right-down body), not ENU's right-forward-up; use --frame NED (frame='NED')" + NEGATED_ACC,
            FrameWarning,
            stacklevel=3,
        )


#: a field norm spread (std / median) above this is more than noise and disturbances in passing
MAG_SPREAD = 0.03
#: the smallest offset (relative to the field) the hard-iron warning names: 5 µT of a 45-µT field turned the
#: heading 12-16° with no word (the norm's spread 4.4-5.4 %, the fit's 1.8-2.2 % on BROAD; as recorded the fit
#: takes out nothing: 1.8-2.3 % either way)
MAG_OFFSET = 0.08
#: the field's direction must spread by this share of its norm (std along a body axis) for the offset along that
#: axis to be fitted: about ±10° of turn about the others
MAG_SEEN_SPREAD = 0.15
#: an offset on the board all along leaves the field less it this steady at most (its norm's std / median over the
#: whole log, rests included), whichever fit found it: 1.7-2.7 % on the nine BROAD trials with offsets of 0.7-20x the
#: field added, 8.7 % on 29 (beside a magnet). A magnet put on partway, in a rest before the motion and there
#: through all of it, is no such offset: BROAD 33 cut at 95 s (the magnet on from 40 s) leaves 12 % to the sphere
#: fit and 27 % to the turning's, and was refused online as an uncalibrated magnetometer, where the estimate, fitting
#: the magnet's offset while it is on, gives 1.02°
MAG_STEADY = 0.1
#: the hard-iron check fits about this many magnetometer rows, evenly spaced
MAG_FIT_ROWS = 100_000


def mag_fit_stride(n: int) -> int:
    """The spacing of the magnetometer rows the hard-iron fit reads of ``n`` (0, s, 2s, …): the smallest power of
    two that keeps at most twice :data:`MAG_FIT_ROWS` — the spacing a log streamed in blocks ends with
    (:meth:`optinav.attitude.stream.StreamChecks.add_mag`), so that a log in memory is fitted on the same rows."""
    s = 1
    while -(-n // s) > 2 * MAG_FIT_ROWS:
        s *= 2
    return s


def hard_iron(mag: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """(offset b, relative spread of |m| (std / median), relative spread of |m − b|) when a constant offset b
    (sphere fit, linear least squares) explains most of a field norm that varies with the orientation; None
    otherwise. ``mag`` (n, 3) in any unit; NaN rows are left out. Along a body axis the field hardly turns about
    (a body that only yaws) the offset is unobservable — the norm is the same for any offset there — and b has no
    part along it (the least-squares minimum-norm solution had put an arbitrary one there). A recording that rests
    long is judged on its distinct fields too (:func:`_distinct_fields`) when all its rows show no offset."""
    m = mag[np.all(np.isfinite(mag), axis=1)]
    got = _hard_iron_rows(m)
    if got is None and m.shape[0] >= 100:
        # the spreads are over the rows, so a long rest at one orientation dilutes the turns that show the offset:
        # BROAD 02 with +30 µT on x after 10 min of rest (its own first 5 s repeated) spread 12 % along one axis
        # against 32 % without, no offset was seen and the heading was 63° off with exit 0
        d = _distinct_fields(m)
        if d.shape[0] < m.shape[0] // 2:
            got = _hard_iron_rows(d)
    return got


#: the size of the cells (share of the median field norm) of which :func:`_distinct_fields` keeps one mean each
MAG_CELL = 0.02


def _distinct_fields(m: np.ndarray) -> np.ndarray:
    """The finite rows ``m`` (n, 3) with those in one cube of MAG_CELL × their median norm averaged into one row:
    each field direction once, however long the sensor stayed there (a rest is a few rows; at BROAD's noise of
    0.3 µT a cell is 0.9 µT)."""
    cell = MAG_CELL * float(np.median(_norm(m)))
    k = np.floor(m / cell).astype(np.int64)
    k -= k.min(axis=0)
    span = k.max(axis=0) + 1
    _, inv, count = np.unique(
        (k[:, 0] * span[1] + k[:, 1]) * span[2] + k[:, 2], return_inverse=True, return_counts=True
    )
    return np.column_stack([np.bincount(inv, weights=m[:, k]) for k in range(3)]) / count[:, None]


def _sphere_fit(m: np.ndarray, axes: np.ndarray) -> tuple[np.ndarray, float, float]:
    """(b, r², relative spread of |m − b|) of the sphere |m − b|² = r² fitted to the rows ``m`` (n, 3) with b along
    the columns of ``axes`` (3, k) only: linear once centred, 2 (m − m̄)·b = |m|² − mean |m|²."""
    mc = m - m.mean(axis=0)
    y = np.einsum("ij,ij->i", m, m)
    b = axes @ np.linalg.lstsq(2.0 * mc @ axes, y - y.mean(), rcond=None)[0]
    r2 = float(np.mean(np.einsum("ij,ij->i", m - b, m - b)))
    return b, r2, float(np.std(_norm(m - b)) / np.sqrt(r2))


def _norm_varies(m: np.ndarray) -> float | None:
    """The relative spread of the norm of the rows ``m`` (n, 3) where it is over :data:`MAG_SPREAD` (a field that
    varies with the orientation: evidence of an offset); None below it or with under 100 rows."""
    if m.shape[0] < 100:
        return None
    n0 = _norm(m)
    s0 = float(np.std(n0) / np.median(n0))
    return s0 if s0 > MAG_SPREAD else None


def sphere_offset(mag: np.ndarray) -> tuple[np.ndarray, float, float, float] | None:
    """(b, r, the norm's relative spread, that of |m − b|) where the sphere fitted along all three axes explains a field norm that varies with the orientation
    as :func:`hard_iron` requires (spread over :data:`MAG_SPREAD`, halved and within :data:`MAG_STEADY`, b over
    :data:`MAG_OFFSET` of the radius r), though an axis the field turns about too little for :func:`hard_iron`
    leaves b uncertain along it: evidence of an offset, not a value to subtract (BROAD 07's fast rotation, its last
    40-80 s, with (25, -15, 35) µT: 24-35 % down to 1.6-1.9 %, b within 1 µT; as recorded 1.6-2.0 %). None
    otherwise. ``mag`` (n, 3), NaN rows left out."""
    m = mag[np.all(np.isfinite(mag), axis=1)]
    s0 = _norm_varies(m)
    if s0 is None:
        return None
    b, r2, s1 = _sphere_fit(m, np.eye(3))
    ok = s1 < s0 / 2 and s1 <= MAG_STEADY and np.linalg.norm(b) > MAG_OFFSET * np.sqrt(r2)
    return (b, float(np.sqrt(r2)), s0, s1) if ok else None


def _hard_iron_rows(m: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """:func:`hard_iron` of the finite rows ``m``, each row one sample."""
    s0 = _norm_varies(m)
    if s0 is None:
        return None
    spread, V = _field_spread(m)
    seen = spread > MAG_SEEN_SPREAD
    b, r2, s1 = _sphere_fit(m, V[:, seen] if seen.any() else V)
    # the spreads are of |m|, which the offset inflates: an axis turned about by less than MAG_SEEN_SPREAD of |m|
    # may be turned about by more of the field itself (BROAD 07 with +30 µT on x and 5 % soft iron: 14.7 % of |m|,
    # 18 % of the field; the offset fitted without it left the norm's 12 % spread unexplained, nothing was said and
    # the heading was 52° off with exit 0; with (100, -80, 60) µT no axis was seen: 119°). Such an axis joins when
    # the fit with it leaves the norm as steady as a calibrated field's (a wrong offset along an axis that turns
    # little would not: see _iframe._hf_solve)
    # a fit along fewer axes leaves the offset along the others in r
    r2_all = r2 if seen.all() else _sphere_fit(m, V)[1]
    more = spread * float(np.median(_norm(m))) / np.sqrt(r2_all) > MAG_SEEN_SPREAD
    if (more & ~seen).any():
        got = _sphere_fit(m, V[:, more])
        if got[2] <= MAG_SPREAD:
            b, r2, s1 = got
            seen = more
    if not seen.any():
        return None
    # a disturbance (a magnet passing, steel nearby) is no constant offset: the fit does not explain it, nor one that
    # came partway (MAG_STEADY)
    ok = s1 < s0 / 2 and s1 <= MAG_STEADY and np.linalg.norm(b) > MAG_OFFSET * np.sqrt(r2)
    return (b, s0, s1) if ok else None


#: the soft-iron warning needs the ellipsoid's correction to turn the field's direction by this much (RMS over the
#: samples, rad): it is what turns the heading. BROAD 02 through [[1.2, 0.1, 0], [0.1, 0.85, 0.05], [0, 0.05, 1]]:
#: 6.4°; the nine trials as recorded 0.6-1.3°, their 5-80 s cuts (whose norm spread passes 3 % and an ellipsoid
#: of axes 1.04-1.10:1 halves it) 0.7-1.9°
MAG_SOFT_TURN = np.radians(3.0)


def soft_iron(mag: np.ndarray) -> tuple[float, float, float] | None:
    """(relative spread of |m| (std / median), the spread left on the fitted ellipsoid, its axis ratio) when an
    ellipsoid (m − c)ᵀ M (m − c) = 1 — soft iron, with an offset c — explains at least half of a norm spread above
    :data:`MAG_SPREAD` that no sphere (:func:`hard_iron`) explains, on a recording that turns the field every way
    (each principal spread above :data:`MAG_SEEN_SPREAD`), its centre within one field norm of zero and a correction
    that turns the field's direction by :data:`MAG_SOFT_TURN` or more; None otherwise. BROAD 02 with its field through
    [[1.2, 0.1, 0], [0.1, 0.85, 0.05], [0, 0.05, 1]]: 7.4 % → 1.7 %, ratio 1.55, heading 4.8° RMSE (1.35° as
    recorded); the nine as recorded 1.8-2.5 % (none judged) or, the magnet trial 29, 8.4 % → 8.1 % (not explained)."""
    m = mag[np.all(np.isfinite(mag), axis=1)]
    if m.shape[0] < 100:
        return None
    n0 = _norm(m)
    s0 = float(np.std(n0) / np.median(n0))
    if s0 <= MAG_SPREAD or float(_field_spread(m)[0].min()) <= MAG_SEEN_SPREAD:
        return None
    x = m / float(np.median(n0))  # the quadric's terms near 1 (a field in nT or counts alike)
    X = np.column_stack([x * x, 2.0 * x[:, [0, 0, 1]] * x[:, [1, 2, 2]], 2.0 * x])
    p = np.linalg.lstsq(X, np.ones(x.shape[0]), rcond=None)[0]
    M0 = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    try:
        c = -np.linalg.solve(M0, p[6:])
    except np.linalg.LinAlgError:
        return None
    M = M0 / (1.0 + c @ M0 @ c)
    lam, V = np.linalg.eigh(M)
    # the centre within one field norm of zero (an offset smaller than the field, where hard_iron found none): a
    # fit centred farther is a patch of a disturbance, not a sensor's ellipsoid (BROAD 29 near its magnet, 20 s:
    # centre 4.4 norms off, axes 2.97:1)
    if not lam.min() > 0 or not float(np.linalg.norm(c)) < 1.0:
        return None
    y = (x - c) @ (V * np.sqrt(lam)) @ V.T
    nu = _norm(y)
    s2 = float(np.std(nu) / np.median(nu))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", x - c, y) / (_norm(x - c) * nu), -1.0, 1.0))
    if s2 >= s0 / 2 or float(np.sqrt(np.mean(turn**2))) < MAG_SOFT_TURN:
        return None
    return s0, s2, float(np.sqrt(lam.max() / lam.min()))


def _warn_soft_iron(mag: np.ndarray) -> None:
    """A :class:`MagnetometerWarning` where :func:`soft_iron` finds the field distorted (no option takes it out)."""
    got = soft_iron(mag)
    if got is not None:
        s0, s2, ratio = got
        warnings.warn(
            f"the magnetometer's field norm varies by {s0:.0%} (std/median) with the orientation, and an ellipsoid "
            f"(axes {ratio:.2f}:1) explains it down to {s2:.1%}: soft iron (or a scale error per axis) turns the "
            "heading by degrees; calibrate the magnetometer for it (an ellipsoid fit) before the estimate",
            MagnetometerWarning,
            stacklevel=3,
        )


def _field_spread(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The field's spread (std) along its principal body axes relative to its median norm (3,), and those axes
    (columns of V), of the finite rows ``m`` (n, 3): how far the recording turns the field about each."""
    mc = m - m.mean(axis=0)
    lam, V = np.linalg.eigh(mc.T @ mc / m.shape[0])
    return np.sqrt(np.maximum(lam, 0.0)) / float(np.median(_norm(m))), V


def check_offset_seen(mag: np.ndarray, source: str, calibrated: str) -> None:
    """Refuse a magnetometer known to carry its hard-iron offset (``source``; ``calibrated``: where its calibrated
    field is) when the recording turns it too little for :func:`hard_iron` to fit the offset along any axis: the
    heading would carry the offset's angle with no word (a still phone's MagnetometerUncalibrated.csv 15, 10, -5 µT
    off gave a 26° heading RMSE with exit 0)."""
    m = mag[np.all(np.isfinite(mag), axis=1)]
    if m.shape[0] < 2:
        return  # no field: refused as such
    spread = float(_field_spread(m)[0].max())
    if spread <= MAG_SEEN_SPREAD:
        raise OptinavError(
            f"{source} is an uncalibrated magnetometer (its hard-iron offset not taken out), and the recording turns "
            f"it too little for the offset to be fitted (the field's direction spreads by {spread:.0%} of its norm, "
            f"{MAG_SEEN_SPREAD:.0%} needed): the heading would be off by the offset's angle",
            f"give --mag-hard-iron=BX,BY,BZ (what optinav attitude --mag names on a recording that turns the sensor "
            f"every way), {calibrated}, or drop --mag",
        )


def zero_rows_missing(mag: np.ndarray) -> np.ndarray:
    """``mag`` (n, 3) with its rows of exactly (0, 0, 0) as NaN, no sample (a copy where there are any): no
    magnetometer in the Earth's field reads zero on three axes at once; a logger writes it for a sample it has not
    got (a slower magnetometer padded with zeros) or a sensor that is not there. Read as a field, the padding made
    the hard-iron check name an offset fitted to it ('varies by inf%'), and a field of zeros ran 6D with exit 0."""
    zero = ~np.any(mag, axis=1)  # NaN is not zero
    if not zero.any():
        return mag
    out = np.array(mag, dtype=float)
    out[zero] = np.nan
    return out


def field_less_offset(field_sums: np.ndarray, counts: np.ndarray, offset) -> np.ndarray:
    """Per-bin field sums (k, 3) over ``counts`` (k,) rows each (:func:`mag_sums`, :func:`field_rate_sums`) of the
    field less a hard-iron ``offset`` (3,, the field's unit; None: as they are)."""
    return field_sums if offset is None else field_sums - counts[:, None] * np.asarray(offset, float)


def rate_sums_less_offset(sums: np.ndarray, offset) -> np.ndarray:
    """:func:`field_rate_sums`' sums (k, 9) with the field's columns less ``offset`` (:func:`field_less_offset`)."""
    if offset is None:
        return sums
    out = np.array(sums, dtype=float)
    out[:, :3] = field_less_offset(out[:, :3], out[:, 3], offset)
    return out


def mag_sums(
    acc: np.ndarray, mag: np.ndarray, row0: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bin numbers (k,), and per TILT_BIN-sample bin the specific-force and field sums (k, 3) over the rows with
    a finite field, their count (k,) and the sum of the specific force's norm's distance from g (k,) m/s² over
    them, of a block starting at row ``row0`` (as :func:`tilt_sums`)."""
    n = acc.shape[0]
    if not n:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    ok = np.all(np.isfinite(mag), axis=1) & np.all(np.isfinite(acc), axis=1)
    bins, first = _bin_starts(n, row0)
    a = np.where(ok[:, None], acc, 0.0)
    m = np.where(ok[:, None], mag, 0.0)
    dev = np.where(ok, np.abs(_norm(a) - G_STANDARD), 0.0)
    return (
        bins,
        np.add.reduceat(a, first, axis=0),
        np.add.reduceat(m, first, axis=0),
        np.add.reduceat(ok, first),
        np.add.reduceat(dev, first),
    )


#: s, the magnetometer-axes check compares gravity and the field averaged over this long (translation averages out)
MAG_AXES_S = 1.0
#: the specific force is taken for gravity in the groups of MAG_AXES_S whose norm stays within this share of g
#: on average (mean of ||a| − g| / g over their rows). A body shaken by several g has no gravity in its 1-s means:
#: BROAD 16 from 36 s, resampled to 100 Hz, 17-67° off the optical vertical with |a| 0.7-4 g off g on average, and
#: 40 s of it from 20 s spread 48° as declared, 14° with another order: "not the IMU's axes", a false warning. With
#: these groups left out, the nine trials and their 20-s and 40-s cuts every 10 s (at 285.7, 95, 100 and 50 Hz) as
#: recorded are never warned about (3 before); the rotating trials keep 93-100 % of their groups, 16 keeps 44 %
MAG_AXES_ACC_DEV = 0.3
#: deg, the 5-95 % spread of the angle between gravity and the field beyond which the axes are questioned. As
#: recorded, the nine BROAD trials spread up to 54° (the magnet trials) and cuts of fast translation up to 51°,
#: where the accelerometer's 1-s means are no gravity (another axis order then spread 12° at best: 37/12); the
#: AK8963 layout of an MPU-9250 (x and y swapped, z negated) 77/4, 95/6 and 87/10 on the rotating trials
MAG_AXES_SPREAD_DEG = 45.0
#: another axis order must bring the spread below this share of the declared one and below the degrees given:
#: refused beyond the first pair (overwhelming), warned about beyond the second
MAG_AXES_REFUSE = (1.0 / 6.0, 10.0)
MAG_AXES_WARN = (1.0 / 3.0, 20.0)
MAG_AXES_REMEDY = "give the magnetometer's columns in the IMU's axes (--mag-columns, or remap them in the file)"


def mag_axes_hint(bins, acc_sums, mag_sums, counts, dev_sums, dt: float) -> tuple[str, bool]:
    """('', False) when the field keeps its angle to gravity as the body turns, or no other order of its axes
    keeps it clearly better; else (text, refuse): the signed permutation of the magnetometer's axes that does (a
    field in another frame than the IMU's, such as the AK8963 inside an MPU-9250), and whether the evidence is
    overwhelming (:data:`MAG_AXES_REFUSE`) or only strong (:data:`MAG_AXES_WARN`). Judged on the sums of
    :func:`mag_sums` gathered into :data:`MAG_AXES_S` groups (a bin split between blocks is summed again), those
    whose specific force is gravity (:data:`MAG_AXES_ACC_DEV`); nothing is said under 30 of them."""
    from optinav.core.rotations import describe_permutation, signed_permutations

    if len(bins) == 0:
        return "", False
    u, inv = np.unique(bins, return_inverse=True)
    A = np.zeros((u.size, 3))
    M = np.zeros((u.size, 3))
    C = np.zeros(u.size)
    E = np.zeros(u.size)
    np.add.at(A, inv, acc_sums)
    np.add.at(M, inv, mag_sums)
    np.add.at(C, inv, counts)
    np.add.at(E, inv, dev_sums)
    g = max(1, int(round(MAG_AXES_S / (TILT_BIN * dt))))
    k = (u.size // g) * g
    if k < 30 * g:
        return "", False  # under 30 groups: too little to judge
    A, M, C, E = (x[:k].reshape(k // g, g, *x.shape[1:]).sum(axis=1) for x in (A, M, C, E))
    keep = (C > 0.5 * g * TILT_BIN) & (E < MAG_AXES_ACC_DEV * G_STANDARD * C)
    A, M = A[keep], M[keep]
    if A.shape[0] < 30:
        return "", False
    a = A / np.maximum(_norm(A), 1e-300)[:, None]

    def spread(P) -> float:
        m = M @ P  # raw rows m = P b: b = Pᵀ m, as rows m @ P
        c = np.einsum("ij,ij->i", a, m) / np.maximum(_norm(m), 1e-300)
        ang = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
        lo, hi = np.percentile(ang, [5, 95])
        return float(hi - lo)

    perms = signed_permutations()
    declared = spread(perms[0])
    if declared <= MAG_AXES_SPREAD_DEG:
        return "", False
    s_best, i = min((spread(P), i) for i, P in enumerate(perms[1:], 1))
    best = perms[i]
    for (share, most), refuse in ((MAG_AXES_REFUSE, True), (MAG_AXES_WARN, False)):
        if s_best < share * declared and s_best <= most:
            return (
                f"the magnetic field's angle to gravity spans {declared:.0f}° as the body turns (5-95 %), "
                f"{s_best:.0f}° with the magnetometer's axes read as "
                f"{describe_permutation(best, 'magnetometer', 'IMU axes')}: its axes "
                + ("are not the IMU's" if refuse else "look not to be the IMU's (a heading from it would be off)"),
                refuse,
            )
    return "", False


#: the field must turn in the body as the gyro says (dm/dt = −ω × m, per TILT_BIN bin): another order of the
#: magnetometer's axes is named where the declared one leaves more than MAG_TURN_BAD of the field's turning
#: unexplained and the other less than MAG_TURN_SHARE of what it leaves. The nine BROAD trials as recorded 0.00-0.28
#: at their rate, 0.01-0.76 at a third of it (16's fast translation; with the two bins' mean rate for the step
#: instead of :func:`_turns`' triangle 0.01-0.29 and 0.06-3.8); in the AK8963 layout 1.6-2.6. A field negated whole
#: turns the same way and cannot be told.
MAG_TURN_BAD, MAG_TURN_SHARE = 0.5, 0.25
#: the field must turn in the body by at least this much in all (rad, summed over the bins) to judge by (the nine
#: trials 32-431)
MAG_TURN_MIN = 5.0


def gyro_sums(gyr: np.ndarray, row0: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bin numbers (k,), gyro sums (k, 6) and row counts (k,) of the TILT_BIN-sample bins a block starting at row
    ``row0`` touches (as :func:`mag_sums`): Σω (rad/s) and Σ p·ω, p the row's place in its bin from 0 to 1 (the
    ramp of :func:`_turns`' triangle)."""
    n = gyr.shape[0]
    if not n:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 6)), np.zeros(0)
    bins, first = _bin_starts(n, row0)
    out = np.empty((first.shape[0], 6))
    out[:, :3] = np.add.reduceat(gyr, first, axis=0)
    ramp = (np.arange(TILT_BIN) + 0.5) / TILT_BIN
    # whole bins as one product with the ramp (a per-row weight took 9× as long as the plain sums); the block's
    # partial first and last bins row by row
    a = int((-row0) % TILT_BIN)
    a = min(a, n)
    k = (n - a) // TILT_BIN
    i = 1 if a else 0
    out[i : i + k, 3:] = ramp @ gyr[a : a + k * TILT_BIN].reshape(k, TILT_BIN, 3)
    if a:
        out[0, 3:] = ramp[row0 % TILT_BIN : row0 % TILT_BIN + a] @ gyr[:a]
    if a + k * TILT_BIN < n:
        out[-1, 3:] = ramp[: n - a - k * TILT_BIN] @ gyr[a + k * TILT_BIN :]
    return bins, out, np.diff(np.append(first, n)).astype(float)


def _field_and_rate(mag_bins, mag_sums_, counts, g_bins, g_sums, g_counts):
    """The TILT_BIN bins with both sensors: bin numbers (k,), mean field (k, 3) (NaN where no finite row) and mean
    rate ω̄ and mean p·ω (k, 6) (rad/s, :func:`gyro_sums`) from the sums of :func:`mag_sums` and :func:`gyro_sums`
    (a bin split between blocks comes twice: merged as the time-base bins are)."""
    ub, MC = merge_bins(np.asarray(mag_bins), np.column_stack([mag_sums_, counts]))
    ug, GN = merge_bins(np.asarray(g_bins), np.column_stack([g_sums, g_counts]))
    both, im, ig = np.intersect1d(ub, ug, return_indices=True)
    M, C, G, N = MC[im, :3], MC[im, 3], GN[ig, :6], GN[ig, 6]
    m = np.where((C > 0)[:, None], M / np.maximum(C, 1.0)[:, None], np.nan)
    return both, m, G / np.maximum(N, 1.0)[:, None]


def _turns(u: np.ndarray, w: np.ndarray, pair: np.ndarray, h: float, *more: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per neighbouring bins (``pair``: the k − 1 pairs kept) the unit field's step Δu and the step the gyro
    predicts, −θ × ū, both (j, 3), rows with a NaN left out; ``w`` (k, 6) the bins' mean ω and p·ω (rad/s,
    :func:`_field_and_rate`; (k, 3) the mean ω alone: θ = h × the two bins' mean ω), ``h`` s a bin; ``more``:
    further rates in ``w``'s layout, the step each predicts returned after (rows kept where all are finite). The
    step between two bins' means weighs each instant's rotation by the share of row pairs across it, a triangle
    rising over the first bin and falling over the second: θ = h (mean p·ω of the first + mean ω − mean p·ω of the
    second). Taken as the two bins' mean rate times h, a rate that swings within the bins left BROAD 16's fast
    translation (20 s at half its rate) with 350 % of the field's turning unexplained and refused as a magnetometer
    in other axes; 39 % so."""
    du = (u[1:] - u[:-1])[pair]
    mid = 0.5 * (u[1:] + u[:-1])
    preds = []
    for v in (w, *more):
        theta = (v[:-1, 3:] + v[1:, :3] - v[1:, 3:]) * h if v.shape[1] == 6 else 0.5 * (v[1:] + v[:-1]) * h
        preds.append(-np.cross(theta, mid)[pair])
    ok = np.all(np.isfinite(np.hstack([du, *preds])), axis=1)
    return du[ok], *(p[ok] for p in preds)


#: the largest turn (rad) between neighbouring TILT_BIN bins taken as the gyro predicts it (−ω̄ × ū h): the mean
#: field of a bin that turns farther is shrunk and no longer stepped so (64 rows are 1.28 s at 50 Hz: BROAD 29
#: averaged to 50 Hz, turning at 3 rad/s, "turned 10 rad where the gyro 113" and was refused as a stuck field; at
#: its own 285.7 Hz 1.35). The stuck-field check counts each step at most this, the axes check leaves those out
MAG_TURN_STEP = 1.0


def _field_turn_bins(mag_bins, mag_sums_, counts, g_bins, g_sums, g_counts, dt: float):
    """(mean field (k, 3), mean ω and p·ω (k, 6) rad/s, which neighbours are consecutive bins (k − 1,), bin length s) of
    the TILT_BIN bins with both sensors (:func:`_field_and_rate`), or None under 30 neighbouring pairs."""
    if len(mag_bins) == 0 or len(g_bins) == 0:
        return None
    both, m, w = _field_and_rate(mag_bins, mag_sums_, counts, g_bins, g_sums, g_counts)
    nxt = np.diff(both) == 1
    return None if np.count_nonzero(nxt) < 30 else (m, w, nxt, TILT_BIN * dt)


#: a field that turns in the body by less than this share of what the gyro turns it (summed steps of the unit
#: field between TILT_BIN bins against −ω × m) is not measured on this body: the nine BROAD trials as recorded
#: 1.05-2.5, each held at its first value 0 (which had passed every check: a 28° heading RMSE on trial 02, exit 0)
MAG_STILL_SHARE = 0.1


def check_mag_turns(mag_bins, mag_sums_, counts, g_bins, g_sums, g_counts, dt: float) -> None:
    """Refuse a field that hardly turns in the body while the gyro turns the body by :data:`MAG_TURN_MIN` or more
    (:data:`MAG_STILL_SHARE`), then one that turns against the gyro (:func:`mag_turn_hint`). The sums as :func:`mag_sums` and
    :func:`gyro_sums` give them; ``dt`` the median step (s)."""
    got = _field_turn_bins(mag_bins, mag_sums_, counts, g_bins, g_sums, g_counts, dt)
    if got is None:
        return
    m, w, nxt, h = got
    du, pred = _turns(m / np.maximum(_norm(m), 1e-300)[:, None], w, nxt, h)
    turned = float(np.sum(np.minimum(_norm(du), MAG_TURN_STEP)))
    predicted = float(np.sum(np.minimum(_norm(pred), MAG_TURN_STEP)))
    if predicted >= MAG_TURN_MIN and turned < MAG_STILL_SHARE * predicted:
        raise OptinavError(
            f"the magnetic field hardly turns in the body ({turned:.1f} rad in all) while the gyro turns the body by "
            f"{predicted:.0f} rad: the magnetometer does not measure the field on this body (a sensor stuck at one "
            "value, a column that is not the magnetometer's, a field logged in another frame, a magnet on the board "
            "far stronger than the Earth's field)",
            "check the magnetometer's columns (--mag-columns, --mag-file) and its logging, or drop --mag",
        )
    warn_or_refuse_mag_axes(mag_turn_hint(*got), True)


def mag_turn_hint(m: np.ndarray, w: np.ndarray, nxt: np.ndarray, h: float) -> str:
    """'' when the field turns in the body as the gyro says (or too little to judge), else the text naming the
    signed order of the magnetometer's axes that does (:data:`MAG_TURN_BAD`, :data:`MAG_TURN_SHARE`): per bin of
    :func:`_field_turn_bins` the unit mean field m and mean ω and p·ω (rad/s), neighbours' Δm against −θ × m
    (:func:`_turns`; ``h`` s a bin). A layout that keeps the field's angle to gravity on a body that mostly yaws
    (the AK8963's x and y swapped, z negated: BROAD 11, 16, 27, 29, 33 ran with exit 0 at a heading 101-131° off)
    turns the field against the gyro."""
    from optinav.core.rotations import signed_permutations

    nxt = nxt & (_norm(0.5 * (w[1:, :3] + w[:-1, :3])) * h <= MAG_TURN_STEP)

    def residual(P) -> tuple[float, float]:
        u = m @ P  # raw rows m = P b: b = Pᵀ m, as rows m @ P
        du, pred = _turns(u / np.maximum(_norm(u), 1e-300)[:, None], w, nxt, h)
        turn = float(np.sum(du**2))
        return float(np.sum((du - pred) ** 2)) / max(turn, 1e-300), float(np.sum(_norm(du)))

    declared, turned = residual(np.eye(3))
    if turned < MAG_TURN_MIN or declared <= MAG_TURN_BAD:
        return ""
    perms = signed_permutations()
    best, i = min((residual(P)[0], i) for i, P in enumerate(perms[1:], 1))
    if best >= MAG_TURN_SHARE * declared:
        return ""
    return (
        f"the magnetic field turns in the body unlike the gyro says ({declared:.0%} of its turning unexplained), "
        f"{best:.0%} with the magnetometer's axes read as {_mag_reading_words(perms[i])}: its axes are not the IMU's"
    )


def _mag_reading_words(P) -> str:
    """The magnetometer's axes read as the signed permutation ``P`` and, but where that is the IMU's own, as −P: a
    field and its negative turn alike in the body, so the turning names both (the first alone, z negated, was
    followed for a magnetometer turned 180° about z, x and y negated: heading 178° off, exit 0)."""
    from optinav.core.rotations import describe_permutation

    words = describe_permutation(P, "magnetometer", "IMU axes")
    if np.array_equal(-np.asarray(P), np.eye(3)):
        return words
    return (
        f"{words} or as {describe_permutation(-np.asarray(P), 'magnetometer', 'IMU axes')} (the turning cannot tell "
        "the two apart: the one whose field points down north of the magnetic equator, up south of it)"
    )


#: bins whose field norm is off its median by more than this share are magnetically disturbed (a magnet, steel
#: nearby) and left out of the gyro-scale check: the field turns there without the body
MAG_QUIET = 0.1
#: s, the gyro-scale check compares the field's and the gyro's turning between bins this long: in TILT_BIN rows
#: (0.22 s at BROAD's rate, 0.67 s at a third of it) a fast turn leaves the step linear in ω no more, and the check
#: judged 58 % of BROAD's cuts at full rate, 12 % at a third; in 0.1-s bins 69 % at full rate, a third and a tenth
MAG_SCALE_BIN_S = 0.1
#: the gyro-scale check judges only where the field turned by at least this much in the quiet bins (rad, summed
#: |Δu|) and the gyro's rotation explains at least MAG_SCALE_EXPLAINED of that turning up to a factor
MAG_SCALE_TURN = 2.0
MAG_SCALE_EXPLAINED = 0.5
#: the field turning this many times as far as the gyro says is refused. The nine BROAD trials as recorded and
#: their 10-s, 20-s, 30-s, 60-s and half cuts, at a third, a tenth and a thirtieth of the rate, with and without a
#: hard-iron offset and magnets passing: 0.41-2.5 where judged; their rad/s declared deg/s 24-140. A gyro reading
#: too much (deg/s declared rad/s) is the peak's and gravity's to find: a hard-iron field turns less than the body,
#: so a small factor is no evidence
MAG_SCALE_FAR = 8.0


def scale_bin_rows(dt: float) -> int:
    """Rows per bin of the gyro-scale check (:data:`MAG_SCALE_BIN_S`) at the median step ``dt`` (s)."""
    return max(1, int(round(MAG_SCALE_BIN_S / dt))) if dt > 0 else 1


def field_rate_sums(gyr: np.ndarray, mag: np.ndarray, rows: int, row0: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Bin numbers (k,) and per ``rows``-sample bin of a block starting at row ``row0``: the field's sum over its
    finite rows, their count, the gyro's sum (rad/s), the row count and the finite rows' offsets from the bin's
    centre summed (in bins: where in its bin a magnetometer slower than the IMU was sampled, for
    :func:`mag_lag`), as (k, 9) columns (a bin split between blocks comes twice: :func:`merge_bins` sums it)."""
    n = gyr.shape[0]
    if not n:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 9))
    ok = np.all(np.isfinite(mag), axis=1)
    bins, first = _bin_starts(n, row0, rows)
    out = np.empty((first.shape[0], 9))  # each part its own reduceat: a stacked copy took 20× as long
    out[:, :3] = np.add.reduceat(np.where(ok[:, None], mag, 0.0), first, axis=0)
    out[:, 3] = np.add.reduceat(ok.astype(float), first)
    out[:, 4:7] = np.add.reduceat(gyr, first, axis=0)
    out[:, 7] = np.diff(np.append(first, n))
    at = (np.arange(row0, row0 + n) % rows - 0.5 * (rows - 1)) / rows
    out[:, 8] = np.add.reduceat(np.where(ok, at, 0.0), first)
    return bins, out


def mag_gyro_scale(bins: np.ndarray, sums: np.ndarray, h: float) -> tuple[float, float, float]:
    """(s, explained, turned): the factor s by which the field turns in the body beyond what the gyro says (least
    squares of the unit field's steps Δu between neighbouring bins on the gyro's −ω̄ × ū · ``h``; ``h`` s a bin,
    the gyro in rad/s), the share of the turning that s times the gyro's explains, and the turning seen (rad,
    Σ|Δu|), over the magnetically quiet bins (:data:`MAG_QUIET`); NaNs when under 30 pairs of bins. ``bins``,
    ``sums`` as :func:`field_rate_sums` gives them."""
    return _scale_fit(_quiet_steps(bins, sums), h)


def _scale_fit(quiet, h: float) -> tuple[float, float, float]:
    """:func:`mag_gyro_scale` of :func:`_quiet_steps`' bins (None: NaNs)."""
    nan = (float("nan"),) * 3
    if quiet is None:
        return nan
    du, pred = _turns(*quiet, h)
    pp, dp, dd = float(np.sum(pred * pred)), float(np.sum(du * pred)), float(np.sum(du * du))
    if not (pp > 0 and dd > 0):
        return nan
    return dp / pp, dp * dp / (pp * dd), float(np.sum(_norm(du)))


def _quiet_steps(bins: np.ndarray, sums: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(unit field (k, 3), mean gyro (k, 3) rad/s, the pairs of neighbouring magnetically quiet bins (k − 1,)) of
    :func:`field_rate_sums`' bins, for :func:`_turns`; None under 30 such pairs."""
    if len(bins) == 0:
        return None
    return _quiet_of(*bin_fields(bins, sums))


def _quiet_of(both: np.ndarray, m: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`_quiet_steps` of :func:`bin_fields`' bin numbers, mean fields and mean gyro rates."""
    nm = _norm(m)
    finite = np.isfinite(nm)
    if not np.any(finite):
        return None
    with np.errstate(invalid="ignore"):
        quiet = np.abs(nm / np.median(nm[finite]) - 1.0) < MAG_QUIET
    pair = (np.diff(both) == 1) & quiet[1:] & quiet[:-1]
    if np.count_nonzero(pair) < 30:
        return None
    return m / np.where(quiet, nm, 1.0)[:, None], w, pair


def gyro_scale_error(s: float, explained: float, turned: float, gyro_unit: str | None = None) -> OptinavError | None:
    """The error for a field that turns ``s`` times as far as the gyro (declared in ``gyro_unit``; None: not known)
    says (:func:`mag_gyro_scale`), None when not judged or within :data:`MAG_SCALE_FAR`. BROAD 11 and 27 (a body
    that mostly yaws: gravity barely turns in it) ran their rad/s declared deg/s with exit 0 at 5.6° RMS. A field
    that turns against the gyro (s < 0: BROAD's nine trials mirrored, −0.96 to −1.34) is a mirrored frame or a
    gyro with its signs flipped; 20 s of trial 11 so ran with exit 0, its heading turning the wrong way."""
    if not (turned >= MAG_SCALE_TURN and explained >= MAG_SCALE_EXPLAINED and (s > MAG_SCALE_FAR or s < 0)):
        return None
    unit = gyro_unit or "rad/s"
    where = f"{turned:.3g} rad of turning where the field is undisturbed, {explained:.0%} of it about the gyro's axes"
    if s < 0:
        factor = f", and by {-s:.3g}× as far: check --gyro-unit too" if -s > MAG_SCALE_FAR else ""
        return OptinavError(
            f"the magnetic field turns in the body the opposite way to the gyro in {unit} ({where}): both sensors in "
            "one left-handed (mirrored) frame read so, as does a gyro with its three signs flipped" + factor,
            MIRROR_REMEDY,
        )
    seen = f"the magnetic field turns in the body {s:.3g}× as far as the gyro in {unit} says ({where})"
    if abs(np.log(s * np.pi / 180.0)) < np.log(1.5) and gyro_unit != "rad/s":
        return OptinavError(
            f"{seen}: a unit factor of 180/π",
            f"it looks like rad/s declared {gyro_unit or 'deg/s (converted twice)'}: --gyro-unit rad/s",
        )
    return OptinavError(
        f"{seen}: the gyro reads too little by that factor",
        "check --gyro-unit (raw counts need their calibration, optinav apply), --rate or the time column's unit "
        "(--time-unit)",
    )


#: a magnetometer the user did not ask for (a witness) names a mirrored frame only where the declared axes with the
#: field turning against the gyro leave at most this share of what the best signed order turning with it leaves
#: unexplained: a magnetometer in a left-handed layout of its own (one axis negated) turns against the gyro too,
#: but one of its orders undoes it. BROAD's nine trials whole, halved and in 20-s cuts, at 1/1 and 1/3 of the rate,
#: mirrored: 0.02-0.99 where judged, 85 % of them under 0.5; as recorded with only the magnetometer's x, y or z
#: negated, x and y swapped or in the AK8963 layout: 1.09-47 (trial 16 with x negated turned against the gyro at
#: −1.01, 82 % explained)
WITNESS_MIRROR_SHARE = 0.5
#: the remedy of a field that turns with the gyro when moved in time
LAG_REMEDY = "align the magnetometer's time stamps with the IMU's"
#: s, the lags of a witness's field against the gyro tried before a field turning against it is called a mirror: a
#: magnetometer 0.2 s late on BROAD 07's fast rotation turned against the gyro (no signed order undid it)
WITNESS_LAG_S = 1.0


def _turns_with_gyro_otherwise(bins: np.ndarray, sums: np.ndarray, h: float) -> tuple[float, str, str]:
    """(explained, how, remedy): the most of the field's turning that the field turning as the gyro explains
    (:func:`mag_gyro_scale`, factor > 0) with the magnetometer's axes in another signed order, or the field moved
    in time by up to :data:`WITNESS_LAG_S`, what reading does it and its remedy; (0, "", "") when none does.
    ``bins``, ``sums`` of :func:`field_rate_sums`, ``h`` s a bin."""
    from optinav.core.rotations import signed_permutations

    bins, sums = merge_bins(np.asarray(bins), np.asarray(sums, float))
    tried, seen = [], []
    for P in signed_permutations()[1:]:
        # a field and its negative turn alike: P and −P are one reading to this test, both named (the first named
        # alone, z negated, was followed for a magnetometer turned 180° about z: heading 178° off, exit 0)
        if any(np.array_equal(P, -Q) for Q in seen):
            continue
        seen.append(P)
        q = sums.copy()
        q[:, :3] = sums[:, :3] @ P
        tried.append((q, f"with the magnetometer's axes read as {_mag_reading_words(P)}", MAG_AXES_REMEDY))
    lag = max(1, int(round(WITNESS_LAG_S / h)))
    for j in (*range(-lag, 0), *range(1, lag + 1)):
        tried.append((_field_shifted(bins, sums, j), f"with the field taken {abs(j) * h:.2g} s {'later' if j > 0 else 'earlier'}",
                      LAG_REMEDY))  # fmt: skip
    best = (0.0, "", "")
    with np.errstate(all="ignore"):
        for q, how, remedy in tried:
            sp, ep, _ = mag_gyro_scale(bins, q, h)
            if np.isfinite(sp) and sp > 0 and ep > best[0]:
                best = (ep, how, remedy)
    return best


def _bins_ahead(bins: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray]:
    """(index of bin i + j among ``bins`` (sorted bin numbers), whether it is there) for each bin i."""
    at = np.minimum(np.searchsorted(bins, bins + j), bins.size - 1)
    return at, bins[at] == bins + j


def _field_shifted(bins: np.ndarray, sums: np.ndarray, j: int) -> np.ndarray:
    """``sums`` of :func:`field_rate_sums` with the field of bin i + j beside the gyro of bin i (none where that bin
    is missing)."""
    at, ok = _bins_ahead(bins, j)
    q = sums.copy()
    field = [0, 1, 2, 3, 8]  # the field's sums, count and where in the bin it was sampled
    q[:, field] = np.where(ok[:, None], sums[at][:, field], 0.0)
    return q


#: s: a magnetometer whose field turns with the gyro best when moved in time (:func:`mag_lag`, searched MAG_LAG_S
#: either way), leaving at most MAG_LAG_BETTER of what it leaves unexplained as stamped, is late or early by that
#: time; from MAG_LAG_MIN it is on another clock and refused whatever the motion: BROAD 02's magnetometer file 0.5 s
#: late ran at 55° heading RMSE with exit 0 (2 s: 6°, 0.2 s early: 3.5°; 1.35° on time)
MAG_LAG_MIN, MAG_LAG_S, MAG_LAG_BETTER = 0.15, 2.0, 0.5
#: s, degrees: a nearer lag, from MAG_LAG_NEAR, is refused where it turns the field's heading MAG_LAG_HEADING or more,
#: the yaw rate about gravity times the lag, RMS over the bins with a field turning faster than STILL_RATE. BROAD 07
#: (fast rotation) with its magnetometer 0.05-0.15 s late ran at 5.6-13° heading RMSE with exit 0 (1.2° as recorded):
#: 18-31° so; 20 ms late (a lag of 0.030 s) 8.1° so, 6.8° RMSE; 10 ms 5.6°, 1.1°. BROAD's own magnetometer is late
#: too, 0.008-0.023 s in the nine and their cuts (the heading so up to 5.9° in halves and 40-120 s cuts, 11° in 5 s of
#: 07's fastest turns). estimate() 9D, online and offline, at the full rate and a third: the nine, halves and 40-,
#: 70-, 120-s cuts (608 runs) none refused, nor with 5 ms more; their 5-, 10-, 20-s cuts (4580) none, with 5 ms more
#: 2 (5 s of 07's fastest turns at a third of the rate: 0.025 s late at 8.2°; a fit of 52 % at 0.152 s early).
#: Set 1.7× above what BROAD's own lag reaches (0.023 s, 5.9°): the other BROAD trials, whose turns are as fast or
#: faster, are evaluated elsewhere, and a refusal of a recording as it comes is worse than the 1-7° a lag of 0.03 s
#: costs on the fastest turns (07 20 ms late: 0.030 s, 8.1°, 6.8° RMSE, now run); 0.05 s late still refused (07:
#: 0.067 s, 18°)
MAG_LAG_NEAR, MAG_LAG_HEADING = 0.04, 10.0


def mag_lag(
    bins: np.ndarray, sums: np.ndarray, h: float, up: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[float, float, float, float] | None:
    """(lag s, explained at it, explained as stamped, RMS yaw rate rad/s): the time by which the magnetometer's
    stamps are late against the gyro's (< 0: early), a continuous least-squares fit to how the field turns in the
    body. Between neighbouring magnetically quiet bins (:data:`MAG_QUIET`) of :func:`field_rate_sums` (``bins``,
    ``sums``; ``h`` s a bin) the unit field's step Δu is set against −θ × ū, θ the gyro's turn between the two fields'
    times less the lag (each field at where in its bin it was sampled; the gyro's turn interpolated between the
    bins' edges), and the lag that explains most of the steps (:func:`mag_gyro_scale`'s share, at a factor > 0) is
    found on a grid of half bins over :data:`MAG_LAG_S` either way, then within a millisecond. Whole bins named a
    10-Hz magnetometer 0.3 s late 0.41 s late. The yaw rate is the gyro's about the bin's specific force (``up``:
    :func:`field_rate_sums` of the gyro and the accelerometer; None: |ω|) over the bins with a field turning faster
    than :data:`STILL_RATE`, for the heading the lag turns. None where the quiet bins turn the field less than
    :data:`MAG_SCALE_TURN` or number under 30 pairs."""
    if len(bins) == 0:
        return None
    both, S = merge_bins(np.asarray(bins), np.asarray(sums, float))
    got = S[:, 3] > 0
    m = np.where(got[:, None], S[:, :3] / np.maximum(S[:, 3], 1.0)[:, None], np.nan)
    w = S[:, 4:7] / np.maximum(S[:, 7], 1.0)[:, None]
    with np.errstate(all="ignore"):
        quiet = _quiet_of(both, m, w)
    if quiet is None:
        return None
    u, _, pair = quiet
    i = np.flatnonzero(pair)
    du = u[i + 1] - u[i]
    if float(np.sum(_norm(du))) < MAG_SCALE_TURN:
        return None
    mid = 0.5 * (u[i + 1] + u[i])
    dt = h / float(np.max(S[:, 7]))
    # times from the first bin's start: the field at its rows' mean (a row at its time), the gyro's turn summed at
    # the bins' edges, each row's rate turning the step before it (so the edges lie a row early)
    b0 = both[0]
    full = np.zeros((both[-1] - b0 + 1, 3))
    full[both - b0] = S[:, 4:7] * dt
    edge = np.vstack([np.zeros(3), np.cumsum(full, axis=0)])
    t_edge = np.arange(edge.shape[0]) * h - dt
    t = (both - b0 + 0.5) * h - 0.5 * dt + np.where(got, S[:, 8] / np.maximum(S[:, 3], 1.0), 0.0) * h
    t0, t1 = t[i], t[i + 1]
    dd = float(np.sum(du * du))

    def share(lag: float) -> float:
        th = np.column_stack([np.interp(t1 - lag, t_edge, edge[:, k]) - np.interp(t0 - lag, t_edge, edge[:, k])
                              for k in range(3)])  # fmt: skip
        pred = -np.cross(th, mid)
        pp, dp = float(np.sum(pred * pred)), float(np.sum(du * pred))
        return dp * dp / (pp * dd) if dp > 0.0 and pp > 0.0 else 0.0

    step = 0.5 * h
    grid = np.arange(-int(round(MAG_LAG_S / step)), int(round(MAG_LAG_S / step)) + 1) * step
    e = np.array([share(x) for x in grid])
    k = int(np.argmax(e))
    # golden-section search for the peak between the grid's neighbours of the best point, to 1 ms
    a, b = grid[k] - step, grid[k] + step
    g = 0.5 * (np.sqrt(5.0) - 1.0)
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = share(x1), share(x2)
    while b - a > 1e-3:
        if f1 >= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - g * (b - a)
            f1 = share(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + g * (b - a)
            f2 = share(x2)
    mid_ab = 0.5 * (a + b)
    lag, best = max((mid_ab, share(mid_ab)), (float(grid[k]), float(e[k])), key=lambda x: x[1])
    rate = _norm(w)
    if up is not None and len(up[0]):
        ub, us = merge_bins(np.asarray(up[0]), np.asarray(up[1], float))
        at = np.clip(np.searchsorted(ub, both), 0, ub.shape[0] - 1)
        f = us[at, :3]
        rate = np.where(ub[at] == both, np.abs(np.sum(w * f, axis=1)) / np.maximum(_norm(f), 1e-300), rate)
    turning = np.isfinite(u[:, 0]) & (_norm(w) > STILL_RATE)
    yaw = float(np.sqrt(np.mean(rate[turning] ** 2))) if np.any(turning) else 0.0
    return float(lag), float(best), share(0.0), yaw


def _secs(x: float) -> str:
    """``x`` s to the millisecond, trailing zeros dropped."""
    return f"{x:.3f}".rstrip("0").rstrip(".")


def check_mag_lag(
    bins: np.ndarray,
    sums: np.ndarray,
    h: float,
    up: tuple[np.ndarray, np.ndarray] | None = None,
    held_s: float = 0.0,
) -> None:
    """Refuse a magnetometer late or early against the IMU (:func:`mag_lag` of ``bins``, ``sums``, ``h``, ``up``)
    by :data:`MAG_LAG_MIN` or more, or from :data:`MAG_LAG_NEAR` by a lag that turns its heading by
    :data:`MAG_LAG_HEADING` in the turns; ``held_s``: how late the field is for being held on the rows between its
    updates (:meth:`MagHeld.hold_s`), whose remedy is its rows, not its stamps. Not judged where the field turns too
    little or the gyro explains too little of it at any lag."""
    got = mag_lag(bins, sums, h, up)
    if got is None:
        return
    lag, e, e0, yaw = got
    heading = float(np.degrees(yaw * abs(lag)))
    if not (e >= MAG_SCALE_EXPLAINED and 1.0 - e <= MAG_LAG_BETTER * (1.0 - e0)):
        return
    if abs(lag) < MAG_LAG_MIN and (abs(lag) < MAG_LAG_NEAR or heading < MAG_LAG_HEADING):
        return
    late, x = ("late", "earlier") if lag > 0 else ("early", "later")
    # a reading held on the rows until the next is late on them by the time it is held: its rows, not its stamps
    held = lag > 0 and held_s >= 0.25 * lag
    what = "field is {} s {} on the IMU's rows" if held else "time stamps are {} s {} against the IMU's"
    cause = (
        f"the magnetometer's {what.format(_secs(abs(lag)), late)}: its field turns in the body as the "
        f"gyro says when moved {_secs(abs(lag))} s {x} ({e:.0%} of its turning explained; {e0:.0%} as stamped)"
    )
    if abs(lag) < MAG_LAG_MIN:
        cause += f", which turns its heading by the yaw rate × {_secs(abs(lag))} s: {heading:.2g}° RMS in the turns"
    shift = f"{LAG_REMEDY} (its t {'−' if lag > 0 else '+'} {_secs(abs(lag))} s)"
    if held:
        rest = lag - held_s
        cause += f"; it repeats each reading on the rows until its next, which leaves it {_secs(held_s)} s late"
        shift = "give the magnetometer's readings only on the rows of its updates (NaN on the rows between)"
        if rest >= MAG_LAG_MIN or rest >= MAG_LAG_NEAR and np.degrees(yaw * rest) >= MAG_LAG_HEADING:
            shift += f", and align its time stamps with the IMU's (its t − {_secs(rest)} s)"
    raise OptinavError(cause, shift)


#: s: a gyro whose rotation turns gravity in the body as the accelerometer sees it best when moved in time by
#: GYRO_LAG_S or more, leaving at most GYRO_LAG_BETTER of what it leaves unexplained as stamped, is on another clock
#: than the accelerometer. BROAD's trials split in two files with the gyro 0.1 s late ran at 2.3-33° inclination
#: RMSE with exit 0 (0.2 s: 3.6-50°; 29 was named "gyro axes swapped"); where judged (02, 03, 24, 33) 0.1 s late
#: leaves 0.59-0.77 of the unexplained turning at the lag, 0.2 s late 0.34-0.52. Nearer lags are not judged: on a
#: smooth simulated flight (on time) the share explained peaks 0.05 s off by 0.001, flat, and a few samples' lag is
#: what an accelerometer filtered more than its gyro has (BROAD's trials 20 ms apart ran at 2-8°: not named)
GYRO_LAG_S, GYRO_LAG_BETTER = 0.08, 0.75
#: the lag is judged where gravity's turning in the quiet bins is explained this well at the best lag, by the gyro at
#: a scale within GYRO_LAG_SCALE of 1 (fast translation turns the specific force without the body: not judged)
GYRO_LAG_EXPLAINED, GYRO_LAG_SCALE = 0.5, 1.25
#: bins (of MAG_SCALE_BIN_S) searched either way
GYRO_LAG_BINS = 5


def gyro_lag(bins: np.ndarray, sums: np.ndarray, h: float) -> tuple[float, float, float] | None:
    """(lag s, explained at it, explained as stamped): the time by which the gyro's stamps are late against the
    accelerometer's, from how the specific force turns in the body (``bins``, ``sums`` of :func:`field_rate_sums`
    of the gyro and the accelerometer, ``h`` s a bin, searched :data:`GYRO_LAG_BINS` bins either way); None where
    not judged (:data:`GYRO_LAG_EXPLAINED`)."""
    if len(bins) == 0:
        return None
    both, m, w = bin_fields(bins, sums)
    js = np.arange(-GYRO_LAG_BINS, GYRO_LAG_BINS + 1)
    got = np.zeros((js.size, 3))
    with np.errstate(all="ignore"):
        for i, j in enumerate(js):
            # the specific force of bin i + j beside the gyro of bin i (NaN where that bin is missing), the bins'
            # means taken once (:func:`mag_gyro_scale` of :func:`_field_shifted` for each j took 11 ms per minute)
            at, ok = _bins_ahead(both, int(j))
            mj = np.where(ok[:, None], m[at], np.nan)
            got[i] = _scale_fit(_quiet_of(both, mj, w), h)
    e = np.where(np.isfinite(got[:, 1]), got[:, 1], 0.0)
    i = int(np.argmax(e))
    s, turned = got[i, 0], got[GYRO_LAG_BINS, 2]
    if not (e[i] >= GYRO_LAG_EXPLAINED and 1 / GYRO_LAG_SCALE <= s <= GYRO_LAG_SCALE and turned >= MAG_SCALE_TURN):
        return None
    # the gyro of bin i turns as the specific force of bin i + j does: its stamps are −j bins late
    return float(-js[i] * h), float(e[i]), float(e[GYRO_LAG_BINS])


def check_gyro_lag(bins: np.ndarray, sums: np.ndarray, h: float) -> None:
    """Refuse a gyro off the accelerometer's clock (:func:`gyro_lag`, :data:`GYRO_LAG_S`; ``bins``, ``sums`` of
    :func:`field_rate_sums` of the gyro and the accelerometer, ``h`` s a bin)."""
    got = gyro_lag(bins, sums, h)
    if got is None:
        return
    lag, e, e0 = got
    if abs(lag) >= GYRO_LAG_S - 1e-9 and 1.0 - e <= GYRO_LAG_BETTER * (1.0 - e0):
        late = "late" if lag > 0 else "early"
        raise OptinavError(
            f"the gyroscope's time stamps are about {abs(lag):.2g} s {late} against the accelerometer's: gravity "
            f"turns in the body as the gyro says when it is moved {abs(lag):.2g} s "
            f"{'earlier' if lag > 0 else 'later'} ({e:.1%} of its turning explained; {e0:.1%} as stamped)",
            f"align the gyroscope's time stamps with the accelerometer's (its t {'−' if lag > 0 else '+'} "
            f"{abs(lag):.2g} s); two files: check that they share one clock",
        )


def witness_error(bins: np.ndarray, sums: np.ndarray, h: float, gyro_unit: str | None = None) -> OptinavError | None:
    """:func:`gyro_scale_error` judged by a magnetometer the file has but the estimate does not use (``bins``,
    ``sums`` of :func:`field_rate_sums`, ``h`` s a bin): its axes may be its own chip's, not the IMU's, so a
    factor beyond :data:`MAG_SCALE_FAR` either way is the gyro's scale, and a field turning against the gyro names
    a mirrored frame only when no signed order of the magnetometer's axes, nor the field moved in time by up to
    :data:`WITNESS_LAG_S`, turns it with the gyro nearly as well (:data:`WITNESS_MIRROR_SHARE`). None when not
    judged (too little turning, disturbed or garbage values)."""
    with np.errstate(all="ignore"):
        s, explained, turned = mag_gyro_scale(bins, sums, h)
    if not (np.isfinite(s) and turned >= MAG_SCALE_TURN and explained >= MAG_SCALE_EXPLAINED):
        return None
    if abs(s) > MAG_SCALE_FAR:
        return gyro_scale_error(abs(s), explained, turned, gyro_unit)
    if s >= 0 or 1.0 - explained > WITNESS_MIRROR_SHARE * (1.0 - _turns_with_gyro_otherwise(bins, sums, h)[0]):
        return None
    return gyro_scale_error(s, explained, turned, gyro_unit)


def check_mag_axes(
    acc: np.ndarray,
    mag: np.ndarray,
    dt: float,
    gyr: np.ndarray | None = None,
    gyro_unit: str | None = None,
    held_s: float = 0.0,
) -> None:
    """Refuse (or warn about) a magnetometer whose axes are not the IMU's (:func:`mag_axes_hint`; a swapped layout
    gave a heading 77° off with exit 0), and with ``gyr`` (rad/s) one whose field does not turn or turns
    against the gyro (:func:`check_mag_turns`), a gyro that reads far less than the field turns
    (:func:`gyro_scale_error`; ``gyro_unit`` as declared) or a field late against the gyro (:func:`check_mag_lag`,
    ``held_s`` as it takes it); ``dt`` the median step (s)."""
    tilt = mag_sums(acc, mag)
    if gyr is None:
        judge_mag_axes(tilt, None, None, 0.0, None, dt, gyro_unit)
        return
    # the gyro's scale and sense first (judge_mag_axes): a field that turns about the gyro's axes by a clear factor
    # is no magnetometer in other axes (those leave the turning unexplained), and a mirrored frame was blamed on one
    rows = scale_bin_rows(dt)
    bins, sums = field_rate_sums(gyr, mag, rows)
    up = field_rate_sums(gyr, acc, rows)
    judge_mag_axes(tilt, bins, sums, rows * dt, gyro_sums(gyr), dt, gyro_unit, up, held_s)


def check_gyro_scale(
    bins: np.ndarray,
    sums: np.ndarray,
    h: float,
    gyro_unit: str | None = None,
    up: tuple[np.ndarray, np.ndarray] | None = None,
    held_s: float = 0.0,
) -> None:
    """Raise :func:`gyro_scale_error` of :func:`mag_gyro_scale` (``bins``, ``sums`` of :func:`field_rate_sums`,
    ``h`` s a bin) when it has one, then :func:`check_mag_lag` (``up``, ``held_s`` as it takes them)."""
    s, explained, turned = got = mag_gyro_scale(bins, sums, h)
    err = gyro_scale_error(*got, gyro_unit)
    if err is not None and -MAG_SCALE_FAR <= s < 0:
        # a magnetometer in axes of its own or off the IMU's time turns against the gyro too: named where a
        # reading of it turns the field with the gyro about as well (WITNESS_MIRROR_SHARE), first where better
        other, how, remedy = _turns_with_gyro_otherwise(bins, sums, h)
        if other > explained and remedy == LAG_REMEDY:
            # moved in time it turns with the gyro better (BROAD 07 at 10 Hz 0.15 s late): its lag to the
            # millisecond, with the shift that undoes it, where check_mag_lag refuses it
            check_mag_lag(bins, sums, h, up, held_s)
        if 1.0 - explained > WITNESS_MIRROR_SHARE * (1.0 - other):
            alt = f"it turns with the gyro {how} ({other:.0%} explained)"
            if other > explained:
                raise OptinavError(f"{err.cause}; {alt}: that is the likelier cause", f"{remedy}; or {err.remedy}")
            raise OptinavError(f"{err.cause}; or {alt}", f"{err.remedy}; or {remedy}")
    if err is not None:
        raise err
    check_mag_lag(bins, sums, h, up, held_s)


def warn_or_refuse_mag_axes(hint: str, refuse: bool) -> None:
    """The outcome of :func:`mag_axes_hint`: an error when overwhelming, a :class:`MagnetometerWarning` when
    strong, nothing otherwise."""
    if not hint:
        return
    if refuse:
        raise OptinavError(hint, MAG_AXES_REMEDY)
    warnings.warn(f"{hint}; {MAG_AXES_REMEDY}", MagnetometerWarning, stacklevel=3)


#: the body must turn by this much (rad, the gyro's 0.1-s means where faster than STILL_RATE) for the field's norm
#: to vary "with the orientation": a body at rest while a magnet is brought near (BROAD 29 and 33, 5-20 s before
#: their motion: the gyro turns 0 rad, the field's norm 41-87 µT) was refused online as an uncalibrated
#: magnetometer, and offline the sphere fitted to it was subtracted (33: heading 13.7° RMSE against 1.06° without)
MAG_TURNED = 1.0


def body_turned(bins: np.ndarray, sums: np.ndarray, h: float) -> float:
    """The body's turning (rad) by the gyro: Σ |ω̄| ``h`` over the bins of :func:`field_rate_sums` (``h`` s each)
    whose mean rate ω̄ exceeds :data:`STILL_RATE` (a still gyro's bias is no turning)."""
    w = _norm(bin_fields(bins, sums)[2])
    return float(np.sum(w[w > STILL_RATE]) * h)


def check_mag(
    mag: np.ndarray,
    offline: bool = False,
    given: np.ndarray | None = None,
    online: bool = False,
    turned: float = float("inf"),
) -> np.ndarray | None:
    """None when the field norm does not vary with the orientation as a constant offset makes it (:func:`hard_iron`);
    else the offset of an uncalibrated (hard-iron) magnetometer, whose heading is wrong by tens of degrees and which
    the disturbance gates cannot tell: offline (the whole recording is used anyway) the fitted offset b, for the
    estimate to subtract; online (``online``) b too, as the sign that the online estimate fits the offset from past
    samples itself (:func:`optinav.attitude.iframe.hard_iron_online`; :func:`online_fit_failed` when that never
    passes its gates); without either refused, naming b and the option that subtracts it. With the offset
    ``given`` (its unit) the field less it is judged, online and offline alike: one that still shows an offset is
    refused, naming the offset that explains it (a given offset 20 µT off turned BROAD's heading by 39° RMS with
    exit 0). ``turned``: the body's turning (rad, :func:`body_turned`); under :data:`MAG_TURNED` nothing is judged."""
    if turned < MAG_TURNED:
        return None  # the norm varies with something else than the orientation (a magnet brought near)
    if given is not None:
        got = hard_iron(mag - given)
        if got is None:
            _warn_soft_iron(mag - given)
            return None
        r, s0, s1 = got
        raise _given_offset_error(
            given, r, f"still varies by {s0:.0%} (std/median) with the orientation, and a further offset of "
            f"[{_vec(r)}] explains it down to {s1:.1%}"
        )  # fmt: skip
    got = hard_iron(mag)
    if got is None:
        _warn_soft_iron(mag)
        return None
    if offline or online:
        return got[0]
    raise _hard_iron_error(*got)


def online_fit_failed(mag: np.ndarray) -> OptinavError:
    """The refusal of an online estimate whose magnetometer shows a hard-iron offset (:func:`hard_iron` on the rows
    ``mag``) that the fit from past samples never took: the recording does not turn the sensor about every body
    axis in a steady field before its end."""
    gates = "never passed its gates (the sensor turned about every body axis in a steady field, the norm then steady)"
    got = hard_iron(mag)
    if got is None:  # asked for without the checks (mag_hard_iron="online"), or a field the checks found none in
        return OptinavError(
            f"the magnetometer's hard-iron offset fitted online from past samples {gates}",
            "pass --mag-hard-iron=BX,BY,BZ (mag_hard_iron= in Python), --offline, or no magnetometer",
        )
    return _hard_iron_error(*got, why=f"; fitted online from past samples it {gates}")


def online_offset_changed(row: int, held_s: float) -> OptinavError:
    """The refusal of an online estimate whose field, from sample ``row`` on and for ``held_s`` s to the end, no
    longer fitted the hard-iron offset fitted from past samples, while the samples since never turned the sensor
    about every body axis to fit another (:func:`optinav.attitude.iframe.online_fit_held`): the heading there was
    the gyro's alone. The offset changed (BROAD 07 with +30 µT on x from 60 s: a fit across the change, 13 µT off,
    passed its gates and the heading ran at 10.8° RMSE with exit 0), or the field is disturbed there (BROAD 29 beside
    a magnet, with an offset added: no fit of its own holds)."""
    return OptinavError(
        f"the magnetometer's field from sample {row} on no longer fits the hard-iron offset fitted online from past "
        f"samples, and the {held_s:.0f} s after it to the end never turned the sensor about every body axis to fit "
        "another (the heading there the gyro's alone): the offset changed (a magnet put on or taken off the body?) "
        "or the field is disturbed there",
        "cut the recording where it changes and run each part (optinav attitude --mag names the offset of a part "
        "that shows one), give --mag-hard-iron=BX,BY,BZ if the offset is known, or drop --mag",
    )


def _hard_iron_error(b, s0: float, s1: float, why: str = "") -> OptinavError:
    """The refusal of a magnetometer whose norm a constant offset ``b`` explains (spread ``s0`` down to ``s1``)."""
    return _offset_error(
        b, f"the magnetometer's field norm varies by {s0:.0%} (std/median) with the orientation, and a constant "
        f"offset of [{_vec(b)}] (its unit) explains it down to {s1:.1%}: an uncalibrated (hard-iron) magnetometer "
        "turns the heading by up to tens of degrees" + why
    )  # fmt: skip


def _vec(v, sep: str = ", ") -> str:
    """An offset (3,) as its messages show it, 4 significant digits."""
    return sep.join(f"{x:.4g}" for x in np.asarray(v, float))


def _offset_error(b, what: str) -> OptinavError:
    """The refusal (``what`` the cause) of a magnetometer that shows a hard-iron offset ``b``, naming it to give."""
    return OptinavError(
        what,
        f"subtract the offset: --mag-hard-iron={_vec(b, ',')} (fitted from this recording; mag_hard_iron= in Python),"
        " or pass --offline, which fits and subtracts it",
    )


def _given_offset_error(given, more, still: str) -> OptinavError:
    """The refusal of a ``given`` offset that leaves the field showing a further offset ``more`` (``still``: how)."""
    return OptinavError(
        f"the magnetometer less the given offset [{_vec(given)}] {still}: the given offset is wrong (a sign, a unit, "
        "another magnetometer's?)",
        f"give --mag-hard-iron={_vec(np.asarray(given, float) + more, ',')} (fitted from this recording; "
        "mag_hard_iron= in Python), or drop it and pass --offline, which fits and subtracts it",
    )


#: a hard-iron offset b is seen in how the field turns (dm/dt = −ω × (m − b): the field turns about b, not about
#: zero) where b explains at least this share of what the gyro leaves of its turning, over the whole log and ...
MAG_TURN_OFFSET_EXPLAINED = 0.7
#: ... at least this share in each of MAG_TURN_OFFSET_PIECES pieces of the log holding equal parts of the turning
#: it explains: an offset on the board all along, not a magnet for a while (BROAD 33 as recorded: 0.95 over the
#: whole log, −1.0 where the magnet is gone). As recorded the nine BROAD trials explain 0.00-0.47 but for 33; an
#: offset of the field's size 0.78-0.99 on every trial, the sphere fit only on those that turn every way (a body
#: that hardly tilts, BROAD 11, 16, 27, ran at a 118-138° heading RMSE with exit 0)
MAG_TURN_OFFSET_PIECE = 0.5
MAG_TURN_OFFSET_PIECES = 4
#: rad, the steps between bins are linear in the rotation only where it turns the body by at most this much per bin
#: (BROAD 07's fast rotation, up to 0.7 rad per 0.1-s bin, explained a third of its turning by a false offset)
MAG_TURN_OFFSET_STEP = 0.2
#: the offset has no part along a direction whose singular value is under this share of the largest
MAG_TURN_OFFSET_RCOND = 0.1
#: the gyro-scale check's factor from which a gyro off by it is named rather than an offset
MAG_TURN_OFFSET_FACTOR = 0.5
#: the field less the offset must keep more than this share of the offset's norm (a field of 50× the Earth's is no
#: offset the recording can be trusted beside; a stuck field leaves its noise)
MAG_TURN_OFFSET_LEFT = 0.02


def bin_fields(bins: np.ndarray, sums: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bin numbers (k,), mean field (k, 3) [the field's unit], mean gyro (k, 3) [rad/s]) of
    :func:`field_rate_sums`' bins, split bins merged."""
    if len(bins) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    both, S = merge_bins(np.asarray(bins), np.asarray(sums))
    m = np.where((S[:, 3] > 0)[:, None], S[:, :3] / np.maximum(S[:, 3], 1.0)[:, None], np.nan)  # NaN: no field
    return both, m, S[:, 4:7] / np.maximum(S[:, 7], 1.0)[:, None]


def _turn_steps(bins: np.ndarray, sums: np.ndarray, h: float):
    """The steps between neighbouring bins of :func:`field_rate_sums` (``h`` s each) that :func:`turning_offset`
    fits: (the bins' mean fields m (k, 3), the steps' residuals Δm + ω̄ × m̄ · h (j, 3), the rotations ω̄ · h (j, 3)
    (rad), their fields m̄ (j, 3) and the bin number of each step's first bin (j,)), over the steps whose both bins
    have a field and that turn by at most :data:`MAG_TURN_OFFSET_STEP`; None without bins."""
    if len(bins) == 0:
        return None
    both, m, w = bin_fields(bins, sums)
    pair = np.diff(both) == 1
    wb = (0.5 * (w[1:] + w[:-1]))[pair]
    mb = (0.5 * (m[1:] + m[:-1]))[pair]
    r0 = (m[1:] - m[:-1])[pair] + np.cross(wb, mb) * h
    ok = np.all(np.isfinite(r0), axis=1) & (_norm(wb) * h <= MAG_TURN_OFFSET_STEP)
    return m, r0[ok], wb[ok] * h, mb[ok], both[:-1][pair][ok]


def _offset_fit(r0: np.ndarray, wb: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(b, |residual| per step, explained): the offset b that the steps' residuals ``r0`` (j, 3) show against the
    rotations ``wb`` (j, 3) rad (:func:`_turn_steps`), r0 = ω̄h × b, twice trimmed of steps beyond three median
    residuals (a disturbance is no offset), and the share of the kept steps' residual it explains."""
    # ω × b = −[b]× ω = [ω]× b: rows of the three skew matrices stacked
    z = np.zeros(wb.shape[0])
    A = np.stack([np.column_stack([z, -wb[:, 2], wb[:, 1]]), np.column_stack([wb[:, 2], z, -wb[:, 0]]),
                  np.column_stack([-wb[:, 1], wb[:, 0], z])], axis=1)  # fmt: skip
    keep = np.ones(r0.shape[0], bool)
    for trim in (True, True, False):
        # no part along a direction the body hardly turns about (its singular value under a tenth of the largest):
        # the minimum-norm solution there, as hard_iron leaves it out (lstsq put hundreds of µT along a yaw axis)
        b = np.linalg.lstsq(A[keep].reshape(-1, 3), r0[keep].ravel(), rcond=MAG_TURN_OFFSET_RCOND)[0]
        res = _norm(r0 - np.cross(wb, b))
        if trim:
            keep = res <= 3.0 * np.median(res)
    e0, e1 = np.sum(r0[keep] ** 2, axis=1), res[keep] ** 2
    return b, res, 1.0 - float(e1.sum()) / max(float(e0.sum()), 1e-300)


def turning_offset(bins: np.ndarray, sums: np.ndarray, h: float) -> tuple[np.ndarray, float] | None:
    """(b, explained) when a constant offset b (the field's unit) explains how the field turns in the body against
    the gyro (least squares of Δm + ω̄ × m̄ · h = ω̄ × b · h between neighbouring bins, twice trimmed of steps beyond
    three median residuals: a disturbance is no offset) by :data:`MAG_TURN_OFFSET_EXPLAINED` over the log and
    :data:`MAG_TURN_OFFSET_PIECE` in each piece, and b exceeds :data:`MAG_OFFSET` of the field's norm less it; else
    None. Unlike :func:`hard_iron` it needs no turn about every axis: on a body that only yaws the offset across
    the vertical shows (the part along it, not seen, does not turn the heading and is left out).
    ``bins``, ``sums`` as :func:`field_rate_sums` gives them, ``h`` s a bin, the gyro in rad/s."""
    steps = _turn_steps(bins, sums, h)
    if steps is None:
        return None
    m, r0, wb, _, _ = steps
    if r0.shape[0] < 30 * MAG_TURN_OFFSET_PIECES:
        return None
    b, res, explained = _offset_fit(r0, wb)
    kept = _norm(m - b)
    left, nb = float(np.nanmedian(kept)), float(np.linalg.norm(b))
    # b = the field itself explains a field stuck at one value: nothing is left of it (check_mag_turns names that)
    if explained < MAG_TURN_OFFSET_EXPLAINED or not MAG_TURN_OFFSET_LEFT * nb < left < nb / MAG_OFFSET:
        return None
    # an offset on the board all along leaves the field less it steady at every row, the still ones too: a magnet
    # put on while the body rested, there through all the motion, explains the turning but not the field before it
    if float(np.nanstd(kept)) > MAG_STEADY * left:
        return None
    # each piece holding an equal share of the turning b predicts must be explained by it too, every step counted
    # (where a magnet on the board has gone, the trimmed steps are those the offset fails)
    e0, e1 = np.sum(r0**2, axis=1), res**2
    ep = np.sum(np.cross(wb, b) ** 2, axis=1)
    part = np.minimum((np.cumsum(ep) / max(float(np.sum(ep)), 1e-300) * MAG_TURN_OFFSET_PIECES).astype(int),
                      MAG_TURN_OFFSET_PIECES - 1)  # fmt: skip
    for k in range(MAG_TURN_OFFSET_PIECES):
        s0, s1 = float(np.sum(e0[part == k])), float(np.sum(e1[part == k]))
        if s0 <= 0.0 or 1.0 - s1 / s0 < MAG_TURN_OFFSET_PIECE:
            return None
    # a gyro off by a clear factor (57× too small, its sense flipped: |s| ≥ MAG_TURN_OFFSET_FACTOR) leaves turning an
    # offset mimics in part (BROAD 11, 16, 27 as recorded: 73-94 % explained by one 2-60× the field): the gyro-scale
    # check names it. An offset makes that check see a small factor instead (the nine with one of 1-20× the field:
    # |s| ≤ 0.21 where it would name one)
    s, share, turned = mag_gyro_scale(bins, sums, h)
    if gyro_scale_error(s, share, turned) is not None and abs(s) >= MAG_TURN_OFFSET_FACTOR:
        return None
    return b, explained


#: s, the windows in which :func:`offset_pieces` fits the offset the field turns about, each on its own
MAG_PIECE_S = 10.0
#: rad, a window is judged where the body turned by at least this much in it (Σ |ω̄| h over its steps)
MAG_PIECE_TURN = 2.0
#: two windows' offsets are different ones when they are this share of the field apart: one offset fitted in
#: windows of BROAD 24 (tapping) scatters by up to 14 % of the field; a magnet on the board 2 cm away adds 60 %
MAG_PIECE_APART = 0.25


def _pieces_field(pieces) -> float:
    """The median norm of the field less its offset over the windows of :func:`offset_pieces` (the field's unit)."""
    return float(np.median([f for _, _, f in pieces]))


def offset_pieces(bins: np.ndarray, sums: np.ndarray, h: float) -> list[tuple[int, np.ndarray | None, float]]:
    """The offset the field turns about in each window of :data:`MAG_PIECE_S` s that turns the body by
    :data:`MAG_PIECE_TURN` or more: (its first bin number, b) with b (3,, the field's unit) where it explains
    :data:`MAG_TURN_OFFSET_EXPLAINED` of what the gyro leaves of the turning, exceeds :data:`MAG_OFFSET` of the
    field less it, and leaves that field steady (:data:`MAG_STEADY`) — a body-fixed offset there — or None where
    the offset fitted is within :data:`MAG_OFFSET` of the field (it turns about zero), and the median norm of the
    field less b; a window that shows neither (a disturbance, a turn too fast for the bins) is left out. The whole log's fits (:func:`hard_iron`, :func:`turning_offset`)
    assume one offset for the whole recording; these tell whether it holds everywhere. ``bins``, ``sums``, ``h`` as
    :func:`turning_offset` takes them."""
    steps = _turn_steps(bins, sums, h)
    if steps is None:
        return []
    _, r0, wb, mb, first = steps
    if not first.shape[0]:
        return []
    per = max(1, int(round(MAG_PIECE_S / h)))
    win = first // per  # ascending: each window's steps are one slice
    cut = np.r_[0, np.flatnonzero(np.diff(win)) + 1, win.shape[0]]
    turn = np.add.reduceat(_norm(wb), cut[:-1])
    out = []
    for k, a, e, t in zip(win[cut[:-1]], cut[:-1], cut[1:], turn):
        if e - a < 30 or t < MAG_PIECE_TURN:
            continue
        at = slice(a, e)
        b, _, explained = _offset_fit(r0[at], wb[at])
        left = _norm(mb[at] - b)
        lm = float(np.median(left))
        if float(np.linalg.norm(b)) <= MAG_OFFSET * lm:
            out.append((int(k) * per, None, lm))
        elif (
            explained >= MAG_TURN_OFFSET_EXPLAINED
            and float(np.std(left)) <= MAG_STEADY * lm
            and lm > MAG_TURN_OFFSET_LEFT * float(np.linalg.norm(b))  # not a stuck field (check_mag_turns names it)
        ):
            out.append((int(k) * per, b, lm))
    return out


#: s, a steady field at rest becomes the estimate's reference after this time (iframe's default ``mag_new_time``):
#: a body-fixed offset held that long beside the windows judged is learned as the Earth's field
MAG_NEW_S = float(IFRAME_DEFAULTS["mag_new_time"])


def _learned(
    pieces, fields, h: float, field: float, at_end: bool, b=None, without=None, close=None, edge: bool = True
) -> bool:
    """Whether the estimate learns the field with an offset b for the Earth's: beyond the windows judged
    (``pieces``; before the first one, or after the last one ``at_end``: the offline backward pass) the field, bin by
    bin (``fields`` of :func:`bin_fields`, ``h`` s each), is told with b, the offset of the window nearest (its norm
    less b is the Earth's, ``field``, and less ``without`` (default zero) it is off by :data:`MAG_OFFSET`); it is
    learned where it starts the recording (ends it, for the backward pass) or is held still for :data:`MAG_NEW_S` (a
    steady new field is taken for the reference then). A magnet taken off in the rest after the motion leaves the
    Earth's field to learn there, one put on 5 s before it (BROAD 33) too. ``b`` given: that point instead (a
    window about zero counts as about it where ``b`` is zero); ``close``: its norm less b within that share of
    ``field`` too; ``edge`` False: only a still run counts (not the first or last second)."""
    order = pieces[::-1] if at_end else pieces
    if b is None:
        b = next(b for _, b, _ in order if b is not None)
        near = order[0][1] is not None
    else:
        near = (order[0][1] is None) == (not np.any(b))
    nums, m, w = fields
    per = max(1, int(round(MAG_PIECE_S / h)))
    sel = nums >= pieces[-1][0] + per if at_end else nums < pieces[0][0]
    nm = _norm(m[sel] if without is None else m[sel] - without)
    nb = _norm(m[sel] - b)
    ok = np.isfinite(nm)
    with_b = (np.abs(nb - field) < np.abs(nm - field)) & (np.abs(nm - field) > MAG_OFFSET * field)
    if close is not None:
        with_b &= np.abs(nb - field) < close * field
    with_b = with_b[ok]
    nums, still = nums[sel][ok], (_norm(w[sel]) < REST_GYR)[ok]
    if not with_b.size:
        return near  # the recording starts (ends) in that window: about b there
    k = max(1, int(round(1.0 / h)))  # the first (last) second: the pass starts there
    if edge and (with_b[-k:] if at_end else with_b[:k]).mean() > 0.5:
        return True
    # a run of still bins with b (bins without a field between them do not break it)
    return _held_new(nums, with_b & still, h)


def _held_new(nums: np.ndarray, run: np.ndarray, h: float) -> bool:
    """Whether the bins ``nums`` (``h`` s each) hold a run of ``run`` (True bins) for 1.1 × :data:`MAG_NEW_S`: 10 %
    more, as the estimate's new-field candidate starts once the field has settled (a magnet put on takes 1-2 s)."""
    return bool(_held_runs(nums, run, h))


def _held_runs(nums: np.ndarray, run: np.ndarray, h: float) -> list[tuple[int, int]]:
    """The runs of :func:`_held_new`: (first bin number, end bin number) of each."""
    return [
        (int(nums[s]), int(nums[e - 1]) + 1)
        for s, e in mask_runs(run)
        if (nums[e - 1] - nums[s] + 1) * h >= 1.1 * MAG_NEW_S
    ]


#: rad, offline the backward pass takes the field at the end for the Earth's; an offset that turns its horizontal
#: part by less than this there (one along the field's horizontal direction or along the vertical) leaves that
#: reference's heading right: BROAD 02/03/11/16/24 with (0, 20, 0) µT from 60-120 s turned the end's field by 0.2-0.6°
#: and ran offline at 0.3-3.9° (refused before), 29 offline runs with an offset that turned it by under 2° at 0.3-3.5°
#: but one (5.1°), those turning it by 2.2-2.8° up to 6.9°
MAG_END_TURN = np.radians(2.0)


def end_up(bins: np.ndarray, acc_sums: np.ndarray, counts: np.ndarray, dt: float) -> np.ndarray | None:
    """The specific force (3,) m/s² over the last second of rows with a field: the last ⌈1 s / TILT_BIN rows⌉ bins
    of :func:`mag_sums` (``bins``, ``acc_sums``, ``counts``; bins split between blocks merged), for :func:`end_turn`
    alike in memory and streamed; None without such rows."""
    b, S = merge_bins(np.asarray(bins), np.column_stack([acc_sums, counts]))
    k = _end_bins(dt)
    c = float(S[-k:, 3].sum())
    return S[-k:, :3].sum(axis=0) / c if c > 0.0 else None


def end_tail(n: int, dt: float) -> int:
    """The first row of the bins :func:`end_up` reads in a log of ``n`` rows (bins of TILT_BIN rows from row 0)."""
    return max(0, ((n - 1) // TILT_BIN - _end_bins(dt) + 1) * TILT_BIN)


def _end_bins(dt: float) -> int:
    """The TILT_BIN bins that hold the last second at the step ``dt`` s (:func:`end_up`)."""
    return max(1, int(np.ceil(1.0 / (TILT_BIN * dt))))


def end_turn(fields, h: float, b, up) -> float:
    """The angle (rad) by which the offset ``b`` turns the horizontal part of the field over the last second
    (``fields`` of :func:`bin_fields`, ``h`` s a bin) about ``up`` (3,), the specific force's direction there (body
    axes): how far the backward pass's reference, the field with b, is from the Earth's in heading; inf without a
    field there."""
    m = fields[1][-max(1, int(round(1.0 / h))) :]
    m = m[np.all(np.isfinite(m), axis=1)]
    nu = float(np.linalg.norm(up)) if up is not None else 0.0
    if not m.shape[0] or not nu > 0.0:
        return float("inf")
    u, m = np.asarray(up, float) / nu, m.mean(axis=0)
    h1, h0 = m - (m @ u) * u, (m - b) - ((m - b) @ u) * u
    return float(np.arctan2(np.linalg.norm(np.cross(h1, h0)), h1 @ h0))


#: deg, a rest's field is another than the Earth's where its angle to the specific force is off the Earth's by more
#: than this, the estimate's dip gate (``mag_dip_th``): the backward pass takes it for the Earth's all the same
#: (:func:`_rest_off_earth`). The Earth's angle is the median over the 1-s groups within the windows about zero whose
#: specific force is gravity (:data:`MAG_AXES_ACC_DEV`): within 1.6° of the start's rest on the nine trials (2-123
#: groups), whose ends are within 0.3° of their starts. A rest less an offset nearer that angle by twice this
#: carries the offset (:func:`_end_rest_with`). BROAD 16 with (-22.8, 7.0, 7.6) µT from 61 % (the end's norm 3 % off
#: the Earth's): 22.8° off as measured, 6.6° less the last window's offset, offline 13.5° heading RMSE with exit 0
#: (online 0.5°); none of the nine nor their 40-, 70- and 120-s cuts is refused by it
MAG_REST_DIP_DEG = 5.0


def _tilt_less(tilt, offset):
    """:func:`mag_sums`' sums ``tilt`` with the field's less ``offset`` (None: as they are)."""
    if offset is None:
        return tilt
    out = list(tilt)
    out[2] = field_less_offset(np.asarray(out[2]), np.asarray(out[3]), offset)
    return out


class _Angles:
    """The field's angle to the specific force (deg) per TILT_BIN bin of ``tilt`` (:func:`mag_sums` of the log;
    split bins merged), and the Earth's (:attr:`earth`, None without a group to tell it): the median over the
    :data:`MAG_AXES_S` groups within the windows about zero of ``pieces`` (``h`` s and ``rows`` samples a bin) whose
    specific force is gravity (:data:`MAG_AXES_ACC_DEV`)."""

    def __init__(self, tilt, pieces, h: float, rows: int):
        self.bins, S = merge_bins(np.asarray(tilt[0]), np.column_stack([tilt[1], tilt[2], tilt[3], tilt[4]]))
        self.acc, self.rows = S[:, :3], rows
        with np.errstate(invalid="ignore", divide="ignore"):
            self.field = S[:, 3:6] / S[:, 6:7]
        per = max(1, int(round(MAG_PIECE_S / h)))
        r0 = self.bins * TILT_BIN
        inside = np.zeros(self.bins.shape[0], bool)
        for k, b, _ in pieces:
            if b is None:
                inside |= (r0 >= k * rows) & (r0 + TILT_BIN <= (k + per) * rows)
        g = max(1, int(round(MAG_AXES_S / (TILT_BIN * h / rows))))
        u, inv = np.unique(self.bins[inside] // g, return_inverse=True)
        G = np.zeros((u.size, 8))
        np.add.at(G, inv, S[inside])
        keep = (G[:, 6] > 0.5 * g * TILT_BIN) & (G[:, 7] < MAG_AXES_ACC_DEV * G_STANDARD * G[:, 6])
        self.earth = float(np.median(self.angle(G[keep, :3], G[keep, 3:6]))) if keep.any() else None

    @staticmethod
    def angle(a: np.ndarray, m: np.ndarray) -> np.ndarray:
        """deg, the angles between the rows of ``a`` and ``m``."""
        return np.degrees(np.arctan2(_norm(np.cross(a, m)), np.sum(a * m, axis=1)))

    def at(self, nums: np.ndarray, b=None) -> np.ndarray:
        """The angle (deg) in the TILT_BIN bin holding the middle of each bin ``nums`` (of ``rows`` samples), the
        field less ``b`` (3,; None: as measured)."""
        i = np.clip(np.searchsorted(self.bins, (nums * self.rows + self.rows // 2) // TILT_BIN), 0, self.bins.size - 1)
        return self.angle(self.acc[i], self.field[i] if b is None else self.field[i] - b)


def _rest_off_earth(pieces, fields, h: float, field: float, angles: _Angles | None = None):
    """(first bin, end bin, the field's median norm there, its angle to the specific force (deg) or None) of a rest
    after the windows judged (``pieces``) in which the field, bin by bin (``fields`` of :func:`bin_fields`, ``h`` s
    each), holds 1.1 × :data:`MAG_NEW_S` with a norm off the Earth's (``field``) by twice :data:`MAG_OFFSET`, or
    with ``angles`` (:class:`_Angles`) an angle to the specific force off the Earth's by :data:`MAG_REST_DIP_DEG`:
    the backward pass takes it for the Earth's, whatever offset it carries (a window's offset fitted in fast
    rotation can be 20 µT off, so the field is not told with it); None without one."""
    nums, m, w = fields
    sel = nums >= pieces[-1][0] + max(1, int(round(MAG_PIECE_S / h)))
    nm = _norm(m[sel])
    ok = np.isfinite(nm)
    nums, nm = nums[sel][ok], nm[ok]
    off = np.abs(nm - field) > 2.0 * MAG_OFFSET * field
    ang = None
    if angles is not None and angles.earth is not None:
        ang = angles.at(nums)
        with np.errstate(invalid="ignore"):
            off |= np.abs(ang - angles.earth) > MAG_REST_DIP_DEG
    got = _held_runs(nums, off & (_norm(w[sel][ok]) < REST_GYR), h)
    if not got:
        return None
    a, e = got[0]
    there = (nums >= a) & (nums < e)
    return a, e, float(np.median(nm[there])), None if ang is None else float(np.nanmedian(ang[there]))


def _end_rest_with(pieces, fields, h: float, b: np.ndarray, field: float, angles: _Angles | None) -> bool:
    """Whether, after the windows judged (``pieces``; ``fields`` of :func:`bin_fields`, ``h`` s a bin), the last
    about the offset ``b``, the body rests for 1.1 × :data:`MAG_NEW_S` in a field not told, bin by bin, to be the
    Earth's as measured: its norm within twice :data:`MAG_OFFSET` of the Earth's (``field``) and, with ``angles``
    (:class:`_Angles`), its angle to the specific force within :data:`MAG_REST_DIP_DEG`, and less b farther
    from the Earth's by :data:`MAG_OFFSET` in norm or twice :data:`MAG_REST_DIP_DEG` in angle. A magnet taken off in the
    rest leaves the Earth's field there (BROAD 02 with 4× 33's magnet to 8 s after its motion). One kept on:
    BROAD 24 with (9.6, -25.0, 1.1) µT from 70 % of its motion, 4 % and 4.6° off the Earth's at the end, and 07
    with (-19.1, 15.1, 11.0) µT from 30 %, its window's offset fitted 20 µT off in fast rotation, ran offline at 55°
    and 17° with exit 0."""
    nums, m, w = fields
    sel = (nums >= pieces[-1][0] + max(1, int(round(MAG_PIECE_S / h)))) & np.all(np.isfinite(m), axis=1)
    sel &= _norm(w) < REST_GYR
    nums, m = nums[sel], m[sel]
    dn, dn_b = np.abs(_norm(m) - field), np.abs(_norm(m - b) - field)
    earth = dn <= 2.0 * MAG_OFFSET * field
    told = dn + MAG_OFFSET * field <= dn_b
    if angles is not None and angles.earth is not None:
        da, da_b = np.abs(angles.at(nums) - angles.earth), np.abs(angles.at(nums, b) - angles.earth)
        with np.errstate(invalid="ignore"):
            earth &= da <= MAG_REST_DIP_DEG
            told |= da + 2.0 * MAG_REST_DIP_DEG <= da_b
    return _held_new(nums, ~(earth & told), h)


def _rest_after_error(pieces, rows: int, h: float, fields, angles: _Angles | None) -> OptinavError | None:
    """Offline, the refusal of a rest after the last window (``pieces`` of :func:`offset_pieces`, that one about
    zero; ``rows`` samples and ``h`` s a bin) in a field other than the Earth's (:func:`_rest_off_earth` on
    ``fields`` of :func:`bin_fields` and ``angles``, the windows about zero giving the Earth's): an offset put on
    in motion that no window judged, the field with it learned at the end; None without one."""
    if fields is None:
        return None
    zeros = [p for p in pieces if p[1] is None]
    earth = float(np.median([f for _, _, f in zeros]))
    rest = _rest_off_earth(pieces, fields, h, earth, angles)
    if rest is None:
        return None
    a, e, norm, ang = rest
    k = zeros[-1][0]
    dip = "" if ang is None else f", at {ang:.0f}° to gravity against {angles.earth:.0f}°"
    return _offset_changes(
        f"the magnetic field turns in the body about zero from sample {k * rows} ({k * h:.1f} s), and from sample "
        f"{a * rows} ({a * h:.1f} s) it rests for {(e - a) * h:.0f} s in another field than the Earth's (its norm "
        f"{norm:.4g} against {earth:.4g}, its unit{dip}); offline the backward pass takes that field for the Earth's",
        "drop --offline (online the field before it is the reference, the offset a disturbance to it), or ",
    )


class OffsetChanges(OptinavError):
    """The refusal of a field whose hard-iron offset changes within the recording (:func:`_offset_changes`)."""


def _offset_changes(cause: str, remedy: str = "", at: str = "") -> OptinavError:
    """The refusal of a field whose hard-iron offset changes within the recording, ``cause`` saying where it shows
    (``remedy``: a first remedy before the usual ones; ``at``: where it changes, in words)."""
    return OffsetChanges(
        f"{cause}: its hard-iron offset changes within the recording (a magnet put on or taken off the body?); the "
        "heading would be off by up to tens of degrees",
        remedy + f"cut the recording where the offset changes{at} and run each part (optinav attitude --mag names the "
        "offset of a part that shows one), or drop --mag",
    )


def offset_change_error(
    pieces: list[tuple[int, np.ndarray | None, float]],
    rows: int,
    h: float,
    offset=None,
    offline: bool = False,
    fields: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    up: np.ndarray | None = None,
    tilt=None,
) -> OptinavError | None:
    """The refusal of a field whose hard-iron offset changes within the recording, from the windows of
    :func:`offset_pieces` (``rows`` samples and ``h`` s per bin) of the field less the ``offset`` the estimate
    subtracts (None: none); None when it holds. Refused: a window that still turns about a point off zero where an
    offset is subtracted (the whole log's fit, or the one given, is wrong there); without an offset, windows about
    two points :data:`MAG_PIECE_APART` apart and none about zero (no part of the log shows the Earth's field);
    online, windows about a point off zero before the first one about zero, where the estimate learns that field for
    the Earth's (:func:`_learned`, with ``fields``: :func:`bin_fields` of the field less the offset); offline, windows
    about a point off zero after the last one about zero, where the backward pass learns it (without ``fields``:
    two windows or more, to the end). BROAD 02 with +30 µT on x from 60 s (a magnet put on the board):
    online the offset fitted from past samples, a mean of both fields, turned the heading by 40° RMS with exit 0,
    offline 21°; BROAD 33 (a magnet on the board from 40 to 99 s) with (30, 0, 0) µT added everywhere: 62°, 64°.
    ``up`` (3,): the specific force's direction over the last second (body axes); offline, an offset to the end
    that turns the field there by under :data:`MAG_END_TURN` (:func:`end_turn`) is not refused. ``tilt``
    (:func:`mag_sums` of the log, the field as measured): offline, a rest at the end told with that offset by the
    field's angle to gravity (:func:`_end_rest_with`) is refused too. Offline, with no window after the last one
    about zero, a rest at the end in a field off the Earth's norm (:func:`_rest_off_earth`) is refused: the offset
    came in motion too fast for its windows to be judged (BROAD 07 with (25, 10, -20) µT from 50 %: 26.3° heading
    RMSE offline with exit 0, 1.7° online; 29 with 100 µT from 70 % of its motion: 28.7°)."""
    if not pieces:
        return None
    # the field's angle to gravity, offline, where the backward pass takes a rest's field for the Earth's
    angles = _Angles(_tilt_less(tilt, offset), pieces, h, rows) if offline and tilt is not None else None
    if not any(b is not None for _, b, _ in pieces):
        return _rest_after_error(pieces, rows, h, fields, angles) if offline and offset is None else None
    field = _pieces_field(pieces)
    zero = np.zeros(3) if offset is None else np.asarray(offset, float)
    about = [(k, zero if b is None else zero + b) for k, b, _ in pieces]  # the point each window turns about

    def about_at(i):
        return f"about [{_vec(about[i][1])}] from sample {about[i][0] * rows} ({about[i][0] * h:.1f} s)"

    def error(i: int, j: int | None, why: str, remedy: str = "") -> OptinavError:
        return _offset_changes(
            f"the magnetic field turns in the body {about_at(i)}{'' if j is None else ' and ' + about_at(j)}{why}",
            remedy,
        )

    def apart(i: int, j: int, share: float) -> bool:
        return float(np.linalg.norm(about[i][1] - about[j][1])) > share * field

    if offset is not None:
        i = next(i for i, (_, b, _) in enumerate(pieces) if b is not None)
        j = next((j for j in range(len(about)) if apart(i, j, MAG_OFFSET)), None)
        why = f", not about the offset [{_vec(offset)}] subtracted (fitted over the whole recording or given)"
        return error(i, None, why) if j is None else error(*sorted((i, j)), why)
    if all(b is not None for _, b, _ in pieces):
        j = next((j for j in range(len(about)) if apart(0, j, MAG_PIECE_APART)), None)
        if j is not None:
            return error(0, j, ", and about zero nowhere (no part of it shows the Earth's field)")
    zeros = [i for i, (_, b, _) in enumerate(pieces) if b is None]
    earth = float(np.median([pieces[i][2] for i in zeros])) if zeros else field
    # online only: offline the backward pass, from a clean end, takes some of it back (33 cut in its magnet: online
    # 13.7-68° heading RMSE, offline 0.8-21°)
    if not offline and fields is not None and zeros and zeros[0] >= 1 and _learned(pieces, fields, h, earth, False):
        return error(
            0, zeros[0], "; the estimate learns the field with that offset, at the start, for the Earth's",
        )  # fmt: skip
    last = zeros[-1] if zeros else -1
    after = len(pieces) - 1 - last  # windows after the last one about zero: all about a point off it
    # the backward pass's reference, the field at the end with the offset of the last window, turned in heading
    turned = fields is None or up is None or end_turn(fields, h, about[-1][1], up) > MAG_END_TURN
    if (
        offline
        and turned
        and last >= 0
        and (
            after >= 2
            if fields is None
            else after >= 1
            and (
                _learned(pieces, fields, h, earth, at_end=True)
                or _rest_off_earth(pieces, fields, h, earth) is not None
                or _end_rest_with(pieces, fields, h, about[-1][1] - zero, earth, angles)
            )
        )
    ):
        return error(
            last, last + 1, " to the end; offline the backward pass takes that field for the Earth's",
            "drop --offline (online the field before it is the reference, the offset a disturbance to it), or ",
        )  # fmt: skip
    if offline and offset is None and last >= 0 == after:
        err = _rest_after_error(pieces, rows, h, fields, angles)
        if err is not None:
            return err
    # no window about zero (the part before the offset does not turn enough to be judged), every one about a point
    # off it: the start, as measured, holds the Earth's field (the close test of offset_held_error) and a rest at
    # the end the field with the offset (BROAD 24 with (-20, 15, 40) µT from 60 s: 21.9° offline, 1.9° online). A
    # recording that ends in motion with it is not judged: 33's first half at 95 Hz, its magnet on from 40 s to the
    # end at 84 s, ran at 3.6° offline
    if (
        offline
        and turned
        and fields is not None
        and last < 0
        and _learned(pieces, fields, h, earth, at_end=True, edge=False)
        and (
            _learned(pieces, fields, h, earth, False, b=np.zeros(3), without=about[0][1], close=0.5 * MAG_OFFSET)
            or _rest_step(fields, h, earth, about[0][1]) is not None  # put on in a rest before the windows
        )
    ):
        return error(
            0, None, " to the end, and at its start the field as measured is the Earth's; offline the backward pass "
            "takes the field with the offset for the Earth's",
            "drop --offline (online the field at the start is the reference, the offset a disturbance to it), or ",
        )  # fmt: skip
    return None


#: s, a change of the offset between two parts of the log is placed where the field, bin by bin (0.1 s), votes for
#: each part's point on its side for at least this long: its norm less that point the Earth's, and nearer it than
#: less the other's by :data:`MAG_OFFSET` of the field (:func:`offset_parts`). A mirrored field's windows turn about
#: points it reflects to the same norm, so it votes for neither (BROAD 11 and 16 mirrored: none placed)
MAG_CHANGE_VOTES_S = 1.0
#: s, the bins this near a change of offset belong to neither part (a magnet put on takes 1-2 s)
MAG_CHANGE_MARGIN_S = 2.0
#: ... and each side's own bins may vote for the other side's point in this share at most: a point that explains how
#: the field turns but not its norm there is no offset. BROAD 29 (a magnet beside it) with the field's y and z
#: swapped: 40-s cuts whose one window turns "about" 72 µT voted 46-63 % for zero, the 400 mirrored, swapped and
#: negated layouts of the nine and their cuts never placed a change; BROAD with 25-100 µT put on partway 0 %
MAG_CHANGE_AGAINST = 0.1


def _runs(pieces, h: float) -> list[list]:
    """The windows of :func:`offset_pieces` (``h`` s a bin) in runs about one point: [first bin, end bin, point
    (3,; zero for windows about zero), windows], a new run where a window's point is :data:`MAG_PIECE_APART` of the
    field from the run's first."""
    per = max(1, int(round(MAG_PIECE_S / h)))
    field = _pieces_field(pieces)
    runs: list[list] = []
    for k, b, _ in pieces:
        p = np.zeros(3) if b is None else np.asarray(b, float)
        if runs and float(np.linalg.norm(p - runs[-1][2])) <= MAG_PIECE_APART * field:
            runs[-1][1] = k + per
            runs[-1][3].append(p)
        else:
            runs.append([k, k + per, p, [p]])
    for r in runs:  # the run's point: its windows' median (about zero: zero)
        r[2] = np.median(r[3], axis=0) if np.any(r[2]) else np.zeros(3)
    return runs


def offset_parts(pieces, fields, h: float, rows: int) -> list[tuple[int, int, np.ndarray]] | None:
    """The parts of a log whose hard-iron offset changes: (first row, end row, offset (3,)) each, the rows within
    :data:`MAG_CHANGE_MARGIN_S` of a change in none; None where the windows of :func:`offset_pieces` (``pieces``,
    ``h`` s and ``rows`` samples a bin; ``fields`` of :func:`bin_fields`, the field as measured) show no change.
    Runs of windows about one point (:func:`_runs`), and a part about zero before the first run or after the last
    where the field votes for it; each change placed by the votes of the bins between (:data:`MAG_CHANGE_VOTES_S`),
    and refused a place without them. A part about zero is needed (the Earth's field shown as measured)."""
    if not pieces:
        return None
    runs = [(a, e, p) for a, e, p, _ in _runs(pieces, h)]
    field = _pieces_field(pieces)
    nums, m, _ = fields
    ok = np.all(np.isfinite(m), axis=1)
    nums, m = nums[ok], m[ok]
    if not nums.size:
        return None
    least = max(1, int(round(MAG_CHANGE_VOTES_S / h)))

    def votes(A, B):  # bins told with A, with B
        dA, dB = np.abs(_norm(m - A) - field), np.abs(_norm(m - B) - field)
        tol = MAG_OFFSET * field
        return dA + tol < dB, dB + tol < dA

    def place(A, B, lo: int, a1: int, b0: int, hi: int) -> int | None:
        """The bin at which the field turns from A to B between bins a1 and b0, judged on the bins from lo to hi."""
        va, vb = votes(A, B)
        sel = (nums >= lo) & (nums < hi)
        n, va, vb = nums[sel], va[sel], vb[sel]
        cand = np.unique(np.clip(np.r_[n[(n >= a1) & (n <= b0)], a1, b0], a1, b0))
        before = np.searchsorted(n, cand)  # bins before each candidate
        ca, cb = np.r_[0, np.cumsum(va)], np.r_[0, np.cumsum(vb)]
        score = ca[before] - cb[before]
        i = int(np.argmax(score))
        s = before[i]
        if ca[s] < least or cb[-1] - cb[s] < least:
            return None
        # each side told with the other's point hardly ever (MAG_CHANGE_AGAINST)
        inside_a, inside_b = n < cand[i], n >= cand[i]
        against = max(vb[inside_a].mean() if inside_a.any() else 0.0, va[inside_b].mean() if inside_b.any() else 0.0)
        if against > MAG_CHANGE_AGAINST:
            return None
        return int(cand[i])

    zero = np.zeros(3)
    lo, hi = int(nums[0]), int(nums[-1]) + 1
    if np.any(runs[0][2]):  # a part about zero before the first run: the start as measured
        at = place(zero, runs[0][2], lo, lo, runs[0][0], runs[0][1])
        if at is not None and at > lo:
            runs.insert(0, (lo, at, zero))
    if np.any(runs[-1][2]):  # ... after the last
        at = place(runs[-1][2], zero, runs[-1][0], runs[-1][1], hi, hi)
        if at is not None and at < hi:
            runs.append((at, hi, zero))
    if len(runs) < 2 or all(np.any(p) for _, _, p in runs):
        return None
    cuts = []
    for (a0, a1, A), (b0, b1, B) in zip(runs[:-1], runs[1:]):
        at = place(A, B, a0, a1, b0, b1)
        if at is None:
            return None
        cuts.append(at * rows)
    margin = int(round(MAG_CHANGE_MARGIN_S / h)) * rows
    edges = [-np.inf, *cuts, np.inf]
    return [(edges[i] + (margin if i else 0), edges[i + 1] - (margin if i < len(cuts) else 0), runs[i][2])
            for i in range(len(runs))]  # fmt: skip


def _part_points(bins: np.ndarray, per: int, parts) -> np.ndarray:
    """The offset (k, 3) of the part of :func:`offset_parts` that holds each bin of ``per`` rows wholly; NaN for a
    bin across a change."""
    r0 = np.asarray(bins) * per
    out = np.full((r0.shape[0], 3), np.nan)
    for a, e, p in parts:
        out[(r0 >= a) & (r0 + per <= e)] = p
    return out


def tilt_less_parts(tilt, parts):
    """:func:`mag_sums`' sums ``tilt`` with each bin's field less the offset of its part (:func:`offset_parts`), a
    bin across a change left out (its sums zero)."""
    bins, A, M, C, E = (np.asarray(x, float) if i else np.asarray(x) for i, x in enumerate(tilt))
    pt = _part_points(bins, TILT_BIN, parts)
    ok = np.isfinite(pt[:, 0])
    return (bins, A * ok[:, None], np.where(ok[:, None], M - C[:, None] * np.nan_to_num(pt), 0.0), C * ok, E * ok)


def rate_sums_less_parts(bins: np.ndarray, sums: np.ndarray, rows: int, parts) -> np.ndarray:
    """:func:`field_rate_sums`' sums (k, 8) of ``rows``-sample bins with the field less the offset of each bin's
    part (:func:`offset_parts`), the field of a bin across a change left out (its count zero)."""
    pt = _part_points(bins, rows, parts)
    ok = np.isfinite(pt[:, 0])
    out = np.array(sums, dtype=float)
    out[:, :3] = np.where(ok[:, None], out[:, :3] - out[:, 3:4] * np.nan_to_num(pt), 0.0)
    out[:, 3] *= ok
    return out


def _parts_words(parts, rows: int, h: float) -> tuple[str, str]:
    """The parts of :func:`offset_parts` in words: about which point from which sample (s) on; and where they
    change (for the remedy)."""
    margin = int(round(MAG_CHANGE_MARGIN_S / h)) * rows
    cuts = [int(a - margin) for a, _, _ in parts[1:]]
    said = [f"about [{_vec(p)}] from sample {k} ({k / rows * h:.1f} s)" for k, (_, _, p) in zip([0, *cuts], parts)]
    at = ", ".join(f"sample {k} ({k / rows * h:.1f} s)" for k in cuts)
    return ", ".join(said[:-1]) + " and " + said[-1], f", at about {at},"


def parts_error(parts, rows: int, h: float, why: str) -> OptinavError:
    """The refusal of a field whose offset changes between the parts of :func:`offset_parts` (``rows`` samples and
    ``h`` s a bin), ``why``: what that explains."""
    where, at = _parts_words(parts, rows, h)
    return _offset_changes(f"the magnetic field turns in the body {where}{why}", at=at)


#: where the one offset of :func:`one_offset_error` came from, in its words
FITTED, GIVEN = "fitted over the whole recording", "given"


def one_offset_error(pieces, turn_bins, turn_sums, h: float, rows: int, offset, how: str) -> OptinavError | None:
    """The refusal of one ``offset`` (3,, the field's unit) for the whole recording (``how``: :data:`FITTED` or
    :data:`GIVEN`; subtracted from every row, or fitted online from past samples) where the field as measured shows
    parts about different points (:func:`offset_parts` of ``pieces``, the windows of :func:`offset_pieces` on
    ``turn_bins``, ``turn_sums`` of :func:`field_rate_sums`, ``h`` s and ``rows`` samples a bin): no one offset holds
    in all of them. BROAD 11 with (21.3, 12.4, 4.2) µT from 70 % of the recording: the whole recording's fit, (9.3,
    5.0, 1.7) µT, a mix of none and the offset, about which the windows after the change turn too little to be
    judged; offline it was subtracted and ran at 11.8° heading RMSE with exit 0, online its fit from past samples
    never passed and the refusal named it to give (--mag-hard-iron=9.34,4.97,1.675), which ran at 40°. None
    without such parts."""
    parts = offset_parts(pieces, bin_fields(turn_bins, turn_sums), h, rows)
    if parts is None:
        return None
    where, at = _parts_words(parts, rows, h)
    return _offset_changes(
        f"the magnetic field turns in the body {where}, and no one offset holds in every part (not the "
        f"[{_vec(offset)}] {how})",
        at=at,
    )


def judge_mag_axes(
    tilt, turn_bins, turn_sums, h: float, gyro, dt: float, gyro_unit: str | None = None, up=None, held_s: float = 0.0
) -> None:
    """:func:`check_mag_axes` on sums: ``tilt`` of :func:`mag_sums`, ``turn_bins``, ``turn_sums`` of
    :func:`field_rate_sums` (``h`` s a bin; None: not judged) and ``gyro`` of :func:`gyro_sums` (None: not
    judged); ``dt`` the median step (s); ``up``, ``held_s`` as :func:`check_gyro_scale` takes them."""
    warn_or_refuse_mag_axes(*mag_axes_hint(*tilt, dt))
    if turn_sums is not None:
        check_gyro_scale(turn_bins, turn_sums, h, gyro_unit, up, held_s)
    if gyro is not None:
        check_mag_turns(tilt[0], tilt[2], tilt[3], *gyro, dt)


def axes_or_change(
    refused: OptinavError,
    err,
    pieces,
    rows: int,
    h: float,
    turn_bins,
    turn_sums,
    tilt,
    gyro,
    dt: float,
    gyro_unit=None,
    up=None,
    held_s: float = 0.0,
) -> OptinavError:
    """What to raise where the magnetometer-axes checks refused the field (``refused``; :func:`check_mag_axes`)
    and an offset that changes within the recording may be the cause: where the windows of the field as measured
    (``pieces`` of :func:`offset_pieces` on ``turn_bins``, ``turn_sums`` of :func:`field_rate_sums`, ``rows``
    samples and ``h`` s a bin) show parts about different points (:func:`offset_parts`) and the checks pass on the
    field less each part's (:func:`judge_mag_axes`; ``tilt`` of :func:`mag_sums`, ``gyro`` of :func:`gyro_sums`,
    the field as measured), the change: ``err`` where the offset checks named one, else :func:`parts_error`.
    Otherwise ``refused``. BROAD 02 with 100 µT from 30 % was refused as a mirrored frame and 16 so as a
    magnetometer in other axes; remapping its columns as told ran 12-174° off with exit 0."""
    parts = offset_parts(pieces, bin_fields(turn_bins, turn_sums), h, rows)
    if parts is None:
        return refused
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            less = rate_sums_less_parts(turn_bins, turn_sums, rows, parts)
            judge_mag_axes(tilt_less_parts(tilt, parts), turn_bins, less, h, gyro, dt, gyro_unit, up, held_s)
        except OptinavError:
            return refused
    if isinstance(err, OffsetChanges):  # said where the estimate learns it (offline: "drop --offline")
        return err
    return parts_error(
        parts, rows, h, "; less each part's offset it turns as the gyro says, which as measured it does not"
    )


#: rad, the steps between bins in which the body turns (mean rate over :data:`STILL_RATE`) must turn it by this much
#: in all for :func:`moving_offset` to judge the offset they show
MAG_UNSEEN_TURN = 0.3
#: the share of those steps' turning (less the gyro's) that the offset must explain: BROAD's cuts (40, 70, 120 s and
#: whole, every half length, at 1/1 and 1/3 of the rate) as recorded 0.00-0.36 outside the magnet trial 33 (whose
#: magnet on the board is an offset: 0.46-0.95); with (25, -15, 35) µT 0.6 or more in 215 of the 218 that turn the
#: body by 2 rad (07's fast rotation aside: its 0.1-s bins turn too far), 27 (a phone vibrating on it) 0.65-0.69,
#: 29 beside its magnet 0.37-0.59
MAG_UNSEEN_EXPLAINED = 0.6


#: the steps at rest (mean rate under :data:`STILL_RATE`) from which :func:`moving_offset` measures the noise of a
#: step's residual, at least
MAG_NOISE_STEPS = 30
#: the turning's residual an offset explains must be this many times a step's noise (its mean square at rest) for
#: the noise to be taken off what it leaves: pure noise gives 3 (the offset's three components), beyond 12 once in
#: 150 logs
MAG_NOISE_SIGNIF = 12.0


#: the most by which the spread (std/median) of the field's norm less an offset :func:`moving_offset` fits may
#: exceed the field's own (and at least by its own spread)
MAG_NORM_WORSE = 0.02


def _step_noise(r0: np.ndarray) -> float:
    """The mean square (the field's unit²) of the residual of a step at rest, from those steps' residuals ``r0``
    (j, 3) of :func:`_turn_steps` (the median, against a disturbance, of |r0|² scaled to the mean of a χ² of three
    degrees of freedom); NaN under :data:`MAG_NOISE_STEPS`."""
    if r0.shape[0] < MAG_NOISE_STEPS:
        return float("nan")
    return float(np.median(np.sum(r0**2, axis=1))) * 3.0 / 2.366


def _beyond_noise(e0: float, e1: float, count: int, noise: float, signif: float = MAG_NOISE_SIGNIF) -> float:
    """The share of the residual ``e0`` (a sum of squares over ``count`` steps) beyond their noise (``noise`` a
    step's mean square, :func:`_step_noise`) that an offset leaving ``e1`` explains; 0 where what it explains is
    under ``signif`` × ``noise`` (or the noise is not known)."""
    floor = count * noise
    if not (e0 - e1 >= signif * noise and e0 > floor):
        return 0.0
    return 1.0 - max(e1 - floor, 0.0) / (e0 - floor)


def moving_offset(bins: np.ndarray, sums: np.ndarray, h: float) -> tuple[int, int, np.ndarray, float, float] | None:
    """(first bin, last bin, b, median norm of the field less b, explained) of the offset b (3,, the field's unit)
    that the field turns about over the steps of :func:`_turn_steps` in which the body turns (mean rate over
    :data:`STILL_RATE`): :func:`turning_offset`'s fit on those steps alone, which holds a few seconds of motion in a
    log at rest (the still steps' noise set its trim and hid them: BROAD's last 40 s, 0.4-2 rad of turning, with
    (25, -15, 35) µT). None where they turn the body by under :data:`MAG_UNSEEN_TURN` rad, or b explains under
    :data:`MAG_UNSEEN_EXPLAINED` of their turning or under :data:`MAG_TURN_OFFSET_PIECE` of the kept steps' in
    either half of what it predicts — each share the larger of that of their residual and that of what the noise
    of a step at rest leaves of it (:func:`_beyond_noise`) — or b is zero or :data:`MAG_TURN_OFFSET_LEFT` beyond
    the field less it (no size floor: whether b matters is the heading turn it gives, :func:`offset_heading`).
    ``bins``, ``sums``, ``h`` as :func:`turning_offset` takes them."""
    steps = _turn_steps(bins, sums, h)
    if steps is None:
        return None
    _, r0, wb, mb, first = steps
    mov = _norm(wb) >= STILL_RATE * h
    if np.count_nonzero(mov) < 10 or float(np.sum(_norm(wb[mov]))) < MAG_UNSEEN_TURN:
        return None
    # the noise of a step, from the steps at rest: a residual of 4.6 µT beside 40 µT (dip -67°) explained 27 % of
    # 2.5 rad of turning, whose residual was two-thirds the magnetometer's noise (0.26 µT a sample), and ran at 16°
    # heading RMSE with exit 0; 80 % of what the noise leaves
    noise = _step_noise(r0[~mov])
    r0, wb, mb, first = r0[mov], wb[mov], mb[mov], first[mov]
    b, res, explained = _offset_fit(r0, wb)
    e0, e1, ep = np.sum(r0**2, axis=1), res**2, np.sum(np.cross(wb, b) ** 2, axis=1)
    # the steps the fit keeps (a room-fixed magnet the body passes is no offset: BROAD 29 with (25, -15, 35) µT,
    # 20-25 % of its steps beside it, explained 10-30 % in a half with them, 62-96 % without; as recorded 1-24 %)
    kept = res <= 3.0 * np.median(res)

    def share(part, signif: float) -> float:
        s0, s1 = float(np.sum(e0[part])), float(np.sum(e1[part]))
        raw = 1.0 - s1 / s0 if s0 > 0.0 else 0.0
        return max(raw, _beyond_noise(s0, s1, int(np.count_nonzero(part)), noise, signif))

    explained = max(explained, share(kept, MAG_NOISE_SIGNIF))
    left, nb = float(np.median(_norm(mb - b))), float(np.linalg.norm(b))
    if explained < MAG_UNSEEN_EXPLAINED or not 0.0 < nb < left / MAG_TURN_OFFSET_LEFT:
        return None
    late = np.cumsum(ep) > 0.5 * float(np.sum(ep))
    for part in (~late & kept, late & kept):  # each half by what the offset itself gives (3: its three components)
        if share(part, 3.0) < MAG_TURN_OFFSET_PIECE:
            return None
    # an offset leaves the field less it steadier in norm than the field as measured (what hard_iron fits): in fast
    # rotation (7-13 rad/s) the field lags the gyro, and BROAD 07's 5-10 s from 85 s, its norm steady within 0.8 %,
    # fitted 58-63 µT beside 50 µT that left it 6-9 % spread, refused as an offset turning the heading 104-107°
    # (0.4-3.8° as measured)
    if not _norm_kept(mb, b):
        return None
    return int(first[0]), int(first[-1]) + 1, b, left, explained


def _norm_kept(m: np.ndarray, b: np.ndarray) -> bool:
    """Whether the fields ``m`` (k, 3) less the offset ``b`` (3,) spread (std/median of the norm) no more than the
    fields do by :data:`MAG_NORM_WORSE` or their own spread, whichever is more: an offset leaves the field less it
    steadier in norm (what :func:`hard_iron` fits), a fit to a lagging field in fast rotation does not."""
    m = m[np.all(np.isfinite(m), axis=1)]
    if m.shape[0] < 2:
        return True
    raw, less = _norm(m), _norm(m - b)
    spread = float(np.std(raw) / np.median(raw))
    return float(np.std(less) / np.median(less)) - spread <= max(spread, MAG_NORM_WORSE)


def _carried(fields, h: float, k: int, b: np.ndarray, field: float, at_end: bool) -> bool:
    """Whether the field the estimate takes for its reference at the start of the recording (``at_end``: the
    backward pass's, at its end) carries the offset ``b`` the field turns about from bin ``k`` on (up to bin ``k``).
    Yes where the recording starts within a second of ``k``, or its first second's norm is off the Earth's
    (``field``, the motion's field less b) by :data:`MAG_OFFSET` (with b, or neither: a reference off either way;
    BROAD 33 from 40 s with (25, -15, 35) µT: 31.4 µT, 70.7 less its magnet's offset too, the Earth's 45.0; 99°
    with exit 0). No where it is the Earth's and less b further off (33 from 20 s, its magnet put on before the
    motion: 44.4 µT, 69.9 less it). The norm telling neither: yes where the body turns throughout up to ``k`` (no
    still second for a magnet to be put on or taken off in), or the field at ``k`` is the first second's within
    :data:`MAG_OFFSET` of ``field`` across a rest (the bins' rates summed less their median, the gyro's bias, under
    half :data:`MAG_OFFSET` rad; each bin's noise summed as a path crossed that in 40 s). ``fields`` of
    :func:`bin_fields`, ``h`` s a bin."""
    nums, m, w = fields
    ok = (nums > k if at_end else nums < k) & np.all(np.isfinite(m), axis=1)
    s = max(1, int(round(1.0 / h)))
    if not ok.any() or (nums[ok][-1] - nums[ok][0] + 1) <= s:
        return True
    mm, ww = m[ok], w[ok]
    edge = np.median(mm[-s:] if at_end else mm[:s], axis=0)
    nm, nb = abs(float(np.linalg.norm(edge)) - field), abs(float(np.linalg.norm(edge - b)) - field)
    if nm > MAG_OFFSET * field:  # not the Earth's as measured: with b, or neither (a reference off either way)
        return True
    # the Earth's as measured, and less b further off; a residual b under MAG_PIECE_APART of the field moves the norm
    # by |b| at most, so there by half MAG_OFFSET or more (4.6 µT beside 40 µT, the norms 0.3 µT apart, said the
    # start clean and ran at 16° with exit 0)
    if nm < nb and (nb - nm > 0.5 * MAG_OFFSET * field or float(np.linalg.norm(b)) > MAG_PIECE_APART * field):
        return False
    if float(np.linalg.norm(np.sum(ww - np.median(ww, axis=0), axis=0))) * h >= 0.5 * MAG_OFFSET:
        still = _norm(ww) < STILL_RATE
        return not any(e - st >= s for st, e in mask_runs(still))
    return float(np.linalg.norm(np.median(mm[:s], axis=0) - np.median(mm[-s:], axis=0))) < MAG_OFFSET * field


#: rad, an offset the estimate would keep that turns the heading by less than this (RMS over the log) is not refused:
#: the heading error is the angle between the field's horizontal part with and without it, so an offset along the
#: vertical, or a small one beside a strong horizontal field, turns it little. A calibrated magnetometer's residual
#: of 2.9 µT beside 28 µT (dip 23°) and one of 6.6 µT along the body's z beside 57 µT on a body that tilts little
#: were refused at 2.4° and 1.6° heading RMSE (the offsets beyond MAG_OFFSET of the field). It gives 0.75-1.2× the
#: heading RMSE the raw field runs at where that is over 4° (2.9 µT beside 36 µT, dip −51°: 4.9° for 5.5°, refused)
MAG_UNSEEN_HEADING = np.radians(4.0)


def offset_heading(b: np.ndarray, bins, acc_sums, field_sums, counts) -> float:
    """rad, the RMS over the TILT_BIN bins of :func:`mag_sums` (split bins merged) of the heading turn an offset
    ``b`` (3,, the field's unit) left in the field gives: the angle between the horizontal parts (across the bin's
    mean specific force, taken for up) of the field and of the field less b; NaN without a bin with a field."""
    if len(bins) == 0:
        return float("nan")
    _, S = merge_bins(np.asarray(bins), np.column_stack([acc_sums, field_sums, counts]))
    ok = S[:, 6] > 0
    up, m = S[ok, :3], S[ok, 3:6] / S[ok, 6:7]
    up = up / np.maximum(_norm(up), 1e-300)[:, None]

    def level(v):
        return v - np.sum(v * up, axis=1)[:, None] * up

    mh, eh = level(m), level(m - b)
    turn = np.arctan2(_norm(np.cross(mh, eh)), np.sum(mh * eh, axis=1))
    return float(np.sqrt(np.mean(turn**2))) if turn.size else float("nan")


def offset_tolerated(turn: float, mag: np.ndarray, turns, tilt) -> bool:
    """Whether an online estimate uses the field as measured, fitting no offset from past samples, beside the offset
    that the whole recording's fit (:func:`check_mag`) shows, which turns the heading by ``turn`` (rad,
    :func:`offset_heading` on ``tilt``, :func:`mag_sums` of the log): where that is under
    :data:`MAG_UNSEEN_HEADING`, as an offset no fit sees is tolerated; and so does the sphere fitted along all three
    axes to the rows ``mag`` (n, 3) and the offset the turning steps show (:func:`moving_offset` of ``turns``,
    :func:`field_rate_sums` and the bin's s): the whole recording's offset has no part along an axis the body turned
    little about, and a residual of 4.5 µT beside 30 µT fitted so (2.1° of heading) turned the heading by 7.7° (8.1°
    RMSE with exit 0). The fit from past samples never passes its gates where the motion spreads the norm too
    little: simulated residuals of 2-8 µT beside 28-57 µT that the raw field ran at 0.9-2.6° were refused, or, the
    fit passing late, ran at 54-126° with exit 0 (the field then unused until it passed, the heading the gyro's from
    the start; since, used as measured there where :func:`measured_before_fit` says so)."""
    m = mag[np.all(np.isfinite(mag), axis=1)]
    seen = []
    if m.shape[0] >= 100:
        seen.append(_sphere_fit(m, np.eye(3))[0])
    moving = moving_offset(*turns)
    if moving is not None:
        seen.append(moving[2])
    return bool(turn < MAG_UNSEEN_HEADING) and all(offset_heading(v, *tilt[:4]) < MAG_UNSEEN_HEADING for v in seen)


#: rad, the RMS heading turn (:func:`offset_heading`) under which an online estimate uses the field as measured
#: before its fit from past samples passes (:func:`measured_before_fit`)
MAG_MEASURED_HEADING = np.radians(20.0)


def measured_before_fit(turn: float) -> bool:
    """Whether an online estimate that fits an offset from past samples uses the field as measured until that fit
    passes: where the whole recording's offset turns its heading by ``turn`` (rad, :func:`offset_heading`) under
    :data:`MAG_MEASURED_HEADING`; else the field is unused there and the heading the gyro's from an arbitrary start.
    Residuals of 2-8 µT beside 28-57 µT on simulated logs whose fit passed 28-79 % into them ran at 39-123° heading
    RMSE with exit 0 (the start's heading arbitrary), now 1.8-11.0°; BROAD 02 with +30 µT on x (offset_heading 58°)
    runs unused before its fit."""
    return bool(turn < MAG_MEASURED_HEADING)


def _offset_pulls_heading(fields, h: float, k0: int, k1: int, b: np.ndarray, field: float, offline: bool, tilt) -> bool:
    """Whether the offset ``b`` (3,, the field's unit) that the field turns about from bin ``k0`` to bin ``k1``
    (``fields`` of :func:`bin_fields`, ``h`` s each; ``field`` the field less it) and that no fit takes out turns the
    estimate's heading: the estimate takes the field with it for the Earth's at its start (``offline`` at its end
    too: :func:`_carried`), and b turns the heading by :data:`MAG_UNSEEN_HEADING` or more (:func:`offset_heading` on
    ``tilt()``, :func:`mag_sums` of the log; ``tilt`` None: not judged)."""
    if not _carried(fields, h, k0, b, field, False) or (offline and not _carried(fields, h, k1 - 1, b, field, True)):
        return False
    return tilt is None or bool(offset_heading(b, *tilt()[:4]) >= MAG_UNSEEN_HEADING)


def offset_unseen_error(
    pieces: list[tuple[int, np.ndarray | None, float]],
    bins: np.ndarray,
    sums: np.ndarray,
    h: float,
    rows: int,
    mag: np.ndarray,
    offline: bool = False,
    tilt=None,
) -> OptinavError | None:
    """The refusal of a field, no offset subtracted, that turns about one point off zero wherever it is judged and
    about zero nowhere: the windows of :func:`offset_pieces` (``pieces`` of ``bins``, ``sums`` of
    :func:`field_rate_sums`, ``rows`` samples and ``h`` s a bin) all about it, or, with none judged, the steps in
    which the body turns (:func:`moving_offset`), or, with neither, the norm of the rows ``mag`` (n, 3)
    (:func:`sphere_offset`), and the estimate takes that field for the Earth's at its start (offline at its end
    too: :func:`_carried`). An
    uncalibrated magnetometer in a log that turns it too little for the whole log's fits: BROAD's last 40 s with
    (25, -15, 35) µT ran at 78-94° heading RMSE with exit 0. None otherwise (a window about zero shows the Earth's
    field; a magnet put on in the rest before the motion leaves the start's reference clean: BROAD 33 from 20 s; with
    ``tilt``, a callable giving :func:`mag_sums` of the log, an offset that turns the heading by under
    :data:`MAG_UNSEEN_HEADING`: :func:`offset_heading`)."""
    if any(b is not None for _, b, _ in pieces) and any(b is None for _, b, _ in pieces):
        return None
    # each fit only where the one before it shows nothing
    moving = moving_offset(bins, sums, h)
    if pieces and pieces[0][1] is None:
        # windows about zero, the usual case, tell no offset within MAG_OFFSET of the field from none (their gate):
        # they do not speak against one that small the turning steps show (2.2 µT beside 30 µT, dip -68°: 4.7-10.6°
        # heading RMSE with exit 0)
        field = _pieces_field(pieces)
        if moving is None or np.linalg.norm(moving[2]) > MAG_OFFSET * field:
            return None
        pieces = []
    sphere = sphere_offset(mag) if moving is None and not pieces else None
    fields = bin_fields(bins, sums)
    if pieces:
        field = _pieces_field(pieces)
        if moving is not None and np.linalg.norm(moving[2] - pieces[0][1]) <= MAG_PIECE_APART * field:
            k0, k1, b, _, explained = moving
        else:
            (k0, b, _), k1, explained = pieces[0], pieces[-1][0] + max(1, int(round(MAG_PIECE_S / h))), None
    elif moving is not None:
        k0, k1, b, field, explained = moving
    elif sphere is not None:
        b, field, explained = *sphere[:2], None
        turning = fields[0][_norm(fields[2]) >= STILL_RATE]
        if not turning.size:
            return None
        k0, k1 = int(turning[0]), int(turning[-1]) + 1
    else:
        return None
    if not _norm_kept(fields[1][(fields[0] >= k0) & (fields[0] < k1)], b):  # a fit to a field lagging in fast
        # rotation (BROAD 07 from 90 s: a 10-s window's 63 µT beside 50 µT)
        return None
    if not _offset_pulls_heading(fields, h, k0, k1, b, field, offline, tilt):
        return None
    if pieces or moving is not None:
        share = "" if explained is None else f" (that offset explains {explained:.0%} of what the gyro leaves of it)"
        seen = (
            f"the magnetic field turns in the body about [{_vec(b)}] (its unit), not about zero, wherever the body "
            f"turns from sample {k0 * rows} ({k0 * h:.1f} s){share}"
        )
    else:
        seen = (
            f"the magnetometer's field norm varies by {sphere[2]:.0%} (std/median) with the orientation, and an offset "
            f"of about [{_vec(b)}] (its unit) explains it down to {sphere[3]:.1%}"
        )
    return OptinavError(
        f"{seen}: an uncalibrated (hard-iron) magnetometer, and the recording turns it too little (or too fast) for "
        "the offset to be fitted; the heading would be off by up to tens of degrees",
        "give --mag-hard-iron=BX,BY,BZ from a calibration that turns the sensor every way (mag_hard_iron= in "
        "Python), a calibrated magnetometer, or drop --mag",
    )


def small_offset(bins: np.ndarray, sums: np.ndarray, h: float, tilt) -> np.ndarray | None:
    """Offline, the offset b (3,, the field's unit) for the estimate to subtract where the steps in which the body
    turns show it (:func:`moving_offset`) and no fit of the whole log does: within :data:`MAG_OFFSET` of the field,
    under the gates of :func:`hard_iron`, :func:`turning_offset` and the windows of :func:`offset_pieces` (which call
    it about zero, or judge none), and turning the heading (:func:`_offset_pulls_heading` offline; ``tilt`` a
    callable giving :func:`mag_sums` of the log): what :func:`offset_unseen_error` refuses online. A residual of
    2-6 µT beside 35-55 µT on simulated logs that turn for a few seconds: refused at 1.6-7.7° heading RMSE, 0.1-1.2°
    with the offset subtracted. None otherwise. ``bins``, ``sums``, ``h`` as :func:`moving_offset` takes them."""
    pieces = offset_pieces(bins, sums, h)
    if any(p is not None for _, p, _ in pieces):
        return None
    moving = moving_offset(bins, sums, h)
    if moving is None:
        return None
    k0, k1, b, field, _ = moving
    if pieces:
        field = _pieces_field(pieces)
    if float(np.linalg.norm(b)) > MAG_OFFSET * field:
        return None
    return b if _offset_pulls_heading(bin_fields(bins, sums), h, k0, k1, b, field, True, tilt) else None


def _rest_step(fields, h: float, field: float, b: np.ndarray):
    """(first bin, last bin, step (3,)) of a rest (bins of :func:`bin_fields`, ``h`` s each, whose mean rate is
    under :data:`REST_GYR`, 3 s or more, turning by under half :data:`MAG_OFFSET` rad in all, less its median rate)
    whose field's last
    second differs from its first by :data:`MAG_OFFSET` of ``field`` or more and within half of ``b`` from ±``b``;
    None without one."""
    nums, m, w = fields
    k = max(1, int(round(1.0 / h)))
    ok = np.all(np.isfinite(m), axis=1)
    rest = ok & (_norm(w) < REST_GYR)
    rest[1:] &= np.diff(nums) == 1  # a run is consecutive bins
    nb = float(np.linalg.norm(b))
    for s, e in mask_runs(rest):
        # the turn less the gyro's bias (its median over the rest: 0.24 rad over BROAD 02's 40 s)
        if e - s < 3 * k or float(np.sum(_norm(w[s:e] - np.median(w[s:e], axis=0)))) * h >= 0.5 * MAG_OFFSET:
            continue
        d = np.median(m[e - k : e], axis=0) - np.median(m[s : s + k], axis=0)
        if float(np.linalg.norm(d)) >= MAG_OFFSET * field and min(_norm(np.array([d - b, d + b]))) < 0.5 * nb:
            return int(nums[s]), int(nums[e - 1]), d
    return None


def offset_held_error(
    bins: np.ndarray, sums: np.ndarray, h: float, rows: int, offset, offline: bool = False
) -> OptinavError | None:
    """The refusal of an ``offset`` subtracted from every row (fitted over the whole recording, or given) that the
    field as measured shows not to hold everywhere; None when it holds. Judged on the windows of
    :func:`offset_pieces` of the field as measured (``bins``, ``sums``: :func:`field_rate_sums`, not less the
    offset; ``rows`` samples, ``h`` s per bin): their offsets are those of the field less it plus it, but each is
    judged by how much of the turning it explains against zero, not against the offset (a window 8 µT off the
    offset explained a quarter of that: none was judged). Refused: a window about zero where the offset is
    :data:`MAG_PIECE_APART` of the field (the median norm of the windows' fields less their points); where the
    estimate learns its reference, the start (offline also the end: the backward pass), a field told without the
    offset (:func:`_learned`: its norm the Earth's, less the offset off by :data:`MAG_OFFSET`). BROAD with an offset
    from 30-120 s, offline: the whole recording's fit, a mean of no offset and the offset (11 with (30, 0, 0) µT
    from 60 s: (13.8, 0, 0)), or the offset where the motion after it dominates (24 with (0, 20, 0) µT from 60 s),
    subtracted from the field before it too, turned the heading by 10-68° RMS with exit 0."""
    pieces = offset_pieces(bins, sums, h)
    if offset is None or not pieces:
        return None
    b = np.asarray(offset, float)
    field = _pieces_field(pieces)

    subtracted = f"the offset [{_vec(b)}] subtracted (fitted over the whole recording or given)"

    def error(i: int, where: str) -> OptinavError:
        k, p, _ = pieces[i]
        return _offset_changes(
            f"the magnetic field {where} is the Earth's as measured, not less {subtracted}, and from sample "
            f"{k * rows} ({k * h:.1f} s) it turns in the body about [{_vec(np.zeros(3) if p is None else p)}]"
        )

    zero = next((i for i, (_, p, _) in enumerate(pieces) if p is None), None)
    if zero is not None and float(np.linalg.norm(b)) > MAG_PIECE_APART * field:
        k = pieces[zero][0]
        return _offset_changes(f"the magnetic field turns in the body about zero from sample {k * rows} ({k * h:.1f} s), "
                       f"not about {subtracted}")  # fmt: skip
    # a rest in which the field steps by the offset (put on, or taken off) while the body does not turn: the field
    # on one side of the step carries none (BROAD with it put on in the rest before the motion, 30 s: the whole
    # recording's fit the offset, the windows agree with it, and the rest before it told by its norm by under 8 %)
    fields = bin_fields(bins, sums)
    step = _rest_step(fields, h, field, b)
    if step is not None:
        i, j, d = step
        return _offset_changes(f"the magnetic field steps by [{_vec(d)}] within a rest from sample {i * rows} ({i * h:.1f} s) "
                       f"to {j * rows} ({j * h:.1f} s) while the body does not turn: {subtracted} is not there on "
                       "one side of the step")  # fmt: skip
    # the field as measured within half MAG_OFFSET of the windows' norm: an offset fitted a few µT off on a body
    # that hardly tilts leaves the field less it 8-12 % off (BROAD 11, 16 with (30, 0, 0) µT all along)
    told = {"b": np.zeros(3), "without": b, "close": 0.5 * MAG_OFFSET}
    if float(np.linalg.norm(b)) <= MAG_OFFSET * field:
        # windows call an offset that small about zero (their gate): they tell nothing of where it is (the turning
        # steps' residual of 3 µT beside 48 µT, subtracted offline, was refused as not at the start)
        return None
    if _learned(pieces, fields, h, field, False, **told):
        return error(0, "at the start of the recording (where the estimate learns its reference)")
    if offline and _learned(pieces, fields, h, field, True, **told):
        return error(len(pieces) - 1, "at the end of the recording (where the backward pass learns its reference)")
    return None


def check_turning_offset(
    bins: np.ndarray, sums: np.ndarray, h: float, offline: bool = False, given: np.ndarray | None = None
) -> np.ndarray | None:
    """:func:`check_mag` for an offset seen in how the field turns (:func:`turning_offset`) where the sphere fit saw
    none: offline the offset b for the estimate to subtract, online refused naming it; with the offset ``given``
    (its unit) the field less it is judged, and one that still turns about a point off zero is refused."""
    got = turning_offset(bins, rate_sums_less_offset(sums, given), h)
    if got is None:
        return None
    b, explained = got
    if given is not None:
        raise _given_offset_error(
            given, b, f"still turns in the body about a point off zero: a further offset of [{_vec(b)}] explains "
            f"{explained:.0%} of what the gyro leaves of its turning"
        )  # fmt: skip
    if offline:
        return b
    raise _offset_error(
        b, f"the magnetic field turns in the body about [{_vec(b)}] (its unit), not about zero: that offset explains "
        f"{explained:.0%} of what the gyro leaves of its turning; an uncalibrated (hard-iron) magnetometer turns the "
        "heading by up to tens of degrees"
    )  # fmt: skip


def still_sums(gyr: np.ndarray, acc: np.ndarray, row0: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Bin numbers (k,) and per TILT_BIN-sample bin of a block starting at row ``row0`` the sums of gyr, gyr², acc,
    acc² (3 columns each) and the row count, (k, 13) (a bin split between blocks: :func:`merge_bins`)."""
    if not gyr.shape[0]:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 13))
    n = gyr.shape[0]
    bins, first = _bin_starts(n, row0)
    out = np.empty((first.shape[0], 13))
    for j, x in enumerate((gyr, gyr * gyr, acc, acc * acc)):  # each its own reduceat: 25× faster than one stack
        out[:, 3 * j : 3 * j + 3] = np.add.reduceat(x, first, axis=0)
    out[:, 12] = np.diff(np.append(first, n))
    return bins, out


#: s, the shortest run of still bins whose gyro is read as its bias at rest
STILL_RUN_S = 1.0


#: a steady turn with a steady specific force turns about it, but for the tilt a centripetal acceleration gives:
#: tan(angle) = a_c / g, so |f| >= g / cos(angle); beyond TURN_ANGLE from f with |f| within TURN_NORM of g (a scale
#: error of an uncalibrated accelerometer, a centripetal acceleration of 0.45 g at most) no turn explains the gyro
TURN_ANGLE, TURN_NORM = np.radians(30.0), 0.1


def _turn_like(w: np.ndarray, f: np.ndarray) -> bool:
    """Whether a steady gyro reading ``w`` (3,) rad/s with the steady specific force ``f`` (3,) m/s² may be a steady
    turn of the body (about the vertical, as on a turntable or in a vehicle's curve) rather than a bias."""
    nf = float(np.linalg.norm(f))
    if abs(nf / G_STANDARD - 1.0) > TURN_NORM:
        return True
    return float(np.linalg.norm(np.cross(w, f))) <= np.sin(TURN_ANGLE) * float(np.linalg.norm(w)) * nf


#: a run of still bins is a slow steady turn, not a rest, where its accelerometer turns by this share of the angle
#: its gyro (across the specific force) says: a bias leaves the specific force put, a turn turns it as much
STILL_TURN_SHARE = 0.5


def _turning_run(gm: np.ndarray, am: np.ndarray, secs: np.ndarray, above: float = 0.0) -> bool:
    """Whether a run of still bins (gyro means ``gm`` (k, 3) rad/s, accelerometer means ``am`` (k, 3) m/s², ``secs``
    (k,) s each) is a steady turn beyond ``above`` rad/s about an axis off the specific force, not a rest: at a high
    rate a bin is short, and a turn of 0.1–0.5 rad/s about a horizontal axis varies the accelerometer too little
    within one, but between the run's first and last bins the specific force turns as the gyro says (a bias: not)."""
    w = np.mean(gm, axis=0)
    if float(np.linalg.norm(w)) <= above:
        return False
    f0, f1 = am[0], am[-1]
    span = float(np.sum(secs) - 0.5 * (secs[0] + secs[-1]))  # s between the first and the last bin's centres
    f = 0.5 * (f0 + f1)
    nf = float(np.linalg.norm(f))
    if not nf > 0.0:
        return False
    said = float(np.linalg.norm(np.cross(w, f / nf))) * span  # rad across f
    seen = float(np.arctan2(np.linalg.norm(np.cross(f0, f1)), np.dot(f0, f1)))
    return seen >= STILL_TURN_SHARE * said and said > 0.0


#: where the still runs' means disagree, the longest run is the rest only if it lasts this many times as long as
#: each run that disagrees with it (:func:`_rest_runs`)
REST_RUN_LEAD = 2.0
#: times the runs that disagree with the rest change their sense of turning about it, in time order, for a swing
#: (out, back, out, back: two swings); a turntable's rests at both ends and one faster step between change it twice
REST_SWING_TURNS = 3


def _rest_runs(means: np.ndarray, secs: np.ndarray, forces: np.ndarray) -> np.ndarray | None:
    """Which of still runs whose gyro means ``means`` (k, 3) rad/s disagree are the rest, (k,) bool, or None where
    that is not told; ``secs`` (k,) s their lengths, ``forces`` (k, 3) m/s² their specific forces. The rest is the
    longest run with those within :data:`REST_GYR_STD` of it, where it lasts :data:`REST_RUN_LEAD` times as long as
    each other run, each of those differs from it by a turn about its specific force that the accelerometer does
    not see (:func:`_turn_like`), and they either all read more than it or turn back and forth about it
    (:data:`REST_SWING_TURNS`): the peak rates of a swing about the vertical (a level body resting 20 s, then
    swinging ±30° every 10 s: 1.3-s runs at the bias ± 18 °/s, whose disagreement left a 3 °/s bias unread and the
    6D heading 104° RMS off, with exit 0). Otherwise a shorter run that reads less may be the rest and the long one
    a slow steady turn (a turntable started after 10 s at rest): not told."""
    k = int(np.argmax(secs))
    keep = _norm(means - means[k]) <= REST_GYR_STD
    if keep.all():  # each within REST_GYR_STD of the longest, if not of the median
        return keep
    if secs[k] < REST_RUN_LEAD * np.max(secs[~keep]):
        return None
    rest = np.median(means[keep], axis=0)
    turns, f = means[~keep] - rest, forces[~keep]
    if not all(_turn_like(w, g) for w, g in zip(turns, f)):
        return None  # two rests whose gyro disagrees (a bias that changed): not told which holds
    about = np.sign(np.einsum("ij,ij->i", turns, f))  # the sense of each turn about the specific force, in time
    swings = np.count_nonzero(np.diff(about)) >= REST_SWING_TURNS
    if np.min(_norm(means[~keep])) <= np.linalg.norm(rest) and not swings:
        return None
    return keep


def rest_reading(bins: np.ndarray, sums: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(median gyro over the still bins (3,) rad/s, their median specific force (3,) m/s², seconds of them) from
    :func:`still_sums`: bins whose gyro and accelerometer hardly vary (std under :data:`REST_GYR_STD` rad/s and
    :data:`REST_ACC_STD` m/s²), in runs of at least :data:`STILL_RUN_S` whose neighbouring bins' gyro means agree
    within REST_GYR_STD and whose accelerometer does not turn as the gyro says (:func:`_turning_run`: a slow steady
    turn); None under STILL_RUN_S of them. Where the runs' means disagree beyond REST_GYR_STD, the runs
    :func:`_rest_runs` takes for the rest (the others: turns the accelerometer does not see); None where it tells
    none."""
    if len(bins) == 0:
        return None
    b, S = merge_bins(np.asarray(bins), np.asarray(sums))
    c = np.maximum(S[:, 12:13], 1.0)
    gm, am = S[:, 0:3] / c, S[:, 6:9] / c
    sg = np.sqrt(np.maximum(S[:, 3:6] / c - gm * gm, 0.0).sum(axis=1))
    sa = np.sqrt(np.maximum(S[:, 9:12] / c - am * am, 0.0).sum(axis=1))
    still = (sg < REST_GYR_STD) & (sa < REST_ACC_STD) & (S[:, 12] >= TILT_BIN / 2)
    # runs of consecutive still bins whose means agree with their neighbour's
    joined = still[1:] & still[:-1] & (np.diff(b) == 1) & (_norm(np.diff(gm, axis=0)) < REST_GYR_STD)
    need = max(2, int(np.ceil(STILL_RUN_S / (TILT_BIN * dt))))
    runs = [(s, e + 1) for s, e in mask_runs(joined) if e + 1 - s >= need]
    # beyond REST_GYR only: a slower turn is taken for a rest by the estimator as well, its bias judged as one
    runs = [(s, e) for s, e in runs if not _turning_run(gm[s:e], am[s:e], S[s:e, 12] * dt, REST_GYR)]
    if not runs:
        return None
    means = np.array([np.median(gm[s:e], axis=0) for s, e in runs])
    rows = np.concatenate([np.arange(s, e) for s, e in runs])
    bias = np.median(gm[rows], axis=0)
    if np.max(_norm(means - bias)) > REST_GYR_STD:
        secs = np.array([np.sum(S[s:e, 12]) for s, e in runs]) * dt
        forces = np.array([np.median(am[s:e], axis=0) for s, e in runs])
        keep = _rest_runs(means, secs, forces)
        if keep is None:
            return None
        rows = np.concatenate([np.arange(s, e) for (s, e), k in zip(runs, keep) if k])
        bias = np.median(gm[rows], axis=0)
    return bias, np.median(am[rows], axis=0), float(np.sum(S[rows, 12]) * dt)


def _turn_or_bias(reading: tuple[np.ndarray, np.ndarray, float]) -> bool:
    """Whether a :func:`rest_reading` exceeds :data:`REST_GYR` about an axis a steady turn may have
    (:func:`_turn_like`: a vehicle's or a turntable's, not only a constant bias; as :func:`_rest_bias`)."""
    return float(np.linalg.norm(reading[0])) > REST_GYR and _turn_like(reading[0], reading[1])


def rest_offset(reading: tuple[np.ndarray, np.ndarray, float] | None) -> np.ndarray | None:
    """The gyro's :func:`rest_reading` (3,) rad/s where it is beyond :data:`REST_GYR` about an axis no steady turn
    has — a bias, which the unit, time-base and axes checks take off the gyro before they judge how it turns
    gravity (their own bias allowances end at 5.7 °/s: BROAD 27 with [0.15, −0.075, 0.11] rad/s added was told
    "deg/s declared rad/s", and the gyro then declared so ran) — else None."""
    if reading is None or float(np.linalg.norm(reading[0])) <= REST_GYR or _turn_or_bias(reading):
        return None
    return reading[0]


def bias_not_turn(bins: np.ndarray, sums: np.ndarray, gap_bins: np.ndarray, reading: np.ndarray) -> bool:
    """Whether the whole log (:func:`whole_log_bins` of the gyro as read) shows a rest ``reading`` (3,) rad/s about
    the vertical to be a bias, not a steady turn: taking it off the gyro lowers how far gravity drifts in the
    gyro-integrated frame by :data:`LOW_AXES_FLOOR` or more (the motion between tilts the body: a bias about its
    vertical then turns gravity, a turntable's turn about the world's vertical does not; on a level body both drifts
    are noise: a turn's steady peak read as a rest, taken off, steadied gravity by 0.1° of 0.2°). BROAD's nine,
    upside down or not, cut to their last two thirds or not, at 1, 1/3 and 1/6 of their rate, with 0.11–1.0 rad/s
    added on z: the drift falls to 0.07–0.82 of itself (trial 11 cut, which hardly tilts, by 0.01–0.02 rad: not
    judged); a turntable's 0.11–1.0 rad/s about the vertical under each of those raises it 1.35–20×. False where
    the log is too short to tell."""
    pieces = _long_pieces(bins, sums, gap_bins, debias=False)
    if not pieces:
        return False
    less = [(g - reading, a, T) for g, a, T in pieces]
    return _long_drift(pieces, 1.0) - _long_drift(less, 1.0) >= LOW_AXES_FLOOR


def _reads_at_rest(bias: np.ndarray, seconds: float) -> str:
    """The words of a refusal for the gyro's ``bias`` (3,) rad/s read over ``seconds`` s at rest."""
    worst = float(np.max(np.abs(bias)))
    return (
        f"the gyro reads [{', '.join(f'{v:.4g}' for v in bias)}] rad/s ({np.degrees(worst):.3g} °/s on its worst axis) "
        f"over {seconds:.3g} s at rest"
    )


def field_tells_turn(bins: np.ndarray, sums: np.ndarray, h: float, reading: np.ndarray) -> bool | None:
    """Whether the magnetic field shows a rest ``reading`` (3,) rad/s of the gyro to be a steady turn (True) or a
    bias (False). Between neighbouring magnetically quiet bins (:data:`MAG_QUIET`; ``bins``/``sums``/``h`` of
    :func:`field_rate_sums`) the unit field steps as the body turns: by what the gyro less the reading predicts
    plus c times what the reading alone predicts; c (least squares) is 1 for a turn, 0 for a bias. Told where c is
    within :data:`FIELD_TELLS` of one of them and its standard error under a third of that; None otherwise (a field
    that hardly turned with the reading, or a disturbed one)."""
    quiet = _quiet_steps(bins, sums)
    if quiet is None:
        return None
    u, w, pair = quiet
    r = np.asarray(reading, dtype=float)
    du, less, alone = _turns(u, w - r, pair, h, np.broadcast_to(r, w.shape))
    pp = float(np.sum(alone * alone))
    if not pp > 0.0:
        return None
    c = float(np.sum((du - less) * alone)) / pp
    res = (du - less) - c * alone
    se = float(np.sqrt(np.sum(res * res) / max(res.size - 1, 1) / pp))
    if se > FIELD_TELLS / 3.0:
        return None
    if abs(c - 1.0) < FIELD_TELLS:
        return True
    return False if abs(c) < FIELD_TELLS else None


#: how near 1 (a turn) or 0 (a bias) the field's share of a rest reading must be (:func:`field_tells_turn`)
FIELD_TELLS = 0.35


def check_bias_range(
    reading: tuple[np.ndarray, np.ndarray, float] | None, clip: float, method: str = "iframe", whole=None, field=None
) -> None:
    """Refuse a gyro whose bias at rest exceeds on an axis the ``clip`` (rad/s) the estimator tracks (iframe's
    ``bias_clip``, default 2 °/s): the estimate is clipped there and the rest is drift — BROAD 02 with [0.06, -0.03,
    0.045] rad/s added ran at 5.9° inclination RMSE with exit 0, 0.39° with bias_clip raised. The rest reading is
    :func:`rest_reading` (None: no rest); beyond :data:`REST_GYR` about the vertical it may be a steady turn, judged by the whole log
    where ``whole()`` gives its bins (:func:`bias_not_turn`; BROAD 02 with 0.154 rad/s on z ran at 8.7° with exit
    0), else left alone. With a magnetometer (``field()``: the bins, sums and bin length of :func:`field_rate_sums`)
    a reading about the vertical is a turn or a bias as the field tells (:func:`field_tells_turn`): a level body
    turning steadily at 2.5–3.5 °/s (a boat, a turntable) was refused as a bias beyond the clip, which no rest
    detector tells from one. The remedy names a clip that holds it (an option of iframe; gd/cg/qn/mekf have the
    bias from iframe's front end at its default clip, ``method``). Within the clip, from :data:`SLOW_TURN` on, a
    reading the field tells a turn is refused too (:func:`_slow_turn_error`)."""
    if reading is None:
        return
    bias, _, seconds = reading
    turn = _turn_or_bias(reading)
    worst, told = float(np.max(np.abs(bias))), None
    if field is not None and _turn_like(bias, reading[1]) and worst > min(clip, SLOW_TURN):
        told = field_tells_turn(*field(), bias)
        if told and worst <= clip:
            raise _slow_turn_error(bias, seconds, clip, method)
    if turn and told is not False and (whole is None or not bias_not_turn(*whole(), bias)):
        return
    if worst <= clip or told:
        return
    wanted = float(np.ceil(2.0 * worst * 100.0) / 100.0)
    why = (
        "not a steady turn: taken off, gravity drifts far less in the gyro's frame over the motion"
        if turn
        else "unless the body turned steadily about the vertical there"
    )
    raise OptinavError(
        f"{_reads_at_rest(bias, seconds)}: a bias beyond the ±{clip:.4g} rad/s the estimator tracks (bias_clip), "
        f"so the attitude would drift ({why})",
        "subtract the bias from the gyro (calibrate it, optinav apply), or pass " + _clip_option(wanted, method),
    )


def _clip_option(clip: float, method: str) -> str:
    """The options that run ``method``'s estimate with iframe's ``bias_clip`` at ``clip`` rad/s (gd/cg/qn/mekf
    have the bias from iframe's front end at its default clip: ``--method iframe``)."""
    option = f"--option bias_clip={clip:g} (bias_clip={clip:g} in Python)"
    return option if method == "iframe" else f"--method iframe {option}"


#: rad/s, the slowest steady turn read at rest that the field is asked about within the clip (:func:`_slow_turn_error`):
#: taken for the bias, it turns the 9D heading by about its rate × tau_mag (5° at 0.5 °/s)
SLOW_TURN = np.radians(0.5)


def _slow_turn_error(reading: np.ndarray, seconds: float, clip: float, method: str) -> OptinavError:
    """The refusal of a rest reading (3,) rad/s within ``clip`` that the magnetic field tells a steady turn of the
    body (:func:`field_tells_turn`): the rest detector takes a turn under the clip for the gyro bias (rest needs
    each axis of the low-passed rate within it, VQF's rule) and learns it, which no gyro and accelerometer tell
    from a bias. A level body yawing at 0.5 / 1.0 / 1.5 °/s with a magnetometer ran at 3.9 / 7.8 / 11.6° 9D heading
    RMSE (the field pulling the heading back over tau_mag), 6D 25-76° off in 55 s, with exit 0. The remedy: a clip
    between the bias and the turn, half the reading (the field tells at most about a third of it bias)."""
    wanted = float(f"{0.5 * float(np.max(np.abs(reading))):.2g}")
    return OptinavError(
        f"{_reads_at_rest(reading, seconds)}, and the magnetic field turns in the body as that rate says: a steady "
        f"turn, which the estimator would take for its gyro bias (within bias_clip, ±{clip:.4g} rad/s), so the "
        "attitude would drift",
        "pass " + _clip_option(wanted, method) + ", under the turn",
    )


#: the methods that, as published (no input stage), estimate no gyro bias
UNTRACKED_BIAS_METHODS = ("gd", "cg", "qn")


def check_untracked_bias(reading: tuple[np.ndarray, np.ndarray, float] | None, method: str) -> None:
    """Refuse for a method without a bias estimate (:data:`UNTRACKED_BIAS_METHODS`, as published) a gyro bias at rest
    beyond :data:`REST_GYR` off the vertical (:func:`rest_offset` of a :func:`rest_reading`): the unit checks judge
    the gyro without it, so it is named here — BROAD 27 with [0.15, −0.075, 0.11] rad/s added was told "deg/s
    declared rad/s" under ``qn`` as published, and with that taken off ran at 35° inclination RMSE (5.8° without)."""
    bias = rest_offset(reading)
    if bias is None or method not in UNTRACKED_BIAS_METHODS:
        return
    worst = float(np.max(np.abs(bias)))
    raise OptinavError(
        f"{_reads_at_rest(bias, reading[2])}: a bias, which {method} as published does not estimate, so the attitude "
        "would drift",
        "subtract the bias from the gyro (calibrate it, optinav apply), or drop --no-input-stage (its front end "
        f"estimates the bias; beyond 2 °/s with --method iframe --option bias_clip={np.ceil(2.0 * worst * 100.0) / 100.0:g})",
    )


def imu_checks(gyr, acc, dts, frame: str, method: str, opts: dict, input_stage: bool, q0=None, field=None) -> float:
    """The checks :func:`~optinav.attitude.estimate` runs on gyr (N, 3) rad/s, acc (N, 3) m/s² and dts (N,) or (1,)
    s before it estimates: :func:`check_imu`, the gyro bias against what ``method`` tracks (``opts``,
    ``input_stage``; ``field()``: the magnetometer's :func:`field_rate_sums`), the frame warning and, with ``q0``
    (4,), its tilt. Returns the typical step (s) they judged by."""
    from optinav.attitude.methods import bias_clip

    step = float(np.median(dts))
    clip = bias_clip(method, opts, input_stage)
    reading = rest_reading(*still_sums(gyr, acc), step)
    # a bias beyond what the unit checks allow for is taken off for them: it is judged as a bias just after
    check_imu(gyr, acc, dts, rest=rest_offset(reading))
    if clip is not None:
        check_bias_range(reading, clip, method, whole=lambda: whole_log_bins(gyr, acc, dts), field=field)
    else:
        check_untracked_bias(reading, method)
    check_frame(acc, frame, dt=step)
    if q0 is not None:
        check_q0(q0, acc, frame)
    return step


#: a streaming filter judges its inputs (:class:`StartChecks`) on its first START_S s at least (the span of the
#: gyro-unit window), on more while gravity has turned in the body by less than START_TURN rad (:func:`tilt_steps`;
#: how it turns tells the gyro's unit; a body at rest tells little), up to START_MAX_S s or START_MAX_ROWS samples
START_S = UNIT_WINDOW_S
START_TURN = 1.0
START_MAX_S = 60.0
START_MAX_ROWS = 1 << 19
#: samples given one by one are kept as numbers in blocks of this many rows (a float in a tuple takes 32 bytes)
START_BLOCK_ROWS = 4096


class StartChecks:
    """:func:`imu_checks` run once on a stream's first samples (a streaming filter's; the arguments after ``dts``):
    :meth:`sample` and :meth:`chunk` gather them, judge them once they span :data:`START_S` s with gravity turned by
    :data:`START_TURN` rad in the body (at most :data:`START_MAX_S` s; a still start's last START_S s) and then
    return True (the filter drops this object: no cost after). A refusal is raised again for every later sample: a loop that skips refused samples
    cannot run on."""

    def __init__(self, frame: str, method: str, opts: dict, input_stage: bool = True, q0=None):
        self._args = (frame, method, opts, input_stage, q0)
        self._rows: list[tuple] = []  # one sample's (gx, gy, gz, ax, ay, az, dt) each, since the last block
        self._blocks: list[np.ndarray] = []  # (n, 7) arrays: chunks, and the rows gathered before them
        self.n, self.t = 0, 0.0  # samples and seconds gathered
        self._gone = 0.0  # seconds of them no longer kept (a still start's beyond START_S)
        self._due = START_S  # the time at which the samples are judged (next)
        self.error: OptinavError | None = None

    def anew(self, q0=None) -> StartChecks:
        """The checks after the filter's reset from ``q0``: gathering begins anew (the samples judged must be one
        stretch), a refusal stands (the units are the sensor's)."""
        return self if self.error is not None else StartChecks(*self._args[:4], q0)

    def sample(self, g, a, h: float) -> bool:
        """One sample (gyr, acc (3,), step h s) before the filter uses it; True once the inputs passed."""
        if self.error is not None:
            self._refuse()
        if type(g) is np.ndarray:  # numbers (a caller may reuse its arrays): tolist takes half the time of g[0], …
            g = g.tolist()
        if type(a) is np.ndarray:
            a = a.tolist()
        rows = self._rows
        rows.append((*g, *a, h))
        self.t += h
        return (self.t >= self._due or len(rows) >= START_BLOCK_ROWS) and self._more()

    def chunk(self, g: np.ndarray, a: np.ndarray, d: np.ndarray) -> bool:
        """A chunk (gyr, acc (N, 3), steps d (N,) or (1,) s) before the filter uses it: its rows up to where the
        inputs are judged (a long first chunk is judged on its first seconds); True once the inputs passed."""
        if self.error is not None:
            self._refuse()
        self._flush()
        n = min(g.shape[0], START_MAX_ROWS - self.n)
        d = np.broadcast_to(d, (g.shape[0],))[:n]
        t = self.t + np.cumsum(d)
        i = 0
        while i < n:
            j = min(n, max(i, int(np.searchsorted(t, self._due))) + 1)  # through the row they are judged at next
            self._blocks.append(np.column_stack([g[i:j], a[i:j], d[i:j]]))
            self.n, self.t, i = self.n + j - i, float(t[j - 1]), j
            if (self.t >= self._due or self.n >= START_MAX_ROWS) and self._judge():
                return True
        return False

    def _more(self) -> bool:
        """After a block of samples, or with the judgement due: judged (True: the inputs passed) or not yet."""
        self._flush()
        return (self.t >= self._due or self.n >= START_MAX_ROWS) and self._judge()

    def _flush(self) -> None:
        """The rows gathered one by one as a block."""
        if self._rows:
            k = len(self._rows)
            self._blocks.append(np.fromiter(itertools.chain.from_iterable(self._rows), float, 7 * k).reshape(k, 7))
            self._rows = []
            self.n += k

    def _judge(self) -> bool:
        """Run the checks once gravity has turned enough in the body (else judge later; at the limits in any case)."""
        self._flush()
        x = self._blocks[0] if len(self._blocks) == 1 else np.concatenate(self._blocks)
        x = x[np.isfinite(x).all(axis=1)]  # a non-finite sample the filter refused
        self.t = self._gone + float(np.sum(x[:, 6]))
        end = self.t >= START_MAX_S or self.n >= START_MAX_ROWS
        if x.shape[0] < 2 or not (end or self._tilted(x) >= START_TURN):
            self._blocks = [self._recent(x)]
            self._due = min(self.t + 0.25 * START_S, START_MAX_S)
            return False
        self._blocks = []
        if self._gone:  # a still start: its last START_S s, with the turning that ended the wait
            x = self._recent(x)
        try:
            imu_checks(x[:, :3], x[:, 3:6], x[:, 6], *self._args)
        except OptinavError as exc:
            self.error = exc
            self._refuse()
        return True

    def _recent(self, x: np.ndarray) -> np.ndarray:
        """The rows of ``x`` (n, 7) in its last START_S s: a still start tells no more than that and costs the checks
        time (BROAD 02 lies still for 42 s); q0's tilt is judged on the stream's first rows before they go."""
        k = int(np.searchsorted(np.cumsum(x[::-1, 6]), START_S)) + 1
        if k >= x.shape[0]:
            return x
        frame, method, opts, stage, q0 = self._args
        if q0 is not None:
            check_q0(q0, x[:, 3:6], frame)
            self._args = (frame, method, opts, stage, None)
        self._gone += float(np.sum(x[:-k, 6]))
        return x[-k:]

    @staticmethod
    def _tilted(x: np.ndarray) -> float:
        """How far gravity turned in the body (rad) over the rows ``x`` (n, 7) (:func:`tilt_steps`)."""
        return float(np.sum(tilt_steps(*tilt_sums(x[:, 3:6]), float(np.median(x[:, 6])))[1]))

    def _refuse(self):
        """Raise the refusal (anew each time: one error's traceback would grow with every sample)."""
        exc = self.error
        again = "feed the corrected samples to a new filter (this one refuses every later sample)"
        raise type(exc)(
            f"the stream's first {self.t:.3g} s: {exc.cause}", again if exc.remedy is None else f"{exc.remedy}; {again}"
        ) from None
