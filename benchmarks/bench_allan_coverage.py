"""Coverage of the 68 % intervals of `optinav allan` (four-term fit, IEEE 952 read-off, Kalibr keys) on simulated
static logs: the fraction of records whose interval holds the true N, B and K, per axis, for a long record and one
that ends near the random-walk upturn (``optinav.core.allan_coverage``). Target: 60–76 % for the fit and Kalibr.
Quick: 40 records per design; full: 200. Writes ``benchmarks/results_allan_coverage.json`` and ``.md``.
"""

from __future__ import annotations

import json
from pathlib import Path

HERE = Path(__file__).resolve().parent


def run(quick: bool) -> list[dict]:
    from optinav.core.allan_coverage import DESIGNS, coverage

    n = 40 if quick else 200
    rows = []
    for d in DESIGNS:
        cov = coverage(d, range(10_000, 10_000 + n))
        for method, terms in cov.items():
            for term, hits in terms.items():
                axes = hits.mean(axis=0).reshape(-1)
                labels = ["x", "y", "z"] if axes.size == 3 else ["largest axis"]
                for lab, v in zip(labels, axes):
                    rows.append(
                        {
                            "group": f"Allan 68 % coverage, {d.name}, {n} records",
                            "method": method,
                            "metric": f"{term} {lab}",
                            "value": float(v),
                            "unit": "1",
                        }
                    )
    if not quick:
        (HERE / "results_allan_coverage.json").write_text(json.dumps({"records": n, "rows": rows}, indent=2) + "\n")
        lines = ["| design | method | term / axis | coverage |", "| --- | --- | --- | --- |"]
        lines += [
            f"| {r['group'].split(', ')[1]} | {r['method']} | {r['metric']} | {r['value']:.0%} |"
            for r in rows
            if r["method"] != "misfit"
        ]
        lines += [
            "",
            "Fraction of the clean axis fits whose χ² was significant, so that the fit added a model error (expected:",
            "the test's level, 10 %):",
            "",
            "| design | axis | flagged |",
            "| --- | --- | --- |",
        ]
        lines += [
            f"| {r['group'].split(', ')[1]} | {r['metric'].split()[-1]} | {r['value']:.0%} |"
            for r in rows
            if r["method"] == "misfit"
        ]
        (HERE / "results_allan_coverage.md").write_text(
            f"# Coverage of the 68 % Allan intervals ({n} simulated records per design)\n\n" + "\n".join(lines) + "\n"
        )
    return rows
