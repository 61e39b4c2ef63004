"""`optinav simulate rins` → `optinav calibrate rins` end to end: angles vs truth within the reported std."""

import json

import numpy as np
import pytest

from optinav.cli.main import main

ARGS = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "100"]


@pytest.mark.parametrize("suffix,unit", [(".npz", "rad"), (".csv", "deg")])
def test_simulate_calibrate_round_trip(tmp_path, suffix, unit, capsys):
    p = np.array([1.0, -2.0, 3.0, -1.0, 2.0, 4.0]) * 1e-4
    text = ",".join(f"{x:.10g}" for x in (np.degrees(p) if unit == "deg" else p))
    data = tmp_path / f"r{suffix}"
    assert main(["--quiet", "simulate", "rins", "--nonorth", text, "--unit", unit, "--seed", "4", "--out", str(data),
                 *ARGS]) == 0
    truth = json.loads((tmp_path / "r.truth.json").read_text())
    np.testing.assert_allclose(list(truth["angles"].values()), p, rtol=1e-9)
    out = tmp_path / "res.json"
    rep = tmp_path / "rep"
    assert main(["--quiet", "calibrate", "rins", str(data), "--out", str(out), "--report", str(rep)]) == 0
    res = json.loads(out.read_text())
    assert res["method"] == "lm" and res["elapsed_s"] > 0
    assert set(res["angles"]) == {"theta_x", "theta_y", "theta_z", "eta_x", "eta_y", "eta_z"}
    assert res["angles"]["eta_y"] is None and res["angles"]["theta_z"] is None and res["angles"]["eta_z"] is None
    assert res["observability"]["rank"] == 4 and len(res["observability"]["null_space"]) == 2
    for nm in ("theta_x", "theta_y", "eta_x"):
        assert abs(res["angles"][nm] - truth["angles"][nm]) < 4 * res["angles_std"][nm], nm
    combo = [c for c in res["combinations"] if c["name"] == "theta_z + eta_z"][0]
    assert abs(combo["value"] - (p[2] + p[5])) < 4 * combo["std"]
    assert all(a < b for a, b in zip(res["rmse_after_deg"], res["rmse_before_deg"]))
    assert (rep / "index.md").is_file()


def test_cli_errors_are_one_line(tmp_path, capsys):
    data = tmp_path / "s.npz"
    assert main(["--quiet", "simulate", "rins", "--nonorth", "1e-4,0,0,0,0,0", "--scheme", "single4", "--align", "30",
                 "--dwell", "5", "--move", "4", "--rate", "50", "--out", str(data)]) == 0
    assert main(["--quiet", "calibrate", "rins", str(data), "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "only the inner (alpha) axis turns" in err and "Traceback" not in err
    assert main(["--quiet", "simulate", "rins", "--nonorth", "1,2,3", "--out", str(data)]) == 2
    assert main(["--quiet", "calibrate", "rins", str(tmp_path / "none.npz"), "--out", str(tmp_path / "r.json")]) == 2
