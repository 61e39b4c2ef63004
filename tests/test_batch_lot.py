"""The lot check of ``optinav batch calibrate`` (units that stand out from the other units of the lot) and the
per-unit result files (``--results-dir``)."""

import json

import numpy as np
import pytest

from optinav import batch
from optinav.batch import _esd_outliers, lot_check, read_results, run_batch
from optinav.cli.main import main
from optinav.core.results import Result
from optinav.errors import OptinavError
from optinav.io import ImuLog, write_imu
from optinav.multipos.calibrate import FileOptions, calibrate_file
from optinav.multipos.simulate import simulate


def test_esd_finds_one_outlier_and_two_that_would_hide_each_other():
    rng = np.random.default_rng(1)
    x = rng.normal(size=12)
    x[4] += 12.0
    assert _esd_outliers(x, 0.01) == [4]
    y = rng.normal(size=12)
    y[[2, 7]] += 10.0  # each inflates the spread the other is judged against
    assert sorted(_esd_outliers(y, 0.01)) == [2, 7]
    assert _esd_outliers(rng.normal(size=12), 0.01) == []


@pytest.mark.parametrize("n", [5, 8, 20])
def test_esd_false_alarm_rate_is_at_most_its_level(n):
    """On normal samples the test flags something in at most ``alpha`` of them (binomial 3-sigma band; the
    uncorrected generalized ESD flagged 8.4 % at 5 % in lots of 8), and not far below it."""
    rng = np.random.default_rng(n)
    alpha, trials = 0.05, 2000
    hits = sum(bool(_esd_outliers(rng.normal(size=n), alpha)) for _ in range(trials))
    band = 3 * np.sqrt(alpha * (1 - alpha) / trials)
    assert alpha / 4 < hits / trials < alpha + band


def _rows(values: dict, unit_kind="m/s^2", n=None):
    n = n or len(next(iter(values.values())))
    rows = []
    for i in range(n):
        r = {"unit": f"u{i}", "status": "ok", "acc_unit": unit_kind, "gyr_unit": unit_kind}
        for k, v in values.items():
            r[k], r[f"{k}_std"] = v[i], 0.01
        rows.append(r)
    return rows


def test_lot_check_flags_the_parameter_that_stands_out_and_keeps_the_unit_ok():
    rng = np.random.default_rng(2)
    vals = {f"acc_b_{a}": rng.normal(0, 0.05, 10) for a in "xyz"} | {"acc_K_xx": 1 + rng.normal(0, 1e-3, 10)}
    vals["acc_b_y"][6] = 0.6  # 12 sigma of the lot
    rows = _rows(vals)
    text = lot_check(rows)
    assert [r["lot_outlier"] for r in rows] == [i == 6 for i in range(10)]
    assert rows[6]["status"] == "ok" and rows[6]["lot_review"].startswith("acc_b_y = 0.6 ")
    assert "4 parameters" in text and "u6" in text
    assert "no outliers" in lot_check(_rows({k: np.delete(v, 6) for k, v in vals.items()}))


def test_lot_check_compares_units_of_the_same_raw_units_only():
    """Units in counts and in m/s² are not one population: the lot's median over both failed the good units of
    the smaller group, and a unit declared in g among units in m/s² was flagged."""
    rng = np.random.default_rng(4)
    counts = _rows({"acc_K_xx": 208.8 + rng.normal(0, 0.5, 8), "acc_b_x": rng.normal(0, 10, 8)}, unit_kind="counts")
    si = _rows({"acc_K_xx": 1.0 + rng.normal(0, 2e-3, 3), "acc_b_x": rng.normal(0, 0.05, 3)})
    for i, r in enumerate(si):
        r["unit"] = f"s{i}"
    rows = counts + si
    text = lot_check(rows)
    assert all(r["status"] == "ok" for r in rows), [r.get("error") for r in rows]
    assert "8 units in counts/counts" in text and "not compared (fewer than 5): 3 in m/s^2/m/s^2" in text
    assert all("lot_outlier" not in r for r in si) and not any(r["lot_outlier"] for r in counts)
    g = _rows({"acc_K_xx": [1.0, 1.001, 0.999, 1.002, 0.998, 1.0], "acc_b_x": [0.01, -0.02, 0.0, 0.02, 0.01, -0.01]})
    g += _rows({"acc_K_xx": [0.102, 0.1021], "acc_b_x": [0.001, 0.002]}, unit_kind="g")
    lot_check(g)
    assert not any(r.get("lot_outlier") for r in g) and all(r["status"] == "ok" for r in g)


def test_lot_check_needs_five_units_and_can_be_switched_off():
    rows = _rows({"acc_b_x": [0.0, 0.01, -0.01, 5.0]})
    assert "not run" in lot_check(rows) and all("lot_outlier" not in r for r in rows)
    rows = _rows({"acc_b_x": [0.0, 0.01, -0.01, 0.02, 5.0]})
    assert lot_check(rows, 0) == "lot check: off" and "lot_outlier" not in rows[-1]
    assert "u4" in lot_check(rows) and rows[-1]["lot_outlier"] is True


def test_lot_check_fails_a_raw_count_scale_off_the_lots_median():
    """In counts no nominal scale exists, so a unit recorded at another range (2x) passed every gate; in a
    physical unit the scale's own gate refuses it already, so only counts are judged against the lot."""
    k = [939.0, 940.2, 938.1, 941.0, 1879.0, 939.5]
    rows = _rows({"gyr_K_xx": k, "gyr_K_yy": k}, unit_kind="counts")
    text = lot_check(rows)
    bad = rows[4]
    assert bad["status"] == "failed" and bad["error"].startswith("gyr_K_xx = 1879 counts per SI unit is 2")
    assert "another range" in bad["error"] and "failed (scale off the lot): u4" in text
    assert all(r["status"] == "ok" and r["lot_outlier"] is False for i, r in enumerate(rows) if i != 4)
    rows = _rows({"gyr_K_xx": k}, unit_kind="rad/s")
    lot_check(rows)
    assert rows[4]["status"] == "ok" and rows[4]["lot_outlier"] is True  # judged by its own gate, not here


def _session(d, name, seed, gyro_factor=1.0):
    s = simulate("18", dwell_s=5.0, rate_hz=20.0, transition_s=2.0, rest_s=3.0, acc_unit="counts", rng=seed)
    gyr = np.round(s.gyr * 1000.0 * gyro_factor)  # a gyro in counts of 1 mrad/s (2x: another range setting)
    write_imu(d / name, ImuLog(t=s.t, acc=s.acc, gyr=gyr, acc_unit="counts", gyro_unit="counts"))


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    d = tmp_path_factory.mktemp("lot")
    for seed in range(1, 7):
        _session(d, f"u{seed}.csv", seed)
    _session(d, "u7.csv", 7, gyro_factor=2.0)
    return d


OPTIONS = FileOptions(acc_unit="counts", gyro_unit="counts")


def test_batch_fails_the_unit_recorded_at_another_range_and_writes_each_result(lot, tmp_path, capsys):
    res = tmp_path / "results"
    res.mkdir()
    out = tmp_path / "r.csv"
    args = ["batch", "calibrate", "accel", str(lot), "--acc-unit", "counts", "--gyro-unit", "counts"]
    assert main(["--quiet", *args, "--out", str(out), "--workers", "0", "--results-dir", str(res)]) == 1
    text = capsys.readouterr().out
    assert "u7: gyr_K_xx" in text and "of the lot's units in counts" in text
    rows = {r["unit"]: r for r in read_results(out)}
    assert rows["u7"]["status"] == "failed" and rows["u7"]["gyr_K_xx"] == pytest.approx(2000, rel=0.02)
    assert all(rows[f"u{i}"]["status"] == "ok" and rows[f"u{i}"]["lot_outlier"] is False for i in range(1, 7))
    # each ok unit's result is the one `optinav calibrate --out` writes; none for the unit the lot failed
    assert sorted(p.name for p in res.iterdir()) == [f"u{i}.json" for i in range(1, 7)]
    one = Result.from_json(res / "u3.json")
    alone = calibrate_file(lot / "u3.csv", OPTIONS)
    np.testing.assert_allclose(one.accelerometer["K"], alone.accelerometer["K"], rtol=1e-12)
    np.testing.assert_allclose(one.gyroscope["K"], alone.gyroscope["K"], rtol=1e-12)
    assert rows["u3"]["result_file"] == "u3.json"
    kalibr = tmp_path / "imu.yaml"
    lsb = ["--acc-lsb", "2048", "--gyro-lsb", str(1000 * np.pi / 180)]  # the sessions' counts (see _session)
    assert main(["--quiet", "export", str(res / "u3.json"), "--to", "kalibr", *lsb, "--out", str(kalibr)]) == 0
    # a result file removed: its unit is computed again on resume (the others resumed)
    (res / "u2.json").unlink()
    s = run_batch(lot, out, OPTIONS, workers=0, results_dir=res, show_progress=False)
    assert s.n_computed == 2 and (res / "u2.json").is_file() and s.n_failed == 1  # u2, and u7 again
    assert not (res / "u7.json").exists()


def test_results_dir_does_not_change_the_options_hash_and_is_checked(lot, tmp_path):
    assert batch.options_hash(batch.BatchJob("multipos", OPTIONS, False, "/x")) == batch.options_hash(
        batch.BatchJob("multipos", OPTIONS, False, None)
    )
    with pytest.raises(OptinavError, match="--results-dir .* is not a folder"):
        run_batch(lot, tmp_path / "r.csv", OPTIONS, results_dir=tmp_path / "nope")
    with pytest.raises(OptinavError, match="--lot-alpha"):
        run_batch(lot, tmp_path / "r.csv", OPTIONS, lot_alpha=1.5)
    assert not (tmp_path / "r.csv").exists()


def test_lot_check_on_a_lot_of_simulated_units_flags_none(tmp_path):
    """Eight units drawn from one IMU preset: their spread is the lot's, no unit is flagged (and the check ran)."""
    for seed in range(11, 19):
        _session(tmp_path, f"u{seed}.csv", seed)
    s = run_batch(tmp_path, tmp_path / "r.csv", OPTIONS, workers=0, show_progress=False)
    assert s.n_ok == 8 and "8 units" in s.lot and "no outliers" in s.lot, s.lot
    assert json.loads(json.dumps(s.rows[0]["lot_outlier"])) is False


def test_an_edited_section_file_recomputes_its_units(tmp_path):
    """The options hash held the --sections file's name only: a section list edited between two runs resumed
    every unit from the journal with the old sections. The files the options name are hashed by content,
    read once by the batch (a worker computes the same hash from the job)."""
    d = tmp_path / "units"
    d.mkdir()
    _session(d, "u1.csv", 1)
    sec = tmp_path / "sections.txt"
    sec.write_text("3.5 8.0\n")
    opts = FileOptions(acc_unit="counts", gyro_unit="counts", sections=str(sec), allow_unobservable=True)
    job = batch.BatchJob("multipos", opts, False, None, batch._option_files({"sections": str(sec)}))
    h1 = batch.options_hash(job)
    assert h1 != batch.options_hash(batch.BatchJob("multipos", opts, False))
    out = tmp_path / "r.csv"
    s1 = run_batch(d, out, opts, workers=0, show_progress=False)
    assert s1.n_computed == 1 and s1.rows[0]["options_hash"] == h1
    assert run_batch(d, out, opts, workers=0, show_progress=False).n_resumed == 1
    sec.write_text("3.5 7.0\n")
    s3 = run_batch(d, out, opts, workers=0, show_progress=False)
    assert (s3.n_resumed, s3.n_computed) == (0, 1)


def test_result_files_belong_to_their_rows(tmp_path):
    """Two defects: a unit that failed on a re-run kept the result file of its earlier ok run (an
    `export` of the folder would use it), and a resumed batch took a result file another run with other options
    had written into the same folder. A failed unit's file is removed; a row takes its file only if it is the one
    it wrote (its SHA-256 in the row)."""
    d = tmp_path / "units"
    d.mkdir()
    for seed in (1, 2, 3):
        _session(d, f"u{seed}.csv", seed)
    res = tmp_path / "res"
    res.mkdir()
    a = run_batch(d, tmp_path / "a.csv", OPTIONS, workers=0, results_dir=res, show_progress=False)
    assert a.n_ok == 3 and all(r["result_sha"] for r in a.rows)
    other = FileOptions(acc_unit="counts", gyro_unit="counts", model="diagonal")
    run_batch(d, tmp_path / "b.csv", other, workers=0, results_dir=res, show_progress=False)
    again = run_batch(d, tmp_path / "a.csv", OPTIONS, workers=0, results_dir=res, show_progress=False)
    assert again.n_computed == 3  # b's files replaced a's: a's rows are computed again, not resumed
    one = Result.from_json(res / "u1.json")
    np.testing.assert_allclose(one.accelerometer["K"], calibrate_file(d / "u1.csv", OPTIONS).accelerometer["K"])
    (d / "u2.csv").write_text("t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n")  # the unit's log is now broken
    s = run_batch(d, tmp_path / "a.csv", OPTIONS, workers=0, results_dir=res, show_progress=False)
    assert s.n_failed == 1 and not (res / "u2.json").exists() and (res / "u1.json").exists()


def test_results_dir_never_replaces_or_removes_a_file_that_is_no_result(tmp_path):
    """--results-dir the units' own folder, which also holds u1.json, u1's section list: the batch wrote u1's
    result over it (exit 1 only because the other units then read that result as their sections), and a unit
    that fails removed its UNIT.json whatever it held. Such a file is refused before any unit runs; an earlier
    run's result files are replaced as before."""
    d = tmp_path / "units"
    d.mkdir()
    for seed in (1, 2):
        _session(d, f"u{seed}.csv", seed)
    sections = d / "u1.json"
    sections.write_text('{"x_p": {"start": 540, "end": 1271}}')
    note = d / "u2.json"
    note.write_text('{"operator": "A. N.", "table": 3}')
    out = tmp_path / "r.csv"
    args = ["--quiet", "batch", "calibrate", "accel", str(d), "--acc-unit", "counts", "--gyro-unit", "counts"]
    assert main([*args, "--out", str(out), "--workers", "0", "--results-dir", str(d)]) == 2
    assert sections.read_text() == '{"x_p": {"start": 540, "end": 1271}}'
    assert note.read_text() == '{"operator": "A. N.", "table": 3}' and not out.exists()
    with pytest.raises(OptinavError, match=r"--results-dir .*u1\.json exists and is not a file this command writes"):
        run_batch(d, out, OPTIONS, workers=0, results_dir=d, show_progress=False)
    sections.unlink()
    note.unlink()
    s = run_batch(d, out, OPTIONS, workers=0, results_dir=d, show_progress=False)
    assert s.n_ok == 2 and Result.from_json(d / "u1.json").accelerometer is not None
    again = run_batch(d, out, OPTIONS, workers=0, results_dir=d, show_progress=False, fresh=True)
    assert again.n_computed == 2  # its own result files are replaced
