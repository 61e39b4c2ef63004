"""The quick report (`optinav --quiet reproduce --quick`), run once per test session and shared by the tests.

Import the fixture into a test module (``from report_fixture import quick_report  # noqa: F401``). Under
pytest-xdist the workers share one run: the first to take the lock writes the report, the others read it.
"""

import fcntl
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest


@dataclass
class QuickReport:
    out: Path
    returncode: int
    stderr: str

    @property
    def summary(self) -> dict:
        return json.loads((self.out / "summary.json").read_text(encoding="utf-8"))

    def study(self, name: str) -> dict:
        return self.summary["studies"][name]


@pytest.fixture(scope="session")
def quick_report(tmp_path_factory) -> QuickReport:
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # shared by the workers of this session
    out, done = base / "quick-report", base / "quick-report.json"
    with open(base / "quick-report.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            # as a user runs it: the console entry point in a fresh process
            proc = subprocess.run(
                [sys.executable, "-m", "optinav.cli.main", "--quiet", "reproduce", "--quick", "--out", str(out)],
                capture_output=True,
                text=True,
                timeout=900,
            )
            done.write_text(json.dumps({"returncode": proc.returncode, "stderr": proc.stderr}))
    rec = json.loads(done.read_text())
    return QuickReport(out, rec["returncode"], rec["stderr"])


def study_failures(study: dict) -> list[str]:
    """The failed checks of one study of summary.json, as readable lines."""
    return [f"{c['name']}: {c['value']} vs {c['kind']} {c['limit']}" for c in study["checks"] if not c["passed"]]
