"""The quick report (`optinav --quiet reproduce --quick`), run once per test session and shared by the tests.

Import the fixture into a test module (``from report_fixture import quick_report  # noqa: F401``). Under
pytest-xdist the workers share one run: the first to take the lock writes the report, the others read it. A run
of whole folders starts it at the session's start in a background process (conftest.py): its tests then wait
for less than the run, and no worker idles on the lock while another builds it.
"""

import fcntl
import json
import os
import subprocess
import sys
import time
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


TIMEOUT_S = 900


def paths(base: Path) -> tuple[Path, Path, Path]:
    """The report folder, its record (return code and stderr, written last) and the background-start marker."""
    return base / "quick-report", base / "quick-report.json", base / "quick-report.started"


def build(out: Path, done: Path) -> None:
    """Run the quick report as a user runs it (the console entry point in a fresh process); record the outcome
    in ``done`` atomically, also when the run fails or times out."""
    rec = {"returncode": -1, "stderr": "the quick report did not finish"}
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "optinav.cli.main", "--quiet", "reproduce", "--quick", "--out", str(out)],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        rec = {"returncode": proc.returncode, "stderr": proc.stderr}
    except subprocess.TimeoutExpired:
        rec["stderr"] = f"the quick report took more than {TIMEOUT_S} s"
    finally:
        tmp = done.with_suffix(".tmp")
        tmp.write_text(json.dumps(rec))
        os.replace(tmp, done)


def start_in_background(base: Path) -> subprocess.Popen:
    """Start :func:`build` in a background process for the fixture to wait for (conftest.py)."""
    out, done, started = paths(base)
    started.write_text("")
    return subprocess.Popen([sys.executable, __file__, str(out), str(done)])


@pytest.fixture(scope="session")
def quick_report(tmp_path_factory) -> QuickReport:
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # shared by the workers of this session
    out, done, started = paths(base)
    with open(base / "quick-report.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            if started.exists():  # the session's start launched it: wait for its record
                t0 = time.monotonic()
                while not done.exists() and time.monotonic() - t0 < TIMEOUT_S + 60:
                    time.sleep(0.2)
            else:
                build(out, done)
    rec = json.loads(done.read_text())
    return QuickReport(out, rec["returncode"], rec["stderr"])


def study_failures(study: dict) -> list[str]:
    """The failed checks of one study of summary.json, as readable lines."""
    return [f"{c['name']}: {c['value']} vs {c['kind']} {c['limit']}" for c in study["checks"] if not c["passed"]]


if __name__ == "__main__":
    build(Path(sys.argv[1]), Path(sys.argv[2]))
