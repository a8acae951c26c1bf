"""Stage 3, optimise: the configured optimiser, then polish, reference and sensitivity probe.

Steps (each optional part set in the optimiser's config):

1. the optimiser (:data:`pipeline.optimizers.OPTIMIZERS`) on the configured
   objective (a Pareto optimiser on its two objectives; its front member
   best on the configured objective is taken);
2. ``polish``: :func:`pipeline.optimizers.polish.polish` from that design;
3. the result of 1-2 is the run's optimum; it is re-evaluated at
   ``refine_factor`` times the resolution, and probed for flat variables
   (:func:`pipeline.optimizers.sensitivity.flat_intervals`);
4. ``reference``: the problem's reference optimum, the best of several
   independent searches (:func:`pipeline.optimizers.reference.best_known`),
   computed once per problem by :func:`reference_stage` (a cached stage of its
   own: every optimiser and seed of a problem shares it; its optimum is re-evaluated
   with the run's in step 3), and the run's gap to it is recorded (``reference_value``, ``<name>_reference``,
   ``reference_gap``, ``reference_found_by``, ``reference_evaluations``). The
   paper-faithful GA keeps its own result as the run's optimum (it is what
   the paper did) and says how far it stops short. ``n_evaluations`` counts
   the run's own evaluations only, never the reference's.

Error bars (issue 23): the estimated discretisation error of an optimum's
objective is its change at ``refine_factor`` times the resolution
(``objective_error``, ``reference_error``); the gap's error is the sum of the
two, relative to the reference (``reference_gap_error``), and a gap whose size is below it
is "within error" (``reference_gap_within_error``, ``reference_gap_label``),
never a precise percentage; a run better than the reference by more than the
error is labelled as beating it.

Stages and their cache keys (:func:`optimise_design` runs them; :func:`stage_runner` caches
each in a run): ``optimise`` (:func:`optimiser_run`: steps 1-2 and the probe) and ``reference``
(:func:`reference_stage`: the searches of step 4) are keyed on the mechanism, resolution,
integration method and objective (and the optimiser's config and starting designs); only
``refine`` (:func:`refine_stage`: the re-evaluations of step 3 and of the reference's optimum)
takes ``refine_factor``. Changing ``refine_factor`` reruns only those few evaluations.

Designs met twice within a run are evaluated once (an in-run memo).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
import pandas as pd

from kinematics.workspace import default_resolution
from pipeline.config import MechanismConfig, ObjectiveConfig
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import EVALUATION_FIELDS, OBJECTIVES, objective_values
from pipeline.optimizers import OPTIMIZERS, OptimizerConfig, Problem
from pipeline.optimizers.polish import polish
from pipeline.optimizers.reference import best_known
from pipeline.optimizers.sensitivity import flat_intervals
from pipeline.stages.evaluate import evaluation_frame
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


#: how :func:`optimise_design` runs its cached parts: ``runner(name, func, *args, **kwargs)``, set by
#: :func:`stage_runner` (the run's chain caches each and records it in the manifest); unset, each
#: part is a plain call (a direct call of :func:`optimise_design`, e.g. from a test or a notebook)
_RUNNER: ContextVar[Callable | None] = ContextVar("stage_runner", default=None)


@contextmanager
def stage_runner(runner: Callable) -> Iterator[None]:
    """Run the parts of :func:`optimise_design` (``optimise``, ``reference``, ``refine``) through
    ``runner(name, func, *args, **kwargs)`` within the block (the run's cached stages)."""
    token = _RUNNER.set(runner)
    try:
        yield
    finally:
        _RUNNER.reset(token)


def _run(name: str, func: Callable, *args: object, **kwargs: object) -> object:
    runner = _RUNNER.get()
    return func(*args, **kwargs) if runner is None else runner(name, func, *args, **kwargs)


def optimise_design(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    refine_factor: int,
    objective: ObjectiveConfig,
    optimizer: OptimizerConfig,
    initial: np.ndarray | None = None,
    reference: dict | None = None,
    n_jobs: int = 1,
) -> dict:
    """Run the optimisation of one study: :func:`optimiser_run`, :func:`reference_stage` and
    :func:`refine_stage`, put together by :func:`optimum_result`.

    Each part is a cached stage of its own in a run (:func:`stage_runner`), keyed on what it
    depends on: ``refine_factor`` reaches only :func:`refine_stage`, so a run that changes it
    alone reads the optimiser's run and the reference from the cache.

    Parameters
    ----------
    mechanism, objective, optimizer
        Typed config sections.
    resolution : int or None
        Grid resolution of the fitness (None: the mechanism's default for the method).
    method : str
        Workspace integration method (``evaluate.method``: grid or midpoint), of the
        fitness and of the refined evaluation alike.
    refine_factor : int
        The optimum (and the reference) is re-evaluated at this multiple of the resolution.
    initial : ndarray (k, n_design), optional
        Starting designs (the best sampled ones), used where the optimiser takes them.
    reference : dict, optional
        The problem's :func:`reference_stage` (computed here when ``optimizer.reference`` is
        set and none is given). One that carries its ``error`` already (objective unit) is
        taken as it is; otherwise its optimum is re-evaluated with the run's.

    Returns
    -------
    dict
        ``history`` (DataFrame per generation, wall time removed), ``wall_time``
        (list of s), ``best`` (dict of scalars: see :func:`optimum_result`) and
        ``front`` (DataFrame of a Pareto optimiser's non-dominated designs, or None).
    """
    run = _run("optimise", optimiser_run, mechanism, resolution, method, objective, optimizer, initial, n_jobs=n_jobs)
    if optimizer.reference and reference is None:
        reference = _run("reference", reference_stage, mechanism, resolution, method, objective, n_jobs=n_jobs)
    if not optimizer.reference:
        reference = None
    reference_x = None if reference is None or "error" in reference else np.asarray(reference["x"], dtype=float)
    refined = _run("refine", refine_stage, mechanism, resolution, method, refine_factor, run["x"], reference_x)
    return optimum_result(mechanism, resolution, method, objective, run, reference, refined)


def optimiser_run(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    objective: ObjectiveConfig,
    optimizer: OptimizerConfig,
    initial: np.ndarray | None = None,
    n_jobs: int = 1,
) -> dict:
    """The optimiser, its polish and the flat-variable probe at the run's resolution (the
    ``optimise`` stage; independent of ``refine_factor`` and of the reference).

    Parameters
    ----------
    mechanism, objective, optimizer, resolution, method, initial
        As :func:`optimise_design`.

    Returns
    -------
    dict
        ``x`` (ndarray (n_design,), design units: the run's optimum), ``value`` (its objective,
        objective unit), ``optimizer_value`` (the optimiser's own, before the polish),
        ``found_by``, ``polish_improvement``, ``n_evaluations`` (the run's own),
        ``evaluation`` (ndarray (1, len(EVALUATION_FIELDS)): the optimum's evaluation at the
        run's resolution), ``flat`` (:func:`~pipeline.optimizers.sensitivity.flat_intervals`),
        ``history`` (DataFrame per generation, wall time removed), ``wall_time`` (list of s),
        ``front`` (DataFrame or None).
    """
    names = list(mechanism.design.names)
    lower, upper = np.asarray(mechanism.design.lower), np.asarray(mechanism.design.upper)
    rows = _MemoEvaluator(DesignEvaluator(mechanism, resolution, n_jobs, method))
    scalar = Problem(lambda x: objective_values(objective.name, rows(x), objective.w_d), lower, upper)
    algorithm = OPTIMIZERS[optimizer.name](optimizer)
    log.info(
        "optimise: %s on %s, objective %s%s (w_d %.3g), about %d evaluations",
        optimizer.name,
        mechanism.name,
        objective.name,
        _in_unit(objective_unit(mechanism, objective.name)),
        objective.w_d,
        algorithm.expected_evaluations(),
    )
    if algorithm.n_objectives == 1:
        result = algorithm.run(scalar, initial)
        x, value = result.x, result.fun
        front = None
    else:
        pair = list(optimizer.objectives)
        multi = Problem(
            lambda x: np.column_stack([objective_values(n, rows(x), objective.w_d) for n in pair]),
            lower,
            upper,
            n_objectives=len(pair),
            # the history reports the run's objective of each population, not the pair's first
            score=lambda x: objective_values(objective.name, rows(x), objective.w_d),
        )
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
    history = result.history.rename(columns={f"x{j}": n for j, n in enumerate(names)})
    wall_time = history.pop("wall_time").tolist()
    # a multi-objective run evaluates outside the scalar problem: count those too
    multi_objective_evaluations = result.n_evaluations if algorithm.n_objectives > 1 else 0
    # counted before the probe below, whose evaluations are not the run's search
    n_evaluations = int(scalar.n_evaluations + multi_objective_evaluations)
    evaluation = rows(x[None, :])
    return {
        "optimizer": optimizer.name,
        "x": x,
        "value": value,
        "optimizer_value": optimizer_value,
        "found_by": found_by,
        "polish_improvement": polish_improvement,
        "n_evaluations": n_evaluations,
        "evaluation": evaluation,
        "flat": flat_intervals(scalar, x, value, names),
        "history": history,
        "wall_time": wall_time,
        "front": front,
    }


def reference_stage(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    objective: ObjectiveConfig,
    n_jobs: int = 1,
) -> dict:
    """The reference optimum of one problem (mechanism, resolution, method, objective), once.

    :func:`~pipeline.optimizers.reference.best_known` (several CMA-ES seeds, DE,
    a dense grid where the dimension allows, each polished) on the run's
    objective at the run's resolution and integration method. Its re-evaluation at
    ``refine_factor`` times the resolution (the error estimate) is :func:`refine_stage`'s, so
    that changing ``refine_factor`` never repeats the searches.

    Returns
    -------
    dict
        ``value`` (objective unit), ``x`` (list, design units), ``found_by``
        (the best search and how many searches agree), ``n_evaluations``.
    """
    rows = _MemoEvaluator(DesignEvaluator(mechanism, resolution, n_jobs, method))
    problem = Problem(
        lambda x: objective_values(objective.name, rows(x), objective.w_d),
        np.asarray(mechanism.design.lower),
        np.asarray(mechanism.design.upper),
    )
    found = best_known(problem)
    log.info(
        "reference: %.6g%s by %s, %d evaluations",
        found.fun,
        _in_unit(objective_unit(mechanism, objective.name), " "),
        found.summary(),
        found.n_evaluations,
    )
    return {
        "value": float(found.fun),
        "x": [float(v) for v in found.x],
        "found_by": found.summary(),
        "n_evaluations": int(found.n_evaluations),
    }


def refine_stage(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    refine_factor: int,
    x: np.ndarray,
    reference_x: np.ndarray | None = None,
) -> dict:
    """The run's optimum ``x`` (and the reference's, ``reference_x``) re-evaluated at
    ``refine_factor`` times the resolution, with the run's integration ``method`` (the ``refine``
    stage: the one part of a run that depends on ``refine_factor``).

    Each design's resolution is ``resolution`` or, where None, the mechanism's default for that
    design and method.

    Returns
    -------
    dict
        ``evaluation`` (ndarray (1, len(EVALUATION_FIELDS)) of ``x``), ``reference_evaluation``
        (the same of ``reference_x``, or None).
    """

    def refined(design: np.ndarray) -> np.ndarray:
        res = resolution or default_resolution(mechanism.build(design), mechanism.orientation_rad(), None, method)
        return DesignEvaluator(mechanism, res * refine_factor, 1, method).evaluate(np.asarray(design)[None, :])

    return {
        "evaluation": refined(x),
        "reference_evaluation": None if reference_x is None else refined(reference_x),
    }


def optimum_result(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    objective: ObjectiveConfig,
    run: dict,
    reference: dict | None,
    refined: dict,
) -> dict:
    """The run's result from its stages: :func:`optimiser_run`'s ``run``, the ``reference``
    (:func:`reference_stage`, or None) and :func:`refine_stage`'s ``refined``.

    Returns
    -------
    dict
        ``history``, ``wall_time``, ``front`` (as :func:`optimiser_run`) and ``best``: design,
        mechanism parameters, evaluation at the run's and at the refined resolution, the
        optimiser's columns, the reference columns (:func:`reference_columns`) and the flat
        intervals.
    """
    names = list(mechanism.design.names)
    best = _best_row(mechanism, resolution, method, objective, run["x"], run["value"], run["evaluation"], refined)
    best.update(
        optimizer_value=run["optimizer_value"],
        found_by=run["found_by"],
        polish_improvement=run["polish_improvement"],
        n_evaluations=run["n_evaluations"],
    )
    if reference is not None and "error" not in reference:
        value_refined = float(objective_values(objective.name, refined["reference_evaluation"], objective.w_d)[0])
        reference = {**reference, "value_refined": value_refined, "error": abs(value_refined - reference["value"])}
    best.update(reference_columns(best, reference, names))
    if reference is not None:
        log.info(
            "optimise: reference %.6g (%s); %s %.6g, %s",
            reference["value"],
            reference["found_by"],
            run["optimizer"],
            run["value"],
            best["reference_gap_label"],
        )
    best.update(run["flat"])
    return {"history": run["history"], "best": best, "front": run["front"], "wall_time": run["wall_time"]}


def objective_unit(mechanism: MechanismConfig, objective: str) -> str:
    """Unit of objective ``objective`` (a name of :data:`~pipeline.objectives.OBJECTIVES`) of
    ``mechanism``: its volume unit over the run's orientation range for ``volume`` (e.g.
    ``"cm³·rad"``), else the objective's own (``"1"``: dimensionless)."""
    unit = OBJECTIVES[objective].unit
    if unit != "volume":
        return unit
    return mechanism.build(mechanism.centre).volume_unit(mechanism.orientation_rad())


def _in_unit(unit: str, separator: str = " in ") -> str:
    """``unit`` for a log line after a value or a name ("" when dimensionless)."""
    return "" if unit == "1" else f"{separator}{unit}"


def within_error(gap: float, gap_error: float) -> bool:
    """Whether a relative gap to the reference is no larger than its error in size (both fractions;
    a negative gap: the run is better than the reference)."""
    return bool(abs(gap) <= gap_error)


def gap_label(gap: float, gap_error: float) -> str:
    """A relative gap to the reference as reported everywhere (best.parquet, log, figures, report):
    "within error (< e %)" where :func:`within_error` (its percentage is not quoted), "beats the
    reference by g % ± e %" for a run better than the reference by more than the error, else
    "g % ± e %". ``gap``, ``gap_error``: fractions of the reference's value."""
    if within_error(gap, gap_error):
        return f"within error (< {100 * gap_error:.2g} %)"
    spread = f"{100 * abs(gap):.3g} % ± {100 * gap_error:.2g} %"
    return f"beats the reference by {spread}" if gap < 0 else spread


def group_gap_label(runs: pd.DataFrame) -> str:
    """:func:`gap_label` of several runs of one study (seeds): their mean gap against their largest
    gap error, or, where some runs trail the reference and others beat it (each by more than the
    error: a mean would cancel them), the range of their gaps; "" where no run has a reference.
    ``runs``: rows of ``best`` with the columns ``reference_gap`` and ``reference_gap_error``
    (fractions)."""
    if "reference_gap_error" not in runs:
        return ""
    rows = runs[["reference_gap", "reference_gap_error"]].dropna()
    if rows.empty:
        return ""
    gaps, gap_error = rows["reference_gap"], float(rows["reference_gap_error"].max())
    if len(rows) == 1:
        return gap_label(float(gaps.iloc[0]), gap_error)
    if gaps.min() < -gap_error and gaps.max() > gap_error:
        return (
            f"beats the reference by up to {100 * -gaps.min():.3g} %, trails it by up to {100 * gaps.max():.3g} % "
            f"± {100 * gap_error:.2g} % ({len(rows)} runs)"
        )
    return f"{gap_label(float(gaps.mean()), gap_error)} (mean of {len(rows)})"


def reference_columns(best: dict, reference: dict | None, names: list[str]) -> dict:
    """The best row's reference columns (NaN/"" without a reference); see :data:`pipeline.store.parquet.COLUMNS`.

    The gap is relative, ``(reference - value) / |reference|``, at the run's
    resolution; its error is ``(objective_error + reference_error) / |reference|``
    (the error of a difference of two estimates); a gap within it is labelled
    "within error" and its percentage is not quoted.
    """
    if reference is None:
        out = {
            "reference_value": np.nan,
            "reference_gap": np.nan,
            "reference_error": np.nan,
            "reference_gap_error": np.nan,
            "reference_gap_within_error": False,
            "reference_gap_label": "",
            "reference_found_by": "",
            "reference_evaluations": 0,
        }
        out.update({f"{n}_reference": np.nan for n in names})
        return out
    scale = abs(reference["value"]) or 1.0
    gap = (reference["value"] - best["objective_value"]) / scale
    gap_error = (best["objective_error"] + reference["error"]) / scale
    within = within_error(gap, gap_error)
    label = gap_label(gap, gap_error)
    out = {
        "reference_value": float(reference["value"]),
        "reference_gap": float(gap),
        "reference_error": float(reference["error"]),
        "reference_gap_error": float(gap_error),
        "reference_gap_within_error": within,
        "reference_gap_label": label,
        "reference_found_by": reference["found_by"],
        "reference_evaluations": int(reference["n_evaluations"]),
    }
    out.update({f"{n}_reference": float(v) for n, v in zip(names, reference["x"])})
    return out


def _best_row(
    mechanism: MechanismConfig,
    resolution: int | None,
    method: str,
    objective: ObjectiveConfig,
    x: np.ndarray,
    value: float,
    evaluation: np.ndarray,
    refined: dict,
) -> dict:
    """Design, mechanism parameters, evaluation at the run's (``evaluation``) and at the refined
    resolution (``refined``: :func:`refine_stage`), both with the run's integration ``method``,
    recorded beside the resolution."""
    names = list(mechanism.design.names)
    best: dict = {name: float(v) for name, v in zip(names, x)}
    lower, upper = mechanism.design.lower, mechanism.design.upper
    best["at_bounds"] = ",".join(
        f"{n}={'lower' if v <= lo else 'upper'}" for n, v, lo, hi in zip(names, x, lower, upper) if v <= lo or v >= hi
    )
    mech = mechanism.build(x)
    for key, v in mech.params().items():
        # a design variable's own column already holds it (Tricept a, b, d; 2-RPR b, q_min)
        if isinstance(v, (int, float, str)) and not isinstance(v, bool) and key not in names:
            best[param_column(key, mech.param_unit(key, v))] = v
    base = evaluation_frame(evaluation).iloc[0]
    res = resolution or default_resolution(mech, mechanism.orientation_rad(), None, method)
    refined_rows = refined["evaluation"]
    refined_frame = evaluation_frame(refined_rows).iloc[0]
    for field in EVALUATION_FIELDS:
        if field != "valid":
            best[field] = base[field].item()
    best["objective_value"] = float(value)
    best["volume_refined"] = float(refined_frame["volume"])
    best["gdi_refined"] = float(refined_frame["gdi"])
    best["objective_value_refined"] = float(objective_values(objective.name, refined_rows, objective.w_d)[0])
    best["objective_error"] = abs(best["objective_value_refined"] - best["objective_value"])
    best["resolution"] = int(res)
    best["method"] = str(method)
    best["volume_unit"] = mech.volume_unit(mechanism.orientation_rad())
    best["objective_unit"] = objective_unit(mechanism, objective.name)
    return best
