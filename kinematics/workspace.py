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

Integration: the midpoint rule on a regular grid with ``resolution`` points
per sampled axis (a deterministic, smooth-in-the-design objective). Where a
mechanism has an axis along which nothing but the actuator range changes
(H4: z, since all carriages slide along z and the Jacobian of eq. 33 does not
depend on z), that axis is integrated exactly from the feasible interval
(:meth:`~kinematics.base.Mechanism.invariant_axis_interval`). The error
estimate is the change against the same grid shifted by half a cell.
``method="polar"`` is the Tricept paper's boundary search (seed 001 Sec. 4.1).

Default orientation ranges (``orientation=None``) are the mechanism's
:attr:`~kinematics.base.Mechanism.default_orientation`: H4 theta in
[-pi/4, pi/4], Tricept psi and theta in [-pi/2, pi/2], 3-RPR phi in [15, 60] deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from kinematics.base import Mechanism
from kinematics.rows import row_all

#: poses evaluated per vectorised chunk (bounds memory, not a per-pose loop)
CHUNK = 1 << 17
METHODS = ("grid", "polar")


@dataclass(frozen=True)
class Evaluation:
    """Workspace volume and dexterity of one design (see module docstring for units)."""

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
def membership(mechanism: Mechanism, poses: np.ndarray, orientation: tuple[float, float],
               min_inverse_condition: float, length: float | None = None,
               reachable: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
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


def _within_orientation(mechanism: Mechanism, poses: np.ndarray,
                        orientation: tuple[float, float]) -> np.ndarray:
    """(N,) bool: every angular pose variable within ``orientation`` (rad)."""
    angular = np.asarray(mechanism.angular)
    if not angular.any():
        return np.ones(poses.shape[0], dtype=bool)
    ang = poses[:, angular]
    return row_all((ang >= orientation[0]) & (ang <= orientation[1]))


def _oriented_and_dexterous(mechanism: Mechanism, poses: np.ndarray, ic: np.ndarray,
                            orientation: tuple[float, float], min_inverse_condition: float
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
def _grid_axes(mechanism: Mechanism, resolution: int, orientation: tuple[float, float],
               fixed: dict[str, float], offset: float = 0.5, exact_axis: int | None = None,
               bounds: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[list[np.ndarray], float]:
    """Grid nodes per pose variable, and the cell measure.

    ``offset = 0.5`` gives the midpoint rule; another offset gives an
    interleaved grid of the same resolution (used for the error estimate).
    ``exact_axis`` is integrated analytically: it gets one placeholder node
    and does not enter the cell measure. ``bounds``: the mechanism's
    ``pose_bounds(orientation)`` when the caller has them already.
    """
    lo, hi = mechanism.pose_bounds(orientation) if bounds is None else bounds
    axes: list[np.ndarray] = []
    cell = 1.0
    for j, name in enumerate(mechanism.pose_names):
        if name in fixed:
            axes.append(np.array([float(fixed[name])]))
        elif mechanism.angular[j] and orientation[0] == orientation[1]:
            axes.append(np.array([float(orientation[0])]))
        elif j == exact_axis:
            axes.append(np.array([0.5 * (lo[j] + hi[j])]))
        else:
            width = max(float(hi[j] - lo[j]), 0.0)
            step = width / resolution
            axes.append(lo[j] + step * (np.arange(resolution) + offset))
            cell *= step
    return axes, cell


def _grid_poses(axes: list[np.ndarray], start: int, stop: int) -> np.ndarray:
    """Rows ``start:stop`` of the C-ordered Cartesian product of ``axes``."""
    shape = tuple(len(a) for a in axes)
    inner = math.prod(shape[1:])
    if start % inner == 0 and (stop % inner == 0 or stop == math.prod(shape)):
        # whole rows of the leading axis (the chunks of _chunk_bounds): broadcast each
        # axis into its column, ~20x faster than unravelling every row index
        block = [axes[0][start // inner:-(-stop // inner)], *axes[1:]]
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


def sampled_axes(mechanism: Mechanism, orientation: tuple[float, float],
                 fixed: dict[str, float] | None = None) -> list[str]:
    """Names of the pose variables that the grid samples (not fixed, not exact, not constant)."""
    fixed = fixed or {}
    exact = _exact_axis(mechanism, fixed)
    return [name for j, name in enumerate(mechanism.pose_names)
            if name not in fixed and j != exact
            and not (mechanism.angular[j] and orientation[0] == orientation[1])]


def default_resolution(mechanism: Mechanism, orientation: tuple[float, float] | None = None,
                       fixed: dict[str, float] | None = None) -> int:
    """Largest resolution whose grid has at most ``mechanism.default_nodes`` nodes.

    The node budgets (class attribute of each mechanism) keep a GA run of
    4,500 evaluations near a minute on 2 workers with a resolution error well
    under 1 % (benchmarks/evaluate.py).
    """
    if orientation is None:
        orientation = mechanism.default_orientation
    n_axes = max(len(sampled_axes(mechanism, orientation, fixed)), 1)
    nodes = int(mechanism.default_nodes)
    res = int(round(nodes ** (1.0 / n_axes)))
    while res > 1 and res**n_axes > nodes:
        res -= 1
    return res


def _integrate_grid(mechanism, resolution, orientation, min_ic, length, fixed, keep_samples,
                    offset=0.5):
    """Midpoint-rule integration; one axis exactly when the mechanism allows it.

    Each grid node carries a weight: 1, or, along an exact axis, the length of
    the node's feasible interval (clipped to the pose box). Volume is
    ``cell * sum(weight)`` over nodes inside the workspace and the GDI is the
    weighted mean of 1/kappa.
    """
    exact = _exact_axis(mechanism, fixed)
    box_lo, box_hi = mechanism.pose_bounds(orientation)
    axes, cell = _grid_axes(mechanism, resolution, orientation, fixed, offset, exact, (box_lo, box_hi))
    total = int(np.prod([len(a) for a in axes]))
    # the grid's angular nodes all lie in the orientation box (it spans the box): then the
    # fused path needs no per-node orientation test
    oriented = all(axis.min() >= orientation[0] and axis.max() <= orientation[1]
                   for axis, angular in zip(axes, mechanism.angular) if angular)
    weight_sum = ic_sum = 0.0
    n_inside = 0
    ic_min, ic_max = math.inf, -math.inf
    kept = []
    for start, stop in _chunk_bounds(axes):
        poses = _grid_poses(axes, start, stop)
        fused = None
        if exact is None:
            weight = np.ones(poses.shape[0])
            extent = None
        else:
            fused = mechanism.exact_axis_columns(poses, box_lo[exact], box_hi[exact], length)
            if fused is None:
                _, lower, upper = mechanism.invariant_axis_interval(poses)
                lower = np.maximum(lower, box_lo[exact])
                upper = np.minimum(upper, box_hi[exact])
            else:
                lower, upper, ic = fused
            weight = np.clip(upper - lower, 0.0, None)
            extent = None
            if fused is None or keep_samples:  # the fused path needs no pose along the axis
                # any z of the interval represents the column (1/kappa does not depend on it)
                feasible = weight > 0
                poses[feasible, exact] = 0.5 * (lower[feasible] + upper[feasible])
                extent = np.column_stack([lower, upper])
        if fused is not None:
            # ic is NaN wherever the axis interval is empty, so inside implies weight > 0
            inside, ic = ((_dexterous(ic, min_ic), ic) if oriented
                          else _oriented_and_dexterous(mechanism, poses, ic, orientation, min_ic))
        else:
            inside, ic = membership(mechanism, poses, orientation, min_ic, length,
                                    reachable=None if exact is None else weight > 0)
            inside &= weight > 0
        w = weight[inside]
        vals = ic[inside]
        n_inside += int(inside.sum())
        if vals.size:
            weight_sum += float(w.sum())
            ic_sum += float((w * vals).sum())
            ic_min = min(ic_min, float(vals.min()))
            ic_max = max(ic_max, float(vals.max()))
        if keep_samples:
            kept.append((poses, ic, inside) + (() if extent is None else (extent,)))
    volume = weight_sum * cell
    stats = (ic_sum / weight_sum, ic_min, ic_max) if weight_sum > 0 else (0.0, 0.0, 0.0)
    samples = tuple(np.concatenate(k) for k in zip(*kept)) if keep_samples else None
    return volume, stats, total, n_inside, samples


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
        samples = (np.concatenate(all_poses), np.concatenate(all_ic),
                   np.tile(boundary > 0, resolution))
    n_samples = int(inside_along.size + 30 * zz.size + resolution * zz.size)
    return volume, stats, n_samples, n_inside, samples


# --------------------------------------------------------------- evaluate
def evaluate(mechanism: Mechanism, *, resolution: int | None = None,
             orientation: tuple[float, float] | None = None,
             min_inverse_condition: float = 0.01, length: float | None = None,
             method: str = "grid", fixed: dict[str, float] | None = None,
             return_samples: bool = False, error_estimate: bool = True) -> Evaluation:
    """Workspace volume, GDI, SURI and 1/kappa statistics of one design.

    Parameters
    ----------
    mechanism : Mechanism
        The design (e.g. ``get_mechanism("h4", d=..., h=..., Qz=...)``).
    resolution : int, optional
        Grid points per sampled axis (larger is finer; doubling it refines
        every axis). Default :func:`default_resolution`: the node budget
        :attr:`~kinematics.base.Mechanism.default_nodes` spread over the sampled axes (H4 24, Tricept
        32, 3-RPR 32 over (x, y, phi) or 181 at constant phi, 2-RPR 400).
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
    method : {"grid", "polar"}
        Regular midpoint grid, or the Tricept paper's polar boundary search.
    fixed : dict, optional
        Pose variables held at a value (e.g. ``{"z": 0.0}`` for a slice);
        the volume is the measure over the others.
    return_samples : bool
        Keep the sampled poses, their 1/kappa and the inside mask (for plots).
    error_estimate : bool
        Also integrate on a grid shifted by half a cell (polar: at half the
        resolution) and report the change as ``volume_error``, ``gdi_error``.

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
        raise ValueError(f"fixed names unknown pose variables {sorted(unknown)}; "
                         f"allowed: {mechanism.pose_names}")
    if resolution is None:
        resolution = default_resolution(mechanism, orientation, fixed)
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 1:
        raise ValueError(f"resolution must be an integer >= 1; got {resolution!r}")
    resolution = int(resolution)

    if method == "polar" and fixed:
        raise ValueError("fixed pose variables are not supported with method 'polar'")

    if method == "polar":
        volume, (ic_mean, ic_min, ic_max), n_samples, n_inside, samples = _integrate_polar(
            mechanism, resolution, orientation, min_ic, length, return_samples)
    else:
        volume, (ic_mean, ic_min, ic_max), n_samples, n_inside, samples = _integrate_grid(
            mechanism, resolution, orientation, min_ic, length, fixed, return_samples)
    volume_error = gdi_error = math.nan
    if error_estimate:
        # grid: the same resolution on nodes shifted by half a cell, an
        # independent sample of the discretisation error; polar: half resolution
        if method == "polar":
            other_volume, (other_mean, _, _), *_ = _integrate_polar(
                mechanism, max(resolution // 2, 1), orientation, min_ic, length, False)
        else:
            other_volume, (other_mean, _, _), *_ = _integrate_grid(
                mechanism, resolution, orientation, min_ic, length, fixed, False, offset=0.0)
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
