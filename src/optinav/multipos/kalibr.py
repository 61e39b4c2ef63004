"""Kalibr's IMU YAML: the noise keys of ``imu.yaml`` and the intrinsics of its ``scale-misalignment`` model.

Kalibr (Rehder et al., ICRA 2016, "Extending kalibr") models the IMU in its own frame i::

    a_meas = M_a · a_i + b_a                                  M_a lower triangular
    ω_meas = M_g · C_gyro_i · ω_i + A · C_gyro_i · a_i + b_g     M_g lower triangular, C_gyro_i a rotation

with measurements in SI (sensor_msgs/Imu: m/s², rad/s) and biases estimated along the trajectory (not stored);
the error terms of Kalibr's ``IccScaledMisalignedImu`` (``IccSensors.py``) are these equations, with M_accel and
M_gyro lower triangular and A full, written as the rotation matrix C_gyro_i and the lists M and A.
optinav's ``raw = K x + b`` (x in the sensor frame s, raw in the file's unit of SI factor f) maps to it by the
LQ factorization f·K_a = M_a·C_i_s: Kalibr's frame i is the accelerometer's lower-triangular frame, rotated by
C_i_s from optinav's; then f_g·K_g·C_i_sᵀ = M_g·C_gyro_i and A = f_g·G·C_i_sᵀ·C_gyro_iᵀ. C_i_s is written as a
comment-free extra key ``C_i_s`` (Kalibr ignores unknown keys) so that reading the file back recovers optinav's
frame. Raw counts need the driver's counts per SI unit (f = its inverse: Kalibr reads m/s² and rad/s, M is
relative to the driver's nominal conversion); the export refuses counts without it.

Noise (Kalibr's continuous-time convention): ``*_noise_density`` = white-noise coefficient N (m/s²/√Hz,
rad/s/√Hz), ``*_random_walk`` = random-walk coefficient K (m/s³/√Hz, rad/s²/√Hz), ``update_rate`` in Hz.
The YAML is written as plain text and read with PyYAML's ``safe_load`` only.
"""

from __future__ import annotations

import math

import numpy as np

from optinav.core.allan import KALIBR_UNITS
from optinav.core.files import read_text, write_text
from optinav.errors import OptinavError

NOISE_KEYS = (
    "accelerometer_noise_density",
    "accelerometer_random_walk",
    "gyroscope_noise_density",
    "gyroscope_random_walk",
)


#: the largest noise value (SI: m/s²/√Hz, m/s³/√Hz, rad/s/√Hz, rad/s²/√Hz) any IMU has, by orders of magnitude
#: (consumer MEMS: about 2e-3 and 3e-3 for the accelerometer, 2e-4 and 2e-5 for the gyro)
NOISE_MAX = 1.0


def lq(K: np.ndarray, sensor: str = "") -> tuple[np.ndarray, np.ndarray]:
    """K = L·Q with L lower triangular of positive diagonal and Q a rotation (det K > 0 needed; ``sensor`` named in
    the refusal)."""
    K = np.asarray(K, float)
    if not np.all(np.isfinite(K)) or np.linalg.det(K) <= 0:
        negative = sensor == "gyroscope" and bool(np.all(np.diag(K) < 0))
        raise OptinavError(
            f"the {sensor + ' ' if sensor else ''}calibration matrix has det(K) <= 0 (a mirrored or singular axis set"
            + ("; every scale negative: made with the rotations' sense opposite to the turns'" if negative else "")
            + ")",
            "Kalibr's model needs a right-handed sensor: check the axis signs of the calibration"
            + (" (imucal's Ferraris: expected_angle 360 for turns of +360°)" if negative else ""),
        )
    Qt, Rt = np.linalg.qr(K.T)
    s = np.sign(np.diag(Rt))
    L, Q = (Rt * s[:, None]).T, (Qt * s[None, :]).T
    return L, Q


def _matrix(name: str, M, indent: str = "  ") -> list[str]:
    return [f"{indent}{name}:"] + [f"{indent}  - [{', '.join(f'{v:.17g}' for v in row)}]" for row in np.asarray(M)]


def _num(v: float) -> str:
    if not math.isfinite(v):
        raise OptinavError(f"a Kalibr value is not finite ({v!r})", "check the noise or calibration input")
    return f"{v:.17g}"


def counts_per_si(acc_lsb: float | None = None, gyro_lsb: float | None = None) -> dict | None:
    """The driver's counts per SI unit from datasheet sensitivities: ``acc_lsb`` LSB per g → counts per m/s²,
    ``gyro_lsb`` LSB per deg/s → counts per rad/s; None when neither is given."""
    from optinav.core.units import DEG, G_STANDARD

    out = {}
    if acc_lsb:
        out["accelerometer"] = float(acc_lsb) / G_STANDARD
    if gyro_lsb:
        out["gyroscope"] = float(gyro_lsb) / DEG
    return out or None


def kalibr_intrinsics(cal, counts_per_si: dict | None = None) -> dict:
    """Kalibr's scale-misalignment matrices of a :class:`~optinav.multipos.result.CalibrationResult` (both
    triads needed): ``{"M_accel", "M_gyro", "A", "C_gyro_i", "C_i_s"}``. A triad calibrated in raw counts needs
    the counts per SI unit its driver divides by (``counts_per_si`` {"accelerometer": counts per m/s²,
    "gyroscope": counts per rad/s}): Kalibr reads sensor_msgs/Imu in m/s² and rad/s, so its M is relative to
    the driver's nominal conversion."""
    from optinav.core.units import factor

    if cal.accelerometer is None or cal.gyroscope is None:
        raise OptinavError(
            "Kalibr's scale-misalignment model needs both the accelerometer and the gyroscope calibration",
            "calibrate with gyroscope data (turns between the poses)",
        )
    cps = counts_per_si or {}
    for sensor, flag in (("accelerometer", "--acc-lsb"), ("gyroscope", "--gyro-lsb")):
        unit = cal.units.get(f"{sensor}_raw")
        if cps.get(sensor) and unit not in (None, "counts"):
            # a sensitivity for a calibration of physical units was taken without a word and not used (probe)
            raise OptinavError(
                f"{flag} gives the driver's counts, and the {sensor} calibration is of {unit}, not raw counts",
                f"drop {flag} (Kalibr's M is then relative to {unit} converted to SI)",
            )
    f_a = _factor(cal.units.get("accelerometer_raw"), factor, cps.get("accelerometer"), "accelerometer", "--acc-lsb")
    f_g = _factor(cal.units.get("gyroscope_raw"), factor, cps.get("gyroscope"), "gyroscope", "--gyro-lsb")
    M_a, C_i_s = lq(f_a * cal.accelerometer["K"], "accelerometer")
    M_g, C_gyro_i = lq(f_g * cal.gyroscope["K"] @ C_i_s.T, "gyroscope")
    G = cal.gyroscope.get("G")
    G = np.zeros((3, 3)) if G is None else np.asarray(G, float)
    A = f_g * G @ C_i_s.T @ C_gyro_i.T
    from optinav.core.units import DEG, G_STANDARD
    from optinav.multipos.gates import SCALE_FACTOR

    for sensor, M, flag, per in (
        ("accelerometer", M_a, "--acc-lsb", 1.0 / G_STANDARD),
        ("gyroscope", M_g, "--gyro-lsb", DEG),
    ):
        d = float(np.median(np.diag(M)))
        if cps.get(sensor) and not (1.0 / SCALE_FACTOR <= d <= SCALE_FACTOR):
            # a sensitivity for another range setting gave M ≈ 0.5 or 0.125 with exit 0
            implied = d * float(cps[sensor]) / per  # the LSB per g (per deg/s) the calibration implies
            raise OptinavError(
                f"with {flag} {float(cps[sensor]) / per:.6g} Kalibr's {sensor} M is {d:.3g} on its diagonal (≈ 1 for "
                f"the driver's sensitivity): the calibration implies about {implied:.4g} LSB per "
                f"{'g' if sensor == 'accelerometer' else 'deg/s'}",
                f"give {flag} for the range setting the unit was calibrated at",
            )
    return {"M_accel": M_a, "M_gyro": M_g, "A": A, "C_gyro_i": C_gyro_i, "C_i_s": C_i_s}


def _factor(unit, factor, counts_per_si=None, sensor: str = "", flag: str = "") -> float:
    """SI units per raw unit: a physical unit's factor; raw counts 1 / the driver's counts per SI unit (refused
    without it when ``flag`` names the option; 1 when reading back a file written before it was recorded)."""
    if unit is None and flag:
        # imu_tk's files and imucal's before 2.0 do not say what K maps from: taken as SI, a counts calibration's M
        # came out 208 and 965 on its diagonal (Kalibr then reads g as 0.047 m/s²) with exit 0
        raise _unstated(sensor, "--acc-unit" if sensor == "accelerometer" else "--gyro-unit")
    if unit is None:
        return 1.0
    if unit != "counts":
        return float(factor(unit))
    if counts_per_si:
        return 1.0 / float(counts_per_si)
    if flag:
        # Kalibr's M is dimensionless against data in m/s² and rad/s: counts per SI unit (M ≈ 208, 937) would be
        # misread with exit 0
        raise OptinavError(
            f"the {sensor} calibration is of raw counts, and Kalibr reads m/s^2 and rad/s (sensor_msgs/Imu): its M "
            "is relative to the driver's conversion",
            f"give the driver's sensitivity ({flag} LSB per {'g' if sensor == 'accelerometer' else 'deg/s'}), or "
            "export --to imu_tk or imucal, which take raw counts",
        )
    return 1.0


def _unstated(sensor: str, flag: str) -> OptinavError:
    """The refusal of a Kalibr export of a ``sensor`` calibration that records no raw unit (``flag`` states it)."""
    return OptinavError(
        f"the {sensor} calibration does not say the raw unit it was made from (imu_tk's files and imucal's before "
        "2.0 do not), and Kalibr's M is relative to SI units",
        f"state it with {flag} (counts: with {'--acc-lsb' if sensor == 'accelerometer' else '--gyro-lsb'} too)",
    )


#: 1/s: the largest random-walk bound Kalibr gets per unit of its white noise (K_bound / N). A typical MEMS has
#: K / N of about 0.1/s (EuRoC's ADIS16448 gyro 0.11/s; 0.02-0.15/s for consumer parts), and Kalibr users inflate
#: K by up to 10×; a bound above that says nothing a datasheet does not. On simulated white-noise logs the bound of
#: the largest axis is 25·N/T in the median (12-50·N/T, T the log's span; 55·N/T at 2 s), so this holds from
#: about a minute at rest: 2 s gave 53/s (2500× the truth), 10 s 10/s, 60 s 0.46/s, 5 min 0.094/s
RW_BOUND_MAX = 1.0

#: the flag that writes a random-walk bound above :data:`RW_BOUND_MAX` anyway
RW_BOUND_FLAG = "--allow-rw-bound"

_RW_UNITS = {sensor: units[1] for sensor, units in KALIBR_UNITS.items()}


def _span(seconds: float) -> str:
    return (
        f"{seconds:.3g} s"
        if seconds < 120
        else f"{seconds / 60:.3g} min"
        if seconds < 7200
        else f"{seconds / 3600:.3g} h"
    )


def random_walk_bounds(noise, *, allow: bool = False) -> list[str]:
    """The notes naming each Kalibr random walk of ``noise`` (an AllanAnalysis) that is only an upper bound (no
    random walk seen in the log); a bound above :data:`RW_BOUND_MAX` times the noise density is refused unless
    ``allow``. A result that does not say whether its random walk was seen (written before it was recorded)
    gets no note."""
    kal = noise.kalibr or {}
    span = float(getattr(noise, "duration_s", float("nan")))
    bounds = []  # (K / N, sensor, K)
    for sensor in _RW_UNITS:
        K, N = kal.get(f"{sensor}_random_walk"), kal.get(f"{sensor}_noise_density")
        if kal.get(f"{sensor}_random_walk_detected") is False and K is not None and N:
            bounds.append((K / N, sensor, K))
    worst = max(bounds, default=None)
    if worst is not None and worst[0] > RW_BOUND_MAX and not allow:
        ratio, sensor, K = worst
        # the bound falls as 1/T: the span that brings it to the limit, with a fifth to spare, at least a minute
        need = max(60.0, 1.2 * span * ratio / RW_BOUND_MAX) if math.isfinite(span) else 60.0
        raise OptinavError(
            f"no {sensor} random walk shows in this {_span(span)} log, and the bound it gives Kalibr, "
            f"{K:.3g} {_RW_UNITS[sensor]}, is {ratio:.3g}/s times the noise density (a MEMS's random walk is about "
            f"0.1/s times it; a bound above {RW_BOUND_MAX:g}/s says nothing)",
            f"record at least {math.ceil(need / 60):d} min at rest (the bound falls as 1/T; hours to measure it), "
            f"or pass {RW_BOUND_FLAG} to write the bound anyway",
        )
    return [
        f"Kalibr's {sensor}_random_walk {K:.3g} {_RW_UNITS[sensor]} is an upper bound, not a measurement: no random "
        f"walk shows in this {_span(span)} log ({ratio:.3g}/s times the noise density; a MEMS's is about 0.1/s times it)"
        for ratio, sensor, K in bounds
    ]


#: the topic written into a Kalibr IMU file when none is known (Kalibr requires the key; its examples' name)
DEFAULT_ROSTOPIC = "/imu0"
#: what the commands say when they wrote :data:`DEFAULT_ROSTOPIC`
DEFAULT_ROSTOPIC_NOTE = f"rostopic {DEFAULT_ROSTOPIC} written (Kalibr requires one); --rostopic names yours"


def write_kalibr_imu_yaml(
    path,
    *,
    noise=None,
    calibration=None,
    rostopic: str | None = None,
    update_rate: float | None = None,
    option: str = "--out",
    counts_per_si: dict | None = None,
    allow_rw_bound: bool = False,
) -> None:
    """Write Kalibr's IMU YAML: the noise keys from ``noise`` (an :class:`~optinav.core.allan.AllanAnalysis` of SI
    data with both triads), ``rostopic``/``update_rate`` (from ``noise`` unless given) and, with ``calibration``,
    ``model: scale-misalignment`` and its matrices. Refuses a file with neither. With ``noise`` the file is a
    Kalibr input (``kalibr_calibrate_imu_camera --imu``): every key Kalibr requires, the topic
    :data:`DEFAULT_ROSTOPIC` unless given or in ``noise``. A random walk that is only an upper bound says so on
    its line, and one above :data:`RW_BOUND_MAX` times the noise density is refused unless ``allow_rw_bound``."""
    if noise is None and calibration is None:
        raise OptinavError("nothing to write into the Kalibr file", "give an allan result or a calibration")
    # no "%YAML:1.0" line (OpenCV's, as imu_utils writes): Kalibr reads the file with yaml.safe_load, which
    # refuses that directive
    head = ["# Kalibr IMU configuration written by optinav"]
    body = []
    rate = update_rate
    if noise is not None:
        kal = dict(noise.kalibr or {})
        missing = [k for k in NOISE_KEYS if kal.get(k) is None]
        if missing:
            raise OptinavError(
                f"the allan result has no {', '.join(missing)} (Kalibr needs both triads in SI units)",
                "run optinav allan on a log with accelerometer and gyroscope in SI units "
                "(calibrate and apply raw counts first)",
            )
        units = {
            f"{sensor}_{kind}": unit
            for sensor, pair in KALIBR_UNITS.items()
            for kind, unit in zip(("noise_density", "random_walk"), pair)
        }
        head.append(
            "# noise: continuous-time white-noise density N and random walk K of the five-term Allan fit (a rate ramp "
            "kept out of K), largest axis; K is the fitted value where every axis shows a random walk, else the "
            "largest upper end of the axes' 68 % intervals (a bound, said on its line)"
        )
        for k in NOISE_KEYS:
            v = kal[k]
            if not (isinstance(v, (int, float)) and 0.0 <= v <= NOISE_MAX and (v > 0.0 or "random_walk" in k)):
                # 1e300 in an Allan file was written into the yaml as it stood, exit 0 (probe)
                raise OptinavError(
                    f"the allan result's {k} is {v!r} {units[k]}: no IMU's (a density is > 0, and none is above "
                    f"{NOISE_MAX:g} in SI units)",
                    "run optinav allan again on the sensor's static log, or check the file",
                )
            bound = k.endswith("_random_walk") and kal.get(f"{k}_detected") is False
            # a bound read as a measured K was taken for the sensor's drift (2500× the truth from a 2-s log)
            why = "  upper bound: no random walk shows in the log (68 % interval's upper end)" if bound else ""
            body.append(f"{k}: {_num(v)}  # [{units[k]}]{why}")
        random_walk_bounds(noise, allow=allow_rw_bound)  # (after each value is one an IMU can have)
        if rate is None:
            rate = kal.get("update_rate")
        # Kalibr's IMU parameters require a topic: its examples' name unless one is known
        rostopic = rostopic or noise.rostopic or DEFAULT_ROSTOPIC
    if rostopic:
        if any(c in rostopic for c in "\n\r#:'\"{}[],&*!|>%@`") or not rostopic.strip():
            raise OptinavError(f"the topic {rostopic!r} is not a plain ROS name", "use a name like /imu0")
        body.append(f"rostopic: {rostopic}")
    if rate is not None:
        # to 6 digits: a rate from epoch time stamps (1.7e9 s) came out 99.999999999205272 for 100 Hz
        body.append(f"update_rate: {float(_num(float(rate))):.6g}  # [Hz]")
    if calibration is not None:
        m = kalibr_intrinsics(calibration, counts_per_si)
        body.append("model: scale-misalignment")
        body.append("accelerometers:")
        body += _matrix("M", m["M_accel"])
        body.append("gyroscopes:")
        body += _matrix("M", m["M_gyro"])
        body += _matrix("A", m["A"])
        body += _matrix("C_gyro_i", m["C_gyro_i"])
        body.append("# optinav: rotation from optinav's sensor frame s to Kalibr's frame i (a_i = C_i_s a_s)")
        body += _matrix("C_i_s", m["C_i_s"], indent="")
        body.append(
            "# optinav: raw units of the calibration (counts: the driver's counts per SI unit, M relative to it)"
        )
        units = {
            "accelerometer_raw": calibration.units.get("accelerometer_raw", "m/s^2"),
            "gyroscope_raw": calibration.units.get("gyroscope_raw", "rad/s"),
        }
        for sensor, n in (counts_per_si or {}).items():
            if units.get(f"{sensor}_raw") == "counts" and n:
                units[f"{sensor}_counts_per_si"] = _num(float(n))
        body.append("optinav_units: {" + ", ".join(f"{k}: {v}" for k, v in units.items()) + "}")
    write_text(path, "\n".join(head + body) + "\n", option)


def read_kalibr_imu_yaml(path) -> dict:
    """Kalibr's IMU YAML as a dict (PyYAML ``safe_load``; a leading ``%YAML:1.0`` line is OpenCV's and skipped).
    A Kalibr results file with ``imu0:`` … at the top is unwrapped to its first IMU."""
    try:
        import yaml
    except ImportError:
        raise OptinavError("reading Kalibr YAML needs PyYAML", "pip install 'optinav[kalibr]'") from None
    text = read_text(path, "Kalibr file")
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML:"):
        lines = lines[1:]
    try:
        data = yaml.safe_load("\n".join(lines))
    except yaml.YAMLError as exc:
        raise OptinavError(
            f"{path} is not valid YAML ({' '.join(str(exc).split())[:80]})", "pass a Kalibr imu.yaml"
        ) from None
    if (
        isinstance(data, dict)
        and len(data) >= 1
        and all(str(k).startswith("imu") for k in data)
        and isinstance(next(iter(data.values())), dict)
    ):
        data = next(iter(data.values()))
    if not isinstance(data, dict):
        raise OptinavError(f"{path} is not a Kalibr IMU file (no key: value mapping)", "pass a Kalibr imu.yaml")
    return data


def calibration_from_kalibr(data: dict) -> dict:
    """optinav's ``{"acc_K", "gyr_K", "gyr_G"}`` (raw per SI in ``optinav_units``, or SI for Kalibr's own files)
    from a scale-misalignment file; biases are not part of Kalibr's file (it estimates them along the
    trajectory). Uses ``C_i_s`` when present (files optinav wrote), else Kalibr's frame i."""
    from optinav.core.units import factor

    if data.get("model") != "scale-misalignment":
        raise OptinavError(
            f"the Kalibr file's model is {data.get('model')!r}, not 'scale-misalignment'",
            "pass the imu yaml of a kalibr --imu-models scale-misalignment run",
        )
    try:
        M_a = np.asarray(data["accelerometers"]["M"], float).reshape(3, 3)
        M_g = np.asarray(data["gyroscopes"]["M"], float).reshape(3, 3)
        A = np.asarray(data["gyroscopes"]["A"], float).reshape(3, 3)
        C = np.asarray(data["gyroscopes"]["C_gyro_i"], float).reshape(3, 3)
        C_i_s = np.asarray(data.get("C_i_s", np.eye(3)), float).reshape(3, 3)
    except (KeyError, TypeError, ValueError):
        raise OptinavError(
            "the Kalibr file lacks accelerometers.M or gyroscopes.M/A/C_gyro_i as 3×3 matrices",
            "pass a complete scale-misalignment imu yaml",
        ) from None
    units = data.get("optinav_units") or {}
    f_a = _factor(units.get("accelerometer_raw", "m/s^2"), factor, units.get("accelerometer_counts_per_si"))
    f_g = _factor(units.get("gyroscope_raw", "rad/s"), factor, units.get("gyroscope_counts_per_si"))
    return {
        "acc_K": M_a @ C_i_s / f_a,
        "gyr_K": M_g @ C @ C_i_s / f_g,
        "gyr_G": A @ C @ C_i_s / f_g,
        "units": {
            "accelerometer_raw": units.get("accelerometer_raw", "m/s^2"),
            "gyroscope_raw": units.get("gyroscope_raw", "rad/s"),
        },
    }
