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


def _imports(path: Path) -> set[str]:
    """The project modules a file imports, anywhere in its body (the project uses no relative imports)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}: relative import"
            found |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
    return {m for m in found if m in MODULES}


GRAPH = {name: _imports(path) for name, path in MODULES.items()}


def _room(module: str) -> str:
    """The longest room of ALLOWED that holds module (top-level modules: "ipo")."""
    return max((r for r in ALLOWED if module == r or module.startswith(r + ".")), key=len)


def test_the_rooms_table_is_read_from_real_packages():
    assert {"ipo.feed.planner", "ipo.nurbs.kernel", "ipo.fit.convert", "ipo.surface.iges", "ipo.errors"} <= set(MODULES)
    assert _room("ipo.feed.blends.nurbs_corner") == "ipo.feed.blends" and _room("ipo.contracts") == "ipo"
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
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles(GRAPH) == []


@pytest.mark.parametrize("pkg", PACKAGES)
def test_no_module_past_400_lines(pkg):
    long = {str(p.relative_to(ROOT)): n for m, p in MODULES.items() if m.split(".")[0] == pkg
            and (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}
