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


def test_every_method_gets_a_9d_grid_of_the_same_factors_around_its_own_magnetometer_defaults():
    import numpy as np

    for quick, wide in ((True, False), (False, False), (False, True)):
        grids = cv.mag_grids(quick, wide)
        assert len(grids["iframe"]) == len(grids["vqf"]) >= 8
        assert cv.iframe_mag_defaults() in grids["iframe"]
        for k, a in cv.IFRAME_MAG_TIED.items():  # a tied option moves by its axis's factor
            assert all(np.isclose(p[k] / IFRAME_DEFAULTS[k], p[a] / IFRAME_DEFAULTS[a]) for p in grids["iframe"])
        assert cv.VQF_MAG_DEFAULTS in grids["vqf"]
        for a, b in zip(cv.IFRAME_MAG, cv.VQF_MAG):  # option by option, the same factors of each default
            fa = {round(p[a] / IFRAME_DEFAULTS[a], 9) for p in grids["iframe"]}
            fb = {round(p[b] / cv.VQF_MAG_DEFAULTS[b], 9) for p in grids["vqf"]}
            assert fa == fb and len(fa) >= 2 and 1.0 in fa


def test_the_vqf_magnetometer_grid_is_centred_on_vqfs_own_defaults():
    """The defaults the VQF grid is built around are VQF's (vqf is a benchmark extra: skipped without it)."""
    import pytest

    vqf = pytest.importorskip("vqf")
    params = vqf.VQF(0.01).params
    assert {k: params[k] for k in cv.VQF_MAG} == cv.VQF_MAG_DEFAULTS


def test_cv_rows_score_an_offline_mode_also_at_the_online_choice():
    import numpy as np

    grid = [{"x": 1.0}, {"x": 2.0}]
    err = {
        "9D online": np.array([[1.0, 1.0, 5.0], [3.0, 3.0, 2.0]]),  # folds choose: a → 1, b → 0
        "9D offline": np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 9.0]]),  # folds choose: a → 0, b → 0
    }
    rows = cv._cv_rows("m", "x", err, ["a", "a", "b"], grid, grid[0], lambda c: [("x", c["x"], "")])
    val = {(r["group"].split(",")[0], r["method"], r["metric"]): r["value"] for r in rows}
    assert val["attitude m 9D online", "m, grid of 2 (x)", "cross-validated mean heading RMSE"] == 11.0 / 3
    assert val["attitude m 9D offline", "m, grid of 2 (x)", "cross-validated mean heading RMSE"] == 1.0
    assert (
        val["attitude m 9D offline", "m, grid point chosen on the online error", "cross-validated mean heading RMSE"]
        == 5.0 / 3
    )
    assert val["attitude m 9D online", "fold without a", "chosen x"] == 2.0
    assert val["attitude m 9D online", "fold without a", "held-out mean heading RMSE, chosen point"] == 3.0
    assert val["attitude m 9D online", "fold without a", "held-out mean heading RMSE, defaults"] == 1.0
    assert val["attitude m 9D online", "m defaults", "training mean heading RMSE"] == 7.0 / 3
