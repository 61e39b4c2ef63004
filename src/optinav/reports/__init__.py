"""Reports: studies produce tables, checks and figures; ``write_report`` turns them into a folder.

A study is a function ``study(quick: bool, rng) -> StudyResult`` registered with ``register_study``
under a name (``optinav reproduce NAME``) and listed, with its module and description, in ``STUDIES``. ``write_report(results, out_dir)`` writes ``index.md``,
``index.html``, ``summary.json`` (every table's numbers and every check) and the PNG figures.
"""

from optinav.reports.report import (STUDIES, Check, Figure, Headline, StudyResult, Table, available_studies, get_study,
                                    prepare_report_dir, register_study, write_report)

__all__ = ["STUDIES", "Check", "Figure", "Headline", "StudyResult", "Table", "available_studies", "get_study", "prepare_report_dir",
           "register_study", "write_report"]
