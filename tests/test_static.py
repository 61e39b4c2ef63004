"""Static-interval detection and manual section lists (optinav.multipos.static)."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from optinav.core.results import Result
from optinav.core.simulate import six_positions, static_positions
from optinav.errors import OptinavError
from optinav.multipos.static import (
    SectionList,
    StaticDetection,
    default_candidate,
    detect_static,
    detection_from_sections,
    moving_variance,
    noise_floor,
    sections_from_list,
    _rank,
    threshold_candidates,
)

DATA = (
    Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    / "imucal"
)


def _brute_variance(t, x, w):
    out = np.empty(t.size)
    for i in range(t.size):
        m = np.abs(t - t[i]) <= w / 2
        out[i] = x[m].var(axis=0).sum()
    return out


def test_moving_variance_matches_brute_force_on_irregular_time():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 1500))
    x = rng.normal(size=(1500, 3)) * [1.0, 2.0, 0.5] + [9.8, -300.0, 2048.0]  # large offsets: cancellation
    x[700:900] += np.linspace(0, 50, 200)[:, None]
    v = moving_variance(t, x, 0.37)
    ref = _brute_variance(t, x, 0.37)
    np.testing.assert_allclose(v, ref, rtol=1e-9, atol=1e-9)


def test_blocked_moving_variance_is_bit_identical_to_whole_array_sums(monkeypatch):
    """Blocks (here of 257 rows, so windows straddle many block edges) give exactly the whole-array result: the
    running sums continue sequentially from block to block."""
    from optinav.multipos import static as st

    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.005, 0.015, 3001))
    x = rng.normal(size=(3001, 3)) * [1.0, 2.0, 0.5] + [9.8, -300.0, 2048.0]
    half, slack = 0.5 * 0.37, 1e-9 * 0.37
    lo = np.searchsorted(t, t - half - slack, side="left")
    hi = np.searchsorted(t, t + half + slack, side="right")
    xc = x - x.mean(axis=0)
    c1 = np.vstack([np.zeros((1, 3)), np.cumsum(xc, axis=0)])
    c2 = np.vstack([np.zeros((1, 3)), np.cumsum(xc * xc, axis=0)])
    n = (hi - lo).astype(float)[:, None]
    mean = (c1[hi] - c1[lo]) / n
    ref = np.maximum(((c2[hi] - c2[lo]) / n - mean * mean).sum(axis=1), 0.0)
    monkeypatch.setattr(st, "_BLOCK", 257)
    v, resolution = st._moving_variance(t, x, 0.37)
    assert np.array_equal(v, ref)
    assert resolution == 8 * np.finfo(float).eps * c2[-1].sum() / n.min()


def _simulated_log(rng, *, jitter=False):
    """12 poses (the six axis poses, twice, with a 2 s turn between), 100 Hz, white noise."""
    C = np.concatenate(
        [six_positions(frame="enu"), six_positions(frame="enu")[[2, 3, 4, 5, 0, 1]]]
    )  # consecutive poses differ
    truth = static_positions(C, dwell=8.0, rate_hz=100.0, lat=0.8, transition=2.0, frame="enu")
    t = truth.t
    if jitter:  # irregular sampling: keep every sample with probability 0.9
        keep = rng.random(t.size) < 0.9
        keep[0] = keep[-1] = True
    else:
        keep = np.ones(t.size, bool)
    sa, sg = 0.02, 0.003  # m/s^2, rad/s per axis
    acc = truth.acc + rng.normal(scale=sa, size=truth.acc.shape)
    gyro = truth.gyr + rng.normal(scale=sg, size=truth.acc.shape)
    return t[keep], acc[keep], gyro[keep], truth.labels[keep], truth.acc[keep], sa


@pytest.mark.parametrize("jitter", [False, True])
def test_auto_detection_finds_every_pose_and_no_motion(jitter):
    rng = np.random.default_rng(11)
    t, acc, gyro, labels, f_true, sa = _simulated_log(rng, jitter=jitter)
    det = detect_static(t, acc, gyr=gyro)
    assert det.n_intervals == 12
    assert det.method == "auto"
    for k, (i0, i1) in enumerate(det.index_ranges):
        lab = labels[i0:i1]
        assert np.all(lab == lab[0]) and lab[0] >= 0, "motion leaked into a static interval"
        assert det.durations[k] >= 2.0
        # mean within 5 sigma of the truth (white noise sa per axis, n samples)
        n = i1 - i0
        assert np.all(np.abs(det.acc_means[k] - f_true[i0]) < 5 * sa / np.sqrt(n))
    # one interval per pose, each covering most of the 8 s dwell (trim 0.5 s + window edges)
    assert len({int(labels[i0]) for i0, _ in det.index_ranges}) == 12
    assert np.all(det.durations > 5.5)


def test_given_threshold_and_candidates_are_consistent():
    rng = np.random.default_rng(5)
    t, acc, gyro, labels, _, sa = _simulated_log(rng)
    cand = threshold_candidates(t, acc, gyr=gyro)
    # the at-rest total variance of white noise is 3 sa^2; the floor (a mode) is within 20% of it
    assert cand.noise_floor == pytest.approx(3 * sa**2, rel=0.2)
    k = cand.default_index
    det = detect_static(t, acc, gyr=gyro, threshold=cand.thresholds[k], gyro_threshold=cand.gyro_thresholds[k])
    np.testing.assert_array_equal(det.index_ranges, cand.default.index_ranges)
    assert det.method == "threshold"
    # larger thresholds never drop static samples
    st = cand.static_time_s
    assert np.all(np.diff(st) >= -1e-9)


@pytest.mark.parametrize("with_gyro", [True, False])
def test_candidates_without_variances_find_the_same_intervals(with_gyro):
    # keep_variance=False (calibrate: 2 B per row instead of 16) compares ranks, not variances: the same
    # intervals for every candidate, also for variances exactly at a threshold
    rng = np.random.default_rng(8)
    t, acc, gyro, *_ = _simulated_log(rng, jitter=True)
    gyr = gyro if with_gyro else None
    full = threshold_candidates(t, acc, gyr=gyr)
    lean = threshold_candidates(t, acc, gyr=gyr, keep_variance=False)
    for a, b in zip(full.detections, lean.detections, strict=True):
        np.testing.assert_array_equal(a.index_ranges, b.index_ranges)
        np.testing.assert_array_equal(a.acc_means, b.acc_means)
        assert b.acc_variance is None and b.gyro_variance is None
        assert a.threshold == b.threshold and a.gyro_threshold == b.gyro_threshold
    assert lean.default_index == full.default_index
    v = full.detections[0].acc_variance
    thr = np.sort(np.concatenate([full.thresholds, [v[5], v[500]]]))
    ranks = _rank(np.concatenate([v, thr]), thr)
    for j, th in enumerate(thr):
        np.testing.assert_array_equal(ranks <= j, np.concatenate([v, thr]) <= th)


def test_no_candidate_interval_error_is_the_same_without_variances():
    rng = np.random.default_rng(2)
    t = np.arange(3000) / 100.0
    acc = np.cumsum(rng.normal(size=(3000, 3)), axis=0)
    msgs = []
    for keep in (True, False):
        with pytest.raises(OptinavError) as e:
            threshold_candidates(t, acc, multipliers=[1e-9], keep_variance=keep)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1] and "median" in msgs[0]


def test_default_candidate_rule():
    # fragments (low), the stable plateau of 12, a merge (high): the plateau's middle
    assert default_candidate([3, 8, 12, 12, 12, 12, 12, 9, 9, 9, 9, 9, 9, 9]) == 4
    # a count seen once (borderline pause) is not trusted over a stable larger plateau
    assert default_candidate([10, 10, 10, 13, 10, 10, 11, 11, 11]) == 7
    # never prefers fewer intervals: the larger stable count wins over a longer smaller one
    assert default_candidate([6, 6, 6, 6, 6, 6, 6, 8, 8, 8]) == 8
    # nothing stable: largest threshold with the largest count
    assert default_candidate([1, 2, 3, 2]) == 2


def test_noise_floor_of_noise_free_data_is_finite():
    t = np.arange(2000) / 100.0
    acc = np.zeros((2000, 3))
    acc[:, 2] = 9.81
    acc[1000:1100, 0] = np.linspace(0, 3, 100)
    det = detect_static(t, acc, min_duration_s=1.0)
    assert det.n_intervals == 2
    assert det.threshold > 0 and np.isfinite(det.threshold)
    assert noise_floor(np.zeros(10)) > 0


def test_no_static_interval_reports_variance_levels():
    rng = np.random.default_rng(2)
    t = np.arange(3000) / 100.0
    acc = np.cumsum(rng.normal(size=(3000, 3)), axis=0)  # random walk: never at rest at these scales
    with pytest.raises(OptinavError) as e:
        detect_static(t, acc, threshold=1e-6, acc_unit="m/s^2")
    msg = str(e.value)
    assert "min" in msg and "median" in msg and "max" in msg and "(m/s^2)^2" in msg
    assert "--sections" in msg and "\n" not in msg


def test_bad_inputs_are_one_line_errors():
    t = np.arange(100) / 10.0
    acc = np.zeros((100, 3))
    with pytest.raises(OptinavError, match="shape"):
        detect_static(t, acc[:50])
    with pytest.raises(OptinavError, match="window_s"):
        detect_static(t, acc, window_s=8.0)
    with pytest.raises(OptinavError, match="gyro_threshold"):
        detect_static(t, acc, gyr=acc, gyro_threshold=1.0)
    with pytest.raises(OptinavError, match="sorted"):
        detect_static(t[::-1], acc)


def test_detection_result_json_round_trip(tmp_path):
    rng = np.random.default_rng(8)
    t, acc, gyro, *_ = _simulated_log(rng)
    det = detect_static(t, acc, gyr=gyro)
    det.to_json(tmp_path / "det.json")
    back = Result.from_json(tmp_path / "det.json")
    assert isinstance(back, StaticDetection)
    np.testing.assert_array_equal(back.index_ranges, det.index_ranges)
    np.testing.assert_allclose(back.acc_variance, det.acc_variance)
    assert back.threshold == det.threshold


# --- manual sections -----------------------------------------------------------------------------------


def test_sections_from_times_text_and_json(tmp_path):
    t = np.arange(1000) * 0.01  # 0 .. 9.99 s
    s = sections_from_list([(1.0, 2.0), (3.005, 4.5)], t)
    np.testing.assert_array_equal(s.index_ranges, [[100, 201], [301, 451]])
    np.testing.assert_allclose(s.t_intervals, [[1.0, 2.0], [3.01, 4.5]])
    p = tmp_path / "s.txt"
    p.write_text("# name start end\nup 1.0 2.0\n\ndown, 3.005, 4.5  # second\n")
    s2 = sections_from_list(p, t)
    assert s2.names == ["up", "down"]
    np.testing.assert_array_equal(s2.index_ranges, s.index_ranges)
    q = tmp_path / "s.json"
    q.write_text(json.dumps({"b": [3.005, 4.5], "a": [1.0, 2.0]}))  # named: sorted by start
    s3 = sections_from_list(q, t)
    assert s3.names == ["a", "b"]
    np.testing.assert_array_equal(s3.index_ranges, s.index_ranges)
    assert s3.as_dict() == {"a": (100, 201), "b": (301, 451)}


@pytest.mark.skipif(not DATA.is_dir(), reason="shared imucal data not available")
def test_sections_from_imucal_section_list():
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    t = np.arange(10376) / 102.4
    s = sections_from_list(DATA / "example_ferraris_session_list.json", t)
    assert s.names[:6] == ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"]
    for n, (i0, i1) in s.as_dict().items():
        assert (i0, i1) == (sec[n]["start"], sec[n]["end"])  # half-open, as imucal's iloc


def test_sample_indices_written_as_pairs_are_named(tmp_path):
    """imucal's section list written as pairs ({"x_p": [540, 1271]}) is read in seconds, and was refused only as
    'outside the log; give times in seconds'; the error now shows how sample indices are written."""
    t = np.arange(10376) / 102.4
    with pytest.raises(OptinavError, match=r'outside the log .* \{"x_p": \{"start": 540, "end": 1271\}\}'):
        sections_from_list({"x_p": [540, 1271]}, t)
    with pytest.raises(OptinavError) as e:
        sections_from_list({"x_p": [540.5, 1271]}, t)  # not whole: no such hint
    assert "start" not in str(e.value)


@pytest.mark.skipif(not DATA.is_dir(), reason="shared imucal data not available")
def test_imucal_section_list_the_other_way_round(tmp_path):
    """imucal's list as pandas writes the table pd.read_json(...).T reads it into ({"start": {name: i0}, "end":
    {name: i1}}) was refused as "section 'start' has no 'start'/'end' keys"; it is the same sections."""
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    other = tmp_path / "t.json"
    other.write_text(json.dumps({k: {n: v[k] for n, v in sec.items()} for k in ("start", "end")}))
    t = np.arange(10376) / 102.4
    assert (
        sections_from_list(other, t).as_dict()
        == sections_from_list(DATA / "example_ferraris_session_list.json", t).as_dict()
    )


@pytest.mark.parametrize(
    "sections, match",
    [
        ([(2.0, 1.0)], "start"),
        ([(1.0, 2.0), (1.5, 3.0)], "overlap"),
        ([(3.0, 4.0), (1.0, 2.0)], "time order"),
        ([(1.0, 20.0)], "outside"),
        ([(1.001, 1.009)], "no sample"),
        ([], "empty"),
        ({"a": {"start": 5, "end": 5}}, "empty or outside|not inside"),
        ({"a": {"start": 1.5, "end": 5}}, "sample indices"),
        ("9 10 11 12\n", "line 1"),
    ],
)
def test_section_validation_errors(sections, match):
    t = np.arange(1000) * 0.01
    with pytest.raises(OptinavError, match=match) as e:
        sections_from_list(sections, t)
    assert "\n" not in str(e.value)


def test_detection_from_manual_sections():
    t = np.arange(1000) * 0.01
    acc = np.zeros((1000, 3))
    acc[:500, 2], acc[500:, 2] = 9.81, -9.81
    det = detection_from_sections("up 1 4\ndown 6 9.5\n", t, acc, gyr=acc * 0)
    assert det.method == "manual" and det.names == ["up", "down"]
    np.testing.assert_array_equal(det.counts, [301, 351])
    np.testing.assert_allclose(det.acc_means[:, 2], [9.81, -9.81])


def test_section_list_result_round_trip(tmp_path):
    t = np.arange(1000) * 0.01
    s = sections_from_list({"a": (1.0, 2.0), "b": (3.0, 4.0)}, t)
    s.to_json(tmp_path / "s.json")
    back = Result.from_json(tmp_path / "s.json")
    assert isinstance(back, SectionList) and back.names == ["a", "b"]
    np.testing.assert_array_equal(back.index_ranges, s.index_ranges)


# --- real data -------------------------------------------------------------------------------------------


@pytest.mark.skipif(not DATA.is_dir(), reason="shared imucal data not available")
def test_real_ferraris_session_static_poses_found():
    d = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    acc = np.column_stack([d["acc_x"], d["acc_y"], d["acc_z"]])
    gyro = np.column_stack([d["gyr_x"], d["gyr_y"], d["gyr_z"]])
    t = np.arange(acc.shape[0]) / 102.4
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    det = detect_static(t, acc, gyr=gyro, acc_unit="m/s^2", gyro_unit="deg/s")
    # every hand-annotated static pose of imucal's example lies inside one detected interval ...
    for name in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a"):
        a, b = sec[name]["start"], sec[name]["end"]
        inside = [(i0 <= a) and (b <= i1) for i0, i1 in det.index_ranges]
        assert sum(inside) == 1, name
        k = inside.index(True)
        # ... whose mean agrees with the annotated section's to well below the static noise (0.02 m/s^2)
        assert np.all(np.abs(det.acc_means[k] - acc[a:b].mean(axis=0)) < 2e-3)
        assert np.all(np.abs(det.gyro_means[k] - gyro[a:b].mean(axis=0)) < 1e-2)
    # and no detected interval overlaps a rotation's turning phase (the 360 deg gyro integral there)
    for name in ("x_rot", "y_rot", "z_rot"):
        a, b = sec[name]["start"], sec[name]["end"]
        for i0, i1 in det.index_ranges:
            lo, hi = max(a, i0), min(b, i1)
            if hi > lo:
                assert np.abs(gyro[lo:hi]).max() < 5.0  # deg/s: a pause, not a turn
