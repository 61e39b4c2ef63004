"""Sun position (optinav.sky.sun): the NREL SPA report's example, pvlib as an oracle, time handling, CLI."""

from __future__ import annotations

import datetime as dt
import json

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.units import DEG
from optinav.errors import OptinavError
from optinav.sky import sun as S
from optinav.sky.sun import delta_t_espenak, solar_position, solar_position_deg, sun_vector, utc_seconds

SPA_EXAMPLE = dict(
    time="2003-10-17T12:30:30-07:00",
    lat_deg=39.742476,
    lon_deg=-105.1786,
    height_m=1830.14,
    pressure_mbar=820.0,
    temperature_c=11.0,
    delta_t=67.0,
)


def test_spa_report_example():
    """Reda & Andreas (2008), Table A5.1 / spa_tester.c output (ΔUT1 = 0)."""
    r = solar_position_deg(**SPA_EXAMPLE)
    assert S.julian_day(utc_seconds(SPA_EXAMPLE["time"])) == pytest.approx(2452930.312847, abs=5e-7)
    assert np.degrees(r.zenith) == pytest.approx(50.11162, abs=5e-6)
    assert np.degrees(r.azimuth) == pytest.approx(194.34024, abs=5e-6)
    assert np.degrees(r.hour_angle) == pytest.approx(11.105902, abs=5e-7)  # H, geocentric
    assert np.degrees(r.declination) == pytest.approx(-9.31434, abs=5e-6)
    assert np.degrees(r.right_ascension) == pytest.approx(202.22741, abs=5e-6)
    assert r.earth_sun_distance == pytest.approx(0.9965422974, abs=5e-10)
    # intermediate quantities of the report
    jde = S.julian_day(utc_seconds(SPA_EXAMPLE["time"])) + 67.0 / 86400
    L, B, R, dpsi, deps = S._slow_terms(np.atleast_1d(jde))
    assert np.degrees(L[0]) % 360 == pytest.approx(24.0182616917, abs=1e-9)
    assert np.degrees(B[0]) == pytest.approx(-0.0001011219, abs=1e-10)
    assert dpsi[0] == pytest.approx(-0.00399840, abs=1e-8)
    assert deps[0] == pytest.approx(0.00166657, abs=1e-8)
    # without refraction the sun is lower by the SPA refraction (~0.0136° here at 820 mbar)
    g = solar_position_deg(**{**SPA_EXAMPLE, "pressure_mbar": None})
    assert not g.refraction and r.refraction
    assert float(g.elevation) == pytest.approx(float(r.elevation_geometric), abs=1e-12)
    refr = np.degrees(r.elevation - g.elevation)
    assert 0.005 < refr < 0.03


def test_pvlib_oracle_grid():
    pvlib = pytest.importorskip("pvlib")
    pd = pytest.importorskip("pandas")
    rng = np.random.default_rng(6)
    t0, t1 = np.datetime64("1950-01-01T00:00", "s"), np.datetime64("2050-12-31T00:00", "s")
    secs = rng.integers(0, int((t1 - t0).astype(np.int64)), 120)
    times = t0 + secs.astype("timedelta64[s]")
    index = pd.DatetimeIndex(times).tz_localize("UTC")
    worst_z = worst_a = 0.0
    for lat in (-80.0, -45.0, -10.0, 0.0, 25.0, 38.8814192, 60.0, 80.0):
        for lon in (-170.0, -60.0, 0.0, 121.528255):
            ours = solar_position_deg(times, lat, lon, 35.0, pressure_mbar=1000.0, temperature_c=5.0)
            ref = pvlib.solarposition.spa_python(
                index, lat, lon, altitude=35.0, pressure=100000.0, temperature=5.0, delta_t=ours.delta_t, how="numpy"
            )
            z = np.degrees(ours.zenith)
            worst_z = max(worst_z, np.max(np.abs(z - ref["apparent_zenith"].to_numpy())))
            dz = np.degrees(np.pi / 2 - ours.elevation_geometric) - ref["zenith"].to_numpy()
            worst_z = max(worst_z, np.max(np.abs(dz)))
            da = (np.degrees(ours.azimuth) - ref["azimuth"].to_numpy() + 180) % 360 - 180
            worst_a = max(worst_a, np.max(np.abs(da * np.sin(ours.zenith))))  # arc on the sky
            eot = ours.equation_of_time / 60.0 - ref["equation_of_time"].to_numpy()
            assert np.max(np.abs(eot)) < 1e-4  # minutes
    assert worst_z < 1e-6 and worst_a < 1e-6, (worst_z, worst_a)


def test_delta_t_matches_pvlib_and_observed():
    spa = pytest.importorskip("pvlib.spa")
    years = np.array([1900, 1935, 1950, 1975, 1990, 2000, 2010, 2020, 2040, 2100, 1650, 1750, 1830, 1870, 1000])
    months = np.array([1, 6, 3, 9, 12, 7, 2, 5, 8, 1, 6, 6, 6, 6, 6])
    ours = delta_t_espenak(years + (months - 0.5) / 12)
    ref = spa.calculate_deltat(years, months)
    np.testing.assert_allclose(ours, ref, atol=1e-6)
    # observed (IERS) ΔT: 1990.0: 56.86 s, 2000.0: 63.83 s
    assert delta_t_espenak(1990.04) == pytest.approx(56.86, abs=0.5)
    assert delta_t_espenak(2000.04) == pytest.approx(63.83, abs=0.5)


def test_time_inputs_agree_and_naive_is_error():
    iso = "2021-01-17T10:34:00+08:00"
    a = utc_seconds(iso)
    b = utc_seconds(dt.datetime(2021, 1, 17, 2, 34, tzinfo=dt.timezone.utc))
    c = utc_seconds(np.datetime64("2021-01-17T02:34:00"))
    d = utc_seconds("2021-01-17T02:34:00Z")
    assert a == b == c == d
    many = utc_seconds([iso, "2021-01-16T16:33:00+08:00"])
    assert many.shape == (2,) and many[0] - many[1] == pytest.approx(18 * 3600 + 60)
    for bad in ("2021-01-17T10:34:00", dt.datetime(2021, 1, 17, 10, 34), ["2021-01-17T10:34+08:00", "2021-01-17"]):
        with pytest.raises(OptinavError, match="no UTC offset"):
            solar_position_deg(bad, 38.9, 121.5)
    with pytest.raises(OptinavError, match="ISO"):
        utc_seconds("yesterday+08:00")
    # a leap second (GNSS and UTC logs write 23:59:60) was refused as "not ISO 8601": it is the next day's 00:00:00
    # in the seconds the sun is computed from; an ordinal date is named as unread
    assert utc_seconds("2016-12-31T23:59:60Z") == utc_seconds("2017-01-01T00:00:00Z")
    assert utc_seconds("2016-12-31T23:59:60.25+00:00") - utc_seconds("2016-12-31T23:59:59+00:00") == 1.25
    with pytest.raises(OptinavError, match="not an ordinal or week date"):
        utc_seconds("2021-016T10:00:00+08:00")
    with pytest.raises(OptinavError, match="plain number"):
        utc_seconds(1.6e9)


def test_si_core_equals_degree_wrapper_and_vectors():
    t = np.datetime64("2021-06-21T04:00:00")
    r1 = solar_position(
        t, 38.8814192 * DEG, 121.528255 * DEG, 35.0, pressure=101325.0, temperature=288.15, delta_t=69.0
    )
    r2 = solar_position_deg(t, 38.8814192, 121.528255, 35.0, pressure_mbar=1013.25, temperature_c=15.0, delta_t=69.0)
    assert float(r1.zenith) == float(r2.zenith) and float(r1.azimuth) == float(r2.azimuth)
    ned, enu = r1.sun_vector("ned"), r1.sun_vector("enu")
    np.testing.assert_allclose(np.linalg.norm(ned), 1.0, atol=1e-15)
    np.testing.assert_allclose(ned, [enu[1], enu[0], -enu[2]], atol=1e-15)
    assert np.arccos(-ned[2]) == pytest.approx(float(r1.zenith), abs=1e-12)
    np.testing.assert_allclose(sun_vector(0.0, 0.0, "ned"), [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(sun_vector(np.pi / 2, 0.0, "enu"), [1, 0, 0], atol=1e-15)
    with pytest.raises(OptinavError):
        sun_vector(0, 0, "xyz")
    with pytest.raises(OptinavError):
        solar_position(t, 2.0, 0.0)  # latitude in degrees by mistake


def test_noon_geometry_and_result_roundtrip(tmp_path):
    # at the equinox the noon sun stands at the colatitude, due south for a northern site
    times = np.arange(np.datetime64("2021-03-20T00:00"), np.datetime64("2021-03-21T00:00"), np.timedelta64(1, "m"))
    r = solar_position_deg(times, 45.0, 0.0, 0.0, delta_t=69.0)
    k = int(np.argmax(r.elevation))
    assert np.degrees(r.elevation[k]) == pytest.approx(45.0, abs=0.4)
    assert np.degrees(r.azimuth[k]) == pytest.approx(180.0, abs=1.0)
    assert abs(r.hour_angle[k]) < 0.25 * DEG + 1e-9  # within one minute of transit
    path = tmp_path / "sun.json"
    r.to_json(path)
    back = S.SolarPosition.from_json(path)
    np.testing.assert_array_equal(back.azimuth, r.azimuth)
    assert back.time[0] == times[0]


def test_vectorized_quarter_year_matches_direct():
    # the hourly-node interpolation of the slow series (the fast path for long series) must not change the
    # answer; its speed is a benchmark's business, not a timed test's (it failed on a loaded machine)
    times = np.arange(np.datetime64("2021-01-01"), np.datetime64("2021-04-01"), np.timedelta64(1, "m"))
    r = solar_position_deg(times, 38.88, 121.53, 35.0, pressure_mbar=1013.0)
    idx = np.arange(0, times.size, 4999)
    direct = solar_position_deg(times[idx], 38.88, 121.53, 35.0, pressure_mbar=1013.0)
    assert np.max(np.abs(r.zenith[idx] - direct.zenith)) < 1e-12
    assert np.max(np.abs(r.azimuth[idx] - direct.azimuth)) < 1e-11


# --- CLI ---------------------------------------------------------------------------------------------------


def test_cli_sun_spa_example(capsys):
    rc = main(
        [
            "sun",
            "--lat",
            "39.742476",
            "--lon",
            "-105.1786",
            "--height",
            "1830.14",
            "--time",
            "2003-10-17T12:30:30-07:00",
            "--pressure",
            "820",
            "--temperature",
            "11",
            "--delta-t",
            "67",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["zenith_deg"] == pytest.approx(50.11162, abs=5e-6)
    assert out["azimuth_deg"] == pytest.approx(194.34024, abs=5e-6)
    assert out["elevation_deg"] == pytest.approx(90 - 50.11162, abs=5e-6)
    assert out["refraction"] is True
    assert len(out["sun_ned"]) == 3


def test_cli_sun_paper_site_and_errors(capsys):
    rc = main(
        [
            "sun",
            "--lat",
            "38.8814192",
            "--lon",
            "121.528255",
            "--height",
            "35",
            "--time",
            "2021-01-17T10:34:00+08:00",
            "--time",
            "2021-01-16T16:33:00+08:00",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert isinstance(out, list) and len(out) == 2
    assert out[0]["refraction"] is False
    # a correct ephemeris: morning sun in the south-east, ~26.6° high; evening sun low in the south-west
    assert 140 < out[0]["azimuth_deg"] < 160 and 25 < out[0]["elevation_deg"] < 28
    assert 225 < out[1]["azimuth_deg"] < 245 and 0 < out[1]["elevation_deg"] < 10
    rc = main(["sun", "--lat", "38.9", "--lon", "121.5", "--time", "2021-01-17T10:34:00"])
    err = capsys.readouterr().err
    assert rc == 2 and "no UTC offset" in err and err.count("\n") == 1
    with pytest.raises(SystemExit) as exc:  # range-checked at parsing: one argparse line
        main(["sun", "--lat", "98", "--lon", "121.5", "--time", "2021-01-17T10:34:00Z"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--lat: 98 is out of range" in err and err.count("\n") == 1
