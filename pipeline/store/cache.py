"""One lazily built ``joblib.Memory`` per cache directory and code version (the benchopt pattern).

Stages are plain functions of typed config sections; :func:`cached` wraps
one with the Memory of ``<cache_dir>/<CODE_VERSION>``. The code version
(package version + a hash of every source file of ``kinematics`` and
``pipeline`` except the document writers) is part of the location, not of the stages' signatures, so
editing any source starts a fresh cache and the stages never see it.
``n_jobs`` is never part of a key: results do not depend on it. Tests check
hits with joblib's own ``check_call_in_cache``.
"""

from __future__ import annotations

import hashlib
import inspect
import re
import shutil
from collections.abc import Callable
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from joblib import Memory

import kinematics
import pipeline

try:
    __version__ = version("pm-design")
except PackageNotFoundError:  # a source tree that was not installed
    __version__ = "0+unknown"


#: modules (and folders of modules) that write documents and pages from results, which no cached
#: stage runs: editing their prose must not throw away hours of cached studies. Everything else is
#: in the key.
DOCUMENT_WRITERS = ("pipeline/report/", "pipeline/reproduction/")
#: data files the cached computations read (the papers' numbers score the readings study)
DATA_FILES = ("pipeline/reproduction/papers/*.yaml",)


#: libraries whose version can change a cached number (compiled kernels, linear algebra, Sobol, CMA-ES)
NUMERIC_LIBRARIES = ("numpy", "numba", "scipy", "cma")


def library_versions() -> dict[str, str]:
    """Installed versions of :data:`NUMERIC_LIBRARIES` (``"absent"`` for one not installed)."""
    out = {}
    for name in NUMERIC_LIBRARIES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "absent"
    return out


def _source_digest() -> str:
    """Hash of every ``.py`` file of the two packages (names and contents) but
    :data:`DOCUMENT_WRITERS`, of :data:`DATA_FILES`, and of the :func:`library_versions`:
    12 hex digits. A new numpy or numba starts a fresh cache, as an edited source does."""
    digest = hashlib.sha256()
    digest.update(repr(sorted(library_versions().items())).encode())
    for package in (kinematics, pipeline):
        root = Path(package.__file__).parent
        data = [p for pattern in DATA_FILES if pattern.startswith(f"{root.name}/")
                for p in root.glob(pattern.split("/", 1)[1])]
        for path in sorted([*root.rglob("*.py"), *data]):
            name = str(path.relative_to(root.parent))
            if name.startswith(DOCUMENT_WRITERS):
                continue
            digest.update(name.encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


#: package version + hash of the sources and numeric libraries; names the cache's subdirectory
CODE_VERSION = f"{__version__}+{_source_digest()}"
#: what a code-version subdirectory of a cache directory is called (anything else there is left alone)
_VERSION_DIR = re.compile(r"^[0-9A-Za-z.+!_-]+\+[0-9a-f]{12}$")


def prune(cache_dir: str | Path, dry_run: bool = False) -> list[tuple[Path, int]]:
    """Remove the cache entries of every other code version under ``cache_dir``.

    Each edit of the sources or upgrade of a numeric library starts a fresh
    ``<cache_dir>/<CODE_VERSION>``; the old ones are never read again. Only
    subdirectories named like a code version are removed; the current one and
    anything else in ``cache_dir`` stay.

    Returns
    -------
    list of (path, bytes)
        The removed (or, with ``dry_run``, removable) directories and their sizes.
    """
    root = Path(cache_dir)
    stale = [d for d in sorted(root.iterdir()) if d.is_dir() and not d.is_symlink()
             and d.name != CODE_VERSION and _VERSION_DIR.match(d.name)] if root.is_dir() else []
    out = []
    for d in stale:
        size = sum(f.stat().st_size for f in d.rglob("*") if f.is_file() and not f.is_symlink())
        if not dry_run:
            shutil.rmtree(d)
        out.append((d, size))
    return out


@lru_cache(maxsize=8)
def memory(cache_dir: str) -> Memory:
    """The ``joblib.Memory`` of ``cache_dir`` for this code version (built on first use)."""
    location = Path(cache_dir) / CODE_VERSION
    location.mkdir(parents=True, exist_ok=True)
    return Memory(location=str(location), verbose=0)


def cached(func: Callable, cache_dir: str | Path) -> Callable:
    """``func`` memoised on disk in ``cache_dir``; an ``n_jobs`` argument is not keyed."""
    params = inspect.signature(func).parameters
    return memory(str(cache_dir)).cache(func, ignore=[n for n in ("n_jobs",) if n in params])
