"""examples/: the notebook runs as a script AND in a real Jupyter kernel (nbclient), from a fresh folder.

The example is a jupytext "percent" file; :func:`percent_to_notebook` turns its ``# %%`` cells
into an nbformat notebook (markdown cells for ``# %% [markdown]``), which nbclient executes in
an ipykernel started from this environment, where ``sys.argv`` is the kernel's own (``-f ...``).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "sweep_and_read.py"


def percent_to_notebook(path: Path):
    """An nbformat v4 notebook of a jupytext percent-format script."""
    import nbformat

    cells, kind, lines = [], None, []

    def flush():
        text = "\n".join(lines).strip("\n")
        if kind == "markdown":
            cells.append(
                nbformat.v4.new_markdown_cell(
                    "\n".join(ln[2:] if ln.startswith("# ") else ln.lstrip("#") for ln in text.splitlines())
                )
            )
        elif kind == "code" and text:
            cells.append(nbformat.v4.new_code_cell(text))

    for line in path.read_text().splitlines():
        if line.startswith("# %%"):
            flush()
            kind, lines = ("markdown" if "[markdown]" in line else "code"), []
        else:
            lines.append(line)
    flush()
    return nbformat.v4.new_notebook(
        cells=cells, metadata={"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}}
    )


def assert_figure(path: Path) -> None:
    image = mpimg.imread(path)
    assert image[..., :3].std() > 0.05, f"{path} is (nearly) blank"


@pytest.mark.slow
def test_example_notebook_runs_in_a_jupyter_kernel(tmp_path, monkeypatch):
    from nbclient import NotebookClient

    out = tmp_path / "out"
    monkeypatch.setenv("PM_DESIGN_EXAMPLE_OUT", str(out))
    notebook = percent_to_notebook(EXAMPLE)
    assert sum(c.cell_type == "code" for c in notebook.cells) >= 4
    NotebookClient(
        notebook, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    outputs = "".join(o.get("text", "") for c in notebook.cells if c.cell_type == "code" for o in c.outputs)
    assert "wrote" in outputs and "mm" in outputs  # the units read back with the dataset
    # a unit that names another column is shown as that column's value (it printed 'volume_unit')
    assert "'volume': 'mm²'" in outputs and "'objective_value': '1'" in outputs, outputs
    html = [o for c in notebook.cells if c.cell_type == "code" for o in c.outputs if "text/html" in o.get("data", {})]
    assert html, "the dataset table is displayed as a DataFrame"
    assert_figure(out / "tradeoff_example.png")
    assert next((out / "sweeps").rglob("report.html")).stat().st_size > 10_000


@pytest.mark.slow
def test_example_runs_as_a_script_from_a_fresh_folder(tmp_path):
    proc = subprocess.run(
        [sys.executable, str(EXAMPLE), "results"], capture_output=True, text=True, cwd=tmp_path, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert_figure(tmp_path / "results" / "tradeoff_example.png")


def test_percent_cells_become_notebook_cells():
    notebook = percent_to_notebook(EXAMPLE)
    assert notebook.cells[0].cell_type == "markdown" and notebook.cells[0].source.startswith("# A small sweep")
    assert all(c.source.strip() for c in notebook.cells)
