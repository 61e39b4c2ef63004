"""Study results and the report writer (Markdown, HTML, JSON, PNG).

A study keeps four things apart: its computation (numbers, with units in ``summary``), its acceptance limits
(``Limit`` values with the reason for each, one dict per study), the formatting of those numbers into ``Table``
cells (per-column formats; the cells stay numbers) and its ``Figure`` drawings. ``write_report`` renders the
tables and writes ``summary.json``, whose quantities are ``{"value": number | list | None, "unit": str}``.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import html
import importlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from optinav.core.files import atomic_path, describe, write_text
from optinav.errors import OptinavError


def plain(value: Any) -> Any:
    """``value`` as plain JSON types (``optinav.core.results.plain``, imported when needed: listing the studies
    for ``--help`` loads no numpy)."""
    from optinav.core.results import plain as to_plain

    return to_plain(value)


def quantity(value: Any, unit: str) -> dict[str, Any]:
    """A number (or array of numbers) with its unit, as ``summary.json`` holds it: ``{"value", "unit"}``; NaN and
    inf become ``None`` (JSON has no NaN)."""
    return {"value": plain(value), "unit": unit}


#: a cell format: a ``str.format`` pattern (``"{:.3f}"``) or a function of the cell value returning its text
CellFormat = str | Callable[[Any], str] | None


@dataclass(frozen=True)
class Cell:
    """A table cell with its own format (where one cell of a column is written differently from the rest); a
    function as ``fmt`` receives the whole value (a dict or list too)."""

    value: Any
    fmt: CellFormat = None


def _cell_values(rows: list[list[Any]]) -> list[list[Any]]:
    """The rows with every ``Cell`` replaced by its value (for ``summary.json``)."""
    return [[c.value if isinstance(c, Cell) else c for c in row] for row in rows]


@dataclass
class Table:
    """A table of a study: ``columns`` names (with units in brackets), ``rows`` lists of cells.

    Cells hold numbers (``None`` shows as "—", booleans as yes/no), text, or lists and dicts of numbers; ``formats``
    gives per column how a number is written (default: 7 significant digits), so ``summary.json`` keeps the
    numbers themselves."""

    title: str
    columns: list[str]
    rows: list[list[Any]]
    note: str = ""
    formats: list[CellFormat] | None = None

    def text_rows(self) -> list[list[str]]:
        """The cells as the report writes them."""
        fmts = self.formats or []
        return [[_cell(c, fmts[j] if j < len(fmts) else None) for j, c in enumerate(row)] for row in self.rows]


@dataclass(frozen=True)
class Limit:
    """An acceptance limit of a study: a value must be ``<= value`` (or ``>=``, by ``kind``), in ``unit``;
    ``reason``: why the limit is where it is (the theory, noise level or published value it comes from).
    ``value=None``: the limit is computed by the study from its data (the reason says how)."""

    value: float | None
    kind: str = "<="
    unit: str = ""
    reason: str = ""


@dataclass
class Check:
    """A number compared with the limit it must meet (``value <= limit`` unless ``kind='>='``).

    ``note``: one line for the reader when a passing value looks alarming (why it is right)."""

    name: str
    value: float
    limit: float
    unit: str = ""
    kind: str = "<="
    note: str = ""
    reason: str = ""

    @classmethod
    def against(cls, name: str, value: float, limit: Limit, note: str = "", at: float | None = None) -> "Check":
        """``value`` checked against the study's ``limit`` (at the computed value ``at`` for a limit whose
        value the study computes)."""
        bound = limit.value if at is None else at
        if bound is None:
            raise ValueError(f"the limit of check {name!r} is computed by the study: pass at=")
        return cls(name, value, bound, limit.unit, limit.kind, note, limit.reason)

    @property
    def passed(self) -> bool:
        v, lim = float(self.value), float(self.limit)
        if not (math.isfinite(v) and math.isfinite(lim)):
            return False
        return v <= lim if self.kind == "<=" else v >= lim


@dataclass
class Figure:
    """A figure: ``draw(fig)`` fills a matplotlib figure; saved as ``filename`` (PNG)."""

    filename: str
    caption: str
    draw: Callable[[Any], None]
    size: tuple[float, float] = (7.0, 4.0)


def value_at(summary: dict[str, Any], path: str) -> Any:
    """The value of the quantity at ``path`` ("a.b.c") of a study's summary (headline values are read this way,
    so the headline shows the numbers ``summary.json`` holds)."""
    node: Any = summary
    for key in path.split("."):
        node = node[key]
    return node["value"]


@dataclass
class Headline:
    """One headline number of a study: the paper's value, optinav's rebuild of the paper's method and optinav's
    best method, measured on the same data (None where a column does not apply). Studies build their headline from
    their summary's quantities (``value_at``)."""

    quantity: str
    unit: str
    paper: float | None
    rebuild: float | None
    best: float | None
    note: str = ""


@dataclass
class StudyResult:
    """What one study reproduced: text, tables, checks, figures and its summary (nested dicts of quantities from
    ``quantity``)."""

    name: str
    title: str
    description: str = ""
    tables: list[Table] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    elapsed: float = 0.0
    headline: list[Headline] = field(default_factory=list)


#: study name → (module that registers it, one-line description). Listing the studies (``--help``) reads only
#: this table; a study's module, with its heavy imports, is loaded when the study runs.
STUDIES: dict[str, tuple[str, str]] = {
    "core": (
        "optinav.reports.core_study",
        "shared core: Earth model, rotations, IMU noise, strapdown coning, alignment vs theory",
    ),
    "accel-ga": (
        "optinav.reports.accel_ga_study",
        "Gao & Zhang 2019: accelerometer norm-observation calibration, GA vs Newton vs optinav LM",
    ),
    "rins-pso": (
        "optinav.reports.rins_study",
        "Li et al. 2023: dual-axis rotational INS gimbal non-orthogonality, PSO vs axis method vs LM",
    ),
    "gfimu": (
        "optinav.reports.gfimu_study",
        "Hao & Liu 2011: gyro-free 10-accelerometer array, 50 installation errors on a turntable",
    ),
    "polarized": (
        "optinav.reports.polarized_study",
        "Jin et al. 2021: MIMU + skylight polarization attitude, GD vs CG vs QN vs MEKF",
    ),
}

_REGISTERED: dict[str, Callable[..., StudyResult]] = {}


def register_study(name: str):
    """Decorator registering ``fn(quick: bool, rng) -> StudyResult`` as study ``name`` (listed in STUDIES)."""

    def deco(fn):
        _REGISTERED[name] = fn
        return fn

    return deco


def available_studies() -> dict[str, str]:
    """Study names → one-line descriptions, without importing the studies."""
    return {k: v[1] for k, v in STUDIES.items()}


def get_study(name: str) -> Callable[..., StudyResult]:
    """The study function ``name`` (imports its module)."""
    if name not in STUDIES:
        raise OptinavError(f"unknown study {name!r}", f"choose one of: {', '.join(sorted(STUDIES))}, or 'all'")
    importlib.import_module(STUDIES[name][0])
    return _REGISTERED[name]


def run_studies(
    names,
    *,
    quick: bool = False,
    seed: int = 2026,
    data_dir: str | Path | None = None,
    announce: Callable[[str], None] | None = None,
) -> list[StudyResult]:
    """Run registered studies (what ``optinav reproduce`` does before writing the report).

    Parameters
    ----------
    names : list of str
        Study names (an unknown one fails before any work).
    quick : bool
        The smaller version of each study.
    seed : int
        Seed of every study's generator; a study's own generator is seeded by ``(seed, CRC-32 of its name)``, so a
        study draws the same numbers run alone as in ``reproduce all``.
    data_dir : str, Path or None
        The real-data folder, for the studies that read one.
    announce : callable or None
        ``announce(name)`` is called as each study starts.

    Returns
    -------
    list of StudyResult
        In the order of ``names``; each ``elapsed`` is its wall time [s].
    """
    import inspect
    import zlib

    import numpy as np

    from optinav.core.progress import task

    fns = [(n, get_study(n)) for n in names]
    results = []
    for k, (name, fn) in enumerate(fns, 1):
        if announce is not None:
            announce(name)
        t0 = time.perf_counter()
        extra = (
            {"data_dir": Path(data_dir)}
            if data_dir is not None and "data_dir" in inspect.signature(fn).parameters
            else {}
        )
        with task(f"study {k}/{len(fns)} {name}"):
            r = fn(quick=quick, rng=np.random.default_rng([seed, zlib.crc32(name.encode())]), **extra)
        r.elapsed = time.perf_counter() - t0
        results.append(r)
    return results


def _fmt(x: Any) -> str:
    """The default text of a value: 7 significant digits, "—" for ``None``, yes/no for booleans."""
    if x is None:
        return "—"
    if hasattr(x, "dtype") and getattr(x, "ndim", 1) == 0:
        x = x.item()  # a NumPy scalar
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, float):
        if x == 0 or not math.isfinite(x):
            return str(x)
        return f"{x:.7g}" if (abs(x) >= 1e-3 and abs(x) < 1e7) else f"{x:.4e}"
    return str(x)


def _cell(x: Any, fmt: CellFormat = None) -> str:
    """The text of a table cell under the column format ``fmt``: text as it is; a list, its items formatted and
    joined by spaces; a dict (settings), ``key = value`` pairs."""
    if isinstance(x, Cell):  # a function formats the whole value (e.g. a value with its std), a pattern each number
        return x.fmt(x.value) if callable(x.fmt) else _cell(x.value, x.fmt)
    if isinstance(x, str):
        return x
    if x is None:
        return "—"
    if isinstance(x, dict):
        return ", ".join(f"{k} = {_cell(v, fmt)}" for k, v in x.items())
    if isinstance(x, (list, tuple)) or getattr(x, "ndim", 0) > 0:
        return " ".join(_cell(v, fmt) for v in x)
    if fmt is None or isinstance(x, bool) or getattr(x, "dtype", None) == bool:
        return _fmt(x)
    return fmt.format(x) if isinstance(fmt, str) else fmt(x)


def rounded(decimals: int) -> Callable[[Any], str]:
    """A cell format: the value rounded to ``decimals``, then written with the default 7 significant digits."""
    return lambda x: _fmt(round(float(x), decimals))


def break_wraps(t, y, jump: float = 180.0):
    """(t, y) of a line plot of an angle wrapped to ±180° [deg], with NaN where consecutive samples differ by more
    than ``jump`` deg (the shortest way between them crosses the wrap), so no vertical line joins the ±180° edges."""
    import numpy as np

    y = np.asarray(y, float).copy()
    y[1:][np.abs(np.diff(y)) > jump] = np.nan
    return t, y


def _md(x: Any) -> str:
    """A Markdown table cell: formatted, with pipes escaped."""
    return _fmt(x).replace("|", "\\|")


def _headline(results: list[StudyResult]) -> tuple[list[str], list[str]]:
    """The table at the top of the report: per study its checks and headline numbers (Markdown, HTML)."""
    cols = [
        "study",
        "checks passed",
        "quantity",
        "paper",
        "optinav rebuild of the paper's method",
        "optinav best",
        "unit",
    ]
    md = [
        "## Headline",
        "",
        "Each row compares methods on the same simulated data; the paper's value is from its own experiment.",
        "",
        "| " + " | ".join(cols) + " |",
        "|---|---|---|---:|---:|---:|---|",
    ]
    h = ["<h2>Headline</h2><table><tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cols) + "</tr>"]
    for r in results:
        ok = f"{sum(c.passed for c in r.checks)}/{len(r.checks)}"
        rows = r.headline or [Headline("—", "", None, None, None)]
        for k, hl in enumerate(rows):
            cells = [
                r.name if k == 0 else "",
                ok if k == 0 else "",
                hl.quantity,
                *("—" if v is None else f"{float(v):.3g}" for v in (hl.paper, hl.rebuild, hl.best)),
                hl.unit,
            ]
            md.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
            h.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    md.append("")
    h.append("</table>")
    return md, h


def _save_figures(study: StudyResult, out: Path) -> list[tuple[Figure, str | None]]:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return [(f, None) for f in study.figures]
    saved = []
    for f in study.figures:
        fig = plt.figure(figsize=f.size)
        try:
            f.draw(fig)
            fig.tight_layout()
            with atomic_path(out / f.filename, _OPTION.get()) as tmp:
                fig.savefig(tmp, dpi=110)
            saved.append((f, f.filename))
        finally:
            plt.close(fig)
    return saved


#: the CLI option that names the report folder in errors: ``--report`` beside a command's output, ``--out`` for
#: ``optinav report`` and ``reproduce`` (:func:`report_option`)
_OPTION: contextvars.ContextVar[str] = contextvars.ContextVar("optinav_report_option", default="--report")


@contextlib.contextmanager
def report_option(option: str):
    """Within the block, the report folder's errors name ``option`` (``"--out"`` for the commands whose output is the
    report): ``optinav report RESULT --out DIR`` was told to "choose another --report", an option it has not."""
    token = _OPTION.set(option)
    try:
        yield
    finally:
        _OPTION.reset(token)


#: the warnings and notes the command said on the console before its report, (kind, message) each: the report
#: keeps them (a reader of BROAD 02's report alone did not see the console's warning that its frame is ENU)
_CONSOLE: contextvars.ContextVar[tuple] = contextvars.ContextVar("optinav_console", default=())


@contextlib.contextmanager
def console_said(messages):
    """Within the block, :func:`write_report` adds ``messages`` ((kind, text) each) as a section of the report and
    ``console`` in summary.json."""
    token = _CONSOLE.set(tuple((str(k), str(m)) for k, m in messages))
    try:
        yield
    finally:
        _CONSOLE.reset(token)


def _ours(path: Path) -> bool:
    """Whether the report file ``path`` (one of :data:`REPORT_FILES`) is one an optinav report wrote."""
    try:
        text = path.read_bytes().decode("utf-8", "replace")
    except OSError:
        return False
    if path.name == "summary.json":
        try:
            return json.loads(text).get("schema") == REPORT_SCHEMA
        except (ValueError, AttributeError):
            return False
    head = text[:4096]
    if path.name == "index.html":
        return head.startswith("<!doctype html><meta charset='utf-8'><title>") and "optinav" in head[:300]
    return head.startswith("# ") and " by optinav " in "\n".join(head.splitlines()[:3])


def check_report_dir(out_dir: str | Path, option: str | None = None) -> Path:
    """Check, without creating anything, that the report folder can be made and written: it is a writable folder,
    or the nearest folder above it that exists is (so a bad path fails before any work and leaves nothing behind),
    and the report files it holds (:data:`REPORT_FILES`) are an optinav report's, which it replaces.

    Parameters
    ----------
    out_dir : str or Path
        The report folder; :func:`prepare_report_dir` makes it when the report is written.
    option : str or None
        The CLI option that names it, for the remedy of an error (None: :func:`report_option`'s, ``--report``).

    Returns
    -------
    Path
        ``out_dir``, unchanged.
    """
    option = option or _OPTION.get()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OptinavError(f"the report folder {out} is a file", f"choose another {option}")
    for name in REPORT_FILES if out.is_dir() else ():
        f = out / name
        if (f.exists() or f.is_symlink()) and not (f.is_file() and _ours(f)):
            # a folder of the user's own notes lost its index.md and summary.json to a report with exit 0
            raise OptinavError(
                f"{f} exists and is not a file an optinav report writes: the report would replace it",
                f"choose another {option} (an empty or new folder, or one holding an earlier report)",
            )
    up = out
    while not up.exists() and up != up.parent:
        up = up.parent
    if not up.is_dir():
        raise OptinavError(f"cannot create report folder {out}: {up} is a file", f"choose another {option}")
    if not os.access(up, os.W_OK | os.X_OK):
        where = f"the report folder {out}" if up == out else f"{up} (to make the report folder {out})"
        raise OptinavError(f"cannot write into {where}: permission denied", f"choose a writable {option}")
    return out


#: the files every report writes into its folder, besides its figures (``*.png``)
REPORT_FILES = ("index.md", "index.html", "summary.json")


def report_writes(out_dir: str | Path, path: str | Path) -> bool:
    """Whether a report written into ``out_dir`` would replace ``path``: one of :data:`REPORT_FILES` or a figure
    (``*.png``) directly in that folder.

    Parameters
    ----------
    out_dir : str or Path
        The report folder (it need not exist yet).
    path : str or Path
        Another output of the command.

    Returns
    -------
    bool
        True when the report would write ``path``.
    """
    p = Path(path)
    if Path(out_dir).resolve() != p.parent.resolve():
        return False
    return p.name in REPORT_FILES or p.suffix.lower() == ".png"


def prepare_report_dir(out_dir: str | Path, option: str | None = None) -> Path:
    """Create the report folder and check it is writable (when the report is written; :func:`check_report_dir`
    checks the path before the work)."""
    option = option or _OPTION.get()
    out = check_report_dir(out_dir, option)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptinavError(
            f"cannot create report folder {out}: {describe(exc)}", f"choose a writable {option}"
        ) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise OptinavError(
            f"cannot write into the report folder {out}: permission denied", f"choose a writable {option}"
        )
    return out


#: the layout of a report's summary.json
REPORT_SCHEMA, REPORT_VERSION = "optinav.report_summary", 1


def write_report(results: list[StudyResult], out_dir: str | Path, *, title: str = "optinav report") -> Path:
    """Write ``index.md``, ``index.html``, ``summary.json`` and PNGs for ``results`` into ``out_dir``."""
    from optinav import __version__

    out = prepare_report_dir(out_dir)
    written = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    md = [f"# {title}", "", f"Written {written} by optinav {__version__}.", ""]
    h = [
        f"<!doctype html><meta charset='utf-8'><title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;max-width:60em;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #999;padding:2px 6px;text-align:right}th{background:#eee}"
        ".fail{color:#b00}.pass{color:#070}</style>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    # which optinav wrote the numbers, and when (summary.json had neither: reports of two versions compared blind)
    summary: dict[str, Any] = {
        "schema": REPORT_SCHEMA,
        "version": REPORT_VERSION,
        "optinav_version": __version__,
        "written_utc": written,
        "title": title,
        "studies": {},
    }
    if any(r.headline or r.checks for r in results):  # a one-log report (calibrate, allan) has nothing to compare
        hmd, hh = _headline(results)
        md += hmd
        h += hh
    console = _CONSOLE.get()
    if console:
        md += ["## Warnings and notes", "", *(f"- **{k}**: {_md(m)}" for k, m in console), ""]
        h += ["<h2>Warnings and notes</h2>", "<ul>"]
        h += [f"<li><b>{html.escape(k)}</b>: {html.escape(m)}</li>" for k, m in console]
        h.append("</ul>")
        summary["console"] = [{"kind": k, "message": m} for k, m in console]
    for r in results:
        took = f", {r.elapsed:.1f} s" if r.elapsed > 0 else ""  # 0: not timed (a report of a result), not "0.0 s"
        md += [f"## {r.title}", "", r.description, "", f"_Study `{r.name}`{took}._", ""]
        h += [f"<h2>{html.escape(r.title)}</h2>", f"<p>{html.escape(r.description)}</p>"]
        if r.checks:
            md += ["| check | value | limit | unit | result | comment |", "|---|---:|---:|---|---|---|"]
            h.append(
                "<table><tr><th>check</th><th>value</th><th>limit</th><th>unit</th><th>result</th><th>comment</th></tr>"
            )
            for c in r.checks:
                verdict = "pass" if c.passed else "FAIL"
                md.append(
                    f"| {_md(c.name)} | {_md(c.value)} | {c.kind} {_md(c.limit)} | {_md(c.unit)} | {verdict} "
                    f"| {_md(c.note)} |"
                )
                h.append(
                    f"<tr><td>{html.escape(c.name)}</td><td>{_fmt(c.value)}</td><td>{html.escape(c.kind)} "
                    f"{_fmt(c.limit)}</td><td>{html.escape(c.unit)}</td>"
                    f"<td class='{verdict.lower()}'>{verdict}</td><td>{html.escape(c.note)}</td></tr>"
                )
            md.append("")
            h.append("</table>")
        for t in r.tables:
            md += [
                f"**{t.title}**",
                "",
                "| " + " | ".join(_md(c) for c in t.columns) + " |",
                "|" + "---|" * len(t.columns),
            ]
            cells = t.text_rows()
            md += ["| " + " | ".join(_md(c) for c in row) + " |" for row in cells]
            if t.note:
                md += ["", f"_{t.note}_"]
            md.append("")
            h.append(
                f"<h3>{html.escape(t.title)}</h3><table><tr>"
                + "".join(f"<th>{html.escape(c)}</th>" for c in t.columns)
                + "</tr>"
            )
            h += ["<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in cells]
            h.append("</table>" + (f"<p><i>{html.escape(t.note)}</i></p>" if t.note else ""))
        for fig, fname in _save_figures(r, out):
            if fname is None:
                md += [f"_Figure omitted ({fig.caption}): install matplotlib._", ""]
            else:
                md += [f"![{fig.caption}]({fname})", "", f"_{fig.caption}_", ""]
                h.append(
                    f"<figure><img src='{html.escape(fname)}' width='700'>"
                    f"<figcaption>{html.escape(fig.caption)}</figcaption></figure>"
                )
        summary["studies"][r.name] = {
            "title": r.title,
            "elapsed_s": r.elapsed,
            "summary": plain(r.summary),
            "headline": [plain(dataclasses.asdict(hl)) for hl in r.headline],
            "checks": [
                {
                    "name": c.name,
                    "value": plain(c.value),
                    "limit": plain(c.limit),
                    "unit": c.unit,
                    "kind": c.kind,
                    "passed": c.passed,
                    "note": c.note,
                    "reason": c.reason,
                }
                for c in r.checks
            ],
            "tables": [
                {"title": t.title, "columns": t.columns, "rows": plain(_cell_values(t.rows)), "note": t.note}
                for t in r.tables
            ],
        }
    option = _OPTION.get()
    write_text(out / "index.md", "\n".join(md) + "\n", option)
    write_text(out / "index.html", "\n".join(h) + "\n", option)
    write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n", option)
    return out
