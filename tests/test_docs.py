"""Generated documentation is current: the configuration reference is what the code writes now."""

from __future__ import annotations

from pathlib import Path

from pipeline.report.reference import experiment_summaries, reference_page

ROOT = Path(__file__).resolve().parents[1]


def test_configuration_reference_is_current():
    committed = (ROOT / "docs" / "configuration.md").read_text()
    assert committed == reference_page(), (
        "docs/configuration.md is stale: regenerate it with `python -m pipeline.report.reference`"
    )


def test_every_experiment_has_a_one_line_summary():
    summaries = experiment_summaries()
    assert summaries and all(summaries.values()), [n for n, s in summaries.items() if not s]


def test_no_experiment_repeats_a_comment_line():
    """An experiment's header comment says each thing once (h4_pareto repeated its summary line)."""
    from pipeline import CONFIG_DIR

    repeated = {}
    for path in sorted((CONFIG_DIR / "experiment").glob("*.yaml")):
        comments = [line.strip("# ").rstrip() for line in path.read_text().splitlines() if line.startswith("#")]
        starts = [c[:50] for c in comments if len(c) > 20]
        if len(starts) != len(set(starts)):
            repeated[path.stem] = sorted({c for c in starts if starts.count(c) > 1})
    assert not repeated, repeated


def test_relative_links_and_images_resolve():
    """Every relative link or image of README.md and docs/*.md names a file that exists (from the
    page's own folder, as a renderer resolves it)."""
    import re

    broken = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            path = target.split("#", 1)[0]
            if not path or re.match(r"[a-z]+:", path):  # an anchor on the page, or a URL
                continue
            if not (page.parent / path).exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, broken


def _documented_columns() -> list[str]:
    """The column names of docs/configuration.md's "Dataset columns" table."""
    import re

    text = (ROOT / "docs" / "configuration.md").read_text().split("## Dataset columns", 1)[1]
    table = text.split("\n\n| column | unit | meaning |", 1)[1].split("\n\n", 1)[0]
    return re.findall(r"^\| `([^`]+)` \|", table, flags=re.MULTILINE)


def test_the_documented_columns_are_the_registry_s_and_cover_best_s_per_variable_columns():
    """docs/configuration.md lists :data:`pipeline.store.parquet.COLUMNS`, whose ``<var>_...`` rows
    are each column the best row repeats per design variable (reference optimum, flat interval)."""
    import numpy as np

    from pipeline.optimizers.base import Problem
    from pipeline.optimizers.sensitivity import flat_intervals
    from pipeline.stages.optimise import reference_columns
    from pipeline.store.parquet import COLUMNS, VARIABLE, column_unit

    documented = _documented_columns()
    assert documented == list(COLUMNS)
    names = ["a", "b"]
    reference = {"value": 1.0, "x": [0.5, 0.5], "found_by": "grid", "n_evaluations": 4, "error": 0.0}
    written = list(reference_columns({"objective_value": 1.0, "objective_error": 0.0}, reference, names))
    problem = Problem(lambda x: -((x[:, 0] - 0.5) ** 2), np.zeros(2), np.ones(2))
    written += list(flat_intervals(problem, np.array([0.5, 0.5]), 0.0, names))
    per_variable = {c for c in documented if c.startswith(VARIABLE)}
    undocumented = [
        c
        for c in written
        if c not in COLUMNS and not any(c == n + p[len(VARIABLE) :] for n in names for p in per_variable)
    ]
    assert not undocumented, f"best's columns missing from COLUMNS (docs/configuration.md): {undocumented}"
    expected = {n + p[len(VARIABLE) :] for n in names for p in per_variable}
    assert expected <= set(written), f"documented but never written: {sorted(expected - set(written))}"
    # each such column carries its variable's unit and a meaning naming the variable (Arrow field metadata)
    for column in expected:
        unit, meaning = column_unit(column, {"a": "mm", "b": "deg"})
        assert unit == {"a": "mm", "b": "deg"}[column[0]] and f"design variable {column[0]}" in meaning, column
    assert "eta" not in written and "pm-design evaluate --parquet" in COLUMNS["eta"][1]
