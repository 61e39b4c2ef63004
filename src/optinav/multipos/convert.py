"""Conversions between optinav's triad calibration ``raw = K x + b`` and imu_tk / imucal parameters.

optinav: ``raw = K x + b`` with x in SI (m/s² or rad/s), raw and b in the input units, K (3×3) raw per SI
unit; a gyro may add ``G f`` (G raw per m/s², f the specific force).

imu_tk (Tedaldi, Pretto & Menegatti, ICRA 2014; ``imu_tk::CalibratedTriad``): ``x' = T S (raw − B)`` with
``S = diag(s)`` and the misalignment matrix ::

        [    1     −mis_yz    mis_zy ]
    T = [  mis_xz     1      −mis_zx ]        "body" form (imu_tk's accelerometer): mis_xz = mis_xy = mis_yx = 0
        [ −mis_xy   mis_yx      1    ]

so ``K = (f T S)⁻¹`` and ``b = B``, f the SI factor of imu_tk's output unit (imu_tk's accelerometer output is
in the units of its gravity magnitude, m/s² by default; its gyro output is rad/s). A K is representable in
the body form iff ``K⁻¹`` is upper triangular (equivalently K upper triangular: optinav's 9-parameter
accelerometer form), and in the general form iff ``K⁻¹`` has a non-zero diagonal. imu_tk's parameter file
(``CalibratedTriad::save``/``load``) is plain text: the 3×3 T, the 3×3 S (row-major) and B as a column,
separated by blank lines; ``load`` reads 21 whitespace-separated numbers.

imucal (Küderle et al., JOSS 2022; ``FerrarisCalibrationInfo``)::

    acc_cal = R_a⁻¹ K_a⁻¹ (acc − b_a)                       K_a diagonal, R_a rows = unit sensitivity axes
    gyr_cal = R_g⁻¹ K_g⁻¹ (gyr − K_ga acc_cal − b_g)

with acc_cal in ``acc_unit`` (m/s²) and gyr_cal in ``gyr_unit`` (deg/s). Hence ``K = K_a R_a / f_acc``,
``K_gyro = K_g R_g / f_gyr`` (= · 180/π for deg/s), ``G = K_ga / f_acc``; the inverse factorization takes
the row norms of K as the diagonal (unique with a positive diagonal). imucal's JSON export (format 2.0.0 and
the legacy pre-2.0 layout with ``gyro_unit``) is read and written as plain JSON; its HDF5 export is read.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from optinav.core.files import parse_json, read_text, write_text
from optinav.core.units import factor
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

__all__ = [
    "to_imu_tk",
    "from_imu_tk",
    "imu_tk_matrices",
    "read_imu_tk",
    "write_imu_tk",
    "to_imucal",
    "from_imucal",
    "ImucalCalibration",
    "read_imucal_json",
    "read_imucal_hdf5",
    "write_imucal_json",
    "IMUCAL_FORMAT_VERSION",
]

IMUCAL_FORMAT_VERSION = "2.0.0"
_MIS3 = ("mis_yz", "mis_zy", "mis_zx")
_MIS6 = _MIS3 + ("mis_xz", "mis_xy", "mis_yx")


def _K(K, name="K") -> np.ndarray:
    K = as_float_array(K, name, last_dims=(3, 3))
    if K.ndim != 2:
        raise OptinavError(f"{name} has shape {K.shape}, expected (3, 3)", "pass one 3×3 matrix")
    if np.linalg.cond(K) > 1e12:
        raise OptinavError(
            f"{name} is singular or ill-conditioned (cond {np.linalg.cond(K):.3g})",
            "pass a calibration matrix of full rank",
        )
    return K


def _b(b, name="b") -> np.ndarray:
    b = as_float_array(b, name, last_dims=(3,))
    if b.shape != (3,):
        raise OptinavError(f"{name} has shape {b.shape}, expected (3,)", "pass one 3-vector")
    return b


def _unit_factor(unit) -> float:
    return 1.0 if unit is None else float(factor(unit))


# --------------------------------------------------------------------------------------------------------
# imu_tk
# --------------------------------------------------------------------------------------------------------


def imu_tk_matrices(params: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(T, S, B) of an imu_tk parameter dict (missing misalignments are zero)."""
    m = {k: float(params.get(k, 0.0)) for k in _MIS6}
    T = np.array([[1.0, -m["mis_yz"], m["mis_zy"]], [m["mis_xz"], 1.0, -m["mis_zx"]], [-m["mis_xy"], m["mis_yx"], 1.0]])
    s = _b(params.get("scale", (1.0, 1.0, 1.0)), "scale")
    return T, np.diag(s), _b(params.get("bias", (0.0, 0.0, 0.0)), "bias")


def to_imu_tk(K, b, *, form: str = "body", calibrated_unit: str | None = None, tol: float = 1e-9) -> dict:
    """imu_tk ``CalibratedTriad`` parameters of ``raw = K x + b``.

    Returns ``{"mis_yz", "mis_zy", "mis_zx", "scale" (3,), "bias" (3,)}`` (``form="body"``) plus
    ``"mis_xz", "mis_xy", "mis_yx"`` (``form="general"``). ``calibrated_unit``: the unit of imu_tk's
    calibrated output (None = SI, i.e. m/s² or rad/s; e.g. "g"). Body form needs K⁻¹ upper triangular:
    lower-triangle entries up to ``tol`` × max|K⁻¹| are treated as rounding, larger ones are an error.
    """
    if form not in ("body", "general"):
        raise OptinavError(f"form must be 'body' or 'general', got {form!r}", "pass form='body' or 'general'")
    K, b = _K(K), _b(b)
    A = np.linalg.inv(K) / _unit_factor(calibrated_unit)  # = T S
    if form == "body":
        low = float(np.abs(np.tril(A, -1)).max())
        if low > tol * float(np.abs(A).max()):
            raise OptinavError(
                f"K is not representable in imu_tk's body form: K⁻¹ has below-diagonal entries up to {low:.3g} "
                f"({low / np.abs(A).max():.2g} of its largest entry)",
                "use form='general' (imu_tk's 6-misalignment gyro form) or an upper-triangular K",
            )
    s = np.diag(A).copy()
    if np.any(s == 0):
        raise OptinavError(
            "K⁻¹ has a zero diagonal entry, which imu_tk's T·S cannot express", "check the axis order of K"
        )
    T = A / s[None, :]
    out = {"mis_yz": -T[0, 1], "mis_zy": T[0, 2], "mis_zx": -T[1, 2]}
    if form == "general":
        out.update({"mis_xz": T[1, 0], "mis_xy": -T[2, 0], "mis_yx": T[2, 1]})
    out = {k: float(v) for k, v in out.items()}
    out["scale"], out["bias"] = s, b.copy()
    return out


def from_imu_tk(
    params: dict | None = None, *, calibrated_unit: str | None = None, **kw
) -> tuple[np.ndarray, np.ndarray]:
    """(K, b) of ``raw = K x + b`` from imu_tk parameters (a dict like :func:`to_imu_tk`'s, or keywords
    ``mis_yz, mis_zy, mis_zx, mis_xz, mis_xy, mis_yx, scale, bias``; missing misalignments are 0).
    ``calibrated_unit`` as in :func:`to_imu_tk`."""
    p = dict(params or {})
    p.update(kw)
    unknown = set(p) - set(_MIS6) - {"scale", "bias", "form"}
    if unknown:
        raise OptinavError(f"unknown imu_tk parameter(s) {sorted(unknown)}", f"use {', '.join(_MIS6)}, scale, bias")
    T, S, B = imu_tk_matrices(p)
    A = T @ S * _unit_factor(calibrated_unit)
    if not np.all(np.isfinite(A)) or np.linalg.cond(A) > 1e12:
        raise OptinavError("imu_tk's T·S is singular", "check the scale factors (non-zero) and misalignments")
    return np.linalg.inv(A), B


def write_imu_tk(path, params: dict) -> None:
    """Write imu_tk's text parameter file (T, S, B; blank-line separated, full double precision)."""
    T, S, B = imu_tk_matrices(params)

    def mat(M):
        return "\n".join(" ".join(f"{v:.17g}" for v in row) for row in M)

    text = mat(T) + "\n\n" + mat(S) + "\n\n" + "\n".join(f"{v:.17g}" for v in B) + "\n\n"
    write_text(path, text)


def read_imu_tk(path, *, tol: float = 1e-12) -> dict:
    """Read imu_tk's text parameter file → dict with all six misalignments, ``scale``, ``bias`` and
    ``form`` ("body" when T's lower triangle is zero). The file must hold 21 numbers; T's diagonal must be 1
    and S diagonal. Note that imu_tk (C++ streams) writes only 6 significant digits by default."""
    p = Path(path)
    tokens = read_text(p, "imu_tk parameter file").split()
    try:
        vals = np.array([float(x) for x in tokens])
    except ValueError:
        raise OptinavError(
            f"{p} holds non-numeric text", "pass a file written by imu_tk's CalibratedTriad::save"
        ) from None
    if vals.size != 21 or not np.all(np.isfinite(vals)):
        raise OptinavError(
            f"{p} holds {vals.size} numbers, expected 21 finite ones (T 3×3, S 3×3, B 3)",
            "pass a file written by imu_tk's CalibratedTriad::save",
        )
    T, S, B = vals[:9].reshape(3, 3), vals[9:18].reshape(3, 3), vals[18:]
    if np.any(np.abs(np.diag(T) - 1.0) > 1e-6):
        raise OptinavError(
            f"{p}: the misalignment matrix has diagonal {np.diag(T).tolist()}, imu_tk's is 1",
            "check the file layout (T, S, B)",
        )
    if np.any(np.abs(S - np.diag(np.diag(S))) > tol * np.abs(S).max()):
        raise OptinavError(f"{p}: the scale matrix is not diagonal", "check the file layout (T, S, B)")
    out = {
        "mis_yz": -T[0, 1],
        "mis_zy": T[0, 2],
        "mis_zx": -T[1, 2],
        "mis_xz": T[1, 0],
        "mis_xy": -T[2, 0],
        "mis_yx": T[2, 1],
    }
    out = {k: float(v) for k, v in out.items()}
    out["scale"], out["bias"] = np.diag(S).copy(), B.copy()
    out["form"] = "body" if np.all(np.tril(T, -1) == 0) else "general"
    return out


# --------------------------------------------------------------------------------------------------------
# imucal
# --------------------------------------------------------------------------------------------------------


def _factor_rows(M: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    k = np.linalg.norm(M, axis=1)
    if np.any(k == 0):
        raise OptinavError(f"{name} has a zero row", "pass a full-rank calibration matrix")
    return np.diag(k), M / k[:, None]


def to_imucal(K, b, *, G=None, sensor: str | None = None, acc_unit: str = "m/s^2", gyr_unit: str = "deg/s") -> dict:
    """imucal's factors of ``raw = K x + b (+ G f)``: ``{"K": diag, "R": rows of unit norm, "b"}`` plus
    ``"K_ga"`` for a gyro. ``sensor``: "accel" or "gyro" (default: "gyro" iff G is given). imucal's
    calibrated units ``acc_unit`` (m/s²) and ``gyr_unit`` (deg/s) fix the unit conversion."""
    sensor = sensor or ("gyro" if G is not None else "accel")
    if sensor not in ("accel", "gyro"):
        raise OptinavError(f"sensor must be 'accel' or 'gyro', got {sensor!r}", "pass sensor='accel' or 'gyro'")
    K, b = _K(K), _b(b)
    if sensor == "accel":
        if G is not None:
            raise OptinavError("G (g-sensitivity) was given for an accelerometer", "omit G or pass sensor='gyro'")
        Kd, R = _factor_rows(K * _unit_factor(acc_unit), "K")
        return {"K": Kd, "R": R, "b": b.copy()}
    Kd, R = _factor_rows(K * _unit_factor(gyr_unit), "K")
    Ga = np.zeros((3, 3)) if G is None else as_float_array(G, "G", last_dims=(3, 3)).reshape(3, 3)
    return {"K": Kd, "R": R, "b": b.copy(), "K_ga": Ga * _unit_factor(acc_unit)}


def from_imucal(K, R, b, *, K_ga=None, sensor: str | None = None, acc_unit: str = "m/s^2", gyr_unit: str = "deg/s"):
    """``(K, b)`` (accel) or ``(K, b, G)`` (gyro: sensor="gyro" or K_ga given) of optinav's convention from
    imucal's K (diagonal), R and b; units as in :func:`to_imucal`."""
    sensor = sensor or ("gyro" if K_ga is not None else "accel")
    if sensor not in ("accel", "gyro"):
        raise OptinavError(f"sensor must be 'accel' or 'gyro', got {sensor!r}", "pass sensor='accel' or 'gyro'")
    Kd = as_float_array(K, "K", last_dims=(3, 3)).reshape(3, 3)
    if np.any(Kd - np.diag(np.diag(Kd)) != 0):
        raise OptinavError("imucal's K must be diagonal", "pass K_a or K_g of an imucal calibration")
    M = _K(Kd @ as_float_array(R, "R", last_dims=(3, 3)).reshape(3, 3), "K·R")
    b = _b(b)
    if sensor == "accel":
        if K_ga is not None:
            raise OptinavError("K_ga was given for an accelerometer", "omit K_ga or pass sensor='gyro'")
        return M / _unit_factor(acc_unit), b.copy()
    Ga = np.zeros((3, 3)) if K_ga is None else as_float_array(K_ga, "K_ga", last_dims=(3, 3)).reshape(3, 3)
    return M / _unit_factor(gyr_unit), b.copy(), Ga / _unit_factor(acc_unit)


#: optinav's raw unit → imucal's name of it (its examples and snapshots call raw counts "a.u.")
IMUCAL_RAW = {"counts": "a.u."}


@dataclass(eq=False)
class ImucalCalibration:
    """An imucal ``FerrarisCalibrationInfo`` (fields named as imucal's; units module docstring)."""

    K_a: np.ndarray
    R_a: np.ndarray
    b_a: np.ndarray
    K_g: np.ndarray
    R_g: np.ndarray
    K_ga: np.ndarray
    b_g: np.ndarray
    acc_unit: str | None = "m/s^2"
    gyr_unit: str | None = "deg/s"
    from_acc_unit: str | None = None
    from_gyr_unit: str | None = None
    comment: str | None = None
    cal_type: str = "Ferraris"

    _MATS = ("K_a", "R_a", "b_a", "K_g", "R_g", "K_ga", "b_g")

    def __post_init__(self):
        for k in self._MATS:
            shape = (3,) if k.startswith("b_") else (3, 3)
            v = as_float_array(getattr(self, k), k, last_dims=shape)
            if v.shape != shape:
                raise OptinavError(
                    f"imucal field {k} has shape {v.shape}, expected {shape}", "pass a complete Ferraris calibration"
                )
            setattr(self, k, v.copy())

    @property
    def _units(self) -> tuple[str, str]:
        # imucal's Ferraris calibration always outputs m/s² and deg/s; legacy files may omit them
        return self.acc_unit or "m/s^2", self.gyr_unit or "deg/s"

    def calibrate(self, acc, gyr) -> tuple[np.ndarray, np.ndarray]:
        """imucal's formula: (acc_cal in ``acc_unit``, gyr_cal in ``gyr_unit``) from raw (N, 3) samples."""
        acc = as_float_array(acc, "acc", last_dims=(3,))
        gyr = as_float_array(gyr, "gyr", last_dims=(3,))
        a = (acc - self.b_a) @ np.linalg.inv(self.K_a @ self.R_a).T
        w = (gyr - a @ self.K_ga.T - self.b_g) @ np.linalg.inv(self.K_g @ self.R_g).T
        return a, w

    def to_optinav(self) -> dict:
        """``{"acc_K", "acc_b", "gyr_K", "gyr_G", "gyr_b"}`` in optinav's convention (x in SI)."""
        au, gu = self._units
        aK, ab = from_imucal(self.K_a, self.R_a, self.b_a, sensor="accel", acc_unit=au)
        gK, gb, G = from_imucal(self.K_g, self.R_g, self.b_g, K_ga=self.K_ga, sensor="gyro", acc_unit=au, gyr_unit=gu)
        return {"acc_K": aK, "acc_b": ab, "gyr_K": gK, "gyr_G": G, "gyr_b": gb}

    @classmethod
    def from_optinav(
        cls,
        acc_K,
        acc_b,
        gyr_K,
        gyr_G,
        gyr_b,
        *,
        from_acc_unit=None,
        from_gyr_unit=None,
        comment=None,
        acc_unit: str = "m/s^2",
        gyr_unit: str = "deg/s",
    ) -> "ImucalCalibration":
        """From optinav's (K, b) of both triads and the gyro g-sensitivity G (raw gyro per m/s²); a raw unit of
        counts is written as imucal writes raw data's, "a.u." (imucal compares the unit string its caller gives)."""
        from_acc_unit, from_gyr_unit = (IMUCAL_RAW.get(u, u) for u in (from_acc_unit, from_gyr_unit))
        a = to_imucal(acc_K, acc_b, sensor="accel", acc_unit=acc_unit)
        g = to_imucal(gyr_K, gyr_b, G=gyr_G, sensor="gyro", acc_unit=acc_unit, gyr_unit=gyr_unit)
        return cls(
            K_a=a["K"],
            R_a=a["R"],
            b_a=a["b"],
            K_g=g["K"],
            R_g=g["R"],
            K_ga=g["K_ga"],
            b_g=g["b"],
            acc_unit=acc_unit,
            gyr_unit=gyr_unit,
            from_acc_unit=from_acc_unit,
            from_gyr_unit=from_gyr_unit,
            comment=comment,
        )

    def to_dict(self) -> dict:
        """imucal's JSON layout (format 2.0.0)."""
        d = {
            "acc_unit": self.acc_unit,
            "gyr_unit": self.gyr_unit,
            "from_acc_unit": self.from_acc_unit,
            "from_gyr_unit": self.from_gyr_unit,
            "comment": self.comment,
        }
        for k in self._MATS:
            d[k] = getattr(self, k).tolist()
        d["cal_type"] = self.cal_type
        d["_format_version"] = IMUCAL_FORMAT_VERSION
        return d


def read_imucal_json(source) -> ImucalCalibration:
    """Read an imucal JSON export (a path or a JSON string): format 2.x, or the legacy pre-2.0 layout
    (no ``_format_version``, ``gyro_unit`` instead of ``gyr_unit``, no input units). Only Ferraris-type
    calibrations (cal_type "Ferraris" or "Turntable") are supported."""
    text = str(source)
    src = "imucal JSON"
    if not text.lstrip().startswith("{"):
        p = Path(source)
        src, text = str(p), read_text(p, "imucal calibration file")
    d = parse_json(text, src, "pass a file written by imucal's to_json_file")
    if not isinstance(d, dict):
        raise OptinavError(f"{src} is not a JSON object", "pass a file written by imucal's to_json_file")
    return _imucal_from_dict(d, src)


def read_imucal_hdf5(path) -> ImucalCalibration:
    """Read imucal's HDF5 export (``CalibrationInfo.to_hdf5``: one dataset per matrix, scalar string datasets for
    ``cal_type``, the units, ``comment`` and ``_format_version``; a unit left ``None`` is absent); checked as
    :func:`read_imucal_json`."""
    from optinav.io.readers import _h5py

    h5py, src = _h5py(), str(path)
    d = {}
    try:
        with h5py.File(path, "r") as fh:
            for k, ds in fh.items():
                if isinstance(ds, h5py.Dataset):
                    v = ds[()]
                    d[k] = v.decode("utf-8", "replace") if isinstance(v, bytes) else v
    except OSError as exc:
        raise OptinavError(f"{src} is not a readable HDF5 file ({exc})", "pass imucal's to_hdf5 export") from None
    return _imucal_from_dict(d, src)


def _imucal_from_dict(d: dict, src: str) -> ImucalCalibration:
    """An :class:`ImucalCalibration` from the keys of imucal's export (JSON or HDF5), ``src`` naming it."""
    version = d.pop("_format_version", None)
    if version is None:  # legacy (imucal < 2.0)
        if "gyro_unit" in d:
            d["gyr_unit"] = d.pop("gyro_unit")
    elif str(version).split(".")[0] != "2":
        raise OptinavError(
            f"{src} has imucal format version {version}, this reader knows 2.x and legacy 1.x",
            "re-export the calibration with imucal 2",
        )
    cal_type = d.pop("cal_type", None)
    if cal_type not in ("Ferraris", "Turntable"):
        raise OptinavError(
            f"{src} is an imucal calibration of type {cal_type!r}, not a Ferraris one",
            "pass a FerrarisCalibrationInfo export",
        )
    missing = [k for k in ImucalCalibration._MATS if k not in d]
    if missing:
        raise OptinavError(f"{src} lacks {', '.join(missing)}", "pass a complete Ferraris calibration export")
    kw = {}
    for k in ImucalCalibration._MATS:
        try:
            kw[k] = np.asarray(d[k], dtype=float)
        except (TypeError, ValueError):
            raise OptinavError(f"{src}: {k} is not an array of numbers", "pass an unedited imucal export") from None
    for k in ("acc_unit", "gyr_unit", "from_acc_unit", "from_gyr_unit", "comment"):
        if k in d:
            kw[k] = d[k]
    return ImucalCalibration(cal_type=cal_type, **kw)


def write_imucal_json(path, cal: ImucalCalibration) -> None:
    """Write ``cal`` in imucal's JSON export layout (format 2.0.0, loadable by imucal's from_json_file)."""
    if not isinstance(cal, ImucalCalibration):
        raise OptinavError(
            f"expected an ImucalCalibration, got {type(cal).__name__}",
            "convert first, e.g. FerrarisCalibration.to_imucal()",
        )
    d = cal.to_dict()
    for k in ImucalCalibration._MATS:
        if not all(math.isfinite(v) for v in np.ravel(d[k])):
            raise OptinavError(f"imucal field {k} is not finite", "check the calibration")
    write_text(path, json.dumps(d, indent=4) + "\n")
