"""Compile the main job's kernels in a second process while the command line starts.

Why: on a machine whose numba cache is empty, the first H4 run compiles its
kernels (the fused columns kernel and the 4 x 4 conditioning batch, about
2.8 s) before it can evaluate, while the second core sits idle during the
~2.3 s of imports and config composition. :func:`start` (called first thing
by the entry point) runs ``python -m pipeline.evaluation.compile_ahead``, which takes
the default mechanism of ``conf/config.yaml`` (H4, the main job's),
says ``start <name>``, evaluates a tiny grid of one of its designs, so that
numba compiles every kernel it uses into its on-disk cache, and says
``done <name>``. :func:`wait_for` (called before the first evaluation) reads
those lines: a run of that mechanism waits for ``done`` and then loads the
kernels from the cache instead of compiling them; a run of another mechanism
goes on at once and compiles its own kernels as before. Results do not
change: the same functions are compiled, only in another process.

Nothing is started when the cache is known to be warm (a marker written after
a complete compilation, named by the hash of the ``kinematics`` sources and the
Python version), when the numpy reference kernels are selected, when
``PM_DESIGN_COMPILE_AHEAD=0``, or on a single core. This module imports only
the standard library, so that :func:`start` costs nothing on the critical path.
"""

from __future__ import annotations

import atexit
import hashlib
import importlib.util
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

from pipeline import CONFIG_DIR

#: the main config, whose default mechanism the helper compiles
CONFIG = CONFIG_DIR / "config.yaml"
#: ``PM_DESIGN_COMPILE_AHEAD=0`` turns the helper off (benchmarks measure with and without it)
SWITCH_ENV = "PM_DESIGN_COMPILE_AHEAD"
#: seconds the run waits for the helper at most (it takes ~3.5 s on this machine)
WAIT_LIMIT = 60.0
_process: list[subprocess.Popen] = []
_said: list[str] = []  # the helper's complete lines so far
_pending = bytearray()  # the helper's output after its last complete line


def _marker() -> Path | None:
    """Where a complete compilation is recorded (next to numba's cache of the kernels), or None."""
    spec = importlib.util.find_spec("kinematics")
    if spec is None or not spec.submodule_search_locations:
        return None
    package = Path(list(spec.submodule_search_locations)[0])
    digest = hashlib.sha256()
    for source in sorted(package.glob("*.py")):  # the kernels' sources (numba recompiles when they change)
        digest.update(source.read_bytes())
    stamp = digest.hexdigest()[:12]
    root = Path(os.environ["NUMBA_CACHE_DIR"]) if os.environ.get("NUMBA_CACHE_DIR") else package / "__pycache__"
    return root / f"pm-design-kernels-{stamp}-py{sys.version_info.major}{sys.version_info.minor}.compiled"


def wanted(argv: list[str]) -> bool:
    """False for command lines that evaluate nothing (Hydra's ``--help``, ``--cfg``, ``--info``, ...)."""
    return all(arg in ("-m", "--multirun") or not arg.startswith("-") for arg in argv)


def start() -> None:
    """Start the compilation in the background unless it is not needed (see the module docstring)."""
    if _process or (os.cpu_count() or 1) < 2:
        return
    if os.environ.get("PM_DESIGN_KERNELS", "numba").strip().lower() == "numpy":
        return
    if os.environ.get(SWITCH_ENV, "1").strip() == "0":
        return
    marker = _marker()
    if marker is None or marker.exists():
        return
    process = subprocess.Popen([sys.executable, "-m", "pipeline.evaluation.compile_ahead", str(marker)],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               preexec_fn=_ignore_sigint)
    _process.append(process)
    atexit.register(stop)


def _ignore_sigint() -> None:
    """In the helper before exec: SIGINT ignored (inherited through exec; Python then installs
    no KeyboardInterrupt handler), so a Ctrl-C stops the run, which ends the helper at exit.
    (Not at a lower priority: the run waits for it while its fitness workers start.)"""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def wait_for(mechanism: str) -> None:
    """Block until the helper has compiled ``mechanism``'s kernels, if those are what it compiles.

    At most :data:`WAIT_LIMIT` seconds: a helper that neither reports nor ends (it should
    never happen) only costs that wait; the run then compiles the kernels itself.
    """
    deadline = time.monotonic() + WAIT_LIMIT
    while _process and f"done {mechanism}" not in _said:
        started = [line.split(" ", 1)[1] for line in _said if line.startswith("start ")]
        if started and started[0] != mechanism:  # it compiles another mechanism's kernels
            return
        remaining = deadline - time.monotonic()
        if remaining <= 0 or not select.select([_process[0].stdout], [], [], remaining)[0]:
            return
        chunk = os.read(_process[0].stdout.fileno(), 4096)
        if not chunk:  # the helper ended (done, or failed: the run compiles what is missing)
            return
        _pending.extend(chunk)
        *lines, rest = bytes(_pending).split(b"\n")
        _pending[:] = rest
        _said.extend(line.decode().strip() for line in lines)


def stop() -> None:
    """End the background process if it is still compiling (at exit)."""
    for process in _process:
        if process.poll() is None:
            process.kill()
        process.wait()
        if process.stdout is not None:
            process.stdout.close()
    _process.clear()


def _compile(marker: Path) -> None:
    """The background process: compile the default mechanism's kernels, say so, then write the marker."""
    import yaml

    defaults = yaml.safe_load(CONFIG.read_text())["defaults"]
    name = next(entry["mechanism"] for entry in defaults if isinstance(entry, dict) and "mechanism" in entry)
    print(f"start {name}", flush=True)  # first, so that a run of another mechanism need not wait

    import numpy as np

    from kinematics import MECHANISMS
    from kinematics.workspace import evaluate

    cls = MECHANISMS[name]  # a tiny grid of the box's centre design compiles every kernel it uses
    centre = np.array([(v.lower + v.upper) / 2 for v in cls.design_variables])
    evaluate(cls.from_design(centre, **cls.default_fixed), resolution=2, error_estimate=False)
    print(f"done {name}", flush=True)
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
    except OSError:  # a read-only install: the next run compiles ahead again, harmlessly
        pass


if __name__ == "__main__":
    _compile(Path(sys.argv[1]))
