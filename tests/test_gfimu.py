"""gfimu: array model, identifiability, builtin cylinder10, rate solvers, installation-error effect."""

import json

import numpy as np
import pytest

from optinav.errors import OptinavError
from optinav.gfimu import (
    AccelerometerArray,
    InstallationErrors,
    builtin,
    coning_motion,
    error_effect,
    identifiability,
    perturb,
    quadratic_products,
    solve_linear,
    solve_rate,
    spinning_motion,
)
from optinav.gfimu.errors import errors_from_geometry, local_frames


def _numeric_output(r, th, A, wdot, w):
    return th @ (A + np.cross(wdot, r) + np.cross(w, np.cross(w, r)))


def test_model_matches_cross_products():
    rng = np.random.default_rng(0)
    arr = AccelerometerArray(rng.normal(size=(7, 3)), np.eye(3)[rng.integers(0, 3, 7)] * 1.0 + 0)
    A, wd, w = rng.normal(size=(3,)), rng.normal(size=(3,)), rng.normal(size=(3,))
    f = arr.outputs(A[None], wd[None], w[None])[0]
    ref = [_numeric_output(arr.positions[i], arr.directions[i], A, wd, w) for i in range(arr.n)]
    np.testing.assert_allclose(f, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(quadratic_products([1.0, 2.0, 3.0]), [1, 4, 9, 2, 3, 6])


def test_cylinder10_identifiability():
    arr = builtin("cylinder10")
    assert arr.n == 10
    assert np.allclose(np.linalg.norm(arr.positions[:, 1:], axis=1), 0.04)  # all on the rim, l = 0.04
    assert np.all(np.abs(arr.positions[:, 0]) <= 0.02 + 1e-12)  # within L = 0.04
    idf = identifiability(arr)
    assert (idf.rank_linear, idf.rank_full, idf.n_quadratic_observable, idf.rank_quadratic) == (6, 10, 4, 4)
    assert idf.solvable_without_rate == ["A_x", "A_y", "A_z", "wdot_x", "wdot_y", "wdot_z"]
    assert "wy^2 + wz^2" in idf.quadratic_observable
    # the basis rows are estimable: z = B q recovered exactly from noise-free outputs
    rng = np.random.default_rng(1)
    w = rng.normal(size=(5, 3))
    A, wd = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    sol = solve_linear(arr, arr.outputs(A, wd, w))
    np.testing.assert_allclose(sol.A, A, atol=1e-10)
    np.testing.assert_allclose(sol.wdot, wd, atol=1e-9)
    np.testing.assert_allclose(sol.z, quadratic_products(w) @ sol.basis.T, atol=1e-9)


def test_six_radial_array_needs_rate_and_deficient_error():
    # six accelerometers on the axes, all sensing radially: no angular acceleration at all
    p = np.vstack([np.eye(3), -np.eye(3)]) * 0.05
    arr = AccelerometerArray(p, np.vstack([np.eye(3), np.eye(3)]))
    idf = identifiability(arr)
    assert idf.rank_linear == 3
    assert idf.solvable_without_rate == ["A_x", "A_y", "A_z"]
    with pytest.raises(OptinavError, match="wdot_x, wdot_y, wdot_z"):
        idf.require()
    with pytest.raises(OptinavError, match="rank deficient"):
        solve_linear(arr, np.zeros((2, 6)))


def test_config_roundtrip_and_bad_configs(tmp_path):
    arr = builtin()
    p = arr.save(tmp_path / "c.json")
    back = AccelerometerArray.load(p)
    np.testing.assert_allclose(back.positions, arr.positions)
    bad = {
        "shape": ({"accelerometers": [{"position": [0, 0], "direction": [1, 0, 0]}]}, "accelerometer 1 position"),
        "zero": ({"accelerometers": [{"position": [0, 0, 0], "direction": [0, 0, 0]}]}, "direction is zero"),
        "nonunit": ({"accelerometers": [{"position": [0, 0, 0], "direction": [1, 1, 0]}]}, "norm 1.414"),
        "dup": (
            {
                "accelerometers": [
                    {"position": [0, 0, 1], "direction": [1, 0, 0]},
                    {"position": [0, 0, 1], "direction": [1, 0, 0]},
                ]
            },
            "accelerometer 2 duplicates",
        ),
        "nolist": ({"sensors": []}, "no 'accelerometers'"),
        "key": ({"accelerometers": [{"position": [0, 0, 0], "direction": [1, 0, 0], "pos": 1}]}, "unknown key"),
    }
    for name, (cfg, msg) in bad.items():
        f = tmp_path / f"{name}.json"
        f.write_text(json.dumps(cfg))
        with pytest.raises(OptinavError, match=msg):
            AccelerometerArray.load(f)
    (tmp_path / "broken.json").write_text("{")
    with pytest.raises(OptinavError, match="not valid JSON"):
        AccelerometerArray.load(tmp_path / "broken.json")


def test_rate_methods_exact_and_noisy():
    arr = builtin()
    m = coning_motion(20.0, 0.01)
    f = arr.outputs(m.A, m.wdot, m.omega)
    # noise-free: integration error is the trapezoid error O(dt²·ω̈); the quadratic method is exact
    for method, tol in (("integration", 2e-4), ("quadratic", 1e-5), ("gauss-newton", 2e-4)):
        w = solve_rate(arr, f, m.t, m.omega[0], method)
        assert np.abs(w - m.omega).max() < tol, method
    # with 1e-4 m/s² noise the integration error is a random walk: σ_ω̇·√(T·dt)
    rng = np.random.default_rng(3)
    fn = f + rng.normal(0, 1e-4, f.shape)
    sol = solve_linear(arr, fn)
    s_wd = np.std(sol.wdot - m.wdot, axis=0).max()
    w = solve_rate(arr, fn, m.t, m.omega[0], "integration")
    assert np.abs(w[-1] - m.omega[-1]).max() < 4 * s_wd * np.sqrt(20.0 * 0.01)
    wq = solve_rate(arr, fn, m.t, m.omega[0], "quadratic")
    assert np.sqrt(np.mean((wq - m.omega) ** 2)) < 0.05


def _smooth_motion(start: str, seconds: float = 60.0, dt: float = 0.01):
    """t (s), ω (rad/s), ω̇ (rad/s²), A (m/s²) of a smooth rate at 0.2 Hz from rest or about a 2 rad/s spin."""
    t = np.arange(0.0, seconds, dt)
    W = 2 * np.pi * 0.2
    if start == "spin":
        wx, wdx = 2.0 + 0.5 * np.sin(W * t), 0.5 * W * np.cos(W * t)
    else:
        wx, wdx = 0.5 * (1 - np.cos(W * t)), 0.5 * W * np.sin(W * t)
    om = np.column_stack([wx, 0.3 * np.sin(2 * W * t), 0.4 * (1 - np.cos(W * t))])
    wd = np.column_stack([wdx, 0.6 * W * np.cos(2 * W * t), 0.4 * W * np.sin(W * t)])
    A = np.column_stack([0.5 * np.sin(0.3 * t), 9.80665 * np.cos(0.1 * t), 9.80665 * np.sin(0.1 * t)])
    return t, om, wd, A


@pytest.mark.parametrize("start", ["rest", "spin"])
def test_gauss_newton_keeps_the_rates_branch_on_a_calibrated_geometry(start):
    """A calibrated (irregular) cylinder10 at 1e-5 m/s² noise, 30 s of a smooth rate from rest through ±0.3–1
    rad/s, or about a 2 rad/s spin: the Gauss–Newton rate jumped onto the mirrored branch (ω → −ω, 2 rad/s off)
    near ω ≈ 0 and stayed there, exit 0, and was 0.03–0.12 rad/s off about the spin where the quadratic terms
    hardly see ωx; now within a few 1e-4 rad/s of the truth (the integration method: 5e-4 from rest, 0.012 about
    the spin)."""
    rng = np.random.default_rng(2)
    arr = perturb(builtin(), InstallationErrors.random(10, rng=rng))
    arr = AccelerometerArray(arr.positions, arr.directions, np.full(10, 1e-5))
    t, om, wd, A = _smooth_motion(start, seconds=30.0)
    f = arr.outputs(A, wd, om) + rng.normal(0, 1e-5, (t.size, 10))
    w = solve_rate(arr, f, t, om[0], "gauss-newton")
    err = np.abs(w - om)[t > 1.0].max(axis=0)
    assert np.all(err < 1e-3), err


@pytest.mark.parametrize("geometry", ["nominal", "perturbed"])
def test_motion_solver_blocks_equal_the_whole_log(geometry):
    """The blocks of a log (odd lengths, one of a single epoch) solved with the rate state carried give the
    whole-array solve_motion to rounding, for every rate method the geometry admits (nominal: separable ω̇,
    vectorized integration; perturbed: the compensated integration loop)."""
    from optinav.gfimu.solve import MotionSolver, RATE_METHODS, solve_motion

    arr = builtin()
    if geometry == "perturbed":
        arr = perturb(arr, InstallationErrors.uniform(arr.n))
    m = spinning_motion(duration=3.0, dt=0.01)
    f = arr.outputs(m.A, m.wdot, m.omega) + np.random.default_rng(5).normal(0, 1e-5, (m.t.size, arr.n))
    cuts = [0, 7, 8, 21, 134, m.t.size]
    methods = RATE_METHODS if geometry == "nominal" else ("integration", "gauss-newton")
    for method in methods:
        whole = solve_motion(arr, f, m.t, m.omega[0], method)
        solver = MotionSolver(arr, m.omega[0], method)
        parts = [solver(f[a:b], m.t[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
        assert solver.rows == m.t.size
        for name in ("omega", "A", "wdot"):
            got = np.concatenate([getattr(p, name) for p in parts])
            np.testing.assert_allclose(got, getattr(whole, name), rtol=0, atol=1e-12, err_msg=f"{method} {name}")
        # the solve is a real one: the rate is the motion's to within the method's error
        assert np.abs(whole.omega - m.omega).max() < 0.05, method
    # time must increase across blocks too
    solver = MotionSolver(arr, m.omega[0])
    solver(f[:5], m.t[:5])
    with pytest.raises(OptinavError, match=r"not sorted: t\[5\]"):
        solver(f[5:9], m.t[5:9] - 1.0)


def test_installation_error_frames_and_inverse():
    fr = local_frames(np.eye(3))
    np.testing.assert_allclose(fr[0], np.eye(3))  # sensor along x: (x, y, z)
    rng = np.random.default_rng(2)
    arr = builtin()
    e = InstallationErrors.random(10, rng=rng)
    act = perturb(arr, e)
    back = errors_from_geometry(arr, act.positions, act.directions)
    np.testing.assert_allclose(back.vector(), e.vector(), atol=1e-14)
    # small-angle form of the paper for a sensor along x: θ = [1, Δβ, Δα]
    x_arr = AccelerometerArray(np.zeros((1, 3)), np.array([[1.0, 0, 0]]))
    th = perturb(x_arr, InstallationErrors(np.zeros((1, 3)), 0.01, 0.02), small_angle=True).directions[0]
    np.testing.assert_allclose(th, [1, 0.02, 0.01])
    th = perturb(x_arr, InstallationErrors(np.zeros((1, 3)), 0.01, 0.02)).directions[0]
    np.testing.assert_allclose(th, [1, 0.02, 0.01], atol=3e-4)


def test_fig3_effect_position_vs_direction():
    """Paper Fig. 3: Δr = 1 mm on all sensors → negligible rate error; Δα = Δβ = 0.01 rad → large."""
    arr = builtin()
    m = coning_motion(100.0, 0.01)
    e_pos = error_effect(arr, perturb(arr, InstallationErrors(np.full((10, 3), 1e-3), 0, 0)), m)
    e_dir = error_effect(arr, perturb(arr, InstallationErrors(np.zeros((10, 3)), 0.01, 0.01)), m)
    e_none = error_effect(arr, arr, m)
    # a common position error only moves the reference point of A: the rate error is the solver's own
    assert np.abs(e_pos).max() < 2 * np.abs(e_none).max() + 1e-9
    assert np.abs(e_dir).max() > 100 * np.abs(e_pos).max()
    s = spinning_motion(10.0)
    assert np.abs(error_effect(arr, arr, s)).max() < 1e-3
