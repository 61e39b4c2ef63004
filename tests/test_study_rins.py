"""`optinav reproduce rins-pso --quick`: every check passes (Table 4, units finding, observability, PSO Monte Carlo)."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_rins_pso_quick_study_checks_pass(quick_report):
    st = quick_report.study("rins-pso")
    assert not study_failures(st)
    assert len(st["tables"]) >= 5
    s = st["summary"]
    # Table 3 read as radians reproduces the paper's uncompensated yaw RMSE (0.9263°) within 5 %
    assert abs(s["units_rmse_deg"]["rad"][2] / 0.9263 - 1) < 0.05
    assert s["rmse_deg"]["lm"][2] < 0.01 * s["rmse_deg"]["none"][2]
