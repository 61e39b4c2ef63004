"""Simulated multi-position calibration sessions (raw logs with truth), built on the core simulator.

A session is an initial rest period, then static poses joined by smooth rotations (zero rate at both ends),
recorded by one IMU unit drawn from a spec (default the MTi-1 class of Gao & Zhang 2019) and written in the
requested raw units. The truth of each triad is given in the calibration convention raw = K·x + b.
"""

from __future__ import annotations

import dataclasses
from dataclasses import field

import numpy as np

from optinav.core import rotations
from optinav.core.earth import gravity as normal_gravity
from optinav.core.imu_model import ImuModel, ImuSpec, TriadErrors, preset
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.simulate import static_positions
from optinav.core.units import DEG, G_STANDARD
from optinav.core.validate import as_float_array, as_rng, check_positive
from optinav.errors import OptinavError

from . import model
from .design import PAPER_SCHEME_UP, pose_orientation

S45 = float(np.sqrt(0.5))
#: the positions of Gao & Zhang (2019) recovered from their Table 1: the sensor-frame up vector, in test order
PAPER_SCHEME = np.array(PAPER_SCHEME_UP[:12])
SIX_SCHEME = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], float)
#: 18 poses: the six axis poses, the eight corners and four 45° poses — well conditioned for all 9 parameters
SCHEME_18 = np.vstack(
    [
        SIX_SCHEME,
        np.array([(sx, sy, sz) for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]) / np.sqrt(3),
        [(S45, S45, 0), (-S45, 0, S45), (0, S45, -S45), (S45, 0, -S45)],
    ]
)
SCHEMES = {"paper12": PAPER_SCHEME, "six": SIX_SCHEME, "18": SCHEME_18}
#: Gao & Zhang (2019) Table 2, "traditional multi-position" reference of their MTi-1: S per 1 g, M (rad), B m/s²
PAPER_REFERENCE = {
    "S": (9.80518, 9.78718, 9.77107),
    "M_xy": -0.0058,
    "M_xz": 0.00522,
    "M_yz": 0.00393,
    "B": (0.11646, 0.0361, 0.13644),
    "M_yx": 0.00607,
    "M_zx": -0.0036,
    "M_zy": -0.0062,
}
RAW_UNITS = ("m/s^2", "g", "counts")


def orientation_for_up(up, yaw: float = 0.0) -> np.ndarray:
    """A C_b^n (ENU) whose sensor-frame up vector is ``up`` (:func:`optinav.multipos.design.pose_orientation`),
    turned by ``yaw`` (rad) about the vertical."""
    c = pose_orientation(up)
    return rotations.rot_z(yaw).T @ c if yaw else c


@dataclasses.dataclass
class SimulatedSession(Result):
    """A simulated raw log with truth (raw = K·x + b per triad, raw in ``acc_unit`` / ``gyro_unit``).

    ``acc_K``, ``acc_b``, ``gyr_K``, ``gyr_b`` carry the names of the result's parameters (``acc_K_xx``,
    ``gyr_b_x`` …, docs/results.md). Version 2 renamed the version-1 fields ``gyro``/``gyro_K``/``gyro_b`` to
    ``gyr``/``gyr_K``/``gyr_b`` (version-1 files still load)."""

    SCHEMA = "optinav.simulated_session"
    VERSION = 2

    t: np.ndarray = field(metadata={"unit": "s"})
    acc: np.ndarray = field(metadata={"unit": "acc_unit"})
    gyr: np.ndarray = field(metadata={"unit": "gyro_unit"})
    acc_unit: str = field(metadata={"unit": "-"})
    gyro_unit: str = field(metadata={"unit": "-"})
    acc_K: np.ndarray = field(metadata={"unit": "acc_unit/(m/s^2)"})
    acc_b: np.ndarray = field(metadata={"unit": "acc_unit"})
    gyr_K: np.ndarray = field(metadata={"unit": "gyro_unit/(rad/s)"})
    gyr_b: np.ndarray = field(metadata={"unit": "gyro_unit"})
    gravity: float = field(metadata={"unit": "m/s^2"})
    up_dirs: np.ndarray = field(metadata={"unit": ""})
    static_intervals: np.ndarray = field(metadata={"unit": "s"})
    labels: np.ndarray = field(metadata={"unit": ""})
    acc_noise_sigma: float = field(metadata={"unit": "acc_unit"})
    acc_bias_instability: float = field(default=0.0, metadata={"unit": "acc_unit"})
    descriptions: list = field(default_factory=list, metadata={"unit": "-"})

    def log(self):
        """The session as a log to write.

        Returns
        -------
        ImuLog
            acc [m/s^2] and gyr [rad/s] (raw counts stay counts), which :func:`optinav.io.write_imu` converts
            back to the file's ``acc_unit``/``gyro_unit``.
        """
        from optinav.core.units import factor
        from optinav.io import ImuLog

        acc = self.acc if self.acc_unit in ("counts", "m/s^2") else self.acc * factor(self.acc_unit)
        gyro = self.gyr if self.gyro_unit in ("counts", "rad/s") else self.gyr * factor(self.gyro_unit)
        return ImuLog(
            t=self.t,
            acc=acc,
            gyr=gyro,
            acc_unit="counts" if self.acc_unit == "counts" else "m/s^2",
            gyro_unit="counts" if self.gyro_unit == "counts" else "rad/s",
            source="optinav simulate",
        )

    def truth(self, site: dict | None = None, provenance: dict | None = None):
        """The session's truth file content (:func:`~optinav.multipos.result.session_truth`).

        Parameters
        ----------
        site : dict or None
            Where the gravity holds, as the caller states it (e.g. ``{"latitude_deg": …, "height_m": …}``);
            written after the gravity.
        provenance : dict or None
            How the session was made (seed, preset, ...); written last.

        Returns
        -------
        Truth
            The parameters in the calibrated parameterization; info: model, units, both triads' K and b,
            gravity, site, static intervals, poses, provenance.
        """
        from optinav.multipos.result import session_truth

        info = {
            "model": "raw = K x + b",
            "units": {
                "accelerometer_raw": self.acc_unit,
                "accelerometer": "m/s^2",
                "gyroscope_raw": self.gyro_unit,
                "gyroscope": "rad/s",
                "time": "s",
            },
            "accelerometer": {
                "K": self.acc_K.tolist(),
                "b": self.acc_b.tolist(),
                "noise_sigma": self.acc_noise_sigma,
                "bias_instability": self.acc_bias_instability,
            },
            "gyroscope": {"K": self.gyr_K.tolist(), "b": self.gyr_b.tolist()},
            "gravity": self.gravity,
            **(site or {}),
            "static_intervals": self.static_intervals.tolist(),
            "up_dirs": self.up_dirs.tolist(),
            "poses": self.descriptions,
            **(provenance or {}),
        }
        return session_truth(
            self.acc_K, self.acc_b, self.gyr_K, self.gyr_b, acc_unit=self.acc_unit, gyro_unit=self.gyro_unit, info=info
        )


register_legacy(
    SimulatedSession,
    SimulatedSession.SCHEMA,
    1,
    lambda d: nested_kwargs(SimulatedSession, d, {"gyro": "gyr", "gyro_K": "gyr_K", "gyro_b": "gyr_b"}),
)  # old names


def _raw_factor(unit: str, kind: str, counts_per_si: float) -> float:
    if kind == "acc":
        table = {"m/s^2": 1.0, "g": 1.0 / G_STANDARD, "counts": counts_per_si}
    else:
        table = {"rad/s": 1.0, "deg/s": 1.0 / DEG, "counts": counts_per_si}
    if unit not in table:
        raise OptinavError(f"unknown {kind} unit {unit!r}", f"use one of {', '.join(table)}")
    return table[unit]


def simulate(
    scheme="paper12",
    *,
    spec: ImuSpec | ImuModel | str = "mems-mti1",
    dwell_s: float = 60.0,
    rate_hz: float | None = None,
    transition_s: float = 4.0,
    rest_s: float = 10.0,
    lat: float = float(np.radians(38.88)),
    height_m: float = 35.0,
    truth: str = "draw",
    acc_unit: str = "m/s^2",
    gyro_unit: str = "rad/s",
    acc_counts_per_si: float = 2048 / G_STANDARD,
    gyro_counts_per_si: float = 16.4 / DEG,
    jitter: float = 0.0,
    rng=None,
) -> SimulatedSession:
    """Simulate a static multi-position session.

    Poses alternate yaw so that consecutive transitions turn about varied axes.

    Parameters
    ----------
    scheme : str or (P, 3) array
        A name in :data:`SCHEMES` or sensor-frame up vectors [-].
    spec : ImuSpec, ImuModel or str
        An ImuSpec (a unit is drawn with ``rng``), an ImuModel, or a preset name.
    dwell_s : float
        Dwell per pose [s].
    rate_hz : float or None
        Sample rate [Hz]; None: the unit's.
    transition_s : float
        Duration of each turn between poses [s].
    rest_s : float
        Initial rest in the first pose [s].
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    truth : str
        ``"draw"`` (the unit's errors) or ``"paper"``: the accelerometer errors of Gao & Zhang's Table 2 (S per
        local g, three misalignments, biases).
    acc_unit, gyro_unit : str
        Units of the raw outputs (``"counts"`` or an SI / named unit).
    acc_counts_per_si : float
        Nominal counts per m/s² of ``acc_unit="counts"`` [1/(m/s^2)].
    gyro_counts_per_si : float
        Nominal counts per rad/s of ``gyro_unit="counts"`` [1/(rad/s)].
    jitter : float
        Timestamp jitter as a fraction of the step [-] (irregular sampling).
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    SimulatedSession
        Raw log ``t`` [s], ``acc`` [acc_unit], ``gyro`` [gyro_unit] with the true K, b and up vectors.
    """
    gen = as_rng(rng)
    ups = SCHEMES.get(scheme) if isinstance(scheme, str) else as_float_array(scheme, "scheme", last_dims=(3,))
    if ups is None:
        raise OptinavError(f"unknown scheme {scheme!r}", f"use one of {', '.join(SCHEMES)} or give up vectors")
    unit_model = preset(spec) if isinstance(spec, str) else spec
    unit_model = unit_model.draw(gen) if isinstance(unit_model, ImuSpec) else unit_model
    if not isinstance(unit_model, ImuModel):
        raise OptinavError("spec must be an ImuSpec, an ImuModel or a preset name", "e.g. spec='mems-mti1'")
    rate = unit_model.rate_hz if rate_hz is None else check_positive(rate_hz, "rate_hz")
    lat = float(lat)
    g = float(normal_gravity(lat, height_m))
    if truth == "paper":
        K, b = model.from_paper(
            PAPER_REFERENCE["S"],
            PAPER_REFERENCE["M_xy"],
            PAPER_REFERENCE["M_xz"],
            PAPER_REFERENCE["M_yz"],
            PAPER_REFERENCE["B"],
            g,
        )
        unit_model = dataclasses.replace(unit_model, acc=TriadErrors.from_matrix("accel", K, b))
    elif truth != "draw":
        raise OptinavError(f"truth={truth!r} is not understood", "use 'draw' or 'paper'")
    poses = np.stack(
        [orientation_for_up(ups[0])] + [orientation_for_up(u, yaw=(k % 4) * np.pi / 2) for k, u in enumerate(ups)]
    )
    dwell = np.r_[rest_s, np.full(len(ups), check_positive(dwell_s, "dwell_s"))]
    n = int(round((dwell.sum() + transition_s * len(ups)) * rate))
    t = np.arange(n) / rate
    if jitter:
        t = t + gen.uniform(-0.5, 0.5, n) * jitter / rate
        t[0] = 0.0
    tr = static_positions(poses, dwell, rate, lat, height_m=height_m, transition=transition_s, t=t, frame="enu")
    meas = unit_model.apply(tr.gyr, tr.acc, dt=np.r_[np.diff(tr.t), 1 / rate], rng=gen)
    fa = _raw_factor(acc_unit, "acc", acc_counts_per_si)
    fg = _raw_factor(gyro_unit, "gyro", gyro_counts_per_si)
    labels = tr.labels.copy()
    labels[labels == 0] = -2  # the rest period is not a calibration pose
    labels[labels > 0] -= 1
    intervals = np.array([[tr.t[labels == k][0], tr.t[labels == k][-1]] for k in range(len(ups))])
    vrw = np.asarray(unit_model.acc_noise.white, float)
    from optinav.core.simulate import describe_pose

    return SimulatedSession(
        t=tr.t,
        acc=meas.acc * fa,
        gyr=meas.gyr * fg,
        acc_unit=acc_unit,
        gyro_unit=gyro_unit,
        acc_K=unit_model.acc.K * fa,
        acc_b=unit_model.acc.bias * fa,
        gyr_K=unit_model.gyr.K * fg,
        gyr_b=unit_model.gyr.bias * fg,
        gravity=g,
        up_dirs=ups,
        static_intervals=intervals,
        labels=labels,
        acc_noise_sigma=float(np.max(vrw) * np.sqrt(rate) * fa),
        acc_bias_instability=float(np.max(unit_model.acc_noise.gm_sigma) * fa),
        descriptions=[describe_pose(c, frame="enu") for c in poses[1:]],
    )
