"""Scale-out exercised: the same small sweep through every launcher gives the same dataset.

``hydra/launcher=submitit_local`` runs the code path of ``submitit_slurm``
(submitit pickles each job and runs it in its own process); Hydra's joblib
launcher runs jobs side by side; ``parallel.backend=dask`` sends the fitness
evaluations to a dask ``LocalCluster``. Each sweep must land in one sweep
directory and give, table by table, the basic launcher's dataset except the
columns that name the launch (ids, wall time, the launcher's own overrides).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
SWEEP = [
    "+experiment=rpr2_mixed",
    "+debug=fast",
    "optimizer.population=4",
    "optimizer.generations=2",
    "objective.w_d=0,1",
]
#: columns that describe the launch, not the result
LAUNCH_COLUMNS = {"run_id", "launch_id", "wall_time", "overrides", "source"}
TABLES = ("best", "history", "designs", "runs")
LAUNCHERS = {
    "joblib": ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2", "parallel.n_jobs=1"],
    "submitit_local": ["hydra/launcher=submitit_local", "parallel.n_jobs=1"],
    "dask_local_cluster": ["parallel.backend=dask", "parallel.n_jobs=2"],
    # a LocalCluster inside the joblib launcher's loky workers: every job failed ("Nanny failed to
    # start": the spawned nanny could not look up loky's start method)
    "joblib_with_dask": [
        "hydra/launcher=joblib",
        "hydra.launcher.n_jobs=2",
        "parallel.backend=dask",
        "parallel.n_jobs=2",
    ],
}


def sweep(out: Path, extra: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "pipeline", "-m", *SWEEP, *extra, f"paths.output_dir={out}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def read_tables(dataset: Path) -> dict[str, pd.DataFrame]:
    tables = {}
    for table in TABLES:
        frame = pd.read_parquet(dataset / table)
        keys = (
            ["config_hash"]
            + (["generation"] if "generation" in frame else [])
            + (["sample_index"] if "sample_index" in frame else [])
        )
        frame = frame.drop(columns=[c for c in LAUNCH_COLUMNS if c in frame])
        tables[table] = frame.sort_values(keys).reset_index(drop=True)
    return tables


@pytest.fixture(scope="module")
def basic(tmp_path_factory) -> dict[str, pd.DataFrame]:
    out = tmp_path_factory.mktemp("basic")
    proc = sweep(out, [])
    assert proc.returncode == 0, proc.stderr[-3000:]
    return read_tables(out / "dataset")


@pytest.mark.parametrize("launcher", sorted(LAUNCHERS))
def test_sweep_through_launcher_gives_the_basic_launchers_dataset(launcher, basic, tmp_path):
    proc = sweep(tmp_path, LAUNCHERS[launcher])
    assert proc.returncode == 0, proc.stderr[-3000:]
    sweeps = list((tmp_path / "sweeps" / "rpr2_mixed").iterdir())
    assert len(sweeps) == 1, sweeps  # every job in the one sweep directory
    jobs = sorted(p.name.split("_", 1)[0] for p in sweeps[0].iterdir() if (p / "manifest.json").exists())
    assert jobs == ["0", "1"]
    tables = read_tables(tmp_path / "dataset")
    for table in TABLES:
        assert len(tables[table]) > 0
        pd.testing.assert_frame_equal(tables[table], basic[table], check_exact=True, obj=table)


# The sweeper used to refuse jobs side by side x parallel.n_jobs > cores, guessing the launcher from
# its class name (a private-API guess, issue 22). Now each run caps its own worker count at the cores
# it may use (tests/test_pool.py); what stays is that every job of every batch is checked first.
def test_a_bad_job_in_a_later_batch_is_refused_before_the_first_batch_runs(tmp_path):
    proc = sweep(
        tmp_path,
        [
            "hydra/launcher=joblib",
            "hydra.launcher.n_jobs=2",
            "parallel.n_jobs=1",
            "hydra.sweeper.max_batch_size=1",
            "objective.w_d=0,1,2",
        ],
    )
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip()
    assert "Traceback" not in err and "\n" not in err, err
    assert err.startswith("error: job 2 (") and "objective.w_d=2" in err, err
    assert not any(p.is_file() for p in tmp_path.rglob("*"))


def test_slurm_jobs_are_checked_before_submitting(tmp_path):
    proc = sweep(tmp_path, ["hydra/launcher=submitit_slurm", "hydra.launcher.cpus_per_task=1", "objective.w_d=0,2"])
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert err.startswith("error: job 1 (") and "objective.w_d=2" in err, err
    assert not any(p.is_file() for p in tmp_path.rglob("*"))


@pytest.mark.skipif(shutil.which("srun") is not None, reason="this machine has SLURM")
def test_slurm_without_slurm_is_one_line_and_writes_nothing(tmp_path):
    """docs/pipeline.md's SLURM command on a machine without SLURM: one line naming the launcher
    and what is allowed, nothing written (submitit raised a 39-line traceback after writing
    multirun.yaml)."""
    proc = sweep(tmp_path, ["hydra/launcher=submitit_slurm", "hydra.launcher.partition=YOUR_PARTITION"])
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert err.startswith("error: hydra/launcher=submitit_slurm is invalid here: no SLURM"), err
    assert not any(p.is_file() for p in tmp_path.rglob("*"))


def test_an_unusable_sweep_dir_is_one_line_exit_2_and_writes_nothing(tmp_path):
    """As hydra.run.dir: a sweep folder that cannot be created (under a regular file; root writes
    anywhere else) is refused before Hydra starts, not by the sweeper's mkdir (exit 1)."""
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    proc = sweep(tmp_path / "out", [f"hydra.sweep.dir={not_a_folder / 'sw'}"])
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert err.startswith(f"error: hydra.sweep.dir='{not_a_folder / 'sw'}' is invalid: "), err
    assert err.endswith("allowed: a writable directory"), err
    assert [p.name for p in tmp_path.iterdir()] == ["file"]
