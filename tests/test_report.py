"""The report that `optinav reproduce --quick` writes: headline first, plain prose, every figure, numbers in JSON."""

import json
import re

import numpy as np

from optinav.reports.report import (
    Cell,
    Check,
    Figure,
    Headline,
    Limit,
    StudyResult,
    Table,
    quantity,
    value_at,
    write_report,
)
from report_fixture import quick_report  # noqa: F401

MARKUP = re.compile(r":(func|class|data|meth|mod|attr):|\(issue \d+\)|as they are added|``")


def test_quick_report_headline_first_and_plain(quick_report):
    assert quick_report.returncode == 0, quick_report.stderr
    text = (quick_report.out / "index.md").read_text(encoding="utf-8")
    assert text.startswith("# optinav reproduce")
    sections = [line for line in text.splitlines() if line.startswith("## ")]
    assert sections[0] == "## Headline" and len(sections) == 1 + len(quick_report.summary["studies"])
    assert not MARKUP.findall(text), MARKUP.findall(text)[:5]
    for name, st in quick_report.summary["studies"].items():
        assert st["headline"], f"{name} has no headline numbers"
        for hl in st["headline"]:
            assert all(v is None or isinstance(v, (int, float)) for v in (hl["paper"], hl["rebuild"], hl["best"]))


def test_quick_report_writes_every_figure(quick_report):
    text = (quick_report.out / "index.md").read_text(encoding="utf-8")
    assert "Figure omitted" not in text
    pngs = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", text)
    assert len(pngs) >= 15
    assert all((quick_report.out / p).stat().st_size > 10_000 for p in pngs)


def test_write_report_headline_and_check_notes(tmp_path):
    def draw(fig):
        fig.add_subplot(111).plot([0, 1], [1, 0])

    r = StudyResult(
        "demo",
        "Demo study",
        "A study.",
        tables=[Table("t", ["a [m]"], [[1.5]])],
        checks=[Check("heading error", -676.0, 110.0, "arcsec", note="within 3σ of the filter")],
        figures=[Figure("demo.png", "a line", draw)],
        headline=[Headline("RMSE", "deg", 0.5, 0.4, 0.1)],
    )
    out = write_report([r], tmp_path)
    md = (out / "index.md").read_text(encoding="utf-8")
    assert md.index("## Headline") < md.index("## Demo study")
    assert "| demo | 1/1 | RMSE | 0.5 | 0.4 | 0.1 | deg |" in md
    assert "within 3σ of the filter" in md
    s = json.loads((out / "summary.json").read_text())["studies"]["demo"]
    assert s["headline"] == [{"quantity": "RMSE", "unit": "deg", "paper": 0.5, "rebuild": 0.4, "best": 0.1, "note": ""}]
    assert s["checks"][0]["note"] == "within 3σ of the filter"
    assert (out / "demo.png").stat().st_size > 1000


def test_progress_bars_only_when_wanted(capsys, monkeypatch):
    from optinav.core.progress import progress, step, task

    with task("study demo", enabled=True):
        step("first")
        assert list(progress(range(3), desc="runs", enabled=True)) == [0, 1, 2]
        step("second")
    err = capsys.readouterr().err
    assert "study demo" in err and "second" in err and "runs" in err
    monkeypatch.setenv("OPTINAV_QUIET", "1")
    with task("quiet"):
        step("x")
        assert list(progress(range(3))) == [0, 1, 2]
    assert capsys.readouterr().err == ""


def _number_text(s: str) -> bool:
    """Whether a string is a formatted number: one or more numbers, a number ± another, or a number and a unit."""
    toks = s.replace("−", "-").split()

    def num(t):
        try:
            float(t)
        except ValueError:
            return False
        return True

    if not toks:
        return False
    if "±" in s:
        return num(s.split("±")[0].strip().replace("−", "-"))
    return all(map(num, toks)) or (len(toks) == 2 and num(toks[0]) and len(toks[1]) <= 6)


def _numeric(v) -> bool:
    if isinstance(v, list):
        return all(map(_numeric, v))
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))


def summary_problems(node, path="summary") -> list[str]:
    """Where a study's summary breaks the layout: every number in a {value, unit} quantity (value a number, None
    or nested lists of them), no formatted numbers in strings, no bare numbers."""
    if isinstance(node, dict) and set(node) == {"value", "unit"}:
        ok = _numeric(node["value"]) and isinstance(node["unit"], str)
        return [] if ok else [f"{path}: malformed quantity {node}"]
    if isinstance(node, dict):
        return [p for k, v in node.items() for p in summary_problems(v, f"{path}.{k}")]
    if isinstance(node, list):
        return [p for k, v in enumerate(node) for p in summary_problems(v, f"{path}[{k}]")]
    if isinstance(node, str):
        return [f"{path}: formatted number {node!r}"] if _number_text(node) else []
    return [f"{path}: {node!r} without a unit"]


def table_problems(table: dict) -> list[str]:
    """Table cells of summary.json that are formatted numbers (cells hold the numbers; the report formats them)."""

    def walk(v, where):
        if isinstance(v, str):
            return [f"{where}: formatted number {v!r}"] if _number_text(v) else []
        if isinstance(v, dict):
            return [p for k, x in v.items() for p in walk(x, f"{where}.{k}")]
        if isinstance(v, list):
            return [p for x in v for p in walk(x, where)]
        return []

    return [p for i, row in enumerate(table["rows"]) for p in walk(row, f"{table['title'][:40]!r} row {i}")]


def test_layout_rules_catch_formatted_numbers():
    assert _number_text("0.262") and _number_text("1.5e-3 2.0") and _number_text("12.2 %")
    assert _number_text("0.1 ± 0.02") and _number_text("−0.5")
    assert not _number_text("0.1/0.2") and not _number_text("PSO, 2 Hz epochs") and not _number_text("—")
    assert (
        summary_problems(
            {"a": quantity(0.262, "%"), "b": {"c": quantity([1.0, None], "deg")}, "why": "skipped: no data"}
        )
        == []
    )
    assert len(summary_problems({"a": "0.262", "b": 3.0, "c": {"value": "1.0", "unit": "%"}})) == 3
    assert table_problems({"title": "t", "rows": [["x", 1.0, None, {"gain": 0.1}], ["y", "0.25"]]}) == [
        "'t' row 1: formatted number '0.25'"
    ]


def test_summary_json_holds_numbers_with_units(quick_report):
    """summary.json of the quick report: quantities with units, tables and checks of numbers, headline of numbers
    that the summary holds."""
    for name, st in quick_report.summary["studies"].items():
        problems = summary_problems(st["summary"], f"{name}.summary")
        problems += [p for t in st["tables"] for p in table_problems(t)]
        problems += [
            f"{name}: check {c['name']!r}"
            for c in st["checks"]
            if not (_numeric(c["value"]) and _numeric(c["limit"]) and isinstance(c["unit"], str))
        ]
        assert not problems, problems[:10]
        assert st["summary"] and all(c["reason"] for c in st["checks"]), f"{name}: a limit without its reason"


def test_quantities_and_headline_from_summary(tmp_path):
    s = {"rmse": {"lm": quantity(np.float64(0.5), "deg"), "nan": quantity(float("nan"), "deg")}}
    assert s["rmse"]["lm"] == {"value": 0.5, "unit": "deg"} and type(s["rmse"]["lm"]["value"]) is float
    assert s["rmse"]["nan"]["value"] is None and value_at(s, "rmse.lm") == 0.5
    t = Table(
        "t",
        ["a", "b", "c", "d"],
        [[1 / 3, [0.25, 0.5], {"gain": 0.033}, Cell(2.0, "{:.1f} s")], [None, True, "x", 4]],
        formats=["{:.3f}", "{:.1f}", "{:g}"],
    )
    assert t.text_rows() == [["0.333", "0.2 0.5", "gain = 0.033", "2.0 s"], ["—", "yes", "x", "4"]]
    c = Check.against("err", 0.3, Limit(0.25, unit="deg", reason="4σ"))
    assert not c.passed and c.reason == "4σ" and c.limit == 0.25 and c.unit == "deg"
    assert Check.against("n", 12, Limit(None, ">=", reason="computed"), at=10).passed
    r = StudyResult(
        "demo",
        "Demo",
        "A study.",
        tables=[t],
        checks=[c],
        summary=s,
        headline=[Headline("RMSE", "deg", None, value_at(s, "rmse.lm"), None)],
    )
    out = write_report([r], tmp_path)
    md = (out / "index.md").read_text(encoding="utf-8")
    assert "| 0.333 | 0.2 0.5 | gain = 0.033 | 2.0 s |" in md and "| demo | 0/1 | RMSE | — | 0.5 | — | deg |" in md
    js = json.loads((out / "summary.json").read_text())["studies"]["demo"]
    assert js["tables"][0]["rows"][0] == [1 / 3, [0.25, 0.5], {"gain": 0.033}, 2.0]
    assert js["summary"]["rmse"]["lm"] == {"value": 0.5, "unit": "deg"} and js["checks"][0]["reason"] == "4σ"


def test_a_study_draws_the_same_alone_as_among_others(monkeypatch):
    """Each study's generator comes from (seed, its name): running one study alone (``reproduce rins-pso``)
    gives the numbers it has in ``reproduce all``, whatever runs before it."""
    from types import SimpleNamespace

    from optinav.reports import report

    def study(quick, rng):
        return SimpleNamespace(draws=rng.standard_normal(3))

    monkeypatch.setattr(report, "get_study", lambda name: study)
    together = report.run_studies(["core", "accel-ga", "gfimu"], seed=7)
    alone = report.run_studies(["gfimu"], seed=7)
    other_seed = report.run_studies(["gfimu"], seed=8)
    assert np.array_equal(together[2].draws, alone[0].draws)
    assert not np.array_equal(together[0].draws, together[2].draws)
    assert not np.array_equal(alone[0].draws, other_seed[0].draws)


def test_a_report_folder_keeps_files_a_report_did_not_write(tmp_path, capsys):
    """``optinav report RESULT --out DIR`` replaced the user's own index.md and summary.json in DIR with exit 0, and
    an error named "--report", an option that command has not. A folder holding someone else's report file is
    refused (exit 2, the file unchanged, naming --out); an earlier report there is replaced."""
    from optinav.cli.main import main

    s = str(tmp_path)
    assert main(["--quiet", "simulate", "accel-multipos", "--out", f"{s}/s.csv", "--scheme", "18", "--seed", "3"]) == 0
    assert main(["--quiet", "calibrate", "accel", f"{s}/s.csv", "--out", f"{s}/r.json"]) == 0
    for k, (name, text) in enumerate(
        (("index.md", "my notes\n"), ("summary.json", '{"a": 1}\n'), ("index.html", "x\n"))
    ):
        d = tmp_path / f"mine{k}"
        d.mkdir()
        (d / name).write_text(text)
        capsys.readouterr()
        assert main(["report", f"{s}/r.json", "--out", str(d)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "is not a file an optinav report writes" in err and "--out" in err, err
        assert (
            "--report" not in err and (d / name).read_text() == text and sorted(p.name for p in d.iterdir()) == [name]
        )
    d = tmp_path / "again"
    assert main(["--quiet", "report", f"{s}/r.json", "--out", str(d)]) == 0
    first = (d / "summary.json").read_text()
    assert main(["--quiet", "report", f"{s}/r.json", "--out", str(d)]) == 0  # its own earlier report: replaced
    assert json.loads((d / "summary.json").read_text())["schema"] == json.loads(first)["schema"]


def test_a_pose_plan_or_a_truth_file_is_named_not_an_unknown_schema(tmp_path, capsys):
    """`report plan.json` said "unknown result schema 'optinav.pose_plan'; upgrade optinav" of optinav's own plan,
    and a simulation's truth file "no 'schema'/'fields' keys" though it has a schema: each is named for what it is."""
    from optinav.cli.main import main

    plan, sim = tmp_path / "plan.json", tmp_path / "s.csv"
    assert main(["--quiet", "design", "--poses", "12", "--preset", "mems-mti1", "--out", str(plan)]) == 0
    assert main(["--quiet", "simulate", "accel-multipos", "--out", str(sim), "--dwell", "4", "--seed", "1"]) == 0
    capsys.readouterr()
    for path, what in ((plan, "is a pose plan (optinav design"), (sim.with_name("s.truth.json"), "simulation's truth")):
        assert main(["--quiet", "report", str(path), "--out", str(tmp_path / "rep")]) == 2
        err = capsys.readouterr().err
        assert what in err and "not a calibration or estimate result" in err and err.count("\n") == 1, err
