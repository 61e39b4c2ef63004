"""A bad input file is reported before the heavy libraries load (issue 17, item 7: a bad-file error within 1 s of
start). Timing is a benchmark (benchmarks/bench_startup.py); this checks the property that makes it fast: when the
one-line read error is printed, numba, scipy and matplotlib are not in ``sys.modules``."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import optinav

HEAVY = ("numba", "scipy", "matplotlib")

# runs the CLI in-process and reports the exit code, stderr's last line and the heavy packages then loaded
_PROBE = """
import contextlib, io, json, sys
from optinav.cli.main import main
err = io.StringIO()
with contextlib.redirect_stderr(err):
    try:
        rc = main(sys.argv[1:])
    except SystemExit as exc:
        rc = exc.code
loaded = sorted({m.split(".")[0] for m in sys.modules} & set(%r))
print(json.dumps({"rc": rc, "err": err.getvalue().strip().splitlines()[-1:], "loaded": loaded}))
""" % (HEAVY,)

BAD_FILES = {
    "text_cell": "t,ax,ay,az,gx,gy,gz\n0,1,x,3,0,0,0\n",
    "ragged_row": "t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0\n",
    "too_short": "t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n",
}


def _probe(args):
    env = {**os.environ, "PYTHONPATH": str(Path(optinav.__file__).parents[1]), "OPTINAV_QUIET": "1"}
    proc = subprocess.run([sys.executable, "-c", _PROBE, *args], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "extra", [[], ["--method", "ferraris"], ["--no-gyro"]], ids=["multipos", "ferraris", "acc-only"]
)
@pytest.mark.parametrize("kind", sorted(BAD_FILES))
def test_calibrate_reports_a_bad_file_before_heavy_imports(tmp_path, kind, extra):
    bad = tmp_path / "bad.csv"
    bad.write_text(BAD_FILES[kind])
    r = _probe(["calibrate", "accel", str(bad), "--out", str(tmp_path / "o.json"), *extra])
    assert r["rc"] == 2
    assert r["err"] and r["err"][0].startswith("optinav: error:") and "Traceback" not in r["err"][0]
    assert r["loaded"] == [], f"imported before the read error: {r['loaded']}"
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize(
    "extra",
    [[], ["--offline"], ["--method", "mekf"], ["--report", "REP"]],
    ids=["streamed", "offline", "mekf", "report"],
)
@pytest.mark.parametrize("kind", ["text_cell", "ragged_row"])  # two rows are a log attitude accepts
def test_attitude_reports_a_bad_file_before_heavy_imports(tmp_path, kind, extra):
    bad = tmp_path / "bad.csv"
    bad.write_text(BAD_FILES[kind])
    extra = [str(tmp_path / "rep") if x == "REP" else x for x in extra]
    r = _probe(["attitude", str(bad), "--out", str(tmp_path / "o.csv"), *extra])
    assert r["rc"] == 2
    assert r["err"] and r["err"][0].startswith("optinav: error:") and "Traceback" not in r["err"][0]
    assert r["loaded"] == [], f"imported before the read error: {r['loaded']}"
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("kind", ["text_cell", "ragged_row"])
def test_allan_reports_a_bad_file_before_heavy_imports(tmp_path, kind):
    """``optinav allan`` streams the file into the Allan sums: the read error comes before scipy loads (the fit)."""
    bad = tmp_path / "bad.csv"
    bad.write_text(BAD_FILES[kind])
    r = _probe(["allan", str(bad), "--out", str(tmp_path / "o.json")])
    assert r["rc"] == 2
    assert r["err"] and r["err"][0].startswith("optinav: error:") and "Traceback" not in r["err"][0]
    assert r["loaded"] == [], f"imported before the read error: {r['loaded']}"
    assert not (tmp_path / "o.json").exists()


def test_attitude_checks_its_options_before_reading(tmp_path):
    """A bad estimator option is still refused before the file is read (here a file that does not exist)."""
    r = _probe(
        [
            "attitude",
            str(tmp_path / "missing.csv"),
            "--out",
            str(tmp_path / "o.csv"),
            "--option",
            "gain=-1",
            "--method",
            "gd",
        ]
    )
    assert r["rc"] == 2 and "gain" in r["err"][0], r
    assert r["loaded"] == []


def test_the_probe_sees_heavy_imports(tmp_path):
    """The check can fail: a command that goes on to real work (here a simulation) loads numba."""
    r = _probe(
        [
            "simulate",
            "accel-multipos",
            "--out",
            str(tmp_path / "s.csv"),
            "--scheme",
            "six",
            "--dwell",
            "3",
            "--seed",
            "1",
        ]
    )
    assert r["rc"] == 0 and "numba" in r["loaded"]
