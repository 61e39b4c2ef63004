"""``optinav sun``: topocentric sun position (NREL SPA) for a place and time, printed as JSON."""

from __future__ import annotations

import argparse
import json
import math
import textwrap

from optinav.cli.common import HEIGHT, LATITUDE, LONGITUDE, number
from optinav.errors import OptinavError


def register(sub) -> None:
    p = sub.add_parser(
        "sun",
        help="sun position (NREL SPA) at a place and time, as JSON",
        description=textwrap.dedent("""\
            Topocentric sun position by the NREL Solar Position Algorithm (Reda & Andreas 2004/2008).
            Prints JSON with zenith_deg, azimuth_deg (from north towards east, 0..360), elevation_deg,
            elevation_geometric_deg, declination_deg and hour_angle_deg (geocentric apparent; hour angle
            positive west, i.e. afternoon), equation_of_time_min, earth_sun_distance_au, delta_t_s and the sun
            unit vector in NED and ENU. elevation_deg is the apparent (refracted) elevation when --pressure
            is given, else the geometric one. --time needs a UTC offset (+08:00, -07:00 or Z); repeat
            --time for several instants (a JSON list is printed then)."""),
        epilog=textwrap.dedent("""\
            examples:
              optinav sun --lat 38.8814192 --lon 121.528255 --height 35 --time 2021-01-17T10:34:00+08:00
              optinav sun --lat 39.742476 --lon -105.1786 --height 1830.14 \\
                  --time 2003-10-17T12:30:30-07:00 --pressure 820 --temperature 11 --delta-t 67
                  (the SPA report's example: zenith 50.11162, azimuth 194.34024)
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--lat", type=LATITUDE, required=True, metavar="DEG", help="geodetic latitude, deg (north +)")
    p.add_argument("--lon", type=LONGITUDE, required=True, metavar="DEG", help="longitude, deg (east +)")
    p.add_argument(
        "--height", dest="height_m", type=HEIGHT, default=0.0, metavar="M", help="height, m (parallax; default 0)"
    )
    p.add_argument(
        "--time",
        action="append",
        required=True,
        metavar="ISO8601",
        help="time with UTC offset, e.g. 2021-01-17T10:34:00+08:00 (repeatable)",
    )
    p.add_argument(
        "--pressure",
        type=number(0.0, 2000.0, lo_open=True, what="a pressure in mbar"),
        metavar="MBAR",
        help="air pressure, mbar (hPa); enables the refraction correction",
    )
    p.add_argument(
        "--temperature",
        type=number(-100.0, 100.0, what="a temperature in deg C"),
        default=12.0,
        metavar="C",
        help="air temperature, deg C, for refraction (default 12)",
    )
    p.add_argument(
        "--delta-t",
        type=number(-1e6, 1e6, what="TT - UT1 in s"),
        default=None,
        metavar="S",
        help="TT - UT1 in s (default: Espenak-Meeus polynomial)",
    )
    p.set_defaults(func=run)


def _row(r, i, times, ned, enu) -> dict:
    def deg(a):
        return round(math.degrees(float(a[i])), 7)

    return {
        "time_utc": str(times[i].astype("datetime64[ms]")) + "Z",
        "zenith_deg": deg(r.zenith),
        "azimuth_deg": deg(r.azimuth),
        "elevation_deg": deg(r.elevation),
        "elevation_geometric_deg": deg(r.elevation_geometric),
        "declination_deg": deg(r.declination),
        "hour_angle_deg": deg(r.hour_angle),
        "right_ascension_deg": deg(r.right_ascension),
        "equation_of_time_min": round(float(r.equation_of_time[i]) / 60.0, 6),
        "earth_sun_distance_au": round(float(r.earth_sun_distance[i]), 10),
        "delta_t_s": round(float(r.delta_t[i]), 3),
        "refraction": bool(r.refraction),
        "sun_ned": [round(float(v), 9) for v in ned[i]],
        "sun_enu": [round(float(v), 9) for v in enu[i]],
    }


def run(args) -> int:
    import numpy as np

    from optinav.sky.sun import solar_position_deg

    if args.pressure is None and args.temperature != 12.0:
        raise OptinavError("--temperature without --pressure has no effect", "add --pressure MBAR for refraction")
    r = solar_position_deg(
        np.asarray(args.time, dtype=object),
        args.lat,
        args.lon,
        args.height_m,
        pressure_mbar=args.pressure,
        temperature_c=args.temperature,
        delta_t=args.delta_t,
    )
    times, ned, enu = r.time, r.sun_vector("ned"), r.sun_vector("enu")  # whole arrays: once, not per row
    rows = [_row(r, i, times, ned, enu) for i in range(len(args.time))]
    out = {"lat_deg": args.lat, "lon_deg": args.lon, "height_m": args.height_m}
    data = [{**out, **row} for row in rows]
    print(json.dumps(data[0] if len(data) == 1 else data, indent=2))
    return 0
