"""Phone apps' exports of several sensors (Sensor Logger, phyphox) given as the zip they share or the folder it
unzips to: read by every command that reads IMU data, each sensor on its own time stamps, nothing written next to
the input."""

import zipfile

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.results import Result
from optinav.errors import OptinavError
from optinav.io import iter_imu, read_imu
from optinav.multipos.simulate import simulate

T0_NS = 1698000000123456789


def _sensor_logger(t, xyz) -> str:
    """One Sensor Logger file (tszheichoi/awesome-sensor-logger UNITS.md: ``time`` in ns since the epoch,
    ``seconds_elapsed`` in s, then the axes in the order z, y, x)."""
    rows = [
        f"{T0_NS + round(ti * 1e9)},{float(ti)!r}," + ",".join(repr(float(v)) for v in x[::-1]) for ti, x in zip(t, xyz)
    ]
    return "time,seconds_elapsed,z,y,x\n" + "\n".join(rows) + "\n"


def _phyphox(t, xyz, label, unit) -> str:
    """One export set as phyphox writes it into its CSV zip (phyphox-android DataExport.java: quoted names, values
    as 0.000000000E0; the simple experiment's names, SimpleExperimentCreator.java)."""
    head = ",".join(f'"{h}"' for h in ["Time (s)", *(f"{label} {a} ({unit})" for a in "xyz")])
    return head + "\n" + "".join(",".join("%.9E" % v for v in (ti, *x)) + "\n" for ti, x in zip(t, xyz))


def _export(tmp_path, name, files: dict, top: str = ""):
    """The export as a zip (members under ``top``) and as the folder it unzips to; their contents."""
    z = tmp_path / f"{name}.zip"
    with zipfile.ZipFile(z, "w", zipfile.ZIP_DEFLATED) as w:
        for member, text in files.items():
            w.writestr(top + member, text)
    folder = tmp_path / name
    with zipfile.ZipFile(z) as w:
        w.extractall(folder)
    return z, folder / top.rstrip("/") if top else folder


def _listing(path):
    return sorted(str(p.relative_to(path.parent)) for p in path.parent.rglob("*"))


def test_a_sensor_logger_export_is_read_as_its_file_pair(tmp_path, capsys):
    """Sensor Logger's export (TotalAcceleration.csv with gravity, Gyroscope.csv on its own clock, the gravity-free
    Accelerometer.csv, Gravity.csv, Metadata.csv) given as its zip or folder ended in 'extract it and pass
    TotalAcceleration.csv with --gyro Gyroscope.csv'. Now read as exactly that pair (the gyroscope interpolated
    onto the accelerometer's times), whole and in blocks, with a note naming the files; calibrate recovers the
    simulated multi-position recording's scales; nothing is written into the folder or beside the zip."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=4)
    files = {
        "TotalAcceleration.csv": _sensor_logger(s.t, s.acc),
        "Gyroscope.csv": _sensor_logger(s.t + 0.002, s.gyr),
        "Accelerometer.csv": _sensor_logger(s.t, s.acc - [0.0, 0.0, 9.8]),
        "Gravity.csv": _sensor_logger(s.t, np.tile([0.0, 0.0, 9.8], (s.t.size, 1))),
        "Metadata.csv": "version,device name,recording time\n1.30,Pixel 7,2024-05-01_10-00-00\n",
    }
    z, folder = _export(tmp_path, "2024-05-01_10-00-00", files, top="2024-05-01_10-00-00/")
    (tmp_path / "pair").mkdir()
    for name in ("TotalAcceleration.csv", "Gyroscope.csv"):
        (tmp_path / "pair" / name).write_text(files[name])
    want = read_imu(tmp_path / "pair" / "TotalAcceleration.csv", gyro_path=tmp_path / "pair" / "Gyroscope.csv")
    before, zipped = _listing(folder), (z.read_bytes(), z.stat().st_mtime_ns)
    for path in (z, folder):
        log = read_imu(path)
        for k in ("t", "acc", "gyr"):
            np.testing.assert_array_equal(getattr(log, k), getattr(want, k))
        assert (
            log.notes[0].startswith(f"{path.name} is Sensor Logger's export: read ")
            and "Gyroscope.csv" in (log.notes[0])
        ), log.notes
        assert ("in memory from the zip" in log.notes[0]) == (path == z)
        blocks = list(iter_imu(path, chunk_rows=500))
        assert len(blocks) > 1
        np.testing.assert_array_equal(np.concatenate([b.gyr for b in blocks]), want.gyr)
    out = tmp_path / "r.json"  # the command reads it as read_imu does
    assert main(["calibrate", "accel", str(z), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    r = Result.from_json(out)
    from optinav.multipos import model

    U, _ = model.upper_triangular_form(s.acc_K)
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(U), atol=4 * np.max(r.accelerometer["K_std"]))
    assert "Sensor Logger's export" in capsys.readouterr().err
    assert _listing(folder) == before  # nothing written into the input folder, the zip untouched
    assert (z.read_bytes(), z.stat().st_mtime_ns) == zipped
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "2024-05-01_10-00-00",
        "2024-05-01_10-00-00.zip",
        "pair",
        "r.json",
    ]


def test_a_sensor_logger_export_with_only_the_uncalibrated_gyroscope_is_read(tmp_path):
    """Sensor Logger writes GyroscopeUncalibrated.csv (the rates with the phone's bias estimate left in) where the
    calibrated gyroscope is switched off: such an export ended in 'Sensor Logger's export without Gyroscope.csv'.
    Now its pair is TotalAcceleration.csv with GyroscopeUncalibrated.csv, read as that pair given by hand;
    Gyroscope.csv is still the one taken where both are there."""
    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=5)
    bias = np.array([0.01, -0.02, 0.005])
    files = {
        "TotalAcceleration.csv": _sensor_logger(s.t, s.acc),
        "GyroscopeUncalibrated.csv": _sensor_logger(s.t + 0.002, s.gyr + bias),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    z, folder = _export(tmp_path, "uncal", files)
    want = read_imu(folder / "TotalAcceleration.csv", gyro_path=folder / "GyroscopeUncalibrated.csv")
    for path in (z, folder):
        log = read_imu(path)
        for k in ("t", "acc", "gyr"):
            np.testing.assert_array_equal(getattr(log, k), getattr(want, k))
        assert "GyroscopeUncalibrated.csv" in log.notes[0], log.notes
    files["Gyroscope.csv"] = _sensor_logger(s.t + 0.002, s.gyr)
    z, folder = _export(tmp_path, "both", files)
    log = read_imu(z)
    np.testing.assert_array_equal(log.gyr, read_imu(folder / "TotalAcceleration.csv",
                                                    gyro_path=folder / "Gyroscope.csv").gyr)  # fmt: skip


def test_a_phyphox_export_is_read_and_allan_takes_each_sensor_on_its_clock(tmp_path, capsys):
    """phyphox's CSV export of its simple experiment (Accelerometer.csv with g, Gyroscope.csv, Magnetometer.csv on
    their own times, meta/device.csv, meta/time.csv) as a zip or a folder: read as the accelerometer with the
    gyroscope interpolated onto its times; allan analyses each sensor on its own clock (interpolating white noise
    onto other times low-passes it): the white noise N within 5 % of the simulated std × √dt; attitude --mag takes
    its Magnetometer.csv (µT) on its own clock."""
    rng = np.random.default_rng(12)
    n, sa, sg = 6000, 0.02, 0.003
    ta, tg = 0.0031 + np.arange(n) / 100.0, 0.0077 + np.arange(n) / 100.0
    acc = np.array([0.1, -0.2, 9.80665]) + rng.normal(0, sa, (n, 3))
    gyr = np.array([0.001, -0.002, 0.003]) + rng.normal(0, sg, (n, 3))
    files = {
        "Accelerometer.csv": _phyphox(ta, acc, "Acceleration", "m/s^2"),
        "Gyroscope.csv": _phyphox(tg, gyr, "Gyroscope", "rad/s"),
        "Magnetometer.csv": _phyphox(ta[::4], np.tile([0.0, 20.0, -40.0], (n // 4, 1)), "Magnetic field", "µT"),
        "meta/device.csv": '"property","value"\n"version","1.1.16"\n',
        "meta/time.csv": '"event","experiment time","system time","system time text"\n',
    }
    z, folder = _export(tmp_path, "Simple 2025-01-01 10-00-00", files)
    for path in (z, folder):
        log = read_imu(path)
        keep = ta <= tg[-1]
        keep &= ta >= tg[0]
        np.testing.assert_allclose(log.t, ta[keep], rtol=1e-9, atol=0)
        np.testing.assert_allclose(log.acc, acc[keep], rtol=1e-9, atol=1e-12)
        want = np.column_stack([np.interp(ta[keep], tg, gyr[:, j]) for j in range(3)])
        np.testing.assert_allclose(log.gyr, want, rtol=1e-9, atol=1e-12)
        out = tmp_path / "allan.json"
        assert main(["allan", str(path), "--out", str(out)]) == 0
        res = Result.from_json(out)
        for sensor, truth in (("accelerometer", sa * 0.1), ("gyroscope", sg * 0.1)):
            np.testing.assert_allclose(res.sensor(sensor)["fit"].white, truth, rtol=0.05)
    capsys.readouterr()
    assert main(["attitude", str(z), "--mag", "--frame", "ENU", "--out", str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    assert "magnetometer of Magnetometer.csv (columns Magnetic field x (µT), Magnetic field y (µT), " in err, err
    assert f"{n // 4} samples at 25 Hz" in err and "(100 Hz) hold a sample" in err, err


def test_a_zip_of_two_recordings_is_refused_and_a_zipped_folder_is_read(tmp_path, capsys):
    """A zip of two Sensor Logger recordings' folders (A/, B/) was read as B's pair with exit 0 (the members keyed by
    their base names, the last one kept): refused naming both folders. phyphox's export zipped with its folder
    (Simple/meta/device.csv) ended in 'extract it and pass one table': read as the same export at the top."""
    t = np.arange(300) / 100.0
    meta = "version,device name\n1.30,Pixel 7\n"
    rec = {
        f"{r}/{n}": _sensor_logger(t, np.tile([0.0, 0.0, 9.8] if n[0] == "T" else [g, 0.0, 0.0], (t.size, 1)))
        for r, g in (("A", 0.1), ("B", 0.2))
        for n in ("TotalAcceleration.csv", "Gyroscope.csv", "Metadata.csv")
    }
    rec.update({k: meta for k in rec if k.endswith("Metadata.csv")})
    z, _ = _export(tmp_path, "two", rec)
    for path, remedy in ((z, "extract it and pass one recording's folder"), (tmp_path / "two", "; pass one rec")):
        with pytest.raises(OptinavError, match=r"2 recordings' exports \(A/, B/\)"):
            read_imu(path)  # the folder it unzips to was 'data file two is a folder; check the path'
        assert main(["attitude", str(path), "--out", str(tmp_path / "a.csv")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and remedy in err[0], err
    np.testing.assert_allclose(read_imu(tmp_path / "two" / "A").gyr[:, 0], 0.1)
    rng = np.random.default_rng(3)
    acc, gyr = rng.normal([0, 0, 9.8], 0.01, (300, 3)), rng.normal(0, 0.01, (300, 3))
    files = {
        "Accelerometer.csv": _phyphox(t, acc, "Acceleration", "m/s^2"),
        "Gyroscope.csv": _phyphox(t, gyr, "Gyroscope", "rad/s"),
        "meta/device.csv": '"property","value"\n',
        "meta/time.csv": '"event","experiment time"\n',
    }
    z, _ = _export(tmp_path, "Simple", files, top="Simple/")
    log = read_imu(z)
    np.testing.assert_allclose(log.acc, acc, rtol=1e-9)
    np.testing.assert_allclose(log.gyr, gyr, rtol=1e-9, atol=1e-12)
    assert "read Simple/Accelerometer.csv" in log.notes[0], log.notes


def test_a_pause_of_both_sensors_is_a_gap_and_a_gyroscope_gap_alone_is_refused(tmp_path, capsys):
    """phyphox paused 10 s (both sensors stop; their times go on): the gyroscope's gap was refused as 'interpolating
    it would invent 10 s of rates' for the one accelerometer row at its edge, and --allow-gaps did not help. Now
    that row is left out (noted) and the pause is a time gap as any log's: refused without --allow-gaps, with it the
    inclination within 0.5° of the simulation's, whole and streamed alike. A gap of the gyroscope alone (the
    accelerometer sampling on) is still refused."""
    from optinav.attitude.metrics import inclination_error, rmse
    from optinav.attitude.simulate import simulate

    f = simulate("static", duration_s=40.0, rate_hz=100.0, frame="enu", rng=3)
    keep = (f.t < 15) | (f.t > 25)
    meta = {"meta/device.csv": '"property","value"\n', "meta/time.csv": '"event","experiment time"\n'}
    acc = _phyphox(f.t[keep], f.acc[keep], "Acceleration", "m/s^2")
    z, _ = _export(tmp_path, "pause", {**meta, "Accelerometer.csv": acc,
                                       "Gyroscope.csv": _phyphox(f.t[keep] + 0.003, f.gyr[keep], "Gyroscope", "rad/s")})  # fmt: skip
    out = tmp_path / "a.csv"
    assert main(["attitude", str(z), "--frame", "ENU", "--out", str(out)]) == 2
    assert "time gap of 10 s" in capsys.readouterr().err
    got = {}
    for extra in ([], ["--chunk-rows", "500"]):
        assert main(["attitude", str(z), "--frame", "ENU", "--allow-gaps", *extra, "--out", str(out)]) == 0
        err = capsys.readouterr().err
        assert "; 1 at the edges of a pause of both sensors" in err, err
        got[len(extra)] = out.read_bytes()
        data = np.loadtxt(out, delimiter=",", skiprows=1)
        rows = np.searchsorted(f.t, data[:, 0] - 1e-9)
        assert rmse(np.degrees(inclination_error(data[:, 1:5], f.q_b_n[rows]))) < 0.5
    assert got[0] == got[2]
    gk = (f.t < 15) | (f.t > 25) | (np.arange(f.t.size) % 2 == 0)  # the accelerometer samples on, at 50 Hz
    files = {**meta, "Accelerometer.csv": _phyphox(f.t[gk], f.acc[gk], "Acceleration", "m/s^2"),
             "Gyroscope.csv": _phyphox(f.t[keep] + 0.003, f.gyr[keep], "Gyroscope", "rad/s")}  # fmt: skip
    z, _ = _export(tmp_path, "gyrogap", files)
    assert main(["attitude", str(z), "--frame", "ENU", "--allow-gaps", "--out", str(out)]) == 2
    assert "the gyroscope has no sample from t = 14.993 s to 25.013 s" in capsys.readouterr().err


def test_an_export_that_cannot_be_read_names_the_remedy(tmp_path, capsys):
    """An export without the pair keeps its one-line error with the remedy: Sensor Logger's without Gyroscope.csv
    (was a bare 'zip archive of 4 text tables; extract it and pass one table'), phyphox's Linear Acceleration (gravity
    taken out); an export given with --gyro is refused naming the export's gyroscope."""
    t = np.arange(50) / 100.0
    xyz = np.tile([0.0, 0.0, 9.8], (50, 1))
    files = {n: _sensor_logger(t, xyz) for n in ("TotalAcceleration.csv", "Accelerometer.csv", "Gravity.csv")}
    files["Metadata.csv"] = "version,device name\n1.30,Pixel 7\n"
    z, folder = _export(tmp_path, "nogyro", files)
    for path, where in ((z, "extract it and pass "), (folder, f"pass {folder}/")):
        assert main(["attitude", str(path), "--out", str(tmp_path / "a.csv")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Sensor Logger's export without Gyroscope.csv" in err[0], err
        assert f"{where}TotalAcceleration.csv for the accelerometer alone" in err[0], err
    lin = {
        "Linear Acceleration.csv": _phyphox(t, xyz * 0, "Linear Acceleration", "m/s^2"),
        "meta/device.csv": '"property","value"\n',
    }
    z, folder = _export(tmp_path, "linear", lin)
    for path in (z, folder):
        assert main(["allan", str(path), "--out", str(tmp_path / "a.json")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "Linear Acceleration has gravity taken out" in err[0], err
    files = {"TotalAcceleration.csv": _sensor_logger(t, xyz), "Gyroscope.csv": _sensor_logger(t, xyz * 0)}
    z, _ = _export(tmp_path, "pair", files)
    with pytest.raises(OptinavError, match="holds the gyroscope .Gyroscope.csv.; drop gyro_path"):
        read_imu(z, gyro_path=z)


def _phone_flight(seed=3, duration_s=40.0):
    """A simulated dynamic flight (optinav.attitude.simulate, NED, 400 Hz) sampled as a phone gives it: the
    accelerometer at 100 Hz, the gyroscope at 100 Hz 2.5 ms later, the magnetometer (a 50 µT field at 60° dip, 0.3 µT
    noise) at 25 Hz 7.5 ms after an accelerometer row; (flight, field samples at every 400 Hz step, row indices
    of acc, gyro, mag)."""
    from optinav.attitude.simulate import simulate
    from optinav.core.rotations import quat_conjugate, quat_rotate

    f = simulate("dynamic", duration_s=duration_s, rate_hz=400.0, frame="ned", rng=seed)
    field = 50.0 * np.array([np.cos(np.radians(60.0)), 0.0, np.sin(np.radians(60.0))])
    mag = quat_rotate(quat_conjugate(f.q_b_n), field) + np.random.default_rng(seed).normal(0, 0.3, (f.t.size, 3))
    n = f.t.size
    return f, mag, np.arange(0, n, 4), np.arange(1, n, 4), np.arange(3, n, 16)


def _heading_rmse_deg(out, q_true):
    from optinav.attitude.metrics import heading_error, rmse

    q = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    return rmse(np.degrees(heading_error(q, q_true))[1000:])  # after the first 10 s (the heading converges)


def _bound_deg(f, mag, rows, log):
    """The heading RMSE (deg) of the same flight with the magnetometer at 25 Hz on the accelerometer's rows themselves
    (every 16th 400 Hz step), plus what a sample misdated by half a 100 Hz step costs at the flight's RMS rate."""
    from optinav.attitude import estimate
    from optinav.attitude.metrics import heading_error, rmse

    direct = np.full((rows.size, 3), np.nan)
    on = rows % 16 == 0
    direct[on] = mag[rows[on]]
    dt = np.diff(log.t, prepend=log.t[0] - 0.01)
    ref = estimate(log.gyr, log.acc, dt, mag=direct, frame="ned")
    ref_rmse = rmse(np.degrees(heading_error(ref.q_b_n, f.q_b_n[rows]))[1000:])
    rate = np.degrees(np.sqrt(np.mean(np.sum(f.gyr_true**2, axis=1))))
    return ref_rmse + rate * 0.005 / 2


def test_9d_attitude_of_a_phone_export_takes_its_magnetometer_on_its_own_clock(tmp_path, capsys):
    """optinav attitude --mag on a phone export had no way to take its Magnetometer.csv (on its own time stamps;
    --mag-columns reads the IMU's rows only). Now each 25 Hz sample goes on its nearest 100 Hz accelerometer row (NaN
    between: no sample invented), noted with both rates. Its heading error is within the same run's with the
    magnetometer sampled on the accelerometer's rows directly, plus what a sample misdated by the rows' half step
    costs at the flight's RMS rate; --mag-file gives the same magnetometer file to a file pair, with the same
    result, and a block boundary between a sample and its row changes nothing."""
    from optinav.attitude import estimate
    from optinav.attitude.metrics import heading_error, rmse

    f, mag, ia, ig, im = _phone_flight()
    files = {
        "TotalAcceleration.csv": _sensor_logger(f.t[ia], f.acc[ia]),
        "Gyroscope.csv": _sensor_logger(f.t[ig], f.gyr[ig]),
        "Magnetometer.csv": _sensor_logger(f.t[im], mag[im]),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    z, folder = _export(tmp_path, "flight", files)
    rows = ia[(f.t[ia] >= f.t[ig[0]]) & (f.t[ia] <= f.t[ig[-1]])]  # the accelerometer rows the gyroscope spans
    outs = {}
    for key, argv in {
        "zip": [str(z), "--mag"],
        "folder": [str(folder), "--mag", "--chunk-rows", "701"],
        "files": [str(folder / "TotalAcceleration.csv"), "--gyro", str(folder / "Gyroscope.csv"), "--mag-file",
                  str(folder / "Magnetometer.csv")],
    }.items():  # fmt: skip
        outs[key] = tmp_path / f"{key}.csv"
        assert main(["attitude", *argv, "--out", str(outs[key])]) == 0
        err = capsys.readouterr().err
        assert f"magnetometer of Magnetometer.csv (columns x, y, z): {im.size} samples at 25 Hz" in err, err
        assert f"each sample put on its nearest IMU row (NaN between: no sample invented): {im.size} of the " in err
        assert f"{rows.size} IMU rows (100 Hz)" in err
    text = outs["zip"].read_bytes()
    assert outs["folder"].read_bytes() == text and outs["files"].read_bytes() == text
    phone = _heading_rmse_deg(outs["zip"], f.q_b_n[rows])
    log = read_imu(z)
    assert phone <= _bound_deg(f, mag, rows, log), phone  # 1.11° vs 1.15° + 0.09°
    dt = np.diff(log.t, prepend=log.t[0] - 0.01)
    gyro_only = estimate(log.gyr, log.acc, dt, frame="ned")
    assert phone < 0.05 * rmse(np.degrees(heading_error(gyro_only.q_b_n, f.q_b_n[rows]))[1000:])


def test_a_magnetometer_file_on_another_clock_is_refused(tmp_path, capsys):
    """--mag-file whose time column is in ms (read as s) put the 1 sample of its first 40 ms on the rows of a 40 s
    flight: 9D with exit 0 and a heading from those. Now refused naming how many of its samples lie within the
    IMU's span, in memory and streamed alike; its column named 't (ms)' (the remedy) gives the heading of the same
    magnetometer in seconds. An IMU log cut from the recording fits its whole magnetometer file; one 1000 s later
    is refused. A duplicate time stamp in it names no option of the IMU's file."""
    f, mag, ia, ig, im = _phone_flight()
    imu = tmp_path / "imu.csv"
    np.savetxt(imu, np.column_stack([f.t[ia], f.acc[ia], f.gyr[ia]]), delimiter=",", comments="",
               header="t,ax,ay,az,gx,gy,gz")  # fmt: skip
    outs = {}
    for name, head, scale in (("s", "t", 1.0), ("ms", "t", 1e3), ("named", "t (ms)", 1e3)):
        path = tmp_path / f"mag_{name}.csv"
        np.savetxt(path, np.column_stack([f.t[im] * scale, mag[im]]), delimiter=",", comments="",
                   header=f"{head},mx,my,mz", fmt="%.10g")  # fmt: skip
        for chunk in ([], ["--chunk-rows", "701"])[: 1 if name == "named" else 2]:
            out = tmp_path / f"{name}{len(chunk)}.csv"
            code = main(["attitude", str(imu), "--mag-file", str(path), "--out", str(out), *chunk])
            err = capsys.readouterr().err
            if name == "ms":
                inside = int(np.count_nonzero(f.t[im] * 1e3 <= f.t[ia[-1]] + 0.01))
                assert code == 2 and not out.exists(), err
                assert "40 s apart) do not fit the IMU's (0 to 40 s, 0.01 s apart;" in err, err
                assert f"{inside} of its {im.size} samples within): another clock or another time unit" in err, err
                assert "name its unit (e.g. 't (ms)')" in err and len(err.strip().splitlines()) == 1, err
            else:
                assert code == 0, err
                outs[name, len(chunk)] = out.read_bytes()
    assert outs["named", 0] == outs["s", 0] == outs["s", 2]
    dup = tmp_path / "mag_dup.csv"  # its remedy named --columns and --rate, options of the IMU's file
    dup.write_text("t,mx,my,mz\n0.0,1,2,3\n0.04,1,2,3\n0.04,1,2,3\n0.08,1,2,3\n")
    assert main(["attitude", str(imu), "--mag-file", str(dup), "--out", str(tmp_path / "d.csv")]) == 2
    err = capsys.readouterr().err
    assert "mag_dup.csv has a duplicate timestamp at index 2 (t = 0.04 s); drop the duplicated samples" in err, err
    assert "--rate" not in err and "--columns" not in err, err
    assert _heading_rmse_deg(tmp_path / "s0.csv", f.q_b_n[ia]) <= _bound_deg(f, mag, ia, read_imu(imu))
    cut = tmp_path / "cut.csv"  # the IMU cut to 20-25 s, the magnetometer's file whole: fits
    rows = ia[(f.t[ia] >= 20.0) & (f.t[ia] < 25.0)]
    np.savetxt(cut, np.column_stack([f.t[rows], f.acc[rows], f.gyr[rows]]), delimiter=",", comments="",
               header="t,ax,ay,az,gx,gy,gz")  # fmt: skip
    assert main(["attitude", str(cut), "--mag-file", str(tmp_path / "mag_s.csv"), "--out", str(out)]) == 0
    assert f"{rows.size // 4} of the {rows.size} IMU rows (100 Hz) hold a sample" in capsys.readouterr().err
    late = tmp_path / "mag_late.csv"  # on another clock: 1000 s later
    np.savetxt(late, np.column_stack([f.t[im] + 1000.0, mag[im]]), delimiter=",", comments="", header="t,mx,my,mz")
    assert main(["attitude", str(imu), "--mag-file", str(late), "--out", str(out)]) == 2
    assert f"0 of its {im.size} samples within): another clock" in capsys.readouterr().err


def test_an_uncalibrated_magnetometer_that_hardly_turns_is_refused(tmp_path, capsys):
    """A still phone's Sensor Logger export with only MagnetometerUncalibrated.csv (15, 10, -5 µT of hard-iron
    offset) gave a 26° heading RMSE with exit 0: the field hardly turns, so the fit cannot see the offset, and
    nothing said so. Now refused, in memory, streamed, offline and as --mag-file, naming --mag-hard-iron and
    Magnetometer.csv; the
    offset given (the remedy) gives the heading of the calibrated file, within 0.5°."""
    from optinav.attitude.simulate import simulate
    from optinav.core.rotations import quat_conjugate, quat_rotate

    f = simulate("static", duration_s=20.0, rate_hz=400.0, frame="ned", rng=3)
    field = 50.0 * np.array([np.cos(np.radians(60.0)), 0.0, np.sin(np.radians(60.0))])
    mag = quat_rotate(quat_conjugate(f.q_b_n), field) + np.random.default_rng(3).normal(0, 0.3, (f.t.size, 3))
    ia, ig, im = (np.arange(k, f.t.size, s) for k, s in ((0, 4), (1, 4), (3, 16)))
    off = np.array([15.0, 10.0, -5.0])
    base = {
        "TotalAcceleration.csv": _sensor_logger(f.t[ia], f.acc[ia]),
        "Gyroscope.csv": _sensor_logger(f.t[ig], f.gyr[ig]),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    cal, _ = _export(tmp_path, "cal", {**base, "Magnetometer.csv": _sensor_logger(f.t[im], mag[im])})
    raw, _ = _export(tmp_path, "raw", {**base, "MagnetometerUncalibrated.csv": _sensor_logger(f.t[im], mag[im] + off)})
    loose = tmp_path / "raw" / "MagnetometerUncalibrated.csv"  # the same file given as --mag-file
    for path, extra in ((raw, []), (raw, ["--chunk-rows", "701"]), (raw, ["--offline"]),
                        (tmp_path / "raw" / "TotalAcceleration.csv", ["--gyro", str(loose.with_name("Gyroscope.csv")),
                                                                      "--mag-file", str(loose)])):  # fmt: skip
        out = tmp_path / "r.csv"
        assert main(["attitude", str(path), "--mag", *extra, "--out", str(out)]) == 2 and not out.exists()
        err = [e for e in capsys.readouterr().err.splitlines() if "error" in e]
        assert len(err) == 1 and "MagnetometerUncalibrated.csv (columns x, y, z) is an uncalibrated" in err[0], err
        assert "--mag-hard-iron=BX,BY,BZ" in err[0] and "(Magnetometer.csv)" in err[0], err
    rows = ia[(f.t[ia] >= f.t[ig[0]]) & (f.t[ia] <= f.t[ig[-1]])]
    head = {}
    for name, path, extra in (("cal", cal, []), ("given", raw, ["--mag-hard-iron=15,10,-5"])):
        out = tmp_path / f"{name}.csv"
        assert main(["attitude", str(path), "--mag", *extra, "--out", str(out)]) == 0
        head[name] = _heading_rmse_deg(out, f.q_b_n[rows])
    assert head["cal"] < 0.5 and head["given"] < 0.5, head


def _ptb_multi(t_rows: dict, values: dict) -> str:
    """Physics Toolbox Sensor Suite's multi record ``time,gFx,gFy,gFz,wx,wy,wz,Bx,By,Bz``: a row at each sensor's
    sample, the other sensors' cells repeating their last sample (0 before their first: the 0.0000 rows of a
    multi record's start, vehicle-classification README; d33pk3rn3l/Navigation_23FS_ETHZ read_sensor_output.py)."""
    events = sorted((t, k, i) for k, ts in t_rows.items() for i, t in enumerate(ts))
    last = {k: np.zeros(3) for k in t_rows}
    rows = []
    for t, k, i in events:
        last[k] = values[k][i]
        rows.append(",".join([f"{t:.6f}", *(f"{v:.5f}" for k2 in ("gF", "w", "B") for v in last[k2])]))
    return "time,gFx,gFy,gFz,wx,wy,wz,Bx,By,Bz\n" + "\n".join(rows) + "\n"


def test_physics_toolbox_multi_record_magnetometer_is_read_on_its_rows(tmp_path, capsys):
    """Physics Toolbox's multi record writes its magnetometer Bx, By, Bz (µT) at its own samples like the other
    sensors: --mag was 'not on the accelerometer's rows; drop --mag'. Now its rows of a new sample are its samples,
    put on the accelerometer's rows as a separate file's: the heading as the phone export's of the same flight."""
    f, mag, ia, ig, im = _phone_flight()
    text = _ptb_multi({"gF": f.t[ia], "w": f.t[ig], "B": f.t[im]},
                      {"gF": f.acc[ia] / 9.80665, "w": f.gyr[ig], "B": mag[im]})  # fmt: skip
    path = tmp_path / "Physics Toolbox multi record.csv"
    path.write_text(text)
    out = tmp_path / "a.csv"
    assert main(["attitude", str(path), "--mag", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"magnetometer of {path.name} (columns Bx, By, Bz, the rows of a new sample): {im.size} samples" in err
    log = read_imu(path)
    rows = ia[np.isin(np.round(f.t[ia], 6), np.round(log.t, 6))]
    assert rows.size == log.t.size
    assert _heading_rmse_deg(out, f.q_b_n[rows]) <= _bound_deg(f, mag, rows, log)


def test_magnetometer_on_the_imu_rows_invents_no_sample():
    """MagSamples.on_rows: a slower magnetometer puts each sample on its nearest row only (the nearer of two on one
    row; none in a gap of the IMU), whole or block by block with the neighbouring rows' times; a faster one is
    interpolated, NaN outside its span and across its gaps."""
    from optinav.io.imu import MagSamples

    t = np.arange(100) * 0.01
    t = np.delete(t, np.arange(40, 60))  # a 0.21 s gap in the IMU's rows
    tm = 0.003 + np.arange(34) * 0.03
    ms = MagSamples(tm, np.column_stack([tm, -tm, 2 * tm]), "m")
    whole = ms.on_rows(t, 0.01)
    held = np.isfinite(whole[:, 0])
    for k in np.flatnonzero(held):  # each row holds the sample nearest to it, within half a step
        assert abs(whole[k, 0] - t[k]) <= 0.005 + 1e-12
    inside = (tm >= -0.005) & ((tm <= t[39] + 0.01) | (tm >= t[40] - 0.01)) & (tm <= t[-1] + 0.01)
    assert held.sum() == inside.sum() == np.unique(whole[held, 0]).size  # every sample once, none in the gap
    cuts = [0, 17, 18, 55, t.size]
    blocks = [ms.on_rows(t[a:b], 0.01, t[a - 1] if a else -np.inf, t[b] if b < t.size else np.inf)
              for a, b in zip(cuts[:-1], cuts[1:])]  # fmt: skip
    np.testing.assert_array_equal(np.concatenate(blocks), whole)
    fast = MagSamples(np.arange(200) * 0.004, np.tile(np.arange(200.0)[:, None], 3), "m")
    got = fast.on_rows(np.arange(100) * 0.01 + 0.001, 0.01)
    np.testing.assert_allclose(got[:-20, 0], (np.arange(80) * 0.01 + 0.001) / 0.004)
    assert np.isnan(got[-20:]).all()  # beyond its last sample (0.796 s)
    gap = MagSamples(np.delete(fast.t, np.arange(100, 120)), np.delete(fast.mag, np.arange(100, 120), 0), "m")
    g = gap.on_rows(np.arange(80) * 0.01, 0.01)
    assert np.isnan(g[41:48]).all() and np.isfinite(g[:40]).all() and np.isfinite(g[49:]).all()


def test_an_export_s_files_are_inputs_and_its_magnetometer_errors_name_the_flag(tmp_path, capsys):
    """An export folder's files are the command's inputs: --out onto its Gyroscope.csv is refused (a folder was not
    an input file to protect). --mag on an export without a magnetometer file, --mag-columns that the magnetometer
    file lacks and a magnetometer file without a time column end in one line naming what to do."""
    t = np.arange(300) / 100.0
    xyz = np.tile([0.0, 0.0, 9.8], (300, 1))
    files = {"TotalAcceleration.csv": _sensor_logger(t, xyz), "Gyroscope.csv": _sensor_logger(t, xyz * 0)}
    _, folder = _export(tmp_path, "rec", files)
    gyro = (folder / "Gyroscope.csv").read_bytes()
    cases = [
        (["attitude", str(folder), "--out", str(folder / "Gyroscope.csv")], "would destroy the input"),
        (["attitude", str(folder), "--mag", "--out", str(tmp_path / "a.csv")],
         "Sensor Logger's export without a magnetometer file; record with the magnetometer switched on, or drop --mag"),
        (["attitude", str(folder), "--mag-file", str(folder / "Gyroscope.csv"), "--mag-columns", "p,q,r", "--out",
          str(tmp_path / "a.csv")], "no column named 'p' (found: time, seconds_elapsed, z, y, x); name the "
         "magnetometer's columns of that file with --mag-columns X,Y,Z"),
    ]  # fmt: skip
    (tmp_path / "m.csv").write_text("mx,my,mz\n" + "20,0,-40\n" * 10)
    cases.append(
        (
            ["attitude", str(folder), "--mag-file", str(tmp_path / "m.csv"), "--out", str(tmp_path / "a.csv")],
            "m.csv has no time column beside its magnetometer",
        )  # fmt: skip
    )
    for argv, msg in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and msg in err[0], err
    assert (folder / "Gyroscope.csv").read_bytes() == gyro


def test_batch_takes_phone_exports_as_units(tmp_path, capsys):
    """optinav batch listed a folder's data files by suffix: a phone export (its zip, or the folder it unzips to)
    was no unit ('holds no data files'). Each is one unit now, read as optinav attitude reads it: the 9D rows of
    the zip and the folder agree and count the accelerometer rows the gyroscope spans."""
    from optinav.batch import read_results

    f, mag, ia, ig, im = _phone_flight(duration_s=20.0)
    files = {
        "TotalAcceleration.csv": _sensor_logger(f.t[ia], f.acc[ia]),
        "Gyroscope.csv": _sensor_logger(f.t[ig], f.gyr[ig]),
        "Magnetometer.csv": _sensor_logger(f.t[im], mag[im]),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    d = tmp_path / "units"
    d.mkdir()
    _export(d, "walk", files)
    (d / "walk.zip").rename(d / "walk-shared.zip")
    out = tmp_path / "b.csv"
    assert main(["--quiet", "batch", "attitude", str(d), "--mag", "--workers", "0", "--out", str(out)]) == 0
    rows = {r["unit"]: r for r in read_results(out)}
    assert sorted(rows) == ["walk", "walk-shared"], rows
    spanned = int(np.count_nonzero((f.t[ia] >= f.t[ig[0]]) & (f.t[ia] <= f.t[ig[-1]])))
    for r in rows.values():
        assert r["status"] == "ok" and r["n_samples"] == spanned and r["mag"] is True, r
    assert [rows["walk"][f"gyr_bias_{a}"] for a in "xyz"] == [rows["walk-shared"][f"gyr_bias_{a}"] for a in "xyz"]


def test_batch_names_an_export_it_cannot_read_as_a_failed_unit(tmp_path, capsys):
    """A zip of two recordings' exports and a Sensor Logger folder without Gyroscope.csv beside a readable export
    were passed over without a word (only exports with the pair were units): a batch of four reported two. Each
    is a unit now, failed with the one-line error the single command gives."""
    from optinav.batch import read_results

    f, mag, ia, ig, im = _phone_flight(duration_s=20.0)
    files = {
        "TotalAcceleration.csv": _sensor_logger(f.t[ia], f.acc[ia]),
        "Gyroscope.csv": _sensor_logger(f.t[ig], f.gyr[ig]),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    d = tmp_path / "units"
    d.mkdir()
    _export(d, "walk", files)
    (d / "walk").rename(d / "walk-folder")
    _export(d, "two", {f"{r}/{k}": v for r in ("A", "B") for k, v in files.items()})
    _export(d, "nogyro", {k: v for k, v in files.items() if k != "Gyroscope.csv"})
    for x in ("two", "nogyro.zip"):
        (d / x).rename(tmp_path / x) if (d / x).is_dir() else (d / x).unlink()
    out = tmp_path / "b.csv"
    assert main(["--quiet", "batch", "attitude", str(d), "--workers", "0", "--out", str(out)]) == 1
    rows = {r["unit"]: r for r in read_results(out)}
    assert sorted(rows) == ["nogyro", "two", "walk", "walk-folder"], rows
    assert rows["walk"]["status"] == rows["walk-folder"]["status"] == "ok"
    assert rows["two"]["status"] == "failed" and "2 recordings' exports (A/, B/)" in rows["two"]["error"], rows
    assert rows["nogyro"]["status"] == "failed" and "without Gyroscope.csv" in rows["nogyro"]["error"], rows


def test_an_export_given_as_one_sensor_s_file_names_the_data_file(tmp_path, capsys):
    """A phone export given as --gyro or --mag-file (attitude, allan, read_imu, read_mag) was named as if only its
    extraction were missing: 'rec.zip is a zip archive, Sensor Logger's export; extract it and pass
    TotalAcceleration.csv ... with --gyro Gyroscope.csv' (for a folder: 'data file rec is a folder, ...'), and
    allan's --gyro read the whole export, judging its accelerometer ('the gravity direction moves'). Now: pass the
    export itself as the data file."""
    from optinav.io import read_mag

    s = simulate("18", dwell_s=6, rest_s=3, acc_unit="m/s^2", gyro_unit="rad/s", rng=4)
    files = {
        "TotalAcceleration.csv": _sensor_logger(s.t, s.acc),
        "Gyroscope.csv": _sensor_logger(s.t + 0.002, s.gyr),
        "Magnetometer.csv": _sensor_logger(s.t[::4], np.tile([20.0, 0.0, -40.0], (s.t[::4].size, 1))),
        "Metadata.csv": "version,device name\n1.30,Pixel 7\n",
    }
    z, folder = _export(tmp_path, "rec", files)
    acc = tmp_path / "acc.csv"
    np.savetxt(acc, np.column_stack([s.t, s.acc]), delimiter=",", header="t,ax,ay,az", comments="")
    for path in (z, folder):
        with pytest.raises(OptinavError, match=rf"--gyro {path.name} is Sensor Logger's export.*as the data file"):
            read_imu(acc, gyro_path=path)
        with pytest.raises(OptinavError, match=rf"--mag-file {path.name} is Sensor Logger's export.*--mag reads"):
            read_mag(path)
    still = tmp_path / "still.csv"
    rng = np.random.default_rng(0)
    t = np.arange(20000) / 100.0
    np.savetxt(still, np.column_stack([t, rng.normal(0, 0.02, (t.size, 2)), 9.81 + rng.normal(0, 0.02, t.size)]),
               delimiter=",", header="t,ax,ay,az", comments="")  # fmt: skip
    for cmd in (["allan", str(still), "--gyro", str(z), "--out", str(tmp_path / "a.json")],
                ["attitude", str(acc), "--gyro", str(z), "--out", str(tmp_path / "q.csv")],
                ["attitude", str(z), "--mag-file", str(folder), "--out", str(tmp_path / "q.csv")]):  # fmt: skip
        assert main(["--quiet", *cmd]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "is Sensor Logger's export, which holds the accelerometer" in err, err
