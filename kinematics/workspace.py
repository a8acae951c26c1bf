"""Workspace volume and dexterity indices of one design (seed 000 Sec. 4, seed 001 Sec. 4).

``evaluate(mechanism, **options)`` integrates over a box of poses derived from
the geometry (:meth:`~kinematics.base.Mechanism.pose_bounds`):

* **volume** ``V = int_W dV`` over the workspace W: H4 in cm^3 rad over
  (x, y, z, theta); Tricept in mm rad^2 over (c, psi, theta) (seed 001 eq.
  38-39); 3-RPR in mm^2 rad over (x, y, phi), or mm^2 at constant phi; 2-RPR
  in mm^2.
* **GDI** ``(1/V) int_W 1/kappa dV`` (seed 000 eq. 36) and the min / max / mean of
  ``1/kappa`` over W (the Tricept paper's LCI range).
* **SURI** ``V / V*`` with ``V*`` the robot size
  (:meth:`~kinematics.base.Mechanism.reference_volume`), and the mixed index
  ``eta = w_d GDI + (1 - w_d) SURI`` (seed 000 eq. 36) via :meth:`Evaluation.mixed`.

Workspace membership of a pose: real inverse kinematics; every actuator
within its range (H4 ``0..stroke``, Tricept 400-750 mm, planar
``rho_min..rho_max``); passive joint limits (Tricept cone <= 60 deg); the
orientation range; and dexterity ``1/kappa > min_inverse_condition`` (0.01,
seed 000 Sec. 4.4; 0 disables it, as the planar papers define their
workspaces).

Integration, ``method="grid"`` (the default; docs/accuracy.md): a regular grid
with ``resolution`` nodes per sampled axis over the part of the box the
workspace occupies (found on a grid of half the resolution), each node owning
its cell. A cell that the workspace boundary cuts counts with the fraction of
it inside: the boundary crossings on the grid edges next to the node are
located on the workspace's margins (:func:`_crossings`: the mechanism's
reachability margins, :meth:`~kinematics.base.Mechanism.constraint_margins`, and
``1/kappa^2`` against the dexterity limit, each interpolated through three points
of the edge; a mechanism without margins is bisected), the boundary is taken as the plane through the nearest
crossing along each axis and the fraction and centroid of the cut cell follow
in closed form; the integrand of a cut cell is taken at that centroid. Exact
for a planar boundary and second order for a smooth one, and continuous in the
design (no step when the boundary crosses a node); it costs more than the plain
count at each mechanism's default (the ratios: docs/accuracy.md). That is the cell rule
``"planes"``; a mechanism whose :attr:`~kinematics.base.Mechanism.cell_rule` is ``"margins"``
(the Tricept, the Gough-Stewart) counts the cells along the boundary under its margins, each
linear over the cell, instead (:mod:`kinematics.margin_cells`, crossings by :func:`_margin_secants`), which
holds a corner and a slab thinner than a cell; ``method="planes"`` and ``method="margins"``
force either rule. Its default resolution
is the mechanism's ``grid_nodes`` budget where set (H4 30 x 30 x 15, half the nodes
along theta: ``grid_axis_nodes``; Tricept 20^3, Delta and Gough-Stewart 26^3), else ``default_nodes``. ``method="midpoint"``: the plain
cell-centre count on a regular grid of ``default_nodes`` (first order; it moves
in steps as the boundary crosses cell centres), the objective of earlier
versions, kept for comparison. Where a mechanism has an axis along which nothing
but the actuator range changes (H4: z, since all carriages slide along z and
the Jacobian of eq. 33 does not depend on z), that axis is integrated exactly
from the feasible interval
(:meth:`~kinematics.base.Mechanism.invariant_axis_interval`). The error
estimate (``volume_error``, ``gdi_error``) is the change against the same
method at half the resolution (grid) or on the grid shifted by half a cell
(midpoint).
A mechanism that provides exact 1-D sections (:meth:`~kinematics.base.Mechanism.exact_sections`,
3-RPR and 2-RPR along x) is integrated by them under ``method="grid"`` instead
(:func:`_integrate_sections`): each section's intervals in closed form, ``1/kappa`` by the
corrected trapezoid rule along it, a sheared midpoint rule across (y, phi); where the mechanism
also knows its reachable volume in closed form (:meth:`~kinematics.base.Mechanism.exact_volume`,
2-RPR), V is that times the dexterous share of the sections.
``method="polar"`` is the Tricept paper's boundary search (seed 001 Sec. 4.1).

Default orientation ranges (``orientation=None``) are the mechanism's
:attr:`~kinematics.base.Mechanism.default_orientation`: H4 theta in
[-pi/4, pi/4], Tricept psi and theta in [-pi/2, pi/2], 3-RPR phi in [15, 60] deg.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from kinematics import kernels, margin_cells
from kinematics.base import Mechanism
from kinematics.polytope import plane_cut
from kinematics.rows import row_all

#: poses evaluated per vectorised chunk (bounds memory, not a per-pose loop)
CHUNK = 1 << 17
METHODS = ("grid", "midpoint", "polar", "margins", "planes")
#: the methods that count boundary cells by fractions, on the grid method's node budget and axes:
#: ``grid`` by the mechanism's :attr:`~kinematics.base.Mechanism.cell_rule`, ``margins`` and
#: ``planes`` by that rule whatever the mechanism's
FRACTION_METHODS = ("grid", "margins", "planes")
#: the second resolution of the error estimate of ``method="grid"``, a fraction of the first
ERROR_RESOLUTION = 0.5


@dataclass(frozen=True)
class Evaluation:
    """Workspace volume and dexterity of one design (see module docstring for units).

    The two counters say how the integration rule sampled the pose space; V and the GDI do not
    depend on them. ``n_inside / n_samples`` is the share of the rule's points inside the
    dexterous workspace (``1/kappa > min_inverse_condition``), i.e. the filled share of the region
    the rule samples, which is not the pose box everywhere:

    ``n_samples`` : int
        Sample points of the rule (dimensionless count). ``grid``, ``midpoint``, ``margins``:
        the grid's nodes (over the box the grid spans; with an axis integrated exactly, H4's z,
        over the other axes). Exact sections (``grid`` for the 2-RPR and 3-RPR): one point per
        node spacing along each row, times the rows (2-RPR: rows over the pose box; 3-RPR: each
        layer's rows over its reachable y extent). ``polar``: the membership tests and ``1/kappa``
        evaluations of the ray search.
    ``n_inside`` : int
        Of those, the points inside (dimensionless count). Grid methods: the nodes inside (with
        an exact axis: nodes whose interval along it is not empty). Exact sections: the rows'
        dexterous length over the node spacing, rounded. ``polar``: the rays that meet the
        workspace.
    """

    mechanism: str
    volume: float
    volume_error: float
    gdi: float
    gdi_error: float
    inverse_condition_min: float
    inverse_condition_max: float
    inverse_condition_mean: float
    suri: float
    reference_volume: float
    n_samples: int
    n_inside: int
    resolution: int
    orientation: tuple[float, float]
    min_inverse_condition: float
    method: str
    volume_unit: str
    samples: np.ndarray | None = field(default=None, repr=False, compare=False)
    inverse_conditions: np.ndarray | None = field(default=None, repr=False, compare=False)
    inside: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: (M, 2) feasible interval of the exactly integrated axis per sample (H4: z), if any
    extent: np.ndarray | None = field(default=None, repr=False, compare=False)

    def mixed(self, w_d: float) -> float:
        """Mixed index ``eta = w_d GDI + (1 - w_d) SURI`` (seed 000 eq. 36), ``0 <= w_d <= 1``."""
        w = float(w_d)
        if not 0.0 <= w <= 1.0:
            raise ValueError(f"w_d must be in [0, 1]; got {w_d!r}")
        return w * self.gdi + (1.0 - w) * self.suri

    def mixed_error(self, w_d: float) -> float:
        """Discretisation error estimate of :meth:`mixed`: ``w_d gdi_error + (1 - w_d)
        volume_error / V*`` (NaN when the evaluation was made without an estimate)."""
        w = float(w_d)
        if not 0.0 <= w <= 1.0:
            raise ValueError(f"w_d must be in [0, 1]; got {w_d!r}")
        suri_error = self.volume_error / self.reference_volume if self.reference_volume > 0 else 0.0
        return w * self.gdi_error + (1.0 - w) * suri_error

    def scalars(self) -> dict[str, float | int | str]:
        """Flat scalar fields (for tables): everything but the sample arrays."""
        out: dict[str, float | int | str] = {}
        for name in self.__dataclass_fields__:
            if name in ("samples", "inverse_conditions", "inside", "extent"):
                continue
            value = getattr(self, name)
            if name == "orientation":
                out["orientation_lo"], out["orientation_hi"] = (float(v) for v in value)
            else:
                out[name] = value
        return out


# ------------------------------------------------------------- membership
def membership(
    mechanism: Mechanism,
    poses: np.ndarray,
    orientation: tuple[float, float],
    min_inverse_condition: float,
    length: float | None = None,
    reachable: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Which poses (N, dof) are in the workspace, and their ``1/kappa``.

    ``reachable`` (N,) bool, when given, says which poses are already known to
    have real IK within the actuator range (the exact-axis path knows it).

    Returns
    -------
    inside : ndarray of bool, shape (N,)
    inverse_condition : ndarray, shape (N,)
        ``1/kappa`` of the homogenised Jacobian where the pose is reachable
        within the actuator and joint limits, NaN elsewhere.
    """
    if reachable is None:
        fused = mechanism.reachable_inverse_condition(poses, length)
        if fused is not None:
            return _oriented_and_dexterous(mechanism, poses, fused, orientation, min_inverse_condition)
    n = poses.shape[0]
    ic = np.full(n, np.nan)
    if reachable is None:
        q = mechanism.inverse(poses)
        q_lo, q_hi = mechanism.actuator_range
        with np.errstate(invalid="ignore"):
            ok = row_all((q >= q_lo) & (q <= q_hi))
    else:
        ok = np.asarray(reachable, dtype=bool).copy()
    ok &= _within_orientation(mechanism, poses, orientation)
    idx = np.nonzero(ok)[0]
    if idx.size:
        idx = idx[mechanism.within_joint_limits(poses[idx])]
    if idx.size:
        ic[idx] = mechanism.inverse_condition(poses[idx], length)
    return _dexterous(ic, min_inverse_condition), ic


def _within_orientation(mechanism: Mechanism, poses: np.ndarray, orientation: tuple[float, float]) -> np.ndarray:
    """(N,) bool: every angular pose variable within ``orientation`` (rad)."""
    angular = np.asarray(mechanism.angular)
    if not angular.any():
        return np.ones(poses.shape[0], dtype=bool)
    ang = poses[:, angular]
    return row_all((ang >= orientation[0]) & (ang <= orientation[1]))


def _oriented_and_dexterous(
    mechanism: Mechanism,
    poses: np.ndarray,
    ic: np.ndarray,
    orientation: tuple[float, float],
    min_inverse_condition: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The end of a compiled membership test: ``ic`` (N,), 1/kappa of the reachable poses and
    NaN elsewhere, set to NaN outside the orientation box (in place); returns ``(inside, ic)``."""
    ic[~_within_orientation(mechanism, poses, orientation)] = np.nan
    return _dexterous(ic, min_inverse_condition), ic


def _dexterous(ic: np.ndarray, min_inverse_condition: float) -> np.ndarray:
    """(N,) bool: ``1/kappa`` above the dexterity limit (finite when the limit is 0)."""
    with np.errstate(invalid="ignore"):
        return ic > min_inverse_condition if min_inverse_condition > 0 else np.isfinite(ic)


# ------------------------------------------------------------------- grid
def _grid_axes(
    mechanism: Mechanism,
    resolution: int,
    orientation: tuple[float, float],
    fixed: dict[str, float],
    offset: float = 0.5,
    exact_axis: int | None = None,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
    anisotropic: bool = False,
) -> tuple[list[np.ndarray], float]:
    """Grid nodes per pose variable, and the cell measure.

    ``offset = 0.5`` gives the midpoint rule; another offset gives an
    interleaved grid of the same resolution (used for the error estimate).
    ``exact_axis`` is integrated analytically: it gets one placeholder node
    and does not enter the cell measure. ``bounds``: the mechanism's
    ``pose_bounds(orientation)`` when the caller has them already. ``anisotropic``: the nodes
    per sampled axis of :func:`_axis_nodes` (``method="grid"``), else ``resolution`` on each.
    """
    lo, hi = mechanism.pose_bounds(orientation) if bounds is None else bounds
    axes: list[np.ndarray] = []
    cell = 1.0
    for j in range(mechanism.dof):
        if j in _sampled_indices(mechanism, orientation, fixed, exact_axis):
            width = max(float(hi[j] - lo[j]), 0.0)
            count = _axis_nodes(mechanism, j, resolution) if anisotropic else resolution
            step = width / count
            axes.append(lo[j] + step * (np.arange(count) + offset))
            cell *= step
        elif mechanism.pose_names[j] in fixed:
            axes.append(np.array([float(fixed[mechanism.pose_names[j]])]))
        elif mechanism.angular[j] and orientation[0] == orientation[1]:
            axes.append(np.array([float(orientation[0])]))
        else:  # the exact axis
            axes.append(np.array([0.5 * (lo[j] + hi[j])]))
    return axes, cell


def _axis_nodes(mechanism: Mechanism, j: int, resolution: int) -> int:
    """Nodes of ``method="grid"`` along pose variable ``j`` at ``resolution``: ``resolution``
    times the mechanism's :attr:`~kinematics.base.Mechanism.grid_axis_nodes` factor, rounded up."""
    factor = mechanism.grid_axis_nodes.get(mechanism.pose_names[j], 1.0)
    return max(int(math.ceil(factor * resolution - 1e-9)), 1)


def grid_nodes(
    mechanism: Mechanism,
    resolution: int,
    orientation: tuple[float, float] | None = None,
    fixed: dict[str, float] | None = None,
    method: str = "grid",
) -> int:
    """Nodes of one evaluation's grid at ``resolution`` (the product over the sampled axes;
    ``method="grid"`` with the mechanism's per-axis factors, its coarse pass not counted)."""
    if orientation is None:
        orientation = mechanism.default_orientation
    fixed = fixed or {}
    sampled = _sampled_indices(mechanism, orientation, fixed, _exact_axis(mechanism, fixed))
    if method not in FRACTION_METHODS:
        return int(resolution) ** len(sampled)
    return math.prod(_axis_nodes(mechanism, j, resolution) for j in sampled)


def _sampled_indices(
    mechanism: Mechanism, orientation: tuple[float, float], fixed: dict[str, float], exact_axis: int | None
) -> list[int]:
    """Column indices of the pose variables the grid samples (not fixed, exact or constant)."""
    return [
        j
        for j, name in enumerate(mechanism.pose_names)
        if name not in fixed and j != exact_axis and not (mechanism.angular[j] and orientation[0] == orientation[1])
    ]


def _grid_poses(axes: list[np.ndarray], start: int, stop: int) -> np.ndarray:
    """Rows ``start:stop`` of the C-ordered Cartesian product of ``axes``."""
    shape = tuple(len(a) for a in axes)
    inner = math.prod(shape[1:])
    if start % inner == 0 and (stop % inner == 0 or stop == math.prod(shape)):
        # whole rows of the leading axis (the chunks of _chunk_bounds): broadcast each
        # axis into its column, ~20x faster than unravelling every row index
        block = [axes[0][start // inner : -(-stop // inner)], *axes[1:]]
        out = np.empty(tuple(len(a) for a in block) + (len(axes),))
        for k, axis in enumerate(block):
            out[..., k] = axis.reshape([-1 if j == k else 1 for j in range(len(axes))])
        return out.reshape(-1, len(axes))
    index = np.unravel_index(np.arange(start, stop), shape)
    return np.column_stack([a[i] for a, i in zip(axes, index)])


def _chunk_bounds(axes: list[np.ndarray]) -> list[tuple[int, int]]:
    """Row ranges of at most ~:data:`CHUNK` grid nodes, whole rows of the leading axis when
    a row fits (so that :func:`_grid_poses` can broadcast)."""
    total = math.prod(len(a) for a in axes)
    inner = math.prod(len(a) for a in axes[1:])
    step = max(CHUNK // inner, 1) * inner if inner <= CHUNK else CHUNK
    return [(start, min(start + step, total)) for start in range(0, total, step)]


#: the analytically integrable axis of each mechanism class (a property of its kinematics, not
#: of a design: probed once per class)
_EXACT_AXES: dict[type, int | None] = {}


def _exact_axis(mechanism: Mechanism, fixed: dict[str, float]) -> int | None:
    """Index of the analytically integrable axis (see ``invariant_axis_interval``), if usable."""
    cls = type(mechanism)
    if cls not in _EXACT_AXES:
        probe = mechanism.invariant_axis_interval(np.zeros((1, mechanism.dof)))
        _EXACT_AXES[cls] = None if probe is None else probe[0]
    axis = _EXACT_AXES[cls]
    if axis is None or mechanism.pose_names[axis] in fixed:
        return None
    return axis


def sampled_axes(
    mechanism: Mechanism, orientation: tuple[float, float], fixed: dict[str, float] | None = None
) -> list[str]:
    """Names of the pose variables that the grid samples (not fixed, not exact, not constant)."""
    fixed = fixed or {}
    exact = _exact_axis(mechanism, fixed)
    return [mechanism.pose_names[j] for j in _sampled_indices(mechanism, orientation, fixed, exact)]


def default_resolution(
    mechanism: Mechanism,
    orientation: tuple[float, float] | None = None,
    fixed: dict[str, float] | None = None,
    method: str = "grid",
) -> int:
    """Largest resolution whose grid has at most ``mechanism.grid_nodes`` nodes (the grid
    method, the default) or ``mechanism.default_nodes`` (``method="midpoint"``, or a
    mechanism without a grid budget).

    The grid method's budgets are where its V, GDI and eta come within 0.1 % of their
    converged values on the ladder's designs of benchmarks/accuracy.py (paper designs,
    documented optima, two random ones; its scan of further random designs finds misses:
    docs/accuracy.md);
    the midpoint budgets kept a GA run of 4,500 evaluations near a minute on 2 workers.
    """
    if orientation is None:
        orientation = mechanism.default_orientation
    names = sampled_axes(mechanism, orientation, fixed)
    n_axes = len(names)
    budget = mechanism.grid_nodes if method in FRACTION_METHODS else None
    nodes = int(mechanism.default_nodes if budget is None else budget)
    if not n_axes:  # one node whatever the resolution: the budget itself, as a 1-axis grid's
        return nodes
    # from above (nodes are rounded up per axis): the budget over the product of the per-axis
    # factors, then down to the largest fit
    factors = [mechanism.grid_axis_nodes.get(name, 1.0) for name in names]
    shrink = math.prod(factors) if method in FRACTION_METHODS else 1.0
    res = int(math.ceil((nodes / shrink) ** (1.0 / n_axes))) + 1
    while res > 1 and grid_nodes(mechanism, res, orientation, fixed, method) > nodes:
        res -= 1
    return res


class _PointValues:
    """Workspace membership, integrand weight and ``1/kappa`` of arbitrary poses (N, dof).

    The weight is 1, or along an exact axis (H4: z) the length of the pose's
    feasible interval of that axis clipped to the pose box (the pose's value
    in that column is ignored). ``oriented``: the caller guarantees that every
    angular variable lies in the orientation box (a grid that spans it); assumed
    for every pose when the box's angular bounds lie in the orientation range
    (all poses evaluated are in the box: grid nodes, points between them and
    the box's faces).
    """

    def __init__(
        self,
        mechanism: Mechanism,
        exact: int | None,
        box: tuple[np.ndarray, np.ndarray],
        orientation: tuple[float, float],
        min_ic: float,
        length: float | None,
    ):
        self.mechanism, self.exact, self.box = mechanism, exact, box
        self.orientation, self.min_ic, self.length = orientation, min_ic, length
        # every pose of the box lies in the orientation range (the box spans at most that range):
        # the poses this class sees (grid nodes, points between nodes and faces) need
        # no orientation test
        angular = np.asarray(mechanism.angular, dtype=bool)
        self.box_oriented = bool(
            np.all(np.asarray(box[0])[angular] >= orientation[0])
            and np.all(np.asarray(box[1])[angular] <= orientation[1])
        )

    def margins(self, poses: np.ndarray) -> np.ndarray | None:
        """The mechanism's reachability margins of ``poses`` (N, K), or None when it has none
        (:meth:`~kinematics.base.Mechanism.constraint_margins`; for an exact axis those of
        the columns, :meth:`~kinematics.base.Mechanism.exact_axis_margins`)."""
        if self.exact is None:
            return self.mechanism.constraint_margins(poses)
        return self.mechanism.exact_axis_margins(poses, self.box[0][self.exact], self.box[1][self.exact])

    def __call__(
        self, poses: np.ndarray, oriented: bool = False, keep_extent: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """``(inside, weight, ic, extent)`` of ``poses`` (modified in place along the exact
        axis: the middle of the feasible interval, when the numpy path needs a pose there)."""
        mechanism, exact, orientation, min_ic = self.mechanism, self.exact, self.orientation, self.min_ic
        oriented = oriented or self.box_oriented
        box_lo, box_hi = self.box
        fused = None
        extent = None
        if exact is None:
            weight = np.ones(poses.shape[0])
            if oriented:
                fused_ic = mechanism.reachable_inverse_condition(poses, self.length)
                if fused_ic is not None:
                    return _dexterous(fused_ic, min_ic), weight, fused_ic, None
        else:
            fused = mechanism.exact_axis_columns(poses, box_lo[exact], box_hi[exact], self.length)
            if fused is None:
                _, lower, upper = mechanism.invariant_axis_interval(poses)
                lower = np.maximum(lower, box_lo[exact])
                upper = np.minimum(upper, box_hi[exact])
            else:
                lower, upper, ic = fused
            weight = np.clip(upper - lower, 0.0, None)
            if fused is None or keep_extent:  # the fused path needs no pose along the axis
                # any z of the interval represents the column (1/kappa does not depend on it)
                feasible = weight > 0
                poses[feasible, exact] = 0.5 * (lower[feasible] + upper[feasible])
                extent = np.column_stack([lower, upper])
        if fused is not None:
            # ic is NaN wherever the axis interval is empty, so inside implies weight > 0
            inside, ic = (
                (_dexterous(ic, min_ic), ic)
                if oriented
                else _oriented_and_dexterous(mechanism, poses, ic, orientation, min_ic)
            )
        else:
            inside, ic = membership(
                mechanism, poses, orientation, min_ic, self.length, reachable=None if exact is None else weight > 0
            )
            inside &= weight > 0
        return inside, weight, ic, extent


#: bisection steps per boundary crossing of a grid edge where the margins cannot place it
#: (``method="grid"``, a mechanism without margins): the crossing is located to
#: ``h / 2**(BISECTIONS + 1)`` (h the grid step), well below the discretisation error
BISECTIONS = 4
#: largest slope ``h / distance`` of a cut cell's plane (a crossing on a node: the plane through
#: the node). Where a crossing is nearer, all the plane's slopes are scaled down together
#: (:func:`_plane_slopes`), so that the plane keeps its direction; such a plane crosses every
#: edge along its steepest axis and is cut in closed form (:func:`_prism_cut`), free of the
#: inclusion-exclusion's cancellation
_MAX_SLOPE = 1e4
#: a plane's slopes below this, after that scaling, are 0 (the plane, within 1e-4 of the node,
#: tilts by ``slope * 1e-4``: 1e-7)
_MIN_PLANE_SLOPE = 1e-3
#: largest ``h / distance`` of a crossing (a crossing on a node): its weights
#: (:func:`_crossing_weights`) take the fourth power, which stays finite
_NODE_SLOPE = 1e60


def _crossings(
    values: _PointValues,
    probe: np.ndarray,
    column: np.ndarray,
    p_in: np.ndarray,
    p_out: np.ndarray,
    start: np.ndarray,
    steps: int | None,
    ic_out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The boundary crossing between an inside (``p_in``) and an outside (``p_out``) value of
    column ``column`` (per row) of the poses ``probe`` (N, dof), and the integrands there.

    The crossing is where the first of the workspace's margins changes sign: the
    mechanism's reachability margins (:meth:`~kinematics.base.Mechanism.constraint_margins`:
    actuator range, joint limits, real IK) and the dexterity margin ``1/kappa^2 - limit^2``
    (the square: near a singular reach boundary, where a rod or an arm is stretched,
    ``1/kappa`` falls like the root of the distance and its square linearly). ``start``
    holds the integrands at the inside end, whose ``1/kappa`` is their ratio, and ``ic_out``
    the outside end's ``1/kappa`` (NaN where unreachable or unknown).

    1. Each margin linear between the ends: the first sign change ``t1`` (a fraction of the
       way from ``p_in``), over the margins known at both ends.
    2. One look at ``t1``: the membership test (its ``1/kappa`` and integrands) and the
       margins there. Each margin as the parabola through its three values (a line through
       the two known ones where the outside end's is unknown): its first root in the bracket
       where the three values change sign, the first of the margins' roots the crossing.
       Third order in the edge length for smooth margins, and continuous in the design.
    3. The integrands at the crossing are those at ``t1`` (``1/kappa`` at the limit where the
       dexterity margin is the first); where ``t1`` is unreachable, those of a second look
       next to the crossing found in step 2 (:func:`_second_look`), and those of the inside
       end where no point short of it is reachable.
    4. Where the dexterity margin comes first but is unknown at the outside end, one more look
       and the parabola through its three values (:func:`_dexterity_parabola`).

    Rows the margins cannot place (the mechanism has none, one is undefined at an end, or
    none changes sign) are bisected ``steps`` times by the membership test instead
    (:func:`_bisect_membership`, to ``h / 2**(steps+1)``); ``steps=None`` leaves them NaN.

    Returns
    -------
    crossing : ndarray (N,)
    value : ndarray (k, N)
        The integrands (:func:`_integrands`) at the crossing.
    """
    n = probe.shape[0]
    limit = values.min_ic
    value = start.copy()
    t = np.full(n, np.nan)
    if n:
        with np.errstate(invalid="ignore", divide="ignore"):
            ic_in = start[1] / start[0] if start.shape[0] >= 2 else np.full(n, np.nan)
        ic_out = np.full(n, np.nan) if ic_out is None else ic_out
        rows = np.arange(n)
        ends = np.vstack([probe, probe])
        ends[rows, column] = p_in
        ends[rows + n, column] = p_out
        reach = values.margins(ends)
        reach = np.empty((2 * n, 0)) if reach is None else reach
        dex_in, dex_out = _dexterity_margin(ic_in, limit), _dexterity_margin(ic_out, limit)
        linear = _linear_crossing_compiled if kernels.compiled() else _linear_crossing
        first = linear(np.ascontiguousarray(reach), dex_in, dex_out)
        look = np.nonzero(np.isfinite(first))[0]
        t1 = first[look]
        at = probe[look]  # a copy (fancy indexing)
        at[np.arange(look.size), column[look]] = p_in[look] + t1 * (p_out[look] - p_in[look])
        if start.shape[0]:
            inside_1, weight_1, ic_1, _ = values(at)
        else:  # no integrands asked for, and no dexterity margin at the inside end to refine
            ic_1 = np.full(look.size, np.nan)
        reach_1 = values.margins(at) if reach.shape[1] else np.empty((look.size, 0))
        dex_1 = _dexterity_margin(ic_1, limit)
        t2, which = _first_root(
            _margin_roots(reach, np.ascontiguousarray(reach_1), dex_in, dex_1, dex_out, look, t1), t1
        )
        if start.shape[0]:

            def edge(rows: np.ndarray) -> tuple[np.ndarray, ...]:
                """The looks' poses (a copy), columns and ends of these rows of ``look``."""
                return at[rows], column[look[rows]], p_in[look[rows]], p_out[look[rows]]

            # the look whose margins the crossing's model used: t1, or the second look's point
            t_look = t1.copy()
            again = np.nonzero(~np.isfinite(ic_1) & (which >= 0))[0]
            if again.size:
                t2[again], which[again], weight_1[again], ic_1[again], t_look[again] = _second_look(
                    values,
                    *edge(again),
                    t2[again],
                    which[again],
                    start[0, look[again]],
                    dex_in[look[again]],
                    reach.shape[1],
                )
            dex_look = _dexterity_margin(ic_1, limit)
            curved = np.nonzero(
                (which == reach.shape[1]) & np.isnan(dex_out[look]) & (t_look > 0.0) & np.isfinite(dex_look)
            )[0]
            if curved.size:
                t2[curved], weight_1[curved] = _dexterity_parabola(
                    values,
                    *edge(curved),
                    t_look[curved],
                    t2[curved],
                    dex_in[look[curved]],
                    dex_look[curved],
                    weight_1[curved],
                )
            # the integrands at the reachable points only (the others keep the inside end's)
            reachable_1 = np.nonzero(np.isfinite(ic_1))[0]
            ic_there = np.where(which[reachable_1] == reach.shape[1], limit, ic_1[reachable_1])
            every = np.ones(reachable_1.size, dtype=bool)
            value[:, look[reachable_1]] = _integrands(every, weight_1[reachable_1], ic_there, start.shape[0])
        t[look] = t2
    crossing = p_in + t * (p_out - p_in)
    left = np.nonzero(np.isnan(t))[0]
    if left.size and steps is not None:
        crossing[left], value[:, left] = _bisect_membership(
            values, probe[left], column[left], p_in[left], p_out[left], start[:, left], steps
        )
    return crossing, value


def _dexterity_parabola(
    values: _PointValues,
    at: np.ndarray,
    column: np.ndarray,
    p_in: np.ndarray,
    p_out: np.ndarray,
    t1: np.ndarray,
    t2: np.ndarray,
    dex_in: np.ndarray,
    dex_1: np.ndarray,
    weight_1: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Step 2 of :func:`_crossings` for the M rows whose dexterity margin comes first but is
    unknown at the outside end (unreachable there): it was placed on the line through its
    values at the inside end (``dex_in``) and at ``t1`` (``dex_1``), at ``t2`` (fractions of the
    way from ``p_in`` to ``p_out`` (M,) along column ``column`` (M,) of the poses ``at``
    (M, dof)). A look at ``t2``, and the parabola through the three values
    (:func:`_margin_roots` on the edge from the inside end to the farther look, the nearer one the
    middle point: ``t2`` lies beyond ``t1`` where the margin is still positive there), its root in
    the bracket where they change sign.

    Why: where the outside end is reachable its margin is known and the crossing lies on the
    parabola through three values; as that end turned unreachable the line took over, and the
    crossing jumped by the line's error (a cell's three crossings by 1 % of the cell at once at
    H4's optimum, 2e-6 of eta). Near the end's reach boundary the look at ``t1`` takes its
    place, so the two parabolas meet.

    Returns the crossing and the weight there (at the look at ``t2``, the nearer one; at
    ``t1`` where that look is unreachable), (M,) each.
    """
    rows = np.arange(t2.size)
    at[rows, column] = p_in + t2 * (p_out - p_in)
    _, weight_2, ic_2, _ = values(at)
    dex_2 = _dexterity_margin(ic_2, values.min_ic)
    # the parabola on [0, far], the nearer look its middle point: t2 lies beyond t1 where the
    # margin is still positive at t1 (the line's root extrapolated)
    beyond = t2 > t1
    far = np.where(beyond, t2, t1)
    middle, dex_middle = np.where(beyond, t1, t2), np.where(beyond, dex_1, dex_2)
    dex_far = np.where(beyond, dex_2, dex_1)
    no_reach = np.empty((2 * t2.size, 0))
    share, found = _first_root(
        _margin_roots(no_reach, np.empty((t2.size, 0)), dex_in, dex_middle, dex_far, rows, middle / far), middle / far
    )
    crossing = np.where(found == 0, share * far, t2)
    return crossing, np.where(np.isfinite(ic_2), weight_2, weight_1)


#: the second look of :func:`_second_look` tries the crossing and the points ``4**-k`` of the
#: way short of it, k = 1 .. LOOK_DEPTH (down to 1e-6), the nearest reachable one its look
LOOK_DEPTH = 10


def _second_look(
    values: _PointValues,
    at: np.ndarray,
    column: np.ndarray,
    p_in: np.ndarray,
    p_out: np.ndarray,
    t2: np.ndarray,
    which: np.ndarray,
    weight_in: np.ndarray,
    dex_in: np.ndarray,
    dexterity: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Step 3 of :func:`_crossings` where the look at ``t1`` is unreachable (M rows): the
    integrands at the crossing ``t2`` (M,) of step 2, a fraction of the way from ``p_in``
    (M,) to ``p_out`` (M,) along column ``column`` (M,) of the poses ``at`` (M, dof).

    Why: the inside end's integrands lie a cell away (1/kappa 0.15 at H4's optimum where it is
    0.01 at the crossing), and ``t2`` lies on the crossing's model, just outside as often as
    inside: a look there alone left the inside end's integrands on one side and the crossing's
    on the other, a step as the look turned reachable (H4's h4_mixed best known sat on such a
    spike, 2e-5 of eta). Where ``t2`` is unreachable the look goes to the nearest reachable of
    the points ``4**-k`` of the way short of it (:data:`LOOK_DEPTH`; one more call for all). The
    value there differs from the one at ``t2`` by that fraction of the slope, and the look
    moves by a factor 4 as the reach boundary passes one of them. The reach margins alone
    placed ``t2`` when the dexterity margin ``dex_in`` (M,) was unknown at the outside end;
    where the line of ``1/kappa^2 - limit^2`` (linear in the distance to a singular reach
    boundary, where ``1/kappa`` falls to 0) through the inside end and the look reaches 0 before
    ``t2``, the dexterity limit comes first there (beyond the look too, so that the crossing
    does not jump as the look's margin changes sign), with the weight (``weight_in`` at the
    inside end (M,)) linear between them, up to the look's.

    Returns ``t2``, ``which`` (``dexterity``, the dexterity margin's column, where it comes
    first), the weight and ``1/kappa`` (NaN: no reachable look, the inside end's integrands
    remain) at the crossing, and the look's point (a fraction as ``t2``), (M,) each.
    """
    rows = np.arange(t2.size)
    t_look = t2.copy()
    at[rows, column] = p_in + t_look * (p_out - p_in)
    _, weight, ic, _ = values(at)
    lost = np.nonzero(~np.isfinite(ic))[0]
    if lost.size:  # the points 4^-k of the way short of t2 (k = LOOK_DEPTH .. 1), in one call
        share = 1.0 - 0.25 ** np.arange(LOOK_DEPTH, 0, -1)
        t_points = t2[lost, None] * share[None, :]  # (lost, points), nearest to t2 first
        probes = np.repeat(at[lost], share.size, axis=0)
        probes[np.arange(probes.shape[0]), np.repeat(column[lost], share.size)] = (
            p_in[lost, None] + t_points * (p_out - p_in)[lost, None]
        ).ravel()
        _, weights, ics, _ = values(probes)
        ics, weights = ics.reshape(lost.size, share.size), weights.reshape(lost.size, share.size)
        nearest = np.argmax(np.isfinite(ics), axis=1)  # none reachable: NaN stays
        inner = np.arange(lost.size)
        t_look[lost], weight[lost], ic[lost] = t_points[inner, nearest], weights[inner, nearest], ics[inner, nearest]
    dex_look = _dexterity_margin(ic, values.min_ic)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = t_look * dex_in / (dex_in - dex_look)
    # the line's root beyond the look too (a margin still positive there), as _margin_roots' line
    # does: at dex_look = 0 it is the look itself from either side
    first = np.nonzero((dex_look < dex_in) & (dex_in >= 0.0) & (s >= 0.0) & (s <= t2))[0]
    t2, which = t2.copy(), which.copy()
    t2[first], which[first] = s[first], dexterity
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(t_look[first] > 0.0, np.minimum(s[first] / t_look[first], 1.0), 0.0)
    weight[first] = weight_in[first] + share * (weight[first] - weight_in[first])
    return t2, which, weight, ic, t_look


def _dexterity_margin(ic: np.ndarray, limit: float) -> np.ndarray:
    """``1/kappa^2 - limit^2`` (N,): >= 0 where dexterous (NaN where unreachable; all NaN without
    a dexterity limit, which then bounds nothing)."""
    if not limit > 0:
        return np.full(np.shape(ic), np.nan)
    return np.asarray(ic) ** 2 - limit**2


def _stacked(reach: np.ndarray, dex: np.ndarray) -> np.ndarray:
    """Margins (N, K) and the dexterity margin (N,) as one array (N, K + 1)."""
    return np.column_stack([reach, dex])


def _linear_crossing(reach: np.ndarray, dex_in: np.ndarray, dex_out: np.ndarray) -> np.ndarray:
    """Step 1 of :func:`_crossings`: per row the first sign change of the margins linear between
    the inside and the outside end, as a fraction of the way in [0, 1]. ``reach`` (2N, K):
    the reachability margins at the N inside ends, then at the N outside ends; ``dex_in``,
    ``dex_out`` (N,): the dexterity margin there (NaN where unknown). NaN where the margins
    cannot place it (a reachability margin unknown at an end, one negative at the inside end,
    or none known at both ends and negative at the outside)."""
    n = dex_in.size
    g_in, g_out = _stacked(reach[:n], dex_in), _stacked(reach[n:], dex_out)
    known = ~np.isnan(g_in) & ~np.isnan(g_out)
    with np.errstate(invalid="ignore", divide="ignore"):
        usable = (
            known[:, :-1].all(axis=1)
            & (np.nan_to_num(g_in, nan=0.0) >= 0).all(axis=1)
            & (known & (g_out < 0)).any(axis=1)
        )
        first = np.where(known & (g_out < 0), g_in / (g_in - g_out), np.inf).min(axis=1)
    return np.where(usable, np.clip(first, 0.0, 1.0), np.nan)


def _margin_roots(
    reach: np.ndarray,
    reach_mid: np.ndarray,
    dex_in: np.ndarray,
    dex_mid: np.ndarray,
    dex_out: np.ndarray,
    rows: np.ndarray,
    tm: np.ndarray,
) -> np.ndarray:
    """Step 2 of :func:`_crossings` on the ``rows`` (M,) of :func:`_linear_crossing`'s arrays, with
    the margins ``reach_mid`` (M, K), ``dex_mid`` (M,) at ``tm`` (M,), the fraction of step 1:
    each margin as the parabola through its three values, its first root in the bracket where
    the three values change sign (``[0, tm]`` where it is negative at ``tm``, else ``[tm, 1]``
    where it is negative at the outside end; none where it is negative at none of them); the
    line through the first two where the outside end's is unknown. Returns each margin's root
    (M, K + 1; inf: none; column K the dexterity margin); the first of them is the crossing
    (:func:`_first_root`). Compiled (:func:`_margin_roots_compiled`) unless
    ``PM_DESIGN_KERNELS=numpy``.

    Why brackets: a margin positive at all three points has no root there to the accuracy of
    the samples, and a parabola through them can still dip below zero: where a margin is not
    smooth (H4's bounds of the z interval take the root of the rod's reach, infinitely steep at
    its boundary) and ``tm`` lies next to an end, its curvature is huge and the dip a spurious
    root anywhere on the edge, which came and went as the design moved (a step in V of 1.6e-4
    at H4's optimum). Within a bracket the root moves continuously; where the outside value is
    negative it goes to ``tm`` as the middle value goes to zero, from either side. A margin that
    only touches zero at ``tm`` (an outside pocket opening in the middle of the edge) still moves
    the first crossing by a jump, as the first boundary along the edge itself does."""
    if kernels.compiled():
        return _margin_roots_compiled(reach, reach_mid, dex_in, dex_mid, dex_out, rows, tm)
    n = dex_in.size
    g0 = _stacked(reach[:n][rows], dex_in[rows])
    g1 = _stacked(reach[n:][rows], dex_out[rows])
    gm = _stacked(reach_mid, dex_mid)
    t = tm[:, None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        c2 = ((gm - g0) - t * (g1 - g0)) / (t * (t - 1.0))
        c1 = g1 - g0 - c2
        # roots of g0 + c1 s + c2 s^2 as q / c2 and g0 / q, q = -(c1 + sign(c1) sqrt(disc)) / 2: no
        # cancellation in q, and a root at s = 0 (g0 = 0: a node on a margin's surface) is g0 / q = 0,
        # where the form 2 g0 / (-c1 -+ sqrt(disc)) gave 0 / 0 for the other root
        disc = c1 * c1 - 4.0 * c2 * g0
        q = -0.5 * (c1 + np.copysign(np.sqrt(np.where(disc >= 0, disc, np.nan)), c1))
        both = np.stack([q / c2, g0 / q])
        early = gm < 0.0  # the sign changes before tm, else (g1 < 0) after it
        lo = np.where(early, 0.0, t)
        hi = np.where(early, t, 1.0)
        quadratic = np.where((both >= lo) & (both <= hi), both, np.inf).min(axis=0)
        # rounding at a bracket's end: the line between the bracket's two values
        ga, gb = np.where(early, g0, gm), np.where(early, gm, g1)
        quadratic = np.where(np.isfinite(quadratic), quadratic, lo + (hi - lo) * ga / (ga - gb))
        quadratic = np.where(early | (g1 < 0.0), quadratic, np.inf)
        line = t * g0 / (g0 - gm)
        line = np.where((gm < g0) & (line >= 0.0) & (line <= 1.0), line, np.inf)
        roots = np.where(np.isnan(g1) | (t <= 0.0) | (t >= 1.0), line, quadratic)
    return np.where(np.isnan(gm) | np.isnan(g0), np.inf, roots)


@kernels.vector_jit
def _linear_crossing_compiled(reach, dex_in, dex_out):
    """:func:`_linear_crossing`, one row at a time (the same operations)."""
    n = dex_in.shape[0]
    k = reach.shape[1]
    out = np.empty(n)
    for r in range(n):
        first = np.inf
        usable = True
        any_negative = False
        for c in range(k + 1):
            a = reach[r, c] if c < k else dex_in[r]
            b = reach[n + r, c] if c < k else dex_out[r]
            known = not (np.isnan(a) or np.isnan(b))
            if c < k and not known:
                usable = False
                break
            if not np.isnan(a) and a < 0.0:
                usable = False
                break
            if known and b < 0.0:
                any_negative = True
                first = min(first, a / (a - b))
        out[r] = min(max(first, 0.0), 1.0) if usable and any_negative else np.nan
    return out


def _first_root(roots: np.ndarray, tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The crossing of each row of :func:`_margin_roots` ``roots`` (M, K + 1): the first root (the
    first margin on a tie; ``tm`` (M,) where no margin has one) and its column (K: the dexterity
    margin; -1: none)."""
    which = np.argmin(roots, axis=1)
    first = roots[np.arange(roots.shape[0]), which]
    found = np.isfinite(first)
    return np.where(found, first, tm), np.where(found, which, -1)


@kernels.inline_jit
def _margin_root(a, mid, b, t):
    """One margin's root of :func:`_margin_roots_compiled` (its values ``a``, ``mid``, ``b`` at
    the inside end, at ``t`` and at the outside end; inf: none), as :func:`_margin_roots`."""
    if np.isnan(mid) or np.isnan(a):
        return np.inf
    if np.isnan(b) or t <= 0.0 or t >= 1.0:
        s = t * a / (a - mid)
        return s if (mid < a and s >= 0.0 and s <= 1.0) else np.inf
    if mid < 0.0:  # the bracket where the three values change sign
        lo, hi, ga, gb = 0.0, t, a, mid
    elif b < 0.0:
        lo, hi, ga, gb = t, 1.0, mid, b
    else:
        return np.inf  # not negative at any of the three points: no root
    c2 = ((mid - a) - t * (b - a)) / (t * (t - 1.0))
    c1 = b - a - c2
    disc = c1 * c1 - 4.0 * c2 * a
    root = np.inf
    if disc >= 0.0:
        qq = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
        for s in (qq / c2, a / qq):
            if s >= lo and s <= hi and s < root:
                root = s
    if root == np.inf:  # rounding at a bracket's end: the line between its two values
        root = lo + (hi - lo) * ga / (ga - gb)
    return root


@kernels.vector_jit
def _margin_roots_compiled(reach, reach_mid, dex_in, dex_mid, dex_out, rows, tm):
    """:func:`_margin_roots`, one row at a time (the same operations)."""
    n = dex_in.shape[0]
    k = reach.shape[1]
    m = rows.shape[0]
    roots = np.empty((m, k + 1))
    for q in range(m):
        r = rows[q]
        for c in range(k + 1):
            a = reach[r, c] if c < k else dex_in[r]
            mid = reach_mid[q, c] if c < k else dex_mid[q]
            b = reach[n + r, c] if c < k else dex_out[r]
            roots[q, c] = _margin_root(a, mid, b, tm[q])
    return roots


def _dexterity_fraction(ic_in: np.ndarray, ic_out: np.ndarray, limit: float) -> np.ndarray:
    """Where ``1/kappa`` meets ``limit`` between a pose where it is ``ic_in`` and one where it is
    ``ic_out``, as a fraction of the way: ``1/kappa^2`` taken linear. Why the square: near a
    singular reach boundary (a rod or an arm stretched: H4, Delta) ``1/kappa`` falls like the
    root of the distance to it and its square linearly; where ``1/kappa`` is smooth both are
    second order."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return _dexterity_margin(ic_in, limit) / (ic_in**2 - ic_out**2)


def _bisect_membership(
    values: _PointValues,
    probe: np.ndarray,
    column: np.ndarray,
    p_in: np.ndarray,
    p_out: np.ndarray,
    start: np.ndarray,
    steps: int,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_crossings` by bisection of the membership test (see there)."""
    rows = np.arange(probe.shape[0])
    value = start
    ic_in = np.full(rows.size, np.nan)
    ic_out = np.full(rows.size, np.nan)
    for _ in range(steps):
        mid = 0.5 * (p_in + p_out)
        probe[rows, column] = mid
        inside_mid, weight, ic, _ = values(probe)
        p_in, p_out = np.where(inside_mid, mid, p_in), np.where(inside_mid, p_out, mid)
        ic_in, ic_out = np.where(inside_mid, ic, ic_in), np.where(inside_mid, ic_out, ic)
        if value.shape[0]:
            value = np.where(inside_mid, np.array(_integrands(inside_mid, weight, ic, value.shape[0])), value)
    limit = values.min_ic
    with np.errstate(invalid="ignore", divide="ignore"):
        t = _dexterity_fraction(ic_in, ic_out, limit)
    dexterity = (limit > 0) & np.isfinite(t) & (ic_out <= limit) & (ic_in > limit)
    t = np.where(dexterity, np.clip(t, 0.0, 1.0), 0.5)
    return p_in + t * (p_out - p_in), value


def _edge_crossings(
    values: _PointValues,
    axes: list[np.ndarray],
    inside: np.ndarray,
    f: tuple[np.ndarray, ...],
    sampled: list[int],
    box: tuple[np.ndarray, np.ndarray],
    steps: int = BISECTIONS,
    ic: np.ndarray | None = None,
) -> list[tuple[np.ndarray, ...]]:
    """Where the workspace boundary crosses the grid edges, along each sampled axis.

    ``inside`` is the node membership in the grid's shape. The edges along
    axis j are those between neighbouring nodes and the half edges from an
    end node to the box face (the face is evaluated where the end node is
    inside: a workspace that fills the box up to the face has no crossing
    there). On each edge whose ends differ in membership the crossing is placed
    by :func:`_crossings` (every axis in the same calls). ``f`` are integrands (node
    arrays, 0 outside) whose values at the crossings are reported; ``ic``: the
    nodes' ``1/kappa`` (NaN where unreachable), for dexterity crossings.

    Returns
    -------
    list of (minus, plus, at_minus, at_plus), one per sampled axis
        ``minus``, ``plus`` (grid shape): distance (unit of the axis) from each
        node to a crossing on its edge towards lower / higher values of the
        axis, inf where there is none; ``at_minus``, ``at_plus`` ((len(f),) +
        grid shape): the integrands at those crossings (0 where there is none).
    """
    ndim, k = inside.ndim, len(f)
    ext, faces = [], []
    for j in sampled:
        n = inside.shape[j]
        pos = np.concatenate([[float(box[0][j])], axes[j], [float(box[1][j])]])
        shape = list(inside.shape)
        shape[j] = n + 2
        ins, g = np.zeros(shape, dtype=bool), np.zeros((k,) + tuple(shape))
        icx = np.full(shape, np.nan)
        inner = [slice(None)] * ndim
        inner[j] = slice(1, n + 1)
        ins[tuple(inner)] = inside
        if ic is not None:
            icx[tuple(inner)] = ic
        for m in range(k):
            g[m][tuple(inner)] = f[m]
        ext.append((j, n, pos, ins, g, icx))
        for face, node in ((0, 0), (n + 1, n - 1)):
            idx = list(np.nonzero(np.take(inside, [node], axis=j)))
            if idx[0].size:
                idx[j] = np.full(idx[0].size, node)
                poses = _node_poses(axes, idx)
                poses[:, j] = pos[face]
                idx[j] = np.full(idx[0].size, face)
                faces.append((len(ext) - 1, tuple(idx), poses))
    if faces:
        inside_f, weight_f, ic_f, _ = values(np.vstack([p for *_, p in faces]))
        start = 0
        for e, idx, poses in faces:
            stop = start + poses.shape[0]
            ext[e][3][idx] = inside_f[start:stop]
            ext[e][5][idx] = ic_f[start:stop]
            for m, fm in enumerate(_integrands(inside_f[start:stop], weight_f[start:stop], ic_f[start:stop], k)):
                ext[e][4][m][idx] = fm
            start = stop
    brackets = []
    for j, n, pos, ins, g, icx in ext:
        lower = [slice(None)] * ndim
        upper = [slice(None)] * ndim
        lower[j], upper[j] = slice(0, n + 1), slice(1, n + 2)
        left, right = ins[tuple(lower)], ins[tuple(upper)]
        idx = list(np.nonzero(left ^ right))  # edge e joins extended points e and e + 1
        edge = idx[j]
        in_left = left[tuple(idx)]
        idx_in = list(idx)
        idx_in[j] = np.where(in_left, edge, edge + 1)
        idx_out = list(idx)
        idx_out[j] = np.where(in_left, edge + 1, edge)
        idx_node = list(idx)
        idx_node[j] = np.clip(edge - 1, 0, n - 1)
        brackets.append(
            (
                idx,
                edge,
                np.where(in_left, pos[edge], pos[edge + 1]),
                np.where(in_left, pos[edge + 1], pos[edge]),
                g[(slice(None),) + tuple(idx_in)],
                _node_poses(axes, idx_node),
                icx[tuple(idx_out)],
            )
        )
    sizes = [b[1].size for b in brackets]
    crossing, value = _crossings(
        values,
        np.vstack([b[5] for b in brackets]),
        np.repeat(sampled, sizes),
        np.concatenate([b[2] for b in brackets]),
        np.concatenate([b[3] for b in brackets]),
        np.concatenate([b[4] for b in brackets], axis=1),
        steps,
        np.concatenate([b[6] for b in brackets]),
    )
    out = []
    start = 0
    for (j, n, *_), (idx, edge, *_) in zip(ext, brackets):
        stop = start + edge.size
        minus, plus = np.full(inside.shape, np.inf), np.full(inside.shape, np.inf)
        at_minus, at_plus = np.zeros((k,) + inside.shape), np.zeros((k,) + inside.shape)
        for node, side, at_side, sign in ((edge - 1, plus, at_plus, 1.0), (edge, minus, at_minus, -1.0)):
            # the node left of the crossing sees it on its plus side, the one right of it on its minus side
            keep = (node >= 0) & (node < n)
            at = [i[keep] for i in idx]
            at[j] = node[keep]
            side[tuple(at)] = sign * (crossing[start:stop][keep] - axes[j][node[keep]])
            at_side[(slice(None),) + tuple(at)] = value[:, start:stop][:, keep]
        out.append((minus, plus, at_minus, at_plus))
        start = stop
    return out


def _integrands(inside: np.ndarray, weight: np.ndarray, ic: np.ndarray, count: int = 2) -> tuple[np.ndarray, ...]:
    """The integrands of V and of V * GDI at poses: ``weight`` and ``weight / kappa``, 0 outside
    (the first ``count``)."""
    f0 = np.where(inside, weight, 0.0)
    if count < 2:
        return (f0,)[:count]
    # 1/kappa only where inside (a fraction of a grid's nodes), where it is finite (the dexterity
    # test: above the limit, or finite without one), so an outside pose's NaN never enters
    f1 = np.zeros(np.shape(inside))
    f1[inside] = weight[inside] * ic[inside]
    return f0, f1


def _node_poses(axes: list[np.ndarray], index: list[np.ndarray]) -> np.ndarray:
    """Poses (N, dof) of the grid nodes at the multi-indices ``index`` (one array per axis)."""
    return np.column_stack([a[i] for a, i in zip(axes, index)])


def _cube_fraction(slopes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The part of the cell ``[-1/2, 1/2]^d`` on the centre's side of the plane through the
    boundary crossings ``u_j = +-1 / slopes_j`` (slopes (N, d) >= 0; 0: the plane is
    parallel to axis j): its volume fraction and its centroid.

    In ``t_j = 1/2 +- u_j`` (the sign flipping the axes whose crossing is below the centre)
    the part is ``{c.t < B}`` in the unit cube, ``c`` the slopes and ``B = 1 + sum_j c_j / 2``.
    With ``g_v = max(B - c.v, 0)`` at the cube's corners ``v``, its volume is
    ``V = sum_v (-1)^|v| g_v^d / (d! prod c)`` (inclusion-exclusion) and its first moments
    ``M_k = -dW/dc_k`` at fixed B, ``W = sum_v (-1)^|v| g_v^(d+1) / ((d+1)! prod c)`` the
    volume integrated over the level B: ``M_k = sum_v (-1)^|v| v_k g_v^d / (d! prod c)
    + W / c_k``. Only axes of non-zero slope enter (the part is a prism along the others).

    Returns
    -------
    fraction : ndarray (N,)
        Volume fraction of the centre's side.
    centroid : ndarray (N, d)
        Its centroid ``t - 1/2`` per axis (cell units, positive towards the crossing).
    """
    n, dims = slopes.shape
    fraction = np.ones(n)
    centroid = np.zeros((n, dims))
    active = slopes > 0
    code = active @ (1 << np.arange(dims))
    for pattern in np.unique(code):
        axes = [j for j in range(dims) if (pattern >> j) & 1]
        if not axes:
            continue
        rows = np.nonzero(code == pattern)[0]
        c = slopes[np.ix_(rows, axes)]
        d = c.shape[1]
        bound = 1.0 + 0.5 * c.sum(axis=1)
        volume, integral = np.zeros(rows.size), np.zeros(rows.size)
        moment = np.zeros((rows.size, d))
        for corner in range(1 << d):
            v = np.array([(corner >> j) & 1 for j in range(d)], dtype=float)
            sign = -1.0 if bin(corner).count("1") % 2 else 1.0
            gap = np.maximum(bound - c @ v, 0.0)
            volume += sign * gap**d
            integral += sign * gap ** (d + 1)
            moment += (sign * gap**d)[:, None] * v
        scale = math.factorial(d) * np.prod(c, axis=1)
        volume /= scale
        moment = moment / scale[:, None] + (integral / ((d + 1) * scale))[:, None] / c
        with np.errstate(divide="ignore", invalid="ignore"):
            part = np.where(volume[:, None] > 0, moment / volume[:, None] - 0.5, 0.0)
        prism, prism_volume, prism_centroid = _prism_cut(c)
        volume = np.where(prism, prism_volume, volume)
        part = np.where(prism[:, None], prism_centroid, part)
        fraction[rows] = np.clip(volume, 0.0, 1.0)
        centroid[np.ix_(rows, axes)] = np.clip(part, -0.5, 0.5)
    return fraction, centroid


def _prism_cut(c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cut of :func:`_cube_fraction` in closed form where the plane crosses every edge of the
    cell along its steepest axis (slopes ``c`` (N, d) > 0, the largest ``c_top >= 2 + sum of the
    others``): the part's extent along that axis is linear in the others, so its volume is
    ``1/2 + 1/c_top``, its centroid ``-c_k / (12 c_top V)`` along another axis k and
    ``(V^2 + sum_k c_k^2 / (12 c_top^2)) / (2 V) - 1/2`` along the steepest.

    Why: the inclusion-exclusion's terms there are about ``(c_top / 2)^d / (d! prod c)``, and a
    plane scaled down next to a node (:func:`_plane_slopes`: 1e4 and slopes down to 1e-3) lost
    up to 1e-3 of a cell to their cancellation (0.5 of a cell in 4-D), the compiled and numpy
    paths differing by as much. Returns ``(prism (N,) bool, volume (N,), centroid (N, d))``,
    the last two meaningful where ``prism``. :func:`kinematics.polytope.prism_plane_cut` is the same
    for one cell."""
    top_axis = np.argmax(c, axis=1)
    rows = np.arange(c.shape[0])
    top = c[rows, top_axis]
    others = np.where(np.arange(c.shape[1])[None, :] == top_axis[:, None], 0.0, c)
    prism = top >= 2.0 + others.sum(axis=1)
    volume = 0.5 + 1.0 / top
    centroid = -others / (12.0 * top * volume)[:, None]
    centroid[rows, top_axis] = (volume * volume + (others * others).sum(axis=1) / (12.0 * top * top)) / (
        2.0 * volume
    ) - 0.5
    return prism, volume, centroid


def _boundary_corrected_sums(
    values: _PointValues,
    axes: list[np.ndarray],
    box: tuple[np.ndarray, np.ndarray],
    sampled: list[int],
    inside: np.ndarray,
    f0: np.ndarray,
    f1: np.ndarray,
    steps: int,
    ic: np.ndarray,
) -> tuple[float, float]:
    """``sum_cells fraction * f`` for ``f0`` (weight) and ``f1`` (weight / kappa), node arrays
    in the grid's shape (0 outside): each boundary cell counts its inside fraction times
    ``f`` at the centroid of its inside part (see :func:`_integrate_grid`). ``ic``: the
    nodes' ``1/kappa`` (NaN where unreachable)."""
    if kernels.compiled():
        return _boundary_corrected_sums_compiled(values, axes, box, sampled, inside, f0, f1, steps, ic)
    n_sampled = len(sampled)
    nearest = np.empty((n_sampled,) + inside.shape)
    toward = np.empty((n_sampled,) + inside.shape)
    crossing_values = np.empty((n_sampled, 2) + inside.shape)
    crossings = _edge_crossings(values, axes, inside, (f0, f1), sampled, box, steps, ic)
    for k, (j, (minus, plus, at_minus, at_plus)) in enumerate(zip(sampled, crossings)):
        step = float(box[1][j] - box[0][j]) / len(axes[j])
        nearest[k] = np.minimum(minus, plus) / step  # in cell units
        toward[k] = np.where(plus < minus, 1.0, -1.0)
        crossing_values[k] = np.where(plus < minus, at_plus, at_minus)
    weight_sum, ic_sum = float(f0.sum()), float(f1.sum())
    boundary = np.nonzero(np.isfinite(nearest.reshape(n_sampled, -1)).any(axis=0))[0]
    if not boundary.size:
        return weight_sum, ic_sum
    dist = nearest.reshape(n_sampled, -1)[:, boundary].T
    sign = toward.reshape(n_sampled, -1)[:, boundary].T
    with np.errstate(divide="ignore"):
        slopes = np.where(np.isfinite(dist), np.minimum(1.0 / np.maximum(dist, 0.0), _NODE_SLOPE), 0.0)
    own, centroid = _faded_cube_fraction(slopes)
    is_in = inside.ravel()[boundary]
    with np.errstate(divide="ignore", invalid="ignore"):
        # centroid of the inside part: the node's side for an inside node, the rest of the
        # cell (whose centroid is the node) for an outside one
        centroid = np.where(
            is_in[:, None], centroid, np.where((own < 1.0)[:, None], -centroid * (own / (1.0 - own))[:, None], 0.0)
        )
    fraction = np.where(is_in, own, 1.0 - own)
    # f at the centroid (cell units, positive towards each axis's crossing; see _cut_cell_value)
    index = np.unravel_index(boundary, inside.shape)
    dims = np.asarray(inside.shape)
    neighbours = []  # per sampled axis: the node beyond (towards the crossing), behind, and its use
    for k, j in enumerate(sampled):
        offset = np.where(slopes[:, k] > 0.0, sign[:, k], 0.0).astype(int)
        beyond = tuple(np.clip(index[i] + (offset if i == j else 0), 0, dims[i] - 1) for i in range(inside.ndim))
        behind = tuple(np.clip(index[i] - (offset if i == j else 0), 0, dims[i] - 1) for i in range(inside.ndim))
        neighbours.append((beyond, behind, (slopes[:, k] > 0.0) & inside[behind] & (behind[j] != index[j])))
    weights = _crossing_weights(slopes)
    flat = np.ravel_multi_index(index, inside.shape)
    totals = []
    for m, f in enumerate((f0, f1)):
        node = f.ravel()[flat]
        inner, outer = node.copy(), np.zeros(boundary.size)
        for k, (beyond, behind, has_behind) in enumerate(neighbours):
            along = centroid[:, k]
            inner += weights[:, k] * np.where(has_behind, along * (node - f[behind]), 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                at_crossing = 1.0 / slopes[:, k]
                t = np.clip((along - at_crossing) / (1.0 - at_crossing), 0.0, 1.0)
            t = np.where(at_crossing < 1.0, t, 0.0)
            cross = crossing_values[k, m].ravel()[boundary]
            outer += weights[:, k] * np.where(weights[:, k] > 0.0, cross + t * (f[beyond] - cross), 0.0)
        value = np.maximum(np.where(is_in, inner, outer), 0.0)
        # the boundary nodes' own values (in the plain sums) replaced by their cells' parts
        totals.append(float(fraction @ value) - float(node.sum()))
    return weight_sum + totals[0], ic_sum + totals[1]


#: distance (cell units) beyond which a crossing's pull on a cut cell's plane fades, to none at
#: the neighbouring node (:func:`_faded_cube_fraction`)
FADE_FROM = 0.75


def _fade_weights(slopes: np.ndarray) -> np.ndarray:
    """Weight (any shape) of each crossing, from its slope ``c = h / distance``, in the cut of a
    cell (:func:`_faded_cube_fraction`): 1 up to the distance :data:`FADE_FROM`, a smoothstep
    falling to 0 at the neighbouring node (``c = 1``), 0 beyond (no crossing: ``c = 0``).
    :func:`_fade_weight` is the same for one slope (compiled path)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (1.0 - 1.0 / slopes) / (1.0 - FADE_FROM)
        smooth = u * u * (3.0 - 2.0 * u)
    return np.where(slopes * FADE_FROM >= 1.0, 1.0, np.where(slopes > 1.0, smooth, 0.0))


@kernels.inline_jit
def _fade_weight(c):
    """:func:`_fade_weights` of one slope (the same operations)."""
    if c * FADE_FROM >= 1.0:
        return 1.0
    if c <= 1.0:
        return 0.0
    u = (1.0 - 1.0 / c) / (1.0 - FADE_FROM)
    return u * u * (3.0 - 2.0 * u)


def _plane_slopes(slopes: np.ndarray) -> np.ndarray:
    """The slopes (N, d) of a cut cell's plane from its crossings' ``slopes`` (N, d): scaled
    together so that the largest is at most :data:`_MAX_SLOPE`, those then below
    :data:`_MIN_PLANE_SLOPE` 0. Why together: a node within 1e-4 of the boundary has its
    crossings at distances whose ratios give the plane's direction; capping each slope alone
    turned the plane as the node approached (the integrand at its centroid by 3 % of a
    column's height at H4's optimum). :func:`_plane_slope` is the same for one slope."""
    top = slopes.max(axis=1, initial=0.0)[:, None]
    scaled = slopes * np.where(top > _MAX_SLOPE, _MAX_SLOPE / np.where(top > 0.0, top, 1.0), 1.0)
    return np.where(scaled >= _MIN_PLANE_SLOPE, scaled, 0.0)


@kernels.inline_jit
def _plane_slope(c, top):
    """:func:`_plane_slopes` of one slope ``c``, the cell's largest being ``top``."""
    scaled = c * (_MAX_SLOPE / top if top > _MAX_SLOPE else 1.0)
    return scaled if scaled >= _MIN_PLANE_SLOPE else 0.0


def _faded_cube_fraction(slopes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_cube_fraction` of a cut cell whose crossings beyond :data:`FADE_FROM` fade out:
    the cuts with and without each such crossing, blended by its :func:`_fade_weights` (the
    fraction, and the first moments, whose ratio is the centroid).

    Why: a crossing lives on a cut edge, and the edge stops being cut when the crossing reaches
    its far end (that node changes sides). At its full slope the plane through it still cut
    the cell's corners there (6 % of a Tricept cell) and lost them in one step as the crossing
    vanished: a step of 3e-5 of eta along a Tricept optimum's line. Beyond half a cell the
    crossing lies outside the cell and only tilts the plane. Why a blend of cuts rather than a
    fading slope: a plane of slope near 0 costs the cut's inclusion-exclusion ``eps / slope``
    of a cell to cancellation; each cut here has slopes 0 or at least 1 (at least
    :data:`_MIN_PLANE_SLOPE` where :func:`_plane_slopes` scales them down next to a node).
    Exact for a planar boundary whose crossings lie within :data:`FADE_FROM`. ``slopes`` (N, d)
    (``h / distance``, at most :data:`_NODE_SLOPE`), returns as :func:`_cube_fraction`."""
    n, dims = slopes.shape
    fade = _fade_weights(slopes)
    plane = _plane_slopes(slopes)
    volume = np.zeros(n)
    moment = np.zeros((n, dims))
    for dropped in range(1 << dims):  # the crossings left out of this cut
        out = np.array([(dropped >> j) & 1 for j in range(dims)], dtype=bool)
        # an axis without a crossing (slope 0) has one cut, its "kept" one
        weight = np.prod(np.where(slopes > 0.0, np.where(out, 1.0 - fade, fade), np.where(out, 0.0, 1.0)), axis=1)
        rows = np.nonzero(weight > 0.0)[0]
        if not rows.size:
            continue
        part, centroid = _cube_fraction(np.where(out, 0.0, plane[rows]))
        volume[rows] += weight[rows] * part
        moment[rows] += (weight[rows] * part)[:, None] * centroid
    with np.errstate(divide="ignore", invalid="ignore"):
        centroid = np.where(volume[:, None] > 0.0, moment / volume[:, None], 0.0)
    return volume, centroid


def _crossing_weights(slopes: np.ndarray) -> np.ndarray:
    """Weights (B, d) of each sampled axis's crossing in the integrand of a cut cell
    (:func:`_cut_cell_value`), from the slopes (B, d) of :func:`_cube_fraction`: ``(slope - 1)^4``
    normalised, 0 for a crossing at the far node or none; the nearest crossing alone where no
    axis has weight (every crossing at a far node: the plane cuts the cell at its corners at most)."""
    above = np.where(slopes > 1.0, (slopes - 1.0) * (slopes - 1.0), 0.0)
    weights = above * above
    total = weights.sum(axis=1)
    none = np.nonzero(total == 0.0)[0]
    weights[none, np.argmax(slopes[none], axis=1)] = 1.0
    return weights / np.where(total == 0.0, 1.0, total)[:, None]


@kernels.inline_jit
def _faded_plane_cut(c, plane, cut, part, active, moment):
    """:func:`_faded_cube_fraction` of one cell: slopes ``c`` (d,) in, ``cut`` (d + 1,) out (as
    :func:`kinematics.polytope.plane_cut`); ``plane`` (d,), ``part`` (d + 1,), ``active``,
    ``moment`` scratch. Only the cuts of non-zero weight are made (a crossing of weight 1 is
    always kept, one of weight 0 always left out: most cells have no fading crossing and one
    cut), in the numpy path's order, so that the sums are the same."""
    d = c.shape[0]
    top = 0.0
    fading = 0  # bit j: axis j's crossing fades
    gone = 0  # bit j: axis j's crossing lies at the far node (weight 0): always left out
    for j in range(d):
        top = max(top, c[j])
        if c[j] > 0.0:
            fade = _fade_weight(c[j])
            if 0.0 < fade < 1.0:
                fading |= 1 << j
            elif fade == 0.0:
                gone |= 1 << j
    for j in range(d + 1):
        cut[j] = 0.0
    dropped = 0
    while True:  # the subsets of the fading axes, in increasing order
        weight = 1.0
        for j in range(d):
            if (fading >> j) & 1:
                fade = _fade_weight(c[j])
                weight *= (1.0 - fade) if (dropped >> j) & 1 else fade
            plane[j] = 0.0 if ((dropped | gone) >> j) & 1 else _plane_slope(c[j], top)
        if weight > 0.0:
            plane_cut(plane, part, active, moment)
            cut[0] += weight * part[0]
            for j in range(d):
                cut[j + 1] += (weight * part[0]) * part[j + 1]
        if dropped == fading:
            break
        dropped = ((dropped | ~fading) + 1) & fading  # the next subset of ``fading``
    if cut[0] > 0.0:
        for j in range(d):
            cut[j + 1] = cut[j + 1] / cut[0]
    else:
        for j in range(d):
            cut[j + 1] = 0.0


@kernels.inline_jit
def _fourth(x):
    """``x**4`` as the numpy path computes it (:func:`_crossing_weights`)."""
    square = x * x
    return square * square


@kernels.inline_jit
def _crossing_weight(c, k, near, total):
    """:func:`_crossing_weights` of axis ``k`` of one cell: slopes ``c`` (d,), ``near`` the axis of
    the largest, ``total`` the sum of ``(c - 1)^4`` over the slopes above 1."""
    if total > 0.0:
        return _fourth(c[k] - 1.0) / total if c[k] > 1.0 else 0.0
    return 1.0 if k == near else 0.0


@kernels.inline_jit
def _cut_cell_value(
    inside, f0, f1, p, c, near, toward, crossing_values, strides, sizes, plane, cut, part, active, moment
):
    """The cut cell of node ``p`` (flat index): its inside fraction times the integrands at the
    centroid of its inside part, ``(fraction f0, fraction f1)`` (:func:`_boundary_corrected_sums`
    for one node). ``c`` (d,) the slopes ``h / distance`` of its nearest crossing per sampled
    axis (0: none), ``near`` the axis of the largest, ``toward`` (d,) their directions (+-1) and
    ``crossing_values`` (d, 2) the integrands there; ``plane``, ``cut``, ``part``, ``active``,
    ``moment`` scratch. The cut is :func:`_faded_plane_cut`'s.

    The integrands at the centroid, linear along each axis with a crossing: for an inside node
    from the node and the node behind it (away from the crossing), at the centroid's offset
    along that axis; for an outside node between the crossing and the inside node beyond it.
    The axes are weighted by ``(c - 1)^4`` (:func:`_crossing_weights`): mostly the nearest
    crossing's. Why weights: the nearest crossing's axis alone switched axes where two crossings
    were about as near, a step in the cell's integrand (2e-5 of eta at H4's optimum); the
    weights move continuously, and a crossing that comes onto an edge at its far node enters
    with weight 0. Why not the full linear model (every axis at weight 1): it was continuous too
    but less accurate, GDI 0.12-0.13 % against 0.08-0.09 % on H4's and the Delta's designs of
    docs/accuracy.md (a one-sided difference along a far crossing's axis is a poor slope)."""
    d = c.shape[0]
    _faded_plane_cut(c, plane, cut, part, active, moment)
    own = cut[0]
    total = 0.0
    for k in range(d):
        if c[k] > 1.0:
            total += _fourth(c[k] - 1.0)
    if inside[p]:
        v0, v1 = f0[p], f1[p]
        for k in range(d):
            weight = _crossing_weight(c, k, near, total)
            if weight <= 0.0:
                continue
            sign = int(toward[k])
            behind = (p // strides[k]) % sizes[k] - sign
            if 0 <= behind < sizes[k] and inside[p - sign * strides[k]]:
                q = p - sign * strides[k]
                v0 += weight * (cut[k + 1] * (f0[p] - f0[q]))
                v1 += weight * (cut[k + 1] * (f1[p] - f1[q]))
        return own * max(v0, 0.0), own * max(v1, 0.0)
    # the inside part's centroid: the rest of the cell, whose centroid is the node
    scale = -own / (1.0 - own) if own < 1.0 else 0.0
    v0 = 0.0
    v1 = 0.0
    for k in range(d):
        weight = _crossing_weight(c, k, near, total)
        if weight <= 0.0:
            continue
        along = cut[k + 1] * scale
        q = p + int(toward[k]) * strides[k]
        at_crossing = 1.0 / c[k]
        t = 0.0
        if at_crossing < 1.0:
            t = min(max((along - at_crossing) / (1.0 - at_crossing), 0.0), 1.0)
        x0, x1 = crossing_values[k, 0], crossing_values[k, 1]
        v0 += weight * (x0 + t * (f0[q] - x0))
        v1 += weight * (x1 + t * (f1[q] - x1))
    return (1.0 - own) * max(v0, 0.0), (1.0 - own) * max(v1, 0.0)


@kernels.vector_jit
def _cut_cell_corrections(
    inside, f0, f1, node, entry, axis, crossing, value, positions, strides, sizes, steps_of, node_slope
):
    """Compiled :func:`_boundary_corrected_sums` after the crossings, sparse: only the nodes
    next to a crossing are visited. Crossing ``i`` lies on a grid edge along sampled axis
    ``axis[i]``, at ``crossing[i]`` (unit of the axis), with the integrands ``value[:, i]``
    there; ``node`` (E,) lists the nodes next to a crossing, grouped (sorted), and ``entry``
    (E,) the crossing of each: ``i`` when it lies above the node, ``i + M`` when below. Node
    arrays ``inside``, ``f0``, ``f1`` (N,); ``positions`` (d, .) the faces and nodes per sampled
    axis, ``strides``, ``sizes`` (d,) of the sampled axes in the flat index, ``steps_of`` (d,)
    their cell widths. Returns ``sum over cut nodes of (cut cell value - plain node value)``
    for both integrands: the plain sums plus these are the corrected sums. Per node and axis
    the nearer of its (up to two) crossings counts, on a tie the one below, as in the numpy
    path."""
    m = axis.shape[0]
    d = strides.shape[0]
    e = node.shape[0]
    nearest = np.empty(d)
    toward = np.empty(d)
    crossing_values = np.empty((d, 2))
    c = np.empty(d)
    plane = np.empty(d)
    cut = np.empty(d + 1)
    part = np.empty(d + 1)
    active = np.empty(d, dtype=np.int64)
    moment = np.empty(d)
    total0 = 0.0
    total1 = 0.0
    a = 0
    while a < e:
        p = node[a]
        for k in range(d):
            nearest[k] = np.inf
            toward[k] = -1.0
        while a < e and node[a] == p:
            i = entry[a] % m
            below = entry[a] >= m
            k = axis[i]
            here = positions[k, (p // strides[k]) % sizes[k] + 1]
            dist = (here - crossing[i] if below else crossing[i] - here) / steps_of[k]
            if dist < nearest[k] or (below and dist == nearest[k]):
                nearest[k] = dist
                toward[k] = -1.0 if below else 1.0
                crossing_values[k, 0], crossing_values[k, 1] = value[0, i], value[1, i]
            a += 1
        near = -1
        for k in range(d):
            if nearest[k] < np.inf:
                c[k] = min(1.0 / nearest[k], node_slope) if nearest[k] > 0.0 else node_slope
                if near < 0 or c[k] > c[near]:
                    near = k
            else:
                c[k] = 0.0
        v0, v1 = _cut_cell_value(
            inside, f0, f1, p, c, near, toward, crossing_values, strides, sizes, plane, cut, part, active, moment
        )
        total0 += v0 - f0[p]
        total1 += v1 - f1[p]
    return total0, total1


@kernels.jit
def _cut_edges(inside, strides, sizes):
    """The grid edges whose two nodes differ in membership: per sampled axis k (flat index
    ``(outer * sizes[k] + c) * strides[k] + inner``) the edges from layer c to c + 1, as
    ``(axis, lower node)`` arrays in the order of the axes, then of the lower node.

    Per axis the differences of the layers, one byte per node (contiguous runs, which LLVM
    vectorises), then the nodes read out eight at a time, a run of eight without a cut skipped
    by one test: few edges are cut (about 3 % of a grid's on the Delta), and a test per node
    cost 7x the time."""
    d = strides.shape[0]
    n = inside.shape[0]
    bits = inside.view(np.uint8)
    words = -(-n // 8)
    diff = np.zeros((d, 8 * words), dtype=np.uint8)  # 1 at the lower node of a cut edge
    count = 0
    for k in range(d):
        stride, size = strides[k], sizes[k]
        length = (size - 1) * stride  # the edges of one block of the axis
        for start in range(0, n, size * stride):
            lo, hi = bits[start : start + length], bits[start + stride : start + stride + length]
            out = diff[k, start : start + length]
            cut = 0
            for q in range(length):
                out[q] = lo[q] ^ hi[q]
                cut += out[q]
            count += cut
    axis = np.empty(count, dtype=np.int64)
    lower = np.empty(count, dtype=np.int64)
    i = 0
    for k in range(d):
        packed = diff[k].view(np.uint64)
        for w in range(words):
            if packed[w] != 0:
                for p in range(8 * w, 8 * w + 8):
                    if diff[k, p]:
                        axis[i], lower[i] = k, p
                        i += 1
    return axis, lower


@kernels.jit
def _edge_first_roots(inside, table, lower, stride):
    """Per grid edge from node ``lower`` to ``lower + stride`` (E,) whose ends differ in
    membership (``inside`` (N,)): its inside and outside end nodes, and the first sign change
    of the margins (rows of ``table``, (N + 1, K + 1); the last column the dexterity margin)
    linear between them, as a fraction of the way from the inside end. NaN where none changes
    sign or, as in step 1 of :func:`_crossings`, a reachability margin is unknown at an end: the
    one that binds there may be it (the Delta's joint angles beyond its reach: its secant then
    fell on another margin, up to 0.8 cells past the crossing), and the edge has no secant."""
    e, count = lower.shape[0], table.shape[1]
    inner = np.empty(e, dtype=np.int64)
    outer = np.empty(e, dtype=np.int64)
    first = np.empty(e)
    for i in range(e):
        a, b = lower[i], lower[i] + stride[i]
        if not inside[a]:
            a, b = b, a
        inner[i], outer[i] = a, b
        best = np.inf
        for c in range(count):
            g_in, g_out = table[a, c], table[b, c]
            if c < count - 1 and (np.isnan(g_in) or np.isnan(g_out)):
                best = np.inf
                break
            if g_in >= 0.0 and g_out < 0.0:
                best = min(best, g_in / (g_in - g_out))
        first[i] = best if best < np.inf else np.nan
    return inner, outer, first


def _margin_secants(
    values: _PointValues,
    axes: list[np.ndarray],
    sampled: list[int],
    margins: margin_cells.NodeMargins,
    inside: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The crossings of ``method="margins"``: on every grid edge whose ends differ in membership,
    each margin that vanishes along it and where, seen from both ends (the secants of
    :func:`kinematics.margin_cells.linear_margins`). None where no edge is cut (the arrays are
    empty where edges are cut but none has a secant).

    Steps 1-2 of :func:`_crossings` on the nodes' margins (``margins.table``, reachability and
    dexterity margins of every node): the margins linear between the ends, their first sign
    change ``t1`` (:func:`_edge_first_roots`); one look at ``t1`` (the reachability margins and
    ``1/kappa`` there); each margin as the parabola through its three values, its root in the
    bracket where they change sign (:func:`_margin_roots`). Third order in the edge length,
    continuous in the design. Every margin with a root gets its secant, not only the first: two
    margins that vanish at the same crossing (the Gough-Stewart's symmetric legs) were one or
    the other by the last bit, the compiled and numpy paths 1e-6 of V apart. Why not
    :func:`_crossings` itself: the rule needs the crossing's margins, not the integrands there,
    and the ends' margins are known; its
    second looks, the integrands at the crossing and the margins at both ends again cost the
    Tricept at 20 per axis a third of its evaluation (the look's ``1/kappa`` comes from the
    membership test's call, its verdict unused). An edge whose margins do not change sign
    between its ends, or where a reachability margin is unknown at an end, has no secant.

    Returns
    -------
    node, axis, distance, column : ndarray (2R,) each
        Per root (of a margin on an edge) and end: the end node (flat index), the sampled axis
        (index into ``sampled``), the signed distance from the node to the root (cell widths, +
        towards the node above) and the vanishing margin (a column of ``margins.table``; K the
        dexterity margin).
    """
    flat_inside = np.ascontiguousarray(inside.ravel())
    strides = margins.strides[sampled]
    sizes = np.array([inside.shape[j] for j in sampled], dtype=np.int64)
    axis, lower = _cut_edges(flat_inside, strides, sizes)
    if not axis.size:
        return None
    table = margins.table
    k = table.shape[1] - 1
    inner, outer, linear = _edge_first_roots(flat_inside, table, lower, strides[axis])
    ahead = inner == lower  # the crossing lies ahead of the lower node where it is inside
    look = np.nonzero(np.isfinite(linear))[0]
    if not look.size:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros(0), empty
    t1 = linear[look]
    g_in, g_out = table[inner[look]], table[outer[look]]
    column = np.asarray(sampled, dtype=np.int64)[axis[look]]
    at = _node_poses(axes, list(np.unravel_index(inner[look], inside.shape)))
    rows = np.arange(look.size)
    towards = np.where(ahead[look], 1.0, -1.0)
    widths = np.array([axes[j][1] - axes[j][0] if axes[j].size > 1 else 0.0 for j in sampled])
    at[rows, column] += towards * t1 * widths[axis[look]]
    reach_1 = values.margins(at)
    _, _, ic_1, _ = values(at)
    reach = np.ascontiguousarray(np.vstack([g_in[:, :k], g_out[:, :k]]))
    roots = _margin_roots(
        reach,
        np.ascontiguousarray(reach_1),
        np.ascontiguousarray(g_in[:, k]),
        ic_1**2 - values.min_ic**2,
        np.ascontiguousarray(g_out[:, k]),
        rows,
        t1,
    )
    edge, which = np.nonzero(np.isfinite(roots))
    t2, towards, look = roots[edge, which], towards[edge], look[edge]
    node = np.concatenate([inner[look], outer[look]])
    distance = np.concatenate([towards * t2, -towards * (1.0 - t2)])
    return node, np.tile(axis[look], 2), distance, np.tile(which, 2)


def _sparse_crossings(
    values: _PointValues,
    axes: list[np.ndarray],
    box: tuple[np.ndarray, np.ndarray],
    sampled: list[int],
    inside: np.ndarray,
    f0: np.ndarray,
    f1: np.ndarray,
    steps: int,
    ic: np.ndarray,
) -> dict[str, np.ndarray] | None:
    """The boundary crossings of the grid's edges, sparse: the grid edges whose ends differ in
    membership found slab by slab (vectorised comparisons of neighbouring layers), and the half
    edges from an inside end node to an outside box face; each crossing placed by
    :func:`_crossings` (all edges in one call per step). None where no edge is cut.

    Returns a dict of arrays: ``axis`` (E,) the sampled axis (index into ``sampled``) of each
    crossing's edge, ``left`` and ``right`` (E,) its end nodes (flat indices; -1 for the box
    face), ``crossing`` (E,) its position (unit of the axis), ``value`` (2, E) the integrands
    ``f0``, ``f1`` there; and the grid's bookkeeping: ``flat_inside``, ``f0``, ``f1`` (N,),
    ``positions`` (d, .) the faces and nodes per sampled axis, ``strides``, ``sizes`` (d,),
    ``steps_of`` (d,) the cell widths."""
    shape = inside.shape
    flat_inside = np.ascontiguousarray(inside.ravel())
    f0, f1 = np.ascontiguousarray(f0.ravel()), np.ascontiguousarray(f1.ravel())
    strides = margin_cells.flat_strides(shape)[sampled]
    sizes = np.array([shape[j] for j in sampled], dtype=np.int64)
    positions = np.zeros((len(sampled), int(sizes.max()) + 2))
    for k, j in enumerate(sampled):  # the face, the nodes, the face
        positions[k, 0], positions[k, sizes[k] + 1] = float(box[0][j]), float(box[1][j])
        positions[k, 1 : sizes[k] + 1] = axes[j]
    steps_of = (positions[np.arange(len(sampled)), sizes + 1] - positions[:, 0]) / sizes
    column = np.asarray(sampled, dtype=np.int64)

    def poses_of(nodes: np.ndarray, axis: np.ndarray, at: np.ndarray) -> np.ndarray:
        poses = _node_poses(axes, list(np.unravel_index(nodes, shape)))
        poses[np.arange(nodes.size), column[axis]] = at
        return poses

    # per sampled axis k the grid as (outer, size, stride) blocks: layer c of axis k is [:, c, :]
    blocks = [flat_inside.reshape(-1, int(sizes[k]), int(strides[k])) for k in range(len(sampled))]

    def flat(k: int, outer: np.ndarray, coordinate: np.ndarray | int, inner: np.ndarray) -> np.ndarray:
        return (outer * sizes[k] + coordinate) * strides[k] + inner

    faces = []  # (axis, side, node) of the inside end nodes
    for k, block in enumerate(blocks):
        for side, end in ((0, 0), (1, int(sizes[k]) - 1)):
            outer, inner = np.nonzero(block[:, end, :])
            faces.append((np.full(outer.size, k), np.full(outer.size, side), flat(k, outer, end, inner)))
    face_axis, face_side, face_node = (np.concatenate(part) for part in zip(*faces))
    axis_parts, left_parts, right_parts = [], [], []
    flat_ic = ic.ravel()
    ic_parts = []
    if face_node.size:  # a face outside the workspace: a crossing on the half edge to it
        face_inside, _, face_ic, _ = values(
            poses_of(face_node, face_axis, positions[face_axis, face_side * (sizes[face_axis] + 1)])
        )
        out = ~face_inside
        axis_parts.append(face_axis[out])
        left_parts.append(np.where(face_side[out] == 0, -1, face_node[out]))
        right_parts.append(np.where(face_side[out] == 0, face_node[out], -1))
        ic_parts.append(face_ic[out])
    edge_axis, lower = _cut_edges(flat_inside, strides, sizes)
    axis_parts.append(edge_axis)
    left_parts.append(lower)
    right_parts.append(lower + strides[edge_axis])
    ic_parts.append(np.where(flat_inside[lower], flat_ic[lower + strides[edge_axis]], flat_ic[lower]))
    axis = np.concatenate(axis_parts).astype(np.int64)
    left = np.concatenate(left_parts).astype(np.int64)
    right = np.concatenate(right_parts).astype(np.int64)
    ic_out = np.concatenate(ic_parts)
    if not axis.size:
        return None
    stride_of = strides[axis]
    left_in = (left >= 0) & flat_inside[np.maximum(left, 0)]
    inner_node = np.where(left_in, left, right)
    coordinate = (inner_node // stride_of) % sizes[axis]
    p_in = positions[axis, coordinate + 1]
    # the outside end: the neighbouring node, or the face past the end node
    p_out = positions[axis, np.where(left_in, coordinate + 2, coordinate)]
    crossing, value = _crossings(
        values,
        poses_of(inner_node, axis, p_in),
        column[axis],
        p_in,
        p_out,
        np.vstack([f0[inner_node], f1[inner_node]]),
        steps,
        ic_out,
    )
    return dict(
        axis=axis,
        left=left,
        right=right,
        crossing=crossing,
        value=value,
        flat_inside=flat_inside,
        f0=f0,
        f1=f1,
        positions=positions,
        strides=strides,
        sizes=sizes,
        steps_of=steps_of,
    )


def _boundary_corrected_sums_compiled(
    values: _PointValues,
    axes: list[np.ndarray],
    box: tuple[np.ndarray, np.ndarray],
    sampled: list[int],
    inside: np.ndarray,
    f0: np.ndarray,
    f1: np.ndarray,
    steps: int,
    ic: np.ndarray,
) -> tuple[float, float]:
    """:func:`_boundary_corrected_sums` with sparse bookkeeping: the grid edges whose ends
    differ in membership are found slab by slab (vectorised comparisons of neighbouring layers),
    only the inside end nodes' faces are evaluated, and the cut cells are summed compiled
    (:func:`_cut_cell_corrections`) over the nodes next to a crossing only; the crossings are
    placed by :func:`_crossings` (all edges in one call per step), as in the numpy path."""
    cut = _sparse_crossings(values, axes, box, sampled, inside, f0, f1, steps, ic)
    if cut is None:
        return float(np.ascontiguousarray(f0.ravel()).sum()), float(np.ascontiguousarray(f1.ravel()).sum())
    axis, left, right, flat_inside = cut["axis"], cut["left"], cut["right"], cut["flat_inside"]
    f0, f1 = cut["f0"], cut["f1"]
    # the nodes next to a crossing: left of it (the crossing above them), right of it (below)
    has_left, has_right = left >= 0, right >= 0
    node = np.concatenate([left[has_left], right[has_right]])
    entry = np.concatenate([np.nonzero(has_left)[0], np.nonzero(has_right)[0] + axis.size])
    order = np.argsort(node, kind="stable")
    correction0, correction1 = _cut_cell_corrections(
        flat_inside,
        f0,
        f1,
        node[order],
        entry[order],
        axis,
        cut["crossing"],
        cut["value"],
        cut["positions"],
        cut["strides"],
        cut["sizes"],
        cut["steps_of"],
        _NODE_SLOPE,
    )
    return float(f0.sum()) + correction0, float(f1.sum()) + correction1


#: the grid of ``method="grid"`` spans the workspace's extent found on a grid of
#: ``1 / COARSE`` the resolution in 3-D (``1 / COARSE**(3/d)`` with d sampled axes: about 1/8
#: of the nodes whatever d), widened by one of its cells on each side
COARSE = 2


#: parts per round of :func:`_multisect`
SECTIONS = 16


def _multisect(
    kept: Callable[[np.ndarray], np.ndarray],
    probe: np.ndarray,
    column: np.ndarray,
    p_in: np.ndarray,
    p_out: np.ndarray,
    rounds: int,
) -> np.ndarray:
    """The outermost change of ``kept`` (poses (N, dof) -> (N,) bool: reachable, say) between a
    kept (``p_in``) and a lost (``p_out``) value of column ``column`` (per row) of the poses
    ``probe`` (N, dof), to ``|p_out - p_in| / SECTIONS**rounds``: each round evaluates
    ``SECTIONS - 1`` evenly spaced points of every row's bracket in one call and keeps the part
    between the kept point nearest the lost end and its outer neighbour. Fewer calls than
    bisection (one per 4 halvings) for few rows, where a call's fixed cost dominates. Returns
    the middle of the last bracket (N,)."""
    rows = probe.shape[0]
    fractions = np.arange(1, SECTIONS) / SECTIONS
    probes = np.repeat(probe, SECTIONS - 1, axis=0)
    rows_of = np.arange(rows * (SECTIONS - 1))
    columns = np.repeat(column, SECTIONS - 1)
    for _ in range(rounds):
        points = p_in[:, None] + fractions[None, :] * (p_out - p_in)[:, None]  # (N, SECTIONS - 1)
        probes[rows_of, columns] = points.ravel()
        inside = kept(probes).reshape(rows, SECTIONS - 1)
        # the last inside point (0: p_in itself), counted from p_in
        last = np.where(inside.any(axis=1), SECTIONS - 1 - np.argmax(inside[:, ::-1], axis=1), 0)
        width = p_out - p_in
        p_in, p_out = p_in + width * last / SECTIONS, p_in + width * (last + 1) / SECTIONS
    return 0.5 * (p_in + p_out)


def _occupied_box(
    values: _PointValues,
    mechanism: Mechanism,
    resolution: int,
    orientation: tuple[float, float],
    fixed: dict[str, float],
    exact: int | None,
    box: tuple[np.ndarray, np.ndarray],
    sampled: list[int],
    rounds: int = 3,
) -> tuple[np.ndarray, np.ndarray]:
    """The pose box narrowed, along each sampled axis, to the reachable set's extent (which
    holds the workspace, its dexterous part).

    Why: a mechanism's box is a bound from the geometry and the workspace may
    fill a fraction of it (Tricept: c in about 300-650 of 0-926 mm); the grid's
    cells then go where the workspace is. On a grid of about 1/8 of the nodes
    (``resolution / COARSE**(3/d)`` per axis, d the sampled axes) the extent along axis j is
    the lowest / highest boundary crossing on the edges below the lowest (above the highest)
    layer of reachable nodes, widened by one coarse cell (so that the box holds the whole edge,
    wherever on it the crossing lies) and clipped to the box; a set in the first or
    last layer keeps that face. Each crossing moves continuously with the design, and so
    does their minimum: the grid, and the integral, stay continuous. The crossings are
    placed on the reach margins (:func:`_crossings`); where the mechanism has none the few
    extreme edges are cut in :data:`SECTIONS` parts ``rounds`` times (:func:`_multisect`, one
    call per round), so that the box moves by no more than ``SECTIONS**-rounds`` (``2**-12``)
    of a coarse cell at a time. An empty coarse grid keeps the box.

    Why reachable, not dexterous: the layers and the crossings must follow one set. With the
    layers of dexterous nodes and crossings on the reach margins, an extreme crossing jumped
    where an outside node turned dexterous (by 1.5 % of a coarse cell at H4's h4_mixed best
    known, and with it every node of the grid: a step of 3e-6 of eta); placing the dexterity
    limit too costs looks (the coarse pass took twice as long). The dexterity limit of the
    built-in configs (1/kappa >= 0.01) trims the reachable set little.
    """
    coarse = max(int(resolution / COARSE ** (3 / len(sampled))), 4)
    axes, _ = _grid_axes(mechanism, coarse, orientation, fixed, 0.5, exact, box, anisotropic=True)
    shape = tuple(len(a) for a in axes)
    reachable = np.concatenate(
        [np.isfinite(values(_grid_poses(axes, start, stop))[2]) for start, stop in _chunk_bounds(axes)]
    ).reshape(shape)
    lo, hi = box[0].astype(float).copy(), box[1].astype(float).copy()
    if not reachable.any():
        return lo, hi
    # the reachable nodes (C order) and their poses, once: each job takes the ones of its layer
    index = np.nonzero(reachable)
    reachable_poses = _node_poses(axes, list(index))
    jobs = []  # (axis, side, rows of reachable_poses, p_in, p_out)
    for j in sampled:
        coordinate = index[j]
        first, last = int(coordinate.min()), int(coordinate.max())
        for side, layer, beyond in (("lo", first, first - 1), ("hi", last, last + 1)):
            if beyond < 0 or beyond >= shape[j]:
                continue  # the workspace reaches the end layer: keep the face
            jobs.append((j, side, np.nonzero(coordinate == layer)[0], axes[j][layer], axes[j][beyond]))
    if jobs:
        sizes = [job[2].size for job in jobs]
        probe = reachable_poses[np.concatenate([job[2] for job in jobs])]
        column = np.repeat([job[0] for job in jobs], sizes)
        p_in, p_out = np.repeat([job[3] for job in jobs], sizes), np.repeat([job[4] for job in jobs], sizes)
        # on the reach margins where the mechanism has them (any crossing of the edge will do: the
        # box is widened by the edge's length; no integrands, so no dexterity margin), by
        # multisection of reachability elsewhere
        crossing, _ = _crossings(values, probe, column, p_in, p_out, np.empty((0, p_in.size)), None)
        left = np.nonzero(np.isnan(crossing))[0]
        if left.size:
            crossing[left] = _multisect(
                lambda poses: np.isfinite(values(poses)[2]), probe[left], column[left], p_in[left], p_out[left], rounds
            )
        start = 0
        for (j, side, *_), size in zip(jobs, sizes):
            stop = start + size
            step = (float(box[1][j]) - float(box[0][j])) / len(axes[j])
            if side == "lo":
                lo[j] = max(float(box[0][j]), float(crossing[start:stop].min()) - step)
            else:
                hi[j] = min(float(box[1][j]), float(crossing[start:stop].max()) + step)
            start = stop
    return lo, hi


def _integrate_grid(
    mechanism,
    resolution,
    orientation,
    min_ic,
    length,
    fixed,
    keep_samples,
    offset=0.5,
    refine=True,
    steps=BISECTIONS,
    margins=False,
):
    """Integration on a regular grid; one axis exactly when the mechanism allows it.

    Each grid node carries a weight: 1, or, along an exact axis, the length of
    the node's feasible interval (clipped to the pose box).

    ``refine=False`` (``method="midpoint"``): the midpoint rule on the
    indicator, volume ``cell * sum(weight)`` over nodes inside the workspace and
    the GDI the weighted mean of 1/kappa; its error is first order in the grid
    step and it jumps whenever the boundary crosses a node.

    ``refine=True`` (``method="grid"``): the grid spans the workspace's extent
    (:func:`_occupied_box`), and each cell counts with the fraction of it inside
    the workspace. On every grid edge (and half edge to the box face) whose ends
    differ in membership the boundary crossing is placed on the margins
    (:func:`_crossings`; :func:`_edge_crossings`); a node next to crossings takes the boundary as the
    plane through the nearest crossing along each axis and counts the part of its
    cell on the workspace's side (:func:`_cube_fraction`), with the integrand at
    that part's centroid (:func:`_boundary_corrected_sums`). Exact for a planar
    boundary, second order for a smooth one, and continuous in the design: when
    the boundary crosses a node the plane passes through the node and the
    fraction is 1/2 from either side. ``steps``: bisections per crossing the margins
    cannot place.

    ``margins=True`` (the linear-margins cell rule, with ``refine``): the same grid, every node's
    margins computed with it, crossings from them (:func:`_margin_secants`), and the cells along
    the boundary counted by the rule of :mod:`kinematics.margin_cells` instead of one plane per
    cell.
    """
    exact = _exact_axis(mechanism, fixed)
    box = mechanism.pose_bounds(orientation)
    sampled = _sampled_indices(mechanism, orientation, fixed, exact) if refine else []
    values = _PointValues(mechanism, exact, box, orientation, min_ic, length)
    if sampled:
        box = _occupied_box(values, mechanism, resolution, orientation, fixed, exact, box, sampled)
    axes, cell = _grid_axes(mechanism, resolution, orientation, fixed, offset, exact, box, anisotropic=refine)
    shape = tuple(len(a) for a in axes)
    total = int(np.prod(shape))
    # the grid's angular nodes all lie in the orientation box (it spans the box): then the
    # fused path needs no per-node orientation test
    oriented = all(
        axis.min() >= orientation[0] and axis.max() <= orientation[1]
        for axis, angular in zip(axes, mechanism.angular)
        if angular
    )
    parts = []
    kept = []
    reach = []  # the nodes' reachability margins, for method "margins"
    for start, stop in _chunk_bounds(axes):
        poses = _grid_poses(axes, start, stop)
        inside, weight, ic, extent = values(poses, oriented, keep_samples)
        parts.append((inside, weight, ic))
        if sampled and margins:
            reach.append(values.margins(poses))
        if keep_samples:
            kept.append((poses, ic, inside) + (() if extent is None else (extent,)))
    inside, weight, ic = (np.concatenate(k) for k in zip(*parts))
    vals = ic[inside]
    n_inside = int(inside.sum())
    if sampled and margins:
        node_margins = margin_cells.NodeMargins(
            reach[0] if len(reach) == 1 else np.concatenate(reach), ic.reshape(shape), values.min_ic
        )
        secants = _margin_secants(values, axes, sampled, node_margins, inside.reshape(shape))
        weight_sum, ic_sum = margin_cells.margin_cell_sums(
            node_margins, sampled, inside.reshape(shape), ic.reshape(shape), secants, values.min_ic
        )
    elif sampled:
        f0, f1 = _integrands(inside, weight, ic)
        weight_sum, ic_sum = _boundary_corrected_sums(
            values,
            axes,
            box,
            sampled,
            inside.reshape(shape),
            f0.reshape(shape),
            f1.reshape(shape),
            steps,
            ic.reshape(shape),
        )
    else:
        f0, f1 = _integrands(inside, weight, ic)
        weight_sum, ic_sum = float(f0.sum()), float(f1.sum())
    volume = weight_sum * cell
    stats = (
        (ic_sum / weight_sum,) + ((float(vals.min()), float(vals.max())) if vals.size else (0.0, 0.0))
        if weight_sum > 0
        else (0.0, 0.0, 0.0)
    )
    samples = tuple(np.concatenate(k) for k in zip(*kept)) if keep_samples else None
    return volume, stats, total, n_inside, samples


# --------------------------------------------------------------- sections
#: nodes of the (y, phi) rule of :func:`_integrate_sections` per ``resolution`` where its rows span
#: the pose box (2-RPR): phi, y, and the sample spacing along the exact axis as a fraction of the
#: box (anisotropic: docs/accuracy.md). Why 1.5 x phi: V is exact along x and its error is the
#: (y, phi) rule's, mostly phi's (3-RPR at its default, 14 designs: worst V 0.113 % with phi at 1x,
#: 0.058 % at 1.5x, 0.089 % with y at 1.25x instead, for the same number of rows)
SECTION_NODES = (1.5, 1.5, 0.375)
#: the same where each layer's rows span its exact extent
#: (:meth:`~kinematics.base.Mechanism.transverse_extent`, 3-RPR). Why fewer rows and samples: over
#: the extent every row meets the workspace, and the box's fractions cost 1.5x as many
#: evaluations of ``1/kappa`` on the paper design; at these, the 3-RPR's worst error over the
#: ladder and the scan of docs/accuracy.md is 0.05 % (V and GDI) at about the cost of the rule
#: over the box (measured 2026-11-28: y at 1x gave V 0.15 % on the scan's sliver, x at 0.2x GDI
#: 0.15 %)
EXTENT_SECTION_NODES = (1.5, 1.25, 0.25)


#: orientations of the scan for the layers' span where the workspace is not reachable at both
#: ends of the orientation range, per layer of the rule (:func:`_reachable_orientations`)
ORIENTATION_SCAN = 2
#: rounds of :func:`_multisect` placing each end of that span (16^4 parts of a scan step)
ORIENTATION_ROUNDS = 4


def _reachable_orientations(
    mechanism: Mechanism,
    angle: int,
    orientation: tuple[float, float],
    layers: int,
    ends: tuple[np.ndarray, np.ndarray],
) -> tuple[float, float] | None:
    """The span of orientations (rad) where the mechanism's
    :meth:`~kinematics.base.Mechanism.transverse_extent` is not empty, within ``orientation``
    (whose extents are ``ends``, each (2,)); ``orientation`` itself where the extent is not
    empty at both of its ends; None where nothing is reachable at any of
    ``ORIENTATION_SCAN * layers + 1`` evenly spaced orientations. Otherwise the first and the last
    reachable orientations of that scan, each moved out to the end of its run by
    :func:`_multisect` (to ``1 / 16**ORIENTATION_ROUNDS`` of a scan step): the span moves
    continuously with the design. ``angle`` is the orientation's column in a pose."""
    if np.all(np.isfinite(ends[0])):
        return orientation
    scan = np.linspace(orientation[0], orientation[1], ORIENTATION_SCAN * layers + 1)
    reachable = np.isfinite(mechanism.transverse_extent(scan)[0])
    if not reachable.any():
        return None
    first, last = int(np.argmax(reachable)), int(scan.size - 1 - np.argmax(reachable[::-1]))
    # the outer neighbour of each (itself at an end of the range, which is reachable then)
    p_in, p_out = scan[[first, last]], scan[[max(first - 1, 0), min(last + 1, scan.size - 1)]]
    span = _multisect(
        lambda poses: np.isfinite(mechanism.transverse_extent(poses[:, angle])[0]),
        np.zeros((2, mechanism.dof)),
        np.array([angle, angle]),
        p_in,
        p_out,
        ORIENTATION_ROUNDS,
    )
    lower = float(orientation[0]) if first == 0 else float(span[0])
    upper = float(orientation[1]) if last == scan.size - 1 else float(span[1])
    return lower, upper


def section_axes(mechanism: Mechanism) -> tuple[int, int | None]:
    """The pose columns across a mechanism's exact sections: its one linear transverse axis
    (3-RPR: y) and its one angle (3-RPR: phi; None without one).

    Raises
    ------
    ValueError
        Unless the mechanism has a :attr:`~kinematics.base.Mechanism.section_axis` and, besides
        it, exactly one linear pose variable and at most one angle: the only layout the product
        rule of :func:`_integrate_sections` (and a stated
        :meth:`~kinematics.base.Mechanism.transverse_extent`) covers.
    """
    section = mechanism.section_axis
    others = [j for j in range(mechanism.dof) if j != section]
    angular = [j for j in others if mechanism.angular[j]]
    linear = [j for j in others if not mechanism.angular[j]]
    if section is None or len(linear) != 1 or len(angular) > 1:
        raise ValueError(
            f"{mechanism.name}: exact sections need a section axis, one linear transverse axis and at most "
            f"one angle (section_axis {section!r}, angular {tuple(mechanism.angular)})"
        )
    return linear[0], (angular[0] if angular else None)


def _integrate_sections(mechanism, resolution, orientation, min_ic, length):
    """Exact sections along ``mechanism.section_axis`` (3-RPR: x), a product rule across them.

    The section axis is integrated in closed form per row
    (:meth:`~kinematics.base.Mechanism.exact_sections`: exact interval ends, ``1/kappa`` by the
    corrected trapezoid rule on nodes ``step`` apart, the dexterity limit placed by
    interpolation). The other two axes (3-RPR: y, phi) take the midpoint rule,
    ``SECTION_NODES[1] * resolution`` rows along y per layer and
    ``SECTION_NODES[0] * resolution`` layers along phi (one at constant orientation;
    :data:`EXTENT_SECTION_NODES` where the rows span the extents, below); each layer's
    rows are shifted by the fraction ``{j g}`` of a row (g the golden ratio's conjugate, j the
    layer), so that a feature at constant y (3-RPR: the annulus of the leg whose platform joint
    is the pose point does not turn with phi) is not sampled at the same offset in every layer.
    Where the mechanism knows its :meth:`~kinematics.base.Mechanism.transverse_extent` (3-RPR),
    the layers span the orientations where anything is reachable
    (:func:`_reachable_orientations`) and each layer's rows span its own exact y extent, each
    layer weighted by its row width; otherwise the rows and layers span the pose box (2-RPR).
    Why: a workspace that fills a small part of the box (a 3-RPR sliver of 9e-6 of V*, over a
    third of the orientations) met one row per layer, 0.56 % of V off; spread over the
    extent, every layer has its full rows (docs/accuracy.md). Continuous in the design: the
    span, the extents, the rows and the sections all move continuously (but for the moment a
    separate part of a layer's workspace shrinks to a point and vanishes: the extent jumps
    there, and the rows move by up to a row, a step of the size of the rule's error).
    """
    section = mechanism.section_axis
    lo, hi = mechanism.pose_bounds(orientation)
    ty, angle = section_axes(mechanism)
    if not (hi[section] > lo[section] and hi[ty] > lo[ty]):  # an empty box (2-RPR: b > 2 q_max)
        return 0.0, (0.0, 0.0, 0.0), 0, 0, None
    ends = mechanism.transverse_extent(np.array(orientation, dtype=float))  # None: not known
    nodes = SECTION_NODES if ends is None else EXTENT_SECTION_NODES
    n_y = max(int(math.ceil(nodes[1] * resolution)), 2)
    if angle is not None and orientation[1] > orientation[0]:
        n_a = max(int(math.ceil(nodes[0] * resolution)), 1)  # rounded up, as the rows
        span = orientation if ends is None else _reachable_orientations(mechanism, angle, orientation, n_a, ends)
        if span is None:
            return 0.0, (0.0, 0.0, 0.0), 0, 0, None
        ha = (span[1] - span[0]) / n_a
        layers = span[0] + ha * (np.arange(n_a) + 0.5)
    else:
        n_a, ha = 1, 1.0
        layers = np.array([float(orientation[0])])
    shift = (np.arange(n_a) * (math.sqrt(5.0) - 1.0) / 2.0) % 1.0 - 0.5
    rows = (np.arange(n_y) + 0.5)[None, :] + shift[:, None]
    extent = mechanism.transverse_extent(layers)
    if extent is None:  # every layer across the pose box, with one row width
        hy = (float(hi[ty]) - float(lo[ty])) / n_y
        ys = float(lo[ty]) + hy * (rows % n_y)
    else:  # each layer's rows across its extent; the layers where nothing is reachable left out
        kept = np.isfinite(extent[0]) & np.isfinite(extent[1])
        layers, rows = layers[kept], rows[kept]
        hy = (extent[1][kept] - extent[0][kept]) / n_y  # per layer
        ys = extent[0][kept][:, None] + hy[:, None] * (rows % n_y)
    poses = np.zeros((ys.size, mechanism.dof))
    poses[:, ty] = ys.ravel()
    if angle is not None:
        poses[:, angle] = np.repeat(layers, n_y)
    step = (float(hi[section]) - float(lo[section])) / max(nodes[2] * resolution, 1.0)
    measure, reach, integral, ic_min, ic_max, _ = mechanism.exact_sections(
        poses, float(lo[section]), step, min_ic, length
    )

    def weighted(per_row: np.ndarray) -> float:
        """The sum of ``per_row`` (N,) times each row's cell, over their common factor ``scale``."""
        if extent is None:
            return float(per_row.sum())
        return float((per_row.reshape(-1, n_y).sum(axis=1) * hy).sum())

    scale = hy * ha if extent is None else ha  # the cell of the product rule, per unit weight
    dexterous = weighted(measure)
    volume = dexterous * scale
    inside = measure > 0
    if volume > 0:
        # the GDI as the ratio of two sums on the same rows: their rim errors cancel
        stats = (weighted(integral) * scale / volume, float(ic_min[inside].min()), float(ic_max[inside].max()))
    else:
        stats = (0.0, 0.0, 0.0)
    exact = mechanism.exact_volume(orientation)
    reachable = weighted(reach)
    if exact is not None and reachable > 0:
        # the reachable volume in closed form times the dexterous share of the sections: the error
        # of the rule across the sections where they shrink to nothing (h^1.5, irregular) falls
        # out of V where the dexterity limit cuts the workspace inside (the default's band), and
        # is at most the sections' own elsewhere; 0 where nothing is dexterous
        volume = float(exact) * dexterous / reachable
    # the counters as a grid's: the rule's sample points, one per node spacing ``step`` along each
    # row, and those inside the dexterous workspace (its length on the rows over ``step``), so that
    # n_inside / n_samples is the dexterous share of what the rows span (the pose box, or the
    # 3-RPR's reachable extent). Why not the Jacobians evaluated and the rows met: those counted
    # other things (83858 evaluations, 530 rows for a 2-RPR filling 45 % of its box)
    n_samples = int(round(poses.shape[0] * (float(hi[section]) - float(lo[section])) / step))
    n_inside = min(int(round(float(measure.sum()) / step)), n_samples)
    return volume, stats, n_samples, n_inside, None


def _has_sections(mechanism: Mechanism, fixed: dict[str, float]) -> bool:
    """Whether ``method="grid"`` integrates by exact sections (the mechanism provides them and
    no pose variable is fixed)."""
    return not fixed and mechanism.section_axis is not None


# ------------------------------------------------------------------ polar
def _integrate_polar(mechanism, resolution, orientation, min_ic, length, keep_samples):
    """Seed 001 Sec. 4.1: slices along the length variable, polar boundary search in each.

    In slice ``Z_i`` a ray from the orientation centre at angle ``alpha`` is
    marched outward in ``resolution`` steps to the first pose outside the
    workspace, then the crossing is bisected (30 halvings). The slice area is
    ``sum 1/2 rho^2 d_alpha`` (eq. 38-39). 1/kappa is integrated along each ray
    with the midpoint rule in ``rho d_rho``. Assumes star-shaped slices
    around the centre, as the paper does.
    """
    angular = np.asarray(mechanism.angular)
    if mechanism.dof != 3 or angular.sum() != 2:
        raise ValueError(
            f"method 'polar' needs one length and two angles (the Tricept); "
            f"{mechanism.name} has pose {mechanism.pose_names}"
        )
    lin = int(np.nonzero(~angular)[0][0])
    ang = np.nonzero(angular)[0]
    lo, hi = mechanism.pose_bounds(orientation)
    dz = (hi[lin] - lo[lin]) / resolution
    z = lo[lin] + dz * (np.arange(resolution) + 0.5)
    n_rays = 4 * resolution
    d_alpha = 2 * np.pi / n_rays
    alpha = d_alpha * np.arange(n_rays)
    centre = 0.5 * (orientation[0] + orientation[1])
    rho_max = math.hypot(orientation[1] - centre, orientation[1] - centre)
    zz, aa = (g.ravel() for g in np.meshgrid(z, alpha, indexing="ij"))

    def poses_at(rho: np.ndarray) -> np.ndarray:
        p = np.empty((zz.size, 3))
        p[:, lin] = zz
        p[:, ang[0]] = centre + rho * np.cos(aa)
        p[:, ang[1]] = centre + rho * np.sin(aa)
        return p

    def is_inside(rho: np.ndarray) -> np.ndarray:
        return membership(mechanism, poses_at(rho), orientation, min_ic, length)[0]

    steps = rho_max * np.arange(resolution + 1) / resolution
    inside_along = np.column_stack([is_inside(np.full(zz.size, r)) for r in steps])
    outside = ~inside_along
    first_out = np.where(outside.any(axis=1), outside.argmax(axis=1), resolution + 1)
    lower = np.where(first_out > 0, steps[np.clip(first_out - 1, 0, resolution)], 0.0)
    upper = np.where(first_out <= resolution, steps[np.clip(first_out, 0, resolution)], rho_max)
    for _ in range(30):
        mid = 0.5 * (lower + upper)
        inside_mid = is_inside(mid)
        lower = np.where(inside_mid, mid, lower)
        upper = np.where(inside_mid, upper, mid)
    boundary = np.where(first_out > 0, lower, 0.0)
    volume = float(np.sum(0.5 * boundary**2) * d_alpha * dz)
    # 1/kappa along each ray, midpoint rule with weight rho
    frac = (np.arange(resolution) + 0.5) / resolution
    weights = np.zeros((zz.size, resolution))
    ics = np.zeros((zz.size, resolution))
    all_poses, all_ic = [], []
    for k, f in enumerate(frac):
        rho = f * boundary
        poses = poses_at(rho)
        _, ic = membership(mechanism, poses, orientation, 0.0, length)
        ics[:, k] = np.nan_to_num(ic)
        weights[:, k] = rho * boundary / resolution
        if keep_samples:
            all_poses.append(poses)
            all_ic.append(ic)
    mass = float(np.sum(weights))
    gdi = float(np.sum(weights * ics) / mass) if mass > 0 else 0.0
    used = ics[weights > 0]
    n_inside = int(np.count_nonzero(boundary))
    stats = (gdi, float(used.min()), float(used.max())) if used.size else (0.0, 0.0, 0.0)
    samples = None
    if keep_samples:
        samples = (np.concatenate(all_poses), np.concatenate(all_ic), np.tile(boundary > 0, resolution))
    n_samples = int(inside_along.size + 30 * zz.size + resolution * zz.size)
    return volume, stats, n_samples, n_inside, samples


def _check_margins_method(mechanism: Mechanism, orientation: tuple[float, float], fixed: dict[str, float]) -> None:
    """ValueError (one line) where the linear-margins cell rule (``method="margins"``, or a
    mechanism's ``cell_rule``) cannot integrate: a mechanism without reachability margins, with
    an exact axis, or a grid of more than 3 sampled axes (the messages name the rule as the
    method: a mechanism's own rule reaches here only with the first two, a defect of its class)."""
    exact = _exact_axis(mechanism, fixed)
    if exact is not None:
        raise ValueError(
            f"method 'margins' does not integrate an exact axis ({mechanism.name} integrates "
            f"{mechanism.pose_names[exact]} exactly); use method 'planes'"
        )
    if mechanism.constraint_margins(np.zeros((1, mechanism.dof))) is None:
        raise ValueError(f"method 'margins' needs a mechanism with constraint_margins; {mechanism.name} has none")
    names = sampled_axes(mechanism, orientation, fixed)
    if not 1 <= len(names) <= 3:
        raise ValueError(
            f"method 'margins' needs 1 to 3 sampled pose axes; {mechanism.name} samples {len(names)} "
            f"({', '.join(names) or 'none'}) here: fix some (fixed=...) or use method 'planes'"
        )


# --------------------------------------------------------------- evaluate
def evaluate(
    mechanism: Mechanism,
    *,
    resolution: int | None = None,
    orientation: tuple[float, float] | None = None,
    min_inverse_condition: float = 0.01,
    length: float | None = None,
    method: str = "grid",
    fixed: dict[str, float] | None = None,
    return_samples: bool = False,
    error_estimate: bool = True,
) -> Evaluation:
    """Workspace volume, GDI, SURI and 1/kappa statistics of one design.

    Parameters
    ----------
    mechanism : Mechanism
        The design (e.g. ``get_mechanism("h4", d=..., h=..., Qz=...)``).
    resolution : int, optional
        Grid points per sampled axis (larger is finer; doubling it refines
        every axis). Default :func:`default_resolution`: for ``method="grid"`` the node budget
        :attr:`~kinematics.base.Mechanism.grid_nodes` spread over the sampled axes where set
        (H4 30, with 15 along theta; Tricept 20, Delta and Gough-Stewart 26), else
        :attr:`~kinematics.base.Mechanism.default_nodes`
        (H4 24, Tricept 32, 3-RPR 32 over (x, y, phi) or 181 at constant phi, 2-RPR 400), which
        ``method="midpoint"`` always takes.
    orientation : (float, float), optional
        Range (rad) of every angular pose variable; ``lo == hi`` asks for the
        constant-orientation workspace (the volume is then the measure over
        the remaining variables). Default: the mechanism's
        ``default_orientation``.
    min_inverse_condition : float
        Dexterity limit: poses with ``1/kappa <=`` it are outside (0.01, seed
        000 Sec. 4.4); 0 disables the limit.
    length : float, optional
        Characteristic length homogenising the Jacobian (default: the
        mechanism's).
    method : {"grid", "midpoint", "polar", "margins", "planes"}
        The grid with boundary cells counted by their inside fraction (the
        default: second order, continuous in the design; dearer than the plain
        count at the defaults, docs/accuracy.md), each cell by the mechanism's
        :attr:`~kinematics.base.Mechanism.cell_rule` (one plane through its crossings, or
        linear margins: the Tricept's and the Gough-Stewart's); the plain cell-centre count (first order,
        the objective of earlier versions); the Tricept paper's polar
        boundary search; or the grid with either cell rule whatever the mechanism's:
        ``"margins"`` (:mod:`kinematics.margin_cells`: mechanisms with margins and no exact axis,
        at most 3 sampled axes) or ``"planes"`` (the cell grid also for a mechanism the grid
        method integrates by exact sections: the 3-RPR, the 2-RPR). All three grids take the
        grid's default resolution.
    fixed : dict, optional
        Pose variables held at a value (e.g. ``{"z": 0.0}`` for a slice);
        the volume is the measure over the others.
    return_samples : bool
        Keep the sampled poses, their 1/kappa and the inside mask (for plots).
    error_estimate : bool
        Also integrate at half the resolution (midpoint: on the grid shifted
        by half a cell; polar: at half the resolution) and report the change
        as ``volume_error``, ``gdi_error`` (see :meth:`Evaluation.mixed_error`).

    Returns
    -------
    Evaluation
    """
    if not isinstance(mechanism, Mechanism):
        raise ValueError(f"mechanism must be a kinematics Mechanism; got {type(mechanism).__name__}")
    if orientation is None:
        orientation = mechanism.default_orientation
    try:
        orientation = (float(orientation[0]), float(orientation[1]))
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"orientation must be (lo, hi) in rad; got {orientation!r}") from None
    if not (all(math.isfinite(v) for v in orientation) and orientation[0] <= orientation[1]):
        raise ValueError(f"orientation must be finite with lo <= hi (rad); got {orientation!r}")
    min_ic = float(min_inverse_condition)
    if not 0.0 <= min_ic < 1.0:
        raise ValueError(f"min_inverse_condition must be in [0, 1); got {min_inverse_condition!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    fixed = dict(fixed or {})
    unknown = set(fixed) - set(mechanism.pose_names)
    if unknown:
        raise ValueError(f"fixed names unknown pose variables {sorted(unknown)}; allowed: {mechanism.pose_names}")
    if resolution is None:
        resolution = default_resolution(mechanism, orientation, fixed, method)
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise ValueError(f"resolution must be an integer >= 1; got {resolution!r}")
    resolution = int(resolution)

    if method == "polar" and fixed:
        raise ValueError("fixed pose variables are not supported with method 'polar'")
    # the linear-margins cell rule: asked for, or the grid method's rule for this mechanism where
    # its grid samples 1 to 3 axes (a 6-D orientation workspace keeps one plane per cell)
    margins = method == "margins" or (
        method == "grid"
        and mechanism.cell_rule == "margins"
        and 1 <= len(sampled_axes(mechanism, orientation, fixed)) <= 3
    )
    if margins:
        _check_margins_method(mechanism, orientation, fixed)

    # exact sections (3-RPR): method "grid" integrates the section axis in closed form
    sections = method == "grid" and not return_samples and _has_sections(mechanism, fixed)
    if method == "polar":
        volume, (ic_mean, ic_min, ic_max), n_samples, n_inside, samples = _integrate_polar(
            mechanism, resolution, orientation, min_ic, length, return_samples
        )
    elif sections:
        volume, (ic_mean, ic_min, ic_max), n_samples, n_inside, samples = _integrate_sections(
            mechanism, resolution, orientation, min_ic, length
        )
    else:
        volume, (ic_mean, ic_min, ic_max), n_samples, n_inside, samples = _integrate_grid(
            mechanism,
            resolution,
            orientation,
            min_ic,
            length,
            fixed,
            return_samples,
            refine=method in FRACTION_METHODS,
            margins=margins,
        )
    volume_error = gdi_error = math.nan
    if error_estimate:
        # grid: the same integral at half the resolution (about the error of the coarser of the
        # two: an upper estimate for a convergent method, at 1/8 of the cost in 3-D; calibrated
        # in docs/accuracy.md);
        # midpoint: the same resolution on nodes shifted by half a cell, an independent sample
        # of its discretisation error; polar: half resolution
        if method == "polar":
            other_volume, (other_mean, _, _), *_ = _integrate_polar(
                mechanism, max(resolution // 2, 1), orientation, min_ic, length, False
            )
        elif sections:
            other_volume, (other_mean, _, _), *_ = _integrate_sections(
                mechanism, max(int(round(ERROR_RESOLUTION * resolution)), 2), orientation, min_ic, length
            )
        elif method in FRACTION_METHODS:
            other_volume, (other_mean, _, _), *_ = _integrate_grid(
                mechanism,
                max(int(round(ERROR_RESOLUTION * resolution)), 2),
                orientation,
                min_ic,
                length,
                fixed,
                False,
                margins=margins,
            )
        else:
            other_volume, (other_mean, _, _), *_ = _integrate_grid(
                mechanism, resolution, orientation, min_ic, length, fixed, False, offset=0.0, refine=False
            )
        volume_error = abs(volume - other_volume)
        gdi_error = abs(ic_mean - other_mean)
    reference = mechanism.reference_volume(orientation)
    unit = mechanism.volume_unit(orientation, fixed)
    return Evaluation(
        mechanism=mechanism.name,
        volume=float(volume),
        volume_error=float(volume_error),
        gdi=float(ic_mean),
        gdi_error=float(gdi_error),
        inverse_condition_min=float(ic_min),
        inverse_condition_max=float(ic_max),
        inverse_condition_mean=float(ic_mean),
        suri=float(volume / reference) if reference > 0 else 0.0,
        reference_volume=float(reference),
        n_samples=int(n_samples),
        n_inside=int(n_inside),
        resolution=resolution,
        orientation=orientation,
        min_inverse_condition=min_ic,
        method=method,
        volume_unit=unit,
        samples=None if samples is None else samples[0],
        inverse_conditions=None if samples is None else samples[1],
        inside=None if samples is None else samples[2],
        extent=None if samples is None or len(samples) < 4 else samples[3],
    )
