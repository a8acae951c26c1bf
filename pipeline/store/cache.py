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
DOCUMENT_WRITERS = ("pipeline/reproduction/__main__.py", "pipeline/report/html.py", "pipeline/reproduction/paper_report.py",
                    "pipeline/reproduction/")
#: data files the cached computations read (the papers' numbers score the readings study)
DATA_FILES = ("pipeline/reproduction/papers/*.yaml",)


def _source_digest() -> str:
    """Hash of every ``.py`` file of the two packages (names and contents) but
    :data:`DOCUMENT_WRITERS`, and of :data:`DATA_FILES`, 12 hex digits."""
    digest = hashlib.sha256()
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


#: package version + hash of the sources; names the cache's subdirectory
CODE_VERSION = f"{__version__}+{_source_digest()}"


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
