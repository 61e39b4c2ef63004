"""The command line: help, errors as one line, and the README's main job end to end."""

import json

import pytest

from optinav.cli.main import main
from report_fixture import quick_report  # noqa: F401


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert "reproduce" in out


def test_unknown_study_is_one_line_error(capsys):
    assert main(["reproduce", "no-such-study", "--out", "unused"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("optinav: error: unknown study 'no-such-study'")


def test_unwritable_report_folder(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["--quiet", "reproduce", "core", "--quick", "--out", str(blocker / "sub")]) == 2
    err = capsys.readouterr().err
    assert "cannot create report folder" in err
    assert "study core" not in err  # failed before doing the work


def test_reproduce_quick_writes_report(quick_report):
    # the README's main job, as a user runs it (the session's one quick run, via python -m)
    out = quick_report.out
    assert quick_report.returncode == 0, quick_report.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert "core" in summary["studies"]
    checks = summary["studies"]["core"]["checks"]
    assert checks and all(c["passed"] for c in checks)
    assert (out / "index.md").read_text().startswith("# optinav reproduce")
    assert (out / "index.html").exists()
    assert list(out.glob("*.png")), "matplotlib is a core dependency, so figures must be written"


def test_closed_stdout_is_not_an_error():
    """``optinav sun ... | head -1``: the reader leaving early ends the command quietly with status 0."""
    import subprocess
    import sys

    times = [f"--time=2021-01-17T{h:02d}:{m:02d}:00+08:00" for h in range(24) for m in range(0, 60, 2)]
    proc = subprocess.Popen(
        [sys.executable, "-m", "optinav.cli.main", "sun", "--lat", "38.9", "--lon", "121.5", *times],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout.readline().strip() == b"["
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert "error" not in err


def test_building_the_parser_loads_no_numpy():
    """``optinav --help`` stays instant: command modules import numerical code only when a command runs."""
    import subprocess
    import sys

    code = "import sys; from optinav.cli.main import build_parser; build_parser(); print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_the_parser_is_built_once_per_set_of_systems_and_each_call_owns_its_defaults():
    """main() built argparse's 370 options on every call (20-35 ms); now once, again when a system is registered
    or removed (its commands are in the parser). A default list (``calibrate accel --export``) is the parser's
    object: each call gets its own copy, so a command that appends to it leaves the next call's default empty."""
    from optinav import registry
    from optinav.cli import main as cli_main

    parser = cli_main._parser()
    assert cli_main._parser() is parser
    argv = ["calibrate", "accel", "s.csv", "--out", "r.json"]
    first = cli_main._own_defaults(parser.parse_args(argv))
    first.export.append("imucal:x.json")
    second = cli_main._own_defaults(parser.parse_args(argv))
    assert second.export == [] and second.export is not first.export
    toy = registry.System(name="toy2", command="toy2", kind="estimate", result="optinav.core.results:Estimate")
    registry.register(toy)
    try:
        assert cli_main._parser() is not parser
    finally:
        registry.unregister("toy2")
    assert cli_main._parser().parse_args(argv).command == "calibrate"
