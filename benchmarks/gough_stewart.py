"""Figures of docs/gough_stewart.md: workspaces, cross-checks, length sensitivity, dense reference.

Run: ``python -m benchmarks.gough_stewart [--dense]``. Prints

1. time per evaluation at the default resolution (constant-orientation workspace, 32^3 nodes)
   and V, GDI against 2x and 4x finer grids;
2. the constant-orientation volume against an independent brute-force Monte-Carlo
   (``tests/test_gough_stewart.py::brute_force_volume``, 4 seeds x 4e5 points);
3. Fichter's singularity: 1/kappa at torsion 85, 90, 95 deg at the home position;
4. the orientation workspace at the home position, and the 6-D volume by randomised QMC
   with its 95 % interval (tilt and torsion within +-15 deg);
5. GDI against the characteristic length L (the docs design, and the experiment's optimum);
6. with ``--dense``: the mixed index (w_d = 0.5) on a dense grid of the design box (the
   experiment's reference, 2,304 evaluations, a few minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import itertools
import math
import time

import numpy as np

from benchmarks.evaluate import best_time
from kinematics import MECHANISMS, get_mechanism
from kinematics.gough_stewart import constant_orientation_workspace, orientation_workspace, workspace_6d
from kinematics.workspace import evaluate

DESIGN = dict(r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0)


def dense_reference(w_d: float = 0.5, n_jobs: int = 2) -> tuple[np.ndarray, float, int]:
    """Best design and mixed index on a grid of the design box (ends included); evaluations."""
    from joblib import Parallel, delayed

    cls = MECHANISMS["gough_stewart"]
    axes = [np.linspace(v.lower, v.upper, n) for v, n in zip(cls.design_variables, (8, 6, 8, 6))]
    designs = np.array(list(itertools.product(*axes)))

    def run(chunk):
        out = []
        for d in chunk:
            ev = evaluate(cls.from_design(d, **cls.default_fixed), error_estimate=False)
            out.append(ev.mixed(w_d))
        return out

    values = np.concatenate(Parallel(n_jobs=n_jobs)(delayed(run)(c) for c in np.array_split(designs, 4 * n_jobs)))
    k = int(np.argmax(values))
    return designs[k], float(values[k]), len(designs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dense", action="store_true", help="also run the dense reference of the experiment")
    parser.add_argument(
        "--optimum",
        type=float,
        nargs=4,
        default=None,
        help="a design (r_platform, sep_base, sep_platform, height) for the L table",
    )
    args = parser.parse_args()
    mech = get_mechanism("gough_stewart", **DESIGN)

    ev = evaluate(mech, error_estimate=False)
    seconds = best_time(lambda: evaluate(mech, error_estimate=False), 5)
    print(
        f"1. default evaluation: resolution {ev.resolution}, {ev.n_samples} nodes, {1e3 * seconds:.0f} ms; "
        f"V = {ev.volume:.5g} {ev.volume_unit}, GDI = {ev.gdi:.4f}, SURI = {ev.suri:.4f}"
    )
    for factor in (2, 4):
        fine = evaluate(mech, resolution=factor * ev.resolution, error_estimate=False)
        print(
            f"   vs {factor}x finer: V {100 * (ev.volume / fine.volume - 1):+.2f} %, "
            f"GDI {100 * (ev.gdi / fine.gdi - 1):+.2f} %"
        )

    from tests.test_gough_stewart import brute_force_volume

    for angles in ((0.0, 0.0, 0.0), (0.15, -0.1, 0.3)):
        grid = constant_orientation_workspace(
            mech, *angles, resolution=96, min_inverse_condition=0.0, error_estimate=False
        ).volume
        brute = np.array([brute_force_volume(mech, *angles, n=400_000, seed=s) for s in range(1, 5)])
        err = brute.std(ddof=1) / math.sqrt(len(brute))
        print(
            f"2. constant orientation {angles} rad: grid (96^3) {grid:.5g} mm³, brute force "
            f"{brute.mean():.5g} ± {err:.2g} mm³ (1 s.e.), difference {100 * (grid / brute.mean() - 1):+.2f} %"
        )

    for torsion in (85.0, 89.0, 90.0, 91.0, 95.0):
        ic = mech.inverse_condition([[0.0, 0.0, 700.0, 0.0, 0.0, math.radians(torsion)]])[0]
        print(f"3. torsion {torsion:5.1f} deg at (0, 0, 700 mm): 1/kappa = {ic:.3g}")

    ow = orientation_workspace(
        mech, (0.0, 0.0, 700.0), (-math.pi / 2, math.pi / 2), resolution=32, error_estimate=False
    )
    print(
        f"4. orientation workspace at (0, 0, 700 mm), box ±90°: {ow.volume:.4g} rad³ "
        f"({100 * ow.suri:.2f} % of the box), GDI {ow.gdi:.4f}"
    )
    t0 = time.perf_counter()
    qmc = workspace_6d(mech, (-math.radians(15), math.radians(15)), n_points=2**15, replicates=8, seed=0)
    print(
        f"   6-D, tilt_x, tilt_y, torsion in ±15°: V = {qmc.volume:.5g} {qmc.unit}, 95 % CI "
        f"[{qmc.volume_ci[0]:.5g}, {qmc.volume_ci[1]:.5g}], GDI {qmc.gdi:.4f} [{qmc.gdi_ci[0]:.4f}, "
        f"{qmc.gdi_ci[1]:.4f}], box {qmc.box_volume:.4g} mm³·rad³, fraction {qmc.fraction:.4f}, "
        f"{qmc.replicates} x {qmc.n_points} points, {time.perf_counter() - t0:.1f} s"
    )
    grid6 = evaluate(mech, orientation=(-math.radians(15), math.radians(15)), resolution=10, error_estimate=False)
    print(f"   6-D grid 10^6 nodes: V = {grid6.volume:.5g}, GDI {grid6.gdi:.4f}")

    designs = {"docs design": mech}
    if args.optimum is not None:
        cls = MECHANISMS["gough_stewart"]
        designs["optimum"] = cls.from_design(np.array(args.optimum), **cls.default_fixed)
    for label, m in designs.items():
        for length in (0.5 * m.r_platform, m.r_platform, 0.5 * (m.r_platform + m.r_base), m.r_base, 2 * m.r_platform):
            e = evaluate(m, length=length, error_estimate=False)
            print(
                f"5. {label}: L = {length:.1f} mm: GDI {e.gdi:.4f}, V {e.volume:.5g} mm³, eta(0.5) {e.mixed(0.5):.5f}"
            )

    if args.dense:
        t0 = time.perf_counter()
        design, value, count = dense_reference()
        print(
            f"6. dense reference (w_d 0.5): {count} designs, best eta {value:.6f} at {design}, "
            f"{time.perf_counter() - t0:.0f} s"
        )


if __name__ == "__main__":
    main()
