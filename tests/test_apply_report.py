"""`optinav apply` and `optinav report` for every system through the registry: the result file's schema picks the
system; the applied output is compared with the simulated truth, the report's numbers with the result."""

import json

import numpy as np
import pytest

from optinav import registry
from optinav.cli.main import main
from optinav.gfimu.array import builtin
from optinav.gfimu.errors import InstallationErrors, perturb, spinning_motion
from optinav.gfimu.solve import solve_motion
from optinav.gfimu.turntable import TurntableCalibration
from optinav.rins.calibrate import RinsCalibration
from optinav.rins.model import attitude_change, euler_rpy
from optinav.rins.unit import compensated_attitude

RINS_ARGS = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "50"]
#: the accelerometer noise of the gfimu simulations (the paper's 1 µg, m/s²)
SIGMA = 1e-6 * 9.80665


@pytest.fixture(scope="module")
def rins(tmp_path_factory):
    d = tmp_path_factory.mktemp("rins")
    data, res = d / "r.npz", d / "r.json"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "rins",
                "--nonorth=1e-4,-2e-4,3e-4,-1e-4,2e-4,4e-4",
                "--seed",
                "4",
                "--out",
                str(data),
                *RINS_ARGS,
            ]
        )
        == 0
    )
    assert main(["--quiet", "calibrate", "rins", str(data), "--out", str(res)]) == 0
    return d, data, res


@pytest.fixture(scope="module")
def gfimu(tmp_path_factory):
    d = tmp_path_factory.mktemp("gfimu")
    data, res = d / "t.npz", d / "t.json"
    assert (
        main(["--quiet", "simulate", "gfimu-turntable", "--builtin", "cylinder10", "--seed", "1", "--out", str(data)])
        == 0
    )
    argv = ["--quiet", "calibrate", "gfimu", str(data), "--builtin", "cylinder10", "--offset", "zero"]
    assert main([*argv, "--out", str(res)]) == 0  # centred, simulated: the calibrated positions are absolute
    return d, data, res


def _attitude_change_rms(C_b_n) -> np.ndarray:
    """RMS (rad) per [roll, pitch, yaw] of the attitude change from the first epoch: the error on a static base."""
    return np.sqrt(np.mean(euler_rpy(attitude_change(C_b_n))[1:] ** 2, axis=0))


def test_rins_calibrate_goes_through_run_unit(rins):
    """`optinav calibrate rins` writes what the registry's run_unit computes (the batch's per-unit path)."""
    d, data, out = rins
    system = registry.SYSTEMS["rins"]
    ref, _ = system.load("run_unit")(data, system.load("options")())
    got = json.loads(out.read_text())["fields"]
    for name, entry in json.loads(ref.to_json())["fields"].items():
        if name != "elapsed_s":
            assert got[name] == entry, name


def test_gfimu_calibrate_goes_through_run_unit(gfimu):
    d, data, out = gfimu
    system = registry.SYSTEMS["gfimu"]
    ref, _ = system.load("run_unit")(data, system.load("options")(builtin="cylinder10", offset="zero"))
    got = json.loads(out.read_text())["fields"]
    for name, entry in json.loads(ref.to_json())["fields"].items():
        if name != "elapsed_s":
            assert got[name] == entry, name


def test_apply_rins_compensates_the_vehicle_attitude(rins, capsys):
    """On a static base the true vehicle attitude is constant: what the compensated attitude still changes is
    the noise the calibration left (its rmse_after, measured on the same data at 10 Hz), while the uncompensated
    one carries the non-orthogonality."""
    d, data, result = rins
    out = d / "att.csv"
    assert main(["--quiet", "apply", str(result), str(data), "--out", str(out)]) == 0
    assert "gimbal non-orthogonality of lm compensated" in capsys.readouterr().out
    tab = np.loadtxt(out, delimiter=",", skiprows=1)
    from optinav.core.rotations import dcm_from_quat, euler_from_quat

    C = dcm_from_quat(tab[:, 1:5])
    np.testing.assert_allclose(np.degrees(euler_from_quat(tab[:, 1:5], "enu")), tab[:, 5:8], atol=1e-8)
    res = RinsCalibration.from_json(result)
    applied = np.degrees(_attitude_change_rms(C))
    raw = np.degrees(_attitude_change_rms(compensated_attitude(np.zeros(6), data)[1]))
    noise = np.asarray(res.rmse_after_deg)
    assert np.all(applied < 1.5 * noise + 1e-5), (applied, noise)
    assert max(raw) > 10 * max(applied), (raw, applied)
    # an option of another system's results, or an output format this one does not write: one line, no output
    for extra, why in (
        (["--omega0", "1,2,3"], "--omega0 is for gfimu results"),
        (["--columns", "t,ax,ay,az"], "--columns is for accel results"),
    ):
        assert main(["--quiet", "apply", str(result), str(data), *extra, "--out", str(d / "x.csv")]) == 2
        assert why in capsys.readouterr().err
    assert main(["--quiet", "apply", str(result), str(data), "--out", str(d / "x.npz")]) == 2
    assert "output is a CSV table" in capsys.readouterr().err
    assert not (d / "x.csv").exists() and not (d / "x.npz").exists()


def test_apply_gfimu_solves_with_the_calibrated_geometry(gfimu, capsys):
    """A spinning array with the paper's installation errors: the motion solved with the calibrated geometry is
    as close to the truth as with the true geometry (the noise floor) up to the calibration's own error, and far
    closer than with the nominal one."""
    d, data, result = gfimu
    nominal = builtin("cylinder10")
    actual = perturb(nominal, InstallationErrors.uniform(nominal.n))
    m = spinning_motion(duration=20.0, dt=0.01)
    f = actual.outputs(m.A, m.wdot, m.omega) + np.random.default_rng(0).normal(0.0, SIGMA, (m.t.size, nominal.n))
    log = d / "motion.csv"
    np.savetxt(
        log,
        np.column_stack([m.t, f]),
        delimiter=",",
        comments="",
        header="t," + ",".join(f"f{i + 1}" for i in range(nominal.n)),
    )
    out = d / "motion_out.csv"
    w0 = ",".join(f"{v:.17g}" for v in m.omega[0])
    assert main(["--quiet", "apply", str(result), str(log), "--omega0", w0, "--out", str(out)]) == 0
    tab = np.loadtxt(out, delimiter=",", skiprows=1)
    res = TurntableCalibration.from_json(result)
    # the relative calibration error left: the installation-error part of the motion error shrinks by it
    left = float(np.max(np.asarray(res.std) / np.abs(np.asarray(res.estimate))))
    rms = lambda e: float(np.sqrt(np.mean(e**2)))  # noqa: E731
    floor = solve_motion(actual.with_geometry(actual.positions, actual.directions), f, m.t, m.omega[0])
    raw = solve_motion(nominal, f, m.t, m.omega[0])
    for k, (name, truth) in enumerate((("A", m.A), ("omega", m.omega), ("wdot", m.wdot))):
        applied = rms(tab[:, 1 + 3 * k : 4 + 3 * k] - truth)
        best = rms(getattr(floor, name) - truth)
        uncompensated = rms(getattr(raw, name) - truth)
        assert applied < best + 5 * left * uncompensated, (name, applied, best, left, uncompensated)
        assert applied < uncompensated / 100, (name, applied, uncompensated)
    capsys.readouterr()
    assert main(["--quiet", "apply", str(result), str(log), "--rate-method", "bogus", "--out", str(d / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--rate-method one of integration" in err and not (d / "x.csv").exists()


@pytest.mark.parametrize("method", ["integration", "gauss-newton"])
def test_apply_gfimu_in_blocks_equals_the_whole_log(gfimu, monkeypatch, method):
    """optinav apply reads, solves and writes a gfimu log in blocks (here of 7 rows): its table is the
    whole-array solve_motion with the calibrated geometry, to the CSV's 12 digits."""
    import optinav.io.readers

    d, _, result = gfimu
    res = TurntableCalibration.from_json(result)
    arr = res.calibrated_array()
    m = spinning_motion(duration=1.0, dt=0.01)
    f = arr.outputs(m.A, m.wdot, m.omega) + np.random.default_rng(1).normal(0.0, SIGMA, (m.t.size, arr.n))
    log = d / "blocks.csv"
    header = "t," + ",".join(f"f{i + 1}" for i in range(arr.n))
    np.savetxt(log, np.column_stack([m.t, f]), delimiter=",", comments="", header=header, fmt="%.17g")
    monkeypatch.setattr(optinav.io.readers, "CHUNK_ROWS", 7)
    out = d / f"blocks_{method}.csv"
    w0 = ",".join(f"{v:.17g}" for v in m.omega[0])
    argv = ["--quiet", "apply", str(result), str(log), "--omega0", w0, "--rate-method", method, "--out", str(out)]
    assert main(argv) == 0
    tab = np.loadtxt(out, delimiter=",", skiprows=1)
    whole = solve_motion(arr, f, m.t, m.omega[0], method)
    ref = np.column_stack([whole.t, whole.A, whole.omega, whole.wdot])
    assert tab.shape == ref.shape == (101, 10)
    np.testing.assert_allclose(tab, ref, rtol=1e-11, atol=1e-13)
    # a log of one sample has no rate to integrate: one line, no output
    np.savetxt(log, np.column_stack([m.t[:1], f[:1]]), delimiter=",", comments="", header=header, fmt="%.17g")
    assert main([*argv[:-1], str(d / "one.csv")]) == 2
    assert not (d / "one.csv").exists()


@pytest.fixture(scope="module")
def attitude(tmp_path_factory):
    """A static flight and the iframe estimate of it as a result file (optinav.attitude.estimate)."""
    from optinav.attitude import estimate
    from optinav.attitude.unit import AttitudeOptions, read_log

    d = tmp_path_factory.mktemp("att")
    data = d / "f.csv"
    assert (
        main(
            ["--quiet", "simulate", "flight", "--kind", "static", "--duration", "10", "--seed", "1", "--out", str(data)]
        )
        == 0
    )
    t, gyr, acc, _, _ = read_log(data, AttitudeOptions())
    res = estimate(gyr, acc, np.diff(t, prepend=t[0] - (t[1] - t[0])))
    out = d / "est.json"
    res.to_json(out)
    return d, data, out


def test_apply_says_an_attitude_estimate_has_nothing_to_apply(attitude, capsys):
    d, data, result = attitude
    assert main(["--quiet", "apply", str(result), str(data), "--out", str(d / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "attitude estimate" in err and "nothing to apply" in err
    assert not (d / "x.csv").exists()
    # its report needs the log's time stamps: a one-line error, and no folder left behind (nor its parents)
    for rep in (d / "rep", d / "new" / "deeper" / "rep", d / "rep.md"):
        assert main(["--quiet", "report", str(result), "--out", str(rep)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "pass the log it came from with --data" in err
        assert not rep.exists() and not (d / "new").exists() and not (d / "rep_files").exists()


def test_a_failed_report_leaves_nothing_behind(gfimu, attitude, capsys):
    """Two results, the second's --data a log of another length: the first report was written, then the second
    failed; neither sub-folder, nor the Markdown file, stays. A --report folder is made only when the report
    is written, so a command that fails after checking it leaves none."""
    d, _, result = gfimu
    da, data, est = attitude
    short = da / "short.csv"
    short.write_text("\n".join(data.read_text().splitlines()[:200]) + "\n")
    for out, made in ((d / "two", d / "two"), (d / "two.md", d / "two_files")):
        assert (
            main(
                [
                    "--quiet",
                    "report",
                    str(result),
                    str(est),
                    "--data",
                    str(d / "t.npz"),
                    "--data",
                    str(short),
                    "--out",
                    str(out),
                ]
            )
            == 2
        )
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "samples, the estimate" in err
        assert not out.exists() and not made.exists()
    # an existing --out folder stays, without the sub-folders this run made
    (d / "kept").mkdir()
    assert (
        main(
            [
                "--quiet",
                "report",
                str(result),
                str(est),
                "--data",
                str(d / "t.npz"),
                "--data",
                str(short),
                "--out",
                str(d / "kept"),
            ]
        )
        == 2
    )
    capsys.readouterr()
    assert (d / "kept").is_dir() and not any((d / "kept").iterdir())
    # calibrate/attitude --report: checked first, made only with the report
    rep = da / "att_rep"
    bare = da / "bare.csv"  # the flight without its STEM.truth.csv: no reference to score against
    bare.write_text(data.read_text())
    assert (
        main(["--quiet", "attitude", str(bare), "--reference", "--out", str(da / "att.csv"), "--report", str(rep)]) == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "truth" in err and not rep.exists() and not (da / "att.csv").exists(), err
    (da / "a_file").write_text("x")
    assert (
        main(["--quiet", "attitude", str(data), "--out", str(da / "att.csv"), "--report", str(da / "a_file" / "rep")])
        == 2
    )
    assert "is a file" in capsys.readouterr().err


def _table(summary: dict, title_start: str) -> list:
    study = next(iter(summary["studies"].values()))
    return next(t for t in study["tables"] if t["title"].startswith(title_start))["rows"]


def test_report_rins_numbers_match_the_result(rins, capsys):
    d, data, result = rins
    res = RinsCalibration.from_json(result)
    assert main(["--quiet", "report", str(result), "--data", str(data), "--out", str(d / "rep")]) == 0
    rows = {r[0]: r[1:] for r in _table(json.loads((d / "rep" / "summary.json").read_text()), "Angles")}
    for nm, v in res.angles.items():
        assert rows[nm][0] == v and rows[nm][1] == res.angles_std.get(nm)
    md = (d / "rep" / "index.md").read_text()
    assert f"| theta_x | {res.angles['theta_x']:.6e} | {res.angles_std['theta_x']:.2e} |" in md
    assert f"{res.rmse_after_deg[2]:.4g}" in md
    assert (d / "rep" / "attitude_error.png").stat().st_size > 0 and (d / "rep" / "rins_angles.png").is_file()


def test_report_gfimu_and_attitude_into_one_markdown_file(gfimu, attitude, capsys):
    d, _, result = gfimu
    da, data, est = attitude
    out = d / "both.md"
    assert (
        main(
            [
                "--quiet",
                "report",
                str(result),
                str(est),
                "--data",
                str(d / "t.npz"),
                "--data",
                str(data),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    md = out.read_text()
    res = TurntableCalibration.from_json(result)
    k = res.names.index("dr_x_1")
    assert f"{res.estimate[k] * 1e3:+.4f} ± {res.std[k] * 1e3:.2g} (CRLB {res.crlb_std[k] * 1e3:.2g})" in md
    assert "](both_files/t/installation_errors.png)" in md and "](both_files/est/attitude_euler.png)" in md
    assert (d / "both_files" / "t" / "installation_errors.png").is_file()
    cells = _table(json.loads((d / "both_files" / "t" / "summary.json").read_text()), "Installation")
    assert cells[0][1] == {"value": res.estimate[k] * 1e3, "std": res.std[k] * 1e3, "crlb": res.crlb_std[k] * 1e3}
    from optinav.attitude.estimators import AttitudeEstimate

    assert f"| samples | {len(AttitudeEstimate.from_json(est).q_b_n)} |" in md  # the attitude estimate's section


def test_report_multipos_without_data_and_errors(tmp_path, capsys):
    """A multipos result alone (no recording): its parameter tables; a wrong number of --data is one line."""
    from optinav.multipos.result import CalibrationResult

    res = CalibrationResult(
        accelerometer={
            "K": np.diag([1.01, 0.99, 1.0]),
            "b": np.array([0.1, -0.2, 0.05]),
            "K_std": np.full((3, 3), 1e-4),
            "b_std": np.full(3, 1e-3),
        },
        units={"accelerometer_raw": "m/s^2"},
        method="lm",
        source="x.csv",
    )
    path = tmp_path / "r.json"
    res.to_json(path)
    assert main(["--quiet", "report", str(path), "--out", str(tmp_path / "rep")]) == 0
    md = (tmp_path / "rep" / "index.md").read_text()
    assert "| row x | 1.01 ± 0.0001 | 0 ± 0.0001 | 0 ± 0.0001 | 0.1 ± 0.001 |" in md
    assert main(["--quiet", "report", str(path), "--data", "a", "--data", "b", "--out", str(tmp_path / "r2")]) == 2
    assert "--data" in capsys.readouterr().err


def test_apply_gfimu_reads_the_unit_in_the_time_columns_name(gfimu, capsys):
    """A log's time column 't [ms]' or 't_us' said 'has no time column t; add a column t in s', and a plain t in ms
    said the rate solution 'diverges at t = 120 s … check the output columns and --omega0': the unit in the name
    is converted (the same table as in s) and the divergence names the time unit."""
    d, _, result = gfimu
    nominal = builtin("cylinder10")
    m = spinning_motion(duration=2.0, dt=0.01)
    f = perturb(nominal, InstallationErrors.uniform(nominal.n)).outputs(m.A, m.wdot, m.omega)
    w0 = ",".join(f"{v:.17g}" for v in m.omega[0])
    tables = []
    for name, scale in (("t", 1.0), ("t [ms]", 1e3), ("t_us", 1e6)):
        log, out = d / "units.csv", d / f"units_{scale:g}.csv"
        header = f"{name}," + ",".join(f"f{i + 1}" for i in range(nominal.n))
        np.savetxt(log, np.column_stack([m.t * scale, f]), delimiter=",", comments="", header=header, fmt="%.17g")
        assert main(["--quiet", "apply", str(result), str(log), "--omega0", w0, "--out", str(out)]) == 0
        tables.append(np.loadtxt(out, delimiter=",", skiprows=1))
    np.testing.assert_allclose(tables[1], tables[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(tables[2], tables[0], rtol=1e-9, atol=1e-9)
    capsys.readouterr()
    header = "t," + ",".join(f"f{i + 1}" for i in range(nominal.n))
    np.savetxt(log, np.column_stack([m.t * 1e3, f]), delimiter=",", comments="", header=header, fmt="%.17g")
    assert main(["--quiet", "apply", str(result), str(log), "--omega0", w0, "--out", str(d / "x.csv")]) == 2
    assert "that t is in seconds (or its name gives the unit: t [ms])" in capsys.readouterr().err


def test_apply_gfimu_replaces_its_own_output_but_not_a_log(gfimu, capsys):
    """Running `optinav apply` of a gfimu (or rins) result again with the same --out said '--out … exists and is
    not a file this command writes (it begins 't,ax,ay,az,gx,…')' — its own table: only the multi-position output
    carried the mark the check looks for. The system's table header is recognized; a data log is still kept."""
    d, _, result = gfimu
    nominal = builtin("cylinder10")
    m = spinning_motion(duration=1.0, dt=0.01)
    f = perturb(nominal, InstallationErrors.uniform(nominal.n)).outputs(m.A, m.wdot, m.omega)
    log, out = d / "again.csv", d / "again_out.csv"
    header = "t," + ",".join(f"f{i + 1}" for i in range(nominal.n))
    np.savetxt(log, np.column_stack([m.t, f]), delimiter=",", comments="", header=header, fmt="%.17g")
    w0 = ",".join(f"{v:.17g}" for v in m.omega[0])
    for _ in range(2):
        assert main(["--quiet", "apply", str(result), str(log), "--omega0", w0, "--out", str(out)]) == 0
    other = d / "other_log.csv"
    other.write_bytes(log.read_bytes())
    capsys.readouterr()
    assert main(["--quiet", "apply", str(result), str(log), "--omega0", w0, "--out", str(other)]) == 2
    assert "is not a file this command writes" in capsys.readouterr().err
    assert other.read_bytes() == log.read_bytes()


def test_report_gfimu_refuses_data_it_was_not_calibrated_from(gfimu, rins, capsys):
    """`optinav report GFIMU_RESULT --data X` wrote a report titled 'from X' for any file, a rotational-INS
    recording included (exit 0): the data must be turntable data of the array with the result's samples per case,
    whose case means the calibrated geometry predicts as well as the calibration's own residual (another unit's
    data with the same cases passed)."""
    d, data, result = gfimu
    other = d / "short.npz"
    argv = ["--quiet", "simulate", "gfimu-turntable", "--builtin", "cylinder10", "--duration", "0.5", "--out"]
    assert main([*argv, str(other)]) == 0
    assert main(["--quiet", "report", str(result), "--data", str(data), "--out", str(d / "rep_ok")]) == 0
    # another unit (installation errors drawn, seed 2) with the same cases: titled the source of the result's errors
    unit2 = d / "unit2.npz"
    argv = ["--quiet", "simulate", "gfimu-turntable", "--builtin", "cylinder10", "--errors", "random", "--seed", "2"]
    assert main([*argv, "--out", str(unit2)]) == 0
    for bad, why in ((other, "samples per case"), (rins[1], "has no mounting"), (unit2, "the result's geometry")):
        capsys.readouterr()
        assert main(["--quiet", "report", str(result), "--data", str(bad), "--out", str(d / "rep_bad")]) == 2
        assert why in capsys.readouterr().err and not (d / "rep_bad").exists()
