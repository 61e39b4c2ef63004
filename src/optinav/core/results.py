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
#: schema → the first version that writes arrays as plain nested lists (with the field's ``arrays``); the version
#: before it wrote ``{"__ndarray__": [...], "dtype"}`` and is read by :func:`nested_kwargs` unless a converter of
#: its own is registered (a layout that also renamed fields). Classes added later start with plain arrays.
PLAIN_ARRAYS_SINCE: dict[str, int] = {
    "optinav.accel_fit": 2,
    "optinav.alignment": 2,
    "optinav.allan": 2,
    "optinav.allan_deviation": 2,
    "optinav.allan_noise_fit": 2,
    "optinav.allan_noise_parameters": 2,
    "optinav.attitude.estimate": 4,
    "optinav.ferraris_calibration": 2,
    "optinav.flight_data": 3,
    "optinav.gfimu.calibration": 3,
    "optinav.gfimu.identifiability": 2,
    "optinav.gyro_calibration": 2,
    "optinav.imu_compensated": 2,
    "optinav.imu_log": 3,
    "optinav.imu_measurement": 2,
    "optinav.imu_model": 3,
    "optinav.imu_spec": 2,
    "optinav.imu_truth": 3,
    "optinav.monte_carlo": 2,
    "optinav.multipos.calibration": 3,
    "optinav.nav_solution": 2,
    "optinav.nees": 2,
    "optinav.observability": 2,
    "optinav.observability_svd": 2,
    "optinav.observability_table": 2,
    "optinav.optimize_result": 2,
    "optinav.pose_plan": 2,
    "optinav.rins.calibration": 3,
    "optinav.rins_data": 3,
    "optinav.scheme_design": 2,
    "optinav.section_list": 2,
    "optinav.simulated_session": 2,
    "optinav.solar_position": 2,
    "optinav.static_detection": 2,
    "optinav.triad_errors": 2,
    "optinav.triad_noise": 2,
}

#: (schema, version) of a layout written by an older optinav → (class, converter of its dict to constructor kwargs)
_LEGACY: dict[tuple[str, int], tuple[type["Result"], Any]] = {}


def dump_json(data: dict, path: str | Path | None = None, *, indent: int = 2) -> str:
    """``data`` as strict JSON text (no NaN); also written to ``path`` atomically when given.

    Parameters
    ----------
    data : dict
        Plain JSON types.
    path : str, Path or None
        Output file.
    indent : int
        Indentation.

    Returns
    -------
    str
        The JSON text.
    """
    from optinav.core.files import json_text, write_text

    text = json_text(data, indent)
    if path is not None:
        write_text(path, text + "\n")
    return text


def plain(value: Any) -> Any:
    """``value`` as plain JSON types, for results with their own flat layout.

    Arrays → lists, numpy scalars → Python numbers, NaN/inf → ``None`` (JSON has no NaN), nested results →
    their ``to_dict()``.

    Parameters
    ----------
    value : Any
        A value of a result field.

    Returns
    -------
    Any
        The same value in plain JSON types (units unchanged).
    """
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "biuU" or (value.dtype.kind == "f" and np.isfinite(value).all()):
            return value.tolist()  # plain already: walking its elements changed none (it took seconds on long logs)
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


def _encode(value: Any, path: str = "", arrays: dict | None = None) -> Any:
    """``value`` in plain JSON types; every numpy array becomes nested lists (:func:`_array_list`) and its
    path within ``value`` (keys and indices joined by ``/``, ``""`` for ``value`` itself) goes into ``arrays``
    with its dtype. Nested results are their own layout."""
    if isinstance(value, Result):
        return value.to_dict()
    if isinstance(value, np.ndarray):
        if arrays is not None:
            arrays[path] = _dtype_name(value.dtype)
        return _array_list(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else {"__float__": repr(v)}
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, dict):
        return {str(k): _encode(v, _join(path, str(k)), arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_encode(v, _join(path, str(i)), arrays) for i, v in enumerate(value)]
    return value


def _join(path: str, key: str) -> str:
    # JSON-pointer escaping, so that a key holding "/" stays one step
    key = key.replace("~", "~0").replace("/", "~1")
    return key if path == "" else f"{path}/{key}"


def _steps(path: str) -> list[str]:
    return [] if path == "" else [k.replace("~1", "/").replace("~0", "~") for k in path.split("/")]


#: array kinds a file may state (bool, signed/unsigned int, float, complex, text); anything else is refused
_ARRAY_KINDS = "biufcU"


def _dtype_name(dtype: np.dtype) -> str:
    if dtype.kind not in _ARRAY_KINDS:
        raise OptinavError(
            f"a result holds a {dtype} array, which JSON cannot carry",
            "store numbers, booleans or text in result arrays",
        )
    return str(dtype)


def _array_list(a: np.ndarray) -> list:
    """Nested lists of plain numbers; in float arrays NaN → null, ±inf → "inf"/"-inf" (JSON has neither)."""
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):

        def fix(x):
            if isinstance(x, list):
                return [fix(y) for y in x]
            return x if math.isfinite(x) else (None if math.isnan(x) else ("inf" if x > 0 else "-inf"))

        return fix(a.tolist())
    if a.dtype.kind == "c":
        return np.stack([a.real, a.imag], axis=-1).tolist()  # [re, im] pairs
    return a.tolist()


def _array_of(value: Any, dtype: str) -> np.ndarray:
    """Inverse of :func:`_array_list`."""
    dt = np.dtype(dtype)
    if dt.kind not in _ARRAY_KINDS:
        raise ValueError(f"array dtype {dtype!r} is not one a result writes")
    if dt.kind == "f":

        def fix(x):
            if not isinstance(x, list):
                return np.nan if x is None else float(x) if isinstance(x, str) else x  # "inf", "-inf"
            # the numbers of a row in the comprehension, not one call each (seconds on long logs)
            return [
                fix(y) if isinstance(y, list) else np.nan if y is None else float(y) if isinstance(y, str) else y
                for y in x
            ]

        return np.asarray(fix(value), dtype=dt)
    if dt.kind == "c":
        pairs = np.asarray(value, dtype=float)
        return (pairs[..., 0] + 1j * pairs[..., 1]).astype(dt) if pairs.size else np.zeros(0, dt)
    return np.asarray(value, dtype=dt)


def _decode(value: Any, where: str = "") -> Any:
    """Nested results back to their classes; the array and float markers of older versions
    (``{"__ndarray__": [...], "dtype"}``, ``{"__float__": "nan"}``) back to numpy arrays and floats. ``where``: the
    path of ``value`` in the file, named when a nested result is damaged."""
    if isinstance(value, dict):
        if "__ndarray__" in value:
            return np.asarray(_decode(value["__ndarray__"]), dtype=value.get("dtype", "float64"))
        if "__float__" in value:
            return float(value["__float__"])
        if "schema" in value and "fields" in value:
            try:
                return Result.from_dict(value)
            except InvalidResult as exc:
                raise InvalidResult(f"{exc.detail}, inside {where!r}" if where else exc.detail) from None
        return {k: _decode(v, f"{where}.{k}" if where else str(k)) for k, v in value.items()}
    if isinstance(value, list):
        # numbers are themselves: only containers are decoded (a path string per number took seconds on long logs)
        return [_decode(v, f"{where}[{i}]") if isinstance(v, (dict, list)) else v for i, v in enumerate(value)]
    return value


def _entry_value(entry: Any, name: str = "") -> Any:
    """A field entry ``{"value", "unit"[, "arrays"]}`` (or a bare value of an older layout) back to Python: the
    arrays its ``arrays`` names become numpy arrays of their dtype; nested results and the markers of older
    versions (``{"__ndarray__"}``, ``{"__float__"}``) are decoded. ``name``: the field's, for the messages."""
    if not (isinstance(entry, dict) and "value" in entry):
        return _decode(entry, name)
    value = _decode(entry["value"], name)
    arrays = entry.get("arrays") or {}
    if not isinstance(arrays, dict):
        raise ValueError("'arrays' of a field is not an object")
    for path, dtype in arrays.items():
        steps = _steps(str(path))
        if not steps:
            value = _named_array(value, dtype, name)
            continue
        parent = value
        for k in steps[:-1]:
            parent = parent[int(k) if isinstance(parent, list) else k]
        last = int(steps[-1]) if isinstance(parent, list) else steps[-1]
        parent[last] = _named_array(parent[last], dtype, ".".join([name, *steps]))
    return value


def _named_array(value: Any, dtype: str, where: str) -> np.ndarray:
    """:func:`_array_of`, a value that is no array of ``dtype`` (text among numbers, 1e300 in a whole-number
    array, which overflowed in an internal error) named as :class:`InvalidResult`."""
    try:
        return _array_of(value, dtype)
    except (TypeError, ValueError, OverflowError):
        what = "whole numbers" if str(dtype).startswith(("int", "uint")) else f"{dtype} values"
        raise InvalidResult(f"field {where!r} holds values that are not {what}") from None


def _field_units(res) -> dict[str, str]:
    """Field name → unit of a result's fields; "[unit]" (a field in the data's own unit) is the result's ``unit``
    field where it has one (allan.json showed "[unit]*sqrt(s)" with the real unit in another field)."""
    own = getattr(res, "unit", None)
    units = {f.name: f.metadata.get("unit", "-") for f in dataclasses.fields(res)}
    if isinstance(own, str) and own:
        units = {k: u.replace("[unit]", f"({own})" if u != "[unit]" else own) for k, u in units.items()}
    return units


@dataclasses.dataclass
class Result:
    """Base of every optinav result; see the module docstring."""

    SCHEMA: ClassVar[str] = "optinav.result"
    VERSION: ClassVar[int] = 1
    #: field → what a file without the field meant, for a field whose default has since changed or gone (e.g.
    #: ``frame``: "enu" before NED became the one default); filled in when a file of any version lacks it
    MISSING_MEANT: ClassVar[dict[str, Any]] = {}
    #: field → what it holds inside (:func:`check_entries`'s kinds), checked key by key when a file is loaded
    ENTRIES: ClassVar[dict[str, Any]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "SCHEMA" in cls.__dict__:
            _REGISTRY[cls.SCHEMA] = cls

    def units(self) -> dict[str, str]:
        """Field name → unit string ('' for dimensionless, '-' for non-numeric).

        Returns
        -------
        dict of str to str
            The units.
        """
        return _field_units(self)

    def to_dict(self) -> dict:
        """The versioned layout ``{"schema", "version", "optinav_version", "fields": {name: {"value", "unit"}}}``.

        Returns
        -------
        dict
            Plain JSON types; every field with its unit.
        """
        from optinav import __version__

        fields = {}
        units = _field_units(self)  # (not self.units(): some results have a field named units)
        for f in dataclasses.fields(self):
            arrays: dict[str, str] = {}
            fields[f.name] = {"value": _encode(getattr(self, f.name), "", arrays), "unit": units[f.name]}
            if arrays:
                fields[f.name]["arrays"] = arrays
        return {"schema": self.SCHEMA, "version": self.VERSION, "optinav_version": __version__, "fields": fields}

    def to_json(self, path: str | Path | None = None, *, indent: int = 2) -> str:
        """Serialize; also write to ``path`` when given (atomically).

        Parameters
        ----------
        path : str, Path or None
            Output file.
        indent : int
            Indentation.

        Returns
        -------
        str
            The JSON text.
        """
        return dump_json(self.to_dict(), path, indent=indent)

    @classmethod
    def from_dict(cls, data: dict) -> "Result":
        """Rebuild a result from :meth:`to_dict`'s layout, or from an older layout registered with
        :func:`register_legacy`; the schema picks the class.

        Parameters
        ----------
        data : dict
            The parsed JSON.

        Returns
        -------
        Result
            The result (a subclass of ``cls``).
        """
        if isinstance(data, dict) and isinstance(data.get("schema"), str):
            if data["schema"] not in _REGISTRY and (data["schema"], data.get("version")) not in _LEGACY:
                _import_systems()
            legacy = _LEGACY.get((data["schema"], data.get("version")))
            if legacy is None and data.get("version") == PLAIN_ARRAYS_SINCE.get(data["schema"], 0) - 1:
                target = _REGISTRY.get(data["schema"])
                legacy = None if target is None else (target, lambda d, c=target: nested_kwargs(c, d))
            if legacy is not None:
                target, convert = legacy
                if cls is not Result and not issubclass(target, cls):
                    raise OptinavError(
                        f"result schema {data['schema']!r} is not a {cls.SCHEMA}", "pass the right result file"
                    )
                return target._from_legacy(convert, data)
        if not isinstance(data, dict) or "schema" not in data or "fields" not in data:
            raise OptinavError(
                "not an optinav result (no 'schema'/'fields' keys)", "pass a JSON file written by optinav"
            )
        schema = data["schema"]
        target = _REGISTRY.get(schema)
        if target is None and cls is not Result:  # asked for one kind: a plan was told to "upgrade optinav"
            raise OptinavError(f"result schema {schema!r} is not a {cls.SCHEMA}", "pass the right result file")
        if target is None:
            raise OptinavError(f"unknown result schema {schema!r}", "upgrade optinav or check the file")
        if cls is not Result and not issubclass(target, cls):
            raise OptinavError(f"result schema {schema!r} is not a {cls.SCHEMA}", "pass the right result file")
        version = data.get("version")
        if not isinstance(version, int) or isinstance(version, bool):
            raise OptinavError(
                f"{schema} version {version!r} is not a whole number (this optinav reads version {target.VERSION})",
                "the file was edited or written by another program: re-run with this optinav",
            )
        if version != target.VERSION:
            raise OptinavError(
                f"{schema} version {version} is not supported (this optinav reads version {target.VERSION})",
                "re-run with this optinav",
            )
        kwargs = {}
        names = {f.name for f in dataclasses.fields(target)}
        if not isinstance(data["fields"], dict):
            raise InvalidResult("'fields' is not an object")
        for name, entry in data["fields"].items():
            if name in names:
                kwargs[name] = _entry_value(entry, name)
        _check_types(target, kwargs)
        for name, kind in target.ENTRIES.items():
            if kwargs.get(name) is not None:
                check_entries(kwargs[name], kind, name)
        try:
            return target(**{**target.MISSING_MEANT, **kwargs})
        except TypeError as exc:
            raise OptinavError(f"{schema} file is incomplete ({exc})", "re-run to write a complete result") from None

    @classmethod
    def _from_legacy(cls, convert, data: dict) -> "Result":
        try:
            kwargs = convert(data)
            return cls(**{**cls.MISSING_MEANT, **kwargs})
        except OptinavError:
            raise
        except (TypeError, KeyError) as exc:
            raise OptinavError(
                f"{data['schema']} version {data.get('version')} file is incomplete ({type(exc).__name__}: {exc})",
                "pass an unmodified optinav result file",
            ) from None

    @classmethod
    def from_json(cls, source: str | Path) -> "Result":
        """Load from a path or a JSON string (see :meth:`from_dict`).

        Parameters
        ----------
        source : str or Path
            A file or the JSON text.

        Returns
        -------
        Result
            The result.
        """
        from optinav.core.files import parse_json, read_text

        text, src = str(source), "result file"
        if not text.lstrip().startswith("{"):
            text, src = read_text(source, "result file"), f"result file {source}"
        data = parse_json(text, src, "pass an unmodified optinav result file")
        try:
            return cls.from_dict(data)
        except InvalidResult as exc:
            raise InvalidResult(exc.detail, src) from None
        except OptinavError:
            raise
        except (TypeError, ValueError, KeyError, IndexError, AttributeError, OverflowError) as exc:
            # a value of the wrong type deep inside (a list where a name belongs, a string as an array ...)
            raise OptinavError(
                f"{src} is not a valid optinav result ({type(exc).__name__}: {' '.join(str(exc).split())[:80]})",
                "pass an unmodified optinav result file",
            ) from None


class InvalidResult(OptinavError):
    """A result file whose layout is right but a field holds a value of the wrong kind (edited or damaged)."""

    def __init__(self, detail: str, src: str = "result"):
        super().__init__(f"{src} is not a valid optinav result ({detail})", "pass an unmodified optinav result file")
        self.detail = detail


#: a field's declared type → the JSON-decoded values it accepts (a float field takes an int: JSON writes 2.0 as 2)
_ACCEPTS: dict[Any, tuple] = {
    float: (float, int),
    int: (int,),
    bool: (bool,),
    str: (str,),
    dict: (dict,),
    list: (list,),
    np.ndarray: (np.ndarray, list, float, int),  # a 0-d array (one axis) is written as a number
}


def json_kind(value: Any) -> str:
    """A value's kind in the words of JSON (for messages).

    Parameters
    ----------
    value : Any
        A decoded JSON value.

    Returns
    -------
    str
        "null", "a boolean", "a number", "text", "a list", "an object" or the Python type's name.
    """
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, (list, np.ndarray)):
        return "a list"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _check_types(target: type, kwargs: dict) -> None:
    """Every field value of a result being loaded has its field's declared kind (``dict | None`` takes an object
    or null, ``float`` a number, a nested result its class, ``Any`` anything): a value of another kind (null for
    the units, text for a matrix) raises :class:`InvalidResult` naming the field, instead of failing later in
    whatever reads it (an AttributeError in ``apply``). A whole number in a ``float`` field becomes that float in
    ``kwargs`` (JSON writes 2.0 as 2): one beyond int64 stayed a Python int and ended ``apply``'s ``np.isfinite``
    in an internal TypeError; one beyond a double's range is refused."""
    import types
    import typing

    try:
        hints = typing.get_type_hints(target)
    except Exception:  # noqa: BLE001 - an annotation that does not resolve: nothing to check against
        return
    for name, value in kwargs.items():
        hint = hints.get(name, Any)
        options = (
            typing.get_args(hint)
            if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union
            else (hint,)
        )
        ok = False
        for h in options:
            h = typing.get_origin(h) or h
            if h is Any or (h is type(None) and value is None):
                ok = True
            elif h in _ACCEPTS:
                ok = isinstance(value, _ACCEPTS[h]) and not (h is not bool and isinstance(value, bool))
                if ok and h is float and isinstance(value, int):
                    try:
                        kwargs[name] = float(value)
                    except OverflowError:
                        raise InvalidResult(f"field {name!r} is a number beyond a double's range") from None
            elif isinstance(h, type):
                ok = isinstance(value, h)
            else:
                ok = True  # a form this check does not know: left to the class
            if ok:
                break
        if not ok:
            raise InvalidResult(f"field {name!r} is {json_kind(value)}")


def nested_array(
    value: Any, where: str, shape: tuple[int, ...], *, finite: bool = False, std: bool = False
) -> np.ndarray:
    """A numeric array inside a result field (a triad's ``K_std``, …), checked while the result is loaded: JSON
    null inside the list is NaN; a value of another kind or shape (null, text, a list of the wrong shape)
    raises :class:`InvalidResult` naming ``where``, instead of an IndexError in whatever reads it.

    Parameters
    ----------
    value : Any
        The decoded JSON value (or an array, when built in Python).
    where : str
        The field path for the message, e.g. ``"accelerometer.K_std"``.
    shape : tuple of int or None
        The required shape (None: any length on that axis).
    finite : bool
        Refuse NaN/inf elements too.
    std : bool
        Standard deviations: refuse negative elements.

    Returns
    -------
    ndarray
        The array [the field's unit, unchanged].
    """
    if value is None or isinstance(value, (bool, str, dict)):
        raise InvalidResult(f"field {where!r} is {json_kind(value)}, expected numbers")
    try:
        a = _array_or_none(value) if isinstance(value, list) else np.asarray(value, dtype=float)
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise InvalidResult(f"field {where!r} holds values that are not numbers") from None
    if a.ndim != len(shape) or any(n is not None and n != m for n, m in zip(shape, a.shape)):
        want = "(" + ", ".join("n" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
        raise InvalidResult(f"field {where!r} has shape {a.shape}, expected {want}")
    if finite and not np.all(np.isfinite(a)):
        raise InvalidResult(f"field {where!r} holds NaN, infinite or null values")
    if std and np.any(a < 0):
        raise InvalidResult(f"field {where!r} holds a negative standard deviation")
    return a


def nested_number(value: Any, where: str, *, none: bool = False, std: bool = False) -> float | None:
    """A number inside a result field (an angle of ``angles``, a combination's ``value`` …), checked while the
    result is loaded.

    Parameters
    ----------
    value : Any
        The decoded JSON value.
    where : str
        The field path for the message, e.g. ``"angles.theta_x"``.
    none : bool
        Accept null (returned as None).
    std : bool
        A standard deviation: refuse a negative one.

    Returns
    -------
    float or None
        The number [the field's unit, unchanged].
    """
    if value is None and none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise InvalidResult(f"field {where!r} is {json_kind(value)}, expected a number" + (" or null" if none else ""))
    if std and value < 0:
        raise InvalidResult(f"field {where!r} is {value!r}, a negative standard deviation")
    return float(value)


def nested_strings(value: Any, where: str) -> list[str]:
    """A list of names inside a result field (a triad's ``held``, …), checked while the result is loaded.

    Parameters
    ----------
    value : Any
        The decoded JSON value.
    where : str
        The field path for the message.

    Returns
    -------
    list of str
        The names.
    """
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):  # text is no list
        raise InvalidResult(f"field {where!r} is {json_kind(value)}, expected a list of names")
    return list(value)


@dataclasses.dataclass(frozen=True)
class Entries:
    """What an object inside a result field holds, checked key by key while the result is loaded
    (:func:`check_entries`): ``required`` and ``optional`` key → kind (see :func:`check_entries`); ``others`` the
    kind of every key not named (None: left as it is)."""

    required: dict = dataclasses.field(default_factory=dict)
    optional: dict = dataclasses.field(default_factory=dict)
    others: Any = None


@dataclasses.dataclass(frozen=True)
class Array:
    """A numeric array inside a result field: ``shape`` (None: any length on that axis); ``finite`` refuses
    NaN/inf elements."""

    shape: tuple
    finite: bool = False


def check_entries(value: Any, kind: Any, where: str) -> None:
    """A value inside a result field checked against its kind while the result is loaded; a value of another kind
    raises :class:`InvalidResult` naming ``where`` (e.g. ``'quality.held_out.t0_s'``, ``'gates[2].passed'``),
    instead of a TypeError in whatever reads it.

    Parameters
    ----------
    value : Any
        The decoded JSON value.
    kind : str, Array, Entries or list
        ``"number"``, ``"count"`` (a whole number >= 0), ``"text"``, ``"bool"``, ``"names"`` (a list of text; each
        with a trailing ``?``: or null); an :class:`Array`; an :class:`Entries` (an object checked key by key); a
        one-element list ``[kind]`` (a list of values of that kind).
    where : str
        The path for the message.
    """
    if isinstance(kind, Entries):
        if not isinstance(value, dict):
            raise InvalidResult(f"field {where!r} is {json_kind(value)}, expected an object")
        missing = [k for k in kind.required if k not in value]
        if missing:
            raise InvalidResult(f"field {where!r} has no {missing[0]!r}")
        named = {**kind.required, **kind.optional}
        for k, v in value.items():
            if named.get(k, kind.others) is not None:
                check_entries(v, named.get(k, kind.others), f"{where}.{k}")
        return
    if isinstance(kind, list):
        if not isinstance(value, list):
            raise InvalidResult(f"field {where!r} is {json_kind(value)}, expected a list")
        for i, v in enumerate(value):
            check_entries(v, kind[0], f"{where}[{i}]")
        return
    if isinstance(kind, Array):
        nested_array(value, where, kind.shape, finite=kind.finite)
        return
    if value is None and kind.endswith("?"):
        return
    base = kind.rstrip("?")
    if base == "number":
        nested_number(value, where)
        return
    if base == "names":
        nested_strings(value, where)
        return
    expected = {"count": "a whole number >= 0", "text": "text", "bool": "true or false"}[base]
    ok = {
        "count": lambda v: isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 0,
        "text": lambda v: isinstance(v, str),
        "bool": lambda v: isinstance(v, (bool, np.bool_)),
    }[base](value)
    if not ok:
        shown = json_kind(value) if isinstance(value, (dict, list, str, np.ndarray)) or value is None else repr(value)
        raise InvalidResult(
            f"field {where!r} is {shown}, expected {expected}" + (" or null" if kind.endswith("?") else "")
        )


#: an :class:`Estimate`'s ``convergence`` (:func:`convergence`) and each of its ``gates`` (:func:`gate`)
CONVERGENCE = Entries(
    optional={"converged": "bool?", "iterations": "count?", "evaluations": "count?", "message": "text"}
)
GATE = Entries(
    required={"name": "text", "value": "number?", "limit": "number?", "kind": "text", "passed": "bool"},
    optional={"unit": "text"},
)


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
        """The parameter as plain JSON types.

        Returns
        -------
        dict
            ``{value, std, crlb_std, unit, observable, reason}`` (values in ``unit``).
        """
        return {
            "value": plain(self.value),
            "std": plain(self.std),
            "crlb_std": plain(self.crlb_std),
            "unit": self.unit,
            "observable": bool(self.observable),
            "reason": self.reason,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "Parameter":
        """A parameter from :meth:`to_dict`'s layout.

        Parameters
        ----------
        d : dict
            ``{value, unit, std?, crlb_std?, observable?, reason?}``.

        Returns
        -------
        Parameter
            The parameter.
        """
        if not isinstance(d, dict) or "value" not in d or "unit" not in d:
            raise OptinavError("a parameter entry has no value/unit", "pass an unmodified optinav file")
        return cls(
            value=_array_or_none(d["value"]),
            unit=str(d["unit"]),
            std=_array_or_none(d.get("std")),
            crlb_std=_array_or_none(d.get("crlb_std")),
            observable=bool(d.get("observable", True)),
            reason=d.get("reason"),
        )


def gate(name: str, value: float, limit: float, *, unit: str = "", kind: str = "max") -> dict:
    """A quality gate's outcome: passed when ``value <= limit`` (``kind="max"``), ``value >= limit`` (``"min"``) or,
    for ``kind="true"``, when ``value`` is true.

    Parameters
    ----------
    name : str
        What is checked.
    value, limit : float
        The measured value and its limit [unit].
    unit : str
        Their unit.
    kind : str
        ``"max"``, ``"min"`` or ``"true"``.

    Returns
    -------
    dict
        ``{name, value, limit, unit, kind, passed}``.
    """
    v = float(value)
    if kind == "true":
        passed = bool(value)
    else:
        passed = bool(v <= limit) if kind == "max" else bool(v >= limit)
    return {
        "name": name,
        "value": v,
        "limit": None if limit is None else float(limit),
        "unit": unit,
        "kind": kind,
        "passed": passed,
    }


def convergence(
    converged: bool | None, *, iterations: int | None = None, evaluations: int | None = None, message: str = ""
) -> dict:
    """How an iterative fit ended.

    Parameters
    ----------
    converged : bool or None
        None for a closed form or a filter, which do not iterate.
    iterations, evaluations : int or None
        Counts where known.
    message : str
        The optimizer's message.

    Returns
    -------
    dict
        ``{converged, iterations, evaluations, message}``.
    """
    return {
        "converged": None if converged is None else bool(converged),
        "iterations": None if iterations is None else int(iterations),
        "evaluations": None if evaluations is None else int(evaluations),
        "message": str(message),
    }


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
    ENTRIES: ClassVar[dict[str, Any]] = {"convergence": CONVERGENCE, "gates": [GATE]}

    def parameters(self) -> dict[str, Parameter]:
        """Everything estimated, in the names the simulated truth uses.

        Returns
        -------
        dict of str to Parameter
            Name → :class:`Parameter` (value, std and CRLB std in the parameter's ``unit``; observability).
        """
        raise NotImplementedError

    def to_dict(self) -> dict:
        """The common result layout: schema, system, kind, method, timing, convergence, quality gates, parameters
        (:meth:`parameters`) and the class's fields.

        Returns
        -------
        dict
            Plain JSON types.
        """
        d = super().to_dict()
        return {
            "schema": d["schema"],
            "version": d["version"],
            "optinav_version": d["optinav_version"],
            "system": self.SYSTEM,
            "kind": self.KIND,
            "method": plain(getattr(self, "method", "")),
            "elapsed_s": plain(self.elapsed_s),
            "convergence": plain(self.convergence),
            "quality_gates": plain(self.gates),
            "parameters": {n: p.to_dict() for n, p in self.parameters().items()},
            "fields": d["fields"],
        }

    def unobservable(self) -> dict[str, str]:
        """Parameters the data cannot determine.

        Returns
        -------
        dict of str to str
            Name → reason.
        """
        return {n: p.reason or "" for n, p in self.parameters().items() if not p.observable}


def register_legacy(cls: type[Result], schema: str, version: int, convert) -> None:
    """Let ``cls.from_json`` read files of an older ``schema``/``version``.

    Parameters
    ----------
    cls : type
        The result class.
    schema : str
        The old schema name.
    version : int
        The old version.
    convert : callable
        ``convert(dict) -> kwargs`` of ``cls``.
    """
    _LEGACY[(schema, version)] = (cls, convert)


def flat_kwargs(cls: type[Result], data: dict, rename: dict | None = None) -> dict:
    """Constructor kwargs of ``cls`` from an old flat layout ``{schema, version, field: value, …}``.

    Parameters
    ----------
    cls : type
        The result class.
    data : dict
        The old file (JSON null of a float field → NaN).
    rename : dict or None
        Old key → field name.

    Returns
    -------
    dict
        The kwargs.
    """
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
    """Constructor kwargs of ``cls`` from an older version of the nested layout ``{schema, version, fields: {name:
    {value, unit}}}``; fields ``cls`` no longer has are dropped.

    Parameters
    ----------
    cls : type
        The result class.
    data : dict
        The old file.
    rename : dict or None
        Old field name → new.

    Returns
    -------
    dict
        The kwargs.
    """
    rename = rename or {}
    names = {f.name for f in dataclasses.fields(cls)}
    out = {}
    for k, v in data["fields"].items():
        k = rename.get(k, k)
        if k in names:
            out[k] = _entry_value(v)
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
        """The truth layout ``{schema, version, optinav_version, system, parameters, **info}``.

        Returns
        -------
        dict
            Plain JSON types (parameter values in their units).
        """
        from optinav import __version__

        return {
            "schema": self.schema,
            "version": self.VERSION,
            "optinav_version": __version__,
            "system": self.system,
            "parameters": {n: p.to_dict() for n, p in self.parameters.items()},
            **plain(self.info),
        }

    def to_json(self, path: str | Path | None = None, *, indent: int = 2) -> str:
        """Serialize; also write to ``path`` when given (atomically).

        Parameters
        ----------
        path, indent
            As :meth:`Result.to_json`.

        Returns
        -------
        str
            The JSON text.
        """
        return dump_json(self.to_dict(), path, indent=indent)

    @classmethod
    def from_dict(cls, data: dict) -> "Truth":
        """A truth from :meth:`to_dict`'s layout, or from an older system truth registered with
        :func:`register_truth_legacy`.

        Parameters
        ----------
        data : dict
            The parsed JSON.

        Returns
        -------
        Truth
            The truth.
        """
        schema = data.get("schema") if isinstance(data, dict) else None
        if not isinstance(schema, str):
            raise OptinavError("not an optinav truth file (no schema)", "pass a STEM.truth.json optinav wrote")
        info = {
            k: v for k, v in data.items() if k not in ("schema", "version", "optinav_version", "system", "parameters")
        }
        if schema.endswith(".truth") and data.get("version") == cls.VERSION:
            params = data.get("parameters")
            if not isinstance(params, dict):
                raise OptinavError(f"{schema} file has no parameters", "pass an unmodified truth file")
            return cls(
                schema[len("optinav.") : -len(".truth")], {n: Parameter.from_dict(p) for n, p in params.items()}, info
            )
        _import_systems()
        for system, (old_schema, convert) in _TRUTH_LEGACY.items():
            if schema == old_schema:
                return cls(system, convert(data), info)
        raise OptinavError(
            f"{schema!r} version {data.get('version')} is not a truth file this optinav reads",
            "pass a STEM.truth.json written by optinav simulate",
        )

    @classmethod
    def from_json(cls, source) -> "Truth":
        """Load a truth file (see :meth:`from_dict`).

        Parameters
        ----------
        source : str or Path
            The file.

        Returns
        -------
        Truth
            The truth.
        """
        from optinav.core.files import parse_json, read_text

        text = read_text(source, "truth file")
        return cls.from_dict(parse_json(text, f"truth file {source}", "pass an unmodified truth file"))

    def compare(self, result: Estimate) -> dict[str, dict]:
        """Field by field: every truth parameter the result estimates (observable, finite value).

        Parameters
        ----------
        result : Estimate
            The estimate of the same system.

        Returns
        -------
        dict of str to dict
            Name → ``{error: estimate − truth, std, crlb_std [parameter unit], z: |error| / std (NaN without std)}``;
            arrays element-wise.
        """
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


def _json_rows(v: np.ndarray) -> str:
    """Rows of an array as JSON text, one row per line, without the enclosing brackets (non-finite → null)."""
    v = np.asarray(v, float)
    num = (lambda x: repr(x) if math.isfinite(x) else "null") if not np.all(np.isfinite(v)) else repr
    if v.ndim == 1:
        return ",\n".join(map(num, v.tolist()))
    return ",\n".join("[" + ", ".join(map(num, r)) + "]" for r in v.reshape(len(v), -1).tolist())


class TruthSeriesReader:
    """A truth file (:meth:`Truth.from_json`'s layout) whose long per-sample series stay on disk and are read block
    by block (:mod:`optinav.core.jsonstream`), so that memory does not grow with their length: ``truth`` holds
    every other parameter, and the streamed series with value None; :meth:`take` gives a series' next rows.

    Parameters
    ----------
    path : str or Path
        The truth file.
    series : sequence of str
        The parameters that may be per-sample series (``q_b_n``, ``roll`` …); those written inline (short) are
        in ``truth`` as usual.
    """

    def __init__(self, path, series):
        from optinav.core.jsonstream import ArrayRows, skeleton

        self.path = Path(path)
        remedy = "pass an unmodified truth file"
        data, regions = skeleton(self.path, depth=4, what="truth file", remedy=remedy)
        self.rows: dict = {}
        params = data.get("parameters") if isinstance(data, dict) else None
        if isinstance(params, dict):
            for name, p in params.items():
                if name in series and isinstance(p, dict) and isinstance(p.get("value"), str) and p["value"] in regions:
                    self.rows[name] = ArrayRows(self.path, regions[p["value"]], f"the truth's {name}")
                    p["value"] = None
        if any(r.marker in json.dumps(data) for r in regions.values()):
            # long arrays elsewhere (not a series): the file is read whole after all
            self.close()
            self.rows = {}
            self.truth = Truth.from_json(self.path)
            return
        self.truth = Truth.from_dict(data)

    def take(self, name: str, n: int) -> np.ndarray:
        """The next rows of a series.

        Parameters
        ----------
        name : str
            The series (a key of ``rows``).
        n : int
            How many rows (fewer at its end).

        Returns
        -------
        ndarray
            The rows [the series' unit].
        """
        return self.rows[name].take(n)

    def taken(self, name: str) -> int:
        """Rows of a series taken so far.

        Parameters
        ----------
        name : str
            The series.

        Returns
        -------
        int
            The count.
        """
        return self.rows[name].rows

    def count_rest(self, name: str) -> int:
        """Rows of a series not taken yet (reads them).

        Parameters
        ----------
        name : str
            The series.

        Returns
        -------
        int
            The count.
        """
        return self.rows[name].count_rest()

    def close(self) -> None:
        """Close the file."""
        for r in self.rows.values():
            r.close()


class TruthSeriesWriter:
    """A truth whose parameters are per-sample series (e.g. a simulated flight's attitude), written to
    ``STEM.truth.json`` block by block: each series' rows wait in a scratch file beside the output until
    :meth:`close` assembles the file atomically, in :meth:`Truth.to_json`'s layout (:meth:`Truth.from_json` reads
    it), so memory does not grow with the length of the series.

    Parameters
    ----------
    path : str or Path
        The truth file.
    system : str
        The system (``"attitude"``).
    units : dict of str to str
        Series name → unit, in the file's order.
    info : dict
        What else the simulator recorded (plain JSON types).
    option : str
        The CLI option that names the output (for errors).
    """

    def __init__(self, path, system: str, units: dict, info: dict | None = None, option: str = "--out"):
        import contextlib

        from optinav.core.files import scratch_file

        self.path, self.option = Path(path), option
        self._head = Truth(system, {n: Parameter(None, u) for n, u in units.items()}, dict(info or {}))
        self._stack = contextlib.ExitStack()
        self._scratch = {n: self._stack.enter_context(scratch_file(self.path, option)) for n in units}

    def write(self, **series) -> None:
        """Append a block's rows of each series.

        Parameters
        ----------
        **series : array
            Every series of ``units`` by name, the same rows of each [in its unit].
        """
        for name, fh in self._scratch.items():
            text = _json_rows(series[name])
            if text:
                fh.write(((",\n" if fh.tell() else "") + text).encode())

    def close(self) -> Path:
        """Write the file (atomically) and remove the scratch files.

        Returns
        -------
        Path
            The truth file written.
        """
        import shutil

        from optinav.core.files import atomic_open, os_error

        with self._stack:
            d = self._head.to_dict()
            for n in self._scratch:
                d["parameters"][n]["value"] = f"@@series:{n}@@"
            text = json.dumps(d, indent=2, allow_nan=False)
            with atomic_open(self.path, "wb", self.option) as out:
                for n, fh in self._scratch.items():
                    head, text = text.split(f'"@@series:{n}@@"', 1)
                    out.write(head.encode() + b"[\n")
                    try:
                        fh.flush()
                        fh.seek(0)
                        shutil.copyfileobj(fh, out, 1 << 20)
                    except OSError as exc:
                        raise os_error(self.path, exc, self.option) from None
                    out.write(b"\n]")
                out.write(text.encode() + b"\n")
        return self.path

    def __enter__(self) -> "TruthSeriesWriter":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if kind is None:
            self.close()
        else:
            self._stack.close()


def register_truth_legacy(system: str, schema: str, convert) -> None:
    """Read truth files of an older optinav (``schema``) as ``system`` truth.

    Parameters
    ----------
    system : str
        The system.
    schema : str
        The old schema name.
    convert : callable
        ``convert(dict) -> {name: Parameter}``.
    """
    _TRUTH_LEGACY[system] = (schema, convert)
