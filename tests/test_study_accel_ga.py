"""`optinav reproduce accel-ga --quick`: every check of the study passes (Table 1, accuracy, speed, efficiency)."""

import numpy as np

from optinav.reports import get_study


def test_accel_ga_quick_study_checks_pass():
    res = get_study("accel-ga")(quick=True, rng=np.random.default_rng(5))
    failed = [f"{c.name}: {c.value} vs {c.limit}" for c in res.checks if not c.passed]
    assert not failed, failed
    assert len(res.tables) >= 6 and len(res.figures) >= 3
    assert res.summary["table1_max_abs_diff"] < 1.5e-3
