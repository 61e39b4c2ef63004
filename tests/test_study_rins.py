"""`optinav reproduce rins-pso --quick`: every check passes (Table 4, units finding, observability, PSO Monte Carlo)."""

import numpy as np

from optinav.reports import get_study


def test_rins_pso_quick_study_checks_pass():
    res = get_study("rins-pso")(quick=True, rng=np.random.default_rng(5))
    failed = [f"{c.name}: {c.value} vs {c.limit}" for c in res.checks if not c.passed]
    assert not failed, failed
    assert len(res.tables) >= 5 and len(res.figures) == 5
    # Table 3 read as radians reproduces the paper's uncompensated yaw RMSE (0.9263°) within 5 %
    assert abs(res.summary["units_rmse_deg"]["rad"][2] / 0.9263 - 1) < 0.05
    assert res.summary["rmse_deg"]["lm"][2] < 0.01 * res.summary["rmse_deg"]["none"][2]
