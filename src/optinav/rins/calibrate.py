"""Gimbal non-orthogonality calibration of a dual-axis rotational INS (Li et al. 2023) and its RESULT.json.

Methods (``method=``):

* ``"none"`` — uncompensated (all six angles zero): the vehicle-attitude error the paper's Table 4 starts from.
* ``"axis"`` — the "previous method" (paper ref. [6], as reconstructed here): the gimbal rotation-axis
  directions in the IMU frame from the gyro increments of each forward/reverse move (Earth rate removed with
  the strapdown attitude, forward and reverse moves averaged so drift cancels), fitted to the first-order
  axis model ``u_in = C_h1^s e_z``, ``u_out(α) = C_h1^s R_z(α)ᵀ C_h2^h0 e_y`` by least squares. It reads
  the raw gyros, so gyro misalignment and scale errors enter the axis vectors (the paper's remark).
* ``"pso"`` — as published: global-best PSO (ω 0.8, c1 = c2 = 2, N = 20, G = 150, velocity clamp V ∈ [−1, 1]
  in units of 5 % of the search half-width, default ±0.01 rad) on the fitness of eqs. 12–14 over all six
  angles, the swarm evaluated at once.
* ``"lm"`` (default) — Levenberg–Marquardt on the same residuals with the analytic Jacobian
  (:func:`optinav.rins.model.residual_jacobian`), restricted to the observable subspace and started from the
  linearized least-squares solution.

Observability: the rank and null space of the first-order residual Jacobian (evaluated on a noise-free chain
following the recorded encoder angles), parameters scaled by 1 mrad. For ±180° dual-axis schemes the rank is
4: ``θz − ηz`` (the IMU turned about the inner axis versus the inner-zero frame turned about it) and ``ηy``
(the outer-encoder zero, i.e. the vehicle frame's definition about the outer axis) never change the attitude
*change* of eq. 12, so they are reported as null; ``θz + ηz`` is estimated as a combination.

Uncertainty: the residuals (strapdown attitude errors) are strongly autocorrelated, so the white-noise
covariance ``σ̂² (JᵀJ)⁻¹`` is inflated by the integrated autocorrelation time of the residuals (Sokal's
windowed estimate): ``std = sqrt(τ_int)`` × the white-noise standard deviation.
"""

from __future__ import annotations

import dataclasses
import functools
import time
import warnings
from dataclasses import field
from typing import Any

import numpy as np

from optinav.core import earth as _earth
from optinav.core.observability import analyze, format_combination, rref
from optinav.core.optimize import Problem, minimize, shortfall_note
from optinav.core.results import (
    Estimate,
    InvalidResult,
    Parameter,
    Truth,
    convergence,
    flat_kwargs,
    json_kind,
    gate,
    nested_array,
    nested_number,
    nested_strings,
    register_legacy,
    register_truth_legacy,
)
from optinav.core.validate import as_rng
from optinav.errors import OptinavError
from optinav.rins.model import (
    PARAM_NAMES,
    chain_pieces,
    equivalent_angles,
    nonorth_dcm,
    residual_jacobian,
    residuals,
    sensor_attitude,
)
from optinav.core.rotations import dcm_from_quat, dcm_from_rotvec
from optinav.rins.io import rins_source
from optinav.rins.process import (
    MOTION_STEP,
    NAV_GYRO_BIAS,
    Alignment,
    latitude_sigma,
    motion_mask,
    strapdown_blocks,
    survey,
)

__all__ = ["METHODS", "RinsCalibration", "calibrate", "prepare", "observability", "attitude_errors"]

METHODS = ("lm", "pso", "axis", "none")
SCALE = 1e-3  #: typical size of a non-orthogonality angle (rad), the column scaling of the rank test
REL_TOL = 1e-3  #: rank tolerance of the first-order Jacobian (relative to its largest scaled singular value)
PSO_PAPER = dict(n_particles=20, generations=150, w=0.8, c1=2.0, c2=2.0)
#: largest plausible non-orthogonality angle (rad): machining and assembly give mrad, the paper's largest is 9 mrad
MAX_ANGLE = 0.05
#: largest accepted ratio of the fitted attitude-residual RMS to the attitude random walk of the gyro noise over
#: the recording, beside what the declared gyro triad errors leave (a correct fit on simulated navigation-grade data
#: with 5″ misalignment leaves 2-10: lock error and wobble; a gyro column's sign flipped left 73-97 and passed the
#: former 100; an unmodelled 100 ppm scale, 42-52). Rule: a residual above it passes only where the 9 declared gyro
#: errors' residual patterns fitted to it (:func:`gyro_error_fit`) take none beyond :data:`GYRO_ERROR_SIGMAS` and
#: leave no more than it. The 30″ sessions of ``reproduce rins-pso --quick``, seeds 0-20, left 2.9-41× and 4 of the
#: 21 were above 30×, all fitted correctly (every combination within 1.2σ of the truth): refused before the rule
MAX_RESIDUAL_RATIO = 30.0
#: a residual above that limit still passes where the declared gyro scale/misalignment explain the excess: the
#: residual patterns of the 9 errors (what the fit leaves of each, at 1σ) fitted to it need no error beyond this
#: many σ and leave no more than the limit. Allowing the patterns' size alone (4σ in quadrature) let an x gyro's
#: sign flip pass (42-50× against 53×), which needs a scale error of ~10⁵-10⁶σ
GYRO_ERROR_SIGMAS = 4.0
#: the gyro-error fit keeps the patterns' directions down to this fraction of the largest singular value: after the
#: fit a 30″ misalignment leaves one dominant pattern, the rest (and the 2 ppm scale's) are tiny and an unrestricted
#: fit spent 10³σ of them on the lock error and wobble
GYRO_FIT_RCOND = 0.1
#: 1σ of the uncalibrated gyro misalignment (rad; the "rlg-nav" preset: 5″) and scale factor (-) propagated into
#: the reported std by default
GYRO_MISALIGNMENT = float(np.radians(5 / 3600))
GYRO_SCALE = 2e-6


# --- data preparation -----------------------------------------------------------------------------------


@dataclasses.dataclass
class Prepared:
    """What a calibration uses of a recording, gathered in one pass over it (:func:`prepare`): the residual epochs
    ``t`` [s] (epoch 0 = the navigation start), ``c_s_n`` (T, 3, 3) and the encoder angles [rad] there, their
    epoch numbers ``index``; ``align`` the first pass's :class:`~optinav.rins.process.Alignment`; ``moves`` the
    axis method's per-move vectors; ``frozen`` the frozen-encoder error found (raised on first use) or None;
    ``gravity`` the error of the accelerometers disagreeing with the gyros across a move (:class:`_GravityWatch`,
    raised after the move axes are checked: they name a gyro mistake first) or None;
    ``perturbed`` ``(i, j, s)`` → where the ``q_s^n`` of that gyro re-integration at the residual epochs wait
    (:class:`_Spill`, out of memory until the uncertainty after the fit); ``source`` the
    recording's blocks (read again only for re-integrations not made yet)."""

    t: np.ndarray
    c_s_n: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    index: np.ndarray
    align: Alignment
    moves: dict
    frozen: OptinavError | None
    perturbed: dict
    source: Any
    gravity: OptinavError | None = None

    @functools.cached_property
    def subspace(self):
        """(observability report, V, C, names) of the gimbal motion — they depend on α, β only, so every
        method run on this preparation shares them. The bad-input checks run here, once, on first use.
        V: orthonormal basis (6, k) of the observable subspace; C, names: its RREF rows and their names."""
        if self.frozen is not None:
            raise self.frozen
        _motion_check(self.alpha, self.beta)
        return observable_combinations(self.alpha, self.beta)

    def perturbed_attitudes(self, keys):
        """``c_s_n`` at the residual epochs re-integrated with ``(I − δK)Δθ`` for each ``(i, j, s)`` of ``keys``, one
        at a time (kept as quaternions in a scratch file); those :func:`prepare` did not integrate cost one more
        pass over the recording, all at once."""
        missing = [k for k in keys if k not in self.perturbed]
        if missing:
            dec = _Decimation(lambda j, t: np.isin(j, self.index), len(missing))
            for nb in strapdown_blocks(self.source, self.align, perturb=missing, desc="re-integrate"):
                dec.feed(nb)
            self.perturbed.update(zip(missing, dec.result()[5]))
        for k in keys:
            spill, i = self.perturbed[k]
            yield dcm_from_quat(spill.read(i))


class _Spill:
    """Rows of ``n`` quaternions (one per re-integration) appended to an unnamed scratch file block by block and
    read back one re-integration at a time: they wait for the uncertainty after the fit out of memory (32 B per
    epoch each; the file goes when it is closed or collected)."""

    ROWS = 1 << 16  #: epochs read back at a time

    def __init__(self, n: int):
        import tempfile

        self.n, self.rows, self.fh = n, 0, tempfile.TemporaryFile()

    def append(self, qs) -> None:
        """Append the epochs of one block: ``qs`` (n,) of (k, 4)."""
        block = np.stack(qs, axis=1) if qs else np.empty((0, self.n, 4))
        self.fh.seek(0, 2)
        self.fh.write(np.ascontiguousarray(block, float).tobytes())
        self.rows += block.shape[0]

    def read(self, i: int) -> np.ndarray:
        """The quaternions (T, 4) of re-integration ``i``."""
        out = np.empty((self.rows, 4))
        self.fh.seek(0)
        for a in range(0, self.rows, self.ROWS):
            k = min(self.ROWS, self.rows - a)
            out[a : a + k] = np.frombuffer(self.fh.read(k * self.n * 32), float).reshape(k, self.n, 4)[:, i]
        return out


class _Decimation:
    """The residual epochs of the strapdown blocks: those ``select(j, t)`` keeps (epoch numbers, s), with
    ``C_s^n`` of the main integration and ``q_s^n`` of each of ``n_perturbed`` re-integrations, these in a
    scratch file (:class:`_Spill`)."""

    def __init__(self, select, n_perturbed: int):
        self.select = select
        self.parts: list = []
        self.spill = _Spill(n_perturbed)

    def feed(self, nb) -> None:
        j = nb.j0 + np.arange(nb.t.size)
        k = np.flatnonzero(self.select(j, nb.t))
        self.parts.append((j[k], nb.t[k], dcm_from_quat(nb.q[k]), nb.alpha[k], nb.beta[k]))
        self.spill.append([p[k] for p in nb.perturbed])

    def result(self):
        """(index, t, c_s_n, alpha, beta, [(spill, i) of each re-integration])."""
        cols = [np.concatenate([p[i] for p in self.parts]) for i in range(5)]
        return (*cols, [(self.spill, i) for i in range(self.spill.n)])


def _perturbations(gyro_misalignment: float, gyro_scale: float) -> list:
    """The (i, j, 1σ) of the gyro triad errors :func:`_systematic` propagates (those of zero size left out)."""
    return [(i, j, s) for i in range(3) for j in range(3) if (s := gyro_scale if i == j else gyro_misalignment) > 0]


def prepare(
    data,
    *,
    residual_rate: float = 10.0,
    align_s: float | None = None,
    window=None,
    gyro_misalignment: float = GYRO_MISALIGNMENT,
    gyro_scale: float = GYRO_SCALE,
) -> Prepared:
    """Check, align and integrate ``C_s^n`` over the recording block by block (two passes: checks and alignment,
    then the strapdown with the gyro re-integrations beside it), keeping the residual epochs (epoch 0 kept) and
    what the checks and the axis method need — memory does not grow with the full-rate log.

    Parameters
    ----------
    data : RinsData, str or Path, or block source
        The recording: in memory, a file (read block by block, twice), or :func:`optinav.rins.io.rins_source`.
    residual_rate : float
        Rate of the residual epochs [Hz].
    align_s : float or None
        Longest alignment window [s]; None: the whole initial rest.
    window : (2,) tuple or None
        ``(t0, t1)`` [s] restricting the calibration epochs.
    gyro_misalignment, gyro_scale : float
        1σ of the gyro triad errors integrated beside the strapdown for the systematic std [rad, -] (as
        :func:`calibrate` takes them; other sizes cost one more pass when asked for).

    Returns
    -------
    Prepared
        The residual epochs ``t`` [s], ``c_s_n`` [-], encoder angles [rad] and what the checks found.
    """
    src = rins_source(data)
    al = survey(src, align_s=align_s)
    stride = max(1, int(round(1.0 / (residual_rate * al.step_nav)))) if residual_rate else 1

    def select(j, t):
        keep = j % stride == 0
        if window is not None:
            keep &= (t >= window[0]) & (t <= window[1])
            keep |= j == 0
        return keep

    keys = _perturbations(gyro_misalignment, gyro_scale)
    dec, frozen, moves = _Decimation(select, len(keys)), _FrozenWatch(al), _AxisMoves(al)
    gravity = _GravityWatch()
    for nb in strapdown_blocks(src, al, perturb=keys):
        dec.feed(nb)
        frozen.feed(nb)
        moves.feed(nb)
        gravity.feed(nb)
    idx, t, cs, a, b, pert = dec.result()
    return Prepared(
        t=t,
        c_s_n=cs,
        alpha=a,
        beta=b,
        index=idx,
        align=al,
        moves=moves.finish(),
        frozen=frozen.finish(),
        perturbed=dict(zip(keys, pert)),
        source=src,
        gravity=gravity.finish(),
    )


def _motion_check(alpha, beta) -> None:
    ra = np.ptp(alpha) if alpha.size else 0.0
    rb = np.ptp(beta) if beta.size else 0.0
    thr = np.radians(5.0)
    if ra < thr and rb < thr:
        raise OptinavError(
            "no gimbal motion after the alignment: none of the six angles "
            f"({', '.join(PARAM_NAMES)}) can be calibrated",
            "record a rotation scheme turning "
            "both the inner (alpha) and the outer (beta) axis, e.g. the 16-position sequence",
        )
    if ra < thr or rb < thr:
        moving, still = ("inner (alpha)", "outer (beta)") if rb < thr else ("outer (beta)", "inner (alpha)")
        rep = observability(alpha, beta)
        lost = [s.split(": ", 1)[1] for s in rep.statements if s.startswith("unobservable")]
        raise OptinavError(
            f"only the {moving} axis turns, the {still} encoder stays still: "
            f"{'; '.join(lost)} cannot be calibrated (rank {rep.rank}/6)",
            "record a scheme turning both axes (if the axis did turn, its encoder channel is missing or frozen)",
        )


class _FrozenWatch:
    """Gyros turning by large angles while both encoders report rest → a frozen encoder channel, block by
    block: an epoch counts when the interval into it turns faster than 1 °/s and no encoder moves within ±2 s
    (the encoders see a move a little later/earlier than the gyros: the slow start of a rate profile), so the
    epochs whose window reaches past a block wait for the next one."""

    def __init__(self, al: Alignment):
        self.w = max(1, int(round(2.0 / al.step_nav)))
        self.step = al.step_nav
        self.prev = None  # the last encoder angles
        self.last_mv = -(1 << 62)  # epoch number of the last moving epoch
        self.pending = (np.empty(0, np.int64), np.empty(0), np.empty(0))  # epochs, rates [rad/s], t [s]
        self.count, self.first = 0, None

    def _confirm(self, j, rate, t) -> None:
        self.count += j.size
        if j.size and self.first is None:
            self.first = (float(rate[0]), float(t[0]))

    def feed(self, nb) -> None:
        j = nb.j0 + np.arange(nb.t.size)
        if self.prev is None:
            self.prev = (nb.alpha[0], nb.beta[0])
        mv = motion_mask(nb.alpha, prev=self.prev[0]) | motion_mask(nb.beta, prev=self.prev[1])
        self.prev = (nb.alpha[-1], nb.beta[-1])
        rate = np.zeros(j.size)
        rate[j.size - nb.dt.size :] = np.linalg.norm(nb.dtheta, axis=1) / nb.dt
        turning = rate > np.radians(1.0)  # far above Earth rate
        turning[: j.size - nb.dt.size] = False  # the navigation start: no interval into it
        # the epochs waiting for this block: dropped when an encoder moves within w after them
        pj, pr, pt = self.pending
        if mv.any():
            ok = pj + self.w < j[mv][0]
            pj, pr, pt = pj[ok], pr[ok], pt[ok]
        done = pj + self.w <= j[-1]
        self._confirm(pj[done], pr[done], pt[done])
        pj, pr, pt = pj[~done], pr[~done], pt[~done]
        last = np.maximum.accumulate(np.where(mv, j, self.last_mv))
        self.last_mv = int(last[-1])
        big = np.iinfo(np.int64).max
        nxt = np.minimum.accumulate(np.where(mv, j, big)[::-1])[::-1]
        cand = turning & (j - last > self.w)
        bad = cand & (nxt != big) & (nxt - j > self.w) | cand & (nxt == big) & (j + self.w <= j[-1])
        self._confirm(j[bad], rate[bad], nb.t[bad])
        wait = cand & (nxt == big) & (j + self.w > j[-1])
        self.pending = (
            np.concatenate([pj, j[wait]]),
            np.concatenate([pr, rate[wait]]),
            np.concatenate([pt, nb.t[wait]]),
        )

    def finish(self) -> OptinavError | None:
        """The error when more than 2 s of such epochs were seen (the window at the log's end is cut), else None."""
        self._confirm(*self.pending)
        if self.count * self.step <= 2.0:
            return None
        rate, t = self.first
        return OptinavError(
            f"the gyros turn at {np.degrees(rate):.3g} °/s at t = {t:.6g} s while "
            "both encoders report rest: an encoder channel is frozen or missing",
            "check the alpha/beta columns (and that they belong to this IMU recording)",
        )


#: the gyros see rest below this rate (rad/s, 0.05 °/s: far above the Earth rate, far below a move)
STILL_RATE = float(np.radians(0.05))
#: shortest dwell whose gravity is compared (s)
DWELL_MIN_S = 1.0
#: largest angle between the gravity of consecutive dwells in the navigation frame (rad): a 1 mg accelerometer bias
#: moves it by 0.12°, a 1000 ppm gyro scale error by 0.18°, drift and noise by 0.01°; the x and y accelerometer
#: columns swapped by 1.3° on a near-level IMU (x and z, or an IMU on its side: by tens of degrees)
GRAVITY_TOL = float(np.radians(0.5))


class _GravityWatch:
    """Gravity measured by the accelerometers against where the gyros carry it, block by block: over each dwell
    (intervals the gyros see at rest, :data:`STILL_RATE`) the velocity increments are turned into the navigation
    frame with the strapdown attitude (aligned on the initial rest, carried through the moves by the gyros) and
    summed; consecutive dwells must agree within :data:`GRAVITY_TOL`. Accelerometer columns swapped or of the wrong
    sign against the gyros pass the alignment (it levels on them) but read far off after a move."""

    def __init__(self):
        self.run = None  # the open dwell: [Σ C_s^n dv (3,) m/s, Σ dt s, t start s]
        self.prev = None  # (unit gravity direction (3,), t start) of the last dwell
        self.worst = (0.0, 0.0, 0.0)  # (angle rad, t of the earlier dwell, t of the later)

    def _close(self) -> None:
        run, self.run = self.run, None
        if run is None or run[1] < DWELL_MIN_S or not np.linalg.norm(run[0]) > 0:
            return
        u = run[0] / np.linalg.norm(run[0])
        if self.prev is not None:
            ang = float(np.arccos(np.clip(u @ self.prev[0], -1.0, 1.0)))
            if ang > self.worst[0]:
                self.worst = (ang, self.prev[1], run[2])
        self.prev = (u, run[2])

    def feed(self, nb) -> None:
        if nb.dt.size == 0 or nb.dv is None:
            return
        still = np.linalg.norm(nb.dtheta, axis=1) < STILL_RATE * nb.dt
        f_n = np.einsum("kij,kj->ki", dcm_from_quat(nb.q_start), nb.dv)
        t0 = nb.t[nb.t.size - nb.dt.size - 1] if nb.t.size > nb.dt.size else nb.t[0] - nb.dt[0]
        t_start = np.concatenate([[t0], t0 + np.cumsum(nb.dt)[:-1]])
        edges = np.flatnonzero(np.diff(still.astype(np.int8))) + 1
        for a, b in zip(np.r_[0, edges], np.r_[edges, still.size]):
            if not still[a]:
                self._close()
                continue
            if self.run is None:
                self.run = [np.zeros(3), 0.0, float(t_start[a])]
            self.run[0] = self.run[0] + f_n[a:b].sum(0)
            self.run[1] += float(nb.dt[a:b].sum())

    def finish(self) -> OptinavError | None:
        """The error when two consecutive dwells disagree by more than :data:`GRAVITY_TOL`, else None."""
        self._close()
        ang, t1, t2 = self.worst
        if ang <= GRAVITY_TOL:
            return None
        return OptinavError(
            f"gravity measured by the accelerometers at the dwell from t = {t2:.6g} s is {np.degrees(ang):.3g}° "
            f"from where the gyros carry the previous dwell's (t = {t1:.6g} s) through the move (at most "
            f"{np.degrees(GRAVITY_TOL):.2g}° for a sound IMU): the accelerometer columns dv_x, dv_y, dv_z are swapped "
            f"or of the wrong sign against the gyros' (or an accelerometer bias of about {ang / 2:.2g} g)",
            "check the order and signs of the dv_x, dv_y, dv_z columns against dtheta_x, dtheta_y, dtheta_z (the "
            "same axes)",
        )


class _AxisMoves:
    """The axis vector of every gimbal move from the gyro increments, block by block: (inner [(u, Δα, β)],
    outer [(u, Δβ, α)]). A move runs over the intervals whose encoder step exceeds MOTION_STEP; from 5 epochs
    before it to 5 after it, the increments less the Earth rate (in the IMU frame along the strapdown attitude at
    each interval's start) are summed as they arrive, with the range and mean of the other encoder: memory holds
    a few epochs of history, however long a move lasts (a gimbal that never stops included)."""

    MARGIN = 5  #: epochs of margin either side of a move: it starts between rows

    def __init__(self, al: Alignment):
        self.w_ie = _earth.earth_rate(al.lat, "enu")
        self.g0 = 0  # global number of the first epoch in the history
        self.ang = {"Z": np.empty(0), "Y": np.empty(0)}  # the history: epochs g0 …
        self.rel = np.empty((0, 3))  # the intervals after each history epoch but the last
        self.moving = {"Z": False, "Y": False}  # the last interval seen turned the axis
        self.open: dict = {"Z": [], "Y": []}  # moves being summed
        self.out: dict = {"Z": [], "Y": []}

    def feed(self, nb) -> None:
        earth_s = np.einsum("kji,j->ki", dcm_from_quat(nb.q_start), self.w_ie) * nb.dt[:, None]
        new = {"Z": np.asarray(nb.alpha, float), "Y": np.asarray(nb.beta, float)}
        i0 = self.g0 + self.ang["Z"].size - 1  # global number of the first new interval (-1 before any epoch)
        ang = {k: np.concatenate([self.ang[k], v]) for k, v in new.items()}
        rel = np.concatenate([self.rel, nb.dtheta - earth_s])
        first = self.ang["Z"].size == 0  # the first block brings the start epoch: one epoch more than intervals
        last = self.g0 + ang["Z"].size - 1
        for axis, other in (("Z", "Y"), ("Y", "Z")):
            step = np.abs(np.diff(ang[axis][-(new[axis].size + (0 if first else 1)) :])) > MOTION_STEP
            flips = np.flatnonzero(np.diff(np.concatenate([[self.moving[axis]], step])))
            for k in flips.tolist():
                g = (0 if first else i0) + k  # global interval where the motion starts or stops
                if step[k]:
                    s0 = max(g - self.MARGIN, 0)
                    c = ang[other][s0 - self.g0]
                    self.open[axis].append(
                        {
                            "s0": s0,
                            "a0": ang[axis][s0 - self.g0],
                            "upto": s0,
                            "e1": None,
                            "sum": np.zeros(3),
                            "lo": c,
                            "hi": c,
                            "osum": c,
                            "count": 1,
                        }
                    )
                else:
                    self.open[axis][-1]["e1"] = g + self.MARGIN
            if step.size:
                self.moving[axis] = bool(step[-1])
            self._advance(axis, other, ang, rel, last, final=False)
        keep = self.MARGIN + 2  # epochs of history: a move starting at the next interval reaches MARGIN back
        cut = max(ang["Z"].size - keep, 0)
        self.ang = {k: v[cut:] for k, v in ang.items()}
        self.rel, self.g0 = rel[cut:], self.g0 + cut

    def _advance(self, axis: str, other: str, ang, rel, last: int, final: bool) -> None:
        """Sum each open move of ``axis`` up to its end (or to ``last``, the last epoch here), emitting those
        complete (at the end of the data every open move ends with it)."""
        still = []
        for mv in self.open[axis]:
            e1 = last if mv["e1"] is None and final else mv["e1"]
            to = last if e1 is None else min(e1, last)
            a, b = mv["upto"] - self.g0, to - self.g0
            if b > a:
                # sequential sums (carried from the last block): the same bits for any block length
                mv["sum"] = np.cumsum(np.concatenate([mv["sum"][None], rel[a:b]]), axis=0)[-1]
                o = ang[other][a + 1 : b + 1]
                mv["lo"], mv["hi"] = min(mv["lo"], float(o.min())), max(mv["hi"], float(o.max()))
                mv["osum"] = float(np.cumsum(np.concatenate([[mv["osum"]], o]))[-1])
                mv["count"] += o.size
                mv["upto"] = to
            if e1 is None or (to < e1 and not final):
                still.append(mv)
                continue
            d_ang = float(ang[axis][b] - mv["a0"])
            if abs(d_ang) >= np.radians(20) and mv["hi"] - mv["lo"] <= np.radians(0.1):
                self.out[axis].append((mv["sum"] / d_ang, d_ang, mv["osum"] / mv["count"]))
        self.open[axis] = still

    def finish(self) -> dict:
        last = self.g0 + self.ang["Z"].size - 1
        for axis, other in (("Z", "Y"), ("Y", "Z")):
            self._advance(axis, other, self.ang, self.rel, last, final=True)
        return self.out


# --- observability ------------------------------------------------------------------------------------------


#: epochs of a recording that :func:`observability` evaluates (every k-th, k = max(1, n // this))
OBSERVABILITY_EPOCHS = 3000


def observability(alpha, beta, p=None, sigma=1.0):
    """First-order observability of the six angles for gimbal angles ``alpha``, ``beta`` (rad).

    The Jacobian is evaluated on a noise-free chain following the given angles (so it does not depend on the
    recording's errors); parameters scaled by :data:`SCALE`. Returns an ObservabilityReport.
    """
    p = np.zeros(6) if p is None else np.asarray(p, float)
    stride = max(1, len(alpha) // OBSERVABILITY_EPOCHS)  # the rank needs the shape of the trajectory, not every epoch
    alpha, beta = np.asarray(alpha, float)[::stride], np.asarray(beta, float)[::stride]
    cs = sensor_attitude(np.broadcast_to(np.eye(3), (len(alpha), 3, 3)), alpha, beta, p)
    J = residual_jacobian(cs, alpha, beta, p)
    # rel_tol 1e-3: encoder noise (~1″) makes exactly unobservable directions look 1e-5 × observable, and mixes
    # them with observable ones by as little: coefficients below it are that mixing, not a coupling (one axis
    # turning read "theta_x + 2.24e+05·eta_z", theta_x observable)
    return analyze(
        J,
        sigma,
        names=list(PARAM_NAMES),
        units=["rad"] * 6,
        scales=np.full(6, SCALE),
        rel_tol=REL_TOL,
        coef_tol=REL_TOL,
    )


def observable_combinations(alpha, beta):
    """(observability report, V, C, names) for gimbal angles ``alpha``, ``beta`` (rad): V an orthonormal basis
    (6, k) of the observable subspace, C its RREF rows (the combinations reported) and their names."""
    rep = observability(alpha, beta)
    null = np.asarray(rep.null_space, float)
    V = np.linalg.svd(null.T)[2][null.shape[1] :].T if null.shape[1] else np.eye(6)
    C = rref(V.T, 1e-8)
    return rep, V, C, [format_combination(c, PARAM_NAMES) for c in C]


#: the exact invariances of the chain (:func:`optinav.rins.model.equivalent_angles`) as first-order directions:
#: the split of θz − ηz and ηy
GAUGE_DIRECTIONS = np.array([[0, 0, 1, 0, 0, -1] / np.sqrt(2), [0, 0, 0, 0, 1.0, 0]])
#: what the reported angles mean when the split of θz − ηz is not observable (RESULT.json ``observability.gauge``)
GAUGE_STATEMENT = (
    "theta_x, theta_y, eta_x and theta_z + eta_z are those of the equivalent angles with theta_z = eta_z and eta_y "
    "= 0: the data fix the gimbal chain, not how theta_z - eta_z splits, and another split d = theta_z - eta_z "
    "turns (theta_x, theta_y) about z by about d/2 (e.g. theta_x + d/2·theta_y; exactly: "
    "optinav.rins.model.equivalent_angles(p_used, split=d)); the compensation is the same for every split"
)


def _gauge(null) -> tuple[np.ndarray, tuple[bool, bool] | None]:
    """An orthonormal basis of ``null`` (6, k) and which of :data:`GAUGE_DIRECTIONS` it holds (split, ηy), or None
    when it is not spanned by them."""
    null = np.asarray(null, float).reshape(6, -1)
    q = np.linalg.qr(null)[0] if null.shape[1] else null
    if np.linalg.norm(q - GAUGE_DIRECTIONS.T @ (GAUGE_DIRECTIONS @ q)) > 1e-6:
        return q, None
    return q, tuple(bool(np.linalg.norm(q.T @ g) > 1 - 1e-6) for g in GAUGE_DIRECTIONS)


def gauge_fixed(p, null) -> np.ndarray:
    """``p`` (rad) moved along the unobservable directions ``null`` (6, k) onto the angles a calibration reports:
    exactly along the chain's invariance (θz − ηz → 0 and/or ηy → 0, :func:`~optinav.rins.model.equivalent_angles`)
    when ``null`` lies in the span of :data:`GAUGE_DIRECTIONS`, else the orthogonal projection."""
    p = np.asarray(p, float)
    q, free = _gauge(null)
    if free is None:
        return p - q @ (q.T @ p)
    return equivalent_angles(p, 0.0 if free[0] else p[2] - p[5], 0.0 if free[1] else p[4])


def _systematic(prep: Prepared, p, V, JV, r0, gyro_misalignment: float, gyro_scale: float):
    """Covariance (rad²) of p̂ caused by unknown gyro scale/misalignment errors of the given 1σ, and the residual
    each leaves after the fit (rad, (n residuals, k errors) at 1σ; None when no error is declared).

    A gyro triad error δK turns the measured rotations like a tilted gimbal axis, so it maps into the angles
    one-to-one; propagated by re-integrating ``C_s^n`` with ``(I − δK)Δθ`` for each of the 9 elements and
    one linearized step ``Δp = −(J V)⁺ Δr``; what that step leaves, ``Δr + J V Δz``, no angle can fit.
    ``JV``, ``r0``: the residual Jacobian times V and the residuals at ``p``. The re-integrated attitudes are the
    preparation's (:meth:`Prepared.perturbed_attitudes`).
    """
    if gyro_misalignment <= 0 and gyro_scale <= 0:
        return np.zeros((6, 6)), None
    a, b = prep.alpha, prep.beta
    pinv = np.linalg.pinv(JV)
    cov, left = np.zeros((6, 6)), []
    keys = _perturbations(gyro_misalignment, gyro_scale)
    for cs in prep.perturbed_attitudes(keys):
        dr = residuals(cs, a, b, p) - r0
        dz = -pinv @ dr
        dp = V @ dz
        cov += np.outer(dp, dp)
        left.append(dr + JV @ dz)
    return cov, np.stack(left, axis=1)


def _autocorr_time(r: np.ndarray) -> float:
    """Integrated autocorrelation time (samples) of the residual components, Sokal's window (c = 5)."""
    taus = []
    for x in np.atleast_2d(r.T):
        x = x - x.mean()
        n = x.size
        if n < 8 or not np.any(x):
            continue
        f = np.fft.rfft(x, 2 * n)
        acf = np.fft.irfft(f * np.conj(f))[:n]
        acf = acf / acf[0]
        tau = 1.0
        for m in range(1, n):
            tau = 1.0 + 2.0 * acf[1 : m + 1].sum()
            if m >= 5 * tau:
                break
        taus.append(max(tau, 1.0))
    return float(np.mean(taus)) if taus else 1.0


# --- the result ---------------------------------------------------------------------------------------------


@dataclasses.dataclass
class RinsCalibration(Estimate):
    """RESULT.json of ``optinav calibrate rins`` (docs/results.md, docs/methods/rins.md).

    :meth:`parameters`: every estimable combination under its name (a single angle such as ``theta_x``, or
    e.g. ``theta_z + eta_z``) with std and CRLB std, and each angle that is not individually observable
    with value null and the reason.

    ``angles``: name → rad, or None when the angle is not individually observable (never calibrated);
    ``angles_std``: 1σ (rad, autocorrelation-inflated) or None; ``combinations``: every estimable combination
    ``{name, coefficients (θx…ηz), value (rad), std, crlb_std}``; ``observability``: ``{rank, singular_values,
    null_space (vectors ordered θx, θy, θz, ηx, ηy, ηz), statements}``; ``p_used``: the six angles applied in
    compensation (unobservable directions set to zero, they do not change the attitude change);
    ``rmse_before_deg``/``rmse_after_deg``: RMS of [roll, pitch, yaw] of the extracted attitude change;
    ``lat_deg``, ``height_m``: the site the recording was processed at, ``align_s``: the longest alignment window
    asked for (None: the initial rest) — how the report reads the recording again; ``gyro_misalignment_arcsec``,
    ``gyro_scale_ppm``: the 1σ gyro triad errors propagated into the std.
    """

    SCHEMA = "optinav.rins.calibration"
    VERSION = 3
    SYSTEM = "rins"
    KIND = "calibration"

    angles: dict = field(default_factory=dict, metadata={"unit": "rad"})
    angles_std: dict = field(default_factory=dict, metadata={"unit": "rad"})
    combinations: list = field(default_factory=list, metadata={"unit": "rad"})
    observability: dict = field(default_factory=dict, metadata={"unit": "-"})
    rmse_before_deg: list = field(default_factory=list, metadata={"unit": "deg"})
    rmse_after_deg: list = field(default_factory=list, metadata={"unit": "deg"})
    method: str = field(default="lm", metadata={"unit": "-"})
    elapsed_s: float = field(default=0.0, metadata={"unit": "s"})
    p_used: list = field(default_factory=lambda: [0.0] * 6, metadata={"unit": "rad"})
    fitness_history_deg: list = field(default_factory=list, metadata={"unit": "deg"})
    correlation_time: float = field(default=1.0, metadata={"unit": "samples"})
    n_epochs: int = field(default=0, metadata={"unit": ""})
    residual_rate_hz: float = field(default=float("nan"), metadata={"unit": "Hz"})
    lat_deg: float | None = field(default=None, metadata={"unit": "deg"})
    height_m: float | None = field(default=None, metadata={"unit": "m"})
    align_s: float | None = field(default=None, metadata={"unit": "s"})
    gyro_misalignment_arcsec: float | None = field(default=None, metadata={"unit": "arcsec"})
    gyro_scale_ppm: float | None = field(default=None, metadata={"unit": "ppm"})
    options: dict = field(default_factory=dict, metadata={"unit": "-"})
    source: str = field(default="", metadata={"unit": "-"})
    convergence: dict = field(default_factory=dict, metadata={"unit": "-"})
    gates: list = field(default_factory=list, metadata={"unit": "-"})

    def __post_init__(self):
        # the nested values the summary, parameters, report and apply read: a damaged one is named on loading
        for name in ("angles", "angles_std"):
            d = getattr(self, name)
            for nm in PARAM_NAMES:
                if nm in d:
                    d[nm] = nested_number(d[nm], f"{name}.{nm}", none=True, std=name == "angles_std")
        for k, c in enumerate(self.combinations):
            if not isinstance(c, dict):
                raise InvalidResult(f"field 'combinations[{k}]' is {json_kind(c)}, expected an object")
            if not isinstance(c.get("name"), str):
                raise InvalidResult(f"field 'combinations[{k}].name' is {json_kind(c.get('name'))}, expected text")
            c["value"] = nested_number(c.get("value"), f"combinations[{k}].value")
            for key in ("std", "crlb_std"):
                c[key] = nested_number(c.get(key), f"combinations[{k}].{key}", none=True, std=True)
        self.observability["statements"] = nested_strings(
            self.observability.get("statements", []), "observability.statements"
        )
        if not isinstance(self.observability.get("gauge") or "", str):
            raise InvalidResult(
                f"field 'observability.gauge' is {json_kind(self.observability['gauge'])}, expected text"
            )
        self.p_used = nested_array(self.p_used, "p_used", (6,), finite=True).tolist()

    def parameters(self) -> dict[str, Parameter]:
        if self.method == "none":
            return {
                nm: Parameter(None, "rad", observable=False, reason="not estimated (method 'none')")
                for nm in PARAM_NAMES
            }
        gauge = self.observability.get("gauge")
        out = {
            c["name"]: Parameter(
                float(c["value"]),
                "rad",
                std=c.get("std"),
                crlb_std=c.get("crlb_std"),
                reason=gauge and f"gauge: {gauge}",
            )
            for c in self.combinations
        }
        statements = self.observability.get("statements", [])
        for nm in PARAM_NAMES:
            if nm not in out:
                why = "; ".join(s for s in statements if nm in s) or "not individually observable"
                out[nm] = Parameter(None, "rad", observable=False, reason=why)
        return out

    @property
    def p(self) -> np.ndarray:
        """The six angles used for compensation (rad)."""
        return np.asarray(self.p_used, float)

    def summary(self) -> str:
        """A human-readable report of the calibration, one parameter per line.

        Returns
        -------
        str
            The report.
        """
        lines = [f"optinav rotational-INS non-orthogonality calibration ({self.method}, {self.elapsed_s:.3g} s)"]
        for nm in PARAM_NAMES:
            v, s = self.angles.get(nm), self.angles_std.get(nm)
            if v is None:
                lines.append(f"  {nm:8s} = null (not observable individually)")
            else:
                lines.append(f"  {nm:8s} = {v: .6e} rad" + (f" ± {s:.2e}" if s is not None else ""))
        for c in self.combinations:
            if "+" in c["name"] or "−" in c["name"]:
                std = c.get("std")
                lines.append(f"  {c['name']} = {c['value']: .6e} rad" + (f" ± {std:.2e}" if std else ""))
        for s in self.observability.get("statements", []):
            lines.append(f"  observability: {s}")
        if self.observability.get("gauge"):
            lines.append(f"  gauge: {self.observability['gauge']}")
        if self.gyro_misalignment_arcsec is not None and self.gyro_scale_ppm is not None:
            lines.append(
                f"  std include the gyro triad's uncalibrated errors at 1σ {self.gyro_misalignment_arcsec:.3g}″ "
                f"misalignment and {self.gyro_scale_ppm:.3g} ppm scale (--gyro-misalignment-arcsec, "
                "--gyro-scale-ppm: give your IMU's)"
            )
        if self.method == "pso" and self.convergence.get("message"):
            lines.append(f"  search: {self.convergence['message']}")
        b, a = self.rmse_before_deg, self.rmse_after_deg
        lines.append(
            "  attitude RMSE [roll, pitch, yaw] deg: before "
            + ", ".join(f"{x:.4g}" for x in b)
            + "; after "
            + ", ".join(f"{x:.4g}" for x in a)
        )
        return "\n".join(lines)


# --- methods ---------------------------------------------------------------------------------------------------


def attitude_errors(prep: Prepared, p) -> np.ndarray:
    """[roll, pitch, yaw] (rad) of the extracted attitude change at the residual epochs t ≥ 1, (T−1, 3)."""
    return residuals(prep.c_s_n, prep.alpha, prep.beta, p).reshape(-1, 3)


def _rms_deg(e) -> list:
    return np.degrees(np.sqrt(np.mean(np.asarray(e) ** 2, axis=0))).tolist()


def _fit_lm(prep, V, p_start=None):
    """LM in the observable subspace p = V z; start from the linearized LS solution (one GN step from 0)."""
    cs, a, b = prep.c_s_n, prep.alpha, prep.beta
    p0 = np.zeros(6) if p_start is None else np.asarray(p_start, float)
    r0 = residuals(cs, a, b, p0)
    J0 = residual_jacobian(cs, a, b, p0) @ V
    z0 = -np.linalg.lstsq(J0, r0, rcond=None)[0]
    del J0, r0  # not held through the fit (the residual Jacobian of a long recording is ~100 B per epoch)
    prob = Problem(
        residuals=lambda z: residuals(cs, a, b, p0 + V @ z),
        jacobian=lambda z: residual_jacobian(cs, a, b, p0 + V @ z) @ V,
        x0=z0,
        x_scale=SCALE,
        names=[f"z{i}" for i in range(V.shape[1])],
    )
    res = minimize(prob, "lm", xtol=1e-10, ftol=1e-10)
    return p0 + V @ res.x, res


def _fit_pso(prep, rng, search: float, small_angle: bool, options: dict):
    cs, a, b = prep.c_s_n, prep.alpha, prep.beta
    # the paper's V ∈ [−1, 1] in units of 5 % of the search half-width (±1 rad steps would overshoot mrad angles)
    opts = {**PSO_PAPER, "v_max": 0.05 * search, **options}
    prob = Problem(
        residuals=lambda p: residuals(cs, a, b, p, small_angle),
        residuals_batch=lambda P: residuals(cs, a, b, P, small_angle),
        x0=np.zeros(6),
        search_interval=(np.full(6, -search), np.full(6, search)),
        names=list(PARAM_NAMES),
    )
    res = minimize(prob, "pso", rng=rng, final_jacobian=False, **opts)
    return res.x, res


def axis_vectors(p, alpha_out) -> tuple[np.ndarray, np.ndarray]:
    """Model axis directions in the IMU frame: inner ``C_h1^s e_z`` (3,), outer ``C_h1^s R_z(α)ᵀ C_h2^h0 e_y``
    at the inner angles ``alpha_out`` (K, 3)."""
    A, B = nonorth_dcm(p[0:3]), nonorth_dcm(p[3:6])
    Z, _ = chain_pieces(np.asarray(alpha_out, float), np.zeros(len(alpha_out)))
    return A @ np.array([0.0, 0, 1]), (A @ Z @ B @ np.array([0.0, 1, 0])).reshape(-1, 3)


#: largest angle (rad) between the axis the gyros turn about during a gimbal move and the gimbal's nominal axis:
#: non-orthogonality and misalignment are milliradians; a gyro column's sign flipped or two columns swapped turn
#: it by up to 180° (180° moves end where they would unflipped, so the attitude residual hardly shows it)
MAX_MOVE_AXIS = 0.05


def check_move_axes(moves: dict) -> None:
    """Each gimbal move of 20° or more (:class:`_AxisMoves`: the gyro increments less the Earth rate, summed over
    the move, per encoder radian) must turn about the gimbal's nominal axis, within :data:`MAX_MOVE_AXIS`, at
    the encoder's rate (the sum's norm within 10 % of 1)."""
    for axis, name in (("Z", "inner (alpha)"), ("Y", "outer (beta)")):
        for k, (u, d_ang, other) in enumerate(moves.get(axis, [])):
            u0 = axis_vectors(np.zeros(6), [other])[0] if axis == "Z" else axis_vectors(np.zeros(6), [other])[1][0]
            nu = float(np.linalg.norm(u))
            off = float(np.arccos(np.clip(u @ u0 / max(nu, 1e-300), -1.0, 1.0)))
            if off > MAX_MOVE_AXIS or not 0.9 < nu < 1.1:
                raise OptinavError(
                    f"during {name} move {k + 1} ({np.degrees(d_ang):+.0f}°) the gyros turn {nu:.3g}× the encoder's "
                    f"angle about an axis {np.degrees(off):.3g}° from the gimbal's: the gyro columns (sign, order) "
                    "or the encoders (sign, alpha/beta swapped) contradict each other",
                    "check the gyro columns (x, y, z, signs) and the encoder columns (alpha = inner, beta = outer)",
                )


def _measure_axes(prep: Prepared):
    """Axis vector of every gimbal move from the gyro increments: (inner [(u, Δα, β)], outer [(u, Δβ, α)]),
    gathered by :func:`prepare` (:class:`_AxisMoves`)."""
    return prep.moves


def _fit_axis(prep: Prepared, V):
    """Axis-vector baseline: forward/reverse-averaged axis directions → first-order LS for p in span(V)."""
    moves = _measure_axes(prep)
    if not moves["Z"] or not moves["Y"]:
        raise OptinavError(
            "the axis method needs moves of both gimbals of at least 20°", "use a dual-axis scheme (or --method lm)"
        )
    rows, meas = [], []

    def add(u_list, which):
        # average forward and reverse moves (per inner angle for the outer axis) so drift terms cancel
        groups: dict = {}
        for u, d, other in u_list:
            key = 0 if which == "Z" else int(np.round(np.degrees(other) / 90.0)) % 4
            groups.setdefault(key, {1: [], -1: []})[int(np.sign(d))].append(u / np.linalg.norm(u))
        for key, g in groups.items():
            ends = [np.mean(g[s], axis=0) for s in (1, -1) if g[s]]
            u = np.mean(ends, axis=0)
            u /= np.linalg.norm(u)
            a_in = np.radians(90.0 * key)
            f = (lambda p: axis_vectors(p, [a_in])[0]) if which == "Z" else (lambda p: axis_vectors(p, [a_in])[1][0])
            u0 = f(np.zeros(6))
            H = np.stack([(f(SCALE * e) - f(-SCALE * e)) / (2 * SCALE) for e in np.eye(6)], axis=1)
            rows.append(H)
            meas.append(u - u0)

    add(moves["Z"], "Z")
    add(moves["Y"], "Y")
    H = np.concatenate(rows) @ V
    y = np.concatenate(meas)
    z = np.linalg.lstsq(H, y, rcond=1e-8)[0]
    return V @ z, {"n_inner_moves": len(moves["Z"]), "n_outer_moves": len(moves["Y"])}


def noise_walk(prep: Prepared) -> float:
    """Attitude random walk (rad) of the gyro white noise over the calibrated span: the per-sample noise of the
    increments at rest (first differences, so the Earth rate drops out) times √(samples)."""
    return prep.align.rest_sd * np.sqrt(prep.align.n - prep.align.m)


def _still_rms(prep: Prepared, e) -> float | None:
    """RMS (rad) of the attitude residuals ``e`` (epochs 1.., :func:`attitude_errors`) at the epochs where neither
    encoder moved since the epoch before nor moves to the next; None when there are none."""
    a, b = np.asarray(prep.alpha, float), np.asarray(prep.beta, float)
    step = (np.abs(np.diff(a)) > MOTION_STEP) | (np.abs(np.diff(b)) > MOTION_STEP)  # between epochs k and k + 1
    moving = np.r_[step, False] | np.r_[False, step]  # epoch k next to a move
    keep = ~moving[1:]
    e = np.asarray(e, float).reshape(-1, 3)
    return float(np.sqrt(np.mean(e[keep] ** 2))) if keep.any() else None


#: declared latitudes within this many 1σ of the measured one (noise and :data:`NAV_GYRO_BIAS`) are warned about,
#: not refused, when they would move the result by more than its std: a navigation-grade bias tilts the measured
#: latitude that far, and which of the two is off the recording cannot tell
LAT_WARN_SIGMA = 3.0


def latitude_shift(prep, p, V, JV, d: float) -> np.ndarray:
    """Change of the fitted angles ``p`` (rad, (6,)) were the latitude ``d`` (rad) from the declared one,
    linearized: the strapdown then removes an Earth rate off by ``d·∂ω_ie/∂φ``, which turns every ``C_s^n`` about
    that fixed ENU vector by its integral since the navigation start. ``JV``: the residual Jacobian on ``V``."""
    phi = prep.align.lat
    dw = _earth.WGS84.omega_ie * np.array([0.0, -np.sin(phi), np.cos(phi)]) * d
    turn = dcm_from_rotvec(np.outer(prep.t - prep.t[0], -dw))  # sign checked against refits
    cs, a, b = prep.c_s_n, prep.alpha, prep.beta
    dr = residuals(turn @ cs, a, b, p) - residuals(cs, a, b, p)
    return -V @ np.linalg.lstsq(JV, dr, rcond=None)[0]


def _latitude_gate(prep, p, V, JV, C, cnames, stds) -> dict | None:
    """Refuse (one line) a declared latitude the gyros contradict beyond :data:`LAT_WARN_SIGMA` where the
    difference would move a combination by more than its std; warn where it would but a navigation-grade bias
    explains it. Returns what was measured (deg, and the largest move in std) or None when not measured."""
    al = prep.align
    if not np.isfinite(al.lat_measured):
        return None
    d = al.lat_measured - al.lat
    sig = latitude_sigma(al.lat_measured_sd)
    moved = np.abs(C @ latitude_shift(prep, p, V, JV, d)) / np.maximum(stds, 1e-300)
    k = int(np.argmax(moved))
    out = {
        "declared_deg": float(np.degrees(al.lat)),
        "measured_deg": float(np.degrees(al.lat_measured)),
        "measured_std_deg": float(np.degrees(sig)),
        "shift_sigma": float(moved[k]),
    }
    if moved[k] <= 1.0:
        return out
    what = (
        f"the latitude {np.degrees(al.lat):.5g}° disagrees with the {np.degrees(al.lat_measured):.5g}° ± "
        f"{np.degrees(sig):.2g}° (1σ: gyro noise and a {np.degrees(NAV_GYRO_BIAS) * 3600:g} °/h bias) the gyros "
        f"measure from the Earth rate at rest, and the difference moves {cnames[k]} by {moved[k]:.2g}× its std"
    )
    if abs(d) > LAT_WARN_SIGMA * sig:
        raise OptinavError(
            what,
            f"check --lat (north positive) or the file's lat_deg; if it is right, a gyro bias of about "
            f"{abs(d) * np.degrees(_earth.WGS84.omega_ie) * 3600:.2g} °/h tilts the Earth rate the gyros see",
        )
    warnings.warn(
        f"{what}, within what a navigation-grade gyro bias explains: if --lat is right the result stands, "
        "if it is off by that much the result is biased; check --lat",
        stacklevel=3,
    )
    return out


def gyro_error_fit(e, patterns) -> tuple[np.ndarray, float]:
    """The gyro triad errors (in units of their declared 1σ) whose residual ``patterns`` (:func:`_systematic`) best
    fit the attitude residuals ``e`` (rad), and the RMS (rad) of what they leave."""
    r = np.asarray(e, float).ravel()
    c = np.linalg.lstsq(patterns, r, rcond=GYRO_FIT_RCOND)[0]
    return c, float(np.sqrt(np.mean((r - patterns @ c) ** 2)))


def _quality_gates(method, p, V, C, cnames, res, e_after, prep, patterns, gyro_errors) -> list[dict]:
    """A fit that did not converge, an implausible angle or a residual far above the gyro noise that the declared
    gyro errors (``patterns``: their residuals at 1σ, of ``gyro_errors`` = (misalignment rad, scale)) do not
    explain ends in a one-line error instead of a result (issue 13: no wrong answer with exit 0); else their
    outcomes."""
    if method == "lm" and res is not None and not res.success:
        raise OptinavError(
            f"the LM fit did not converge ({res.message})",
            "check the data (encoder columns, --lat) or try --method pso",
        )
    values = [(nm, float(c @ p)) for c, nm in zip(C, cnames)]
    bad = [(nm, v) for nm, v in values if abs(v) > MAX_ANGLE]
    if bad:
        nm, v = max(bad, key=lambda x: abs(x[1]))
        raise OptinavError(
            f"the fitted {nm} = {v:.4g} rad is not a plausible non-orthogonality (|angle| ≤ "
            f"{MAX_ANGLE} rad): the alpha/beta columns may be swapped, in degrees or of another "
            "recording, or the gyro columns swapped or sign-flipped",
            "check the encoder columns (alpha = inner, beta = outer, rad) and the gyro columns (x, y, z, signs)",
        )
    rms = float(np.sqrt(np.mean(np.asarray(e_after) ** 2)))
    walk = noise_walk(prep)
    out = [gate("optimizer converged", res.success, None, kind="true")] if method == "lm" and res is not None else []
    out.append(gate("largest |combination|", max((abs(v) for _, v in values), default=0.0), MAX_ANGLE, unit="rad"))
    if walk <= 0:
        return out
    if rms <= MAX_RESIDUAL_RATIO * walk:
        return [*out, gate("attitude residual / gyro-noise random walk", rms / walk, MAX_RESIDUAL_RATIO)]
    explained = ""
    if patterns is not None:  # the declared gyro errors may explain the excess (GYRO_ERROR_SIGMAS)
        c, left = gyro_error_fit(e_after, patterns)
        big = float(np.abs(c).max())
        if left <= MAX_RESIDUAL_RATIO * walk and big <= GYRO_ERROR_SIGMAS:
            return [
                *out,
                gate(
                    "attitude residual beyond the declared gyro errors / gyro-noise random walk",
                    left / walk,
                    MAX_RESIDUAL_RATIO,
                ),
                gate("largest declared gyro error it takes [σ]", big, GYRO_ERROR_SIGMAS),
            ]
        gm, gs = gyro_errors
        explained = (
            f"; the declared {np.degrees(gm) * 3600:g}″ gyro misalignment and {gs * 1e6:g} ppm scale explain it only "
            f"with an error of {big:.2g}σ, leaving {left / walk:.3g}×"
        )
    still = _still_rms(prep, e_after)
    if still is not None and still < rms / 3:  # a lag misfits the moves only; other faults last at rest
        raise OptinavError(
            f"after the fit the attitude residual is {np.degrees(rms):.3g}° RMS, {rms / walk:.3g}× the "
            f"{np.degrees(walk):.2g}° the gyro noise explains (limit {MAX_RESIDUAL_RATIO:g}×{explained}), but only "
            f"{still / walk:.3g}× with both gimbals at rest: the misfit is in the moves, where the encoder angles "
            "and the gyros disagree in time — the encoder and IMU time stamps are not synchronized (a lag)",
            "synchronize the encoder angles with the IMU samples before calibrating: each row's alpha, beta at "
            "its t, the start of its increments (a column named time is read as their end)",
        )
    raise OptinavError(
        f"after the fit the attitude residual is {np.degrees(rms):.3g}° RMS, "
        f"{rms / walk:.3g}× the {np.degrees(walk):.2g}° the gyro noise explains (limit {MAX_RESIDUAL_RATIO:g}×"
        f"{explained}): the gimbal model does not fit this recording",
        "check the gyro columns (order, signs), the encoder columns (alpha = inner, beta = outer, rad) and --lat",
    )


def calibrate(
    data=None,
    method: str = "lm",
    *,
    prep: Prepared | None = None,
    residual_rate: float = 10.0,
    align_s: float | None = None,
    window=None,
    rng=None,
    search: float = 0.01,
    small_angle: bool = False,
    pso_options: dict | None = None,
    source: str = "",
    gyro_misalignment: float = GYRO_MISALIGNMENT,
    gyro_scale: float = GYRO_SCALE,
) -> RinsCalibration:
    """Calibrate the six non-orthogonality angles from a :class:`~optinav.rins.simulate.RinsData` recording.

    Parameters
    ----------
    data : RinsData, str or Path, or None
        The recording, in memory or a file (None when ``prep`` is given).
    method : str
        ``"lm"`` (default), ``"pso"``, ``"axis"`` or ``"none"`` (module docstring).
    prep : Prepared or None
        A :func:`prepare` result to reuse (C_s^n computed once for several methods).
    residual_rate : float
        Rate of the residual epochs [Hz]; the strapdown attitude is integrated at the full rate.
    align_s : float or None
        Longest alignment window [s]; None: the whole initial rest.
    window : (2,) tuple or None
        ``(t0, t1)`` [s] restricting the calibration epochs (e.g. one 16-position cycle).
    rng : int, Generator or None
        Seed or generator (PSO).
    search : float
        PSO search half-width, also its velocity clamp [rad].
    small_angle : bool
        PSO particles as the paper's linear matrices (eqs. 10–11).
    pso_options : dict or None
        Options of the particle swarm.
    source : str
        Recorded in the result.
    gyro_misalignment : float
        1σ of the uncalibrated gyro misalignment propagated into the reported std [rad] (default the
        "rlg-nav" preset: 5″; 0 leaves it out).
    gyro_scale : float
        1σ of the uncalibrated gyro scale factor [-] (fraction; default 2 ppm).

    Returns
    -------
    RinsCalibration
        The angles [rad] with std and CRLB std, observability, convergence and quality gates.
    """
    if method not in METHODS:
        raise OptinavError(f"unknown method {method!r}", f"use one of {', '.join(METHODS)}")
    t_start = time.perf_counter()
    if prep is None:
        if data is None:
            raise OptinavError("calibrate needs data or prep", "pass a RinsData recording")
        prep = prepare(
            data,
            residual_rate=residual_rate,
            align_s=align_s,
            window=window,
            gyro_misalignment=gyro_misalignment,
            gyro_scale=gyro_scale,
        )
    rep0, V, C, cnames = prep.subspace  # checks the input on first use
    check_move_axes(prep.moves)
    if prep.gravity is not None:  # the gyros turn about the gimbal axes: the accelerometers disagree with them
        raise prep.gravity
    t_fit = time.perf_counter()
    history: list = []
    info: dict = {}
    n_res = prep.alpha.size - 1
    if method == "none":
        p = np.zeros(6)
    elif method == "lm":
        p, res = _fit_lm(prep, V)
        p = gauge_fixed(p, rep0.null_space)  # span(V) is the first-order slice; the same chain, exactly there
        history = np.degrees(np.sqrt(np.asarray(res.history) / n_res)).tolist()
        info = {"nfev": res.nfev, "njev": res.njev, "message": res.message}
    elif method == "pso":
        p_raw, res = _fit_pso(prep, as_rng(rng), search, small_angle, pso_options or {})
        history = np.degrees(np.sqrt(np.asarray(res.history) / n_res)).tolist()
        info = {
            "nfev": res.nfev,
            "p_raw": p_raw.tolist(),
            "small_angle": small_angle,
            "search": search,
            **{k: v for k, v in res.options.items() if k in ("n_particles", "generations", "w", "c1", "c2")},
        }
        # the unobservable directions do not change the residuals: move along them exactly (a linear projection
        # leaves the chain's invariant manifold and turns θx, θy by (θz − ηz)/2 of the particle)
        p = gauge_fixed(p_raw, rep0.null_space)
    else:
        p, info = _fit_axis(prep, V)
    # the swarm's own time: the local search that measures its shortfall after it is not the published method's
    elapsed = res.elapsed if method == "pso" else time.perf_counter() - t_fit
    e_before = attitude_errors(prep, np.zeros(6))
    e_after = attitude_errors(prep, p)
    J = residual_jacobian(prep.c_s_n, prep.alpha, prep.beta, p)
    JV, r = J @ V, e_after.ravel()
    # the gyro errors' share: the std's systematic part, and the residual the gate allows for them
    cov_sys, patterns = (
        _systematic(prep, p, V, JV, r, gyro_misalignment, gyro_scale) if method != "none" else (np.zeros((6, 6)), None)
    )
    gates = []
    if method != "none":
        fit = res if method in ("lm", "pso") else None
        gates = _quality_gates(method, p, V, C, cnames, fit, e_after, prep, patterns, (gyro_misalignment, gyro_scale))
    # uncertainty on the observable subspace (white-noise CRLB inflated by the residual correlation time)
    sigma = float(np.sqrt(np.mean(r**2))) if np.any(r) else 1e-12
    tau = _autocorr_time(e_after)
    rep = analyze(J, sigma, names=list(PARAM_NAMES), units=["rad"] * 6, scales=np.full(6, SCALE), rel_tol=REL_TOL)
    cov_noise = np.asarray(rep.crlb) * tau
    d = np.zeros(6)
    if method == "pso" and res.shortfall is not None:
        # where the swarm stopped short of its objective's minimum, on the observable combinations (gauge-fixed)
        d = gauge_fixed(p_raw + res.shortfall, rep0.null_space) - p
    cov = cov_noise + cov_sys + np.outer(d, d)
    lat_check = None
    if method != "none":
        std = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", C, cov, C), 0.0))
        lat_check = _latitude_gate(prep, p, V, JV, C, cnames, std)
        if lat_check is not None:
            info = {**info, "latitude": lat_check}
    combos, angles, stds = [], {}, {}
    for c, nm in zip(C, cnames):
        sd = float(np.sqrt(max(c @ cov @ c, 0.0)))
        combos.append(
            {
                "name": nm,
                "coefficients": c.tolist(),
                "value": float(c @ p),
                "std": sd,
                "std_noise": float(np.sqrt(max(c @ cov_noise @ c, 0.0))),
                "std_gyro_errors": float(np.sqrt(max(c @ cov_sys @ c, 0.0))),
                "crlb_std": float(np.sqrt(max(c @ np.asarray(rep.crlb) @ c, 0.0))),
                **({"std_search": float(abs(c @ d))} if d.any() else {}),
            }
        )
    if method in ("lm", "pso"):
        message = res.message
        if d.any():
            short = [x["std_search"] for x in combos]
            message += "; " + shortfall_note(
                short, [np.hypot(x["std_noise"], x["std_gyro_errors"]) for x in combos], cnames
            )
        conv = convergence(
            res.success if method == "lm" else None,
            iterations=getattr(res, "nit", None),
            evaluations=res.nfev,
            message=message,
        )
    else:
        conv = convergence(None, message="closed form" if method == "axis" else "not estimated")
    for i, nm in enumerate(PARAM_NAMES):
        ok = bool(rep0.observable[i]) and method != "none"
        angles[nm] = float(p[i]) if ok else None
        stds[nm] = float(np.sqrt(cov[i, i])) if ok else None
    obs = {
        "rank": int(rep0.rank),
        "singular_values": np.asarray(rep0.singular_values).tolist(),
        "null_space": np.asarray(rep0.null_space).T.tolist(),
        "statements": list(rep0.statements),
        "observable": [bool(x) for x in rep0.observable],
        "scale_rad": SCALE,
    }
    if (_gauge(rep0.null_space)[1] or (False,))[0]:
        obs["gauge"] = GAUGE_STATEMENT
    return RinsCalibration(
        angles=angles,
        angles_std=stds,
        combinations=combos,
        observability=obs,
        rmse_before_deg=_rms_deg(e_before),
        rmse_after_deg=_rms_deg(e_after),
        method=method,
        elapsed_s=elapsed if method != "none" else time.perf_counter() - t_start,
        p_used=p.tolist(),
        fitness_history_deg=history,
        correlation_time=tau,
        n_epochs=int(prep.alpha.size),
        residual_rate_hz=float(residual_rate or np.nan),
        lat_deg=float(np.degrees(prep.align.lat)),
        gyro_misalignment_arcsec=float(np.degrees(gyro_misalignment) * 3600),
        gyro_scale_ppm=float(gyro_scale * 1e6),
        height_m=float(prep.align.height_m),
        options=info,
        source=source,
        convergence=conv,
        gates=gates,
    )


def _legacy_v1(data: dict) -> dict:
    """RESULT.json of an older optinav (schema "optinav.rins_calibration" version 1, flat).

    Version 1 wrote ``rmse_before_deg``/``rmse_after_deg`` as [pitch, roll, yaw] (commit 5c3e5ad turned them to
    [roll, pitch, yaw] without a version bump; version-1 files from the 25 minutes until version 2 replaced the
    layout, 370cc2a, are swapped by this reader); they are read as [roll, pitch, yaw]. Version 2 was always
    [roll, pitch, yaw]."""
    kw = flat_kwargs(RinsCalibration, data)
    for key in ("rmse_before_deg", "rmse_after_deg"):
        v = kw.get(key)
        if isinstance(v, list) and len(v) == 3:
            kw[key] = [v[1], v[0], v[2]]
    if kw.get("method") == "lm" and "message" in (data.get("options") or {}):
        kw["convergence"] = convergence(
            None, evaluations=data["options"].get("nfev"), message=data["options"]["message"]
        )
    return kw


register_legacy(RinsCalibration, "optinav.rins_calibration", 1, _legacy_v1)


def rins_truth(angles, alpha, beta, info: dict | None = None) -> Truth:
    """A simulated recording's truth in the parameterization :func:`calibrate` estimates: the six angles
    ``angles`` (rad, θx θy θz ηx ηy ηz) and every combination observable with the encoder angles ``alpha``,
    ``beta`` (rad) under the name the result gives it, of the equivalent angles the result reports
    (:func:`gauge_fixed`: θx, θy at θz = ηz; :data:`GAUGE_STATEMENT`)."""
    p = np.asarray(angles, float)
    rep, _, C, names = observable_combinations(np.asarray(alpha, float), np.asarray(beta, float))
    params = {nm: Parameter(float(v), "rad") for nm, v in zip(PARAM_NAMES, p)}
    pg = gauge_fixed(p, rep.null_space)  # the combinations as the result reports them (GAUGE_STATEMENT)
    params.update({nm: Parameter(float(c @ pg), "rad") for c, nm in zip(C, names)})
    return Truth("rins", params, dict(info or {}))


def simulation_truth(data, *, seed: int, lat_deg: float, encoders=None) -> Truth:
    """The truth of a recording :func:`optinav.rins.simulate.simulate` made, as ``optinav simulate rins``
    writes it beside the data.

    Parameters
    ----------
    data : RinsData
        The simulated recording (its ``truth`` angles [rad], encoder angles, ``align_s`` [s] and ``info``).
    seed : int
        The seed it was simulated with.
    lat_deg : float
        Its latitude as given [deg] (recorded as given, not converted back from radians).
    encoders : (alpha, beta) or None
        Encoder angles [rad] to judge the observability with instead of ``data``'s: every k-th of a session
        streamed without keeping its rows (:meth:`optinav.rins.simulate.RinsStream.encoder_samples`,
        k as :func:`observability` strides the whole).

    Returns
    -------
    Truth
        :func:`rins_truth` of the angles, with the scheme, site, seed and the drawn gyro errors.
    """
    p = np.asarray(data.truth, float)
    info = {
        "unit": "rad",
        "angles": dict(zip(PARAM_NAMES, p.tolist())),
        "lat_deg": lat_deg,
        "seed": seed,
        "scheme": data.info["scheme"],
        "steps": data.info["steps"],
        "align_s": data.align_s,
        "gyro_K": data.info["gyro_K"],
        "gyro_bias_rad_s": data.info["gyro_bias"],
    }
    alpha, beta = (data.alpha, data.beta) if encoders is None else encoders
    return rins_truth(p, alpha, beta, info)


register_truth_legacy(
    "rins", "optinav.rins_truth", lambda d: {nm: Parameter(float(d["angles"][nm]), "rad") for nm in PARAM_NAMES}
)
