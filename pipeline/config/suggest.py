"""Did-you-mean suggestions for unknown config keys and names.

Used by :mod:`pipeline.config.validate` (unknown keys) and by the command
line (Hydra's "could not override" and "could not find" errors).
"""

from __future__ import annotations

import dataclasses
import difflib
import os

from pipeline.config.schema import Config


def did_you_mean(word: str, options) -> str:
    """``"; did you mean X?"`` for the closest of ``options`` (empty if none is close)."""
    options = [str(o) for o in options]
    match = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    if not match:  # a dropped or added separator ("wd" for "w_d") is a near miss, too
        plain = {o.replace("_", "").lower(): o for o in options}
        key = word.replace("_", "").lower()
        match = [plain[key]] if key in plain else []
    if not match:  # the same stem under another name ("population" for cmaes's "popsize")
        shared = {o: len(os.path.commonprefix([o.lower(), word.lower()])) for o in options}
        best = max(shared.values(), default=0)
        match = [o for o, n in shared.items() if n == best and n >= 3][:1]
    match = [m for m in match if m != word]  # the word itself is never the advice
    return f"; did you mean {match[0]}?" if match else ""


def section_keys(dotted_parent: str) -> list[str]:
    """Keys allowed under ``dotted_parent`` ("" = top level) by the typed schema; every
    optimiser's fields under ``optimizer``."""
    from pipeline.optimizers import OPTIMIZERS

    if dotted_parent == "optimizer":
        return sorted({f.name for o in OPTIMIZERS.values() for f in dataclasses.fields(o.Config)})
    schema = Config
    for part in [p for p in dotted_parent.split(".") if p]:
        fields = {f.name: f for f in dataclasses.fields(schema)}
        hints = {f.name: f.type for f in dataclasses.fields(schema)}
        if part not in fields:
            return []
        import typing

        resolved = typing.get_type_hints(schema).get(part, hints[part])
        if not dataclasses.is_dataclass(resolved):
            return []
        schema = resolved
    return [f.name for f in dataclasses.fields(schema)]


def key_suggestion(dotted_key: str) -> str:
    """Did-you-mean text for an unknown dotted key such as ``objective.wd`` (empty if none)."""
    parent, _, leaf = dotted_key.lstrip("+~").rpartition(".")
    suggestion = did_you_mean(leaf, section_keys(parent))
    return suggestion.replace("did you mean ", f"did you mean {parent}." if parent else "did you mean ")
