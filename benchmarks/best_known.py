"""Best-known optima of the benchmark problems: computed once, written as golden values.

``python -m benchmarks.best_known`` runs :func:`pipeline.optimizers.reference.best_known`
(CMA-ES seeds 0-3, DE, a dense 9-point-per-variable grid; each polished) on each problem of
:data:`PROBLEMS`, built exactly as the pipeline builds them (the mechanism's default
resolution and readings), re-evaluates the optimum at 4x the resolution for its
discretisation error, and writes ``benchmarks/best_known.json``: per problem the optimum,
its design, how it was found (every search's value), the resolution, the error estimate
and the code that computed it (package version + source hash, and a digest of the objective's
sources: ``kinematics/`` and ``pipeline/objectives.py``).

benchmarks/optimiser_seeds.py reads the file and refuses a record whose design no longer
evaluates to its value (the objective changed: regenerate, a few minutes on 2 cores). ``--problem NAME`` recomputes one.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

import kinematics
import pipeline
from kinematics.workspace import default_resolution
from pipeline.config import EvaluateConfig, MechanismConfig
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import objective_values
from pipeline.optimizers.base import Problem
from pipeline.optimizers.reference import best_known
from pipeline.stages.optimise import gap_label
from pipeline.store.cache import CODE_VERSION

#: the benchmark problems: experiment name -> (mechanism, objective, w_d)
PROBLEMS = {
    "h4_mixed": ("h4", "mixed", 0.5),
    "h4_max_volume": ("h4", "volume", 0.0),
    "tricept_max_volume": ("tricept", "volume", 0.0),
    "rpr3_mixed": ("rpr3", "mixed", 0.5),
}
GOLDEN = Path(__file__).with_name("best_known.json")
#: the error estimate re-evaluates the optimum at this multiple of the default resolution
REFINE_FACTOR = 4
#: the workspace integration of the problems: the pipeline's default (``evaluate.method``)
METHOD = EvaluateConfig().method


def objective_digest() -> str:
    """Hash of the sources that define the objective (``kinematics/*.py``, ``pipeline/objectives.py``)."""
    digest = hashlib.sha256()
    root = Path(kinematics.__file__).parent
    for path in sorted([*root.glob("*.py"), Path(pipeline.__file__).parent / "objectives.py"]):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def make_problem(name: str, n_jobs: int = 2, resolution: int | None = None) -> Problem:
    """The problem ``name`` of :data:`PROBLEMS` as the pipeline builds it (maximised, design units)."""
    mechanism, objective, w_d = PROBLEMS[name]
    config = MechanismConfig(name=mechanism)
    evaluator = DesignEvaluator(config, resolution, n_jobs, METHOD)
    return Problem(
        lambda x: objective_values(objective, evaluator.evaluate(x), w_d), config.design.lower, config.design.upper
    )


def default_resolution_of(name: str, x: np.ndarray) -> int:
    config = MechanismConfig(name=PROBLEMS[name][0])
    return int(default_resolution(config.build(x), config.orientation_rad(), None, METHOD))


def compute(name: str) -> dict:
    """The golden record of one problem (see the module docstring)."""
    start = time.perf_counter()
    problem = make_problem(name)
    found = best_known(problem)
    resolution = default_resolution_of(name, found.x)
    refined = float(make_problem(name, 1, resolution * REFINE_FACTOR)(found.x[None])[0])
    config = MechanismConfig(name=PROBLEMS[name][0])
    return {
        "mechanism": PROBLEMS[name][0],
        "objective": PROBLEMS[name][1],
        "w_d": PROBLEMS[name][2],
        "value": found.fun,
        "design": dict(zip(config.design.names, map(float, found.x))),
        "found_by": found.found_by,
        "agreeing": found.agreeing,
        "searches": [
            {"method": s.method, "value": s.value, "n_evaluations": s.n_evaluations, "design": [float(v) for v in s.x]}
            for s in found.searches
        ],
        "n_evaluations": found.n_evaluations,
        "method": METHOD,
        "resolution": resolution,
        "value_refined": refined,
        "refine_factor": REFINE_FACTOR,
        "error": abs(refined - found.fun),
        "relative_error": abs(refined - found.fun) / abs(found.fun),
        "code_version": CODE_VERSION,
        "objective_digest": objective_digest(),
        "computed": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "wall_time_s": round(time.perf_counter() - start, 1),
    }


def load(check: list[str] | None = None) -> dict:
    """The golden records; refuse those of ``check`` (names) whose objective changed since.

    The check re-evaluates each record's design (one evaluation) and compares it with the
    recorded value (relative 1e-9): an objective changed anywhere near the optimum is caught,
    while an edit of the sources that leaves the objective as it was (a new opt-in method, a
    faster kernel) does not throw the golden values away.
    """
    records = json.loads(GOLDEN.read_text())
    stale = []
    for name in check or []:
        if name not in records:
            stale.append(name)
            continue
        x = np.array(list(records[name]["design"].values()))
        value = float(make_problem(name, 1)(x[None])[0])
        if abs(value - records[name]["value"]) > 1e-9 * abs(records[name]["value"]):
            stale.append(f"{name} ({records[name]['value']:.8g} recorded, {value:.8g} now)")
    if stale:
        raise SystemExit(
            f"benchmarks/best_known.json is stale for {', '.join(stale)} (the objective "
            f"changed): regenerate with python -m benchmarks.best_known"
        )
    return records


def save(records: dict) -> None:
    GOLDEN.write_text(json.dumps(records, indent=1) + "\n")


def refined_value(name: str, x: np.ndarray) -> float:
    """The objective of design ``x`` at :data:`REFINE_FACTOR` x its default resolution."""
    return float(make_problem(name, 1, default_resolution_of(name, x) * REFINE_FACTOR)(x[None])[0])


def labelled_gap(value: float, error: float, record: dict) -> str:
    """The gap of a run's ``value`` (its discretisation ``error``, objective units) to the best known
    ``record``, as the pipeline labels it (:func:`pipeline.stages.optimise.gap_label`, the error of
    the gap being the two errors' sum): "within error" where the gap is below it, else the gap's
    percentage with that error."""
    scale = abs(record["value"])
    return gap_label((record["value"] - value) / scale, (error + record["error"]) / scale)


def adopt(records: dict, name: str, value: float, x: np.ndarray, found_by: str) -> bool:
    """Make ``(value, x)`` the best known optimum of ``name`` if it beats the record.

    Why: the best known is the best value any search of the benchmarks has found; a
    benchmark's run that beats it becomes it (written back to ``best_known.json``, ``found_by``
    naming the run) before gaps are measured against it. Returns whether it did.
    """
    record = records[name]
    if value <= record["value"]:
        return False
    refined = refined_value(name, x)
    records[name] = {
        **record,
        "value": float(value),
        "design": dict(zip(record["design"], map(float, x))),
        "found_by": found_by,
        "value_refined": refined,
        "error": abs(refined - value),
        "relative_error": abs(refined - value) / abs(value),
        "computed": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
    }
    save(records)
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--problem", choices=sorted(PROBLEMS), action="append", help="recompute only these (default: all)"
    )
    args = parser.parse_args()
    records = load() if GOLDEN.exists() else {}
    for name in args.problem or PROBLEMS:
        records[name] = compute(name)
        r = records[name]
        print(
            f"{name}: {r['value']:.8g} at {r['design']} by {r['found_by']} ({r['agreeing']} of "
            f"{len(r['searches'])} searches agree within 0.1 %), error {100 * r['relative_error']:.3g} %, "
            f"{r['n_evaluations']} evaluations, {r['wall_time_s']} s",
            flush=True,
        )
        save(records)


if __name__ == "__main__":
    main()
