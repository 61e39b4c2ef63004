"""Quality gates of `calibrate accel`: each bad input that used to give a wrong result with exit 0 now gives the
right answer (with a note) or a one-line error naming the cause and a flag that exists."""

import re
from pathlib import Path

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.imu_model import preset
from optinav.core.units import G_STANDARD, factor
from optinav.errors import OptinavError
from optinav.multipos import gates, model
from optinav.multipos.calibrate import calibrate, count_range, saturated_mask
from optinav.multipos.result import CalibrationResult
from optinav.multipos.simulate import SCHEMES, simulate
from optinav.multipos.uncertainty import _session_gyro_bias
from csv_edit import clip_columns

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal"
needs_data = pytest.mark.skipif(not (DATA / "example_ferraris_session.csv").is_file(), reason="imucal data absent")
OFFSET = 32768.0


@pytest.fixture(scope="module")
def sim():
    """18 poses in raw counts, written as an unsigned 16-bit ADC does (offset binary, centred at 32768)."""
    s = simulate("18", dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="counts", rng=5)
    return s, np.round(s.acc + OFFSET), np.round(s.gyr + OFFSET)


def _cli_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("optinav: error: ") and "Traceback" not in "\n".join(err)
    return err[-1]


def _write(tmp_path, name, t, acc, gyro, acc_unit="m/s^2", gyro_unit="rad/s"):
    """A text log whose header declares no unit (the CLI options then state it)."""
    path = tmp_path / name
    cols = np.column_stack([t, acc] + ([gyro] if gyro is not None else []))
    head = "t,ax,ay,az" + (",gx,gy,gz" if gyro is not None else "")
    np.savetxt(path, cols, delimiter=",", header=head, comments="", fmt="%.10g")
    return path


# ---------------------------------------------------------------------------------------------------- counts


def test_unsigned_counts_are_not_saturated_at_mid_scale():
    raw = np.array([[32767.0, 32768, 40000], [30000, 32767, 32768]])
    assert count_range(raw) == (0.0, 65535.0)
    assert not saturated_mask(raw, counts=True).any()
    assert count_range(raw - OFFSET) == (-32768.0, 32767.0)
    assert saturated_mask(np.array([[0.0, 1, 2], [65535, 3, 4], [5, 6, 7]]), counts=True).tolist() == [
        True,
        True,
        False,
    ]
    assert saturated_mask(np.array([[-8388608.0, 0, 0], [40000, 0, 0]]), counts=True).tolist() == [True, False]
    assert saturated_mask(np.array([[99.0, 0, 0], [-101, 0, 0]]), 100.0).tolist() == [False, True]
    assert saturated_mask(np.array([[99.0, 0, 5], [-101, 0, 5]]), (0.0, 100.0)).tolist() == [True, True]


def test_unsigned_counts_calibrate_against_truth(sim):
    s, acc, gyr = sim
    r = calibrate(s.t, acc, gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity)
    assert r.excluded["saturated_acc"] == 0 and r.excluded["saturated_gyro"] == 0
    U, Q = model.upper_triangular_form(s.acc_K)
    a = r.accelerometer
    iu = np.triu_indices(3)
    # rounding to counts adds 1/√12 count of noise: tolerance from the reported std
    assert np.all(np.abs(a["K"] - U)[iu] < 5 * a["K_std"][iu] + 1e-9)
    assert np.all(np.abs(a["b"] - (s.acc_b + OFFSET)) < 5 * a["b_std"])
    Kg = s.gyr_K @ Q.T
    assert np.all(np.abs(r.gyroscope["K"] - Kg) < 5 * r.gyroscope["K_std"] + 1e-3 * np.abs(Kg).max())


@pytest.mark.parametrize("method", ["newton", "ga", "pso"])
def test_paper_methods_on_raw_counts_with_big_offsets_agree_with_lm(sim, method):
    s, acc, _ = sim
    ref = calibrate(s.t, acc, acc_unit="counts", g=s.gravity)
    r = calibrate(s.t, acc, acc_unit="counts", g=s.gravity, method=method, rng=1)
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(ref.accelerometer["K"]), rtol=5e-3)
    # bias within 0.5 % of the g span (K·g) of LM's
    assert np.all(
        np.abs(r.accelerometer["b"] - ref.accelerometer["b"]) < 5e-3 * s.gravity * np.diag(ref.accelerometer["K"])
    )


def test_a_gyro_turn_at_full_scale_is_left_out_with_a_note(sim):
    s, acc, gyr = sim
    gyr = gyr.copy()
    iv = s.static_intervals
    k = int(np.flatnonzero((s.t > iv[3, 1]) & (s.t < iv[4, 0]))[5])
    gyr[k, 0] = 65535.0
    r = calibrate(s.t, acc, gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity)
    assert r.excluded["saturated_turns"] == 1 and r.excluded["saturated_gyro"] == 1
    assert any("saturates during 1 turn" in n for n in r.quality["notes"])
    _, Q = model.upper_triangular_form(s.acc_K)
    Kg = s.gyr_K @ Q.T
    assert r.gyroscope["n_transitions"] == len(iv) - 2
    assert np.all(np.abs(r.gyroscope["K"] - Kg) < 5 * r.gyroscope["K_std"] + 1e-3 * np.abs(Kg).max())


@pytest.mark.parametrize("clip", [None, 0.6, 0.85])
def test_turns_clipped_before_the_calibration_matrix_are_left_out(clip):
    """A gyro that clips its sensor axis before its calibration matrix mixes the axes (a calibrated output) tops out
    without a flat top, its noise and the other axes' share on it: no clip test saw it and K came out 3-5 % off
    with exit 0 (a helper's finding). The turns that top out on the axis's extreme are left out when the other turns
    then fit 3x better, with a note, and K is right; unclipped, every turn is kept."""
    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    gyr = s.gyr
    if clip:
        w = np.linalg.solve(s.gyr_K, (s.gyr - s.gyr_b).T).T  # the sensor axes' rates (with their noise)
        lim = clip * np.abs(w[:, 0]).max()
        gyr = np.column_stack([np.clip(w[:, 0], -lim, lim), w[:, 1:]]) @ s.gyr_K.T + s.gyr_b
    r = calibrate(s.t, s.acc, gyr, g=s.gravity, rng=1)
    notes = [n for n in r.quality["notes"] if "top out on the gyro x" in n]
    assert bool(notes) == bool(clip) == bool(r.excluded["flat_topped_turns"]), r.quality["notes"]
    _, Q = model.upper_triangular_form(s.acc_K)
    Kg = s.gyr_K @ Q.T
    assert np.all(np.abs(r.gyroscope["K"] - Kg) < 5 * r.gyroscope["K_std"] + 1e-3 * np.abs(Kg).max())


# ---------------------------------------------------------------------------------------------------- units


@pytest.mark.parametrize("true_unit, fac", [("g", 1 / 9.80665), ("mg", 1000 / 9.80665), ("counts", 208.8)])
def test_mislabelled_accelerometer_unit_names_the_likely_one(sim, tmp_path, capsys, true_unit, fac):
    s, _, _ = sim
    path = _write(tmp_path, "a.csv", s.t, s.acc / (2048 / 9.80665) * fac, None)
    msg = _cli_error(
        capsys, ["calibrate", "accel", str(path), "--acc-unit", "m/s^2", "--out", str(tmp_path / "r.json")]
    )
    assert f"--acc-unit {true_unit}" in msg and "at rest" in msg
    assert not (tmp_path / "r.json").exists()


def test_data_in_mg_calibrates_with_acc_unit_mg(sim, tmp_path, capsys):
    s, _, _ = sim
    acc_mg = s.acc / (2048 / 9.80665) * (1000 / 9.80665)
    path = _write(tmp_path, "a.csv", s.t, acc_mg, None)
    out = tmp_path / "r.json"
    assert (
        main(["calibrate", "accel", str(path), "--acc-unit", "mg", "--gravity", str(s.gravity), "--out", str(out)]) == 0
    )
    r = CalibrationResult.from_json(out)
    assert r.units["accelerometer_raw"] == "mg"
    U, _ = model.upper_triangular_form(s.acc_K / (2048 / 9.80665) * (1000 / 9.80665))
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(U), rtol=1e-3)
    err = capsys.readouterr().err
    assert f"g = {s.gravity:.6g} m/s^2 (given)" in err


def test_standard_gravity_default_is_announced(sim):
    s, acc, _ = sim
    r = calibrate(s.t, acc, acc_unit="counts")
    assert "standard gravity, by default" in r.quality["notes"][0] and "--latitude" in r.quality["notes"][0]


def test_gyro_in_degrees_labelled_radians_is_a_unit_error(sim):
    s, _, _ = sim
    acc = s.acc / (2048 / 9.80665)
    gyr_deg = s.gyr / 16.4  # counts → deg/s
    with pytest.raises(OptinavError, match="--gyro-unit deg/s"):
        calibrate(s.t, acc, gyr_deg, acc_unit="m/s^2", gyro_unit="rad/s", g=s.gravity)


@pytest.mark.parametrize(
    "declared, data, likely",
    [
        ("rad/s", "counts", "counts"),
        ("deg/s", "counts", "counts"),
        ("deg/s", "rad/s", "rad/s"),
        ("rad/s", "deg/s", "deg/s"),
    ],
)
def test_gyro_unit_is_checked_against_the_turns_the_accelerometer_sees(sim, declared, data, likely):
    """Before any gyro fit, the turn angle (perpendicular to gravity) in the declared unit must match the
    gravity-direction change between poses: counts (16.4 per °/s) or a 57.3 mix-up is named with its flag."""
    s, acc, gyr = sim
    raw = {"counts": gyr - OFFSET, "deg/s": (gyr - OFFSET) / 16.4, "rad/s": (gyr - OFFSET) / 16.4 * np.pi / 180}
    with pytest.raises(OptinavError, match=f"turns .* as far as gravity .*pass --gyro-unit {likely}") as err:
        calibrate(s.t, acc, raw[data], acc_unit="counts", gyro_unit=declared, g=s.gravity)
    ratio = float(str(err.value).split("turns ")[1].split("×")[0])
    k = {"counts": 16.4 * 180 / np.pi, "deg/s": 180 / np.pi, "rad/s": 1.0}  # raw per rad/s of each
    expected = k[data] / k[declared]
    # perpendicular turn angle / gravity change is 1 for turns about a horizontal axis, up to π/2 otherwise
    assert expected * 0.95 < ratio < expected * 1.6, (ratio, expected)
    if likely == "counts":
        assert "--gyro-range" in str(err.value)


def test_check_gyro_turns_numbers():
    a = np.radians([90.0, 180.0, 90.0, 45.0])
    noise = np.full(4, 1e-3)
    gates.check_gyro_turns(a * 1.1, a, noise, np.arange(4), np.arange(4) + 1, "rad/s")  # within ×2.5
    gates.check_gyro_turns(a * 939, a, noise, np.arange(4), np.arange(4) + 1, "counts")  # counts: no nominal
    with pytest.raises(OptinavError, match="turns 57.3× .*look like deg/s"):
        gates.check_gyro_turns(a * 57.3, a, noise, np.arange(4), np.arange(4) + 1, "rad/s")
    with pytest.raises(OptinavError, match="1 of 4 transitions .*sees no turn .*--method ferraris"):
        gates.check_gyro_turns(np.r_[a[:3], 4e-3], a, noise, np.arange(4), np.arange(4) + 1, "counts")
    gates.check_gyro_turns(np.r_[a[:3], 6e-3], a, noise, np.arange(4), np.arange(4) + 1, "rad/s")  # 6σ: a turn


def test_a_log_cut_between_the_poses_is_named(sim):
    """The motion between poses cut out of the log (as a file of annotated sections holds it): gravity jumps
    while the gyro sees no turn; the error names the cut and --method ferraris / --no-gyro."""
    s, acc, gyr = sim
    keep = s.labels >= 0  # the static poses only
    t = np.arange(np.count_nonzero(keep)) * np.median(np.diff(s.t))
    with pytest.raises(OptinavError, match="gyroscope sees no turn .*cut between the poses.*--no-gyro"):
        calibrate(t, acc[keep], gyr[keep], acc_unit="counts", gyro_unit="counts", g=s.gravity)


@needs_data
@pytest.mark.parametrize("unit, ratio", [("rad/s", 57.3), (None, None)])
def test_imucal_example_gyro_unit_from_the_turns(tmp_path, capsys, unit, ratio):
    """imucal's Ferraris session (gyro in deg/s): read as rad/s (the default), the turn check names deg/s."""
    argv = [
        "calibrate",
        "accel",
        str(DATA / "example_ferraris_session.csv"),
        "--rate",
        "102.4",
        "--gravity",
        "9.81",
        "--out",
        str(tmp_path / "r.json"),
    ]
    if unit:
        err = _cli_error(capsys, argv)
        assert "pass --gyro-unit deg/s" in err
        got = float(err.split("turns ")[1].split("×")[0])
        assert ratio * 0.95 < got < ratio * 1.6
    else:
        assert main(argv + ["--gyro-unit", "deg/s"]) == 0


@needs_data
def test_imucal_annotated_sections_take_ferraris_by_default_and_lm_names_the_cut(tmp_path, capsys):
    """The annotated session holds only the nine cut sections, named in its label column: without --method they
    go to the Ferraris closed form (the console says why), which gives what --method ferraris gives; --method lm
    cannot integrate the turns between the cut poses and says so with the flags that work (--method ferraris,
    --no-gyro). Before, the default route was lm: one refusal more on the way to a calibration."""
    argv = [
        "calibrate",
        "accel",
        str(DATA / "annotated_session.csv"),
        "--rate",
        "204.8",
        "--acc-unit",
        "counts",
        "--gyro-unit",
        "counts",
        "--gravity",
        "9.81",
        "--rotation-angle",
        "360",
    ]
    assert main([*argv, "--out", str(tmp_path / "auto.json")]) == 0
    assert "(ferraris: the log is cut to the nine sections its labels name)" in capsys.readouterr().err
    assert main([*argv, "--method", "ferraris", "--out", str(tmp_path / "named.json")]) == 0
    auto, named = (CalibrationResult.from_json(tmp_path / f) for f in ("auto.json", "named.json"))
    assert auto.method == named.method == "ferraris"
    for sensor in ("accelerometer", "gyroscope"):
        for k in ("K", "b"):
            np.testing.assert_array_equal(getattr(auto, sensor)[k], getattr(named, sensor)[k])
    lm = [a for a in argv if a not in ("--rotation-angle", "360")] + [
        "--method",
        "lm",
        "--out",
        str(tmp_path / "r.json"),
    ]
    err = _cli_error(capsys, lm)
    assert "cut between the poses" in err and "--method ferraris" in err and "--no-gyro" in err
    assert main(lm + ["--no-gyro"]) == 0
    # a Ferraris option on a log without the labels: the norm fit does not use it, as with --method lm
    sim = tmp_path / "s.csv"
    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    np.savetxt(sim, np.column_stack([s.t, s.acc, s.gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    err = _cli_error(
        capsys, ["calibrate", "accel", str(sim), "--rotation-angle", "360", "--out", str(tmp_path / "q.json")]
    )
    assert "--method lm does not use --rotation-angle" in err and "pass --method ferraris" in err


@needs_data
@pytest.mark.parametrize("route", [["--method", "ferraris", "--rotation-angle", "360"], []])
def test_swapped_triads_in_counts_are_named(tmp_path, capsys, route):
    """imucal's annotated session (raw counts) with the gyro written in the accelerometer's columns and back: in
    counts no unit check can tell the triads apart, and both routes failed on a pose or scale gate that pointed at
    the sections or --acc-unit. The gate's error now also names the swap (the "accelerometer" norm varies by
    218 % over rests and turns, the "gyroscope" norm by 3.9 %) and --columns."""
    head = (DATA / "annotated_session.csv").read_text().splitlines()
    rows = [r.split(",") for r in head[1:]]
    swapped = tmp_path / "swapped.csv"
    swapped.write_text("\n".join([head[0]] + [",".join(r[:2] + r[5:8] + r[2:5]) for r in rows]) + "\n")
    argv = ["calibrate", "accel", str(swapped), "--rate", "204.8", "--acc-unit", "counts", "--gyro-unit", "counts"]
    err = _cli_error(capsys, argv + route + ["--out", str(tmp_path / "r.json")])
    assert "are the two triads swapped?" in err and "(--columns)" in err
    # the figure named is the data's own: the gyro columns' norm (now under the accelerometer's names) varies by
    # its coefficient of variation, computed here from the file
    gyr = np.array([[float(x) for x in r[5:8]] for r in rows])
    norm = np.linalg.norm(gyr, axis=1)
    assert f"norm varies by {np.std(norm) / np.mean(norm):.0%}" in err


def test_swapped_triads_words_only_for_the_swap(sim):
    """The words come only when the accelerometer columns' norm varies like a gyro's and the gyro columns' is
    steady: a simulated session in counts in its right order gives none, swapped gives them."""
    from optinav.multipos.calibrate import swapped_triads

    s = sim[0]
    assert swapped_triads(s.acc, s.gyr) is None
    assert "swapped" in swapped_triads(s.gyr, s.acc)
    assert swapped_triads(s.acc, None) is None


# ---------------------------------------------------------------------------------------------------- axes


@pytest.mark.parametrize("how", ["swap", "flip"])
def test_swapped_or_flipped_axes_are_named(sim, how):
    s, acc, gyr = sim
    gyr = gyr.copy()
    if how == "swap":
        gyr[:, [0, 1]] = gyr[:, [1, 0]]
    else:
        gyr[:, 2] = 2 * OFFSET - gyr[:, 2]
    with pytest.raises(OptinavError, match="swapped or flipped") as exc:
        calibrate(s.t, acc, gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity)
    assert ("gyroscope x reads +y" in str(exc.value)) if how == "swap" else ("gyroscope z reads -z" in str(exc.value))


def test_axis_permutation_diagnosis_covers_the_48_signed_permutations():
    import itertools

    rng = np.random.default_rng(0)
    seen = set()
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1, -1), repeat=3):
            P = np.zeros((3, 3))
            P[range(3), perm] = signs
            K = np.diag(rng.uniform(50, 60, 3)) @ P + rng.normal(0, 0.5, (3, 3))
            found, share = gates.axis_permutation(K)
            assert np.array_equal(found, P) and share > 0.9
            seen.add(P.tobytes())
    assert len(seen) == 48


# ---------------------------------------------------------------------------------------------------- fits


def test_motion_inside_the_static_intervals_fails_the_residual_gate(sim):
    s, acc, _ = sim
    iv = s.static_intervals
    shifted = [(a + 6.0, b + 3.0) for a, b in iv[:-1]]  # each "pose" now holds most of a turn
    with pytest.raises(OptinavError, match="static poses are not still") as e:
        calibrate(s.t, acc, acc_unit="counts", g=s.gravity, sections=shifted)
    assert "--sections" in e.value.remedy


def test_optimizer_that_stops_early_is_an_error(sim):
    s, acc, _ = sim
    with pytest.raises(OptinavError, match="did not converge.*--model diagonal"):
        calibrate(
            s.t, acc, acc_unit="counts", g=s.gravity, method="gn", model_form="full", method_options={"max_iter": 1}
        )


@needs_data
def test_imucal_repeated_poses_fall_back_to_the_diagonal_model(tmp_path, capsys):
    """The issue's case: 11 intervals but 6 distinct poses gave K_zz = 468 with exit 0."""
    out = tmp_path / "r.json"
    args = [
        "calibrate",
        "accel",
        str(DATA / "example_ferraris_session.csv"),
        "--rate",
        "102.4",
        "--gyro-unit",
        "deg/s",
        "--no-gyro",
        "--gravity",
        "9.81",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "6 distinct pose directions" in err and "held at 0" in err
    r = CalibrationResult.from_json(out)
    # imucal's diagonal scale (reference/example_ferraris_session_cal_102p4Hz.json, g = 9.81): 0.99675,
    # 1.00244, 1.02340; its cross terms (< 0.015) are what the diagonal model leaves out
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), [0.99675, 1.00244, 1.02340], atol=1e-3)
    assert r.accelerometer["held"] == ["K_xy", "K_xz", "K_yz"]
    msg = _cli_error(capsys, args[:-2] + ["--model", "full", "--out", str(tmp_path / "f.json")])
    assert "6 distinct pose directions" in msg and "--model diagonal" in msg


def test_uncertainty_options_from_the_cli(sim, tmp_path, capsys):
    s, acc, gyr = sim
    path = _write(tmp_path, "a.csv", s.t, acc, None)
    base = ["calibrate", "accel", str(path), "--acc-unit", "counts", "--gravity", str(s.gravity)]
    out = tmp_path / "r.json"
    assert main(["--quiet", *base, "--out", str(out)]) == 0
    plain = CalibrationResult.from_json(out)
    assert main(["--quiet", *base, "--acc-bias-instability", "5", "--out", str(out)]) == 0
    drift = CalibrationResult.from_json(out)
    np.testing.assert_allclose(drift.accelerometer["b_std"], np.hypot(plain.accelerometer["b_std"], 5.0))
    assert main(["--quiet", *base, "--model", "diagonal", "--held-misalignment", "0.02", "--out", str(out)]) == 0
    wide = CalibrationResult.from_json(out)
    assert main(["--quiet", *base, "--model", "diagonal", "--held-misalignment", "0", "--out", str(out)]) == 0
    narrow = CalibrationResult.from_json(out)
    assert wide.accelerometer["held_std_rad"] == 0.02
    assert np.all(np.diag(wide.accelerometer["K_std"]) > np.diag(narrow.accelerometer["K_std"]))
    with pytest.raises(SystemExit):  # argparse: a one-line usage error
        main(["--quiet", *base, "--held-misalignment", "-1", "--out", str(out)])
    assert "--held-misalignment" in capsys.readouterr().err
    gpath = _write(tmp_path, "g.csv", s.t, acc, gyr)
    gbase = [
        "calibrate",
        "accel",
        str(gpath),
        "--acc-unit",
        "counts",
        "--gyro-unit",
        "counts",
        "--gravity",
        str(s.gravity),
        "--out",
        str(out),
    ]
    assert main(["--quiet", *gbase]) == 0
    g_plain = CalibrationResult.from_json(out).gyroscope
    assert main(["--quiet", *gbase, "--gyro-bias-instability", "2.0"]) == 0  # counts, ≈ 0.12 °/s
    g_drift = CalibrationResult.from_json(out).gyroscope
    assert g_plain["bias_mode"] == "local" and np.all(g_plain["b_std"] < 2.0)
    np.testing.assert_allclose(g_drift["b_std"], np.sqrt(g_plain["b_std"] ** 2 + 4.0), rtol=0.2)
    assert np.all(g_drift["b_std"] >= 2.0)


def test_too_few_distinct_poses_is_an_error_however_many_intervals():
    """Eight intervals, but only four directions (each pose twice): not even scales and biases are determined."""
    ups = np.array([(1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0)] * 2, float)
    s = simulate(ups, dwell_s=6, rest_s=3, acc_unit="counts", gyro_unit="counts", rng=2)
    with pytest.raises(OptinavError, match="4 distinct pose directions .*at least 6 distinct poses"):
        calibrate(s.t, s.acc, acc_unit="counts", g=s.gravity)


def test_a_drifting_gyro_bias_fails_static_and_calibrates_by_default(sim):
    s, acc, gyr = sim
    ramp = np.outer(s.t / s.t[-1], [60.0, -40.0, 50.0])  # counts: about 3.6 °/s of drift over the session
    with pytest.raises(OptinavError, match="--gyro-bias local"):
        calibrate(s.t, acc, gyr + ramp, acc_unit="counts", gyro_unit="counts", g=s.gravity, gyro_bias="static")
    r = calibrate(s.t, acc, gyr + ramp, acc_unit="counts", gyro_unit="counts", g=s.gravity)  # local
    _, Q = model.upper_triangular_form(s.acc_K)
    Kg = s.gyr_K @ Q.T
    assert np.all(np.abs(r.gyroscope["K"] - Kg) < 5 * r.gyroscope["K_std"])
    # the reported bias is the session's (the mean of the bias over the rests used), and its std is that of it:
    # the interpolation tracks the drift, which is no error of the session's bias and not in its std
    rest = np.zeros(s.t.size, bool)
    for t0, t1 in np.asarray(r.static_intervals):
        rest |= (s.t >= t0) & (s.t <= t1)
    # the bias instability (Gauss-Markov, tau 100 s) moves the bias too: the unit's mean bias over those rests
    b_session = _session_gyro_bias(s, preset("mems-mti1"), 5, drawn=True, intervals=r.static_intervals)
    b_session = b_session + OFFSET + ramp[rest].mean(axis=0)
    assert np.all(np.abs(r.gyroscope["b"] - b_session) < 3 * r.gyroscope["b_std"])
    assert np.all(r.gyroscope["b_std"] < 0.01 * np.abs(ramp[-1]))


def test_gyro_g_sensitivity_enters_the_std():
    """A gyro g-sensitivity of 0.1 °/s/g (1σ per element) the model leaves out, given as --gyro-g-sensitivity:
    K and the bias within their std (RMS(error/std) over 4 seeded sessions, within the 99 % band of 12 values,
    0.55 … 1.5; tests/test_uncertainty_mc.py checks the row without the option)."""
    from optinav.multipos.uncertainty import gyro_g_sensitivity_study

    name = "gyro, --gyro-g-sensitivity"
    given = gyro_g_sensitivity_study(4, rng=0, only=[name])[name]
    assert 0.55 < given["scale"] < 1.5 and 0.55 < given["bias"] < 1.5, given


def test_default_gyro_bias_follows_a_drift_and_its_std_covers_it():
    """A unit whose gyro bias drifts (Gauss–Markov, 100 °/h, τ 100 s): the former default (static) reports a
    bias std that the error exceeds several times, and fits K worse; the default (local) interpolates the bias
    through each turn and its std covers the session's bias; --gyro-bias-instability with the process's τ raises
    the std to cover the long-term bias, by what a 220 s session's mean keeps of the drift (less than σ)."""
    from optinav.core.imu_model import GM_SIGMA_PER_BIAS_INSTABILITY, preset
    from optinav.core.units import DEG

    s = simulate(
        "18",
        spec=preset("mems-mti1", gyro_bias_instability=(100, "deg/h")),
        dwell_s=8,
        rest_s=5,
        acc_unit="counts",
        gyro_unit="counts",
        rng=11,
    )
    _, Q = model.upper_triangular_form(s.acc_K)
    Kg = s.gyr_K @ Q.T
    kw = dict(acc_unit="counts", gyro_unit="counts", g=s.gravity)
    st = calibrate(s.t, s.acc, s.gyr, gyro_bias="static", **kw).gyroscope
    r_lo = calibrate(s.t, s.acc, s.gyr, **kw)
    lo = r_lo.gyroscope
    assert lo["bias_mode"] == "local"
    z_static = np.abs(st["b"] - s.gyr_b) / st["b_std"]
    # the bias over the rests the calibration used (what local reports), not over the simulated poses
    spec = preset("mems-mti1", gyro_bias_instability=(100, "deg/h"))
    b_session = _session_gyro_bias(s, spec, 11, drawn=True, intervals=r_lo.static_intervals)
    z_local = np.abs(lo["b"] - b_session) / lo["b_std"]
    assert np.max(z_static) > 2 and np.all(z_local < 3), (z_static, z_local)
    assert np.sum(np.abs(lo["K"] - Kg)) < np.sum(np.abs(st["K"] - Kg))
    sigma = GM_SIGMA_PER_BIAS_INSTABILITY * 100 * DEG / 3600 * float(np.mean(np.diag(s.gyr_K)))
    given = calibrate(s.t, s.acc, s.gyr, gyro_bias_instability=sigma, gyro_bias_corr_time=100.0, **kw).gyroscope
    assert np.all(given["b_std"] < sigma) and np.all(given["b_std"] > 0.5 * sigma)
    assert np.all(np.abs(given["b"] - s.gyr_b) < 3 * given["b_std"])
    np.testing.assert_allclose(given["K"], lo["K"])


@pytest.mark.parametrize(
    "change",
    [
        lambda a, g: (a * [1, -1, 1], g),  # an accelerometer axis flipped
        lambda a, g: (a[:, [1, 0, 2]], g),  # two accelerometer columns swapped
        lambda a, g: (a, g * [1, -1, 1]),  # a gyro axis flipped
        lambda a, g: (a, g[:, [1, 0, 2]]),  # two gyro columns swapped
    ],
    ids=["acc-flip", "acc-swap", "gyro-flip", "gyro-swap"],
)
def test_triads_that_disagree_are_named_not_called_unobservable(change):
    """A flipped or swapped axis in one triad was reported as 'rank-deficient … add poses whose transitions
    rotate about the body x, y and z axes', sending the user to record again: the turns then miss the
    accelerometer's poses by 26-36° RMS (noise: ≤ 1.5°). Named for what it is."""
    s = simulate("paper12", dwell_s=6, rest_s=3, rng=3)
    acc, gyr = change(s.acc, s.gyr)
    with pytest.raises(OptinavError, match=r"turns between the poses do not match .* miss by \d+° RMS.*flipped"):
        calibrate(s.t, acc, gyr, g=s.gravity)
    calibrate(s.t, s.acc, s.gyr, g=s.gravity)  # the same session as recorded calibrates


def test_a_clipped_accelerometer_is_named_and_its_poses_left_out():
    """An accelerometer clipped at ±8.5 m/s² (a ±0.87 g range) was refused as 'check for motion inside the static
    intervals' (or, clipped just below 1 g in counts, passed far off). A pose whose axis reads the log's extreme
    in every sample is clipped: left out with a note, as are the poses at a given full scale (--acc-range), and
    the six tilted poses calibrate the scales and biases within their std."""
    s = simulate("paper12", dwell_s=6, rest_s=3, rng=3)
    acc = np.clip(s.acc, -8.5, 8.5)
    for rng_given in (None, 8.5):  # found by its flat axis at the log's extreme, or by the range given
        r = calibrate(s.t, acc, None, g=s.gravity, acc_range=rng_given)
        assert sum("at the accelerometer's full scale" in n for n in r.quality["notes"]) == 6
        assert sum("(clipped at the sensor's range)" in n for n in r.quality["notes"]) == 6
        K, b = np.asarray(r.accelerometer["K"]), np.asarray(r.accelerometer["b"])
        K_std = np.asarray(r.accelerometer["K_std"])
        assert np.all(np.abs(np.diag(K) - np.diag(s.acc_K)) < 3 * np.diag(K_std))
        assert np.all(np.abs(b - s.acc_b) < 0.002)
    # one axis clipped just below 1 g in raw counts: the residual gate passed (12 poses fit 9 parameters nearly
    # exactly) and K_xx came out 2 050 std off with exit 0
    c = simulate("paper12", dwell_s=6, rest_s=3, rng=3, acc_unit="counts", gyro_unit="counts")
    lim = 0.96 * np.max(np.abs(c.acc[:, 0]))
    acc = c.acc.copy()
    acc[:, 0] = np.round(np.clip(acc[:, 0], -lim, lim))
    r = calibrate(c.t, acc, None, g=c.gravity, acc_unit="counts")
    K, K_std = np.asarray(r.accelerometer["K"]), np.asarray(r.accelerometer["K_std"])
    assert np.all(np.abs(np.diag(K) - np.diag(c.acc_K)) < 4 * np.diag(K_std))


@pytest.mark.parametrize("lat_deg", [0.0, 85.0])
def test_scales_std_covers_an_unknown_local_gravity(lat_deg):
    """Without --gravity or --latitude the fit assumes standard gravity, and the scales come out in proportion
    to it: at the equator or a pole (g 0.27 % off) the scales were 14-19 of their std off the truth, exit 0, with
    a note. Their std now includes the unknown g (±0.3 %, uniform); given the local g it is the fit's own."""
    s = simulate("paper12", dwell_s=6, rest_s=3, rng=3, lat=np.radians(lat_deg))
    assert abs(s.gravity / 9.80665 - 1) > 0.002
    r = calibrate(s.t, s.acc, None)
    K, K_std = np.asarray(r.accelerometer["K"]), np.asarray(r.accelerometer["K_std"])
    z = (np.diag(K) - np.diag(s.acc_K)) / np.diag(K_std)
    assert np.all(np.abs(z) < 3) and np.all(np.diag(K_std) > 1e-3)
    r = calibrate(s.t, s.acc, None, g=s.gravity)
    K, K_std = np.asarray(r.accelerometer["K"]), np.asarray(r.accelerometer["K_std"])
    assert np.all(np.abs(np.diag(K) - np.diag(s.acc_K)) < 4 * np.diag(K_std)) and np.all(np.diag(K_std) < 2e-4)


def test_gyro_scale_window_of_a_physical_unit_is_tight_and_counts_have_none():
    """A gyro in deg/s reads within ×GYRO_SCALE_FACTOR of 1, an accelerometer in m/s², g or mg within
    ×ACC_SCALE_FACTOR (it had the wide ×1.5 window: raw counts of 800 per g declared mg calibrated to 0.82× with exit
    0); counts have no nominal scale."""
    nom = 180.0 / np.pi  # deg/s per rad/s
    kw = {"option": "--gyro-unit", "columns_flag": "--columns"}
    for r in (1.0, 1.14, 1 / 1.14):
        gates.check_matrix(np.eye(3) * nom * r, nom, "gyroscope", "deg/s", **kw)
    for r in (1.16, 1 / 1.16, 1.4):
        with pytest.raises(OptinavError, match="wrong time base") as e:
            gates.check_matrix(np.diag([nom, nom * r, nom]), nom, "gyroscope", "deg/s", **kw)
        assert "--rate" in e.value.remedy and "K_yy" in str(e.value)
    akw = {"option": "--acc-unit", "columns_flag": "--columns"}
    for unit in ("m/s^2", "g", "mg"):
        nom = 1.0 / factor(unit)
        for r in (1.0, 1.14, 1 / 1.14):
            gates.check_matrix(np.eye(3) * nom * r, nom, "accelerometer", unit, **akw)
        for r in (1.16, 1 / 1.16, 1.4):
            with pytest.raises(OptinavError, match=re.escape(f"nominal value in {unit}")) as e:
                gates.check_matrix(np.diag([nom, nom, nom * r]), nom, "accelerometer", unit, **akw)
            assert "K_zz" in str(e.value) and "--acc-unit counts" in e.value.remedy
    gates.check_matrix(np.diag([1.0, 1.4, 1.0]), 1.0, "accelerometer", "counts", **akw)
    gates.check_matrix(np.diag([1.0, 1.4, 1.0]), 1.0, "gyroscope", "counts", **kw)


def _creep(s, pose: int, deg: float, vertical: bool = False):
    """The session with pose ``pose`` turning slowly by ``deg`` over its dwell (gyro and accelerometer agree),
    about a horizontal axis or (``vertical``) about the up direction, which the accelerometer cannot see."""
    from optinav.core.rotations import dcm_from_rotvec

    t, acc, gyr = s.t, s.acc.copy(), s.gyr.copy()
    t0, t1 = s.static_intervals[pose]
    i = np.flatnonzero((t >= t0) & (t <= t1))
    axis = np.array(s.up_dirs[pose], float) if vertical else np.cross(s.up_dirs[pose], [0.3, 0.5, 0.8])
    axis /= np.linalg.norm(axis)
    rate = np.radians(deg) / (t[i[-1]] - t[i[0]])
    f = np.linalg.solve(s.acc_K, (acc[i] - s.acc_b).T).T
    f = np.einsum("nji,nj->ni", dcm_from_rotvec(np.outer(rate * (t[i] - t[i[0]]), axis)), f)
    acc[i] = f @ s.acc_K.T + s.acc_b
    gyr[i] += s.gyr_K @ (rate * axis)
    return acc, gyr


@pytest.mark.parametrize("unit", ["m/s^2", "offset counts"])
def test_a_pose_that_creeps_is_left_out_with_a_note(unit):
    """A pose that tilts 2° during its 8 s rest: 0.25 °/s, too slow for the variance detector, put the gyro
    bias 10σ off; now the pose is left out and the fit is right. A 0.3° creep is kept (real poses settle).
    Counts of an unsigned ADC (offset 32768) shrank the raw angle 28x below the threshold: it is measured on
    offset-free directions."""
    counts = unit != "m/s^2"
    kw = {"acc_unit": "counts", "gyro_unit": "counts"} if counts else {}
    s = simulate("18", dwell_s=8, rest_s=5, rng=5, **kw)
    for deg, left_out in ((2.0, True), (0.3, False)):
        acc, gyr = _creep(s, 4, deg)
        if counts:
            acc, gyr = acc + OFFSET, gyr + OFFSET
        r = calibrate(s.t, acc, gyr, g=s.gravity, rng=1, **kw)
        if counts:
            r.accelerometer["b"] = r.accelerometer["b"] - OFFSET
            r.gyroscope["b"] = r.gyroscope["b"] - OFFSET
        notes = [n for n in r.quality["notes"] if "a slow creep or tilt" in n]
        assert bool(notes) == left_out and r.quality["n_poses"] == 18 - left_out
        assert np.all(np.abs(r.gyroscope["b"] - s.gyr_b) < 4 * r.gyroscope["b_std"])
        assert np.all(np.abs(r.accelerometer["b"] - s.acc_b) < 4 * r.accelerometer["b_std"])


@pytest.mark.parametrize("pose", [0, 7, 17])
def test_a_pose_turned_about_the_vertical_is_no_gyro_rest(pose):
    """A pose that turns 0.5 °/s about the vertical through its dwell: the accelerometer cannot see it, and the gyro
    bias, the mean of the rests, was 38σ off with exit 0 (a helper's finding). Now that rest is left out of the gyro
    calibration with a note naming it (first, middle and last pose: its turns in and out are joined) and the
    bias is right; the clean session leaves every rest in."""
    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    dwell = float(np.diff(s.static_intervals[pose])[0])
    for deg in (0.0, 0.5 * dwell):
        acc, gyr = _creep(s, pose, deg, vertical=True)
        r = calibrate(s.t, acc, gyr, g=s.gravity, rng=1)
        notes = [n for n in r.quality["notes"] if "left out of the gyro calibration" in n]
        assert len(notes) == (deg > 0) and r.excluded["turning_rests"] == (deg > 0)
        # the calibration's intervals hold the initial rest too: the turned pose is the one that starts with it
        ints = np.asarray(r.static_intervals)
        k = int(np.argmin(np.abs(ints[:, 0] - s.static_intervals[pose][0])))
        if deg:
            assert notes[0].startswith(f"static pose {k + 1} ") and "turned during it" in notes[0]
        # the unit's mean bias (with its Gauss-Markov drift) over the rests the gyro calibration used
        rests = np.delete(ints, k, axis=0) if deg else ints
        b_session = _session_gyro_bias(s, preset("mems-mti1"), 3, drawn=True, intervals=rests)
        assert np.all(np.abs(r.gyroscope["b"] - b_session) < 4 * r.gyroscope["b_std"]), deg


def test_many_rests_the_others_do_not_predict_are_refused(monkeypatch):
    """More than a third of the poses no rest for the gyro (here every rest the test is asked about) is a session
    to record again: an error naming one and the option that helps, not a calibration from what is left."""
    from optinav.multipos import gyro

    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    monkeypatch.setattr(gyro, "rest_outlier", lambda means, *a: (0, 2, 0.5, 99.0))
    with pytest.raises(
        OptinavError, match=r"7 of 18 static poses are no rest for the gyro \(static pose 7 .*--sections"
    ):
        calibrate(s.t, s.acc, s.gyr, g=s.gravity, rng=1)


@pytest.mark.parametrize(
    "drop, k, n, want",
    [([0, 1, 4], 0, 6, [0, 3]), ([0, 1, 4], 2, 6, [0, 1, 3]), ([2], 3, 6, [2]), ([3], 3, 6, [2]), ([4], 5, 6, [])],
)
def test_leaving_a_rest_out_joins_its_turns(drop, k, n, want):
    """Turn i joins rests i and i + 1: without rest k the turns into and out of it are one (left out when either
    was); the first or last rest's single turn goes with it."""
    from optinav.multipos.calibrate import _merge_turns

    assert _merge_turns(drop, k, n) == want


def test_gyro_std_includes_the_accelerometer_calibration_for_poses_in_a_cone():
    """25 poses within 24° of z: the accelerometer's own calibration error turns every pose's direction
    together, and the small turns between them carry it into the gyro scales (17-161σ off with exit 0 before).
    Now the gyro std includes it (gyro.calibrate_gyro up_cov)."""
    dirs = [[0.0, 0.0, 1.0]]
    for k in range(12):
        for el, off in ((12.0, 0.0), (24.0, 0.3)):
            e, az = np.radians(el), 2 * np.pi * k / 12 + off
            dirs.append([np.sin(e) * np.cos(az), np.sin(e) * np.sin(az), np.cos(e)])
    for seed in range(3):
        s = simulate(np.array(dirs), dwell_s=8, rest_s=5, rng=seed)
        r = calibrate(s.t, s.acc, s.gyr, g=s.gravity, rng=1)
        z = (np.diag(r.gyroscope["K"]) - np.diag(s.gyr_K)) / np.diag(r.gyroscope["K_std"])
        assert np.all(np.abs(z) < 4), (seed, z)


def test_a_quiet_axis_mid_range_is_not_called_clipped():
    """A pose whose axis reads one value throughout (noise below one count) but not at the poses' extreme is
    quantization: a fit that fails the residual gate then names motion, not clipping."""
    import importlib

    from optinav.multipos import accel
    from optinav.multipos.simulate import SCHEME_18

    cal = importlib.import_module("optinav.multipos.calibrate")
    g = 9.81
    means = SCHEME_18 * g
    means[3] *= 1.2  # a pose that does not fit: residual RMS > 1 % of g
    cov = np.tile(np.eye(3) * 1e-4, (len(means), 1, 1))
    cov[7, 1, 1] = 0.0  # pose 8's y reads one value; it is mid-range (-g/sqrt(3) between -g and +g)
    st = accel.PoseStatistics(means, cov, np.full(len(means), 500))
    fit = accel.fit_accel(st, g)
    with pytest.raises(OptinavError, match="motion inside the static intervals") as e:
        cal._accel_gates(fit, st, "m/s^2")
    assert "clipped" not in str(e.value)


def test_a_gyro_clipped_below_its_integer_range_leaves_its_turns_out(tmp_path, capsys):
    """A gyro in deg/s clipped at ±50 °/s (its turns peak at 64): without --gyro-range nothing saw it, and gyro
    K_xx came out 4 % low with exit 0. Flat runs at an axis's extreme entered steeply are saturation
    whatever the unit: those turns are left out with a note, and K is right."""
    import json

    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11"]) == 0
    clipped = clip_columns(f, tmp_path / "c.csv", ("gx", "gy", "gz"), 50.0)
    capsys.readouterr()
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(clipped), "--latitude", "38.88", "--out", str(res)]) == 0
    assert "the gyroscope saturates during" in capsys.readouterr().err
    truth = json.loads(f.with_name("d.truth.json").read_text())["gyroscope"]["K"]
    r = CalibrationResult.from_json(res)
    k, s = np.diag(np.asarray(r.gyroscope["K"])), np.diag(np.asarray(r.gyroscope["K_std"]))
    assert np.all(np.abs(k - np.diag(np.asarray(truth))) < 3 * s), (k, np.diag(np.asarray(truth)), s)


@needs_data
def test_a_doubled_rate_that_leaves_too_few_poses_names_rate(tmp_path, capsys):
    """imucal's example session at 102.4 Hz given --rate 204.8 (the annotated session's rate): its still stretches
    halve and too few reach --min-duration; the error listed --window, --threshold, --min-duration and --sections
    but not --rate."""
    argv = ["calibrate", "accel", str(DATA / "example_ferraris_session.csv"), "--rate", "204.8"]
    err = _cli_error(capsys, argv + ["--gyro-unit", "deg/s", "--out", str(tmp_path / "r.json")])
    assert "static interval(s)" in err and "--rate" in err


@needs_data
def test_raw_counts_not_taken_for_swapped_triads(tmp_path, capsys):
    """imucal's annotated session as the logger wrote it (raw counts, no units stated) with only --rate: its gyro
    reads about 9 counts at rest, close to g's number, and the swap check named the triads swapped and --columns.
    A gyro's norm varies over rests and turns (here by more than 100 %), an accelerometer's stays steady: the
    error now names the accelerometer's unit, and the message after it the gyroscope's (a swapped file is still
    named swapped: test_swapped_triads_in_counts_are_named, and in SI units below)."""
    src = str(DATA / "annotated_session.csv")
    out = str(tmp_path / "r.json")
    err = _cli_error(capsys, ["calibrate", "accel", src, "--rate", "204.8", "--out", out])
    assert "swapped" not in err and "raw counts?" in err and "--acc-unit counts" in err
    # its gyro columns hold whole numbers too: both flags in one refusal (the gyro's own check comes after the fit)
    assert "the gyroscope columns hold whole numbers too: if they are counts, add --gyro-unit counts" in err
    err = _cli_error(capsys, ["calibrate", "accel", src, "--rate", "204.8", "--gyro-unit", "counts", "--out", out])
    assert "--acc-unit counts" in err and "--gyro-unit" not in err


def test_a_gyro_in_a_physical_unit_is_not_told_counts_with_the_accelerometer(tmp_path, capsys):
    """An accelerometer in counts beside a gyro in deg/s (not whole numbers): the refusal names the accelerometer's
    flag only."""
    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    path = tmp_path / "c.csv"
    acc = np.round(s.acc / 9.80665 * 2048)
    np.savetxt(path, np.column_stack([s.t, acc, np.degrees(s.gyr)]), delimiter=",", header="t,ax,ay,az,gx,gy,gz",
               comments="")  # fmt: skip
    err = _cli_error(
        capsys, ["calibrate", "accel", str(path), "--gyro-unit", "deg/s", "--out", str(tmp_path / "r.json")]
    )
    assert "raw counts?" in err and "--acc-unit counts" in err and "gyro" not in err.split("at rest")[1]


def test_swapped_triads_in_si_units_are_named(tmp_path, capsys):
    """A simulated session in SI units with the two triads' columns exchanged is still named swapped (the gyro
    columns hold g's steady norm)."""
    s = simulate("18", dwell_s=8, rest_s=5, rng=3)
    path = tmp_path / "swapped.csv"
    np.savetxt(path, np.column_stack([s.t, s.gyr, s.acc]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    err = _cli_error(capsys, ["calibrate", "accel", str(path), "--out", str(tmp_path / "r.json")])
    assert "the two triads look swapped" in err and "--columns" in err


@pytest.mark.parametrize(
    "named_swap, cause",
    [
        # a cause that holds "swapped" only in a name (a folder, a file) names no swap: the hint is added
        (False, "no pose found in /data/swapped_rig/log.csv"),
        (True, "the two triads look swapped"),
    ],
)
def test_the_swap_hint_follows_the_error_type_not_its_words(sim, monkeypatch, named_swap, cause):
    """calibrate_data adds the swapped-triads words to a failed fit unless the error is a SwappedAxes, which names
    the swap itself (it routed on the word "swapped" in the message, and so missed a cause that holds it in a
    path)."""
    import importlib

    from optinav import errors

    cal = importlib.import_module("optinav.multipos.calibrate")  # the module (the package exports the function)
    kind = errors.SwappedAxes if named_swap else OptinavError

    s = sim[0]

    def fails(*args, **kwargs):
        raise kind(cause, "check the input")

    monkeypatch.setattr(cal, "_calibrate_data", fails)
    data = cal.SessionData(s.t, s.gyr, "counts", s.acc, "counts")  # the triads swapped
    with pytest.raises(OptinavError) as info:
        cal.calibrate_data(data, cal.FileOptions())
    assert ("are the two triads swapped?" in str(info.value)) != named_swap, str(info.value)
    assert str(info.value).startswith(cause)


def test_a_gyro_range_stated_in_deg_s_finds_the_clipped_turns(tmp_path, capsys):
    """A gyro in deg/s clipped at ±60 °/s (its turns peak at 64) with --gyro-range 60: the reader's deg/s → rad/s →
    deg/s round trip turned 60 into 59.99999999999999, below the range, so no turn was left out and gyro K came out
    0.8 % off (4 std) with exit 0, worse than without the flag. Values within a few ulp of the range are
    at it: the turns are left out with a note, and K is right."""
    import json

    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11"]) == 0
    assert (60 * np.pi / 180) * (180 / np.pi) < 60  # the round trip this test is about
    clipped = clip_columns(f, tmp_path / "c.csv", ("gx", "gy", "gz"), 60.0)
    capsys.readouterr()
    res = tmp_path / "r.json"
    argv = ["--quiet", "calibrate", "accel", str(clipped), "--latitude", "38.88", "--gyro-range", "60"]
    assert main(argv + ["--out", str(res)]) == 0
    assert "the gyroscope saturates during" in capsys.readouterr().err
    truth = json.loads(f.with_name("d.truth.json").read_text())["gyroscope"]["K"]
    r = CalibrationResult.from_json(res)
    k, s = np.diag(np.asarray(r.gyroscope["K"])), np.diag(np.asarray(r.gyroscope["K_std"]))
    assert np.all(np.abs(k - np.diag(np.asarray(truth))) < 3 * s), (k, np.diag(np.asarray(truth)), s)


def _gyro_clipped_session(tmp_path, limit: float):
    """A simulated session (deg/s gyro, turns peaking at 64 °/s) with the gyro clipped at ±limit °/s."""
    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11"]) == 0
    return clip_columns(f, tmp_path / "c.csv", ("gx", "gy", "gz"), limit)


@pytest.mark.parametrize("stated", [False, True])
def test_turns_too_fast_for_the_gyro_range_are_named(tmp_path, capsys, stated):
    """Turns far too fast for the gyro's ±30 °/s: every turn (or all but a few) saturates and is left out, and the
    error said '0 transition(s) usable … record at least 6 static poses' or 'rank-deficient … add poses', naming
    neither the saturation nor --gyro-range. The error now says the turns saturate and what helps."""
    clipped = _gyro_clipped_session(tmp_path, 30.0)
    capsys.readouterr()
    argv = ["calibrate", "accel", str(clipped), "--latitude", "38.88", "--out", str(tmp_path / "r.json")]
    err = _cli_error(capsys, argv + (["--gyro-range", "30"] if stated else []))
    assert "saturates in" in err and "turn more slowly" in err and "--gyro-range" in err, err


def test_poses_left_out_as_clipped_are_named_when_the_gyro_fails(tmp_path, capsys):
    """An accelerometer clipped at 1950 counts (g reads about 2040): the six axis poses are left out and the gyro
    fit of the turns between the six tilted poses left is rank-deficient; the error named the gyro's rank and
    'add poses', not the clipping. It now names the poses at the accelerometer's full scale."""
    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11"]) == 0
    clipped = clip_columns(f, tmp_path / "c.csv", ("ax", "ay", "az"), 1950.0)
    capsys.readouterr()
    err = _cli_error(
        capsys, ["calibrate", "accel", str(clipped), "--latitude", "38.88", "--out", str(tmp_path / "r.json")]
    )
    assert "gyro" in err and "pose(s) at the accelerometer's full scale" in err and "--acc-range" in err, err


def test_poses_that_all_lie_near_one_axis_are_named(tmp_path, capsys):
    """Nine poses all within 25° of z up: z's scale and bias cannot be told apart, and the fit ended in 'K_zz … 1e6×
    its nominal … check --acc-unit … or use --model diagonal' or 'did not converge … pass --model diagonal', which
    failed alike. The error now names the axis the poses hardly turn and what to record (both models);
    axis poses, with or without an ADC's offset, are not named."""
    rng = np.random.default_rng(0)
    tilt, az = np.radians(rng.uniform(5, 25, 9)), rng.uniform(0, 2 * np.pi, 9)
    ups = np.column_stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)])
    s = simulate(ups, dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="deg/s", rng=2)
    path = _write(tmp_path, "cone.csv", s.t, s.acc, s.gyr)
    argv = ["calibrate", "accel", str(path), "--acc-unit", "counts", "--gyro-unit", "deg/s", "--latitude", "38.88"]
    for model_form in ("auto", "diagonal"):
        err = _cli_error(capsys, [*argv, "--model", model_form, "--out", str(tmp_path / "r.json")])
        assert "hardly turn the z axis" in err and "both up and down" in err, err
    assert gates.narrow_axes(np.eye(3) * 2040 + 32768) is None and gates.narrow_axes(-np.eye(3)) is None


def test_a_rate_given_against_the_files_stated_rate_is_refused(tmp_path, capsys):
    """A log without a time column whose preamble states 'Update Rate: 100Hz', calibrated with --rate 50: the flag
    was taken as it stood and a gyro in counts (no nominal scale to judge by) came out 2× off with exit 0 (probe).
    Contradicting rates are now an error naming both; a --rate that agrees (or none) calibrates as before."""
    import json

    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "counts", "--seed", "11", "--rate", "100"]) == 0
    lines = f.read_text().splitlines()
    head = [i for i, ln in enumerate(lines) if ln and ln[0].isalpha()][-1]
    body = [ln.split(",", 1)[1] for ln in lines[head:]]  # the time column dropped
    notime = tmp_path / "n.csv"
    notime.write_text("# Update Rate: 100Hz\n" + "\n".join(body) + "\n")
    base = ["calibrate", "accel", str(notime), "--acc-unit", "counts", "--gyro-unit", "counts", "--latitude", "38.88"]
    err = _cli_error(capsys, [*base, "--rate", "50", "--out", str(tmp_path / "x.json")])
    assert "states 100 Hz" in err and "--rate 50" in err and "drop --rate" in err, err
    truth = np.diag(np.asarray(json.loads(f.with_name("d.truth.json").read_text())["gyroscope"]["K"]))
    for extra in ([], ["--rate", "100"]):
        res = tmp_path / "r.json"
        assert main(["--quiet", *base, *extra, "--out", str(res)]) == 0
        r = CalibrationResult.from_json(res)
        k, s = np.diag(np.asarray(r.gyroscope["K"])), np.diag(np.asarray(r.gyroscope["K_std"]))
        assert np.all(np.abs(k - truth) < 4 * s), (k, truth, s)


@needs_data
def test_a_gyro_in_counts_with_one_axis_off_is_not_told_raw_counts(tmp_path, capsys):
    """imucal's session with its gyro in counts (16.384 per deg/s) and z_rot cut at half its turn: K_zz came out
    0.46× the other scales and the error said 'raw counts? … pass --gyro-unit counts', which was given (probe). Data
    declared counts are not told to be counts: the error names the scale off and --sections."""
    head, *rows = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    cols = head.split(",")
    g = [cols.index(c) for c in ("gyr_x", "gyr_y", "gyr_z")]
    out = [head]
    for row in rows:
        v = row.split(",")
        for j in g:
            v[j] = repr(float(round(float(v[j]) * 16.384)))
        out.append(",".join(v))
    path = tmp_path / "counts.csv"
    path.write_text("\n".join(out) + "\n")
    import json

    secs = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    secs["z_rot"]["end"] = 9360  # the turn goes on to 9512
    sec = tmp_path / "s.json"
    sec.write_text(json.dumps(secs))
    argv = ["calibrate", "accel", str(path), "--rate", "102.4", "--gyro-unit", "counts", "--gravity", "9.81"]
    err = _cli_error(capsys, [*argv, "--method", "ferraris", "--sections", str(sec), "--out", str(tmp_path / "r.json")])
    assert "raw counts?" not in err and "K_zz" in err and "--sections" in err, err


def test_a_stated_rate_the_time_column_contradicts_is_noted(tmp_path, capsys):
    """A log with a time column at 100 Hz and a preamble 'Update Rate: 50Hz': the contradiction passed in silence
    (probe). The time column is used, with a note naming both; a preamble that agrees adds none."""
    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "deg/s", "--seed", "11", "--rate", "100"]) == 0
    for rate, noted in (("50", True), ("100.0", False)):
        g = tmp_path / f"r{rate}.csv"
        g.write_text(f"# Update Rate: {rate}Hz\n" + f.read_text())
        capsys.readouterr()
        assert main(["calibrate", "accel", str(g), "--latitude", "38.88", "--out", str(tmp_path / "r.json")]) == 0
        err = capsys.readouterr().err
        assert ("states 50 Hz" in err and "steps at 100 Hz: the time column is used" in err) == noted, err


@pytest.mark.parametrize("g", [9.7, 9.9, 9.0, 9.81 * 1.02])
def test_gravity_outside_earths_range_is_named_with_its_bounds(g):
    """--gravity 9.7 was refused as 'outside 9.7–9.9' (the bounds are exclusive); the error says so and names the
    other way to give gravity (--latitude); 9.76-9.83 m/s² (equatorial peaks to the poles) pass."""
    from optinav.multipos.calibrate import local_gravity

    with pytest.raises(OptinavError, match=r"not above 9.7 and below 9.9 .*--latitude"):
        local_gravity(g)
    for ok in (9.764, 9.8322):
        assert local_gravity(ok) == (ok, "given")


def test_a_latitude_that_reads_as_radians_too_is_named():
    """--latitude 0.86 (imucal's Erlangen, 49.3°, in radians) gave normal gravity 9.7803 for 9.8103 — every
    accelerometer scale 0.3 % off (12-16 std on imucal's session) with only 'normal gravity at 0.86°' said. A
    latitude within ±π/2 degrees names its reading as radians; 49.6° and the equator say nothing more."""
    from optinav.multipos.calibrate import local_gravity

    g, how = local_gravity(lat=np.radians(0.86))
    assert g == pytest.approx(9.7803, abs=1e-4)
    assert "if 0.86 is the latitude in radians, it is 49.27°: --latitude takes degrees" in how, how
    for deg in (49.6, 0.0, -12.0, 1.6):
        assert "radians" not in local_gravity(lat=np.radians(deg))[1]


@pytest.mark.parametrize("axis", [0, 2])
def test_a_drifting_accelerometer_bias_is_noted_with_its_size(axis):
    """An accelerometer bias drifting linearly by 2 mg over the session: the fit reports the session's mean bias
    (honest as a mean), and a note names the drift, its axis and its size over the poses (within 3σ of the trend's
    z); the same session undrifted gets no note."""
    s = simulate("18", dwell_s=6, rest_s=3, rng=4)
    clean = calibrate(s.t, s.acc, g=s.gravity)
    assert not [n for n in clean.quality["notes"] if "accelerometer drifts" in n]
    drift = 2e-3 * G_STANDARD * (s.t - s.t[0]) / (s.t[-1] - s.t[0])
    acc = s.acc.copy()
    acc[:, axis] += drift
    r = calibrate(s.t, acc, g=s.gravity)
    (note,) = [n for n in r.quality["notes"] if "accelerometer drifts" in n]
    m = re.search(r"on acc (\w) .* \(([-+\d.e]+) mg\) over the poses' ([\d.]+) min .*, (\d+) std;", note)
    assert m and m[1] == "xyz"[axis], note
    # the true drift between the first and last pose centres
    ranges = [np.flatnonzero((s.t >= a) & (s.t <= b)) for a, b in np.asarray(r.static_intervals)]
    tc = [s.t[i].mean() for i in ranges]
    true_mg = 2.0 * (tc[-1] - tc[0]) / (s.t[-1] - s.t[0])
    # 0.05 mg: the note rounds the size to two digits
    assert abs(float(m[2]) - true_mg) < 3 * true_mg / float(m[4]) + 0.05, (note, true_mg)


@pytest.mark.parametrize("method", ["ga", "pso"])
def test_a_search_stopped_after_few_generations_is_named_not_the_data(tmp_path, capsys, method):
    """GA or PSO with 3 generations on a clean session: "the poses do not fit one accelerometer model … check for
    motion inside the static intervals" (the data fit LM to 1e-4 m/s²), or a silent fall-back to the diagonal model.
    The local search from the best particle reaches a minimum that passes the gate: the search is named, with the
    flags that help."""
    f = tmp_path / "d.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "6", "--acc-unit", "counts"]
    assert main(argv + ["--seed", "1"]) == 0
    base = ["--quiet", "calibrate", "accel", str(f), "--latitude", "38.88", "--out", str(tmp_path / "r.json")]
    assert main(base + ["--method", "lm"]) == 0
    capsys.readouterr()
    err = _cli_error(capsys, base + ["--method", method, "--generations", "3"])
    assert f"the {method.upper()} search stopped short of the minimum of its objective" in err, err
    assert "--generations" in err and "--method lm" in err and "motion" not in err, err


@pytest.mark.parametrize("seed", [3, 18])
def test_gyro_std_carries_the_held_accelerometer_misalignments(seed):
    """The six axis poses twice (12 poses, turns between them): the accelerometer holds its misalignments at 0,
    and the gyro fitted in that frame takes the turns' angles the shear distorts (K_g up to 2.6 % off). Its std
    ignored the held terms: K_g 5.5 (seed 3) and 5.1 (seed 18) std off with exit 0; with their prior (1σ 0.005
    rad) through the up directions every element is within 3 std (0.8 and 1.6)."""
    s = simulate(np.vstack([SCHEMES["six"]] * 2), dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="counts", rng=seed)
    r = calibrate(s.t, s.acc, s.gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity)
    assert r.accelerometer["held"] == ["K_xy", "K_xz", "K_yz"]
    truth = s.gyr_K @ model.upper_triangular_form(s.acc_K)[1].T  # the gyro in the accelerometer's frame
    assert np.all(np.abs(r.gyroscope["K"] - truth) < 3.0 * np.asarray(r.gyroscope["K_std"]))
    if seed == 3:
        # a held misalignment of 1σ 0.05 rad leaves K_g's std beyond 5 % of the scale: refused, naming the cause
        with pytest.raises(OptinavError, match="held at 0 .*tilted poses"):
            calibrate(s.t, s.acc, s.gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity, held_misalignment=0.05)


@pytest.mark.parametrize(("seed", "dwell"), [(14, 20), (5, 8)])
def test_a_clean_six_pose_session_is_not_refused_for_a_scale_sign(seed, dwell):
    """The norm |K⁻¹(m − b)| = g cannot tell the sign of a column of K (K·D has the inverse D·K⁻¹), and the fit
    of a clean session (six axis poses twice, seed 14) converged to K_zz = −209 and was refused as "accelerometer z
    reads −z". The scales are made positive, at no change of the cost: the accelerometer within 3 std of the
    truth."""
    s = simulate(np.vstack([SCHEMES["six"]] * 2), dwell_s=dwell, rest_s=30, transition_s=4, acc_unit="counts",
                 gyro_unit="counts", rng=seed)  # fmt: skip
    r = calibrate(s.t, s.acc, s.gyr, acc_unit="counts", gyro_unit="counts", g=s.gravity)
    K, std = np.diag(r.accelerometer["K"]), np.diag(np.asarray(r.accelerometer["K_std"]))
    assert np.all(np.abs(K - np.diag(s.acc_K)) < 3.0 * std), (K, np.diag(s.acc_K), std)
    from optinav.multipos.accel import positive_scales

    theta = np.array([-2.0, 3.0, -4.0, 0.1, 0.2, 0.3, 1.0, 2.0, 3.0])
    m = np.random.default_rng(0).normal(0.0, 5.0, (20, 3))
    flipped = positive_scales(theta)
    assert np.all(flipped[:3] > 0)
    np.testing.assert_allclose(model.norm_residuals(flipped, m, 9.8), model.norm_residuals(theta, m, 9.8), rtol=1e-12)


@pytest.mark.parametrize("seed", [4, 7, 8, 17])
def test_gyro_turn_residuals_judge_the_held_misalignment_prior(seed):
    """The six axis poses twice: the accelerometer holds its misalignments at 0 and their shear of the poses shows in
    the gyro's turns. Units whose held terms are large for the simulated MTi-1 (seed 4: RMS 0.0105 rad, 7: 0.0075,
    8: K_xz −20 mrad) pass at the default prior (0.0071), each gyro K element within 3 std of the truth (at 0.005
    seed 8's was 3.9 std off; the turns' excess over their prediction now widens the std, χ² scaling) and the
    frame's gate logged. Seed 7 with the prior understated (0.0005 rad) left turns missing by 5.3 mrad RMS, 16× what
    the noise predicts, and K 4.3 std off with exit 0: refused, naming --held-misalignment and what the turns imply
    (0.0076 rad; its held terms' RMS is 0.0075). Seed 17's two 180° turns about z were taken for clipped (their misfit
    is the shear) and left out, and the nine left could not show it: at 0.0005 K 10.6 std off with exit 0; they are
    kept now, and the understated prior refused."""
    s = simulate(np.vstack([SCHEMES["six"]] * 2), dwell_s=8, rest_s=5, acc_unit="counts", gyro_unit="counts", rng=seed)
    kw = dict(acc_unit="counts", gyro_unit="counts", g=s.gravity)
    if seed in (7, 17):
        with pytest.raises(OptinavError, match=r"by more than their 1σ 0.0005 rad \(the turns imply about 0.0") as e:
            calibrate(s.t, s.acc, s.gyr, held_misalignment=0.0005, **kw)
        assert "--held-misalignment" in e.value.remedy and "\n" not in str(e.value)
    r = calibrate(s.t, s.acc, s.gyr, **kw)
    truth = s.gyr_K @ model.upper_triangular_form(s.acc_K)[1].T
    assert np.all(np.abs(r.gyroscope["K"] - truth) < 3.0 * np.asarray(r.gyroscope["K_std"]))
    assert r.accelerometer["held"] == ["K_xy", "K_xz", "K_yz"] and r.accelerometer["held_std_rad"] == 0.0071
    (g,) = [g for g in r.gates if "accelerometer frame's directions" in g["name"]]
    assert g["passed"] and r.gyroscope["residual_noise_ratio"] > 0 and r.gyroscope["std_widening"] >= 1.0
    assert r.excluded["flat_topped_turns"] == 0
