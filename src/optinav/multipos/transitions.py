"""The motions between consecutive still poses of a multi-position log, for the gyro: one helper shared by the
multi-position gyro fit (:mod:`optinav.multipos.gyro`) and the Ferraris pose-turn check
(:func:`optinav.multipos.ferraris.pose_turns`).

Each transition k runs from the last sample of pose k to the first of pose k+1; its raw gyro rows are integrated
with :func:`optinav.core.strapdown.attitude_update` into C_k = C_{b(k+1)}^{b(k)}, which must carry gravity's unit
direction u_k of pose k into u_{k+1}: the residual r_k = C_kᵀu_k − u_{k+1} (≈ the angle off, rad).
"""

from __future__ import annotations

import numpy as np

from optinav.core.rotations import quat_conjugate, quat_multiply, quat_rotate
from optinav.core.strapdown import attitude_update
from optinav.core.validate import integration_steps


class Transitions:
    """The motion samples of all transitions, concatenated for one strapdown call per evaluation.

    Parameters
    ----------
    t : (N,) array
        Time stamps [s].
    raw : (N, 3) array
        Gyro output [raw units].
    idx : (P, 2) int array
        Sample ranges of the still poses, in time order.
    u : (P, 3) array
        Unit gravity direction of each pose, body axes [-].
    coning : str
        The coning correction of :func:`optinav.core.strapdown.attitude_update`.
    keep : sequence of int or None
        The transitions k (pose k to k+1) used; None: all.
    """

    def __init__(self, t, raw, idx, u, coning, keep=None):
        keep = np.arange(idx.shape[0] - 1) if keep is None else np.asarray(keep, int)
        segs = [np.arange(idx[k, 1] - 1, idx[k + 1, 0] + 1) for k in keep]
        lens = np.array([s.size for s in segs])
        self.seg = np.repeat(np.arange(lens.size), lens)  # transition of each row (a per-transition bias)
        self.ends = np.cumsum(lens) - 1
        self.starts = self.ends - lens + 1
        sel = np.concatenate(segs)
        self.raw = raw[sel]
        tt = t[sel]
        self.t_rows = tt
        # steps per transition (stamps rounded to a coarse tick get the uniform step); the joins are set below
        h = np.concatenate([integration_steps(t[s]) for s in segs])[:-1]
        self.gap = np.zeros(h.size, dtype=bool)
        self.gap[self.ends[:-1]] = True  # increment joining two transitions
        h[self.gap] = np.median(h[~self.gap])  # any positive step: its increment is zero
        self.h = h
        self.durations = tt[self.ends] - tt[self.starts]
        self.u0, self.u1 = u[keep], u[keep + 1]
        self.keep = keep
        self.coning = coning

    def up_jacobian(self, K, b, n_up: int) -> np.ndarray:
        """∂r/∂u (3T × 3·n_up) of the residuals r_k = C_kᵀu_k − u_{k+1} with respect to the up directions."""
        qc = quat_conjugate(self.rotations(K, b))
        C = np.stack([quat_rotate(qc, np.broadcast_to(e, (qc.shape[0], 3))) for e in np.eye(3)], axis=-1)  # C_kᵀ
        J = np.zeros((3 * self.keep.size, 3 * n_up))
        for k, i in enumerate(self.keep):
            J[3 * k : 3 * k + 3, 3 * i : 3 * i + 3] = C[k]
            J[3 * k : 3 * k + 3, 3 * i + 3 : 3 * i + 6] = -np.eye(3)
        return J

    def _attitudes(self, K, b) -> np.ndarray:
        """Quaternion per row (rows, 4) of the body against the first row's, the rates K⁻¹(raw − b) integrated
        (b: (3,) or one per row, the "local" bias); the increments joining two transitions are zero."""
        w = (self.raw - b) @ np.linalg.inv(K).T
        dth = 0.5 * (w[:-1] + w[1:]) * self.h[:, None]
        dth[self.gap] = 0.0
        return attitude_update(np.array([1.0, 0.0, 0.0, 0.0]), dth, coning=self.coning, dt=self.h)

    def rotations(self, K, b) -> np.ndarray:
        """Quaternions q_k of C_{b(k+1)}^{b(k)} (T, 4) for the given K, b."""
        q = self._attitudes(K, b)
        return quat_multiply(quat_conjugate(q[self.starts]), q[self.ends])

    def residuals(self, K, b) -> np.ndarray:
        """r_k = C_kᵀ u_k − u_{k+1}, (T, 3)."""
        q = self.rotations(K, b)
        return quat_rotate(quat_conjugate(q), self.u0) - self.u1

    def permutation_costs(self, k: float, b, perms) -> np.ndarray:
        """Σ‖r_k‖² for K = k·P, each P of ``perms`` a signed axis permutation: the rates become Pᵀω/k. Pᵀ = s·R
        with R a rotation and s = det P, and the strapdown update (coning term included) commutes with a rotation
        of its rates, so C_k(K) = R·C_k(s·k·I)·Rᵀ: two integrations serve all 48 permutations, not 48."""
        qc = {s: quat_conjugate(self.rotations(s * k * np.eye(3), b)) for s in (1.0, -1.0)}
        out = np.empty(len(perms))
        for j, P in enumerate(perms):
            s = 1.0 if np.linalg.det(P) > 0 else -1.0
            R = s * np.asarray(P, float).T
            r = quat_rotate(qc[s], self.u0 @ R) @ R.T - self.u1  # rows: R·C_kᵀ·Rᵀ·u_k − u_{k+1}
            out[j] = float(np.sum(r * r))
        return out

    def path(self, K, b) -> np.ndarray:
        """Quaternion per row (rows, 4) of the body at that row relative to the body at its transition's start."""
        q = self._attitudes(K, b)
        return quat_multiply(quat_conjugate(q[self.starts][self.seg]), q)

    def gravity_path(self, K, b) -> np.ndarray:
        """Unit specific-force direction per row (body frame, (rows, 3)): u_k carried along the turn."""
        return quat_rotate(quat_conjugate(self.path(K, b)), self.u0[self.seg])

    def turn_angles(self, b) -> tuple[np.ndarray, np.ndarray]:
        """Per transition: the raw rotation perpendicular to the first pose's gravity direction
        ``‖Θ_k − (Θ_k·u_k)u_k‖`` (raw·s, Θ_k = ∫(raw − b)dt; a turn about gravity moves no gravity direction) and
        the gravity-direction change ``α_k`` (rad) that the accelerometer sees."""
        w = self.raw - b
        dth = 0.5 * (w[:-1] + w[1:]) * self.h[:, None]
        dth[self.gap] = 0.0
        cs = np.vstack([np.zeros((1, 3)), np.cumsum(dth, axis=0)])
        th = cs[self.ends] - cs[self.starts]
        perp = th - np.einsum("ij,ij->i", th, self.u0)[:, None] * self.u0
        alpha = np.arccos(np.clip(np.einsum("ij,ij->i", self.u0, self.u1), -1.0, 1.0))
        return np.linalg.norm(perp, axis=1), alpha

    def raw_rotation(self, b) -> np.ndarray:
        """‖∫(raw − b)dt‖ per transition (raw·s), the rotation angle times the scale for K = k·I."""
        w = self.raw - b
        dth = 0.5 * (w[:-1] + w[1:]) * self.h[:, None]
        dth[self.gap] = 0.0
        cs = np.vstack([np.zeros((1, 3)), np.cumsum(dth, axis=0)])
        return np.linalg.norm(cs[self.ends] - cs[self.starts], axis=1)
