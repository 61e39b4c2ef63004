"""One turntable recording of a gyro-free accelerometer array, as :mod:`optinav.batch` runs it (registry:
``gfimu``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from optinav.errors import OptinavError
from optinav.gfimu.array import AccelerometerArray, builtin, identifiability
from optinav.gfimu.turntable import TurntableCalibration, TurntableData, calibrate


@dataclasses.dataclass
class GfimuOptions:
    """The options of ``optinav calibrate gfimu``: the nominal array (``config`` file or ``builtin`` name),
    ``method`` ("lm" or "closed-form"), ``offset`` ("zero", "estimate" or the measured (x, y, z) in m),
    ``rate_unit`` of the table_rate column ("rad/s" or "deg/s"), ``noise`` accelerometer std in m/s² (None:
    from the data)."""

    config: str | None = None
    builtin: str | None = None
    method: str = "lm"
    offset: str | tuple = "zero"
    rate_unit: str = "rad/s"
    noise: float | None = None

    def array(self) -> AccelerometerArray:
        """The nominal array: the configuration file or the built-in one."""
        if self.config and self.builtin:
            raise OptinavError("both CONFIG.json and --builtin were given", "pass one of them")
        if self.builtin:
            return builtin(self.builtin)
        if not self.config:
            raise OptinavError("no configuration given",
                               "pass CONFIG.json (--config in a batch) or --builtin cylinder10")
        return AccelerometerArray.load(self.config)


def check(options: GfimuOptions) -> None:
    if options.method not in ("lm", "closed-form"):
        raise OptinavError(f"unknown calibration method {options.method!r}", "use 'lm' or 'closed-form'")
    if options.rate_unit not in ("rad/s", "deg/s"):
        raise OptinavError(f"--rate-unit {options.rate_unit!r}", "use rad/s or deg/s")
    identifiability(options.array()).require(("linear",))


def run_unit(path, options: GfimuOptions, reference: bool = False) -> tuple[TurntableCalibration, dict]:
    """Read and calibrate ``path`` (what ``optinav calibrate gfimu`` does); extra columns: samples, rank,
    residual RMS (in σ)."""
    arr = options.array()
    data = TurntableData.load(path, arr.n)
    if options.rate_unit == "deg/s":
        data.table_rate = np.radians(data.table_rate)
    offset = options.offset if isinstance(options.offset, str) else np.asarray(options.offset, float)
    res = calibrate(arr, data, method=options.method, offset=offset, sigma=options.noise)
    return res, {"n_samples": int(len(data.t)), "rank": int(res.rank), "n_params": int(res.n_params),
                 "residual_rms_sigma": float(res.residual_rms)}
