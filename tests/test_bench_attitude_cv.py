"""benchmarks/bench_attitude_cv.py tunes every compared method by the same procedure: a grid of the same size
around each method's own defaults (the README's iframe-vs-VQF comparison rests on it)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import bench_attitude_cv as cv  # noqa: E402

from optinav.attitude.iframe import IFRAME_DEFAULTS  # noqa: E402


def test_every_method_gets_a_grid_of_the_same_size_around_its_defaults():
    for quick in (True, False):
        grids = cv.grids(quick)
        assert set(grids) == {"iframe", "vqf"}
        assert len(grids["iframe"]) == len(grids["vqf"]) >= 12
        assert {k: IFRAME_DEFAULTS[k] for k in grids["iframe"][0]} in grids["iframe"]
        assert cv.VQF_DEFAULTS in grids["vqf"]
        # the accelerometer time constant takes the same values for both
        assert {g["tau_acc"] for g in grids["iframe"]} == {g["tauAcc"] for g in grids["vqf"]}


def test_logo_cv_chooses_on_the_other_groups_only():
    import numpy as np

    # config 0 is best on group a, config 1 on group b: each held-out group is scored with the other's choice
    err = np.array([[1.0, 1.0, 5.0], [3.0, 3.0, 2.0]])
    out, chosen = cv.logo_cv(err, ["a", "a", "b"])
    assert chosen == {"a": 1, "b": 0} and np.allclose(out, [3.0, 3.0, 5.0])
