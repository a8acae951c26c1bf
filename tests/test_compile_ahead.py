"""The entry point's compile-ahead helper (pipeline.evaluation.compile_ahead): it compiles, it is skipped
once the cache is warm, and a run that used it gives the same results as one that did not."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from pipeline.evaluation import compile_ahead

ROOT = Path(__file__).resolve().parents[1]
TINY_H4 = ["+experiment=h4_mixed", "+debug=fast", "optimizer.population=4", "optimizer.generations=2",
           "optimizer.reference=false", "plot.enabled=false"]


@pytest.fixture
def fresh_helper(monkeypatch, tmp_path):
    """An empty numba cache for this test, and the helper's module state reset around it."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.delenv(compile_ahead.SWITCH_ENV, raising=False)
    monkeypatch.delenv("PM_DESIGN_KERNELS", raising=False)
    compile_ahead.stop()
    compile_ahead._said.clear()
    compile_ahead._pending.clear()
    yield tmp_path / "numba"
    compile_ahead.stop()
    compile_ahead._said.clear()
    compile_ahead._pending.clear()


def test_helper_compiles_then_is_skipped(fresh_helper):
    marker = compile_ahead._marker()
    assert marker is not None and marker.parent == fresh_helper and not marker.exists()
    compile_ahead.start()
    assert len(compile_ahead._process) == 1
    t0 = time.perf_counter()
    compile_ahead.wait_for("tricept")  # not the default mechanism: no wait for the compilation (~3 s)
    assert time.perf_counter() - t0 < 1.5
    assert compile_ahead._said == ["start h4"]  # the config's default mechanism
    compile_ahead.wait_for("h4")
    assert compile_ahead._said == ["start h4", "done h4"]
    compile_ahead._process[0].wait(timeout=60)
    assert marker.exists()  # written after a complete compilation
    assert any(fresh_helper.rglob("h4._h4_columns-*.nbi")) and any(fresh_helper.rglob("kernels._batch_laguerre-*.nbi"))
    compile_ahead.stop()
    compile_ahead.start()  # the cache is warm now: nothing is started
    assert compile_ahead._process == []


def test_a_silent_helper_costs_at_most_the_wait_limit(fresh_helper, monkeypatch):
    """A helper that neither reports nor ends: the run waits WAIT_LIMIT, then goes on (and compiles itself)."""
    monkeypatch.setattr(compile_ahead, "WAIT_LIMIT", 0.5)
    silent = subprocess.Popen([sys.executable, "-c", "import sys, time; sys.stdout.write('h'); sys.stdout.flush(); "
                               "time.sleep(30)"], stdout=subprocess.PIPE)
    compile_ahead._process.append(silent)
    t0 = time.perf_counter()
    compile_ahead.wait_for("h4")
    assert 0.4 < time.perf_counter() - t0 < 5.0
    assert compile_ahead._said == [] and bytes(compile_ahead._pending) == b"h"  # half a line kept
    compile_ahead.stop()
    assert silent.poll() is not None  # ended at exit


def test_helper_is_off_when_not_wanted(fresh_helper, monkeypatch):
    assert compile_ahead.wanted(["+experiment=h4_mixed"]) and compile_ahead.wanted(["-m", "objective.w_d=0,1"])
    assert not compile_ahead.wanted(["--help"]) and not compile_ahead.wanted(["--cfg", "job"])
    monkeypatch.setenv(compile_ahead.SWITCH_ENV, "0")
    compile_ahead.start()
    assert compile_ahead._process == []
    monkeypatch.delenv(compile_ahead.SWITCH_ENV)
    monkeypatch.setenv("PM_DESIGN_KERNELS", "numpy")
    compile_ahead.start()
    assert compile_ahead._process == []


def test_run_with_the_helper_equals_a_run_without(tmp_path):
    """From empty numba caches: the same best row with and without the helper; no process left."""
    rows = []
    for ahead in ("1", "0"):
        out = tmp_path / f"out{ahead}"
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / f"numba{ahead}"), compile_ahead.SWITCH_ENV: ahead}
        proc = subprocess.run([sys.executable, "-m", "pipeline", *TINY_H4, f"paths.output_dir={out}"], cwd=ROOT,
                              env=env, capture_output=True, text=True, timeout=240)
        assert proc.returncode == 0, proc.stderr[-2000:]
        (best,) = out.glob("runs/h4_mixed/*/best.parquet")
        rows.append(pd.read_parquet(best).drop(columns=["config_hash"]))
        markers = list((tmp_path / f"numba{ahead}").glob("pm-design-kernels-*.compiled"))
        assert len(markers) == (1 if ahead == "1" else 0)
    pd.testing.assert_frame_equal(rows[0], rows[1])
