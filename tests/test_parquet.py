"""Parquet files as input: the values written with pyarrow are the values read, whatever the column layout
(names, order, types, lists, structs, row groups, nulls), with units from the file's metadata."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import read_imu, read_table, write_imu


def _data(rng, n):
    t = 1000.0 + np.cumsum(rng.uniform(0.005, 0.015, n))
    return t, rng.normal(0, 3, (n, 3)), rng.normal(0, 0.5, (n, 3))


def test_plain_columns(tmp_path):
    t, acc, gyr = _data(np.random.default_rng(0), 500)
    tab = pa.table(
        {
            "t": t,
            **{f"a{a}": acc[:, j] for j, a in enumerate("xyz")},
            **{f"g{a}": gyr[:, j] for j, a in enumerate("xyz")},
            "note": ["x"] * 500,
        }
    )
    pq.write_table(tab, tmp_path / "d.parquet", row_group_size=77)
    log = read_imu(tmp_path / "d.parquet")
    assert np.array_equal(log.t, t) and np.array_equal(log.acc, acc) and np.array_equal(log.gyr, gyr)


def _layouts():
    """One column layout: how each triad is stored, alias names, float type, column order, row groups, extras."""
    triad = st.sampled_from(["columns", "list", "fixed_list", "struct"])
    return st.fixed_dictionaries(
        {
            "acc": triad,
            "gyro": triad,
            "acc_name": st.sampled_from(["acc", "accel", "linear_acceleration", "imu_acc"]),
            "gyro_name": st.sampled_from(["gyro", "gyr", "angular_velocity", "omega"]),
            "t_name": st.sampled_from(["t", "time", "timestamp", "Time [s]", "time_ms", "stamp_ts"]),
            "f32": st.booleans(),
            "order": st.permutations(range(4)),
            "group": st.integers(1, 60),
            "nulls": st.lists(st.integers(0, 39), max_size=3),
            "n": st.integers(2, 40),
            "extra": st.sampled_from([None, "string", "varlist", "int"]),
        }
    )


def _triad(layout, name, kind, v, ftype, pa_null):
    if kind == "columns":
        sep = "_" if len(name) > 3 else ""
        return [(f"{name}{sep}{a}", pa.array(v[:, j], type=ftype, mask=pa_null)) for j, a in enumerate("xyz")]
    if kind == "struct":
        arrs = [pa.array(v[:, j], type=ftype, mask=pa_null) for j in range(3)]
        return [(name, pa.StructArray.from_arrays(arrs, names=["x", "y", "z"]))]
    flat = pa.array(v.reshape(-1), type=ftype)
    if kind == "fixed_list":
        return [(name, pa.FixedSizeListArray.from_arrays(flat, 3))]
    return [(name, pa.ListArray.from_arrays(pa.array(np.arange(0, 3 * len(v) + 1, 3, dtype=np.int32)), flat))]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(layout=_layouts(), seed=st.integers(0, 2**31))
def test_odd_layouts_read_back(tmp_path, layout, seed):
    rng = np.random.default_rng(seed)
    n = layout["n"]
    t, acc, gyr = _data(rng, n)
    ftype = pa.float32() if layout["f32"] else pa.float64()
    if layout["f32"]:
        acc, gyr = acc.astype(np.float32).astype(float), gyr.astype(np.float32).astype(float)
    nulls = sorted({i for i in layout["nulls"] if i < n})
    mask = np.zeros(n, bool)
    mask[nulls] = True
    scale = 1e3 if layout["t_name"] == "time_ms" else 1.0
    if layout["t_name"] == "stamp_ts":
        t_col = pa.array((t * 1e9).astype(np.int64), type=pa.timestamp("ns"))
        t = (t * 1e9).astype(np.int64) * 1e-9
    else:
        t_col = pa.array(t * scale)
    acc_mask = mask if layout["acc"] in ("columns", "struct") else None
    groups = [
        [(layout["t_name"], t_col)],
        _triad(layout, layout["acc_name"], layout["acc"], acc, ftype, acc_mask),
        _triad(layout, layout["gyro_name"], layout["gyro"], gyr, ftype, None),
    ]
    extra = {
        "string": pa.array([f"s{i}" for i in range(n)]),
        "int": pa.array(np.arange(n)),
        "varlist": pa.array([[1.0] * (i % 3) for i in range(n)]),
    }.get(layout["extra"])
    groups.append([("comment", extra)] if extra is not None else [])
    cols = [c for k in layout["order"] for c in groups[k]]
    path = tmp_path / f"d{seed}.parquet"
    pq.write_table(pa.table(dict(cols)), path, row_group_size=layout["group"])
    log = read_imu(path, columns=None if layout["t_name"] != "stamp_ts" else "t=stamp_ts")
    np.testing.assert_allclose(log.t, t, rtol=1e-15, atol=0)
    expect = acc.copy()
    if acc_mask is not None:
        expect[mask] = np.nan
    assert np.array_equal(log.acc, expect, equal_nan=True)
    assert np.array_equal(log.gyr, gyr)
    assert log.nan_rows == (len(nulls) if acc_mask is not None else 0)


def test_units_from_metadata_and_rate(tmp_path):
    n = 200
    rng = np.random.default_rng(2)
    acc_g, gyr_dps = rng.normal(0, 1, (n, 3)), rng.normal(0, 30, (n, 3))
    fields = [pa.field(f"a{a}", pa.float64(), metadata={"unit": "g"}) for a in "xyz"]
    fields += [pa.field(f"g{a}", pa.float64(), metadata={"units": "deg/s"}) for a in "xyz"]
    schema = pa.schema(fields, metadata={"rate": "250"})
    tab = pa.table([*acc_g.T, *gyr_dps.T], schema=schema)
    pq.write_table(tab, tmp_path / "u.pq")
    log = read_imu(tmp_path / "u.pq")
    np.testing.assert_allclose(log.acc, acc_g * 9.80665, rtol=1e-15)
    np.testing.assert_allclose(log.gyr, np.deg2rad(gyr_dps), rtol=1e-15)
    np.testing.assert_allclose(log.t, np.arange(n) / 250.0)
    assert log.acc_input_unit == "g" and any("250 Hz" in x for x in log.notes)
    # a stated unit overrides the file's, with a note (a file in the wrong unit could not be read otherwise)
    over = read_imu(tmp_path / "u.pq", acc_unit="m/s^2")
    assert over.acc_input_unit == "m/s^2" and any("declare g; acc_unit=m/s^2 overrides that" in x for x in over.notes)


def test_positional_names_and_labels(tmp_path):
    n = 30
    rng = np.random.default_rng(3)
    m = rng.normal(size=(n, 7))
    m[:, 0] = np.arange(n) * 0.01
    tab = pa.table(
        {f"c{j}": m[:, j] for j in range(7)} | {"lab": pa.array(["p1"] * 10 + ["p2"] * 20).dictionary_encode()}
    )
    pq.write_table(tab, tmp_path / "p.parquet")
    log = read_imu(tmp_path / "p.parquet", columns="t,ax,ay,az,gx,gy,gz,label")
    assert np.array_equal(log.acc, m[:, 1:4]) and np.array_equal(log.gyr, m[:, 4:7])
    assert list(log.labels[:11]) == ["p1"] * 10 + ["p2"]
    with pytest.raises(OptinavError, match="columns names 3 column.* but p.parquet has 8"):
        read_imu(tmp_path / "p.parquet", columns="t,ax,ay")


def test_damaged_and_empty(tmp_path):
    t, acc, gyr = _data(np.random.default_rng(4), 100)
    pq.write_table(pa.table({"t": t, "ax": acc[:, 0], "ay": acc[:, 1], "az": acc[:, 2]}), tmp_path / "ok.parquet")
    raw = (tmp_path / "ok.parquet").read_bytes()
    (tmp_path / "cut.parquet").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(OptinavError, match="cut.parquet is not a readable Parquet file"):
        read_imu(tmp_path / "cut.parquet")
    pq.write_table(pa.table({"name": ["a", "b"]}), tmp_path / "text.parquet")
    with pytest.raises(OptinavError, match="has no accelerometer or gyroscope data"):
        read_imu(tmp_path / "text.parquet")
    pq.write_table(
        pa.table({"m": pa.array([{"k": 1}, {"k": 2}], type=pa.map_(pa.string(), pa.int64()))}), tmp_path / "map.parquet"
    )
    with pytest.raises(OptinavError, match=r"holds no numeric columns \(unreadable: .*map"):
        read_table(tmp_path / "map.parquet")


def test_cli_attitude_reads_parquet(tmp_path, capsys):
    """The same log as CSV and as Parquet gives the same attitude."""
    csv = tmp_path / "s.csv"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(csv),
                "--scheme",
                "six",
                "--dwell",
                "2",
                "--seed",
                "1",
            ]
        )
        == 0
    )
    log = read_imu(csv)
    pq.write_table(
        pa.table(
            {
                "time": log.t,
                "acc": pa.FixedSizeListArray.from_arrays(pa.array(log.acc.ravel()), 3),
                "gyro": pa.FixedSizeListArray.from_arrays(pa.array(log.gyr.ravel()), 3),
            }
        ),
        tmp_path / "s.parquet",
    )
    out = {}
    for name in ("s.csv", "s.parquet"):
        o = tmp_path / f"{name}.att.csv"
        assert main(["--quiet", "attitude", str(tmp_path / name), "--out", str(o)]) == 0
        out[name] = o.read_text().splitlines()[1:]
    assert out["s.csv"] == out["s.parquet"] and len(out["s.csv"]) > 100
    rt = tmp_path / "rt.npz"
    write_imu(rt, read_imu(tmp_path / "s.parquet"))
    assert np.array_equal(np.load(rt)["acc"], log.acc)
    json.dumps(log.notes)


def test_pandas_datetime_index_is_the_time(tmp_path):
    """A DataFrame with an unnamed DatetimeIndex written by pandas (stored as '__index_level_0__'): its
    timestamps are the samples' times in seconds since the epoch (was: no time column)."""
    pd = pytest.importorskip("pandas")
    rng = np.random.default_rng(4)
    vals = rng.normal(0, 1, (50, 6))
    df = pd.DataFrame(
        vals, columns=["ax", "ay", "az", "gx", "gy", "gz"], index=pd.date_range("2026-01-01", periods=50, freq="5ms")
    )
    df.to_parquet(tmp_path / "p.parquet")
    log = read_imu(tmp_path / "p.parquet")
    assert log.t[0] == pytest.approx(1767225600.0) and np.allclose(np.diff(log.t), 0.005, atol=1e-6)
    np.testing.assert_array_equal(log.acc, vals[:, :3])


def test_int64_nanoseconds_since_the_epoch(tmp_path):
    # a header stamp in ns as int64 (beyond 2**53): read as the nearest double, not Arrow's range error (traceback)
    rng = np.random.default_rng(7)
    n = 40
    ns = 1_700_000_000 * 10**9 + np.arange(n, dtype=np.int64) * 5_000_000 + 123
    acc, gyr = rng.normal(0, 3, (n, 3)), rng.normal(0, 0.5, (n, 3))
    cols = {f"linear_acceleration.{a}": acc[:, j] for j, a in enumerate("xyz")}
    cols.update({f"angular_velocity.{a}": gyr[:, j] for j, a in enumerate("xyz")})
    pq.write_table(pa.table({"header.stamp": pa.array(ns, pa.int64()), **cols}), tmp_path / "ns.parquet")
    log = read_imu(tmp_path / "ns.parquet")
    assert np.array_equal(log.t, ns.astype(float) * 1e-9)
    assert np.array_equal(log.acc, acc) and np.array_equal(log.gyr, gyr)
    # under a name that states no unit: the error names --time-unit ns
    pq.write_table(pa.table({"t": pa.array(ns, pa.int64()), **cols}), tmp_path / "t.parquet")
    with pytest.raises(OptinavError, match="--time-unit ns"):
        read_imu(tmp_path / "t.parquet")
    assert np.array_equal(read_imu(tmp_path / "t.parquet", time_unit="ns").t, ns.astype(float) * 1e-9)


def test_field_paths_as_plotjuggler_names_them(tmp_path):
    # /imu/angular_velocity/x named only 'x' (no triad found) and /imu/orientation/w the gyroscope triad ('w': a
    # shape error); the axis is now read with its field, in Parquet and in text
    rng = np.random.default_rng(8)
    t, acc, gyr = _data(rng, 60)
    cols = {"__time": t}
    cols.update({f"/imu/angular_velocity/{a}": gyr[:, j] for j, a in enumerate("xyz")})
    cols.update({f"/imu/linear_acceleration/{a}": acc[:, j] for j, a in enumerate("xyz")})
    cols.update({f"/imu/orientation/{a}": np.full(60, 0.5) for a in "wxyz"})
    pq.write_table(pa.table(cols), tmp_path / "pj.parquet")
    np.savetxt(
        tmp_path / "pj.csv", np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments=""
    )
    for name in ("pj.parquet", "pj.csv"):
        log = read_imu(tmp_path / name)
        assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc), name


def test_ros2_stamp_as_sec_and_nanosec(tmp_path):
    # a ROS 2 export's stamp in two integer columns (flat, or a header struct): refused as a file without time
    # ("pass --rate"), which would have thrown the stamps away; now sec + nanosec·1e-9, as a bag's stamp is read
    rng = np.random.default_rng(9)
    n = 120
    ns = 1_700_000_000 * 10**9 + np.cumsum(rng.integers(4_000_000, 6_000_000, n))
    sec, nsec = ns // 10**9, ns % 10**9
    _, acc, gyr = _data(rng, n)
    vec = {
        f"{q}.{a}": v[:, j]
        for q, v in (("angular_velocity", gyr), ("linear_acceleration", acc))
        for j, a in enumerate("xyz")
    }
    flat = {"header.stamp.sec": pa.array(sec, pa.int32()), "header.stamp.nanosec": pa.array(nsec, pa.uint32()), **vec}
    header = pa.array([{"stamp": {"sec": int(s), "nanosec": int(f)}, "frame_id": "imu"} for s, f in zip(sec, nsec)])
    pq.write_table(pa.table(flat), tmp_path / "flat.parquet", row_group_size=50)
    pq.write_table(pa.table({"header": header, **vec}), tmp_path / "struct.parquet")
    # bare sec and nanosec: 'sec' alone was the time, whole seconds (a duplicate-timestamp error)
    bare = {"sec": pa.array(sec, pa.int32()), "nanosec": pa.array(nsec, pa.uint32()), **vec}
    pq.write_table(pa.table(bare), tmp_path / "bare.parquet")
    for name in ("flat.parquet", "struct.parquet", "bare.parquet"):
        log = read_imu(tmp_path / name)
        assert np.array_equal(log.t, sec + nsec * 1e-9), name
        assert np.array_equal(log.acc, acc) and np.array_equal(log.gyr, gyr)


@pytest.mark.parametrize("fixed", [True, False])
def test_a_null_list_is_a_missing_sample(tmp_path, fixed):
    # one null row in the gyroscope's list column left the whole column out with no word (read_imu: no gyroscope)
    rng = np.random.default_rng(10)
    t, acc, gyr = _data(rng, 80)
    typ = pa.list_(pa.float64(), 3) if fixed else pa.list_(pa.float64())
    rows = gyr.tolist()
    rows[7] = rows[40] = None
    tab = pa.table({"t": t, "gyro": pa.array(rows, typ), "acc": pa.array(acc.tolist(), typ)})
    pq.write_table(tab, tmp_path / "n.parquet", row_group_size=30)
    expect = gyr.copy()
    expect[[7, 40]] = np.nan
    log = read_imu(tmp_path / "n.parquet")
    assert np.array_equal(log.gyr, expect, equal_nan=True) and np.array_equal(log.acc, acc) and log.nan_rows == 2
    from optinav.io import iter_imu

    blocks = list(iter_imu(tmp_path / "n.parquet", chunk_rows=25))
    assert np.array_equal(np.concatenate([b.gyr for b in blocks]), expect, equal_nan=True)


def test_an_unreadable_triad_column_is_named(tmp_path):
    # a gyroscope list column of varying length was left out as unreadable with no word: read without a gyroscope
    rng = np.random.default_rng(11)
    t, acc, gyr = _data(rng, 40)
    rows = gyr.tolist()
    rows[7] = rows[7][:2]
    tab = pa.table({"t": t, "gyro": pa.array(rows, pa.list_(pa.float64())), "acc": pa.array(acc.tolist())})
    pq.write_table(tab, tmp_path / "v.parquet")
    with pytest.raises(OptinavError, match="'gyro' looks like the gyroscope but cannot be read .lists of varying"):
        read_imu(tmp_path / "v.parquet")
    log = read_imu(tmp_path / "v.parquet", columns="t,_,acc")
    assert log.gyr is None and np.array_equal(log.acc, acc)
