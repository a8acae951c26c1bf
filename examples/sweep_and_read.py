# %% [markdown]
# # A small sweep, read back with pandas (a jupytext "percent" notebook)
#
# Open it in Jupyter with jupytext, or run it as a script:
# `python examples/sweep_and_read.py [output dir]`. It runs a w_d sweep of the
# planar 2-RPR through the pipeline (tiny sizes), reads the dataset the way the
# README says, and draws the trade-off inline (importing the package leaves
# matplotlib's backend alone, so figures show in a notebook).

# %%
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="pm-design-"))
backend_before = plt.get_backend()

# %%
subprocess.run([sys.executable, "-m", "pipeline", "-m", "+experiment=rpr2_mixed", "+debug=fast",
                "optimizer.population=6", "optimizer.generations=5", "objective.w_d=0,0.5,1",
                f"paths.output_dir={out}"], check=True)

# %%
import pipeline.stages.plot  # noqa: E402,F401  (the package is importable in a notebook without side effects)

assert plt.get_backend() == backend_before, "importing pipeline changed matplotlib's backend"
best = pd.read_parquet(out / "dataset" / "best")
print(best[["mechanism", "w_d", "b", "q_min", "objective_value", "gdi", "suri", "volume", "volume_unit"]])

# %%
fig, ax = plt.subplots(figsize=(5, 3.5))
best = best.sort_values("w_d")
ax.plot(best["w_d"], best["gdi"], "o-", label="GDI")
ax.plot(best["w_d"], best["suri"], "s-", label="SURI")
ax.set_xlabel("$w_d$")
ax.set_ylabel("index [1]")
ax.legend()
fig.savefig(out / "tradeoff_example.png", dpi=150)
print(f"wrote {out / 'tradeoff_example.png'}")
