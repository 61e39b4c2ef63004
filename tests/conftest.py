"""Test configuration: studies marked ``slow`` run only with OPTINAV_FULL=1 (CI runs their quick versions).

With the environment variable ``CI`` set (the README's test command sets it) Hypothesis uses the ``ci`` profile:
derandomized, so every CI run draws the same examples and a failure reproduces on every machine. Without it the
``dev`` profile draws new examples each run (``--hypothesis-seed N`` repeats one). Neither has a deadline: speed
belongs in benchmarks/, and a loaded machine made the 200 ms default fail examples that are correct."""

import json
import os

# The README's command runs two workers on two cores (and the quick report beside them): BLAS threads of their own
# only oversubscribe the cores (a 201×201 matrix product test took 2.6× the CPU with OpenBLAS's default threads).
# Set before numpy loads in the workers, which inherit this environment; a value the caller set is kept.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


_BACKGROUND = []


def pytest_sessionstart(session):
    """A run of whole folders (the README's command) starts the quick report in the background at once: its 50 s
    then overlap the other tests instead of holding a worker (or two, one waiting on the other's lock); and it
    compiles the attitude kernels once before the workers start (:func:`_warm_kernels`)."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return  # the controller (or a plain session) starts it; the workers share its folder
    from pathlib import Path

    args = [a.split("::")[0] for a in session.config.args] or ["tests"]
    if not all(Path(a).is_dir() for a in args):
        return  # single files or tests: the fixture builds it only if asked for
    from report_fixture import start_in_background

    _BACKGROUND.append(start_in_background(session.config._tmp_path_factory.getbasetemp()))
    _warm_kernels()


def _warm_kernels() -> None:
    """Compile the attitude estimators' kernels into numba's cache once, while the quick report starts on the other
    core and before the workers start (xdist starts them after this hook): on a fresh install each worker compiled
    the same kernels at once. The attitude tests on 2 workers from an empty cache: 199 s, 127 s after the 32-s warm-up.
    A failure here is no test's: the tests compile what they need themselves."""
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).with_name("warm_kernels.py")
    try:
        subprocess.run([sys.executable, str(script)], timeout=600, capture_output=True)
    except (OSError, subprocess.TimeoutExpired):
        pass


def pytest_sessionfinish(session, exitstatus):
    for proc in _BACKGROUND:  # an interrupted run leaves no report running
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def pytest_collection_modifyitems(config, items):
    if os.environ.get("OPTINAV_FULL"):
        return
    skip = pytest.mark.skip(reason="slow study: set OPTINAV_FULL=1 to run the full version")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def cube(tmp_path):
    """A valid gyro-free configuration file (six tangential accelerometers)."""
    cfg = {
        "accelerometers": [
            {"position": [0.1, 0, 0], "direction": [0, 1, 0]},
            {"position": [0.1, 0, 0], "direction": [0, 0, 1]},
            {"position": [0, 0.1, 0], "direction": [1, 0, 0]},
            {"position": [0, 0.1, 0], "direction": [0, 0, 1]},
            {"position": [0, 0, 0.1], "direction": [1, 0, 0]},
            {"position": [0, 0, 0.1], "direction": [0, 1, 0]},
        ]
    }
    p = tmp_path / "cube.json"
    p.write_text(json.dumps(cfg))
    return p
