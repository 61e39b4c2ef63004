"""The attitude methods, their default options and the checks of a method name and its options: what a command
checks before it reads a file, without loading the estimators (numba kernels; issue 17, a bad-file error within
1 s of start). :mod:`optinav.attitude.estimators` and :mod:`optinav.attitude.iframe` use these."""

from __future__ import annotations

import numpy as np

from optinav.core.units import G_STANDARD
from optinav.errors import OptinavError

__all__ = ["IFRAME_DEFAULTS", "METHODS", "DEFAULTS"]

_D2R = np.pi / 180.0

#: options of ``method="iframe"`` (SI units: s, rad, rad/s, m/s²; ``mag_norm_th`` relative)
IFRAME_DEFAULTS: dict[str, float] = {
    "tau_acc": 4.0,  # s, accelerometer low-pass time constant in the almost-inertial frame
    "rest_tau": 0.5,  # s, low-pass of the rest detector
    "rest_gyr": 2.0 * _D2R,  # rad/s, max gyro deviation at rest
    "rest_acc": 0.5,  # m/s², max accelerometer deviation at rest
    "rest_time": 1.5,  # s, minimum still time before rest is declared
    "rest_tau_acc": 2.0,  # s, accelerometer low-pass time constant while at rest (gravity alone); 0 = tau_acc
    "bias_sigma0": 0.5 * _D2R,  # rad/s, initial bias σ
    "bias_rw": 0.003 * _D2R,  # rad/s/√s, bias random walk
    "bias_rest": 0.05 * _D2R,  # rad/s·√s, rest measurement noise density
    "bias_motion": 0.05 * _D2R,  # rad/s·√s, motion (tilt-correction rate) noise density; 0 = off
    "bias_clip": 2.0 * _D2R,  # rad/s, bias estimate bound (and of a motion update's innovation)
    "bias_loop": 2.0,  # -, the motion bias loop's time constant is at least this many tau_acc
    "motion_max_gyr": 0.0,  # rad/s, no motion bias update above this rate; 0 = no limit
    "motion_max_acc": 1.0,  # m/s², ... or when the low-passed |acc| is this far from g
    "motion_gate": 25.0,  # -, ... or when the correction rate is beyond this many σ of bias (sustained accel.); 0 = off
    "gravity": 9.81,  # m/s²
    "tau_mag": 10.0,  # s, heading correction time constant
    "mag_norm_th": 0.05,  # relative deviation of |m| from the reference
    "mag_dip_th": 5.0 * _D2R,  # rad, deviation of the dip angle from the reference
    "mag_new_time": 20.0,  # s, a steady new field becomes the reference after this time
    "tau_mag_ref": 30.0,  # s, averaging time of the learned reference
    "tau_mag_smooth": 20.0,  # s, offline: the heading offset's smoother (gyro-carried heading vs field); 0 = off
    "hard_iron_tau": 10.0,  # s, averaging time of a body-fixed field offset fitted while disturbed; 0 = off
    "mag_current_tau": 0.05,  # s, low-pass of the field's norm and dip seen by the new-field candidate; 0 = none
    "latency": 0.0,  # s, how late the IMU's samples are: the output is predicted that far ahead
    "tau_pol": 2.0,  # s, heading correction time constant of skylight polarization (pol=)
    "mag_pol_th": 10.0 * _D2R,  # rad, a field's azimuth this far from the heading polarization holds: unused; 0 = off
    "declination": 0.0,  # rad, magnetic north's angle east of true north (WMM's sign): the magnetometer's heading true
}

#: the estimators of :func:`optinav.attitude.estimate`
METHODS = ("iframe", "qn", "gd", "cg", "mekf")

#: default options per method (units in the comments; see the class docstrings)
DEFAULTS: dict[str, dict[str, float]] = {
    "iframe": IFRAME_DEFAULTS,
    # β (rad/s): Madgwick's gain; 0.033 is ahrs's default for gyro+acc
    "gd": {"gain": 0.033, "pol_weight": 1.0},
    "cg": {"gain": 0.033, "restart": 10, "pol_weight": 1.0},
    # β₀ (1/s) base rate of the correction, κ (1/rad) its growth with ‖q̇‖ (rad/s), max step (fraction), g (m/s²),
    # ε (m/s²) accelerometer state threshold, step factor beyond it, BFGS reset bound on trace(H)
    "qn": {
        "gain": 0.5,
        "rate_gain": 0.3,
        "max_step": 0.5,
        "gravity": G_STANDARD,
        "acc_threshold": 0.8,
        "acc_shrink": 0.1,
        "h_reset": 100.0,
        "pol_weight": 1.0,
    },
    # σ_g rad/s/√Hz, σ_b rad/s²/√Hz, σ_a 1/√Hz (the measured gravity direction's noise density: a sample's σ is
    # σ_a·√(1/dt), so the trust in the accelerometer per second does not depend on the rate), σ_α rad (per
    # polarization sample), g, ε m/s², inflation, initial σ (rad, rad/s),
    # bound on the heading σ (rad) while no heading measurement is used (a heading error is at most π), and
    # couple_heading 0/1: 1 lets the gravity update correct the heading through its correlation with the bias
    "mekf": {
        "gyro_noise": 0.002,
        "bias_noise": 5e-5,
        "acc_noise_density": 0.01,
        "pol_noise": np.radians(1.0),
        "gravity": G_STANDARD,
        "acc_threshold": 0.8,
        "acc_inflate": 5.0,
        "init_att_std": 0.05,
        "init_bias_std": 0.01,
        "max_heading_std": np.pi,
        "couple_heading": 0.0,
    },
}


def variant(method: str, *, offline: bool = False, input_stage: bool = True) -> str:
    """Which variant of ``method`` ran, as every output names it: ``"qn with the input stage"``, ``"qn as
    published"`` (gd/cg/qn/mekf without it), ``"iframe"`` or ``"iframe offline"`` (its front end is built in)."""
    if method == "iframe":
        return "iframe offline" if offline else "iframe"
    return f"{method} with the input stage" if input_stage else f"{method} as published"


#: options a method divides by (a noise σ enters as 1/σ², g as 1/g): 0 is refused, not a division by zero
_DIVISORS = {"mekf": ("acc_noise_density", "pol_noise", "gravity", "acc_inflate"), "qn": ("gravity",)}
#: the smallest divisor whose 1/σ² is finite
_MIN_DIVISOR = 1.0 / np.sqrt(np.finfo(float).max)
#: options that take either sign, with the bound of their magnitude (a declination is an angle east or west)
_SIGNED = {("iframe", "declination"): np.pi}


#: options that were replaced: (method, old name) → (what changed, the remedy)
RENAMED = {
    ("mekf", "acc_noise"): (
        "mekf's option acc_noise (a per-sample σ, whose meaning changed with the sampling rate) is now "
        "acc_noise_density (1/√Hz, the same at every rate)",
        "pass acc_noise_density = acc_noise·√dt, e.g. acc_noise=0.1 at 100 Hz is acc_noise_density=0.01",
    ),
}


def _options(method: str, options: dict) -> dict:
    if method not in METHODS:
        raise OptinavError(f"unknown method {method!r}", f"use one of {', '.join(METHODS)}")
    opts = dict(DEFAULTS[method])
    for k, v in options.items():
        if (method, k) in RENAMED:
            raise OptinavError(*RENAMED[method, k])
        if k not in opts:
            raise OptinavError(
                f"option {k!r} does not apply to method {method!r}", f"valid options: {', '.join(sorted(opts))}"
            )
        try:
            fv = float(v)
        except (TypeError, ValueError):
            fv = float("nan")
        if (method, k) in _SIGNED:
            if not abs(fv) <= _SIGNED[method, k]:
                raise OptinavError(
                    f"option {k}={v!r} must be within ±{_SIGNED[method, k]:.6g} rad", f"pass {k} in rad, east positive"
                )
        elif not np.isfinite(fv) or fv < 0:
            raise OptinavError(f"option {k}={v!r} must be a finite non-negative number", f"pass a valid {k}")
        if k in _DIVISORS.get(method, ()) and not fv > _MIN_DIVISOR:
            raise OptinavError(f"option {k}={v!r} must be > 0 (the filter divides by it)", f"pass a positive {k}")
        opts[k] = fv
    if method == "mekf" and opts["max_heading_std"] <= 0:
        raise OptinavError("max_heading_std must be > 0", "pass a bound in rad, e.g. max_heading_std=3.14")
    if method == "mekf" and opts["couple_heading"] not in (0.0, 1.0):
        raise OptinavError(
            f"couple_heading={opts['couple_heading']:g} must be 0 or 1",
            "pass couple_heading=0 (heading from the gyro alone) or 1",
        )
    if method == "cg" and opts["restart"] < 1:
        raise OptinavError("restart must be >= 1", "pass restart=1 (plain gradient) or more")
    return opts


def _method(method, pol, mag: bool = False, offline: bool = False) -> str:
    """The estimator's name for ``method`` (None: the default, iframe; mekf with ``pol`` alone online; iframe, the
    one that takes both and the one with an offline mode, with ``pol`` and a magnetometer ``mag`` or ``offline``)."""
    if method is None:
        return "iframe" if pol is None or mag or offline else "mekf"
    return str(method).lower()


def declination_without_mag() -> OptinavError:
    """The refusal of a declination given without a magnetometer (it turns the field's heading only)."""
    return OptinavError(
        "a magnetic declination was given without a magnetometer: it turns only the magnetometer's heading",
        "add --mag (mag=), or drop --declination-deg (declination=)",
    )


def bias_clip(method: str, opts: dict, input_stage: bool) -> float | None:
    """The gyro bias (rad/s, per axis) the estimate tracks: iframe's ``bias_clip`` (``opts``), the front end's
    default before gd/cg/qn/mekf with the input stage; None where no iframe bias is estimated."""
    if method == "iframe":
        return float(opts["bias_clip"])
    return float(IFRAME_DEFAULTS["bias_clip"]) if input_stage else None
