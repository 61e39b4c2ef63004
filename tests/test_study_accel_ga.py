"""`optinav reproduce accel-ga --quick`: every check of the study passes (Table 1, accuracy, speed, efficiency)."""

from report_fixture import quick_report, study_failures  # noqa: F401


def test_accel_ga_quick_study_checks_pass(quick_report):
    st = quick_report.study("accel-ga")
    assert not study_failures(st)
    assert len(st["tables"]) >= 6
    assert st["summary"]["table1_max_abs_diff"]["value"] < 1.5e-3


def test_accel_ga_findings_table(quick_report):
    st = quick_report.study("accel-ga")
    t = next(t for t in st["tables"] if t["title"].startswith("The paper's head-to-head findings"))
    assert len(t["rows"]) == 5 and all(isinstance(r[3], bool) for r in t["rows"])
    assert st["summary"]["findings_reproduced"]["value"] == sum(r[3] for r in t["rows"])


def test_paper_ga_operators_converge():
    import numpy as np

    from optinav.core.optimize import Problem, minimize

    t = np.linspace(0, 1, 50)
    y = 2.0 * np.exp(-3.0 * t)
    problem = Problem(
        residuals=lambda x: x[0] * np.exp(-x[1] * t) - y, x0=[1.0, 1.0], search_interval=([0.0, 0.0], [5.0, 10.0])
    )
    r = minimize(problem, method="ga", rng=0, operators="paper", generations=300)
    assert np.allclose(r.x, [2.0, 3.0], atol=0.05)
