"""Stage 3, optimise: the configured optimiser, then polish, reference and sensitivity probe.

Steps (each optional part set in the optimiser's config):

1. the optimiser (:data:`pipeline.optimizers.OPTIMIZERS`) on the configured
   objective (a Pareto optimiser on its two objectives; its front member
   best on the configured objective is taken);
2. ``polish``: :func:`pipeline.optimizers.polish.polish` from that design;
3. the result of 1-2 is the run's optimum; it is re-evaluated at
   ``refine_factor`` times the resolution, and probed for flat variables
   (:func:`pipeline.optimizers.sensitivity.flat_intervals`);
4. ``reference``: the reference optimiser (CMA-ES + polish, same seed) is run
   too, and its value, design and the run's relative gap to it are recorded
   (``reference_value``, ``<name>_reference``, ``reference_gap``). The
   paper-faithful GA keeps its own result as the run's optimum (it is what
   the paper did) and says how far it stops short.

Designs met twice within a run are evaluated once (an in-run memo).
"""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd

from kinematics.workspace import default_resolution
from pipeline.config import MechanismConfig, ObjectiveConfig
from pipeline.stages.evaluate import evaluation_frame
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import EVALUATION_FIELDS, OBJECTIVES, objective_values
from pipeline.optimizers import OPTIMIZERS, REFERENCE_OPTIMIZER, OptimizerConfig, Problem, reference_optimum
from pipeline.optimizers.polish import polish
from pipeline.optimizers.sensitivity import flat_intervals
from pipeline.store.parquet import param_column

log = logging.getLogger(__name__)


class _MemoEvaluator:
    """Evaluation rows of designs, each distinct design evaluated once (batch, parallel)."""

    def __init__(self, evaluator: DesignEvaluator) -> None:
        self.evaluator = evaluator
        self.memo: dict[bytes, np.ndarray] = {}

    def __call__(self, designs: np.ndarray) -> np.ndarray:
        keys = [d.tobytes() for d in designs]
        todo = [k for k in dict.fromkeys(keys) if k not in self.memo]
        if todo:
            fresh = self.evaluator.evaluate(np.array([np.frombuffer(k) for k in todo]))
            self.memo.update(zip(todo, fresh))
        return np.array([self.memo[k] for k in keys])


def optimise_design(mechanism: MechanismConfig, resolution: int | None, refine_factor: int,
                    objective: ObjectiveConfig, optimizer: OptimizerConfig,
                    initial: np.ndarray | None = None, n_jobs: int = 1) -> dict:
    """Run the optimisation of one study.

    Parameters
    ----------
    mechanism, objective, optimizer
        Typed config sections.
    resolution : int or None
        Grid resolution of the fitness (None: the mechanism's default).
    refine_factor : int
        The optimum is re-evaluated at this multiple of the resolution.
    initial : ndarray (k, n_design), optional
        Starting designs (the best sampled ones), used where the optimiser takes them.

    Returns
    -------
    dict
        ``history`` (DataFrame per generation, wall time removed), ``wall_time``
        (list of s), ``best`` (dict of scalars: see :func:`_best_row`) and
        ``front`` (DataFrame of a Pareto optimiser's non-dominated designs, or None).
    """
    names = list(mechanism.design.names)
    lower, upper = np.asarray(mechanism.design.lower), np.asarray(mechanism.design.upper)
    rows = _MemoEvaluator(DesignEvaluator(mechanism, resolution, n_jobs))
    scalar = Problem(lambda x: objective_values(objective.name, rows(x), objective.w_d), lower, upper)
    algorithm = OPTIMIZERS[optimizer.name](optimizer)
    log.info("optimise: %s on %s, objective %s (w_d %.3g), about %d evaluations", optimizer.name,
             mechanism.name, objective.name, objective.w_d, algorithm.expected_evaluations())
    if algorithm.n_objectives == 1:
        result = algorithm.run(scalar, initial)
        x, value = result.x, result.fun
        front = None
    else:
        pair = list(optimizer.objectives)
        multi = Problem(lambda x: np.column_stack([objective_values(n, rows(x), objective.w_d) for n in pair]),
                        lower, upper, n_objectives=len(pair))
        result = algorithm.run(multi, initial)
        front_x, front_values = result.front
        scores = scalar(front_x)
        x, value = front_x[int(np.argmax(scores))], float(scores.max())
        front = pd.DataFrame(front_x, columns=names)
        for k, n in enumerate(pair):
            front[n] = front_values[:, k]
        front["objective_value"] = scores
    optimizer_value, found_by = float(value), optimizer.name
    polish_improvement = 0.0
    if optimizer.polish:
        polished = polish(scalar, x, value, max_evaluations=optimizer.polish_evaluations)
        polish_improvement = polished.improvement
        if polished.fun > value:
            x, value, found_by = polished.x, polished.fun, "polish"
    reference_value, reference_x = np.nan, np.full(len(names), np.nan)
    if optimizer.reference:
        ref = reference_optimum(scalar, optimizer.seed)
        reference_value, reference_x = ref.fun, ref.x
        log.info("optimise: reference %s + polish %.6g; %s %.6g (gap %.3g %%)", REFERENCE_OPTIMIZER,
                 reference_value, optimizer.name, value, 100 * (reference_value - value) / abs(reference_value or 1))
    history = result.history.rename(columns={f"x{j}": n for j, n in enumerate(names)})
    wall_time = history.pop("wall_time").tolist()
    # a multi-objective run evaluates outside the scalar problem: count those too
    multi_objective_evaluations = result.n_evaluations if algorithm.n_objectives > 1 else 0
    best = _best_row(mechanism, resolution, refine_factor, objective, x, value, rows)
    best.update(optimizer_value=optimizer_value, found_by=found_by, polish_improvement=polish_improvement,
                reference_value=float(reference_value),
                reference_gap=float((reference_value - value) / abs(reference_value)) if reference_value else np.nan,
                n_evaluations=int(scalar.n_evaluations + multi_objective_evaluations))
    best.update({f"{n}_reference": float(v) for n, v in zip(names, reference_x)})
    best.update(flat_intervals(scalar, x, value, names))
    return {"history": history, "best": best, "front": front, "wall_time": wall_time}


def _best_row(mechanism: MechanismConfig, resolution: int | None, refine_factor: int,
              objective: ObjectiveConfig, x: np.ndarray, value: float, rows: _MemoEvaluator) -> dict:
    """Design, mechanism parameters, evaluation at the run's and at the refined resolution."""
    names = list(mechanism.design.names)
    best: dict = {name: float(v) for name, v in zip(names, x)}
    lower, upper = mechanism.design.lower, mechanism.design.upper
    best["at_bounds"] = ",".join(f"{n}={'lower' if v <= lo else 'upper'}"
                                 for n, v, lo, hi in zip(names, x, lower, upper) if v <= lo or v >= hi)
    mech = mechanism.build(x)
    for key, v in mech.params().items():
        # a design variable's own column already holds it (Tricept a, b, d; 2-RPR b, q_min)
        if isinstance(v, (int, float, str)) and not isinstance(v, bool) and key not in names:
            best[param_column(key, mech.param_unit(key, v))] = v
    base = evaluation_frame(rows(x[None, :])).iloc[0]
    res = resolution or default_resolution(mech, mechanism.orientation_rad())
    refined_rows = DesignEvaluator(mechanism, res * refine_factor, 1).evaluate(x[None, :])
    refined = evaluation_frame(refined_rows).iloc[0]
    for field in EVALUATION_FIELDS:
        if field != "valid":
            best[field] = base[field].item()
    best["objective_value"] = float(value)
    best["volume_refined"] = float(refined["volume"])
    best["gdi_refined"] = float(refined["gdi"])
    best["objective_value_refined"] = float(objective_values(objective.name, refined_rows, objective.w_d)[0])
    best["resolution"] = int(res)
    best["volume_unit"] = mech.volume_unit(mechanism.orientation_rad())
    unit = OBJECTIVES[objective.name].unit
    best["objective_unit"] = best["volume_unit"] if unit == "volume" else unit
    return best
