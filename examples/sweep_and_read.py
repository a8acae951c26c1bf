# %% [markdown]
# # A small sweep, read back with pandas (a jupytext "percent" notebook)
#
# Works both ways: open it in Jupyter (with jupytext, or paste the cells; the tests run it in a
# real kernel through nbclient) or run it as a script, `python examples/sweep_and_read.py [DIR]`.
# It runs a w_d sweep of the planar 2-RPR through the pipeline (tiny sizes), reads the dataset
# with its units, and draws the trade-off inline (importing the package leaves matplotlib's
# backend alone, so figures show in a notebook).
#
# Results go to `DIR` (script), else `$PM_DESIGN_EXAMPLE_OUT`, else a new temporary folder.

# %%
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt


def output_folder() -> Path:
    """DIR from the command line when run as a script; a kernel's argv (``-f file.json``) is not one."""
    in_kernel = "ipykernel" in sys.modules
    if not in_kernel and len(sys.argv) > 1:
        return Path(sys.argv[1])
    if os.environ.get("PM_DESIGN_EXAMPLE_OUT"):
        return Path(os.environ["PM_DESIGN_EXAMPLE_OUT"])
    return Path(tempfile.mkdtemp(prefix="pm-design-"))


out = output_folder()
backend_before = plt.get_backend()
print(f"results in {out}")

# %%
proc = subprocess.run(
    [
        sys.executable,
        "-m",
        "pipeline",
        "-m",
        "+experiment=rpr2_mixed",
        "+debug=fast",
        "plot.enabled=true",
        "optimizer.population=6",
        "optimizer.generations=5",
        "objective.w_d=0,0.5,1",
        f"paths.output_dir={out}",
    ],
    capture_output=True,
    text=True,
)
print(proc.stdout)
assert proc.returncode == 0, proc.stderr[-2000:]

# %%
from pipeline.store import read_dataset  # noqa: E402  (importing pipeline keeps matplotlib's backend)

assert plt.get_backend() == backend_before, "importing pipeline changed matplotlib's backend"
# the sweep ran with +debug=fast (tiny sizes): debug runs are left out of the default view, so ask for them
best = read_dataset(out / "dataset", "best", purposes=None)
units = best.attrs["units"]
columns = [
    "mechanism",
    "w_d",
    "b",
    "q_min",
    "param_q_max_mm",
    "objective_value",
    "gdi",
    "suri",
    "volume",
    "volume_unit",
]
# a unit that names another column (volume: "volume_unit") is that column's value in each row
print({c: ", ".join(sorted(set(best[u].astype(str)))) if u in best else u for c in columns if (u := units.get(c))})
best[columns]

# %%
fig, ax = plt.subplots(figsize=(5, 3.5))
best = best.sort_values("w_d")
ax.plot(best["w_d"], best["gdi"], "o-", label="GDI")
ax.plot(best["w_d"], best["suri"], "s-", label="SURI")
ax.plot(best["w_d"], best["objective_value"], "^-", label="η")
ax.set_xlabel("$w_d$ [1]")
ax.set_ylabel("GDI, SURI, η [1]")
ax.set_title("2-RPR optima versus $w_d$ (tiny sizes)")
ax.legend()
fig.savefig(out / "tradeoff_example.png", dpi=150, bbox_inches="tight")  # the x label inside the file
print(f"wrote {out / 'tradeoff_example.png'}; the sweep's report: {next((out / 'sweeps').rglob('report.html'))}")
