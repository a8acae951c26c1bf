"""The command line: ``pm-design`` / ``python -m pipeline`` (:mod:`.main`), its subcommands
(:mod:`.commands`, ``evaluate`` in :mod:`.evaluate`) and the check of a run's overrides before Hydra starts (:mod:`.precheck`)."""

from pipeline.cli.commands import print_help
from pipeline.cli.evaluate import evaluate_command
from pipeline.cli.main import entry, main, run_from_hydra
from pipeline.cli.precheck import precheck_overrides

__all__ = ["entry", "evaluate_command", "main", "precheck_overrides", "print_help", "run_from_hydra"]
