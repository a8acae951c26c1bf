"""The subcommands of ``pm-design`` (run before Hydra) and the one-line form of config errors.

``pm-design evaluate`` (one given design: V, GDI, SURI, η; :mod:`.evaluate`), ``aggregate`` (runs
into the dataset), ``report`` (``report.html``) and ``--help`` (commands and one
line per experiment). :func:`one_line` and :func:`suggestion` turn a Hydra or
OmegaConf error into one line with a did-you-mean; :mod:`pipeline.cli` uses them
for a study's overrides too.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from pipeline.config import CONFIG_DIR
from pipeline.config.registry import OPTION_NOTES
from pipeline.config.suggest import did_you_mean, key_suggestion
from pipeline.errors import ConfigError, check_writable


def one_line(exc: BaseException) -> str:
    """A Hydra or OmegaConf error as one line: its first line, plus the options it lists."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    if not lines:
        return type(exc).__name__
    text = lines[0]
    if any(ln.startswith("Available options") for ln in lines):
        start = next(k for k, ln in enumerate(lines) if ln.startswith("Available options")) + 1
        options = [ln for ln in lines[start:] if not ln.startswith(("Config search path", "provider="))]
        options = [ln.split()[0] for ln in options if ln and ":" not in ln]
        group = re.search(r"Available options in '([^']+)'", str(exc))
        notes = {o: OPTION_NOTES.get((group.group(1) if group else "", o)) for o in options}
        text += f"; allowed: {', '.join(f'{o} ({notes[o]})' if notes[o] else o for o in options)}"
    elif len(lines) > 1 and not lines[1].startswith(("full_key", "object_type", "reference_type")):
        text += f": {lines[1]}"
    elif exc.__cause__ is not None and str(exc.__cause__).strip():
        text += f": {str(exc.__cause__).strip().splitlines()[0]}"
    return text


def suggestion(exc: BaseException, argv: list[str]) -> str:
    """Did-you-mean text for a Hydra error about an unknown key or group option (else empty).

    Hydra's own advice for a mistyped key (``objective.wd=0.5``) is to append it
    with ``+``; the user almost always meant an existing key (``objective.w_d``).
    """
    text = str(exc)
    key = re.search(r"Could not override '([^']+)'", text) or re.search(r"Key '([^']+)' is not in struct", text)
    if key:
        dotted = key.group(1)
        full = next(
            (a.split("=", 1)[0].lstrip("+~") for a in argv if a.split("=", 1)[0].lstrip("+~").endswith(dotted)), dotted
        )
        return key_suggestion(full)
    missing = re.search(r"Could not (?:find|load) '([^']+)/([^']+)'", text)
    if missing:
        group, name = missing.groups()
        options = [p.stem for p in (CONFIG_DIR / group).glob("*.yaml")] if (CONFIG_DIR / group).is_dir() else []
        if not options:
            from hydra.core.config_store import ConfigStore

            options = (
                [o.removesuffix(".yaml") for o in ConfigStore.instance().list(group)]
                if ConfigStore.instance().repo.get(group) is not None
                else []
            )
        return did_you_mean(name, options)
    return ""


HELP = """usage: pm-design [+experiment=NAME] [key=value ...]       one study (python -m pipeline)
       pm-design -m [+experiment=NAME] key=a,b,c ...        a sweep: one study per combination
       pm-design evaluate mechanism=NAME VAR=VALUE ... [objective.w_d=W] [--parquet FILE]
                                                            V, GDI, SURI, eta of one given design
       pm-design aggregate DIR [DIR ...] [--dataset DIR]    runs below DIR into the dataset
       pm-design report DIR [--out FILE]                    report.html of a sweep or dataset
       pm-design --hydra-help                               Hydra's own options

Results: outputs/runs/<experiment>/<launch id> (one run), outputs/sweeps/... (-m);
every complete run is added to outputs/dataset (pipeline.store.read_dataset() reads it back).
Presets: +debug=fast (tiny sizes; kept out of the dataset's default view), +reading=NAME.
Config groups: mechanism={mechanisms}  objective={objectives}  optimizer={optimizers}

Experiments (+experiment=NAME; conf/experiment/ and installed plug-in packages):
{experiments}
"""


def experiments_on_search_path() -> dict[str, str]:
    """Every experiment ``+experiment=NAME`` can compose, with its one-line summary: Hydra's own
    list of the group on its search path (conf/ and the plug-in packages' ``pm_design.configs``
    entry points, :mod:`hydra_plugins.pm_design.external_configs`), as a run finds them."""
    import importlib.resources

    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from kinematics.plugins import config_search_paths
    from pipeline.report.reference import experiment_summaries

    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
        names = GlobalHydra.instance().config_loader().get_group_options("experiment")
    texts = experiment_summaries()
    for package in config_search_paths():
        folder = Path(str(importlib.resources.files(package.removeprefix("pkg://"))))
        texts = {**experiment_summaries(folder), **texts}  # conf/ first, as on Hydra's search path
    return {name: texts.get(name, "") for name in sorted(names)}


def print_help() -> None:
    """``--help``: usage, subcommands, and one line per experiment (plug-in packages' included)."""
    from kinematics import MECHANISMS
    from pipeline.objectives import OBJECTIVES
    from pipeline.optimizers import OPTIMIZERS

    summaries = experiments_on_search_path()
    width = max(map(len, summaries), default=0)
    print(
        HELP.format(
            mechanisms="|".join(MECHANISMS),
            objectives="|".join(OBJECTIVES),
            optimizers="|".join(OPTIMIZERS),
            experiments="\n".join(f"  {name:<{width}}  {text}" for name, text in summaries.items()),
        )
    )


def check_output_file(option: str, path: Path) -> Path:
    """``path`` can be written as a file: not a folder, its folder existing (or creatable) and
    writable; checked before any work, :class:`ConfigError` naming ``option``."""
    path = Path(path).expanduser()
    if path.is_dir():
        raise ConfigError(
            f"{option}={str(path)!r} is invalid: it is a folder; allowed: a file path in a writable folder"
        )
    try:
        check_writable(option, path.parent)
    except ConfigError as exc:
        reason = str(exc).split(" is invalid: ", 1)[1].split("; allowed", 1)[0]
        raise ConfigError(
            f"{option}={str(path)!r} is invalid: {reason}; allowed: a file path in a writable folder"
        ) from None
    return path


def subcommand(argv: list[str]) -> int | None:
    """Run a subcommand (``evaluate``, ``aggregate``, ``report``) or ``--help``; None: a study for Hydra."""
    if argv[:1] in (["--help"], ["-h"]):
        print_help()
        return 0
    if not argv or argv[0] not in SUBCOMMANDS:
        return None
    return SUBCOMMANDS[argv[0]](argv[1:])


def _aggregate_command(argv: list[str]) -> int:
    from pipeline.stages.aggregate import main as aggregate_main

    return aggregate_main(argv)


def _evaluate_command(argv: list[str]) -> int:
    from pipeline.cli.evaluate import evaluate_command

    return evaluate_command(argv)


def _report_command(argv: list[str]) -> int:
    from pipeline.report.html import main as report_main

    out = next((a.split("=", 1)[1] for a in argv if a.startswith("--out=")), None)
    if "--out" in argv[:-1]:
        out = argv[argv.index("--out") + 1]
    if out is not None:  # before the report is built (minutes for a large dataset)
        try:
            check_output_file("--out", Path(out))
        except ConfigError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    return report_main(argv)


SUBCOMMANDS = {"evaluate": _evaluate_command, "aggregate": _aggregate_command, "report": _report_command}
