"""Rotational-INS data files with the columns of docs/methods/rins.md: written as NPZ, CSV or HDF5, read from
any table :func:`optinav.io.iter_table` reads (text .csv/.tsv/.txt/.dat, also .gz; .npz, .npy, HDF5, .mat,
parquet — the units ``optinav batch`` lists).

Columns (all SI): ``t`` (s, the start of each row's increment interval), ``dtheta_x, dtheta_y, dtheta_z`` (rad,
gyro increments over (t[k], t[k+1]]), ``dv_x, dv_y, dv_z`` (m/s), ``alpha`` (rad, inner encoder at t[k]),
``beta`` (rad, outer encoder at t[k]). Files with a ``time`` column instead of ``t`` (written before the
conventions were unified, or by other tools as an IMU outputs them) hold the *end* of each interval with the
encoders at that end; they are read by pairing each end epoch's encoders with the next row's increments
(one row fewer). Site: ``lat_deg`` and ``height_m`` — NPZ scalar arrays, HDF5 file attributes,
or a CSV comment line ``# optinav rins: lat_deg=28.2 height_m=50``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import re
from pathlib import Path

import numpy as np

from optinav.core.files import atomic_open, atomic_path, csv_writer
from optinav.core.units import UNITS
from optinav.errors import OptinavError
from optinav.io.imu import TIME_UNITS
from optinav.io.readers import find_with_unit, iter_table
from optinav.rins.simulate import RinsData

COLUMNS = ("t", "dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z", "alpha", "beta")
_FORMATS = {".npz": "npz", ".csv": "csv", ".h5": "hdf5", ".hdf5": "hdf5"}

__all__ = [
    "COLUMNS",
    "file_format",
    "write_rins",
    "rins_csv_writer",
    "read_rins",
    "RinsBlock",
    "ArraySource",
    "RinsFile",
    "rins_source",
]


def file_format(path, *, writing: bool = False) -> str:
    """The format of ``path`` by its suffix: ``"csv"`` for any text table (.csv .tsv .txt .dat .log, also as .gz),
    else ``"npz"``, ``"npy"``, ``"hdf5"``, ``"mat"`` or ``"parquet"`` — what :func:`optinav.io.iter_table` reads
    (the suffixes the batch lists). Writing: .npz, .csv or .h5/.hdf5 only. An unknown suffix (or HDF5 to write
    without h5py) is an error."""
    from optinav.io.readers import SUFFIXES, _suffix

    p = Path(path)
    if writing:
        f = _FORMATS.get(p.suffix.lower())
        if f is None:
            raise OptinavError(
                f"{p.name}: cannot write a rotational-INS file of type {p.suffix!r}",
                "use .npz, .csv or .h5 (see docs/methods/rins.md)",
            )
        if f == "hdf5":
            try:
                import h5py  # noqa: F401
            except ImportError:
                raise OptinavError(
                    "writing HDF5 needs h5py", "pip install 'optinav[hdf5]' or write .npz/.csv"
                ) from None
        return f
    gz = p.suffix.lower() == ".gz"
    f = SUFFIXES.get(_suffix(p))
    if f is None or (gz and f != "text"):
        raise OptinavError(
            f"{p.name}: unknown rotational-INS file type {''.join(p.suffixes[-2 if gz else -1 :]) or '(none)'}",
            f"use one of {' '.join(SUFFIXES)} (text also as .gz; see docs/methods/rins.md)",
        )
    return "csv" if f == "text" else f


def write_rins(path, data: RinsData) -> Path:
    """Write ``data`` to ``path`` atomically (format by suffix: .npz, .csv, .h5/.hdf5; site as ``lat_deg``,
    ``height_m``).

    Parameters
    ----------
    path : str or Path
        Output file.
    data : RinsData
        The recording.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    kind = file_format(path, writing=True)
    cols = {
        "t": data.t,
        "dtheta_x": data.dtheta[:, 0],
        "dtheta_y": data.dtheta[:, 1],
        "dtheta_z": data.dtheta[:, 2],
        "dv_x": data.dv[:, 0],
        "dv_y": data.dv[:, 1],
        "dv_z": data.dv[:, 2],
        "alpha": data.alpha,
        "beta": data.beta,
    }
    site = {"lat_deg": float(np.degrees(data.lat)), "height_m": float(data.height_m)}
    if kind == "npz":
        with atomic_open(path, "wb") as fh:
            np.savez(fh, **cols, **{k: np.array(v) for k, v in site.items()})
    elif kind == "hdf5":
        import h5py

        with atomic_path(path) as tmp, h5py.File(tmp, "w") as fh:
            for k, v in cols.items():
                ds = fh.create_dataset(k, data=np.asarray(v, float))
                ds.attrs["unit"] = {"t": "s", "dv_x": "m/s", "dv_y": "m/s", "dv_z": "m/s"}.get(k, "rad")
            for k, v in site.items():
                fh.attrs[k] = v
    else:
        with rins_csv_writer(path, data.lat, data.height_m) as write:
            write(data.t, data.dtheta, data.dv, data.alpha, data.beta)
    return path


@contextlib.contextmanager
def rins_csv_writer(path, lat: float, height_m: float):
    """A rotational-INS CSV file written block by block, atomically: the layout of :func:`write_rins` (site and
    units comment lines, the :data:`COLUMNS` header), so the blocks of a session give the same bytes as the whole.

    Parameters
    ----------
    path : str or Path
        Output file (.csv); it appears when the ``with`` block ends without an error.
    lat : float
        Latitude [rad].
    height_m : float
        Height [m].

    Yields
    ------
    callable
        ``write(t, dtheta, dv, alpha, beta)`` appends rows: t [s], dtheta (m, 3) [rad], dv (m, 3) [m/s], alpha
        and beta [rad].
    """
    header = (
        f"# optinav rins: lat_deg={float(np.degrees(lat)):.10g} height_m={float(height_m):.10g}\n"
        "# units: t=s dtheta=rad dv=m/s alpha=rad beta=rad\n# " + ",".join(COLUMNS)
    )
    with csv_writer(path, header) as write:
        yield lambda t, dtheta, dv, alpha, beta: write(np.column_stack([t, dtheta, dv, alpha, beta]))


def _csv_comments(path: Path) -> tuple[dict, dict]:
    """(site, declared units) of a text file's comment lines: ``# optinav rins: lat_deg=… height_m=…`` and
    ``# units: t=s dtheta=rad dv=m/s alpha=deg beta=deg`` (keys: column names or their groups)."""
    import gzip

    site, units = {}, {}
    opener = gzip.open if path.suffix.lower() == ".gz" else open
    with opener(path, "rt", encoding="utf-8", errors="replace") as fh:
        for _ in range(20):
            line = fh.readline()
            if not line.startswith("#"):
                continue
            for k, v in re.findall(r"(lat_deg|height_m)\s*=\s*([-+0-9.eE]+)", line):
                site[k] = float(v)
            m = re.search(r"\bunits?\s*:\s*(.*)$", line, re.IGNORECASE)
            if m:
                units.update({k.lower(): v for k, v in re.findall(r"([A-Za-z_]\w*)\s*=\s*([^\s,;]+)", m.group(1))})
    return site, units


#: the units a file may declare for each column group, and their factor to SI (s, rad, m/s), from the shared tables
_ANGLE = {u: UNITS[u] for u in ("rad", "mrad", "urad", "deg", "arcmin", "arcsec")}
DECLARED_UNITS = {"t": TIME_UNITS, "dtheta": _ANGLE, "dv": {"m/s": 1.0}, "alpha": _ANGLE, "beta": _ANGLE}
_SPELLINGS = {"°": "deg", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad", "sec": "s", "µs": "us"}


def _group(col: str) -> str:
    return col.split("_")[0] if col.startswith(("dtheta", "dv")) else col


def find_column(tab, name: str) -> tuple[str | None, str | None]:
    """The key of column ``name`` (a :data:`COLUMNS` name or ``time``) in ``tab`` and the unit its name declares
    (``alpha [deg]``, ``t_ms``, ``dtheta_x_arcsec``: :func:`optinav.io.readers.find_with_unit`)."""
    return find_with_unit(tab, name, DECLARED_UNITS["t" if name == "time" else _group(name)])


def unit_factors(path: Path, declared: dict, names: dict) -> dict:
    """The factor to SI of each column (:data:`COLUMNS`) from the units the file declares: ``declared`` maps
    column names, their groups (``dtheta``, ``dv``) or ``time`` to unit names; ``names``: column → the file's
    name for it. A unit the column cannot be in is a one-line error; undeclared columns are SI (factor 1)."""
    out = {}
    for c, name in names.items():
        g = _group(c)
        u = next((declared[k] for k in (name.lower(), c, g) if k in declared), None)
        if u is None and c == "t":
            u = declared.get("time")
        if u is None:
            continue
        key = _SPELLINGS.get(u.strip().lower(), u.strip())
        allowed = DECLARED_UNITS[g]
        if key not in allowed:
            raise OptinavError(
                f"{path.name} declares {name} in {u!r}, a unit optinav cannot convert {g} from",
                f"write {name} in one of {', '.join(allowed)} and declare that (see docs/methods/rins.md)",
            )
        out[c] = allowed[key]
    return out


def row_estimate(path) -> int:
    """About how many rows ``path`` holds, without reading it: the length of its ``t`` (or first) array for NPZ and
    HDF5, the file size over the mean length of its first data lines for CSV; 0 when that cannot be told (the
    reader then reports what is wrong)."""
    import zipfile

    path = Path(path)
    try:
        kind = file_format(path)
        if kind == "csv" and path.suffix.lower() != ".gz":
            with open(path, "rb") as fh:
                head = fh.read(1 << 16)
            lines = [x for x in head.splitlines()[:-1] if x.strip() and not x.lstrip().startswith(b"#")][1:]
            return int(path.stat().st_size / (sum(map(len, lines)) / len(lines) + 1)) if lines else 0
        if kind != "npz" and kind != "hdf5":
            return 0
        if kind == "npz":
            with zipfile.ZipFile(path) as z:
                names = z.namelist()
                name = "t.npy" if "t.npy" in names else names[0]
                with z.open(name) as fh:
                    major, _ = np.lib.format.read_magic(fh)
                    read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
                    shape = read(fh)[0]
            return int(shape[0]) if shape else 0
        import h5py

        with h5py.File(path, "r") as fh:
            ds = fh["t"] if "t" in fh else next((v for v in fh.values() if hasattr(v, "shape")), None)
            return int(ds.shape[0]) if ds is not None and ds.shape else 0
    except (OSError, ValueError, KeyError, StopIteration, ImportError, zipfile.BadZipFile, OptinavError):
        return 0


#: rows per block of a recording processed block by block (the memory of a block, not of the log)
BLOCK_ROWS = 1 << 16


@dataclasses.dataclass
class RinsBlock:
    """Consecutive rows ``row0 ..`` of a recording: ``t`` (s), ``dtheta`` (k, 3) rad, ``dv`` (k, 3) m/s, encoder
    angles ``alpha``, ``beta`` (rad), as the fields of :class:`~optinav.rins.simulate.RinsData`."""

    row0: int
    t: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray


class ArraySource:
    """An in-memory :class:`~optinav.rins.simulate.RinsData` as blocks of ``block_rows`` rows (views, no copies);
    iterable again and again. ``lat`` (rad), ``height_m`` (m); ``size``/``position``: rows, for progress bars."""

    def __init__(self, data: RinsData, block_rows: int = BLOCK_ROWS):
        t = np.asarray(data.t)
        if t.ndim != 1:
            raise OptinavError(f"time must be one-dimensional, got shape {t.shape}", "pass one timestamp per sample")
        n = t.size
        for name, a in (("alpha (inner encoder)", data.alpha), ("beta (outer encoder)", data.beta)):
            if np.shape(a) != (n,):
                raise OptinavError(
                    f"{name} has {np.size(a)} samples for {n} IMU samples (sample-rate mismatch)",
                    "resample the encoder angles to the IMU epochs (e.g. numpy.interp) first",
                )
        if np.shape(data.dtheta) != (n, 3) or np.shape(data.dv) != (n, 3):
            raise OptinavError(
                f"dtheta {np.shape(data.dtheta)} / dv {np.shape(data.dv)} do not match {n} time stamps",
                "give one increment row per time stamp",
            )
        self.data, self.block_rows = data, max(1, int(block_rows))
        self.lat, self.height_m = float(data.lat), float(data.height_m)
        self.size, self.position = n, 0

    def __iter__(self):
        d, n = self.data, self.size
        for r0 in range(0, n, self.block_rows):
            r1 = min(r0 + self.block_rows, n)
            self.position = r1
            yield RinsBlock(r0, d.t[r0:r1], d.dtheta[r0:r1], d.dv[r0:r1], d.alpha[r0:r1], d.beta[r0:r1])


class RinsFile:
    """A rotational-INS file (:data:`COLUMNS`) read block by block each time it is iterated: text in blocks of
    ``block_rows`` lines, NPZ and HDF5 in blocks of rows (:func:`optinav.io.iter_table`; a file read whole
    by its library is cut into blocks). ``lat`` (rad) and ``height_m`` (m): the overrides, else the file's (known after the first
    block). Files with a ``time`` column (interval ends, module docstring) give one row fewer. ``size``,
    ``position``: bytes, for :func:`optinav.core.progress.progress_blocks`."""

    def __init__(self, path, *, lat: float | None = None, height_m: float | None = None, block_rows: int = BLOCK_ROWS):
        self.path = Path(path)
        self.kind = file_format(self.path)
        self.block_rows = max(1, int(block_rows))
        self._lat, self._height = lat, height_m
        self.lat, self.height_m = lat, height_m
        self.size, self.position = self.path.stat().st_size, 0

    def _site(self, meta) -> None:
        path, site = self.path, {}
        if self.kind == "csv":
            site = _csv_comments(path)[0]
        elif self.kind != "hdf5":  # scalars (0-d arrays, MAT variables) are the table's metadata, not columns
            site = {k: float(meta[k]) for k in ("lat_deg", "height_m") if k in meta}
        else:
            import h5py

            with h5py.File(path, "r") as fh:
                site = {k: float(fh.attrs[k]) for k in ("lat_deg", "height_m") if k in fh.attrs}
        lat = self._lat if self._lat is not None else site.get("lat_deg")
        if lat is None:
            raise OptinavError(f"{path.name} does not state the latitude", "pass --lat DEG (the alignment needs it)")
        self.lat = float(lat if self._lat is not None else np.radians(lat))
        self.height_m = float(self._height if self._height is not None else site.get("height_m", 0.0))

    def __iter__(self):
        path = self.path
        chunks = iter_table(path, chunk_rows=self.block_rows)
        ends, names, held, rows = False, COLUMNS, None, 0
        for tab in chunks:
            if held is None and rows == 0:
                # a "time" column (and no "t"): the end of each interval, encoders at that end (the older layout)
                ends = find_column(tab, "t")[0] is None and find_column(tab, "time")[0] is not None
                names = ("time",) + COLUMNS[1:] if ends else COLUMNS
                keys = {c: find_column(tab, n) for c, n in zip(COLUMNS, names)}
                missing = [n for c, n in zip(COLUMNS, names) if keys[c][0] is None]
                if missing:
                    found = ", ".join(list(tab.data)[:12])
                    raise OptinavError(
                        f"{path.name} has no column(s) {', '.join(missing)} (found: {found})",
                        f"write the columns {', '.join(COLUMNS)} (see docs/methods/rins.md)",
                    )
                self._site(tab.meta)
                declared = {k.lower(): v for k, v in tab.units.items()}
                declared.update({k.lower(): u for k, u in keys.values() if u is not None})
                if self.kind == "csv":
                    declared.update(_csv_comments(path)[1])
                found = {c: k for c, (k, _) in keys.items()}
                factors = {c: f for c, f in unit_factors(path, declared, found).items() if f != 1.0}
            col = {c: np.asarray(tab.get(found[c]), dtype=float).ravel() for c in COLUMNS}
            for c, f in factors.items():
                col[c] = col[c] * f
            n = col["t"].size
            for c, name in zip(COLUMNS, names):
                if col[c].size != n:
                    raise OptinavError(
                        f"column {name} has {col[c].size} samples for {n} time stamps (sample-rate mismatch)",
                        "resample the encoder angles to the IMU epochs first",
                    )
            if ends:  # row k: the encoders at end epoch t[k], the increments of file row k + 1 (held across blocks)
                if held is not None:
                    col = {
                        c: np.concatenate([held[c], v]) if c in ("t", "alpha", "beta") else v for c, v in col.items()
                    }
                else:
                    col = {c: v if c in ("t", "alpha", "beta") else v[1:] for c, v in col.items()}
                held = {c: col[c][-1:] for c in ("t", "alpha", "beta")}
                col = {c: v[:-1] if c in ("t", "alpha", "beta") else v for c, v in col.items()}
            dth = np.column_stack([col.pop(f"dtheta_{a}") for a in "xyz"])
            dv = np.column_stack([col.pop(f"dv_{a}") for a in "xyz"])
            k = col["t"].size
            for r0 in range(0, k, self.block_rows):  # whole-array formats come as one table
                r1 = min(r0 + self.block_rows, k)
                self.position = chunks.position
                yield RinsBlock(
                    rows + r0, col["t"][r0:r1], dth[r0:r1], dv[r0:r1], col["alpha"][r0:r1], col["beta"][r0:r1]
                )
            rows += k
        if rows == 0:
            raise OptinavError(f"{path.name} holds no data rows", f"write the columns {', '.join(COLUMNS)}")


def rins_source(data, *, lat: float | None = None, height_m: float | None = None):
    """Blocks of a recording: ``data`` as it is when it is a source already (:class:`ArraySource`,
    :class:`RinsFile`), a :class:`~optinav.rins.simulate.RinsData` as an :class:`ArraySource`, else a path read
    by :class:`RinsFile` (``lat`` [rad], ``height_m`` [m] overriding the file's)."""
    if isinstance(data, (ArraySource, RinsFile)):
        return data
    if isinstance(data, RinsData):
        return ArraySource(data)
    return RinsFile(data, lat=lat, height_m=height_m)


def read_rins(path, *, lat: float | None = None, height_m: float | None = None) -> RinsData:
    """Read a rotational-INS file (columns in :data:`COLUMNS`) whole.

    Parameters
    ----------
    path : str or Path
        .npz, .csv or .h5/.hdf5 file.
    lat : float or None
        Latitude [rad], overriding the file's ``lat_deg``.
    height_m : float or None
        Height [m], overriding the file's ``height_m``.

    Returns
    -------
    RinsData
        Increments ``dtheta`` [rad], ``dv`` [m/s] and encoder angles [rad].
    """
    src = RinsFile(path, lat=lat, height_m=height_m)
    parts: dict = {c: [] for c in ("t", "dtheta", "dv", "alpha", "beta")}
    for b in src:
        for c, v in parts.items():
            v.append(getattr(b, c))
    col = {}
    for c in list(parts):  # one column at a time, its blocks freed as it is joined (not the log twice)
        v = parts.pop(c)
        col[c] = v[0] if len(v) == 1 else np.concatenate(v)
        del v
    return RinsData(**col, lat=src.lat, height_m=src.height_m)
