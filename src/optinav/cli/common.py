"""Options shared by the data-reading commands (one spelling everywhere)."""

from __future__ import annotations

import numpy as np

from optinav.core.units import factor


def add_input_options(p, *, gyro: bool = True) -> None:
    """--columns, --acc-unit, --gyro-unit, --time-unit, --rate, --delimiter, --datasets."""
    p.add_argument("--columns", help="names of the file's columns in order (t,ax,ay,az,gx,gy,gz; '_' skips one), "
                                     "or std=name pairs for named columns/arrays; default: recognised headers")
    p.add_argument("--acc-unit", choices=["counts", "g", "m/s^2"], help="accelerometer unit in the file "
                                                                          "(default: as declared, else m/s^2)")
    if gyro:
        p.add_argument("--gyro-unit", choices=["counts", "deg/s", "rad/s"],
                       help="gyroscope unit in the file (default: as declared, else rad/s)")
    p.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column (default s)")
    p.add_argument("--rate", type=float, help="sample rate in Hz for files without a time column")
    p.add_argument("--delimiter", help="column delimiter of text files (default: detected)")
    p.add_argument("--datasets", help="HDF5/MAT/NPZ names as std=name pairs, e.g. t=imu/time,acc=imu/acc")


def parse_pairs(text: str | None) -> dict | None:
    if not text:
        return None
    out = {}
    for item in text.split(","):
        k, _, v = item.partition("=")
        if not v:
            from optinav.errors import OptinavError
            raise OptinavError(f"--datasets entry {item!r} is not std=name", "write e.g. t=imu/time,acc=imu/acc")
        out[k.strip()] = v.strip()
    return out


def raw_units(log, kind: str) -> tuple[np.ndarray, str]:
    """The log's values in the file's own unit (the unit a calibration's K and b are expressed in).

    Readers convert g and deg/s to SI; a calibration is stated in the user's raw unit, so convert back."""
    values = log.acc if kind == "acc" else log.gyro
    unit = log.acc_unit if kind == "acc" else log.gyro_unit
    file_unit = (log.acc_input_unit if kind == "acc" else log.gyro_input_unit) or unit
    if file_unit == unit or values is None:
        return values, unit
    return values / factor(file_unit), file_unit
