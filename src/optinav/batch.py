"""Batch runs for every system: every unit's recording in a folder, in parallel, one table row per unit,
resumable (``optinav batch calibrate accel|rins|gfimu DIR``, ``optinav batch attitude DIR``).

A *unit* is one data file directly inside the folder (no recursion) whose suffix the readers know
(:data:`optinav.io.readers.SUFFIXES`: text, NumPy, HDF5, MAT, Parquet, ROS bag files; text also as .gz) or a
ROS 2 bag folder (a sub-folder holding ``metadata.yaml``, or the storage files of a recording that did not
close), or a phone app's export (its zip or the sub-folder it
unzips to, :mod:`optinav.io.phone`), in sorted file-name order; hidden files (leading
"."), the batch's own output/journal, any results table an earlier batch wrote there and .txt/.log notes
without a line of numbers are skipped
(``*.truth.json`` is not a data suffix, so simulation truths are skipped too). The unit name is the file name
without its data suffix (``unit7.csv`` → ``unit7``), or the whole file name where two files share a stem.

Each unit runs its system's ``run_unit`` (:mod:`optinav.registry`; for ``multipos`` that is
``read_session_file`` + ``calibrate_data``, what ``optinav calibrate accel`` runs) in a worker: local processes
(:class:`concurrent.futures.ProcessPoolExecutor`, stdlib, so no extra is needed), in this process
(``workers=0``), or a dask.distributed cluster (``scheduler="tcp://host:8786"``; the optional extra
``optinav[dask]``, imported only then). A unit's failure
(an :class:`OptinavError` or any other exception) becomes a ``failed`` row with the one-line message; the
other units continue.

Resume: every finished row is appended to the journal ``OUT.journal.jsonl`` (one JSON line, flushed and
fsynced) before it counts as done; the output table is rebuilt from the journal and written atomically
(temporary file in the same folder, then :func:`os.replace`). A re-run with the same ``out`` skips every unit
whose journal entry matches its file name, size, modification time (ns) and the options' hash; a killed run
therefore loses at most the units in flight. The journal is kept (it is the resume record; delete it, or pass
``fresh=True``, to recompute everything). See docs/batch.md for the columns.

Rows are read from the result through the common layout (:class:`optinav.core.results.Estimate`): one
column per parameter (``NAME``, ``NAME_std``, ``NAME_crlb_std``; a triad as ``NAME_x`` … ``NAME_z``, another
vector of up to four elements as ``NAME_0`` …; time series are left out), the convergence, the quality gates
and the names of the unobservable parameters, plus the system's own columns. With ``reference=True`` a unit's
simulated truth beside it (``STEM.truth.json``) is compared field by field (``NAME_error`` and ``truth_max_z``;
a unit more than :data:`MAX_TRUTH_Z` std from its truth fails).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import re
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as _local_as_completed
from pathlib import Path
from typing import NamedTuple

import numpy as np

from optinav.core.files import RESULT_MARK, atomic_open, atomic_path, check_output, check_replace, describe, os_error
from optinav.errors import OptinavError, message_kind

JOURNAL_SCHEMA = "optinav.batch_journal"
JOURNAL_VERSION = 1
#: the row layout: part of the options hash, so rows journaled by another layout are recomputed (3: attitude rows
#: name frame, offline, input_stage and mag, and a simulated truth is compared in the estimate's frame — rows of
#: layout 2 scored a NED flight run in ENU at 175°)
LAYOUT = 3
OUTPUT_SUFFIXES = (".csv", ".parquet")
_AX = "xyz"

#: (column, type) every table starts with
HEAD: list[tuple[str, str]] = [
    ("unit", "str"),
    ("file", "str"),
    ("status", "str"),
    ("error", "str"),
    ("elapsed_s", "float"),
    ("system", "str"),
    ("schema", "str"),
    ("method", "str"),
    ("converged", "bool"),
    ("gates_passed", "bool"),
    ("n_gates", "int"),
    ("unobservable", "str"),
    ("n_samples", "int"),
]
#: (column, type) every table ends with (the resume record of the row)
TAIL: list[tuple[str, str]] = [
    ("file_size", "int"),
    ("file_mtime_ns", "int"),
    ("options_hash", "str"),
    ("optinav_version", "str"),
    ("finished_utc", "str"),
]
#: the columns of every table, in order; a table adds the system's and the parameters' columns between them
COLUMN_NAMES = [c for c, _ in HEAD + TAIL]
_TYPES = dict(HEAD + TAIL)
#: types of system columns (the rest are numbers)
_EXTRA_TYPES = {
    "acc_unit": "str",
    "gyr_unit": "str",
    "dof": "int",
    "n_poses": "int",
    "rank": "int",
    "n_params": "int",
    "n_reference": "int",
    "held_out_pose": "int",
    "held_out_n_used": "int",
    "notes": "str",
    "result_file": "str",
    "result_sha": "str",
    "lot_outlier": "bool",
    "lot_review": "str",
    "frame": "str",
    "offline": "bool",
    "input_stage": "bool",
    "mag": "bool",
    "mag_hard_iron_from": "int",
}


@dataclasses.dataclass(frozen=True)
class BatchJob:
    """What each unit runs: the registered ``system`` name, its options dataclass, and whether to score it
    against the truth or reference found beside it. Picklable: workers receive it as is."""

    system: str
    options: object
    reference: bool = False
    #: where each ok unit's result JSON goes (``UNIT.json``, as ``optinav calibrate --out`` writes it); not part
    #: of the options hash (it changes where results go, not what they are)
    results_dir: str | None = None
    #: {path: SHA-256} of the files the options name (:func:`_option_files`), read once by the batch: part of the
    #: options hash, so a section list edited between runs recomputes its units (workers do not read them again)
    option_files: dict | None = None


@dataclasses.dataclass(frozen=True)
class Unit:
    """One data file of the batch folder; ``size`` (bytes) and ``mtime_ns`` identify its content for resume."""

    name: str
    path: Path
    size: int
    mtime_ns: int


@dataclasses.dataclass
class BatchSummary:
    """What :func:`run_batch` did: counts, the rows in unit order, where they were written."""

    out: Path
    journal: Path
    rows: list[dict]
    n_units: int
    n_ok: int
    n_failed: int
    n_resumed: int
    n_computed: int
    n_lost: int = 0  # units whose worker died: reported failed, not journaled, retried by the next run
    lot: str = ""  # what the lot check found (:func:`lot_check`); empty for an estimate system
    results_dir: Path | None = None
    skipped: list = dataclasses.field(default_factory=list)  # (name, why): data-named entries that are no file

    def summary(self) -> str:
        lines = [
            f"optinav batch: {self.n_units} units: {self.n_ok} ok, {self.n_failed} failed "
            f"({self.n_resumed} resumed from the journal, {self.n_computed} computed now)"
        ]
        lines += [f"  failed: {r['unit']}: {r['error']}" for r in self.rows if r["status"] != "ok"]
        lines += [f"  review: {r['unit']}: {r['lot_review']}" for r in self.rows if r.get("lot_outlier")]
        lines += [f"  skipped: {name}: {why}, not a unit" for name, why in self.skipped]
        if self.lot:
            lines.append(f"  {self.lot}")
        return "\n".join(lines)


def _data_suffix(name: str) -> str | None:
    from optinav.io.readers import SUFFIXES

    parts = name.lower().split(".")
    if len(parts) < 2:
        return None
    last = "." + parts[-1]
    if last == ".gz" and len(parts) >= 3 and SUFFIXES.get("." + parts[-2]) == "text":
        return "." + parts[-2] + last
    return last if last in SUFFIXES else None


def find_units(directory, *, exclude=(), skipped: list | None = None) -> list[Unit]:
    """The units of ``directory`` (module docstring rule), sorted by file name; ``exclude``: paths to skip;
    ``skipped``: a list that receives (name, why) of the entries with a data suffix that are no regular file (a
    named pipe, a broken or looping link), which are not units either."""
    from optinav.core.files import input_kind
    from optinav.io.phone import looks_like_export
    from optinav.io.rosbag import is_bag

    d = Path(directory)
    if input_kind(d, "folder", "pass the folder holding one data file per unit") != "dir":
        raise OptinavError(f"{d} is not a folder", "pass the folder holding one data file per unit")
    skip = {Path(p).resolve() for p in exclude}
    found = []
    try:
        for p in sorted(d.iterdir(), key=lambda q: q.name):
            if p.name.startswith("."):
                continue
            if p.is_dir() and is_bag(p):
                # a ROS 2 bag: a folder of metadata and storage files (or storage files alone: one that did not close)
                found.append((p.name, p, _folder_stat(p)))
                continue
            if p.is_dir() and looks_like_export(p):
                found.append((p.name, p, _folder_stat(p)))  # a phone app's export unzipped
                continue
            if p.is_file() and p.suffix.lower() == ".zip" and p.resolve() not in skip and looks_like_export(p):
                st = p.stat()
                found.append((p.name[:-4], p, st))  # a phone app's export as it shares it
                continue
            if not p.is_file():
                if skipped is not None and _data_suffix(p.name) is not None and not p.is_dir():
                    skipped.append((p.name, _not_a_file(p)))
                continue
            if p.resolve() in skip:
                continue
            suffix = _data_suffix(p.name)
            if suffix is None or p.name[: -len(suffix)].endswith(".truth"):
                continue  # not data, or a simulation's truth (STEM.truth.csv) beside its data
            if suffix in (".csv", ".parquet") and p.stat().st_size > 0 and _is_results_table(p, suffix):
                continue  # an earlier batch's results table (another --out) is no unit: it failed the lot
            if suffix in PROSE_SUFFIXES and _is_prose(p):
                # a README.txt or LICENSE.txt beside the recordings failed as a ragged table (exit 1)
                if skipped is not None:
                    skipped.append((p.name, "text without a line of numbers (notes?)"))
                continue
            st = p.stat()
            found.append((p.name[: -len(suffix)], p, st))
    except OSError as exc:
        raise OptinavError(f"cannot read the folder {d} ({describe(exc)})", "check the folder's permissions") from None
    stems = [s for s, _, _ in found]
    return [Unit(stem if stems.count(stem) == 1 else p.name, p, st.st_size, st.st_mtime_ns) for stem, p, st in found]


#: text suffixes that notes share with logs (README.txt, run.log): such a file without a line of numbers in its
#: first PROSE_BYTES is skipped, not a failed unit
PROSE_SUFFIXES = (".txt", ".log")
PROSE_BYTES = 65536


def _is_prose(p: Path) -> bool:
    """Whether text file ``p`` has no line of numbers only (comma, semicolon, tab or space separated; one column
    counts) in its first :data:`PROSE_BYTES`; an unreadable file is left to the reader's own error."""
    try:
        with open(p, "rb") as f:
            head = f.read(PROSE_BYTES).decode("utf-8", "replace")
    except OSError:
        return False
    for line in head.splitlines():
        fields = [x for x in re.split(r"[,;\t ]+", line.strip()) if x]
        if fields and all(_number(x) for x in fields):
            return False
    return True


def _number(x: str) -> bool:
    try:
        float(x)
    except ValueError:
        return False
    return True


class _FolderStat(NamedTuple):
    st_size: int
    st_mtime_ns: int


def _folder_stat(p: Path) -> _FolderStat:
    """Size (bytes, summed) and latest mtime of the regular files directly in folder ``p`` (a ROS 2 bag): a
    recording rewritten or re-split counts as changed for resume."""
    sts = [q.stat() for q in p.iterdir() if q.is_file()]
    return _FolderStat(sum(st.st_size for st in sts), max((st.st_mtime_ns for st in sts), default=0))


def data_kinds() -> str:
    """The data files a batch folder's units may be, in words (from :data:`optinav.io.readers.SUFFIXES`)."""
    from optinav.io.readers import SUFFIXES

    return " ".join(SUFFIXES) + " (text also as .gz), a ROS 2 bag folder, or a phone app's export (zip or folder)"


def _not_a_file(p: Path) -> str:
    import stat

    try:
        mode = os.stat(p).st_mode
    except OSError as exc:
        return "a broken or looping link" if p.is_symlink() else describe(exc)
    return "a named pipe" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "not a regular file"


#: option fields added after journals were written (attitude: a magnetometer file, a hard-iron offset to subtract)
LATER_OPTIONS = ("mag_path", "mag_hard_iron", "acc_lsb", "gyro_lsb")


def options_hash(job) -> str:
    """A short hash of the job (system, options, reference), the defaults its options leave to the method (an
    options object's ``resolved_options()``, where it has one) and the row layout: a journal row is reused only
    under the same ones (:func:`hashed_fields`)."""
    text = json.dumps(hashed_fields(job), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def hashed_fields(job) -> dict:
    """What :func:`options_hash` hashes of ``job``: the layout, the job's fields (without where results go; option
    files only when there are some; an option of :data:`LATER_OPTIONS` only when set) and the resolved defaults."""
    fields = dataclasses.asdict(_as_job(job))
    fields.pop("results_dir", None)
    if not fields.get("option_files"):
        fields.pop("option_files", None)  # the hash of a job without option files as before they were hashed
    opts = fields.get("options")
    for k in LATER_OPTIONS if isinstance(opts, dict) else ():
        if k in opts and opts[k] is None:
            opts.pop(k)  # unset, it hashes as before the option existed: a journal of then is still current
    resolved = getattr(job.options, "resolved_options", None)
    if callable(resolved):  # the defaults the options leave to the method: a changed default recomputes the units
        fields["resolved"] = resolved()
    return {"layout": LAYOUT, **fields}


def _option_files(options) -> dict:
    """{path: SHA-256 of its content} for every option value naming an existing file (``--sections``, a
    configuration): the options hash covers what the files say, not only their names."""
    out = {}

    def walk(v):
        if isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)
        elif isinstance(v, (str, Path)) and v and "\n" not in str(v) and len(str(v)) < 4096:
            p = Path(v)
            digest = _file_sha(p, None) if p.is_file() else None
            if digest is not None:  # unreadable: the unit's run names it
                out[str(p)] = digest

    walk(options)
    return out


def _num(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _cell(v):
    """A system column's value as a table cell: text, bool and integers as they are, numbers as finite floats."""
    if v is None or isinstance(v, (str, bool)):
        return v
    if isinstance(v, (int, np.integer)):
        return int(v)
    return _num(v)


def _flat(name: str, value, out: dict, suffix: str = "") -> bool:
    """``out[name + suffix] = value`` for a scalar, ``out[name_x + suffix] …`` for a 3-vector (``name_0`` … for
    another vector of ≤ 4 elements);
    False (nothing written) for a larger array (a time series)."""
    if value is None:
        out[name + suffix] = None
        return True
    v = np.asarray(value, float)
    if v.ndim == 0:
        out[name + suffix] = _num(v)
    elif v.ndim == 1 and v.size <= 4:
        for i, x in enumerate(v):  # a triad's axes by name, other vectors by index
            out[f"{name}_{_AX[i] if v.size == 3 else i}{suffix}"] = _num(x)
    else:
        return False
    return True


def result_columns(res) -> dict:
    """The columns of one result, read through the common layout (:class:`~optinav.core.results.Estimate`):
    schema, method, convergence, gates, unobservable names and every parameter's value, std and CRLB std."""
    gates = list(res.gates)
    row = {
        "schema": res.SCHEMA,
        "method": str(res.method),
        "converged": res.convergence.get("converged"),
        # none checked is no pass (an attitude estimate has no gates): empty, not True
        "gates_passed": all(bool(g["passed"]) for g in gates) if gates else None,
        "n_gates": len(gates),
        "unobservable": "; ".join(res.unobservable()),
    }
    for name, p in res.parameters().items():
        if _flat(name, p.value, row):
            scalar = p.value is None or np.ndim(p.value) == 0
            for v, suffix in ((p.std, "_std"), (p.crlb_std, "_crlb_std")):
                if v is not None or scalar:  # a vector without std gets no columns for it
                    _flat(name, v, row, suffix)
    quality = getattr(res, "quality", None)
    if isinstance(quality, dict):
        # what calibrate prints beside the numbers (a time base off by a factor, turns left out, …) and the
        # held-out pose's check (--hold-out): the table kept neither
        for k, v in (quality.get("held_out") or {}).items():
            row[f"held_out_{k}"] = _num(v) if isinstance(v, (int, float)) else v
        row["notes"] = " | ".join(str(n) for n in quality.get("notes") or [])
    return row


def _keep_warnings(row: dict, heard: list) -> None:
    """The warnings a unit raised (``heard``: :func:`warnings.catch_warnings` records), shown as the batch shows
    warnings with the unit's name in front and kept in its row's ``notes``: on stderr they named no unit (four
    frame warnings over a folder of BROAD trials, from which files?), and the table and its journal kept none, so a
    resumed batch lost them."""
    kept = []
    for w in heard:
        text = " ".join(str(w.message).split())
        warnings.showwarning(f"{row['unit']}: {text}", w.category, w.filename, w.lineno)
        if text not in (row.get("notes") or ""):  # (a result's own notes are there already)
            kept.append(f"{message_kind(w.category)}: {text}")
    if kept:
        row["notes"] = " | ".join(filter(None, [row.get("notes"), *kept]))


def truth_columns(res, path: Path) -> dict:
    """``NAME_error`` (estimate − truth) for every parameter the unit's ``STEM.truth.json`` and the result share
    (``NAME_rmse`` for a time series), and ``truth_max_z`` (the largest |error|/std); nothing when there is no
    truth file beside the unit. A result that compared itself while it was estimated block by block brings its
    ``truth_comparison`` (:class:`optinav.attitude.filestream.StreamedEstimate`)."""
    from optinav.core.results import Truth

    tp = path.with_name(path.stem + ".truth.json")  # where optinav simulate writes it
    if not tp.is_file():
        return {}
    # a result estimated block by block compared itself while streaming (it keeps no per-sample series)
    cmp = getattr(res, "truth_comparison", None)
    if cmp is None:
        cmp = Truth.from_json(tp).compare(res)
    row, zs = {}, []
    for name, c in cmp.items():
        if "rmse" in c:  # a series, compared block by block
            row[f"{name}_rmse"] = _num(c["rmse"])
            zs += [float(c["z"])] if np.isfinite(c["z"]) else []
            continue
        err = np.asarray(c["error"], float)
        if err.ndim == 0 or (err.ndim == 1 and err.size <= 4):
            _flat(name, err, row, "_error")
        else:  # a series: its RMS
            row[f"{name}_rmse"] = _num(np.sqrt(np.mean(err**2)))
        z = np.asarray(c["z"], float)
        zs += [float(x) for x in np.atleast_1d(z) if np.isfinite(x)]
    row["truth_max_z"] = max(zs) if zs else None
    return row


#: with ``reference``, a unit whose largest |error|/std against its truth exceeds this fails: a gross error its
#: std and gates missed (swapped columns gave 42 000); honest std put the largest of 24-50 parameters at 5-5.6 in
#: a few per cent of simulated units (simulated batches), which are not failures
MAX_TRUTH_Z = 10.0


def _as_job(job) -> BatchJob:
    """``job`` as a :class:`BatchJob`: multipos options alone are the multipos system's."""
    return job if isinstance(job, BatchJob) else BatchJob("multipos", job)


def calibrate_unit(path: str, job, name: str = "") -> dict:
    """Run one unit's file through its system (``job``: a :class:`BatchJob`, or multipos options) and return its
    table row; never raises for a bad unit (status "failed" and the one-line error instead). Runs in a worker
    process, so it takes and returns plain picklable values."""
    from optinav import __version__
    from optinav.registry import SYSTEMS

    job = _as_job(job)
    p = Path(path)
    row = {
        "unit": name or p.name,
        "file": p.name,
        "optinav_version": __version__,
        "system": job.system,
        "options_hash": options_hash(job),
        "method": getattr(job.options, "method", None),
    }
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as heard:  # the unit's warnings go into its row
        try:
            res, extra = SYSTEMS[job.system].load("run_unit")(p, job.options, job.reference)
            row.update({k: _cell(v) for k, v in extra.items()})
            row.update(result_columns(res))
            row.update(status="ok", error="")
            if job.results_dir is not None:
                rp = Path(job.results_dir) / f"{name or p.name}.json"
                res.to_json(rp)  # atomic: a killed worker leaves the old file or none
                row["result_file"] = rp.name
                row["result_sha"] = _file_sha(rp)  # a resume takes the file only if it is still this one
            if job.reference:
                row.update(truth_columns(res, p))
                z = row.get("truth_max_z")
                if z is not None and z > MAX_TRUTH_Z:  # scored against the truth: an error the std did not cover
                    row.update(
                        status="failed",
                        error=f"the result is {z:.3g} std from the simulated truth (beyond {MAX_TRUTH_Z:g}): an error its "
                        "std and gates missed",
                    )
        except OptinavError as exc:
            row.update(status="failed", error=str(exc))
        except Exception as exc:  # noqa: BLE001 - a unit's crash is its row, not the batch's end
            msg = " ".join(str(exc).split()) or type(exc).__name__
            row.update(status="failed", error=f"internal error: {type(exc).__name__}: {msg}")
    _keep_warnings(row, heard)
    row["elapsed_s"] = time.perf_counter() - start
    row["finished_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    return row


def columns_of(rows: list[dict]) -> list[str]:
    """The table's columns: :data:`HEAD`, then the system's and the parameters' columns in the order they first
    appear, then :data:`TAIL`."""
    fixed = set(COLUMN_NAMES)
    middle = list(dict.fromkeys(k for r in rows for k in r if k not in fixed))
    return [c for c, _ in HEAD] + middle + [c for c, _ in TAIL]


def _type(column: str) -> str:
    return _TYPES.get(column) or _EXTRA_TYPES.get(column, "float")


def _complete(row: dict, columns: list[str] | None = None) -> dict:
    return {c: row.get(c) for c in (columns or columns_of([row]))}


# ----------------------------------------------------------------------------------------------- lot check
#: the lot check runs on at least this many ok units (fewer cannot tell a unit from the lot's spread)
LOT_MIN_UNITS = 5
#: family-wise false-alarm probability of the lot check for a lot whose parameters are normally distributed
LOT_ALPHA = 0.01
#: at most this many outliers per parameter are looked for (a lot with more is no longer one lot)
LOT_MAX_OUTLIERS = 3
#: a raw-count scale this many times off the lot's median (or its inverse) fails the unit: the bound of the
#: scale's plausibility gate against a nominal value (``optinav.multipos.gates.SCALE_FACTOR``), with the lot's
#: median as the nominal a log in counts lacks
LOT_SCALE_FACTOR = 1.5


def _esd_outliers(x: np.ndarray, alpha: float) -> list[int]:
    """Indices of the outliers of ``x`` at level ``alpha``: the generalized ESD procedure (Rosner, Technometrics
    25(2), 1983), its statistic written as each value's deviation from the others over their std (Student's t
    with n − 2 dof, a monotone function of Rosner's R; Bonferroni over the n values). Up to a third of the values
    and at most :data:`LOT_MAX_OUTLIERS` are tested (two units off the same way do not hide each other), each step
    at ``alpha`` over the number of steps. Small lots detect little: among 9 units, with 21 parameters at a 1 %
    lot-wide level, a unit 10 lot std off is flagged about half the time."""
    from optinav.core.distributions import t_isf

    idx = np.arange(x.size)
    removed, stats = [], []
    steps = min(max(1, (x.size - 1) // 3), LOT_MAX_OUTLIERS)
    alpha = alpha / steps
    for _ in range(steps):
        keep = np.delete(idx, removed) if removed else idx
        rest = x[keep]
        n = rest.size
        if n < LOT_MIN_UNITS - 1:
            break
        total, total2 = rest.sum(), (rest**2).sum()
        mo = (total - rest) / (n - 1)
        vo = np.maximum((total2 - rest**2) - (n - 1) * mo**2, 0.0) / (n - 2)
        dev = np.abs(rest - mo)
        with np.errstate(divide="ignore", invalid="ignore"):
            tval = np.where(vo > 0, dev / np.sqrt(vo * (1.0 + 1.0 / (n - 1))), np.where(dev > 0, np.inf, 0.0))
        j = int(np.argmax(tval))
        stats.append(tval[j] > t_isf(alpha / (2 * n), n - 2))
        removed.append(int(keep[j]))
    last = max((k for k, hit in enumerate(stats) if hit), default=-1)
    return removed[: last + 1]


def _column(rows: list[dict], col: str) -> np.ndarray:
    """The column ``col`` of ``rows`` as floats, NaN where a row has no finite value."""
    return np.array([np.nan if (v := _num(r.get(col))) is None else v for r in rows], float)


def _scale_columns(row: dict) -> list[tuple[str, str]]:
    """(column, raw unit) of the diagonal scale parameters of triads recorded in raw counts (multipos)."""
    out = []
    for sensor in ("acc", "gyr"):
        if row.get(f"{sensor}_unit") == "counts":
            out += [(f"{sensor}_K_{a}{a}", "counts") for a in _AX if f"{sensor}_K_{a}{a}" in row]
    return out


def lot_check(rows: list[dict], alpha: float = LOT_ALPHA) -> str:
    """Compare the ok units of a calibration lot with each other; mark ``rows`` in place and return a summary.

    Units are compared within groups of the same raw units (``acc_unit``, ``gyr_unit``: parameters in counts and
    in m/s² are not one population; a unit in g among units in m/s² was flagged, and a lot's mixed medians failed
    good units). In each group of at least :data:`LOT_MIN_UNITS` ok units, every parameter column with a
    std (``NAME`` beside ``NAME_std``) is tested for outlying units by the generalized ESD test at ``alpha / P``
    (P parameters: the group's false-alarm probability is at most about ``alpha`` when its units' parameters are
    normal). A flagged unit keeps status ok — its calibration passed its own gates — and gets ``lot_outlier``
    true and ``lot_review`` naming the parameters, each against the other units' median and spread: a unit to
    look at, or a lot with heavy tails. A scale of a triad in raw counts beyond ×:data:`LOT_SCALE_FACTOR` of its
    group's median fails the unit: it was recorded at another range than the lot (in a physical unit the
    scale's gate against its nominal value does this). ``alpha`` 0 switches the check off.
    """
    ok = [r for r in rows if r.get("status") == "ok"]
    if alpha <= 0:
        return "lot check: off"
    groups: dict[tuple, list[dict]] = {}
    for r in ok:
        groups.setdefault((r.get("acc_unit"), r.get("gyr_unit")), []).append(r)
    parts, small = [], []
    for key, members in groups.items():
        label = "/".join(str(u) for u in key if u) or "all"
        if len(members) < LOT_MIN_UNITS:
            small.append(f"{len(members)} in {label}")
            continue
        parts.append(_lot_group(members, alpha, label if len(groups) > 1 else ""))
    if not parts:
        return f"lot check: not run (it needs {LOT_MIN_UNITS} ok units of the same raw units; " + ", ".join(small) + ")"
    text = "lot check: " + "; ".join(parts)
    if small:
        text += "; not compared (fewer than " + f"{LOT_MIN_UNITS}): " + ", ".join(small)
    return text


def _lot_group(ok: list[dict], alpha: float, label: str) -> str:
    """:func:`lot_check` of one group of units of the same raw units; its summary (``label`` names the group)."""
    params = [c for c in dict.fromkeys(k for r in ok for k in r) if f"{c}_std" in ok[0] and not c.endswith("_std")]
    failed = []
    medians = {}
    for col, unit in dict.fromkeys(c for r in ok for c in _scale_columns(r)):
        vals = _column(ok, col)
        if np.sum(np.isfinite(vals)) >= LOT_MIN_UNITS:
            medians[col] = (float(np.nanmedian(vals)), unit)
    for r in ok:
        for col, (med, unit) in medians.items():
            v = _num(r.get(col))
            if v is not None and med > 0 and not (1 / LOT_SCALE_FACTOR <= v / med <= LOT_SCALE_FACTOR):
                r.update(
                    status="failed",
                    error=f"{col} = {v:.5g} {unit} per SI unit is {v / med:.3g}× the median {med:.5g} of the lot's "
                    f"units in {unit} (accepted ×{1 / LOT_SCALE_FACTOR:.2g}…×{LOT_SCALE_FACTOR:g}): recorded at "
                    "another range setting than the lot? check the unit's settings, and calibrate it alone if they "
                    "differ on purpose",
                )
                failed.append(r)
                break
    ok = [r for r in ok if r not in failed]
    tested = []
    for col in params:
        vals = _column(ok, col)
        good = np.flatnonzero(np.isfinite(vals))
        if good.size >= LOT_MIN_UNITS:
            tested.append((col, vals, good))
    flagged: dict[int, list[str]] = {}
    for col, vals, good in tested:
        for k in _esd_outliers(vals[good], alpha / len(tested)):
            i = int(good[k])
            others = np.delete(vals[good], k)
            flagged.setdefault(i, []).append(
                f"{col} = {vals[i]:.5g} (the others {np.median(others):.5g} ± {others.std(ddof=1):.2g})"
            )
    for i, r in enumerate(ok):
        r["lot_outlier"] = i in flagged
        r["lot_review"] = "; ".join(flagged.get(i, []))
    text = f"{len(ok) + len(failed)} units{f' in {label}' if label else ''}, {len(tested)} parameters"
    if failed:
        text += f"; failed (scale off the lot): {', '.join(r['unit'] for r in failed)}"
    if flagged:
        text += "; outliers to review (column lot_review): " + ", ".join(ok[i]["unit"] for i in sorted(flagged))
    else:
        text += "; no outliers"
    return text


# --------------------------------------------------------------------------------------------------- journal
class Journal:
    """Append-only JSON-lines record of finished units (``OUT.journal.jsonl``), locked against a second batch.

    Each line: ``{"schema", "version", "row": {...}}``; a line torn by a kill is ignored on reading."""

    def __init__(self, path: Path, *, fresh: bool = False):
        self.path = Path(path)
        existed = self.path.exists()
        try:
            self._fh = open(self.path, "a+", encoding="utf-8", errors="replace")
        except OSError as exc:
            raise OptinavError(
                f"cannot open the journal {self.path} ({exc.strerror})", "choose a writable --out folder"
            ) from None
        try:
            import fcntl

            fcntl.flock(self._fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # no advisory locks on this platform: one batch per output is then the user's care
            pass
        except OSError:
            self._fh.close()
            raise OptinavError(
                f"another optinav batch is writing {self.path}", "wait for it to finish, or use another --out"
            ) from None
        try:
            if fresh:
                self._fh.truncate(0)
            self.rows = self._read()
        except OptinavError:
            self._fh.close()
            if not existed and self.path.stat().st_size == 0:  # no journal left behind by a batch that never ran
                self.path.unlink()
            raise

    def _read(self) -> dict[str, dict]:
        try:
            self._fh.seek(0)
            text = self._fh.read()
        except OSError as exc:
            raise os_error(self.path, exc) from None
        rows = {}
        for line in text.splitlines():
            try:
                rec = json.loads(line)
            except ValueError:
                continue  # a line torn by a kill
            if isinstance(rec, dict) and rec.get("schema") == JOURNAL_SCHEMA and isinstance(rec.get("row"), dict):
                rows[rec["row"].get("file")] = rec["row"]  # a later line for the same file wins
        if text and not text.endswith("\n"):
            self._write("\n")  # start the next record on its own line after a torn one
        return rows

    def _write(self, text: str) -> None:
        """Append ``text`` and sync it to the disk; an OS failure (a full disk) is a one-line error."""
        try:
            self._fh.write(text)
            self._fh.flush()
            os.fsync(self._fh.fileno())
        except OSError as exc:
            raise os_error(self.path, exc) from None

    def append(self, row: dict) -> None:
        rec = {"schema": JOURNAL_SCHEMA, "version": JOURNAL_VERSION, "row": row}
        self._write(json.dumps(rec, allow_nan=False) + "\n")
        self.rows[row["file"]] = row

    def close(self) -> None:
        self._fh.close()


def _done(row: dict | None, unit: Unit, ohash: str, retry_failed: bool, results_dir: str | None = None) -> bool:
    return (
        row is not None
        and row.get("file_size") == unit.size
        and row.get("file_mtime_ns") == unit.mtime_ns
        and row.get("options_hash") == ohash
        and not (retry_failed and row.get("status") != "ok")
        # an ok unit whose result file is not the one its row wrote (none, or another run's in the same folder) is
        # computed again
        and not (
            results_dir is not None
            and row.get("status") == "ok"
            and row.get("result_sha") != _file_sha(Path(results_dir) / f"{unit.name}.json")
        )
    )


def _file_sha(path: Path, length: int | None = 16) -> str | None:
    """SHA-256 of a file's content (its first ``length`` hex digits; None: all), read in 1-MiB blocks; None when
    the file cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()[:length]


# ---------------------------------------------------------------------------------------------------- output
def _check_output(out: Path) -> str:
    kind = out.suffix.lower()
    if kind not in OUTPUT_SUFFIXES:
        raise OptinavError(f"--out {out} is neither .csv nor .parquet", "name the results RESULTS.csv or .parquet")
    if not out.parent.is_dir():
        raise OptinavError(f"the folder of --out ({out.parent}) does not exist", "create it first")
    check_output(out)
    if out.is_file() and not _is_results_table(out, kind):
        # e.g. --out DIR/unit002.csv: the unit's raw log would be dropped from the batch and overwritten
        raise OptinavError(
            f"--out {out} exists and is not an optinav results table (a unit's data file?)",
            "choose another --out; it is never overwritten",
        )
    if kind == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise OptinavError(
                "parquet output needs pyarrow, which is not installed",
                "pip install 'optinav[parquet]', or write --out RESULTS.csv",
            ) from None
    return kind


def _is_results_table(path: Path, kind: str) -> bool:
    """Whether ``path`` is a table :func:`write_table` wrote (its CSV header / its Parquet schema metadata)."""
    try:
        if kind == ".csv":
            with open(path, "rb") as fh:
                return fh.read(len(COLUMN_NAMES[0]) + 40).startswith(",".join(COLUMN_NAMES[:3]).encode())
        with open(path, "rb") as fh:
            if fh.read(4) != b"PAR1":
                return path.stat().st_size == 0
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        return meta.get(b"schema") == b"optinav.batch_results"
    except Exception:  # noqa: BLE001 - unreadable: not ours
        return False


def _csv_cell(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(float(v)) if isinstance(v, float) else str(v)


def write_table(rows: list[dict], out) -> Path:
    """Write ``rows`` to ``out`` (.csv or .parquet; columns :func:`columns_of`) atomically: a temporary file in
    the same folder, fsynced, then :func:`os.replace` — a reader sees the old table or the new, never half."""
    import csv

    out = Path(out)
    kind = _check_output(out)
    columns = columns_of(rows)
    if kind == ".csv":
        with atomic_open(out, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(columns)
            for r in rows:
                w.writerow([_csv_cell(r.get(c)) for c in columns])
    else:
        import pyarrow as pa
        import pyarrow.parquet as pq

        types = {"str": pa.string(), "float": pa.float64(), "int": pa.int64(), "bool": pa.bool_()}
        schema = pa.schema(
            [(c, types[_type(c)]) for c in columns],
            metadata={"schema": "optinav.batch_results", "version": str(LAYOUT)},
        )
        table = pa.Table.from_pylist([_complete(r, columns) for r in rows], schema=schema)
        with atomic_path(out) as tmp:
            pq.write_table(table, tmp)
    return out


def read_results(path) -> list[dict]:
    """The rows of a results table written by :func:`write_table` (.csv or .parquet), typed (:data:`HEAD`,
    :data:`TAIL`, the system's text and integer columns; the rest numbers)
    (empty CSV cells → None)."""
    import csv

    path = Path(path)
    if not path.is_file():
        raise OptinavError(f"results table {path} does not exist", "run `optinav batch calibrate accel` first")
    if path.suffix.lower() == ".parquet":
        _check_output(path)
        import pyarrow.parquet as pq

        return pq.read_table(path).to_pylist()
    conv = {"str": str, "float": float, "int": lambda v: int(float(v)), "bool": lambda v: v == "true"}
    with open(path, newline="", encoding="utf-8") as fh:
        return [
            {k: (None if v == "" and _type(k) != "str" else conv[_type(k)](v)) for k, v in r.items()}
            for r in csv.DictReader(fh)
        ]


# ------------------------------------------------------------------------------------------------- executors
def _default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


#: what every system's first unit imports lazily in a worker (scipy's optimizers and distributions)
_WORKER_PRELOAD = ("scipy.optimize", "scipy.special")


def _mp_context(preload=()):
    import multiprocessing as mp

    # forkserver/spawn rather than fork: the parent may hold threads (a dask client, numba), which fork copies badly
    if "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        # workers start with numpy, optinav, the system's unit module (``preload``) and the scipy parts every
        # system's first unit imports lazily (1.5 s of it) already imported: a pool's workers no longer import
        # them each. The list of the pool that starts the fork server holds while it runs (the process's
        # lifetime); a module it lacks is imported by the worker.
        ctx.set_forkserver_preload(["optinav.batch", *_WORKER_PRELOAD, *preload])
        return ctx
    return mp.get_context("spawn")


def _unit_modules(job) -> list[str]:
    """The module of the ``run_unit`` that :func:`calibrate_unit` runs for ``job``."""
    from optinav.registry import SYSTEMS

    ref = getattr(SYSTEMS.get(_as_job(job).system), "run_unit", None)
    return [ref.partition(":")[0]] if ref else []


def _require_distributed():
    try:
        import distributed
    except ImportError:
        raise OptinavError(
            "--scheduler needs dask.distributed, which is not installed",
            "pip install 'optinav[dask]', or drop --scheduler to use local processes",
        ) from None
    return distributed


def _dask_client(address: str):
    Client = _require_distributed().Client
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise OptinavError(
            f"cannot reach the dask scheduler at {address} ({msg})",
            "start it (`dask scheduler`, workers with optinav installed) or check the address",
        ) from None


def _run_jobs(jobs, options, workers, scheduler):
    """Yield (unit, row or None, error text) as units finish; error text when the worker itself was lost.

    ``scheduler``: None (local processes), a dask address or a connected ``distributed.Client`` (not closed)."""
    if scheduler is not None:
        from distributed import as_completed

        client = _dask_client(scheduler) if isinstance(scheduler, str) else scheduler
        try:
            futures = {
                client.submit(
                    calibrate_unit,
                    str(u.path),
                    options,
                    u.name,
                    pure=False,
                    key=f"optinav-batch-{u.name}-{os.getpid()}-{time.time_ns()}",
                ): u
                for u in jobs
            }
            for fut in as_completed(list(futures)):
                yield _outcome(futures[fut], fut)
        finally:
            if isinstance(scheduler, str):
                client.close()
        return
    if workers == 0:
        for u in jobs:
            yield u, calibrate_unit(str(u.path), options, u.name), None
        return
    yield from _run_local(jobs, options, workers)


def _run_local(jobs, options, workers, fn=None):
    """Local worker processes that survive a worker's death: when one dies (killed, out of memory) the pool
    breaks and every unit in flight or queued fails with it; those are run again in a fresh pool, and if that
    one breaks too, each alone in its own worker — so only the unit that kills its worker is lost."""
    from concurrent.futures.process import BrokenProcessPool

    fn = calibrate_unit if fn is None else fn  # ``fn(path, options, name) -> row``: a module-level function
    pending, stage = list(jobs), 0
    while pending:
        groups = [pending] if stage < 2 else [[u] for u in pending]
        broken = []
        for group in groups:
            pool = ProcessPoolExecutor(
                max_workers=min(workers, len(group)),
                mp_context=_mp_context(_unit_modules(options) if fn is calibrate_unit else ()),
                initializer=_worker_init,
                initargs=(os.getpid(), _picklable(warnings.showwarning)),
            )
            try:
                futures = {pool.submit(fn, str(u.path), options, u.name): u for u in group}
                for fut in _local_as_completed(futures):
                    if isinstance(fut.exception(), BrokenProcessPool) and stage < 2:
                        broken.append(futures[fut])
                    else:
                        yield _outcome(futures[fut], fut)
            finally:
                pool.shutdown(wait=True, cancel_futures=True)
        pending, stage = broken, stage + 1


def _picklable(fn):
    """``fn`` when it can be sent to a worker process (a module-level function), else None."""
    import pickle

    try:
        pickle.dumps(fn)
    except Exception:  # noqa: BLE001 - a lambda, a bound method of an unpicklable object, ...
        return None
    return fn


def _worker_init(parent_pid: int, showwarning=None) -> None:
    """In each worker: show warnings as the batch process does (``showwarning``: its ``warnings.showwarning``, e.g.
    the CLI's one-line ``optinav: warning: …``; a fresh worker process would print Python's two-line form), and
    die with the batch process. Linux: PR_SET_PDEATHSIG (SIGKILL when the parent — the batch, or the fork server
    between them — exits); everywhere: a watchdog thread that exits when the batch process is gone (the fork
    server may outlive it for a moment)."""
    import signal
    import sys
    import threading

    if showwarning is not None:
        warnings.showwarning = showwarning

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    def watch():
        while True:
            try:
                os.kill(parent_pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # a reused pid of another user: the batch is gone
                os._exit(1)
            time.sleep(0.5)

    threading.Thread(target=watch, name="optinav-batch-watchdog", daemon=True).start()


def _outcome(unit, fut):
    try:
        return unit, fut.result(), None
    except Exception as exc:  # noqa: BLE001 - the worker (not the unit) failed: killed, out of memory, ...
        msg = " ".join(str(exc).split()) or type(exc).__name__
        return unit, None, f"worker lost: {type(exc).__name__}: {msg}"


def run_batch(
    directory,
    out,
    options=None,
    *,
    system: str | None = None,
    reference: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    fresh: bool = False,
    retry_failed: bool = False,
    show_progress: bool | None = None,
    results_dir=None,
    lot_alpha: float = LOT_ALPHA,
) -> BatchSummary:
    """Run every unit of ``directory`` through a system and write the table ``out`` (.csv/.parquet); see the
    module docs.

    ``system``: a registered system name (:mod:`optinav.registry`: "multipos", "rins", "gfimu", "attitude"; also
    its command word, e.g. "accel"); default: the system whose options class ``options`` is, else "multipos".
    ``options``: that system's options dataclass (default: its defaults). ``reference``: score each unit
    against the truth (``STEM.truth.json``; attitude also ``STEM.truth.csv`` or a BROAD trial's reference)
    found beside it. ``workers``: local processes (default: the usable cores; 0 = in this process);
    ``scheduler``: a dask.distributed scheduler address instead (the workers must see ``directory`` at the same
    path and have optinav installed). ``fresh``: ignore the journal and recompute every unit; ``retry_failed``:
    recompute units whose journal row failed (otherwise a failed unit is retried only once its file changes).
    ``show_progress``: None follows :func:`optinav.core.progress.progress_enabled`. ``results_dir``: a folder
    where each ok unit's result JSON is written as ``UNIT.json`` (what ``optinav calibrate --out`` writes, for
    ``optinav export`` / ``apply``; calibration systems). ``lot_alpha``: the lot check's false-alarm
    probability (:func:`lot_check`, calibration systems; 0 = off).
    """
    from optinav import registry

    if system is None:
        match = [
            s for s in registry.systems() if s.options and options is not None and type(options) is s.load("options")
        ]
        sysd = match[0] if match else registry.SYSTEMS["multipos"]
    else:
        sysd = registry.by_command(system)
    options = sysd.load("options")() if options is None else options
    if not isinstance(options, sysd.load("options")):
        raise OptinavError(
            f"the options are a {type(options).__name__}, not the {sysd.name} system's {sysd.load('options').__name__}",
            f"pass {sysd.load('options').__name__}(...)",
        )
    sysd.load("check")(options)  # bad options: once, not per unit
    if not (0 <= lot_alpha < 1):
        raise OptinavError(f"--lot-alpha {lot_alpha:g} is not a probability in [0, 1)", "pass e.g. 0.01, or 0 (off)")
    if results_dir is not None:
        if sysd.kind != "calibration":
            raise OptinavError(
                f"--results-dir: a {sysd.command} unit has no result file (its table row is its result)",
                "drop --results-dir",
            )
        rd = Path(results_dir)
        if not rd.is_dir():
            raise OptinavError(f"--results-dir {rd} is not a folder", "create it first")
        if not os.access(rd, os.W_OK | os.X_OK):
            raise OptinavError(f"--results-dir {rd} is not writable", "choose a folder you can write to")
        results_dir = str(rd.resolve())  # workers (a dask cluster's too) may run elsewhere than this cwd
    job = BatchJob(sysd.name, options, bool(reference), results_dir, _option_files(dataclasses.asdict(options)))
    out = Path(out)
    _check_output(out)
    if scheduler is not None and workers is not None:
        raise OptinavError(
            "--workers applies to local processes; a dask cluster has its own workers",
            "drop --workers with --scheduler",
        )
    if workers is not None and workers < 0:
        raise OptinavError(f"--workers {workers} is negative", "give a number of processes (0 = in this process)")
    workers = _default_workers() if workers is None else int(workers)
    journal_path = out.with_name(out.name + ".journal.jsonl")
    skipped: list = []
    units = find_units(directory, exclude=(out, journal_path), skipped=skipped)
    if not units:
        raise OptinavError(
            f"{directory} holds no data files ({data_kinds()})",
            "pass the folder with one data file per unit",
        )
    if results_dir is not None:
        for u in units:
            # a unit's result file replaces (or, when the unit fails, removes) UNIT.json in the folder: a section
            # list or note of that name beside the logs was overwritten and the other units read the result as
            # their sections
            check_replace(Path(results_dir) / f"{u.name}.json", "--results-dir", RESULT_MARK)
    client = None
    if scheduler is not None:
        _require_distributed()
        client = _dask_client(scheduler)  # unreachable: one-line error before any file is written
    try:
        summary = _run_batch(
            units, out, journal_path, job, workers, client, fresh, retry_failed, show_progress, lot_alpha
        )
        summary.results_dir = None if results_dir is None else Path(results_dir)
        summary.skipped = skipped
        return summary
    finally:
        if client is not None:
            client.close()


def _run_batch(units, out, journal_path, options, workers, client, fresh, retry_failed, show_progress, lot_alpha):
    from optinav.core.progress import progress
    from optinav.registry import SYSTEMS

    ohash = options_hash(options)
    journal = Journal(journal_path, fresh=fresh)
    lost: dict[str, dict] = {}
    n_computed = 0
    try:
        rdir = options.results_dir
        resumed = {u.name for u in units if _done(journal.rows.get(u.path.name), u, ohash, retry_failed, rdir)}
        jobs = [u for u in units if u.name not in resumed]
        if jobs:
            it = _run_jobs(jobs, options, workers, client)
            desc = f"batch {_command(options)}"
            for unit, row, lost_msg in progress(it, total=len(jobs), desc=desc, enabled=show_progress):
                if row is None:
                    lost[unit.path.name] = {
                        "unit": unit.name,
                        "file": unit.path.name,
                        "status": "failed",
                        "error": lost_msg,
                        "system": options.system,
                        "options_hash": ohash,
                    }
                    continue
                if row.get("options_hash") != ohash:
                    # the worker read the options into other fields (another optinav, e.g. from before a rename):
                    # its rows would be journaled but never match, so the table would silently lack them
                    raise OptinavError(
                        f"a worker computed {unit.path.name} with options hash {row.get('options_hash')}, not "
                        f"{ohash}: it runs another optinav ({row.get('optinav_version')})",
                        "install the same optinav on every worker, or run with --workers N (local processes)",
                    )
                row.update(unit=unit.name, file=unit.path.name, file_size=unit.size, file_mtime_ns=unit.mtime_ns)
                journal.append(_complete(row))
                n_computed += 1
    finally:
        # rebuilt from the journal on disk, also when interrupted (an interrupt may land between a row's
        # fsync and its bookkeeping): the table then holds exactly what the journal holds
        journal.rows = journal._read()
        rows = []
        for u in units:
            r = journal.rows.get(u.path.name)
            if _done(r, u, ohash, False, options.results_dir):
                rows.append(_complete(r))
            elif u.path.name in lost:
                rows.append(_complete(lost[u.path.name]))
        journal.close()
        lot = ""
        if SYSTEMS[options.system].kind == "calibration":
            lot = lot_check(rows, lot_alpha)
        if options.results_dir is not None:
            for r in rows:
                if r["status"] != "ok":
                    # a failed unit (by its own gates, its truth or the lot) leaves no result file an `export` of the
                    # folder could pick up, an earlier run's neither (a lot-failed unit is computed again on resume)
                    r.pop("result_file", None)
                    r.pop("result_sha", None)
                    with contextlib.suppress(OSError, OptinavError):
                        rp = Path(options.results_dir) / f"{r['unit']}.json"
                        check_replace(rp, "--results-dir", RESULT_MARK)  # one put there during the run stays
                        rp.unlink(missing_ok=True)
        write_table(rows, out)
    n_ok = sum(r["status"] == "ok" for r in rows)
    return BatchSummary(
        out=out,
        journal=journal_path,
        rows=rows,
        n_units=len(units),
        n_ok=n_ok,
        n_failed=len(rows) - n_ok,
        n_resumed=len(resumed),
        n_computed=n_computed,
        n_lost=len(lost),
        lot=lot,
    )


def _command(job: BatchJob) -> str:
    """The CLI words of the job's system (``calibrate accel``, ``attitude``), for the progress bar."""
    from optinav.registry import SYSTEMS

    s = SYSTEMS[job.system]
    return f"calibrate {s.command}" if s.kind == "calibration" else s.command
