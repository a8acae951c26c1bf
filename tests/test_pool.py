"""The fitness pool behind the parallel batch evaluation (``pipeline.evaluation.pool``).

A kept loky executor: the cases that matter are the ones where it could be left
in a bad state or leave processes behind: an exception on either side, a worker
that dies or hangs, an interruption, a process that exits with a pool open.
"""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest
from joblib.externals.loky.process_executor import BrokenProcessPool

from pipeline.config import MechanismConfig
from pipeline.evaluation import DesignEvaluator
from pipeline.evaluation import pool as pool_module
from pipeline.evaluation.pool import FitnessPool, fitness_pool, worker_count
from tests.helpers import loky_children, rpr2_evaluation_source, run_python, session_ends, start_python, wait_until_dead

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow


def scaled(values, factor: float):
    return np.asarray(values) * factor


def fail_in_worker(message: str) -> None:
    raise ValueError(message)


def sleep_for(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


#: loky workers this process already had when the running test started (other tests' executors,
#: e.g. joblib's reusable one, kept alive in the same xdist worker): not the test's to watch
_PREEXISTING: set[int] = set()


@pytest.fixture(autouse=True)
def _ignore_earlier_workers():
    _PREEXISTING.clear()
    _PREEXISTING.update(loky_children())
    yield


def loky_workers() -> list[int]:
    """Process ids of the loky workers this process started during the running test."""
    return [p for p in loky_children() if p not in _PREEXISTING]


@pytest.fixture
def pool():
    before = set(loky_workers())
    pool = FitnessPool(2, preload=("numpy",))
    yield pool
    pool.close(kill=True)
    assert wait_until_dead([p for p in loky_workers() if p not in before])


def test_map_returns_the_local_result_first_then_each_call_in_order(pool):
    out = pool.map(scaled, [(np.arange(3.0), 2.0), (np.arange(3.0), -1.0)], local=lambda: "here", timeout=60)
    assert out[0] == "here"
    np.testing.assert_array_equal(out[1], [0.0, 2.0, 4.0])
    np.testing.assert_array_equal(out[2], [0.0, -1.0, -2.0])
    for k in range(20):  # fewer calls than workers, many batches in a row
        assert pool.map(scaled, [(k, 3.0)], local=lambda: None, timeout=60)[1] == 3.0 * k


def test_a_workers_exception_carries_the_workers_traceback_and_the_pool_goes_on(pool):
    with pytest.raises(ValueError, match="from a worker") as raised:
        pool.map(fail_in_worker, [("from a worker",)], local=lambda: None, timeout=60)
    cause = raised.value.__cause__
    assert cause is not None and "fail_in_worker" in str(cause) and "Traceback" in str(cause)

    def local_fails():
        raise KeyError("here")

    with pytest.raises(KeyError):
        pool.map(scaled, [(1.0, 5.0)], local=local_fails, timeout=60)
    assert pool.map(scaled, [(1.0, 7.0), (2.0, 7.0)], local=lambda: 0, timeout=60) == [0, 7.0, 14.0]
    assert not pool.closed


def test_a_hung_worker_times_out_and_its_pool_is_killed():
    pool = FitnessPool(1)
    pool.map(sleep_for, [(0.0,)], local=lambda: None, timeout=60)
    pids = loky_workers()
    t0 = time.perf_counter()
    with pytest.raises(TimeoutError, match="within 0.5 s"):
        pool.map(sleep_for, [(60.0,)], local=lambda: None, timeout=0.5)
    assert time.perf_counter() - t0 < 30 and pool.closed
    assert wait_until_dead(pids)


def test_an_interrupted_caller_kills_the_pool(pool):
    pool.map(scaled, [(1.0, 1.0), (1.0, 1.0)], local=lambda: None, timeout=60)
    pids = loky_workers()

    def interrupted():
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        pool.map(scaled, [(1.0, 1.0)], local=interrupted, timeout=60)
    assert pool.closed and wait_until_dead(pids)
    with pytest.raises(BrokenProcessPool):
        pool.map(scaled, [(1.0, 1.0)], local=lambda: None, timeout=60)


def test_ctrl_c_while_the_pool_is_made_ends_what_was_started(monkeypatch):
    """SIGINT pending while the workers start is delivered as the mask is restored, inside the
    pool's construction: the processes must not outlive it."""
    real = pool_module.sigint_blocked
    made: list = []

    class Interrupted:
        def __enter__(self):
            self.inner = real()
            return self.inner.__enter__()

        def __exit__(self, *exc):
            self.inner.__exit__(*exc)
            made.extend(loky_workers())
            raise KeyboardInterrupt

    monkeypatch.setattr(pool_module, "sigint_blocked", Interrupted)
    with pytest.raises(KeyboardInterrupt):
        FitnessPool(1, preload=("numpy",))
    assert wait_until_dead(made)


def test_a_dead_worker_breaks_one_batch_and_the_next_starts_afresh():
    """A worker killed (e.g. by the OOM killer) between two GA generations."""
    pool_module.shutdown_pools(kill=True)  # the kept pool is this test's own, not an earlier test's
    designs = np.array([[5.0, 6.0], [4.0, 7.0], [4.5, 6.5], [5.5, 8.0]])
    evaluator = DesignEvaluator(MechanismConfig(name="rpr2"), 24, 2)
    expected = DesignEvaluator(MechanismConfig(name="rpr2"), 24, 1).evaluate(designs)
    np.testing.assert_array_equal(evaluator.evaluate(designs), expected)
    kept = fitness_pool(1, preload=("pipeline.evaluation.evaluator",))
    (pid,) = loky_workers()
    os.kill(pid, signal.SIGKILL)
    wait_until_dead([pid])
    with pytest.raises(BrokenProcessPool):
        evaluator.evaluate(designs)
    assert kept.closed
    np.testing.assert_array_equal(evaluator.evaluate(designs), expected)
    assert fitness_pool(1, preload=("pipeline.evaluation.evaluator",)) is not kept
    pool_module.shutdown_pools(kill=True)


def test_worker_count_is_capped_by_the_cores_the_process_may_use(tmp_path):
    """Launcher-agnostic: a run given one core (taskset, a SLURM task) evaluates in-process,
    whatever parallel.n_jobs says, and says so in its log."""
    assert worker_count(1) == 1 and worker_count(10_000) == max(1, worker_count(10_000)) <= (os.cpu_count() or 1)
    script = tmp_path / "one_core.py"
    script.write_text(
        "import logging, os\n"
        "logging.basicConfig(level=logging.INFO)\n"
        "os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})\n"
        + rpr2_evaluation_source(24, 4)
        + "print(len(loky_pids()))\n"
    )
    proc = run_python([str(script)], timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["0"]
    assert "parallel.n_jobs=4 capped at 1" in proc.stderr


def test_a_process_with_an_open_pool_exits_and_leaves_no_worker(tmp_path):
    script = tmp_path / "exits.py"
    script.write_text(rpr2_evaluation_source(24, 2, designs=2) + "print(table.shape, flush=True)\n")
    proc = start_python([str(script)])
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert out.strip().startswith("(2, ")

    assert session_ends(proc.pid, seconds=10)  # loky's resource tracker ends just after the process
