"""Helpers of the tests that run the real CLI in a child process and watch its processes.

Shared by ``test_faults.py``, ``test_reliability.py`` and ``test_pool.py``: start
``python -m pipeline`` (to completion or in the background, in its own session),
wait for its run to start, read its one-line error, and find the processes it
left (its session, its loky workers) through ``/proc``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the smallest study that runs every stage (a fraction of a second once compiled)
TINY = ["+debug=fast", "optimizer.population=4", "optimizer.generations=2"]
#: the child's output as it is written (a test reads its log while it runs)
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def interruptible() -> None:
    """``preexec_fn`` of a child that the test interrupts: Ctrl-C's default action restored.

    Why: a test runner started with SIGINT ignored (in the background of a non-interactive
    shell, as some CI runners do) passes that on to its children, and a Python started with
    SIGINT ignored never raises KeyboardInterrupt, so the test would not test the CLI.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_python(args: list[str], timeout: float = 300, **kwargs: object) -> subprocess.CompletedProcess:
    """``python *args`` from the repository's root, run to its end (output captured)."""
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=ENV, **kwargs
    )


def run_cli(
    args: list[str], module: str = "pipeline", timeout: float = 300, **kwargs: object
) -> subprocess.CompletedProcess:
    """``python -m module *args`` (the CLI by default), run to its end (output captured)."""
    return run_python(["-m", module, *args], timeout=timeout, **kwargs)


def start_python(
    args: list[str], env: dict[str, str] | None = None, interrupt: bool = False, stderr: int = subprocess.PIPE
) -> subprocess.Popen:
    """``python *args`` started in the background, leading its own session (so
    ``os.killpg(proc.pid, ...)`` reaches it and its workers, and :func:`processes_in_session`
    finds what it leaves). ``interrupt``: it may be sent Ctrl-C (:func:`interruptible`)."""
    return subprocess.Popen(
        [sys.executable, *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=stderr,
        text=True,
        start_new_session=True,
        preexec_fn=interruptible if interrupt else None,
        env=env or ENV,
    )


def start_cli(args: list[str], env: dict[str, str] | None = None, interrupt: bool = False) -> subprocess.Popen:
    """``python -m pipeline *args`` started in the background in its own session (:func:`start_python`)."""
    return start_python(["-m", "pipeline", *args], env=env, interrupt=interrupt)


def wait_for_run(out: Path, ready: Callable[[Path], bool], seconds: float = 120, poll: float = 0.2) -> Path | None:
    """The first ``manifest.json`` under ``out`` once ``ready(out)`` holds (the run is where the
    test wants it), or None after ``seconds``."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        manifests = list(out.rglob("manifest.json"))
        if manifests and ready(out):
            return manifests[0]
        time.sleep(poll)
    return None


def files_under(path: Path) -> list[Path]:
    return sorted(p for p in path.rglob("*") if p.is_file()) if path.exists() else []


def one_error_line(proc: subprocess.CompletedProcess, *fragments: str) -> str:
    """The child's stderr, asserted to be one ``error:`` line, no traceback, holding every fragment."""
    err = proc.stderr.strip()
    assert "Traceback" not in proc.stderr, proc.stderr
    assert err.startswith("error: ") and "\n" not in err, err
    for fragment in fragments:
        assert fragment in err, err
    return err


def cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def processes_in_session(sid: int) -> list[int]:
    """Live processes of session ``sid`` (zombies are already dead)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


def session_ends(sid: int, seconds: float) -> bool:
    """Whether every process of session ``sid`` is gone within ``seconds``."""
    deadline = time.time() + seconds
    while processes_in_session(sid) and time.time() < deadline:
        time.sleep(0.1)
    return processes_in_session(sid) == []


def loky_children(pid: int | None = None) -> list[int]:
    """Process ids of the loky workers of process ``pid`` (this one by default)."""
    pid = os.getpid() if pid is None else pid
    kids = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    return [int(kid) for kid in kids if b"LokyProcess" in cmdline(int(kid))]


#: source lines for a child's script: ``loky_pids()``, its own loky workers' process ids (as strings)
LOKY_PIDS_SOURCE = (
    "import os\n"
    "def loky_pids():\n"
    "    kids = open(f'/proc/{os.getpid()}/task/{os.getpid()}/children').read().split()\n"
    "    return [p for p in kids if 'LokyProcess' in open(f'/proc/{p}/cmdline').read()]\n"
)


def rpr2_evaluation_source(resolution: int, n_jobs: int, designs: int = 3) -> str:
    """Source lines for a child's script: :data:`LOKY_PIDS_SOURCE`, then ``designs`` RPR-2
    designs evaluated by a ``DesignEvaluator`` with ``n_jobs`` (its pool is left open), the
    table in ``table``."""
    return LOKY_PIDS_SOURCE + (
        "import numpy as np\n"
        "from pipeline.evaluation import DesignEvaluator\n"
        "from pipeline.config import MechanismConfig\n"
        f"designs = np.array([[5.0, 6.0], [4.0, 7.0], [4.5, 6.5]][:{designs}])\n"
        f"table = DesignEvaluator(MechanismConfig(name='rpr2'), {resolution}, {n_jobs}).evaluate(designs)\n"
    )


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def wait_until_dead(pids: list[int], seconds: float = 30) -> bool:
    deadline = time.time() + seconds
    while any(alive(p) for p in pids) and time.time() < deadline:
        time.sleep(0.1)
    return not any(alive(p) for p in pids)
