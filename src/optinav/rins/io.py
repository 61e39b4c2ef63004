"""Rotational-INS data files: NPZ, CSV and HDF5 with the columns of docs/methods/rins.md.

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
import re
from pathlib import Path

import numpy as np

from optinav.core.files import atomic_open, atomic_path, csv_writer
from optinav.errors import OptinavError
from optinav.io.readers import iter_table
from optinav.rins.simulate import RinsData

COLUMNS = ("t", "dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z", "alpha", "beta")
_FORMATS = {".npz": "npz", ".csv": "csv", ".h5": "hdf5", ".hdf5": "hdf5"}

__all__ = ["COLUMNS", "file_format", "write_rins", "rins_csv_writer", "read_rins"]


def file_format(path, *, writing: bool = False) -> str:
    """``"npz"``, ``"csv"`` or ``"hdf5"`` by the suffix of ``path``; an unknown suffix (or HDF5 to write without h5py)
    is an error."""
    p = Path(path)
    f = _FORMATS.get(p.suffix.lower())
    if f is None:
        raise OptinavError(
            f"{p.name}: unknown rotational-INS file type {p.suffix!r}",
            "use .npz, .csv or .h5 (see docs/methods/rins.md)",
        )
    if writing and f == "hdf5":
        try:
            import h5py  # noqa: F401
        except ImportError:
            raise OptinavError("writing HDF5 needs h5py", "pip install 'optinav[hdf5]' or write .npz/.csv") from None
    return f


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


def _site_from_csv(path: Path) -> dict:
    out = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for _ in range(20):
            line = fh.readline()
            if not line.startswith("#"):
                continue
            for k, v in re.findall(r"(lat_deg|height_m)\s*=\s*([-+0-9.eE]+)", line):
                out[k] = float(v)
    return out


def row_estimate(path) -> int:
    """About how many rows ``path`` holds, without reading it: the length of its ``t`` (or first) array for NPZ and
    HDF5, the file size over the mean length of its first data lines for CSV; 0 when that cannot be told (the
    reader then reports what is wrong)."""
    import zipfile

    path = Path(path)
    try:
        kind = file_format(path)
        if kind == "csv":
            with open(path, "rb") as fh:
                head = fh.read(1 << 16)
            lines = [x for x in head.splitlines()[:-1] if x.strip() and not x.lstrip().startswith(b"#")][1:]
            return int(path.stat().st_size / (sum(map(len, lines)) / len(lines) + 1)) if lines else 0
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


def read_rins(path, *, lat: float | None = None, height_m: float | None = None) -> RinsData:
    """Read a rotational-INS file (columns in :data:`COLUMNS`).

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
    path = Path(path)
    kind = file_format(path)
    # text in blocks (iter_table: the whole text and its parse held at once cost ~700 B per row), each column
    # gathered once; other formats come as one table
    parts, ends, names = None, False, COLUMNS
    for tab in iter_table(path):
        if parts is None:
            # a "time" column (and no "t"): the end of each interval, encoders at that end (the older layout)
            ends = tab.find("t") is None and tab.find("time") is not None
            names = ("time",) + COLUMNS[1:] if ends else COLUMNS
            missing = [c for c in names if tab.find(c) is None]
            if missing:
                found = ", ".join(list(tab.data)[:12])
                raise OptinavError(
                    f"{path.name} has no column(s) {', '.join(missing)} (found: {found})",
                    f"write the columns {', '.join(COLUMNS)} (see docs/methods/rins.md)",
                )
            parts, meta = {c: [] for c in COLUMNS}, tab.meta
        for c, n in zip(COLUMNS, names):
            parts[c].append(np.asarray(tab.get(n), dtype=float).ravel())
    if parts is None:
        raise OptinavError(f"{path.name} holds no data rows", f"write the columns {', '.join(COLUMNS)}")
    col = {}
    for c in COLUMNS:  # one column at a time, its blocks freed as it is joined (not the log twice)
        v = parts.pop(c)
        col[c] = v[0] if len(v) == 1 else np.concatenate(v)
        del v
    site = {}
    if kind == "csv":
        site = _site_from_csv(path)
    elif kind == "npz":  # scalars (0-d arrays) are the table's metadata, not columns
        site = {k: float(meta[k]) for k in ("lat_deg", "height_m") if k in meta}
    else:
        import h5py

        with h5py.File(path, "r") as fh:
            site = {k: float(fh.attrs[k]) for k in ("lat_deg", "height_m") if k in fh.attrs}
    if lat is None and "lat_deg" in site:
        lat = np.radians(site["lat_deg"])
    if lat is None:
        raise OptinavError(f"{path.name} does not state the latitude", "pass --lat DEG (the alignment needs it)")
    h = height_m if height_m is not None else site.get("height_m", 0.0)
    n = col["t"].size
    for c, name in zip(COLUMNS, names):
        if col[c].size != n:
            raise OptinavError(
                f"column {name} has {col[c].size} samples for {n} time stamps (sample-rate mismatch)",
                "resample the encoder angles to the IMU epochs first",
            )
    if ends:  # row k: the encoders at end epoch t[k] and the increments over (t[k], t[k+1]] of the next row
        col = {c: (v[1:] if c.startswith(("dtheta", "dv")) else v[:-1]) for c, v in col.items()}
    dtheta = np.column_stack([col.pop(f"dtheta_{a}") for a in "xyz"])
    dv = np.column_stack([col.pop(f"dv_{a}") for a in "xyz"])
    return RinsData(
        t=col["t"],
        dtheta=dtheta,
        dv=dv,
        alpha=col["alpha"],
        beta=col["beta"],
        lat=float(lat),
        height_m=float(h),
    )
