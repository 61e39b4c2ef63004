"""Simulated dual-axis rotational INS sessions on a static base (truth from :func:`optinav.core.simulate.gimbal`).

A session: a static alignment phase (α = β = 0, default 600 s as in Li et al. 2023 §3), then a rotation
scheme of ±180° (or any) gimbal moves with smooth rate profiles and dwells. The IMU attitude is the exact chain
(inverse of eq. 6)::

    C_s^n(t) = C_b^n · R_y(β) · C_h2^h0(η)ᵀ · R_z(α) · C_h1^s(θ)ᵀ      (model.nonorth_dcm, exact rotations)

IMU errors from the ``"rlg-nav"`` preset (paper Table 1), optionally with larger gyro misalignment and scale
errors (they bias the axis-vector baseline). Encoders: the joint angles plus white noise, rounded to the
encoder resolution. Optional unmodelled effects: *lock error* (each stop of a gimbal ends ε_k away from the
commanded angle the encoder reports, ε_k ~ N(0, σ²)) and *axis wobble* (the outer axis tilts about x_h2 by
``w·sin β``, the inner axis about x_h1 by ``w·sin α``).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import field

import numpy as np

from optinav.core.imu_model import preset
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.rotations import dcm_from_euler
from optinav.core.simulate import AxisSchedule, Move, gimbal
from optinav.core.validate import as_rng, check_positive
from optinav.errors import OptinavError
from optinav.rins.model import PARAM_NAMES, nonorth_dcm

__all__ = ["SCHEMES", "RinsData", "scheme_steps", "simulate", "PAPER_TABLE3"]

#: PSINS improved 16-position dual-axis sequence (Z = inner axis α, Y = outer axis β), ±180° each
_PSINS16 = list(zip("ZYZYYZYZYZYZZYZY", [+1, -1, +1, -1, -1, +1, -1, +1, +1, -1, +1, -1, -1, +1, -1, +1]))

#: scheme name → list of (axis, angle in degrees)
SCHEMES: dict[str, list[tuple[str, float]]] = {
    "psins16": [(a, 180.0 * s) for a, s in _PSINS16],
    "single4": [("Z", 180.0), ("Z", 90.0), ("Z", -180.0), ("Z", -90.0)],
    "dual4": [("Z", 180.0), ("Y", 180.0), ("Z", -180.0), ("Y", -180.0)],
}

#: Table 3 of the paper (labelled degrees), order θx, θy, θz, ηx, ηy, ηz
PAPER_TABLE3 = np.array([-0.000279, -0.000963, -0.002212, 0.000721, -0.000806, -0.009205])


def scheme_steps(scheme) -> list[tuple[str, float]]:
    """Steps ``[(axis 'Z'|'Y', angle deg), ...]`` of a named scheme, a custom text ``"Z+180,Y-180,..."``
    or a list of pairs."""
    if isinstance(scheme, str):
        if scheme in SCHEMES:
            return list(SCHEMES[scheme])
        steps = []
        for tok in scheme.split(","):
            m = re.fullmatch(r"\s*([ZzYy])\s*([+-]?\d+(?:\.\d*)?)\s*", tok)
            if not m:
                raise OptinavError(
                    f"rotation scheme {scheme!r} is neither a preset nor a step list",
                    f"use one of {', '.join(SCHEMES)} or steps like 'Z+180,Y-180,Z-180'",
                )
            steps.append((m.group(1).upper(), float(m.group(2))))
        return steps
    steps = [(str(a).upper(), float(d)) for a, d in scheme]
    if any(a not in ("Z", "Y") for a, _ in steps):
        raise OptinavError("scheme axes must be 'Z' (inner, α) or 'Y' (outer, β)", "fix the scheme")
    return steps


@dataclasses.dataclass(eq=False)
class RinsData(Result):
    """A rotational-INS recording: IMU increments and encoder angles at common epochs (+ truth if simulated).

    Row k: ``dtheta[k]`` (rad) and ``dv[k]`` (m/s) integrate over ``(t[k], t[k+1]]`` (the last row ends one
    step after ``t[-1]``), as docs/conventions.md says; ``alpha[k]``, ``beta[k]`` (rad) are the inner/outer
    encoder angles at ``t[k]``, the start of row k's increments. ``truth`` (simulations):
    the six angles (rad) in :data:`optinav.rins.model.PARAM_NAMES` order, or None. Version 2 renamed the
    version-1 fields ``h``/``c_b_n`` to ``height_m``/``C_b_n`` (version-1 files still load).
    """

    SCHEMA = "optinav.rins_data"
    VERSION = 3

    t: np.ndarray = field(metadata={"unit": "s"})
    dtheta: np.ndarray = field(metadata={"unit": "rad"})
    dv: np.ndarray = field(metadata={"unit": "m/s"})
    alpha: np.ndarray = field(metadata={"unit": "rad"})
    beta: np.ndarray = field(metadata={"unit": "rad"})
    lat: float = field(default=float(np.radians(28.2)), metadata={"unit": "rad"})
    height_m: float = field(default=0.0, metadata={"unit": "m"})
    truth: np.ndarray | None = field(default=None, metadata={"unit": "rad"})
    C_b_n: np.ndarray | None = field(default=None, metadata={"unit": ""})  #: true vehicle attitude (3, 3)
    align_s: float = field(default=float("nan"), metadata={"unit": "s"})  #: alignment phase length
    info: dict = field(default_factory=dict, metadata={"unit": "-"})

    @property
    def rate_hz(self) -> float:
        """Sample rate [Hz]: the inverse of the median epoch spacing."""
        return float(1.0 / np.median(np.diff(self.t)))


register_legacy(RinsData, RinsData.SCHEMA, 1, lambda d: nested_kwargs(RinsData, d, {"h": "height_m", "c_b_n": "C_b_n"}))


def _schedules(steps, t_start, move_s, dwell_s, profile, lock_sigma, rng):
    """Commanded (encoder) and true angle schedules of both axes; returns (cmd_z, cmd_y, true_z, true_y, end)."""
    moves = {"Z": [], "Y": []}
    true_moves = {"Z": [], "Y": []}
    eps = {"Z": 0.0, "Y": 0.0}
    t = t_start
    for axis, deg in steps:
        ang = np.radians(deg)
        moves[axis].append(Move(t, move_s, ang, profile))
        new = float(rng.normal(0.0, lock_sigma)) if lock_sigma > 0 else 0.0
        true_moves[axis].append(Move(t, move_s, ang + new - eps[axis], profile))
        eps[axis] = new
        t += move_s + dwell_s
    return (
        AxisSchedule(moves["Z"]),
        AxisSchedule(moves["Y"]),
        AxisSchedule(true_moves["Z"]),
        AxisSchedule(true_moves["Y"]),
        t,
    )


def _wobbled(schedule, amp, phase):
    """``w·sin(θ(t) + φ)`` with its rate and acceleration, for a wobble joint driven by ``schedule``."""

    def f(t):
        th, rt, ac = schedule(t)
        s, c = np.sin(th + phase), np.cos(th + phase)
        return amp * s, amp * c * rt, amp * (c * ac - s * rt**2)

    return f


def simulate(
    nonorth=(0.0,) * 6,
    *,
    scheme="psins16",
    cycles: int = 1,
    move_s: float = 10.0,
    dwell_s: float = 50.0,
    align_s: float = 600.0,
    rate_hz: float = 200.0,
    lat: float = float(np.radians(28.2)),
    height_m: float = 50.0,
    attitude=tuple(np.radians((0.5, -0.3, 30.0)).tolist()),
    imu="rlg-nav",
    gyro_misalignment=None,
    gyro_scale=None,
    imu_errors: bool = True,
    noise: bool = True,
    encoder_noise=np.radians(1 / 3600),
    encoder_lsb=2 * np.pi / 2**21,
    lock_sigma: float = 0.0,
    wobble: float = 0.0,
    profile: str = "cosine",
    rng=None,
) -> RinsData:
    """Simulate a static-base dual-axis rotational-INS session (see the module docstring).

    Parameters
    ----------
    nonorth : (6,) array_like
        True non-orthogonality ``[θx, θy, θz, ηx, ηy, ηz]`` [rad].
    scheme : str or sequence
        A name in :data:`SCHEMES`, a step text ``"Z+180,Y-180"`` or (axis, degrees) pairs.
    cycles : int
        Repetitions of the scheme.
    move_s : float
        Duration of each move [s].
    dwell_s : float
        Rest after each move [s].
    align_s : float
        Alignment phase before the first move [s].
    rate_hz : float
        Sample rate [Hz].
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    attitude : (3,) array_like
        Vehicle [roll, pitch, yaw] [rad] (ENU convention).
    imu : str or ImuSpec
        Preset name or an :class:`~optinav.core.imu_model.ImuSpec`.
    gyro_misalignment : float or None
        Overrides the spec: 1σ of each of the six misalignment terms [rad].
    gyro_scale : float or None
        Overrides the spec: 1σ scale-factor error [-] (fraction).
    imu_errors : bool
        Draw the unit's deterministic errors (False: an ideal triad).
    noise : bool
        Add sensor and encoder noise.
    encoder_noise : float
        Encoder noise 1σ [rad].
    encoder_lsb : float
        Encoder quantum [rad] (0: none).
    lock_sigma : float
        1σ stop error unseen by the encoders [rad].
    wobble : float
        Axis wobble amplitude w (tilt ``w·sin β`` of the outer, ``w·sin α`` of the inner axis) [rad].
    profile : str
        Rate profile of a move, as :class:`optinav.core.simulate.Move`.
    rng : int, Generator or None
        Seed or generator.

    Returns
    -------
    RinsData
        Increments ``dtheta`` [rad] and ``dv`` [m/s], encoder angles [rad] and the truth.
    """
    gen = as_rng(rng)
    p = np.asarray(nonorth, dtype=float)
    if p.shape != (6,) or not np.all(np.isfinite(p)):
        raise OptinavError(
            f"nonorth has shape {p.shape}, expected 6 finite angles", f"pass {', '.join(PARAM_NAMES)} in rad"
        )
    if np.any(np.abs(p) > 0.1):
        raise OptinavError(
            f"non-orthogonality angles up to {np.max(np.abs(p)):.3g} rad are not small",
            "pass radians (e.g. 1e-4), or --unit deg for degrees",
        )
    rate = check_positive(rate_hz, "rate_hz")
    lat, h = float(lat), float(height_m)
    if not -np.pi / 2 <= lat <= np.pi / 2:
        raise OptinavError(f"latitude {lat:g} rad is outside ±π/2", "pass lat in rad (the CLI's --lat is in degrees)")
    move_s, align_s = check_positive(move_s, "move_s"), check_positive(align_s, "align_s")
    if dwell_s < 0:
        raise OptinavError("dwell_s is negative", "pass a dwell time >= 0 s")
    steps = scheme_steps(scheme) * int(cycles)
    cz, cy, tz, ty, end = _schedules(steps, align_s, move_s, dwell_s, profile, lock_sigma, gen)
    c_b_n = dcm_from_euler(np.asarray(attitude, float), "enu")
    A, B = nonorth_dcm(p[0:3]), nonorth_dcm(p[3:6])
    if wobble > 0:
        ph = gen.uniform(0, 2 * np.pi, 2)
        fixed = [c_b_n, np.eye(3), B.T, np.eye(3), A.T]
        axes = ["y", "x", "z", "x"]
        angles = [ty, _wobbled(ty, wobble, ph[0]), tz, _wobbled(tz, wobble, ph[1])]
        truth = gimbal(
            fixed,
            axes,
            angles,
            end,
            rate,
            lat,
            h,
            "enu",
            breakpoints=ty.breakpoints + tz.breakpoints,
            max_step=min(1.0 / rate, 0.05),
        )
    else:
        truth = gimbal([c_b_n, B.T, A.T], ["y", "z"], [ty, tz], end, rate, lat, h, "enu")
    spec = preset(imu) if isinstance(imu, str) else imu
    over = {}
    if gyro_misalignment is not None:
        over["gyro_misalignment"] = float(gyro_misalignment)
    if gyro_scale is not None:
        over["gyro_scale"] = float(gyro_scale)
    if over:
        spec = spec.replace(**over)
    if spec.rate_hz != rate:
        spec = spec.replace(rate_hz=rate)
    unit = spec.draw(gen, errors=imu_errors)
    meas = unit.apply(truth.dtheta, truth.dv, truth.dt, gen, kind="increment", noise=noise)
    ts = truth.t[:-1]  # row k: the increments over (t[k], t[k+1]] and the encoders at t[k]
    enc = []
    for s in (cz, cy):
        a = s(ts)[0]
        if noise and encoder_noise > 0:
            a = a + gen.normal(0.0, encoder_noise, a.shape)
        if encoder_lsb > 0:
            a = np.round(a / encoder_lsb) * encoder_lsb
        enc.append(a)
    info = {
        "scheme": scheme if isinstance(scheme, str) else "custom",
        "steps": [f"{a}{d:+g}" for a, d in steps],
        "move_s": move_s,
        "dwell_s": dwell_s,
        "imu": spec.name,
        "gyro_K": unit.gyr.K.tolist(),
        "gyro_bias": unit.gyr.bias.tolist(),
        "lock_sigma": lock_sigma,
        "wobble": wobble,
        "encoder_noise": encoder_noise if noise else 0.0,
        "encoder_lsb": encoder_lsb,
    }
    return RinsData(
        t=ts,
        dtheta=meas.gyr,
        dv=meas.acc,
        alpha=enc[0],
        beta=enc[1],
        lat=lat,
        height_m=float(h),
        truth=p.copy(),
        C_b_n=c_b_n,
        align_s=float(align_s),
        info=info,
    )
