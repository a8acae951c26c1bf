"""One lazily built ``joblib.Memory`` behind a tiny helper (the benchopt pattern).

Stages are plain functions; :func:`cached` wraps one with the Memory of a
cache directory. Their arguments are plain dicts from the resolved config
plus :data:`CODE_VERSION`, never DictConfigs or objects whose hash changes
between processes. ``n_jobs`` is never part of a key: results do not depend
on it.
"""

from __future__ import annotations

import hashlib
import inspect
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

from joblib import Memory

import kinematics
import pipeline

__version__ = "0.1.0"


#: pipeline modules whose code the cached stages execute (with all of kinematics)
STAGE_MODULES = ("sample", "evaluate", "optimise", "objective", "ga", "de")


def _source_digest() -> str:
    """Hash of the code the stages run: all of ``kinematics`` and :data:`STAGE_MODULES`.

    Any change there invalidates the cache; changes to orchestration, I/O,
    plots or the reproduction document do not.
    """
    digest = hashlib.sha256()
    files = sorted(Path(kinematics.__file__).parent.glob("*.py"))
    files += [Path(pipeline.__file__).parent / f"{name}.py" for name in STAGE_MODULES]
    for path in files:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


#: package version + hash of the sources; part of every stage's cache key
CODE_VERSION = f"{__version__}+{_source_digest()}"


@lru_cache(maxsize=8)
def memory(cache_dir: str) -> Memory:
    """The ``joblib.Memory`` of ``cache_dir`` (built on first use, then reused)."""
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    return Memory(location=cache_dir, verbose=0)


def cached(func: Callable, cache_dir: str, ignore: tuple[str, ...] = ("n_jobs", "designs", "table")
           ) -> Callable:
    """``func`` memoised on disk in ``cache_dir``; arguments named in ``ignore`` are not keyed.

    Ignored by default: ``n_jobs`` (results do not depend on it) and the
    tables that a stage receives from an upstream stage (``designs``,
    ``table``), which are functions of arguments that are keyed.
    """
    params = inspect.signature(func).parameters
    return memory(str(cache_dir)).cache(func, ignore=[name for name in ignore if name in params])
