"""``optinav batch calibrate rins|gfimu`` and ``optinav batch attitude``: each on a real dask.distributed
LocalCluster against the simulated truth beside its units (--reference), resumed from the journal, and a killed
run that loses nothing finished. Tiny simulated units keep it fast; one LocalCluster serves the module."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from optinav import batch
from optinav.attitude.unit import AttitudeOptions
from optinav.batch import read_results, run_batch
from optinav.cli.main import main
from optinav.gfimu.unit import GfimuOptions
from optinav.rins.unit import RinsOptions

NONORTH = [np.array([1.0, -2.0, 3.0, -1.0, 2.0, 4.0]) * 1e-4, np.array([-2.0, 1.0, -1.0, 3.0, -1.0, 2.0]) * 1e-4]

#: system → (batch CLI words, options, CLI options, simulate argv per unit (seed k), unit file names)
SYSTEMS = {
    "rins": (
        ["calibrate", "rins"],
        RinsOptions(),
        [],
        lambda k, out: [
            "simulate",
            "rins",
            "--nonorth=" + ",".join(f"{x:.6g}" for x in NONORTH[k]),
            "--scheme",
            "dual4",
            "--align",
            "40",
            "--dwell",
            "5",
            "--move",
            "5",
            "--rate",
            "25",
            "--seed",
            str(k + 1),
            "--out",
            out,
        ],
        ["r1.npz", "r2.npz"],
    ),
    "gfimu": (
        ["calibrate", "gfimu"],
        GfimuOptions(builtin="cylinder10", offset="zero"),  # centred, simulated: absolute Δr against the truth
        ["--builtin", "cylinder10", "--offset", "zero"],
        lambda k, out: [
            "simulate",
            "gfimu-turntable",
            "--builtin",
            "cylinder10",
            "--errors",
            "random",
            "--duration",
            "0.5",
            "--seed",
            str(k + 1),
            "--out",
            out,
        ],
        ["t1.npz", "t2.npz"],
    ),
    "attitude": (
        ["attitude"],
        AttitudeOptions(method="mekf"),
        ["--method", "mekf"],
        lambda k, out: [
            "simulate",
            "flight",
            "--kind",
            "static",
            "--duration",
            "5",
            "--seed",
            str(k + 1),
            "--out",
            out,
        ],
        ["f1.csv", "f2.csv"],
    ),
}
BAD = "a0_corrupt.csv"


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    out = {}
    for system, (_, _, _, simulate, names) in SYSTEMS.items():
        d = tmp_path_factory.mktemp(system)
        for k, name in enumerate(names):
            assert main(["--quiet", *simulate(k, str(d / name))]) == 0
        (d / BAD).write_text("t,ax,ay,az\n0,1,2\n1,2,oops,4\n")
        out[system] = d
    return out


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        yield c


def _check_rows(system, rows):
    by = {r["unit"]: r for r in rows}
    assert list(by) == ["a0_corrupt", *[n.split(".")[0] for n in SYSTEMS[system][4]]]
    assert by["a0_corrupt"]["status"] == "failed" and by["a0_corrupt"]["error"]
    for name in SYSTEMS[system][4]:
        r = by[name.split(".")[0]]
        assert r["status"] == "ok", r["error"]
        assert r["system"] == system and r["elapsed_s"] > 0
        # an attitude estimate has no quality gates: none checked is no pass
        assert r["gates_passed"] is (None if system == "attitude" else True) and (r["n_gates"] > 0) == (
            system != "attitude"
        )
        if system == "rins":
            # dual-axis ±180°: theta_z − eta_z and eta_y unobservable, theta_z + eta_z estimated
            assert set(r["unobservable"].split("; ")) == {"theta_z", "eta_y", "eta_z"} and r["theta_z"] is None
            assert r["theta_z + eta_z_std"] > 0 and r["theta_x_crlb_std"] > 0 and r["converged"] is True
        if system == "gfimu":
            assert r["unobservable"] == "" and r["dr_x_1_crlb_std"] > 0 and r["rank"] == 50
        if system in ("rins", "gfimu"):
            # each estimate against the truth beside the unit, field by field, within 4σ
            assert r["truth_max_z"] is not None and r["truth_max_z"] < 4, r["truth_max_z"]
        if system == "attitude":
            assert r["converged"] is None and "yaw" in r["unobservable"] and r["n_samples"] == 501  # 5 s, 100 Hz
            # MPU-6000 noise: 0.16° of tilt per sample; the filtered tilt is well inside it
            assert r["inclination_rmse_deg"] < 0.16 and r["n_reference"] == 501
            assert r["roll_rmse"] < np.radians(0.16) and r["gyr_bias_x"] is not None


@pytest.mark.parametrize("system", list(SYSTEMS))
def test_dask_cluster_batch_against_truth_then_resumes(system, folders, cluster, tmp_path, capsys):
    words, options, cli_opts, _, names = SYSTEMS[system]
    d, out = folders[system], tmp_path / "results.csv"
    assert (
        main(
            [
                "--quiet",
                "batch",
                *words,
                str(d),
                "--out",
                str(out),
                "--reference",
                "--scheduler",
                cluster.scheduler_address,
                *cli_opts,
            ]
        )
        == 1
    )  # the corrupt unit failed
    assert f"{len(names) + 1} units: {len(names)} ok, 1 failed" in capsys.readouterr().out
    rows = read_results(out)
    _check_rows(system, rows)
    journal = tmp_path / "results.csv.journal.jsonl"
    before = journal.read_bytes()
    s = run_batch(d, out, options, reference=True, scheduler=cluster.scheduler_address, show_progress=False)
    assert (s.n_resumed, s.n_computed) == (len(names) + 1, 0) and journal.read_bytes() == before
    assert read_results(out) == rows


@pytest.mark.parametrize("system", list(SYSTEMS))
def test_killed_batch_loses_nothing_finished(system, folders, tmp_path):
    words, options, cli_opts, _, names = SYSTEMS[system]
    d, out = folders[system], tmp_path / "r.csv"
    journal = tmp_path / "r.csv.journal.jsonl"
    cmd = [
        sys.executable,
        "-m",
        "optinav.cli.main",
        "--quiet",
        "batch",
        *words,
        str(d),
        "--out",
        str(out),
        "--workers",
        "1",
        *cli_opts,
    ]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
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
    n = len(names) + 1
    assert 1 <= len(finished) <= n
    s = run_batch(d, out, options, workers=0, show_progress=False)
    assert s.n_resumed == len(finished) and s.n_computed == n - len(finished) and s.n_ok == len(names)
    for r in s.rows:
        if r["unit"] in finished:
            assert r == batch._complete(finished[r["unit"]])  # kept, not recomputed


def test_registry_system_options_are_checked_once(folders, tmp_path):
    from optinav.errors import OptinavError

    with pytest.raises(OptinavError, match="unknown method"):
        run_batch(folders["rins"], tmp_path / "r.csv", RinsOptions(method="nope"))
    with pytest.raises(OptinavError, match="not the gfimu system"):
        run_batch(folders["gfimu"], tmp_path / "r.csv", RinsOptions(), system="gfimu")
    with pytest.raises(OptinavError, match="no configuration"):
        run_batch(folders["gfimu"], tmp_path / "r.csv", GfimuOptions())
    assert not (tmp_path / "r.csv").exists()


def test_reference_far_from_the_truth_fails_the_unit(tmp_path, capsys):
    """With --reference a unit whose result lies far outside its std from the simulated truth was "ok" (the truth
    columns said 42 000 σ, the summary "0 failed", exit 0): it fails, with the reason."""
    import json

    d = tmp_path / "units"
    d.mkdir()
    for k in (1, 2):
        argv = ["--quiet", "simulate", "accel-multipos", "--out", str(d / f"u{k}.csv"), "--dwell", "5"]
        assert main(argv + ["--seed", str(k)]) == 0
    truth = json.loads((d / "u2.truth.json").read_text())
    truth["parameters"]["acc_K_xx"]["value"] += 0.05  # the truth beside u2 no longer is its truth: 5 % off
    (d / "u2.truth.json").write_text(json.dumps(truth))
    capsys.readouterr()
    out = tmp_path / "b.csv"
    assert main(["batch", "calibrate", "accel", str(d), "--reference", "--out", str(out), "--workers", "0"]) == 1
    text = capsys.readouterr().out
    assert "1 ok, 1 failed" in text and "u2: the result is" in text and "std from the simulated truth" in text
