"""``optinav apply`` for a multi-position calibration: raw logs corrected block by block,
a = K⁻¹(raw − b) (m/s²) and ω = K_g⁻¹(raw − G·a − b_g) (rad/s).

The calibration is optinav's RESULT.json, an imucal JSON export or imu_tk parameter files
(:func:`optinav.multipos.exchange.load_calibration`); it is refused when its K/b cannot be a sensor's.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np

from optinav.errors import Note, OptinavError

#: accepted ratio of a calibrated scale to its nominal value (1 / the SI factor of the raw unit); MEMS scale
#: errors are percent, so a factor 2 only lets through what cannot be a calibration of that unit
SCALE_FACTOR = 2.0
#: raw counts per SI unit that any real ADC and range give (16 to 32 bits, ranges 0.5 g to 400 g, 10 to 5000 °/s)
COUNTS_PER_SI = (1e-2, 1e9)
#: largest condition number of K: misalignments are degrees at most, so K is close to a scaled identity
MAX_COND = 10.0
#: the largest zero offset |b| accepted [raw units]: a 32-bit converter's whole range (offset-binary counts reach
#: half of it); a bias of 1e300 in a damaged file overflowed in the checks after the correction (a warning line
#: before the error)
MAX_OFFSET = 2.0**32


@dataclasses.dataclass
class ApplyOptions:
    """How the raw log is read (the reading options of :func:`optinav.io.imu.iter_imu`: ``columns``, units
    (None: those the calibration was made in), ``time_unit``, ``rate_hz`` Hz, ``datasets``, ``delimiter``,
    ``topic``, ``skip_bad_lines``), ``chunk_rows`` rows per block, and ``gyro_cal``: imu_tk's gyroscope parameter file when the
    result is imu_tk's accelerometer file."""

    columns: str | None = None
    acc_unit: str | None = None
    gyro_unit: str | None = None
    time_unit: str | None = None
    rate_hz: float | None = None
    datasets: str | None = None
    delimiter: str | None = None
    topic: str | None = None
    skip_bad_lines: bool = False
    chunk_rows: int | None = None
    gyro_cal: str | None = None


def apply_file(result_path, data_path, out, options: ApplyOptions | None = None) -> str:
    """Correct the raw log ``data_path`` with the calibration ``result_path`` into ``out`` (format by extension),
    block by block so that memory does not grow with the log; returns the one-line account."""
    from optinav.core.files import CHUNK_ROWS
    from optinav.core.progress import progress_blocks
    from optinav.io import ImuLog
    from optinav.io.imu import iter_imu, open_imu_writer, reader_options
    from optinav.multipos.exchange import load_calibration

    o = options or ApplyOptions()
    res = load_calibration(result_path, o.gyro_cal)
    for sensor, entry, key in (
        ("accelerometer", res.accelerometer, "accelerometer_raw"),
        ("gyroscope", res.gyroscope, "gyroscope_raw"),
    ):
        if entry is not None:
            check_plausible_K(sensor, entry, res.units.get(key))
    # a unit the file declares or the user states wins; a file that declares none is in the calibration's units
    defaults = (
        res.units.get("accelerometer_raw") if res.accelerometer else None,
        res.units.get("gyroscope_raw") if res.gyroscope else None,
    )
    blocks = iter_imu(data_path, unit_defaults=defaults, chunk_rows=o.chunk_rows or CHUNK_ROWS, **reader_options(o))
    source = f"optinav apply {Path(result_path).name} {Path(data_path).name}"
    # block by block: read, correct, append to the (temporary, renamed at the end) output, so memory does not
    # grow with the log; a bad row fails when its block is read and leaves no output
    seen: list[str] = []
    n_bad = 0
    with open_imu_writer(out) as writer:
        for log in progress_blocks(blocks, "apply"):
            for note in log.notes:  # the reader's notes (an incomplete last line left out, ...), each once
                if note not in seen:
                    seen.append(note)
                    warnings.warn(note, Note, stacklevel=2)
            raw = [x for x in (log.acc, log.gyr) if x is not None]
            n_bad += int(np.count_nonzero(~np.all(np.isfinite(np.hstack(raw)), axis=1))) if raw else 0
            acc, gyro = corrected(res, log, data_path, result_path)
            if writer.rows == 0 and res.method == "imu_tk" and res.gyroscope is None and log.gyr is not None:
                from optinav.multipos.exchange import check_imu_tk_alone

                check_imu_tk_alone(result_path, data_path)
            if writer.rows == 0:
                written = [u for u, x in (("m/s^2", acc), ("rad/s", gyro)) if x is not None]
                pairs = (("accelerometer", log.acc, acc), ("gyroscope", log.gyr, gyro))
                left = [name for name, raw, x in pairs if x is None and raw is not None]
            if writer.rows == 0 and acc is not None:
                _check_corrected_norm(acc, log, data_path, result_path, res.method == "imu_tk", res)
                _check_rest_norm(res, acc, log, data_path, result_path)
                if gyro is not None:
                    _check_corrected_gyro(res, acc, gyro, log, data_path, result_path)
            if writer.rows == 0 and gyro is not None and o.gyro_unit is None:
                # after the gyro check, which names the unit where gravity turns
                _check_counts_resolution(res, log, data_path, result_path)
            writer.write(
                ImuLog(
                    t=log.t, acc=acc, gyr=gyro, acc_unit="m/s^2", gyro_unit="rad/s", source=source, labels=log.labels
                )
            )
    if n_bad:
        # kept, row for row (the output keeps the log's rows and times); said, so that no one averages them away
        warnings.warn(
            f"{n_bad} rows of {Path(data_path).name} hold empty, NaN or infinite values: written as NaN",
            Note,
            stacklevel=2,
        )
    if writer.rows and left:
        # an accelerometer-only calibration wrote the log without its gyro, said "(m/s^2, rad/s)" and nothing else
        warnings.warn(
            f"the {' and '.join(left)} of {Path(data_path).name} left out of {Path(out).name}: "
            f"{Path(result_path).name} holds no {' or '.join(left)} calibration"
            + (" (imu_tk's gyroscope file goes with --gyro-cal)" if res.method == "imu_tk" else ""),
            Note,
            stacklevel=2,
        )
    return f"wrote {writer.rows} corrected samples to {out} ({', '.join(written) if writer.rows else 'none'})"


#: the offsets of offset-binary counts (unsigned, mid-scale at rest) of 16-, 24- and 32-bit sensors
OFFSET_BINARY = (2.0**15, 2.0**23, 2.0**31)


def _check_corrected_norm(acc, log, data_path, result_path, unitless: bool = False, res=None) -> None:
    """The first block's corrected specific force must read about g (median norm within ×2): a calibration made
    for other raw units (g for counts, counts for m/s²) gave |a| of 0.17 or 19 964 m/s² with exit 0. ``unitless``:
    a calibration file that records no unit (imu_tk's), whose raw unit no flag can state. Counts in offset binary
    (each axis mid-scale at rest) under a calibration of signed ones (``res``) are named so."""
    from optinav.core.units import G_STANDARD

    def median_norm(a) -> float:
        return float(np.nanmedian(np.sqrt(np.einsum("ij,ij->i", a, a))))

    med = median_norm(acc)
    if not 0.5 * G_STANDARD <= med <= 2.0 * G_STANDARD and res is not None and log.acc_input_unit == "counts":
        raw = calibration_raw(log, "acc", res.units.get("accelerometer_raw"))
        for off in OFFSET_BINARY:
            a = res.correct_accel(raw - off)
            if abs(median_norm(a) / G_STANDARD - 1.0) < 0.1:
                raise OptinavError(
                    f"{Path(result_path).name} applied to {Path(data_path).name} gives |a| = {med:.4g} m/s^2, and "
                    f"{G_STANDARD:.4g} with {off:.0f} taken off every count: the data are offset-binary counts "
                    "(unsigned, mid-scale at zero), the calibration was made for signed ones",
                    f"convert the counts to signed ones (subtract {off:.0f}), or calibrate from data in this encoding",
                )
    if not 0.5 * G_STANDARD <= med <= 2.0 * G_STANDARD:
        what = (
            f"{Path(result_path).name} applied to {Path(data_path).name} gives |a| = {med:.4g} m/s^2 (median of the "
            f"first {acc.shape[0]} samples), not about g: the data's raw unit ({log.acc_input_unit or 'unstated'}) "
            "is not the one the calibration was made for"
        )
        if unitless and log.acc_input_unit:
            # the unit was stated, and the file has none to convert it to: --acc-unit cannot help
            ratio = med / G_STANDARD
            guess = next(
                (u for u, f in (("g", G_STANDARD), ("mg", G_STANDARD / 1e3)) if abs(ratio / f - 1) < 0.1), None
            )
            raise OptinavError(
                what
                + " (imu_tk files record no unit"
                + (f"; |a| is {ratio:.4g} g: this one was made for data in {guess})" if guess else ")"),
                f"convert the log to the unit the calibration was made in{f' ({guess})' if guess else ''}, or export "
                "the calibration from optinav's result.json (which records its units) instead",
            )
        raise OptinavError(
            what,
            "state the data's unit with --acc-unit (counts, g, mg, m/s^2), or apply the calibration of this sensor",
        )


#: the corrected |a| of the first block's rests may differ from the calibration's g by this much (m/s², the median
#: over the rests: a vehicle's steady acceleration found as a rest is one of many; and REST_NORM_RESIDUALS × the
#: calibration's own residual) before the calibration is taken for another sensor's: imucal's example
#: calibration on its own session 0.0004 (rests 9.8096-9.8106), on another sensor's log in the same units
#: (imucal's annotated session at its nominal 2048 counts per g) 0.47 (9.28-10.43). A MEMS bias that moved with
#: temperature by 10-20 mg stays below it
REST_NORM_MAX = 0.2
REST_NORM_RESIDUALS = 10.0
#: rests needed to judge by, found in at most the first REST_NORM_ROWS rows (the static detection of a block of
#: 200 000 rows takes 0.25 s)
REST_NORM_MIN_RESTS = 3
REST_NORM_ROWS = 65536


def _check_rest_norm(res, acc, log, data_path, result_path) -> None:
    """The corrected specific force must read g at the log's rests (those of its first block): a calibration of
    another sensor of the same units (biases 0.5 m/s² apart) read 9.28-10.43 m/s² at rest with exit 0, passing
    the check of the median norm (within ×2)."""
    from optinav.core.units import G_STANDARD
    from optinav.multipos.static import detect_static

    n = min(acc.shape[0], REST_NORM_ROWS)
    ok = np.isfinite(acc[:n]).all(axis=1)
    if log.t is None or np.count_nonzero(ok) < 100:
        return
    try:
        det = detect_static(log.t[:n][ok], acc[:n][ok])
    except OptinavError:
        return  # too short or too irregular to find rests in: the median check above is what remains
    if len(det.counts) < REST_NORM_MIN_RESTS:
        return
    norms = np.linalg.norm(np.asarray(det.acc_means, float), axis=1)
    g = float(res.gravity) if np.isfinite(res.gravity) else G_STANDARD
    slack = 0.0 if np.isfinite(res.gravity) else 0.03  # a local g the file does not state: 9.78-9.83
    off = float(np.median(np.maximum(np.abs(norms - g) - slack, 0.0)))
    residual = float(res.residual_rms) if np.isfinite(res.residual_rms) else 0.0
    if off > max(REST_NORM_MAX, REST_NORM_RESIDUALS * residual):
        raise OptinavError(
            f"{Path(result_path).name} applied to {Path(data_path).name} reads |a| = {norms.min():.4g}-"
            f"{norms.max():.4g} m/s^2 at the log's {norms.size} rests, {off:.2g} m/s^2 off g = {g:.5g} (median; "
            f"the calibration's own residual {residual:.2g}): the calibration is another sensor's, or its biases moved",
            "apply the calibration of this sensor, or calibrate it again",
        )


#: a raw gyro log in a unit finer than counts: most values not whole and the median step between samples below this
#: many counts. A converter's counts are whole; unrounded counts (a simulator, a logger's mean of a few samples) of
#: a gyro whose noise is ~0.8 count or more (a 16-bit ±2000 °/s MEMS gyro at 100 Hz) step by ≥ 0.5 count
#: (median |step| = 0.67σ√2); rad/s and deg/s read as counts step by their noise, 0.001-0.01 rad/s or ~0.1 °/s
COUNTS_STEP_MIN = 0.25


def _check_counts_resolution(res, log, data_path, result_path) -> None:
    """Refuse a gyro read as the counts a calibration was made for whose values are neither whole nor step like
    counts: rad/s data under a calibration of counts, with no unit stated, came out ~940× too small with exit 0
    when nothing turned gravity (a session turning only about the vertical, or at rest: the gyro check below is
    silent then)."""
    if res.units.get("gyroscope_raw") != "counts" or log.gyr is None or log.gyr.shape[0] < 20:
        return
    raw = calibration_raw(log, "gyro", "counts")
    ok = np.isfinite(raw).all(axis=1)
    raw = raw[ok]
    if raw.shape[0] < 20:
        return
    whole = float(np.mean(raw == np.round(raw)))
    step = float(np.median(np.abs(np.diff(raw, axis=0))))
    if whole < 0.5 and step < COUNTS_STEP_MIN:
        raise OptinavError(
            f"{Path(result_path).name} was made for raw gyro counts, but the gyro of {Path(data_path).name} reads "
            f"values that are not whole ({100 * (1 - whole):.0f} %) and step by {step:.2g} counts (median): a "
            "physical unit (rad/s, deg/s), not a converter's counts",
            "apply the calibration to the gyro's raw counts (a logger that averages counts: state --gyro-unit counts)",
        )


def _check_corrected_gyro(res, acc, gyro, log, data_path, result_path) -> None:
    """The first block's corrected gyro must explain how the corrected specific force turns in the body (the
    attitude input check, :func:`optinav.attitude.checks.gyro_unit_hint`, with the raw gyro ×π/180 and ×180/π
    corrected by the calibration as the alternatives, for a calibration of counts the raw gyro read as deg/s and
    rad/s; silent when too little turns): a log in rad/s corrected by a calibration made for deg/s read 57 times
    too small with exit 0 (the calibration's bias, in its own unit, is no multiple of the data's)."""
    from optinav.attitude.checks import gyro_unit_hint, unit_error
    from optinav.core.units import factor

    if log.t is None or log.t.size < 3:
        return
    dts = np.diff(log.t, prepend=2 * log.t[0] - log.t[1])
    ok = np.isfinite(acc).all(axis=1) & np.isfinite(gyro).all(axis=1)
    if not ok.all() or not np.all(dts > 0):
        return  # the reader's checks name gaps and non-finite rows; the unit is judged on clean blocks
    expected = res.units.get("gyroscope_raw")
    raw = calibration_raw(log, "gyro", expected)
    factors = {s: s for s in (np.pi / 180, 180 / np.pi)}  # the data in deg/s read as rad/s, and the reverse
    k = float(np.mean(np.abs(np.diag(np.asarray(res.gyroscope["K"], float)))))
    # a calibration of counts (stated, or an imu_tk file's scale beyond twice a deg/s one's: no physical unit's):
    # the alternatives are data in deg/s and rad/s read as counts (× its counts per deg/s and per rad/s); a rad/s
    # gyro read as counts came out ~900× too small with exit 0 (probe)
    counts = expected == "counts" or (expected is None and k > 2 * 180 / np.pi)
    if counts:
        factors = {np.pi / 180: k * np.pi / 180, 180 / np.pi: k}

    def alt(s, sl):
        return res.correct_gyro(raw[sl] * factors[s], acc[sl])

    hint = gyro_unit_hint(gyro, acc, dts, alt=alt, units_only=True)

    def axes_in(sl):
        w = gyro_unit_hint(
            gyro[sl], acc[sl], dts[sl], alt=lambda s, ss: alt(s, slice(sl.start + ss.start, sl.start + ss.stop))
        )
        return w if w is not None and w.kind == "axes" else None

    # a gyro that turns about the wrong axes (an axis flipped, in either triad) explains gravity worse than no turn
    # at all, which was taken for "the data look like deg/s" of data in deg/s (probe): axes named first. An
    # accelerometer axis flipped keeps |a| and the unit (exit 0 before; probe) and shows only where the turns
    # involve that axis: without a unit hint each quarter of the block is judged too, with its own windows
    n = gyro.shape[0]
    parts = [slice(0, n)] + ([] if hint else [slice(k * n // 4, (k + 1) * n // 4) for k in range(4)])
    axes = next((w for w in (axes_in(sl) for sl in parts if sl.stop - sl.start >= 16) if w is not None), None)
    if axes is not None:
        # which triad is off, as the attitude checks word it: the session with its accelerometer's y negated was told
        # "gyro x reads -x, gyro z reads -z", and to fix the gyro's columns (a mirror image gravity cannot tell)
        named = unit_error(axes, "rad/s")
        raise OptinavError(
            f"{Path(result_path).name} applied to {Path(data_path).name}: the corrected gyro does not explain "
            f"how gravity turns in the body: {named.cause}",
            f"{named.remedy}; or apply the calibration of this sensor",
        )
    if hint:
        unit = "deg/s" if hint.scale < 1.0 else "rad/s"
        # an imu_tk file holds no unit: its scale tells the raw unit it reads (57.3 raw per rad/s: deg/s)
        implied = next((u for u in ("deg/s", "rad/s") if abs(k * factor(u) - 1.0) < 0.1), None)
        if expected is None and not counts and implied and log.gyro_input_unit not in (None, implied):
            raise OptinavError(
                f"{Path(result_path).name} applied to {Path(data_path).name}: the calibration holds no unit and its "
                f"gyro scale, {k:.4g} raw per rad/s, reads raw {implied}, while the data's gyro is in "
                f"{log.gyro_input_unit}: the corrected gyro does not explain how gravity turns in the body",
                f"give the data's gyro in {implied} (the unit the calibration was made from), or apply a calibration "
                f"made from {log.gyro_input_unit} data",
            )
        raise OptinavError(
            f"{Path(result_path).name} applied to {Path(data_path).name}: the corrected gyro does not explain how "
            f"gravity turns in the body, as it would were the data's gyro in {unit}: it is not in the "
            f"{'counts' if counts else log.gyro_input_unit or 'unit'} the calibration was made for, or the "
            "calibration is another sensor's",
            "apply the calibration to the gyro's raw counts, or that of this sensor"
            if counts
            else "state the data's gyro unit with --gyro-unit (deg/s, rad/s), or apply the calibration of this sensor",
        )


def corrected(res, log, data_path, result_path):
    """One block's corrected (acc m/s², gyro rad/s), None for a sensor the result or the data lack."""
    acc = gyro = None
    if res.accelerometer is not None and log.acc is not None:
        acc = res.correct_accel(calibration_raw(log, "acc", res.units.get("accelerometer_raw")))
    if res.gyroscope is not None and log.gyr is not None:
        gyro = res.correct_gyro(calibration_raw(log, "gyro", res.units.get("gyroscope_raw")), acc)
    if acc is None and gyro is None:
        raise OptinavError(
            f"{data_path} has no data for the sensors in {result_path}", "check --columns (t,ax,ay,az,gx,gy,gz)"
        )
    return acc, gyro


def check_plausible_K(sensor: str, entry: dict, raw_unit: str | None) -> None:
    """Refuse a calibration whose K/b cannot be a sensor's (non-finite, ill-conditioned, an offset beyond
    :data:`MAX_OFFSET`, scale far from the raw unit's nominal, e.g. K = 1e300 of a damaged file): applied, it would
    write plausible-looking garbage."""
    from optinav.core.units import factor

    K, b = np.asarray(entry["K"], float), np.asarray(entry["b"], float)
    cause = None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(b))):
        cause = "K or b is not finite"
    elif np.linalg.cond(K) > MAX_COND:
        cause = f"K has condition number {np.linalg.cond(K):.3g} (> {MAX_COND:g}: axes nearly parallel)"
    elif np.any(np.abs(b) > MAX_OFFSET):
        cause = f"the offsets b = {', '.join(f'{v:.4g}' for v in b)} {raw_unit or 'raw'} exceed {MAX_OFFSET:.4g}"
    elif sensor == "gyroscope" and np.all(np.diag(K) < 0):
        # calibrate refuses this (made with the turns' sense the other way: imucal's Ferraris default expected angle
        # −360° for turns of +360°); imucal's own calibration of its annotated session applied read every rate with
        # its sign flipped (−360° for the +360° turns) with exit 0
        cause = (
            "every gyro scale is negative (diag(K) = "
            f"{', '.join(f'{v:.4g}' for v in np.diag(K))}): made with the rotations' sense opposite to the turns', it "
            "reads every rate with its sign flipped"
        )
    else:
        scale = np.abs(np.diag(K))
        if raw_unit in (None, "counts"):
            lo, hi = COUNTS_PER_SI
        else:
            nominal = 1.0 / factor(raw_unit)
            lo, hi = nominal / SCALE_FACTOR, nominal * SCALE_FACTOR
        if np.any(scale < lo) or np.any(scale > hi):
            cause = (
                f"the scales diag(K) = {', '.join(f'{v:.4g}' for v in scale)} {raw_unit or 'raw'} per SI unit "
                f"are outside {lo:.3g}..{hi:.3g}"
            )
    if cause:
        raise OptinavError(
            f"the {sensor} calibration is implausible: {cause}",
            "re-run optinav calibrate on this unit (for Ferraris turns: with the rotation angle they make, imucal's "
            "expected_angle=360 for turns of +360°)"
            if "negative" in cause
            else "re-run optinav calibrate on this unit (the result file may be damaged or of another unit)",
        )


def calibration_raw(log, kind: str, expected: str | None) -> np.ndarray:
    """The log's ``kind`` ("acc"/"gyro") triad in the calibration's raw unit ``expected``: a physical unit
    (g, mg, m/s^2; deg/s, rad/s) is converted to another; counts are no physical unit, so counts against a
    physical unit (or the reverse) cannot be and are refused."""
    from optinav.core.units import factor
    from optinav.io import raw_units

    raw, unit = raw_units(log, kind)
    if not expected or unit == expected:
        return raw
    sensor, flag = ("accelerometer", "--acc-unit") if kind == "acc" else ("gyroscope", "--gyro-unit")
    if "counts" in (unit, expected):
        raise OptinavError(
            f"the {sensor} data are in {unit} but the calibration was made in {expected}: no factor converts "
            "counts to a physical unit",
            f"apply the calibration to data in {expected} ({flag} states the data's unit)",
        )
    si = log.acc if kind == "acc" else log.gyr  # the reader's SI values
    return si / factor(expected)
