"""The installed package: console script, configs inside the package, Hydra's shell completion, version."""

from __future__ import annotations

import shutil
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from pipeline.config import CONFIG_DIR
from pipeline.store.cache import __version__

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow


def test_configs_are_found_from_the_installed_package():
    # editable install: the top-level conf/ in place; a wheel: the copy setup.py maps into pipeline/conf
    # (.ci/run installs the wheel and runs the main job from another folder)
    import pipeline

    packaged = Path(pipeline.__file__).parent / "conf"
    assert CONFIG_DIR in (packaged, Path(pipeline.__file__).parents[1] / "conf")
    assert (CONFIG_DIR / "config.yaml").exists() and (CONFIG_DIR / "experiment" / "h4_mixed.yaml").exists()


def test_version_comes_from_the_package_metadata():
    assert __version__ == version("pm-design")


@pytest.mark.skipif(shutil.which("pm-design") is None, reason="console script not on PATH (pip install -e .)")
def test_console_script_runs_from_another_folder_with_shell_completion(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [
            "pm-design",
            "+experiment=rpr2_mixed",
            "+debug=fast",
            "optimizer.population=4",
            "optimizer.generations=2",
            f"paths.output_dir={out}",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    run = next(out.rglob("manifest.json")).parent
    assert (run / ".hydra" / "overrides.yaml").exists() and (run / "pm-design.log").exists()
    completion = subprocess.run(
        ["pm-design", "-sc", "query=bash"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={
            "COMP_LINE": "pm-design mechanism=tr",
            "COMP_POINT": "22",
            "PATH": str(Path(sys.executable).parent) + ":/usr/bin:/bin",
        },
        timeout=120,
    )
    assert "mechanism=tricept" in completion.stdout.split()
    help_text = subprocess.run(["pm-design", "--help"], capture_output=True, text=True, timeout=120).stdout
    assert help_text.startswith("usage: pm-design") and "h4_mixed" in help_text  # one line per experiment
