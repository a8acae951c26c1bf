"""Every figure is not blank and its axis labels carry units; the sweep report renders in a browser."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote

import matplotlib.image as mpimg
import numpy as np
import pandas as pd
import pytest

import pipeline.stages.plot as plot_module
from kinematics import MECHANISMS
from pipeline.config import MechanismConfig

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def captured(monkeypatch):
    """Figures as they are saved (to read their labels), while still writing the files."""
    figures = []
    real = plot_module._save

    def save(fig, path, plot=None):
        figures.append(fig)
        return real(fig, path, plot)

    monkeypatch.setattr(plot_module, "_save", save)
    return figures


def assert_not_blank(path: Path) -> None:
    image = mpimg.imread(path)
    assert image.shape[0] >= 500 and image.shape[1] >= 700, image.shape  # >= 150 dpi on a 5 in figure
    assert image[..., :3].std() > 0.05, f"{path} is (nearly) blank"


def assert_labels_have_units(fig) -> None:
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if label == "generation":  # a count
                continue
            assert label and "[" in label and "]" in label, f"label without unit: {label!r}"


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_workspace_figures(name, tmp_path, captured):
    config = MechanismConfig(name=name)
    mech = config.build(config.centre)
    paths = plot_module.plot_workspace(
        mech, config.orientation_rad() or mech.default_orientation, 0.01, None, tmp_path, f"{name}, test"
    )
    for path in paths:
        assert_not_blank(path)
    for fig in captured:
        assert_labels_have_units(fig)
        assert fig.axes[0].get_title()


def test_convergence_tradeoff_and_front_figures(tmp_path, captured):
    history = pd.DataFrame(
        {"generation": range(20), "best": np.linspace(0.1, 0.3, 20), "mean": np.linspace(0.05, 0.25, 20)}
    )
    paths = [plot_module.plot_convergence(history, tmp_path / "c.png", "ga convergence (h4, mixed)", "η [1]")]
    best = pd.DataFrame(
        {
            "objective": ["mixed"] * 6,
            "mechanism": ["h4"] * 3 + ["rpr2"] * 3,
            "w_d": [0.0, 0.5, 1.0] * 2,
            "gdi": np.linspace(0.1, 0.4, 6),
            "suri": np.linspace(0.5, 0.2, 6),
            "objective_value": np.linspace(0.3, 0.2, 6),
        }
    )
    paths.append(plot_module.plot_tradeoff(pd.concat([best, best.assign(gdi=best["gdi"] * 1.1)]), tmp_path / "t.png"))
    front = pd.DataFrame({"gdi": np.linspace(0.1, 0.5, 10), "suri": np.linspace(0.6, 0.1, 10)})
    paths.append(plot_module.plot_front(front, ["gdi", "suri"], tmp_path / "f.png", "h4"))
    for path in paths:
        assert_not_blank(path)
    for fig in captured:
        assert_labels_have_units(fig)
    assert "η" in captured[0].axes[0].get_ylabel()


def test_tradeoff_of_a_sweep_without_mixed_runs_says_so(tmp_path, captured):
    """A sweep of V or GDI alone (e.g. experiment h4_table1): a labelled figure, no matplotlib warning."""
    import warnings

    best = pd.DataFrame(
        {
            "objective": ["volume"] * 3,
            "mechanism": ["h4"] * 3,
            "w_d": [0.0] * 3,
            "gdi": [0.2, 0.3, 0.4],
            "suri": [0.1, 0.2, 0.3],
            "objective_value": [1.0, 2.0, 3.0],
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = plot_module.plot_tradeoff(best, tmp_path / "t.png")
    assert path.exists()
    (ax,) = captured[0].axes
    assert ax.get_legend() is None
    assert any("no mixed-index runs" in text.get_text() for text in ax.texts)
    assert_labels_have_units(captured[0])


def test_vector_format_beside_the_png(tmp_path):
    class Plot:
        format, dpi = "svg", 150

    history = pd.DataFrame({"generation": range(3), "best": [1.0, 2.0, 3.0], "mean": [0.5, 1.0, 2.0]})
    plot_module.plot_convergence(history, tmp_path / "c.png", "t", "V [cm³·rad]", Plot())
    assert (tmp_path / "c.svg").read_text().lstrip().startswith("<?xml")


def test_importing_the_package_keeps_the_matplotlib_backend():
    code = (
        "import matplotlib; matplotlib.use('svg'); import pipeline.stages.plot, pipeline.study, pipeline.report, "
        "pipeline.reproduction; import matplotlib.pyplot as plt; print(plt.get_backend())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().lower() == "svg"


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


@pytest.mark.slow
@pytest.mark.skipif(
    _chromium() is None, reason="headless Chromium not installed (apt-get install chromium; README: Tests)"
)
def test_report_renders_in_a_real_browser(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pipeline",
            "-m",
            "+experiment=rpr3_mixed",
            "+debug=fast",
            "plot.enabled=true",
            "optimizer.population=4",
            "optimizer.generations=2",
            "objective.w_d=0,1",
            "optimizer.seed=0,1",
            f"paths.output_dir={out}",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = next((out / "sweeps").rglob("report.html"))
    shot = tmp_path / "report.png"
    browser = subprocess.run(
        [
            _chromium(),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1280,2000",
            "--enable-logging=stderr",
            "--v=0",
            f"--screenshot={shot}",
            report.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    console = [ln for ln in browser.stderr.splitlines() if "CONSOLE" in ln]
    assert any("pm-design report ready: 4 runs" in ln for ln in console), browser.stderr[-2000:]
    assert not [ln for ln in console if "Uncaught" in ln or "Error" in ln], console
    assert_not_blank(shot)
    # usable at 800 px: the page does not overflow sideways, and the figures fit
    narrow = subprocess.run(
        [
            _chromium(),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=800,1600",
            "--enable-logging=stderr",
            "--v=0",
            f"--screenshot={tmp_path / 'narrow.png'}",
            report.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    widths = [ln for ln in narrow.stderr.splitlines() if "pm-design page width" in ln]
    assert widths, narrow.stderr[-2000:]
    width, of = re.search(r"page width (\d+) of (\d+)", widths[0]).groups()
    assert int(width) <= int(of) <= 800, widths[0]
    # the links are relative and still resolve once the sweep folder is moved elsewhere
    moved = tmp_path / "moved"
    shutil.copytree(report.parent, moved)
    for link in re.findall(r'href="([^"]+)"', (moved / "report.html").read_text()):
        assert (moved / unquote(link)).is_file(), link
    # the same command on the aggregated dataset
    dataset_report = subprocess.run(
        [sys.executable, "-m", "pipeline.report", str(out / "dataset"), "--out", str(tmp_path / "dataset.html")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert dataset_report.returncode == 0, dataset_report.stderr
    assert "4 complete runs" in (tmp_path / "dataset.html").read_text()
