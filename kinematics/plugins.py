"""Mechanisms from outside this package: Python entry points and ``"module:Class"`` paths.

A user's own package adds a mechanism without touching this repository by
declaring an entry point in the group :data:`ENTRY_POINT_GROUP`
(``pm_design.mechanisms``) whose name is the mechanism's registry name and
whose value is its class::

    [project.entry-points."pm_design.mechanisms"]
    five_bar = "pm_five_bar.mechanism:FiveBar"

:func:`entry_point_mechanisms` loads them (``kinematics.MECHANISMS`` merges
them after the built-ins), and :func:`resolve_mechanism` also accepts an
explicit ``"package.module:Class"`` path. A package may also ship Hydra
config groups (e.g. ``experiment/<name>.yaml``) by declaring a second entry
point in :data:`CONFIG_ENTRY_POINT_GROUP` (``pm_design.configs``) whose value
is the importable package holding them; :func:`config_search_paths` lists
them as Hydra ``pkg://`` search paths.

Every failure is a :class:`PluginError` (a ``ValueError``) with a one-line
message naming the entry point or the path: a broken plugin is never skipped
silently, and it never shadows a built-in mechanism.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
from collections.abc import Iterable, Mapping

from kinematics.base import Mechanism

#: entry-point group of external mechanism classes (name = registry name, value = ``module:Class``)
ENTRY_POINT_GROUP = "pm_design.mechanisms"
#: entry-point group of packages holding Hydra config groups (value = an importable package)
CONFIG_ENTRY_POINT_GROUP = "pm_design.configs"


class PluginError(ValueError):
    """An external mechanism or its config that cannot be used; the message is one line."""


def one_line(exc: BaseException) -> str:
    """``Type: message`` of an exception on one line (third-party messages may span several)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _describe(ep: importlib.metadata.EntryPoint) -> str:
    """``'name = value' (group G, distribution D V)``: enough to find the entry point's source."""
    dist = getattr(ep, "dist", None)
    origin = f", distribution {dist.metadata['Name']} {dist.version}" if dist is not None else ""
    return f"entry point '{ep.name} = {ep.value}' (group {ep.group}{origin})"


def check_mechanism_class(obj: object, where: str) -> type[Mechanism]:
    """Return ``obj`` if it is a concrete :class:`Mechanism` subclass with a string ``name``.

    Parameters
    ----------
    obj : object
        What an entry point or a ``module:Class`` path resolved to.
    where : str
        How the object was named, for the error message.

    Raises
    ------
    PluginError
        One line naming ``where`` and what is wrong.
    """
    if not (inspect.isclass(obj) and issubclass(obj, Mechanism)):
        raise PluginError(f"{where}: {obj!r} is not a subclass of kinematics.base.Mechanism")
    if inspect.isabstract(obj):
        missing = ", ".join(sorted(obj.__abstractmethods__))
        raise PluginError(f"{where}: {obj.__qualname__} is abstract (does not implement {missing})")
    name = getattr(obj, "name", None)
    if not (isinstance(name, str) and name.isidentifier()):
        raise PluginError(
            f"{where}: {obj.__qualname__}.name must be a Python identifier string "
            f"(the registry and Hydra option name); got {name!r}"
        )
    return obj


def entry_point_mechanisms(
    builtins: Mapping[str, type[Mechanism]],
    entry_points: Iterable[importlib.metadata.EntryPoint] | None = None,
) -> dict[str, type[Mechanism]]:
    """Load the external mechanisms declared in the entry-point group :data:`ENTRY_POINT_GROUP`.

    Parameters
    ----------
    builtins : mapping
        The built-in registry (name -> class); an entry point may not reuse one of its names.
    entry_points : iterable of EntryPoint, optional
        The entry points to load; default: every installed distribution's, in
        the group :data:`ENTRY_POINT_GROUP`.

    Returns
    -------
    dict
        Registry name -> class, sorted by name.

    Raises
    ------
    PluginError
        One line naming the first entry point that cannot be loaded (import
        error, missing attribute, not a concrete Mechanism subclass), whose
        name differs from its class's ``name``, or whose name is a built-in's
        or another entry point's.
    """
    if entry_points is None:
        entry_points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    found: dict[str, type[Mechanism]] = {}
    origin: dict[str, str] = {}
    for ep in sorted(entry_points, key=lambda e: (e.name, e.value)):
        where = _describe(ep)
        if ep.name in builtins:
            builtin = builtins[ep.name]
            raise PluginError(
                f"{where}: name '{ep.name}' is the built-in mechanism "
                f"{builtin.__module__}:{builtin.__qualname__}; rename the entry point "
                f"and its class's name"
            )
        if ep.name in found:
            raise PluginError(f"{where}: name '{ep.name}' is also declared by {origin[ep.name]}")
        try:
            obj = ep.load()
        except Exception as exc:  # any error of third-party code at import becomes one line naming it
            raise PluginError(f"{where}: cannot load: {one_line(exc)}") from None
        cls = check_mechanism_class(obj, where)
        if cls.name != ep.name:
            raise PluginError(f"{where}: the entry point's name must equal {cls.__qualname__}.name ({cls.name!r})")
        found[ep.name] = cls
        origin[ep.name] = where
    return dict(sorted(found.items()))


def load_class(path: str) -> type[Mechanism]:
    """The Mechanism subclass named by ``"package.module:Class"`` (``Class`` may be dotted).

    Raises
    ------
    PluginError
        One line: malformed path, unknown module (or an error importing it),
        missing class, or not a concrete Mechanism subclass.
    """
    module_name, sep, attr = str(path).partition(":")
    if not (
        sep
        and module_name
        and attr
        and all(p.isidentifier() for p in module_name.split("."))
        and all(p.isidentifier() for p in attr.split("."))
    ):
        raise PluginError(f"mechanism path {path!r}: expected 'package.module:Class'")
    try:
        obj = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module_name + ".").startswith(exc.name + "."):
            raise PluginError(
                f"mechanism path {path!r}: no module named {exc.name!r} (is its package installed in this environment?)"
            ) from None
        raise PluginError(f"mechanism path {path!r}: cannot import {module_name!r}: {one_line(exc)}") from None
    except Exception as exc:  # third-party import-time errors become one line naming the path
        raise PluginError(f"mechanism path {path!r}: cannot import {module_name!r}: {one_line(exc)}") from None
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise PluginError(f"mechanism path {path!r}: module {module_name!r} has no attribute {attr!r}")
        obj = getattr(obj, part)
    return check_mechanism_class(obj, f"mechanism path {path!r}")


def resolve_mechanism(name_or_path: str, registry: Mapping[str, type[Mechanism]]) -> type[Mechanism]:
    """The mechanism class of a registry name (``"h4"``) or of a ``"module:Class"`` path.

    A path's class must not take the name of a different registered class
    (its rows in a dataset would be mistaken for the other mechanism's).

    Raises
    ------
    PluginError
        One line: unknown name (listing the known ones), or any error of
        :func:`load_class`, or a name clash.
    """
    if not isinstance(name_or_path, str):
        raise PluginError(f"mechanism must be a registry name or 'module:Class'; got {name_or_path!r}")
    if ":" not in name_or_path:
        try:
            return registry[name_or_path]
        except KeyError:
            raise PluginError(
                f"unknown mechanism {name_or_path!r}; allowed: {', '.join(registry)} or 'package.module:Class'"
            ) from None
    cls = load_class(name_or_path)
    registered = registry.get(cls.name)
    if registered is not None and registered is not cls:
        raise PluginError(
            f"mechanism path {name_or_path!r}: its name {cls.name!r} is taken by "
            f"{registered.__module__}:{registered.__qualname__}"
        )
    return cls


def config_search_paths(entry_points: Iterable[importlib.metadata.EntryPoint] | None = None) -> list[str]:
    """Hydra search paths (``pkg://package``) of the config packages external mechanisms ship.

    Each entry point of the group :data:`CONFIG_ENTRY_POINT_GROUP` names an
    importable package whose folders are Hydra config groups, e.g.
    ``pm_five_bar.conf`` holding ``experiment/five_bar_mixed.yaml``; with its
    search path appended, ``+experiment=five_bar_mixed`` composes.

    Raises
    ------
    PluginError
        One line naming an entry point whose value is not an importable package.
    """
    if entry_points is None:
        entry_points = importlib.metadata.entry_points(group=CONFIG_ENTRY_POINT_GROUP)
    paths = []
    for ep in sorted(entry_points, key=lambda e: (e.name, e.value)):
        where = _describe(ep)
        if ep.attr or not all(p.isidentifier() for p in ep.value.split(".")):
            raise PluginError(f"{where}: the value must be a package name such as 'my_package.conf'")
        try:
            spec = importlib.util.find_spec(ep.value)
        except (ImportError, ValueError) as exc:
            raise PluginError(f"{where}: cannot find package {ep.value!r}: {one_line(exc)}") from None
        if spec is None or spec.submodule_search_locations is None:
            raise PluginError(
                f"{where}: {ep.value!r} is not an importable package "
                f"(a folder with an __init__.py, shipped with the distribution)"
            )
        paths.append(f"pkg://{ep.value}")
    return paths


__all__ = [
    "CONFIG_ENTRY_POINT_GROUP",
    "ENTRY_POINT_GROUP",
    "PluginError",
    "check_mechanism_class",
    "config_search_paths",
    "entry_point_mechanisms",
    "load_class",
    "one_line",
    "resolve_mechanism",
]
