"""numba core of the ``iframe`` estimator (private; the API is :mod:`optinav.attitude.iframe`).

One scalar step :func:`step` per sample on a flat ``state`` array (the streaming filter calls it directly, the
batch loop :func:`run` calls it N times), so batch and streaming are the same arithmetic. Design after VQF
(Laidig & Seel, Information Fusion 91, 2023): the gyro strapdown q_g = q_b^I defines an almost-inertial frame
I, where gravity is nearly constant while the body rotates; the accelerometer is low-passed there (second-order
Butterworth, bilinear with pre-warping, time constant ``tau_acc``), and a tilt correction q_c = q_I^n' turns
the low-passed specific force onto the vertical. A heading correction δ about the vertical (magnetometer)
completes q_b^n = R_up(δ) ⊗ q_c ⊗ q_g. The gyro bias is a 3-state Kalman filter fed by detected rest (H = I)
and, in motion, by the tilt-correction rate (its horizontal part equals −C_b^n δb through the low-pass).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from optinav.attitude.checks import MAG_OFFSET as HF_MAG_OFFSET
from optinav.attitude.checks import MAG_SEEN_SPREAD as HF_SEEN_SPREAD
from optinav.attitude.checks import MAG_SPREAD as HF_MAG_SPREAD
from optinav.attitude.checks import STILL_RATE as HF_STILL_RATE
from optinav.core._quat import qmul as _qmul
from optinav.core._quat import rv2q as _rotvec_q

_NJ = dict(cache=True, nogil=True, fastmath=False)

# --- state layout ---------------------------------------------------------------------------------------------
S_QG, S_QC, S_DELTA, S_BIAS, S_P = 0, 4, 8, 9, 12  # q_g (4), q_c (4), δ (1), bias (3), P bias (9)
S_LP = 21  # Butterworth memory: x1, x2, y1, y2 per axis (12)
S_DT = 33  # dt of the cached coefficients, then b0, b1, a1, a2 (4)
S_RG, S_RA = 38, 41  # rest low-pass of gyr (3) and acc (3)
S_REST_T, S_REST = 44, 45  # time at rest so far (s), rest flag
S_M_NORM, S_M_DIP, S_M_REF_T = 46, 47, 48  # magnetic reference: norm (µT or any), dip (rad), time
S_M_DIST_T, S_M_C_NORM, S_M_C_DIP = 49, 50, 51  # time disturbed, candidate norm, candidate dip
S_M_INIT = 52  # 1 once δ was set from the first usable mag sample
S_INIT = 53  # 1 once the first sample initialized the state
S_ACC_USED, S_MAG_USED, S_BIAS_MOTION = 54, 55, 56  # last sample's flags (1/0)
S_Q = 57  # output q_b^n (4)
S_TIME = 61  # time since start (s)
S_RDT = 62  # dt of the cached rest coefficients, then α (1)
S_LPC = 64  # Butterworth memory of C_b^I (9 entries × 4)
S_AVG_N = 100  # samples averaged so far in the first ``tau_acc`` seconds (the low-passes' start)
S_M_LP = 101  # |m| and dip low-passed over mag_current_tau (the candidate's input; |m| = 0: not started)
S_M_T0 = 103  # s of magnetometer age, start of the heading's running mean (then first order, tau_mag); 0: tau_acc
S_LP_T0 = 104  # s, when the low-passes' running-mean start began last: 0, or the end of a gap
S_HNOM = 105  # s, the typical step (a slow mean of the steps that are no gap)
S_M_SEEN, S_M_T1, S_M_LAST = 106, 107, 108  # 1 once a mag sample came; s: time before the first, of the last
S_RN = 109  # gyr (3) and acc (3) through the rest detector's band limit (REST_BAND_TAU), then its α (1)
S_STEP_T = 116  # s per axis: how long the rest innovation has been beyond 3σ (a bias step once it lasts rest_tau)
# a body-fixed field offset (a magnet or a phone on the board) fitted while the field is disturbed: the
# exponentially weighted sums of the fit m − Cᵀe = (Cᵀ∂e/∂φ)·δφ + b (weight w, s): W, Σw|g|², Σw·g (3), Σw·g·r,
# Σw·r (3), Σw|r|² (10), then how long the raw field has been accepted (1), the offset b (3) and 1 while it is valid
S_HI = 119
S_HI_OK = 129
S_HI_B = 130
S_HI_V = 133
S_MAG_CORR = 134  # 1: the last sample's field was used less the fitted offset
S_HI_U = 135  # Σw·u (3), u the up direction in body axes over the offset fit's samples (its tilt spread)
S_HI_N = 138  # Σw·C r (3): the fit's residual r = m − Cᵀe in the navigation frame (a field fixed in the room)
S_REST_LP = 141  # the specific force in I low-passed over rest_tau_acc while at rest (3), then 1 while it runs
#: rest_tau's a bias step at rest must last, its rate flat (the means of the halves of that time within 3 standard
#: errors): a ramp rises between them by slope × this × rest_tau / 2, against noise that falls as its square root
STEP_TAUS = 2.0
# per axis, over a candidate bias step's STEP_TAUS rest_tau (S_STEP_T): n, Σg, Σg² of the band-limited rate in its
# first half, then in its second (6 per axis)
S_STEP_S = 145
# skylight polarization (:func:`run_pol`): s before its first used sample, s of its last sample, 1 once it has set
# δ, the last sample's flag (1 used)
S_P_T0, S_P_LAST, S_P_INIT, S_POL_USED = 163, 164, 165, 166
S_P_USED_T = 167  # s of its last used sample
S_P_OTHER = 168  # 1: its first used sample takes the AoP's other root, the heading branch not nearest δ
S_G_LAST = 169  # the last sample's gyr (3) as given: a stream's step that lost samples is judged against it
STATE_SIZE = 172

#: s, the rest detector reads gyro and accelerometer through a first-order low-pass of this time constant (a band
#: of about 1/(4·REST_BAND_TAU) = 250 Hz): white noise of a given density (rad/s/√Hz, m/s²/√Hz) then deviates from
#: the rest low-pass by the same amount at every rate above ~300 Hz. Read sample by sample, its deviation grew as
#: √rate: an MPU6000-class accelerometer (400 µg/√Hz) on a simulated flight rested 6.3 % of the time at 100-700 Hz
#: and never at 1 kHz (σ 0.12 m/s² per axis, one sample beyond rest_acc in 1.5 s resets the rest time), its gyro
#: bias left to the motion update (z at the 2 °/s clip, heading RMSE 0.27 -> 5.4°). Below ~300 Hz the rate's own
#: band limits the noise (factor ≥ 0.94 on the variance at BROAD's 286 Hz, ≥ 0.9999 at 100 Hz)
REST_BAND_TAU = 0.001

#: a step longer than this many typical steps is a gap of lost samples, low-passed in sub-steps
GAP_SUBSTEP = 1.75
#: s, a gap at least this long restarts the low-passes as at the start (the running mean over the next tau_acc
#: s): the gyro alone carried the attitude across it, by the rate of the sample after it, and the turn it made
#: then is unknown (hand motion: 50 rad/s² over 0.1 s, about 15°). Ten gaps of 0.05-0.45 s in motion on five
#: BROAD trials (two draws): inclination 16.0 -> 4.9° and 4.2° mean (VQF, which leaves the gaps out, 17.0° and
#: 12.8°; fast translation is the exception: 15.2 and 13.9° against VQF's 14.3 and 4.8°). Shorter gaps do not
#: restart: their turn is known better than a restart's running mean knows the tilt. One gap in motion at three
#: places of each of the nine trials, online / offline inclination [deg], restart at 0.05 s -> never: 0.06 s
#: 1.18/0.63 -> 0.72/0.55, 0.08 s 1.15/0.65 -> 0.89/0.63, 0.1 s 1.19/0.68 -> 1.04/0.71, 0.15 s 1.32/0.75 ->
#: 1.51/0.96 (beyond, restarting wins more and more); five gaps of 0.03-0.45 s per trial, four draws: threshold
#: 0.05 -> 0.1 s 2.61/1.75 -> 2.12/1.59 (0.12 s: 2.43/1.72). A step-by-step rule by the gyro's change across the
#: gap (its turn error |Δω|·h/2) did worse offline (0.3 s gaps 1.36 against 0.94)
GAP_RESTART_S = 0.1

#: s, while the tilt settles (the first tau_acc s) the heading follows the field low-passed over this time:
#: following each sample put the field's noise and a fast rotation's tilt error (±10° at 450 °/s, BROAD trial
#: 07 cut at the start of its motion) into the heading; a running mean over the whole settling read the field
#: through the start's worst tilt (cuts starting in motion got worse). Cuts of the nine BROAD trials starting
#: 0-60 s into their motion: 9D online heading 4.54 -> 4.40° mean (0.1 s: 4.45, 0.3 s: 4.39); whole trials
#: (starting at rest) unchanged
MAG_SETTLE_TAU = 0.2
#: s the raw field must be accepted without a break before a fitted body-fixed offset is forgotten (the disturbance
#: ended; a few disturbed samples pass the gates by chance while it lasts)
HI_RESET_TIME = 1.0
#: the least rotation diversity of the offset fit, D/(W·(N cos dip)²) with D = W·var(Cᵀ∂e/∂φ): 0 without rotation
#: (offset and heading inseparable), 1 for horizontal field directions spread evenly; and likewise var(Cᵀu) of
#: the up direction u: 0 for a body turning about the vertical only, whose offset along it is inseparable from a
#: field fixed in the room along the vertical (level yaw past steel, 13 µT: the heading 11.7° off, gyro 2.7°)
HI_MIN_SPREAD = 0.3
#: the fit's residual (vector RMS) at most this fraction of the reference field: a field that turns with the body
#: leaves only the sensor's noise and the attitude's error (BROAD trial 33: 4.5 %); one fixed in the room does not.
#: Not the norm gate's mag_norm_th: a stricter gate for the samples need not refuse the offset the fit is for
HI_RMS_GATE = 0.1

# --- parameter layout (all SI: s, rad, rad/s, m/s², relative) ------------------------------------------------
P_TAU_ACC, P_REST_TAU, P_REST_GYR, P_REST_ACC, P_REST_TIME = 0, 1, 2, 3, 4
P_BIAS_SIGMA0, P_BIAS_RW, P_BIAS_REST, P_BIAS_MOTION, P_BIAS_CLIP = 5, 6, 7, 8, 9
P_MOTION_MAX_GYR, P_MOTION_MAX_ACC, P_GRAVITY = 10, 11, 12
P_TAU_MAG, P_MAG_NORM_TH, P_MAG_DIP_TH, P_MAG_NEW_TIME, P_TAU_MAG_REF = 13, 14, 15, 16, 17
P_UP, P_NORTH = 18, 21  # unit up and north of the navigation frame
P_LATENCY = 24  # s, output predicted forward by the sensor latency
P_BIAS_LOOP = 25  # -, the motion bias loop's time constant is at least this many tau_acc
P_MAG_CUR_TAU = 26  # s, low-pass of |m| and dip for the new-field candidate; 0 = none
P_MOTION_GATE = 27  # -, a motion update whose correction rate exceeds this many σ of what bias explains is skipped
P_HI_TAU = 28  # s, averaging time of the body-fixed field offset fitted while the field is disturbed; 0 = off
P_REST_TAU_ACC = 29  # s, the accelerometer's low-pass time constant in I while at rest; 0 = tau_acc
P_TAU_POL = 30  # s, the polarization heading correction's time constant
P_MAG_POL_TH = 31  # rad, a field's azimuth beyond this from the heading polarization holds is not used; 0 = off
P_DECLINATION = 32  # rad, magnetic north's angle east of true north: added to every azimuth of the field
PAR_SIZE = 33

#: the least |dα′/dφ| (AoP per heading) a polarization sample must have to correct the heading: the heading's
#: error is the AoP's divided by it (a level zenith-viewing sensor: 1; a sensor viewing near the horizon towards
#: the sun's vertical plane: 0, the AoP then says nothing of the heading)
POL_MIN_SLOPE = 0.2
#: per-sample polarization outcomes of :func:`run_pol`: none given, used, sun within the minimum separation of
#: the viewing axis, no heading explains the AoP at this tilt (or too weakly: POL_MIN_SLOPE)
POL_NONE, POL_USED, POL_NEAR_ZENITH, POL_UNRESOLVED = 0, 1, 2, 3


@numba.njit(**_NJ)
def _rot(q0, q1, q2, q3, x, y, z):
    """C(q)·v for a unit quaternion q."""
    tx = 2.0 * (q2 * z - q3 * y)
    ty = 2.0 * (q3 * x - q1 * z)
    tz = 2.0 * (q1 * y - q2 * x)
    return (x + q0 * tx + q2 * tz - q3 * ty, y + q0 * ty + q3 * tx - q1 * tz, z + q0 * tz + q1 * ty - q2 * tx)


# one signature: numba typed each call's constant offset k (S_QC, S_QG, S_Q) as a literal and compiled it three times
@numba.njit("void(float64[::1], int64, float64, float64, float64, float64)", **_NJ)
def _store_q(st, k, q0, q1, q2, q3):
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    st[k] = q0 / n
    st[k + 1] = q1 / n
    st[k + 2] = q2 / n
    st[k + 3] = q3 / n


@numba.njit(**_NJ)
def _butter(st, par, h):
    """Second-order Butterworth low-pass coefficients for step h, cached in the state (rate-independent:
    cutoff f_c = √2/(2π τ) with τ = ``tau_acc``). Returns the number of sub-steps the step takes: a step longer
    than GAP_SUBSTEP typical steps (lost samples) is filtered in sub-steps of about the typical step, so that the
    filter's memory (its past inputs and outputs, spaced by that step) keeps its meaning."""
    ns = 1
    hn = st[S_HNOM]
    if hn == 0.0:
        st[S_HNOM] = h
    elif h > GAP_SUBSTEP * hn:
        ns = int(round(h / hn))
        h = h / ns
    else:
        st[S_HNOM] += 0.01 * (h - hn)  # jittered steps: the mean over about 100 of them
    if st[S_DT] != h:
        fc = math.sqrt(2.0) / (2.0 * math.pi * par[P_TAU_ACC])
        k = math.tan(math.pi * min(fc * h, 0.49))
        nrm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
        b0 = k * k * nrm
        st[S_DT] = h
        st[S_DT + 1] = b0
        st[S_DT + 2] = 2.0 * b0
        st[S_DT + 3] = 2.0 * (k * k - 1.0) * nrm
        st[S_DT + 4] = (1.0 - math.sqrt(2.0) * k + k * k) * nrm
    return ns


# one signature: numba typed each call's constant channel and base as literals and compiled _lp twelve times (on
# a cold cache: a first estimate() 12.0 s, now 7.2 s)
@numba.njit("float64(float64[::1], int64, float64, int64, float64, int64)", **_NJ)
def _lp(st, j, x, base, n, ns):
    """One Butterworth step (direct form I) on channel j of the memory at ``base``; ``n`` ≥ 1: the start, the
    mean of the n samples so far instead, kept as the filter's steady state for that input (every memory equal),
    so that one accelerated first sample does not weigh for seconds (as VQF starts its low-pass). ``ns`` > 1: the
    step is a gap taken in ``ns`` sub-steps, the input interpolated linearly from the last one (a 0.3-s gap
    filtered as one step with its own coefficients left an increment that the next, short step read as its own:
    the tilt overshot by 100° for seconds)."""
    m = base + 4 * j
    if n > 0.0:
        y = st[m] + (x - st[m]) / n
        st[m] = st[m + 1] = st[m + 2] = st[m + 3] = y
        return y
    b0, b1, a1, a2 = st[S_DT + 1], st[S_DT + 2], st[S_DT + 3], st[S_DT + 4]
    x0 = st[m]
    y = 0.0
    for i in range(1, ns + 1):
        xi = x0 + (x - x0) * (i / ns) if ns > 1 else x
        y = b0 * xi + b1 * st[m] + b0 * st[m + 1] - a1 * st[m + 2] - a2 * st[m + 3]
        st[m + 1] = st[m]
        st[m] = xi
        st[m + 3] = st[m + 2]
        st[m + 2] = y
    return y


@numba.njit(**_NJ)
def _motion_row(st, L, c0, c1, c2, c3, px, py, pz):
    """Row p·C(q_c)·LP(C_b^I) of the motion bias update for the horizontal unit vector p (navigation frame)."""
    jx, jy, jz = _rot(c0, -c1, -c2, -c3, px, py, pz)  # p into I
    hx = jx * st[L + 4 * 0 + 2] + jy * st[L + 4 * 3 + 2] + jz * st[L + 4 * 6 + 2]
    hy = jx * st[L + 4 * 1 + 2] + jy * st[L + 4 * 4 + 2] + jz * st[L + 4 * 7 + 2]
    hz = jx * st[L + 4 * 2 + 2] + jy * st[L + 4 * 5 + 2] + jz * st[L + 4 * 8 + 2]
    return hx, hy, hz


@numba.njit(**_NJ)
def _quad(P, hx, hy, hz):
    """h·P·hᵀ of a row h and the 3×3 bias covariance P (row-major)."""
    return (
        hx * (P[0] * hx + P[1] * hy + P[2] * hz)
        + hy * (P[3] * hx + P[4] * hy + P[5] * hz)
        + hz * (P[6] * hx + P[7] * hy + P[8] * hz)
    )


@numba.njit(inline="always", **_NJ)
def _step_add(st, j, g, late):
    """Add the band-limited rate ``g`` (rad/s) of axis ``j`` to the sums of the first half of a candidate bias
    step's STEP_TAUS rest_tau (``late``: of its second)."""
    k = S_STEP_S + 6 * j + (3 if late else 0)
    st[k] += 1.0
    st[k + 1] += g
    st[k + 2] += g * g


@numba.njit(inline="always", **_NJ)
def _step_reset(st, j):
    """End axis ``j``'s candidate bias step (its time and sums), if one is open."""
    if st[S_STEP_T + j] != 0.0:
        st[S_STEP_T + j] = 0.0
        for k in range(6):
            st[S_STEP_S + 6 * j + k] = 0.0


@numba.njit(inline="always", **_NJ)
def _step_flat(st, j) -> bool:
    """Whether axis ``j``'s rate was flat over its candidate bias step: the means of the halves of its time differ
    by under 3 standard errors of their difference (from the halves' own scatter); True with too few samples."""
    k = S_STEP_S + 6 * j
    n1, n2 = st[k], st[k + 3]
    if n1 < 2.0 or n2 < 2.0:
        return True
    m1, m2 = st[k + 1] / n1, st[k + 4] / n2
    v1 = max(st[k + 2] / n1 - m1 * m1, 0.0) * n1 / (n1 - 1.0)
    v2 = max(st[k + 5] / n2 - m2 * m2, 0.0) * n2 / (n2 - 1.0)
    d = m2 - m1
    return d * d <= 9.0 * (v1 / n1 + v2 / n2)


@numba.njit(**_NJ)
def _bias_update(st, h0, h1, h2, z, r, clip):
    """Scalar Kalman update of the gyro bias with row h, residual z (rad/s), variance r; bias clipped."""
    P = st[S_P : S_P + 9]
    ph0 = P[0] * h0 + P[1] * h1 + P[2] * h2
    ph1 = P[3] * h0 + P[4] * h1 + P[5] * h2
    ph2 = P[6] * h0 + P[7] * h1 + P[8] * h2
    s = r + h0 * ph0 + h1 * ph1 + h2 * ph2
    k0, k1, k2 = ph0 / s, ph1 / s, ph2 / s
    b = st[S_BIAS : S_BIAS + 3]
    b[0] = min(max(b[0] + k0 * z, -clip), clip)
    b[1] = min(max(b[1] + k1 * z, -clip), clip)
    b[2] = min(max(b[2] + k2 * z, -clip), clip)
    P[0] -= k0 * ph0
    P[1] -= k0 * ph1
    P[2] -= k0 * ph2
    P[3] -= k1 * ph0
    P[4] -= k1 * ph1
    P[5] -= k1 * ph2
    P[6] -= k2 * ph0
    P[7] -= k2 * ph1
    P[8] -= k2 * ph2


@numba.njit(inline="always", **_NJ)
def _axes(par):
    """Up, north and west (up × north) of the navigation frame: nine numbers."""
    ux, uy, uz = par[P_UP], par[P_UP + 1], par[P_UP + 2]
    nx, ny, nz = par[P_NORTH], par[P_NORTH + 1], par[P_NORTH + 2]
    return ux, uy, uz, nx, ny, nz, uy * nz - uz * ny, uz * nx - ux * nz, ux * ny - uy * nx


@numba.njit(inline="always", **_NJ)
def _dip_azimuth(par, t0, t1, t2, t3, mx, my, mz, nm):
    """Dip (rad, down positive) and azimuth φ (rad, from north toward west, positive about up) of the field m
    (norm nm) carried by t = q_c ⊗ q_g into the frame before the heading correction δ, plus the declination D:
    the field's horizontal part lies D east of true north, so δ = −φ turns the heading to the true one."""
    ux, uy, uz, nx, ny, nz, wx, wy, wz = _axes(par)
    vx, vy, vz = _rot(t0, t1, t2, t3, mx, my, mz)
    dip = math.asin(max(-1.0, min(1.0, -(vx * ux + vy * uy + vz * uz) / nm)))
    return dip, math.atan2(vx * wx + vy * wy + vz * wz, vx * nx + vy * ny + vz * nz) + par[P_DECLINATION]


@numba.njit(inline="always", **_NJ)
def _field_agrees(st, par, nm, dip):
    """The gates: norm within mag_norm_th (relative) and dip within mag_dip_th of the learned reference."""
    return abs(nm - st[S_M_NORM]) < par[P_MAG_NORM_TH] * st[S_M_NORM] and abs(dip - st[S_M_DIP]) < par[P_MAG_DIP_TH]


@numba.njit(inline="always", **_NJ)
def _heading_gain(st, par, hm, age):
    """The heading correction's gain for a field sample after hm s: 1/n over the running mean since the heading's
    start (S_M_T0, else tau_acc), growing to hm/tau_mag."""
    tm0 = st[S_M_T0] if st[S_M_T0] > 0.0 else par[P_TAU_ACC]
    return min(1.0, hm / min(par[P_TAU_MAG], max(age - tm0, hm)))


@numba.njit(**_NJ)
def _hi_reset(st):
    """Forget the body-fixed offset's fit (its sums and its validity)."""
    for j in range(10):
        st[S_HI + j] = 0.0
    for j in range(6):
        st[S_HI_U + j] = 0.0
    st[S_HI_V] = 0.0


@numba.njit(**_NJ)
def mag_restart(st):
    """Forget every magnetometer sample so far: the state's magnetic part as before the first (reference, new-field
    candidate, start-up clock, the body-fixed offset's fit). The next field sample sets the heading anew, as a
    magnetometer that starts there would; the tilt and the bias, which the field never enters, go on."""
    for j in range(S_M_NORM, S_M_INIT + 1):
        st[j] = 0.0
    st[S_MAG_USED] = 0.0
    for j in (S_M_LP, S_M_LP + 1, S_M_T0, S_M_SEEN, S_M_T1, S_M_LAST):
        st[j] = 0.0
    for j in range(S_HI, S_HI_N + 3):
        st[j] = 0.0


@numba.njit(**_NJ)
def _hard_iron(st, par, t0, t1, t2, t3, mx, my, mz, hm):
    """Add a disturbed field sample to the body-fixed offset fit and solve it: m − Cᵀe(φ̂) = Cᵀ∂e/∂φ·δφ + b, e the
    reference field (norm, dip) at the azimuth φ̂ = −δ − D the heading holds (D the declination), C = C(t) body →
    the frame before δ,
    weights exponentially forgotten over P_HI_TAU s. Sets st[S_HI_B:+3] and st[S_HI_V] (1: the fit has seen half
    its time, the spreads of Cᵀ∂e/∂φ and of the up direction Cᵀu are ≥ HI_MIN_SPREAD, and its residual is within
    HI_RMS_GATE of the field and below that of a field fixed in the room, m − Cᵀe = Cᵀd). Returns the azimuth
    (rad, as step's φ) of the field less the offset when the fit is valid and that field passes the norm and dip
    gates, else NaN."""
    ux, uy, uz, nx, ny, nz, wx, wy, wz = _axes(par)
    nr, dp = st[S_M_NORM], st[S_M_DIP]
    cd, sd = nr * math.cos(dp), nr * math.sin(dp)
    cp, sp = math.cos(st[S_DELTA] + par[P_DECLINATION]), -math.sin(st[S_DELTA] + par[P_DECLINATION])
    ex, ey, ez = (
        cd * (cp * nx + sp * wx) - sd * ux,
        cd * (cp * ny + sp * wy) - sd * uy,
        cd * (cp * nz + sp * wz) - sd * uz,
    )
    fx, fy, fz = cd * (cp * wx - sp * nx), cd * (cp * wy - sp * ny), cd * (cp * wz - sp * nz)
    ex, ey, ez = _rot(t0, -t1, -t2, -t3, ex, ey, ez)  # into the body
    gx, gy, gz = _rot(t0, -t1, -t2, -t3, fx, fy, fz)
    rx, ry, rz = mx - ex, my - ey, mz - ez
    lam = math.exp(-hm / par[P_HI_TAU])
    a = (
        hm,
        hm * (gx * gx + gy * gy + gz * gz),
        hm * gx,
        hm * gy,
        hm * gz,
        hm * (gx * rx + gy * ry + gz * rz),
        hm * rx,
        hm * ry,
        hm * rz,
        hm * (rx * rx + ry * ry + rz * rz),
    )
    for j in range(10):
        st[S_HI + j] = lam * st[S_HI + j] + a[j]
    vx, vy, vz = _rot(t0, -t1, -t2, -t3, ux, uy, uz)  # up in the body
    st[S_HI_U] = lam * st[S_HI_U] + hm * vx
    st[S_HI_U + 1] = lam * st[S_HI_U + 1] + hm * vy
    st[S_HI_U + 2] = lam * st[S_HI_U + 2] + hm * vz
    kx, ky, kz = _rot(t0, t1, t2, t3, rx, ry, rz)  # the residual in the frame before δ, then turned by δ
    kn, kw = kx * nx + ky * ny + kz * nz, kx * wx + ky * wy + kz * wz
    st[S_HI_N] = lam * st[S_HI_N] + hm * (kn * cp + kw * sp)
    st[S_HI_N + 1] = lam * st[S_HI_N + 1] + hm * (kw * cp - kn * sp)
    st[S_HI_N + 2] = lam * st[S_HI_N + 2] + hm * (kx * ux + ky * uy + kz * uz)
    a = (
        st[S_HI],
        st[S_HI + 1],
        st[S_HI + 2],
        st[S_HI + 3],
        st[S_HI + 4],
        st[S_HI + 5],
        st[S_HI + 6],
        st[S_HI + 7],
        st[S_HI + 8],
        st[S_HI + 9],
    )
    w = a[0]
    st[S_HI_V] = 0.0
    spread = a[1] - (a[2] * a[2] + a[3] * a[3] + a[4] * a[4]) / w
    tilt = w * w - (st[S_HI_U] ** 2 + st[S_HI_U + 1] ** 2 + st[S_HI_U + 2] ** 2)
    if w < 0.5 * par[P_HI_TAU] or spread < HI_MIN_SPREAD * w * cd * cd or tilt < HI_MIN_SPREAD * w * w:
        return math.nan
    dphi = (a[5] - (a[2] * a[6] + a[3] * a[7] + a[4] * a[8]) / w) / spread
    bx, by, bz = (a[6] - a[2] * dphi) / w, (a[7] - a[3] * dphi) / w, (a[8] - a[4] * dphi) / w
    ss = (
        a[9]
        - 2.0 * dphi * a[5]
        - 2.0 * (bx * a[6] + by * a[7] + bz * a[8])
        + dphi * dphi * a[1]
        + 2.0 * dphi * (bx * a[2] + by * a[3] + bz * a[4])
        + w * (bx * bx + by * by + bz * bz)
    )
    st[S_HI_B], st[S_HI_B + 1], st[S_HI_B + 2] = bx, by, bz
    # the same samples explained by a field d fixed in the room, m − Cᵀe = Cᵀd: its east–west part is exactly a
    # heading error in the offset's fit, which then took it for one and turned the heading by it (3-D turning past
    # 10 µT of steel: 10° off, gyro 0.35°); the offset must explain the samples better
    room = a[9] - (st[S_HI_N] ** 2 + st[S_HI_N + 1] ** 2 + st[S_HI_N + 2] ** 2) / w
    if not ss < w * (HI_RMS_GATE * nr) ** 2 or not ss < room:
        return math.nan
    st[S_HI_V] = 1.0
    # the field less the offset, through the same gates as a measured one
    cx, cy, cz = mx - bx, my - by, mz - bz
    nc = math.sqrt(cx * cx + cy * cy + cz * cz)
    dc, phc = _dip_azimuth(par, t0, t1, t2, t3, cx, cy, cz, nc)
    return phc if _field_agrees(st, par, nc, dc) else math.nan


@numba.njit(**_NJ)
def _init(st, par, ax, ay, az):
    """Level q_c from the first accelerometer sample unless q0 was put there (q_g = identity, δ as the new state
    set it: 0, or the heading branch to start from); fill the filter memories."""
    ux, uy, uz = par[P_UP], par[P_UP + 1], par[P_UP + 2]
    na = math.sqrt(ax * ax + ay * ay + az * az)
    st[S_QG] = 1.0
    st[S_QG + 1] = st[S_QG + 2] = st[S_QG + 3] = 0.0
    given = st[S_QC] ** 2 + st[S_QC + 1] ** 2 + st[S_QC + 2] ** 2 + st[S_QC + 3] ** 2 > 0.0  # q0 passed
    if not given and na > 0.0:
        vx, vy, vz = ax / na, ay / na, az / na
        # shortest rotation v → up
        cx, cy, cz = vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux
        c = vx * ux + vy * uy + vz * uz
        if c < -0.999999:  # upside down: half turn about any horizontal axis
            nx, ny, nz = par[P_NORTH], par[P_NORTH + 1], par[P_NORTH + 2]
            _store_q(st, S_QC, 0.0, nx, ny, nz)
        else:
            _store_q(st, S_QC, 1.0 + c, cx, cy, cz)
    elif not given:
        st[S_QC] = 1.0
        st[S_QC + 1] = st[S_QC + 2] = st[S_QC + 3] = 0.0
    a = (ax, ay, az)
    lp = a
    if given:
        # q0 gives the tilt: the tilt's low-pass starts steady at the specific force q0 predicts at rest (g·up in
        # the body, which is I now), not with a running mean from this sample, which in motion is off the vertical
        # and set the tilt at once, q0's overridden (BROAD 16 cut at 45.8 s, in fast motion: the tilt 20-50° off,
        # with the AoP the heading 175° off, exit 0)
        c0, c1, c2, c3 = st[S_QC], st[S_QC + 1], st[S_QC + 2], st[S_QC + 3]
        gx, gy, gz = _rot(c0, -c1, -c2, -c3, ux, uy, uz)
        lp = (par[P_GRAVITY] * gx, par[P_GRAVITY] * gy, par[P_GRAVITY] * gz)
        st[S_LP_T0] = -math.inf
    for j in range(3):
        for k in range(4):
            st[S_LP + 4 * j + k] = lp[j]
        st[S_RA + j] = a[j]
        st[S_RG + j] = 0.0
        st[S_RN + 3 + j] = a[j]
        st[S_RN + j] = 0.0
    for j in range(9):
        for k in range(4):
            st[S_LPC + 4 * j + k] = 1.0 if j % 4 == 0 else 0.0
    st[S_INIT] = 1.0


@numba.njit(**_NJ)
def _mag_update(st, par, t0, t1, t2, t3, mx, my, mz, nm, h):
    """The heading correction δ from one magnetometer sample (|m| = nm > 0, step h s) in the frame of
    t = q_c ⊗ q_g: the reference's start, gates, new-field candidate and the body-fixed offset's fit. Out of
    :func:`step`, which calls it only for a sample with a field: inlined there, its code made the 6D loop 25 %
    slower."""
    dip, phi = _dip_azimuth(par, t0, t1, t2, t3, mx, my, mz, nm)
    # the magnetometer's own clock: its start-up counts from its first sample (one that starts late, after the
    # tilt settled, got none: heading 11.6° vs VQF 1.9° on BROAD trial 07 with the field from 30 s),
    # and each sample weighs the time since the previous one (a magnetometer at 1/30 of the IMU rate, its rows
    # NaN between, had every time constant 30× longer: 2.0° vs VQF 0.55°)
    if st[S_M_SEEN] == 0.0:
        st[S_M_SEEN] = 1.0
        st[S_M_T1] = st[S_TIME] - h
        st[S_M_LAST] = st[S_TIME] - h
    hm = st[S_TIME] - st[S_M_LAST]
    st[S_M_LAST] = st[S_TIME]
    age = st[S_TIME] - st[S_M_T1]
    # the reference starts as the mean of the second half of the low-pass's start (the first tau_acc s):
    # a dip measured with the first, possibly accelerated, sample's tilt would reject every later sample,
    # and one sample's noise (≈ 1 µT) is a good part of the norm gate
    settling = age <= par[P_TAU_ACC]
    # the new-field candidate sees norm and dip low-passed over mag_current_tau: one sample's noise (≈ 1 µT, a
    # good part of the 5 % gate) reset a steady candidate every second or so, so a field learned at a
    # disturbed start was never replaced in motion. The use gate keeps the raw sample (it also rejects the
    # samples of fast rotations whose tilt is off)
    if st[S_M_LP] == 0.0:
        st[S_M_LP] = nm
        st[S_M_LP + 1] = dip
    else:
        am = 1.0 - math.exp(-hm / par[P_MAG_CUR_TAU]) if par[P_MAG_CUR_TAU] > 0.0 else 1.0
        st[S_M_LP] += am * (nm - st[S_M_LP])
        st[S_M_LP + 1] += am * (dip - st[S_M_LP + 1])
    cn, cd = st[S_M_LP], st[S_M_LP + 1]
    if st[S_M_REF_T] == 0.0 or age <= 0.5 * par[P_TAU_ACC]:
        st[S_M_NORM] = nm
        st[S_M_DIP] = dip
        st[S_M_REF_T] = 0.0
    ok = settling or _field_agrees(st, par, nm, dip)
    corr = False
    phc = 0.0
    st[S_MAG_CORR] = 0.0
    if ok:
        st[S_HI_OK] += hm
        if st[S_HI_OK] > HI_RESET_TIME:
            # the disturbance ended: its offset fit and the new-field candidate's time go. Not at one sample that
            # passes the gates by chance: a reference learned at a start in a disturbed field (BROAD 33 from 38 s,
            # 8 % off the Earth's) was never replaced, every few seconds a sample within 5 % of it restarting the
            # candidate's 20 s (22.9° heading RMSE)
            _hi_reset(st)
            st[S_M_DIST_T] = 0.0
    else:
        st[S_HI_OK] = 0.0
        if par[P_HI_TAU] > 0.0 and not settling:
            phc = _hard_iron(st, par, t0, t1, t2, t3, mx, my, mz, hm)
            corr = not math.isnan(phc)
    if ok:
        kr = hm / (st[S_M_REF_T] + hm) if settling else hm / max(par[P_TAU_MAG_REF], st[S_M_REF_T] + hm)
        st[S_M_REF_T] += hm
        st[S_M_NORM] += kr * (nm - st[S_M_NORM])
        st[S_M_DIP] += kr * (dip - st[S_M_DIP])
        err = -phi - st[S_DELTA]
        err = math.atan2(math.sin(err), math.cos(err))
        if st[S_M_INIT] == 0.0:
            st[S_DELTA] = -phi
            st[S_M_INIT] = 1.0
        elif settling:
            # while the tilt settles the heading follows the field, low-passed over MAG_SETTLE_TAU; then the
            # mean of the samples since, growing to the time constant tau_mag (a heading taken with a
            # start's tilt would take tau_mag's several times to fade)
            st[S_DELTA] += hm / max(min(age, MAG_SETTLE_TAU), hm) * err
        else:
            st[S_DELTA] += _heading_gain(st, par, hm, age) * err
        st[S_MAG_USED] = 1.0
    else:
        if st[S_M_T0] == 0.0 and age < par[P_TAU_ACC] + par[P_TAU_MAG] and st[S_M_T1] < par[P_TAU_ACC]:
            # the heading's first running mean (tau_mag s) takes every sample, as VQF's start: the reference
            # was learned in 2 s of a start that may be in motion or in a disturbed field, and is no more
            # trustworthy than the samples it would reject. Not for a magnetometer that starts after the tilt
            # settled: its reference's dip is sound, and a magnet 8 s after a late start was followed (trial 33)
            err = -phi - st[S_DELTA]
            err = math.atan2(math.sin(err), math.cos(err))
            st[S_DELTA] += hm / max(age - par[P_TAU_ACC], hm) * err
            corr = False  # the start's running mean has taken the sample
        # a new, steady field (moved to another place) becomes the reference after mag_new_time
        if st[S_M_DIST_T] == 0.0:
            st[S_M_C_NORM] = cn
            st[S_M_C_DIP] = cd
        kc = hm / max(1.0, st[S_M_DIST_T] + hm)
        st[S_M_C_NORM] += kc * (cn - st[S_M_C_NORM])
        st[S_M_C_DIP] += kc * (cd - st[S_M_C_DIP])
        if (
            abs(cn - st[S_M_C_NORM]) < par[P_MAG_NORM_TH] * st[S_M_C_NORM]
            and abs(cd - st[S_M_C_DIP]) < par[P_MAG_DIP_TH]
        ):
            st[S_M_DIST_T] += hm
        else:
            st[S_M_DIST_T] = 0.0
        # ... or sooner when the reference itself was seen for less time (at least tau_acc): a reference learned
        # at a start in a disturbed field loses to a field steady for longer
        t_new = min(par[P_MAG_NEW_TIME], max(st[S_M_REF_T], par[P_TAU_ACC]))
        if st[S_M_DIST_T] > t_new:
            if st[S_M_REF_T] < par[P_MAG_NEW_TIME]:
                # the replaced reference was seen for less time than the new one: δ taken from it weighs
                # no more than the new field's samples; the heading restarts its running mean
                st[S_M_T0] = age
            st[S_M_NORM] = st[S_M_C_NORM]
            st[S_M_DIP] = st[S_M_C_DIP]
            st[S_M_REF_T] = hm
            st[S_M_DIST_T] = 0.0
            _hi_reset(st)  # the offset's fit was against the old reference
            corr = False
        if corr:
            # the field less the fitted body-fixed offset agrees with the reference: it holds the heading
            err = -phc - st[S_DELTA]
            err = math.atan2(math.sin(err), math.cos(err))
            st[S_DELTA] += _heading_gain(st, par, hm, age) * err
            st[S_MAG_USED] = 1.0
            st[S_MAG_CORR] = 1.0


@numba.njit(**_NJ)
def _rest_lp(st, par, ix, iy, iz, lx, ly, lz, h):
    """At rest the specific force is gravity, which needs less averaging than motion: the low-passed force in I
    (lx, ly, lz, over ``tau_acc``) is replaced by a first-order low-pass of it (ix, iy, iz) over ``rest_tau_acc``,
    started from the low-pass when rest begins (or the start's running mean ends at rest), and the Butterworth
    memories are held at its value (motion then resumes from it). Returns the force the tilt correction takes."""
    if st[S_REST_LP + 3] == 0.0:
        st[S_REST_LP] = lx
        st[S_REST_LP + 1] = ly
        st[S_REST_LP + 2] = lz
        st[S_REST_LP + 3] = 1.0
    a = 1.0 - math.exp(-h / par[P_REST_TAU_ACC])
    st[S_REST_LP] += a * (ix - st[S_REST_LP])
    st[S_REST_LP + 1] += a * (iy - st[S_REST_LP + 1])
    st[S_REST_LP + 2] += a * (iz - st[S_REST_LP + 2])
    for j in range(3):
        m = S_LP + 4 * j
        st[m] = st[m + 1] = st[m + 2] = st[m + 3] = st[S_REST_LP + j]
    return st[S_REST_LP], st[S_REST_LP + 1], st[S_REST_LP + 2]


@numba.njit(**_NJ)
def step(st, par, gx, gy, gz, ax, ay, az, mx, my, mz, h):
    """Advance one sample: gyr (rad/s), acc (m/s²), mag (any unit; NaN = none), step h (s). Writes q_b^n to
    st[S_Q:S_Q+4] and the per-sample flags; True. A non-finite gyr, acc or h leaves the state as it was: False
    (a NaN there had made every later output NaN)."""
    if not math.isfinite(gx + gy + gz + ax + ay + az + h):
        return False
    if st[S_INIT] == 0.0:
        _init(st, par, ax, ay, az)
    st[S_TIME] += h
    st[S_G_LAST] = gx
    st[S_G_LAST + 1] = gy
    st[S_G_LAST + 2] = gz
    ux, uy, uz, nx, ny, nz, wx, wy, wz = _axes(par)
    # --- rest detection: deviation from first-order low-passes, in physical units -----------------------
    if st[S_RDT] != h:
        st[S_RDT] = h
        st[S_RDT + 1] = 1.0 - math.exp(-h / par[P_REST_TAU])
        st[S_RN + 6] = 1.0 - math.exp(-h / REST_BAND_TAU)
    al = st[S_RDT + 1]
    be = st[S_RN + 6]
    dg = 0.0
    da = 0.0
    raw = (gx, gy, gz, ax, ay, az)
    for j in range(6):  # the band limit (see REST_BAND_TAU)
        st[S_RN + j] += be * (raw[j] - st[S_RN + j])
    g = (st[S_RN], st[S_RN + 1], st[S_RN + 2])
    a = (st[S_RN + 3], st[S_RN + 4], st[S_RN + 5])
    for j in range(3):
        st[S_RG + j] += al * (g[j] - st[S_RG + j])
        st[S_RA + j] += al * (a[j] - st[S_RA + j])
        dg += (g[j] - st[S_RG + j]) ** 2
        da += (a[j] - st[S_RA + j]) ** 2
    rg2 = par[P_REST_GYR] ** 2
    still = dg < rg2 and da < par[P_REST_ACC] ** 2
    clip = par[P_BIAS_CLIP]
    if still and abs(st[S_RG]) <= clip and abs(st[S_RG + 1]) <= clip and abs(st[S_RG + 2]) <= clip:
        st[S_REST_T] += h
    else:
        st[S_REST_T] = 0.0
    rest = st[S_REST_T] >= par[P_REST_TIME]
    st[S_REST] = 1.0 if rest else 0.0
    if not rest:
        for j in range(3):
            _step_reset(st, j)
    # --- bias: random walk, rest measurement -------------------------------------------------------------
    qrw = par[P_BIAS_RW] ** 2 * h
    st[S_P] += qrw
    st[S_P + 4] += qrw
    st[S_P + 8] += qrw
    if rest:
        r = par[P_BIAS_REST] ** 2 / h
        for j in range(3):
            # a bias step (innovation beyond 3σ of the low-passed gyro for STEP_TAUS rest_tau s, the rate flat
            # over that time) resets that axis to its prior σ. Until it has lasted that long the sample teaches
            # nothing: it may be the start of a motion the rest detector has not seen yet (it lags ~0.25 s behind
            # a smooth start), and a reset there took the turning gyro for the bias (simulated flight: 0.3 °/s
            # bias learned at rest, 0.005 °/s after the first 0.25 s of motion, and the 60-s inclination 1.4 ->
            # 2.8° behind the motion gate)
            z = st[S_RG + j] - st[S_BIAS + j]
            if z * z > 9.0 * (st[S_P + 4 * j] + par[P_BIAS_REST] ** 2 / par[P_REST_TAU]):
                st[S_STEP_T + j] += h
                if st[S_STEP_T + j] < STEP_TAUS * par[P_REST_TAU]:
                    _step_add(st, j, g[j], st[S_STEP_T + j] >= 0.5 * STEP_TAUS * par[P_REST_TAU])
                    continue
                # a step is flat: the smooth start of a turn the rest detector has not seen yet (a ramp under
                # 4 °/s² passes its still test) rises between the halves of that time, and was taken for the
                # bias (a level body yawing from rest: 1.5 °/s on z, its heading 46° off in 40 s)
                if not _step_flat(st, j):
                    _step_reset(st, j)
                    continue
                st[S_P + 4 * j] = max(st[S_P + 4 * j], par[P_BIAS_SIGMA0] ** 2, z * z)
            _step_reset(st, j)
            hj0 = 1.0 if j == 0 else 0.0
            hj1 = 1.0 if j == 1 else 0.0
            hj2 = 1.0 if j == 2 else 0.0
            _bias_update(st, hj0, hj1, hj2, st[S_RG + j] - st[S_BIAS + j], r, clip)
    # --- gyro strapdown in the almost-inertial frame ------------------------------------------------------
    bx, by, bz = st[S_BIAS], st[S_BIAS + 1], st[S_BIAS + 2]
    d0, d1, d2, d3 = _rotvec_q((gx - bx) * h, (gy - by) * h, (gz - bz) * h)
    q0, q1, q2, q3 = _qmul(st[S_QG], st[S_QG + 1], st[S_QG + 2], st[S_QG + 3], d0, d1, d2, d3)
    _store_q(st, S_QG, q0, q1, q2, q3)
    g0, g1, g2, g3 = st[S_QG], st[S_QG + 1], st[S_QG + 2], st[S_QG + 3]
    # --- accelerometer low-passed in I, tilt correction ----------------------------------------------------
    na = math.sqrt(ax * ax + ay * ay + az * az)
    st[S_ACC_USED] = 0.0
    st[S_BIAS_MOTION] = 0.0
    c0, c1, c2, c3 = st[S_QC], st[S_QC + 1], st[S_QC + 2], st[S_QC + 3]
    if na > 0.0 and math.isfinite(na):
        st[S_ACC_USED] = 1.0
        hn = st[S_HNOM]
        ns = _butter(st, par, h)
        if ns > 1 and h - hn >= GAP_RESTART_S:
            st[S_LP_T0] = st[S_TIME] - h  # the running mean starts again with this sample
            st[S_AVG_N] = 0.0
        n = 0.0  # the first tau_acc seconds (from the start or a gap's end): the running mean (see _lp)
        if st[S_TIME] - st[S_LP_T0] <= par[P_TAU_ACC]:
            st[S_AVG_N] += 1.0
            n = st[S_AVG_N]
        ix, iy, iz = _rot(g0, g1, g2, g3, ax, ay, az)
        lx, ly, lz = _lp(st, 0, ix, S_LP, n, ns), _lp(st, 1, iy, S_LP, n, ns), _lp(st, 2, iz, S_LP, n, ns)
        if rest and n == 0.0 and par[P_REST_TAU_ACC] > 0.0:
            # a break after motion left the tau_acc low-pass still holding the motion for seconds: the tilt
            # settled 0.55 -> 0.08° in 9 s (VQF, tau 3 s: 0.02°); BROAD trials with three 10-s breaks put in,
            # online 0.695 -> 0.662° (VQF 0.704°), their whole trials (rest only at the ends) unchanged
            lx, ly, lz = _rest_lp(st, par, ix, iy, iz, lx, ly, lz, h)
        else:
            st[S_REST_LP + 3] = 0.0
        # C_b^I low-passed like the specific force: the correction rate responds to the bias through it
        _lp(st, 0, g0 * g0 + g1 * g1 - g2 * g2 - g3 * g3, S_LPC, n, ns)
        _lp(st, 1, 2.0 * (g1 * g2 - g0 * g3), S_LPC, n, ns)
        _lp(st, 2, 2.0 * (g1 * g3 + g0 * g2), S_LPC, n, ns)
        _lp(st, 3, 2.0 * (g1 * g2 + g0 * g3), S_LPC, n, ns)
        _lp(st, 4, g0 * g0 - g1 * g1 + g2 * g2 - g3 * g3, S_LPC, n, ns)
        _lp(st, 5, 2.0 * (g2 * g3 - g0 * g1), S_LPC, n, ns)
        _lp(st, 6, 2.0 * (g1 * g3 - g0 * g2), S_LPC, n, ns)
        _lp(st, 7, 2.0 * (g2 * g3 + g0 * g1), S_LPC, n, ns)
        _lp(st, 8, g0 * g0 - g1 * g1 - g2 * g2 + g3 * g3, S_LPC, n, ns)
        nl = math.sqrt(lx * lx + ly * ly + lz * lz)
        if nl > 0.0:
            vx, vy, vz = _rot(c0, c1, c2, c3, lx / nl, ly / nl, lz / nl)
            # rotation vector e that turns v onto up (e ⊥ up: the heading is untouched)
            cx, cy, cz = vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux
            sn = math.sqrt(cx * cx + cy * cy + cz * cz)
            cs = vx * ux + vy * uy + vz * uz
            ang = math.atan2(sn, cs)
            if sn > 0.0:
                f = ang / sn
                ex, ey, ez = cx * f, cy * f, cz * f
                e0, e1, e2, e3 = _rotvec_q(ex, ey, ez)
                c0, c1, c2, c3 = _qmul(e0, e1, e2, e3, c0, c1, c2, c3)
                _store_q(st, S_QC, c0, c1, c2, c3)
                c0, c1, c2, c3 = st[S_QC], st[S_QC + 1], st[S_QC + 2], st[S_QC + 3]
                # in motion: the correction rate is the horizontal projection of −C_b^n δb, as seen through
                # the low-pass (rows of C(q_c)·LP(C_b^I))
                gn = math.sqrt((gx - bx) ** 2 + (gy - by) ** 2 + (gz - bz) ** 2)
                if (
                    not rest
                    and par[P_BIAS_MOTION] > 0.0
                    and (par[P_MOTION_MAX_GYR] <= 0.0 or gn < par[P_MOTION_MAX_GYR])
                    and abs(nl - par[P_GRAVITY]) < par[P_MOTION_MAX_ACC]
                ):
                    st[S_BIAS_MOTION] = 1.0
                    r0 = par[P_BIAS_MOTION] ** 2 / h
                    L = S_LPC
                    P = st[S_P : S_P + 9]
                    ax_, ay_, az_ = _motion_row(st, L, c0, c1, c2, c3, nx, ny, nz)
                    bx_, by_, bz_ = _motion_row(st, L, c0, c1, c2, c3, wx, wy, wz)
                    z0 = -(ex * nx + ey * ny + ez * nz) / h
                    z1 = -(ex * wx + ey * wy + ez * wz) / h
                    qa, qb = _quad(P, ax_, ay_, az_), _quad(P, bx_, by_, bz_)
                    s_tr = qa + qb
                    # a correction rate beyond the bias bound is not bias (VQF clips it too): the start's levelling,
                    # an acceleration the low-pass let through. Clipped as a horizontal vector and one variance for
                    # both rows (R = r·I), so that the update does not depend on the heading (per-row clips and
                    # floors made the tilt error 3.6-5.0° by the initial heading on one simulated flight).
                    zn = math.sqrt(z0 * z0 + z1 * z1)
                    # a correction rate far beyond what the bias's uncertainty and the update's noise (its density
                    # over tau_acc, a rate: no dependence on the sampling rate) explain is a sustained acceleration,
                    # not bias: a vehicle's turns and braking held the low-passed force off the vertical for seconds,
                    # and the update took it as bias (simulated 60-s flights from rest: 6D heading drift up to 14°
                    # online and 70° offline, the bias at the 2 °/s clip; VQF ≤ 2.4°). Skipped beyond motion_gate
                    # σ: ≤ 1.8°. Hand-held BROAD motion seldom reaches it (nine trials: 0.568 -> 0.570° online)
                    gate = par[P_MOTION_GATE]
                    skip = gate > 0.0 and zn * zn > gate * gate * (
                        par[P_BIAS_MOTION] ** 2 / par[P_TAU_ACC] + 0.5 * s_tr
                    )
                    if skip:
                        st[S_BIAS_MOTION] = 0.0
                    elif zn > clip:
                        z0 *= clip / zn
                        z1 *= clip / zn
                    # the bias closes a loop through the low-pass (bias → q_g → LP → correction → bias): with the
                    # prior σ (a recording that starts in motion, no rest yet) the gain P/r would make it ~1000×
                    # faster than tau_acc, and the bias rings between the clips (BROAD cut in motion: ±2 °/s for a
                    # minute; heading 10–18° off). The variance is floored at bias_loop·tau_acc·P·|row|/h, P the
                    # bias variance along the row's direction (the mean of the two rows'): the loop's time constant
                    # is at least bias_loop·tau_acc/|row| and the gain per unit correction rate at most
                    # h/(bias_loop·tau_acc), however short the rows. Floored with the rows' own P (∝ |row|²) that
                    # gain grew as 1/|row|: a fast rotation about changing axes averages LP(C_b^I) down to short
                    # rows, and a lever arm's centripetal force became bias (BROAD trial 29 cut in motion: z at the
                    # 2 °/s clip within 10 s, 6D heading drift 35° RMSE; now 12°, VQF 5°). A floor ∝ P alone (gain
                    # ∝ |row|) gave 5° there but left a clean simulated fast rotation's bias 0.056 °/s off after
                    # 300 s (0.001 °/s). Once P is small the variance is r0.
                    if not skip:
                        na = max(ax_ * ax_ + ay_ * ay_ + az_ * az_, 1e-24)
                        nb = max(bx_ * bx_ + by_ * by_ + bz_ * bz_, 1e-24)
                        s_dir = 0.5 * (qa / math.sqrt(na) + qb / math.sqrt(nb))
                        r = max(r0, par[P_BIAS_LOOP] * par[P_TAU_ACC] * s_dir / h)
                        _bias_update(st, ax_, ay_, az_, z0, r, clip)
                        _bias_update(st, bx_, by_, bz_, z1, r, clip)
    # --- magnetometer heading ------------------------------------------------------------------------------
    t0, t1, t2, t3 = _qmul(c0, c1, c2, c3, g0, g1, g2, g3)
    st[S_MAG_USED] = 0.0
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    if nm > 0.0 and math.isfinite(nm):
        _mag_update(st, par, t0, t1, t2, t3, mx, my, mz, nm, h)
    h0, h1, h2, h3 = _rotvec_q(st[S_DELTA] * ux, st[S_DELTA] * uy, st[S_DELTA] * uz)
    o0, o1, o2, o3 = _qmul(h0, h1, h2, h3, t0, t1, t2, t3)
    lat = par[P_LATENCY]
    if lat != 0.0:
        # the samples are late by ``latency``: the output is the attitude then, predicted with the current rate
        p0, p1, p2, p3 = _rotvec_q((gx - bx) * lat, (gy - by) * lat, (gz - bz) * lat)
        o0, o1, o2, o3 = _qmul(o0, o1, o2, o3, p0, p1, p2, p3)
    _store_q(st, S_Q, o0, o1, o2, o3)
    return True


@numba.njit(**_NJ)
def run(st, par, gyr, acc, mag, dt, out, flags, bias, moff, restart=-1):
    """Batch loop over :func:`step`: out (N, 4) q_b^n; flags (N, 4) int8 rest, acc used, mag used, motion
    bias update; bias (N, 3) rad/s; moff (N, 3) the body-fixed offset the used field was taken less (0: the
    field as measured). ``mag`` and ``moff`` may have 0 rows (none); ``dt`` 1 or N entries; the magnetic part of
    the state restarts before row ``restart`` (:func:`mag_restart`; -1: none)."""
    n = gyr.shape[0]
    one = dt.shape[0] == 1
    nan = np.nan
    # two loops: the one without a magnetometer passes NaN constants, so the compiler drops the magnetometer's
    # code from it (one loop choosing per sample ran 6D 25 % slower once that code grew)
    if mag.shape[0] == n:
        for i in range(n):
            h = dt[0] if one else dt[i]
            g, a, m = gyr[i], acc[i], mag[i]
            if i == restart:
                mag_restart(st)
            step(st, par, g[0], g[1], g[2], a[0], a[1], a[2], m[0], m[1], m[2], h)
            _emit(st, i, out, flags, bias)
            c = st[S_MAG_CORR] != 0.0
            for k in range(3):
                moff[i, k] = st[S_HI_B + k] if c else 0.0
    else:
        for i in range(n):
            h = dt[0] if one else dt[i]
            g, a = gyr[i], acc[i]
            step(st, par, g[0], g[1], g[2], a[0], a[1], a[2], nan, nan, nan, h)
            _emit(st, i, out, flags, bias)


@numba.njit(**_NJ)
def _pol_update(st, par, sx, sy, sz, cbm, aop, min_d2, h):
    """The heading correction δ from one skylight-polarization sample (the unit sun vector (sx, sy, sz) in n, the
    sensor mounting ``cbm`` C_b^m, the measured AoP ``aop`` rad, ``min_d2`` sin² of the least sun separation from
    the viewing axis; ``h`` s the step), after :func:`step`: the heading φ at which the AoP predicted through R_up(φ) ⊗ t
    (t = q_c ⊗ q_g) and C_b^m equals the measured one, in closed form (the E-vector (y, −x) of the sun at
    (x, y, ·) in m parallel to (cos α, sin α): A + B cos φ + C sin φ = 0), of its two roots the one nearest δ
    (the AoP is axial: a level sensor's roots are π apart; the first used sample takes the other one where
    S_P_OTHER is set, the start on the other heading branch). δ moves toward it with the gain of a running mean
    from the first used sample (which sets it there, whatever a magnetometer set: the polarization's heading is
    the true one, and :func:`_pol_gate` then holds the field to it) growing to hp/tau_pol (hp the time since the
    previous sample); the output st[S_Q] is turned by the change. Returns the
    sample's POL_* outcome. Measurement model: :func:`optinav.attitude._kernels._model`. The root depends on the
    attitude and the sun at the sample alone, not on the direction of time: the offline backward pass takes the
    samples alike (the gain's clock, S_TIME, runs on in either)."""
    ux, uy, uz = par[P_UP], par[P_UP + 1], par[P_UP + 2]
    t0, t1, t2, t3 = _qmul(
        st[S_QC], st[S_QC + 1], st[S_QC + 2], st[S_QC + 3], st[S_QG], st[S_QG + 1], st[S_QG + 2], st[S_QG + 3]
    )
    hp = st[S_TIME] - st[S_P_LAST] if st[S_P_LAST] > 0.0 else h
    st[S_P_LAST] = st[S_TIME]
    st[S_POL_USED] = 0.0
    # R_up(−φ)s = su·u + cos φ·s_h − sin φ·(u × s): three fixed vectors, each into the body (t*) and m
    su = sx * ux + sy * uy + sz * uz
    hx, hy, hz = sx - su * ux, sy - su * uy, sz - su * uz
    vx, vy, vz = -(uy * hz - uz * hy), -(uz * hx - ux * hz), -(ux * hy - uy * hx)
    xs = np.empty(3)
    ys = np.empty(3)
    for k in range(3):
        if k == 0:
            ax, ay, az = _rot(t0, -t1, -t2, -t3, su * ux, su * uy, su * uz)
        elif k == 1:
            ax, ay, az = _rot(t0, -t1, -t2, -t3, hx, hy, hz)
        else:
            ax, ay, az = _rot(t0, -t1, -t2, -t3, vx, vy, vz)
        xs[k] = cbm[0, 0] * ax + cbm[0, 1] * ay + cbm[0, 2] * az
        ys[k] = cbm[1, 0] * ax + cbm[1, 1] * ay + cbm[1, 2] * az
    de = st[S_DELTA]
    cd, sd = math.cos(de), math.sin(de)
    x = xs[0] + xs[1] * cd + xs[2] * sd
    y = ys[0] + ys[1] * cd + ys[2] * sd
    if x * x + y * y < min_d2:  # at the current heading, as every estimator's model judges it
        return POL_NEAR_ZENITH
    ca, sa = math.cos(aop), math.sin(aop)
    a = xs[0] * ca + ys[0] * sa
    b = xs[1] * ca + ys[1] * sa
    c = xs[2] * ca + ys[2] * sa
    r = math.sqrt(b * b + c * c)
    if not (r > 0.0 and abs(a) <= r):
        return POL_UNRESOLVED
    p0, w = math.atan2(c, b), math.acos(-a / r)
    e1 = p0 + w - de
    e2 = p0 - w - de
    e1 = math.atan2(math.sin(e1), math.cos(e1))
    e2 = math.atan2(math.sin(e2), math.cos(e2))
    err = e1 if abs(e1) <= abs(e2) else e2
    if st[S_P_INIT] == 0.0 and st[S_P_OTHER] != 0.0:  # the start on the other heading branch
        err = e2 if abs(e1) <= abs(e2) else e1
    phi = de + err
    cp, sp = math.cos(phi), math.sin(phi)
    x = xs[0] + xs[1] * cp + xs[2] * sp
    y = ys[0] + ys[1] * cp + ys[2] * sp
    dx, dy = xs[2] * cp - xs[1] * sp, ys[2] * cp - ys[1] * sp
    d = x * x + y * y
    if not abs(x * dy - y * dx) >= POL_MIN_SLOPE * d:  # |dα′/dφ| = |x y′ − y x′| / d
        return POL_UNRESOLVED
    if st[S_P_INIT] == 0.0:
        st[S_P_T0] = st[S_TIME] - hp
    k = min(1.0, hp / min(par[P_TAU_POL], max(st[S_TIME] - st[S_P_T0], hp)))
    st[S_P_INIT] = 1.0
    st[S_P_USED_T] = st[S_TIME]
    _turn_heading(st, par, k * err)
    st[S_POL_USED] = 1.0
    return POL_USED


@numba.njit(**_NJ)
def _turn_heading(st, par, dd):
    """δ changed by ``dd`` rad after :func:`step`: its output R_up(δ) ⊗ t (⊗ the latency's prediction) turned by
    R_up(dd) with it."""
    st[S_DELTA] += dd
    h0, h1, h2, h3 = _rotvec_q(dd * par[P_UP], dd * par[P_UP + 1], dd * par[P_UP + 2])
    o0, o1, o2, o3 = _qmul(h0, h1, h2, h3, st[S_Q], st[S_Q + 1], st[S_Q + 2], st[S_Q + 3])
    _store_q(st, S_Q, o0, o1, o2, o3)


@numba.njit(**_NJ)
def _pol_gate(st, par, mx, my, mz, d0):
    """Undo the magnetometer's heading correction of the sample :func:`step` just took (δ back to ``d0``, the
    sample not used) when its field's azimuth lies beyond mag_pol_th of ``d0`` while polarization holds the
    heading (a sample of it used within the last tau_pol s): a disturbance within the norm and dip gates (a field
    turned 40° with both kept) would otherwise pull the heading by tau_pol/(tau_pol + tau_mag) of it."""
    th = par[P_MAG_POL_TH]
    if st[S_MAG_USED] == 0.0 or th <= 0.0 or st[S_P_INIT] == 0.0 or st[S_TIME] - st[S_P_USED_T] > par[P_TAU_POL]:
        return
    if st[S_MAG_CORR] != 0.0:  # used less the body-fixed offset fitted while disturbed
        mx, my, mz = mx - st[S_HI_B], my - st[S_HI_B + 1], mz - st[S_HI_B + 2]
    t0, t1, t2, t3 = _qmul(
        st[S_QC], st[S_QC + 1], st[S_QC + 2], st[S_QC + 3], st[S_QG], st[S_QG + 1], st[S_QG + 2], st[S_QG + 3]
    )
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    _, phi = _dip_azimuth(par, t0, t1, t2, t3, mx, my, mz, nm)
    e = -phi - d0
    if abs(math.atan2(math.sin(e), math.cos(e))) <= th:
        return
    _turn_heading(st, par, d0 - st[S_DELTA])
    st[S_MAG_USED] = 0.0
    st[S_MAG_CORR] = 0.0


@numba.njit(**_NJ)
def run_pol(st, par, gyr, acc, mag, dt, use, sn, cbm, aop, min_d2, out, flags, bias, moff, pol, restart=-1):
    """:func:`run` with skylight polarization: after each :func:`step`, :func:`_pol_update` where ``use`` (N,)
    (sun ``sn`` (1 or N, 3) in n, mounting ``cbm`` (3, 3), AoP ``aop`` (N,) rad, ``min_d2``); ``pol`` (N,) int8
    its POL_* outcome per sample. A loop of its own: the 6D and 9D loops of :func:`run` stay as they are."""
    n = gyr.shape[0]
    one = dt.shape[0] == 1
    has = mag.shape[0] == n
    nan = np.nan
    for i in range(n):
        h = dt[0] if one else dt[i]
        g, a = gyr[i], acc[i]
        if has:
            m = mag[i]
            if i == restart:
                mag_restart(st)
            d0 = st[S_DELTA]
            ok = step(st, par, g[0], g[1], g[2], a[0], a[1], a[2], m[0], m[1], m[2], h)
            if ok:
                _pol_gate(st, par, m[0], m[1], m[2], d0)
        else:
            ok = step(st, par, g[0], g[1], g[2], a[0], a[1], a[2], nan, nan, nan, h)
        pol[i] = POL_NONE
        st[S_POL_USED] = 0.0
        if ok and use[i]:
            j = i if sn.shape[0] > 1 else 0
            pol[i] = _pol_update(st, par, sn[j, 0], sn[j, 1], sn[j, 2], cbm, aop[i], min_d2, h)
        _emit(st, i, out, flags, bias)
        if has:
            c = st[S_MAG_CORR] != 0.0
            for k in range(3):
                moff[i, k] = st[S_HI_B + k] if c else 0.0


@numba.njit(**_NJ)
def _emit(st, i, out, flags, bias):
    """Row i of :func:`run`'s per-sample outputs from the state after the sample."""
    for k in range(4):
        out[i, k] = st[S_Q + k]
    flags[i, 0] = st[S_REST] != 0.0
    flags[i, 1] = st[S_ACC_USED] != 0.0
    flags[i, 2] = st[S_MAG_USED] != 0.0
    flags[i, 3] = st[S_BIAS_MOTION] != 0.0
    for k in range(3):
        bias[i, k] = st[S_BIAS + k]


# step6 and step9 hand step float64 values whatever the sequences hold: a float32 array, an int step or a float32
# magnetometer each compiled the whole step again (~7 s on a cold cache, its helpers with it) and ran part of it in
# float32; these small wrappers still compile once per kind of sequence (0.25 s)
@numba.njit(**_NJ)
def step6(st, par, g, a, h):
    """:func:`step` with gyr and acc as 3-sequences (arrays or tuples) and no magnetometer."""
    f = np.float64  # numba's float() keeps a float32 a float32
    return step(st, par, f(g[0]), f(g[1]), f(g[2]), f(a[0]), f(a[1]), f(a[2]), np.nan, np.nan, np.nan, f(h))


@numba.njit(**_NJ)
def step9(st, par, g, a, m, h):
    """:func:`step` with gyr, acc and mag as 3-sequences (arrays or tuples)."""
    f = np.float64  # numba's float() keeps a float32 a float32
    return step(st, par, f(g[0]), f(g[1]), f(g[2]), f(a[0]), f(a[1]), f(a[2]), f(m[0]), f(m[1]), f(m[2]), f(h))


@numba.njit(**_NJ)
def front_force(q, up, acc, out):
    """The input stage's specific force: ``out[i] = C(q[i])ᵀ up · ‖acc[i]‖`` — the estimated vertical in body axes
    with the measured norm; q (N, 4) q_b^n, up (3,), acc (N, 3) m/s², out (N, 3) m/s² (one loop for a chunk and
    for one streamed sample alike)."""
    for i in range(q.shape[0]):
        # rotate up by q*: t = 2 u×v, v' = v + w t + u×t with u = −q_vec
        w, ux, uy, uz = q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3]
        tx = 2.0 * (uy * up[2] - uz * up[1])
        ty = 2.0 * (uz * up[0] - ux * up[2])
        tz = 2.0 * (ux * up[1] - uy * up[0])
        na = math.sqrt(acc[i, 0] * acc[i, 0] + acc[i, 1] * acc[i, 1] + acc[i, 2] * acc[i, 2])
        out[i, 0] = (up[0] + w * tx + (uy * tz - uz * ty)) * na
        out[i, 1] = (up[1] + w * ty + (uz * tx - ux * tz)) * na
        out[i, 2] = (up[2] + w * tz + (ux * ty - uy * tx)) * na


@numba.njit(**_NJ)
def strapdown(gyr, bias, dt, out, q):
    """q_g = q_b^I of the bias-corrected gyro for every sample, the arithmetic of :func:`step`, from ``q`` (4,),
    the attitude before the first sample (the identity for a whole log), which is left at the last sample's (a
    log strapped down in blocks); ``bias`` (N, 3) rad/s, ``dt`` 1 or N entries."""
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    for i in range(gyr.shape[0]):
        h = dt[i] if dt.shape[0] > 1 else dt[0]
        d0, d1, d2, d3 = _rotvec_q(
            (gyr[i, 0] - bias[i, 0]) * h, (gyr[i, 1] - bias[i, 1]) * h, (gyr[i, 2] - bias[i, 2]) * h
        )
        q0, q1, q2, q3 = _qmul(q0, q1, q2, q3, d0, d1, d2, d3)
        n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0, q1, q2, q3 = q0 / n, q1 / n, q2 / n, q3 / n
        out[i, 0] = q0
        out[i, 1] = q1
        out[i, 2] = q2
        out[i, 3] = q3
    q[0], q[1], q[2], q[3] = q0, q1, q2, q3


@numba.njit(**_NJ)
def heading_forward(d, u, used, sb, dt, tau, sa2, state, x, p, xr, phi, normal):
    """Forward Kalman filter of the offline heading offset: ``d`` (N,) rad, the field's azimuth in the attitude
    whose heading the gyro carries, measures an offset x that is a random walk; ``x``, ``p`` (N,) its filtered
    value and variance (NaN before the first sample ``used``). Variance unit: the azimuth's noise density, taken
    as its scatter ``sa2`` (rad²) correlated over ``tau`` s. A magnetometer sample after a step hm has variance
    1/hm, so a slow magnetometer weighs as much per second; the walk grows 1/tau² per s (with a perfect gyro the
    smoother averages over about ``tau`` s at any rate) plus sb²·tau/(sa2·tau): a vertical gyro-bias error ``sb``
    (N,) rad/s held over tau s (``sa2`` 0: that term off).

    With ``u`` (N, 3), the up direction in body axes, the offset is that walk plus Φᵀδb, Φ = ∫u dt (s, ``phi``
    (N, 3)): the heading a constant error δb (rad/s, body axes) of the gyro bias turns. The same gains filter the
    columns of Φ (``xr`` (N, 3)), and ``normal`` (12,) sums their innovations' normal equations
    [Σ ν_Φ ν_Φᵀ/F (9), Σ ν_Φ ν_d/F (3)] (F the innovation variance): δb's information (de Jong's augmented
    filter), so that the smoothed offset is linear in δb (:func:`heading_backward`). ``u`` (0, 3): none.
    ``state`` (9,) [x, P, s since the previous finite sample, Φ (3), filtered Φ (3)] carried from block to block
    (P 0: not started); ``dt`` 1 or N steps (s)."""
    reg = u.shape[0] > 0
    for i in range(d.shape[0]):
        h = dt[i] if dt.shape[0] > 1 else dt[0]
        state[2] += h
        if reg:
            for j in range(3):
                state[3 + j] += h * u[i, j]
                phi[i, j] = state[3 + j]
        if state[1] > 0.0:
            state[1] += h * _walk(sb[i], tau, sa2)
        if math.isfinite(d[i]):
            hm = state[2]
            state[2] = 0.0
            if used[i]:
                r = 1.0 / hm
                if state[1] == 0.0:
                    state[0] = d[i]
                    state[1] = r
                    for j in range(3):
                        state[6 + j] = state[3 + j]
                else:
                    e = d[i] - state[0]
                    e = math.atan2(math.sin(e), math.cos(e))
                    f = state[1] + r
                    k = state[1] / f
                    state[0] += k * e
                    state[1] *= 1.0 - k
                    if reg:
                        e0 = state[3] - state[6]
                        e1 = state[4] - state[7]
                        e2 = state[5] - state[8]
                        normal[0] += e0 * e0 / f
                        normal[1] += e0 * e1 / f
                        normal[2] += e0 * e2 / f
                        normal[4] += e1 * e1 / f
                        normal[5] += e1 * e2 / f
                        normal[8] += e2 * e2 / f
                        normal[9] += e0 * e / f
                        normal[10] += e1 * e / f
                        normal[11] += e2 * e / f
                        state[6] += k * e0
                        state[7] += k * e1
                        state[8] += k * e2
        x[i] = state[0] if state[1] > 0.0 else math.nan
        p[i] = state[1] if state[1] > 0.0 else math.nan
        if reg:
            for j in range(3):
                xr[i, j] = state[6 + j] if state[1] > 0.0 else math.nan


@numba.njit(**_NJ)
def _walk(sb, tau, sa2):
    """The heading offset's random-walk density per s in :func:`heading_forward`'s unit."""
    w = 1.0 / (tau * tau)
    if sa2 > 0.0:
        w *= 1.0 + sb * sb * tau * tau / sa2
    return w


@numba.njit(**_NJ)
def heading_backward(x, p, xr, sb, dt, tau, sa2, state, out, outr):
    """Rauch–Tung–Striebel pass over :func:`heading_forward`'s ``x``, ``p`` (N,) (the same ``sb``, ``tau``,
    ``sa2``), from the last sample to the first: ``out`` (N,) the smoothed offset (rad; NaN where no sample was
    used at all), and with the same gains ``outr`` (N, 3) the smoothed columns ``xr`` (N, 3) of Φ ((0, 3): none).
    ``state`` (6,) [smoothed offset of the next sample, 1 once started, that sample's walk variance (step ×
    density), smoothed Φ of the next sample (3)] carried from block to block (later block first)."""
    reg = xr.shape[0] > 0
    for j in range(x.shape[0]):
        i = x.shape[0] - 1 - j
        h = dt[i] if dt.shape[0] > 1 else dt[0]
        if not math.isfinite(x[i]):
            out[i] = state[0] if state[1] > 0.0 else math.nan  # before the first used sample: held from it
            if reg:
                for m in range(3):
                    outr[i, m] = state[3 + m] if state[1] > 0.0 else math.nan
        elif state[1] == 0.0:
            out[i] = x[i]
            if reg:
                for m in range(3):
                    outr[i, m] = xr[i, m]
            state[1] = 1.0
        else:
            c = p[i] / (p[i] + state[2])
            out[i] = x[i] + c * (state[0] - x[i])
            if reg:
                for m in range(3):
                    outr[i, m] = xr[i, m] + c * (state[3 + m] - xr[i, m])
        state[0] = out[i]
        if reg:
            for m in range(3):
                state[3 + m] = outr[i, m]
        state[2] = h * _walk(sb[i], tau, sa2)


@numba.njit(**_NJ)
def outer_sum(v, acc):
    """Adds to ``acc`` (10,) [Σ v vᵀ (9, row-major), count] the rows of ``v`` (N, 3), in order (a log in blocks
    sums alike)."""
    for i in range(v.shape[0]):
        for a in range(3):
            for b in range(3):
                acc[3 * a + b] += v[i, a] * v[i, b]
        acc[9] += 1.0


@numba.njit(**_NJ)
def azimuth_scatter(d, out, used, acc):
    """Adds to ``acc`` (2,) [Σ e², count] the squared azimuth residuals e = d − out (wrapped, rad) of the samples
    ``used`` with finite values, in order (a log in blocks sums alike)."""
    for i in range(d.shape[0]):
        if used[i] and math.isfinite(d[i]) and math.isfinite(out[i]):
            e = d[i] - out[i]
            e = math.atan2(math.sin(e), math.cos(e))
            acc[0] += e * e
            acc[1] += 1.0


# --- a hard-iron offset fitted online from past samples (an uncalibrated magnetometer) ---------------------------
# the sphere fit |m − b|² = r² of checks.hard_iron over the samples taken while the body turns, accumulated as
# moments about the first field c, each block of HF_MOM numbers n, Σm', Σm'm'ᵀ (6: xx yy zz xy xz yz), Σy, Σy·m'
# (3), Σy² with m' = m − c, y = |m'|²: the fit's block; the time since the last solve (s), the offset b (3), 1 once
# valid, the rows seen and the row from which the field was used less b; the current block (HF_BLOCK s), a
# candidate fit (the blocks since the offset stopped explaining them), a scratch block; the current block's time
# (s), 1 while a candidate is open, the restarts, the row of the last one, the row the open candidate was opened
# at, 1 while a younger fit gathers blocks beside one that turned every way and never passed; the last block; the
# time (s) the field has been held unused, and 1 while it is (the open candidate shows another offset); 1 where the
# field is given as measured before the fit passes (NaN otherwise)
HF_C, HF_SET, HF_M, HF_MM, HF_Y, HF_YM, HF_YY = 0, 3, 5, 8, 14, 15, 18
HF_T, HF_B, HF_OK, HF_ROWS, HF_FROM = 19, 20, 23, 24, 25
HF_MOM = 15
# the moments blocks' offsets, passed to the fit's helpers as k: as plain ints numba typed each as a literal of its
# own and compiled the helper, and every helper calling it, once per block (np.int64 is typed int64)
HF_N, HF_BLK, HF_CAND, HF_TMP = np.int64(4), np.int64(26), np.int64(41), np.int64(56)
HF_BLK_T, HF_OPEN, HF_RESTARTS, HF_RESTART_ROW, HF_OPEN_ROW, HF_YOUNG = 71, 72, 73, 74, 75, 76
HF_OPEN_T, HF_HELD, HF_MEASURED = 92, 93, 94
HF_LAST = np.int64(77)  # a moments block too
HF_SIZE = 95
#: s between two solves of the online fit (a 3×3 eigenvalue problem: out of the per-sample loop)
HF_EVERY = 0.25
#: s of samples judged together against the offset in use (BROAD's 2.5-s blocks in motion spread the field by
#: 3-37 % of its norm along their widest axis: an offset change of a tenth of the field spreads its norm about the
#: old offset beyond the 3 % of MAG_SPREAD where they turn it by a third). On the BROAD sweep of offsets put on
#: mid-recording (252 runs online) blocks of 1.25, 2.5 and 5 s refuse 100, 100 and 99 and leave 6 runs with exit 0
#: more than twice and 3° worse than the trial as recorded, mean heading 2.10°, 2.11°, 2.10°
HF_BLOCK = 2.5


@numba.njit(**_NJ)
def _hf_stats(fs, k, b0, b1, b2):
    """Mean and variance of |m − b|² over the samples of the moments block at ``fs[k:]`` (b in the field's unit)."""
    n = fs[k]
    p0, p1, p2 = b0 - fs[HF_C], b1 - fs[HF_C + 1], b2 - fs[HF_C + 2]  # b about the first field
    m0, m1, m2 = fs[k + 1] / n, fs[k + 2] / n, fs[k + 3] / n
    c00, c11, c22 = fs[k + 4] / n - m0 * m0, fs[k + 5] / n - m1 * m1, fs[k + 6] / n - m2 * m2
    c01, c02, c12 = fs[k + 7] / n - m0 * m1, fs[k + 8] / n - m0 * m2, fs[k + 9] / n - m1 * m2
    yb = fs[k + 10] / n
    cy0, cy1, cy2 = fs[k + 11] / n - m0 * yb, fs[k + 12] / n - m1 * yb, fs[k + 13] / n - m2 * yb
    vy = fs[k + 14] / n - yb * yb
    mean = yb - 2.0 * (p0 * m0 + p1 * m1 + p2 * m2) + p0 * p0 + p1 * p1 + p2 * p2
    pcp = p0 * p0 * c00 + p1 * p1 * c11 + p2 * p2 * c22 + 2.0 * (p0 * p1 * c01 + p0 * p2 * c02 + p1 * p2 * c12)
    var = vy - 4.0 * (p0 * cy0 + p1 * cy1 + p2 * cy2) + 4.0 * pcp
    return mean, var


@numba.njit(**_NJ)
def _hf_spread(fs, k, b0, b1, b2):
    """The norm spread std |m − b| / mean |m − b| of the block at ``fs[k:]`` from its moments (std |m − b| ≈ std
    |m − b|² / (2 mean |m − b|²)); inf when it holds no sample."""
    if fs[k] < 1.0:
        return math.inf
    mean, var = _hf_stats(fs, k, b0, b1, b2)
    if not mean > 0.0:
        return math.inf
    return math.sqrt(max(var, 0.0)) / (2.0 * mean)


@numba.njit(**_NJ)
def _hf_cov(fs, k):
    """The field's covariance (3, 3) over the samples of the block at ``fs[k:]``."""
    n = fs[k]
    m0, m1, m2 = fs[k + 1] / n, fs[k + 2] / n, fs[k + 3] / n
    C = np.empty((3, 3))
    C[0, 0], C[1, 1], C[2, 2] = fs[k + 4] / n - m0 * m0, fs[k + 5] / n - m1 * m1, fs[k + 6] / n - m2 * m2
    C[0, 1] = C[1, 0] = fs[k + 7] / n - m0 * m1
    C[0, 2] = C[2, 0] = fs[k + 8] / n - m0 * m2
    C[1, 2] = C[2, 1] = fs[k + 9] / n - m1 * m2
    return C


@numba.njit(**_NJ)
def _eig3(C):
    """Eigenvalues (3,) ascending and unit eigenvectors (3, 3, columns) of the symmetric 3×3 ``C`` by cyclic
    Jacobi rotations, to rounding (numba's LAPACK wrappers, and its argsort and fancy indexing, cost seconds of
    compiling in every kernel holding them)."""
    A = np.empty((3, 3))
    V = np.zeros((3, 3))
    for i in range(3):
        V[i, i] = 1.0
        for j in range(3):
            A[i, j] = C[i, j]
    for _ in range(50):
        off = A[0, 1] * A[0, 1] + A[0, 2] * A[0, 2] + A[1, 2] * A[1, 2]
        if not off > 1e-36 * (A[0, 0] * A[0, 0] + A[1, 1] * A[1, 1] + A[2, 2] * A[2, 2]):
            break
        for r in range(3):
            p, q = (0, 1) if r == 0 else ((0, 2) if r == 1 else (1, 2))
            apq = A[p, q]
            if apq == 0.0:
                continue
            theta = (A[q, q] - A[p, p]) / (2.0 * apq)
            t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):
                akp, akq = A[k, p], A[k, q]
                A[k, p], A[k, q] = c * akp - s * akq, s * akp + c * akq
            for k in range(3):
                apk, aqk = A[p, k], A[q, k]
                A[p, k], A[q, k] = c * apk - s * aqk, s * apk + c * aqk
            for k in range(3):
                vkp, vkq = V[k, p], V[k, q]
                V[k, p], V[k, q] = c * vkp - s * vkq, s * vkp + c * vkq
    w = np.empty(3)
    for i in range(3):
        w[i] = A[i, i]
    for i in range(2):  # ascending, the vectors with them
        for j in range(2 - i):
            if w[j + 1] < w[j]:
                w[j], w[j + 1] = w[j + 1], w[j]
                for k in range(3):
                    V[k, j], V[k, j + 1] = V[k, j + 1], V[k, j]
    return w, V


@numba.njit(**_NJ)
def _hf_offset(fs, k, w, V, seen, p0, p1, p2):
    """The offset less the first field, b − c (3), from the moments block at ``fs[k:]`` along the eigenvectors v
    of its field covariance (eigenvalues λ ``w``, vectors the columns of ``V``) with λ > ``seen``: 2 (m − m̄)·(b − c)
    = y − ȳ in the least-squares sense, so b − c = Σ (v·cov(m, y)/2)/λ v over them; along the others the given
    p = (p0, p1, p2), p·v v. Returns it and how many directions were seen."""
    n = fs[k]
    m0, m1, m2 = fs[k + 1] / n, fs[k + 2] / n, fs[k + 3] / n
    yb = fs[k + 10] / n
    c0, c1, c2 = fs[k + 11] / n - m0 * yb, fs[k + 12] / n - m1 * yb, fs[k + 13] / n - m2 * yb
    d = np.zeros(3)
    count = 0
    for i in range(3):
        v = V[:, i]
        if w[i] > seen:
            d += (0.5 * (v[0] * c0 + v[1] * c1 + v[2] * c2) / w[i]) * v
            count += 1
        else:
            d += (v[0] * p0 + v[1] * p1 + v[2] * p2) * v
    return d, count


@numba.njit(**_NJ)
def _hf_fit(fs, k, out):
    """The sphere fit of the block at ``fs[k:]`` into ``out`` (3) when its samples turned the field about every
    body axis by MAG_SEEN_SPREAD of the fitted radius r, not of |m|, which the offset inflates (BROAD 02 with (100,
    -80, 60) µT never passed: refused, though the offset is fitted within 0.5 µT; a wrong offset δ along an axis the
    field spreads σ along leaves |m − b| spread by about δσ/r², so with a spread gate of MAG_SPREAD δ stays under
    0.03 r² / σ < 0.2 r). Returns the norm spread about ``out`` (:func:`_hf_spread`), inf when not fitted."""
    n = fs[k]
    if n < 100.0:
        return math.inf
    mz0, _ = _hf_stats(fs, k, 0.0, 0.0, 0.0)
    if not mz0 > 0.0:
        return math.inf
    w, V = _eig3(_hf_cov(fs, k))
    low = w[0]
    if not low > 1e-12 * mz0:  # not turned at all about one axis: no fit
        return math.inf
    d, _ = _hf_offset(fs, k, w, V, -math.inf, 0.0, 0.0, 0.0)  # every direction seen: C (b − c) = cov(m, y) / 2
    out[0], out[1], out[2] = fs[HF_C] + d[0], fs[HF_C + 1] + d[1], fs[HF_C + 2] + d[2]
    r2, _ = _hf_stats(fs, k, out[0], out[1], out[2])
    if not (r2 > 0.0 and low > (HF_SEEN_SPREAD * HF_SEEN_SPREAD) * r2):
        return math.inf
    return _hf_spread(fs, k, out[0], out[1], out[2])


@numba.njit(**_NJ)
def _hf_partial(fs, k, b0, b1, b2):
    """The norm spread of the block at ``fs[k:]`` about the offset fitted along the directions its samples turned
    the field along by MAG_SEEN_SPREAD of the field (|m − b| about b = (b0, b1, b2)), b kept along the others: how
    well another offset explains samples that have not turned about every axis (inf when along none)."""
    n = fs[k]
    if n < 100.0:
        return math.inf
    r2, _ = _hf_stats(fs, k, b0, b1, b2)
    w, V = _eig3(_hf_cov(fs, k))
    # the old offset b kept along the directions not seen
    d, seen = _hf_offset(fs, k, w, V, HF_SEEN_SPREAD * HF_SEEN_SPREAD * r2, b0 - fs[HF_C], b1 - fs[HF_C + 1],
                         b2 - fs[HF_C + 2])  # fmt: skip
    if seen == 0:
        return math.inf
    return _hf_spread(fs, k, fs[HF_C] + d[0], fs[HF_C + 1] + d[1], fs[HF_C + 2] + d[2])


@numba.njit(**_NJ)
def _hf_solve(fs, k):
    """Solve the online fit from the moments at ``fs[k:]`` and judge it with the gates of ``checks.hard_iron``
    (norm spread beyond MAG_SPREAD, halved by the offset, which is beyond MAG_OFFSET of the field), every body axis
    seen (:func:`_hf_fit`: an axis not yet turned about leaves the offset along it unknown) and the field less the
    offset as steady as a calibrated one (its norm's spread at most MAG_SPREAD). Sets the offset and returns True
    when it passes; else leaves the last one."""
    s0 = _hf_spread(fs, k, 0.0, 0.0, 0.0)
    if not (fs[k] >= 100.0 and HF_MAG_SPREAD < s0 < math.inf):
        return False
    b = np.empty(3)
    s1 = _hf_fit(fs, k, b)
    if not (s1 < 0.5 * s0 and s1 <= HF_MAG_SPREAD):
        return False
    r2, _ = _hf_stats(fs, k, b[0], b[1], b[2])
    if not b[0] * b[0] + b[1] * b[1] + b[2] * b[2] > HF_MAG_OFFSET**2 * r2:
        return False
    fs[HF_B], fs[HF_B + 1], fs[HF_B + 2] = b[0], b[1], b[2]
    return True


@numba.njit(**_NJ)
def _hf_add(fs, k, x, y, z, q):
    """Add the sample m' = (x, y, z) with q = |m'|² to the moments block at ``fs[k:]``."""
    fs[k] += 1.0
    fs[k + 1] += x
    fs[k + 2] += y
    fs[k + 3] += z
    fs[k + 4] += x * x
    fs[k + 5] += y * y
    fs[k + 6] += z * z
    fs[k + 7] += x * y
    fs[k + 8] += x * z
    fs[k + 9] += y * z
    fs[k + 10] += q
    fs[k + 11] += q * x
    fs[k + 12] += q * y
    fs[k + 13] += q * z
    fs[k + 14] += q * q


@numba.njit(**_NJ)
def _hf_merge(fs, dst, a, b):
    """The moments block at ``fs[dst:]`` set to the sum of those at ``fs[a:]`` and ``fs[b:]`` (b < 0: none)."""
    for j in range(HF_MOM):
        fs[dst + j] = fs[a + j] + (fs[b + j] if b >= 0 else 0.0)


@numba.njit(**_NJ)
def _hf_first(fs, k):
    """The first offset from the moments at ``fs[k:]`` (:func:`_hf_solve`), taken only when the last block and
    the current one (those of 100 samples or more) are explained by it too (norm spread about it within
    MAG_SPREAD): a fit over samples of two offsets can pass the gates between them (BROAD 07 with +30 µT on x
    from 60 s: 16.8 µT from 10 s before the change and 5 s after, the heading 20° off at once). Sets the offset in
    use and the row it is used from; returns True then."""
    if not _hf_solve(fs, k):
        return False
    for j in (HF_LAST, HF_BLK):
        if fs[j] >= 100.0 and _hf_spread(fs, j, fs[HF_B], fs[HF_B + 1], fs[HF_B + 2]) > HF_MAG_SPREAD:
            return False
    fs[HF_OK], fs[HF_YOUNG] = 1.0, 0.0
    fs[HF_FROM] = fs[HF_ROWS] - 1.0
    return True


@numba.njit(**_NJ)
def _hf_close(fs):
    """Close the candidate of :func:`_hf_block_end` (its moments cleared)."""
    fs[HF_OPEN] = fs[HF_HELD] = 0.0
    for j in range(HF_MOM):
        fs[HF_CAND + j] = 0.0


@numba.njit(**_NJ)
def _hf_block_end(fs):
    """Close the current block into the fit. With an offset in use, a block of at least 100 samples whose norm
    spread about it exceeds MAG_SPREAD opens a candidate, which gathers the blocks after it (not that one, which may
    straddle the change) until their own fit passes the gates of :func:`_hf_fit` with a spread at most MAG_SPREAD
    and under half the old offset's: it then becomes the fit with its offset (a restart). Meanwhile the field is
    held unused (the heading the gyro's) while another offset explains the candidate along the axes it turned
    about (:func:`_hf_partial`), and used less the old offset where none does (a disturbed field, which the norm and
    dip gates judge), until a block fits the old offset again. Once its samples have turned about every axis
    (:func:`_hf_fit` finite) and the old offset explains them (spread within MAG_SPREAD), it is closed too.

    Before any offset is in use, a fit that has turned about every axis and still fails the gates holds samples
    of another offset (BROAD 07 turns from 29.3 s: +30 µT on x from 30 s left 0.7 s without it in the sums, and the
    fit never passed): a younger fit gathers the blocks from then on and, once it has turned about every axis
    itself, replaces the older one (used at once if it passes the gates), the next younger one starting anew."""
    if fs[HF_OPEN] == 0.0:
        _hf_merge(fs, HF_N, HF_N, HF_BLK)
    if fs[HF_OK] == 0.0:
        b = np.empty(3)
        if fs[HF_YOUNG] != 0.0:
            _hf_merge(fs, HF_CAND, HF_CAND, HF_BLK)
            if _hf_fit(fs, HF_CAND, b) < math.inf:
                _hf_merge(fs, HF_N, HF_CAND, -1)
                _hf_close(fs)
                _hf_first(fs, HF_N)
        elif _hf_fit(fs, HF_N, b) < math.inf:
            fs[HF_YOUNG] = 1.0
    if fs[HF_OK] != 0.0 and fs[HF_BLK] >= 100.0:
        b0, b1, b2 = fs[HF_B], fs[HF_B + 1], fs[HF_B + 2]
        fits = _hf_spread(fs, HF_BLK, b0, b1, b2) <= HF_MAG_SPREAD
        if fs[HF_OPEN] == 0.0:
            if not fits:
                fs[HF_OPEN] = 1.0
        elif fits and fs[HF_HELD] == 0.0:
            # a disturbance over (no other offset explained it): the next change gets a candidate of its own
            _hf_close(fs)
        else:
            _hf_merge(fs, HF_CAND, HF_CAND, HF_BLK)
            b = np.empty(3)
            s1 = _hf_fit(fs, HF_CAND, b)
            s_old = _hf_spread(fs, HF_CAND, b0, b1, b2)
            if s1 <= HF_MAG_SPREAD and s1 < 0.5 * s_old:
                _hf_merge(fs, HF_N, HF_CAND, -1)
                fs[HF_B], fs[HF_B + 1], fs[HF_B + 2] = b[0], b[1], b[2]
                fs[HF_RESTARTS] += 1.0
                fs[HF_RESTART_ROW] = fs[HF_ROWS] - 1.0
                _hf_close(fs)
            elif s1 < math.inf and s_old <= HF_MAG_SPREAD:
                _hf_close(fs)
            else:
                # held unused while another offset explains the candidate along the axes it turned about; a field
                # that none explains is disturbed there, used less the old offset (the norm and dip gates judge it)
                sp = _hf_partial(fs, HF_CAND, b0, b1, b2)
                held = sp <= HF_MAG_SPREAD and sp < 0.5 * s_old
                if held and fs[HF_HELD] == 0.0:
                    fs[HF_OPEN_T] = 0.0
                    fs[HF_OPEN_ROW] = fs[HF_ROWS] - 1.0
                fs[HF_HELD] = 1.0 if held else 0.0
    for j in range(HF_MOM):
        fs[HF_LAST + j], fs[HF_BLK + j] = fs[HF_BLK + j], 0.0


@numba.njit(**_NJ)
def hard_iron_online(fs, mx, my, mz, h, w):
    """One magnetometer sample (any unit; NaN: none) after a step of h s, the body turning at ``w`` rad/s (|ω|;
    NaN: not known), into the online offset fit ``fs`` (HF_SIZE): the field less the offset fitted from this and
    the earlier samples once the fit has passed its gates (:func:`_hf_solve`, every HF_EVERY s; before, NaN, or
    with HF_MEASURED the field as measured, which the filter uses until then: :func:`fitted_sample`), then refined
    at each solve that passes; NaN while the recent samples show another offset, until their own fit restarts it
    (:func:`_hf_block_end`). Only samples taken while the body turns faster than STILL_RATE enter the fit: at rest
    the field sits at one point of the sphere and says nothing of the offset but, weighted by its time, pulls the
    fit there (30 s of rest before a magnet came on held BROAD 02's online fit at 18.5 of 30 µT, heading 35.7°)."""
    fs[HF_T] += h
    fs[HF_BLK_T] += h
    fs[HF_ROWS] += 1.0
    if fs[HF_HELD] != 0.0:
        fs[HF_OPEN_T] += h
    finite = math.isfinite(mx + my + mz)
    if finite and not w <= HF_STILL_RATE:
        if fs[HF_SET] == 0.0:
            fs[HF_C], fs[HF_C + 1], fs[HF_C + 2], fs[HF_SET] = mx, my, mz, 1.0
        x, y, z = mx - fs[HF_C], my - fs[HF_C + 1], mz - fs[HF_C + 2]
        _hf_add(fs, HF_BLK, x, y, z, x * x + y * y + z * z)
    if fs[HF_T] >= HF_EVERY:
        fs[HF_T] = 0.0
        if fs[HF_OPEN] == 0.0:
            _hf_merge(fs, HF_TMP, HF_N, HF_BLK)  # the fit's blocks and the current one so far
            if fs[HF_OK] != 0.0:
                _hf_solve(fs, HF_TMP)
            else:
                _hf_first(fs, HF_TMP)
    if fs[HF_BLK_T] >= HF_BLOCK:
        fs[HF_BLK_T] = 0.0
        _hf_block_end(fs)
    if fs[HF_HELD] != 0.0 or not finite:
        return math.nan, math.nan, math.nan
    if fs[HF_OK] == 0.0:
        return (mx, my, mz) if fs[HF_MEASURED] != 0.0 else (math.nan, math.nan, math.nan)
    return mx - fs[HF_B], my - fs[HF_B + 1], mz - fs[HF_B + 2]


@numba.njit(**_NJ)
def first_fitted_row(fs, row0):
    """The row, counted from the fit state ``fs``'s row ``row0`` (a chunk's first, or a sample's own), from which
    the online fit's offset is first subtracted (the filter's magnetic part restarts there: :func:`mag_restart`);
    -1 where that is before ``row0`` or the fit has not passed."""
    k = fs[HF_FROM] - row0
    return int(k) if fs[HF_OK] != 0.0 and k >= 0 else -1


@numba.njit(**_NJ)
def fitted_sample(fs, st, mx, my, mz, h, w):
    """:func:`hard_iron_online` for the filter state ``st``: the field to step it with, its magnetic part restarted
    (:func:`mag_restart`) at the sample from which the fit's offset is subtracted."""
    m = hard_iron_online(fs, mx, my, mz, h, w)
    if first_fitted_row(fs, fs[HF_ROWS] - 1.0) == 0:
        mag_restart(st)
    return m


@numba.njit(**_NJ)
def hard_iron_online_run(fs, mag, dt, gyr, out):
    """:func:`hard_iron_online` over the rows of ``mag`` (N, 3) with the steps ``dt`` (1 or N s) and the gyro
    ``gyr`` (N, 3 rad/s; 0 rows: not known): ``out`` (N, 3)."""
    one = dt.shape[0] == 1
    has = gyr.shape[0] > 0
    for i in range(mag.shape[0]):
        w = math.sqrt(gyr[i, 0] ** 2 + gyr[i, 1] ** 2 + gyr[i, 2] ** 2) if has else math.nan
        h = dt[0] if one else dt[i]
        out[i, 0], out[i, 1], out[i, 2] = hard_iron_online(fs, mag[i, 0], mag[i, 1], mag[i, 2], h, w)
