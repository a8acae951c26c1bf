"""Speed of the evaluator, the main job, sweeps and a projection to a cluster (issue 14).

Run: ``python -m benchmarks.speed [--markdown docs/benchmarks_speed.md]``. Every
ratio is measured side by side in this one run, on this machine:

1. per-design evaluation of every mechanism at its default resolution: the
   compiled kernels, the numpy reference (``PM_DESIGN_KERNELS=numpy``) and a
   naive per-pose loop (IK, limits, Jacobian and ``numpy.linalg.cond`` one pose
   at a time, timed on a sample of the grid's nodes and scaled to all of
   them), with V and GDI against a 4x finer grid;
2. ``inverse_condition`` on 10^5 H4 poses, compiled and numpy (poses/s, one core);
3. cost against the resolution (H4);
4. the main job (``python -m pipeline +experiment=h4_mixed``) in a fresh
   process: cold (empty stage cache and empty numba cache, so imports and
   compilation count), with the kernels compiled, and warm; ``h4_design``
   against the paper GA;
5. a sweep of the same small study with 1, 2 and 4 jobs, through the basic
   launcher (jobs one after the other, 2 workers each) and Hydra's joblib
   launcher (2 jobs side by side, 1 worker each);
6. a 1,000-job sweep projected onto N dask workers from the measured per-job
   compute time and per-job overheads.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.evaluate import best_time
from kinematics import MECHANISMS, get_mechanism, kernels
from kinematics.workspace import _exact_axis, _grid_axes, _grid_poses, default_resolution, evaluate

ROOT = Path(__file__).resolve().parents[1]
#: designs evaluated per mechanism (the papers' examples; tests/conftest.py PAPER_DESIGNS)
DESIGNS = {
    "h4": dict(d=13.52484, h=13.88781, Qz=35.18892),  # seed 000 Table 1
    "tricept": dict(a=250.0, b=400.0, d=100.0),
    "rpr3": dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0),
    "rpr2": dict(b=5.0, q_min=6.0, q_max=9.6),
    "delta": dict(R=200.0, r=50.0, la=200.0, lb=400.0),
    # constant-orientation workspace at the home orientation (its default evaluation)
    "gough_stewart": dict(r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0),
}
SWEEP_STUDY = ["+experiment=h4_design", "sample.n=16", "optimizer.max_evaluations=120"]


def naive_seconds_per_node(mech, sample: int = 1500) -> float:
    """Seconds per grid node of the naive loop: one pose at a time, ``numpy.linalg.cond``."""
    orientation = mech.default_orientation
    res = default_resolution(mech)
    exact = _exact_axis(mech, {})
    axes, _ = _grid_axes(mech, res, orientation, {}, exact_axis=exact)
    total = int(np.prod([len(a) for a in axes]))
    nodes = _grid_poses(axes, 0, total)[np.linspace(0, total - 1, min(sample, total)).astype(int)]
    lo, hi = mech.pose_bounds(orientation)
    q_lo, q_hi = mech.actuator_range
    scale = mech.angular_scale()
    with kernels.reference_kernels():
        t0 = time.perf_counter()
        for node in nodes:
            pose = node[None, :].copy()
            if exact is not None:
                _, z_lo, z_hi = mech.invariant_axis_interval(pose)
                z_lo, z_hi = max(z_lo[0], lo[exact]), min(z_hi[0], hi[exact])
                if not z_hi > z_lo:
                    continue
                pose[0, exact] = 0.5 * (z_lo + z_hi)
            q = mech.inverse(pose)[0]
            if not (np.all(q >= q_lo) and np.all(q <= q_hi)) or not mech.within_joint_limits(pose)[0]:
                continue
            jac = mech.jacobian(pose)[0] * scale
            _ = 1.0 / np.linalg.cond(jac) if np.all(np.isfinite(jac)) else 0.0
        return (time.perf_counter() - t0) / len(nodes)


def evaluation_table() -> list[list[str]]:
    rows = []
    for name in sorted(MECHANISMS):
        mech = get_mechanism(name, **DESIGNS[name])
        res = default_resolution(mech)
        ev = evaluate(mech, error_estimate=False)
        fine = evaluate(mech, resolution=4 * res, error_estimate=False)
        fast = best_time(lambda: evaluate(mech, error_estimate=False), 7)
        accuracy = [f"{100 * (ev.volume / fine.volume - 1):+.3f} %", f"{100 * (ev.gdi / fine.gdi - 1):+.3f} %"]
        if mech.section_axis is not None:
            # exact sections (planar mechanisms): compiled only, no grid nodes to loop over
            nodes = f"{ev.n_samples:,} points of the rows' rule"
            rows.append(
                [name, str(res), nodes, f"{1e3 * fast:.2f}", *["exact sections: compiled only"] * 4, *accuracy, ""]
            )
            continue
        with kernels.reference_kernels():
            reference = best_time(lambda: evaluate(mech, error_estimate=False), 7)
            ref_ev = evaluate(mech, error_estimate=False)
        naive = naive_seconds_per_node(mech) * ev.n_samples
        same = abs(ev.volume / ref_ev.volume - 1) if ref_ev.volume else abs(ev.volume)
        rows.append(
            [
                name,
                str(res),
                f"{ev.n_samples:,}",
                f"{1e3 * fast:.2f}",
                f"{1e3 * reference:.2f}",
                f"{reference / fast:.1f}x",
                f"{1e3 * naive:.0f}",
                f"{naive / fast:.0f}x",
                *accuracy,
                f"{same:.0e}",
            ]
        )
    return rows


def conditioning_rate() -> tuple[float, float]:
    mech = get_mechanism("h4", **DESIGNS["h4"])
    rng = np.random.default_rng(0)
    lo, hi = mech.pose_bounds(mech.default_orientation)
    poses = lo + (hi - lo) * rng.random((400_000, 4))
    poses = poses[np.isfinite(mech.inverse_condition(poses))][:100_000]
    fast = best_time(lambda: mech.inverse_condition(poses), 5)
    with kernels.reference_kernels():
        reference = best_time(lambda: mech.inverse_condition(poses), 3)
    return len(poses) / fast, len(poses) / reference


def resolution_table() -> list[list[str]]:
    mech = get_mechanism("h4", **DESIGNS["h4"])
    fine = evaluate(mech, resolution=96, error_estimate=False)
    rows = []
    for res in (12, 16, 24, 32, 48):
        seconds = best_time(lambda: evaluate(mech, resolution=res, error_estimate=False), 3)
        ev = evaluate(mech, resolution=res, error_estimate=False)
        rows.append(
            [
                str(res),
                f"{ev.n_samples:,}",
                f"{1e3 * seconds:.2f}",
                f"{100 * (ev.volume / fine.volume - 1):+.3f} %",
                f"{100 * (ev.gdi / fine.gdi - 1):+.3f} %",
            ]
        )
    return rows


def run_cli(args: list[str], out: Path, env: dict[str, str] | None = None) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(
        # purpose=benchmark: a benchmark's runs stay out of a dataset's default view
        [sys.executable, "-m", "pipeline", *args, "purpose=benchmark", f"paths.output_dir={out}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
    )
    if proc.returncode != 0:
        raise SystemExit(f"benchmark run failed: {' '.join(args)}\n{proc.stderr[-2000:]}")
    return time.perf_counter() - t0


def main_job_times(scratch: Path) -> dict[str, float]:
    """The main job cold (empty caches: stages and numba), with the kernels compiled, and warm,
    each in a fresh process."""
    env = {"NUMBA_CACHE_DIR": str(scratch / "numba-cache")}
    out = scratch / "main-cold"
    return {
        "cold": run_cli(["+experiment=h4_mixed"], out, env),
        "compiled": run_cli(["+experiment=h4_mixed"], scratch / "main-compiled", env),
        "warm": run_cli(["+experiment=h4_mixed"], out, env),
    }


def preset_against_paper_ga(scratch: Path) -> list[list[str]]:
    """``h4_design`` (CMA-ES + polish) against the paper GA (``h4_mixed`` without its reference run),
    each from an empty stage cache: the optimise stage (from the manifests) and the whole process."""
    rows = []
    for label, args in (
        (
            "paper GA 30 x 150 (h4_mixed, optimizer.reference=false)",
            ["+experiment=h4_mixed", "optimizer.reference=false"],
        ),
        ("h4_design (IPOP-CMA-ES + polish)", ["+experiment=h4_design"]),
    ):
        out = scratch / label.split()[0]
        wall = run_cli([*args, "plot.enabled=false"], out)
        manifest = json.loads(next(out.rglob("manifest.json")).read_text())
        rows.append([label, f"{manifest['timings']['optimise']:.2f}", f"{wall:.1f}"])
    rows.append(
        ["ratio", f"{float(rows[1][1]) / float(rows[0][1]):.2f}", f"{float(rows[1][2]) / float(rows[0][2]):.2f}"]
    )
    return rows


def sweep_times(scratch: Path) -> list[list[str]]:
    rows = []
    base_per_job = None
    for n_jobs in (1, 2, 4):
        values = ",".join(str(round(v, 3)) for v in np.linspace(0.2, 0.8, n_jobs))
        sweep = ["-m", *SWEEP_STUDY, f"objective.w_d={values}"]
        basic = run_cli(sweep, scratch / f"basic{n_jobs}")
        side = run_cli(
            [*sweep, "hydra/launcher=joblib", "hydra.launcher.n_jobs=2", "parallel.n_jobs=1"],
            scratch / f"joblib{n_jobs}",
        )
        base_per_job = base_per_job or basic
        rows.append([str(n_jobs), f"{basic:.1f}", f"{side:.1f}", f"{basic / side:.2f}x"])
    return rows


def projection(per_job: float, overhead: float, jobs: int = 1000) -> list[list[str]]:
    """Wall time of ``jobs`` jobs on N single-core dask workers: waves of N jobs, each
    costing its compute plus a per-job overhead (process start, imports, scheduling)."""
    rows = []
    for workers in (2, 8, 32, 128, 512):
        waves = math.ceil(jobs / workers)
        hours = waves * (per_job + overhead) / 3600
        rows.append([str(workers), str(waves), f"{hours:.2f} h" if hours >= 1 else f"{60 * hours:.1f} min"])
    return rows


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--markdown", type=Path, help="also write the tables to this Markdown file")
    parser.add_argument("--skip-cli", action="store_true", help="skip the main-job and sweep timings")
    args = parser.parse_args()
    sections = []

    header = [
        "mechanism",
        "resolution",
        "nodes",
        "compiled [ms]",
        "numpy [ms]",
        "numpy/compiled",
        "naive loop [ms]",
        "naive/compiled",
        "V vs 4x finer",
        "GDI vs 4x finer",
        "|V compiled/numpy - 1|",
    ]
    sections.append(
        "## 1. One design at the default resolution (one core)\n\n" + markdown_table(header, evaluation_table())
    )
    fast, reference = conditioning_rate()
    sections.append(
        f"## 2. `inverse_condition`, 10^5 H4 poses (one core)\n\ncompiled {fast / 1e6:.2f} M poses/s, "
        f"numpy {reference / 1e6:.2f} M poses/s ({fast / reference:.1f}x; goal >= 4 M poses/s)"
    )
    sections.append(
        "## 3. H4 cost against the resolution (error against resolution 96)\n\n"
        + markdown_table(["resolution", "(x, y, θ) nodes", "ms per design", "V error", "GDI error"], resolution_table())
    )
    if not args.skip_cli:
        scratch = Path(tempfile.mkdtemp(prefix="pm-speed-"))
        try:
            main_job = main_job_times(scratch)
            sections.append(
                f"## 4. The main job, `python -m pipeline +experiment=h4_mixed`, fresh process\n\n"
                f"cold (empty stage cache, empty numba cache: imports and compilation count) "
                f"{main_job['cold']:.1f} s (goal <= 12 s); empty stage cache "
                f"with the kernels compiled {main_job['compiled']:.1f} s; warm {main_job['warm']:.1f} s "
                f"(goal <= 3 s)"
            )
            sections.append(
                "## 4b. The fast preset against the paper GA, seconds (empty stage cache)\n\n"
                + markdown_table(["run", "optimise stage", "whole process"], preset_against_paper_ga(scratch))
            )
            rows = sweep_times(scratch)
            sections.append(
                "## 5. Sweeps of a small study (`h4_design`, 16 samples, 120 evaluations), wall seconds\n\n"
                + markdown_table(
                    ["jobs", "basic launcher, 2 workers per job", "joblib launcher, 2 jobs x 1 worker", "ratio"], rows
                )
            )
            # per-job figures for the projection: the 4-job basic sweep's time per job, and the
            # overhead of a job = the warm main job (process start, imports, Hydra, cache reads)
            per_job = float(rows[-1][1]) / 4
            sections.append(
                f"## 6. A 1,000-job sweep of that study on N single-core dask workers (projection)\n\n"
                f"From this run: {per_job:.1f} s per job (4-job basic sweep / 4, 2 workers) and "
                f"{main_job['warm']:.1f} s overhead per job (the warm main job: start, imports, Hydra, "
                f"cache reads); one core per job doubles the compute part.\n\n"
                + markdown_table(["workers", "waves", "wall time"], projection(2 * per_job, main_job["warm"]))
            )
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
    text = "\n\n".join(sections) + "\n"
    print(text)
    if args.markdown:
        args.markdown.write_text(
            "# Speed benchmarks (generated by `python -m benchmarks.speed`)\n\n"
            f"Measured on this project's {os.cpu_count()}-core machine, shared with other jobs (load "
            f"average {', '.join(f'{x:.1f}' for x in os.getloadavg())} at the end: absolute times move with "
            "it, ratios measured side by side less); rerun to update.\n\n" + text
        )


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):
        main()
