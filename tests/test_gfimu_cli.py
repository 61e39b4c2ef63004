"""CLI: `optinav gfimu analyze`, `simulate gfimu-turntable`, `calibrate gfimu`."""

import json

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.gfimu import builtin


def test_analyze_builtin_and_config(tmp_path, capsys, cube):
    out = tmp_path / "a.json"
    assert main(["gfimu", "analyze", "--builtin", "cylinder10", "--out", str(out)]) == 0
    a = json.loads(out.read_text())
    assert (a["n_accelerometers"], a["rank_linear"], a["rank_full"], a["n_quadratic_observable"]) == (10, 6, 10, 4)
    assert a["solvable_without_rate"] == ["A_x", "A_y", "A_z", "wdot_x", "wdot_y", "wdot_z"]
    # six tangential accelerometers on the axes: [A, ω̇] solvable only with the rate known
    assert main(["gfimu", "analyze", str(cube), "--out", str(out)]) == 0
    a = json.loads(out.read_text())
    assert a["n_accelerometers"] == 6 and a["rank_linear"] == 6 and a["rank_full"] == 6
    assert a["n_quadratic_observable"] == 0
    assert a["solvable_without_rate"] == [] and a["rank_quadratic"] == 3


def test_rank_deficient_and_malformed(tmp_path, capsys):
    p = tmp_path / "radial.json"
    p.write_text(
        json.dumps(
            {
                "accelerometers": [
                    {
                        "position": [0.05 * s * (k == j) for j in range(3)],
                        "direction": [1.0 * (k == j) for j in range(3)],
                    }
                    for s in (1, -1)
                    for k in range(3)
                ]
            }
        )
    )
    assert main(["gfimu", "analyze", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "rank deficient" in err and "wdot_x, wdot_y, wdot_z" in err
    assert main(["gfimu", "analyze", str(p), "--allow-deficient", "--out", str(tmp_path / "x.json")]) == 0
    for cfg, msg in (
        ({"accelerometers": [{"position": [0, 0, 0], "direction": [0, 0, 0]}]}, "direction is zero"),
        ({"accelerometers": [{"position": [0, 0, 0, 1], "direction": [1, 0, 0]}]}, "not 3 numbers"),
        ({"accelerometers": [{"position": [0, 0, 0], "direction": [2, 0, 0]}]}, "not 1"),
    ):
        p.write_text(json.dumps(cfg))
        assert main(["gfimu", "analyze", str(p)]) == 2
        err = capsys.readouterr().err.strip()
        assert msg in err and err.count("\n") == 0
    assert main(["gfimu", "analyze", str(tmp_path / "none.json")]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_simulate_calibrate_recovers_truth(tmp_path, capsys, suffix):
    cfg = tmp_path / "c.json"
    builtin().save(cfg)
    data = tmp_path / f"tt{suffix}"
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "gfimu-turntable",
                "--config",
                str(cfg),
                "--errors",
                "random",
                "--duration",
                "2",
                "--out",
                str(data),
                "--seed",
                "4",
            ]
        )
        == 0
    )
    truth = json.loads((tmp_path / "tt.truth.json").read_text())
    out = tmp_path / "r.json"
    # simulated on the table axis: --offset zero says so, and the absolute Δr are the truth's
    argv = ["--quiet", "calibrate", "gfimu", str(data), "--config", str(cfg), "--out", str(out)]
    assert main([*argv, "--offset", "zero"]) == 0
    r = json.loads(out.read_text())["fields"]
    est = np.array(r["estimate"]["value"])
    std = np.array(r["std"]["value"])
    tv = np.array(list(truth["coefficients"].values()))
    assert est.shape == (50,)
    assert np.abs((est - tv) / std).max() < 4.5
    # by default the offset is unknown: Δr relative to their mean, named so, as the truth file names them
    assert main(argv) == 0
    pars = json.loads(out.read_text())["parameters"]
    assert pars["dr_x_1"]["value"] is None and pars["mean(dr_x)"]["value"] is None
    z = [
        (p["value"] - truth["parameters"][nm]["value"]) / p["std"]
        for nm, p in pars.items()
        if p["value"] is not None and nm in truth["parameters"]
    ]
    assert len(z) == 50 and np.abs(z).max() < 4.5
    if suffix == ".npz":  # the report: every coefficient with its std, and the figure
        rep = tmp_path / "rep"
        assert (
            main(
                [
                    "--quiet",
                    "calibrate",
                    "gfimu",
                    str(data),
                    "--config",
                    str(cfg),
                    "--out",
                    str(out),
                    "--report",
                    str(rep),
                ]
            )
            == 0
        )
        md = (rep / "index.md").read_text()
        assert md.count("CRLB") >= 50 and "installation_errors.png" in md


def test_calibrate_errors(tmp_path, capsys):
    data = tmp_path / "tt.npz"
    assert main(["--quiet", "simulate", "gfimu-turntable", "--duration", "0.5", "--out", str(data)]) == 0
    cfg = tmp_path / "six.json"
    a = builtin()
    a.with_geometry(a.positions[:6], a.directions[:6]).save(cfg)
    assert main(["calibrate", "gfimu", str(data), "--config", str(cfg), "--out", str(tmp_path / "r.json")]) == 2
    assert "10 accelerometer columns, the configuration 6" in capsys.readouterr().err
    assert (
        main(
            [
                "calibrate",
                "gfimu",
                str(data),
                "--builtin",
                "cylinder10",
                "--offset",
                "estimate",
                "--out",
                str(tmp_path / "r.json"),
            ]
        )
        == 2
    )
    assert "cannot be separated" in capsys.readouterr().err
    assert main(["calibrate", "gfimu", str(data), "--builtin", "cylinder10", "--out", str(tmp_path / "r.txt")]) == 2


def _simulate_argv(data, *extra):
    return ["--quiet", "simulate", "gfimu-turntable", "--errors", "random", "--duration", "2", "--seed", "4", *extra]


def test_simulate_csv_in_blocks_is_the_library_data(tmp_path, monkeypatch):
    """The CLI streams the CSV in blocks (here 7 of 250 rows, the last short): the bytes TurntableData.save writes
    for the library's simulation with the same seed, read back by calibrate gfimu, which recovers the truth."""
    from optinav.gfimu import InstallationErrors, simulate, turntable

    monkeypatch.setattr(turntable, "BLOCK_ROWS", 250)
    data = tmp_path / "tt.csv"
    assert main([*_simulate_argv(data), "--out", str(data)]) == 0
    arr = builtin()
    e = InstallationErrors.random(10, rng=5)
    ref = simulate(arr, e, rates=(0.5, 1.0), duration=2.0, rng=4)
    assert len(ref.t) == 1200
    ref.save(tmp_path / "ref.csv")
    assert data.read_bytes() == (tmp_path / "ref.csv").read_bytes()
    truth = json.loads((tmp_path / "tt.truth.json").read_text())
    tv = np.array(list(truth["coefficients"].values()))
    np.testing.assert_array_equal(tv, e.vector())
    assert truth["samples_per_case"] == 200
    out = tmp_path / "r.json"
    argv = ["--quiet", "calibrate", "gfimu", str(data), "--builtin", "cylinder10", "--offset", "zero"]
    assert main([*argv, "--out", str(out)]) == 0
    r = json.loads(out.read_text())["fields"]
    est, std = np.array(r["estimate"]["value"]), np.array(r["std"]["value"])
    assert np.abs((est - tv) / std).max() < 4.5
    # the NPZ gathers the same blocks
    assert main([*_simulate_argv(data), "--out", str(tmp_path / "tt.npz")]) == 0
    with np.load(tmp_path / "tt.npz") as z:
        np.testing.assert_array_equal(z["f"], ref.acc)
        np.testing.assert_array_equal(z["case"], ref.case.astype(float))


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".h5"])
def test_oversized_data_sets_are_refused_up_front(tmp_path, capsys, monkeypatch, suffix):
    """3 M rows (--duration 5000 at 100 Hz, six cases): the CSV against the free disk, NPZ/HDF5 against memory;
    nothing is written."""
    import shutil
    from collections import namedtuple

    from optinav.cli import common

    monkeypatch.setattr(common, "available_memory", lambda: 2**30)  # half of it, 512 MiB, for the data set
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(2**40, 2**40 - 2**28, 2**28))  # 256 MiB free
    argv = ["simulate", "gfimu-turntable", "--duration", "5000", "--out", str(tmp_path / f"g{suffix}")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "3e+06 samples" in err
    if suffix == ".csv":  # 280 B per row assumed: 0.78 GiB
        assert "0.782 GiB on disk" in err and "0.25 GiB free" in err
    else:  # 220 B per row assumed: 0.61 GiB
        assert "0.615 GiB of memory" in err and "write .csv" in err
    assert list(tmp_path.iterdir()) == []
    # a short one (6 000 rows) fits either way
    monkeypatch.setattr(common, "available_memory", lambda: 2**32)
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(2**40, 2**40 - 2**32, 2**32))
    argv[3] = "10"
    assert main(["--quiet", *argv]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"g{suffix}", "g.truth.json"])


def test_analyze_of_a_result_says_it_is_no_configuration(tmp_path, capsys):
    """`gfimu analyze RESULT.json` (a calibration, not the array's configuration) said the file 'has no
    accelerometers list; write {...}' (probe): it says what the file is and what the command takes."""
    res = tmp_path / "r.json"
    res.write_text(json.dumps({"schema": "optinav.gfimu.calibration", "version": 3, "fields": {}}))
    assert main(["gfimu", "analyze", str(res), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert "is an optinav result ('optinav.gfimu.calibration'), not an array configuration" in err
    assert "CONFIG.json" in err and "--builtin" in err
