"""Kinematic models of parallel manipulators (seeds 000, 001, 003, 004).

Public API
----------
``MECHANISMS``
    dict from registry name (``"h4"``, ``"tricept"``, ``"rpr3"``, ``"rpr2"``) to
    the mechanism class. It is filled by discovering every
    :class:`~kinematics.base.Mechanism` subclass in this package's modules, so
    adding a mechanism is one new module (its Hydra option is generated from the class).
``get_mechanism(name, **params)``
    builds one mechanism from its geometric parameters.
"""

from __future__ import annotations

from kinematics.base import Mechanism
from kinematics.registry import discover


MECHANISMS: dict[str, type[Mechanism]] = discover(__name__, __path__, Mechanism)


def get_mechanism(name: str, **params: object) -> Mechanism:
    """Build the mechanism registered as ``name`` from keyword geometric parameters.

    Raises
    ------
    ValueError
        If ``name`` is unknown (the message lists the known names) or a
        parameter is out of range.
    """
    try:
        cls = MECHANISMS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown mechanism {name!r}; allowed: {', '.join(MECHANISMS)}"
        ) from None
    try:
        return cls(**params)
    except TypeError as exc:  # wrong keyword: name the accepted ones
        raise ValueError(f"{cls.__name__}: {exc}") from None


__all__ = ["MECHANISMS", "Mechanism", "get_mechanism"]
