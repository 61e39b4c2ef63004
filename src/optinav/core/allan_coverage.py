"""Monte Carlo coverage of the 68 % intervals of the Allan noise fit and read-off on simulated static logs.

Each record is :func:`optinav.core.imu_model.static_noise` (the noise of ``optinav simulate static``) with white
N, flicker B and random walk K per axis whose Allan terms cross at ``cross_white_s`` (N/B) and ``cross_rw_s``
(B/K), in one design plus a rate ramp R (a warm-up drift); :func:`coverage` counts, per term and axis, how often the reported interval holds the truth. The
benchmark (``benchmarks/bench_allan_coverage.py``) runs hundreds of records, ``tests/test_allan.py`` a few dozen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optinav.core.allan import (
    FLICKER_FLOOR,
    allan_deviation,
    fit_noise_model,
    kalibr_noise,
    noise_parameters_from_allan,
)
from optinav.core.imu_model import static_noise

TERMS = ("white", "bias_instability", "random_walk")


@dataclass(frozen=True)
class Design:
    """A simulated static log: ``n`` samples at ``dt`` s, the N/B and B/K crossings of the Allan terms in s."""

    name: str
    n: int
    dt: float
    cross_white_s: float
    cross_rw_s: float
    #: a rate ramp (a warm-up drift) whose change over the record is this many times the random walk's K·√T
    ramp: float = 0.0

    def truth(self) -> dict[str, np.ndarray]:
        """The simulated noise terms, with the crossing times of the design.

        Returns
        -------
        dict of str to (3,) ndarray
            ``white`` N [rad/√s], ``bias_instability`` B [rad/s], ``random_walk`` K [rad/s/√s] per axis, and with a
            ramp ``rate_ramp`` R [rad/s²].
        """
        N = np.array([1e-3, 2e-3, 5e-4])
        B = N / math.sqrt(self.cross_white_s) / FLICKER_FLOOR
        K = math.sqrt(3.0 / self.cross_rw_s) * FLICKER_FLOOR * B
        out = {"white": N, "bias_instability": B, "random_walk": K}
        if self.ramp:
            out["rate_ramp"] = self.ramp * K / math.sqrt(self.n * self.dt)
        return out


#: 3.6 h at 20 Hz, upturn at 300 s (the log is 44 times longer); 2.9 h at 50 Hz, upturn at 1000 s (10 times:
#: the last octave-spaced cluster time, 1311 s, is just past the upturn)
DESIGNS = (
    Design("long record (44x the upturn)", 2**18, 0.05, 1.0, 300.0),
    Design("short record (10x the upturn)", int(2.9 * 3600 * 50), 0.02, 0.3, 1000.0),
    Design("long record with a warm-up ramp (3 K·√T)", 2**18, 0.05, 1.0, 300.0, ramp=3.0),
)


def coverage(design: Design, seeds) -> dict:
    """Per method ("fit", "read_off") and term, the (n_seeds, 3) booleans "the 68 % interval holds the truth";
    "kalibr" ("noise_density", "random_walk"): (n_seeds,) whether the interval of the axis that gives Kalibr's
    value (the largest of the fit, :func:`~optinav.core.allan.kalibr_noise`) holds the largest true value.

    Parameters
    ----------
    design : Design
        The simulated record.
    seeds : iterable of int
        One simulated record per seed.

    Returns
    -------
    dict
        ``{method: {term: bool ndarray}}`` as above.
    """
    truth = design.truth()
    terms = TERMS + (("rate_ramp",) if "rate_ramp" in truth else ())
    out = {m: {t: [] for t in terms} for m in ("fit", "read_off")}
    out["kalibr"] = {"noise_density": [], "random_walk": []}
    out["misfit"] = {"flagged": []}
    for seed in seeds:
        x = static_noise(design.n, design.dt, rng=int(seed), **{t: truth[t] for t in TERMS})
        if "rate_ramp" in truth:
            x += np.arange(design.n)[:, None] * design.dt * truth["rate_ramp"]
        ad = allan_deviation(x, design.dt)
        fit, ro = fit_noise_model(ad), noise_parameters_from_allan(ad)
        for method, res in (("fit", fit), ("read_off", ro)):
            for t in terms:
                iv = np.asarray(getattr(res, t + "_interval"))
                out[method][t].append((iv[0] <= truth[t]) & (truth[t] <= iv[1]))
        out["misfit"]["flagged"].append(np.asarray(fit.model_floor) > 0)
        kal = kalibr_noise(fit, "gyroscope")
        for key, term in (("noise_density", "white"), ("random_walk", "random_walk")):
            # Kalibr's value is the largest axis of the fit: its interval is that axis' one, its truth the largest
            j = int(np.argmax(np.asarray(getattr(fit, term))))
            iv = np.asarray(getattr(fit, term + "_interval"))[:, j]
            out["kalibr"][key].append(bool(iv[0] <= truth[term].max() <= iv[1]) and kal[f"gyroscope_{key}"] >= iv[0])
    return {m: {t: np.array(v) for t, v in d.items()} for m, d in out.items()}


def binomial_band(n: int, p_lo: float = 0.60, p_hi: float = 0.76, z: float = 2.576) -> tuple[float, float]:
    """Bounds on an observed fraction of n trials that a true coverage in [p_lo, p_hi] passes with probability
    ≥ 99 % each side (normal approximation of the binomial, z = 2.576).

    Parameters
    ----------
    n : int
        Trials.
    p_lo, p_hi : float
        The accepted range of the true coverage [-].
    z : float
        Normal quantile of the one-sided test [-].

    Returns
    -------
    (float, float)
        Lowest and highest observed fraction that passes [-].
    """
    return (p_lo - z * math.sqrt(p_lo * (1 - p_lo) / n), p_hi + z * math.sqrt(p_hi * (1 - p_hi) / n))
