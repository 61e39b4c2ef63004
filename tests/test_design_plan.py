"""``optinav design``: the words name the right face for known poses, the turns bring the next pose up, the
predicted std of the accelerometer and gyroscope parameters match Monte Carlo runs of the calibrators, and the
command writes Markdown, JSON and a figure."""

import json
import math
import re

import numpy as np
import pytest
from norm_fit_mc import norm_fit_errors

from optinav.cli.main import main
from optinav.core.simulate import orientation_from_up
from optinav.errors import OptinavError
from optinav.multipos import model
from optinav.multipos.design import default_candidates, pose_orientation
from optinav.multipos.gyro import calibrate_gyro
from optinav.multipos.plan import noise_from_allan, plan_poses, pose_words, turn_between

S = math.sqrt(0.5)


@pytest.mark.parametrize(
    "c, words",
    [
        (np.eye(3), "+z face up; y axis north"),  # body = ENU
        (orientation_from_up("x", frame="enu"), "+x face up; y axis north"),
        (orientation_from_up("-y", north="x", frame="enu"), "−y face up; x axis north"),
        (
            orientation_from_up("-z", north="-x", frame="enu"),
            "−z face up; y axis west",
        ),  # x south, y west: y is nearer north
    ],
)
def test_words_of_axis_poses(c, words):
    assert pose_words(c) == words


def test_words_of_tilted_poses():
    w = pose_words(pose_orientation([S, -S, 0]))
    assert w.startswith("edge between the +x and −y faces up (both faces 45° above level); z axis level, pointing ")
    w = pose_words(pose_orientation(np.ones(3) / math.sqrt(3)))
    assert w.startswith("corner of the +x, +y and +z faces up (all three faces 35.3° above level)")
    w = pose_words(pose_orientation([math.cos(0.5), 0, -math.sin(0.5)]))
    assert w == "+x face 61.4°, −z face 28.6° above level; y axis level, pointing north"


def _up_from_words(text: str) -> np.ndarray:
    """The body up vector a technician realizes from the words: the named faces at the named elevation."""
    faces = re.findall(r"([+−])([xyz])", text.split(";")[0])
    elev = [float(x) for x in re.findall(r"([0-9.]+)°", text.split(";")[0])]
    up = np.zeros(3)
    for k, (s, a) in enumerate(faces):
        e = elev[min(k, len(elev) - 1)] if elev else 90.0
        up["xyz".index(a)] = (1 if s == "+" else -1) * math.sin(math.radians(e))
    return up


def test_words_round_trip_all_candidates():
    for u in default_candidates():
        c = pose_orientation(u)
        np.testing.assert_allclose(_up_from_words(pose_words(c)), u, atol=1e-3)
        assert pose_words(c).count(";") == 1


def test_turns_bring_the_next_face_up():
    ax, ang, words = turn_between([1, 0, 0], [0, 0, 1])
    assert words == "tip it 90° about its y axis until the +z face is up"
    assert abs(ang - math.pi / 2) < 1e-12 and np.allclose(np.abs(ax), [0, 1, 0])
    ax, ang, words = turn_between([0, 0, 1], [0, 0, -1])
    assert words.startswith("tip it 180° about its x axis")
    for u0 in default_candidates():
        for u1 in default_candidates():
            ax, ang, _ = turn_between(u0, u1)
            # a world-fixed vector's body components turn opposite to the body: rotating u0 about ax by +ang
            # (right hand) gives u1, so the body turns by −ang about ax and u1 ends up pointing up
            np.testing.assert_allclose(_rotate(u0, ax, ang), u1, atol=1e-9)


def _rotate(v, ax, ang):
    """Rodrigues: v rotated about unit ax by ang (right hand)."""
    v, ax = np.asarray(v, float), np.asarray(ax, float)
    return v * math.cos(ang) + np.cross(ax, v) * math.sin(ang) + ax * (ax @ v) * (1 - math.cos(ang))


def test_dwell_meets_the_target_and_accelerometer_std_matches_monte_carlo():
    """9 poses, dwell from a bias target; 300 simulated calibrations (norm fit of the pose means) scatter as
    predicted (sampling error of a std from 300 runs ≈ 4 %)."""
    n_acc = 2e-3  # m/s²/√Hz: a noisy MEMS, so a few seconds are enough
    plan = plan_poses(9, acc_noise_density=n_acc, gyro_noise_density=None, targets={"bias_mg": 0.02}, rng=0)
    pred = np.array(plan.acc_std)
    assert plan.dwell_s > 10 and np.max(pred[6:]) <= 0.02e-3 * 9.80665 * (1 + 1e-9)
    # one second less would miss the target: the dwell is the smallest whole second that meets it
    shorter = plan_poses(9, acc_noise_density=n_acc, dwell_s=plan.dwell_s - 1.0, rng=0)
    assert np.max(np.array(shorter.acc_std)[6:]) > 0.02e-3 * 9.80665
    g = plan.g
    K = np.array([[1.003, 0.002, -0.001], [0.0, 0.996, 0.0015], [0.0, 0.0, 1.002]])
    b = np.array([0.04, -0.02, 0.03])
    truth = model.Kb_to_theta(K, b)
    clean = (K @ (g * plan.up_dirs).T).T + b
    errs = norm_fit_errors(clean, n_acc / math.sqrt(plan.dwell_s), truth, g, 300, seed=11)
    ratio = np.std(errs, axis=0) / pred
    assert np.all((ratio > 0.82) & (ratio < 1.18)), ratio


def _session(plan, K, b, n_gyro, rate, rng):
    """Gyro samples of the plan: rests of dwell_s and constant-rate turns, white noise n_gyro (rad/s/√Hz); the
    static intervals as calibrate's detection leaves them (:data:`STATIC_PAD_S` less per rest)."""
    from optinav.multipos.plan import STATIC_PAD_S

    dt = 1.0 / rate
    parts, intervals, i0 = [], [], 0
    sd = n_gyro * math.sqrt(rate)
    n_rest = int(round(plan.dwell_s * rate))
    for k in range(plan.n_poses):
        parts.append(np.zeros((n_rest, 3)))
        pad = int(round(0.5 * STATIC_PAD_S * rate))
        intervals.append((i0 + (pad if k else 0), i0 + n_rest - (pad if k < len(plan.turns) else 0)))
        i0 += n_rest
        if k < len(plan.turns):
            tr = plan.turns[k]
            n = int(round(tr["duration_s"] * rate))
            # the body turns by −angle about the axis (see turn_between); the samples span n steps exactly
            w = -np.asarray(tr["axis_body"]) * math.radians(tr["angle_deg"]) / (n * dt)
            parts.append(np.tile(w, (n, 1)))
            i0 += n
    omega = np.vstack(parts)
    t = np.arange(omega.shape[0]) * dt
    raw = omega @ K.T + b + rng.normal(0.0, sd, omega.shape)
    return t, raw, np.array(intervals)


def test_gyro_std_matches_monte_carlo_of_the_turn_calibration():
    """The first-order prediction of the gyro K std against 30 runs of the real turn calibration (imu_tk's
    method, the bias interpolated between the rests as calibrate's default): within the sampling error of 30 runs
    (≈ 13 % per entry) and the first-order model."""
    n_gyro = 2e-3  # rad/s/√Hz
    plan = plan_poses(12, acc_noise_density=1e-3, gyro_noise_density=n_gyro, dwell_s=4.0, turn_rate_deg_s=60.0, rng=0)
    pred = np.array(plan.gyro_std[:9], float)
    K = np.array([[1.01, 0.003, -0.002], [0.001, 0.99, 0.004], [-0.003, 0.002, 1.005]])
    b = np.array([0.01, -0.02, 0.015])
    rng = np.random.default_rng(5)
    errs = []
    for _ in range(30):
        t, raw, iv = _session(plan, K, b, n_gyro, 50.0, rng)
        cal = calibrate_gyro(t, raw, iv, plan.up_dirs, bias="local")
        errs.append((cal.K - K).ravel())
    ratio = np.sqrt(np.mean(np.square(errs), axis=0)) / pred
    assert np.all((ratio > 0.65) & (ratio < 1.4)), ratio
    assert 0.85 < np.exp(np.mean(np.log(ratio))) < 1.18, ratio


def test_noise_from_allan_json(tmp_path):
    p = tmp_path / "allan.json"
    p.write_text(
        json.dumps(
            {
                "schema": "x",
                "kalibr": {"accelerometer_noise_density": 0.002, "gyroscope_noise_density": [1e-4, 2e-4, 3e-4]},
            }
        )
    )
    got = noise_from_allan(p)
    assert np.allclose(got["acc"], 0.002) and np.allclose(got["gyro"], [1e-4, 2e-4, 3e-4])
    p.write_text(json.dumps({"gyroscope_noise_density": -1}))
    with pytest.raises(OptinavError, match="not a positive number"):
        noise_from_allan(p)
    p.write_text("{}")
    with pytest.raises(OptinavError, match="holds neither"):
        noise_from_allan(p)
    # optinav's own allan result of a log in counts has no densities: named as such, not "pass optinav's JSON"
    p.write_text(json.dumps({"schema": "optinav.allan", "fields": {"kalibr": {"value": {"update_rate": 100.0}}}}))
    with pytest.raises(OptinavError, match="allan result of a log in raw units.*optinav apply"):
        noise_from_allan(p)


def test_cli_writes_markdown_json_and_figure(tmp_path, capsys):
    allan = tmp_path / "a.json"
    allan.write_text(json.dumps({"accelerometer_noise_density": 1e-3, "gyroscope_noise_density": 1e-4}))
    md, js, png = tmp_path / "plan.md", tmp_path / "plan.json", tmp_path / "plan.png"
    assert (
        main(
            [
                "design",
                "--poses",
                "10",
                "--criterion",
                "A",
                "--allan",
                str(allan),
                "--target-scale",
                "200",
                "--out",
                str(md),
                "--figure",
                str(png),
            ]
        )
        == 0
    )
    text = md.read_text()
    assert text.startswith("# Calibration pose plan: 10 poses (A-optimal)")
    assert text.count("\n| ") >= 10 + 21 and "ppm (scale factor)" in text and "deg/h (bias)" in text
    # the bias std is the session's (a helper read it against a long-term bias): said beside the table
    assert "The biases' 1σ is against their mean over the session's rests" in text
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (
        main(["--quiet", "design", "--poses", "10", "--allan", str(allan), "--target-scale", "200", "--out", str(js)])
        == 0
    )
    d = json.loads(js.read_text())
    assert d["schema"] == "optinav.pose_plan"
    f = d["fields"]
    assert len(f["words"]["value"]) == 10 and len(f["turns"]["value"]) == 9
    assert max(f["acc_std"]["value"][:3]) <= 200e-6
    capsys.readouterr()
    assert main(["design", "--dwell", "10", "--target-bias", "1", "--out", str(tmp_path / "x.md")]) == 2
    assert "--dwell and a --target-* option" in capsys.readouterr().err
    assert main(["design", "--out", str(tmp_path / "x.txt")]) == 2
    assert main(["design", "--allan", str(tmp_path / "missing.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(e.startswith("optinav: error: ") for e in err)


def test_gyro_std_includes_the_g_sensitivity_of_a_consumer_mems():
    """mpu6000 (0.1 °/s/g g-sensitivity): the plan predicted gyro scales 20-40x and biases 30x better than
    `calibrate accel` reaches on the plan's own simulated session (white noise only); with G, within 2x. The
    session follows the plan: its poses' headings and its turns' durations (`simulate --plan`)."""
    from optinav.multipos.calibrate import calibrate
    from optinav.multipos.plan import plan_g_sensitivity, plan_noise
    from optinav.multipos.simulate import simulate

    acc, gyro, _ = plan_noise(preset="mpu6000")
    gs, text = plan_g_sensitivity(preset="mpu6000")
    assert gs > 0 and "deg/s/g" in text
    plan = plan_poses(12, acc_noise_density=acc, gyro_noise_density=gyro, dwell_s=30, gyro_g_sensitivity=gs)
    k_err, b_err = [], []
    for seed in range(4):
        s = simulate(
            np.asarray(plan.up_dirs),
            spec="mpu6000",
            dwell_s=30,
            rest_s=30,
            orientations=np.asarray(plan.orientations),
            transition_s=[t["duration_s"] for t in plan.turns],
            rng=seed,
        )
        r = calibrate(s.t, s.acc, s.gyr, g=s.gravity, rng=1)
        k_err.append(np.diag(r.gyroscope["K"]) / np.diag(s.gyr_K) - 1)
        b_err.append(r.gyroscope["b"] - s.gyr_b)
    pred = np.array(plan.gyro_std, float)
    k_ratio = np.sqrt(np.mean(np.square(k_err))) / np.mean(pred[[0, 4, 8]])
    b_ratio = np.sqrt(np.mean(np.square(b_err))) / np.mean(pred[9:])
    assert 0.5 < k_ratio < 2 and 0.5 < b_ratio < 2, (k_ratio, b_ratio)


@pytest.mark.parametrize(
    "argv, flag, reach",
    [
        (["--target-bias", "1e-6"], "--target-bias", "(600 s per pose reach 0.00245 mg)"),
        (["--preset", "rlg-nav", "--target-scale", "0.001"], "--target-scale", "(600 s per pose reach 0.354 ppm)"),
        (["--target-gyro-bias", "0.05"], "--target-gyro-bias", "deg/h)"),
    ],
)
def test_a_target_past_the_allan_minimum_is_refused(tmp_path, capsys, argv, flag, reach):
    """A target needing more rest per pose than --max-dwell (3.6e9 s for a 1e-6 mg bias) gave a plan promising it
    with exit 0 and only a note that averaging there does not help: the white-noise 1σ do not hold past the Allan
    minimum. Refused naming the target's flag and what --max-dwell reaches; the reach itself is met by a plan."""
    out = tmp_path / "p.json"
    assert main(["design", "--poses", "12", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "more than --max-dwell 600 s" in err and f"relax {flag}" in err, err
    assert reach in err, err
    value = float(re.search(r"reach ([0-9.e+-]+) ", err).group(1))
    assert main(["--quiet", "design", "--poses", "12", *argv[:-1], f"{value * 1.01:.6g}", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["fields"]["dwell_s"]["value"] <= 600


def test_a_dwell_past_the_allan_minimum_is_refused(tmp_path, capsys):
    """--dwell 1e9 (31 years per pose) printed a 0.00023 deg/h gyro bias 1σ with exit 0 and no word; a dwell beyond
    --max-dwell is refused as the targets are, and allowed once --max-dwell is raised."""
    out = tmp_path / "p.json"
    assert main(["design", "--dwell", "1e9", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--dwell 1e+09 s is more than --max-dwell 600 s" in err and "shorten --dwell" in err
    assert main(["--quiet", "design", "--dwell", "900", "--max-dwell", "900", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["fields"]["dwell_s"]["value"] == 900


def test_a_dwell_too_short_for_calibrate_to_find_the_rests_is_refused(tmp_path, capsys):
    """--dwell 0.001 wrote a plan with exit 0 whose rests calibrate's static detection (2 s at least by default,
    --min-duration) cannot find; refused naming the shortest dwell. The detection takes 2 s off a rest's ends too:
    a session of the plan at 3 s per pose found one rest ("only 1 static interval"), at 4 s all; 2 s was taken."""
    out = tmp_path / "p.json"
    for dwell in ("0.001", "3.9"):
        assert main(["design", "--dwell", dwell, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "shorter than the 4 s a pose must last" in err and "--min-duration" in err, err
    assert main(["--quiet", "design", "--dwell", "4", "--out", str(out)]) == 0


def test_design_takes_the_noise_of_kalibrs_imu_yaml(tmp_path, capsys):
    """Kalibr's imu.yaml (as allan_variance_ros / imu_utils write it, comments and all) was 'not valid JSON' to
    design --allan; its densities are read (SI, continuous time: the plan's convention)."""
    y = tmp_path / "imu.yaml"
    y.write_text(
        "#Accelerometers\naccelerometer_noise_density: 1.86e-03   #Noise density (continuous-time)\n"
        "accelerometer_random_walk:   4.33e-04\ngyroscope_noise_density:     1.87e-04\n"
        "gyroscope_random_walk:       2.66e-05\nrostopic: /imu0\nupdate_rate: 200.0  #Hz\n"
    )
    out = tmp_path / "p.json"
    assert main(["--quiet", "design", "--allan", str(y), "--out", str(out)]) == 0
    f = json.loads(out.read_text())["fields"]
    assert f["acc_noise_density"]["value"] == [1.86e-3] * 3 and f["gyro_noise_density"]["value"] == [1.87e-4] * 3


def test_the_allan_minimum_of_an_allan_result_caps_the_rest(tmp_path, capsys):
    """design --allan ALLAN.json ignored the Allan minimum it holds: --max-dwell stayed 600 s, so a plan could
    promise 1/√dwell past the bias instability. The shortest τ at which the result reads its bias instability is
    the cap now (said in a note), the default 30-s rest shortened to it; --max-dwell still overrides."""
    from optinav.core.allan import AllanAnalysis

    log, allan = tmp_path / "s.csv", tmp_path / "allan.json"
    sim = ["--quiet", "simulate", "static", "--out", str(log), "--hours", "0.3", "--rate", "20", "--seed", "1"]
    assert main(sim) == 0 and main(["--quiet", "allan", str(log), "--out", str(allan)]) == 0
    res = AllanAnalysis.from_json(allan)
    taus = [res.sensor(n)["read_off"].bias_instability_tau for n in ("accelerometer", "gyroscope")]
    cap = float(np.nanmin(np.concatenate(taus)))
    assert 2.0 < cap < 30.0  # this short log's minimum lies below the default rest
    out = tmp_path / "p.json"
    capsys.readouterr()
    assert main(["--quiet", "design", "--allan", str(allan), "--out", str(out)]) == 0
    assert f"capped at {cap:.4g} s, the Allan minimum" in capsys.readouterr().err
    assert json.loads(out.read_text())["fields"]["dwell_s"]["value"] == pytest.approx(cap)
    assert main(["design", "--allan", str(allan), "--target-bias", "0.001", "--out", str(out)]) == 2
    assert f"more than --max-dwell {cap:g} s" in capsys.readouterr().err
    assert (
        main(["--quiet", "design", "--allan", str(allan), "--max-dwell", "60", "--dwell", "40", "--out", str(out)]) == 0
    )


@pytest.mark.parametrize("value", ["abc", [1e-4, 2e-4], {"value": "x"}])
def test_a_noise_density_that_is_no_number_is_named(tmp_path, capsys, value):
    """A gyroscope_noise_density of text (or 2 axes) was dropped and the plan written without the gyro, exit 0."""
    p = tmp_path / "noise.json"
    p.write_text(json.dumps({"accelerometer_noise_density": 1e-3, "gyroscope_noise_density": value}))
    assert main(["design", "--allan", str(p), "--out", str(tmp_path / "p.md")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "gyro noise density" in err and "is not a positive number" in err, err
    assert "--gyro-noise-density" in err


@pytest.mark.parametrize("poses", [9, 18, 26])
def test_the_figure_title_clears_the_pose_titles(tmp_path, monkeypatch, poses):
    """The figure's title was drawn over the first row's pose titles in an 18-pose plan (5 rows)."""
    import matplotlib.pyplot as plt

    from optinav.multipos.plan import plot_plan

    figs = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figs.append(fig))
    plot_plan(plan_poses(poses, acc_noise_density=1e-3, rng=0), tmp_path / "p.png")
    fig = figs[0]
    r = fig.canvas.get_renderer()
    top = fig._suptitle.get_window_extent(r)
    for ax in fig.axes:
        box = ax.title.get_window_extent(r)
        assert not top.overlaps(box), (poses, ax.get_title())
    monkeypatch.undo()
    plt.close(fig)


def test_a_plans_poses_are_where_its_turns_leave_the_unit():
    """The pose words gave the design's own headings ("x axis level, pointing west") where the 60° tip named
    before them turned the body 90° or 163°: a technician following both, or `simulate --plan`, turned the unit
    other than the plan's gyro prediction assumed. Each pose is now the last one tipped as its turn says."""
    from optinav.core.rotations import dcm_from_rotvec

    plan = plan_poses(12, acc_noise_density=1e-3, gyro_noise_density=1e-4, dwell_s=20, rng=0)
    C = np.asarray(plan.orientations, float)
    for k, tr in enumerate(plan.turns):
        turn = dcm_from_rotvec(-np.radians(tr["angle_deg"]) * np.asarray(tr["axis_body"]))
        np.testing.assert_allclose(C[k].T @ C[k + 1], turn, atol=1e-12, err_msg=f"turn {k + 1}")
    np.testing.assert_allclose(C[:, 2, :], np.asarray(plan.up_dirs), atol=1e-12)  # C_b^nᵀ·e_U: the pose's up


def test_simulate_plan_turns_for_the_plans_durations(tmp_path):
    """`simulate --plan` turned every pose in 4 s (--transition's default) where the plan's turns take 1.3-2 s at
    its 45 °/s: the gyro integrates noise over the turn's time, so the session was not the plan's."""
    plan = tmp_path / "plan.json"
    assert main(["--quiet", "design", "--poses", "9", "--dwell", "10", "--out", str(plan)]) == 0
    out = tmp_path / "s.npz"
    assert main(["--quiet", "simulate", "accel-multipos", "--plan", str(plan), "--rest", "20", "--out", str(out)]) == 0
    turns = [t["duration_s"] for t in json.loads(plan.read_text())["fields"]["turns"]["value"]]
    t = np.load(out)["t"]
    # the initial rest, its move into the first pose (the shortest turn), 9 rests of 10 s and the plan's turns
    assert abs(t[-1] + t[1] - (20 + min(turns) + 9 * 10 + sum(turns))) < 0.02, (t[-1], sum(turns))
