"""A pose plan for a technician: which static poses, in which order, how long to rest in each, and the turns
between them, with the precision the calibration will reach (``optinav design``).

Poses: :func:`optinav.multipos.design.design_scheme` (D/E/A-optimal choice among the 26 axis, 45° and corner
poses for the accelerometer norm model), ordered by a greedy nearest-neighbour tour (each next pose the one
reached by the smallest turn) so that the technician turns the unit as little as possible.

Dwell: the accelerometer's predicted standard deviations (Cramér–Rao bound at nominal parameters, white noise
only) scale as ``1/√dwell``, so a target std ``s*`` for a parameter predicted at ``s₁`` with dwell ``T₁`` needs
``T = T₁·(s₁/s*)²``; the plan takes the largest such T over the targets given (whole seconds, at least
:data:`MIN_DWELL_S`). Averaging beyond the Allan-deviation minimum does not reduce the error further (bias
instability); a dwell (given or from the targets) beyond ``--max-dwell`` is refused.

Gyroscope: calibrated from the turns between poses (:mod:`optinav.multipos.gyro`): each turn k carries the
gravity direction ``u_k`` to ``u_{k+1}``; a wrong K tilts the carried direction, ``r_k = C_kᵀu_k − u_{k+1}``.
To first order at nominal ``K = I`` (raw in rad/s) a turn at constant rate by the body rotation vector
``Φ_k`` over ``T_k`` s sees the rate error ``δω = −δK·Φ_k/T_k − δb``; an error at time t reaches the end of
the turn rotated by the rest of it, so the end attitude is off by ``e = M_k·δω·T_k`` with
``M_k = ∫₀¹ exp(−[Φ_k×](1 − s)) ds`` (the SO(3) Jacobian of the turn; ignoring it, ``M = I``, misjudges the
std by up to 40 % for 90° turns), and ``r_k ≈ [u_{k+1}×]·e`` (two components; the one along ``u_{k+1}`` is
of second order). White gyro noise N (rad/s/√Hz) gives ``cov e = T_k·mean(R N² Rᵀ)`` over the turn. K follows
by weighted least squares with b fixed at the mean of the rests (std ``N/√(ΣT_dwell)``, propagated into K),
as :func:`~optinav.multipos.gyro.calibrate_gyro` does with ``bias="static"``; tests/test_design_plan.py checks
the prediction against Monte Carlo runs of that calibrator. A turn sequence whose rotation axes leave some
combination of K undetermined is reported (rank < 9).
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, field

import numpy as np

from optinav.core.observability import analyze
from optinav.core.results import Result
from optinav.core.rotations import dcm_from_rotvec, skew
from optinav.core.simulate import describe_pose
from optinav.core.units import G_STANDARD
from optinav.multipos.static import MIN_STATIC_S
from optinav.errors import OptinavError
from optinav.multipos import design as _design
from optinav.multipos.gyro import GYRO_PARAMS
from optinav.multipos.model import ACCEL_PARAMS

__all__ = [
    "PosePlan",
    "plan_poses",
    "plot_plan",
    "pose_words",
    "turn_between",
    "gyro_turn_std",
    "noise_from_allan",
    "plan_noise",
    "plan_g_sensitivity",
    "MIN_DWELL_S",
    "ACC_NAMES",
    "GYRO_NAMES",
]

MIN_DWELL_S = 5.0
ACC_NAMES = ACCEL_PARAMS
GYRO_NAMES = GYRO_PARAMS
_DEG_H = math.pi / 180.0 / 3600.0  # rad/s per deg/h


# --- words ------------------------------------------------------------------------------------------------------


def _deg(x: float) -> str:
    return f"{x:.0f}" if abs(x - round(x)) < 0.05 else f"{x:.1f}"


def _face(i: int, s: float) -> str:
    return f"{'+' if s > 0 else '−'}{'xyz'[i]}"


def pose_words(C_b_n) -> str:
    """Which face of the unit points up, and where a level axis points: ``"+x face up; y axis north"``,
    ``"edge between the +x and −y faces up (both faces 45° above level); z axis level, pointing east"``.

    ``C_b_n``: C_b^n (ENU) of the pose. A face is named by its outward normal (the +x face is the one the
    body +x axis leaves through); "above level" is the elevation of that normal.
    """
    c = np.asarray(C_b_n, float)
    up = c[2]  # C_b^nᵀ·e_U: the body direction pointing up
    order = sorted((i for i in range(3) if abs(up[i]) > 1e-6), key=lambda i: (-round(abs(float(up[i])), 6), i))
    faces = [_face(i, up[i]) for i in order]
    elev = [math.degrees(math.asin(min(1.0, abs(float(up[i]))))) for i in order]
    if len(faces) == 1:
        text = f"{faces[0]} face up"
    elif max(elev) - min(elev) < 0.05:
        kind = "edge between the" if len(faces) == 2 else "corner of the"
        names = " and ".join(faces) if len(faces) == 2 else f"{faces[0]}, {faces[1]} and {faces[2]}"
        text = (
            f"{kind} {names} faces up ({'both' if len(faces) == 2 else 'all three'} faces {_deg(elev[0])}° above level)"
        )
    else:
        text = ", ".join(f"{f} face {_deg(e)}°" for f, e in zip(faces, elev)) + " above level"
    # the heading from describe_pose's last words ("…, y north"): the most level remaining axis
    head = describe_pose(c, frame="enu").rsplit(", ", 1)[-1]
    axis, where = head.split(" ", 1)
    level = abs(up["xyz".index(axis)]) < 1e-6
    if len(faces) == 1:
        return f"{text}; {axis} axis {where}"
    return f"{text}; {axis} axis {'level, pointing ' if level else ''}{where}"


def turn_between(u0, u1) -> tuple[np.ndarray, float, str]:
    """The smallest turn that brings body direction ``u1`` up from a pose with ``u0`` up.

    Returns (body rotation axis (3,) unit, angle rad, words). The axis is ``u0 × u1`` (a body axis between
    axis and 45° poses); a half turn (``u1 = −u0``) is about the body axis most perpendicular to ``u0``.
    """
    a, b = np.asarray(u0, float), np.asarray(u1, float)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    ang = math.acos(max(-1.0, min(1.0, float(a @ b))))
    ax = np.cross(a, b)
    if np.linalg.norm(ax) < 1e-9:
        if ang < 1e-9:
            return np.zeros(3), 0.0, "no turn (same pose)"
        ax = np.eye(3)[int(np.argmin(np.abs(a)))]
        ax = ax - (ax @ a) * a
    ax = ax / np.linalg.norm(ax)
    j = int(np.argmax(np.abs(ax)))
    name = (
        f"its {'xyz'[j]} axis"
        if abs(abs(ax[j]) - 1) < 1e-9
        else "the axis [" + ", ".join(f"{v:.3f}" for v in np.round(ax, 3) + 0.0) + "]"
    )
    k = [i for i in range(3) if abs(b[i]) > 1e-6]
    until = f" until the {_face(k[0], b[k[0]])} face is up" if len(k) == 1 else " into the next pose"
    return ax, ang, f"tip it {_deg(math.degrees(ang))}° about {name}{until}"


def chain_orientations(C0, up_dirs) -> np.ndarray:
    """C_b^n (P, 3, 3) of poses reached from ``C0`` by the turns of :func:`turn_between` between the up vectors
    ``up_dirs`` (P, 3): each pose is where the technician's tip leaves the last. (The design's own headings were
    not: a plan's pose 5 said "x axis level, pointing west" where the 60° tip from pose 4 it named turns the body
    90°, and a session following the pose words turned as the plan's gyro prediction did not.)"""
    out = [np.asarray(C0, float)]
    for k in range(len(up_dirs) - 1):
        ax, ang, _ = turn_between(up_dirs[k], up_dirs[k + 1])
        out.append(out[-1] @ dcm_from_rotvec(-ang * ax))  # the body turns opposite to its up vector
    return np.stack(out)


# --- gyroscope prediction -------------------------------------------------------------------------------------


def gyro_turn_std(
    up_dirs,
    turn_axes,
    turn_angles,
    turn_times,
    noise_density,
    static_time_s: float,
    g_sensitivity: float = 0.0,
    g: float = G_STANDARD,
    rest_weights=None,
    bias: str = "local",
    pad_s: float = 0.0,
):
    """Predicted 1σ of the gyro calibration (K row-major (9), b (3)) from the turns between poses.

    ``up_dirs`` (P, 3) body up vector per pose, turn k from pose k to k+1: body axis ``turn_axes[k]``, angle
    ``turn_angles[k]`` rad, duration ``turn_times[k]`` s; ``noise_density`` (3,) or scalar rad/s/√Hz;
    ``static_time_s``: total rest time giving the bias; ``g_sensitivity``: 1σ of each element of the gyro's
    g-sensitivity G (rad/s per m/s², datasheet; the model leaves it out). Nominal K = I (raw in rad/s); first-order
    model of the module docstring. ``bias`` as ``calibrate``'s gyro bias: "static", b the mean of the rests, fixed
    while K is fitted, its error propagated into K; "local" (calibrate's default), each turn's bias the chord
    between the means of the rests before and after it (``rest_weights`` (P,) their durations, s), whose noise
    enters each turn and is shared by the two turns beside a rest. ``pad_s``: rest time the gyro integrates with
    each turn (calibrate's static detection leaves it between the rests, :data:`STATIC_PAD_S`). G puts G·g·ū (ū the
    rests' mean up vector, weighted by ``rest_weights``, default equal) into b and into turn k G·g·(ū_k − ū) ("static",
    ū_k the mean of its end poses' up vectors) or G·g·(u(t) − the two rests' mean up vector) ("local"), a
    bias error of that turn. Returns (std (12,) with inf where not determined, ObservabilityReport of K).
    """
    u = np.asarray(up_dirs, float)
    n = np.broadcast_to(np.asarray(noise_density, float), (3,))
    w = np.ones(u.shape[0]) if rest_weights is None else np.asarray(rest_weights, float)
    ubar = (w / w.sum()) @ u
    rows, rows_g = [], []
    mid = (np.arange(64) + 0.5) / 64.0  # midpoint rule over the turn
    for k in range(u.shape[0] - 1):
        # the body turns by Φ = −angle·axis (turn_between: the up vector turns by +angle, the body opposite)
        Phi = -np.asarray(turn_axes[k], float) * float(turn_angles[k])
        T = float(turn_times[k])
        # the window the gyro integrates: half the pad at rest before, the turn, half the pad at rest after. A rate
        # error δω at time t reaches the end frame turned by the rest of the turn, R(t): e = Σ R δω dt
        Rs = np.concatenate([dcm_from_rotvec(-Phi)[None], dcm_from_rotvec(-np.outer(1.0 - mid, Phi)), np.eye(3)[None]])
        dt = np.r_[0.5 * pad_s, np.full(mid.size, T / mid.size), 0.5 * pad_s]
        up_t = np.concatenate(
            [u[k][None], np.einsum("sij,j->si", dcm_from_rotvec(-np.outer(mid, Phi)), u[k]), u[k + 1][None]]
        )
        M = np.einsum("s,sij->ij", dt, Rs)
        cu = skew(u[k + 1])
        # δω = −δK·Φ/T over the turn − δb over the window; r = −e × u = [u×]e
        MT = np.einsum("s,sij->ij", dt[1:-1], Rs[1:-1])
        Jk = np.hstack([cu @ MT @ np.kron(np.eye(3), Phi[None, :]) / T, cu @ M])
        # white rate noise: cov e = Σ R diag(N²) Rᵀ dt; r's covariance has rank 2: whiten on its range
        Ce = np.einsum("s,sij,j,skj->ik", dt, Rs, n**2, Rs)
        P = np.linalg.svd(cu)[0][:, :2]
        L = np.linalg.cholesky(P.T @ cu @ Ce @ cu.T @ P)
        rows.append(np.linalg.solve(L, P.T @ Jk))
        # a g-sensitivity G is a bias G·g·(u(t) − ū_ref): ū_ref the session's mean up vector ("static") or the mean
        # of the two rests' ("local": the bias interpolated between them holds their G·g·u)
        ref = 0.5 * (u[k] + u[k + 1]) if bias == "local" else ubar
        E = np.zeros((3, 9))
        for i in range(3):  # δb_i = g·(u − ū_ref)·G[i, :]: column block i of vec(G) (row-major)
            E[:, 3 * i : 3 * i + 3] = g * np.einsum("s,sj,sl->jl", dt, Rs[:, :, i], up_t - ref)
        rows_g.append(np.linalg.solve(L, P.T @ (cu @ E)))
    J = np.vstack(rows)
    sb_noise = n / math.sqrt(static_time_s)  # the bias from all rest, fixed during the K fit (bias="static")
    JK, Jb = J[:, :9], J[:, 9:]
    JG = np.vstack(rows_g)
    sg = abs(float(g_sensitivity))
    rep = analyze(JK, np.ones(J.shape[0]), names=list(GYRO_NAMES[:9]), scales=np.ones(9))
    std = np.full(12, np.inf)
    std[9:] = np.sqrt(sb_noise**2 + (sg * g) ** 2 * float(ubar @ ubar))  # and G·g·ū in every rest
    if rep.rank == 9:
        FK = JK.T @ JK
        G = np.linalg.solve(FK, JK.T @ Jb)  # K̂ moves by −G·δb for a bias error δb
        H = np.linalg.solve(FK, JK.T @ JG)  # and by −H·vec(G) for the g-sensitivity in the turns
        cov = np.linalg.inv(FK) + sg**2 * (H @ H.T)
        if bias == "local":
            # turn k's bias is ½(ε_k + ε_k+1), ε the rests' mean noise N²/T_rest, as calibrate's local bias has it
            # (a few percent of the K std on a 12-pose MTi-1 plan; the turn's window, STATIC_PAD_S, took it 1.5x)
            rest_s = np.full(u.shape[0], static_time_s / u.shape[0]) if rest_weights is None else w
            D = np.zeros((J.shape[0], 3 * u.shape[0]))
            for k in range(u.shape[0] - 1):
                D[2 * k : 2 * k + 2, 3 * k : 3 * k + 6] = 0.5 * np.hstack([Jb[2 * k : 2 * k + 2]] * 2)
            eps = (n[None, :] ** 2 / np.asarray(rest_s, float)[:, None]).ravel()
            A = np.linalg.solve(FK, JK.T @ D)
            cov += (A * eps) @ A.T
        else:
            cov += G @ np.diag(sb_noise**2) @ G.T
        std[:9] = np.sqrt(np.diag(cov))
    else:
        std[:9] = np.asarray(rep.crlb_std, float)
    return std, rep


# --- noise ------------------------------------------------------------------------------------------------------


#: s, the longest rest per pose when neither --max-dwell nor an allan result's minimum says otherwise
DEFAULT_MAX_DWELL_S = 600.0


def plan_max_dwell(allan=None, max_dwell_s: float | None = None) -> tuple[float, str | None]:
    """The longest rest per pose a plan may ask for, and a note on where it comes from.

    Parameters
    ----------
    allan : str, Path or None
        ``optinav allan``'s JSON (other noise files carry no Allan minimum).
    max_dwell_s : float or None
        Given by the user [s]: taken as it is.

    Returns
    -------
    seconds : float
        ``max_dwell_s``; else the shortest averaging time τ [s] at which the allan result reads a bias
        instability (the Allan minimum: past it averaging no longer lowers the error the plan predicts as white
        noise's 1/√dwell); else :data:`DEFAULT_MAX_DWELL_S`.
    note : str or None
        Said with the plan when the allan result set it.
    """
    if max_dwell_s is not None:
        return float(max_dwell_s), None
    if allan:
        from optinav.core.allan import AllanAnalysis
        from optinav.core.results import Result

        try:
            res = Result.from_json(allan)
        except OptinavError:  # Kalibr's YAML, a plain JSON of densities: no Allan curve
            res = None
        if isinstance(res, AllanAnalysis):
            taus = [
                np.asarray(s["read_off"].bias_instability_tau, float)
                for s in (res.sensor(n) for n in ("accelerometer", "gyroscope"))
                if s is not None
            ]
            tau = np.concatenate(taus) if taus else np.array([])
            if np.any(np.isfinite(tau)):
                t = float(np.nanmin(tau))
                return t, (
                    f"the rest per pose is capped at {t:.4g} s, the Allan minimum of {allan} (its bias instability "
                    "is read there: longer averaging does not help; --max-dwell sets another cap)"
                )
    return DEFAULT_MAX_DWELL_S, None


def noise_from_allan(path) -> dict:
    """Noise densities from a JSON file or Kalibr's imu.yaml (``.yaml``/``.yml``, read by
    :func:`optinav.multipos.kalibr.read_kalibr_imu_yaml`: safe YAML, as allan_variance_ros / imu_utils write it):
    the first ``accelerometer_noise_density`` (m/s²/√Hz) and ``gyroscope_noise_density`` (rad/s/√Hz) found at any
    depth (Kalibr's names and convention), each a number or one per axis. Returns ``{"acc": (3,) or None, "gyro":
    (3,) or None}``."""
    from pathlib import Path

    from optinav.core.files import parse_json, read_text

    if Path(path).suffix.lower() in (".yaml", ".yml"):
        from optinav.multipos.kalibr import read_kalibr_imu_yaml

        data = read_kalibr_imu_yaml(path)  # a Kalibr imu.yaml was 'not valid JSON' (probe)
    else:
        data = parse_json(
            read_text(path, "noise file"),
            str(path),
            "pass the JSON written by optinav allan or Kalibr's imu.yaml, or give --acc-noise-density",
        )
    found: dict = {}

    def walk(x):
        if isinstance(x, dict):
            for k, v in x.items():
                key = str(k).lower()
                for name, kind in (("accelerometer_noise_density", "acc"), ("gyroscope_noise_density", "gyro")):
                    if key == name and kind not in found:
                        found[kind] = v
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    walk(data)
    out = {}
    for kind in ("acc", "gyro"):
        v = found.get(kind)
        if isinstance(v, dict):  # {"value": ..., "unit": ...}
            v = v.get("value")
        try:
            arr = None if v is None else np.broadcast_to(np.asarray(v, float), (3,)).copy()
        except (TypeError, ValueError):  # text or a list of 2 was dropped, and the plan made without that sensor
            arr = np.full(3, np.nan)
        if arr is not None and not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
            raise OptinavError(
                f"{path}: {kind} noise density {v!r} is not a positive number",
                "fix the file or pass --acc-noise-density / --gyro-noise-density",
            )
        out[kind] = arr
    if out["acc"] is None and out["gyro"] is None:
        if isinstance(data, dict) and data.get("schema") == "optinav.allan":
            # optinav's own allan result of a log in raw units: Kalibr's densities need SI
            raise OptinavError(
                f"{path} is the allan result of a log in raw units: it has no noise densities in SI units",
                "run optinav allan on the log corrected by optinav apply (m/s^2, rad/s), or pass "
                "--acc-noise-density/--gyro-noise-density",
            )
        raise OptinavError(
            f"{path} holds neither accelerometer_noise_density nor gyroscope_noise_density",
            "pass the JSON written by optinav allan, or --acc-noise-density/--gyro-noise-density",
        )
    return out


def plan_noise(
    allan=None,
    preset: str | None = None,
    acc_noise_density: float | None = None,
    gyro_noise_density: float | None = None,
) -> tuple[np.ndarray, np.ndarray | None, str]:
    """The white-noise densities a plan is made for, and where they come from.

    Parameters
    ----------
    allan : str, Path or None
        A JSON with Kalibr's noise densities (:func:`noise_from_allan`), e.g. ``optinav allan``'s result.
    preset : str or None
        A sensor class of :mod:`optinav.core.imu_model` (at most one of ``allan`` and ``preset``; mems-mti1 is
        assumed when neither nor ``acc_noise_density`` is given).
    acc_noise_density : float or None
        Accelerometer white-noise density on every axis [m/s^2/sqrt(Hz)]; overrides the source's.
    gyro_noise_density : float or None
        Gyroscope white-noise density on every axis [rad/s/sqrt(Hz)]; overrides the source's.

    Returns
    -------
    acc : (3,) ndarray
        Accelerometer density [m/s^2/sqrt(Hz)].
    gyro : (3,) ndarray or None
        Gyroscope density [rad/s/sqrt(Hz)].
    text : str
        The densities and their source, for the plan.
    """
    given = [n for n, v in (("--allan", allan), ("--preset", preset)) if v]
    if len(given) > 1:
        raise OptinavError("--allan and --preset both give the noise", "pass one of them")
    acc = gyro = None
    parts = []
    if allan:
        got = noise_from_allan(allan)
        acc, gyro = got["acc"], got["gyro"]
        parts.append(f"from {allan}")
    name = preset or (None if allan or acc_noise_density else "mems-mti1")
    if name:
        from optinav.core.imu_model import preset as get

        spec = get(name)
        acc, gyro = np.asarray(spec.acc_vrw, float), np.asarray(spec.gyro_arw, float)
        parts.append(f"preset {name}" + ("" if preset else " (assumed; pass --allan or the densities)"))
    if acc_noise_density is not None:
        acc = np.full(3, acc_noise_density)
        parts.append("accelerometer density given")
    if gyro_noise_density is not None:
        gyro = np.full(3, gyro_noise_density)
        parts.append("gyro density given")
    if acc is None:
        raise OptinavError(f"{allan} has no accelerometer noise density", "add --acc-noise-density")
    text = f"accelerometer {float(np.mean(acc)) / 9.80665e-6:.3g} µg/√Hz"
    if gyro is not None:
        text += f", gyroscope {float(np.mean(gyro)) * 180 / np.pi * 60:.3g} deg/√h"
    return acc, gyro, text + " (" + "; ".join(parts) + ")"


def plan_g_sensitivity(allan=None, preset: str | None = None, given: float | None = None, acc_given: bool = False):
    """1σ per element of the gyro g-sensitivity (rad/s per m/s²) a plan is made for: ``given``, else the preset's
    (mems-mti1 when neither ``allan`` nor an accelerometer density is given, as :func:`plan_noise`), else 0
    (an Allan deviation does not show it). Returns (value, text or "")."""
    if given is not None:
        return float(given), "gyro g-sensitivity given"
    name = preset or (None if allan or acc_given else "mems-mti1")
    if not name:
        return 0.0, ""
    from optinav.core.imu_model import preset as get

    v = float(get(name).gyro_g_sensitivity)
    return v, (f"gyro g-sensitivity {v * G_STANDARD * 180 / np.pi:.3g} deg/s/g" if v else "")


# --- the plan ---------------------------------------------------------------------------------------------------


@dataclass
class PosePlan(Result):
    """A calibration session plan: poses in order, dwell, turns and predicted precision.

    Accelerometer (raw in m/s², nominal K = I): ``acc_std`` (9,) for :data:`ACC_NAMES` — K entries
    dimensionless (scale factor error, misalignment in rad), b in m/s². Gyroscope (raw in rad/s, K = I):
    ``gyro_std`` (12,) for :data:`GYRO_NAMES` — K dimensionless, b in rad/s; None without a gyro noise.
    Non-determined parameters have std None. ``turns``: one entry per turn from pose k to k+1 (1-based).
    """

    SCHEMA = "optinav.pose_plan"
    VERSION = 2

    criterion: str = field(metadata={"unit": "-"})
    up_dirs: np.ndarray = field(metadata={"unit": ""})
    orientations: np.ndarray = field(metadata={"unit": ""})
    words: list = field(metadata={"unit": "-"})
    dwell_s: float = field(metadata={"unit": "s"})
    dwell_reason: str = field(metadata={"unit": "-"})
    rate_hz: float = field(metadata={"unit": "Hz"})
    acc_noise_density: np.ndarray = field(metadata={"unit": "m/s^2/sqrt(Hz)"})
    gyro_noise_density: np.ndarray | None = field(metadata={"unit": "rad/s/sqrt(Hz)"})
    noise_source: str = field(metadata={"unit": "-"})
    acc_std: list = field(metadata={"unit": "1 | m/s^2"})
    turns: list = field(metadata={"unit": "-"})
    turn_rate_deg_s: float = field(metadata={"unit": "deg/s"})
    gyro_std: list | None = field(default=None, metadata={"unit": "1 | rad/s"})
    gyro_rank: int | None = field(default=None, metadata={"unit": ""})
    targets: dict = field(default_factory=dict, metadata={"unit": "ppm | mrad | mg | deg/h"})
    notes: list = field(default_factory=list, metadata={"unit": "-"})
    g: float = field(default=G_STANDARD, metadata={"unit": "m/s^2"})

    @property
    def n_poses(self) -> int:
        return int(np.asarray(self.up_dirs).shape[0])

    @property
    def session_s(self) -> float:
        """Rest in every pose plus the turns (s)."""
        return float(self.dwell_s * self.n_poses + sum(t["duration_s"] for t in self.turns))

    def std_table(self) -> list[tuple[str, str, str, str]]:
        """(sensor, parameter, std, unit) rows in the units a datasheet uses."""
        rows = []
        for i, nm in enumerate(ACC_NAMES):
            s = self.acc_std[i]
            rows.append(("accelerometer", nm, *_show(s, i, "acc", self.g)))
        if self.gyro_std is not None:
            for i, nm in enumerate(GYRO_NAMES):
                rows.append(("gyroscope", nm, *_show(self.gyro_std[i], i, "gyro", self.g)))
        return rows

    def markdown(self) -> str:
        """The plan as a Markdown page for the technician."""
        lines = [
            f"# Calibration pose plan: {self.n_poses} poses ({self.criterion}-optimal)",
            "",
            f"Noise: {self.noise_source}. Rate {self.rate_hz:g} Hz.",
            "",
            f"**Rest {self.dwell_s:g} s in each pose** ({self.dwell_reason}); turn at about "
            f"{self.turn_rate_deg_s:g}°/s. Session about {self.session_s / 60:.1f} min plus handling.",
            "",
            "Start with the unit at rest in pose 1. A face is named by the body axis leaving through it "
            "(the +x face is the one the +x arrow on the case points out of); heading does not matter, the "
            "words give one to make the poses repeatable.",
            "",
            "| # | pose | then |",
            "|---|---|---|",
        ]
        for i, w in enumerate(self.words):
            nxt = self.turns[i]["words"] if i < len(self.turns) else "stop (end of session)"
            lines.append(f"| {i + 1} | {w} | {nxt} |")
        lines += [
            "",
            "## Predicted 1σ (Cramér–Rao bound, white noise, nominal parameters)",
            "",
            BIAS_AGAINST,
            "",
            "| sensor | parameter | 1σ | unit |",
            "|---|---|---|---|",
        ]
        lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in self.std_table()]
        if self.notes:
            lines += ["", "## Notes", ""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"

    def summary(self) -> str:
        lines = [
            f"optinav pose plan: {self.n_poses} poses ({self.criterion}-optimal), rest {self.dwell_s:g} s "
            f"each ({self.dwell_reason}); session about {self.session_s / 60:.1f} min",
            f"noise: {self.noise_source}",
        ]
        for i, w in enumerate(self.words):
            lines.append(f"  pose {i + 1:2d}: {w}")
            if i < len(self.turns):
                lines.append(f"           then {self.turns[i]['words']}")
        lines.append(f"predicted 1σ ({BIAS_AGAINST[0].lower()}{BIAS_AGAINST[1:-1]}):")
        lines += [f"  {a:13s} {b:5s} {c:>10s} {d}" for a, b, c, d in self.std_table()]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


#: what the predicted bias std is against (a helper read the gyro's 1.8 deg/h against a long-term bias off by 7.9)
BIAS_AGAINST = (
    "The biases' 1σ is against their mean over the session's rests; against a long-term or run-to-run bias add the "
    "sensor's bias instability (calibrate's --gyro-bias-instability, --acc-bias-instability)."
)


def _show(s, i: int, sensor: str, g: float) -> tuple[str, str]:
    if s is None or not np.isfinite(s):
        return "not determined", ""
    if sensor == "acc":
        if i < 3:
            return f"{s * 1e6:.3g}", "ppm (scale factor)"
        if i < 6:
            return f"{s * 1e3:.3g}", "mrad (misalignment)"
        return f"{s / G_STANDARD * 1e3:.3g}", "mg (bias)"
    if i < 9:
        r, c = divmod(i, 3)
        return (f"{s * 1e6:.3g}", "ppm (scale factor)") if r == c else (f"{s * 1e3:.3g}", "mrad (misalignment)")
    return f"{s / _DEG_H:.3g}", "deg/h (bias)"


def _order(up: np.ndarray, orient: np.ndarray) -> np.ndarray:
    """Greedy nearest-neighbour tour from the first pose: the next pose is the one with the smallest turn."""
    left = list(range(1, up.shape[0]))
    seq = [0]
    while left:
        cur = up[seq[-1]]
        nxt = min(left, key=lambda j: (math.acos(max(-1.0, min(1.0, float(cur @ up[j])))), j))
        seq.append(nxt)
        left.remove(nxt)
    return np.asarray(seq)


#: the longest rest per pose (s) a target may ask for: beyond it a target is out of the sensor's reach (1e12 s is
#: 30 000 years), and the rest would soon be no finite number
MAX_TARGET_DWELL_S = 1e12

#: the initial rest (s) in the first pose that docs/howto/calibrate-your-imu.md asks for: part of the gyro's rests
INITIAL_REST_S = 30.0
#: s that calibrate's static detection (a 1-s centred window, then half a window trimmed off each end) takes from
#: each rest beside a turn and adds to the turn the gyro integrates: a simulated 1.33-s turn of a plan was
#: integrated over 3.04 s, and the plan predicted the gyro scale 2x better than calibrate reached
STATIC_PAD_S = 2.0

#: target name → (accelerometer parameter indices, factor from the target's unit to the std's unit)
TARGETS = {
    "scale_ppm": ((0, 1, 2), 1e-6),
    "misalignment_mrad": ((3, 4, 5), 1e-3),
    "bias_mg": ((6, 7, 8), 1e-3 * G_STANDARD),
}


#: target name → its option and unit in ``optinav design``
TARGET_FLAGS = {
    "scale_ppm": "--target-scale",
    "misalignment_mrad": "--target-misalignment",
    "bias_mg": "--target-bias",
    "gyro_bias_deg_h": "--target-gyro-bias",
}
TARGET_UNITS = {"scale_ppm": "ppm", "misalignment_mrad": "mrad", "bias_mg": "mg", "gyro_bias_deg_h": "deg/h"}


#: the noise densities a plan is made for: sensor → (lowest, highest) [m/s^2/sqrt(Hz) | rad/s/sqrt(Hz)], as
#: ``optinav design --acc-noise-density/--gyro-noise-density`` take them
DENSITY_RANGE = {"accelerometer": (1e-12, 10.0, "m/s^2/sqrt(Hz)"), "gyroscope": (1e-12, 1.0, "rad/s/sqrt(Hz)")}


def _density(value, sensor: str, source: str) -> np.ndarray:
    """A white-noise density per axis, checked against :data:`DENSITY_RANGE` (an absurd one from an edited Allan
    file, 1e300, overflowed the plan into "sigma contains NaN"): ``source`` names where it came from."""
    lo, hi, unit = DENSITY_RANGE[sensor]
    try:
        n = np.broadcast_to(np.asarray(value, float), (3,)).copy()
    except (TypeError, ValueError):
        n = np.full(3, np.nan)
    if not np.all((n >= lo) & (n <= hi)):  # NaN fails too
        bad = next((float(x) for x in n if not lo <= x <= hi), float("nan"))
        raise OptinavError(
            f"the {sensor} noise density {bad:g} {unit} is not in [{lo:g}, {hi:g}]"
            + (f" (noise: {source})" if source else ""),
            "fix the noise source, or pass --acc-noise-density/--gyro-noise-density",
        )
    return n


def plan_poses(
    n_poses: int = 12,
    *,
    criterion: str = "D",
    acc_noise_density=None,
    gyro_noise_density=None,
    noise_source: str = "",
    rate_hz: float = 100.0,
    dwell_s: float | None = None,
    targets: dict | None = None,
    gyro_bias_deg_h: float | None = None,
    turn_rate_deg_s: float = 45.0,
    max_dwell_s: float = DEFAULT_MAX_DWELL_S,
    max_dwell_note: str | None = None,
    g: float = G_STANDARD,
    rng=0,
    gyro_g_sensitivity: float = 0.0,
) -> PosePlan:
    """The pose plan (module docstring). Noise densities in m/s²/√Hz and rad/s/√Hz (scalar or per axis);
    ``dwell_s`` s per pose, or None to derive it from ``targets`` (``{"scale_ppm": …, "misalignment_mrad": …,
    "bias_mg": …}``, accelerometer 1σ) and ``gyro_bias_deg_h`` (gyro bias 1σ from all rest, deg/h);
    neither: 30 s. ``gyro_g_sensitivity``: 1σ per element of the gyro g-sensitivity (rad/s per m/s²), in the
    predicted gyro std (:func:`gyro_turn_std`)."""
    if acc_noise_density is None:
        raise OptinavError(
            "the plan needs the accelerometer noise density", "pass --allan ALLAN.json, --acc-noise-density or --preset"
        )
    acc_n = _density(acc_noise_density, "accelerometer", noise_source)
    gyro_n = None if gyro_noise_density is None else _density(gyro_noise_density, "gyroscope", noise_source)
    targets = {k: float(v) for k, v in (targets or {}).items() if v is not None}
    for k, v in targets.items():
        if k not in TARGETS or not (math.isfinite(v) and v > 0):
            raise OptinavError(f"target {k}={v!r} is not a positive number", "give targets as positive numbers")
    ref = 60.0
    d = _design.design_scheme(
        int(n_poses), criterion=criterion, noise_density=acc_n, rate_hz=rate_hz, dwell_s=ref, g=g, rng=rng
    )
    notes = [max_dwell_note] if max_dwell_note else []
    seq = _order(np.asarray(d.up_dirs), np.asarray(d.orientations))
    up, orient = (
        np.asarray(d.up_dirs)[seq],
        chain_orientations(np.asarray(d.orientations)[seq[0]], np.asarray(d.up_dirs)[seq]),
    )
    if dwell_s is None and (targets or gyro_bias_deg_h):
        need, why, reach = MIN_DWELL_S, [], {}
        for k, v in targets.items():
            idx, f = TARGETS[k]
            s1 = float(np.max(np.asarray(d.predicted_std)[list(idx)]))
            r = s1 / (v * f)
            t = ref * r * r  # a float product: inf when beyond any count, where ** raised OverflowError
            why.append((t, k))
            reach[k] = s1 / f * math.sqrt(ref / max_dwell_s)  # the 1σ max_dwell_s gives, in the target's unit
            need = max(need, t)
        if gyro_bias_deg_h:
            if gyro_n is None:
                raise OptinavError(
                    "a gyro bias target needs the gyro noise density", "pass --gyro-noise-density, --allan or --preset"
                )
            r = float(np.max(gyro_n)) / (gyro_bias_deg_h * _DEG_H)
            t = r * r / up.shape[0]
            why.append((t, "gyro_bias_deg_h"))
            reach["gyro_bias_deg_h"] = float(np.max(gyro_n)) / math.sqrt(max_dwell_s * up.shape[0]) / _DEG_H
            need = max(need, t)
        t_top, top = max(why)
        what = {
            "scale_ppm": "accelerometer scale-factor target {:g} ppm",
            "misalignment_mrad": "accelerometer misalignment target {:g} mrad",
            "bias_mg": "accelerometer bias target {:g} mg",
            "gyro_bias_deg_h": "gyro bias target {:g} deg/h",
        }[top].format(targets.get(top, gyro_bias_deg_h))
        flag = TARGET_FLAGS[top]
        if not need <= MAX_TARGET_DWELL_S:
            raise OptinavError(
                f"the {what} would need {need:.3g} s of rest per pose (more than {MAX_TARGET_DWELL_S:g} s) with this "
                "noise density",
                f"relax the target ({flag})",
            )
        dwell = float(math.ceil(need))
        reason = (
            f"the {what} sets it" if t_top >= MIN_DWELL_S else f"the {MIN_DWELL_S:g} s minimum; the targets need less"
        )
        if dwell > max_dwell_s:
            # the plan's 1σ fall as 1/√dwell (white noise); past the Allan-deviation minimum the bias instability
            # stops them, so a plan printed at 3.6e9 s per pose promised a 1e-6 mg bias with exit 0
            raise OptinavError(
                f"the {what} needs {dwell:.3g} s of rest per pose, more than --max-dwell {max_dwell_s:g} s: past the "
                "Allan-deviation minimum more averaging does not help (bias instability), so the plan could not "
                "keep its predicted 1-sigma",
                f"relax {flag} ({max_dwell_s:g} s per pose reach {reach[top]:.3g} {TARGET_UNITS[top]}) or use more "
                "--poses; raise --max-dwell only up to your sensor's Allan minimum",
            )
    else:
        dwell = min(30.0, max_dwell_s) if dwell_s is None else float(dwell_s)
        reason = "given" if dwell_s is not None else "default; pass targets to derive it"
        shortest = MIN_STATIC_S + STATIC_PAD_S
        if dwell < shortest:  # --dwell 0.001 wrote a plan whose rests calibrate cannot find (probe)
            raise OptinavError(
                f"--dwell {dwell:g} s is shorter than the {shortest:g} s a pose must last for optinav calibrate to find "
                f"its rest (its --min-duration {MIN_STATIC_S:g} s, after the {STATIC_PAD_S:g} s its static detection "
                "takes from a rest's ends)",
                f"give --dwell of at least {shortest:g} s",
            )
        if dwell > max_dwell_s:  # --dwell 1e9 printed a 0.00023 deg/h gyro bias 1σ, exit 0
            raise OptinavError(
                f"--dwell {dwell:g} s is more than --max-dwell {max_dwell_s:g} s: past the Allan-deviation minimum "
                "more averaging does not help (bias instability), so the plan could not keep its predicted 1-sigma",
                "shorten --dwell, or raise --max-dwell up to your sensor's Allan minimum",
            )
    final = _design.evaluate_scheme(up, criterion=d.criterion, noise_density=acc_n, rate_hz=rate_hz, dwell_s=dwell, g=g)
    acc_std = [None if not np.isfinite(s) else float(s) for s in final.predicted_std]
    turns = []
    for k in range(up.shape[0] - 1):
        ax, ang, words = turn_between(up[k], up[k + 1])
        turns.append(
            {
                "from": k + 1,
                "to": k + 2,
                "axis_body": ax.tolist(),
                "angle_deg": math.degrees(ang),
                "duration_s": max(1.0, math.degrees(ang) / turn_rate_deg_s),
                "words": words,
            }
        )
    gyro_std = rank = None
    if gyro_n is not None:
        std, rep = gyro_turn_std(
            up,
            [t["axis_body"] for t in turns],
            [math.radians(t["angle_deg"]) for t in turns],
            [t["duration_s"] for t in turns],
            gyro_n,
            (dwell - STATIC_PAD_S) * up.shape[0] + INITIAL_REST_S,
            g_sensitivity=gyro_g_sensitivity,
            g=g,
            rest_weights=np.full(up.shape[0], dwell - STATIC_PAD_S) + INITIAL_REST_S * (np.arange(up.shape[0]) == 0),
            pad_s=STATIC_PAD_S,
        )
        gyro_std = [None if not np.isfinite(s) else float(s) for s in std]
        if gyro_bias_deg_h and gyro_g_sensitivity and float(np.max(std[9:])) > gyro_bias_deg_h * _DEG_H:
            notes.append(
                f"the gyro bias target {gyro_bias_deg_h:g} deg/h is below what the g-sensitivity leaves in it "
                f"({float(np.max(std[9:])) / _DEG_H:.3g} deg/h): more rest does not reach it; poses whose up "
                "vectors average to zero (and a short initial rest) do, or a stated g-sensitivity "
                "(calibrate --gyro-g-sensitivity)"
            )
        rank = int(rep.rank)
        if rank < 9:
            notes.append(
                "the turns leave gyro parameters undetermined (" + "; ".join(rep.statements) + "); add "
                "turns about the missing axes, e.g. a full turn about each body axis"
            )
    axes = np.abs(np.array([t["axis_body"] for t in turns])).max(axis=0) if turns else np.zeros(3)
    missing = [a for a, v in zip("xyz", axes) if v < 0.5]
    if missing:
        notes.append(
            f"no turn is mainly about the body {', '.join(missing)} axis; the gyro scale of that axis "
            "is only seen through tilted turns"
        )
    return PosePlan(
        criterion=d.criterion,
        up_dirs=up,
        orientations=orient,
        words=[pose_words(c) for c in orient],
        dwell_s=dwell,
        dwell_reason=reason,
        rate_hz=float(rate_hz),
        acc_noise_density=acc_n,
        gyro_noise_density=gyro_n,
        noise_source=noise_source,
        acc_std=acc_std,
        turns=turns,
        turn_rate_deg_s=float(turn_rate_deg_s),
        gyro_std=gyro_std,
        gyro_rank=rank,
        targets={**targets, **({"gyro_bias_deg_h": gyro_bias_deg_h} if gyro_bias_deg_h else {})},
        notes=notes,
        g=float(g),
    )


# --- figure -----------------------------------------------------------------------------------------------------

_FACE_COLORS = {"+x": "#d62728", "−x": "#f4a6a6", "+y": "#2ca02c", "−y": "#a6dba0", "+z": "#1f77b4", "−z": "#a6c8e8"}


def plot_plan(plan: PosePlan, path) -> None:
    """One panel per pose: the unit as a box in its pose (ENU: x east, y north, z up), faces coloured by
    axis (+ dark, − light) and labelled, with the pose number and words; written atomically as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from optinav.core.files import atomic_path

    P = plan.n_poses
    cols = min(4, P)
    rows = math.ceil(P / cols)
    fig = plt.figure(figsize=(3.2 * cols, 3.4 * rows))
    half = np.array([0.5, 0.35, 0.2])  # a box, not a cube: the faces are told apart by size too
    # from 60° above: a face whose normal is ≥ 30° above level (every "up" face of a pose, edge poses 45°, corner
    # poses 54.7°) faces the camera from any azimuth; at 25° an up face on the far side was hidden
    elev, azim = 60.0, -60.0
    e, a = math.radians(elev), math.radians(azim)
    view = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])  # towards the camera
    for k in range(P):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        C = np.asarray(plan.orientations[k], float)
        for i in range(3):
            for s in (1.0, -1.0):
                n = np.zeros(3)
                n[i] = s
                if (C @ n) @ view <= 1e-9:  # a face turned away from the camera: matplotlib would not hide it
                    continue
                j1, j2 = [j for j in range(3) if j != i]
                corners = []
                for c1, c2 in ((1, 1), (1, -1), (-1, -1), (-1, 1)):
                    v = n * half
                    v[j1], v[j2] = c1 * half[j1], c2 * half[j2]
                    corners.append(C @ v)
                name = _face(i, s)
                ax.add_collection3d(
                    Poly3DCollection([corners], facecolor=_FACE_COLORS[name], edgecolor="k", linewidth=0.6)
                )
                centre = C @ (n * half)
                ax.text(
                    *(centre + 0.12 * (C @ n)), name, fontsize=9, ha="center", va="center", weight="bold", zorder=10
                )
        # beside the box, not above it: seen from 60° an arrow over the box lies across its top faces
        ax.quiver(-0.65, 0.65, 0.0, 0, 0, 0.45, color="k", arrow_length_ratio=0.3)
        ax.text(-0.65, 0.65, 0.55, "up", fontsize=7, ha="center")
        ax.quiver(0, -0.7, -0.7, 0, 0.4, 0, color="gray", arrow_length_ratio=0.3)
        ax.text(0, -0.2, -0.7, "N", fontsize=7, color="gray")
        ax.set_xlim(-0.7, 0.7)
        ax.set_ylim(-0.7, 0.7)
        ax.set_zlim(-0.7, 0.7)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_axis_off()
        title = textwrap.fill(f"{k + 1}. {plan.words[k]}", 42)
        ax.set_title(title, fontsize=7)
    fig.suptitle(f"{P} poses, rest {plan.dwell_s:g} s each (box: x long, z short; + faces dark)", fontsize=9)
    # 0.4 in kept for the title: in a tall figure (18 poses, 5 rows) it was written over the first row's titles
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.4 / fig.get_figheight()))
    with atomic_path(path, "--figure") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
