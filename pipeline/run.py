"""One study: validate -> sample -> evaluate -> optimise -> write Parquet -> plot.

``run_study(cfg, run_dir)`` is what ``python -m pipeline`` calls for every
run of a launch (Hydra) and what the tests call with a config built by
Hydra's compose API.
"""

from __future__ import annotations

import json
import logging
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
from joblib import parallel_config
from omegaconf import DictConfig, OmegaConf

from kinematics import MECHANISMS
from pipeline.cache import CODE_VERSION, cached
from pipeline.config import ConfigError, validate
from pipeline.evaluate import evaluate_designs
from pipeline.io import write_parquet
from pipeline.optimise import optimise_design
from pipeline.plot import plot_convergence, plot_workspace
from pipeline.sample import sample_designs

log = logging.getLogger(__name__)

#: config sections that say how to run, not what to compute; kept out of the
#: result files so the same study gives bit-identical Parquet whatever the workers
EXECUTION_SECTIONS = ("parallel", "paths", "plot")


@contextmanager
def parallel_backend(parallel: dict):
    """joblib backend of the fitness evaluations (``parallel`` config node)."""
    if parallel["backend"] == "dask":
        from dask.distributed import Client, LocalCluster

        if parallel.get("scheduler_address"):
            client, cluster = Client(parallel["scheduler_address"]), None
        else:
            cluster = LocalCluster(n_workers=int(parallel["n_jobs"]), threads_per_worker=1,
                                   processes=True, host="127.0.0.1", dashboard_address=None)
            client = Client(cluster)
        try:
            with parallel_config(backend="dask"):
                yield
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    else:
        with parallel_config(backend=parallel["backend"]):
            yield


def result_config(cfg: dict) -> dict:
    """The resolved config without the execution sections (stored in every result file)."""
    return {k: v for k, v in cfg.items() if k not in EXECUTION_SECTIONS}


def run_study(cfg: DictConfig | dict, run_dir: Path) -> dict[str, Path]:
    """Run one study into ``run_dir``; returns the paths written.

    Raises
    ------
    ConfigError
        Before any computation or file, for a value out of range.
    """
    c = validate(cfg)
    run_dir = Path(run_dir)
    mech, objective, optimizer = c["mechanism"], c["objective"], c["optimizer"]
    n_jobs, cache_dir = int(c["parallel"]["n_jobs"]), c["paths"]["cache_dir"]
    timings: dict[str, float] = {}
    with parallel_backend(c["parallel"]):
        t0 = time.perf_counter()
        designs = cached(sample_designs, cache_dir)(mech, c["sample"], CODE_VERSION)
        timings["sample"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        evaluated = cached(evaluate_designs, cache_dir)(mech, c["sample"], c["evaluate"], CODE_VERSION,
                                                        designs=designs, n_jobs=n_jobs)
        timings["evaluate"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        seeding = c["sample"] if optimizer["seed_from_samples"] else None
        optimum = cached(optimise_design, cache_dir)(mech, c["evaluate"], objective, optimizer, seeding,
                                                     CODE_VERSION, table=evaluated, n_jobs=n_jobs)
        timings["optimise"] = time.perf_counter() - t0

    keys = {"experiment": c["experiment_name"], "mechanism": mech["name"], "objective": objective["name"],
            "w_d": float(objective["w_d"]), "optimizer": optimizer["name"], "seed": int(optimizer["seed"])}
    meta = result_config(c)
    designs_table = evaluated.copy()
    designs_table["eta"] = keys["w_d"] * designs_table["gdi"] + (1 - keys["w_d"]) * designs_table["suri"]
    paths = {
        "designs": write_parquet(_with_keys(designs_table, keys), run_dir / "designs.parquet", meta),
        "history": write_parquet(_with_keys(optimum["history"], keys), run_dir / "history.parquet", meta),
        "best": write_parquet(_with_keys(pd.DataFrame([optimum["best"]]), keys),
                              run_dir / "best.parquet", meta),
    }
    (run_dir / "config.yaml").write_text(OmegaConf.to_yaml(OmegaConf.create(c)))
    timings["generation_wall_time"] = optimum["wall_time"]
    if c["plot"]["enabled"]:
        t0 = time.perf_counter()
        paths.update(_plots(c, optimum, run_dir))
        timings["plot"] = time.perf_counter() - t0
    (run_dir / "timings.json").write_text(json.dumps(timings, indent=1))
    best = optimum["best"]
    log.info("%s: best fitness %.6g, V %.6g, GDI %.4f, SURI %.4f (refined x%d: V %+.2f %%, GDI %+.2f %%)",
             c["experiment_name"], best["fitness"], best["volume"], best["gdi"], best["suri"],
             c["evaluate"]["refine_factor"], 100 * best["volume_change_refined"],
             100 * best["gdi_change_refined"])
    return paths


def _with_keys(frame: pd.DataFrame, keys: dict) -> pd.DataFrame:
    out = frame.copy()
    for k, (name, value) in enumerate(keys.items()):
        out.insert(k, name, value)
    for name in ("experiment", "mechanism", "objective", "optimizer"):
        out[name] = out[name].astype("string")
    out["w_d"] = out["w_d"].astype("float64")
    out["seed"] = out["seed"].astype("int64")
    return out


def _plots(c: dict, optimum: dict, run_dir: Path) -> dict[str, Path]:
    mech_cfg = c["mechanism"]
    names = mech_cfg["design"]["names"]
    design = [optimum["best"][n] for n in names]
    mech = MECHANISMS[mech_cfg["name"]].from_design(design, **mech_cfg["fixed"])
    orientation = tuple(mech_cfg["orientation"]) if mech_cfg.get("orientation") else mech.default_orientation
    title = f"{c['experiment_name']}:"
    out = {"convergence": plot_convergence(optimum["history"], run_dir / "convergence.png",
                                           f"{title} {c['optimizer']['name']} convergence")}
    ws, ic = plot_workspace(mech, orientation, float(mech_cfg["min_inverse_condition"]), run_dir, title)
    out.update(workspace=ws, inverse_condition=ic)
    return out


def run_from_hydra(cfg: DictConfig, run_dir: str) -> None:
    """Entry of ``python -m pipeline``: a bad value prints one line and exits 2, writing nothing.

    :func:`run_study` validates before any computation or file, so a
    ConfigError leaves only the directory Hydra created, which is removed.
    """
    try:
        run_study(cfg, Path(run_dir))
    except ConfigError as exc:
        _remove_if_empty(Path(run_dir))
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)


def _remove_if_empty(path: Path) -> None:
    """Hydra creates the run directory before the task starts; leave nothing behind."""
    try:
        path.rmdir()
    except OSError:
        pass
