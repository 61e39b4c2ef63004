"""`optinav attitude` end to end on a simulated flight written to CSV (with polarization columns)."""

import numpy as np
import pytest

from optinav.attitude.metrics import euler_errors
from optinav.cli.main import main
from optinav.core.rotations import quat_angle_between


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    from optinav.attitude.simulate import PAPER_SITE, PAPER_TIMES, simulate

    d = simulate("dynamic", duration_s=40, rate_hz=100, rng=4, gyro_bias=np.radians([0.3, -0.2, 0.25]))
    folder = tmp_path_factory.mktemp("att")
    path = folder / "flight.csv"
    cols = np.column_stack([d.t, d.acc, np.degrees(d.gyr), np.degrees(d.aop), d.dop])
    np.savetxt(path, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz,aop_deg,dop", comments="", fmt="%.10g")
    return d, folder, path, PAPER_SITE, PAPER_TIMES


def _level_at_rest(n: int, seed: int, field) -> tuple:
    """(t s, acc m/s², gyr rad/s, mag) of a level IMU at rest for n samples at 100 Hz, seeded, in the field ``field``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.02, (n, 3))
    gyr = rng.normal(0, 0.002, (n, 3))
    mag = np.tile(field, (n, 1)) + rng.normal(0, 0.2, (n, 3))
    return t, acc, gyr, mag


def _read(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return data


def test_cli_attitude_with_polarization(flight, capsys):
    d, folder, path, site, times = flight
    out, rep = folder / "att.csv", folder / "rep"
    assert (
        main(
            [
                "--quiet",
                "attitude",
                str(path),
                "--gyro-unit",
                "deg/s",
                "--method",
                "mekf",
                "--pol-columns",
                "aop_deg,dop",
                "--aop-unit",
                "deg",
                "--lat",
                str(np.degrees(site["lat"])),
                "--lon",
                str(np.degrees(site["lon"])),
                "--height",
                "35",
                "--start-time",
                times["dynamic"],
                "--option",
                "acc_noise_density=0.04",
                "--q0-deg",
                ",".join(str(v) for v in np.degrees(d.euler[0])),
                "--out",
                str(out),
                "--report",
                str(rep),
            ]
        )
        == 0
    )
    r = _read(out)
    assert r.dtype.names == ("t", "qw", "qx", "qy", "qz", "roll_deg", "pitch_deg", "yaw_deg")
    q = np.column_stack([r["qw"], r["qx"], r["qy"], r["qz"]])
    err = np.degrees(quat_angle_between(q, d.q_b_n))
    assert np.sqrt(np.mean(err[500:] ** 2)) < 3.0
    # the Euler columns are the quaternion's, in degrees
    e = np.degrees(euler_errors(q, d.q_b_n))
    assert np.allclose(
        np.degrees(d.euler[:, :2]) + e[:, :2], np.column_stack([r["roll_deg"], r["pitch_deg"]]), atol=1e-5
    )
    assert (rep / "index.md").is_file()
    assert "polarization used" in (rep / "index.md").read_text()


def test_cli_attitude_gyro_acc_only(flight):
    d, folder, path, *_ = flight
    out = folder / "att6.csv"
    assert main(["--quiet", "attitude", str(path), "--gyro-unit", "deg/s", "--method", "qn", "--out", str(out)]) == 0
    r = _read(out)
    assert r.shape == (len(d),)
    tilt = np.degrees(euler_errors(np.column_stack([r["qw"], r["qx"], r["qy"], r["qz"]]), d.q_b_n))[:, :2]
    assert np.sqrt(np.mean(tilt[500:] ** 2)) < 5.0


@pytest.mark.parametrize(
    "extra, msg",
    [
        (["--option", "gain"], "KEY=VALUE"),
        (["--option", "bogus=1"], "does not apply"),
        (["--lat", "38"], "without --pol-columns"),
        (["--pol-columns", "aop_deg", "--aop-unit", "deg"], "needs the sun"),
        (["--pol-columns", "aop_deg", "--sun-azimuth", "10", "--sun-elevation", "20"], "--aop-unit deg"),
        (["--pol-columns", "nope", "--sun-azimuth", "10", "--sun-elevation", "20"], "no column"),
        (["--q0-deg", "1,2"], "ROLL,PITCH,YAW"),
    ],
)
def test_cli_attitude_errors(flight, capsys, extra, msg):
    _, folder, path, *_ = flight
    assert main(["attitude", str(path), "--gyro-unit", "deg/s", "--out", str(folder / "x.csv")] + extra) == 2
    err = capsys.readouterr().err
    assert err.startswith("optinav: error:") and msg in err and err.count("\n") == 1


def test_cli_simulate_flight_then_attitude(tmp_path, capsys):
    """`optinav simulate flight` writes what `optinav attitude` reads; the heading follows the truth."""
    data, out = tmp_path / "flight.csv", tmp_path / "att.csv"
    assert main(["simulate", "flight", "--kind", "dynamic", "--duration", "20", "--seed", "3", "--out", str(data)]) == 0
    msg = capsys.readouterr().err
    e0 = msg.rsplit(":", 1)[1].strip()
    truth = np.loadtxt(tmp_path / "flight.truth.csv", delimiter=",", skiprows=1)
    # the truth file (written block by block) holds the same attitude as the CSV beside it; no scratch file is left
    from optinav.core.results import Truth

    tj = Truth.from_json(tmp_path / "flight.truth.json")
    assert tj.info["seed"] == 3 and tj.info["frame"] == "ned" and tj.parameters["yaw"].unit == "rad"
    np.testing.assert_allclose(tj.parameters["q_b_n"].value, truth[:, 1:], rtol=0, atol=1e-12)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["flight.csv", "flight.truth.csv", "flight.truth.json"]
    assert (
        main(
            [
                "--quiet",
                "attitude",
                str(data),
                "--method",
                "mekf",
                "--pol-columns",
                "aop_deg,dop",
                "--aop-unit",
                "deg",
                "--lat",
                "38.8814192",
                "--lon",
                "121.528255",
                "--start-time",
                "2021-01-16T16:33:00+08:00",
                "--q0-deg",
                e0.replace(" ", ""),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    r = _read(out)
    q = np.column_stack([r["qw"], r["qx"], r["qy"], r["qz"]])
    yaw = np.degrees(euler_errors(q, truth[:, 1:]))[:, 2]
    assert np.sqrt(np.mean(yaw**2)) < 2.0
    assert main(["simulate", "flight", "--out", str(tmp_path / "f.npz")]) == 2


def test_a_simulated_truth_on_other_times_is_refused(tmp_path, capsys):
    """STEM.truth.csv was read row for row and its t column ignored: a truth that starts 0.5 s later scored the
    attitude against the wrong samples with exit 0 (a helper's finding). Its times must match the log's."""
    data = tmp_path / "flight.csv"
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "10", "--out", str(data)]) == 0
    args = ["--quiet", "attitude", str(data), "--reference", "--out", str(tmp_path / "a.csv")]
    assert main(args) == 0
    truth = tmp_path / "flight.truth.csv"
    lines = truth.read_text().splitlines()
    shifted = [lines[0]] + [",".join([repr(float(r.split(",")[0]) + 0.5), *r.split(",")[1:]]) for r in lines[1:]]
    truth.write_text("\n".join(shifted) + "\n")
    capsys.readouterr()
    assert main(args[1:]) == 2
    err = capsys.readouterr().err
    assert "flight.truth.csv does not hold t,qw,qx,qy,qz for each log sample (row 1: t = 0.5 s, the log's" in err, err


def test_cli_aop_in_radians_declared_degrees_is_named(flight, tmp_path, capsys):
    """An AoP column in rad passed with --aop-unit deg ran to exit 0 with roll/pitch/yaw errors of 37/31/84°
    (only degrees declared rad were checked). Its values never leave ±π/2 "degrees"."""
    d, folder, path, site, times = flight
    data = np.genfromtxt(path, delimiter=",", names=True)
    rad = tmp_path / "aop_rad.csv"
    cols = [data[c] for c in ("t", "ax", "ay", "az", "gx", "gy", "gz")] + [np.radians(data["aop_deg"]), data["dop"]]
    np.savetxt(rad, np.column_stack(cols), delimiter=",", header="t,ax,ay,az,gx,gy,gz,aop,dop", comments="")
    args = ["attitude", str(rad), "--gyro-unit", "deg/s", "--method", "mekf", "--pol-columns", "aop,dop"]
    args += ["--lat", str(np.degrees(site["lat"])), "--lon", str(np.degrees(site["lon"]))]
    args += ["--start-time", times["dynamic"], "--out", str(tmp_path / "a.csv")]
    assert main([*args, "--aop-unit", "deg"]) == 2
    err = capsys.readouterr().err
    assert "radians declared deg" in err and "--aop-unit rad" in err and err.count("\n") == 1
    assert main(["--quiet", *args, "--aop-unit", "rad"]) == 0


def test_check_aop_both_ways():
    from optinav.attitude.checks import check_aop
    from optinav.errors import OptinavError

    x = np.linspace(-1.5, 1.5, 200)
    check_aop(x, "rad")
    with pytest.raises(OptinavError, match="radians declared deg"):
        check_aop(x, "deg")
    check_aop(np.degrees(x), "deg")
    check_aop(np.full(200, 1.2), "deg")  # a still sensor's AoP of 1.2° spans nothing: not judged
    with pytest.raises(OptinavError, match="degrees declared rad"):
        check_aop(np.degrees(x) * 10, "rad")
    with pytest.raises(OptinavError, match="reaches 9999, beyond ±360°: a fill value"):
        check_aop(np.r_[np.degrees(x), 9999.0], "deg")


def test_polarization_in_the_wrong_unit_is_refused_in_python_and_streamed(flight, tmp_path, capsys):
    """An AoP in degrees given to PolarizationMeasurement (a streaming filter's pol=) ran 75-113° off with exit 0;
    a DoP in percent skipped no sample for a low DoP; a fill value of 9999° in a degree column every 7th sample
    was taken as an angle (2-5° off). Refused naming the unit, the fill value."""
    from optinav.attitude import PolarizationMeasurement
    from optinav.errors import OptinavError

    d, folder, path, site, times = flight
    with pytest.raises(OptinavError, match=r"aop reaches 9\d(\.\d*)?, beyond 2π: it is in radians"):
        PolarizationMeasurement(np.degrees(d.aop), d.sun_n, frame="ned")
    with pytest.raises(OptinavError, match="degree of polarization reaches .*it looks like percent"):
        PolarizationMeasurement(d.aop, d.sun_n, dop=100 * d.dop, frame="ned")
    data = np.genfromtxt(path, delimiter=",", names=True)
    for name, aop, dop, words in (
        ("fill", np.where(np.arange(data.size) % 7, data["aop_deg"], 9999.0), data["dop"], "a fill value"),
        ("pct", data["aop_deg"], 100 * data["dop"], "it looks like percent"),
    ):
        f = tmp_path / f"{name}.csv"
        cols = [data[c] for c in ("t", "ax", "ay", "az", "gx", "gy", "gz")] + [aop, dop]
        np.savetxt(f, np.column_stack(cols), delimiter=",", header="t,ax,ay,az,gx,gy,gz,aop_deg,dop", comments="")
        argv = ["attitude", str(f), "--gyro-unit", "deg/s", "--pol-columns", "aop_deg,dop", "--aop-unit", "deg"]
        argv += ["--lat", str(np.degrees(site["lat"])), "--lon", str(np.degrees(site["lon"]))]
        assert main([*argv, "--start-time", times["dynamic"], "--out", str(tmp_path / "a.csv")]) == 2
        err = capsys.readouterr().err
        assert words in err and err.count("\n") == 1, err


def test_magnetometer_columns_with_units_in_brackets(tmp_path, capsys):
    """A header ``mx [G]`` (the field's unit in brackets, as ``acc_x [g]`` is read) was not found by --mag and the
    error asked for "--mag-columns X,Y,Z"; ``mag_x [uT]`` was suggested with its brackets, for the shell to quote.
    Magnetometer names are matched as the other columns are (a unit in brackets, case, spaces), the
    estimate equal to the same file's without units (Xsens' ``Mag_X [uT]``: by the magnetometer's usual names)."""
    import numpy as np

    from optinav.cli.main import main

    t, acc, gyr, mag = _level_at_rest(3000, 0, [20.0, 0.0, -40.0])
    out = {}
    for name, head in (
        ("plain", "mx,my,mz"),
        ("gauss", "mx [G],my [G],mz [G]"),
        ("xsens", "Mag_X [uT],Mag_Y [uT],Mag_Z [uT]"),
    ):
        f = tmp_path / f"{name}.csv"
        np.savetxt(
            f, np.column_stack([t, acc, gyr, mag]), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz," + head
        )
        out[name] = tmp_path / f"{name}.out.csv"
        argv = ["--quiet", "attitude", str(f), "--frame", "ENU", "--out", str(out[name])]
        code = main(argv + ["--mag"])
        assert code == 0, capsys.readouterr().err
    assert out["gauss"].read_text() == out["plain"].read_text() == out["xsens"].read_text()


@pytest.mark.parametrize(
    "head",
    ["Mag X (uT),Mag Y (uT),Mag Z (uT)", "magnetometer_x,magnetometer_y,magnetometer_z", "MagneticFieldX,"
     "MagneticFieldY,MagneticFieldZ", "imu_mag_x,imu_mag_y,imu_mag_z", "m_x,m_y,m_z"],
)  # fmt: skip
def test_magnetometer_found_by_its_usual_names(tmp_path, capsys, head):
    """--mag looked for columns mx, my, mz only: a logger's ``Mag X (uT)`` (the accelerometer's ``Accel X (g)`` beside
    it was read by its name) needed --mag-columns. The magnetometer's usual names are found (one triad; named in a
    note); the estimate equals the same file's under mx, my, mz, streamed and in memory."""
    import numpy as np

    from optinav.attitude.unit import AttitudeOptions, read_log
    from optinav.cli.main import main

    t, acc, gyr, mag = _level_at_rest(3000, 0, [20.0, 0.0, -40.0])
    outs = []
    for h in ("mx,my,mz", head):
        f = tmp_path / "log.csv"
        np.savetxt(
            f, np.column_stack([t, acc, gyr, mag]), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz," + h
        )
        outs.append(tmp_path / f"o{len(outs)}.csv")
        assert main(["attitude", str(f), "--mag", "--frame", "ENU", "--out", str(outs[-1])]) == 0
        err = capsys.readouterr().err
        assert ("note: magnetometer: columns" in err) == (h != "mx,my,mz"), err
        assert np.array_equal(read_log(f, AttitudeOptions(mag=True))[3], mag)
    assert outs[0].read_text() == outs[1].read_text()


def test_two_magnetometer_triads_are_for_mag_columns_to_choose(tmp_path, capsys):
    """A calibrated and a raw magnetometer in one file: --mag takes neither by itself."""
    import numpy as np

    from optinav.cli.main import main

    t, acc, gyr, mag = _level_at_rest(3000, 0, [20.0, 0.0, -40.0])
    f = tmp_path / "log.csv"
    head = "t,ax,ay,az,gx,gy,gz,mag_x,mag_y,mag_z,magnetometer_x,magnetometer_y,magnetometer_z"
    np.savetxt(f, np.column_stack([t, acc, gyr, mag, 2 * mag]), delimiter=",", comments="", header=head)
    argv = ["--quiet", "attitude", str(f), "--frame", "ENU", "--out", str(tmp_path / "o.csv")]
    assert main(argv + ["--mag"]) == 2
    assert "--mag-columns" in capsys.readouterr().err
    assert main(argv + ["--mag-columns", "magnetometer_x,magnetometer_y,magnetometer_z"]) == 0


def test_magnetometer_and_single_sensor_files_name_the_flag_that_helps(tmp_path, capsys):
    """--mag on an Xsens export (Mag_X, ...) or Physics Toolbox (Bx, ...) listed the file's columns without naming
    --mag-columns; a phone app's accelerometer-only file was told to use --columns, which cannot add a gyro.
    """
    import numpy as np

    from optinav.cli.main import main

    n = 3000
    t = np.arange(n) * 0.01
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    gyr = np.zeros((n, 3))
    mag = np.tile([20.0, 0.0, -40.0], (n, 1))
    for head, want in (("Bx,By,Bz", "--mag-columns Bx,By,Bz"),):  # Xsens' Mag_X, ...: read (test above)
        f = tmp_path / "x.csv"
        np.savetxt(
            f, np.column_stack([t, acc, gyr, mag]), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz," + head
        )
        argv = ["--quiet", "attitude", str(f), "--mag", "--frame", "ENU", "--out", str(tmp_path / "o.csv")]
        assert main(argv) == 2
        assert want in capsys.readouterr().err
    f = tmp_path / "Accelerometer.csv"
    np.savetxt(f, np.column_stack([t, acc]), delimiter=",", comments="", header="t,ax,ay,az")
    assert main(["--quiet", "attitude", str(f), "--frame", "ENU", "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "has only the accelerometer" in err and "--gyro GYRODATA" in err


def test_attitude_from_a_phone_apps_two_files_on_their_own_clocks(tmp_path, capsys):
    """A phone app writes Accelerometer.csv and Gyroscope.csv, each on its own time stamps: attitude had no way to
    take the second file ("merge the sensors' files on one time column first"). --gyro interpolates the gyro onto
    the accelerometer's times: BROAD trial 02 split so (the gyro 0.4 of a sample later) gives the one-file attitude
    within 0.01° RMS of inclination (0.05° after the start-up), streamed and in memory (--report) alike."""
    import os
    from pathlib import Path

    from optinav.attitude.data import load_broad
    from optinav.attitude.metrics import inclination_error

    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    p = shared / "attitude" / "broad" / "02_undisturbed_slow_rotation_B.hdf5"
    if not p.is_file():
        pytest.skip("BROAD data absent")
    tr = load_broad(p)
    t = np.arange(tr.gyr.shape[0]) / tr.rate_hz
    tg = t[:-1] + 0.4 / tr.rate_hz
    g_at = np.column_stack([np.interp(tg, t, tr.gyr[:, j]) for j in range(3)])
    one, fa, fg = tmp_path / "one.csv", tmp_path / "Accelerometer.csv", tmp_path / "Gyroscope.csv"
    np.savetxt(one, np.column_stack([t, tr.acc, tr.gyr]), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz")
    np.savetxt(fa, np.column_stack([t, tr.acc]), delimiter=",", comments="", header="t,ax,ay,az")
    np.savetxt(fg, np.column_stack([tg, g_at]), delimiter=",", comments="", header="t,gx,gy,gz")
    base = ["--quiet", "attitude", "--frame", "ENU"]
    assert main([*base, str(one), "--out", str(tmp_path / "one_att.csv")]) == 0
    ref = np.genfromtxt(tmp_path / "one_att.csv", delimiter=",", names=True)
    for extra in ([], ["--report", str(tmp_path / "rep")]):
        capsys.readouterr()
        out = tmp_path / f"two_att{len(extra)}.csv"
        assert main([*base, str(fa), "--gyro", str(fg), "--out", str(out), *extra]) == 0
        assert "interpolated onto the time stamps of Accelerometer.csv" in capsys.readouterr().err
        two = np.genfromtxt(out, delimiter=",", names=True)
        k = np.searchsorted(ref["t"], two["t"])
        qa = np.column_stack([ref[c][k] for c in ("qw", "qx", "qy", "qz")])
        qb = np.column_stack([two[c] for c in ("qw", "qx", "qy", "qz")])
        err = np.degrees(inclination_error(qb, qa))
        # the first accelerometer row is left out (before the gyro's first time): the start-up differs a little
        assert np.sqrt(np.mean(err**2)) < 0.01 and np.max(err[int(2 * tr.rate_hz) :]) < 0.05, (
            np.sqrt(np.mean(err**2)),
            np.max(err[int(2 * tr.rate_hz) :]),
        )


def test_nan_rows_left_out_as_lost_samples(flight, tmp_path, capsys):
    """A logger that writes NaN for a lost sample (rows 500-502 gyro, 1500 acc, the last row): refused with no
    flag to take them as lost. With --drop-nan the rows are left out and the time steps over them: the output
    equals the run on the file without those rows, also with the rate in place of a time column (the rows keep
    their times)."""
    from optinav.attitude.unit import AttitudeOptions, read_log

    d, *_ = flight
    cols = np.column_stack([d.t, d.acc, np.degrees(d.gyr)])
    lost = np.array([500, 501, 502, 1500, cols.shape[0] - 1])
    bad = cols.copy()
    bad[lost[:3], 5] = np.nan
    bad[lost[3:], 1] = np.nan
    kept = np.delete(cols, lost, axis=0)
    head = "t,ax,ay,az,gx,gy,gz"
    for name, arr in (("bad", bad), ("kept", kept)):
        np.savetxt(tmp_path / f"{name}.csv", arr, delimiter=",", header=head, comments="", fmt="%.10g")
    np.savetxt(tmp_path / "bad_rate.csv", bad[:, 1:], delimiter=",", header=head[2:], comments="", fmt="%.10g")
    assert main(["--quiet", "attitude", str(tmp_path / "bad.csv"), "--gyro-unit", "deg/s", "--out", "x.csv"]) == 2
    err = capsys.readouterr().err
    assert "has 5 rows with NaN" in err and "--drop-nan" in err
    outs = {}
    for name, extra in (("kept", []), ("bad", ["--drop-nan"]), ("bad_rate", ["--drop-nan", "--rate", "100"])):
        out = tmp_path / f"{name}.out.csv"
        args = ["attitude", str(tmp_path / f"{name}.csv"), "--gyro-unit", "deg/s", "--out", str(out)] + extra
        assert main(args) == 0
        outs[name] = np.loadtxt(out, delimiter=",", skiprows=1)
    assert "5 rows with NaN accelerometer/gyro values left out (--drop-nan)" in capsys.readouterr().err
    np.testing.assert_array_equal(outs["bad"], outs["kept"])
    np.testing.assert_allclose(outs["bad_rate"], outs["kept"], rtol=0, atol=1e-9)
    assert np.isclose(outs["bad"][500, 0] - outs["bad"][499, 0], 0.04)  # the step over three lost samples
    with pytest.warns(UserWarning, match="5 rows with NaN"):
        t, gyr, acc, _, _ = read_log(tmp_path / "bad.csv", AttitudeOptions(gyro_unit="deg/s", drop_nan=True))
    on_file = np.loadtxt(tmp_path / "kept.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(np.column_stack([t, acc, np.degrees(gyr)]), on_file, rtol=1e-14, atol=0)


def test_magnetometer_columns_take_a_sign(tmp_path, capsys):
    """A magnetometer mounted with an axis flipped (the frame's MIRROR remedy: negate one axis of every sensor)
    could not be mapped: --mag-columns took names only, and the flipped field turned the heading with exit 0. A
    '-' before a name now reads it negated: the estimate equals the same log's with the axis as it should be,
    streamed and read whole (the reader behind the report)."""
    from optinav.attitude.unit import AttitudeOptions, read_log
    from optinav.cli.main import main

    t, acc, gyr, mag = _level_at_rest(1500, 3, [12.0, 15.0, -40.0])
    files = {}
    for name, m in (("right", mag), ("flipped", mag * [1, -1, 1])):
        files[name] = tmp_path / f"{name}.csv"
        np.savetxt(files[name], np.column_stack([t, acc, gyr, m]), delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz")
    out = {}
    for name, path, cols in (("right", files["right"], "mx,my,mz"), ("as logged", files["flipped"], "mx,my,mz"),
                             ("signed", files["flipped"], "mx,-my,mz")):  # fmt: skip
        out[name] = tmp_path / f"{name}.out.csv"
        argv = ["--quiet", "attitude", str(path), "--frame", "ENU", "--mag-columns", cols, "--out", str(out[name])]
        assert main(argv) == 0, capsys.readouterr().err
    yaw = {k: np.genfromtxt(v, delimiter=",", names=True)["yaw_deg"] for k, v in out.items()}
    np.testing.assert_array_equal(yaw["signed"], yaw["right"])
    assert abs(yaw["as logged"][-1] - yaw["right"][-1]) > 40.0  # 2 atan(15/12) of heading, with exit 0
    whole = read_log(files["flipped"], AttitudeOptions(mag_columns="mx,-my,mz"))[3]
    np.testing.assert_array_equal(whole, read_log(files["right"], AttitudeOptions(mag=True))[3])


def test_cli_declination_gives_the_true_heading(flight, tmp_path, capsys):
    """``--declination-deg 12`` (east positive) on a simulated flight in a field 12° east of true north, scored
    against its truth CSV with --reference: heading RMSE 12.4° without it, 0.5° with it online (offline 12.4° and
    0.4°), each the in-memory estimate with ``declination`` to the CSV's digits; the summary and the report say so,
    and ``batch attitude --declination-deg`` scores alike. Without --mag it is refused in one line."""
    import csv

    from optinav.attitude import estimate
    from optinav.core.rotations import quat_conjugate, quat_rotate

    d = flight[0]
    dip, dec = np.radians(60.0), np.radians(12.0)
    field = 50.0 * np.array([np.cos(dip) * np.cos(dec), np.cos(dip) * np.sin(dec), np.sin(dip)])  # NED, 12° east
    mag = quat_rotate(quat_conjugate(d.q_b_n), np.broadcast_to(field, (len(d), 3)))
    mag = mag + np.random.default_rng(0).normal(0.0, 0.3, mag.shape)
    units = tmp_path / "units"
    units.mkdir()
    path = units / "f.csv"
    cols = np.column_stack([d.t, d.acc, d.gyr, mag])
    np.savetxt(path, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="", fmt="%.17g")
    np.savetxt(units / "f.truth.csv", np.column_stack([d.t, d.q_b_n]), delimiter=",", header="t,qw,qx,qy,qz",
               comments="", fmt="%.17g")  # fmt: skip
    dt = np.r_[d.t[1] - d.t[0], np.diff(d.t)]
    heading = {}
    for extra in ([], ["--offline"]):
        for flag in ([], ["--declination-deg", "12"]):
            out = tmp_path / "a.csv"
            argv = ["attitude", str(path), "--mag", "--reference", *extra, *flag, "--out", str(out)]
            assert main(argv + ["--report", str(tmp_path / "rep")] * bool(flag)) == 0
            text = capsys.readouterr().out
            heading[bool(extra), bool(flag)] = float(text.split("heading RMSE ")[1].split(" deg")[0])
            r = _read(out)
            q = np.column_stack([r["qw"], r["qx"], r["qy"], r["qz"]])
            want = estimate(d.gyr, d.acc, dt, mag=mag, offline=bool(extra), declination=dec if flag else 0.0)
            assert np.max(np.abs(q - want.q_b_n)) < 1e-6
            assert ("true heading (magnetic declination 12.00° E)" in text) == bool(flag) and want.summary() in text
        report = (tmp_path / "rep" / "index.md").read_text()
        assert "| magnetic declination, east positive [deg] | 12.00 |" in report
    for offline in (False, True):
        assert abs(heading[offline, False] - 12.0) < 1.0 and heading[offline, True] < 1.0, heading
    res = tmp_path / "res.csv"
    argv = ["--quiet", "batch", "attitude", str(units), "--mag", "--reference", "--workers", "0", "--out", str(res)]
    assert main([*argv, "--declination-deg", "12"]) == 0
    (row,) = list(csv.DictReader(res.open()))
    assert float(row["heading_rmse_deg"]) == pytest.approx(heading[False, True], abs=1e-3)
    assert float(row["declination_deg"]) == pytest.approx(12.0)
    assert main(["attitude", str(path), "--declination-deg", "12", "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "declination was given without a magnetometer" in err and err.count("\n") == 1


@pytest.mark.parametrize("late", [0.2, -0.1])
def test_a_gyro_file_on_another_clock_than_the_accelerometers_is_named(tmp_path, capsys, late):
    """BROAD trial 02 split into an accelerometer and a gyroscope file, the gyro's time stamps 0.1 s late: 9.1°
    inclination RMSE with exit 0 (0.2 s: 17°; a fast trial 33° and 50°), and 0.1 s late on trial 29 was named
    "gyro axes swapped". The lag is read off how gravity turns in the body as the gyro says when moved in time:
    refused from 0.08 s where that explains a quarter of what is left unexplained as stamped, streamed and in
    memory (--report) alike; on time, nothing is said."""
    import os
    from pathlib import Path

    from optinav.attitude.data import load_broad

    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    p = shared / "attitude" / "broad" / "02_undisturbed_slow_rotation_B.hdf5"
    if not p.is_file():
        pytest.skip("BROAD data absent")
    tr = load_broad(p)
    n = 15000  # its first 52 s
    t = np.arange(n) / tr.rate_hz
    fa, fg = tmp_path / "Accelerometer.csv", tmp_path / "Gyroscope.csv"
    np.savetxt(fa, np.column_stack([t, tr.acc[:n]]), delimiter=",", comments="", header="t,ax,ay,az")
    base = ["--quiet", "attitude", "--frame", "ENU", str(fa), "--gyro", str(fg)]
    word = "late" if late > 0 else "early"
    for shift, refused in ((late, True), (0.0, False)):
        np.savetxt(fg, np.column_stack([t + shift, tr.gyr[:n]]), delimiter=",", comments="", header="t,gx,gy,gz")
        for extra in ([], ["--report", str(tmp_path / "rep")]):
            capsys.readouterr()
            rc = main([*base, "--out", str(tmp_path / f"a{len(extra)}{refused}.csv"), *extra])
            err = capsys.readouterr().err
            assert rc == (2 if refused else 0), err
            said = f"the gyroscope's time stamps are about {abs(late):.2g} s {word} against the accelerometer's"
            assert (said in err and "its t " in err) == refused, err


def test_the_report_of_an_estimate_takes_its_log_as_estimated(tmp_path, capsys):
    """`report R.json --data OTHER` of an attitude estimate checked the sample count only: BROAD 03 cut to trial
    02's length was reported as "Attitude of t03.csv" with 02's angles, exit 0; now refused (the estimate does not
    turn as that log's gyro does). An estimate of a log in two files could not be reported at all: the reader's
    message named --columns and --gyro, which report did not have; now it takes them."""
    import os
    from pathlib import Path

    from optinav.attitude import estimate
    from optinav.attitude.data import load_broad

    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    broad = shared / "attitude" / "broad"
    if not (broad / "03_undisturbed_slow_rotation_C.hdf5").is_file():
        pytest.skip("BROAD data absent")
    a, b = (
        load_broad(broad / "02_undisturbed_slow_rotation_B.hdf5"),
        load_broad(broad / "03_undisturbed_slow_rotation_C.hdf5"),
    )
    n = 15000  # the first 52 s of each
    t = np.arange(n) / a.rate_hz
    res = estimate(a.gyr[:n], a.acc[:n], 1 / a.rate_hz, frame="ENU")
    res.to_json(tmp_path / "r.json")
    fa, fg, other = tmp_path / "acc.csv", tmp_path / "gyr.csv", tmp_path / "t03.csv"
    np.savetxt(fa, np.column_stack([t, a.acc[:n]]), delimiter=",", comments="", header="t,ax,ay,az")
    np.savetxt(fg, np.column_stack([t, a.gyr[:n]]), delimiter=",", comments="", header="t,gx,gy,gz")
    np.savetxt(
        other, np.column_stack([t, b.acc[:n], b.gyr[:n]]), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz"
    )
    base = ["--quiet", "report", str(tmp_path / "r.json")]
    assert main([*base, "--data", str(other), "--out", str(tmp_path / "bad")]) == 2
    assert "does not turn as the gyro of" in capsys.readouterr().err
    assert main([*base, "--data", str(fa), "--gyro", str(fg), "--out", str(tmp_path / "ok")]) == 0
    assert "Attitude of acc.csv" in (tmp_path / "ok" / "index.md").read_text()


def test_polarization_none_of_which_can_be_used_is_refused(flight, capsys):
    """A start time in UTC where the flight's zone was +08:00 (or a longitude's sign flipped, or a night) put the
    sun below the horizon for the whole log: polarization used 0, skipped all, the heading the start's (110° off),
    exit 0. Refused naming why, streamed and in memory (--report), and by estimate()."""
    from optinav.attitude import PolarizationMeasurement, estimate

    d, folder, path, site, times = flight
    utc = times["dynamic"][:19] + "Z"  # the local time read as UTC: 8 h earlier, at night there
    argv = ["--quiet", "attitude", str(path), "--gyro-unit", "deg/s", "--pol-columns", "aop_deg,dop", "--aop-unit"]
    argv += ["deg", "--lat", str(np.degrees(site["lat"])), "--lon", str(np.degrees(site["lon"]))]
    for extra in ([], ["--report", str(folder / "night_rep")]):
        capsys.readouterr()
        assert main([*argv, "--start-time", utc, "--out", str(folder / "night.csv"), *extra]) == 2
        err = capsys.readouterr().err
        assert "none of the 4001 polarization samples can be used (sun below horizon 4001)" in err, err
        assert "--start-time (its time zone)" in err and not (folder / "night.csv").exists()
    below = -np.asarray(d.sun_n)  # the sun's direction mirrored: below the horizon
    with pytest.raises(Exception, match="none of the 4001 polarization samples can be used"):
        estimate(d.gyr, d.acc, d.dt, pol=PolarizationMeasurement(d.aop, below, frame="ned"))


def test_a_q0_the_aop_contradicts_is_refused_streamed(flight, tmp_path, capsys):
    """--q0-deg with its yaw 180° off ran 179° off, 90° off (or the AoP's reference axis 90° off) 90° off, with exit
    0: streamed (in blocks, online and offline) the runs from q0 and from q0 turned 180° refuse both, no output
    written; the true start passes."""
    from optinav.core.rotations import euler_from_quat

    d, folder, path, site, times = flight
    roll, pitch, yaw = np.degrees(euler_from_quat(d.q_b_n[0], "ned"))
    argv = ["--quiet", "attitude", str(path), "--gyro-unit", "deg/s", "--pol-columns", "aop_deg,dop", "--aop-unit"]
    argv += ["deg", "--lat", str(np.degrees(site["lat"])), "--lon", str(np.degrees(site["lon"])), "--height", "35"]
    argv += ["--start-time", times["dynamic"], "--chunk-rows", "700"]
    for extra in ([], ["--offline"], ["--method", "iframe"]):
        out = tmp_path / "a.csv"
        assert main([*argv, *extra, f"--q0-deg={roll},{pitch},{yaw}", "--out", str(out)]) == 0
        out.unlink()
        for off, words in ((180.0, "is 180° from the one the AoP shows"), (90.0, "turns the heading")):
            capsys.readouterr()
            assert main([*argv, *extra, f"--q0-deg={roll},{pitch},{yaw + off}", "--out", str(out)]) == 2
            err = capsys.readouterr().err
            assert words in err and "--q0-deg" in err and err.count("\n") == 1 and not out.exists(), (extra, err)


def test_an_aop_that_fits_neither_heading_branch_is_named(flight, tmp_path, capsys):
    """The AoP with its sign mirrored left 28.5° of robust residual on both heading branches and was refused as
    "ambiguous by 180°: pass --q0-deg", which then ran at 69-108° heading RMSE with exit 0. The refusal now says the
    AoP fits neither branch and names the convention, mounting and columns."""
    d, folder, path, site, times = flight
    data = np.genfromtxt(path, delimiter=",", names=True)
    neg = tmp_path / "neg.csv"
    cols = [data[c] for c in ("t", "ax", "ay", "az", "gx", "gy", "gz")] + [-data["aop_deg"], data["dop"]]
    np.savetxt(neg, np.column_stack(cols), delimiter=",", header="t,ax,ay,az,gx,gy,gz,aop_deg,dop", comments="")
    argv = ["--quiet", "attitude", str(neg), "--gyro-unit", "deg/s", "--pol-columns", "aop_deg,dop", "--aop-unit"]
    argv += ["deg", "--lat", str(np.degrees(site["lat"])), "--lon", str(np.degrees(site["lon"])), "--height", "35"]
    assert main([*argv, "--start-time", times["dynamic"], "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err
    assert "fits the sky's polarization pattern on neither heading branch" in err and "--pol-columns" in err, err
