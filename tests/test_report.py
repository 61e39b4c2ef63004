"""The report that `optinav reproduce --quick` writes: headline first, plain prose, every figure, numbers in JSON."""

import json
import re

from optinav.reports.report import Check, Figure, Headline, StudyResult, Table, write_report
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

    r = StudyResult("demo", "Demo study", "A study.", tables=[Table("t", ["a [m]"], [[1.5]])],
                    checks=[Check("heading error", -676.0, 110.0, "arcsec", note="within 3σ of the filter")],
                    figures=[Figure("demo.png", "a line", draw)],
                    headline=[Headline("RMSE", "deg", 0.5, 0.4, 0.1)])
    out = write_report([r], tmp_path)
    md = (out / "index.md").read_text(encoding="utf-8")
    assert md.index("## Headline") < md.index("## Demo study")
    assert "| demo | 1/1 | RMSE | 0.5 | 0.4 | 0.1 | deg |" in md
    assert "within 3σ of the filter" in md
    s = json.loads((out / "summary.json").read_text())["studies"]["demo"]
    assert s["headline"] == [{"quantity": "RMSE", "unit": "deg", "paper": 0.5, "rebuild": 0.4, "best": 0.1,
                              "note": ""}]
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
