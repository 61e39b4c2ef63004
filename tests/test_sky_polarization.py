"""Sky polarization (optinav.sky.polarization): Rayleigh/Berry invariants and the point-source sensor."""

from __future__ import annotations

import numpy as np
import pytest

from optinav.core.units import DEG
from optinav.errors import OptinavError
from optinav.sky.polarization import (
    DEFAULT_D_MAX,
    PointSensor,
    aop_in_sensor,
    rayleigh_dop,
    scattering_angle,
    sky_polarization,
    wrap_axial,
    zenith_aop,
)

UP = np.array([0.0, 0.0, 1.0])


def _random_units(rng, n, upper=False):
    v = rng.normal(size=(n, 3))
    if upper:
        v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_rayleigh_invariants():
    rng = np.random.default_rng(0)
    s, v = _random_units(rng, 5000), _random_units(rng, 5000)
    p = sky_polarization(s, v)
    assert np.all((p.dop >= 0) & (p.dop <= DEFAULT_D_MAX + 1e-15))
    np.testing.assert_allclose(np.sum(p.e * s, axis=1), 0, atol=1e-12)  # perpendicular to the scattering plane
    np.testing.assert_allclose(np.sum(p.e * v, axis=1), 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(p.e, axis=1), 1, atol=1e-12)
    # maximum at 90°, zero forward and backward; symmetric in γ ↔ π − γ
    assert rayleigh_dop(np.pi / 2, 0.8) == pytest.approx(0.8)
    assert rayleigh_dop(0.3, 0.8) == pytest.approx(rayleigh_dop(np.pi - 0.3, 0.8))
    np.testing.assert_allclose(p.gamma, np.arccos(np.clip(np.sum(s * v, axis=1), -1, 1)), atol=1e-7)
    assert scattering_angle([0, 0, 1.0], [1.0, 0, 0]) == pytest.approx(np.pi / 2)


def test_degenerate_sun_on_axis_and_antisun():
    z = np.array([0.0, 0.0, 1.0])
    for s in (z, -z):
        p = sky_polarization(s, z)
        assert not p.valid and p.dop == 0 and np.all(p.e == 0)
        assert np.isnan(aop_in_sensor(p.e)) and np.isnan(zenith_aop(s))
    # Berry with the sun at the zenith: the meridian is arbitrary, the neutral points sit δ/2 from the zenith
    d = 0.4
    b = sky_polarization(z, z, model="berry", up=UP, neutral_distance=d)
    assert np.isfinite(b.dop) and 0 < b.dop < 0.1  # the sun itself is not a neutral point in Berry's model
    ring = np.array(
        [[np.sin(d / 2) * np.cos(a), np.sin(d / 2) * np.sin(a), np.cos(d / 2)] for a in np.arange(4) * np.pi / 2]
    )
    bz = sky_polarization(z, ring, model="berry", up=UP, neutral_distance=d)
    assert np.min(bz.dop) < 1e-12  # one of the two is on the chosen meridian
    with pytest.raises(OptinavError):
        sky_polarization(z, [0, 0, 2.0])  # not a unit vector
    with pytest.raises(OptinavError):
        sky_polarization(z, z, model="berry")  # needs up


def test_zenith_aop_is_axial_and_matches_sensor_frame_formula():
    rng = np.random.default_rng(1)
    s = _random_units(rng, 2000)
    a = zenith_aop(s)
    assert np.all((a >= -np.pi / 2) & (a < np.pi / 2))
    assert np.all(zenith_aop(-s) == a) or np.allclose(wrap_axial(zenith_aop(-s) - a), 0, atol=1e-12)  # axial
    p = sky_polarization(s, np.broadcast_to([0, 0, 1.0], s.shape))
    np.testing.assert_allclose(wrap_axial(aop_in_sensor(p.e) - a), 0, atol=1e-12)
    # E_m ∝ [s_y, −s_x, 0]: the sun due +X_m gives E along Y_m, i.e. α = −π/2 (≡ π/2)
    assert zenith_aop([0.6, 0.0, 0.8]) == pytest.approx(-np.pi / 2)
    assert zenith_aop([0.0, 0.6, 0.8]) == pytest.approx(0.0)
    # turning the sensor about Z_m by +θ turns the measured angle by −θ
    th = 0.4
    c = np.array([[np.cos(th), np.sin(th), 0], [-np.sin(th), np.cos(th), 0], [0, 0, 1]])  # C_m^m'
    np.testing.assert_allclose(wrap_axial(zenith_aop(s @ c.T) - (a - th)), 0, atol=1e-12)


def test_berry_reduces_to_rayleigh_and_has_neutral_points():
    rng = np.random.default_rng(2)
    s, v = _random_units(rng, 3000, upper=True), _random_units(rng, 3000, upper=True)
    r = sky_polarization(s, v)
    b = sky_polarization(s, v, model="berry", up=UP, neutral_distance=0.0)
    np.testing.assert_allclose(b.dop, r.dop, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(b.e * r.e, axis=1)), 1, atol=1e-12)
    # neutral points δ/2 above and below the sun on the solar meridian; antisolar ones below the horizon side
    ts, d = 60 * DEG, 25 * DEG
    sun = np.array([np.sin(ts), 0, np.cos(ts)])
    for th in (ts - d / 2, ts + d / 2):
        view = np.array([np.sin(th), 0, np.cos(th)])
        assert sky_polarization(sun, view, model="berry", up=UP, neutral_distance=d).dop < 1e-12
    # far from the neutral points the two models agree closely (90° from the sun)
    view = np.array([0.0, 1.0, 0.0]) * np.sin(80 * DEG) + UP * np.cos(80 * DEG)
    view /= np.linalg.norm(view)
    bb = sky_polarization(sun, view, model="berry", up=UP, neutral_distance=d)
    rr = sky_polarization(sun, view)
    assert abs(bb.dop - rr.dop) < 0.05 and abs(np.sum(bb.e * rr.e)) > np.cos(5 * DEG)


@pytest.mark.parametrize(
    "sensor", [PointSensor(), PointSensor.four_channel(extinction_ratio=30.0), PointSensor(extinction_ratio=np.inf)]
)
def test_stokes_inversion_exact_without_noise(sensor):
    rng = np.random.default_rng(3)
    aop = rng.uniform(-np.pi / 2, np.pi / 2, 500)
    dop = rng.uniform(0.05, 0.9, 500)
    m = sensor.measure(aop, dop, noise=False)
    np.testing.assert_allclose(wrap_axial(m.aop - aop), 0, atol=1e-12)
    np.testing.assert_allclose(m.dop, dop, atol=1e-12)
    np.testing.assert_allclose(m.intensity, sensor.intensity, atol=1e-12)
    # the angle is axial: α and α + π give the same channels
    np.testing.assert_allclose(
        sensor.channels(aop + np.pi, dop, noise=False), sensor.channels(aop, dop, noise=False), atol=1e-12
    )


@pytest.mark.parametrize("psi_deg", [(0, 60, 120), (0, 45, 90, 135)])
def test_noise_statistics_match_theory(psi_deg):
    sensor = PointSensor(psi=np.array(psi_deg) * DEG, noise=0.004, extinction_ratio=200.0)
    n, d, alpha = 20000, 0.4, 0.3
    m = sensor.measure(np.full(n, alpha), np.full(n, d), rng=7)
    err = wrap_axial(m.aop - alpha)
    k = len(psi_deg)
    eta = (1 - 1 / 200) / (1 + 1 / 200)
    theory = np.sqrt(2.0 / k) * sensor.noise / (eta * d) * (1 + 1 / 200) ** -1  # σ_α = √(2/K)·σ_I/(η' I d)
    assert sensor.aop_sigma(d) == pytest.approx(theory, rel=1e-9)
    # sample std of n normal values: relative standard error 1/√(2n) = 0.5 %; allow 4σ
    assert np.std(err) == pytest.approx(theory, rel=4 / np.sqrt(2 * n))
    assert abs(np.mean(err)) < 4 * theory / np.sqrt(n)
    assert abs(np.mean(m.dop) - d) < 0.01  # the DoP estimator is unbiased to second order at this SNR


def test_channel_errors_bias_the_angle_and_validation():
    good = PointSensor()
    bad = PointSensor(gain=[1.03, 0.98, 1.0], offset=[0.0, 0.01, -0.01])
    aop = np.linspace(-1.5, 1.5, 50)
    e_good = wrap_axial(good.measure(aop, 0.5, noise=False).aop - aop)
    e_bad = wrap_axial(bad.measure(aop, 0.5, noise=False).aop - aop)
    assert np.max(np.abs(e_good)) < 1e-12 and np.max(np.abs(e_bad)) > 0.5 * DEG
    # a calibrated inversion (assumed = true gains/offsets) removes the bias
    cal = PointSensor(gain=bad.gain, offset=bad.offset, assumed_gain=bad.gain, assumed_offset=bad.offset)
    assert np.max(np.abs(wrap_axial(cal.measure(aop, 0.5, noise=False).aop - aop))) < 1e-12
    r1 = PointSensor.with_random_errors(0.02, 0.005, rng=1)
    r2 = PointSensor.with_random_errors(0.02, 0.005, rng=1)
    np.testing.assert_array_equal(r1.gain, r2.gain)
    for kw in ({"psi": [0.0, 1.0]}, {"psi": [0.0, np.pi, 2 * np.pi]}, {"extinction_ratio": 1.0}, {"noise": -1.0}):
        with pytest.raises(OptinavError):
            PointSensor(**kw)
