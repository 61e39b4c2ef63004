"""The calibration result file (RESULT.json) and applying it to new raw data.

Layout (``schema`` "optinav.calibration", ``version`` 1; documented in docs/file-formats.md)::

    {"schema": "optinav.calibration", "version": 1, "optinav_version": "...",
     "model": "raw = K x + b",
     "units": {"accelerometer_raw": "counts", "accelerometer": "m/s^2", "gyroscope_raw": "deg/s",
               "gyroscope": "rad/s", "time": "s", ...},
     "accelerometer": {"K": 3×3, "b": [3], "K_std": 3×3, "b_std": [3], "form": "upper-triangular",
                       "estimated": [...], "held": [...]},
     "gyroscope": {"K": 3×3, "b": [3], "K_std", "b_std", "G": 3×3 or null, "G_std": 3×3 (ferraris), ...} or null,
     "gravity": 9.80..., "residual_rms": ..., "static_intervals": [[t0, t1], ...],
     "observability": {"rank", "n_params", "singular_values", "unobservable", "statements"},
     "method": "lm", "elapsed_s": ..., "excluded": {"nan_rows": n, "saturated": n}, "quality": {...}}

``K`` is in raw units per SI unit (raw per m/s², raw per rad/s), ``b`` in raw units; the corrected values are
``a = K⁻¹(raw − b)`` and ``ω = K_g⁻¹(raw_g − G·a − b_g)`` (G, the gyro g-sensitivity in raw per m/s², only from
the Ferraris method). Standard deviations are NaN for parameters that were held (not estimated).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import field

import numpy as np

from optinav.core.results import (
    Array,
    Entries,
    Estimate,
    InvalidResult,
    Parameter,
    Truth,
    flat_kwargs,
    nested_array,
    nested_strings,
    register_legacy,
    register_truth_legacy,
)
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

MODEL = "raw = K x + b"


#: a triad entry's arrays: key → shape (K, b required; the rest optional, G also null)
_TRIAD_ARRAYS = {"K": (3, 3), "b": (3,), "K_std": (3, 3), "b_std": (3,), "G": (3, 3), "G_std": (3, 3)}


def _triad(d: dict | None, name: str) -> dict | None:
    """A triad entry (``accelerometer``/``gyroscope``) checked key by key: the arrays' kinds and shapes, the names
    lists, the form; a damaged value raises :class:`~optinav.core.results.InvalidResult` naming e.g.
    ``'accelerometer.K_std'``."""
    if d is None:
        return None
    if not isinstance(d, dict) or "K" not in d or "b" not in d:
        raise InvalidResult(f"field {name!r} has no K and b")
    out = dict(d)
    for key, shape in _TRIAD_ARRAYS.items():
        if key in ("K", "b") or (key in d and not (key == "G" and d[key] is None)):
            out[key] = nested_array(d[key], f"{name}.{key}", shape, finite=key in ("K", "b"))
    if d.get("crlb_std") is not None:
        out["crlb_std"] = nested_array(d["crlb_std"], f"{name}.crlb_std", (None,))
    for key in ("estimated", "held", "unobservable"):
        if key in d:
            out[key] = nested_strings(d[key], f"{name}.{key}")
    if d.get("form", "full") not in ("full", "upper-triangular"):
        raise InvalidResult(f"field '{name}.form' is {d['form']!r}, expected 'full' or 'upper-triangular'")
    with np.errstate(over="ignore"):  # a huge K (a damaged file) overflows to inf: not singular; apply judges it
        det = np.linalg.det(out["K"])
    if abs(det) < 1e-300:
        raise OptinavError(f"the {name} matrix K is singular", "the result file is corrupt; re-run the calibration")
    return out


#: what a calibration's ``quality`` holds (the LM fit's, the Ferraris method's, ``--hold-out``'s), checked key by key
#: when a file is loaded; a held-out pose's numbers went into the summary's formats (a TypeError when damaged)
QUALITY = Entries(
    optional={
        "n_poses": "count",
        "pose_residual_rms": "number?",
        "chi2": "number?",
        "dof": "number?",
        "interval_selection": "text",
        "gravity_source": "text",
        "optimizer_success": "bool",
        "optimizer_message": "text",
        "nfev": "count?",
        "data": "text",
        "notes": "names",
        "sections": "names",
        "rotation_angle_deg": Array((None,)),
        "pose_turn_factor": "number?",
        "pose_turn_factor_std": "number?",
        "threshold_selection": Entries(
            optional={
                "rule": "text",
                "thresholds": Array((None,)),
                "n_intervals": Array((None,)),
                "reduced_chi2": Array((None,)),
                "chosen": "count",
                "threshold": "number?",
            }
        ),
        "held_out": Entries(
            required={
                "pose": "count",
                "t0_s": "number",
                "t1_s": "number",
                "norm_error_m_s2": "number",
                "n_used": "count",
                "rms_used_m_s2": "number",
            }
        ),
    }
)


@dataclasses.dataclass
class CalibrationResult(Estimate):
    """A triad calibration as written to RESULT.json (see the module docstring and docs/results.md).

    :meth:`parameters` names the elements ``acc_K_xx`` … ``acc_K_zz``, ``acc_b_x`` … (and ``gyr_K_*``,
    ``gyr_b_*``, ``gyr_G_*`` with a gyroscope): K in raw units per SI unit, b in raw units."""

    SCHEMA = "optinav.multipos.calibration"
    VERSION = 3
    SYSTEM = "multipos"
    KIND = "calibration"
    ENTRIES = {**Estimate.ENTRIES, "quality": QUALITY}

    accelerometer: dict | None = field(default=None, metadata={"unit": "raw per m/s^2 | raw"})
    gyroscope: dict | None = field(default=None, metadata={"unit": "raw per rad/s | raw"})
    units: dict = field(default_factory=dict, metadata={"unit": "-"})
    gravity: float = field(default=float("nan"), metadata={"unit": "m/s^2"})
    residual_rms: float = field(default=float("nan"), metadata={"unit": "m/s^2"})
    static_intervals: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), metadata={"unit": "s"})
    observability: dict = field(default_factory=dict, metadata={"unit": "-"})
    method: str = field(default="", metadata={"unit": "-"})
    elapsed_s: float = field(default=0.0, metadata={"unit": "s"})
    excluded: dict = field(default_factory=dict, metadata={"unit": "-"})
    quality: dict = field(default_factory=dict, metadata={"unit": "-"})
    source: str = field(default="", metadata={"unit": "-"})
    convergence: dict = field(default_factory=dict, metadata={"unit": "-"})
    gates: list = field(default_factory=list, metadata={"unit": "-"})

    def parameters(self) -> dict[str, Parameter]:
        out: dict[str, Parameter] = {}
        if self.accelerometer is not None:
            out.update(
                _triad_parameters("acc", self.accelerometer, self.units.get("accelerometer_raw") or "raw", "m/s^2")
            )
        if self.gyroscope is not None:
            out.update(
                _triad_parameters(
                    "gyr", self.gyroscope, self.units.get("gyroscope_raw") or "raw", "rad/s", acc_unit="m/s^2"
                )
            )
        return out

    def __post_init__(self):
        self.accelerometer = _triad(self.accelerometer, "accelerometer")
        self.gyroscope = _triad(self.gyroscope, "gyroscope")
        self.static_intervals = np.asarray(self.static_intervals, float).reshape(-1, 2)
        for k, v in self.units.items():
            if not isinstance(v, str):
                raise InvalidResult(f"field 'units.{k}' is not text")
        for sensor in ("", "accelerometer.", "gyroscope."):
            o = self.observability.get(sensor[:-1]) if sensor else self.observability
            if isinstance(o, dict) and o.get("unobservable") is not None:
                o["unobservable"] = nested_strings(o["unobservable"], f"observability.{sensor}unobservable")
        if self.accelerometer is None and self.gyroscope is None:
            raise OptinavError(
                "the calibration result has neither an accelerometer nor a gyroscope",
                "pass a result file written by `optinav calibrate`",
            )

    def correct_accel(self, raw) -> np.ndarray:
        """Corrected specific force a = K⁻¹(raw − b).

        Parameters
        ----------
        raw : (N, 3) array
            Accelerometer output [the calibrated input unit].

        Returns
        -------
        (N, 3) ndarray
            Specific force [m/s^2], body axes.
        """
        if self.accelerometer is None:
            raise OptinavError("this result has no accelerometer calibration", "calibrate the accelerometer first")
        raw = as_float_array(raw, "accelerometer data", last_dims=(3,), finite=False)
        K, b = self.accelerometer["K"], self.accelerometer["b"]
        return np.linalg.solve(K, (raw - b).T).T

    def correct_gyro(self, raw, acc=None) -> np.ndarray:
        """Corrected angular rate ω = K_g⁻¹(raw − G·a − b_g).

        Parameters
        ----------
        raw : (N, 3) array
            Gyroscope output [the calibrated input unit].
        acc : (N, 3) array or None
            Corrected specific force [m/s^2] for the g-sensitivity G (required when G ≠ 0).

        Returns
        -------
        (N, 3) ndarray
            Angular rate [rad/s], body axes.
        """
        if self.gyroscope is None:
            raise OptinavError("this result has no gyroscope calibration", "calibrate with gyroscope data")
        raw = as_float_array(raw, "gyroscope data", last_dims=(3,), finite=False)
        K, b = self.gyroscope["K"], self.gyroscope["b"]
        v = raw - b
        G = self.gyroscope.get("G")
        if G is not None and np.any(np.asarray(G) != 0):
            if acc is None:
                raise OptinavError(
                    "the gyroscope calibration has a g-sensitivity term but no accelerometer data was given",
                    "pass the accelerometer data too",
                )
            v = v - np.asarray(acc, float) @ np.asarray(G, float).T
        return np.linalg.solve(K, v.T).T

    def summary(self) -> str:
        """A human-readable report of the calibration.

        Returns
        -------
        str
            The report.
        """
        lines = [f"optinav calibration ({self.method})"]
        for name, d, unit in (("accelerometer", self.accelerometer, "m/s^2"), ("gyroscope", self.gyroscope, "rad/s")):
            if d is None:
                continue
            raw_unit = self.units.get(f"{name}_raw", "raw")
            lines.append(f"{name}: raw = K·x + b  (x in {unit}, raw in {raw_unit})")
            K, b = d["K"], d["b"]
            Ks = d.get("K_std", np.full((3, 3), np.nan))
            bs = d.get("b_std", np.full(3, np.nan))
            for i in range(3):
                row = "  ".join(
                    f"{K[i, j]: .6g}" + (f" ±{Ks[i, j]:.2g}" if np.isfinite(Ks[i, j]) else "") for j in range(3)
                )
                lines.append(f"  K[{'xyz'[i]}] = {row}")
            lines.append(
                "  b = "
                + "  ".join(f"{b[i]: .6g}" + (f" ±{bs[i]:.2g}" if np.isfinite(bs[i]) else "") for i in range(3))
            )
            if d.get("held"):
                lines.append(f"  held (not observable from these poses): {', '.join(d['held'])}")
        if math.isfinite(self.residual_rms):
            lines.append(f"residual rms of |a| - g over static samples: {self.residual_rms:.4g} m/s^2")
        if len(self.static_intervals):
            lines.append(f"static intervals used: {len(self.static_intervals)}")
        held = self.quality.get("held_out")
        if held:
            lines.append(
                f"held-out pose {held['pose']} ({held['t0_s']:g}-{held['t1_s']:g} s): |a| - g = "
                f"{held['norm_error_m_s2']:+.2e} m/s^2; the {held['n_used']} poses used: rms "
                f"{held['rms_used_m_s2']:.2e} m/s^2"
            )
        for s in self.observability.get("unobservable", []) or []:
            lines.append(f"unobservable: {s}")
        return "\n".join(lines)


_AX = "xyz"
#: the accelerometer's ``crlb_std`` order (:data:`optinav.multipos.model.ACCEL_PARAMS`)
_ACC_CRLB = ("K_xx", "K_yy", "K_zz", "K_xy", "K_xz", "K_yz", "b_x", "b_y", "b_z")
_GAUGE = (
    "fixed at 0 by the upper-triangular form: norm observations cannot see a rotation of the triad "
    "(the sensor z axis and y-z plane are the reference)"
)


def _std(a, i, j=None):
    if a is None:
        return None
    v = float(np.asarray(a, float)[i] if j is None else np.asarray(a, float)[i, j])
    return v if math.isfinite(v) else None


def _triad_parameters(prefix: str, d: dict, raw: str, si: str, acc_unit: str | None = None) -> dict:
    """The K, b (and G) elements of one triad entry as :class:`Parameter` (names ``{prefix}_K_xy`` …)."""
    form = d.get("form", "full")
    held = set(d.get("held") or [])
    crlb = d.get("crlb_std")
    crlb = dict(zip(_ACC_CRLB, np.asarray(crlb, float))) if crlb is not None and len(crlb) == 9 else {}
    unobs = [str(u) for u in d.get("unobservable") or []]
    out = {}

    def entry(short, value, std, unit):
        name = f"{prefix}_{short}"
        c = crlb.get(short)
        c = float(c) if c is not None and math.isfinite(c) else None
        if short in held:
            return name, Parameter(
                None,
                unit,
                reason="held at 0: the poses cannot determine it (diagonal model; "
                "its 1σ model error enters the scale and bias std)",
                observable=False,
            )
        which = [u for u in unobs if short in u.replace("(", " ").replace(")", " ").split()]
        if which:
            return name, Parameter(
                None,
                unit,
                observable=False,
                reason="held at the initial guess, not determined by the turns: " + "; ".join(which),
            )
        return name, Parameter(float(value), unit, std=std, crlb_std=c)

    K, Ks = np.asarray(d["K"], float), d.get("K_std")
    for i in range(3):
        for j in range(3):
            short = f"K_{_AX[i]}{_AX[j]}"
            if form == "upper-triangular" and i > j:
                out[f"{prefix}_{short}"] = Parameter(None, f"{raw} per {si}", observable=False, reason=_GAUGE)
                continue
            n, p = entry(short, K[i, j], _std(Ks, i, j), f"{raw} per {si}")
            out[n] = p
    b, bs = np.asarray(d["b"], float), d.get("b_std")
    for i in range(3):
        n, p = entry(f"b_{_AX[i]}", b[i], _std(bs, i), raw)
        out[n] = p
    if d.get("G") is not None:
        G, Gs = np.asarray(d["G"], float), d.get("G_std")
        for i in range(3):
            for j in range(3):
                out[f"{prefix}_G_{_AX[i]}{_AX[j]}"] = Parameter(
                    float(G[i, j]), f"{raw} per {acc_unit}", std=_std(Gs, i, j)
                )
    return out


def _legacy_v1(data: dict) -> dict:
    """RESULT.json of optinav ≤ 0.x (schema "optinav.calibration" version 1, flat)."""
    kw = flat_kwargs(CalibrationResult, data)
    q = data.get("quality") or {}
    if "optimizer_success" in q:
        from optinav.core.results import convergence

        kw["convergence"] = convergence(
            q.get("optimizer_success"), evaluations=q.get("nfev"), message=q.get("optimizer_message") or ""
        )
    return kw


register_legacy(CalibrationResult, "optinav.calibration", 1, _legacy_v1)


def session_truth(
    acc_K, acc_b, gyr_K=None, gyr_b=None, *, acc_unit: str = "m/s^2", gyro_unit: str = "rad/s", info: dict | None = None
) -> Truth:
    """A simulated unit's truth in the parameterization :func:`~optinav.multipos.calibrate.calibrate`
    estimates: the accelerometer K in the upper-triangular form U (K = U·Q with Q a rotation: norm observations
    fix the sensor z axis and y-z plane) and the gyroscope K expressed in that frame (K_g·Qᵀ); raw units as
    written (``acc_unit``/``gyro_unit``)."""
    from optinav.multipos import model

    U, Q = model.upper_triangular_form(np.asarray(acc_K, float))
    acc = {"K": U, "b": np.asarray(acc_b, float), "form": "upper-triangular"}
    params = _triad_parameters("acc", acc, acc_unit, "m/s^2")
    if gyr_K is not None:
        gyr = {"K": np.asarray(gyr_K, float) @ Q.T, "b": np.asarray(gyr_b, float), "form": "full"}
        params.update(_triad_parameters("gyr", gyr, gyro_unit, "rad/s"))
    return Truth("multipos", params, dict(info or {}))


def _truth_v1(data: dict) -> dict:
    units = data.get("units") or {}
    a, g = data["accelerometer"], data.get("gyroscope")
    return session_truth(
        a["K"],
        a["b"],
        None if g is None else g["K"],
        None if g is None else g["b"],
        acc_unit=units.get("accelerometer_raw", "m/s^2"),
        gyro_unit=units.get("gyroscope_raw", "rad/s"),
    ).parameters


register_truth_legacy("multipos", "optinav.simulation_truth", _truth_v1)
