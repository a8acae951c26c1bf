"""One lazily built ``joblib.Memory`` per cache directory and code version (the benchopt pattern).

Stages are plain functions of typed config sections; :func:`cached` wraps
one with the Memory of ``<cache_dir>/<CODE_VERSION>``. The code version
(package version + a hash of every source file of ``kinematics`` and
``pipeline`` except the document writers) is part of the location, not of the stages' signatures, so
editing any source starts a fresh cache and the stages never see it.
``n_jobs`` is never part of a key: results do not depend on it. Tests check
hits with joblib's own ``check_call_in_cache``. Every cached output carries a
checksum verified when it is read (:class:`CheckedStage`).
"""

from __future__ import annotations

import hashlib
import inspect
import logging
import os
import re
import shutil
from collections.abc import Callable
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import joblib
from joblib import Memory

import kinematics
import pipeline

try:
    __version__ = version("pm-design")
except PackageNotFoundError:  # a source tree that was not installed
    __version__ = "0+unknown"

log = logging.getLogger(__name__)


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
        data = [
            p
            for pattern in DATA_FILES
            if pattern.startswith(f"{root.name}/")
            for p in root.glob(pattern.split("/", 1)[1])
        ]
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
    stale = (
        [
            d
            for d in sorted(root.iterdir())
            if d.is_dir() and not d.is_symlink() and d.name != CODE_VERSION and _VERSION_DIR.match(d.name)
        ]
        if root.is_dir()
        else []
    )
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


class CheckedStage:
    """A stage memoised by ``joblib.Memory`` whose cached outputs carry a checksum verified on read.

    Why: joblib serves whatever pickle sits in an entry; one overwritten by
    another valid pickle (a copy between machines, a bad restore, a hand
    edit) would land in a ``complete`` run. Each output's hash
    (``joblib.hash`` of the value) is recorded beside the cache under
    ``checksums/<stage>/<hash of the call's arguments>``; a hit whose value
    does not match (or has no record) is recomputed, with one warning line.
    """

    def __init__(self, func: Callable, cache_dir: str | Path) -> None:
        params = inspect.signature(func).parameters
        self.ignored = [n for n in ("n_jobs",) if n in params]
        self.memorized = memory(str(cache_dir)).cache(func, ignore=self.ignored)
        self.name = func.__name__
        self.records = Path(cache_dir) / CODE_VERSION / "checksums" / f"{func.__module__}.{func.__qualname__}"

    def check_call_in_cache(self, *args: object, **kwargs: object) -> bool:
        """True if joblib holds an entry for these arguments (verified only when read)."""
        return self.memorized.check_call_in_cache(*args, **kwargs)

    def __call__(self, *args: object, **kwargs: object) -> object:
        hit = self.memorized.check_call_in_cache(*args, **kwargs)
        value = self.memorized(*args, **kwargs)
        digest = hash_value(value)
        record = self.records / f"{self._call_key(args, kwargs)}.sha"
        if hit:
            recorded = _read_record(record)
            if recorded == digest:
                return value
            log.warning(
                "%s: cached output failed its checksum (%s); recomputed",
                self.name,
                "no record" if recorded is None else f"recorded {recorded[:12]}, found {digest[:12]}",
            )
            value, _ = self.memorized.call(*args, **kwargs)
            digest = hash_value(value)
        _write_record(record, digest)
        return value

    def _call_key(self, args: tuple, kwargs: dict) -> str:
        bound = inspect.signature(self.memorized.func).bind(*args, **kwargs)
        bound.apply_defaults()
        return hash_value({k: v for k, v in bound.arguments.items() if k not in self.ignored})


def hash_value(value: object) -> str:
    """Content hash of a stage's output or arguments (``joblib.hash``: arrays by their bytes)."""
    return joblib.hash(value, hash_name="sha1")


def _read_record(path: Path) -> str | None:
    try:
        return path.read_text().strip() or None
    except OSError:
        return None


def _write_record(path: Path, digest: str) -> None:
    """Record an output's checksum (atomically); a failure only costs a recomputation later."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(digest)
        os.replace(tmp, path)
    except OSError as exc:
        log.warning("checksum of %s not recorded: %s", path.parent.name, exc.strerror or exc)


def cached(func: Callable, cache_dir: str | Path) -> CheckedStage:
    """``func`` memoised on disk in ``cache_dir`` (checksummed); an ``n_jobs`` argument is not keyed."""
    return CheckedStage(func, cache_dir)
