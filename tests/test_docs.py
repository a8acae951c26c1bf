"""Generated documentation is current: the configuration reference is what the code writes now;
the developer commands of docs/ (benchmarks, the reference's generator) run where the pages say."""

from __future__ import annotations

import importlib
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

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


# ----------------------------------------------------------------------------- developer commands
def _benchmark_commands() -> list[str]:
    """The commands of docs/benchmarks.md's bash block (comments and comment-only lines dropped)."""
    import re

    block = re.search(r"^```bash\n(.*?)^```", (ROOT / "docs" / "benchmarks.md").read_text(), flags=re.S | re.M)
    lines = (line.split(" #", 1)[0].strip() for line in block.group(1).splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def _run_from(command: str, cwd: Path, timeout: float):
    """``command`` run by bash in ``cwd``, as a reader types it (``python`` is this environment's)."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def test_benchmarks_page_says_where_its_commands_run():
    """``benchmarks`` is a folder of the checkout, not an installed package: the page says to run its
    commands from the checkout root, and every one of them names a script of that folder."""
    text = " ".join((ROOT / "docs" / "benchmarks.md").read_text().split())
    assert "Run these from the checkout root" in text and "No module named 'benchmarks'" in text
    commands = _benchmark_commands()
    assert commands and all(shlex.split(c)[:2] == ["python", "-m"] for c in commands), commands
    for command in commands:
        module = shlex.split(command)[2]
        assert module.startswith("benchmarks.") and (ROOT / f"{module.replace('.', '/')}.py").is_file(), command


@pytest.mark.parametrize("module, work", [("accuracy", "study"), ("external", "resolve_mechanism")])
def test_benchmark_help_prints_usage_without_running(module, work, monkeypatch, capsys):
    """``python -m benchmarks.accuracy --help`` started the six-minute run that rewrites
    docs/accuracy.md: ``--help`` prints the usage (the docstring's first line) and exits 0 first."""
    script = importlib.import_module(f"benchmarks.{module}")

    def started(*args, **kwargs):
        raise AssertionError(f"benchmarks.{module} --help started the benchmark")

    monkeypatch.setattr(script, work, started)
    monkeypatch.setattr(sys, "argv", [f"{module}.py", "--help"])
    with pytest.raises(SystemExit) as exit_:
        script.main()
    assert exit_.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert out.startswith("usage:") and " ".join(script.__doc__.split("\n")[0].split()) in out


@pytest.mark.slow
@pytest.mark.parametrize("command", _benchmark_commands())
def test_every_benchmark_script_answers_help_from_the_checkout_root(command):
    """Each documented script, from the checkout root, prints its usage and exits at once (nothing
    run, no page rewritten)."""
    pages = {p: p.stat().st_mtime_ns for p in (ROOT / "docs").glob("*.md")}
    proc = _run_from(" ".join(shlex.split(command)[:3]) + " --help", ROOT, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("usage:"), proc.stderr[-2000:]
    assert pages == {p: p.stat().st_mtime_ns for p in (ROOT / "docs").glob("*.md")}


@pytest.mark.slow
def test_a_benchmark_command_runs_verbatim_from_the_checkout_root(tmp_path):
    """docs/benchmarks.md's cheapest command, verbatim, where the page says to run it; from an empty
    folder it cannot run (which is why the page says where)."""
    command = next(c for c in _benchmark_commands() if c.startswith("python -m benchmarks.kinematics"))
    proc = _run_from(command, ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0].split() == ["mechanism", "kernel", "poses/s"] and len(lines) > 2, proc.stdout
    elsewhere = _run_from(command, tmp_path, timeout=120)
    assert elsewhere.returncode != 0 and "No module named 'benchmarks'" in elsewhere.stderr


# ------------------------------------------------------------------ python -m pipeline.report.reference
def test_reference_command_writes_the_checkout_s_page_from_any_folder(tmp_path, monkeypatch, capsys):
    """``python -m pipeline.report.reference`` from an empty folder ended in a FileNotFoundError
    traceback (it wrote to ``docs/`` of the working folder): it writes the source checkout's page,
    whatever the folder (here redirected, not to overwrite the real page)."""
    from pipeline.report import reference

    assert reference.PAGE == ROOT / "docs" / "configuration.md"
    checkout = tmp_path / "checkout" / "docs"
    checkout.mkdir(parents=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    monkeypatch.chdir(empty)
    monkeypatch.setattr(reference, "PAGE", checkout / "configuration.md")
    assert reference.main([]) == 0
    assert (checkout / "configuration.md").read_text() == reference.reference_page()
    assert capsys.readouterr().out.strip() == str(checkout / "configuration.md")
    assert not any(empty.iterdir())  # no stray docs/ where it was run


def test_reference_command_refuses_a_missing_folder_in_one_line(tmp_path, monkeypatch, capsys):
    """An installed package has no docs/ beside it: one line naming --out, no traceback, no file."""
    from pipeline.report import reference

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(reference, "PAGE", tmp_path / "site-packages" / "docs" / "configuration.md")
    for argv in ([], ["--out", str(tmp_path / "nowhere" / "configuration.md")]):
        assert reference.main(argv) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: --out=") and "allowed:" in lines[0], lines
    assert not any(tmp_path.iterdir())
