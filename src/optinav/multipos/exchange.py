"""A calibration result to and from the files other tools read: imu_tk, imucal and Kalibr.

:func:`export_calibration` writes a :class:`~optinav.multipos.result.CalibrationResult` as imu_tk's two parameter
files (accelerometer, gyroscope), imucal's Ferraris JSON or Kalibr's ``scale-misalignment`` imu.yaml (with the
noise of an ``optinav allan`` result); :func:`load_calibration` reads optinav's RESULT.json, an imucal JSON
(or HDF5) export or an imu_tk accelerometer file (with the gyroscope file beside it) back into a ``CalibrationResult``, which is what
``optinav apply`` applies. The parameter conversions are in :mod:`optinav.multipos.convert` and
:mod:`optinav.multipos.kalibr`; what each format can hold:

- imu_tk: K and b per triad, no g-sensitivity and no units (the raw unit is the data's); calibrated outputs in
  m/s² and rad/s. An accelerometer K that is upper triangular is written in imu_tk's body form.
- imucal: both triads, the g-sensitivity K_ga, calibrated outputs in m/s² and deg/s, raw units as
  ``from_acc_unit``/``from_gyr_unit``.
- Kalibr: M, A and C_gyro_i (no biases: Kalibr estimates them along its trajectory), so it is written, not
  applied.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

FORMATS = ("imu_tk", "imucal", "kalibr")


def export_calibration(
    res,
    fmt: str,
    out,
    *,
    gyro_out=None,
    noise=None,
    rostopic: str | None = None,
    update_rate: float | None = None,
    option: str = "--out",
    counts_per_si: dict | None = None,
    allow_rw_bound: bool = False,
) -> list[Path]:
    """Write ``res`` in format ``fmt`` (one of :data:`FORMATS`) to ``out`` (and ``gyro_out`` for imu_tk's gyro
    file); returns the paths written. ``noise``: an AllanAnalysis for Kalibr's noise keys."""
    from optinav.multipos.convert import ImucalCalibration, to_imu_tk, write_imu_tk, write_imucal_json

    if fmt not in FORMATS:
        raise OptinavError(f"unknown export format {fmt!r}", f"use one of {', '.join(FORMATS)}")
    acc, gyro = res.accelerometer, res.gyroscope
    G = None if gyro is None else gyro.get("G")
    has_G = G is not None and np.any(np.asarray(G) != 0)
    if fmt == "imu_tk":
        if has_G:
            raise OptinavError(
                "imu_tk's model has no gyro g-sensitivity, which this calibration estimated",
                "export it to imucal or Kalibr, which keep it (optinav export RESULT.json --to imucal)",
            )
        written = []
        if gyro is None and gyro_out is not None:
            raise OptinavError(
                "--gyro-out names imu_tk's gyroscope file, and this calibration has no gyroscope",
                "drop --gyro-out (the accelerometer file is written to --out)",
            )
        if acc is not None and gyro is not None and gyro_out is None:
            raise OptinavError(
                "imu_tk keeps the gyroscope calibration in a second file", "name it with --gyro-out (e.g. gyro.calib)"
            )
        if acc is not None:
            K = np.asarray(acc["K"], float)
            body = np.allclose(np.tril(np.linalg.inv(K), -1), 0.0, atol=1e-12 * np.abs(np.linalg.inv(K)).max())
            write_imu_tk(out, to_imu_tk(K, acc["b"], form="body" if body else "general"))
            written.append(Path(out))
        elif gyro_out is None:
            gyro_out, out = out, None
        if gyro is not None:
            write_imu_tk(gyro_out, to_imu_tk(gyro["K"], gyro["b"], form="general"))
            written.append(Path(gyro_out))
        return written
    if fmt == "imucal":
        if acc is None or gyro is None:
            raise OptinavError(
                "imucal's Ferraris calibration holds both the accelerometer and the gyroscope",
                "calibrate with gyroscope data, or export the accelerometer to imu_tk (optinav export RESULT.json "
                "--to imu_tk)",
            )
        units = res.units or {}
        cal = ImucalCalibration.from_optinav(
            acc["K"],
            acc["b"],
            gyro["K"],
            G if G is not None else np.zeros((3, 3)),
            gyro["b"],
            from_acc_unit=units.get("accelerometer_raw"),
            from_gyr_unit=units.get("gyroscope_raw"),
            comment="; ".join(
                c for c in (f"exported by optinav from {res.source or 'a calibration'}", held_note(res, fmt)) if c
            ),
        )
        write_imucal_json(out, cal)
        return [Path(out)]
    from optinav.multipos.kalibr import write_kalibr_imu_yaml

    write_kalibr_imu_yaml(
        out,
        noise=noise,
        calibration=res,
        rostopic=rostopic,
        update_rate=update_rate,
        option=option,
        counts_per_si=counts_per_si,
        allow_rw_bound=allow_rw_bound,
    )
    return [Path(out)]


def held_note(res, fmt: str) -> str | None:
    """What a ``fmt`` file cannot say of ``res``: the parameters the data did not determine (held at their prior
    or initial guess under --allow-unobservable), which the file states as numbers like the estimated ones."""
    held = [n for n, p in res.parameters().items() if not p.observable and (p.reason or "").startswith("held")]
    if not held:
        return None
    return (
        f"{', '.join(held)} were not observable and are held at their prior, not estimated; the {fmt} file "
        "writes them like the estimated ones (RESULT.json keeps which): add poses (optinav design) to estimate them"
    )


def _raw_unit(sensor: str, unit) -> str | None:
    """optinav's name of imucal's free-text ``from_*_unit`` (its "a.u." is counts, as in a data file), None for
    a unit optinav does not read: imucal's "a.u." was dropped, so a gyro in rad/s under an imucal calibration of
    counts came out ~940× too small with exit 0 (probe)."""
    from optinav.io.imu import ACC_UNITS, GYRO_UNITS

    table = ACC_UNITS if sensor == "accelerometer" else GYRO_UNITS
    key = str(unit).strip() if unit else ""
    return table.get(key) or table.get(key.lower())


#: lines (not blank, not '#') beyond which a text file given as a calibration is a data log: imu_tk's parameter
#: file holds 9 (T, S, B rows) and writes blank lines between them
IMU_TK_MAX_LINES = 20


def load_calibration(path, gyro_path=None):
    """A :class:`~optinav.multipos.result.CalibrationResult` from optinav's RESULT.json, an imucal JSON or HDF5
    export or an imu_tk accelerometer parameter file (``gyro_path``: imu_tk's gyroscope file). The format is recognised
    from the content. Raw units are those the file records (imucal's ``from_*_unit``; none for imu_tk)."""
    from optinav.core.files import is_hdf5, parse_json, read_text
    from optinav.multipos.convert import from_imu_tk, read_imu_tk, read_imucal_hdf5, read_imucal_json
    from optinav.multipos.result import CalibrationResult

    if is_hdf5(path):  # imucal's to_hdf5 export read "not UTF-8 text ... saved as UTF-8" (probe)
        if gyro_path is not None:
            raise OptinavError(
                "--gyro-cal is for imu_tk's separate gyroscope file; this imucal HDF5 file holds both triads",
                "drop --gyro-cal",
            )
        return _from_imucal(read_imucal_hdf5(path), path)
    text = read_text(path, "calibration file")
    head = text.lstrip()
    if head.startswith(("{", "[")):
        data = parse_json(text, f"calibration file {path}", "pass an optinav, imucal or imu_tk calibration file")
        if gyro_path is not None:
            raise OptinavError(
                "--gyro-cal is for imu_tk's separate gyroscope file; this JSON holds both triads", "drop --gyro-cal"
            )
        if isinstance(data, dict) and "schema" in data:
            try:
                return CalibrationResult.from_json(path)
            except OptinavError as exc:
                if not exc.cause.startswith("result schema"):
                    raise
                # 'result schema X is not a optinav.multipos.calibration; pass the right result file' (probe)
                raise OptinavError(
                    f"{path} is an optinav result of {data['schema']!r}, not a calibration of optinav calibrate accel",
                    "pass the RESULT.json of calibrate accel, an imucal export or imu_tk's file (an allan result goes "
                    "with export --noise)",
                ) from None
        if isinstance(data, dict) and "K_a" in data:
            return _from_imucal(read_imucal_json(path), path)
        raise OptinavError(
            f"{path} is JSON but neither an optinav result nor an imucal export",
            "pass RESULT.json of optinav calibrate or imucal's to_json_file output",
        )
    # Kalibr's imu.yaml often opens with comment lines (its wiki's example, optinav's allan --kalibr)
    first = next((ln.strip() for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    kalibr_keys = ("%YAML", "---", "accelerometer_", "gyroscope_", "imu0:", "rostopic", "update_rate", "model:")
    if first.startswith(kalibr_keys) or "scale-misalignment" in head:
        raise OptinavError(
            f"{path} is a Kalibr file, which holds no biases (Kalibr estimates them along its "
            "trajectory), so it cannot correct raw data",
            "apply the optinav, imucal or imu_tk calibration it was exported from",
        )
    rows = sum(1 for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith("#"))
    if rows > IMU_TK_MAX_LINES:
        # a data log given as the calibration (apply's two files swapped) was told it 'holds non-numeric text;
        # pass a file written by imu_tk's CalibratedTriad::save'
        raise OptinavError(
            f"{path} holds {rows} lines: a data log, not a calibration (imu_tk's parameter file holds 9 rows of numbers)",
            "pass RESULT.json of optinav calibrate accel (run it on this log first), an imucal export or imu_tk's "
            "parameter file as the calibration — for apply before the data file",
        )
    acc = read_imu_tk(path)
    acc_K, acc_b = from_imu_tk(_imu_tk_params(acc))
    entry = {"accelerometer": {"K": acc_K, "b": acc_b}}
    if gyro_path is not None:
        gyro = read_imu_tk(gyro_path)
        if all(np.array_equal(acc[k], gyro[k]) for k in acc):
            # the gyro file given twice corrected the accelerometer with the gyro's T, S, B with exit 0 (probe)
            raise OptinavError(
                f"{path} and --gyro-cal {gyro_path} hold the same calibration: one triad's file is given for both",
                "pass imu_tk's accelerometer file as the calibration and its gyroscope file with --gyro-cal",
            )
        if imu_tk_triangular(gyro) and not imu_tk_triangular(acc):
            # a swapped pair corrected each triad with the other's T, S, B: refused as a unit mismatch in counts,
            # exit 0 with SI data of scale ≈ 1 (probe)
            raise OptinavError(
                f"{path} has six misalignments (imu_tk's gyroscope form) and {gyro_path} three (imu_tk's "
                "accelerometer form): the accelerometer and gyroscope files are given the wrong way round",
                f"pass {gyro_path} as the calibration and {path} with --gyro-cal",
            )
        g_K, g_b = from_imu_tk(_imu_tk_params(gyro))
        entry["gyroscope"] = {"K": g_K, "b": g_b}
    units = {"accelerometer": "m/s^2", "gyroscope": "rad/s", "K": "raw per SI unit", "b": "raw"}
    return CalibrationResult(
        **entry, units=units, method="imu_tk", source=" + ".join(str(p) for p in (path, gyro_path) if p is not None)
    )


def _from_imucal(cal, path):
    """The CalibrationResult of an imucal calibration read from ``path`` (raw units from its ``from_*_unit``)."""
    from optinav.multipos.result import CalibrationResult

    p = cal.to_optinav()
    units = {"accelerometer": "m/s^2", "gyroscope": "rad/s", "K": "raw per SI unit", "b": "raw"}
    for sensor, key in (("accelerometer", "from_acc_unit"), ("gyroscope", "from_gyr_unit")):
        u = _raw_unit(sensor, getattr(cal, key))
        if u:
            units[f"{sensor}_raw"] = u
    return CalibrationResult(
        accelerometer={"K": p["acc_K"], "b": p["acc_b"]},
        gyroscope={"K": p["gyr_K"], "b": p["gyr_b"], "G": p["gyr_G"]},
        units=units,
        method="imucal",
        source=str(path),
    )


def _imu_tk_params(p: dict) -> dict:
    return {k: v for k, v in p.items() if k != "form"}


def imu_tk_triangular(params: dict) -> bool:
    """Whether imu_tk parameters (of :func:`~optinav.multipos.convert.read_imu_tk`) have a triangular T, as
    imu_tk writes its accelerometer (upper; lower in a common variant); its gyroscope has all six misalignments."""
    return all(params[k] == 0 for k in ("mis_xz", "mis_xy", "mis_yx")) or all(
        params[k] == 0 for k in ("mis_yz", "mis_zy", "mis_zx")
    )


def load_export_source(path, gyro_path, fmt: str, acc_unit: str | None = None, gyro_unit: str | None = None):
    """:func:`load_calibration` for ``optinav export --to fmt``: an imu_tk file given alone is read as the
    accelerometer's, which imucal and Kalibr cannot take alone; they were told to 'calibrate with gyroscope data',
    for imu_tk's gyroscope file too (given as RESULT) and for its accelerometer file, which only lacks --gyro-cal.
    (--to imu_tk writes a file given alone back as it is.) ``acc_unit``/``gyro_unit``: the raw units the
    calibration was made from where the file does not say them (imu_tk, imucal before 2.0); refused where it does
    and differs."""
    from optinav.multipos.convert import read_imu_tk

    res = load_calibration(path, gyro_path)
    for sensor, flag, unit in (("accelerometer", "--acc-unit", acc_unit), ("gyroscope", "--gyro-unit", gyro_unit)):
        known = res.units.get(f"{sensor}_raw")
        if unit is not None and known is not None and unit != known:
            raise OptinavError(
                f"{flag} {unit} for the {sensor} calibration made from {known} (the file says so)", f"drop {flag}"
            )
        if unit is not None:
            res.units[f"{sensor}_raw"] = unit
    if res.method != "imu_tk" or gyro_path is not None or fmt not in ("imucal", "kalibr"):
        return res
    if not imu_tk_triangular(read_imu_tk(path)):
        raise OptinavError(
            f"{Path(path).name} has six misalignments (imu_tk's gyroscope form; imu_tk writes the accelerometer's "
            f"three), and {fmt} needs both triads",
            "pass imu_tk's accelerometer file as RESULT and this one with --gyro-cal (an accelerometer file with six "
            "misalignments: add its gyroscope file with --gyro-cal)",
        )
    raise OptinavError(
        f"{Path(path).name} is imu_tk's accelerometer file alone, and {fmt} needs the gyroscope's calibration too",
        "add imu_tk's gyroscope file with --gyro-cal, or export to imu_tk",
    )


def check_imu_tk_alone(path, data_path) -> None:
    """Refuse an imu_tk file with six misalignments (imu_tk's gyroscope form) given alone, without --gyro-cal,
    for data that hold a gyroscope: taken as the accelerometer calibration, imu_tk's gyroscope file corrected
    the accelerometer with the gyro's T, S, B, and SI data of scale ≈ 1 gave |a| ≈ g with exit 0 (probe)."""
    from optinav.multipos.convert import read_imu_tk

    if not imu_tk_triangular(read_imu_tk(path)):
        raise OptinavError(
            f"{Path(path).name} has six misalignments (imu_tk's gyroscope form; imu_tk writes the accelerometer's "
            f"three) and no --gyro-cal was given, while {Path(data_path).name} holds a gyroscope",
            "pass imu_tk's accelerometer file as the calibration and this one with --gyro-cal (an accelerometer "
            "file with six misalignments: add its gyroscope file with --gyro-cal)",
        )
