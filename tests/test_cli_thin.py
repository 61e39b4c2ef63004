"""Review of the CLI's shape (issue 16, "a thin CLI"): a command parses its arguments, reads, calls one library
function and writes; the numerical work lives in the library where a Python user can call it.

Measured from the source (AST), no import of the commands: the functions the parser dispatches to (every
``set_defaults(func=NAME)`` in ``src/optinav/cli/``) and the private helpers of the same module they reach.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "optinav"
CLI = SRC / "cli"

#: logical code lines (statements, the docstring excluded: the same however a formatter wraps them) of one command
#: function's body
MAX_BODY = 30
#: statements of a command together with the helpers of its own module it calls (directly or through each other):
#: room for the command's argument checks, while moving the work into private helpers beside the command does
#: not make it thin (before issue 16: attitude 198 lines, allan 100)
MAX_REACH = 75

#: commands still above a limit, with their measured lines when the list was written. Each entry is owned by the
#: work named in its comment and is removed when that lands; the test fails if an entry is no longer needed (or
#: if its command grew), so the list can only shrink.
ALLOWED: dict[tuple[str, str, str], int] = {
    # e.g. ("gfimu.py", "run_calibrate", "reach"): 80,  # owner: what moves where, then remove the entry
}


def _code_lines(fn: ast.FunctionDef) -> int:
    """Logical lines of ``fn``'s body: its statements, nested ones included (a compound statement counts once
    for its header), the docstring not; the count does not change when a formatter wraps a long call."""
    body = fn.body
    if (
        body
        and isinstance(body[0], ast.Expr)
        and isinstance(body[0].value, ast.Constant)
        and isinstance(body[0].value.value, str)
    ):
        body = body[1:]
    return sum(1 for stmt in body for node in ast.walk(stmt) if isinstance(node, ast.stmt))


def _dispatched(tree: ast.Module) -> set[str]:
    """Names passed as ``func=`` to ``set_defaults`` anywhere in the module (the commands the parser runs)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "set_defaults":
            out |= {kw.value.id for kw in node.keywords if kw.arg == "func" and isinstance(kw.value, ast.Name)}
    return out


def _reach(name: str, functions: dict[str, ast.FunctionDef]) -> set[str]:
    """``name`` and the module-level functions of its module it calls, transitively."""
    seen, todo = set(), [name]
    while todo:
        n = todo.pop()
        if n in seen or n not in functions:
            continue
        seen.add(n)
        todo += [c.func.id for c in ast.walk(functions[n]) if isinstance(c, ast.Call) and isinstance(c.func, ast.Name)]
    return seen


def measure() -> dict[tuple[str, str, str], int]:
    """``(module file, command, "body"|"reach") -> statements`` of every dispatched command in ``cli/``."""
    out = {}
    for path in sorted(CLI.glob("*.py")):
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
        for name in sorted(_dispatched(tree)):
            assert name in functions, f"{path.name}: the parser dispatches to {name}, not a function of the module"
            out[(path.name, name, "body")] = _code_lines(functions[name])
            out[(path.name, name, "reach")] = sum(_code_lines(functions[n]) for n in _reach(name, functions))
    return out


def test_the_review_sees_every_command():
    found = measure()
    commands = {(f, n) for f, n, _ in found}
    # sun, allan, design, export, reproduce, attitude, the simulate kinds, calibrate/apply, rins, gfimu, batch
    assert len(commands) >= 15
    for expected in (("sun.py", "run"), ("attitude.py", "run"), ("allan.py", "run"), ("simulate.py", "run_static")):
        assert expected in commands


def test_command_bodies_are_thin():
    found = measure()
    too_long = {
        k: v for k, v in found.items() if v > (MAX_BODY if k[2] == "body" else MAX_REACH) and v > ALLOWED.get(k, -1)
    }
    assert not too_long, (
        "CLI commands doing library work (statements above the limit "
        f"{MAX_BODY} per body, {MAX_REACH} with their module's helpers): {too_long}"
    )


def test_the_allow_list_only_shrinks():
    found = measure()
    stale = {
        k: (v, found.get(k))
        for k, v in ALLOWED.items()
        if found.get(k) is None or found[k] <= (MAX_BODY if k[2] == "body" else MAX_REACH)
    }
    assert not stale, f"ALLOWED entries no longer needed (remove them): {stale}"


def test_the_measure_counts_code_not_docstrings_or_comments():
    src = 'def f(args):\n    """Doc\n    string."""\n    # why\n\n    a = 1\n    b = (a,\n         2)\n    return b\n'
    fn = ast.parse(src).body[0]
    assert _code_lines(fn) == 3  # a wrapped statement counts once
    # a compound statement counts its header and its body; a formatter's wrapping changes nothing
    loop = "def f():\n    for i in range(3):\n        if i:\n            g(i,\n              2)\n    return 1\n"
    assert _code_lines(ast.parse(loop).body[0]) == 4
    assert _code_lines(ast.parse(loop.replace("g(i,\n              2)", "g(i, 2)")).body[0]) == 4
    tree = ast.parse(
        "def g():\n    h()\ndef h():\n    x = 1\n    return x\ndef k():\n    pass\n"
        "p.set_defaults(func=g, progress_task='g')\n"
    )
    functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert _dispatched(tree) == {"g"}
    assert _reach("g", functions) == {"g", "h"}


@pytest.mark.parametrize(
    "path", sorted(p for p in SRC.rglob("*.py") if CLI not in p.parents), ids=lambda p: str(p.relative_to(SRC))
)
def test_no_argparse_outside_the_cli(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        names = (
            [a.name for a in node.names]
            if isinstance(node, ast.Import)
            else [node.module or ""]
            if isinstance(node, ast.ImportFrom)
            else []
        )
        assert not any(n.split(".")[0] == "argparse" for n in names), f"{path.name} imports argparse"


#: library functions that still take an argparse namespace, and who removes them
ALLOWED_ARGS_PARAMETER: set[str] = set()


def test_the_library_takes_no_argparse_namespace():
    """Mapping parsed arguments to library options is the CLI's job (optinav.cli.common.options_from_args): no
    function outside cli/ has a parameter ``args`` (a namespace) or is a ``from_args`` constructor."""
    found = set()
    for path in SRC.rglob("*.py"):
        if CLI in path.parents:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        owners = {id(f): f"{cls.name}." for cls in ast.walk(tree) if isinstance(cls, ast.ClassDef) for f in cls.body}
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and (
                node.name == "from_args"
                or "args" in {a.arg for a in node.args.args + node.args.kwonlyargs + node.args.posonlyargs}
            ):
                found.add(f"{path.relative_to(SRC).as_posix()}:{owners.get(id(node), '')}{node.name}")
    assert found <= ALLOWED_ARGS_PARAMETER, f"the library takes argparse namespaces: {found - ALLOWED_ARGS_PARAMETER}"
    assert ALLOWED_ARGS_PARAMETER <= found, f"remove from ALLOWED_ARGS_PARAMETER: {ALLOWED_ARGS_PARAMETER - found}"


#: what the CLI may use of NumPy: unit conversion at the boundary (degrees ↔ radians), arrays of parsed numbers,
#: seeds
CLI_NUMPY = {"radians", "degrees", "asarray", "ndarray", "random.default_rng"}
#: NumPy the CLI still uses beyond that, per module, and who moves it into the library (the list only shrinks)
ALLOWED_NUMPY: dict[str, set[str]] = {}


def _numpy_names(tree: ast.Module) -> set[str]:
    """``np.NAME`` (``np.linalg.cond`` → ``linalg.cond``) used in a module."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            parts, n = [], node
            while isinstance(n, ast.Attribute):
                parts.append(n.attr)
                n = n.value
            if isinstance(n, ast.Name) and n.id == "np":
                out.add(".".join(reversed(parts)))
    # only the longest chains: np.linalg.cond, not also np.linalg
    return {a for a in out if not any(b.startswith(a + ".") for b in out)}


def test_the_cli_does_no_array_math():
    used = {p.name: _numpy_names(ast.parse(p.read_text(encoding="utf-8"))) - CLI_NUMPY for p in CLI.glob("*.py")}
    extra = {
        m: sorted(names - ALLOWED_NUMPY.get(m, set()))
        for m, names in used.items()
        if names - ALLOWED_NUMPY.get(m, set())
    }
    assert not extra, f"NumPy work in the CLI (move it into the library): {extra}"
    stale = {m: sorted(names - used.get(m, set())) for m, names in ALLOWED_NUMPY.items() if names - used.get(m, set())}
    assert not stale, f"ALLOWED_NUMPY entries no longer needed (remove them): {stale}"


if __name__ == "__main__":  # the review as a table: python tests/test_cli_thin.py
    rows = measure()
    print(f"{'module':<14} {'command':<22} {'body':>5} {'reach':>6}   (limits {MAX_BODY} / {MAX_REACH} statements)")
    for (module, name, kind), n in rows.items():
        if kind == "body":
            print(f"{module:<14} {name:<22} {n:>5} {rows[(module, name, 'reach')]:>6}")


def test_python_m_optinav_is_the_command():
    """``python -m optinav`` runs the same command (a scripts folder off PATH), exit codes included."""
    import subprocess
    import sys

    ok = subprocess.run([sys.executable, "-m", "optinav", "--version"], capture_output=True, text=True, timeout=60)
    assert ok.returncode == 0 and ok.stdout.startswith("optinav ")
    bad = subprocess.run([sys.executable, "-m", "optinav", "sun", "--nonsense"], capture_output=True, timeout=60)
    assert bad.returncode == 2
