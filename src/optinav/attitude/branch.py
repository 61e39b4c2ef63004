"""The heading's branch with skylight polarization alone: a zenith-viewing sensor sees the same angle of
polarization (AoP) at heading ψ and ψ + π, so the estimate's start takes one of two headings.

Once the viewing axis tilts (the body tilts, or the mounting C_b^m is not vertical) the AoP at the other heading
differs and the gyro links the samples: started on the wrong branch, the estimate's AoP residuals (measured minus
predicted, wrapped to [−π/2, π/2)) grow. :func:`optinav.attitude.estimate` therefore runs iframe online from both
branches (:data:`BRANCHES`: the polarization's first used sample takes the AoP's root nearest the start's heading,
or the other; iframe's tilt never sees the heading, so the two runs differ in the heading alone) and compares their AoP residuals over the samples usable in both (a sample whose AoP no heading
explains at a branch's tilt counts against it with its residual): the branch whose mean square is lower by more
than :data:`BRANCH_MARGIN` noise variances is taken, the noise σ the better branch's robust residual scale (at least
:data:`MIN_AOP_NOISE`); two branches within that margin (a level body under a zenith-viewing sensor) are refused
(:meth:`BranchResiduals.verdict`). With a magnetometer the heading is known from the start and nothing is decided
here; with ``q0`` its branch is taken, and the same runs, from q0 and from q0 turned 180° about up, refuse an AoP that
contradicts it (``verdict(fixed=True)``). Residuals are gathered block by block, so a log read in blocks decides as the whole log does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optinav.core.rotations import quat_rotate
from optinav.errors import OptinavError

__all__ = [
    "BRANCHES",
    "BRANCH_MARGIN",
    "MIN_AOP_NOISE",
    "MIN_HELD",
    "Q0_TURN",
    "Branch",
    "BranchResiduals",
    "HeldBranch",
]

#: the two starts (``other_root``): the polarization's first used sample takes the AoP's root nearest the start's
#: heading (iframe: δ = 0; the others: |ψ| ≤ 90° for a level sensor), or the other one
BRANCHES = (False, True)
#: the other branch's mean square AoP residual must exceed the better one's by this many noise variances σ².
#: BROAD's nine with synthesized AoP (0.5° noise), 20- and 60-s cuts every 20 s (151 cuts): a level resting body
#: (viewing axis within 2.4° of the vertical) 0.06 at most, every cut with tilting motion 6.8 or more
BRANCH_MARGIN = 1.0
#: rad, the least AoP noise σ the margin takes: noise-free (simulated) AoPs leave the right branch the estimator's
#: own error, and two runs of a level body differ by rounding
MIN_AOP_NOISE = float(np.radians(0.1))
#: the robust scale of |r| (its median × 1.4826 is σ for Gaussian noise) from a histogram over these bin edges
#: [rad] (1.4 % wide): a log read in blocks keeps counts, not residuals
_EDGES = np.geomspace(1e-7, np.pi / 2, 1201)
#: rad², the unit the squared residuals are summed in as integers (r² ≤ (π/2)² is below 2⁴² of them), and the
#: rows summed in int64 at a time (well within its range)
_SQ, _SUM_ROWS = 2.0**-40, 1 << 20


@dataclass
class Branch:
    """The heading branch a recording's AoP took: ``other_root``, the estimate's start (one of :data:`BRANCHES`,
    iframe's, or for the other methods the one of :class:`HeldBranch`); ``rms`` (2,) rad, the AoP residual RMS of
    iframe from it and from the other branch (None: no polarization sample to compare)."""

    other_root: bool
    rms: np.ndarray | None


def weakest(rms) -> np.ndarray | None:
    """Of the residual RMS pairs ``rms`` (each (2,) rad: the branch taken, the other) of a log's segments, the one
    whose other branch came closest (the least excess of its mean square); None for none."""
    rms = [r for r in rms if r is not None]
    return min(rms, key=lambda r: r[1] ** 2 - r[0] ** 2) if rms else None


#: rad: an AoP whose residual's robust scale on the better branch exceeds this fits the model on neither (a
#: polarization sensor's noise is a few degrees at most): its sign mirrored, its reference axis 90° off or the AoP
#: and DoP columns swapped left 28.5° and were refused as "ambiguous by 180°, pass --q0-deg", which then ran at
#: 46-108° heading RMSE with exit 0
AOP_MISFIT = float(np.radians(10.0))


def misfit_error(rms, sigma: float) -> OptinavError:
    """The refusal of an AoP whose residuals' robust scale ``sigma`` rad exceeds :data:`AOP_MISFIT` from either
    heading branch (``rms`` (2,) rad the residual RMS of the runs from either)."""
    a, b = np.degrees(rms)
    return OptinavError(
        f"the AoP fits the sky's polarization pattern on neither heading branch (residual RMS {a:.2f}° and "
        f"{b:.2f}°, robust scale {np.degrees(sigma):.2f}°; a polarization sensor's noise is a few degrees): the "
        "AoP's sign or reference axis, or the columns, are not what the model takes",
        "check the AoP's convention (the angle from the sensor's X_m axis to the polarization direction, "
        "docs/methods/attitude.md) and sign, the sensor's mounting, and that --pol-columns names AOP then DOP",
    )


#: rad: from q0 the polarization's first used sample may turn the heading by this at most (to the AoP's heading
#: nearest q0's). A q0 chooses the branch (its yaw within 90° of the truth); a turn beyond 45° says q0's yaw or
#: the AoP (its reference axis 90° off: 90° heading error with exit 0), the mounting or the sun is off by it
Q0_TURN = float(np.radians(45.0))


def q0_branch_error(rms, sigma: float) -> OptinavError:
    """The refusal of a q0 on the heading branch the AoP contradicts: ``rms`` (2,) rad the residual RMS of the runs
    from q0 and from q0 turned 180° about up, ``sigma`` rad the noise. A q0 180° off ran 179° off with exit 0."""
    a, b = np.degrees(rms)
    return OptinavError(
        f"the initial attitude's heading (q0) is 180° from the one the AoP shows: estimated from q0 the AoP "
        f"residual RMS is {a:.2f}°, from q0 turned 180° about up {b:.2f}° (noise {np.degrees(sigma):.2f}°)",
        "check q0's yaw and its frame (--q0-deg ROLL,PITCH,YAW, docs/conventions.md), or drop it: the recording's "
        "tilting motion decides the heading's branch",
    )


def q0_turn_error(turn: float) -> OptinavError:
    """The refusal of a q0 whose heading the first used polarization sample turns by ``turn`` rad (beyond
    :data:`Q0_TURN`)."""
    return OptinavError(
        f"the first polarization sample used turns the heading {np.degrees(turn):.1f}° from q0's (to the AoP's "
        "heading nearest it): q0's yaw, the AoP's reference axis or sign, the sensor's mounting or the sun (place, "
        "time and its zone) is off by that",
        "check them (the AoP is the angle from the sensor's X_m axis to the polarization direction, "
        "docs/methods/attitude.md); a q0 whose yaw is not known within 45° is better dropped (--q0-deg): the "
        "recording's tilting motion decides the heading's branch",
    )


def branch_error(rms, sigma: float, tilt: float) -> OptinavError:
    """The refusal of a heading whose two branches explain the AoP alike: ``rms`` (2,) rad the AoP residual RMS
    of the runs from either, ``sigma`` rad the noise, ``tilt`` rad the viewing axis's largest angle from the
    vertical."""
    a, b = np.degrees(rms)
    return OptinavError(
        "the heading from skylight polarization alone is ambiguous by 180° here: estimated from either branch the "
        f"AoP residuals are alike (RMS {a:.2f}° and {b:.2f}°, noise {np.degrees(sigma):.2f}°; the viewing axis "
        f"within {np.degrees(tilt):.1f}° of the vertical)",
        "pass the initial attitude (--q0-deg ROLL,PITCH,YAW; q0=) or a magnetometer (--mag; mag=), or record "
        "tilting motion",
    )


def stream_branch_error() -> OptinavError:
    """The refusal of a streaming filter's first polarization sample when nothing fixed the heading's branch."""
    return OptinavError(
        "polarization alone gives the heading only up to 180° (a zenith-viewing sensor sees the same AoP at ψ and "
        "ψ + 180°), and a stream's outputs leave before the data can tell the two apart",
        "pass q0= (e.g. the last attitude optinav.attitude.estimate gives for the first seconds of tilting motion, "
        "then stream from there), heading0= (rad about up: the AoP's heading nearest it), or a magnetometer (iframe)",
    )


def q0_starts(q0, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """The two starts a run from ``q0`` (4,) [w, x, y, z] checks its branch from: q0, and q0 turned 180° about the
    navigation frame's up."""
    from optinav.attitude.measurement import up_vector
    from optinav.core.rotations import quat_from_rotvec, quat_multiply

    q0 = np.asarray(q0, float)
    return q0, quat_multiply(quat_from_rotvec(np.pi * up_vector(frame)), q0)


def field_sets_branch(mag, use) -> bool:
    """Whether the magnetometer ``mag`` (N, 3) has a field (three finite values) at or before the first usable
    polarization sample (``use`` (N,) bool; none usable: True): iframe then takes the AoP's root nearest the field's
    heading. A field that starts later is held to the branch the polarization took (``mag_pol_th``)."""
    if not use.any():
        return True
    return bool(np.isfinite(mag[: int(np.argmax(use)) + 1]).all(axis=1).any())


class BranchResiduals:
    """AoP residuals of the two runs from :data:`BRANCHES`, gathered block by block (:meth:`add`), and the
    :meth:`verdict`. ``C_b_m`` (3, 3) the sensor mounting, ``min_d2`` sin² of the least sun separation from the
    viewing axis (:func:`optinav.attitude.measurement.pol_inputs`), ``up`` (3,) the navigation frame's up."""

    def __init__(self, C_b_m, min_d2: float, up):
        self.C_b_m, self.min_d2, self.up = np.asarray(C_b_m, float), float(min_d2), np.asarray(up, float)
        self.n = 0  # samples compared
        self.sq = [0, 0]  # Σr² per branch in units of _SQ rad², exact: the same sum however the log is cut in blocks
        self.counts = np.zeros((2, _EDGES.size + 1), np.int64)  # |r| per branch by bin
        self.tilt = 0.0  # rad, the viewing axis's largest angle from the vertical (branch 0's attitude)
        self.turn = None  # rad, from q0: the heading turn at the first polarization sample used (add_turn)

    def add(self, q0_b_n, q1_b_n, use, sun_n, aop) -> None:
        """One block: the runs' attitudes ``q0_b_n``, ``q1_b_n`` (n, 4) [w, x, y, z], the usable samples ``use``
        (n,) bool, the sun ``sun_n`` (1 or n, 3) [-] and the AoP ``aop`` (n,) [rad] (as ``pol_inputs`` gives them).
        """
        from optinav.attitude.measurement import sensor_aop, sun_in_sensor, wrap_axial

        res, ok = [], np.asarray(use, bool).copy()
        for q in (q0_b_n, q1_b_n):
            s_m = sun_in_sensor(q, np.broadcast_to(sun_n, (len(ok), 3)), self.C_b_m)
            # the sun within min_sun_separation of the viewing axis at either branch's attitude: its AoP is no test
            ok &= s_m[:, 0] ** 2 + s_m[:, 1] ** 2 >= self.min_d2
            res.append(wrap_axial(aop - sensor_aop(s_m)))
        if len(ok):  # the viewing axis Z_m in n against up (branch 0's tilt; iframe's runs share it)
            cos = np.clip(quat_rotate(q0_b_n, self.C_b_m[2]) @ self.up, -1.0, 1.0)
            self.tilt = max(self.tilt, float(np.arccos(cos.min())))
        self.n += int(np.count_nonzero(ok))
        for k, r in enumerate(res):
            r = r[ok]
            units = np.rint(r * r / _SQ).astype(np.int64)
            self.sq[k] += sum(int(units[i : i + _SUM_ROWS].sum()) for i in range(0, units.size, _SUM_ROWS))
            self.counts[k] += np.bincount(np.searchsorted(_EDGES, np.abs(r)), minlength=_EDGES.size + 1)

    def _sigma(self, k: int) -> float:
        """rad, branch ``k``'s robust residual scale: the median |r| (interpolated in its bin) × 1.4826."""
        c = np.cumsum(self.counts[k])
        i = int(np.searchsorted(c, 0.5 * c[-1]))
        lo, hi = (_EDGES[i - 1] if i else 0.0), _EDGES[min(i, _EDGES.size - 1)]
        below = c[i - 1] if i else 0
        frac = (0.5 * c[-1] - below) / max(self.counts[k, i], 1)
        return 1.4826 * float(lo + frac * (hi - lo))

    def add_turn(self, q_b_n, used, before) -> None:
        """One block of the run from q0 (branch 0): its attitudes ``q_b_n`` (n, 4), the polarization samples it
        used ``used`` (n,) bool and the attitude ``before`` its first row (q0, or the last row of the block before):
        the heading turn at the first used sample (:data:`Q0_TURN`) is kept."""
        from optinav.attitude.metrics import heading_error

        if self.turn is None and np.any(used):
            k = int(np.argmax(used))
            prev = np.asarray(before, float) if k == 0 else q_b_n[k - 1]
            self.turn = float(heading_error(q_b_n[k : k + 1], prev[None, :])[0])

    def verdict(self, fixed: bool = False) -> tuple[int, np.ndarray | None]:
        """The branch the AoP takes and the residual RMS (2,) rad of it and of the other; (0, None) where no
        sample was usable (no heading from polarization: the gyro's, as without it). An AoP beyond
        :data:`AOP_MISFIT` raises :func:`misfit_error`. Two branches within :data:`BRANCH_MARGIN` raise
        :func:`branch_error`; with ``fixed`` (branch 0 started from q0) they keep q0's branch, and the other one
        taken (:func:`q0_branch_error`) or q0's heading turned beyond :data:`Q0_TURN` (:meth:`add_turn`) raise."""
        if self.n == 0:
            return 0, None
        ms = np.array(self.sq, float) * _SQ / self.n
        k = int(np.argmin(ms))
        sigma = max(self._sigma(k), MIN_AOP_NOISE)
        rms = np.sqrt(ms[[k, 1 - k]])
        if sigma > AOP_MISFIT:
            raise misfit_error(rms, sigma)
        alike = ms[1 - k] - ms[k] <= BRANCH_MARGIN * sigma**2
        if fixed:  # a q0 90° off turns to either root: named by its turn, not as 180° off
            if self.turn is not None and self.turn > Q0_TURN:
                raise q0_turn_error(self.turn)
            if k == 1 and not alike:
                raise q0_branch_error(rms[::-1], sigma)
            return 0, np.sqrt(ms)
        if alike:
            raise branch_error(rms, sigma, self.tilt)
        return k, rms


#: the least share of the samples on which gd/cg/qn/mekf must hold the heading branch iframe's AoP residuals took
#: (within 90° of iframe's heading), from the start on it or else from the other. BROAD's nine with synthesized AoP,
#: 20- and 60-s cuts every 20 s: 0.98 or more where the method holds it; 0.48 for qn from a start in fast
#: translation (trial 16; 170° off for its first half, then on the branch), 0.25 or less where it holds it from
#: neither start
MIN_HELD = 0.8


def left_error(method: str, share: float) -> OptinavError:
    """The refusal of a method that holds the heading branch the AoP took from neither start (``share`` the
    largest share of the samples within 90° of it)."""
    return OptinavError(
        f"{method}, started on either heading branch, does not hold the one the AoP takes (iframe's, from its "
        f"residuals): within 90° of it on {100 * share:.0f} % of the samples at best",
        "use --method iframe (its tilt never sees the heading), or pass the initial attitude (--q0-deg "
        "ROLL,PITCH,YAW; q0=)",
    )


class HeldBranch:
    """Whether gd/cg/qn/mekf, run from a start (:data:`BRANCHES` as ``other_root``), hold the heading branch
    iframe's AoP residuals took: per start and per reference (iframe's run from either branch; read in blocks, the
    one taken is known at the end), the samples of the ``n`` within 90° of the reference's heading. Their tilt sees
    the AoP: from a start in fast motion mekf's tilt, 20–50° off, let it take the other branch's AoP (BROAD trial
    16); qn crossed to the branch there only after 30 s."""

    def __init__(self, n: int, refs: int = 1):
        self.n, self.counts = n, np.full((2, refs), -1, np.int64)  # −1: that start not run

    def add(self, start: int, q_b_n, refs) -> None:
        """One block of the run from ``start`` (0 or 1): its attitudes ``q_b_n`` (m, 4) and the references' ``refs``
        (of (m, 4)), [w, x, y, z]."""
        from optinav.attitude.metrics import heading_error

        for i, r in enumerate(refs):
            near = int(np.count_nonzero(heading_error(q_b_n, r) < np.pi / 2))
            self.counts[start, i] = max(self.counts[start, i], 0) + near

    def share(self, start: int, ref: int = 0) -> float:
        """The share of the samples the run from ``start`` held reference ``ref``'s branch on (0 not run)."""
        return max(int(self.counts[start, ref]), 0) / max(self.n, 1)

    def verdict(self, method: str, ref: int = 0, prefer: int = 0) -> int:
        """The start that holds reference ``ref``'s branch on :data:`MIN_HELD` of the samples, ``prefer`` (the
        reference's own) if it does, else the other; neither: :func:`left_error`."""
        for j in (prefer, 1 - prefer):
            if self.share(j, ref) >= MIN_HELD:
                return j
        raise left_error(method, max(self.share(0, ref), self.share(1, ref)))
