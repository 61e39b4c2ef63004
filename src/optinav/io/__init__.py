"""Data files in and out: tables (CSV/TSV/text, NPZ, HDF5, MATLAB) and IMU logs.

``read_table`` returns named numpy arrays; ``read_imu`` interprets them as an :class:`ImuLog` (time in s,
accelerometer in m/s² or counts, gyroscope in rad/s or counts); ``write_imu`` writes a log back as CSV/TSV/text,
NPZ, HDF5 or MAT. ``iter_imu``/``iter_table`` read logs in blocks (text, NPY, NPZ, HDF5, MATLAB v7.3, Parquet; memory
independent of their length) and
``open_imu_writer`` writes logs block by block; ``read_mag`` reads a magnetometer on its own time stamps, which
:class:`MagSamples` puts on a log's rows. A phone app's export (Sensor Logger, phyphox; its zip or folder) is read
as one log (:mod:`optinav.io.phone`); ROS bags (:mod:`optinav.io.rosbag`) and PX4 flight logs
(:mod:`optinav.io.ulog`) as they are recorded. Formats, column aliases and units: docs/file-formats.md.
"""

from optinav.io.imu import (
    ALIASES,
    STANDARD_NAMES,
    ImuLog,
    MagSamples,
    iter_imu,
    open_imu_writer,
    raw_units,
    read_imu,
    read_mag,
    write_imu,
)
from optinav.io.readers import iter_table, read_table

__all__ = [
    "read_table",
    "read_imu",
    "write_imu",
    "iter_table",
    "iter_imu",
    "open_imu_writer",
    "ImuLog",
    "STANDARD_NAMES",
    "ALIASES",
    "raw_units",
    "read_mag",
    "MagSamples",
]
