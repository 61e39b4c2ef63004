"""The README's Python examples run as written."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_examples():
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_readme_example_runs(code, capsys):
    exec(compile(code, str(README), "exec"), {"__name__": "readme"})
    assert capsys.readouterr().out.strip()


def _cli_lines() -> list[str]:
    """`optinav …` command lines of the README's bash blocks, except the long reproduce runs and pip lines."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S):
        for line in block.splitlines():
            cmd = line.split("#")[0].strip()
            if cmd.startswith("optinav ") and " reproduce" not in cmd:
                lines.append(cmd)
    return lines


def test_readme_cli_examples_run_as_written(tmp_path, monkeypatch, capsys):
    """The CLI examples work in an empty folder, in order (later ones use the files earlier ones write)."""
    import shlex

    from optinav.cli.main import main

    cmds = _cli_lines()
    assert any(c.startswith("optinav calibrate") for c in cmds)
    monkeypatch.chdir(tmp_path)
    for cmd in cmds:
        argv = shlex.split(cmd)[1:]
        try:
            code = main(argv)
        except SystemExit as exc:  # --help
            code = exc.code
        assert code == 0, cmd
