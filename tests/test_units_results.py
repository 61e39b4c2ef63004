"""Unit table, versioned JSON results and input validation."""

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st

from optinav import OptinavError
from optinav.core import units
from optinav.core.results import Result
from optinav.core.validate import as_float_array, check_timestamps, integration_steps, mask_runs


def test_unit_conversions_by_hand():
    assert units.to_si(0.005, "deg/h") == pytest.approx(0.005 * np.pi / 180 / 3600)
    assert units.to_si(0.0005, "deg/sqrt(h)") == pytest.approx(0.0005 * np.pi / 180 / 60)
    assert units.to_si(20, "ug") == pytest.approx(20e-6 * 9.80665)
    assert units.to_si(400, "μg/√Hz") == pytest.approx(400e-6 * 9.80665)
    assert units.to_si(2, "ppm") == pytest.approx(2e-6)
    assert units.to_si(1, "arcsec") == pytest.approx(np.pi / 180 / 3600)
    assert units.from_si(units.to_si(7.5, "deg/s"), "deg/s") == pytest.approx(7.5)
    with pytest.raises(OptinavError, match="unknown unit"):
        units.to_si(1.0, "furlong/fortnight")


@given(st.sampled_from(sorted(units.UNITS)), st.floats(-1e6, 1e6))
def test_unit_round_trip(unit, x):
    assert units.from_si(units.to_si(x, unit), unit) == pytest.approx(x, rel=1e-12, abs=1e-300)


@dataclasses.dataclass
class _Demo(Result):
    SCHEMA = "optinav.test_demo"
    VERSION = 1
    bias: np.ndarray = dataclasses.field(metadata={"unit": "m/s^2"})
    cost: float = dataclasses.field(metadata={"unit": "(m/s^2)^2"})
    name: str = "x"
    extra: dict = dataclasses.field(default_factory=dict)


def test_result_json_round_trip(tmp_path):
    r = _Demo(
        bias=np.array([1.0, -2.5, 3e-9]),
        cost=float("inf"),
        name="unit 7",
        extra={"hist": np.arange(3.0), "n": np.int64(4)},
    )
    path = tmp_path / "r.json"
    r.to_json(path)
    data = json.loads(path.read_text())
    assert data["schema"] == "optinav.test_demo" and data["version"] == 1
    assert data["fields"]["bias"]["unit"] == "m/s^2"
    back = Result.from_json(path)
    assert isinstance(back, _Demo)
    np.testing.assert_array_equal(back.bias, r.bias)
    assert back.cost == float("inf") and back.name == "unit 7"
    np.testing.assert_array_equal(back.extra["hist"], np.arange(3.0))


def test_result_json_errors(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(OptinavError, match="not valid JSON"):
        Result.from_json(p)
    with pytest.raises(OptinavError, match="does not exist"):
        Result.from_json(tmp_path / "missing.json")
    with pytest.raises(OptinavError, match="unknown result schema"):
        Result.from_json('{"schema": "nope", "version": 1, "fields": {}}')
    with pytest.raises(OptinavError, match="version 9"):
        Result.from_json('{"schema": "optinav.test_demo", "version": 9, "fields": {}}')
    with pytest.raises(OptinavError, match="incomplete"):
        Result.from_json('{"schema": "optinav.test_demo", "version": 1, "fields": {}}')


@pytest.mark.parametrize("cost", [2, -(2**63) - 1, 10**400], ids=["2", "below int64", "beyond a double"])
def test_a_whole_number_in_a_float_field_is_read_as_that_float(cost):
    """JSON writes 2.0 as 2: a float field takes a whole number as its float. One beyond int64 (-2⁶³ − 1, found by
    hypothesis in a damaged calibration's gravity) stayed a Python int and ended apply's np.isfinite in an internal
    TypeError; one beyond a double's range is refused naming the field."""
    text = json.dumps(
        {"schema": "optinav.test_demo", "version": 1, "fields": {"bias": {"value": [0.0]}, "cost": {"value": cost}}}
    )
    if cost == 10**400:
        with pytest.raises(OptinavError, match="'cost' is a number beyond a double's range"):
            Result.from_json(text)
        return
    back = Result.from_json(text)
    assert type(back.cost) is float and back.cost == float(cost) and np.isfinite(back.cost)


def test_timestamps_checks():
    check_timestamps([0.0, 0.1, 0.25])
    with pytest.raises(OptinavError, match="duplicate"):
        check_timestamps([0.0, 0.1, 0.1])
    with pytest.raises(OptinavError, match="not sorted"):
        check_timestamps([0.0, 0.2, 0.1])
    with pytest.raises(OptinavError, match="gap"):
        check_timestamps([0.0, 0.1, 0.2, 5.0], max_gap_factor=5)
    with pytest.raises(OptinavError, match="NaN"):
        check_timestamps([0.0, np.nan])
    with pytest.raises(OptinavError, match="at least"):
        check_timestamps([0.0])


def test_timestamp_steps_are_checked_across_blocks(monkeypatch):
    # the steps are checked a block at a time: a fault on either side of a block edge names its sample
    import optinav.core.validate as validate

    monkeypatch.setattr(validate, "_STEP_BLOCK", 4)
    for i in range(1, 12):
        t = np.arange(12.0)
        t[i] = t[i - 1]
        with pytest.raises(OptinavError, match=f"duplicate timestamp at index {i} "):
            check_timestamps(t)
        t = np.arange(12.0)
        t[i] = t[i - 1] - 0.5
        with pytest.raises(OptinavError, match=rf"not sorted: t\[{i}\]"):
            check_timestamps(t)
    np.testing.assert_array_equal(check_timestamps(np.arange(12.0)), np.arange(12.0))


def test_sorted_timestamps_are_told_without_their_steps(monkeypatch):
    """A log's usual timestamps (finite, strictly increasing) are told by one comparison per step, without the
    steps that the checks naming a fault compute (a diff and two masks: 11 ms of a 3.6 M-sample read); every fault
    is named as before, NaN and inf among them (a NaN fails the comparison, an inf can only be an end)."""
    import optinav.core.validate as validate

    monkeypatch.setattr(validate, "_STEP_BLOCK", 4)
    diffs = []
    diff = np.diff
    monkeypatch.setattr(np, "diff", lambda *a, **k: diffs.append(1) or diff(*a, **k))
    for t in (np.arange(12.0), 1e9 + 0.01 * np.arange(13.0), [0.0, 1.0], [5.0]):
        np.testing.assert_array_equal(check_timestamps(t, min_count=1), t)
    assert not diffs
    for t, what in (
        ([0.0, 1.0, 2.0, 3.0, np.inf], "1 NaN or infinite"),
        ([-np.inf, 0.0, 1.0], "1 NaN or infinite"),
        ([0.0, 1.0, np.nan, 3.0, 4.0, np.nan], "2 NaN or infinite"),
        ([np.nan], "1 NaN or infinite"),
        ([[0.0, 1.0], [2.0, 3.0]], "one-dimensional"),
        ([0.0, 1.0, 2.0, 3.0, 4.0, 4.0], "duplicate timestamp at index 5 "),
        ([0.0, 1.0, 2.0, 3.0, 2.5, 5.0], r"not sorted: t\[4\]"),
    ):
        with pytest.raises(OptinavError, match=what):
            check_timestamps(t)
    with pytest.raises(OptinavError, match="at least 3"):
        check_timestamps([0.0, 1.0], min_count=3)


def test_array_checks():
    with pytest.raises(OptinavError, match="shape"):
        as_float_array(np.zeros((4, 2)), "gyro", last_dims=(3,))
    with pytest.raises(OptinavError, match="not numeric"):
        as_float_array(["a", "b"], "gyro")


def test_check_positive():
    from optinav.core.validate import check_positive

    assert check_positive("2.5", "rate") == 2.5
    for bad in (None, "abc", 0, -1.0, float("inf"), float("nan")):
        with pytest.raises(OptinavError, match="positive finite"):
            check_positive(bad, "rate")


@given(
    rate=st.floats(20.0, 2000.0),
    tick=st.sampled_from([1e-3, 1e-4, 1.0 / 32768]),
    t0=st.floats(0.0, 1e5),
    n=st.integers(50, 2000),
)
@example(rate=128.0, tick=1e-3, t0=0.0, n=204)  # stamps exactly half a tick off the line: the band is q exactly
def test_integration_steps_undo_the_rounding_of_uniform_stamps(rate, tick, t0, n):
    """Uniform sampling, stamps rounded to a coarse tick: the steps are the true step within the fit's error
    (tick/n), not a tick off; the integral of a constant rate is the duration."""
    h = 1.0 / rate
    assume(tick < 0.6 * h)  # coarser ticks give duplicate stamps, which the readers refuse
    assume(not 0.009 * h < tick < 0.011 * h)  # the rule's edge (a tick of 1 % of the step) either way
    t = np.round((t0 + h * np.arange(n)) / tick) * tick
    s = integration_steps(t)
    assert s.shape == (n,)
    if tick >= 0.01 * h and len(np.unique(np.round(np.diff(t) / tick))) == 2:
        np.testing.assert_allclose(s, h, rtol=0, atol=2 * tick / n)
    else:  # a fine tick (or steps that are whole ticks) is left alone
        np.testing.assert_allclose(s[:-1], np.diff(t))


def test_integration_steps_keep_real_irregular_steps_and_gaps():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.009, 0.011, 500))  # real jitter, exact stamps: a random walk off any line
    np.testing.assert_array_equal(integration_steps(t)[:-1], np.diff(t))
    g = np.round(np.r_[np.arange(100), np.arange(106, 200)] / 102.4, 3)  # ms stamps and a 6-sample gap
    s = integration_steps(g)
    np.testing.assert_array_equal(s[:-1], np.diff(g))
    assert s[-1] == np.median(np.diff(g))  # the last sample: the median step, not a step past the end


def test_a_version_that_is_no_whole_number_is_named():
    """A result whose "version" is the text "5" said "version 5 is not supported (this optinav reads version 5)"."""
    from optinav.attitude import estimate

    w = np.zeros((200, 3))
    acc = np.tile([0.0, 0.0, -9.81], (200, 1))
    d = estimate(w, acc, 0.01).to_dict()
    d["version"] = str(d["version"])
    with pytest.raises(OptinavError, match=r"version '\d+' is not a whole number"):
        Result.from_dict(d)


@given(st.lists(st.booleans(), max_size=60))
def test_mask_runs_are_the_mask_s_true_runs(bits):
    """mask_runs (the runs of rests, still bins, gap-free pieces …, written out five times before) gives half-open
    ranges, each a maximal run of True, whose union is the mask."""
    m = np.array(bits, dtype=bool)
    runs = mask_runs(m)
    back = np.zeros(m.shape, bool)
    for s, e in runs:
        assert s < e and m[s:e].all()
        assert (s == 0 or not m[s - 1]) and (e == m.size or not m[e])
        back[s:e] = True
    assert np.array_equal(back, m)
