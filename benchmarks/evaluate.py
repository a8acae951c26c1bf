"""Accuracy and speed of the workspace evaluator on the H4 design of seed 000 Table 1.

The evaluator integrates H4's z exactly (see kinematics/workspace.py), so one
grid node is an (x, y, theta) column; figures below say which count they use.

Run: ``python -m benchmarks.evaluate``. Prints

1. the convergence table of V and GDI as the resolution grows;
2. the default resolution's error: V and GDI against a 4x finer evaluation;
3. time per evaluation, poses/s/core sampled and conditioned (the poses that
   pass the actuator limits and get a Jacobian condition number);
4. the ratio to a straightforward reference written here: the same poses,
   one at a time in a Python loop with ``numpy.linalg.cond``;
5. the projected time of a GA run (30 x 150 = 4,500 evaluations) on 2 workers.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from kinematics import get_mechanism
from kinematics.workspace import _grid_axes, default_resolution, evaluate

TABLE1 = dict(d=13.52484, h=13.88781, Qz=35.18892)
#: the integration measured here: the plain cell-centre count, the per-node kernels alone (the
#: same integral as the naive loop below); the default boundary-fraction grid's error and cost
#: are benchmarks/accuracy.py's
METHOD = "midpoint"


def naive_evaluation(mech, resolution: int, orientation, min_ic: float = 0.01):
    """Reference: the evaluator's grid nodes, one at a time in a Python loop.

    Per node: the feasible z-interval, the IK range check, the Jacobian and
    ``numpy.linalg.cond`` of the homogenised Jacobian. Same integral as the
    evaluator (z exact, (x, y, theta) midpoint rule).
    """
    axes, cell = _grid_axes(mech, resolution, orientation, {}, exact_axis=2)
    lo, hi = mech.pose_bounds(orientation)
    q_lo, q_hi = mech.actuator_range
    scale = mech.angular_scale()
    volume = total_ic = 0.0
    for x in axes[0]:
        for y in axes[1]:
            for theta in axes[3]:
                pose = np.array([[x, y, 0.0, theta]])
                _, z_lo, z_hi = mech.invariant_axis_interval(pose)
                z_lo, z_hi = max(z_lo[0], lo[2]), min(z_hi[0], hi[2])
                if not z_hi > z_lo:
                    continue
                pose[0, 2] = 0.5 * (z_lo + z_hi)
                q = mech.inverse(pose)[0]
                if not (np.all(q >= q_lo - 1e-9) and np.all(q <= q_hi + 1e-9)):
                    continue
                jac = mech.jacobian(pose)[0] * scale
                ic = 1.0 / np.linalg.cond(jac) if np.all(np.isfinite(jac)) else 0.0
                if ic > min_ic:
                    volume += (z_hi - z_lo) * cell
                    total_ic += ic * (z_hi - z_lo) * cell
    return volume, total_ic / volume if volume else 0.0


def conditioned_count(mech, resolution: int, orientation) -> int:
    """Nodes whose z-interval is non-empty: the poses that get a condition number."""
    ev = evaluate(
        mech, method=METHOD, resolution=resolution, orientation=orientation, error_estimate=False, return_samples=True
    )
    return int(np.isfinite(ev.inverse_conditions).sum())


def best_time(func, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--naive-resolution",
        type=int,
        default=None,
        help="resolution of the side-by-side naive comparison (default: the default resolution)",
    )
    args = parser.parse_args()
    mech = get_mechanism("h4", **TABLE1)
    orient = mech.default_orientation
    res = default_resolution(mech, method=METHOD)
    print(f"H4, Table 1 design {TABLE1} cm, theta in [{orient[0]:.4f}, {orient[1]:.4f}] rad, 1/kappa > 0.01")
    print("\n1. convergence")
    print(f"{'resolution':>10} {'poses':>10} {'V [cm^3 rad]':>14} {'GDI':>8} {'seconds':>8}")
    results = {}
    for r in (4, 8, 12, 16, 24, 32, 48, 4 * res):
        t0 = time.perf_counter()
        ev = evaluate(mech, method=METHOD, resolution=r, error_estimate=False)
        dt = time.perf_counter() - t0
        results[r] = ev
        print(f"{r:>10} {ev.n_samples:>10} {ev.volume:>14.1f} {ev.gdi:>8.4f} {dt:>8.3f}")

    ref = results[4 * res]
    ev = results[res]
    print(f"\n2. default resolution {res} vs 4x finer ({4 * res}):")
    print(f"   V error   {100 * (ev.volume - ref.volume) / ref.volume:+.3f} %  (goal: within 1 %)")
    print(f"   GDI error {100 * (ev.gdi - ref.gdi) / ref.gdi:+.3f} %")
    est = evaluate(mech, method=METHOD, resolution=res)
    print(
        f"   reported error estimate (vs the grid shifted by half a cell): V +-{est.volume_error:.1f}, GDI +-{est.gdi_error:.4f}"
    )

    seconds = best_time(lambda: evaluate(mech, method=METHOD, resolution=res, error_estimate=False), 7)
    cond = conditioned_count(mech, res, orient)
    print(f"\n3. one evaluation at resolution {res}: {1e3 * seconds:.1f} ms (one core)")
    print(f"   sampled poses/s/core:     {ev.n_samples / seconds:>12,.0f}")
    print(
        f"   conditioned poses/s/core: {cond / seconds:>12,.0f}  ({cond} of {ev.n_samples} (x, y, theta)"
        f" nodes conditioned; goal 3,000,000)"
    )
    print(
        f"   equivalent 4-D grid poses/s/core: {res * ev.n_samples / seconds:>12,.0f}  (z is integrated"
        f" exactly; a plain grid would sample {res} z values per node)"
    )

    r = args.naive_resolution or res
    fast = best_time(lambda: evaluate(mech, method=METHOD, resolution=r, error_estimate=False), 5)
    t0 = time.perf_counter()
    v_naive, gdi_naive = naive_evaluation(mech, r, orient)
    slow = time.perf_counter() - t0
    ev_r = evaluate(mech, method=METHOD, resolution=r, error_estimate=False)
    print(f"\n4. side by side at resolution {r} ({ev_r.n_samples} poses):")
    print(
        f"   vectorised {1e3 * fast:.2f} ms, naive loop with numpy.linalg.cond {1e3 * slow:.1f} ms:"
        f" ratio {slow / fast:.0f}x (goal >= 100x)"
    )
    print(f"   same result: V {ev_r.volume:.3f} vs {v_naive:.3f}, GDI {ev_r.gdi:.6f} vs {gdi_naive:.6f}")

    print(f"\n5. projected GA run, 4,500 evaluations on 2 workers: {4500 * seconds / 2:.0f} s (goal <= 60 s)")


if __name__ == "__main__":
    main()
