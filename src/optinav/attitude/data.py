"""Real attitude data: the BROAD benchmark (Laidig et al. 2021, Data 6(7):72, CC BY 4.0) and synthesized
skylight polarization for real trajectories.

BROAD HDF5 layout (dlaidig/broad, data_hdf5/): ``imu_gyr`` (N, 3) rad/s, ``imu_acc`` (N, 3) m/s²,
``imu_mag`` (N, 3) µT, ``opt_quat`` (N, 4) [w, x, y, z] body → ENU optical reference (NaN rows where
tracking was lost), ``opt_pos`` (N, 3) m, ``movement`` (N,) bool (the samples the BROAD metrics use); root
attribute ``sampling_rate`` Hz.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from optinav.core.rotations import DEFAULT_FRAME
from optinav.core.validate import as_rng
from optinav.errors import OptinavError

if TYPE_CHECKING:
    from optinav.attitude.measurement import PolarizationMeasurement
from optinav.sky.polarization import wrap_axial

__all__ = [
    "BroadTrial",
    "is_broad",
    "has_reference",
    "broad_units",
    "load_broad",
    "BROAD_TRIAL_02",
    "synthesize_polarization",
]

#: path of BROAD trial 02 inside a data folder laid out as the project's shared data (``attitude/broad/``);
#: the library reads only the paths it is given, the CLI, tests and benchmarks resolve the folder
BROAD_TRIAL_02 = Path("attitude") / "broad" / "02_undisturbed_slow_rotation_B.hdf5"


@dataclass
class BroadTrial:
    """One BROAD trial (SI units; frame ENU; ``q_ref`` body → ENU with NaN rows)."""

    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    q_ref: np.ndarray
    movement: np.ndarray
    rate_hz: float
    name: str
    #: the gyro's unit as declared (option or file attribute) before the conversion to rad/s: the checks name it
    gyro_unit: str = "rad/s"

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def eval_mask(self) -> np.ndarray:
        """BROAD's evaluation samples: movement phase with a valid optical reference."""
        return self.movement & np.all(np.isfinite(self.q_ref), axis=1)


def _names(p: Path) -> set:
    """The dataset / variable names of an HDF5 or MAT file (the names only: a long log is not read whole)."""
    from optinav.io.arrayblocks import mat5_names

    names = mat5_names(p) if p.suffix.lower() == ".mat" else None
    if names is not None:
        return set(names)
    import h5py

    try:
        with h5py.File(p, "r") as f:  # HDF5 and MATLAB v7.3
            return set(f)
    except OSError:
        pass  # not HDF5 after all: the reader below names the problem
    from optinav.io.readers import load_table

    return set(load_table(p).data)


#: BROAD's datasets and their columns, one row per sample of ``imu_gyr``
BROAD_COLUMNS = {"imu_gyr": 3, "imu_acc": 3, "imu_mag": 3, "opt_quat": 4, "movement": 1}


def check_broad_shapes(name: str, shapes: dict) -> None:
    """Refuse a BROAD-layout file whose datasets (``shapes``: name → shape, those to judge) are not one row per
    sample of ``imu_gyr`` with BROAD's columns (:data:`BROAD_COLUMNS`; ``movement`` (N,) or (N, 1)): an
    ``opt_quat`` 100 rows short or of 3 columns, or a short ``imu_acc``, ended in an internal error."""
    n = int(shapes["imu_gyr"][0]) if len(shapes.get("imu_gyr", ())) else None
    for key, shape in shapes.items():
        shape, width = tuple(int(x) for x in shape), BROAD_COLUMNS[key]
        if len(shape) in (1, 2) and shape[0] == (shape[0] if n is None else n) and (shape[1:] or (1,))[0] == width:
            continue
        raise OptinavError(
            f"{name}: {key} has shape {shape}, not {(n, width) if width > 1 else (n,)} (one row per sample of "
            "imu_gyr, as BROAD stores it)",
            "pass the trial as published" + (", or drop --reference" if key in ("opt_quat", "movement") else ""),
        )


def movement_mask(x) -> np.ndarray:
    """BROAD's ``movement`` as a (N,) bool mask: a float dataset's NaN rows are not movement (read as bool, NaN is
    True, and every sample of a trial whose movement held NaN was scored)."""
    x = np.asarray(x).ravel()
    return np.nan_to_num(x, nan=0.0) != 0 if x.dtype.kind in "fc" else x.astype(bool)


def is_broad(path) -> bool:
    """True for an HDF5 or MAT file (by suffix) holding BROAD's ``imu_gyr`` and ``imu_acc``."""
    p = Path(path)
    if p.suffix.lower() not in (".h5", ".hdf5", ".mat") or not p.is_file():
        return False
    return {"imu_gyr", "imu_acc"} <= _names(p)


def _broad_rate(rate, path) -> float:
    """A BROAD trial's ``sampling_rate`` (Hz) as read from its file (attribute, variable or None), checked."""
    try:
        rate = float(np.asarray(rate, float).ravel()[0])
    except (TypeError, ValueError, IndexError):
        rate = float("nan")
    if not np.isfinite(rate) or rate <= 0:
        raise OptinavError(
            f"{Path(path).name} has no valid 'sampling_rate'",
            "give --rate HZ, or name a time dataset with --datasets t=NAME,acc=imu_acc,gyro=imu_gyr",
        )
    return rate


def has_reference(path) -> bool:
    """True when the BROAD-layout file ``path`` holds the optical reference (``opt_quat`` and ``movement``)."""
    return {"opt_quat", "movement"} <= _names(Path(path))


def broad_declared(key: str, attrs, options=None) -> str | None:
    """The unit ``key`` (``"acc_unit"``, ``"gyro_unit"``) a BROAD-layout file is read in: the option of that name,
    else the file's attribute, else None (BROAD's own files: m/s², rad/s)."""
    unit = (None if options is None else getattr(options, key, None)) or attrs.get(key)
    return unit.decode() if isinstance(unit, bytes) else unit


def broad_units(name: str, attrs, options=None, file_rate=None) -> tuple[float, float, float]:
    """(acc factor, gyro factor, rate Hz) of a BROAD-layout file: the units from the options (``acc_unit``,
    ``gyro_unit`` of :class:`optinav.attitude.unit.AttitudeOptions`) or the file's attributes of those names
    (BROAD's own files: m/s², rad/s); the rate its ``sampling_rate``, or ``rate_hz`` when it states none. A time
    unit, a rate that contradicts the file's or raw counts end in a one-line error."""
    from optinav.core.units import factor

    o = options
    if o is not None and getattr(o, "time_unit", None):
        raise OptinavError(
            f"{name} has BROAD's layout: its time is sample / sampling_rate, there is no time column",
            "drop --time-unit (--rate gives the rate of a file that states none)",
        )
    given = None if o is None else getattr(o, "rate_hz", None)
    if file_rate is not None and given is not None:
        fr = _broad_rate(file_rate, name)
        from optinav.io.imu import RATE_AGREE  # a rate typed to its printed digits is the file's

        if abs(fr - float(given)) > RATE_AGREE * fr:
            raise OptinavError(
                f"{name} states sampling_rate {fr:.10g} Hz, --rate says {float(given):.10g}", "drop --rate"
            )
    rate = _broad_rate(file_rate if file_rate is not None else given, name)
    out = []
    for key in ("acc_unit", "gyro_unit"):
        unit = broad_declared(key, attrs, o)
        if unit is not None and str(unit).strip().lower() == "counts":
            raise OptinavError(f"{name} is in raw counts", "calibrate first (optinav apply), or declare its unit")
        out.append(1.0 if unit is None else factor(str(unit)))
    return out[0], out[1], rate


def load_broad(path, options=None) -> BroadTrial:
    """Read a BROAD trial as published: HDF5 (``sampling_rate`` attribute) or MAT (``sampling_rate`` variable);
    ``opt_quat`` and ``movement`` (the optical reference) may be absent (NaN / False then). ``options``: the
    reading options of :class:`optinav.attitude.unit.AttitudeOptions` (units, rate; :func:`broad_units`)."""
    from optinav.io.readers import load_table

    p = Path(path)
    if not p.is_file():
        raise OptinavError(f"BROAD file {p} not found", "download it from github.com/dlaidig/broad (data_hdf5/)")
    tab = load_table(p)
    missing = [k for k in ("imu_gyr", "imu_acc") if k not in tab.data]
    if missing:
        raise OptinavError(f"{p.name} lacks BROAD dataset(s) {missing}", "pass a BROAD trial HDF5 or MAT file")
    rate = tab.meta.get("sampling_rate")
    if rate is None and "sampling_rate" in tab.data:
        rate = np.asarray(tab.get("sampling_rate"), float).ravel()[0]
    attrs = dict(tab.meta)
    if tab.kind == "hdf5":
        import h5py

        with h5py.File(p, "r") as f:
            attrs.update(f.attrs)
            rate = f.attrs.get("sampling_rate") if rate is None else rate
    fa, fg, rate = broad_units(p.name, attrs, options, rate)
    gyr = np.asarray(tab.get("imu_gyr"), float) * fg
    acc = np.asarray(tab.get("imu_acc"), float) * fa
    mag = np.asarray(tab.get("imu_mag"), float) if "imu_mag" in tab.data else np.full(gyr.shape, np.nan)
    check_broad_shapes(p.name, {"imu_gyr": gyr.shape, "imu_acc": acc.shape, "imu_mag": mag.shape})
    n = gyr.shape[0]
    return BroadTrial(
        gyr=gyr,
        acc=acc,
        mag=mag,
        q_ref=np.asarray(tab.get("opt_quat"), float) if "opt_quat" in tab.data else np.full((n, 4), np.nan),
        movement=movement_mask(tab.get("movement")) if "movement" in tab.data else np.zeros(n, bool),
        rate_hz=rate,
        name=p.stem,
        gyro_unit=str(broad_declared("gyro_unit", attrs, options) or "rad/s"),
    )


def synthesize_polarization(
    q_ref, sun_n, *, frame: str = DEFAULT_FRAME, C_b_m=None, aop_noise: float = 0.0, rng=None, **options
) -> PolarizationMeasurement:
    """Rayleigh AoP a zenith-viewing sensor would have measured along a reference trajectory.

    q_ref (N, 4) body → ``frame`` (NaN rows give missing samples; BROAD's ``q_ref`` is ENU: pass
    ``frame="enu"``); sun_n (3,) or (N, 3) unit sun vector in the frame; ``aop_noise`` rad (white, Gaussian).
    ``options`` go to :class:`PolarizationMeasurement`.
    """
    from optinav.attitude.measurement import PolarizationMeasurement, as_c_b_m, predicted_aop

    q = np.asarray(q_ref, dtype=float)
    ok = np.all(np.isfinite(q), axis=1)
    c_b_m = as_c_b_m(C_b_m, frame)
    aop = np.full(q.shape[0], np.nan)
    s = np.asarray(sun_n, float)
    aop[ok] = predicted_aop(q[ok], s if s.ndim == 1 else s[ok], c_b_m, frame)
    if aop_noise:
        aop[ok] += as_rng(rng).normal(0.0, aop_noise, int(ok.sum()))
    aop = wrap_axial(aop)
    return PolarizationMeasurement(aop, s, C_b_m=c_b_m, frame=frame, **options)
