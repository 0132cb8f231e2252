"""The map of docs/architecture.md, checked on the source: layering, no import circles, no
private names across modules.

Reference: the layer rules of docs/architecture.md ("Imports run one way", "No import
circles, not even through an import inside a function; no private names imported across
modules"). Every ``import`` statement of the package is read with :mod:`ast`, including those
inside functions.
"""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "neweul_py"

#: Layers that may not import the symbolic layers.
NUMERIC = ("elastic", "fem", "analysis", "ffrf")
SYMBOLIC = ("description", "model", "kinematics", "equations", "codegen")


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """``(module, imported names, line)`` of every import of ``path`` (absolute names),
    except those under ``if TYPE_CHECKING:`` (never executed)."""
    tree = ast.parse(path.read_text(), str(path))
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rsplit(".", 1)[0]
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and ast.unparse(node.test).endswith("TYPE_CHECKING")
                   for stmt in node.body for n in ast.walk(stmt)}
    out = []
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            out.append((mod, [a.name for a in node.names], node.lineno))
        elif isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names]
    return out


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in PKG.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in files}
    for mod, path in files.items():
        for target, names, _line in _imports(path):
            if not target.startswith("neweul_py"):
                continue
            subs = [n for n in names if f"{target}.{n}" in files]
            graph[mod].update(f"{target}.{n}" for n in subs)   # "from . import submodule"
            if target in files and (len(subs) < len(names) or not names):
                graph[mod].add(target)
    return graph


def test_numeric_layers_never_import_the_symbolic_layers() -> None:
    """elastic/, fem/, analysis/ and ffrf/ import none of description, model, kinematics,
    equations, codegen (docs/architecture.md)."""
    bad = []
    for layer in NUMERIC:
        for path in (PKG / layer).rglob("*.py"):
            for target, _names, line in _imports(path):
                parts = target.split(".")
                if len(parts) > 1 and parts[0] == "neweul_py" and parts[1] in SYMBOLIC:
                    bad.append(f"{path.relative_to(PKG)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


#: The rooms of elastic/ from the ground up: a room imports only rooms below it (or itself).
ELASTIC_ROOMS = ("fe_model", "bodies", "io", "reductors", ("parametric", "quality"))
#: Layers of the library that may not import an application built on them.
LIBRARY = ("description", "model", "kinematics", "equations", "codegen", "analysis",
           "elastic", "fem", "ffrf")


def _room(target: str) -> int | None:
    """Floor of an ``elastic`` module in :data:`ELASTIC_ROOMS` (``None`` outside elastic/)."""
    parts = target.split(".")
    if parts[:2] != ["neweul_py", "elastic"] or len(parts) < 3:
        return None
    for floor, rooms in enumerate(ELASTIC_ROOMS):
        if parts[2] in ((rooms,) if isinstance(rooms, str) else rooms):
            return floor
    return None


def test_elastic_rooms_import_downwards() -> None:
    """Inside elastic/: fe_model ← bodies ← io ← reductors ← parametric, quality
    (docs/architecture.md); a room never imports one on its own floor or above, but itself."""
    bad = []
    for path in (PKG / "elastic").rglob("*.py"):
        me = _module_name(path)
        mine = _room(me)
        if mine is None:
            continue
        for target, _names, line in _imports(path):
            there = _room(target)
            same_room = target.split(".")[:3] == me.split(".")[:3]
            if there is not None and there >= mine and not same_room:
                bad.append(f"{path.relative_to(PKG)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_the_library_never_imports_its_applications() -> None:
    """No layer of the library imports ``neweul_py.middle_ear`` (docs/architecture.md: the
    application is built on fem/ and elastic/, never imported by them)."""
    bad = []
    for layer in LIBRARY:
        for path in (PKG / layer).rglob("*.py"):
            for target, _names, line in _imports(path):
                if target.startswith("neweul_py.middle_ear"):
                    bad.append(f"{path.relative_to(PKG)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_no_import_circles() -> None:
    """No module reaches itself through imports (package ``__init__`` re-exports aside)."""
    graph = _graph()
    cycles = []
    for start in graph:
        stack = [(start, [start])]
        seen: set[str] = set()
        while stack:
            node, path = stack.pop()
            for nxt in graph[node]:
                if nxt == start:
                    cycles.append(" → ".join([*path, start]))
                elif nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, [*path, nxt]))
    assert not cycles, "\n".join(sorted(set(cycles))[:10])


def test_no_private_names_across_modules() -> None:
    """``from X import _name`` never crosses modules (a package's private submodules,
    ``from . import protocol``, are its own business)."""
    files = {_module_name(p) for p in PKG.rglob("*.py")}
    bad = []
    for path in PKG.rglob("*.py"):
        for target, names, line in _imports(path):
            if target.startswith("neweul_py"):
                bad += [f"{path.relative_to(PKG)}:{line} imports {target}.{n}"
                        for n in names if n.startswith("_") and not n.startswith("__")
                        and f"{target}.{n}" not in files]
    assert not bad, "\n".join(bad)


#: Calls that turn text into code or expressions (sympy's ``sympify``/``S`` parse strings).
PARSING_CALLS = {"eval", "exec", "sympify", "parse_expr", "S"}


def test_no_call_parses_text_as_code() -> None:
    """Reference: the rule that user text reaches sympy only through the description's own
    parser; conversions of values use ``neweul_py.model.as_expr``, which refuses strings. No
    call of ``eval``, ``exec``, ``sympify``, ``S`` or ``parse_expr`` (bare or as an attribute)
    anywhere in the package."""
    found = []
    for path in sorted(PKG.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call):
                f = node.func
                name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(
                    f, ast.Attribute) else ""
                if name in PARSING_CALLS:
                    found.append(f"{path.relative_to(PKG.parent)}:{node.lineno}: {name}(…)")
    assert not found, "\n" + "\n".join(found)
