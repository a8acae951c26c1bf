"""One-line errors: :class:`ConfigError` for bad input, :class:`RunError` for a run that cannot go on.

Every message names the field (or path) and what is allowed, on one line;
the entry point prints it as ``error: <message>`` and exits 2 (bad input)
or 1 (a run that failed at run time).
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path


class ConfigError(ValueError):
    """A configuration value out of range, an unknown name or key, an unusable path."""


class RunError(RuntimeError):
    """A run that failed at run time (disk full, a worker lost, ...), with a one-line reason."""


def check(field: str, value: object, ok: bool, allowed: str) -> None:
    """Raise :class:`ConfigError` ``"<field>=<value> is invalid: allowed <allowed>"`` unless ``ok``."""
    if not ok:
        raise ConfigError(f"{field}={value!r} is invalid: allowed {allowed}")


def finite(value: object) -> bool:
    """True for a finite real number (bools are not numbers here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_writable(field_name: str, path: str | os.PathLike) -> Path:
    """``path`` is (or can be created as) a writable directory.

    Nothing is left behind: the nearest existing directory is probed with an
    anonymous temporary file (a permission check alone is not enough: root
    passes it on read-only or pseudo file systems).
    """
    if not str(path).strip():
        # Path("") is the working folder, but a path built on it ("${paths.output_dir}/cache")
        # is the file system's root
        raise ConfigError(f"{field_name}={str(path)!r} is invalid: it is empty; allowed: a writable directory")
    p = Path(path).expanduser()
    probe = p
    while not probe.exists() and not probe.is_symlink():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise ConfigError(
            f"{field_name}={str(path)!r} is invalid: {probe} is not a directory; allowed: a writable directory"
        )
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise ConfigError(
            f"{field_name}={str(path)!r} is invalid: no file can be created in {probe} "
            f"({exc.strerror or exc}); allowed: a writable directory"
        ) from None
    return p


class Terminated(KeyboardInterrupt):
    """SIGTERM (``timeout``, SLURM, ``kill``): handled like Ctrl-C, reported with exit status 143."""


def interrupt_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt behind ``exc``, if any: a Ctrl-C or SIGTERM that reached compiled code
    (numba) comes back as ``SystemError ... returned a result with an exception set`` whose
    cause or context is the interrupt."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def describe_fault(exc: BaseException, where: str | os.PathLike | None = None) -> str:
    """A run-time fault as one line naming its cause and file: ``OSError``\\ s name the file (or
    ``where`` when the library raising it did not say)."""
    if isinstance(exc, RunError):
        return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if isinstance(exc, OSError):
        cause = exc.strerror or (str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
        target = exc.filename or where
        return f"{cause}: {target}" if target else cause
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
