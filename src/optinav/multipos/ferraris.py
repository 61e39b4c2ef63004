"""Closed-form Ferraris calibration of an accelerometer and a gyroscope triad.

Ferraris, Grimaldi & Parvis, "Procedure for effortless in-field calibration of three-axial rate gyros and
accelerometers", Sensors and Materials 7(5), 1995, pp. 311–330; the section layout and sign conventions follow
imucal's ``FerrarisCalibration`` (Küderle et al., JOSS 7(73):4338, 2022), so its results are reproduced.

Recording: six static poses with each sensor axis up and down (``x_p``, ``x_a``, ``y_p``, ``y_a``, ``z_p``,
``z_a``: the accelerometer axis reads +g / −g) and three rotations by a known angle about x, y and z
(``x_rot``, ``y_rot``, ``z_rot``, each started from the corresponding ``_p`` pose).

Model in optinav's convention (``raw`` in the input units, x in SI)::

    acc_raw  = K_a f + b_a                     f specific force (m/s²)
    gyro_raw = K_g ω + G f + b_g               ω angular rate (rad/s), G g-sensitivity (raw per m/s²)

With U₊, U₋ (3×3) the mean raw outputs of the six poses stacked as columns (x, y, z) and g the local
gravity magnitude, the closed form is (Ferraris eqs. 19–23; 9; 12–15)::

    K_a = (U₊ − U₋) / (2g)            b_a,i = ((U₊ + U₋)/2)_ii
    G   = (V₊ − V₋) / (2g)            b_g   = mean of all static gyro samples
    K_g = W diag(θ)⁻¹,  W_:j = ∫ (gyro_raw − G f̂ − b_g) dt over rotation j,  f̂ = K_a⁻¹(acc_raw − b_a)

with V± the gyro pose means and θ the expected rotation angles (rad). imucal factors K_a = K'_a R_a and
K_g = K'_g R_g (diagonal scale × rows of unit sensitivity axes) and calibrates the gyro to deg/s, so
``K_g(ours) = K'_g R_g · 180/π``; :mod:`optinav.multipos.convert` converts both ways. Limitations of the
method: the Earth rate is ignored (it enters b_g and K_g at the 1e-4 level for a 360° turn in ~10 s), the
rotations must be about single axes, and the bias estimate of an axis uses only the two poses of that axis.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.validate import as_float_array, check_positive, check_timestamps, integration_steps
from optinav.errors import OptinavError

__all__ = [
    "FerrarisCalibration",
    "ferraris_calibration",
    "ferraris_from_sections",
    "sections_from_labels",
    "POSES",
    "ROTATIONS",
    "SECTIONS",
    "IMUCAL_GRAVITY",
    "check_rotations",
    "ferraris_std",
    "repair_rotation_glitches",
    "repair_pose_spikes",
    "noise_roll_off",
    "turn_sampling",
    "turn_sampling_std",
]

#: static pose names in imucal's order: axis x/y/z pointing up (p, reads +g) or down (a, reads −g)
POSES = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")
#: rotation section names
ROTATIONS = ("x_rot", "y_rot", "z_rot")
SECTIONS = POSES + ROTATIONS
#: imucal's default gravity (m/s²); pass the local gravity (optinav.core.earth.gravity) for best accuracy
IMUCAL_GRAVITY = 9.81
#: the turn goes on outside its section while the rate about the axis keeps its sign and stays above this
#: fraction of the section's 90th-percentile rate
TURN_GOES_ON = 0.02
#: largest accepted turn outside a rotation section, as a fraction of the stated angle
MAX_MISSED_TURN = 0.02
#: gravity at least this far (degrees) from a rotation axis lets the accelerometer see the turn
ACC_SEES_TURN_DEG = 30.0
#: largest accepted difference (degrees) between the turn the accelerometer sees and the stated angle
MAX_TURN_MISMATCH_DEG = 5.0
#: a step of a turn made in steps keeps gravity within this angle (degrees) of where the section left it
STEP_KEEPS_UP_DEG = 5.0


@dataclass(eq=False)
class FerrarisCalibration(Result):
    """Result of :func:`ferraris_calibration` in the convention ``raw = K x + b`` (module docstring).

    ``acc_K`` (raw acc per m/s²), ``acc_b`` (raw acc), ``gyr_K`` (raw gyro per rad/s), ``gyr_G`` (raw
    gyro per m/s²), ``gyr_b`` (raw gyro). Diagnostics: ``acc_static_norm`` (6,) the norms of the corrected
    pose means (m/s², equal to ``gravity`` up to the inconsistency of the six poses), the pose means,
    the samples per pose and the rotation durations. Version 2 renamed the version-1 fields ``gyro_`` K, G, b
    to ``gyr_K``/``gyr_G``/``gyr_b`` (the result's parameter names; version-1 files still load).
    """

    SCHEMA = "optinav.ferraris_calibration"
    VERSION = 2

    acc_K: np.ndarray = field(metadata={"unit": "acc raw unit / (m/s^2)"})
    acc_b: np.ndarray = field(metadata={"unit": "acc raw unit"})
    gyr_K: np.ndarray = field(metadata={"unit": "gyro raw unit / (rad/s)"})
    gyr_G: np.ndarray = field(metadata={"unit": "gyro raw unit / (m/s^2)"})
    gyr_b: np.ndarray = field(metadata={"unit": "gyro raw unit"})
    gravity: float = field(metadata={"unit": "m/s^2"})
    expected_angle: np.ndarray = field(metadata={"unit": "rad"})
    acc_unit: str = field(default="raw", metadata={"unit": "-"})
    gyro_unit: str = field(default="raw", metadata={"unit": "-"})
    acc_static_means: np.ndarray | None = field(default=None, metadata={"unit": "acc raw unit"})
    gyro_static_means: np.ndarray | None = field(default=None, metadata={"unit": "gyro raw unit"})
    static_counts: np.ndarray | None = field(default=None, metadata={"unit": ""})
    rotation_duration: np.ndarray | None = field(default=None, metadata={"unit": "s"})
    acc_static_norm: np.ndarray | None = field(default=None, metadata={"unit": "m/s^2"})

    def correct_acc(self, acc_raw) -> np.ndarray:
        """Specific force (..., 3) m/s² from raw accelerometer samples: K_a⁻¹(raw − b_a)."""
        a = as_float_array(acc_raw, "acc_raw", last_dims=(3,))
        return np.linalg.solve(self.acc_K, (a - self.acc_b).reshape(-1, 3).T).T.reshape(a.shape)

    def correct_gyro(self, gyro_raw, acc_si) -> np.ndarray:
        """Angular rate (..., 3) rad/s: K_g⁻¹(raw − G f − b_g), f the corrected specific force (m/s²)."""
        w = as_float_array(gyro_raw, "gyro_raw", last_dims=(3,))
        f = as_float_array(acc_si, "acc_si", last_dims=(3,))
        if f.shape != w.shape:
            raise OptinavError(
                f"acc_si has shape {f.shape} but gyro_raw has {w.shape}",
                "pass one corrected acc sample per gyro sample",
            )
        r = w - f @ self.gyr_G.T - self.gyr_b
        return np.linalg.solve(self.gyr_K, r.reshape(-1, 3).T).T.reshape(w.shape)

    def correct(self, acc_raw, gyro_raw) -> tuple[np.ndarray, np.ndarray]:
        """(specific force m/s², angular rate rad/s) from raw samples (imucal's ``calibrate`` in SI)."""
        f = self.correct_acc(acc_raw)
        return f, self.correct_gyro(gyro_raw, f)

    def to_imucal(self, comment: str | None = None):
        """The same calibration as an :class:`optinav.multipos.convert.ImucalCalibration` (outputs m/s², deg/s)."""
        from optinav.multipos.convert import ImucalCalibration

        return ImucalCalibration.from_optinav(
            self.acc_K,
            self.acc_b,
            self.gyr_K,
            self.gyr_G,
            self.gyr_b,
            from_acc_unit=self.acc_unit,
            from_gyr_unit=self.gyro_unit,
            comment=comment,
        )


register_legacy(
    FerrarisCalibration,
    FerrarisCalibration.SCHEMA,
    1,
    lambda d: nested_kwargs(FerrarisCalibration, d, {"gyro_" + k: "gyr_" + k for k in "KGb"}),
)


# --------------------------------------------------------------------------------------------------------
# input handling
# --------------------------------------------------------------------------------------------------------


def _sections(x, names: tuple[str, ...], what: str) -> list:
    """A dict by name or a sequence in ``names`` order → list of arrays (each (3,) or (N, 3))."""
    if isinstance(x, dict):
        missing = [n for n in names if n not in x]
        if missing:
            raise OptinavError(f"{what} lacks the section(s) {', '.join(missing)}", f"give all of {', '.join(names)}")
        items = [x[n] for n in names]
    else:
        if isinstance(x, np.ndarray) and x.ndim == 2 and x.shape == (len(names), 3):
            items = list(x)
        else:
            try:
                items = list(x)
            except TypeError:
                raise OptinavError(
                    f"{what} is not a sequence of {len(names)} sections",
                    f"pass a dict or a list in the order {', '.join(names)}",
                ) from None
        if len(items) != len(names):
            raise OptinavError(
                f"{what} has {len(items)} sections, expected {len(names)}", f"pass them in the order {', '.join(names)}"
            )
    out = []
    for n, it in zip(names, items):
        a = as_float_array(it, f"{what}[{n}]", last_dims=(3,))
        if a.ndim > 2 or (a.ndim == 2 and a.shape[0] == 0):
            raise OptinavError(f"{what}[{n}] has shape {a.shape}", "pass (N, 3) samples or a (3,) mean")
        out.append(a)
    return out


def _pose_means(secs: list) -> tuple[np.ndarray, np.ndarray | None]:
    """Means (6, 3) of the parsed poses and their sample counts (None when means were given)."""
    means = np.array([s if s.ndim == 1 else s.mean(axis=0) for s in secs])
    counts = np.array([s.shape[0] for s in secs], dtype=np.int64) if all(s.ndim == 2 for s in secs) else None
    return means, counts


# --------------------------------------------------------------------------------------------------------
# calibration
# --------------------------------------------------------------------------------------------------------


def ferraris_calibration(
    acc_static,
    gyro_static,
    acc_rot,
    gyro_rot,
    *,
    rate_hz: float | None = None,
    dt=None,
    expected_angle=-2.0 * np.pi,
    gravity: float = IMUCAL_GRAVITY,
    static_counts=None,
    acc_unit: str = "raw",
    gyro_unit: str = "raw",
) -> FerrarisCalibration:
    """Ferraris closed form (module docstring) from the six poses and the three rotations.

    Parameters
    ----------
    acc_static, gyro_static : dict or sequence of arrays
        The poses ``x_p, x_a, y_p, y_a, z_p, z_a`` by name or in that order, each (N_i, 3) samples or a (3,) mean
        [input units].
    acc_rot, gyro_rot : dict or sequence of arrays
        The rotations ``x_rot, y_rot, z_rot`` as (M_j, 3) samples [input units].
    rate_hz : float or None
        Sample rate [Hz]; the rotation integral is Σ samples / rate, as imucal.
    dt : float, sequence of 3 (M_j,) arrays or None
        Sample steps [s] instead of ``rate_hz``.
    expected_angle : float or (3,) array
        Turn angle per axis [rad]; imucal's default −360° (a clockwise turn seen from the axis tip, which makes
        the gyro read negative).
    gravity : float
        Gravity [m/s^2] (imucal default 9.81; pass the local value).
    static_counts : (6,) int array or None
        Samples per pose when means are given, to weight the gyro bias as imucal does.
    acc_unit, gyro_unit : str
        Names of the raw units.

    Returns
    -------
    FerrarisCalibration
        ``acc_K`` [raw/(m/s^2)], ``acc_b`` [raw], ``gyr_K`` [raw/(rad/s)], ``gyr_G`` [raw/(m/s^2)], ``gyr_b`` [raw].
    """
    p = _prepare(acc_static, gyro_static, acc_rot, gyro_rot, rate_hz, dt, expected_angle, gravity, static_counts)
    return _calibration(p, acc_unit, gyro_unit)


def _calibration(p: _Inputs, acc_unit: str, gyro_unit: str) -> FerrarisCalibration:
    """:func:`ferraris_calibration` of prepared inputs."""
    acc_K, acc_b, G, gyr_b, gyr_K = _closed_form(p.Ua, p.Ug, p.cg, p.Sw, p.Sa, p.D, p.th, p.g)
    if _singular(acc_K):
        raise OptinavError(
            "the six accelerometer pose means give a singular scale matrix",
            "check that the poses x_p..z_a point each axis up and down, in imucal's order",
        )
    if _singular(gyr_K):
        raise OptinavError(
            "the three rotations give a singular gyro scale matrix",
            "check that x_rot, y_rot and z_rot each turn about one sensor axis by expected_angle",
        )
    norms = np.linalg.norm((p.Ua - acc_b) @ np.linalg.inv(acc_K).T, axis=1)
    return FerrarisCalibration(
        acc_K=acc_K,
        acc_b=acc_b,
        gyr_K=gyr_K,
        gyr_G=G,
        gyr_b=gyr_b,
        gravity=p.g,
        expected_angle=p.th,
        acc_unit=str(acc_unit),
        gyro_unit=str(gyro_unit),
        acc_static_means=p.Ua,
        gyro_static_means=p.Ug,
        static_counts=p.ca,
        rotation_duration=p.D,
        acc_static_norm=norms,
    )


class _Inputs(NamedTuple):
    g: float
    th: np.ndarray  # (3,) rad
    Ua: np.ndarray  # (6, 3) pose means, acc raw
    Ug: np.ndarray  # (6, 3) pose means, gyro raw
    ca: np.ndarray | None  # samples per pose (None: means given)
    cg: np.ndarray | None  # weights of the gyro bias
    static: tuple  # (acc, gyro) pose sections as given
    rot: tuple  # (acc, gyro) rotation samples
    steps: list  # per rotation: (M_j,) steps in s, or None (Σ / rate)
    rate: float | None
    Sw: np.ndarray  # (3, 3) column j: Σ gyro dt over rotation j (raw·s)
    Sa: np.ndarray  # (3, 3) column j: Σ acc dt over rotation j (raw·s)
    D: np.ndarray  # (3,) rotation durations (s)
    gap_var: np.ndarray  # (3, 3) column j: variance of Σ gyro dt over the gaps of rotation j (raw·s)²
    #: the gyroscope's own samples where the rows hold them interpolated: ([(w, h)] per rotation, [w] per pose)
    own: tuple | None = None
    #: (3, 3) column j: variance of Σ gyro dt over rotation j from a linear interpolation's images (raw·s)², and the
    #: largest as a share of its turn (:func:`interpolation_images`)
    image_var: np.ndarray | None = None
    image_share: float = 0.0


def _gap_variance(w: np.ndarray, h: np.ndarray, k: int) -> np.ndarray:
    """Variance (3,) of the unknown integral of ``w`` over the gap after sample ``k`` (step ``h[k]``) bridged by
    the mean of its end rates: the turn's own departure from that bridge, over every stretch of the same length
    it did record (a hand turn's rate peaks between samples 0.1 s apart: the bridge missed 4° of 28°)."""
    med = float(np.median(h))
    L = max(1, int(round(h[k] / med)))
    M = w.shape[0]
    fallback = (h[k] * (w[k + 1] - w[k])) ** 2 / 12.0  # uniform between the two rectangles
    if M - L < 3:
        return fallback
    cw = np.concatenate([np.zeros((1, 3)), np.cumsum(w * h[:, None], axis=0)])
    ch = np.concatenate([[0.0], np.cumsum(h)])
    cg = np.concatenate([[0], np.cumsum(h > GAP_STEPS * med)])
    i = np.arange(M - L)
    clean = cg[i + L] == cg[i]  # stretches without a gap of their own
    if np.count_nonzero(clean) < 3:
        return fallback
    i = i[clean]
    dev = (cw[i + L] - cw[i]) - 0.5 * (w[i] + w[i + L]) * (ch[i + L] - ch[i])[:, None]
    scale = (h[k] / np.mean(ch[i + L] - ch[i])) ** 2
    whole = np.mean(dev**2, axis=0) * scale
    # and the stretches around the gap alone: a hand turn's rate changes most near its peak, and the mean over the
    # whole section (its slow ends too) left a gap there 4-5 std off
    near = np.abs(i + 0.5 * L - (k + 0.5)) <= GAP_NEIGHBOURHOOD * L
    local = np.mean(dev[near] ** 2, axis=0) * scale if np.count_nonzero(near) >= 3 else whole
    return np.maximum(np.maximum(whole, local), fallback)


#: the stretches within this many gap lengths of a gap give its local variance (:func:`_gap_variance`)
GAP_NEIGHBOURHOOD = 3.0

#: a step longer than this many median steps inside a rotation is a gap (lost samples)
GAP_STEPS = 1.5


def _prepare(acc_static, gyro_static, acc_rot, gyro_rot, rate, dt, expected_angle, gravity, static_counts) -> _Inputs:
    """Checked inputs of :func:`ferraris_calibration` and the sums over each rotation."""
    g = check_positive(gravity, "gravity")
    th = (
        np.broadcast_to(as_float_array(expected_angle, "expected_angle"), (3,)).astype(float).copy()
        if np.ndim(expected_angle) == 0
        else as_float_array(expected_angle, "expected_angle")
    )
    if th.shape != (3,) or np.any(th == 0):
        raise OptinavError(
            f"expected_angle must be a non-zero scalar or 3 non-zero angles (rad), got {th!r}",
            "pass e.g. expected_angle=-2*pi (imucal's -360 deg)",
        )
    static = (_sections(acc_static, POSES, "acc_static"), _sections(gyro_static, POSES, "gyro_static"))
    Ua, ca = _pose_means(static[0])
    Ug, cg = _pose_means(static[1])
    if static_counts is not None:
        sc = as_float_array(static_counts, "static_counts")
        if sc.shape != (6,) or np.any(sc <= 0):
            raise OptinavError(
                f"static_counts must be 6 positive counts, got {np.ravel(sc).tolist()}",
                "give the number of samples of each pose",
            )
        cg = sc
    ar = _sections(acc_rot, ROTATIONS, "acc_rot")
    gr = _sections(gyro_rot, ROTATIONS, "gyro_rot")
    for n, a, w in zip(ROTATIONS, ar, gr):
        if a.ndim != 2 or w.ndim != 2 or a.shape != w.shape:
            raise OptinavError(
                f"rotation {n}: acc {a.shape} and gyro {w.shape} samples do not match",
                "pass (M, 3) acc and gyro samples of the same rotation",
            )
    if (rate is None) == (dt is None):
        raise OptinavError("give exactly one of rate (Hz) and dt (s)", "e.g. rate=102.4")
    if rate is not None:
        rate = check_positive(rate, "rate")
        steps = [None, None, None]
    elif isinstance(dt, (int, float, np.number)) or (isinstance(dt, np.ndarray) and dt.ndim == 0):
        d = check_positive(dt, "dt")
        steps = [np.full(w.shape[0], d) for w in gr]
    else:
        steps = [as_float_array(s, f"dt[{n}]") for n, s in zip(ROTATIONS, _seq3(dt))]
        for n, s, w in zip(ROTATIONS, steps, gr):
            if s.shape != (w.shape[0],) or np.any(s <= 0):
                raise OptinavError(
                    f"dt[{n}] must hold {w.shape[0]} positive steps, got shape {s.shape}",
                    "give one step (s) per rotation sample",
                )
    Sw, Sa, D, gap_var = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3))
    for j, (a, w, h) in enumerate(zip(ar, gr, steps)):
        if h is None:
            Sw[:, j], Sa[:, j], D[j] = w.sum(axis=0) / rate, a.sum(axis=0) / rate, w.shape[0] / rate
            continue
        Sw[:, j], Sa[:, j], D[j] = h @ w, h @ a, h.sum()
        gap = np.flatnonzero(h[:-1] > GAP_STEPS * np.median(h))
        if gap.size:
            # lost samples inside the turn: the step across the gap takes the mean of the rates on both sides
            # (the rate before alone: 10 lost rows of a hand turn, K_xx 1.2 % off at a std of 0.016 %)
            Sw[:, j] += 0.5 * h[gap] @ (w[gap + 1] - w[gap])
            Sa[:, j] += 0.5 * h[gap] @ (a[gap + 1] - a[gap])
            gap_var[:, j] = sum(_gap_variance(w, h, k) for k in gap)
    return _Inputs(g, th, Ua, Ug, ca, cg, static, (ar, gr), steps, rate, Sw, Sa, D, gap_var)


def _closed_form(Ua, Ug, cg, Sw, Sa, D, th, g):
    """K_a, b_a, G, b_g, K_g of the module docstring from the pose means and the rotation sums (the integral of
    the offset-free gyro output is linear in them: ∫c dt = Sw − G K_a⁻¹ (Sa − b_a D) − b_g D). ``Ua``, ``Ug``,
    ``Sw`` and ``Sa`` may carry a leading axis of draws (each draw solved alone, as one call of its own would)."""
    # accelerometer (Ferraris eqs. 19-23): columns are the x, y, z poses
    Up, Un = np.swapaxes(Ua[..., 0::2, :], -1, -2), np.swapaxes(Ua[..., 1::2, :], -1, -2)
    acc_K = (Up - Un) / (2.0 * g)
    acc_b = 0.5 * np.diagonal(Up + Un, axis1=-2, axis2=-1)
    # gyroscope g-sensitivity (eq. 9) and bias (all static samples)
    G = (np.swapaxes(Ug[..., 0::2, :], -1, -2) - np.swapaxes(Ug[..., 1::2, :], -1, -2)) / (2.0 * g)
    gyr_b = Ug.mean(axis=-2) if cg is None else (cg[:, None] * Ug).sum(axis=-2) / cg.sum()
    # rotations (eqs. 12-15)
    sing = _singular(acc_K)
    with np.errstate(all="ignore"):
        if np.ndim(sing) == 0:
            Kinv = np.linalg.pinv(acc_K) if sing else np.linalg.inv(acc_K)
        else:
            Kinv = np.empty_like(acc_K)
            Kinv[~sing] = np.linalg.inv(acc_K[~sing])
            Kinv[sing] = np.linalg.pinv(acc_K[sing])
    W = Sw - G @ Kinv @ (Sa - acc_b[..., :, None] * D) - gyr_b[..., :, None] * D
    return acc_K, acc_b, G, gyr_b, W / th


def _mean_cov(x: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Covariance (3, 3) of the mean of samples x (N, 3) with the lag-1 correlation of the noise taken into
    account (AR(1): variance of the mean × (1 + ρ)/(1 − ρ)); also ρ and the per-sample variance (3,)."""
    r = x - x.mean(axis=0)
    n = x.shape[0]
    rho = float(np.clip(np.sum(r[1:] * r[:-1]) / max(float(np.sum(r * r)), 1e-300), 0.0, 0.95))
    cov = r.T @ r / max(n - 1, 1)
    return cov / n * (1 + rho) / (1 - rho), rho, np.diag(cov)


def white_noise(stats) -> np.ndarray:
    """Per-sample variance (3,) [unit²] of white noise that an integral of the samples adds up as the stills show
    it: the median over the stills of their per-sample variance, times (1 + ρ)/(1 − ρ) for the median lag-1
    correlation ρ (AR(1): a low-passed noise's integral grows as its low-frequency level, not its sample variance).
    ``stats`` the :func:`_mean_cov` of each still."""
    rho = float(np.median([c[1] for c in stats]))
    return np.median([c[2] for c in stats], axis=0) * (1 + rho) / (1 - rho)


def _step(sections) -> np.ndarray:
    """The readings' resolution (3,) over ``sections`` of (N_i, 3) samples: the smallest step any of them takes per
    axis (:func:`_resolution`; 0 where none moves)."""
    r = [_resolution(np.asarray(x, float)) for x in sections if np.ndim(x) == 2 and len(x) > 1]
    r = np.array(r) if r else np.full((1, 3), 1e-300)
    r = np.where(r > 1e-300, r, np.inf).min(axis=0)
    return np.where(np.isfinite(r), r, 0.0)


def quantized_mean_var(var, step):
    """Variance [unit²] (3,) of a reading's bias from its quantization, which the noise does not average out where
    it is below about half a step: the mean of Q(x + n) misses x by up to (Δ/π) exp(−2π²σ²/Δ²) (Widrow's first
    harmonic; σ² the readings' variance less Δ²/12, Δ the step), taken as uniform within that bound. It holds
    for a still pose's mean and for every sample of a turn at a constant rate. ``var`` (3,) the readings'
    variance, ``step`` (3,) Δ, in the readings' unit (Δ 0: none). A 16-bit gyro with 0.15 counts of noise: K_g
    8.7 std off the truth without it."""
    var, step = np.asarray(var, float), np.asarray(step, float)
    sig2 = np.maximum(var - step**2 / 12.0, 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        bound = step / np.pi * np.exp(-2.0 * np.pi**2 * np.where(step > 0.0, sig2 / step**2, np.inf))
    return np.nan_to_num(bound) ** 2 / 3.0


def ferraris_std(
    acc_static,
    gyro_static,
    acc_rot,
    gyro_rot,
    *,
    rate_hz: float | None = None,
    dt=None,
    expected_angle=-2.0 * np.pi,
    gravity: float = IMUCAL_GRAVITY,
    rng=0,
    n_draws: int = 2000,
) -> dict:
    """1σ of the Ferraris closed form from the noise of its inputs, by Monte Carlo through the closed form.

    The pose means vary by their within-pose covariance over the samples (lag-1 correlation taken into account)
    and the rotation integrals by the gyro's and accelerometer's white noise measured in the poses, integrated
    over each rotation (Σ dt²); where the gyro's noise at rest shows no anti-alias filter, the rotation integrals
    also by their sampling (:func:`turn_sampling`); both, where the readings' noise is below their step, by the
    quantization's bias (:func:`quantized_mean_var`). Not included (add them where known): the unknown local g, the
    Earth rate in the bias, a turn missed by the sections. Arguments as :func:`ferraris_calibration` (samples, not
    means); ``rng`` seed or Generator. Returns ``acc_K``, ``acc_b``, ``gyr_K``, ``gyr_G``, ``gyr_b`` std in the
    result's units (NaN when the poses are given as means), ``gyr_turn_sampling``, that sampling's std as a share
    of each turn (0: filtered, or not judged), ``gyr_turn_sampling_each`` (3,) that share of turn j's integral on its
    own axis, and ``gyr_images``, the largest share of a turn from a linear
    interpolation's images (:func:`interpolation_images`; 0 here, where no second file's clock is given)."""
    p = _prepare(acc_static, gyro_static, acc_rot, gyro_rot, rate_hz, dt, expected_angle, gravity, None)
    return _std(p, rng, n_draws)


def _std(p: _Inputs, rng, n_draws: int) -> dict:
    """:func:`ferraris_std` of prepared inputs."""
    from optinav.core.validate import as_rng

    shapes = {"acc_K": (3, 3), "acc_b": (3,), "gyr_G": (3, 3), "gyr_b": (3,), "gyr_K": (3, 3)}
    if p.ca is None or np.any(p.ca < 3):
        nan = {k: np.full(v, np.nan) for k, v in shapes.items()}
        return {**nan, "gyr_turn_sampling": 0.0, "gyr_turn_sampling_each": np.zeros(3), "gyr_images": 0.0}
    gen = as_rng(rng)
    covs = []
    noise = []
    quant = []  # per sensor: a reading's quantization bias, as a variance (3,), where the noise does not dither it
    for k, (secs, rot) in enumerate(zip(p.static, p.rot)):
        c = [_mean_cov(x) for x in secs]
        # a gyro file on its own clock: its quantization is its own samples' (interpolated rows fall between steps)
        read = (*secs, *rot) if k == 0 or p.own is None else (*p.own[1], *(w for w, _ in p.own[0]))
        step = _step(read)
        rvar = (
            [ci[2] for ci in c]
            if k == 0 or p.own is None
            else [np.var(x, axis=0) if len(x) > 1 else ci[2] for x, ci in zip(p.own[1], c)]
        )
        covs.append(np.array([ci[0] + np.diag(quantized_mean_var(v, step)) for ci, v in zip(c, rvar)]))
        noise.append(white_noise(c))
        quant.append(quantized_mean_var(np.median(rvar, axis=0), step))
    # Σ dt² per rotation: the variance of an integral of white noise
    h2 = np.array([(x.shape[0] / p.rate**2) if h is None else float(h @ h) for x, h in zip(p.rot[1], p.steps)])
    w, V = np.linalg.eigh(np.stack(covs))  # a square root that a zero-variance (clipped) axis cannot break
    chol = V * np.sqrt(np.clip(w, 0.0, None))[..., None, :]
    # all draws at once, in the order a draw-by-draw loop takes them: per draw 6×3, 6×3, 3×3 and 3×3 normals
    z = gen.standard_normal((n_draws, 54))
    Ua = p.Ua + np.einsum("pij,npj->npi", chol[0], z[:, :18].reshape(n_draws, 6, 3))
    Ug = p.Ug + np.einsum("pij,npj->npi", chol[1], z[:, 18:36].reshape(n_draws, 6, 3))
    # a turn held at a constant rate reads one quantization bias throughout: that bias over its duration
    Sa = p.Sa + np.sqrt(noise[0][:, None] * h2[None, :] + quant[0][:, None] * p.D**2) * z[:, 36:45].reshape(
        n_draws, 3, 3
    )
    if p.own is None:
        turns = [(w, np.full(w.shape[0], 1.0 / p.rate) if h is None else h) for w, h in zip(p.rot[1], p.steps)]
        share, samp = turn_sampling(turns, p.static[1])
    else:
        share, samp = turn_sampling(*p.own)
    var = noise[1][:, None] * h2[None, :] + quant[1][:, None] * p.D**2 + p.gap_var + samp**2
    if p.image_var is not None:
        var = var + p.image_var
    Sw = p.Sw + np.sqrt(var) * z[:, 45:].reshape(n_draws, 3, 3)
    out = _closed_form(Ua, Ug, p.cg, Sw, Sa, p.D, p.th, p.g)
    std = {k: v.std(axis=0, ddof=1) for k, v in zip(("acc_K", "acc_b", "gyr_G", "gyr_b", "gyr_K"), out)}
    each = np.diag(samp) / np.maximum(np.abs(np.diag(p.Sw)), 1e-300)
    return {**std, "gyr_turn_sampling": share, "gyr_turn_sampling_each": each, "gyr_images": p.image_share}


#: the gyro's noise at rest shows an anti-alias filter when its power over the top tenth of the band below the Nyquist
#: frequency falls below its power over 0.4-0.8 of it by more than ROLL_OFF_SIGMA times the scatter of that ratio for
#: white noise (:func:`noise_roll_off`). imucal's session at 102.4 Hz: 10.7; its every 2nd, 3rd or 4th row (no filter,
#: the noise above the new Nyquist frequency folded back): -2.8 to 1.3; low-passed before decimating
#: (scipy.signal.decimate's FIR, resample_poly): 3.8 to 5.8
ROLL_OFF_SIGMA = 3.0


def noise_roll_off(poses) -> float:
    """How far the noise power of still samples falls from 0.4-0.8 to 0.9-1 of the Nyquist frequency, in units of
    that ratio's scatter for white noise (0: white up to the Nyquist frequency, no anti-alias filter; NaN: no
    noise to judge). ``poses`` a sequence of (N_i, 3) still samples on a uniform clock [any unit]."""
    top = mid = 0.0
    n_top = n_mid = 0
    for x in poses:
        x = np.asarray(x, float)
        if x.ndim != 2 or x.shape[0] < 20 or not np.all(np.isfinite(x)):
            continue
        P = np.abs(np.fft.rfft(x - x.mean(axis=0), axis=0)) ** 2
        f = np.fft.rfftfreq(x.shape[0]) * 2.0  # in units of the Nyquist frequency
        t, m = f > 0.9, (f > 0.4) & (f < 0.8)
        top, mid = top + float(P[t].sum()), mid + float(P[m].sum())
        n_top, n_mid = n_top + 3 * int(np.count_nonzero(t)), n_mid + 3 * int(np.count_nonzero(m))
    if not (n_top and n_mid and mid > 0.0):
        return float("nan")
    return (1.0 - (top / n_top) / (mid / n_mid)) / float(np.sqrt(1.0 / n_top + 1.0 / n_mid))


def _top_level(w: np.ndarray, h: float, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Mean power (3,) of a turn's samples ``w`` (M, 3) over the top fifth of the band below the Nyquist frequency
    (|h·DFT|², the ends' line taken out), the white noise's level there (M h² σ², ``noise`` (3,) σ²) and its bins."""
    M = w.shape[0]
    k = max(1, min(5, M // 10))
    x = w - np.linspace(w[:k].mean(axis=0), w[-k:].mean(axis=0), M)
    P = np.abs(np.fft.rfft(x, axis=0) * h) ** 2
    top = np.fft.rfftfreq(M) * 2.0 > 0.8
    return P[top].mean(axis=0), M * h * h * noise, int(np.count_nonzero(top))


#: the top's power carried from its centre (0.9 f_N) to the sample rate and its multiples m f_s = 2m f_N (both signs
#: of m) at the slowest decay a turn's rate can have, |W| ∝ 1/f (a jump in rate): Σ 2 (2m/0.9)^-2 = 0.9² π²/12
TOP_CARRY = 0.9**2 * np.pi**2 / 12.0


def turn_sampling(turns, poses) -> tuple[float, np.ndarray]:
    """The uncertainty of the rotations' integrals from their sampling, where the still samples show no anti-alias
    filter (:func:`noise_roll_off` below :data:`ROLL_OFF_SIGMA`): a turn's content at the sample rate then folds
    into its integral (imucal's session on every 2nd row, 51.2 Hz: K_g 4-5 std off with exit 0; low-passed before
    decimating, within 0.4). Its size from the turns' spectra (:func:`turn_sampling_std`), pooled over the turns as
    shares of each. ``turns`` the three rotations' (w (M, 3) raw, h (M,) steps s), ``poses`` the six (N, 3) still
    samples. Returns (that error as a share of each turn; (3, 3) std of Σ w h [raw·s], column j rotation j); (0,
    zeros) with a filter or nothing to judge."""
    none = (0.0, np.zeros((3, 3)))
    turns = [(np.asarray(w, float), np.asarray(h, float)) for w, h in turns]
    if any(w.shape[0] < 20 or not np.all(np.isfinite(w)) for w, _ in turns):
        return none
    std = turn_sampling_std(turns, poses, axes=range(3))
    if std is None:
        return none
    size = [np.abs(np.minimum(h, float(np.median(h))) @ w)[j] for j, (w, h) in enumerate(turns)]
    rel_top = float(np.mean([std[j, j] ** 2 / max(size[j], 1e-300) ** 2 for j in range(3)]))
    return float(np.sqrt(rel_top)), std


def turn_sampling_std(turns, poses, axes=None) -> np.ndarray | None:
    """Std (3, T) [raw·s] of the integrals Σ w h of T turns from their sampling, column k turn k, where the still
    samples show no anti-alias filter (:func:`noise_roll_off` below :data:`ROLL_OFF_SIGMA`); None with a filter or
    where no turn's top is above the noise. The power over the top fifth of the band below the Nyquist frequency
    (noise level taken out) carried to the sample rate and its multiples at the slowest decay a turn's rate can have,
    1/f (:data:`TOP_CARRY`; a jump in rate, sampled at a random phase, errs by its size × step / √12), as the turn
    integral's error on sampling at a random phase (Σ over m ≠ 0 of |W(m f_s)|²); none where the top is within the
    noise (below the 99.9 % point of its level for noise alone) on the axis judged. The decay is not measured from
    the band below: a vibration line or a ring folded into it made it look flat (refused, though K_g was within 2
    std) or steep (K_g up to 23 std off with exit 0). Content above the Nyquist frequency that the top does not show
    (a line near a multiple of the sample rate, folding near 0 Hz) is beyond it. ``turns`` (w (M, 3) raw, h (M,)
    steps s) each, ``poses`` (N, 3) still samples [raw]; ``axes`` per turn the axis judged against the noise (None:
    the axis it turns most about). Turns under 20 samples or not finite get 0."""
    from scipy.special import gammaincinv

    if not noise_roll_off(poses) < ROLL_OFF_SIGMA:
        return None
    noise = np.median([np.var(np.asarray(x, float), axis=0) for x in poses if np.ndim(x) == 2 and len(x) > 2], axis=0)
    # a reading's quantization error, within ±Δ/2, adds up to Δ²/4 to its noise by where it falls between two steps,
    # which the poses need not show where their noise is below a step (a 16-bit gyro with 0.2 counts of noise at
    # rest: a motorized turn's noise 1.5x the poses', refused as spectra not falling off)
    step = _step([w for w, _ in turns])
    noise = noise + step**2 / 4.0
    std, over = np.zeros((3, len(turns))), False
    for k, (w, h) in enumerate(turns):
        w, h = np.asarray(w, float), np.asarray(h, float)
        if w.shape[0] < 20 or not np.all(np.isfinite(w)):
            continue
        hm = float(np.median(h))
        t, floor, n = _top_level(w, hm, noise)
        j = int(np.argmax(np.abs(np.minimum(h, hm) @ w))) if axes is None else list(axes)[k]
        # a top within the noise's 99.9 % point (its mean over n bins of 2 degrees of freedom each) is no evidence
        over |= bool(t[j] > floor[j] * gammaincinv(n, 0.999) / n)  # (χ²₂ₙ's 99.9 % point over 2n)
        std[:, k] = np.sqrt(np.maximum(t - floor, 0.0) * TOP_CARRY)
    return std if over else None


def _singular(M: np.ndarray):
    """Whether a (3, 3) matrix is singular or not finite (condition number above 1e10); for a stack (n, 3, 3)
    the (n,) booleans."""
    if M.ndim == 2:
        if not np.all(np.isfinite(M)) or not np.any(M):
            return True
        return bool(np.linalg.cond(M) > 1e10)
    out = ~np.all(np.isfinite(M), axis=(-2, -1)) | ~np.any(M, axis=(-2, -1))
    with np.errstate(all="ignore"):
        out[~out] = np.linalg.cond(M[~out]) > 1e10
    return out


def _seq3(x):
    try:
        items = list(x)
    except TypeError:
        raise OptinavError(
            "dt is neither a scalar nor 3 per-sample step arrays", "pass dt=1/rate or 3 arrays"
        ) from None
    if len(items) != 3:
        raise OptinavError(
            f"dt has {len(items)} entries, expected 3 (x_rot, y_rot, z_rot)",
            "pass a scalar dt or one step array per rotation",
        )
    return items


def section_name(name) -> str:
    """imucal's name of a section written in capitals or with blanks around it ('X_P ' → 'x_p': the label column
    and the section list named no section before, 'the Ferraris method needs ... the nine named sections'); any
    other name as given."""
    key = str(name).strip().lower()
    return key if key in SECTIONS else str(name)


def labels_name_sections(labels) -> bool:
    """Whether a per-sample label column labels every row with one of the nine sections ``x_p … z_rot``, all of
    them present (in imucal's spelling, or in capitals or with blanks around it): a log cut to its sections."""
    if labels is None:
        return False
    return set(SECTIONS) == {section_name(u) for u in np.unique(np.asarray(labels).astype(str))}


def sections_from_labels(labels) -> dict | None:
    """The nine sections ``x_p … z_rot`` as {name: (i0, i1)} half-open sample ranges from a per-sample label
    column (imucal's annotated ``part`` column); None when the labels name none of them. Each named section
    must be one contiguous run, and all nine must be present."""
    if labels is None:
        return None
    uniq, inv = np.unique(np.asarray(labels).astype(str), return_inverse=True)
    lab = np.array([section_name(u) for u in uniq])[inv.reshape(-1)]
    present = [n for n in SECTIONS if np.any(lab == n)]
    if not present:
        return None
    missing = [n for n in SECTIONS if n not in present]
    if missing:
        raise OptinavError(
            f"the label column names {', '.join(present)} but not {', '.join(missing)}",
            "label all nine Ferraris sections, or give them with --sections FILE",
        )
    out = {}
    for n in SECTIONS:
        i = np.flatnonzero(lab == n)
        if i[-1] - i[0] + 1 != i.size:
            raise OptinavError(
                f"the label {n!r} marks {i.size} samples that are not one contiguous run",
                "label each Ferraris section once, or give them with --sections FILE",
            )
        out[n] = (int(i[0]), int(i[-1]) + 1)
    return out


def ferraris_from_sections(t_or_rate, acc, gyr, sections, *, with_std: bool = False, gyr_clock=None, **kwargs):
    """Ferraris calibration of a continuous log with annotated sections.

    With timestamps the rotation integral uses the steps inside each section
    (:func:`optinav.core.validate.integration_steps`: the step to the next row only where it is no jump — a log
    cut to its nine sections joins them end to end, and a turn's last sample times the 10 s to the next section
    added 4–9° to it); with a rate, Σ samples / rate (imucal).

    Parameters
    ----------
    t_or_rate : (N,) array or float
        Timestamps [s], or the sample rate [Hz] of a uniformly sampled log without timestamps.
    acc, gyr : (N, 3) array
        Raw samples [input units].
    sections : dict, SectionList or str
        The nine sections ``x_p … z_rot`` (imucal's names): name → (i0, i1) half-open sample ranges, name →
        {"start": i0, "end": i1} (imucal's section list), a :class:`optinav.multipos.static.SectionList`, or the
        path of imucal's JSON section list.
    **kwargs
        Passed to :func:`ferraris_calibration`.

    with_std : bool
        Also return :func:`ferraris_std` of the sections (``rng=`` among ``kwargs`` seeds it; default 0).
    gyr_clock : (t_g (M,) array, gyr_g (M, 3) array) or None
        The gyroscope's own times [s] and samples [input units] where ``gyr`` holds them interpolated onto the
        timestamps (a second file on its own clock): each rotation sums them over the span its rows stand for
        (:func:`_own_clock_integral`), their sampling and, where they were interpolated from the timestamps' clock,
        that interpolation's images enter the std (:func:`turn_sampling`, :func:`interpolation_images`). None, or
        with a rate: the rows.

    Returns
    -------
    FerrarisCalibration, or (FerrarisCalibration, dict) with ``with_std``
        As :func:`ferraris_calibration` (and :func:`ferraris_std`).
    """
    gyro = gyr
    from optinav.multipos.static import SectionList, sections_from_list

    acc = as_float_array(acc, "acc", last_dims=(3,))
    gyro = as_float_array(gyro, "gyro", last_dims=(3,))
    if acc.ndim != 2 or gyro.shape != acc.shape:
        raise OptinavError(
            f"acc {acc.shape} and gyro {gyro.shape} must be (N, 3) arrays of equal length",
            "pass one acc and one gyro sample per epoch",
        )
    N = acc.shape[0]
    if np.ndim(t_or_rate) == 0:
        rate = check_positive(t_or_rate, "rate")
        t = None
    else:
        rate = None
        t = check_timestamps(t_or_rate, "t", min_count=2)
        if t.size != N:
            raise OptinavError(f"t has {t.size} samples but acc has {N}", "pass one timestamp per sample")
    if isinstance(sections, (str, Path)):
        sections = sections_from_list(sections, t if t is not None else np.arange(N) / rate)
    if isinstance(sections, SectionList):
        sections = sections.as_dict()
    if not isinstance(sections, dict):
        raise OptinavError(
            "sections must map the section names to sample ranges", "pass {'x_p': (i0, i1), ..., 'z_rot': (i0, i1)}"
        )
    missing = [n for n in SECTIONS if n not in sections]
    if missing:
        raise OptinavError(f"sections lacks {', '.join(missing)}", f"annotate all of {', '.join(SECTIONS)}")
    idx = {}
    for n in SECTIONS:
        v = sections[n]
        try:
            i0, i1 = (v["start"], v["end"]) if isinstance(v, dict) else tuple(v)
            i0, i1 = int(i0), int(i1)
        except (KeyError, TypeError, ValueError):
            raise OptinavError(
                f"section {n!r} is {v!r}, not a sample range (i0, i1)", "give half-open sample index ranges"
            ) from None
        if not 0 <= i0 < i1 <= N:
            raise OptinavError(
                f"section {n!r} range [{i0}, {i1}) is empty or outside the log of {N} samples", "give 0 ≤ i0 < i1 ≤ N"
            )
        idx[n] = (i0, i1)
    parts = [{n: x[slice(*idx[n])] for n in names} for x, names in ((acc, POSES), (gyro, POSES))]
    parts += [{n: x[slice(*idx[n])] for n in ROTATIONS} for x in (acc, gyro)]
    if rate is not None:
        timing = {"rate_hz": rate}
    else:
        timing = {
            "dt": [integration_steps(t[slice(*idx[n])], t[idx[n][1]] if idx[n][1] < N else None) for n in ROTATIONS]
        }
    rng = kwargs.pop("rng", 0)  # the Monte Carlo std's seed
    own = gyr_clock is not None and t is not None
    if not with_std and not own:
        return ferraris_calibration(*parts, **timing, **kwargs)
    # the inputs prepared once for both: the closed form, then its Monte Carlo std
    units = {k: kwargs.pop(k, "raw") for k in ("acc_unit", "gyro_unit")}
    p = _prepare(
        *parts,
        timing.get("rate_hz"),
        timing.get("dt"),
        kwargs.pop("expected_angle", -2.0 * np.pi),
        kwargs.pop("gravity", IMUCAL_GRAVITY),
        kwargs.pop("static_counts", None),
    )
    if kwargs:
        raise TypeError(f"ferraris_from_sections got unexpected keyword(s) {sorted(kwargs)}")
    if own:
        # the rows' sum of the interpolated rates takes each sample where a row falls: a linear interpolant's
        # kinks at a hand turn's jerks, sampled at another phase, moved the integral by up to 5e-4 of the turn
        # (3 std of K_jj; the second file at 1.3x the rate), twice the turn's own samples' difference
        Sw = p.Sw.copy()
        for j, (n, h) in enumerate(zip(ROTATIONS, timing["dt"])):
            a = t[idx[n][0]] - 0.5 * h[0]  # the rows' steps, each centred on its row
            Sw[:, j] = _own_clock_integral(gyr_clock[0], gyr_clock[1], a, a + float(h.sum()))
        own_samples = _own_samples(gyr_clock, t, idx, timing["dt"])
        img, share = interpolation_images(gyr_clock, t, idx, timing["dt"])
        p = p._replace(Sw=Sw, own=own_samples, image_var=None if img is None else img**2, image_share=share)
        if not with_std:
            return _calibration(p, **units)
    return _calibration(p, **units), _std(p, rng, 2000)


#: a gyro file's still samples whose noise variance follows their phase on the accelerometer's clock as a linear
#: interpolation's does, beyond this many std of that regression's slope, were interpolated from that clock
#: (imucal's gyro interpolated onto 0.7-1.3x the rate: 7.2-14; resampled by a polyphase filter, or its own: below 2.0)
INTERPOLATED_SIGMA = 5.0


def interpolation_images(gyr_clock, t, idx: dict, steps: list) -> tuple[np.ndarray | None, float]:
    """Where a second file's gyro samples (``gyr_clock`` = (times (M,) s, samples (M, 3) raw)) were linearly
    interpolated from samples on the accelerometer's clock (``t`` (N,) s, rate f₀; ``idx`` the sections' rows,
    ``steps`` the rotations' steps as :func:`ferraris_from_sections` takes them), the std (3, 3) of each rotation's
    integral (column j) from the interpolant's images, and its largest share of a turn; (None, 0) when the still
    samples do not show it. Between the clock's samples a linear interpolant averages their noise, whose variance
    goes as α² + (1 − α)² of its phase α on that clock: that modulation beyond :data:`INTERPOLATED_SIGMA` std of the
    regression's slope tells it. The interpolant's kinks put an image of the turn's content at |f' − f₀| (f' the
    file's rate) at f', where the file's samples fold it into the integral, weighed sinc²(f'/f₀): at most
    2|W(|f' − f₀|)| sinc²(f'/f₀) / sinc²(|f' − f₀|/f₀), W read from the file (imucal's gyro interpolated onto 0.8x
    the rate: K_yy 4.0 std off with exit 0; every turn's error within that bound at 0.7-1.3x)."""
    tg, wg = (np.asarray(v, float) for v in gyr_clock)
    t = np.asarray(t, float)
    f0 = 1.0 / float(np.median(np.diff(t)))
    fp = 1.0 / float(np.median(np.diff(tg)))
    turn_spans, pose_spans = _own_spans(tg, t, idx, steps)
    r2, g = [], []
    for k0, k1 in pose_spans:
        x = wg[k0:k1]
        if x.shape[0] < 20 or not np.all(np.isfinite(x)):
            continue
        alpha = np.mod((tg[k0:k1] - t[0]) * f0, 1.0)
        r2.append(np.sum((x - x.mean(axis=0)) ** 2, axis=1))
        g.append(alpha**2 + (1.0 - alpha) ** 2)
    if not r2:
        return None, 0.0
    r2, g = np.concatenate(r2), np.concatenate(g)
    if r2.size < 50 or np.std(g) < 0.01:  # (one phase on the clock throughout: the same rate, no images)
        return None, 0.0
    A = np.column_stack([np.ones_like(g), g - g.mean()])
    coef, *_ = np.linalg.lstsq(A, r2, rcond=None)
    e = r2 - A @ coef
    slope_std = float(np.sqrt(e @ e / (r2.size - 2) * np.linalg.inv(A.T @ A)[1, 1]))
    if not coef[1] > INTERPOLATED_SIGMA * slope_std:
        return None, 0.0
    fb = abs(fp - f0)
    fa = abs(fb - round(fb / fp) * fp)  # where the file's samples show the content at fb
    weight = np.sinc(fp / f0) ** 2 / max(float(np.sinc(fb / f0) ** 2), 1e-12)
    std = np.zeros((3, 3))
    share = 0.0
    for j, (k0, k1) in enumerate(turn_spans):
        w = wg[k0:k1]
        if w.shape[0] < 4:
            continue
        k = np.arange(w.shape[0])
        W = np.abs(np.exp(-2j * np.pi * fa * k / fp) @ (w - w.mean(axis=0))) / fp
        std[:, j] = 2.0 * W * weight
        share = max(share, float(std[j, j] / max(abs(float(w[:, j].sum())) / fp, 1e-300)))
    return std, share


def _own_samples(gyr_clock, t, idx: dict, steps: list) -> tuple:
    """The gyroscope's own samples (``gyr_clock``) of each rotation, with their steps, over the span its rows stand
    for, and of each pose within its rows' times: :func:`turn_sampling` judges the samples the integrals use."""
    tg, wg = (np.asarray(v, float) for v in gyr_clock)
    turn_spans, pose_spans = _own_spans(tg, t, idx, steps)
    turns = [(wg[k0:k1], integration_steps(tg[k0:k1], tg[k1] if k1 < tg.size else None)) for k0, k1 in turn_spans]
    return turns, [wg[k0:k1] for k0, k1 in pose_spans]


def _own_spans(tg, t, idx: dict, steps: list) -> tuple[list, list]:
    """Index ranges (k0, k1) into a gyro file's own times ``tg`` (M,) s: per rotation the samples within the span
    its rows stand for (from its first row less half a step, for the sum of its ``steps``), per pose those within
    its rows' times (``t`` (N,) s, ``idx`` the sections' rows)."""
    turns = []
    for n, h in zip(ROTATIONS, steps):
        a = t[idx[n][0]] - 0.5 * h[0]
        turns.append(tuple(int(k) for k in np.searchsorted(tg, [a, a + float(h.sum())])))
    poses = [tuple(int(k) for k in np.searchsorted(tg, [t[idx[n][0]], t[idx[n][1] - 1]], "right")) for n in POSES]
    return turns, poses


def _own_clock_integral(t, w, a: float, b: float) -> np.ndarray:
    """The integral (3,) of the rates ``w`` (M, 3, any unit per s) at times ``t`` (M,) s over [a, b) (s), taken as
    the rows' sum takes it: each sample holds over its step (:func:`optinav.core.validate.integration_steps`),
    centred on it, here the part of that inside [a, b); a clock equal to the rows' gives their sum."""
    t = np.asarray(t, float)
    k0, k1 = np.searchsorted(t, [a, b])
    k0, k1 = max(int(k0) - 1, 0), min(int(k1) + 1, t.size)
    h = integration_steps(t[k0:k1], t[k1] if k1 < t.size else None)
    held = np.clip(np.minimum(t[k0:k1] + 0.5 * h, b) - np.maximum(t[k0:k1] - 0.5 * h, a), 0.0, None)
    return held @ np.asarray(w, float)[k0:k1]


def _turn_outside(
    w: np.ndarray, dt: np.ndarray, i0: int, i1: int, other: np.ndarray, up: np.ndarray | None
) -> tuple[float, float]:
    """Angle (rad) turned about axis j just before sample i0 and from sample i1 on, while the rate ``w`` (N, 3,
    rad/s; column 0 the axis j) keeps the sign of the section's turn above :data:`TURN_GOES_ON` of its
    90th-percentile rate, up to a sample of another section (``other`` (N,) bool: a file of cut sections joins
    them end to end). A turn made in steps (4 × 90° with pauses) goes on after a pause no longer than 1.5× the
    longest pause inside the section, with a burst about the axis (|ω_j| ≥ 0.9‖ω‖) that keeps gravity within
    :data:`STEP_KEEPS_UP_DEG` of where it was (``up`` (N, 3) unit specific force: a step about a vertical axis
    does, the move to the next pose does not); ``up`` None: no steps after a pause (the accelerometer judges)."""
    wj = w[:, 0]
    sec = wj[i0:i1]
    sign = np.sign(sec @ dt[i0:i1]) or 1.0
    level = TURN_GOES_ON * float(np.percentile(np.abs(sec), 90))
    gap = 5.0 * float(np.median(dt))  # a jump in time (a log of cut sections) ends the turn
    moving = sign * wj > level
    axial = np.abs(wj) >= 0.9 * np.linalg.norm(w, axis=1)
    inside = np.flatnonzero(moving[i0:i1])
    longest = int((np.diff(inside) - 1).max()) if inside.size > 1 and up is not None else 0
    lead = int(inside[0]) if inside.size else i1 - i0
    trail = int(i1 - i0 - 1 - inside[-1]) if inside.size else i1 - i0
    cos_keep = np.cos(np.radians(STEP_KEEPS_UP_DEG))

    def run(ks, pause: int, ref: int) -> float:
        total, burst, resumed = 0.0, 0.0, pause == 0
        for k in ks:
            if dt[k] > gap or other[k]:
                break
            if moving[k] and (resumed or axial[k]):
                if not resumed and up is not None and up[k] @ up[ref] < cos_keep:
                    total -= burst  # gravity moved: the move to the next pose, not a step of the turn
                    break
                total += wj[k] * dt[k]
                burst += wj[k] * dt[k]
                pause = 0
                continue
            pause, resumed, burst = pause + 1, False, 0.0
            if pause > 1.5 * longest:
                break
        return abs(total)

    return run(range(i0 - 1, -1, -1), lead, i0), run(range(i1, wj.size), trail, i1 - 1)


def check_rotations(cal: FerrarisCalibration, t, acc, gyr, ranges: dict) -> list[dict]:
    """Each rotation section holds one whole turn by the stated angle, or a one-line error.

    Two views that the closed form cannot give (it scales K_g so that every section integrates to the stated
    angle, whatever the section holds): the turn the gyro sees *outside* the section (it goes on after the
    section ends or began before it: a cut section, K_g too small by the missed share), and, for an axis at
    least :data:`ACC_SEES_TURN_DEG` from gravity, the turn of gravity the accelerometer sees across the section
    (a turn shorter or longer than stated). ``t`` (N,) s, ``acc``/``gyr`` (N, 3) raw, ``ranges`` name →
    (i0, i1) of the log. Returns per rotation ``{"name", "missed_deg", "acc_turn_deg"}`` (NaN: not seen)."""
    t = np.asarray(t, float)
    a = cal.correct_acc(acc)
    w = cal.correct_gyro(gyr, a)
    dt = np.diff(t)
    dt = np.append(dt, dt[-1] if dt.size else 0.0)
    up = a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)
    out = []
    for j, name in enumerate(ROTATIONS):
        i0, i1 = ranges[name]
        stated = abs(float(cal.expected_angle[j]))
        other = np.zeros(w.shape[0], bool)
        for n, (a0, a1) in ranges.items():
            other[a0:a1] |= n != name
        p = [(j + 1) % 3, (j + 2) % 3]  # cyclic: the angle of atan2(f_p1, f_p0) turns about +j
        f = a[i0:i1]
        perp = np.linalg.norm(f[:, p], axis=1)
        sees = bool(np.median(perp / np.linalg.norm(f, axis=1)) >= np.sin(np.radians(ACC_SEES_TURN_DEG)))
        # a turn about a vertical axis made in steps may go on after a pause; about a horizontal one the
        # accelerometer sees the whole turn, and the move to the next pose would look like one more step
        before, after = _turn_outside(np.roll(w, -j, axis=1), dt, i0, i1, other, None if sees else up)
        if before + after > MAX_MISSED_TURN * stated:
            where = "goes on after it ends" if after >= before else "began before it starts"
            raise OptinavError(
                f"the turn of {name} {where}: the gyro turns {np.degrees(before + after):.3g}° about "
                f"{'xyz'[j]} outside the section ({np.degrees(before):.3g}° before, {np.degrees(after):.3g}° "
                f"after), so the gyro scale misses that share of the {np.degrees(stated):.4g}° turn",
                f"let the section {name} span the whole turn, from rest to rest (--sections, or the label column)",
            )
        acc_turn = np.nan
        if sees:
            # gravity turns the other way in the sensor frame: −(angle of its component across the axis)
            # (a sample far from g is no gravity direction: an accelerometer spike of 10 g turned the unwrapped
            # angle by 360°, and the run was refused as a turn of 720° or 0°)
            g_med = float(np.median(np.linalg.norm(f, axis=1)))
            ok = np.abs(np.linalg.norm(f, axis=1) - g_med) < 0.5 * g_med
            phi = np.interp(np.arange(f.shape[0]), np.flatnonzero(ok), np.unwrap(np.arctan2(f[ok, p[1]], f[ok, p[0]])))
            m = max(1, min(f.shape[0] // 10, int(np.ceil(0.1 / max(float(np.median(dt[i0:i1])), 1e-9)))))
            acc_turn = -float(phi[-m:].mean() - phi[:m].mean())
            if abs(acc_turn - cal.expected_angle[j]) > np.radians(MAX_TURN_MISMATCH_DEG):
                raise OptinavError(
                    f"in {name} the accelerometer sees gravity turn by {np.degrees(acc_turn):.4g}° about "
                    f"{'xyz'[j]}, not the stated {np.degrees(cal.expected_angle[j]):.4g}°: the section does not "
                    "hold the whole turn, or the turn was not by the stated angle",
                    f"let the section {name} span the whole turn from rest to rest (--sections), or pass the "
                    "angle turned (--rotation-angle)",
                )
        out.append(
            {"name": name, "missed_deg": float(np.degrees(before + after)), "acc_turn_deg": float(np.degrees(acc_turn))}
        )
    return out


#: a run of up to GLITCH_RUN gyro samples inside a rotation that leaves the samples around it and comes back (its
#: departure: the smaller of the two jumps, less the jumps inside the run) is a glitch when the departure exceeds
#: GLITCH_FRACTION of the section's 95th-percentile rate and GLITCH_OUTLIER times the section's 5th-largest
#: one-sample departure (the turn's own roughness at this rate). Measured on imucal's six real rotations at their
#: rates and at 1/2, 1/4, 1/8 of them (every phase; sections of ≥ GLITCH_MIN_SAMPLES): at most 6.9×, for one real
#: 40-ms burst of annotated y_rot that its 51.2-Hz copies hold in one sample; at the native rates ≤ 0.20 and ≤ 2.8×.
#: A spike of 300 deg/s in imucal's z_rot is 0.75 and 12×; one of 150 deg/s (K_zz 0.41 % off) is 0.37 and 5.8×,
#: like that burst, and passes this test (the test by isolation below tells it).
GLITCH_FRACTION = 0.3
GLITCH_OUTLIER = 8.0
GLITCH_RUN = 3
#: a rotation of fewer samples has too few to tell its roughness (imucal's sessions at 12.8 Hz: 40-68 samples a
#: turn, real departures up to 37× the 5th largest) and is not judged
GLITCH_MIN_SAMPLES = 100
#: spikes repaired per rotation section before it is refused
MAX_SPIKES = 3
#: a second test, by isolation: a run of up to GLITCH_RUN samples whose departure (the smallest of its mean offset
#: from the line through the samples on both sides and from the lines extrapolated from two samples on either
#: side, less the jumps inside the run: a band-limited rate continues one of them, a kink included) exceeds
#: GLITCH_MIN_DEPARTURE of the section's 95th-percentile rate and, for one sample, GLITCH_ISOLATION times the largest
#: one-sample departure within GLITCH_WINDOW rows around it (or the section's median one, the noise where it is
#: quiet); a longer run, once bridged, GLITCH_RUN_ISOLATION times. Measured on imucal's six real rotations at their
#: rates and at 1/2, 1/4, 1/8 of them (every phase): one sample at most 7.6× (a real burst of annotated z_rot held
#: in one sample at 51.2 Hz), runs at most 14×; smaller departures are real shocks the accelerometer sees too
#: (annotated y_rot: 0.03 of the rate, 19× its surroundings; K_g < 0.02 %). One sample 50 / 150 deg/s off in the
#: still start of imucal's z_rot is 19× / 58× (0.12 / 0.37 of the rate, under the first test), two of 150 are 57×.
#: Amid the turn's own jerks a spike of their size is not told from the turn by the gyro alone.
GLITCH_ISOLATION = 10.0
GLITCH_RUN_ISOLATION = 20.0
GLITCH_WINDOW = 5
GLITCH_MIN_DEPARTURE = 0.05


def _worst_glitch(w: np.ndarray) -> tuple[float, float, int, int, int]:
    """The largest departure-and-return of ``w`` (M, 3) as a fraction of its 95th-percentile rate:
    (fraction, fraction over the section's 5th-largest one-sample departure, first row, run length, axis); a
    run's samples differ from each other by less than it departs."""
    scale = float(np.nanpercentile(np.abs(w).max(axis=1), 95)) if np.isfinite(w).any() else 0.0
    d = np.diff(w, axis=0)
    best = (0.0, 0.0, 0, 0, 0)
    if not scale > 0.0 or w.shape[0] < GLITCH_MIN_SAMPLES:
        return best
    fifth = 0.0
    for L in range(1, GLITCH_RUN + 1):
        n = w.shape[0] - L - 1  # runs starting at rows 1 .. M-L-1, with a sample on each side
        if n < 1:
            break
        din, dout = d[:n], d[L : L + n]
        inner = np.zeros_like(din)
        for i in range(1, L):
            inner = np.maximum(inner, np.abs(d[i : i + n]))
        m = np.where(np.sign(din) == -np.sign(dout), np.minimum(np.abs(din), np.abs(dout)) - inner, 0.0) / scale
        m = np.nan_to_num(m, nan=0.0)  # (a NaN row, left by --skip-bad-lines, judges nothing)
        if L == 1:
            fifth = float(np.sort(m.ravel())[-5])
        k, c = np.unravel_index(int(np.argmax(m)), m.shape)
        if m[k, c] > best[0]:
            best = (float(m[k, c]), 0.0, int(k) + 1, L, int(c))
    return (best[0], best[0] / max(fifth, 1e-12), *best[2:])


def _departures(w: np.ndarray, L: int) -> np.ndarray:
    """Per start row k (M − L + 1, 3) the departure of the run w[k:k+L] (M, 3) from the rate around it: the
    smallest |mean offset| from the line through w[k−1], w[k+L] and from the lines extrapolated from w[k−2], w[k−1]
    and from w[k+L+1], w[k+L], less the largest jump inside the run (w's unit; 0 within two rows of an end)."""
    M = w.shape[0]
    out = np.zeros((max(M - L + 1, 0), w.shape[1]))
    if M < L + 4:
        return out
    k = np.arange(2, M - L - 1)
    run = np.mean([w[k + i] for i in range(L)], axis=0)
    a1, a2, b1, b2 = w[k - 1], w[k - 2], w[k + L], w[k + L + 1]
    mid = 0.5 * (L + 1)  # the run's centre, in rows after k − 1
    interp = a1 + (b1 - a1) * mid / (L + 1)
    left = a1 + (a1 - a2) * mid
    right = b1 + (b1 - b2) * mid
    dep = np.minimum(np.minimum(np.abs(run - interp), np.abs(run - left)), np.abs(run - right))
    inner = np.zeros_like(dep)
    for i in range(L - 1):
        inner = np.maximum(inner, np.abs(w[k + i + 1] - w[k + i]))
    out[k] = np.nan_to_num(np.maximum(dep - inner, 0.0), nan=0.0)  # (a NaN row judges nothing)
    return out


def _resolution(w: np.ndarray) -> np.ndarray:
    """Per axis of ``w`` (M, 3) the smallest nonzero step between samples, the readings' resolution (one count of
    a quantized gyro; 1e-300 where the axis never changes)."""
    d = np.abs(np.diff(w, axis=0))
    d = np.where(np.isfinite(d) & (d > 0.0), d, np.inf)
    r = d.min(axis=0) if d.shape[0] else np.full(w.shape[1], np.inf)
    return np.where(np.isfinite(r), r, 1e-300)


def _worst_isolated(w: np.ndarray) -> tuple[float, float, int, int, int]:
    """The run of 1–:data:`GLITCH_RUN` samples of ``w`` (M, 3) that departs (:func:`_departures`) most beyond the
    one-sample departures within :data:`GLITCH_WINDOW` rows around it (floored at the section's median one): a
    sample beyond :data:`GLITCH_ISOLATION` × them, a longer run (once bridged by the line through its neighbours,
    whose departures reach into it) beyond :data:`GLITCH_RUN_ISOLATION` ×; only departures beyond
    :data:`GLITCH_MIN_DEPARTURE` of the 95th-percentile rate count. (multiple, departure over the rate, first row,
    run length, axis); all 0 when none is beyond its limit."""
    best, worst = (0.0, 0.0, 0, 0, 0), 1.0
    scale = float(np.nanpercentile(np.abs(w).max(axis=1), 95)) if np.isfinite(w).any() else 0.0
    if not scale > 0.0 or w.shape[0] < GLITCH_MIN_SAMPLES:
        return best
    # floored at the gyro's resolution too: where it reads one value for most samples (a section at rest, quantized
    # to whole counts) the median departure is 0, and one count's step was 'a glitch 6e+303× the departures
    # around it'
    floor = np.maximum(np.median(_departures(w, 1)[2:-2], axis=0), _resolution(w))
    h = GLITCH_WINDOW + 2
    for L in range(1, GLITCH_RUN + 1):
        limit = GLITCH_ISOLATION if L == 1 else GLITCH_RUN_ISOLATION
        dL = _departures(w, L)
        for k, c in np.argwhere((dL > GLITCH_MIN_DEPARTURE * scale) & (dL > limit * floor)):
            if k < h or k + L + h > w.shape[0]:
                continue
            seg = w[k - h : k + L + h, c].copy()
            if L > 1:
                seg[h : h + L] = seg[h - 1] + (seg[h + L] - seg[h - 1]) * np.arange(1, L + 1) / (L + 1)
            d1 = _departures(seg[:, None], 1)[:, 0]
            ratio = dL[k, c] / max(d1[2:h].max(), d1[h + L : -2].max(), floor[c])
            if ratio / limit > worst:
                worst, best = ratio / limit, (float(ratio), float(dL[k, c] / scale), int(k), L, int(c))
    return best


def find_glitch(w) -> tuple[str, int, int, int] | None:
    """The worst glitch of a turn's gyro samples ``w`` (M, 3, any unit) by the tests of
    :func:`repair_rotation_glitches` (a departure beyond :data:`GLITCH_FRACTION` of the rate and
    :data:`GLITCH_OUTLIER` × the turn's roughness, or one far beyond the departures around it), or None: (why, in
    words; first row; run length; axis)."""
    frac, outlier, k, L, c = _worst_glitch(w)
    if frac > GLITCH_FRACTION and outlier > GLITCH_OUTLIER:
        return (
            f"{frac:.2f} of the section's 95th-percentile rate, {outlier:.1f}× its 5th-largest such departure",
            k,
            L,
            c,
        )
    iso, frac, k, L, c = _worst_isolated(w)
    if not iso:
        return None
    return f"{frac:.2f} of the section's 95th-percentile rate, {iso:.0f}× the departures around it", k, L, c


def repair_rotation_glitches(gyr, ranges: dict, t=None, unit: str = "raw") -> tuple[np.ndarray, list[str]]:
    """Gyro samples (N, 3, raw) with one-sample spikes inside the rotation sections replaced by their neighbours'
    mean, and a note per repair. The closed form scales K_g so that each section integrates to the stated angle,
    so a glitch inside a turn scales K_g by its share (a spike of 150 deg/s in imucal's z_rot: K_zz −0.41 %, exit
    0). A run of 2–:data:`GLITCH_RUN` samples (a dropout: the true rates are unknown) is refused. A glitch is a
    departure beyond :data:`GLITCH_FRACTION` of the rate and :data:`GLITCH_OUTLIER` × the turn's roughness, or one
    far beyond the departures around it (:func:`_worst_isolated`); smaller ones pass unseen. ``ranges`` name →
    (i0, i1) rows; ``t`` (N,) s names the times (None: rows), ``unit`` the raw unit."""
    w = np.array(gyr, float)
    notes = []
    for j, name in enumerate(ROTATIONS):
        i0, i1 = ranges[name]
        for count in range(MAX_SPIKES + 1):
            hit = find_glitch(w[i0:i1])
            if hit is None:
                break
            why, k, L, c = hit
            row = i0 + k
            when = f"t = {t[row]:.6g} s" if t is not None else f"row {row}"
            size = float(w[row : row + L, c].mean() - 0.5 * (w[row - 1, c] + w[row + L, c]))
            share = abs(size) * L / max(abs(float(np.nansum(w[i0:i1, j]))), 1e-300)
            what = (
                f"{L} gyro {'xyz'[c]} sample(s) at {when} in {name} depart from the turn by {size:.4g} {unit} and "
                f"come back ({why}; {share:.2%} of its turn)"
            )
            if L > 1 or count == MAX_SPIKES:
                why = "a dropout or glitch" if L > 1 else f"a spike after {MAX_SPIKES} others"
                raise OptinavError(
                    f"{what}: {why}; the closed form would scale K_g by that share",
                    f"record the turn {name} again, or drop --method ferraris and --sections (the default fit finds "
                    "the rests and judges each turn between them)",
                )
            w[row, c] = 0.5 * (w[row - 1, c] + w[row + 1, c])
            notes.append(f"{what}: a spike, replaced by its neighbours' mean")
    return w, notes


#: a gyro glitch amid a turn the accelerometer sees (about an axis off gravity) is told by the gravity the
#: accelerometer measures: the gyro carries gravity along the turn, and after a glitch of δ (rad) the carried direction
#: stays δ off the measured one. The two agree up to the noise, the lever arm's accelerations ω×(ω×r) + α×r (r
#: fitted), a small linear map between the two sensors' frames and a scale error (a ramp); a step between the
#: STEP_WINDOW samples on either side of a row (STEP_GAP rows left out around it) beyond STEP_SIGMA times the
#: section's robust spread of such steps is a glitch. Simulated hand turns (rate jerking by 0.5-0.8 of itself at
#: ~15 Hz, the sensor 0-10 cm off the axis, poses placed exactly or within 1°; 230 clean turns): at most 4.6×; one
#: sample 0.5 rad/s off amid the jerks (K_jj 2-5 std off, unseen by the gyro's own tests) is refused in 37 of 45
#: turns, the 8 others (poses placed within 1°) moved K_jj 2.0-3.7 std. Samples far off the fit (an accelerometer
#: spike) are left out of it and of the windows.
STEP_WINDOW = 20
STEP_GAP = 2
STEP_SIGMA = 8.0


def turn_step(t, f, w) -> tuple[float, float, int]:
    """The largest step of the gyro's turn against the accelerometer's within one rotation section that starts and
    ends at rest: ``t`` (M,) s, ``f`` (M, 3) corrected specific force (m/s²), ``w`` (M, 3) corrected rate (rad/s).
    Gravity of the first samples is carried along the turn by ``w``; the measured ``f`` less it, less the lever arm's
    accelerations (r fitted), a small linear map between the two sensors' frames and a ramp along the turn (a scale
    error), is an angle about the turn's axis, whose step between the means of the windows on either side of each row
    is compared with the spread of such steps (robust σ); samples far off the fit are left out of it. Returns
    (step over its σ, step [rad], row of the step); (0, 0, 0) when the section is too short to judge."""
    from optinav.core.rotations import quat_conjugate, quat_rotate, skew
    from optinav.core.strapdown import attitude_update

    t, f, w = np.asarray(t, float), np.asarray(f, float), np.asarray(w, float)
    M = t.size
    if M < 4 * (STEP_WINDOW + STEP_GAP) or not (np.all(np.isfinite(f)) and np.all(np.isfinite(w))):
        return 0.0, 0.0, 0
    h = np.diff(t)
    wm = 0.5 * (w[:-1] + w[1:])  # the rate over each step (trapezoid)
    q = attitude_update(np.array([1.0, 0.0, 0.0, 0.0]), wm * h[:, None], dt=h)
    g0 = np.median(f[: STEP_WINDOW // 2], axis=0)
    gb = quat_rotate(quat_conjugate(q), np.broadcast_to(g0, (M, 3)))  # gravity carried along the turn (body axes)
    axis = np.sum(w, axis=0)
    axis /= max(float(np.linalg.norm(axis)), 1e-300)
    tang = np.cross(axis, gb) / float(np.linalg.norm(g0))  # direction gravity moves by a turn about the axis
    # angle turned so far (rad): a scale error grows with it
    turned = np.r_[0.0, np.cumsum(wm @ axis * h)]
    # regressors: the lever arm r (ω×(ω×r) + α×r), a small linear map E·g between the accelerometer's frame and the
    # gyro's (poses placed tilted leave the calibrated axes skewed against the gyro's: a smooth error over the turn,
    # 0.7° "steps" with exit 2 before E), and the ramp
    lever = skew(w) @ skew(w) + skew(np.gradient(w, t, axis=0))
    E = (np.eye(3)[None, :, :, None] * gb[:, None, None, :]).reshape(M, 3, 9)
    A = np.concatenate([lever, E, (tang * turned[:, None])[..., None]], -1)
    res = f - gb

    def fit(res, keep):
        coef, *_ = np.linalg.lstsq(A[keep].reshape(-1, A.shape[-1]), res[keep].reshape(-1), rcond=None)
        return coef

    keep = np.ones(M, bool)
    coef = fit(res, keep)
    # samples far off the fit (an accelerometer spike, the rows around a gyro glitch) do not steer it
    e = np.linalg.norm(res - A @ coef, axis=1)
    keep = e <= 8.0 * 1.4826 * float(np.median(e)) + 1e-300
    coef = fit(res, keep)
    # the map also acts on the lever arm's accelerations (jerks of 3 m/s² through a 1° skew: 0.1° steps): once more
    # with E·(ω×(ω×r) + α×r) of the first fit taken out
    res = res - (lever @ coef[:3]) @ coef[3:12].reshape(3, 3).T
    coef = fit(res, keep)
    ang = np.einsum("ij,ij->i", res - A @ coef, tang) / float(np.linalg.norm(g0))
    # means of the windows over the samples the fit kept: a spike of the accelerometer (a few samples far off the
    # fit) moves neither, a step of the gyro every sample after it
    W, G = STEP_WINDOW, STEP_GAP
    cs = np.r_[0.0, np.cumsum(np.where(keep, ang, 0.0))]
    cn = np.r_[0, np.cumsum(keep)]
    k = np.arange(W + G, M - W - G)

    def mean(a, b):
        return (cs[b] - cs[a]) / np.maximum(cn[b] - cn[a], 1)

    d = mean(k + G, k + G + W) - mean(k - G - W, k - G)
    sig = 1.4826 * float(np.median(np.abs(d - np.median(d))))
    i = int(np.argmax(np.abs(d)))
    return float(abs(d[i]) / max(sig, 1e-300)), float(d[i]), int(k[i])


#: a sample of a still pose is a spike when its departure (:func:`_departures`) exceeds POSE_SPIKE_SIGMA times the
#: pose's noise (robust σ of the second difference, at least half its smallest step) and GLITCH_ISOLATION times
#: every departure within GLITCH_WINDOW rows of it. imucal's 12 real poses, also at 1/2 and 1/4 of their rates:
#: at most 5.4σ, and 4.0 for the smaller of the two multiples. A tap rings over several samples: not isolated, it
#: is left to :func:`optinav.multipos.calibrate.pose_taps`, which refuses it.
POSE_SPIKE_SIGMA = 10.0


def repair_pose_spikes(x, ranges: dict, t=None, what: str = "gyro", unit: str = "raw") -> tuple[np.ndarray, list[str]]:
    """Samples (N, 3, ``unit``) with isolated one-sample spikes inside the still poses (``ranges`` pose name → (i0,
    i1) rows) replaced by their neighbours' mean, and a note per repair: one sample 5 m/s^2 off in imucal's x_p
    moved its mean by 14× its noise and the run was refused as a tap. A pose with more than :data:`MAX_SPIKES` per
    axis is left as it is. ``t`` (N,) s names the times (None: rows); ``what`` names the sensor."""
    w = np.array(x, float)
    notes = []
    for name, (i0, i1) in ranges.items():
        seg = w[i0:i1]
        if name not in POSES or seg.shape[0] < 2 * GLITCH_WINDOW + 5 or not np.isfinite(seg).any():
            continue
        e = seg[1:-1] - 0.5 * (seg[:-2] + seg[2:])
        sig = 1.4826 * np.nanmedian(np.abs(e - np.nanmedian(e, axis=0)), axis=0)
        steps = np.abs(np.diff(seg, axis=0))
        steps = steps[np.isfinite(steps) & (steps > 0)]
        sig = np.maximum(sig, 0.5 * float(steps.min()) if steps.size else 0.0)
        d1 = _departures(seg, 1)
        pad = np.pad(d1, ((GLITCH_WINDOW, GLITCH_WINDOW), (0, 0)))
        win = np.lib.stride_tricks.sliding_window_view(pad, 2 * GLITCH_WINDOW + 1, 0)
        around = np.maximum(win[..., :GLITCH_WINDOW].max(-1), win[..., GLITCH_WINDOW + 1 :].max(-1))
        spike = (d1 > POSE_SPIKE_SIGMA * np.maximum(sig, 1e-300)) & (d1 > GLITCH_ISOLATION * around)
        for c in range(3):
            rows = np.flatnonzero(spike[:, c])
            if rows.size > MAX_SPIKES:
                continue
            for k in rows:
                row = i0 + int(k)
                size = float(w[row, c] - 0.5 * (w[row - 1, c] + w[row + 1, c]))
                when = f"t = {t[row]:.6g} s" if t is not None else f"row {row}"
                notes.append(
                    f"1 {what} {'xyz'[c]} sample at {when} in the still pose {name} departs from its neighbours by "
                    f"{size:.4g} {unit} ({d1[k, c] / sig[c]:.0f}× the pose's noise, alone among quiet samples): a "
                    "spike, replaced by its neighbours' mean"
                )
                w[row, c] = 0.5 * (w[row - 1, c] + w[row + 1, c])
    return w, notes


#: the gyro's turns between the six poses may give the rotations' angle this far (fraction) from the stated one
#: before the calibration is refused (and beyond MIN_POSE_TURN_SIGMA of its std); below it the share beyond twice
#: its std enters K_g's std (imucal's session: 0.9977 ± 0.0011)
MAX_POSE_TURN = 0.01
MIN_POSE_TURN_SIGMA = 4.0
#: the poses' turns judge the angle only when one factor carries gravity between them within this RMS (rad per
#: transition; imucal's session 0.010, and with the wrong angle too)
POSE_TURN_RMS = np.radians(3.0)


class PoseTurns(NamedTuple):
    """The common factor λ on K_g that best carries gravity from pose to pose through the gyro's turns between
    them (1: the rotations turned by the stated angle), its std and the transitions used."""

    factor: float
    std: float
    transitions: int

    @property
    def limit(self) -> float:
        """The largest |factor − 1| accepted: MAX_POSE_TURN, or MIN_POSE_TURN_SIGMA of its std if larger."""
        return max(MAX_POSE_TURN, MIN_POSE_TURN_SIGMA * self.std)


class PoseTurnAxes(NamedTuple):
    """Per gyro axis j the factor λ_j (row j of K_g → λ_j × it) that, with the others', carries gravity from pose
    to pose through the gyro's turns where no common factor does (:func:`pose_turn_axes`), their std and the
    transitions used."""

    factors: np.ndarray
    std: np.ndarray
    transitions: int

    def off(self) -> list[int]:
        """The axes whose factor is beyond MAX_POSE_TURN and MIN_POSE_TURN_SIGMA of its std from 1."""
        limit = np.maximum(MAX_POSE_TURN, MIN_POSE_TURN_SIGMA * self.std)
        return [j for j in range(3) if abs(self.factors[j] - 1.0) > limit[j]]


def _pose_transitions(K, b, t, acc_dirs, gyr, poses, clipped):
    """(transitions, the ones used, the angles gravity turned through in them) of :func:`pose_turns`, or None
    under two transitions or when they turn gravity by < 30°."""
    from .transitions import Transitions

    t = np.asarray(t, float)
    poses = np.asarray(poses, int)
    dt = np.diff(t)
    gap = 5.0 * float(np.median(dt))
    bad = np.zeros(t.size, bool) if clipped is None else np.asarray(clipped, bool)
    keep = [
        k
        for k in range(poses.shape[0] - 1)
        if not (np.any(dt[poses[k, 1] - 1 : poses[k + 1, 0]] > gap) or np.any(bad[poses[k, 1] : poses[k + 1, 0]]))
    ]
    if not keep:
        return None
    u = np.asarray(acc_dirs, float)
    tr = Transitions(t, np.asarray(gyr, float), poses, u, "previous", keep)
    # a transition the gyro does not turn through (sections cut and joined end to end) is no evidence
    turned = np.arccos(np.clip(np.einsum("ij,ij->i", tr.u0, tr.u1), -1.0, 1.0))
    gyro_turn = tr.raw_rotation(b) / float(np.median(np.abs(np.diag(K))))
    used = gyro_turn >= 0.2 * turned  # (the scale may be off by the factor sought: a loose bound)
    turned = turned[used]
    if turned.size < 2 or turned.max() < np.radians(30.0):
        return None
    return tr, used, turned


def pose_turn_axes(K, b, t, acc_dirs, gyr, poses, clipped=None) -> PoseTurnAxes | None:
    """Where no common factor on K_g carries gravity between the poses (:func:`pose_turns` None), a factor per gyro
    axis that does (within :data:`POSE_TURN_RMS`), else None. One rotation section whose turn was not the stated
    angle scales its axis alone: 10 rows repeated inside imucal's x_rot (a log without time or counter) gave K_xx
    6 % high and 50 lost 12 % low with exit 0 — one factor left gravity 4.9 and 11.6° off, the axes' factors
    0.944 and 1.137 (the others 0.997) carry it within 0.6°, as the right K_g does."""
    from scipy.optimize import least_squares

    got = _pose_transitions(K, b, t, acc_dirs, gyr, poses, clipped)
    if got is None:
        return None
    tr, used, turned = got
    K, b = np.asarray(K, float), np.asarray(b, float)

    def res(x: np.ndarray) -> np.ndarray:
        return tr.residuals(np.exp(x)[:, None] * K, b)[used].ravel()

    r = least_squares(res, np.zeros(3), x_scale=0.1)
    e = r.fun
    if np.sqrt(float(e @ e) / turned.size) > POSE_TURN_RMS:
        return None
    lam = np.exp(r.x)
    s2 = float(e @ e) / max(e.size - 3, 1)
    try:
        cov = s2 * np.linalg.inv(r.jac.T @ r.jac)
    except np.linalg.LinAlgError:
        return None
    return PoseTurnAxes(lam, lam * np.sqrt(np.maximum(np.diag(cov), 0.0)), int(turned.size))


def pose_turns(K, b, t, acc_dirs, gyr, poses, clipped=None) -> PoseTurns | None:
    """The gyro (raw, K raw per rad/s, b raw) over the motions between consecutive still poses (``poses`` (P, 2)
    sample ranges in time order, ``acc_dirs`` (P, 3) their unit gravity directions in the body) must turn gravity
    from one pose's direction to the next's: the factor λ (K_g → λ·K_g) that does it best. The closed form takes
    each rotation section as exactly the stated angle, whatever was turned (imucal's session with
    --rotation-angle -330 gave K_g 9 % off at 530 std, exit 0); the poses' own turns tell. Transitions with a time
    gap (a log of cut sections) or a clipped gyro sample (``clipped`` (N,) bool rows) are left out; None under two
    transitions or when they turn gravity by < 30°."""
    from scipy.optimize import minimize_scalar

    got = _pose_transitions(K, b, t, acc_dirs, gyr, poses, clipped)
    if got is None:
        return None
    tr, used, turned = got
    K, b = np.asarray(K, float), np.asarray(b, float)

    def res(lam: float) -> np.ndarray:
        # per transition used C_kᵀu_k − u_{k+1}: ≈ the angle off (rad); each transition's rotation is its own
        return tr.residuals(K * lam, b)[used].ravel()

    r = minimize_scalar(lambda x: float(np.sum(res(np.exp(x)) ** 2)), bounds=(-1.6, 1.6), method="bounded")
    lam = float(np.exp(r.x))
    h = 1e-4
    J = (res(lam * (1 + h)) - res(lam * (1 - h))) / (2 * h * lam)
    e = res(lam)
    std = float(np.sqrt(float(e @ e) / max(e.size - 1, 1) / max(float(J @ J), 1e-300)))
    if np.sqrt(float(e @ e) / turned.size) > POSE_TURN_RMS:
        return None  # no one factor carries gravity between the poses: the motions are not what they seem
    return PoseTurns(lam, std, int(turned.size))
