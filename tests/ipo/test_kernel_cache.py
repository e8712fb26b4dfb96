"""ipo.kernel_cache: numba's cache directory follows every source a kernel depends on."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from ipo import kernel_cache

ROOT = Path(kernel_cache.__file__).resolve().parents[1]


def _copy_tree(tmp_path: Path) -> Path:
    for package in kernel_cache.PACKAGES:
        shutil.copytree(ROOT / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def test_a_constant_a_kernel_imports_from_another_file_changes_the_version(tmp_path):
    # ipr/plain_runs.py (numba) takes MOTION_LINEAR from ipr/gcodes.py: numba's own cache keys
    # plain_runs' code on plain_runs.py alone, the failure this module exists for
    tree = _copy_tree(tmp_path)
    assert b"from ipr.gcodes import" in (tree / "ipr" / "plain_runs.py").read_bytes()
    before = kernel_cache.source_hash(tree)
    assert "ipr.gcodes" in kernel_cache.kernel_sources(tree)
    gcodes = tree / "ipr" / "gcodes.py"
    gcodes.write_text(gcodes.read_text() + "\nEXTRA_CONSTANT = 1\n")
    assert kernel_cache.source_hash(tree) != before


def test_a_change_no_kernel_depends_on_keeps_the_version(tmp_path):
    tree = _copy_tree(tmp_path)
    before = kernel_cache.source_hash(tree)
    sources = kernel_cache.kernel_sources(tree)
    # run.py and warmup.py import numba.core.event inside functions (no kernel): once they counted, and
    # with them every module machine.commands imports, so an edit of the CLI recompiled every kernel
    for name in ("cli", "commands/run", "commands/warmup", "commands/__init__"):
        assert "machine." + name.replace("/", ".").removesuffix(".__init__") not in sources
        path = tree / "machine" / f"{name}.py"
        path.write_text(path.read_text() + "\n# an edit\n")
    assert kernel_cache.source_hash(tree) == before


def test_kernels_cache_under_the_version_directory(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    code = ("import os, ipo.nurbs.compiled as c, numpy as np; "
            "c.find_span(np.array([0., 0, 0, 1, 1, 1]), 2, 0.5, 2); "
            "print(os.environ['NUMBA_CACHE_DIR'])")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    version_dir = Path(out.stdout.strip())
    assert version_dir.parent == tmp_path and version_dir.name == kernel_cache.source_hash()
    assert any(version_dir.rglob("*.nbi")), "the kernel's index went to the version directory"
    # a child started from there (a test calling the CLI) keeps the same directory
    env = dict(os.environ, NUMBA_CACHE_DIR=str(version_dir))
    out = subprocess.run([sys.executable, "-c", "import os, ipo; print(os.environ['NUMBA_CACHE_DIR'])"],
                         env=env, capture_output=True, text=True, check=True)
    assert Path(out.stdout.strip()) == version_dir


def test_prune_keeps_recent_caches_and_removes_old_ones(tmp_path):
    current, recent, old = (tmp_path / n for n in ("0" * 16, "1" * 16, "2" * 16))
    for d in (current, recent, old):
        (d / "sub").mkdir(parents=True)
        (d / "sub" / "k.nbc").write_bytes(b"x" * 1000)
    os.utime(old / "sub" / "k.nbc", (0, 0))
    assert kernel_cache.prune_other_versions(current, older_than_s=3600) == (1, 1000)
    assert current.exists() and recent.exists() and not old.exists()


BLAS_CHECK = """
import sys
import numpy as np
import ipo
from ipo.nurbs.compiled import dist3
dist3(0.0, 0.0, 0.0, 1.0, 1.0, 1.0)  # the first kernel load: numba imports its implementations
import numba.np.arraymath
print(numba.np.arraymath._HAVE_BLAS, "scipy.linalg" in sys.modules)
from numba import njit
dot = njit(lambda a, b: np.dot(a, b))
rng = np.random.default_rng(3)
a, b = rng.normal(size=(2, 10_000)) * np.logspace(0, 12, 10_000)
acc = 0.0
for x, y in zip(a.tolist(), b.tolist()):
    acc += x * y  # numba's np.dot without a BLAS: a plain loop
import scipy.linalg
import scipy.linalg.cython_blas
from scipy.linalg import blas
print(dot(a, b) == blas.ddot(a, b), dot(a, b) == acc, scipy.linalg.cython_blas is sys.modules["scipy.linalg.cython_blas"])
print(scipy.linalg.solve(np.diag([2.0, 4.0]), np.ones(2)).tolist())
"""


def test_numba_finds_its_blas_without_importing_scipy_linalg():
    """ipo loads scipy.linalg.cython_blas alone (kernel_cache.spare_scipy_linalg): numba's BLAS
    check passes, a kernel's np.dot is scipy's BLAS ddot bit for bit (not numba's loop for a
    missing BLAS), and scipy.linalg imported later works and holds the same module."""
    out = subprocess.run([sys.executable, "-c", BLAS_CHECK], capture_output=True, text=True, check=True,
                         cwd=ROOT).stdout.split("\n")
    assert out[0] == "True False"  # BLAS found, scipy.linalg not imported
    assert out[1] == "True False True"
    assert out[2] == "[0.5, 0.25]"
