"""`optinav simulate accel-multipos`, `calibrate accel`, `apply` end to end, and the real imucal session."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.core.results import Truth
from optinav.multipos import model
from optinav.multipos.result import CalibrationResult

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"  # ../shared relative to the project root
DATA = Path(os.environ.get("OPTINAV_SHARED_DATA", SHARED)) / "imucal"
needs_data = pytest.mark.skipif(not (DATA / "example_ferraris_session.csv").is_file(), reason="imucal data absent")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("sess")
    data = d / "s.csv"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(data),
                "--scheme",
                "18",
                "--dwell",
                "15",
                "--acc-unit",
                "counts",
                "--gyro-unit",
                "deg/s",
                "--jitter",
                "0.2",
                "--seed",
                "3",
            ]
        )
        == 0
    )
    return d, data, json.loads((d / "s.truth.json").read_text())


def test_simulate_calibrate_apply_round_trip(session, capsys):
    d, data, truth = session
    out = d / "r.json"
    rep = d / "rep"
    assert (
        main(
            [
                "calibrate",
                "accel",
                str(data),
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--out",
                str(out),
                "--report",
                str(rep),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(out)
    raw = json.loads(out.read_text())
    for key in (
        "schema",
        "version",
        "optinav_version",
        "parameters",
        "convergence",
        "quality_gates",
        "elapsed_s",
        "method",
        "fields",
    ):
        assert key in raw
    assert raw["schema"] == "optinav.multipos.calibration" and raw["version"] == 3
    assert raw["convergence"]["converged"] is True and raw["elapsed_s"] > 0
    assert raw["quality_gates"] and all(g["passed"] for g in raw["quality_gates"])
    assert raw["parameters"]["acc_K_xx"]["unit"] == "counts per m/s^2"
    assert raw["parameters"]["gyr_b_x"]["unit"] == "deg/s"
    assert raw["parameters"]["acc_K_yx"]["value"] is None and not raw["parameters"]["acc_K_yx"]["observable"]
    assert res.units["accelerometer_raw"] == "counts" and res.units["gyroscope_raw"] == "deg/s"
    assert len(res.static_intervals) == 18
    # the truth file holds the truth in the estimated parameterization: compared field by field
    cmp = Truth.from_json(d / "s.truth.json").compare(res)
    assert len(cmp) == 6 + 3 + 9 + 3  # upper-triangular K_a, b_a, K_g, b_g
    assert max(float(np.max(c["z"])) for c in cmp.values()) < 5, {n: c["z"] for n, c in cmp.items()}
    # accelerometer: compare with the upper-triangular form of the true K (norms cannot see a rotation)
    U, Q = model.upper_triangular_form(np.array(truth["accelerometer"]["K"]))
    acc = res.accelerometer
    iu = np.triu_indices(3)
    z = (acc["K"] - U)[iu] / acc["K_std"][iu]
    assert np.all(np.abs(z) < 5), z
    assert np.all(np.abs(acc["b"] - truth["accelerometer"]["b"]) < 5 * acc["b_std"])
    # gyroscope: calibrated in the accelerometer's frame, K_g·Qᵀ
    gy = res.gyroscope
    Kg = np.array(truth["gyroscope"]["K"]) @ Q.T
    assert np.all(np.abs(gy["K"] - Kg) < 5 * gy["K_std"] + 1e-3 * np.abs(Kg).max())
    assert np.all(np.abs(gy["b"] - truth["gyroscope"]["b"]) < 5 * gy["b_std"])
    assert (rep / "index.md").is_file() and (rep / "summary.json").is_file()
    # apply: corrected static samples have |a| = g and the gyro reads ~0 at rest
    corrected = d / "c.npz"
    assert main(["apply", str(out), str(data), "--out", str(corrected)]) == 0
    z = np.load(corrected)
    t, a, w = z["t"], z["acc"], z["gyro"]
    iv = np.array(truth["static_intervals"])
    m = np.zeros(len(t), bool)
    for t0, t1 in iv:
        m |= (t > t0 + 1) & (t < t1 - 1)
    assert abs(np.mean(np.linalg.norm(a[m], axis=1)) - truth["gravity"]) < 2e-4
    assert np.all(np.abs(w[m].mean(axis=0)) < 2e-4)  # Earth rate (7e-5 rad/s) + residual bias


@pytest.mark.parametrize("method", ["gn", "newton"])
def test_other_methods_from_the_cli(session, method):
    d, data, truth = session
    out = d / f"r_{method}.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(data),
                "--no-gyro",
                "--gravity",
                str(truth["gravity"]),
                "--method",
                method,
                "--out",
                str(out),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(out)
    U, _ = model.upper_triangular_form(np.array(truth["accelerometer"]["K"]))
    np.testing.assert_allclose(np.diag(res.accelerometer["K"]), np.diag(U), rtol=2e-4)
    assert res.gyroscope is None


def test_two_files_sharing_the_time_column(session, tmp_path):
    d, data, truth = session
    from optinav.io import read_imu

    log = read_imu(data)
    acc_f, gyro_f = tmp_path / "acc.csv", tmp_path / "gyro.csv"
    np.savetxt(acc_f, np.column_stack([log.t, log.acc]), delimiter=",", header="t,ax,ay,az", comments="")
    np.savetxt(gyro_f, np.column_stack([log.t, log.gyr / (np.pi / 180)]), delimiter=" ")
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(acc_f),
                "--acc-unit",
                "counts",
                "--gyro",
                str(gyro_f),
                "--gyro-columns",
                "t,gx,gy,gz",
                "--gyro-unit",
                "deg/s",
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(out)
    assert res.gyroscope is not None and res.units["gyroscope_raw"] == "deg/s"
    # time columns on two clocks that never meet → one-line error, exit 2 (times that differ but overlap are
    # interpolated: tests/test_io.py, tests/test_calibration_real.py)
    g2 = tmp_path / "gyro2.csv"
    np.savetxt(g2, np.column_stack([log.t + 1e5, log.gyr]), delimiter=",")
    assert (
        main(
            [
                "calibrate",
                "accel",
                str(acc_f),
                "--acc-unit",
                "counts",
                "--gyro",
                str(g2),
                "--gyro-columns",
                "t,gx,gy,gz",
                "--out",
                str(tmp_path / "x.json"),
            ]
        )
        == 2
    )


def test_bad_inputs_give_one_line_errors(tmp_path, capsys):
    # a log without any rest: no static interval → error naming the variance levels
    rng = np.random.default_rng(0)
    t = np.arange(3000) / 100.0
    acc = np.column_stack([np.sin(t * 3), np.cos(t * 2), np.sin(t)]) * 9.8 + rng.normal(0, 0.01, (3000, 3))
    f = tmp_path / "moving.csv"
    np.savetxt(f, np.column_stack([t, acc]), delimiter=",", header="t,ax,ay,az", comments="")
    assert main(["--quiet", "calibrate", "accel", str(f), "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "static interval" in err[0] and "variance" in err[0], err
    assert main(["calibrate", "accel", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "r.json")]) == 2
    assert main(["calibrate", "accel", str(f), "--out", str(tmp_path / "r.txt")]) == 2
    with pytest.raises(SystemExit) as exc:  # argparse: usage and one error line naming the accepted units
        main(["calibrate", "accel", str(f), "--acc-unit", "furlongs", "--out", str(tmp_path / "r.json")])
    assert exc.value.code == 2


def test_nan_rows_are_excluded_and_counted(session, tmp_path):
    d, data, truth = session
    from optinav.io import read_imu

    log = read_imu(data)
    acc = log.acc.copy()
    acc[[100, 5000, 9000]] = np.nan
    f = tmp_path / "nan.csv"
    np.savetxt(f, np.column_stack([log.t, acc]), delimiter=",", header="t,ax,ay,az", comments="")
    out = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(f), "--acc-unit", "counts", "--out", str(out)]) == 0
    assert CalibrationResult.from_json(out).excluded["nan_rows"] == 3


@needs_data
def test_imucal_session_norm_observation_reports_unobservable_misalignments(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert (
        main(
            [
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
                "--sections",
                str(DATA / "example_ferraris_session_list.json"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(out)
    acc = res.accelerometer
    assert acc["held"] == ["K_xy", "K_xz", "K_yz"]
    text = " ".join(res.observability["unobservable"])
    assert "K_xy" in text and "K_yz" in text
    ref = json.loads((DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").read_text())
    # imucal: raw = K_a R_a a + b_a; the row norms of K_a R_a are the per-axis sensitivities
    KR = np.array(ref["K_a"]) @ np.array(ref["R_a"])
    np.testing.assert_allclose(np.diag(acc["K"]), np.linalg.norm(KR, axis=1), rtol=2e-3)
    np.testing.assert_allclose(acc["b"], ref["b_a"], atol=0.02)
    assert res.residual_rms < 0.05
    assert "unobservable" in capsys.readouterr().out


@needs_data
def test_imucal_session_ferraris_method_matches_reference(tmp_path):
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(DATA / "example_ferraris_session.csv"),
                "--rate",
                "102.4",
                "--gyro-unit",
                "deg/s",
                "--gravity",
                "9.81",
                "--method",
                "ferraris",
                "--sections",
                str(DATA / "example_ferraris_session_list.json"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(out)
    ref = json.loads((DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").read_text())
    np.testing.assert_allclose(res.accelerometer["K"], np.array(ref["K_a"]) @ np.array(ref["R_a"]), rtol=1e-10)
    np.testing.assert_allclose(
        res.gyroscope["K"] * np.pi / 180, np.array(ref["K_g"]) @ np.array(ref["R_g"]), rtol=1e-10
    )
    # apply reproduces imucal's calibrated head-50 snapshot
    corrected = tmp_path / "c.csv"
    assert (
        main(
            [
                "--quiet",
                "apply",
                str(out),
                str(DATA / "example_ferraris_session.csv"),
                "--rate",
                "102.4",
                "--out",
                str(corrected),
            ]
        )
        == 0
    )
    from optinav.io import read_imu

    got = read_imu(corrected)
    snap = np.genfromtxt(DATA / "reference" / "ferraris_example_calibrated_head50.csv", delimiter=",", names=True)
    np.testing.assert_allclose(got.acc[:50, 0], snap["acc_x"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got.gyr[:50, 2] * 180 / np.pi, snap["gyr_z"], rtol=1e-8, atol=1e-8)


def test_an_axis_at_the_rail_and_a_gyro_saturating_in_every_turn_are_named(session):
    """An accelerometer axis stuck at the 16-bit rail was refused as "every accelerometer sample is at the full
    scale" (the whole sensor); it names the axis now. A gyro that saturates in every turn was refused with "turn more
    slowly" only, where --no-gyro (no_gyro: the gyroscope left out) calibrates the accelerometer right."""
    from optinav.io import read_imu
    from optinav.multipos.calibrate import calibrate

    d, data, truth = session
    log = read_imu(data)
    acc = log.acc.copy()
    acc[:, 2] = 32767.0
    with pytest.raises(OptinavError, match=r"full scale \(axis z in all of them: a dead or disconnected axis\?\)"):
        calibrate(log.t, acc, acc_unit="counts", g=truth["gravity"])
    gyro = np.clip(log.gyr, -0.02, 0.02)  # every turn beyond a ±0.02 rad/s range
    with pytest.raises(OptinavError, match="saturates in .* turn.*--no-gyro calibrates the accelerometer alone"):
        calibrate(log.t, log.acc, gyro, acc_unit="counts", g=truth["gravity"], gyro_range=0.02)


def test_apply_names_offset_binary_counts(session, tmp_path, capsys):
    """A calibration of signed counts applied to the same data in offset binary (+32768) was refused as "the data's
    raw unit (counts) is not the one the calibration was made for": both are counts. The encoding is named."""
    from optinav.io import read_imu, write_imu

    d, data, truth = session
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--acc-unit", "counts", "--out", str(res)]) == 0
    log = read_imu(data, acc_unit="counts")
    log.acc = log.acc + 32768.0
    off = write_imu(tmp_path / "off.csv", log, acc_unit="counts")
    assert main(["apply", str(res), str(off), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "offset-binary counts" in err and "subtract 32768" in err, err


def test_saturated_samples_are_excluded_and_counted(session):
    from optinav.io import read_imu
    from optinav.multipos.calibrate import calibrate, saturated_mask

    d, data, truth = session
    log = read_imu(data)
    acc = log.acc.copy()
    iv = np.array(truth["static_intervals"])
    i0 = int(np.searchsorted(log.t, iv[2, 0] + 2))
    acc[i0 : i0 + 50, 0] = 2500.0  # clipped at a ±2500-count range
    ref = calibrate(log.t, log.acc, acc_unit="counts", g=truth["gravity"])
    res = calibrate(log.t, acc, acc_unit="counts", g=truth["gravity"], acc_range=2500.0)
    assert res.excluded["saturated_acc"] == 50
    np.testing.assert_allclose(
        res.accelerometer["K"], ref.accelerometer["K"], atol=3 * np.nanmax(ref.accelerometer["K_std"])
    )
    # raw counts at a 16-bit full scale are flagged without a range
    assert saturated_mask(np.array([[32767.0, 0, 0], [100.0, 0, 0], [0, -32768.0, 0]]), counts=True).tolist() == [
        True,
        False,
        True,
    ]


def test_gyro_bias_from_an_initial_rest_period(session, tmp_path):
    d, data, truth = session
    out = tmp_path / "r.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(data),
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--gyro-bias",
                "rest",
                "--rest",
                "0.5",
                "9.5",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    gy = CalibrationResult.from_json(out).gyroscope
    assert gy["bias_mode"] == "rest"
    assert np.all(np.abs(gy["b"] - truth["gyroscope"]["b"]) < 5 * gy["b_std"])
    # without --rest: the first static interval is the window (the 10 s initial rest and the first pose's dwell,
    # with no turn between them), and the notes say so
    auto = tmp_path / "auto.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(data),
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--gyro-bias",
                "rest",
                "--out",
                str(auto),
            ]
        )
        == 0
    )
    res = CalibrationResult.from_json(auto)
    note = [n for n in res.quality["notes"] if "initial rest" in n]
    assert len(note) == 1 and "--rest T0 T1" in note[0]
    t0, t1 = (float(v) for v in note[0].split("interval ")[1].split(" s")[0].split("-"))
    assert t0 < 1.0 and t1 > 9.5, note
    np.testing.assert_allclose(res.gyroscope["b"], gy["b"], atol=3 * np.max(gy["b_std"]))
    # a window without the rest mode is a contradiction
    assert main(["--quiet", "calibrate", "accel", str(data), "--rest", "0.5", "9.5", "--out", str(out)]) == 2
