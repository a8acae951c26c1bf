"""Throughput of the vectorised kernels: poses/s of `inverse` and `inverse_condition`.

Run: ``python -m benchmarks.kinematics [--n 100000]``. Prints one line per
mechanism and kernel. Figures are wall-clock on this machine (best of 3).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from kinematics import get_mechanism

DESIGNS = {
    "h4": (dict(d=13.52484, h=13.88781, Qz=35.18892), ([-40, -40, -60, -1.5], [40, 40, 40, 1.5])),
    "tricept": (dict(a=250.0, b=400.0, d=100.0), ([400, -0.8, -0.8], [750, 0.8, 0.8])),
    "rpr3": (
        dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0),
        ([0, 0, -np.pi], [200, 200, np.pi]),
    ),
    "rpr2": (dict(b=5.0, q_min=6.0, q_max=9.6), ([-6, -9], [11, 9])),
    "gough_stewart": (
        dict(r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0),
        ([-150, -150, 600, -0.4, -0.4, -0.4], [150, 150, 850, 0.4, 0.4, 0.4]),
    ),
}


def best_of(func, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, default=100_000, help="poses per call")
    args = parser.parse_args()
    print(f"{'mechanism':<14}{'kernel':<20}{'poses/s':>14}")
    for name, (params, (lo, hi)) in DESIGNS.items():
        mech = get_mechanism(name, **params)
        poses = np.random.default_rng(0).uniform(lo, hi, size=(args.n, len(lo)))
        for kernel in ("inverse", "inverse_condition"):
            seconds = best_of(lambda: getattr(mech, kernel)(poses))
            print(f"{name:<14}{kernel:<20}{args.n / seconds:>14,.0f}")


if __name__ == "__main__":
    main()
