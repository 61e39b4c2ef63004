"""Long logs: one row per sensor sample (``time, sensor, x, y, z``), as custom loggers and Android event dumps
write them. Each sensor's rows are read as its triad on its own times (as a multi record's), against the same
samples written one triad per column (imucal's real session, a BROAD trial)."""

from pathlib import Path

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import read_imu
from optinav.multipos.result import CalibrationResult

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
SESSION = SHARED / "imucal" / "example_ferraris_session.csv"
BROAD02 = SHARED / "attitude" / "broad" / "02_undisturbed_slow_rotation_B.hdf5"


def _session():
    if not SESSION.is_file():
        pytest.skip("imucal data absent")
    raw = np.genfromtxt(SESSION, delimiter=",", names=True)
    acc = np.column_stack([raw[f"acc_{a}"] for a in "xyz"])
    gyr = np.column_stack([raw[f"gyr_{a}"] for a in "xyz"])  # deg/s
    return np.arange(raw.size) / 102.4, acc, gyr


def _write_long(path, rows) -> Path:
    """``rows``: (time, sensor, (x, y, z)) in file order."""
    with open(path, "w") as f:
        f.write("t,sensor,x,y,z\n")
        for t, name, v in rows:
            f.write(f"{float(t)!r},{name},{float(v[0])!r},{float(v[1])!r},{float(v[2])!r}\n")
    return path


def _calibrate(tmp_path, path, name, *extra) -> CalibrationResult:
    out = tmp_path / f"{name}.json"
    argv = ["--quiet", "calibrate", "accel", str(path), "--gyro-unit", "deg/s", "--gravity", "9.81", *extra]
    assert main([*argv, "--out", str(out)]) == 0
    return CalibrationResult.from_json(out)


def test_a_long_log_calibrates_as_its_columns_do_and_in_bursts(tmp_path, capsys):
    """imucal's session as a long log, its gyro rows 1 ms after the accelerometer's (GYR on its own clock):
    the calibration of the wide file (gyro K within 1 % of its std: its samples interpolated onto the accelerometer's
    times),
    the note naming how the rows were read. Written in bursts of 100 rows of one sensor (the first blocks a
    streamed reader sees hold the accelerometer only) it reads the same."""
    t, acc, gyr = _session()
    wide = tmp_path / "wide.csv"
    np.savetxt(wide, np.column_stack([t, acc, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="",
               fmt="%.17g")  # fmt: skip
    rows = [r for i in range(t.size) for r in ((t[i], "ACC", acc[i]), (t[i] + 1e-3, "GYR", gyr[i]))]
    ref = _calibrate(tmp_path, wide, "wide")
    long = _calibrate(tmp_path, _write_long(tmp_path / "long.csv", rows), "long")
    err = capsys.readouterr().err
    assert (
        "long.csv: one row per sensor sample, column 'sensor' naming each row's sensor: ACC as the accelerometer; "
        "GYR as the gyroscope; the accelerometer on 10376 of its 20752 rows, the gyroscope on its 10376"
    ) in err
    # the accelerometer's samples are the file's; its poses are found with the gyro, interpolated
    np.testing.assert_allclose(long.accelerometer["K"], ref.accelerometer["K"], rtol=0, atol=1e-6)
    # the gyro's samples interpolated 1 ms (a tenth of a sample) onto the accelerometer's times: K within 1 % of
    # its std
    assert np.all(np.abs(long.gyroscope["K"] - ref.gyroscope["K"]) <= 0.01 * ref.gyroscope["K_std"])
    bursts = [r for k in range(0, t.size, 100) for s in (0, 1) for r in rows[2 * k + s : 2 * k + 200 : 2]]
    assert bursts[0][1] == bursts[99][1] == "ACC" and sorted(map(id, bursts)) == sorted(map(id, rows))
    burst = _calibrate(tmp_path, _write_long(tmp_path / "bursts.csv", bursts), "bursts")
    np.testing.assert_array_equal(burst.gyroscope["K"], long.gyroscope["K"])
    np.testing.assert_array_equal(burst.accelerometer["K"], long.accelerometer["K"])


def test_android_type_numbers_and_other_sensors_rows(tmp_path):
    """A numeric type column is read as Android's sensor types (1 accelerometer, 4 gyroscope); rows of other
    sensors (9, gravity) are left out and named; the accelerometer's samples are the file's, to the bit, from the
    gyro's first."""
    t, acc, gyr = _session()
    k = 2000
    path = tmp_path / "android.csv"
    with open(path, "w") as f:
        f.write("timestamp,type,value_x,value_y,value_z\n")
        for i in range(k):
            a, g, s = (float(v) for v in (t[i], t[i] + 2e-3, t[i] + 3e-3))
            f.write(f"{a!r},1,{','.join(repr(float(v)) for v in acc[i])}\n")
            f.write(f"{g!r},4,{','.join(repr(float(v)) for v in gyr[i])}\n")
            f.write(f"{s!r},9,0,0,9.8\n")
    log = read_imu(path, gyro_unit="deg/s")
    # the first accelerometer row comes before the gyro's first sample (2 ms later): no gyro to put on it
    np.testing.assert_array_equal(log.acc, acc[1:k])
    np.testing.assert_array_equal(log.t, t[1:k])
    assert any("1 (Android's type) as the accelerometer; 4 (Android's type) as the gyroscope (the rows of 9" in n
               for n in log.notes)  # fmt: skip


def test_a_long_log_without_time_or_without_an_imu_sensor(tmp_path):
    """Without a time column the sensors' rows cannot be put in time: one line naming it. Rows of sensors that
    are no IMU triad (GPS, a barometer) are not a long log: the shared columns name no sensor, as before."""
    rows = [(i / 100, s, (1.0, 2.0, 3.0)) for i in range(50) for s in ("ACC", "GYR")]
    path = _write_long(tmp_path / "nt.csv", rows)
    path.write_text("\n".join(",".join(line.split(",")[1:]) for line in path.read_text().splitlines()) + "\n")
    with pytest.raises(OptinavError, match="without a time column the sensors' samples cannot be put in time"):
        read_imu(path, rate_hz=100.0)
    other = _write_long(tmp_path / "gps.csv", [(i, s, (1.0, 2.0, 3.0)) for i in range(50) for s in ("GPS", "BARO")])
    with pytest.raises(OptinavError, match="columns x, y, z do not say which sensor they hold"):
        read_imu(other)


def test_a_9d_attitude_of_a_long_log_is_that_of_its_columns(tmp_path):
    """A BROAD trial's first 4000 samples as a long log with ACC, GYR and MAG rows at the same times: the 9D
    attitude (the magnetometer read from its own rows) is the wide file's, to the bit."""
    if not BROAD02.is_file():
        pytest.skip("BROAD data absent")
    from optinav.attitude.data import load_broad
    from optinav.io.readers import read_table

    tr = load_broad(BROAD02)
    n = 4000
    t = np.arange(n) * tr.dt
    wide = tmp_path / "w.csv"
    np.savetxt(wide, np.column_stack([t, tr.acc[:n], tr.gyr[:n], tr.mag[:n]]), delimiter=",",
               header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="", fmt="%.17g")  # fmt: skip
    rows = [(t[i], s, a[i]) for i in range(n) for s, a in (("ACC", tr.acc), ("GYR", tr.gyr), ("MAG", tr.mag))]
    long = _write_long(tmp_path / "l.csv", rows)
    q = []
    for path in (wide, long):
        out = tmp_path / f"{path.stem}.out.csv"
        assert main(["--quiet", "attitude", str(path), "--frame", "ENU", "--mag", "--out", str(out)]) == 0
        tab = read_table(out)
        q.append(np.column_stack([tab[k] for k in ("qw", "qx", "qy", "qz")]))
    np.testing.assert_array_equal(q[1], q[0])


def test_a_device_name_column_beside_the_triads_is_left_out_as_before(tmp_path):
    """A 'sensor' column holding the device's name on every row beside ax … gz is no long log: left out with the
    note any unread text column gets, the triads read as they stand."""
    t, acc, gyr = _session()
    path = tmp_path / "w.csv"
    with open(path, "w") as f:
        f.write("sensor,t,ax,ay,az,gx,gy,gz\n")
        for i in range(500):
            f.write(f"MPU6050,{float(t[i])!r},{','.join(repr(float(v)) for v in (*acc[i], *gyr[i]))}\n")
    log = read_imu(path, gyro_unit="deg/s")
    np.testing.assert_array_equal(log.acc, acc[:500])
    assert any("column(s) 'sensor' hold text and were left out" in n for n in log.notes)


def test_a_type_column_beside_named_triads_is_no_long_log(tmp_path):
    """A numeric 'type' column (a packet type, 1 on every row, as Android's accelerometer number) beside x, y, z
    positions and named triads: the triads are read as named, x, y, z left alone."""
    t, acc, gyr = _session()
    path = tmp_path / "p.csv"
    pos = np.arange(1500.0)[:, None] * [1.0, 2.0, 3.0]
    np.savetxt(path, np.column_stack([t[:1500], np.ones(1500), pos, acc[:1500], gyr[:1500]]), delimiter=",",
               header="t,type,x,y,z,ax,ay,az,gx,gy,gz", comments="", fmt="%.17g")  # fmt: skip
    log = read_imu(path, gyro_unit="deg/s")
    np.testing.assert_array_equal(log.acc, acc[:1500])
    assert not any("one row per sensor sample" in n for n in log.notes)
