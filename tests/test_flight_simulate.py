"""UAV flight simulator (optinav.attitude.simulate): accelerometer and polarization outputs against truth."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from optinav.attitude.simulate import PAPER_SITE, FlightData, FlightStream, simulate
from optinav.core.earth import gravity_vector
from optinav.core.imu_model import preset
from optinav.core.units import DEG
from optinav.errors import OptinavError
from optinav.sky.polarization import PointSensor, wrap_axial


@pytest.fixture(scope="module")
def static():
    return simulate("static", 30.0, 100.0, rng=11)


@pytest.fixture(scope="module")
def dynamic():
    return simulate("dynamic", 40.0, 100.0, rng=12)


def _rayleigh_aop(f: FlightData) -> np.ndarray:
    # independent evaluation of α = atan2(−s_x, s_y) for the sun in the sensor frame
    c_n_b = np.swapaxes(f.C_b_n, 1, 2)
    s_m = np.einsum("ij,njk,nk->ni", f.C_b_m, c_n_b, f.sun_n)
    return wrap_axial(np.arctan2(-s_m[:, 0], s_m[:, 1]))


def test_static_accelerometer_is_gravity(static):
    f = static
    g_n = gravity_vector(f.lat, f.height_m, "ned")
    expect = np.einsum("nji,j->ni", f.C_b_n, -g_n)  # C_n^b·(−g_n)
    np.testing.assert_allclose(f.acc_true, expect, atol=1e-6)
    spec = preset("mpu6000")
    n = len(f)
    sigma = spec.acc_vrw * np.sqrt(100.0)  # white noise per sample (m/s²)
    lsb = spec.acc_lsb
    # mean: white noise 5σ/√N, plus the in-run Gauss–Markov bias (σ = 1.076·B, 5σ) and half an LSB
    tol = 5 * sigma / np.sqrt(n) + 5 * 1.076 * spec.acc_bias_instability + lsb / 2
    assert np.all(np.abs(f.acc.mean(axis=0) - expect.mean(axis=0)) < tol)
    std = (f.acc - expect).std(axis=0)
    assert np.all(np.abs(std - np.sqrt(sigma**2 + lsb**2 / 12)) < 0.1 * sigma)
    # static gyro: Earth rate only, plus noise
    assert np.all(
        np.abs((f.gyr - f.gyr_true).mean(axis=0))
        < 5 * spec.gyro_arw * 10 / np.sqrt(n) + 5 * 1.076 * spec.gyro_bias_instability + spec.gyro_lsb / 2
    )
    assert np.linalg.norm(f.gyr_true[0]) == pytest.approx(7.292115e-5, rel=1e-3)


@pytest.mark.parametrize("which", ["static", "dynamic"])
def test_aop_matches_rayleigh_within_noise(which, static, dynamic):
    f = static if which == "static" else dynamic
    pred = _rayleigh_aop(f)
    np.testing.assert_allclose(wrap_axial(f.aop_true - pred), 0, atol=1e-9)
    sensor = PointSensor()  # the default sensor the simulator uses
    sig = sensor.aop_sigma(f.dop_true)
    z = wrap_axial(f.aop - pred) / sig
    n = z.size
    assert abs(np.mean(z)) < 5 / np.sqrt(n)
    assert np.std(z) == pytest.approx(1.0, abs=5 / np.sqrt(2 * n) + 0.02)  # +2 %: small-noise approximation
    # DoP: Rayleigh with the scattering angle between the sun and the viewing axis
    c_b_n = f.C_b_n
    view_n = np.einsum("nij,j->ni", c_b_n, f.C_b_m.T @ [0, 0, 1.0])
    cg = np.sum(view_n * f.sun_n, axis=1)
    np.testing.assert_allclose(f.dop_true, 0.75 * (1 - cg**2) / (1 + cg**2), atol=1e-12)


def test_shared_convention_with_measurement_model(dynamic):
    meas = pytest.importorskip("optinav.attitude.measurement")
    f = dynamic
    pred = meas.predicted_aop(f.q_b_n, f.sun_n, f.C_b_m, f.frame)
    np.testing.assert_allclose(wrap_axial(pred - f.aop_true), 0, atol=1e-9)
    pol = f.polarization()
    assert len(pol) == len(f)


def test_dynamic_flight_has_strong_manoeuvres(dynamic):
    f = dynamic
    a_n = np.einsum("nij,nj->ni", f.C_b_n, f.acc_true) + gravity_vector(f.lat, f.height_m, "ned")  # kinematic
    a = np.linalg.norm(a_n, axis=1)
    assert a.max() > 3.0  # strong accelerations (m/s²)
    assert f.metadata["gyro_saturated"] == 0 and f.metadata["acc_saturated"] == 0
    assert np.max(np.abs(f.euler[:, :2])) > 15 * DEG  # real tilts
    # still on the ground for the first 10 % of the flight, 4 s here (the estimators initialize from gravity)
    still = f.t < 3.0  # the position spline rings ~1e-3 m/s² within a few knots of the ramp
    assert np.max(a[still]) < 1e-5 and np.max(np.linalg.norm(f.gyr_true[still], axis=1)) < 1e-4
    # the paper's evening: sun low in the south-west
    assert 0 < np.degrees(f.sun_elevation.mean()) < 6 and 230 < np.degrees(f.sun_azimuth.mean()) < 250
    np.testing.assert_allclose(np.linalg.norm(f.q_b_n, axis=1), 1, atol=1e-12)


def test_enu_frame_same_physics_and_options():
    ned = simulate("static", 2.0, 50.0, rng=3)
    enu = simulate("static", 2.0, 50.0, rng=3, frame="ENU")
    np.testing.assert_allclose(enu.aop_true, ned.aop_true, atol=1e-9)  # same mounting, same sky
    np.testing.assert_allclose(enu.sun_n[:, [1, 0]], ned.sun_n[:, :2], atol=1e-12)
    np.testing.assert_allclose(enu.sun_n[:, 2], -ned.sun_n[:, 2], atol=1e-12)
    assert ned.sun_n.shape == (101, 3) and ned.frame == "ned" and enu.frame == "enu"
    sub = simulate("static", 2.0, 50.0, rng=3, pol_rate_hz=10.0)
    assert np.count_nonzero(np.isfinite(sub.aop)) == 21
    berry = simulate("static", 1.0, 50.0, rng=3, sky_model="berry", neutral_distance=0.0)
    np.testing.assert_allclose(wrap_axial(berry.aop_true - ned.aop_true[:51]), 0, atol=1e-9)
    bias = simulate("static", 2.0, 50.0, rng=3, gyro_bias=[0.01, 0, 0])
    assert np.mean(bias.gyr[:, 0] - ned.gyr[:, 0]) == pytest.approx(0.01, abs=1e-12)
    with pytest.raises(OptinavError, match="no UTC offset"):
        simulate("static", 1.0, 50.0, time="2021-01-17T10:34:00")
    with pytest.raises(OptinavError):
        simulate("loop", 1.0, 50.0)


def test_flight_data_roundtrip(tmp_path):
    f = simulate("static", 0.5, 20.0, rng=5, lat=PAPER_SITE["lat"])
    path = tmp_path / "flight.json"
    f.to_json(path)
    back = FlightData.from_json(path)
    np.testing.assert_array_equal(back.q_b_n, f.q_b_n)
    assert back.metadata["imu"] == "mpu6000"


def test_flight_blocks_do_not_change_the_flight():
    """The flight is generated block by block; any block length gives the same samples as :func:`simulate`."""
    whole = simulate("dynamic", 12.0, 50.0, rng=4, pol_rate_hz=10.0)
    stream = FlightStream("dynamic", 12.0, 50.0, rng=4, pol_rate_hz=10.0)
    parts = list(stream.blocks(97))
    assert len(parts) == stream.n_blocks(97) == 7 and stream.n == len(whole) == 601
    for k in parts[0]:
        got, want = np.concatenate([p[k] for p in parts]), getattr(whole, k)
        if k in ("t", "gyr", "acc", "q_b_n", "gyr_true", "acc_true"):
            assert np.array_equal(got, want), k
        else:  # the sun and the sky: numpy's vectorized sin/cos round by SIMD lane, so by position in the block
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=k)
    assert np.isnan(whole.aop[1:5]).all() and np.isfinite(whole.aop[[0, 5, 10]]).all()  # 10 Hz of 50 Hz
    meta = stream.metadata
    assert meta["gyro_saturated"] == whole.metadata["gyro_saturated"]
    assert meta["sun_elevation_deg_mean"] == pytest.approx(whole.metadata["sun_elevation_deg_mean"], rel=1e-12)
    with pytest.raises(OptinavError, match="already generated"):
        next(stream.blocks())


def test_long_flight_manoeuvres_are_integrated_in_chunks(monkeypatch):
    """The 0.01 s manoeuvre grid of a long flight is integrated a chunk at a time with the integrals carried: the
    knots are those of one pass over the whole grid to rounding."""
    mod = sys.modules["optinav.attitude.simulate"]  # the package attribute `simulate` is the function
    one = mod._dynamic_knots(60.0, "ned", np.random.default_rng(5), 4.0, 0.5, 0.1)
    monkeypatch.setattr(mod, "FINE_CHUNK", 777)
    chunked = mod._dynamic_knots(60.0, "ned", np.random.default_rng(5), 4.0, 0.5, 0.1)
    for a, b in zip(one, chunked):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-10)


def test_point_sensor_draws_must_match_the_channels():
    sensor = PointSensor(noise=0.01)
    with pytest.raises(OptinavError, match="one per channel"):
        sensor.measure(np.zeros(4), np.full(4, 0.5), draws=np.zeros((4, 2)))
    # the same standard normal draws as a generator's give the same reading
    z = np.random.default_rng(2).standard_normal((4, 3))
    a = sensor.measure(np.full(4, 0.3), np.full(4, 0.5), draws=z)
    b = sensor.measure(np.full(4, 0.3), np.full(4, 0.5), np.random.default_rng(2))
    np.testing.assert_allclose(a.aop, b.aop, rtol=0, atol=1e-15)
