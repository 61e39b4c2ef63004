"""docs/howto/calibrate-your-imu.md runs as written: its bash `optinav` lines and Python blocks, in order, in an empty
folder (later steps read the files earlier ones wrote), as tests/test_readme.py does for the README."""

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
    for command in ("design", "simulate", "calibrate", "apply", "allan", "export"):
        assert command in kinds
    monkeypatch.chdir(tmp_path)
    for kind, text in steps:
        if kind == "bash":
            assert main(["--quiet", *shlex.split(text)[1:]]) == 0, text
        else:
            exec(compile(text, str(HOWTO), "exec"), {"__name__": "howto"})
    out = capsys.readouterr().out
    assert "held-out pose" in out and "Kalibr imu.yaml written" in out
    assert (tmp_path / "kalibr-imu.yaml").is_file() and (tmp_path / "allan-report" / "index.md").is_file()
    import numpy as np

    from optinav.io import read_imu

    ref, tk = read_imu("corrected-imucal.csv"), read_imu("corrected-imu_tk.csv")
    assert np.allclose(ref.acc, tk.acc, rtol=1e-9, atol=1e-9) and np.allclose(ref.gyr, tk.gyr, rtol=1e-9, atol=1e-9)
