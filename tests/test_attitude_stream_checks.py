"""The streaming filters judge their inputs as estimate() does, once, on a stream's first seconds
(:class:`optinav.attitude.checks.StartChecks`): BROAD 02, 20 000 rows (70 s) from row 5000, ran with the gyro in
deg/s at 95.4°/99.9° inclination/heading RMSE and with the accelerometer in mg at 1.06°/7.2° (0.36°/0.72° right),
and on frame="ned" with ENU data, all without a word, where estimate() refused or warned."""

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from optinav.attitude import AttitudeFilter, estimate, make_filter
from optinav.attitude import checks as C
from optinav.attitude.data import BROAD_TRIAL_02, load_broad
from optinav.attitude.metrics import heading_error, inclination_error, rmse
from optinav.errors import OptinavError

SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
PATH = SHARED / BROAD_TRIAL_02
pytestmark = pytest.mark.skipif(not PATH.is_file(), reason=f"BROAD data absent ({PATH})")

CUT = slice(5000, 25000)
G = 9.80665


@pytest.fixture(scope="module")
def cut():
    t = load_broad(PATH)
    return t, t.gyr[CUT].copy(), t.acc[CUT].copy()


def _loop(f, g, a):
    """Feed ``f`` sample by sample; (samples used, the error) at the first refusal, else (len(g), None)."""
    for i in range(g.shape[0]):
        try:
            f.update(g[i], a[i])
        except OptinavError as exc:
            return i, exc
    return g.shape[0], None


def _rmse_deg(q, t):
    ref, mask = t.q_ref[CUT], t.eval_mask[CUT]
    return np.degrees(rmse(inclination_error(q, ref), mask)), np.degrees(rmse(heading_error(q, ref), mask))


@pytest.mark.parametrize(
    "case, words",
    [("deg/s gyro", "deg/s declared rad/s"), ("mg accelerometer", "accelerometer")],
)
@pytest.mark.parametrize("method", ["iframe", "mekf"])
def test_wrong_units_are_refused_by_update_batch_and_update(cut, case, words, method):
    t, g, a = cut
    if case == "deg/s gyro":
        g = np.degrees(g)
    else:
        a = a / G * 1000.0
    with pytest.raises(OptinavError, match=words):
        estimate(g, a, t.dt, method=method, frame="enu")
    new = lambda: make_filter(method, rate_hz=t.rate_hz, frame="enu")  # noqa: E731
    f = new()
    with pytest.raises(OptinavError, match=f"the stream's first .* s: .*{words}") as got:
        f.update_batch(g, a)
    assert f.q_b_n is None  # a first chunk longer than the checks' window: refused before any output
    assert "new filter" in str(got.value) and "\n" not in str(got.value)
    used, err = _loop(new(), g, a)
    assert err is not None and words in str(err)
    assert used * t.dt <= C.START_MAX_S  # within the first minute at most (here: 30 s and 20 s)


def test_a_refusal_stands_for_every_later_sample(cut):
    """A loop that skips refused samples (as it may a non-finite one) must not run on with the wrong unit."""
    t, g, a = cut
    g = np.degrees(g)
    f = AttitudeFilter(t.rate_hz, frame="enu")
    used, err = _loop(f, g, a)
    q = f.q_b_n
    for i in range(used, used + 50):
        with pytest.raises(OptinavError, match="deg/s declared rad/s"):
            f.update(g[i], a[i])
    with pytest.raises(OptinavError, match="deg/s declared rad/s"):
        f.update_batch(g[used:], a[used:])
    np.testing.assert_array_equal(f.q_b_n, q)  # no refused sample changed the state
    f.reset()  # the units are the sensor's: a new start keeps the refusal
    with pytest.raises(OptinavError, match="deg/s declared rad/s"):
        f.update(np.radians(g[used]), a[used])


def test_checks_false_runs_as_estimate_without_checks(cut):
    t, g, a = cut
    g = np.degrees(g)
    ref = estimate(g, a, t.dt, frame="enu", checks=False).q_b_n
    np.testing.assert_array_equal(AttitudeFilter(t.rate_hz, frame="enu", checks=False).update_batch(g, a).q_b_n, ref)


@pytest.mark.parametrize("chunk", [None, 1000, 1])
def test_a_frame_mismatch_warns_once(cut, chunk):
    """ENU data (body z up) declared NED: 180° off in inclination; the stream warns once, as estimate() does."""
    t, g, a = cut
    f = AttitudeFilter(t.rate_hz, frame="ned")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        if chunk == 1:
            assert _loop(f, g, a) == (g.shape[0], None)
        else:
            step = chunk or g.shape[0]
            for i in range(0, g.shape[0], step):
                f.update_batch(g[i : i + step], a[i : i + step])
    frame = [x for x in w if issubclass(x.category, C.FrameWarning)]
    assert len(frame) == 1 and "use --frame ENU" in str(frame[0].message)
    assert len(w) == 1


@pytest.mark.parametrize("method", ["iframe", "mekf", "gd"])
def test_data_that_pass_give_the_estimate_bit_for_bit(cut, method):
    """The checks change nothing: per sample, per chunk and estimate() agree exactly, at VQF's accuracy."""
    t, g, a = cut
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ref = estimate(g, a, t.dt, method=method, frame="enu").q_b_n
        f = make_filter(method, rate_hz=t.rate_hz, frame="enu")
        runs = [f.update_batch(g[i : i + 777], a[i : i + 777]).q_b_n for i in range(0, g.shape[0], 777)]
        np.testing.assert_array_equal(np.concatenate(runs), ref)
        unchecked = make_filter(method, rate_hz=t.rate_hz, frame="enu", checks=False)
        np.testing.assert_array_equal(unchecked.update_batch(g, a).q_b_n, ref)
        if method == "iframe":
            f = AttitudeFilter(t.rate_hz, frame="enu")
            q = np.empty_like(ref)
            for i in range(g.shape[0]):
                f.update(g[i], a[i])
                q[i] = f.q_b_n
            np.testing.assert_array_equal(q, ref)
    incl, head = _rmse_deg(ref, t)
    assert incl < {"iframe": 0.40, "mekf": 0.50, "gd": 0.70}[method]
    if method == "iframe":
        assert head < 0.80  # 0.36° / 0.72°


def test_the_inputs_are_judged_once(cut, monkeypatch):
    """One judgement, on the first seconds, then no check and no kept samples: one attribute test per sample."""
    t, g, a = cut
    calls = []
    real = C.imu_checks
    monkeypatch.setattr(C, "imu_checks", lambda *x, **k: calls.append(x[0].shape[0]) or real(*x, **k))
    f = AttitudeFilter(t.rate_hz, frame="enu")
    used = None
    for i in range(g.shape[0]):
        f.update(tuple(g[i]), tuple(a[i]))
        if used is None and f._checks is None:
            used = i + 1
    assert len(calls) == 1 and C.START_S <= used * t.dt <= C.START_MAX_S
    # a still start (here 25 s) is judged on its last START_S s, the turning that ended the wait in them: not all 30
    assert calls[0] < used and calls[0] <= C.START_S / t.dt + 2
    f = AttitudeFilter(t.rate_hz, frame="enu")
    f.update_batch(g, a)  # one chunk: judged on its first seconds only, as sample by sample
    assert calls == [calls[0]] * 2 and f._checks is None
