"""`optinav reproduce gfimu --quick`: every check of the study passes."""

import numpy as np

from optinav.reports import get_study


def test_gfimu_quick_study_checks_pass():
    res = get_study("gfimu")(quick=True, rng=np.random.default_rng(5))
    failed = [f"{c.name}: {c.value} vs {c.limit}" for c in res.checks if not c.passed]
    assert not failed, failed
    assert len(res.tables) >= 5 and len(res.figures) == 2
    assert res.summary["table_stats"]["high"]["lm_pos_max"] < 1.0
