"""Stage 3, optimise: the GA (or DE) for the configured objective and w_d.

Returns the per-generation history and the optimum with its evaluation at
the run's resolution and re-evaluated at ``refine_factor`` times it.
"""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd

from kinematics import MECHANISMS
from pipeline.de import differential_evolution
from pipeline.evaluate import design_objective, evaluate_designs
from pipeline.ga import genetic_algorithm
from pipeline.objective import EVALUATION_FIELDS

log = logging.getLogger(__name__)


def optimise_design(mechanism: dict, evaluate: dict, objective: dict, optimizer: dict,
                    sample: dict | None, code_version: str, table: pd.DataFrame | None = None,
                    n_jobs: int = 2) -> dict:
    """Run the optimiser; ``sample`` is given only when seeding from the sampled designs.

    ``table`` is the evaluate stage's output for ``sample`` (not keyed; used to
    pick the starting designs when ``optimizer.seed_from_samples``).

    Returns
    -------
    dict
        ``history`` (DataFrame, one row per generation; wall time excluded so
        the output is a function of the config only), ``best`` (dict of
        scalars: design variables, mechanism parameters, fitness, evaluation
        at the run's resolution and ``*_refined`` at ``refine_factor`` x), and
        ``wall_time`` (list of seconds per generation).
    """
    names = list(mechanism["design"]["names"])
    fitness = design_objective(mechanism, evaluate, objective, n_jobs=n_jobs)
    lower = np.array(mechanism["design"]["lower"], dtype=float)
    upper = np.array(mechanism["design"]["upper"], dtype=float)
    log.info("optimise: computing %s for %s, objective %s, w_d %.3f", optimizer["name"],
             mechanism["name"], objective["name"], objective["w_d"])
    initial = None
    if sample is not None and optimizer["seed_from_samples"]:
        if table is None:
            table = evaluate_designs(mechanism, sample, evaluate, code_version, n_jobs=n_jobs)
        scores = fitness.fitness_of(table[list(EVALUATION_FIELDS)].to_numpy(dtype=float))
        best_rows = np.argsort(-scores, kind="stable")[: int(optimizer["seed_count"])]
        initial = table.iloc[best_rows][names].to_numpy()
    if optimizer["name"] == "ga":
        result = genetic_algorithm(
            fitness, lower, upper, population=int(optimizer["population"]),
            generations=int(optimizer["generations"]), seed=int(optimizer["seed"]),
            selection_q=float(optimizer["selection_q"]), crossover_rate=float(optimizer["crossover_rate"]),
            mutation_rate=float(optimizer["mutation_rate"]),
            mutation_shape=float(optimizer["mutation_shape"]), initial=initial)
    else:
        result = differential_evolution(fitness, lower, upper, population=int(optimizer["population"]),
                                        generations=int(optimizer["generations"]),
                                        seed=int(optimizer["seed"]))
    history = result.history.rename(columns={f"x{j}": name for j, name in enumerate(names)})
    wall_time = history.pop("wall_time").tolist()

    best = {name: float(v) for name, v in zip(names, result.x)}
    params = MECHANISMS[mechanism["name"]].from_design(result.x, **mechanism["fixed"]).params()
    best.update({f"param_{k}": float(v) for k, v in params.items() if np.isscalar(v)})
    best["fitness"] = float(result.fun)
    best["n_evaluations"] = int(result.n_evaluations)
    base = dict(zip(EVALUATION_FIELDS, fitness.evaluate_batch(result.x[None, :])[0]))
    factor = int(evaluate["refine_factor"])
    refined_objective = design_objective(
        mechanism, {**evaluate, "resolution": _resolution(mechanism, evaluate, result.x)},
        objective, n_jobs=1, factor=factor)
    refined = dict(zip(EVALUATION_FIELDS, refined_objective.evaluate_batch(result.x[None, :])[0]))
    for field in EVALUATION_FIELDS:
        if field != "valid":
            best[field] = float(base[field])
            best[f"{field}_refined"] = float(refined[field])
    w_d = float(objective["w_d"])
    best["eta"] = w_d * best["gdi"] + (1.0 - w_d) * best["suri"]
    best["eta_refined"] = w_d * best["gdi_refined"] + (1.0 - w_d) * best["suri_refined"]
    best["volume_change_refined"] = _relative_change(best["volume"], best["volume_refined"])
    best["gdi_change_refined"] = _relative_change(best["gdi"], best["gdi_refined"])
    return {"history": history, "best": best, "wall_time": wall_time}


def _resolution(mechanism: dict, evaluate: dict, design: np.ndarray) -> int:
    """The run's resolution (explicit, or the mechanism's default for this design)."""
    if evaluate.get("resolution") is not None:
        return int(evaluate["resolution"])
    from kinematics.workspace import default_resolution

    mech = MECHANISMS[mechanism["name"]].from_design(design, **mechanism["fixed"])
    orientation = mechanism.get("orientation")
    return default_resolution(mech, None if orientation is None else tuple(orientation))


def _relative_change(value: float, refined: float) -> float:
    return float((refined - value) / value) if value else 0.0
