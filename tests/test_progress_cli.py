"""Progress of long CLI commands: step labels on a terminal, nothing when piped or with --quiet."""

import sys

import pytest

from optinav.cli.main import main


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("progress")
    data = d / "s.csv"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(data),
                "--acc-unit",
                "counts",
                "--gyro-unit",
                "deg/s",
                "--seed",
                "1",
            ]
        )
        == 0
    )
    return d, data


def _calibrate(d, data, *extra):
    return main(
        [
            *extra,
            "calibrate",
            "accel",
            str(data),
            "--latitude",
            "38.88",
            "--out",
            str(d / "r.json"),
            "--method",
            "ga",
            "--generations",
            "5",
        ]
    )


def test_calibrate_shows_steps_on_a_terminal(session, capsys, monkeypatch):
    monkeypatch.setenv("OPTINAV_QUIET", "")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert _calibrate(*session) == 0
    err = capsys.readouterr().err
    assert "calibrate accel:" in err and "GA generations" in err and ", write" in err


def test_calibrate_silent_when_piped_or_quiet(session, capsys, monkeypatch):
    monkeypatch.setenv("OPTINAV_QUIET", "")
    assert _calibrate(*session) == 0  # stderr is not a terminal
    err = capsys.readouterr().err
    assert "GA generations" not in err and "steps" not in err and "\r" not in err
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert _calibrate(*session, "--quiet") == 0
    assert capsys.readouterr().err.count("\r") == 0


def test_attitude_and_flight_steps(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("optinav.core.progress.progress_enabled", lambda: True)
    f = tmp_path / "f.csv"
    assert main(["simulate", "flight", "--out", str(f), "--duration", "5"]) == 0
    assert main(["attitude", str(f), "--out", str(tmp_path / "q.csv")]) == 0
    err = capsys.readouterr().err
    # the flight is generated and written block by block (a bar over its blocks); attitude reports its steps
    assert "simulate flight:" in err and "0/1" in err and "attitude:" in err and ", write" in err


def test_generation_bars_only_directly_inside_a_task():
    from optinav.core.progress import in_task, progress, task

    assert not in_task()
    with task("job", enabled=False):
        assert in_task()
        for _ in progress(range(1), enabled=True):
            assert not in_task()  # one outer bar per run is enough


def test_a_long_compile_is_said_once_and_a_loaded_kernel_not():
    """The first run after installing compiles numba's kernels for seconds (the attitude filter's 15-20 s) with
    nothing on the screen: the note says so once, while a compile lasts longer than ``after_s``; a kernel already
    compiled (or loaded from numba's cache: no compile event) is not said, nor anything when not on a terminal."""
    import io

    import numba

    from optinav.core.progress import COMPILE_NOTE, compile_note

    def fresh():
        @numba.njit
        def total(n):
            s = 0.0
            for i in range(n):
                s += i * 0.5
            return s

        return total

    f = fresh()
    said = io.StringIO()
    with compile_note(after_s=0.0, enabled=True, stream=said):
        assert f(4) == 3.0
    assert said.getvalue() == COMPILE_NOTE + "\n"
    again = io.StringIO()
    with compile_note(after_s=0.0, enabled=True, stream=again):
        f(5)
    assert again.getvalue() == ""
    with compile_note(after_s=0.0, enabled=False, stream=again):
        fresh()(4)
    assert again.getvalue() == ""
