"""`optinav reproduce gfimu --quick`: every check of the study passes."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_gfimu_quick_study_checks_pass(quick_report):
    st = quick_report.study("gfimu")
    assert not study_failures(st)
    assert len(st["tables"]) >= 5
    assert st["summary"]["table_stats"]["high"]["lm_pos_max"] < 1.0
