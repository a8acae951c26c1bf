"""Entry point: ``python -m pipeline``.

Until the Hydra pipeline lands this prints the H4 paper example (seed 000
eq. 25-27): its inverse and forward kinematics.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from kinematics import get_mechanism


def main(argv: list[str]) -> int:
    h4 = get_mechanism("h4", d=6.0, h=6.0, Qz=42.0)
    pose = np.array([[5.0, -5.0, -30.0, math.pi / 6]])
    q = h4.inverse(pose)[0]
    print("H4 example (seed 000 eq. 25-27), h = d = 6 cm, Qz = 42 cm")
    print("pose (x, y, z [cm], theta [rad]):", np.round(pose[0], 5).tolist())
    print("IK q [cm] (eq. 26):", np.round(q, 3).tolist())
    print("FK polynomial roots T = tan(theta/2) (eq. 27):")
    for root in np.roots(h4.forward_polynomial(q)):
        print(f"  {root:.6g}")
    print("FK real poses:")
    for sol in h4.forward(q):
        print("  ", np.round(sol, 4).tolist())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
