"""optinav.io: table readers (text, NPZ, HDF5, MATLAB v5/v7.3), read_imu, write_imu and their errors."""

import math
import re
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optinav.core.units import G_STANDARD
from optinav.errors import OptinavError
from optinav.io import ImuLog, read_imu, read_table, write_imu
from optinav.io.imu import TIME_UNITS
from optinav.io.readers import iter_table, load_table

try:
    import h5py
except ImportError:  # the hdf5 extra is optional
    h5py = None
needs_h5py = pytest.mark.skipif(h5py is None, reason="h5py not installed")

SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
IMUCAL = SHARED / "imucal"


def _log(n=50, seed=0, counts=False, labels=False):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.015, n))  # irregular steps
    acc = rng.normal(0, 5, (n, 3))
    gyro = rng.normal(0, 1, (n, 3))
    if counts:
        acc, gyro = np.round(acc * 400), np.round(gyro * 900)
    lab = np.repeat(np.array(["x_p", "x_a", "z_rot"]), -(-n // 3))[:n] if labels else None
    return ImuLog(
        t=t,
        acc=acc,
        gyr=gyro,
        acc_unit="counts" if counts else "m/s^2",
        gyro_unit="counts" if counts else "rad/s",
        labels=lab,
        sample=np.arange(n) + 7,
    )


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def _same(a: ImuLog, b: ImuLog):
    assert np.array_equal(a.t, b.t)
    for name in ("acc", "gyr"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None)
        if x is not None:
            np.testing.assert_array_equal(x, y)
    assert a.acc_unit == b.acc_unit and a.gyro_unit == b.gyro_unit
    if a.labels is not None:
        assert list(map(str, a.labels)) == list(map(str, b.labels))
    if a.sample is not None:
        np.testing.assert_array_equal(a.sample, b.sample)


# --- write/read round trips -----------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".csv", ".tsv", ".txt", ".npz", ".mat", pytest.param(".h5", marks=needs_h5py)])
@pytest.mark.parametrize("counts", [False, True])
def test_round_trip_every_format(tmp_path, suffix, counts):
    log = _log(counts=counts, labels=True)
    path = write_imu(tmp_path / f"log{suffix}", log)
    back = read_imu(path)
    _same(log, back)
    assert back.n_rows_read == 50 and back.nan_rows == 0
    assert back.acc_input_unit == ("counts" if counts else "m/s^2")
    assert not list(tmp_path.glob(".*tmp*"))  # the atomic write left nothing behind


def test_round_trip_keeps_nan_rows_and_units_on_output(tmp_path):
    log = _log()
    log.acc[3, 1] = np.nan
    log.gyr[10, 2] = np.inf
    log.gyr[3, 0] = np.nan  # same row as the acc NaN: counted once
    log.nan_rows = 2
    back = read_imu(write_imu(tmp_path / "x.csv", log, acc_unit="g", gyro_unit="deg/s"))
    assert back.nan_rows == 2 and back.acc_input_unit == "g" and back.gyro_input_unit == "deg/s"
    np.testing.assert_allclose(back.acc, log.acc, rtol=1e-15)
    np.testing.assert_allclose(back.gyr, log.gyr, rtol=1e-15)
    assert np.isnan(back.acc[3, 1]) and np.isinf(back.gyr[10, 2])
    text = (tmp_path / "x.csv").read_text().splitlines()
    assert text[1] == "# units: t=s acc=g gyro=deg/s" and text[2] == "t,sample,ax,ay,az,gx,gy,gz"
    over = read_imu(tmp_path / "x.csv", acc_unit="m/s^2")  # the option overrides the file's line, with a note
    np.testing.assert_allclose(over.acc, log.acc / G_STANDARD, rtol=1e-15)
    assert any("declare g; acc_unit=m/s^2 overrides that" in n for n in over.notes), over.notes


def test_write_refuses_bad_requests(tmp_path):
    with pytest.raises(OptinavError, match="cannot be written in g"):
        write_imu(tmp_path / "x.csv", _log(counts=True), acc_unit="g")
    with pytest.raises(OptinavError, match="unknown file type .xlsx"):
        write_imu(tmp_path / "x.xlsx", _log())
    bad = _log(labels=True)
    bad.labels = bad.labels.astype("<U8")
    bad.labels[0] = "a,b"
    with pytest.raises(OptinavError, match="label 'a,b' cannot be written"):
        write_imu(tmp_path / "x.csv", bad)
    back = read_imu(write_imu(tmp_path / "x.npz", bad))  # NPZ keeps any label text
    assert back.labels[0] == "a,b"


def test_imulog_json_and_select():
    log = _log(labels=True)
    log.acc[5, 0] = np.nan
    log.nan_rows = 1
    back = ImuLog.from_json(log.to_json())
    _same(log, back)
    part = log.select(log.labels == "x_a")
    assert len(part) == np.count_nonzero(log.labels == "x_a") and part.nan_rows == 0
    assert log.select(slice(0, 10)).nan_rows == 1
    assert log.select(np.array([1, 5, 9])).sample.tolist() == [8, 12, 16]
    assert "50 samples" in log.summary()
    with pytest.raises(OptinavError, match="not increasing"):
        log.select(np.array([3, 1]))
    with pytest.raises(OptinavError, match="expected \\(50, 3\\)"):
        ImuLog(t=log.t, acc=log.acc[:-1])


# --- text tables ----------------------------------------------------------------------------------------------

ROWS = [[0.0, 1.5, -2.0, 9.81], [0.01, 1.25, -2.5, 9.8], [0.02, 1.0, 3e-3, -9.75]]


@pytest.mark.parametrize("delim", [",", "\t", ";", " ", "   "])
@pytest.mark.parametrize("header", [True, False])
def test_text_delimiters_and_header_detection(tmp_path, delim, header):
    lines = ["# exported by a logger", ""] + ([delim.join(["time", "acc_x", "acc_y", "acc_z"])] if header else [])
    lines += [delim.join(repr(v) for v in r) for r in ROWS]
    path = _write(tmp_path / "d.txt", "\r\n".join(lines) + "\n")
    table = read_table(path)
    names = ["time", "acc_x", "acc_y", "acc_z"] if header else ["col1", "col2", "col3", "col4"]
    assert list(table) == names
    np.testing.assert_array_equal(np.column_stack([table[n] for n in names]), ROWS)
    log = read_imu(path, columns=None if header else "t,ax,ay,az")
    np.testing.assert_array_equal(log.acc, np.asarray(ROWS)[:, 1:])
    np.testing.assert_array_equal(log.t, np.asarray(ROWS)[:, 0])
    assert log.gyr is None


def test_explicit_delimiter_and_positional_columns(tmp_path):
    path = _write(tmp_path / "d.dat", "a|b|c|d\n" + "\n".join("|".join(map(str, r)) for r in ROWS) + "\n")
    table = read_table(path, delimiter="|", columns="t,_,x,-")
    assert list(table) == ["t", "x"] and table["x"].tolist() == [-2.0, -2.5, 3e-3]
    assert read_table(path, delimiter="|", columns="ax=c")["ax"].tolist() == [-2.0, -2.5, 3e-3]
    with pytest.raises(OptinavError, match="delimiter '5' is not usable"):
        read_table(path, delimiter="5")


def test_aliases_are_recognised(tmp_path):
    header = "Timestamp [ms],Gyro_X,gyr.y,omega-z,AccX,accel_y,a_z,n_samples,Section"
    rows = ["0,1,2,3,4,5,6,10,a", "20,1,2,3,4,5,6,11,a", "40,1,2,3,4,5,6,12,b"]
    log = read_imu(_write(tmp_path / "a.csv", "\n".join([header, *rows])))
    np.testing.assert_allclose(log.t, [0, 0.02, 0.04], rtol=0, atol=1e-17)  # ms from the header
    np.testing.assert_array_equal(log.acc, [[4, 5, 6]] * 3)
    np.testing.assert_array_equal(log.gyr, [[1, 2, 3]] * 3)
    assert log.sample.tolist() == [10, 11, 12] and log.labels.tolist() == ["a", "a", "b"]
    # a name implying its unit and a mapping entry
    log = read_imu(
        _write(tmp_path / "b.csv", "time_us,w_x,w_y,w_z,zeit\n0,1,2,3,5\n500,1,2,3,5.05\n"),
        columns="t=zeit",
        gyro_unit="deg/s",
    )
    assert log.t.tolist() == [5.0, 5.05] and log.acc is None
    np.testing.assert_allclose(log.gyr[0], np.deg2rad([1, 2, 3]), rtol=1e-15)
    log = read_imu(tmp_path / "b.csv")
    assert log.t.tolist() == [0.0, 500e-6]


def test_units_convert_to_si_and_counts_are_kept(tmp_path):
    path = _write(tmp_path / "u.csv", "t,ax,ay,az,gx,gy,gz\n0,1,0,-1,180,0,-90\n0.01,0.5,2,0,360,1,0\n")
    log = read_imu(path, acc_unit="g", gyro_unit="deg/s")
    assert log.acc[0, 0] == G_STANDARD == 9.80665 and log.acc[0, 2] == -9.80665
    assert log.gyr[0, 0] == pytest.approx(math.pi, rel=1e-15) and log.gyr[1, 0] == pytest.approx(2 * math.pi)
    assert (log.acc_unit, log.gyro_unit, log.acc_input_unit, log.gyro_input_unit) == ("m/s^2", "rad/s", "g", "deg/s")
    raw = read_imu(path, acc_unit="counts", gyro_unit="counts")
    assert raw.acc_unit == raw.gyro_unit == "counts" and raw.gyr[0, 0] == 180.0 and raw.acc[1, 0] == 0.5
    si = read_imu(path)
    assert si.acc[0, 0] == 1.0 and si.gyr[0, 0] == 180.0  # defaults m/s^2, rad/s: no conversion
    assert read_imu(path, time_unit="ms").t.tolist() == [0.0, 1e-5]
    assert read_imu(path, acc_unit="mg").acc[1, 0] == pytest.approx(0.5e-3 * 9.80665, rel=1e-15)
    for kw, accepted in (
        ({"acc_unit": "ug"}, "counts, g, mg, m/s\\^2"),
        ({"gyro_unit": "deg/h"}, "counts, deg/s, mdps, rad/s"),
        ({"time_unit": "min"}, "s, ms, us, ns"),
    ):
        with pytest.raises(OptinavError, match=f"unknown {next(iter(kw))} .*use one of: {accepted}"):
            read_imu(path, **kw)


def test_text_errors_name_the_line_and_column(tmp_path):
    head = "t,ax,ay,az\n0,1,2,3\n"
    cases = {
        "1,1,2\n": "line 3 has 3 field\\(s\\), 4 expected \\(truncated",
        "1,1,2,3,4\n": "line 3 has 5 field\\(s\\), 4 expected \\(too long",
        "1,1,abc,3\n": "line 3, column 3 \\('ay'\\): 'abc' is not a number",
        "# note\n\n1;1;2;3\n": "line 5 has 1 field",
    }
    for i, (tail, msg) in enumerate(cases.items()):
        with pytest.raises(OptinavError, match=msg):
            read_imu(_write(tmp_path / f"e{i}.csv", head + tail))
    assert read_table(_write(tmp_path / "dc.csv", "a;b\n1;2,5\n3;4\n"))["b"].tolist() == [2.5, 4.0]  # ';' and ','
    with pytest.raises(OptinavError, match="is empty"):
        read_table(_write(tmp_path / "empty.csv", ""))
    with pytest.raises(OptinavError, match="no data rows"):
        read_table(_write(tmp_path / "c.csv", "# only\n\n"))
    with pytest.raises(OptinavError, match="header but no data rows"):
        read_table(_write(tmp_path / "h.csv", "t,ax\n"))
    with pytest.raises(OptinavError, match="does not exist"):
        read_table(tmp_path / "missing.csv")
    with pytest.raises(OptinavError, match="unknown data file type .xls; use one of .csv"):
        (tmp_path / "x.xls").write_bytes(bytes(range(256)) * 4)  # binary under a suffix optinav does not read
        read_table(tmp_path / "x.xls")
    assert read_table(_write(tmp_path / "y.xls", "a,b\n1,2\n"))["b"].tolist() == [2.0]  # text: read as text
    with pytest.raises(OptinavError, match="columns names 3 column\\(s\\) but .* has 4"):
        read_imu(tmp_path / "e0.csv", columns="t,ax,ay")
    with pytest.raises(OptinavError, match="header names column 't' twice"):
        read_table(_write(tmp_path / "dup.csv", "t,t\n1,2\n"))
    with pytest.raises(OptinavError, match="looks binary"):
        read_table(_write(tmp_path / "bin.csv", "1,2\x00"))


def test_empty_cells_are_nan_and_counted(tmp_path):
    path = _write(
        tmp_path / "n.csv",
        "t,ax,ay,az,gx,gy,gz\n0,1,,3,1,1,1\n.01,1,2,3,nan,1,1\n.02,1,2,3,1,1,1\n.03,inf,2,3,1,1,nan\n",
    )
    log = read_imu(path)
    assert log.nan_rows == 3 and len(log) == 4 and log.finite.tolist() == [False, False, True, False]
    assert np.isnan(log.acc[0, 1])


@pytest.mark.parametrize("compiled", [False, True])
def test_value_checks_are_the_same_through_the_compiled_interleave(tmp_path, monkeypatch, compiled):
    # long columns are interleaved by a compiled kernel that also returns their range (no min/max passes, no
    # finite count when all are finite); here every column takes that path, with the same results and errors
    import optinav.io.imu as imu

    if compiled:
        monkeypatch.setattr(imu, "_COMPILED_ROWS", 2)
    head = "t,ax,ay,az,gx,gy,gz\n"
    log = read_imu(
        _write(tmp_path / "n.csv", head + "0,1,,3,1,1,1\n.01,1,2,3,nan,1,1\n.02,1,2,3,1,1,1\n.03,inf,2,3,1,1,nan\n")
    )
    assert log.nan_rows == 3 and log.finite.tolist() == [False, False, True, False]
    log = read_imu(_write(tmp_path / "ok.csv", head + "0,1,2,3,4,5,6\n.01,-1,-2,-3,-4,-5,-6\n"), gyro_unit="deg/s")
    assert log.nan_rows == 0 and log.acc.flags.c_contiguous
    np.testing.assert_array_equal(log.acc, [[1, 2, 3], [-1, -2, -3]])
    np.testing.assert_allclose(log.gyr, np.radians([[4, 5, 6], [-4, -5, -6]]), rtol=1e-15)
    with pytest.raises(OptinavError, match="'gy' holds 1e\\+308 in data row 2"):
        read_imu(_write(tmp_path / "h.csv", head + "0,1,2,3,4,5,6\n1,1,2,3,4,1e308,6\n"))
    with pytest.raises(OptinavError, match="'ay' holds no number"):
        read_imu(_write(tmp_path / "e.csv", head + "0,1,,3,4,5,6\n1,1,nan,3,4,5,6\n"))


def test_gyro_triad_built_beside_the_acc_one(tmp_path, monkeypatch):
    # long separate columns: the gyro triad is interleaved by a helper thread while this one does the acc's; the
    # same log as in turn (no helper: one CPU)
    import optinav.io._pool as pool
    import optinav.io.imu as imu

    monkeypatch.setattr(imu, "_COMPILED_ROWS", 2)
    rng = np.random.default_rng(4)
    v = rng.normal(size=(50, 6))
    v[7, 4] = np.nan
    rows = "".join(f"{0.01 * i}," + ",".join(repr(float(x)) for x in r) + "\n" for i, r in enumerate(v))
    path = _write(tmp_path / "g.csv", "t,ax,ay,az,gx,gy,gz\n" + rows)
    jobs = []
    real = pool.helper()

    class Spy:
        def submit(self, fn, *args):
            jobs.append(fn.__name__)
            return real.submit(fn, *args)

    monkeypatch.setattr(pool, "helper", lambda: Spy())
    log = read_imu(path)
    assert jobs == ["_triad"] and log.nan_rows == 1
    np.testing.assert_array_equal(log.gyr, v[:, 3:])
    np.testing.assert_array_equal(log.acc, v[:, :3])
    monkeypatch.setattr(pool, "helper", lambda: None)
    one = read_imu(path)
    np.testing.assert_array_equal(one.gyr, log.gyr)
    assert one.nan_rows == 1


@pytest.mark.parametrize("compiled", [False, True])
def test_value_checks_are_the_same_for_n_by_3_arrays(tmp_path, monkeypatch, compiled):
    # an (n, 3) array (or a bag's columns, views of one) has its range taken in one compiled pass when long; here
    # every array takes that path, with the same counts and errors as numpy's min and max
    import optinav.io.imu as imu

    if compiled:
        monkeypatch.setattr(imu, "_COMPILED_ROWS", 2)
    t = np.arange(4) * 0.01
    gyr = np.ones((4, 3))
    acc = np.array([[1.0, np.nan, 3], [1, 2, 3], [1, 2, 3], [np.inf, 2, 3]])
    np.savez(tmp_path / "n.npz", t=t, acc=acc, gyr=gyr)
    log = read_imu(tmp_path / "n.npz")
    assert log.nan_rows == 2 and log.finite.tolist() == [False, True, True, False]
    np.savez(tmp_path / "ok.npz", t=t, acc=-acc[[1, 1, 2, 2]], gyr=gyr)
    assert read_imu(tmp_path / "ok.npz").nan_rows == 0
    acc[2, 1] = -1e308
    np.savez(tmp_path / "h.npz", t=t, acc=acc, gyr=gyr)
    with pytest.raises(OptinavError, match="holds -1e\\+308 in data row 3"):
        read_imu(tmp_path / "h.npz")


@given(st.lists(st.sampled_from([0.0, -1.5, 2.0, 1e300, -1e300, np.inf, -np.inf, np.nan]), min_size=3, max_size=30))
def test_interleave_kernel_range_and_layout(values):
    from optinav.io._colkernels import interleave3
    from optinav.io.imu import _range

    v = np.array(values[: len(values) // 3 * 3]).reshape(3, -1)
    out = np.empty((v.shape[1], 3))
    lo, hi = interleave3(v[0], v[1], v[2], out)
    np.testing.assert_array_equal(out, v.T)
    long = np.tile(out, (-(-(1 << 18) // max(out.shape[0], 1)), 1))  # a triad long enough for the quick range
    if out.shape[0]:
        assert np.array_equal(_range(long), (lo, hi), equal_nan=True)
    if np.isnan(v).any():
        assert np.isnan(lo) and np.isnan(hi)
    else:
        assert (lo, hi) == (v.min(), v.max())


def test_missing_columns_and_time_errors(tmp_path):
    with pytest.raises(OptinavError, match="found ax \\('acc_x'\\), ay \\('acc_y'\\) but no az column"):
        read_imu(_write(tmp_path / "a.csv", "t,acc_x,acc_y\n0,1,2\n1,1,2\n"))
    with pytest.raises(OptinavError, match="no accelerometer or gyroscope data .*found: t, temp"):
        read_imu(_write(tmp_path / "b.csv", "t,temp\n0,1\n1,2\n"))
    nt = _write(tmp_path / "c.csv", "sample,ax,ay,az\n5,1,2,3\n6,1,2,3\n")
    with pytest.raises(OptinavError, match="has no time column .*pass --rate HZ"):
        read_imu(nt)
    log = read_imu(nt, rate_hz=50)
    assert log.t.tolist() == [0.0, 0.02] and log.sample.tolist() == [5, 6]
    with pytest.raises(OptinavError, match="rate_hz must be a positive"):
        read_imu(nt, rate_hz=-1)
    with pytest.raises(OptinavError, match="has a time column \\('t'\\) and rate_hz=50"):
        read_imu(_write(tmp_path / "r.csv", "t,ax,ay,az\n0,1,2,3\n1,1,2,3\n"), rate_hz=50)
    with pytest.raises(OptinavError, match="not sorted: t\\[2\\]"):
        read_imu(_write(tmp_path / "u.csv", "t,ax,ay,az\n0,1,2,3\n2,1,2,3\n1,1,2,3\n"))
    with pytest.raises(OptinavError, match="duplicate timestamp"):
        read_imu(_write(tmp_path / "d.csv", "t,ax,ay,az\n0,1,2,3\n0,1,2,3\n"))
    with pytest.raises(OptinavError, match="NaN or infinite"):
        read_imu(_write(tmp_path / "f.csv", "t,ax,ay,az\n0,1,2,3\n,1,2,3\n2,1,2,3\n"))
    with pytest.raises(OptinavError, match="'time' and 'timestamp' both look like 't'"):
        read_imu(_write(tmp_path / "g.csv", "time,timestamp,ax,ay,az\n0,0,1,2,3\n1,1,1,2,3\n"))
    with pytest.raises(OptinavError, match="has no column named 'nope' \\(found: t, acc_x, acc_y\\)"):
        read_imu(tmp_path / "a.csv", columns="t=nope")
    with pytest.raises(OptinavError, match="'foo' is not a standard name"):
        read_imu(tmp_path / "a.csv", columns="foo=t")


def test_label_column_text_is_kept_elsewhere_refused(tmp_path):
    body = "x_p,0,1,2,3\nx_p,.01,1,2,3\nz_rot,.02,1,2,3\n"
    log = read_imu(_write(tmp_path / "l.csv", "part,t,ax,ay,az\n" + body))
    assert log.labels.tolist() == ["x_p", "x_p", "z_rot"]
    # text in a column read_imu does not take is left out with a note (a frame id beside the values)
    log = read_imu(_write(tmp_path / "k.csv", "kind,t,ax,ay,az\n" + body))
    assert log.labels is None and any("'kind' hold text and were left out" in n for n in log.notes)
    with pytest.raises(OptinavError, match="line 2, column 2 \\('ax'\\): 'x_p' is not a number"):
        read_imu(_write(tmp_path / "x.csv", "t,ax,ay,az\n0,x_p,2,3\n.01,1,2,3\n"))
    # positional names: the text column skipped or named as labels, without a header
    log = read_imu(_write(tmp_path / "n.csv", body), columns="_,t,ax,ay,az")
    assert log.labels is None and len(log) == 3
    assert read_imu(tmp_path / "n.csv", columns="section,t,ax,ay,az").labels[-1] == "z_rot"
    assert read_imu(tmp_path / "k.csv", columns="label=kind").labels.tolist() == ["x_p", "x_p", "z_rot"]
    with pytest.raises(OptinavError, match="line 3 has 4 field\\(s\\), 5 expected"):
        read_imu(_write(tmp_path / "r.csv", "part,t,ax,ay,az\nx_p,0,1,2,3\nx_p,1,1,2\nz_rot,2,1,2,3\n"))
    quoted = read_imu(_write(tmp_path / "q.csv", 'part,t,ax,ay,az\n"a, b",0,1,2,3\nc,.01,1,2,3\n'))
    assert quoted.labels.tolist() == ["a, b", "c"]
    numeric = read_imu(_write(tmp_path / "i.csv", "label,t,ax,ay,az\n-1,0,1,2,3\n4,.01,1,2,3\n"))
    assert numeric.labels.dtype.kind == "i" and numeric.labels.tolist() == [-1, 4]


def test_a_gyro_file_on_its_own_time_stamps_is_interpolated_onto_the_accelerometers(tmp_path):
    """Phones and apps log each sensor to its own file at its own times (Sensor Logger, phyphox): a gyro file whose
    times were not the accelerometer's was refused ("resample both files onto the same time stamps", with no tool
    for it). The gyro is interpolated linearly onto the accelerometer's times — a smooth rate to its interpolation
    error —, the accelerometer rows outside the gyro's span are left out, and a note says so; a gap in the gyro
    and files that do not overlap are refused."""
    ta = np.arange(0.0, 2.0, 0.01)  # 100 Hz
    tg = np.arange(0.0037, 2.05, 1 / 190.0)  # 190 Hz, another phase, starts later and ends later

    def rate(t):
        return np.column_stack([np.sin(2 * t), np.cos(3 * t), 0.5 * t])

    acc_rows = "\n".join(f"{float(t)!r},0,0,9.81" for t in ta)
    acc = _write(tmp_path / "Accelerometer.csv", "t,ax,ay,az\n" + acc_rows + "\n")
    gyr = _write(tmp_path / "Gyroscope.csv", "time,gx,gy,gz\n" + "\n".join(f"{float(t)!r},{float(a)!r},{float(b)!r},{float(c)!r}" for t, (a, b, c) in zip(tg, rate(tg))) + "\n")  # fmt: skip
    log = read_imu(acc, gyro_path=gyr)
    kept = ta[ta >= tg[0]]
    np.testing.assert_array_equal(log.t, kept)
    h = 1 / 190.0  # linear interpolation error ≤ h²/8 · max|second derivative| (9 for cos 3t)
    np.testing.assert_allclose(log.gyr, rate(kept), atol=h * h / 8 * 9 + 1e-12)
    assert log.acc.shape == (kept.size, 3)
    assert any("interpolated onto the time stamps of Accelerometer.csv (100 Hz); 1 accelerometer rows" in n for n in log.notes), log.notes  # fmt: skip
    gap = _write(tmp_path / "gap.csv", "t,gx,gy,gz\n" + "\n".join(f"{float(t)!r},1,2,3" for t in tg if not 0.8 < t < 1.0) + "\n")  # fmt: skip
    with pytest.raises(OptinavError, match="the gyroscope has no sample from t = 0.79.* s to 1.00.* s"):
        read_imu(acc, gyro_path=gap)
    late = _write(tmp_path / "late.csv", "t,gx,gy,gz\n" + "\n".join(f"{float(t) + 5!r},1,2,3" for t in tg) + "\n")
    with pytest.raises(OptinavError, match="do not overlap"):
        read_imu(acc, gyro_path=late)


def test_two_files_share_the_time_column(tmp_path):
    acc = _write(tmp_path / "acc.csv", "t,ax,ay,az\n0,1,2,3\n0.01,1,2,3\n0.02,1,2,3\n")
    gyr = _write(tmp_path / "gyr.csv", "time,gx,gy,gz\n0,4,5,6\n0.01,4,5,6\n0.02,4,5,7\n")
    log = read_imu(acc, gyro_path=gyr, gyro_unit="deg/s")
    np.testing.assert_allclose(log.gyr[2], np.deg2rad([4, 5, 7]), rtol=1e-15)
    assert log.acc[0].tolist() == [1, 2, 3] and " + " in log.source
    # positional names for the gyro file without a header
    gyr2 = _write(tmp_path / "g2.txt", "0 4 5 6\n0.01 4 5 6\n0.02 4 5 7\n")
    assert read_imu(acc, gyro_path=gyr2, gyro_columns="t,gx,gy,gz").gyr[2, 2] == 7
    # a gyro on its own clock is interpolated onto the accelerometer's times (tests below); without times the
    # files must hold the same samples
    short = _write(tmp_path / "short.txt", "4 5 6\n4 5 6\n")
    with pytest.raises(OptinavError, match="acc.csv has 3 rows but short.txt has 2"):
        read_imu(acc, gyro_path=short, gyro_columns="gx,gy,gz")
    with pytest.raises(OptinavError, match="has no gyroscope data"):
        read_imu(acc, gyro_path=acc)
    with pytest.raises(OptinavError, match="gyro_columns was given without gyro_path"):
        read_imu(acc, gyro_columns="t,gx,gy,gz")


# --- NPZ, HDF5, MATLAB ----------------------------------------------------------------------------------------


def test_npz_named_arrays_single_table_and_pickles(tmp_path):
    t = np.arange(5) * 0.1
    data = np.column_stack([t, np.ones((5, 3)), np.zeros((5, 3))])
    np.savez(tmp_path / "one.npz", data=data)
    table = read_table(tmp_path / "one.npz")
    assert list(table) == [f"col{j}" for j in range(1, 8)]
    log = read_imu(tmp_path / "one.npz", columns="t,ax,ay,az,gx,gy,gz")
    np.testing.assert_array_equal(log.t, t)
    assert read_table(tmp_path / "one.npz", columns="x=data")["x"].shape == (5, 7)
    with pytest.raises(OptinavError, match="columns names 3 column\\(s\\) but 'data' .* has 7"):
        read_imu(tmp_path / "one.npz", columns="t,ax,ay")
    np.save(tmp_path / "acc.npy", np.ones((5, 3)))  # a single triad named like one
    assert read_imu(tmp_path / "acc.npy", rate_hz=10).acc.shape == (5, 3)
    np.savez(tmp_path / "named.npz", time=t, accelerometer=np.ones((5, 3)), temp=np.arange(5.0))
    log = read_imu(tmp_path / "named.npz", acc_unit="g")
    assert log.acc[0, 0] == G_STANDARD and log.gyr is None
    with pytest.raises(OptinavError, match="positional column names do not apply"):
        read_imu(tmp_path / "named.npz", columns="t,ax,ay,az")
    np.savez(tmp_path / "t3.npz", t=t[:3], acc=np.ones((3, 5)))
    with pytest.raises(OptinavError, match="'acc' has shape \\(3, 5\\), expected \\(N, 3\\) \\(transpose it\\)"):
        read_imu(tmp_path / "t3.npz")
    np.savez(tmp_path / "p.npz", t=t, acc=np.array([object()] * 5, dtype=object))
    with pytest.raises(OptinavError, match="array 'acc' is pickled"):
        read_imu(tmp_path / "p.npz")
    (tmp_path / "fake.npz").write_bytes(b"not a zip\x00\x01")
    with pytest.raises(OptinavError, match="not NPZ .*signature"):
        read_table(tmp_path / "fake.npz")
    _write(tmp_path / "text.npz", "not a table")  # text under .npz is read as text, and says so when it fails
    with pytest.raises(OptinavError, match="no data rows .*holds text despite its .npz suffix"):
        read_table(tmp_path / "text.npz")


@pytest.mark.parametrize("suffix", [".npz", ".npy", ".h5"])
def test_streamed_text_under_a_binary_suffix_says_so(tmp_path, suffix):
    """The block reader (apply/attitude stream through it) gives the whole-file reader's one-line hint."""
    p = tmp_path / f"log{suffix}"
    _write(p, "not a table")
    with pytest.raises(OptinavError, match=f"no data rows .*holds text despite its \\{suffix} suffix") as e:
        list(iter_table(p))
    assert str(e.value).count("despite its") == 1 and "\n" not in str(e.value)
    _write(p, "t,ax\n0,1\n0.1,x\n")  # a bad cell in a later line: the block parser's error carries the hint too
    with pytest.raises(OptinavError, match="holds text despite its"):
        list(iter_table(p, chunk_rows=1))
    _write(tmp_path / "ok.csv", "not a table")  # a text suffix: no hint
    with pytest.raises(OptinavError) as e:
        list(iter_table(tmp_path / "ok.csv"))
    assert "despite" not in str(e.value)


@needs_h5py
def test_hdf5_datasets_and_tables(tmp_path):
    t = np.arange(6) * 0.01
    with h5py.File(tmp_path / "a.h5", "w") as f:
        g = f.create_group("imu")
        g["time"] = t
        g["acc"] = np.full((6, 3), 2.0)
        g["acc"].attrs["unit"] = "g"
        g["gyro_raw"] = np.full((6, 3), 5.0)
        f["camera"] = np.zeros((6, 2, 2))
    log = read_imu(tmp_path / "a.h5")
    assert log.acc[0, 0] == 2 * G_STANDARD and log.acc_input_unit == "g" and log.gyr is None
    log = read_imu(
        tmp_path / "a.h5", datasets={"t": "/imu/time", "acc": "imu/acc", "gyro": "imu/gyro_raw"}, gyro_unit="counts"
    )
    assert log.gyro_unit == "counts" and log.gyr[0, 0] == 5
    with pytest.raises(OptinavError, match="no dataset 'imu/gyro' \\(datasets: camera, imu/acc, imu/gyro_raw, imu/t"):
        read_imu(tmp_path / "a.h5", datasets="t=imu/time,gyro=imu/gyro")
    # read_imu and read_table share the datasets rules: names must be mapped, each once
    with pytest.raises(OptinavError, match="datasets must map names"):
        read_imu(tmp_path / "a.h5", datasets="t")
    with pytest.raises(OptinavError, match="maps 't' twice"):
        read_imu(tmp_path / "a.h5", datasets="t=imu/time,t=imu/acc")
    with h5py.File(tmp_path / "b.hdf5", "w") as f:
        f["log"] = np.column_stack([t, np.ones((6, 6))])
    assert read_imu(tmp_path / "b.hdf5", columns="t,gx,gy,gz,ax,ay,az").gyr.shape == (6, 3)
    rec = np.zeros(6, dtype=[("t", "f8"), ("ax", "f4"), ("ay", "f4"), ("az", "f4")])
    rec["t"], rec["az"] = t, 9.81
    with h5py.File(tmp_path / "c.h5", "w") as f:
        f["data"] = rec  # a compound dataset is a table with named columns
    assert read_imu(tmp_path / "c.h5").acc[0, 2] == pytest.approx(9.81, rel=1e-7)
    (tmp_path / "bad.h5").write_bytes(b"garbage\x00")
    with pytest.raises(OptinavError, match="not a readable HDF5 file"):
        read_table(tmp_path / "bad.h5")


def test_missing_h5py_is_a_clear_error(tmp_path, monkeypatch):
    import sys

    (tmp_path / "x.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100))
    monkeypatch.setitem(sys.modules, "h5py", None)  # makes "import h5py" raise ImportError
    with pytest.raises(OptinavError, match="needs h5py.*pip install 'optinav\\[hdf5\\]'"):
        read_table(tmp_path / "x.h5")


def test_mat_v5_variables_structs_and_single_matrix(tmp_path):
    import scipy.io

    t = np.arange(4) * 0.05
    scipy.io.savemat(
        tmp_path / "a.mat",
        {
            "imu": {"t": t.reshape(-1, 1), "gyr": np.ones((4, 3))},
            "gyro_unit": "deg/s",
            "part": np.array(["a", "a", "b", "b"], dtype=object),
        },
    )
    log = read_imu(tmp_path / "a.mat")
    np.testing.assert_array_equal(log.t, t)
    assert log.gyro_input_unit == "deg/s" and log.gyr[0, 0] == pytest.approx(math.pi / 180)
    assert log.labels.tolist() == ["a", "a", "b", "b"]
    assert read_imu(tmp_path / "a.mat", columns="t=imu.t,gyro=imu/gyr", gyro_unit="deg/s").gyr.shape == (4, 3)
    scipy.io.savemat(tmp_path / "m.mat", {"M": np.column_stack([t, np.zeros((4, 3))])})
    log = read_imu(tmp_path / "m.mat", columns="t,ax,ay,az")
    np.testing.assert_array_equal(log.t, t)
    _write(tmp_path / "bad.mat", "MATLAB 5.0 MAT-file but not really")
    with pytest.raises(OptinavError, match="not a readable MATLAB file"):
        read_table(tmp_path / "bad.mat")


def _write_mat73(path: Path, variables: dict) -> None:
    """A MATLAB v7.3 file as MATLAB lays it out: HDF5 with a 512-byte user block holding the 128-byte MAT header,
    column-major data (so h5py sees every matrix transposed), MATLAB_class attributes, chars as uint16 and cell
    arrays as object references into '#refs#'."""
    with h5py.File(path, "w", userblock_size=512) as f:
        refs = f.create_group("#refs#")

        def char(group, name, text):
            ds = group.create_dataset(name, data=np.array([[ord(c)] for c in text], dtype=np.uint16))
            ds.attrs["MATLAB_class"] = np.bytes_("char")
            return ds

        for name, value in variables.items():
            if isinstance(value, str):
                char(f, name, value)
            elif isinstance(value, list):  # cell array of strings, a MATLAB 1×n cell
                r = [char(refs, f"{name}{i}", s).ref for i, s in enumerate(value)]
                ds = f.create_dataset(name, data=np.array(r, dtype=h5py.ref_dtype).reshape(-1, 1))
                ds.attrs["MATLAB_class"] = np.bytes_("cell")
            else:
                a = np.asarray(value, dtype=float)
                a = a.reshape(-1, 1) if a.ndim == 1 else a  # a MATLAB column vector
                ds = f.create_dataset(name, data=a.T)
                ds.attrs["MATLAB_class"] = np.bytes_("double")
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + bytes(8) + b"\x00\x02IM")


@needs_h5py
def test_mat_v73_is_read_transposed_back(tmp_path):
    t = np.arange(5) * 0.1
    acc = np.arange(15.0).reshape(5, 3)
    _write_mat73(tmp_path / "v73.mat", {"t": t, "acc": acc, "acc_unit": "g", "labels": ["a", "b", "b", "c", "c"]})
    log = read_imu(tmp_path / "v73.mat")
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.acc, acc * G_STANDARD)  # rows are samples again
    assert log.acc_input_unit == "g" and log.labels.tolist() == ["a", "b", "b", "c", "c"]
    _write_mat73(tmp_path / "tab.mat", {"data": np.column_stack([t, acc])})
    assert read_table(tmp_path / "tab.mat", columns="t,ax,ay,az")["ay"].tolist() == acc[:, 1].tolist()


@needs_h5py
def test_mat_v73_objects_name_the_matlab_lines_that_save_their_numbers(tmp_path, capsys):
    """MATLAB Mobile's sensor log saved with -v7.3 keeps each sensor as a timetable, a MATLAB object (MCOS): a dataset
    of uint32 (0xDD000000, dims, object id, class id) with MATLAB_class 'timetable' and MATLAB_object_decode 3, its
    content in '#subsystem#' (matio's mat73 reader; MATLAB's v7.3 layout). Its metadata was read as the data:
    "'Acceleration' has shape (6,), expected (N, 3)". Now, as a v5 file's objects, one line naming them and the MATLAB
    lines that save plain arrays (which read)."""
    from optinav.cli.main import main

    path = tmp_path / "sensorlog_20240501_100000.mat"
    _write_mat73(path, {"note": "phone"})
    with h5py.File(path, "r+") as f:
        for i, name in enumerate(("Acceleration", "AngularVelocity"), 1):
            ds = f.create_dataset(name, data=np.array([[0xDD000000, 2, 1, 1, i, 1]], dtype=np.uint32).T)
            ds.attrs["MATLAB_class"] = np.bytes_("timetable")
            ds.attrs["MATLAB_object_decode"] = np.int32(3)
        f.create_dataset("#subsystem#/MCOS", data=np.zeros((4, 1), np.uint32)).attrs["MATLAB_class"] = np.bytes_(
            "FileWrapper__"
        )
    for cmd in (["allan"], ["calibrate", "accel"], ["attitude"]):
        out = tmp_path / ("o.csv" if cmd == ["attitude"] else "o.json")
        assert main([*cmd, str(path), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "holds MATLAB objects" in err[0] and "Acceleration (timetable)" in err[0], err
        assert "acc = Acceleration{:,:}; save('acc.mat','t','acc')" in err[0] and "--gyro gyro.mat" in err[0]
    with pytest.raises(OptinavError, match="AngularVelocity .timetable."):
        read_imu(path, datasets={"gyro": "AngularVelocity"})
    t = np.arange(5) * 0.01
    acc = np.arange(15.0).reshape(5, 3)
    _write_mat73(tmp_path / "acc.mat", {"t": t, "acc": acc})  # what the MATLAB lines save (-v7.3 too)
    log = read_imu(tmp_path / "acc.mat")
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.acc, acc)


# --- real data ------------------------------------------------------------------------------------------------


def _shared(name: str) -> Path:
    path = IMUCAL / name
    if not path.is_file():
        pytest.skip(f"shared data {path} not available (set OPTINAV_SHARED_DATA)")
    return path


def test_real_ferraris_session():
    log = read_imu(_shared("example_ferraris_session.csv"), rate_hz=102.4, gyro_unit="deg/s")
    assert log.acc.shape == log.gyr.shape == (10376, 3) and log.nan_rows == 0
    assert log.acc[0, 0] == 10.332114257812501 and log.acc[0, 2] == 0.51732421875
    assert log.gyr[0, 0] == pytest.approx(-0.6103515625 * math.pi / 180, rel=1e-15)
    assert log.t[-1] == pytest.approx(10375 / 102.4) and log.sample[-1] == 10375
    assert log.acc_unit == "m/s^2" and log.gyro_input_unit == "deg/s"


@pytest.mark.parametrize("name", ["LOG0001", "imu.out", "run.raw"])
def test_a_text_log_under_no_table_suffix_is_read_by_its_content(tmp_path, name):
    """A logger's file under no suffix or one optinav does not know was "unknown data file type (none)": a user
    had to rename it. Text by its first bytes, it reads as its .csv copy does; a binary file (or text with more
    than a serial capture's noise of control bytes) under such a name is still refused with the list of formats."""
    src = _shared("example_ferraris_session.csv")
    (tmp_path / name).write_bytes(src.read_bytes())
    log = read_imu(tmp_path / name, rate_hz=102.4, gyro_unit="deg/s")
    ref = read_imu(src, rate_hz=102.4, gyro_unit="deg/s")
    for k in ("t", "acc", "gyr"):
        np.testing.assert_array_equal(getattr(log, k), getattr(ref, k))
    # a result, a configuration or notes passed as data are refused by their suffix, as before, not parsed
    (tmp_path / "r.json").write_text('{"schema": "optinav.result",\n "version": 1}\n')
    with pytest.raises(OptinavError, match=r"r.json: unknown data file type .json; use one of .csv"):
        read_imu(tmp_path / "r.json", rate_hz=102.4)
    # a text file under an unknown suffix that is no table says it was read as text for want of a known suffix
    (tmp_path / "bad.raw").write_text("t,ax,ay,az\n1,2,3\n")
    with pytest.raises(OptinavError, match=r"\(read as text: its suffix .raw names no format optinav reads\)"):
        read_imu(tmp_path / "bad.raw")
    noisy = bytes([3, 7, 0x1B, 0x7F]) * 30 + src.read_bytes()[:4000]  # 90 control bytes in the first 4 KB: 2 %
    (tmp_path / "noisy").write_bytes(noisy)
    with pytest.raises(OptinavError, match=r"noisy: unknown data file type \(none\); use one of .csv"):
        read_imu(tmp_path / "noisy", rate_hz=102.4)


def test_real_annotated_session_keeps_text_labels():
    log = read_imu(_shared("annotated_session.csv"), rate_hz=204.8, acc_unit="counts", gyro_unit="counts")
    assert log.acc.shape == (9414, 3) and log.acc_unit == "counts"
    assert log.acc[0].tolist() == [-2052.0, -28.0, -73.0] and log.gyr[0].tolist() == [1.0, 0.0, -5.0]
    names, counts = np.unique(log.labels, return_counts=True)
    assert dict(zip(names, counts))["x_a"] == 1061 and len(names) == 9
    assert log.sample[0] == 1028  # the non-monotonic sample counter is kept, never used as time


# --- fuzz -----------------------------------------------------------------------------------------------------

_ALPHABET = st.sampled_from(
    list('0123456789.,;\t -+eE#"\nnaif_xyzt')
    + ["\r\n", "nan", "inf", "acc_x", "gyr_y", "t", "time", "part", "1e400", "\x00", "é"]
)


def _valid(log: ImuLog) -> None:
    assert isinstance(log, ImuLog) and log.t.ndim == 1 and len(log) >= 2
    assert np.all(np.isfinite(log.t)) and np.all(np.diff(log.t) > 0)
    assert log.acc is not None or log.gyr is not None
    for v in (log.acc, log.gyr):
        assert v is None or v.shape == (len(log), 3)
    assert log.nan_rows == int(np.count_nonzero(~log.finite))


_MUTATION = st.tuples(
    st.sampled_from(["truncate", "replace", "insert", "delete"]), st.floats(0, 1), st.binary(min_size=1, max_size=8)
)
_SEED_FILES: dict[str, bytes] = {}


def _seed_file(tmp_path: Path, suffix: str) -> bytes:
    """The bytes of a valid IMU file (with NaN, labels and units) to mutate."""
    if suffix not in _SEED_FILES:
        log = _log(n=12, labels=True)
        log.acc[2, 1] = np.nan
        _SEED_FILES[suffix] = write_imu(tmp_path / f"seed{suffix}", log, acc_unit="g").read_bytes()
    return _SEED_FILES[suffix]


def _mutate(raw: bytes, mutations) -> bytes:
    for op, where, chunk in mutations:
        i = int(where * len(raw))
        if op == "truncate":
            raw = raw[:i]
        elif op == "replace":
            raw = raw[:i] + chunk + raw[i + len(chunk) :]
        elif op == "insert":
            raw = raw[:i] + chunk + raw[i:]
        else:
            raw = raw[:i] + raw[i + len(chunk) :]
    return raw


_SUFFIXES = [".csv", ".txt", ".tsv", ".npz", ".mat", ".npy"] + ([".h5"] if h5py is not None else [])


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    content=st.one_of(
        st.binary(max_size=300),
        st.text(max_size=300),
        st.lists(_ALPHABET, max_size=120).map("".join),
        st.lists(_MUTATION, max_size=3),
    ),
    suffix=st.sampled_from(_SUFFIXES),
    rate=st.sampled_from([None, 100.0]),
    prefix=st.sampled_from([b"", b"PK\x03\x04", b"\x93NUMPY", b"MATLAB 5.0 MAT-file", b"\x89HDF\r\n\x1a\n"]),
)
def test_fuzz_read_imu_returns_a_log_or_an_optinav_error(tmp_path, content, suffix, rate, prefix):
    """Arbitrary bytes, text, or a valid file with bytes truncated/replaced/inserted/deleted."""
    path = tmp_path / f"fuzz{suffix}"
    if isinstance(content, list):
        raw = _mutate(_seed_file(tmp_path, suffix if suffix != ".npy" else ".npz"), content)
    else:
        raw = content.encode("utf-8", "surrogatepass") if isinstance(content, str) else content
        raw = prefix + raw if suffix not in (".csv", ".txt", ".tsv") else raw
    path.write_bytes(raw)
    try:
        log = read_imu(path, rate_hz=rate)
    except OptinavError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    _valid(log)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    rows=st.lists(
        st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.just("")), min_size=1, max_size=8),
        min_size=1,
        max_size=8,
    ),
    header=st.booleans(),
    delim=st.sampled_from([",", "\t", ";", " "]),
)
def test_fuzz_numeric_tables(tmp_path, rows, header, delim):
    """Near-valid tables: ragged rows, empty cells, NaN/inf; a log (with consistent counts) or a clear error."""
    lines = [delim.join(["t", "ax", "ay", "az", "gx", "gy", "gz", "x"][: len(rows[0])])] if header else []
    lines += [delim.join(repr(v) if v != "" else "" for v in r) for r in rows]
    path = _write(tmp_path / "f.csv", "\n".join(lines) + "\n")
    try:
        table = load_table(path)
        log = read_imu(
            path, columns=None if header else ",".join(["t", "ax", "ay", "az", "gx", "gy", "gz", "_"][: len(rows[0])])
        )
    except OptinavError:
        return
    assert all(v.shape == (len(log),) for v in table.data.values())
    _valid(log)


@pytest.mark.slow
def test_million_row_csv_reads_in_seconds(tmp_path):
    import time

    n = 1_000_000
    rng = np.random.default_rng(3)
    log = ImuLog(t=np.arange(n) / 100.0, acc=rng.normal(0, 9, (n, 3)), gyr=rng.normal(0, 1, (n, 3)))
    path = write_imu(tmp_path / "big.csv", log)
    start = time.perf_counter()
    back = read_imu(path)
    elapsed = time.perf_counter() - start
    _same(log, back)
    assert elapsed < 30.0, f"reading {n} rows took {elapsed:.1f} s"


def test_a_time_column_in_another_unit_than_seconds_is_refused_unless_stated(tmp_path):
    """Times read as seconds because nothing states their unit must give an IMU rate (≥ 10 Hz): a logger's
    millis() at 1 kHz or nanoseconds since boot read as seconds gave 1 Hz / 1e-7 Hz logs and noise densities
    orders of magnitude off, with exit 0. The error names the unit that fits; a stated unit is taken."""
    rng = np.random.default_rng(2)
    n = 400
    acc = rng.normal(0, 0.01, (n, 3)) + [0, 0, 9.81]
    body = "".join("{}," + ",".join(map(repr, a.tolist())) + "\n" for a in acc)
    for unit, step, fits in (("ms", 1, "ms"), ("ms", 2, "ms"), ("ns", 10_000_000, "ns"), ("us", 5000, "us")):
        ticks = 1_700_000_000 * (step if unit == "ms" else 1) + np.arange(n) * step
        path = _write(tmp_path / f"{unit}{step}.csv", "t,ax,ay,az\n" + body.format(*ticks))
        with pytest.raises(
            OptinavError, match=rf"steps {re.escape(f'{step:.3g}')} s read as seconds .*pass --time-unit {fits}\b"
        ):
            read_imu(path)
        log = read_imu(path, time_unit=unit)
        np.testing.assert_allclose(np.diff(log.t), step * TIME_UNITS[unit], rtol=0, atol=1e-6)  # epoch times
        np.testing.assert_array_equal(log.acc, acc)
    slow = _write(tmp_path / "slow.csv", "t,ax,ay,az\n" + body.format(*np.arange(n)))  # a 1 Hz log, said so
    assert read_imu(slow, time_unit="s").t[-1] == n - 1
    fast = _write(tmp_path / "ok.csv", "t,ax,ay,az\n" + body.format(*(np.arange(n) / 10)))  # 10 Hz: accepted
    assert read_imu(fast).t[1] == 0.1
    # a 4 kHz log's 0.25 ms steps read as seconds gave a 4 Hz log (noise densities 32x off), exit 0
    khz4 = _write(tmp_path / "k4.csv", "time,ax,ay,az\n" + body.format(*(np.arange(n) * 0.25)))
    with pytest.raises(OptinavError, match=r"steps 0.25 s read as seconds .*: a 4 Hz IMU log; pass --time-unit ms"):
        read_imu(khz4)
    assert read_imu(khz4, time_unit="ms").t[1] == 0.25e-3
    with pytest.raises(OptinavError, match=r"in its stated unit: a 1e\+08 Hz IMU log; pass the right --time-unit"):
        read_imu(_write(tmp_path / "s.csv", "t,ax,ay,az\n" + body.format(*(np.arange(n) / 100))), time_unit="us")


def test_a_unit_implied_by_a_name_yields_to_the_option(tmp_path):
    # header.stamp implies ns (rostopic echo -p); one in s was refused with "pass the right --time-unit", and
    # --time-unit s then with "column 'header.stamp' declares ns": no way to read it
    t = 1_700_000_000 + np.arange(40) * 0.005
    rows = "".join(f"{float(x)!r},0,0,9.81,0.1,0,0\n" for x in t)
    path = tmp_path / "s.csv"
    path.write_text("header.stamp,ax,ay,az,gx,gy,gz\n" + rows)
    with pytest.raises(OptinavError, match="pass the right --time-unit"):
        read_imu(path)
    assert np.array_equal(read_imu(path, time_unit="s").t, t)
    # a unit the file states still contradicts the option
    path.write_text("header.stamp [ns],ax,ay,az,gx,gy,gz\n" + rows)
    with pytest.raises(OptinavError, match="declares ns but time_unit='s' was passed"):
        read_imu(path, time_unit="s")


def test_a_stated_sensor_unit_overrides_a_header_that_declares_another(tmp_path):
    """A header in the wrong unit (``acc_x [m/s^2]`` over values in g): calibrate named --acc-unit g, which was then
    refused as contradicting the file ("drop acc_unit or correct the file"), and no flag could read it. The stated
    unit is taken, with a note naming the override; read whole and in blocks alike."""
    from optinav.io import iter_imu

    rng = np.random.default_rng(0)
    acc_g, gyr = rng.normal(0, 1, (60, 3)), rng.normal(0, 10, (60, 3))
    rows = "".join(f"{i * 0.01!r},{','.join(map(repr, [*acc_g[i].tolist(), *gyr[i].tolist()]))}\n" for i in range(60))
    head = "t,acc_x [m/s^2],acc_y [m/s^2],acc_z [m/s^2],gyr_x [rad/s],gyr_y [rad/s],gyr_z [rad/s]\n"
    path = _write(tmp_path / "w.csv", head + rows)
    log = read_imu(path, acc_unit="g", gyro_unit="deg/s")
    np.testing.assert_allclose(log.acc, acc_g * G_STANDARD, rtol=1e-12)
    np.testing.assert_allclose(log.gyr, np.radians(gyr), rtol=1e-12)
    said = " ".join(log.notes)
    assert "declare m/s^2; acc_unit=g overrides that" in said and "declare rad/s; gyro_unit=deg/s overrides" in said
    blocks = list(iter_imu(path, acc_unit="g", gyro_unit="deg/s", chunk_rows=25))
    np.testing.assert_array_equal(np.concatenate([b.acc for b in blocks]), log.acc)
    np.testing.assert_array_equal(read_imu(path).acc, acc_g)  # as declared without the option


@pytest.mark.parametrize(
    "head, acc_k, gyr_k",
    [
        ("time,acc_x_mg,acc_y_mg,acc_z_mg,gyr_x_mdps,gyr_y_mdps,gyr_z_mdps", G_STANDARD * 1e-3, math.pi / 180e3),
        ("t,AccX_g,AccY_g,AccZ_g,GyroX_dps,GyroY_dps,GyroZ_dps", G_STANDARD, math.pi / 180),
        ("timestamp,imu_ax,imu_ay,imu_az,imu_gx,imu_gy,imu_gz", 1.0, 1.0),
        ("t,ax,ay,az,imu0_gx,imu0_gy,imu0_gz", 1.0, 1.0),
    ],
)
def test_axis_names_with_a_unit_after_or_an_imu_word_before(tmp_path, head, acc_k, gyr_k):
    """Loggers write the unit after the axis (acc_x_mg, GyroX_dps) or a word before it (imu_ax): such files were
    "no accelerometer or gyroscope data". The unit after the name is the column's declared unit."""
    rng = np.random.default_rng(3)
    acc, gyr = rng.normal(0, 1, (50, 3)) + [0, 0, 1000], rng.normal(0, 100, (50, 3))
    path = tmp_path / "u.csv"
    np.savetxt(path, np.column_stack([np.arange(50) * 0.01, acc, gyr]), delimiter=",", header=head, comments="")
    log = read_imu(path)
    np.testing.assert_allclose(log.acc, acc * acc_k, rtol=1e-12)
    np.testing.assert_allclose(log.gyr, gyr * gyr_k, rtol=1e-12)


def test_a_word_before_an_axis_name_does_not_stand_beside_the_exact_name(tmp_path):
    """raw_ax … beside ax … (a logger's raw and scaled columns) keeps the exactly named ones, as before; two IMUs'
    imu0_ax and imu1_ax are named both, to choose with --columns."""
    rng = np.random.default_rng(4)
    cols = rng.normal(0, 1, (50, 9))
    path = tmp_path / "r.csv"
    np.savetxt(path, np.column_stack([np.arange(50) * 0.01, cols]), delimiter=",",
               header="t,ax,ay,az,gx,gy,gz,raw_ax,raw_ay,raw_az", comments="")  # fmt: skip
    np.testing.assert_array_equal(read_imu(path).acc, cols[:, :3])
    two = tmp_path / "two.csv"
    np.savetxt(two, np.column_stack([np.arange(50) * 0.01, cols[:, :6], cols[:, :6]]), delimiter=",",
               header="t,imu0_ax,imu0_ay,imu0_az,imu0_gx,imu0_gy,imu0_gz,imu1_ax,imu1_ay,imu1_az,imu1_gx,imu1_gy,imu1_gz",
               comments="")  # fmt: skip
    with pytest.raises(OptinavError, match="columns 'imu0_ax' and 'imu1_ax' both look like 'ax'"):
        read_imu(two)
