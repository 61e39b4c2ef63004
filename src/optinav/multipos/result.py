"""The calibration result file (RESULT.json) and applying it to new raw data.

Layout (``schema`` "optinav.calibration", ``version`` 1; documented in docs/file-formats.md)::

    {"schema": "optinav.calibration", "version": 1, "optinav_version": "...",
     "model": "raw = K x + b",
     "units": {"accelerometer_raw": "counts", "accelerometer": "m/s^2", "gyroscope_raw": "deg/s",
               "gyroscope": "rad/s", "time": "s", ...},
     "accelerometer": {"K": 3×3, "b": [3], "K_std": 3×3, "b_std": [3], "form": "upper-triangular",
                       "estimated": [...], "held": [...]},
     "gyroscope": {"K": 3×3, "b": [3], "K_std", "b_std", "G": 3×3 or null, ...} or null,
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

from optinav.core.results import Result
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

MODEL = "raw = K x + b"


def _nan(v):
    """JSON null back to NaN inside numeric lists."""
    if isinstance(v, list):
        return [_nan(x) for x in v]
    return np.nan if v is None else v


def _triad(d: dict | None, name: str) -> dict | None:
    if d is None:
        return None
    if not isinstance(d, dict) or "K" not in d or "b" not in d:
        raise OptinavError(f"the {name} entry of the result has no K and b", "pass a complete optinav result file")
    out = dict(d)
    out["K"] = as_float_array(d["K"], f"{name} K", last_dims=(3, 3))
    out["b"] = as_float_array(d["b"], f"{name} b", last_dims=(3,))
    if out["K"].shape != (3, 3) or out["b"].shape != (3,):
        raise OptinavError(f"the {name} K/b have shapes {out['K'].shape}/{out['b'].shape}", "expect 3×3 and 3")
    with np.errstate(over="ignore"):  # a huge K (a damaged file) overflows to inf: not singular; apply judges it
        det = np.linalg.det(out["K"])
    if abs(det) < 1e-300:
        raise OptinavError(f"the {name} matrix K is singular", "the result file is corrupt; re-run the calibration")
    for key in ("K_std", "b_std", "G"):
        if d.get(key) is not None:
            out[key] = np.asarray(_nan(d[key]), dtype=float)
    return out


@dataclasses.dataclass
class CalibrationResult(Result):
    """A triad calibration as written to RESULT.json (see the module docstring)."""

    SCHEMA = "optinav.calibration"
    VERSION = 1
    _FLAT = True
    _FLAT_WHAT = "calibration result"
    _FLAT_REMEDY = "pass the RESULT.json written by `optinav calibrate`"
    _FLAT_EXTRA = {"model": MODEL}

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

    def __post_init__(self):
        self.accelerometer = _triad(self.accelerometer, "accelerometer")
        self.gyroscope = _triad(self.gyroscope, "gyroscope")
        self.static_intervals = np.asarray(self.static_intervals, float).reshape(-1, 2)
        if self.accelerometer is None and self.gyroscope is None:
            raise OptinavError("the calibration result has neither an accelerometer nor a gyroscope",
                               "pass a result file written by `optinav calibrate`")

    def correct_accel(self, raw) -> np.ndarray:
        """a = K⁻¹(raw − b) (m/s²) for raw (N, 3) in the calibrated input units."""
        if self.accelerometer is None:
            raise OptinavError("this result has no accelerometer calibration", "calibrate the accelerometer first")
        raw = as_float_array(raw, "accelerometer data", last_dims=(3,), finite=False)
        K, b = self.accelerometer["K"], self.accelerometer["b"]
        return np.linalg.solve(K, (raw - b).T).T

    def correct_gyro(self, raw, acc=None) -> np.ndarray:
        """ω = K_g⁻¹(raw − G·a − b_g) (rad/s); ``acc`` is the corrected specific force (m/s²) for G."""
        if self.gyroscope is None:
            raise OptinavError("this result has no gyroscope calibration", "calibrate with gyroscope data")
        raw = as_float_array(raw, "gyroscope data", last_dims=(3,), finite=False)
        K, b = self.gyroscope["K"], self.gyroscope["b"]
        v = raw - b
        G = self.gyroscope.get("G")
        if G is not None and np.any(np.asarray(G) != 0):
            if acc is None:
                raise OptinavError("the gyroscope calibration has a g-sensitivity term but no accelerometer data "
                                   "was given", "pass the accelerometer data too")
            v = v - np.asarray(acc, float) @ np.asarray(G, float).T
        return np.linalg.solve(K, v.T).T

    def summary(self) -> str:
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
                row = "  ".join(f"{K[i, j]: .6g}" + (f" ±{Ks[i, j]:.2g}" if np.isfinite(Ks[i, j]) else "")
                                for j in range(3))
                lines.append(f"  K[{'xyz'[i]}] = {row}")
            lines.append("  b = " + "  ".join(f"{b[i]: .6g}" + (f" ±{bs[i]:.2g}" if np.isfinite(bs[i]) else "")
                                              for i in range(3)))
            if d.get("held"):
                lines.append(f"  held (not observable from these poses): {', '.join(d['held'])}")
        if math.isfinite(self.residual_rms):
            lines.append(f"residual rms of |a| - g over static samples: {self.residual_rms:.4g} m/s^2")
        if len(self.static_intervals):
            lines.append(f"static intervals used: {len(self.static_intervals)}")
        for s in self.observability.get("unobservable", []) or []:
            lines.append(f"unobservable: {s}")
        return "\n".join(lines)
