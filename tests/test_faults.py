"""Fault and bad-input table through the real CLI (``python -m pipeline``), at tiny sizes.

Every case asserts the exit status, that stderr is one ``error:`` line with
no traceback, and what is on disk afterwards (nothing, or the earlier
results untouched). Cases that need a run to fail *during* computation
(disk full, a job failing mid-sweep, Ctrl-C) are at the end.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from tests.helpers import (
    ROOT,
    TINY,
    cmdline,
    files_under,
    one_error_line,
    processes_in_session,
    rpr2_evaluation_source,
    run_cli,
    run_python,
    session_ends,
    start_cli,
    start_python,
    wait_for_run,
)

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def existing_run(tmp_path_factory) -> Path:
    """A complete run made through the CLI, to check that nothing replaces it."""
    base = tmp_path_factory.mktemp("existing")
    run_dir = base / "run"
    proc = run_cli(["+experiment=rpr2_mixed", *TINY, f"paths.output_dir={base}", f"hydra.run.dir={run_dir}"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    return run_dir


# (case id, overrides, field named in the one-line error)
SINGLE_RUN_REFUSALS = [
    ("w_d above 1", ["objective.w_d=2"], "objective.w_d"),
    ("w_d below 0", ["objective.w_d=-0.1"], "objective.w_d"),
    ("w_d NaN", ["objective.w_d=nan"], "objective.w_d"),
    ("w_d inf", ["objective.w_d=inf"], "objective.w_d"),
    ("w_d not a number", ["objective.w_d=abc"], "objective.w_d"),
    ("unknown objective name", ["objective.name=speed"], "objective.name"),
    ("unknown objective option", ["objective=speed"], "objective/speed"),
    ("typo key w_d", ["+objective.wd=0.9"], "objective.wd"),
    ("unknown top-level key", ["+foo=1"], "foo"),
    ("misspelt key without +", ["evaluate.resolutoin=3"], "resolutoin"),
    ("unknown mechanism option", ["mechanism=stewart"], "mechanism/stewart"),
    ("unknown mechanism name", ["mechanism.name=stewart"], "mechanism.name"),
    ("schema is no option", ["mechanism=schema"], "mechanism/schema"),
    ("unknown optimizer option", ["optimizer=pso"], "optimizer/pso"),
    ("optimizer name without its group", ["optimizer.name=de"], "optimizer.name"),
    ("ga population 1", ["optimizer.population=1"], "optimizer.population"),
    ("ga generations 0", ["optimizer.generations=0"], "optimizer.generations"),
    ("selection q 0", ["optimizer.selection_q=0"], "optimizer.selection_q"),
    ("selection q above 1", ["optimizer.selection_q=1.5"], "optimizer.selection_q"),
    ("crossover rate negative", ["optimizer.crossover_rate=-0.1"], "optimizer.crossover_rate"),
    ("mutation rate 2", ["optimizer.mutation_rate=2"], "optimizer.mutation_rate"),
    ("mutation shape -1", ["optimizer.mutation_shape=-1"], "optimizer.mutation_shape"),
    ("mutation shape NaN", ["optimizer.mutation_shape=nan"], "optimizer.mutation_shape"),
    ("optimizer seed -1", ["optimizer.seed=-1"], "optimizer.seed"),
    ("optimizer seed too large", ["optimizer.seed=99999999999"], "optimizer.seed"),
    ("seed count 0", ["optimizer.seed_count=0"], "optimizer.seed_count"),
    ("de population 3", ["optimizer=de", "optimizer.population=3"], "optimizer.population"),
    ("de mutation 2.5", ["optimizer=de", "optimizer.mutation=2.5"], "optimizer.mutation"),
    ("cmaes sigma 0", ["optimizer=cmaes", "optimizer.sigma0=0"], "optimizer.sigma0"),
    ("cmaes budget 5", ["optimizer=cmaes", "optimizer.max_evaluations=5"], "optimizer.max_evaluations"),
    ("nsga2 same objective twice", ["optimizer=nsga2", "optimizer.objectives=[gdi,gdi]"], "optimizer.objectives"),
    ("nsga2 unknown objective", ["optimizer=nsga2", "optimizer.objectives=[gdi,speed]"], "optimizer.objectives"),
    ("polish budget 0", ["optimizer.polish_evaluations=0"], "optimizer.polish_evaluations"),
    ("sample seed -1", ["sample.seed=-1"], "sample.seed"),
    ("sample n 0", ["sample.n=0"], "sample.n"),
    ("resolution 1 (too coarse)", ["evaluate.resolution=1"], "evaluate.resolution"),
    ("resolution 0", ["evaluate.resolution=0"], "evaluate.resolution"),
    ("resolution 1e9 (memory)", ["evaluate.resolution=1000000000"], "evaluate.resolution"),
    ("resolution 10000 (node budget)", ["evaluate.resolution=10000"], "evaluate.resolution"),
    ("resolution over the time budget", ["evaluate.resolution=39", "evaluate.max_hours=0.01"], "evaluate.resolution"),
    ("rpr2 resolution below its minimum", ["mechanism=rpr2", "evaluate.resolution=20"], "evaluate.resolution"),
    ("refine factor 0", ["evaluate.refine_factor=0"], "evaluate.refine_factor"),
    ("refine factor 1 (an error bar of 0)", ["evaluate.refine_factor=1"], "evaluate.refine_factor"),
    ("unknown integration method", ["evaluate.method=foo"], "evaluate.method"),
    ("polar is no method of a run", ["evaluate.method=polar"], "evaluate.method"),
    ("max hours 0", ["evaluate.max_hours=0"], "evaluate.max_hours"),
    ("n_jobs 0", ["parallel.n_jobs=0"], "parallel.n_jobs"),
    ("unknown backend", ["parallel.backend=mpi"], "parallel.backend"),
    ("malformed scheduler address", ["parallel.scheduler_address=somewhere"], "parallel.scheduler_address"),
    (
        "unreachable dask scheduler",
        ["parallel.backend=dask", "parallel.scheduler_address=tcp://127.0.0.1:1"],
        "parallel.scheduler_address",
    ),
    ("experiment name escaping", ["experiment_name=a/../../x"], "experiment_name"),
    ("experiment name empty", ["experiment_name="], "experiment_name"),
    ("design bounds crossed", ["mechanism.design.lower=[0.2,0.01,0.35]"], "mechanism.design bounds of d_ratio"),
    ("design bounds length", ["mechanism.design.lower=[0.1]"], "mechanism.design.lower"),
    ("design names changed", ["mechanism.design.names=[a,b,c]"], "mechanism.design.names"),
    ("orientation reversed", ["mechanism.orientation=[10,-10]"], "mechanism.orientation"),
    ("dexterity limit 1", ["mechanism.min_inverse_condition=1"], "mechanism.min_inverse_condition"),
    ("homogenising length negative", ["mechanism.length=-1"], "mechanism.length"),
    ("stroke negative", ["mechanism.fixed.stroke=-5"], "mechanism.fixed"),
    ("tricept cone 200 deg", ["mechanism=tricept", "mechanism.fixed.cone=200"], "mechanism.fixed"),
    ("unknown fixed parameter", ["+mechanism.fixed.foo=1"], "mechanism.fixed.foo"),
    ("unknown H4 base reading", ["mechanism.fixed.base=bogus"], "mechanism.fixed"),
    ("plot dpi 10", ["plot.dpi=10"], "plot.dpi"),
    ("plot format gif", ["plot.format=gif"], "plot.format"),
    ("output dir unwritable", ["paths.output_dir=/sys/pm-design-test"], "paths.output_dir"),
    ("output dir empty (the cache would go to /cache)", ["paths.output_dir="], "paths.output_dir"),
    (
        "orientation of a mechanism without angles",
        ["mechanism=rpr2", "mechanism.orientation=[-10,10]"],
        "mechanism.orientation",
    ),
    ("run dir unwritable", ["hydra.run.dir=/sys/pm-design-run"], "hydra.run.dir"),
]


@pytest.mark.parametrize(
    "overrides, field", [c[1:] for c in SINGLE_RUN_REFUSALS], ids=[c[0] for c in SINGLE_RUN_REFUSALS]
)
def test_single_run_refusal(overrides, field, tmp_path):
    out = tmp_path / "out"
    proc = run_cli(["+experiment=h4_mixed", f"paths.output_dir={out}", *overrides])
    assert proc.returncode == 2, proc.stderr
    one_error_line(proc, field)
    assert files_under(out) == [] and not out.exists(), files_under(out)


@pytest.mark.parametrize("target", ["output_dir", "cache_dir", "dataset_dir"])
def test_path_that_is_a_file_is_refused(target, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    out = tmp_path / "out"
    args = [f"paths.output_dir={out}", f"paths.{target}={blocker}/sub"]
    proc = run_cli(["+experiment=h4_mixed", *TINY, *args])
    assert proc.returncode == 2
    one_error_line(proc, f"paths.{target}")
    assert blocker.read_text() == "not a directory" and not out.exists()


def test_dask_not_installed_is_one_line(tmp_path):
    """Run with an interpreter flag that hides the dask packages."""
    out = tmp_path / "out"
    shim = tmp_path / "shim"
    shim.mkdir()
    (shim / "sitecustomize.py").write_text(
        "import importlib.abc, sys\n"
        "class _Hide(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('distributed', 'dask'):\n"
        "            raise ModuleNotFoundError(f'No module named {name!r}', name=name)\n"
        "sys.meta_path.insert(0, _Hide())\n"
    )
    env = {**os.environ, "PYTHONPATH": str(shim)}
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline",
            "+experiment=h4_mixed",
            *TINY,
            f"paths.output_dir={out}",
            "parallel.backend=dask",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert proc.returncode == 2
    one_error_line(proc, "parallel.backend")
    assert not out.exists()


def test_reused_run_dir_is_refused_and_kept(existing_run, tmp_path):
    before = {p: p.read_bytes() for p in files_under(existing_run)}
    proc = run_cli(
        [
            "+experiment=rpr2_mixed",
            *TINY,
            f"paths.output_dir={tmp_path}",
            f"hydra.run.dir={existing_run}",
            "objective.w_d=0.9",
        ]
    )
    assert proc.returncode == 2
    one_error_line(proc, "hydra.run.dir")
    assert {p: p.read_bytes() for p in files_under(existing_run)} == before


def test_sweep_with_one_bad_job_is_refused_before_any_job_runs(tmp_path):
    out = tmp_path / "out"
    proc = run_cli(["-m", "+experiment=h4_mixed", *TINY, f"paths.output_dir={out}", "objective.w_d=0,2,1"])
    assert proc.returncode == 2
    err = one_error_line(proc, "job 1 (")
    assert "objective.w_d=2" in err
    assert files_under(out) == [], files_under(out)


def test_sweep_with_an_unknown_option_is_refused_before_any_job_runs(tmp_path):
    out = tmp_path / "out"
    proc = run_cli(["-m", "+experiment=h4_mixed", *TINY, f"paths.output_dir={out}", "mechanism=h4,stewart"])
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    assert not any(p.suffix == ".parquet" for p in files_under(out))


def test_reused_sweep_dir_is_refused(tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "old.txt").write_text("earlier sweep")
    proc = run_cli(
        [
            "-m",
            "+experiment=h4_mixed",
            *TINY,
            f"paths.output_dir={tmp_path}",
            f"hydra.sweep.dir={sweep}",
            "objective.w_d=0,1",
        ]
    )
    assert proc.returncode == 2
    one_error_line(proc, "hydra.sweep.dir")
    assert [p.name for p in sweep.iterdir()] == ["old.txt"]


@pytest.mark.parametrize(
    "args, pattern, code",
    [
        (["{missing}"], "source", 2),
        (["{run}", "--dataset", "{file}"], "--dataset", 2),
        (["{run}", "--dataset", "/sys/pm-design-dataset"], "--dataset", 2),
        (["{run}", "--dataset", "{foreign}"], "--dataset", 2),
    ],
)
def test_aggregate_cli_refusals(args, pattern, code, existing_run, tmp_path):
    file = tmp_path / "f.txt"
    file.write_text("x")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    values = {"missing": tmp_path / "nope", "run": existing_run, "file": file, "foreign": foreign}
    proc = run_cli([a.format(**values) for a in args], module="pipeline.stages.aggregate")
    assert proc.returncode == code
    one_error_line(proc, pattern)
    assert file.read_text() == "x" and [p.name for p in foreign.iterdir()] == ["notes.txt"]


# ------------------------------------------------- failures while computing
def test_ctrl_c_stops_with_one_line_and_no_workers_left(tmp_path):
    out = tmp_path / "out"
    proc = start_cli(
        [
            "+experiment=h4_mixed",
            f"paths.output_dir={out}",
            "sample.n=8",
            "optimizer.generations=100",
            "plot.enabled=false",
        ],
        interrupt=True,
    )
    # a stage finished (a cache entry): the GA is running
    manifest = wait_for_run(out, lambda out: bool(list((out / "cache").rglob("*.pkl"))))
    assert manifest is not None, "the run did not start"
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    errors = [ln for ln in stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "interrupted" in errors[0]
    assert json.loads(manifest.read_text())["status"] == "interrupted"
    assert not list(manifest.parent.glob("best.parquet"))
    time.sleep(1.0)
    assert processes_in_session(proc.pid) == []


@pytest.mark.parametrize("delay", [0.0, 0.05, 1.0, 2.0])
def test_ctrl_c_while_the_workers_start(delay, tmp_path):
    """Ctrl-C just as the fitness workers are starting, with an empty numba cache, so the
    main process is compiling the kernels meanwhile, as on a new machine. Before the
    fixes: a worker's own KeyboardInterrupt traceback (8 runs in 8), and a Ctrl-C that
    landed in llvmlite's compile callback was swallowed and the run went on."""
    proc = start_cli(
        ["+experiment=h4_mixed", f"paths.output_dir={tmp_path / 'out'}", "sample.n=8", "plot.enabled=false"],
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")},
        interrupt=True,
    )
    deadline = time.time() + 120
    while time.time() < deadline and not any(
        b"popen_loky_posix" in cmdline(pid) for pid in processes_in_session(proc.pid)
    ):
        time.sleep(0.005)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert [ln for ln in stderr.splitlines() if ln.startswith("error:")] == stderr.strip().splitlines()


def _hydra_main(monkeypatch, argv: list[str]) -> int:
    """Run the CLI's Hydra app in this process (to inject a fault); returns the exit code."""
    from pipeline.__main__ import main

    monkeypatch.setattr(sys, "argv", ["pipeline", *argv])
    try:
        main()
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def test_disk_full_marks_no_run_complete(monkeypatch, tmp_path, capsys):
    import pyarrow.parquet as pq

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pq, "write_table", full)
    out = tmp_path / "out"
    code = _hydra_main(
        monkeypatch, ["+experiment=rpr2_mixed", *TINY, f"paths.output_dir={out}", f"hydra.run.dir={out}/run"]
    )
    err = capsys.readouterr().err
    assert code == 1
    line = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(line) == 1 and "no space left on device" in line[0]
    manifest = json.loads((out / "run" / "manifest.json").read_text())
    assert manifest["status"] == "failed" and "no space left" in manifest["reason"]
    assert not list((out / "run").glob("*.parquet"))


def test_a_job_failing_at_run_time_does_not_lose_the_sweep(monkeypatch, tmp_path, capsys):
    import pipeline.study.compute as run_module

    real = run_module.optimise_design

    def flaky(
        mechanism, resolution, method, refine_factor, objective, optimizer, initial=None, reference=None, n_jobs=1
    ):
        if objective.w_d == 0.5:
            raise MemoryError("simulated out of memory")
        return real(mechanism, resolution, method, refine_factor, objective, optimizer, initial, reference, n_jobs)

    monkeypatch.setattr(run_module, "optimise_design", flaky)
    out = tmp_path / "out"
    code = _hydra_main(
        monkeypatch, ["-m", "+experiment=rpr2_mixed", *TINY, f"paths.output_dir={out}", "objective.w_d=0,0.5,1"]
    )
    err = capsys.readouterr().err
    assert code == 1
    line = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(line) == 1 and line[0].startswith("error: 2 of 3 jobs completed; failed: job 1")
    assert "MemoryError: simulated out of memory" in line[0]
    best = pd.read_parquet(out / "dataset" / "best")
    assert sorted(best["w_d"]) == [0.0, 1.0]
    statuses = sorted(json.loads(p.read_text())["status"] for p in out.rglob("manifest.json"))
    assert statuses == ["complete", "complete", "failed"]


def test_workers_never_see_ctrl_c(tmp_path):
    """Ctrl-C reaches the whole process group; the workers must leave it to the main process.

    A worker that gets SIGINT while still importing prints a traceback of its
    own (seen once in CI). Workers start with SIGINT blocked; the main thread's
    mask is restored after submitting.
    """
    script = tmp_path / "masks.py"
    script.write_text(
        rpr2_evaluation_source(40, 3) + "import signal\nfrom pipeline.evaluation.pool import worker_count\n"
        "def blocked(pid):\n"
        "    line = next(ln for ln in open(f'/proc/{pid}/status') if ln.startswith('SigBlk:'))\n"
        "    return bool(int(line.split()[1], 16) >> (signal.SIGINT - 1) & 1)\n"
        "pids = loky_pids()\n"
        "print(len(pids) == worker_count(3) - 1, all(blocked(p) for p in pids), "
        "signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []))\n"
    )
    proc = run_python([str(script)], timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "True", "False"]


def test_ctrl_c_during_kernel_compilation_is_deferred_not_lost(tmp_path):
    """Within sigint_deferred (around numba's compile) SIGINT is noted, not raised; it is
    raised once the block ends, through the usual handler."""
    script = tmp_path / "deferred.py"
    script.write_text(
        "import os, signal, time\n"
        "from pipeline.evaluation.pool import sigint_deferred\n"
        "try:\n"
        "    with sigint_deferred():\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        time.sleep(0.2)\n"
        "        print('block finished', flush=True)\n"
        "    print('not interrupted', flush=True)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted after the block', flush=True)\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n"
    )
    proc = run_python([str(script)], timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[:3] == ["block finished", "interrupted after the block", "True"]


def test_workers_of_a_killed_run_exit(tmp_path):
    """SIGKILL (the OOM killer) leaves the fitness workers orphaned: they must not live on.

    Each worker watches its parent (pipeline.evaluation.pool.start_worker) and exits once orphaned.
    """
    script = tmp_path / "killed.py"
    script.write_text(
        rpr2_evaluation_source(40, 2) + "print(os.getpid(), *loky_pids(), flush=True)\nos.kill(os.getpid(), 9)\n"
    )
    # the workers inherit the pipes, so wait for the process, not for the end of its output
    proc = start_python([str(script)], stderr=subprocess.DEVNULL)
    session, *worker_pids = map(int, proc.stdout.readline().split())  # the killed process led its own session
    assert len(worker_pids) == 1  # n_jobs=2: this process and one worker
    assert proc.wait(timeout=120) == -signal.SIGKILL
    assert session_ends(session, seconds=30)
    proc.stdout.close()
