"""Real data: BROAD trial 02 (optical truth). Inclination RMSE with gyro + accelerometer only against the
reference figures of README_SOURCE.txt (VQF 0.43°, ahrs Madgwick(0.033) 0.61°, ahrs Mahony 0.46°), and heading
with polarization synthesized from the optical truth by the Rayleigh model, the sun at the paper's place and
static-test time (Dalian, 2021-01-17 10:34 +08:00, SPA)."""

import copy
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from optinav.attitude import estimate, estimate_q
from optinav.attitude.data import BROAD_TRIAL_02, synthesize_polarization
from optinav.attitude.data import load_broad as _load_broad
from optinav.attitude.iframe import run_iframe
from optinav.attitude.checks import hard_iron
from optinav.attitude.estimators import AttitudeEstimate
from optinav.attitude.metrics import earth_error_quaternion, heading_error, inclination_error, rmse
from optinav.core.rotations import quat_conjugate, quat_rotate
from optinav.core.strapdown import attitude_update
from optinav.errors import OptinavError

#: the shared data folder: ../shared/data relative to the project root ($OPTINAV_SHARED_DATA overrides)
SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
PATH = SHARED / BROAD_TRIAL_02
#: the shared BROAD trials' folder
BROAD = SHARED / "attitude" / "broad"
pytestmark = pytest.mark.skipif(not PATH.is_file(), reason=f"BROAD data absent ({PATH})")

_READ: dict = {}


def _present(*paths):
    """The shared trials' ``paths`` (one path: itself), or the test skipped where one is absent."""
    absent = [p.name for p in paths if not p.is_file()]
    if absent:
        pytest.skip(f"BROAD data absent: {', '.join(absent)}")
    return paths[0] if len(paths) == 1 else paths


def load_broad(path, options=None):
    """:func:`optinav.attitude.data.load_broad`, each shared trial read once in this module (a hundred tests read
    the nine files); every call gets its own copy of the arrays, which tests change."""
    p = Path(path).resolve()
    if options is not None or SHARED.resolve() not in p.parents:
        return _load_broad(path, options)
    key = (p, p.stat().st_mtime_ns)
    if key not in _READ:
        _READ[key] = _load_broad(path)
    return copy.deepcopy(_READ[key])


#: BROAD inclination RMSE limits (deg), defaults of each method. GD/CG are Madgwick's filter with ahrs's gain:
#: the ahrs reference 0.61° + 15 %. QN (as published: proportional correction, no gyro-bias state; this IMU has
#: ~0.2 °/s bias) within 30 % of Madgwick. MEKF (gyro-bias states, like VQF) within 15 % of VQF's 0.43°.
LIMITS_DEG = {"gd": 0.70, "cg": 0.70, "qn": 0.80, "mekf": 0.50}


@pytest.fixture(scope="module")
def trial():
    return load_broad(PATH)


def test_q0_gives_the_tilt_of_a_start_in_fast_motion():
    """Trial 16 (fast translation) cut at 45.8 s, the body turning at 3.3 rad/s with |a| 4.9 m/s²: iframe from q0
    (the reference there) took the tilt from the first sample's specific force at once (its low-pass's running-mean
    start), q0's overridden: online the inclination 175° off within 5 s (RMS 21.7° over 20 s), and with synthesized
    AoP the heading 178° off, exit 0. q0 now starts the tilt's low-pass steady at the gravity it predicts: within 5°
    (measured 2.9° online, 2.4° offline) and the AoP's heading within 3° (1.7°, 1.4°)."""
    tr = load_broad(_present(BROAD / "16_undisturbed_fast_translation_B.hdf5"))
    a, b = int(45.8 / tr.dt), int(65.8 / tr.dt)
    el, az = np.radians(30.0), np.radians(120.0)
    sun = np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])  # ENU
    pol = synthesize_polarization(tr.q_ref[a:b], sun, aop_noise=np.radians(0.5), rng=0, frame="enu")
    for offline in (False, True):
        for p in (None, pol):
            e = estimate(tr.gyr[a:b], tr.acc[a:b], tr.dt, frame="ENU", method="iframe", q0=tr.q_ref[a], pol=p,
                         offline=offline, checks=False)  # fmt: skip
            inc = np.degrees(inclination_error(e.q_b_n, tr.q_ref[a:b]))
            assert np.nanmax(inc[: int(5.0 / tr.dt)]) < 5.0, (offline, p is None, np.nanmax(inc[: int(5.0 / tr.dt)]))
            if p is not None:
                hd = np.degrees(heading_error(e.q_b_n, tr.q_ref[a:b]))
                assert np.nanmax(hd) < 3.0, (offline, np.nanmax(hd))


@pytest.mark.parametrize("method", ["gd", "cg", "qn", "mekf"])
def test_broad_inclination_rmse_6d(trial, method):
    q = estimate_q(trial.gyr, trial.acc, trial.dt, method=method, frame="ENU")
    err = np.degrees(rmse(inclination_error(q, trial.q_ref), trial.eval_mask))
    assert err < LIMITS_DEG[method], f"{method}: {err:.3f} deg"


def test_broad_gd_reproduces_ahrs_madgwick(trial):
    ahrs = pytest.importorskip("ahrs")
    q_ahrs = ahrs.filters.Madgwick(gyr=trial.gyr, acc=trial.acc, frequency=trial.rate_hz, gain=0.033).Q
    ref = np.degrees(rmse(inclination_error(q_ahrs, trial.q_ref), trial.eval_mask))
    q = estimate_q(trial.gyr, trial.acc, trial.dt, method="gd", frame="ENU", gain=0.033, input_stage=False)
    ours = np.degrees(rmse(inclination_error(q, trial.q_ref), trial.eval_mask))
    assert abs(ref - 0.61) < 0.01  # the README's figure
    assert abs(ours - ref) < 0.05


def test_broad_heading_with_synthesized_polarization(trial):
    from optinav.attitude.simulate import PAPER_SITE, PAPER_TIMES
    from optinav.sky import solar_position

    sp = solar_position(
        np.datetime64(PAPER_TIMES["static"][:19]) - np.timedelta64(8, "h"),
        PAPER_SITE["lat"],
        PAPER_SITE["lon"],
        PAPER_SITE["height_m"],
    )
    sun = sp.sun_vector("enu")
    pol = synthesize_polarization(trial.q_ref, sun, aop_noise=np.radians(0.5), rng=0, frame="enu")
    i0 = int(np.flatnonzero(np.all(np.isfinite(trial.q_ref), axis=1))[0])  # start at the first optical sample
    sl = slice(i0, None)
    mask = trial.eval_mask[sl]
    res = {}
    for method in ("gd", "qn", "mekf"):
        q = estimate_q(
            trial.gyr[sl],
            trial.acc[sl],
            trial.dt,
            pol=pol.select(sl),
            method=method,
            frame="ENU",
            q0=trial.q_ref[i0],
            input_stage=False,  # as published: the polarization alone holds the heading
        )
        res[method] = np.degrees(rmse(heading_error(q, trial.q_ref[sl]), mask))
    q6 = estimate_q(
        trial.gyr[sl], trial.acc[sl], trial.dt, method="gd", frame="ENU", q0=trial.q_ref[i0], input_stage=False
    )
    no_pol = np.degrees(rmse(heading_error(q6, trial.q_ref[sl]), mask))
    # the gyro alone drifts by > 5° (z bias ≈ 0.22 °/s over 3 min); polarization holds the heading to < 1°
    assert no_pol > 5.0
    assert res["gd"] < 1.0 and res["qn"] < 1.0 and res["mekf"] < 0.5, res


@pytest.mark.parametrize(
    "options",
    [{}, {"acc_noise_density": 0.0012}, {"bias_noise": 2e-3}, {"couple_heading": 1}],
    ids=["defaults", "acc_noise_density=0.0012", "bias_noise=2e-3", "couple_heading=1"],
)
def test_broad_mekf_6d_heading_not_worse_than_gyro_alone(trial, options):
    """Gyro + accelerometer only: heading is unobservable from gravity, so the MEKF must not do worse than
    integrating the gyro alone (z bias ≈ 0.22 °/s: ≈ 13.6° RMS). Both start from the optical truth at the first
    valid sample; RMSE over the movement samples. Before the null-space-consistent propagation the MEKF gave
    4.5° (defaults), 50° (acc_noise_density 0.0012, a σ of 0.02 per sample) and 48° (bias_noise 2e-3): the heading variance leaked into tilt and
    the gravity update corrected heading through spurious correlations. Now ≈ 10° (heading from the
    bias-corrected gyro) or, with couple_heading=1, ≈ 2–3° (heading corrected through its correlation with the
    bias, which the rotations reveal); inclination as without the fix."""
    i0 = int(np.flatnonzero(np.all(np.isfinite(trial.q_ref), axis=1))[0])
    sl = slice(i0, None)
    mask, q_ref = trial.eval_mask[sl], trial.q_ref[sl]
    q_gyro = attitude_update(q_ref[0], trial.gyr[sl] * trial.dt, coning="none")[1:]
    gyro_only = np.degrees(rmse(heading_error(q_gyro, q_ref), mask))
    q = estimate_q(
        trial.gyr[sl], trial.acc[sl], trial.dt, method="mekf", frame="ENU", q0=q_ref[0], input_stage=False, **options
    )
    mekf = np.degrees(rmse(heading_error(q, q_ref), mask))
    assert gyro_only > 10.0  # the drift the test is about
    assert mekf <= gyro_only, f"MEKF heading {mekf:.2f} deg vs gyro alone {gyro_only:.2f} deg"
    if not options:
        assert np.degrees(rmse(inclination_error(q, q_ref), mask)) < LIMITS_DEG["mekf"]


# --- the nine BROAD trials in shared/ (issue 12): default iframe against the targets and VQF --------------------

NINE = sorted(p for p in BROAD.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
#: VQF 2.1.2 on the same nine trials, default options (issue 12; benchmarks/bench_attitude.py measures it again)
VQF_ONLINE_DEG, VQF_OFFLINE_DEG, VQF_HEADING_9D_DEG = 0.608, 0.488, 2.21


@pytest.fixture(scope="module")
def nine():
    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    from optinav.attitude.checks import TimeBaseWarning, check_imu

    rows = []
    for p in NINE:
        tr = load_broad(p)
        with warnings.catch_warnings():
            warnings.simplefilter("error", TimeBaseWarning)  # nor is a few percent off their rate said
            check_imu(tr.gyr, tr.acc, np.array([tr.dt]))  # real recordings pass the unit / swap / clipping checks
        on = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", checks=False)
        off = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", offline=True, checks=False)
        mag = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag, checks=False)
        m = tr.eval_mask
        rows.append(
            [
                np.degrees(rmse(inclination_error(on, tr.q_ref), m)),
                np.degrees(rmse(inclination_error(off, tr.q_ref), m)),
                np.degrees(rmse(heading_error(mag, tr.q_ref), m)),
            ]
        )
    return np.array(rows)


def test_nine_trials_default_online_beats_vqf_and_no_trial_above_target(nine):
    """Online 6D inclination: mean 0.569° against VQF's 0.608° (the issue's 0.55° is not reached; 0.582° with the
    former 2 rad/s limit on the motion bias update, so the 0.575° bound catches its return), every trial below
    the 1.5° target (worst 1.00°, fast rotation)."""
    assert nine[:, 0].mean() < 0.575, nine[:, 0]
    assert nine[:, 0].mean() < VQF_ONLINE_DEG
    assert nine[:, 0].max() < 1.1


def test_nine_trials_offline_better_than_online(nine):
    """Offline (forward–backward fusion + zero-phase tilt refinement) below online on average and below VQF
    offline (measured 0.484° vs 0.488°: the issue's 0.44° target is not reached); worst trial 0.96°."""
    assert nine[:, 1].mean() < nine[:, 0].mean() - 0.05
    assert nine[:, 1].mean() < VQF_OFFLINE_DEG, nine[:, 1]
    assert nine[:, 1].max() < 1.05


def test_nine_trials_9d_heading_meets_target(nine):
    """9D heading (magnetometer, disturbed trials included) meets the ≤ 2.0° target (VQF online 2.21°): 1.75°
    (1.93° before the field less a body-fixed offset was used through trial 33's attached magnet)."""
    assert nine[:, 2].mean() <= 1.8, nine[:, 2]


def test_an_attached_magnet_is_fitted_and_the_heading_holds():
    """Trial 33: a magnet attached 2 cm from the IMU from about 40 s to 100 s while it turns (~130 °/s). The field
    read in the body less the reference turned with the attitude is a constant (−3, −0.3, +27) µT, scatter
    1.3 µT per axis. The gates rejected it all and the online heading followed the gyro, 5° off by 95 s: 9D
    2.69° RMSE (VQF 3.70°). The offset fitted on the disturbed samples (hard_iron_tau) lets the field less it be
    used from ~65 s: 1.10°; off, the stretch is the gyro's alone again."""
    name = "33_disturbed_attached_magnet_2cm"
    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    f = lambda **o: run_iframe(tr.gyr, tr.acc, np.array([tr.dt]), mag=tr.mag, frame="ENU", **o)  # noqa: E731
    r, r0 = f(), f(hard_iron_tau=0.0)
    on, on0 = (np.degrees(rmse(heading_error(x.q_b_n, tr.q_ref), tr.eval_mask)) for x in (r, r0))
    assert on < 1.3 and on0 > 2.5, (on, on0)
    stretch = slice(int(65 / tr.dt), int(95 / tr.dt))
    assert r.mag_used[stretch].mean() > 0.9 and r0.mag_used[stretch].mean() < 0.1
    fitted = r.mag_offset[stretch][r.mag_offset[stretch].any(axis=1)]
    assert np.abs(np.median(fitted, axis=0) - [-3.0, -0.3, 26.7]).max() < 1.0, np.median(fitted, axis=0)


@pytest.mark.parametrize("start_s,limit", [(60.0, 3.0), (70.0, 2.5), (90.0, 2.5)])
def test_an_offline_cut_that_starts_in_a_magnet_takes_the_field_both_passes_used(tmp_path, start_s, limit):
    """Trial 33 cut from 60 or 70 s to 120 s, and from 90 s to 130 s (in its magnet, attached at ~40 s, taken off at
    ~99 s): the forward
    pass took the magnet's field for the Earth's, and the offline heading smoothed its offset to the field over the
    samples either pass used as measured — 18.2° / 21.1° / 8.3° heading RMSE with exit 0 (online the first two are
    refused). Over those both passes used, the backward pass's reference, from the clean end, rules out the
    magnet's: 2.3° / 1.6° / 1.9°, in memory and streamed."""
    tr = load_broad(_present(BROAD / "33_disturbed_attached_magnet_2cm.hdf5"))
    s = slice(int(start_s / tr.dt), int(130.0 / tr.dt) if start_s == 90.0 else int(120.0 / tr.dt))
    r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s], offline=True)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[s])), tr.eval_mask[s]) < limit
    if start_s == 60.0:  # streamed alike (the backward pass's flags in the file's blocks)
        from optinav.attitude.filestream import stream_attitude
        from optinav.attitude.unit import AttitudeOptions

        path, out = tmp_path / "cut.csv", tmp_path / "a.csv"
        cols = np.column_stack([np.arange(s.stop - s.start) * tr.dt, tr.acc[s], tr.gyr[s], tr.mag[s]])
        np.savetxt(path, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="", fmt="%.10g")
        stream_attitude(path, out, AttitudeOptions(mag=True, frame="ENU", offline=True), chunk_rows=3000)
        q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:5]
        assert np.abs(np.abs(np.sum(q * r.q_b_n, axis=1)) - 1.0).max() < 1e-8


def test_a_magnet_put_on_before_the_motion_is_no_hard_iron_offset_to_refuse():
    """Trial 33 cut at 95 s: the magnet is put on at ~40 s, in the rest before the motion, and stays through all of
    it. How the field turns in the motion is explained by the magnet's offset (88 %), and the estimate was refused
    online as an uncalibrated magnetometer — where the disturbance handling fits the offset while the magnet is on
    (1.02° heading RMSE); cut at 100 s the sphere fit took it for one too (0.98°). The field less that offset is not
    steady over the log (27 % and 12 % norm spread: the rest before the magnet): no offset on the board all along. An offset added to the whole trial 11 (a level body) still is
    one (1 % spread) and refused online, naming it."""
    p33, p11 = _present(
        BROAD / "33_disturbed_attached_magnet_2cm.hdf5", BROAD / "11_undisturbed_slow_translation_B.hdf5"
    )
    tr = load_broad(p33)
    for end in (95.0, 100.0):  # 100 s: the sphere fit's too (12 % left, 31 % before it)
        s = slice(0, int(end / tr.dt))
        r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s])
        assert r.mag_hard_iron is None and r.mag_hard_iron_from is None
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[s])), tr.eval_mask[s]) < 1.3, end
    tr = load_broad(p11)
    field = np.median(np.linalg.norm(tr.mag, axis=1))
    with pytest.raises(OptinavError, match=r"turns in the body about \["):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag + field * np.array([0.48, -0.6, 0.64]))


def test_output_lags_the_reference_by_half_a_sample_not_by_the_integration():
    """Fast rotation (trial 07), online: the output lags BROAD's optical reference by about h/2 (predicting it
    forward by h/2 with the gyro: 1.00° → 0.51°), yet the centred trapezoid (gyr[k−1] + gyr[k])/2 is worse
    (1.62°), not better: the lag is in the recording's timing, and gyr[k] over (t[k−1], t[k]] is already the
    least lagging causal convention (docs/methods/attitude.md, "Timing")."""
    path = _present(BROAD / "07_undisturbed_fast_rotation_B.hdf5")
    from optinav.core.rotations import quat_from_rotvec, quat_multiply

    tr = load_broad(path)
    q = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", checks=False)
    trap = 0.5 * (tr.gyr + np.vstack([tr.gyr[:1], tr.gyr[:-1]]))
    q_trap = estimate_q(trap, tr.acc, tr.dt, frame="ENU", checks=False)
    q_lead = quat_multiply(q, quat_from_rotvec(tr.gyr * (0.5 * tr.dt)))
    err = [np.degrees(rmse(inclination_error(x, tr.q_ref), tr.eval_mask)) for x in (q, q_trap, q_lead)]
    assert err[2] < 0.6 * err[0] and err[1] > 1.4 * err[0], err


def test_a_recording_that_starts_in_fast_motion():
    """BROAD trial 16 cut so that it starts during fast translation (|a| = 26.8 m/s² on the first sample). The
    first sample filled the accelerometer low-pass and levelled the estimate, and the magnetometer's reference
    dip was taken with that tilt: 72° tilt error at 2 s, 17.9° RMSE (VQF 4.96° on the same samples), the
    magnetometer rejected on 98 % of the samples and the heading 28° off after a minute. Now the low-pass starts
    as the running mean of its first tau_acc seconds, the reference is learned once the tilt has settled and the
    heading converges from then on (as VQF starts)."""
    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    s0 = 18081
    g, a, m, ref = tr.gyr[s0:], tr.acc[s0:], tr.mag[s0:], tr.q_ref[s0:]
    assert np.linalg.norm(a[0]) > 25.0
    q = estimate_q(g, a, tr.dt, frame="ENU", checks=False)
    inc = np.degrees(inclination_error(q, ref))
    at = lambda t0, t1: slice(int(t0 / tr.dt), int(t1 / tr.dt))  # noqa: E731
    assert np.nanmax(inc[at(2, 5)]) < 10.0 and np.nanmax(inc[at(5, 30)]) < 8.0
    assert np.degrees(rmse(inclination_error(q, ref), tr.eval_mask[s0:])) < 5.6  # VQF 4.96
    est = estimate(g, a, tr.dt, frame="ENU", mag=m, checks=False)
    head = np.degrees(heading_error(est.q_b_n, ref))
    assert est.mag_used.mean() > 0.8
    assert np.nanmean(head[-int(30 / tr.dt) :]) < 2.0 and np.nanmax(head[at(5, 10)]) < 5.0


def test_an_uncalibrated_magnetometer_is_fitted_online_and_subtracted_offline(tmp_path):
    """A hard-iron offset (+30 µT on body x of trial 02) turned the 9D heading 62° with exit 0 and only
    'magnetometer used 67 %' (VQF is as wrong: no estimator can tell the offset from the field); then a warning
    with exit 0 and no way to subtract it. The field norm follows the orientation, which a constant offset
    explains. Online it was refused (the whole recording's fit uses future samples); now the offset is fitted from
    past samples and used from the sample where that fit passes its gates (trial 02 turns about its x axis only
    from 104 s: the magnetometer is unused before), the heading from there within 0.5° of the offset given's
    (measured 1.07° vs 1.67°); trial 29 (a magnet beside it, the field disturbed throughout) was refused: its fit
    never passed the gates, the rest before its motion in the sums; it now passes at 37.5 s (29.5 µT on x), the
    heading at 1.74° (the offset given 1.21°). Given, and offline (fitted from the whole
    recording), the heading is as good as the trial's own. None of the nine trials (the magnet trials included) is
    taken for one."""
    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    for p in NINE:
        assert hard_iron(load_broad(p).mag) is None, p.name
    tr = load_broad(PATH)
    mag = tr.mag + [30.0, 0.0, 0.0]
    head = lambda est, sl=True: rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref)), tr.eval_mask & sl)
    est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    k = est.mag_hard_iron_from
    after = np.arange(mag.shape[0]) >= k
    given = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=[30.0, 0.0, 0.0])
    assert abs(k * tr.dt - 103.8) < 1.0 and not est.mag_used[:k].any()
    assert head(est, after) < head(given, after) + 0.5, (head(est, after), head(given, after))
    assert f"(fitted online from past samples; the magnetometer used from sample {k} on" in est.summary()
    d = load_broad(next(p for p in NINE if p.name.startswith("29_")))
    near = estimate(d.gyr, d.acc, d.dt, frame="ENU", mag=d.mag + [30.0, 0.0, 0.0])
    np.testing.assert_allclose(near.mag_hard_iron, [30.0, 0.0, 0.0], atol=1.0)
    assert rmse(np.degrees(heading_error(near.q_b_n, d.q_ref)), d.eval_mask) < 2.5  # the offset given: 1.21°
    b = hard_iron(mag)[0]
    np.testing.assert_allclose(b, [30.0, 0.0, 0.0], atol=1.0)
    # the fit from past samples, of the rows taken while the gyro turns, ends near the whole one of every row
    # (29.73, -0.06, 0.09 against 29.69, -0.11, 0.39)
    np.testing.assert_allclose(est.mag_hard_iron, b, atol=0.5)
    for offline in (False, True):
        own = head(estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag, offline=offline))
        kw = {} if offline else {"mag_hard_iron": b}
        est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=offline, **kw)
        # the trial's own magnetometer keeps a fraction of a µT of offset (the fit's b is 29.7, not 30): better
        assert head(est) < own + 0.1 and est.mag_hard_iron_fitted == offline
        np.testing.assert_array_equal(est.mag_hard_iron, b)
        how = "fitted from the recording's rotations" if offline else "given"
        assert f"magnetometer offset [29.69, -0.1118, 0.3866] subtracted ({how})" in est.summary()
        back = AttitudeEstimate.from_json(est.to_json(tmp_path / f"e{offline}.json"))
        np.testing.assert_array_equal(back.mag_hard_iron, b)
    # 5 µT turned the heading 12-16° with no word: the fit takes the norm's spread 5.4 % down to 1.8 %
    small = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag + [5.0, -2.5, 1.5])
    np.testing.assert_allclose(small.mag_hard_iron, [5.0, -2.5, 1.5], atol=0.5)
    est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag)
    assert est.mag_hard_iron is None and "magnetometer offset" not in est.summary()
    with pytest.raises(OptinavError, match="mag_hard_iron was given without a magnetometer"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag_hard_iron=b)
    with pytest.raises(OptinavError, match="mag_hard_iron contains 1 NaN"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=[1.0, np.nan, 0.0])


def test_an_offset_on_a_magnetometer_with_soft_iron_is_seen_along_every_axis_the_field_turns_about():
    """BROAD 07 (fast rotation) with +30 µT on body x and 5 % soft iron (a scale/misalignment matrix): the field
    norm varies by 12 % with the orientation, and the fit of the offset along the two axes turned about by more than
    15 % of |m| left it unexplained (the third by 14.7 % of |m|, which the offset inflates; 18 % of the field), so
    nothing was fitted or said and the online heading was 52° off with exit 0 (offline 48°). Judged against the
    field the fit finds, that axis is seen: the offset is fitted (within 1 µT of the one added, measured 0.7 µT),
    the online heading after the fit passed (42 s) within 1° of the offset given's and under 3.5° (measured 2.77°
    vs 2.64°), and offline 2.42°."""
    p = _present(BROAD / "07_undisturbed_fast_rotation_B.hdf5")
    tr = load_broad(p)
    soft = np.eye(3) + np.random.default_rng(1).uniform(-0.05, 0.05, (3, 3))
    mag = tr.mag @ soft.T + [30.0, 0.0, 0.0]
    b = hard_iron(mag)[0]
    np.testing.assert_allclose(b, [30.0, 0.0, 0.0], atol=1.0)
    head = lambda est, sl=True: rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref)), tr.eval_mask & sl)
    est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    after = np.arange(mag.shape[0]) >= est.mag_hard_iron_from
    given = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=[30.0, 0.0, 0.0])
    assert head(est, after) < min(head(given, after) + 1.0, 3.5), (head(est, after), head(given, after))
    assert head(estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)) < 3.0


@pytest.mark.parametrize(("name", "offset"), [("07", (100.0, -80.0, 60.0)), ("02", (250.0, -150.0, 300.0))])
def test_an_offset_larger_than_the_field_is_fitted(name, offset):
    """A raw magnetometer's offset can exceed the Earth's field (a phone's: hundreds of µT). Whether the field had
    turned about an axis was judged against |m|, which such an offset inflates 3-9 times: BROAD 07 with
    (100, -80, 60) µT and 02 with (250, -150, 300) µT showed no offset and the heading was 119° and 105° off with
    exit 0, online and offline (02 with (100, -80, 60) µT was refused online though fitted within 0.5 µT).
    Judged against the fitted field's radius, the offset is fitted within 1 µT (measured 0.8 and 0.4), online from
    the sample the fit passed (48 s, 105 s) the heading within 1° of the whole recording's offset given (measured
    3.75° vs 2.98° and 1.00° vs 0.78°), offline within 2.5° (measured 2.19° and 0.42°)."""
    p = next((q for q in NINE if q.name.startswith(name + "_")), None)
    if p is None:
        pytest.skip(f"BROAD trial {name} is not present")
    tr = load_broad(p)
    mag = tr.mag + offset
    head = lambda est, sl=True: rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref)), tr.eval_mask & sl)
    est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    np.testing.assert_allclose(est.mag_hard_iron, offset, atol=1.0)
    after = np.arange(mag.shape[0]) >= est.mag_hard_iron_from
    # the offset the whole recording's fit names (BROAD's own magnetometer keeps a fraction of a µT)
    given = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=hard_iron(mag)[0])
    assert head(est, after) < head(given, after) + 1.0, (head(est, after), head(given, after))
    off = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
    np.testing.assert_allclose(off.mag_hard_iron, offset, atol=1.0)
    assert head(off) < 2.5


@pytest.mark.parametrize("name", ["02", "03", "24"])
def test_the_whole_recordings_offset_does_not_depend_on_the_offset(name):
    """The sphere fit is the same wherever the offset puts the sphere: (100, -80, 60) µT less the fit is +30 µT on x
    less its fit within 0.01 µT. The axes were judged turned about against the radius of a fit along the axes
    turned by 15 % of |m| only, which keeps the offset along the others: no offset was seen on the rows, and the
    recording's distinct fields gave one 0.3-0.7 µT from the +30 µT fit's."""
    p = next((q for q in NINE if q.name.startswith(name + "_")), None)
    if p is None:
        pytest.skip(f"BROAD trial {name} is not present")
    mag = load_broad(p).mag
    big, small = np.array([100.0, -80.0, 60.0]), np.array([30.0, 0.0, 0.0])
    np.testing.assert_allclose(hard_iron(mag + big)[0] - big, hard_iron(mag + small)[0] - small, atol=0.01)


def test_the_magnetometer_axes_are_judged_on_the_field_less_its_offset(tmp_path, capsys):
    """BROAD 03's first 30 000 rows with (250, -150, 300) µT (a raw magnetometer's offset, 9 times the field): the
    magnetometer-axes check judged the field as measured, whose direction the offset holds nearly still and turns
    unlike the body, and refused it as turning against the gyro (a mirrored frame), in memory and streamed. It now
    judges the field less the offset the hard-iron check found (or was given): fitted online and offline, in
    memory as streamed (the heading within 1e-3° of each other)."""

    p = next((q for q in NINE if q.name.startswith("03_")), None)
    if p is None:
        pytest.skip("BROAD trial 03 is not present")
    tr = load_broad(p)
    n, off = 30000, np.array([250.0, -150.0, 300.0])
    rows = np.column_stack([np.arange(n) * tr.dt, tr.gyr[:n], tr.acc[:n], tr.mag[:n] + off])
    f = tmp_path / "raw.csv"
    np.savetxt(f, rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")
    back = np.loadtxt(f, delimiter=",", skiprows=1)
    for offline in (False, True):
        est = estimate(back[:, 1:4], back[:, 4:7], tr.dt, frame="ENU", mag=back[:, 7:10], offline=offline)
        np.testing.assert_allclose(est.mag_hard_iron, off, atol=1.5)
        _streamed_as_in_memory(f, est.q_b_n, offline, 7000, tmp_path, capsys)
        if not offline:  # the fit asked for (mag_hard_iron="online") is judged alike: it was refused as mirrored
            said = estimate(back[:, 1:4], back[:, 4:7], tr.dt, frame="ENU", mag=back[:, 7:10], mag_hard_iron="online")
            assert said.mag_hard_iron_from == est.mag_hard_iron_from and np.array_equal(said.q_b_n, est.q_b_n)


def test_an_offset_after_a_long_rest_is_not_diluted_out_of_sight():
    """A logger left at rest for 10 min before the motion (BROAD 02's first 5 s of rest repeated, then the trial)
    with +30 µT on body x: the norm's and the field's spreads were taken over the rows, which the rest outnumbers
    3 to 1, so one axis spread by 12 % (32 % without the rest), no offset was seen, and the online heading was 63°
    off with exit 0. Judged on its distinct fields too, the offset is seen (within 1 µT): offline subtracted (the
    heading within 1°, measured 0.50°). Online it was refused, as the fit from past samples, whose sums the rest
    diluted too, never passed its gates; it takes only the rows where the gyro turns now, passes as on the trial
    without the rest (from its 104th s of motion) and the heading is within 1.5° (measured 0.86°, the offset given
    1.36°)."""
    tr = load_broad(PATH)
    rest = np.tile(np.arange(int(5 * tr.rate_hz)), 120)
    idx = np.r_[rest, np.arange(tr.gyr.shape[0])]
    gyr, acc, mag = tr.gyr[idx], tr.acc[idx], tr.mag[idx] + [30.0, 0.0, 0.0]
    mask = np.r_[np.zeros(rest.size, bool), tr.eval_mask]
    est = estimate(gyr, acc, tr.dt, frame="ENU", mag=mag)
    np.testing.assert_allclose(est.mag_hard_iron, [30.0, 0.0, 0.0], atol=1.0)
    assert abs((est.mag_hard_iron_from - rest.size) * tr.dt - 103.8) < 1.0
    assert rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref[idx])), mask) < 1.5
    est = estimate(gyr, acc, tr.dt, frame="ENU", mag=mag, offline=True)
    np.testing.assert_allclose(est.mag_hard_iron, [30.0, 0.0, 0.0], atol=1.0)
    assert rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref[idx])), mask) < 1.0


def test_an_uncalibrated_magnetometer_on_a_streamed_file(tmp_path, capsys):
    """The same on a log read in blocks: online the offset fitted from past samples (the same as in memory), the
    offset given or --offline subtract it, and the rows the fit reads are gathered while the file streams."""
    from optinav.cli.main import main

    tr = load_broad(PATH)
    mag = tr.mag + [30.0, 0.0, 0.0]
    n = 40000  # the first 20 000 samples turn too little for a fit
    rows = np.column_stack([np.arange(n) * tr.dt, tr.gyr[:n], tr.acc[:n], mag[:n]])
    f = tmp_path / "hi.csv"
    np.savetxt(f, rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")
    out = tmp_path / "o.csv"
    cmd = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "3000", "--out", str(out)]
    assert main(cmd) == 0
    line = capsys.readouterr().out
    back = np.loadtxt(f, delimiter=",", skiprows=1)
    mem = estimate(back[:, 1:4], back[:, 4:7], tr.dt, frame="ENU", mag=back[:, 7:10])
    k = mem.mag_hard_iron_from
    b = ", ".join(f"{v:.4g}" for v in mem.mag_hard_iron)
    assert f"[{b}] subtracted (fitted online from past samples; the magnetometer used from sample {k} on" in line
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:5]
    assert k == 29663 and np.nanmax(np.degrees(heading_error(q, mem.q_b_n))) < 1e-3
    b = hard_iron(mag[:n])[0]
    given = ",".join(f"{v:.4g}" for v in b)
    for extra, how in (([f"--mag-hard-iron={given}"], "given"), (["--offline"], "fitted from the recording's")):
        assert main([*cmd, *extra]) == 0
        line = capsys.readouterr().out
        assert f"magnetometer offset [{', '.join(f'{v:.4g}' for v in b)}] subtracted ({how}" in line
        q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:5]
        est = estimate(tr.gyr[:n], tr.acc[:n], tr.dt, frame="ENU", mag=tr.mag[:n], offline=extra == ["--offline"])
        assert np.nanmax(np.degrees(heading_error(q, est.q_b_n))) < 3.0
    assert main(["attitude", str(f), "--frame", "ENU", "--mag-hard-iron", "1,2,3", "--out", str(out)]) == 2
    assert "--mag-hard-iron was given without a magnetometer; add --mag (or --mag-columns, --mag-file)" in (
        capsys.readouterr().err
    )


def test_a_batch_names_the_unit_of_each_warning_and_keeps_it_in_its_row(tmp_path, capsys):
    """``optinav batch attitude`` over BROAD trials in the default frame (NED): four frame warnings went to stderr
    naming no unit, and neither the table nor its journal kept them (a resumed batch lost them). Each warning now
    starts with its unit's name and is in that row's ``notes``, also when the row is resumed from the journal."""
    from optinav.batch import read_results
    from optinav.cli.main import main

    tr = load_broad(PATH)
    d = tmp_path / "units"
    d.mkdir()
    for name, k in (("a", 12000), ("b", 9000)):
        rows = np.column_stack([np.arange(k) * tr.dt, tr.gyr[:k], tr.acc[:k]])
        np.savetxt(d / f"{name}.csv", rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az", comments="", fmt="%.9g")
    out = tmp_path / "b.csv"
    argv = ["batch", "attitude", str(d), "--workers", "0", "--out", str(out)]
    assert main(argv) == 0
    said = [x for x in capsys.readouterr().err.splitlines() if x.startswith("optinav: warning:")]
    assert sorted(x.split(": ")[2] for x in said) == ["a", "b"] and all("--frame ENU" in x for x in said), said
    for again in (False, True):  # the second run resumes both rows from the journal
        if again:
            assert main(argv) == 0
        got = {r["unit"]: r for r in read_results(out)}
        for unit in "ab":
            text = next(x for x in said if x.startswith(f"optinav: warning: {unit}: ")).split(f"{unit}: ", 1)[1]
            assert got[unit]["notes"] == f"warning: {text}", got[unit]["notes"]


def test_a_batch_row_says_the_hard_iron_offset_and_from_which_sample(tmp_path):
    """``optinav batch attitude --mag`` on an uncalibrated magnetometer (trial 02's first 40 000 rows, +30 µT on x):
    the row said nothing of the offset subtracted nor that the heading was the gyro's until the online fit passed
    (the summary line of ``optinav attitude`` says both). It now holds the offset (``mag_hard_iron_x/y/z``, the
    magnetometer's unit) and ``mag_hard_iron_from``, those of the estimate in memory; offline the offset fitted
    from the recording; a calibrated magnetometer leaves them empty."""
    from optinav.batch import read_results
    from optinav.cli.main import main

    tr = load_broad(PATH)
    n = 40000
    d = tmp_path / "units"
    d.mkdir()
    for name, off, k in (("raw", [30.0, 0.0, 0.0], n), ("calibrated", [0.0, 0.0, 0.0], 5000)):
        rows = np.column_stack([np.arange(k) * tr.dt, tr.gyr[:k], tr.acc[:k], tr.mag[:k] + off])
        np.savetxt(
            d / f"{name}.csv", rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g"
        )
    back = np.loadtxt(d / "raw.csv", delimiter=",", skiprows=1)
    for extra in ([], ["--offline"]):
        out = tmp_path / f"b{len(extra)}.csv"
        argv = ["--quiet", "batch", "attitude", str(d), "--frame", "ENU", "--mag", "--workers", "0", *extra]
        assert main([*argv, "--out", str(out)]) == 0
        got = {r["unit"]: r for r in read_results(out)}
        mem = estimate(back[:, 1:4], back[:, 4:7], tr.dt, frame="ENU", mag=back[:, 7:10], offline=bool(extra))
        raw = got["raw"]
        np.testing.assert_allclose([raw[f"mag_hard_iron_{a}"] for a in "xyz"], mem.mag_hard_iron, atol=1e-6)
        assert raw.get("mag_hard_iron_from") == mem.mag_hard_iron_from == (None if extra else 29663), raw
        cal = got["calibrated"]
        assert all(cal.get(k) is None for k in ("mag_hard_iron_x", "mag_hard_iron_from")), cal


def test_a_wrong_given_hard_iron_offset_is_refused(tmp_path, capsys):
    """--mag-hard-iron was subtracted unchecked: trial 02 given 20,-10,5 (its magnetometer calibrated) gave a 39° RMS
    heading with exit 0, online and offline; +30 µT given with the wrong sign was taken as well. Now the field less
    the given offset is judged as an ungiven one is: refused, in memory and streamed, online and offline, naming the
    offset that explains the field; that offset, typed, gives the heading of the correctly given one."""
    from optinav.cli.main import main

    tr = load_broad(PATH)
    head = lambda est: rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref)), tr.eval_mask)
    for offline in (False, True):
        with pytest.raises(OptinavError, match=r"less the given offset \[20, -10, 5\] .*--mag-hard-iron=-0\.3"):
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag, mag_hard_iron=[20.0, -10.0, 5.0], offline=offline)
    mag = tr.mag + [30.0, 0.0, 0.0]
    b = hard_iron(mag)[0]
    n = 40000
    rows = np.column_stack([np.arange(n) * tr.dt, tr.gyr[:n], tr.acc[:n], mag[:n]])
    f = tmp_path / "hi.csv"
    np.savetxt(f, rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")
    out = tmp_path / "o.csv"
    cmd = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "3000", "--out", str(out)]
    wrong = ",".join(f"{v:.4g}" for v in -hard_iron(mag[:n])[0])
    for extra in ([], ["--offline"]):
        assert main([*cmd, f"--mag-hard-iron={wrong}", *extra]) == 2 and not out.exists()
        err = [e for e in capsys.readouterr().err.splitlines() if "error" in e]
        assert len(err) == 1 and "a further offset of [59." in err[0], err
    given = err[0].split("--mag-hard-iron=")[1].split()[0]
    np.testing.assert_allclose([float(v) for v in given.split(",")], hard_iron(mag[:n])[0], atol=0.01)
    assert main([*cmd, f"--mag-hard-iron={given}"]) == 0
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:5]
    est = estimate(tr.gyr[:n], tr.acc[:n], tr.dt, frame="ENU", mag=tr.mag[:n])
    assert np.nanmax(np.degrees(heading_error(q, est.q_b_n))) < 3.0
    own = head(estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag))
    assert head(estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=b)) < own + 0.1


@pytest.mark.parametrize("block", [999, 4096, 65536])
def test_streamed_hard_iron_rows_are_evenly_spaced(block):
    """The streamed check keeps rows 0, s, 2s, … of the whole log (s doubling as it fills), whatever the blocks,
    and the in-memory estimate the same rows (an offset fitted offline is the same, the outputs identical)."""
    from optinav.attitude.checks import MAG_FIT_ROWS, mag_fit_stride
    from optinav.attitude.stream import StreamChecks

    n = 5 * MAG_FIT_ROWS + 123
    mag = np.arange(3 * n, dtype=float).reshape(n, 3)
    c = StreamChecks()
    for a in range(0, n, block):
        c.add_mag(mag[a : a + block])
    kept = np.concatenate(c._mag)
    s = c._mag_stride
    assert s == 4 and np.array_equal(kept, mag[::s])
    # a log in memory is fitted on the same rows (it took every n // MAG_FIT_ROWS-th: 5, another fit)
    assert (
        mag_fit_stride(n) == s and mag_fit_stride(2 * MAG_FIT_ROWS) == 1 and mag_fit_stride(2 * MAG_FIT_ROWS + 1) == 2
    )


def test_a_deg_s_gyro_on_a_log_at_rest_is_refused():
    """The first 30 s of trial 02 (at rest) with the gyro in deg/s but declared rad/s: its 0.2 °/s bias read as
    0.2 rad/s tilted the estimate 41° with exit 0 (the unit check judged how gravity turns around a centred
    mean, which a steady false turn follows). A body the accelerometer shows still for 2 s cannot turn about a
    horizontal axis: refused naming --gyro-unit deg/s; the same samples in rad/s, and a steady level turn
    (specific force tilted by its centripetal pull, turning about the vertical), pass."""
    from optinav.attitude.checks import check_imu
    from optinav.errors import OptinavError

    tr = load_broad(PATH)
    m = int(30 / tr.dt)
    d = np.full(m, tr.dt)
    with pytest.raises(OptinavError, match=r"--gyro-unit deg/s \(the gyro turns at 0.1\d+ rad/s about a horizontal"):
        check_imu(np.degrees(tr.gyr[:m]), tr.acc[:m], d)
    check_imu(tr.gyr[:m], tr.acc[:m], d)
    rng = np.random.default_rng(3)
    n = 6000
    acc = np.tile([1.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.05, (n, 3))  # 1 m/s² centripetal, level body
    gyr = np.tile([0.0, 0.0, 0.2], (n, 1)) + rng.normal(0, 0.002, (n, 3))
    check_imu(gyr, acc, np.full(n, 0.01))


@pytest.mark.parametrize(
    ("name", "after_s", "limit", "vqf"),
    [("11_undisturbed_slow_translation_B", 10.0, 4.5, 3.42), ("16_undisturbed_fast_translation_B", 5.0, 6.89, 6.89)],
)
def test_a_9d_recording_cut_in_motion_keeps_its_bias_and_heading(name, after_s, limit, vqf):
    """Cut 5-10 s after the motion starts, with no rest to learn the gyro bias from: the motion bias update
    (through the accelerometer low-pass, with the prior's σ) rang between its ±2 °/s clips for a minute, and the
    heading over the next 60 s was 11.7° (trial 11) and 18.1° (16) off, VQF 3.4° and 6.9°. The update's
    innovation is now clipped and its loop kept slower than 2 tau_acc: 2.9° and 5.0°; with the heading of the
    first tau_acc s low-passed over MAG_SETTLE_TAU (which helps cuts on average: 36 cuts' first minute 8.41 ->
    8.31°) 2.8° and 6.5° — trial 16's limit is VQF's."""
    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    s0 = int(np.flatnonzero(tr.eval_mask)[0] + after_s / tr.dt)
    est = estimate(tr.gyr[s0:], tr.acc[s0:], tr.dt, frame="ENU", mag=tr.mag[s0:], checks=False)
    win = tr.eval_mask[s0:] & (np.arange(tr.gyr.shape[0] - s0) * tr.dt < 60.0)
    head = np.degrees(rmse(heading_error(est.q_b_n, tr.q_ref[s0:]), win))
    assert head < limit, (head, vqf)
    assert np.degrees(np.abs(est.gyr_bias[: int(60 / tr.dt)])).max() < 1.0


def _heading_drift_deg(q, q_ref, mask) -> float:
    """RMSE (deg) over ``mask`` of BROAD's heading error less its value at the first sample with a reference."""
    e = earth_error_quaternion(q, q_ref)
    ok = np.isfinite(e[:, 0])
    psi = np.unwrap(2.0 * np.arctan2(e[ok, 3], e[ok, 0]))
    return float(np.degrees(rmse(psi - psi[0], mask[ok])))


def _cut_in_motion(name: str, start_s: float):
    """(trial, slice): BROAD trial ``name`` from ``start_s`` s after its first movement sample to 10 s before its
    last (benchmarks/bench_attitude_cuts.py's cuts); skips when the trial is absent."""
    p = next((BROAD / f"{name}{x}" for x in (".hdf5", ".mat")
              if (BROAD / f"{name}{x}").is_file()), None)  # fmt: skip
    if p is None:
        pytest.skip(f"{name} absent")
    tr = load_broad(p)
    mv = np.flatnonzero(tr.eval_mask)
    return tr, slice(int(mv[0] + start_s / tr.dt), int(mv[-1] - 10.0 / tr.dt))


def test_a_cut_in_fast_rotation_keeps_its_bias():
    """Trial 29 (about 400 °/s about changing axes, a lever arm's centripetal acceleration) cut to start 10 s into
    its motion, no rest to learn the bias from. The low-passed C_b^I of so fast a rotation is small, so the motion
    update's rows are short; its variance floor grew with |row|² and the gain per unit correction rate with
    1/|row|: the lever arm's correction rates became bias, z at the 2 °/s clip within 10 s, 6D heading drift
    34.8° RMSE and 9D heading 6.1° (VQF 5.0° and 2.3°; the whole trial's bias is about 0.2 °/s). The floor now
    bounds that gain: 12.0° and 2.9°."""
    tr, s = _cut_in_motion("29_disturbed_stationary_magnet_B", 10.0)
    est = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", checks=False)
    drift = _heading_drift_deg(est.q_b_n, tr.q_ref[s], tr.eval_mask[s])
    assert drift < 15.0, drift  # VQF 5.0
    b = run_iframe(tr.gyr[s], tr.acc[s], np.array([tr.dt]), frame="ENU").gyr_bias
    assert np.degrees(np.abs(b)).max() < 1.0  # 0.75; 1.97 before (the clip is 2)
    est = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s], checks=False)
    assert np.degrees(rmse(heading_error(est.q_b_n, tr.q_ref[s]), tr.eval_mask[s])) < 3.5  # VQF 2.3


def test_the_offline_6d_heading_of_a_cut_in_motion_drifts_less_than_the_online_one():
    """Trial 11 (slow translation) cut 30 s into its motion, 6D: the fused heading came from the forward pass at
    the end and from the backward one at the start, which carried the forward end's heading back with its own bias:
    18.1° drift RMSE offline against 11.5° online (VQF offline 11.5°). The heading is now the gyro's with each
    pass's bias where that pass has run longer (iframe.blended_bias): 0.3°. The tilt is untouched."""
    tr, s = _cut_in_motion("11_undisturbed_slow_translation_B", 30.0)
    ref, mask = tr.q_ref[s], tr.eval_mask[s]
    on = estimate_q(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", checks=False)
    off = estimate_q(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", offline=True, checks=False)
    drift = [_heading_drift_deg(q, ref, mask) for q in (off, on)]
    assert drift[0] < 3.0 and drift[0] < drift[1], drift
    assert np.degrees(rmse(inclination_error(off, ref), mask)) < 0.35  # 0.288° (online 0.581°, VQF offline 0.270°)


@pytest.mark.parametrize(("start_s", "end_s", "before"), [(-100.0, 60.0, 6.55), (20.0, None, 2.36)])
def test_offline_on_a_recording_that_ends_or_starts_in_motion(start_s, end_s, before):
    """Trial 16 (fast translation) cut to end 60 s into the motion, or to start 20 s into it (times from the
    first movement sample): the zero-phase filter's odd padding pinned the low-passed specific force to the
    accelerated end sample, and the fusion kept half of the forward pass's start: offline 6.55° and 2.36° (online
    0.53° and 8.3°, VQF offline 0.46° on both). Even padding and fusion weights that grow with each pass's
    running time: below 0.8°."""
    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    m0 = np.flatnonzero(tr.eval_mask)[0]
    s = slice(max(0, int(m0 + start_s / tr.dt)), None if end_s is None else int(m0 + end_s / tr.dt))
    q = estimate_q(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", offline=True, checks=False)
    assert np.degrees(rmse(inclination_error(q, tr.q_ref[s]), tr.eval_mask[s])) < 0.8, before


def _broad_copy(path, out, drop=(), scale=None, attrs=None):
    """A copy of a BROAD HDF5 trial without the datasets ``drop``, the IMU arrays scaled (``scale``: {name:
    factor}) and root attributes added."""
    import h5py

    with h5py.File(path, "r") as src, h5py.File(out, "w") as dst:
        for k in src:
            if k not in drop:
                dst[k] = src[k][()] * (scale or {}).get(k, 1.0)
        dst.attrs.update(dict(src.attrs))
        dst.attrs.update(attrs or {})
    return out


def test_broad_layout_files_as_users_make_them(tmp_path, capsys):
    """An HDF5 in BROAD's layout without the optical reference was refused ('lacks opt_quat, movement') even
    without --reference; its units in the file's attributes or in --acc-unit/--gyro-unit were ignored (an
    accelerometer in g then refused with "declare the unit with --acc-unit"), --time-unit and a contradicting
    --rate passed silently; the generic reader found no gyroscope in imu_gyr."""
    from optinav.cli.main import main
    from optinav.io import read_imu

    p = _present(SHARED / BROAD_TRIAL_02)
    out = str(tmp_path / "x.csv")

    def run(path, *extra):
        code = main(["--quiet", "attitude", str(path), "--frame", "ENU", *extra, "--out", out])
        cap = capsys.readouterr()
        return code, (cap.out + cap.err).strip().splitlines()

    own = _broad_copy(p, tmp_path / "own.hdf5", drop=("opt_quat", "movement"))
    assert run(own)[0] == 0
    code, err = run(own, "--reference")
    assert code == 2 and "not a BROAD file with opt_quat and movement" in err[-1], err
    assert read_imu(own).gyr.shape == (read_imu(own).t.size, 3)
    d2r, g = np.pi / 180.0, 9.80665
    scaled = {"imu_gyr": 1 / d2r, "imu_acc": 1 / g}
    by_attr = _broad_copy(p, tmp_path / "attr.hdf5", scale=scaled, attrs={"acc_unit": "g", "gyro_unit": "deg/s"})
    by_flag = _broad_copy(p, tmp_path / "flag.hdf5", scale=scaled)
    code, ref = run(p, "--reference")
    for path, extra in ((by_attr, ()), (by_flag, ("--acc-unit", "g", "--gyro-unit", "deg/s"))):
        code, got = run(path, "--reference", *extra)
        score = [x for x in got if "inclination RMSE" in x]
        assert code == 0 and len(score) == 1 and score == [x for x in ref if "inclination RMSE" in x]
    code, err = run(p, "--time-unit", "ms")
    assert code == 2 and "--time-unit" in err[-1]
    code, err = run(p, "--rate", "100")
    assert code == 2 and "sampling_rate" in err[-1] and "drop --rate" in err[-1]
    # the file's rate typed to its printed digits is the file's rate (was refused as "states 285.714 Hz, --rate
    # says 285.714")
    code, got = run(p, "--reference", "--rate", "285.714")
    assert code == 0 and [x for x in got if "inclination RMSE" in x] == [x for x in ref if "inclination RMSE" in x]


def test_a_gyro_logged_in_whole_deg_s_is_not_taken_for_clipped():
    """Trial 02's gyro rounded to whole deg/s (a logger's CSV): a 411 °/s peak held 3 samples and entered by
    3 °/s (0.7 % of the peak, above the 0.5 % rule) was refused as clipped, with no way round it; the
    quantum of the output now bounds a natural step. A real clip of the same data at 300 °/s is still named."""
    from optinav.attitude.checks import _check_clipping, axis_steps, quantum
    from optinav.errors import OptinavError

    p = _present(SHARED / BROAD_TRIAL_02)
    tr = load_broad(p)
    whole = np.radians(np.round(np.degrees(tr.gyr)))
    assert quantum(axis_steps(whole[:, 0])) == pytest.approx(np.radians(1.0))
    assert quantum(axis_steps(tr.gyr[:, 0])) == 0.0
    _check_clipping(whole, None, tr.dt)  # no error
    with pytest.raises(OptinavError, match="clipped"):
        _check_clipping(np.clip(whole, -np.radians(300.0), np.radians(300.0)), None, tr.dt)


@pytest.mark.parametrize(
    "name",
    [
        "07_undisturbed_fast_rotation_B.hdf5",
        "16_undisturbed_fast_translation_B.hdf5",
        "29_disturbed_stationary_magnet_B.mat",
    ],
)
def test_a_rad_s_gyro_declared_deg_s_is_named_on_dynamic_recordings(name):
    """A rad/s gyro declared deg/s (×π/180) on fast rotation, fast translation and a disturbed trial passed the
    unit check with exit 0 (its per-sample spread drowned in the translation: 0.69 vs 0.42 rad on trial 07, 1.25
    vs 1.60 on 16); the drift of the 2-s means in the gyro-integrated frame averages the translation out (0.54 vs
    0.03 rad on 07). The right unit passes (the nine trials' fixture checks every one)."""
    from optinav.attitude.checks import check_imu
    from optinav.errors import OptinavError

    p = _present(BROAD / name)
    tr = load_broad(p)
    # from Python the data are rad/s by contract: the cause says so (it said "in deg/s" for a day)
    with pytest.raises(OptinavError, match="the gyro in rad/s does not explain.*rad/s declared deg/s"):
        check_imu(tr.gyr * np.pi / 180.0, tr.acc, np.array([tr.dt]))
    check_imu(tr.gyr, tr.acc, np.array([tr.dt]))


def test_a_reference_stored_scalar_last_is_named(tmp_path, capsys):
    """opt_quat stored [x, y, z, w] (scipy's order) scored 102° with no hint: a warning then said that
    read so it scores 0.39°; now its turns against the gyro refuse it, naming the order (exit 2, no score); BROAD's
    own order scores with no word on it."""
    import h5py

    from optinav.cli.main import main

    p = _present(SHARED / BROAD_TRIAL_02)
    bad = _broad_copy(p, tmp_path / "xyzw.hdf5")
    with h5py.File(bad, "r+") as f:
        q = f["opt_quat"][()]
        del f["opt_quat"]
        f["opt_quat"] = q[:, [1, 2, 3, 0]]
    for path, warned in ((p, False), (bad, True)):
        argv = ["--quiet", "attitude", str(path), "--frame", "ENU", "--reference", "--out", str(tmp_path / "x.csv")]
        assert main(argv) == (2 if warned else 0)
        err = capsys.readouterr().err
        assert ("stored scalar-last" in err) == warned, err


@pytest.mark.parametrize(
    ("key", "cut", "reference_only"),
    [("opt_quat", np.s_[:, :3], True), ("opt_quat", np.s_[:-100], True), ("movement", np.s_[:-10], True),
     ("imu_acc", np.s_[:-50], False)],
)  # fmt: skip
def test_a_dataset_not_one_row_per_sample_is_named_in_one_line(tmp_path, capsys, key, cut, reference_only):
    """opt_quat of 3 columns or 100 rows short, movement 10 rows short, or imu_acc 50 rows short ended in an
    internal error (exit 1, "operands could not be broadcast together"), in memory and streamed: each names the
    dataset and its shape (exit 2); a damaged reference only where --reference asks for it."""
    import h5py

    from optinav.cli.main import main

    bad = _broad_copy(_present(SHARED / BROAD_TRIAL_02), tmp_path / "bad.hdf5")
    with h5py.File(bad, "r+") as f:
        x = f[key][()]
        del f[key]
        f[key] = x[cut]
    for extra in ([], ["--offline"]):
        for reference in ([], ["--reference"]):
            argv = ["--quiet", "attitude", str(bad), "--frame", "ENU", *reference, *extra]
            code = main([*argv, "--out", str(tmp_path / "x.csv")])
            err = capsys.readouterr().err
            if reference_only and not reference:
                assert code == 0, err
                continue
            assert code == 2 and err.count("\n") == 1 and f"bad.hdf5: {key} has shape" in err, err


def _attitude_of_csv(tmp_path, capsys, gyr, acc, rate_hz: float) -> tuple[int, str]:
    """(exit code, stderr) of `optinav attitude` on gyr, acc written as a CSV without a time column (streamed)."""
    from optinav.cli.main import main

    f = tmp_path / "log.csv"
    np.savetxt(f, np.column_stack([gyr, acc]), delimiter=",", header="gx,gy,gz,ax,ay,az", comments="")
    argv = ["--quiet", "attitude", str(f), "--rate", str(rate_hz), "--frame", "ENU", "--out", str(tmp_path / "x.csv")]
    return main(argv), capsys.readouterr().err


@pytest.mark.parametrize(("triad", "k"), [("gyr", 0), ("gyr", 2), ("acc", 1)])
def test_a_dead_axis_is_named_and_a_noise_free_simulated_one_is_not(tmp_path, capsys, triad, k):
    """BROAD 02 with its gyro's x at 0 in every sample ran at 75.6° inclination RMSE with exit 0 (0.39° as
    recorded; its accelerometer's y at 0: 5.6°), and with --reference was blamed on the reference. An axis that
    reads one value throughout while the triad's other axes vary with a sensor's noise is named, in memory and
    streamed; a noise-free simulated yaw (gyro x and y exactly 0) runs."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    gyr, acc = tr.gyr.copy(), tr.acc.copy()
    (gyr if triad == "gyr" else acc)[:, k] = 0.0
    name = "gyro" if triad == "gyr" else "accelerometer"
    with pytest.raises(OptinavError, match=f"{name} axis {'xyz'[k]} reads 0 .* in every one of"):
        check_imu(gyr, acc, np.array([tr.dt]))
    code, err = _attitude_of_csv(tmp_path, capsys, gyr, acc, tr.rate_hz)
    assert code == 2 and f"{name} axis {'xyz'[k]} reads 0" in err, err
    n = 5000
    w = np.zeros((n, 3))
    w[:, 2] = 0.5 * np.sin(np.arange(n) * 0.01)
    check_imu(w, np.tile([0.0, 0.0, 9.81], (n, 1)), np.array([0.01]))


@pytest.mark.parametrize(
    ("name", "g", "refused"),
    [("16_undisturbed_fast_translation_B", 4.0, True), ("16_undisturbed_fast_translation_B", 8.0, False),
     ("24_disturbed_tapping_A", 4.0, False)],
)  # fmt: skip
def test_a_clipped_accelerometer_is_refused_where_it_holds_the_tilt_off(tmp_path, capsys, name, g, refused):
    """BROAD 16 (sustained accelerations) with its accelerometer clipped at ±4 g ran at 6.0° inclination RMSE with
    exit 0 (0.49° as recorded; ±2 g 15.8°): only the gyro's clipping was judged. Clipped in 3.7 % of the samples it
    is refused, in memory and streamed; at ±8 g (0.19 %, 0.60°) and 24's taps at ±4 g (0.09 %, 0.63° as recorded
    0.64°) it is said in a warning."""
    from optinav.attitude.checks import ClippingWarning, check_imu

    tr = load_broad(_present(BROAD / f"{name}.hdf5"))
    acc = np.clip(tr.acc, -g * 9.80665, g * 9.80665)
    if refused:
        with pytest.raises(OptinavError, match="accelerometer axis . is clipped at"):
            check_imu(tr.gyr, acc, np.array([tr.dt]))
    else:
        with pytest.warns(ClippingWarning, match="accelerometer axis . is clipped at"):
            check_imu(tr.gyr, acc, np.array([tr.dt]))
    code, err = _attitude_of_csv(tmp_path, capsys, tr.gyr, acc, tr.rate_hz)
    assert code == (2 if refused else 0) and "accelerometer axis" in err, err


@pytest.mark.parametrize("held", ["last", "zeros"])
def test_a_logger_that_stalled_in_motion_is_named(tmp_path, capsys, held):
    """BROAD 02 with every channel holding one sample for 2 s in motion ran at 5.2° inclination and 39.5° heading
    RMSE with exit 0 (0.39° / 0.70° as recorded); with 2 s of zeros at 81.5° heading. A whole sample repeated for
    0.5 s while its gyro reads a turn, or its accelerometer 0 on three axes, is named with its rows, in memory and
    streamed; the nine as recorded pass (the trials' fixture)."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    gyr, acc = tr.gyr.copy(), tr.acc.copy()
    a = int(np.flatnonzero(np.linalg.norm(gyr, axis=1) > 0.3)[len(gyr) // 4])  # in motion
    s = slice(a + 1, a + int(2.0 * tr.rate_hz))
    gyr[s], acc[s] = (gyr[a], acc[a]) if held == "last" else (0.0, 0.0)
    if held == "zeros":
        gyr[a], acc[a] = 0.0, 0.0
    with pytest.raises(OptinavError, match=r"rows \d+-\d+ repeat one whole sample for 2 s"):
        check_imu(gyr, acc, np.array([tr.dt]))
    code, err = _attitude_of_csv(tmp_path, capsys, gyr, acc, tr.rate_hz)
    assert code == 2 and f"rows {a + 1}-" in err, err


@pytest.mark.parametrize("range_dps", [250.0, 500.0])
def test_a_gyro_whose_readings_wrap_around_at_its_range_is_named(tmp_path, capsys, range_dps):
    """BROAD 07 (fast rotation, up to 25 rad/s) with its gyro readings wrapped at ±250 °/s, as counts read as the
    wrong integer type come out, ran at 52° inclination RMSE with exit 0: a sign flip between two samples both
    near the axis' largest reading is named with its rows, in memory and streamed (the nine as recorded flip at
    most at 0.16 of their largest, BROAD 24's taps)."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    fs = np.radians(range_dps)
    gyr = (tr.gyr + fs) % (2 * fs) - fs
    with pytest.raises(OptinavError, match=r"gyro axis [xyz] jumps from [-+][\d.]+ to [-+][\d.]+ rad/s between rows"):
        check_imu(gyr, tr.acc, np.array([tr.dt]))
    code, err = _attitude_of_csv(tmp_path, capsys, gyr, tr.acc, tr.rate_hz)
    assert code == 2 and f"({range_dps:.4g} deg/s): readings that wrap around" in err, err


@pytest.mark.parametrize(("triad", "k", "seconds"), [("gyr", 0, 10.0), ("acc", 2, 10.0), ("gyr", 1, 1.0)])
def test_an_axis_that_froze_in_motion_is_named(tmp_path, capsys, triad, k, seconds):
    """BROAD 02 with its gyro's x frozen at one reading for 10 s in motion ran at 27° inclination RMSE with exit 0,
    its accelerometer's z at 23° (the nine hold an axis at most 10 samples, 35 ms): an axis holding its value far
    longer than chance gives, while the triad's other axes show motion, is named with its rows, in memory and
    streamed in blocks that cut the run; a quantized quiet axis at rest and a noise-free simulated yaw run."""
    from optinav.attitude.checks import StuckAxes, check_imu

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    gyr, acc = tr.gyr.copy(), tr.acc.copy()
    x = gyr if triad == "gyr" else acc
    a = int(np.flatnonzero(np.linalg.norm(gyr, axis=1) > 0.5)[len(gyr) // 3])  # in motion
    x[a : a + int(seconds * tr.rate_hz), k] = x[a, k]
    name = "gyro" if triad == "gyr" else "accelerometer"
    with pytest.raises(OptinavError, match=f"{name} axis {'xyz'[k]} reads .* in rows {a + 1}-.* an axis that froze"):
        check_imu(gyr, acc, np.array([tr.dt]))
    code, err = _attitude_of_csv(tmp_path, capsys, gyr, acc, tr.rate_hz)
    assert code == 2 and f"{name} axis {'xyz'[k]} reads" in err and f"in rows {a + 1}-" in err, err
    whole, parts = StuckAxes(), StuckAxes()
    whole.add(gyr, acc)
    for b in range(0, len(gyr), 777):
        parts.add(gyr[b : b + 777], acc[b : b + 777])
    np.testing.assert_array_equal(parts.best, whole.best)
    np.testing.assert_array_equal(parts.repeats, whole.repeats)
    # a yaw whose gyro x and y read a bias and noise quantized to 0.01 rad/s (mostly 0.01), or exactly 0: not judged
    n, rng = 20000, np.random.default_rng(1)
    for quiet in (np.round(rng.normal(0.01, 0.002, (n, 2)), 2), np.zeros((n, 2))):
        w = np.column_stack([quiet, 0.5 * np.sin(np.arange(n) * 0.01)])
        check_imu(w, np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0.0, 0.02, (n, 3)), np.array([0.01]))


def test_a_gyro_axis_dead_at_zero_in_motion_is_named():
    """A gyro axis that reads exactly 0 while the body turns about it was let pass as a driver's dead band: BROAD
    02's x at 0 for 5 s in motion ran at 21.7° inclination RMSE, from there to the end 68°, and a 60-s cut that
    starts in motion with x dead throughout 80° (its noise, judged on first differences, looked noise-free there),
    all with exit 0. Refused now; a dead band of 2σ of the noise on two axes of a yawing body still runs."""
    from optinav.attitude import estimate

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    k = int(np.flatnonzero(tr.movement)[0] + 20 * tr.rate_hz)  # 20 s into the motion
    for end in (k + int(5 * tr.rate_hz), len(tr.gyr)):
        gyr = tr.gyr.copy()
        gyr[k:end, 0] = 0.0
        with pytest.raises(OptinavError, match=f"gyro axis x reads 0 rad/s in rows {k + 1}-{end} .*an axis that froze"):
            estimate(gyr, tr.acc, tr.dt, frame="ENU")
    cut = slice(int(np.flatnonzero(tr.movement)[0] + 5 * tr.rate_hz), None)
    gyr = tr.gyr[cut].copy()
    gyr[:, 0] = 0.0
    with pytest.raises(OptinavError, match="gyro axis x reads 0 rad/s in every one of the .* a dead axis"):
        estimate(gyr, tr.acc[cut], tr.dt, frame="ENU")
    rng, n = np.random.default_rng(0), 12000
    t = np.arange(n) * 0.01
    s = np.sin(2 * np.pi * t / 20)
    gyr = np.column_stack([np.zeros((n, 2)), 0.6 * np.sign(s) * (s * s > 0.1)]) + rng.normal(0, 0.005, (n, 3))
    gyr[:, :2][np.abs(gyr[:, :2]) < 0.01] = 0.0  # a dead band of 2σ: x and y read 0 in 95 % of the samples
    estimate(gyr, np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.03, (n, 3)), 0.01, frame="ENU")


def test_a_magnetometer_that_holds_its_reading_in_a_turn_is_named(tmp_path, capsys):
    """A magnetometer axis dead at 0 ran at 29-144° heading RMSE with exit 0 (with z at 0: refused as a hard-iron
    offset, whose remedy then ran 3-4° off), one stuck at its reading from mid-motion to the end at 15-35°. No field
    holds still in a turning body: refused, in memory and streamed; a 10-Hz magnetometer held between its updates
    (as loggers fill the IMU's rows) runs as before."""
    from optinav.attitude import estimate
    from optinav.cli.main import main

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    cut = slice(0, int(60 * tr.rate_hz))  # the first minute: rest, then motion
    gyr, acc, mag = tr.gyr[cut], tr.acc[cut], tr.mag[cut].copy()
    dead = mag.copy()
    dead[:, 1] = 0.0
    with pytest.raises(
        OptinavError, match="magnetometer axis y reads 0 while its other axes change .*a dead or frozen"
    ):
        estimate(gyr, acc, tr.dt, frame="ENU", mag=dead)
    stuck = mag.copy()
    k = int(np.flatnonzero(tr.movement)[0] + 10 * tr.rate_hz)
    stuck[k:] = stuck[k]
    t = np.arange(gyr.shape[0]) * tr.dt
    path = tmp_path / "stuck.csv"
    np.savetxt(path, np.column_stack([t, acc, gyr, stuck]), delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz",
               comments="")  # fmt: skip
    argv = ["attitude", str(path), "--frame", "ENU", "--mag", "--chunk-rows", "3000", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    # (from row k + 1, 1-based; or a row before where the magnetometer repeated its sample between updates)
    assert re.search(rf"the magnetometer repeats one reading for 9\.9\d s from row ({k}|{k + 1}) ", err), err
    held = mag[(np.arange(mag.shape[0]) // 28) * 28]  # 10 Hz, held between its updates
    estimate(gyr, acc, tr.dt, frame="ENU", mag=held)


@pytest.mark.parametrize("late_s", [0.5, -0.2, 2.0])
def test_a_magnetometer_off_the_imus_clock_is_named(tmp_path, capsys, late_s):
    """BROAD 02's magnetometer in a file of its own with its time stamps 0.5 s late ran at 55° heading RMSE with
    exit 0 (1.35° on time; 2 s late: 6°; 0.2 s early: 3.5°): a field that turns with the gyro far better when
    moved in time names the offset, from the file pair (streamed) and in memory. The nine on their one clock leave
    at least 4.4× more unexplained at any other lag than at none."""
    from optinav.attitude import estimate
    from optinav.cli.main import main

    tr = load_broad(_present(SHARED / BROAD_TRIAL_02))
    t = np.arange(len(tr.gyr)) * tr.dt
    imu, mag = tmp_path / "imu.csv", tmp_path / "mag.csv"
    np.savetxt(imu, np.column_stack([t, tr.acc, tr.gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    np.savetxt(mag, np.column_stack([t + late_s, tr.mag]), delimiter=",", header="t,mx,my,mz", comments="")
    argv = ["--quiet", "attitude", str(imu), "--mag-file", str(mag), "--frame", "ENU", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    word = "late" if late_s > 0 else "early"
    found = re.search(rf"the magnetometer's time stamps are ([0-9.]+) s {word} against the IMU's", err)
    assert found and abs(float(found[1]) - abs(late_s)) <= 0.11, err  # (to the checks' 0.1-s bins)
    k = int(round(abs(late_s) / tr.dt))
    shifted = np.roll(tr.mag, -k if late_s < 0 else k, axis=0)  # the field of another time on each row
    with pytest.raises(OptinavError, match=f"time stamps are [0-9.]+ s {word} against the IMU's"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=shifted)


def _named_lag(text: str) -> float:
    """The lag (s, > 0 late) a refusal names: "time stamps are X s late/early" or "field is X s late"."""
    found = re.search(r"magnetometer's (?:time stamps are|field is) ([0-9.]+) s (late|early)", text)
    assert found, text
    return float(found[1]) * (1.0 if found[2] == "late" else -1.0)


def test_a_magnetometer_tens_of_ms_late_is_named_to_the_ms_and_its_shift_runs():
    """40 s of BROAD 07's fast rotation with its magnetometer 0.05 s late ran at 20.5° heading RMSE online, 14.3°
    offline, with exit 0 (2.4°, 2.0° as recorded; the whole trial at 7.5°, 5.6°): lags under 0.15 s were not judged.
    The lag is now fitted to the millisecond and refused where it turns the heading by 6° in the turns (the yaw rate
    × the lag: 24° here). BROAD's own magnetometer is 0.013 s late on this cut, so ~0.063 s is named; that shift
    applied runs at 2.1° online, 1.4° offline. A filter's delay of a few ms (5 ms: 5.8° so, 3.5° RMSE) runs."""
    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    s = slice(int(40 / tr.dt), int(80 / tr.dt))
    t = np.arange(len(tr.gyr)) * tr.dt

    def late(m, lag):  # the field of ``lag`` s before on each row (stamped that late)
        return np.column_stack([np.interp(t[s] - lag, t[s], m[:, k]) for k in range(3)])

    with pytest.raises(OptinavError) as got:
        estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=late(tr.mag[s], 0.05))
    named = _named_lag(str(got.value))
    assert 0.055 <= named <= 0.072 and "which turns its heading by the yaw rate" in str(got.value), got.value
    assert f"(its t − {named:g} s)" in str(got.value)
    fixed = late(late(tr.mag[s], 0.05), -named)
    for offline, limit in ((False, 2.6), (True, 1.8)):
        r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=fixed, offline=offline)
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[s])), tr.eval_mask[s]) < limit
    estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=late(tr.mag[s], 0.005))


def test_a_10_hz_magnetometer_file_late_is_named_as_estimate_names_it(tmp_path, capsys):
    """A 9.9-Hz magnetometer file (every 29th IMU row, a sample in each 0.1-s bin of the checks) 0.3 s late: BROAD
    24 and 16 were named 0.41 s late, the field taken at the bins' centres though sampled at their starts, and
    shifted so they still ran 0.1 s late; this first minute of trial 07 ran with exit 0 at 6.3° heading RMSE. The
    field's time in its bin is kept and the lag fitted between bins: streamed and in memory the same words, 0.3 s
    plus BROAD's own ~0.015 s; the file shifted by that runs at 1.0° (1.2° with the magnetometer on time)."""
    from optinav.cli.main import main

    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    s = slice(0, int(60 / tr.dt))
    t = np.arange(s.stop - s.start) * tr.dt
    imu, mag, out = tmp_path / "imu.csv", tmp_path / "mag.csv", tmp_path / "o.csv"
    np.savetxt(imu, np.column_stack([t, tr.acc[s], tr.gyr[s]]), delimiter=",", header="t,ax,ay,az,gx,gy,gz",
               comments="", fmt="%.9g")  # fmt: skip
    rows = np.arange(0, t.size, 29)
    field = tr.mag[s][rows]

    def mag_file(late_s):
        np.savetxt(mag, np.column_stack([t[rows] + late_s, field]), delimiter=",", header="t,mx,my,mz", comments="")
        return ["--quiet", "attitude", str(imu), "--mag-file", str(mag), "--frame", "ENU", "--out", str(out)]

    assert main(mag_file(0.3)) == 2
    err = capsys.readouterr().err
    named = _named_lag(err)
    assert 0.305 <= named <= 0.33, err
    on_rows, at = np.full((t.size, 3), np.nan), rows + int(round(0.3 / tr.dt))  # each sample on its stamp's row
    on_rows[at[at < t.size]] = field[at < t.size]
    with pytest.raises(OptinavError) as got:
        estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=on_rows)
    assert str(got.value).split(";")[0] in err, (got.value, err)
    assert main(mag_file(0.3 - named)) == 0
    d = np.genfromtxt(out, delimiter=",", names=True)
    q = np.column_stack([d["qw"], d["qx"], d["qy"], d["qz"]])
    assert rmse(np.degrees(heading_error(q, tr.q_ref[s])), tr.eval_mask[s]) < 1.5


def test_a_magnetometer_held_between_its_updates_is_named_with_its_rows():
    """A 10-Hz magnetometer repeated on the IMU's rows until its next reading (as loggers fill them) is 0.047 s old
    on a row on average: 40 s of BROAD 07 so ran at 17.2° heading RMSE online, 4.6° offline, with exit 0 (2.9°,
    2.3° with NaN between its readings; the whole trial 9.0°, 7.0°). Refused: the lag, the hold, and the remedy (its
    readings on their rows only), which runs."""
    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    s = slice(int(40 / tr.dt), int(80 / tr.dt))
    rows = (np.arange(s.stop - s.start) // 28) * 28
    with pytest.raises(OptinavError) as got:
        estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s][rows])
    text = str(got.value)
    assert "repeats each reading on the rows until its next, which leaves it 0.047 s late" in text, text
    assert "readings only on the rows of its updates (NaN on the rows between)" in text and "its t −" not in text
    sparse = np.full((s.stop - s.start, 3), np.nan)
    sparse[::28] = tr.mag[s][::28]
    r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=sparse)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[s])), tr.eval_mask[s]) < 3.2


def test_a_float_movement_with_nan_scores_the_movement_samples_only(tmp_path, capsys):
    """movement stored as float with NaN where not moving was read as True everywhere (all 53 240 samples scored,
    not the 32 280 of the movement phase): NaN is not movement, in memory and streamed."""
    import h5py

    from optinav.cli.main import main

    p = _present(SHARED / BROAD_TRIAL_02)
    bad = _broad_copy(p, tmp_path / "movfloat.hdf5")
    with h5py.File(bad, "r+") as f:
        m = f["movement"][()].astype(bool)
        del f["movement"]
        f["movement"] = np.where(m, 1.0, np.nan)
    for extra in ([], ["--offline"]):
        lines = []
        for path in (p, bad):
            argv = ["attitude", str(path), "--frame", "ENU", "--reference", *extra, "--out", str(tmp_path / "x.csv")]
            assert main(argv) == 0
            lines.append(next(x for x in capsys.readouterr().out.splitlines() if x.startswith("reference:")))
        assert lines[0] == lines[1] and "(32280 movement samples" in lines[1], lines


def test_swapped_triads_of_a_fast_turning_log_are_named(tmp_path, capsys):
    """Trial 29's gyro turns at a median 3.6 rad/s (over 0.3 g as a number): its triads swapped were blamed on
    "gravity removed (a linear-acceleration output)". An accelerometer never reads near zero but in free
    fall; a gyro at rest does: that names the swap, in memory and streamed; the trial as recorded passes."""
    from optinav.attitude.checks import check_imu
    from optinav.cli.main import main

    p = _present(BROAD / "29_disturbed_stationary_magnet_B.mat")
    tr = load_broad(p)
    with pytest.raises(Exception, match="the two triads look swapped"):
        check_imu(tr.acc, tr.gyr, np.array([tr.dt]))
    check_imu(tr.gyr, tr.acc, np.array([tr.dt]))
    csv = tmp_path / "swapped.csv"
    t = np.arange(len(tr.gyr)) * tr.dt
    np.savetxt(csv, np.column_stack([t, tr.gyr, tr.acc]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    assert main(["--quiet", "attitude", str(csv), "--frame", "ENU", "--out", str(tmp_path / "x.csv")]) == 2
    assert "the two triads look swapped" in capsys.readouterr().err


def test_a_magnetometer_stored_as_one_n_by_3_array(tmp_path, capsys):
    """An NPZ/HDF5 with the magnetometer as one (N, 3) array ``mag`` (as acc and gyro are) could not be used: --mag
    looked for mx,my,mz and the error asked for three names, which --mag-columns refused for one array.
    One name now takes the array, with the attitude of the same field in three columns; --mag names it."""
    import h5py

    from optinav.cli.main import main

    p = _present(SHARED / BROAD_TRIAL_02)
    tr = load_broad(p)
    n = int(40 * tr.rate_hz)
    t, gyr, acc, mag = np.arange(n) * tr.dt, tr.gyr[:n], tr.acc[:n], tr.mag[:n]
    np.savez(tmp_path / "cols.npz", t=t, acc=acc, gyro=gyr, mx=mag[:, 0], my=mag[:, 1], mz=mag[:, 2])
    np.savez(tmp_path / "array.npz", t=t, acc=acc, gyro=gyr, mag=mag)
    with h5py.File(tmp_path / "array.h5", "w") as f:
        f["t"], f["acc"], f["gyro"], f["mag"] = t, acc, gyr, mag

    def run(path, *extra):
        out = tmp_path / f"{Path(path).stem}{len(extra)}.csv"
        code = main(["--quiet", "attitude", str(path), "--frame", "ENU", *extra, "--out", str(out)])
        return code, capsys.readouterr().err, out

    code, _, want = run(tmp_path / "cols.npz", "--mag")
    assert code == 0
    code, err, _ = run(tmp_path / "array.npz", "--mag")
    assert code == 2 and "--mag-columns mag" in err, err
    for path in (tmp_path / "array.npz", tmp_path / "array.h5"):
        code, err, got = run(path, "--mag-columns", "mag")
        assert code == 0, err
        assert got.read_text() == want.read_text()
    code, err, _ = run(tmp_path / "array.npz", "--mag-columns", "t")
    assert code == 2 and "not (N, 3)" in err, err


@pytest.mark.parametrize("perm", [7, 37, 40])
def test_gyro_axes_flipped_on_fast_translation_are_named_from_the_whole_log(perm):
    """BROAD 16 (fast translation) with its gyro negated or its axes swapped ran with exit 0 at 75°, 46° and 22°
    inclination RMSE: over the unit window gravity turns too little to judge (0.23 rad), and the whole-log
    check searched factors only. Over minutes the signed order that holds gravity is named."""
    from optinav.attitude.checks import check_imu
    from optinav.core.rotations import signed_permutations

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    P = signed_permutations()[perm]
    # all three negated: so reads a gyro with its signs flipped or a mirrored frame (the message names both)
    words = "(all three of its axes negated)" if perm == 7 else "the gyro axes look swapped or flipped"
    with pytest.raises(Exception, match=re.escape(words)) as exc:
        check_imu(tr.gyr @ P, tr.acc, np.array([tr.dt]))
    assert "--columns" in exc.value.remedy


def test_a_reference_without_movement_samples_is_named(tmp_path, capsys):
    """Trial 02 cut to its first 20 s (at rest: no sample marked movement) with --reference ran the whole estimate
    and ended in "no finite samples to average; check the reference data and the mask": the error now
    says what the reference lacks and the flag to drop."""
    import h5py

    from optinav.attitude.recording import reference_rmse
    from optinav.cli.main import main
    from optinav.errors import OptinavError

    p = _present(SHARED / BROAD_TRIAL_02)
    cut = tmp_path / "first20s.hdf5"
    with h5py.File(p, "r") as src, h5py.File(cut, "w") as dst:
        n = int(20 * src.attrs["sampling_rate"])
        for k in src:
            dst[k] = src[k][:n]
        dst.attrs.update(dict(src.attrs))
    code = main(["--quiet", "attitude", str(cut), "--frame", "ENU", "--reference", "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "of 5714 samples 0 are marked movement" in err[-1] and "drop --reference" in err[-1], err
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    with pytest.raises(OptinavError, match="1 are marked movement and 0 have a finite reference"):
        reference_rmse(q, np.full((3, 4), np.nan), np.array([True, False, False]))


@pytest.mark.parametrize("bias_deg_s", [[2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [-2.0, 2.0, 1.0]])
def test_a_mems_gyro_bias_is_no_unit_error(bias_deg_s):
    """Trial 11 (slow translation: little turning) with an ordinary MEMS bias of 2-3 °/s added: the unit check
    refused it as 'deg/s declared rad/s' (the bias drifts gravity in the gyro-integrated frame by 0.20 rad over
    the window, beyond the 0.2 floor; the advised --gyro-unit deg/s then ran with exit 0 at 5.6°). The
    drift is now judged with the constant bias (≤ 5 °/s) that steadies it most; a deg/s gyro is still named."""
    from optinav.attitude.checks import check_imu
    from optinav.errors import OptinavError

    p = _present(BROAD / "11_undisturbed_slow_translation_B.hdf5")
    tr = load_broad(p)
    gyr = tr.gyr + np.radians(bias_deg_s)
    check_imu(gyr, tr.acc, np.array([tr.dt]))
    with pytest.raises(OptinavError, match="deg/s declared rad/s"):
        check_imu(np.degrees(gyr), tr.acc, np.array([tr.dt]))


@pytest.mark.parametrize(
    "name, row, seconds",
    [
        ("24_disturbed_tapping_A.hdf5", 27105, 5.0),
        ("16_undisturbed_fast_translation_B.hdf5", 19591, 1.0),
        ("11_undisturbed_slow_translation_B.hdf5", 17595, 5.0),
    ],
)
def test_excerpts_pass_the_input_checks(tmp_path, capsys, name, row, seconds):
    """Excerpts of real trials were refused: 5 s of trial 24 as 'gyro axis y clipped at 3.225 rad/s' —
    the logger held one whole sample four times at the excerpt's peak (every channel repeats: no clip); 1 s of
    trial 16's fast translation as 'rad/s declared deg/s' with rad/s declared (too short to judge the unit by how
    gravity turns); 5 s of trial 11 as 'clipped at 1.16 rad/s', a sharp natural peak three samples flat (one run
    of 3-4 samples is no evidence). All run, in memory and streamed from a file."""
    from optinav.attitude.checks import check_imu
    from optinav.cli.main import main

    p = _present(BROAD / name)
    tr = load_broad(p)
    sl = slice(row, row + int(round(seconds / tr.dt)))
    check_imu(tr.gyr[sl], tr.acc[sl], np.array([tr.dt]))
    t = np.arange(sl.stop - sl.start) * tr.dt
    f = tmp_path / "excerpt.csv"
    np.savetxt(
        f, np.column_stack([t, tr.acc[sl], tr.gyr[sl]]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments=""
    )
    assert main(["--quiet", "attitude", str(f), "--frame", "ENU", "--out", str(tmp_path / "o.csv")]) == 0, (
        capsys.readouterr().err
    )


@pytest.mark.parametrize("row, seconds", [(20000, 1.0), (20000, 2.0), (10000, 1.0)])
def test_offline_on_a_recording_shorter_than_tau_acc(tmp_path, row, seconds):
    """Offline on 1-2 s of BROAD's fast rotation (trial 07) gave 11° against online 6° and VQF offline 0.95°:
    the zero-phase filter's reflected ends took the edge samples' direction. Its ends are extended at
    the mean of their first tau_acc s now — within 1.5° (and never worse than online); streamed the same."""
    from optinav.cli.main import main

    p = _present(BROAD / "07_undisturbed_fast_rotation_B.hdf5")
    tr = load_broad(p)
    sl = slice(row, row + int(round(seconds / tr.dt)))
    g, a, q = tr.gyr[sl], tr.acc[sl], tr.q_ref[sl]
    on = estimate_q(g, a, tr.dt, frame="ENU", checks=False)
    off = estimate_q(g, a, tr.dt, frame="ENU", offline=True, checks=False)
    e_on, e_off = (np.degrees(rmse(inclination_error(x, q))) for x in (on, off))
    assert e_off < 1.5 and e_off <= e_on + 0.05, (e_off, e_on)
    f = tmp_path / "w.csv"
    t = np.arange(g.shape[0]) * tr.dt
    np.savetxt(f, np.column_stack([t, a, g]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    out = tmp_path / "o.csv"
    assert (
        main(["--quiet", "attitude", str(f), "--frame", "ENU", "--offline", "--chunk-rows", "97", "--out", str(out)])
        == 0
    )
    rows = np.genfromtxt(out, delimiter=",", names=True, comments="#")
    np.testing.assert_allclose(np.column_stack([rows[k] for k in ("qw", "qx", "qy", "qz")]), off, atol=1e-9)


@pytest.mark.parametrize(
    ("name", "start_s", "end_s", "before", "vqf"),
    [
        ("11_undisturbed_slow_translation_B", 30.0, 10.0, 3.39, 0.81),
        ("16_undisturbed_fast_translation_B", 20.0, 40.0, 2.37, 0.64),
    ],
)
def test_offline_9d_heading_of_a_recording_in_motion(name, start_s, end_s, before, vqf):
    """Offline 9D on a recording that starts (and ends) in motion: both passes read the field through tilts that
    lag, and a dip of 68° turns 1° of tilt into 2.5° of heading — the offline heading was no better than the
    online one. The field's azimuth is now taken in the smoothed attitude and averaged forward and
    backward over tau_mag_smooth (40 s); the nine whole trials unchanged (1.60°)."""
    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    mv = np.flatnonzero(tr.eval_mask)
    sl = slice(int(mv[0] + start_s / tr.dt), int(mv[-1] - end_s / tr.dt))
    off = estimate_q(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl], offline=True, checks=False)
    head = np.degrees(rmse(heading_error(off, tr.q_ref[sl]), tr.eval_mask[sl]))
    assert head < 0.6 * before, (head, before, vqf)


def test_an_excerpt_in_rad_s_declared_deg_s_is_named_and_a_right_q0_is_not():
    """60 s of trial 07 (880 °/s peaks) with its rad/s gyro declared deg/s ran with exit 0 at 22°: the
    drift criterion's floor, which allows for a bias, held it back — a bias cannot steady a gyro that reads 57×
    too small, so that comparison has no floor now. And a right q0 at a start in motion was warned about (34°):
    the q0 check judges only a still start."""
    import warnings

    from optinav.attitude.checks import check_imu
    from optinav.errors import OptinavError

    p, q = _present(BROAD / "07_undisturbed_fast_rotation_B.hdf5", BROAD / "02_undisturbed_slow_rotation_B.hdf5")
    tr = load_broad(p)
    sl = slice(35376, 35376 + int(60 / tr.dt))
    d = np.array([tr.dt])
    with pytest.raises(OptinavError, match="rad/s declared deg/s"):
        check_imu(tr.gyr[sl] * np.pi / 180, tr.acc[sl], d)
    check_imu(tr.gyr[sl], tr.acc[sl], d)
    tr = load_broad(q)
    sl = slice(12416, 12416 + int(10 / tr.dt))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", q0=tr.q_ref[12416])


@pytest.mark.parametrize(("end_s", "limit", "before"), [(5.0, 1.35, 1.69), (15.0, 0.75, 0.85), (60.0, 0.62, 0.69)])
def test_offline_of_a_recording_that_ends_in_fast_motion(end_s, limit, before):
    """Trial 16 cut to end 5-60 s into its fast translation: offline 1.69 / 0.85 / 0.69° against online 0.55° and
    VQF offline 0.42-0.46°. The backward pass began with the forward low-pass memories, whose slope
    reversed time turns around (it took ~10 s to settle), and was blended in at 40 % 5 s after its start: the
    memories are now held at their last output, and each pass weighs by its running time over 3 tau_acc."""
    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    m0 = np.flatnonzero(tr.eval_mask)[0]
    s = slice(None, int(m0 + end_s / tr.dt))
    q = estimate_q(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", offline=True, checks=False)
    assert np.degrees(rmse(inclination_error(q, tr.q_ref[s]), tr.eval_mask[s])) < limit, before


def _with_lost_samples(tr, stretches):
    """The trial's rows without the ``stretches`` ((first row, count) pairs), and each row's step from the true
    time stamps (s)."""
    keep = np.ones(tr.gyr.shape[0], bool)
    for s, n in stretches:
        keep[s : s + n] = False
    k = np.flatnonzero(keep)
    return k, np.diff(k * tr.dt, prepend=-tr.dt)


def test_lost_samples_in_motion_do_not_throw_the_tilt():
    """0.3 s lost 60 s into BROAD trial 16 (fast translation; the stamps right): the low-pass took the gap as one
    step with its own coefficients, and the next, short step read the gap's increment as its own — the tilt
    overshot to 134° for seconds (RMSE 34.7°, VQF 2.8°). The gap is now low-passed in sub-steps and the
    low-pass restarts as at the start (its running mean over the next tau_acc s): RMSE 3.8°, 1.1° 8 s after the
    gap; VQF, which leaves the gap out, 2.8° and 0.8°. (The gyro's turn across it is uncertain by 56°: refused
    unless gaps are allowed, then bridged, test_samples_lost_where_the_gyro_turned_are_refused_unless_allowed.)"""
    from optinav.attitude.checks import LostSamplesWarning

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    s = int(60.0 / tr.dt)
    k, dts = _with_lost_samples(tr, [(s, int(0.3 / tr.dt))])
    with pytest.warns(LostSamplesWarning):
        q = estimate_q(tr.gyr[k], tr.acc[k], dts, frame="ENU", allow_gaps=True)
    err = np.degrees(inclination_error(q, tr.q_ref[k]))
    j = int(np.searchsorted(k, s))
    after = err[j : j + int(8.0 / tr.dt)]
    assert np.nanmax(after) < 90.0  # was 134°, and still 104° 8 s later
    assert np.nanmean(after[-int(2.0 / tr.dt) :]) < 2.0  # back to the trial's level within 8 s
    assert np.degrees(rmse(inclination_error(q, tr.q_ref[k]), tr.eval_mask[k])) < 4.5


def test_samples_lost_where_the_gyro_turned_are_refused_unless_allowed(tmp_path, capsys):
    """A dropout shorter than a time gap (0.5 s) was integrated as one step at the rate after it, even with the
    steps given: 0.2 s (57 samples) lost in BROAD 07's fast rotation ran at 157° heading RMSE online (1.0° / 2.2°
    without), 9D 43.5°, with exit 0; one at 31.13 s was named "readings that wrap around". Where the turn across
    the step is uncertain beyond GAP_TURN (|Δω|·dt/2: 63.6° here; 3 lost samples in BROAD's motion 0.06-0.5°) it is
    refused naming the samples lost, in memory and streamed (online, offline), and bridged with a warning under
    allow_gaps; 3 samples lost in 02's slow motion pass as before."""
    from optinav.attitude import estimate
    from optinav.attitude.checks import LostSamplesWarning
    from optinav.cli.main import main

    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    for first in (10732, 8895):  # 20 s about each dropout
        k, dts = _with_lost_samples(tr, [(first, 57)])
        k, dts = k[(k >= first - 3000) & (k < first + 3000)], dts[(k >= first - 3000) & (k < first + 3000)]
        with pytest.raises(OptinavError, match="samples lost before sample 3000 .*uncertain by .*--allow-gaps"):
            estimate(tr.gyr[k], tr.acc[k], dts, frame="ENU")
    path = tmp_path / "drop.csv"
    np.savetxt(path, np.column_stack([k * tr.dt, tr.acc[k], tr.gyr[k]]), delimiter=",", header="t,ax,ay,az,gx,gy,gz",
               comments="", fmt="%.9g")  # fmt: skip
    for extra in ([], ["--offline"]):
        argv = ["attitude", str(path), "--frame", "ENU", "--chunk-rows", "2000", "--out", str(tmp_path / "o.csv")]
        assert main([*argv, *extra]) == 2
        err = capsys.readouterr().err
        assert "samples lost before sample 3000" in err and not (tmp_path / "o.csv").exists(), err
        assert main(["--quiet", *argv, *extra, "--allow-gaps"]) == 0
        assert "1 step(s) that lost samples bridged" in capsys.readouterr().err
        (tmp_path / "o.csv").unlink()
    with pytest.warns(LostSamplesWarning, match="bridged where the gyro's turn across them is uncertain"):
        estimate(tr.gyr[k], tr.acc[k], dts, frame="ENU", allow_gaps=True)
    slow = load_broad(_present(SHARED / BROAD_TRIAL_02))
    first = int(np.flatnonzero(slow.movement)[0] + 20 * slow.rate_hz)
    k, dts = _with_lost_samples(slow, [(first, 3)])
    near = (k >= first - 3000) & (k < first + 3000)
    estimate(slow.gyr[k[near]], slow.acc[k[near]], dts[near], frame="ENU")


def test_a_correct_gyro_unit_is_not_refused_for_lost_samples():
    """0.36 s lost in motion inside the window the gyro-unit check judges: the strapdown turned by the rate after
    the gap for all of it, which no unit factor explains — the correct rad/s was refused as deg/s, and as rad/s
    when declared deg/s. The check judges the longest stretch without lost samples."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    k, dts = _with_lost_samples(tr, [(15142, 103)])
    check_imu(tr.gyr[k], tr.acc[k], dts)
    with pytest.raises(Exception, match="rad/s declared deg/s"):
        check_imu(tr.gyr[k] * np.pi / 180, tr.acc[k], dts)  # a deg/s-sized gyro is still named


@pytest.mark.parametrize(("factor", "words"), [(2.0, "twice as long"), (0.5, "half as long")])
@pytest.mark.parametrize("name", ["02_undisturbed_slow_rotation_B", "07_undisturbed_fast_rotation_B"])
def test_a_time_base_off_by_two_is_named_on_broad(name, factor, words):
    """A sample rate or time column off by 2 turned gravity by the gyro twice or half as far as the accelerometer
    saw and passed (or, on fast rotation, was blamed on the gyro unit)."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    with pytest.raises(Exception, match=words):
        check_imu(tr.gyr, tr.acc, np.array([tr.dt * factor]))


@pytest.mark.parametrize(
    ("name", "start_s", "limit"),
    [("07_undisturbed_fast_rotation_B", 30.0, 3.5), ("33_disturbed_attached_magnet_2cm", 30.0, 3.5)],
)
def test_a_magnetometer_that_starts_late_gets_its_own_start(name, start_s, limit):
    """The field from 30 s on (NaN before, a magnetometer that starts late): its start-up (reference from its
    first tau_acc s, a running mean for tau_mag) ran on the filter's age, so the late first sample, taken in fast
    rotation, became a one-sample reference and was followed at the full tau_mag: heading 11.6° (VQF 1.89°). It now runs on the magnetometer's age: 2.5°. The start's every-sample mean (for a tilt that is still
    settling) is not taken by a late magnetometer: in trial 33 a magnet comes 8 s after the field, and that mean
    followed it (8.8°, VQF 3.7°): 2.5°."""
    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    mag = tr.mag.copy()
    mag[: int(start_s / tr.dt)] = np.nan
    q = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, checks=False)
    assert np.degrees(rmse(heading_error(q, tr.q_ref), tr.eval_mask)) < limit


def test_a_magnetometer_in_other_axes_is_named(tmp_path, capsys):
    """The AK8963 layout of an MPU-9250 (x and y swapped, z negated) gave a heading 77° off with exit 0:
    the field's angle to gravity spans 77° as the body turns, 4° in the IMU's axes. The nine trials as recorded,
    and their 40-s cuts every 20 s, pass without a warning."""
    from optinav.attitude.checks import check_mag_axes
    from optinav.cli.main import main
    from optinav.errors import OptinavError

    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    import warnings

    from optinav.attitude.checks import MagnetometerWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error", MagnetometerWarning)
        for p in NINE:
            tr = load_broad(p)
            check_mag_axes(tr.acc, tr.mag, tr.dt, tr.gyr)
            # cuts of fast translation: the accelerometer's 1-s means are no gravity there
            n = int(40.0 / tr.dt)
            for i0 in range(0, tr.acc.shape[0] - n, n // 2):
                sl = slice(i0, i0 + n)
                check_mag_axes(tr.acc[sl], tr.mag[sl], tr.dt, tr.gyr[sl])
    p = BROAD / "02_undisturbed_slow_rotation_B.hdf5"
    tr = load_broad(p)
    ak = np.column_stack([tr.mag[:, 1], tr.mag[:, 0], -tr.mag[:, 2]])
    with pytest.raises(
        OptinavError, match=r"magnetometer x reads \+y, magnetometer y reads \+x, magnetometer z reads -z"
    ):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=ak)
    import h5py

    f = tmp_path / "ak.hdf5"
    with h5py.File(p, "r") as src, h5py.File(f, "w") as dst:
        for k in src:
            dst[k] = ak if k == "imu_mag" else src[k][()]
        for k, v in src.attrs.items():
            dst.attrs[k] = v
    assert main(["--quiet", "attitude", str(f), "--frame", "ENU", "--mag", "--out", str(tmp_path / "a.csv")]) == 2
    assert "its axes are not the IMU's" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["11_undisturbed_slow_translation_B", "16_undisturbed_fast_translation_B"])
def test_a_magnetometer_in_other_axes_on_a_yawing_body_is_named(tmp_path, capsys, name):
    """The AK8963 layout on trials that mostly yaw keeps the field's angle to gravity (11, 16, 27, 29, 33 passed
    the check above) and ran with exit 0 at a heading 111° and 117° off: the field turns in the body
    against the gyro there. Named in memory and streamed, at full rate and at a tenth of it (NaN between); the
    trial as recorded passes (also a tenth of the rate, and with a hard-iron offset of half the field)."""
    from optinav.attitude.checks import check_mag_axes
    from optinav.cli.main import main
    from optinav.errors import OptinavError

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    ak = np.column_stack([tr.mag[:, 1], tr.mag[:, 0], -tr.mag[:, 2]])
    slow = np.arange(len(ak)) % 10 == 0
    for mag in (ak, np.where(slow[:, None], ak, np.nan)):
        with pytest.raises(OptinavError, match=r"turns in the body unlike the gyro says.*magnetometer x reads \+y"):
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    field = float(np.mean(np.linalg.norm(tr.mag, axis=1)))
    for mag in (tr.mag, np.where(slow[:, None], tr.mag, np.nan), tr.mag + [0.5 * field, 0.0, 0.0]):
        check_mag_axes(tr.acc, mag, tr.dt, tr.gyr)
    csv = tmp_path / "ak.csv"
    t = np.arange(len(ak)) * tr.dt
    np.savetxt(csv, np.column_stack([t, tr.acc, tr.gyr, ak]), delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz")
    assert main(["--quiet", "attitude", str(csv), "--frame", "ENU", "--mag", "--out", str(tmp_path / "a.csv")]) == 2
    assert "turns in the body unlike the gyro says" in capsys.readouterr().err


def test_a_correct_gyro_unit_with_several_short_gaps_is_not_refused():
    """20 s of trial 29 with four stretches lost (0.42, 0.21, 0.11, 0.31 s): the unit check judged the longest
    stretch without lost samples, 7.5 s — three 2-s means, over which a gyro 57× too large spun gravity steady —
    and refused the correct rad/s as "rad/s declared deg/s". A stretch under 12 s is not judged."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / "29_disturbed_stationary_magnet_B.mat")
    tr = load_broad(p)
    i0 = int(77.0 / tr.dt)
    keep = np.ones(int(20.0 / tr.dt), bool)
    for at, lost in ((1.05, 0.42), (5.1, 0.21), (12.83, 0.108), (19.16, 0.305)):
        a = int(at / tr.dt)
        keep[a : a + int(lost / tr.dt)] = False
    k = i0 + np.flatnonzero(keep)
    check_imu(tr.gyr[k], tr.acc[k], np.diff(k * tr.dt, prepend=(k[0] - 1) * tr.dt))


def test_a_cut_that_starts_upside_down_gets_no_frame_warning(tmp_path, capsys):
    """Trial 03 from 76.2 s starts with the body upside down: judged on its first 200 samples alone it was told to
    use NED; the whole recording's mean specific force must lean the same way — also block by block in
    `optinav attitude`, which had dropped the whole log's sums after its first pass (found on review)."""
    from optinav.cli.main import main

    p = _present(BROAD / "03_undisturbed_slow_rotation_C.hdf5")
    tr = load_broad(p)
    sl = slice(int(76.2 / tr.dt), int(176.2 / tr.dt))
    assert tr.acc[sl][0, 2] < 0  # z reads −g at the start of the cut
    f = tmp_path / "cut.csv"
    t = np.arange(sl.stop - sl.start) * tr.dt
    np.savetxt(
        f, np.column_stack([t, tr.acc[sl], tr.gyr[sl]]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments=""
    )
    assert main(["attitude", str(f), "--frame", "ENU", "--out", str(tmp_path / "a.csv")]) == 0
    assert "use --frame NED" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "rate"),
    [
        ("02_undisturbed_slow_rotation_B", 1000.0),
        ("02_undisturbed_slow_rotation_B", 200.0),
        ("07_undisturbed_fast_rotation_B", 400.0),
        ("07_undisturbed_fast_rotation_B", 230.0),
    ],
)
def test_a_wrong_sample_rate_is_named_with_the_rate_the_data_fit(name, rate):
    """Only a rate off by 2 was named: --rate 1000, 200 or 400 for BROAD's 285.7 Hz ran with exit 0 at 80°, 40° and
    14° inclination RMSE, and --rate 100 was blamed on the gyro unit, whose flag then gave 80°. The
    factor is searched now, and the message names --rate with the rate the data fit."""
    from optinav.attitude.checks import check_imu

    fit, tr = _rate_named(name, rate)
    assert abs(fit / tr.rate_hz - 1) < 0.05
    check_imu(tr.gyr, tr.acc, np.array([tr.dt]))


def _rate_named(name: str, rate: float, roughly: str = "") -> tuple:
    """The rate (Hz) the checks name for BROAD trial ``name`` declared at ``rate`` Hz, and the trial."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    with pytest.raises(Exception, match="the time column, the sample rate or the gyro's unit is off") as exc:
        check_imu(tr.gyr, tr.acc, np.array([1.0 / rate]))
    assert "--rate" in exc.value.remedy
    return float(exc.value.remedy.split(f"the data fit {roughly}")[1].split(" Hz")[0]), tr


def test_a_time_column_in_ticks_or_an_epoch_read_in_the_wrong_unit_is_named():
    """Xsens' SampleTimeFine (100-µs ticks) read as µs made the log 100× too fast and too short (1.9 s) for the
    unit check: exit 0 at 18°; an epoch in ns read as s gave steps of 3.5e6 s, integrated with exit 0."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(PATH)
    with pytest.raises(Exception, match="about ×0.0") as exc:
        check_imu(tr.gyr, tr.acc, np.array([tr.dt / 100]))
    assert "--time-unit" in exc.value.remedy and "roughly" in exc.value.remedy
    with pytest.raises(Exception, match="no IMU's rate"):
        check_imu(tr.gyr, tr.acc, np.array([tr.dt * 1e9]))


@pytest.mark.parametrize(
    ("name", "every"),
    [
        ("07_undisturbed_fast_rotation_B", 5),
        ("07_undisturbed_fast_rotation_B", 10),
        ("16_undisturbed_fast_translation_B", 5),
    ],
)
def test_a_time_unit_1000_times_too_small_at_a_low_rate_is_named(name, every):
    """BROAD decimated to 57 or 29 Hz with its time column in ms declared µs (or µs as ns): 183 s read as 0.18 s,
    too short for the 2-s means, and the 1-s bins of fast motion do not correlate; it ran with exit 0 at 35°
    inclination RMSE. The steps 1000× further apart are judged too; the message names the rate the data fit."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    g, a, h = tr.gyr[::every], tr.acc[::every], tr.dt * every
    with pytest.raises(Exception, match="×0.001 as far") as exc:
        check_imu(g, a, np.array([h / 1000]))
    fit = float(exc.value.remedy.split("the data fit ")[1].split(" Hz")[0])
    assert abs(fit * h - 1) < 0.01 and "--time-unit" in exc.value.remedy
    check_imu(g, a, np.array([h]))


def test_short_correct_logs_at_high_rates_are_not_taken_for_a_time_unit_slip():
    """The slip check judges logs under 6 s at 500 Hz and more: correct ones (simulated flights, BROAD cuts
    resampled to 1 kHz) pass."""
    from optinav.attitude.checks import check_imu
    from optinav.attitude.simulate import simulate

    for rate, seconds, seed in ((500.0, 5.5, 0), (1000.0, 3.0, 1), (2000.0, 5.5, 2)):
        f = simulate("dynamic", duration_s=seconds, rate_hz=rate, rng=seed)
        check_imu(f.gyr, f.acc, np.array([1.0 / rate]))
    tr = load_broad(PATH)
    t = np.arange(len(tr.gyr)) * tr.dt
    for start in (45.0, 100.0, 130.0):
        tt = np.arange(start, start + 5.5, 1e-3)
        g = np.column_stack([np.interp(tt, t, tr.gyr[:, j]) for j in range(3)])
        a = np.column_stack([np.interp(tt, t, tr.acc[:, j]) for j in range(3)])
        check_imu(g, a, np.array([1e-3]))


@pytest.mark.parametrize("rate", [100.0, 200.0, 400.0, 1000.0])
def test_a_wrong_rate_on_fast_translation_is_named_from_the_whole_log(rate):
    """BROAD 16 (fast translation at 285.7 Hz) with --rate 100, 400 or 1000 ran with exit 0 at 66, 13 and 28°, and
    --rate 200 was named as "deg/s declared rad/s", whose flag ran at 35°: over the unit checks' 20-s windows the
    translation hides how gravity turns (the right factor does no better there). Over the whole log a gyro off by
    a factor leaves gravity wandering in the gyro-integrated frame; the factor that holds it is the rate named."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    with pytest.raises(Exception, match="the time column, the sample rate or the gyro's unit is off") as exc:
        check_imu(tr.gyr, tr.acc, np.array([1.0 / rate]))
    fit = float(exc.value.remedy.split("the data fit ")[1].split(" Hz")[0])
    assert abs(fit / tr.rate_hz - 1) < 0.06
    if rate == 200.0:  # declared deg/s as well: the other unit and the rate it gives are named together
        with pytest.raises(Exception, match="gyro's unit is off") as exc:
            check_imu(tr.gyr * np.pi / 180, tr.acc, np.array([1.0 / rate]), gyro_unit="deg/s")
        then = float(exc.value.remedy.split("--gyro-unit rad/s (the data then fit ")[1].split(" Hz")[0])
        assert abs(then / tr.rate_hz - 1) < 0.06


@pytest.mark.parametrize(
    ("name", "factor"),
    [
        ("02_undisturbed_slow_rotation_B", 1.05),
        ("02_undisturbed_slow_rotation_B", 1.0 / 1.05),
        ("24_disturbed_tapping_A", 1.05),
        ("29_disturbed_stationary_magnet_B", 1.02),
    ],
)
def test_a_rate_a_few_percent_off_is_named_with_the_rate_the_data_fit(name, factor):
    """A datasheet's 300 Hz for a device's 285.7 (5 % off) ran with exit 0 at 8.3° inclination RMSE on BROAD 02
    (0.39° at its rate), 27° heading with the magnetometer on 03, and trial 29 (fast rotation) at 8.5° with its rate
    2 % off: a factor within 10 % of 1 was no finding. Where the whole log shows it (another factor holds gravity in
    the gyro-integrated frame at a fifth of the declared drift) it is named with the rate the data fit (to 1 %) and
    the other cause of a few percent, the gyro's scale; the nine trials at their own rate are not (the trials'
    fixture runs every one through the checks)."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(_present(BROAD / f"{name}.{'mat' if name.startswith('29') else 'hdf5'}"))
    declared = tr.rate_hz * factor
    with pytest.raises(OptinavError, match="the sample rate or the time column is off by .* or the gyro's scale") as e:
        check_imu(tr.gyr, tr.acc, np.array([1.0 / declared]))
    fit = float(e.value.remedy.split("the data fit ")[1].split(" Hz")[0])
    assert abs(fit / tr.rate_hz - 1) < 0.01, (fit, tr.rate_hz)
    assert "--rate" in e.value.remedy and "calibration" in e.value.remedy


@pytest.mark.parametrize(
    ("name", "factor"),
    [
        ("02_undisturbed_slow_rotation_B", 1.02),
        ("02_undisturbed_slow_rotation_B", 1.0 / 1.02),
        ("03_undisturbed_slow_rotation_C", 1.02),
        ("33_disturbed_attached_magnet_2cm", 1.0 / 1.02),
    ],
)
def test_a_rate_two_percent_off_is_said_with_the_rate_the_data_fit(name, factor):
    """Under 3 % a factor is not refused (a consumer gyro's scale is often 1-2 % off), and BROAD 02, 03 and 33 with
    their rate 2 % off ran at 1.8-3.5° inclination RMSE (0.39-0.58° at their rate) without a word: the declared gyro
    drifts gravity there below the whole-log search's floor. From half that floor a factor of 1.25 % or more that
    holds gravity with at most 0.6 of the declared drift is said in a warning with the rate the data fit (to 1 %);
    the attitude runs as declared. The nine at their own rate are not warned (the trials' fixture)."""
    from optinav.attitude.checks import TimeBaseWarning, check_imu

    tr = load_broad(_present(BROAD / f"{name}.hdf5"))
    with pytest.warns(TimeBaseWarning, match="may be off by about .* or the gyro's scale is") as w:
        check_imu(tr.gyr, tr.acc, np.array([1.0 / (tr.rate_hz * factor)]))
    fit = float(str(w[0].message).split("the data fit about ")[1].split(" Hz")[0])
    assert abs(fit / tr.rate_hz - 1) < 0.01, (fit, tr.rate_hz)


@pytest.mark.parametrize(
    ("name", "rate"),
    [
        ("11_undisturbed_slow_translation_B", 100.0),
        ("11_undisturbed_slow_translation_B", 200.0),
        ("27_disturbed_phone_vibration_B", 200.0),
    ],
)
def test_a_wrong_rate_on_a_body_that_hardly_tilts_is_named_roughly(name, rate):
    """BROAD 11 and 27 turn mostly about the vertical (gravity's 5-s means move 0.02-0.05 rad): the whole-log check
    did not judge them, so --rate 200 for their 285.7 Hz ran with exit 0 (trial 11: 3.3° inclination, 18.7°
    heading), and --rate 100 was named "deg/s declared rad/s", whose flag ran at 5.1°. The declared gyro drifts
    gravity there by 0.08-0.57 rad, the right factor by 0.02-0.03: where the factor is a clear minimum below the
    drift of a gyro scaled away, the rate is named, as rough."""
    fit, tr = _rate_named(name, rate, "roughly ")
    assert abs(fit / tr.rate_hz - 1) < 0.05


def test_a_window_s_axes_finding_gives_way_to_the_whole_log_s_rate():
    """BROAD 33 with --rate 100 (285.7 Hz): a window took the gyro for "y reads +z, z reads +y, and rad/s declared
    deg/s" and named --columns and --gyro-unit; over the whole log the axes as they are hold gravity at the rate's
    factor, which is named. A real swap at the right rate (trial 33 and 02, x and y exchanged) is still named."""
    from optinav.attitude.checks import check_imu

    for name in ("33_disturbed_attached_magnet_2cm", "02_undisturbed_slow_rotation_B"):
        p = _present(BROAD / f"{name}.hdf5")
        tr = load_broad(p)
        if name.startswith("33"):
            with pytest.raises(Exception, match="the sample rate or the gyro's unit is off") as exc:
                check_imu(tr.gyr, tr.acc, np.array([0.01]))
            fit = float(exc.value.remedy.split("the data fit ")[1].split(" Hz")[0])
            assert abs(fit / tr.rate_hz - 1) < 0.05
        with pytest.raises(Exception, match=r"gyro x reads \+y, gyro y reads \+x") as exc:
            check_imu(tr.gyr[:, [1, 0, 2]], tr.acc, np.array([tr.dt]))
        assert "--columns" in exc.value.remedy


def test_the_whole_log_check_is_skipped_where_a_window_shows_the_time_base(monkeypatch):
    """Where gravity turns in a unit window and the declared gyro holds it there better than 10 % more or less of
    it, the whole-log check (0.15 s per million samples: input checks 1.58 M samples/s instead of 1.9 M) has nothing
    to add; fast translation (trial 16) shows nothing in its windows and is still judged whole."""
    from optinav.attitude import checks as C

    called = []
    real = C.long_time_hint
    monkeypatch.setattr(C, "long_time_hint", lambda *a: called.append(1) or real(*a))
    tr = load_broad(PATH)
    C.check_imu(tr.gyr, tr.acc, np.array([tr.dt]))
    assert not called
    p = BROAD / "16_undisturbed_fast_translation_B.hdf5"
    if p.is_file():
        t16 = load_broad(p)
        with pytest.raises(Exception, match="the data fit 28"):
            C.check_imu(t16.gyr, t16.acc, np.array([0.01]))
        assert called


def test_a_wrong_rate_on_fast_translation_is_named_on_a_streamed_file(tmp_path, capsys):
    """`optinav attitude` checks a file block by block: the whole-log time base is judged from bins gathered in
    its second pass (trial 16 without its time column, --rate 100: exit 0 at 66° before)."""
    from optinav.cli.main import main

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    f = tmp_path / "t16.csv"
    np.savetxt(f, np.hstack([tr.acc, tr.gyr]), delimiter=",", header="ax,ay,az,gx,gy,gz", comments="", fmt="%.6g")
    args = ["--quiet", "attitude", str(f), "--rate", "100", "--frame", "ENU", "--out", str(tmp_path / "a.csv")]
    assert main([*args, "--chunk-rows", "7000"]) == 2
    err = capsys.readouterr().err
    fit = float(err.split("the data fit ")[1].split(" Hz")[0])
    assert abs(fit / tr.rate_hz - 1) < 0.06
    assert not (tmp_path / "a.csv").exists()


def test_the_whole_log_time_base_check_passes_the_nine_trials_and_splits_at_gaps():
    """The nine BROAD trials at their rate, whole, pass the whole-log check (their drift as declared 0.01-0.12 rad,
    no other factor near); a log whose gaps leave no 20-s piece is not judged (a gap in motion would turn the
    gyro-integrated frame by the rate after it for the whole gap); pieces between gaps are judged."""
    from optinav.attitude import checks as C

    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    for p in NINE:
        tr = load_broad(p)
        assert C.long_time_hint(*C.whole_log_bins(tr.gyr, tr.acc, np.array([tr.dt])), tr.dt) is None, p.name
    tr = load_broad(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    wrong = np.full(tr.gyr.shape[0], 0.01)  # --rate 100
    bins, sums, gaps = C.whole_log_bins(tr.gyr, tr.acc, wrong)
    assert C.long_time_hint(bins, sums, gaps, 0.01) is not None
    every = np.unique(np.searchsorted(np.cumsum(sums[:, 3]), np.arange(15.0, 600.0, 15.0)))
    assert C.long_time_hint(bins, sums, bins[every[every < bins.shape[0]]], 0.01) is None  # 15-s pieces: not judged
    wrong[np.arange(1, 6) * int(60.0 / 0.01)] = 2.0  # five 2-s gaps: pieces of 60 s (declared)
    bins, sums, gaps = C.whole_log_bins(tr.gyr, tr.acc, wrong)
    assert gaps.size == 5
    hint = C.long_time_hint(bins, sums, gaps, 0.01)
    assert hint is not None and abs(hint.rate_hz / tr.rate_hz - 1) < 0.06


def test_a_linear_acceleration_output_is_refused_in_any_unit():
    """A phone's 'linear acceleration' (gravity removed) was hinted as 'g', and --acc-unit g then ran with exit 0
    at 77° inclination RMSE: while the gyro is still, its 2-s means keep ~10 % of its norm (the nine
    BROAD trials ≥ 99 %), and it is refused with the cause named."""
    from optinav.attitude.checks import check_imu
    from optinav.core.rotations import quat_conjugate, quat_rotate

    tr = load_broad(PATH)
    ok = np.all(np.isfinite(tr.q_ref), axis=1)
    lin = tr.acc[ok] - quat_rotate(quat_conjugate(tr.q_ref[ok]), np.array([0.0, 0.0, 9.81]))
    for unit_factor in (1.0, 9.80665):  # as m/s², and as if declared g
        with pytest.raises(Exception, match="gravity looks removed"):
            check_imu(tr.gyr[ok], lin * unit_factor, np.array([tr.dt]))


def test_a_gyro_in_a_finer_unit_does_not_get_the_flag_the_user_gave(tmp_path, capsys):
    """A gyro in mdps declared deg/s was told 'it looks like deg/s declared rad/s: --gyro-unit deg/s', the flag
    it already had: with the declared unit known, the message names another unit."""
    from optinav.cli.main import main

    tr = load_broad(PATH)
    n = 20000
    f = tmp_path / "mdps.csv"
    cols = np.column_stack([np.arange(n) * tr.dt, tr.acc[:n], np.degrees(tr.gyr[:n]) * 1000.0])
    np.savetxt(f, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    argv = ["--quiet", "attitude", str(f), "--gyro-unit", "deg/s", "--frame", "ENU", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--gyro-unit deg/s" not in err and "as declared in deg/s" in err and "--gyro-unit" in err


@pytest.mark.parametrize(
    ("name", "start_s", "seconds"),
    [("07_undisturbed_fast_rotation_B", 101.0, 2.0), ("07_undisturbed_fast_rotation_B", 99.0, 5.0),
     ("27_disturbed_phone_vibration_B", 160.0, 2.0)],
)  # fmt: skip
def test_short_cuts_in_fast_rotation_or_vibration_are_not_refused(name, start_s, seconds):
    """The short-log time check counted every turn of the accelerometer's 0.1-s means as gravity turning: a lever
    arm's pull and vibration gave ratios of 28-50× with the gyro right, and correct 2-s and 5-s cuts were refused
    as "roughly 10 Hz" (20 of 3341 cuts). It now needs the gyro's rotations to match the accelerometer's
    turns (correlation ≥ 0.7)."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    i = int(round(start_s / tr.dt))
    j = i + int(round(seconds / tr.dt))
    check_imu(tr.gyr[i:j], tr.acc[i:j], np.array([tr.dt]))


@pytest.mark.parametrize(("start_s", "seconds"), [(85.0, 10.0), (90.0, 5.0)])
def test_fast_rotation_cuts_with_the_magnetometer_are_no_uncalibrated_magnetometer(start_s, seconds):
    """BROAD 07 cut to 5-10 s of its fastest rotation (7-13 rad/s), the magnetometer calibrated: the field lags the
    gyro there, and the turning steps' fit and a 10-s window's took 58-63 µT beside its 50 µT for an offset the
    field turns about — refused as an uncalibrated magnetometer (the heading 104-107° off with it), though the field
    as measured runs at 0.4-3.8°. An offset leaves the field less it steadier in norm; those left it 6-9 % spread
    against the field's own 0.8 %: not an offset. Online and offline, the heading within 5°."""
    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    s = slice(int(start_s / tr.dt), int((start_s + seconds) / tr.dt))
    for offline in (False, True):
        r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s], offline=offline)
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[s])), tr.eval_mask[s]) < 5.0


def test_a_still_car_or_a_vibrating_mount_is_not_refused():
    """A level car speeding up and braking at 0.25 g with its gyro still (5 s) was refused by the short-log check
    ("roughly 0.24 Hz"); a still IMU on a mount vibrating at 2-2.5 g was refused as "gravity removed" (its median
    norm twice g). Both pass now."""
    from optinav.attitude.checks import check_imu

    rng = np.random.default_rng(0)
    dt, n = 0.01, 500
    t = np.arange(n) * dt
    acc = np.c_[2.5 * np.sin(2 * np.pi * t / 5.0), np.zeros(n), np.full(n, 9.81)] + 0.02 * rng.standard_normal((n, 3))
    check_imu(0.002 * rng.standard_normal((n, 3)), acc, np.array([dt]))
    dt, n = 0.001, 20000
    t = np.arange(n) * dt
    shake = 20.0 * np.sin(2 * np.pi * 150 * t + rng.uniform(0, 2 * np.pi))
    acc = np.c_[shake, 0.5 * shake, 9.81 + 0.3 * shake] + 0.05 * rng.standard_normal((n, 3))
    check_imu(0.003 * rng.standard_normal((n, 3)), acc, np.array([dt]))


def test_a_linear_acceleration_output_in_continuous_motion_is_refused():
    """With no still 2-s window, the gravity check had nothing to judge by: 20 s of trial 07's motion as a
    linear-acceleration output ran with exit 0 at 65°. Such a log is judged in the gyro-integrated frame
    (the nine trials' unit windows keep ≥ 99 % of the norm there)."""
    from optinav.attitude.checks import check_imu
    from optinav.core.rotations import quat_conjugate, quat_rotate

    tr = load_broad(BROAD / "07_undisturbed_fast_rotation_B.hdf5")
    i = int(round(65.0 / tr.dt))
    j = i + int(round(20.0 / tr.dt))
    q = tr.q_ref[i:j]
    assert np.all(np.isfinite(q))
    lin = tr.acc[i:j] - quat_rotate(quat_conjugate(q), np.array([0.0, 0.0, 9.81]))
    check_imu(tr.gyr[i:j], tr.acc[i:j], np.array([tr.dt]))
    with pytest.raises(Exception, match="gravity looks removed"):
        check_imu(tr.gyr[i:j], lin, np.array([tr.dt]))


@pytest.mark.parametrize(("name", "start_s", "seconds"), [("03_undisturbed_slow_rotation_C", 0.0, 60.0), ("02_undisturbed_slow_rotation_B", 40.0, 20.0)])  # fmt: skip
def test_a_rate_too_high_on_a_cut_is_named(name, start_s, seconds):
    """--rate 1000 for 285.7 Hz on cuts: 60 s of trial 03 ran at 65° (gravity drifted within the 2-s means'
    tolerance), 20 s of 02 at 48° (17 s declared: too short for them). The gyro's rotations against the
    accelerometer's turns, bin by bin where they correlate, name the factor; the cuts at their true rate pass."""
    from optinav.attitude.checks import check_imu

    tr = load_broad(BROAD / f"{name}.hdf5")
    i = int(round(start_s / tr.dt))
    j = i + int(round(seconds / tr.dt))
    with pytest.raises(Exception, match="as far as the accelerometer sees it turn") as exc:
        check_imu(tr.gyr[i:j], tr.acc[i:j], np.array([1e-3]))
    assert "--rate" in exc.value.remedy
    check_imu(tr.gyr[i:j], tr.acc[i:j], np.array([tr.dt]))


def test_swapped_triads_in_an_hdf5_file_name_the_datasets_option(tmp_path, capsys):
    """A BROAD file with imu_gyr and imu_acc exchanged was told to check --columns, which names the columns of a
    table; for HDF5/MAT/NPZ the datasets are named with --datasets, which the message now gives too."""
    import h5py

    from optinav.cli.main import main

    tr = load_broad(PATH)
    f = tmp_path / "swapped.hdf5"
    with h5py.File(f, "w") as h:
        h.attrs["sampling_rate"] = tr.rate_hz
        h["imu_gyr"], h["imu_acc"] = tr.acc, tr.gyr
    assert main(["--quiet", "attitude", str(f), "--frame", "ENU", "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err
    assert "swapped" in err and "--datasets" in err


def test_a_short_gap_in_motion_does_not_restart_the_tilt():
    """One gap of 70 ms (lost samples) in motion at three places of BROAD trials 07 (fast rotation), 16 (fast
    translation), 24 (tapping) and 29: a gap of 0.05 s or more restarted the low-passes as at the start (a running
    mean over the next tau_acc s), which knows the tilt worse than the gyro's turn across so short a gap does on
    average: mean inclination RMSE 2.16° (trial 16 up to 6.4°, 29 0.96° -> 2.7°). Gaps shorter than
    GAP_RESTART_S = 0.1 s are bridged now: 1.50° (fast rotation's turn across the gap is the exception: 07 up to
    3.5° against 1.3°; docs/methods/attitude.md has the study on the nine trials)."""
    from optinav.attitude import _iframe

    names = ("07_undisturbed_fast_rotation_B.hdf5", "16_undisturbed_fast_translation_B.hdf5",
             "24_disturbed_tapping_A.hdf5", "29_disturbed_stationary_magnet_B.mat")  # fmt: skip
    paths = [BROAD / n for n in names]
    if not all(p.is_file() for p in paths):
        pytest.skip("BROAD trials 07/16/24/29 absent")
    assert _iframe.GAP_RESTART_S == 0.1
    errs = []
    for p in paths:
        tr = load_broad(p)
        n = tr.gyr.shape[0]
        t = np.arange(n) * tr.dt
        mov = np.flatnonzero(tr.eval_mask)
        for s in mov[[len(mov) // 4, len(mov) // 2, 3 * len(mov) // 4]]:
            keep = np.ones(n, bool)
            keep[s : s + int(round(0.07 / tr.dt))] = False
            dts = np.diff(t[keep], prepend=-tr.dt)
            q = estimate_q(tr.gyr[keep], tr.acc[keep], dts, frame="ENU", checks=False, allow_gaps=True)
            errs.append(np.degrees(rmse(inclination_error(q, tr.q_ref[keep]), tr.eval_mask[keep])))
    assert np.mean(errs) < 1.8 and max(errs) < 4.0, np.round(errs, 2)


@pytest.mark.parametrize("name", ["02_undisturbed_slow_rotation_B.hdf5", "29_disturbed_stationary_magnet_B.mat"])
def test_a_broad_file_declared_deg_s_is_told_rad_s(name, tmp_path, capsys):
    """A BROAD trial (rad/s) run with --gyro-unit deg/s was told "the gyro declared rad/s reads 57× less ...;
    check --gyro-unit" — the unit the user had not given, and no flag: the streamed BROAD reader never said what
    the gyro was declared in. It names the declared deg/s and the --gyro-unit rad/s that fixes it (HDF5 and MAT)."""
    from optinav.cli.main import main

    p = _present(BROAD / name)
    rc = main(["--quiet", "attitude", str(p), "--gyro-unit", "deg/s", "--out", str(tmp_path / "a.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and "the gyro in deg/s does not explain" in err and "--gyro-unit rad/s" in err, err


@pytest.mark.parametrize(
    ("name", "sensor", "columns", "signs", "words"),
    [
        ("11_undisturbed_slow_translation_B.hdf5", "gyr", [1, 0, 2], [1, 1, 1], "gyro x reads +y, gyro y reads +x"),
        ("11_undisturbed_slow_translation_B.hdf5", "gyr", [1, 2, 0], [1, 1, 1], "gyro x reads +y, gyro y reads +z"),
        ("27_disturbed_phone_vibration_B.hdf5", "gyr", [0, 1, 2], [-1, 1, 1], "gyro x reads -x"),
        ("27_disturbed_phone_vibration_B.hdf5", "acc", [1, 0, 2], [1, 1, 1], "gyro x reads -y, gyro y reads -x"),
    ],
)
def test_axes_swapped_on_a_body_turning_about_the_vertical_are_named(name, sensor, columns, signs, words):
    """BROAD 11 (slow translation) and 27 (a phone vibrating on a table) turn mostly about the vertical: gravity
    moves in the body by 2-3° only, so neither the unit windows nor the whole log judged the axes, and two gyro
    axes swapped, one negated or the accelerometer's x and y swapped ran with exit 0 at 3.6-11° inclination RMSE.
    Over the whole log the declared gyro drifts gravity by 0.04-0.23 rad in its integrated frame, the axes turned
    back by 0.012-0.013 (a gyro scaled to nothing 0.027-0.036): the signed order is named. The right axes pass (the
    nine trials' fixture checks every trial as published)."""
    from optinav.attitude.checks import check_imu

    p = _present(BROAD / name)
    tr = load_broad(p)
    gyr, acc = tr.gyr, tr.acc
    if sensor == "gyr":
        gyr = gyr[:, columns] * signs
    else:
        acc = acc[:, columns] * signs
    with pytest.raises(Exception, match="the gyro axes look swapped or flipped") as exc:
        check_imu(gyr, acc, np.array([tr.dt]))
    assert words in str(exc.value) and "--columns" in exc.value.remedy


def test_trial_02_in_loggers_layouts_gives_the_attitude_of_its_plain_csv(trial, tmp_path, capsys):
    """BROAD trial 02 (40 s) rewritten as loggers write it: SensorLog's iOS CSV (Core Motion: minus the specific
    force, in g, 6 decimals), ArduPilot's IMU CSV from mavlogdump (TimeUS in µs beside its wall clock and the
    temperature T) and an Arduino serial capture (start-up text above a micros() table). `optinav attitude` on
    each writes the attitude of the plain t,ax..gz CSV: was no accelerometer (iOS; with the columns mapped, roll
    0.2 deg where the trial reads -179.8 deg, exit 0), 'timestamp' and 'T' both look like 't' (ArduPilot), 'no
    column of numbers … check the delimiter option' (Arduino); and PX4's vehicle_imu (increments over their
    periods in µs) was refused with no option that helped. Read whole and in blocks."""
    from optinav.cli.main import main

    n, g0 = int(40 * trial.rate_hz), 9.80665
    t, acc, gyr = np.arange(n) / trial.rate_hz, trial.acc[:n], trial.gyr[:n]
    us = np.round(t * 1e6).astype(np.int64)
    dus = np.diff(us, prepend=us[0] - us[1])  # PX4 vehicle_imu's integration periods (µs)
    r = lambda v: repr(float(v))  # noqa: E731
    layouts = {
        "plain.csv": ["t,ax,ay,az,gx,gy,gz"] + [",".join(map(r, (t[i], *acc[i], *gyr[i]))) for i in range(n)],
        "2021-01-17_10_34_00_my_iOS_device.csv": [
            "loggingTime(txt),loggingSample(N),accelerometerTimestamp_sinceReboot(s),accelerometerAccelerationX(G),"
            "accelerometerAccelerationY(G),accelerometerAccelerationZ(G),gyroTimestamp_sinceReboot(s),"
            "gyroRotationX(rad/s),gyroRotationY(rad/s),gyroRotationZ(rad/s)"
        ]
        + [
            ",".join(["2021-01-17T10:34:00.000+08:00", str(i), "%.6f" % (900 + t[i])])
            + "".join(",%.6f" % v for v in -acc[i] / g0)
            + ",%.6f" % (900 + t[i])
            + "".join(",%.6f" % v for v in gyr[i])
            for i in range(n)
        ],
        "00000002_IMU.csv": ["timestamp,TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"]
        + [
            ",".join(["%.8f" % (1.6e9 + t[i]), str(us[i] + 50_000_000), "0", *map(r, gyr[i]), *map(r, acc[i])])
            + ",0,0,41.25,1,1,286,286"
            for i in range(n)
        ],
        "log_2_vehicle_imu_0.csv": [
            "timestamp,timestamp_sample,accel_device_id,gyro_device_id,delta_angle[0],delta_angle[1],delta_angle[2],"
            "delta_velocity[0],delta_velocity[1],delta_velocity[2],delta_angle_dt,delta_velocity_dt,"
            "delta_angle_clipping,delta_velocity_clipping,accel_calibration_count,gyro_calibration_count"
        ]
        + [
            ",".join([str(us[i] + 300), str(us[i]), "1", "2", *map(r, np.r_[gyr[i], acc[i]] * (dus[i] * 1e-6))])
            + f",{dus[i]},{dus[i]},0,0,1,1"
            for i in range(n)
        ],
        "capture.txt": [
            "Initializing I2C devices...",
            "MPU6050 connection successful",
            "micros\tax\tay\taz\tgx\tgy\tgz",
        ]
        + ["\t".join([str(us[i] + 123), *map(r, acc[i]), *map(r, gyr[i])]) for i in range(n)],
    }
    got = {}
    for name, lines in layouts.items():
        (tmp_path / name).write_text("\n".join(lines) + "\n")
        for stream in ((), ("--chunk-rows", "3000")):
            out = tmp_path / f"att_{name}{len(stream)}.csv"
            code = main(["--quiet", "attitude", str(tmp_path / name), "--frame", "ENU", *stream, "--out", str(out)])
            assert code == 0, (name, stream, capsys.readouterr().err)
            got[name, stream] = np.loadtxt(out, delimiter=",", skiprows=1)
    ref = got.pop(("plain.csv", ()))
    assert ref.shape == (n, 8) and abs(ref[-1, 5]) < 1.0  # ENU roll of the trial near 0 (not 180°)
    for name, q in got.items():
        # the quaternions' angle apart (2·|q - ±q_ref| for small angles; arccos of their product is lost in the
        # output's 9 digits): the times in whole µs (ArduPilot, Arduino) move it by ~1e-3 deg, 6 decimals of g ~2e-5
        q1, q0 = q[:, 1:5], ref[:, 1:5]
        ang = np.degrees(2 * np.minimum(np.linalg.norm(q1 - q0, axis=1), np.linalg.norm(q1 + q0, axis=1)))
        assert q.shape == ref.shape and ang.max() < 0.005, (name, ang.max())
        np.testing.assert_allclose(q[:, 0] - q[0, 0], ref[:, 0] - ref[0, 0], rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    "name, order, cause",
    [
        ("as given", lambda q: q, None),
        ("conjugated", lambda q: q * [1.0, -1.0, -1.0, -1.0], "conjugated"),
        ("scalar-last", lambda q: q[:, [1, 2, 3, 0]], "scalar-last"),
    ],
)
def test_a_reference_that_turns_unlike_the_gyro_is_refused(trial, tmp_path, capsys, name, order, cause):
    """Trial 02 with opt_quat conjugated (q_n^b) or stored [x, y, z, w] scored, with status ok and exit 0, an
    inclination RMSE of 11-14° (trial 11) — a number about the file, not the estimate; the rest-phase vertical
    does not show it (a level body turned about the vertical keeps it). Its turns do: over 35-ms windows of fast
    rotation the stored reference turns > 30° from the gyro in all of them (median 95° and 172°), the true one in
    at most 0.4 % (the nine trials). Refused in one line naming the storage; the reference as given still scores."""
    import h5py

    from optinav.cli.main import main

    f = tmp_path / "t.hdf5"
    with h5py.File(f, "w") as h:
        h.attrs["sampling_rate"] = trial.rate_hz
        h["imu_gyr"], h["imu_acc"], h["imu_mag"] = trial.gyr, trial.acc, trial.mag
        h["opt_quat"], h["movement"] = order(trial.q_ref), trial.movement
    argv = ["--quiet", "attitude", str(f), "--frame", "ENU", "--reference", "--out", str(tmp_path / "a.csv")]
    for extra in ([], ["--offline"]):
        code = main(argv + extra)
        err = capsys.readouterr().err.strip()
        if cause is None:
            assert code == 0, err
            continue
        assert code == 2 and err.count("\n") == 0 and "turns unlike the gyroscope" in err and cause in err, err
        assert not (tmp_path / "a.csv").exists()


def test_the_reference_scores_alike_in_ned_and_enu(tmp_path, capsys):
    """--reference with --frame NED was refused ("the BROAD reference is body -> ENU"), so the same trial could not
    be scored in both frames. The reference is now turned into the estimate's frame: trial 02 with the magnetometer
    scores the same inclination and heading RMSE (0.388°, 1.351°) in NED as in ENU."""
    import re

    from optinav.cli.main import main

    got = {}
    for frame in ("ENU", "NED"):
        argv = ["--quiet", "attitude", str(PATH), "--frame", frame, "--mag", "--reference"]
        assert main([*argv, "--out", str(tmp_path / f"{frame}.csv")]) == 0
        out = capsys.readouterr().out
        got[frame] = [
            float(x) for x in re.search(r"inclination RMSE ([\d.]+) deg, heading RMSE ([\d.]+)", out).groups()
        ]
    assert 0.2 < got["ENU"][0] < 0.6 and got["ENU"][1] < 3.0  # VQF's league (README_SOURCE.txt)
    np.testing.assert_allclose(got["NED"], got["ENU"], atol=2e-3)


@pytest.mark.parametrize("offline", [False, True])
def test_the_report_draws_the_error_against_the_reference(tmp_path, monkeypatch, capsys, offline):
    """--report with --reference gave the RMSE in a table but no error over time, so where an estimator fails
    (a fast turn, a disturbance) was not visible. A second figure draws the inclination
    and heading error of the scored samples: their RMS is the reported RMSE (trial 02 is drawn whole)."""
    from matplotlib.figure import Figure as MplFigure

    from optinav.cli.main import main
    from optinav.reports import attitude_report

    captured = []
    monkeypatch.setattr(attitude_report, "write_report", lambda studies, *a, **k: captured.extend(studies))
    argv = ["--quiet", "attitude", str(PATH), "--frame", "ENU", "--mag", "--reference", "--chunk-rows", "7000"]
    argv += ["--out", str(tmp_path / "a.csv"), "--report", str(tmp_path / "rep")] + ["--offline"] * offline
    assert main(argv) == 0
    rows = {r[0]: getattr(r[1], "value", r[1]) for r in captured[0].tables[0].rows}
    (fig_spec,) = [f for f in captured[0].figures if f.filename == "attitude_error.png"]
    fig = MplFigure()
    fig_spec.draw(fig)
    for ax, name in zip(fig.axes, ("inclination", "heading")):
        y = np.asarray(ax.lines[0].get_ydata(), float)
        assert np.count_nonzero(np.isfinite(y)) == 32280  # the movement samples with a valid reference
        want = rows[f"{name} RMSE vs reference [deg]"]
        np.testing.assert_allclose(np.sqrt(np.nanmean(y**2)), want, rtol=1e-9)


@pytest.mark.parametrize("chunk", [None, "7000"])
def test_the_report_keeps_the_warnings_said_on_the_console(tmp_path, capsys, chunk):
    """Trial 02 in the default frame (NED): the console warned that its accelerometer reads an up-pointing z and
    named --frame ENU, but --report's index.md, index.html and summary.json did not, so a reader of the report
    alone had no hint. They keep every warning and note the command said, in its words."""
    import json

    from optinav.cli.main import main

    rep = tmp_path / "rep"
    argv = ["attitude", str(PATH), "--reference", "--out", str(tmp_path / "a.csv"), "--report", str(rep)]
    assert main(argv + (["--chunk-rows", chunk] if chunk else [])) == 0
    said = [x for x in capsys.readouterr().err.splitlines() if x.startswith("optinav: warning:")]
    assert len(said) == 1 and "--frame ENU" in said[0]
    text = said[0].removeprefix("optinav: warning: ")
    md, page = (rep / "index.md").read_text(), (rep / "index.html").read_text()
    assert "## Warnings and notes" in md and text in md and "Warnings and notes" in page and "--frame ENU" in page
    assert json.loads((rep / "summary.json").read_text())["console"] == [{"kind": "warning", "message": text}]


def test_the_reference_line_says_when_the_heading_is_not_measured(tmp_path, capsys):
    """6D, the reference line read "heading RMSE 0.704 deg" on trial 02 as if the heading were estimated (165° in
    NED on the same estimate: it is the start's yaw offset and the gyro's drift); it now says so, and with the
    magnetometer it does not."""
    from optinav.cli.main import main

    for extra, note in (([], True), (["--mag"], False)):
        argv = ["--quiet", "attitude", str(PATH), "--frame", "ENU", "--reference", "--out", str(tmp_path / "a.csv")]
        assert main(argv + extra) == 0
        (line,) = [s for s in capsys.readouterr().out.splitlines() if s.startswith("reference:")]
        assert ("no heading measurement" in line) == note, line


@pytest.mark.parametrize(
    ("name", "start_s"), [("11_undisturbed_slow_translation_B", 30.0), ("27_disturbed_phone_vibration_B", 80.0)]
)
def test_rad_s_declared_deg_s_on_a_yawing_body_is_named_by_the_magnetometer(tmp_path, capsys, name, start_s):
    """Trials that mostly yaw barely turn gravity in the body: their rad/s declared deg/s (the gyro at 1/57.3)
    passed the gravity checks and ran with exit 0 at 5.6° and 5.7° inclination RMSE (issue 12). The field turns
    in the body as the body yaws: 57-63× as far as that gyro says over 20 s (1.0-1.1 with the declared unit
    right). Named in memory and streamed; the cut as recorded passes."""
    from optinav.attitude.checks import check_mag_axes
    from optinav.cli.main import main
    from optinav.errors import OptinavError

    p = _present(BROAD / f"{name}.hdf5")
    tr = load_broad(p)
    sl = slice(int(start_s / tr.dt), int((start_s + 20.0) / tr.dt))
    gyr, acc, mag = tr.gyr[sl], tr.acc[sl], tr.mag[sl]
    with pytest.raises(OptinavError, match=r"turns in the body (5[6-9]|6[0-4])\.?\d*× as far as the gyro") as exc:
        estimate(gyr * np.pi / 180.0, acc, tr.dt, frame="ENU", mag=mag)
    assert "--gyro-unit rad/s" in exc.value.remedy
    check_mag_axes(acc, mag, tr.dt, gyr, "rad/s")
    csv = tmp_path / "cut.csv"
    t = np.arange(gyr.shape[0]) * tr.dt
    np.savetxt(csv, np.column_stack([t, acc, gyr, mag]), delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz")
    argv = ["--quiet", "attitude", str(csv), "--frame", "ENU", "--mag", "--out", str(tmp_path / "a.csv")]
    assert main([*argv, "--gyro-unit", "deg/s"]) == 2
    err = capsys.readouterr().err
    assert "as far as the gyro in deg/s says" in err and "--gyro-unit rad/s" in err, err


def test_the_gyro_scale_by_the_field_raises_no_false_alarm_on_broad():
    """The nine trials with their declared units right (magnets moving and attached in 29 and 33), whole, in
    halves and in 30-s cuts every 15 s, at full rate and a third of it: no refusal, the factor 0.70-1.46 where
    judged (the refusal is beyond MAG_SCALE_FAR = 8). The same cuts with rad/s declared deg/s: 211 of the 254
    refused, the others not judged (the field turns too little, or not as any gyro says)."""
    from optinav.attitude.checks import MAG_SCALE_FAR, field_rate_sums, gyro_scale_error, mag_gyro_scale
    from optinav.attitude.checks import scale_bin_rows

    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    judged, refused, cuts = [], 0, 0
    for p in NINE:
        tr = load_broad(p)
        for step in (1, 3):
            gyr, mag, dt = tr.gyr[::step], tr.mag[::step], tr.dt * step
            n, k, r = gyr.shape[0], int(30.0 / dt), scale_bin_rows(dt)
            for a, b in [(0, n), (0, n // 2), (n // 2, n), *((i, i + k) for i in range(0, n - k, k // 2))]:
                cuts += 1
                got = mag_gyro_scale(*field_rate_sums(gyr[a:b], mag[a:b], r), r * dt)
                assert gyro_scale_error(*got, "rad/s") is None, (p.name, step, a, got)
                wrong = mag_gyro_scale(*field_rate_sums(gyr[a:b] * np.pi / 180.0, mag[a:b], r), r * dt)
                if gyro_scale_error(*wrong, "deg/s") is not None:
                    refused += 1
                    judged.append(got[0])
    assert 0.5 < min(judged) and max(judged) < MAG_SCALE_FAR / 4, (min(judged), max(judged))
    assert refused > 0.75 * cuts, (refused, cuts)


def test_a_mirrored_frame_is_named_as_such_not_blamed_on_the_gyro(tmp_path, capsys):
    """Both triads with x and y swapped (a left-handed file): a rotation is a pseudovector, so the gyro reads every
    axis negated against the accelerometer, and the error said "gyro x reads -x, gyro y reads -y, gyro z reads -z"
    and told to fix the gyro alone. Gravity cannot tell a mirrored frame from a gyro with its signs flipped: both
    are named, with the swap of every sensor alike. 20 s of trial 11 (it yaws: gravity turns too little to see
    it) so mirrored, magnetometer too, ran with exit 0 and its heading turning the wrong way: the field turns
    against the gyro there (factor −1.1); the columns swapped back pass."""
    from optinav.attitude.checks import check_imu
    from optinav.cli.main import main
    from optinav.errors import OptinavError

    tr = load_broad(PATH)
    sl = slice(int(60.0 / tr.dt), int(100.0 / tr.dt))
    swap = [1, 0, 2]
    with pytest.raises(OptinavError, match=r"left-handed \(mirrored\) frame") as exc:
        check_imu(tr.gyr[sl][:, swap], tr.acc[sl][:, swap], np.array([tr.dt]))
    assert "gyro x reads" not in str(exc.value) and "swap two axes of every sensor alike" in exc.value.remedy
    p = _present(BROAD / "11_undisturbed_slow_translation_B.hdf5")
    tr = load_broad(p)
    sl = slice(int(30.0 / tr.dt), int(50.0 / tr.dt))
    csv = tmp_path / "mirrored.csv"
    t = np.arange(sl.stop - sl.start) * tr.dt
    rows = np.column_stack([t, tr.acc[sl][:, swap], tr.gyr[sl][:, swap], tr.mag[sl][:, swap]])
    np.savetxt(csv, rows, delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="")
    argv = ["--quiet", "attitude", str(csv), "--frame", "ENU", "--mag", "--out", str(tmp_path / "a.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "turns in the body the opposite way to the gyro" in err and "left-handed" in err, err
    assert main([*argv, "--columns", "t,ay,ax,az,gy,gx,gz,my,mx,mz"]) == 0
    # 40 s of 11 in its motion so mirrored: the field turns about one point in some windows and another in others
    # (the mirrored gyro explains it wrongly), and that was named an offset changing within the recording, raised
    # before the axes check; the whole log and streamed alike
    sl = slice(int(60.0 / tr.dt), int(100.0 / tr.dt))
    with pytest.raises(OptinavError, match=r"left-handed \(mirrored\) frame"):
        estimate(tr.gyr[sl][:, swap], tr.acc[sl][:, swap], tr.dt, frame="ENU", mag=tr.mag[sl][:, swap])
    csv = _cut_csv(tmp_path / "mirrored2.csv", tr, 60.0, 40.0, axes=swap)
    argv = [
        "--quiet",
        "attitude",
        csv,
        "--frame",
        "ENU",
        "--mag",
        "--chunk-rows",
        "7000",
        "--out",
        str(tmp_path / "b.csv"),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "left-handed (mirrored)" in err and "offset" not in err, err


def _cut_csv(path, tr, start_s, seconds, mag=True, axes=(0, 1, 2), mag_of=lambda m: m):
    """``seconds`` of a BROAD trial from ``start_s`` as a CSV (t, acc, gyr in rad/s, and mx,my,mz with ``mag``),
    every triad's columns in the order ``axes``; ``mag_of`` makes the magnetometer's columns of the field."""
    sl = slice(int(start_s / tr.dt), int((start_s + seconds) / tr.dt))
    ax = list(axes)
    cols = [np.arange(sl.stop - sl.start) * tr.dt, tr.acc[sl][:, ax], tr.gyr[sl][:, ax]]
    cols += [mag_of(tr.mag[sl][:, ax])] if mag else []
    head = "t,ax,ay,az,gx,gy,gz" + (",mx,my,mz" if mag else "")
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=head, comments="", fmt="%.9g")
    return str(path)


def test_a_magnetometer_not_asked_for_witnesses_the_gyro_unit_and_a_mirrored_frame(tmp_path, capsys):
    """Without --mag the gyro-scale check had no field: 20 s of trial 11 (it mostly yaws, gravity barely turns in
    the body) ran with exit 0 in rad/s declared deg/s, and with every sensor's x and y swapped (a mirrored file).
    The file's mx, my, mz now witness the gyro (the field turns 61× as far as that gyro says; against a mirrored
    one) while the estimate stays 6D: the cut as recorded writes the same attitude as without the columns."""
    from optinav.cli.main import main

    p = _present(BROAD / "11_undisturbed_slow_translation_B.hdf5")
    tr = load_broad(p)
    out = tmp_path / "a.csv"
    argv = ["--quiet", "attitude", "--frame", "ENU", "--out", str(out)]
    assert main([*argv, _cut_csv(tmp_path / "u.csv", tr, 30.0, 20.0), "--gyro-unit", "deg/s"]) == 2
    err = capsys.readouterr().err
    assert re.search(r"turns in the body (5[6-9]|6[0-6])\.?\d*× as far as the gyro in deg/s", err), err
    assert "--gyro-unit rad/s" in err
    assert main([*argv, _cut_csv(tmp_path / "m.csv", tr, 30.0, 20.0, axes=(1, 0, 2))]) == 2
    err = capsys.readouterr().err
    assert "turns in the body the opposite way to the gyro" in err and "left-handed" in err, err
    assert main([*argv, _cut_csv(tmp_path / "ok.csv", tr, 30.0, 20.0)]) == 0
    with_mag = out.read_bytes()
    assert main([*argv, _cut_csv(tmp_path / "no.csv", tr, 30.0, 20.0, mag=False)]) == 0
    assert out.read_bytes() == with_mag
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("kind", ["noise", "nan", "zero", "own left-handed axes", "0.2 s late"])
def test_a_magnetometer_not_asked_for_that_is_garbage_raises_no_alarm(tmp_path, capsys, kind):
    """A magnetometer the estimate does not take must never fail a right run: noise, NaN or zeros leave it
    unjudged; one in a left-handed layout of its own (x negated: 20 s of trial 16, where the field so turns against
    the gyro at −1.0 with 82 % explained) is undone by another order of its axes, and one 0.2 s late on trial 07's
    fast rotation (30 s: −1.13, 72 % explained) by moving it in time, so neither names a mirrored frame. With
    --mag both were refused as a mirrored frame or a gyro with its signs flipped (fix every sensor or the gyro);
    the error now names first what turns the field with the gyro (96 %, 95 % explained), the late one its lag alone
    with the shift that undoes it (a lag explains the field's turning: no mirrored frame does)."""
    from optinav.cli.main import main

    trial, start_s, seconds = ("07_undisturbed_fast_rotation_B", 45.0, 30.0) if kind == "0.2 s late" else (
        "16_undisturbed_fast_translation_B", 62.0, 20.0)  # fmt: skip
    p = _present(BROAD / f"{trial}.hdf5")
    tr = load_broad(p)
    rng = np.random.default_rng(1)
    if kind == "0.2 s late":
        tr.mag[:] = np.roll(tr.mag, int(round(0.2 / tr.dt)), axis=0)
    mag_of = {
        "noise": lambda m: rng.normal(size=m.shape) * 1e3,
        "nan": lambda m: np.full(m.shape, np.nan),
        "zero": np.zeros_like,
        "own left-handed axes": lambda m: m * [-1.0, 1.0, 1.0],
    }.get(kind, lambda m: m)
    csv = _cut_csv(tmp_path / "g.csv", tr, start_s, seconds, mag_of=mag_of)
    argv = ["--quiet", "attitude", csv, "--frame", "ENU", "--out", str(tmp_path / "a.csv")]
    assert main(argv) == 0
    assert capsys.readouterr().err == ""
    if kind in ("own left-handed axes", "0.2 s late"):  # with --mag they are refused, naming the likelier cause
        assert main([*argv, "--mag"]) == 2
        err = capsys.readouterr().err
        if kind == "0.2 s late":  # its lag, to the ms with BROAD's own 0.013 s, and the shift (no mirrored frame)
            assert 0.205 <= _named_lag(err) <= 0.225 and "its t − 0.2" in err and "mirrored" not in err, err
        else:
            assert "magnetometer's axes read as" in err and "that is the likelier cause" in err, err


def test_a_break_in_the_motion_settles_the_tilt():
    """BROAD's trials with breaks (04, 05, 08, 09, 13, 14, 17, 18: three 10-s rests inside the motion) are not
    among the nine: trial 02 with a 10-s rest put in at 30, 50 and 70 % of its motion (its own initial rest's
    gyro and accelerometer noise about gravity at the attitude there). The tau_acc low-pass held the motion, and
    the bias the motion had taught drifted the tilt: 0.14, 0.18, 0.29° in the break's last 3 s. At rest the force
    is gravity alone and is low-passed over rest_tau_acc (2 s): 0.06, 0.06, 0.13°."""
    from optinav.core.rotations import dcm_from_quat

    tr = load_broad(PATH)
    h = tr.dt
    mv = np.flatnonzero(tr.eval_mask)
    rest = slice(int(0.5 / h), mv[0] - int(1 / h))
    g0, a0 = tr.gyr[rest], tr.acc[rest]
    nb = int(10 / h)
    k = np.arange(nb) % g0.shape[0]
    for frac in (0.3, 0.5, 0.7):
        c = int(mv[0] + frac * (mv[-1] - mv[0]))
        while not np.all(np.isfinite(tr.q_ref[c])):
            c += 1
        up = dcm_from_quat(tr.q_ref[c]).T @ [0.0, 0.0, 1.0]  # up in body axes (q_ref: body -> ENU)
        still = np.linalg.norm(a0.mean(axis=0)) * up + (a0[k] - a0.mean(axis=0))
        g, a = np.vstack([tr.gyr[:c], g0[k], tr.gyr[c:]]), np.vstack([tr.acc[:c], still, tr.acc[c:]])
        q = np.vstack([tr.q_ref[:c], np.tile(tr.q_ref[c], (nb, 1)), tr.q_ref[c:]])
        last = slice(c + nb - int(3 / h), c + nb)
        new, old = (
            np.degrees(inclination_error(estimate_q(g, a, h, frame="ENU", checks=False, **kw), q))[last].mean()
            for kw in ({}, {"rest_tau_acc": 0.0})
        )
        assert new < 0.15 and new < 0.6 * old, (frac, new, old)


@pytest.mark.parametrize(
    "name, start_s, seconds",
    [
        ("03_undisturbed_slow_rotation_C.hdf5", 61.3, 10.0),
        ("24_disturbed_tapping_A.hdf5", 141.5, 20.0),
        ("29_disturbed_stationary_magnet_B.mat", 81.8, 20.0),
    ],
)
def test_a_cut_of_a_calibrated_magnetometer_is_not_warned_as_soft_iron(name, start_s, seconds):
    """Cuts of BROAD's calibrated magnetometer were warned as soft iron: 03 and 24 (norm spread 3.2 %, an ellipsoid
    of axes 1.04:1 halves it, but its correction turns the field's direction by 0.7° RMS: no heading to speak of),
    29 near its magnet (axes 2.97:1, centred 4.4 field norms off: a patch of the disturbance). The heading
    against the optical reference is as good as the trials' own (under 2.5°). The same cuts through BROAD's
    soft-iron matrix of the soft-iron test (correction 6°) are still warned."""
    from optinav.attitude.checks import MagnetometerWarning

    tr = load_broad(BROAD / name)
    sl = slice(int(start_s / tr.dt), int((start_s + seconds) / tr.dt))
    g, a, m, q = tr.gyr[sl], tr.acc[sl], tr.mag[sl], tr.q_ref[sl]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = estimate(g, a, tr.dt, frame="ENU", mag=m, offline=True)
    assert rmse(np.degrees(heading_error(r.q_b_n, q)), tr.eval_mask[sl]) < 2.5
    if not name.startswith("29"):  # a calibrated field in a clean place, through a soft-iron matrix
        soft = m @ np.array([[1.2, 0.1, 0.0], [0.1, 0.85, 0.05], [0.0, 0.05, 1.0]]).T
        with pytest.warns(MagnetometerWarning, match="soft iron"):
            estimate(g, a, tr.dt, frame="ENU", mag=soft, offline=True)


def test_a_magnet_brought_near_a_body_at_rest_is_no_hard_iron_offset(tmp_path, capsys):
    """BROAD 33, 25-45 s: the body at rest (the gyro turns 0.09 rad, none faster than 0.1 rad/s) while the magnet
    is brought to it (field norm 44 -> 21 µT). The sphere fitted to that field (19 % -> 7.5 %) was taken for an
    uncalibrated magnetometer: online refused, offline subtracted (heading 13.7° RMSE). A norm that changes while
    the body does not turn is no offset fixed to the sensor: online 1.06°, offline 1.38°, in memory and through the
    CLI's streamed HDF5. The magnet on the turning body (82-87 s, an offset the online estimate cannot take: 49°
    without the checks) is still refused online."""
    import h5py

    from optinav.cli.main import main

    tr = load_broad(BROAD / "33_disturbed_attached_magnet_2cm.hdf5")
    h = tr.dt
    sl = slice(int(25.3 / h), int(45.3 / h))
    g, a, m, q = tr.gyr[sl], tr.acc[sl], tr.mag[sl], tr.q_ref[sl]
    for offline in (False, True):
        r = estimate(g, a, h, frame="ENU", mag=m, offline=offline)
        assert r.mag_hard_iron is None
        assert rmse(np.degrees(heading_error(r.q_b_n, q))) < 2.0, offline
    path = tmp_path / "rest_magnet.hdf5"
    with h5py.File(path, "w") as f:
        f.attrs["sampling_rate"] = tr.rate_hz
        for name, v in (("imu_gyr", g), ("imu_acc", a), ("imu_mag", m)):
            f.create_dataset(name, data=v)
    for flags in ([], ["--offline"]):
        assert (
            main(
                ["--quiet", "attitude", str(path), "--frame", "ENU", "--mag", *flags, "--out", str(tmp_path / "a.csv")]
            )
            == 0
        )
        assert capsys.readouterr().err == ""
    on = slice(int(82.0 / h), int(87.0 / h))
    with pytest.raises(OptinavError, match="hard-iron"):
        estimate(tr.gyr[on], tr.acc[on], h, frame="ENU", mag=tr.mag[on])


def _averaged_to(x, rate_hz, to_hz):
    """``x`` (n, k) sampled at ``rate_hz`` as a slower IMU outputs it at ``to_hz``: the mean over each output
    period (box filter), and the input row at each output sample's centre."""
    k = rate_hz / to_hz
    c = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0)
    t0 = np.arange(int(x.shape[0] / k) - 1) * k
    i = np.arange(c.shape[0])
    at = lambda t: np.column_stack([np.interp(t, i, c[:, j]) for j in range(x.shape[1])])  # noqa: E731
    return (at(t0 + k) - at(t0)) / k, np.round(t0 + k / 2).astype(int)


def test_a_fast_turn_at_50_hz_is_no_stuck_magnetometer():
    """BROAD 29, 45-85 s (turning at 3 rad/s beside the magnet), averaged to 50 Hz as a slower IMU: the stuck-field
    check compared the mean field of 64-sample bins (1.28 s, a turn of several rad) with −ω̄ × ū h and found it
    "turned 10 rad where the gyro 113": refused as a stuck magnetometer. Bins turning more than 1 rad are left out:
    the estimate runs, its heading RMSE what the recording at its own 285.7 Hz gives (14°, beside the magnet).
    The same field held at its first value is still refused at 50 Hz; 125-165 s, refused as swapped axes, runs."""
    tr = load_broad(BROAD / "29_disturbed_stationary_magnet_B.mat")
    sl = slice(int(45.4 * tr.rate_hz), int(85.4 * tr.rate_hz))
    full = estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl])
    ok = tr.eval_mask[sl] & np.isfinite(tr.q_ref[sl]).all(axis=1)
    h_full = rmse(np.degrees(heading_error(full.q_b_n, tr.q_ref[sl])), ok)
    (g, i), (a, _), (m, _) = (_averaged_to(x[sl], tr.rate_hz, 50.0) for x in (tr.gyr, tr.acc, tr.mag))
    q, ok = tr.q_ref[sl][i], ok[i]
    for offline in (False, True):
        r = estimate(g, a, 0.02, frame="ENU", mag=m, offline=offline)
        h = rmse(np.degrees(heading_error(r.q_b_n, q)), ok)
        assert abs(h - h_full) < 1.0 if not offline else h < h_full + 1.0, (offline, h, h_full)
    with pytest.raises(OptinavError, match="repeats one reading for .* while the gyro turns the body"):
        estimate(g, a, 0.02, frame="ENU", mag=np.tile(m[0], (m.shape[0], 1)))
    # 125-165 s the axes check read the fast bins' steps as "4382 % of its turning unexplained": swapped axes
    sl = slice(int(124.6 * tr.rate_hz), int(164.6 * tr.rate_hz))
    (g, _), (a, _), (m, _) = (_averaged_to(x[sl], tr.rate_hz, 50.0) for x in (tr.gyr, tr.acc, tr.mag))
    estimate(g, a, 0.02, frame="ENU", mag=m)


def test_a_gyro_bias_beyond_rest_gyr_off_the_vertical_is_refused_as_a_bias(trial):
    """A gyro bias beyond rest_gyr (0.1 rad/s) was not judged (a steady turn about the vertical reads the same), so
    BROAD 02 with [0.15, -0.075, 0.11] rad/s (8.8 °/s on x) added ran at 25.8° inclination RMSE with exit 0. A
    steady turn with a steady specific force turns about it (within the tilt a centripetal acceleration gives,
    and that raises |f| above g): a still reading this far off the accelerometer's axis, with |f| ≈ g, is a bias
    and is refused naming the clip that holds it; with it the tilt is the recording's (0.39°). A turn about the
    specific force (a tilted turntable) still passes."""
    bias = np.array([0.15, -0.075, 0.11])
    with pytest.raises(OptinavError, match=r"8\.8 °/s on its worst axis.*a bias beyond") as exc:
        estimate(trial.gyr + bias, trial.acc, trial.dt, frame="ENU")
    clip = float(re.search(r"bias_clip=([0-9.]+)", exc.value.remedy).group(1))
    q = estimate_q(trial.gyr + bias, trial.acc, trial.dt, frame="ENU", bias_clip=clip)
    assert np.degrees(rmse(inclination_error(q, trial.q_ref), trial.eval_mask)) < 0.5
    n, dt = 3000, 0.01
    up = np.array([0.0, 0.3, 1.0]) / np.hypot(0.3, 1.0)
    estimate(np.tile(0.3 * up, (n, 1)), np.tile(9.81 * up, (n, 1)), dt, frame="ENU")  # not refused


def test_a_gyro_bias_beyond_the_unit_checks_allowance_is_named_a_bias_not_a_unit(tmp_path, capsys):
    """BROAD 27 (translation, hardly turning) with [0.15, -0.075, 0.11] rad/s added was told "a unit factor of π/180
    explains it: --gyro-unit deg/s" (the unit checks allow for 5 °/s of bias), and 11 with [0.3, 0.2, -0.1] "axes
    swapped and deg/s": wrong causes, whose remedies run. The reading at rest beyond rest_gyr, off the specific
    force, is taken off before the unit, time base and axes are judged, then named as the bias it is — in memory and
    streamed from a file alike. A gyro in deg/s declared rad/s with its bias is still named a unit error."""
    from optinav.cli.main import main

    for name, bias in (
        ("27_disturbed_phone_vibration_B", [0.15, -0.075, 0.11]),
        ("11_undisturbed_slow_translation_B", [0.3, 0.2, -0.1]),
    ):
        p = _present(BROAD / f"{name}.hdf5")
        tr = load_broad(p)
        with pytest.raises(OptinavError, match=r"at rest: a bias beyond"):
            estimate(tr.gyr + bias, tr.acc, tr.dt, frame="ENU")
    f = _csv(tmp_path / "b.csv", tr.dt, tr.acc, tr.gyr + bias)
    assert main(["attitude", f, "--frame", "ENU", "--chunk-rows", "20000", "--out", str(tmp_path / "o.csv")]) == 2
    assert "at rest: a bias beyond" in capsys.readouterr().err
    with pytest.raises(
        OptinavError, match="deg/s declared rad/s"
    ):  # 0.6–1.1 °/s of bias, the gyro in deg/s read as rad/s
        estimate((tr.gyr + [0.01, -0.02, 0.005]) * (180.0 / np.pi), tr.acc, tr.dt, frame="ENU")


def test_a_gyro_bias_beyond_the_unit_checks_allowance_is_named_a_bias_by_the_methods_as_published(tmp_path, capsys):
    """BROAD 27 with [0.15, -0.075, 0.11] rad/s added under qn as published (--no-input-stage): the rest reading
    was taken off for the unit checks only where iframe's bias is tracked, so this was told "deg/s declared rad/s",
    a wrong cause whose remedy runs; taken off for them, qn (no bias estimate) ran at 35° inclination RMSE (5.8°
    without the bias). It is named a bias now, in memory and streamed; mekf as published estimates it and runs."""
    from optinav.cli.main import main

    p = _present(BROAD / "27_disturbed_phone_vibration_B.hdf5")
    tr = load_broad(p)
    gyr = tr.gyr + [0.15, -0.075, 0.11]
    with pytest.raises(OptinavError, match=r"at rest: a bias, which qn as published does not estimate"):
        estimate(gyr, tr.acc, tr.dt, frame="ENU", method="qn", input_stage=False)
    f = _csv(tmp_path / "b.csv", tr.dt, tr.acc, gyr)
    argv = ["attitude", f, "--frame", "ENU", "--method", "qn", "--no-input-stage", "--chunk-rows", "20000"]
    assert main([*argv, "--out", str(tmp_path / "o.csv")]) == 2
    assert "a bias, which qn as published does not estimate" in capsys.readouterr().err
    q = estimate_q(gyr, tr.acc, tr.dt, frame="ENU", method="mekf", input_stage=False)
    q0 = estimate_q(tr.gyr, tr.acc, tr.dt, frame="ENU", method="mekf", input_stage=False)
    err = [np.degrees(rmse(inclination_error(x, tr.q_ref), tr.eval_mask)) for x in (q, q0)]
    assert err[0] < err[1] + 0.5, err


def test_a_gyro_bias_about_the_vertical_is_told_from_a_turntable_by_the_whole_log(trial, tmp_path, capsys):
    """A still reading beyond rest_gyr along the vertical may be a steady turn (a turntable), so it was not judged:
    BROAD 02 with 0.154 rad/s (8.8 °/s) added on z ran at 8.7° inclination RMSE with exit 0. Once the body tilts, a
    bias turns gravity in the gyro-integrated frame and a turn about the world's vertical does not: taken off the
    whole log, this reading cuts that drift to a tenth, so it is refused as the bias it is (in memory and streamed).
    The same trial on a turntable turning at 0.154 rad/s about the vertical throughout still runs, at its own
    accuracy."""
    from optinav.cli.main import main

    gyr = trial.gyr + [0.0, 0.0, 0.154]
    with pytest.raises(OptinavError, match=r"a bias beyond.*not a steady turn"):
        estimate(gyr, trial.acc, trial.dt, frame="ENU")
    f = _csv(tmp_path / "z.csv", trial.dt, trial.acc, gyr)
    assert main(["attitude", f, "--frame", "ENU", "--chunk-rows", "20000", "--out", str(tmp_path / "o.csv")]) == 2
    assert "not a steady turn" in capsys.readouterr().err
    q = estimate_q(trial.gyr, trial.acc, trial.dt, frame="ENU")
    up = quat_rotate(quat_conjugate(q), np.tile([0.0, 0.0, 0.154], (q.shape[0], 1)))  # the turn in the body
    q = estimate_q(trial.gyr + up, trial.acc, trial.dt, frame="ENU")
    assert np.degrees(rmse(inclination_error(q, trial.q_ref), trial.eval_mask)) < 0.6


def test_a_gyro_bias_about_the_vertical_of_a_body_mounted_upside_down_is_no_turntable(tmp_path, capsys):
    """BROAD 29 mounted upside down (y and z negated) with 0.154 rad/s added on z: the drift a bias about the
    vertical leaves in the gyro-integrated frame is bounded by the body's tilt, and here taking the reading off cut
    it only to 0.60 of itself (0.146 -> 0.087 rad; the rule asked for half), so it ran at 5.0° inclination RMSE
    (0.98° without the bias) with exit 0. Whichever of bias and turn explains gravity better by LOW_AXES_FLOOR is
    now taken: refused as a bias, in memory and streamed. On a turntable turning at 0.154 rad/s it still runs at its
    own accuracy (taking the turn off would make the drift worse, 1.35-20× over the nine trials' variants)."""
    from optinav.cli.main import main
    from optinav.core.rotations import quat_multiply

    p = _present(BROAD / "29_disturbed_stationary_magnet_B.mat")
    tr = load_broad(p)
    g, a = tr.gyr * [1.0, -1.0, -1.0], tr.acc * [1.0, -1.0, -1.0]
    ref = quat_multiply(tr.q_ref, np.array([0.0, 1.0, 0.0, 0.0]))  # the body turned 180° about x
    with pytest.raises(OptinavError, match=r"a bias beyond.*not a steady turn"):
        estimate(g + [0.0, 0.0, 0.154], a, tr.dt, frame="ENU")
    f = _csv(tmp_path / "z.csv", tr.dt, a, g + [0.0, 0.0, 0.154])
    assert main(["attitude", f, "--frame", "ENU", "--chunk-rows", "20000", "--out", str(tmp_path / "o.csv")]) == 2
    assert "not a steady turn" in capsys.readouterr().err
    q = estimate_q(g, a, tr.dt, frame="ENU")
    assert np.degrees(rmse(inclination_error(q, ref), tr.eval_mask)) < 1.1
    up = quat_rotate(quat_conjugate(q), np.tile([0.0, 0.0, 0.154], (q.shape[0], 1)))  # the turn in the body
    q = estimate_q(g + up, a, tr.dt, frame="ENU")
    assert np.degrees(rmse(inclination_error(q, ref), tr.eval_mask)) < 1.1


def _offset_from(tr, start_s: float, offset) -> np.ndarray:
    """The trial's magnetometer rows with ``offset`` (3,) µT added from ``start_s`` s on (a magnet put on the board)."""
    mag = tr.mag.copy()
    mag[int(start_s * tr.rate_hz) :] += offset
    return mag


def _about(msg: str) -> list[np.ndarray]:
    """The points a refusal says the field turns about, in its order."""
    return [np.array(v.split(", "), float) for v in re.findall(r"about \[([^\]]+)\]", msg)]


def test_a_hard_iron_offset_that_changes_within_the_recording_is_refused(tmp_path, capsys):
    """The whole log's hard-iron fits assume one offset. BROAD 02 with +30 µT on body x from 60 s (a magnet put on
    the board): online the offset fitted from past samples (a mean of both fields) turned the heading by 40° RMS
    with exit 0, offline the whole log's 21°. BROAD 33 (its magnet on the board from 40 to 99 s) with (30, 0, 0) µT
    added everywhere: nothing fitted, 62° online, 64° offline. Fitted in windows of 10 s, the field turns about
    one point before the change and another after: refused, naming them (02 about zero before, 33 about the added
    offset plus the magnet's, then the added offset alone), in memory and streamed alike. BROAD 03 with
    (-20, 15, 40) µT from 60 s runs online (1.9°: the field before it is the reference, the offset a disturbance)
    and is refused offline (16°: the backward pass learns the field with the offset at the end)."""
    from optinav.cli.main import main

    p33, p03 = _present(BROAD / "33_disturbed_attached_magnet_2cm.hdf5", BROAD / "03_undisturbed_slow_rotation_C.hdf5")
    tr = load_broad(PATH)
    mag = _offset_from(tr, 60.0, [30.0, 0.0, 0.0])
    for offline in (False, True):
        with pytest.raises(OptinavError, match="changes within the recording") as e:
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=offline)
        assert np.linalg.norm(_about(str(e.value))[0]) < 2.0, str(e.value)  # calibrated before 60 s
    n = tr.gyr.shape[0]
    f = tmp_path / "magnet.csv"
    rows = np.column_stack([np.arange(n) * tr.dt, tr.gyr, tr.acc, mag])
    np.savetxt(f, rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "7000", "--out", str(tmp_path / "o.csv")]
    assert main(argv) != 0
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "changes within the recording" in err and not (tmp_path / "o.csv").exists(), err

    tr = load_broad(p33)
    for offline in (False, True):
        with pytest.raises(OptinavError, match="about zero nowhere") as e:
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag + [30.0, 0.0, 0.0], offline=offline)
        first, then = _about(str(e.value))
        assert np.linalg.norm(then - [30.0, 0.0, 0.0]) < 3.0 and abs(first[0] - 30.0) < 3.0, str(e.value)
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag, offline=True)  # as recorded: its magnet handled
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 3.5

    tr = load_broad(p03)
    mag = _offset_from(tr, 60.0, [-20.0, 15.0, 40.0])
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 3.0
    with pytest.raises(OptinavError, match="drop --offline"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)


def test_no_recording_of_the_nine_nor_its_cuts_is_taken_for_an_offset_that_changes():
    """The windowed offsets (offset_pieces) of the nine trials as recorded, their halves and 40-s cuts, at the full
    rate and a third of it: none is refused, online or offline — the magnet trial 33 included (its magnet on the
    board from 40 to 99 s, a disturbance the estimate handles: 1.1° online, 1.2° offline) — but online the cuts
    of 33 that start with its magnet on: the estimate learns that field for the Earth's (13.7-68° heading RMSE),
    and offline its 40-s cut from 40 s may be, as the magnet is put on (the Earth's field at its start, the magnet's
    to its end: 31.7° offline with exit 0, refused at the full rate)."""
    from optinav.attitude.checks import bin_fields, field_rate_sums, offset_change_error, offset_pieces, scale_bin_rows

    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    judged, magnet, put_on = 0, [], []
    for p in NINE:
        tr = load_broad(p)
        for step in (1, 3):
            gyr, mag, dt = tr.gyr[::step], tr.mag[::step], tr.dt * step
            n, k, r = gyr.shape[0], int(40.0 / dt), scale_bin_rows(dt)
            for a, b in [(0, n), (0, n // 2), (n // 2, n), *((i, i + k) for i in range(0, n - k, k // 2))]:
                bins, sums = field_rate_sums(gyr[a:b], mag[a:b], r)
                pieces, fields = offset_pieces(bins, sums, r * dt), bin_fields(bins, sums)
                judged += len(pieces)
                for offline in (False, True):
                    err = offset_change_error(pieces, r, r * dt, None, offline, fields)
                    if err is not None and p.name.startswith("33_") and not offline and 40.0 < a * dt < 99.0:
                        magnet.append(a * dt)
                    elif err is not None and p.name.startswith("33_") and offline and 39.9 < a * dt < 41.0:
                        put_on.append(b - a)
                    else:
                        assert err is None, (p.name, step, a, b, offline)
    assert judged > 300 and magnet and len(put_on) <= 2, (judged, magnet, put_on)
    tr = load_broad(next(p for p in NINE if p.name.startswith("33_")))
    s = slice(int(min(magnet) / tr.dt), None)
    with pytest.raises(OptinavError, match="at the start, for the Earth's"):
        estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s])
    # 5 s of 29 beside its magnet: no step between bins that the fit takes (an empty window list crashed)
    tr = load_broad(next(p for p in NINE if p.name.startswith("29_")))
    s = slice(int(35.6 / tr.dt), int(40.6 / tr.dt))
    assert estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s]).mag_used is not None


def test_an_offset_fitted_over_a_recording_it_came_partway_into_is_refused(tmp_path, capsys):
    """Offline, the whole recording's hard-iron fit is subtracted from every row. With an offset put on partway,
    that fit is a mix of none and the offset: BROAD 24 (tapping) with (30, 0, 0) µT from 60 s fitted (21.8, 1.9,
    -1.5) and ran at an 18.7° heading RMSE with exit 0, BROAD 11 with it from 90 s fitted (12.9, 0, 0): 32.6°.
    Judged against the offset subtracted, the windows after the change (8 µT off it on 24) explained a quarter of
    their turning: none was judged. On the field as measured they are judged against zero: 24's turn about (30, 0,
    0) µT from 60 s while its start, where the estimate learns its reference, holds the Earth's field without the
    offset; 11's turn about zero before 90 s. Refused, in memory and streamed."""
    from optinav.cli.main import main

    p24, p11 = _present(BROAD / "24_disturbed_tapping_A.hdf5", BROAD / "11_undisturbed_slow_translation_B.hdf5")
    tr = load_broad(p24)
    mag = _offset_from(tr, 60.0, [30.0, 0.0, 0.0])
    with pytest.raises(OptinavError, match="start of the recording.*changes within the recording") as e:
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
    assert np.linalg.norm(_about(str(e.value))[-1] - [30.0, 0.0, 0.0]) < 5.0, str(e.value)
    n = tr.gyr.shape[0]
    f = tmp_path / "magnet.csv"
    np.savetxt(f, np.column_stack([np.arange(n) * tr.dt, tr.gyr, tr.acc, mag]), delimiter=",",
               header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")  # fmt: skip
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--offline", "--chunk-rows", "7000"]
    assert main([*argv, "--out", str(tmp_path / "o.csv")]) != 0
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "changes within the recording" in err and not (tmp_path / "o.csv").exists(), err

    tr = load_broad(p11)
    mag = _offset_from(tr, 90.0, [30.0, 0.0, 0.0])
    with pytest.raises(OptinavError, match=r"about zero from sample \d+ \(40\.2 s\).*changes within"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)


def test_an_offset_that_comes_before_the_first_window_judged_is_refused_offline():
    """BROAD 24 with (-20, 15, 40) µT from 60 s: its motion starts at 40 s, no window before 60 s turns enough to be
    judged, every one after turns about the offset, and the whole recording's fits find none (it is not there at the
    start): offline the backward pass took the end's field for the Earth's, 21.9° heading RMSE with exit 0. The
    start holds the Earth's field as measured, the end the field with the offset: refused offline, naming the
    offset and "drop --offline"; online the field at the start is the reference (1.9°)."""
    p24 = _present(BROAD / "24_disturbed_tapping_A.hdf5")
    tr = load_broad(p24)
    mag = _offset_from(tr, 60.0, [-20.0, 15.0, 40.0])
    with pytest.raises(OptinavError, match="to the end, and at its start.*changes within") as e:
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
    assert "drop --offline" in e.value.remedy
    assert np.linalg.norm(_about(str(e.value))[0] - [-20.0, 15.0, 40.0]) < 6.0, str(e.value)
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 3.0


def test_an_offset_fitted_poorly_in_fast_rotation_is_refused_by_the_rest_after_it():
    """BROAD 07 (fast rotation) with (-20, 15, 40) µT from 60 s, offline: a window about zero at 40 s, one about
    (-18.9, 19.1, 59.9) µT at 60 s — 20 µT off the offset, fitted in fast rotation — so the rest at the end was not
    told with it (|m| 37 µT, less it 62, the Earth's 47) and nothing was said: 17.2° heading RMSE with exit 0
    (online 2.1°). The backward pass takes the end's rest for the Earth's whatever offset it carries: where a window
    after the last one about zero shows an offset, a rest of 22 s with a norm 16 % off the Earth's is refused."""
    p07 = _present(BROAD / "07_undisturbed_fast_rotation_B.hdf5")
    tr = load_broad(p07)
    mag = _offset_from(tr, 60.0, [-20.0, 15.0, 40.0])
    with pytest.raises(OptinavError, match=r"about \[0, 0, 0\].*to the end.*changes within") as e:
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
    assert "drop --offline" in e.value.remedy
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 3.0


def test_an_offset_to_the_end_that_leaves_the_heading_of_the_end_is_not_refused_offline():
    """BROAD 02 with (0, 20, 0) µT from 90 s or 120 s: offline, the field at the end carries the offset and the
    backward pass takes it for the Earth's, which was refused ("drop --offline"). At the end the offset lies along
    the field's horizontal direction: it turns it by 0.3° (end_turn), and offline ran at 0.9° and 0.4° heading RMSE
    (1.3° from 120 s since the offline heading takes only fields with the Earth's norm: iframe.earth_like). Now run;
    (30, 0, 0) µT from 90 s turns it by tens of degrees and is still refused."""
    tr = load_broad(PATH)
    for start_s, limit in ((90.0, 1.5), (120.0, 1.5)):
        mag = _offset_from(tr, start_s, [0.0, 20.0, 0.0])
        r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < limit, start_s
    mag = _offset_from(tr, 90.0, [30.0, 0.0, 0.0])
    with pytest.raises(OptinavError, match="changes within the recording"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)


def test_an_offset_put_on_in_the_rest_before_the_motion_is_refused_offline():
    """BROAD 02 with (0, 20, 0) µT from 30 s, in the 40-s rest before its motion: the whole recording's fit is the
    offset, every window agrees with it, and the rest before it, as measured, is 5 % off the field less it (under
    the 8 % the start's test needs): subtracted there too, 15.7° heading RMSE offline with exit 0. The field steps
    by the offset within the rest while the body does not turn (the gyro less its median): refused. BROAD 16 with
    (30, 0, 0) µT from 30 s (21.0°) alike; 02 with it from 0 s (one offset all along) runs (0.4°)."""
    p16 = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    for path, off in ((PATH, [0.0, 20.0, 0.0]), (p16, [30.0, 0.0, 0.0])):
        tr = load_broad(path)
        mag = _offset_from(tr, 30.0, off)
        with pytest.raises(OptinavError, match=r"steps by \[.*within a rest.*changes within") as e:
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
        step = np.array(re.search(r"steps by \[([^\]]+)\]", str(e.value)).group(1).split(", "), float)
        assert np.linalg.norm(step - off) < 2.0, str(e.value)
    tr = load_broad(PATH)
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=tr.mag + [0.0, 20.0, 0.0], offline=True)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.0


def test_an_offset_on_the_board_all_along_is_not_taken_for_one_that_came_partway():
    """The nine trials and their cuts ([0, 50 %], [25 %, 100 %], [10 s, end − 10 s]) with a constant offset added
    to every row: where the offset fitted (sphere or turning fit, as estimate() does offline) is within MAG_OFFSET
    of the field's norm of the one added, offset_held_error refuses none (71 of the 108 runs), nor any as recorded.
    A fit further off may be refused (16 with (30, 0, 0) µT from 25 %: fitted 4.4 µT off, the field less it 8 %
    off the Earth's at the end; its whole recording ran at 6.1° heading RMSE against 0.4° as recorded)."""
    from optinav.attitude.checks import (
        MAG_OFFSET,
        body_turned,
        check_mag,
        check_turning_offset,
        field_rate_sums,
        offset_held_error,
        scale_bin_rows,
    )

    if len(NINE) != 9:
        pytest.skip("the nine BROAD trials are not all present")
    held = 0
    for p in NINE:
        tr = load_broad(p)
        n, k, r = tr.gyr.shape[0], int(10.0 / tr.dt), scale_bin_rows(tr.dt)
        for a, b in ((0, n), (0, n // 2), (n // 4, n), (k, n - k)):
            for off in ([0.0, 0.0, 0.0], [30.0, 0.0, 0.0], [-20.0, 15.0, 40.0], [100.0, -80.0, 60.0]):
                mag = tr.mag[a:b] + off
                bins, sums = field_rate_sums(tr.gyr[a:b], mag, r)
                try:
                    got = check_mag(mag[::4], True, turned=body_turned(bins, sums, r * tr.dt))
                    got = check_turning_offset(bins, sums, r * tr.dt, True) if got is None else got
                except OptinavError:
                    continue  # refused before: an offset the recording does not show
                if got is not None and np.linalg.norm(got - off) < MAG_OFFSET * float(
                    np.median(np.linalg.norm(tr.mag, axis=1))
                ):
                    held += 1
                    assert offset_held_error(bins, sums, r * tr.dt, r, got, True) is None, (p.name, a, b, off, got)
    assert held >= 60, held


def _ak8963(m):
    """The field ``m`` (n, 3) as the AK8963 inside an MPU-9250 reads it in the IMU's axes: x and y swapped, z
    negated."""
    return np.column_stack([m[:, 1], m[:, 0], -m[:, 2]])


def _csv(path, dt, acc, gyr, mag=None):
    """A CSV of t, acc (m/s²), gyr (rad/s) and, given, mx, my, mz."""
    cols = [np.arange(acc.shape[0]) * dt, acc, gyr] + ([] if mag is None else [mag])
    head = "t,ax,ay,az,gx,gy,gz" + ("" if mag is None else ",mx,my,mz")
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=head, comments="", fmt="%.9g")
    return str(path)


def test_the_magnetometer_axes_are_judged_where_the_accelerometer_reads_gravity(tmp_path, capsys):
    """BROAD 16 averaged to 100 Hz, 40 s from 20 s: shaken by several g from 36 s, its accelerometer's 1.28-s means
    are 20-67° off the optical vertical, and the field's angle to them spread 48° as declared, 14° with the
    magnetometer's axes in another order: "its axes look not to be the IMU's", a warning with exit 0, in memory and
    streamed. Only the groups whose specific force stays within 0.3 g of g on average are judged now. The AK8963
    layout is still named by the field's angle to gravity on the rotating trials at 100 Hz, whole and cut."""
    from optinav.attitude.checks import MagnetometerWarning, check_mag_axes
    from optinav.cli.main import main

    names = ("16_undisturbed_fast_translation_B", "02_undisturbed_slow_rotation_B", "24_disturbed_tapping_A")
    if not all((BROAD / f"{n}.hdf5").is_file() for n in names):
        pytest.skip("BROAD 02, 16 or 24 absent")
    tr = load_broad(BROAD / f"{names[0]}.hdf5")
    (g, _), (a, _), (m, _) = (_averaged_to(x, tr.rate_hz, 100.0) for x in (tr.gyr, tr.acc, tr.mag))
    g, a, m = g[2000:6000], a[2000:6000], m[2000:6000]
    with warnings.catch_warnings():
        warnings.simplefilter("error", MagnetometerWarning)
        check_mag_axes(a, m, 0.01, g)
    csv = _csv(tmp_path / "16.csv", 0.01, a, g, m)
    assert main(["attitude", csv, "--frame", "ENU", "--mag", "--out", str(tmp_path / "a.csv")]) == 0
    assert "IMU's" not in capsys.readouterr().err
    for name, sl in ((names[1], slice(None)), (names[1], slice(2000, 6000)), (names[2], slice(None))):
        tr = load_broad(BROAD / f"{name}.hdf5")
        (g, _), (a, _), (m, _) = (_averaged_to(x, tr.rate_hz, 100.0) for x in (tr.gyr, tr.acc, tr.mag))
        with pytest.raises(OptinavError, match="angle to gravity.*its axes are not the IMU's"):
            check_mag_axes(a[sl], _ak8963(m[sl]), 0.01, g[sl])


def test_a_body_shaken_by_several_g_is_not_taken_for_another_accelerometer_unit(tmp_path, capsys):
    """BROAD 16, 5 s from 56.1 s: shaken at a median norm of 38 m/s² (3.9 g) and turning at 5 rad/s (no still 2-s
    window), it was refused as "another unit", at 285.7 Hz and at a third of it, in memory and streamed. Gravity's
    norm is judged instead: the still windows' 2-s means, or without one the 2-s means in the gyro-integrated frame
    (9.9 m/s² here). The cut in mg or in m/s² declared g, the whole trial in mg (its rests) and a shaken stretch too
    short to judge gravity by (3 s) in mg are still refused."""
    from optinav.attitude.checks import check_imu
    from optinav.cli.main import main
    from optinav.core.units import G_STANDARD

    p = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    tr = load_broad(p)
    sl = slice(int(56.1 / tr.dt), int(61.1 / tr.dt))
    mg = 1000.0 / G_STANDARD
    for k in (1, 3):
        g, a = (x[sl][: (sl.stop - sl.start) // k * k].reshape(-1, k, 3).mean(axis=1) for x in (tr.gyr, tr.acc))
        assert np.median(np.linalg.norm(a, axis=1)) > 3.5 * G_STANDARD
        check_imu(g, a, np.array([k * tr.dt]))
        for factor in (mg, G_STANDARD):
            with pytest.raises(OptinavError, match="it looks like another unit.*--acc-unit"):
                check_imu(g, a * factor, np.array([k * tr.dt]))
    with pytest.raises(OptinavError, match="--acc-unit"):
        check_imu(g[: int(3.0 / (3 * tr.dt))], a[: int(3.0 / (3 * tr.dt))] * mg, np.array([3 * tr.dt]))
    with pytest.raises(OptinavError, match="where the gyro is still .*--acc-unit"):
        check_imu(tr.gyr, tr.acc * mg, np.array([tr.dt]))
    argv = ["attitude", "--frame", "ENU", "--out", str(tmp_path / "a.csv")]
    assert main([*argv, _csv(tmp_path / "ok.csv", tr.dt, tr.acc[sl], tr.gyr[sl])]) == 0
    assert main([*argv, _csv(tmp_path / "mg.csv", tr.dt, tr.acc[sl] * mg, tr.gyr[sl])]) == 2
    assert "--acc-unit" in capsys.readouterr().err


def test_a_body_turning_over_gets_no_frame_warning_unless_it_lies_level_against_the_frame(tmp_path, capsys):
    """Cuts of the rotating trials that start upside down and lean so on average were told to use NED (their first
    200 samples were judged): BROAD 02 at a third of its rate, 5 s from 90.7 s (turning over and over: 1.2 s lying
    level upside down, 1.1 s upright), 03 for 20 s from 80 s (1.7 s, 1.3 s), 24 for 10 s from 142.5 s (1.0 s,
    0.9 s). The warning now needs 3 s lying level against the frame and three times the time with it; declared
    NED — a frame mistake — the whole of 02 and 20 s of 11 (15 s level) are still warned about, in memory and
    streamed."""
    from optinav.attitude.checks import FrameWarning
    from optinav.cli.main import main

    names = ("02_undisturbed_slow_rotation_B", "03_undisturbed_slow_rotation_C", "24_disturbed_tapping_A")
    if not all((BROAD / f"{n}.hdf5").is_file() for n in (*names, "11_undisturbed_slow_translation_B")):
        pytest.skip("BROAD 02, 03, 11 or 24 absent")
    tr = load_broad(BROAD / f"{names[0]}.hdf5")
    n = tr.acc.shape[0] // 3 * 3
    g, a = (x[:n].reshape(-1, 3, 3).mean(axis=1) for x in (tr.gyr, tr.acc))
    sl = slice(int(90.7 / (3 * tr.dt)), int(95.7 / (3 * tr.dt)))
    cuts = [(3 * tr.dt, a[sl], g[sl])]
    for name, start, seconds in ((names[1], 80.0, 20.0), (names[2], 142.5, 10.0)):
        t = load_broad(BROAD / f"{name}.hdf5")
        s = slice(int(start / t.dt), int((start + seconds) / t.dt))
        cuts.append((t.dt, t.acc[s], t.gyr[s]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", FrameWarning)
        for dt, acc, gyr in cuts:
            estimate(gyr, acc, dt, frame="ENU")
    assert (
        main(["attitude", _csv(tmp_path / "c.csv", *cuts[0]), "--frame", "ENU", "--out", str(tmp_path / "a.csv")]) == 0
    )
    assert "use --frame NED" not in capsys.readouterr().err
    with pytest.warns(FrameWarning, match="--frame ENU"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="NED")
    t = load_broad(BROAD / "11_undisturbed_slow_translation_B.hdf5")
    s = slice(int(60.0 / t.dt), int(80.0 / t.dt))
    with pytest.warns(FrameWarning, match="--frame ENU"):
        estimate(t.gyr[s], t.acc[s], t.dt, frame="NED")
    csv = _csv(tmp_path / "11.csv", t.dt, t.acc[s], t.gyr[s])
    assert main(["attitude", csv, "--frame", "NED", "--out", str(tmp_path / "b.csv")]) == 0
    assert "use --frame ENU" in capsys.readouterr().err


def test_a_magnet_taken_off_in_the_rest_after_the_motion_runs_offline_one_kept_on_is_refused(tmp_path, capsys):
    """Offline, windows about an offset after the last one about zero were refused as the field the backward pass
    learns — whether or not the magnet was still on at the end. A magnet on the board (33's own offset, (-2.9,
    -0.3, 27.1) µT, ×4: a 1.3-cm magnet) from 113 s of BROAD 02, taken off 8 s after the motion ends, was refused
    (--offline: 0.44° heading RMSE without the check; the same on 33 and 03, 1-8× that offset: 20 of 20 such cuts).
    With 33's magnet kept on through its final rest to 4 s before the end, one window showed it: 14.3° with exit 0.
    The backward pass learns the field where the recording ends or where it holds MAG_NEW_S: judged bin by bin
    there, the field less the offset being the Earth's."""
    from optinav.cli.main import main

    p33 = _present(BROAD / "33_disturbed_attached_magnet_2cm.hdf5")
    magnet = np.array([-2.9, -0.3, 27.1])

    def on(tr, t1, t2):  # the magnet's field, put on at t1 and taken off at t2 (2-s ramps), body axes
        t = np.arange(tr.gyr.shape[0]) * tr.dt
        return (np.clip((t - t1) / 2.0, 0, 1) * np.clip((t2 - t) / 2.0, 0, 1))[:, None] * magnet

    tr = load_broad(PATH)  # motion ends at 153 s
    mag = tr.mag + 4.0 * on(tr, 113.0, 161.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the magnet's field norm also reads as soft iron
        r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.0
    n = tr.gyr.shape[0]
    f = tmp_path / "magnet.csv"
    np.savetxt(f, np.column_stack([np.arange(n) * tr.dt, tr.gyr, tr.acc, mag]), delimiter=",",
               header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")  # fmt: skip
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--offline", "--chunk-rows", "7000"]
    assert main([*argv, "--out", str(tmp_path / "o.csv")]) == 0, capsys.readouterr().err

    tr = load_broad(p33)  # motion ends at 135 s, the recording at 169 s
    for k, off, ok in ((4.0, 140.0, True), (4.0, 165.0, False)):
        mag = tr.mag + k * on(tr, 110.0, off)
        if ok:
            r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
            assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.5
        else:
            with pytest.raises(OptinavError, match="drop --offline"):
                estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
            r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)  # online the field before it is the reference
            assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.5


def _at_about(msg: str) -> int:
    """The sample at which a refusal says the offset changes (its remedy: cut the recording there)."""
    return int(re.search(r"changes, at about sample (\d+)", msg).group(1))


def test_a_magnet_put_on_partway_is_named_not_a_mirrored_frame_nor_other_axes(tmp_path, capsys):
    """A magnet of about twice the field put on the board partway: BROAD 02 with (16.0, -81.8, 55.2) µT from 74 s was
    refused as a mirrored frame, "likelier" a magnetometer in other axes (remapped as told it ran 12-174° off with
    exit 0), and 16 with (-87.9, -0.3, 47.7) µT from 69 s as a magnetometer in other axes. Less each part's offset
    (the field's windows turn about zero, then about the magnet's) it turns as the gyro says: refused as an offset
    that changes within the recording, naming where (within 1 s), online and offline, in memory and streamed."""
    import h5py

    from optinav.cli.main import main

    p16 = _present(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    for path, row, off in ((PATH, 21133, [16.02, -81.81, 55.23]), (p16, 19702, [-87.87, -0.32, 47.74])):
        tr = load_broad(path)
        mag = tr.mag.copy()
        mag[row:] += off
        for offline in (False, True):
            with warnings.catch_warnings(), pytest.raises(OptinavError, match="changes within the recording") as e:
                warnings.simplefilter("ignore")  # its norm reads as soft iron too
                estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=offline)
            msg = str(e.value)
            assert "mirrored" not in msg and "not the IMU's" not in msg, msg
            first, then = _about(msg)[0], _about(msg)[-1]
            assert np.linalg.norm(first) < 2.0 and np.linalg.norm(then - off) < 6.0, msg
            if "at about sample" in msg:
                assert abs(_at_about(msg) - row) * tr.dt < 1.0, msg
            else:  # offline, said where the backward pass learns the magnet's field: online runs
                assert offline and "drop --offline" in e.value.remedy, msg
    f = tmp_path / "magnet.hdf5"  # BROAD 02's, streamed in blocks: refused alike
    with h5py.File(PATH, "r") as src, h5py.File(f, "w") as dst:
        for k in src:
            dst[k] = src[k][()]
        dst["imu_mag"][21133:] += [16.02, -81.81, 55.23]
        dst.attrs.update(dict(src.attrs))
    out = tmp_path / "o.csv"
    assert (
        main(["--quiet", "attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "7000", "--out", str(out)]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "changes within the recording" in err and "mirrored" not in err and not out.exists(), err
    assert abs(_at_about(err) - 21133) * 0.0035 < 1.0, err


def test_one_offset_for_a_recording_whose_offset_changes_is_refused_as_the_change():
    """BROAD 11 with (21.3, 12.4, 4.2) µT from 70 % of the recording (118 s): the whole recording's sphere fit,
    (9.3, 5.0, 1.7) µT, is a mix of none and the offset, about which the windows after the change turn too little
    to be judged. Offline it was subtracted (11.8° heading RMSE with exit 0); online its fit from past samples never
    passed and the refusal named it to give (--mag-hard-iron=9.34,4.97,1.675), which ran at 40° with exit 0. The
    field's windows turn about zero before 118 s and about the offset after: refused as the change, named within
    1.5 s, online, offline and with that offset given."""
    p11 = _present(BROAD / "11_undisturbed_slow_translation_B.hdf5")
    tr = load_broad(p11)
    mag = tr.mag.copy()
    mag[33678:] += [21.32, 12.37, 4.19]
    for kw in ({}, {"offline": True}, {"mag_hard_iron": [9.34, 4.97, 1.675]}):
        with pytest.raises(OptinavError, match="no one offset holds in every part.*changes within") as e:
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, **kw)
        assert "--mag-hard-iron=" not in str(e.value) and abs(_at_about(str(e.value)) - 33678) * tr.dt < 1.5, kw


def test_offline_a_magnet_put_on_in_motion_is_refused_by_the_rest_after_it():
    """Offline the backward pass takes the field of the rest at the end for the Earth's. BROAD 07 with (25, 10, -20)
    µT from 50 % of the recording (in fast rotation: no window after it judged) ran offline at 26.3° heading RMSE
    with exit 0 (online 1.7°), 29 with 100 µT from 70 % of its motion at 28.7°: the rest at the end holds a field 50
    % and 72 % off the Earth's norm. 16 with (-22.8, 7.0, 7.6) µT from 61 %: windows about the offset to the end,
    the end's norm 3 % off the Earth's, its angle to gravity 23° off (6.6° less the offset): 13.5°. Refused offline,
    naming "drop --offline"; online 07 runs at 1.7° (its heading in the final rest is taken from the magnet's field
    once it has held 20 s)."""
    p07, p16, p29 = _present(
        BROAD / "07_undisturbed_fast_rotation_B.hdf5",
        BROAD / "16_undisturbed_fast_translation_B.hdf5",
        BROAD / "29_disturbed_stationary_magnet_B.mat",
    )
    for path, row, off in (
        (p07, 26259, [25.0, 10.0, -20.0]),
        (p29, 33381, [-56.961, 19.345, 79.883]),
        (p16, 32532, [-22.77, 6.98, 7.6]),
    ):
        tr = load_broad(path)
        mag = tr.mag.copy()
        mag[row:] += off
        with (
            warnings.catch_warnings(),
            pytest.raises(OptinavError, match="backward pass takes that field.*changes") as e,
        ):
            warnings.simplefilter("ignore")  # 29's magnet beside its field reads as other axes too (a warning)
            estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, offline=True)
        assert "drop --offline" in e.value.remedy, str(e.value)
        if path == p07:
            r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
            assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 2.5


@pytest.mark.parametrize(("name", "limit"), [("02", 1.5), ("24", 2.5), ("07", 2.5)])
def test_a_magnet_put_on_as_the_motion_starts_is_learned_online(name, limit):
    """+30 µT on body x from 30 s, in the rest before the motion (02 turns from 38 s, 24 from 40 s) or 0.7 s into
    it (07, from 29.3 s): the online fit summed every sample from the start, so the 30 s of rest without the offset,
    a cluster off the sphere of the field with it, held it at 18.5 and 16.1 µT (its refinements then failed the
    spread gate) and the heading ran at 35.7° and 25.2° RMSE with exit 0 (as recorded 1.35° and 1.14°); on 07 at
    20.1 µT, 5.8° (1.18°). Only samples taken while the gyro turns enter the fit now, and a fit that turned every
    way without passing its gates gives way to one of the blocks after it: the offset within 1 µT (measured 29.7,
    29.5 and 30.1 on x), the heading at 0.86°, 1.89° and 1.78°."""
    p = next((q for q in NINE if q.name.startswith(name + "_")), None)
    if p is None:
        pytest.skip(f"BROAD trial {name} is not present")
    tr = load_broad(p)
    est = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=_offset_from(tr, 30.0, [30.0, 0.0, 0.0]))
    np.testing.assert_allclose(est.mag_hard_iron, [30.0, 0.0, 0.0], atol=1.5)
    assert abs(est.mag_hard_iron[0] - 30.0) < 1.0 and est.mag_hard_iron_from * tr.dt > 38.0
    assert rmse(np.degrees(heading_error(est.q_b_n, tr.q_ref)), tr.eval_mask) < limit


def test_an_offset_that_comes_in_motion_and_is_never_fitted_again_is_refused_online(tmp_path, capsys):
    """BROAD 07 with +30 µT on body x from 60 s, in its fast rotation: the online fit of the samples before and
    after never passed its gates and the refusal named a mix of both to give (--mag-hard-iron=16.65,-0.6456,5.74);
    a fit of the blocks across the change passed them 13 µT off and ran at 10.8° RMSE with exit 0. The blocks after it no longer fit the offset in use, and the rest of
    the recording never turns the sensor about every axis again: the field is left unused from there (the heading
    the gyro's) and, as that lasts to the end (over mag_new_time), the estimate is refused naming the sample and the
    remedy, in memory and streamed alike."""
    from optinav.cli.main import main

    p = next((q for q in NINE if q.name.startswith("07_")), None)
    if p is None:
        pytest.skip("BROAD trial 07 is not present")
    tr = load_broad(p)
    mag = _offset_from(tr, 60.0, [30.0, 0.0, 0.0])
    with pytest.raises(OptinavError, match=r"from sample \d+ on no longer fits the hard-iron offset") as e:
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    row = int(re.search(r"from sample (\d+) on", str(e.value)).group(1))
    assert 60.0 < row * tr.dt < 75.0 and "cut the recording where it changes" in str(e.value)
    n = tr.gyr.shape[0]
    f, out = tmp_path / "m.csv", tmp_path / "o.csv"
    rows = np.column_stack([np.arange(n) * tr.dt, tr.gyr, tr.acc, mag])
    np.savetxt(f, rows, delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="", fmt="%.9g")
    assert main(["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "9000", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"from sample {row} on no longer fits" in err and not out.exists(), err


def test_a_magnet_held_at_rest_before_the_motion_is_learned_online_and_refused():
    """A magnet put on the board (33's offset, (-2.9, -0.3, 27.1) µT) 25 s before BROAD 02's motion and taken off at
    80 s: the estimate took the steady field at rest for the Earth's (a new field after mag_new_time, 20 s) and the
    heading ran at 6.6° RMSE online with exit 0 (21.8° with 4× the offset; 02, 03, 24 with it from 5 or 15 s:
    6.1-38°). The windows turn about the offset before the first one about zero, and the rest before them holds
    the field with it for 20 s or more: refused, naming both points. Put on 15 s before the motion it is a
    disturbance the estimate handles (1.2°), as BROAD 33's own magnet, put on 5 s before it."""
    tr = load_broad(PATH)  # motion from 40 s
    t = np.arange(tr.gyr.shape[0]) * tr.dt
    magnet = np.array([-2.9, -0.3, 27.1])
    for t1, t2, ok in ((15.0, 80.0, False), (25.0, 85.0, True)):
        mag = tr.mag + (np.clip((t - t1) / 2.0, 0, 1) * np.clip((t2 - t) / 2.0, 0, 1))[:, None] * magnet
        if ok:
            r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
            assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.5
        else:
            with pytest.raises(OptinavError, match="at the start, for the Earth's") as e:
                estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
            first, then = _about(str(e.value))
            assert np.linalg.norm(first - magnet) < 3.0 and np.linalg.norm(then) < 1e-9, str(e.value)


def test_a_reference_learned_in_a_disturbed_start_is_replaced_once_the_field_is_clean():
    """BROAD 33 cut to start at 38 s, as its magnet is put on the board: the online estimate learns its magnetic
    reference from the start (41 µT, 8 % off the Earth's 44.5). Once the magnet is taken off (99 s) the clean field
    is steady and should become the reference after mag_new_time, but every few seconds one sample fell within
    the 5 % gate of the old reference and restarted the candidate's time: 3 % of the samples after 110 s used, the
    heading 25° off to the end. A disturbance ends once the field has agreed for HI_RESET_TIME without a break
    (as the body-fixed offset's fit already took it): 98 % used, 2° over the motion's last 16 s."""
    tr = load_broad(BROAD / "33_disturbed_attached_magnet_2cm.hdf5")
    s = slice(int(38.0 / tr.dt), None)
    r = estimate(tr.gyr[s], tr.acc[s], tr.dt, frame="ENU", mag=tr.mag[s], checks=False)
    t = 38.0 + np.arange(r.q_b_n.shape[0]) * tr.dt
    assert r.mag_used[t > 110.0].mean() > 0.9
    late = (t > 120.0) & (t < 136.0)
    err = np.degrees(heading_error(r.q_b_n[late], tr.q_ref[s][late]))
    assert rmse(err, tr.eval_mask[s][late]) < 3.0


def _pairs_averaged(x):
    """``x`` (n, 3) at half its rate, each pair of rows averaged (an IMU that samples half as fast)."""
    n = x.shape[0] // 2 * 2
    return x[:n].reshape(-1, 2, 3).mean(axis=1)


def test_a_rate_swinging_within_the_bins_is_no_magnetometer_in_other_axes():
    """BROAD 16 at half its rate (142.9 Hz), 20 s from 28 s of its fast translation: between 64-row bins (0.45 s)
    the field's step was compared with the two bins' mean rate × 0.45 s, while the step between two means weighs
    the rotation by a triangle across both bins: with the rate swinging within them, 350 % of the field's turning
    was unexplained and the cut refused as a magnetometer in other axes. With the triangle (39 %) it runs, its
    heading and inclination RMSE within 0.05° of the same cut at the full rate; the magnetometer in the AK8963
    layout is still refused, as is a mirrored frame, and the sums of a log streamed in blocks are the whole's."""
    from optinav.attitude import checks as C

    tr = load_broad(BROAD / "16_undisturbed_fast_translation_B.hdf5")
    errs = []
    for k, (g, a, m) in ((1, (tr.gyr, tr.acc, tr.mag)), (2, map(_pairs_averaged, (tr.gyr, tr.acc, tr.mag)))):
        s = slice(int(28.0 * tr.rate_hz / k), int(48.0 * tr.rate_hz / k))
        q = tr.q_ref[k // 2 :: k][s]
        ok = tr.eval_mask[k // 2 :: k][s] & np.isfinite(q).all(axis=1)
        r = estimate(g[s], a[s], k * tr.dt, frame="ENU", mag=m[s])
        errs.append([rmse(np.degrees(f(r.q_b_n, q)), ok) for f in (heading_error, inclination_error)])
    assert np.all(np.abs(np.subtract(*errs)) < 0.05), errs
    g, a, m = g[s], a[s], m[s]
    with pytest.raises(OptinavError, match="turns in the body unlike the gyro says"):
        estimate(g, a, 2 * tr.dt, frame="ENU", mag=_ak8963(m))
    x = np.array([-1.0, 1.0, 1.0])
    with pytest.raises(OptinavError, match="left-handed"):
        estimate(g * x, a * x, 2 * tr.dt, frame="ENU", mag=m * x)
    whole = C.gyro_sums(g)
    cut = 1000  # within a bin
    blocks = [np.concatenate(z) for z in zip(C.gyro_sums(g[:cut]), C.gyro_sums(g[cut:], cut))]
    (b0, s0), (b1, s1) = (C.merge_bins(b, np.column_stack([s, c])) for b, s, c in (whole, blocks))
    assert np.array_equal(b0, b1) and np.allclose(s0, s1)


def test_a_fast_turn_that_spins_gravity_away_is_no_unit_factor():
    """BROAD 29, 10 s from 82.5 s at its own 285.7 Hz, turning at 7.4 rad/s RMS: the gyro × 180/π spins the frame
    so fast that the 2-s means of the specific force in it average gravity away but for its part along the spin's
    axis (29 % of gravity kept), and those short means stayed put (0.021 rad) better than the declared unit's
    (0.076 rad, all of gravity kept): refused as rad/s declared deg/s. A scale whose means keep under half of
    gravity is no evidence: it runs, offline within the whole recording's online inclination RMSE over those
    samples (1.25°); the cut's rad/s declared deg/s and deg/s declared rad/s are still refused."""
    tr = load_broad(BROAD / "29_disturbed_stationary_magnet_B.mat")
    s = slice(int(82.5 / tr.dt), int(92.5 / tr.dt))
    ok = tr.eval_mask[s] & np.isfinite(tr.q_ref[s]).all(axis=1)
    whole = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU")
    limit = rmse(np.degrees(inclination_error(whole.q_b_n[s], tr.q_ref[s])), ok)
    g, a = tr.gyr[s], tr.acc[s]
    for mag in (None, tr.mag[s]):
        r = estimate(g, a, tr.dt, frame="ENU", mag=mag, offline=True)
        assert rmse(np.degrees(inclination_error(r.q_b_n, tr.q_ref[s])), ok) < limit
    with pytest.raises(OptinavError, match="180/π"):
        estimate(g * np.pi / 180, a, tr.dt, frame="ENU")
    with pytest.raises(OptinavError, match="deg/s declared rad/s"):
        estimate(g * 180 / np.pi, a, tr.dt, frame="ENU")


def _streamed_as_in_memory(f, q_b_n, offline: bool, chunk: int, tmp_path, capsys) -> None:
    """``optinav attitude f --frame ENU --mag`` in blocks of ``chunk`` rows (``--offline``) gives the heading of
    the in-memory estimate ``q_b_n`` within 1e-3°."""
    from optinav.cli.main import main

    out = tmp_path / "o.csv"
    extra = ["--offline"] if offline else []
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", str(chunk), "--out", str(out), *extra]
    assert main(argv) == 0, capsys.readouterr().err
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:5]
    assert np.nanmax(np.degrees(np.abs(heading_error(q, q_b_n)))) < 1e-3


def test_the_end_s_specific_force_is_the_same_in_memory_and_streamed(trial):
    """The offline end-turn rule reads the specific force over the last second: in memory it was the mean of the
    last second's samples, streamed the last bins of the last four blocks (a decision near its 2° could differ,
    and blocks shorter than a second saw less). Both now take the same bins (checks.end_up): alike to rounding
    (a bin split between blocks summed in two parts) for blocks of 7000 and 100 rows."""
    from optinav.attitude import checks as C

    n = trial.acc.shape[0]
    i = C.end_tail(n, trial.dt)
    b, a, _, c, _ = C.mag_sums(trial.acc[i:], trial.mag[i:], i)
    whole = C.end_up(b, a, c, trial.dt)
    np.testing.assert_allclose(whole, trial.acc[-int(round(1.0 / trial.dt)) :].mean(axis=0), atol=0.01)
    for rows in (7000, 100):
        parts = [C.mag_sums(trial.acc[s : s + rows], trial.mag[s : s + rows], s) for s in range(0, n, rows)]
        b, a, _, c, _ = (np.concatenate(x) for x in zip(*parts))
        np.testing.assert_allclose(C.end_up(b, a, c, trial.dt), whole, rtol=1e-12, atol=0)  # (a split bin's sum)


def test_an_offset_a_short_log_turns_too_little_to_fit_is_refused_not_run_on_the_raw_field(tmp_path, capsys):
    """BROAD 02's last 40 s (the motion's last 3 s, 2.1 rad of turning, then rest) with a (25, -15, 35) µT offset:
    too little turning for the whole log's fits, and the raw field ran at 80° heading RMSE online, 87° offline,
    with exit 0. The field turns about the offset, not zero, where the body turns (88 % explained), and the start
    holds that field: refused, in memory and streamed. As recorded it runs (1.3° and 0.8°), and so with the offset
    given."""
    from optinav.cli.main import main

    tr = load_broad(PATH)
    sl = slice(tr.gyr.shape[0] - int(40.0 / tr.dt), None)
    g, a, q, mask = tr.gyr[sl], tr.acc[sl], tr.q_ref[sl], tr.eval_mask[sl]
    b0 = np.array([25.0, -15.0, 35.0])
    mag = tr.mag[sl] + b0
    for offline in (False, True):
        with pytest.raises(OptinavError, match="not about zero, wherever the body turns") as exc:
            estimate(g, a, tr.dt, frame="ENU", mag=mag, offline=offline)
        assert "--mag-hard-iron" in exc.value.remedy
        got = re.search(r"about \[([^\]]+)\]", str(exc.value)).group(1)
        assert np.linalg.norm(np.array(got.split(","), float) - b0) < 5.0  # the offset it names (µT)
        for m, given in ((tr.mag[sl], None), (mag, b0)):
            r = estimate(g, a, tr.dt, frame="ENU", mag=m, mag_hard_iron=given, offline=offline)
            assert rmse(np.degrees(heading_error(r.q_b_n, q)), mask) < 2.0
    f = tmp_path / "m.csv"
    np.savetxt(f, np.column_stack([np.arange(g.shape[0]) * tr.dt, g, a, mag]), delimiter=",",
               header="t,gx,gy,gz,ax,ay,az,mx,my,mz", comments="")  # fmt: skip
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "3000", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    assert "not about zero, wherever the body turns" in capsys.readouterr().err


def test_an_offset_all_along_with_a_magnet_in_the_first_rest_is_refused(tmp_path, capsys):
    """BROAD 11 (it hardly tilts: the offset is read from how the field turns) with a (25, -15, 35) µT offset all
    along and 30 µT more on x for 10 s of its first rest: the field less the offset, unsteady in that rest, made the
    whole log's fits decline it, and the raw field ran at 91° heading RMSE online with exit 0 (given the offset:
    0.72°). Every window judged turns about the offset, none about zero, and the start holds that field: refused,
    in memory and streamed."""
    from optinav.cli.main import main

    tr = load_broad(_present(BROAD / "11_undisturbed_slow_translation_B.hdf5"))  # motion from 33 s
    t = np.arange(tr.gyr.shape[0]) * tr.dt
    mag = tr.mag + np.array([25.0, -15.0, 35.0])
    mag[(t > 19.0) & (t < 29.0)] += np.array([30.0, 0.0, 0.0])
    with pytest.raises(OptinavError, match="not about zero, wherever the body turns"):
        estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag)
    r = estimate(tr.gyr, tr.acc, tr.dt, frame="ENU", mag=mag, mag_hard_iron=[25.0, -15.0, 35.0], checks=False)
    assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref)), tr.eval_mask) < 1.5  # what a refusal points to
    f = tmp_path / "m.csv"
    np.savetxt(f, np.column_stack([t, tr.gyr, tr.acc, mag]), delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz",
               comments="")  # fmt: skip
    argv = ["attitude", str(f), "--frame", "ENU", "--mag", "--chunk-rows", "7000", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    assert "not about zero, wherever the body turns" in capsys.readouterr().err


def test_a_magnet_on_the_board_is_refused_where_the_estimate_starts_in_it_not_where_it_starts_clean():
    """BROAD 33 as recorded, its magnet put on the board at 38 s and taken off at 99 s. From 60 s to 100 s the
    field turns about the magnet's offset wherever judged and the estimate starts in it: 39.5° heading RMSE online,
    63° offline, with exit 0; refused. From 20 s to 60 s the motion shows the same offset, but the start, before
    the magnet, holds the Earth's field (44.4 µT; less the offset 70 µT): the reference is clean and the heading
    right (1.0°), not refused. A start off the Earth's norm either way is refused (below)."""
    tr = load_broad(_present(BROAD / "33_disturbed_attached_magnet_2cm.hdf5"))

    def cut(a, b):
        sl = slice(int(a / tr.dt), int(b / tr.dt))
        return tr.gyr[sl], tr.acc[sl], tr.dt, tr.mag[sl], tr.q_ref[sl], tr.eval_mask[sl]

    for offline in (False, True):
        g, a, dt, m, _, _ = cut(60.0, 100.0)
        with pytest.raises(OptinavError, match="not about zero, wherever the body turns"):
            estimate(g, a, dt, frame="ENU", mag=m, offline=offline)
        g, a, dt, m, q, mask = cut(20.0, 60.0)
        r = estimate(g, a, dt, frame="ENU", mag=m, offline=offline)
        assert rmse(np.degrees(heading_error(r.q_b_n, q)), mask) < 1.5
        # with a (25, -15, 35) µT offset too, from 40 s: the start holds that offset but not the magnet's (31.4 µT,
        # less both 70.7, the Earth's 45.0): a reference off either way, 99° online and 103° offline with exit 0
        g, a, dt, m, _, _ = cut(40.0, 80.0)
        with pytest.raises(OptinavError, match="not about zero, wherever the body turns"):
            estimate(g, a, dt, frame="ENU", mag=m + [25.0, -15.0, 35.0], offline=offline)


def test_an_offset_shown_in_one_window_of_a_log_turning_throughout_is_refused():
    """BROAD 07's last 80 s (fast rotation, then rest) with a (25, -15, 35) µT offset: one 10-s window turns about
    the offset, the rest of the motion too fast for the 0.1-s steps, and the start's norm tells neither (46.8 µT as
    measured, 44.6 less the offset): the raw field ran at 23.6° heading RMSE online, 50° offline, with exit 0. The
    body turns throughout before that window (no still second for a magnet to be put on in): refused."""
    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    sl = slice(tr.gyr.shape[0] - int(80.0 / tr.dt), None)
    for offline in (False, True):
        with pytest.raises(OptinavError, match="not about zero, wherever the body turns"):
            estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl] + [25.0, -15.0, 35.0], offline=offline)
        r = estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl], offline=offline)
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[sl])), tr.eval_mask[sl]) < 2.5  # as recorded


def test_an_offset_the_norm_shows_on_a_body_turning_too_fast_for_the_steps_is_refused():
    """BROAD 07's fast rotation from 80 s to 120 s with a (25, -15, 35) µT offset: the 0.1-s steps turn too far to
    fit how the field turns and the sphere fit sees one axis turned about too little, so the raw field ran at 97°
    heading RMSE online, 54° offline, with exit 0. Its norm varies by 24 % with the orientation, and the sphere
    fitted along all three axes takes it down to 1.6 % (as recorded 1.6 %, varying by 1.6 %: not judged): refused,
    naming that offset."""
    tr = load_broad(_present(BROAD / "07_undisturbed_fast_rotation_B.hdf5"))
    sl = slice(int(80.0 / tr.dt), int(120.0 / tr.dt))
    for offline in (False, True):
        with pytest.raises(OptinavError, match="field norm varies by 24%") as exc:
            estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl] + [25.0, -15.0, 35.0], offline=offline)
        got = re.search(r"about \[([^\]]+)\]", str(exc.value)).group(1)
        assert np.linalg.norm(np.array(got.split(","), float) - [25.0, -15.0, 35.0]) < 2.0
        # as recorded it runs: 5.7° online (from the first sample's heading, 98° off, in fast rotation), 0.8° offline
        r = estimate(tr.gyr[sl], tr.acc[sl], tr.dt, frame="ENU", mag=tr.mag[sl], offline=offline)
        assert rmse(np.degrees(heading_error(r.q_b_n, tr.q_ref[sl])), tr.eval_mask[sl]) < (1.5 if offline else 7.0)


def test_a_magnetometer_turned_half_a_turn_names_both_readings_its_turning_allows():
    """A magnetometer turned 180° about its z axis (x and y negated) on a simulated flight (its angle to gravity
    barely changes: the turning judges it) was named "z reads -z": a field and its negative turn alike in the body,
    and that reading, followed, ran at a heading 178° off with exit 0. Both readings are named, and how to tell
    them apart."""
    from optinav.attitude import simulate
    from optinav.core.rotations import dcm_from_quat
    from optinav.errors import OptinavError

    fl = simulate("dynamic", duration_s=30.0, rng=1)
    C = dcm_from_quat(fl.q_b_n)  # C_b^n
    m_b = np.einsum("nji,j->ni", C, [20.0, -3.0, 45.0]) + np.random.default_rng(3).normal(0, 0.3, (len(C), 3))
    with pytest.raises(OptinavError) as exc:
        estimate(fl.gyr, fl.acc, fl.dt, mag=m_b * [-1.0, -1.0, 1.0])
    text = str(exc.value)
    assert "magnetometer x reads -x, magnetometer y reads -y" in text and "z reads -z" in text, text
    assert "field points down north of the magnetic equator" in text, text


def test_a_magnet_attached_nearer_than_33s_runs_as_33_does():
    """BROAD's attached-magnet trials put the magnet on the board 1-5 cm from the IMU for part of the recording
    (32-36; 33, 2 cm, is here; the others are the independent evaluation's). 33's disturbance while its magnet is on
    (the field less the Earth's by the optical reference, 40-99 s) scaled to a magnet 1 cm away (×8: a dipole falls
    with the cube of the distance) must run as 33 does, not be refused as an uncalibrated magnetometer (a guard:
    the checks that refuse offsets which come and go were tuned on 33 alone): 2.1° heading RMSE online, 1.8°
    offline (VQF 9.6°, 1.7°; 33 itself 1.1°, 1.3°).
    (Scaled with the mask closed over 99-133 s, the residual there ×8 too, it was refused: not a magnet.)"""
    tr = load_broad(_present(BROAD / "33_disturbed_attached_magnet_2cm.hdf5"))
    ok = np.all(np.isfinite(tr.q_ref), axis=1)
    first = ok & (np.arange(ok.size) < int(20 * tr.rate_hz))  # the magnet is put on at 40 s
    earth = np.mean(quat_rotate(tr.q_ref[first], tr.mag[first]), axis=0)
    d = np.full_like(tr.mag, np.nan)
    d[ok] = tr.mag[ok] - quat_rotate(quat_conjugate(tr.q_ref[ok]), np.broadcast_to(earth, (ok.sum(), 3)))
    rows = np.arange(ok.size)
    d = np.column_stack([np.interp(rows, rows[ok], d[ok, k]) for k in range(3)])
    w = int(tr.rate_hz)  # on the board where the disturbance's 1-s mean is beyond 3 µT
    on = np.convolve(np.linalg.norm(d, axis=1), np.ones(w) / w, mode="same") > 3.0
    mag = tr.mag + 7.0 * d * on[:, None]  # ×8 in all
    r = estimate(tr.gyr, tr.acc, 1.0 / tr.rate_hz, mag=mag, frame="ENU")
    assert np.degrees(rmse(heading_error(r.q_b_n, tr.q_ref), tr.eval_mask)) < 4.0


def test_a_field_disturbed_in_the_final_rest_does_not_turn_the_offline_heading():
    """A recording that ends at rest beside a monitor or a steel desk (a field fixed in the room, +8, −5, 6 µT ENU,
    put in over the first second of BROAD 02's final rest): each pass learns the steady new field as its reference
    after mag_new_time and uses it, and the offline heading took its azimuth for magnetic north: 4.9° heading RMSE
    over the motion (online 1.35°, VQF offline 1.0°). The offline heading now takes only fields with the Earth's norm
    and dip (iframe.earth_like): 1.06°."""
    tr = load_broad(PATH)
    n = tr.gyr.shape[0]
    ramp = np.clip((np.arange(n) - np.flatnonzero(tr.movement)[-1]) / tr.rate_hz, 0.0, 1.0)
    ok = np.all(np.isfinite(tr.q_ref), axis=1)
    q = tr.q_ref[np.maximum.accumulate(np.where(ok, np.arange(n), 0))]  # the rest's attitude: the last optical one
    room = quat_rotate(quat_conjugate(q), np.broadcast_to([8.0, -5.0, 6.0], (n, 3)))
    mag = tr.mag + np.nan_to_num(ramp[:, None] * room)
    r = estimate(tr.gyr, tr.acc, 1.0 / tr.rate_hz, mag=mag, frame="ENU", offline=True)
    assert np.degrees(rmse(heading_error(r.q_b_n, tr.q_ref), tr.eval_mask)) < 1.3
