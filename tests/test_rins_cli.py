"""`optinav simulate rins` → `optinav calibrate rins` end to end: angles vs truth within the reported std."""

import json

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.results import Truth
from optinav.rins.calibrate import RinsCalibration

ARGS = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "100"]


@pytest.mark.parametrize("suffix,unit", [(".npz", "rad"), (".csv", "deg")])
def test_simulate_calibrate_round_trip(tmp_path, suffix, unit, capsys):
    p = np.array([1.0, -2.0, 3.0, -1.0, 2.0, 4.0]) * 1e-4
    text = ",".join(f"{x:.10g}" for x in (np.degrees(p) if unit == "deg" else p))
    data = tmp_path / f"r{suffix}"
    assert (
        main(
            ["--quiet", "simulate", "rins", "--nonorth", text, "--unit", unit, "--seed", "4", "--out", str(data), *ARGS]
        )
        == 0
    )
    truth = json.loads((tmp_path / "r.truth.json").read_text())
    np.testing.assert_allclose(list(truth["angles"].values()), p, rtol=1e-9)
    out = tmp_path / "res.json"
    rep = tmp_path / "rep"
    assert main(["--quiet", "calibrate", "rins", str(data), "--out", str(out), "--report", str(rep)]) == 0
    raw = json.loads(out.read_text())
    assert raw["schema"] == "optinav.rins.calibration" and raw["method"] == "lm" and raw["elapsed_s"] > 0
    assert raw["convergence"]["converged"] is True and all(g["passed"] for g in raw["quality_gates"])
    par = raw["parameters"]
    assert set(par) == {"theta_x", "theta_y", "theta_z", "eta_x", "eta_y", "eta_z", "theta_z + eta_z"}
    for nm in ("eta_y", "theta_z", "eta_z"):
        assert par[nm]["value"] is None and not par[nm]["observable"] and nm in par[nm]["reason"]
    res = RinsCalibration.from_json(out)
    assert res.observability["rank"] == 4 and len(res.observability["null_space"]) == 2
    # truth in the estimated parameterization (the combination included), compared field by field
    cmp = Truth.from_json(tmp_path / "r.truth.json").compare(res)
    assert sorted(cmp) == ["eta_x", "theta_x", "theta_y", "theta_z + eta_z"]
    assert all(float(c["z"]) < 4 for c in cmp.values()), cmp
    assert abs(par["theta_z + eta_z"]["value"] - (p[2] + p[5])) < 4 * par["theta_z + eta_z"]["std"]
    assert all(a < b for a, b in zip(res.rmse_after_deg, res.rmse_before_deg))
    assert (rep / "index.md").is_file()


def test_cli_errors_are_one_line(tmp_path, capsys):
    data = tmp_path / "s.npz"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "rins",
                "--nonorth",
                "1e-4,0,0,0,0,0",
                "--scheme",
                "single4",
                "--align",
                "30",
                "--dwell",
                "5",
                "--move",
                "4",
                "--rate",
                "50",
                "--out",
                str(data),
            ]
        )
        == 0
    )
    assert main(["--quiet", "calibrate", "rins", str(data), "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "only the inner (alpha) axis turns" in err and "Traceback" not in err
    assert main(["--quiet", "simulate", "rins", "--nonorth", "1,2,3", "--out", str(data)]) == 2
    assert main(["--quiet", "calibrate", "rins", str(tmp_path / "none.npz"), "--out", str(tmp_path / "r.json")]) == 2


def test_report_reads_the_data_at_the_calibrations_latitude(tmp_path, capsys):
    """A logger's file states no latitude: calibrate needs --lat, and then `optinav report RESULT --data FILE`
    ended in 'does not state the latitude; pass --lat DEG', a flag report does not have. The result keeps the
    site and alignment window it was calibrated with, and the report reads the recording with them."""
    data = tmp_path / "r.csv"
    assert (
        main(
            ["--quiet", "simulate", "rins", "--nonorth=1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4", "--lat", "-33.5"]
            + ["--seed", "4", "--out", str(data), *ARGS]
        )
        == 0
    )
    logger = tmp_path / "logger.csv"
    logger.write_text("".join(x for x in data.read_text().splitlines(True) if "lat_deg" not in x))
    out = tmp_path / "res.json"
    assert main(["--quiet", "calibrate", "rins", str(logger), "--out", str(out)]) == 2
    assert "pass --lat" in capsys.readouterr().err
    args = ["--quiet", "calibrate", "rins", str(logger), "--lat", "-33.5", "--align", "50", "--out", str(out)]
    assert main(args) == 0
    res = RinsCalibration.from_json(out)
    assert res.lat_deg == -33.5 and res.align_s == 50
    capsys.readouterr()
    assert main(["--quiet", "report", str(out), "--data", str(logger), "--out", str(tmp_path / "rep")]) == 0, (
        capsys.readouterr().err
    )
    assert (tmp_path / "rep" / "attitude_error.png").is_file()


def test_report_refuses_the_recording_of_another_session(tmp_path, capsys):
    """`optinav report RESULT --data OTHER` drew the attitude-change figure of another session beside the result's
    numbers, exit 0. The recording's uncompensated attitude change must be the result's rmse_before_deg."""
    runs = {}
    for name, nonorth in (("a", "1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4"), ("b", "2e-3,1e-3,-3e-3,1e-3,-2e-3,4e-3")):
        data = tmp_path / f"{name}.csv"
        sim = ["--quiet", "simulate", "rins", f"--nonorth={nonorth}", "--seed", "4", "--out", str(data), *ARGS]
        assert main(sim) == 0
        out = tmp_path / f"{name}.json"
        assert main(["--quiet", "calibrate", "rins", str(data), "--residual-rate", "4", "--out", str(out)]) == 0
        runs[name] = (data, out)
    capsys.readouterr()
    assert (
        main(["--quiet", "report", str(runs["a"][1]), "--data", str(runs["a"][0]), "--out", str(tmp_path / "ok")]) == 0
    )
    assert (
        main(["--quiet", "report", str(runs["a"][1]), "--data", str(runs["b"][0]), "--out", str(tmp_path / "x")]) == 2
    )
    err = capsys.readouterr().err
    assert "not the recording it was calibrated from" in err and not (tmp_path / "x").exists()


def test_the_gyro_error_assumption_of_the_std_is_a_flag(tmp_path, capsys):
    """An IMU whose gyro triad is worse than the 'rlg-nav' preset (60″ misalignment, 50 ppm scale) got std from the
    preset's 5″ / 2 ppm, exit 0, with θz + ηz 5.4 std off the truth, and no word of the assumption and no way to
    change it. --gyro-misalignment-arcsec / --gyro-scale-ppm set it; the summary states it."""
    data = tmp_path / "r.npz"
    sim = ["--quiet", "simulate", "rins", "--nonorth=1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4", "--seed", "4"]
    gyro = ["--gyro-misalignment-arcsec", "60", "--gyro-scale-ppm", "50"]
    assert main([*sim, *gyro, "--out", str(data), *ARGS]) == 0
    std = {}
    for name, extra in (("preset", []), ("given", gyro)):
        out = tmp_path / f"{name}.json"
        capsys.readouterr()
        assert main(["calibrate", "rins", str(data), *extra, "--out", str(out)]) == 0
        text = capsys.readouterr().out
        res = RinsCalibration.from_json(out)
        std[name] = np.array([c["std"] for c in res.combinations])
        want = "60″ misalignment and 50 ppm" if extra else "5″ misalignment and 2 ppm"
        assert f"std include the gyro triad's uncalibrated errors at 1σ {want}" in text
    cmp = Truth.from_json(tmp_path / "r.truth.json").compare(RinsCalibration.from_json(tmp_path / "given.json"))
    assert all(float(c["z"]) < 4 for c in cmp.values()), cmp
    assert np.all(std["given"] > 3 * std["preset"])
