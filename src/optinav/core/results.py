"""Results as dataclasses that serialize to versioned JSON with units.

A result class subclasses :class:`Result`, sets ``SCHEMA`` (a stable name) and ``VERSION``, and gives
each field its unit in the field metadata: ``bias: np.ndarray = field(metadata={"unit": "m/s^2"})``.
``to_json`` writes ``{"schema", "version", "optinav_version", "fields": {name: {"value", "unit"}}}``;
``from_json`` checks the schema and version and rebuilds numpy arrays and nested results.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from optinav.errors import OptinavError

_REGISTRY: dict[str, type["Result"]] = {}


def plain(value: Any) -> Any:
    """``value`` as plain JSON types, for results with their own flat layout: arrays → lists, numpy scalars →
    Python numbers, NaN/inf → ``None`` (JSON has no NaN), nested results → their ``to_dict()``."""
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (np.floating, float)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, dict):
        return {str(k): plain(x) for k, x in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(x) for x in value]
    if isinstance(value, Result):
        return value.to_dict()
    return value


def _encode(value: Any) -> Any:
    if isinstance(value, Result):
        return value.to_dict()
    if isinstance(value, np.ndarray):
        return {"__ndarray__": _encode(value.tolist()), "dtype": str(value.dtype)}
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else {"__float__": repr(v)}
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, dict):
        return {str(k): _encode(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    return value


def _decode(value: Any) -> Any:
    if isinstance(value, dict):
        if "__ndarray__" in value:
            return np.asarray(_decode(value["__ndarray__"]), dtype=value.get("dtype", "float64"))
        if "__float__" in value:
            return float(value["__float__"])
        if "schema" in value and "fields" in value:
            return Result.from_dict(value)
        return {k: _decode(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v) for v in value]
    return value


@dataclasses.dataclass
class Result:
    """Base of every optinav result; see the module docstring."""

    SCHEMA: ClassVar[str] = "optinav.result"
    #: True for results written in a flat layout (``{"schema", "version", "optinav_version", field: value, …}``,
    #: plain JSON, non-finite floats as null), e.g. a calibration's RESULT.json; ``_FLAT_WHAT`` names the file in
    #: errors, ``_FLAT_REMEDY`` says where a good one comes from, ``_FLAT_EXTRA`` holds constant keys written too
    _FLAT: ClassVar[bool] = False
    _FLAT_WHAT: ClassVar[str] = "result"
    _FLAT_REMEDY: ClassVar[str] = "pass a JSON file written by optinav"
    _FLAT_EXTRA: ClassVar[dict] = {}
    VERSION: ClassVar[int] = 1

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "SCHEMA" in cls.__dict__:
            _REGISTRY[cls.SCHEMA] = cls

    def units(self) -> dict[str, str]:
        """Field name → unit string ('' for dimensionless, '-' for non-numeric)."""
        return {f.name: f.metadata.get("unit", "-") for f in dataclasses.fields(self)}

    def to_dict(self) -> dict:
        from optinav import __version__

        if self._FLAT:
            out = {"schema": self.SCHEMA, "version": self.VERSION, "optinav_version": __version__,
                   **self._FLAT_EXTRA}
            for f in dataclasses.fields(self):
                out[f.name] = plain(getattr(self, f.name))
            return out
        fields = {}
        for f in dataclasses.fields(self):
            fields[f.name] = {"value": _encode(getattr(self, f.name)), "unit": f.metadata.get("unit", "-")}
        return {"schema": self.SCHEMA, "version": self.VERSION, "optinav_version": __version__,
                "fields": fields}

    def to_json(self, path: str | Path | None = None, *, indent: int = 2) -> str:
        """Serialize; also write to ``path`` when given (atomically)."""
        text = json.dumps(self.to_dict(), indent=indent, allow_nan=False)
        if path is not None:
            from optinav.core.files import write_text

            write_text(path, text + "\n")
        return text

    @classmethod
    def from_dict(cls, data: dict) -> "Result":
        if cls._FLAT:
            return cls._from_flat(data)
        flat = _REGISTRY.get(data.get("schema")) if isinstance(data, dict) and isinstance(data.get("schema"),
                                                                                          str) else None
        if flat is not None and flat._FLAT:
            if cls is not Result and not issubclass(flat, cls):
                raise OptinavError(f"result schema {data['schema']!r} is not a {cls.SCHEMA}", "pass the right result file")
            return flat._from_flat(data)
        if not isinstance(data, dict) or "schema" not in data or "fields" not in data:
            raise OptinavError("not an optinav result (no 'schema'/'fields' keys)",
                               "pass a JSON file written by optinav")
        schema = data["schema"]
        target = _REGISTRY.get(schema)
        if target is None:
            raise OptinavError(f"unknown result schema {schema!r}", "upgrade optinav or check the file")
        if cls is not Result and not issubclass(target, cls):
            raise OptinavError(f"result schema {schema!r} is not a {cls.SCHEMA}", "pass the right result file")
        if data.get("version") != target.VERSION:
            raise OptinavError(f"{schema} version {data.get('version')} is not supported "
                               f"(this optinav reads version {target.VERSION})", "re-run with this optinav")
        kwargs = {}
        names = {f.name for f in dataclasses.fields(target)}
        for name, entry in data["fields"].items():
            if name in names:
                kwargs[name] = _decode(entry["value"] if isinstance(entry, dict) and "value" in entry else entry)
        try:
            return target(**kwargs)
        except TypeError as exc:
            raise OptinavError(f"{schema} file is incomplete ({exc})", "re-run to write a complete result") from None

    @classmethod
    def _from_flat(cls, data) -> "Result":
        if not isinstance(data, dict) or data.get("schema") != cls.SCHEMA:
            raise OptinavError(f"not an optinav {cls._FLAT_WHAT} (schema is not {cls.SCHEMA!r})", cls._FLAT_REMEDY)
        if data.get("version") != cls.VERSION:
            raise OptinavError(f"{cls._FLAT_WHAT} version {data.get('version')} is not supported "
                               f"(this optinav reads version {cls.VERSION})", "re-run the calibration")
        fields = dataclasses.fields(cls)
        kwargs = {f.name: data[f.name] for f in fields if f.name in data}
        for f in fields:  # plain() wrote non-finite floats as null
            if f.type in ("float", float) and f.name in kwargs and kwargs[f.name] is None:
                kwargs[f.name] = float("nan")
        try:
            return cls(**kwargs)
        except TypeError as exc:
            raise OptinavError(f"{cls._FLAT_WHAT} is incomplete ({exc})", "re-run the calibration") from None

    @classmethod
    def from_json(cls, source: str | Path) -> "Result":
        """Load from a path or a JSON string."""
        from optinav.core.files import parse_json, read_text

        text, src = str(source), "result file"
        if not text.lstrip().startswith("{"):
            text, src = read_text(source, "result file"), f"result file {source}"
        data = parse_json(text, src, "pass an unmodified optinav result file")
        try:
            return cls.from_dict(data)
        except OptinavError:
            raise
        except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
            # a value of the wrong type deep inside (a list where a name belongs, a string as an array ...)
            raise OptinavError(f"{src} is not a valid optinav result ({type(exc).__name__}: "
                               f"{' '.join(str(exc).split())[:80]})", "pass an unmodified optinav result file") from None
