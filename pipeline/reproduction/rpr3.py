"""Seed 003, the planar 3-RPR (thesis): forward kinematics, the §5.3 Jacobian, Fig. 8-11.

No optimisation: the thesis' numerical examples are recomputed and set beside its printed values.
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np

from kinematics import get_mechanism
from kinematics.workspace import evaluate
from pipeline.report.tables import rel, table
from pipeline.reproduction.driver import Reproduction

SEEDS = (0, 1, 2)
#: the thesis' example geometry (mm): base and platform points, leg range
THESIS = dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0)


def thesis_jacobian_program(x: float, y: float, phi_deg: float, legs: tuple[float, float, float]) -> np.ndarray:
    """The thesis' appendix C++ program, with its index bug (a[2][2] uses x - t3), as printed.

    Returns ``-A^-1 B`` (the matrix it prints). Base inputs t1, t2, t3 = c2, c3, d3 = 200, 0, 200;
    platform l2 = 50, l3 = 40 sqrt2, gam = 45 deg.
    """
    t1, t2, t3 = 200.0, 0.0, 200.0
    l2, l3, gam = 50.0, 40.0 * math.sqrt(2.0), math.pi / 4
    phi = math.radians(phi_deg)
    a = np.array(
        [
            [x, y, 0.0],
            [
                (x - t1) + l2 * math.cos(phi),
                y + l2 * math.sin(phi),
                l2 * (y * math.cos(phi) - (x - t1) * math.sin(phi)),
            ],
            [
                (x - t2) + l3 * math.cos(phi + gam),
                (y - t3) + l3 * math.sin(phi + gam),
                l3 * ((y - t3) * math.cos(phi + gam) - (x - t3) * math.sin(phi + gam)),
            ],
        ]
    )
    return -np.linalg.inv(a) @ np.diag(legs)


def thesis_forward_ga(q: np.ndarray, seed: int, generations: int) -> np.ndarray:
    """The thesis' binary GA for the forward kinematics of :data:`THESIS` at leg lengths ``q`` (mm):
    the pose (x, y in mm, φ in rad) it finds (a module-level function, so that it can be cached)."""
    return get_mechanism("rpr3", **THESIS).forward_ga(q, seed=seed, generations=generations)[0]


def rpr3(r: Reproduction) -> None:
    """Section "Planar 3-RPR": forward kinematics, the §5.3 Jacobian, Fig. 8-11."""
    m = get_mechanism("rpr3", **THESIS)
    q = np.array([100.0, 120.0, 150.0])
    modes = m.forward(q)
    thesis = {
        "mode 1": ((97.99, 19.91, 85.01), {500: (97.849462, 20.039101, 84.1045)}),
        "mode 2": ((52.86, 84.95, -33.45), {1000: (52.981427, 85.141740, -33.7865)}),
    }
    ours = {"mode 1": modes[1], "mode 2": modes[0]}
    rows = []
    for label, (alg, ga) in thesis.items():
        pose = ours[label]
        rows.append([label, "thesis algebraic", *alg, "-"])
        rows.append(
            [
                label,
                "ours, degree-6 polynomial",
                round(pose[0], 3),
                round(pose[1], 3),
                round(math.degrees(pose[2]), 3),
                f"{np.abs(m.inverse(pose[None])[0] - q).max():.1e}",
            ]
        )
        for gens, vals in ga.items():
            rows.append([label, f"thesis GA, {gens} generations", *vals, "-"])
    for gens in (500, 1000):
        for seed in SEEDS:
            sol = r.memo(thesis_forward_ga)(q, seed, gens)
            nearest = min(ours, key=lambda k: np.linalg.norm(ours[k][:2] - sol[:2]))
            rows.append(
                [
                    nearest,
                    f"ours, thesis GA, {gens} gen., seed {seed}",
                    round(sol[0], 3),
                    round(sol[1], 3),
                    round(math.degrees(sol[2]), 3),
                    f"{np.abs(m.inverse(sol[None])[0] - q).max():.2f}",
                ]
            )
    j_thesis = np.array(
        [[-0.855658, 0.190268, -0.0903346], [-0.811356, -0.93643, 0.444595], [-0.00522636, -0.0127963, -0.00770599]]
    )
    pose = modes[1]
    j_ours = m.jacobian(pose[None])[0]
    j_inv = np.linalg.inv(j_ours)
    j_prog = thesis_jacobian_program(97.99, 19.91, 85.02, (100.0, 150.0, 150.0))

    def mat(a):
        return "<br>".join("[" + ", ".join(f"{v:.4g}" for v in row) + "]" for row in a)

    area_rows = []
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.5), layout="constrained")
    for ax, deg in zip(axes, (15, 30, 45, 60)):
        phi = math.radians(deg)
        ev = r.memo(evaluate)(
            m,
            orientation=(phi, phi),
            min_inverse_condition=0.0,
            resolution=240,
            return_samples=True,
            error_estimate=False,
        )
        exact = m.exact_area(phi)
        area_rows.append([deg, round(exact, 1), round(ev.volume, 1), rel(ev.volume, exact)])
        pts = ev.samples[ev.inside]
        ax.scatter(pts[:, 0], pts[:, 1], s=1, c="tab:blue", marker="s")
        centres = m.annulus_centres(phi)
        for c in centres:
            for radius, style in ((m.rho_min, "--"), (m.rho_max, "-")):
                ax.add_patch(plt.Circle(c, radius, fill=False, ls=style, lw=0.6, color="0.4"))
        ax.set_xlim(-200, 350)
        ax.set_ylim(-200, 350)
        ax.set_aspect("equal")
        ax.set_title(f"3-RPR workspace at φ = {deg}°, area {exact:.0f} mm²", fontsize=10)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
    fig.savefig(r.figures / "rpr3_fig8_11_workspaces.png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    r.add(f"""
## Planar 3-RPR (seed 003)

### Forward kinematics: the thesis' GA versus the polynomial

A = (0,0), (200,0), (0,200); B' = (0,0), (50,0), (40,40); legs (100, 120, 150) mm. The degree-6
polynomial in tan(φ/2) has exactly two real roots.

{table(["mode", "method", "x [mm]", "y [mm]", "φ [deg]", "max leg error [mm]"], rows)}

Both exact modes satisfy the leg lengths to rounding. The thesis' "algebraic" mode 2
(52.86, 84.95, -33.45°) is off its own constraints by 0.05 mm in the legs, hence our 0.06 mm
difference in y. Our binary GA with the thesis' settings (uniform crossover 0.999, mutation 0.001,
population 40) lands near one mode with leg errors of millimetres, as the thesis' GA does, and
which mode it finds depends on the seed.

### §5.3 Jacobian: the thesis' matrix and ours (pose of mode 1)

{
        table(
            ["matrix", "rows"],
            [
                ["thesis, printed", mat(j_thesis)],
                ["ours, J = B⁻¹A (q̇ = J ẋ)", mat(j_ours)],
                ["ours, J⁻¹ (ẋ = J⁻¹ q̇)", mat(j_inv)],
                ["thesis program re-run: -A⁻¹B with its a[2][2] index bug, legs (100, 150, 150)", mat(j_prog)],
            ],
        )
    }

The printed matrix does not follow from the stated data. It is the output of the thesis' C++
program (appendix), which computes -A⁻¹B, the forward Jacobian, not the -B⁻¹A of eq. 16. The
program has an index bug: `a[2][2]` uses x - t3 = x - d₃ where eq. 27 has x - c₃. Its second
column is 150/120 times ours, as if leg 2 had been entered as 150. Re-running the program's
formula with these three facts reproduces every printed entry to within 1 % (float32 and rounded
inputs). Apart from sign and direction conventions, the correct matrix is our J⁻¹.

### Fig. 8-11: constant-orientation workspaces, legs 80-160 mm

![Fig. 8-11]({r.figure("rpr3_fig8_11_workspaces.png")})

{table(["φ [deg]", "exact area [mm²]", "grid 240² [mm²]", "difference"], area_rows)}

Exact areas come from the intersection of the three annuli (Green's theorem on the boundary arcs,
`kinematics.annuli`). The thesis plots these shapes without giving areas.
""")
