"""The configuration reference page, generated from the schema and the registries.

``docs/configuration.md`` is written by ``python -m pipeline.report.reference``
from the code itself (the config dataclasses of :mod:`pipeline.config.schema`,
every optimiser's ``Config``, :data:`kinematics.MECHANISMS`,
:data:`pipeline.objectives.OBJECTIVES` and the experiment files of ``conf/``),
so it cannot drift: ``tests/test_docs.py`` fails when the committed page
differs from what this module writes.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import math
import sys
import textwrap
from pathlib import Path

from kinematics import MECHANISMS
from kinematics.base import Mechanism
from pipeline import CONFIG_DIR
from pipeline.config import schema
from pipeline.errors import RunError
from pipeline.objectives import OBJECTIVES
from pipeline.optimizers import OPTIMIZERS
from pipeline.store import parquet

#: where the page lives: docs/ of the source checkout this package sits in (found from this file,
#: as the benchmarks find theirs), so the command writes the same file from any folder
PAGE = Path(__file__).resolve().parents[2] / "docs" / "configuration.md"
#: the sections of the top-level config, in the order of the page
SECTIONS = (
    ("sample", schema.SampleConfig),
    ("evaluate", schema.EvaluateConfig),
    ("parallel", schema.ParallelConfig),
    ("paths", schema.PathsConfig),
    ("plot", schema.PlotConfig),
)


def field_comments(cls: type) -> dict[str, str]:
    """The ``#:`` comment lines written above each field of a dataclass, by field name.

    Inherited fields included: a field takes the comment of the nearest class in the MRO that
    declares it (an optimiser's ``Config`` inherits ``seed`` and ``polish`` from
    :class:`pipeline.optimizers.base.OptimizerConfig`, whose source alone holds their comments).
    """
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        out.update(_own_field_comments(klass))
    return out


def _own_field_comments(cls: type) -> dict[str, str]:
    """The ``#:`` comments of the fields declared in ``cls``'s own body."""
    try:
        source = textwrap.dedent(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    lines = source.splitlines()
    out = {}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            above, k = [], node.lineno - 2
            while k >= 0 and lines[k].strip().startswith("#:"):
                above.insert(0, lines[k].strip()[2:].strip())
                k -= 1
            if above:  # a redeclared field without a comment keeps its base class's
                out[node.target.id] = " ".join(above)
    return out


def _default(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "(required)"
    if dataclasses.is_dataclass(value):
        return "(section)"
    return "`null`" if value is None else f"`{value}`"


def _type(f: dataclasses.Field) -> str:
    """The field's annotation, ``Optional[X]`` written ``X?`` (only the outer bracket is Optional's:
    ``dict[str, Any]`` keeps its own)."""
    text = str(f.type).replace("typing.", "")
    if text.startswith("Optional[") and text.endswith("]"):
        return text[len("Optional[") : -1] + "?"
    return text


def _first_line(text: str | None) -> str:
    return (text or "").strip().split("\n\n")[0].replace("\n", " ").strip()


def dataclass_table(prefix: str, cls: type, skip: tuple[str, ...] = ()) -> list[str]:
    comments = field_comments(cls)
    rows = ["| key | type | default | meaning |", "| --- | --- | --- | --- |"]
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        rows.append(f"| `{prefix}{f.name}` | {_type(f)} | {_default(f)} | {comments.get(f.name, '')} |")
    return rows


def _bound(value: float) -> str:
    return "∞" if math.isinf(value) else f"{value:g}"


def mechanism_section(name: str, cls: type[Mechanism]) -> list[str]:
    pose = ", ".join(f"{p} ({'rad' if a else cls.length_unit})" for p, a in zip(cls.pose_names, cls.angular))
    out = [
        f"### `mechanism={name}`",
        "",
        _first_line(cls.__doc__),
        "",
        f"Pose ({cls.dof} DOF): {pose}.",
        "",
        "| design variable | lower | upper | unit |",
        "| --- | --- | --- | --- |",
    ]
    out += [f"| `{v.name}` | {_bound(v.lower)} | {_bound(v.upper)} | {v.unit} |" for v in cls.design_variables]
    if cls.default_fixed:
        out += [
            "",
            "Fixed parameters (`mechanism.fixed.*`) and their defaults: "
            + ", ".join(f"`{k}` = `{v}`" for k, v in cls.default_fixed.items())
            + ".",
        ]
    return out + [""]


def experiment_summaries(config_dir: Path = CONFIG_DIR) -> dict[str, str]:
    """One line per experiment file: the comment line after ``# Study: NAME``."""
    out = {}
    for path in sorted((config_dir / "experiment").glob("*.yaml")):
        comments = [ln[1:].strip() for ln in path.read_text().splitlines() if ln.startswith("#")]
        body = [c for c in comments if c and not c.startswith(("@package", "Study:"))]
        out[path.stem] = body[0] if body else ""
    return out


def reference_page() -> str:
    """The whole Markdown page (deterministic: sorted registries, no dates)."""
    lines = [
        "# Configuration reference",
        "",
        "Generated by `python -m pipeline.report.reference` from the schema and the registries; "
        "do not edit by hand (`tests/test_docs.py` checks it is current).",
        "",
        "Every key is set on the command line as `key=value` (`python -m pipeline key=value ...`). "
        "Bad values stop the run before any work with one line naming the key and what is allowed.",
        "",
        "## Top level",
        "",
    ]
    lines += dataclass_table(
        "", schema.Config, skip=tuple(name for name, _ in SECTIONS) + ("mechanism", "objective", "optimizer")
    ) + [""]
    for name, cls in SECTIONS:
        lines += [f"## `{name}`", "", _first_line(cls.__doc__), ""] + dataclass_table(f"{name}.", cls) + [""]
    lines += ["## `mechanism`", "", _first_line(schema.MechanismConfig.__doc__), ""]
    lines += dataclass_table("mechanism.", schema.MechanismConfig) + [""]
    # the built-ins only: an installed plug-in must not make the committed page stale
    for name in sorted(MECHANISMS.builtins):
        lines += mechanism_section(name, MECHANISMS[name])
    lines += [
        "## `objective`",
        "",
        _first_line(schema.ObjectiveConfig.__doc__),
        "",
        "`objective.w_d` is the GDI's weight in η, in [0, 1], with `objective=mixed` only; the other "
        "objectives fix it at the η they equal (a run records no weight it ignored).",
        "",
        "| option | label | unit | `w_d` |",
        "| --- | --- | --- | --- |",
    ]
    lines += [
        f"| `objective={n}` | {o.label} | {o.unit} | {o.default_w_d}{' (default)' if n == 'mixed' else ' (fixed)'} |"
        for n, o in sorted(OBJECTIVES.items())
    ]
    lines += ["", "## `optimizer`", ""]
    for name in sorted(OPTIMIZERS):
        cls = OPTIMIZERS[name]
        lines += [f"### `optimizer={name}`", "", _first_line(cls.__doc__ or cls.Config.__doc__), ""]
        lines += dataclass_table("optimizer.", cls.Config, skip=("name",)) + [""]
    lines += ["## Experiments (`+experiment=NAME`)", "", "| name | what it is |", "| --- | --- |"]
    lines += [f"| `{n}` | {s} |" for n, s in experiment_summaries().items()]
    lines += [
        "",
        "## Dataset columns",
        "",
        "Every Parquet table (`best`, `history`, `designs`, `front`, `runs`) uses these names; a unit "
        "`volume_unit` / `objective_unit` means the unit named in that row's column of that name.",
        "",
        "| column | unit | meaning |",
        "| --- | --- | --- |",
    ]
    lines += [f"| `{name}` | {unit} | {meaning} |" for name, (unit, meaning) in parquet.COLUMNS.items()]
    lines += [
        "",
        "### Units rule",
        "",
        units_rule(),
        "",
        "Design variables and mechanism parameters, per mechanism (`param_*` columns as named in the dataset):",
        "",
        "| mechanism | design variables | `param_*` columns |",
        "| --- | --- | --- |",
    ]
    for name in sorted(MECHANISMS.builtins):
        cls = MECHANISMS[name]
        names = {v.name for v in cls.design_variables}
        variables = ", ".join(f"`{v.name}` [{v.unit}]" for v in cls.design_variables)
        centre = [0.5 * (v.lower + v.upper) for v in cls.design_variables]
        built = cls.from_design(centre, **cls.default_fixed).params()
        params = ", ".join(
            f"`{parquet.param_column(k, cls.param_unit(k, v))}`"
            for k, v in built.items()
            if k not in names and isinstance(v, (int, float, str)) and not isinstance(v, bool)
        )
        lines.append(f"| `{name}` | {variables} | {params} |")
    return "\n".join(lines).rstrip() + "\n"


def units_rule() -> str:
    """The units rule of the dataset, as Markdown (from :mod:`pipeline.store.parquet`'s docstring)."""
    text = parquet.__doc__.split("---------------------------------------------------------------------\n", 1)[1]
    return text.strip().replace("``", "`")


def main(argv: list[str] | None = None) -> int:
    """Write the page (``--out``, default :data:`PAGE`); 2 and a one-line error if it cannot."""
    parser = argparse.ArgumentParser(prog="python -m pipeline.report.reference", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--out", type=Path, default=PAGE, help="output file (default: docs/configuration.md of the source checkout)"
    )
    args = parser.parse_args(argv)
    if not args.out.parent.is_dir():
        # an installed package has no docs/ beside it: refuse rather than create a stray folder
        print(
            f"error: --out={str(args.out)!r} is invalid: its folder {args.out.parent} does not exist "
            "(the default is the docs/ of a source checkout); allowed: a file in an existing folder",
            file=sys.stderr,
        )
        return 2
    text = reference_page()  # the whole page first: a failure leaves no partial file
    try:
        parquet.write_text(args.out, text)
    except RunError as exc:
        print(f"error: --out: {exc}", file=sys.stderr)
        return 2
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
