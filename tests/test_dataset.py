"""The dataset guarantee: no sequence of runs, re-runs, failures and aggregations loses,
duplicates or silently mixes a row; every column of every run comes back with pandas."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
from hydra import compose, initialize_config_dir

import pipeline.stages.dataset_build as build_module  # where the dataset files are written
from pipeline.config import CONFIG_DIR, register_configs
from pipeline.errors import RunError
from pipeline.stages.aggregate import aggregate
from pipeline.store.runs import launch_id
from pipeline.study import run_study

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
TINY = ["+debug=fast", "optimizer.population=4", "optimizer.generations=2"]


def make_run(run_dir: Path, tmp_path: Path, *overrides: str, job: int = 0) -> Path:
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=[*TINY, f"paths.output_dir={tmp_path}", *overrides])
    run_study(cfg, run_dir, job=job)
    return run_dir


def snapshot(dataset: Path) -> dict[str, bytes]:
    return {str(p.relative_to(dataset)): p.read_bytes() for p in sorted(dataset.rglob("*.parquet"))}


def test_readme_sweep_and_read_returns_every_column_of_four_mechanisms(tmp_path):
    out = tmp_path / "outputs"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline",
            "-m",
            "objective.name=mixed",
            "objective.w_d=0.5",
            "mechanism=h4,tricept,rpr3,rpr2",
            *TINY,
            f"paths.output_dir={out}",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    best = pd.read_parquet(out / "dataset" / "best")  # as README tells users to read it
    assert sorted(best["mechanism"]) == ["h4", "rpr2", "rpr3", "tricept"]
    design_columns = {"d_ratio", "h_ratio", "Qz_ratio", "a", "b", "d", "base_side", "platform_side", "q_min"}
    assert design_columns <= set(best.columns)
    h4 = best[best["mechanism"] == "h4"].iloc[0]
    rpr2 = best[best["mechanism"] == "rpr2"].iloc[0]
    assert pd.notna(h4["d_ratio"]) and pd.isna(h4["q_min"])
    assert pd.notna(rpr2["q_min"]) and pd.isna(rpr2["d_ratio"])
    assert best["n_samples"].dtype == "int64" and best["w_d"].dtype == "float64"
    assert not [c for c in best.columns if best[c].dtype == object]
    assert best["run_id"].is_unique
    for table in ("history", "designs", "runs"):
        frame = pd.read_parquet(out / "dataset" / table)
        assert set(frame["mechanism"]) == {"h4", "tricept", "rpr3", "rpr2"}
    designs = pd.read_parquet(out / "dataset" / "designs")
    assert {"a", "q_min", "d_ratio"} <= set(designs.columns) and designs["n_samples"].dtype == "int64"
    field = pq.read_schema(next((out / "dataset" / "best").glob("*.parquet"))).field("gdi")
    assert field.metadata[b"unit"] == b"1"
    # a unit that names a column ("volume_unit": the row's own unit) names one of the same table
    for table in ("best", "history", "designs"):
        schema = pq.read_schema(next((out / "dataset" / table).rglob("*.parquet")))
        for name in schema.names:
            unit = ((schema.field(name).metadata or {}).get(b"unit") or b"").decode()
            if unit.endswith("_unit"):
                assert unit in schema.names, (table, name, unit)
    assert set(designs.groupby("mechanism")["volume_unit"].first()) == {"cm³·rad", "mm·rad²", "mm²·rad", "mm²"}


def test_aggregating_again_by_any_path_changes_nothing(tmp_path):
    sweep = tmp_path / "sweep"
    for job, w in enumerate((0.0, 1.0)):
        make_run(sweep / str(job), tmp_path, "+experiment=rpr2_mixed", f"objective.w_d={w}", job=job)
    dataset = tmp_path / "dataset"
    first = aggregate(sweep, dataset)
    assert len(first.added) == 2
    before = snapshot(dataset)
    for source in (sweep, sweep / "0", tmp_path, [sweep, sweep / "1"]):
        again = aggregate(source, dataset)
        assert again.added == [] and len(again.present) >= 1
        assert snapshot(dataset) == before
    assert len(pd.read_parquet(dataset / "best")) == 2


def test_runs_with_the_same_folder_names_never_overwrite_each_other(tmp_path):
    dataset = tmp_path / "dataset"
    for sweep in ("sweep_a", "sweep_b"):  # both have a run "0" with the same w_d and config
        make_run(tmp_path / sweep / "0", tmp_path, "+experiment=rpr2_mixed", "objective.w_d=0.5")
        aggregate(tmp_path / sweep, dataset)
    best = pd.read_parquet(dataset / "best")
    assert len(best) == 2 and best["run_id"].is_unique
    assert best["config_hash"].nunique() == 1  # the same study, run twice: two rows, one hash
    assert best["study_hash"].nunique() == 1 and len(best["study_hash"].iloc[0]) == 16  # its study, from the manifest


def test_only_complete_runs_are_taken(tmp_path, caplog):
    sweep = tmp_path / "sweep"
    make_run(sweep / "0", tmp_path, "+experiment=rpr2_mixed")
    make_run(sweep / "1", tmp_path, "+experiment=rpr2_mixed", "objective.w_d=0.9", job=1)
    manifest_path = sweep / "1" / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    manifest["status"] = "running"  # e.g. killed before it finished its figures
    manifest_path.write_text(json.dumps(manifest))
    (sweep / "2").mkdir()  # a job that never started
    report = aggregate(sweep, tmp_path / "dataset")
    assert len(report.added) == 1 and len(report.skipped) == 1 and "running" in report.skipped[0]
    assert len(pd.read_parquet(tmp_path / "dataset" / "best")) == 1


def test_a_failure_midway_leaves_the_previous_dataset_intact(tmp_path, monkeypatch):
    dataset = tmp_path / "dataset"
    make_run(tmp_path / "s1" / "0", tmp_path, "+experiment=rpr2_mixed")
    aggregate(tmp_path / "s1", dataset)
    before = snapshot(dataset)
    make_run(tmp_path / "s2" / "0", tmp_path, "+experiment=h4_mixed")  # new columns: a schema change
    calls = {"n": 0}
    real = build_module.write_table

    def failing(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise RunError("cannot write: no space left on device")
        return real(*args, **kwargs)

    monkeypatch.setattr(build_module, "write_table", failing)
    with pytest.raises(RunError):
        aggregate(tmp_path / "s2", dataset)
    assert snapshot(dataset) == before
    assert not [
        p for p in tmp_path.iterdir() if p.name.startswith(".dataset.") and not p.name.endswith(".lock")
    ]  # no staging left
    monkeypatch.setattr(build_module, "write_table", real)
    aggregate(tmp_path / "s2", dataset)
    best = pd.read_parquet(dataset / "best")
    assert sorted(best["mechanism"]) == ["h4", "rpr2"] and {"q_min", "d_ratio"} <= set(best.columns)
    # every file of a table shares the unified schema (what makes pandas return all columns)
    schemas = {pq.read_schema(p).remove_metadata().to_string() for p in (dataset / "best").glob("*.parquet")}
    assert len(schemas) == 1


def test_rerunning_a_study_adds_a_row_and_replaces_nothing(tmp_path):
    dataset = tmp_path / "dataset"
    make_run(tmp_path / "first", tmp_path, "+experiment=rpr2_mixed")
    aggregate(tmp_path / "first", dataset)
    with pytest.raises(Exception, match="already holds run"):
        make_run(tmp_path / "first", tmp_path, "+experiment=rpr2_mixed", "objective.w_d=0.9")
    make_run(tmp_path / "second", tmp_path, "+experiment=rpr2_mixed", job=1)
    aggregate(tmp_path, dataset)
    runs = pd.read_parquet(dataset / "runs")
    assert len(runs) == 2 and runs["run_id"].is_unique and runs["launch_id"].eq(launch_id()).all()


def test_every_table_of_a_run_has_the_unit_columns_its_units_name(tmp_path):
    """A column whose unit is "volume_unit" or "objective_unit" (the row's own unit) has that column
    beside it, in the Pareto front's table too."""
    run = make_run(tmp_path / "run", tmp_path, "optimizer=nsga2", "mechanism=rpr2")
    for table in ("best", "history", "designs", "front"):
        schema = pq.read_schema(run / f"{table}.parquet")
        for name in schema.names:
            unit = ((schema.field(name).metadata or {}).get(b"unit") or b"").decode()
            if unit.endswith("_unit"):
                assert unit in schema.names, (table, name, unit)
    assert set(pd.read_parquet(run / "front.parquet")["volume_unit"]) == {"mm²"}
