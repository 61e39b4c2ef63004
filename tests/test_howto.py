"""docs/howto/calibrate-your-imu.md runs as written: its `optinav` command lines, in order, in an empty folder (later
steps read the files earlier ones wrote), as tests/test_readme.py does for the README. Every step is a command the
engineer types: the page has no Python block."""

import re
import shlex
from pathlib import Path

HOWTO = Path(__file__).resolve().parents[1] / "docs" / "howto" / "calibrate-your-imu.md"


def _steps() -> list[tuple[str, str]]:
    """("bash", command line) and ("python", code) in document order."""
    steps = []
    for lang, body in re.findall(r"```(bash|python)\n(.*?)```", HOWTO.read_text(encoding="utf-8"), flags=re.S):
        if lang == "python":
            steps.append(("python", body))
            continue
        for line in body.splitlines():
            cmd = line.split("#")[0].strip()
            if cmd:
                assert cmd.startswith("optinav "), f"the how-to's shell lines are optinav commands: {cmd}"
                steps.append(("bash", cmd))
    return steps


def test_howto_runs_as_written(tmp_path, monkeypatch, capsys):
    from optinav.cli.main import main

    steps = _steps()
    kinds = [s[1].split()[1] for s in steps if s[0] == "bash"]
    for command in ("design", "simulate", "calibrate", "report", "apply", "allan", "export"):
        assert command in kinds
    assert all(kind == "bash" for kind, _ in steps), "the how-to's steps are CLI commands"
    monkeypatch.chdir(tmp_path)
    for kind, text in steps:
        if kind == "bash":
            assert main(["--quiet", *shlex.split(text)[1:]]) == 0, text
        else:
            exec(compile(text, str(HOWTO), "exec"), {"__name__": "howto"})
    out = capsys.readouterr().out
    assert "held-out pose 9" in out and "Kalibr imu.yaml written" in out
    assert (tmp_path / "kalibr-imu.yaml").is_file() and (tmp_path / "allan-report" / "index.md").is_file()
    import json

    import numpy as np

    from optinav.io import read_imu
    from optinav.multipos.plan import PosePlan
    from optinav.multipos.result import CalibrationResult

    # the session followed the designed plan, and the calibration found its poses and determined all 9 parameters
    plan = PosePlan.from_json("plan.json")
    truth = json.loads((tmp_path / "session.truth.json").read_text())
    res = CalibrationResult.from_json("result.json")
    assert plan.n_poses == 18 and len(res.static_intervals) == 18
    assert res.observability["accelerometer"]["rank"] == 9 and "Observability" in Path("result-report.md").read_text()
    # against the simulated unit: K·Kᵀ (free of the choice of body axes) and b within 6σ of the fit
    K, K_true = res.accelerometer["K"], np.asarray(truth["accelerometer"]["K"])
    tol = 2 * np.abs(K).max() * 6 * np.max(res.accelerometer["K_std"])
    np.testing.assert_allclose(K @ K.T, K_true @ K_true.T, rtol=0, atol=tol)
    np.testing.assert_array_less(
        np.abs(res.accelerometer["b"] - truth["accelerometer"]["b"]), 6 * res.accelerometer["b_std"]
    )
    # the held-out pose: its error is of the size of the poses used (out-of-sample check of step 5)
    held = CalibrationResult.from_json("result-17.json").quality["held_out"]
    assert held["pose"] == 9 and held["n_used"] == 17
    assert abs(held["norm_error_m_s2"]) < 5 * held["rms_used_m_s2"] + 1e-3

    ref, tk = read_imu("corrected-imucal.csv"), read_imu("corrected-imu_tk.csv")
    assert np.allclose(ref.acc, tk.acc, rtol=1e-9, atol=1e-9) and np.allclose(ref.gyr, tk.gyr, rtol=1e-9, atol=1e-9)


def test_hold_out_and_plan_refusals(tmp_path, capsys):
    """--hold-out names a pose the log has; --plan and --scheme exclude each other: one-line errors, exit 2."""
    from optinav.cli.main import main

    csv = tmp_path / "s.csv"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(csv),
                "--scheme",
                "paper12",
                "--dwell",
                "4",
                "--seed",
                "4",
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert (
        main(
            ["calibrate", "accel", str(csv), "--gravity", "9.80", "--hold-out", "13", "--out", str(tmp_path / "r.json")]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "optinav: error: --hold-out 13: the log has 12 static poses; pass K from 1 to 12"
    assert not (tmp_path / "r.json").exists()
    with __import__("pytest").raises(SystemExit) as exc:
        main(["simulate", "accel-multipos", "--out", str(tmp_path / "x.csv"), "--scheme", "six", "--plan", "p.json"])
    assert exc.value.code == 2 and "not allowed with argument" in capsys.readouterr().err


def test_simulate_plan_names_a_file_of_the_wrong_kind(tmp_path, capsys):
    """The howto's design writes plan.md and plan.json; simulate --plan plan.md said 'result file plan.md is not
    valid JSON; pass an unmodified optinav result file', an allan result 'pass the right result file': each names
    --plan and the plan.json it takes."""
    from optinav.cli.main import main

    md, js = tmp_path / "plan.md", tmp_path / "plan.json"
    for out in (md, js):
        assert main(["--quiet", "design", "--poses", "9", "--dwell", "5", "--out", str(out)]) == 0
    for bad, why in ((md, "is not valid JSON"), (tmp_path / "allan.json", "is not a optinav.pose_plan")):
        if bad.suffix == ".json":
            bad.write_text(js.read_text().replace('"optinav.pose_plan"', '"optinav.allan"'))
        capsys.readouterr()
        assert main(["simulate", "accel-multipos", "--out", str(tmp_path / "s.csv"), "--plan", str(bad)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--plan {bad}:" in err and why in err, err
        assert "--plan takes the plan.json of optinav design --out plan.json" in err


def test_simulate_plan_keeps_the_plans_headings(tmp_path):
    """simulate --plan kept the plan's up directions and turned each pose 90° in heading from the last, not as the
    plan says (a helper's finding): the turns the gyro calibration observes were not the plan's. The simulated
    poses are now the plan's C_b^n, headings too."""
    import json

    from optinav.cli.main import main
    from optinav.multipos.design import describe_pose
    from optinav.multipos.plan import PosePlan

    plan, data = tmp_path / "plan.json", tmp_path / "s.csv"
    assert main(["--quiet", "design", "--poses", "9", "--dwell", "5", "--out", str(plan)]) == 0
    assert main(["--quiet", "simulate", "accel-multipos", "--plan", str(plan), "--out", str(data)]) == 0
    poses = json.loads(data.with_name("s.truth.json").read_text())["poses"]
    p = PosePlan.from_json(plan)
    assert poses == [describe_pose(c, frame="enu") for c in p.orientations]
    assert any("azimuth" in w for w in poses)  # headings of the plan's own, not multiples of 90°
