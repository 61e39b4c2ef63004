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
    simulated session's scales; nothing is written into the folder or beside the zip."""
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
    before = _listing(folder)
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
        out = tmp_path / f"r{path.suffix}.json"
        assert main(["calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
        r = Result.from_json(out)
        from optinav.multipos import model

        U, _ = model.upper_triangular_form(s.acc_K)
        np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(U), atol=4 * np.max(r.accelerometer["K_std"]))
    assert "Sensor Logger's export" in capsys.readouterr().err
    assert _listing(folder) == before  # nothing written into the input folder or beside the zip


def test_a_phyphox_export_is_read_and_allan_takes_each_sensor_on_its_clock(tmp_path, capsys):
    """phyphox's CSV export of its simple experiment (Accelerometer.csv with g, Gyroscope.csv, Magnetometer.csv on
    their own times, meta/device.csv, meta/time.csv) as a zip or a folder: read as the accelerometer with the
    gyroscope interpolated onto its times; allan analyses each sensor on its own clock (interpolating white noise
    onto other times low-passes it): the white noise N within 5 % of the simulated std × √dt."""
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
