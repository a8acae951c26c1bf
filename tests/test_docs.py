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
