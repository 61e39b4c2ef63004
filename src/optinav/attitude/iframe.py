"""``iframe``: attitude from gyro + accelerometer (+ magnetometer) filtered in an almost-inertial frame.

After VQF (Laidig & Seel, "VQF: Highly accurate IMU orientation estimation with bias estimation and magnetic
disturbance rejection", Information Fusion 91, 2023); written here from the paper's ideas:

* the bias-corrected gyro strapdown q_g = q_b^I defines an almost-inertial frame I in which gravity is
  nearly constant; the specific force is low-passed there (second-order Butterworth, time constant
  ``tau_acc`` s, independent of the sampling rate), so a horizontal acceleration that averages out over
  ``tau_acc`` does not tilt the estimate, whatever its norm;
* the tilt correction q_c turns the low-passed specific force onto the vertical: q_b^n = R_up(δ) ⊗ q_c ⊗ q_g;
* rest is detected from the deviation of gyro and accelerometer from their low-passes (thresholds in rad/s and
  m/s² over ``rest_time`` s); a 3-state Kalman filter estimates the gyro bias from rest (all three axes) and,
  in motion, from the tilt-correction rate (its horizontal part is −C_b^n δb, so rotations reveal every
  axis; at any rotation rate unless ``motion_max_gyr`` > 0 sets a limit); the bias is clipped at ``bias_clip``;
  at rest the specific force (gravity alone) is low-passed over ``rest_tau_acc`` s instead of ``tau_acc``;
* the magnetometer sets the heading correction δ (first-order, ``tau_mag`` s) when its norm and dip agree with
  a learned reference (``mag_norm_th`` relative, ``mag_dip_th`` rad); while disturbed the heading follows the
  gyro alone; a new steady field becomes the reference after ``mag_new_time`` s, or after as long as the
  reference was seen (at least ``tau_acc``), judged on norm and dip low-passed over ``mag_current_tau``; while
  disturbed, a body-fixed offset (a magnet on the board) is fitted over ``hard_iron_tau`` s with the heading's
  error (m − Cᵀe = Cᵀ∂e/∂φ·δφ + b) and, once the body has turned and tilted enough to tell them apart and the
  residual is small and below that of a field fixed in the room, the field less it goes through the same gates
  (the offline heading uses the measured fields only); ``declination`` (rad, east positive) is added to the
  field's azimuth wherever it is compared with a heading, so that the heading is the true one;
* skylight polarization: after each step the heading at which the predicted AoP equals the measured
  one (closed form, the root nearest the current heading) moves δ with a running mean growing to ``tau_pol`` s
  (:func:`_iframe._pol_update`), beside the magnetometer's corrections; offline both passes take it, the forward
  pass's running time in the fusion counts from its first polarization sample, and the heading is the fused
  passes' (no smoother, no 6D gyro heading);
* the motion bias update closes a loop through the low-pass: its innovation is clipped at ``bias_clip`` and its
  variance floored so that the loop is never faster than ``bias_loop`` × ``tau_acc`` (a start in motion); a
  correction rate beyond ``motion_gate`` σ of what the bias uncertainty explains is a sustained acceleration (a
  vehicle's turn), not bias, and updates nothing;
* start: the low-passes begin as the running mean of the first ``tau_acc`` seconds (as VQF's), so a recording
  that starts in motion is not levelled by its first, accelerated sample; the magnetic reference is the mean of
  the second half of that time, the heading follows the field (low-passed over 0.2 s) until then and converges from then on with a
  gain of 1/n growing to ``tau_mag`` (over every sample for the first ``tau_mag`` s); the magnetometer's
  start-up runs on its own age (from its first finite sample: one that starts late gets it too), and each of
  its samples weighs the time since the previous one (a magnetometer slower than the IMU, NaN rows between);
* offline (:func:`estimate_iframe` with ``offline=True``): a forward pass, a backward pass over the reversed
  recording started from the forward end state (so its bias has seen the whole recording; the reversed gyro
  is negated, so is its bias), and the two estimates fused (weighted mean of the error rotation, each pass by
  its running time, :func:`backward_share`): the forward pass lags the low-pass, the backward pass leads. Then a
  zero-phase refinement: the specific force in the almost-inertial frame of the smoothed bias, low-passed
  forward and backward (Butterworth, same ``tau_acc``, each end extended by its first ``tau_acc`` s' mean), gives
  a lag-free up direction; the fused estimate is turned halfway towards it (tilt only). Without a magnetometer
  the heading is then the gyro's with :func:`blended_bias` (each pass's bias where that pass has run longer).
  With a magnetometer the heading is the gyro's (the strapdown of the smoothed bias, :func:`gyro_heading`) plus
  its offset to the field's azimuth, a random walk smoothed by a Kalman filter and its Rauch–Tung–Striebel pass
  over the samples
  both passes used (:func:`measured_used`): time constant ``tau_mag_smooth`` with a perfect gyro, shorter where the forward pass's
  vertical bias differs from the smoothed one (that difference over ``tau_mag_smooth`` against the azimuth's
  scatter), plus the heading a constant error δb of the smoothed bias turns (Φᵀδb, Φ = ∫up_b dt; δb from the
  whole recording, its prior the bias filter's covariance plus the forward bias's scatter about the smoothed
  one: a recording that starts in motion has no rest to fix the vertical bias); a disturbed stretch the gates
  reject is carried by the gyro.
* lost samples (a step beyond 1.75 typical steps, shorter than the gaps :func:`optinav.attitude.checks.find_gaps`
  refuses): the low-passes take the step in sub-steps of the typical step, their input interpolated, so that
  their memory keeps its spacing; a gap of 0.05 s or more restarts them as at the start (the running mean over
  the next ``tau_acc`` s), since the gyro's turn across it is a guess;
* timing: gyr[k] is integrated over (t[k−1], t[k]] and the output is the attitude at t[k] (as VQF); an IMU
  whose samples are late by a known ``latency`` (s, e.g. its low-pass group delay; default 0) gets the output
  predicted that far ahead with the bias-corrected rate, q ⊗ exp((ω − b)·latency) (offline: once, after the
  smoothing).

Frames: ``q`` = q_b^n [w, x, y, z]; ``frame`` NED or ENU (the up and north vectors are the only frame input,
so the estimator is frame-equivariant).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optinav.attitude import _iframe as _k
from optinav.attitude.checks import GAP_TURN, LOST_STEPS, StartChecks, gap_limit, lost_turns, lost_warning
from optinav.attitude.methods import IFRAME_DEFAULTS
from optinav.core.rotations import DEFAULT_FRAME, frame_name
from optinav.errors import OptinavError

__all__ = [
    "IFRAME_DEFAULTS",
    "AttitudeFilter",
    "FilterRun",
    "IframeRun",
    "run_iframe",
    "input_stage",
    "hard_iron_online",
    "online_fit_state",
    "online_fit_held",
]

_ORDER = (
    "tau_acc",
    "rest_tau",
    "rest_gyr",
    "rest_acc",
    "rest_time",
    "bias_sigma0",
    "bias_rw",
    "bias_rest",
    "bias_motion",
    "bias_clip",
    "motion_max_gyr",
    "motion_max_acc",
    "gravity",
    "tau_mag",
    "mag_norm_th",
    "mag_dip_th",
    "mag_new_time",
    "tau_mag_ref",
)  # then latency, bias_loop, mag_current_tau, motion_gate, hard_iron_tau, rest_tau_acc at P_LATENCY … P_REST_TAU_ACC
_POSITIVE = ("tau_acc", "rest_tau", "bias_rest", "gravity", "tau_mag", "tau_mag_ref", "tau_pol")

#: the largest ``latency`` (s) taken: the output is predicted that far with the gyro, which only holds for a
#: delay far shorter than the motion's time scale
MAX_LATENCY = 1.0

_NORTH = {"ned": np.array([1.0, 0.0, 0.0]), "enu": np.array([0.0, 1.0, 0.0])}
_UP = {"ned": np.array([0.0, 0.0, -1.0]), "enu": np.array([0.0, 0.0, 1.0])}


def _params(frame: str, opts: dict) -> np.ndarray:
    for k in _POSITIVE:
        if not opts[k] > 0:
            raise OptinavError(f"option {k}={opts[k]!r} must be > 0", f"pass a positive {k}")
    p = np.zeros(_k.PAR_SIZE)
    p[: len(_ORDER)] = [opts[k] for k in _ORDER]
    frame = frame_name(frame)
    p[_k.P_UP : _k.P_UP + 3] = _UP[frame]
    p[_k.P_NORTH : _k.P_NORTH + 3] = _NORTH[frame]
    if not (np.isfinite(opts["latency"]) and 0.0 <= opts["latency"] <= MAX_LATENCY):
        raise OptinavError(
            f"option latency={opts['latency']!r} s must be within 0…{MAX_LATENCY:g} s (an IMU's delay is milliseconds)",
            "pass the IMU's delay in s, e.g. latency=0.002, or 0",
        )
    p[_k.P_LATENCY] = opts["latency"]
    p[_k.P_BIAS_LOOP] = opts["bias_loop"]
    p[_k.P_MAG_CUR_TAU] = opts["mag_current_tau"]
    p[_k.P_MOTION_GATE] = opts["motion_gate"]
    p[_k.P_HI_TAU] = opts["hard_iron_tau"]
    p[_k.P_REST_TAU_ACC] = opts["rest_tau_acc"]
    p[_k.P_TAU_POL] = opts["tau_pol"]
    p[_k.P_MAG_POL_TH] = opts["mag_pol_th"]
    p[_k.P_DECLINATION] = opts["declination"]
    return p


def _new_state(opts: dict, q0=None, heading0: float = 0.0, other_root: bool = False) -> np.ndarray:
    """A state before the first sample: from ``q0`` (q_g = identity, q_c = q0, δ = 0; the tilt's low-pass from the
    gravity q0 predicts, the other memories from acc[0]: :func:`_iframe._init`), else levelled then, δ =
    ``heading0`` (rad, a turn about up: the polarization's first used sample takes the AoP's root nearest it, or
    with ``other_root`` the other one, the other heading branch)."""
    st = np.zeros(_k.STATE_SIZE)
    st[_k.S_P : _k.S_P + 9] = (np.eye(3) * opts["bias_sigma0"] ** 2).ravel()
    if q0 is not None:
        st[_k.S_QC : _k.S_QC + 4] = q0
    else:
        st[_k.S_DELTA], st[_k.S_P_OTHER] = heading0, float(other_root)
    return st


@dataclass
class FilterRun:
    """Per-sample outputs of a chunk of samples, the same type for every method (``update_batch`` of each
    streaming filter, :func:`run_iframe`); an output the method does not have is None.

    ``q_b_n`` (N, 4) q_b^n [w, x, y, z]; ``rest`` (N,) bool, rest detected (the input stage's for gd/cg/qn/mekf);
    ``acc_used``/``mag_used`` (N,) bool, the accelerometer / magnetometer sample corrected the attitude (iframe's
    decisions; ``mag_used`` None where no magnetometer was given, as in the estimate); ``gyr_bias`` (N, 3) rad/s, the gyro-bias estimate
    after each sample (mekf: the input stage's plus its own state); ``state`` iframe's final state;
    ``att_std`` (N, 3) rad, mekf's attitude-error σ about the body axes; ``mag_offset`` (N, 3), magnetometer
    unit, iframe's body-fixed field offset the sample's field was used less (0 where used as measured or not
    used); ``pol_used`` (N,) bool, the polarization sample corrected iframe's heading (None without ``pol``), and
    ``pol_skipped`` the chunk's polarization samples left out by reason. The names are those of
    :class:`~optinav.attitude.AttitudeEstimate`, whose ``gyr_bias`` is the last row's and ``pol_used`` a count.
    """

    q_b_n: np.ndarray
    rest: np.ndarray | None = None
    acc_used: np.ndarray | None = None
    mag_used: np.ndarray | None = None
    gyr_bias: np.ndarray | None = None
    state: np.ndarray | None = None
    att_std: np.ndarray | None = None
    mag_offset: np.ndarray | None = None
    pol_used: np.ndarray | None = None
    pol_skipped: dict | None = None

    @property
    def offset_used(self) -> np.ndarray | None:
        """The samples (N,) whose field was used less a fitted body-fixed offset (its row of ``mag_offset`` not 0);
        None without ``mag_offset``."""
        return None if self.mag_offset is None else self.mag_offset.any(axis=1)


#: the name of :class:`FilterRun` while only iframe's chunks returned one
IframeRun = FilterRun


def _run(st, par, gyr, acc, mag, dts, restart: int = -1) -> FilterRun:
    n = gyr.shape[0]
    out = np.empty((n, 4))
    flags = np.empty((n, 4), np.int8)
    bias = np.empty((n, 3))
    moff = np.empty((mag.shape[0], 3))
    _k.run(st, par, gyr, acc, mag, dts, out, flags, bias, moff, restart)
    f = flags.astype(bool)
    return FilterRun(out, f[:, 0], f[:, 1], f[:, 2], bias, st, mag_offset=moff if mag.shape[0] else None)


def _run_pol(st, par, gyr, acc, mag, dts, pin, restart: int = -1, code=None) -> FilterRun:
    """:func:`_run` with the polarization correcting the heading (:func:`_iframe.run_pol`), ``pin`` its kernel inputs
    for the N samples (:func:`~optinav.attitude.measurement.pol_inputs`); its use and skipped counts in
    ``pol_used``/``pol_skipped``, each sample's POL_* outcome in ``code`` (N,) int8 where given."""
    use, sn, cbm, aop, min_d2, skipped = pin
    n = gyr.shape[0]
    out, flags, bias = np.empty((n, 4)), np.empty((n, 4), np.int8), np.empty((n, 3))
    moff, code = np.empty((mag.shape[0], 3)), np.empty(n, np.int8) if code is None else code
    _k.run_pol(st, par, gyr, acc, mag, dts, use, sn, cbm, aop, min_d2, out, flags, bias, moff, code, restart)
    f = flags.astype(bool)
    return FilterRun(
        out, f[:, 0], f[:, 1], f[:, 2], bias, st, mag_offset=moff if mag.shape[0] else None,
        pol_used=code == _k.POL_USED, pol_skipped=pol_skipped(skipped, code),
    )  # fmt: skip


def _pass(st, par, gyr, acc, mag, dts, pin=None, code=None) -> FilterRun:
    """One pass over the samples: :func:`_run`, or :func:`_run_pol` with the polarization inputs ``pin``."""
    return _run(st, par, gyr, acc, mag, dts) if pin is None else _run_pol(st, par, gyr, acc, mag, dts, pin, code=code)


def pol_skipped(skipped: dict, code) -> dict:
    """The polarization samples left out, by reason: those the inputs left out (``skipped``) and those whose
    outcome ``code`` (N,) (:data:`_iframe.POL_UNRESOLVED`, :data:`_iframe.POL_NEAR_ZENITH`) says so."""
    out = dict(skipped)
    out["heading_unresolved"] = int(np.count_nonzero(code == _k.POL_UNRESOLVED))
    out["sun_near_sensor_zenith"] = int(np.count_nonzero(code == _k.POL_NEAR_ZENITH))
    return out


def reversed_pol(pin):
    """The polarization inputs ``pin`` (:func:`~optinav.attitude.measurement.pol_inputs`) of the time-reversed
    recording: sample N−1−k at reversed step k, as :func:`_reverse` orders the IMU's (an AoP depends on the
    attitude and the sun at its sample, not on the direction of time: :func:`_iframe._pol_update`)."""
    use, sn, cbm, aop, min_d2, skipped = pin
    sn = sn[::-1] if sn.shape[0] > 1 else sn
    return use[::-1].copy(), np.ascontiguousarray(sn), cbm, aop[::-1].copy(), min_d2, skipped


def either_pass(fwd_code, bwd_used) -> np.ndarray:
    """The offline outcome (N,) int8 of each polarization sample: POL_USED where either pass used it (both feed the
    fused heading), else the forward pass's (``fwd_code`` (N,); ``bwd_used`` (N,) bool in forward order)."""
    return np.where(bwd_used, _k.POL_USED, fwd_code).astype(np.int8)


def first_pol_time(t, pol_used) -> float:
    """s, the elapsed time ``t`` (N,) of the forward pass's first polarization sample used (``pol_used`` (N,)): its
    heading before it is the start's guess (or the field's), so the offline fusion counts its running time from there
    (:func:`backward_share`); 0 where none was used (as without polarization)."""
    k = np.flatnonzero(pol_used)
    return float(t[k[0]]) if k.size else 0.0


def online_fit_state(measured: bool = False) -> np.ndarray:
    """A new state (:data:`_iframe.HF_SIZE`) of :func:`hard_iron_online`'s fit: before it passes its gates the
    magnetometer rows given as measured (``measured``: the heading from them until then, off by what the offset
    turns it) or NaN (the field unused, the heading the gyro's from the start)."""
    fs = np.zeros(_k.HF_SIZE)
    fs[_k.HF_MEASURED] = float(measured)
    return fs


def hard_iron_online(mag, dts, fit=None, gyr=None) -> tuple[np.ndarray, np.ndarray]:
    """The magnetometer (N, 3, any unit) less its hard-iron offset fitted online, each row from itself and the rows
    before it (:func:`_iframe.hard_iron_online`: the sphere fit of :func:`optinav.attitude.checks.hard_iron` as
    running moments over the rows where the gyro ``gyr`` (N, 3) [rad/s] turns faster than
    :data:`~optinav.attitude.checks.STILL_RATE` (None: every row), solved every 0.25 s of the steps ``dts`` (s, 1
    or N), used once it passes the same gates with every body axis turned about and the corrected norm as steady
    as a calibrated one, and restarted from the recent rows when they show another offset; before, NaN or the rows
    as measured (:func:`online_fit_state`; :func:`_iframe.first_fitted_row`), NaN while another offset explains the
    recent rows but is not fitted yet: :func:`online_fit_held`); and the fit's state ``fit``
    (:func:`online_fit_state` when None, else continued in place)."""
    fs = online_fit_state() if fit is None else fit
    out = np.empty(mag.shape)
    w = np.zeros((0, 3)) if gyr is None else np.ascontiguousarray(gyr, dtype=float)
    _k.hard_iron_online_run(fs, np.ascontiguousarray(mag, dtype=float), np.ascontiguousarray(dts, dtype=float), w, out)
    return out, fs


def online_fit_result(fs) -> tuple[np.ndarray | None, int | None]:
    """(offset (3,) fitted online, the row from which the field was used less it) of the fit state ``fs``; (None,
    None) while it has not passed its gates."""
    if not fs[_k.HF_OK]:
        return None, None
    return fs[_k.HF_B : _k.HF_B + 3].copy(), int(fs[_k.HF_FROM])


def online_fit_held(fs) -> tuple[int, float] | None:
    """(row, s) of the fit state ``fs``: the sample from which the field has been left unused, as it no longer fits
    the offset in use and the samples since have not fitted another (:func:`_iframe.hard_iron_online`), and for how
    long; None while the offset in use fits."""
    if not fs[_k.HF_HELD]:
        return None
    return int(fs[_k.HF_OPEN_ROW]), float(fs[_k.HF_OPEN_T])


def _reverse(gyr, acc, mag, dts):
    """Time-reversed inputs: reversed step k goes from sample N−k to N−1−k with −ω_{N−k} over dt_{N−k}."""
    g = np.empty_like(gyr)
    g[0] = 0.0
    g[1:] = -gyr[:0:-1]
    d = dts if dts.shape[0] == 1 else np.concatenate([dts[-1:], dts[:0:-1]])
    return g, acc[::-1].copy(), (mag[::-1].copy() if mag.shape[0] else mag), np.ascontiguousarray(d)


def reversed_state(state: np.ndarray) -> np.ndarray:
    """The forward pass's end state as the backward pass's start: the bias negated (the reversed gyro reads
    −ω − b), and each Butterworth memory (the specific force's and C_b^I's) held at its last output. Its two past
    inputs and outputs carry the forward slope, which reversed time turns around: the backward pass of a
    recording that ends in motion took ~10 s to settle from it (tilt 5° off at 4 s before the end: offline 1.69°
    against online 0.55° on BROAD trial 16 cut 5 s into its motion)."""
    st = state.copy()
    st[_k.S_BIAS : _k.S_BIAS + 3] *= -1.0
    for base, n in ((_k.S_LP, 3), (_k.S_LPC, 9)):
        for j in range(n):
            m = base + 4 * j
            st[m] = st[m + 1] = st[m + 3] = st[m + 2]
    return st


def backward_share(t, t_end: float, h_last: float, tau: float, t_start: float = 0.0) -> np.ndarray:
    """Weight (N,) of the backward estimate in the offline fusion at the elapsed times ``t`` (s, the sum of the
    steps up to each sample; ``t_end`` the last one, ``h_last`` the last step): each pass is weighted by how long
    it has run, 1 − exp(−t/(SETTLE_TAUS·τ)) (τ = ``tau_acc``) — ½ in the middle, the backward pass alone at the
    start, where the forward one is still settling (a recording that starts in motion), and the forward pass at
    the end. The forward pass's time counts from ``t_start`` (s; its first polarization sample: its heading before
    is a guess), the backward pass alone before it."""
    s = SETTLE_TAUS * tau
    wf = -np.expm1(-np.maximum(np.asarray(t, float) - t_start, 0.0) / s)
    wb = -np.expm1(-(t_end - np.asarray(t, float) + h_last) / s)
    return wb / (wf + wb)


#: a pass's start-up lasts a few ``tau_acc``: its second-order Butterworth low-pass settles (to 2 %) in about
#: 4 τ; weighted by 1 − exp(−t/τ), a backward pass begun in motion was blended in at 40 % 5 s after its start,
#: while still degrees off (eight cuts of BROAD trials ending or starting in motion: 0.73 → 0.69°; the nine
#: whole trials, which start and end at rest, unchanged)
SETTLE_TAUS = 3.0


def blended_bias(b_fwd, b_smooth, share) -> np.ndarray:
    """The offline 6D heading's gyro bias (N, 3) rad/s: the forward pass's ``b_fwd`` where it has run longer, the
    backward pass's ``b_smooth`` where that one has, by :func:`backward_share` ``share`` (N,). The heading of the
    fused attitudes came from the forward pass at the end and the backward one at the start, which carried the
    forward end's heading back with its own bias: on BROAD's cuts that start in motion it drifted more than the
    online heading (30 s into the motion: 7.8° against 5.6° RMSE), and on simulated vehicle flights twice as much.
    Strapped down with this bias from the first attitude (:func:`gyro_heading`): 6.2 / 4.3 / 2.6° on the cuts 10 /
    30 / 60 s into the motion (fused 7.6 / 7.8 / 2.9°, online 9.1 / 5.6 / 9.7°, VQF offline 8.7 / 6.6 / 3.8°)."""
    return np.ascontiguousarray(b_fwd + np.asarray(share)[:, None] * (b_smooth - b_fwd))


def _fuse(qf, qb, share):
    """Weighted mean of the forward and backward estimates: exp(w·log(q_b ⊗ q_f*)) ⊗ q_f, w = ``share`` (N,)."""
    from optinav.core.rotations import quat_conjugate, quat_from_rotvec, quat_multiply, rotvec_from_quat

    r = rotvec_from_quat(quat_multiply(qb, quat_conjugate(qf)))
    return quat_multiply(quat_from_rotvec(np.asarray(share, float)[:, None] * r), qf)


def run_iframe(
    gyr,
    acc,
    dts,
    *,
    mag=None,
    pol=None,
    frame: str = DEFAULT_FRAME,
    q0=None,
    offline: bool = False,
    other_root: bool = False,
    **options,
) -> FilterRun:
    """Run the estimator on checked (N, 3) float arrays; ``dts`` (1,) or (N,) s; ``mag`` (N, 3) any unit or
    None; ``pol`` a :class:`~optinav.attitude.PolarizationMeasurement` or None; without ``q0`` the polarization's
    first used sample takes the AoP's root nearest the start's heading, or with ``other_root`` the other one (the
    other heading branch, :mod:`optinav.attitude.branch`). Options override :data:`IFRAME_DEFAULTS`."""
    from optinav.attitude.measurement import pol_inputs

    opts = dict(IFRAME_DEFAULTS)
    opts.update(options)
    par = _params(frame, opts)
    # one layout for the kernel: a view (a column block of a table) would compile it again, ~10 s
    gyr, acc = np.ascontiguousarray(gyr, dtype=float), np.ascontiguousarray(acc, dtype=float)
    m = np.zeros((0, 3)) if mag is None else np.ascontiguousarray(mag, dtype=float)
    n = gyr.shape[0]
    pin = None if pol is None else pol_inputs(pol, n, frame, "the IMU")
    if not offline:
        r = _pass(_new_state(opts, q0, other_root=other_root), par, gyr, acc, m, dts, pin)
        r.mag_used = None if mag is None else r.mag_used
        return r
    # the passes estimate the attitude at the sample times; the latency is applied once, to the smoothed result
    lat = par[_k.P_LATENCY]
    par[_k.P_LATENCY] = 0.0
    code = np.empty(n, np.int8)
    fwd = _pass(_new_state(opts, q0, other_root=other_root), par, gyr, acc, m, dts, pin, code)
    # the reversed recording sees the gyro negated, so its bias is −b: start the backward pass from the forward
    # end state with the bias negated, and negate it back; the backward bias at t has seen the whole recording
    # (the forward pass's end state and the samples from t on), the forward one only the samples before t. The
    # polarization's samples go backward too, from the forward end's heading
    st = reversed_state(fwd.state)
    bwd = _pass(st, par, *_reverse(gyr, acc, m, dts), None if pin is None else reversed_pol(pin))
    bias = -bwd.gyr_bias[::-1]
    h = np.broadcast_to(dts, (n,))
    t = np.cumsum(h)
    t0 = 0.0 if pin is None else first_pol_time(t, fwd.pol_used)
    share = backward_share(t, t[-1], h[-1], opts["tau_acc"], t0)
    q = _fuse(fwd.q_b_n, bwd.q_b_n[::-1], share)
    qg = np.empty((n, 4))
    # started at the first attitude, not the identity: q ⊗ q_g* then stays near the identity and its twist about
    # up (gyro_heading) is defined whatever the mounting (an upside-down body made it a 180° tilt, undefined)
    _k.strapdown(gyr, np.ascontiguousarray(bias), dts, qg, q[0].copy())
    q = _zero_phase_tilt(q, qg, acc, dts, frame, opts["tau_acc"])
    used = measured_used(fwd) & measured_used(bwd)[::-1]
    held = pin is not None and bool(fwd.pol_used.any() or bwd.pol_used.any())  # polarization holds the heading
    if not m.shape[0] and not held and refinable(acc):
        # 6D: the heading the gyro carries with each pass's bias where that pass has run longer
        _k.strapdown(gyr, blended_bias(fwd.gyr_bias, bias, share), dts, qg, q[0].copy())
        psi = gyro_heading(q, qg, frame)
        q = heading_turned(q, psi - psi[0], frame)  # from the first attitude's heading (q_g[0] has turned once)
    # with polarization the heading is the fused passes' (each holds it to the AoP): smoothing the gyro-carried
    # heading's offset to the AoP's, as the field's, ran at 0.45° on BROAD's nine with synthesized AoP against
    # 0.37° online and 0.31° fused
    earth = used
    if m.shape[0] and not held and opts["tau_mag_smooth"] > 0.0 and used.any():
        nd = norm_dip(q, m, frame)  # the fields the heading takes: those with the Earth's norm and dip
        earth = used & earth_like(*nd, (np.median(nd[0][used]), np.median(nd[1][used])), opts)
    if m.shape[0] and not held and opts["tau_mag_smooth"] > 0.0 and earth.any():
        tau = opts["tau_mag_smooth"]
        psi = gyro_heading(q, qg, frame)
        d = field_azimuth(q, m, frame, opts["declination"]) - psi  # in the attitude whose heading the gyro carries
        db = np.ascontiguousarray(fwd.gyr_bias - bias)
        sb = bias_gap(q, db, frame)
        out = _smoothed_offset(d, earth, sb, dts, tau, 0.0)
        acc, mom = np.zeros(2), np.zeros(10)
        _k.azimuth_scatter(d, out, earth, acc)
        _k.outer_sum(db, mom)
        pb = bias_prior(bwd.state[_k.S_P : _k.S_P + 9], mom)
        u = np.ascontiguousarray(body_up(q, frame))
        out = psi + _smoothed_offset(d, earth, sb, dts, tau, acc[0] / acc[1], u, pb)
        q = heading_turned(q, out, frame)
    if lat != 0.0:
        from optinav.core.rotations import quat_from_rotvec, quat_multiply

        q = quat_multiply(q, quat_from_rotvec((gyr - bias) * lat))
    pol_used = skipped = None
    if pin is not None:
        code = either_pass(code, bwd.pol_used[::-1])
        pol_used, skipped = code == _k.POL_USED, pol_skipped(pin[5], code)
    return FilterRun(
        q, fwd.rest | bwd.rest[::-1], fwd.acc_used, None if mag is None else used, bias, fwd.state,
        pol_used=pol_used, pol_skipped=skipped,
    )  # fmt: skip


def measured_used(r: FilterRun) -> np.ndarray:
    """The samples (N,) whose field a pass used as measured. The offline heading takes only those both passes used:
    the gyro with the smoothed bias carries it through a disturbance better than the field less a fitted body-fixed
    offset (its azimuth off by ±3° over seconds in motion on BROAD trial 33, as the measured field's is), and a
    pass that starts in a disturbance takes its field for the Earth's until the reference moves (BROAD 33 cut from
    60 or 70 s, in its magnet: offline heading RMSE 18–21° with the samples either pass used, 1.6–2.3° with those
    both used)."""
    return r.mag_used if r.mag_offset is None else r.mag_used & ~r.offset_used


#: the offline heading takes a field its passes used only within this many times the gates (``mag_norm_th``,
#: ``mag_dip_th``) of the Earth's field as the recording shows it (:func:`earth_like`)
EARTH_GATES = 2.0


def norm_dip(q, mag, frame) -> tuple[np.ndarray, np.ndarray]:
    """The field's norm (N,) [its unit] and dip (N,) rad (its angle above the horizontal: up positive) in the
    attitudes ``q`` (N, 4) of the magnetometer ``mag`` (N, 3)."""
    norm = np.linalg.norm(mag, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return norm, np.arcsin(np.clip(np.sum(body_up(q, frame) * mag, axis=1) / norm, -1.0, 1.0))


def earth_like(norm, dip, ref, opts: dict) -> np.ndarray:
    """The samples (N,) whose field (``norm``, ``dip`` of :func:`norm_dip`) is the Earth's — ``ref`` (norm, dip),
    the medians over the samples both offline passes used — within :data:`EARTH_GATES` × the gates. A pass learns
    a steady new field as its reference after ``mag_new_time`` (online the heading then goes on from it), and both
    passes used a disturbed field so where the recording ends at rest beside a monitor or a steel desk: its
    azimuth, taken for magnetic north by the offline heading, turned BROAD 02, 11 and 24 with such a field (+8, −5,
    6 µT, ENU) in their final rest by 4.9-17.7° (online 0.7-1.4°, VQF offline 1.0-1.2°); 1.1, 0.6, 3.6° now."""
    with np.errstate(invalid="ignore"):
        return (np.abs(norm / ref[0] - 1.0) <= EARTH_GATES * opts["mag_norm_th"]) & (
            np.abs(dip - ref[1]) <= EARTH_GATES * opts["mag_dip_th"]
        )


def field_azimuth(q, mag, frame, declination: float = 0.0) -> np.ndarray:
    """Azimuth (N,) rad of the magnetometer's horizontal field in the navigation frame of the attitudes ``q``
    (N, 4), from north toward west (positive about up), plus the ``declination`` (rad, east positive: the field
    lies that far east of true north): the heading error the field shows (as :func:`_iframe._dip_azimuth`)."""
    from optinav.core.rotations import quat_rotate

    f = frame_name(frame)
    up, north = _UP[f], _NORTH[f]
    v = quat_rotate(q, mag)
    return np.arctan2(v @ np.cross(up, north), v @ north) + declination


def _smoothed_offset(d, used, sb, dts, tau, sa2, u=None, pb=None):
    """The offline heading offset (N,) rad: :func:`_iframe.heading_forward`, then its RTS pass; with the body up
    vectors ``u`` (N, 3) and the prior ``pb`` (3, 3) of the gyro-bias error (:func:`bias_prior`), plus the heading
    the estimated error turns (:func:`bias_error`)."""
    n = d.shape[0]
    m = 0 if u is None else n
    x, p, out = np.empty(n), np.empty(n), np.empty(n)
    xr, phi, outr, normal = np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 3)), np.zeros(12)
    reg = np.zeros((0, 3)) if u is None else u
    _k.heading_forward(d, reg, used, sb, dts, tau, sa2, np.zeros(9), x, p, xr, phi, normal)
    _k.heading_backward(x, p, xr, sb, dts, tau, sa2, np.zeros(6), out, outr)
    if u is not None:
        out += bias_turn(phi - outr, bias_error(normal, pb, sa2, tau))
    return out


def bias_turn(dphi, db) -> np.ndarray:
    """Heading (N,) rad that the gyro-bias error ``db`` (3,) rad/s turns over ``dphi`` (N, 3) s (Φ minus its
    smoothed value), row by row in a fixed order (a log in blocks gives the same digits)."""
    return dphi[:, 0] * db[0] + dphi[:, 1] * db[1] + dphi[:, 2] * db[2]


def body_up(q, frame) -> np.ndarray:
    """The up direction (N, 3) in body axes of the attitudes ``q`` (N, 4): the axis about which a gyro-bias error
    turns the heading (its rate is up_bᵀ δb)."""
    from optinav.core.rotations import quat_conjugate, quat_rotate

    return quat_rotate(quat_conjugate(q), np.broadcast_to(_UP[frame_name(frame)], (q.shape[0], 3)))


def bias_prior(p_bias, moment) -> np.ndarray:
    """Covariance (3, 3) (rad/s)², body axes, of the smoothed gyro bias's error, the prior of the offline heading's
    δb: the bias filter's own (``p_bias`` (9,), the backward pass's at the first sample: the axes it could not see,
    e.g. vertical while the body stays level) plus the mean outer product of the forward pass's bias about the
    smoothed one (``moment`` (10,), :func:`_iframe.outer_sum`): where the two disagree, the filter's covariance
    is too small (BROAD cuts that start in motion: the smoothed vertical bias 0.2–0.8 °/s off, the filter's σ
    0.04–0.1 °/s, the two biases 0.3–0.5 °/s apart)."""
    p = np.asarray(p_bias, float).reshape(3, 3)
    if moment[9] > 0.0:
        p = p + np.asarray(moment[:9]).reshape(3, 3) / moment[9]
    return 0.5 * (p + p.T)


def bias_error(normal, pb, sa2: float, tau: float) -> np.ndarray:
    """δb (3,) rad/s: the gyro-bias error that the field's azimuth shows over the whole recording, from the
    normal equations ``normal`` (12,) of :func:`_iframe.heading_forward` (in its variance unit, the azimuth's
    scatter ``sa2`` rad² over ``tau`` s) and the prior ``pb`` (3, 3) (rad/s)²: (I + P₀A)⁻¹P₀b, P₀ in that unit.
    Zero without scatter (a field without noise gives no scale)."""
    if not sa2 > 0.0:
        return np.zeros(3)
    a = np.asarray(normal[:9]).reshape(3, 3)
    a = np.triu(a) + np.triu(a, 1).T
    p0 = np.asarray(pb, float) / (sa2 * tau)
    return np.linalg.solve(np.eye(3) + p0 @ a, p0 @ np.asarray(normal[9:]))


def bias_gap(q, db, frame) -> np.ndarray:
    """Vertical component (N,) rad/s of the gyro-bias difference ``db`` (N, 3, body axes) in the attitudes ``q``:
    how far the forward pass's bias is from the smoothed one about up — the uncertainty of the rate at which the
    gyro carries the heading (BROAD: 0.04 °/s on the whole trials, which start at rest; 0.3–0.5 °/s on cuts that
    start in motion, where the vertical bias is hardly observable)."""
    from optinav.core.rotations import quat_rotate

    return quat_rotate(q, db) @ _UP[frame_name(frame)]


def gyro_heading(q, qg, frame) -> np.ndarray:
    """Angle ψ (N,) rad about up that turns ``q`` (N, 4) to the heading the gyro carries: the twist about up of
    q ⊗ q_g* (q_g (N, 4) the strapdown of the smoothed bias from the first attitude, so that q ⊗ q_g* is near the
    identity: its twist is undefined at a 180° tilt); turned by −ψ, q ⊗ q_g* keeps only
    its tilt and the heading changes only as the bias-corrected gyro turns it (the offline heading's base: the
    passes' own magnetometer corrections, which followed a disturbed field wherever the gates let it through, are
    removed)."""
    from optinav.core.rotations import quat_conjugate, quat_multiply

    r = quat_multiply(q, quat_conjugate(qg))
    return 2.0 * np.arctan2(r[:, 1:] @ _UP[frame_name(frame)], r[:, 0])


def heading_turned(q, out, frame) -> np.ndarray:
    """``q`` (N, 4) turned about up by −``out`` (N,) rad (the offline heading correction; NaN, where no
    magnetometer sample was used at all: 0)."""
    from optinav.core.rotations import quat_from_rotvec, quat_multiply

    a = np.where(np.isfinite(out), out, 0.0)
    return quat_multiply(quat_from_rotvec(-a[:, None] * _UP[frame_name(frame)][None, :]), q)


#: the fewest samples the offline refinements (zero-phase tilt, 6D gyro heading) take
MIN_REFINE_ROWS = 16


def refinable(acc) -> bool:
    """Whether the offline refinements run on a recording with the accelerometer ``acc`` (N, 3): at least
    :data:`MIN_REFINE_ROWS` samples, every one finite (else the fused passes are the result)."""
    return acc.shape[0] >= MIN_REFINE_ROWS and bool(np.isfinite(acc).all())


def _zero_phase_tilt(q, qg, acc, dts, frame, tau):
    """Offline tilt refinement: the specific force low-passed in the almost-inertial frame ``qg`` (N, 4) of the
    smoothed bias (:func:`_iframe.strapdown`) with a zero-phase (forward–backward) Butterworth filter of the same time constant, its input extended at each
    end by the mean of that end's first ``tau`` s (:func:`edge_rows`), gives the up direction without lag; ``q``
    is turned halfway towards it (a tilt-only rotation, the heading is kept). Skipped when the recording is too
    short or the accelerometer has non-finite samples."""
    from scipy.signal import filtfilt

    from optinav.core.rotations import quat_conjugate, quat_rotate

    n = qg.shape[0]
    if not refinable(acc):
        return q
    b, a, pad = zero_phase_filter(dts, tau, n)
    x = quat_rotate(qg, acc)
    k0 = edge_rows(dts, tau, pad)
    left, right = np.repeat(x[:k0].mean(axis=0)[None], pad, 0), np.repeat(x[-k0:].mean(axis=0)[None], pad, 0)
    lp = filtfilt(b, a, np.concatenate([left, x, right]), axis=0, padtype=None)[pad : pad + n]
    up_b = quat_rotate(quat_conjugate(qg), lp)
    if not np.all(np.linalg.norm(up_b, axis=1) > 0.0):
        return q
    return tilt_halfway(q, up_b, frame)


def edge_rows(dts, tau: float, pad: int) -> int:
    """Rows whose mean pads each end of the zero-phase filter's input: the first (last) ``tau`` s, at most
    ``pad`` + 1. A constant extension at the ends' mean, not a reflection: reflected, the filter's start took the
    edge samples' direction (1 s of BROAD's fast rotation: offline 11° against online 6° and VQF offline 1°),
    while the mean of a short recording's specific force in the almost-inertial frame is its up direction."""
    h = float(np.mean(dts))
    return int(max(1, min(pad + 1, np.ceil(tau / h))))


def zero_phase_filter(dts, tau: float, n: int) -> tuple[np.ndarray, np.ndarray, int]:
    """(b, a, padlen) of the offline refinement's Butterworth low-pass for a recording of ``n`` samples with the
    steps ``dts`` (s, 1 or n) and the time constant ``tau`` (s): the cutoff of the causal low-pass
    (rate-independent), at the mean step."""
    from scipy.signal import butter

    h = float(np.mean(dts))
    pad = int(min(n - 1, np.ceil(3.0 * tau / h)))
    fc = np.sqrt(2.0) / (2.0 * np.pi * tau)
    b, a = butter(2, min(2.0 * fc * h, 0.98))
    return b, a, pad


def tilt_halfway(q, up_b, frame):
    """``q`` (N, 4) turned halfway (tilt only) towards the up direction ``up_b`` (N, 3, body axes, non-zero)."""
    from optinav.core.rotations import quat_from_rotvec, quat_multiply, quat_rotate

    nrm = np.linalg.norm(up_b, axis=1)
    cur = quat_rotate(q, up_b / nrm[:, None])  # the zero-phase up, in n with the current estimate
    up = _UP[frame_name(frame)]
    ax = np.cross(cur, up)
    sn = np.linalg.norm(ax, axis=1)
    ang = np.arctan2(sn, cur @ up)
    rv = ax * (0.5 * ang / np.maximum(sn, 1e-300))[:, None]
    return quat_multiply(quat_from_rotvec(rv), q)


def input_stage(gyr, acc, dts, frame: str = DEFAULT_FRAME, **options) -> tuple[np.ndarray, np.ndarray, FilterRun]:
    """The iframe front end for other estimators: bias-corrected gyro (rad/s) and the specific force low-passed
    in the almost-inertial frame, expressed back in body axes (m/s²)."""
    r = run_iframe(gyr, acc, dts, frame=frame, **options)
    return (*front_outputs(r, gyr, acc, frame), r)


def front_outputs(r: FilterRun, gyr, acc, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """The input stage's (bias-corrected gyro, filtered specific force) of the samples ``r`` ran on."""
    # the low-passed specific force in n is (along) up; back to the body with the estimated attitude, scaled by
    # the measured norm so the published methods' norm checks still see the dynamics
    acc_f = np.empty((r.q_b_n.shape[0], 3))
    _k.front_force(r.q_b_n, _UP[frame_name(frame)], np.ascontiguousarray(acc, dtype=float), acc_f)
    return gyr - r.gyr_bias, acc_f


class StreamGaps:
    """Time gaps in a stream, the same for every method's streaming filter: a step beyond
    :func:`~optinav.attitude.checks.gap_limit` of the typical one (the filter's ``dt``; without it the step
    before, or a chunk's median) is refused with the state unchanged, as :func:`~optinav.attitude.estimate`
    refuses a gap: the gyro's turn across it is unknown. :meth:`reset` starts the estimate anew. A step beyond
    LOST_STEPS typical ones lost samples: where the turn across it is uncertain beyond GAP_TURN (|Δω|·dt/2, the
    gyro after it against the one before) it is refused alike, unless the filter was built with ``bridge_lost=True``
    (then bridged with a :class:`~optinav.attitude.checks.LostSamplesWarning`, as ``estimate(allow_gaps=True)``
    bridges them): a 0.2-s dropout in BROAD 07's motion, given with its step, ran on at 157° heading RMSE."""

    def _gaps_init(self) -> None:
        self._gap_check = True  # off where the caller cuts the gaps itself (a file's, judged on its whole median)
        # a step beyond _odd_s is judged (_judge_step): beyond LOST_STEPS typical steps (the filter's dt; without it
        # the step before, _prev) it lost samples, beyond gap_limit of one it is a gap
        self._odd_s = 0.0 if self.dt is None else LOST_STEPS * self.dt
        self._prev = math.inf

    def _last_gyro(self) -> np.ndarray | None:
        """The gyro sample (3,) rad/s before the next update (None before the first)."""
        raise NotImplementedError

    def _judge_step(self, h: float, gyr) -> None:
        """Refuse a step ``h`` (s) that is a time gap, or one that lost samples where the turn across it is
        uncertain beyond GAP_TURN (the gyro ``gyr`` (3,) rad/s after it against the one before: |Δω|·h/2) unless
        the filter bridges those (``bridge_lost``: then warned); the state unchanged."""
        typical = self.dt if self.dt is not None else self._prev
        if not math.isfinite(typical):
            self._odd_s = LOST_STEPS * h  # the first step: nothing yet to judge it against
            return
        lim = gap_limit(typical)
        if lim < h < math.inf:  # an infinite step is refused as a non-finite sample
            self._gap(h, lim)
        if self.dt is None and h <= LOST_STEPS * typical:
            self._odd_s = LOST_STEPS * h
        before = self._last_gyro()
        if LOST_STEPS * typical < h < math.inf and before is not None:  # (an infinite step: a non-finite sample)
            g = np.asarray(gyr, dtype=float).reshape(1, 3)
            self._lost(h, lost_turns(g, np.array([h]), before), typical)

    def _lost(self, h: float, turns: np.ndarray, typical: float, row: int | None = None) -> None:
        """Refuse (or, bridging, warn about) the steps whose ``turns`` (rad) exceed GAP_TURN, the first ``h`` s long
        (before ``row`` of a chunk)."""
        turns = turns[turns > GAP_TURN]
        if not turns.size:
            return
        if self._bridge_lost:
            lost_warning(turns)
            return
        turn = float(turns[0])
        where = "" if row is None else f" before row {row} of the chunk"
        raise OptinavError(
            f"a step of {h:.3g} s{where} lost samples (the typical step {typical:.3g} s) where the gyro's turn "
            f"across it is uncertain by {math.degrees(turn):.3g}°: the heading after it would be off by about that "
            "(the filter's state is unchanged)",
            "build the filter with bridge_lost=True to bridge such steps (the tilt recovers; the heading carries "
            "their uncertainty), or call reset() for a new start levelled from the next sample",
        )

    def _gap(self, h: float, lim: float, row: int | None = None) -> None:
        where = "" if row is None else f" before row {row} of the chunk"
        raise OptinavError(
            f"a step of {h:.3g} s{where} is a time gap (more than {lim:.3g} s): the gyro's turn across it "
            "is unknown (the filter's state is unchanged)",
            "call reset() for a new start levelled from the next sample, then give the samples after the gap with "
            "dt= their usual step" + ("" if row is None else " (update_batch: the chunk from that row)"),
        )

    def _chunk_gaps(self, d: np.ndarray, g: np.ndarray) -> None:
        """Refuse a chunk whose steps ``d`` (N,) s hold a gap, or one that lost samples where the turn across it is
        uncertain (as :meth:`_judge_step`; ``g`` (N, 3) rad/s the chunk's gyro); without the filter's ``dt`` the
        typical step is the chunk's median (as :func:`~optinav.attitude.checks.find_gaps`), or the step before for
        one or two rows."""
        if not self._gap_check or d.size == 1 and self.dt is not None:  # one step for every row: check_step's
            return
        typical = self.dt if self.dt is not None else self._prev if d.size < 3 else float(np.median(d[1:]))
        lim = gap_limit(typical)
        big = np.flatnonzero(d > lim)
        if big.size:
            self._gap(float(d[big[0]]), lim, int(big[0]))
        lost = np.flatnonzero(d > LOST_STEPS * typical)
        before = self._last_gyro()
        if before is None:
            lost = lost[lost > 0]
        if lost.size:
            turns = lost_turns(g, np.broadcast_to(d, (g.shape[0],)), before)[lost]
            k = int(np.argmax(turns > GAP_TURN))  # the first uncertain one, named
            self._lost(float(d[lost[k]]), turns[k:], typical, int(lost[k]))
        self._prev = float(d[-1])


class AttitudeFilter(StreamGaps):
    """Streaming ``iframe`` filter: ``update(gyr, acc, mag=None, dt=None)`` per sample (one numba call).

    ``rate_hz`` or ``dt`` (s) gives the default step. ``mag_hard_iron`` (3,) [the magnetometer's unit, body axes]:
    a hard-iron offset subtracted from every magnetometer sample, as :func:`optinav.attitude.estimate` takes it;
    ``"online"``: an uncalibrated magnetometer whose offset is fitted from the samples so far
    (:func:`hard_iron_online`, as the online estimate does when its check finds one), the magnetometer unused (the
    heading the gyro's from the start) until the fit passes its gates, or with ``mag_measured_before_fit`` used as
    measured until then (the heading off by what the offset turns it); from there less the offset, the heading
    starting anew from it (as a magnetometer that starts there). :attr:`mag_hard_iron` and
    :attr:`mag_hard_iron_from` then say the offset and the sample from which it was subtracted. Only for a
    magnetometer known to carry an offset (a raw sensor, or one the estimate found so): a calibrated one shows none
    to fit and stays unused, or used as measured throughout. After each update: :attr:`q_b_n`, :attr:`rest`,
    :attr:`gyr_bias` (rad/s), :attr:`acc_used`, :attr:`mag_used` (None before the first); ``update`` itself returns
    None (a copy of q would cost a third of its time: read :attr:`q_b_n`). :meth:`update_batch` runs chunks with
    the same arithmetic as :func:`optinav.attitude.estimate` and returns a :class:`FilterRun`, as every method's
    filter does. With polarization the heading's branch must be known before its first sample is used (a stream's
    outputs cannot wait for the data to decide, as the estimate does): ``q0``, ``heading0`` (rad, δ about up: the
    AoP's root nearest it) or a magnetometer sample at or before it; else that chunk is refused.

    Input checks (``checks=True``): the stream's first seconds (20 s, more until gravity has turned 1 rad in the
    body, at most 60 s: :class:`~optinav.attitude.checks.StartChecks`) are judged once by the checks
    :func:`~optinav.attitude.estimate` runs (units, swapped triads or axes, clipping, gyro bias, frame warning, q0;
    not the magnetometer): a refusal raises :class:`~optinav.errors.OptinavError` at the sample or chunk that
    completes them, state unchanged, and again at every later one (:meth:`reset` keeps it); the outputs before it
    are unjudged, a first chunk that long is judged before it runs. No cost after. ``checks=False``: none (a stream
    already judged). ``bridge_lost``: steps that lost samples where the turn is uncertain are bridged, warned
    (:class:`StreamGaps`), not refused.
    """

    def __init__(
        self,
        rate_hz: float | None = None,
        *,
        dt: float | None = None,
        frame: str = DEFAULT_FRAME,
        q0=None,
        mag_hard_iron=None,
        mag_measured_before_fit: bool = False,
        C_b_m=None,
        min_sun_elevation: float = 0.0,
        min_dop: float = 0.05,
        min_sun_separation: float = math.radians(10.0),
        heading0: float | None = None,
        checks: bool = True,
        bridge_lost: bool = False,
        **options,
    ):
        from optinav.attitude.estimators import _as_heading0, _as_q0, _hard_iron, _options, default_step
        from optinav.attitude.measurement import as_c_b_m

        self.frame = frame_name(frame)
        # the polarization sensor of update(..., pol_sample=), as the other methods' filters take it
        self.C_b_m = as_c_b_m(C_b_m, self.frame)
        self._pol_kw = dict(min_sun_elevation=min_sun_elevation, min_dop=min_dop, min_sun_separation=min_sun_separation)
        self._pol_skipped: dict[str, int] | None = None
        self.options = _options("iframe", options)
        self.dt = default_step(rate_hz, dt)
        self._par = _params(self.frame, self.options)
        online = isinstance(mag_hard_iron, str) and mag_hard_iron == "online"
        self._given = None if mag_hard_iron is None or online else _hard_iron(mag_hard_iron, True)
        self._hi = None if self._given is None else tuple(float(v) for v in self._given)
        self._fit = online_fit_state(mag_measured_before_fit) if online else None
        self._fit_step = _k.fitted_sample
        self._branch = q0 is not None or heading0 is not None  # the polarization's heading branch is fixed
        q0 = None if q0 is None else _as_q0(q0)
        self._state = _new_state(self.options, q0, _as_heading0(heading0) or 0.0)
        # views of the state's q and bias: a read copies them without slicing (the state is never replaced)
        self._q, self._bias = self._state[_k.S_Q : _k.S_Q + 4], self._state[_k.S_BIAS : _k.S_BIAS + 3]
        self._step = _k.step
        self._step6 = _k.step6
        self._step9 = _k.step9
        self._bridge_lost = bool(bridge_lost)
        self._gaps_init()
        self._checks = StartChecks(self.frame, "iframe", self.options, True, q0) if checks else None

    def reset(self, q0=None, heading0: float | None = None) -> None:
        """Start the estimate anew (after a time gap, or a new recording): the state as built. The options, the
        hard-iron offset given, and one fitted online (a property of the sensor, as
        :func:`~optinav.attitude.estimate` keeps it across gaps) stay.

        Parameters
        ----------
        q0 : (4,) array or None
            q_b^n [w, x, y, z] [-] to start from; None: levelled from the next sample's accelerometer.
        heading0 : float or None
            Without ``q0``: the heading correction δ [rad, about up] to start from, the polarization's heading
            branch (as the constructor's).
        """
        from optinav.attitude.estimators import _as_heading0, _as_q0

        self._branch = q0 is not None or heading0 is not None
        q0 = None if q0 is None else _as_q0(q0)
        self._state[:] = _new_state(self.options, q0, _as_heading0(heading0) or 0.0)
        self._gaps_init()
        self._checks = None if self._checks is None else self._checks.anew(q0)

    def _decided(self, other_root: bool) -> None:
        """Before the first sample, the heading branch a log's runs from either decided
        (:mod:`optinav.attitude.branch`): the polarization's first used sample takes the AoP's root nearest the
        start's heading, or with ``other_root`` the other one."""
        self._state[_k.S_P_OTHER], self._branch = float(other_root), True

    def _check_branch(self, pin, mag) -> None:
        """Refuse the chunk's first usable polarization sample (``pin``: its kernel inputs) while nothing fixed the
        heading's branch: q0, heading0, or a magnetometer sample (``mag`` (N, 3) or None; with an offset fitted
        online only a field already used) at or before it, whose field sets the heading the AoP's root is taken
        nearest to (:func:`_iframe._pol_update`)."""
        if self._branch or self._state[_k.S_P_INIT] or self._state[_k.S_M_INIT] or not pin[0].any():
            return
        first = int(np.argmax(pin[0]))
        if mag is None or not np.isfinite(mag[: first + 1]).all(axis=1).any():
            from optinav.attitude.branch import stream_branch_error

            raise stream_branch_error()

    def update(self, gyr, acc, mag=None, dt=None, pol_sample=None) -> None:
        """One sample; then read :attr:`q_b_n`, :attr:`rest`, … Per sample only the lengths are checked in Python
        (speed), the stream's first seconds once as a whole (the class's input checks); a non-finite gyr, acc or dt
        raises :class:`~optinav.errors.OptinavError` and leaves the state unchanged. With ``pol_sample`` the sample
        goes through :meth:`update_batch` (the same arithmetic, checked as a chunk).

        Parameters
        ----------
        gyr : (3,) array
            Angular rate ω_ib^b [rad/s].
        acc : (3,) array
            Specific force [m/s^2].
        mag : (3,) array, float or None
            Magnetometer [any unit]; a number here is the step dt (``update(gyr, acc, dt)``, the form of the
            other methods' filters from :func:`~optinav.attitude.make_filter`).
        dt : float or None
            Step [s]; None: the filter's.
        pol_sample : tuple or None
            Skylight polarization: (aop [rad], sun_n (3,) [-]) or (aop, sun_n, dop [-]), the sensor of the filter's
            ``C_b_m`` and thresholds.
        """
        if mag is not None and (not hasattr(mag, "__len__") or getattr(mag, "ndim", 1) == 0):  # a 0-d array too
            mag, dt = None, mag
        if pol_sample is not None:
            from optinav.attitude.estimators import one_pol_sample

            pol = one_pol_sample(pol_sample, self.C_b_m, self.frame, self._pol_kw)
            one = lambda v: None if v is None else np.asarray(v, dtype=float).reshape(1, -1)
            self.update_batch(one(gyr), one(acc), one(mag), dt=dt, pol=pol)
            return
        h = self.dt if dt is None else dt
        if h is None or not h > 0:
            raise OptinavError("no positive time step for this update", "pass dt= or build with rate_hz")
        if h > self._odd_s and self._gap_check:
            self._judge_step(h, gyr)
        if len(gyr) != 3 or len(acc) != 3 or (mag is not None and len(mag) != 3):
            raise OptinavError("gyr, acc and mag must have 3 components each", "pass one sample (x, y, z)")
        if self._checks is not None and self._checks.sample(gyr, acc, h):
            self._checks = None  # the inputs passed: nothing is checked after
        if mag is not None and self._hi is not None:
            b = self._hi
            mag = (mag[0] - b[0], mag[1] - b[1], mag[2] - b[2])
        elif mag is not None and self._fit is not None:
            w = math.sqrt(float(gyr[0]) ** 2 + float(gyr[1]) ** 2 + float(gyr[2]) ** 2)
            mag = self._fit_step(self._fit, self._state, float(mag[0]), float(mag[1]), float(mag[2]), float(h), w)
        if mag is None and type(gyr) is not list and type(acc) is not list:  # arrays and tuples as they are
            ok = self._step6(self._state, self._par, gyr, acc, h)
        elif mag is not None and type(gyr) is not list and type(acc) is not list and type(mag) is not list:
            ok = self._step9(self._state, self._par, gyr, acc, mag, h)
        else:  # lists: numbers, not a reflected list (deprecated in numba, compiled anew)
            m = (math.nan,) * 3 if mag is None else mag
            g0, g1, g2, a0, a1, a2, m0, m1, m2 = (float(v) for v in (*gyr, *acc, *m))
            ok = self._step(self._state, self._par, g0, g1, g2, a0, a1, a2, m0, m1, m2, float(h))
        if not ok:
            raise OptinavError(
                f"a sample with a non-finite gyr {list(gyr)}, acc {list(acc)} or dt {h} was not used (state unchanged)",
                "skip it: give the next sample dt= the time since the last one used",
            )
        self._prev = h

    def update_batch(self, gyr, acc, mag=None, dt=None, pol=None) -> FilterRun:
        """A chunk of samples, with per-sample outputs (the arithmetic of :meth:`update`); the stream's first
        seconds are judged as the class says (input checks).

        Parameters
        ----------
        gyr : (N, 3) array
            Angular rate ω_ib^b [rad/s].
        acc : (N, 3) array
            Specific force [m/s^2].
        mag : (N, 3) array, float, (N,) array or None
            Magnetometer [any unit]; a number or (N,) array here is the step dt [s] (``update_batch(gyr, acc,
            dt)``, the form of the other methods' filters).
        dt : float, (N,) array or None
            Steps [s]; None: the filter's.
        pol : PolarizationMeasurement or None
            The chunk's skylight-polarization samples (N of them): heading corrections as :func:`run_iframe`'s.

        Returns
        -------
        FilterRun
            ``q_b_n`` (N, 4) q_b^n, ``rest``/``acc_used``/``mag_used`` (N,) flags (``mag_used`` None without
            ``mag``), ``gyr_bias`` (N, 3) [rad/s] after each sample, ``mag_offset`` (N, 3) [mag's unit] the
            body-fixed offset a disturbed field was used less (0 where used as measured or not at all; None
            without ``mag``), ``pol_used`` (N,) and ``pol_skipped`` (None without ``pol``); N = 0 gives empty
            arrays.
        """
        from optinav.attitude.estimators import _as_dt, _checked_imu

        if mag is not None and np.ndim(mag) < 2:  # a step in mag's place, as update() takes it
            if dt is not None:
                raise OptinavError("update_batch got the step twice (third argument and dt=)", "pass dt= only")
            mag, dt = None, mag
        if np.shape(gyr)[:1] == (0,) and np.shape(acc)[:1] == (0,):  # an empty chunk (a stream's last read)
            no = np.zeros(0, bool)
            used, off = (None, None) if mag is None else (no.copy(), np.empty((0, 3)))
            return FilterRun(
                np.empty((0, 4)), no, no.copy(), used, np.empty((0, 3)), self._state.copy(), mag_offset=off
            )
        g, a, m = _checked_imu(gyr, acc, mag, whole=False)  # a chunk: a slow magnetometer may give it none
        h = self.dt if dt is None else dt
        if h is None:
            raise OptinavError("no time step for this chunk", "pass dt= or build with rate_hz")
        d = _as_dt(h, g.shape[0])
        self._chunk_gaps(d, g)
        if self._checks is not None and self._checks.chunk(g, a, d):
            self._checks = None  # the inputs passed: nothing is checked after
        pin = None
        if pol is not None:
            from optinav.attitude.measurement import pol_inputs

            pin = pol_inputs(pol, g.shape[0], self.frame, "the IMU")
            self._check_branch(pin, None if self._fit is not None else m)  # before any state changes
        restart = -1
        if m is not None and self._given is not None:
            m = m - self._given
        elif m is not None and self._fit is not None:
            row0 = self._fit[_k.HF_ROWS]
            m, _ = hard_iron_online(m, d, self._fit, g)
            restart = _k.first_fitted_row(self._fit, row0)
        rows = np.zeros((0, 3)) if m is None else m
        if pol is None:
            r = _run(self._state, self._par, g, a, rows, d, restart)
        else:
            r = _run_pol(self._state, self._par, g, a, rows, d, pin, restart)
        if pol is not None:
            self._pol_skipped = self._pol_skipped or {}
            for k, v in r.pol_skipped.items():
                self._pol_skipped[k] = self._pol_skipped.get(k, 0) + v
        r.state = self._state.copy()  # the chunk's end state, not the filter's live one
        r.mag_used = None if m is None else r.mag_used  # no magnetometer given: None, as estimate() reports it
        return r

    def _last_gyro(self) -> np.ndarray | None:
        st = self._state
        return st[_k.S_G_LAST : _k.S_G_LAST + 3].copy() if st[_k.S_INIT] else None

    @property
    def mag_hard_iron(self) -> np.ndarray | None:
        """The hard-iron offset (3,) [the magnetometer's unit] subtracted from the magnetometer: the one given, or
        the one fitted online so far (None until its fit passed its gates, and without either)."""
        if self._fit is not None:
            return online_fit_result(self._fit)[0]
        return None if self._given is None else self._given.copy()

    @property
    def mag_hard_iron_from(self) -> int | None:
        """With ``mag_hard_iron="online"``: the sample (counted from 0 over every update) from which the field was
        used less the offset fitted online; None before and otherwise."""
        return None if self._fit is None else online_fit_result(self._fit)[1]

    @property
    def q_b_n(self) -> np.ndarray | None:
        """q_b^n [w, x, y, z] after the last update (None before the first)."""
        return self._q.copy() if self._state[_k.S_INIT] else None

    @property
    def rest(self) -> bool | None:
        """Whether rest was detected at the last sample (None before the first)."""
        return bool(self._state[_k.S_REST]) if self._state[_k.S_INIT] else None

    @property
    def gyr_bias(self) -> np.ndarray | None:
        """Gyro-bias estimate [rad/s] after the last update (None before the first)."""
        return self._bias.copy() if self._state[_k.S_INIT] else None

    @property
    def acc_used(self) -> bool | None:
        """Whether the last accelerometer sample corrected the tilt (None before the first)."""
        return bool(self._state[_k.S_ACC_USED]) if self._state[_k.S_INIT] else None

    @property
    def mag_used(self) -> bool | None:
        """Whether the last sample's magnetometer corrected the heading (None until a magnetometer sample came)."""
        return bool(self._state[_k.S_MAG_USED]) if self._state[_k.S_M_SEEN] else None

    @property
    def pol_skipped(self) -> dict[str, int] | None:
        """Polarization samples left out so far, by reason, as :func:`~optinav.attitude.estimate` counts them (None
        until a polarization sample was given)."""
        return None if self._pol_skipped is None else dict(self._pol_skipped)

    @property
    def pol_used(self) -> bool | None:
        """Whether the last sample's polarization corrected the heading (None until a polarization sample came)."""
        return bool(self._state[_k.S_POL_USED]) if self._state[_k.S_P_LAST] else None

    @property
    def mag_offset(self) -> np.ndarray | None:
        """The body-fixed offset (3,) [the magnetometer's unit] the last sample's field was used less (zeros where it
        was used as measured or not at all; :attr:`FilterRun.mag_offset`); None until a magnetometer sample came."""
        if not self._state[_k.S_M_SEEN]:
            return None
        used = self._state[_k.S_MAG_CORR] != 0.0
        return self._state[_k.S_HI_B : _k.S_HI_B + 3].copy() if used else np.zeros(3)

    @property
    def att_std(self) -> None:
        """None: iframe has no attitude covariance (mekf's filter has, as :attr:`FilterRun.att_std`)."""
        return None
