"""README is executable: every shell command and Python block of README.md runs, verbatim, from a
fresh temporary folder with the default relative paths.

README.md is parsed at test time (it changes). The only changes to a command:

* tiny sizes are *appended* to each ``python -m pipeline`` / ``pm-design`` study command:
  ``+debug=fast`` and the optimiser's own budget (population and generations, or evaluations),
  chosen from the command's composed config; nothing else is changed;
* in a set-up line (``python3 -m venv ... && pip install ... && CMD``) the parts that create the
  virtual environment, activate it, install the package or run the test suite are skipped: CI
  (``.ci/run``) runs those in a fresh environment, and a test cannot re-run its own suite. What
  the line runs after installing (the main job) runs here.

Python blocks run in a folder where README's main job (its first study command) has run, as a
reader who follows README from the top would have it. A sweep's ``report.html`` must have
links that still resolve after its folder is moved.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

#: tiny budgets per optimiser, appended after +debug=fast (each optimiser has its own fields)
TINY_OPTIMIZER = {
    "ga": ["optimizer.population=4", "optimizer.generations=2"],
    "de": ["optimizer.population=5", "optimizer.generations=2", "optimizer.polish_evaluations=10"],
    "cmaes": ["optimizer.max_evaluations=12", "optimizer.polish_evaluations=10"],
    "nsga2": ["optimizer.population=4", "optimizer.generations=2"],
}
#: parts of a set-up line skipped (CI runs them): venv, activation, installation, the test suite
SETUP = re.compile(r"^(python3? -m venv|\. \S+/activate|source \S+/activate|pip install|python -m pytest)")


def blocks(language: str) -> list[str]:
    """The fenced blocks of ``language`` in README.md, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(), flags=re.S | re.M)


def commands() -> list[str]:
    """Every command of README's bash blocks (continuation lines joined, comments dropped)."""
    out = []
    for block in blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip()
            if line and not line.startswith("#"):
                out.append(line)
    return out


def is_study(part: str) -> bool:
    words = shlex.split(part)
    return words[:3] == ["python", "-m", "pipeline"] or words[:1] == ["pm-design"]


def optimizer_of(overrides: list[str]) -> str:
    """The optimiser a study's overrides select (its config composed; swept values left out)."""
    from hydra import compose, initialize_config_dir

    from pipeline.config import CONFIG_DIR, register_configs

    register_configs()
    plain = [
        o for o in overrides if not o.startswith("-") and "," not in o.split("=", 1)[-1] and not o.startswith("hydra")
    ]
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        return str(compose(config_name="config", overrides=plain).optimizer.name)


def runnable(command: str) -> str:
    """``command`` as run here: set-up parts skipped, tiny sizes appended to study commands."""
    parts = []
    for part in (p.strip() for p in command.split("&&")):
        if SETUP.match(part):
            continue
        if is_study(part) and part.split()[-1] not in ("--help", "-h"):
            words = shlex.split(part)
            start = 3 if words[0] == "python" else 1
            if words[start : start + 1] not in (["evaluate"], ["aggregate"], ["report"]):
                part += " +debug=fast " + " ".join(TINY_OPTIMIZER[optimizer_of(words[start:])])
        parts.append(part)
    return " && ".join(parts)


def run(command: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=1800)


def check_reports_survive_a_move(folder: Path, elsewhere: Path) -> None:
    for report in (folder / "outputs").rglob("report.html"):
        moved = elsewhere / report.parent.name
        shutil.copytree(report.parent, moved)
        links = re.findall(r'href="([^"]+)"', (moved / "report.html").read_text())
        assert links, report
        for link in links:
            assert not link.startswith(("file:", "/")), link
            assert (moved / unquote(link)).is_file(), f"{report}: {link} does not resolve after the move"


def setup_only(command: str) -> bool:
    """Every part of ``command`` is set-up (nothing left to run here)."""
    return all(SETUP.match(p.strip()) for p in command.split("&&"))


def test_readme_has_commands_and_setup_is_recognised():
    found = commands()
    assert found and any(is_study(c.split("&&")[-1].strip()) for c in found)
    setup = [c for c in found if SETUP.match(c)]
    assert setup and all(not setup_only(c) or "pytest" in c for c in setup), setup


@pytest.mark.slow
@pytest.mark.parametrize("command", [c for c in commands() if not setup_only(c)])
def test_readme_command_runs_from_a_fresh_folder(command, tmp_path):
    folder = tmp_path / "fresh"
    folder.mkdir()
    proc = run(runnable(command), folder)
    assert proc.returncode == 0, f"{runnable(command)}\n{proc.stderr[-3000:]}"
    last = command.split("&&")[-1].strip()
    if is_study(last) and shlex.split(last)[1:2] != ["evaluate"]:  # evaluating one design writes no dataset
        assert "dataset: outputs/dataset" in proc.stdout, proc.stdout[-2000:]  # says where results went
        assert (folder / "outputs" / "dataset" / "best").is_dir()
    check_reports_survive_a_move(folder, tmp_path / "moved")


@pytest.mark.slow
@pytest.mark.parametrize("number", range(len(blocks("python"))))
def test_readme_python_block_runs_after_the_main_job(number, tmp_path):
    main_job = next(runnable(c) for c in commands() if any(is_study(p.strip()) for p in c.split("&&")))
    assert run(main_job, tmp_path).returncode == 0
    script = tmp_path / "block.py"
    script.write_text(blocks("python")[number])
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
