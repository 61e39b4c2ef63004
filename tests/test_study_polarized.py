"""The quick `polarized` study runs within budget and every check passes."""

import time

from optinav.reports.report import get_study


def test_polarized_quick_study_checks_pass():
    t0 = time.perf_counter()
    res = get_study("polarized")(quick=True)
    elapsed = time.perf_counter() - t0
    failed = [(c.name, c.value, c.limit) for c in res.checks if not c.passed]
    assert not failed, failed
    assert len(res.checks) >= 8 and len(res.tables) == 4 and len(res.figures) == 4
    assert elapsed < 25.0
    # Table 3 holds the improvement rows beside the paper's claims
    assert any("paper" in str(row[0]) for row in res.tables[3].rows)


def test_polarized_report_written(tmp_path):
    from optinav.reports.report import write_report

    res = get_study("polarized")(quick=True)
    out = write_report([res], tmp_path)
    text = (out / "index.md").read_text()
    assert "Table 3" in text and "FAIL" not in text
