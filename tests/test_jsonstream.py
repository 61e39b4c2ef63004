"""Long JSON arrays read block by block (optinav.core.jsonstream, TruthSeriesReader): the skeleton parses to the
file's value with the long arrays as markers, and each array's blocks join to its elements, whatever the
layout, the block size and the strings around them."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import optinav.core.jsonstream as js
from optinav.core.results import Parameter, Truth, TruthSeriesReader, TruthSeriesWriter
from optinav.errors import OptinavError


def _restore(value, regions, path):
    """``value`` with every marker replaced by its array parsed from the file."""
    if isinstance(value, dict):
        return {k: _restore(v, regions, path) for k, v in value.items()}
    if isinstance(value, list):
        return [_restore(v, regions, path) for v in value]
    if isinstance(value, str) and value in regions:
        r = regions[value]
        return json.loads(path.read_bytes()[r.start : r.end + 1])
    return value


def _rows(path, region, step):
    rows = js.ArrayRows(path, region)
    parts = []
    while len(got := rows.take(step)):
        parts.append(got)
    rows.close()
    return np.concatenate(parts) if parts else np.empty(0)


_STRINGS = st.text(alphabet=st.sampled_from(list('ab[]{},"\\: \n') + ["é", "\u2028"]), max_size=12)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    n=st.integers(0, 60),
    width=st.sampled_from([0, 1, 4]),
    nulls=st.booleans(),
    label=_STRINGS,
    indent=st.sampled_from([None, 0, 2]),
    block=st.sampled_from([7, 64, 1 << 23]),
    step=st.integers(1, 25),
)
def test_blocks_join_to_the_parsed_file(tmp_path, monkeypatch, n, width, nulls, label, indent, block, step):
    monkeypatch.setattr(js, "_BLOCK", block)
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, width) if width else n) * 10.0 ** rng.integers(-30, 30)
    v = a.tolist()
    if nulls and n:
        (v[0] if width else v).__setitem__(0, None)
    doc = {
        label: {"x": label, "nested": [[1, 2], {label: [3]}]},
        "parameters": {"q": {"value": v, "unit": label}, "k": {"value": [1.5, 2.5], "unit": "-"}},
        "after": [label, "]"],
    }
    path = tmp_path / "x.json"
    path.write_text(json.dumps(doc, indent=indent), encoding="utf-8")
    data, regions = js.skeleton(path, depth=4, min_bytes=1)
    assert _restore(data, regions, path) == doc
    q = data["parameters"]["q"]["value"]
    assert q in regions and data["parameters"]["k"]["value"] in regions
    got = _rows(path, regions[q], step)
    want = np.array([np.nan if x is None else x for x in v] if not width else v, dtype=float)
    assert got.shape == (want.shape if n else (0,)) and np.array_equal(got, want.reshape(got.shape), equal_nan=True)


def test_short_arrays_stay_in_place(tmp_path):
    path = tmp_path / "x.json"
    path.write_text(json.dumps({"a": {"b": {"c": [1.0, 2.0]}}, "z": [3.0]}))
    assert js.skeleton(path, depth=4) == ({"a": {"b": {"c": [1.0, 2.0]}}, "z": [3.0]}, {})


@pytest.mark.parametrize("bad", ['[1.0, "x"]', "[[1.0, 2.0], [3.0]]", "[[1.0, 2.0], [3.0, [4.0]]]"])
def test_a_bad_array_is_a_one_line_error(tmp_path, bad):
    path = tmp_path / "x.json"
    path.write_text('{"p": {"q": {"value": ' + bad + "}}}")
    data, regions = js.skeleton(path, depth=4, min_bytes=1)
    with pytest.raises(OptinavError) as exc:
        _rows(path, regions[data["p"]["q"]["value"]], 10)
    assert "\n" not in str(exc.value)


def test_truth_series_reader_equals_the_whole_truth(tmp_path, monkeypatch):
    """A truth written by TruthSeriesWriter (series one row per line) and by Truth.to_json (indented): the reader
    gives the other parameters as Truth.from_json does and the series' rows in blocks."""
    monkeypatch.setattr(js, "_BLOCK", 4096)
    rng = np.random.default_rng(1)
    q, yaw = rng.normal(size=(5000, 4)), rng.normal(size=5000)
    q[7, 2] = np.nan
    with TruthSeriesWriter(tmp_path / "w.truth.json", "attitude", {"q_b_n": "-", "yaw": "rad"}, {"seed": 3}) as w:
        for a in range(0, 5000, 999):
            w.write(q_b_n=q[a : a + 999], yaw=yaw[a : a + 999])
    Truth(
        "attitude",
        {"q_b_n": Parameter(q, "-"), "yaw": Parameter(yaw, "rad"), "gyr_bias": Parameter(np.ones(3) * 1e-3, "rad/s")},
        {"seed": 3},
    ).to_json(tmp_path / "t.truth.json")
    for name in ("w.truth.json", "t.truth.json"):
        whole = Truth.from_json(tmp_path / name)
        reader = TruthSeriesReader(tmp_path / name, ("q_b_n", "yaw", "roll"))
        assert set(reader.rows) == {"q_b_n", "yaw"} and reader.truth.info == whole.info
        for k, p in whole.parameters.items():
            got = reader.truth.parameters[k]
            assert got.unit == p.unit and (k in reader.rows or np.array_equal(got.value, p.value))
        parts = [reader.take("q_b_n", 1234) for _ in range(5)]
        assert np.array_equal(np.concatenate(parts), np.asarray(whole.parameters["q_b_n"].value), equal_nan=True)
        assert reader.take("yaw", 10).tolist() == yaw[:10].tolist() and reader.count_rest("yaw") == 4990
        reader.close()


def test_attitude_unit_scores_a_long_truth_read_in_blocks(tmp_path, monkeypatch):
    """batch attitude's unit: the truth comparison of a streamed truth (series over several JSON blocks) equals
    the comparison with the truth read whole; a truth shorter than the log is a one-line error."""
    import optinav.core.files
    from optinav.attitude.unit import AttitudeOptions, run_unit
    from optinav.cli.main import main

    data = tmp_path / "f.csv"
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "30", "--out", str(data)]) == 0
    monkeypatch.setattr(optinav.core.files, "CHUNK_ROWS", 700)
    whole, _ = run_unit(data, AttitudeOptions(), reference=True)
    monkeypatch.setattr(js, "_BLOCK", 5000)
    blocks, _ = run_unit(data, AttitudeOptions(), reference=True)
    assert "q_b_n" in TruthSeriesReader(tmp_path / "f.truth.json", ("q_b_n",)).rows  # read in blocks
    assert blocks.truth_comparison.keys() == whole.truth_comparison.keys() and "roll" in whole.truth_comparison
    for k, c in whole.truth_comparison.items():
        if "rmse" in c:
            assert blocks.truth_comparison[k]["rmse"] == pytest.approx(c["rmse"], rel=1e-12)
    tp = tmp_path / "f.truth.json"
    truth = Truth.from_json(tp)
    truth.parameters["roll"] = Parameter(np.asarray(truth.parameters["roll"].value)[:-5], "rad")
    truth.to_json(tp)
    with pytest.raises(OptinavError, match="the truth.s roll has 2996 samples, the log at least 3001"):
        run_unit(data, AttitudeOptions(), reference=True)


# --- writing: json_text is json.dumps, the long lists of numbers joined ----------------------------------------

_NUMBER = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False), st.integers(-(2**70), 2**70), st.none(), st.booleans()
)
_ROWS = st.lists(st.one_of(_NUMBER, st.lists(_NUMBER, max_size=4)), min_size=28, max_size=40)
_JSON = st.recursive(
    st.one_of(_NUMBER, _STRINGS, st.just("@@optinav-numbers:0@@"), _ROWS),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(_STRINGS, inner, max_size=4),
    max_leaves=12,
)


@settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(_JSON, st.sampled_from([0, 1, 2, 4, None, "\t"]))
def test_json_text_is_json_dumps_byte_for_byte(data, indent):
    """The long lists of plain numbers (a result's arrays, where json's indented encoder took ~2 µs a number) are
    joined from their reprs, at any depth and indentation; lists with booleans, strings holding the placeholder
    and the rest go through json.dumps: the same text either way."""
    from optinav.core.files import json_text

    assert json_text(data, indent) == json.dumps(data, indent=indent, allow_nan=False)


def test_json_text_refuses_what_json_dumps_refuses():
    from optinav.core.files import json_text

    for bad in ([1.0] * 40 + [float("nan")], {"a": [[1.0, 2.0]] * 40 + [[float("inf"), 0.0]]}):
        with pytest.raises(ValueError, match="Out of range float values are not JSON compliant"):
            json_text(bad)


def test_the_depth_limit_of_json_inputs_counts_the_numbers_in_the_deepest_list():
    """parse_json walks only the containers now: a number in a list at the deepest level allowed (64) is one level
    too deep, as before; that list empty, or its number one level up, is read."""
    from optinav.core.files import MAX_JSON_DEPTH, parse_json

    def nested(depth, leaf):
        return "[" * (depth - 1) + leaf + "]" * (depth - 1)

    assert parse_json(nested(MAX_JSON_DEPTH, "[]"), "x", "") is not None
    assert parse_json(nested(MAX_JSON_DEPTH, "1"), "x", "") is not None
    for text in (nested(MAX_JSON_DEPTH, "[1]"), nested(MAX_JSON_DEPTH + 1, "[]"), nested(MAX_JSON_DEPTH, '{"a": 1}')):
        with pytest.raises(OptinavError, match="nested more than 64 levels deep"):
            parse_json(text, "x", "")
    assert parse_json("1.5", "x", "") == 1.5
