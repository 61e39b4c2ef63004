"""Sun position by the NREL Solar Position Algorithm (SPA), vectorized over time.

Reda, I. & Andreas, A., "Solar position algorithm for solar radiation applications", Solar Energy 76 (2004)
577–589; NREL/TP-560-34302 (rev. 2008). Steps and equation numbers follow §3 of the report: Julian day (§3.1),
heliocentric L, B, R from the periodic terms (§3.2, Table A4.2), geocentric Θ, β (§3.3), nutation Δψ, Δε (§3.4,
Table A4.3), true obliquity ε (§3.5), aberration Δτ (§3.6), apparent longitude λ (§3.7), apparent sidereal time
ν (§3.8), geocentric α, δ (§3.9–3.10), local hour angle H (§3.11), parallax → topocentric α′, δ′, H′
(§3.12–3.13), topocentric elevation with the SPA refraction formula (§3.14, Eq. 42), zenith and azimuth
(§3.15–3.16), equation of time (Appendix A.1). Stated accuracy ±0.0003° for −2000..6000 (with the right ΔT).

Inputs are SI (lat/lon in rad, height in m, pressure in Pa, temperature in K); :func:`solar_position_deg`
takes degrees, mbar and °C. Times: numpy ``datetime64`` (taken as UTC), timezone-aware ``datetime`` objects or
ISO-8601 strings with a UTC offset (``"2021-01-17T10:34+08:00"``, ``"...Z"``); a time without an offset is
an error. ΔT = TT − UT1: given by the user, or the Espenak–Meeus (2006) polynomials (:func:`delta_t_espenak`);
UT1 is taken equal to UTC (|UT1 − UTC| < 0.9 s, ≤ 0.004° of hour angle).
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass, field

import numpy as np

from optinav.core.rotations import frame_name
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.units import DEG
from optinav.errors import OptinavError
from optinav.sky import _spa_tables as T

__all__ = [
    "SolarPosition",
    "solar_position",
    "solar_position_deg",
    "sun_vector",
    "utc_seconds",
    "delta_t_espenak",
    "julian_day",
]

_CHUNK = 65536  # samples per block: bounds the (terms × samples) temporaries
_UNIX_JD0 = 2440587.5  # Julian day of 1970-01-01T00:00 UTC
_J2000 = 2451545.0
#: default apparent sun radius + refraction at sunrise (deg), the SPA's ``atmos_refract``
ATMOS_REFRACT_DEG = 0.5667
_SUN_RADIUS_DEG = 0.26667


# --- time -------------------------------------------------------------------------------------------------


#: an ISO time at a leap second: (everything before the seconds, the rest after them)
_LEAP_SECOND = re.compile(r"^(.*\d{2}:\d{2}:)60((?:\.\d+)?(?:Z|[+-]\d{2}:?\d{2})?)$")


def _naive_error(what) -> OptinavError:
    return OptinavError(
        f"time {what!s} has no UTC offset",
        "give timezone-aware times, e.g. '2021-01-17T10:34:00+08:00' or '...Z' for UTC, "
        "or numpy datetime64 values in UTC",
    )


def _one_seconds(x) -> float:
    if isinstance(x, str):
        s = x.strip()
        # a leap second (23:59:60, as GNSS receivers and UTC logs write it): Python's datetime has none; the
        # second after 23:59:59 is the next day's 00:00:00 in the seconds the sun is computed from (1 s: 0.004°)
        leap = _LEAP_SECOND.match(s)
        if leap:
            s = leap.group(1) + "59" + leap.group(2)
        try:
            d = _dt.datetime.fromisoformat(s)
        except ValueError:
            raise OptinavError(
                f"time {x!r} is not an ISO 8601 date and time that optinav reads",
                "write it like 2021-01-17T10:34:00+08:00 (calendar date, not an ordinal or week date; years 1-9999)",
            ) from None
        if d.tzinfo is None or d.utcoffset() is None:
            raise _naive_error(repr(x))
        return d.timestamp() + (1.0 if leap else 0.0)
    if isinstance(x, _dt.datetime):
        if x.tzinfo is None or x.utcoffset() is None:
            raise _naive_error(x.isoformat())
        return x.timestamp()
    if isinstance(x, np.datetime64):
        return _datetime64_seconds(np.asarray(x)).item()
    if isinstance(x, _dt.date):
        raise OptinavError(
            f"time {x!s} is a date without a time of day and UTC offset",
            "give a timezone-aware datetime or an ISO string with an offset",
        )
    raise OptinavError(
        f"cannot read a time from {type(x).__name__} {x!r}",
        "pass ISO strings with an offset, aware datetimes or datetime64 (UTC)",
    )


def _datetime64_seconds(a: np.ndarray) -> np.ndarray:
    if np.any(a != a):  # NaT
        raise OptinavError("time contains NaT values", "remove the missing times")
    # µs rather than ns: datetime64[ns] ends in 1677 and 2262, inside the SPA's years -2000..6000
    us = a.astype("datetime64[us]").astype(np.int64)
    # split whole seconds and the fraction so that float rounding stays at the µs level
    sec = np.floor_divide(us, 1_000_000)
    return sec.astype(float) + (us - sec * 1_000_000) * 1e-6


def utc_seconds(time) -> np.ndarray:
    """Seconds since 1970-01-01T00:00 UTC (float64, shape of ``time``; 0-d for a scalar).

    Accepts datetime64 (UTC), aware ``datetime``/``pandas.Timestamp``, aware ``pandas.DatetimeIndex``, ISO
    strings with an offset, or sequences of these. Naive times raise :class:`OptinavError`.
    """
    if hasattr(time, "tz") and hasattr(time, "tz_convert") and not isinstance(time, _dt.datetime):
        if time.tz is None:  # naive pandas index
            raise _naive_error("index")
        return _datetime64_seconds(np.asarray(time.tz_convert("UTC").tz_localize(None), dtype="datetime64[ns]"))
    if isinstance(time, (str, _dt.datetime, np.datetime64, _dt.date)):
        return np.asarray(_one_seconds(time), dtype=float)
    a = np.asarray(time)
    if a.dtype.kind == "M":
        return _datetime64_seconds(a)
    if a.dtype.kind in "fiu":
        raise OptinavError("time is a plain number", "pass datetime64 (UTC) or ISO strings with a UTC offset")
    flat = [_one_seconds(x) for x in a.ravel().tolist()] if a.dtype.kind in "OU" else None
    if flat is None:
        raise OptinavError(f"cannot read times of dtype {a.dtype}", "pass datetime64 or ISO strings with an offset")
    return np.asarray(flat, dtype=float).reshape(a.shape)


def julian_day(unix_seconds) -> np.ndarray:
    """Julian day (UT) of seconds since the Unix epoch (SPA Eq. 4 for Gregorian dates)."""
    return np.asarray(unix_seconds, dtype=float) / 86400.0 + _UNIX_JD0


def delta_t_espenak(decimal_year) -> np.ndarray:
    """ΔT = TT − UT (s) from the Espenak & Meeus (2006) polynomials (NASA Five Millennium Canon of Solar
    Eclipses, "Polynomial expressions for Delta T"); ``decimal_year`` = year + (month − 0.5)/12.

    Within ≈1 s of the observed ΔT for 1900–2005; the 2005–2050 branch is an extrapolation that exceeds the
    observed value by ≈2–4 s in 2015–2025 (observed 2021: 69.4 s, polynomial 72.1 s; 3 s ≈ 0.0125° of hour
    angle). Pass the IERS value as ``delta_t`` when that matters.
    """
    y = np.asarray(decimal_year, dtype=float)
    out = np.empty_like(y)

    def put(mask, val):
        out[mask] = val[mask]

    u = (y - 1820.0) / 100.0
    put(y < -500, -20 + 32 * u**2)
    u = y / 100.0
    put(
        (y >= -500) & (y < 500),
        10583.6
        - 1014.41 * u
        + 33.78311 * u**2
        - 5.952053 * u**3
        - 0.1798452 * u**4
        + 0.022174192 * u**5
        + 0.0090316521 * u**6,
    )
    u = (y - 1000.0) / 100.0
    put(
        (y >= 500) & (y < 1600),
        1574.2
        - 556.01 * u
        + 71.23472 * u**2
        + 0.319781 * u**3
        - 0.8503463 * u**4
        - 0.005050998 * u**5
        + 0.0083572073 * u**6,
    )
    t = y - 1600
    put((y >= 1600) & (y < 1700), 120 - 0.9808 * t - 0.01532 * t**2 + t**3 / 7129)
    t = y - 1700
    put((y >= 1700) & (y < 1800), 8.83 + 0.1603 * t - 0.0059285 * t**2 + 0.00013336 * t**3 - t**4 / 1174000)
    t = y - 1800
    put(
        (y >= 1800) & (y < 1860),
        13.72
        - 0.332447 * t
        + 0.0068612 * t**2
        + 0.0041116 * t**3
        - 0.00037436 * t**4
        + 0.0000121272 * t**5
        - 0.0000001699 * t**6
        + 0.000000000875 * t**7,
    )
    t = y - 1860
    put(
        (y >= 1860) & (y < 1900),
        7.62 + 0.5737 * t - 0.251754 * t**2 + 0.01680668 * t**3 - 0.0004473624 * t**4 + t**5 / 233174,
    )
    t = y - 1900
    put((y >= 1900) & (y < 1920), -2.79 + 1.494119 * t - 0.0598939 * t**2 + 0.0061966 * t**3 - 0.000197 * t**4)
    t = y - 1920
    put((y >= 1920) & (y < 1941), 21.20 + 0.84493 * t - 0.076100 * t**2 + 0.0020936 * t**3)
    t = y - 1950
    put((y >= 1941) & (y < 1961), 29.07 + 0.407 * t - t**2 / 233 + t**3 / 2547)
    t = y - 1975
    put((y >= 1961) & (y < 1986), 45.45 + 1.067 * t - t**2 / 260 - t**3 / 718)
    t = y - 2000
    put(
        (y >= 1986) & (y < 2005),
        63.86 + 0.3345 * t - 0.060374 * t**2 + 0.0017275 * t**3 + 0.000651814 * t**4 + 0.00002373599 * t**5,
    )
    put((y >= 2005) & (y < 2050), 62.92 + 0.32217 * t + 0.005589 * t**2)
    u = (y - 1820.0) / 100.0
    put((y >= 2050) & (y < 2150), -20 + 32 * u**2 - 0.5628 * (2150 - y))
    put(y >= 2150, -20 + 32 * u**2)
    return out


#: the years for which the SPA is valid (Reda & Andreas 2008, abstract: -2000 to 6000), as Unix seconds
SPA_VALID_S = (
    float(np.datetime64("-2000-01-01T00:00:00", "s").astype(np.int64)),
    float(np.datetime64("6001-01-01T00:00:00", "s").astype(np.int64)),
)


def _check_valid_range(unix_seconds: np.ndarray) -> None:
    bad = (unix_seconds < SPA_VALID_S[0]) | (unix_seconds >= SPA_VALID_S[1])
    if np.any(bad):
        t = np.floor(unix_seconds[bad][0]).astype(np.int64).astype("datetime64[s]")
        raise OptinavError(
            f"time {t}Z is outside the years -2000 to 6000 for which the SPA is valid", "pass a time within -2000..6000"
        )


def _decimal_year(unix_seconds: np.ndarray) -> np.ndarray:
    d = np.floor(unix_seconds).astype(np.int64).astype("datetime64[s]")  # seconds are ample for a month index
    year = d.astype("datetime64[Y]").astype(np.int64) + 1970
    month = d.astype("datetime64[M]").astype(np.int64) % 12 + 1
    return year + (month - 0.5) / 12.0


# --- SPA core (degrees inside, as the report writes it) ---------------------------------------------------


def _series(table: np.ndarray, jme: np.ndarray) -> np.ndarray:
    # Σ A cos(B + C·JME) (SPA Eq. 9)
    return np.cos(table[:, 1:2] + table[:, 2:3] * jme[None, :]).T @ table[:, 0]


def _poly_series(tables, jme):
    acc = np.zeros_like(jme)
    for k, tab in enumerate(tables):
        acc = acc + _series(tab, jme) * jme**k
    return acc / 1e8


_L = (T._L0, T._L1, T._L2, T._L3, T._L4, T._L5)
_B = (T._B0, T._B1)
_R = (T._R0, T._R1, T._R2, T._R3, T._R4)
_NUT_Y = T._NUT_Y.astype(float)


def _slow_terms(jde: np.ndarray) -> tuple[np.ndarray, ...]:
    """Heliocentric L (rad, unwrapped), B (rad), R (AU) and nutation Δψ, Δε (deg) at Julian ephemeris days."""
    jce = (jde - _J2000) / 36525.0
    jme = jce / 10.0
    L = _poly_series(_L, jme)
    B = _poly_series(_B, jme)
    R = _poly_series(_R, jme)
    x = np.stack(
        [
            297.85036 + 445267.111480 * jce - 0.0019142 * jce**2 + jce**3 / 189474.0,
            357.52772 + 35999.050340 * jce - 0.0001603 * jce**2 - jce**3 / 300000.0,
            134.96298 + 477198.867398 * jce + 0.0086972 * jce**2 + jce**3 / 56250.0,
            93.27191 + 483202.017538 * jce - 0.0036825 * jce**2 + jce**3 / 327270.0,
            125.04452 - 1934.136261 * jce + 0.0020708 * jce**2 + jce**3 / 450000.0,
        ],
        axis=1,
    )  # (N, 5) deg (Eqs. 15–19)
    arg = np.radians(x @ _NUT_Y.T)  # (N, 63)
    abcd = T._NUT_ABCD
    dpsi = (np.sin(arg) * (abcd[:, 0] + abcd[:, 1] * jce[:, None])).sum(axis=1) / 36e6
    deps = (np.cos(arg) * (abcd[:, 2] + abcd[:, 3] * jce[:, None])).sum(axis=1) / 36e6
    return L, B, R, dpsi, deps


#: node spacing (days) of the interpolated slow terms; the fastest nutation term (period 5.6 d, amplitude
#: 0.0003″) and the annual/monthly terms of L, B, R leave cubic-interpolation errors below 1e-12 deg at 1 h
_NODE_STEP = 1.0 / 24.0


def _slow_terms_fast(jde: np.ndarray) -> tuple[np.ndarray, ...]:
    # many samples in a short span (a flight log, a year at 1 min): evaluate the series on an hourly grid
    # and interpolate with a cubic spline, which is exact to well below the SPA's own accuracy
    if jde.size < 64:
        return _slow_terms(jde)
    lo, hi = float(jde.min()), float(jde.max())
    n_nodes = int(np.ceil((hi - lo) / _NODE_STEP)) + 7
    if n_nodes * 4 > jde.size:
        return _slow_terms(jde)
    from scipy.interpolate import CubicSpline

    nodes = lo - 3 * _NODE_STEP + _NODE_STEP * np.arange(n_nodes)
    vals = np.stack(_slow_terms(nodes), axis=1)
    return tuple(CubicSpline(nodes, vals, axis=0)(jde).T)


def _spa_block(jd, delta_t, lat_deg, lon_deg, height, pressure_mbar, temp_c, refract, atmos_refract, slow):
    jde = jd + delta_t / 86400.0
    jc = (jd - _J2000) / 36525.0
    jme = (jde - _J2000) / 365250.0
    Lr, Br, R, dpsi, deps = slow
    L = np.degrees(Lr) % 360.0
    B = np.degrees(Br)

    theta = (L + 180.0) % 360.0  # geocentric longitude (Eq. 13)
    beta = -B

    U = jme / 10.0
    eps0 = 84381.448 + U * (
        -4680.93
        + U
        * (
            -1.55
            + U
            * (1999.25 + U * (-51.38 + U * (-249.67 + U * (-39.05 + U * (7.12 + U * (27.87 + U * (5.79 + U * 2.45)))))))
        )
    )  # arcsec (Eq. 24)
    eps = eps0 / 3600.0 + deps
    dtau = -20.4898 / (3600.0 * R)  # aberration (Eq. 26)
    lam = theta + dpsi + dtau

    nu0 = (280.46061837 + 360.98564736629 * (jd - _J2000) + 0.000387933 * jc**2 - jc**3 / 38710000.0) % 360.0
    nu = nu0 + dpsi * np.cos(np.radians(eps))  # apparent sidereal time at Greenwich (Eq. 29)

    lr, er, br = np.radians(lam), np.radians(eps), np.radians(beta)
    alpha = np.degrees(np.arctan2(np.sin(lr) * np.cos(er) - np.tan(br) * np.sin(er), np.cos(lr))) % 360.0
    delta = np.degrees(np.arcsin(np.sin(br) * np.cos(er) + np.cos(br) * np.sin(er) * np.sin(lr)))

    H = (nu + lon_deg - alpha) % 360.0  # local hour angle, westward (Eq. 32)

    # parallax for an observer at height above the geoid (Eqs. 33–38)
    xi = np.radians(8.794 / (3600.0 * R))
    phi = np.radians(lat_deg)
    u = np.arctan(0.99664719 * np.tan(phi))
    xx = np.cos(u) + height / 6378140.0 * np.cos(phi)
    yy = 0.99664719 * np.sin(u) + height / 6378140.0 * np.sin(phi)
    Hr, dr = np.radians(H), np.radians(delta)
    den = np.cos(dr) - xx * np.sin(xi) * np.cos(Hr)
    dalpha = np.arctan2(-xx * np.sin(xi) * np.sin(Hr), den)
    delta_p = np.arctan2((np.sin(dr) - yy * np.sin(xi)) * np.cos(dalpha), den)
    alpha_p = alpha + np.degrees(dalpha)
    Hp = Hr - dalpha  # topocentric local hour angle (rad)

    e0 = np.degrees(np.arcsin(np.sin(phi) * np.sin(delta_p) + np.cos(phi) * np.cos(delta_p) * np.cos(Hp)))
    if refract:
        de = (
            (pressure_mbar / 1010.0)
            * (283.0 / (273.0 + temp_c))
            * 1.02
            / (60.0 * np.tan(np.radians(e0 + 10.3 / (e0 + 5.11))))
        )  # Eq. 42 (Bennett/Sæmundsson form)
        de = np.where(e0 >= -(_SUN_RADIUS_DEG + atmos_refract), de, 0.0)
    else:
        de = np.zeros_like(e0)
    e = e0 + de

    gamma = np.degrees(np.arctan2(np.sin(Hp), np.cos(Hp) * np.sin(phi) - np.tan(delta_p) * np.cos(phi)))
    azimuth = (gamma + 180.0) % 360.0  # from north, eastward (Eq. 46)

    M = (
        280.4664567
        + 360007.6982779 * jme
        + 0.03032028 * jme**2
        + jme**3 / 49931.0
        - jme**4 / 15300.0
        - jme**5 / 2000000.0
    ) % 360.0
    E = 4.0 * (M - 0.0057183 - alpha + dpsi * np.cos(er))  # minutes (Eq. A1)
    E = E - 1440.0 * np.round(E / 1440.0)  # keep |E| ≤ 20 min whatever the wrap of α

    H_geo = (H + 180.0) % 360.0 - 180.0
    Hp_deg = (np.degrees(Hp) + 180.0) % 360.0 - 180.0
    return dict(
        elevation=e,
        elevation_geometric=e0,
        azimuth=azimuth,
        declination=delta,
        declination_topocentric=np.degrees(delta_p),
        right_ascension=alpha,
        right_ascension_topocentric=alpha_p % 360.0,
        hour_angle=H_geo,
        hour_angle_topocentric=Hp_deg,
        equation_of_time=E * 60.0,
        earth_sun_distance=R,
        ecliptic_longitude=lam,
        nutation_longitude=dpsi,
        nutation_obliquity=deps,
        obliquity=eps,
    )


# --- result -----------------------------------------------------------------------------------------------


def _rad(unit="rad"):
    return field(metadata={"unit": unit})


@dataclass
class SolarPosition(Result):
    """Topocentric sun position of the NREL SPA at the times ``unix_time``.

    Angles in rad. ``azimuth`` is measured from north towards east, in [0, 2π). ``elevation`` is the apparent
    (refracted) elevation when a pressure was given (``refraction`` True), otherwise equal to
    ``elevation_geometric`` (topocentric, with parallax, without refraction); ``zenith = π/2 − elevation``.
    ``declination``, ``right_ascension`` and ``hour_angle`` are geocentric apparent values (what an almanac
    lists); the ``*_topocentric`` ones include parallax. Hour angles in (−π, π], positive west of the
    meridian (afternoon). ``equation_of_time`` = apparent − mean solar time (s). ``delta_t`` = TT − UT1 (s).
    Version 2 renamed ``height`` to ``height_m`` (version-1 files still load).
    """

    SCHEMA = "optinav.solar_position"
    VERSION = 2

    unix_time: np.ndarray = _rad("s")
    lat: float = _rad()
    lon: float = _rad()
    height_m: float = _rad("m")
    zenith: np.ndarray = _rad()
    azimuth: np.ndarray = _rad()
    elevation: np.ndarray = _rad()
    elevation_geometric: np.ndarray = _rad()
    declination: np.ndarray = _rad()
    declination_topocentric: np.ndarray = _rad()
    right_ascension: np.ndarray = _rad()
    hour_angle: np.ndarray = _rad()
    hour_angle_topocentric: np.ndarray = _rad()
    equation_of_time: np.ndarray = _rad("s")
    earth_sun_distance: np.ndarray = _rad("AU")
    delta_t: np.ndarray = _rad("s")
    refraction: bool = field(default=False, metadata={"unit": "-"})
    pressure: float = field(default=float("nan"), metadata={"unit": "Pa"})
    temperature: float = field(default=float("nan"), metadata={"unit": "K"})

    def sun_vector(self, frame: str = "ned") -> np.ndarray:
        """Unit vector towards the sun in the local-level frame ``"ned"`` or ``"enu"``, shape (..., 3)."""
        return sun_vector(self.azimuth, self.elevation, frame)

    @property
    def time(self) -> np.ndarray:
        """The times as datetime64[us] (UTC; µs, not ns, so that years -2000..6000 fit)."""
        return np.round(np.asarray(self.unix_time) * 1e6).astype(np.int64).astype("datetime64[us]")


register_legacy(
    SolarPosition, SolarPosition.SCHEMA, 1, lambda d: nested_kwargs(SolarPosition, d, {"height": "height_m"})
)  # old names


def sun_vector(azimuth, elevation, frame: str = "ned") -> np.ndarray:
    """Unit vector to a direction of azimuth (rad, from north towards east) and elevation (rad) in the
    navigation frame ``"ned"`` (north, east, down) or ``"enu"`` (east, north, up); shape (..., 3)."""
    az, el = np.broadcast_arrays(np.asarray(azimuth, dtype=float), np.asarray(elevation, dtype=float))
    n, e, u = np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)
    if frame_name(frame) == "ned":
        return np.stack([n, e, -u], axis=-1)
    return np.stack([e, n, u], axis=-1)


def _scalar(x, name, lo=-np.inf, hi=np.inf) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise OptinavError(f"{name} must be a number, got {x!r}", f"pass {name} as a number") from None
    if not np.isfinite(v) or not lo <= v <= hi:
        raise OptinavError(f"{name} = {v!r} is outside [{lo}, {hi}]", f"pass a valid {name}")
    return v


def solar_position(
    time,
    lat,
    lon,
    height_m=0.0,
    *,
    pressure=None,
    temperature=285.15,
    delta_t=None,
    atmos_refract=ATMOS_REFRACT_DEG * DEG,
) -> SolarPosition:
    """Topocentric sun position (NREL SPA) for an observer at geodetic ``lat``, ``lon`` (rad, east positive)
    and ``height_m`` (m; the SPA uses it for parallax only).

    time: see :func:`utc_seconds` (any shape; outputs have that shape). pressure (Pa) and temperature (K):
    when ``pressure`` is given the elevation is corrected for refraction by SPA Eq. 42 while the geometric
    centre of the sun is above −(sun radius + ``atmos_refract``); ``pressure=None`` gives the geometric
    topocentric position. delta_t (s): TT − UT1, scalar or per time; default :func:`delta_t_espenak`.
    """
    lat = _scalar(lat, "lat", -np.pi / 2, np.pi / 2)
    lon = _scalar(lon, "lon", -2 * np.pi, 2 * np.pi)
    height = _scalar(height_m, "height_m", -1e4, 1e7)
    refract = pressure is not None
    p_mbar, t_c = np.nan, np.nan
    if refract:
        p_mbar = _scalar(pressure, "pressure", 0.0, 2e5) / 100.0
        t_c = _scalar(temperature, "temperature", 150.0, 400.0) - 273.15
    atmos = _scalar(atmos_refract, "atmos_refract", 0.0, 0.1) / DEG
    secs = utc_seconds(time)
    shape = secs.shape
    s = secs.ravel()
    _check_valid_range(s)
    if delta_t is None:
        dts = delta_t_espenak(_decimal_year(s))
    else:
        try:
            dts = (
                np.broadcast_to(np.asarray(delta_t, dtype=float), shape).ravel()
                if np.ndim(delta_t)
                else np.full(s.shape, _scalar(delta_t, "delta_t", -1e6, 1e6))
            )
        except (ValueError, TypeError):
            raise OptinavError(
                f"delta_t has shape {np.shape(delta_t)} for times of shape {shape}", "pass one ΔT (s) or one per time"
            ) from None
        if not np.all(np.isfinite(dts)):
            raise OptinavError("delta_t contains NaN or infinite values", "pass finite ΔT in s")
    jd = julian_day(s)
    parts = []
    if s.size:
        slow = _slow_terms_fast(jd + dts / 86400.0)
        for i in range(0, s.size, _CHUNK):
            sl = slice(i, i + _CHUNK)
            parts.append(
                _spa_block(
                    jd[sl],
                    dts[sl],
                    lat / DEG,
                    lon / DEG,
                    height,
                    p_mbar,
                    t_c,
                    refract,
                    atmos,
                    tuple(v[sl] for v in slow),
                )
            )
    keys = (
        "elevation",
        "elevation_geometric",
        "azimuth",
        "declination",
        "declination_topocentric",
        "right_ascension",
        "hour_angle",
        "hour_angle_topocentric",
        "equation_of_time",
        "earth_sun_distance",
    )
    out = {}
    for k in keys:
        v = np.concatenate([p[k] for p in parts]) if parts else np.empty(0)
        out[k] = v.reshape(shape)
    deg = {k: out[k] * DEG for k in keys if k not in ("equation_of_time", "earth_sun_distance")}
    el = deg["elevation"]
    return SolarPosition(
        unix_time=secs,
        lat=lat,
        lon=lon,
        height_m=height,
        zenith=np.pi / 2 - el,
        azimuth=deg["azimuth"],
        elevation=el,
        elevation_geometric=deg["elevation_geometric"],
        declination=deg["declination"],
        declination_topocentric=deg["declination_topocentric"],
        right_ascension=deg["right_ascension"],
        hour_angle=deg["hour_angle"],
        hour_angle_topocentric=deg["hour_angle_topocentric"],
        equation_of_time=out["equation_of_time"],
        earth_sun_distance=out["earth_sun_distance"],
        delta_t=dts.reshape(shape),
        refraction=refract,
        pressure=p_mbar * 100.0 if refract else float("nan"),
        temperature=t_c + 273.15 if refract else float("nan"),
    )


def solar_position_deg(
    time,
    lat_deg,
    lon_deg,
    height_m=0.0,
    *,
    pressure_mbar=None,
    temperature_c=12.0,
    delta_t=None,
    atmos_refract_deg=ATMOS_REFRACT_DEG,
) -> SolarPosition:
    """:func:`solar_position` with latitude/longitude in degrees, pressure in mbar (hPa) and temperature in
    °C: the NREL SPA report's own units, for checking against it and for I/O (the CLI's ``optinav sun``).
    Library code calls :func:`solar_position` (SI). The result is in SI (rad) like :func:`solar_position`."""
    p = None if pressure_mbar is None else _scalar(pressure_mbar, "pressure_mbar", 0.0, 2000.0) * 100.0
    t = _scalar(temperature_c, "temperature_c", -120.0, 120.0) + 273.15
    lat = _scalar(lat_deg, "lat_deg", -90, 90) * DEG
    return solar_position(
        time,
        lat,
        _scalar(lon_deg, "lon_deg", -360, 360) * DEG,
        height_m,
        pressure=p,
        temperature=t,
        delta_t=delta_t,
        atmos_refract=_scalar(atmos_refract_deg, "atmos_refract_deg", 0, 5) * DEG,
    )
