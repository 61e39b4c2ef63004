"""Peak memory (resident set) of the commands on one long log: simulate, calibrate accel, apply, attitude.

Data: `optinav simulate accel-multipos` (the paper's 12 poses at 100 Hz; dwell 60 s, about 78 000 rows;
full: 8 300 s, about 10 M rows), written as CSV, then calibrated, corrected with the result and run through the
attitude filter, each command in its own process (peak RSS from ``getrusage`` of that process). Two log
lengths (quick: dwell 10 s and 60 s) give the growth per million rows (the imports cancel) and the peak
extrapolated to 10 M rows. Target (issue 17): under 1 GB for a 10 M-row log; nothing streams yet, so this
records how far from it each command is.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

_WRAP = ("import resource, sys; from optinav.cli.main import main; rc = main(sys.argv[1:]); "
         "print('peak_kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr); sys.exit(rc)")


def _peak_mib(argv: list[str]) -> float:
    proc = subprocess.run([sys.executable, "-c", _WRAP, "--quiet", *argv], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"optinav {' '.join(argv)} failed: {proc.stderr.strip()[-300:]}")
    line = [x for x in proc.stderr.splitlines() if x.startswith("peak_kib")][-1]
    return int(line.split()[1]) / 1024.0


def _measure(d: Path, dwell: float) -> tuple[int, dict]:
    log, res = d / f"log{dwell:g}.csv", d / f"result{dwell:g}.json"
    corrected = d / f"corrected{dwell:g}.csv"
    steps = [("simulate accel-multipos", ["simulate", "accel-multipos", "--out", str(log), "--dwell", str(dwell),
                                          "--rate", "100", "--seed", "1"]),
             ("calibrate accel", ["calibrate", "accel", str(log), "--latitude", "38.88", "--height", "35",
                                  "--out", str(res)]),
             ("apply", ["apply", str(res), str(log), "--out", str(corrected)]),
             ("attitude", ["attitude", str(corrected), "--out", str(d / f"att{dwell:g}.csv")])]
    peaks = {name: _peak_mib(argv) for name, argv in steps}
    with open(log, encoding="utf-8") as fh:
        n = sum(1 for _ in fh) - 3  # two comment lines and the header
    return n, peaks


def run(quick: bool) -> list[dict]:
    small, large = (10.0, 60.0) if quick else (60.0, 8300.0)
    with tempfile.TemporaryDirectory() as tmp:
        n1, p1 = _measure(Path(tmp), small)
        n2, p2 = _measure(Path(tmp), large)
    group = f"peak memory, logs of {n1} and {n2} rows"
    rows = []
    for name in p2:
        slope = (p2[name] - p1[name]) / ((n2 - n1) / 1e6)  # MiB per million rows, the imports cancel
        rows += [{"group": group, "method": name, "metric": f"peak RSS at {n2} rows", "value": p2[name],
                  "unit": "MiB"},
                 {"group": group, "method": name, "metric": "growth per million rows", "value": slope, "unit": "MiB"},
                 {"group": group, "method": name, "metric": "peak RSS at 10 M rows (extrapolated)",
                  "value": p1[name] + slope * (10 - n1 / 1e6), "unit": "MiB"}]
    return rows
