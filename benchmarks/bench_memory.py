"""Peak memory (resident set) and time of the commands on long logs: simulate, calibrate, apply, attitude.

Data: `optinav simulate accel-multipos` (the paper's 12 poses at 100 Hz; rest 10 s, turns 4 s, the dwell set
for 1 M and 3 M rows; quick: 20 000 and 60 000), written as CSV, then calibrated, corrected with the result and
run through the attitude filter (iframe), each command in its own process (peak RSS from ``getrusage`` of that
process, wall time around it). Every step runs twice: with this tree's sources ("after") and with the sources of
commit ``BEFORE`` exported by ``git archive`` ("before", the tree before the commands streamed). The two log
lengths give the growth per million rows (the imports cancel) and the peak extrapolated to 10 M rows: 10 M
rows were not run (a 1.3 GB CSV per step, and the "before" commands would need about 11 GB), so the 10 M
figures are a linear extrapolation from 1 M and 3 M, which holds for the streamed commands only while their
per-row state stays as measured. Target (issue 17): under 1 GB for a 10 M-row log. Streamed: apply (blocks of
200 000 rows: flat), attitude (two passes; three floats per row kept for the exact medians of its checks;
``--offline`` runs its passes over a scratch file beside the output). Calibrate reads in blocks (iter_imu) into one
array per field and keeps time, accelerometer and gyroscope (56 B per row) plus its static detection's rank of
each row among the candidate thresholds (2 B per row); it holds the log, so it grows. ``simulate accel-multipos`` generates and writes in
blocks too (noise drawn per sample, its states carried): ``--simulate`` measures it alone at 1 M, 3 M and 10 M rows
(results_memory_simulate.json) and ``--merge-simulate`` puts its 1 M and 3 M runs into results_memory.json.
``simulate static``, ``simulate rins``, ``simulate flight`` and ``simulate gfimu-turntable`` are generated and
written in blocks too: ``--simulate-static``, ``--simulate-rins``, ``--simulate-flight`` and ``--simulate-gfimu``
measure each before and after at 1 M and 3 M rows and after at 10 M rows (results_memory_simulate_static.json,
results_memory_simulate_rins.json, results_memory_simulate_flight.json, results_memory_simulate_gfimu.json; one
runner, ``_run_simulator``); ``--calibrate-gfimu`` measures ``calibrate gfimu`` before and after on its CSV at 1 M, 3 M and 10 M
rows (summarized per case while reading; results_memory_calibrate_gfimu.json). ``--calibrate-rins`` measures
``calibrate rins`` and ``apply`` of its result (this tree, both streamed) on the ``simulate rins`` CSV at 1 M, 3 M and 10 M
rows (results_memory_calibrate_rins.json). ``--attitude-report`` measures ``attitude --report`` before (whole log in
memory) and after (streamed; results_memory_attitude_report.json). ``--apply-gfimu`` measures ``apply`` of a gfimu
result and ``--batch-attitude`` a one-unit ``batch attitude`` before and after (results_memory_apply_gfimu.json,
results_memory_batch_attitude.json). Results: results_memory.json, and results_memory.md from
``python benchmarks/bench_memory.py results_memory.json``.

"Bad cell": the 1 M-row log with the last row's ``ay`` replaced by text; the time until ``apply`` and
``attitude`` end with their one-line error (the streamed commands process the rows before it first: apply
corrects and writes them, attitude's first pass only reads them).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: the commit before the commands streamed (the "before" column)
BEFORE = "588414d"
ROOT = Path(__file__).resolve().parent.parent

#: runs the CLI and prints the process's peak resident memory: VmHWM, the high-water mark of its own address
#: space (ru_maxrss is not: after a vfork + exec it also holds the parent's peak, so every run measured after
#: this runner had read a 1 M-row log into memory once showed at least the runner's ~520 MiB)
_WRAP = """import resource, sys
from optinav.cli.main import main
rc = main(sys.argv[1:])
try:
    kib = next(int(x.split()[1]) for x in open('/proc/self/status') if x.startswith('VmHWM:'))
except (OSError, StopIteration):
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print('peak_kib', kib, file=sys.stderr)
sys.exit(rc)
"""


def _run(src: Path, argv: list[str], expect_error: bool = False) -> tuple[float, float, str]:
    """(peak MiB, wall s, stderr) of ``optinav argv`` with the sources in ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src), OPTINAV_QUIET="1")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _WRAP, "--quiet", *argv], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if (proc.returncode != 0) != expect_error:
        raise RuntimeError(f"optinav {' '.join(argv)} exited {proc.returncode}: {proc.stderr.strip()[-300:]}")
    lines = [x for x in proc.stderr.splitlines() if x.startswith("peak_kib")]
    peak = int(lines[-1].split()[1]) / 1024.0 if lines else float("nan")
    return peak, wall, proc.stderr


def _before_src(tmp: Path, commit: str = BEFORE) -> Path | None:
    """The sources of ``commit``, or None outside a git checkout."""
    if shutil.which("git") is None:
        return None
    dest = tmp / "before"
    dest.mkdir()
    arch = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "src"], capture_output=True)
    if arch.returncode != 0:
        return None
    subprocess.run(["tar", "-x", "-C", str(dest)], input=arch.stdout, check=True)
    return dest / "src"


def _versions(tmp: Path, commit: str) -> dict[str, Path]:
    """The sources to run: "after" (this tree) and, in a git checkout, "before" (``commit``)."""
    versions = {"after": ROOT / "src"}
    old = _before_src(tmp, commit)
    if old is not None:
        versions["before"] = old
    return versions


def _steps(d: Path, rows: int) -> list[tuple[str, list[str]]]:
    dwell = (rows / 100.0 - 10.0) / 12.0 - 4.0
    log, res = d / f"log{rows}.csv", d / f"result{rows}.json"
    return [
        (
            "simulate accel-multipos",
            [
                "simulate",
                "accel-multipos",
                "--out",
                str(log),
                "--dwell",
                f"{dwell:.6f}",
                "--rate",
                "100",
                "--seed",
                "1",
            ],
        ),
        (
            "calibrate accel",
            ["calibrate", "accel", str(log), "--latitude", "38.88", "--height", "35", "--out", str(res)],
        ),
        ("apply", ["apply", str(res), str(log), "--out", str(d / f"corrected{rows}.csv")]),
        ("attitude", ["attitude", str(d / f"corrected{rows}.csv"), "--out", str(d / f"att{rows}.csv")]),
    ]


def _rows_of(path: Path) -> int:
    with open(path, "rb") as fh:
        return sum(1 for _ in fh) - 3  # two comment lines and the header


def _bad_copy(src: Path, dst: Path) -> None:
    """``src`` with the last row's ``ay`` cell (column 3) replaced by text."""
    with open(src, "rb") as fh:
        data = fh.read()
    head, last = data.rstrip(b"\n").rsplit(b"\n", 1)
    cells = last.split(b",")
    cells[2] = b"x1.5"
    dst.write_bytes(head + b"\n" + b",".join(cells) + b"\n")


def run(quick: bool, before: bool = True) -> list[dict]:
    """The rows of results_memory.json; ``before=False`` measures this tree only (:func:`remeasure`)."""
    sizes = (20_000, 60_000) if quick else (1_000_000, 3_000_000)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        versions = {"after": ROOT / "src"}
        old = _before_src(tmp) if before else None
        if old is not None:
            versions["before"] = old
        peaks: dict[tuple[str, str], list[tuple[int, float, float]]] = {}
        for version, src in versions.items():
            for rows in sizes:
                d = tmp / f"{version}{rows}"
                d.mkdir()
                n = None
                for name, argv in _steps(d, rows):
                    peak, wall, _ = _run(src, argv)
                    n = n or _rows_of(d / f"log{rows}.csv")
                    peaks.setdefault((name, version), []).append((n, peak, wall))
                if rows == sizes[0]:
                    bad = d / "bad.csv"
                    _bad_copy(d / f"log{rows}.csv", bad)
                    for name, argv in (
                        ("apply", ["apply", str(d / f"result{rows}.json"), str(bad), "--out", str(d / "bad_out.csv")]),
                        ("attitude", ["attitude", str(bad), "--out", str(d / "bad_att.csv")]),
                    ):
                        _, wall, err = _run(src, argv, expect_error=True)
                        if "not a number" not in err:
                            raise RuntimeError(f"{name} on the bad cell: {err.strip()[-300:]}")
                        out.append(
                            {
                                "group": f"bad cell in the last of {n} rows",
                                "method": f"{name} ({version})",
                                "metric": "time to the one-line error",
                                "value": wall,
                                "unit": "s",
                            }
                        )
                shutil.rmtree(d)
    for (name, version), pts in peaks.items():
        (n1, p1, _), (n2, p2, w2) = pts
        out += _peak_rows(f"peak memory, logs of {n1} and {n2} rows", f"{name} ({version})", n1, p1, n2, p2, w2)
    order = {"simulate accel-multipos": 0, "calibrate accel": 1, "apply": 2, "attitude": 3}
    return sorted(out, key=lambda r: (r["group"], order.get(r["method"].split(" (")[0], 9), r["method"]))


def _peak_rows(group: str, method: str, n1: int, p1: float, n2: int, p2: float, w2: float) -> list[dict]:
    """The rows of one command measured at ``n1`` and ``n2`` rows (peaks ``p1``, ``p2`` MiB; wall ``w2`` s at
    ``n2``): both peaks, the growth per million rows (the imports cancel) and the peak extrapolated to 10 M rows."""
    slope = (p2 - p1) / ((n2 - n1) / 1e6)
    return [
        {"group": group, "method": method, "metric": f"peak RSS at {n1} rows", "value": p1, "unit": "MiB"},
        {"group": group, "method": method, "metric": f"peak RSS at {n2} rows", "value": p2, "unit": "MiB"},
        {"group": group, "method": method, "metric": "growth per million rows", "value": slope, "unit": "MiB"},
        {
            "group": group,
            "method": method,
            "metric": "peak RSS at 10 M rows (extrapolated)",
            "value": p1 + slope * (10 - n1 / 1e6),
            "unit": "MiB",
        },
        {"group": group, "method": method, "metric": f"wall time at {n2} rows", "value": w2, "unit": "s"},
    ]


def remeasure(path: Path, note: str) -> None:
    """Re-run this tree's steps ("after") into the results JSON ``path``, keeping its "before" rows (the commit
    before the commands streamed does not change), with ``note`` and the date added to its notes."""
    import json

    results = json.loads(path.read_text())
    keep = [r for r in results["rows"] if not r["method"].endswith("(after)")]
    rows = keep + run(quick=bool(results["meta"].get("quick")), before=False)
    order = {"simulate accel-multipos": 0, "calibrate accel": 1, "apply": 2, "attitude": 3}
    results["rows"] = sorted(rows, key=lambda r: (r["group"], order.get(r["method"].split(" (")[0], 9), r["method"]))
    results["meta"]["notes"] = [
        f'every "after" row re-measured {time.strftime("%Y-%m-%dT%H:%M%z")} ({note}); '
        "the peak is now the process's own high-water mark (VmHWM): ru_maxrss, used before, "
        "held the runner's ~520 MiB after it had read a 1 M-row log, which floored the "
        'streamed commands\' figures (the "before" rows are all above it)'
    ]
    path.write_text(json.dumps(results, indent=2) + "\n")


def markdown(results: dict) -> str:
    """The before/after table of a results JSON written by ``run.py --only memory`` (results_memory.md)."""
    rows, meta = results["rows"], results["meta"]

    def val(cmd, ver, metric):
        return next(r["value"] for r in rows if r["method"] == f"{cmd} ({ver})" and r["metric"].startswith(metric))

    big = [r["metric"] for r in rows if r["metric"].startswith("wall time at ")][0].split()[-2]
    small = [r["metric"] for r in rows if r["metric"].startswith("peak RSS at ") and "10 M" not in r["metric"]]
    small = min(int(m.split()[-2]) for m in small)
    out = [
        "# Peak memory of the commands on long logs (benchmarks/bench_memory.py)",
        "",
        f"Generated from results_memory.json ({meta['date']}, Python {meta['python']}, a shared 2-core machine: "
        'wall times vary with the load). "before": '
        f'commit {BEFORE}; "after": this tree. 10 M rows were not run: the 10 M column is the linear '
        f"extrapolation from {small} and {big} rows.",
        "",
        f"| command | version | peak RSS {small} rows [MiB] | peak RSS {big} rows [MiB] | growth [MiB per M rows] "
        f"| 10 M rows, extrapolated [MiB] | wall time {big} rows [s] |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    if meta.get("notes"):
        out[3:3] = ["", "Notes: " + "; ".join(meta["notes"]) + "."]
    for c in ("simulate accel-multipos", "calibrate accel", "apply", "attitude"):
        for v in ("before", "after"):
            out.append(
                f"| {c} | {v} | {val(c, v, f'peak RSS at {small}'):.0f} | {val(c, v, f'peak RSS at {big}'):.0f} "
                f"| {val(c, v, 'growth'):.0f} | {val(c, v, 'peak RSS at 10 M'):.0f} "
                f"| {val(c, v, 'wall time'):.0f} |"
            )
    out += [
        "",
        f"Bad cell (text in `ay` of the last of {small} rows): time until the one-line error naming line and column.",
        "",
        "| command | before [s] | after [s] |",
        "|---|---:|---:|",
    ]
    for c in ("apply", "attitude"):
        t = {
            v: next(r["value"] for r in rows if r["method"] == f"{c} ({v})" and r["group"].startswith("bad"))
            for v in ("before", "after")
        }
        out.append(f"| {c} | {t['before']:.1f} | {t['after']:.1f} |")
    return "\n".join(out) + "\n"


def _broad_layout(src: Path, dst: Path) -> None:
    """The IMU log ``src`` (t, acc, gyro in SI) as a BROAD-layout HDF5 trial at 100 Hz: imu_acc, imu_gyr,
    imu_mag (the accelerometer standing in), opt_quat (the identity: only the scoring's memory is measured) and
    movement (all samples), written in blocks."""
    import h5py
    import numpy as np

    from optinav.io.imu import iter_imu

    with h5py.File(dst, "w") as f:
        f.attrs["sampling_rate"] = 100.0
        sets = {
            k: f.create_dataset(k, shape=(0, w), maxshape=(None, w), dtype=float, chunks=(65536, w))
            for k, w in (("imu_acc", 3), ("imu_gyr", 3), ("imu_mag", 3), ("opt_quat", 4), ("movement", 1))
        }
        for log in iter_imu(src):
            n = len(log)
            q = np.zeros((n, 4))
            q[:, 0] = 1.0
            for k, v in (
                ("imu_acc", log.acc),
                ("imu_gyr", log.gyr),
                ("imu_mag", log.acc),
                ("opt_quat", q),
                ("movement", np.ones((n, 1))),
            ):
                ds = sets[k]
                ds.resize(ds.shape[0] + n, axis=0)
                ds[-n:] = v


#: the attitude modes measured by :func:`run_attitude_modes` (argv after the input file)
ATTITUDE_MODES = {
    "attitude (online)": [],
    "attitude --mag": ["--mag-columns", "ax,ay,az"],
    "attitude --offline": ["--offline"],
    "attitude --reference (BROAD layout, --mag)": None,
}


def run_attitude_modes(quick: bool) -> list[dict]:
    """Peak RSS of ``optinav attitude`` per mode (this tree only) on the simulated accel-multipos log of 1 M and
    3 M rows (quick: 20 000 and 60 000), written as CSV (the BROAD-layout run: an HDF5 copy of it); growth per
    million rows and the 10 M extrapolation as in :func:`run`. The magnetometer runs take the accelerometer
    columns as the field: the data path and its memory are those of a real magnetometer."""
    sizes = (20_000, 60_000) if quick else (1_000_000, 3_000_000)
    src = ROOT / "src"
    peaks: dict[str, list[tuple[int, float, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for rows in sizes:
            d = Path(tmp) / str(rows)
            d.mkdir()
            name, argv = _steps(d, rows)[0]
            log = d / f"log{rows}.csv"
            peak, wall, _ = _run(src, argv)
            n = _rows_of(log)
            peaks.setdefault(name, []).append((n, peak, wall))
            h5 = d / "trial.hdf5"
            _broad_layout(log, h5)
            for mode, extra in ATTITUDE_MODES.items():
                args = [str(h5), "--frame", "ENU", "--mag", "--reference"] if extra is None else [str(log), *extra]
                peak, wall, _ = _run(src, ["attitude", *args, "--out", str(d / "att.csv")])
                peaks.setdefault(mode, []).append((n, peak, wall))
            shutil.rmtree(d)
    out = []
    for name, ((n1, p1, _), (n2, p2, w2)) in peaks.items():
        slope = (p2 - p1) / ((n2 - n1) / 1e6)
        out.append(
            {
                "group": f"attitude modes, logs of {n1} and {n2} rows",
                "method": name,
                "rows": [n1, n2],
                "peak_mib": [p1, p2],
                "growth_mib_per_m_rows": slope,
                "peak_10m_mib": p1 + slope * (10 - n1 / 1e6),
                "wall_s": w2,
            }
        )
    return out


def markdown_modes(rows: list[dict]) -> str:
    """The table of :func:`run_attitude_modes` (appended to results_memory.md)."""
    n1, n2 = rows[0]["rows"]
    out = [
        f"## Attitude modes (`run_attitude_modes`, this tree; logs of {n1} and {n2} rows, 10 M extrapolated)",
        "",
        f"| command | peak RSS {n1} rows [MiB] | peak RSS {n2} rows [MiB] | growth [MiB per M rows] "
        f"| 10 M rows, extrapolated [MiB] | wall time {n2} rows [s] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        out.append(
            f"| {r['method']} | {r['peak_mib'][0]:.0f} | {r['peak_mib'][1]:.0f} | "
            f"{r['growth_mib_per_m_rows']:.0f} | {r['peak_10m_mib']:.0f} | {r['wall_s']:.0f} |"
        )
    return "\n".join(out) + "\n"


def run_simulate(sizes=(1_000_000, 3_000_000, 10_000_000)) -> list[dict]:
    """Peak RSS and wall time of ``optinav simulate accel-multipos`` (this tree, streamed: generated and written in
    blocks) at each row count of ``sizes``, the same session as :func:`run` (``--dwell 8328`` at 10 M rows), CSV;
    the file is removed after each run."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for rows in sizes:
            d = Path(tmp) / str(rows)
            d.mkdir()
            name, argv = _steps(d, rows)[0]
            peak, wall, _ = _run(ROOT / "src", argv)
            n = _rows_of(d / f"log{rows}.csv")
            out.append({"method": name, "rows": n, "peak_mib": peak, "wall_s": wall})
            print(f"{name}: {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
            shutil.rmtree(d)
    return out


def merge_simulate(path: Path, runs: list[dict], note: str) -> None:
    """Replace the "simulate accel-multipos (after)" rows of the results JSON ``path`` by the runs of
    :func:`run_simulate` at the two row counts of its group (the "before" rows stay), with ``note`` added to its
    notes."""
    import json

    results = json.loads(path.read_text())
    name = "simulate accel-multipos (after)"
    old = [r for r in results["rows"] if r["method"] == name]
    group = old[0]["group"]
    first, second = runs[0], runs[1]
    new = _peak_rows(
        group, name, first["rows"], first["peak_mib"], second["rows"], second["peak_mib"], second["wall_s"]
    )
    rows = results["rows"]
    i = rows.index(old[0])
    results["rows"] = [r for r in rows[:i] if r["method"] != name] + new + [r for r in rows[i:] if r["method"] != name]
    results["meta"]["notes"] = results["meta"].get("notes", []) + [
        f"{name} re-measured {time.strftime('%Y-%m-%dT%H:%M%z')} ({note})"
    ]
    path.write_text(json.dumps(results, indent=2) + "\n")


def _run_simulator(name: str, before: str, argv_of, sizes, after_only, comment_lines: int = 2) -> list[dict]:
    """Peak RSS and wall time of ``optinav simulate NAME`` writing a CSV of each row count of ``sizes`` with this
    tree ("after") and with commit ``before`` ("before"), and at ``after_only`` with this tree alone; ``argv_of(out,
    rows)`` is the command line; the files (the CSV and its ``STEM.truth.*``) are removed after each run."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), before)
        for rows in (*sizes, *after_only):
            for version, src in versions.items():
                if version == "before" and rows in after_only:
                    continue
                data = Path(tmp) / f"{name}{rows}.csv"
                peak, wall, _ = _run(src, argv_of(data, rows))
                n = _rows_of(data) + 2 - comment_lines
                out.append({"method": f"simulate {name} ({version})", "rows": n, "peak_mib": peak, "wall_s": wall})
                print(f"simulate {name} ({version}): {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
                for p in [data, *Path(tmp).glob(f"{name}{rows}.truth.*")]:
                    p.unlink()
    return out


#: the commit whose ``simulate static`` generated the whole log (one FFT over eight times its length)
STATIC_BEFORE = "1448b49"


def run_simulate_static(sizes=(1_000_000, 3_000_000), after_only=(10_000_000,)) -> list[dict]:
    """``simulate static`` (preset mems-mti1, 100 Hz, CSV) with this tree ("after": generated and written in
    blocks) and with commit :data:`STATIC_BEFORE` ("before": the whole log at once), at ``after_only`` with this
    tree alone (the "before" would need about 6 GB there)."""

    def argv(out, rows):
        return ["simulate", "static", "--out", str(out), "--hours", f"{rows / 360000:.9g}", "--seed", "1"]

    return _run_simulator("static", STATIC_BEFORE, argv, sizes, after_only)


#: the commit whose ``simulate rins`` generated the whole session (about 470 B per sample at the peak)
RINS_BEFORE = "6d4f545"


def _rins_argv(out: Path, rows: int) -> list[str]:
    """``optinav simulate rins`` of ``rows`` samples: the default psins16 scheme at 200 Hz (960 s per cycle), as
    many cycles as fit after a 600 s alignment, the alignment lengthened to make up the rest."""
    seconds = rows / 200.0
    cycles = max(1, int((seconds - 600.0) // 960.0))
    align = seconds - 960.0 * cycles
    return [
        "simulate",
        "rins",
        "--nonorth=1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4",
        "--cycles",
        str(cycles),
        "--align",
        f"{align:.9g}",
        "--seed",
        "1",
        "--out",
        str(out),
    ]


def run_simulate_rins(sizes=(1_000_000, 3_000_000), after_only=(10_000_000,)) -> list[dict]:
    """``simulate rins`` (CSV, :func:`_rins_argv`) with this tree ("after": generated and written in blocks) and
    with commit :data:`RINS_BEFORE` ("before": the whole session at once), at ``after_only`` with this tree alone
    (the "before" would need about 5 GB there)."""
    return _run_simulator("rins", RINS_BEFORE, _rins_argv, sizes, after_only)


#: the commit whose ``simulate flight`` generated the whole flight (a global spline, the truth JSON built in memory)
FLIGHT_BEFORE = "7afc2c8"


def run_simulate_flight(sizes=(1_000_000, 3_000_000), after_only=(10_000_000,)) -> list[dict]:
    """``simulate flight --kind dynamic`` (100 Hz: the CSV, STEM.truth.csv and STEM.truth.json) with this tree
    ("after": generated and written in blocks) and with commit :data:`FLIGHT_BEFORE` ("before": the whole flight at
    once), at ``after_only`` with this tree alone (the "before" would need about 25 GB there)."""

    def argv(out, rows):
        return ["simulate", "flight", "--kind", "dynamic", "--out", str(out), "--duration", f"{(rows - 1) / 100:.9g}"]

    return _run_simulator("flight", FLIGHT_BEFORE, lambda o, r: argv(o, r) + ["--seed", "1"], sizes, after_only, 1)


#: the commit whose ``simulate gfimu-turntable`` generated the whole data set (about 1.6 kB per row checked)
GFIMU_BEFORE = "e3ae9d7"


def _gfimu_argv(out: Path, rows: int) -> list[str]:
    """``optinav simulate gfimu-turntable`` of ``rows`` samples: the built-in 10-accelerometer array, the six
    cases (three mountings, rates 0.5 and 1.0 rad/s) at 100 Hz, ``--duration`` set to ``rows / 600`` s per case."""
    return ["simulate", "gfimu-turntable", "--duration", f"{rows / 600:.9g}", "--seed", "1", "--out", str(out)]


def run_simulate_gfimu(sizes=(1_000_000, 3_000_000), after_only=(10_000_000,)) -> list[dict]:
    """``simulate gfimu-turntable`` (CSV, :func:`_gfimu_argv`; a header line, no comment lines) with this tree
    ("after": generated and written in blocks) and with commit :data:`GFIMU_BEFORE` ("before": the whole data set
    at once), at ``after_only`` with this tree alone (the "before" would need about 16 GB there)."""
    return _run_simulator("gfimu-turntable", GFIMU_BEFORE, _gfimu_argv, sizes, after_only, 0)


def run_calibrate_gfimu(sizes=(1_000_000, 3_000_000)) -> list[dict]:
    """Peak RSS and wall time of ``optinav calibrate gfimu`` (``--builtin cylinder10``) on the CSV of
    :func:`_gfimu_argv` at each row count (written by this tree), with this tree ("after") and with commit
    :data:`GFIMU_BEFORE` ("before"); ``csv_bytes`` is the file's size."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), GFIMU_BEFORE)
        for rows in sizes:
            data = Path(tmp) / f"gfimu{rows}.csv"
            _run(ROOT / "src", _gfimu_argv(data, rows))
            n = _rows_of(data) + 2
            for version, src in versions.items():
                argv = ["calibrate", "gfimu", str(data), "--builtin", "cylinder10", "--out", str(Path(tmp) / "r.json")]
                peak, wall, _ = _run(src, argv)
                size = data.stat().st_size
                out.append(
                    {
                        "method": f"calibrate gfimu ({version})",
                        "rows": n,
                        "peak_mib": peak,
                        "wall_s": wall,
                        "csv_bytes": size,
                    }
                )
                print(f"calibrate gfimu ({version}): {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
            data.unlink()
    return out


def run_calibrate_rins(sizes=(1_000_000, 3_000_000, 10_000_000)) -> list[dict]:
    """Peak RSS and wall time of ``optinav calibrate rins`` (default options: lm, 10 Hz residual epochs) and of
    ``optinav apply`` of its result on the ``simulate rins`` CSV of :func:`_rins_argv` at each row count, this tree
    (both streamed: two passes over the file); ``csv_bytes`` is the session's size. The files are removed after
    each size."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for rows in sizes:
            d = Path(tmp) / str(rows)
            d.mkdir()
            data, res = d / f"rins{rows}.csv", d / "result.json"
            _run(ROOT / "src", _rins_argv(data, rows))
            n = _rows_of(data)
            for name, argv in (
                ("calibrate rins", ["calibrate", "rins", str(data), "--out", str(res)]),
                ("apply (rins)", ["apply", str(res), str(data), "--out", str(d / "attitude.csv")]),
            ):
                peak, wall, _ = _run(ROOT / "src", argv)
                row = {"method": name, "rows": n, "peak_mib": peak, "wall_s": wall, "csv_bytes": data.stat().st_size}
                out.append(row)
                print(f"{name}: {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
            shutil.rmtree(d)
    return out


#: the commit whose ``attitude --report`` read the whole log (the "before" of :func:`run_attitude_report`)
REPORT_BEFORE = "0d7719b"


def run_attitude_report(sizes=(1_000_000, 3_000_000)) -> list[dict]:
    """Peak RSS and wall time of ``optinav attitude LOG --report DIR`` on the simulated accel-multipos log of each
    row count, with this tree ("after": streamed, the figure every k-th row) and with commit
    :data:`REPORT_BEFORE` ("before": the whole log read at once)."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), REPORT_BEFORE)
        for rows in sizes:
            d = Path(tmp) / str(rows)
            d.mkdir()
            _run(ROOT / "src", _steps(d, rows)[0][1])
            n = _rows_of(d / f"log{rows}.csv")
            for version, src in versions.items():
                argv = [
                    "attitude",
                    str(d / f"log{rows}.csv"),
                    "--out",
                    str(d / "att.csv"),
                    "--report",
                    str(d / version),
                ]
                peak, wall, _ = _run(src, argv)
                out.append({"method": f"attitude --report ({version})", "rows": n, "peak_mib": peak, "wall_s": wall})
                print(f"attitude --report ({version}): {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
            shutil.rmtree(d)
    return out


#: main before ``apply`` of a gfimu result and ``batch attitude`` streamed (the "before" of the two runners below)
APPLY_BATCH_BEFORE = "165ef2b"


def run_apply_gfimu(sizes=(1_000_000, 3_000_000, 10_000_000)) -> list[dict]:
    """Peak RSS and wall time of ``optinav apply RESULT.json DATA --out OUT.csv`` for a gfimu result (calibrated
    by this tree on a 60 000-row data set) on the CSV of :func:`_gfimu_argv` at each row count (written by this
    tree; its t and f1..f10 are solved, rate method integration), with this tree ("after": read, solved and
    written in blocks) and with commit :data:`APPLY_BATCH_BEFORE` ("before": the whole table at once)."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), APPLY_BATCH_BEFORE)
        res, small = Path(tmp) / "r.json", Path(tmp) / "small.csv"
        _run(ROOT / "src", _gfimu_argv(small, 60_000))
        _run(ROOT / "src", ["calibrate", "gfimu", str(small), "--builtin", "cylinder10", "--out", str(res)])
        for rows in sizes:
            data, motion = Path(tmp) / f"gfimu{rows}.csv", Path(tmp) / "motion.csv"
            _run(ROOT / "src", _gfimu_argv(data, rows))
            n = _rows_of(data) + 2
            for version, src in versions.items():
                peak, wall, _ = _run(src, ["apply", str(res), str(data), "--out", str(motion)])
                rec = {"method": f"apply gfimu ({version})", "rows": n, "peak_mib": peak, "wall_s": wall}
                out.append({**rec, "csv_bytes": data.stat().st_size})
                print(f"apply gfimu ({version}): {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
                motion.unlink()
            data.unlink()
    return out


def run_batch_attitude(sizes=(1_000_000, 3_000_000), after_only=(10_000_000,)) -> list[dict]:
    """Peak RSS and wall time of ``optinav batch attitude DIR --workers 0`` (the unit in the measured process) on a
    folder holding one unit, the simulated accel-multipos log of :func:`_steps` at each row count, with this tree
    ("after": the unit streamed, no per-unit output) and with commit :data:`APPLY_BATCH_BEFORE` ("before": the
    whole log read and estimated at once), at ``after_only`` with this tree alone."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), APPLY_BATCH_BEFORE)
        for rows in (*sizes, *after_only):
            d = Path(tmp) / str(rows)
            units = d / "units"
            units.mkdir(parents=True)
            _run(ROOT / "src", _steps(d, rows)[0][1])
            (d / f"log{rows}.csv").rename(units / f"log{rows}.csv")
            n = _rows_of(units / f"log{rows}.csv")
            for version, src in versions.items():
                if version == "before" and rows in after_only:
                    continue
                argv = ["batch", "attitude", str(units), "--workers", "0", "--fresh", "--out", str(d / "res.csv")]
                peak, wall, _ = _run(src, argv)
                out.append({"method": f"batch attitude ({version})", "rows": n, "peak_mib": peak, "wall_s": wall})
                print(f"batch attitude ({version}): {n} rows, peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
            shutil.rmtree(d)
    return out


#: main before binary files were read in row blocks (the "before" of :func:`run_binary_formats`)
BINARY_BEFORE = "a2fedd0"
#: the binary layouts of :func:`run_binary_formats` (file name → extra arguments of the commands)
BINARY_FORMATS = {
    "log.h5": [],
    "log.npz": [],
    "log.parquet": [],
    "log_v73.mat": [],
    "log_v7.mat": [],
    "log.npy": ["--columns", "t,ax,ay,az,gx,gy,gz"],
}


def _write_binary(d: Path, rows: int) -> dict[str, Path]:
    """The simulated accel-multipos session of about ``rows`` rows (100 Hz, seed 1) in each layout of
    :data:`BINARY_FORMATS`, written in blocks (the NPZ from arrays gathered here: numpy writes it whole): HDF5
    datasets ``t``, ``acc``, ``gyro`` (chunked); NPZ arrays of the same names; Parquet columns t, ax … gz (row
    groups of 1 M rows); a MATLAB v7.3 file (``t`` N×1, ``acc``/``gyro`` N×3, stored column-major); one N×7 .npy
    matrix; a compressed MATLAB v7 file (:func:`_write_mat7`)."""
    import h5py
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    from optinav.multipos.simulate import SessionStream

    dwell = (rows / 100.0 - 10.0 - 4.0 * 12) / 12
    stream = SessionStream("paper12", dwell_s=dwell, rate_hz=100.0, rng=1)
    n = stream.n
    paths = {k: d / k for k in BINARY_FORMATS}
    t_all, acc_all, gyr_all = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    names = ["t", "ax", "ay", "az", "gx", "gy", "gz"]
    npy = np.lib.format.open_memmap(paths["log.npy"], mode="w+", dtype=float, shape=(n, 7))
    with h5py.File(paths["log.h5"], "w") as h5, h5py.File(paths["log_v73.mat"], "w", userblock_size=512) as mat:
        h5s = {
            k: h5.create_dataset(k, shape=(n,) + s, dtype=float, chunks=(65536,) + s)
            for k, s in (("t", ()), ("acc", (3,)), ("gyro", (3,)))
        }
        mats = {
            k: mat.create_dataset(k, shape=(w, n), dtype=float, chunks=(w, 65536))
            for k, w in (("t", 1), ("acc", 3), ("gyro", 3))
        }
        for ds in mats.values():
            ds.attrs["MATLAB_class"] = np.bytes_("double")
        writer = pq.ParquetWriter(paths["log.parquet"], pa.schema([(c, pa.float64()) for c in names]))
        a, buf = 0, []
        for log in stream.log_blocks():
            b = a + len(log)
            t_all[a:b], acc_all[a:b], gyr_all[a:b] = log.t, log.acc, log.gyr
            for k, v in (("t", log.t), ("acc", log.acc), ("gyro", log.gyr)):
                h5s[k][a:b] = v
                mats[k][:, a:b] = np.atleast_2d(v.T)
            npy[a:b] = np.column_stack([log.t, log.acc, log.gyr])
            buf.append(pa.table(dict(zip(names, np.column_stack([log.t, log.acc, log.gyr]).T))))
            if sum(x.num_rows for x in buf) >= 1_000_000 or b == n:
                writer.write_table(pa.concat_tables(buf), row_group_size=1 << 20)
                buf = []
            a = b
        writer.close()
    npy.flush()
    del npy
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    with open(paths["log_v73.mat"], "r+b") as fh:
        fh.write(header.ljust(116, b" ") + bytes(8) + b"\x00\x02IM")
    np.savez(paths["log.npz"], t=t_all, acc=acc_all, gyro=gyr_all)
    _write_mat7(paths["log_v7.mat"], t_all, acc_all, gyr_all)
    return paths


def _write_mat7(path: Path, t, acc, gyr) -> None:
    """A MATLAB v7 file (v5 layout, compressed, as MATLAB's default ``save``): ``t`` N×1, ``acc``, ``gyro`` N×3."""
    import scipy.io

    scipy.io.savemat(path, {"t": t[:, None], "acc": acc, "gyro": gyr}, do_compression=True)


def run_binary_formats(rows: int = 10_000_000, before=("log.h5", "log.parquet")) -> list[dict]:
    """Peak RSS and wall time of ``optinav attitude FILE --frame ENU`` and ``optinav calibrate accel FILE`` on the
    session of :func:`_write_binary` (about ``rows`` rows) in each binary layout, with this tree ("after": read
    in row blocks, :mod:`optinav.io.arrayblocks`) and, for the layouts in ``before``, with commit
    :data:`BINARY_BEFORE` (the file read whole by its library, then cut)."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        versions = _versions(Path(tmp), BINARY_BEFORE)
        d = Path(tmp) / "data"
        d.mkdir()
        paths = _write_binary(d, rows)
        for name, extra in BINARY_FORMATS.items():
            path = paths[name]
            for version, src in versions.items():
                if version == "before" and name not in before:
                    continue
                for cmd, argv in (
                    ("attitude", ["attitude", str(path), "--frame", "ENU", "--out", str(d / "att.csv"), *extra]),
                    (
                        "calibrate accel",
                        [
                            "calibrate",
                            "accel",
                            str(path),
                            "--latitude",
                            "38.88",
                            "--height",
                            "35",
                            "--out",
                            str(d / "r.json"),
                            *extra,
                        ],
                    ),
                ):
                    peak, wall, _ = _run(src, argv)
                    rec = {"method": f"{cmd} {name} ({version})", "rows": rows, "peak_mib": peak, "wall_s": wall}
                    out.append({**rec, "file_bytes": path.stat().st_size})
                    print(f"{rec['method']}: peak {peak:.0f} MiB, {wall:.0f} s", file=sys.stderr)
                    for f in (d / "att.csv", d / "r.json"):
                        f.unlink(missing_ok=True)
    return out


if __name__ == "__main__":
    # python benchmarks/bench_memory.py RESULTS.json > results_memory.md
    # python benchmarks/bench_memory.py --after RESULTS.json NOTE: re-measure this tree's rows in RESULTS.json
    # python benchmarks/bench_memory.py --attitude-modes [--quick] MODES.json: run the attitude modes, write
    # MODES.json and print their table
    import json

    if sys.argv[1] == "--after":
        # python benchmarks/bench_memory.py --after RESULTS.json NOTE: this tree's rows re-measured in place
        remeasure(Path(sys.argv[2]), sys.argv[3])
    elif sys.argv[1] == "--simulate":
        # python benchmarks/bench_memory.py --simulate SIMULATE.json [ROWS ...]: the streamed simulator alone
        sizes = tuple(int(x) for x in sys.argv[3:]) or (1_000_000, 3_000_000, 10_000_000)
        Path(sys.argv[2]).write_text(json.dumps(run_simulate(sizes), indent=1) + "\n")
    elif sys.argv[1] == "--simulate-static":
        # python benchmarks/bench_memory.py --simulate-static STATIC.json: simulate static before/after
        Path(sys.argv[2]).write_text(json.dumps(run_simulate_static(), indent=1) + "\n")
    elif sys.argv[1] == "--simulate-rins":
        # python benchmarks/bench_memory.py --simulate-rins RINS.json: simulate rins before/after
        Path(sys.argv[2]).write_text(json.dumps(run_simulate_rins(), indent=1) + "\n")
    elif sys.argv[1] == "--simulate-flight":
        # python benchmarks/bench_memory.py --simulate-flight FLIGHT.json: simulate flight before/after
        Path(sys.argv[2]).write_text(json.dumps(run_simulate_flight(), indent=1) + "\n")
    elif sys.argv[1] == "--simulate-gfimu":
        # python benchmarks/bench_memory.py --simulate-gfimu GFIMU.json: simulate gfimu-turntable before/after
        Path(sys.argv[2]).write_text(json.dumps(run_simulate_gfimu(), indent=1) + "\n")
    elif sys.argv[1] == "--calibrate-gfimu":
        # python benchmarks/bench_memory.py --calibrate-gfimu CAL.json [ROWS ...]: calibrate gfimu before/after
        sizes = tuple(int(x) for x in sys.argv[3:]) or (1_000_000, 3_000_000, 10_000_000)
        Path(sys.argv[2]).write_text(json.dumps(run_calibrate_gfimu(sizes), indent=1) + "\n")
    elif sys.argv[1] == "--calibrate-rins":
        # python benchmarks/bench_memory.py --calibrate-rins CAL.json [ROWS ...]: calibrate rins and apply, this tree
        sizes = tuple(int(x) for x in sys.argv[3:]) or (1_000_000, 3_000_000, 10_000_000)
        Path(sys.argv[2]).write_text(json.dumps(run_calibrate_rins(sizes), indent=1) + "\n")
    elif sys.argv[1] == "--attitude-report":
        # python benchmarks/bench_memory.py --attitude-report REPORT.json [ROWS ...]: attitude --report, before/after
        sizes = tuple(int(x) for x in sys.argv[3:]) or (1_000_000, 3_000_000)
        Path(sys.argv[2]).write_text(json.dumps(run_attitude_report(sizes), indent=1) + "\n")
    elif sys.argv[1] == "--apply-gfimu":
        # python benchmarks/bench_memory.py --apply-gfimu APPLY.json [ROWS ...]: apply of a gfimu result, before/after
        sizes = tuple(int(x) for x in sys.argv[3:]) or (1_000_000, 3_000_000, 10_000_000)
        Path(sys.argv[2]).write_text(json.dumps(run_apply_gfimu(sizes), indent=1) + "\n")
    elif sys.argv[1] == "--binary-formats":
        # python benchmarks/bench_memory.py --binary-formats BINARY.json [ROWS]: attitude and calibrate accel on
        # HDF5, NPZ, Parquet, MATLAB v7.3 and NPY logs, this tree (and before on HDF5 and Parquet)
        rows = int(sys.argv[3]) if len(sys.argv) > 3 else 10_000_000
        Path(sys.argv[2]).write_text(json.dumps(run_binary_formats(rows), indent=1) + "\n")
    elif sys.argv[1] == "--batch-attitude":
        # python benchmarks/bench_memory.py --batch-attitude BATCH.json: one unit of 1 M and 3 M rows before/after,
        # 10 M rows after
        Path(sys.argv[2]).write_text(json.dumps(run_batch_attitude(), indent=1) + "\n")
    elif sys.argv[1] == "--merge-simulate":
        # python benchmarks/bench_memory.py --merge-simulate RESULTS.json SIMULATE.json NOTE: its 1 M and 3 M runs
        # become the "after" rows of simulate accel-multipos in RESULTS.json
        merge_simulate(Path(sys.argv[2]), json.loads(Path(sys.argv[3]).read_text()), sys.argv[4])
    elif sys.argv[1] == "--attitude-modes":
        quick = "--quick" in sys.argv
        res = run_attitude_modes(quick)
        Path(sys.argv[-1]).write_text(json.dumps(res, indent=1) + "\n")
        print(markdown_modes(res), end="")
    else:
        print(markdown(json.loads(Path(sys.argv[1]).read_text())), end="")
