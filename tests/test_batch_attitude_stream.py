"""``optinav batch attitude`` runs each unit block by block (no per-unit output, memory bounded): its row equals
the whole-log estimate's numbers (the estimate, its reference scores and its truth comparison) and the scores of
the single-file ``optinav attitude`` output."""

import csv

import numpy as np
import pytest

from optinav.cli.main import main


def _flight_with_mag(d, seed: int):
    """A simulated dynamic flight (STEM.truth.csv/.json beside it) with magnetometer columns mx, my, mz added: the
    NED field seen through the true attitude, plus noise (µT)."""
    from optinav.core.rotations import quat_conjugate, quat_rotate

    data = d / f"f{seed}.csv"
    argv = ["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "12", "--seed", str(seed)]
    assert main([*argv, "--out", str(data)]) == 0
    lines = data.read_text().splitlines()
    q = np.loadtxt(d / f"f{seed}.truth.csv", delimiter=",", skiprows=1)[:, 1:]
    m = quat_rotate(quat_conjugate(q), np.broadcast_to([20.0, -3.0, 45.0], (len(q), 3)))
    m = m + np.random.default_rng(seed).normal(0.0, 0.2, m.shape)
    head = [i for i, line in enumerate(lines) if line.startswith("t,")][0]
    rows = lines[: head + 1] + [f"{a},{x:.17g},{y:.17g},{z:.17g}" for a, (x, y, z) in zip(lines[head + 1 :], m)]
    rows[head] += ",mx,my,mz"
    data.write_text("\n".join(rows) + "\n")
    return data


def _whole_log_row(data, options):
    """The row's numbers computed on the whole log in memory: estimate(), reference_rmse against STEM.truth.csv,
    Truth.compare against STEM.truth.json (series as their RMS error)."""
    from optinav.attitude import estimate
    from optinav.attitude.recording import reference_rmse
    from optinav.attitude.unit import read_log, steps
    from optinav.core.results import Truth

    t, gyr, acc, mag, _ = read_log(data, options)
    res = estimate(gyr, acc, steps(t), mag=mag, offline=options.offline)
    q_ref = np.loadtxt(data.with_name(data.stem + ".truth.csv"), delimiter=",", skiprows=1)[:, 1:]
    inc, head, n = reference_rmse(res.q_b_n, q_ref, np.ones(len(t), bool))
    row = {
        "n_samples": t.size,
        "duration_s": t[-1] - t[0],
        "inclination_rmse_deg": np.degrees(inc),
        "heading_rmse_deg": np.degrees(head),
        "n_reference": n,
        "unobservable": "; ".join(res.unobservable()),
        **{f"gyr_bias_{a}": v for a, v in zip("xyz", res.gyr_bias)},
    }
    for name, c in Truth.from_json(data.with_name(data.stem + ".truth.json")).compare(res).items():
        row[f"{name}_rmse"] = np.sqrt(np.mean(np.asarray(c["error"]) ** 2))
    return row


@pytest.mark.parametrize("offline", [False, True])
@pytest.mark.parametrize("mag", [False, True])
def test_batch_attitude_row_equals_the_whole_log(tmp_path, monkeypatch, offline, mag):
    """Blocks of 333 rows (odd; the truth CSV read beside them): every number of the row is the whole-log one to
    1e-9 relative, the heading-dependent columns (q_b_n and yaw RMSE, 'unobservable') appear with --mag only."""
    import optinav.core.files
    from optinav.attitude.unit import AttitudeOptions

    d = tmp_path / "units"
    d.mkdir()
    data = _flight_with_mag(d, 3)
    monkeypatch.setattr(optinav.core.files, "CHUNK_ROWS", 333)
    out = tmp_path / "res.csv"
    argv = ["--quiet", "batch", "attitude", str(d), "--reference", "--workers", "0", "--out", str(out)]
    assert main(argv + ["--offline"] * offline + ["--mag"] * mag) == 0
    (row,) = list(csv.DictReader(out.open()))
    assert row["status"] == "ok" and not (d / "f3.csv").with_suffix(".att.csv").exists()
    assert sorted(p.name for p in d.iterdir()) == ["f3.csv", "f3.truth.csv", "f3.truth.json"]  # nothing left
    want = _whole_log_row(data, AttitudeOptions(offline=offline, mag=mag))
    assert row["unobservable"] == want.pop("unobservable") == ("" if mag else "q_b_n; yaw")
    assert ("yaw_rmse" in want) == ("q_b_n_rmse" in want) == mag
    assert set(k for k in row if k.endswith("_rmse") and row[k]) == set(k for k in want if k.endswith("_rmse"))
    for k, v in want.items():
        np.testing.assert_allclose(float(row[k]), v, rtol=1e-9, atol=0, err_msg=k)
    assert int(row["n_samples"]) == 1201 and 0.0 < float(row["inclination_rmse_deg"]) < 20.0
    # the single-file command on the same log: its attitude (q to 9 digits) gives the row's scores
    from optinav.attitude.recording import reference_rmse

    att = tmp_path / "att.csv"
    assert main(["--quiet", "attitude", str(data), "--out", str(att)] + ["--offline"] * offline + ["--mag"] * mag) == 0
    q = np.loadtxt(att, delimiter=",", skiprows=1)[:, 1:5]
    q_ref = np.loadtxt(d / "f3.truth.csv", delimiter=",", skiprows=1)[:, 1:]
    inc, head, n = reference_rmse(q, q_ref, np.ones(len(q), bool))
    np.testing.assert_allclose(
        [float(row["inclination_rmse_deg"]), float(row["heading_rmse_deg"])], np.degrees([inc, head]), rtol=1e-6
    )
    assert int(row["n_reference"]) == n == 1201


def test_batch_attitude_truth_of_another_frame(tmp_path):
    """A simulated NED flight estimated with --frame ENU (the same sensor axes, another navigation frame) scores
    as with --frame NED: the truth (STEM.truth.json names its frame) is compared in its own frame, so inclination
    and the roll/pitch errors agree to the estimators' rounding. Before, the ENU estimate was compared with the
    NED truth as if both were ENU: 175° of inclination error, 2.9 rad of roll error, status ok, exit 0."""
    d = tmp_path / "units"
    d.mkdir()
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "12", "--seed", "4",
                 "--out", str(d / "f4.csv")]) == 0  # fmt: skip
    rows = {}
    for frame in ("NED", "ENU"):
        out = tmp_path / f"{frame}.csv"
        argv = ["--quiet", "batch", "attitude", str(d), "--reference", "--workers", "0", "--frame", frame]
        assert main([*argv, "--out", str(out)]) == 0
        (rows[frame],) = list(csv.DictReader(out.open()))
    ned, enu = rows["NED"], rows["ENU"]
    assert ned["status"] == enu["status"] == "ok"
    assert float(ned["inclination_rmse_deg"]) < 20.0
    for k in ("inclination_rmse_deg", "roll_rmse", "pitch_rmse"):
        np.testing.assert_allclose(float(enu[k]), float(ned[k]), rtol=1e-3, err_msg=k)


def test_batch_attitude_rows_say_how_they_were_estimated(tmp_path):
    """Tables of several runs merged to compare methods (online/offline, with/without the magnetometer, input
    stage, frame) told their rows apart only by the 16-hex options hash; each row now names them, typed."""
    from optinav.batch import read_results

    d = tmp_path / "units"
    d.mkdir()
    _flight_with_mag(d, 5)
    runs = {
        "a": (["--offline", "--mag", "--frame", "ENU"], ("iframe", "enu", True, True, True)),
        "b": (["--method", "gd", "--no-input-stage"], ("gd", "ned", False, False, False)),
        "c": (["--method", "mekf"], ("mekf", "ned", False, True, False)),  # the input stage is on by default
    }
    for name, (extra, want) in runs.items():
        out = tmp_path / f"{name}.csv"
        assert main(["--quiet", "batch", "attitude", str(d), "--workers", "0", "--out", str(out), *extra]) == 0
        (row,) = read_results(out)
        assert (row["method"], row["frame"], row["offline"], row["input_stage"], row["mag"]) == want, row


def test_single_file_reference_scores_a_simulated_flight(tmp_path, capsys):
    """`optinav attitude flight.csv --reference` refused a simulated flight ("not a BROAD file") although `batch
    --reference` scored it against STEM.truth.csv: the single-file command now scores it the same (NED and ENU
    alike: the truth is compared in its own frame), and a log with neither reference is refused naming both."""
    import re

    d = tmp_path / "units"
    d.mkdir()
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "12", "--seed", "6",
                 "--out", str(d / "f6.csv")]) == 0  # fmt: skip
    assert (
        main(
            ["--quiet", "batch", "attitude", str(d), "--reference", "--workers", "0", "--out", str(tmp_path / "b.csv")]
        )
        == 0
    )
    (row,) = list(csv.DictReader((tmp_path / "b.csv").open()))
    capsys.readouterr()
    for frame in ("NED", "ENU"):
        argv = ["--quiet", "attitude", str(d / "f6.csv"), "--reference", "--frame", frame]
        assert main([*argv, "--out", str(tmp_path / f"{frame}.csv")]) == 0
        inc = float(re.search(r"inclination RMSE ([\d.]+) deg", capsys.readouterr().out).group(1))
        assert abs(inc - float(row["inclination_rmse_deg"])) < 2e-3, (frame, inc, row["inclination_rmse_deg"])
    (d / "f6.truth.csv").unlink()
    assert main(["--quiet", "attitude", str(d / "f6.csv"), "--reference", "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "not a BROAD trial" in err and "f6.truth.csv" in err, err


def test_a_truth_of_another_frame_without_its_json_is_refused(tmp_path, capsys):
    """A NED flight's STEM.truth.csv without STEM.truth.json (which names the frame) scored with --frame ENU as
    if the truth were ENU: 175° of inclination RMSE, exit 0. The truth's vertical at rest is the accelerometer's
    reversed, which now refuses it in one line (single file and batch); in its own frame it still scores."""
    d = tmp_path / "units"
    d.mkdir()
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "12", "--seed", "6",
                 "--out", str(d / "f6.csv")]) == 0  # fmt: skip
    (d / "f6.truth.json").unlink()
    argv = ["--quiet", "attitude", str(d / "f6.csv"), "--reference", "--out", str(tmp_path / "a.csv")]
    assert main(argv) == 0
    capsys.readouterr()
    assert main([*argv, "--frame", "ENU"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "warning: the accelerometer reads" not in line]
    assert len(err) == 1 and "vertical" in err[0] and "not q_b^n in the ENU frame" in err[0], err  # + the frame warning
    out = tmp_path / "b.csv"
    assert main(["--quiet", "batch", "attitude", str(d), "--reference", "--frame", "ENU", "--workers", "0",
                 "--out", str(out)]) == 1  # fmt: skip
    (row,) = list(csv.DictReader(out.open()))
    assert row["status"] == "failed" and "vertical" in row["error"] and not row.get("inclination_rmse_deg")


def test_a_closed_stderr_does_not_fail_the_units(tmp_path):
    """`optinav batch attitude ... 2>&1 | head -1`: a unit whose warning (here the frame's) met the closed pipe
    failed with 'internal error: BrokenPipeError' and was journaled so (a re-run did not retry it). A warning
    that cannot be shown is lost, as with Python's own showwarning; the units are ok."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    d = tmp_path / "units"
    d.mkdir()
    for seed in (1, 2):
        assert main(["--quiet", "simulate", "flight", "--kind", "static", "--duration", "5", "--seed", str(seed),
                     "--out", str(d / f"f{seed}.csv")]) == 0  # fmt: skip
    out = tmp_path / "r.csv"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    cmd = [sys.executable, "-m", "optinav", "batch", "attitude", str(d), "--frame", "ENU", "--workers", "1"]
    p = subprocess.Popen([*cmd, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    p.stderr.close()  # the reader is gone before anything is written
    p.wait(timeout=300)
    rows = list(csv.DictReader(out.open()))
    assert [(r["unit"], r["status"], r["error"]) for r in rows] == [("f1", "ok", ""), ("f2", "ok", "")]


def test_a_changed_default_recomputes_the_journaled_units(tmp_path, monkeypatch):
    """mekf's acc_noise (0.1 per sample) became acc_noise_density (0.01/√Hz) and the journal's options hash, over the
    options given only, stayed the same (29c872981c8e9f77 for --method mekf --no-input-stage before and after): a
    re-run reused rows computed with the old meaning (at BROAD's 286 Hz another filter). The hash now covers the
    options with the defaults filled in, and the input stage's when it runs, so a changed default recomputes."""
    from optinav.attitude.methods import DEFAULTS, IFRAME_DEFAULTS

    d = tmp_path / "units"
    d.mkdir()
    assert main(["--quiet", "simulate", "flight", "--duration", "3", "--seed", "1", "--out", str(d / "f.csv")]) == 0
    out = tmp_path / "r.csv"
    argv = ["--quiet", "batch", "attitude", str(d), "--workers", "0", "--out", str(out), "--method", "mekf"]

    from optinav.batch import read_results

    for extra, key, table in (
        (["--no-input-stage"], "acc_noise_density", DEFAULTS["mekf"]),
        ([], "tau_acc", IFRAME_DEFAULTS),
    ):
        assert main([*argv, *extra]) == 0
        h0 = read_results(out)[0]["options_hash"]
        assert main([*argv, *extra]) == 0 and read_results(out)[0]["options_hash"] == h0  # resumed: same hash
        monkeypatch.setitem(table, key, 2.0 * table[key])
        assert main([*argv, *extra]) == 0
        assert read_results(out)[0]["options_hash"] != h0, key
        monkeypatch.undo()


def test_batch_attitude_rows_keep_what_the_reader_said(tmp_path):
    """`batch attitude` kept a unit's warnings in its row's notes but not what `attitude` prints beside the numbers
    (here an incomplete last line left out; from two files, the gyroscope interpolated and rows left out), which
    docs/batch.md promises: a row whose rows were dropped could not be audited from the table."""
    from optinav.batch import read_results

    d = tmp_path / "units"
    d.mkdir()
    f = d / "f6.csv"
    assert main(["--quiet", "simulate", "flight", "--kind", "dynamic", "--duration", "12", "--seed", "6",
                 "--out", str(f)]) == 0  # fmt: skip
    for truth in d.glob("f6.truth*"):
        truth.unlink()
    f.write_text(f.read_text() + "12.01,0.1,")  # a logger killed mid-line
    out = tmp_path / "b.csv"
    assert main(["--quiet", "batch", "attitude", str(d), "--workers", "0", "--out", str(out)]) == 0
    (row,) = read_results(out)
    assert "is incomplete and was left out" in (row.get("notes") or ""), row
