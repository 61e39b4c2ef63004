"""Time from start to the one-line error on a bad input file (issue 17: within 1 s, lazy imports).

Each command runs in its own process on a few small bad files (a text cell, a ragged row, NUL bytes, a missing
file); the figures are the median over the repeats of the wall time and of the CPU time (user + system, from
``getrusage`` of the child), and which of numba, scipy and matplotlib were loaded when the error was printed. On
a loaded machine the wall time grows with the load while the CPU time stays near what an idle machine takes, so
the 1 s target is read on the CPU column. "before": commit ``BEFORE`` (the commands imported the systems'
packages, scipy and numba before reading); "after": this tree. ``tests/test_lazy_imports.py`` keeps the property
(no heavy import before a read error) from regressing without timing anything.

Results: results_startup.json, and results_startup.md from ``python benchmarks/bench_startup.py
results_startup.json``.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_memory import ROOT, _before_src  # noqa: E402

#: the commit before the imports were deferred
BEFORE = "05877ff"
HEAVY = ("numba", "scipy", "matplotlib")

BAD_FILES = {
    "text cell": b"t,ax,ay,az,gx,gy,gz\n0,1,x,3,0,0,0\n",
    "ragged row": b"t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0\n",
    "NUL bytes": b"t,ax,ay,az\x00\x01\x02 garbage\n",
    "missing file": None,
}

_WRAP = (
    "import sys; from optinav.cli.main import main\n"
    "try:\n    rc = main(sys.argv[1:])\nexcept SystemExit as exc:\n    rc = exc.code\n"
    "print('heavy', ','.join(sorted({m.split('.')[0] for m in sys.modules} & set(%r))), file=sys.stderr)\n"
    "sys.exit(rc)\n" % (HEAVY,)
)


def _commands(bad: Path, d: Path) -> dict[str, list[str]]:
    return {
        "calibrate accel": ["calibrate", "accel", str(bad), "--out", str(d / "o.json")],
        "calibrate accel --method ferraris": [
            "calibrate",
            "accel",
            str(bad),
            "--method",
            "ferraris",
            "--out",
            str(d / "o.json"),
        ],
        "attitude": ["attitude", str(bad), "--out", str(d / "o.csv"), "--rate", "100"],
    }


def _time(src: Path, argv: list[str]) -> tuple[float, float, str]:
    """(wall s, CPU s, heavy modules loaded) of one failing run of ``optinav argv`` with the sources in ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src), OPTINAV_QUIET="1")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _WRAP, *argv], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 2 or "optinav: error:" not in proc.stderr:
        raise RuntimeError(f"optinav {' '.join(argv)} exited {proc.returncode}: {proc.stderr.strip()[-300:]}")
    heavy = [x for x in proc.stderr.splitlines() if x.startswith("heavy")][-1].split(" ", 1)[1:]
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), (heavy[0] if heavy else "")


def run(quick: bool) -> list[dict]:
    repeats = 1 if quick else 3
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        versions = {"after": ROOT / "src"}
        before = _before_src(tmp, BEFORE)
        if before is not None:
            versions["before"] = before
        for kind, content in BAD_FILES.items():
            bad = tmp / f"bad_{kind.replace(' ', '_')}.csv"
            if content is not None:
                bad.write_bytes(content)
            for name, argv in _commands(bad, tmp).items():
                for version, src in versions.items():
                    runs = [_time(src, argv) for _ in range(repeats)]
                    method = f"{name} ({version})"
                    group = f"bad file: {kind}"
                    out += [
                        {
                            "group": group,
                            "method": method,
                            "metric": "wall time to the error",
                            "value": statistics.median(r[0] for r in runs),
                            "unit": "s",
                        },
                        {
                            "group": group,
                            "method": method,
                            "metric": "CPU time to the error",
                            "value": statistics.median(r[1] for r in runs),
                            "unit": "s",
                        },
                        {
                            "group": group,
                            "method": method,
                            "metric": "heavy modules loaded",
                            "value": float(len([m for m in runs[0][2].split(",") if m])),
                            "unit": runs[0][2] or "-",
                        },
                    ]
    return out


def markdown(results: dict) -> str:
    """The table of a results JSON written by ``run.py --only startup`` (results_startup.md)."""
    rows, meta = results["rows"], results["meta"]

    def get(group, method, metric):
        return next(r for r in rows if r["group"] == group and r["method"] == method and r["metric"] == metric)

    out = [
        "# Time to the one-line error on a bad input file (benchmarks/bench_startup.py)",
        "",
        f"Generated from results_startup.json ({meta['date']}, Python {meta['python']}, a shared 2-core machine "
        "under load: the wall time includes waiting for a core, the CPU time (user + system of the process) is "
        f'what an idle machine takes). Medians of repeated runs. "before": commit {BEFORE}; "after": this '
        "tree. Target (issue 17): under 1 s.",
        "",
        "| bad file | command | CPU before [s] | CPU after [s] | wall before [s] | wall after [s] "
        "| loaded at the error, before | after |",
        "|---|---|---:|---:|---:|---:|---|---|",
    ]
    groups = list(dict.fromkeys(r["group"] for r in rows))
    for g in groups:
        for cmd in dict.fromkeys(r["method"].rsplit(" (", 1)[0] for r in rows if r["group"] == g):
            cpu = {v: get(g, f"{cmd} ({v})", "CPU time to the error")["value"] for v in ("before", "after")}
            wall = {v: get(g, f"{cmd} ({v})", "wall time to the error")["value"] for v in ("before", "after")}
            heavy = {v: get(g, f"{cmd} ({v})", "heavy modules loaded")["unit"] for v in ("before", "after")}
            out.append(
                f"| {g.split(': ', 1)[1]} | {cmd} | {cpu['before']:.2f} | {cpu['after']:.2f} "
                f"| {wall['before']:.2f} | {wall['after']:.2f} | {heavy['before']} | {heavy['after']} |"
            )
    return "\n".join(out) + "\n"


if __name__ == "__main__":  # python benchmarks/bench_startup.py RESULTS.json > results_startup.md
    import json

    print(markdown(json.loads(Path(sys.argv[1]).read_text())), end="")
