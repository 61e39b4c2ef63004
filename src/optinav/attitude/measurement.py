"""The measurement model shared by every attitude estimator: gravity and skylight-polarization errors.

Conventions (shared with :mod:`optinav.sky` and :mod:`optinav.attitude.simulate`):

* ``q`` = q_b^n scalar-first, ``C_b^n = dcm_from_quat(q)``; navigation frame ``"NED"`` (default, as the paper)
  or ``"ENU"``. The accelerometer measures specific force: at rest ``a_b = C_n^b·u_n·g`` with the unit "up"
  vector ``u_n`` = [0, 0, −1] (NED) or [0, 0, 1] (ENU).
* Polarization sensor frame m: ``Z_m`` = viewing direction, ``X_m`` = reference axis, ``Y_m = Z_m × X_m``.
  :data:`DEFAULT_C_B_M` (body forward-right-down, NED users): the sensor looks up (``Z_m = −z_b``) with its
  reference axis forward (``X_m = x_b``), so ``C_b^m = diag(1, −1, −1)``. :data:`DEFAULT_C_B_M_ENU` is the same
  physical mounting for a right-forward-up body (``X_m = y_b``, ``Z_m = z_b``).
* Rayleigh single scattering: E ∝ s × v (s unit sun vector, v viewing direction); in the sensor frame
  ``E′ ∝ s_m × z_m = [s_m,y, −s_m,x, 0]``. Angle of polarization α = atan2(E_y, E_x) wrapped to
  [−π/2, π/2), an axial quantity (α and α + π are the same measurement).

Errors (Jin et al. 2021, §2.1–2.2, eqs. for ε_b and ε_m; F = [ε_b; ε_m], ∇F = JᵀF):

* gravity ``ε_b(q) = C_n^b(q)·u_n − a_b/‖a_b‖`` (3 rows);
* polarization, doubled-angle form ``ε_m(q) = w·([cos 2α′, sin 2α′] − [cos 2α, sin 2α])`` (2 rows) with
  α′ the AoP predicted from ``s_m = C_b^m C_n^b(q) s_n``. The paper compares the un-normalized E′ with
  ``[cos α, sin α, 0]``; that error changes sign when α → α + π and grows with ‖E′‖ (sun elevation and
  sensor tilt). Doubling the angle makes it axial and normalized: |ε_m| = 2|sin(α′ − α)|, smooth except
  when the sun is on the viewing axis (s_m,x = s_m,y = 0), which is skipped (``min_sun_separation``).

Jacobians, analytic (tests compare them with finite differences), in three parameterizations:
``"body"`` δθ with q ⊗ exp(δθ/2) (∂(C_n^b v_n) = [v_b×]δθ), ``"nav"`` φ with exp(φ/2) ⊗ q
(J_nav = J_body·C_n^b), ``"quat"`` the 4-column derivative on the unit sphere (J_quat = 2·J_body·Ξ(q)ᵀ,
tangent to q; the radial part would only change ‖q‖, which every estimator renormalizes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optinav.attitude import _kernels
from optinav.core.rotations import DEFAULT_FRAME, frame_name
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError
from optinav.sky.polarization import wrap_axial

__all__ = [
    "DEFAULT_C_B_M",
    "DEFAULT_C_B_M_ENU",
    "PolarizationMeasurement",
    "up_vector",
    "default_c_b_m",
    "as_c_b_m",
    "measurement_error",
    "predicted_aop",
    "sun_elevation",
    "wrap_axial",
]

#: C_b^m for a zenith-viewing sensor on a forward-right-down body: X_m = x_b (forward), Z_m = −z_b (up)
DEFAULT_C_B_M = np.diag([1.0, -1.0, -1.0])
#: the same mounting for a right-forward-up body (frame="ENU" users): X_m = y_b (forward), Z_m = z_b (up)
DEFAULT_C_B_M_ENU = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
_JAC_MODES = {"body": _kernels.MODE_BODY, "nav": _kernels.MODE_NAV, "quat": _kernels.MODE_QUAT}


def up_vector(frame: str = DEFAULT_FRAME) -> np.ndarray:
    """Unit vector opposite to gravity in the navigation frame (what a resting accelerometer measures).

    Parameters
    ----------
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.

    Returns
    -------
    (3,) ndarray
        The up direction [-].
    """
    return np.array([0.0, 0.0, -1.0]) if frame_name(frame) == "ned" else np.array([0.0, 0.0, 1.0])


def default_c_b_m(frame: str = DEFAULT_FRAME) -> np.ndarray:
    """Zenith-viewing sensor mounting: :data:`DEFAULT_C_B_M` (NED, FRD body) or :data:`DEFAULT_C_B_M_ENU`.

    Parameters
    ----------
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.

    Returns
    -------
    (3, 3) ndarray
        C_b^m [-].
    """
    return (DEFAULT_C_B_M if frame_name(frame) == "ned" else DEFAULT_C_B_M_ENU).copy()


def as_c_b_m(C_b_m, frame: str = DEFAULT_FRAME) -> np.ndarray:
    """The sensor mounting C_b^m checked as a rotation matrix; ``None`` → :func:`default_c_b_m`."""
    if C_b_m is None:
        return default_c_b_m(frame)
    c = as_float_array(C_b_m, "C_b_m", last_dims=(3, 3))
    if c.shape != (3, 3) or not np.allclose(c @ c.T, np.eye(3), atol=1e-6) or np.linalg.det(c) < 0:
        raise OptinavError("C_b_m is not a 3x3 rotation matrix", "pass the sensor mounting C_b^m (orthonormal)")
    return c


def sun_elevation(sun_n, frame: str = DEFAULT_FRAME) -> np.ndarray:
    """Elevation (rad) of unit sun vector(s) in the navigation frame."""
    s = np.asarray(sun_n, dtype=float)
    return np.arcsin(np.clip(s[..., 2] * up_vector(frame)[2], -1.0, 1.0))


@dataclass
class PolarizationMeasurement:
    """Skylight-polarization samples aligned with the IMU samples.

    aop (N,) rad, angle between E and X_m (axial; NaN = no measurement); sun_n (N, 3) or (3,) unit sun vector
    in the navigation frame; dop (N,) degree of polarization or None; C_b_m (3, 3) mounting (None → the
    zenith-viewing default of ``frame``); valid (N,) bool mask or None (all valid where aop is finite).

    Skip options (used by :meth:`usable`): ``min_sun_elevation`` rad (sun below it → skipped, default 0),
    ``min_dop`` (default 0.05), ``min_sun_separation`` rad between the sun and the viewing axis (default 10°;
    evaluated at the estimated attitude inside the estimators).
    """

    aop: np.ndarray = field(metadata={"unit": "rad"})
    sun_n: np.ndarray = field(metadata={"unit": ""})
    dop: np.ndarray | None = field(default=None, metadata={"unit": ""})
    C_b_m: np.ndarray | None = field(default=None, metadata={"unit": ""})
    frame: str = DEFAULT_FRAME
    valid: np.ndarray | None = None
    min_sun_elevation: float = field(default=0.0, metadata={"unit": "rad"})
    min_dop: float = 0.05
    min_sun_separation: float = field(default=np.radians(10.0), metadata={"unit": "rad"})

    def __post_init__(self):
        self.frame = frame_name(self.frame)
        aop = as_float_array(self.aop, "aop", finite=False)
        if aop.ndim != 1 or aop.size == 0:
            raise OptinavError(f"aop has shape {aop.shape}, expected (N,)", "pass one angle (rad) per IMU sample")
        if np.any(np.isinf(aop)):
            raise OptinavError("aop contains infinite values", "use NaN for missing polarization samples")
        big = float(np.nanmax(np.abs(aop))) if np.isfinite(aop).any() else 0.0
        if big > 2 * np.pi:  # streamed in degrees, the heading ran 75-113° off with exit 0
            raise OptinavError(
                f"aop reaches {big:.4g}, beyond 2π: it is in radians (an angle of polarization in degrees?)",
                "pass radians (np.radians(aop_deg)); NaN for missing samples",
            )
        self.aop = aop
        n = aop.size
        s = as_float_array(self.sun_n, "sun_n", last_dims=(3,))
        if s.ndim == 1:
            s = s[None, :]
        if s.ndim != 2 or s.shape[0] not in (1, n):
            raise OptinavError(
                f"sun_n has shape {np.shape(self.sun_n)}, expected (3,) or ({n}, 3)",
                "pass one unit sun vector or one per sample",
            )
        norm = np.linalg.norm(s, axis=1)
        if np.any(np.abs(norm - 1.0) > 1e-3):
            raise OptinavError(
                f"sun_n is not a unit vector (norm {norm.min():.4g}..{norm.max():.4g})",
                "pass the unit sun direction in the navigation frame",
            )
        self.sun_n = s / norm[:, None]
        if self.dop is not None:
            d = as_float_array(self.dop, "dop", finite=False)
            if d.shape != (n,):
                raise OptinavError(f"dop has shape {d.shape}, expected ({n},)", "pass one degree per sample")
            lo, hi = (float(np.nanmin(d)), float(np.nanmax(d))) if np.isfinite(d).any() else (0.0, 0.0)
            if lo < 0.0 or hi > 1.0 + 1e-9:  # in percent, no sample was ever skipped for a low DoP
                raise OptinavError(
                    f"the degree of polarization reaches {hi if hi > 1 else lo:.4g}, outside [0, 1]"
                    + (": it looks like percent" if hi > 1 else ""),
                    "pass it as a fraction (percent / 100), or leave it out (--pol-columns AOP alone): then no sample "
                    "is skipped for a low DoP",
                )
            self.dop = d
        self.C_b_m = as_c_b_m(self.C_b_m, self.frame)
        if self.valid is not None:
            v = np.asarray(self.valid)
            if v.shape != (n,):
                raise OptinavError(f"valid has shape {v.shape}, expected ({n},)", "pass one bool per sample")
            self.valid = v.astype(bool)
        for name in ("min_sun_elevation", "min_dop", "min_sun_separation"):
            if not np.isfinite(float(getattr(self, name))):
                raise OptinavError(f"{name} is not finite", f"pass a number for {name}")

    def __len__(self) -> int:
        return self.aop.size

    def usable(self) -> tuple[np.ndarray, dict[str, int]]:
        """Samples the estimators may use, and the skipped ones counted by reason.

        Returns
        -------
        ok : (N,) bool ndarray
            Usable samples.
        counts : dict of str to int
            ``missing``, ``invalid``, ``sun_below_horizon``, ``low_dop`` → number skipped.
        """
        n = self.aop.size
        ok = np.isfinite(self.aop)
        counts = {"missing": int(np.count_nonzero(~ok))}
        if self.valid is not None:
            bad = ok & ~self.valid
            counts["invalid"] = int(np.count_nonzero(bad))
            ok &= self.valid
        elev = sun_elevation(self.sun_n, self.frame)
        elev = np.broadcast_to(elev, (n,))
        low = ok & (elev < self.min_sun_elevation)
        counts["sun_below_horizon"] = int(np.count_nonzero(low))
        ok &= ~low
        if self.dop is not None:
            weak = ok & ~(self.dop >= self.min_dop)
            counts["low_dop"] = int(np.count_nonzero(weak))
            ok &= ~weak
        return ok, counts

    def select(self, rows) -> "PolarizationMeasurement":
        """The measurement restricted to ``rows``.

        Parameters
        ----------
        rows : slice, int array or bool array
            The samples to keep.

        Returns
        -------
        PolarizationMeasurement
            The same sensor and thresholds on those samples.
        """
        return PolarizationMeasurement(
            self.aop[rows],
            self.sun_n if self.sun_n.shape[0] == 1 else self.sun_n[rows],
            None if self.dop is None else self.dop[rows],
            self.C_b_m,
            self.frame,
            None if self.valid is None else self.valid[rows],
            self.min_sun_elevation,
            self.min_dop,
            self.min_sun_separation,
        )


def predicted_aop(q_b_n, sun_n, C_b_m=None, frame: str = DEFAULT_FRAME) -> np.ndarray:
    """Rayleigh AoP seen by the sensor at attitude(s) ``q_b_n`` for sun vector(s) ``sun_n``.

    The forward model of the shared measurement model, also used to synthesize measurements.

    Parameters
    ----------
    q_b_n : (4,) or (N, 4) array
        Attitude q_b^n [-] as [w, x, y, z].
    sun_n : (3,) or (N, 3) array
        Unit sun vector in the navigation frame [-].
    C_b_m : (3, 3) array or None
        Sensor mounting C_b^m [-]; None: :func:`default_c_b_m`.
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.

    Returns
    -------
    (N,) ndarray
        AoP in [−π/2, π/2) [rad].
    """
    return sensor_aop(sun_in_sensor(q_b_n, sun_n, as_c_b_m(C_b_m, frame)))


def sensor_aop(s_m) -> np.ndarray:
    """The Rayleigh AoP [rad] in [−π/2, π/2) of unit sun vector(s) ``s_m`` (..., 3) in the sensor frame."""
    s_m = np.asarray(s_m, float)
    # E ∝ s_m × z_m = [s_y, −s_x, 0]
    return wrap_axial(np.arctan2(-s_m[..., 0], s_m[..., 1]))


def sun_in_sensor(q_b_n, sun_n, C_b_m) -> np.ndarray:
    """The unit sun vector in the sensor frame, s_m = C_b^m C_n^b s_n, at attitude(s) ``q_b_n`` (4,) or (N, 4)
    [w, x, y, z] for sun vector(s) ``sun_n`` (3,) or (N, 3) and the mounting ``C_b_m`` (3, 3) [-]."""
    from optinav.core.rotations import dcm_from_quat

    q = as_float_array(q_b_n, "q_b_n", last_dims=(4,))
    s = as_float_array(sun_n, "sun_n", last_dims=(3,))
    return np.einsum("...ji,...j->...i", dcm_from_quat(q), s) @ np.asarray(C_b_m, float).T


def unusable_pol_error(skipped: dict, n: int) -> OptinavError:
    """The refusal of a log none of whose ``n`` polarization samples can be used (``skipped``: the counts of
    :meth:`PolarizationMeasurement.usable`): the heading was the start's, exit 0 (the sun below the horizon for the
    whole log: a time zone or a longitude's sign off, or a night)."""
    why = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in skipped.items() if v)
    return OptinavError(
        f"none of the {n} polarization samples can be used ({why}): the heading would be the start's alone",
        "check --start-time (its time zone), --lon (east positive) and --lat, or the AoP/DoP columns; drop "
        "--pol-columns to estimate without polarization",
    )


def pol_inputs(pol, n: int, frame: str, what: str = "the IMU"):
    """The kernels' polarization inputs for ``n`` samples: (usable mask, sun_n, C_b_m, AoP with 0 where unusable,
    sin² of the minimum sun separation, skipped counts); ``pol`` None gives "never usable"."""
    if pol is None:
        return np.zeros(n, bool), np.array([[1.0, 0.0, 0.0]]), default_c_b_m(frame), np.zeros(n), 0.0, {}
    if not isinstance(pol, PolarizationMeasurement):
        raise OptinavError(
            f"pol must be a PolarizationMeasurement, got {type(pol).__name__}",
            "wrap the angles with optinav.attitude.PolarizationMeasurement(aop, sun_n, ...)",
        )
    if pol.frame != frame_name(frame):
        raise OptinavError(f"pol.frame is {pol.frame} but frame is {frame}", "use one navigation frame")
    if len(pol) != n:
        raise OptinavError(f"pol has {len(pol)} samples but {what} has {n}", "align the polarization samples with it")
    use, skipped = pol.usable()
    return (
        use,
        np.ascontiguousarray(pol.sun_n),
        np.ascontiguousarray(pol.C_b_m),
        np.where(use, pol.aop, 0.0),
        float(np.sin(pol.min_sun_separation) ** 2),
        skipped,
    )


def measurement_error(
    q_b_n,
    acc,
    *,
    pol: PolarizationMeasurement | None = None,
    frame: str = DEFAULT_FRAME,
    jacobian: str = "quat",
    pol_weight: float = 1.0,
):
    """F(q) = [ε_b; ε_m] and its Jacobian at each sample (numpy face of the estimators' kernel).

    Parameters
    ----------
    q_b_n : (N, 4) array
        Attitude q_b^n [-] as [w, x, y, z].
    acc : (N, 3) array
        Specific force [any unit] (only its direction is used).
    pol : PolarizationMeasurement or None
        Polarization samples.
    frame : str
        Navigation frame, ``"ned"`` or ``"enu"``.
    jacobian : str
        "quat" (tangent, 4 columns), "body" or "nav" error angle (3 columns).
    pol_weight : float
        Weight w of the polarization rows (module docstring) [-].

    Returns
    -------
    F : (N, 5) ndarray
        Residuals ε_b (unit-vector difference) and ε_m (doubled-angle form) [-]; unused rows NaN.
    J : (N, 5, 3 or 4) ndarray
        Jacobian [1/rad].
    rows : (N,) int ndarray
        3 (gravity only), 5 (with polarization) or −3 (polarization requested but the sun within
        ``min_sun_separation`` of the viewing axis).
    """
    frame = frame_name(frame)
    if jacobian not in _JAC_MODES:
        raise OptinavError(f"unknown jacobian {jacobian!r}", "use 'quat', 'body' or 'nav'")
    q = as_float_array(q_b_n, "q_b_n", last_dims=(4,)).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    acc = as_float_array(acc, "acc", last_dims=(3,)).reshape(-1, 3)
    n = q.shape[0]
    if acc.shape[0] != n:
        raise OptinavError(f"q has {n} rows but acc has {acc.shape[0]}", "pass one accelerometer sample per q")
    if np.any(np.linalg.norm(acc, axis=1) == 0):
        raise OptinavError("acc contains zero vectors", "drop samples without accelerometer data")
    use, sn, cbm, aop, min_d2, _ = pol_inputs(pol, n, frame, "q")
    ncol = 4 if jacobian == "quat" else 3
    F = np.full((n, 5), np.nan)
    J = np.full((n, 5, ncol), np.nan)
    rows = np.zeros(n, dtype=np.int64)
    _kernels.model_batch(
        q, acc, up_vector(frame), use, sn, cbm, aop, float(pol_weight), float(min_d2), _JAC_MODES[jacobian], F, J, rows
    )
    return F, J, rows
