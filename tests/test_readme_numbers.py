"""Every bold number of the README's studies table equals a headline number of the quick report."""

from readme_numbers import README, headline_values, matches, studies_table
from report_fixture import quick_report  # noqa: F401


def test_readme_table_parser():
    rows = studies_table("| `gfimu` | x | worst **0.30** % vs **0.25** %, not 1 |\n| other | **1** |")
    assert rows == {"gfimu": ["0.30", "0.25"]}
    assert matches("0.30", [0.3036]) and not matches("0.30", [0.306]) and matches("12", [12.2])


def test_readme_numbers_come_from_the_report(quick_report):
    rows = studies_table(README.read_text(encoding="utf-8"))
    summary = quick_report.summary["studies"]
    assert set(rows) == {"accel-ga", "rins-pso", "gfimu", "polarized"}
    for study, numbers in rows.items():
        assert numbers, f"{study}: no bold numbers in the README row"
        values = headline_values(summary[study])
        wrong = [n for n in numbers if not matches(n, values)]
        assert not wrong, f"{study}: README numbers {wrong} are not headline numbers of the report ({values})"
