"""Earth model: constant sets, normal gravity, Earth and transport rates, radii of curvature.

Navigation frame vectors are returned in ``frame="ned"`` (north, east, down; the default) or ``"enu"``.
Latitude ``lat`` in rad, height ``h`` in m above the ellipsoid, velocities in m/s in the navigation frame.

Two constant sets:

* :data:`WGS84` — NIMA TR8350.2 (2000): a = 6378137 m, f = 1/298.257223563, ω_ie = 7.292115e-5 rad/s,
  GM = 3.986004418e14 m³/s²; Somigliana normal gravity with the second-order free-air height term
  (TR8350.2 eq. 4-1 and 4-3).
* :data:`PSINS` — the constants of the PSINS toolbox ``glv`` (Yan Gongmin): f = 1/298.257,
  ω_ie = 7.2921151467e-5 rad/s, g0 = 9.7803267715 m/s², gravity
  ``g = g0 (1 + 5.27094e-3 sin²L + 2.32718e-5 sin⁴L) − 3.086e-6 h``, so results can be compared with PSINS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optinav.core.rotations import DEFAULT_FRAME, frame_name
from optinav.errors import OptinavError


@dataclass(frozen=True)
class EarthConstants:
    """One selectable set of Earth constants (SI)."""

    name: str
    a: float  #: m, equatorial radius
    f: float  #: flattening
    omega_ie: float  #: rad/s, Earth rotation rate
    gm: float  #: m³/s²
    gravity_model: str  #: "somigliana" or "psins"
    g_e: float  #: m/s², normal gravity at the equator
    k_somigliana: float = 0.0  #: Somigliana constant (b γ_p)/(a γ_e) − 1

    @property
    def e2(self) -> float:
        """First eccentricity squared."""
        return self.f * (2.0 - self.f)

    @property
    def b(self) -> float:
        """Semi-minor axis, m."""
        return self.a * (1.0 - self.f)


WGS84 = EarthConstants(
    "WGS84",
    a=6378137.0,
    f=1.0 / 298.257223563,
    omega_ie=7.292115e-5,
    gm=3.986004418e14,
    gravity_model="somigliana",
    g_e=9.7803253359,
    k_somigliana=0.00193185265241,
)
PSINS = EarthConstants(
    "PSINS",
    a=6378137.0,
    f=1.0 / 298.257,
    omega_ie=7.2921151467e-5,
    gm=3.986004418e14,
    gravity_model="psins",
    g_e=9.7803267715,
)
CONSTANT_SETS = {"wgs84": WGS84, "psins": PSINS}


def constants(name: str | EarthConstants = "wgs84") -> EarthConstants:
    """Look up an Earth constant set by name, or pass one through.

    Parameters
    ----------
    name : str or EarthConstants
        ``"wgs84"`` or ``"psins"``, or a set.

    Returns
    -------
    EarthConstants
        The set (SI).
    """
    if isinstance(name, EarthConstants):
        return name
    try:
        return CONSTANT_SETS[str(name).lower()]
    except KeyError:
        raise OptinavError(f"unknown Earth constant set {name!r}", "use 'wgs84' or 'psins'") from None


def radii(lat, height_m=0.0, earth="wgs84") -> tuple[np.ndarray, np.ndarray]:
    """Meridian (R_M) and prime-vertical (R_N) radii of curvature, plus the height.

    Parameters
    ----------
    lat : float or array
        Geodetic latitude [rad].
    height_m : float or array
        Height above the ellipsoid [m].
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    R_M, R_N : ndarray
        R_M + h and R_N + h [m].
    """
    h = height_m
    e = constants(earth)
    s2 = np.sin(np.asarray(lat, dtype=float)) ** 2
    w = np.sqrt(1.0 - e.e2 * s2)
    rn = e.a / w
    rm = e.a * (1.0 - e.e2) / w**3
    return rm + h, rn + h


def gravity(lat, height_m=0.0, earth="wgs84") -> np.ndarray:
    """Magnitude of normal gravity (includes the centrifugal term).

    Parameters
    ----------
    lat : float or array
        Geodetic latitude [rad].
    height_m : float or array
        Height above the ellipsoid [m].
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    ndarray
        g [m/s^2].
    """
    e = constants(earth)
    lat = np.asarray(lat, dtype=float)
    h = np.asarray(height_m, dtype=float)
    s2 = np.sin(lat) ** 2
    if e.gravity_model == "psins":
        return e.g_e * (1.0 + 5.27094e-3 * s2 + 2.32718e-5 * s2**2) - 3.086e-6 * h
    g0 = e.g_e * (1.0 + e.k_somigliana * s2) / np.sqrt(1.0 - e.e2 * s2)
    m = e.omega_ie**2 * e.a**2 * e.b / e.gm
    return g0 * (1.0 - 2.0 / e.a * (1.0 + e.f + m - 2.0 * e.f * s2) * h + 3.0 / e.a**2 * h**2)


def gravity_vector(lat, height_m=0.0, frame=DEFAULT_FRAME, earth="wgs84") -> np.ndarray:
    """Gravity vector g^n: ``[0, 0, −g]`` in ENU, ``[0, 0, g]`` in NED.

    Parameters
    ----------
    lat : float or array
        Geodetic latitude [rad].
    height_m : float or array
        Height above the ellipsoid [m].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (..., 3) ndarray
        g^n [m/s^2].
    """
    g = gravity(lat, height_m, earth)
    z = np.zeros_like(g)
    sign = -1.0 if frame_name(frame) == "enu" else 1.0
    return np.stack([z, z, sign * g], -1)


def earth_rate(lat, frame=DEFAULT_FRAME, earth="wgs84") -> np.ndarray:
    """Earth rate ω_ie^n: ENU ``[0, ω cos L, ω sin L]``; NED ``[ω cos L, 0, −ω sin L]``.

    Parameters
    ----------
    lat : float or array
        Geodetic latitude L [rad].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (..., 3) ndarray
        ω_ie^n [rad/s].
    """
    w = constants(earth).omega_ie
    lat = np.asarray(lat, dtype=float)
    c, s, z = w * np.cos(lat), w * np.sin(lat), np.zeros_like(lat)
    if frame_name(frame) == "enu":
        return np.stack([z, c, s], -1)
    return np.stack([c, z, -s], -1)


def transport_rate(lat, height_m, v_n, frame=DEFAULT_FRAME, earth="wgs84") -> np.ndarray:
    """Transport rate ω_en^n for a navigation-frame velocity.

    Parameters
    ----------
    lat : float or array
        Geodetic latitude [rad].
    height_m : float or array
        Height above the ellipsoid [m].
    v_n : (..., 3) array
        Velocity in the navigation frame [m/s].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (..., 3) ndarray
        ω_en^n [rad/s].
    """
    v = np.asarray(v_n, dtype=float)
    rm, rn = radii(lat, height_m, earth)
    t = np.tan(np.asarray(lat, dtype=float))
    if frame_name(frame) == "enu":
        ve, vn = v[..., 0], v[..., 1]
        return np.stack([-vn / rm, ve / rn, ve * t / rn], -1)
    vn, ve = v[..., 0], v[..., 1]
    return np.stack([ve / rn, -vn / rm, -ve * t / rn], -1)


def position_rate(lat, height_m, v_n, frame=DEFAULT_FRAME, earth="wgs84") -> np.ndarray:
    """Time derivative of ``[lat, lon, height_m]`` for a navigation-frame velocity.

    Parameters
    ----------
    lat, height_m, v_n, frame, earth
        As :func:`transport_rate` [rad, m, m/s].

    Returns
    -------
    (..., 3) ndarray
        [rad/s, rad/s, m/s].
    """
    v = np.asarray(v_n, dtype=float)
    rm, rn = radii(lat, height_m, earth)
    if frame_name(frame) == "enu":
        ve, vn, vu = v[..., 0], v[..., 1], v[..., 2]
    else:
        vn, ve, vu = v[..., 0], v[..., 1], -v[..., 2]
    return np.stack([vn / rm, ve / (rn * np.cos(lat)), vu], -1)


def dcm_e_to_n(lat, lon, frame=DEFAULT_FRAME) -> np.ndarray:
    """``C_e^n`` from ECEF to the local navigation frame.

    Parameters
    ----------
    lat, lon : float or array
        Geodetic latitude and longitude [rad].
    frame : str
        ``"enu"`` or ``"ned"``.

    Returns
    -------
    (..., 3, 3) ndarray
        ``C_e^n`` [-].
    """
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(sl)
    east = np.stack([-so, co, z], -1)
    north = np.stack([-sl * co, -sl * so, cl], -1)
    up = np.stack([cl * co, cl * so, sl], -1)
    if frame_name(frame) == "enu":
        return np.stack([east, north, up], -2)
    return np.stack([north, east, -up], -2)


def geodetic_to_ecef(lat, lon, height_m, earth="wgs84") -> np.ndarray:
    """Geodetic position → ECEF position.

    Parameters
    ----------
    lat, lon : float or array
        Geodetic latitude and longitude [rad].
    height_m : float or array
        Height above the ellipsoid [m].
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (..., 3) ndarray
        ECEF position [m].
    """
    e = constants(earth)
    h = height_m
    lat = np.asarray(lat, dtype=float)
    _, rn = radii(lat, 0.0, e)
    cl = np.cos(lat)
    return np.stack([(rn + h) * cl * np.cos(lon), (rn + h) * cl * np.sin(lon), (rn * (1 - e.e2) + h) * np.sin(lat)], -1)


def ecef_to_geodetic(r, earth="wgs84") -> np.ndarray:
    """ECEF position → geodetic ``[lat, lon, height]``; fixed-point iteration on latitude.

    Parameters
    ----------
    r : (..., 3) array
        ECEF position [m].
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (..., 3) ndarray
        [lat, lon, height] [rad, rad, m].
    """
    r = np.asarray(r, dtype=float)
    e = constants(earth)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    with np.errstate(divide="ignore", invalid="ignore"):  # np.where evaluates the branch it then discards
        return _ecef_to_geodetic_iter(x, y, z, p, e)


def _ecef_to_geodetic_iter(x, y, z, p, e):
    lat = np.arctan2(z, p * (1.0 - e.e2))
    h = np.zeros_like(p)
    for _ in range(8):  # converges to < 1e-15 rad within ~4 iterations near the surface
        n = e.a / np.sqrt(1.0 - e.e2 * np.sin(lat) ** 2)
        h = np.where(np.abs(np.cos(lat)) > 1e-3, p / np.cos(lat) - n, z / np.sin(lat) - n * (1 - e.e2))
        lat = np.arctan2(z, p * (1.0 - e.e2 * n / (n + h)))
    n = e.a / np.sqrt(1.0 - e.e2 * np.sin(lat) ** 2)
    h = np.where(np.abs(np.cos(lat)) > 1e-3, p / np.cos(lat) - n, z / np.sin(lat) - n * (1 - e.e2))
    return np.stack([lat, np.arctan2(y, x), h], -1)
