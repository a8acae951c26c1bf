"""``pm-design evaluate``: V, GDI, SURI and η of one given design (:func:`evaluate_command`)."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from omegaconf.errors import OmegaConfBaseException

from pipeline.cli.commands import check_output_file, one_line, suggestion
from pipeline.config import CONFIG_DIR, Config, validate
from pipeline.config.mechanism import working_folder_hint
from pipeline.config.suggest import did_you_mean
from pipeline.errors import ConfigError, RunError


def _compose_evaluate(overrides: list[str]):
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
        return compose(config_name="config", overrides=list(overrides))


def _number(name: str, text: str, lo: float, hi: float, unit: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ConfigError(
            f"{name}={text!r} is invalid: allowed a number in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}"
        ) from None


def evaluate_overrides(assignments: list[str]) -> tuple[type, list[float], list[str]]:
    """(mechanism class, design vector, config overrides) of ``pm-design evaluate``'s arguments.

    Raises
    ------
    ConfigError
        One line: a bare word, an unknown mechanism, a key that is neither a design variable nor
        a config key (with a did-you-mean among the design variables), a missing variable, a
        value that is not a number.
    """
    from kinematics import MECHANISMS, resolve_mechanism
    from kinematics.plugins import PluginError

    bad = [a for a in assignments if "=" not in a]
    if bad:
        raise ConfigError(f"{bad[0]} is invalid: allowed key=value")
    given = dict(a.split("=", 1) for a in assignments)
    name = given.pop("mechanism", "h4")
    if name == "path":
        if "mechanism.name" not in given:
            raise ConfigError("mechanism=path needs mechanism.name=package.module:Class (the class to evaluate)")
        try:
            cls = resolve_mechanism(given["mechanism.name"])
        except PluginError as exc:
            path = given["mechanism.name"]
            raise ConfigError(f"mechanism.name={path!r} is invalid: {exc}{working_folder_hint(path)}") from None
    elif name in MECHANISMS:
        cls = MECHANISMS[name]
    else:
        raise ConfigError(
            f"mechanism={name} is invalid: allowed {', '.join(MECHANISMS)}, or path with "
            f"mechanism.name=package.module:Class{did_you_mean(name, MECHANISMS)}"
        )
    variables = {v.name: v for v in cls.design_variables}
    plain_keys = {f.name for f in dataclasses.fields(Config)} | {p.name for p in CONFIG_DIR.iterdir() if p.is_dir()}
    for key in given:
        bare = key.lstrip("+~")
        if "." not in bare and bare not in variables and bare != "design" and bare not in plain_keys:
            raise ConfigError(
                f"{bare} is not a design variable of {cls.name}: allowed "
                f"{' '.join(f'{v}=...' for v in variables)} or design=[...], and config keys such as "
                f"objective.w_d=...{did_you_mean(bare, variables)}"
            )
    if "design" in given:
        text = given.pop("design")
        numbers = [v.strip() for v in text.strip("[]() ").split(",") if v.strip()]
        allowed = ", ".join(variables)
        try:
            design = [float(v) for v in numbers]
        except ValueError:
            raise ConfigError(f"design={text} is invalid: allowed {len(variables)} numbers ({allowed})") from None
    else:
        missing = [v for v in variables if v not in given]
        if missing:
            raise ConfigError(
                f"{missing[0]} is missing: allowed {' '.join(f'{v}=...' for v in variables)} "
                f"or design=[...] ({cls.name}'s design variables)"
            )
        design = [_number(v, given.pop(v), d.lower, d.upper, d.unit) for v, d in variables.items()]
    overrides = [
        f"mechanism={name}",
        *(f"{k}={v}" for k, v in given.items()),
        "hydra.run.dir=.",
        "experiment_name=evaluate",
    ]
    return cls, design, overrides


def evaluate_command(argv: list[str]) -> int:
    """``pm-design evaluate mechanism=NAME VAR=VALUE ... [design=[...]] [key=value ...] [--parquet FILE]``.

    Design variables by name (``a=250``) or all at once (``design=[250,400,100]``),
    in the mechanism's design units; every other ``key=value`` is a config override
    (``mechanism.fixed.stroke=120``, ``evaluate.resolution=24``, ``evaluate.method=midpoint``,
    ``objective.w_d=0.3``);
    a class of one's own with ``mechanism=path mechanism.name=package.module:Class``.
    Prints one table; ``--parquet FILE`` also writes it with units (its folder is checked
    before the evaluation). Exit 2 on bad input, 1 if the file cannot be written after all.
    """
    import argparse

    from hydra.errors import HydraException

    from pipeline.cli.explain import explain
    from pipeline.stages.design import evaluate_design
    from pipeline.store.parquet import column_unit, write_parquet

    parser = argparse.ArgumentParser(prog="pm-design evaluate", description=evaluate_command.__doc__.split("\n")[0])
    parser.add_argument("assignments", nargs="*", help="mechanism=NAME, design variables VAR=VALUE, overrides")
    parser.add_argument("--parquet", type=Path, default=None, help="also write the row to this Parquet file")
    args = parser.parse_args(argv)
    overrides: list[str] = []
    try:
        if args.parquet is not None:
            check_output_file("--parquet", args.parquet)
        cls, design, overrides = evaluate_overrides(list(args.assignments))
        try:
            cfg = _compose_evaluate(overrides)
        except (HydraException, OmegaConfBaseException) as exc:
            message = explain(exc, overrides, _compose_evaluate)
            if message is None:
                raise
            raise ConfigError(message) from None
        table = evaluate_design(validate(cfg), design)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (HydraException, OmegaConfBaseException) as exc:
        print(f"error: {one_line(exc)}{suggestion(exc, overrides)}", file=sys.stderr)
        return 2
    row = table.iloc[0]
    units = {v.name: v.unit for v in cls.design_variables}
    for column, value in row.items():
        unit = units.get(column) or column_unit(column)[0]
        unit = row["volume_unit"] if unit == "volume_unit" else unit
        text = f"{value:.6g}" if isinstance(value, float) else str(value)
        print(f"{column:<24} {text:>14}  {unit if unit not in ('', '1') else ''}".rstrip())
    if args.parquet is not None:
        try:
            write_parquet(table, args.parquet, {"mechanism": cls.name, "design": design}, units)
        except RunError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {args.parquet}")
    return 0
