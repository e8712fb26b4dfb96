"""Every third-party module that vcnc's packages import is a runtime dependency in pyproject.toml.

Found missing once: machine.workpiece.measure imports scipy (find_peaks, cKDTree), which was only in
the `dev` extra, so `pip install vcnc` without it failed `vcnc run --stock` and `vcnc surface-report`
with an ImportError; the README installs the dev extra, so nothing else caught it. The reference is
the installed distributions' own record of which top-level modules they provide.
"""
from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ipr", "ipo", "machine")


def _imported_modules() -> dict[str, str]:
    """Top-level third-party module -> a file of vcnc's packages that imports it."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top not in sys.stdlib_module_names and top not in PACKAGES:
                        found.setdefault(top, str(path.relative_to(ROOT)))
    return found


def _normalised(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def test_every_imported_module_is_a_runtime_dependency():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    runtime = {_normalised(re.split(r"[<>=!~;\[ ]", spec, maxsplit=1)[0]) for spec in project["dependencies"]}
    provided_by = importlib.metadata.packages_distributions()
    missing = {module: where for module, where in _imported_modules().items()
               if not {_normalised(d) for d in provided_by.get(module, [module])} & runtime}
    assert not missing, f"imported by vcnc but not in pyproject's dependencies: {missing}"
