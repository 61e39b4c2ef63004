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

A session is generated block by block (:class:`RinsStream`; :func:`simulate` gathers the blocks), so a long one
can be written without being held in memory.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import field

import numpy as np

from optinav.core.imu_model import MeasurementStream, SampleDraws, preset
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.rotations import dcm_from_euler
from optinav.core.simulate import AxisSchedule, Move, gimbal_sampler
from optinav.core.validate import as_rng, check_positive
from optinav.errors import OptinavError
from optinav.rins.model import PARAM_NAMES, nonorth_dcm

__all__ = ["SCHEMES", "RinsData", "RinsStream", "scheme_steps", "simulate", "PAPER_TABLE3", "BLOCK_ROWS"]

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


#: samples per block of a session generated block by block (:class:`RinsStream`): some tens of MB each
BLOCK_ROWS = 1 << 16


class RinsStream:
    """A simulated static-base dual-axis rotational-INS session (see the module docstring) generated block by block,
    so that memory does not grow with its length (``optinav simulate rins``); :func:`simulate` gathers the same
    blocks.

    Drawn from ``rng`` in this order: the lock errors of the schedules, the wobble phases, the unit, then one key,
    from which the sensor and encoder noise of every sample are drawn by sample index
    (:class:`~optinav.core.imu_model.SampleDraws`, :class:`~optinav.core.imu_model.MeasurementStream` with the noise
    states carried across blocks): the same seed gives the same session whatever the block length. The exact
    increments come from :func:`optinav.core.simulate.gimbal_sampler`.

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

    Attributes
    ----------
    n : int
        Rows (IMU samples) of the session.
    rate_hz : float
        Sample rate [Hz].
    unit : ImuModel
        The drawn unit.
    measure : MeasurementStream
        Its outputs so far, with the saturated axis samples counted (``gyro_saturated``, ``acc_saturated``).
    """

    def __init__(
        self,
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
    ):
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
            raise OptinavError(
                f"latitude {lat:g} rad is outside ±π/2", "pass lat in rad (the CLI's --lat is in degrees)"
            )
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
            extra = dict(breakpoints=ty.breakpoints + tz.breakpoints, max_step=min(1.0 / rate, 0.05))
        else:
            fixed, axes, angles, extra = [c_b_n, B.T, A.T], ["y", "z"], [ty, tz], {}
        self._sampler = gimbal_sampler(fixed, axes, angles, end, rate, lat, height_m=h, frame="enu", **extra)
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
        self.unit = spec.draw(gen, errors=imu_errors)
        key = int(gen.integers(0, 2**63))  # the noise of every sample, sensors and encoders (after the unit)
        self.measure = MeasurementStream(self.unit, key, kind="increment", noise=noise)
        self._enc_noise = float(encoder_noise) if noise and encoder_noise > 0 else 0.0
        self._enc_draws = SampleDraws(key, 6, width=2) if self._enc_noise else None
        self._enc_lsb, self._encoders = float(encoder_lsb), (cz, cy)
        self.n, self.rate_hz = self._sampler.n, rate
        self.nonorth, self.lat, self.height_m, self.C_b_n, self.align_s = p.copy(), lat, h, c_b_n, float(align_s)
        self.info = {
            "scheme": scheme if isinstance(scheme, str) else "custom",
            "steps": [f"{a}{d:+g}" for a, d in steps],
            "move_s": move_s,
            "dwell_s": dwell_s,
            "imu": spec.name,
            "gyro_K": self.unit.gyr.K.tolist(),
            "gyro_bias": self.unit.gyr.bias.tolist(),
            "lock_sigma": lock_sigma,
            "wobble": wobble,
            "encoder_noise": encoder_noise if noise else 0.0,
            "encoder_lsb": encoder_lsb,
        }
        # every stride-th encoder sample, all that the truth's observability reads of them
        from optinav.rins.calibrate import OBSERVABILITY_EPOCHS

        self._stride = max(1, self.n // OBSERVABILITY_EPOCHS)
        self._enc_kept: list[tuple[np.ndarray, np.ndarray]] = []
        self._done = 0

    def _encoder_angles(self, t: np.ndarray, i0: int) -> tuple[np.ndarray, np.ndarray]:
        """The inner and outer encoder angles [rad] at the epochs ``t`` of rows ``i0`` … (noise, quantization)."""
        out = [s(t)[0] for s in self._encoders]
        if self._enc_draws is not None:
            w = self._enc_draws.take(i0, i0 + t.size)
            out = [a + self._enc_noise * w[:, j] for j, a in enumerate(out)]
        if self._enc_lsb > 0:
            out = [np.round(a / self._enc_lsb) * self._enc_lsb for a in out]
        return out[0], out[1]

    def blocks(self, block_rows: int | None = None):
        """Generate the session's rows in order, ``block_rows`` at a time (once per stream).

        Parameters
        ----------
        block_rows : int or None
            Rows per block (default :data:`BLOCK_ROWS`; memory grows with it, not with the session; the rows do not
            depend on it).

        Yields
        ------
        t : (m,) ndarray
            Epochs [s]: row k starts at t[k].
        dtheta : (m, 3) ndarray
            Measured gyro increments over (t[k], t[k+1]] [rad].
        dv : (m, 3) ndarray
            Measured velocity increments [m/s].
        alpha, beta : (m,) ndarray
            Inner and outer encoder angles at t[k] [rad].
        """
        if self._done:
            raise OptinavError("this session was already generated", "make a new RinsStream")
        step = int(check_positive(BLOCK_ROWS if block_rows is None else block_rows, "block_rows"))
        for i0 in range(0, self.n, step):
            i1 = min(i0 + step, self.n)
            te = self._sampler.epochs(i0, i1 + 1)
            dth, dv = self._sampler(te)
            dth, dv = self.measure(dth, dv, np.diff(te))
            t = te[:-1]
            alpha, beta = self._encoder_angles(t, i0)
            keep = np.arange(-(-i0 // self._stride) * self._stride, i1, self._stride) - i0
            self._enc_kept.append((alpha[keep], beta[keep]))
            self._done = i1
            yield t, dth, dv, alpha, beta

    def n_blocks(self, block_rows: int | None = None) -> int:
        """Number of blocks :meth:`blocks` yields for ``block_rows`` (default :data:`BLOCK_ROWS`)."""
        return -(-self.n // int(BLOCK_ROWS if block_rows is None else block_rows))

    def _check_done(self) -> None:
        if self._done < self.n:
            raise OptinavError("the session's blocks were not all generated", "run blocks() to the end first")

    def data(self, t=None, dtheta=None, dv=None, alpha=None, beta=None) -> RinsData:
        """The session (after :meth:`blocks` ran to the end) with the rows given, or none (empty arrays).

        Returns
        -------
        RinsData
            The rows with the site, the true angles, the vehicle attitude and the info.
        """
        self._check_done()
        e1, e3 = np.empty(0), np.empty((0, 3))
        return RinsData(
            t=e1 if t is None else t,
            dtheta=e3 if dtheta is None else dtheta,
            dv=e3 if dv is None else dv,
            alpha=e1 if alpha is None else alpha,
            beta=e1 if beta is None else beta,
            lat=self.lat,
            height_m=self.height_m,
            truth=self.nonorth.copy(),
            C_b_n=self.C_b_n,
            align_s=self.align_s,
            info=dict(self.info),
        )

    def gather(self, blocks=None) -> RinsData:
        """The whole session in memory: ``blocks`` (default :meth:`blocks`; e.g. wrapped in a progress bar) filled
        into arrays of :attr:`n` rows.

        Returns
        -------
        RinsData
            As :func:`simulate` returns it.
        """
        n = self.n
        t, dth, dv, al, be = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.empty(n)
        i = 0
        for bt, bth, bdv, ba, bb in self.blocks() if blocks is None else blocks:
            j = i + bt.size
            t[i:j], dth[i:j], dv[i:j], al[i:j], be[i:j] = bt, bth, bdv, ba, bb
            i = j
        return self.data(t, dth, dv, al, be)

    def encoder_samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Every k-th encoder angle of the session (after :meth:`blocks` ran), k = max(1, n // m) with m
        :data:`~optinav.rins.calibrate.OBSERVABILITY_EPOCHS`: all that the truth's observability reads of them, as
        ``encoders`` of :func:`~optinav.rins.calibrate.simulation_truth`.

        Returns
        -------
        alpha, beta : ndarray
            Inner and outer encoder angles [rad].
        """
        self._check_done()
        alpha, beta = (np.concatenate(x) for x in zip(*self._enc_kept))
        return alpha, beta


def simulate(nonorth=(0.0,) * 6, **options) -> RinsData:
    """Simulate a static-base dual-axis rotational-INS session (see the module docstring): the blocks of
    :class:`RinsStream` gathered, so the same seed gives the same rows as the streamed session.

    Parameters
    ----------
    nonorth : (6,) array_like
        True non-orthogonality ``[θx, θy, θz, ηx, ηy, ηz]`` [rad].
    **options
        The keywords of :class:`RinsStream`: ``scheme``, ``cycles``, ``move_s``, ``dwell_s``, ``align_s`` [s],
        ``rate_hz`` [Hz], ``lat`` [rad], ``height_m`` [m], ``attitude`` [rad], ``imu``, ``gyro_misalignment`` [rad],
        ``gyro_scale``, ``imu_errors``, ``noise``, ``encoder_noise``, ``encoder_lsb``, ``lock_sigma``, ``wobble``
        [rad], ``profile``, ``rng``.

    Returns
    -------
    RinsData
        Increments ``dtheta`` [rad] and ``dv`` [m/s], encoder angles [rad] and the truth.
    """
    return RinsStream(nonorth, **options).gather()
