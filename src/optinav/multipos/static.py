"""Static-interval detection on raw IMU logs, and manual section lists.

A sample is *static* when the total moving variance of the accelerometer (and, if given, of the gyroscope)
over a centred window of ``window_s`` seconds is below a threshold. The moving variance is
``v(t_i) = Σ_axes var{x(t) : |t − t_i| ≤ window_s/2}`` (population variance, in the input units²), computed
for irregular timestamps from cumulative sums with window bounds found by ``searchsorted``. Runs of static
samples become intervals; each is trimmed by ``trim_s`` (default half a window) at both ends so that slow
motion onsets do not leak in, and intervals shorter than ``min_duration_s`` after trimming are dropped.

Automatic threshold (imu_tk's idea, Tedaldi et al., ICRA 2014, §IV-A: thresholds as multiples of the noise
variance): the noise floor is the mode of log10(v) (a calibration log is mostly at rest, so the densest
variance level is the at-rest noise; ``init_rest_s`` uses the variance of an initial rest period instead, as
imu_tk does). Candidates are ``m × floor`` for geometrically spaced multipliers ``m``; the same ``m`` applies
to the gyroscope floor. :func:`threshold_candidates` returns them all with their detections, so a
calibrator can choose by a fit criterion; :func:`detect_static` with ``threshold=None`` takes the default
rule below (:func:`default_candidate`), which never prefers a candidate just because it finds fewer
intervals:

    the largest interval count that is *stable*, i.e. found by at least :data:`STABLE_RUN` consecutive
    candidates (a factor ≈ 1.9 in threshold); the middle candidate of its longest such run.

Too-low thresholds split poses into fragments that ``min_duration_s`` drops, too-high ones merge poses
through slow motion; both give fewer intervals, so the largest stable count is the plateau of separated
poses, and its geometric middle is farthest from both failure modes. A count that appears for one or two
candidates only (a borderline pause) is not trusted. Note that an accelerometer alone cannot see a rotation
about the vertical; pass ``gyro`` to exclude such turns.
"""

from __future__ import annotations

import json

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optinav.core.files import parse_json, read_text
from optinav.core.results import Result
from optinav.core.validate import as_float_array, check_positive, check_timestamps, mask_runs
from optinav.errors import OptinavError

__all__ = [
    "StaticDetection",
    "ThresholdCandidates",
    "SectionList",
    "moving_variance",
    "noise_floor",
    "threshold_candidates",
    "default_candidate",
    "detect_static",
    "intervals_from_mask",
    "sections_from_list",
    "detection_from_sections",
    "DEFAULT_MULTIPLIERS",
    "STABLE_RUN",
]

#: default threshold multipliers of the noise floor (geometric, 1.5 … 300, ratio ≈ 1.37)
DEFAULT_MULTIPLIERS = tuple(float(m) for m in np.geomspace(1.5, 300.0, 18))
#: a count is "stable" when it holds over this many consecutive candidates (a factor ≈ 1.9 in threshold)
STABLE_RUN = 3

_EPS = np.finfo(float).eps


# --------------------------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------------------------


@dataclass(eq=False)
class StaticDetection(Result):
    """Static intervals found in a log.

    ``t_intervals`` (K, 2) are [t0, t1] in s (first and last sample time); ``index_ranges`` (K, 2) are the
    half-open sample ranges [i0, i1) of the same intervals; ``acc_means``/``gyro_means`` (K, 3) the mean
    outputs per interval (input units) and ``counts`` (K,) the samples per interval. ``acc_variance`` and
    ``gyro_variance`` (N,) are the moving variances (input units²); ``threshold``/``gyro_threshold`` the
    values used. ``method`` is "auto", "threshold" or "manual".
    """

    SCHEMA = "optinav.static_detection"
    VERSION = 2

    t_intervals: np.ndarray = field(metadata={"unit": "s"})
    index_ranges: np.ndarray = field(metadata={"unit": ""})
    acc_means: np.ndarray = field(metadata={"unit": "input acc units"})
    gyro_means: np.ndarray | None = field(metadata={"unit": "input gyro units"})
    counts: np.ndarray = field(metadata={"unit": ""})
    acc_variance: np.ndarray | None = field(metadata={"unit": "(input acc units)^2"})
    gyro_variance: np.ndarray | None = field(metadata={"unit": "(input gyro units)^2"})
    threshold: float | None = field(metadata={"unit": "(input acc units)^2"})
    gyro_threshold: float | None = field(metadata={"unit": "(input gyro units)^2"})
    window_s: float | None = field(metadata={"unit": "s"})
    min_duration_s: float | None = field(metadata={"unit": "s"})
    trim_s: float | None = field(metadata={"unit": "s"})
    method: str = field(default="threshold", metadata={"unit": "-"})
    names: list | None = field(default=None, metadata={"unit": "-"})

    @property
    def n_intervals(self) -> int:
        return int(len(self.index_ranges))

    @property
    def durations(self) -> np.ndarray:
        """Interval durations t1 − t0 (s)."""
        ti = np.asarray(self.t_intervals, dtype=float).reshape(-1, 2)
        return ti[:, 1] - ti[:, 0]

    def mask(self, n: int) -> np.ndarray:
        """Boolean (n,) mask of the samples inside the intervals."""
        m = np.zeros(int(n), dtype=bool)
        for i0, i1 in np.asarray(self.index_ranges, dtype=int).reshape(-1, 2):
            m[i0:i1] = True
        return m


@dataclass(eq=False)
class ThresholdCandidates:
    """Candidate thresholds ``multipliers × noise floor`` and the detection each gives.

    ``thresholds``/``gyro_thresholds`` (M,) in input units²; ``n_intervals`` (M,), ``static_time_s`` (M,);
    ``detections`` the M :class:`StaticDetection` (sharing the variance arrays); ``default_index`` the
    candidate picked by the rule in the module docstring.
    """

    multipliers: np.ndarray
    noise_floor: float
    gyro_noise_floor: float | None
    thresholds: np.ndarray
    gyro_thresholds: np.ndarray | None
    n_intervals: np.ndarray
    static_time_s: np.ndarray
    detections: list
    default_index: int

    @property
    def default(self) -> StaticDetection:
        return self.detections[self.default_index]


@dataclass(eq=False)
class SectionList(Result):
    """Validated, time-ordered sections of a log: ``t_intervals`` (K, 2) [t0, t1] s (first and last sample
    time), ``index_ranges`` (K, 2) half-open sample ranges [i0, i1), ``names`` (K,) ('' when unnamed)."""

    SCHEMA = "optinav.section_list"
    VERSION = 2

    t_intervals: np.ndarray = field(metadata={"unit": "s"})
    index_ranges: np.ndarray = field(metadata={"unit": ""})
    names: list = field(metadata={"unit": "-"})

    def as_dict(self) -> dict:
        """name → (i0, i1) (needs unique non-empty names)."""
        unnamed = self.names.count("")
        if unnamed:
            # unnamed 'start end' lines given to a method that needs names (Ferraris: x_p … z_rot) were told 'not
            # uniquely named', not how to name them (probe)
            raise OptinavError(
                f"{unnamed} of the {len(self.names)} sections have no name",
                "name each section: 'name start end' lines in seconds (--sections), a JSON object name → [start, "
                "end], or imucal's section list",
            )
        twice = sorted({n for n in self.names if self.names.count(n) > 1})
        if twice:
            raise OptinavError(f"the section name(s) {', '.join(twice)} are given twice", "name every section once")
        return {n: (int(a), int(b)) for n, (a, b) in zip(self.names, np.asarray(self.index_ranges, dtype=int))}


# --------------------------------------------------------------------------------------------------------
# moving variance and noise floor
# --------------------------------------------------------------------------------------------------------


#: s, the shortest rest the static detection keeps by default (``--min-duration``): a pose must rest longer
MIN_STATIC_S = 2.0


def _check_t_x(t, x, name: str) -> tuple[np.ndarray, np.ndarray]:
    t = check_timestamps(t, "t", min_count=2)
    x = as_float_array(x, name, last_dims=(3,))
    if x.ndim != 2 or x.shape[0] != t.size:
        raise OptinavError(
            f"{name} has shape {x.shape} but t has {t.size} samples",
            f"pass {name} as an (N, 3) array with one row per timestamp",
        )
    return t, x


#: rows per block of :func:`_moving_variance` (its temporaries are a few blocks, not a few copies of the log)
_BLOCK = 1 << 16


def _moving_variance(t: np.ndarray, x: np.ndarray, window_s: float) -> tuple[np.ndarray, float]:
    """Variance (N,) and its rounding resolution (input units²).

    Computed in blocks of :data:`_BLOCK` rows from running sums that are held only over the rows the block's
    windows reach: each continues from its last value (``cumsum`` adds sequentially), so the result is
    bit-identical to the whole-array computation while the memory beyond the result (8 B per row) is a few
    blocks and a window."""
    n_rows = t.size
    half = 0.5 * window_s
    # a tiny relative slack keeps samples exactly half a window away inside despite rounding of t
    slack = 1e-9 * max(window_s, 1e-300)
    centre = x.mean(axis=0)  # centring limits the cancellation in the cumulative sums of squares
    # c1, c2: the sums of xc and xc² over the rows before row held0 + j, for j = 0 … len − 1
    held0, c1, c2 = 0, np.zeros((1, 3)), np.zeros((1, 3))
    var = np.empty(n_rows)
    n_min = np.inf
    for a in range(0, n_rows, _BLOCK):
        ta = t[a : a + _BLOCK]
        lo = np.searchsorted(t, ta - half - slack, side="left")
        hi = np.searchsorted(t, ta + half + slack, side="right")
        end = held0 + c1.shape[0] - 1
        first = int(lo[0])
        if hi[-1] > end:
            xc = x[end : hi[-1]] - centre
            c1 = np.concatenate([c1[first - held0 : -1], np.cumsum(np.concatenate([c1[-1:], xc]), axis=0)])
            c2 = np.concatenate([c2[first - held0 : -1], np.cumsum(np.concatenate([c2[-1:], xc * xc]), axis=0)])
        else:
            c1, c2 = c1[first - held0 :], c2[first - held0 :]
        held0 = first
        lo -= held0
        hi -= held0
        n = (hi - lo).astype(float)[:, None]
        n_min = min(n_min, float(n.min()))
        mean = (c1[hi] - c1[lo]) / n
        var[a : a + ta.size] = ((c2[hi] - c2[lo]) / n - mean * mean).sum(axis=1)
    # rounding error of a difference of two cumulative sums ≈ eps × (running sum) / (window count)
    resolution = float(8 * _EPS * c2[-1].sum() / max(n_min, 1.0))
    return np.maximum(var, 0.0, out=var), resolution


def moving_variance(t, x, window_s: float) -> np.ndarray:
    """Total moving variance (N,) of the 3 axes of ``x`` (N, 3) over a centred window of ``window_s`` s.

    ``v_i = Σ_axes var{x_k : |t_k − t_i| ≤ window_s/2}`` (population variance, input units²); windows are
    cut at the ends of the log. ``t`` (N,) s, strictly increasing, any spacing.
    """
    t, x = _check_t_x(t, x, "x")
    window_s = check_positive(window_s, "window_s")
    return _moving_variance(t, x, window_s)[0]


def noise_floor(variance, *, resolution: float = 0.0) -> float:
    """Robust at-rest level of a moving-variance series: the mode of log10(variance).

    Histogram of log10 v in 0.05-decade bins smoothed over 5 bins; the densest bin's centre. ``resolution``
    (the rounding level of v) is a lower bound, so noise-free data give a finite floor.
    """
    v = np.asarray(variance, dtype=float).reshape(-1)
    lowest = max(float(resolution), np.finfo(float).tiny)

    def logs(a: int) -> np.ndarray:
        # values at the rounding level count as that level (noise-free or quantized data at rest)
        x = v[a : a + _BLOCK]
        return np.log10(np.maximum(x[np.isfinite(x)], lowest))

    # in blocks (the same numbers as on the whole series): the memory stays a few blocks, not copies of v
    lo, hi = np.inf, -np.inf
    for a in range(0, v.size, _BLOCK):
        lv = logs(a)
        if lv.size:
            lo, hi = min(lo, float(lv.min())), max(hi, float(lv.max()))
    if not np.isfinite(lo):
        return lowest
    if hi - lo < 0.1:
        return float(10.0 ** np.median(np.concatenate([logs(a) for a in range(0, v.size, _BLOCK)])))
    nb = int(np.ceil((hi - lo) / 0.05))
    h = np.zeros(nb, dtype=np.int64)
    for a in range(0, v.size, _BLOCK):
        hb, e = np.histogram(logs(a), bins=nb, range=(lo, hi))
        h += hb
    hs = np.convolve(h, np.ones(5) / 5.0, mode="same")
    k = int(np.argmax(hs))
    return float(max(10.0 ** (0.5 * (e[k] + e[k + 1])), lowest))


# --------------------------------------------------------------------------------------------------------
# intervals
# --------------------------------------------------------------------------------------------------------


def intervals_from_mask(t, mask, *, min_duration_s: float = 0.0, trim_s: float = 0.0) -> np.ndarray:
    """Half-open index ranges (K, 2) of the runs of ``mask``, each trimmed by ``trim_s`` s at both ends and
    kept when its duration (last − first sample time) is at least ``min_duration_s``."""
    t = np.asarray(t, dtype=float)
    m = np.asarray(mask, dtype=bool)
    starts, ends = mask_runs(m).T  # ends exclusive
    if trim_s > 0 and starts.size:
        starts = np.searchsorted(t, t[starts] + trim_s, side="left")
        ends = np.searchsorted(t, t[ends - 1] - trim_s, side="right")
    ok = ends > starts
    starts, ends = starts[ok], ends[ok]
    if starts.size:
        dur = t[ends - 1] - t[starts]
        keep = dur >= min_duration_s - 1e-9 * max(min_duration_s, 1.0)
        starts, ends = starts[keep], ends[keep]
    return np.column_stack([starts, ends]).astype(np.int64).reshape(-1, 2)


def pose_means(x: np.ndarray, ranges) -> np.ndarray:
    """(P, 3) means of ``x`` over the sample ranges [i0, i1) of ``ranges`` (P, 2)."""
    ranges = np.asarray(ranges)
    if ranges.size == 0:
        return np.zeros((0, 3))
    return np.array([x[a:b].mean(axis=0) for a, b in ranges])


def _rank(v: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """Per row, how many of the increasing ``thresholds`` ``v`` exceeds, so ``v <= thresholds[j]`` is
    ``rank <= j``: the same comparisons as on ``v`` in 1 or 2 B per row instead of 8."""
    rank = np.zeros(v.shape, np.uint8 if thresholds.size < 256 else np.uint16)
    for a in range(0, v.size, _BLOCK):
        rank[a : a + _BLOCK] = np.count_nonzero(v[a : a + _BLOCK, None] > thresholds, axis=1)
    return rank


def _detection(t, acc, gyro, va, vg, thr, gthr, window_s, min_duration_s, trim_s, method, mask=None):
    """The detection of thresholds ``thr``/``gthr`` on variances ``va``/``vg``, or of a given ``mask``
    (then ``va``/``vg`` are only stored)."""
    if mask is None:
        mask = va <= thr
        if vg is not None and gthr is not None:
            mask &= vg <= gthr
    ranges = intervals_from_mask(t, mask, min_duration_s=min_duration_s, trim_s=trim_s)
    ti = np.column_stack([t[ranges[:, 0]], t[ranges[:, 1] - 1]]) if ranges.size else np.zeros((0, 2))
    return StaticDetection(
        t_intervals=ti,
        index_ranges=ranges,
        acc_means=pose_means(acc, ranges),
        gyro_means=pose_means(gyro, ranges) if gyro is not None else None,
        counts=(ranges[:, 1] - ranges[:, 0]).astype(np.int64),
        acc_variance=va,
        gyro_variance=vg,
        threshold=float(thr),
        gyro_threshold=None if gthr is None else float(gthr),
        window_s=float(window_s),
        min_duration_s=float(min_duration_s),
        trim_s=float(trim_s),
        method=method,
    )


def _levels(v: np.ndarray, unit: str) -> str:
    return f"moving variance min {np.min(v):.3g}, median {np.median(v):.3g}, max {np.max(v):.3g} {unit}"


def _check_t_acc_gyro(t, acc, gyro):
    t, acc = _check_t_x(t, acc, "acc")
    if gyro is not None:
        gyro = as_float_array(gyro, "gyro", last_dims=(3,))
        if gyro.shape != acc.shape:
            raise OptinavError(
                f"gyro has shape {gyro.shape} but acc has {acc.shape}",
                "pass gyro and acc sampled at the same timestamps",
            )
    return t, acc, gyro


def _prepare(t, acc, gyro, window_s, min_duration_s, trim_s):
    t, acc, gyro = _check_t_acc_gyro(t, acc, gyro)
    window_s = check_positive(window_s, "window_s")
    min_duration_s = float(min_duration_s)
    if not np.isfinite(min_duration_s) or min_duration_s < 0:
        raise OptinavError(f"min_duration_s must be ≥ 0, got {min_duration_s!r}", "pass a duration in s")
    trim_s = 0.5 * window_s if trim_s is None else float(trim_s)
    if not np.isfinite(trim_s) or trim_s < 0:
        raise OptinavError(f"trim_s must be ≥ 0, got {trim_s!r}", "pass a trim in s (default half a window)")
    span = t[-1] - t[0]
    if window_s > 0.5 * span:
        raise OptinavError(
            f"window_s = {window_s:g} s is more than half the log ({span:.6g} s)",
            "use a shorter window (about 1 s) or a longer log",
        )
    return t, acc, gyro, window_s, min_duration_s, trim_s


def threshold_candidates(
    t,
    acc,
    *,
    gyr=None,
    window_s: float = 1.0,
    min_duration_s: float = MIN_STATIC_S,
    trim_s: float | None = None,
    multipliers=None,
    init_rest_s: float | None = None,
    acc_unit: str = "input units",
    gyro_unit: str = "input units",
    keep_variance: bool = True,
) -> ThresholdCandidates:
    """Candidate thresholds ``m × noise floor`` (``multipliers``, default :data:`DEFAULT_MULTIPLIERS`) with
    their detections; see the module docstring for the floor and the default rule.

    ``init_rest_s``: if given, the floor is the total variance of the first ``init_rest_s`` seconds (the log
    must start at rest, as imu_tk assumes). Each candidate's samples are found from the rank of each row's
    variance among the thresholds (:func:`_rank`: the same comparisons in 1 B per row). ``keep_variance=False``:
    the detections hold no moving variances (``acc_variance``/``gyro_variance`` None; the same intervals, in
    2 B per row instead of 16 while they are found). Other arguments as in :func:`detect_static`.
    """
    gyro = gyr
    t, acc, gyro, window_s, min_duration_s, trim_s = _prepare(t, acc, gyro, window_s, min_duration_s, trim_s)
    mult = np.asarray(DEFAULT_MULTIPLIERS if multipliers is None else multipliers, dtype=float).ravel()
    if mult.size == 0 or not np.all(np.isfinite(mult)) or np.any(mult <= 0):
        raise OptinavError("multipliers must be positive finite numbers", "pass e.g. multipliers=[2, 5, 10]")
    mult = np.unique(mult)
    if init_rest_s is not None:
        init_rest_s = check_positive(init_rest_s, "init_rest_s")
        k = int(np.searchsorted(t, t[0] + init_rest_s, side="right"))
        if k < 3 or init_rest_s < window_s:
            raise OptinavError(
                f"init_rest_s = {init_rest_s:g} s covers {k} samples, fewer than a window",
                "pass an initial rest of at least one window (imu_tk uses ~50 s) or leave it None",
            )

    def floor_of(x):
        """The moving variance of ``x`` (None unless kept), its noise floor, its rank among the thresholds."""
        v, res = _moving_variance(t, x, window_s)
        if init_rest_s is not None:
            f = max(float(x[:k].var(axis=0).sum()), res, np.finfo(float).tiny)
        else:
            f = noise_floor(v, resolution=res)
        return (v if keep_variance else None), f, _rank(v, mult * f)

    va, fa, rank_a = floor_of(acc)
    vg, fg, rank_g = floor_of(gyro) if gyro is not None else (None, None, None)

    def detection(j: int) -> StaticDetection:
        mask = rank_a <= j  # v <= mult[j] · floor
        if rank_g is not None:
            mask &= rank_g <= j
        thr, gthr = mult[j] * fa, None if fg is None else mult[j] * fg
        return _detection(t, acc, gyro, va, vg, thr, gthr, window_s, min_duration_s, trim_s, "auto", mask)

    dets = [detection(j) for j in range(mult.size)]
    n = np.array([d.n_intervals for d in dets], dtype=np.int64)
    st = np.array([float(d.durations.sum()) for d in dets])
    if n.max() == 0:
        if va is None:  # the message's levels: the variances again (only on this error)
            va = _moving_variance(t, acc, window_s)[0]
            vg = _moving_variance(t, gyro, window_s)[0] if gyro is not None else None
        what = _levels(va, f"({acc_unit})^2")
        if vg is not None:
            what += "; gyro " + _levels(vg, f"({gyro_unit})^2")
        raise OptinavError(
            f"no static interval of at least {min_duration_s:g} s found with thresholds up to "
            f"{mult.max():g} × the noise floor {fa:.3g} ({acc_unit})^2 ({what})",
            "try a longer window_s, a larger threshold (or multipliers), a shorter min_duration_s, "
            "or give the static sections by hand (--sections)",
        )
    return ThresholdCandidates(
        multipliers=mult,
        noise_floor=fa,
        gyro_noise_floor=fg,
        thresholds=mult * fa,
        gyro_thresholds=None if fg is None else mult * fg,
        n_intervals=n,
        static_time_s=st,
        detections=dets,
        default_index=default_candidate(n),
    )


def default_candidate(n_intervals, stable: int = STABLE_RUN) -> int:
    """Index of the default threshold from the interval counts of increasing candidates.

    The largest count that persists over at least ``stable`` consecutive candidates; the middle candidate
    of its longest run (ties: the first run). Without any run that long: the largest threshold with the
    largest count.
    """
    n = np.asarray(n_intervals, dtype=np.int64).ravel()
    if n.size == 0:
        raise OptinavError("no threshold candidates", "pass at least one multiplier")
    runs = []  # (count, length, start)
    s = 0
    for k in range(1, n.size + 1):
        if k == n.size or n[k] != n[s]:
            runs.append((int(n[s]), k - s, s))
            s = k
    ok = [r for r in runs if r[1] >= stable and r[0] > 0]
    if not ok:
        return int(np.flatnonzero(n == n.max())[-1])
    top = max(r[0] for r in ok)
    cnt, length, start = max((r for r in ok if r[0] == top), key=lambda r: (r[1], -r[2]))
    return int(start + (length - 1) // 2)


def detect_static(
    t,
    acc,
    *,
    gyr=None,
    window_s: float = 1.0,
    threshold: float | None = None,
    gyro_threshold: float | None = None,
    min_duration_s: float = MIN_STATIC_S,
    trim_s: float | None = None,
    multipliers=None,
    init_rest_s: float | None = None,
    acc_unit: str = "input units",
    gyro_unit: str = "input units",
) -> StaticDetection:
    """Static intervals of a log from the moving variance of ``acc`` (and ``gyr``).

    A sample is static when the acc moving variance over a centred ``window_s`` window is ≤ ``threshold`` and,
    with ``gyr``, the gyro variance is ≤ ``gyro_threshold``. Intervals are trimmed by ``trim_s`` at both ends,
    then those shorter than ``min_duration_s`` are dropped.

    Parameters
    ----------
    t : (N,) array
        Sample times [s].
    acc : (N, 3) array
        Accelerometer output [input units].
    gyr : (N, 3) array or None
        Gyroscope output [input units].
    window_s : float
        Moving-variance window [s].
    threshold : float or None
        Acc variance threshold [input units²]; None: automatic (module docstring; the gyro uses the same multiple
        of its own floor).
    gyro_threshold : float or None
        Gyro variance threshold [input units²]; a given ``threshold`` without it uses the acc alone.
    min_duration_s : float
        Shortest interval kept [s].
    trim_s : float or None
        Trim at both ends of an interval [s]; None: ``window_s/2``.
    multipliers : (M,) array or None
        Candidate threshold multiples of the noise floor [-]; None: :data:`DEFAULT_MULTIPLIERS`.
    init_rest_s : float or None
        Take the noise floor from the first ``init_rest_s`` [s] (an initial rest, as imu_tk).
    acc_unit, gyro_unit : str
        Unit names, only for error messages.

    Returns
    -------
    StaticDetection
        ``t_intervals`` [s], ``index_ranges`` and per-interval means [input units].
    """
    gyro = gyr
    if threshold is None:
        if gyro_threshold is not None:
            raise OptinavError(
                "gyro_threshold was given without threshold",
                "give both thresholds, or neither for the automatic choice",
            )
        return threshold_candidates(
            t,
            acc,
            gyr=gyro,
            window_s=window_s,
            min_duration_s=min_duration_s,
            trim_s=trim_s,
            multipliers=multipliers,
            init_rest_s=init_rest_s,
            acc_unit=acc_unit,
            gyro_unit=gyro_unit,
        ).default
    thr = check_positive(threshold, "threshold")
    gthr = None if gyro_threshold is None else check_positive(gyro_threshold, "gyro_threshold")
    t, acc, gyro, window_s, min_duration_s, trim_s = _prepare(t, acc, gyro, window_s, min_duration_s, trim_s)
    va, _ = _moving_variance(t, acc, window_s)
    vg = _moving_variance(t, gyro, window_s)[0] if gyro is not None else None
    det = _detection(t, acc, gyro, va, vg, thr, gthr, window_s, min_duration_s, trim_s, "threshold")
    if det.n_intervals == 0:
        what = _levels(va, f"({acc_unit})^2")
        if vg is not None and gthr is not None:
            what += f"; gyro threshold {gthr:.3g}, " + _levels(vg, f"({gyro_unit})^2")
        raise OptinavError(
            f"no static interval of at least {min_duration_s:g} s with acc threshold {thr:.3g} ({acc_unit})^2 ({what})",
            "try a longer window_s, a larger threshold, a shorter min_duration_s, "
            "or give the static sections by hand (--sections)",
        )
    return det


# --------------------------------------------------------------------------------------------------------
# manual sections
# --------------------------------------------------------------------------------------------------------


def _parse_text(text: str, src: str) -> list:
    rows = []
    for ln, line in enumerate(text.splitlines(), 1):
        s = line.split("#", 1)[0].replace(",", " ").replace(";", " ").strip()
        if not s:
            continue
        parts = s.split()
        try:
            if len(parts) == 2:
                rows.append(("", float(parts[0]), float(parts[1])))
            elif len(parts) == 3:
                rows.append((parts[0], float(parts[1]), float(parts[2])))
            else:
                raise ValueError
        except ValueError:
            raise OptinavError(
                f"{src} line {ln} is not 'start end' or 'name start end' in seconds: {line.strip()!r}",
                "write one section per line, times in seconds",
            ) from None
    return rows


def _load_sections(sections):
    """→ (rows [(name, a, b)], kind 'time'|'index', named)."""
    src = "sections"
    if isinstance(sections, (str, Path)):
        text = str(sections)
        p = Path(text)
        if isinstance(sections, Path) or not (text.lstrip().startswith(("{", "[")) or "\n" in text):
            src, text = str(p), read_text(p, "section file")
        if text.lstrip().startswith(("{", "[")):
            sections = parse_json(text, src, "fix the file or write 'start end' lines in seconds")
        else:
            rows = _parse_text(text, src)
            return rows, "time", any(r[0] for r in rows)
    if isinstance(sections, SectionList):
        return [(n, int(a), int(b)) for n, (a, b) in zip(sections.names, sections.index_ranges)], "index", True
    if (
        isinstance(sections, dict)
        and set(sections) == {"start", "end"}
        and all(isinstance(v, dict) for v in sections.values())
        and set(sections["start"]) == set(sections["end"])
    ):
        # imucal's section list the other way round, {"start": {name: i0}, "end": {name: i1}} (pandas' to_json of
        # the table that pd.read_json(...).T reads it into): it named a section 'start' without keys
        sections = {n: {"start": sections["start"][n], "end": sections["end"][n]} for n in sections["start"]}
    if isinstance(sections, dict):
        rows, kinds = [], set()
        for name, v in sections.items():
            if isinstance(v, dict):
                if "start" not in v or "end" not in v:
                    raise OptinavError(
                        f"section {name!r} has no 'start'/'end' keys",
                        "use {'name': {'start': i0, 'end': i1}} (sample indices)",
                    )
                a, b = v["start"], v["end"]
                if not all(
                    isinstance(q, (int, np.integer)) or (isinstance(q, float) and q.is_integer()) for q in (a, b)
                ):
                    raise OptinavError(
                        f"section {name!r} start/end {a!r}, {b!r} are not sample indices",
                        "imucal section lists hold integer sample indices",
                    )
                rows.append((str(name), int(a), int(b)))
                kinds.add("index")
            else:
                try:
                    a, b = (float(q) for q in v)
                except (TypeError, ValueError):
                    raise OptinavError(
                        f"section {name!r} is {v!r}, not (start, end) in seconds",
                        "give each section as (start_s, end_s)",
                    ) from None
                rows.append((str(name), a, b))
                kinds.add("time")
        if len(kinds) > 1:
            raise OptinavError("the section list mixes sample indices and times", "use one layout for all sections")
        return rows, (kinds.pop() if kinds else "time"), True
    if isinstance(sections, (list, tuple)) and len(sections) == 0:
        return [], "time", False
    try:
        arr = np.asarray(sections, dtype=float)
    except (TypeError, ValueError):
        raise OptinavError("sections is not a list of (start, end) times", "pass [(t0, t1), ...] in seconds") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise OptinavError(f"sections has shape {arr.shape}, expected (K, 2)", "pass [(t0, t1), ...] in seconds")
    return [("", float(a), float(b)) for a, b in arr], "time", False


def sections_from_list(sections, t) -> SectionList:
    """Validated manual sections of the log with timestamps ``t``.

    Checks: start < end, inside the log, at least one sample, no overlap. Unnamed sections must be in time
    order (an unsorted list is usually a typo); named ones are sorted by start. A section in seconds keeps the
    samples with start ≤ t ≤ end.

    Parameters
    ----------
    sections : list, dict or str
        A list of (start, end) times [s]; a dict name → (start, end) [s]; the path of a text file with one
        ``start end`` or ``name start end`` line per section [s] ('#' comments, commas allowed; a string
        containing a newline is taken as such text) or of a JSON file holding any layout here; or imucal's
        section-list layout ``{"name": {"start": i0, "end": i1}}`` whose values are **sample indices** into ``t``
        (half-open [i0, i1), as imucal slices with ``iloc``).
    t : (N,) array
        Sample times [s]; for a log without timestamps pass ``t = arange(N) / rate``.

    Returns
    -------
    SectionList
        ``t_intervals`` [s], ``index_ranges`` and ``names``.
    """
    t = check_timestamps(t, "t", min_count=2)
    rows, kind, named = _load_sections(sections)
    if not rows:
        raise OptinavError("the section list is empty", "give at least one (start, end) section")
    N = t.size
    names, ranges, times = [], [], []
    for k, (name, a, b) in enumerate(rows):
        label = f"section {name!r}" if name else f"section {k + 1}"
        if kind == "index":
            if not (0 <= a < b <= N):
                raise OptinavError(
                    f"{label} sample range [{a}, {b}) is not inside the log of {N} samples or is empty",
                    "give 0 ≤ start < end ≤ number of samples",
                )
            i0, i1 = int(a), int(b)
        else:
            if not (np.isfinite(a) and np.isfinite(b)) or a >= b:
                raise OptinavError(f"{label} has start {a:g} s ≥ end {b:g} s", "give start < end in seconds")
            tol = 1e-9 * max(1.0, abs(t[-1]))
            if a < t[0] - tol or b > t[-1] + tol:
                # [540, 1271] for imucal's x_p were sample indices written as a pair, read as seconds
                rows = float(a).is_integer() and float(b).is_integer() and 0 <= a < b <= N
                raise OptinavError(
                    f"{label} [{a:g}, {b:g}] s is outside the log [{t[0]:g}, {t[-1]:g}] s",
                    "give times in seconds on the log's time axis"
                    + (
                        " (sample indices are written as imucal's list writes them: "
                        + json.dumps({name or "NAME": {"start": int(a), "end": int(b)}})
                        + ")"
                        if rows
                        else ""
                    ),
                )
            i0 = int(np.searchsorted(t, a - tol, side="left"))
            i1 = int(np.searchsorted(t, b + tol, side="right"))
            if i1 <= i0:
                raise OptinavError(f"{label} [{a:g}, {b:g}] s contains no sample", "widen the section")
        names.append(name)
        ranges.append((i0, i1))
        times.append((a, b))
    ranges = np.array(ranges, dtype=np.int64)
    order = np.argsort(ranges[:, 0], kind="stable")
    if not named and np.any(order != np.arange(len(order))):
        k = int(np.flatnonzero(np.diff(ranges[:, 0]) < 0)[0])
        raise OptinavError(
            f"sections are not in time order: section {k + 2} starts before section {k + 1}",
            "sort the sections by start time",
        )
    ranges = ranges[order]
    names = [names[i] for i in order]
    for k in range(1, len(ranges)):
        if ranges[k, 0] < ranges[k - 1, 1]:
            a = names[k - 1] or f"{k}"
            b = names[k] or f"{k + 1}"
            raise OptinavError(
                f"sections {a!r} and {b!r} overlap (t = {t[ranges[k, 0]]:.6g} s .. {t[ranges[k - 1, 1] - 1]:.6g} s)",
                "make the sections disjoint",
            )
    ti = np.column_stack([t[ranges[:, 0]], t[ranges[:, 1] - 1]])
    return SectionList(t_intervals=ti, index_ranges=ranges, names=names)


def detection_from_sections(sections, t, acc, *, gyr=None) -> StaticDetection:
    """A :class:`StaticDetection` (method "manual", no variances) of hand-given static sections, so a
    calibrator treats detected and manual intervals alike. ``sections`` as in :func:`sections_from_list`
    (or a :class:`SectionList`); t (N,) s; acc, gyro (N, 3) input units."""
    gyro = gyr
    t, acc, gyro = _check_t_acc_gyro(t, acc, gyro)
    sl = sections if isinstance(sections, SectionList) else sections_from_list(sections, t)
    r = np.asarray(sl.index_ranges, dtype=np.int64).reshape(-1, 2)
    if r.size and r.max() > t.size:
        raise OptinavError(
            f"the sections reach sample {int(r.max())} but the log has {t.size}", "give sections of this log"
        )
    return StaticDetection(
        t_intervals=np.asarray(sl.t_intervals, dtype=float).reshape(-1, 2),
        index_ranges=r,
        acc_means=pose_means(acc, r),
        gyro_means=pose_means(gyro, r) if gyro is not None else None,
        counts=(r[:, 1] - r[:, 0]).astype(np.int64),
        acc_variance=None,
        gyro_variance=None,
        threshold=None,
        gyro_threshold=None,
        window_s=None,
        min_duration_s=None,
        trim_s=None,
        method="manual",
        names=list(sl.names),
    )
