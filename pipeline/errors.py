"""One-line errors: :class:`ConfigError` for bad input, :class:`RunError` for a run that cannot go on.

Every message names the field (or path) and what is allowed, on one line;
the entry point prints it as ``error: <message>`` and exits 2 (bad input)
or 1 (a run that failed at run time).
"""

from __future__ import annotations

import math


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
