"""Where the numba kernels of ipr, ipo and machine keep their compiled machine code.

Why not numba's default: `cache=True` keys each kernel's cached code on its own source file
only. A kernel that calls a kernel in another file, or reads a constant imported from one,
keeps running the old compiled code after that other file changes (seen three times while
vcnc was developed; a user who updates an editable checkout with `git pull` would hit it too).

So the cache lives in a directory named by one hash over the source of every module a kernel
can depend on: the modules that use numba and, transitively, the project modules they import.
Any change to one of them gives a new, empty directory; edits elsewhere (the CLI, plots) keep
the compiled kernels. The directory is
`$NUMBA_CACHE_DIR/<hash>` when the user set NUMBA_CACHE_DIR, else
`$XDG_CACHE_HOME/vcnc/kernels/<hash>` (`~/.cache/...`). `use_source_keyed_cache` runs from
`ipo/__init__`, before any kernel module of ipo or machine is imported (machine imports ipo
first); ipr alone (no ipo imported) keeps numba's default.

Loading the first cached kernel of a process makes numba import its implementations, among them
numba.np.arraymath, which checks at import that a BLAS is there for `np.dot` in kernels by
importing scipy.linalg.cython_blas. That import runs the whole scipy.linalg package first:
0.2-0.3 s of CPU in every vcnc process, a fifth of `vcnc interp`'s, for a package vcnc does
not use. `spare_scipy_linalg` (also from `ipo/__init__`) loads the extension module alone,
under its own name, so the check finds it; see there why that is the same module.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shutil
import sys
import time
from pathlib import Path

PACKAGES = ("ipr", "ipo", "machine")
_ROOT = Path(__file__).resolve().parent.parent
_VERSION = r"[0-9a-f]{16}"
# a kernel module imports numba at its top; the CLI's numba imports inside functions (run's compile
# notice, warmup's counter: numba.core.event) define no kernel, and would key every kernel on the CLI
_USES_NUMBA = re.compile(rb"^(?:import|from)\s+numba\b", re.M)
_IMPORT = re.compile(r"^\s*(?:from\s+((?:ipr|ipo|machine)(?:\.\w+)*)\s+import\s+\(?([\w\s,]+)\)?"
                     r"|import\s+((?:ipr|ipo|machine)(?:\.\w+)*))", re.M)


def _imported(name: str, text: str) -> set[str]:
    """Project modules named by a module's imports, with the packages that hold them."""
    found = set()
    for frm, names, plain in _IMPORT.findall(text):
        if frm:
            found.add(frm)
            found.update(f"{frm}.{n.strip()}" for n in names.split(",") if n.strip())
        else:
            found.add(plain)
    parents = {".".join(m.split(".")[:k]) for m in found | {name} for k in range(1, m.count(".") + 1)}
    return found | parents


def package_files(root: Path, suffix: str = ".py") -> list[Path]:
    """The files of vcnc's packages under root whose names end with suffix, in a fixed order
    (also machine.client's key of the code a server runs, with every file)."""
    files = []
    for package in PACKAGES:
        for folder, subfolders, names in os.walk(root / package):
            subfolders[:] = sorted(s for s in subfolders if s != "__pycache__")
            files += [Path(folder, n) for n in sorted(names) if n.endswith(suffix)]
    return files


def kernel_sources(root: Path = _ROOT) -> dict[str, bytes]:
    """Source of every module a compiled kernel can depend on, by module name (`root` holds
    the packages)."""
    texts = {}
    for path in package_files(root):
        name = ".".join(path.relative_to(root).with_suffix("").parts)
        texts[name.removesuffix(".__init__")] = path.read_bytes()
    todo = [name for name, text in texts.items() if _USES_NUMBA.search(text)]
    needed = set(todo)
    while todo:
        name = todo.pop()
        for dep in _imported(name, texts[name].decode()):
            if dep in texts and dep not in needed:
                needed.add(dep)
                todo.append(dep)
    return {name: texts[name] for name in sorted(needed)}


def source_hash(root: Path = _ROOT) -> str:
    """The kernels' source version: a hash of `kernel_sources`."""
    digest = hashlib.sha1()
    for name, text in kernel_sources(root).items():
        digest.update(name.encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


def _stat_key() -> str:
    digest = hashlib.sha1(str(_ROOT).encode())
    for path in package_files(_ROOT):
        st = path.stat()
        digest.update(f"{path}\0{st.st_mtime_ns}\0{st.st_size}\0".encode())
    return digest.hexdigest()


def source_version(root: Path) -> str:
    """`source_hash`, remembered under `root` by the files' sizes and times.

    Reading and hashing the sources takes 50-100 ms; a stat of each file about 1.5 ms in all,
    so a run pays the full hash only when some file changed since the last one.
    """
    memo = root / "by-stat" / _stat_key()
    try:
        return memo.read_text().strip()
    except OSError:
        pass
    version = source_hash()
    try:
        memo.parent.mkdir(parents=True, exist_ok=True)
        scratch = memo.with_suffix(f".{os.getpid()}")
        scratch.write_text(version)
        scratch.replace(memo)
    except OSError:
        pass
    return version


def cache_root() -> Path:
    """The directory holding one cache per source version."""
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        return Path(user)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "vcnc" / "kernels"


def use_source_keyed_cache() -> Path:
    """Point numba's cache at this source version's directory; return it.

    A child process (a test calling the CLI) inherits NUMBA_CACHE_DIR pointing at a version's
    directory; it takes that directory's parent as the root rather than nesting another level.
    """
    root = cache_root()
    if re.fullmatch(_VERSION, root.name):
        root = root.parent
    path = root / source_version(root)
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.config.CACHE_DIR = str(path)
    return path


def prune_other_versions(current: Path, older_than_s: float) -> tuple[int, int]:
    """Delete the caches of other source versions not written for `older_than_s`.

    Returns (directories removed, bytes freed). Other versions' caches still in use (another
    checkout of a different commit on the same account) are kept by the age limit.
    """
    removed = freed = 0
    cutoff = time.time() - older_than_s
    for memo in (current.parent / "by-stat").glob("*"):
        if memo.stat().st_mtime < cutoff:
            memo.unlink(missing_ok=True)
    for other in current.parent.iterdir() if current.parent.is_dir() else ():
        if other == current or not other.is_dir() or not re.fullmatch(_VERSION, other.name):
            continue
        files = [f for f in other.rglob("*") if f.is_file()]
        if max((f.stat().st_mtime for f in files), default=0.0) > cutoff:
            continue
        freed += sum(f.stat().st_size for f in files)
        shutil.rmtree(other, ignore_errors=True)
        removed += 1
    return removed, freed


_CYTHON_BLAS = "scipy.linalg.cython_blas"


def spare_scipy_linalg() -> None:
    """Have scipy.linalg.cython_blas loaded alone, without its package, when numba imports
    numba.np.arraymath (see the module's docstring); nothing is loaded before then, so that
    `vcnc --help` loads no numpy.

    It is the module scipy's own import would load: the same file (found in scipy/linalg by the
    standard path finder), and the same module object for numba's BLAS calls (numba._helperlib
    imports it by name, from sys.modules) and for scipy's extension modules that cimport it.
    Should scipy.linalg be imported later, the module is set on it as its own import would have
    done. Nothing changes when scipy.linalg or numba's implementations are loaded already, and
    any failure leaves the import to numba as before."""
    if not any(m in sys.modules for m in ("scipy.linalg", _CYTHON_BLAS, "numba.np.arraymath")):
        sys.meta_path.insert(0, _OnceFinder("numba.np.arraymath", _load_cython_blas))


class _OnceFinder:
    """A meta path finder that acts on the first import of one module, then leaves sys.meta_path
    (a new list: the import under way keeps iterating the old one). `act(path, target)` returns
    the module's spec, or None for the finders after it to find it."""

    def __init__(self, name: str, act):
        self.name, self.act = name, act

    def find_spec(self, fullname, path=None, target=None):
        if fullname != self.name:
            return None
        sys.meta_path = [f for f in sys.meta_path if f is not self]
        return self.act(path, target)


def _load_cython_blas(path, target) -> None:
    try:
        import scipy

        spec = importlib.machinery.PathFinder.find_spec(_CYTHON_BLAS, [os.path.join(scipy.__path__[0], "linalg")])
        if spec is None:
            return None
        module = importlib.util.module_from_spec(spec)
        sys.modules[_CYTHON_BLAS] = module
        spec.loader.exec_module(module)
    except (ImportError, OSError):
        sys.modules.pop(_CYTHON_BLAS, None)
        return None
    sys.meta_path.insert(0, _OnceFinder("scipy.linalg", _scipy_linalg_binding_cython_blas))
    return None


def _scipy_linalg_binding_cython_blas(path, target):
    """scipy.linalg's spec as the path finder finds it, its loader also setting the preloaded
    cython_blas on the package once it has run."""
    spec = importlib.machinery.PathFinder.find_spec("scipy.linalg", path, target)
    if spec is not None and spec.loader is not None:
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            module.cython_blas = sys.modules[_CYTHON_BLAS]

        spec.loader.exec_module = exec_module
    return spec
