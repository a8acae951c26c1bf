"""The command line: ``pm-design`` / ``python -m pipeline`` ``[+experiment=NAME] [key=value ...]``.

Subcommands, dispatched before Hydra (``pm-design --help`` lists them):
``evaluate`` (one given design: V, GDI, SURI, η), ``aggregate`` (runs into
the dataset) and ``report`` (``report.html`` of a sweep or dataset).

The top layer: it checks a single run's overrides before Hydra creates
anything (one ``error:`` line, exit 2), hands the run to Hydra, and turns
the study's outcome into an exit status: 0 complete, 1 failed at run time,
2 bad input, 130 interrupted. A sweep (``-m``) goes through Hydra's sweeper
(:mod:`pipeline.sweeps`), and each of its jobs through the same task.
"""

from __future__ import annotations

import gc
import logging
import os
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig
from omegaconf.errors import OmegaConfBaseException

from pipeline.config import CONFIG_DIR, register_configs, validate
from pipeline.config.suggest import did_you_mean, key_suggestion
from pipeline.errors import ConfigError, RunError, check_writable
from pipeline.evaluation import workers
from pipeline.stages.aggregate import aggregate
from pipeline.store.runs import check_run_dir
from pipeline.study import run_study

log = logging.getLogger(__name__)


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
        text += f"; allowed: {', '.join(options)}"
    elif len(lines) > 1 and not lines[1].startswith(("full_key", "object_type", "reference_type")):
        text += f": {lines[1]}"
    elif exc.__cause__ is not None and str(exc.__cause__).strip():
        text += f": {str(exc.__cause__).strip().splitlines()[0]}"
    return text


def precheck_overrides(argv: list[str]) -> None:
    """Compose and check a single run's config before Hydra creates anything (one line, exit 2).

    Catches composition errors (unknown group option, bad type), every
    :func:`validate` error, an unwritable or already used ``hydra.run.dir``.

    Skipped when any Hydra flag is given (``-m``, ``--help``, ...): Hydra
    handles those, and a sweep's jobs are checked by the sweeper.
    """
    if any(arg.startswith("-") for arg in argv):
        return
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException


    register_configs()
    try:
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
            cfg = compose(config_name="config", overrides=list(argv), return_hydra_config=True)
        validate(cfg)
        run_dir = Path(cfg.hydra.run.dir)
        check_writable("hydra.run.dir", run_dir)
        check_run_dir(run_dir)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except (HydraException, OmegaConfBaseException, ValueError) as exc:
        print(f"error: {one_line(exc)}{suggestion(exc, argv)}", file=sys.stderr)
        sys.exit(2)


def suggestion(exc: BaseException, argv: list[str]) -> str:
    """Did-you-mean text for a Hydra error about an unknown key or group option (else empty).

    Hydra's own advice for a mistyped key (``objective.wd=0.5``) is to append it
    with ``+``; the user almost always meant an existing key (``objective.w_d``).
    """
    import re

    text = str(exc)
    key = re.search(r"Could not override '([^']+)'", text) or re.search(r"Key '([^']+)' is not in struct", text)
    if key:
        dotted = key.group(1)
        full = next((a.split("=", 1)[0].lstrip("+~") for a in argv
                     if a.split("=", 1)[0].lstrip("+~").endswith(dotted)), dotted)
        return key_suggestion(full)
    missing = re.search(r"Could not (?:find|load) '([^']+)/([^']+)'", text)
    if missing:
        group, name = missing.groups()
        options = [p.stem for p in (CONFIG_DIR / group).glob("*.yaml")] if (CONFIG_DIR / group).is_dir() else []
        if not options:
            from hydra.core.config_store import ConfigStore

            options = [o.removesuffix(".yaml") for o in ConfigStore.instance().list(group)] \
                if ConfigStore.instance().repo.get(group) is not None else []
        return did_you_mean(name, options)
    return ""




def remove_if_empty(path: Path, levels: int = 3) -> None:
    """Hydra creates the run directory (and its parents) before the task starts; remove the
    empty ones it made (the run directory and up to ``levels - 1`` empty parents)."""
    for _ in range(levels):
        try:
            path.rmdir()
        except OSError:
            return
        path = path.parent


def shutdown_workers() -> None:
    """End the fitness workers and joblib's reusable ones (after Ctrl-C, so none outlives the run)."""
    workers.shutdown_workers(kill=True)
    try:
        from joblib.externals.loky import get_reusable_executor

        get_reusable_executor().shutdown(wait=False, kill_workers=True)
    except Exception:  # noqa: BLE001 - best effort at exit; the process is ending anyway
        pass


def run_from_hydra(cfg: DictConfig) -> dict:
    """The task of ``python -m pipeline``: one run, its failure reported as one line.

    Single run: bad input exits 2, a run-time failure 1, Ctrl-C 130, each with
    one ``error:`` line and no traceback. In a multirun a run-time failure is
    returned as the job's status so the other jobs go on
    (:class:`pipeline.sweeps.sweeper.CheckedSweeper` sums them up).
    """
    hc = HydraConfig.get()
    run_dir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    job = int(hc.job.num) if multirun else 0
    try:
        run_study(cfg, run_dir, job, list(hc.overrides.task))
        if not multirun:  # a sweep aggregates its jobs at its end (pipeline.sweeps)
            dataset = Path(cfg.paths.dataset_dir)
            aggregate(run_dir, dataset)
            shown = os.path.relpath(run_dir) if run_dir.is_absolute() else str(run_dir)
            print(f"run: {shown}\ndataset: {dataset} "
                  f"(from pipeline.store import read_dataset; read_dataset({str(dataset)!r}))")
        return {"status": "complete", "reason": ""}
    except (ConfigError, RunError) as exc:
        if isinstance(exc, ConfigError):
            remove_if_empty(run_dir)
        if multirun:
            log.error("job %d failed: %s", job, exc)
            return {"status": "failed", "reason": str(exc)}
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2 if isinstance(exc, ConfigError) else 1)
    except KeyboardInterrupt:
        shutdown_workers()
        print(f"error: interrupted; {run_dir} is marked interrupted and will not be aggregated", file=sys.stderr)
        sys.exit(130)


register_configs()


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def main(cfg: DictConfig) -> dict:
    return run_from_hydra(cfg)


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

Experiments (+experiment=NAME, conf/experiment/):
{experiments}
"""


def print_help() -> None:
    """``--help``: usage, subcommands, and one line per experiment."""
    from kinematics import MECHANISMS
    from pipeline.objectives import OBJECTIVES
    from pipeline.optimizers import OPTIMIZERS
    from pipeline.report.reference import experiment_summaries

    summaries = experiment_summaries()
    width = max(map(len, summaries), default=0)
    print(HELP.format(mechanisms="|".join(MECHANISMS), objectives="|".join(OBJECTIVES),
                      optimizers="|".join(OPTIMIZERS),
                      experiments="\n".join(f"  {name:<{width}}  {text}" for name, text in summaries.items())))


def evaluate_command(argv: list[str]) -> int:
    """``pm-design evaluate mechanism=NAME VAR=VALUE ... [design=[...]] [key=value ...] [--parquet FILE]``.

    Design variables by name (``a=250``) or all at once (``design=[250,400,100]``),
    in the mechanism's design units; every other ``key=value`` is a config override
    (``mechanism.fixed.stroke=120``, ``evaluate.resolution=24``, ``objective.w_d=0.3``).
    Prints one table; ``--parquet FILE`` also writes it with units. Exit 2 on bad input.
    """
    import argparse

    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException

    from kinematics import MECHANISMS
    from pipeline.stages.design import evaluate_design
    from pipeline.store.parquet import write_parquet

    parser = argparse.ArgumentParser(prog="pm-design evaluate", description=evaluate_command.__doc__.split("\n")[0])
    parser.add_argument("assignments", nargs="*", help="mechanism=NAME, design variables VAR=VALUE, overrides")
    parser.add_argument("--parquet", type=Path, default=None, help="also write the row to this Parquet file")
    args = parser.parse_args(argv)
    given = dict(a.split("=", 1) for a in args.assignments if "=" in a)
    bad = [a for a in args.assignments if "=" not in a]
    try:
        if bad:
            raise ConfigError(f"{bad[0]} is invalid: allowed key=value")
        name = given.pop("mechanism", "h4")
        if name not in MECHANISMS:
            raise ConfigError(f"mechanism={name} is invalid: allowed {', '.join(MECHANISMS)}"
                              f"{did_you_mean(name, MECHANISMS)}")
        variables = [v.name for v in MECHANISMS[name].design_variables]
        if "design" in given:
            text = given.pop("design").strip("[]() ")
            design = [float(v) for v in text.split(",") if v.strip()]
        else:
            missing = [v for v in variables if v not in given]
            if missing:
                raise ConfigError(f"{missing[0]} is missing: allowed {' '.join(f'{v}=...' for v in variables)} "
                                  f"or design=[...] ({name}'s design variables)")
            design = [float(given.pop(v)) for v in variables]
        overrides = [f"mechanism={name}", *(f"{k}={v}" for k, v in given.items()),
                     "hydra.run.dir=.", "experiment_name=evaluate"]
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
            cfg = compose(config_name="config", overrides=overrides)
        table = evaluate_design(validate(cfg), design)
    except ValueError as exc:
        print(f"error: design is invalid: {exc}; allowed numbers", file=sys.stderr)
        return 2
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (HydraException, OmegaConfBaseException) as exc:
        print(f"error: {one_line(exc)}{suggestion(exc, list(args.assignments))}", file=sys.stderr)
        return 2
    row = table.iloc[0]
    units = {v.name: v.unit for v in MECHANISMS[name].design_variables}
    from pipeline.store.parquet import column_unit

    for column, value in row.items():
        unit = units.get(column) or column_unit(column)[0]
        unit = row["volume_unit"] if unit == "volume_unit" else unit
        text = f"{value:.6g}" if isinstance(value, float) else str(value)
        print(f"{column:<24} {text:>14}  {unit if unit not in ('', '1') else ''}".rstrip())
    if args.parquet is not None:
        try:
            write_parquet(table, args.parquet, {"mechanism": name, "design": design}, units)
        except RunError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {args.parquet}")
    return 0


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


def _report_command(argv: list[str]) -> int:
    from pipeline.report.html import main as report_main

    return report_main(argv)


SUBCOMMANDS = {"evaluate": evaluate_command, "aggregate": _aggregate_command, "report": _report_command}


def entry() -> None:
    """The console script: subcommands and ``--help``, else the one-line precheck of a run, then Hydra."""
    try:
        code = subcommand(sys.argv[1:])
        if code is not None:
            sys.exit(code)
        precheck_overrides(sys.argv[1:])
        main()
    finally:
        # Why: by now every result is written; what remains is Python's teardown, whose
        # garbage collections walk every object of ~1,000 modules (numba, pandas, matplotlib):
        # ~0.5 s of every command. Frozen objects are skipped; the exit is otherwise the usual
        # one (exit handlers, workers ended, streams flushed).
        gc.disable()
        gc.freeze()
