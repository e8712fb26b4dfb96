"""Shared test helpers: where the shared corpus lives, skipping cleanly where it is absent.

Import the plain helpers from a test module with `from conftest import corpus_files`
(pytest puts tests/ on sys.path), or use the `shared_dir` / `corpus` fixtures.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

import ipo  # noqa: F401  (before any kernel, ipr's too: numba's source-keyed cache, ipo/kernel_cache.py)

# CI must not fail by the luck of the draw: there the property tests replay a fixed sequence of
# examples (developers' runs stay random and keep finding new cases).
settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# Many small least-squares fits: BLAS threads only contend for the two cores (as in the CLI).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

# The repo is /work/main and the shared material /work/shared: a sibling of the checkout.
SHARED_DIR = Path(__file__).resolve().parents[2] / "shared"
CORPUS_DIR = SHARED_DIR / "corpus" / "linuxcnc"
_MISSING = f"shared corpus not found at {CORPUS_DIR} (it lives outside the repo, in ../shared)"


def require_corpus() -> Path:
    """The LinuxCNC corpus directory, or skip the calling test."""
    if not CORPUS_DIR.is_dir():
        pytest.skip(_MISSING)
    return CORPUS_DIR


def corpus_files(pattern: str = "*.ngc") -> list:
    """Corpus files for `pytest.mark.parametrize`, ids by file name; one skipped param where absent."""
    files = sorted(CORPUS_DIR.glob(pattern)) if CORPUS_DIR.is_dir() else []
    if not files:
        return [pytest.param(None, id="no-corpus", marks=pytest.mark.skip(reason=_MISSING))]
    return [pytest.param(f, id=f.name) for f in files]


@pytest.fixture
def shared_dir() -> Path:
    if not SHARED_DIR.is_dir():
        pytest.skip(f"shared directory not found at {SHARED_DIR}")
    return SHARED_DIR


@pytest.fixture
def corpus() -> Path:
    return require_corpus()
