"""Fault injection for the 17 items of issue 25: values, paths, signals, corruption, concurrency,
scale-out, injection. Each case asserts the exit status or exception, the one ``error:`` line, and
what is left on disk (the manifest's final state, the dataset's tables, files outside the output).

Items are named in each test's name (``item01`` ... ``item17``). Cases that need a run through
the CLI to be interrupted or a cluster are in the slow tier.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import textwrap
import time
import tomllib
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from joblib import parallel_config
from omegaconf import OmegaConf

from kinematics import MECHANISMS
from pipeline.config import CONFIG_DIR, ConfigError, guard, register_configs
from pipeline.errors import RunError, interrupt_in
from pipeline.stages.aggregate import aggregate
from pipeline.store.checksums import REGISTRY
from tests.helpers import ROOT, TINY, files_under, one_error_line, run_cli, run_python, start_cli, wait_for_run


def compose_cfg(*overrides: str, hydra: bool = False):
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        return compose(config_name="config", overrides=list(overrides), return_hydra_config=hydra)


def make_run(run_dir: Path, out: Path, *overrides: str, job: int = 0) -> Path:
    from pipeline.study import run_study

    run_study(compose_cfg(*TINY, f"paths.output_dir={out}", *overrides), run_dir, job=job)
    return run_dir


@pytest.fixture(scope="module")
def one_run(tmp_path_factory) -> Path:
    """A complete tiny run, copied by the tests that damage runs."""
    base = tmp_path_factory.mktemp("one_run")
    return make_run(base / "run", base, "+experiment=rpr2_mixed")


def copy_run(source: Path, target: Path, suffix: str) -> Path:
    """A copy of a run under another run id (a second run without computing it)."""
    shutil.copytree(source, target)
    manifest = json.loads((target / "manifest.json").read_text())
    manifest["run_id"] = f"{manifest['run_id']}-{suffix}"
    (target / "manifest.json").write_text(json.dumps(manifest))
    return target


def precheck(argv: list[str], capsys) -> tuple[int, str]:
    """The CLI's check of the overrides, in this process: (exit status, stderr)."""
    from pipeline.cli import precheck_overrides

    try:
        precheck_overrides(argv)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    return code, capsys.readouterr().err.strip()


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (
            ["mechanism.fixed.stroke=1e300"],
            "mechanism.fixed.stroke=1e+300 is invalid: allowed a number in [1, 1000] cm",
        ),
        (["mechanism.fixed.stroke=1e-300"], "mechanism.fixed.stroke=1e-300 is invalid: allowed a number in [1, 1000]"),
        (["mechanism.fixed.stroke=abc"], "mechanism.fixed.stroke='abc' is invalid: allowed a number in [1, 1000]"),
        (["mechanism.fixed.stroke=nan"], "mechanism.fixed.stroke=nan is invalid"),
        (["mechanism.fixed.stroke=-100"], "mechanism.fixed.stroke=-100 is invalid"),
        (
            ["mechanism=tricept", "mechanism.fixed.tilt_limit=0"],
            "mechanism.fixed.tilt_limit=0 is invalid: allowed null or",
        ),
        (["mechanism=delta", "mechanism.fixed.z_max=1"], "mechanism.fixed.z_max=1 is invalid"),
        (["-m", "objective.w_d=abc"], "objective.w_d"),
        (["+hydra.callbacks.x._target_=shutil.copyfile"], "hydra.callbacks.x._target_ is refused"),
        (["-m", "+hydra.callbacks.x._target_=builtins.open"], "hydra.callbacks.x._target_ is refused"),
        (["+hydra.job.env_set.PYTHONPATH=/tmp"], "hydra.job.env_set.PYTHONPATH is refused"),
        (["-m", "+hydra.job.env_set.PYTHONPATH=/tmp"], "hydra.job.env_set.PYTHONPATH is refused"),
        (["hydra.launcher._target_=os.system"], "is refused"),
        (["--config-dir=/tmp"], "--config-dir is refused"),
        (["--experimental-rerun", "x.pickle"], "--experimental-rerun is refused"),
    ],
)
def test_items01_02_03_16_17_precheck_in_process(argv, fragment, tmp_path, capsys):
    code, err = precheck([*argv, f"paths.output_dir={tmp_path / 'out'}"], capsys)
    assert code == 2 and err.startswith("error: ") and "\n" not in err and fragment in err, err
    assert files_under(tmp_path / "out") == []


def test_a_good_sweep_passes_the_precheck(tmp_path, capsys):
    code, err = precheck(
        [
            "-m",
            "+experiment=rpr2_mixed",
            "objective.w_d=0,0.5,1",
            "mechanism.fixed.q_max=9,9.6",
            f"paths.output_dir={tmp_path / 'out'}",
        ],
        capsys,
    )
    assert code == 0 and err == ""


# ------------------------------------------------------------------ 1, 2: values
@pytest.mark.slow
@pytest.mark.parametrize("value", ["1e300", "1e-300", "abc", "nan", "-100", "inf", "true"])
def test_item01_02_fixed_values_are_refused_naming_key_and_range(value, tmp_path):
    out = tmp_path / "out"
    proc = run_cli([f"mechanism.fixed.stroke={value}", f"paths.output_dir={out}"], timeout=120)
    assert proc.returncode == 2
    one_error_line(proc, "mechanism.fixed.stroke=", "allowed a number in [1, 1000] cm")
    assert files_under(out) == []


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_item01_every_fixed_parameter_is_declared_with_range_and_default(name):
    cls = MECHANISMS[name]
    declared = {p.name: p for p in cls.fixed_parameters}
    assert set(declared) == set(cls.default_fixed)
    for p in declared.values():
        assert p.accepts(p.default), p
        assert p.choices or (p.unit and p.lower < p.upper), p
        if not p.choices:
            for bad in (float("nan"), float("inf"), p.lower - 1, p.upper + 1, "1", True):
                assert not p.accepts(bad), (p, bad)


def test_item01_a_non_finite_result_is_never_complete(monkeypatch, tmp_path):
    import pipeline.study.compute as study

    real = study.objective_values
    monkeypatch.setattr(study, "objective_values", lambda *a: np.full_like(real(*a), np.nan))
    run_dir = tmp_path / "run"
    with pytest.raises(RunError, match="degenerate result: non-finite"):
        make_run(run_dir, tmp_path, "+experiment=rpr2_mixed")
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "failed" and manifest["reason"].startswith("degenerate result")
    assert not list(run_dir.glob("*.parquet"))


def test_item01_an_optimum_without_workspace_is_never_complete(monkeypatch, tmp_path):
    import pipeline.study.compute as study

    real = study.optimise_design

    def empty(*args, **kwargs):
        optimum = real(*args, **kwargs)
        optimum["best"]["volume"] = 0.0
        return optimum

    monkeypatch.setattr(study, "optimise_design", empty)
    run_dir = tmp_path / "run"
    with pytest.raises(RunError, match="no workspace"):
        make_run(run_dir, tmp_path, "+experiment=rpr2_mixed", "sample.seed=3")
    assert json.loads((run_dir / "manifest.json").read_text())["status"] == "failed"


# ------------------------------------------------------------------ 3: -m precheck
@pytest.mark.slow
@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (["objective.w_d=abc"], "objective.w_d"),
        (["objective.w_d=0,abc"], "objective.w_d"),
        (["+nosuchkey=1"], "nosuchkey"),
        (["mechanism.fixed.stroke=0.5,1e300"], "mechanism.fixed.stroke"),
    ],
)
def test_item03_a_bad_override_under_multirun_is_one_line_exit_2(overrides, fragment, tmp_path):
    out = tmp_path / "out"
    proc = run_cli(["-m", *overrides, f"paths.output_dir={out}"], timeout=120)
    assert proc.returncode == 2
    one_error_line(proc, fragment)
    assert files_under(out) == []


# ------------------------------------------------------------------ 4: disk full
FULL_DISK = """
import builtins, errno, logging, runpy, sys
real_open = builtins.open
def full_open(file, mode="r", *args, **kwargs):
    if {where!r} in str(file) and any(m in mode for m in "wa"):
        raise OSError(errno.ENOSPC, "No space left on device", str(file))
    return real_open(file, mode, *args, **kwargs)
builtins.open = full_open
{extra}
sys.argv = ["pipeline", *sys.argv[1:]]
runpy.run_module("pipeline", run_name="__main__")
"""


@pytest.mark.slow
def test_item04_disk_full_while_hydra_saves_its_config_is_one_line_exit_1(tmp_path):
    out = tmp_path / "out"
    script = FULL_DISK.format(where=".hydra", extra="")
    proc = run_python(
        ["-c", script, "+experiment=rpr2_mixed", *TINY, f"paths.output_dir={out}", f"hydra.run.dir={out}/run"]
    )
    assert proc.returncode == 1
    one_error_line(proc, "No space left on device", ".hydra")
    assert not list(out.rglob("manifest.json")) and not list(out.rglob("*.parquet"))


@pytest.mark.slow
def test_item04_disk_full_during_the_run_ends_failed_with_one_line_naming_the_place(tmp_path):
    """Every write of the run fails (results, the log file, the manifest's rewrite): one line,
    exit 1, no logging tracebacks, and the manifest still ends ``failed`` (rewritten in place)."""
    out = tmp_path / "out"
    extra = textwrap.dedent("""
        import pyarrow.parquet as pq, os
        def full(*a, **k):
            raise OSError(errno.ENOSPC, "No space left on device")  # pyarrow names no file
        pq.write_table = full
        real_replace = os.replace
        def replace(src, dst, *a, **k):
            if str(dst).endswith("manifest.json") and os.path.exists(dst):
                raise OSError(errno.ENOSPC, "No space left on device", str(src))
            return real_replace(src, dst, *a, **k)
        os.replace = replace
    """)
    script = FULL_DISK.format(where="pm-design.log", extra=extra)
    run_dir = out / "run"
    proc = run_python(
        ["-c", script, "+experiment=rpr2_mixed", *TINY, f"paths.output_dir={out}", f"hydra.run.dir={run_dir}"]
    )
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "Logging error" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "no space left on device" in errors[0].lower() and str(run_dir) in errors[0]
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "failed" and "no space left" in manifest["reason"].lower()
    assert not list(run_dir.glob("*.parquet"))


# ------------------------------------------------------------------ 5: the joblib launcher
def test_item05_the_joblib_launcher_is_a_main_dependency():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert any(d.startswith("hydra-joblib-launcher") for d in project["dependencies"])


# ------------------------------------------------------------------ 6, 7: interrupts
def test_item06_an_interrupt_inside_compiled_code_is_an_interrupt():
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("<numba function> returned a result with an exception set")  # noqa: B904 - as numba raises it
    except SystemError as exc:
        assert isinstance(interrupt_in(exc), KeyboardInterrupt)
    assert interrupt_in(ValueError("x")) is None


def test_item06_ctrl_c_during_evaluate_marks_the_run_interrupted(monkeypatch, tmp_path):
    import pipeline.study.compute as study

    def ctrl_c_in_numba(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("CPUDispatcher returned a result with an exception set")  # noqa: B904 - as numba raises it

    monkeypatch.setattr(study, "evaluate_designs", ctrl_c_in_numba)
    run_dir = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        make_run(run_dir, tmp_path, "+experiment=rpr2_mixed", "sample.seed=5")
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["status"] == "interrupted" and "Ctrl-C" in manifest["reason"]
    assert not list(run_dir.glob("*.parquet"))


def _start_and_signal(out: Path, sig: int, when: str, extra: list[str]) -> tuple[subprocess.Popen, str, Path]:
    proc = start_cli(["+experiment=h4_mixed", f"paths.output_dir={out}", "plot.enabled=false", *extra])

    def ready(out: Path) -> bool:
        logs = list(out.rglob("pm-design.log"))
        return when == "start" or bool(logs and "evaluate: computing" in logs[0].read_text())

    manifest = wait_for_run(out, ready, seconds=180, poll=0.05)
    assert manifest is not None, "the run did not start"
    time.sleep(0.5)
    os.killpg(proc.pid, sig) if sig == signal.SIGINT else proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=120)
    return proc, stderr, manifest


@pytest.mark.slow
def test_item06_ctrl_c_during_evaluate_through_the_cli(tmp_path):
    proc, stderr, manifest = _start_and_signal(
        tmp_path / "out", signal.SIGINT, "evaluate", ["sample.n=64", "evaluate.resolution=36"]
    )
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "SystemError" not in stderr
    assert json.loads(manifest.read_text())["status"] == "interrupted"


@pytest.mark.slow
def test_item07_sigterm_is_handled_like_ctrl_c_with_exit_143(tmp_path):
    proc, stderr, manifest = _start_and_signal(
        tmp_path / "out", signal.SIGTERM, "start", ["sample.n=16", "optimizer.generations=200"]
    )
    assert proc.returncode == 143, stderr
    errors = [ln for ln in stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "SIGTERM" in errors[0] and "Traceback" not in stderr
    final = json.loads(manifest.read_text())
    assert final["status"] == "interrupted" and "SIGTERM" in final["reason"]
    assert not list(manifest.parent.glob("best.parquet"))


# ------------------------------------------------------------------ 8: cache corruption
def test_item08_a_cache_entry_overwritten_with_another_pickle_is_recomputed(tmp_path, caplog):
    from pipeline.config import validate
    from pipeline.stages.sample import sample_designs
    from pipeline.store.cache import cached

    c = validate(compose_cfg("+experiment=rpr2_mixed", *TINY, f"paths.output_dir={tmp_path}"))
    cache = str(tmp_path / "cache")
    stage = cached(sample_designs, cache)
    good = stage(c.mechanism.design, c.sample)
    outputs = list((tmp_path / "cache").rglob("output.pkl"))
    assert len(outputs) == 1
    forged = good.copy()
    forged[forged.columns[-1]] = forged[forged.columns[-1]] * 2
    joblib.dump(forged, outputs[0])  # a valid entry of another frame
    assert stage.check_call_in_cache(c.mechanism.design, c.sample)
    with caplog.at_level("WARNING"):
        again = stage(c.mechanism.design, c.sample)
    pd.testing.assert_frame_equal(again, good)
    lines = [r.getMessage() for r in caplog.records if "checksum" in r.getMessage()]
    assert len(lines) == 1 and "recomputed" in lines[0]
    pd.testing.assert_frame_equal(joblib.load(outputs[0]), good)  # the entry is healed
    caplog.clear()
    with caplog.at_level("WARNING"):
        pd.testing.assert_frame_equal(stage(c.mechanism.design, c.sample), good)
    assert not [r for r in caplog.records if "checksum" in r.getMessage()]


# ------------------------------------------------------------------ 9-13: the dataset
def test_item09_a_truncated_run_file_is_skipped_and_the_others_added(one_run, tmp_path, caplog):
    sweep = tmp_path / "sweep"
    good = copy_run(one_run, sweep / "0", "a")
    bad = copy_run(one_run, sweep / "1", "b")
    data = (bad / "best.parquet").read_bytes()
    (bad / "best.parquet").write_bytes(data[: len(data) // 2])
    with caplog.at_level("WARNING"):
        report = aggregate(sweep, tmp_path / "dataset")
    assert len(report.added) == 1 and report.added[0].endswith("-a")
    assert len(report.skipped) == 1 and "unreadable best.parquet" in report.skipped[0]
    assert pd.read_parquet(tmp_path / "dataset" / "best")["run_id"].tolist() == report.added
    assert good.exists()


def test_item10_a_manifest_without_run_id_is_skipped_and_the_others_added(one_run, tmp_path):
    sweep = tmp_path / "sweep"
    copy_run(one_run, sweep / "0", "a")
    bad = copy_run(one_run, sweep / "1", "b")
    manifest = json.loads((bad / "manifest.json").read_text())
    del manifest["run_id"]
    (bad / "manifest.json").write_text(json.dumps(manifest))
    report = aggregate(sweep, tmp_path / "dataset")
    assert len(report.added) == 1 and "manifest lacks run_id" in report.skipped[0]
    proc = run_cli(
        [str(sweep), "--dataset", str(tmp_path / "dataset2")], module="pipeline.stages.aggregate", timeout=120
    )
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert json.loads(proc.stdout)["added"] == 1


def _dataset_of_two(one_run: Path, tmp_path: Path) -> tuple[Path, Path, list[str]]:
    sweep = tmp_path / "sweep"
    copy_run(one_run, sweep / "0", "a")
    copy_run(one_run, sweep / "1", "b")
    dataset = tmp_path / "dataset"
    report = aggregate(sweep, dataset)
    assert len(report.added) == 2 and (dataset / REGISTRY).exists()
    return sweep, dataset, sorted(report.added)


def _read_all(dataset: Path) -> dict[str, pd.DataFrame]:
    return {t: pd.read_parquet(dataset / t) for t in ("best", "history", "designs", "runs")}


def test_item11_a_truncated_dataset_file_is_found_and_rebuilt_from_its_run(one_run, tmp_path, caplog):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    before = _read_all(dataset)
    target = dataset / "designs" / f"{ids[0]}.parquet"
    target.write_bytes(target.read_bytes()[:100])
    with caplog.at_level("WARNING"):
        report = aggregate(sweep, dataset)
    assert report.repaired == [ids[0]] and report.present == [ids[1]] and report.added == []
    assert [r for r in caplog.records if ids[0] in r.getMessage() and "rebuilt" in r.getMessage()]
    after = _read_all(dataset)
    for name, frame in before.items():
        pd.testing.assert_frame_equal(
            after[name].sort_values(list(after[name].columns[:3])).reset_index(drop=True),
            frame.sort_values(list(frame.columns[:3])).reset_index(drop=True),
        )
    again = aggregate(sweep, dataset)
    assert again.repaired == [] and sorted(again.present) == ids


def test_item11_a_damaged_run_whose_source_is_not_given_is_rebuilt_from_its_recorded_source(one_run, tmp_path):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    target = dataset / "best" / f"{ids[1]}.parquet"
    target.write_bytes(b"PAR1" + b"\0" * 64)
    other = copy_run(one_run, tmp_path / "other", "c")
    report = aggregate(other, dataset)
    assert report.repaired == [ids[1]] and len(report.added) == 1
    assert sorted(pd.read_parquet(dataset / "best")["run_id"]) == sorted([*ids, report.added[0]])


def test_item12_a_deleted_dataset_file_is_not_present_and_is_restored(one_run, tmp_path):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    (dataset / "history" / f"{ids[1]}.parquet").unlink()
    report = aggregate(sweep, dataset)
    assert ids[1] not in report.present and report.repaired == [ids[1]]
    assert sorted(pd.read_parquet(dataset / "history")["run_id"].unique()) == ids


def test_item12_a_run_whose_source_is_gone_is_removed_from_every_table(one_run, tmp_path):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    (dataset / "best" / f"{ids[0]}.parquet").unlink()
    shutil.rmtree(sweep / "0")
    report = aggregate(sweep, dataset)
    assert report.repaired == [ids[0]] and report.present == [ids[1]]
    for name, frame in _read_all(dataset).items():
        assert sorted(frame["run_id"].unique()) == [ids[1]], name


def test_item13_stale_staging_is_cleaned_under_the_lock(one_run, tmp_path):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    stale = tmp_path / ".dataset.staging-deadbeef"
    shutil.copytree(dataset, stale)
    old = tmp_path / ".dataset.old-cafe0000"
    shutil.copytree(dataset, old)
    report = aggregate(sweep, dataset)
    assert sorted(report.present) == ids
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".dataset")) == [".dataset.lock"]


def test_item13_a_kill_between_the_swap_renames_is_restored(one_run, tmp_path):
    sweep, dataset, ids = _dataset_of_two(one_run, tmp_path)
    os.rename(dataset, tmp_path / ".dataset.old-0badf00d")
    report = aggregate(sweep, dataset)
    assert sorted(report.present) == ids and report.added == []
    assert len(pd.read_parquet(dataset / "best")) == 2


# ------------------------------------------------------------------ 14, 15: scale-out
class FutureCancelledError(Exception):
    """Stands for distributed's error when a worker holding a batch dies."""


FutureCancelledError.__module__ = "distributed.client"


def test_item14_a_batch_lost_with_a_dask_worker_is_retried_while_workers_remain(monkeypatch, caplog):
    import pipeline.evaluation.evaluator as evaluator
    from pipeline.evaluation import DesignEvaluator
    from pipeline.evaluation.scale import retry_lost_workers

    monkeypatch.setattr("pipeline.evaluation.pool.cpu_count", lambda: 4)
    c = compose_cfg("+experiment=rpr2_mixed", *TINY)
    from pipeline.config import validate

    mech = validate(c).mechanism
    designs = np.array([[5.0, 6.0], [4.0, 5.0], [6.0, 7.0], [3.0, 4.0]])
    expected = DesignEvaluator(mech, 8, 1).evaluate(designs)
    calls = []
    real = evaluator.Parallel

    class LosesAWorkerOnce:
        def __init__(self, n_jobs):
            self.n_jobs = n_jobs

        def __call__(self, tasks):
            calls.append(self.n_jobs)
            if len(calls) == 1:
                raise FutureCancelledError("batch ... already forgotten")
            return real(n_jobs=1)(tasks)

    monkeypatch.setattr(evaluator, "Parallel", LosesAWorkerOnce)
    monkeypatch.setattr("pipeline.evaluation.scale.dask_workers_left", lambda: 1)
    with caplog.at_level("WARNING"), parallel_config(backend="threading"):  # joblib's dispatch, as on dask
        rows = DesignEvaluator(mech, 8, 4).evaluate(designs)
    np.testing.assert_array_equal(rows, expected)
    assert len(calls) == 2 and [r for r in caplog.records if "worker was lost" in r.getMessage()]
    # none left: the run fails with the error
    with pytest.raises(FutureCancelledError):
        retry_lost_workers(lambda: (_ for _ in ()).throw(FutureCancelledError("gone")), workers_left=lambda: 0)
    with pytest.raises(ValueError):  # a failure of the computation itself is not retried
        retry_lost_workers(lambda: (_ for _ in ()).throw(ValueError("bug")), workers_left=lambda: 2)


def test_item15_n_jobs_is_capped_by_cores_and_batch(monkeypatch):
    import pipeline.evaluation.evaluator as evaluator
    from pipeline.config import validate
    from pipeline.evaluation import DesignEvaluator
    from pipeline.evaluation.pool import worker_count
    from pipeline.evaluation.scale import workers_for

    assert workers_for(16, 4) == min(4, worker_count(16))
    assert workers_for(1000, 10_000) == worker_count(1000) <= (os.cpu_count() or 1)
    assert workers_for(2, 1) == 1

    class Started(Exception):
        """Stops the evaluation once the pool's size is known."""

    sizes = []

    def pool_of(n, preload=()):
        sizes.append(n)
        raise Started

    monkeypatch.setattr(evaluator, "fitness_pool", pool_of)
    monkeypatch.setattr("pipeline.evaluation.pool.cpu_count", lambda: 64)
    mech = validate(compose_cfg("+experiment=rpr2_mixed", *TINY)).mechanism
    designs = np.array([[5.0, 6.0], [4.0, 5.0], [6.0, 7.0], [3.0, 4.0]])
    with pytest.raises(Started):
        DesignEvaluator(mech, 8, 16).evaluate(designs)
    assert sizes == [3]  # 4 designs: this process and 3 workers, not 15


# ------------------------------------------------------------------ 16, 17: injection
@pytest.mark.slow
def test_item16_callbacks_from_the_command_line_run_nothing(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    out = tmp_path / "out"
    for args in (
        [
            "+hydra.callbacks.x._target_=shutil.copyfile",
            f"+hydra.callbacks.x.src={victim}",
            f"+hydra.callbacks.x.dst={tmp_path / 'copy.txt'}",
        ],
        ["+hydra.callbacks.x._target_=builtins.open", f"+hydra.callbacks.x.file={victim}", "+hydra.callbacks.x.mode=w"],
    ):
        for flags in ([], ["-m"]):
            proc = run_cli([*flags, *args, f"paths.output_dir={out}"], timeout=120)
            assert proc.returncode == 2
            one_error_line(proc, "hydra.callbacks")
    assert victim.read_text() == "keep" and not (tmp_path / "copy.txt").exists()
    assert files_under(out) == []


@pytest.mark.slow
@pytest.mark.parametrize(
    "override",
    [
        "+hydra.launcher._target_=os.system",
        "hydra.job_logging.handlers.console.class=shutil.copyfile",
        "hydra.sweeper._target_=os.system",
    ],
)
def test_item16_no_target_anywhere_under_hydra(override, tmp_path):
    proc = run_cli([override, f"paths.output_dir={tmp_path / 'out'}"], timeout=120)
    assert proc.returncode == 2
    one_error_line(proc, "is refused")


def test_item16_experiment_files_cannot_add_callbacks_or_environment():
    hydra = OmegaConf.to_container(compose_cfg(hydra=True).hydra, resolve=False)
    guard.check_hydra_node(OmegaConf.create(hydra))  # the project's own config passes

    def with_(**changes):
        return OmegaConf.create({**hydra, **changes})

    with pytest.raises(ConfigError, match="hydra.callbacks.x._target_"):
        guard.check_hydra_node(with_(callbacks={"x": {"_target_": "shutil.copyfile"}}))
    with pytest.raises(ConfigError, match="PYTHONPATH"):
        guard.check_hydra_node(with_(job={**hydra["job"], "env_set": {"PYTHONPATH": "/tmp/evil"}}))
    with pytest.raises(ConfigError, match="hydra.launcher._target_"):
        guard.check_hydra_node(with_(launcher={"_target_": "os.system"}))
    guard.check_hydra_node(with_(job={**hydra["job"], "env_set": {"OMP_NUM_THREADS": "1"}}))


@pytest.mark.slow
def test_item17_env_set_pythonpath_plants_nothing(tmp_path):
    planted = tmp_path / "plant"
    planted.mkdir()
    marker = tmp_path / "ran.txt"
    (planted / "sitecustomize.py").write_text(f"open({str(marker)!r}, 'w').write('ran')\n")
    out = tmp_path / "out"
    for flags in ([], ["-m"]):
        proc = run_cli(
            [
                *flags,
                "+experiment=rpr2_mixed",
                *TINY,
                f"+hydra.job.env_set.PYTHONPATH={planted}",
                f"paths.output_dir={out}",
            ],
            timeout=120,
        )
        assert proc.returncode == 2
        one_error_line(proc, "hydra.job.env_set.PYTHONPATH")
    assert not marker.exists() and files_under(out) == []
