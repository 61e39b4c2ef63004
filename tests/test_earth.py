"""Earth model against published reference values (NIMA TR8350.2; PSINS glv)."""

import numpy as np
import pytest

from optinav import OptinavError
from optinav.core import earth


def test_wgs84_normal_gravity_reference_values():
    # NIMA TR8350.2 Table 3.4: γ_e = 9.7803253359, γ_p = 9.8321849378 m/s²
    assert earth.gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert earth.gravity(np.pi / 2) == pytest.approx(9.8321849378, abs=1e-9)


def test_wgs84_free_air_gradient():
    # TR8350.2 eq. 4-3: dγ/dh ≈ −3.086e-6 s⁻² near the surface at mid latitudes
    lat = np.radians(45)
    grad = (earth.gravity(lat, 100.0) - earth.gravity(lat, 0.0)) / 100.0
    assert grad == pytest.approx(-3.086e-6, rel=2e-3)


def test_psins_gravity_formula():
    # PSINS: g = g0 (1 + 5.27094e-3 sin²L + 2.32718e-5 sin⁴L) − 3.086e-6 h, g0 = 9.7803267715
    lat, h = np.radians(34.0), 380.0
    s2 = np.sin(lat) ** 2
    expect = 9.7803267715 * (1 + 5.27094e-3 * s2 + 2.32718e-5 * s2**2) - 3.086e-6 * h
    assert earth.gravity(lat, h, earth="psins") == pytest.approx(expect, abs=1e-12)
    assert earth.PSINS.omega_ie == 7.2921151467e-5
    assert earth.PSINS.f == 1 / 298.257
    # the two models agree to within a few μg
    assert abs(earth.gravity(lat, h, earth="psins") - earth.gravity(lat, h)) < 5e-5


def test_radii_reference():
    # R_N at the equator is a; R_M at the equator is a(1 − e²)
    rm, rn = earth.radii(0.0)
    assert rn == pytest.approx(6378137.0)
    assert rm == pytest.approx(6378137.0 * (1 - earth.WGS84.e2))
    # at the pole both equal a²/b
    rm, rn = earth.radii(np.pi / 2)
    a, b = earth.WGS84.a, earth.WGS84.b
    assert rm == pytest.approx(a**2 / b, rel=1e-12) and rn == pytest.approx(a**2 / b, rel=1e-12)


def test_frames_consistent():
    lat = np.radians(38.88)
    w_enu = earth.earth_rate(lat, "enu")
    w_ned = earth.earth_rate(lat, "ned")
    np.testing.assert_allclose(w_ned, [w_enu[1], w_enu[0], -w_enu[2]])
    assert np.linalg.norm(w_enu) == pytest.approx(earth.WGS84.omega_ie)
    v_enu = np.array([10.0, 20.0, 1.0])
    v_ned = np.array([20.0, 10.0, -1.0])
    t_enu = earth.transport_rate(lat, 100.0, v_enu, "enu")
    t_ned = earth.transport_rate(lat, 100.0, v_ned, "ned")
    np.testing.assert_allclose(t_ned, [t_enu[1], t_enu[0], -t_enu[2]])
    np.testing.assert_allclose(
        earth.position_rate(lat, 100.0, v_enu, "enu"), earth.position_rate(lat, 100.0, v_ned, "ned")
    )
    np.testing.assert_allclose(earth.gravity_vector(lat, 0, "enu")[2], -earth.gravity(lat))


def test_dcm_e_to_n_maps_earth_axis():
    lat, lon = np.radians(30.0), np.radians(120.0)
    c = earth.dcm_e_to_n(lat, lon, "enu")
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-15)
    # Earth rotation vector [0, 0, ω] in ECEF equals ω_ie^n
    np.testing.assert_allclose(c @ [0, 0, earth.WGS84.omega_ie], earth.earth_rate(lat, "enu"), atol=1e-20)
    cn = earth.dcm_e_to_n(lat, lon, "ned")
    np.testing.assert_allclose(cn @ [0, 0, earth.WGS84.omega_ie], earth.earth_rate(lat, "ned"), atol=1e-20)


def test_geodetic_to_ecef_reference():
    # on the equator at lon 0 the point is (a + h, 0, 0); at the pole (0, 0, b + h)
    np.testing.assert_allclose(earth.geodetic_to_ecef(0.0, 0.0, 10.0), [6378147.0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(earth.geodetic_to_ecef(np.pi / 2, 0.0, 0.0), [0, 0, earth.WGS84.b], atol=1e-6)


def test_vectorized():
    lat = np.radians(np.linspace(-80, 80, 7))
    assert earth.gravity_vector(lat).shape == (7, 3)
    assert earth.earth_rate(lat, "ned").shape == (7, 3)


def test_bad_input():
    with pytest.raises(OptinavError, match="frame"):
        earth.earth_rate(0.0, "nwu")
    with pytest.raises(OptinavError, match="constant set"):
        earth.gravity(0.0, earth="grs67")


def test_ecef_geodetic_round_trip():
    lat = np.radians([-89.9, -45.0, 0.0, 30.0, 89.99])
    lon = np.radians([-170.0, 10.0, 0.0, 120.0, 45.0])
    h = np.array([-100.0, 0.0, 8848.0, 350.0, 1e5])
    back = earth.ecef_to_geodetic(earth.geodetic_to_ecef(lat, lon, h))
    np.testing.assert_allclose(back[:, 0], lat, atol=1e-12)
    np.testing.assert_allclose(back[:, 1], lon, atol=1e-12)
    np.testing.assert_allclose(back[:, 2], h, atol=1e-6)
