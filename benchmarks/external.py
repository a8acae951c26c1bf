"""Cost of an external mechanism written in pure numpy against a built-in compiled one.

Run: ``pip install --no-deps examples/five_bar`` once, then
``python -m benchmarks.external``. Side by side in this one run, one core,
``error_estimate=False`` (one grid per evaluation, as the optimisers
evaluate), best of 15 repeats in CPU time of this process
(``time.process_time``: on a shared machine wall time also counts the other
jobs' turns on the core; every path here is single-threaded):

1. per-design evaluation (``kinematics.workspace.evaluate``) of the example's
   planar five-bar (``examples/five_bar``, numpy only: it has no compiled
   kernel) and of the built-in planar 2-RPR with its compiled kernel and with
   the numpy reference (``PM_DESIGN_KERNELS=numpy``), on the cell grid of
   ``evaluate(method="grid")`` (``workspace._integrate_grid``: the 2-RPR's
   ``evaluate`` integrates exact sections instead) of the same node counts;
   ns per grid node and the ratio to the compiled 2-RPR;
2. the conformance harness (``kinematics.testing.check_mechanism``) per
   mechanism, warm.

The 2-RPR is the closest built-in to the five-bar (planar, two legs, two
pose variables); its numpy path does less arithmetic per node (square roots
against the five-bar's arctan2, arccos, sin and cos), so the numpy-vs-numpy
ratio also shows what the five-bar's own kinematics cost.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

from kinematics import MECHANISMS, get_mechanism, kernels, resolve_mechanism
from kinematics.plugins import PluginError
from kinematics.testing import check_mechanism
from kinematics.workspace import _integrate_grid

#: the example's class, by path (it needs no entry point to be benchmarked)
FIVE_BAR = "pm_five_bar.mechanism:FiveBar"
RESOLUTIONS = (160, 400)  # the five-bar's default (160^2 nodes) and the 2-RPR's (400^2)
REPEATS = 15
#: the dexterity limit of ``evaluate``'s default
MIN_IC = 0.01


def best_cpu_time(func: Callable[[], object], repeats: int = REPEATS) -> float:
    """Smallest CPU time (s) of this process over ``repeats`` calls of ``func``."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        func()
        best = min(best, time.process_time() - t0)
    return best


def main() -> None:
    # --help prints the usage and exits before any work (the run takes minutes)
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    try:
        five_bar_cls = resolve_mechanism(FIVE_BAR)
    except PluginError as exc:
        raise SystemExit(f"{exc}; install the example first: pip install --no-deps examples/five_bar") from None
    five_bar = five_bar_cls.from_design([40.0, 30.0], **five_bar_cls.default_fixed)
    rpr2 = get_mechanism("rpr2", b=5.0, q_min=6.0, q_max=9.6)

    print(f"1. one evaluation (ms of CPU time), one core, best of {REPEATS}; ns per grid node in brackets")
    print(
        f"{'resolution':>10} {'nodes':>8} | {'five-bar numpy':>18} | {'2-RPR compiled':>18} | "
        f"{'2-RPR numpy':>18} | five-bar/2-RPR compiled | five-bar/2-RPR numpy"
    )
    for res in RESOLUTIONS:
        nodes = res * res

        def timed(mech, res=res):
            # the cell grid of evaluate(method="grid") for both (the 2-RPR's evaluate integrates
            # exact sections instead, which have no grid nodes and no numpy path)
            def grid():
                return _integrate_grid(mech, res, mech.default_orientation, MIN_IC, None, {}, False)

            grid()  # warm (numba loads its cache)
            return best_cpu_time(grid)

        five = timed(five_bar)
        compiled = timed(rpr2)
        with kernels.reference_kernels():
            numpy_ref = timed(rpr2)
        cells = [f"{1e3 * t:8.2f} ({1e9 * t / nodes:5.1f})" for t in (five, compiled, numpy_ref)]
        print(
            f"{res:>10} {nodes:>8,} | {cells[0]:>18} | {cells[1]:>18} | {cells[2]:>18} | "
            f"{five / compiled:22.1f}x | {five / numpy_ref:19.1f}x"
        )

    print("\n2. conformance harness per mechanism (s of CPU time, warm, best of 3)")
    for name, cls in [*MECHANISMS.builtins.items(), ("five_bar (example)", five_bar_cls)]:
        failures = check_mechanism(cls)
        seconds = best_cpu_time(lambda cls=cls: check_mechanism(cls), 3)
        print(f"{name:>20}: {seconds:5.2f} s, {len(failures)} failures")


if __name__ == "__main__":
    main()
