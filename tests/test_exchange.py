"""Calibrations through imu_tk, imucal and Kalibr files: export → import gives the same numbers (1e-12), and
`optinav apply` corrects data identically from each format."""

import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from optinav import OptinavError
from optinav.cli.main import main
from optinav.multipos.exchange import export_calibration, load_calibration
from optinav.multipos.kalibr import calibration_from_kalibr, lq, read_kalibr_imu_yaml
from optinav.multipos.result import CalibrationResult


def _calibration(seed: int, *, G: bool, acc_unit="counts", gyro_unit="deg/s", upper=True) -> CalibrationResult:
    """A plausible calibration: scales of the raw unit, percent-level misalignments, biases."""
    rng = np.random.default_rng(seed)
    acc_scale = 1000.0 if acc_unit == "counts" else 1.0 / {"g": 9.80665, "m/s^2": 1.0}[acc_unit]
    gyro_scale = 180 / np.pi if gyro_unit == "deg/s" else (2000.0 if gyro_unit == "counts" else 1.0)
    Ka = acc_scale * (np.eye(3) + 0.01 * rng.standard_normal((3, 3)))
    if upper:
        Ka = np.triu(Ka)
    Kg = gyro_scale * (np.eye(3) + 0.01 * rng.standard_normal((3, 3)))
    gyro = {"K": Kg, "b": rng.normal(0, 0.5, 3)}
    if G:
        gyro["G"] = gyro_scale * 1e-3 * rng.standard_normal((3, 3))
    return CalibrationResult(
        accelerometer={"K": Ka, "b": rng.normal(0, 50, 3)},
        gyroscope=gyro,
        units={"accelerometer_raw": acc_unit, "gyroscope_raw": gyro_unit},
        method="lm",
    )


def _close(a, b, rtol=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b)) <= rtol * max(np.abs(b).max(), 1e-300)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), upper=st.booleans())
def test_imu_tk_round_trip(tmp_path_factory, seed, upper):
    d = tmp_path_factory.mktemp("tk")
    res = _calibration(seed, G=False, upper=upper)
    export_calibration(res, "imu_tk", d / "acc.calib", gyro_out=d / "gyro.calib")
    back = load_calibration(d / "acc.calib", d / "gyro.calib")
    for s in ("accelerometer", "gyroscope"):
        assert _close(getattr(back, s)["K"], getattr(res, s)["K"])
        assert _close(getattr(back, s)["b"], getattr(res, s)["b"])


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), with_G=st.booleans())
def test_imucal_round_trip(tmp_path_factory, seed, with_G):
    """optinav → imucal JSON → optinav keeps K and b; raw counts are written as imucal calls them, "a.u." (its
    examples; imucal compares the unit string its caller gives), and read back as counts."""
    d = tmp_path_factory.mktemp("imucal")
    res = _calibration(seed, G=with_G, upper=False)
    export_calibration(res, "imucal", d / "cal.json")
    raw = json.loads((d / "cal.json").read_text())
    assert raw["cal_type"] == "Ferraris" and raw["from_acc_unit"] == "a.u." and raw["gyr_unit"] == "deg/s"
    back = load_calibration(d / "cal.json")
    assert back.units["accelerometer_raw"] == "counts" and back.units["gyroscope_raw"] == "deg/s"
    for s in ("accelerometer", "gyroscope"):
        assert _close(getattr(back, s)["K"], getattr(res, s)["K"])
        assert _close(getattr(back, s)["b"], getattr(res, s)["b"])
    G = res.gyroscope.get("G", np.zeros((3, 3)))
    assert np.max(np.abs(back.gyroscope["G"] - G)) <= 1e-12 * np.abs(res.gyroscope["K"]).max()


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    with_G=st.booleans(),
    units=st.sampled_from([("counts", "counts"), ("g", "deg/s"), ("m/s^2", "rad/s")]),
)
def test_kalibr_round_trip_and_model(tmp_path_factory, seed, with_G, units):
    """Kalibr's M are lower triangular, C_gyro_i and C_i_s rotations, and the file's matrices reproduce optinav's
    K and G (biases are not part of Kalibr's file) to 1e-12; Kalibr's own model equation holds in its frame i."""
    from optinav.core.units import factor

    d = tmp_path_factory.mktemp("kalibr")
    res = _calibration(seed, G=with_G, acc_unit=units[0], gyro_unit=units[1])
    # raw counts: the driver's counts per SI unit (Kalibr reads m/s² and rad/s); refused without them
    # (the driver's counts per SI unit: those the calibration implies, so that Kalibr's M ≈ 1)
    cps = (
        {s: float(np.median(np.diag(getattr(res, s)["K"]))) for s in ("accelerometer", "gyroscope")}
        if units[0] == "counts"
        else None
    )
    if cps:
        with pytest.raises(OptinavError, match="--acc-lsb"):
            export_calibration(res, "kalibr", d / "imu.yaml", rostopic="/imu0", update_rate=200.0)
    export_calibration(res, "kalibr", d / "imu.yaml", rostopic="/imu0", update_rate=200.0, counts_per_si=cps)
    data = read_kalibr_imu_yaml(d / "imu.yaml")
    assert data["model"] == "scale-misalignment" and data["rostopic"] == "/imu0" and data["update_rate"] == 200.0
    M_a, M_g = np.array(data["accelerometers"]["M"]), np.array(data["gyroscopes"]["M"])
    C, C_i_s = np.array(data["gyroscopes"]["C_gyro_i"]), np.array(data["C_i_s"])
    assert np.allclose(np.triu(M_a, 1), 0, atol=1e-15) and np.allclose(np.triu(M_g, 1), 0, atol=1e-15)
    for R in (C, C_i_s):
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-14) and np.linalg.det(R) == pytest.approx(1.0)
    back = calibration_from_kalibr(data)
    G = res.gyroscope.get("G", np.zeros((3, 3)))
    assert _close(back["acc_K"], res.accelerometer["K"]) and _close(back["gyr_K"], res.gyroscope["K"])
    assert np.max(np.abs(back["gyr_G"] - G)) <= 1e-12 * np.abs(res.gyroscope["K"]).max()
    # Kalibr's equation in its frame: f·(raw − b) = M_a·a_i and M_g·C·ω_i + A·C·a_i for a, ω in optinav's frame
    rng = np.random.default_rng(seed)
    a_s, w_s = rng.normal(0, 9.8, 3), rng.normal(0, 1.0, 3)
    fa = 1.0 / cps["accelerometer"] if units[0] == "counts" else factor(units[0])
    fg = 1.0 / cps["gyroscope"] if units[1] == "counts" else factor(units[1])
    raw_a = res.accelerometer["K"] @ a_s
    raw_g = res.gyroscope["K"] @ w_s + G @ a_s
    a_i, w_i = C_i_s @ a_s, C_i_s @ w_s
    assert np.allclose(fa * raw_a, M_a @ a_i, rtol=1e-12, atol=1e-12 * np.abs(fa * raw_a).max())
    A = np.array(data["gyroscopes"]["A"])
    assert np.allclose(fg * raw_g, M_g @ C @ w_i + A @ C @ a_i, rtol=1e-12, atol=1e-12 * np.abs(fg * raw_g).max())


def test_lq_factorization():
    rng = np.random.default_rng(5)
    K = np.eye(3) + 0.1 * rng.standard_normal((3, 3))
    L, Q = lq(K)
    assert np.allclose(L @ Q, K, atol=1e-15) and np.all(np.diag(L) > 0) and np.allclose(np.triu(L, 1), 0)
    with pytest.raises(OptinavError):
        lq(np.diag([1.0, 1.0, -1.0]))


def test_export_refusals(tmp_path):
    res = _calibration(1, G=True)
    with pytest.raises(OptinavError, match="g-sensitivity"):
        export_calibration(res, "imu_tk", tmp_path / "a.calib", gyro_out=tmp_path / "g.calib")
    with pytest.raises(OptinavError, match="--gyro-out"):
        export_calibration(_calibration(1, G=False), "imu_tk", tmp_path / "a.calib")
    acc_only = CalibrationResult(accelerometer=res.accelerometer, units={"accelerometer_raw": "counts"})
    with pytest.raises(OptinavError, match="both"):
        export_calibration(acc_only, "imucal", tmp_path / "c.json")
    with pytest.raises(OptinavError, match="both"):
        export_calibration(acc_only, "kalibr", tmp_path / "k.yaml")
    assert not any(tmp_path.iterdir())


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("exch")
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
                "--seed",
                "5",
            ]
        )
        == 0
    )
    return d, data


def test_calibrate_export_then_apply_each_format(session, capsys):
    """`calibrate --export` writes all three formats; `apply` on the imucal file and on the imu_tk pair corrects
    the data exactly as RESULT.json does; `export` writes the same files as `calibrate --export`."""
    d, data = session
    out = d / "r.json"
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(data),
                "--out",
                str(out),
                "--export",
                f"imucal:{d / 'cal.json'}",
                "--export",
                f"imu_tk:{d / 'acc.calib'},{d / 'gyro.calib'}",
            ]
        )
        == 0
    )
    assert "imu_tk file written" in capsys.readouterr().out
    # Kalibr reads m/s² and rad/s: an accelerometer in counts needs its driver's sensitivity, refused up front
    kal = ["--quiet", "calibrate", "accel", str(data), "--out", str(d / "k.json"), "--export", f"kalibr:{d / 'k.yaml'}"]
    assert main(kal) == 2 and "optinav export RESULT.json --to kalibr --acc-lsb" in capsys.readouterr().err
    assert not (d / "k.json").exists()
    assert (
        main(["--quiet", "export", str(out), "--to", "kalibr", "--acc-lsb", "2048", "--out", str(d / "imu.yaml")]) == 0
    )
    # a sensitivity of another range setting (4096 LSB/g at ±8 g) gave M ≈ 0.5 with exit 0
    assert main(["export", str(out), "--to", "kalibr", "--acc-lsb", "4096", "--out", str(d / "x.yaml")]) == 2
    assert "implies about 20" in capsys.readouterr().err and not (d / "x.yaml").exists()
    ref = d / "ref.npz"
    assert main(["--quiet", "apply", str(out), str(data), "--out", str(ref)]) == 0
    z_ref = np.load(ref)
    for name, argv in (
        ("imucal", [str(d / "cal.json")]),
        ("imu_tk", [str(d / "acc.calib"), "--gyro-cal", str(d / "gyro.calib")]),
    ):
        o = d / f"{name}.npz"
        cal, *extra = argv
        # imu_tk records no raw unit: the file's declared units (counts, deg/s) are used as they are
        assert main(["--quiet", "apply", cal, str(data), "--out", str(o), *extra]) == 0, name
        z = np.load(o)
        for k in ("acc", "gyro"):
            assert np.allclose(z[k], z_ref[k], rtol=1e-9, atol=1e-12), (name, k)
    # optinav export gives the same bytes as calibrate --export
    for fmt, fname in (("imucal", "cal.json"), ("kalibr", "imu.yaml")):
        o = d / f"again_{fname}"
        lsb = ["--acc-lsb", "2048"] if fmt == "kalibr" else []
        assert main(["--quiet", "export", str(out), "--to", fmt, *lsb, "--out", str(o)]) == 0
        assert o.read_text().replace(str(o), "") == (d / fname).read_text().replace(str(d / fname), "")


def test_export_kalibr_with_allan_noise(session, tmp_path, capsys):
    d, data = session
    out = d / "r2.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(out)]) == 0
    rest = tmp_path / "rest.npz"
    assert main(["--quiet", "simulate", "static", "--out", str(rest), "--hours", "0.2", "--seed", "2"]) == 0
    allan = tmp_path / "allan.json"
    assert main(["--quiet", "allan", str(rest), "--out", str(allan)]) == 0
    capsys.readouterr()
    yml = tmp_path / "imu.yaml"
    lsb = ["--acc-lsb", "2048"]  # the session's accelerometer is in counts (its gyro in deg/s)
    assert main(["export", str(out), "--to", "kalibr", *lsb, "--noise", str(allan), "--out", str(yml)]) == 0
    # read as Kalibr reads it (yaml.safe_load of the whole file); every key its IMU parameters require, the topic
    # Kalibr's examples use when none is known, and a note saying so
    assert "rostopic /imu0 written (Kalibr requires one); --rostopic" in capsys.readouterr().err
    k = yaml.safe_load(yml.read_text())
    a = json.loads(allan.read_text())["fields"]["kalibr"]["value"]
    for key in ("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density"):
        assert k[key] == a[key]
    for key in ("gyroscope_random_walk", "update_rate"):
        assert k[key] == a[key]
    assert k["rostopic"] == "/imu0" and k["model"] == "scale-misalignment"
    assert main(["--quiet", "export", str(out), "--to", "kalibr", *lsb, "--noise", str(allan), "--rostopic", "/a/imu",
                 "--out", str(tmp_path / "b.yaml")]) == 0  # fmt: skip
    assert yaml.safe_load((tmp_path / "b.yaml").read_text())["rostopic"] == "/a/imu"
    # one-line refusals naming the flag
    assert main(["export", str(out), "--to", "imucal", "--noise", str(allan), "--out", str(tmp_path / "c.json")]) == 2
    assert "--noise is for --to kalibr" in capsys.readouterr().err
    assert main(["export", str(out), "--to", "imu_tk", "--out", str(tmp_path / "a.calib")]) == 2
    assert "--gyro-out" in capsys.readouterr().err
    assert main(["apply", str(yml), str(data), "--out", str(tmp_path / "x.csv")]) == 2
    assert "holds no biases" in capsys.readouterr().err
    # Kalibr's noise-only imu.yaml as its wiki shows it (comment lines first) and as allan --kalibr writes it
    wiki = tmp_path / "wiki.yaml"
    wiki.write_text("#Accelerometers\naccelerometer_noise_density: 1.86e-03\naccelerometer_random_walk: 4.33e-04\n"
                    "#Gyroscopes\ngyroscope_noise_density: 1.87e-04\ngyroscope_random_walk: 2.66e-05\n"
                    "rostopic: /imu0\nupdate_rate: 200.0\n")  # fmt: skip
    kal = tmp_path / "noise.yaml"
    assert main(["--quiet", "allan", str(rest), "--kalibr", str(kal), "--out", str(tmp_path / "al.json")]) == 0
    assert kal.read_text().startswith("#")
    for f in (wiki, kal):
        assert main(["apply", str(f), str(data), "--out", str(tmp_path / "y.csv")]) == 2
        assert "is a Kalibr file" in capsys.readouterr().err


def test_export_kalibr_names_noise_files_of_the_wrong_kind(session, tmp_path, capsys):
    """--noise given a design plan said 'unknown result schema ...; upgrade optinav', a calibration or Kalibr's YAML
    'pass the right result file' / 'not valid JSON', none naming --noise: each names the option and its file."""
    d, data = session
    out = d / "r3.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(out)]) == 0
    plan, yml = tmp_path / "plan.json", tmp_path / "noise.yaml"
    assert main(["--quiet", "design", "--poses", "9", "--out", str(plan)]) == 0
    yml.write_text("accelerometer_noise_density: 1.86e-03\ngyroscope_noise_density: 1.87e-04\n")
    for noise, why in (
        (plan, "'optinav.pose_plan' is not a optinav.allan"),
        (out, "'optinav.multipos.calibration' is not a optinav.allan"),
        (yml, "not valid JSON"),
    ):
        capsys.readouterr()
        argv = ["export", str(out), "--to", "kalibr", "--acc-lsb", "2048", "--noise", str(noise)]
        assert main([*argv, "--out", str(tmp_path / "imu.yaml")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--noise {noise}:" in err and why in err and "optinav allan" in err, err
        assert "upgrade" not in err
    assert not (tmp_path / "imu.yaml").exists()


def test_export_kalibr_passes_on_what_the_noise_rests_on(session, tmp_path, capsys):
    """A 36-s rest's allan result puts the upper end of K's interval into imu.yaml (170× the truth on a simulated
    log); allan said its K is not reliable, export said nothing. It repeats the allan result's notes."""
    d, data = session
    out = d / "r4.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(out)]) == 0
    rest, allan = tmp_path / "rest.csv", tmp_path / "allan.json"
    assert main(["--quiet", "simulate", "static", "--out", str(rest), "--hours", "0.01", "--seed", "2"]) == 0
    assert main(["--quiet", "allan", str(rest), "--out", str(allan)]) == 0
    capsys.readouterr()
    argv = ["export", str(out), "--to", "kalibr", "--acc-lsb", "2048", "--noise", str(allan), "--rostopic", "/imu"]
    assert main([*argv, "--out", str(tmp_path / "imu.yaml")]) == 0
    err = capsys.readouterr().err
    assert f"note: --noise {allan}: the log spans 0.6 min" in err and "neither K nor its interval is reliable" in err


def test_export_kalibr_says_a_random_walk_is_a_bound_and_refuses_a_meaningless_one(session, tmp_path, capsys):
    """A 20-s rest's allan result (white noise only) gave export a random walk the log only bounds, 25× its noise
    density per second: written as the fit's K with exit 0. Refused as allan --kalibr refuses it (and written with
    --allow-rw-bound, called a bound in the yaml and a note)."""
    d, data = session
    out = d / "r5.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(out)]) == 0
    rng = np.random.default_rng(5)
    n, N = 2000, 1e-3
    rows = np.c_[np.arange(n) / 100.0, rng.standard_normal((n, 3)) * 10 * N * 10 + [0, 0, 9.80665],
                 rng.standard_normal((n, 3)) * N * 10]  # fmt: skip
    rest, allan, yml = tmp_path / "rest.csv", tmp_path / "allan.json", tmp_path / "imu.yaml"
    np.savetxt(rest, rows, delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt="%.10g")
    assert main(["--quiet", "allan", str(rest), "--out", str(allan)]) == 0
    argv = ["export", str(out), "--to", "kalibr", "--acc-lsb", "2048", "--noise", str(allan), "--out", str(yml)]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "random walk shows in this 20 s log" in err and "--allow-rw-bound" in err, err
    assert not yml.exists()
    assert main([*argv, "--allow-rw-bound"]) == 0
    assert "is an upper bound, not a measurement" in capsys.readouterr().err
    kal = read_kalibr_imu_yaml(yml)
    assert kal["gyroscope_random_walk"] > 1.0 * kal["gyroscope_noise_density"]
    assert yml.read_text().count("upper bound: no random walk shows in the log") == 2
    assert main(["export", str(out), "--to", "imucal", "--allow-rw-bound", "--out", str(tmp_path / "c.json")]) == 2


@pytest.mark.parametrize(
    "text, why",
    [
        ("model: scale-misalignment\naccelerometers: {M: [[1, 0]]}\n", "3×3"),
        ("!!python/object/apply:os.system ['echo hi']\n", "not valid YAML"),
        ("model: [unclosed\n", "not valid YAML"),
        ("model: calibrated\n", "not 'scale-misalignment'"),
    ],
)
def test_kalibr_reader_refuses_in_one_line(tmp_path, text, why):
    p = tmp_path / "imu.yaml"
    p.write_text(text)
    with pytest.raises(OptinavError, match=why):
        calibration_from_kalibr(read_kalibr_imu_yaml(p))


@pytest.mark.parametrize(
    "text, why",
    [
        ("hello world\n", "non-numeric"),
        ("1 2 3\n", "21"),
        ('{"K_a": [[1]], "cal_type": "Ferraris"}', "lacks"),
        ('{"foo": 1}', "neither"),
    ],
)
def test_apply_refuses_unreadable_calibrations(tmp_path, capsys, text, why):
    cal = tmp_path / "cal.txt"
    cal.write_text(text)
    data = tmp_path / "d.csv"
    data.write_text("t,ax,ay,az\n0,0,0,9.8\n0.01,0,0,9.8\n")
    assert main(["apply", str(cal), str(data), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and why in err, err
    assert not (tmp_path / "o.csv").exists()


SHARED = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"  # ../shared relative to the project root
DATA = Path(os.environ.get("OPTINAV_SHARED_DATA", SHARED)) / "imucal"


@pytest.mark.skipif(not (DATA / "example_ferraris_session.csv").is_file(), reason="imucal data absent")
def test_a_data_log_given_as_the_calibration_is_named(tmp_path, capsys):
    """apply's two files swapped (imucal's session given as the calibration, the result as the data) and export of
    the session said '... holds non-numeric text; pass a file written by imu_tk's CalibratedTriad::save'. A text
    file of more lines than imu_tk's is named a data log."""
    log = DATA / "example_ferraris_session.csv"
    cal = DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json"
    out = tmp_path / "o.csv"
    assert main(["apply", str(log), str(cal), "--rate", "102.4", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "holds 10377 lines: a data log, not a calibration" in err, err
    assert "before the data file" in err and not out.exists()
    assert main(["export", str(log), "--to", "imucal", "--out", str(tmp_path / "c.json")]) == 2
    assert "a data log, not a calibration" in capsys.readouterr().err


def test_imu_tk_files_of_a_deg_s_gyro_applied_to_rad_s_data_name_the_units(session, tmp_path, capsys):
    """imu_tk's files hold no unit: a calibration made from a gyro in deg/s applied to a log whose gyro is in rad/s
    was refused with "as it would were the data's gyro in rad/s: it is not in the rad/s the calibration was made
    for" (a helper's finding: it contradicts itself). The unit its scale reads (57.3 raw per rad/s: deg/s) and the
    data's are named, and the remedy says which to change."""
    import pandas as pd

    d, data = session
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(res)]) == 0
    tk = (tmp_path / "a.calib", tmp_path / "g.calib")
    export_calibration(CalibrationResult.from_json(res), "imu_tk", tk[0], gyro_out=tk[1])
    df = pd.read_csv(data, comment="#")
    g = ["gx", "gy", "gz"]
    df[g] = np.radians(df[g])
    rad = tmp_path / "rad.csv"
    rad.write_text("# units: t=s acc=counts gyro=rad/s\n" + df.to_csv(index=False))
    capsys.readouterr()
    assert main(["apply", str(tk[0]), "--gyro-cal", str(tk[1]), str(rad), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "the calibration holds no unit and its gyro scale, 57." in err and "raw per rad/s, reads raw deg/s" in err
    assert "data's gyro is in rad/s" in err and "give the data's gyro in deg/s" in err, err


@pytest.mark.skipif(
    not (DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").is_file(), reason="imucal data absent"
)
def test_apply_reads_imucal_own_export_and_matches_its_output(tmp_path):
    """imucal 2.6's own export of the example session's Ferraris calibration, applied by `optinav apply`,
    reproduces imucal's calibrated samples (its head-50 snapshot) to 1e-9; exported again by optinav it
    reads back to the same matrices to 1e-12."""
    from optinav.io import read_imu
    from optinav.multipos.convert import read_imucal_json

    ref = DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json"
    out = tmp_path / "c.csv"
    assert (
        main(
            [
                "--quiet",
                "apply",
                str(ref),
                str(DATA / "example_ferraris_session.csv"),
                "--rate",
                "102.4",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    got = read_imu(out)
    snap = np.genfromtxt(DATA / "reference" / "ferraris_example_calibrated_head50.csv", delimiter=",", names=True)
    for j, ax in enumerate("xyz"):
        np.testing.assert_allclose(got.acc[:50, j], snap[f"acc_{ax}"], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.degrees(got.gyr[:50, j]), snap[f"gyr_{ax}"], rtol=1e-8, atol=1e-8)
    res = load_calibration(ref)
    export_calibration(res, "imucal", tmp_path / "again.json")
    a, b = read_imucal_json(ref), read_imucal_json(tmp_path / "again.json")
    for k in ("K_a", "R_a", "b_a", "K_g", "R_g", "K_ga", "b_g"):
        assert _close(getattr(b, k), getattr(a, k)) or np.max(np.abs(getattr(b, k) - getattr(a, k))) < 1e-12, k


def test_calibrate_exports_never_replace_the_result_or_each_other(session, tmp_path, capsys):
    """`--out r.json --export imucal:r.json` turned the result file into an imucal file (exit 0); an imu_tk pair
    naming one file, or two exports to one file, kept only the last. Refused before any work."""
    d, data = session
    r = tmp_path / "r.json"
    for extra in (["--export", f"imucal:{r}"], ["--export", f"imu_tk:{tmp_path / 'a.calib'},{tmp_path / 'a.calib'}"],
                  ["--export", f"imucal:{tmp_path / 'x'}", "--export", f"kalibr:{tmp_path / 'x'}"]):  # fmt: skip
        assert main(["calibrate", "accel", str(data), "--out", str(r), *extra]) == 2
        assert "give each output file its own name" in capsys.readouterr().err
        assert not r.exists()


def test_apply_refuses_data_in_other_raw_units(session, tmp_path, capsys):
    """A calibration applied to data in other raw units (a log without unit header, counts read as the result's
    unit) gave |a| of 0.17 or 19 964 m/s² with exit 0. The first block's corrected |a| must be about g."""
    import pandas as pd

    d, data = session
    res = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(res)]) == 0
    df = pd.read_csv(data, comment="#")
    df[["ax", "ay", "az"]] *= 1000.0  # the same log in mili-units, no unit stated
    other = tmp_path / "milli.csv"
    df.to_csv(other, index=False)
    assert main(["apply", str(res), str(other), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "not about g" in err and "--acc-unit" in err and not (tmp_path / "o.csv").exists()
    assert main(["--quiet", "apply", str(res), str(data), "--out", str(tmp_path / "ok.csv")]) == 0


def _imu_tk_text(T, S, B) -> str:
    """An imu_tk parameter file as CalibratedTriad::save writes it (C++ streams: 6 significant digits)."""
    rows = [" ".join(f"{v:g}" for v in r) for r in (*T, *S)]
    return "\n".join(rows[:3]) + "\n\n" + "\n".join(rows[3:]) + "\n\n" + "\n".join(f"{v:g}" for v in B) + "\n\n"


def test_export_of_one_imu_tk_file_to_imucal_or_kalibr_names_the_other_file(tmp_path, capsys):
    """imu_tk's gyroscope file given to export as RESULT, or its accelerometer file without --gyro-cal, to imucal
    or Kalibr (both need both triads) were told 'calibrate with gyroscope data, or export the accelerometer to
    imu_tk': the pair exists, --gyro-cal is what is missing. With it, imucal's file holds imu_tk's numbers."""
    m = float(np.radians(1.0))
    Ta = np.array([[1.0, -m, m], [0.0, 1.0, -m], [0.0, 0.0, 1.0]])
    Tg = np.array([[1.0, -m, m], [m, 1.0, -m], [-m, m, 1.0]])
    acc_f, gyro_f = tmp_path / "acc.calib", tmp_path / "gyro.calib"
    acc_f.write_text(_imu_tk_text(Ta, np.diag([1.05, 0.98, 1.02]), np.array([0.12, -0.08, 0.05])))
    gyro_f.write_text(_imu_tk_text(Tg, np.diag([1.05, 1.01, 0.97]), np.array([0.002, -0.001, 0.003])))
    for fmt, out in (("imucal", "c.json"), ("kalibr", "imu.yaml")):
        assert main(["export", str(gyro_f), "--to", fmt, "--out", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert "gyro.calib has six misalignments (imu_tk's gyroscope form" in err and "--gyro-cal" in err, err
        assert main(["export", str(acc_f), "--to", fmt, "--out", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert f"acc.calib is imu_tk's accelerometer file alone, and {fmt} needs" in err and "--gyro-cal" in err
    both = ["--quiet", "export", str(acc_f), "--gyro-cal", str(gyro_f), "--to", "imucal"]
    assert main([*both, "--out", str(tmp_path / "c.json")]) == 0
    assert main(["--quiet", "export", str(acc_f), "--to", "imu_tk", "--out", str(tmp_path / "a2.calib")]) == 0


def test_apply_imu_tk_pair_is_imu_tks_model_and_refuses_the_files_mixed_up(tmp_path, capsys):
    """imu_tk's own files (accelerometer T upper triangular, gyroscope T full; scale 1.05, misalignments 1°) on
    SI data: apply gives imu_tk's x' = T·S·(raw − B) of each triad (computed here from the file's numbers). The
    gyroscope file given alone corrected the accelerometer with the gyro's T, S, B and wrote |a| ≈ g with exit 0;
    the pair given the wrong way round was refused as a unit mismatch. Both now name the mix-up."""
    import pandas as pd

    data = tmp_path / "si.csv"
    sim = ["--quiet", "simulate", "accel-multipos", "--out", str(data), "--scheme", "18", "--dwell", "5"]
    assert main([*sim, "--seed", "3"]) == 0
    m = float(np.radians(1.0))
    Ta = np.array([[1.0, -m, m], [0.0, 1.0, -m], [0.0, 0.0, 1.0]])  # imu_tk's accelerometer ("body") form
    Tg = np.array([[1.0, -m, m], [m, 1.0, -m], [-m, m, 1.0]])  # its gyroscope form: six misalignments
    Sa, Sg = np.diag([1.05, 0.98, 1.02]), np.diag([1.05, 1.01, 0.97])
    Ba, Bg = np.array([0.12, -0.08, 0.05]), np.array([0.002, -0.001, 0.003])
    acc_f, gyro_f = tmp_path / "acc.calib", tmp_path / "gyro.calib"
    acc_f.write_text(_imu_tk_text(Ta, Sa, Ba))
    gyro_f.write_text(_imu_tk_text(Tg, Sg, Bg))
    out = tmp_path / "c.csv"
    assert main(["--quiet", "apply", str(acc_f), str(data), "--gyro-cal", str(gyro_f), "--out", str(out)]) == 0
    raw, got = pd.read_csv(data, comment="#"), pd.read_csv(out, comment="#")
    for cols, f in ((["ax", "ay", "az"], acc_f), (["gx", "gy", "gz"], gyro_f)):
        v = np.array(f.read_text().split(), float)  # as CalibratedTriad::load reads it: T, S row-major, B
        T, S, B = v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:]
        want = (raw[cols].to_numpy() - B) @ (T @ S).T
        assert np.max(np.abs(got[cols].to_numpy() - want)) <= 1e-12 * np.abs(want).max()
    # the accelerometer's file alone: the gyro is left out of the output, and the account says so
    capsys.readouterr()
    assert main(["apply", str(acc_f), str(data), "--out", str(tmp_path / "acc_only.csv")]) == 0
    said = capsys.readouterr()
    assert "(m/s^2)" in said.out and "gyroscope of si.csv left out" in said.err and "--gyro-cal" in said.err
    assert list(pd.read_csv(tmp_path / "acc_only.csv", comment="#").columns) == ["t", "ax", "ay", "az"]
    for argv, why in (
        ([str(gyro_f), str(data)], "six misalignments"),
        ([str(gyro_f), str(data), "--gyro-cal", str(acc_f)], "wrong way round"),
        ([str(gyro_f), str(data), "--gyro-cal", str(gyro_f)], "same calibration"),
    ):
        bad = tmp_path / "bad.csv"
        assert main(["apply", *argv, "--out", str(bad)]) == 2
        err = capsys.readouterr().err
        assert why in err and "--gyro-cal" in err and len(err.strip().splitlines()) == 1
        assert not bad.exists()


def test_export_says_which_parameters_were_held(tmp_path, capsys):
    """Six axis poses leave the accelerometer misalignments (and one gyro combination) undetermined; with
    --allow-unobservable they are held at their prior. imu_tk's and imucal's files cannot mark a parameter as
    held, and the export wrote them like estimated ones without a word; it now names them (and imucal's comment
    keeps them)."""
    data, res = tmp_path / "six.csv", tmp_path / "r.json"
    sim = ["--quiet", "simulate", "accel-multipos", "--out", str(data), "--scheme", "six", "--dwell", "10"]
    assert main([*sim, "--acc-unit", "counts", "--gyro-unit", "counts", "--seed", "3"]) == 0
    assert main(["--quiet", "calibrate", "accel", str(data), "--allow-unobservable", "--out", str(res)]) == 0
    held = [n for n, p in CalibrationResult.from_json(res).parameters().items() if (p.reason or "").startswith("held")]
    assert {"acc_K_xy", "acc_K_xz", "acc_K_yz"} <= set(held)
    capsys.readouterr()
    tk = ["export", str(res), "--to", "imu_tk", "--out", str(tmp_path / "a.calib")]
    assert main([*tk, "--gyro-out", str(tmp_path / "g.calib")]) == 0
    err = capsys.readouterr().err
    assert "not observable" in err and all(n in err for n in held), err
    assert main(["export", str(res), "--to", "imucal", "--out", str(tmp_path / "c.json")]) == 0
    err = capsys.readouterr().err
    assert all(n in err for n in held), err
    assert all(n in json.loads((tmp_path / "c.json").read_text())["comment"] for n in held)


@pytest.mark.skipif(
    not (DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").is_file(), reason="imucal data absent"
)
def test_apply_reads_imucals_hdf5_export(tmp_path, capsys):
    """imucal also saves a calibration as HDF5 (``to_hdf5``: a dataset per matrix, scalar strings for cal_type, the
    units, comment and format version). `apply` refused it as "not UTF-8 text ... saved as UTF-8"; it now reads it
    and corrects the example session as imucal's formula does (computed here from the reference matrices)."""
    import h5py
    import pandas as pd

    ref = json.loads((DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").read_text())
    cal = tmp_path / "cal.h5"
    with h5py.File(cal, "w") as fh:  # the layout imucal's CalibrationInfo.to_hdf5 writes
        for k, v in ref.items():
            if isinstance(v, list):
                fh.create_dataset(k, data=v)
            elif v:
                fh[k] = v
    raw = pd.read_csv(DATA / "example_ferraris_session.csv")
    out = tmp_path / "c.csv"
    argv = ["--quiet", "apply", str(cal), str(DATA / "example_ferraris_session.csv"), "--rate", "102.4"]
    assert main([*argv, "--out", str(out)]) == 0
    m = {k: np.array(ref[k]) for k in ("K_a", "R_a", "b_a", "K_g", "R_g", "K_ga", "b_g")}
    acc = (raw[["acc_x", "acc_y", "acc_z"]].to_numpy() - m["b_a"]) @ np.linalg.inv(m["K_a"] @ m["R_a"]).T
    gyr = raw[["gyr_x", "gyr_y", "gyr_z"]].to_numpy() - acc @ m["K_ga"].T - m["b_g"]
    gyr = gyr @ np.linalg.inv(m["K_g"] @ m["R_g"]).T  # deg/s, imucal's gyr_unit
    got = pd.read_csv(out, comment="#")
    assert np.max(np.abs(got[["ax", "ay", "az"]].to_numpy() - acc)) <= 1e-12 * np.abs(acc).max()
    assert np.max(np.abs(np.degrees(got[["gx", "gy", "gz"]].to_numpy()) - gyr)) <= 1e-12 * np.abs(gyr).max()
    assert main(["apply", str(cal), str(DATA / "example_ferraris_session.csv"), "--gyro-cal", str(cal),
                 "--out", str(tmp_path / "x.csv")]) == 2  # fmt: skip
    assert "--gyro-cal" in capsys.readouterr().err and not (tmp_path / "x.csv").exists()


def test_apply_refuses_a_physical_gyro_read_as_the_calibrations_counts(tmp_path, capsys):
    """A calibration of raw counts (≈ 940 counts per rad/s) applied to a log whose gyro is in rad/s, no unit
    stated (so read as the calibration's counts): the corrected gyro came out ~940× too small with exit 0, and a
    gyro in deg/s was refused as "rad/s". The alternatives tried for a counts calibration are now the data in
    deg/s and in rad/s read as counts (also for imu_tk's files, which state no unit, when their gyro scale is no
    physical unit's), and the error names the right one."""
    import pandas as pd

    data, res = tmp_path / "s.csv", tmp_path / "r.json"
    sim = ["--quiet", "simulate", "accel-multipos", "--out", str(data), "--scheme", "18", "--dwell", "5"]
    assert main([*sim, "--acc-unit", "counts", "--gyro-unit", "counts", "--seed", "4"]) == 0
    assert main(["--quiet", "calibrate", "accel", str(data), "--out", str(res)]) == 0
    assert main(["--quiet", "apply", str(res), str(data), "--out", str(tmp_path / "ok.csv")]) == 0
    cal = CalibrationResult.from_json(res)
    df = pd.read_csv(data, comment="#")  # no unit line: the gyro is read in the calibration's counts
    g = ["gx", "gy", "gz"]
    df[g] = cal.correct_gyro(df[g].to_numpy(), cal.correct_accel(df[["ax", "ay", "az"]].to_numpy()))  # rad/s
    # imu_tk's files state no unit: a gyro scale of hundreds of counts per rad/s is no physical unit's
    tk = (tmp_path / "a.calib", tmp_path / "g.calib")
    export_calibration(cal, "imu_tk", tk[0], gyro_out=tk[1])
    for unit, scale in (("rad/s", 1.0), ("deg/s", 180 / np.pi)):
        other, out = tmp_path / f"gyro_{unit[:3]}.csv", tmp_path / "o.csv"
        df.assign(**{c: df[c] * scale for c in g}).to_csv(other, index=False)
        for cal_args in ([str(res)], [str(tk[0]), "--gyro-cal", str(tk[1])]):
            capsys.readouterr()
            assert main(["apply", cal_args[0], str(other), *cal_args[1:], "--out", str(out)]) == 2, (unit, cal_args)
            err = capsys.readouterr().err
            assert f"were the data's gyro in {unit}" in err and "raw counts" in err, err
            assert not out.exists()


@pytest.mark.skipif(
    not (DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").is_file(), reason="imucal data absent"
)
def test_calibrate_export_imu_tk_of_a_g_sensitivity_names_a_command_that_exists(tmp_path, capsys):
    """`calibrate --method ferraris --export imu_tk:…` is refused (imu_tk has no g-sensitivity) after RESULT.json
    is written; the remedy said "export with --to imucal", a flag calibrate does not have. It now names the
    export command, which then runs as written."""
    r = tmp_path / "r.json"
    argv = ["calibrate", "accel", str(DATA / "example_ferraris_session.csv"), "--rate", "102.4", "--gyro-unit",
            "deg/s", "--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json"),
            "--gravity", "9.81", "--out", str(r), "--export", f"imu_tk:{tmp_path / 'a.calib'},{tmp_path / 'g.calib'}"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "g-sensitivity" in err and "optinav export RESULT.json --to imucal" in err, err
    assert r.exists() and not (tmp_path / "a.calib").exists()
    assert main(["--quiet", "export", str(r), "--to", "imucal", "--out", str(tmp_path / "c.json")]) == 0


@pytest.mark.skipif(
    not (DATA / "reference" / "example_cal_annotated_session.json").is_file(), reason="imucal data absent"
)
def test_imucal_au_is_counts(tmp_path, capsys):
    """imucal names raw counts "a.u." (its snapshot of the annotated session). optinav dropped that unit, so the
    annotated session with its gyro stated in rad/s was corrected as if counts: ~950× too small, exit 0. "a.u." is
    now counts (as in a data file), and a physical unit against it is refused."""
    import pandas as pd

    cal = DATA / "reference" / "example_cal_annotated_session.json"
    assert load_calibration(cal).units["gyroscope_raw"] == "counts"
    # its gyro scales are negative (imucal's expected angle −360° for the session's turns of +360°), which apply
    # refuses first: the same calibration with the turns' sense, for the unit check
    info = json.loads(cal.read_text())
    info["R_g"] = (-np.asarray(info["R_g"])).tolist()
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(info))
    df = pd.read_csv(DATA / "annotated_session.csv")
    g = ["gyr_x", "gyr_y", "gyr_z"]
    df[g] = np.radians(df[g] / 16.4)  # the driver's deg/s at ±2000 °/s, then rad/s: stated in the header
    other = tmp_path / "gyro_rad.csv"
    df.rename(columns={c: f"{c} [rad/s]" for c in g}).to_csv(other, index=False)
    out = tmp_path / "o.csv"
    assert main(["apply", str(cal), str(other), "--rate", "204.8", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "gyroscope data are in rad/s but the calibration was made in counts" in err and not out.exists()


@pytest.mark.skipif(
    not (DATA / "reference" / "example_cal_annotated_session.json").is_file(), reason="imucal data absent"
)
def test_a_gyro_calibration_with_every_scale_negative_is_refused(tmp_path, capsys):
    """imucal's calibration of its annotated session (its Ferraris default, an expected angle of −360° for turns
    that integrate to +360°) has every gyro scale negative: applied to the session it read each turn as −360°
    with exit 0, where optinav calibrate refuses the same assumption. apply refuses it naming the sense; the export
    to Kalibr names the gyroscope."""
    cal = DATA / "reference" / "example_cal_annotated_session.json"
    out = tmp_path / "o.csv"
    assert main(["apply", str(cal), str(DATA / "annotated_session.csv"), "--rate", "204.8", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "every gyro scale is negative" in err and "expected_angle=360" in err and not out.exists(), err
    lsb = ["--acc-lsb", "2048", "--gyro-lsb", "16.4"]
    assert main(["export", str(cal), "--to", "kalibr", *lsb, "--out", str(tmp_path / "k.yaml")]) == 2
    assert "the gyroscope calibration matrix has det(K) <= 0" in capsys.readouterr().err


def test_kalibr_sensitivity_for_a_calibration_of_physical_units_is_refused(tmp_path):
    """--acc-lsb/--gyro-lsb (the driver's counts per g, per °/s) with a calibration made in m/s² and rad/s were
    accepted and silently unused; they are refused naming the flag."""
    res = _calibration(3, G=False, acc_unit="m/s^2", gyro_unit="rad/s")
    for sensor, flag in (("accelerometer", "--acc-lsb"), ("gyroscope", "--gyro-lsb")):
        with pytest.raises(OptinavError, match=flag):
            export_calibration(res, "kalibr", tmp_path / "k.yaml", counts_per_si={sensor: 2048 / 9.80665})
    assert not (tmp_path / "k.yaml").exists()
    export_calibration(res, "kalibr", tmp_path / "k.yaml")


def test_export_imu_tk_never_replaces_a_numeric_log(tmp_path, capsys):
    """imu_tk reads its data as whitespace-separated numbers (``t ax ay az``); `export --to imu_tk --out` replaced
    such a log with exit 0, since a file of numbers only was taken for an imu_tk parameter file. Only a file that
    opens with imu_tk's T (three rows of three, 1 on the diagonal, a blank line) is replaced: optinav's and the
    C++ stream's."""
    res = tmp_path / "r.json"
    _calibration(2, G=False).to_json(res)
    log = tmp_path / "imu_acc.mat"
    rng = np.random.default_rng(0)
    np.savetxt(log, np.c_[np.arange(50) * 0.01, rng.normal(0, 1, (50, 3))], fmt="%.6f")
    before = log.read_bytes()
    tk = ["export", str(res), "--to", "imu_tk", "--gyro-out", str(tmp_path / "g.calib"), "--out"]
    assert main([*tk, str(log)]) == 2
    assert "would be replaced" in capsys.readouterr().err and log.read_bytes() == before
    cpp = tmp_path / "acc.calib"  # as CalibratedTriad::save writes it (Eigen's aligned columns)
    cpp.write_text("         1 -0.00123   0.0045\n         0         1 -0.0021\n        -0         0         1\n\n"
                   "0.00479 0 0\n0 0.00479 0\n0 0 0.0048\n\n1\n2\n3\n\n")  # fmt: skip
    assert main([*tk, str(cpp)]) == 0 and main([*tk, str(cpp)]) == 0  # its own file again


@pytest.mark.skipif(
    not (DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").is_file(), reason="imucal data absent"
)
def test_export_converts_imucals_calibration_to_kalibr(tmp_path, capsys):
    """`optinav export` took only optinav results ("neither ... schema"): imucal's own Ferraris calibration of the
    example session goes to Kalibr's imu.yaml, whose model equation in its frame reproduces imucal's formula
    (raw = K R x + b; the gyro's K_ga on the specific force) to 1e-12; imu_tk's file pair goes to imucal; a model
    the target cannot hold is still refused, and the input is never the output."""
    from optinav.multipos.convert import read_imucal_json

    ref = DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json"
    out = tmp_path / "imu.yaml"
    assert main(["--quiet", "export", str(ref), "--to", "kalibr", "--rostopic", "/imu0", "--out", str(out)]) == 0
    data = read_kalibr_imu_yaml(out)
    cal = read_imucal_json(ref)
    M_a, M_g = np.array(data["accelerometers"]["M"]), np.array(data["gyroscopes"]["M"])
    C, C_i_s, A = (np.array(x) for x in (data["gyroscopes"]["C_gyro_i"], data["C_i_s"], data["gyroscopes"]["A"]))
    rng = np.random.default_rng(5)
    for _ in range(5):
        a, w_deg = rng.normal(0, 9.8, 3), rng.normal(0, 90.0, 3)
        raw_a = cal.K_a @ cal.R_a @ a + cal.b_a  # imucal: m/s² and deg/s in, as its from_*_unit say
        raw_g = cal.K_g @ cal.R_g @ w_deg + cal.K_ga @ a + cal.b_g
        a_i, w_i = C_i_s @ a, C_i_s @ np.radians(w_deg)
        np.testing.assert_allclose(raw_a - cal.b_a, M_a @ a_i, rtol=1e-12, atol=1e-11)
        np.testing.assert_allclose(np.radians(raw_g - cal.b_g), M_g @ C @ w_i + A @ C @ a_i, rtol=1e-12, atol=1e-12)
    assert main(["--quiet", "export", str(ref), "--to", "imu_tk", "--out", str(tmp_path / "a.calib"),
                 "--gyro-out", str(tmp_path / "g.calib")]) == 2  # fmt: skip
    assert "no gyro g-sensitivity" in capsys.readouterr().err
    assert main(["--quiet", "export", str(out), "--to", "imucal", "--out", str(tmp_path / "c.json")]) == 2
    assert "Kalibr file, which holds no biases" in capsys.readouterr().err
    # an imu_tk pair (no g-sensitivity) to imucal, read back as the same calibration
    res = load_calibration(ref)
    res.gyroscope["G"] = np.zeros((3, 3))
    export_calibration(res, "imu_tk", tmp_path / "acc.calib", gyro_out=tmp_path / "gyr.calib")
    args = ["--quiet", "export", str(tmp_path / "acc.calib"), "--gyro-cal", str(tmp_path / "gyr.calib")]
    assert main(args + ["--to", "imucal", "--out", str(tmp_path / "tk.json")]) == 0
    back = load_calibration(tmp_path / "tk.json")
    for s in ("accelerometer", "gyroscope"):
        for k in ("K", "b"):
            np.testing.assert_allclose(getattr(back, s)[k], getattr(res, s)[k], rtol=1e-6, atol=1e-9)
    assert main(args + ["--to", "imu_tk", "--out", str(tmp_path / "acc.calib")]) == 2
    assert "is the input" in capsys.readouterr().err


@pytest.mark.skipif(not (DATA / "legacy_calibration_pre_2.0.json").is_file(), reason="imucal data absent")
def test_export_to_kalibr_of_a_calibration_that_does_not_say_its_raw_unit(tmp_path, capsys):
    """imucal's calibration before 2.0 (of counts: its K_a is the 2.x reference's × 2048/9.81) and imu_tk's files
    record no raw unit: exported to Kalibr as if in m/s² and rad/s, M came out 208 and 965 on its diagonal (Kalibr
    then reads g as 0.047 m/s²) with exit 0. Refused naming --acc-unit; stated counts with the driver's sensitivity,
    M ≈ 1 (the 2.x reference's own K in m/s² and deg/s, from the legacy's counts: within 0.1 %)."""
    legacy, ref = (
        DATA / "legacy_calibration_pre_2.0.json",
        DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json",
    )
    out = tmp_path / "k.yaml"
    assert main(["export", str(legacy), "--to", "kalibr", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "does not say the raw unit" in err and "--acc-unit" in err and not out.exists(), err
    units = ["--acc-unit", "counts", "--gyro-unit", "counts", "--acc-lsb", "2048", "--gyro-lsb", "16.384"]
    assert main(["--quiet", "export", str(legacy), "--to", "kalibr", *units, "--out", str(out)]) == 0
    got = read_kalibr_imu_yaml(out)
    assert main(["--quiet", "export", str(ref), "--to", "kalibr", "--out", str(tmp_path / "r.yaml")]) == 0
    want = read_kalibr_imu_yaml(tmp_path / "r.yaml")
    for s in ("accelerometers", "gyroscopes"):
        # the legacy's counts at the nominal 2048 LSB/g (g = 9.81 there) and 16.384 LSB/(°/s)
        f = 9.81 / 9.80665 if s == "accelerometers" else 1.0
        np.testing.assert_allclose(np.array(got[s]["M"]) * f, np.array(want[s]["M"]), rtol=2e-3, atol=2e-3)
    assert main(["export", str(ref), "--to", "kalibr", "--acc-unit", "counts", "--out", str(out)]) == 2
    assert "made from m/s^2 (the file says so)" in capsys.readouterr().err


def test_apply_refuses_rad_s_under_counts_when_gravity_does_not_turn(tmp_path, capsys):
    """The gyro check judges the unit by how gravity turns in the body: a log that turns only about the vertical
    (or rests) in rad/s under a calibration of counts, no unit stated, came out ~940x too small with exit 0.
    Values that are neither whole nor step like counts are refused; integer counts, and the simulator's unrounded
    counts (noise of a count or so), are applied; --gyro-unit counts overrides (a logger averaging counts)."""
    from optinav.io import read_imu

    rng = np.random.default_rng(48)
    cal = _calibration(3, G=False, acc_unit="counts", gyro_unit="counts")
    res = tmp_path / "r.json"
    cal.to_json(res)
    n, rate = 3000, 100.0
    t = np.arange(n) / rate
    w = np.zeros((n, 3))
    w[:, 2] = 2.0 * np.sin(np.pi * t / t[-1]) ** 2  # a turn about the vertical only: gravity stays on z
    a = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.02, (n, 3))
    raw_a = a @ cal.accelerometer["K"].T + cal.accelerometer["b"]
    w_meas = w + rng.normal(0, 0.002, (n, 3))
    raw_g = w_meas @ cal.gyroscope["K"].T + cal.gyroscope["b"]

    def write(name, gyr):
        p = tmp_path / name
        np.savetxt(p, np.column_stack([t, raw_a, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
        return p

    out = tmp_path / "o.csv"
    for gyr in (w_meas, np.degrees(w_meas)):  # rad/s or deg/s where counts were meant
        capsys.readouterr()
        assert main(["apply", str(res), str(write("phys.csv", gyr)), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert "made for raw gyro counts" in err and "--gyro-unit counts" in err and not out.exists()
    for name, gyr in (("int.csv", np.round(raw_g)), ("sim.csv", raw_g + rng.normal(0, 1.0, raw_g.shape))):
        assert main(["--quiet", "apply", str(res), str(write(name, gyr)), "--out", str(out)]) == 0
        got = read_imu(out)
        assert got.gyro_unit == "rad/s" and np.max(np.abs(got.gyr[:, 2] - w[:, 2])) < 0.01  # the turn, corrected
        out.unlink()
    avg = write("avg.csv", raw_g)  # counts averaged by a logger (no quantization): the user says so
    assert main(["--quiet", "apply", str(res), str(avg), "--gyro-unit", "counts", "--out", str(out)]) == 0


def test_export_of_a_result_of_another_kind_says_what_it_is(tmp_path, capsys):
    """`optinav export ALLAN.json` said 'result schema optinav.allan is not a optinav.multipos.calibration; pass
    the right result file' (probe): it names the kind of result given and where an allan result goes; results of
    the calibration's earlier layouts still export."""
    legacy = Path(__file__).parent / "data" / "legacy"
    assert (
        main(["--quiet", "export", str(legacy / "rins_v2.json"), "--to", "imucal", "--out", str(tmp_path / "a.json")])
        == 2
    )
    err = capsys.readouterr().err
    assert "is an optinav result of 'optinav.rins" in err and "calibrate accel" in err and "--noise" in err, err
    for name in ("multipos_v1.json", "multipos_v2.json"):
        assert main(["--quiet", "export", str(legacy / name), "--to", "imucal", "--out", str(tmp_path / name)]) == 0


@pytest.mark.parametrize("axis", ["ax", "ay", "az"])
def test_apply_names_an_accelerometer_axis_flipped(tmp_path, capsys, axis):
    """A log whose accelerometer x or z column is negated keeps |a| ≈ g and the gyro's unit, so apply wrote it with
    exit 0 (probe): the gyro's axes are judged even when the unit is right — on the block and on each quarter
    (the block's most turning windows turned about x, where an x flip does not show) — and the error names the
    axes and --columns."""
    import pandas as pd

    data, res = tmp_path / "d.csv", tmp_path / "r.json"
    sim = ["--quiet", "simulate", "accel-multipos", "--out", str(data), "--dwell", "6", "--acc-unit", "counts"]
    assert main([*sim, "--gyro-unit", "deg/s", "--seed", "11"]) == 0
    assert main(["--quiet", "calibrate", "accel", str(data), "--latitude", "38.88", "--out", str(res)]) == 0
    lines = data.read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    df = pd.read_csv(data, skiprows=head)
    out = tmp_path / "o.csv"
    assert main(["--quiet", "apply", str(res), str(data), "--out", str(out)]) == 0
    flipped = tmp_path / "f.csv"
    flipped.write_text("\n".join(lines[:head]) + "\n" + df.assign(**{axis: -df[axis]}).to_csv(index=False))
    assert main(["--quiet", "apply", str(res), str(flipped), "--out", str(tmp_path / "o2.csv")]) == 2
    err = capsys.readouterr().err
    assert "does not explain how gravity turns" in err and "reads -" in err and "--columns" in err, err


def test_an_imu_tk_file_for_data_in_g_names_the_unit_it_was_made_for(tmp_path, capsys):
    """imu_tk files record no unit. A calibration of a log in g, exported to imu_tk and applied to the same log in
    m/s² (declared), said "state the data's unit with --acc-unit": it was stated, and no flag can help. The error
    names the unit the file was made for (|a| 9.8 g: g) and the remedy that works."""
    s = tmp_path / "s.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(s), "--acc-unit", "g", "--dwell", "10", "--seed", "3"]
    assert main(argv) == 0
    r = tmp_path / "r.json"
    assert main(["--quiet", "calibrate", "accel", str(s), "--out", str(r)]) == 0
    a, g = tmp_path / "a.calib", tmp_path / "g.calib"
    assert main(["--quiet", "export", str(r), "--to", "imu_tk", "--out", str(a), "--gyro-out", str(g)]) == 0
    d = np.genfromtxt(s, delimiter=",", names=True, skip_header=2)  # (two comment lines: source, units)
    si = tmp_path / "si.csv"
    cols = [d["t"], *(d[f"a{c}"] * 9.80665 for c in "xyz"), *(d[f"g{c}"] for c in "xyz")]
    np.savetxt(si, np.column_stack(cols), delimiter=",", comments="", header="t,ax,ay,az,gx,gy,gz")
    si.write_text("# units: t=s acc=m/s^2 gyro=rad/s\n" + si.read_text())
    capsys.readouterr()
    assert main(["--quiet", "apply", str(a), str(si), "--gyro-cal", str(g), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "imu_tk files record no unit" in err and "made for data in g" in err and "convert the log" in err, err


def test_kalibr_update_rate_is_written_to_six_digits(tmp_path):
    """A rate from epoch time stamps (1.7e9 s) came out 99.999999999205272 in imu.yaml; written to 6 digits."""
    res = _calibration(0, G=False, acc_unit="m/s^2", gyro_unit="rad/s")
    export_calibration(res, "kalibr", tmp_path / "imu.yaml", rostopic="/imu0", update_rate=99.999999999205272)
    assert read_kalibr_imu_yaml(tmp_path / "imu.yaml")["update_rate"] == 100.0
    assert "update_rate: 100  #" in (tmp_path / "imu.yaml").read_text()
