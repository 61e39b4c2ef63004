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

# runs CLI commands in turn in one process (the argument: a JSON list of argument lists) and reports for each the
# exit code, stderr's last line and the heavy packages loaded by then (one interpreter start for all the cases)
_PROBE = """
import contextlib, io, json, sys
from optinav.cli.main import main
out = []
for args in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            rc = main(args)
        except SystemExit as exc:
            rc = exc.code
    loaded = sorted({m.split(".")[0] for m in sys.modules} & set(%r))
    out.append({"rc": rc, "err": err.getvalue().strip().splitlines()[-1:], "loaded": loaded})
print(json.dumps(out))
""" % (HEAVY,)

BAD_FILES = {
    "text_cell": "t,ax,ay,az,gx,gy,gz\n0,1,x,3,0,0,0\n",
    "ragged_row": "t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0\n",
    "too_short": "t,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n",
}


def _probe_all(cases):
    env = {**os.environ, "PYTHONPATH": str(Path(optinav.__file__).parents[1]), "OPTINAV_QUIET": "1"}
    cmd = [sys.executable, "-c", _PROBE, json.dumps(cases)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _probe(args):
    return _probe_all([args])[0]


CALIBRATE_EXTRAS = {"multipos": [], "ferraris": ["--method", "ferraris"], "acc-only": ["--no-gyro"]}
ATTITUDE_EXTRAS = {"streamed": [], "offline": ["--offline"], "mekf": ["--method", "mekf"], "report": ["--report"]}


def _cases(base: Path) -> dict:
    """Every bad-file command of this module, by test case, each with its own file and output."""
    cases = {}
    for kind, text in BAD_FILES.items():
        (base / f"{kind}.csv").write_text(text)
    for kind in BAD_FILES:
        for name, extra in CALIBRATE_EXTRAS.items():
            out = base / f"calibrate-{kind}-{name}.json"
            cases["calibrate", kind, name] = [
                "calibrate",
                "accel",
                str(base / f"{kind}.csv"),
                "--out",
                str(out),
                *extra,
            ]
    for kind in ("text_cell", "ragged_row"):  # two rows are a log attitude accepts
        for name, extra in ATTITUDE_EXTRAS.items():
            out = base / f"attitude-{kind}-{name}.csv"
            extra = extra + [str(base / f"rep-{kind}")] if name == "report" else extra
            cases["attitude", kind, name] = ["attitude", str(base / f"{kind}.csv"), "--out", str(out), *extra]
        cases["allan", kind, ""] = ["allan", str(base / f"{kind}.csv"), "--out", str(base / f"allan-{kind}.json")]
    return cases


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """The bad-file commands run in turn in one process: (its results by case, the argument lists). A case run
    after one that loaded a heavy package could not show its own imports; it is run again alone."""
    cases = _cases(tmp_path_factory.mktemp("bad-files"))
    results = dict(zip(cases, _probe_all(list(cases.values()))))
    clean = True
    for key, r in results.items():
        if not clean:
            results[key] = _probe(cases[key])
        clean = clean and not r["loaded"]
    return results, cases


def _check_refused(probed, key):
    results, cases = probed
    r = results[key]
    assert r["rc"] == 2
    assert r["err"] and r["err"][0].startswith("optinav: error:") and "Traceback" not in r["err"][0]
    assert r["loaded"] == [], f"imported before the read error: {r['loaded']}"
    assert not Path(cases[key][cases[key].index("--out") + 1]).exists()


@pytest.mark.parametrize("extra", sorted(CALIBRATE_EXTRAS))
@pytest.mark.parametrize("kind", sorted(BAD_FILES))
def test_calibrate_reports_a_bad_file_before_heavy_imports(probed, kind, extra):
    _check_refused(probed, ("calibrate", kind, extra))


@pytest.mark.parametrize("extra", sorted(ATTITUDE_EXTRAS))
@pytest.mark.parametrize("kind", ["text_cell", "ragged_row"])  # two rows are a log attitude accepts
def test_attitude_reports_a_bad_file_before_heavy_imports(probed, kind, extra):
    _check_refused(probed, ("attitude", kind, extra))


@pytest.mark.parametrize("kind", ["text_cell", "ragged_row"])
def test_allan_reports_a_bad_file_before_heavy_imports(probed, kind):
    """``optinav allan`` streams the file into the Allan sums: the read error comes before scipy loads (the fit)."""
    _check_refused(probed, ("allan", kind, ""))


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
