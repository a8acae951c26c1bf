"""Hydra's and OmegaConf's errors about an override, as the project's one line naming the field.

Hydra's own text for a key the config does not have (``Could not override
'optimizer.population'. To append to your config use +optimizer.population=4``)
and for a value of the wrong type (``Error merging override sample.n=nan: Value
'nan' of type 'float' could not be converted to Integer``) name no allowed
values and give advice that fails. :func:`explain` replaces them with what the
selected section allows: the mechanism's fixed parameters, the chosen
optimiser's keys (and which optimisers have the key), a field's range.
"""

from __future__ import annotations

import dataclasses
import re
import typing
from collections.abc import Callable, Sequence

from omegaconf import DictConfig

from pipeline.config.mechanism import DesignSpace
from pipeline.config.schema import Config, MechanismConfig
from pipeline.config.suggest import did_you_mean, key_suggestion
from pipeline.errors import ConfigError

_UNKNOWN_KEY = (re.compile(r"Could not override '([^']+)'"), re.compile(r"Key '([^']+)' is not in struct"))
#: a value of the wrong type: a scalar's (``Value '...' could not be converted``) or a scalar given for a
#: list (``Invalid value assigned: str is not a ListConfig``)
_BAD_VALUE = re.compile(r"Error merging override ([^=\s]+)=(.*?): (?:Value '|Invalid value assigned)", re.DOTALL)


def explain(exc: BaseException, overrides: Sequence[str], compose: Callable[[list[str]], DictConfig]) -> str | None:
    """The one-line message for ``exc`` raised while composing ``overrides`` (None: not an override's fault).

    ``compose`` builds the config of a list of overrides; it is used to learn
    which mechanism and optimiser the other overrides select.
    """
    text = f"{exc}: {exc.__cause__}" if exc.__cause__ is not None else str(exc)
    bad = _BAD_VALUE.search(text)
    if bad:
        return value_message(bad.group(1).lstrip("+~"), bad.group(2))
    for pattern in _UNKNOWN_KEY:
        found = pattern.search(text)
        if found:
            return unknown_key_message(_full_key(found.group(1), overrides), overrides, compose)
    return None


def _full_key(dotted: str, overrides: Sequence[str]) -> str:
    keys = [o.split("=", 1)[0].lstrip("+~") for o in overrides]
    return next((k for k in keys if k.endswith(dotted)), dotted)


def _selected(overrides: Sequence[str], key: str, compose: Callable[[list[str]], DictConfig]) -> tuple[str, str]:
    """(mechanism name, optimiser name) the overrides other than ``key``'s select."""
    others = [o for o in overrides if o.split("=", 1)[0].lstrip("+~") != key]
    try:
        cfg = compose(others)
        return str(cfg.mechanism.name), str(cfg.optimizer.name)
    except Exception:  # noqa: BLE001 - another override is wrong too: fall back to what was typed
        given = dict(o.split("=", 1) for o in overrides if "=" in o)
        return given.get("mechanism", "h4"), given.get("optimizer", "cmaes")


def unknown_key_message(key: str, overrides: Sequence[str], compose: Callable[[list[str]], DictConfig]) -> str:
    """``key`` is not in the selected config: what is allowed there, and a did-you-mean."""
    from kinematics import resolve_mechanism
    from pipeline.optimizers import OPTIMIZERS

    parent, _, leaf = key.rpartition(".")
    mechanism, optimizer = _selected(overrides, key, compose)
    if parent == "mechanism.fixed":
        try:
            declared = [p.name for p in resolve_mechanism(mechanism).fixed_parameters]
        except Exception:  # noqa: BLE001 - an unknown mechanism is reported by its own check
            declared = []
        hint = did_you_mean(leaf, declared).replace("mean ", "mean mechanism.fixed.")
        return (
            f"{key} is not a parameter of {mechanism}; allowed keys: "
            f"{', '.join(f'mechanism.fixed.{p}' for p in declared) or 'none'}{hint}"
        )
    if parent == "optimizer" and optimizer in OPTIMIZERS:
        own = [f.name for f in dataclasses.fields(OPTIMIZERS[optimizer].Config)]
        owners = [n for n, o in OPTIMIZERS.items() if leaf in {f.name for f in dataclasses.fields(o.Config)}]
        where = f" (a key of {', '.join(owners)}: optimizer={owners[0]} selects it)" if owners else ""
        hint = did_you_mean(leaf, own).replace("mean ", "mean optimizer.")
        return f"{key} is not a key of {optimizer}{where}; allowed keys of {optimizer}: {', '.join(own)}{hint}"
    allowed = _section_fields(parent)
    listed = f"; allowed keys{' of ' + parent if parent else ''}: {', '.join(allowed)}" if allowed else ""
    return f"{key} is an unknown key{listed}{key_suggestion(key)}"


def _section_type(dotted_parent: str) -> type | None:
    schema: type = Config
    for part in [p for p in dotted_parent.split(".") if p]:
        if not dataclasses.is_dataclass(schema):
            return None
        hints = typing.get_type_hints(schema)
        if part not in hints:
            return None
        schema = hints[part]
    return schema if dataclasses.is_dataclass(schema) else None


def _section_fields(dotted_parent: str) -> list[str]:
    schema = _section_type(dotted_parent)
    return [f.name for f in dataclasses.fields(schema)] if schema is not None else []


def value_message(key: str, value: str) -> str:
    """``key=value`` has the wrong type: the field's own range check, else its type in words."""
    from pipeline.optimizers import OPTIMIZERS

    parent, _, leaf = key.rpartition(".")
    section = _section_type(parent)
    if parent == "optimizer":  # the field of whichever optimiser has it
        section = next((o.Config for o in OPTIMIZERS.values() if leaf in _field_types(o.Config)), None)
    types = _field_types(section) if section is not None else {}
    if leaf in types:
        # the section's own check of a value no range admits gives the range, in the section's words
        try:
            _probe(section, leaf)
        except ConfigError as exc:
            message = str(exc)
            if " is invalid: allowed " in message:
                return f"{key}={value} is invalid: allowed {message.split(' is invalid: allowed ', 1)[1]}"
        return f"{key}={value} is invalid: allowed {_type_words(types[leaf])}"
    return f"{key}={value} is invalid: the value has the wrong type"


def _field_types(schema: type) -> dict[str, object]:
    return typing.get_type_hints(schema) if dataclasses.is_dataclass(schema) else {}


def _probe(section: type, leaf: str) -> None:
    """Build ``section`` with NaN in ``leaf`` (no range admits NaN; a list field: a list of NaN),
    defaults elsewhere. The mechanism's section is built with a built-in mechanism's name, its one
    required field (the ranges of its own fields are the same for every mechanism); a bound of the
    design box is checked there too."""
    from kinematics import MECHANISMS

    nan = float("nan")
    value: object = [nan, nan] if _is_list(_field_types(section).get(leaf)) else nan
    first = next(iter(MECHANISMS))
    if section is DesignSpace and leaf in ("lower", "upper"):
        n = len(MECHANISMS[first].design_variables)
        section, leaf, value = MechanismConfig, "design", DesignSpace(**{leaf: [nan] * n})
    required = {"name": first} if section is MechanismConfig and leaf != "name" else {}
    try:
        section(**required, **{leaf: value})
    except ConfigError:
        raise
    except Exception:  # noqa: BLE001 - a section that cannot be built alone (required fields): no range known
        return


def _is_list(hint: object) -> bool:
    return "list" in str(hint).lower()


def _type_words(hint: object) -> str:
    text = str(hint)
    if _is_list(hint):
        return "a list of numbers" if "float" in text or "int" in text else "a list"
    if hint is bool or "bool" in text:
        return "true or false"
    if hint is int or "int" in text:
        return "an integer"
    if hint is float or "float" in text:
        return "a number"
    return f"a value of type {getattr(hint, '__name__', text)}"
