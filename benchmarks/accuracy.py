"""Discretisation error vs cost of the workspace integral, old (cell-centre count) vs new
(boundary-fraction grid), for every mechanism; writes docs/accuracy.md and its log-log figure.

Run: ``python -m benchmarks.accuracy`` (about six minutes on 2 cores).

For each mechanism, designs are the test suite's paper design, two random designs of the
design box (seeded) and, where documented, an optimum of docs/reproduction.md. The reference
of each design is the new method at :data:`REFERENCE_FACTOR` x the finer of the two methods'
default resolutions, cross-checked against the old method at the same resolution (printed). Each method is timed
at a ladder of resolutions in the same run (best of :data:`REPEATS`, one core), so the cost
ratios are side by side. The error of a method at a resolution is the largest relative error
over the designs of V, GDI and eta (w_d = 0.5). Beyond the ladder: :data:`SCAN` further random
designs per mechanism at each default only (:func:`scan`, with the error bar that ``evaluate``
reports against the true error), and the new method's cost phase by phase (:func:`phases`).
"""

from __future__ import annotations

import argparse
import cProfile
import math
import pstats
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

from benchmarks.best_known import load as load_best_known  # noqa: E402
from kinematics import MECHANISMS, get_mechanism  # noqa: E402
from kinematics.workspace import default_resolution, evaluate, grid_nodes  # noqa: E402

#: the reference resolution, in multiples of the default
REFERENCE_FACTOR = 4
#: resolutions of the ladder, in multiples of the default
LADDER = (0.5, 0.75, 1.0, 1.5, 2.0)
#: timing rounds (the least counts). Why 15: with 5, the 3-RPR's ratio on a quiet machine read
#: 1.69x in one run and 2.00x in the next; with 15 rounds two runs read 1.72x and 1.76x
REPEATS = 15
W_D = 0.5
#: the wider check: this many further random designs per mechanism (seeded), at each method's
#: default against the same reference rule
SCAN = 10
SCAN_SEED = 7
#: old (cell-centre count), new (boundary fractions)
METHODS = ("midpoint", "grid")


def reference_method(mech) -> str:
    """The rule of a design's reference: the grid with one plane per cell (a planar mechanism's
    exact sections), whatever the mechanism's own cell rule, so that a mechanism whose cells are
    counted by linear margins (the Tricept, ``cell_rule``) is checked against the other rule."""
    return "planes" if mech.cell_rule == "margins" else "grid"


def reference_evaluation(mech):
    """A design's reference: :func:`reference_method` at :data:`REFERENCE_FACTOR` x the finer of
    the two methods' default resolutions (:data:`METHODS`), no error estimate."""
    resolution = REFERENCE_FACTOR * max(default_resolution(mech, method=method) for method in METHODS)
    return evaluate(mech, resolution=resolution, method=reference_method(mech), error_estimate=False)


#: the issue's targets: cost of the new method at its default vs the old default, and its error
COST_TARGET = 2.0
ERROR_TARGET = 1e-3
DOCS = Path(__file__).resolve().parent.parent / "docs"
FIGURE = DOCS / "figures" / "accuracy_convergence.png"

#: one design per mechanism from the papers (tests/conftest.py) and documented optima
PAPER = {
    "h4": dict(d=6.0, h=6.0, Qz=42.0),
    "tricept": dict(a=250.0, b=400.0, d=100.0),
    "rpr3": dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]], rho_min=80.0, rho_max=160.0),
    "rpr2": dict(b=5.0, q_min=6.0, q_max=9.6),
    "delta": dict(R=200.0, r=50.0, la=200.0, lb=400.0),
    "gough_stewart": dict(r_base=400.0, r_platform=250.0, sep_base=30.0, sep_platform=30.0, height=700.0),
}


def best_known_design(problem: str) -> list[float]:
    """The design vector of ``problem``'s best known optimum (benchmarks/best_known.json)."""
    return [float(v) for v in load_best_known()[problem]["design"].values()]


#: documented optima: keyword arguments of ``get_mechanism`` (docs/reproduction.md) or design vectors
#: (``from_design``: benchmarks/best_known.json, docs/reproduction.md's trade-off)
OPTIMA: dict[str, list[dict | list[float]]] = {
    # seed 000 Table 1 design, and h4_max_volume's best known (the design box's corner, where the
    # GA's optima for w_d <= 0.3 also lie)
    "h4": [dict(d=13.52484, h=13.88781, Qz=35.18892), best_known_design("h4_max_volume")],
    # the best known (benchmarks/best_known.json), then two optima of the cell count it replaced
    "tricept": [dict(a=200.0, b=300.0, d=200.0), dict(a=200.1, b=300.0, d=191.3), dict(a=203.6, b=303.4, d=186.2)],
    # rpr3_mixed's best known (w_d = 0.5), and the trade-off's w_d = 1 optimum
    "rpr3": [best_known_design("rpr3_mixed"), [128.2046, 100.0]],
    "rpr2": [[8.774, 3.0]],  # the trade-off's w_d = 0.5 optimum
}


METHOD = r"""# Accuracy of the workspace integral (V, GDI, eta)

Issue 23, parts 1-2. `kinematics.workspace.evaluate` integrates by a **boundary-fraction
grid** (`method="grid"`, the default of `evaluate` and of the pipeline's `evaluate.method`);
the cell-centre count of earlier versions (`method="midpoint"`) is kept for comparison and is
the "old" method below. This page is generated by `python -m benchmarks.accuracy`; the figure
is `docs/figures/accuracy_convergence.png`.

## Method

1. **Box.** The mechanism's pose box is a bound from the geometry; the workspace may fill a
   fraction of it (Tricept: c in about 300-650 of 0-926 mm). A coarse grid of about 1/8 of
   the nodes finds the extent of the reachable set (which holds the workspace, its dexterous
   part) along each sampled axis: on the edges below the lowest (above the highest) layer of
   reachable nodes the crossing is placed on the reach margins as in step 3, the extreme one
   widened by one coarse cell (so the box holds the whole edge) and clipped to the box. The
   fine grid spans that box. Layers and crossings follow one set: with layers of dexterous
   nodes and crossings on the reach margins, an extreme crossing jumped where an outside node
   turned dexterous (by 1.5 % of a coarse cell at the earlier h4_mixed best known, and with it
   every node of the grid: a step of 3e-6 of eta).
2. **Cells.** Nodes at cell centres, `resolution` per sampled axis times the mechanism's
   factor for that axis where it sets one (`grid_axis_nodes`; H4: 1/2 along theta, where its
   margins and `1/kappa` vary slowly; H4's z still integrated exactly per column). The default
   resolution is the mechanism's node budget `grid_nodes` where it sets one (H4 30 x 30 x 15,
   Tricept 20^3, Delta 26^3, Gough-Stewart 26^3), else `default_nodes`. A node without a
   boundary crossing on its edges counts its whole cell (inside) or nothing (outside); the
   Tricept's cell rule (the end of step 6) widens that to the nodes whose 26 neighbours share
   its membership.
3. **Crossings on the margins.** Every built-in mechanism states its reachability margins
   (`Mechanism.constraint_margins`; H4 per (x, y, theta) column, `exact_axis_margins`): smooth
   functions of the pose, >= 0 exactly where an actuator range, a joint limit or the reality of
   the inverse kinematics holds (leg lengths against their range; cone angles as
   `cos(angle) - cos(limit)`; the Delta's elbow closure `rho -+ c`; H4's rod reach
   `M^2 - dx^2 - dy^2` and the order of the bounds of its z interval), and the dexterity limit
   is the margin `1/kappa^2 - limit^2` (the square: at a singular reach boundary, where a rod or
   an arm is stretched, 1/kappa falls like the root of the distance, its square linearly). On
   every grid edge whose ends differ in membership (and on the half edge from an inside end
   node to the box face): (a) each margin linear between the ends, the first sign change `t1`;
   (b) one look at `t1` (the membership test and the margins there), each margin as the
   parabola through its three values, its first root in the bracket where the three values
   change sign (`[0, t1]` or `[t1, 1]`; a margin negative at none of them has no root): third
   order in the edge length, continuous in the design, one evaluation per crossing. The bracket
   matters where a margin is not smooth: H4's bounds of its z interval take the root of a rod's
   reach, infinitely steep at its boundary, and with `t1` next to an end a parabola through
   three positive values dipped below zero anywhere on the edge, a spurious root that came and
   went as the design moved (a step of 1.6e-4 in V at the h4_mixed optimum before). The integrands at the crossing are
   those at `t1` (1/kappa at the limit where the dexterity margin is the first). (c) Where `t1`
   is unreachable, a second look at the crossing found in (b), or, where that falls just
   outside too (about as often as in: it lies on the crossing's model; a third of the Delta's),
   at the nearest reachable of the points `4^-k` of the way short of it (k = 1..10, one call
   for all). The inside node's integrands, which stood in there before, lie a cell away: the
   earlier h4_mixed best known sat on a spike of 2e-5 of eta, narrower than 1e-9 of d_ratio,
   where the look fell outside (1/kappa 0.16 at the inside node for 0.01 at the crossing). Where
   the dexterity margin is negative at that look it comes first: on the line through the inside
   node and the look. (d) Where the dexterity margin comes first but is unknown at the outside
   end (unreachable there), one more look at its root, and the parabola through the three
   values. Where the outside end is reachable its crossing lies on a parabola through three
   values; with the line alone, the crossing jumped by the line's error as that end turned
   unreachable (a cell's three crossings by 1 % of the cell at once, 2e-6 of eta). The numpy
   and compiled paths, whose boxes differ in the last bit, can still take different sides of a
   reach boundary at a look: GDI 1e-6 apart on one Tricept design at resolution 17. A
   mechanism without margins (an external one, `examples/five_bar`) is bisected
   four times instead, the crossing then to h/32. Compiled (numba) margins and crossing steps;
   `PM_DESIGN_KERNELS=numpy` runs their numpy reference, and `tests/test_kernels.py` checks that
   both give the same numbers.
4. **Cut cells.** A node next to crossings takes the boundary as the plane through the nearest
   crossing along each axis (intercept form `sum_j c_j |u_j| = 1`, `u` in cell units,
   `c_j = h_j / distance_j`). The volume of the cell on either side of that plane and its
   centroid are exact (inclusion-exclusion over the cell's corners,
   `V = sum_v (-1)^|v| max(B - c.v, 0)^d / (d! prod c)`, first moments by differentiating the
   integral over the level B). An inside node counts its own side, an outside node the other.
   A crossing farther than `FADE_FROM` = 3/4 of a cell fades out of the cut: the cuts with and
   without it are blended by a smoothstep that falls to 0 at the neighbouring node. A crossing
   lives on a cut edge, and the edge stops being cut when the crossing reaches its far node
   (that node changes sides): at full slope the plane through it still cut the cell's corners
   there (6 % of a Tricept cell) and lost them in one step (3e-5 of eta along a Tricept
   optimum's line). A blend of cuts rather than a fading slope: a plane of slope near 0 loses
   `eps / slope` of a cell to the inclusion-exclusion's cancellation. Within 1e-4 of a cell
   of a node, all its plane's slopes are scaled down together (at most 1e4), so that the
   plane keeps its direction (capped one by one they turned it, and the integrand at the
   centroid moved by 3 % of a column's height as the node neared the boundary).
5. **Integrand of a cut cell** (1 for V, the column height for H4, 1/kappa for the GDI): taken
   at the centroid of the inside part, linearly along each axis with a crossing: from the node
   and the node behind it (inside node), or between the value at the crossing and the inside
   node beyond it (outside node); the axes weighted by `(c_j - 1)^4`, normalised (mostly the
   nearest crossing's, 0 for a crossing at the far node). The nearest crossing's axis alone
   switched axes where two crossings were about as near, a step in the cell's integrand; the
   weights move continuously. Every axis at weight 1 (the full linear model) is continuous too
   but less accurate (GDI 0.12-0.13 % on H4's and the Delta's designs, a one-sided difference
   along a far crossing's axis being a poor slope).
6. **Bookkeeping is sparse.** The sums are the plain node sums plus, over the nodes next to a
   crossing only, (cut-cell value - plain value), summed compiled.

   **Linear margins, the Tricept's and the Gough-Stewart's cell rule** (`cell_rule = "margins"`,
   `kinematics/margin_cells.py`; `method="margins"` on any mechanism with margins and no exact
   axis, `method="planes"` one plane per cell on any). Steps 3-6 are replaced along the
   boundary: every node whose 26 neighbours share its membership counts its cell whole or not at
   all; every other node (the band) counts the exact part of its cell where each reachability
   margin and the dexterity margin, **each linear over the cell**, holds: from its value at the
   node and its central differences to the neighbouring nodes (every node's margins are computed
   with the fine pass), the margin that vanishes first along a cut edge taking the secant through
   its zero there. That zero is placed as in step 3 (a) and (b), from the two nodes' margins and
   one look between them (the margins and `1/kappa` there; no membership test, no second look:
   the rule needs the crossing's margin, not the integrands there). The part is a convex
   polytope, its volume and centroid exact (`kinematics.polytope.clipped_cell`: the cube clipped
   by each margin's plane, in closed form where one margin cuts the cell, as in step 4), so an
   edge where two constraint surfaces meet, a corner and a slab thinner than a cell keep their
   shape, which one plane per cell cannot (the thin-feature limit below). 1/kappa of a band
   cell's part: the mean over the part of `sqrt(m + limit^2)`, `m` the linear dexterity margin,
   to second order in its spread, `sqrt(E) max(1 - r/8, (1 + r)^(-1/2))` with `E` the mean of
   `m + limit^2` over the part (at its centroid) and `r` its variance over `E^2`, the variance
   exact on every path of the clipper (`kinematics.polytope.clipped_cell_moments`: `|g|^2/12` a
   whole cell, the tetrahedra of a clipped one, inclusion-exclusion's next powers where one
   margin cuts it), so that it moves continuously; of a whole
   cell the node's value plus 1/24 of its second differences along the sampled axes whose two
   neighbours are inside (the cell mean of a parabola); where neither a band node nor its face
   neighbours know the dexterity margin (a corner of the workspace reaching into an unreachable
   node's cell), the nearest of its 26 neighbours that does lends its linear model (that part's
   1/kappa was 0 before: the GDI under-counted by the share of V in such parts, 0.2 % on the
   Gough-Stewart at 22 per axis, 0.05 % on the Tricept). Why the Tricept: at 20^3 nodes it is
   within 0.1 % on every design of the ladder and the scan (at most 0.077 %, the V of a
   documented optimum; 12 further random designs, seed 8: at most 0.082 %, the V of one), where one plane per cell needed
   28^3 and still missed a scan design (0.120 %), at about the cost one plane per cell had at
   28^3 (the tables below); at 19^3 and 18^3 too (V 0.090 % and 0.089 %, GDI 0.075 % and
   0.068 % on the 16 designs, `python -m benchmarks.part_means tricept --resolution 19 18`; with
   the centroid's 1/kappa the GDI missed on 8 and 5 of them), not yet adopted (it would move the
   tricept_max_volume objective and its best known); it has no step where a slab empties
   (Continuity). Why the
   Gough-Stewart (its constant-orientation grid; a 6-D grid keeps one plane per cell): at 26^3
   nodes it is within 0.1 % on the 13 designs (at most 0.085 %) at about 1.8x the old default's
   cost, where one plane per cell at 32^3 cost about 2.6x and fewer nodes did not hold (below);
   at 22^3 and 24^3 its V misses on 3 and 2 designs (0.131 %, 0.115 %). Why not the Delta yet:
   the table "The linear-margins rule" below (its GDI misses, its boundary costlier than its
   nodes save).
7. **Planar mechanisms: exact sections** (`RPR3.exact_sections`, `RPR2.exact_sections`, one
   kernel for both: `kinematics.annuli.annuli_x_sections`). The 3-RPR's workspace at (y, phi)
   is, along x, the intersection of three annuli (seed 003 eq. 12-14): at most four intervals,
   in closed form; the 2-RPR's at y the intersection of two (seed 004 eq. 1-2). V sums their
   lengths over a midpoint rule in (y, phi) (each layer's rows shifted by a golden-ratio
   fraction of a row, so that the annulus that does not turn with phi is not met at the same
   offset in every layer). The 2-RPR's rows span the pose box (1.5 x `resolution` of them,
   `kinematics.workspace.SECTION_NODES`). The 3-RPR's span each layer's exact y extent
   (`kinematics.annuli.annuli_y_extent`: the lowest and highest points of an intersection of
   annuli are extremes of its circles or points where two of them cross, kept where they lie in
   every annulus; `Mechanism.transverse_extent`), and its layers span the orientations where
   anything is reachable (a scan, then a multisection of each end: continuous in the design),
   1.5 x `resolution` layers of 1.25 x `resolution` rows each,
   `kinematics.workspace.EXTENT_SECTION_NODES`. Why: over the pose box, a workspace that fills
   a small part of it met few rows. The scan's sliver (9e-6 of V*, reachable over a third of
   the orientations) met about one row per layer and was 0.56 % off its 4x reference, and 0.51 %
   off the exact integral over phi of the annuli's areas (`RPR3.exact_area`, without a dexterity
   limit). Over the extents it is within 0.003 % of that integral. 1/kappa (closed
   form for the legs' 3 x 3 or 2 x 2 Jacobian, its sign kept so that it stays smooth through a
   singularity) by a corrected trapezoid rule along each interval, the dexterity limit placed by
   interpolation. This replaces the grid for the planar mechanisms, whose thin slivers and
   sharp corners (annuli meeting at grazing angles, narrower than a cell) one plane per cell
   could not hold (3-RPR: 0.56 % at 32^3 on a random design before; 2-RPR: 0.18 % at 400^2 on
   the scan's worst design). Where the reachable volume is known in closed form (2-RPR:
   `RPR2.exact_area`, `Mechanism.exact_volume`), V is that volume times the sections'
   dexterous share (dexterous length over reachable length, summed over the rows): where the
   dexterity limit cuts the workspace inside (the default limit's band), the error of the rule
   across the sections falls out of V, elsewhere it is at most the sections' own; the GDI stays
   the ratio of two sums on the same rows (their errors cancel).

**Order.** Exact for a planar boundary; for a smooth boundary the plane through the crossings is
second-order accurate (the crossings are on the boundary to third order), so the volume error is
O(h^2); the integrand at the centroid is first order per cut cell, and cut cells are O(h) of the
volume, so the GDI is O(h^2) as well (H4's ladder below: the error falls about 4x per halving of
the cell). Features thinner than a cell still converge irregularly (Delta's ladder): each node
keeps one crossing per axis, the nearer, so a cell that holds two boundaries (a slab or a rim
thinner than a cell, two constraint surfaces meeting at a grazing angle) is cut by one plane
through crossings of both, and the resolution at which a feature falls between grid lines
decides the error (on such a Gough-Stewart design the error changes by an order of magnitude
between neighbouring resolutions, while its crossings agree with 20 bisections each). A default
within 0.1 % on the ladder's designs is therefore not a guarantee on every design: the scan of
further random designs below measures how far it holds. (Its other miss was a 3-RPR sliver, a
workspace that is a tiny part of the reference volume, see the V / V* column. Rows over each
layer's extent, item 7, resolve it now.) The fix is a cell rule that keeps every boundary of a
cell: linear margins (below; the Tricept's and the Gough-Stewart's rule now, not yet the Delta's).
Tried and
not adopted: a far strip per axis (a node with crossings on both sides of an axis, the farther
within its cell, took off, or for an outside node added, the part of its cell beyond the farther
crossing, its face normal to the axis). On the scan below it took the worst V from 0.185 % to
0.113 % (Delta) and from 0.120 % to 0.089 % (Tricept), but the Gough-Stewart's paper design
from -0.049 % to -0.145 % against 4x (a random one from -0.053 % to -0.124 %): there the
slabs' over-count had offset an under-count of about 0.15 % elsewhere, not yet located, and
the exact part beyond the farther crossing under the cell's plane (Monte Carlo, 2e4 points a
cell) gives -0.133 %, so the strip's shape is not the cause. Where the error lives, cell by
cell against 400 random points in each (`python -m benchmarks.cell_errors delta "scan 0"`; Delta
scan designs 0 and 3, the Gough-Stewart's paper design): cells cut along one axis only, whose plane is
normal to that axis, over-count at inside nodes (+0.11 to +0.15 % of V) and under-count at
outside ones (-0.11 to -0.20 %), a tilted boundary leaving the cell through a face that plane
does not see, netting -0.09 to +0.03 %; the slabs +0.05 to +0.12 %; outside nodes none of
whose edges is cut but whose cell's corner lies inside -0.04 to -0.07 %. Each is a boundary
the cell's own crossings do not describe; a rule that also takes the tilt from the
neighbouring nodes' crossings (or the margins' values at the cell's corners) is the next step.
Measured after the fact on these designs and Tricept scan 5 (not in the code): tilting each plane
along every axis without a crossing by the difference of its neighbours' crossings along its main
axis (a height function) cuts the one-axis cells' mean error per cell 2-2.5x and their net
error from +0.05 to +0.15 % (inside nodes) and -0.03 to -0.20 % (outside) to within 0.06 %, and
the two-axis cells' mean error by 20-30 %; the three-axis cells at inside nodes, which hold the
slabs, still over-count by +0.10 to +0.15 %, so the sum over cut cells improves only once they
are treated too (and the objective must stay continuous where a neighbour's crossing comes and
goes). Both together, measured after the fact in the same way (a model of the rule without its
fading, tested with the truth on the same 200 random points of each cut cell): the cut cells' net
error goes from +0.250 to +0.167 % of V on Delta scan 0, from +0.003 to -0.022 % on Delta scan
3, from +0.144 to +0.131 % on Tricept scan 5 and from +0.029 to -0.032 % on the
Gough-Stewart's paper design. The mean error per cell falls by 35-40 %, the net error does not:
on Delta scan 0 what remains over-counts the workspace at inside (+0.095 %) and outside
(+0.072 %) nodes alike, a bias neither change touches. So neither is adopted. What does remove
it, measured after the fact (`python -m benchmarks.cell_errors delta "scan 0" --candidate`), is
a rule that keeps each constraint's own surface, **linear margins**: each margin (and the
dexterity margin) linear over the cell, from its value at the node and its differences to the
neighbouring nodes, its slope along an axis the secant through that axis's crossing where it is
the margin that vanishes there; the cell's inside part is the intersection of their half-spaces,
so that an edge where two surfaces meet, a corner and a slab keep their shape. Against the
membership of the same 200 points a cell (cut cells, % of V), the planes -> linear margins: Delta
scan 0 +0.250 -> +0.011, Delta scan 3 +0.003 -> +0.050, Tricept scan 5 +0.144 -> -0.018, the
Gough-Stewart's paper design +0.029 -> -0.040; the mean error per cut cell falls 3.5-7.6x (0.0147
-> 0.0042 of a cell on Delta scan 0, 0.0114 -> 0.0015 on Tricept scan 5). Over all 30 scan
designs of the three mechanisms (150 points a cell) its net error stays within 0.062 % (the
planes: up to +0.225 %). With a third of the nodes (18, 20 and 22 per axis for the Delta, the
Tricept and the Gough-Stewart) 28 of the 30 stay within 0.1 % (Delta scan 1 +0.109 %, scan 3
+0.117 %; the planes: up to +0.442 %, 19 of 30 over 0.1 %): nearly the rule accurate on fewer
nodes that the cost target needs (below). Over the whole grid (`--volume`: every node whose 26
neighbours share its membership counts its cell whole or not at all, every other node the exact
part of its cell under its linear margins, `kinematics.polytope.clipped_cell`; 1/kappa of a part
at its centroid from the linear dexterity margin, of a whole cell the node's value plus 1/24 of
its second differences; no Monte Carlo), against the 4x reference on the 10 scan designs, max
|error| V / GDI: at the defaults Delta 0.053 / 0.160 % (the code: 0.185 / 0.068 %), Tricept
0.030 / 0.013 % (0.120 / 0.029 %), Gough-Stewart 0.043 / 0.060 % (0.048 / 0.019 %); with fewer
nodes the Tricept at 20 per axis 0.067 / 0.069 % (none of the 10 over 0.1 %; one plane per cell
at 28, its default then, cost about twice as much), the Delta at 21 0.118 / 0.228 % (5 over), the Gough-Stewart at 22
0.110 / 0.152 % (1 over, scan 5). The secants matter: without
them (margins at the nodes alone, no looks between the nodes) V errs by up to 0.34 % (Delta),
0.06 % (Tricept), 0.09 % (Gough-Stewart) at the defaults. The GDI's weak part is the boundary
cells' 1/kappa: with every boundary part's 1/kappa and membership exact (Monte Carlo) and the
second differences inside, the Delta's GDI errs by +0.007 % on scan 5 at 18 per axis, with the
centroid's 1/kappa by +0.46 % (1/kappa falls like a root towards a singular boundary, and the
square of the linear model overshoots there; a look at the centroid does no better, +0.42 %).
It is built (`kinematics/margin_cells.py`, the end of step 6) and is the **Tricept's cell rule**
at 20 per axis: its crossings from the nodes' margins and one look per cut edge (margins and
`1/kappa` only), every node's margins with the fine pass, a closed form where one margin cuts a
cell, which brought its cost from 2.8x the old default (with the grid method's crossings: three
looks per cut edge, a membership test and the margins at each crossing again) to about 2.3x, and
with the compiled nearest secants and one pass per clipped cell to about 1.8-1.9x (the table below). The
GDI's bias was positive (the Tricept's +0.03 to +0.09 %) while 1/kappa of a band cell's part was
the square root of the linear model at the part's centroid, above its mean over the part (1/kappa
is concave there, a root towards a singular boundary); with the mean from the part's moments (step
6) the Tricept's GDI errs by at most 0.049 % (+0.02 to +0.05 %), and agrees with the Monte Carlo
mean of the same model, each cell its own 4,000 points, within 0.003 % (`python -m
benchmarks.part_means tricept`; one set of points for every cell gave 0.042 %, its sampling error
the same in every cell, a bias). It is
the Gough-Stewart's cell rule too, at 26 per axis (its GDI's misses at 22, -0.15 %, were the
parts without a dexterity model, now lent one: 0.04 %). Not yet the Delta's (the table "The
linear-margins rule" below): its GDI misses at fewer nodes than its default and its boundary
costs more than its nodes save (with the parts' means its GDI at 26 errs by 0.090 %, 0.131 %
before, but its V by 0.112 % on scan 5). The H4's exact axis is not supported. The parts' means
moved the Gough-Stewart's GDI by 0.004-0.008 % (its largest error 0.020 -> 0.013 %), the
Tricept's by 0.015-0.053 %; V did not move (bit for bit).
The
planar mechanisms' sections converge like h^1.5 across (y, phi) (where a section shrinks to
nothing, its length falls like a square root), irregularly (the 2-RPR's reachable sections
against `RPR2.exact_area` on its paper design: +0.045 %, -0.020 %, +0.026 % at 200, 400, 800,
which the closed-form volume takes out of its V).

**Independent references.** The reference of each design below is the grid method at
4x the finer of the two defaults (cross-checked against the old method there), with one plane
per cell whatever the mechanism's cell rule (`benchmarks.accuracy.reference_method`: the
Tricept's linear margins are checked against the other rule, not against themselves). Where the exact value is
known independently of any grid, the tests hold the default to it: the 2-RPR's reachable area
(`RPR2.exact_area`, two annuli in closed form) against the sum of its sections before the
closed form replaces it (six random designs within 0.1 %; the old count errs by up to 0.27 % on
them), its dexterous area against the cell grid at 4x the default (and at 8x where the
dexterity limit is 0.3 and reaches the sections' ends: within 0.3 %), the 3-RPR's
constant-orientation area (`RPR3.exact_area`), and the 3-RPR's reachable volume over its
orientations against the adaptive integral (scipy's `quad`) of that area over phi: the sliver
and three random designs, within 0.1 %.

**Continuity.** When the boundary crosses a node, the plane passes through the node and its
cell counts one half from either side (whatever the plane's direction): the count has no step.
The crossings on the margins, the 3-RPR's sections and the occupied box move continuously with
the design, and a crossing that leaves a cell at its far node fades out of its cut first.
`tests/test_accuracy.py::test_eta_along_a_line_has_no_steps` walks eta (w_d = 0.5) through an
optimum (H4: h4_mixed's best known; Tricept: a max-volume optimum; 3-RPR: rpr3_mixed's best
known; 2-RPR: the trade-off's w_d = 0.5 optimum; the Delta, which has none documented: the
middle of its design box) along **every** design variable, in steps of 0.05 % of its range
(shifted to stay within its bounds): no change between neighbours exceeds both twice the median
change and twice each of its two neighbouring changes (+1e-5 eta: a step stands out from its smooth
neighbours, while a kink at a ridge does not; through rpr3_mixed's regenerated best known eta rises
by about 1e-6 per point on one side and falls by 4-7e-6 on the other, with no step); the old count fails the same test for H4, Tricept, Delta and 3-RPR along
one variable each (along H4's line through the regenerated best known it steps by 32 ppm of eta
against a median of 4; through the earlier one its changes were all irregular). The objective of the previous version failed it for H4 (a spike of
2e-5 of eta at the h4_mixed best known, where a crossing's look fell just outside, step 3c)
and for the Tricept along b (3e-5 of eta, a corner cut lost in one step, step 4; faded since). Along the old
h4_mixed best known's line the largest change between neighbours is now 2.3x the median (it was
246x); `test_no_spike_where_a_crossing_s_look_falls_just_outside` walks it at a tenth of the
step. The last step, along the Tricept's b with one plane per cell, went with its linear margins:
0.4 % of b above its lower bound a node inside a slab 0.73 cells wide leaves it through the
slab's far side; the edge to its outside neighbour stops being cut, and the crossing on it, 0.27
cells from that neighbour, was lost with 0.23 of its cell (1.8e-5 of eta): one crossing per node
and axis cannot hold a slab thinner than a cell once no node lies inside it (the thin-feature
limit above). The linear margins keep both faces of the slab in the band's cells, and the walk
along b has no step (`test_one_plane_per_cell_steps_where_a_slab_empties` keeps the planes' step
as the evidence that the test can fail there).

**Error bars** (part 2). `Evaluation.volume_error` and `gdi_error` (with `error_estimate=True`,
the default of `evaluate`) are the change against the same method at half the resolution
(1/8 of the cost in 3-D); `Evaluation.mixed_error(w_d)` propagates them to eta. For the old
method they remain the change against the grid shifted by half a cell. In the pipeline each
optimum carries `objective_error` (its change at `evaluate.refine_factor` x the resolution, in
`best.parquet` and the dataset), and a gap smaller than its error is reported as within error.
The table at the end compares the estimate at the default with the true error: an upper
estimate in most cases, not all, often 2-10x conservative.

**An independent check** (docs/monte_carlo.md, `python -m benchmarks.monte_carlo`): randomised
quasi-Monte Carlo over the whole pose box, each point tested by `membership` alone (no grid, no
crossing, no occupied box). On the paper designs of the six mechanisms and the best known optima
of the four problems, the default V and GDI are within 0.088 % of it (H4's h4_max_volume GDI;
the Tricept's V of its optimum -0.077 %), and the reference of the tables below within 0.011 %.
On the Delta's ten scan designs (the scan below) the default V is more than 0.1 % above it
on four: scans 0, 4, 7 and 9, by 0.177, 0.158, 0.115 and 0.114 % (intervals ±0.009 to ±0.023 %);
the reference is within 0.016 % on all ten: the Delta's scan miss, confirmed independently of
our reference.

**Measured against the issue's targets.** The verdict per mechanism is computed from the
tables and printed at the top of "Measured" below (old and new timed alternately in one run,
the process's CPU time, least of 15 per design, mean over the designs; on the shared 2-core
machine a single figure moves by 10-20 % between runs: a ratio near 2x can fall on either
side). Where the cost goes is measured phase by phase in the table "Where the new method's
time goes": the fine pass alone (the grid's nodes, nothing else) is the floor of the method at
its node budget. The table compares the room it leaves under 2x with what the coarse pass and
the boundary cost now: where the room is a fraction of that (H4: 30 x 30 x 15 columns of a compiled z
interval against the old 24^3; the Gough-Stewart with one plane per cell: the occupied box put
about twice as many reachable nodes, each a 6 x 6 SVD, into the workspace as the old grid over
the whole box), 2x needs a rule accurate to 0.1 % on fewer nodes rather than a faster boundary:
one plane per cell at 26, 28 and 30 nodes per axis instead of 32 erred on the Gough-Stewart by up
to 0.138 %, 0.203 % and 0.194 % of V (against the 4x reference, on the ladder's 3 and the scan's
10 designs), its linear margins at 26 by 0.085 % (its cell rule now). On top of the fine
pass come the coarse pass (1/8 of the nodes, plus the extreme edges'
crossings), and the boundary: with one plane per cell the margins at three points per cut edge
(H4: 28 margins, 4 rods' reach, the 12 orderings of the z interval's bounds and its 8 bounds
against the box, 4 joint limits), one membership test per cut edge, and the cut-cell sums; with
linear margins every node's margins (in the fine pass), one look per cut edge (its margins and
1/kappa) and the band's clipped cells.
"""


def random_designs(name: str, seed: int, count: int, label: str = "random") -> list[tuple[str, object]]:
    """``count`` designs drawn uniformly from the design box (seeded), those with a workspace."""
    cls = MECHANISMS[name]
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count and cls.design_variables:
        x = [rng.uniform(v.lower, v.upper) for v in cls.design_variables]
        mech = cls.from_design(np.array(x), **cls.default_fixed)
        if evaluate(mech, resolution=12, error_estimate=False).volume > 0:
            out.append((f"{label} {len(out)}", mech))
    return out


def optimum(name: str, k: int):
    """The mechanism of the ``k``-th documented optimum of :data:`OPTIMA`."""
    design = OPTIMA[name][k]
    if isinstance(design, dict):
        return get_mechanism(name, **design)
    cls = MECHANISMS[name]
    return cls.from_design(np.array(design), **cls.default_fixed)


def designs(name: str, seed: int = 0) -> list[tuple[str, object]]:
    """(label, mechanism) pairs: paper design, documented optima, two random designs."""
    out = [("paper", get_mechanism(name, **PAPER[name]))]
    out += [(f"optimum {k}", optimum(name, k)) for k in range(len(OPTIMA.get(name, [])))]
    return out + random_designs(name, seed, 2)


def best_time(func, repeats: int = REPEATS) -> float:
    """Least CPU seconds of this process over ``repeats`` calls: CPU time, not wall time, since
    the 2-core machine is shared (under a load of 4-6 wall-clock ratios moved by 50 % between
    runs); the kernels run on one thread, so this is one core's time."""
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        func()
        best = min(best, time.process_time() - start)
    return best


def alternate_times(mech, resolutions: dict[str, int | None]) -> dict[str, float]:
    """Least CPU seconds of one evaluation of ``mech`` per method of ``resolutions`` (method ->
    resolution, None: its default) over :data:`REPEATS` rounds that time the methods
    alternately: the machine's load hits both alike."""
    best = dict.fromkeys(resolutions, math.inf)
    for _ in range(REPEATS):
        for method, resolution in resolutions.items():
            best[method] = min(
                best[method],
                best_time(
                    lambda r=resolution, k=method: evaluate(mech, resolution=r, method=k, error_estimate=False), 1
                ),
            )
    return best


#: the quantities of :func:`quantities`, in its order
QUANTITIES = ("V", "GDI", "eta")


def percentages(values: np.ndarray) -> str:
    """A triple of relative errors (V, GDI, eta) as ``a % / b % / c %``."""
    return " / ".join(f"{100 * v:.3f} %" for v in values)


def quantities(ev) -> np.ndarray:
    return np.array([ev.volume, ev.gdi, ev.mixed(W_D)])


def study(name: str) -> dict:
    cases = designs(name)
    # each method's ladder around its own default (the grid method's node budget may differ)
    r_default = {method: default_resolution(cases[0][1], method=method) for method in ("midpoint", "grid")}
    # the reference: REFERENCE_FACTOR x the finer of the two defaults
    r0 = max(r_default.values())
    refs, cross = [], []
    for _, mech in cases:
        ref = reference_evaluation(mech)
        old_ref = evaluate(mech, resolution=REFERENCE_FACTOR * r0, method="midpoint", error_estimate=False)
        refs.append(quantities(ref))
        cross.append(np.abs(quantities(old_ref) / quantities(ref) - 1))
    rows = []
    for factor in LADDER:
        res = {method: max(int(round(factor * r)), 2) for method, r in r_default.items()}
        errors = {"midpoint": [], "grid": []}
        seconds = {"midpoint": [], "grid": []}
        for (_, mech), ref in zip(cases, refs):
            for method in errors:
                ev = evaluate(mech, resolution=res[method], method=method, error_estimate=False)  # compile, warm
                errors[method].append(np.abs(quantities(ev) / ref - 1))
            for method, best in alternate_times(mech, res).items():
                seconds[method].append(best)
        for method in errors:
            err = np.max(errors[method], axis=0)
            rows.append(
                dict(
                    method=method,
                    factor=factor,
                    resolution=res[method],
                    seconds=float(np.mean(seconds[method])),
                    v=err[0],
                    gdi=err[1],
                    eta=err[2],
                )
            )
    rows.sort(key=lambda row: (row["method"] != "midpoint", row["factor"]))
    # error bars: the grid method's own estimate (half resolution) against the true error, at its default
    calibration = []
    for (label, mech), ref in zip(cases, refs):
        ev = evaluate(mech, method="grid")
        calibration.append(
            (
                label,
                abs(ev.volume / ref[0] - 1),
                ev.volume_error / ref[0],
                abs(ev.gdi / ref[1] - 1),
                ev.gdi_error / ref[1],
            )
        )
    return dict(
        name=name,
        r0=r0,
        r_old=r_default["midpoint"],
        r_grid=r_default["grid"],
        cases=[c[0] for c in cases],
        rows=rows,
        cross=np.max(cross, axis=0),
        calibration=calibration,
        designs=[mech for _, mech in cases],
        refs=refs,
    )


def scan(name: str) -> dict:
    """Errors (designs, 3: V, GDI, eta) of each method at its default on :data:`SCAN` random designs
    (seed :data:`SCAN_SEED`), against the new method at :data:`REFERENCE_FACTOR` x the finer
    of the two defaults."""
    errors: dict[str, list] = {method: [] for method in METHODS}
    suri, estimate, mechs, refs = [], [], [], []
    for _, mech in random_designs(name, SCAN_SEED, SCAN, "scan"):
        reference = reference_evaluation(mech)
        ref = quantities(reference)
        mechs.append(mech)
        refs.append(ref)
        suri.append(reference.suri)
        for method in METHODS:
            ev = evaluate(mech, method=method, error_estimate=method == "grid")
            errors[method].append(np.abs(quantities(ev) / ref - 1))
            if method == "grid":  # the error bar the pipeline reports, against the true error
                estimate.append(np.array([ev.volume_error, ev.gdi_error, ev.mixed_error(W_D)]) / np.abs(ref))
    return {method: np.array(e) for method, e in errors.items()} | {
        "suri": np.array(suri),
        "estimate": np.array(estimate),
        "designs": mechs,
        "refs": refs,
    }


#: ``evaluate(method="margins")`` (kinematics.margin_cells) where it is not the mechanism's cell rule
#: (the Tricept's ladder and scan measure it there): its resolutions per mechanism, the grid
#: method's default (None) and about a third of its nodes
MARGIN_RESOLUTIONS = {"delta": (None, 21, 18)}


def margins_study(r: dict) -> list[dict]:
    """``evaluate(method="margins")`` at :data:`MARGIN_RESOLUTIONS` on the ladder's and the scan's
    designs of ``r`` (:func:`study` with its ``scan``), against the same references: per resolution
    the largest error of V, GDI and eta, the designs over the target, and the cost on the paper
    design against the old default (timed alternately, as the ladder)."""
    name = r["name"]
    mechs = r["designs"] + r["scan"]["designs"]
    refs = r["refs"] + r["scan"]["refs"]
    paper = r["designs"][0]
    rows = []
    for resolution in MARGIN_RESOLUTIONS.get(name, ()):
        errors = np.array(
            [
                np.abs(quantities(evaluate(m, resolution=resolution, method="margins", error_estimate=False)) / ref - 1)
                for m, ref in zip(mechs, refs)
            ]
        )
        res = resolution or default_resolution(paper, method="margins")
        evaluate(paper, resolution=res, method="margins", error_estimate=False)  # compile, warm
        times = alternate_times(paper, {"midpoint": None, "margins": res})
        rows.append(
            dict(
                name=name,
                resolution=res,
                default=resolution is None,
                nodes=grid_nodes(paper, res, method="margins"),
                designs=len(mechs),
                max=errors.max(axis=0),
                over=int((errors.max(axis=1) > ERROR_TARGET).sum()),
                cost=times["margins"] / times["midpoint"],
            )
        )
    return rows


def margins_table(results: list[dict]) -> str:
    lines = [
        "| mechanism | resolution (nodes) | designs | max error V / GDI / eta | designs over "
        f"{100 * ERROR_TARGET:g} % | cost vs old default |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        for row in r.get("margins", []):
            label = f"{row['resolution']}{' (the grid default)' if row['default'] else ''}, {row['nodes']}"
            lines.append(
                f"| {row['name']} | {label} | {row['designs']} | {percentages(row['max'])} | {row['over']} | "
                f"{row['cost']:.2f}x |"
            )
    return "\n".join(lines)


#: the new method's phases, by the functions of kinematics.workspace that run them
PHASES = {
    "_integrate_grid": "total",
    "_occupied_box": "coarse",
    "_boundary_corrected_sums": "boundary",
    "_margin_secants": "boundary",
    "margin_cell_sums": "boundary",
}


def phases(name: str) -> dict[str, float] | None:
    """CPU seconds of the new method's phases at its default on the paper design: the coarse pass
    (the occupied box), the boundary (the crossings and the cut cells) and the fine pass (the
    rest: the grid's nodes). The profiler slows Python more than the compiled kernels, so each
    phase is its share of the fastest of :data:`REPEATS` profiled runs times the unprofiled
    evaluation (``total``, timed alternately with the old default, ``old``, as in the ladder).
    None where the new method is not a grid (3-RPR, 2-RPR: sections)."""
    mech = get_mechanism(name, **PAPER[name])
    evaluate(mech, error_estimate=False)  # compile, warm
    best = None
    for _ in range(REPEATS):
        profile = cProfile.Profile(time.process_time)
        profile.enable()
        evaluate(mech, error_estimate=False)
        profile.disable()
        spent = dict.fromkeys(PHASES.values(), 0.0)
        for (path, _, function), (_, _, _, cumulative, _) in pstats.Stats(profile).stats.items():
            if function in PHASES and path.endswith(("workspace.py", "margin_cells.py")):
                spent[PHASES[function]] += cumulative
        if spent["total"] > 0 and (best is None or spent["total"] < best["total"]):
            best = spent
    if best is None:
        return None
    times = alternate_times(mech, dict.fromkeys(METHODS))
    share = {phase: best[phase] / best["total"] for phase in ("coarse", "boundary")}
    share["fine"] = 1.0 - share["coarse"] - share["boundary"]
    return {phase: value * times["grid"] for phase, value in share.items()} | {
        "total": times["grid"],
        "old": times["midpoint"],
    }


def phase_table(results: list[dict]) -> str:
    lines = [
        "| mechanism | old default, ms | new default, ms | coarse pass | fine pass | boundary: crossings, cut cells "
        f"| fine pass alone / old default | room left under {COST_TARGET:g}x for coarse + boundary, "
        "in old defaults | coarse + boundary now |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        p = r["phases"]
        if p is None:
            lines.append(f"| {r['name']} | | | exact sections, no grid phases | | | | | |")
            continue
        lines.append(
            f"| {r['name']} | {1e3 * p['old']:.1f} | {1e3 * p['total']:.1f} | {1e3 * p['coarse']:.1f} | "
            f"{1e3 * p['fine']:.1f} | {1e3 * p['boundary']:.1f} | **{p['fine'] / p['old']:.2f}x** | "
            f"{COST_TARGET - p['fine'] / p['old']:.2f} | {(p['coarse'] + p['boundary']) / p['old']:.2f} |"
        )
    return "\n".join(lines)


def scan_table(results: list[dict]) -> str:
    lines = [
        "| mechanism | designs | new max error V / GDI / eta | new median V / GDI / eta | designs over "
        f"{100 * ERROR_TARGET:g} % | V / V* of the worst | the worst: error, its estimate "
        "| old max error V / GDI / eta |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        new, old = r["scan"]["grid"], r["scan"]["midpoint"]
        if not new.size:
            continue
        worst, column = np.unravel_index(int(np.argmax(new)), new.shape)
        lines.append(
            f"| {r['name']} | {new.shape[0]} | {percentages(new.max(axis=0))} | "
            f"{percentages(np.median(new, axis=0))} | "
            f"{int((new.max(axis=1) > ERROR_TARGET).sum())} | {r['scan']['suri'][worst]:.2g} | "
            f"{QUANTITIES[column]} {100 * new[worst, column]:.3f} %, "
            f"{100 * r['scan']['estimate'][worst, column]:.3f} % | {percentages(old.max(axis=0))} |"
        )
    return "\n".join(lines)


def scan_calibration(results: list[dict]) -> str:
    """How often the error bar (the change at half the resolution) covers the true error on the
    scan's designs, over all of them and over those that miss :data:`ERROR_TARGET`."""
    true = np.vstack([r["scan"]["grid"] for r in results if r["scan"]["grid"].size])
    bar = np.vstack([r["scan"]["estimate"] for r in results if r["scan"]["grid"].size])
    covered = bar >= true
    missing = true.max(axis=1) > ERROR_TARGET
    return (
        f"On these {true.shape[0]} designs the error bar is at least the true error for V on "
        f"{int(covered[:, 0].sum())}, for the GDI on {int(covered[:, 1].sum())} and for eta on "
        f"{int(covered[:, 2].sum())}; on the {int(missing.sum())} designs that miss "
        f"{100 * ERROR_TARGET:g} % it covers every quantity on {int(covered[missing].all(axis=1).sum())}."
    )


def table(results: list[dict]) -> str:
    lines = [
        "| mechanism | method | resolution | ms / evaluation | cost vs old default | max error V | GDI | eta |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        base = next(row["seconds"] for row in r["rows"] if row["method"] == "midpoint" and row["factor"] == 1.0)
        for row in r["rows"]:
            mark = " (default)" if row["factor"] == 1.0 else ""
            lines.append(
                f"| {r['name']} | {'old' if row['method'] == 'midpoint' else 'new'} | "
                f"{row['resolution']}{mark} | {1e3 * row['seconds']:.1f} | {row['seconds'] / base:.2f} | "
                f"{100 * row['v']:.3f} % | {100 * row['gdi']:.3f} % | {100 * row['eta']:.3f} % |"
            )
    return "\n".join(lines)


def verdict(results: list[dict]) -> str:
    """The issue's two targets per mechanism, from each method's row at its default: cost at most
    :data:`COST_TARGET` x the old default, V, GDI and eta within :data:`ERROR_TARGET`."""
    cost, accuracy, widely = [], [], []
    for r in results:
        old, new = (next(row for row in r["rows"] if row["method"] == m and row["factor"] == 1.0) for m in METHODS)
        ratio = new["seconds"] / old["seconds"]
        cost.append((r["name"], ratio <= COST_TARGET, f"{ratio:.2f}x"))
        worst = max(("V", new["v"]), ("GDI", new["gdi"]), ("eta", new["eta"]), key=lambda kv: kv[1])
        accuracy.append((r["name"], worst[1] <= ERROR_TARGET, f"{worst[0]} {100 * worst[1]:.3f} %"))
        scanned = r["scan"]["grid"]
        if scanned.size:
            column = int(np.argmax(scanned.max(axis=0)))
            value = float(scanned.max())
            label = f"{QUANTITIES[column]} {100 * value:.3f} %"
            widely.append((r["name"], value <= ERROR_TARGET, label))

    def line(title: str, items: list) -> str:
        met = [f"{name} ({figure})" for name, ok, figure in items if ok]
        missed = [f"{name} ({figure})" for name, ok, figure in items if not ok]
        return f"* {title}: met for {', '.join(met) or 'none'}; **missed for {', '.join(missed) or 'none'}**."

    return "\n".join(
        [
            "Verdict against the issue's targets at each method's default (from the tables below):\n",
            line(f"Cost, new <= {COST_TARGET:g}x the old default", cost),
            line(f"Accuracy, largest error of V, GDI, eta over the designs <= {100 * ERROR_TARGET:g} %", accuracy),
            line(
                f"Accuracy on {SCAN} further random designs per mechanism (seed {SCAN_SEED}), largest error "
                f"<= {100 * ERROR_TARGET:g} %",
                widely,
            ),
        ]
    )


def summary(results: list[dict]) -> str:
    """One row per mechanism: each method at its default resolution, the cost ratio measured in
    the same run, and the largest errors over the designs."""
    lines = [
        "| mechanism | old: resolution, ms | new: resolution, ms | new / old cost | new max error V / GDI / eta "
        "| old max error V / GDI / eta |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        old, new = (next(row for row in r["rows"] if row["method"] == m and row["factor"] == 1.0) for m in METHODS)
        lines.append(
            f"| {r['name']} | {old['resolution']}, {1e3 * old['seconds']:.1f} | {new['resolution']}, "
            f"{1e3 * new['seconds']:.1f} | **{new['seconds'] / old['seconds']:.2f}x** | "
            + f"{percentages([new[k] for k in ('v', 'gdi', 'eta')])} | "
            + f"{percentages([old[k] for k in ('v', 'gdi', 'eta')])} |"
        )
    return "\n".join(lines)


def figure(results: list[dict]) -> None:
    columns = 3
    rows_of_panels = -(-len(results) // columns)
    fig, axes = plt.subplots(rows_of_panels, columns, figsize=(4.2 * columns, 3.6 * rows_of_panels), sharey=True)
    axes = np.atleast_1d(axes).ravel()
    for ax in axes[len(results) :]:
        ax.set_visible(False)
    for ax, r in zip(axes, results):
        for method, style, label in (
            ("midpoint", "o--", "old: cell-centre count"),
            ("grid", "s-", "new: boundary fractions"),
        ):
            rows = [row for row in r["rows"] if row["method"] == method]
            cost = [1e3 * row["seconds"] for row in rows]
            err = [100 * max(row["v"], row["gdi"], row["eta"], 1e-6) for row in rows]
            ax.loglog(cost, err, style, label=label)
            for row, c, e in zip(rows, cost, err):
                if row["factor"] == 1.0:
                    ax.annotate("default", (c, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.axhline(0.1, color="grey", lw=0.8, ls=":")
        ax.xaxis.set_minor_formatter(NullFormatter())  # a narrow decade would label its minor ticks
        ax.set_title(f"{r['name']} (defaults: old {r['r_old']}, new {r['r_grid']})")
        ax.set_xlabel("CPU ms per evaluation (one core)")
        ax.grid(True, which="both", lw=0.3)
    for ax in axes[::columns]:
        ax.set_ylabel("max relative error of V, GDI, eta [%]")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=120)


def main() -> None:
    # --help prints the usage and exits before any work (the run rewrites docs/accuracy.md)
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    results = []
    for name in sorted(MECHANISMS):
        r = study(name)
        r["scan"] = scan(name)
        r["phases"] = phases(name)
        r["margins"] = margins_study(r)
        results.append(r)
        print(
            f"{name}: designs {', '.join(r['cases'])}; reference at resolution {REFERENCE_FACTOR * r['r0']}, "
            f"old vs new there: V {100 * r['cross'][0]:.3f} %, GDI {100 * r['cross'][1]:.3f} %",
            flush=True,
        )
    text = (
        verdict(results)
        + "\n\nAt each method's default resolution:\n\n"
        + summary(results)
        + f"\n\nOn {SCAN} further random designs per mechanism (seed {SCAN_SEED}; each against the same "
        "reference rule; the ladder's designs are not among them; V / V* is the worst design's workspace "
        "against the mechanism's reference volume: a small one is a sliver; its estimate is the error bar "
        "`evaluate` reports, the change at half the resolution). A mechanism's worst design here is a "
        "case of tests/test_accuracy.py (label `thin`), a strict xfail where it misses the target:\n\n"
        + scan_table(results)
        + "\n\n"
        + scan_calibration(results)
        + '\n\nThe linear-margins rule `evaluate(method="margins")` (`kinematics.margin_cells`) where it is '
        "not the mechanism's cell rule (the Tricept's and the Gough-Stewart's are, see \"Order\"), on the ladder's and the scan's designs against the same references, "
        "at the grid method's default resolution and at about a third of its nodes; its cost on the paper "
        "design against the old default, timed alternately as the ladder:\n\n"
        + margins_table(results)
        + "\n\nWhere the new method's time goes at its default (paper design, CPU time; each phase is its "
        f"share of the fastest of {REPEATS} profiled runs times the unprofiled evaluation; the fine pass "
        "is the grid's nodes, the boundary the crossings and the cut cells; the last two columns in "
        "units of the old default's evaluation):\n\n" + phase_table(results) + "\n\nThe ladder:\n\n" + table(results)
    )
    print(text)
    calib = [
        "| mechanism | design | true V error | estimate | true GDI error | estimate |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        for label, tv, ev, tg, eg in r["calibration"]:
            calib.append(
                f"| {r['name']} | {label} | {100 * tv:.3f} % | {100 * ev:.3f} % | {100 * tg:.3f} % | {100 * eg:.3f} % |"
            )
    rows = [row for r in results for row in r["calibration"]]
    calib.append(
        f"\nThe estimate is at least the true error for V in {sum(ev >= tv for _, tv, ev, _, _ in rows)} "
        f"of {len(rows)} designs, for the GDI in {sum(eg >= tg for _, _, _, tg, eg in rows)} of {len(rows)} "
        "(compared before the table's rounding to 0.001 %)."
    )
    print("\n".join(calib))
    figure(results)
    cross = "\n".join(
        f"* {r['name']}: V {100 * r['cross'][0]:.3f} %, GDI {100 * r['cross'][1]:.3f} % "
        f"(designs: {', '.join(r['cases'])})"
        for r in results
    )
    write_page(
        text
        + "\n\nOld vs new method at the reference resolution (largest difference over the designs):\n\n"
        + cross
        + "\n\nError bars at the default resolution (`Evaluation.volume_error`, `gdi_error`) against "
        "the true error (vs the reference):\n\n" + "\n".join(calib) + "\n"
    )


def write_page(measured: str) -> None:
    """docs/accuracy.md: the method (:data:`METHOD`) and the measured tables."""
    (DOCS / "accuracy.md").write_text(
        "<!-- generated by python -m benchmarks.accuracy; edit METHOD there, not this file -->\n\n"
        + METHOD
        + "\n## Measured ("
        + time.strftime("%Y-%m-%d")
        + ", CPU time on one core of the 2-core machine)\n\n"
        + measured
    )


if __name__ == "__main__":
    main()
