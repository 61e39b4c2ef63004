"""Files as loggers write them: text under a .mat/.log name, key,value preambles with the rate, rate attributes
and variables, an incomplete last line, an empty column, absurd cells — read, or a one-line error."""

import datetime
import gzip
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import iter_imu, read_imu
from optinav.core.results import Result
from optinav.multipos.result import CalibrationResult
from optinav.multipos.simulate import simulate

DATA_IMUCAL = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal"
ROWS = "1,2,3,4,5,6\n2,3,4,5,6,7\n3,4,5,6,7,8\n"


def _w(path, text):
    path.write_bytes(text.encode("latin-1") if isinstance(text, str) else text)
    return path


@pytest.mark.parametrize(
    "key, value", [("Fs", "100"), ("rate", "100 Hz"), ("sampling_rate", "100"), ("Sample Rate", "100")]
)
def test_preamble_before_the_header_gives_the_rate(tmp_path, key, value):
    log = read_imu(_w(tmp_path / "a.csv", f"device,MTi-1\n{key},{value}\nserial: 0x12\nax,ay,az,gx,gy,gz\n" + ROWS))
    np.testing.assert_allclose(log.t, [0.0, 0.01, 0.02])
    assert log.acc[2].tolist() == [3.0, 4.0, 5.0]
    assert any("100 Hz" in n and key in n for n in log.notes)


def test_two_column_table_is_not_a_preamble(tmp_path):
    from optinav.io.readers import read_table

    d = read_table(_w(tmp_path / "b.csv", "name,value\nfoo,1\nbar,2\n"), text_columns=("name",))
    assert list(d) == ["name", "value"] and d["value"].tolist() == [1.0, 2.0]


@pytest.mark.parametrize("suffix", [".mat", ".log", ".dat", ".npz", ".npy", ".h5", ".hdf5", ".MAT", ".csv.npz"])
def test_text_under_a_binary_or_logger_suffix_is_text(tmp_path, suffix):
    log = read_imu(_w(tmp_path / f"x{suffix}", "t ax ay az\n0 1 2 3\n0.05 1 2 3\n"))
    assert log.t.tolist() == [0.0, 0.05]


def test_binary_under_the_wrong_suffix_is_read_by_its_content(tmp_path):
    np.savez(tmp_path / "a.npz", t=np.array([0.0, 0.05]), ax=np.ones(2), ay=np.ones(2), az=np.ones(2))
    (tmp_path / "a.csv").write_bytes((tmp_path / "a.npz").read_bytes())
    assert read_imu(tmp_path / "a.csv").t.tolist() == [0.0, 0.05]


@pytest.mark.parametrize(
    "head, what",
    [
        (b"SQLite format 3\x00", "SQLite database"),
        (b"#ROSBAG V1.2\n", "ROS 1 bag of another format than 2.0"),
        (b"\x89PNG\r\n\x1a\n", "PNG image"),
        (b"%PDF-1.7\n", "PDF"),
    ],
)
@pytest.mark.parametrize("suffix", [".csv", ".npz", ".h5", ".dat"])
def test_foreign_binary_is_named_in_one_line(tmp_path, head, what, suffix):
    path = _w(tmp_path / f"x{suffix}", head + bytes(range(256)) * 4)
    with pytest.raises(OptinavError, match=f"x{suffix}: the file is an? .*{what}") as err:
        read_imu(path)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("head", [b"#ROSBAG V2.0\n", b"\x89MCAP0\r\n"])
def test_a_bag_under_another_suffix_is_read_as_a_bag(tmp_path, head):
    # ROS 1 bags and MCAP files are inputs whatever their suffix (a recording left as X.bag.active)
    path = _w(tmp_path / "x.csv", head + bytes(range(256)) * 4)
    with pytest.raises(
        OptinavError, match=r"x\.csv is not a readable ROS bag: it (ends within its header|holds no co)"
    ):
        read_imu(path)


def test_parquet_under_another_suffix_is_read_as_parquet(tmp_path):
    # Parquet is an input format: its signature chooses the reader whatever the suffix, like NPZ's and HDF5's
    path = _w(tmp_path / "x.csv", b"PAR1" + bytes(range(256)) * 4)
    with pytest.raises(OptinavError, match="x.csv is not a readable Parquet file"):
        read_imu(path)


def test_excel_workbook_is_named(tmp_path):
    import zipfile

    with zipfile.ZipFile(tmp_path / "book.csv", "w") as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        z.writestr("xl/workbook.xml", "<workbook/>")
    with pytest.raises(OptinavError, match="Office .* save the sheet as CSV"):
        read_imu(tmp_path / "book.csv")


@pytest.mark.parametrize("suffix", [".npz", ".npy"])
def test_npz_without_signature_nor_text_is_one_line(tmp_path, suffix):
    path = _w(tmp_path / f"x{suffix}", bytes(np.random.default_rng(0).integers(1, 256, 3000, dtype=np.uint8)))
    with pytest.raises(OptinavError, match=f"not {suffix[1:].upper()} .*lacks the format's signature"):
        read_imu(path)


def test_latin1_header_reads(tmp_path):
    log = read_imu(_w(tmp_path / "l.csv", "t,ax [m/s²],ay,az\n0,1,2,3\n.01,1,2,3\n".encode("latin-1")))
    assert log.acc.shape == (2, 3)


def test_incomplete_last_line_is_left_out_with_a_note(tmp_path):
    log = read_imu(_w(tmp_path / "c.csv", "t,ax,ay,az\n0,1,2,3\n.01,1,2,3\n.02,1,2"))
    assert len(log) == 2 and any("last line (4) is incomplete" in n for n in log.notes)
    with pytest.raises(OptinavError, match="line 4 has 3 field"):  # a complete line with a field missing
        read_imu(_w(tmp_path / "d.csv", "t,ax,ay,az\n0,1,2,3\n1,1,2,3\n2,1,2\n"))


def test_rate_attribute_and_variable(tmp_path):
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "a.h5", "w") as fh:
        fh["acc"] = np.ones((4, 3))
        fh.attrs["sampling_rate"] = 50.0
    assert read_imu(tmp_path / "a.h5").t[1] == pytest.approx(0.02)
    import scipy.io

    scipy.io.savemat(tmp_path / "b.mat", {"acc": np.ones((4, 3)), "Fs": 25.0})
    assert read_imu(tmp_path / "b.mat").t[1] == pytest.approx(0.04)


@pytest.mark.parametrize(
    "body, match",
    [
        ("0,1,,3\n1,1,,3\n", "column 'ay' holds no number"),
        ("0,1,2,3\n1,1e308,2,3\n", "column 'ax' holds 1e\\+308 in data row 2"),
    ],
)
def test_bad_columns_and_cells_are_one_line_errors(tmp_path, body, match):
    with pytest.raises(OptinavError, match=match) as exc:
        read_imu(_w(tmp_path / "e.csv", "t,ax,ay,az\n" + body))
    assert "\n" not in str(exc.value)


def test_damaged_gzip_is_a_one_line_error(tmp_path):
    raw = gzip.compress(("t,ax,ay,az\n" + "0,1,2,3\n" * 1000).encode())
    with pytest.raises(OptinavError, match="damaged gzip|cannot read"):
        read_imu(_w(tmp_path / "g.csv.gz", raw[: len(raw) // 2]))


def test_a_raw_logger_file_calibrates_with_the_unit_options_alone(tmp_path, capsys):
    """Unsigned 16-bit counts, text saved under .mat, a preamble with the rate, a last line cut short."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="counts", gyro_unit="counts", rng=11)
    raw = np.round(np.column_stack([s.acc, s.gyr]) + 32768).astype(int)
    rows = "\n".join(",".join(map(str, r)) for r in raw)
    path = _w(tmp_path / "log.mat", f"Fs,{1 / np.median(np.diff(s.t)):g}\nax,ay,az,gx,gy,gz\n{rows}\n12,13")
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "calibrate",
                "accel",
                str(path),
                "--acc-unit",
                "counts",
                "--gyro-unit",
                "counts",
                "--gravity",
                str(s.gravity),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "sample rate 100 Hz from the preamble line 'Fs'" in err and "is incomplete" in err
    r = _acc_scales_match(out, s, rtol=5e-4)
    np.testing.assert_allclose(r.accelerometer["b"], s.acc_b + 32768, atol=0.5)
    assert r.excluded["saturated_acc"] == 0 and r.excluded["saturated_gyro"] == 0


_PIECES = st.sampled_from(
    [
        "Fs,100\n",
        "rate: 1e308\n",
        "ax,ay,az\n",
        "t,ax,ay,az\n",
        "1,2,3\n",
        "1,2,3,4\n",
        "1e308,inf,-inf\n",
        "nan,,\n",
        ",,,\n",
        "\xe9\xb0,1\n",
        "1;2;3\n",
        '"a",b\n',
        "1,2",
    ]
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    pieces=st.lists(_PIECES, max_size=10),
    suffix=st.sampled_from([".csv", ".mat", ".log", ".dat", ".npz", ".h5"]),
    rate=st.sampled_from([None, 10.0]),
)
def test_fuzz_logger_text_reads_or_fails_in_one_line(tmp_path, pieces, suffix, rate):
    path = _w(tmp_path / f"f{suffix}", "".join(pieces))
    try:
        log = read_imu(path, rate_hz=rate)
    except OptinavError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    assert np.all(np.diff(log.t) > 0)
    for v in (log.acc, log.gyr):
        if v is not None:
            assert v.shape == (len(log), 3) and not np.any(np.isfinite(v) & (np.abs(v) > 1e12))


XSENS_HEAD = """// General information:
//  MT Manager version: 2022.2.0
//  XDA version: 2022.2.0 build 7381 rev 124627
// Device information:
//  DeviceId: 00B42D4F
//  ProductCode: MTW2-3A7G6
// Device settings:
//  Filter Profile: human(46.1)
//  Option Flags: Orientation Smoother Disabled, Position/Velocity Smoother Disabled
{rate}// Coordinate system: ENU
PacketCounter\tSampleTimeFine\tYear\tMonth\tDay\tSecond\tAcc_X\tAcc_Y\tAcc_Z\tGyr_X\tGyr_Y\tGyr_Z\tRoll\tPitch\tYaw
"""


@pytest.mark.parametrize("rate", ["// Update Rate: 100.0Hz\n", ""])
def test_xsens_mt_manager_export_reads(tmp_path, rate):
    """An Xsens MT Manager text export as written: '//' settings lines, tab-separated, PacketCounter and a
    SampleTimeFine that may be NaN (wireless MTw), Acc_* in m/s^2, Gyr_* in rad/s, Euler columns beside; the rate
    from its 'Update Rate' line, or --rate when it has none (was refused: 'line 2 has 5 field(s), 3 expected')."""
    rng = np.random.default_rng(5)
    acc = rng.normal(0, 0.01, (50, 3)) + [0, 0, 9.81]
    gyr = rng.normal(0, 0.001, (50, 3))
    rows = "".join(
        "\t".join(
            [str(51400 + i)] + ["NaN"] * 5 + [f"{v:.6f}" for v in (*acc[i], *gyr[i])] + ["-0.25", "0.21", "-137.1"]
        )
        + "\n"
        for i in range(50)
    )
    path = _w(tmp_path / "MT_00B42D4F_000.txt", XSENS_HEAD.format(rate=rate) + rows)
    if not rate:
        with pytest.raises(OptinavError, match="has no time column .*pass --rate HZ"):
            read_imu(path)
    log = read_imu(path) if rate else read_imu(path, rate_hz=100.0)
    np.testing.assert_allclose(log.t[:3], [0.0, 0.01, 0.02])
    np.testing.assert_allclose(log.acc, np.round(acc, 6), rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.gyr, np.round(gyr, 6), rtol=0, atol=1e-12)
    assert log.sample[0] == 51400
    if rate:
        assert any("Update Rate" in n for n in log.notes)


def test_euroc_asl_imu_csv_reads_as_published(tmp_path):
    """EuRoC / TUM-VI ``imu0/data.csv`` (ASL format): a '#' header with units in brackets, times in ns since the
    epoch, w_RS_S_* before a_RS_S_*, CRLF. Read with no option (was: no accelerometer or gyroscope data), and
    with names given the header's [ns] is kept (was read as seconds: a 2e-7 Hz log)."""
    rng = np.random.default_rng(6)
    n, t0 = 300, 1403636579758555392
    gyr, acc = rng.normal(0, 0.002, (n, 3)), rng.normal(0, 0.02, (n, 3)) + [9.81, 0, 0]
    head = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    head += "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"
    rows = [",".join([str(t0 + i * 5_000_000)] + [repr(float(v)) for v in (*gyr[i], *acc[i])]) for i in range(n)]
    path = _w(tmp_path / "data.csv", "\r\n".join([head, *rows]) + "\r\n")
    for log in (read_imu(path), read_imu(path, columns="t,gx,gy,gz,ax,ay,az")):
        np.testing.assert_allclose(np.diff(log.t), 0.005, rtol=0, atol=1e-6)
        assert log.t[0] == pytest.approx(t0 * 1e-9, abs=1e-6)
        np.testing.assert_array_equal(log.gyr, gyr)
        np.testing.assert_array_equal(log.acc, acc)


def _triads(seed, n, down=9.81):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 0.002, (n, 3)), rng.normal(0, 0.02, (n, 3)) + [0, 0, down]


def test_rostopic_echo_csv_reads_with_header_stamps(tmp_path):
    """``rostopic echo -p /imu > imu.csv`` (ROS 1): field.* names, the header stamp in ns beside the receive
    time %time, a text frame id (left out: nobody reads it; was 'imu_link' is not a number), covariances."""
    n, t0 = 200, 1403636579758555392
    gyr, acc = _triads(7, n)
    cov = lambda p: [f"field.{p}_covariance{i}" for i in range(9)]  # noqa: E731
    hdr = ["%time", "field.header.seq", "field.header.stamp", "field.header.frame_id"]
    hdr += [f"field.orientation.{a}" for a in "xyzw"] + cov("orientation")
    hdr += [f"field.angular_velocity.{a}" for a in "xyz"] + cov("angular_velocity")
    hdr += [f"field.linear_acceleration.{a}" for a in "xyz"] + cov("linear_acceleration")
    rows = []
    for i in range(n):
        stamp = t0 + i * 5_000_000
        vals = [str(stamp + 4321), str(i), str(stamp), "imu_link", "0.0", "0.0", "0.0", "1.0"] + ["0.0"] * 9
        vals += [repr(float(v)) for v in gyr[i]] + ["0.0"] * 9 + [repr(float(v)) for v in acc[i]] + ["0.0"] * 9
        rows.append(",".join(vals))
    path = _w(tmp_path / "imu.csv", "\n".join([",".join(hdr), *rows]) + "\n")
    for log in (read_imu(path), next(iter(iter_imu(path, chunk_rows=10_000)))):
        assert log.t[0] == pytest.approx(t0 * 1e-9, abs=1e-6)  # the header stamp, not %time
        np.testing.assert_allclose(np.diff(log.t), 0.005, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(log.gyr, gyr)
        np.testing.assert_array_equal(log.acc, acc)
    bad = _w(tmp_path / "bad.csv", "t,ax,ay,az\n0,x,1,2\n0.01,1,1,2\n")  # text in a column that is read
    with pytest.raises(OptinavError, match="'x' is not a number"):
        read_imu(bad)


def test_px4_sensor_combined_and_arduino_millis_read(tmp_path):
    """PX4's sensor_combined as pyulog's ulog2csv writes it (gyro_rad[0..2], accelerometer_m_s2[0..2], timestamp
    in µs since boot, read as µs: see test_px4_vehicle_imu_increments_read_as_rates) and an Arduino log with a
    millis() column."""
    n = 300
    gyr, acc = _triads(8, n, down=-9.81)
    hdr = "timestamp,gyro_rad[0],gyro_rad[1],gyro_rad[2],gyro_integral_dt,accelerometer_timestamp_relative,"
    hdr += "accelerometer_m_s2[0],accelerometer_m_s2[1],accelerometer_m_s2[2],accelerometer_integral_dt"
    rows = [
        ",".join(
            [str(20_123_456 + 4000 * i), *map(repr, gyr[i].tolist()), "4000", "0", *map(repr, acc[i].tolist()), "4000"]
        )
        for i in range(n)
    ]
    px4 = _w(tmp_path / "log_0_sensor_combined_0.csv", "\n".join([hdr, *rows]) + "\n")
    for log in (read_imu(px4), read_imu(px4, time_unit="us")):  # µs as ulog2csv writes it (was: --time-unit us)
        np.testing.assert_allclose(np.diff(log.t), 0.004, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(log.gyr, gyr)
        np.testing.assert_array_equal(log.acc, acc)
    ard = _w(tmp_path / "ard.csv", "millis,ax,ay,az\n" + "".join(f"{1000 + i},{i % 7},0,1000\n" for i in range(n)))
    np.testing.assert_allclose(np.diff(read_imu(ard, acc_unit="counts").t), 0.001, rtol=0, atol=1e-12)


def test_kalibr_imu_csv_reads_as_published(tmp_path):
    """Kalibr's IMU CSV (kalibr_bagcreater's imu0.csv: timestamp [ns], omega_* [rad/s], alpha_* [m/s^2]): alpha
    is the accelerometer there and the timestamp ns; elsewhere alpha_* is not an accelerometer."""
    n, t0 = 200, 1_600_000_000_000_000_000
    gyr, acc = _triads(9, n)
    rows = [
        ",".join([str(t0 + 5_000_000 * i), *map(repr, gyr[i].tolist()), *map(repr, acc[i].tolist())]) for i in range(n)
    ]
    path = _w(
        tmp_path / "imu0.csv", "\n".join(["timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z", *rows]) + "\n"
    )
    log = read_imu(path)
    np.testing.assert_allclose(np.diff(log.t), 0.005, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_array_equal(log.acc, acc)
    other = _w(tmp_path / "o.csv", "t,alpha_x,alpha_y,alpha_z\n" + "".join(f"{i / 100},1,2,3\n" for i in range(5)))
    with pytest.raises(OptinavError, match="no accelerometer or gyroscope data"):
        read_imu(other)


@pytest.mark.parametrize(
    ("head", "fmt", "offset_s"),
    [
        ("time", "%Y-%m-%d %H:%M:%S.%f", 0.0),  # pandas' to_csv of a DatetimeIndex named 'time'
        ("", "%Y-%m-%d %H:%M:%S.%f", 0.0),  # ... of an unnamed one: an empty header name
        ("timestamp", "%Y-%m-%dT%H:%M:%S.%fZ", 0.0),
        ("timestamp", "%Y-%m-%dT%H:%M:%S.%f+02:00", -7200.0),
    ],
)
def test_iso_datetime_time_column_reads_as_epoch_seconds(tmp_path, head, fmt, offset_s):
    """ISO 8601 date-times in the time column (was: "'2026-01-01 00:00:00.000' is not a number") are seconds
    since the epoch, a UTC offset applied; a cell of other text later is a one-line error."""
    import datetime as dt

    n = 120
    gyr, acc = _triads(10, n)
    t0 = dt.datetime(2026, 1, 1, 12, 0, 0)
    stamps = [(t0 + dt.timedelta(milliseconds=10 * i)).strftime(fmt) for i in range(n)]
    body = "".join(f"{s},{','.join(map(repr, [*acc[i].tolist(), *gyr[i].tolist()]))}\n" for i, s in enumerate(stamps))
    path = _w(tmp_path / "d.csv", f"{head},ax,ay,az,gx,gy,gz\n" + body)
    epoch = (t0 - dt.datetime(1970, 1, 1)).total_seconds() + offset_s
    for log in (read_imu(path), next(iter(iter_imu(path, chunk_rows=50)))):
        assert log.t[0] == pytest.approx(epoch, abs=1e-6)
        np.testing.assert_allclose(np.diff(log.t), 0.01, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(log.acc, acc[: len(log)])
    with pytest.raises(OptinavError, match="holds date-times and other text"):
        read_imu(_w(tmp_path / "e.csv", f"{head},ax,ay,az,gx,gy,gz\n" + body + "soon,1,2,3,4,5,6\n"))
    with pytest.raises(OptinavError, match="declares s but time_unit='ms' was passed"):
        read_imu(path, time_unit="ms")


def test_allan_and_attitude_print_what_the_reader_assumed(tmp_path, capsys):
    """The reader's notes (the rate's source, a text column left out) reach the user of allan and attitude as
    they reach calibrate's."""
    rng = np.random.default_rng(12)
    n = 6000
    acc = rng.normal(0, 0.01, (n, 3)) + [0, 0, 9.81]
    gyr = rng.normal(0, 0.001, (n, 3))
    rows = "".join(
        "\t".join(
            [str(i), "NaN", "NaN", "NaN", "NaN", "NaN"] + [f"{v:.6f}" for v in (*acc[i], *gyr[i])] + ["0", "0", "0"]
        )
        + "\n"
        for i in range(n)
    )
    path = _w(tmp_path / "MT.txt", XSENS_HEAD.format(rate="// Update Rate: 100.0Hz\n") + rows)
    note = "optinav: note: sample rate 100 Hz from the preamble line 'Update Rate' of MT.txt"
    assert main(["allan", str(path), "--out", str(tmp_path / "a.json")]) == 0
    assert note in capsys.readouterr().err
    assert main(["attitude", str(path), "--frame", "ENU", "--out", str(tmp_path / "q.csv")]) == 0
    assert note in capsys.readouterr().err


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    start=st.datetimes(min_value=datetime.datetime(1971, 1, 1), max_value=datetime.datetime(2200, 1, 1)),
    offset_min=st.integers(-14 * 60, 14 * 60),
    sep=st.sampled_from(["T", " "]),
    zulu=st.booleans(),
)
def test_iso_datetimes_parse_to_the_epoch_seconds_python_gives(tmp_path, start, offset_min, sep, zulu):
    """Invariant of the date-time time column: the seconds are those of Python's datetime for the same instant,
    whatever the separator and UTC offset (to the float's resolution)."""
    dt = datetime

    tz = dt.timezone(dt.timedelta(minutes=offset_min))
    stamps = [(start + dt.timedelta(milliseconds=5 * i)).replace(tzinfo=tz) for i in range(3)]
    suffix = (
        (lambda s: "Z") if zulu and offset_min == 0 else (lambda s: s.strftime("%z")[:3] + ":" + s.strftime("%z")[3:])
    )
    cells = [s.strftime(f"%Y-%m-%d{sep}%H:%M:%S.%f") + suffix(s) for s in stamps]
    path = _w(tmp_path / "h.csv", "time,ax,ay,az\n" + "".join(f"{c},0,0,9.8\n" for c in cells))
    got = read_imu(path, time_unit="s").t
    want = np.array([s.timestamp() for s in stamps])
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-6 * max(1.0, abs(want[0]) / 1e9))


def test_a_column_nobody_reads_may_hold_text_further_down(tmp_path):
    """A logger's event / GPS-fix column, empty or numeric at first and text on some row, is NaN there: the file
    reads (it was refused at that row), whole and in blocks, also with the columns named."""
    rng = np.random.default_rng(5)
    n = 600
    v = np.round(rng.normal(size=(n, 6)), 6)
    event = [""] * n
    event[300] = "button"
    fix = ["0"] * 200 + ["3D"] * (n - 200)
    lines = ["t,ax,ay,az,gx,gy,gz,event,gps_fix"] + [
        f"{k * 0.01:.2f}," + ",".join(f"{x:.6f}" for x in v[k]) + f",{event[k]},{fix[k]}" for k in range(n)
    ]
    f = _w(tmp_path / "ev.csv", "\n".join(lines) + "\n")
    for kw in ({}, {"columns": "t=t,ax=ax,ay=ay,az=az,gx=gx,gy=gy,gz=gz"}):
        log = read_imu(f, **kw)
        assert np.array_equal(log.acc, v[:, :3]) and np.array_equal(log.gyr, v[:, 3:])
        np.testing.assert_allclose(log.t, np.arange(n) * 0.01, atol=1e-12)
        blocks = list(iter_imu(f, chunk_rows=128, **kw))
        assert np.array_equal(np.concatenate([b.acc for b in blocks]), v[:, :3])
    # a column read_imu takes still refuses text, naming the row
    lines[401] = lines[401].replace(f",{v[400, 0]:.6f},", ",oops,", 1)
    with pytest.raises(OptinavError, match="line 402, column 2 .'ax'.: 'oops' is not a number"):
        read_imu(_w(tmp_path / "bad.csv", "\n".join(lines) + "\n"))


def test_a_delimiter_that_splits_nothing_is_a_one_line_error(tmp_path, capsys):
    f = _w(tmp_path / "mini.csv", "t,ax,ay,az,gx,gy,gz\n" + "".join(f"{k / 100},1,2,9.8,0,0,0\n" for k in range(50)))
    assert main(["allan", str(f), "--delimiter", ";", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no column of numbers" in err and "--delimiter" in err


def test_rows_written_twice_are_named_not_unsorted(tmp_path):
    """imucal's session with a time column and 10 rows inside x_rot written twice (a logger's buffer) was told
    'is not sorted ...; sort the samples by time', which leaves ten duplicated stamps: the repeat is named, as in
    any log (here 30 rows at 100 Hz repeated)."""
    n = 3000
    body = "".join("{},0,0,9.81,0,0,0\n" for _ in range(n + 30))
    t = np.r_[np.arange(1000), np.arange(970, 1000), np.arange(1000, n)] * 0.01
    with pytest.raises(
        OptinavError, match=r"the 30 rows from there repeat the stamps from 9.7 s .*; drop the repeated"
    ):
        read_imu(_w(tmp_path / "twice.csv", "t,ax,ay,az,gx,gy,gz\n" + body.format(*t)))


def test_a_time_step_back_is_named_for_what_it_is(tmp_path, capsys):
    """A wrapping µs counter (an Arduino's micros() after 71.6 min) or a second recording appended was met with
    'sort the samples by time', which would scramble the log: the error names the wrap (with the unwrap) or the
    jump back; a few samples out of order still read 'sort'."""
    n = 3000
    body = "".join("{},0,0,9.81,0,0,0\n" for _ in range(n))
    us = (np.arange(n, dtype=np.int64) * 10_000 + 2**32 - 15_000_000) % 2**32  # wraps at sample 1500
    f = _w(tmp_path / "wrap.csv", "timestamp_us,ax,ay,az,gx,gy,gz\n" + body.format(*us))
    with pytest.raises(OptinavError, match=r"t\[1500\] = 0 s < .*32-bit µs counter wrapping every 4294.97 s\)"
                       r"; unwrap the time \(add 2\^32 µs after each wrap\)"):  # fmt: skip
        read_imu(f)
    for chunk in (512, 1500):  # the wrap inside a block and on a block's first sample
        with pytest.raises(OptinavError, match="32-bit µs counter wrapping"):
            list(iter_imu(f, chunk_rows=chunk))
    t = np.r_[np.arange(1000) * 0.01, np.arange(2000) * 0.01]  # a second recording appended
    with pytest.raises(OptinavError, match=r"jump back by 9.99 s, 999 steps: a second recording .*; cut the log"):
        read_imu(_w(tmp_path / "two.csv", "t,ax,ay,az,gx,gy,gz\n" + body.format(*t)))
    t = np.arange(n) * 0.01
    t[[10, 11]] = t[[11, 10]]
    with pytest.raises(OptinavError, match=r"is not sorted: t\[11\] = 0.1 s < t\[10\] = 0.11 s; sort the samples"):
        read_imu(_w(tmp_path / "swap.csv", "t,ax,ay,az,gx,gy,gz\n" + body.format(*t)))


def test_cli_errors_name_the_command_line_options(tmp_path, capsys):
    """The library's messages name its keyword arguments (time_unit=..., rate_hz=...): the command line prints its
    own flags instead. 'msec'/'usec' units in a header are read."""
    from optinav.cli.main import cli_wording

    assert cli_wording("pass time_unit=... or rate_hz=100, columns='t=x' (time_unit_x=1)") == (
        "pass --time-unit ... or --rate 100, --columns 't=x' (time_unit_x=1)"
    )
    f = _w(tmp_path / "a.csv", "Time [minutes],ax,ay,az\n" + "".join(f"{k},1,2,9\n" for k in range(20)))
    assert main(["allan", str(f), "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err
    assert "pass --time-unit ... to state the unit" in err and "time_unit=" not in err
    f = _w(tmp_path / "b.csv", "t,ax,ay,az\n" + "".join(f"{k / 100},1,2,9\n" for k in range(20)))
    assert main(["allan", str(f), "--rate", "100", "--out", str(tmp_path / "x.json")]) == 2
    assert "and --rate 100 was given too" in capsys.readouterr().err
    log = read_imu(_w(tmp_path / "c.csv", "Time [msec],ax,ay,az\n0,1,2,9\n10,1,2,9\n20,1,2,9\n"))
    np.testing.assert_allclose(log.t, [0, 0.01, 0.02], rtol=0, atol=1e-15)


@pytest.mark.parametrize("enc, gz", [("utf-16", False), ("utf-16-le", False), ("utf-16", True)])
def test_utf16_text_reads(tmp_path, enc, gz):
    """Excel's "Unicode Text" (UTF-16 with a byte-order mark, tabs) was called binary; read whole and in blocks.
    Without a byte-order mark it is named as UTF-16 text."""
    import codecs

    rng = np.random.default_rng(8)
    v = np.round(rng.normal(size=(3000, 6)), 6)
    text = "t\tax\tay\taz\tgx\tgy\tgz\r\n" + "".join(
        f"{k / 100:.2f}\t" + "\t".join(f"{x:.6f}" for x in v[k]) + "\r\n" for k in range(3000)
    )
    raw = text.encode(enc) if enc == "utf-16" else codecs.BOM_UTF16_LE + text.encode(enc)
    f = tmp_path / ("u.txt.gz" if gz else "u.txt")
    f.write_bytes(gzip.compress(raw) if gz else raw)
    log = read_imu(f)
    assert np.array_equal(log.acc, v[:, :3]) and np.array_equal(log.gyr, v[:, 3:])
    assert np.array_equal(np.concatenate([b.gyr for b in iter_imu(f, chunk_rows=700)]), v[:, 3:])
    if not gz:
        f.write_bytes(text.encode("utf-16-le"))
        with pytest.raises(OptinavError, match="looks like UTF-16 text without a byte-order mark; save it as UTF-8"):
            read_imu(f)


@pytest.mark.parametrize("noise", [b"\xff\xfe\x00\x8c\r\n", b"\xff\xfe\xa5", b"\xfe\xff\x13\r\nets boot\r\n"])
def test_boot_noise_starting_like_a_utf16_mark_reads_as_the_ascii_it_is(tmp_path, noise):
    """An Arduino's boot noise starting with FF FE (or FE FF) was taken for a UTF-16 byte-order mark: the file
    was decoded as UTF-16 (an internal UnicodeDecodeError, or 'a header but no data rows'). The mark is UTF-16
    only when NUL high bytes follow; here the noise (also when the header follows it on its line) is left out
    with a note, whole and in blocks."""
    rng = np.random.default_rng(31)
    v = rng.integers(-2000, 2000, (900, 6))
    body = "ax,ay,az,gx,gy,gz\r\n" + "".join(",".join(map(str, r)) + "\r\n" for r in v)
    f = _w(tmp_path / "cap.csv", noise + body.encode())
    kw = {"acc_unit": "counts", "gyro_unit": "counts", "rate_hz": 100.0}
    log = read_imu(f, **kw)
    assert np.array_equal(log.acc, v[:, :3]) and np.array_equal(log.gyr, v[:, 3:])
    assert any("above the table ('(binary noise)'" in n for n in log.notes), log.notes
    assert np.array_equal(np.concatenate([b.gyr for b in iter_imu(f, chunk_rows=200, **kw)]), v[:, 3:])


def test_a_zip_that_is_not_npz_is_named(tmp_path):
    """A phone app's export (a zip of CSV files) or an openpyxl workbook (its content-types entry last, beyond
    the first 4 kB) was read as NPZ: 'holds no numeric arrays'."""
    import zipfile

    z = tmp_path / "export.zip"
    with zipfile.ZipFile(z, "w") as w:
        w.writestr("Accelerometer.csv", "time,x,y,z\n0,1,2,3\n")
        w.writestr("Gyroscope.csv", "time,x,y,z\n0,1,2,3\n")
    with pytest.raises(OptinavError, match=r"zip archive of 2 text table\(s\) \(Accelerometer.csv, Gyroscope.csv\)"):
        read_imu(z)
    z = tmp_path / "2024-05-01_10-00-00.zip"  # Sensor Logger's export without its gyroscope (the pair is read)
    with zipfile.ZipFile(z, "w") as w:
        for name in ("Accelerometer.csv", "Gravity.csv", "Metadata.csv", "TotalAcceleration.csv"):
            w.writestr(f"2024-05-01_10-00-00/{name}", "time,seconds_elapsed,z,y,x\n0,0,1,2,3\n")
    with pytest.raises(OptinavError) as err:
        read_imu(z)
    assert "extract it and pass 2024-05-01_10-00-00/TotalAcceleration.csv for the accelerometer alone" in str(err.value)
    x = tmp_path / "log.xlsx"
    with zipfile.ZipFile(x, "w") as w:
        w.writestr("xl/worksheets/sheet1.xml", "<x/>" * 2000)
        w.writestr("[Content_Types].xml", "<Types/>")
    with pytest.raises(OptinavError, match=r"is an Office \(.xlsx\) workbook"):
        read_imu(x)
    np.savez(tmp_path / "ok.npz", t=np.arange(3) * 0.01, ax=np.ones(3), ay=np.ones(3), az=np.ones(3))
    assert read_imu(tmp_path / "ok.npz").acc.shape == (3, 3)


def _phyphox_set(t, xyz, label, unit):
    """One export set as phyphox writes it into its CSV zip (phyphox-android DataExport.java: quoted names, values
    as 0.000000000E0; the simple experiment's names, SimpleExperimentCreator.java)."""
    head = ",".join(f'"{h}"' for h in ["Time (s)", *(f"{label} {a} ({unit})" for a in "xyz")])
    return head + "\n" + "".join(",".join("%.9E" % v for v in (ti, *x)) + "\n" for ti, x in zip(t, xyz))


def test_phyphox_export_of_several_sensors_names_the_files_to_pass(tmp_path, capsys):
    """phyphox exports an experiment of several sensors (its 'simple experiment' of accelerometer, gyroscope and
    magnetometer) as a zip of one CSV per sensor, each on its own times, beside meta/device.csv and meta/time.csv, or
    as an Excel workbook of one sheet per sensor. The zip was 'a zip archive of 5 text table(s) …; extract it and
    pass one table', the folder it unzips to 'is a folder; check the path', the workbook 'save the sheet as CSV'
    (which sheet, and the gyroscope?). Each now names the files and the flag: Accelerometer.csv with --gyro
    Gyroscope.csv, which read to the truth (time in s, m/s², rad/s interpolated onto the accelerometer's times)."""
    import zipfile

    gyr, acc = _triads(31, 400)
    ta, tg = 0.0031 + np.arange(400) / 200.0, 0.0007 + np.arange(400) / 200.0
    files = {
        "Accelerometer.csv": _phyphox_set(ta, acc, "Acceleration", "m/s^2"),
        "Gyroscope.csv": _phyphox_set(tg, gyr, "Gyroscope", "rad/s"),
        "Magnetometer.csv": _phyphox_set(ta[::4], np.tile([0.0, 20.0, -40.0], (100, 1)), "Magnetic field", "µT"),
        "meta/device.csv": '"property","value"\n"version","1.1.16"\n',
        "meta/time.csv": '"event","experiment time","system time","system time text"\n',
    }
    z = tmp_path / "Simple 2025-01-01 10-00-00.zip"
    folder = tmp_path / "Simple"
    with zipfile.ZipFile(z, "w") as w:
        for name, text in files.items():
            w.writestr(name, text)
    with zipfile.ZipFile(z) as w:
        w.extractall(folder)
    x = tmp_path / "Simple.xlsx"
    with zipfile.ZipFile(x, "w") as w:
        sheets = ("Accelerometer", "Gyroscope", "Magnetometer", "Metadata Device", "Metadata Time")
        xml = "".join(f'<sheet name="{n}" sheetId="{i}" r:id="rId{i}"/>' for i, n in enumerate(sheets, 1))
        w.writestr("xl/workbook.xml", f"<workbook><sheets>{xml}</sheets></workbook>")
        w.writestr("[Content_Types].xml", "<Types/>")
    for cmd in (["allan"], ["calibrate", "accel"], ["attitude"]):  # the zip and its folder are read (test_phone.py)
        out = tmp_path / ("o.csv" if cmd == ["attitude"] else "o.json")
        assert main([*cmd, str(x), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "phyphox's" in err[0], err
        assert "pass Accelerometer.csv (the accelerometer with gravity) with --gyro Gyroscope.csv" in err[0]
    assert "export it as 'CSV (Comma, decimal point)'" in str(pytest.raises(OptinavError, read_imu, x).value)
    log = read_imu(folder / "Accelerometer.csv", gyro_path=folder / "Gyroscope.csv")
    keep = ta <= tg[-1]  # the accelerometer's rows within the gyroscope's span
    np.testing.assert_allclose(log.t, ta[keep], rtol=1e-9, atol=0)
    np.testing.assert_allclose(log.acc, acc[keep], rtol=1e-9, atol=1e-12)
    want = np.column_stack([np.interp(ta[keep], tg, gyr[:, j]) for j in range(3)])
    np.testing.assert_allclose(log.gyr, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_decimal_commas_read_where_comma_is_not_the_delimiter(tmp_path, sep):
    """A German / French Excel or LibreOffice export, phyphox's "CSV (semicolon, decimal comma)": ';' (or tab)
    between cells and ',' in numbers was refused with no option to accept it. Read, whole and in blocks, with a
    note; a label's text is left as it is in the header."""
    rng = np.random.default_rng(12)
    n = 2500
    v = np.round(rng.normal(size=(n, 6)), 6)
    head = sep.join(["Time (s)", "ax", "ay", "az", "gx", "gy", "gz"]) if sep != " " else "t ax ay az gx gy gz"
    rows = [sep.join([f"{k / 100:.2f}".replace(".", ",")] + [f"{x:.6f}".replace(".", ",") for x in v[k]])
            for k in range(n)]  # fmt: skip
    f = _w(tmp_path / "eu.csv", "\n".join([head, *rows]) + "\n")
    log = read_imu(f)
    assert np.array_equal(log.acc, v[:, :3]) and np.array_equal(log.gyr, v[:, 3:])
    np.testing.assert_allclose(log.t, np.arange(n) / 100, atol=1e-12)
    assert any("decimal commas read as decimal points" in x for x in log.notes)
    assert np.array_equal(np.concatenate([b.acc for b in iter_imu(f, chunk_rows=333)]), v[:, :3])


def test_a_hash_inside_a_cell_is_no_comment(tmp_path):
    """'pose#1' … 'pose#5' in a label column were all read as 'pose' (numpy's comment character cut the cell,
    silently merging the poses); a '#' starts a comment only at a line's start or after white space."""
    lines = ["t,ax,ay,az,pose"] + [f"{k / 100:.2f},1,2,{k},pose#{k // 10 + 1}" for k in range(50)]
    lines.insert(20, "# a comment line")
    lines[30] += "  # a trailing comment"
    log = read_imu(_w(tmp_path / "h.csv", "\n".join(lines) + "\n"))
    assert sorted(set(log.labels.tolist())) == [f"pose#{i}" for i in range(1, 6)]
    assert log.acc[:, 2].tolist() == list(range(50))
    log = read_imu(_w(tmp_path / "n.csv", "t ax ay az\n" + "".join(f"{k / 100} 1 2 3  # x\n" for k in range(9))))
    assert log.acc.shape == (9, 3)


def test_a_shimmer_consensys_export_reads_with_its_names(tmp_path):
    """Shimmer Consensys writes Excel's '"sep=<tab>"' line, the header with a trailing tab, a row of "CAL" labels
    and a row of units (ms, m/(s^2), deg/s): the sep line was read as the only column ("1 expected"), and --delimiter
    tab then found one column named 'sep='. Read now, its units converted."""
    p = "Shimmer_9F6D_"
    names = ["Timestamp_Unix_CAL"] + [f"Accel_LN_{a}_CAL" for a in "XYZ"] + [f"Gyro_{a}_CAL" for a in "XYZ"]
    rows = [[1000.0 + 10 * i, 0.1, 0.2, 9.8, 1.0 * i, 0.0, -2.0] for i in range(5)]
    text = '"sep=\t"\n' + "\t".join(p + n for n in names) + "\t\n" + "CAL\t" * 7 + "\n"
    text += "ms\t" + "m/(s^2)\t" * 3 + "deg/s\t" * 3 + "\n" + "".join("\t".join(map(str, r)) + "\t\n" for r in rows)
    f = _w(tmp_path / "shimmer.csv", text)
    cols = ",".join(f"{k}={p}{n}" for k, n in zip(["t", "ax", "ay", "az", "gx", "gy", "gz"], names))
    log = read_imu(f, columns=cols)
    np.testing.assert_allclose(log.t, [1.0, 1.01, 1.02, 1.03, 1.04])
    np.testing.assert_allclose(log.acc[0], [0.1, 0.2, 9.8])
    np.testing.assert_allclose(log.gyr[:, 0], np.radians([0, 1, 2, 3, 4]))


def test_coarse_duplicate_times_name_the_way_round_them(tmp_path):
    """Whole-millisecond stamps at 286 Hz repeat: the error said "drop duplicated samples", naming no flag."""
    f = _w(tmp_path / "dup.csv", "t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0,0,0,9.8,0,0,0\n1,0,0,9.8,0,0,0\n")
    with pytest.raises(OptinavError, match="duplicate timestamp") as exc:
        read_imu(f, time_unit="ms")
    assert "'_' in --columns" in exc.value.remedy and "--rate" in exc.value.remedy


def test_rows_of_words_under_the_header_are_not_all_taken_for_labels(tmp_path):
    """Label rows under the header (Shimmer's "CAL", then units) are skipped only when data follow them: quoted
    decimal commas ("0,0035") looked like three rows of words and were skipped, the error then naming line 5."""
    rows = "".join(f'"0,{i:06d}","0,1","0,2","9,8","0,0","0,0","0,0"\n' for i in range(0, 40, 4))
    f = _w(tmp_path / "q.csv", '"t","ax","ay","az","gx","gy","gz"\n' + rows)
    with pytest.raises(OptinavError, match="line 3"):
        read_imu(f)


def test_a_serial_capture_with_start_up_text_above_the_table_reads(tmp_path):
    """An Arduino serial capture (MPU6050 example sketch): the sketch's start-up lines above the tab-separated
    table, micros() times, raw counts. Was refused with "no column of numbers in the first data row ('MPU6050
    connection successful', split at whitespace); check the delimiter option" although the delimiter was right.
    Now the lines above the table are left out with a note; so is a row cut at the start of a headerless capture
    (the serial monitor opened mid-line)."""
    rng = np.random.default_rng(11)
    n = 400
    acc = rng.integers(-300, 300, (n, 3)) + [0, 0, 16384]
    gyr = rng.integers(-40, 40, (n, 3))
    rows = ["\t".join(map(str, [1_000_123 + 2500 * i, *acc[i], *gyr[i]])) for i in range(n)]
    start = "Initializing I2C devices...\nTesting device connections...\nMPU6050 connection successful\n"
    path = _w(tmp_path / "capture.txt", start + "micros\tax\tay\taz\tgx\tgy\tgz\n" + "\n".join(rows) + "\n")
    log = read_imu(path, acc_unit="counts", gyro_unit="counts")
    np.testing.assert_array_equal(log.acc, acc)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_allclose(np.diff(log.t), 0.0025, rtol=0, atol=1e-12)
    assert any("3 line(s) above the table ('Initializing I2C devices...'" in x for x in log.notes), log.notes
    cut = _w(tmp_path / "cut.txt", "ctions...\n3 -33 16384\n" + "\n".join(r.replace("\t", " ") for r in rows))
    log = read_imu(cut, columns="t,ax,ay,az,gx,gy,gz", time_unit="us", acc_unit="counts", gyro_unit="counts")
    np.testing.assert_array_equal(log.acc, acc)
    assert any("2 line(s) above the table" in x for x in log.notes)
    # a header with fewer names than the rows have fields is still taken for the header (and named)
    short = _w(tmp_path / "short.csv", "t,ax,ay\n" + "".join(f"{i},1,2,3\n" for i in range(5)))
    with pytest.raises(OptinavError, match="line 2 has 4 field"):
        read_imu(short)


def _ardupilot_imu_csv(path, t_s, gyr, acc, inst):
    """ArduPilot's IMU message as ``mavlogdump.py --format csv --types IMU`` writes it (pymavlink 2.4): the
    wall-clock ``timestamp`` column it adds, then the message's fields (TimeUS in µs since boot, instance I, rad/s,
    m/s², temperature T, …)."""
    hdr = "timestamp,TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"
    rows = [
        ",".join(
            ["%.8f" % (1.7e9 + t_s[i]), str(round(t_s[i] * 1e6) + 61_000_000), str(inst[i])]
            + [repr(float(v)) for v in (*gyr[i], *acc[i])]
            + ["0", "0", "41.25", "1", "1", "400", "400"]
        )
        for i in range(len(t_s))
    ]
    return _w(path, "\n".join([hdr, *rows]) + "\n")


def test_ardupilot_imu_csv_reads_its_time_and_refuses_interleaved_imus(tmp_path, capsys):
    """mavlogdump's CSV of ArduPilot's IMU message was refused ("columns 'timestamp' and 'T' both look like 't'",
    T being the temperature), and with the flag that error named (--columns t=timestamp) a log of two IMUs in
    alternate rows (instance column I = 0, 1: every flight controller with two IMUs) was read as one 800 Hz log
    with exit 0. Now TimeUS (µs) is the time, and several instances are refused, naming the export of one."""
    n = 400
    gyr, acc = _triads(12, n)
    t = np.arange(n) / 400.0
    one = _ardupilot_imu_csv(tmp_path / "00000012_IMU.csv", t, gyr, acc, [0] * n)
    log = read_imu(one)
    assert log.t[0] == pytest.approx(61.0, abs=1e-9)
    np.testing.assert_allclose(np.diff(log.t), 0.0025, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_array_equal(log.acc, acc)
    two_t = np.repeat(t, 2) + np.tile([0.0, 1e-4], n)
    two = _ardupilot_imu_csv(
        tmp_path / "00000013_IMU.csv", two_t, np.repeat(gyr, 2, 0), np.repeat(acc, 2, 0), [0, 1] * n
    )
    for cols in (None, "t=timestamp"):
        with pytest.raises(OptinavError, match="column 'I' holds 2 IMU instances") as exc:
            read_imu(two, columns=cols)
        assert "--condition 'IMU.I==0'" in exc.value.remedy
    code = main(["allan", str(two), "--out", str(tmp_path / "a.json"), "--chunk-rows", "100"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "IMU instances" in err[0]
    # the high-rate ACC message (batch sampling): SampleUS is each sample's time, TimeUS the batch's; two
    # instances were read as one log with exit 0 (the IMU check did not look at ACC/GYR)
    for insts in ([0], [0, 1]):
        rows = [
            f"{1.6e9 + i / 1e3 + k * 1e-5:.8f},{5_000_000 + i // 10 * 10_000 + k},{k},{5_000_000 + i * 1000 + 3 * k},"
            + ",".join(map(repr, acc[i % n].tolist()))
            for i in range(2 * n)
            for k in insts
        ]
        path = _w(tmp_path / f"ACC{len(insts)}.csv", "timestamp,TimeUS,I,SampleUS,AccX,AccY,AccZ\n" + "\n".join(rows))
        if len(insts) == 1:
            log = read_imu(path)
            np.testing.assert_allclose(log.t, 5.0 + np.arange(2 * n) / 1e3, rtol=0, atol=1e-9)
            np.testing.assert_array_equal(log.acc[:n], acc)
        else:
            with pytest.raises(OptinavError, match="holds 2 IMU instances") as exc:
                read_imu(path)
            assert "--types ACC --condition 'ACC.I==0'" in exc.value.remedy


def test_one_ardupilot_imu_instance_is_read_with_topic_name_at_id(tmp_path, capsys):
    """mavlogdump's IMU CSV of a flight controller with two IMUs (instance column I = 0, 1 in alternate rows) was
    refused with only mavlogdump's --condition as remedy, and a column named ``Instance`` was not recognised at
    all: the two sensors read as one 800 Hz log with exit 0. ``--topic IMU@1`` (the bag's TOPIC@FRAME: one sensor
    of several) reads that instance alone, whole and in blocks, and the refusal names it."""
    n = 400
    gyr, acc = _triads(13, n)
    t = np.arange(n) / 400.0
    two_t = np.repeat(t, 2) + np.tile([0.0, 1e-4], n)
    gyr2, acc2 = gyr + 0.01, acc - 0.1  # the second IMU: other biases
    g, a = np.empty((2 * n, 3)), np.empty((2 * n, 3))
    g[0::2], g[1::2], a[0::2], a[1::2] = gyr, gyr2, acc, acc2
    two = _ardupilot_imu_csv(tmp_path / "00000013_IMU.csv", two_t, g, a, [0, 1] * n)
    named = _w(tmp_path / "inst.csv", two.read_text().replace(",I,", ",Instance,", 1))
    for path in (two, named):
        with pytest.raises(OptinavError, match="holds 2 IMU instances") as exc:
            read_imu(path)
        assert "--topic IMU@0" in exc.value.remedy
        for topic, (gy, ac, t0) in {"IMU@1": (gyr2, acc2, 61.0001), "@0": (gyr, acc, 61.0)}.items():
            for log in (read_imu(path, topic=topic), *iter_imu(path, topic=topic, chunk_rows=2 * n)):
                np.testing.assert_array_equal(log.gyr, gy)
                np.testing.assert_array_equal(log.acc, ac)
                np.testing.assert_allclose(log.t, t0 + t, rtol=0, atol=1e-9)
    for topic, msg in (
        ("ACC@1", "holds ArduPilot's IMU message, not ACC"),
        ("IMU@2", r"no row .* I == 2 \(found: 0, 1\)"),
    ):
        with pytest.raises(OptinavError, match=msg):
            read_imu(two, topic=topic)
    assert main(["attitude", str(two), "--topic", "IMU@1", "--frame", "ENU", "--out", str(tmp_path / "q.csv")]) == 0
    capsys.readouterr()
    assert main(["allan", str(two), "--chunk-rows", "100", "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--topic IMU@0" in err[0]


SENSORLOG_HEAD = (
    "loggingTime(txt),loggingSample(N),accelerometerTimestamp_sinceReboot(s),accelerometerAccelerationX(G),"
    "accelerometerAccelerationY(G),accelerometerAccelerationZ(G),gyroTimestamp_sinceReboot(s),gyroRotationX(rad/s),"
    "gyroRotationY(rad/s),gyroRotationZ(rad/s),motionTimestamp_sinceReboot(s),motionRotationRateX(rad/s),"
    "motionRotationRateY(rad/s),motionRotationRateZ(rad/s),motionUserAccelerationX(G),motionUserAccelerationY(G),"
    "motionUserAccelerationZ(G),motionAttitudeReferenceFrame(txt),motionGravityX(G),motionGravityY(G),"
    "motionGravityZ(G)"
)


def test_ios_core_motion_acceleration_is_read_as_the_specific_force(tmp_path, capsys):
    """SensorLog's iOS CSV: Core Motion reports minus the specific force in g (a phone face up reads z = -1 g).
    It was refused (no accelerometer), and with the columns mapped by name it was read as it stands, +1 g down:
    attitude then wrote roll 0.2 deg for a BROAD trial at -179.8 deg, exit 0. Now the accelerometer (raw, or
    userAcceleration + gravity without it) is negated with a note, the gyroscope and its time are found, and a
    userAcceleration mapped alone (no gravity in it) is refused."""
    n, g0 = 300, 9.80665
    gyr, f = _triads(13, n)  # specific force, +9.81 m/s² up on z
    cm = np.round(-f / g0, 6)  # what Core Motion logs
    grav = np.round(-f.mean(0) / g0, 6)
    user = np.round(cm - grav, 6)
    rows = []
    for i in range(n):
        ts = 5000.0 + i / 100.0
        rows.append(
            ",".join(
                ["2023-10-22T10:00:00.000+02:00", str(i), f"{ts:.6f}", *(f"{v:.6f}" for v in cm[i]), f"{ts + 1e-4:.6f}"]
                + [repr(float(v)) for v in gyr[i]]
                + [f"{ts + 2e-4:.6f}", *("0.0", "0.0", "0.0"), *(f"{v:.6f}" for v in user[i]), "XArbitraryZVertical"]
                + [f"{v:.6f}" for v in grav]
            )
        )
    path = _w(tmp_path / "2023-10-22_10_00_00_my_iOS_device.csv", "\n".join([SENSORLOG_HEAD, *rows]) + "\n")
    columns = ",".join(f"a{a}=accelerometerAcceleration{a.upper()}(G)" for a in "xyz")
    for log in (read_imu(path), read_imu(path, columns=columns + ",t=accelerometerTimestamp_sinceReboot(s)")):
        np.testing.assert_allclose(log.acc, -cm * g0, rtol=0, atol=1e-12)
        assert np.mean(log.acc[:, 2]) == pytest.approx(9.81, abs=0.01)  # up on z, as optinav's specific force
        assert any("minus the specific force" in x for x in log.notes), log.notes
    np.testing.assert_array_equal(read_imu(path).gyr, gyr)
    np.testing.assert_allclose(read_imu(path).t, 5000.0 + np.arange(n) / 100.0, rtol=0, atol=1e-9)
    split = tmp_path / "split.csv"
    keep = [j for j, h in enumerate(SENSORLOG_HEAD.split(",")) if not h.startswith(("accelerometer", "gyro"))]
    lines = [",".join(np.array(x.split(","))[keep]) for x in [SENSORLOG_HEAD, *rows]]
    log = read_imu(_w(split, "\n".join(lines) + "\n"))
    np.testing.assert_allclose(log.acc, -(user + grav) * g0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.t[0], 5000.0002, rtol=0, atol=1e-9)
    with pytest.raises(OptinavError, match="Core Motion's userAcceleration .gravity taken out., not the"):
        read_imu(path, columns=",".join(f"a{a}=motionUserAcceleration{a.upper()}(G)" for a in "xyz"))


def test_phyphox_linear_acceleration_is_named_gravity_free(tmp_path, capsys):
    """phyphox's "Linear Acceleration" export (gravity taken out by the phone) reads about 0 at rest in every
    unit. allan said "declare the unit with --acc-unit (g, mg, m/s^2, counts)" and calibrate accel "raw counts?;
    pass --acc-unit counts": flags that cannot help. Both now name the cause and the file to read instead; the
    same export with gravity ("Acceleration x (m/s^2)", phyphox's comma/tab/semicolon variants) reads as is."""
    rng = np.random.default_rng(14)
    n = 3000
    t = 0.0013 + np.arange(n) / 200.0
    lin = rng.normal(0, 0.05, (n, 3))
    head = '"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)","Linear Acceleration z (m/s^2)"'
    rows = [",".join("%.9E" % v for v in (t[i], *lin[i])) for i in range(n)]
    path = _w(tmp_path / "Linear Acceleration.csv", "\n".join([head, *rows]) + "\n")
    np.testing.assert_allclose(read_imu(path).acc, lin, rtol=1e-9, atol=0)
    for cmd in (["allan"], ["calibrate", "accel"]):
        code = main([*cmd, str(path), "--out", str(tmp_path / "r.json")])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and "gravity taken out?" in err[-1] and "TotalAcceleration.csv" in err[-1], err
        assert "--acc-unit counts" not in err[-1] and "(g, mg, m/s^2, counts)" not in err[-1]
    acc = lin + [0.1, 0.2, 9.8]
    for sep, comma in ((",", False), ("\t", False), (";", True)):
        cell = (lambda v: ("%.9E" % v).replace(".", ",")) if comma else (lambda v: "%.9E" % v)  # noqa: E731
        head = sep.join(f'"{h}"' for h in ["Time (s)", *(f"Acceleration {a} (m/s^2)" for a in "xyz")])
        body = "\n".join(sep.join(cell(v) for v in (t[i], *acc[i])) for i in range(n))
        log = read_imu(_w(tmp_path / "Raw Data.csv", head + "\n" + body + "\n"))
        np.testing.assert_allclose(log.acc, acc, rtol=1e-9, atol=0)
        np.testing.assert_allclose(log.t, t, rtol=1e-9, atol=0)


def test_sensor_logger_files_name_their_sensor_and_read_time_in_ns(tmp_path, capsys):
    """Sensor Logger (Android/iOS) writes one file per sensor: time (ns since the epoch), seconds_elapsed, then
    z, y, x. The error listed every standard name ("pass --columns 't,ax,ay,az,gx,gy,gz'"); now it names the
    mapping of x, y, z for either sensor. Mapped, the time was read as seconds (refused: "pass --time-unit ns");
    beside seconds_elapsed it is ns, and the axes come in x, y, z order whatever the columns' order."""
    n, t0 = 500, 1698000000123456789
    gyr, acc = _triads(15, n)
    text = {}
    for name, tri in (("Gyroscope.csv", gyr), ("TotalAcceleration.csv", acc)):
        rows = [
            f"{t0 + 5_000_000 * i},{5_000_000 * i / 1e9!r}," + ",".join(map(repr, tri[i][::-1].tolist()))
            for i in range(n)
        ]
        # renamed: the name no longer says which sensor (Sensor Logger's own names do, below)
        text[name] = _w(tmp_path / f"phone_{name}", "time,seconds_elapsed,z,y,x\n" + "\n".join(rows) + "\n")
    code = main(["allan", str(text["Gyroscope.csv"]), "--out", str(tmp_path / "a.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "columns z, y, x do not say which sensor" in err[0] and "'gx=x,gy=y,gz=z' for a gyroscope" in err[0]
    g = read_imu(text["Gyroscope.csv"], columns="gx=x,gy=y,gz=z")
    a = read_imu(text["TotalAcceleration.csv"], columns="ax=x,ay=y,az=z")
    np.testing.assert_array_equal(g.gyr, gyr)
    np.testing.assert_array_equal(a.acc, acc)
    assert g.t[0] == pytest.approx(t0 * 1e-9, abs=1e-6)
    np.testing.assert_allclose(np.diff(a.t), 0.005, rtol=0, atol=1e-6)


def _sensor_logger_file(path, t, xyz, t0=1698000000123456789):
    """One Sensor Logger file (tszheichoi/awesome-sensor-logger UNITS.md: ``time`` in ns since the epoch,
    ``seconds_elapsed`` in s, then the axes in the order z, y, x)."""
    rows = [
        f"{t0 + round(ti * 1e9)},{float(ti)!r}," + ",".join(repr(float(v)) for v in x[::-1]) for ti, x in zip(t, xyz)
    ]
    return _w(path, "time,seconds_elapsed,z,y,x\n" + "\n".join(rows) + "\n")


def test_sensor_logger_headphone_is_its_own_imu_never_the_phones(tmp_path, capsys):
    """Sensor Logger's Headphone.csv (AirPods; awesome-sensor-logger UNITS.md: time in ns, seconds_elapsed,
    rotationRate rad/s, gravity m/s², acceleration with gravity taken out in g by default, quaternion, devicelocation)
    was read as an accelerometer: its gravity-free acceleration in g taken for the specific force in m/s² (allan:
    exit 0 on it). Now it is the headphones' own IMU: its gyroscope (allan reads it, x, y, z, 200 Hz); calibrate and
    attitude, alone or paired with the phone's TotalAcceleration.csv, end in one line naming it another device."""
    n, t0 = 600, 1698000000123456789
    gyr, acc = _triads(41, n)
    t = np.arange(n) / 200.0
    grav = np.tile([0.0, 0.0, -9.80665], (n, 1))
    user = np.random.default_rng(41).normal(0, 0.002, (n, 3))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    head = "time,seconds_elapsed,rotationRateX,rotationRateY,rotationRateZ,gravityX,gravityY,gravityZ,accelerationX,"
    head += "accelerationY,accelerationZ,quaternionW,quaternionX,quaternionY,quaternionZ,roll,pitch,yaw,devicelocation"
    rows = [
        ",".join([str(t0 + 5_000_000 * i), *(repr(float(v)) for v in np.r_[t[i], gyr[i], grav[i], user[i], quat[i]])])
        + ",0,0,0,left"
        for i in range(n)
    ]
    path = _w(tmp_path / "Headphone.csv", head + "\n" + "\n".join(rows) + "\n")
    log = read_imu(path)
    assert log.acc is None
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_allclose(log.t - log.t[0], t, rtol=0, atol=1e-6)
    assert log.t[0] == pytest.approx(t0 * 1e-9, abs=1e-6)
    assert main(["allan", str(path), "--out", str(tmp_path / "a.json")]) == 0
    assert "600 samples at 200 Hz" in capsys.readouterr().out
    phone = _sensor_logger_file(tmp_path / "TotalAcceleration.csv", t, acc, t0=t0)
    for argv in (
        ["calibrate", "accel", str(path), "--out", str(tmp_path / "r.json")],
        ["attitude", str(path), "--out", str(tmp_path / "o.csv")],
        ["attitude", str(phone), "--gyro", str(path), "--out", str(tmp_path / "o.csv")],
        ["calibrate", "accel", str(path), "--gyro", str(path), "--out", str(tmp_path / "r.json")],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Headphone.csv is Sensor Logger's headphone motion" in err[0], err
        assert "another device than the phone" in err[0] and "TotalAcceleration.csv with --gyro Gyroscope.csv" in err[0]


def test_sensor_logger_files_read_by_their_names(tmp_path, capsys):
    """Sensor Logger's export, a file per sensor under fixed names: TotalAcceleration.csv (Android, gravity in it,
    m/s²), Gyroscope.csv (rad/s), Accelerometer.csv (gravity taken out), AccelerometerUncalibrated.csv (iOS: g and
    minus the specific force by default; Android: m/s²), Gravity.csv (awesome-sensor-logger UNITS.md,
    COORDINATES.md). Every command ended in "columns z, y, x do not say which sensor they hold". The file's name
    says it: the pair calibrates to its truth as it is, x, y, z in order and the time in s; the files that hold no
    accelerometer with gravity are refused naming the ones that do, and the uncalibrated one naming the flags of
    each platform."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=4)
    d = tmp_path / "2024-05-01_10-00-00"
    d.mkdir()
    acc = _sensor_logger_file(d / "TotalAcceleration.csv", s.t, s.acc)
    gyro = _sensor_logger_file(d / "Gyroscope.csv", s.t + 0.002, s.gyr)  # its own clock: interpolated onto acc's
    log = read_imu(acc, gyro_path=gyro)
    inside = s.t >= s.t[0] + 0.002  # the accelerometer's rows within the gyroscope's span
    np.testing.assert_array_equal(log.acc, s.acc[inside])
    np.testing.assert_allclose(log.t, 1698000000.123456789 + s.t[inside], rtol=0, atol=2e-6)
    want = np.array([np.interp(s.t[inside], s.t + 0.002, g) for g in s.gyr.T]).T
    np.testing.assert_allclose(log.gyr, want, rtol=0, atol=1e-6)  # the stamps' ns rounding
    assert any("read by its name as the gyroscope" in x for x in log.notes), log.notes
    out = tmp_path / "r.json"
    assert (
        main(["calibrate", "accel", str(acc), "--gyro", str(gyro), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    )
    r = _acc_scales_match(out, s)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]), np.diag(s.gyr_K), rtol=5e-3)
    capsys.readouterr()
    for name, msg in (("Accelerometer.csv", "with gravity taken out"), ("Gravity.csv", "gravity vector")):
        f = _sensor_logger_file(d / name, s.t[:300], s.acc[:300] - 9.8 * (name == "Accelerometer.csv"))
        assert main(["attitude", str(f), "--gyro", str(gyro), "--out", str(tmp_path / "q.csv")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and msg in err[0] and "TotalAcceleration.csv" in err[0], err
        assert ("--columns 'ax=x,ay=y,az=z'" in err[0]) == (name == "Accelerometer.csv"), err  # another app's file
    ios = _sensor_logger_file(d / "AccelerometerUncalibrated.csv", s.t, -s.acc / 9.80665)  # iOS: g, negated
    code = main(["attitude", str(ios), "--gyro", str(gyro), "--out", str(tmp_path / "q.csv")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "norm reads 0.996, so g: iOS" in err[0] and "--columns 'ax=-x,ay=-y,az=-z' --acc-unit 'g' (iOS)" in err[0]
    log = read_imu(ios, gyro_path=gyro, columns="ax=-x,ay=-y,az=-z", acc_unit="g")
    np.testing.assert_allclose(log.acc, s.acc[inside], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("standardised", [False, True])
def test_sensor_logger_wrist_motion_is_the_watch_imu(tmp_path, standardised):
    """Sensor Logger's WristMotion.csv (Apple Watch, Core Motion device motion; awesome-sensor-logger UNITS.md and
    COORDINATES.md): rotationRate (rad/s), gravity and acceleration (gravity taken out) in g and Core Motion's sign
    by default, in m/s² and Android's sign with 'Standardise Units & Frames'. Its user acceleration was read as the
    accelerometer (about 0) and its gyroscope not at all ('has only the accelerometer'). Now the gyroscope is
    rotationRate and the specific force acceleration + gravity, negated in g by default, as it is in m/s²; the
    gravity's norm (1 or 9.81) tells which."""
    n, g0 = 400, 9.80665
    gyr, f = _triads(21, n)  # the specific force, +9.81 up on z
    down = f.mean(0) / np.linalg.norm(f.mean(0))
    grav, user = (down * g0, f - down * g0) if standardised else (-down, -f / g0 + down)
    head = "time,seconds_elapsed,rotationRateX,rotationRateY,rotationRateZ,gravityX,gravityY,gravityZ,"
    head += "accelerationX,accelerationY,accelerationZ,quaternionW,quaternionX,quaternionY,quaternionZ,pitch,roll,yaw\n"
    rows = [
        f"{1698000000000000000 + 10_000_000 * i},{i / 100}," + ",".join(repr(float(v)) for v in (*gyr[i], *grav, *user[i]))
        + ",1,0,0,0,0,0,0"
        for i in range(n)
    ]  # fmt: skip
    log = read_imu(_w(tmp_path / "WristMotion.csv", head + "\n".join(rows) + "\n"))
    np.testing.assert_allclose(log.acc, f, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_allclose(log.t - log.t[0], np.arange(n) / 100, rtol=0, atol=1e-6)
    assert any("WristMotion read" in x for x in log.notes), log.notes
    bad = list(rows)
    bad[5] = ",".join(bad[5].split(",")[:5] + ["0.5", "0.5", "0.5"] + bad[5].split(",")[8:])
    with pytest.raises(OptinavError, match="gravity's norm is neither 1"):
        read_imu(_w(tmp_path / "WristMotion (1).csv", head + "\n".join(bad) + "\n"))


def test_physics_toolbox_g_force_is_the_accelerometer(tmp_path, capsys):
    """Physics Toolbox Sensor Suite: the g-force meter gFx, gFy, gFz (the specific force in g) and, in a multi
    record, the linear accelerometer ax, ay, az (m/s², gravity taken out) beside the gyroscope wx, wy, wz (rad/s):
    ``time,gFx,gFy,gFz,ax,ay,az,wx,wy,wz,…`` (headers as read by several users' scripts on GitHub, e.g.
    ``time,gFx,gFy,gFz,ax,ay,az,wx,wy,wz,Azimuth,Pitch,Roll,Latitude,Longitude,Speed (m/s)``), the g-force meter
    alone ``time,gFx,gFy,gFz,TgF``. The linear acceleration was read as the accelerometer (attitude: "gravity looks
    removed"), and the g-force meter alone not at all. Now gF is the accelerometer in g, the linear one passed over
    with a note: the recording calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="g", gyro_unit="rad/s", rng=6)
    rng = np.random.default_rng(6)
    gf = np.round(s.acc, 5)
    lin = np.round(rng.normal(0, 0.03, s.acc.shape), 4)  # the phone's linear acceleration: about 0 at rest
    head = "time,gFx,gFy,gFz,ax,ay,az,wx,wy,wz,Bx,By,Bz,Azimuth,Pitch,Roll\n"
    rows = [
        ",".join([f"{s.t[i]:.6f}", *(f"{v:.5f}" for v in gf[i]), *(f"{v:.4f}" for v in lin[i])])
        + "," + ",".join(repr(float(v)) for v in s.gyr[i]) + ",20.1,-3.2,-40.5,12.0,3.0,1.0"
        for i in range(len(s.t))
    ]  # fmt: skip
    multi = _w(tmp_path / "Physics Toolbox multi record.csv", head + "\n".join(rows) + "\n")
    log = read_imu(multi)
    assert log.acc_input_unit == "g"
    np.testing.assert_allclose(log.acc, gf * 9.80665, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log.gyr, s.gyr)
    np.testing.assert_allclose(log.t, np.round(s.t, 6), rtol=0, atol=1e-12)
    assert any("ax, ay, az (the phone's linear acceleration" in x for x in log.notes), log.notes
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(multi), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    _acc_scales_match(out, s)
    capsys.readouterr()
    body = "".join(f"{s.t[i]:.6f},{gf[i, 0]:.5f},{gf[i, 1]:.5f},{gf[i, 2]:.5f},1.0\n" for i in range(len(s.t)))
    log = read_imu(_w(tmp_path / "gforce.csv", "time,gFx,gFy,gFz,TgF\n" + body))
    np.testing.assert_allclose(log.acc, gf * 9.80665, rtol=0, atol=1e-12)


def _ptb_multi_record(path, ta, gf, tg, gyr, blank=False, bfield=None):
    """Physics Toolbox Sensor Suite's multi record (``time,gFx,gFy,gFz,wx,wy,wz[,Bx,By,Bz]``): a row at each sensor's
    sample, the other sensor's cells repeating its last sample (0 before its first: the ``0.0000`` rows at the start
    of a multi record in a user's README, vehicle-classification; d33pk3rn3l/Navigation_23FS_ETHZ reads such files
    whole as numbers) or, ``blank``, left empty; ``bfield`` a magnetometer reading in every row."""
    events = sorted([(t, 0, i) for i, t in enumerate(ta)] + [(t, 1, i) for i, t in enumerate(tg)])
    last = [np.zeros(3), np.zeros(3)]
    rows = []
    for t, k, i in events:
        last[k] = (gf, gyr)[k][i]
        cells = [("" if blank and j != k else f"{v:.5f}") for j in (0, 1) for v in last[j]]
        rows.append(",".join([f"{t:.6f}", *cells, *(() if bfield is None else map(str, bfield))]))
    head = "time,gFx,gFy,gFz,wx,wy,wz" + ("" if bfield is None else ",Bx,By,Bz")
    return _w(path, head + "\n" + "\n".join(rows) + "\n")


def test_physics_toolbox_multi_record_reads_each_sensor_on_its_rows(tmp_path, capsys):
    """A Physics Toolbox multi record writes a row at each sensor's sample (accelerometer and gyroscope on their own
    clocks), the other sensor's cells repeated (0 before its first) or blank. Read as one log, every sample was paired
    with a repeated or a blank one: 2 N rows at twice the rate, the first accelerometer row 0 (held), or every row NaN
    in one sensor (blank; calibrate: "time has 0 sample(s)"). Now each sensor is read on its own rows (time in s, gF
    in g → m/s², x, y, z in order), the gyroscope interpolated onto the accelerometer's times as from two files;
    a magnetometer column that never changes holds one sample (its own rows: tests/test_phone.py), a one-line
    error."""
    n = 500
    gyr, acc = _triads(21, n)
    gf, gyr = np.round(acc / 9.80665, 5), np.round(gyr, 5)
    ta = 0.0123 + np.arange(n) / 100.0
    tg = ta + 0.004  # the gyroscope's own clock
    for blank in (False, True):
        log = read_imu(_ptb_multi_record(tmp_path / f"multi{int(blank)}.csv", ta, gf, tg, gyr, blank=blank))
        np.testing.assert_allclose(log.t, np.round(ta[1:], 6), rtol=0, atol=1e-12)  # the first is before any gyro
        np.testing.assert_allclose(log.acc, gf[1:] * 9.80665, rtol=0, atol=1e-12)
        want = np.column_stack([np.interp(log.t, np.round(tg, 6), gyr[:, j]) for j in range(3)])
        np.testing.assert_allclose(log.gyr, want, rtol=0, atol=1e-12)
        assert np.abs(log.gyr - gyr[1:]).max() < 0.5 * np.abs(np.diff(gyr, axis=0)).max()  # not a row earlier
        assert any("multi record" in x and f"{n} of its {2 * n} rows" in x for x in log.notes), log.notes
    path = _ptb_multi_record(tmp_path / "mag.csv", ta, gf, tg, gyr, bfield=(20.0, -3.0, -40.0))
    argv = ["attitude", str(path), "--mag-columns", "Bx,By,Bz", "--out", str(tmp_path / "a.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "magnetometer holds 1 sample(s)" in err[0] and "drop --mag" in err[0], err
    assert main(argv[:2] + argv[4:]) == 0  # without the magnetometer
    capsys.readouterr()


def test_physics_toolbox_multi_record_allan_takes_each_sensor_on_its_own_clock(tmp_path, capsys):
    """allan of a Physics Toolbox multi record (accelerometer and gyroscope at 100 Hz each, on clocks half a sample
    apart): read as one log it was 200 Hz of repeated samples, exit 0 with the white noise off by up to a quarter
    (VRW z 0.00153 for 0.00200). Now each triad is analysed on its own rows and rate, as from two files: N within 5 %
    of the simulated white noise (std × √dt)."""
    rng = np.random.default_rng(12)
    n, sa, sg = 6000, 0.02, 0.003
    ta = 0.004 + np.arange(n) / 100.0
    acc = np.array([0.1, -0.2, 9.80665]) + rng.normal(0, sa, (n, 3))
    gyr = np.array([0.001, -0.002, 0.003]) + rng.normal(0, sg, (n, 3))
    path = _ptb_multi_record(tmp_path / "multi.csv", ta, acc / 9.80665, ta + 0.005, gyr)
    out = tmp_path / "allan.json"
    assert main(["allan", str(path), "--out", str(out)]) == 0
    assert "100 Hz" in capsys.readouterr().out
    res = Result.from_json(out)
    for sensor, truth in (("accelerometer", sa * 0.1), ("gyroscope", sg * 0.1)):
        np.testing.assert_allclose(res.sensor(sensor)["fit"].white, truth, rtol=0.05)


def test_hyperimu_file_reads_by_its_sensors_line(tmp_path, capsys):
    """HyperIMU's log file (ianovir/HIMUServer README.md, HIMU-filetest.csv): '@' header lines ('@Sensors:
    MPLAccelerometer - MPLLinearAcceleration', '@ SamplingTime: 100ms'), then three values per sensor in that order,
    no header, a first row of zeros. Was 'line 5 has 1 field(s), 3 expected' (the '@' lines taken for the table).
    Now the '@' lines are its header: the accelerometer's triad is ax..az (the linear acceleration's is not), the
    gyroscope's gx..gz, the rate 1 / SamplingTime, the zeros left out; the recording calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=8)
    head = "@ HyperIMU - ianovir - 2013\n@ Date: Sat Aug 02 17:32:42 CEST 2014\n"
    head += "@Sensors: MPLAccelerometer - MPLLinearAcceleration - MPLGyroscope\n@ SamplingTime: 10ms\n"
    lin = s.acc - s.acc.mean(0)
    rows = [",".join(repr(float(v)) for v in (*s.acc[i], *lin[i], *s.gyr[i])) for i in range(len(s.t))]
    path = _w(tmp_path / "HIMU-2024-05-01_10-00-00.csv", head + "0.0," * 8 + "0.0\n" + "\n".join(rows) + "\n")
    log = read_imu(path)
    np.testing.assert_array_equal(log.acc, s.acc)
    np.testing.assert_array_equal(log.gyr, s.gyr)
    np.testing.assert_allclose(log.t, np.arange(len(s.t)) / 100.0, rtol=0, atol=1e-12)
    assert any("zeros written before the sensors" in x for x in log.notes), log.notes
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    _acc_scales_match(out, s)
    test = "@ HyperIMU - ianovir - 2013\n@Sensors: MPLAccelerometer - MPLLinearAcceleration\n@ SamplingTime: 100ms\n"
    test += "0.0,0.0,0.0,0.0,0.0,0.0\n0.13322297,9.381591,0.8710387,0.36958146,-0.38709503,0.0040415954\n"
    test += "-0.20881577,9.42485,0.7918533,-0.3580554,-0.34982255,-0.026045837\n"
    log = read_imu(_w(tmp_path / "HIMU-filetest.csv", test))
    np.testing.assert_array_equal(log.acc, [[0.13322297, 9.381591, 0.8710387], [-0.20881577, 9.42485, 0.7918533]])
    assert log.t.tolist() == [0.0, 0.1] and log.gyr is None


def _mat5_element(body: bytes, compress: bool) -> bytes:
    """One top-level MAT v5 miMATRIX element around ``body`` (its subelements), zlib-compressed (miCOMPRESSED) as
    MATLAB's default -v7 writes it when ``compress``."""
    import struct
    import zlib

    el = struct.pack("<II", 14, len(body)) + body
    return struct.pack("<II", 15, len(z := zlib.compress(el))) + z if compress else el


def _mat5_sub(typ: int, payload: bytes) -> bytes:
    import struct

    return struct.pack("<II", typ, len(payload)) + payload + b"\0" * (-len(payload) % 8)


@pytest.mark.parametrize("compress", [False, True])
def test_matlab_mobile_timetables_are_named_with_the_way_out(tmp_path, compress):
    """MATLAB Mobile logs to sensorlog_*.mat, each sensor a timetable (Acceleration, AngularVelocity, …; read in
    MATLAB as Acceleration.X, Acceleration.Timestamp by users' scripts on GitHub): MATLAB objects (opaque MCOS
    arrays: the variable's name, 'MCOS', the class name, then a uint32 reference) that scipy returns as an opaque
    'None' without numbers. Was 'not a readable MATLAB file (the variable at byte 128: dimensions of another type or
    size); save it again from MATLAB (-v7)', which cannot help. Now the objects are named with the MATLAB lines that
    save their numbers, and the files those lines write read to their truth."""
    import struct

    sub = _mat5_sub
    ref = sub(6, struct.pack("<II", 13, 0)) + sub(5, struct.pack("<ii", 6, 1)) + sub(1, b"")
    ref = struct.pack("<II", 14, len(ref + sub(6, bytes(24)))) + ref + sub(6, bytes(24))
    objects = [
        _mat5_element(sub(6, struct.pack("<II", 17, 0)) + sub(1, n.encode()) + sub(1, b"MCOS") + sub(1, b"timetable") + ref, compress)
        for n in ("Acceleration", "AngularVelocity", "MagneticField")
    ]  # fmt: skip
    head = b"MATLAB 5.0 MAT-file, Platform: MACI64, Created on: Wed May  1 10:00:00 2024".ljust(116) + bytes(8)
    path = _w(tmp_path / "sensorlog_20240501_100000.mat", head + struct.pack("<H", 0x0100) + b"IM" + b"".join(objects))
    with pytest.raises(OptinavError, match=r"holds MATLAB objects.*Acceleration \(timetable\), AngularVelocity") as err:
        read_imu(path)
    assert "posixtime(Acceleration.Timestamp)" in err.value.remedy and "gyro_path=gyro.mat" in err.value.remedy
    from scipy.io import savemat  # what the remedy's MATLAB lines write: t (N×1, s since 1970), acc / gyro (N×3)

    gyr, acc = _triads(19, 400)
    t = 1714557600.0 + np.arange(400) / 100.0
    savemat(tmp_path / "acc.mat", {"t": t[:, None], "acc": acc})
    savemat(tmp_path / "gyro.mat", {"t": t[:, None] + 0.004, "gyro": gyr})
    log = read_imu(tmp_path / "acc.mat", gyro_path=tmp_path / "gyro.mat")
    np.testing.assert_array_equal(log.acc, acc[1:])  # the first row lies before the gyroscope's first
    np.testing.assert_allclose(log.t, t[1:], rtol=0, atol=1e-9)
    want = np.array([np.interp(t[1:], t + 0.004, g) for g in gyr.T]).T
    np.testing.assert_allclose(log.gyr, want, rtol=0, atol=1e-9)


def test_px4_vehicle_imu_increments_read_as_rates(tmp_path, capsys):
    """PX4's vehicle_imu from ulog2csv: delta_angle[0..2] (rad) and delta_velocity[0..2] (m/s) over
    delta_angle_dt / delta_velocity_dt (µs), stamped by timestamp_sample (µs). Was refused (no accelerometer or
    gyroscope, no option helped), and sensor_combined needed --time-unit us; now the increments over their periods
    are the rates, the sample stamp the time, with no option, through `optinav allan` too."""
    n = 4000
    gyr, acc = _triads(16, n, down=-9.81)
    dt = np.where(np.arange(n) % 7 == 3, 4001, 3999)  # µs: the integration period varies a little
    stamp = 12_000_000 + np.cumsum(dt)
    hdr = "timestamp,timestamp_sample,accel_device_id,gyro_device_id,delta_angle[0],delta_angle[1],delta_angle[2],"
    hdr += "delta_velocity[0],delta_velocity[1],delta_velocity[2],delta_angle_dt,delta_velocity_dt,"
    hdr += "delta_angle_clipping,delta_velocity_clipping,accel_calibration_count,gyro_calibration_count"
    rows = [
        ",".join(
            [str(stamp[i] + 250), str(stamp[i]), "2490378", "2490634"]
            + [repr(float(v)) for v in (*(gyr[i] * dt[i] * 1e-6), *(acc[i] * dt[i] * 1e-6))]
            + [str(dt[i]), str(dt[i]), "0", "0", "1", "1"]
        )
        for i in range(n)
    ]
    path = _w(tmp_path / "log_3_2024-5-1-10-00-00_vehicle_imu_0.csv", "\n".join([hdr, *rows]) + "\n")
    log = read_imu(path)
    np.testing.assert_allclose(log.t, stamp * 1e-6, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.gyr, gyr, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(log.acc, acc, rtol=1e-12, atol=1e-15)
    code = main(["--quiet", "allan", str(path), "--out", str(tmp_path / "a.json")])
    assert code == 0, capsys.readouterr().err
    res = Result.from_json(tmp_path / "a.json")
    assert res.rate_hz == pytest.approx(1e6 / dt.mean(), rel=1e-3)
    for sensor, sigma in (("accelerometer", 0.02), ("gyroscope", 0.002)):  # white noise N = σ/√rate
        fit = res.sensor(sensor)["fit"]
        assert np.all(np.abs(fit.white - sigma / np.sqrt(res.rate_hz)) <= 3.0 * fit.white_std), (sensor, fit.white)


def test_rows_ending_in_a_delimiter_under_a_header_that_does_not(tmp_path):
    """An Arduino sketch printing Serial.print(v); Serial.print(",") for every value ends each row in a comma
    (CRLF from println) under a header printed without one: was "line 2 has 8 field(s), 7 expected (too long or
    ragged row)" for every file; the empty last column is now left aside, as when the header ends in a comma too.
    A row that is really longer is still named."""
    rng = np.random.default_rng(17)
    n = 600
    acc = rng.integers(-200, 200, (n, 3)) + [0, 0, 16384]
    gyr = rng.integers(-30, 30, (n, 3))
    rows = "".join(",".join(map(str, [5 * i, *acc[i], *gyr[i]])) + ",\r\n" for i in range(n))
    path = _w(tmp_path / "LOG00042.CSV", "ms,ax,ay,az,gx,gy,gz\r\n" + rows)
    for log in (read_imu(path, acc_unit="counts", gyro_unit="counts"),):
        np.testing.assert_array_equal(log.acc, acc)
        np.testing.assert_array_equal(log.gyr, gyr)
        np.testing.assert_allclose(log.t, 0.005 * np.arange(n), rtol=0, atol=1e-12)
    blocks = list(iter_imu(path, acc_unit="counts", gyro_unit="counts", chunk_rows=100))
    np.testing.assert_array_equal(np.concatenate([b.acc for b in blocks]), acc)
    bad = _w(tmp_path / "bad.csv", "ms,ax,ay,az\n" + "".join(f"{i},1,2,3,\n" for i in range(20)) + "20,1,2,3,4,5\n")
    with pytest.raises(OptinavError, match="line 22"):
        read_imu(bad, acc_unit="counts")


def test_lines_of_named_values_as_arduino_sketches_print_them(tmp_path, capsys):
    """The classic MPU-6050 sketch prints 'AcX = -1234 | AcY = 56 | … | Tmp = 36.53 | GyX = …' and the Arduino
    Serial Plotter reads 'ax:12,ay:5,…': refused as "the header names column '=' twice" (and one such line under
    start-up text was taken for a key: value preamble). The names are now the columns (AcX/GyX as ax/gx), a
    start-up line above them is left out, a garbled line further down is named; read whole and in blocks."""
    rng = np.random.default_rng(18)
    n = 600
    acc = rng.integers(-200, 200, (n, 3)) + [0, 0, 16384]
    gyr = rng.integers(-30, 30, (n, 3))
    mpu = "".join(
        f"AcX = {acc[i, 0]} | AcY = {acc[i, 1]} | AcZ = {acc[i, 2]} | Tmp = 36.53 | "
        f"GyX = {gyr[i, 0]} | GyY = {gyr[i, 1]} | GyZ = {gyr[i, 2]}\n"
        for i in range(n)
    )
    plot = "".join(
        f"t:{5 * i},ax:{acc[i, 0]},ay:{acc[i, 1]},az:{acc[i, 2]},gx:{gyr[i, 0]},gy:{gyr[i, 1]},gz:{gyr[i, 2]}\r\n"
        for i in range(n)
    )
    counts = {"acc_unit": "counts", "gyro_unit": "counts"}
    for name, text, kw in (
        ("mpu.txt", mpu, {"rate_hz": 200.0}),
        ("boot.txt", "MPU6050 connection successful\n" + mpu, {"rate_hz": 200.0}),
        ("plotter.txt", plot, {"time_unit": "ms"}),
    ):
        path = _w(tmp_path / name, text)
        for log in (read_imu(path, **counts, **kw), *iter_imu(path, **counts, **kw, chunk_rows=10**6)):
            np.testing.assert_array_equal(log.acc, acc)
            np.testing.assert_array_equal(log.gyr, gyr)
            np.testing.assert_allclose(log.t, 0.005 * np.arange(n), rtol=0, atol=1e-12)
        blocks = list(iter_imu(path, **counts, **kw, chunk_rows=100))
        np.testing.assert_array_equal(np.concatenate([b.gyr for b in blocks]), gyr)
    code = main(["allan", str(tmp_path / "mpu.txt"), "--out", str(tmp_path / "a.json")])
    assert code == 2 and "pass --rate HZ" in capsys.readouterr().err
    lines = mpu.splitlines(keepends=True)
    bad = _w(tmp_path / "reset.txt", "".join(lines[:300] + ["MPU6050 reset!\n"] + lines[300:]))
    with pytest.raises(OptinavError, match="line 301 has 1 field"):
        read_imu(bad, **counts, rate_hz=200.0)


def test_rostopic_csv_of_two_imus_on_one_topic_is_refused(tmp_path, capsys):
    """`rostopic echo -p` of a topic on which two IMUs publish (field.header.frame_id imu_a, imu_b alternating):
    the frame id was left out as text and the rows read as one log at twice the rate, exit 0 from the reader (the
    commands then named the time unit or '--rate' with the time column skipped, which mixes the sensors in
    silence). Now it is refused naming the frames; a frame_id that changes once (a driver restarted) is read."""
    n, t0 = 300, 1403636579758555392
    gyr, acc = _triads(19, 2 * n)
    hdr = "%time,field.header.seq,field.header.stamp,field.header.frame_id,"
    hdr += ",".join(f"field.{f}.{a}" for f in ("angular_velocity", "linear_acceleration") for a in "xyz")

    def write(name, frames):
        rows = [
            f"{t0 + i * 2_500_000 + 4321},{i},{t0 + i * 2_500_000},{frames[i]},"
            + ",".join(map(repr, (*gyr[i].tolist(), *acc[i].tolist())))
            for i in range(2 * n)
        ]
        return _w(tmp_path / name, hdr + "\n" + "\n".join(rows) + "\n")

    two = write("two.csv", ["imu_a", "imu_b"] * n)
    with pytest.raises(OptinavError, match="holds 2 sensor frames \\('imu_a', 'imu_b'\\)") as exc:
        read_imu(two)
    assert "--topic TOPIC@FRAME" in exc.value.remedy
    code = main(["attitude", str(two), "--chunk-rows", "100", "--out", str(tmp_path / "q.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "sensor frames" in err and "--topic @imu_a" in err
    # --topic @FRAME reads one frame's rows (as TOPIC@FRAME does in a bag), whole and in blocks
    for log in (read_imu(two, topic="@imu_b"), *iter_imu(two, topic="@imu_b", chunk_rows=10 * n)):
        np.testing.assert_array_equal(log.gyr, gyr[1::2])
        np.testing.assert_allclose(np.diff(log.t), 0.005, rtol=0, atol=1e-6)
    log = read_imu(write("restart.csv", ["imu"] * n + ["imu_2"] * n))
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_allclose(np.diff(log.t), 0.0025, rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    "name, head, what, export",
    [
        ("00000042.BIN", b"\xa3\x95\x80\x80\x59FMT\x00", "an ArduPilot DataFlash log", "mavlogdump.py --format csv"),
        (
            "00000042.log",
            b"FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n",
            "DataFlash text log",
            "mavlogdump",
        ),
    ],
)
def test_flight_logs_name_the_export_that_reads(tmp_path, capsys, name, head, what, export):
    """ArduPilot's DataFlash logs (.BIN; Mission Planner's text .log) as they come off the flight controller:
    "unknown data file type .BIN" (use one of .csv, …) and, for the text log, "the header names column 'FMT'
    twice". Each is now named with the export whose CSV optinav reads as it is (PX4's ULog is read as it comes:
    tests/test_ulog.py)."""
    rows = "".join(f"IMU, {60000000 + 2500 * i}, 0, 0.001, -0.002, 0.0, 0.01, -0.02, -9.8\n" for i in range(50))
    body = rows.encode() if head.startswith(b"FMT") else bytes(range(256)) * 8
    path = _w(tmp_path / name, head + body)
    for cmd in (["allan"], ["calibrate", "accel"]):
        assert main([*cmd, str(path), "--out", str(tmp_path / "r.json")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and what in err[0] and export in err[0], err


def test_a_serial_capture_starting_in_boot_noise_reads(tmp_path):
    """An ESP32/Arduino serial capture opened while the board boots: bytes at another baud rate (NULs among them),
    the ROM's reset lines, then the sketch's table. Was refused as "looks binary (it contains NUL bytes)"; the
    noise lines are now left out above the table with a note (whole and in blocks). NULs further down, or in a
    file of no text, still make it binary."""
    rng = np.random.default_rng(20)
    n = 600
    acc = rng.integers(-200, 200, (n, 3)) + [0, 0, 16384]
    gyr = rng.integers(-30, 30, (n, 3))
    body = "ax,ay,az,gx,gy,gz\r\n" + "".join(",".join(map(str, [*acc[i], *gyr[i]])) + "\r\n" for i in range(n))
    boot = b"\xf8\x80\x00\xa5\xa5\r\nets Jun  8 2016 00:22:57\r\n\x00\x00\xe0\r\nrst:0x1 (POWERON_RESET),boot:0x13\r\n"
    path = _w(tmp_path / "capture.txt", boot + body.encode())
    kw = {"acc_unit": "counts", "gyro_unit": "counts", "rate_hz": 100.0}
    log = read_imu(path, **kw)
    np.testing.assert_array_equal(log.acc, acc)
    np.testing.assert_array_equal(log.gyr, gyr)
    assert any("4 line(s) above the table ('(binary noise)'" in x for x in log.notes), log.notes
    blocks = list(iter_imu(path, **kw, chunk_rows=100))
    np.testing.assert_array_equal(np.concatenate([b.acc for b in blocks]), acc)
    lines = body.encode().split(b"\r\n")
    late = _w(tmp_path / "late.txt", b"\r\n".join(lines[:400] + [b"\x00\x00"] + lines[400:]))
    for read in (lambda: read_imu(late, **kw), lambda: list(iter_imu(late, **kw, chunk_rows=100))):
        with pytest.raises(OptinavError, match="looks binary"):
            read()


def test_a_nul_line_inside_a_short_table_is_named_not_taken_for_boot_noise(tmp_path):
    """Boot noise is only the lines that hold NULs: in a short file (all within the first 4 KiB) a NUL line in the
    table is an error at its line, the rows above it are not left out as noise."""
    rows = ["t,ax,ay,az"] + [f"{i / 100},0,0,9.8" for i in range(40)]
    path = _w(tmp_path / "short.csv", ("\n".join(rows[:21] + ["\x00\x01"] + rows[21:]) + "\n").encode())
    with pytest.raises(OptinavError, match="line 22"):
        read_imu(path)


def test_a_capture_with_the_serial_monitors_timestamps_reads(tmp_path, capsys):
    """The Arduino IDE's serial monitor with "Show timestamp" puts '14:23:01.123 -> ' before every line: the
    header became '14:23:00.000 -> t_ms' and every first cell text, left out ("no accelerometer or gyroscope
    data"). The receive time is now cut off with a note (the computer's, in bursts of USB packets: no sample
    time) and the sketch's own millis() column is the time; whole and in blocks."""
    rng = np.random.default_rng(21)
    n = 600
    acc = rng.integers(-200, 200, (n, 3)) + [0, 0, 16384]
    gyr = rng.integers(-30, 30, (n, 3))

    def stamp(i):
        s = i * 7 // 1000  # received in bursts
        return f"14:{23 + s // 60:02d}:{s % 60:02d}.{i * 7 % 1000:03d} -> "

    text = stamp(0) + "MPU6050 connection successful\r\n" + stamp(0) + "t_ms,ax,ay,az,gx,gy,gz\r\n"
    text += "".join(stamp(i) + ",".join(map(str, [5 * i, *acc[i], *gyr[i]])) + "\r\n" for i in range(n))
    path = _w(tmp_path / "monitor.txt", text)
    kw = {"acc_unit": "counts", "gyro_unit": "counts"}
    log = read_imu(path, **kw)
    np.testing.assert_array_equal(log.acc, acc)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_allclose(log.t, 0.005 * np.arange(n), rtol=0, atol=1e-12)
    assert any("serial monitor's receive times" in x for x in log.notes), log.notes
    blocks = list(iter_imu(path, **kw, chunk_rows=100))
    np.testing.assert_array_equal(np.concatenate([b.gyr for b in blocks]), gyr)
    assert any("serial monitor's receive times" in x for x in blocks[0].notes)


def _garbled(tmp_path, rng, n=1200, time=True, bad=(301, 702, 703)):
    """A serial capture of ``n`` rows with a garbled cell, a cut line and two lines run together at the file lines
    ``bad`` (1-based, header = line 1): (path, t, acc, gyr, the rows that lines ``bad`` held)."""
    t = np.arange(n) / 100.0
    v = np.round(rng.normal(0, 0.05, (n, 6)) + [0, 0, 9.81, 0, 0, 0], 5)  # at rest, z up
    rows = [",".join(f"{x:g}" for x in ([t[i]] if time else []) + list(v[i])) for i in range(n)]
    lines = [("t," if time else "") + "ax,ay,az,gx,gy,gz", *rows]
    lines[bad[0] - 1] = lines[bad[0] - 1].replace(".", "x", 2)  # '0x31…': a byte flipped on the line
    lines[bad[1] - 1] = lines[bad[1] - 1][:9]  # cut short
    lines[bad[2] - 1] = lines[bad[2] - 1] + lines[bad[2] - 1]  # a newline lost: two lines run together
    f = tmp_path / ("cap.csv" if time else "cap_rate.csv")
    f.write_text("\n".join(lines) + "\n")
    return f, t, v[:, :3], v[:, 3:], [b - 2 for b in bad]


def test_garbled_lines_are_named_or_skipped_with_a_note(tmp_path, capsys):
    """A serial capture with corrupted lines mid-file was refused with no way through; the error now names the
    line and --skip-bad-lines, which leaves such lines out with a note naming them (whole and in blocks): with a
    time column the rows are gone and the other rows keep their times; without one they are NaN rows where they
    stood, so the rate keeps timing the rows after them. More than 1 % of the lines unreadable is refused."""
    rng = np.random.default_rng(41)
    f, t, acc, gyr, lost = _garbled(tmp_path, rng)
    assert main(["attitude", str(f), "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 301, column 1" in err[0] and "--skip-bad-lines" in err[0], err
    keep = np.setdiff1d(np.arange(t.size), lost)
    whole = read_imu(f, skip_bad_lines=True)
    blocks = list(iter_imu(f, skip_bad_lines=True, chunk_rows=250))
    for log in (whole, blocks):
        got = (
            (lambda k: np.concatenate([getattr(b, k) for b in log])) if isinstance(log, list) else log.__getattribute__
        )
        assert np.array_equal(got("t"), t[keep]) and np.array_equal(got("acc"), acc[keep])
        assert np.array_equal(got("gyr"), gyr[keep])
    assert any("3 unreadable lines 301, 702, 703 left out" in n for n in whole.notes), whole.notes
    assert sum(len(b.notes) for b in blocks) >= 1
    g, t, acc, gyr, lost = _garbled(tmp_path, rng, time=False)
    for log in (
        read_imu(g, rate_hz=100.0, skip_bad_lines=True),
        list(iter_imu(g, rate_hz=100.0, skip_bad_lines=True, chunk_rows=250)),
    ):
        got = (
            (lambda k: np.concatenate([getattr(b, k) for b in log])) if isinstance(log, list) else log.__getattribute__
        )
        np.testing.assert_allclose(got("t"), t, rtol=0, atol=1e-12)
        assert np.isnan(got("acc")[lost]).all() and np.array_equal(got("gyr")[keep], gyr[keep])
    h, *_ = _garbled(tmp_path, rng, n=200, bad=(50, 90, 91))
    for read in (
        lambda: read_imu(h, skip_bad_lines=True),
        lambda: list(iter_imu(h, skip_bad_lines=True, chunk_rows=60)),
    ):
        with pytest.raises(
            OptinavError, match=r"3 of 200 data lines are unreadable \(lines 50, 90, 91\), more than 1%"
        ):
            read()


def test_skip_bad_lines_reaches_every_command_that_reads_a_log(tmp_path, capsys):
    """attitude (whole and in blocks), allan and calibrate accel take --skip-bad-lines (before: unknown option)."""
    rng = np.random.default_rng(42)
    f, *_ = _garbled(tmp_path, rng, n=3000, bad=(1501, 2001, 2002))
    for extra in ([], ["--chunk-rows", "700"]):
        assert (
            main(["attitude", str(f), "--frame", "ENU", "--skip-bad-lines", "--out", str(tmp_path / "a.csv"), *extra])
            == 0
        )
        assert "3 unreadable lines 1501, 2001, 2002 left out" in capsys.readouterr().err
    # allan needs a regular record: the lines left out are a gap it names, no wrong deviation
    assert main(["allan", str(f), "--skip-bad-lines", "--out", str(tmp_path / "n.json")]) == 2
    assert "not regularly sampled" in capsys.readouterr().err


@pytest.mark.skipif(not (DATA_IMUCAL / "example_ferraris_session.csv").is_file(), reason="imucal data absent")
def test_imucal_session_with_a_garbled_line_calibrates_as_the_clean_one(tmp_path, capsys):
    """imucal's Ferraris session (no time column: --rate 102.4) with one line garbled mid-file: refused naming the
    line and --skip-bad-lines; with it the sample is lost where it stood (the rate keeps the turns' timing) and
    every parameter is within 1 % of its std of the clean file's."""
    import json

    src = DATA_IMUCAL / "example_ferraris_session.csv"
    lines = src.read_text().split("\n")
    lines[5001] = lines[5001].replace(".", "x", 1)
    bad = tmp_path / "session.csv"
    bad.write_text("\n".join(lines))
    argv = ["calibrate", "accel", "--rate", "102.4", "--gravity", "9.81", "--gyro-unit", "deg/s", "--out"]
    assert main([*argv, str(tmp_path / "clean.json"), str(src)]) == 0
    assert main([*argv, str(tmp_path / "bad.json"), str(bad)]) == 2
    assert "line 5002" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "bad.json"), str(bad), "--skip-bad-lines"]) == 0
    assert "1 unreadable line 5002 read as lost samples" in capsys.readouterr().err
    a, b = (json.loads((tmp_path / n).read_text())["parameters"] for n in ("clean.json", "bad.json"))
    for k, p in a.items():
        if p["value"] is not None:
            assert abs(b[k]["value"] - p["value"]) <= 0.01 * p["std"], k


def test_a_garbled_line_of_a_nine_axis_capture_without_time_keeps_the_magnetometer_in_step(tmp_path, capsys):
    """An MPU9250 capture (acc, gyro, mag; no time column) with one corrupted line: --skip-bad-lines put a NaN row
    where the line stood in the IMU's rows but left it out of the magnetometer's, and `attitude --mag` ended in
    "the magnetometer has 2999 rows, the IMU 3000". Now the magnetometer keeps the row too: the estimate equals
    the one of the file with that line written as NaN, streamed in blocks or not."""
    rng = np.random.default_rng(0)
    n = 3000
    rows = np.column_stack(
        [
            np.tile([0, 0, 9.81], (n, 1)) + rng.normal(0, 0.02, (n, 3)),
            rng.normal(0, 0.002, (n, 3)),
            np.tile([20.0, 0, -40.0], (n, 1)) + rng.normal(0, 0.2, (n, 3)),
        ]
    )
    lines = ["ax,ay,az,gx,gy,gz,mx,my,mz"] + [",".join(f"{v:.6f}" for v in r) for r in rows]
    bad, nan = tmp_path / "bad.csv", tmp_path / "nan.csv"
    nan.write_text("\n".join([*lines[:1500], ",".join(["nan"] * 9), *lines[1501:]]) + "\n")
    lines[1500] = "0.01,0.02,9.8x1,0.001,0.1,0.1,20,0,-40"
    bad.write_text("\n".join(lines) + "\n")
    common = ["--quiet", "attitude", "--frame", "ENU", "--rate", "100", "--mag", "--drop-nan"]
    assert main([*common, str(nan), "--out", str(tmp_path / "ref.csv")]) == 0
    ref = np.loadtxt(tmp_path / "ref.csv", delimiter=",", skiprows=1)
    for chunk in ("1000000", "700"):
        out = tmp_path / f"o{chunk}.csv"
        assert main([*common, str(bad), "--skip-bad-lines", "--chunk-rows", chunk, "--out", str(out)]) == 0
        np.testing.assert_array_equal(np.loadtxt(out, delimiter=",", skiprows=1), ref)
    assert "line 1501" in capsys.readouterr().err


def test_skip_bad_lines_alone_takes_a_capture_without_time_through_attitude(tmp_path, capsys):
    """A capture without a time column with one corrupted line: `attitude --skip-bad-lines` read the line as a lost
    sample (a NaN row, so that the rate times the rows after it) and then refused that row, asking for --drop-nan
    as well — two flags for one request. --skip-bad-lines alone now leaves the row out, the step over it two
    samples long (streamed or not, and through read_log): the same estimate as the file with that line written as
    NaN and --drop-nan, without the lost sample's time; a NaN row without --skip-bad-lines is still refused."""
    from optinav.attitude.unit import AttitudeOptions, read_log

    rng = np.random.default_rng(3)
    n = 3000
    t = np.arange(n) / 100.0
    # turning about the vertical (the accelerometer sees gravity still)
    gyr = np.column_stack([np.zeros(n), np.zeros(n), 0.3 * np.sin(0.7 * t)]) + rng.normal(0, 2e-3, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.02, (n, 3))
    lines = ["ax,ay,az,gx,gy,gz"] + [",".join(f"{v:.6f}" for v in r) for r in np.column_stack([acc, gyr])]
    bad, nan = tmp_path / "bad.csv", tmp_path / "nan.csv"
    nan.write_text("\n".join([*lines[:1201], ",".join(["nan"] * 6), *lines[1202:]]) + "\n")
    lines[1201] = "0.01,0.02,9.8x1,0.001,0.1,0.1"
    bad.write_text("\n".join(lines) + "\n")
    common = ["--quiet", "attitude", "--frame", "ENU", "--rate", "100"]
    assert main([*common, str(nan), "--out", str(tmp_path / "refused.csv")]) == 2
    assert "--drop-nan" in capsys.readouterr().err
    assert main([*common, str(nan), "--drop-nan", "--out", str(tmp_path / "ref.csv")]) == 0
    ref = np.loadtxt(tmp_path / "ref.csv", delimiter=",", skiprows=1)
    assert ref.shape[0] == n - 1 and not np.any(np.isclose(ref[:, 0], t[1200]))
    for chunk in ("1000000", "700"):
        out = tmp_path / f"o{chunk}.csv"
        assert main([*common, str(bad), "--skip-bad-lines", "--chunk-rows", chunk, "--out", str(out)]) == 0
        np.testing.assert_array_equal(np.loadtxt(out, delimiter=",", skiprows=1), ref)
    assert "left out (--skip-bad-lines)" in capsys.readouterr().err
    with pytest.warns(UserWarning, match="--skip-bad-lines"):
        tt, g, a, _, _ = read_log(bad, AttitudeOptions(rate_hz=100.0, skip_bad_lines=True))
    assert tt.size == n - 1 and np.all(np.isfinite(g)) and np.all(np.isfinite(a))


def test_imu_tk_data_one_sensor_per_headerless_file_calibrates_as_one_table(tmp_path, capsys):
    """imu_tk's data (its "Matlab matrix" .mat files: text lines ``timestamp x y z``, one sensor per file, raw
    counts of an offset-binary ADC around 32768): `calibrate accel xsens_acc.mat --gyro xsens_gyro.mat` was refused
    ("no accelerometer data; found col1..col4") with an example of seven column names for a file of four. The
    pair is now read as t,ax,ay,az and t,gx,gy,gz with a note, and calibrates exactly as the same samples in one
    named table; a file of four without --gyro names the four names and --gyro; a first column that decreases is
    no time, and is not taken for one."""
    import json

    session = tmp_path / "s.csv"
    sim = ["--quiet", "simulate", "accel-multipos", "--out", str(session), "--dwell", "4", "--seed", "2"]
    assert main([*sim, "--acc-unit", "counts", "--gyro-unit", "counts"]) == 0
    d = np.loadtxt(session, delimiter=",", comments="#", skiprows=3)
    t, acc, gyr = d[:, 0] + 1.4e9, np.round(d[:, 1:4]) + 32768, np.round(d[:, 4:7]) + 32768
    one = tmp_path / "one.csv"
    np.savetxt(one, np.column_stack([t, acc, gyr]), fmt="%.6f", delimiter=",", header="t,ax,ay,az,gx,gy,gz",
               comments="")  # fmt: skip
    a, g = tmp_path / "xsens_acc.mat", tmp_path / "xsens_gyro.mat"
    np.savetxt(a, np.column_stack([t, acc]), fmt="%.6f %d %d %d")
    np.savetxt(g, np.column_stack([t, gyr]), fmt="%.6f %d %d %d")
    units = ["--acc-unit", "counts", "--gyro-unit", "counts"]
    assert main(["--quiet", "calibrate", "accel", str(one), *units, "--out", str(tmp_path / "one.json")]) == 0
    capsys.readouterr()
    assert main(["calibrate", "accel", str(a), "--gyro", str(g), *units, "--out", str(tmp_path / "pair.json")]) == 0
    err = capsys.readouterr().err
    assert "xsens_acc.mat: no header; its 4 columns read as t,ax,ay,az" in err
    assert "xsens_gyro.mat: no header; its 4 columns read as t,gx,gy,gz" in err
    p1, p2 = (json.loads((tmp_path / n).read_text())["parameters"] for n in ("one.json", "pair.json"))
    for k, v in p1.items():
        assert v["value"] == p2[k]["value"] or (v["value"] is None and p2[k]["value"] is None), k
    assert main(["calibrate", "accel", str(a), *units, "--out", str(tmp_path / "x.json")]) == 2
    assert "--columns 't,ax,ay,az' and the gyroscope's file as --gyro GYRODATA" in capsys.readouterr().err
    rev = tmp_path / "rev_acc.txt"
    np.savetxt(rev, np.column_stack([t[::-1], acc]), fmt="%.6f %d %d %d")
    assert main(["calibrate", "accel", str(rev), "--gyro", str(g), *units, "--out", str(tmp_path / "y.json")]) == 2
    assert "has no accelerometer data" in capsys.readouterr().err


def _dot_export(s, tail=",,,,,,,,,,,,,,,,,"):
    """A Movella DOT app/SDK CSV export of session ``s`` (m/s^2, deg/s): Excel's 'sep=,' line, 'Key:,value' lines
    padded with commas, the copyright line, a blank line, then the table timed by SampleTimeFine (µs)."""
    head = ["DeviceTag:,Left wrist", "FirmwareVersion:,2.4.0", "AppVersion:,2023.3.0", "SyncStatus:,Synced"]
    head += ["OutputRate:,100Hz", "FilterProfile:,General", "Measurement Mode:,Custom Mode 27"]
    head += ["StartTime:,2023-11-14 14:13:20.000 +0100", "Movella Technologies B. V. 2005-2023,"]
    rows = "".join(
        f"{i},{123456 + 10_000 * i},0.5,-0.25,10.0,{','.join(f'{v:.6f}' for v in (*s.acc[i], *s.gyr[i]))},0\n"
        for i in range(len(s.t))
    )
    cols = "PacketCounter,SampleTimeFine,Euler_X,Euler_Y,Euler_Z,Acc_X,Acc_Y,Acc_Z,Gyr_X,Gyr_Y,Gyr_Z,Flag\n"
    return "sep=,\n" + "".join(h + tail + "\n" for h in head) + "\n" + cols + rows


@pytest.mark.parametrize("tail", [",,,,,,,,,,,,,,,,,", ""])
def test_a_movella_dot_export_reads_its_rate_and_names_the_gyro_unit(tmp_path, capsys, tail):
    """A Movella DOT export ('Key:,value' settings lines padded with commas above the table, the rate in
    'OutputRate:,100Hz', Gyr_* in deg/s) was refused as a ragged row ('line 12 has 12 field(s), 19 expected'; unpadded
    'line 12 has 12 field(s), 2 expected'), naming --skip-bad-lines, which cannot help. Its settings are a preamble now, the
    rate read from it; calibrate names the gyro's unit, and with it gives the truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="deg/s", rng=7)
    path = _w(tmp_path / "Left wrist_20231114_141320_000.csv", _dot_export(s, tail).encode())
    log = read_imu(path, gyro_unit="deg/s")
    np.testing.assert_allclose(log.t - log.t[0], np.arange(len(s.t)) / 100.0, atol=1e-12)
    np.testing.assert_allclose(log.acc, np.round(s.acc, 6), atol=1e-12)
    assert any("SampleTimeFine read as the time, in ticks of 1 µs" in n for n in log.notes), log.notes
    out = tmp_path / "r.json"
    argv = ["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]
    assert main(argv) == 2
    assert "--gyro-unit deg/s" in capsys.readouterr().err
    assert main([*argv, "--gyro-unit", "deg/s"]) == 0
    _acc_scales_match(out, s)


def _metabase(t, values, unit):
    """A MetaWear MetaBase CSV of one sensor: epoch (ms), the local clock as text under its UTC offset, elapsed (s),
    then the axes with the unit in brackets."""
    head = f"epoch (ms),time (-08:00),elapsed (s),x-axis ({unit}),y-axis ({unit}),z-axis ({unit})\n"
    rows = []
    for ti, v in zip(t, values):
        ms = 1_700_000_000_000 + int(round(ti * 1000))
        clock = datetime.datetime.fromtimestamp(ms / 1000, datetime.timezone(datetime.timedelta(hours=-8)))
        rows.append(
            f"{ms},{clock.strftime('%Y-%m-%dT%H.%M.%S.%f')[:-3]},{ti - t[0]:.3f},{v[0]:.6f},{v[1]:.6f},{v[2]:.6f}\n"
        )
    return head + "".join(rows)


def test_metawear_metabase_files_read_by_the_units_of_their_axes(tmp_path, capsys):
    """MetaWear's MetaBase writes one file per sensor, 'epoch (ms),time (-08:00),elapsed (s),x-axis (g),…' (the gyro's
    'x-axis (deg/s)'): refused at the first row ("'2023-11-14T14.13.20.000' is not a number"), the local clock under
    its UTC offset taken for the time; and with it skipped, 'x-axis' named no sensor. The clock is left out as text,
    elapsed (s) is the time and the unit in brackets names the sensor: the pair calibrates to the truth, as the
    session in one file does."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="g", gyro_unit="deg/s", rng=3)
    acc = _w(tmp_path / "MetaWear_Accelerometer.csv", _metabase(s.t, s.acc, "g").encode())
    gyro = _w(tmp_path / "MetaWear_Gyroscope.csv", _metabase(s.t, s.gyr, "deg/s").encode())
    log = read_imu(acc, gyro_path=gyro)
    assert log.acc_input_unit == "g" and log.gyro_input_unit == "deg/s"
    np.testing.assert_allclose(log.t, np.round(s.t - s.t[0], 3), atol=1e-9)
    np.testing.assert_allclose(log.gyr, np.radians(np.round(s.gyr, 6)), atol=1e-12)
    out = tmp_path / "r.json"
    assert (
        main(["calibrate", "accel", str(acc), "--gyro", str(gyro), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    )
    assert "'time (-08:00)' hold text and were left out" in capsys.readouterr().err
    r = _acc_scales_match(out, s)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]), np.diag(s.gyr_K), rtol=5e-3)


@pytest.mark.parametrize("unit", ["a.u.", "T", ""])
def test_axes_whose_unit_names_no_sensor_stay_unnamed(tmp_path, unit):
    """A magnetometer's, raw counts' or no unit on 'x-axis' says nothing of the sensor: the error asks for the mapping."""
    head = ",".join(f"{a}-axis ({unit})" if unit else f"{a}-axis" for a in "xyz")
    f = _w(tmp_path / "m.csv", "elapsed (s)," + head + "\n" + "".join(f"{i / 100},1,2,3\n" for i in range(20)))
    with pytest.raises(OptinavError, match="no accelerometer or gyroscope"):
        read_imu(f)


def test_androsensor_export_takes_the_accelerometer_and_its_clock(tmp_path, capsys):
    """AndroSensor's CSV (';', 'ACCELEROMETER X (m/s²)', 'GRAVITY X (m/s²)', 'LINEAR ACCELERATION X (m/s²)' — the
    phone's gravity-free acceleration —, 'GYROSCOPE X (rad/s)', 'Time since start in ms ', a local date-time) was
    refused as 'ACCELEROMETER X and LINEAR ACCELERATION X both look like ax', one axis per run, and then as a file
    without time. The linear acceleration is passed over (a note says so), the time read in ms: the session
    calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=5)
    ms = np.round((s.t - s.t[0]) * 1000).astype(int)
    head = ";".join(
        [f"ACCELEROMETER {a} (m/s²)" for a in "XYZ"]
        + [f"GRAVITY {a} (m/s²)" for a in "XYZ"]
        + [f"LINEAR ACCELERATION {a} (m/s²)" for a in "XYZ"]
        + [f"GYROSCOPE {a} (rad/s)" for a in "XYZ"]
        + ["Time since start in ms ", "YYYY-MO-DD HH-MI-SS_SSS"]
    )
    rows = "".join(
        ";".join(f"{v:.6f}" for v in (*s.acc[i], *s.acc[i], *(0.01 * s.acc[i]), *s.gyr[i]))
        + f";{ms[i]};2023-11-14 14:13:{20 + ms[i] // 1000:02d}:{ms[i] % 1000:03d}\n"
        for i in range(len(s.t))
    )
    path = _w(tmp_path / "Sensor_record_20231114_141320_AndroSensor.csv", (head + "\n" + rows).encode())
    log = read_imu(path)
    np.testing.assert_allclose(log.t, ms / 1000.0, atol=1e-12)
    np.testing.assert_allclose(log.acc, np.round(s.acc, 6), atol=1e-12)
    assert any("LINEAR ACCELERATION X (m/s²)" in n and "passed over" in n for n in log.notes)
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    _acc_scales_match(out, s)


def test_ros_linear_acceleration_alone_is_the_accelerometer(tmp_path):
    """ROS's linear_acceleration holds gravity: without an ACCELEROMETER triad beside it, it is still read."""
    head = "t,linear_acceleration_x,linear_acceleration_y,linear_acceleration_z\n"
    log = read_imu(_w(tmp_path / "r.csv", head + "".join(f"{i / 100},0.1,0.2,9.8\n" for i in range(20))))
    np.testing.assert_allclose(log.acc[0], [0.1, 0.2, 9.8])


def test_a_shimmer_export_reads_without_columns(tmp_path, capsys):
    """A Shimmer Consensys export ('"sep=;"', 'Shimmer_40AC_Timestamp_Unix_CAL;…_Accel_LN_X_CAL;…_Accel_WR_X_CAL;…
    _Gyro_X_CAL;…_Mag_X_CAL;', a units row ms, m/(s^2), deg/s, local_flux) was refused as having no accelerometer,
    the remedy a 7-name --columns for its 14 columns. The low-noise accelerometer, the gyroscope and the Unix time
    are read (the wide-range accelerometer named in a note): the session calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="deg/s", rng=9)
    p = "Shimmer_40AC_"
    names = ["Timestamp_Unix_CAL", *(f"Accel_{r}_{a}_CAL" for r in ("LN", "WR") for a in "XYZ")]
    names += [f"Gyro_{a}_CAL" for a in "XYZ"] + [f"Mag_{a}_CAL" for a in "XYZ"]
    units = ["ms"] + ["m/(s^2)"] * 6 + ["deg/s"] * 3 + ["local_flux"] * 3
    ms = 1_700_000_000_000 + (s.t - s.t[0]) * 1000
    rows = "".join(
        ";".join([f"{ms[i]:.3f}", *(f"{v:.6f}" for v in (*s.acc[i], *(s.acc[i] + 0.3), *s.gyr[i])), "-0.1;-0.9;0.05"])
        + ";\n"
        for i in range(len(s.t))
    )
    text = '"sep=;"\n' + ";".join(p + n for n in names) + ";\n" + ";".join(units) + ";\n" + rows
    path = _w(tmp_path / "2023-11-14_14.13.20_Session1_Shimmer_40AC_Calibrated_PC.csv", text.encode())
    log = read_imu(path)
    np.testing.assert_allclose(log.t - log.t[0], s.t - s.t[0], atol=2e-6)
    np.testing.assert_allclose(log.acc, np.round(s.acc, 6), atol=1e-12)
    np.testing.assert_allclose(log.gyr, np.radians(np.round(s.gyr, 6)), atol=1e-12)
    assert any("Accel_WR_X_CAL" in n and "passed over" in n for n in log.notes)
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    r = _acc_scales_match(out, s)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]), np.diag(s.gyr_K), rtol=5e-3)


def test_two_shimmers_in_one_export_are_not_guessed(tmp_path):
    """Two devices' columns in one export: which one is the log is not guessed (the error lists the columns)."""
    names = [f"Shimmer_{d}_{s}_{a}_CAL" for d in ("40AC", "9F6D") for s in ("Accel_LN", "Gyro") for a in "XYZ"]
    f = _w(tmp_path / "two.csv", ",".join(names) + "\n" + "".join("0,0,9.8,0,0,0,0,0,9.8,0,0,0\n" for _ in range(20)))
    with pytest.raises(OptinavError, match="no accelerometer or gyroscope data"):
        read_imu(f, rate_hz=100.0)


def test_ronin_hdf5_reads_its_synced_arrays(tmp_path, capsys):
    """RoNIN's data.hdf5 (synced/time in s, synced/acce and synced/gyro N×3; raw/imu/acce, raw/imu/gyro … N'×4 on
    their own clocks) was refused as "'raw/imu/gyro' and 'synced/gyro' both look like 'gyro'", its remedy naming the
    raw array (time in its first column), and 'acce' named no accelerometer. The synced arrays are read (a note
    says so): the session calibrates to its truth."""
    h5py = pytest.importorskip("h5py")
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=13)
    n = len(s.t)
    path = tmp_path / "data.hdf5"
    with h5py.File(path, "w") as f:
        f["synced/time"] = 1234.5 + s.t - s.t[0]
        f["synced/acce"], f["synced/gyro"] = s.acc, s.gyr
        f["synced/gyro_uncalib"], f["synced/linacce"] = s.gyr + 0.01, s.acc * 0
        f["synced/game_rv"] = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
        f["raw/imu/acce"], f["raw/imu/gyro"] = np.ones((n + 37, 4)), np.ones((n - 11, 4))
        f["pose/tango_pos"] = np.zeros((n, 3))
    log = read_imu(path)
    np.testing.assert_array_equal(log.acc, s.acc)
    assert any("synced/acce" in n for n in log.notes)
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    _acc_scales_match(out, s)


def test_ridi_csv_reads_acce_and_its_ns_time(tmp_path):
    """RIDI's CSV (pandas' index, time in ns, gyro_x…, acce_x…, linacce_x…, grav_x…) named no accelerometer ('acce')
    and, its time read as seconds, was refused naming --time-unit ns; both are the layout's, now read so."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=17)
    head = ",time," + ",".join(f"{q}_{a}" for q in ("gyro", "acce", "linacce", "grav") for a in "xyz")
    ns = 1_500_000_000_000_000_000 + np.round((s.t - s.t[0]) * 1e9).astype(np.int64)
    rows = "".join(
        f"{i},{ns[i]}," + ",".join(f"{v:.6f}" for v in (*s.gyr[i], *s.acc[i], 0.0, 0.0, 0.0, *s.acc[i])) + "\n"
        for i in range(len(s.t))
    )
    log = read_imu(_w(tmp_path / "dan_body1.csv", head + "\n" + rows))
    np.testing.assert_allclose(np.diff(log.t), np.diff(s.t), atol=1e-6)
    np.testing.assert_allclose(log.acc, np.round(s.acc, 6), atol=1e-12)
    np.testing.assert_allclose(log.gyr, np.round(s.gyr, 6), atol=1e-12)


def test_an_adis_register_export_reads_and_its_counts_are_named(tmp_path, capsys):
    """An ADIS16470's evaluation export names its columns by register (X_GYRO_OUT, …, X_ACCL_OUT, …) and holds raw
    counts: 800 per g, 10 per deg/s. The columns named no sensor; mapped, 800 at rest was told 'data in mg?; pass
    --acc-unit mg', which calibrated with exit 0 to K 20 % below the nominal mg scale. The register names are
    recognised, and a rest norm that a physical unit makes more than 10 % off g names counts first: with
    --acc-unit counts the session calibrates to its truth."""
    per_g, per_dps = 800.0, 10.0
    s = simulate(
        "18",
        dwell_s=6,
        rest_s=3,
        acc_unit="counts",
        gyro_unit="counts",
        rng=19,
        acc_counts_per_si=per_g / 9.80665,
        gyro_counts_per_si=per_dps * 180 / np.pi,
    )
    head = "X_GYRO_OUT,Y_GYRO_OUT,Z_GYRO_OUT,X_ACCL_OUT,Y_ACCL_OUT,Z_ACCL_OUT,TEMP_OUT\n"
    raw = np.round(np.column_stack([s.gyr, s.acc])).astype(int)
    path = _w(tmp_path / "adis16470.csv", head + "".join(",".join(map(str, r)) + ",2500\n" for r in raw))
    rate = f"{1 / np.median(np.diff(s.t)):g}"
    out = tmp_path / "r.json"
    argv = ["calibrate", "accel", str(path), "--rate", rate, "--gravity", str(s.gravity), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "raw counts? (" in err and "per g" in err and "pass --acc-unit counts" in err
    assert main([*argv, "--acc-unit", "counts", "--gyro-unit", "counts"]) == 0
    _acc_scales_match(out, s, rtol=2e-3)
    # declared mg (as the old hint said), the counts calibrated with exit 0 to a scale 0.82x of mg's: an
    # accelerometer in a physical unit reads g within x1.15, beyond it the fit is refused naming counts
    capsys.readouterr()
    assert main([*argv, "--acc-unit", "mg", "--gyro-unit", "counts"]) == 2
    err = capsys.readouterr().err
    assert re.search(r"0\.8\d*× its nominal value in mg", err) and re.search(r"\((79\d|80\d)(\.\d+)? per g\)", err), err
    assert "pass --acc-unit counts" in err


def test_an_accelerometer_a_few_percent_off_in_a_physical_unit_still_calibrates(tmp_path):
    """The physical-unit scale gate (x1.15) leaves a real sensor's scale error alone: 8 % off in g calibrates to it."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="g", gyro_unit="rad/s", rng=23)
    path = tmp_path / "s.csv"
    rows = np.column_stack([s.t, 1.08 * s.acc, s.gyr])
    np.savetxt(path, rows, delimiter=",", header="t,ax [g],ay [g],az [g],gx,gy,gz", comments="", fmt="%.9g")
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    from optinav.multipos import model

    r = CalibrationResult.from_json(out)
    U, _ = model.upper_triangular_form(s.acc_K)
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), 1.08 * np.diag(U), rtol=2e-3)


def _vn_line(name, values):
    body = f"{name}," + ",".join(values)
    check = 0
    for ch in body:
        check ^= ord(ch)
    return f"${body}*{check:02X}\n"


def test_a_vectornav_ascii_capture_reads_by_its_sentence(tmp_path, capsys):
    """A VN-100's ASCII output captured from its serial port ('$VNYMR,yaw,pitch,roll,magX..Z,accelX..Z,gyroX..Z*5C',
    m/s^2 and rad/s) was refused as naming no sensor, and mapped by position, its gyro z cell ('+00.000660*64')
    was text. The checksum is checked and cut, the fields named by the sentence's layout; a line whose checksum
    fails is unreadable at its line (--skip-bad-lines leaves it out). The session calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=23)
    lines = [
        _vn_line(
            "VNYMR",
            ["+010.071", "-002.111", "-000.778", "-00.7810", "+00.1620", "+00.4630"]
            + [f"{v:+07.3f}" for v in s.acc[i]]
            + [f"{v:+09.6f}" for v in s.gyr[i]],
        )
        for i in range(len(s.t))
    ]
    path = _w(tmp_path / "vn100.txt", "".join(lines))
    rate = 1 / np.median(np.diff(s.t))
    log = read_imu(path, rate_hz=rate)
    np.testing.assert_allclose(log.acc, np.round(s.acc, 3), atol=1e-12)
    np.testing.assert_allclose(log.gyr, np.round(s.gyr, 6), atol=1e-12)
    assert any("$VNYMR" in n for n in log.notes)
    out = tmp_path / "r.json"
    assert (
        main(["calibrate", "accel", str(path), "--rate", f"{rate:g}", "--gravity", str(s.gravity), "--out", str(out)])
        == 0
    )
    _acc_scales_match(out, s)
    lines[40] = lines[40].replace("+", "-", 1)  # a bit flipped on the wire: the checksum fails
    bad = _w(tmp_path / "vn100_bad.txt", "".join(lines))
    with pytest.raises(OptinavError, match="line 41.*--skip-bad-lines"):
        read_imu(bad, rate_hz=rate)
    log = read_imu(bad, rate_hz=rate, skip_bad_lines=True)
    assert np.isnan(log.acc[40]).all() and np.isfinite(log.acc[41]).all()


def test_a_pair_given_the_wrong_way_round_is_named(tmp_path, capsys):
    """A file per sensor given the wrong way round (MetaWear's Gyroscope.csv as DATA, its Accelerometer.csv as
    --gyro) was told to map ax/ay/az with --columns (calibrate, attitude: the deg/s axes as an accelerometer) or to
    check --columns/--sensor (allan); the errors now say which sensor each file holds and to swap them."""
    rng = np.random.default_rng(2)
    t = np.arange(3000) / 100.0
    acc = _w(tmp_path / "Accelerometer.csv", _metabase(t, rng.normal(0, 1e-3, (3000, 3)) + [0, 0, 1], "g").encode())
    gyr = _w(tmp_path / "Gyroscope.csv", _metabase(t, rng.normal(0, 0.05, (3000, 3)), "deg/s").encode())
    for cmd, out in ((["calibrate", "accel"], "r.json"), (["attitude"], "a.csv"), (["allan"], "n.json")):
        assert main([*cmd, str(gyr), "--gyro", str(acc), "--out", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert "Gyroscope.csv" in err and "holds the gyroscope" in err and "--gyro" in err and "--columns" not in err, (
            err
        )


def test_xsens_increments_read_as_rates(tmp_path, capsys):
    """A Movella DOT's high-fidelity export (and MT Manager's) holds increments per output period: dq_W..dq_Z, the
    orientation increment, and dv[1]..dv[3] (m/s, axes counted from 1; 'dv[1]' read as 'dv_y', 'dv[3]' as a unit).
    It named no sensor; now the mean rate and specific force of each period (1 / OutputRate) are read, and a
    simulated session so written gives the rates it was written from and calibrates to its truth; without a
    stated rate or a time the increments are refused, naming --rate."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=29)
    dt = 1 / 100.0
    th = s.gyr * dt
    ang = np.linalg.norm(th, axis=1)
    dq = np.column_stack([np.cos(ang / 2), th * (np.sin(ang / 2) / np.where(ang > 0, ang, 1))[:, None]])
    head = ["DeviceTag:,1", "OutputRate:,100Hz", "Measurement Mode:,Custom Mode 4"]
    cols = "PacketCounter,SampleTimeFine,dq_W,dq_X,dq_Y,dq_Z,dv[1],dv[2],dv[3],Mag_X,Mag_Y,Mag_Z,Status\n"
    rows = "".join(
        f"{i},{10_000 * i}," + ",".join(f"{v:.12g}" for v in (*dq[i], *(s.acc[i] * dt))) + ",0.1,0.2,0.3,0\n"
        for i in range(len(s.t))
    )
    path = _w(tmp_path / "dot_hf.csv", "sep=,\n" + "".join(h + ",,,\n" for h in head) + "\n" + cols + rows)
    log = read_imu(path)
    np.testing.assert_allclose(log.gyr, s.gyr, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.acc, s.acc, rtol=0, atol=1e-8)
    assert log.gyro_input_unit == "rad/s" and any("dq_*/dv[*]" in n for n in log.notes)
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    r = _acc_scales_match(out, s)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]), np.diag(s.gyr_K), rtol=5e-3)
    bare = _w(tmp_path / "bare.csv", cols + rows)
    with pytest.raises(OptinavError, match="pass --rate HZ"):
        read_imu(bare)


def test_a_wide_headerless_file_is_offered_one_name_per_column(tmp_path):
    """A headerless file of more than 7 columns (OxIOD's 16: time, attitude, rates, gravity, user acceleration,
    field) was offered --columns 't,ax,ay,az,gx,gy,gz', which its next error refused as 7 names for 16 columns; the
    example now holds one name per column."""
    rows = "".join(f"{i / 100},0.1,0.2,0.3,{0.01 * i},0,0,0,0,-1,0,0,0,10,20,30\n" for i in range(30))
    f = _w(tmp_path / "imu1.csv", rows)
    with pytest.raises(OptinavError) as exc:
        read_imu(f)
    example = exc.value.remedy.split("'")[1]
    assert len(example.split(",")) == 16
    log = read_imu(f, columns="t,_,_,_,gx,gy,gz,ax,ay,az,_,_,_,_,_,_")
    np.testing.assert_allclose(log.acc[0], [0, 0, -1])


def test_a_sample_printed_over_several_lines_is_named(tmp_path):
    """Adafruit's BNO055 sketches print each sensor on its own line ('Gyro:\\tx= 0.00 |\\ty= …', then 'Accl:', …): the
    capture was refused as "no column of numbers in the first data row …; check the delimiter option", which cannot
    help. The error now says a sample spans several lines and how to print one per line."""
    labels = ("Orient", "Gyro", "Linear", "Mag", "Accl")
    rows = ["".join(f"{lab}:\tx= {i * 0.01:.2f} |\ty= 0.04 |\tz= 9.85\n" for lab in labels) + "\n" for i in range(20)]
    f = _w(tmp_path / "bno055.txt", "".join(rows))
    with pytest.raises(OptinavError, match="prints each sensor on its own line .*Gyro, Linear") as exc:
        read_imu(f, rate_hz=100.0)
    assert "delimiter" not in str(exc.value)
    one = _w(tmp_path / "plotter.txt", "".join(f"ax:0.1,ay:0.2,az:9.8,gx:{i},gy:0,gz:0\n" for i in range(20)))
    assert read_imu(one, rate_hz=100.0).acc.shape == (20, 3)


def _acc_scales_match(out, s, **tol):
    """The calibration written to ``out`` has the simulated session ``s``'s accelerometer scales (the diagonal of its
    K in upper-triangular form) within ``tol`` (default: 4 × the largest K std it reports); returns it."""
    from optinav.multipos import model

    r = CalibrationResult.from_json(out)
    U, _ = model.upper_triangular_form(s.acc_K)
    tol = tol or {"atol": 4 * np.max(r.accelerometer["K_std"])}
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(U), **tol)
    return r


def _inclination_deg(out, q_b_n):
    """Median and largest inclination error (deg) of the attitude CSV ``out`` against ``q_b_n`` (its frame)."""
    from optinav.attitude.metrics import inclination_error

    d = np.genfromtxt(out, delimiter=",", names=True)
    e = np.degrees(inclination_error(np.column_stack([d[k] for k in ("qw", "qx", "qy", "qz")]), q_b_n))
    return float(np.median(e)), float(np.max(e))


def test_columns_negate_the_acceleration_core_motion_logs(tmp_path, capsys):
    """Apple's Core Motion logs minus the specific force (a phone face up reads -1 g on z; OxIOD's headerless
    imu*.csv: time, attitude, rotation rate rad/s, gravity and user acceleration in g, field µT). --columns could
    not negate a column: the raw accelerometer read as it stands put a simulated flight 179° off (inclination)
    with exit 0, under a warning whose only remedy was the other frame. Now '-' before a name (t,-ax,… or
    ax=-NAME) reads it negated, with a note; the warning names the negation; OxIOD's file reads by Core Motion's
    names, which sum gravity and user acceleration and negate them (docs/file-formats.md)."""
    from optinav.attitude.simulate import simulate as fly

    d = fly("dynamic", duration_s=12, rate_hz=100, rng=4, frame="enu")  # RFU body: a phone face up
    f = d.acc / 9.80665
    apple = tmp_path / "apple.csv"
    np.savetxt(apple, np.column_stack([d.t, -f, d.gyr]), delimiter=",", fmt="%.9g")
    grav = -np.cumsum(f, axis=0) / np.arange(1, len(f) + 1)[:, None]  # any split of -f: Core Motion sums them
    ox = tmp_path / "imu1.csv"
    np.savetxt(ox, np.column_stack([d.t, 0 * f, d.gyr, grav, -f - grav, 0 * f + 30.0]), delimiter=",", fmt="%.9g")
    cm = ",".join(f"motion{k}{a}" for k in ("Gravity", "UserAcceleration") for a in "XYZ")
    ours = tmp_path / "ours.csv"  # the same flight in optinav's sign
    np.savetxt(ours, np.column_stack([d.t, np.round(f, 9), d.gyr]), delimiter=",", fmt="%.9g")
    runs = {
        "ours": (ours, "t,ax,ay,az,gx,gy,gz"),
        "as logged": (apple, "t,ax,ay,az,gx,gy,gz"),
        "negated": (apple, "t,-ax,-ay,-az,gx,gy,gz"),
        "negated by name": (apple, "t=col1,ax=-col2,ay=-col3,az=-col4,gx=col5,gy=col6,gz=col7"),
        "OxIOD": (ox, f"t,_,_,_,gx,gy,gz,{cm},_,_,_"),
    }
    errs = {}
    for k, (path, cols) in runs.items():
        out = tmp_path / f"{k} attitude.csv"
        assert main(["--quiet", "attitude", str(path), "--columns", cols, "--acc-unit", "g", "--frame", "ENU",
                     "--out", str(out)]) == 0  # fmt: skip
        errs[k] = (_inclination_deg(out, d.q_b_n), capsys.readouterr().err)
    assert errs["ours"][0][0] < 5.0 and errs["as logged"][0][0] > 170.0
    assert "negate the accelerometer's columns, e.g. --columns t,-ax,-ay,-az" in errs["as logged"][1]
    for k in ("negated", "negated by name", "OxIOD"):
        np.testing.assert_allclose(errs[k][0], errs["ours"][0], atol=1e-3)
        assert "down-pointing" not in errs[k][1]
    assert "read negated as the columns option asks: -ax, -ay, -az" in errs["negated"][1]
    assert "-(motionUserAccelerationX + motionGravityX)" in errs["OxIOD"][1]
    log = read_imu(apple, columns="t,-ax,-ay,-az,gx,gy,gz", acc_unit="g")
    np.testing.assert_allclose(log.acc, np.round(f, 9) * 9.80665, rtol=1e-8, atol=1e-8)
    for bad, match in (("t,-t,ay,az,gx,gy,gz", "no accelerometer or gyroscope column"), ("t,-_,ay", "signs no")):
        with pytest.raises(OptinavError, match=match):
            read_imu(apple, columns=bad)


def test_a_negated_column_calibrates_to_the_truth(tmp_path, capsys):
    """A session logged in Core Motion's sign (minus the specific force): the norm fit cannot see the sign, so as
    logged it calibrated with every accelerometer bias negated, exit 0; '-' in --columns gives the truth's, and
    the result records the mapping in its notes."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=11)
    path = tmp_path / "apple.csv"
    np.savetxt(path, np.column_stack([s.t, -s.acc, -s.gyr]), delimiter=",", fmt="%.12g")
    out = tmp_path / "r.json"
    cmd = ["--quiet", "calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]
    assert main([*cmd, "--columns", "t,-ax,-ay,-az,-gx,-gy,-gz"]) == 0
    r = _acc_scales_match(out, s)
    tol = 4 * np.max(r.accelerometer["b_std"])
    np.testing.assert_allclose(r.accelerometer["b"], s.acc_b, atol=tol)
    assert "apple.csv: read negated as the columns option asks: -ax, -ay, -az, -gx, -gy, -gz" in r.quality["notes"]


def _dot_increments(path, s, head, stf, rate_hz=100.0, columns="PacketCounter,SampleTimeFine,"):
    """A Movella DOT increments export of the simulated session ``s`` (``head``: its settings lines, ``stf``: its
    SampleTimeFine per row, or None for none)."""
    dt = 1 / rate_hz
    th = s.gyr * dt
    ang = np.linalg.norm(th, axis=1)
    dq = np.column_stack([np.cos(ang / 2), th * (np.sin(ang / 2) / np.where(ang > 0, ang, 1))[:, None]])
    cols = columns + "dq_W,dq_X,dq_Y,dq_Z,dv[1],dv[2],dv[3],Status\n"
    rows = "".join(
        f"{i}," + ("" if stf is None else f"{stf[i]},") + ",".join(f"{v:.12g}" for v in (*dq[i], *(s.acc[i] * dt)))
        + ",0\n"
        for i in range(len(s.t))
    )  # fmt: skip
    return _w(path, head + (cols if stf is not None else cols.replace("SampleTimeFine,", "")) + rows)


def test_xsens_increments_without_a_rate_line(tmp_path, capsys):
    """A DOT export of increments without its OutputRate line was refused, --rate or not ("the export states no
    rate"), and its SampleTimeFine (µs, a 32-bit counter) was never read as time. Now SampleTimeFine times a DOT
    export that names no other time, its wrap at 2^32 µs unwrapped (within a file read whole and between the blocks
    of a streamed one), and the increments' period is its step; without the DOT's settings lines (the tick, µs or
    an MTi's 100 µs, unknown) --rate decides it, a rate that fits neither tick is refused, and a file without
    SampleTimeFine reads at the rate given. The session calibrates to its truth."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=29)
    n, wrap_row = len(s.t), 4000
    stf = (2**32 + (np.arange(n) - wrap_row) * 10_000) % 2**32  # wraps at row 4000
    dot = _dot_increments(tmp_path / "dot.csv", s, "sep=,\nDeviceTag:,1,,\nMeasurement Mode:,Custom Mode 4,,\n\n", stf)
    log = read_imu(dot)
    np.testing.assert_allclose(np.diff(log.t), 0.01, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.gyr, s.gyr, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.acc, s.acc, rtol=0, atol=1e-8)
    assert any("1/100-s period (the step of its time column 'SampleTimeFine')" in x for x in log.notes), log.notes
    blocks = list(iter_imu(dot, chunk_rows=wrap_row))  # the wrap between two blocks
    assert len(blocks) > 1
    np.testing.assert_allclose(np.concatenate([b.t for b in blocks]), log.t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.concatenate([b.gyr for b in blocks]), s.gyr, rtol=0, atol=1e-9)
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(dot), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    _acc_scales_match(out, s)
    bare = _dot_increments(tmp_path / "bare.csv", s, "", stf)
    with pytest.raises(OptinavError, match="tick of 'SampleTimeFine' is not known .*pass --rate HZ"):
        read_imu(bare)
    np.testing.assert_allclose(read_imu(bare, rate_hz=100.0).gyr, s.gyr, rtol=0, atol=1e-9)
    with pytest.raises(OptinavError, match="rate_hz=60 contradicts its time column 'SampleTimeFine'"):
        read_imu(bare, rate_hz=60.0)
    none = _dot_increments(tmp_path / "none.csv", s, "", None)
    with pytest.raises(OptinavError, match="neither the export nor a time column .* states the period"):
        read_imu(none)
    log = read_imu(none, rate_hz=100.0)
    np.testing.assert_allclose(log.gyr, s.gyr, rtol=0, atol=1e-9)
    np.testing.assert_allclose(log.t[-1], (n - 1) / 100.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize(("head", "fmt"), [("datetime", "%Y-%m-%dT%H:%M:%S.%f"), ("Date", "%Y-%m-%d %H:%M:%S.%f"),
                                          ("UTC", "%Y-%m-%dT%H:%M:%S.%f+02:00")])  # fmt: skip
def test_a_date_time_column_of_any_name_is_the_time_when_nothing_else_is(tmp_path, head, fmt):
    """A logger's only time as ISO 8601 date-times under a name no alias takes (datetime, Date, UTC) was parsed,
    then passed over: "has no time column, pass --rate", which drops the real timing. It is the time now, whole and
    in blocks, with a note; beside a numeric time column, or beside a second date-time column, it is not."""
    n = 120
    gyr, acc = _triads(10, n)
    t0 = datetime.datetime(2024, 5, 1, 12, 0, 0)
    when = [t0 + datetime.timedelta(milliseconds=10 * i + (25 if i > 60 else 0)) for i in range(n)]  # a lost sample
    stamps = [w.strftime(fmt) for w in when]
    rows = [f"{s},{','.join(map(repr, [*acc[i].tolist(), *gyr[i].tolist()]))}" for i, s in enumerate(stamps)]
    path = _w(tmp_path / "d.csv", f"{head},ax,ay,az,gx,gy,gz\n" + "\n".join(rows) + "\n")
    want = np.array([(w - datetime.datetime(1970, 1, 1)).total_seconds() for w in when])
    want -= 7200.0 if fmt.endswith("+02:00") else 0.0  # s since the epoch, the UTC offset applied
    for log in (read_imu(path), *iter_imu(path, chunk_rows=50)):
        k = np.searchsorted(want, log.t[0] - 1e-4)
        np.testing.assert_allclose(log.t, want[k : k + len(log)], rtol=0, atol=2e-6)
        np.testing.assert_array_equal(log.acc, acc[k : k + len(log)])
    assert any(f"date-times {head!r} read as the time" in x for x in read_imu(path).notes)
    both = _w(tmp_path / "b.csv", f"{head},t,ax,ay,az,gx,gy,gz\n" + "".join(
        f"{s},{i * 0.01},{r.split(',', 1)[1]}\n" for i, (s, r) in enumerate(zip(stamps, rows))))  # fmt: skip
    np.testing.assert_allclose(read_imu(both).t, np.arange(n) * 0.01)
    two = _w(tmp_path / "2.csv", f"{head},stamp2,ax,ay,az,gx,gy,gz\n" + "".join(
        f"{s},{s},{r.split(',', 1)[1]}\n" for s, r in zip(stamps, rows)))  # fmt: skip
    with pytest.raises(OptinavError, match="has no time column"):
        read_imu(two)


def test_a_kitti_raw_oxts_folder_is_read_as_one_log(tmp_path, capsys):
    """KITTI raw's oxts/ folder (data/NNNNNNNNNN.txt with the 30 values of one sample each, timestamps.txt of
    date-times to the ns) was refused as 'a folder; check the path', and one of its files offered 7 names for 30
    columns of a single sample. The folder (or its data/) is one log now: the time from timestamps.txt, ax..az and
    wx..wz (the vehicle's forward-left-up axes); a simulated flight so written gives the attitude of the same data
    in a CSV, near the truth of those axes."""
    from optinav.attitude.simulate import simulate as fly
    from optinav.core.rotations import quat_from_euler, quat_multiply

    d = fly("dynamic", duration_s=12, rate_hz=100, rng=5, frame="enu")  # right-forward-up body
    flu = lambda v: np.column_stack([v[:, 1], -v[:, 0], v[:, 2]])  # noqa: E731 (KITTI's forward-left-up axes)
    acc, gyr = flu(d.acc), flu(d.gyr)
    oxts = tmp_path / "2011_09_26_drive_0001_extract" / "oxts"
    (oxts / "data").mkdir(parents=True)
    t0 = datetime.datetime(2011, 9, 26, 13, 2, 25)
    when = [t0 + datetime.timedelta(seconds=float(x)) for x in d.t]
    (oxts / "timestamps.txt").write_text("".join(w.strftime("%Y-%m-%d %H:%M:%S.%f") + "123\n" for w in when))
    for i in range(len(d.t)):
        v = [49.0, 8.4, 116.4, 0, 0, 0, 0, 0, 0, 0, 0, *acc[i], *acc[i], *gyr[i], *gyr[i], 0.5, 0.05, 4, 10, 4, 4, 6]
        (oxts / "data" / f"{i:010d}.txt").write_text(" ".join(f"{x:.12g}" for x in v) + "\n")
    log = read_imu(oxts / "data")
    epoch = (t0 - datetime.datetime(1970, 1, 1)).total_seconds()
    np.testing.assert_allclose(log.t - epoch, d.t + 123e-9, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log.acc, acc, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(log.gyr, gyr, rtol=1e-11, atol=1e-11)
    assert any("KITTI's oxts folder read" in x for x in log.notes)
    csv = tmp_path / "same.csv"
    np.savetxt(csv, np.column_stack([log.t, acc, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", fmt="%.17g")
    q_flu = quat_multiply(d.q_b_n, quat_from_euler([0.0, 0.0, np.pi / 2], "enu"))  # the truth of those axes
    errs = {}
    for name, path in (("kitti", oxts), ("csv", csv)):
        out = tmp_path / f"{name}.out.csv"
        assert main(["--quiet", "attitude", str(path), "--frame", "ENU", "--out", str(out)]) == 0
        errs[name] = _inclination_deg(out, q_flu)
    assert errs["csv"][0] < 5.0
    np.testing.assert_allclose(errs["kitti"], errs["csv"], atol=1e-3)
    (oxts / "data" / "0000000000.txt").unlink()
    with pytest.raises(OptinavError, match="lines in timestamps.txt for .* files in data/"):
        read_imu(oxts)


def _stamp(when: datetime.datetime, style: str) -> str:
    """A logger's time stamp of ``when``: WitMotion's PC software (fields not zero-padded, ms), its newer exports
    (the ms after a ':'), an RTC logger's slash date, or the time of day alone."""
    ms = f"{when.microsecond // 1000:03d}"
    if style == "wit":
        return f"{when.year}-{when.month}-{when.day} {when.hour}:{when.minute:02d}:{when.second:02d}.{ms}"
    if style == "wit_colon":
        return f"{when.year}-{when.month}-{when.day} {when.hour}:{when.minute}:{when.second}:{ms}"
    if style == "slash":
        return when.strftime("%Y/%m/%d %H:%M:%S.") + ms
    return when.strftime("%H:%M:%S.") + ms


def _witmotion(path, t, acc_g, gyr_dps, t0, head="old", delim="\t", encoding="utf-8"):
    """A WitMotion PC-software export (WT901/BWT901CL/HWT905) of samples at ``t`` (s after ``t0``): the computer's
    receive ``time`` (packets in bursts of four) and the sensor's ``ChipTime``, acceleration in g, angular velocity
    in deg/s, angles, the temperature ``T(°)`` and the magnetometer's counts. The layouts are those of gyroflow's
    telemetry-parser (src/witmotion/txt.rs, txt4.rs), which reads the vendor's files: ``head="old"``: ``time,
    ChipTime, ax(g) … wx(deg/s) … AngleX(deg) … T(°), hx, hy, hz``, stamps '2023-5-16 15:30:35.760'; ``"new"``:
    ``time, Device name, Chip Time(), Acceleration X(g) … Angular velocity X(°/s) … Angle X(°) … Magnetic field
    X(uT) … Temperature(°C)``, stamps '2023-5-16 15:30:35:760', written in GBK by Chinese Windows."""
    n = len(t)
    chip = [t0 + datetime.timedelta(milliseconds=round(1000 * x)) for x in t]
    pc = [chip[min(n - 1, (i // 4) * 4 + 3)] + datetime.timedelta(milliseconds=23) for i in range(n)]  # bursts
    if head == "old":
        names = ["time", "ChipTime", *(f"a{a}(g)" for a in "xyz"), *(f"w{a}(deg/s)" for a in "xyz")]
        names += [*(f"Angle{a}(deg)" for a in "XYZ"), "T(°)", "hx", "hy", "hz"]
        stamps = [(_stamp(p, "wit"), _stamp(c, "wit")) for p, c in zip(pc, chip)]
    else:
        names = ["time", "Device name", "Chip Time()", *(f"Acceleration {a}(g)" for a in "XYZ")]
        names += [*(f"Angular velocity {a}(°/s)" for a in "XYZ"), *(f"Angle {a}(°)" for a in "XYZ")]
        names += [*(f"Magnetic field {a}(uT)" for a in "XYZ"), "Temperature(°C)"]
        stamps = [(_stamp(p, "wit_colon"), "WT5300002296(COM3)", _stamp(c, "wit_colon")) for p, c in zip(pc, chip)]
    rows = [
        delim.join(
            [*st, *(f"{v:.6f}" for v in (*acc_g[i], *gyr_dps[i])), "1.5", "-0.7", "123.4", "25.31", "-12", "34", "-56"]
        )  # fmt: skip
        for i, st in enumerate(stamps)
    ]
    path.write_bytes((delim.join(names) + "\r\n" + "\r\n".join(rows) + "\r\n").encode(encoding))
    return path


def test_a_witmotion_export_calibrates_to_the_truth_without_columns_or_units(tmp_path, capsys):
    """WitMotion's PC software exports (WT901, BWT901CL, HWT905, WT61…) were refused at their first time stamp
    ("'2023-5-16 15:30:35.760' is not a number": a date whose fields are not zero-padded), and their temperature
    T(°) was taken for a second time column. Now the log reads as the header says: the sensor's ChipTime is
    the time (the computer's receive time, in USB bursts, passed over with a note), g and deg/s from the brackets,
    T(°) a temperature; tab- or comma-separated; the newer export ('Chip Time()', 'Angular velocity X(°/s)', the
    ms after a ':', GBK as Chinese Windows writes it) reads to the same samples. A simulated multi-position recording
    so written calibrates to its truth with no --columns and no unit flag."""
    s = simulate("18", dwell_s=4, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=11)
    acc_g, gyr_dps = s.acc / 9.80665, np.degrees(s.gyr)
    t0 = datetime.datetime(2023, 5, 16, 15, 30, 35, 760000)
    epoch = (t0 - datetime.datetime(1970, 1, 1)).total_seconds()
    old = _witmotion(tmp_path / "20230516153035.txt", s.t, acc_g, gyr_dps, t0)
    log = read_imu(old)
    np.testing.assert_allclose(log.t - epoch, s.t, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log.acc, s.acc, rtol=0, atol=1e-5)  # 1e-6 g cells
    np.testing.assert_allclose(log.gyr, s.gyr, rtol=0, atol=1e-7)
    assert "WitMotion's 'ChipTime' (the sensor's clock) read as the time; 'time' (the computer's receive time) " \
        "passed over" in " ".join(log.notes)  # fmt: skip
    comma = _witmotion(tmp_path / "comma.csv", s.t[:500], acc_g, gyr_dps, t0, delim=",")
    new = _witmotion(tmp_path / "new.txt", s.t, acc_g, gyr_dps, t0, head="new", encoding="gbk")
    for got in (read_imu(comma), read_imu(new), *iter_imu(new, chunk_rows=5000)):
        k = np.searchsorted(log.t, got.t[0])
        for name in ("t", "acc", "gyr"):
            np.testing.assert_array_equal(getattr(got, name), getattr(log, name)[k : k + len(got)])
    out = tmp_path / "r.json"
    assert main(["calibrate", "accel", str(old), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    assert "ChipTime" in capsys.readouterr().err
    from optinav.multipos import model

    r = CalibrationResult.from_json(out)
    acc, g = r.accelerometer, 9.80665  # raw = K·x + b in the file's g
    U, _ = model.upper_triangular_form(s.acc_K)
    np.testing.assert_allclose(np.diag(acc["K"]) * g, np.diag(U), rtol=0, atol=4 * g * np.max(np.diag(acc["K_std"])))
    np.testing.assert_allclose(acc["b"] * g, s.acc_b, rtol=0, atol=4 * g * np.max(acc["b_std"]))


@pytest.mark.parametrize("style", ["time_of_day", "slash", "wit"])
def test_time_of_day_and_slash_date_stamps_time_the_samples(tmp_path, capsys, style):
    """An RTC/Arduino logger's only time column as the time of day ('23:59:59.990', a day rollover inside), or with
    a slash date ('2024/05/01 12:00:00.010'), was refused ("… is not a number"). It times the samples now, whole
    and in blocks (a rollover between two blocks too): times of day count from the midnight before the first row,
    a step back of more than 12 h being the next day. A simulated flight so logged gives the attitude of the same
    samples in a plain CSV."""
    from optinav.attitude.simulate import simulate as fly

    d = fly("dynamic", duration_s=12, rate_hz=100, rng=4, frame="enu")
    t0 = datetime.datetime(2024, 5, 1, 23, 59, 55)  # midnight 5 s in, inside the second block of 400 rows
    when = [t0 + datetime.timedelta(milliseconds=round(1000 * x)) for x in d.t]
    values = np.column_stack([d.acc, d.gyr])
    rows = "".join(f"{_stamp(w, style)},{','.join(f'{v:.9g}' for v in values[i])}\n" for i, w in enumerate(when))
    path = _w(tmp_path / "rtc.csv", "time,ax,ay,az,gx,gy,gz\n" + rows)
    plain = tmp_path / "plain.csv"
    np.savetxt(plain, np.column_stack([d.t, values]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="",
               fmt="%.9g")  # fmt: skip
    start = t0 - (t0.replace(hour=0, minute=0, second=0) if style == "time_of_day" else datetime.datetime(1970, 1, 1))
    log = read_imu(path)
    np.testing.assert_allclose(log.t - start.total_seconds(), d.t, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(log.acc, read_imu(plain).acc)
    np.testing.assert_array_equal(np.concatenate([b.t for b in iter_imu(path, chunk_rows=400)]), log.t)
    if style == "time_of_day":
        assert any("its times of day 'time' read as the time" in x for x in log.notes)
    q = {}
    for name, p in (("logger", path), ("plain", plain)):
        out = tmp_path / f"{name}.q.csv"
        assert main(["--quiet", "attitude", str(p), "--frame", "ENU", "--out", str(out)]) == 0
        q[name] = np.genfromtxt(out, delimiter=",", names=True)
    for k in ("qw", "qx", "qy", "qz"):
        np.testing.assert_allclose(q["logger"][k], q["plain"][k], rtol=0, atol=1e-6)
    assert _inclination_deg(tmp_path / "logger.q.csv", d.q_b_n)[0] < 5.0
    back = _w(
        tmp_path / "back.csv", "time,ax,ay,az\n12:00:00.000,0,0,9.8\n12:00:00.010,0,0,9.8\n11:59:59.000,0,0,9.8\n"
    )
    with pytest.raises(OptinavError, match="back"):  # an hour or a second back is no rollover
        read_imu(back)


def test_headerless_files_of_one_sensor_timed_by_the_time_of_day(tmp_path, capsys):
    """A pair of headerless files, one per sensor, whose first column is the time of day of an RTC logger
    ('23:59:58.000 0.01 -0.02 9.81', imu_tk's layout with a clock): that column was left out as text and the pair
    refused as having no time column. The first column is the time now (a day rollover inside), the other three
    the sensor as imu_tk's rule reads them, and a simulated flight so logged gives the attitude of the same
    samples in one plain CSV; a first column that steps back by an hour is no time and is not taken for one."""
    from optinav.attitude.simulate import simulate as fly

    d = fly("dynamic", duration_s=8, rate_hz=100, rng=6, frame="enu")
    t0 = datetime.datetime(2024, 5, 1, 23, 59, 58)
    stamps = [_stamp(t0 + datetime.timedelta(milliseconds=round(1000 * x)), "time_of_day") for x in d.t]
    a, g = tmp_path / "acc.txt", tmp_path / "gyro.txt"
    for path, v in ((a, d.acc), (g, d.gyr)):
        _w(path, "".join(f"{s} {' '.join(f'{x:.9g}' for x in row)}\n" for s, row in zip(stamps, v)))
    log = read_imu(a, gyro_path=g)
    np.testing.assert_allclose(log.t - (23 * 3600 + 59 * 60 + 58), d.t, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log.gyr, d.gyr, rtol=1e-8, atol=1e-12)
    assert any("its 4 columns read as t,gx,gy,gz" in x for x in log.notes)
    plain = tmp_path / "plain.csv"
    np.savetxt(plain, np.column_stack([d.t, np.array([[float(f"{x:.9g}") for x in r] for r in np.column_stack(
        [d.acc, d.gyr])])]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt="%.17g")  # fmt: skip
    q = {}
    for name, args in (("pair", [str(a), "--gyro", str(g)]), ("plain", [str(plain)])):
        out = tmp_path / f"{name}.q.csv"
        assert main(["--quiet", "attitude", *args, "--frame", "ENU", "--out", str(out)]) == 0
        q[name] = np.genfromtxt(out, delimiter=",", names=True)
    for k in ("qw", "qx", "qy", "qz"):
        np.testing.assert_allclose(q["pair"][k], q["plain"][k], rtol=0, atol=1e-6)
    back = _w(
        tmp_path / "back.txt", "".join(f"{s} 0 0 9.8\n" for s in ("12:00:00.000", "12:00:00.010", "11:00:00.020"))
    )
    with pytest.raises(OptinavError, match="has no accelerometer data"):
        read_imu(back, gyro_path=g)


def _logger_rows(stamps, values, delim=","):
    return "".join(f"{s}{delim}{delim.join(f'{v:.9g}' for v in row)}\n" for s, row in zip(stamps, values))


def _utc(when: datetime.datetime) -> float:
    return when.replace(tzinfo=datetime.timezone.utc).timestamp()


def test_a_date_and_a_time_in_two_fields_are_one_time_column(tmp_path, capsys):
    """Loggers write the date and the time of day as two fields: '2024-05-01 12:00:00.010 0.01 …' split at white
    space (headerless, or under 'date time ax …' or 'timestamp ax …'), 'Date,Time,AccX,…' in a CSV. Headerless, the
    --columns the error offered ('t,ax,ay,az,gx,gy,gz') were refused as 7 names for 8 columns; under a header the
    date was left out and the time of day read alone, or the 7-name header taken as a line above the table. Both
    fields are one column of date-times now (s since the epoch, UTC), counted as one column, whole and in blocks;
    a headerless file whose first column is a date-time in one field reads alike with the same --columns. A
    simulated flight so logged gives the attitude of the plain CSV."""
    from optinav.attitude.simulate import simulate as fly

    d = fly("dynamic", duration_s=6, rate_hz=100, rng=5, frame="enu")
    t0 = datetime.datetime(2024, 5, 1, 23, 59, 57)  # a midnight inside: the date changes
    when = [t0 + datetime.timedelta(milliseconds=round(1000 * x)) for x in d.t]
    values = np.column_stack([d.acc, d.gyr])
    iso = [w.strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] for w in when]
    files = {
        "bare.txt": (None, _logger_rows(iso, values, " ")),
        "both.txt": ("date time ax ay az gx gy gz\n", _logger_rows(iso, values, " ")),
        "one.txt": ("timestamp ax ay az gx gy gz\n", _logger_rows(iso, values, " ")),
        "columns.csv": ("Date,Time,AccX,AccY,AccZ,GyrX,GyrY,GyrZ\n", _logger_rows([s.replace(" ", ",") for s in iso], values)),
        "iso.csv": (None, _logger_rows([s.replace(" ", "T") for s in iso], values)),
    }  # fmt: skip
    for name, (head, rows) in files.items():
        path = _w(tmp_path / name, (head or "") + rows)
        columns = None
        if head is None:
            with pytest.raises(OptinavError) as exc:
                read_imu(path)
            columns = exc.value.remedy.split("'")[1]
            assert columns == "t,ax,ay,az,gx,gy,gz", name
        log = read_imu(path, columns=columns)
        np.testing.assert_allclose(log.t - _utc(t0), d.t, rtol=0, atol=1e-6, err_msg=name)
        np.testing.assert_allclose(log.acc, values[:, :3], rtol=1e-8, err_msg=name)
        np.testing.assert_allclose(log.gyr, values[:, 3:], rtol=1e-8, err_msg=name)
        blocks = list(iter_imu(path, columns=columns, chunk_rows=97))
        np.testing.assert_array_equal(np.concatenate([b.t for b in blocks]), log.t)
    assert any(
        "two fields a row, read as one column of date-times 'time'" in x for x in read_imu(tmp_path / "both.txt").notes
    )
    # a serial monitor's line of words above such rows is still no header
    capture = _w(tmp_path / "capture.txt", "MPU6050 connection successful\n" + files["bare.txt"][1])
    log = read_imu(capture, columns="t,ax,ay,az,gx,gy,gz")
    assert len(log) == len(d.t) and any("'MPU6050 connection successful') were left out" in x for x in log.notes)
    plain = tmp_path / "plain.csv"  # the same samples at the same times (s since the epoch)
    np.savetxt(plain, np.column_stack([_utc(t0) + d.t, values]), delimiter=",", header="t,ax,ay,az,gx,gy,gz",
               comments="", fmt=["%.3f"] + ["%.9g"] * 6)  # fmt: skip
    q = {}
    for name, args in (("both", [str(tmp_path / "both.txt")]), ("plain", [str(plain)])):
        out = tmp_path / f"{name}.q.csv"
        assert main(["--quiet", "attitude", *args, "--frame", "ENU", "--out", str(out)]) == 0
        q[name] = np.genfromtxt(out, delimiter=",", names=True)
    for k in ("qw", "qx", "qy", "qz"):  # (the times differ by an ulp at 1.7e9 s, 0.24 µs: the filter moves 1e-4)
        np.testing.assert_allclose(q["both"][k], q["plain"][k], rtol=0, atol=2e-3)


@pytest.mark.parametrize(
    "fmt, day, two",
    [
        ("%d/%m/%Y", 13, False),  # day first: the first field above 12
        ("%m/%d/%Y", 13, False),  # month first: the second
        ("%d.%m.%Y", 1, True),  # dots: day first (German loggers), in two fields
        ("%m/%d/%Y", 20, True),
    ],
)
def test_slash_dates_day_or_month_first_are_told_from_the_data(tmp_path, fmt, day, two):
    """Dates with the year last ('13/05/2024 12:00:00.010', '05/13/2024 …', '01.05.2024 …') were not date-times: the
    file was refused. A field above 12 in the first rows tells the day from the month; a '.' date is day first.
    The samples are timed in s since the epoch, whole and in blocks."""
    t0 = datetime.datetime(2024, 5, day, 9, 30, 0)
    when = [t0 + datetime.timedelta(milliseconds=10 * i) for i in range(300)]
    stamps = [w.strftime(f"{fmt} %H:%M:%S.%f")[:-3] for w in when]
    values = np.tile([0.01, -0.02, 9.8, 0.001, 0.002, 0.003], (300, 1))
    head = "date time ax ay az gx gy gz\n" if two else "time,ax,ay,az,gx,gy,gz\n"
    path = _w(tmp_path / "rtc.txt", head + _logger_rows(stamps, values, " " if two else ","))
    log = read_imu(path)
    np.testing.assert_allclose(log.t - _utc(t0), 0.01 * np.arange(300), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(np.concatenate([b.t for b in iter_imu(path, chunk_rows=64)]), log.t)


def test_slash_dates_that_do_not_tell_day_from_month_time_by_the_time_of_day(tmp_path):
    """'01/05/2024' is 1 May or 5 January: with no field above 12 in the first rows, the date does not time the
    samples (a note says so) and the times of day do, from the midnight before the first row, across a midnight
    where the date changes too (whole and in blocks); a date no order reads ('13/13/2024') is a one-line error."""
    t0 = datetime.datetime(2024, 5, 1, 23, 59, 58)
    when = [t0 + datetime.timedelta(milliseconds=10 * i) for i in range(400)]
    values = np.tile([0.01, -0.02, 9.8, 0.001, 0.002, 0.003], (400, 1))
    stamps = [w.strftime("%d/%m/%Y %H:%M:%S.%f")[:-3] for w in when]
    path = _w(tmp_path / "rtc.csv", "time,ax,ay,az,gx,gy,gz\n" + _logger_rows(stamps, values))
    log = read_imu(path)
    np.testing.assert_allclose(log.t, 86398.0 + 0.01 * np.arange(400), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(np.concatenate([b.t for b in iter_imu(path, chunk_rows=50)]), log.t)
    assert any("'time' (01/05/2024) do not tell the day from the month" in x for x in log.notes)
    bad = _w(
        tmp_path / "bad.csv", "time,ax,ay,az\n" + "".join(f"13/13/2024 12:00:0{i}.000,0,0,9.8\n" for i in range(5))
    )
    with pytest.raises(OptinavError, match="13/13/2024"):
        read_imu(bad)


def test_a_gps_clock_to_the_second_is_no_sample_time(tmp_path, capsys):
    """A 100 Hz log whose only time is a GPS clock to the second ('12:00:07', a hundred samples a stamp) was refused
    as holding duplicate timestamps, and --rate refused beside its time column. A clock coarser than the samples
    is no time now: without --rate a one-line error names --rate and the rate its stamps say; with --rate the
    samples are timed by it (the clock set aside, with a note) when the stamps agree, and a rate they contradict
    is refused. A simulated flight so logged gives the attitude of the plain CSV."""
    from optinav.attitude.simulate import simulate as fly

    d = fly("dynamic", duration_s=10, rate_hz=100, rng=7, frame="enu")
    values = np.column_stack([d.acc, d.gyr])
    sec = 12 * 3600 + 0.37 + d.t  # the first sample 0.37 s into its second
    stamps = [f"{int(s) // 3600:02d}:{int(s) % 3600 // 60:02d}:{int(s) % 60:02d}" for s in sec]
    path = _w(tmp_path / "gps.csv", "gps_time,ax,ay,az,gx,gy,gz\n" + _logger_rows(stamps, values))
    with pytest.raises(OptinavError, match="coarser than the samples") as exc:
        read_imu(path)
    assert "--rate" in exc.value.remedy and "about 100 Hz" in exc.value.remedy
    log = read_imu(path, rate_hz=100.0)
    np.testing.assert_allclose(log.t, d.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.gyr, values[:, 3:], rtol=1e-8)
    assert any("'gps_time' (steps of 1 s, 100 samples a stamp) set aside" in x for x in log.notes)
    np.testing.assert_array_equal(np.concatenate([b.t for b in iter_imu(path, rate_hz=100.0, chunk_rows=150)]), log.t)
    for rate in (50.0, 102.0):
        with pytest.raises(OptinavError, match=f"says 100 Hz but --rate {rate:g}"):
            read_imu(path, rate_hz=rate)
    out = tmp_path / "gps.q.csv"
    assert main(["attitude", str(path), "--frame", "ENU", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--rate" in err
    plain = tmp_path / "plain.csv"
    np.savetxt(plain, np.column_stack([d.t, values]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="",
               fmt="%.9g")  # fmt: skip
    assert main(["--quiet", "attitude", str(path), "--rate", "100", "--frame", "ENU", "--out", str(out)]) == 0
    assert main(["--quiet", "attitude", str(plain), "--frame", "ENU", "--out", str(tmp_path / "p.q.csv")]) == 0
    a, b = (np.genfromtxt(f, delimiter=",", names=True) for f in (out, tmp_path / "p.q.csv"))
    for k in ("t", "qw", "qx", "qy", "qz"):
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-6)
