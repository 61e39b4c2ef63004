"""Noise characterisation of a long static log: `optinav allan` (streamed) and allantools' oadev side by side.

Data: `optinav simulate static` at 1 kHz (quick: 6 min, 360 000 samples; full: 1 h, 3.6 M samples — the issue 14
target size), written as NPZ. Rows: wall time and peak resident memory of the whole `optinav allan` command (read,
six axes, fit, JSON; its own process), and, on one gyro axis held in memory, the time of
``optinav.core.allan.allan_deviation`` and of ``allantools.oadev`` (data_type="freq", the same octave τ) with the
largest relative difference of the two deviations.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

_WRAP = (
    "import resource, sys, time; from optinav.cli.main import main; t0 = time.perf_counter(); "
    "rc = main(sys.argv[1:]); print('wall_s', time.perf_counter() - t0, file=sys.stderr); "
    "print('peak_kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr); sys.exit(rc)"
)


def _command(argv: list[str]) -> dict:
    proc = subprocess.run([sys.executable, "-c", _WRAP, "--quiet", *argv], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"optinav {' '.join(argv)} failed: {proc.stderr.strip()[-300:]}")
    vals = dict(line.split() for line in proc.stderr.splitlines() if line.startswith(("wall_s", "peak_kib")))
    return {"wall_s": float(vals["wall_s"]), "peak_mib": int(vals["peak_kib"]) / 1024.0}


def run(quick: bool) -> list[dict]:
    import numpy as np

    hours = 0.1 if quick else 1.0
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "rest.npz"
        _command(["simulate", "static", "--out", str(log), "--hours", str(hours), "--rate", "1000", "--seed", "1"])
        cmd = _command(["allan", str(log), "--out", str(Path(tmp) / "allan.json")])
        x = np.load(log)["gyro"][:, 0].copy()
    n = x.size
    group = f"Allan deviation, {n} samples at 1 kHz"
    rows = [
        {
            "group": group,
            "method": "optinav allan (6 axes, streamed)",
            "metric": "wall time",
            "value": cmd["wall_s"],
            "unit": "s",
        },
        {
            "group": group,
            "method": "optinav allan (6 axes, streamed)",
            "metric": "peak RSS",
            "value": cmd["peak_mib"],
            "unit": "MiB",
        },
    ]
    from optinav.core.allan import allan_deviation

    try:
        import allantools
    except ImportError:
        allantools = None
    # both warmed on a short record and timed best of 3: the first call of either pays its imports (scipy.stats
    # for optinav's intervals), which made optinav's deviation look 1.8× slower than allantools' in one run
    allan_deviation(x[:4096], 1e-3)
    if allantools is not None:
        allantools.oadev(x[:4096], rate=1000.0, data_type="freq")

    def best(f):
        times, out = [], None
        for _ in range(3):
            t0 = time.perf_counter()
            out = f()
            times.append(time.perf_counter() - t0)
        return min(times), out

    t_ours, ad = best(lambda: allan_deviation(x, 1e-3))
    rows.append(
        {
            "group": group,
            "method": "optinav allan_deviation (1 axis)",
            "metric": "wall time",
            "value": t_ours,
            "unit": "s",
        }
    )
    if allantools is None:
        return rows
    t_at, (_, dev, _, _) = best(lambda: allantools.oadev(x, rate=1000.0, data_type="freq", taus=ad.tau))
    rows += [
        {"group": group, "method": "allantools oadev (1 axis)", "metric": "wall time", "value": t_at, "unit": "s"},
        {
            "group": group,
            "method": "optinav vs allantools",
            "metric": "max relative difference",
            "value": float(np.max(np.abs(dev / ad.adev - 1))),
            "unit": "1",
        },
    ]
    return rows
