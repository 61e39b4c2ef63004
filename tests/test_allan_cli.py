"""`optinav simulate static` → `optinav allan` end to end: JSON result, report, Kalibr imu.yaml read back."""

import json
import math
from pathlib import Path
import re

import numpy as np
import pytest
import yaml

from optinav.cli.main import main
from optinav.core.files import write_csv
from optinav.core.allan import AllanAnalysis
from optinav.core.results import Result


@pytest.fixture(scope="module")
def rest(tmp_path_factory):
    d = tmp_path_factory.mktemp("rest")
    data = d / "rest.csv"
    # 40 min at 50 Hz with a strong gyro rate random walk, so all three terms show within the record
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "static",
                "--out",
                str(data),
                "--hours",
                "0.67",
                "--rate",
                "50",
                "--gyro-rrw",
                "200",
                "--accel-rrw",
                "20",
                "--gyro-unit",
                "deg/s",
                "--seed",
                "4",
            ]
        )
        == 0
    )
    return d, data, json.loads((d / "rest.truth.json").read_text())


def test_allan_end_to_end_with_kalibr(rest, capsys):
    d, data, truth = rest
    out, yml, rep = d / "allan.json", d / "imu.yaml", d / "rep"
    assert (
        main(
            [
                "--quiet",
                "allan",
                str(data),
                "--out",
                str(out),
                "--kalibr",
                str(yml),
                "--rostopic",
                "/imu0",
                "--report",
                str(rep),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "white noise N" in text and "Kalibr imu.yaml written" in text
    res = Result.from_json(out)
    assert isinstance(res, AllanAnalysis) and res.rate_hz == pytest.approx(50.0, rel=1e-9)
    assert res.gyroscope["deviation"].unit == "rad/s"  # the file's deg/s converted to SI
    # each field carries its real unit (they said "[unit]*sqrt(s)", the unit in another field)
    gyro = json.loads(out.read_text())["fields"]["gyroscope"]["value"]
    assert gyro["fit"]["fields"]["white"]["unit"] == "(rad/s)*sqrt(s)", gyro["fit"]["fields"]["white"]
    assert gyro["deviation"]["fields"]["adev"]["unit"] == "rad/s"
    for sensor in ("accelerometer", "gyroscope"):
        fit = res.sensor(sensor)["fit"]
        N_true = np.array(truth[sensor]["white"])
        # white noise is measured to a few percent in 40 min, within 3 of its reported std in every axis (a 68 %
        # interval misses 2 of 3 axes of one record a quarter of the time: its coverage is
        # test_allan.test_fit_interval_coverage's and benchmarks/results_allan_coverage.md's)
        assert np.all(np.abs(fit.white - N_true) <= 3.0 * fit.white_std)
        assert np.all(np.abs(fit.white / N_true - 1) < 0.05)
    # Kalibr's file: plain YAML read as Kalibr reads it (yaml.safe_load of the whole file, which refuses OpenCV's
    # "%YAML:1.0" line), with the fit's largest-axis N and K in Kalibr's units
    k = yaml.safe_load(yml.read_text())
    assert set(k) == {
        "accelerometer_noise_density",
        "accelerometer_random_walk",
        "gyroscope_noise_density",
        "gyroscope_random_walk",
        "rostopic",
        "update_rate",
    }
    assert k["rostopic"] == "/imu0" and k["update_rate"] == pytest.approx(50.0, rel=1e-9)
    for sensor in ("accelerometer", "gyroscope"):
        fit = res.sensor(sensor)["fit"]
        assert k[f"{sensor}_noise_density"] == pytest.approx(float(np.max(fit.white)), rel=1e-15)
        assert k[f"{sensor}_noise_density"] == pytest.approx(max(truth[sensor]["white"]), rel=0.05)
    K_true = max(truth["gyroscope"]["random_walk"])
    assert 0.5 * K_true < k["gyroscope_random_walk"] < 2.0 * K_true
    # the report: markdown and one log-log figure per sensor
    md = (rep / "index.md").read_text()
    assert "IEEE 952 read-off" in md and "allan_gyroscope.png" in md
    assert (rep / "allan_accelerometer.png").stat().st_size > 10_000


def test_allan_refusals(rest, tmp_path, capsys):
    d, data, _ = rest
    lines = data.read_text().splitlines()
    header = [ln for ln in lines if not ln[:1].isdigit() and not ln[:1] == "-"]
    body = [ln for ln in lines if ln[:1].isdigit() or ln[:1] == "-"]
    # a gap: drop a block of rows
    gap = tmp_path / "gap.csv"
    gap.write_text("\n".join(header + body[:5000] + body[5100:20000]) + "\n")
    assert main(["allan", str(gap), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert "not regularly sampled" in err and len(err.strip().splitlines()) == 1
    # raw counts: no Kalibr file (Kalibr reads SI), one line naming what helps
    counts = tmp_path / "counts.csv"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(counts),
                "--scheme",
                "six",
                "--dwell",
                "5",
                "--acc-unit",
                "counts",
                "--gyro-unit",
                "counts",
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert main(["allan", str(counts), "--out", str(tmp_path / "c.json"), "--kalibr", str(tmp_path / "k.yaml")]) == 2
    err = capsys.readouterr().err
    assert "Kalibr needs both triads in SI units" in err and "apply" in err
    assert not (tmp_path / "k.yaml").exists()
    # too short a record
    short = tmp_path / "short.csv"
    short.write_text("\n".join(header + body[:40]) + "\n")
    assert main(["allan", str(short), "--out", str(tmp_path / "s.json")]) == 2
    assert "record a longer static log" in capsys.readouterr().err


def test_streamed_log_matches_in_memory(rest, tmp_path):
    """Read in blocks of 997 rows and folded into the angle sums block by block, the deviation equals the
    in-memory computation on the whole log (to rounding)."""
    from optinav.core.allan import allan_deviation
    from optinav.io import read_imu

    _, data, _ = rest
    out = tmp_path / "a.json"
    assert main(["--quiet", "allan", str(data), "--out", str(out), "--sensor", "gyro", "--chunk-rows", "997"]) == 0
    res = Result.from_json(out)
    assert res.accelerometer is None
    log = read_imu(data)
    dt = (log.t[-1] - log.t[0]) / (len(log.t) - 1)
    ref = allan_deviation(log.gyr, dt, unit="rad/s")
    dev = res.gyroscope["deviation"]
    assert np.allclose(dev.tau, ref.tau, rtol=1e-12)
    assert np.max(np.abs(dev.adev / ref.adev - 1)) < 1e-9


def test_allan_refuses_an_accelerometer_not_in_m_s2_and_a_moving_log(tmp_path, capsys):
    """A log at rest has |a| ≈ g: an accelerometer in g read as m/s² (no unit stated) gave a VRW 9.8× too small
    with exit 0 — now refused naming --acc-unit g, and with it the result is the m/s² log's. A log whose gravity
    direction moves is not at rest: refused, the gyro alone too."""
    rng = np.random.default_rng(11)
    n, rate = 30_000, 100.0
    t = np.arange(n) / rate
    acc = rng.normal(0, 0.02, (n, 3)) + [0.1, -0.2, 9.79]
    gyr = rng.normal(0, 0.002, (n, 3))
    head = "t,ax,ay,az,gx,gy,gz"
    si, g = tmp_path / "si.csv", tmp_path / "g.csv"
    write_csv(si, np.c_[t, acc, gyr], head, "%.17g")
    write_csv(g, np.c_[t, acc / 9.80665, gyr], head, "%.17g")
    assert main(["allan", str(g), "--out", str(tmp_path / "g.json")]) == 2
    err = capsys.readouterr().err
    assert "mean norm is 0.999 m/s², not about 9.8 at rest: it looks like g" in err and "--acc-unit g" in err
    assert main(["--quiet", "allan", str(g), "--acc-unit", "g", "--out", str(tmp_path / "g.json")]) == 0
    assert main(["--quiet", "allan", str(si), "--out", str(tmp_path / "si.json")]) == 0
    a, b = (Result.from_json(tmp_path / f"{k}.json") for k in ("g", "si"))
    np.testing.assert_allclose(a.accelerometer["deviation"].adev, b.accelerometer["deviation"].adev, rtol=1e-9)
    # turned by 90° halfway (a second pose): not at rest
    moved = np.r_[acc[: n // 2], acc[n // 2 :][:, [2, 1, 0]]]
    mv = tmp_path / "moved.csv"
    write_csv(mv, np.c_[t, moved, gyr], head, "%.17g")
    for extra in ([], ["--sensor", "gyro"]):
        capsys.readouterr()
        assert main(["allan", str(mv), "--out", str(tmp_path / "m.json"), *extra]) == 2
        err = capsys.readouterr().err
        assert "the gravity direction moves in this log (|mean a| / mean |a| = 0.714)" in err  # cos 45° and biases
        assert len(err.strip().splitlines()) == 1


def test_a_deg_s_gyro_read_as_rad_s_is_named(tmp_path, capsys):
    """A static pose of imucal's real session (gyro in deg/s, no unit stated): read as rad/s its noise density
    (0.0045 'rad/s/√Hz') would have gone into a Kalibr file with exit 0; its rest rate (0.7) and noise are
    beyond any MEMS gyro in rad/s. Stated as deg/s it runs."""
    from pathlib import Path

    data = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal" / "example_ferraris_session.csv"
    if not data.is_file():
        pytest.skip("imucal data absent")
    rows = np.genfromtxt(data, delimiter=",", names=True)[540:1271]  # pose x_p
    f = tmp_path / "xp.csv"
    cols = [rows[f"acc_{a}"] for a in "xyz"] + [rows[f"gyr_{a}"] for a in "xyz"]
    np.savetxt(
        f,
        np.column_stack([np.arange(rows.size) / 102.4, *cols]),
        delimiter=",",
        header="t,ax,ay,az,gx,gy,gz",
        comments="",
    )
    assert main(["allan", str(f), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "looks like deg/s read as rad/s" in err and "--gyro-unit deg/s" in err, err
    assert main(["--quiet", "allan", str(f), "--gyro-unit", "deg/s", "--out", str(tmp_path / "b.json")]) == 0


def test_a_mdps_gyro_declared_deg_s_is_named_mdps(tmp_path, capsys):
    """The same pose with the gyro in mdps: declared deg/s it was told "looks like deg/s read as rad/s" and
    "--gyro-unit deg/s", the unit given; now it names mdps (in a note: a stated unit is analysed as stated), and
    --gyro-unit mdps gives the deg/s file's noise."""
    from pathlib import Path

    data = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal" / "example_ferraris_session.csv"
    if not data.is_file():
        pytest.skip("imucal data absent")
    rows = np.genfromtxt(data, delimiter=",", names=True)[540:1271]  # pose x_p
    t = np.arange(rows.size) / 102.4
    acc = [rows[f"acc_{a}"] for a in "xyz"]
    for name, k in (("dps.csv", 1.0), ("mdps.csv", 1000.0)):
        cols = np.column_stack([t, *acc, *(rows[f"gyr_{a}"] * k for a in "xyz")])
        np.savetxt(tmp_path / name, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt="%.17g")
    argv = ["allan", str(tmp_path / "mdps.csv"), "--out", str(tmp_path / "a.json")]
    assert main(argv) == 2  # read as rad/s, the default
    assert "looks like mdps read as rad/s" in capsys.readouterr().err
    # deg/s stated: the user's word stands (a gyro that noisy in deg/s had no way through), the note names mdps
    assert main([*argv, "--gyro-unit", "deg/s"]) == 0
    err = capsys.readouterr().err
    assert "as declared in deg/s (--gyro-unit)" in err and "it looks like mdps read as deg/s" in err, err
    fits = []
    for name, unit in (("mdps.csv", "mdps"), ("dps.csv", "deg/s")):
        out = tmp_path / f"{name}.json"
        assert main(["--quiet", "allan", str(tmp_path / name), "--gyro-unit", unit, "--out", str(out)]) == 0
        fits.append(json.loads(out.read_text()))
    a, b = (f["fields"]["gyroscope"]["value"]["fit"]["fields"] for f in fits)
    for term in ("white", "bias_instability"):  # the same samples in rad/s but for the rounding of ×1000
        np.testing.assert_allclose(a[term]["value"], b[term]["value"], rtol=1e-9)


def test_a_moving_log_in_counts_is_refused(tmp_path, capsys):
    """A multi-position session in raw counts gave noise figures with exit 0 (the at-rest check judged only logs
    in m/s^2): the gravity direction's steadiness needs no unit."""
    f = tmp_path / "u.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(f), "--dwell", "4", "--acc-unit", "counts"]
    assert main(argv + ["--gyro-unit", "counts", "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["--quiet", "allan", str(f), "--out", str(tmp_path / "a.json")]) == 2
    assert "the gravity direction moves in this log" in capsys.readouterr().err


def test_a_short_log_says_its_random_walk_is_not_reliable(tmp_path, capsys):
    """30-s logs gave a random walk 29-86× the truth with 68 % intervals 10× off it, with no word."""
    log = tmp_path / "short.csv"
    assert main(["--quiet", "simulate", "static", "--out", str(log), "--hours", "0.01", "--seed", "3"]) == 0
    assert main(["allan", str(log), "--out", str(tmp_path / "a.json")]) == 0
    cap = capsys.readouterr()
    err = cap.err
    assert "the log spans 0.6 min" in err and "neither K nor its interval is reliable (N is)" in err
    assert json.loads((tmp_path / "a.json").read_text())["fields"]["notes"]["value"]
    # a term the IEEE read-off cannot see in 36 s is said so in the table (it printed "(nan)")
    rw = [line for line in cap.out.splitlines() if line.lstrip().startswith("random walk K")]
    assert len(rw) == 2 and all(line.count("(not seen)") == 3 for line in rw) and "nan" not in cap.out, cap.out


def test_a_warm_up_ramp_is_fitted_apart_from_the_random_walk_and_named(tmp_path, capsys):
    """A gyro whose rate drifts steadily over the log (a sensor warming up: here by 20·K·√T on x over the
    40 min) was fitted as random walk — K_x 4.9× the truth, its 68 % interval [3.9, 7.3]× excluding it, and no
    word. The ramp is now the fit's fifth term R: K's interval holds the truth again on x (1.2×), R is within
    10 % of the simulated ramp, and the note names x alone."""
    from optinav.core.allan import FLICKER_FLOOR
    from optinav.core.imu_model import static_noise

    n, dt = 40 * 60 * 50, 0.02
    N = np.array([2e-3, 2e-3, 2e-3])
    B = N / FLICKER_FLOOR
    K = np.sqrt(3 / 200.0) * FLICKER_FLOOR * B
    t = np.arange(n) * dt
    gyr = static_noise(n, dt, white=N, bias_instability=B, random_walk=K, rng=5)
    R = 20.0 * K[0] / np.sqrt(n * dt)
    gyr[:, 0] += R * t
    acc = np.array([0.0, 0.0, 9.81]) + static_noise(n, dt, white=np.full(3, 1e-3), rng=6)
    log = tmp_path / "warm.csv"
    write_csv(log, np.column_stack([t, acc, gyr]), "t,ax,ay,az,gx,gy,gz", "%.18e")
    out = tmp_path / "a.json"
    assert main(["allan", str(log), "--out", str(out), "--sensor", "gyro"]) == 0
    err = capsys.readouterr().err
    assert "the gyroscope rate drifts steadily (x R = " in err and " y R" not in err and " z R" not in err
    assert "differs between the log's halves" not in err  # a steady ramp is no change of the noise
    fit = Result.from_json(out.read_text()).gyroscope["fit"]
    assert fit.random_walk_interval[0, 0] <= K[0] <= fit.random_walk_interval[1, 0]
    assert abs(fit.rate_ramp[0] / R - 1) < 0.1


def test_a_warm_up_that_settles_early_is_named_not_stationary(tmp_path, capsys):
    """A warm-up that settles in the first minutes (the bias −A·e^(−t/τ), τ = T/20, A = 10·K·√T on x) has no ramp's
    slope: the fit took it for random walk (K_x 3.3× the truth over 3.6 h, its interval excluding it) with no word.
    The two halves of the log (here 2 h) now give K apart (99 % intervals), and a note says the noise is
    not stationary; the ramp-free y and z are not named."""
    from optinav.core.allan import FLICKER_FLOOR
    from optinav.core.imu_model import static_noise

    n, dt = 2 * 3600 * 20, 0.05
    N = np.full(3, 2e-3)
    B = N / FLICKER_FLOOR
    K = np.sqrt(3 / 200.0) * FLICKER_FLOOR * B
    t = np.arange(n) * dt
    gyr = static_noise(n, dt, white=N, bias_instability=B, random_walk=K, rng=8)
    gyr[:, 0] -= 10.0 * K[0] * np.sqrt(n * dt) * np.exp(-t / (n * dt / 20))
    acc = np.array([0.0, 0.0, 9.81]) + static_noise(n, dt, white=np.full(3, 1e-3), rng=9)
    log = tmp_path / "warm.csv"
    write_csv(log, np.column_stack([t, acc, gyr]), "t,ax,ay,az,gx,gy,gz", "%.18e")
    assert main(["allan", str(log), "--out", str(tmp_path / "a.json"), "--sensor", "gyro"]) == 0
    err = capsys.readouterr().err
    assert "random walk differs between the log's halves (x K = " in err and "not stationary" in err
    assert "; y K" not in err and "; z K" not in err


def _write_log(path, t, acc, gyr):
    write_csv(path, np.c_[t, acc, gyr], "t,ax,ay,az,gx,gy,gz", "%.10g")


def test_a_log_that_moves_in_the_middle_is_refused(tmp_path, capsys):
    """Seconds of motion in a log at rest leave the mean gravity direction in place, and the fit took the motion for
    noise: BROAD's rests joined by 5 s of its motion gave N = 0 on most axes, exit 0; a simulated 20-min rest with a
    10-s turn and back gave the turned axes N = 0 and K 10⁴× the truth. Refused, naming where the log moves; the
    rests alone still run."""
    import os
    from pathlib import Path

    rng = np.random.default_rng(5)
    rate, n = 100.0, 120_000
    t = np.arange(n) / rate
    acc = rng.normal(0, 0.01, (n, 3)) + np.cumsum(rng.normal(0, 1e-4, (n, 3)), axis=0) + [0, 0, 9.81]
    gyr = rng.normal(0, 1e-3, (n, 3)) + np.cumsum(rng.normal(0, 1e-5, (n, 3)), axis=0)
    still = tmp_path / "still.csv"
    _write_log(still, t, acc, gyr)
    assert main(["--quiet", "allan", str(still), "--out", str(tmp_path / "s.json")]) == 0
    i0, i1 = 60_000, 61_000  # 10 s: up 45° about x and back, at 9°/s
    ang = np.radians(45) * np.sin(np.linspace(0, np.pi, i1 - i0))
    acc[i0:i1, 1] += 9.81 * np.sin(ang)
    acc[i0:i1, 2] += 9.81 * (np.cos(ang) - 1)
    gyr[i0:i1, 0] += np.gradient(ang, 1 / rate)
    moved = tmp_path / "moved.csv"
    _write_log(moved, t, acc, gyr)
    for extra in ([], ["--sensor", "gyro"]):
        capsys.readouterr()
        assert main(["allan", str(moved), "--out", str(tmp_path / "m.json"), *extra]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "is not at rest throughout" in err, err
        assert "at t = 600 s" in err and "until t = 610 s" in err and "cut the static part" in err, err
    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    trial = shared / "attitude" / "broad" / "03_undisturbed_slow_rotation_C.hdf5"
    if not trial.is_file():
        pytest.skip("BROAD data absent")
    import h5py

    with h5py.File(trial, "r") as f:
        a, g, rest = f["imu_acc"][:], f["imu_gyr"][:], ~f["movement"][:].astype(bool)
        rate = float(f.attrs["sampling_rate"])
    edges = np.flatnonzero(np.diff(rest.astype(int)))  # the first rest ends, the last begins
    first, last = np.arange(edges[0] + 1), np.arange(edges[-1] + 1, rest.size)
    for name, rows, code in (
        ("rest", first, 0),
        ("rest_move_rest", np.r_[first, np.arange(edges[0] + 1, edges[0] + 1 + int(5 * rate)), last], 2),
    ):
        f = tmp_path / f"{name}.csv"
        _write_log(f, np.arange(rows.size) / rate, a[rows], g[rows])
        capsys.readouterr()
        assert main(["allan", str(f), "--out", str(tmp_path / f"{name}.json")]) == code, capsys.readouterr().err
    assert "is not at rest throughout" in capsys.readouterr().err


def test_a_raw_log_read_as_si_is_named_raw_counts(tmp_path, capsys):
    """imucal's annotated session holds raw counts (~2048/g, ~16.7/(deg/s)); read as SI, the accelerometer was said
    to look like mg and the gyro like deg/s, and following either hint ran with exit 0 and noise 2× or 16× off.
    Whole-number samples name raw counts and --acc-unit/--gyro-unit counts."""
    import os
    from pathlib import Path

    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    data = shared / "imucal" / "annotated_session.csv"
    if not data.is_file():
        pytest.skip("imucal data absent")
    rows = np.genfromtxt(data, delimiter=",", names=True, dtype=None, encoding="utf-8")
    pose = rows[rows["part"] == "x_a"]
    f = tmp_path / "xa.csv"
    cols = [pose[f"acc_{a}"] for a in "xyz"] + [pose[f"gyr_{a}"] for a in "xyz"]
    _write_log(f, np.arange(pose.size) / 204.8, np.column_stack(cols[:3]), np.column_stack(cols[3:]))
    out = str(tmp_path / "a.json")
    assert main(["allan", str(f), "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "raw counts (its samples are whole numbers)" in err and "--acc-unit counts" in err
    assert main(["allan", str(f), "--acc-unit", "counts", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "looks like raw counts" in err and "--gyro-unit counts" in err, err
    assert main(["--quiet", "allan", str(f), "--acc-unit", "counts", "--gyro-unit", "counts", "--out", out]) == 0
    # a log in g or deg/s (fractional samples) keeps its hint
    _write_log(f, np.arange(pose.size) / 204.8, np.column_stack(cols[:3]) / 2048.0, np.column_stack(cols[3:]) / 16.7)
    assert main(["allan", str(f), "--out", out]) == 2
    err = capsys.readouterr().err
    assert "it looks like g;" in err and "counts" not in err, err


def test_an_axis_that_reads_one_value_throughout_is_refused(tmp_path, capsys):
    """A gyro axis the logger fills with 0 gave N = 0 [0, 0] on it with exit 0 (no IMU axis is noiseless); refused
    naming the axis, --columns and --sensor for the other triad, which then runs."""
    rng = np.random.default_rng(9)
    n = 30_000
    t = np.arange(n) / 100.0
    acc = rng.normal(0, 0.01, (n, 3)) + [0, 0, 9.81]
    gyr = rng.normal(0, 1e-3, (n, 3))
    gyr[:, 2] = 0.0
    f = tmp_path / "dead.csv"
    _write_log(f, t, acc, gyr)
    assert main(["allan", str(f), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the gyroscope reads one value in every sample (z = 0 rad/s)" in err, err
    assert "--columns" in err and "--sensor acc" in err
    assert main(["--quiet", "allan", str(f), "--sensor", "acc", "--out", str(tmp_path / "a.json")]) == 0


def test_a_log_of_a_few_samples_is_named_short_not_dead(tmp_path):
    """Three rows of imucal's still pose x_p (gyro in deg/s, quantized to 1/16.4 deg/s) were refused as 'the
    gyroscope reads one value in every sample ... a dead axis, a column that is not the sensor's', sending the user
    to --columns; too few samples is the cause."""
    from optinav.core.allan import analyse_blocks
    from optinav.errors import OptinavError
    from optinav.io import read_imu

    data = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal" / "example_ferraris_session.csv"
    if not data.is_file():
        pytest.skip("imucal data absent")
    head, *rows = data.read_text().splitlines()
    f = tmp_path / "three.csv"
    f.write_text("\n".join([head, *rows[540:543]]) + "\n")
    log = read_imu(f, rate_hz=102.4, gyro_unit="deg/s")
    with pytest.raises(OptinavError, match=r"the log has 3 samples; an Allan deviation needs thousands"):
        analyse_blocks([log])


def test_one_corrupted_gyro_sample_is_named_where_it_is_not_a_unit(tmp_path, capsys):
    """One sample of 30 rad/s in a 30-min rest (a corrupted line) raised the gyro's mean-square noise past any MEMS
    gyro's, and the error said the log looked like deg/s (--gyro-unit deg/s); the jump is named with its time."""
    rng = np.random.default_rng(3)
    n = 180_000
    t = np.arange(n) / 100.0
    gyr = rng.normal(0, 1e-3, (n, 3))
    gyr[90_000, 1] = 30.0
    f = tmp_path / "spike.csv"
    _write_log(f, t, rng.normal(0, 0.01, (n, 3)) + [0, 0, 9.81], gyr)
    assert main(["allan", str(f), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the gyroscope is not at rest throughout" in err and "t = 900 s" in err, err
    assert "deg/s" not in err


def _broad_rest(name):
    import os
    from pathlib import Path

    shared = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    trial = shared / "attitude" / "broad" / name
    if not trial.is_file():
        pytest.skip("BROAD data absent")
    import h5py

    with h5py.File(trial, "r") as f:
        a, g, rest = f["imu_acc"][:], f["imu_gyr"][:], ~f["movement"][:].astype(bool)
        rate = float(f.attrs["sampling_rate"])
    end = int(np.flatnonzero(~rest)[0])  # the first rest
    return a[:end], g[:end], rate


def test_a_rest_touched_at_its_end_is_refused_naming_when(tmp_path, capsys):
    """BROAD's rests are touched in their first or last seconds in six of nine trials (the spread within 1-s windows
    3-22× the rest's; the mean barely moves): their gyro N came out up to 6× the untouched rests', exit 0. Refused
    naming when; the rest cut before it runs, and an untouched rest is not refused."""
    a, g, rate = _broad_rest("02_undisturbed_slow_rotation_B.hdf5")
    n = a.shape[0]
    f = tmp_path / "rest.csv"
    _write_log(f, np.arange(n) / rate, a, g)
    assert main(["allan", str(f), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the gyroscope is not at rest throughout: from t = 39.06 s" in err, err
    assert "spread within 1.01-s windows" in err and "cut the static part" in err
    k = int(38.0 * rate)
    _write_log(f, np.arange(k) / rate, a[:k], g[:k])
    assert main(["--quiet", "allan", str(f), "--out", str(tmp_path / "a.json")]) == 0
    a, g, rate = _broad_rest("03_undisturbed_slow_rotation_C.hdf5")
    _write_log(f, np.arange(a.shape[0]) / rate, a, g)
    assert main(["--quiet", "allan", str(f), "--out", str(tmp_path / "a.json")]) == 0


def test_a_rest_in_counts_with_noise_below_a_count_runs(tmp_path, capsys):
    """Samples that rarely leave one count have window means that differ by rounding only: the jump check's scatter
    was ~1e-16 and an hour at rest was refused as moving at 3e14 sigma; the scatter is floored at the resolution."""
    rng = np.random.default_rng(3)
    n = 360_000
    acc = np.round(rng.normal(0, 0.15, (n, 3)) + [0.3, -0.2, 2048.4])
    gyr = np.round(rng.normal(0, 0.15, (n, 3)) + [0.2, 0.1, -0.3])
    f = tmp_path / "q.csv"
    _write_log(f, np.arange(n) / 100.0, acc, gyr)
    argv = [
        "--quiet",
        "allan",
        str(f),
        "--acc-unit",
        "counts",
        "--gyro-unit",
        "counts",
        "--out",
        str(tmp_path / "a.json"),
    ]
    assert main(argv) == 0, capsys.readouterr().err


def test_a_low_pass_filtered_imu_gets_its_white_noise(tmp_path, capsys):
    """An IMU sampled at 1 kHz behind a 40 Hz low-pass (a MEMS DLPF) lies below the white-noise line at short τ; the
    fit took those points and gave N 30-45 % low with intervals excluding the truth (Kalibr's density with it).
    From the first point where the curve falls as white noise's, N is within 6 % on every axis (sampling + the
    filter's tail)."""
    from scipy.signal import butter, lfilter

    rng = np.random.default_rng(8)
    fs, n = 1000.0, 600_000
    b, a = butter(2, 40 / (fs / 2))
    acc = lfilter(b, a, rng.normal(0, 1e-3 * np.sqrt(fs), (n, 3)), axis=0) + [0, 0, 9.81]
    gyr = lfilter(b, a, rng.normal(0, 1e-4 * np.sqrt(fs), (n, 3)), axis=0)
    f = tmp_path / "dlpf.npz"  # (a CSV of 600 000 rows took most of the test's time)
    np.savez(f, t=np.arange(n) / fs, acc=acc, gyr=gyr)
    assert main(["--quiet", "allan", str(f), "--out", str(tmp_path / "a.json")]) == 0
    res = Result.from_json(tmp_path / "a.json")
    for sensor, truth in (("accelerometer", 1e-3), ("gyroscope", 1e-4)):
        N = np.asarray(res.sensor(sensor)["fit"].white)
        assert np.all(np.abs(N / truth - 1) < 0.06), (sensor, N / truth)


def test_a_slow_nudge_of_the_pose_is_refused(tmp_path, capsys):
    """A rest nudged by 1° over 10 s (a cable pulling, a hand on the table) is too slow for the jump check and
    leaves the spread within 1-s windows alone: the 40-min simulated rest ran with exit 0 and accelerometer K 2.9×
    the truth. Gravity's direction in the 1-s means turns by 1° in 10 s against 0.02° of the rest's own drift:
    refused, naming when, with the gyroscope's turn there; the rest without the nudge runs, and so does a 0.05°
    nudge (within the drift)."""
    rng = np.random.default_rng(5)
    rate, n = 100.0, 120_000
    t = np.arange(n) / rate
    acc = rng.normal(0, 0.01, (n, 3)) + np.cumsum(rng.normal(0, 1e-4, (n, 3)), axis=0) + [0, 0, 9.81]
    gyr = rng.normal(0, 1e-3, (n, 3)) + np.cumsum(rng.normal(0, 1e-6, (n, 3)), axis=0)
    i0, i1 = 60_000, 61_000  # 10 s from t = 600 s
    for deg, code in ((0.0, 0), (0.05, 0), (1.0, 2)):
        ang = np.zeros(n)
        ang[i0:i1] = np.radians(deg) * (1 - np.cos(np.linspace(0, np.pi, i1 - i0))) / 2
        ang[i1:] = np.radians(deg)
        a, g = acc.copy(), gyr.copy()
        a[:, 1] += 9.81 * np.sin(ang)
        a[:, 2] += 9.81 * (np.cos(ang) - 1)
        g[:, 0] += np.gradient(ang, 1 / rate)
        f = tmp_path / f"nudge_{deg}.npz"
        np.savez(f, t=t, acc=a, gyr=g)
        capsys.readouterr()
        assert main(["--quiet", "allan", str(f), "--out", str(tmp_path / f"n{deg}.json")]) == code
        err = capsys.readouterr().err
        if code:
            assert err.count("\n") == 1 and "not at rest throughout" in err and "cut the static part" in err, err
            turn, ta, tb, gyro = re.search(
                r"turns by ([\d.]+)° between t = (\d+) s and (\d+) s.*?gyroscope turns by ([\d.]+)°", err
            ).groups()
            assert abs(float(turn) - 1.0) < 0.05 and 595 <= int(ta) <= 601 and 605 <= int(tb) <= 611, err
            assert abs(float(gyro) - 1.0) < 0.15, err  # the gyro's noise over 10 s: ~0.02°, its bias drift more


def test_accelerometer_and_gyroscope_in_two_files_on_their_own_clocks(tmp_path, capsys):
    """A phone app logs a file per sensor, each with its own time stamps: `allan` read one file, and a Kalibr
    imu.yaml needs both triads. ``--gyro GYRODATA`` analyses each triad on its own clock (the gyro's stamps 3 ms
    later here): the same numbers and the same imu.yaml as the one file; a gyroscope at another rate is named
    (Kalibr's update_rate is the accelerometer's); --sensor is refused beside --gyro."""
    from optinav.io import read_imu

    one = tmp_path / "one.csv"
    assert main(["--quiet", "simulate", "static", "--out", str(one), "--hours", "0.1", "--rate", "50",
                 "--gyro-rrw", "200", "--accel-rrw", "20", "--seed", "7"]) == 0  # fmt: skip
    log = read_imu(one)
    acc, gyr, gyr2 = tmp_path / "Accelerometer.csv", tmp_path / "Gyroscope.csv", tmp_path / "Gyroscope25.csv"
    write_csv(acc, np.column_stack([log.t, log.acc]), "t,ax,ay,az", "%.17g")
    rows = np.column_stack([log.t + 0.003, log.gyr])
    write_csv(gyr, rows, "t,gx,gy,gz", "%.17g")
    write_csv(gyr2, rows[::2], "t,gx,gy,gz", "%.17g")
    res = {}
    for name, argv in {
        "one": [str(one)],
        "two": [str(acc), "--gyro", str(gyr)],
        "25": [str(acc), "--gyro", str(gyr2)],
    }.items():
        out, yml = tmp_path / f"{name}.json", tmp_path / f"{name}.yaml"
        assert main(["--quiet", "allan", *argv, "--out", str(out), "--kalibr", str(yml)]) == 0
        res[name] = (Result.from_json(out), yaml.safe_load(yml.read_text()), capsys.readouterr().err)
    (r1, y1, _), (r2, y2, e2), (_, y3, e3) = res["one"], res["two"], res["25"]
    assert y1 == y2
    for sensor in ("accelerometer", "gyroscope"):
        np.testing.assert_array_equal(r2.sensor(sensor)["fit"].white, r1.sensor(sensor)["fit"].white)
        np.testing.assert_array_equal(r2.sensor(sensor)["deviation"].adev, r1.sensor(sensor)["deviation"].adev)
    assert "ran at" not in e2
    assert "gyroscope (Gyroscope25.csv) ran at 25 Hz" in e3 and y3["update_rate"] == 50
    assert y3["accelerometer_noise_density"] == y1["accelerometer_noise_density"]
    assert (
        main(["--quiet", "allan", str(acc), "--gyro", str(gyr), "--sensor", "gyro", "--out", str(tmp_path / "x.json")])
        == 2
    )
    assert "--sensor does not apply" in capsys.readouterr().err


def test_lost_samples_are_bridged_with_fill_gaps(tmp_path, capsys):
    """A static log with one garbled line (or a logger's dropped samples) had no way through: --skip-bad-lines left
    the line out and the timing check then refused the 2-step gap ("cut the log at the gap"). --fill-gaps bridges
    runs of up to 5 lost samples by linear interpolation, also across the blocks of a streamed read, with a note:
    the noise terms stay those of the clean log (N within 0.2 %, against its own 68 % interval of ±0.5 % on 18 000
    samples: 4 bridged samples carry no noise, 0.02 % of the variance); more than 0.1 % bridged is refused."""
    one = tmp_path / "one.csv"
    assert main(["--quiet", "simulate", "static", "--out", str(one), "--hours", "0.1", "--rate", "50",
                 "--gyro-rrw", "200", "--seed", "7"]) == 0  # fmt: skip
    lines = one.read_text().splitlines()
    body = [i for i, line in enumerate(lines) if not line.startswith("#")][1:]  # data rows after the header
    bad, dropped, many = (tmp_path / f"{n}.csv" for n in ("bad", "dropped", "many"))
    garbled = list(lines)
    garbled[body[5000]] = garbled[body[5000]].replace(",", ",x", 1)
    bad.write_text("\n".join(garbled) + "\n")
    gone = {body[i] for i in (8000, 8001, 8002, 12000)}
    dropped.write_text("\n".join(x for i, x in enumerate(lines) if i not in gone) + "\n")
    many.write_text("\n".join(x for i, x in enumerate(lines) if i not in set(body[1000:17000:100])) + "\n")

    def allan(path, *extra):
        out = tmp_path / f"{path.stem}{len(extra)}.json"
        rc = main(["--quiet", "allan", str(path), "--out", str(out), *extra])
        return rc, (Result.from_json(out) if rc == 0 else None), capsys.readouterr().err

    _, clean, _ = allan(one)
    rc, _, err = allan(bad, "--skip-bad-lines")
    assert rc == 2 and "--fill-gaps" in err
    for path, extra, lost in (
        (bad, ("--skip-bad-lines",), 1),
        (dropped, (), 4),
        (dropped, ("--chunk-rows", "8001"), 4),
    ):
        rc, res, err = allan(path, *extra, "--fill-gaps")
        assert rc == 0, err
        assert f"{lost} lost sample(s)" in err and "bridged by linear interpolation" in err
        for s in ("accelerometer", "gyroscope"):
            np.testing.assert_allclose(res.sensor(s)["fit"].white, clean.sensor(s)["fit"].white, rtol=2e-3)
    rc, _, err = allan(many, "--fill-gaps")
    assert rc == 2 and "more than --fill-gaps bridges" in err


def test_a_raw_static_log_gives_kalibr_noise_by_its_datasheet_sensitivity(tmp_path, capsys):
    """A static log in raw counts (an InvenSense-style ±16 g / ±2000 °/s part: 2048 per g, 16.4 per deg/s) was
    refused for --kalibr ("calibrate, then apply, then analyse"): with --acc-lsb/--gyro-lsb its counts are read in
    SI, and Kalibr's noise keys come from one command. The densities are the SI log's, the gyro's with the
    quantization of its 1/16.4 deg/s step added (σ = step/√12 per sample)."""
    si, raw = tmp_path / "si.csv", tmp_path / "raw.csv"
    argv = ["--quiet", "simulate", "static", "--out", str(si), "--hours", "0.1", "--seed", "1"]
    assert main(argv) == 0
    from optinav.io import read_imu

    log = read_imu(si)
    acc, gyr = np.round(log.acc / 9.80665 * 2048), np.round(np.degrees(log.gyr) * 16.4)
    np.savetxt(raw, np.column_stack([log.t, acc, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="",
               fmt=["%.6f"] + ["%d"] * 6)  # fmt: skip
    assert main(["allan", str(raw), "--out", str(tmp_path / "x.json"), "--kalibr", str(tmp_path / "x.yaml")]) == 2
    assert "--acc-lsb LSB_PER_G" in capsys.readouterr().err
    keys = []
    for data, extra in ((raw, ["--acc-lsb", "2048", "--gyro-lsb", "16.4"]), (si, [])):
        out = tmp_path / f"{data.stem}.yaml"
        assert main(["--quiet", "allan", str(data), *extra, "--out", str(tmp_path / f"{data.stem}.json"),
                     "--kalibr", str(out)]) == 0  # fmt: skip
        keys.append(yaml.safe_load(out.read_text()))
    err = capsys.readouterr().err
    assert "gyroscope counts read as rad/s by 16.4 per deg/s (a nominal sensitivity, no calibration)" in err
    k_raw, k_si = keys
    # the accelerometer's step (1/2048 g) is a tenth of its noise per sample: its density is the SI log's
    assert k_raw["accelerometer_noise_density"] == pytest.approx(k_si["accelerometer_noise_density"], rel=0.02)
    q = math.radians(1 / 16.4) / math.sqrt(12) * math.sqrt(0.01)  # the quantization's density at 100 Hz
    want = math.hypot(k_si["gyroscope_noise_density"], q)
    assert k_raw["gyroscope_noise_density"] == pytest.approx(want, rel=0.03)


def test_a_sensitivity_is_for_counts_only(tmp_path):
    """--acc-lsb beside a physical --acc-unit is refused in one line naming both flags."""
    f = tmp_path / "a.csv"
    np.savetxt(f, np.column_stack([np.arange(100) * 0.01, np.zeros((100, 2)), np.full(100, 1.0), np.zeros((100, 3))]),
               delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")  # fmt: skip
    from optinav.errors import OptinavError
    from optinav.io import read_imu

    with pytest.raises(OptinavError, match=r"acc_lsb \(--acc-lsb\) reads an accelerometer in raw counts, not one in g"):
        read_imu(f, acc_unit="g", acc_lsb=2048)


def _static_log(path, seconds, *, N=1e-3, K=2e-5, rate=100.0, seed=0):
    """A static log of white noise N and random walk K per gyro axis (rad/s; the accelerometer 10× both, m/s^2),
    as the adversarial review's logs; returns the truth in Kalibr's units."""
    rng = np.random.default_rng(seed)
    n, dt = int(round(seconds * rate)), 1.0 / rate

    def triad(n_, k_):
        return rng.standard_normal((n, 3)) * n_ / math.sqrt(dt) + np.cumsum(
            rng.standard_normal((n, 3)) * k_ * math.sqrt(dt), axis=0
        )

    acc = triad(10 * N, 10 * K) + [0.0, 0.0, 9.80665]
    _write_log(path, np.arange(n) * dt, acc, triad(N, K))
    return {"accelerometer": (10 * N, 10 * K), "gyroscope": (N, K)}


def _rw_lines(yml):
    return {k: line for line in yml.read_text().splitlines() for k in ("accelerometer", "gyroscope")
            if line.startswith(f"{k}_random_walk:")}  # fmt: skip


def test_a_random_walk_the_log_only_bounds_is_labelled_and_a_meaningless_bound_refused(tmp_path, capsys):
    """A 2-s log wrote accelerometer_random_walk 0.51 (2500× the truth), a 10-s one 75×, as "random walk K of the
    five-term Allan fit", exit 0: they were the upper ends of 68 % intervals. A bound over 1/s times the noise
    density (a MEMS's K is about 0.1/s times it) is refused, naming the length needed and --allow-rw-bound; a
    5-min log's bound (below it) is written and called a bound in the yaml and on the console; a random walk every
    axis shows is written as fitted."""
    for seconds in (2, 10):
        log = tmp_path / f"s{seconds}.csv"
        truth = _static_log(log, seconds)
        yml, out = tmp_path / f"s{seconds}.yaml", tmp_path / f"s{seconds}.json"
        assert main(["allan", str(log), "--out", str(out), "--kalibr", str(yml)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "random walk shows in this" in err and "--allow-rw-bound" in err, err
        assert re.search(r"record at least \d+ min at rest", err) and not yml.exists() and not out.exists()
        assert main(["allan", str(log), "--out", str(out), "--kalibr", str(yml), "--allow-rw-bound"]) == 0
        kal = yaml.safe_load(yml.read_text())
        for s, line in _rw_lines(yml).items():
            assert "upper bound" in line
            assert kal[f"{s}_random_walk"] > truth[s][1]  # a bound that holds the truth, far above it
        assert capsys.readouterr().err.count("is an upper bound, not a measurement") == 2
    log, yml = tmp_path / "m5.csv", tmp_path / "m5.yaml"
    truth = _static_log(log, 300)
    assert main(["allan", str(log), "--out", str(tmp_path / "m5.json"), "--kalibr", str(yml)]) == 0
    kal = yaml.safe_load(yml.read_text())
    for s, (N, K) in truth.items():
        assert "upper bound" in _rw_lines(yml)[s]
        assert K < kal[f"{s}_random_walk"] < N * 1.0 and kal[f"{s}_noise_density"] == pytest.approx(N, rel=0.05)
    assert capsys.readouterr().err.count("is an upper bound, not a measurement") == 2
    # where every axis shows its random walk (K / N = 0.5/s, 10 min) Kalibr gets the fitted K, no bound said
    log, yml = tmp_path / "k.csv", tmp_path / "k.yaml"
    truth = _static_log(log, 600, K=5e-4, seed=1)
    assert main(["allan", str(log), "--out", str(tmp_path / "k.json"), "--kalibr", str(yml)]) == 0
    assert "upper bound" not in yml.read_text() + capsys.readouterr().err
    kal = yaml.safe_load(yml.read_text())
    for s, (N, K) in truth.items():
        assert kal[f"{s}_random_walk"] == pytest.approx(K, rel=0.5)


def test_kalibr_random_walk_takes_one_rule_across_the_axes():
    """One axis's fitted K beside another's interval upper end: the largest of the mix was written (neither the
    largest K nor a bound on every axis). Unless every axis shows one, every axis's upper end is taken."""
    from types import SimpleNamespace

    from optinav.core.allan import kalibr_noise

    fit = SimpleNamespace(white=[1e-2] * 3, random_walk=[0.0, 0.0, 2.7e-4],
                          random_walk_interval=[[0.0, 0.0, 1e-4], [4.6e-4, 4.5e-4, 5.3e-4]])  # fmt: skip
    kal = kalibr_noise(fit, "accelerometer")
    assert kal["accelerometer_random_walk"] == 5.3e-4 and kal["accelerometer_random_walk_detected"] is False
    fit.random_walk = [1e-4, 2e-4, 2.7e-4]
    assert kalibr_noise(fit, "accelerometer")["accelerometer_random_walk"] == 2.7e-4


def test_a_noisy_gyro_declared_rad_s_is_analysed_with_a_note(tmp_path, capsys):
    """A gyro in rad/s with 0.005 rad/s/√Hz of white noise (beyond the MEMS check's 0.003) was refused even with
    --gyro-unit rad/s stated, told to declare deg/s: every number 57× too small. Stated, it runs with a note naming
    the density and gives N to its truth; not stated, the refusal names --gyro-unit rad/s as the way through."""
    log = tmp_path / "noisy.csv"
    truth = _static_log(log, 120, N=5e-3, K=0.0, seed=2)
    out = tmp_path / "a.json"
    assert main(["allan", str(log), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--gyro-unit rad/s if it is rad/s" in err, err
    assert main(["allan", str(log), "--gyro-unit", "rad/s", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("beyond any MEMS gyro") == 1 and "(--gyro-unit)" in err and "0.005" in err, err
    fit = Result.from_json(out).sensor("gyroscope")["fit"]
    np.testing.assert_allclose(fit.white, truth["gyroscope"][0], rtol=0.05)


def test_a_gap_longer_than_fill_gaps_bridges_names_the_limit(tmp_path, capsys):
    """7 samples lost in a row with --fill-gaps passed were told "pass --fill-gaps": the limit (5 in a row) and
    what to do beyond it are named; 5 in a row are bridged."""
    log = tmp_path / "s.csv"
    _static_log(log, 120, seed=3)
    lines = log.read_text().splitlines()
    for lost in (5, 7):
        cut = tmp_path / f"drop{lost}.csv"
        cut.write_text("\n".join(lines[:5001] + lines[5001 + lost :]) + "\n")
        rc = main(["allan", str(cut), "--out", str(tmp_path / f"d{lost}.json"), "--fill-gaps"])
        err = capsys.readouterr().err
        if lost == 5:
            assert rc == 0 and "5 lost sample(s) in 1 gap(s)" in err, err
            continue
        assert rc == 2 and err.count("\n") == 1, err
        assert "7 samples are lost in a row after t = 49.99 s: --fill-gaps bridges at most 5" in err, err
        assert "pass --fill-gaps" not in err and "cut the log at the gap" in err
