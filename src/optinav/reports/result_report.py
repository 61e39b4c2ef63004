"""``optinav report``: the report of any system's result file, built by the system's ``report`` reference in
:mod:`optinav.registry` (the schema of the file selects the system), into a folder or one Markdown file; and the
report references of the multipos and attitude systems."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from optinav.errors import OptinavError


def multipos_report(res, out_dir, data=None, options=None) -> Path:
    """The report of a multi-position calibration: its tables and, with the recording ``data`` (read with
    ``options``, a :class:`~optinav.multipos.calibrate.FileOptions`), the corrected norm over the log and the
    pose residuals (:mod:`optinav.reports.calibration_report`)."""
    from optinav.reports import calibration_report as cr

    if res.accelerometer is None:  # optinav writes none without: the report's tables and residuals are of it
        raise OptinavError(
            "the calibration result has no accelerometer (its field 'accelerometer' is null), which every "
            "multi-position calibration of optinav has",
            "pass an unmodified optinav result file",
        )
    if data is not None:
        import dataclasses

        from optinav.multipos.calibrate import FileOptions, read_session_file

        o = options or FileOptions()
        units = res.units or {}
        ours = options is None or (options.acc_unit is None and options.gyro_unit is None)
        raw = (units.get("accelerometer_raw"), units.get("gyroscope_raw"))
        if ours and any(raw):
            # a log whose header declares other units is not the result's: the raw units below are the program's
            # (as apply reads a log), and a stated unit overrides a declared one
            from optinav.io.imu import iter_imu, reader_options

            head = next(iter(iter_imu(data, chunk_rows=64, unit_defaults=raw, **reader_options(o))), None)
            have = () if head is None else (head.acc_input_unit, head.gyro_input_unit)
            if any(u and h and u != h for u, h in zip(raw, have)):
                raise OptinavError(
                    f"{Path(data).name} is in {', '.join(h for h in have if h)}, the result was calibrated from raw "
                    f"{', '.join(u for u in raw if u)}: not its log",
                    "pass the log the result was calibrated from with --data",
                )
        # the log the result came from is in the raw units the calibration was made for (as apply reads it)
        if o.acc_unit is None and units.get("accelerometer_raw"):
            o = dataclasses.replace(o, acc_unit=units["accelerometer_raw"])
        if o.gyro_unit is None and units.get("gyroscope_raw"):
            o = dataclasses.replace(o, gyro_unit=units["gyroscope_raw"])
        d = read_session_file(data, o)
        _check_same_log(res, d, data)
        return cr.write_calibration_report(res, d.t, d.acc, d.gyr, out_dir)
    from optinav.reports.report import StudyResult, write_report

    study = StudyResult(
        name="calibration",
        title=f"Calibration of {res.source or 'a log'} ({res.method})",
        description=res.summary().replace("\n", "  \n"),
        tables=cr.tables(res, []),
    )
    return write_report([study], out_dir, title="optinav calibration")


def _reading(system, rate_hz: float | None, time_unit: str | None = None, more: dict | None = None):
    """The reading options of ``system``'s recordings with ``rate_hz``, ``time_unit`` and ``more`` (option field →
    value: ``columns``, ``topic``, ``gyro_path``; None values left out), or None (its defaults)."""
    given = {"rate_hz": rate_hz, "time_unit": time_unit, **(more or {})}
    given = {k: v for k, v in given.items() if v is not None}
    if not given:
        return None
    import dataclasses

    cls = system.load("options")
    names = {f.name for f in dataclasses.fields(cls)}
    flags = {"rate_hz": "--rate", "time_unit": "--time-unit", "gyro_path": "--gyro"}
    for field_name in given:
        if field_name not in names:
            flag = flags.get(field_name, f"--{field_name}")
            raise OptinavError(f"{flag} does not apply to {system.name} results", f"drop {flag}")
    if "rate_hz" in given:
        given["rate_hz"] = float(given["rate_hz"])
    return cls(**given)


def _check_same_log(res, d, data) -> None:
    """``--data`` must be the log ``res`` was calibrated from: every static interval holds samples of it, and its
    corrected specific force reads about g there (another session, or a log in other units, gave a report of NaN
    rows with exit 0)."""
    import numpy as np

    from optinav.core.units import G_STANDARD

    t = np.asarray(d.t, float)
    a = res.correct_accel(np.asarray(d.acc, float))
    sq, count = 0.0, 0  # Σ(|a| − g)² and samples over the static intervals
    for k, (t0, t1) in enumerate(np.asarray(res.static_intervals, float)):
        m = (t >= t0) & (t <= t1) & np.all(np.isfinite(a), axis=1)
        if not m.any():
            raise OptinavError(
                f"{data} has no samples in static interval {k} ({t0:.6g}–{t1:.6g} s) of the result: not its log",
                "pass the log the result was calibrated from with --data",
            )
        norms = np.linalg.norm(a[m], axis=1)
        sq, count = sq + float(np.sum((norms - res.gravity) ** 2)), count + norms.size
        med = float(np.median(norms))
        if not 0.5 * G_STANDARD <= med <= 2.0 * G_STANDARD:
            raise OptinavError(
                f"{data} corrected by the result reads |a| = {med:.4g} m/s² in static interval {k}, not about g: not "
                f"the log it was calibrated from, or not in its raw unit ({(res.units or {}).get('accelerometer_raw')})",
                "pass the log the result was calibrated from with --data",
            )
        # a static interval holds one pose: with another time base (a wrong --rate) it reaches into the moves
        u = a[m] / np.linalg.norm(a[m], axis=1, keepdims=True)
        c = np.median(u, axis=0)
        off = np.degrees(np.arccos(np.clip(u @ (c / np.linalg.norm(c)), -1.0, 1.0)))
        moving = float(np.mean(off > STILL_DEG))
        if moving > STILL_SHARE:
            raise OptinavError(
                f"static interval {k} ({t0:.6g}–{t1:.6g} s) of the result is not still in {data}: "
                f"{100 * moving:.0f} % of its samples point more than {STILL_DEG:g}° from the pose — the log's time "
                "base is not the one the result was calibrated with, or it is not its log",
                "read the log as calibrate did (--rate, --time-unit), or pass the log it was calibrated from",
            )
    rms = float(np.sqrt(sq / max(count, 1)))
    if res.residual_rms and rms > FIT_RATIO * res.residual_rms:
        raise OptinavError(
            f"{data} corrected by the result reads |a| − g = {rms:.3g} m/s² RMS over its static intervals, "
            f"{rms / res.residual_rms:.0f}× the calibration's own {res.residual_rms:.3g} m/s²: not the log it was "
            "calibrated from (another unit's or another session's recording)",
            "pass the log the result was calibrated from with --data (optinav apply corrects another recording)",
        )


#: a sample of a static interval farther than this (deg) from the interval's pose direction is motion
STILL_DEG = 10.0
#: more than this share of such samples: the interval is not a pose of the log read
STILL_SHARE = 0.05
#: the corrected |a| − g RMS over the static intervals beyond this multiple of the result's own: another log (the
#: same log reads 1×; another simulated unit of the same preset at the same poses and times 10-20×)
FIT_RATIO = 3.0


#: rad/s: the samples of a log turning faster than this judge whether an attitude estimate is of it
TURNING = 0.2
#: an estimate whose rotation from sample to sample differs from the log's gyro by more than this share of the
#: gyro's rate (median over its turning samples) is of another recording: BROAD 02's estimate on its own log 0.007,
#: on trial 03 cut to its length 1.3 (reported as trial 03's attitude with exit 0)
TURN_MISFIT = 0.5


def _check_turns_with(res, t, gyr, data) -> None:
    """``--data`` (times ``t`` s, gyro ``gyr`` rad/s) must be the log the estimate ``res`` came from: the estimate
    turns from sample to sample as its gyro says (judged where the gyro turns faster than :data:`TURNING`)."""
    import numpy as np

    from optinav.core.rotations import quat_conjugate, quat_multiply

    q = np.asarray(res.q_b_n, float)
    g = np.asarray(gyr, float)[1:]
    fast = np.linalg.norm(g, axis=1) > TURNING
    if np.count_nonzero(fast) < 100:
        return
    dq = quat_multiply(quat_conjugate(q[:-1][fast]), q[1:][fast])
    with np.errstate(all="ignore"):
        w = 2.0 * dq[:, 1:] * np.sign(dq[:, :1]) / np.diff(t)[fast][:, None]
        share = float(np.nanmedian(np.linalg.norm(w - g[fast], axis=1) / np.linalg.norm(g[fast], axis=1)))
    if share > TURN_MISFIT:
        raise OptinavError(
            f"the estimate does not turn as the gyro of {data} does (its rotation from sample to sample differs from "
            f"the gyro's by {share:.2g} of the gyro's rate, median over {np.count_nonzero(fast)} samples turning "
            f"faster than {TURNING:g} rad/s): not the log it was estimated from",
            "pass the log the estimate came from with --data",
        )


def attitude_report(res, out_dir, data=None, options=None) -> Path:
    """The report of an attitude estimate: its summary and the roll, pitch, yaw over the log ``data`` it was
    estimated from (read with ``options``, an :class:`~optinav.attitude.unit.AttitudeOptions`), which gives the
    time stamps the estimate does not hold."""
    import numpy as np

    from optinav.attitude.unit import AttitudeOptions, read_log
    from optinav.core.rotations import euler_from_quat, frame_name
    from optinav.reports.attitude_report import write_attitude_report

    if data is None:
        raise OptinavError("an attitude estimate holds no time stamps", "pass the log it came from with --data")
    t, gyr = read_log(data, options or AttitudeOptions())[:2]
    if t.size != len(res.q_b_n):
        raise OptinavError(
            f"{data} has {t.size} samples, the estimate {len(res.q_b_n)}",
            "pass the log the estimate came from with --data",
        )
    _check_turns_with(res, t, gyr, data)
    eul = np.degrees(euler_from_quat(res.q_b_n, frame_name(res.frame)))
    return write_attitude_report(res, t, eul, str(data), out_dir)


def _stems(paths) -> list[str]:
    """One distinct folder name per result file (its stem, numbered when two are the same)."""
    out: list[str] = []
    for p in paths:
        stem, k = Path(p).stem, 2
        name = stem
        while name in out:
            name, k = f"{stem}-{k}", k + 1
        out.append(name)
    return out


def write_result_reports(
    results,
    out,
    data=None,
    rate_hz: float | None = None,
    *,
    time_unit: str | None = None,
    reading: dict | None = None,
    gyro=None,
) -> Path:
    """Report every result file of ``results`` (paths; ``data``: None or the recording of each, in order) into
    ``out``: a folder (one result: its report there; several: one sub-folder each and an index.md linking
    them) or a Markdown file ``FILE.md`` (the reports one after the other, their figures, HTML and summaries in
    ``FILE_files/``). ``rate_hz``: the sampling rate (Hz) of recordings without a time column (the reading
    option of multi-position and attitude results), ``time_unit`` that of their time column, ``reading`` further
    reading options of theirs (``columns``, ``topic``) and ``gyro`` the gyroscope's file of each (two-file
    recordings, in order). Returns the Markdown file written."""
    from optinav import registry
    from optinav.core.files import check_output, write_text
    from optinav.reports.report import check_report_dir

    data = list(data or [])
    if data and len(data) != len(results):
        raise OptinavError(
            f"{len(data)} --data files for {len(results)} results",
            "give one --data per result, in the same order, or none",
        )
    out = Path(out)
    single_file = out.suffix.lower() == ".md"
    if single_file:
        check_output(out)
    root = check_report_dir(out.with_name(out.stem + "_files") if single_file else out, "--out")
    loaded = [registry.for_result(p) for p in results]
    if any(res is None for _, res in loaded):  # an imucal/imu_tk file: the report is of optinav results
        raise OptinavError(
            "only optinav result files (with a schema) have a report", "pass RESULT.json written by optinav calibrate"
        )
    stems = _stems(results)
    folders = [root if len(results) == 1 and not single_file else root / s for s in stems]
    # a report that fails (a check of its system, a bad --data) leaves none of the folders it made behind
    made = _outermost_missing(root)
    new = [made] if made is not None else [f for f in folders if not f.exists()]
    try:
        gyros = list(gyro or []) or [None] * len(results)
        for (system, res), folder, d, g in zip(loaded, folders, data or [None] * len(results), gyros):
            opts = _reading(system, rate_hz, time_unit, {**(reading or {}), "gyro_path": g})
            system.load("report")(res, folder, d, opts)
        if single_file:
            parts = [_relinked((f / "index.md").read_text(encoding="utf-8"), f"{root.name}/{f.name}") for f in folders]
            return write_text(out, "\n".join(parts), "--out")
        if len(results) > 1:
            lines = ["# optinav report", ""] + [
                f"- [{Path(p).name}]({s}/index.md) ({sys_.name})" for p, s, (sys_, _) in zip(results, stems, loaded)
            ]
            write_text(root / "index.md", "\n".join(lines) + "\n", "--out")
    except BaseException:
        for folder in new:
            shutil.rmtree(folder, ignore_errors=True)
        raise
    return root / "index.md"


def _outermost_missing(path: Path) -> Path | None:
    """The outermost folder of ``path`` that does not exist yet (what creating ``path`` makes), or None."""
    if path.exists():
        return None
    while not path.parent.exists() and path.parent != path:
        path = path.parent
    return path


def _relinked(markdown: str, prefix: str) -> str:
    """``markdown`` with its relative figure links ``![caption](name.png)`` pointing into ``prefix``."""
    return re.sub(r"(!\[[^\]]*\]\()([^)/:]+\))", lambda m: f"{m.group(1)}{prefix}/{m.group(2)}", markdown)
