"""Engineering units at the I/O boundary; everything inside optinav is SI (rad, m/s², s).

``to_si(value, unit)`` and ``from_si(value, unit)`` convert with one table, :data:`UNITS`. The ``g`` used
by μg, mg and g-based units is standard gravity :data:`G_STANDARD` (9.80665 m/s², ISO 80000-3), not the
local gravity, so a datasheet value converts the same everywhere.
"""

from __future__ import annotations

import math

import numpy as np

from optinav.errors import OptinavError

G_STANDARD = 9.80665  #: m/s², standard gravity for unit conversion
#: an accelerometer log that reads about 0 at rest in every unit: the cause, and what to do (one shared wording)
GRAVITY_OUT = "gravity taken out? (a phone's linear or user acceleration reads about 0 at rest)"
GRAVITY_OUT_REMEDY = (
    "read the accelerometer with gravity (phyphox: Acceleration with g; Sensor Logger: TotalAcceleration.csv or "
    "AccelerometerUncalibrated.csv); no --acc-unit makes up for it"
)
DEG = math.pi / 180.0  #: rad per degree
ARCMIN = DEG / 60.0
ARCSEC = DEG / 3600.0
HOUR = 3600.0

#: unit name → factor such that value_SI = value × factor; the SI unit of each quantity is in the comment.
UNITS: dict[str, float] = {
    # angle → rad
    "rad": 1.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "deg": DEG,
    "arcmin": ARCMIN,
    "arcsec": ARCSEC,
    # angular rate → rad/s
    "rad/s": 1.0,
    "deg/s": DEG,
    "mdps": DEG * 1e-3,  # millidegrees per second (ST MEMS drivers)
    "deg/h": DEG / HOUR,
    "deg/hr": DEG / HOUR,
    "rpm": 2 * math.pi / 60.0,
    # angular random walk → rad/√s
    "rad/sqrt(s)": 1.0,
    "deg/sqrt(h)": DEG / 60.0,
    "deg/sqrt(hr)": DEG / 60.0,
    "deg/s/sqrt(Hz)": DEG,
    "deg/h/sqrt(Hz)": DEG / HOUR,
    "rad/s/sqrt(Hz)": 1.0,
    # rate random walk → rad/s/√s
    "deg/h/sqrt(h)": DEG / HOUR / 60.0,
    "deg/h^1.5": DEG / HOUR / 60.0,
    "rad/s/sqrt(s)": 1.0,
    # acceleration → m/s²
    "m/s^2": 1.0,
    "g": G_STANDARD,
    "mg": 1e-3 * G_STANDARD,
    "ug": 1e-6 * G_STANDARD,
    # velocity random walk → m/s/√s
    "m/s/sqrt(s)": 1.0,
    "m/s^2/sqrt(Hz)": 1.0,
    "ug/sqrt(Hz)": 1e-6 * G_STANDARD,
    "mg/sqrt(Hz)": 1e-3 * G_STANDARD,
    "m/s/sqrt(h)": 1.0 / 60.0,
    # acceleration random walk → m/s²/√s
    "m/s^2/sqrt(s)": 1.0,
    "ug/sqrt(s)": 1e-6 * G_STANDARD,
    # dimensionless
    "1": 1.0,
    "ppm": 1e-6,
    "%": 1e-2,
    # time, frequency, length
    "s": 1.0,
    "ms": 1e-3,
    "min": 60.0,
    "h": HOUR,
    "Hz": 1.0,
    "m": 1.0,
    "mm": 1e-3,
    # gyro g-sensitivity → rad/s per m/s²
    "rad/s/(m/s^2)": 1.0,
    "deg/h/g": DEG / HOUR / G_STANDARD,
    "deg/s/g": DEG / G_STANDARD,
}

_ALIASES = {
    "μg": "ug",
    "µg": "ug",
    "°": "deg",
    "°/h": "deg/h",
    "°/s": "deg/s",
    "mdeg/s": "mdps",
    "°/√h": "deg/sqrt(h)",
    "μg/√Hz": "ug/sqrt(Hz)",
    "µg/√Hz": "ug/sqrt(Hz)",
    "m/s2": "m/s^2",
    "m/s²": "m/s^2",
    "dph": "deg/h",
    "dpsh": "deg/sqrt(h)",
    "ugpsHz": "ug/sqrt(Hz)",
}


def factor(unit: str) -> float:
    """SI factor of a unit (see :data:`UNITS`).

    Parameters
    ----------
    unit : str
        Unit name or alias.

    Returns
    -------
    float
        SI value of one ``unit`` [SI unit per unit].
    """
    key = _ALIASES.get(unit, unit)
    try:
        return UNITS[key]
    except KeyError:
        raise OptinavError(f"unknown unit {unit!r}", f"use one of: {', '.join(sorted(UNITS))}") from None


def to_si(value, unit: str):
    """Convert a value given in ``unit`` to SI.

    Parameters
    ----------
    value : float or array
        Value [unit].
    unit : str
        Its unit (see :data:`UNITS`).

    Returns
    -------
    float or ndarray
        The value [SI].
    """
    return np.asarray(value, dtype=float) * factor(unit) if not np.isscalar(value) else float(value) * factor(unit)


def from_si(value, unit: str):
    """Convert an SI value to ``unit``.

    Parameters
    ----------
    value : float or array
        Value [SI].
    unit : str
        Target unit (see :data:`UNITS`).

    Returns
    -------
    float or ndarray
        The value [unit].
    """
    return np.asarray(value, dtype=float) / factor(unit) if not np.isscalar(value) else float(value) / factor(unit)
