"""Results as dataclasses that serialize to versioned JSON with units.

A result class subclasses :class:`Result`, sets ``SCHEMA`` (a stable name) and ``VERSION``, and gives
each field its unit in the field metadata: ``bias: np.ndarray = field(metadata={"unit": "m/s^2"})``.
``to_json`` writes ``{"schema", "version", "optinav_version", "fields": {name: {"value", "unit"}}}``;
``from_json`` checks the schema and version and rebuilds numpy arrays and nested results; layouts of older
versions are read through :func:`register_legacy`.

Calibrations and estimates derive :class:`Estimate`, which adds the layout every system shares (parameters with
value, std, CRLB std, unit and observability; convergence; quality gates; ``elapsed_s``), and simulated truth is a
:class:`Truth` under the same parameter names (docs/results.md).
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
#: (schema, version) of a layout written by an older optinav → (class, converter of its dict to constructor kwargs)
_LEGACY: dict[tuple[str, int], tuple[type["Result"], Any]] = {}


def dump_json(data: dict, path: str | Path | None = None, *, indent: int = 2) -> str:
    """``data`` as strict JSON text (no NaN); also written to ``path`` atomically when given."""
    text = json.dumps(data, indent=indent, allow_nan=False)
    if path is not None:
        from optinav.core.files import write_text

        write_text(path, text + "\n")
    return text


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

        fields = {}
        for f in dataclasses.fields(self):
            fields[f.name] = {"value": _encode(getattr(self, f.name)), "unit": f.metadata.get("unit", "-")}
        return {"schema": self.SCHEMA, "version": self.VERSION, "optinav_version": __version__,
                "fields": fields}

    def to_json(self, path: str | Path | None = None, *, indent: int = 2) -> str:
        """Serialize; also write to ``path`` when given (atomically)."""
        return dump_json(self.to_dict(), path, indent=indent)

    @classmethod
    def from_dict(cls, data: dict) -> "Result":
        if isinstance(data, dict) and isinstance(data.get("schema"), str):
            if data["schema"] not in _REGISTRY and (data["schema"], data.get("version")) not in _LEGACY:
                _import_systems()
            legacy = _LEGACY.get((data["schema"], data.get("version")))
            if legacy is not None:
                target, convert = legacy
                if cls is not Result and not issubclass(target, cls):
                    raise OptinavError(f"result schema {data['schema']!r} is not a {cls.SCHEMA}",
                                       "pass the right result file")
                return target._from_legacy(convert, data)
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
    def _from_legacy(cls, convert, data: dict) -> "Result":
        try:
            kwargs = convert(data)
            return cls(**kwargs)
        except OptinavError:
            raise
        except (TypeError, KeyError) as exc:
            raise OptinavError(f"{data['schema']} version {data.get('version')} file is incomplete "
                               f"({type(exc).__name__}: {exc})", "pass an unmodified optinav result file") from None

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


def _import_systems() -> None:
    """Import every registered system's result module, so that their schemas (and the layouts of earlier
    versions they read) are known to :meth:`Result.from_dict` without the caller importing them first."""
    from optinav import registry

    for system in registry.systems():
        try:
            system.load("result")
        except (ImportError, AttributeError):  # a plugin system that is not installed: its files stay unknown
            continue


# ------------------------------------------------------------------------------------- the common result layout
def _array_or_none(v: Any) -> Any:
    """A JSON number/list back to float or ndarray (null inside a list → NaN); None stays None."""
    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, list):
        def nan(x):
            return [nan(y) for y in x] if isinstance(x, list) else (np.nan if x is None else x)
        return np.asarray(nan(v), dtype=float)
    return float(v)


@dataclasses.dataclass
class Parameter:
    """One quantity of a result in the common layout (docs/results.md).

    ``value`` (float, or an array for a vector or a time series) in ``unit``; ``std``: the reported 1σ (what
    the estimator propagates: noise, plus model errors where it says so); ``crlb_std``: the Cramér–Rao bound
    from the measurement noise alone, None where not computed; ``observable``: False when the data cannot
    determine it — then ``value`` is None (or the value it was held at) and ``reason`` says why."""

    value: Any
    unit: str
    std: Any = None
    crlb_std: Any = None
    observable: bool = True
    reason: str | None = None

    def to_dict(self) -> dict:
        return {"value": plain(self.value), "std": plain(self.std), "crlb_std": plain(self.crlb_std),
                "unit": self.unit, "observable": bool(self.observable), "reason": self.reason}

    @classmethod
    def from_dict(cls, d: dict) -> "Parameter":
        if not isinstance(d, dict) or "value" not in d or "unit" not in d:
            raise OptinavError("a parameter entry has no value/unit", "pass an unmodified optinav file")
        return cls(value=_array_or_none(d["value"]), unit=str(d["unit"]), std=_array_or_none(d.get("std")),
                   crlb_std=_array_or_none(d.get("crlb_std")), observable=bool(d.get("observable", True)),
                   reason=d.get("reason"))


def gate(name: str, value: float, limit: float, *, unit: str = "", kind: str = "max") -> dict:
    """A quality gate's outcome ``{name, value, limit, unit, kind, passed}``: passed when ``value <= limit``
    (``kind="max"``), ``value >= limit`` (``"min"``) or, for ``kind="true"``, when ``value`` is true."""
    v = float(value)
    if kind == "true":
        passed = bool(value)
    else:
        passed = bool(v <= limit) if kind == "max" else bool(v >= limit)
    return {"name": name, "value": v, "limit": None if limit is None else float(limit), "unit": unit, "kind": kind,
            "passed": passed}


def convergence(converged: bool | None, *, iterations: int | None = None, evaluations: int | None = None,
                message: str = "") -> dict:
    """How an iterative fit ended: ``converged`` (None for a closed form or a filter, which do not iterate),
    iterations and function evaluations where counted, the optimizer's message."""
    return {"converged": None if converged is None else bool(converged),
            "iterations": None if iterations is None else int(iterations),
            "evaluations": None if evaluations is None else int(evaluations), "message": str(message)}


class Estimate(Result):
    """Base of every calibration and estimate result: one layout for the four systems (docs/results.md).

    A subclass is a dataclass that sets ``SYSTEM`` and ``KIND`` (the schema is ``optinav.<system>.<kind>``),
    has the fields ``elapsed_s`` (s), ``convergence`` (:func:`convergence`) and ``gates`` (a list of
    :func:`gate` outcomes), and implements :meth:`parameters`. ``to_dict`` writes the common sections
    (``parameters``, ``convergence``, ``quality_gates``, ``elapsed_s``) and, under ``fields``, everything the
    class holds (the nested layout of :class:`Result`, from which it is read back). Layouts of older versions
    are read through :func:`register_legacy`.
    """

    SYSTEM: ClassVar[str] = ""
    KIND: ClassVar[str] = ""

    def parameters(self) -> dict[str, Parameter]:
        """Everything estimated, in the names the simulated truth uses.

        Returns
        -------
        dict of str to Parameter
            Name → :class:`Parameter` (value, std and CRLB std in the parameter's ``unit``; observability).
        """
        raise NotImplementedError

    def to_dict(self) -> dict:
        d = super().to_dict()
        return {"schema": d["schema"], "version": d["version"], "optinav_version": d["optinav_version"],
                "system": self.SYSTEM, "kind": self.KIND, "method": plain(getattr(self, "method", "")),
                "elapsed_s": plain(self.elapsed_s), "convergence": plain(self.convergence),
                "quality_gates": plain(self.gates),
                "parameters": {n: p.to_dict() for n, p in self.parameters().items()}, "fields": d["fields"]}

    def unobservable(self) -> dict[str, str]:
        """Name → reason of every parameter the data cannot determine."""
        return {n: p.reason or "" for n, p in self.parameters().items() if not p.observable}


def register_legacy(cls: type[Result], schema: str, version: int, convert) -> None:
    """Let ``cls.from_json`` read files of an older ``schema``/``version``: ``convert(dict) -> kwargs``."""
    _LEGACY[(schema, version)] = (cls, convert)


def flat_kwargs(cls: type[Result], data: dict, rename: dict | None = None) -> dict:
    """Constructor kwargs of ``cls`` from an old flat layout ``{schema, version, field: value, …}`` (JSON null
    of a float field → NaN); ``rename``: old key → field name."""
    rename = rename or {}
    names = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for k, v in data.items():
        k = rename.get(k, k)
        if k in names:
            f = names[k]
            kwargs[k] = float("nan") if v is None and f.type in ("float", float) else v
    return kwargs


def nested_kwargs(cls: type[Result], data: dict, rename: dict | None = None) -> dict:
    """Constructor kwargs of ``cls`` from an older version of the nested layout ``{schema, version, fields:
    {name: {value, unit}}}``; ``rename``: old field name → new. Fields ``cls`` no longer has are dropped."""
    rename = rename or {}
    names = {f.name for f in dataclasses.fields(cls)}
    out = {}
    for k, v in data["fields"].items():
        k = rename.get(k, k)
        if k in names:
            out[k] = _decode(v["value"] if isinstance(v, dict) and "value" in v else v)
    return out


#: system → function(legacy truth dict) -> {name: Parameter} for truth files of an older optinav
_TRUTH_LEGACY: dict[str, Any] = {}


@dataclasses.dataclass
class Truth:
    """Simulated truth in the estimated parameterization: ``parameters`` carries the names (and units) of the
    system's result, so that truth and estimate compare field by field (:meth:`compare`); ``info``: what else
    the simulator recorded (seed, scheme, the truth in its own parameterization …). Written as
    ``{"schema": "optinav.<system>.truth", "version": 2, "system", "parameters": {...}, **info}``."""

    system: str
    parameters: dict
    info: dict = dataclasses.field(default_factory=dict)

    VERSION: ClassVar[int] = 2

    @property
    def schema(self) -> str:
        return f"optinav.{self.system}.truth"

    def to_dict(self) -> dict:
        from optinav import __version__

        return {"schema": self.schema, "version": self.VERSION, "optinav_version": __version__,
                "system": self.system, "parameters": {n: p.to_dict() for n, p in self.parameters.items()},
                **plain(self.info)}

    def to_json(self, path: str | Path | None = None, *, indent: int = 2) -> str:
        """Serialize; also write to ``path`` when given (atomically)."""
        return dump_json(self.to_dict(), path, indent=indent)

    @classmethod
    def from_dict(cls, data: dict) -> "Truth":
        schema = data.get("schema") if isinstance(data, dict) else None
        if not isinstance(schema, str):
            raise OptinavError("not an optinav truth file (no schema)", "pass a STEM.truth.json optinav wrote")
        info = {k: v for k, v in data.items() if k not in ("schema", "version", "optinav_version", "system",
                                                           "parameters")}
        if schema.endswith(".truth") and data.get("version") == cls.VERSION:
            params = data.get("parameters")
            if not isinstance(params, dict):
                raise OptinavError(f"{schema} file has no parameters", "pass an unmodified truth file")
            return cls(schema[len("optinav."):-len(".truth")],
                       {n: Parameter.from_dict(p) for n, p in params.items()}, info)
        _import_systems()
        for system, (old_schema, convert) in _TRUTH_LEGACY.items():
            if schema == old_schema:
                return cls(system, convert(data), info)
        raise OptinavError(f"{schema!r} version {data.get('version')} is not a truth file this optinav reads",
                           "pass a STEM.truth.json written by optinav simulate")

    @classmethod
    def from_json(cls, source) -> "Truth":
        from optinav.core.files import parse_json, read_text

        text = read_text(source, "truth file")
        return cls.from_dict(parse_json(text, f"truth file {source}", "pass an unmodified truth file"))

    def compare(self, result: Estimate) -> dict[str, dict]:
        """Field by field: for every truth parameter the result estimates (observable, finite value),
        ``{error: estimate − truth, std, crlb_std, z: |error| / std (NaN without std)}``; arrays element-wise."""
        out = {}
        est = result.parameters()
        for name, tp in self.parameters.items():
            p = est.get(name)
            if p is None or not p.observable or p.value is None or tp.value is None:
                continue
            est_v, true_v = np.asarray(p.value, float), np.asarray(tp.value, float)
            if name.startswith("q_") and est_v.shape[-1:] == (4,):
                # q and −q are one rotation: compare with the sign of the truth
                est_v = est_v * np.where(np.sum(est_v * true_v, axis=-1, keepdims=True) < 0, -1.0, 1.0)
            err = est_v - true_v
            if p.unit == "rad":
                err = (err + np.pi) % (2 * np.pi) - np.pi  # angles: the difference on the circle
            std = None if p.std is None else np.asarray(p.std, float)
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.abs(err) / std if std is not None else np.full_like(err, np.nan)
            out[name] = {"error": err, "std": std, "crlb_std": p.crlb_std, "z": z}
        return out


def register_truth_legacy(system: str, schema: str, convert) -> None:
    """Read truth files of an older optinav (``schema``) as ``system`` truth: ``convert(dict) -> parameters``."""
    _TRUTH_LEGACY[system] = (schema, convert)
