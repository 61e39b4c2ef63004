"""Public functions are documented in one style (numpydoc): a ``Parameters`` section naming every parameter,
a ``Returns`` (or ``Yields``) section when the function returns something, and a unit in brackets for every
float or array quantity (``[rad/s]``, ``[m/s^2]``, ``[-]`` when dimensionless) — docs/conventions.md."""

import ast
import importlib
import inspect
import pkgutil
import re
import textwrap

import optinav.core

SYSTEMS = ("optinav.io", "optinav.rins", "optinav.multipos", "optinav.attitude", "optinav.gfimu")
#: ``optinav.core`` has no ``__all__``: each of its public modules is walked (their ``__all__``, or the public
#: functions and classes they define)
CORE = tuple(
    f"optinav.core.{m.name}" for m in pkgutil.iter_modules(optinav.core.__path__) if not m.name.startswith("_")
)
#: packages walked
PACKAGES = SYSTEMS + CORE
PARAM_KINDS = (
    inspect.Parameter.POSITIONAL_ONLY,
    inspect.Parameter.POSITIONAL_OR_KEYWORD,
    inspect.Parameter.KEYWORD_ONLY,
)
#: a type that names a physical quantity (a number or an array of numbers) must carry a unit
QUANTITY = re.compile(r"\b(float|array|ndarray|array_like)\b|\(N\b|\(\w+, 3\)")
#: … unless its elements are flags, text or integers (labels, indices, counts)
NOT_QUANTITY = re.compile(r"\b(bool|str)\b|\bint (array|ndarray|array_like)\b")
UNIT = re.compile(r"\[[^\]]+\]")


def _sections(doc: str) -> dict[str, list[str]]:
    """numpydoc sections of a docstring: title → its lines (dedented)."""
    lines = inspect.cleandoc(doc or "").splitlines()
    out, title = {}, None
    for k, line in enumerate(lines):
        if k + 1 < len(lines) and re.fullmatch(r"-{3,}", lines[k + 1].strip()) and line.strip():
            title = line.strip()
            out[title] = []
        elif title is not None and not re.fullmatch(r"-{3,}", line.strip()):
            out[title].append(line)
    return out


def _entries(lines: list[str]) -> list[tuple[list[str], str, str]]:
    """(names, type, description) of each ``name : type`` entry of a section."""
    out = []
    for line in lines:
        if line and not line[0].isspace():
            head, _, typ = line.partition(" : ")
            names = [n.strip().lstrip("*") for n in head.split(",")]
            out.append((names, typ.strip() if typ else head.strip(), ""))
        elif out and line.strip():
            names, typ, desc = out[-1]
            out[-1] = (names, typ, f"{desc} {line.strip()}")
    return out


def _returns_value(fn) -> str | None:
    """'Returns' / 'Yields' if the function's own body returns / yields a value, else None."""
    try:
        src = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError):
        return None
    tree = ast.parse(src).body[0]
    found = None

    def walk(node):
        nonlocal found
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
                continue
            if isinstance(child, (ast.Yield, ast.YieldFrom)):
                found = "Yields"
            elif isinstance(child, ast.Return) and child.value is not None and found is None:
                if not (isinstance(child.value, ast.Constant) and child.value.value is None):
                    found = "Returns"
            walk(child)

    walk(tree)
    return found


def check(name: str, fn) -> list[str]:
    """What ``fn``'s docstring lacks, one line each."""
    doc = inspect.getdoc(fn)
    if not doc:
        return [f"{name}: no docstring"]
    secs, bad = _sections(doc), []
    params = [
        p
        for p, v in inspect.signature(fn).parameters.items()
        if p not in ("self", "cls") and (v.kind in PARAM_KINDS or v.kind == inspect.Parameter.VAR_KEYWORD)
    ]
    entries = _entries(secs.get("Parameters", []))
    documented = {n for names, _, _ in entries for n in names}
    if params and "Parameters" not in secs:
        bad.append(f"{name}: no Parameters section")
    else:
        bad += [f"{name}: parameter {p!r} not documented" for p in params if p not in documented]
    kind = _returns_value(fn)
    if kind and kind not in secs:
        bad.append(f"{name}: no {kind} section")
    for sec in ("Parameters", "Returns", "Yields"):
        for names, typ, desc in _entries(secs.get(sec, [])):
            if QUANTITY.search(typ) and not NOT_QUANTITY.search(typ) and not UNIT.search(f"{typ} {desc}"):
                bad.append(f"{name}: {sec} {', '.join(names)} ({typ}) states no unit in brackets")
    return bad


def public_callables(packages=PACKAGES):
    """(qualified name, function) of every function and public method of every class in ``__all__``."""
    seen, out = set(), []
    for pkg in packages:
        mod = importlib.import_module(pkg)
        names = getattr(mod, "__all__", None) or [
            n
            for n, o in vars(mod).items()
            if not n.startswith("_")
            and getattr(o, "__module__", "") == pkg
            and (inspect.isfunction(o) or inspect.isclass(o))
        ]
        for n in names:
            obj = getattr(mod, n)
            if id(obj) in seen:
                continue
            seen.add(id(obj))
            if inspect.isfunction(obj):
                out.append((f"{pkg}.{n}", obj))
            elif inspect.isclass(obj):
                for k, v in vars(obj).items():
                    if isinstance(v, (classmethod, staticmethod)):
                        v = v.__func__
                    if inspect.isfunction(v) and not k.startswith("_"):
                        out.append((f"{pkg}.{n}.{k}", v))
    return out


def test_public_api_docstrings_have_parameters_returns_and_units():
    calls = public_callables()
    # the walk found the API: every system and most of core
    assert all(sum(n.startswith(f"{pkg}.") for n, _ in calls) >= 5 for pkg in SYSTEMS) and len(calls) > 200
    bad = [line for name, fn in calls for line in check(name, fn)]
    assert not bad, f"{len(bad)} docstring gaps:\n" + "\n".join(bad)


def test_the_docstring_check_flags_what_is_missing():
    def ok(t, acc, *, rate_hz=100.0):
        """Mean specific force.

        Parameters
        ----------
        t : (N,) array
            Epochs [s].
        acc : (N, 3) array
            Specific force [m/s^2].
        rate_hz : float
            Sample rate [Hz].

        Returns
        -------
        (3,) array
            Mean [m/s^2].
        """
        return acc.mean(0)

    def bad(t, acc, rate_hz=100.0):
        """Mean specific force.

        Parameters
        ----------
        t : (N,) array
            Epochs.
        acc : (N, 3) array
            Specific force [m/s^2].
        """
        return acc.mean(0)

    def gen(n):
        """Counts.

        Parameters
        ----------
        n : int
            How many.
        """
        yield from range(n)

    assert check("ok", ok) == []
    assert check("bad", bad) == [
        "bad: parameter 'rate_hz' not documented",
        "bad: no Returns section",
        "bad: Parameters t ((N,) array) states no unit in brackets",
    ]
    assert check("gen", gen) == ["gen: no Yields section"]
    assert check("none", lambda x: x) == ["none: no docstring"]
