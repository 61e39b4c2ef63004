"""Accelerometer-array model of a gyro-free IMU and its identifiability.

Each accelerometer i at position ``r_i`` (m, body frame, from the array's reference point) with unit sensing
direction ``θ_i`` measures (Hao & Liu 2011, eq. 1; Mostov 2000)

    f_i = θ_iᵀ (A + ω̇ × r_i + ω × (ω × r_i))                                  (m/s²)

with ``A`` the specific force at the reference point, ``ω`` the body rate (rad/s) and ``ω̇`` its derivative.
Since ``θᵀ(ω̇ × r) = (r × θ)ᵀ ω̇`` and ``θᵀ(ω × (ω × r)) = ωᵀ(sym(θ rᵀ) − (θ·r) I) ω``, the N outputs are

    f = H_lin [A; ω̇] + H_quad q(ω),   q = (ωx², ωy², ωz², ωxωy, ωxωz, ωyωz)

``H_lin`` rows ``[θ_iᵀ, (r_i × θ_i)ᵀ]`` (N × 6), ``H_quad`` rows from ``M_i = sym(θ_i r_iᵀ) − (θ_i·r_i) I``:
``[M_xx, M_yy, M_zz, 2M_xy, 2M_xz, 2M_yz]`` (N × 6). :func:`identifiability` treats the 12 terms as free
unknowns (a linear identifiability analysis, the standard one for gyro-free arrays).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optinav.core.observability import format_combination, rref
from optinav.core.results import Result
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

__all__ = [
    "AccelerometerArray",
    "Identifiability",
    "identifiability",
    "builtin",
    "BUILTINS",
    "LINEAR_NAMES",
    "QUAD_NAMES",
    "quadratic_products",
    "h_lin",
    "h_quad",
    "RANK_TOL",
]

LINEAR_NAMES = ["A_x", "A_y", "A_z", "wdot_x", "wdot_y", "wdot_z"]
QUAD_NAMES = ["wx^2", "wy^2", "wz^2", "wx*wy", "wx*wz", "wy*wz"]
#: singular values below RANK_TOL · s_max of the column-normalized design count as zero
RANK_TOL = 1e-9
_UNIT_TOL = 1e-3  # |‖θ‖ − 1| allowed in a configuration file (then normalized)
_DUP_TOL = 1e-9  # m and rad: two sensors this close in position and direction are duplicates


def quadratic_products(omega) -> np.ndarray:
    """Quadratic rate products q(ω) = (ωx², ωy², ωz², ωxωy, ωxωz, ωyωz).

    Parameters
    ----------
    omega : (..., 3) array
        Angular rate [rad/s].

    Returns
    -------
    (..., 6) ndarray
        q(ω) [rad^2/s^2].
    """
    w = np.asarray(omega, float)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    return np.stack([x * x, y * y, z * z, x * y, x * z, y * z], -1)


def h_lin(positions, directions) -> np.ndarray:
    """Rows ``[θᵀ, (r × θ)ᵀ]`` (..., N, 6) of the part linear in [A; ω̇]."""
    r, th = np.asarray(positions, float), np.asarray(directions, float)
    return np.concatenate([th, np.cross(r, th)], -1)


def h_quad(positions, directions) -> np.ndarray:
    """Rows (..., N, 6) multiplying q(ω): ``[M_xx, M_yy, M_zz, 2M_xy, 2M_xz, 2M_yz]``, M = sym(θrᵀ) − (θ·r)I."""
    r, th = np.asarray(positions, float), np.asarray(directions, float)
    d = np.sum(r * th, -1)
    return np.stack(
        [
            th[..., 0] * r[..., 0] - d,
            th[..., 1] * r[..., 1] - d,
            th[..., 2] * r[..., 2] - d,
            th[..., 0] * r[..., 1] + th[..., 1] * r[..., 0],
            th[..., 0] * r[..., 2] + th[..., 2] * r[..., 0],
            th[..., 1] * r[..., 2] + th[..., 2] * r[..., 1],
        ],
        -1,
    )


@dataclass
class AccelerometerArray:
    """N accelerometers: ``positions`` (N, 3) m, unit ``directions`` (N, 3), optional ``noise`` (N,) m/s² (1σ).

    Validation is strict: a non-finite entry, a wrong shape, a zero or non-unit direction (|‖θ‖−1| > 1e-3;
    smaller deviations are normalized) or two identical sensors raise :class:`OptinavError` naming the sensor.
    """

    positions: np.ndarray
    directions: np.ndarray
    noise: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        p = _as_rows(self.positions, "positions")
        d = _as_rows(self.directions, "directions")
        if p.shape != d.shape:
            raise OptinavError(
                f"{p.shape[0]} positions but {d.shape[0]} directions",
                "give one position and one direction per accelerometer",
            )
        with np.errstate(over="ignore"):  # a direction of 1e300 (a damaged file) is named below by its norm, inf
            n = np.linalg.norm(d, axis=1)
        for i, ni in enumerate(n):
            if ni == 0:
                raise OptinavError(
                    f"accelerometer {i + 1}: sensing direction is zero", "give a unit vector along the sensing axis"
                )
            if abs(ni - 1) > _UNIT_TOL:
                raise OptinavError(
                    f"accelerometer {i + 1}: sensing direction has norm {ni:.6g}, not 1",
                    "give a unit vector (divide by its norm)",
                )
        d = d / n[:, None]
        for i in range(len(p)):
            for j in range(i):
                if np.all(np.abs(p[i] - p[j]) <= _DUP_TOL) and np.all(np.abs(d[i] - d[j]) <= _DUP_TOL):
                    raise OptinavError(
                        f"accelerometer {i + 1} duplicates accelerometer {j + 1} (same position and direction)",
                        "remove one of them",
                    )
        self.positions, self.directions = p, d
        if self.noise is not None:
            s = as_float_array(self.noise, "noise")
            if s.ndim == 0:
                s = np.full(len(p), float(s))
            if s.shape != (len(p),):
                raise OptinavError(
                    f"noise has {s.size} entries for {len(p)} accelerometers",
                    "give one noise std (m/s^2) per accelerometer, or none",
                )
            if np.any(s <= 0):
                i = int(np.flatnonzero(s <= 0)[0])
                raise OptinavError(
                    f"accelerometer {i + 1}: noise std {s[i]:.6g} is not positive",
                    "give the noise standard deviation in m/s^2 (> 0)",
                )
            self.noise = s

    @property
    def n(self) -> int:
        return int(self.positions.shape[0])

    @property
    def H_lin(self) -> np.ndarray:
        return h_lin(self.positions, self.directions)

    @property
    def H_quad(self) -> np.ndarray:
        return h_quad(self.positions, self.directions)

    @property
    def H(self) -> np.ndarray:
        """[H_lin, H_quad] (N × 12)."""
        return np.hstack([self.H_lin, self.H_quad])

    def weights(self) -> np.ndarray:
        """Least-squares weights of the sensors.

        Returns
        -------
        (N,) ndarray
            1/σ_i [1/(m/s^2)] (ones when no noise is given).
        """
        return np.ones(self.n) if self.noise is None else 1.0 / self.noise

    def outputs(self, A, wdot, omega) -> np.ndarray:
        """Noise-free outputs of the exact model (eq. 1).

        Parameters
        ----------
        A : (T, 3) array
            Specific force at the reference point [m/s^2], body axes.
        wdot : (T, 3) array
            Angular acceleration [rad/s^2].
        omega : (T, 3) array
            Angular rate [rad/s].

        Returns
        -------
        (T, N) ndarray
            Sensor outputs [m/s^2].
        """
        return (
            np.asarray(A, float) @ self.directions.T
            + np.asarray(wdot, float) @ np.cross(self.positions, self.directions).T
            + quadratic_products(omega) @ self.H_quad.T
        )

    def with_geometry(self, positions, directions) -> "AccelerometerArray":
        """The same sensors (noise, name) at another geometry.

        Parameters
        ----------
        positions : (N, 3) array
            Sensor positions [m], body axes.
        directions : (N, 3) array
            Sensitive directions [-] (unit vectors).

        Returns
        -------
        AccelerometerArray
            The new array.
        """
        return AccelerometerArray(positions, directions, self.noise, self.name)

    # --- configuration files ------------------------------------------------------------------------------
    def to_config(self) -> dict:
        """The configuration layout read by :meth:`from_config`.

        Returns
        -------
        dict
            ``{"accelerometers": [{"position" [m], "direction", "noise" [m/s^2]}, ...], "name"}``.
        """
        acc = []
        for i in range(self.n):
            e = {"position": [float(v) for v in self.positions[i]], "direction": [float(v) for v in self.directions[i]]}
            if self.noise is not None:
                e["noise"] = float(self.noise[i])
            acc.append(e)
        out = {"accelerometers": acc}
        if self.name:
            out["name"] = self.name
        return out

    def save(self, path) -> Path:
        """Write :meth:`to_config` as JSON, atomically.

        Parameters
        ----------
        path : str or Path
            Output file.

        Returns
        -------
        Path
            The file written.
        """
        from optinav.core.files import write_json

        return write_json(path, self.to_config())

    @classmethod
    def from_config(cls, cfg, source: str = "configuration") -> "AccelerometerArray":
        """An array from its configuration (SI units).

        Parameters
        ----------
        cfg : dict
            ``{"accelerometers": [{"position": [x,y,z] (m), "direction": [x,y,z], "noise": σ (m/s², optional)}, ...]}``.
        source : str
            Named in error messages.

        Returns
        -------
        AccelerometerArray
            The validated array.
        """
        if isinstance(cfg, dict) and "accelerometers" not in cfg and isinstance(cfg.get("schema"), str):
            # a RESULT.json (or any optinav result) was told only that it lacks the list (probe)
            raise OptinavError(
                f"{source} is an optinav result ({cfg['schema']!r}), not an array configuration",
                "pass the CONFIG.json of the array (its accelerometers' positions and directions), or --builtin",
            )
        if not isinstance(cfg, dict) or "accelerometers" not in cfg:
            raise OptinavError(
                f"{source} has no 'accelerometers' list",
                'write {"accelerometers": [{"position": [x, y, z], "direction": [x, y, z]}, ...]}',
            )
        acc = cfg["accelerometers"]
        if not isinstance(acc, list) or not acc:
            raise OptinavError(f"{source}: 'accelerometers' is not a non-empty list", "list one entry per sensor")
        pos, dirs, noise = [], [], []
        for i, e in enumerate(acc):
            if not isinstance(e, dict):
                raise OptinavError(
                    f"{source}: accelerometer {i + 1} is not an object",
                    'write {"position": [x, y, z], "direction": [x, y, z]}',
                )
            unknown = sorted(set(e) - {"position", "direction", "noise", "name"})
            if unknown:
                raise OptinavError(
                    f"{source}: accelerometer {i + 1} has unknown key(s) {', '.join(unknown)}",
                    "use position (m), direction (unit vector) and optionally noise (m/s^2)",
                )
            for key in ("position", "direction"):
                v = e.get(key)
                if not (
                    isinstance(v, list)
                    and len(v) == 3
                    and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
                ):
                    raise OptinavError(
                        f"{source}: accelerometer {i + 1} {key} is {v!r}, not 3 numbers",
                        f"give {key} as [x, y, z]" + (" in m" if key == "position" else ""),
                    )
            pos.append(e["position"])
            dirs.append(e["direction"])
            noise.append(e.get("noise"))
        if any(s is not None for s in noise) and any(s is None for s in noise):
            raise OptinavError(
                f"{source}: noise is given for some accelerometers only",
                "give noise (m/s^2) for every accelerometer or for none",
            )
        for i, s in enumerate(noise):
            if s is not None and (not isinstance(s, (int, float)) or isinstance(s, bool)):
                raise OptinavError(
                    f"{source}: accelerometer {i + 1} noise is {s!r}, not a number", "give the noise std in m/s^2"
                )
        return cls(
            np.array(pos, float),
            np.array(dirs, float),
            None if noise[0] is None else np.array(noise, float),
            str(cfg.get("name", "")),
        )

    @classmethod
    def load(cls, path) -> "AccelerometerArray":
        """An array from a JSON configuration file (layout of :meth:`from_config`).

        Parameters
        ----------
        path : str or Path
            The file.

        Returns
        -------
        AccelerometerArray
            The validated array.
        """
        from optinav.core.files import parse_json, read_text

        cfg = parse_json(read_text(path, "configuration file"), str(path), "fix the configuration file")
        return cls.from_config(cfg, str(path))


def _as_rows(x, name) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise OptinavError(f"{name} is not numeric", f"give {name} as an (N, 3) array") from None
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 1:
        raise OptinavError(f"{name} has shape {a.shape}, expected (N, 3)", "give one 3-vector per accelerometer")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise OptinavError(
            f"accelerometer {int(np.flatnonzero(bad)[0]) + 1}: {name[:-1]} is not finite", "give finite numbers"
        )
    return a


# ------------------------------------------------------------------------------------------------------------
# identifiability
# ------------------------------------------------------------------------------------------------------------


def _rowspace(H: np.ndarray, tol: float = RANK_TOL) -> tuple[int, np.ndarray]:
    """Rank r and the right singular vectors (n × n) of the column-normalized H (scale-invariant): rows
    ``[:r]`` span its row space, rows ``[r:]`` its null space."""
    _, s, vt = np.linalg.svd(H, full_matrices=True)
    r = int(np.count_nonzero(s > tol * (s[0] if s.size else 0.0))) if s.size and s[0] > 0 else 0
    return r, vt


@dataclass
class Identifiability(Result):
    """What an accelerometer array can solve, from its design matrix (see :func:`identifiability`)."""

    SCHEMA = "optinav.gfimu.identifiability"
    VERSION = 2

    n_accelerometers: int = field(metadata={"unit": ""})
    rank_linear: int = field(metadata={"unit": ""})
    rank_quadratic: int = field(metadata={"unit": ""})
    rank_full: int = field(metadata={"unit": ""})
    n_quadratic_observable: int = field(metadata={"unit": ""})
    solvable_without_rate: list = field(metadata={"unit": "-"})
    solvable_with_rate: list = field(metadata={"unit": "-"})
    quadratic_observable: list = field(metadata={"unit": "-"})
    unobservable: list = field(metadata={"unit": "-"})
    unobservable_linear: list = field(metadata={"unit": "-"})
    statements: list = field(metadata={"unit": "-"})
    quadratic_basis: np.ndarray = field(metadata={"unit": ""})
    condition_linear: float = field(metadata={"unit": ""})
    name: str = field(default="", metadata={"unit": "-"})

    def to_summary(self) -> dict:
        """Plain-JSON dictionary (what ``optinav gfimu analyze`` writes).

        Returns
        -------
        dict
            Ranks, solvable components and unobservable combinations.
        """
        return {
            "name": self.name,
            "n_accelerometers": self.n_accelerometers,
            "rank_linear": self.rank_linear,
            "rank_quadratic": self.rank_quadratic,
            "rank_full": self.rank_full,
            "n_quadratic_observable": self.n_quadratic_observable,
            "solvable_without_rate": list(self.solvable_without_rate),
            "solvable_with_rate": list(self.solvable_with_rate),
            "quadratic_observable": list(self.quadratic_observable),
            "unobservable": list(self.unobservable),
            "unobservable_linear": list(self.unobservable_linear),
            "statements": list(self.statements),
            "condition_linear": self.condition_linear,
        }

    def require(self, needed=("linear",)) -> None:
        """Raise a one-line :class:`OptinavError` naming what cannot be solved when [A, ω̇] is not identifiable.

        Parameters
        ----------
        needed : sequence of str
            ``"linear"`` ([A, ω̇] with the rate known) and/or ``"without_rate"``.
        """
        if self.rank_linear < 6:
            missing = [n for n in LINEAR_NAMES if n not in self.solvable_with_rate]
            raise OptinavError(
                f"configuration{' ' + self.name if self.name else ''} is rank deficient: rank {self.rank_linear} "
                f"of 6 for [A, wdot] even with the rate known; cannot solve "
                f"{', '.join(missing) or 'the combination'} (unobservable: {'; '.join(self.unobservable)})",
                "add or re-orient accelerometers (see optinav gfimu analyze)",
            )
        if "without_rate" in needed and len(self.solvable_without_rate) < 6:
            missing = [n for n in LINEAR_NAMES if n not in self.solvable_without_rate]
            raise OptinavError(
                f"configuration{' ' + self.name if self.name else ''} cannot solve {', '.join(missing)} without "
                "knowing the angular rate (they mix with the quadratic rate terms)",
                "use method 'gauss-newton' (rate as a prior) or a configuration that separates them",
            )

    def summary(self) -> str:
        """A human-readable report of the ranks and solvable components.

        Returns
        -------
        str
            The report.
        """
        return "\n".join(
            [
                f"{self.n_accelerometers} accelerometers: rank [A, wdot] {self.rank_linear}/6, "
                f"rank with the 6 quadratic terms {self.rank_full}/12, "
                f"{self.n_quadratic_observable} quadratic combination(s) observable"
            ]
            + ["  " + s for s in self.statements]
        )


def identifiability(array: AccelerometerArray) -> Identifiability:
    """Ranks and solvable components of ``array`` (columns normalized, so the units of A, ω̇, q do not matter).

    * ``rank_linear`` = rank H_lin — [A, ω̇] solvable when ω is known (quadratic terms subtracted);
    * ``rank_full`` = rank [H_lin, H_quad];
    * ``n_quadratic_observable`` = rank_full − rank_linear: combinations ``bᵀq`` estimable with [A, ω̇] unknown
      (the rows of ``quadratic_basis``, orthonormal, coordinates in QUAD_NAMES);
    * ``solvable_without_rate``: components of [A, ω̇] whose estimate does not depend on q (unit vector in the
      row space of the full design, i.e. identifiable after projecting out the quadratic columns).

    Parameters
    ----------
    array : AccelerometerArray
        The configuration.

    Returns
    -------
    Identifiability
        The report.
    """
    if not isinstance(array, AccelerometerArray):
        raise OptinavError("identifiability needs an AccelerometerArray", "load one with AccelerometerArray.load")
    H = array.H * array.weights()[:, None]
    norms = np.linalg.norm(H, axis=0)
    D = np.where(norms > 0, norms, 1.0)
    Hs = H / D
    rl, vt_l = _rowspace(Hs[:, :6])
    rq, _ = _rowspace(Hs[:, 6:])
    rf, vt_all = _rowspace(Hs)
    V, Vl = vt_all[:rf], vt_l[:rl]
    # estimable functionals cᵀ[x; q] ⇔ c ∈ rowspace(Hs) (in scaled coordinates, which keep zero patterns)
    P = V.T @ V
    solv_free = [LINEAR_NAMES[k] for k in range(6) if norms[k] > 0 and np.linalg.norm(P[:, k] - np.eye(12)[k]) < 1e-7]
    # with q known, [A, ω̇] components estimable from H_lin alone
    Pl = Vl.T @ Vl
    solv_rate = [LINEAR_NAMES[k] for k in range(6) if norms[k] > 0 and np.linalg.norm(Pl[:, k] - np.eye(6)[k]) < 1e-7]
    # quadratic combinations: a ∈ null(V[:, :6]ᵀ) → b = aᵀ V[:, 6:]
    if rf > 0:
        _, s, vt = np.linalg.svd(V[:, :6].T, full_matrices=True)
        k = int(np.count_nonzero(s > 1e-9))
        a = vt[k:]
        B = a @ V[:, 6:]
    else:
        B = np.zeros((0, 6))
    B = B * D[6:][None, :]  # functionals: cᵀu = (D c)ᵀq with u = D q
    nq = B.shape[0]
    Bq = np.linalg.qr(B.T)[0].T if nq else B
    words_q = [format_combination(row, QUAD_NAMES, normalize=True) for row in rref(B)] if nq else []
    # unobservable directions of [x; q] (null space of Hs, RREF for readable words)
    null = vt_all[rf:]
    unobs = []
    if null.shape[0]:
        N = rref(null)
        unobs = [format_combination(row / D, LINEAR_NAMES + QUAD_NAMES, normalize=True) for row in N]
    # words for the linear part only (with the rate known)
    null_l = vt_l[rl:]
    unobs_lin = (
        [format_combination(row / D[:6], LINEAR_NAMES, normalize=True) for row in rref(null_l)]
        if null_l.shape[0]
        else []
    )
    s_lin = np.linalg.svd(array.H_lin * array.weights()[:, None], compute_uv=False)
    cond = float(s_lin[0] / s_lin[5]) if s_lin.size >= 6 and s_lin[5] > 1e-12 * s_lin[0] else float("inf")
    st = [
        f"[A, wdot] with the rate known: rank {rl}/6" + ("" if rl == 6 else " — unobservable: " + "; ".join(unobs_lin)),
        "solvable without the rate: " + (", ".join(solv_free) if solv_free else "none"),
        f"quadratic rate terms: rank {rq}/6 in the design, {nq} combination(s) observable"
        + (": " + "; ".join(words_q) if words_q else ""),
    ]
    if unobs:
        st.append(f"{len(unobs)} direction(s) of [A, wdot, q] unobservable (with ω unknown): " + "; ".join(unobs))
    return Identifiability(
        n_accelerometers=array.n,
        rank_linear=rl,
        rank_quadratic=rq,
        rank_full=rf,
        n_quadratic_observable=nq,
        solvable_without_rate=solv_free,
        solvable_with_rate=solv_rate,
        quadratic_observable=words_q,
        unobservable=unobs,
        unobservable_linear=unobs_lin,
        statements=st,
        quadratic_basis=Bq,
        condition_linear=cond,
        name=array.name,
    )


# ------------------------------------------------------------------------------------------------------------
# built-in configurations
# ------------------------------------------------------------------------------------------------------------


def _cylinder10(l: float = 0.04, L: float = 0.04) -> AccelerometerArray:
    """Ten accelerometers on a cylinder of radius ``l`` and length ``L`` (axis = body x, the spin axis).

    Rim points ``(x, l cos φ, l sin φ)`` with φ from +y towards +z; "axial" senses +x, "tangential" senses
    the counter-clockwise tangent ``(0, −sin φ, cos φ)``. Rear face x = −L/2: axial at φ = 90°, 270°,
    tangential at 0°, 270°; mid-plane x = 0: tangential at 90°, 180°; front face x = +L/2: axial at 0°,
    180°, tangential at 0°, 270°. Found by a search over axial/radial/tangential sensors at the 14 rim and
    face-centre points maximizing the information on [A, ω̇] with the quadratic terms as nuisance, subject to
    rank [A, ω̇] = 6 without the rate (the paper's layout was lost in the text extraction).
    """
    spec = [
        (-L / 2, 0, "t"),
        (-L / 2, 90, "a"),
        (-L / 2, 270, "a"),
        (-L / 2, 270, "t"),
        (0.0, 90, "t"),
        (0.0, 180, "t"),
        (L / 2, 0, "a"),
        (L / 2, 0, "t"),
        (L / 2, 180, "a"),
        (L / 2, 270, "t"),
    ]
    pos, dirs = [], []
    for x, phi, kind in spec:
        c, s = np.cos(np.radians(phi)), np.sin(np.radians(phi))
        c, s = round(c), round(s)  # exact 0/±1 at the quarter angles
        pos.append([x, l * c, l * s])
        dirs.append([1.0, 0.0, 0.0] if kind == "a" else [0.0, -s, c])
    return AccelerometerArray(np.array(pos, float), np.array(dirs, float), name="cylinder10")


BUILTINS = {"cylinder10": _cylinder10}


def builtin(name: str = "cylinder10", **kwargs) -> AccelerometerArray:
    """A built-in configuration by name.

    Parameters
    ----------
    name : str
        One of :data:`BUILTINS` (``cylinder10``: l = L = 0.04 m).
    **kwargs
        Geometry of the configuration, e.g. ``l=``, ``L=`` [m] to scale ``cylinder10``.

    Returns
    -------
    AccelerometerArray
        The array.
    """
    if name not in BUILTINS:
        raise OptinavError(f"unknown built-in configuration {name!r}", f"use one of {', '.join(BUILTINS)}")
    return BUILTINS[name](**kwargs)
