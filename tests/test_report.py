"""report.html: relative links (the folder can be moved), a relative source path (issue 21 item 1),
design variables with units, gaps in percent, captions, repeats of one seed told apart from seeds."""

from __future__ import annotations

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
    assert "gap to reference [%]" in text
    assert "rpr2, mixed, w_d = 0.5, ga, seed 0" in text  # captions name what a run is
    # the repeat of seed 0 is counted once: 3 runs, 2 distinct seeds, 1 repeat
    row = re.search(r"<tr><td>rpr2</td><td>mixed</td><td>0.5</td><td>ga</td>(.*?)</tr>", text).group(1)
    assert re.findall(r"<td>([^<]*)</td>", row)[:4] == ["3", "2", "0, 1", "1"]
    assert '<meta name="viewport"' in text and "overflow-x: auto" in text
    assert "<script src=" not in text and "https://" not in text  # offline: nothing fetched


@pytest.mark.slow  # the fixture: three tiny runs with figures (~40 s on 2 busy cores)
def test_dataset_report_leaves_debug_runs_out_unless_there_is_nothing_else(sweep):
    dataset = sweep.parents[1] / "dataset"
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
