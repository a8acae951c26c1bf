"""Kinematic models of parallel manipulators (seeds 000, 001, 003, 004).

Public API
----------
``MECHANISMS``
    mapping from registry name (``"h4"``, ``"tricept"``, ``"rpr3"``, ``"rpr2"``,
    ``"delta"``, plus any installed plug-in) to the mechanism class. The
    built-ins are every :class:`~kinematics.base.Mechanism` subclass in this
    package's modules, so adding a mechanism is one new module (its Hydra
    option is generated from the class). External mechanisms declared as
    entry points in the group ``pm_design.mechanisms`` follow, loaded at the
    first use of the mapping (see :mod:`kinematics.plugins`); a broken one or
    one taking a built-in's name raises :class:`~kinematics.plugins.PluginError`
    with one line naming the entry point.
``get_mechanism(name, **params)``
    builds one mechanism from its geometric parameters; an omitted fixed
    parameter takes its documented default (``Mechanism.default_fixed``).
``resolve_mechanism(name_or_path)``
    the class of a registry name or of a ``"package.module:Class"`` path.
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator, Mapping

from kinematics import plugins
from kinematics.base import Mechanism
from kinematics.registry import discover


class MechanismRegistry(Mapping[str, type[Mechanism]]):
    """Built-in mechanisms, then the entry-point ones, by registry name.

    Why lazy: an external mechanism's module imports :mod:`kinematics.base`,
    so loading the entry points while this package is being imported would
    import that module half-way (e.g. when a worker process unpickles one of
    its designs before anything else). They are loaded at the first lookup.
    """

    def __init__(self, builtins: dict[str, type[Mechanism]]) -> None:
        self._builtins = builtins
        self._all: dict[str, type[Mechanism]] | None = None

    def _merged(self) -> dict[str, type[Mechanism]]:
        if self._all is None:
            self._all = {**self._builtins, **plugins.entry_point_mechanisms(self._builtins)}
        return self._all

    @property
    def builtins(self) -> dict[str, type[Mechanism]]:
        """The mechanisms of this package alone (no entry point loaded)."""
        return dict(self._builtins)

    def __getitem__(self, name: str) -> type[Mechanism]:
        return self._merged()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._merged())

    def __len__(self) -> int:
        return len(self._merged())

    def __repr__(self) -> str:
        return f"MechanismRegistry({', '.join(self)})"


MECHANISMS = MechanismRegistry(discover(__name__, __path__, Mechanism))


def get_mechanism(name: str, **params: object) -> Mechanism:
    """Build the mechanism registered as ``name`` from keyword geometric parameters.

    A fixed parameter left out takes its documented default (the class's
    ``default_fixed``, e.g. the Gough-Stewart's ``r_base=400``), as
    :meth:`~kinematics.base.Mechanism.from_design` does.

    Raises
    ------
    ValueError
        If ``name`` is unknown (the message lists the known names) or a
        parameter is out of range.
    """
    try:
        cls = MECHANISMS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown mechanism {name!r}; allowed: {', '.join(MECHANISMS)}") from None
    # only the defaults the constructor takes: a plug-in's from_design may map a fixed parameter
    # to other constructor arguments (its constructor would refuse the name)
    accepted = inspect.signature(cls).parameters
    any_keyword = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in accepted.values())
    defaults = {k: v for k, v in cls.with_default_fixed(params).items() if k in params or any_keyword or k in accepted}
    try:
        return cls(**defaults)
    except TypeError as exc:  # wrong keyword: name the accepted ones
        raise ValueError(f"{cls.__name__}: {exc}") from None


def resolve_mechanism(name_or_path: str) -> type[Mechanism]:
    """The mechanism class of a registry name (``"h4"``) or a ``"package.module:Class"`` path.

    The pipeline's ``mechanism.name`` accepts both; a path needs no entry
    point (the class's module must be importable).

    Raises
    ------
    kinematics.plugins.PluginError
        A ``ValueError`` with one line: unknown name (the message lists the
        known ones), unknown module, missing class, not a concrete Mechanism
        subclass, or a path whose class takes a registered mechanism's name.
    """
    return plugins.resolve_mechanism(name_or_path, MECHANISMS)


__all__ = ["MECHANISMS", "Mechanism", "MechanismRegistry", "get_mechanism", "resolve_mechanism"]
