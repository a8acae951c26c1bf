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
