"""`optinav reproduce accel-ga --quick`: every check of the study passes (Table 1, accuracy, speed, efficiency)."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_accel_ga_quick_study_checks_pass(quick_report):
    st = quick_report.study("accel-ga")
    assert not study_failures(st)
    assert len(st["tables"]) >= 6
    assert st["summary"]["table1_max_abs_diff"] < 1.5e-3
