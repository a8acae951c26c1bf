"""The worker group behind the parallel batch evaluation (``pipeline.evaluation.workers``).

Its requests travel over one socket per worker, so the cases that matter are
the ones where the two ends could fall out of step: an exception on either
side, a worker that dies, a group used again afterwards.
"""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest
from joblib.externals.loky.process_executor import BrokenProcessPool

from pipeline.evaluation import workers
from pipeline.config import MechanismConfig
from pipeline.evaluation import DesignEvaluator


def scaled(values: np.ndarray, factor: float) -> np.ndarray:
    return np.asarray(values) * factor


def fail(message: str) -> None:
    raise ValueError(message)


class FailsToUnpickle:
    """Pickles, but raises when unpickled (in the worker)."""

    def __reduce__(self):
        return fail, ("unpickling in the worker",)


class Unpicklable(Exception):
    def __reduce__(self):
        raise TypeError("this exception does not pickle")


def fail_unpicklably() -> None:
    raise Unpicklable("raised in a worker")


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture
def group():
    group = workers.WorkerGroup(2, preload=("numpy",))
    yield group
    group.close(kill=True)


def test_map_returns_the_local_result_first_then_each_request_in_order(group):
    out = group.map(scaled, [(np.arange(3.0), 2.0), (np.arange(3.0), -1.0)], local=lambda: "here")
    assert out[0] == "here"
    np.testing.assert_array_equal(out[1], [0.0, 2.0, 4.0])
    np.testing.assert_array_equal(out[2], [0.0, -1.0, -2.0])
    assert len(set(group.pids)) == 2 and os.getpid() not in group.pids
    # fewer requests than workers, and many batches in a row
    for k in range(20):
        assert group.map(scaled, [(k, 3.0)], local=lambda: None)[1] == 3.0 * k


def test_exceptions_on_either_side_are_raised_and_leave_the_group_in_step(group):
    with pytest.raises(ValueError, match="from a worker"):
        group.map(fail, [("from a worker",), ("from a worker",)], local=lambda: None)
    with pytest.raises(RuntimeError, match="Unpicklable|does not pickle"):
        group.map(fail_unpicklably, [()], local=lambda: None)
    with pytest.raises(ValueError, match="unpickling in the worker"):
        group.map(scaled, [(FailsToUnpickle(), 2.0)], local=lambda: None)
    with pytest.raises(TypeError):  # cannot be pickled here: raised before anything is sent
        group.map(scaled, [(1.0, 2.0), (lambda: None, threading.Lock())], local=lambda: None)
    # requests are pickled as loky pickles them: a lambda works
    assert group.map(lambda x: x + 1, [(1,), (2,)], local=lambda: 0) == [0, 2, 3]

    def local_fails():
        raise KeyError("here")

    with pytest.raises(KeyError):
        group.map(scaled, [(1.0, 5.0), (2.0, 5.0)], local=local_fails)
    # the replies owed by the failed batches do not answer this one
    assert group.map(scaled, [(1.0, 7.0), (2.0, 7.0)], local=lambda: 0) == [0, 7.0, 14.0]
    assert not group.closed


def test_an_interrupted_caller_kills_the_group(group):
    group.map(scaled, [(1.0, 1.0)], local=lambda: None)
    pids = list(group.pids)

    def interrupted():
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        group.map(scaled, [(1.0, 1.0), (1.0, 1.0)], local=interrupted)
    assert group.closed
    deadline = time.time() + 30
    while any(_alive(p) for p in pids) and time.time() < deadline:
        time.sleep(0.1)
    assert not any(_alive(p) for p in pids)


def test_close_ends_the_workers(group):
    group.map(scaled, [(1.0, 1.0), (1.0, 1.0)], local=lambda: None)
    pids = list(group.pids)
    group.close()
    assert not any(_alive(p) for p in pids)
    with pytest.raises(BrokenProcessPool):
        group.map(scaled, [(1.0, 1.0)], local=lambda: None)


def test_a_dead_worker_breaks_one_batch_and_the_next_starts_afresh():
    """A worker killed (e.g. by the OOM killer) between two GA generations."""
    designs = np.array([[5.0, 6.0], [4.0, 7.0], [4.5, 6.5], [5.5, 8.0]])
    evaluator = DesignEvaluator(MechanismConfig(name="rpr2"), 24, 3)
    expected = DesignEvaluator(MechanismConfig(name="rpr2"), 24, 1).evaluate(designs)
    np.testing.assert_array_equal(evaluator.evaluate(designs), expected)
    group = workers.worker_group(2, preload=("pipeline.evaluation.evaluator",))
    os.kill(group.pids[0], signal.SIGKILL)
    with pytest.raises(BrokenProcessPool):
        evaluator.evaluate(designs)
    assert group.closed
    np.testing.assert_array_equal(evaluator.evaluate(designs), expected)
    assert workers.worker_group(2, preload=("pipeline.evaluation.evaluator",)) is not group


def test_a_worker_that_dies_before_connecting_is_reported():
    group = workers.WorkerGroup(1, preload=("a_module_that_does_not_exist",))
    with pytest.raises(BrokenProcessPool):
        group.map(scaled, [(1.0, 1.0)], local=lambda: None)
    assert group.closed


def test_workers_that_never_connect_are_reported(monkeypatch, tmp_path):
    (tmp_path / "slow_to_import.py").write_text("import time\ntime.sleep(30)\n")
    monkeypatch.syspath_prepend(str(tmp_path))  # loky's workers start with this sys.path
    monkeypatch.setattr(workers, "CONNECT_TIMEOUT", 1.0)
    group = workers.WorkerGroup(1, preload=("slow_to_import",))
    with pytest.raises(BrokenProcessPool, match="did not connect within 1 s"):
        group.map(scaled, [(1.0, 1.0)], local=lambda: None)
    assert group.closed


def test_a_process_with_an_open_group_exits_and_leaves_no_socket_behind(tmp_path):
    """Loky's exit hook waits for running loky tasks; a serving worker has none, whatever
    other loky executor started after the group (which re-registers loky's hook last)."""
    import subprocess
    import sys
    from pathlib import Path

    script = tmp_path / "exits.py"
    script.write_text(
        "import numpy as np\n"
        "from joblib.externals.loky import ProcessPoolExecutor\n"
        "from pipeline import evaluation as objective\nfrom pipeline.evaluation import workers\n"
        "from pipeline.config import MechanismConfig\n"
        "designs = np.array([[5.0, 6.0], [4.0, 7.0]])\n"
        "objective.DesignEvaluator(MechanismConfig(name='rpr2'), 24, 2).evaluate(designs)\n"
        "pool = ProcessPoolExecutor(max_workers=1)\n"
        "pool.submit(abs, -1).result()\n"
        "pool.shutdown()\n"
        "pool = ProcessPoolExecutor(max_workers=1)\n"
        "print(pool.submit(abs, -2).result(), flush=True)\n")
    root = Path(__file__).resolve().parents[1]
    proc = subprocess.run([sys.executable, str(script)], cwd=root, capture_output=True, text=True, timeout=60,
                          env={**os.environ, "TMPDIR": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["2"]
    assert not list(tmp_path.glob("pmw-*"))
    # a group that never served a batch (e.g. the run failed while compiling): exit does not wait for it
    script.write_text(
        "import time\n"
        "from pipeline.evaluation import workers\n"
        "group = workers.worker_group(1, preload=('pipeline.evaluation.evaluator',))\n"
        "time.sleep(3)\n"  # the worker has connected by now
        "print('exiting', flush=True)\n")
    proc = subprocess.run([sys.executable, str(script)], cwd=root, capture_output=True, text=True, timeout=60,
                          env={**os.environ, "TMPDIR": str(tmp_path)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["exiting"]
    assert not list(tmp_path.glob("pmw-*"))


def test_ctrl_c_while_the_group_is_made_ends_what_was_started(monkeypatch, tmp_path):
    """SIGINT pending while the workers start is delivered as the mask is restored, inside
    the group's construction: the processes and the socket must not outlive it."""
    started: list = []
    real = workers.submit_masked

    def interrupted(pool, func, argument_tuples):
        started.append(pool)
        real(pool, func, argument_tuples)
        raise KeyboardInterrupt

    monkeypatch.setattr(workers, "submit_masked", interrupted)
    monkeypatch.setattr(workers.tempfile, "tempdir", str(tmp_path))
    with pytest.raises(KeyboardInterrupt):
        workers.WorkerGroup(1, preload=("numpy",))
    pool = started[0]
    with pytest.raises(RuntimeError):  # shut down
        pool.submit(int)
    assert not list(tmp_path.glob("pmw-*"))
