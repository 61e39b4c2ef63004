"""`optinav reproduce gfimu --quick`: every check of the study passes."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_gfimu_quick_study_checks_pass(quick_report):
    st = quick_report.study("gfimu")
    assert not study_failures(st)
    assert len(st["tables"]) >= 5
    worst = st["summary"]["table_stats"]["high"]["lm_pos_max"]
    assert worst["unit"] == "%" and worst["value"] < 1.0


def test_gfimu_closed_form_and_lm_on_the_same_samples(quick_report):
    st = quick_report.study("gfimu")
    same = st["summary"]["same_data"]
    for k in ("low", "high"):
        # LM lowers the worst position error on the same data; the closed form is within a factor 2 of it
        lm, cf = same[k]["lm_pos"]["value"], same[k]["cf_pos"]["value"]
        assert lm < cf < 2 * lm
    assert any(t["title"].startswith("Closed form vs optinav LM on the same data") for t in st["tables"])
