"""Bad input and OS faults through the CLI, in-process: every case ends in a one-line error with exit 2 (or
succeeds), and no input file is changed (issue 17)."""

import errno
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core import files
from optinav.errors import OptinavError


def digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def one_line_error(capsys, *needles) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("optinav: error:"), err
    for n in needles:
        assert n in err, err
    return err


def _data(tmp_path) -> Path:
    p = tmp_path / "session.csv"
    p.write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{k / 100},0,0,9.8,0,0,0\n" for k in range(50)))
    return p


def _damaged(res, path: tuple, value, tmp_path) -> Path:
    """A copy of the result file ``res`` (tmp_path/bad.json) with the value at ``path`` (field name, then keys or
    indices inside its value) replaced by ``value``."""
    d = json.loads(Path(res).read_text())
    if len(path) == 1:
        d["fields"][path[0]]["value"] = value
    else:
        t = d["fields"][path[0]]["value"]
        for k in path[1:-1]:
            t = t[k]
        t[path[-1]] = value
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    return bad


# --- inputs are never overwritten -----------------------------------------------------------------------------


@pytest.mark.parametrize("link", ["same", "symlink", "hardlink"])
def test_out_onto_an_input_is_refused(tmp_path, capsys, cube, link):
    target = cube
    if link == "symlink":
        target = tmp_path / "alias.json"
        target.symlink_to(cube)
    elif link == "hardlink":
        target = tmp_path / "hard.json"
        os.link(cube, target)
    before = digest(cube)
    assert main(["gfimu", "analyze", str(cube), "--out", str(target)]) == 2
    one_line_error(capsys, "is the input", "choose another --out")
    assert digest(cube) == before


def test_apply_and_calibrate_refuse_out_onto_inputs(tmp_path, capsys):
    data = _data(tmp_path)
    result = tmp_path / "result.json"
    result.write_text("{}")
    sections = tmp_path / "sections.json"
    sections.write_text('{"x_p": [0, 1]}')
    before = {p: digest(p) for p in (data, result, sections)}
    for argv in (
        ["apply", str(result), str(data), "--out", str(data)],
        ["apply", str(result), str(data), "--out", str(result)],
        ["calibrate", "accel", str(data), "--method", "ferraris", "--sections", str(sections), "--out", str(sections)],
    ):
        assert main(argv) == 2, argv
        one_line_error(capsys, "is the input")
    assert {p: digest(p) for p in before} == before


def test_out_onto_a_file_of_another_kind_is_refused(tmp_path, capsys):
    """--out replaced any existing file that was not an input of the same command: a simulated log by an attitude
    table, a simulator's truth by a calibration, a raw log by apply or simulate, a sections list by a result, all
    with exit 0. An output is replaced only by the command's own kind; a rerun still replaces its own."""
    # a short session (5 s poses): which --out a command may replace does not depend on the length of its input
    assert main(["--quiet", "simulate", "accel-multipos", "--dwell", "5", "--out", str(tmp_path / "mp.csv")]) == 0
    assert main(["--quiet", "simulate", "flight", "--duration", "20", "--out", str(tmp_path / "fl.csv")]) == 0
    raw = _data(tmp_path)
    sections = tmp_path / "sections.json"
    sections.write_text('{"x_p": {"start": 0, "end": 10}}')
    keep = {p: digest(p) for p in (tmp_path / "mp.csv", tmp_path / "mp.truth.json", raw, sections)}
    capsys.readouterr()
    for argv in (
        ["attitude", str(tmp_path / "fl.csv"), "--out", str(tmp_path / "mp.csv")],
        ["calibrate", "accel", str(tmp_path / "mp.csv"), "--out", str(tmp_path / "mp.truth.json")],
        ["calibrate", "accel", str(tmp_path / "mp.csv"), "--out", str(sections)],
        ["simulate", "flight", "--duration", "20", "--out", str(raw)],
        ["attitude", str(tmp_path / "fl.csv"), "--out", str(raw)],
    ):
        assert main(["--quiet", *argv]) == 2, argv
        one_line_error(capsys, "is not a file this command writes", "choose another --out")
    assert {p: digest(p) for p in keep} == keep
    r, a = tmp_path / "r.json", tmp_path / "a.csv"
    for _ in range(2):  # reruns replace their own outputs
        assert main(["--quiet", "calibrate", "accel", str(tmp_path / "mp.csv"), "--out", str(r)]) == 0
        assert main(["--quiet", "attitude", str(tmp_path / "fl.csv"), "--out", str(a)]) == 0
        assert main(["--quiet", "apply", str(r), str(tmp_path / "mp.csv"), "--out", str(tmp_path / "ap.csv")]) == 0
    assert main(["--quiet", "apply", str(r), str(tmp_path / "mp.csv"), "--out", str(a)]) == 2
    capsys.readouterr()


def test_foreign_sidecar_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "x.csv"
    truth = tmp_path / "x.truth.csv"
    truth.write_text("my own measurements\n1,2,3\n")
    before = digest(truth)
    assert main(["simulate", "flight", "--out", str(out), "--duration", "1"]) == 2
    one_line_error(capsys, "x.truth.csv exists and was not written by optinav")
    assert digest(truth) == before and not out.exists()
    truth.unlink()
    for _ in range(2):  # a truth optinav wrote is replaced by the next run
        assert main(["simulate", "flight", "--out", str(out), "--duration", "1"]) == 0
    assert truth.read_text().startswith("t,qw,qx,qy,qz\n")
    capsys.readouterr()
    before = digest(out)
    assert main(["attitude", str(out), "--out", str(out)]) == 2
    one_line_error(capsys, "is the input")
    assert digest(out) == before


def test_own_truth_sidecar_is_replaced(tmp_path, capsys):
    out = tmp_path / "tt.npz"
    argv = ["simulate", "gfimu-turntable", "--out", str(out), "--duration", "0.2"]
    assert main(argv) == 0
    assert main(argv) == 0  # a second run replaces the truth optinav wrote
    truth = json.loads((tmp_path / "tt.truth.json").read_text())
    assert truth["schema"] == "optinav.gfimu.truth"
    (tmp_path / "tt.truth.json").write_text('{"mine": 1}')
    assert main(argv) == 2
    one_line_error(capsys, "was not written by optinav")


# --- output checks before any work -----------------------------------------------------------------------------


def test_bad_output_locations(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    (tmp_path / "dir.json").mkdir()
    cases = [
        (tmp_path / "dir.json", "is a folder"),
        (blocker / "a.json", "is a file"),
        (blocker / "s" / "a.json", "lies below the file"),
        (tmp_path / "nope" / "a.json", "does not exist"),
    ]
    for out, why in cases:
        assert main(["gfimu", "analyze", "--builtin", "cylinder10", "--out", str(out)]) == 2
        one_line_error(capsys, why)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.json", "file"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_named_pipe_as_output_is_refused_not_replaced(tmp_path, capsys):
    """Every writer renamed its temporary file over a FIFO at --out: the pipe a reader waited on became a
    regular file, exit 0. The atomic writer refuses a pipe, socket or device."""
    import stat

    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    assert main(["gfimu", "analyze", "--builtin", "cylinder10", "--out", str(fifo)]) == 2
    one_line_error(capsys, "is a named pipe, not a file")
    os.mkfifo(tmp_path / "p.truth.json")  # where the truth is written beside the data: reading it blocked
    assert main(["simulate", "flight", "--kind", "static", "--duration", "2", "--out", str(tmp_path / "p.csv")]) == 2
    one_line_error(capsys, "is a named pipe, not a file")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and stat.S_ISFIFO(os.stat(tmp_path / "p.truth.json").st_mode)


# --- the atomic writer ------------------------------------------------------------------------------------------


def test_atomic_writer_keeps_the_old_file_on_failure(tmp_path, monkeypatch):
    out = tmp_path / "r.json"
    out.write_text("old")

    def full(*_a, **_k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(OptinavError, match="no space left on the device"):
        files.write_text(out, "new")
    assert out.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["r.json"]


def test_atomic_writer_replaces_a_symlink_not_its_target(tmp_path):
    target = tmp_path / "target.txt"
    target.write_text("keep")
    link = tmp_path / "out.txt"
    link.symlink_to(target)
    files.write_text(link, "new")
    assert target.read_text() == "keep" and link.read_text() == "new" and not link.is_symlink()
    assert oct(link.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


def test_file_size_limit_is_a_one_line_error(tmp_path):
    # a real write failure (EFBIG under ulimit -f), through the installed command in a subprocess
    import resource

    out = tmp_path / "a.json"
    env = {**os.environ, "PYTHONPATH": str(Path(files.__file__).parents[2])}
    proc = subprocess.run(
        [sys.executable, "-m", "optinav.cli.main", "gfimu", "analyze", "--builtin", "cylinder10", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (200, 200)),
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "file-size limit" in proc.stderr
    assert list(tmp_path.iterdir()) == []


def _run_cli(argv, **kw) -> subprocess.CompletedProcess:
    """The command in a subprocess (``python -m optinav.cli.main``), stderr captured as text."""
    env = {**os.environ, "PYTHONPATH": str(Path(files.__file__).parents[2])}
    cmd = [sys.executable, "-m", "optinav.cli.main", *argv]
    return subprocess.run(cmd, stderr=subprocess.PIPE, text=True, timeout=120, env=env, **kw)


SUN = ["sun", "--lat", "1", "--lon", "1", "--time", "2021-01-17T10:34:00Z"]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
@pytest.mark.parametrize("argv", [SUN, ["design"], ["gfimu", "analyze", "--builtin", "cylinder10"]])
def test_a_full_standard_output_is_a_one_line_error(argv):
    """``>/dev/full`` ended in "internal error: OSError [Errno 28]", exit 1 (the JSON of sun is written only when
    Python flushed at exit)."""
    with open("/dev/full", "w") as full:
        proc = _run_cli(argv, stdout=full)
    err = proc.stderr.strip()
    assert proc.returncode == 2, err
    assert err.splitlines()[-1] == (
        "optinav: error: cannot write to standard output: no space left on the device; "
        "redirect it to a file on a disk with free space"
    ), err
    assert "Traceback" not in err and "Exception ignored" not in err


def test_a_closed_standard_output_is_a_one_line_error(tmp_path):
    """``optinav sun ... >&-`` printed nothing and exited 0: the JSON asked for was lost without a word."""
    proc = _run_cli(SUN, preexec_fn=lambda: os.close(1), cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (
        "optinav: error: cannot write to standard output: it is closed; give the command one (a file, a pipe or "
        "/dev/null)"
    )


def test_a_closed_standard_error_keeps_the_exit_code_and_stdout_clean(tmp_path, counts_session):
    """``2>&-``: calibrate failed with an internal AttributeError (sys.stderr is None: no isatty), exit 1, and an
    error message went into standard output (print to a None file writes to stdout)."""
    _, data, _ = counts_session
    close, out = (lambda: os.close(2)), subprocess.PIPE
    proc = _run_cli(["calibrate", "accel", str(data), "--out", "r.json"], preexec_fn=close, stdout=out, cwd=tmp_path)
    assert proc.returncode == 0 and (tmp_path / "r.json").exists() and "internal error" not in proc.stdout
    proc = _run_cli(["report", "missing.json", "--out", "r"], preexec_fn=close, stdout=out, cwd=tmp_path)
    assert proc.returncode == 2 and proc.stdout == "", proc.stdout
    proc = _run_cli(SUN, preexec_fn=close, stdout=out, cwd=tmp_path)
    assert proc.returncode == 0 and json.loads(proc.stdout)


def test_a_reader_that_goes_away_ends_quietly():
    """``optinav sun ... | head``: not an error of optinav's (unchanged by the standard-output checks)."""
    with subprocess.Popen(
        [sys.executable, "-m", "optinav.cli.main", *SUN],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(Path(files.__file__).parents[2])},
    ) as proc:
        proc.stdout.close()  # the reader is gone before the command writes
        err = proc.stderr.read().decode()
        assert proc.wait(timeout=120) == 0 and err == "", err


# --- JSON inputs: every parser failure is one line --------------------------------------------------------------


@pytest.mark.parametrize(
    "content, why",
    [
        (b"[" * 100_000 + b"]" * 100_000, "nested"),
        (b'{"a":' * 200 + b"1" + b"}" * 200, "nested more than"),
        (b'{"schema": "optinav.calibration", "x": "\xff\xfe"}', "not UTF-8"),
        (b'{"version": ' + b"9" * 5000 + b"}", "not readable JSON"),
        (b'{"schema": ', "not valid JSON"),
    ],
)
def test_json_inputs_fail_in_one_line(tmp_path, capsys, content, why):
    bad = tmp_path / "bad.json"
    bad.write_bytes(content)
    data = _data(tmp_path)
    before = digest(data)
    for argv in (
        ["apply", str(bad), str(data), "--out", str(tmp_path / "o.csv")],
        ["gfimu", "analyze", str(bad)],
        [
            "--quiet",
            "calibrate",
            "accel",
            str(data),
            "--method",
            "ferraris",
            "--sections",
            str(bad),
            "--out",
            str(tmp_path / "r.json"),
        ],
    ):
        assert main(argv) == 2, argv
        one_line_error(capsys, why)
    assert digest(data) == before and not (tmp_path / "o.csv").exists()


# --- option ranges at parsing: one line, exit 2 ----------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, why",
    [
        (["sun", "--lat", "95", "--lon", "0", "--time", "2021-01-01T00:00:00Z"], "--lat: 95 is out of range"),
        (["sun", "--lat", "10", "--lon", "0", "--height", "1e7", "--time", "2021-01-01T00:00:00Z"], "--height"),
        (["simulate", "gfimu-turntable", "--out", "x.npz", "--noise", "-1"], "--noise: -1 is out of range"),
        (["simulate", "rins", "--nonorth", "0,0,0,0,0,0", "--cycles", "0", "--out", "x.npz"], "--cycles"),
        (["simulate", "rins", "--nonorth", "0,0,0,0,0,0", "--lat", "95", "--out", "x.npz"], "--lat"),
        (["simulate", "accel-multipos", "--out", "x.csv", "--dwell", "nan"], "not finite"),
        (["calibrate", "rins", "x.npz", "--lat", "-91", "--out", "r.json"], "--lat"),
        # these ended in "internal error" (ValueError, OverflowError) or named the library's rng/sigma
        (["reproduce", "core", "--quick", "--seed", "-1", "--out", "r1"], "--seed: -1 is out of range (must be >= 0)"),
        (["simulate", "flight", "--seed", "-1", "--out", "f.csv"], "--seed: -1 is out of range (must be >= 0)"),
        (["simulate", "flight", "--rate", "inf", "--out", "f.csv"], "--rate: 'inf' is not finite"),
        (["simulate", "flight", "--duration", "-5", "--out", "f.csv"], "--duration: -5 is out of range"),
        (["simulate", "static", "--hours", "1e300", "--out", "s.csv"], "--hours: 1e300 is out of range (must be > 0"),
        (["design", "--target-bias", "1e-300"], "--target-bias: 1e-300 is out of range (must be >= 1e-06"),
        (["design", "--target-scale", "1e-300"], "--target-scale: 1e-300 is out of range"),
        (["design", "--target-misalignment", "1e-300"], "--target-misalignment: 1e-300 is out of range"),
        (["design", "--target-gyro-bias", "1e-300"], "--target-gyro-bias: 1e-300 is out of range"),
        (["design", "--acc-noise-density", "1e300"], "--acc-noise-density: 1e300 is out of range (must be >= 1e-12"),
        (["design", "--gyro-noise-density", "1e300"], "--gyro-noise-density: 1e300 is out of range"),
        # --rest nan reached the library as data ("remove or interpolate the bad samples")
        (["calibrate", "accel", "x.csv", "--out", "r.json", "--rest", "nan", "5"], "--rest: 'nan' is not finite"),
        (["calibrate", "accel", "x.csv", "--out", "r.json", "--rest", "0", "inf"], "--rest: 'inf' is not finite"),
        (["calibrate", "accel", "x.csv", "--out", "r.json", "--rotation-angle", "nan"], "--rotation-angle: 'nan'"),
    ],
)
def test_out_of_range_options_are_one_line_argparse_errors(argv, why, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and why in err and "see optinav" in err, err


@pytest.mark.parametrize(
    "argv, why",
    [
        (["--target-bias", "1e-6", "--acc-noise-density", "10"], "bias target 1e-06 mg would need 2.6e+17 s"),
        (["--target-gyro-bias", "1e-6", "--gyro-noise-density", "1"], "gyro bias target 1e-06 deg/h would need"),
    ],
)
def test_design_targets_beyond_reach_are_named(argv, why, capsys):
    """Within the options' ranges a target can still need rest beyond any count (the dwell overflowed)."""
    assert main(["design", *argv]) == 2
    one_line_error(capsys, why, "more than 1e+12 s", "relax the target")


@pytest.mark.parametrize("key, value", [("accelerometer", 1e300), ("gyroscope", 1e300), ("accelerometer", 1e-300)])
def test_design_refuses_an_absurd_density_from_an_allan_file(tmp_path, capsys, key, value):
    """An Allan JSON with a noise density of 1e300 ended in "sigma contains … NaN" (an overflow in the plan)."""
    f = tmp_path / "allan.json"
    f.write_text(json.dumps({"kalibr": {"accelerometer_noise_density": 1e-3, "gyroscope_noise_density": 1e-4}}))
    d = json.loads(f.read_text())
    d["kalibr"][f"{key}_noise_density"] = value
    f.write_text(json.dumps(d))
    assert main(["design", "--allan", str(f)]) == 2
    one_line_error(capsys, f"the {key} noise density {value:g}", "is not in [1e-12", "allan.json")


# --- rins quality gates: wrong latitude, swapped encoders ------------------------------------------------------

RINS = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "100"]


@pytest.fixture(scope="module")
def rins_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("rins")
    data = d / "r.npz"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "rins",
                "--nonorth=-2e-4,-9e-4,-2e-3,7e-4,-8e-4,-9e-3",
                "--seed",
                "3",
                "--out",
                str(data),
                *RINS,
            ]
        )
        == 0
    )
    return data


def test_a_rins_result_with_a_value_replaced_inside_a_field_is_named(rins_file, tmp_path, capsys):
    """An angle as text, a negative std, a combination null or without a name, statements as a number made report
    fail with an internal TypeError/KeyError/ValueError."""
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "rins", str(rins_file), "--out", str(res)]) == 0
    cases = [
        (("angles", "theta_x"), "x", "angles.theta_x"),
        (("angles_std", "theta_x"), -1, "angles_std.theta_x"),
        (("combinations", 0), None, "combinations[0]"),
        (("combinations", 0, "name"), None, "combinations[0].name"),
        (("combinations", 1, "value"), [1.0], "combinations[1].value"),
        (("observability", "statements"), 1.5, "observability.statements"),
        (("p_used",), [1.0, 2.0], "p_used"),
    ]
    for path, value, where in cases:
        bad = _damaged(res, path, value, tmp_path)
        capsys.readouterr()
        assert main(["--quiet", "report", str(bad), "--out", str(tmp_path / "rep")]) == 2, where
        one_line_error(capsys, f"(field '{where}'", "pass an unmodified optinav result file")


@pytest.mark.parametrize("lat", ["-28.2", "25", "90"])
def test_rins_latitude_must_match_the_measured_earth_rate(rins_file, tmp_path, capsys, lat):
    # the file was recorded at 28.2°; the gyros measure it to ~0.02°, so 3° off or the other hemisphere is refused
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "rins", str(rins_file), "--lat", lat, "--out", str(out)]) == 2
    one_line_error(capsys, f"the latitude {float(lat):.4g}° disagrees with the 28.", "--lat")
    assert not out.exists()


def test_rins_swapped_encoders_are_refused(rins_file, tmp_path, capsys):
    import numpy as np

    d = dict(np.load(rins_file))
    d["alpha"], d["beta"] = d["beta"], d["alpha"]
    swapped = tmp_path / "swapped.npz"
    np.savez(swapped, **d)
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "rins", str(swapped), "--out", str(out)]) == 2
    one_line_error(capsys, "alpha/beta")
    assert not out.exists()
    assert main(["--quiet", "calibrate", "rins", str(rins_file), "--lat", "28.3", "--out", str(out)]) == 0


@pytest.mark.parametrize(
    "case, why",
    [
        ("flip gx", "the gimbal model does not fit this recording; check the gyro columns"),
        ("gyro deg", "57.3× the Earth rate"),
        ("gyro rate", "the gyro increments are not in rad"),
        ("encoders deg", "they are in degrees, not rad; write the encoder columns in rad"),
        ("flip gy", "the gyros turn 1× the encoder's angle about an axis 179° from the gimbal's"),
        ("swap gx gy", "about an axis 89"),
        ("flip beta", "move 1 (-180°) the gyros turn"),
        ("t in ms", "specific force of 0.001 g at rest"),
        ("t doubled", "specific force of 0.501 g at rest"),
    ],
)
def test_rins_gyro_and_encoder_mistakes_are_named(rins_file, tmp_path, capsys, case, why):
    """A gyro column's sign flipped passed the residual gate (73× the noise walk, limit 100)
    with every angle 82σ off; gyro increments in degrees or given as rates, and encoders in degrees, were refused
    with messages about the encoders or the rest; a time column in ms or doubled, about the gyro or --lat."""
    import numpy as np

    d = dict(np.load(rins_file))
    if case == "flip gx":  # the scheme that showed it (psins16, 20 s dwells): the flip shows in the residual
        src = tmp_path / "p.npz"
        argv = ["--quiet", "simulate", "rins", "--nonorth=-2e-4,-9e-4,-2e-3,7e-4,-8e-4,-9e-3", "--seed", "3"]
        assert main(argv + ["--align", "300", "--dwell", "20", "--out", str(src)]) == 0
        d = dict(np.load(src))
        d["dtheta_x"] = -d["dtheta_x"]
    elif case == "gyro deg":
        d.update({f"dtheta_{k}": np.degrees(d[f"dtheta_{k}"]) for k in "xyz"})
    elif case == "flip gy":
        d["dtheta_y"] = -d["dtheta_y"]
    elif case == "swap gx gy":
        d["dtheta_x"], d["dtheta_y"] = d["dtheta_y"], d["dtheta_x"]
    elif case == "flip beta":
        d["beta"] = -d["beta"]
    elif case == "gyro rate":
        h = float(np.median(np.diff(d["t"])))
        d.update({f"dtheta_{k}": d[f"dtheta_{k}"] / h for k in "xyz"})
    elif case.startswith("t "):  # were blamed on the gyro increments' unit and on --lat
        d["t"] = d["t"] * (1000.0 if case == "t in ms" else 2.0)
    else:
        d["alpha"], d["beta"] = np.degrees(d["alpha"]), np.degrees(d["beta"])
    bad = tmp_path / "bad.npz"
    np.savez(bad, **d)
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "rins", str(bad), "--out", str(out)]) == 2
    one_line_error(capsys, why)
    assert not out.exists()


# --- sun: the SPA's whole valid range, refused outside --------------------------------------------------------


def test_sun_beyond_datetime64_ns_range(capsys):
    import numpy as np

    from optinav.sky.sun import solar_position_deg

    # June solstice of 2300 and of 1600: declination = obliquity (23.4393° − 0.013°/century from J2000,
    # Meeus eq. 22.2 to first order) and a distance within perihelion/aphelion
    for year, eps in ((2300, 23.4393 - 0.0130 * 3), (1600, 23.4393 + 0.0130 * 4)):
        t = np.datetime64(f"{year}-06-10T00:00") + np.arange(0, 24 * 24, 3).astype("timedelta64[h]")
        r = solar_position_deg(t, 38.88, 121.5)
        assert np.max(r.declination) == pytest.approx(np.radians(eps), abs=np.radians(0.01))
        assert np.all((r.earth_sun_distance > 0.983) & (r.earth_sun_distance < 1.017))
        assert str(r.time[0]).startswith(f"{year}-06-10")
    assert main(["sun", "--lat", "38.88", "--lon", "121.5", "--time", "2300-06-21T04:00:00Z"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["time_utc"] == "2300-06-21T04:00:00.000Z" and 0.98 < out["earth_sun_distance_au"] < 1.02
    assert main(["sun", "--lat", "38.88", "--lon", "121.5", "--time", "7000-01-01T00:00:00Z"]) == 2
    one_line_error(capsys, "outside the years -2000 to 6000")


# --- apply refuses a calibration no sensor can have -------------------------------------------------------------


@pytest.mark.parametrize(
    "K, why",
    [
        (1e300, "outside"),
        (3.0, "outside"),
        (0.1, "outside"),
        ([[1, 1, 0], [1, 1.01, 0], [0, 0, 1]], "condition number"),
    ],
)
def test_apply_refuses_implausible_K(tmp_path, capsys, K, why):
    import numpy as np

    from optinav.multipos.result import CalibrationResult

    data = _data(tmp_path)
    good = CalibrationResult(accelerometer={"K": np.eye(3), "b": np.zeros(3)}, units={"accelerometer_raw": "m/s^2"})
    good.to_json(tmp_path / "good.json")
    assert main(["apply", str(tmp_path / "good.json"), str(data), "--out", str(tmp_path / "ok.csv")]) == 0
    capsys.readouterr()
    Kb = np.asarray(K, float) * (np.eye(3) if np.ndim(K) == 0 else 1)
    bad = tmp_path / "bad.json"
    d = good.to_dict()
    d["fields"]["accelerometer"]["value"]["K"] = Kb.tolist()
    bad.write_text(json.dumps(d))
    out = tmp_path / "o.csv"
    assert main(["apply", str(bad), str(data), "--out", str(out)]) == 2
    one_line_error(capsys, "implausible", why)
    assert not out.exists()


@pytest.mark.parametrize("sensor", ["accelerometer", "gyroscope"])
def test_apply_refuses_an_offset_no_converter_holds(tmp_path, capsys, counts_session, sensor):
    """A bias of 1e300 (a damaged file) overflowed in the gyro-unit check after the correction: a RuntimeWarning line
    before the error, which blamed the data's gyro unit. Refused in one line naming the offsets."""
    _, data, res = counts_session
    bad = _damaged(res, (sensor, "b", 0), 1e300, tmp_path)
    out = tmp_path / "o.csv"
    assert main(["apply", str(bad), str(data), "--out", str(out)]) == 2
    one_line_error(capsys, f"the {sensor} calibration is implausible: the offsets b = 1e+300")
    assert not out.exists()


# --- gfimu quality gates: stuck outputs, table-rate unit, residual against --noise -------------------------------


@pytest.fixture(scope="module")
def turntable(tmp_path_factory):
    d = tmp_path_factory.mktemp("gfimu")
    data = d / "tt.npz"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "gfimu-turntable",
                "--builtin",
                "cylinder10",
                "--duration",
                "1",
                "--seed",
                "2",
                "--out",
                str(data),
            ]
        )
        == 0
    )
    import numpy as np

    return data, dict(np.load(data))


@pytest.mark.parametrize(
    "case, extra, why",
    [
        ("constant", [], "barely change between the turntable cases"),
        ("stuck4", [], "accelerometer(s) 4 barely change"),
        ("deg", [], "looks like deg/s labelled rad/s (the rate-dependent change of the outputs is 0.0003"),
        ("good", ["--noise", "1e-9"], "against --noise"),
        # each fitted "exactly" (χ² 1.5) with tens of thousands of σ of error, exit 0
        ("swap18", [], "0.04 m about their mean at accelerometer 8"),
        ("swap4_10", [], "two output columns are swapped"),
        ("rate+20%", [], "× the stated ones"),
        ("rate-20%", [], "i.e. rates 1.25× the stated ones"),
        ("five cases", [], "equations for 50 unknowns: no redundancy"),
        ("bias 3e-5", [], "(reduced χ² 19.4)"),
    ],
)
def test_gfimu_gates(turntable, tmp_path, capsys, case, extra, why):
    import numpy as np

    path, d = turntable
    d = {k: v.copy() for k, v in d.items()}
    if case == "constant":  # every output constant up to a little noise: used to be "all observable", 31.6 m
        d["f"] = 1.0 + 1e-5 * np.random.default_rng(0).standard_normal(d["f"].shape)
    elif case == "stuck4":
        d["f"][:, 3] = 0.2
    elif case == "deg":
        d["table_rate"] = np.degrees(d["table_rate"])
    elif case.startswith("swap"):
        i, j = (0, 7) if case == "swap18" else (3, 9)
        d["f"][:, [i, j]] = d["f"][:, [j, i]]
    elif case.startswith("rate"):
        d["table_rate"] = d["table_rate"] * (1.2 if "+" in case else 0.8)
    elif case == "five cases":
        keep = d["case"] != 6
        d = {k: (v[keep] if v.ndim else v) for k, v in d.items()}
    elif case == "bias 3e-5":  # an unmodelled bias of 3 µg on one sensor: tens of σ of its direction errors
        d["f"][:, 2] += 3e-5
    bad = tmp_path / "bad.npz"
    np.savez(bad, **d)
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "gfimu", str(bad), "--builtin", "cylinder10", *extra, "--out", str(out)]) == 2
    one_line_error(capsys, why)
    assert not out.exists()
    if case == "deg":  # the flag the error names makes it right: the truth's 1 mm errors within 4σ
        assert (
            main(
                [
                    "--quiet",
                    "calibrate",
                    "gfimu",
                    str(bad),
                    "--builtin",
                    "cylinder10",
                    "--rate-unit",
                    "deg/s",
                    "--offset",
                    "zero",  # centred, simulated: absolute Δr against the truth
                    "--out",
                    str(out),
                ]
            )
            == 0
        )
        res = json.loads(out.read_text())["fields"]
        truth = json.loads(path.with_name("tt.truth.json").read_text())
        dr = np.asarray(res["dr"]["value"])
        std = np.asarray(res["std"]["value"]).reshape(-1, 5)[:, :3]
        assert np.all(np.abs(dr - np.asarray(truth["dr_m"])) < 4 * std)


@pytest.mark.parametrize(
    "name, damage, where",
    [
        ("estimate", lambda v: v[:-1], "field 'estimate' has shape (49,), expected (50,)"),
        ("crlb_std", lambda v: [1.0], "field 'crlb_std' has shape (1,)"),
        ("std", lambda v: [[1.0]], "field 'std' has shape (1, 1)"),
        ("statements", lambda v: [None, *v[1:]], "field 'statements' is a list, expected a list of names"),
    ],
)
def test_a_gfimu_result_with_a_damaged_array_is_named(turntable, tmp_path, capsys, name, damage, where):
    """An estimate one short, a std of the wrong shape, a statement null: internal IndexError/TypeError in report."""
    data, _ = turntable
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "gfimu", str(data), "--builtin", "cylinder10", "--out", str(res)]) == 0
    d = json.loads(res.read_text())
    d["fields"][name]["value"] = damage(d["fields"][name]["value"])
    res.write_text(json.dumps(d))
    assert main(["--quiet", "report", str(res), "--out", str(tmp_path / "rep")]) == 2
    one_line_error(capsys, where, "pass an unmodified optinav result file")


def test_gfimu_rate_check_knows_the_offset(tmp_path, capsys):
    """An array 10-30 cm off the table axis, the offset given: the rate-scale check predicted the outputs with the
    centre on the axis and refused correct data as "table rates 1.2x the stated ones"; without
    the offset the error names it too."""
    f = tmp_path / "o.npz"
    argv = ["--quiet", "simulate", "gfimu-turntable", "--out", str(f), "--seed", "14", "--offset", "0.3,0.2,0.1"]
    assert main(argv + ["--duration", "2"]) == 0
    out = tmp_path / "r.json"
    base = ["--quiet", "calibrate", "gfimu", str(f), "--builtin", "cylinder10", "--out", str(out)]
    assert main(base + ["--offset", "0.3,0.2,0.1"]) == 0
    capsys.readouterr()
    assert main(base) == 2
    one_line_error(capsys, "or the array's centre is off the table axis", "--offset X,Y,Z")


def test_gfimu_std_widen_with_the_residual_and_apply_refuses_garbage(turntable, tmp_path, capsys):
    """An unmodelled bias below the χ² gate widens the std by √χ² (was 20σ off with the noise-only std); apply
    refused nothing: two columns swapped made the rate integration diverge to 1e227 rad/s and NaN, outputs in g
    gave a rate 3× too small, both with exit 0."""
    import numpy as np

    path, d = turntable
    truth = json.loads(path.with_name("tt.truth.json").read_text())
    b = {k: v.copy() for k, v in d.items()}
    b["f"][:, 2] += 1e-5
    np.savez(tmp_path / "b.npz", **b)
    out = tmp_path / "r.json"
    assert (
        main(
            ["--quiet", "calibrate", "gfimu", str(tmp_path / "b.npz"), "--builtin", "cylinder10", "--offset", "zero"]
            + ["--out", str(out)]
        )
        == 0
    )
    res = json.loads(out.read_text())["fields"]
    assert any("std scaled by √(reduced χ²)" in st for st in res["statements"]["value"])
    est, std = np.asarray(res["estimate"]["value"]), np.asarray(res["std"]["value"])
    x = np.column_stack([truth["dr_m"], truth["dalpha_rad"], truth["dbeta_rad"]]).ravel()
    assert np.max(np.abs(est[: x.size] - x) / std[: x.size]) < 4.0
    assert main(["--quiet", "calibrate", "gfimu", str(path), "--builtin", "cylinder10", "--out", str(out)]) == 0
    one = d["case"] == 1
    c1 = {k: (v[one] if v.ndim else v) for k, v in d.items()}
    w0 = ["--omega0", "0.25,0,0.4330127"]  # case 1: 0.5 rad/s about the table axis, 30° off the array's z
    for name, f, why in (
        (
            "swap",
            c1["f"][:, [0, 7, 2, 3, 4, 5, 6, 1, 8, 9]],
            "the outputs of swap.npz do not fit the calibrated geometry",
        ),
        ("in_g", c1["f"] / 9.80665, "the outputs look like g, not m/s^2"),
    ):
        np.savez(tmp_path / f"{name}.npz", **{**c1, "f": f})
        rc = main(["--quiet", "apply", str(out), str(tmp_path / f"{name}.npz"), "--out", str(tmp_path / "m.csv"), *w0])
        assert rc == 2, name
        one_line_error(capsys, why)
    np.savez(tmp_path / "ok.npz", **c1)
    assert main(["--quiet", "apply", str(out), str(tmp_path / "ok.npz"), "--out", str(tmp_path / "m.csv"), *w0]) == 0
    # a rate integration that diverges (not finite, or beyond any motion) is named, whatever made it
    from optinav.gfimu.errors import Motion
    from optinav.gfimu.unit import _check_motion

    t = np.arange(4.0)
    for bad in (np.nan, 1e227):
        w = np.zeros((4, 3))
        w[2, 0] = bad
        with pytest.raises(OptinavError, match="diverges at t = 2 s"):
            _check_motion(Motion(t, np.full((4, 3), 5.7), np.zeros((4, 3)), w, "a"), "x.npz", True)


@pytest.mark.parametrize("k, bias", [(0, 0.05), (4, 0.05), (5, 0.05), (4, 0.001)])
def test_gfimu_apply_names_the_output_that_is_off(turntable, tmp_path, capsys, k, bias):
    """One output biased by 0.05 m/s² (thousands of σ): the misfit named the output with the largest residual, and
    the least-squares residual spreads one output's fault onto the others (f5 and f6 nearly mirror each other in
    cylinder10: a bias on f5 was named "most at f6"). Each output left out in turn, the one without which the
    others fit at the noise level is named; two swapped columns or a wrong --omega0 are no one output. A bias of
    0.001 m/s² (15× the noise, below the 30× gate) gave a rate about 0.006 rad/s off after 1 s with exit 0: one
    output that the others contradict is refused from 5× on."""
    path, d = turntable
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "gfimu", str(path), "--builtin", "cylinder10", "--out", str(out)]) == 0
    one = d["case"] == 1
    c1 = {n: (v[one] if v.ndim else v) for n, v in d.items()}
    f = c1["f"].copy()
    f[:, k] += bias
    np.savez(tmp_path / "b.npz", **{**c1, "f": f})
    w0 = ["--omega0", "0.25,0,0.4330127"]  # case 1: 0.5 rad/s about the table axis, 30° off the array's z
    assert main(["--quiet", "apply", str(out), str(tmp_path / "b.npz"), "--out", str(tmp_path / "m.csv"), *w0]) == 2
    one_line_error(capsys, f"without f{k + 1} the others fit", f"f{k + 1} is off")
    np.savez(tmp_path / "s.npz", **{**c1, "f": c1["f"][:, [0, 7, 2, 3, 4, 5, 6, 1, 8, 9]]})
    assert main(["--quiet", "apply", str(out), str(tmp_path / "s.npz"), "--out", str(tmp_path / "m.csv"), *w0]) == 2
    one_line_error(capsys, "no one output left out makes the others fit")
    # the table turning at the first sample but --omega0 left at rest: every output is off, none is named (leaving
    # one out brought the misfit from 275 to 18× the noise, and f2 was named)
    np.savez(tmp_path / "ok.npz", **c1)
    assert main(["--quiet", "apply", str(out), str(tmp_path / "ok.npz"), "--out", str(tmp_path / "m.csv")]) == 2
    one_line_error(capsys, "no one output left out makes the others fit", "--omega0")


def test_gfimu_apply_names_the_integrations_drift_not_a_sensor(turntable, tmp_path, capsys):
    """About a 2 rad/s spin the integration method's rate drifted 0.012 rad/s off (its ω̇ integrated through the
    quadratic terms' compensation): the outputs left 16× the noise with it, and a healthy output was named "off";
    every output fits the Gauss–Newton rate, so the drift is named with --rate-method gauss-newton, whose rate is
    then within 1e-3 rad/s of the truth after the first second."""
    from optinav.gfimu import InstallationErrors, builtin, perturb

    path, _ = turntable
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "gfimu", str(path), "--builtin", "cylinder10", "--out", str(out)]) == 0
    truth = json.loads(path.with_name("tt.truth.json").read_text())
    errors = InstallationErrors(np.array(truth["dr_m"]), np.array(truth["dalpha_rad"]), np.array(truth["dbeta_rad"]))
    arr = perturb(builtin(), errors)  # the array as built: the calibration knows it to its own std
    t = np.arange(0.0, 60.0, 0.01)
    W = 2 * np.pi * 0.2
    om = np.column_stack([2 + 0.5 * np.sin(W * t), 0.3 * np.sin(2 * W * t), 0.4 * (1 - np.cos(W * t))])
    wd = np.column_stack([0.5 * W * np.cos(W * t), 0.6 * W * np.cos(2 * W * t), 0.4 * W * np.sin(W * t)])
    A = np.column_stack([0.5 * np.sin(0.3 * t), 9.80665 * np.cos(0.1 * t), 9.80665 * np.sin(0.1 * t)])
    f = arr.outputs(A, wd, om) + np.random.default_rng(4).normal(0, 1e-5, (t.size, arr.n))
    np.savez(tmp_path / "spin.npz", t=t, f=f)
    base = ["--quiet", "apply", str(out), str(tmp_path / "spin.npz"), "--omega0", "2,0,0", "--out"]
    assert main([*base, str(tmp_path / "i.csv")]) == 2
    one_line_error(capsys, "the integration method's rate drifted off the outputs", "--rate-method gauss-newton")
    assert main([*base, str(tmp_path / "g.csv"), "--rate-method", "gauss-newton"]) == 0
    got = np.genfromtxt(tmp_path / "g.csv", delimiter=",", names=True)
    err = np.column_stack([got["gx"], got["gy"], got["gz"]]) - om
    # (its first steps weigh --omega0 at a 0.05 rad/s 1σ against the outputs: 0.012 rad/s off at the second sample)
    assert np.abs(err[t > 1.0]).max() < 1e-3, np.abs(err[t > 1.0]).max(axis=0)


def test_gfimu_apply_leave_one_out_solves_a_bounded_share_of_a_block(turntable, tmp_path, monkeypatch):
    """The leave-one-out search solved the whole block N times (blocks of 200 000 rows and a rate method of ≈ 1 s
    per 10⁴ epochs: minutes per block of a log with a misfit of 5-30× the noise); it takes the block's first
    CULPRIT_EPOCHS epochs, and still names the output off."""
    from optinav.gfimu import solve, unit
    from optinav.gfimu.turntable import TurntableCalibration

    path, d = turntable
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "gfimu", str(path), "--builtin", "cylinder10", "--out", str(out)]) == 0
    res = TurntableCalibration.from_json(out)
    one = d["case"] == 1
    f = np.tile(d["f"][one], (30, 1))
    f[:, 4] += 0.05
    t = np.arange(f.shape[0]) * float(np.median(np.diff(d["t"][one])))
    solved = []
    call = solve.MotionSolver.__call__
    monkeypatch.setattr(solve.MotionSolver, "__call__", lambda self, a, tt: solved.append(len(a)) or call(self, a, tt))
    state = solve.RateState(np.array([0.25, 0.0, 0.4330127]))
    k, fit = unit._culprit(res.calibrated_array(), f, t, state, "integration", res.sigma)
    assert k == 4 and fit < unit.LEFT_OUT_FIT
    assert f.shape[0] > unit.CULPRIT_EPOCHS and max(solved) == unit.CULPRIT_EPOCHS, solved


# --- batch: inputs, options once, workers that die ---------------------------------------------------------------


def _batch_units(tmp_path):
    import numpy as np

    from optinav.io import ImuLog, write_imu
    from optinav.multipos.simulate import simulate

    d = tmp_path / "units"
    d.mkdir()
    for k in (1, 2):
        s = simulate(
            "18", dwell_s=5.0, rate_hz=20.0, transition_s=2.0, rest_s=3.0, lat=np.radians(38.88), height_m=35.0, rng=k
        )
        write_imu(d / f"u{k}.csv", ImuLog(t=s.t, acc=s.acc, gyr=s.gyr, acc_unit="m/s^2", gyro_unit="rad/s"))
    return d


def test_batch_refuses_a_unit_as_out_and_bad_options_before_work(tmp_path, capsys):
    d = _batch_units(tmp_path)
    before = digest(d / "u2.csv")
    assert (
        main(
            [
                "--quiet",
                "batch",
                "calibrate",
                "accel",
                str(d),
                "--out",
                str(d / "u2.csv"),
                "--workers",
                "0",
                "--latitude",
                "38.88",
            ]
        )
        == 2
    )
    one_line_error(capsys, "is not an optinav results table")
    assert digest(d / "u2.csv") == before
    # bad site options fail once, before any unit (they used to fail every unit and exit 0)
    assert (
        main(
            [
                "--quiet",
                "batch",
                "calibrate",
                "accel",
                str(d),
                "--out",
                str(tmp_path / "r.csv"),
                "--workers",
                "0",
                "--gravity",
                "5",
            ]
        )
        == 2
    )
    one_line_error(capsys, "gravity 5 m/s^2 is not above 9.7 and below 9.9")
    from optinav.batch import run_batch
    from optinav.multipos.calibrate import FileOptions

    with pytest.raises(OptinavError, match="latitude 95"):
        run_batch(d, tmp_path / "r.csv", FileOptions(lat_deg=95), workers=0)
    with pytest.raises(SystemExit):  # the CLI refuses it at parsing already
        main(["batch", "calibrate", "accel", str(d), "--out", str(tmp_path / "r.csv"), "--latitude", "95"])
    assert not (tmp_path / "r.csv").exists() and not (tmp_path / "r.csv.journal.jsonl").exists()
    # a batch with a failed unit exits 1; its table is written, and a re-run may replace it
    (d / "u3.csv").write_text("t,ax,ay,az\n0,1,2\n")
    assert (
        main(
            [
                "--quiet",
                "batch",
                "calibrate",
                "accel",
                str(d),
                "--out",
                str(d / "r.csv"),
                "--workers",
                "0",
                "--latitude",
                "38.88",
                "--height",
                "35",
            ]
        )
        == 1
    )
    assert "3 units: 2 ok, 1 failed" in capsys.readouterr().out
    assert (
        main(
            [
                "--quiet",
                "batch",
                "calibrate",
                "accel",
                str(d),
                "--out",
                str(d / "r.csv"),
                "--workers",
                "0",
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--fresh",
            ]
        )
        == 1
    )


def dies_on_u2(path, options, name):
    """A unit job for the pool tests: the worker of unit u2 is killed (as by the OOM killer)."""
    import signal

    if name == "u2":
        os.kill(os.getpid(), signal.SIGKILL)
    return {"unit": name, "status": "ok"}


def sleeps(path, options, name):
    """A unit job that records its worker's pid and works for a long time."""
    import time

    tmp = Path(f"{path}.{os.getpid()}.part")  # renamed into place so the test never reads half a pid
    tmp.write_text(str(os.getpid()))
    os.replace(tmp, path)
    time.sleep(60)
    return {"unit": name, "status": "ok"}


def test_a_killed_worker_loses_only_its_unit(tmp_path):
    from optinav import batch

    units = [batch.Unit(f"u{k}", tmp_path / f"u{k}", 1, 1) for k in range(1, 5)]
    out = {u.name: (row, lost) for u, row, lost in batch._run_local(units, None, 2, fn=dies_on_u2)}
    assert sorted(out) == [u.name for u in units]
    assert out["u2"][0] is None and out["u2"][1].startswith("worker lost")
    assert all(out[n][0] == {"unit": n, "status": "ok"} for n in out if n != "u2")


def test_workers_die_with_the_batch(tmp_path):
    import signal
    import time

    code = (
        f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); from pathlib import Path\n"
        "from optinav import batch; import test_reliability as t\n"
        f"units = [batch.Unit(f'u{{k}}', Path({str(tmp_path)!r}) / f'pid{{k}}', 1, 1) for k in (1, 2)]\n"
        "list(batch._run_local(units, None, 2, fn=t.sleeps))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(files.__file__).parents[2])}
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        # only the renamed pid files: a worker's ``.part`` file may vanish between listing and reading
        pids = []
        while time.monotonic() < deadline and len(pids) < 2:
            time.sleep(0.05)
            pids = [int(p.read_text()) for p in (tmp_path / "pid1", tmp_path / "pid2") if p.is_file()]
        assert len(pids) == 2
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)

    def alive(pid):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        with open(f"/proc/{pid}/stat") as fh:  # a zombie is dead
            return fh.read().split(") ")[1][0] != "Z"

    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(alive(p) for p in pids):
        time.sleep(0.1)
    assert not any(alive(p) for p in pids)


# --- sizes that cannot fit are refused up front with the estimate ------------------------------------------------


@pytest.mark.parametrize(
    "argv, needles",
    [
        (["simulate", "flight", "--out", "{d}/f.csv", "--duration", "1e7"], ("GiB of memory", "available")),
        # streamed to text: memory is bounded, the file is not (about 133 B per row)
        (["simulate", "accel-multipos", "--out", "{d}/m.csv", "--dwell", "1e9"], ("GiB on disk", "free")),
        # NPZ gathers the blocks: refused by memory
        (["simulate", "accel-multipos", "--out", "{d}/m.npz", "--dwell", "1e7"], ("GiB of memory", "write .csv")),
        (
            ["simulate", "rins", "--nonorth=0,0,0,0,0,0", "--dwell", "1e7", "--out", "{d}/r.npz"],
            ("GiB of memory", "available"),
        ),
        (["simulate", "gfimu-turntable", "--duration", "1e9", "--out", "{d}/g.npz"], ("GiB of memory", "available")),
    ],
)
def test_simulations_that_cannot_fit_are_refused(tmp_path, capsys, argv, needles):
    assert main([a.format(d=tmp_path) for a in argv]) == 2
    one_line_error(capsys, *needles)
    assert list(tmp_path.iterdir()) == []


def test_height_without_latitude_is_an_error(tmp_path, capsys):
    data = _data(tmp_path)
    assert main(["calibrate", "accel", str(data), "--height", "35", "--out", str(tmp_path / "r.json")]) == 2
    one_line_error(capsys, "--height without --latitude")
    with pytest.raises(SystemExit):
        main(["calibrate", "accel", str(data), "--gravity", "0", "--out", str(tmp_path / "r.json")])
    assert "--gravity: 0 is out of range" in capsys.readouterr().err


# --- every JSON input: any bytes end in a value or a one-line OptinavError ---------------------------------------

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_json = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=20,
)
_keys = st.sampled_from(
    [
        "schema",
        "version",
        "fields",
        "accelerometer",
        "gyroscope",
        "K",
        "b",
        "units",
        "accelerometers",
        "position",
        "direction",
        "noise",
        "start",
        "end",
        "x_p",
        "value",
        "__ndarray__",
        "__float__",
        "dtype",
        "angles",
        "arrays",
        "",
    ]
)
_shaped = st.recursive(
    st.none()
    | st.floats()
    | st.integers()
    | st.sampled_from(["optinav.calibration", "float64", "optinav.triad_noise", "inf"]),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(_keys, kids, max_size=5),
    max_leaves=25,
)


def _readers():
    from optinav.core.results import Result
    from optinav.gfimu.array import AccelerometerArray
    from optinav.multipos.result import CalibrationResult
    from optinav.multipos.static import _load_sections
    from optinav.rins.calibrate import RinsCalibration

    return [
        Result.from_json,
        CalibrationResult.from_json,
        RinsCalibration.from_json,
        AccelerometerArray.load,
        _load_sections,
    ]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    content=st.one_of(
        st.binary(max_size=200),
        _json.map(lambda v: json.dumps(v).encode()),
        _shaped.map(lambda v: json.dumps(v).encode()),
    )
)
def test_json_readers_never_crash(tmp_path, content):
    p = tmp_path / "in.json"
    p.write_bytes(content)
    for read in _readers():
        try:
            read(Path(p))
        except OptinavError as exc:
            assert "\n" not in str(exc)


def test_calibrate_rins_refuses_a_session_that_cannot_fit(tmp_path, capsys):
    """The row count comes from the file's header alone (here an NPZ whose arrays claim 1e11 rows): refused up front
    with the estimate, before anything is read."""
    import io
    import zipfile

    import numpy as np

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**11,)})
    path = tmp_path / "huge.npz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("t.npy", buf.getvalue())
    assert main(["calibrate", "rins", str(path), "--out", str(tmp_path / "r.json")]) == 2
    one_line_error(capsys, "GiB of memory", "shorter part of the recording")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["huge.npz"]


# --- faults a demanding user meets (pipes, unreadable folders, damaged HDF5, full disks) ----------


@pytest.fixture(scope="module")
def counts_session(tmp_path_factory):
    """A simulated multi-position session in raw counts and deg/s, and its calibration."""
    d = tmp_path_factory.mktemp("faults")
    data, res = d / "s.csv", d / "r.json"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(data), "--scheme", "18", "--dwell", "8"]
    assert main(argv + ["--acc-unit", "counts", "--gyro-unit", "deg/s", "--seed", "3"]) == 0
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(res)]) == 0
    return d, data, res


def test_a_pipe_or_device_as_input_is_refused_at_once(tmp_path, capsys, counts_session):
    """A named pipe blocked ``open`` for ever (calibrate, attitude); a device read as "empty" or "missing"."""
    _, _, res = counts_session
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    import threading

    def unblock():  # a reader that opens the pipe blocks until a writer comes: fail, never hang the suite
        while not done.wait(5.0):
            _unblock(fifo)

    done = threading.Event()
    threading.Thread(target=unblock, daemon=True).start()
    for argv in (
        ["calibrate", "accel", str(fifo), "--out", str(tmp_path / "o.json")],
        ["attitude", str(fifo), "--out", str(tmp_path / "a.csv")],
        ["allan", str(fifo), "--out", str(tmp_path / "al.json")],
        ["apply", str(res), str(fifo), "--out", str(tmp_path / "x.csv")],
    ):
        assert main(argv) == 2, argv
        one_line_error(capsys, "pipe.csv is a named pipe, not a file")
    done.set()
    assert main(["attitude", "/dev/zero", "--out", str(tmp_path / "a.csv")]) == 2
    one_line_error(capsys, "/dev/zero is a device, not a file")


def _unblock(fifo) -> None:
    """Open and close the pipe's writing end when a reader waits on it (a non-blocking open for writing fails
    otherwise): the reader's open returns and it reads the end of the data."""
    try:
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    except OSError:
        pass


def test_an_input_in_a_folder_that_cannot_be_looked_at(tmp_path, capsys, monkeypatch, counts_session):
    """``Path.exists`` raises PermissionError (Python 3.11) for a file in a folder without permission: it was an
    internal error; it is a one-line error naming the file (simulated: the tests may run as root)."""
    _, data, res = counts_session
    hidden = tmp_path / "noexec" / "s.csv"
    real = Path.stat

    def stat(self, *a, **kw):
        if "noexec" in str(self):
            raise PermissionError(errno.EACCES, "Permission denied", str(self))
        return real(self, *a, **kw)

    monkeypatch.setattr(Path, "stat", stat)
    for argv in (
        ["calibrate", "accel", str(hidden), "--out", str(tmp_path / "o.json")],
        ["attitude", str(hidden), "--out", str(tmp_path / "a.csv")],
        ["apply", str(res), str(hidden), "--out", str(tmp_path / "x.csv")],
        ["batch", "calibrate", "accel", str(hidden.parent), "--out", str(tmp_path / "b.csv")],
    ):
        assert main(argv) == 2, argv
        one_line_error(capsys, "noexec", "permission denied")


def test_a_damaged_broad_hdf5_is_a_one_line_error(tmp_path, capsys):
    """A BROAD-layout HDF5 file with a damaged compressed block (h5py: OSError from the filter, mid-stream) or a
    damaged object header (KeyError on opening the dataset): both were internal errors of attitude (online and
    offline); both are the reader's one-line error."""
    h5py = pytest.importorskip("h5py")
    rng = np.random.default_rng(4)
    n = 60_000

    def trial(name):
        f = tmp_path / name
        with h5py.File(f, "w") as h:
            h.attrs["sampling_rate"] = 286.0
            h.create_dataset("imu_gyr", data=rng.normal(0, 0.1, (n, 3)), chunks=(2000, 3), compression="gzip")
            h.create_dataset("imu_acc", data=rng.normal(0, 0.1, (n, 3)) + [0, 0, 9.81], chunks=(2000, 3),
                             compression="gzip")  # fmt: skip
            info = h["imu_acc"].id.get_chunk_info(20)
        return f, bytearray(f.read_bytes()), info

    f, raw, info = trial("block.hdf5")
    raw[info.byte_offset : info.byte_offset + info.size] = bytes(info.size)  # one gzip block zeroed
    f.write_bytes(bytes(raw))
    g, raw, _ = trial("header.hdf5")
    mid = len(raw) // 2
    raw[mid : mid + 200_000] = rng.integers(0, 256, 200_000, dtype=np.uint8).tobytes()
    g.write_bytes(bytes(raw))
    for path in (f, g):
        for extra in ([], ["--offline"]):
            assert main(["attitude", str(path), "--frame", "ENU", "--out", str(tmp_path / "a.csv"), *extra]) == 2
            one_line_error(capsys, f"{path.name}: could not read the HDF5 content")


def test_batch_journal_on_a_full_disk(tmp_path, capsys, monkeypatch, counts_session):
    """The batch's journal could not be written (a full disk): it was an internal error that left an empty
    journal behind; it is the writers' one-line error, and no journal is left."""
    import optinav.batch as batch

    d, data, _ = counts_session
    units = tmp_path / "units"
    units.mkdir()
    (units / "a.csv").write_bytes(data.read_bytes())

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(batch.os, "fsync", full)
    out = tmp_path / "b.csv"
    (tmp_path / "b.csv.journal.jsonl").write_text('{"torn')  # a torn line: the journal writes a newline first
    assert main(["batch", "calibrate", "accel", str(units), "--out", str(out), "--workers", "0"]) == 2
    one_line_error(capsys, "no space left on the device")
    (tmp_path / "b.csv.journal.jsonl").unlink()
    monkeypatch.setattr(batch.Journal, "_read", lambda self: (_ for _ in ()).throw(batch.os_error(self.path,
                        OSError(errno.ENOSPC, "full"))))  # fmt: skip
    assert main(["batch", "calibrate", "accel", str(units), "--out", str(out), "--workers", "0"]) == 2
    one_line_error(capsys, "no space left on the device")
    assert not (tmp_path / "b.csv.journal.jsonl").exists() and not out.exists()


@pytest.mark.parametrize(
    ("argv", "why"),
    [
        (["--method", "mekf", "--option", "acc_noise_density=0"], "acc_noise_density=0.0 must be > 0"),
        (["--method", "mekf", "--option", "acc_inflate=0"], "acc_inflate=0.0 must be > 0"),
        (["--method", "mekf", "--option", "acc_noise_density=1e-300"], "acc_noise_density=1e-300 must be > 0"),
        (["--method", "mekf", "--option", "acc_noise=0.1"], "is now acc_noise_density (1/√Hz"),
        (["--option", "latency=100"], "latency=100.0 s must be within 0…1 s"),
        (["--sun-elevation=-1000"], "--sun-elevation: -1000 is out of range"),
        (["--lat", "95"], "--lat: 95 is out of range"),
    ],
)
def test_attitude_options_that_divide_by_zero_or_make_no_sense(tmp_path, capsys, argv, why, counts_session):
    """acc_noise=0 was a ZeroDivisionError (internal error; the option is now acc_noise_density, and the old name
    is refused with the conversion); a 100 s latency or a sun 1000° high ran with exit 0."""
    f = counts_session[0] / "flight.csv"
    if not f.exists():
        assert main(["--quiet", "simulate", "flight", "--out", str(f), "--duration", "2", "--seed", "1"]) == 0
    capsys.readouterr()
    try:
        rc = main(["--quiet", "attitude", str(f), "--out", str(tmp_path / "a.csv"), *argv])
    except SystemExit as exc:  # argparse's range errors
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err
    assert why in err and err.strip().count("\n") == 0, err


def test_imucal_file_with_text_for_a_matrix(tmp_path, capsys, counts_session):
    d, data, res = counts_session
    cal = tmp_path / "cal.json"
    assert main(["--quiet", "export", str(res), "--to", "imucal", "--out", str(cal)]) == 0
    bad = json.loads(cal.read_text())
    bad["K_a"] = "abc"
    cal.write_text(json.dumps(bad))
    assert main(["apply", str(cal), str(data), "--out", str(tmp_path / "x.csv")]) == 2
    one_line_error(capsys, "K_a is not an array of numbers")


def test_apply_refuses_a_gyro_in_another_unit_and_notes_a_cut_line(tmp_path, capsys, counts_session):
    """A log whose gyro is in rad/s, corrected by a calibration made for deg/s, read 57 times too small with exit
    0; an incomplete last line was dropped without the note the other commands give."""
    d, data, res = counts_session
    lines = data.read_text().splitlines()
    head = [i for i, ln in enumerate(lines) if ln and ln[0].isalpha()][-1]  # the column names' line
    cols = lines[head].split(",")
    g = [cols.index(c) for c in cols if c.strip().lower() in ("gx", "gy", "gz")]
    rad = lines[: head + 1]
    for ln in lines[head + 1 :]:
        v = ln.split(",")
        for j in g:
            v[j] = repr(float(v[j]) * np.pi / 180)
        rad.append(",".join(v))
    f = tmp_path / "rad.csv"
    f.write_text("\n".join(rad) + "\n")
    assert main(["apply", str(res), str(f), "--out", str(tmp_path / "x.csv")]) == 2
    one_line_error(
        capsys, "as it would were the data's gyro in rad/s: it is not in the deg/s the calibration", "--gyro-unit"
    )
    # declared, the unit is converted: the same corrected log as from the deg/s file
    f.write_text(f.read_text().replace("gyro=deg/s", "gyro=rad/s"))
    assert main(["--quiet", "apply", str(res), str(f), "--out", str(tmp_path / "r.csv")]) == 0
    assert main(["--quiet", "apply", str(res), str(data), "--out", str(tmp_path / "d.csv")]) == 0
    r, dd = (_read_out(tmp_path / n) for n in ("r.csv", "d.csv"))
    for c in ("gx", "gy", "gz", "ax"):
        np.testing.assert_allclose(r[c], dd[c], rtol=1e-12, atol=1e-15)
    cut = tmp_path / "cut.csv"
    text = data.read_text()
    cut.write_text(text[: text.rstrip().rindex(",")])  # the last line without its last column
    assert main(["apply", str(res), str(cut), "--out", str(tmp_path / "y.csv")]) == 0
    assert "optinav: note: cut.csv: the last line" in capsys.readouterr().err


def test_apply_names_a_flipped_axis_not_a_unit(tmp_path, capsys, col="gx"):
    """A log in the calibration's units with its gyro x axis's sign flipped: the corrected gyro turns gravity the
    wrong way, and the error said 'as it would were the data's gyro in deg/s: it is not in the deg/s the
    calibration was made for … --gyro-unit' of data in deg/s (probe). It now names the flipped axis and --columns."""
    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11"]) == 0
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(f), "--latitude", "38.88", "--out", str(res)]) == 0
    lines = f.read_text().splitlines()
    head = [i for i, ln in enumerate(lines) if ln and ln[0].isalpha()][-1]
    j = lines[head].split(",").index(col)
    out = lines[: head + 1]
    for ln in lines[head + 1 :]:
        v = ln.split(",")
        v[j] = repr(-float(v[j]))
        out.append(",".join(v))
    flipped = tmp_path / "flipped.csv"
    flipped.write_text("\n".join(out) + "\n")
    capsys.readouterr()
    assert main(["apply", str(res), str(flipped), "--out", str(tmp_path / "x.csv")]) == 2
    one_line_error(capsys, "reads -", "--columns")


def test_report_data_of_another_log_is_refused(tmp_path, capsys, counts_session):
    """``report --data`` with a log that is not the result's gave NaN pose rows with exit 0."""
    d, data, res = counts_session
    other = tmp_path / "other.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(other), "--scheme", "18", "--dwell", "4"]
    assert main(argv + ["--acc-unit", "counts", "--gyro-unit", "deg/s", "--seed", "4"]) == 0
    assert main(["report", str(res), "--data", str(other), "--out", str(tmp_path / "r1")]) == 2
    one_line_error(capsys, "other.csv", "static interval", "not its log")
    si = tmp_path / "si.csv"
    assert main(["--quiet", "simulate", "flight", "--out", str(si), "--duration", "2"]) == 0
    capsys.readouterr()
    assert main(["report", str(res), "--data", str(si), "--out", str(tmp_path / "r2")]) == 2
    one_line_error(capsys, "the result was calibrated from raw counts", "not its log")
    assert main(["--quiet", "report", str(res), "--data", str(data), "--out", str(tmp_path / "r3")]) == 0
    # another unit at the same poses and times: its residuals were 10-20x the result's, shown with exit 0
    unit2 = tmp_path / "unit2.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(unit2), "--scheme", "18", "--dwell", "8"]
    assert main(argv + ["--acc-unit", "counts", "--gyro-unit", "deg/s", "--seed", "5"]) == 0
    capsys.readouterr()
    assert main(["report", str(res), "--data", str(unit2), "--out", str(tmp_path / "r4")]) == 2
    one_line_error(capsys, "unit2.csv corrected by the result reads |a| − g =", "× the calibration's own", "--data")
    # without --data the static intervals are listed with their times, the rest said to need the log (the table
    # was empty)
    assert main(["--quiet", "report", str(res), "--out", str(tmp_path / "r5")]) == 0
    md = (tmp_path / "r5" / "index.md").read_text()
    rows = [ln for ln in md.splitlines() if ln.startswith("| 1 |") or ln.startswith("| 2 |")]
    assert rows and all(ln.endswith("| — | — | — | — |") for ln in rows[:2]), rows
    assert "pass it with --data to list them" in md


def test_report_on_the_out_file_and_gyro_out_without_a_gyro(tmp_path, capsys, counts_session):
    d, data, res = counts_session
    out = tmp_path / "c.json"
    assert main(["calibrate", "accel", str(data), "--out", str(out), "--report", str(out)]) == 2
    one_line_error(capsys, "names the --out file")
    assert not out.exists()  # refused before the work, nothing written
    ng = tmp_path / "ng.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--no-gyro", "--out", str(ng)]) == 0
    capsys.readouterr()
    argv = ["export", str(ng), "--to", "imu_tk", "--out", str(tmp_path / "a.calib")]
    assert main(argv + ["--gyro-out", str(tmp_path / "g.calib")]) == 2
    one_line_error(capsys, "this calibration has no gyroscope")


@pytest.mark.parametrize(
    "cmd, extra, why",
    [
        (["calibrate", "accel"], ["--out", "rep/summary.json"], "--out rep/summary.json is a file the report writes"),
        (
            ["calibrate", "accel"],
            ["--out", "r.json", "--export", "imucal:rep/index.md"],
            "--export imucal rep/index.md",
        ),
        (["calibrate", "accel"], ["--out", "r.json", "--export", "imu_tk:a.calib,rep/f.png"], "imu_tk rep/f.png"),
        (["allan"], ["--out", "rep/summary.json"], "--out rep/summary.json is a file the report writes"),
    ],
)
def test_an_output_the_report_would_replace_is_refused(tmp_path, capsys, monkeypatch, counts_session, cmd, extra, why):
    """``calibrate accel mp.csv --out rep/summary.json --report rep`` wrote the result, then the report replaced
    it with its own summary.json (exit 0): refused before any work now."""
    _, data, _ = counts_session
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rep").mkdir()
    assert main([*cmd, str(data), *extra, "--report", "rep"]) == 2
    one_line_error(capsys, why, "give each output file its own name")
    assert list((tmp_path / "rep").iterdir()) == [] and not (tmp_path / "r.json").exists()


def test_report_data_without_a_time_column_takes_rate(tmp_path, capsys):
    """imucal's real Ferraris session has no time column: ``report --data`` said "pass --rate HZ", an option
    report did not have; it has it now (and refuses it without --data or for a result that reads no rate)."""
    shared = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal"
    data = shared / "example_ferraris_session.csv"
    if not data.is_file():
        pytest.skip("imucal's example session is not in ../shared/data")
    res = tmp_path / "fr.json"
    argv = ["--quiet", "calibrate", "accel", str(data), "--rate", "102.4", "--gyro-unit", "deg/s", "--gravity", "9.81"]
    argv += ["--method", "ferraris", "--sections", str(shared / "example_ferraris_session_list.json")]
    assert main(argv + ["--out", str(res)]) == 0
    capsys.readouterr()
    assert main(["report", str(res), "--data", str(data), "--out", str(tmp_path / "r0")]) == 2
    one_line_error(capsys, "has no time column")
    assert (
        main(["--quiet", "report", str(res), "--data", str(data), "--rate", "102.4", "--out", str(tmp_path / "r")]) == 0
    )
    assert "pose" in (tmp_path / "r" / "index.md").read_text()
    assert main(["report", str(res), "--rate", "102.4", "--out", str(tmp_path / "r2")]) == 2
    one_line_error(capsys, "--rate is the sampling rate of the --data recordings")
    # a time column in ms: calibrate takes --time-unit ms, and report had no such flag
    rows = np.genfromtxt(data, delimiter=",", names=True)
    ms = tmp_path / "ms.csv"
    cols = [np.arange(rows.size) * 1000 / 102.4] + [rows[f"acc_{a}"] for a in "xyz"] + [rows[f"gyr_{a}"] for a in "xyz"]
    np.savetxt(ms, np.column_stack(cols), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    res_ms = tmp_path / "ms.json"
    argv_ms = [
        "--quiet",
        "calibrate",
        "accel",
        str(ms),
        "--time-unit",
        "ms",
        "--gyro-unit",
        "deg/s",
        "--gravity",
        "9.81",
    ]
    assert main(argv_ms + ["--out", str(res_ms)]) == 0
    argv_rep = [
        "--quiet",
        "report",
        str(res_ms),
        "--data",
        str(ms),
        "--time-unit",
        "ms",
        "--out",
        str(tmp_path / "rms"),
    ]
    assert main(argv_rep) == 0
    capsys.readouterr()
    # a wrong rate put the static intervals on the moves: two '+x up' rows, one with motion, exit 0
    assert main(["report", str(res), "--data", str(data), "--rate", "50", "--out", str(tmp_path / "r3")]) == 2
    one_line_error(capsys, "static interval 0", "is not still", "--rate")


def _read_out(path):
    """An optinav CSV output (its '#' provenance lines skipped) as a structured array by column name."""
    import io

    lines = [ln for ln in Path(path).read_text().splitlines() if not ln.startswith("#")]
    return np.genfromtxt(io.StringIO("\n".join(lines)), delimiter=",", names=True)


def test_gfimu_negated_outputs_and_a_single_sample_are_named(turntable, tmp_path, capsys):
    """All outputs negated gave a numpy warning and 'rates nan× the stated ones'; a one-row NPZ was 'has no t,
    mounting, … (found: f)' (one-element arrays are read as the file's settings)."""
    d = dict(turntable[1])
    neg = tmp_path / "neg.npz"
    np.savez(neg, **{**d, "f": -d["f"]})
    args = ["--quiet", "calibrate", "gfimu", "--builtin", "cylinder10", "--out", str(tmp_path / "r.json")]
    assert main([*args[:3], str(neg), *args[3:]]) == 2
    one_line_error(capsys, "the outputs look negated", "negate the f columns")
    one = tmp_path / "one.npz"
    np.savez(one, **{k: v[:1] for k, v in d.items()})
    assert main([*args[:3], str(one), *args[3:]]) == 2
    one_line_error(capsys, "single values: t,")


def test_batch_names_data_entries_that_are_no_file(tmp_path, capsys, counts_session):
    """A named pipe and broken or looping links with a data suffix were dropped without a word ('2 units' of a
    folder of five entries): the summary names them."""
    d = tmp_path / "units"
    d.mkdir()
    (d / "u1.csv").write_bytes(counts_session[1].read_bytes())
    (d / "broken.csv").symlink_to(tmp_path / "nowhere.csv")
    (d / "loop.csv").symlink_to(d / "loop.csv")
    if hasattr(os, "mkfifo"):
        os.mkfifo(d / "pipe.csv")
    argv = ["batch", "calibrate", "accel", str(d), "--acc-unit", "counts", "--gyro-unit", "deg/s"]
    assert main([*argv, "--workers", "0", "--out", str(tmp_path / "r.csv")]) == 0
    out = capsys.readouterr().out
    assert "skipped: broken.csv: a broken or looping link" in out and "skipped: loop.csv" in out
    assert not hasattr(os, "mkfifo") or "skipped: pipe.csv: a named pipe" in out


def test_apply_says_how_many_rows_were_not_finite(tmp_path, capsys, counts_session):
    """Rows with NaN or infinite cells went through apply as NaN with exit 0 and no word, while attitude and
    allan refuse them: they are kept row for row, and counted in a note."""
    _, data, res = counts_session
    lines = data.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line[:1].isdigit())
    for k, bad in ((first + 50, "nan"), (first + 80, "inf")):
        cells = lines[k].split(",")
        cells[1] = bad
        lines[k] = ",".join(cells)
    f = tmp_path / "holes.csv"
    f.write_text("\n".join(lines) + "\n")
    assert main(["apply", str(res), str(f), "--out", str(tmp_path / "c.csv")]) == 0
    assert "2 rows of holes.csv hold empty, NaN or infinite values: written as NaN" in capsys.readouterr().err


# --- a damaged result file: any field replaced ends in a one-line error ------------------------------------------

_values = st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=4) | st.just([]) | st.just({})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pick=st.data())
def test_a_result_with_a_field_replaced_fails_in_one_line(tmp_path_factory, capsys, counts_session, pick):
    """``fields.units`` null made apply and report fail with an internal AttributeError, ``fields.accelerometer``
    null report with a TypeError: every field of a real result replaced by another JSON value is read, or refused
    in one line. (Values replaced inside a field, e.g. the accelerometer's K_std, are not all caught yet.)"""
    _, data, res = counts_session
    d = json.loads(res.read_text())
    name = pick.draw(st.sampled_from(sorted(d["fields"])), label="field")
    d["fields"][name]["value"] = pick.draw(_values, label="value")
    _apply_and_report(tmp_path_factory, capsys, d, data)


def _apply_and_report(tmp_path_factory, capsys, d: dict, data) -> list[str]:
    """Write the damaged result ``d`` and run apply and report on it: each succeeds or fails in one line (the
    errors returned)."""
    tmp = tmp_path_factory.mktemp("damaged")
    bad = tmp / "bad.json"
    bad.write_text(json.dumps(d))
    capsys.readouterr()
    errors = []
    for argv in (
        ["apply", str(bad), str(data), "--out", str(tmp / "o.csv")],
        ["report", str(bad), "--out", str(tmp / "r")],
    ):
        if main(["--quiet", *argv]) != 0:
            errors.append(one_line_error(capsys))
        capsys.readouterr()
    return errors


_nested_values = _values | st.sampled_from(
    [[1.0, 2.0], [[1.0, 2.0], [3.0, 4.0]], [None] * 3, [[None] * 3] * 3, ["a"] * 3]
)


@settings(max_examples=30, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pick=st.data())
def test_a_result_with_a_value_replaced_inside_a_field_fails_in_one_line(
    tmp_path_factory, capsys, counts_session, pick
):
    """``fields.accelerometer.value.K_std`` (or K, b, a gyroscope entry) null, text or a list of the wrong shape
    made report and apply fail with an internal IndexError/TypeError: refused in one line naming the entry."""
    _, data, res = counts_session
    d = json.loads(res.read_text())
    sensor = pick.draw(st.sampled_from(["accelerometer", "gyroscope"]), label="field")
    key = pick.draw(st.sampled_from(sorted(d["fields"][sensor]["value"])), label="key")
    d["fields"][sensor]["value"][key] = value = pick.draw(_nested_values, label="value")
    for err in _apply_and_report(tmp_path_factory, capsys, d, data):
        if key in ("K", "b", "K_std", "b_std") and value is None:
            assert f"(field '{sensor}.{key}'" in err and "pass an unmodified optinav result file" in err, err


@pytest.mark.parametrize(
    "path, value, where",
    [
        (("units", "time"), None, "units.time"),
        (("units", "accelerometer_raw"), -1, "units.accelerometer_raw"),
        (("observability", "unobservable"), 1.5, "observability.unobservable"),
        (("observability", "accelerometer", "unobservable"), True, "observability.accelerometer.unobservable"),
    ],
)
def test_a_calibration_with_damaged_units_or_observability_is_named(
    tmp_path, capsys, counts_session, path, value, where
):
    """A unit as a number or null, the unobservable statements as a number: an internal IndexError/TypeError."""
    _, _, res = counts_session
    bad = _damaged(res, path, value, tmp_path)
    assert main(["--quiet", "report", str(bad), "--out", str(tmp_path / "r")]) == 2
    one_line_error(capsys, f"(field '{where}'", "pass an unmodified optinav result file")


@pytest.mark.parametrize(
    "key, value", [("accelerometer_noise_density", "x"), ("update_rate", [1.0]), ("gyroscope_random_walk", -1)]
)
def test_export_refuses_an_allan_result_with_damaged_kalibr_numbers(tmp_path, capsys, counts_session, key, value):
    """Text or a list for a noise density or the update rate in the --noise file: an internal TypeError."""
    _, _, res = counts_session
    from optinav.core.allan import AllanAnalysis

    noise = tmp_path / "allan.json"
    AllanAnalysis(
        kalibr={"accelerometer_noise_density": 1e-3, "gyroscope_random_walk": 1e-5, "update_rate": 100.0}
    ).to_json(noise)
    d = json.loads(noise.read_text())
    d["fields"]["kalibr"]["value"][key] = value
    noise.write_text(json.dumps(d))
    argv = ["export", str(res), "--to", "kalibr", "--noise", str(noise), "--out", str(tmp_path / "imu.yaml")]
    assert main(argv) == 2
    one_line_error(capsys, f"(field 'kalibr.{key}'", "pass an unmodified optinav result file")


def test_a_result_with_null_units_or_accelerometer_is_named(tmp_path, capsys, counts_session):
    _, data, res = counts_session
    for name in ("units", "accelerometer"):
        d = json.loads(res.read_text())
        d["fields"][name]["value"] = None
        bad = tmp_path / f"{name}.json"
        bad.write_text(json.dumps(d))
        for argv in (["report", str(bad), "--out", str(tmp_path / "r")], ["apply", str(bad), str(data)]):
            assert main(argv if argv[0] == "report" else [*argv, "--out", str(tmp_path / "o.csv")]) == 2
            one_line_error(capsys, "pass an unmodified optinav result file")
    # a result without an accelerometer that loads (the raw unit is SI) has no report: named, not a TypeError
    from optinav.multipos.result import CalibrationResult

    gyro_only = CalibrationResult(gyroscope={"K": np.eye(3), "b": np.zeros(3)}, units={"gyroscope_raw": "rad/s"})
    gyro_only.to_json(tmp_path / "g.json")
    assert main(["report", str(tmp_path / "g.json"), "--out", str(tmp_path / "r")]) == 2
    one_line_error(capsys, "has no accelerometer", "pass an unmodified optinav result file")
