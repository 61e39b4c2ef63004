"""One rotational-INS recording, as :mod:`optinav.batch` runs it (registry: ``rins``)."""

from __future__ import annotations

import dataclasses
import math

from optinav.errors import OptinavError
from optinav.rins.calibrate import METHODS, RinsCalibration, calibrate, prepare
from optinav.rins.io import read_rins


@dataclasses.dataclass
class RinsOptions:
    """The options of ``optinav calibrate rins``: ``method``; ``lat_deg`` latitude in degrees (None: from the
    file); ``align_s`` longest alignment window in s (None: the initial rest); ``residual_rate_hz`` epochs per
    second of the attitude residuals; ``seed`` of PSO."""

    method: str = "lm"
    lat_deg: float | None = None
    align_s: float | None = None
    residual_rate_hz: float = 10.0
    seed: int = 0


def check(options: RinsOptions) -> None:
    if options.method not in METHODS:
        raise OptinavError(f"unknown method {options.method!r}", f"use one of {', '.join(METHODS)}")
    if not (math.isfinite(options.residual_rate_hz) and options.residual_rate_hz > 0):
        raise OptinavError(f"--residual-rate {options.residual_rate_hz!r} is not a positive rate",
                           "give epochs per second, e.g. --residual-rate 10")


def run_unit(path, options: RinsOptions, reference: bool = False) -> tuple[RinsCalibration, dict]:
    """Read and calibrate ``path`` (what ``optinav calibrate rins`` does); extra columns: samples, the RMS of
    the extracted attitude change before/after compensation (deg, [roll, pitch, yaw])."""
    data = read_rins(path, lat=None if options.lat_deg is None else math.radians(options.lat_deg))
    prep = prepare(data, residual_rate=options.residual_rate_hz, align_s=options.align_s)
    res = calibrate(method=options.method, prep=prep, rng=options.seed, source=str(path))
    extra = {"n_samples": int(data.t.size)}
    for when, v in (("before", res.rmse_before_deg), ("after", res.rmse_after_deg)):
        extra.update({f"rmse_{when}_{ax}_deg": float(x) for ax, x in zip(("roll", "pitch", "yaw"), v)})
    return res, extra
