"""Input checks shared by every module: each failure is a one-line :class:`OptinavError`."""

from __future__ import annotations

import numpy as np

from optinav.errors import OptinavError


def as_float_array(
    x, name: str, *, last_dims: tuple[int, ...] = (), finite: bool = True, row0: int | None = None
) -> np.ndarray:
    """``x`` as a float64 array whose trailing dimensions equal ``last_dims``.

    ``last_dims=(3,)`` accepts a single 3-vector or an (N, 3) array; ``(3, 3)`` a matrix or a stack.

    Parameters
    ----------
    x : array_like
        The input [any unit, unchanged].
    name : str
        Named in error messages.
    last_dims : tuple of int
        Required trailing shape.
    finite : bool
        Refuse NaN/inf.
    row0 : int or None
        The file's row index of ``x[0]`` when ``x`` holds rows of a data file: the message then names the first
        bad data rows (counted from 1) and the remedy is for the file [-].

    Returns
    -------
    ndarray
        The array [unit of x].
    """
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise OptinavError(f"{name} is not numeric ({exc})", "pass an array of numbers") from None
    if last_dims and (a.ndim < len(last_dims) or a.shape[a.ndim - len(last_dims) :] != tuple(last_dims)):
        want = "(..., " + ", ".join(map(str, last_dims)) + ")"
        raise OptinavError(f"{name} has shape {a.shape}, expected {want}", "check the array's layout")
    if finite and a.size and not np.all(np.isfinite(a)):
        bad = int(np.count_nonzero(~np.isfinite(a)))
        if row0 is None or a.ndim == 0:
            raise OptinavError(
                f"{name} contains {bad} NaN or infinite value(s)",
                "remove or interpolate the bad samples before calling",
            )
        rows = np.flatnonzero(~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)) + row0 + 1
        first = ", ".join(str(r) for r in rows[:3]) + (", ..." if rows.size > 3 else "")
        raise OptinavError(
            f"{name} holds NaN/inf in {rows.size} row(s) (data row{'s' if rows.size > 1 else ''} {first}, counted "
            "from 1)",
            "remove those rows or fill in their values",
        )
    return a


#: samples per block of :func:`check_timestamps`' step checks
_STEP_BLOCK = 1 << 20


#: (bits, unit s, name) of the time counters loggers write, for naming a wrap
_COUNTERS = tuple((b, u, n) for b in (16, 32) for u, n in ((1e-6, "µs"), (1e-3, "ms"), (1e-9, "ns"), (1.0, "s")))


def _backwards(t: np.ndarray, i: int) -> tuple[str, str]:
    """(what the step back from ``t[i]`` to ``t[i + 1]`` looks like, the remedy): a counter wrapping, a jump back
    of many steps (a restart), or samples out of order."""
    near = np.diff(t[max(i - 64, 0) : i + 66])
    step = float(np.median(near[near > 0])) if np.any(near > 0) else 0.0
    back = float(t[i] - t[i + 1])
    if step > 0 and back > 100 * step:
        for bits, unit, uname in _COUNTERS:
            period = 2.0**bits * unit
            if abs(back + step - period) <= max(2 * step, 1e-9 * period):
                return (
                    f" (a {bits}-bit {uname} counter wrapping every {period:.6g} s)",
                    f"unwrap the time (add 2^{bits} {uname} after each wrap), or skip the time column ('_' in columns) "
                    "and give the rate",
                )
        return (
            f" (a jump back by {back:.6g} s, {back / step:.3g} steps: a second recording or a clock reset)",
            "cut the log at that sample and read each part alone",
        )
    # rows written twice (a logger's buffer): the stamps after the step repeat earlier ones, which sorting would
    # only make duplicates of ('sort the samples by time' for 10 repeated rows of imucal's session)
    k = int(np.searchsorted(t[: i + 1], t[i + 1]))
    n = 0
    while i + 1 + n < t.size and k + n <= i and t[k + n] == t[i + 1 + n]:
        n += 1
    if n >= 2:
        return (
            f": the {n} rows from there repeat the stamps from {t[k]:.6g} s (rows written twice)",
            "drop the repeated rows",
        )
    return "", "sort the samples by time"


#: the remedy of a duplicate timestamp when the caller names none (no option of any command: callers whose
#: command can skip the time column or take a rate say so, :data:`optinav.io.imu.COARSE_TIME_REMEDY`)
DUPLICATE_REMEDY = "drop the duplicated samples (each row needs its own time stamp)"


def check_timestamps(
    t,
    name: str = "time",
    *,
    min_count: int = 2,
    max_gap_factor: float | None = None,
    index0: int = 0,
    duplicate_remedy: str = DUPLICATE_REMEDY,
) -> np.ndarray:
    """Validate a 1-D timestamp vector: finite, strictly increasing, optionally without gaps.

    Parameters
    ----------
    t : (N,) array
        Timestamps [s].
    name : str
        Named in error messages.
    min_count : int
        Fewest samples.
    max_gap_factor : float or None
        A step larger than this multiple of the median step is reported as a gap [-].
    index0 : int
        Index of ``t[0]`` in the whole log (a block of a streamed log), for the indices in messages.
    duplicate_remedy : str
        What to do about a duplicate timestamp, in the terms of the caller's command (the options it has).

    Returns
    -------
    (N,) ndarray
        ``t`` as float64 [s].
    """
    t = as_float_array(t, name, finite=False)
    # the usual log told in one comparison per step (a third of the time of the checks that name a fault)
    if not (t.ndim == 1 and t.size >= max(min_count, 1) and _increasing(t)):
        _timestamp_fault(t, name, min_count, index0, duplicate_remedy)
    if max_gap_factor is not None and t.size > 1:
        dt = np.diff(t)
        med = float(np.median(dt))
        big = dt > max_gap_factor * med
        if np.any(big):
            i = int(np.flatnonzero(big)[0])
            raise OptinavError(
                f"{name} has a gap of {dt[i]:.6g} s after t = {t[i]:.6g} s (median step {med:.6g} s)",
                "split the log at the gap or fill it",
            )
    return t


def _increasing(t: np.ndarray) -> bool:
    """Every step of the 1-D float64 ``t`` positive and its ends finite, hence every stamp finite (a NaN fails the
    comparison; an inf can only be an end); a block at a time (a whole-log comparison would be 1 B per sample
    more)."""
    if not (np.isfinite(t[0]) and np.isfinite(t[-1])):
        return False
    for a in range(0, t.size - 1, _STEP_BLOCK):
        seg = t[a : a + _STEP_BLOCK + 1]
        if not np.all(seg[1:] > seg[:-1]):
            return False
    return True


def _timestamp_fault(t: np.ndarray, name: str, min_count: int, index0: int, duplicate_remedy: str) -> None:
    """Raise the first fault of timestamps ``t`` that :func:`_increasing` refused (the caller's checks in order:
    finite, 1-D, enough samples, no duplicate, no step back)."""
    t = as_float_array(t, name)
    if t.ndim != 1:
        raise OptinavError(f"{name} must be one-dimensional, got shape {t.shape}", "pass one timestamp per sample")
    if t.size < min_count:
        raise OptinavError(f"{name} has {t.size} sample(s), at least {min_count} are needed", "record a longer log")
    # the steps a block at a time: a whole-log diff and its masks would be 10 B per sample
    for a in range(0, t.size - 1, _STEP_BLOCK):
        dt = np.diff(t[a : a + _STEP_BLOCK + 1])
        if np.any(dt == 0):
            i = a + int(np.flatnonzero(dt == 0)[0])
            raise OptinavError(
                f"{name} has a duplicate timestamp at index {index0 + i + 1} (t = {t[i + 1]:.6g} s)",
                duplicate_remedy,
            )
        if np.any(dt < 0):
            i = a + int(np.flatnonzero(dt < 0)[0])
            why, hint = _backwards(t, i)
            raise OptinavError(
                f"{name} is not sorted: t[{index0 + i + 1}] = {t[i + 1]:.6g} s < t[{index0 + i}] = {t[i]:.6g} s{why}",
                hint,
            )


def integration_steps(t, t_next: float | None = None) -> np.ndarray:
    """Steps for integrating samples at times ``t``: the forward steps t[k+1] − t[k]; the last sample's the step
    to ``t_next`` unless that is longer than 5 median steps (a jump: a log cut to sections joined end to end),
    else the median step.

    A stretch sampled uniformly whose stamps are rounded to a coarse tick q (1 ms at 102.4 Hz: steps of 9 and
    10 ms) gets its uniform step: its steps take two values q apart and the stamps lie within a band of width q
    about a straight line (the rounding's ±q/2 about the true one), whose slope is the step. The rounding would
    otherwise pair each rate with a step off by up to a tick — on a jerky hand turn (33 °/s between samples) 0.3°
    of 360, five times the std.

    Parameters
    ----------
    t : (N,) array
        Sample times [s], increasing.
    t_next : float or None
        Time of the row after the stretch [s], None at the end of the log.

    Returns
    -------
    (N,) ndarray
        The step of each sample [s].
    """
    t = np.asarray(t, float)
    if t.size < 2:
        return np.zeros(t.size)
    step = np.diff(t)
    med = float(np.median(step))
    lo, hi = float(step.min()), float(step.max())
    q = hi - lo
    eps = 1e-6 * med  # the stamps' float rounding
    if t.size > 2 and 0.01 * med <= q < med and np.all((step - lo <= eps) | (hi - step <= eps)):
        from scipy.optimize import minimize_scalar

        k = np.arange(t.size, dtype=float)
        x = t - t[0]

        def spread(h):  # convex in h: the stamps' spread about the line of slope h
            r = x - k * h
            return float(r.max() - r.min())

        best = minimize_scalar(spread, bounds=(lo, hi), method="bounded", options={"xatol": 1e-9 * med})
        # the spread is V-shaped in h and the bounded search stops a little off its corner, where the spread grows
        # by (n − 1)·|Δh|: stamps exactly half a tick off the line (128 Hz to 1 ms from t = 0) have a spread of q
        # exactly, and 204 of them missed a tolerance of 1e-6·q by 8e-9 s. A real jitter's walk off any line
        # spreads far beyond q, so 1 % of q decides alike
        if best.fun <= q * 1.01 + eps:
            return np.full(t.size, float(best.x))
    last = med if t_next is None or not 0.0 < t_next - t[-1] <= 5.0 * med else float(t_next - t[-1])
    return np.append(step, last)


def as_rng(rng) -> np.random.Generator:
    """A ``numpy.random.Generator`` from a Generator, an int seed, a SeedSequence or None (fresh entropy).

    Parameters
    ----------
    rng : Generator, int, SeedSequence or None
        The source.

    Returns
    -------
    numpy.random.Generator
        The generator.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError):
        raise OptinavError(
            f"rng must be a numpy Generator or an int seed, got {type(rng).__name__}",
            "pass e.g. rng=np.random.default_rng(1)",
        ) from None


def check_positive(value, name: str) -> float:
    """A finite, strictly positive scalar.

    Parameters
    ----------
    value : float
        The value [any unit, unchanged].
    name : str
        Named in the error message.

    Returns
    -------
    float
        ``value`` [unit of value].
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not np.isfinite(v) or v <= 0:
        raise OptinavError(f"{name} must be a positive finite number, got {value!r}", f"pass a valid {name}")
    return v


def mask_runs(mask) -> np.ndarray:
    """The runs of True in a 1-D mask, as half-open index ranges.

    Parameters
    ----------
    mask : (N,) array_like of bool
        The mask [-].

    Returns
    -------
    ndarray
        (K, 2) int [start, end) [-] of each maximal run of True, in order.
    """
    m = np.asarray(mask, dtype=bool)
    zero = np.zeros(1, np.int8)  # int8 edges: a Python 0 would promote the padded copy to int64
    return np.flatnonzero(np.diff(np.concatenate([zero, m.view(np.int8), zero]))).reshape(-1, 2)
