"""Gyro calibration from multi-position sessions (imu_tk-style, :mod:`optinav.multipos.gyro`).

Truth: :func:`optinav.core.simulate.static_positions` (exact rates at jittered epochs), a known K with 1–3 %
scale errors and ~1e-2 misalignments on both sides of the diagonal, a bias, white noise and integer
"counts" (16.4 counts per deg/s). Tolerances come from the reported standard deviations (checked for
honesty by a small Monte Carlo) plus absolute sanity bounds. Real data: imucal's hand-made Ferraris session,
compared with imucal's own calibration (different method: known 360° turns).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from optinav.core import earth
from optinav.core.rotations import rot_x, rot_y, rot_z, rotation_angle
from optinav.core.simulate import orientation_from_up, static_positions
from optinav.errors import OptinavError
from optinav.multipos.gyro import GYRO_PARAMS, GyroCalibration, calibrate_gyro, transition_residuals

COUNTS = 16.4 * 180.0 / np.pi  # counts per rad/s (a ±2000 deg/s MEMS range)
K_REL = np.array([[1.020, 0.012, -0.008], [-0.011, 0.985, 0.009], [0.007, -0.013, 1.015]])
K_TRUE = K_REL * COUNTS
B_TRUE = np.array([12.0, -7.5, 3.2])  # counts
ARW = 1.7e-4  # rad/s/√Hz (≈ 0.01 deg/s/√Hz)
RATE = 100.0
U_NOISE = 1e-4  # rad, per component of the measured up directions

DATA = (
    Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    / "imucal"
)


def _poses():
    ups = ["z", "x", "y", "-z", "-x", "-y", "z", "y", "x", "-y", "-z", "x", "-x", "z"]
    P = [orientation_from_up(u, frame="enu") for u in ups]
    P.insert(3, orientation_from_up("z", frame="enu") @ rot_x(0.6) @ rot_y(0.4))  # tilted poses
    P.insert(9, orientation_from_up("y", frame="enu") @ rot_z(0.5))
    return np.stack(P)


def _session(rng, *, lat=0.0, earth_model="none", jitter=True):
    P = _poses()
    dwell, tr = 3.0, 2.0
    T = len(P) * dwell + (len(P) - 1) * tr
    t = np.arange(int(T * RATE) + 1) / RATE
    if jitter:  # irregular sampling: ±30 % of the step
        t = np.clip(t + rng.uniform(-0.3, 0.3, t.size) / RATE, 0.0, T)
        t[0] = 0.0
    kw = {"earth": "wgs84"} if earth_model == "wgs84" else {"earth": "none", "gravity": [0.0, 0.0, -9.80665]}
    truth = static_positions(P, dwell=dwell, rate_hz=RATE, lat=lat, transition=tr, t=t, frame="enu", **kw)
    lab = truth.labels
    iv = np.array([[np.flatnonzero(lab == p)[0], np.flatnonzero(lab == p)[-1] + 1] for p in range(lab.max() + 1)])
    f = np.array([truth.acc[a:b].mean(0) for a, b in iv])
    return truth, iv, f / np.linalg.norm(f, axis=1)[:, None]


def _measure(truth, u0, rng, arw=ARW, u_noise=None, quantize=True):
    u_noise = U_NOISE if u_noise is None else u_noise
    dt = np.median(np.diff(truth.t))
    w = truth.gyr
    raw = w @ K_TRUE.T + B_TRUE + rng.normal(0.0, arw / np.sqrt(dt), w.shape) * COUNTS
    if quantize:
        raw = np.round(raw)
    u = u0 + rng.normal(0.0, u_noise, u0.shape)
    return raw, u / np.linalg.norm(u, axis=1)[:, None]


@pytest.fixture(scope="module")
def sim():
    rng = np.random.default_rng(11)
    truth, iv, u0 = _session(rng)
    return truth, iv, u0


def _z(cal):
    return np.r_[((cal.K - K_TRUE) / cal.K_std).ravel(), (cal.b - B_TRUE) / cal.b_std]


@pytest.mark.parametrize("bias", ["static", "estimate"])
def test_recovers_K_and_b_in_counts_with_irregular_timestamps(sim, bias):
    truth, iv, u0 = sim
    raw, u = _measure(truth, u0, np.random.default_rng(2))
    cal = calibrate_gyro(truth.t, raw, iv, u, bias=bias)
    assert cal.n_transitions == len(iv) - 1 == 15
    assert cal.observability.full_rank and cal.observability.names == list(
        GYRO_PARAMS[: 12 if bias == "estimate" else 9]
    )
    assert cal.success and not cal.unobservable
    # K to 5σ and, absolutely, to 1e-3 of the scale (0.1 % scale / 1 mrad); b to 5σ and 0.2 counts
    assert np.all(np.abs(_z(cal)) < 5.0), _z(cal)
    assert np.max(np.abs(cal.K - K_TRUE)) < 1e-3 * COUNTS
    assert np.max(np.abs(cal.b - B_TRUE)) < 0.2
    # residuals at the noise level: white rate noise over a 2 s turn (ARW·√2 per axis) and both up directions
    expected = np.sqrt(2.0 * ARW**2 + 2.0 * U_NOISE**2)
    assert 0.5 * expected < cal.sigma < 2.0 * expected
    assert np.all(np.isfinite(cal.K_std)) and np.all(cal.K_std > 0)
    assert cal.k0 == pytest.approx(COUNTS, rel=0.05)  # the 1-D scale step found the unit on its own
    P = _poses()
    true_angles = rotation_angle(np.einsum("kji,kjl->kil", P[:-1], P[1:]))  # C_{b(k+1)}^{b(k)} = C_kᵀ C_{k+1}
    np.testing.assert_allclose(cal.transition_angles, true_angles, atol=1e-3)
    om = cal.correct(raw[iv[0, 0] : iv[0, 1]])  # at rest: zero to 5σ of the mean of the white noise
    assert np.max(np.abs(om.mean(0))) < 5 * ARW * np.sqrt(RATE / (iv[0, 1] - iv[0, 0]))


def test_reported_std_is_honest_monte_carlo(sim):
    """20 noise realizations: the errors normalized by the reported std have RMS ≈ 1 (band [0.5, 2])."""
    truth, iv, u0 = sim
    rng = np.random.default_rng(7)
    Z = []
    for _ in range(20):
        raw, u = _measure(truth, u0, rng)
        Z.append(_z(calibrate_gyro(truth.t, raw, iv, u, x0=COUNTS * np.eye(3))))  # x0: skip the scale scan
    Z = np.array(Z)
    rms_K, rms_b = np.sqrt(np.mean(Z[:, :9] ** 2)), np.sqrt(np.mean(Z[:, 9:] ** 2))
    assert 0.5 < rms_K < 2.0 and 0.5 < rms_b < 2.0, (rms_K, rms_b)
    # no systematic error: the mean normalized error of 180 K entries is ~N(0, 1/√20) per entry
    assert np.max(np.abs(Z[:, :9].mean(0))) < 4.5 / np.sqrt(20)


@pytest.mark.parametrize("bias", ["static", "estimate"])
def test_earth_rate_stays_within_documented_bound(bias):
    """Latitude 45°, (nearly) noise-free: the only error is the neglected Earth rate, ≤ earth_rate_param_bound."""
    rng = np.random.default_rng(3)
    truth, iv, u0 = _session(rng, lat=np.radians(45.0), earth_model="wgs84", jitter=False)
    raw, u = _measure(truth, u0, rng, arw=1e-9, u_noise=0.0, quantize=False)
    cal = calibrate_gyro(truth.t, raw, iv, u, bias=bias)
    np.testing.assert_allclose(cal.earth_rate_bound, 2 * earth.WGS84.omega_ie * cal.transition_durations)
    err = np.abs(np.r_[(cal.K - K_TRUE).ravel(), cal.b - B_TRUE])
    ratio = err / cal.earth_rate_param_bound
    assert np.all(ratio <= 1.0), ratio
    assert ratio.max() > 0.05  # the Earth rate does show: the bound is not vacuous
    assert np.max(cal.earth_rate_param_bound[:9]) < 1e-3 * COUNTS  # and it is small: < 0.1 % of the scale


def _single_axis_session(rng):
    ang = np.radians([0, 90, 200, 280, 30, 150, 250, 340])
    P = np.stack([orientation_from_up("z", frame="enu") @ rot_x(a) for a in ang])  # every turn is about body x
    truth = static_positions(P, dwell=2.0, rate_hz=RATE, lat=0.7, transition=2.0, frame="enu")
    lab = truth.labels
    iv = np.array([[np.flatnonzero(lab == p)[0], np.flatnonzero(lab == p)[-1] + 1] for p in range(lab.max() + 1)])
    f = np.array([truth.acc[a:b].mean(0) for a, b in iv])
    raw, u = _measure(truth, f / np.linalg.norm(f, axis=1)[:, None], rng)
    return truth, raw, iv, u


def test_single_axis_scheme_is_reported_unobservable():
    truth, raw, iv, u = _single_axis_session(np.random.default_rng(4))
    with pytest.raises(OptinavError) as exc:
        calibrate_gyro(truth.t, raw, iv, u)
    msg = str(exc.value)
    assert "\n" not in msg and "rank-deficient (rank 3/9)" in msg
    for name in ("K_xy", "K_xz", "K_yy", "K_yz", "K_zy", "K_zz"):
        assert name in msg
    assert "K_xx" not in msg and "body y and z axes" in msg
    cal = calibrate_gyro(truth.t, raw, iv, u, allow_unobservable=True)
    assert sorted(cal.unobservable) == ["K_xy", "K_xz", "K_yy", "K_yz", "K_zy", "K_zz"]
    assert np.all(np.isinf(cal.K_std[:, 1:])) and np.all(np.isfinite(cal.K_std[:, 0]))
    # the rotated axis' column is still found, to 5σ
    assert np.all(np.abs(cal.K[:, 0] - K_TRUE[:, 0]) < 5 * cal.K_std[:, 0])
    np.testing.assert_allclose(cal.K[:, 1:], cal.k0 * np.eye(3)[:, 1:], atol=1e-6 * cal.k0)  # held at K₀


def test_bias_modes_methods_and_time_intervals(sim):
    truth, iv, u0 = sim
    raw, u = _measure(truth, u0, np.random.default_rng(5))
    ref = calibrate_gyro(truth.t, raw, iv, u)
    given = calibrate_gyro(truth.t, raw, iv, u, bias=B_TRUE)
    assert given.bias_mode == "given" and np.array_equal(given.b, B_TRUE) and np.all(given.b_std == 0)
    assert np.all(np.abs(given.K - K_TRUE) < 5 * given.K_std)
    t0, t1 = truth.t[iv[0, 0]], truth.t[iv[0, 1] - 1]
    rest = calibrate_gyro(truth.t, raw, iv, u, bias="rest", rest=(t0, t1))
    np.testing.assert_allclose(rest.b, raw[iv[0, 0] : iv[0, 1]].mean(0))
    assert np.all(np.abs(rest.b - B_TRUE) < 5 * rest.b_std)
    # the same intervals given as times [t0, t1] in s
    tiv = np.stack([truth.t[iv[:, 0]], truth.t[iv[:, 1] - 1]], 1)
    by_time = calibrate_gyro(truth.t, raw, tiv, u, interval_units="s")
    np.testing.assert_allclose(by_time.K, ref.K, rtol=0, atol=1e-9 * COUNTS)
    for method in ("gauss-newton", "trf"):
        other = calibrate_gyro(truth.t, raw, iv, u, method=method)
        assert other.method == method
        assert np.all(np.abs(other.K - ref.K) < 1e-3 * ref.K_std)
    # a user K₀ skips the scale step and lands on the same optimum
    x0 = calibrate_gyro(truth.t, raw, iv, u, x0=1.1 * COUNTS * np.eye(3))
    assert np.all(np.abs(x0.K - ref.K) < 1e-3 * ref.K_std)
    # transition_residuals reproduces the fit's per-transition angles
    r = transition_residuals(truth.t, raw, iv, u, ref.K, ref.b)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), ref.transition_residuals, rtol=1e-6, atol=1e-12)


def test_the_axis_check_costs_equal_each_permutations_own_integration(sim):
    """The axis-swap check's 48 costs Σ‖r‖² of K = k·P come from two integrations, rotated (the strapdown update
    commutes with a rotation of its rates; a reflection is a rotation of the negated rates): each equals the cost
    of integrating that K itself, with a coning correction and a bias."""
    from optinav.multipos import gates
    from optinav.multipos.transitions import Transitions

    truth, iv, u0 = sim
    raw, u = _measure(truth, u0, np.random.default_rng(8))
    for coning in ("none", "previous"):
        tr = Transitions(truth.t, raw, iv, u, coning)
        perms = gates.signed_permutations()
        k, b = 1.03 * COUNTS, np.array([0.3, -0.2, 0.1]) * COUNTS * 1e-2
        own = [float(np.sum(tr.residuals(k * P, b) ** 2)) for P in perms]
        np.testing.assert_allclose(tr.permutation_costs(k, b, perms), own, rtol=1e-9, atol=0)


def test_result_json_roundtrip(sim, tmp_path):
    truth, iv, u0 = sim
    raw, u = _measure(truth, u0, np.random.default_rng(6))
    cal = calibrate_gyro(truth.t, raw, iv, u)
    path = tmp_path / "gyro.json"
    cal.to_json(path)
    back = GyroCalibration.from_json(path)
    np.testing.assert_array_equal(back.K, cal.K)
    np.testing.assert_array_equal(back.covariance, cal.covariance)
    assert back.observability.rank == 9 and back.units()["K"] == "raw/(rad/s)"
    assert "Gyro calibration" in back.summary()


def _bad(sim):
    truth, iv, u0 = sim
    raw, u = _measure(truth, u0, np.random.default_rng(8))
    t = truth.t
    cases = {
        "few transitions": ((t, raw, iv[:5], u[:5]), {}, "4 transition"),
        "gyro rows": ((t, raw[:-1], iv, u), {}, "gyro_raw has shape"),
        "nan": ((t, np.where(np.arange(len(t))[:, None] == 50, np.nan, raw), iv, u), {}, "NaN"),
        "time order": ((np.r_[t[:10], t[9], t[11:]], raw, iv, u), {}, "not sorted|duplicate"),
        "out of range": ((t, raw, np.vstack([iv[:-1], [iv[-1, 0], len(t) + 5]]), u), {}, "outside"),
        "overlap": ((t, raw, np.vstack([iv[:3], [iv[2, 1] - 5, iv[3, 1]], iv[4:]]), u), {}, "overlaps"),
        "unsorted": ((t, raw, iv[[0, 2, 1, *range(3, len(iv))]], u), {}, "starts before|overlaps"),
        "not unit": ((t, raw, iv, 9.81 * u), {}, "not a unit vector"),
        "up count": ((t, raw, iv, u[:-1]), {}, "up_dirs has shape"),
        "bias word": ((t, raw, iv, u), {"bias": "mean"}, "bias="),
        "rest alone": ((t, raw, iv, u), {"rest": (0.0, 1.0)}, "rest was given"),
        "rest missing": ((t, raw, iv, u), {"bias": "rest"}, "needs the rest window"),
        "method": ((t, raw, iv, u), {"method": "ga"}, "method="),
        "fraction index": ((t, raw, iv + 0.5, u), {}, "whole sample indices"),
        "no tilt change": ((t, raw, iv, np.tile([0.0, 0.0, 1.0], (len(iv), 1))), {}, "change the gravity direction"),
    }
    return cases


@pytest.mark.parametrize(
    "case",
    [
        "few transitions",
        "gyro rows",
        "nan",
        "time order",
        "out of range",
        "overlap",
        "unsorted",
        "not unit",
        "up count",
        "bias word",
        "rest alone",
        "rest missing",
        "method",
        "fraction index",
        "no tilt change",
    ],
)
def test_bad_input_is_one_line_error(sim, case):
    args, kw, match = _bad(sim)[case]
    with pytest.raises(OptinavError, match=match) as exc:
        calibrate_gyro(*args, **kw)
    assert "\n" not in str(exc.value)


# --- real data ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ferraris():
    if not (DATA / "example_ferraris_session.csv").is_file():
        pytest.skip("shared imucal data not available (set OPTINAV_SHARED_DATA)")
    d = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)
    sections = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    ref = json.loads((DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").read_text())
    t = np.arange(d.shape[0]) / 102.4
    gyr, acc = d[:, 1:4], d[:, 4:7]  # deg/s, m/s²
    Ka, Ra, ba = (np.array(ref[k]) for k in ("K_a", "R_a", "b_a"))
    # gravity directions in imucal's calibrated accelerometer frame (box axes): the frame both gyro models use
    acc_cal = np.linalg.solve(Ka @ Ra, (acc - ba).T).T
    six = np.array([[sections[k]["start"], sections[k]["end"]] for k in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")])
    # the device also rests just before and after each 360° turn (imucal's x_rot, y_rot, z_rot sections)
    extra = []
    for k in ("x_rot", "y_rot", "z_rot"):
        s, e = sections[k]["start"], sections[k]["end"]
        extra += [[s - 300, s - 20], [e + 40, e + 300]]
    return t, gyr, acc_cal, six, np.array(extra), ref


def _ups(acc, iv):
    f = np.array([acc[a:b].mean(0) for a, b in iv])
    return f / np.linalg.norm(f, axis=1)[:, None]


def test_real_ferraris_session_against_imucal(ferraris):
    t, gyr, acc_cal, six, extra, ref = ferraris
    b0 = gyr[six[0, 0] : six[0, 1]].mean(0)
    for a, b in extra:  # the added windows really are at rest (rates ≤ 0.3 deg/s from the bias)
        assert np.max(np.linalg.norm(gyr[a:b] - b0, axis=1)) < 0.3
    iv = np.vstack([six, extra])
    cal = calibrate_gyro(t, gyr, iv, _ups(acc_cal, iv))  # raw = deg/s, so K is deg/s per rad/s
    assert cal.n_transitions == 11 and cal.observability.full_rank
    # hand flips at up to 900 deg/s leave ~0.5° per transition (imucal's own K/b leave 0.7° RMS here)
    assert cal.residual_rms < np.radians(1.0)
    r_ref = transition_residuals(
        t, gyr, iv, _ups(acc_cal, iv), np.array(ref["K_g"]) @ np.array(ref["R_g"]) * 180 / np.pi, np.array(ref["b_g"])
    )
    assert cal.residual_rms < np.sqrt(np.mean(np.sum(r_ref**2, 1)))
    # imucal: gyr = K_g R_g ω_deg + K_ga a + b_g  ⇒  K·π/180 ↔ K_g R_g
    M = cal.K * np.pi / 180
    S = cal.K_std * np.pi / 180
    M_ref = np.array(ref["K_g"]) @ np.array(ref["R_g"])
    d = M - M_ref
    assert np.max(np.abs(np.diag(d) / np.diag(M_ref))) < 0.02  # diagonal within 2 % (found 0.3, 1.4, 0.2 %)
    assert np.max(np.abs(d - np.diag(np.diag(d)))) < 0.02  # misalignments within 20 mrad
    assert np.all(np.abs(d) < 3.5 * S), d / S  # and within 3.5σ of ours (max 2.0σ found)
    np.testing.assert_allclose(cal.b, ref["b_g"], atol=0.01)  # deg/s


def test_real_six_flips_alone_are_not_enough(ferraris):
    """5 hand flips give 10 constraints for 9 unknowns: the noise estimate has 1 dof and a direction stays open."""
    t, gyr, acc_cal, six, _, ref = ferraris
    with pytest.raises(OptinavError, match="rank-deficient .*unobservable: .*K_xx") as exc:
        calibrate_gyro(t, gyr, six, _ups(acc_cal, six))
    assert "--allow-unobservable" in str(exc.value)
    cal = calibrate_gyro(t, gyr, six, _ups(acc_cal, six), allow_unobservable=True)
    assert len(cal.unobservable) == 1 and cal.observability.rank == 8
    M_ref = np.array(ref["K_g"]) @ np.array(ref["R_g"])
    np.testing.assert_allclose(np.diag(cal.K) * np.pi / 180, np.diag(M_ref), rtol=0.02)
