"""Parquet files → a :class:`~optinav.io.readers.Table` through pyarrow (``pip install 'optinav[parquet]'``).

Numeric and boolean columns become float columns (nulls as NaN), timestamps and durations seconds, text and
dictionary columns text (label columns); a fixed-size list column of 3 numbers per row (``acc``) becomes an N×3
array; a struct column ``linear_acceleration {x, y, z}`` becomes ``linear_acceleration_x`` … (nested structs
joined the same way). Units come from a field's metadata key ``unit``/``units``, the file metadata keys
``acc_unit``/``gyro_unit``/``time_unit`` and a rate key (``rate``, ``fs``, …), or brackets in a column name
(``acc_x [g]``). Other types (variable-length lists, maps, binary) are listed as unreadable.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from optinav.errors import OptinavError

__all__ = ["load_parquet", "iter_parquet", "PARQUET_SUFFIXES"]

PARQUET_SUFFIXES = (".parquet", ".pq")


def _pyarrow():
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise OptinavError(
            "reading Parquet files needs pyarrow, which is not installed", "pip install 'optinav[parquet]'"
        ) from None
    return pa, pq


def _open(path: Path, **kw):
    """(pyarrow, the open ParquetFile (``kw``: its options), the Table template with the file's metadata);
    one-line errors."""
    from optinav.io.readers import Table

    pa, pq = _pyarrow()
    try:
        pf = pq.ParquetFile(path, **kw)
        schema = pf.schema_arrow
    except Exception as exc:  # noqa: BLE001 - ArrowInvalid/OSError on damaged or non-Parquet files
        raise _damaged(path, exc) from None
    table = Table(path=path, kind="parquet", data={})
    for k, v in (schema.metadata or {}).items():
        key = k.decode("utf-8", "replace")
        if key not in ("pandas", "ARROW:schema") and len(v) < 200:
            table.meta[key] = v.decode("utf-8", "replace").strip()
    return pa, pf, table


def _damaged(path: Path, exc: Exception) -> OptinavError:
    return OptinavError(
        f"{path.name} is not a readable Parquet file ({' '.join(str(exc).split())[:200]})",
        "check that the file is complete",
    )


def _fill(table, tab, names, pa) -> None:
    """Add the columns of the Arrow table ``tab`` (named ``names`` in order when given) to ``table``."""
    from optinav.io.readers import SKIP_NAMES, _add

    path = table.path
    fields = list(tab.schema)
    if names is not None:
        if len(names) != len(fields):
            raise OptinavError(
                f"columns names {len(names)} column(s) but {path.name} has {len(fields)} "
                f"({', '.join(f.name for f in fields)})",
                "give one name per column in order, '_' to skip one, or std=name entries",
            )
        pairs = [(n, f, tab.column(j)) for j, (n, f) in enumerate(zip(names, fields)) if n not in SKIP_NAMES]
    else:
        pairs = [(_index_name(f, pa), f, tab.column(j)) for j, f in enumerate(fields)]
    for name, fld, col in pairs:
        _column(table, name, fld, col, pa, _add)
    if not table.data:
        extra = f" (unreadable: {table.names()})" if table.skipped else ""
        raise OptinavError(f"{path.name} holds no numeric columns{extra}", "write the data as numeric columns")


def _index_name(fld, pa) -> str:
    """A column's name; pandas' unnamed index stored as a column (``__index_level_0__``) is ``time`` when it holds
    timestamps or durations (a DatetimeIndex: the samples' times)."""
    if fld.name == "__index_level_0__" and (pa.types.is_timestamp(fld.type) or pa.types.is_duration(fld.type)):
        return "time"
    return fld.name


def load_parquet(path, *, names: Sequence[str] | None = None, only: Sequence[str] | None = None):
    """Read the Parquet file ``path`` into a Table (see the module docs).

    ``names``: the columns' names in order (``_``/``-`` skips one) replacing the file's. ``only`` (the names a
    ``std=name`` mapping needs) does not prune the columns read: as in a text file, the unmapped columns are
    still recognised by their names.
    """
    path = Path(path)
    pa, pf, table = _open(path)
    try:
        tab = pf.read(use_threads=True)
    except Exception as exc:  # noqa: BLE001 - ArrowInvalid/OSError on damaged files
        raise _damaged(path, exc) from None
    _fill(table, tab, names, pa)
    return table


def iter_parquet(path, *, names: Sequence[str] | None = None, chunk_rows: int, progress=None):
    """:func:`load_parquet` in blocks of ``chunk_rows`` rows (record batches of one row group at a time, joined
    and cut; never a block of a single row, see :func:`optinav.io.arrayblocks.block_bounds`); one table when the
    file holds no more.
    ``progress(fraction)`` after each block."""
    import dataclasses

    from optinav.io.arrayblocks import block_bounds

    path = Path(path)
    # column chunks read through a 1 MiB buffer (not whole), one row group at a time: one reader over all row
    # groups keeps what it decoded until it ends (memory grows with the file)
    pa, pf, tpl = _open(path, buffer_size=1 << 20, pre_buffer=False)
    n = pf.metadata.num_rows
    if n <= chunk_rows:
        yield load_parquet(path, names=names)
        return
    step = max(int(chunk_rows), 2)
    batches = (
        batch
        for group in range(pf.metadata.num_row_groups)
        for batch in pf.iter_batches(batch_size=step, row_groups=[group], use_threads=True)
    )
    held, got = [], 0
    for a, b in block_bounds(n, chunk_rows):
        try:
            while got < b - a:
                batch = next(batches, None)
                if batch is None:
                    raise OptinavError(
                        f"{path.name} holds fewer rows ({a + got}) than its metadata states ({n})",
                        "check that the file is complete",
                    )
                held.append(pa.Table.from_batches([batch]))
                got += batch.num_rows
            whole = pa.concat_tables(held) if len(held) > 1 else held[0]
        except OptinavError:
            raise
        except Exception as exc:  # noqa: BLE001 - ArrowInvalid/OSError on damaged files
            raise _damaged(path, exc) from None
        rest = whole.slice(b - a)
        held, got = ([rest] if rest.num_rows else []), rest.num_rows
        table = dataclasses.replace(tpl, data={}, units={}, meta=dict(tpl.meta), skipped={}, row0=a)
        _fill(table, whole.slice(0, b - a), names, pa)
        if progress is not None:
            progress(b / n)
        yield table


def _column(table, name: str, fld, col, pa, add) -> None:
    """Add one Arrow column (a ChunkedArray) under ``name``; structs recurse as ``name_field``."""
    import pyarrow.compute as pc

    t = fld.type
    unit = None
    if fld.metadata:
        for key in (b"unit", b"units"):
            if key in fld.metadata:
                unit = fld.metadata[key].decode("utf-8", "replace").strip()
    if pa.types.is_struct(t):
        arr = col.combine_chunks() if col.num_chunks != 1 else col.chunk(0)
        for j in range(t.num_fields):
            sub = t.field(j)
            child = arr.field(j)
            if arr.null_count:  # a null struct makes its children null too
                child = pc.if_else(arr.is_valid(), child, pa.nulls(len(child), child.type))
            _column(table, f"{name}_{sub.name}", sub, pa.chunked_array([child]), pa, add)
        return
    if pa.types.is_fixed_size_list(t) or pa.types.is_list(t) or pa.types.is_large_list(t):
        value_type = t.value_type
        if not (pa.types.is_integer(value_type) or pa.types.is_floating(value_type)):
            table.skipped[name] = f"list of {value_type}"
            return
        arr = col.combine_chunks() if col.num_chunks != 1 else col.chunk(0)
        # a null list is a missing sample: a row of NaN (the column was left out whole, with no word: a gyroscope
        # with one null row read as no gyroscope)
        valid = arr.is_valid().to_numpy(zero_copy_only=False)
        held = arr.filter(pa.array(valid)) if arr.null_count else arr
        if pa.types.is_fixed_size_list(t):
            width = t.list_size
        else:
            lengths = pc.list_value_length(held).to_numpy(zero_copy_only=False)
            if lengths.size == 0 or np.any(lengths != lengths[0]):
                table.skipped[name] = "lists of varying length" if lengths.size else "null lists"
                return
            width = int(lengths[0])
        out = np.full((len(arr), width), np.nan)
        out[valid] = pc.list_flatten(held).to_numpy(zero_copy_only=False).astype(float).reshape(-1, width)
        table.data[name] = out if width > 1 else out[:, 0]
        if unit:
            table.units[name] = unit
        return
    if pa.types.is_dictionary(t):
        col = col.cast(t.value_type)
        t = t.value_type
    if pa.types.is_timestamp(t) or pa.types.is_duration(t):
        # seconds since the epoch (timestamps, time zone ignored: stored as UTC) or of the duration
        ns = col.cast(pa.timestamp("ns") if pa.types.is_timestamp(t) else pa.duration("ns")).cast(pa.int64())
        v = ns.to_numpy().astype(float) if not ns.null_count else ns.cast(pa.float64()).fill_null(np.nan).to_numpy()
        table.data[name] = v * 1e-9
        table.units.setdefault(name, "s")
        return
    if pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_boolean(t) or pa.types.is_decimal(t):
        if not pa.types.is_floating(t) or col.null_count:
            # unchecked: a 64-bit integer beyond 2**53 (a time in ns since the epoch) rounds to the nearest double,
            # as numpy's astype does, where the checked cast raised
            col = col.cast(pa.float64(), safe=False)
            if col.null_count:
                col = col.fill_null(np.nan)
        arr = col.to_numpy()
        table.data[name] = arr if arr.dtype == np.float64 else arr.astype(float)
        if unit:
            table.units[name] = unit
        return
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        add(table, name, np.asarray(col.fill_null("").to_pylist(), dtype=str))
        return
    table.skipped[name] = str(t)
