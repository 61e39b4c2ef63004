"""What the commands do, called from Python: the library functions the thin CLI delegates to (issue 16)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optinav.errors import OptinavError


@pytest.fixture(scope="module")
def rest():
    from optinav.core.imu_model import simulate_static

    return simulate_static(1800.0, "mems-mti1", rate_hz=50.0, seed=3)


def test_simulate_static_is_the_preset_at_rest(rest):
    from optinav.core.earth import gravity
    from optinav.core.imu_model import preset, simulate_static

    spec = preset("mems-mti1")
    assert rest.t.size == 90_000 and rest.t[1] == pytest.approx(0.02)
    # the mean of white + flicker noise over the log is gravity (z) and zero (rate) within a few white-noise sigmas
    sigma_mean = np.max(spec.acc_vrw) / np.sqrt(rest.t[-1])
    g = float(gravity(np.radians(45.0), 0.0))
    assert np.allclose(rest.acc.mean(axis=0), [0, 0, g], atol=10 * sigma_mean + 3 * np.max(spec.acc_bias_instability))
    p = rest.truth.parameters
    assert p["acc_white_x"].value == pytest.approx(spec.acc_vrw[0]) and p["gyr_random_walk_z"].value == 0.0
    assert rest.truth.info["seed"] == 3 and rest.truth.info["rate_hz"] == 50.0
    again = simulate_static(1800.0, "mems-mti1", rate_hz=50.0, seed=3)
    assert np.array_equal(again.gyr, rest.gyr)  # the seed fixes the draws
    with pytest.raises(OptinavError, match="needs thousands"):
        simulate_static(10.0, rate_hz=50.0)


def test_simulate_static_command_streams_the_library_log(rest, tmp_path):
    """``optinav simulate static`` writes its log block by block (90 000 samples: two blocks of 65 536): the file
    is the library's gathered log, and the truth beside it the same."""
    import json

    from optinav.cli.main import main
    from optinav.io import read_imu

    out = tmp_path / "rest.csv"
    assert (
        main(["--quiet", "simulate", "static", "--out", str(out), "--hours", "0.5", "--rate", "50", "--seed", "3"]) == 0
    )
    log = read_imu(out)
    np.testing.assert_allclose(log.t, rest.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.gyr, rest.gyr, rtol=1e-15, atol=0)
    np.testing.assert_allclose(log.acc, rest.acc, rtol=1e-15, atol=0)
    truth = json.loads((tmp_path / "rest.truth.json").read_text())
    assert truth["seed"] == 3 and truth["parameters"]["gyr_white_x"]["value"] == pytest.approx(
        rest.truth.parameters["gyr_white_x"].value
    )


def _blocks(log, cuts):
    from optinav.io import ImuLog

    edges = [0, *sorted(set(cuts)), log.t.size]
    return [
        ImuLog(t=log.t[a:b], acc=log.acc[a:b], gyr=log.gyr[a:b], acc_unit="m/s^2", gyro_unit="rad/s")
        for a, b in zip(edges[:-1], edges[1:])
        if b > a
    ]


@settings(max_examples=5)
@given(st.lists(st.integers(1, 89_999), max_size=4))
def test_allan_analysis_does_not_depend_on_the_blocks(rest, cuts):
    """The streamed analysis folds blocks into angle sums: any split gives the one-block result, and the white
    noise read from the fit is the preset's within its 68 % interval widened to 3 sigma."""
    from optinav.core.allan import analyse_blocks
    from optinav.core.imu_model import preset

    whole = _analysis(rest)
    split = analyse_blocks(_blocks(rest, cuts), "gyro")
    fit_w, fit_s = whole.gyroscope["fit"], split.gyroscope["fit"]
    assert np.allclose(fit_s.white, fit_w.white, rtol=1e-9)
    N = preset("mems-mti1").gyro_arw
    lo, hi = np.asarray(fit_w.white_interval).reshape(2, -1)
    assert np.all(N > lo - 2 * (fit_w.white - lo)) and np.all(N < hi + 2 * (hi - fit_w.white))


_CACHE: dict = {}


def _analysis(rest):
    from optinav.core.allan import analyse_blocks

    if "whole" not in _CACHE:
        _CACHE["whole"] = analyse_blocks(_blocks(rest, []), "gyro")
    return _CACHE["whole"]


def test_allan_analysis_summary_and_refusals(rest):
    from optinav.core.allan import analyse_blocks

    res = _analysis(rest)
    text = res.summary()
    assert "90000 samples at 50 Hz over 0.5 h" in text and "white noise N (ARW/VRW) [rad/s*sqrt(s)]" in text
    t = rest.t.copy()
    t[5000:] += 1.0  # a one-second gap
    from optinav.io import ImuLog

    gap = ImuLog(t=t, acc=rest.acc, gyr=rest.gyr, acc_unit="m/s^2", gyro_unit="rad/s")
    with pytest.raises(OptinavError, match="not regularly sampled"):
        analyse_blocks([gap])
    with pytest.raises(OptinavError, match="Kalibr needs both triads"):
        analyse_blocks(_blocks(rest, []), "gyro", need_kalibr=True)


def test_csv_writer_blocks_equal_one_write(tmp_path):
    from optinav.attitude.recording import CSV_FORMAT, CSV_HEADER
    from optinav.core.files import csv_writer, write_csv

    rng = np.random.default_rng(0)
    table = np.column_stack([1.6e9 + np.arange(7) * 0.01, rng.normal(size=(7, 7))])
    write_csv(tmp_path / "one.csv", table, CSV_HEADER, CSV_FORMAT)
    with csv_writer(tmp_path / "blocks.csv", CSV_HEADER, CSV_FORMAT) as write:
        write(table[:3])
        write(table[3:])
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "blocks.csv").read_bytes()
    back = np.loadtxt(tmp_path / "one.csv", delimiter=",", skiprows=1)
    assert np.array_equal(back[:, 0], table[:, 0])  # times exactly (%.17g)
    with pytest.raises(ZeroDivisionError), csv_writer(tmp_path / "failed.csv", "a") as write:
        write(np.ones((1, 1)))
        1 / 0
    assert not (tmp_path / "failed.csv").exists()  # atomic: nothing when the block fails


def test_sun_along_log():
    from optinav.attitude.recording import sun_along_log
    from optinav.sky import solar_position, sun_vector

    t = np.array([100.0, 160.0, 3700.0])
    lat, lon = np.radians(38.8814192), np.radians(121.528255)
    s = sun_along_log(t, "ned", lat=lat, lon=lon, height_m=35.0, start_time="2021-01-16T16:33:00+08:00")
    # t is relative to the log's first sample, which is the start time
    ref = solar_position(
        np.array(["2021-01-16T08:33:00", "2021-01-16T08:34:00", "2021-01-16T09:33:00"], dtype="datetime64[ns]"),
        lat,
        lon,
        35.0,
        pressure=101325.0,
    )
    assert np.allclose(s, ref.sun_vector("ned"), atol=1e-12)
    # a low winter sun (up is -z) that has set an hour later
    assert np.allclose(np.linalg.norm(s, axis=1), 1.0) and np.all(s[:2, 2] < 0) and s[2, 2] > 0
    fixed = sun_along_log(t, "enu", azimuth=np.radians(200.0), elevation=np.radians(30.0))
    assert np.allclose(fixed, sun_vector(np.radians(200.0), np.radians(30.0), "enu"))
    with pytest.raises(OptinavError, match="both a fixed sun"):
        sun_along_log(t, "ned", lat=lat, azimuth=0.0, elevation=0.0)
    with pytest.raises(OptinavError, match="go together"):
        sun_along_log(t, "ned", azimuth=0.0)
    with pytest.raises(OptinavError, match="needs the sun"):
        sun_along_log(t, "ned", lat=lat, lon=lon)


def test_plan_noise_sources(tmp_path):
    from optinav.core.imu_model import preset
    from optinav.multipos.plan import plan_noise

    acc, gyro, text = plan_noise()
    spec = preset("mems-mti1")
    assert np.array_equal(acc, spec.acc_vrw) and np.array_equal(gyro, spec.gyro_arw) and "assumed" in text
    acc, gyro, text = plan_noise(acc_noise_density=1e-3)
    assert np.array_equal(acc, np.full(3, 1e-3)) and gyro is None
    assert f"accelerometer {1e-3 / 9.80665e-6:.3g} µg/√Hz" in text
    with pytest.raises(OptinavError, match="both give the noise"):
        plan_noise(allan=tmp_path / "a.json", preset="mpu6000")


def test_simulated_session_log_and_truth():
    from optinav.multipos.result import session_truth
    from optinav.multipos.simulate import simulate

    s = simulate("six", dwell_s=5.0, rest_s=2.0, transition_s=2.0, rate_hz=50.0, acc_unit="g", gyro_unit="deg/s", rng=2)
    log = s.log()
    assert log.acc_unit == "m/s^2" and log.gyro_unit == "rad/s"
    assert np.allclose(log.acc, s.acc * 9.80665) and np.allclose(log.gyr, np.radians(s.gyr))
    truth = s.truth({"latitude_deg": 38.88}, {"seed": 2})
    want = session_truth(s.acc_K, s.acc_b, s.gyr_K, s.gyr_b, acc_unit="g", gyro_unit="deg/s")
    assert truth.parameters.keys() == want.parameters.keys()
    assert all(truth.parameters[k].value == want.parameters[k].value for k in want.parameters)
    assert truth.info["seed"] == 2 and truth.info["accelerometer"]["K"] == s.acc_K.tolist()
    assert list(truth.info)[5:7] == ["latitude_deg", "static_intervals"]  # the site after the gravity it sets
