"""The chain of one study: sample -> evaluate -> (reference) -> optimise -> Parquet -> figures.

:func:`compute` runs the stages, each cached (:func:`pipeline.store.cache.cached`)
and recorded in the manifest's ``stages`` as ``computed`` or ``cached``; checks
the result (a non-finite or empty optimum is never written as complete); and
writes the run's tables and figures. The run's lifecycle around it (manifest,
identity, failure states) is :mod:`pipeline.study.run`.
"""

from __future__ import annotations

import logging
import multiprocessing
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import parallel_config

from pipeline.config import Config
from pipeline.errors import RunError
from pipeline.evaluation.scale import workers_for
from pipeline.objectives import EVALUATION_FIELDS, objective_values
from pipeline.stages.evaluate import evaluate_designs
from pipeline.stages.optimise import optimise_design, reference_stage, stage_runner
from pipeline.stages.plot import run_figures
from pipeline.stages.sample import sample_designs
from pipeline.store.cache import cached
from pipeline.store.parquet import write_bytes, write_parquet

log = logging.getLogger(__name__)


@contextmanager
def parallel_backend(parallel):
    """joblib backend of the fitness evaluations (``parallel`` config section)."""
    if parallel.backend == "dask":
        from dask.distributed import Client, LocalCluster

        if parallel.scheduler_address:
            client, cluster = Client(parallel.scheduler_address, timeout=10), None
        else:
            # in a loky worker (hydra/launcher=joblib runs each job in one) the start method is
            # loky's own, which the nanny's spawned child cannot look up ("cannot find context for
            # 'loky'": every job failed); the nanny's children are spawned either way
            if multiprocessing.get_start_method(allow_none=True) not in (
                None,
                *multiprocessing.get_all_start_methods(),
            ):
                multiprocessing.set_start_method("spawn", force=True)
            cluster = LocalCluster(
                n_workers=workers_for(parallel.n_jobs, parallel.n_jobs),
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
            )
            client = Client(cluster)
        try:
            with parallel_config(backend="dask"):
                yield
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    else:
        with parallel_config(backend=parallel.backend):
            yield


def compute(c: Config, run_dir: Path, timings: dict, stages: dict) -> dict[str, Path]:
    """Run the stages of ``c`` into ``run_dir``; ``timings`` (s) and ``stages`` (computed | cached)
    are the manifest's records, filled in place. Returns the paths written."""
    mech, objective, optimizer = c.mechanism, c.objective, c.optimizer
    n_jobs, cache_dir = c.parallel.n_jobs, c.paths.cache_dir
    start = time.perf_counter()
    with parallel_backend(c.parallel):
        t0 = time.perf_counter()
        designs = _stage(stages, "sample", sample_designs, cache_dir, mech.design, c.sample)
        # resolution and integration method are arguments of every evaluating stage: both in its cache key
        resolution, method = c.evaluate.resolution, c.evaluate.method
        evaluated = _stage(
            stages, "evaluate", evaluate_designs, cache_dir, mech, resolution, method, designs, n_jobs=n_jobs
        )
        timings["sample_evaluate"] = time.perf_counter() - t0
        scores = objective_values(objective.name, evaluated[list(EVALUATION_FIELDS)].to_numpy(float), objective.w_d)
        initial = None
        if getattr(optimizer, "seed_from_samples", False):
            order = np.argsort(-scores, kind="stable")[: int(optimizer.seed_count)]
            initial = evaluated.iloc[order][mech.design.names].to_numpy()
        t0 = time.perf_counter()
        # the reference optimum is a stage of its own: one per problem, shared by every optimiser and seed
        reference = (
            _stage(stages, "reference", reference_stage, cache_dir, mech, resolution, method, objective, n_jobs=n_jobs)
            if optimizer.reference
            else None
        )
        # the optimiser's run (stage "optimise") and the refined re-evaluations (stage "refine"),
        # each cached on its own: refine_factor is in the second's key only
        with stage_runner(lambda name, func, *args, **kwargs: _stage(stages, name, func, cache_dir, *args, **kwargs)):
            optimum = optimise_design(
                mech,
                resolution,
                method,
                c.evaluate.refine_factor,
                objective,
                optimizer,
                initial,
                reference=reference,
                n_jobs=n_jobs,
            )
        timings["optimise"] = time.perf_counter() - t0

    _check_result(evaluated, scores, optimum["best"])
    keys = {
        "config_hash": c.config_hash(),
        "experiment": c.experiment_name,
        "mechanism": mech.name,
        "objective": objective.name,
        "w_d": float(objective.w_d),
        "optimizer": optimizer.name,
        "seed": int(optimizer.seed),
    }
    units = {v.name: v.unit for v in mech.cls.design_variables}
    config = c.result_dict()
    designs_table = evaluated.copy()
    designs_table["objective_value"] = scores
    # every table names the units of its own columns (attrs["units"] points to these columns)
    best = optimum["best"]
    designs_table["volume_unit"] = best["volume_unit"]
    designs_table["objective_unit"] = best["objective_unit"]
    history = optimum["history"].assign(objective_unit=best["objective_unit"])
    tables = {"designs": designs_table, "history": history, "best": pd.DataFrame([best])}
    if optimum["front"] is not None:
        tables["front"] = optimum["front"].assign(
            volume_unit=best["volume_unit"], objective_unit=best["objective_unit"]
        )
    paths = {
        name: write_parquet(_with_keys(frame, keys), run_dir / f"{name}.parquet", config, units)
        for name, frame in tables.items()
    }
    if c.plot.enabled:
        t0 = time.perf_counter()
        paths.update(_plots(c, optimum, run_dir, stages))
        timings["plot"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    timings["generation_wall_time"] = optimum["wall_time"][-1] if optimum["wall_time"] else 0.0
    best = optimum["best"]
    gap = f"; against the reference: {best['reference_gap_label']}" if best["reference_gap_label"] else ""
    log.info(
        "%s: %s %.6g (%s%s), V %.6g %s, GDI %.4f, SURI %.4f",
        c.experiment_name,
        objective.name,
        best["objective_value"],
        best["found_by"],
        gap,
        best["volume"],
        best["volume_unit"],
        best["gdi"],
        best["suri"],
    )
    return paths


def _check_result(evaluated: pd.DataFrame, scores: np.ndarray, best: dict) -> None:
    """Refuse a non-finite or degenerate result: it is never written as ``complete``.

    Non-finite: any evaluation field of a valid design, any objective value,
    the optimum's objective, V, GDI or SURI (plain and refined). Degenerate:
    an optimum without workspace (V <= 0).

    Raises
    ------
    RunError
        One line naming the first bad quantity.
    """
    numeric = evaluated.loc[evaluated["valid"], [f for f in EVALUATION_FIELDS if f != "valid"]]
    bad = [name for name in numeric if not np.isfinite(numeric[name].to_numpy(float)).all()]
    if bad or not np.isfinite(scores).all():
        raise RunError(
            f"degenerate result: non-finite {', '.join(bad) or 'objective_value'} among the sampled "
            f"designs (check mechanism.fixed against the mechanism's ranges)"
        )
    for name in ("objective_value", "objective_value_refined", "volume", "volume_refined", "gdi", "suri"):
        value = best.get(name)
        if value is not None and not np.isfinite(float(value)):
            raise RunError(f"degenerate result: the optimum's {name} is {value}")
    if not float(best.get("volume", 0.0)) > 0:
        raise RunError("degenerate result: the optimum has no workspace (volume 0)")


def _stage(record: dict, name: str, func, cache_dir: str, *args, **kwargs):
    """Run a cached stage; ``record[name]`` (the manifest's ``stages``) and one log line say
    whether it was ``computed`` or read from the cache (``cached``; joblib's public
    ``check_call_in_cache``)."""
    stage = cached(func, cache_dir)
    record[name] = "cached" if stage.check_call_in_cache(*args, **kwargs) else "computed"
    log.info("%s: %s", name, "cached" if record[name] == "cached" else "computing")
    return stage(*args, **kwargs)


def _with_keys(frame: pd.DataFrame, keys: dict) -> pd.DataFrame:
    out = frame.copy()
    for k, (name, value) in enumerate(keys.items()):
        out.insert(k, name, value)
    for name in ("config_hash", "experiment", "mechanism", "objective", "optimizer"):
        out[name] = out[name].astype("string")
    out["w_d"] = out["w_d"].astype("float64")
    out["seed"] = out["seed"].astype("int64")
    return out


def _plots(c: Config, optimum: dict, run_dir: Path, stages: dict) -> dict[str, Path]:
    """The run's figures: a cached stage (drawn once per result), written into ``run_dir``."""
    figures = _stage(
        stages,
        "plot",
        run_figures,
        c.paths.cache_dir,
        c.mechanism,
        c.objective,
        c.optimizer,
        c.plot,
        optimum,
        c.purpose,
    )
    out = {}
    for name, data in figures.items():
        path = write_bytes(run_dir / name, data)
        if path.suffix == ".png":
            out[path.stem] = path
    return out
