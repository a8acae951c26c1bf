"""The worked example of an external mechanism: examples/five_bar (package pm-five-bar).

Default tier: the package's source is put on sys.path with a distribution
record built from its pyproject.toml's entry points (what ``pip install``
writes), so discovery goes through ``importlib.metadata`` as for an installed
package. Slow tier: ``pip install`` of the package into a folder of its own
(not this venv: its mechanism would join every later test run's
``MECHANISMS``), then the CLI runs ``+experiment=five_bar_mixed`` and a
built-in study into one dataset and report.

Tolerance of the area check
---------------------------
The grid's midpoint rule counts a cell of area ``h_x h_y`` as inside when
its centre is, so only cells that the workspace boundary crosses err, each by
at most ``h_x h_y``. The boundary lies on four circles (radii R, R, r, r),
and a circle of radius rho meets at most ``4 rho / h_x + 4 rho / h_y + 4``
cells (its x and y each vary by 4 rho over four monotone arcs). Hence the
certain bound ``|A_grid - A| <= h_x h_y n_b`` with ``n_b`` that count. Its
errors have random signs: with the covered fraction of a crossed cell
spread uniformly, each cell's error has mean ~0 and standard deviation
``h_x h_y / sqrt(12)``, so the sum has ``sigma = h_x h_y sqrt(n_b / 12)``;
the test asks for ``5 sigma`` (0.25 % at resolution 200 for the 40/30 mm design,
whose measured error is below 0.01 %).
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from kinematics import MECHANISMS
from kinematics.plugins import config_search_paths, entry_point_mechanisms
from kinematics.testing import check_mechanism
from kinematics.workspace import evaluate

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "five_bar"


def write_distribution_record(folder: Path) -> None:
    """The ``.dist-info`` folder pip would write for examples/five_bar (its entry points, from pyproject.toml)."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    info = folder / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    lines = []
    for group, entries in project["entry-points"].items():
        lines += [f"[{group}]", *(f"{k} = {v}" for k, v in entries.items()), ""]
    (info / "entry_points.txt").write_text("\n".join(lines))


@pytest.fixture()
def five_bar(tmp_path, monkeypatch):
    """The FiveBar class, discovered through its entry point."""
    write_distribution_record(tmp_path)
    monkeypatch.syspath_prepend(str(EXAMPLE / "src"))
    monkeypatch.syspath_prepend(str(tmp_path))
    found = entry_point_mechanisms(MECHANISMS.builtins)
    assert list(found) == ["five_bar"]
    return found["five_bar"]


def test_discovered_by_entry_point_with_its_configs(five_bar):
    assert five_bar.__module__ == "pm_five_bar.mechanism" and five_bar.__name__ == "FiveBar"
    assert config_search_paths() == ["pkg://pm_five_bar.conf"]
    shipped = EXAMPLE / "src" / "pm_five_bar" / "conf" / "experiment" / "five_bar_mixed.yaml"
    assert "override /mechanism: five_bar" in shipped.read_text()


def test_passes_the_conformance_harness(five_bar):
    assert check_mechanism(five_bar) == []


def area_tolerances(mech, resolution: int) -> tuple[float, float]:
    """(5 sigma, certain bound) of the grid area's error (mm^2); see the module docstring."""
    lo, hi = mech.pose_bounds(mech.default_orientation)
    hx, hy = (hi - lo) / resolution
    radii = [mech.l1 + mech.l2] * 2 + [abs(mech.l1 - mech.l2)] * 2
    crossed = sum(4 * rho / hx + 4 * rho / hy + 4 for rho in radii)
    return 5 * hx * hy * math.sqrt(crossed / 12), hx * hy * crossed


@pytest.mark.parametrize("l1, l2", [(40.0, 30.0), (30.0, 30.0), (60.0, 20.0), (20.0, 20.0), (25.0, 55.0)])
def test_area_matches_the_closed_form(five_bar, l1, l2):
    mech = five_bar(l1=l1, l2=l2, d=40.0)
    resolution = 200
    ev = evaluate(mech, resolution=resolution, min_inverse_condition=0.0, error_estimate=False)
    exact = mech.exact_area()
    likely, certain = area_tolerances(mech, resolution)
    assert abs(ev.volume - exact) <= likely, (ev.volume, exact, likely)
    assert likely < 0.01 * exact < certain  # the statistical tolerance is the one that tests something
    # the dexterity limit removes a band around the singular curves
    limited = evaluate(mech, resolution=resolution, error_estimate=False).volume
    assert 0 < limited < ev.volume


def test_min_resolution_is_within_three_percent(five_bar):
    """The class's ``min_resolution`` (48) keeps V and GDI within 3 % of a fine grid (400)."""
    for l1, l2 in [(20.0, 20.0), (40.0, 30.0), (60.0, 60.0), (20.0, 60.0)]:
        mech = five_bar(l1=l1, l2=l2, d=40.0)
        coarse = evaluate(mech, resolution=five_bar.min_resolution, error_estimate=False)
        fine = evaluate(mech, resolution=400, error_estimate=False)
        assert coarse.volume == pytest.approx(fine.volume, rel=0.03)
        assert coarse.gdi == pytest.approx(fine.gdi, rel=0.03)


def test_inverse_kinematics_by_hand(five_bar):
    """P straight above the middle of a symmetric five-bar: both elbows out at the same angle."""
    mech = five_bar(l1=30.0, l2=40.0, d=40.0)
    # |P - A_i| = sqrt(20^2 + 30^2); the law of cosines gives the elbow angle beta
    rho = math.hypot(20.0, 30.0)
    beta = math.acos((30.0**2 + rho**2 - 40.0**2) / (2 * 30.0 * rho))
    phi = math.atan2(30.0, 20.0)
    theta = mech.inverse([[0.0, 30.0]])[0]
    np.testing.assert_allclose(theta, [phi + beta, math.pi - phi - beta], rtol=1e-12)
    assert np.isnan(mech.inverse([[0.0, 80.0]])).all()  # beyond l1 + l2 of both base joints
    with pytest.raises(ValueError, match=r"FiveBar: parameter 'd' must be below 2 \(l1 \+ l2\)"):
        five_bar(l1=10.0, l2=10.0, d=50.0)


# ------------------------------------------------------------------ slow tier
def run(args: list[str], env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess:
    proc = subprocess.run(args, capture_output=True, text=True, env=env, cwd=cwd, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


@pytest.mark.slow
def test_installed_package_runs_through_the_cli_into_one_dataset(tmp_path):
    """pip install the example, run its own experiment and a built-in one; one dataset, one report."""
    source = tmp_path / "src"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    target = tmp_path / "site"
    run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(source)],
        dict(os.environ),
        tmp_path,
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(target), str(ROOT)])}
    probe = run(
        [
            sys.executable,
            "-c",
            "import kinematics, kinematics.testing as t; c = kinematics.MECHANISMS['five_bar']; "
            "print(c.__module__, t.check_mechanism(c), kinematics.plugins.config_search_paths())",
        ],
        env,
        tmp_path,
    )
    assert probe.stdout.split("\n")[0] == "pm_five_bar.mechanism [] ['pkg://pm_five_bar.conf']"
    out = tmp_path / "outputs"
    tiny = ["+debug=fast", "optimizer.population=4", "optimizer.generations=2", f"paths.output_dir={out}"]
    for experiment in ("five_bar_mixed", "rpr2_mixed"):
        run([sys.executable, "-m", "pipeline", "-m", f"+experiment={experiment}", *tiny], env, tmp_path)
    best = pd.read_parquet(out / "dataset" / "best")
    assert sorted(best["mechanism"]) == ["five_bar", "rpr2"]
    five = best[best["mechanism"] == "five_bar"].iloc[0]
    assert 20.0 <= five["l1"] <= 60.0 and 20.0 <= five["l2"] <= 60.0 and np.isnan(five["b"])
    assert five["volume"] > 0 and five["experiment"] == "five_bar_mixed"
    run([sys.executable, "-m", "pipeline.report", str(out / "dataset")], env, tmp_path)
    page = (out / "dataset" / "report.html").read_text()
    assert "five_bar" in page and "rpr2" in page
