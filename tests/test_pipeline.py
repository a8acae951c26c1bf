"""The Hydra pipeline end to end: configs from the real conf/ via the compose API, tiny sizes."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from pipeline.aggregate import aggregate
from pipeline.aggregate import main as aggregate_main
from pipeline.config import ConfigError, register_configs, validate
from pipeline.io import read_metadata
from pipeline.run import run_study

ROOT = Path(__file__).resolve().parents[1]
CONF = ROOT / "conf"
EXPERIMENTS = sorted(p.stem for p in (CONF / "experiment").glob("*.yaml"))


def tiny(tmp_path: Path, *extra: str) -> list[str]:
    return ["sample.n=4", "optimizer.population=4", "optimizer.generations=2",
            "evaluate.resolution=4", "evaluate.refine_factor=2", "plot.enabled=false",
            "parallel.n_jobs=1", f"paths.output_dir={tmp_path}", *extra]


def make_cfg(overrides: list[str]):
    register_configs()
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        return compose(config_name="config", overrides=overrides)


def test_experiments_exist():
    assert {"h4_max_volume", "h4_max_gdi", "h4_mixed", "tricept_max_volume"} <= set(EXPERIMENTS)
    assert any(e.startswith("rpr3") for e in EXPERIMENTS) and any(e.startswith("rpr2") for e in EXPERIMENTS)


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_each_experiment_runs_end_to_end(experiment, tmp_path):
    cfg = make_cfg([f"+experiment={experiment}", *tiny(tmp_path)])
    paths = run_study(cfg, tmp_path / "run")
    best = pd.read_parquet(paths["best"])
    assert len(best) == 1 and best["experiment"].iloc[0] == experiment
    history = pd.read_parquet(paths["history"])
    assert list(history["generation"]) == [0, 1, 2]
    designs = pd.read_parquet(paths["designs"])
    assert len(designs) == 4
    for frame in (best, history, designs):
        assert frame["w_d"].dtype == "float64"
        assert str(frame["mechanism"].dtype) == "string"
        numeric_as_object = [c for c in frame.columns if frame[c].dtype == object]
        assert not numeric_as_object
    meta = read_metadata(paths["best"])
    assert meta["config"]["experiment_name"] == experiment
    assert meta["version"] and meta["git_commit"]
    assert (tmp_path / "run" / "config.yaml").exists()


def test_results_schema_and_refined_evaluation(tmp_path):
    cfg = make_cfg(["+experiment=h4_mixed", *tiny(tmp_path)])
    paths = run_study(cfg, tmp_path / "run")
    best = pd.read_parquet(paths["best"]).iloc[0]
    for column in ("d_ratio", "h_ratio", "Qz_ratio", "param_d", "param_h", "param_Qz", "volume", "gdi",
                   "suri", "eta", "fitness", "volume_refined", "gdi_refined", "eta_refined",
                   "volume_change_refined"):
        assert column in best.index
    assert best["eta"] == pytest.approx(0.5 * best["gdi"] + 0.5 * best["suri"])
    assert best["fitness"] == pytest.approx(best["eta"])
    assert best["param_d"] == pytest.approx(100 * best["d_ratio"])
    schema = pq.read_schema(paths["best"])
    stored = json.loads(schema.metadata[b"pm_design.config"])
    assert "parallel" not in stored and stored["objective"]["w_d"] == 0.5


def test_figures_are_written(tmp_path):
    cfg = make_cfg(["+experiment=rpr3_mixed", *tiny(tmp_path, "plot.enabled=true")])
    paths = run_study(cfg, tmp_path / "run")
    for name in ("convergence", "workspace", "inverse_condition"):
        assert paths[name].stat().st_size > 5_000


# ---------------------------------------------------------------- caching
def computed_stages(caplog) -> list[str]:
    return [r.getMessage().split(":")[0] for r in caplog.records if ": computing" in r.getMessage()]


def test_cache_second_run_recomputes_nothing(tmp_path, caplog):
    overrides = ["+experiment=h4_mixed", *tiny(tmp_path)]
    with caplog.at_level(logging.INFO):
        run_study(make_cfg(overrides), tmp_path / "a")
        assert computed_stages(caplog) == ["sample", "evaluate", "optimise"]
        caplog.clear()
        run_study(make_cfg(overrides), tmp_path / "b")
        assert computed_stages(caplog) == []
        caplog.clear()
        run_study(make_cfg([*overrides, "objective.w_d=0.75"]), tmp_path / "c")
        assert computed_stages(caplog) == ["optimise"]
        caplog.clear()
        run_study(make_cfg([*overrides, "evaluate.resolution=5"]), tmp_path / "d")
        assert computed_stages(caplog) == ["evaluate", "optimise"]
    a = pd.read_parquet(tmp_path / "a" / "best.parquet")
    b = pd.read_parquet(tmp_path / "b" / "best.parquet")
    pd.testing.assert_frame_equal(a, b)


def test_same_config_bit_identical_whatever_the_workers(tmp_path):
    one = run_study(make_cfg(["+experiment=h4_mixed", *tiny(tmp_path / "w1")]), tmp_path / "one")
    two = run_study(make_cfg(["+experiment=h4_mixed", *tiny(tmp_path / "w2", "parallel.n_jobs=2")]),
                    tmp_path / "two")
    for table in ("best", "history", "designs"):
        assert one[table].read_bytes() == two[table].read_bytes()


def test_dask_backend_on_a_local_cluster(tmp_path):
    from dask.distributed import LocalCluster

    loky = run_study(make_cfg(["+experiment=rpr2_mixed", *tiny(tmp_path / "loky")]), tmp_path / "loky_run")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        cfg = make_cfg(["+experiment=rpr2_mixed", *tiny(tmp_path / "dask", "parallel.backend=dask",
                                                        "parallel.n_jobs=2",
                                                        f"parallel.scheduler_address={cluster.scheduler_address}")])
        dask = run_study(cfg, tmp_path / "dask_run")
    assert loky["best"].read_bytes() == dask["best"].read_bytes()


# ------------------------------------------------------------- validation
@pytest.mark.parametrize("override, field", [
    ("objective.w_d=1.5", "objective.w_d"),
    ("mechanism.design.lower=[0.2,0.01,0.35]", "mechanism.design bounds of d_ratio"),
    ("mechanism.name=delta", "mechanism.name"),
    ("evaluate.resolution=0", "evaluate.resolution"),
    ("parallel.n_jobs=0", "parallel.n_jobs"),
    ("objective.name=speed", "objective.name"),
    ("optimizer.name=pso", "optimizer.name"),
    ("parallel.backend=mpi", "parallel.backend"),
])
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


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pipeline", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=600)


def test_cli_rejects_bad_values_without_writing(tmp_path):
    out = tmp_path / "outputs"
    for bad in ("objective.w_d=2", "mechanism=delta", "objective.w_d=abc", "parallel.n_jobs=0"):
        proc = run_cli(["+experiment=h4_mixed", f"paths.output_dir={out}", bad], ROOT)
        assert proc.returncode != 0, bad
        assert "Traceback" not in proc.stderr, proc.stderr
        assert not out.exists() or not any(p.is_file() for p in out.rglob("*")), list(out.rglob("*"))
    proc = run_cli(["+experiment=h4_mixed", f"paths.output_dir={out}", "objective.w_d=2"], ROOT)
    assert proc.stderr.strip() == "error: objective.w_d=2.0 is invalid: allowed [0, 1]"


def test_cli_multirun_aggregates_a_w_d_sweep(tmp_path):
    out = tmp_path / "outputs"
    proc = run_cli(["-m", "+experiment=h4_mixed", "objective.w_d=0,0.5,1", *tiny(out)], ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    best = pd.read_parquet(out / "dataset" / "best")
    assert len(best) == 3
    assert best["w_d"].dtype == "float64" and sorted(best["w_d"]) == [0.0, 0.5, 1.0]
    assert str(best["mechanism"].dtype) in ("category", "string")
    assert not [c for c in best.columns if best[c].dtype == object]
    history = pd.read_parquet(out / "dataset" / "history")
    assert history.groupby("run").size().tolist() == [3, 3, 3]
    sweeps = list((out / "sweeps" / "h4_mixed").iterdir())
    assert len(sweeps) == 1 and (sweeps[0] / "tradeoff.png").stat().st_size > 5_000


def test_cli_multirun_over_mechanisms(tmp_path):
    out = tmp_path / "outputs"
    proc = run_cli(["-m", "objective.name=mixed", "objective.w_d=0,1", "mechanism=h4,rpr2",
                    *tiny(out)], ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    best = pd.read_parquet(out / "dataset" / "best")
    assert sorted(zip(best["mechanism"].astype(str), best["w_d"])) == [
        ("h4", 0.0), ("h4", 1.0), ("rpr2", 0.0), ("rpr2", 1.0)]


def test_aggregate_runs_on_its_own(tmp_path):
    sweep = tmp_path / "sweep"
    for k, w in enumerate((0.25, 0.75)):
        run_study(make_cfg(["+experiment=rpr2_mixed", *tiny(tmp_path), f"objective.w_d={w}"]), sweep / str(k))
    assert aggregate_main([str(sweep), "--dataset", str(tmp_path / "ds")]) == 0
    best = pd.read_parquet(tmp_path / "ds" / "best")
    assert sorted(best["w_d"]) == [0.25, 0.75]
    # idempotent: aggregating again overwrites the sweep's own files
    aggregate(sweep, tmp_path / "ds")
    assert len(pd.read_parquet(tmp_path / "ds" / "best")) == 2
    assert aggregate_main([str(tmp_path / "nothing"), "--dataset", str(tmp_path / "ds2")]) == 2


def test_validate_returns_a_plain_dict(tmp_path):
    cfg = make_cfg(["+experiment=tricept_max_volume", *tiny(tmp_path)])
    plain = validate(cfg)
    assert isinstance(plain, dict) and plain["mechanism"]["name"] == "tricept"
    assert OmegaConf.is_config(cfg)
