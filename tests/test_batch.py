"""``optinav batch calibrate accel``: a real dask.distributed LocalCluster, local processes, parquet, a corrupt
unit, resume from the journal, and an interrupted / killed run that loses nothing finished."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from optinav import batch
from optinav.batch import find_units, read_results, run_batch
from optinav.cli.main import main
from optinav.core.imu_model import preset
from optinav.errors import OptinavError
from optinav.io import ImuLog, write_imu
from optinav.multipos import model
from optinav.multipos.calibrate import FileOptions, calibrate_file
from optinav.multipos.simulate import simulate
from optinav.multipos.uncertainty import _session_gyro_bias

LAT, HEIGHT = 38.88, 35.0
OPTIONS = FileOptions(lat_deg=LAT, height_m=HEIGHT)
CAL_ARGS = ["--latitude", str(LAT), "--height", str(HEIGHT)]
# (file name, accelerometer unit written, seed): small sessions (18 poses of 5 s at 20 Hz) calibrate in ~0.1 s
UNITS = [("u1.csv", "m/s^2", 11), ("u2.csv", "counts", 12), ("u3.npz", "m/s^2", 13)]
BAD = "u0_corrupt.csv"
SEEDS = {Path(name).stem: seed for name, _, seed in UNITS}


@pytest.fixture(scope="module")
def units(tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    truth = {}
    for name, acc_unit, seed in UNITS:
        s = simulate(
            "18",
            dwell_s=5.0,
            rate_hz=20.0,
            transition_s=2.0,
            rest_s=3.0,
            lat=np.radians(LAT),
            height_m=HEIGHT,
            acc_unit=acc_unit,
            rng=seed,
        )
        write_imu(d / name, ImuLog(t=s.t, acc=s.acc, gyr=s.gyr, acc_unit=acc_unit, gyro_unit="rad/s"))
        truth[Path(name).stem] = s
    (d / BAD).write_text("t,ax,ay,az\n0,1,2\n1,2,oops,4\n")
    (d / "u1.truth.json").write_text("{}")  # not a unit
    (d / ".hidden.csv").write_text("t,ax,ay,az\n")  # not a unit
    return d, truth


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        yield c


def _check_rows_against_truth(rows, truth, units_dir):
    by = {r["unit"]: r for r in rows}
    assert sorted(by) == ["u0_corrupt", "u1", "u2", "u3"]  # sorted unit order, hidden/truth files skipped
    assert [r["unit"] for r in rows] == ["u0_corrupt", "u1", "u2", "u3"]
    bad = by["u0_corrupt"]
    with pytest.raises(OptinavError) as exc:
        calibrate_file(units_dir / BAD, OPTIONS)
    assert bad["status"] == "failed" and bad["error"] == str(exc.value) and bad["acc_K_xx"] is None
    for unit, s in truth.items():
        r = by[unit]
        assert r["status"] == "ok" and r["error"] == "", r["error"]
        assert r["acc_unit"] == s.acc_unit and r["n_poses"] == 18 and r["system"] == "multipos"
        assert r["converged"] is True and r["gates_passed"] is True and r["n_gates"] == 6
        # the lower triangle of K is the gauge of norm observation: unobservable, null in the table
        assert set(r["unobservable"].split("; ")) == {"acc_K_yx", "acc_K_zx", "acc_K_zy"}
        assert r["acc_K_yx"] is None and r["acc_K_yx_std"] is None
        K = np.array([[r[f"acc_K_{a}{b}"] or 0.0 for b in "xyz"] for a in "xyz"])
        Ks = np.array([[r[f"acc_K_{a}{b}_std"] or 0.0 for b in "xyz"] for a in "xyz"])
        assert 0 < r["acc_K_xx_crlb_std"] <= r["acc_K_xx_std"]
        bias = np.array([r[f"acc_b_{a}"] for a in "xyz"])
        bs = np.array([r[f"acc_b_{a}_std"] for a in "xyz"])
        # norm observation sees K only up to a rotation: compare with the upper-triangular form of the truth
        U, Q = model.upper_triangular_form(s.acc_K)
        iu = np.triu_indices(3)
        assert np.all(np.abs(K - U)[iu] < 5 * Ks[iu]), (unit, (K - U)[iu] / Ks[iu])
        assert np.all(np.abs(bias - s.acc_b) < 5 * bs), (unit, (bias - s.acc_b) / bs)
        Kg = np.array([[r[f"gyr_K_{a}{b}"] for b in "xyz"] for a in "xyz"])
        Kgs = np.array([[r[f"gyr_K_{a}{b}_std"] for b in "xyz"] for a in "xyz"])
        bg = np.array([r[f"gyr_b_{a}"] for a in "xyz"])
        bgs = np.array([r[f"gyr_b_{a}_std"] for a in "xyz"])
        assert np.all(np.abs(Kg - s.gyr_K @ Q.T) < 5 * Kgs), unit
        # the reported bias is the session's (the unit's bias plus the mean of its drift over the rests)
        b_session = _session_gyro_bias(s, preset("mems-mti1"), SEEDS[unit], drawn=True)
        assert np.all(np.abs(bg - b_session) < 5 * bgs), (unit, (bg - b_session) / bgs)
        assert 0 < r["reduced_chi2"] < 5 and r["elapsed_s"] > 0 and r["optinav_version"]


def test_dask_cluster_batch_matches_truth_then_resumes(units, cluster, tmp_path, capsys):
    d, truth = units
    out = tmp_path / "results.csv"
    assert (
        main(
            [
                "--quiet",
                "batch",
                "calibrate",
                "accel",
                str(d),
                "--out",
                str(out),
                "--scheduler",
                cluster.scheduler_address,
                *CAL_ARGS,
            ]
        )
        == 1
    )  # the corrupt unit failed
    assert "4 units: 3 ok, 1 failed" in capsys.readouterr().out
    rows = read_results(out)
    _check_rows_against_truth(rows, truth, d)
    journal = tmp_path / "results.csv.journal.jsonl"
    assert len(journal.read_text().splitlines()) == 4
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]  # the atomic write left no temp file
    # re-run: every unit is in the journal with the same file and options → nothing recomputed
    before = journal.read_bytes()
    s = run_batch(d, out, OPTIONS, scheduler=cluster.scheduler_address, show_progress=False)
    assert (s.n_resumed, s.n_computed, s.n_ok, s.n_failed) == (4, 0, 3, 1)
    assert journal.read_bytes() == before
    assert read_results(out) == rows  # same elapsed_s and finish times: the rows were kept, not recomputed
    # other options are another calibration: nothing is reused
    s = run_batch(
        d,
        out,
        FileOptions(lat_deg=LAT, height_m=HEIGHT, method="gn"),
        scheduler=cluster.scheduler_address,
        show_progress=False,
    )
    assert (s.n_resumed, s.n_computed) == (0, 4) and {r["method"] for r in s.rows} == {"gn"}


def test_local_processes_parquet_and_changed_file(units, tmp_path, monkeypatch):
    pytest.importorskip("pyarrow")
    d, truth = units
    for name in ("dask", "distributed"):  # the local mode must not need the optional dask extra
        monkeypatch.setitem(sys.modules, name, None)
    out = tmp_path / "results.parquet"
    s = run_batch(d, out, OPTIONS, workers=2, show_progress=False)
    assert (s.n_units, s.n_ok, s.n_failed, s.n_computed) == (4, 3, 1, 4)
    import pyarrow.parquet as pq

    table = pq.read_table(out)
    assert table.column_names[:3] == ["unit", "file", "status"] and table.num_rows == 4
    assert table.column_names[-5:] == batch.COLUMN_NAMES[-5:] and "gyr_b_z_crlb_std" in table.column_names
    assert str(table.schema.field("acc_K_xx").type) == "double"
    rows = read_results(out)
    _check_rows_against_truth(rows, truth, d)
    # a unit whose file changed (new mtime) is recomputed, the others are kept
    st = (d / "u2.csv").stat()
    os.utime(d / "u2.csv", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    try:
        s2 = run_batch(d, out, OPTIONS, workers=2, show_progress=False)
    finally:
        os.utime(d / "u2.csv", ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (s2.n_resumed, s2.n_computed) == (3, 1)
    new = {r["unit"]: r for r in read_results(out)}
    old = {r["unit"]: r for r in rows}
    assert new["u1"] == old["u1"] and new["u2"]["finished_utc"] >= old["u2"]["finished_utc"]
    assert new["u2"]["acc_K_xx"] == pytest.approx(old["u2"]["acc_K_xx"], rel=1e-12)


def test_interrupted_run_keeps_finished_rows_and_resumes(units, tmp_path, monkeypatch):
    d, _ = units
    out = tmp_path / "r.csv"
    real = batch.calibrate_unit
    calls = []

    def interrupted_on_third(path, options, name=""):
        calls.append(name)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(path, options, name)

    monkeypatch.setattr(batch, "calibrate_unit", interrupted_on_third)
    with pytest.raises(KeyboardInterrupt):
        run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    journal = [json.loads(x)["row"] for x in (tmp_path / "r.csv.journal.jsonl").read_text().splitlines()]
    assert [r["unit"] for r in journal] == ["u0_corrupt", "u1"]
    assert [r["unit"] for r in read_results(out)] == ["u0_corrupt", "u1"]  # the table holds what finished
    monkeypatch.setattr(batch, "calibrate_unit", real)
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert (s.n_resumed, s.n_computed, s.n_ok) == (2, 2, 3)
    assert s.rows[1] == batch._complete(journal[1])  # u1 was kept as journaled


#: FileOptions fields renamed to the vocabulary (docs/conventions.md): new name → the name journals had before
RENAMED_OPTIONS = {"rate_hz": "rate", "height_m": "height", "gyro_path": "gyro", "lat_deg": "latitude"}


def _hash_with_names(job, names: dict) -> str:
    """options_hash's formula over the job with the option fields spelled by ``names``."""
    import dataclasses
    import hashlib

    d = dataclasses.asdict(job)
    d.pop("results_dir")  # where results go is not what they are
    if not d.get("option_files"):
        d.pop("option_files")  # a job that names no files hashes as before files were hashed
    d["options"] = {names.get(k, k): v for k, v in d["options"].items()}
    text = json.dumps({"layout": batch.LAYOUT, **d}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def test_attitude_options_added_later_leave_an_unset_job_s_hash_as_it_was():
    """An attitude job that sets neither ``mag_path`` nor ``mag_hard_iron`` (added since) hashes their absence as
    before they existed, so its journal is resumed unless a default changed (the resolved options are hashed);
    the second option had changed every attitude job's hash. Setting one changes it."""
    from optinav.attitude.unit import AttitudeOptions

    job = batch.BatchJob("attitude", AttitudeOptions(mag=True, offline=True), True)
    assert not set(batch.LATER_OPTIONS) & set(batch.hashed_fields(job)["options"])
    for k, v in (("mag_path", "m.csv"), ("mag_hard_iron", (1.0, 2.0, 3.0))):
        other = batch.BatchJob("attitude", AttitudeOptions(mag=True, offline=True, **{k: v}), True)
        assert batch.hashed_fields(other)["options"][k] == v
        assert batch.options_hash(other) != batch.options_hash(job)


def test_an_attitude_declination_left_at_0_hashes_as_before_it_existed():
    """iframe's ``declination`` (added with 0, the estimate as before) is part of the resolved options the hash
    covers: left at 0 it is left out of them (every attitude job, iframe's and the input stage's of the other
    methods, hashes as before, its journal resumed); set, it changes the hash."""
    from optinav.attitude.unit import AttitudeOptions

    for method in ("iframe", "gd"):
        job = batch.BatchJob("attitude", AttitudeOptions(method=method), True)
        resolved = batch.hashed_fields(job)["resolved"]
        assert all("declination" not in v for v in resolved.values() if isinstance(v, dict)), method
    job = batch.BatchJob("attitude", AttitudeOptions(mag=True), True)
    zero = batch.BatchJob("attitude", AttitudeOptions(mag=True, options={"declination": 0.0}), True)
    assert batch.hashed_fields(zero)["resolved"] == batch.hashed_fields(job)["resolved"]
    turned = batch.BatchJob("attitude", AttitudeOptions(mag=True, options={"declination": 0.2}), True)
    assert batch.hashed_fields(turned)["resolved"]["options"]["declination"] == 0.2
    assert batch.options_hash(turned) != batch.options_hash(job)


def test_journal_of_the_old_option_names_is_recomputed_not_mixed(units, tmp_path):
    """Rows journaled when the options were named ``rate``/``height``/``gyro``/``latitude`` carry another options
    hash: the next run recomputes every unit and the table holds only rows of the current options."""
    d, _ = units
    out = tmp_path / "r.csv"
    job = batch.BatchJob("multipos", OPTIONS, False)
    new_hash = batch.options_hash(job)
    assert _hash_with_names(job, {}) == new_hash  # the formula above is options_hash's
    old_hash = _hash_with_names(job, RENAMED_OPTIONS)
    assert old_hash != new_hash
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert s.n_computed == 4
    journal = tmp_path / "r.csv.journal.jsonl"
    recs = [json.loads(x) for x in journal.read_text().splitlines()]
    assert {r["row"]["options_hash"] for r in recs} == {new_hash}
    for r in recs:  # as an older optinav would have journaled the same calibrations
        r["row"]["options_hash"] = old_hash
    journal.write_text("".join(json.dumps(r) + "\n" for r in recs))
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert (s.n_resumed, s.n_computed, s.n_ok, s.n_failed) == (0, 4, 3, 1)
    assert {r["options_hash"] for r in read_results(out)} == {new_hash}


def test_a_worker_of_another_version_is_an_error_not_a_missing_row(units, tmp_path, monkeypatch):
    """A worker whose optinav reads the options into other fields (e.g. from before the rename) returns rows of
    another options hash: a one-line error naming the versions, nothing journaled under it."""
    d, _ = units
    out = tmp_path / "r.csv"
    real = batch.calibrate_unit
    old_hash = _hash_with_names(batch.BatchJob("multipos", OPTIONS, False), RENAMED_OPTIONS)

    def old_worker(path, options, name=""):
        return {**real(path, options, name), "options_hash": old_hash, "optinav_version": "0.1.0"}

    monkeypatch.setattr(batch, "calibrate_unit", old_worker)
    with pytest.raises(OptinavError, match=r"another optinav \(0\.1\.0\)"):
        run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert (tmp_path / "r.csv.journal.jsonl").read_text() == ""
    assert read_results(out) == []


def test_killed_process_loses_nothing_finished(units, tmp_path):
    d, _ = units
    out = tmp_path / "r.csv"
    journal = tmp_path / "r.csv.journal.jsonl"
    cmd = [
        sys.executable,
        "-m",
        "optinav.cli.main",
        "--quiet",
        "batch",
        "calibrate",
        "accel",
        str(d),
        "--out",
        str(out),
        "--workers",
        "1",
        *CAL_ARGS,
    ]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if journal.is_file() and journal.read_text().count("\n") >= 1:
                break
            time.sleep(0.01)
        assert journal.is_file(), proc.stderr.read().decode() if proc.poll() is not None else "no journal"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # the batch and its worker processes: its own session
        proc.wait(timeout=30)
        proc.stderr.close()
    finished = {
        json.loads(x)["row"]["unit"]: json.loads(x)["row"] for x in journal.read_text().splitlines() if x.strip()
    }
    assert 1 <= len(finished) <= 4
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert s.n_resumed == len(finished) and s.n_computed == 4 - len(finished) and s.n_ok == 3
    for r in s.rows:
        if r["unit"] in finished:
            assert r == batch._complete(finished[r["unit"]])  # kept, not recomputed


def test_lost_worker_is_reported_but_retried_next_run(units, tmp_path, monkeypatch):
    d, _ = units
    real = batch._run_jobs

    def one_worker_dies(jobs, options, workers, scheduler):
        for unit, row, lost in real(jobs, options, workers, scheduler):
            yield (unit, None, "worker lost: KilledWorker: oom") if unit.name == "u2" else (unit, row, lost)

    monkeypatch.setattr(batch, "_run_jobs", one_worker_dies)
    out = tmp_path / "r.csv"
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert s.n_lost == 1 and s.n_computed == 3
    row = {r["unit"]: r for r in read_results(out)}["u2"]
    assert row["status"] == "failed" and row["error"].startswith("worker lost")
    monkeypatch.setattr(batch, "_run_jobs", real)
    s = run_batch(d, out, OPTIONS, workers=0, show_progress=False)
    assert (s.n_resumed, s.n_computed, s.n_ok) == (3, 1, 3)


def test_unit_rule(tmp_path):
    for name in ("b.csv", "a.txt.gz", "a.npz", "c.tsv", "notes.md", "x.truth.json", ".h.csv", "results.csv"):
        (tmp_path / name).write_bytes(b"1")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "d.csv").write_bytes(b"1")
    units = find_units(tmp_path, exclude=[tmp_path / "results.csv"])
    assert [(u.name, u.path.name) for u in units] == [
        ("a.npz", "a.npz"),
        ("a.txt.gz", "a.txt.gz"),
        ("b", "b.csv"),
        ("c", "c.tsv"),
    ]


def test_notes_beside_the_recordings_are_skipped_not_failed(tmp_path):
    """A README.txt or LICENSE.txt beside the recordings (the BROAD folder here holds both) was a unit that failed
    as a ragged table, so the batch ended with exit 1. A .txt/.log without a line of numbers only in its head is
    now skipped and named; a log of numbers under a text header, and a one-column log, stay units."""
    (tmp_path / "README.txt").write_text("Trial notes\nrecorded 2021-03-04, sensor 2, 100 Hz\n\n- left: ok\n")
    (tmp_path / "run.log").write_text("start 12:00\nstop 12:30\n")
    (tmp_path / "imu.txt").write_text("# my logger\ntime acc_x acc_y\n0.00 0.1 9.8\n0.01 0.2 9.7\n")
    (tmp_path / "imu2.log").write_text("t,ax,ay,az\n0,0,0,9.8\n")
    (tmp_path / "one.txt").write_text("1.5\n2.5\n")
    skipped: list = []
    units = find_units(tmp_path, skipped=skipped)
    assert [u.path.name for u in units] == ["imu.txt", "imu2.log", "one.txt"]
    assert sorted(name for name, _ in skipped) == ["README.txt", "run.log"]
    assert all("without a line of numbers" in why for _, why in skipped)


def test_the_workers_fork_with_their_systems_unit_module_imported():
    """Each pool's workers imported scipy and the system themselves (a pool of 2 took 3-6 s for two 0.1 s units):
    the fork server preloads the module of the system's run_unit, for every registered system."""
    import importlib

    from optinav.registry import SYSTEMS

    assert batch._unit_modules(OPTIONS) == ["optinav.multipos.unit"]
    for name, system in SYSTEMS.items():
        if system.run_unit:
            (module,) = batch._unit_modules(batch.BatchJob(name, None))
            assert importlib.import_module(module) is sys.modules[system.load("run_unit").__module__], name


def test_bad_requests_are_one_line_errors(units, tmp_path, monkeypatch, capsys):
    d, _ = units
    for argv in (
        ["--out", str(tmp_path / "r.json")],
        ["--out", str(tmp_path / "missing" / "r.csv")],
        ["--out", str(tmp_path / "r.csv"), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
        ["--out", str(tmp_path / "r.csv"), "--workers", "-1"],
        ["--out", str(tmp_path / "r.csv"), "--generations", "3"],
    ):
        assert main(["--quiet", "batch", "calibrate", "accel", str(d), *argv]) == 2
    assert (
        main(["--quiet", "batch", "calibrate", "accel", str(tmp_path / "nope"), "--out", str(tmp_path / "r.csv")]) == 2
    )
    (tmp_path / "empty").mkdir()
    assert (
        main(["--quiet", "batch", "calibrate", "accel", str(tmp_path / "empty"), "--out", str(tmp_path / "r.csv")]) == 2
    )
    err = capsys.readouterr().err
    assert err.count("optinav: error:") == 7 and "Traceback" not in err
    # the optional extras missing: the error names them
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    with pytest.raises(OptinavError, match=r"optinav\[parquet\]"):
        run_batch(d, tmp_path / "r.parquet", OPTIONS)
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(OptinavError, match=r"optinav\[dask\]"):
        run_batch(d, tmp_path / "r.csv", OPTIONS, scheduler="tcp://127.0.0.1:1")
    assert not (tmp_path / "r.csv").exists()  # nothing started, nothing written


def test_batch_keeps_the_hold_out_check_and_the_notes(tmp_path, capsys):
    """``batch --hold-out K`` fitted every unit without pose K but tabulated nothing of the held-out check, and
    the notes calibrate prints (a time base off by a factor, turns left out, …) were lost."""
    d = tmp_path / "units"
    d.mkdir()
    for seed in (1, 2):
        argv = ["--quiet", "simulate", "accel-multipos", "--out", str(d / f"u{seed}.csv"), "--dwell", "4"]
        assert main(argv + ["--acc-unit", "counts", "--gyro-unit", "counts", "--seed", str(seed)]) == 0
    out = tmp_path / "r.csv"
    assert main(["--quiet", "batch", "calibrate", "accel", str(d), "--hold-out", "3", "--out", str(out)]) == 0
    capsys.readouterr()
    rows = read_results(out)
    for r in rows:
        assert r["status"] == "ok" and r["held_out_pose"] == 3
        assert 0.0 < abs(r["held_out_norm_error_m_s2"]) < 0.05
        assert "g = 9.80665 m/s^2" in r["notes"]


def test_an_earlier_batch_table_in_the_folder_is_no_unit(tmp_path, capsys):
    """A results table of an earlier batch (another --out) left in the units folder was taken as a unit and
    failed the whole lot ('no accelerometer or gyroscope data', exit 1)."""
    d = tmp_path / "units"
    d.mkdir()
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(d / "u1.csv"), "--dwell", "4"]
    assert main(argv + ["--acc-unit", "counts", "--gyro-unit", "counts", "--seed", "1"]) == 0
    assert main(["--quiet", "batch", "calibrate", "accel", str(d), "--out", str(tmp_path / "first.csv")]) == 0
    (d / "old_results.csv").write_bytes((tmp_path / "first.csv").read_bytes())
    assert main(["--quiet", "batch", "calibrate", "accel", str(d), "--out", str(tmp_path / "second.csv")]) == 0
    capsys.readouterr()
    assert [r["unit"] for r in read_results(tmp_path / "second.csv")] == ["u1"]


@pytest.mark.parametrize("workers", ["0", "1"])
def test_worker_warnings_are_one_line_like_the_batch_process(tmp_path, workers):
    """A warning raised in a worker process (``--workers 1``) was Python's two lines (``…/filestream.py:952:
    FrameWarning: …`` and the source line) while ``--workers 0`` printed ``optinav: warning: …``: the workers
    now show warnings as the batch process does."""
    d = tmp_path / "units"
    d.mkdir()
    # +g along body z: an up-pointing z, which the attitude reader warns about for the default NED frame
    (d / "s.csv").write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{k / 100},0,0,9.8,0,0,0\n" for k in range(500)))
    cmd = [sys.executable, "-m", "optinav.cli.main", "--quiet", "batch", "attitude", str(d)]
    cmd += ["--out", str(tmp_path / "b.csv"), "--workers", workers]
    env = {**os.environ, "PYTHONPATH": str(Path(batch.__file__).parents[1])}
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert lines and all(x.startswith("optinav: warning: ") for x in lines), proc.stderr
    assert any("up-pointing z" in x for x in lines), proc.stderr
