"""PX4 ULog (.ulg) files as input: logs written here from the ULog specification (PX4 "ULog File Format":
header, flag bits, formats, subscriptions, data), checked against pyulog's own parser, then read by optinav as
sensor_combined, vehicle_imu increments, a raw sensor_accel/sensor_gyro pair and a magnetometer topic; every
refusal is a one-line error."""

import os
import struct
import sys

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import read_imu
from optinav.io.readers import load_table

#: numpy types of the ULog field types written here (little endian, packed: pyulog reads without alignment)
_NP = {"uint64_t": "<u8", "int32_t": "<i4", "uint32_t": "<u4", "uint8_t": "u1", "float": "<f4"}
COMBINED = [
    ("uint64_t", "timestamp"),
    ("float[3]", "gyro_rad"),
    ("uint32_t", "gyro_integral_dt"),
    ("int32_t", "accelerometer_timestamp_relative"),
    ("float[3]", "accelerometer_m_s2"),
    ("uint32_t", "accelerometer_integral_dt"),
    ("uint8_t", "accelerometer_clipping"),
    ("uint8_t", "gyro_clipping"),
]
VEHICLE_IMU = [
    ("uint64_t", "timestamp"),
    ("uint64_t", "timestamp_sample"),
    ("uint32_t", "accel_device_id"),
    ("uint32_t", "gyro_device_id"),
    ("float[3]", "delta_angle"),
    ("float[3]", "delta_velocity"),
    ("uint32_t", "delta_angle_dt"),
    ("uint32_t", "delta_velocity_dt"),
]
RAW = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("uint32_t", "device_id")]
RAW += [("float", "x"), ("float", "y"), ("float", "z"), ("float", "temperature")]
VEHICLE_MAG = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("uint32_t", "device_id")]
VEHICLE_MAG += [("float[3]", "magnetometer_ga")]
FORMATS = {
    "sensor_combined": COMBINED,
    "vehicle_imu": VEHICLE_IMU,
    "sensor_accel": RAW,
    "sensor_gyro": RAW,
    "sensor_mag": RAW,
    "vehicle_magnetometer": VEHICLE_MAG,
}


def _dtype(fields) -> np.dtype:
    out = []
    for typ, name in fields:
        base, _, n = typ.partition("[")
        out.append((name, _NP[base], (int(n[:-1]),)) if n else (name, _NP[base]))
    return np.dtype(out)


def _msg(kind: str, payload: bytes) -> bytes:
    """A ULog message: uint16 size of the payload, uint8 type, the payload."""
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def write_ulog(path, topics, *, start_us=1_000_000, version=1):
    """A ULog file of ``topics`` [(name, multi_id, {field: values})] (fields of :data:`FORMATS`; a missing field is
    zero), its data messages interleaved in time order as the logger writes them; returns the path."""
    head = b"ULog\x01\x12\x35" + bytes([version]) + struct.pack("<Q", start_us)
    defs = _msg("B", bytes(8) + bytes(8) + bytes(24)) if version >= 1 else b""  # no flags, nothing appended
    defs += _msg("I", bytes([len("char[6] sys_name")]) + b"char[6] sys_nameoptnav")
    for name in dict.fromkeys(t[0] for t in topics):
        defs += _msg("F", f"{name}:{''.join(f'{t} {n};' for t, n in FORMATS[name])}".encode())
    subs, rows = b"", []
    for msg_id, (name, multi_id, values) in enumerate(topics):
        subs += _msg("A", struct.pack("<BH", multi_id, msg_id) + name.encode())
        dt = _dtype(FORMATS[name])
        n = len(values["timestamp"])
        arr = np.zeros(n, dt)
        for k, v in values.items():
            arr[k] = v
        raw = arr.tobytes()
        for i in range(n):
            payload = struct.pack("<H", msg_id) + raw[i * dt.itemsize : (i + 1) * dt.itemsize]
            rows.append((int(arr["timestamp"][i]), msg_id, _msg("D", payload)))
    rows.sort(key=lambda r: (r[0], r[1]))
    path.write_bytes(head + defs + subs + b"".join(r[2] for r in rows))
    return path


def _combined(t, acc, gyr, t0_us=5_000_000):
    """sensor_combined's fields for samples at ``t`` (s after ``t0_us``)."""
    return {
        "timestamp": np.round(t * 1e6).astype(np.int64) + t0_us,
        "gyro_rad": gyr,
        "accelerometer_m_s2": acc,
        "gyro_integral_dt": np.full(t.size, 4000),
        "accelerometer_integral_dt": np.full(t.size, 4000),
    }


def _session(seed=2, dwell_s=3.0):
    from optinav.multipos.simulate import simulate

    return simulate("paper12", dwell_s=dwell_s, rate_hz=250.0, acc_unit="m/s^2", gyro_unit="rad/s", rng=seed)


def test_written_ulog_is_parsed_by_pyulog_to_the_values_written(tmp_path):
    """The writer above against the reference parser: every topic, instance and field as written."""
    pyulog = pytest.importorskip("pyulog")
    rng = np.random.default_rng(1)
    t = np.arange(50) / 250.0
    comb = _combined(t, rng.normal(size=(50, 3)), rng.normal(size=(50, 3)))
    mag = {"timestamp": comb["timestamp"][::5] + 7, "timestamp_sample": comb["timestamp"][::5] + 3}
    mag |= {"x": rng.normal(size=10), "y": rng.normal(size=10), "z": rng.normal(size=10)}
    topics = [("sensor_combined", 0, comb), ("sensor_mag", 0, mag), ("sensor_mag", 1, mag)]
    log = pyulog.ULog(str(write_ulog(tmp_path / "a.ulg", topics)))
    assert not log.file_corruption
    assert [(d.name, d.multi_id) for d in log.data_list] == [
        ("sensor_combined", 0),
        ("sensor_mag", 0),
        ("sensor_mag", 1),
    ]
    d = log.get_dataset("sensor_combined").data
    np.testing.assert_array_equal(d["timestamp"], comb["timestamp"])
    for k in range(3):
        np.testing.assert_array_equal(d[f"gyro_rad[{k}]"], comb["gyro_rad"][:, k].astype(np.float32))
        np.testing.assert_array_equal(
            d[f"accelerometer_m_s2[{k}]"], comb["accelerometer_m_s2"][:, k].astype(np.float32)
        )
    m = log.get_dataset("sensor_mag", 1).data
    np.testing.assert_array_equal(m["timestamp_sample"], mag["timestamp_sample"])
    np.testing.assert_array_equal(m["y"], mag["y"].astype(np.float32))
    assert log.msg_info_dict["sys_name"] == "optnav"


def test_sensor_combined_reads_and_calibrates_to_the_simulated_truth(tmp_path, capsys):
    """A simulated 250 Hz multi-position session written as sensor_combined: read_imu gives its float32 values at
    timestamp (µs → s), and ``optinav calibrate accel LOG.ulg`` recovers the simulated scale factors and biases
    within 5 of the standard deviations it reports (before: "not a data table optinav reads")."""
    pytest.importorskip("pyulog")
    s = _session()
    path = write_ulog(tmp_path / "flight.ulg", [("sensor_combined", 0, _combined(s.t, s.acc, s.gyr))])
    log = read_imu(path)
    np.testing.assert_allclose(log.t, 5.0 + np.round(s.t * 1e6) * 1e-6, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(log.acc, s.acc.astype(np.float32))
    np.testing.assert_array_equal(log.gyr, s.gyr.astype(np.float32))
    assert any("PX4 topic sensor_combined@0 read" in n for n in log.notes), log.notes
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(path), "--gravity", str(s.gravity), "--out", str(out)]) == 0
    from optinav.multipos.result import CalibrationResult

    r = CalibrationResult.from_json(out)
    for sensor, K, b in (("accelerometer", s.acc_K, s.acc_b), ("gyroscope", s.gyr_K, s.gyr_b)):
        d = getattr(r, sensor)
        assert np.all(np.abs(d["b"] - b) <= 5 * d["b_std"] + 1e-12), (sensor, d["b"] - b, d["b_std"])
        diag = np.diag(d["K"]) - np.diag(K)
        assert np.all(np.abs(diag) <= 5 * np.diag(d["K_std"]) + 1e-12), (sensor, diag, np.diag(d["K_std"]))


def test_vehicle_imu_increments_and_instances(tmp_path, capsys):
    """vehicle_imu's increments over delta_*_dt become the mean rate and specific force at timestamp_sample (the
    conversion of pyulog's CSV export); two instances are refused naming both, and one is read with NAME@K."""
    pytest.importorskip("pyulog")
    rng = np.random.default_rng(3)
    n = 400
    gyr, acc = rng.normal(0, 0.5, (n, 3)), rng.normal(0, 3, (n, 3)) + [0, 0, -9.8]
    dt_us = rng.integers(3900, 4100, n)
    ts = 2_000_000 + np.cumsum(dt_us)
    dtheta, dv = (gyr * dt_us[:, None] * 1e-6).astype(np.float32), (acc * dt_us[:, None] * 1e-6).astype(np.float32)
    imu = {"timestamp": ts + 150, "timestamp_sample": ts, "delta_angle": dtheta, "delta_velocity": dv}
    imu |= {"delta_angle_dt": dt_us, "delta_velocity_dt": dt_us}
    other = dict(imu, delta_angle=dtheta * 2)
    path = write_ulog(tmp_path / "v.ulg", [("vehicle_imu", 0, imu), ("vehicle_imu", 1, other)])
    with pytest.raises(
        OptinavError, match=r"logs 2 instances of 'vehicle_imu' \(vehicle_imu@0 \(400 msgs\), vehicle_imu@1"
    ):
        read_imu(path, topic="vehicle_imu")
    for k, want in ((0, dtheta), (1, dtheta * 2)):
        log = read_imu(path, topic=f"vehicle_imu@{k}")
        np.testing.assert_allclose(log.t, ts * 1e-6, rtol=0, atol=1e-9)
        np.testing.assert_allclose(log.gyr, want.astype(float) / (dt_us[:, None] * 1e-6), rtol=1e-12)
        np.testing.assert_allclose(log.acc, dv.astype(float) / (dt_us[:, None] * 1e-6), rtol=1e-12)
    np.testing.assert_allclose(read_imu(path, topic="vehicle_imu@0").gyr, gyr, rtol=1e-6, atol=1e-6)
    # the default topic is missing: the error lists what the log holds
    assert main(["--quiet", "allan", str(path), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "optinav: error: v.ulg has no default topic 'sensor_combined' (IMU and magnetometer topics: vehicle_imu@0 "
        "(400 msgs), vehicle_imu@1 (400 msgs)); pass one of the listed topics with --topic (NAME or NAME@INSTANCE; "
        "sensor_accel,sensor_gyro as a pair)"
    ], err


def test_raw_sensor_pair_each_on_its_own_times(tmp_path):
    """sensor_accel and sensor_gyro sample on their own clocks (here the gyro 1.5 ms after the accelerometer, at
    the same 250 Hz): the gyroscope is interpolated onto the accelerometer's timestamp_sample, as a second file's
    is. A session's static rates come back within the interpolation of its noise."""
    pytest.importorskip("pyulog")
    s = _session(seed=5, dwell_s=2.0)
    us = 3_000_000 + np.round(s.t * 1e6).astype(np.int64)
    acc = {"timestamp": us + 200, "timestamp_sample": us, "x": s.acc[:, 0], "y": s.acc[:, 1], "z": s.acc[:, 2]}
    gus = us + 1500
    gyr = {"timestamp": gus + 200, "timestamp_sample": gus, "x": s.gyr[:, 0], "y": s.gyr[:, 1], "z": s.gyr[:, 2]}
    path = write_ulog(tmp_path / "raw.ulg", [("sensor_accel", 0, acc), ("sensor_gyro", 0, gyr)])
    log = read_imu(path, topic="sensor_accel,sensor_gyro")
    keep = (us >= gus[0]) & (us <= gus[-1])
    np.testing.assert_allclose(log.t, us[keep] * 1e-6, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(log.acc, s.acc[keep].astype(np.float32))
    want = np.column_stack([np.interp(us[keep], gus, s.gyr[:, k].astype(np.float32)) for k in range(3)])
    np.testing.assert_allclose(log.gyr, want, rtol=0, atol=1e-12)
    assert any("raw.ulg:sensor_gyro@0" in n and "interpolated onto the time stamps" in n for n in log.notes)
    with pytest.raises(OptinavError, match="names sensor_accel without sensor_gyro"):
        read_imu(path, topic="sensor_accel")


def _flight(seed=1, duration_s=30.0):
    """A simulated dynamic flight (NED, 250 Hz) and a magnetometer at each sample (0.5 gauss at 60° dip, 0.003 gauss
    noise)."""
    from optinav.attitude.simulate import simulate
    from optinav.core.rotations import quat_conjugate, quat_rotate

    f = simulate("dynamic", duration_s=duration_s, rate_hz=250.0, frame="ned", rng=seed)
    field = 0.5 * np.array([np.cos(np.radians(60.0)), 0.0, np.sin(np.radians(60.0))])
    mag = quat_rotate(quat_conjugate(f.q_b_n), field) + np.random.default_rng(seed).normal(0, 0.003, (f.t.size, 3))
    return f, mag


def _flight_log(tmp_path, duration_s):
    """A simulated flight as f.ulg: sensor_combined at 250 Hz, vehicle_magnetometer at 50 Hz on its own
    timestamp_sample 1 ms after an IMU sample; (flight, magnetometer at each sample, its rows logged, path)."""
    f, mag = _flight(duration_s=duration_s)
    comb = _combined(f.t, f.acc, f.gyr)
    im = np.arange(0, f.t.size, 5)
    vm = {"timestamp": comb["timestamp"][im] + 300, "timestamp_sample": comb["timestamp"][im] + 1000}
    vm["magnetometer_ga"] = mag[im]
    return f, mag, im, write_ulog(tmp_path / "f.ulg", [("sensor_combined", 0, comb), ("vehicle_magnetometer", 0, vm)])


def test_attitude_mag_takes_the_magnetometer_topic_on_its_own_times(tmp_path, capsys):
    """``optinav attitude LOG.ulg --mag``: sensor_combined with vehicle_magnetometer (gauss, 50 Hz, its own
    timestamp_sample 1 ms after an IMU sample) on the IMU's rows. Each sample goes on its row: the attitude equals
    the estimate with the magnetometer given on those rows directly, its heading error against the simulation's
    truth is under a tenth of the gyro-only heading's, and the note names the topic, its unit and both rates."""
    pytest.importorskip("pyulog")
    from optinav.attitude import estimate
    from optinav.attitude.metrics import heading_error, rmse

    f, mag, im, path = _flight_log(tmp_path, 20.0)
    out = tmp_path / "q.csv"
    assert main(["attitude", str(path), "--mag", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"magnetometer of f.ulg (topic vehicle_magnetometer@0, gauss): {im.size} samples at 50 Hz" in err, err
    assert f"{im.size} of the {f.t.size} IMU rows (250 Hz) hold a sample" in err, err
    q = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    log = read_imu(path)
    direct = np.full((f.t.size, 3), np.nan)
    direct[im] = mag[im].astype(np.float32)
    dt = np.diff(log.t, prepend=log.t[0] - 0.004)
    np.testing.assert_allclose(q, estimate(log.gyr, log.acc, dt, mag=direct, frame="ned").q_b_n, atol=1e-6)
    gyro_only = estimate(log.gyr, log.acc, dt, frame="ned").q_b_n
    heading = [rmse(np.degrees(heading_error(x, f.q_b_n))[1250:]) for x in (q, gyro_only)]  # after 5 s
    assert heading[0] < 0.1 * heading[1], heading


def _still(seed, n=2500):
    """A level FRD body at rest for n samples at 250 Hz as sensor_combined: (n, its generator, the topic)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 250.0
    return n, rng, _combined(t, [0.0, 0.0, -9.80665] + rng.normal(0, 0.02, (n, 3)), rng.normal(0, 0.003, (n, 3)))


def test_a_raw_sensor_mag_that_hardly_turns_is_refused(tmp_path, capsys):
    """A still log whose only magnetometer is sensor_mag (the sensor's output before CAL_MAG*: 0.15, 0.1, -0.05 gauss
    of offset) was read with exit 0 and its heading off by the offset's angle. Now refused naming
    vehicle_magnetometer; the same field as vehicle_magnetometer (calibrated) is read."""
    pytest.importorskip("pyulog")
    n, rng, comb = _still(4)
    im = np.arange(0, n, 5)
    field = 0.5 * np.array([np.cos(np.radians(60.0)), 0.0, np.sin(np.radians(60.0))]) + rng.normal(
        0, 0.003, (im.size, 3)
    )
    ts = {"timestamp": comb["timestamp"][im] + 300, "timestamp_sample": comb["timestamp"][im] + 1000}
    raw = dict(ts, **{a: field[:, k] + [0.15, 0.1, -0.05][k] for k, a in enumerate("xyz")})
    out = tmp_path / "q.csv"
    path = write_ulog(tmp_path / "raw.ulg", [("sensor_combined", 0, comb), ("sensor_mag", 0, raw)])
    assert main(["attitude", str(path), "--mag", "--out", str(out)]) == 2 and not out.exists()
    err = [e for e in capsys.readouterr().err.splitlines() if "error" in e]
    assert len(err) == 1 and "raw.ulg (topic sensor_mag@0, gauss) is an uncalibrated magnetometer" in err[0], err
    assert "vehicle_magnetometer (--topic IMU,vehicle_magnetometer)" in err[0], err
    cal = write_ulog(
        tmp_path / "cal.ulg",
        [("sensor_combined", 0, comb), ("vehicle_magnetometer", 0, dict(ts, magnetometer_ga=field))],
    )
    assert main(["attitude", str(cal), "--mag", "--out", str(out)]) == 0
    q = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    from optinav.attitude.metrics import heading_error

    assert np.abs(heading_error(q, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))[-500:]).max() < np.radians(2.0)


def test_a_magnetometer_topic_named_without_mag_is_refused(tmp_path, capsys):
    """``attitude LOG.ulg --topic vehicle_magnetometer@1`` (a second magnetometer, as docs/file-formats.md names it)
    without --mag wrote the gyro-only (6D) attitude with exit 0, the named topic left out. Now refused naming --mag,
    streamed and in memory; with --mag the heading is the one of that instance's field (within 1° of north)."""
    pytest.importorskip("pyulog")
    from optinav.attitude.metrics import heading_error
    from optinav.attitude.unit import AttitudeOptions, read_log

    n, rng, comb = _still(6)
    im = np.arange(0, n, 5)
    ts = {"timestamp": comb["timestamp"][im], "timestamp_sample": comb["timestamp"][im]}
    mags = [dict(ts, magnetometer_ga=np.tile(f, (im.size, 1)) + rng.normal(0, 0.003, (im.size, 3)))
            for f in ([0.0, 0.2, 0.4], [0.2, 0.0, 0.4])]  # fmt: skip
    topics = [("sensor_combined", 0, comb), ("vehicle_magnetometer", 0, mags[0]), ("vehicle_magnetometer", 1, mags[1])]
    path = write_ulog(tmp_path / "two.ulg", topics)
    out = tmp_path / "q.csv"
    cmd = ["attitude", str(path), "--topic", "vehicle_magnetometer@1", "--out", str(out)]
    assert main(cmd) == 2 and not out.exists()
    err = [e for e in capsys.readouterr().err.splitlines() if "error" in e]
    assert len(err) == 1 and "magnetometer topic vehicle_magnetometer@1 of two.ulg" in err[0], err
    assert "add --mag (9D)" in err[0], err
    with pytest.raises(OptinavError, match="--mag was not given"):
        read_log(path, AttitudeOptions(topic="vehicle_magnetometer@1"))
    assert main([*cmd, "--mag"]) == 0
    q = np.loadtxt(out, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    assert np.abs(heading_error(q, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))[-500:]).max() < np.radians(1.0)


def test_refusals_are_one_line_errors(tmp_path, capsys, monkeypatch):
    """Without pyulog, a damaged or truncated log, a topic that is no IMU topic, a magnetometer asked of a log
    without one: each a one-line error naming what helps, never a traceback."""
    t = np.arange(20) / 250.0
    good = write_ulog(tmp_path / "g.ulg", [("sensor_combined", 0, _combined(t, np.ones((20, 3)), np.zeros((20, 3))))])
    raw = good.read_bytes()
    with monkeypatch.context() as m:
        m.setitem(sys.modules, "pyulog", None)
        with pytest.raises(OptinavError, match=r"needs the pyulog library.*pip install 'optinav\[ulog\]', or export"):
            load_table(good)
        assert main(["allan", str(good), "--out", str(tmp_path / "a.json")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "ulog2csv LOG.ulg" in err[0], err
    pytest.importorskip("pyulog")
    cases = {
        "short.ulg": (raw[:10], "short.ulg is not a readable ULog (Invalid file format (Header too short))"),
        "defs.ulg": (raw[:40], "defs.ulg is damaged: pyulog skipped messages"),  # cut in the definitions
        "junk.ulg": (raw[:16] + bytes(range(256)) * 4, "junk.ulg holds no message of an IMU or magnetometer topic"),
        "junk2.ulg": (raw[:200] + bytes(range(256)) * 4, "junk2.ulg is not a readable ULog"),
    }
    for name, (data, what) in cases.items():
        (tmp_path / name).write_bytes(data)
        assert main(["--quiet", "allan", str(tmp_path / name), "--out", str(tmp_path / "x.json")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"optinav: error: {what}"), (name, err)
    # a data message's type byte damaged in the middle: pyulog finds no sync marker after it and loses the rest
    n = 400
    t = np.arange(n) / 250.0
    full = write_ulog(tmp_path / "f.ulg", [("sensor_combined", 0, _combined(t, np.ones((n, 3)), np.zeros((n, 3))))])
    data = bytearray(full.read_bytes())
    data[data.index(b"D", len(data) // 2)] = 0
    (tmp_path / "hole.ulg").write_bytes(bytes(data))
    assert main(["--quiet", "allan", str(tmp_path / "hole.ulg"), "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "hole.ulg is damaged" in err[0] and "pass --skip-bad-lines" in err[0], err
    log = read_imu(tmp_path / "hole.ulg", skip_bad_lines=True)
    assert 0 < len(log) < n and any("damaged, read as pyulog recovers it" in x for x in log.notes), log.notes
    np.testing.assert_array_equal(log.t, read_imu(full).t[: len(log)])
    renamed = tmp_path / "renamed.csv"  # a ULog under another suffix is read as one (by its first bytes)
    renamed.write_bytes(raw)
    np.testing.assert_array_equal(read_imu(renamed).acc, read_imu(good).acc)
    pair = [("sensor_accel", 0, {"timestamp": 10 + np.arange(5), "timestamp_sample": np.arange(5) + 1, "x": t[:5]})]
    pair += [("sensor_gyro", 0, {"timestamp": 10 + np.arange(5), "timestamp_sample": np.arange(5) + 2, "y": t[:5]})]
    raw_pair = write_ulog(tmp_path / "pair.ulg", pair).read_bytes()
    (tmp_path / "pair.dat").write_bytes(raw_pair)
    got = read_imu(tmp_path / "pair.dat", topic="sensor_accel,sensor_gyro").acc[:, 0]
    np.testing.assert_array_equal(got, t[1:5].astype(np.float32))
    assert main(["--quiet", "allan", str(good), "--columns", "t,ax,ay,az", "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "optinav: error: positional columns (--columns t,ax,…) apply to text and array files, not to the ULog g.ulg; "
        "drop them (a ULog topic's fields are read by name)"
    ], err
    assert main(["--quiet", "allan", str(good), "--topic", "vehicle_attitude", "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'vehicle_attitude' is not a PX4 IMU or magnetometer topic" in err[0], err
    assert main(["--quiet", "attitude", str(good), "--mag", "--out", str(tmp_path / "q.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "g.ulg logs no magnetometer" in err[0] and "drop --mag" in err[0], err


def test_a_duplicated_time_stamp_names_a_remedy_a_ulog_takes(tmp_path, capsys):
    """A sensor_combined message logged twice (its timestamp repeated) ended in 'skipped with '_' in --columns, the
    sample rate given with --rate': --columns given for a ULog is refused. Now the remedy is the CSV export, whose
    rows less the repeated one read as the log's other samples; the same for the raw pair's topics."""
    pytest.importorskip("pyulog")
    from pyulog.ulog2csv import convert_ulog2csv

    n = 200
    t = np.arange(n) / 250.0
    rng = np.random.default_rng(5)
    comb = _combined(t, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))
    comb["timestamp"][100] = comb["timestamp"][99]
    raw_t = comb["timestamp"]
    pair = [("sensor_accel", 0, {"timestamp": raw_t, "timestamp_sample": raw_t, "x": t})]
    pair += [("sensor_gyro", 0, {"timestamp": raw_t + 1, "timestamp_sample": raw_t + 1, "y": t})]
    for name, topics, topic in (("dup", [("sensor_combined", 0, comb)], []),
                                ("pair", pair, ["--topic", "sensor_accel,sensor_gyro"])):  # fmt: skip
        log = write_ulog(tmp_path / f"{name}.ulg", topics)
        for chunk in ([], ["--chunk-rows", "64"]):
            assert main(["--quiet", "allan", str(log), *topic, *chunk, "--out", str(tmp_path / "a.json")]) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and "duplicate timestamp at index 100 (t = 5.396 s)" in err[0], err
            assert "--columns" not in err[0] and err[0].endswith("drop the duplicated rows of its CSV"), err
    convert_ulog2csv(str(tmp_path / "dup.ulg"), "sensor_combined", str(tmp_path), ",", None, None)
    csv = tmp_path / "dup_sensor_combined_0.csv"
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(lines[:101] + lines[102:]) + "\n")
    got = read_imu(csv)
    want = np.delete(comb["gyro_rad"], 100, axis=0).astype(np.float32)
    np.testing.assert_allclose(got.gyr, want, rtol=1e-6)  # ulog2csv writes float32 to 8 digits
    assert got.t.size == n - 1


def test_invalid_accelerometer_rows_are_nan_in_the_log_and_its_csv_export(tmp_path):
    """sensor_combined rows whose accelerometer_timestamp_relative is RELATIVE_TIMESTAMP_INVALID (0x7fffffff: "the
    associated sensor values are invalid", SensorCombined.msg; PX4 publishes it before the first accelerometer
    sample) were read as measurements; now their accelerometer is NaN (lost samples), in the .ulg and in the CSV
    ulog2csv writes of it alike, with a note."""
    pytest.importorskip("pyulog")
    n = 50
    t = np.arange(n) / 250.0
    rng = np.random.default_rng(6)
    acc, gyr = rng.normal(0, 1, (n, 3)) + [0, 0, -9.8], rng.normal(0, 0.1, (n, 3))
    comb = _combined(t, acc, gyr)
    comb["accelerometer_timestamp_relative"] = np.where(np.arange(n) < 3, 2147483647, 0)
    path = write_ulog(tmp_path / "i.ulg", [("sensor_combined", 0, comb)])
    names = ["timestamp", *(f"gyro_rad[{k}]" for k in range(3)), "accelerometer_timestamp_relative"]
    names += [f"accelerometer_m_s2[{k}]" for k in range(3)]
    cols = [comb["timestamp"], *gyr.astype(np.float32).T, comb["accelerometer_timestamp_relative"]]
    cols += list(acc.astype(np.float32).T)
    csv = tmp_path / "i_sensor_combined_0.csv"
    csv.write_text(
        ",".join(names) + "\n" + "".join(",".join(map(repr, r)) + "\n" for r in zip(*(c.tolist() for c in cols)))
    )
    for src in (path, csv):
        log = read_imu(src)
        assert np.all(np.isnan(log.acc[:3])) and log.nan_rows == 3, src
        np.testing.assert_array_equal(log.acc[3:], acc[3:].astype(np.float32))
        np.testing.assert_array_equal(log.gyr, gyr.astype(np.float32))
        assert any(
            "3 rows whose accelerometer_timestamp_relative is PX4's RELATIVE_TIMESTAMP_INVALID" in x for x in log.notes
        )


def test_allan_of_the_raw_pair_takes_each_sensor_on_its_own_clock(tmp_path, capsys):
    """``optinav allan LOG.ulg --topic sensor_accel,sensor_gyro``: each sensor on its own timestamp_sample (the gyro
    half a step after the accelerometer at 250 Hz; interpolated onto the accelerometer's times, a low-pass, its
    fitted white noise read 10–14 % low): the white noise N within 5 % of the simulated std × √dt for both."""
    pytest.importorskip("pyulog")
    from optinav.core.results import Result

    rng = np.random.default_rng(9)
    n, sa, sg = 10000, 0.02, 0.003
    us = 1_000_000 + 4000 * np.arange(n)
    acc = np.array([0.1, -0.2, -9.80665]) + rng.normal(0, sa, (n, 3))
    gyr = np.array([0.001, -0.002, 0.003]) + rng.normal(0, sg, (n, 3))
    topics = [
        ("sensor_accel", 0, {"timestamp": us + 90, "timestamp_sample": us, **dict(zip("xyz", acc.T))}),
        ("sensor_gyro", 0, {"timestamp": us + 2060, "timestamp_sample": us + 2000, **dict(zip("xyz", gyr.T))}),
    ]
    path = write_ulog(tmp_path / "rest.ulg", topics)
    out = tmp_path / "allan.json"
    assert main(["--quiet", "allan", str(path), "--topic", "sensor_accel,sensor_gyro", "--out", str(out)]) == 0
    res = Result.from_json(out)
    for sensor, truth in (("accelerometer", sa * np.sqrt(0.004)), ("gyroscope", sg * np.sqrt(0.004))):
        np.testing.assert_allclose(res.sensor(sensor)["fit"].white, truth, rtol=0.05)


def test_attitude_mag_parses_the_log_once(tmp_path, monkeypatch, capsys):
    """``attitude LOG.ulg --mag`` read the IMU's topic, then the magnetometer's, and pyulog parsed the whole file
    each time (bench_ulog: 3.7 s + 3.3 s per hour of log). The parse is kept for the second read of the unchanged
    file: one parse, the same attitude; a changed file is parsed again."""
    pytest.importorskip("pyulog")
    import pyulog

    f, mag, im, path = _flight_log(tmp_path, 10.0)
    parses = []
    real = pyulog.ULog

    def counting(*a, **k):
        parses.append(a[0])
        return real(*a, **k)

    monkeypatch.setattr(pyulog, "ULog", counting)
    out = tmp_path / "q.csv"
    assert main(["--quiet", "attitude", str(path), "--mag", "--out", str(out)]) == 0
    assert len(parses) == 1, parses
    first = out.read_bytes()
    path.write_bytes(path.read_bytes())  # the same bytes, a new modification time: parsed again
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))
    assert main(["--quiet", "attitude", str(path), "--mag", "--out", str(out)]) == 0
    assert len(parses) == 2 and out.read_bytes() == first
