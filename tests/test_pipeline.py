"""The Hydra pipeline end to end: configs from the real conf/ via the compose API, tiny sizes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from pipeline.config import CONFIG_DIR, Config, register_configs, validate
from pipeline.errors import ConfigError
from pipeline.stages.evaluate import evaluate_designs
from pipeline.stages.optimise import optimiser_run
from pipeline.stages.sample import sample_designs
from pipeline.store.cache import cached
from pipeline.store.parquet import read_metadata
from pipeline.study import run_study

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CONF = CONFIG_DIR
EXPERIMENTS = sorted(p.stem for p in (CONF / "experiment").glob("*.yaml"))


#: tiny budgets per optimiser (each has its own config fields)
TINY_OPTIMIZER = {
    "ga": ["optimizer.population=4", "optimizer.generations=2"],
    "de": ["optimizer.population=5", "optimizer.generations=2", "optimizer.polish_evaluations=10"],
    "cmaes": ["optimizer.max_evaluations=12", "optimizer.polish_evaluations=10"],
    "nsga2": ["optimizer.population=4", "optimizer.generations=2"],
}


def experiment_optimizer(experiment: str) -> str:
    text = (CONF / "experiment" / f"{experiment}.yaml").read_text()
    for name in TINY_OPTIMIZER:
        if f"override /optimizer: {name}" in text:
            return name
    return "ga"


def tiny(tmp_path: Path, *extra: str, optimizer: str = "ga") -> list[str]:
    return ["+debug=fast", *TINY_OPTIMIZER[optimizer], f"paths.output_dir={tmp_path}", *extra]


def make_cfg(overrides: list[str]):
    register_configs()
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        return compose(config_name="config", overrides=overrides)


def test_experiments_exist():
    assert {"h4_max_volume", "h4_max_gdi", "h4_mixed", "tricept_max_volume"} <= set(EXPERIMENTS)
    assert any(e.startswith("rpr3") for e in EXPERIMENTS) and any(e.startswith("rpr2") for e in EXPERIMENTS)


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_each_experiment_runs_end_to_end(experiment, tmp_path):
    cfg = make_cfg([f"+experiment={experiment}", *tiny(tmp_path, optimizer=experiment_optimizer(experiment))])
    paths = run_study(cfg, tmp_path / "run")
    best = pd.read_parquet(paths["best"])
    assert len(best) == 1 and best["experiment"].iloc[0] == experiment
    history = pd.read_parquet(paths["history"])
    assert list(history["generation"]) == list(range(len(history))) and len(history) >= 2
    designs = pd.read_parquet(paths["designs"])
    assert len(designs) == 4
    for frame in (best, history, designs):
        assert frame["w_d"].dtype == "float64"
        assert str(frame["mechanism"].dtype) in ("str", "string")
        numeric_as_object = [c for c in frame.columns if frame[c].dtype == object]
        assert not numeric_as_object
    meta = read_metadata(paths["best"])
    assert meta["config"]["experiment_name"] == experiment
    assert meta["version"] and meta["git_commit"]
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["status"] == "complete" and manifest["config"]["experiment_name"] == experiment


def test_results_schema_and_refined_evaluation(tmp_path):
    cfg = make_cfg(["+experiment=h4_mixed", *tiny(tmp_path)])
    paths = run_study(cfg, tmp_path / "run")
    best = pd.read_parquet(paths["best"]).iloc[0]
    for column in (
        "d_ratio",
        "h_ratio",
        "Qz_ratio",
        "param_d_cm",
        "param_h_cm",
        "param_Qz_cm",
        "param_base",
        "volume",
        "gdi",
        "suri",
        "objective_value",
        "volume_refined",
        "gdi_refined",
        "objective_value_refined",
        "optimizer_value",
        "found_by",
        "reference_gap",
        "flat_variables",
        "d_ratio_flat_lower",
        "volume_unit",
        "at_bounds",
    ):
        assert column in best.index
    for redundant in ("wd", "fitness", "eta", "inverse_condition_mean", "volume_error", "gdi_error"):
        assert redundant not in best.index
    assert best["objective_value"] == pytest.approx(0.5 * best["gdi"] + 0.5 * best["suri"])
    assert best["param_d_cm"] == pytest.approx(100 * best["d_ratio"])
    assert best["volume_unit"] == "cm³·rad" and best["param_base"] == "scaled"
    schema = pq.read_schema(paths["best"])
    stored = json.loads(schema.metadata[b"pm_design.config"])
    assert "parallel" not in stored and stored["objective"]["w_d"] == 0.5
    assert schema.field("volume").metadata[b"unit"] == b"volume_unit"
    assert schema.field("d_ratio").metadata[b"unit"] == b"d / stroke"
    # every column is documented (pipeline.store.parquet.COLUMNS, docs/configuration.md), the
    # per-variable ones (<var>_reference, <var>_flat_lower, ...) with their variable's unit
    assert not [f.name for f in schema if not f.metadata[b"description"]]
    for name in ("d_ratio", "h_ratio", "Qz_ratio"):
        for suffix in ("_reference", "_flat_lower", "_flat_upper"):
            assert schema.field(name + suffix).metadata[b"unit"] == schema.field(name).metadata[b"unit"]


def test_figures_are_written(tmp_path):
    cfg = make_cfg(["+experiment=rpr3_mixed", *tiny(tmp_path, "plot.enabled=true")])
    paths = run_study(cfg, tmp_path / "run")
    for name in ("convergence", "workspace", "inverse_condition"):
        assert paths[name].stat().st_size > 5_000


# ---------------------------------------------------------------- caching
def test_cache_hits_checked_with_joblibs_api(tmp_path):
    overrides = ["+experiment=h4_mixed", *tiny(tmp_path)]
    c = validate(make_cfg(overrides))
    cache = c.paths.cache_dir
    designs_args = (c.mechanism.design, c.sample)
    assert not cached(sample_designs, cache).check_call_in_cache(*designs_args)
    run_study(make_cfg(overrides), tmp_path / "a")
    designs = cached(sample_designs, cache)(*designs_args)
    grid = (c.evaluate.resolution, c.evaluate.method)
    optimise_args = (c.mechanism, *grid, c.objective, c.optimizer, None)
    assert cached(sample_designs, cache).check_call_in_cache(*designs_args)
    assert cached(evaluate_designs, cache).check_call_in_cache(c.mechanism, *grid, designs)
    assert cached(optimiser_run, cache).check_call_in_cache(*optimise_args)
    # a new w_d reruns only the optimiser; n_jobs is not part of any key
    other = validate(make_cfg([*overrides, "objective.w_d=0.75", "parallel.n_jobs=2"]))
    assert not cached(optimiser_run, cache).check_call_in_cache(
        other.mechanism, *grid, other.objective, other.optimizer, None
    )
    assert cached(evaluate_designs, cache).check_call_in_cache(other.mechanism, *grid, designs, n_jobs=2)
    run_study(make_cfg(overrides), tmp_path / "b")
    for table in ("best", "history", "designs"):
        assert (tmp_path / "a" / f"{table}.parquet").read_bytes() == (tmp_path / "b" / f"{table}.parquet").read_bytes()


@pytest.mark.parametrize("method", ["grid", "midpoint"])
def test_the_integration_method_is_the_runs_and_recorded(method, tmp_path):
    """``evaluate.method`` reaches every evaluation of the run and is recorded beside the resolution."""
    from kinematics.workspace import evaluate
    from pipeline.evaluation import DesignEvaluator
    from pipeline.objectives import EVALUATION_FIELDS

    overrides = ["+experiment=h4_mixed", *tiny(tmp_path, f"evaluate.method={method}")]
    c = validate(make_cfg(overrides))
    assert c.evaluate.method == method
    paths = run_study(make_cfg(overrides), tmp_path / "run")
    best = pd.read_parquet(paths["best"]).iloc[0]
    assert best["method"] == method and best["resolution"] == 4
    assert read_metadata(paths["best"])["config"]["evaluate"]["method"] == method
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["status"] == "complete" and manifest["config"]["evaluate"]["method"] == method
    # the sampled designs' numbers are the evaluator's with that method, the optimum's too
    designs = pd.read_parquet(paths["designs"])
    rows = DesignEvaluator(c.mechanism, 4, 1, method).evaluate(designs[c.mechanism.design.names].to_numpy())
    assert designs["volume"].tolist() == rows[:, EVALUATION_FIELDS.index("volume")].tolist()
    x = best[c.mechanism.design.names].to_numpy(float)
    options = c.mechanism.evaluation_options()
    ev = evaluate(c.mechanism.build(x), resolution=4, method=method, error_estimate=False, **options)
    refined = evaluate(c.mechanism.build(x), resolution=8, method=method, error_estimate=False, **options)
    assert (best["volume"], best["gdi"]) == (ev.volume, ev.gdi)
    assert (best["volume_refined"], best["gdi_refined"]) == (refined.volume, refined.gdi)


def test_a_midpoint_result_is_never_reused_for_a_grid_run(tmp_path):
    grid = ["+experiment=h4_mixed", *tiny(tmp_path, "optimizer.reference=true")]  # the default method: grid
    midpoint = [*grid, "evaluate.method=midpoint"]
    assert validate(make_cfg(grid)).evaluate.method == "grid"
    run_study(make_cfg(midpoint), tmp_path / "midpoint")
    run_study(make_cfg(grid), tmp_path / "grid")
    stages = json.loads((tmp_path / "grid" / "manifest.json").read_text())["stages"]
    assert stages == {
        "sample": "cached",
        "evaluate": "computed",
        "reference": "computed",
        "optimise": "computed",
        "refine": "computed",
    }
    by_method = {m: pd.read_parquet(tmp_path / m / "best.parquet").iloc[0] for m in ("grid", "midpoint")}
    assert {m: row["method"] for m, row in by_method.items()} == {"grid": "grid", "midpoint": "midpoint"}
    assert by_method["grid"]["config_hash"] != by_method["midpoint"]["config_hash"]
    # the same method again: every stage from the cache
    run_study(make_cfg(midpoint), tmp_path / "midpoint_again")
    again = json.loads((tmp_path / "midpoint_again" / "manifest.json").read_text())["stages"]
    assert set(again.values()) == {"cached"}


def test_cache_key_covers_every_source_file():
    import pipeline
    from pipeline.store import cache

    files = {p.name for p in Path(pipeline.__file__).parent.rglob("*.py")}
    assert {"plot.py", "ga.py", "cmaes.py", "aggregate.py"} <= files  # no hand-kept list
    assert cache.CODE_VERSION.split("+")[1] == cache._source_digest()


def test_same_config_bit_identical_whatever_the_workers(tmp_path):
    one = run_study(make_cfg(["+experiment=h4_mixed", *tiny(tmp_path / "w1")]), tmp_path / "one")
    two = run_study(make_cfg(["+experiment=h4_mixed", *tiny(tmp_path / "w2", "parallel.n_jobs=2")]), tmp_path / "two")
    for table in ("best", "history", "designs"):
        assert one[table].read_bytes() == two[table].read_bytes()


def test_dask_backend_on_a_local_cluster(tmp_path):
    from dask.distributed import LocalCluster

    loky = run_study(make_cfg(["+experiment=rpr2_mixed", *tiny(tmp_path / "loky")]), tmp_path / "loky_run")
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        cfg = make_cfg(
            [
                "+experiment=rpr2_mixed",
                *tiny(
                    tmp_path / "dask",
                    "parallel.backend=dask",
                    "parallel.n_jobs=2",
                    f"parallel.scheduler_address={cluster.scheduler_address}",
                ),
            ]
        )
        dask = run_study(cfg, tmp_path / "dask_run")
    assert loky["best"].read_bytes() == dask["best"].read_bytes()


# ------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "override, field",
    [
        ("objective.w_d=1.5", "objective.w_d"),
        ("mechanism.design.lower=[0.2,0.01,0.35]", "mechanism.design bounds of d_ratio"),
        ("mechanism.name=stewart", "mechanism.name"),
        ("evaluate.resolution=0", "evaluate.resolution"),
        ("evaluate.method=foo", "evaluate.method"),
        ("parallel.n_jobs=0", "parallel.n_jobs"),
        ("objective.name=speed", "objective.name"),
        ("optimizer.name=pso", "optimizer.name"),
        ("parallel.backend=mpi", "parallel.backend"),
    ],
)
def test_out_of_range_values_fail_with_one_line(override, field, tmp_path):
    cfg = make_cfg(["+experiment=h4_mixed", *tiny(tmp_path), override])
    with pytest.raises(ConfigError) as err:
        run_study(cfg, tmp_path / "run")
    message = str(err.value)
    assert "\n" not in message and message.startswith(field) and "allowed" in message
    assert not (tmp_path / "run").exists()


def test_types_are_checked_by_the_schema(tmp_path):
    with pytest.raises(Exception, match="w_d"):
        make_cfg(["objective.w_d=abc", *tiny(tmp_path)])
    with pytest.raises(Exception, match="resolutoin"):
        make_cfg(["evaluate.resolutoin=3", *tiny(tmp_path)])


def test_validate_returns_typed_objects(tmp_path):
    cfg = make_cfg(["+experiment=tricept_max_volume", *tiny(tmp_path)])
    typed = validate(cfg)
    assert isinstance(typed, Config) and typed.mechanism.name == "tricept"
    assert type(typed.optimizer).__name__ == "GAConfig"
    from kinematics.tricept import Tricept

    assert typed.mechanism.fixed == Tricept.default_fixed and typed.mechanism.fixed["cone"] == 60.0
    assert OmegaConf.is_config(cfg)


def test_mechanism_options_come_from_the_classes():
    from kinematics import MECHANISMS

    for name, cls in MECHANISMS.items():
        c = validate(make_cfg([f"mechanism={name}", "+debug=fast"]))
        assert c.mechanism.design.names == [v.name for v in cls.design_variables]
        assert c.mechanism.fixed == cls.default_fixed
    with pytest.raises(Exception, match="schema"):
        make_cfg(["mechanism=schema"])


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "pipeline", *args], cwd=cwd, capture_output=True, text=True, timeout=600
    )


def test_cli_multirun_aggregates_a_w_d_sweep(tmp_path):
    out = tmp_path / "outputs"
    proc = run_cli(["-m", "+experiment=h4_mixed", "objective.w_d=0,0.5,1", *tiny(out)], ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    best = pd.read_parquet(out / "dataset" / "best")
    assert len(best) == 3
    assert best["w_d"].dtype == "float64" and sorted(best["w_d"]) == [0.0, 0.5, 1.0]
    assert str(best["mechanism"].dtype) in ("str", "string")
    assert not [c for c in best.columns if best[c].dtype == object]
    history = pd.read_parquet(out / "dataset" / "history")
    assert history.groupby("run_id").size().tolist() == [3, 3, 3]
    sweeps = list((out / "sweeps" / "h4_mixed").iterdir())
    assert len(sweeps) == 1 and (sweeps[0] / "tradeoff.png").stat().st_size > 5_000
    assert "3 of 3 jobs completed" in proc.stderr + proc.stdout


def test_cli_multirun_over_mechanisms(tmp_path):
    out = tmp_path / "outputs"
    proc = run_cli(["-m", "objective.name=mixed", "objective.w_d=0,1", "mechanism=h4,rpr2", *tiny(out)], ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    best = pd.read_parquet(out / "dataset" / "best")
    assert sorted(zip(best["mechanism"].astype(str), best["w_d"])) == [
        ("h4", 0.0),
        ("h4", 1.0),
        ("rpr2", 0.0),
        ("rpr2", 1.0),
    ]
