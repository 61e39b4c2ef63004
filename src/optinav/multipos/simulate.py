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
from optinav.core.imu_model import ImuModel, ImuSpec, MeasurementStream, SampleDraws, TriadErrors, draw_key, preset
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.simulate import describe_pose, static_positions_sampler
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
        return _as_log(self.t, self.acc, self.gyr, self.acc_unit, self.gyro_unit)

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


def paper_accelerometer(g: float) -> tuple[np.ndarray, np.ndarray]:
    """K [-] and b [m/s^2] of Gao & Zhang's Table 2 accelerometer (:data:`PAPER_REFERENCE`; S per local g ``g``
    [m/s^2])."""
    r = PAPER_REFERENCE
    return model.from_paper(r["S"], r["M_xy"], r["M_xz"], r["M_yz"], r["B"], g)


def _as_log(t, acc, gyr, acc_unit: str, gyro_unit: str):
    """Raw samples (acc [acc_unit], gyr [gyro_unit]) as an ImuLog in SI (counts stay counts) for :func:`write_imu`."""
    from optinav.core.units import factor
    from optinav.io import ImuLog

    return ImuLog(
        t=t,
        acc=acc if acc_unit in ("counts", "m/s^2") else acc * factor(acc_unit),
        gyr=gyr if gyro_unit in ("counts", "rad/s") else gyr * factor(gyro_unit),
        acc_unit="counts" if acc_unit == "counts" else "m/s^2",
        gyro_unit="counts" if gyro_unit == "counts" else "rad/s",
        source="optinav simulate",
    )


def _raw_factor(unit: str, kind: str, counts_per_si: float) -> float:
    if kind == "acc":
        table = {"m/s^2": 1.0, "g": 1.0 / G_STANDARD, "counts": counts_per_si}
    else:
        table = {"rad/s": 1.0, "deg/s": 1.0 / DEG, "counts": counts_per_si}
    if unit not in table:
        raise OptinavError(f"unknown {kind} unit {unit!r}", f"use one of {', '.join(table)}")
    return table[unit]


#: samples per block of a session generated block by block (:class:`SessionStream`): some tens of MB each
BLOCK_ROWS = 1 << 17


class SessionStream:
    """A simulated static multi-position session generated block by block, so that memory does not grow with its
    length (``optinav simulate accel-multipos``); :func:`simulate` gathers the same blocks.

    The unit is drawn from ``rng`` first (so a seed gives the same unit and truth K, b as before); then one key is
    drawn, from which the noise and the timestamp jitter of every sample are drawn by sample index
    (:class:`~optinav.core.imu_model.SampleDraws`), with the noise states carried across blocks
    (:class:`~optinav.core.imu_model.MeasurementStream`): the same seed gives the same samples whatever the block
    length.

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
    transition_s : float or (P − 1,) array
        Duration of each turn between poses [s] (one for all, or one per turn, e.g. a pose plan's; the move from
        the initial rest into the first pose, which does not turn, takes the shortest).
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
    orientations : (P, 3, 3) array or None
        C_b^n (ENU) of each pose, e.g. a pose plan's (:class:`~optinav.multipos.plan.PosePlan`), whose up vectors
        must be ``scheme``'s; None: each pose turned 90° in heading from the last (the turns between the poses are
        what the gyro calibration observes, so a plan's headings are kept).
    rng : int, Generator or None
        Seed or generator.

    Attributes
    ----------
    n : int
        Samples of the session.
    rate_hz : float
        Sample rate [Hz].
    """

    def __init__(
        self,
        scheme="paper12",
        *,
        spec: ImuSpec | ImuModel | str = "mems-mti1",
        dwell_s: float = 60.0,
        rate_hz: float | None = None,
        transition_s=4.0,
        rest_s: float = 10.0,
        lat: float = float(np.radians(38.88)),
        height_m: float = 35.0,
        truth: str = "draw",
        acc_unit: str = "m/s^2",
        gyro_unit: str = "rad/s",
        acc_counts_per_si: float = 2048 / G_STANDARD,
        gyro_counts_per_si: float = 16.4 / DEG,
        jitter: float = 0.0,
        orientations=None,
        rng=None,
    ):
        gen = as_rng(rng)
        ups = SCHEMES.get(scheme) if isinstance(scheme, str) else as_float_array(scheme, "scheme", last_dims=(3,))
        if ups is None:
            raise OptinavError(f"unknown scheme {scheme!r}", f"use one of {', '.join(SCHEMES)} or give up vectors")
        if orientations is not None:
            orientations = as_float_array(orientations, "orientations")
            up_of = orientations.transpose(0, 2, 1)[:, :, 2] if orientations.ndim == 3 else None
            if orientations.shape != (len(ups), 3, 3) or not np.allclose(
                up_of, ups / np.linalg.norm(ups, axis=1, keepdims=True), atol=1e-6
            ):
                raise OptinavError(
                    f"orientations of shape {orientations.shape} are not the {len(ups)} poses' C_b^n with their up vectors",
                    "pass one C_b^n (ENU) per pose, each with C_b^nᵀ·[0, 0, 1] the pose's up vector",
                )
        unit_model = preset(spec) if isinstance(spec, str) else spec
        unit_model = unit_model.draw(gen) if isinstance(unit_model, ImuSpec) else unit_model
        if not isinstance(unit_model, ImuModel):
            raise OptinavError("spec must be an ImuSpec, an ImuModel or a preset name", "e.g. spec='mems-mti1'")
        self.rate_hz = unit_model.rate_hz if rate_hz is None else check_positive(rate_hz, "rate_hz")
        lat = float(lat)
        self.gravity = g = float(normal_gravity(lat, height_m))
        if truth == "paper":
            K, b = paper_accelerometer(g)
            unit_model = dataclasses.replace(unit_model, acc=TriadErrors.from_matrix("accel", K, b))
        elif truth != "draw":
            raise OptinavError(f"truth={truth!r} is not understood", "use 'draw' or 'paper'")
        poses = (
            np.concatenate([orientations[:1], orientations])  # (the initial rest in the first pose)
            if orientations is not None
            else np.stack(
                [orientation_for_up(ups[0])]
                + [orientation_for_up(u, yaw=(k % 4) * np.pi / 2) for k, u in enumerate(ups)]
            )
        )
        dwell = np.r_[rest_s, np.full(len(ups), check_positive(dwell_s, "dwell_s"))]
        turns = as_float_array(transition_s, "transition_s").ravel()
        if turns.size not in (1, len(ups) - 1) or not np.all(turns > 0):
            raise OptinavError(
                f"transition_s holds {turns.size} durations for {len(ups) - 1} turns between poses",
                "give one positive duration (s) or one per turn",
            )
        transition_s = np.r_[turns.min(), np.broadcast_to(turns, (len(ups) - 1,))]
        self.n = int(round((dwell.sum() + transition_s.sum()) * self.rate_hz))
        self.ups, self.unit_model, self.jitter = ups, unit_model, float(jitter)
        self.acc_unit, self.gyro_unit = acc_unit, gyro_unit
        self.fa = _raw_factor(acc_unit, "acc", acc_counts_per_si)
        self.fg = _raw_factor(gyro_unit, "gyro", gyro_counts_per_si)
        self.descriptions = [describe_pose(c, frame="enu") for c in poses[1:]]
        self._sampler = static_positions_sampler(
            poses, dwell, lat, height_m=height_m, transition=transition_s, frame="enu"
        )
        key = draw_key(gen)
        self._measure = MeasurementStream(unit_model, key)
        self._jitter = SampleDraws(key, 6, 1, "uniform")
        self._first = np.full(len(ups), np.nan)
        self._last = np.full(len(ups), np.nan)
        self._done = 0

    def _epochs(self, i0: int, i1: int) -> np.ndarray:
        t = np.arange(i0, i1) / self.rate_hz
        if self.jitter:
            t = t + (self._jitter.take(i0, i1)[:, 0] - 0.5) * self.jitter / self.rate_hz
            if i0 == 0 and i1 > 0:
                t[0] = 0.0
        return np.clip(t, 0.0, self._sampler.duration)

    def blocks(self, block_rows: int = BLOCK_ROWS):
        """Generate the session's samples in order, ``block_rows`` at a time (once per stream).

        Parameters
        ----------
        block_rows : int
            Samples per block (memory grows with it, not with the session; the samples do not depend on it).

        Yields
        ------
        t : (m,) ndarray
            Epochs [s].
        acc : (m, 3) ndarray
            Raw accelerometer [acc_unit].
        gyr : (m, 3) ndarray
            Raw gyroscope [gyro_unit].
        labels : (m,) int ndarray
            Pose index, -1 in turns, -2 in the initial rest.
        """
        if self._done:
            raise OptinavError("this session was already generated", "make a new SessionStream")
        step = int(check_positive(block_rows, "block_rows"))
        for i0 in range(0, self.n, step):
            i1 = min(i0 + step, self.n)
            te = self._epochs(i0, min(i1 + 1, self.n))
            t = te[: i1 - i0]
            dt = np.r_[np.diff(te), [1.0 / self.rate_hz] * (i1 - i0 + 1 - te.size)]
            gyr, acc, labels = self._sampler(t)
            mg, ma = self._measure(gyr, acc, dt)
            labels[labels == 0] = -2  # the rest period is not a calibration pose
            labels[labels > 0] -= 1
            for k in np.unique(labels[labels >= 0]):
                tk = t[labels == k]
                if np.isnan(self._first[k]):
                    self._first[k] = tk[0]
                self._last[k] = tk[-1]
            self._done = i1
            yield t, ma * self.fa, mg * self.fg, labels

    def n_blocks(self, block_rows: int = BLOCK_ROWS) -> int:
        """Number of blocks :meth:`blocks` yields for ``block_rows``."""
        return -(-self.n // int(block_rows))

    def session(self, t=None, acc=None, gyr=None, labels=None) -> SimulatedSession:
        """The session (after :meth:`blocks` ran to the end) with the samples given, or none (empty arrays: the
        truth and the poses only, e.g. for :meth:`SimulatedSession.truth`).

        Returns
        -------
        SimulatedSession
            The samples with the true K, b, static intervals and poses.
        """
        if self._done < self.n:
            raise OptinavError("the session's blocks were not all generated", "run blocks() to the end first")
        if np.any(np.isnan(self._first)):
            raise OptinavError("a pose holds no sample", "lengthen dwell_s or raise rate_hz")
        um, fa, fg = self.unit_model, self.fa, self.fg
        vrw = np.asarray(um.acc_noise.white, float)
        return SimulatedSession(
            t=np.empty(0) if t is None else t,
            acc=np.empty((0, 3)) if acc is None else acc,
            gyr=np.empty((0, 3)) if gyr is None else gyr,
            acc_unit=self.acc_unit,
            gyro_unit=self.gyro_unit,
            acc_K=um.acc.K * fa,
            acc_b=um.acc.bias * fa,
            gyr_K=um.gyr.K * fg,
            gyr_b=um.gyr.bias * fg,
            gravity=self.gravity,
            up_dirs=self.ups,
            static_intervals=np.column_stack([self._first, self._last]),
            labels=np.empty(0, np.int64) if labels is None else labels,
            acc_noise_sigma=float(np.max(vrw) * np.sqrt(self.rate_hz) * fa),
            acc_bias_instability=float(np.max(um.acc_noise.gm_sigma) * fa),
            descriptions=list(self.descriptions),
        )

    def log_blocks(self, block_rows: int = BLOCK_ROWS):
        """:meth:`blocks` as ImuLog blocks to write (:meth:`SimulatedSession.log`'s units)."""
        for t, acc, gyr, _ in self.blocks(block_rows):
            yield _as_log(t, acc, gyr, self.acc_unit, self.gyro_unit)


def simulate(scheme="paper12", **options) -> SimulatedSession:
    """Simulate a static multi-position session.

    Poses alternate yaw so that consecutive transitions turn about varied axes. The samples are those of
    :class:`SessionStream` (gathered here), whose noise is drawn by sample index from one key drawn after the unit.

    Parameters
    ----------
    scheme : str or (P, 3) array
        A name in :data:`SCHEMES` or sensor-frame up vectors [-].
    **options
        The keywords of :class:`SessionStream`: ``spec``, ``dwell_s``, ``rate_hz``, ``transition_s``, ``rest_s``,
        ``lat``, ``height_m``, ``truth``, ``acc_unit``, ``gyro_unit``, ``acc_counts_per_si``,
        ``gyro_counts_per_si``, ``jitter``, ``orientations``, ``rng``.

    Returns
    -------
    SimulatedSession
        Raw log ``t`` [s], ``acc`` [acc_unit], ``gyro`` [gyro_unit] with the true K, b and up vectors.
    """
    stream = SessionStream(scheme, **options)
    parts = list(zip(*stream.blocks()))
    return stream.session(*(np.concatenate(p) for p in parts))
