"""Processing chain of a rotational-INS recording: checks → alignment → strapdown → ``C_s^n(t)``.

Alignment on the initial rest (both encoders still, at most ``align_s`` s): analytic coarse alignment then the
Kalman fine alignment of :mod:`optinav.core.alignment`. Strapdown: :class:`optinav.core.strapdown.AttitudeStream`
with the Earth rate as the navigation-frame rate (static base: ``ω_in^n = ω_ie^n``, no transport rate),
"previous"-sample coning correction. ``C_s^n`` is computed once; calibrations only re-evaluate the gimbal chain.

Block by block, in two passes over the recording (:func:`optinav.rins.io.rins_source`: a file read again, or a
:class:`~optinav.rins.simulate.RinsData` sliced): :func:`survey` (the checks, the initial rest, the alignment),
then :func:`strapdown_blocks` (the attitude carried across blocks: any block length gives the whole-log numbers).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from optinav.core import earth as _earth
from optinav.core.alignment import coarse_alignment, fine_alignment
from optinav.core.progress import progress_blocks
from optinav.core.rotations import dcm_from_quat, quat_from_dcm
from optinav.core.strapdown import AttitudeStream
from optinav.core.units import G_STANDARD
from optinav.core.validate import as_float_array, check_timestamps
from optinav.errors import OptinavError
from optinav.rins.io import RinsFile, rins_source

__all__ = [
    "SensorAttitude",
    "Alignment",
    "NavBlock",
    "check_data",
    "survey",
    "strapdown_blocks",
    "sensor_attitude_from_imu",
    "motion_mask",
]

#: an encoder step above this (rad) between samples counts as motion
MOTION_STEP = np.radians(0.01)

#: a duplicate time stamp in a recording: rins reads its steps from the t column (no rate option)
DUPLICATE_REMEDY = (
    "drop the duplicated rows: each row's t (s) starts its own increment interval, and the integration takes "
    "its steps from the t column"
)


@dataclasses.dataclass
class SensorAttitude:
    """IMU attitude ``c_s_n`` (M, 3, 3) at epochs ``t`` (M,) with the encoder angles there (rad).

    ``index``: the data rows of the epochs; epoch 0 is the end of the alignment (the navigation start).
    """

    t: np.ndarray
    c_s_n: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    index: np.ndarray
    align_end: float
    align_std: np.ndarray


def motion_mask(angle, step: float = MOTION_STEP, prev: float | None = None) -> np.ndarray:
    """Rows where an encoder angle changed by more than ``step`` rad since the previous row; ``prev``: the angle
    before the first row (the previous block's last; None: the first row counts as still)."""
    a = np.asarray(angle, float)
    return np.abs(np.diff(a, prepend=a[0] if prev is None else prev)) > step


def _check_block(b, prev_t) -> np.ndarray:
    """The bad-input checks of one block: timestamps (with the previous block's last, ``prev_t``, so an
    unsorted pair across the boundary is seen), finite increments and encoder angles; returns t (float)."""
    t = as_float_array(b.t, "time", row0=b.row0)
    if t.ndim != 1:
        raise OptinavError(f"time must be one-dimensional, got shape {t.shape}", "pass one timestamp per sample")
    tt = t if prev_t is None else np.concatenate([[prev_t], t])
    check_timestamps(tt, "time", min_count=1, index0=b.row0 - (tt.size - t.size), duplicate_remedy=DUPLICATE_REMEDY)
    as_float_array(b.dtheta, "dtheta (gyro increments)", last_dims=(3,), row0=b.row0)
    as_float_array(b.dv, "dv (accelerometer increments)", last_dims=(3,), row0=b.row0)
    for name, a in (("alpha (inner encoder)", b.alpha), ("beta (outer encoder)", b.beta)):
        as_float_array(a, name, row0=b.row0)
    return t


class _Checks:
    """The bad-input checks of issue 4, item 8 accumulated block by block (:meth:`feed`, then :meth:`finish`):
    time stamps, gaps (the largest step against the median, so the steps are kept: 8 B per row, the median
    must be exact), and encoders sampled slower than the IMU (8 rows of overlap carried across blocks)."""

    def __init__(self):
        self.n, self.prev_t, self.dt = 0, None, []
        self.gap = (-np.inf, 0.0)  # the largest step [s] (the first of equals) and the epoch it starts at
        self.enc = {name: [np.empty(0), 0, 0] for name in ENCODERS}  # last 8 angles, moving rows, held of them
        # per encoder: the largest |angle| (rad as read), the first step beyond π (row, step), the first rows
        # (for the sample-to-sample noise): what tells an encoder in degrees, wrapped or noisy
        self.amax = dict.fromkeys(ENCODERS, 0.0)
        self.jump: dict = dict.fromkeys(ENCODERS)
        self.head = {name: [] for name in ENCODERS}
        # the turning every TURN_ROWS rows: of each encoder (|angle change|) and of the gyros (|summed
        # increments|), summed over the recording; their ratio is 57.3 for encoders in degrees whatever the noise
        self.turn = dict.fromkeys(ENCODERS, 0.0)
        self.turn_gyro, self.at = 0.0, None  # the gyro sum, (encoder angles, summed increments) at the last node
        self.cum = np.zeros(3)

    def feed(self, b) -> np.ndarray:
        t = _check_block(b, self.prev_t)
        tt = t if self.prev_t is None else np.concatenate([[self.prev_t], t])
        dt = np.diff(tt)
        if dt.size:
            self.dt.append(dt)
            k = int(np.argmax(dt))
            if dt[k] > self.gap[0]:
                self.gap = (float(dt[k]), float(tt[k]))
        for name, a in zip(ENCODERS, (b.alpha, b.beta)):
            st = self.enc[name]
            self._encoder_stats(name, b.row0, np.asarray(a, float), st[0])
            a = np.concatenate([st[0], np.asarray(a, float)])
            # fast part of the moves: the angle changes by > 8 motion steps over ±4 samples
            inside = np.flatnonzero(np.abs(a[8:] - a[:-8]) > 8 * MOTION_STEP) + 4
            st[1] += inside.size
            st[2] += int(np.count_nonzero(a[inside + 1] == a[inside]))
            st[0] = a[-8:]
        self._turning(b)
        self.n += t.size
        self.prev_t = float(t[-1]) if t.size else self.prev_t
        return t

    def _encoder_stats(self, name: str, row0: int, a: np.ndarray, before: np.ndarray) -> None:
        if not a.size:
            return
        self.amax[name] = max(self.amax[name], float(np.nanmax(np.abs(a))))
        if self.jump[name] is None:
            d = np.diff(np.concatenate([before[-1:], a]))
            big = np.flatnonzero(np.abs(d) > np.pi)
            if big.size:
                k = int(big[0])
                self.jump[name] = (row0 + k - (1 if before.size else 0), float(d[k]))
        kept = sum(map(len, self.head[name]))
        if kept < HEAD_ROWS:
            self.head[name].append(a[: HEAD_ROWS - kept])

    def _turning(self, b) -> None:
        k = np.flatnonzero((b.row0 + np.arange(len(b.t))) % TURN_ROWS == 0)
        if not k.size:
            self.cum = self.cum + np.asarray(b.dtheta, float).sum(0)
            return
        cum = self.cum + np.concatenate([np.zeros((1, 3)), np.cumsum(np.asarray(b.dtheta, float), 0)])
        nodes = np.column_stack([np.asarray(b.alpha, float)[k], np.asarray(b.beta, float)[k]])
        g = cum[k]
        if self.at is not None:
            nodes, g = np.vstack([self.at[0], nodes]), np.vstack([self.at[1], g])
        d = np.abs(np.diff(nodes, axis=0))
        for j, name in enumerate(ENCODERS):
            self.turn[name] += float(np.nansum(d[:, j]))
        self.turn_gyro += float(np.linalg.norm(np.diff(g, axis=0), axis=1).sum())
        self.at = (nodes[-1], g[-1])
        self.cum = cum[-1]

    def encoder_trouble(self) -> tuple[str, str] | None:
        """(cause, remedy) when an encoder column is not in rad, wraps, or is noisier than the motion step (what
        makes the rest look shorter than a sample or two), else None."""
        return self.wrap_trouble() or self._unit_or_noise_trouble()

    def wrap_trouble(self) -> tuple[str, str] | None:
        """(cause, remedy) when an encoder column jumps by a full turn between samples (wrapped), else None."""
        for name in ENCODERS:
            j = self.jump[name]
            if j is not None and abs(abs(j[1]) - 360.0) < 5.0:
                return (
                    f"{name} jumps by {j[1]:.6g} at row {j[0] + 1}: it is in degrees wrapped to 360",
                    "write the encoder columns in rad, unwrapped (or declare '# units: alpha=deg beta=deg' in a "
                    "text file and unwrap them)",
                )
            if j is not None and abs(abs(j[1]) - 2 * np.pi) < 0.1:
                return (
                    f"{name} jumps by {j[1]:.4g} rad at row {j[0] + 1}, a wrap of 2π (the angle kept in [0, 2π) "
                    "or (−π, π]): the gimbals cannot turn a full turn in one sample",
                    "unwrap the encoder columns (numpy.unwrap) before calibrating",
                )
        return None

    def _unit_or_noise_trouble(self) -> tuple[str, str] | None:
        enc = sum(self.turn.values())
        if self.turn_gyro > 0.5 and 20.0 < enc / self.turn_gyro < 120.0:
            return (
                f"the encoders turn {enc / self.turn_gyro:.3g}× the angle the gyros turn (the encoders read up to "
                f"{max(self.amax.values()):.4g}): they are in degrees, not rad",
                "write the encoder columns in rad (or declare '# units: alpha=deg beta=deg' in a text file)",
            )
        for name in ENCODERS:
            a = np.concatenate(self.head[name]) if self.head[name] else np.empty(0)
            if a.size > 20:
                # white noise σ gives second differences of σ√6; a smooth gimbal move almost none
                sd = 1.4826 * float(np.median(np.abs(np.diff(a, 2)))) / np.sqrt(6)
                if 3 * np.sqrt(2) * sd > MOTION_STEP:
                    return (
                        f"{name} has {np.degrees(sd) * 3600:.3g}″ rms noise from sample to sample, "
                        f"above the {np.degrees(MOTION_STEP) * 3600:.3g}″ step that counts as gimbal motion",
                        "low-pass or average the encoder angles below that step (or check that they are in rad)",
                    )
        return None

    def finish(self) -> np.ndarray:
        """Raise what the whole recording shows; returns the sample steps (s)."""
        if self.n < 10:
            raise OptinavError(f"time has {self.n} sample(s), at least 10 are needed", "record a longer log")
        dt = np.concatenate(self.dt)
        self.dt = []
        med = float(np.median(dt))
        if self.gap[0] > 1.5 * med:
            raise OptinavError(
                f"gap of {self.gap[0]:.4g} s at t = {self.gap[1]:.6g} s (nominal step {med:.4g} s)",
                "pass an uninterrupted recording (increments over a gap are not defined)",
            )
        for name, (_, moving, held) in self.enc.items():
            if moving > 20 and held / moving > 0.3:
                raise OptinavError(
                    f"{name} holds its value on {held / moving:.0%} of the samples while it turns: it is "
                    f"sampled slower than the IMU ({1.0 / med:.4g} Hz)",
                    "interpolate the encoder angles to the IMU epochs (sample-rate mismatch)",
                )
        return dt


ENCODERS = ("alpha (inner encoder)", "beta (outer encoder)")

#: first rows of each encoder kept for its noise (:meth:`_Checks.encoder_trouble`)
HEAD_ROWS = 2000
#: rows between the samples of the encoder and gyro turning compared (:meth:`_Checks.encoder_trouble`)
TURN_ROWS = 100


def check_data(data) -> None:
    """Bad-input checks of issue 4, item 8 (one-line OptinavErrors; see docs/methods/rins.md) of a
    :class:`~optinav.rins.simulate.RinsData` or any block source (:func:`optinav.rins.io.rins_source`)."""
    checks = _Checks()
    for b in rins_source(data):
        checks.feed(b)
    checks.finish()


#: gyro bias (rad/s, 0.01 °/h) a navigation-grade unit may carry: it tilts the measured latitude by up to its ratio
#: to the Earth rate (0.04°), which the gyro noise's σ does not include; the "rlg-nav" preset draws 0.005 °/h
NAV_GYRO_BIAS = np.radians(0.01) / 3600
#: declared latitudes this many 1σ (noise and :data:`NAV_GYRO_BIAS`) and :data:`LAT_HINT_DEG` from the measured one
#: are refused before the fit; nearer ones after it, where they would move the result by more than its std
#: (``calibrate``), once the gimbal moves have named a gyro column flipped or swapped (which tilts the measured
#: latitude too: 0.6° for a flipped x or y gyro)
LAT_TOL_SIGMA = 5.0
#: how near (deg) the declared value negated or read as radians must come to the measured one for the message to
#: name that mistake (a flipped z axis measured −29.2° at 28.2°: the sensor's own tilt adds to the sign)
LAT_HINT_DEG = 2.0


def measured_latitude(dth, dv, span: float) -> tuple[float, float]:
    """Latitude (rad) from the Earth rate the gyros see at rest: the angle between the mean rate and the
    horizontal plane, up from the mean specific force; and its 1σ (rad) from the gyro noise (first differences of
    the increments, so the constant Earth rate drops out). ``dth`` (rad), ``dv`` (m/s) over ``span`` seconds."""
    w = dth.sum(0) / span
    up = dv.sum(0) / np.linalg.norm(dv.sum(0))
    w_up = float(w @ up)
    w_h = float(np.linalg.norm(w - w_up * up))
    noise = np.std(np.diff(dth, axis=0), axis=0).max() / np.sqrt(2) * np.sqrt(len(dth)) / span
    return float(np.arctan2(w_up, w_h)), float(noise / _earth.WGS84.omega_ie)


def latitude_sigma(sd: float) -> float:
    """1σ (rad) of the measured latitude: the gyro noise's ``sd`` (rad) and the tilt of :data:`NAV_GYRO_BIAS`."""
    return float(np.hypot(sd, NAV_GYRO_BIAS / _earth.WGS84.omega_ie))


def latitude_check(dth, dv, span: float, lat: float) -> tuple[float, float]:
    """The declared latitude ``lat`` (rad) must agree with the one the gyros measure at rest (a wrong latitude
    misplaces the Earth rate removed by the strapdown and every angle comes out wrong); returns the measured
    latitude and its 1σ from the gyro noise (rad, :func:`measured_latitude`)."""
    if not -np.pi / 2 <= lat <= np.pi / 2:
        raise OptinavError(f"latitude {np.degrees(lat):.6g}° is outside [-90°, 90°]", "pass --lat DEG (north +)")
    f = float(np.linalg.norm(dv.sum(0))) / span / _earth.WGS84.g_e
    meas, sd = measured_latitude(dth, dv, span)
    w = float(np.linalg.norm(dth.sum(0) / span))
    ratio = w / _earth.WGS84.omega_ie
    step = span / max(len(dth), 1)
    if not 0.8 < f < 1.25:
        if sd < 0.1 and 0.5 < ratio < 2.0:
            # the gyros read the Earth rate over the same span: the time base is right, the dv columns are not
            g = _earth.WGS84.g_e / G_STANDARD
            why = next(
                (
                    why
                    for x, why in ((1 / G_STANDARD, "in g·s"), (1e-3 / G_STANDARD, "in mg·s"), (1 / step, "rates"))
                    if abs(f * g / x - 1) < 0.05
                ),
                None,
            )
            hint = {
                "in g·s": "the dv columns are in g·s, not m/s",
                "in mg·s": "the dv columns are in mg·s, not m/s",
                "rates": f"the dv columns hold specific forces in m/s² (×{1 / step:.3g}), not increments",
            }.get(why, "the dv columns are not velocity increments in m/s")
            raise OptinavError(
                f"the accelerometer increments give a specific force of {f:.3g} g at rest while the gyros read the "
                f"Earth rate ({ratio:.3g}×) over the same {span:.6g} s: {hint}",
                "write dv_x, dv_y, dv_z as velocity increments in m/s over each sample step",
            )
        # gyro and accelerometer increments both divided by the span: a wrong time base scales both alike, a
        # wrong gyro unit the gyro alone (a t column in ms was blamed on the gyro increments, 2× on --lat)
        raise OptinavError(
            f"the accelerometer increments give a specific force of {f:.3g} g at rest over the time column's "
            f"{span:.6g} s: the time column is off by that factor (not in seconds, or another rate)",
            "write the t column in seconds on the samples' own clock",
        )
    rates = np.linalg.norm(dth, axis=1) / step
    k = int(np.argmax(rates)) if rates.size else 0
    if rates.size and rates[k] > 100 * max(float(np.median(rates)), _earth.WGS84.omega_ie):
        # a turn inside the rest, not a unit (that scales every sample alike): an encoder that did not follow it
        raise OptinavError(
            f"the gyros turn at {np.degrees(rates[k]):.3g} °/s at row {k + 1} of the initial rest (the rows before "
            "the first encoder move) while both encoders report rest: an encoder channel is frozen or missing",
            "check the alpha/beta columns (and that they belong to this IMU recording)",
        )
    if sd < 0.1 and not 0.5 < ratio < 2.0:  # a navigation-grade gyro at rest reads the Earth rate, nothing else
        raise OptinavError(
            f"the gyros measure {w:.3g} rad/s at rest, {ratio:.3g}× the Earth rate ({_earth.WGS84.omega_ie:.3g} "
            f"rad/s): the gyro increments are not in rad (degrees read ×57.3; rates in rad/s instead of "
            f"increments ×{1 / step:.3g})",
            "write the gyro columns as angle increments in rad over each sample step",
        )
    dph = np.degrees(_earth.WGS84.omega_ie) * 3600  # the Earth rate, °/h
    if sd < 0.01 and abs(ratio - 1) > max(0.05, 5 * sd):  # any latitude gives the Earth rate's full magnitude
        raise OptinavError(
            f"the gyros measure {ratio:.3g}× the Earth rate's magnitude at rest, which no latitude gives (a "
            f"latitude only tilts it): a gyro bias of about {abs(ratio - 1) * dph:.2g} °/h, or a gyro scale error",
            "check the gyro columns (bias, scale, units); the fit assumes a gyro bias far below the Earth rate",
        )
    tol = max(LAT_TOL_SIGMA * latitude_sigma(sd), np.radians(LAT_HINT_DEG))
    if sd < np.radians(10) and abs(meas - lat) > tol:
        d = abs(meas - lat)

        neg = abs(meas + lat) < tol
        if abs(meas - np.degrees(lat)) < tol:  # the latitude in radians read as degrees
            raise OptinavError(
                f"the latitude {np.degrees(lat):.4g}° disagrees with the {np.degrees(meas):.4g}° ± "
                f"{np.degrees(sd):.2g}° the gyros measure from the Earth rate at rest, and {np.degrees(lat):.4g} rad "
                f"is {np.degrees(np.degrees(lat)):.4g}°: the latitude was given in radians",
                f"give --lat (or the file's lat_deg) in degrees: {np.degrees(np.degrees(lat)):.6g}",
            )
        raise OptinavError(
            f"the latitude {np.degrees(lat):.4g}° disagrees with the {np.degrees(meas):.5g}° ± "
            f"{np.degrees(latitude_sigma(sd)):.2g}° (1σ: gyro noise and a {np.degrees(NAV_GYRO_BIAS) * 3600:g} °/h "
            "bias) the gyros measure from the Earth rate at rest (its angle above the plane the accelerometers "
            "level)" + (": about the declared one negated" if neg else ""),
            "check --lat (north positive) or the file's lat_deg; if it is right, the sensors disagree: "
            + (
                "a z gyro's or z accelerometer's sign flipped (check the columns' signs)"
                if neg
                else f"a gyro or accelerometer axis flipped or swapped, or a bias of about {d * dph:.2g} °/h on a "
                f"gyro or {np.sin(d):.2g} g on a horizontal accelerometer (check the columns' order, signs and biases)"
            ),
        )
    return meas, sd


def _blocks(src, desc: str):
    """The blocks of ``src``, behind a progress bar of the bytes read for a file (the CLI's; none for arrays)."""
    return progress_blocks(src, desc) if isinstance(src, RinsFile) else iter(src)


@dataclasses.dataclass
class Alignment:
    """The start of the strapdown found by the first pass (:func:`survey`): data row ``m`` (epoch ``t_m`` [s], the
    last with both encoders still, capped by ``align_s``), ``q0`` the aligned ``q_s^n`` there (ENU), ``std`` its
    1σ (rad), ``n`` rows in all, ``step``/``step_nav`` the median sample step of the whole recording / of the
    strapdown epochs (rows m..n−1) [s], ``rest_sd`` the per-sample gyro noise of the rest (rad, first differences
    of the increments over √2; 0 under 3 rows), ``lat`` [rad], ``height_m`` [m]; ``lat_measured`` the latitude
    the gyros measure at rest and its 1σ from their noise ``lat_measured_sd`` [rad] (NaN: not measured)."""

    m: int
    t_m: float
    q0: np.ndarray
    std: np.ndarray
    n: int
    step: float
    step_nav: float
    rest_sd: float
    lat: float
    height_m: float
    lat_measured: float = float("nan")
    lat_measured_sd: float = float("nan")


#: most rows of the initial rest kept for the alignment (56 B each: 235 MB); a longer rest needs ``align_s``
MAX_REST_ROWS = 1 << 22


def survey(data, *, align_s: float | None = None, fine: bool = True, desc: str = "check") -> Alignment:
    """First pass over a recording: the bad-input checks, the initial rest (rows kept until the first gimbal
    move or ``align_s`` [s]), the latitude check and the alignment on that rest.

    Parameters
    ----------
    data : RinsData, path or block source
        The recording (:func:`optinav.rins.io.rins_source`).
    align_s : float or None
        Longest alignment window [s]; None: the whole initial rest.
    fine : bool
        Kalman fine alignment after the analytic coarse one.
    desc : str
        Label of the progress bar (files).

    Returns
    -------
    Alignment
        Where and how the strapdown starts.
    """
    src = rins_source(data)
    checks = _Checks()
    rest: dict = {"t": [], "dtheta": [], "dv": []}
    k_a, t0, prev = None, None, None  # rows of the rest once known; first epoch; last encoder angles
    kept, overflow = 0, False  # rest rows kept; more than MAX_REST_ROWS (no longer kept)
    for b in _blocks(src, desc):
        t = checks.feed(b)
        if k_a is not None or not t.size:
            continue
        a, bb = np.asarray(b.alpha, float), np.asarray(b.beta, float)
        if prev is None:
            t0, prev = float(t[0]), (a[0], bb[0])
        moving = motion_mask(a, prev=prev[0]) | motion_mask(bb, prev=prev[1])
        prev = (a[-1], bb[-1])
        stop = moving.copy()
        if align_s is not None:
            stop |= t >= t0 + align_s
        end = int(np.argmax(stop)) if stop.any() else t.size
        if kept + end > MAX_REST_ROWS and not overflow:
            overflow, rest = True, {c: [] for c in rest}  # a rest this long ends in an error: keep none of it
        if not overflow:
            for c in rest:
                rest[c].append(np.asarray(getattr(b, c), float)[:end])
            kept += end
        if end < t.size:
            k_a = b.row0 + end
    dt = checks.finish()
    n = checks.n
    k_a = n if k_a is None else k_a
    step = float(np.median(dt))
    if k_a * step < 10.0:
        # an encoder in degrees (57× its noise), wrapped at 2π or noisy looks as if it moved at once
        trouble = checks.encoder_trouble()
        if trouble is not None:
            raise OptinavError(
                f"only {k_a * step:.3g} s of rest before the first gimbal move: {trouble[0]}", trouble[1]
            )
        raise OptinavError(
            f"only {k_a * step:.3g} s of rest before the first gimbal move",
            "record at least 60 s (the paper: 600 s) static with both gimbals still first",
        )
    # wrapped to (−π, π] the encoders start at rest and jump only within a move: the rest looks fine and the move
    # check blamed the gyro columns for a "−360°" move
    wrap = checks.wrap_trouble()
    if wrap is not None:
        raise OptinavError(*wrap)
    if k_a >= n - 2:
        raise OptinavError(
            "the gimbals never move after the alignment (no gimbal motion)",
            "nothing can be calibrated: record a rotation scheme turning both axes",
        )
    if overflow:
        raise OptinavError(
            f"the initial rest lasts {k_a * step:.0f} s ({k_a} rows), longer than the {MAX_REST_ROWS} rows the "
            "alignment keeps in memory",
            "pass --align S to align on its first S seconds (the paper: 600)",
        )
    # row k integrates over (t[k], t[k+1]]; t[m] is the last epoch with both encoders still, so the alignment
    # uses rows 0..m−1 (epochs t[0..m]) and the strapdown starts at t[m]
    m = k_a - 1
    step_nav = float(np.median(dt[m:]))
    del dt
    ep = np.concatenate(rest["t"])[: m + 1]
    dth, dv = np.concatenate(rest["dtheta"])[:m], np.concatenate(rest["dv"])[:m]
    span = ep[-1] - ep[0]
    lat, h = src.lat, src.height_m
    # the encoders see a move start a little after the gyros (slow start of a rate profile): leave 2 s out
    k_lat = max(2, m - int(round(2.0 / step)))
    lat_meas, lat_sd = latitude_check(dth[:k_lat], dv[:k_lat], k_lat * step, lat)
    coarse = coarse_alignment(dv.sum(0) / span, dth.sum(0) / span, lat, h, "enu")
    if fine:
        al = fine_alignment(
            ep,
            dth,
            dv,
            lat,
            h,
            frame="enu",
            q0=coarse.q_b_n,
            gyro_white=5e-7,
            acc_white=5e-5,
            gyro_bias_std=1e-7,
            acc_bias_std=3e-4,
        )
    else:
        al = coarse
    rest_sd = float(np.std(np.diff(dth, axis=0), axis=0).max() / np.sqrt(2)) if m > 2 else 0.0
    return Alignment(
        m=m,
        t_m=float(ep[m]),
        q0=np.asarray(al.q_b_n, float),
        std=np.asarray(al.attitude_std, float),
        n=n,
        step=step,
        step_nav=step_nav,
        rest_sd=rest_sd,
        lat=float(lat),
        height_m=float(h),
        lat_measured=lat_meas,
        lat_measured_sd=lat_sd,
    )


@dataclasses.dataclass
class NavBlock:
    """The strapdown epochs of one block: epoch numbers ``j0 ..`` (0 = the navigation start, data row ``m``),
    ``t`` (s), ``q`` (k, 4) ``q_s^n`` (ENU), encoder angles ``alpha``, ``beta`` (rad); the intervals ending at the
    last ``len(dt)`` epochs (all but the first at the start): increments ``dtheta`` (rad), steps ``dt`` (s) and
    ``q_start`` the attitude at each interval's start, ``dv`` (m/s) the velocity increments of those intervals;
    ``perturbed``: ``q_s^n`` (k, 4) of each re-integration."""

    j0: int
    t: np.ndarray
    q: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    dtheta: np.ndarray
    dt: np.ndarray
    q_start: np.ndarray
    perturbed: list
    dv: np.ndarray | None = None


def strapdown_blocks(data, al: Alignment, *, coning: str = "previous", perturb=(), desc: str = "strapdown"):
    """Second pass: ``C_s^n`` integrated from the alignment on, block by block (the attitude and coning state
    carried, :class:`optinav.core.strapdown.AttitudeStream`): the attitude of the whole-log integration at every
    epoch, bit for bit, for any block length. Static base: the Earth rate is the navigation-frame rate.

    Parameters
    ----------
    data : RinsData, path or block source
        The recording (as :func:`survey` read it).
    al : Alignment
        The first pass's result.
    coning : str
        "previous" or "none".
    perturb : sequence of (i, j, s)
        Gyro triad errors integrated beside it, each with the increments ``(I − δK)Δθ``, ``δK`` = ``s`` at
        (i, j) alone, from the same start (re-read from its DCM, as a calibration's attitude gives it).
    desc : str
        Label of the progress bar (files).

    Yields
    ------
    NavBlock
        The epochs of each block from row ``al.m`` on.
    """
    w_ie = _earth.earth_rate(al.lat, "enu")
    main = AttitudeStream(al.q0, coning=coning, omega_in_n=w_ie)
    q_p = quat_from_dcm(dcm_from_quat(main.q))  # the start as the attitude's first DCM gives it back
    others = [(i, j, s, AttitudeStream(q_p, coning=coning, omega_in_n=w_ie)) for i, j, s in perturb]
    held = None  # the last row of the previous block: its increment and epoch (the interval into this block)
    for b in _blocks(rins_source(data), desc):
        r1 = b.row0 + len(b.t)
        if r1 <= al.m:
            continue
        a = max(al.m - b.row0, 0)
        t = np.asarray(b.t, float)
        dth_all, dv_all = np.asarray(b.dtheta, float), np.asarray(b.dv, float)
        if held is None:  # the navigation start: epochs m.., intervals between them
            dth, dv, tt, first = dth_all[a:-1], dv_all[a:-1], t[a:], 0
        else:
            dth, tt, first = np.concatenate([held[0][None], dth_all[:-1]]), np.concatenate([[held[1]], t]), 1
            dv = np.concatenate([held[2][None], dv_all[:-1]])
        dt = np.diff(tt)
        q = main.update(dth, dt)
        pert = []
        for i, j, s, stream in others:
            d = dth.copy()
            d[:, i] -= s * dth[:, j]
            pert.append(stream.update(d, dt)[first:])
        j0 = 0 if held is None else b.row0 - al.m
        held = (dth_all[-1], t[-1], dv_all[-1])
        yield NavBlock(
            j0=j0,
            t=tt[first:],
            q=q[first:],
            alpha=np.asarray(b.alpha, float)[a:],
            beta=np.asarray(b.beta, float)[a:],
            dtheta=dth,
            dt=dt,
            q_start=q[:-1],
            perturbed=pert,
            dv=dv,
        )


def sensor_attitude_from_imu(
    data, *, align_s: float | None = None, coning: str = "previous", fine: bool = True
) -> SensorAttitude:
    """Align on the initial rest, then integrate ``C_s^n`` over the rest of the recording, at every epoch.

    data: :class:`~optinav.rins.simulate.RinsData` (or a path or block source). align_s: longest alignment window
    (s; default the whole initial rest). Returns the attitude from the last alignment row on (the whole log's
    worth: the calibration keeps only its residual epochs, see :func:`optinav.rins.calibrate.prepare`).
    """
    al = survey(data, align_s=align_s, fine=fine)
    parts = list(strapdown_blocks(data, al, coning=coning))
    cat = lambda f: np.concatenate([getattr(p, f) for p in parts])  # noqa: E731
    return SensorAttitude(
        t=cat("t"),
        c_s_n=dcm_from_quat(cat("q")),
        alpha=cat("alpha"),
        beta=cat("beta"),
        index=np.arange(al.m, al.n),
        align_end=al.t_m,
        align_std=al.std,
    )
