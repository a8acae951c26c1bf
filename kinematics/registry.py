"""Plug-in discovery shared by the registries (mechanisms here, optimisers in ``pipeline``)."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable


def discover(package_name: str, package_path: Iterable[str], base: type) -> dict[str, type]:
    """Import every public module of a package; return its ``base`` subclasses by ``name``, sorted.

    A subclass is registered when it sets a string class attribute ``name``;
    abstract intermediates without one are skipped.
    """
    for info in pkgutil.iter_modules(package_path):
        if not info.name.startswith("_"):
            importlib.import_module(f"{package_name}.{info.name}")
    found: dict[str, type] = {}
    stack = list(base.__subclasses__())
    while stack:
        cls = stack.pop()
        stack.extend(cls.__subclasses__())
        if isinstance(getattr(cls, "name", None), str):
            found[cls.name] = cls
    return dict(sorted(found.items()))
