"""A full H4 mixed-index GA run (seed 000 settings: 30 x 150) with 1 and with 2 workers.

Run: ``python -m benchmarks.ga [--w-d 0.5] [--seed 0] [--dispatch]``. Prints the
wall time of each run, the ratio, and checks that both runs give the same history.
Goals (issue 14): <= 8 s with 2 workers; 2 workers >= 1.8x faster than 1.

``--dispatch`` also replays the run's batches through three ways of splitting
a batch over two processes, side by side: one loky future per chunk (what the
evaluator did before ``pipeline/evaluation/workers.py``), the caller's chunk plus one
loky future, and the caller's chunk plus one request to a worker group (what
it does now).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from joblib.externals.loky import ProcessPoolExecutor

from pipeline.config import MechanismConfig
from pipeline.evaluation import DesignEvaluator, MechanismSpec
from pipeline.evaluation.evaluator import _evaluate_chunk
from pipeline.objectives import objective_values
from pipeline.optimizers.base import Problem
from pipeline.optimizers.ga import genetic_algorithm
from pipeline.evaluation.workers import WorkerGroup


def run(n_jobs: int, w_d: float, seed: int, batches: list[np.ndarray]):
    """One GA run on ``n_jobs`` workers: (seconds, result); each batch evaluated is appended to ``batches``."""
    # the design box of the pipeline's config (the class's, unless overridden)
    mechanism = MechanismConfig(name="h4")
    evaluator = DesignEvaluator(mechanism, None, n_jobs)

    def fitness(designs: np.ndarray) -> np.ndarray:
        batches.append(designs.copy())
        return objective_values("mixed", evaluator.evaluate(designs), w_d)

    problem = Problem(fitness, mechanism.design.lower, mechanism.design.upper)
    evaluator.evaluate(np.vstack([problem.lower, problem.upper]))  # start the workers outside the timing
    t0 = time.perf_counter()
    result = genetic_algorithm(problem, problem.lower, problem.upper, seed=seed)
    return time.perf_counter() - t0, result


def dispatch_comparison(batches: list[np.ndarray]) -> None:
    """Time the same batches (each (P, 3) H4 designs) evaluated four ways; print seconds and ratios."""
    spec = MechanismSpec.of(MechanismConfig(name="h4"))

    def chunk(designs):
        return _evaluate_chunk(spec, None, designs)

    def serial():
        for batch in batches:
            chunk(batch)

    futures_pool = ProcessPoolExecutor(max_workers=2)
    caller_pool = ProcessPoolExecutor(max_workers=1)
    group = WorkerGroup(1, preload=("pipeline.evaluation",))

    def futures_per_chunk():
        for batch in batches:
            parts = [futures_pool.submit(_evaluate_chunk, spec, None, c) for c in np.array_split(batch, 2)]
            [f.result() for f in parts]

    def caller_and_future():
        for batch in batches:
            first, second = np.array_split(batch, 2)
            future = caller_pool.submit(_evaluate_chunk, spec, None, second)
            chunk(first)
            future.result()

    def caller_and_group():
        for batch in batches:
            first, second = np.array_split(batch, 2)
            group.map(_evaluate_chunk, [(spec, None, second)], local=lambda: chunk(first))

    ways = {"one process": serial, "a loky future per chunk": futures_per_chunk,
            "caller's chunk + a loky future": caller_and_future, "caller's chunk + worker group": caller_and_group}
    # start the workers and load the kernels outside the timing
    for pool, n in ((futures_pool, 2), (caller_pool, 1)):
        [f.result() for f in [pool.submit(_evaluate_chunk, spec, None, batches[0][:1]) for _ in range(n)]]
    group.map(_evaluate_chunk, [(spec, None, batches[0][:1])], local=lambda: None)
    times = {}
    for name, way in ways.items():
        t0 = time.perf_counter()
        way()
        times[name] = time.perf_counter() - t0
    print(f"the run's {len(batches)} batches evaluated four ways:")
    for name, seconds in times.items():
        print(f"  {name:32s} {seconds:5.2f} s  ({times['one process'] / seconds:.2f}x one process)")
    group.close()
    futures_pool.shutdown()
    caller_pool.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--w-d", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dispatch", action="store_true",
                        help="also compare ways of splitting a batch over two processes")
    args = parser.parse_args()
    times, results, batches = {}, {}, []
    for n_jobs in (1, 2):
        times[n_jobs], results[n_jobs] = run(n_jobs, args.w_d, args.seed, batches if n_jobs == 1 else [])
        r = results[n_jobs]
        print(f"n_jobs={n_jobs}: {times[n_jobs]:6.1f} s, {r.n_evaluations} evaluations "
              f"({r.n_evaluations / times[n_jobs]:.0f}/s), best eta {r.fun:.5f} at {np.round(r.x, 5)}")
    cols = [c for c in results[1].history.columns if c != "wall_time"]
    same = results[1].history[cols].equals(results[2].history[cols])
    print(f"speed-up of 2 workers over 1: {times[1] / times[2]:.2f}x (goal >= 1.8x); "
          f"2-worker run {times[2]:.1f} s (goal <= 8 s); identical histories: {same}")
    if args.dispatch:
        dispatch_comparison(batches)


if __name__ == "__main__":
    main()
