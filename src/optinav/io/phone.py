"""A phone app's export of several sensors — Sensor Logger's or phyphox's CSV export, the zip it shares or the folder
that zip unzips to — found by its files' names (:func:`optinav.io.readers.export_sets`) and read file by file: a
folder's files where they are, a zip's members in memory (nothing is extracted or written next to the input)."""

from __future__ import annotations

import dataclasses
import zipfile
import zlib
from pathlib import Path

from optinav.errors import OptinavError

#: the first bytes of a zip archive
ZIP_MAGIC = b"PK\x03\x04"


@dataclasses.dataclass(frozen=True)
class ExportMember:
    """One file of a phone export: ``export`` (the folder or zip) and its ``name`` there."""

    export: PhoneExport
    name: str

    @property
    def path(self) -> Path:
        """The file as messages and notes name it (``export.zip/Gyroscope.csv``; a folder's file is that path)."""
        return self.export.path / self.name

    def load(self, **kw):
        """The member's :class:`~optinav.io.readers.Table` (``kw`` as :func:`~optinav.io.readers.load_table`)."""
        from optinav.io.readers import load_table

        if not self.export.zipped:
            return load_table(self.path, **kw)
        try:
            with zipfile.ZipFile(self.export.path) as z:
                raw = z.read(self.name)
        except (OSError, zipfile.BadZipFile, zlib.error, KeyError, ValueError, NotImplementedError) as exc:
            raise OptinavError(
                f"cannot read {self.name} in the zip {self.export.path.name} ({exc})", "re-export or extract it"
            ) from None
        return load_table(self.path, raw=raw, **kw)


@dataclasses.dataclass(frozen=True)
class PhoneExport:
    """A phone app's export whose accelerometer (with gravity) and gyroscope files optinav reads as one log:
    ``path`` (the folder or zip), ``what`` it is, the members ``acc``, ``gyro`` and ``mag`` (None: none)."""

    path: Path
    what: str
    acc: str
    gyro: str
    mag: str | None
    zipped: bool
    size: int

    def member(self, name: str) -> ExportMember:
        return ExportMember(self, name)

    def note(self) -> str:
        """Which files were read, for the reader's notes."""
        return (
            f"{self.path.name} is {self.what}: read {self.acc} (the accelerometer with gravity) and {self.gyro} "
            f"(the gyroscope){' in memory from the zip' if self.zipped else ''}"
        )


def _listing(p: Path):
    """(CSV names, zipped, bytes) of a folder (its top and meta/) or a zip whatever its suffix; None for anything
    else: another file, a ROS 2 bag or KITTI folder, an Office workbook, NumPy's .npz, one unreadable."""
    from optinav.core.files import kitti_oxts_folder
    from optinav.io.rosbag import is_bag

    try:
        if p.is_dir():
            if is_bag(p) or kitti_oxts_folder(p) is not None:
                return None
            files = list(p.glob("*.csv"))
            names = [f.name for f in files] + [f"meta/{f.name}" for f in (p / "meta").glob("*.csv")]
            return names, False, sum(f.stat().st_size for f in files)
        if p.is_file():
            with open(p, "rb") as fh:
                if fh.read(4) != ZIP_MAGIC:
                    return None
            with zipfile.ZipFile(p) as z:
                names = [n for n in z.namelist() if not n.endswith("/")]
            if any(n.startswith("xl/") or n == "[Content_Types].xml" for n in names):
                return None  # an Office workbook (phyphox's Excel export): named by the readers
            return [n for n in names if n.lower().endswith(".csv")], True, p.stat().st_size
    except (OSError, zipfile.BadZipFile, ValueError):
        pass  # the readers name what is wrong with it
    return None


def phone_export(path) -> PhoneExport | None:
    """The phone export that ``path`` is (a folder, or a zip whatever its suffix) when it holds an accelerometer
    with gravity and a gyroscope (:func:`optinav.io.readers.export_sets`); None for anything else — another file,
    a ROS 2 bag or KITTI folder, an Office workbook, NumPy's .npz, an export without that pair (whose one-line error
    the readers name as before)."""
    from optinav.io.readers import export_sets

    p = Path(path)
    got = _listing(p)
    if got is None:
        return None
    names, zipped, size = got
    found = export_sets(names)
    if found is None or found["acc"] is None:
        return None
    return PhoneExport(p, found["what"], found["acc"], found["gyro"], found["mag"], zipped, max(size, 1))


def looks_like_export(path) -> bool:
    """Whether ``path`` (a folder or zip) holds a phone app's export by its files' names, readable or not (without
    the accelerometer and gyroscope pair, several recordings): a unit of a batch, which fails with the readers'
    one-line error rather than being passed over."""
    from optinav.io.readers import export_sets

    got = _listing(Path(path))
    return got is not None and export_sets(got[0]) is not None


def refuse_as_one_sensor(path, option: str) -> None:
    """Refuse a phone export given as one sensor's file (``option``: ``--gyro``, ``--mag-file``): it is read whole
    as the data file (its accelerometer, gyroscope and magnetometer files paired). The readers named it as if only
    its extraction were missing ("extract it and pass TotalAcceleration.csv with --gyro Gyroscope.csv")."""
    if not isinstance(path, str | Path):
        return  # a member of an export or a topic of a flight log, read as one sensor's
    export = phone_export(path)
    if export is None:
        return
    holds = "the accelerometer, the gyroscope and the magnetometer" if export.mag else "the accelerometer and gyroscope"
    raise OptinavError(
        f"{option} {Path(path).name} is {export.what}, which holds {holds}",
        f"pass {Path(path).name} itself as the data file, without {option}"
        + (" (--mag reads its magnetometer)" if export.mag and option == "--mag-file" else ""),
    )
