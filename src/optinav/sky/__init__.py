"""Sky models for polarization navigation: sun position (NREL SPA, :mod:`optinav.sky.sun`) and Rayleigh/Berry
sky polarization with a point-source polarization sensor (:mod:`optinav.sky.polarization`).
See docs/methods/sky.md."""

from optinav.sky.polarization import (
    DEFAULT_D_MAX,
    DEFAULT_NEUTRAL_DISTANCE,
    PointSensor,
    PolarizationReading,
    SkyPolarization,
    aop_in_sensor,
    rayleigh_dop,
    scattering_angle,
    sky_polarization,
    zenith_aop,
)
from optinav.sky.sun import (
    SolarPosition,
    delta_t_espenak,
    julian_day,
    solar_position,
    solar_position_deg,
    sun_vector,
    utc_seconds,
)

__all__ = [
    "DEFAULT_D_MAX",
    "DEFAULT_NEUTRAL_DISTANCE",
    "PointSensor",
    "PolarizationReading",
    "SkyPolarization",
    "aop_in_sensor",
    "rayleigh_dop",
    "scattering_angle",
    "sky_polarization",
    "zenith_aop",
    "SolarPosition",
    "delta_t_espenak",
    "julian_day",
    "solar_position",
    "solar_position_deg",
    "sun_vector",
    "utc_seconds",
]
