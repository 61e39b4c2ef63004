"""Attitude estimators from gyroscope + accelerometer (+ skylight polarization): batch and streaming APIs.

Methods (one measurement model, :mod:`optinav.attitude.measurement`; per-sample loops are numba kernels):

* ``"iframe"`` (default without polarization, and with polarization and a magnetometer) — gyro +
  accelerometer (+ magnetometer, + polarization online) filtered in an almost-inertial frame with rest detection
  and a gyro-bias filter, after VQF (Laidig & Seel 2023); online or offline (forward–backward); see
  :mod:`optinav.attitude.iframe`.
* ``"gd"`` — gradient descent, Madgwick's filter (Madgwick 2010): q̇ = ½ q⊗ω − β ∇F/‖∇F‖.
* ``"cg"`` — conjugate gradient: the same update with the Polak–Ribière+ conjugate direction.
* ``"qn"`` — quasi-Newton as published by Jin et al. (2021, §2.3): the gyro propagates q, then one
  iteration q ← exp(λ_k D_k/2) ⊗ q with D_k = −B_k⁻¹∇F (BFGS), the dynamic step factor
  λ_k = (β₀ + κ‖q̇‖)·Δt (small when the attitude changes little, large when it changes fast) and the state
  threshold (|‖a‖ − g| > ε shrinks the step). B_k lives on the 3-parameter navigation-frame error angle: the
  4×4 Hessian in q-space is singular along q itself, and in navigation coordinates the gravity curvature
  I − u uᵀ is constant, so BFGS can carry it from sample to sample.
* ``"mekf"`` — multiplicative extended Kalman filter with gyro-bias states (the strong baseline).

Inputs: gyr (N, 3) rad/s, acc (N, 3) m/s² (specific force, body axes), dt scalar or (N,) s (the step from
the previous sample to this one), mag (N, 3) any unit (``iframe`` only). ``input_stage=True`` puts the
iframe front end (gyro bias from rest and motion, accelerometer low-passed in the almost-inertial frame) before
gd/cg/qn/mekf (default); ``input_stage=False`` runs them as published. Output q_b^n (N, 4) [w, x, y, z] with n = ``frame`` ("NED": body
forward-right-down; "ENU": body right-forward-up). Without polarization the heading is the gyro's.
"""

from __future__ import annotations

import functools
import threading
import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from optinav.attitude import _kernels
from optinav.attitude.branch import (
    BRANCHES,
    BranchResiduals,
    MIN_HELD,
    HeldBranch,
    field_sets_branch,
    q0_starts,
    stream_branch_error,
    weakest,
)
from optinav.attitude.checks import (
    StartChecks,
    imu_checks,
    body_turned,
    check_mag,
    check_mag_axes,
    check_turning_offset,
    field_rate_sums,
    MagHeld,
    find_gaps,
    gap_error,
    lost_error,
    lost_warning,
    uncertain_steps,
    hard_iron,
    mag_fit_stride,
    scale_bin_rows,
    small_offset,
    end_tail,
    end_up,
    mag_sums,
    zero_rows_missing,
    bin_fields,
    FITTED,
    GIVEN,
    axes_or_change,
    gyro_sums,
    offset_change_error,
    one_offset_error,
    offset_heading,
    offset_held_error,
    offset_tolerated,
    offset_unseen_error,
    offset_pieces,
    measured_before_fit,
    online_fit_failed,
    online_offset_changed,
    rate_sums_less_offset,
)
from optinav.attitude.iframe import (
    AttitudeFilter,
    FilterRun,
    StreamGaps,
    front_outputs,
    hard_iron_online,
    online_fit_held,
    online_fit_result,
    online_fit_state,
    run_iframe,
)
from optinav.attitude.iframe import input_stage as _input_stage
from optinav.attitude.methods import (
    DEFAULTS,
    METHODS,
    _method,
    _options,
    declination_without_mag,
    variant,
)
from optinav.attitude.measurement import (
    PolarizationMeasurement,
    as_c_b_m,
    pol_inputs,
    predicted_aop,
    up_vector,
    wrap_axial,
    unusable_pol_error,
)
from optinav.core.results import (
    Array,
    Entries,
    Estimate,
    Parameter,
    Truth,
    convergence,
    nested_kwargs,
    register_legacy,
)
from optinav.core.rotations import (
    DEFAULT_FRAME,
    euler_from_quat,
    frame_name,
    quat_from_euler,
    quat_from_rotvec,
    quat_multiply,
)
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

__all__ = [
    "METHODS",
    "DEFAULTS",
    "AttitudeFilter",
    "AttitudeEstimate",
    "FilterRun",
    "estimate",
    "estimate_q",
    "initial_attitude",
    "GradientDescent",
    "ConjugateGradient",
    "QuasiNewton",
    "MEKF",
    "make_filter",
]


def filter_convergence() -> dict:
    """The convergence record of a recursive filter (it does not iterate: ``converged`` is None)."""
    return convergence(None, message="recursive filter")


#: why q_b_n and the yaw are not observable when neither the magnetometer nor polarization was used
NO_HEADING = "no magnetometer or polarization used: the heading follows the gyro from its initial value"


@dataclass
class AttitudeEstimate(Estimate):
    """Estimated attitude q_b^n per sample and how the measurements were used (docs/results.md).

    :meth:`parameters`: ``q_b_n`` (N, 4), ``roll``/``pitch``/``yaw`` (N,) rad in the frame's Euler
    convention (the yaw not observable without a magnetometer or polarization: it follows the gyro from the
    initial heading) and ``gyr_bias`` (3,) rad/s, the final gyro-bias estimate, where the method has one."""

    SCHEMA: ClassVar[str] = "optinav.attitude.estimate"
    VERSION: ClassVar[int] = 9
    SYSTEM: ClassVar[str] = "attitude"
    KIND: ClassVar[str] = "estimate"
    #: checked when a file is loaded: a number or null for q_b_n, nulls or text in rest, gyr_bias or pol_skipped
    #: ended in an internal TypeError in the report
    ENTRIES: ClassVar[dict] = {
        **Estimate.ENTRIES,
        "q_b_n": Array((None, 4), finite=True),
        "att_std": Array((None, 3), finite=True),
        "gyr_bias": Array((3,), finite=True),
        "rest": Array((None,), finite=True),
        "acc_used": Array((None,), finite=True),
        "mag_used": Array((None,), finite=True),
        "mag_hard_iron": Array((3,), finite=True),
        "pol_skipped": Entries(others="count"),
        "pol_branch_rms": Array((2,), finite=True),
    }

    q_b_n: np.ndarray = field(metadata={"unit": ""})
    method: str = "iframe"
    frame: str = DEFAULT_FRAME
    options: dict = field(default_factory=dict)
    pol_used: int = 0
    pol_skipped: dict = field(default_factory=dict)
    #: polarization alone without q0: the AoP residual RMS of iframe run from the heading's branch taken and from
    #: the one 180° away (:mod:`optinav.attitude.branch`; with time gaps, of the segment whose other came closest);
    #: None where nothing was decided (q0 or a magnetometer fixed the branch, no polarization used)
    pol_branch_rms: np.ndarray | None = field(default=None, metadata={"unit": "rad"})
    acc_threshold_hits: int = 0
    att_std: np.ndarray | None = field(default=None, metadata={"unit": "rad"})
    gyr_bias: np.ndarray | None = field(default=None, metadata={"unit": "rad/s"})
    rest: np.ndarray | None = field(default=None, metadata={"unit": ""})
    acc_used: np.ndarray | None = field(default=None, metadata={"unit": ""})
    mag_used: np.ndarray | None = field(default=None, metadata={"unit": ""})
    #: iframe online: the fraction of samples whose field was used less a body-fixed offset fitted while disturbed
    #: (a magnet on the board); None without a magnetometer or where not fitted (offline, other methods)
    mag_offset_used: float | None = field(default=None, metadata={"unit": ""})
    #: the magnetometer's hard-iron offset subtracted from every row (its unit), given (``mag_hard_iron=``) or, offline,
    #: fitted from the recording (``mag_hard_iron_fitted``); None: none subtracted
    mag_hard_iron: np.ndarray | None = field(default=None, metadata={"unit": "magnetometer's"})
    mag_hard_iron_fitted: bool = False
    #: online, an uncalibrated magnetometer: the sample from which the field was used less ``mag_hard_iron``, fitted
    #: from that sample and those before it (:func:`~optinav.attitude.iframe.hard_iron_online`; refined since, the
    #: offset the last one), the heading from there starting anew from the field less it. None: not fitted online
    mag_hard_iron_from: int | None = None
    #: rows holding a magnetometer sample (a slower magnetometer on the IMU's rows has NaN rows between); None: no
    #: magnetometer
    mag_rows: int | None = None
    offline: bool = False
    input_stage: bool = False
    segments: int = 1
    elapsed_s: float = field(default=0.0, metadata={"unit": "s"})
    #: a filter does not iterate to convergence: ``converged`` is None
    convergence: dict = field(default_factory=lambda: filter_convergence())
    gates: list = field(default_factory=list)

    @property
    def declination(self) -> float:
        """rad, east positive: the magnetic declination the magnetometer's heading was turned by to the true one
        (iframe's option; 0: the heading magnetic, as in files written before the option)."""
        return float(self.options.get("declination", 0.0)) if self.method == "iframe" else 0.0

    @property
    def mag_used_before_fit(self) -> bool:
        """With :attr:`mag_hard_iron_from`: whether the field was used as measured before it (the offset turns its
        heading little: :func:`checks.measured_before_fit`); else it was unused there, the heading the gyro's."""
        k = self.mag_hard_iron_from
        return k is not None and self.mag_used is not None and bool(np.any(self.mag_used[:k]))

    def parameters(self) -> dict[str, Parameter]:
        e = self.euler()
        heading = self.pol_used > 0 or (self.mag_used is not None and bool(np.any(self.mag_used)))
        why = None if heading else NO_HEADING
        out = {
            "q_b_n": Parameter(self.q_b_n, "", observable=heading, reason=why),
            "roll": Parameter(e[:, 0], "rad"),
            "pitch": Parameter(e[:, 1], "rad"),
            "yaw": Parameter(e[:, 2], "rad", observable=heading, reason=why),
        }
        if self.gyr_bias is not None:
            out["gyr_bias"] = Parameter(np.asarray(self.gyr_bias, float), "rad/s")
        return out

    def euler(self) -> np.ndarray:
        """The estimated attitude as Euler angles in the frame's convention.

        Returns
        -------
        (N, 3) ndarray
            [roll, pitch, yaw] [rad].
        """
        return euler_from_quat(self.q_b_n, frame_name(self.frame))

    def summary(self) -> str:
        """One line: method, frame, samples, rest / magnetometer / polarization use.

        Returns
        -------
        str
            The line.
        """
        return summary_line(
            self.method,
            self.frame,
            self.q_b_n.shape[0],
            offline=self.offline,
            input_stage=self.input_stage,
            segments=self.segments,
            rest=None if self.rest is None else float(np.mean(self.rest)),
            mag_used=None if self.mag_used is None else float(np.mean(self.mag_used)),
            mag_rows=self.mag_rows,
            mag_offset_used=self.mag_offset_used,
            mag_hard_iron=self.mag_hard_iron,
            mag_hard_iron_fitted=self.mag_hard_iron_fitted,
            mag_hard_iron_from=self.mag_hard_iron_from,
            mag_used_before_fit=self.mag_used_before_fit,
            pol_used=self.pol_used,
            pol_skipped=self.pol_skipped,
            pol_branch_rms=self.pol_branch_rms,
            declination=self.declination,
        )


def summary_line(
    method: str,
    frame: str,
    n: int,
    *,
    offline: bool = False,
    input_stage: bool = False,
    segments: int = 1,
    rest: float | None = None,
    mag_used: float | None = None,
    pol_used: int = 0,
    pol_skipped: dict | None = None,
    mag_offset_used: float | None = None,
    mag_hard_iron=None,
    mag_hard_iron_fitted: bool = False,
    mag_rows: int | None = None,
    mag_hard_iron_from: int | None = None,
    mag_used_before_fit: bool = False,
    declination: float = 0.0,
    pol_branch_rms=None,
) -> str:
    """One line on an estimate of ``n`` samples, starting with its :func:`variant`; ``rest``/``mag_used`` the
    fractions of samples at rest and with the magnetometer used, ``mag_offset_used`` of those used less a fitted
    body-fixed offset; ``mag_hard_iron`` the hard-iron offset subtracted (fitted from the recording or given; with
    ``mag_hard_iron_from``, fitted online from past samples and used from that sample on, the field before it as
    measured with ``mag_used_before_fit``, else unused);
    ``mag_rows`` the rows holding a magnetometer sample: fewer than ``n`` (a slower magnetometer), the share is
    of those; ``declination`` (rad, east positive) the one the magnetometer's heading was turned by (0: none);
    ``pol_branch_rms`` (2,) rad: the AoP residual RMS from the heading branch the recording took and from the other
    (None: none decided)."""
    pol_skipped = pol_skipped or {}
    skipped = sum(pol_skipped.values())
    s = f"{variant(method, offline=offline, input_stage=input_stage)}: {n} samples ({frame})"
    if segments > 1:
        s += f", {segments} segments between time gaps"
    if rest is not None:
        s += f"; rest {100 * rest:.0f} %"
    if mag_used is not None:
        if mag_rows is not None and 0 < mag_rows < n:
            s += f"; magnetometer used {100 * mag_used * n / mag_rows:.0f} % of its {mag_rows} samples"
        else:
            s += f"; magnetometer used {100 * mag_used:.0f} %"
        if mag_offset_used:
            s += f" ({100 * mag_offset_used:.0f} % less a body-fixed offset fitted while disturbed, e.g. a magnet on the board)"
        if mag_hard_iron is not None:
            b = ", ".join(f"{v:.4g}" for v in np.asarray(mag_hard_iron, float))
            how = "fitted from the recording's rotations" if mag_hard_iron_fitted else "given"
            if mag_hard_iron_from is not None:
                before = (
                    "as measured before it (the heading off by what the offset turns it)"
                    if mag_used_before_fit
                    else "the heading before it the gyro's from the start"
                )
                how = f"fitted online from past samples; the magnetometer used from sample {mag_hard_iron_from} on, {before}"
            s += f"; magnetometer offset [{b}] subtracted ({how})"
        if declination:
            side = "E" if declination > 0 else "W"
            s += f"; true heading (magnetic declination {abs(np.degrees(declination)):.2f}° {side})"
    if pol_used or skipped:
        s += f"; polarization used {pol_used}, skipped {skipped} " + str(pol_skipped)
    if pol_branch_rms is not None:
        a, b = np.degrees(pol_branch_rms)
        s += f"; heading branch chosen by the data (AoP residual RMS {a:.2f}° against {b:.2f}° from 180° away)"
    return s


def _hard_iron(offset, mag) -> np.ndarray:
    """The hard-iron offset ``mag_hard_iron`` as a finite (3,) array, or ``"online"``; refused without a
    magnetometer."""
    if mag is None:
        raise OptinavError(
            "mag_hard_iron was given without a magnetometer", "pass mag= (--mag, --mag-columns or --mag-file)"
        )
    if isinstance(offset, str) and offset == "online":
        return offset
    b = as_float_array(offset, "mag_hard_iron", last_dims=(3,))
    if b.shape != (3,):
        raise OptinavError(f"mag_hard_iron has shape {b.shape}, expected (3,)", "give one offset BX,BY,BZ")
    return b


def _as_dt(dt, n: int) -> np.ndarray:
    d = as_float_array(dt, "dt")
    if d.ndim == 0:
        d = d.reshape(1)
    elif d.shape != (n,):
        raise OptinavError(f"dt has shape {d.shape}, expected a scalar or ({n},)", "pass one step per sample")
    if np.any(d <= 0):
        raise OptinavError(
            f"dt has {int(np.count_nonzero(d <= 0))} non-positive step(s)",
            "pass strictly positive time steps in s (check the time column)",
        )
    check_step(float(d[0]) if d.size == 1 else float(np.median(d)))  # one step: no median (a streamed sample)
    return np.ascontiguousarray(d)


#: the longest sample step (s) of an IMU log an attitude is estimated from (2 Hz); single gaps may be longer
MAX_STEP_S = 0.5


def check_step(dt: float, name: str = "dt") -> None:
    """Refuse a (median) step beyond MAX_STEP_S: a rate in Hz or a step in ms passed as ``dt`` ran with exit 0
    (dt = 100: 11.6° tilt error on a simulated flight) or was taken for a gyro in deg/s."""
    if not (np.isfinite(dt) and dt <= MAX_STEP_S):
        raise OptinavError(
            f"{name} = {dt:g} s is no IMU sample step (at most {MAX_STEP_S:g} s)",
            f"pass the step in seconds: a rate of 100 Hz is {name} = 0.01 (a step of 10 ms too)",
        )


def default_step(rate_hz: float | None, dt: float | None) -> float | None:
    """A streaming filter's default step [s] from ``rate_hz`` [Hz] or ``dt`` [s] (``dt`` wins), None without
    either; a rate below an IMU's (a step given as a rate) or a non-positive step is refused."""
    if dt is None and rate_hz is not None:
        if not (np.isfinite(rate_hz) and rate_hz > 0):  # 0 raised ZeroDivisionError, -100 named "dt=-0.01"
            raise OptinavError(f"rate_hz={rate_hz!r} must be a positive sample rate in Hz", "pass rate_hz > 0 or dt")
        dt = 1.0 / float(rate_hz)
    if dt is not None and not (np.isfinite(dt) and dt > 0):
        raise OptinavError(f"dt={dt!r} must be a positive step in s", "pass rate_hz or dt > 0")
    if dt is not None and rate_hz is not None and dt > MAX_STEP_S:
        raise OptinavError(
            f"rate_hz = {rate_hz:g} Hz is no IMU sample rate (at least {1 / MAX_STEP_S:g} Hz)",
            "pass the rate in Hz (dt= takes the step in seconds)",
        )
    if dt is not None:
        check_step(float(dt))
    return None if dt is None else float(dt)


def _as_q0(q0) -> np.ndarray:
    q = as_float_array(q0, "q0", last_dims=(4,))
    if q.shape != (4,) or np.linalg.norm(q) == 0:
        raise OptinavError(
            f"q0 must be one non-zero quaternion [w, x, y, z], got shape {q.shape}", "pass e.g. q0=[1, 0, 0, 0]"
        )
    return q / np.linalg.norm(q)


def _as_heading0(heading0) -> float | None:
    """A filter's ``heading0`` (rad, a turn about up) as a finite float, or None."""
    if heading0 is None:
        return None
    h = float(as_float_array(heading0, "heading0"))
    if not np.isfinite(h):
        raise OptinavError(f"heading0 = {heading0!r} is not finite", "pass a turn about up in rad, e.g. 0 or pi")
    return h


def initial_attitude(
    acc0,
    frame: str = DEFAULT_FRAME,
    pol: PolarizationMeasurement | None = None,
    index: int = 0,
    heading0: float = 0.0,
    other_root: bool = False,
) -> np.ndarray:
    """q_b^n from one accelerometer sample (roll, pitch; yaw 0) turned about up by ``heading0`` and, if ``pol`` is
    usable at ``index``, to the heading nearest that which explains its AoP.

    A zenith-viewing sensor sees the same AoP at heading ψ and ψ + π (a tilted one at two headings): one sample
    cannot tell the two branches apart. :func:`estimate` without q0 or a magnetometer runs from either and lets the
    recording decide (:mod:`optinav.attitude.branch`); a streaming filter needs q0, ``heading0`` or a magnetometer.

    Parameters
    ----------
    acc0 : (3,) array
        Specific force [m/s^2] (only its direction is used).
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.
    pol : PolarizationMeasurement or None
        Polarization samples.
    index : int
        The sample of ``pol`` to use.
    heading0 : float
        A turn about the up direction [rad] (counter-clockwise seen from above) from the levelled attitude: the
        AoP's heading nearest it is taken (0: the branch with |ψ| ≤ 90° of a level sensor).
    other_root : bool
        Take the AoP's other heading, the other branch (without a usable sample, or a second one: ``heading0`` +
        π).

    Returns
    -------
    (4,) ndarray
        q_b^n [-] as [w, x, y, z].
    """
    frame = frame_name(frame)
    a = np.asarray(acc0, dtype=float)
    na = np.linalg.norm(a)
    if not np.isfinite(na) or na == 0:
        raise OptinavError("the first accelerometer sample is zero or not finite", "pass q0 or drop the sample")
    u = a / na
    if frame == "ned":  # FRD body: a = g·[sin θ, −sin φ cos θ, −cos φ cos θ]
        roll, pitch = np.arctan2(-u[1], -u[2]), np.arctan2(u[0], np.hypot(u[1], u[2]))
    else:  # RFU body, ENU convention C = Rz(ψ)Rx(θ)Ry(φ): a = g·[−sin φ cos θ, sin θ, cos φ cos θ]
        roll, pitch = np.arctan2(-u[0], u[2]), np.arctan2(u[1], np.hypot(u[0], u[2]))
    q = quat_from_euler([roll, pitch, 0.0], frame)
    up = up_vector(frame)
    turn = float(heading0) + (np.pi if other_root else 0.0)
    if pol is not None and pol.select(slice(index, index + 1)).usable()[0][0]:
        turns = np.radians(np.arange(-180.0, 180.0, 0.5))
        qs = quat_multiply(quat_from_rotvec(turns[:, None] * up), q)
        sn = pol.sun_n[index if pol.sun_n.shape[0] > 1 else 0]
        cost = np.abs(wrap_axial(predicted_aop(qs, sn, pol.C_b_m, frame) - pol.aop[index]))
        best = turns[np.argmin(cost)]
        off = np.angle(np.exp(1j * (best - heading0)))
        if abs(off) > np.pi / 2:  # the half turn about up centred on heading0: a level sensor's roots are π apart
            best -= np.sign(off) * np.pi
        turn = best
        if other_root:  # the AoP's other heading: of its error's minima about up the one farthest from that
            low = np.flatnonzero((cost < np.roll(cost, 1)) & (cost <= np.roll(cost, -1)))
            far = np.abs(np.angle(np.exp(1j * (turns[low] - best))))
            turn = turns[low[np.argmax(far)]] if far.max() > np.pi / 4 else best + np.pi
    q = quat_multiply(quat_from_rotvec(turn * up), q)
    return q / np.linalg.norm(q)


def one_pol_sample(pol_sample, C_b_m, frame: str, thresholds: dict) -> PolarizationMeasurement:
    """The :class:`PolarizationMeasurement` of one streamed ``pol_sample`` (aop, sun_n) or (aop, sun_n, dop) [rad,
    -, -] with the filter's mounting ``C_b_m`` and skip ``thresholds`` (min_sun_elevation, min_dop,
    min_sun_separation)."""
    if len(pol_sample) not in (2, 3):
        raise OptinavError("pol_sample must be (aop, sun_n) or (aop, sun_n, dop)", "pass a tuple")
    dop = None if len(pol_sample) == 2 or pol_sample[2] is None else [pol_sample[2]]
    return PolarizationMeasurement(
        np.array([pol_sample[0]], dtype=float), pol_sample[1], dop, C_b_m, frame, **thresholds
    )


def _pol_arrays(pol, n: int, frame: str):
    use, sn, cbm, aop, min_d2, skipped = pol_inputs(pol, n, frame, "the IMU")
    return use, sn, cbm, np.cos(2 * aop), np.sin(2 * aop), min_d2, skipped


def _init_state(method: str, q: np.ndarray, opts: dict) -> np.ndarray:
    if method in ("gd", "cg"):
        s = np.zeros(13)
        s[:4] = q
    elif method == "qn":
        s = np.zeros(13)
        s[:4] = q
        s[4:13] = np.eye(3).ravel()
    else:
        s = np.zeros(43)
        s[:4] = q
        P = np.diag([opts["init_att_std"] ** 2] * 3 + [opts["init_bias_std"] ** 2] * 3)
        s[7:43] = P.ravel()
    return s


#: no per-sample rows wanted (mekf's own bias state per sample: estimate() and update() keep only the last)
_NO_ROWS = np.empty((0, 3))


def _run(
    method, opts, state, gyr, acc, dt, un, use, sn, cbm, c2, s2, min_d2, out, std, counts, staged, own_bias=_NO_ROWS
):
    """One method's kernel over a chunk; ``staged``: behind the input stage (mekf: gravity rows leave the bias);
    ``own_bias`` (N, 3) rad/s gets mekf's bias state after each sample, or has 0 rows (not kept)."""
    if method in ("gd", "cg"):
        _kernels.run_gd_cg(
            gyr,
            acc,
            dt,
            un,
            use,
            sn,
            cbm,
            c2,
            s2,
            opts["pol_weight"],
            min_d2,
            opts["gain"],
            method == "cg",
            int(opts.get("restart", 1)),
            state,
            out,
            counts,
        )
    elif method == "qn":
        _kernels.run_qn(
            gyr,
            acc,
            dt,
            un,
            use,
            sn,
            cbm,
            c2,
            s2,
            opts["pol_weight"],
            min_d2,
            opts["gain"],
            opts["rate_gain"],
            opts["max_step"],
            opts["gravity"],
            opts["acc_threshold"],
            opts["acc_shrink"],
            opts["h_reset"],
            state,
            out,
            counts,
        )
    else:
        _kernels.run_mekf(
            gyr,
            acc,
            dt,
            un,
            use,
            sn,
            cbm,
            c2,
            s2,
            1.0,
            min_d2,
            opts["gyro_noise"],
            opts["bias_noise"],
            opts["acc_noise_density"],
            opts["pol_noise"],
            opts["gravity"],
            opts["acc_threshold"],
            opts["acc_inflate"],
            opts["max_heading_std"],
            opts["couple_heading"] == 0.0,
            staged,
            state,
            out,
            std,
            own_bias,
            counts,
        )


def no_mag_error() -> OptinavError:
    """A magnetometer given without one usable sample: the heading would come from the gyro alone."""
    return OptinavError(
        "the magnetometer has no sample with three finite values, not all zero: the heading would come from the "
        "gyro alone",
        "check --mag-columns or the MagneticField topic's time stamps (another clock?), or drop --mag",
    )


def _checked_imu(gyr, acc, mag=None, *, whole: bool = True):
    """(N, 3) float arrays gyr, acc (and mag or None) with matching N >= 1; ``whole``: the whole recording, whose
    magnetometer must have a finite sample (a chunk of a stream may have none: a slow magnetometer's NaN rows)."""
    gyr = as_float_array(gyr, "gyr", last_dims=(3,))
    acc = as_float_array(acc, "acc", last_dims=(3,))
    if gyr.ndim != 2 or acc.ndim != 2 or gyr.shape[0] == 0:
        raise OptinavError(f"gyr {gyr.shape} and acc {acc.shape} must be (N, 3) with N >= 1", "pass one row per sample")
    if acc.shape != gyr.shape:
        raise OptinavError(f"gyr has {gyr.shape[0]} samples but acc has {acc.shape[0]}", "align the two triads")
    if mag is not None:
        mag = as_float_array(mag, "mag", last_dims=(3,), finite=False)
        if mag.shape != gyr.shape:
            raise OptinavError(f"mag has shape {mag.shape}, expected {gyr.shape}", "align the magnetometer")
        mag = zero_rows_missing(mag)
        if whole and not np.isfinite(mag).all(axis=1).any():
            raise no_mag_error()
        mag = np.ascontiguousarray(mag)
    return np.ascontiguousarray(gyr), np.ascontiguousarray(acc), mag


def _beside(fn):
    """``fn()`` started in a thread, beside the caller's work (a numba kernel that releases the GIL runs on another
    core); the returned callable waits for it and gives its result, or raises its error. Left unjoined (the
    caller raised first), the daemon thread ends with its kernel and its result goes."""
    out: dict = {}

    def work():
        try:
            out["result"] = fn()
        except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
            out["error"] = exc

    thread = threading.Thread(target=work, daemon=True)
    thread.start()

    def join():
        thread.join()
        if "error" in out:
            raise out["error"]
        return out["result"]

    return join


def _timed(fn):
    """Set ``elapsed_s`` of the returned result to the wall time of the call (s)."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        t0 = time.perf_counter()
        res = fn(*args, **kwargs)
        res.elapsed_s = time.perf_counter() - t0
        return res

    return run


@_timed
def estimate(
    gyr,
    acc,
    dt,
    *,
    pol: PolarizationMeasurement | None = None,
    method: str | None = None,
    frame: str = DEFAULT_FRAME,
    q0=None,
    mag=None,
    mag_hard_iron=None,
    offline: bool = False,
    input_stage: bool = True,
    allow_gaps: bool = False,
    checks: bool = True,
    **options,
) -> AttitudeEstimate:
    """Attitude q_b^n of a recording as an :class:`AttitudeEstimate`; :func:`estimate_q` returns only ``q_b_n``.

    Without ``pol`` roll and pitch are observed and the heading follows the gyro, or the magnetometer (iframe).
    With ``pol`` and neither ``q0`` nor a magnetometer field from its first sample, the AoP gives the heading up to
    its branch (ψ or ψ + 180° for a level zenith-viewing sensor): iframe is run from either and the branch whose AoP
    residuals are lower by more than the noise is taken (the summary says so, ``pol_branch_rms``); gd/cg/qn/mekf
    start on it, from the start that holds it (:mod:`optinav.attitude.branch`). Branches alike (a level body) are
    refused, naming ``q0``. From ``q0`` its branch is taken, refused where the AoP contradicts it (the other
    branch, or a turn of its heading beyond 45°). Bad input raises :class:`OptinavError`.

    Parameters
    ----------
    gyr : (N, 3) array
        Angular rate ω_ib^b [rad/s].
    acc : (N, 3) array
        Specific force [m/s^2], body axes.
    dt : float or (N,) array
        Sample step [s].
    pol : PolarizationMeasurement or None
        Skylight-polarization samples.
    method : str or None
        "iframe" (default without ``pol``, and with ``pol`` and ``mag`` or ``offline``), "mekf" (default with
        ``pol`` alone online), "qn", "gd" or "cg".
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.
    q0 : (4,) array or None
        Initial attitude q_b^n [-] ([w, x, y, z]); None: levelled from acc[0], heading from the polarization on
        the branch the recording shows (above) or the field's, else 0.
    mag : (N, 3) array or None
        Magnetometer [any unit] (iframe): a magnetic heading, or the true one with the option ``declination``
        [rad, east positive] (docs/conventions.md).
    mag_hard_iron : (3,) array, "online" or None
        The magnetometer's hard-iron offset [its unit], subtracted from every row. None: with ``checks``, a field
        norm that follows the orientation as a constant offset makes it is fitted (:func:`checks.hard_iron`):
        subtracted offline; online fitted from past samples instead (as ``"online"`` does, iframe:
        :func:`~optinav.attitude.iframe.hard_iron_online`), the heading starting anew from the field less it where
        that fit passes its gates (``mag_hard_iron_from`` of the result), and refused when it never does (naming
        the offset to pass here). Before, the field is used as measured where the whole recording's offset turns
        its heading by under 20° (:func:`checks.measured_before_fit`; ``mag_used_before_fit``), else unused.
    offline : bool
        Use the whole recording (iframe; with ``pol`` too).
    input_stage : bool
        Put the iframe front end (gyro bias, accelerometer filtered in an almost-inertial frame) before
        gd/cg/qn/mekf (default); False runs them exactly as published. iframe has it built in.
    allow_gaps : bool
        Restart after a time gap instead of refusing it.
    checks : bool
        Run the input checks (units, swaps, clipping, …) and, with polarization and ``q0``, the check that the AoP
        does not contradict q0 (iframe run from q0 turned 180° about up beside it); False: inputs already judged
        (a Monte Carlo's or a tuning's repeated runs on one judged flight).
    **options
        Override :data:`DEFAULTS` of the method.

    Returns
    -------
    AttitudeEstimate
        ``q_b_n`` (N, 4) q_b^n [w, x, y, z] plus per-sample flags, counts and σ [rad].
    """
    frame = frame_name(frame)
    method = _method(method, pol, mag is not None, offline)
    opts = _options(method, options)
    if mag is None and opts.get("declination"):
        raise declination_without_mag()
    gyr, acc, mag = _checked_imu(gyr, acc, mag)
    n = gyr.shape[0]
    dts = _as_dt(dt, n)
    fitted, online_fit, measured = False, False, False
    if mag_hard_iron is not None:
        mag_hard_iron = _hard_iron(mag_hard_iron, mag)
        online_fit = isinstance(mag_hard_iron, str)
        mag_hard_iron = None if online_fit else mag_hard_iron
        if online_fit and (offline or method != "iframe"):
            raise OptinavError(
                'mag_hard_iron="online" fits the offset in the online iframe estimate only',
                "drop it: offline the offset is fitted from the whole recording",
            )
    if mag is not None and method != "iframe":
        raise OptinavError(f"method {method} takes no magnetometer", "use --method iframe with --mag-columns")
    if offline and method != "iframe":
        raise OptinavError(f"method {method} has no offline mode", "use --method iframe with --offline")
    if pol is not None and len(pol) == n and n:
        use, skipped = pol.usable()
        if not use.any():  # asked for, none usable: the heading was the start's with exit 0
            raise unusable_pol_error(skipped, n)
    gaps = find_gaps(dts)
    lost, lost_turn = uncertain_steps(dts, gyr)
    # polarization alone without q0: the heading's branch is the recording's to decide, from iframe's runs from
    # either (optinav.attitude.branch); a magnetometer's field picks it as the estimate starts
    decide = pol is not None and q0 is None and mag is None
    # from q0 its branch is taken, and the AoP must not contradict it (a q0 180° off ran 179° off, an AoP of the
    # other sign 69-108°, its reference axis 90° off 90°, all with exit 0)
    confirm = checks and pol is not None and q0 is not None and mag is None and not gaps.size
    branch_opts = opts if method == "iframe" else _options("iframe", {})
    ahead = None
    if checks and not gaps.size and (decide or confirm or method == "iframe" and mag is None):
        # the checks judge these inputs and change none of them: the estimate runs beside them (its kernel releases
        # the GIL; 1 M samples of BROAD 02: 0.42 s, the checks 0.18 s), kept only where they pass
        ahead = _beside(
            lambda: (
                _branch_runs(gyr, acc, dts, pol, frame, branch_opts, _as_q0(q0) if confirm else None)
                if decide or confirm
                else run_iframe(
                    gyr, acc, dts, pol=pol, frame=frame, q0=None if q0 is None else _as_q0(q0), offline=offline, **opts
                )
            )
        )
    if checks:
        step = float(np.median(dts))  # the typical step (s) the checks judge by
        rows = scale_bin_rows(step)
        # the field's and the gyro's sums per 0.1-s bin: for the bias range (a turn or a bias) and the field's checks
        turns = None if mag is None else (*field_rate_sums(gyr, mag, rows), rows * step)
        field = None if turns is None else lambda: turns
        imu_checks(gyr, acc, dts, frame, method, opts, input_stage, None if q0 is None else _as_q0(q0), field)
        if mag is not None:
            # a magnetometer (or one axis) that holds its reading while the body turns, before any field check
            # reads its values: a dead axis was refused as a hard-iron offset, whose remedy then ran 3-4° off
            held = MagHeld()
            held.add(gyr, mag, dts)
            held.check()
            tilt = functools.cache(lambda: mag_sums(acc, mag))  # the whole log's tilt-bin sums, once if at all
            checked = mag_hard_iron  # the offset the field checks take off: fitted online, the whole recording's
            turn = None  # rad, the heading turn it gives online (offset_heading): how the field is used before a fit
            if online_fit:  # an uncalibrated magnetometer said so: fitted from past samples below
                got = hard_iron(mag[:: mag_fit_stride(mag.shape[0])])
                checked = None if got is None else got[0]
                turn = None if got is None else offset_heading(checked, *tilt()[:4])
            elif mag_hard_iron is None:
                turned = body_turned(*turns)
                strided = mag[:: mag_fit_stride(mag.shape[0])]
                b = check_mag(strided, offline, online=method == "iframe", turned=turned)
                turn = None if offline or b is None else offset_heading(b, *tilt()[:4])
                # online, an offset that turns the heading little is used as measured from the start (the checks
                # take it off, as they take off the one fitted from past samples)
                tolerated = turn is not None and offset_tolerated(turn, strided, turns, tilt())
                online_fit = b is not None and not offline and not tolerated
                if b is None:  # an offset the recording does not turn every way about
                    b = check_turning_offset(*turns, offline)
                if b is None and offline:  # a residual under those fits' gates that the turning shows
                    b = small_offset(*turns, tilt)
                mag_hard_iron = None if online_fit or tolerated else b
                checked, fitted = b, b is not None and not tolerated
            else:
                check_mag(mag[:: mag_fit_stride(mag.shape[0])], given=mag_hard_iron, turned=body_turned(*turns))
                check_turning_offset(*turns, given=mag_hard_iron)
            # one offset for the whole recording, or none, must hold in every part of it
            less = rate_sums_less_offset(turns[1], checked)
            i = end_tail(n, step)  # the specific force over the last second (as streamed)
            end_bins, end_acc, _, end_count, _ = mag_sums(acc[i:], mag[i:], i)
            up = end_up(end_bins, end_acc, end_count, step)
            pieces = offset_pieces(turns[0], less, turns[2])
            err = offset_change_error(
                pieces, rows, turns[2], checked, offline, bin_fields(turns[0], less), up, tilt() if offline else None
            )
            # the windows of the field as measured (those above where no offset is taken off)
            raw_pieces = functools.cache(lambda p=pieces: p if checked is None else offset_pieces(*turns))
            if err is None and mag_hard_iron is not None:  # subtracted from every row: it must be there at each
                err = offset_held_error(*turns[:2], turns[2], rows, mag_hard_iron, offline)
                if err is None:
                    err = one_offset_error(raw_pieces(), *turns, rows, mag_hard_iron, FITTED if fitted else GIVEN)
            if err is None and checked is None and not online_fit:  # no offset taken out: it must turn about zero
                err = offset_unseen_error(pieces, *turns, rows, mag[:: mag_fit_stride(mag.shape[0])], offline, tilt)
            # the field the estimate uses: less the offset it subtracts. Before an offset the field turns about is
            # refused: a mirrored frame or a magnetometer in other axes turns it about a point off zero too, and
            # one that changes within the recording (its parts' offsets then tell)
            hold = held.hold_s(step)  # how late the field is for being held on the rows between readings
            try:
                check_mag_axes(acc, mag if checked is None else mag - checked, step, gyr, held_s=hold)
            except OptinavError as refused:
                up = field_rate_sums(gyr, acc, rows)  # the specific force the lag check judges the yaw rate about
                raise axes_or_change(
                    refused, err, raw_pieces(), rows, turns[2], *turns[:2], tilt(), gyro_sums(gyr), step, None, up, hold
                ) from None
            if err is not None:
                raise err
            measured = online_fit and turn is not None and measured_before_fit(turn)
    if mag_hard_iron is not None:
        mag = mag - mag_hard_iron
    if gaps.size and not allow_gaps:
        raise gap_error(float(dts[gaps[0]]), int(gaps[0]), gaps.size)
    if lost.size and not allow_gaps:
        raise lost_error(float(dts[lost[0]]), int(lost[0]), lost_turn)
    if lost.size and checks:
        lost_warning(lost_turn)
    hi_from = early = None
    if online_fit:
        # the offset from each sample and those before it: the gaps' segments continue one fit (a sensor property),
        # each gap a typical step (as the segments take it, and a log read in blocks)
        fit_dt = dts.copy() if gaps.size else dts
        fit_dt[gaps] = np.median(dts)
        raw, (mag, fs) = mag, hard_iron_online(mag, fit_dt, online_fit_state(measured), gyr=gyr)
        mag_hard_iron, hi_from = online_fit_result(fs)
        if hi_from is None:  # no one offset where the field's parts show a change, else the fit's
            changed = None
            if checks and checked is not None:
                changed = one_offset_error(raw_pieces(), *turns, rows, checked, FITTED)
            raise changed or online_fit_failed(raw[:: mag_fit_stride(raw.shape[0])])
        held = online_fit_held(fs)
        if held is not None and held[1] >= opts["mag_new_time"]:  # as long as a new field takes to be believed
            raise online_offset_changed(*held)
        fitted = True
        # before the fit passed, the field as measured: the estimate of those rows alone (its magnetic part then
        # restarts, as the streamed filter's does: _iframe.mag_restart; the tilt and the bias never see the field)
        if measured:
            pre = slice(0, hi_from)
            early = estimate(
                gyr[pre],
                acc[pre],
                dts[pre] if dts.shape[0] > 1 else dts[0],
                method=method,
                frame=frame,
                q0=q0,
                mag=raw[pre],
                pol=None if pol is None else pol.select(pre),
                allow_gaps=allow_gaps,
                checks=False,
                **options,
            )
        mag = mag.copy()
        mag[:hi_from] = np.nan
    mag_rows = None if mag is None else int(np.count_nonzero(np.isfinite(raw if online_fit else mag).all(axis=1)))
    if gaps.size:
        seg_dt = dts.copy()
        seg_dt[gaps] = np.median(dts)  # each segment starts afresh: its first step is a normal one

        def part(a, b):
            m = None if mag is None else mag[a:b]
            # a segment before the online hard-iron fit passed has no field to use: run without (and without the
            # declination, which turns the field's heading only), none used
            none = m is not None and not np.isfinite(m).all(axis=1).any()
            kw = {**options, "declination": 0.0} if none else options
            p = estimate(
                gyr[a:b],
                acc[a:b],
                seg_dt[a:b],
                pol=(None if pol is None else pol.select(slice(a, b))),
                method=method,
                frame=frame,
                q0=q0 if a == 0 else None,
                mag=None if none else m,
                offline=offline,
                input_stage=input_stage,
                checks=False,
                allow_gaps=True,  # (refused above unless allowed; a segment's lost samples are bridged)
                **kw,
            )
            if none:
                p.mag_used, p.mag_offset_used = np.zeros(b - a, bool), 0.0
            return p

        parts = [part(a, b) for a, b in zip(np.r_[0, gaps], np.r_[gaps, n])]
        first = parts[0]
        cat = lambda name: None if getattr(first, name) is None else np.concatenate([getattr(p, name) for p in parts])
        return _after(early, AttitudeEstimate(
            q_b_n=cat("q_b_n"),
            method=method,
            frame=frame,
            options=opts,
            pol_used=sum(p.pol_used for p in parts),
            pol_skipped={k: sum(p.pol_skipped.get(k, 0) for p in parts) for k in first.pol_skipped},
            acc_threshold_hits=sum(p.acc_threshold_hits for p in parts),
            att_std=cat("att_std"),
            gyr_bias=parts[-1].gyr_bias,
            rest=cat("rest"),
            acc_used=cat("acc_used"),
            mag_used=cat("mag_used"),
            mag_offset_used=None
            if first.mag_offset_used is None
            else sum(p.mag_offset_used * p.q_b_n.shape[0] for p in parts) / max(n, 1),
            mag_hard_iron=mag_hard_iron,
            mag_hard_iron_fitted=fitted,
            mag_hard_iron_from=hi_from,
            mag_rows=mag_rows,
            offline=offline,
            input_stage=first.input_stage,
            segments=len(parts),
            pol_branch_rms=weakest(p.pol_branch_rms for p in parts),
        ))  # fmt: skip
    other, branch_rms, r, ref = False, None, None, None
    if pol is not None and q0 is None and mag is not None:  # a field that starts after the polarization does not
        decide = not field_sets_branch(mag, pol.usable()[0])
    if decide:
        runs = ahead() if ahead is not None else _branch_runs(gyr, acc, dts, pol, frame, branch_opts)
        k, branch_rms = _branch(runs, pol, frame)
        other, ref = BRANCHES[k], None if branch_rms is None else runs[k].q_b_n
        r = runs[k] if method == "iframe" and not offline and mag is None else None  # the estimate itself
    elif confirm:
        runs = ahead() if ahead is not None else _branch_runs(gyr, acc, dts, pol, frame, branch_opts, _as_q0(q0))
        _branch(runs, pol, frame, _as_q0(q0))
        r = runs[0] if method == "iframe" and not offline else None
    elif ahead is not None:
        r = ahead()
    if method == "iframe":
        if r is None:
            r = run_iframe(
                gyr,
                acc,
                dts,
                mag=mag,
                pol=pol,
                frame=frame,
                q0=None if q0 is None else _as_q0(q0),
                offline=offline,
                other_root=other,
                **opts,
            )
        return _after(early, AttitudeEstimate(
            q_b_n=r.q_b_n,
            method=method,
            frame=frame,
            options=opts,
            gyr_bias=r.gyr_bias[-1].copy(),
            rest=r.rest,
            acc_used=r.acc_used,
            mag_used=r.mag_used,
            mag_offset_used=None if r.offset_used is None else float(np.mean(r.offset_used)),
            mag_hard_iron=mag_hard_iron,
            mag_hard_iron_fitted=fitted,
            mag_hard_iron_from=hi_from,
            mag_rows=mag_rows,
            offline=offline,
            input_stage=True,
            acc_threshold_hits=int(np.count_nonzero(~r.acc_used)),
            pol_used=0 if r.pol_used is None else int(np.count_nonzero(r.pol_used)),
            pol_skipped=r.pol_skipped or {},
            pol_branch_rms=branch_rms,
        ))  # fmt: skip
    front = None
    if input_stage:
        gyr, acc, front = _input_stage(gyr, acc, dts, frame=frame)
    use, sn, cbm, c2, s2, min_d2, skipped = _pol_arrays(pol, n, frame)

    def run_from(q):
        """The method from q_b^n ``q``: its end state, q_b^n (n, 4), σ (n, 3) and counts."""
        state, out, std, counts = (
            _init_state(method, q, opts),
            np.empty((n, 4)),
            np.empty((n, 3)),
            np.zeros(3, np.int64),
        )
        _run(method, opts, state, gyr, acc, dts, up_vector(frame), use, sn, cbm, c2, s2, min_d2, out, std, counts,
             bool(input_stage))  # fmt: skip
        return state, out, std, counts

    if ref is None:
        state, out, std, counts = run_from(_as_q0(q0) if q0 is not None else initial_attitude(acc[0], frame, pol, 0))
    else:
        # from the start on the branch iframe's AoP residuals took, or where it does not hold it, from the other:
        # the other methods' tilt sees the AoP (started in fast motion mekf traded 54° of tilt for the other
        # branch's AoP)
        held = HeldBranch(n)
        for j in (k, 1 - k):
            state, out, std, counts = run_from(initial_attitude(acc[0], frame, pol, 0, other_root=BRANCHES[j]))
            held.add(j, out, [ref])
            if held.share(j) >= MIN_HELD:
                break
        held.verdict(method, prefer=k)
    if pol is not None:
        skipped = dict(skipped)
        skipped["sun_near_sensor_zenith"] = int(counts[_kernels.C_POL_NEAR_ZENITH])
    bias = state[4:7].copy() if method == "mekf" else None
    if front is not None:
        bias = front.gyr_bias[-1] + (0.0 if bias is None else bias)
    return AttitudeEstimate(
        q_b_n=out,
        method=method,
        frame=frame,
        options=opts,
        pol_used=int(counts[0]),
        pol_skipped=skipped,
        acc_threshold_hits=int(counts[_kernels.C_ACC_SHRUNK]),
        att_std=std if method == "mekf" else None,
        gyr_bias=bias,
        rest=None if front is None else front.rest,
        input_stage=input_stage,
        pol_branch_rms=branch_rms,
    )


def _branch_runs(gyr, acc, dts, pol, frame: str, opts: dict, q0=None) -> list[FilterRun]:
    """iframe online from either heading branch (:data:`~optinav.attitude.branch.BRANCHES`), with ``opts``; from
    ``q0`` (4,) and from q0 turned 180° about up where given."""
    if q0 is not None:
        return [run_iframe(gyr, acc, dts, pol=pol, frame=frame, q0=q, **opts) for q in q0_starts(q0, frame)]
    return [run_iframe(gyr, acc, dts, pol=pol, frame=frame, other_root=b, **opts) for b in BRANCHES]


def _branch(runs: list[FilterRun], pol: PolarizationMeasurement, frame: str, q0=None) -> tuple[int, np.ndarray | None]:
    """The branch of :func:`_branch_runs` the recording's AoP takes and the residual RMS (2,) rad of it and of the
    other (:meth:`~optinav.attitude.branch.BranchResiduals.verdict`; refused when alike). From ``q0`` its branch,
    refused where the AoP contradicts it."""
    use, sn, cbm, aop, min_d2, _ = pol_inputs(pol, runs[0].q_b_n.shape[0], frame, "the IMU")
    res = BranchResiduals(cbm, min_d2, up_vector(frame))
    res.add(runs[0].q_b_n, runs[1].q_b_n, use, sn, aop)
    if q0 is not None:
        res.add_turn(runs[0].q_b_n, runs[0].pol_used, q0)
    return res.verdict(fixed=q0 is not None)


def _after(early: AttitudeEstimate | None, est: AttitudeEstimate) -> AttitudeEstimate:
    """``est`` with the attitude and the magnetometer's use of its first rows those of ``early`` (the rows before an
    online hard-iron fit passed, estimated with the field as measured; the tilt, the bias, rest and the
    accelerometer's use never see the field), its share of samples used less a disturbed field's offset over both."""
    if early is None:
        return est
    k, n = early.q_b_n.shape[0], est.q_b_n.shape[0]
    est.q_b_n[:k], est.mag_used[:k] = early.q_b_n, early.mag_used
    est.mag_offset_used = (est.mag_offset_used * n + early.mag_offset_used * k) / max(n, 1)
    return est


def estimate_q(
    gyr,
    acc,
    dt,
    *,
    pol: PolarizationMeasurement | None = None,
    method: str | None = None,
    frame: str = DEFAULT_FRAME,
    q0=None,
    **options,
) -> np.ndarray:
    """The quaternions of :func:`estimate`, without the diagnostics.

    Parameters
    ----------
    gyr, acc, dt, pol, method, frame, q0, **options
        As :func:`estimate` (rad/s, m/s², s).

    Returns
    -------
    (N, 4) ndarray
        q_b^n [-] as [w, x, y, z].
    """
    return estimate(gyr, acc, dt, pol=pol, method=method, frame=frame, q0=q0, **options).q_b_n


# --- streaming ------------------------------------------------------------------------------------------------


class _Filter(StreamGaps):
    """Streaming attitude filter running the same kernel as :func:`estimate`: :meth:`update` one sample,
    :meth:`update_batch` a chunk, :meth:`reset` a new start; ``rate_hz`` [Hz] or ``dt`` [s] gives the default step
    (as :class:`~optinav.attitude.AttitudeFilter`, and a time gap is refused as there); ``input_stage`` as
    :func:`estimate` (default on; False: the method exactly as published). With polarization the heading's branch
    must be known before the first sample it corrects (the outputs cannot wait for the data to decide, as
    :func:`estimate` does): ``q0``, or ``heading0`` (rad, a turn about up from the levelled start:
    :func:`initial_attitude` takes the AoP's heading within 90° of it); else that sample is refused. ``checks``: the
    input checks on the stream's first seconds, as :class:`~optinav.attitude.AttitudeFilter`'s; ``bridge_lost`` as
    its (steps that lost samples where the turn across them is uncertain bridged, warned, not refused)."""

    METHOD = "qn"

    def __init__(
        self,
        frame: str = DEFAULT_FRAME,
        q0=None,
        C_b_m=None,
        *,
        rate_hz: float | None = None,
        dt: float | None = None,
        min_sun_elevation: float = 0.0,
        min_dop: float = 0.05,
        min_sun_separation: float = np.radians(10.0),
        input_stage: bool = True,
        heading0: float | None = None,
        checks: bool = True,
        bridge_lost: bool = False,
        **options,
    ):
        self.dt = default_step(rate_hz, dt)
        self.frame = frame_name(frame)
        self.options = _options(self.METHOD, options)
        self.input_stage = bool(input_stage)
        # the input stage: iframe's own streaming filter, fed the samples estimate() feeds it on the whole log
        self._front = AttitudeFilter(dt=self.dt, frame=self.frame, checks=False) if self.input_stage else None
        if self._front is not None:
            self._front._gap_check = False  # this filter judges the steps
        self._bridge_lost = bool(bridge_lost)
        self._g_last = None  # the gyro sample (3,) of the last update, rad/s
        self._gaps_init()
        self.C_b_m = as_c_b_m(C_b_m, self.frame)  # a bad mounting fails here, not at the first sample
        self._pol_kw = dict(min_sun_elevation=min_sun_elevation, min_dop=min_dop, min_sun_separation=min_sun_separation)
        self._q0 = None if q0 is None else _as_q0(q0)
        self._heading0 = _as_heading0(heading0)
        self._other_root = False  # the start takes the AoP's other root (a log's decision: the other branch)
        self._checks = (
            StartChecks(self.frame, self.METHOD, self.options, self.input_stage, self._q0) if checks else None
        )
        self.state = None
        self.counts = np.zeros(3, dtype=np.int64)
        self._skipped: dict[str, int] = {}
        self._pol_seen = False
        self._out = np.empty((1, 4))
        self._std = np.empty((1, 3))
        self._un = up_vector(self.frame)

    @property
    def q_b_n(self) -> np.ndarray | None:
        """Current q_b^n (None before the first update)."""
        return None if self.state is None else self.state[:4].copy()

    def reset(self, q0=None, heading0: float | None = None) -> None:
        """Start the estimate anew (after a time gap, or a new recording), its input stage too; the counts of
        :attr:`pol_skipped` go on.

        Parameters
        ----------
        q0 : (4,) array or None
            q_b^n [w, x, y, z] [-] to start from; None: levelled from the next sample's accelerometer.
        heading0 : float or None
            Without ``q0``: the turn about up [rad] the levelled start takes, the polarization's heading branch
            (as the constructor's).
        """
        self.state, self._q0 = None, None if q0 is None else _as_q0(q0)
        self._heading0, self._other_root = _as_heading0(heading0), False
        if self._front is not None:
            self._front.reset()
        self._g_last = None
        self._gaps_init()
        self._checks = None if self._checks is None else self._checks.anew(self._q0)

    @property
    def pol_skipped(self) -> dict[str, int]:
        """Polarization samples left out so far, by reason, as :func:`estimate` counts them (with the samples whose
        sun was near the sensor's zenith once a polarization sample was given)."""
        if not self._pol_seen:
            return dict(self._skipped)
        return {**self._skipped, "sun_near_sensor_zenith": int(self.counts[_kernels.C_POL_NEAR_ZENITH])}

    def _check_branch(self, pol) -> None:
        """Refuse a usable polarization sample in ``pol`` (before any state changes) while neither q0 nor heading0
        fixed the heading's branch."""
        if isinstance(pol, PolarizationMeasurement) and self._q0 is None and self._heading0 is None:
            if pol.usable()[0].any():
                raise stream_branch_error()

    def _decided(self, other_root: bool) -> None:
        """Before the first sample, the heading branch a log's runs from either decided
        (:mod:`optinav.attitude.branch`): the start takes the AoP's heading nearest the levelled one, or with
        ``other_root`` the other one."""
        self._heading0, self._other_root = 0.0, bool(other_root)

    def _start(self, acc0, pol) -> np.ndarray:
        """q_b^n to start from at the first sample (``acc0`` its specific force after the input stage, m/s²)."""
        if self._q0 is not None:
            return self._q0
        return initial_attitude(acc0, self.frame, pol, 0, self._heading0 or 0.0, self._other_root)

    def _add_skipped(self, skipped: dict, pol) -> None:
        self._pol_seen = self._pol_seen or pol is not None
        for k, v in skipped.items():
            self._skipped[k] = self._skipped.get(k, 0) + v

    @property
    def gyr_bias(self) -> np.ndarray | None:
        """Gyro bias estimate [rad/s] after the last update: the input stage's plus the MEKF's state (None
        for gd/cg/qn as published)."""
        if self.state is None:
            return None
        own = self.state[4:7].copy() if self.METHOD == "mekf" else None
        if self._front is None:
            return own
        return self._front.gyr_bias + (0.0 if own is None else own)

    @property
    def rest(self) -> bool | None:
        """Whether the input stage detected rest at the last sample (as :attr:`AttitudeEstimate.rest`); None for
        gd/cg/qn/mekf as published, which detect none, and before the first update."""
        return None if self._front is None else self._front.rest

    @property
    def acc_used(self) -> None:
        """None: gd/cg/qn/mekf take every accelerometer sample (as :attr:`AttitudeEstimate.acc_used`)."""
        return None

    @property
    def mag_used(self) -> None:
        """None: gd/cg/qn/mekf take no magnetometer."""
        return None

    @property
    def mag_offset(self) -> None:
        """None: gd/cg/qn/mekf take no magnetometer (iframe's filter gives the body-fixed offset it took out)."""
        return None

    @property
    def att_std(self) -> np.ndarray | None:
        """Attitude-error σ [rad] about the body axes after the last update: mekf's; None for gd/cg/qn."""
        return None

    def _front_step(self, g: np.ndarray, a: np.ndarray, dts: np.ndarray):
        """The input stage on a chunk (its state carried): bias-corrected gyro, filtered specific force and the
        stage's :class:`FilterRun` (None without the stage)."""
        if self._front is None:
            return g, a, None
        if g.shape[0] == 1:  # one sample: the filter's step (same arithmetic, no per-chunk arrays)
            f = self._front
            f.update(g[0], a[0], dt=float(dts[0]))
            r = FilterRun(f.q_b_n[None], np.array([f.rest]), gyr_bias=f.gyr_bias[None])
        else:
            r = self._front.update_batch(g, a, dt=dts if dts.size > 1 else float(dts[0]))  # (1,): one step for all
        return (*front_outputs(r, g, a, self.frame), r)

    def _last_gyro(self) -> np.ndarray | None:
        return self._g_last

    def _step(self, dt) -> float | np.ndarray:
        h = self.dt if dt is None else dt
        if h is None:
            raise OptinavError("no time step for this update", "pass dt= or build the filter with rate_hz")
        return h

    def _no_mag(self, mag) -> None:
        if mag is not None:  # as estimate() refuses it (a keyword of iframe's filter, so one loop can pass it)
            raise OptinavError(f"method {self.METHOD} takes no magnetometer", "use make_filter('iframe') with mag")

    def update(self, gyr, acc, dt=None, pol_sample=None, mag=None) -> np.ndarray:
        """Process one sample: gyr (3,) rad/s, acc (3,) m/s², dt s (None: the filter's); ``pol_sample`` None,
        (aop, sun_n) or (aop, sun_n, dop); ``mag`` only None (refused: iframe's). Returns q_b^n (4,)."""
        self._no_mag(mag)
        g = as_float_array(gyr, "gyr", last_dims=(3,)).reshape(1, 3)
        a = as_float_array(acc, "acc", last_dims=(3,)).reshape(1, 3)
        h = self._step(dt)
        g_in = g[0].copy()
        if self._gap_check and np.ndim(h) == 0 and h > self._odd_s:
            self._judge_step(float(h), g_in)
        dts = _as_dt(h, 1)
        if self._checks is not None and self._checks.sample(g[0], a[0], float(dts[0])):
            self._checks = None  # the inputs passed: nothing is checked after
        pol = None if pol_sample is None else one_pol_sample(pol_sample, self.C_b_m, self.frame, self._pol_kw)
        self._check_branch(pol)
        g, a, _ = self._front_step(np.ascontiguousarray(g), np.ascontiguousarray(a), dts)
        use, sn, cbm, c2, s2, min_d2, skipped = _pol_arrays(pol, 1, self.frame)
        self._add_skipped(skipped, pol)
        if self.state is None:
            self.state = _init_state(self.METHOD, self._start(a[0], pol), self.options)
        _run(self.METHOD, self.options, self.state, g, a, dts, self._un, use, sn, cbm, c2, s2, min_d2, self._out,
             self._std, self.counts, self.input_stage)  # fmt: skip
        self._prev, self._g_last = float(dts[-1]), g_in
        return self._out[0].copy()

    def update_batch(self, gyr, acc, dt=None, pol: PolarizationMeasurement | None = None, mag=None) -> FilterRun:
        """A chunk of samples, with the arithmetic of :func:`estimate` (chunks in turn give its output exactly).

        Parameters
        ----------
        gyr : (N, 3) array
            Angular rate ω_ib^b [rad/s].
        acc : (N, 3) array
            Specific force [m/s^2].
        dt : float, (N,) array or None
            Steps [s]; None: the filter's.
        pol : PolarizationMeasurement or None
            The chunk's polarization samples (N of them).
        mag : None
            Refused unless None: these methods take no magnetometer (iframe's filter does).

        Returns
        -------
        FilterRun
            ``q_b_n`` (N, 4) q_b^n [-] after each sample; behind the input stage its ``rest`` (N,) and
            ``gyr_bias`` (N, 3) [rad/s] (mekf: plus its own bias state; as published mekf's own, gd/cg/qn None);
            mekf's ``att_std`` (N, 3) [rad]; ``acc_used``/``mag_used`` None. N = 0 gives empty arrays.
        """
        self._no_mag(mag)
        g = np.ascontiguousarray(as_float_array(gyr, "gyr", last_dims=(3,)).reshape(-1, 3))
        a = np.ascontiguousarray(as_float_array(acc, "acc", last_dims=(3,)).reshape(-1, 3))
        if g.shape != a.shape:
            raise OptinavError(f"gyr {g.shape} and acc {a.shape} differ in shape", "pass one row per sample")
        n = g.shape[0]
        mekf = self.METHOD == "mekf"
        if n == 0:
            rows = np.empty((0, 3))
            bias = rows if self.input_stage or mekf else None
            rest = np.zeros(0, bool) if self.input_stage else None
            return FilterRun(np.empty((0, 4)), rest, gyr_bias=bias, att_std=rows.copy() if mekf else None)
        dts = _as_dt(self._step(dt), n)
        self._chunk_gaps(dts, g)
        g_in = g[-1].copy()
        if self._checks is not None and self._checks.chunk(g, a, dts):
            self._checks = None  # the inputs passed: nothing is checked after
        self._check_branch(pol)
        g, a, front = self._front_step(g, a, dts)
        use, sn, cbm, c2, s2, min_d2, skipped = _pol_arrays(pol, n, self.frame)
        self._add_skipped(skipped, pol)
        if self.state is None:
            self.state = _init_state(self.METHOD, self._start(a[0], pol), self.options)
        out, std, own = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)) if mekf else _NO_ROWS
        _run(self.METHOD, self.options, self.state, g, a, dts, self._un, use, sn, cbm, c2, s2, min_d2, out, std,
             self.counts, self.input_stage, own)  # fmt: skip
        self._out[0], self._std[0] = out[-1], std[-1]
        self._g_last = g_in
        bias = None if front is None else front.gyr_bias
        if mekf:  # the stage's bias plus the MEKF's own state, as gyr_bias after each update()
            bias = own if bias is None else bias + own
        return FilterRun(out, None if front is None else front.rest, gyr_bias=bias, att_std=std if mekf else None)


class GradientDescent(_Filter):
    """Madgwick's gradient-descent filter (``method="gd"``); options: gain β (rad/s), pol_weight."""

    METHOD = "gd"


class ConjugateGradient(_Filter):
    """Conjugate-gradient filter (``method="cg"``); options: gain β, restart (samples), pol_weight."""

    METHOD = "cg"


class QuasiNewton(_Filter):
    """Quasi-Newton filter of Jin et al. 2021 (``method="qn"``); options in ``DEFAULTS["qn"]``."""

    METHOD = "qn"


class MEKF(_Filter):
    """Multiplicative EKF with gyro bias (``method="mekf"``); options in ``DEFAULTS["mekf"]``."""

    METHOD = "mekf"

    @property
    def att_std(self) -> np.ndarray | None:
        """Attitude-error σ [rad] about the body axes after the last update (None before the first)."""
        return None if self.state is None else self._std[0].copy()


_CLASSES = {"iframe": AttitudeFilter, "gd": GradientDescent, "cg": ConjugateGradient, "qn": QuasiNewton, "mekf": MEKF}


def make_filter(method: str = "iframe", **kwargs):
    """Streaming filter for ``method``.

    Parameters
    ----------
    method : str
        One of :data:`METHODS`.
    **kwargs
        Options as :func:`estimate` (``input_stage`` too: iframe has it built in and takes it as estimate() does;
        ``checks``: its checks, judged once on the stream's first seconds: :class:`AttitudeFilter`).

    Returns
    -------
    AttitudeFilter or a filter of the method
        Feed it with ``update`` (one sample; gd/cg/qn/mekf return q_b^n (4,), iframe None for speed) or
        ``update_batch`` (a chunk: a :class:`FilterRun` for every method); after either, every filter has
        ``q_b_n``, ``rest``, ``gyr_bias`` [rad/s], ``acc_used``, ``mag_used``, ``att_std`` [rad] (None where the
        method has no such output, and before the first sample).
    """
    m = str(method).lower()
    if m not in _CLASSES:
        raise OptinavError(f"unknown method {method!r}", f"use one of {', '.join(METHODS)}")
    if m == "iframe":  # one loop over METHODS with input_stage=... as estimate() takes it (iframe: built in)
        kwargs.pop("input_stage", None)
    return _CLASSES[m](**kwargs)


#: the fields of versions 2-4 that the vocabulary renamed in version 5
_V4_NAMES = {"q": "q_b_n", "gyro_bias": "gyr_bias"}
for _v in (2, 3, 4):  # 2, 3: arrays as {"__ndarray__"}; 4: plain arrays
    register_legacy(
        AttitudeEstimate, "optinav.attitude.estimate", _v, lambda d: nested_kwargs(AttitudeEstimate, d, _V4_NAMES)
    )
# 5: before mag_offset_used (None: not reported); 6: before mag_hard_iron (None: none subtracted); 7: before
# mag_hard_iron_from (None: not fitted online); 8: before pol_branch_rms (None: not decided)
for _v in (5, 6, 7, 8):
    register_legacy(AttitudeEstimate, "optinav.attitude.estimate", _v, lambda d: nested_kwargs(AttitudeEstimate, d))


#: the series of a simulated attitude's truth (:func:`attitude_truth`) and their units
TRUTH_UNITS = {"q_b_n": "", "roll": "rad", "pitch": "rad", "yaw": "rad"}


def attitude_truth_series(q_b_n, frame: str = DEFAULT_FRAME) -> dict:
    """The truth series of attitudes ``q_b_n`` (N, 4): ``q_b_n`` and ``roll``, ``pitch``, ``yaw`` [rad] in
    ``frame``'s Euler convention (:data:`TRUTH_UNITS`), for a truth written block by block."""
    q = np.asarray(q_b_n, float)
    e = euler_from_quat(q, frame_name(frame))
    return {"q_b_n": q, "roll": e[:, 0], "pitch": e[:, 1], "yaw": e[:, 2]}


def attitude_truth(q_b_n, frame: str = DEFAULT_FRAME, info: dict | None = None) -> Truth:
    """A simulated attitude ``q_b_n`` (N, 4) as truth with the names of :class:`AttitudeEstimate`
    (``q_b_n``, ``roll``, ``pitch``, ``yaw`` in ``frame``'s Euler convention)."""
    series = attitude_truth_series(q_b_n, frame)
    return Truth(
        "attitude",
        {n: Parameter(series[n], u) for n, u in TRUTH_UNITS.items()},
        {"frame": frame_name(frame), **(info or {})},
    )
