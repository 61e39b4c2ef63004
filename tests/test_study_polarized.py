"""The quick `polarized` study runs within budget and every check passes."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_polarized_quick_study_checks_pass(quick_report):
    st = quick_report.study("polarized")
    assert not study_failures(st)
    assert len(st["checks"]) >= 8 and len(st["tables"]) >= 4
    assert st["elapsed_s"] < 40.0
    # Table 3 holds the improvement rows beside the paper's claims
    t3 = next(t for t in st["tables"] if t["title"].startswith("Table 3"))
    assert any("paper" in str(row[0]) for row in t3["rows"])
