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


def test_accel_ga_every_method_budget_and_ga_seeds(quick_report):
    """Both GAs run on one seed set with the same population and generations, and the headline quotes the
    median over those seeds (not one run)."""
    import numpy as np

    st = quick_report.study("accel-ga")
    seeds, budget = st["summary"]["ga_seeds"], st["summary"]["budget"]
    paper, ours = seeds["ga"]["seeds"]["value"], seeds["ga_optinav"]["seeds"]["value"]
    assert len(paper) >= 9 and len(ours) >= 3 and ours == paper[: len(ours)]
    for k in ("generations", "population"):
        assert budget["ga"][k]["value"] == budget["ga_optinav"][k]["value"]
    assert {"newton", "lm"} <= set(budget) and all(budget[m]["iterations"]["value"] >= 1 for m in ("newton", "lm"))
    head = {h["quantity"]: h for h in st["headline"]}
    for part in ("bias", "scale"):
        runs = seeds["ga"][f"worst_{part}_error"]["value"]
        name = "worst bias relative error" if part == "bias" else "worst scale-factor relative error"
        assert head[name]["rebuild"] == float(np.median(runs))
