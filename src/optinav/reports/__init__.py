"""Reports: studies produce tables, checks and figures; ``write_report`` turns them into a folder.

A study is a function ``study(quick: bool, rng) -> StudyResult`` registered with ``register_study`` under a name
(``optinav reproduce NAME``) and listed, with its module and description, in ``STUDIES``. Each study module keeps
apart its computation (``compute``: numbers), its acceptance limits (``LIMITS``: ``Limit`` values with the reason
for each), its ``summary`` (quantities ``{"value", "unit"}``, from ``quantity``), the ``tables`` (numbers in the
cells, formats per column), ``checks``, ``figures`` and ``headline`` (read from the summary with ``value_at``).
``write_report(results, out_dir)`` writes ``index.md``, ``index.html``, ``summary.json`` (every quantity, table
and check as numbers) and the PNG figures.
"""

from optinav.reports.report import (
    STUDIES,
    Cell,
    Check,
    Figure,
    Headline,
    Limit,
    StudyResult,
    Table,
    available_studies,
    check_report_dir,
    get_study,
    prepare_report_dir,
    quantity,
    register_study,
    rounded,
    run_studies,
    value_at,
    write_report,
)

__all__ = [
    "STUDIES",
    "Cell",
    "Check",
    "Figure",
    "Headline",
    "Limit",
    "StudyResult",
    "Table",
    "available_studies",
    "check_report_dir",
    "get_study",
    "prepare_report_dir",
    "quantity",
    "register_study",
    "rounded",
    "run_studies",
    "value_at",
    "write_report",
]
