"""The paper GA on H4 (seed 000 settings: 30 x 150) with 1 and 2 workers, and its batch dispatch.

Run: ``python -m benchmarks.ga [--w-d 0.5] [--seed 0] [--dispatch] [--compile-ahead] [--repeats 5]``.
Prints the wall time of each GA run, the ratio, and checks that both runs give
the same history. Goals: the 2-worker run <= 1.2 s on this machine (issue 22),
2 workers >= 1.8x faster than 1 (issue 14).

``--dispatch`` replays the 1-worker run's batches, side by side, ``--repeats``
times in turn: in one process; through the evaluator's pool as it is now (the
caller's chunk plus a future on a kept loky executor, joblib's public API,
:mod:`pipeline.evaluation.pool`); and through the socket worker group it
replaced (``pipeline/evaluation/workers.py`` read from git at ``--old-ref``).
``--compile-ahead`` times the main job on an empty numba cache with and
without the compile-ahead helper it removed (the tree at ``--old-ref``, in
fresh processes). Both write their figures to ``docs/benchmarks_dispatch.md``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pipeline.config import MechanismConfig
from pipeline.evaluation import DesignEvaluator, MechanismSpec
from pipeline.evaluation.evaluator import _evaluate_chunk
from pipeline.evaluation.pool import FitnessPool
from pipeline.objectives import objective_values
from pipeline.optimizers.base import Problem
from pipeline.optimizers.ga import genetic_algorithm

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "benchmarks_dispatch.md"
#: the last commit with the socket worker group and the compile-ahead helper
OLD_REF = "81b69eb"


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


def old_tree(ref: str, into: Path) -> Path:
    """The repository's files at ``ref`` (``git archive``), extracted under ``into``."""
    tree = into / f"tree-{ref}"
    tree.mkdir()
    archive = subprocess.run(["git", "archive", ref], cwd=ROOT, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    return tree


def old_workers_module(ref: str, into: Path):
    """``pipeline/evaluation/workers.py`` at ``ref``, importable (also by loky's workers, which
    start with this process's ``sys.path``) as the module ``old_workers``."""
    source = subprocess.run(
        ["git", "show", f"{ref}:pipeline/evaluation/workers.py"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    (into / "old_workers.py").write_text(source)
    sys.path.insert(0, str(into))
    return importlib.import_module("old_workers")


def dispatch_comparison(batches: list[np.ndarray], repeats: int, ref: str, scratch: Path) -> list[str]:
    """The same batches (each (P, 3) H4 designs) evaluated three ways, ``repeats`` times in turn;
    markdown lines of seconds and ratios."""
    spec = MechanismSpec.of(MechanismConfig(name="h4"))
    old = old_workers_module(ref, scratch)

    def chunk(designs):
        return _evaluate_chunk(spec, None, designs)

    pool = FitnessPool(1, preload=("pipeline.evaluation.evaluator",))
    group = old.WorkerGroup(1, preload=("pipeline.evaluation.evaluator",))
    timeout = 60.0

    def serial():
        for batch in batches:
            chunk(batch)

    def new_pool():
        for batch in batches:
            first, second = np.array_split(batch, 2)
            pool.map(_evaluate_chunk, [(spec, None, second)], local=lambda: chunk(first), timeout=timeout)

    def old_group():
        for batch in batches:
            first, second = np.array_split(batch, 2)
            group.map(_evaluate_chunk, [(spec, None, second)], local=lambda: chunk(first))

    ways = {
        "one process": serial,
        "new: caller's chunk + loky future (pool.py)": new_pool,
        "old: caller's chunk + socket worker group (workers.py)": old_group,
    }
    # start the workers and load the kernels outside the timing
    pool.map(_evaluate_chunk, [(spec, None, batches[0][:1])], local=lambda: None, timeout=120)
    group.map(_evaluate_chunk, [(spec, None, batches[0][:1])], local=lambda: None)
    times: dict[str, list[float]] = {name: [] for name in ways}
    for _ in range(repeats):
        for name, way in ways.items():
            t0 = time.perf_counter()
            way()
            times[name].append(time.perf_counter() - t0)
    pool.close()
    group.close()
    new, old_name = list(ways)[1], list(ways)[2]
    lines = [
        f"The 1-worker GA run's {len(batches)} batches ({sum(len(b) for b in batches)} designs), "
        f"replayed {repeats} times in turn, each way on 2 processes except the first:",
        "",
        "| way | " + " | ".join(f"run {k + 1} [s]" for k in range(repeats)) + " | speed-up over one process |",
        "|---|" + "---|" * repeats + "---|",
    ]
    for name in ways:
        speedups = [a / b for a, b in zip(times["one process"], times[name])]
        lines.append(
            f"| {name} | "
            + " | ".join(f"{t:.2f}" for t in times[name])
            + f" | {min(speedups):.2f}-{max(speedups):.2f}x |"
        )
    ratios = [n / o for o, n in zip(times[old_name], times[new])]
    lines += [
        "",
        f"Speed-up of the old socket group over the new pool (new time / old time), run by run: "
        f"{', '.join(f'{r:.2f}' for r in ratios)} (median {statistics.median(ratios):.2f}). "
        f"Criterion to keep workers.py: >= 1.2. Load average when done: "
        f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores.",
    ]
    return lines


def compile_ahead_comparison(repeats: int, ref: str, scratch: Path) -> list[str]:
    """The main job on an empty numba cache (fresh process) at ``ref``, with and without the
    compile-ahead helper (``PM_DESIGN_COMPILE_AHEAD``), ``repeats`` times in turn."""
    tree = old_tree(ref, scratch)
    times: dict[str, list[float]] = {"1": [], "0": []}
    for k in range(repeats):
        for ahead in times:
            env = {
                **os.environ,
                "NUMBA_CACHE_DIR": str(scratch / f"numba-{ahead}-{k}"),
                "PM_DESIGN_COMPILE_AHEAD": ahead,
                "PYTHONPATH": str(tree),
            }
            t0 = time.perf_counter()
            proc = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pipeline",
                    "+experiment=h4_mixed",
                    f"paths.output_dir={scratch / f'out-{ahead}-{k}'}",
                ],
                cwd=tree,
                capture_output=True,
                text=True,
                env=env,
            )
            times[ahead].append(time.perf_counter() - t0)
            if proc.returncode != 0:
                raise SystemExit(f"main job at {ref} failed:\n{proc.stderr[-2000:]}")
    ratios = [off / on for on, off in zip(times["1"], times["0"])]
    return [
        f"`python -m pipeline +experiment=h4_mixed` at {ref}, empty numba and stage caches, fresh "
        f"process, {repeats} times in turn:",
        "",
        "| compile-ahead helper | " + " | ".join(f"run {k + 1} [s]" for k in range(repeats)) + " |",
        "|---|" + "---|" * repeats,
        "| on | " + " | ".join(f"{t:.1f}" for t in times["1"]) + " |",
        "| off | " + " | ".join(f"{t:.1f}" for t in times["0"]) + " |",
        "",
        f"off / on, run by run: {', '.join(f'{r:.2f}' for r in ratios)} "
        f"(median {statistics.median(ratios):.2f}). Criterion to keep compile_ahead.py: >= 1.2; "
        f"it only acts on a machine's first run (an empty numba cache). Load average when done: "
        f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores.",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--w-d", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dispatch", action="store_true", help="compare the batch dispatch, new and old")
    parser.add_argument("--compile-ahead", action="store_true", help="time the removed compile-ahead helper")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--old-ref", default=OLD_REF)
    args = parser.parse_args()
    times, results, batches = {}, {}, []
    for n_jobs in (1, 2):
        times[n_jobs], results[n_jobs] = run(n_jobs, args.w_d, args.seed, batches if n_jobs == 1 else [])
        r = results[n_jobs]
        print(
            f"n_jobs={n_jobs}: {times[n_jobs]:6.2f} s, {r.n_evaluations} evaluations "
            f"({r.n_evaluations / times[n_jobs]:.0f}/s), best eta {r.fun:.5f} at {np.round(r.x, 5)}"
        )
    cols = [c for c in results[1].history.columns if c != "wall_time"]
    same = results[1].history[cols].equals(results[2].history[cols])
    summary = (
        f"GA 30 x 150 (H4, mixed index, w_d={args.w_d}, seed {args.seed}): 1 worker {times[1]:.2f} s, "
        f"2 workers {times[2]:.2f} s (goal <= 1.2 s); speed-up {times[1] / times[2]:.2f}x "
        f"(goal >= 1.8x); identical histories: {same}"
    )
    print(summary)
    if not (args.dispatch or args.compile_ahead):
        return
    sections = [
        f"# Fitness dispatch benchmark (`python -m benchmarks.ga{' --dispatch' * args.dispatch}"
        f"{' --compile-ahead' * args.compile_ahead} --repeats {args.repeats}`)",
        "",
        f"Generated by `benchmarks/ga.py` on {os.cpu_count()} cores; do not edit by hand.",
        "",
        "## The GA run",
        "",
        summary,
    ]
    scratch = Path(tempfile.mkdtemp(prefix="pm-bench-"))
    try:
        if args.dispatch:
            sections += [
                "",
                "## Batch dispatch: new (loky executor) against old (socket worker group)",
                "",
                *dispatch_comparison(batches, args.repeats, args.old_ref, scratch),
            ]
        if not args.compile_ahead:
            sections += [
                "",
                "## Compile-ahead helper (removed)",
                "",
                "Not re-measured in this run (`--compile-ahead` times it at the old commit). It was "
                "removed at 65c37b2 when the main job from an empty numba cache, with and without it, "
                "measured off/on = 0.92 (median of 5; criterion to keep it >= 1.2); see this page's history.",
            ]
        if args.compile_ahead:
            sections += [
                "",
                "## Compile-ahead helper (removed)",
                "",
                *compile_ahead_comparison(args.repeats, args.old_ref, scratch),
            ]
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    text = "\n".join(sections) + "\n"
    print(text)
    PAGE.write_text(text)


if __name__ == "__main__":
    main()
