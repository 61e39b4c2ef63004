"""Bad input and OS faults through the CLI, in-process: every case ends in a one-line error with exit 2 (or
succeeds), and no input file is changed (issue 17)."""

import errno
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

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


@pytest.fixture
def cube(tmp_path):
    """A valid gyro-free configuration file (six tangential accelerometers)."""
    cfg = {"accelerometers": [
        {"position": [0.1, 0, 0], "direction": [0, 1, 0]}, {"position": [0.1, 0, 0], "direction": [0, 0, 1]},
        {"position": [0, 0.1, 0], "direction": [1, 0, 0]}, {"position": [0, 0.1, 0], "direction": [0, 0, 1]},
        {"position": [0, 0, 0.1], "direction": [1, 0, 0]}, {"position": [0, 0, 0.1], "direction": [0, 1, 0]}]}
    p = tmp_path / "cube.json"
    p.write_text(json.dumps(cfg))
    return p


def _data(tmp_path) -> Path:
    p = tmp_path / "session.csv"
    p.write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{k / 100},0,0,9.8,0,0,0\n" for k in range(50)))
    return p


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
    for argv in (["apply", str(result), str(data), "--out", str(data)],
                 ["apply", str(result), str(data), "--out", str(result)],
                 ["calibrate", "accel", str(data), "--method", "ferraris", "--sections", str(sections),
                  "--out", str(sections)]):
        assert main(argv) == 2, argv
        one_line_error(capsys, "is the input")
    assert {p: digest(p) for p in before} == before


def test_foreign_sidecar_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "x.csv"
    truth = tmp_path / "x.truth.csv"
    truth.write_text("my own measurements\n1,2,3\n")
    before = digest(truth)
    assert main(["simulate", "flight", "--out", str(out), "--duration", "1"]) == 2
    one_line_error(capsys, "x.truth.csv exists and was not written by optinav")
    assert digest(truth) == before and not out.exists()


def test_own_truth_sidecar_is_replaced(tmp_path, capsys):
    out = tmp_path / "tt.npz"
    argv = ["simulate", "gfimu-turntable", "--out", str(out), "--duration", "0.2"]
    assert main(argv) == 0
    assert main(argv) == 0  # a second run replaces the truth optinav wrote
    truth = json.loads((tmp_path / "tt.truth.json").read_text())
    assert truth["schema"] == "optinav.gfimu_truth"
    (tmp_path / "tt.truth.json").write_text('{"mine": 1}')
    assert main(argv) == 2
    one_line_error(capsys, "was not written by optinav")


# --- output checks before any work -----------------------------------------------------------------------------

def test_bad_output_locations(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    (tmp_path / "dir.json").mkdir()
    cases = [(tmp_path / "dir.json", "is a folder"), (blocker / "a.json", "is a file"), (blocker / "s" / "a.json", "lies below the file"),
             (tmp_path / "nope" / "a.json", "does not exist")]
    for out, why in cases:
        assert main(["gfimu", "analyze", "--builtin", "cylinder10", "--out", str(out)]) == 2
        one_line_error(capsys, why)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.json", "file"]


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
        capture_output=True, text=True, timeout=120, env=env,
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (200, 200)))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "file-size limit" in proc.stderr
    assert list(tmp_path.iterdir()) == []


# --- JSON inputs: every parser failure is one line --------------------------------------------------------------

@pytest.mark.parametrize("content, why", [
    (b"[" * 100_000 + b"]" * 100_000, "nested"),
    (b'{"a":' * 200 + b"1" + b"}" * 200, "nested more than"),
    (b'{"schema": "optinav.calibration", "x": "\xff\xfe"}', "not UTF-8"),
    (b'{"version": ' + b"9" * 5000 + b"}", "not readable JSON"),
    (b'{"schema": ', "not valid JSON"),
])
def test_json_inputs_fail_in_one_line(tmp_path, capsys, content, why):
    bad = tmp_path / "bad.json"
    bad.write_bytes(content)
    data = _data(tmp_path)
    before = digest(data)
    for argv in (["apply", str(bad), str(data), "--out", str(tmp_path / "o.csv")],
                 ["gfimu", "analyze", str(bad)],
                 ["--quiet", "calibrate", "accel", str(data), "--method", "ferraris", "--sections", str(bad),
                  "--out", str(tmp_path / "r.json")]):
        assert main(argv) == 2, argv
        one_line_error(capsys, why)
    assert digest(data) == before and not (tmp_path / "o.csv").exists()


# --- option ranges at parsing: one line, exit 2 ----------------------------------------------------------------

@pytest.mark.parametrize("argv, why", [
    (["sun", "--lat", "95", "--lon", "0", "--time", "2021-01-01T00:00:00Z"], "--lat: 95 is out of range"),
    (["sun", "--lat", "10", "--lon", "0", "--height", "1e7", "--time", "2021-01-01T00:00:00Z"], "--height"),
    (["simulate", "gfimu-turntable", "--out", "x.npz", "--noise", "-1"], "--noise: -1 is out of range"),
    (["simulate", "rins", "--nonorth", "0,0,0,0,0,0", "--cycles", "0", "--out", "x.npz"], "--cycles"),
    (["simulate", "rins", "--nonorth", "0,0,0,0,0,0", "--lat", "95", "--out", "x.npz"], "--lat"),
    (["simulate", "accel-multipos", "--out", "x.csv", "--dwell", "nan"], "not finite"),
    (["calibrate", "rins", "x.npz", "--lat", "-91", "--out", "r.json"], "--lat"),
])
def test_out_of_range_options_are_one_line_argparse_errors(argv, why, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and why in err and "see optinav" in err, err


# --- rins quality gates: wrong latitude, swapped encoders ------------------------------------------------------

RINS = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "100"]


@pytest.fixture(scope="module")
def rins_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("rins")
    data = d / "r.npz"
    assert main(["--quiet", "simulate", "rins", "--nonorth=-2e-4,-9e-4,-2e-3,7e-4,-8e-4,-9e-3", "--seed", "3",
                 "--out", str(data), *RINS]) == 0
    return data


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

@pytest.mark.parametrize("K, why", [(1e300, "outside"), (3.0, "outside"), (0.1, "outside"),
                                    ([[1, 1, 0], [1, 1.01, 0], [0, 0, 1]], "condition number")])
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
    d["accelerometer"]["K"] = Kb.tolist()
    bad.write_text(json.dumps(d))
    out = tmp_path / "o.csv"
    assert main(["apply", str(bad), str(data), "--out", str(out)]) == 2
    one_line_error(capsys, "implausible", why)
    assert not out.exists()
