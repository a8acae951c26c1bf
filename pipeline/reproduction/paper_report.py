"""Report step: a dataset's optima beside a paper's printed tables.

``python -m pipeline.reproduction.paper_report DATASET --paper seed000_h4 [--out FILE.md]``
reads the dataset as users do (:func:`pipeline.store.dataset.read_dataset`: its debug runs
left out), counts each repeat of a run once, keeps the runs of the paper's mechanism, and for
each printed table row (:mod:`pipeline.reproduction.papers`) the runs of the same objective (and
``w_d`` for the mixed index), one line per optimiser and study (an experiment run with an
override, another orientation say, is another study: its line carries the first digits of its
``study_hash``): how many runs, and for V, GDI and each design variable (V and the design
variables labelled with their units, read from the data: ``d (cm)``) the paper's number, ours as
mean ± sample standard deviation (n − 1) over the runs, and the relative difference. Rows
without runs in the dataset say so. It compares; it does not claim a reproduction: each paper
file's header says what its numbers mean (e.g. the H4 paper's V in cm³ as printed, ours in
cm³·rad), and ``docs/reproduction.md`` explains every difference.

Typical use: ``python -m pipeline -m +experiment=h4_table3`` (the multirun
that declares Table 3's sweep), then this report on ``outputs/dataset``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from kinematics import MECHANISMS
from pipeline.errors import ConfigError
from pipeline.report.html import read_studies
from pipeline.report.tables import rel, table
from pipeline.reproduction.papers import load_paper, paper_names
from pipeline.stages.plot import distinct_seeds, study_labels, with_study
from pipeline.store.parquet import PARAM_UNITS, column_unit

#: printed quantity -> dataset column (design quantities: :func:`_design_column`)
QUANTITIES = {"V": "volume", "gdi": "gdi", "lci_min": "inverse_condition_min", "lci_max": "inverse_condition_max"}


def _matching(best: pd.DataFrame, mechanism: str, row: dict) -> pd.DataFrame:
    """The dataset's runs of the paper row's mechanism and objective (and w_d for the mixed index)."""
    runs = best[(best["mechanism"] == mechanism) & (best["objective"] == row["objective"])]
    if row.get("w_d") is not None:
        runs = runs[np.isclose(runs["w_d"].astype(float), float(row["w_d"]), rtol=0.0, atol=1e-9)]
    return runs


def _design_column(best: pd.DataFrame, name: str) -> str:
    """The column of a printed design quantity in the runs ``best``: the design variable itself,
    else the mechanism parameter ``param_<name>_<unit>`` (the paper's unit: H4 cm, Tricept mm;
    pipeline.store.parquet). A column these runs leave empty does not count: in a dataset of
    several mechanisms the Tricept's design variable ``d`` and the Delta's ``param_d_mm`` are
    columns, empty on the H4's rows, whose ``d`` is ``param_d_cm``."""
    if name in best.columns and best[name].notna().any():
        return name
    return next(
        (
            c
            for c in best.columns
            if (c == f"param_{name}" or (c.startswith(f"param_{name}_") and c[len(f"param_{name}_") :] in PARAM_UNITS))
            and best[c].notna().any()
        ),
        f"param_{name}",
    )


def _design_units(mechanism: str) -> dict[str, str]:
    """``{design variable: unit}`` of a registered mechanism (empty for an unknown name: the
    ``param_<name>_<unit>`` columns still carry theirs)."""
    try:
        cls = MECHANISMS[mechanism]
    except (KeyError, ValueError):  # ValueError: a broken plug-in (kinematics.plugins.PluginError)
        return {}
    return {v.name: v.unit for v in cls.design_variables}


def _label(key: str, column: str, group: pd.DataFrame, units: dict[str, str]) -> str:
    """The printed quantity with its unit from the data: V's from the runs' ``volume_unit``, a
    design quantity's from its column (``param_d_cm``: cm; a design variable: the mechanism's
    unit of it); a unitless quantity (GDI) as is."""
    if key == "V":
        found = sorted(set(group["volume_unit"].astype(str))) if "volume_unit" in group else []
    elif key in QUANTITIES:
        found = []
    else:
        found = [column_unit(column, units)[0]]
    found = [u for u in found if u and u != "1"]
    return f"{key} ({', '.join(found)})" if found else key


def compare(best: pd.DataFrame, paper: dict) -> list[list]:
    """Rows ``[table, optimiser, runs, quantity, paper, ours (mean ± sd), difference]``.

    Parameters
    ----------
    best : DataFrame
        The dataset's ``best`` table (one row per run; columns ``mechanism``,
        ``objective``, ``w_d``, ``optimizer``, ``volume``, ``gdi``, ``param_*``).
    paper : dict
        A paper's reference data (:func:`pipeline.reproduction.papers.load_paper`).
    """
    out = []
    units = _design_units(paper["mechanism"])
    for row in paper["rows"]:
        runs = _matching(best, paper["mechanism"], row)
        if runs.empty:
            out.append([row["table"], "-", 0, "-", "-", "no runs in the dataset", "-"])
            continue
        quantities = {
            **QUANTITIES,
            **{k: _design_column(runs, k) for k in row if k not in (*QUANTITIES, "table", "objective", "w_d")},
        }
        groups = list(with_study(runs).groupby(["optimizer", "study_hash"], sort=True))
        for (_, group), optimizer in zip(groups, study_labels([key for key, _ in groups])):
            for key, column in quantities.items():
                if key not in row or column not in group:  # not printed for this row, or not in our runs
                    continue
                values = group[column].to_numpy(dtype=float)
                mean = float(values.mean())
                spread = float(values.std(ddof=1)) if len(values) > 1 else math.nan
                ours = f"{mean:.4g} ± {spread:.2g}" if len(values) > 1 else f"{mean:.4g}"
                quantity = _label(key, column, group, units)
                out.append([row["table"], optimizer, len(values), quantity, row[key], ours, rel(mean, row[key])])
    return out


def report(dataset: Path, paper_name: str) -> str:
    """The Markdown report of ``dataset`` against ``paper_name`` (ConfigError for bad input)."""
    paper = load_paper(paper_name)
    dataset = Path(dataset)
    if not (dataset / "best").is_dir():
        raise ConfigError(
            f"dataset={str(dataset)!r} is invalid: allowed a dataset directory (holding best/, written by aggregation)"
        )
    best, _, purposes = read_studies(dataset)
    # a dataset of debug runs only (a smoke test of this report): compared, and said so
    smoke = purposes is None and not best.empty
    rows = compare(distinct_seeds(best, ["mechanism", "objective", "w_d", "optimizer"]), paper)
    return (
        f"# {paper_name}: the paper's tables beside {dataset}\n\n"
        + ("**Debug runs only** (`+debug`, tiny sizes): a smoke test of this report, not results.\n\n" if smoke else "")
        + "Ours: mean ± sample standard deviation (n − 1) over the runs of each objective, optimiser and study "
        "(debug runs left out, a repeat of a run counted once). "
        f"What the paper's numbers mean: `pipeline/reproduction/papers/{paper_name}.yaml`.\n\n"
        + table(["table", "optimiser", "runs", "quantity", "paper", "ours", "difference"], rows)
        + "\n"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m pipeline.reproduction.paper_report", description=__doc__.split("\n")[0]
    )
    parser.add_argument("dataset", type=Path, help="dataset directory (e.g. outputs/dataset)")
    parser.add_argument("--paper", required=True, help=f"one of {', '.join(paper_names())}")
    parser.add_argument("--out", type=Path, help="write the Markdown here instead of printing it")
    args = parser.parse_args(argv)
    try:
        text = report(args.dataset, args.paper)
        if args.out is not None:
            from pipeline.errors import check_writable

            check_writable("--out", args.out)
            from pipeline.store.parquet import write_text

            write_text(args.out, text)
        else:
            print(text, end="")
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
