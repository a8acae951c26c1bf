"""report.html: relative links (the folder can be moved), a relative source path (issue 21 item 1),
design variables with units, gaps as recorded, captions, repeats of one seed told apart from seeds."""

from __future__ import annotations

import html
import re
import shutil
from pathlib import Path
from urllib.parse import unquote

import pytest

from pipeline.config import register_configs
from pipeline.report.html import build_report
from pipeline.report.html import main as report_main
from pipeline.stages.aggregate import aggregate
from pipeline.store.dataset import read_dataset
from pipeline.study import run_study
from tests.test_pipeline import make_cfg


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> Path:
    """A sweep folder of three tiny 2-RPR runs: seed 0, seed 0 again (a repeat), seed 1."""
    register_configs()
    root = tmp_path_factory.mktemp("report")
    sweep = root / "sweeps" / "s"
    for job, seed in enumerate((0, 0, 1)):
        cfg = make_cfg(
            [
                "+experiment=rpr2_mixed",
                "+debug=fast",
                "optimizer.population=4",
                "optimizer.generations=2",
                f"optimizer.seed={seed}",
                f"paths.output_dir={root}",
                "plot.enabled=true",
                "optimizer.reference=true",
            ]
        )
        run_study(cfg, sweep / f"{job}_seed={seed}", job)
    aggregate(sweep, root / "dataset")
    return sweep


@pytest.mark.slow  # the fixture: three tiny runs with figures (~40 s on 2 busy cores)
def test_report_of_a_relative_path_has_relative_links_that_survive_a_move(sweep, tmp_path, monkeypatch):
    monkeypatch.chdir(sweep.parents[1])
    assert report_main(["sweeps/s"]) == 0  # a relative source: crashed in Path.as_uri() before
    text = (sweep / "report.html").read_text()
    links = re.findall(r'href="([^"]+)"', text)
    assert links and not any(link.startswith(("file:", "/")) for link in links)
    moved = tmp_path / "elsewhere"
    shutil.copytree(sweep, moved)
    for link in links:
        assert (moved / unquote(link)).is_file(), link


@pytest.mark.slow  # the fixture: three tiny runs with figures (~40 s on 2 busy cores)
def test_report_table_units_gaps_captions_and_seeds(sweep):
    text = build_report(sweep)
    assert "b [mm]" in text and "q_min [mm]" in text  # design variables with units
    assert "<th>gap to reference</th>" in text  # its labels carry their own % (no "[%]")
    # each optimum with its estimated discretisation error, each gap as recorded (issue 23)
    best = read_dataset(sweep.parents[1] / "dataset", purposes=None)  # +debug=fast runs
    assert re.search(r"η = 0\.\d+ ± \d", text)
    for label in best["reference_gap_label"]:
        assert html.escape(label) in text
    assert "rpr2, mixed, w_d = 0.5, ga, seed 0" in text  # captions name what a run is
    assert "<strong>3 of 3 runs are debug runs</strong>" in text  # +debug=fast: said above everything
    # the repeat of seed 0 is counted once: 3 runs, 2 distinct seeds, 1 repeat
    row = re.search(
        r"<tr><td>rpr2</td><td>mixed</td><td>0.5</td><td>ga</td><td>rpr2_mixed</td><td>[0-9a-f]{16}</td>(.*?)</tr>",
        text,
    ).group(1)
    assert re.findall(r"<td>([^<]*)</td>", row)[:4] == ["3", "2", "0, 1", "1"]
    assert '<meta name="viewport"' in text and "overflow-x: auto" in text
    assert "<script src=" not in text and "https://" not in text  # offline: nothing fetched
    # a folder of runs without multirun.yaml: the runs' own configs (the box was empty)
    configuration = text[text.index("<h2>Configuration</h2>") :]
    assert "<details><summary>config of rpr2, mixed, w_d = 0.5, ga, seed 0" in configuration
    assert "experiment_name: rpr2_mixed" in configuration and "hydra_logging" not in configuration


@pytest.mark.slow  # the fixture: three tiny runs with figures (~40 s on 2 busy cores)
def test_dataset_report_leaves_debug_runs_out_unless_there_is_nothing_else(sweep):
    dataset = sweep.parents[1] / "dataset"
    with pytest.warns(UserWarning, match=r"all 3 rows of best are debug runs, .*purposes=None keeps them"):
        assert read_dataset(dataset).empty  # all three are +debug=fast runs
    everything = read_dataset(dataset, purposes=None)
    assert len(everything) == 3 and set(everything["purpose"]) == {"debug"}
    assert "debug runs only" in build_report(dataset)


def test_links_are_relative_to_the_page_even_for_relative_paths(tmp_path, monkeypatch):
    """Issue 21 item 1: ``Path.as_uri()`` of a relative path raised after all the work was done."""
    from pipeline.report.html import _link

    monkeypatch.chdir(tmp_path)
    assert _link(Path("outputs/sweeps/s/0_w_d=0/best.parquet"), Path("outputs/sweeps/s")) == "0_w_d=0/best.parquet"
    assert _link(Path("outputs/runs/r/best.parquet"), Path("reports")) == "../outputs/runs/r/best.parquet"


def test_sweep_config_leaves_hydra_out():
    """The report's configuration is the sweep's own config: Hydra's node (help template, logging,
    hundreds of lines) is left out; interpolations stay as written."""
    from pipeline.report.html import sweep_config

    text = (
        "hydra:\n  help:\n    template: 'long help text'\n  hydra_logging:\n    version: 1\n"
        "  job_logging:\n    root: {level: INFO}\n"
        "experiment_name: h4_mixed\nmechanism:\n  name: h4\nobjective:\n  w_d: 0.5\n"
        "paths:\n  output_dir: ${hydra:runtime.cwd}/outputs\n"
    )
    out = sweep_config(text)
    assert "hydra_logging" not in out and "template" not in out and "job_logging" not in out
    assert out.startswith("experiment_name: h4_mixed")
    assert "w_d: 0.5" in out and "${hydra:runtime.cwd}/outputs" in out


def test_runs_configs_show_each_config_once_or_say_there_is_none(tmp_path):
    import json

    import pandas as pd

    from pipeline.report.html import runs_configs

    rows, dirs = [], {}
    for run_id, seed in (("a", 0), ("b", 1), ("c", 2)):
        d = tmp_path / run_id
        d.mkdir()
        config = {"experiment_name": "h4_pareto", "optimizer": {"name": "nsga2", "seed": seed // 2}}
        (d / "manifest.json").write_text(json.dumps({"run_id": run_id, "config": config}))
        dirs[run_id] = d
        rows.append(
            {"run_id": run_id, "mechanism": "h4", "objective": "mixed", "w_d": 0.5, "optimizer": "nsga2", "seed": seed}
        )
    html_text = runs_configs(pd.DataFrame(rows), dirs)
    assert html_text.count("<details>") == 2  # runs a and b share one config
    assert "h4, mixed, w_d = 0.5, nsga2, seed 0; h4, mixed, w_d = 0.5, nsga2, seed 1" in html_text
    assert "experiment_name: h4_pareto" in html_text
    assert "No config recorded" in runs_configs(pd.DataFrame(rows), {})


def test_optima_table_heads_the_gap_labels_without_a_unit():
    """The gap column holds labels ("within error (< 0.19 %)", "beats the reference by 5 % ± 0.1 %")
    that carry their own %: a header "[%]" promised numbers."""
    import pandas as pd

    from pipeline.report.html import optima_table

    best = pd.DataFrame(
        {
            "run_id": ["a"],
            "mechanism": ["h4"],
            "objective": ["mixed"],
            "w_d": [0.5],
            "optimizer": ["cmaes"],
            "seed": [0],
            "objective_value": [0.2],
            "volume": [1.0],
            "reference_gap": [-0.05],
            "reference_gap_label": ["beats the reference by 5 % ± 0.1 %"],
        }
    )
    text = optima_table(best, {}, Path("."))
    assert "<th>gap to reference</th>" in text and "[%]" not in text
    assert '<td data-value="-5.0">beats the reference by 5 % ± 0.1 %</td>' in text
    # w_d weighs the mixed index only: a volume run's stored 0 is no weight
    assert "<td>0.5</td>" in text
    volume = optima_table(best.assign(objective="volume", w_d=0.0), {}, Path("."))
    assert "<td>volume</td><td></td><td>cmaes</td>" in volume


def test_reference_page_types_keep_their_brackets():
    """``Optional[X]`` reads ``X?``; other brackets stay (``dict[str, Any?``, ``list[float??`` before)."""
    from pipeline.report.reference import reference_page

    types = [row.split(" | ")[1] for row in reference_page().splitlines() if row.startswith("| `") and "?" in row]
    assert types, "no optional field found"
    broken = [t for t in types if t.count("[") != t.count("]") or "??" in t or ("?" in t and not t.endswith("?"))]
    assert not broken, broken
    for key, shown in (
        ("mechanism.fixed", "dict[str, Any]"),
        ("mechanism.orientation", "list[float]?"),
        ("evaluate.resolution", "int?"),
        ("optimizer.objectives", "list[str]"),
    ):
        assert f"| `{key}` | {shown} |" in reference_page(), key


def test_reference_page_gives_inherited_fields_their_meaning():
    """An optimiser's ``Config`` inherits ``seed``, ``polish``, ... from ``OptimizerConfig``, whose
    ``#:`` comments were not read (empty meaning cells); a redeclared field without one keeps them."""
    from dataclasses import dataclass

    from pipeline.optimizers import OPTIMIZERS
    from pipeline.optimizers.base import OptimizerConfig
    from pipeline.report.reference import dataclass_table, field_comments

    base = field_comments(OptimizerConfig)
    inherited = [f for f in ("seed", "polish", "reference", "polish_evaluations") if base.get(f)]
    assert len(inherited) == 4, base

    @dataclass
    class Redeclared(OptimizerConfig):
        seed: int = 1

    assert field_comments(Redeclared)["seed"] == base["seed"]
    for name, cls in OPTIMIZERS.items():
        rows = dataclass_table("optimizer.", cls.Config, skip=("name",))
        for field in inherited:
            (row,) = [r for r in rows if r.startswith(f"| `optimizer.{field}` |")]
            assert row.endswith(f"| {base[field]} |"), (name, row)
