"""The layout's rules, read from the source: import direction between packages and ipo's rooms,
no import cycles, no module past 400 lines.

Each room's `__init__.py` says what it may import; ALLOWED below is that table.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ipr", "ipo", "machine")
# ipo's rooms -> the rooms they may import (besides their own); "ipo" is the top level
# (config, contracts, errors, roughness), which imports no room.
ALLOWED = {
    "ipo": set(),
    "ipo.nurbs": {"ipo"},
    "ipo.interp": {"ipo", "ipo.nurbs"},
    "ipo.feed.blends": {"ipo", "ipo.nurbs"},
    "ipo.feed": {"ipo", "ipo.nurbs", "ipo.interp", "ipo.feed.blends"},
    "ipo.fit": {"ipo", "ipo.nurbs"},
    "ipo.surface": {"ipo", "ipo.nurbs", "ipo.fit"},
}
MAX_LINES = 400


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in (ROOT / pkg).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


MODULES = _modules()


def _imports(path: Path, *, top_level_only: bool = False) -> set[str]:
    """The project modules a file imports: anywhere in its body, or (top_level_only) those
    imported when the module itself is imported. Imports under `if TYPE_CHECKING:` never
    run and are left out. The project uses no relative imports."""
    found = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                for sub in child.orelse:
                    visit_one(sub)
                continue
            if top_level_only and isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                continue
            visit_one(child)

    def visit_one(child: ast.AST) -> None:
        if isinstance(child, ast.Import):
            found.update(a.name for a in child.names)
        elif isinstance(child, ast.ImportFrom):
            assert child.level == 0, f"{path}: relative import"
            found.update({child.module} | {f"{child.module}.{a.name}" for a in child.names})
        visit(child)

    visit(ast.parse(path.read_text(), str(path)))
    return {m for m in found if m in MODULES}


GRAPH = {name: _imports(path) for name, path in MODULES.items()}
AT_IMPORT = {name: _imports(path, top_level_only=True) for name, path in MODULES.items()}


def _room(module: str) -> str:
    """The longest room of ALLOWED that holds module (top-level modules: "ipo")."""
    return max((r for r in ALLOWED if module == r or module.startswith(r + ".")), key=len)


def test_the_rooms_table_is_read_from_real_packages():
    assert {"ipo.feed.planner", "ipo.nurbs.kernel", "ipo.fit.convert", "ipo.surface.iges", "ipo.errors"} <= set(MODULES)
    assert _room("ipo.feed.blends.curve_corner") == "ipo.feed.blends" and _room("ipo.contracts") == "ipo"
    assert "ipo.nurbs.kernel" in GRAPH["ipo.nurbs.compiled"]  # the parser sees imports


def test_ipr_imports_nothing_of_ipo_or_machine_and_ipo_nothing_of_machine():
    bad = [(m, i) for m, deps in GRAPH.items() for i in deps
           if (m.startswith("ipr") and not i.startswith("ipr")) or (m.startswith("ipo") and i.startswith("machine"))]
    assert bad == []


def test_ipo_rooms_import_only_the_rooms_their_docstring_allows():
    bad = []
    for m, deps in GRAPH.items():
        if not m.startswith("ipo"):
            continue
        room = _room(m)
        for i in deps:
            if i.startswith("ipo") and _room(i) != room and _room(i) not in ALLOWED[room]:
                bad.append(f"{m} ({room}) imports {i} ({_room(i)})")
    assert bad == []


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Import cycles by depth-first search; a module importing its own package (a
    docstring-only __init__) is not one."""
    state: dict[str, int] = {}
    found = []

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for i in sorted(graph[m]):
            if m.startswith(i + "."):
                continue
            if state.get(i) == 1:
                found.append(stack[stack.index(i):] + [i])
            elif i not in state:
                visit(i, stack + [i])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    return found


def test_no_import_cycles():
    """None in ipr and ipo, counting imports inside functions too; none at import time in
    machine, whose commands import each other lazily (a function-level import)."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    strict = {m: deps for m, deps in GRAPH.items() if not m.startswith("machine")}
    assert _cycles(strict) == []
    assert _cycles(AT_IMPORT) == []


@pytest.mark.parametrize("pkg", PACKAGES)
def test_no_module_past_400_lines(pkg):
    long = {str(p.relative_to(ROOT)): n for m, p in MODULES.items() if m.split(".")[0] == pkg
            and (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}
