"""Conformance harness: the properties every :class:`~kinematics.base.Mechanism` must have.

Run it on a mechanism class, built-in or from a user's own package::

    from kinematics.testing import check_mechanism, assert_conforms
    failures = check_mechanism(FiveBar)   # [] when it conforms
    assert_conforms(FiveBar)              # AssertionError listing every failure

Each failure is one line, ``"<check>: <what is wrong, with the numbers>"``;
the checks, in order (a failure of the first three stops the run, since the
later checks need a well-formed class, a buildable design and well-shaped
arrays; an exception the mechanism raises inside a check, whatever its type,
becomes that check's line, ``"<check>: raised <Type>: <message>"``):

``attributes``
    ``name`` (identifier), ``dof``, ``pose_names``, ``angular``, ``length_unit``,
    ``design_variables`` (each with a unit and finite ``lower < upper``),
    ``default_fixed`` (a dict), ``default_nodes``, ``min_resolution``, ``grid_nodes`` (None or int).
``build``
    The design box's centre builds with ``default_fixed``; so does every
    design with one variable at a bound and the others at the centre (the
    optimisers evaluate such designs); ``params()`` rebuilds the same
    mechanism; the design pickles (worker processes receive designs so).
``shapes``
    ``inverse`` (N, dof), ``jacobian`` (N, dof, dof), ``inverse_condition``
    (N,), ``forward`` (k, dof), a single pose gives a batch of one; the
    geometry (``pose_bounds``, ``actuator_range``, ``reference_volume``,
    ``characteristic_length``, ``default_orientation``) well formed.
``batch``
    Row k of a batch equals pose k alone (inverse, jacobian, inverse_condition).
``ik-fk``
    ``forward(inverse(x))`` contains ``x`` (angles modulo 2 pi) for reachable poses.
``jacobian``
    ``jacobian`` equals central differences of ``inverse`` (relative 1e-5 of the largest entry).
``pose-bounds``
    Poses reached by ``forward(q)`` for ``q`` drawn in ``actuator_range``
    (within the joint limits and the orientation range) lie inside ``pose_bounds``.
``margins``
    Where the class states reachability margins
    (:meth:`~kinematics.base.Mechanism.constraint_margins`, or per column of an exact axis
    :meth:`~kinematics.base.Mechanism.exact_axis_margins`): one row per pose, all
    ``>= 0`` exactly where the pose (column) is reachable, and the compiled path, if any,
    gives the numpy reference's margins.
``transverse-extent``
    Where the class states :meth:`~kinematics.base.Mechanism.transverse_extent` (it has exact
    sections): one ``(lower, upper)`` pair per orientation, and every reachable pose drawn in
    the pose box lies within its orientation's extent (none where the extent is empty: NaN).
``workspace``
    The centre design's workspace (:func:`kinematics.workspace.evaluate` at
    ``min_resolution``) is not empty, the compiled path, if the class
    has one, gives the numpy reference's volume and GDI on the cell grid, and
    exact sections, if the class has them, agree with the cell grid.
``design-variables``
    Moving each design variable (others at the centre) changes the volume,
    GDI or SURI.

Sizes are tiny (8 reachable poses, the coarsest accepted grid): 0.01-0.06 s
of CPU time per built-in mechanism, the Tricept 1.2 s (its forward
kinematics), warm (``python -m benchmarks.external``).
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable

import numpy as np

from kinematics import kernels
from kinematics.base import DesignVariable, Mechanism
from kinematics.plugins import one_line as _one_line
from kinematics.workspace import evaluate, section_axes

#: relative tolerance of the IK∘FK round trip (pose units)
ROUND_TRIP_RTOL = 1e-6
#: tolerance of the analytic Jacobian against central differences, relative to its largest entry
JACOBIAN_RTOL = 1e-5
#: poses closer than this to a singularity (1/kappa) are left out of IK∘FK and the Jacobian check
SINGULAR_IC = 1e-3
#: a design variable "acts" when it changes V, GDI or SURI by more than this (relative)
ACTS_RTOL = 1e-6
#: compiled and numpy paths must give the same V and GDI to this relative tolerance
COMPILED_RTOL = 1e-9
#: a mechanism's exact sections and the cell grid (two independent integrations of the same
#: workspace, at the coarsest accepted resolution) must agree in V, GDI and SURI to this (they
#: agree to 0.18 % (2-RPR) and 0.05 % (3-RPR GDI, rows over each layer's extent) on the centre designs)
SECTIONS_RTOL = 0.005


class _Stop(Exception):
    """A failure that leaves the later checks without input (bad attributes, no design, bad shapes)."""


def _fmt(values: np.ndarray) -> str:
    return np.array2string(np.asarray(values, dtype=float), precision=6, separator=", ", max_line_width=10_000)


# ------------------------------------------------------------------ checks
def _check_attributes(cls: type[Mechanism]) -> list[str]:
    out = []
    name = getattr(cls, "name", None)
    if not (isinstance(name, str) and name.isidentifier()):
        out.append(f"attributes: name must be an identifier string (the registry name); got {name!r}")
    dof = getattr(cls, "dof", None)
    if isinstance(dof, bool) or not isinstance(dof, int) or dof < 1:
        out.append(f"attributes: dof must be an integer >= 1; got {dof!r}")
        return out  # the per-column attributes cannot be checked
    pose_names = getattr(cls, "pose_names", None)
    if not (
        isinstance(pose_names, tuple)
        and len(pose_names) == dof
        and all(isinstance(n, str) and n for n in pose_names)
        and len(set(pose_names)) == dof
    ):
        out.append(f"attributes: pose_names must be a tuple of {dof} distinct names; got {pose_names!r}")
    angular = getattr(cls, "angular", None)
    if not (isinstance(angular, tuple) and len(angular) == dof and all(isinstance(a, bool) for a in angular)):
        out.append(f"attributes: angular must be a tuple of {dof} bools; got {angular!r}")
    unit = getattr(cls, "length_unit", None)
    if not (isinstance(unit, str) and unit.strip()):
        out.append(f"attributes: length_unit must be a non-empty string (e.g. 'mm'); got {unit!r}")
    variables = getattr(cls, "design_variables", ())
    if not (isinstance(variables, tuple) and variables and all(isinstance(v, DesignVariable) for v in variables)):
        out.append(
            "attributes: design_variables must be a non-empty tuple of kinematics.base.DesignVariable; "
            f"got {variables!r}"
        )
    else:
        names = [v.name for v in variables]
        if len(set(names)) != len(names):
            out.append(f"attributes: design variable names must be distinct; got {names}")
        for v in variables:
            if not (isinstance(v.unit, str) and v.unit.strip()):
                out.append(f"attributes: design variable '{v.name}' declares no unit")
            if not (math.isfinite(v.lower) and math.isfinite(v.upper) and v.lower < v.upper):
                out.append(
                    f"attributes: design variable '{v.name}' needs finite lower < upper; got [{v.lower}, {v.upper}]"
                )
    fixed = getattr(cls, "default_fixed", None)
    if not isinstance(fixed, dict):
        out.append(f"attributes: default_fixed must be a dict; got {fixed!r}")
    elif isinstance(variables, tuple):
        both = sorted(set(fixed) & {getattr(v, "name", None) for v in variables})
        if both:
            out.append(f"attributes: default_fixed names design variables {both}")
    if isinstance(fixed, dict):
        # the pipeline takes each fixed parameter's default and range from fixed_parameters only
        declared = {getattr(p, "name", None) for p in getattr(cls, "fixed_parameters", ())}
        undeclared = sorted(set(fixed) - declared)
        if undeclared:
            out.append(
                f"attributes: default_fixed {undeclared} without a FixedParameter in fixed_parameters "
                "(kinematics.base.FixedParameter: default, range, unit; the pipeline refuses the mechanism)"
            )
    for attr in ("default_nodes", "min_resolution"):
        value = getattr(cls, attr, None)
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            out.append(f"attributes: {attr} must be an integer >= 1; got {value!r}")
    grid_nodes = getattr(cls, "grid_nodes", None)
    if grid_nodes is not None and (isinstance(grid_nodes, bool) or not isinstance(grid_nodes, int) or grid_nodes < 1):
        out.append(f"attributes: grid_nodes must be None or an integer >= 1; got {grid_nodes!r}")
    return out


def _design_box(cls: type[Mechanism]) -> tuple[np.ndarray, np.ndarray]:
    lower = np.array([v.lower for v in cls.design_variables], dtype=float)
    upper = np.array([v.upper for v in cls.design_variables], dtype=float)
    return lower, upper


def _build(cls: type[Mechanism], design: np.ndarray) -> Mechanism:
    return cls.from_design(design, **dict(cls.default_fixed))


def _check_build(cls: type[Mechanism]) -> tuple[Mechanism, list[str]]:
    lower, upper = _design_box(cls)
    centre = 0.5 * (lower + upper)
    try:
        mech = _build(cls, centre)
    except Exception as exc:
        raise _Stop(
            f"build: the design box's centre {_fmt(centre)} with default_fixed does not build: {_one_line(exc)}"
        ) from None
    if not isinstance(mech, cls):
        raise _Stop(f"build: from_design returned {type(mech).__name__}, not {cls.__name__}")
    out = []
    for j, var in enumerate(cls.design_variables):
        for bound, value in (("lower", lower[j]), ("upper", upper[j])):
            design = centre.copy()
            design[j] = value
            try:
                _build(cls, design)
            except Exception as exc:
                out.append(
                    f"build: design with '{var.name}' at its {bound} bound {value:g} (others at the "
                    f"centre) does not build: {_one_line(exc)}"
                )
    try:
        again = cls(**mech.params())
        poses = _box_samples(mech, 4, np.random.default_rng(0))
        if not np.array_equal(again.inverse(poses), mech.inverse(poses), equal_nan=True):
            out.append("build: cls(**params()) builds a different mechanism (inverse kinematics differ)")
    except Exception as exc:
        out.append(f"build: cls(**params()) does not rebuild the design: {_one_line(exc)}")
    try:
        pickle.loads(pickle.dumps(mech))
    except Exception as exc:
        out.append(f"build: the design does not pickle (worker processes need it): {_one_line(exc)}")
    return mech, out


def _box_samples(mech: Mechanism, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` uniform poses (n, dof) in ``pose_bounds(default_orientation)``."""
    lo, hi = (np.asarray(b, dtype=float) for b in mech.pose_bounds(mech.default_orientation))
    return lo + (hi - lo) * rng.random((n, mech.dof))


def _reachable(mech: Mechanism, poses: np.ndarray) -> np.ndarray:
    """(N,) bool: within the actuator range, the joint limits and the default orientation range."""
    q = mech.inverse(poses)
    q_lo, q_hi = mech.actuator_range
    with np.errstate(invalid="ignore"):
        ok = np.all((q >= q_lo) & (q <= q_hi), axis=1)
    angular = np.asarray(mech.angular)
    if angular.any():
        lo, hi = mech.default_orientation
        ok &= np.all((poses[:, angular] >= lo) & (poses[:, angular] <= hi), axis=1)
    idx = np.nonzero(ok)[0]
    ok[idx] = mech.within_joint_limits(poses[idx])
    return ok


def _check_shapes(mech: Mechanism, rng: np.random.Generator, n_box: int) -> np.ndarray:
    """Shapes of every public result (raises :class:`_Stop` at the first wrong one); returns the
    poses (n_box, dof) it drew in ``pose_bounds``."""
    dof = mech.dof

    def expect(what: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
        arr = np.asarray(value)
        if arr.shape != shape:
            raise _Stop(f"shapes: {what} has shape {arr.shape}; expected {shape}")
        return arr

    def geometry(what: str, get: Callable[[], object], shape: tuple[int, ...]) -> np.ndarray:
        try:
            value = np.asarray(get(), dtype=float)
        except Exception as exc:
            raise _Stop(f"shapes: {what} raised {_one_line(exc)}") from None
        value = expect(what, value, shape)
        if not np.all(np.isfinite(value)):
            raise _Stop(f"shapes: {what} is not finite: {_fmt(value)}")
        return value

    orientation = geometry("default_orientation", lambda: mech.default_orientation, (2,))
    if orientation[0] > orientation[1]:
        raise _Stop(f"shapes: default_orientation must have lo <= hi (rad); got {_fmt(orientation)}")
    lo = geometry("pose_bounds(default_orientation)[0]", lambda: mech.pose_bounds(mech.default_orientation)[0], (dof,))
    hi = geometry("pose_bounds(default_orientation)[1]", lambda: mech.pose_bounds(mech.default_orientation)[1], (dof,))
    if np.any(lo > hi):
        raise _Stop(f"shapes: pose_bounds lower {_fmt(lo)} exceeds upper {_fmt(hi)}")
    q_lo = expect("actuator_range[0]", mech.actuator_range[0], (dof,))
    q_hi = expect("actuator_range[1]", mech.actuator_range[1], (dof,))
    if not np.all(q_lo < q_hi):
        raise _Stop(f"shapes: actuator_range needs lower < upper; got {_fmt(q_lo)}, {_fmt(q_hi)}")
    for what, value in (
        (
            "reference_volume(default_orientation)",
            geometry("reference_volume", lambda: mech.reference_volume(mech.default_orientation), ()),
        ),
        ("characteristic_length", geometry("characteristic_length", lambda: mech.characteristic_length, ())),
    ):
        if not value > 0:
            raise _Stop(f"shapes: {what} must be > 0; got {float(value)}")
    unit = mech.volume_unit()
    if not (isinstance(unit, str) and unit):
        raise _Stop(f"shapes: volume_unit() must be a non-empty string; got {unit!r}")

    poses = _box_samples(mech, n_box, rng)
    expect(f"inverse of {n_box} poses", mech.inverse(poses), (n_box, dof))
    expect(f"jacobian of {n_box} poses", mech.jacobian(poses), (n_box, dof, dof))
    expect(f"inverse_condition of {n_box} poses", mech.inverse_condition(poses), (n_box,))
    expect("inverse of one 1-D pose", mech.inverse(poses[0]), (1, dof))
    reachable = poses[_reachable(mech, poses)]
    if len(reachable):
        sols = np.asarray(mech.forward(mech.inverse(reachable[:1])[0]))
        if sols.ndim != 2 or sols.shape[1] != dof:
            raise _Stop(f"shapes: forward(q) has shape {sols.shape}; expected (k, {dof})")
    return poses


def _check_batch(mech: Mechanism, poses: np.ndarray) -> list[str]:
    poses = np.vstack([poses, np.full((1, mech.dof), np.nan)])
    out = []
    for what, method in (
        ("inverse", mech.inverse),
        ("jacobian", mech.jacobian),
        ("inverse_condition", mech.inverse_condition),
    ):
        batch = method(poses)
        bad = [
            k for k in range(len(poses)) if not np.array_equal(method(poses[k : k + 1])[0], batch[k], equal_nan=True)
        ]
        if bad:
            k = bad[0]
            out.append(
                f"batch: {what} of pose {k} alone differs from row {k} of a batch of {len(poses)} "
                f"({len(bad)} rows differ), pose {_fmt(poses[k])}"
            )
    return out


def _check_round_trip(mech: Mechanism, poses: np.ndarray) -> list[str]:
    angular = np.asarray(mech.angular)
    misses = []
    for pose in poses:
        q = mech.inverse(pose)[0]
        sols = mech.forward(q)
        if len(sols) == 0:
            misses.append((pose, math.inf))
            continue
        diff = sols - pose
        diff[:, angular] = np.angle(np.exp(1j * diff[:, angular]))  # angles modulo 2 pi
        error = float(np.min(np.max(np.abs(diff) / (1.0 + np.abs(pose)), axis=1)))
        if not error <= ROUND_TRIP_RTOL:
            misses.append((pose, error))
    if not misses:
        return []
    pose, error = misses[0]
    return [
        f"ik-fk: forward(inverse(x)) does not contain x at {len(misses)} of {len(poses)} reachable "
        f"poses, e.g. x = {_fmt(pose)} (nearest solution off by {error:.3g} relative, "
        f"tolerance {ROUND_TRIP_RTOL:g})"
    ]


def central_differences(mech: Mechanism, poses: np.ndarray, relative_step: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian of ``mech.inverse`` at ``poses`` (N, dof), shape (N, dof, dof).

    Step ``relative_step * (1 + |x_j|)`` per pose variable (in its unit);
    entry ``[n, i, j]`` approximates ``d q_i / d x_j`` like :meth:`Mechanism.jacobian`.
    """
    poses = np.asarray(poses, dtype=float)
    step = relative_step * (1.0 + np.abs(poses))
    fd = np.empty((poses.shape[0], mech.dof, mech.dof))
    for j in range(mech.dof):
        dp = np.zeros_like(poses)
        dp[:, j] = step[:, j]
        fd[:, :, j] = (mech.inverse(poses + dp) - mech.inverse(poses - dp)) / (2 * step[:, [j]])
    return fd


def _check_jacobian(mech: Mechanism, poses: np.ndarray) -> list[str]:
    jac = mech.jacobian(poses)
    fd = central_differences(mech, poses)
    scale = np.abs(jac).max(axis=(1, 2))
    with np.errstate(invalid="ignore"):
        rel = np.abs(fd - jac).max(axis=(1, 2)) / scale
    bad = np.nonzero(~(rel <= JACOBIAN_RTOL))[0]
    if not bad.size:
        return []
    n = bad[np.argmax(np.nan_to_num(rel[bad], nan=np.inf))]
    i, j = np.unravel_index(np.argmax(np.nan_to_num(np.abs(fd[n] - jac[n]), nan=np.inf)), jac[n].shape)
    return [
        f"jacobian: J differs from central differences of inverse() at {bad.size} of {len(poses)} poses, "
        f"e.g. at {_fmt(poses[n])} entry d{i}/d{mech.pose_names[j]}: analytic {jac[n, i, j]:.6g}, "
        f"finite-difference {fd[n, i, j]:.6g} (relative {rel[n]:.3g}, tolerance {JACOBIAN_RTOL:g})"
    ]


def _check_pose_bounds(mech: Mechanism, rng: np.random.Generator, n_actuators: int) -> list[str]:
    q_lo, q_hi = (np.asarray(b, dtype=float) for b in mech.actuator_range)
    lo, hi = (np.asarray(b, dtype=float) for b in mech.pose_bounds(mech.default_orientation))
    slack = 1e-9 * (1.0 + np.maximum(np.abs(lo), np.abs(hi)))
    reached = []
    for q in q_lo + (q_hi - q_lo) * rng.random((n_actuators, mech.dof)):
        sols = mech.forward(q)
        if len(sols):
            reached.append(sols[_reachable(mech, sols)])
    poses = np.concatenate(reached) if reached else np.empty((0, mech.dof))
    outside = np.nonzero(np.any((poses < lo - slack) | (poses > hi + slack), axis=1))[0]
    if not outside.size:
        return []
    pose = poses[outside[0]]
    cols = [mech.pose_names[j] for j in range(mech.dof) if not lo[j] - slack[j] <= pose[j] <= hi[j] + slack[j]]
    return [
        f"pose-bounds: {outside.size} of {len(poses)} poses reached by forward(q) lie outside pose_bounds, "
        f"e.g. {_fmt(pose)} in {cols} (bounds {_fmt(lo)} .. {_fmt(hi)})"
    ]


def _margins_and_reach(mech: Mechanism, poses: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
    """The stated margins of ``poses`` (None: none) and whether each is reachable (actuator range,
    joint limits; for an exact axis: the column's interval non-empty within the pose box)."""
    probe = mech.invariant_axis_interval(poses[:1])
    if probe is None:
        q = mech.inverse(poses)
        q_lo, q_hi = mech.actuator_range
        with np.errstate(invalid="ignore"):
            reach = np.all((q >= q_lo) & (q <= q_hi), axis=1)
        return mech.constraint_margins(poses), reach & mech.within_joint_limits(poses)
    axis = probe[0]
    lo, hi = mech.pose_bounds(mech.default_orientation)
    _, lower, upper = mech.invariant_axis_interval(poses)
    reach = np.minimum(upper, hi[axis]) > np.maximum(lower, lo[axis])
    return mech.exact_axis_margins(poses, lo[axis], hi[axis]), reach & mech.within_joint_limits(poses)


def _check_margins(mech: Mechanism, poses: np.ndarray) -> list[str]:
    margins, reach = _margins_and_reach(mech, poses)
    if margins is None:
        return []
    margins = np.asarray(margins, dtype=float)
    if margins.ndim != 2 or margins.shape[0] != poses.shape[0]:
        return [f"margins: expected one row per pose, shape ({poses.shape[0]}, K); got {margins.shape}"]
    with np.errstate(invalid="ignore"):
        says = np.all(margins >= 0, axis=1)
    wrong = np.nonzero(says != reach)[0]
    out = []
    if wrong.size:
        k = wrong[0]
        out.append(
            f"margins: {wrong.size} of {poses.shape[0]} poses disagree with reachability, e.g. pose "
            f"{_fmt(poses[k])}: reachable {bool(reach[k])}, margins {_fmt(margins[k])}"
        )
    with kernels.reference_kernels():
        reference, _ = _margins_and_reach(mech, poses)
    if not np.allclose(margins, reference, rtol=COMPILED_RTOL, atol=1e-9, equal_nan=True):
        out.append("margins: the compiled path's margins differ from the numpy reference's")
    return out


def _check_transverse_extent(mech: Mechanism, poses: np.ndarray) -> list[str]:
    """The stated extent along the transverse axis of the sections holds every reachable pose
    of ``poses`` (N, dof) at its orientation (slack 1e-9 of the extent's size)."""
    angular = [j for j in range(mech.dof) if mech.angular[j]]
    angles = poses[:, angular[0]] if angular else np.full(poses.shape[0], float(mech.default_orientation[0]))
    extent = mech.transverse_extent(angles)
    if extent is None:
        return []
    try:
        across_axis, _ = section_axes(mech)
    except ValueError as exc:
        return [f"transverse-extent: stated, but {exc}"]
    lower, upper = (np.asarray(e, dtype=float) for e in extent)
    if lower.shape != angles.shape or upper.shape != angles.shape:
        return [
            f"transverse-extent: expected (lower, upper) of shape {angles.shape} for {angles.size} "
            f"orientations; got {lower.shape} and {upper.shape}"
        ]
    across = poses[:, across_axis]
    slack = 1e-9 * (1.0 + np.abs(lower) + np.abs(upper))
    with np.errstate(invalid="ignore"):
        within = (across >= lower - slack) & (across <= upper + slack)
    outside = np.nonzero(_reachable(mech, poses) & ~within)[0]
    if not outside.size:
        return []
    k = outside[0]
    return [
        f"transverse-extent: {outside.size} reachable poses lie outside their orientation's extent, e.g. "
        f"pose {_fmt(poses[k])}: {mech.pose_names[across_axis]} outside [{lower[k]:.6g}, {upper[k]:.6g}]"
    ]


def _evaluation(mech: Mechanism, resolution: int, cells: bool = False) -> np.ndarray:
    """(V, GDI, SURI) by ``evaluate``; ``cells``: on the cut-cell grid even where the mechanism
    has exact sections (``return_samples`` takes the grid, whose samples are the plot's)."""
    ev = evaluate(mech, resolution=resolution, error_estimate=False, return_samples=cells)
    return np.array([ev.volume, ev.gdi, ev.suri])


def _check_workspace(mech: Mechanism, resolution: int) -> tuple[np.ndarray, list[str]]:
    values = _evaluation(mech, resolution)
    if not values[0] > 0:
        raise _Stop(
            f"workspace: the centre design's workspace is empty at resolution {resolution} "
            f"(volume {values[0]:g} {mech.volume_unit()})"
        )
    sections = mech.section_axis is not None
    grid = _evaluation(mech, resolution, cells=True) if sections else values
    with kernels.reference_kernels():
        reference = _evaluation(mech, resolution, cells=sections)
    if not np.allclose(grid, reference, rtol=COMPILED_RTOL, atol=0.0):
        return values, [
            f"workspace: the compiled path gives (V, GDI, SURI) {_fmt(grid)}, the numpy reference "
            f"{_fmt(reference)} (resolution {resolution})"
        ]
    if sections and not np.allclose(values, grid, rtol=SECTIONS_RTOL, atol=0.0):
        return values, [
            f"workspace: the exact sections give (V, GDI, SURI) {_fmt(values)}, the cell grid "
            f"{_fmt(grid)} (resolution {resolution}; allowed relative difference {SECTIONS_RTOL:g})"
        ]
    return values, []


def _check_design_variables(cls: type[Mechanism], centre_values: np.ndarray, resolution: int) -> list[str]:
    lower, upper = _design_box(cls)
    centre = 0.5 * (lower + upper)
    out = []
    for j, var in enumerate(cls.design_variables):
        changes = []
        for fraction in (0.25, 0.75):
            design = centre.copy()
            design[j] = lower[j] + fraction * (upper[j] - lower[j])
            values = _evaluation(_build(cls, design), resolution)
            changes.append(np.max(np.abs(values - centre_values) / np.maximum(np.abs(centre_values), 1e-300)))
        if not max(changes) > ACTS_RTOL:
            out.append(
                f"design-variables: '{var.name}' moved to 25 % and 75 % of [{var.lower:g}, {var.upper:g}] "
                f"{var.unit} changes volume, GDI and SURI by at most {max(changes):.3g} relative "
                f"(resolution {resolution}); it does nothing"
            )
    return out


# ------------------------------------------------------------------ public
def check_mechanism(
    cls: type[Mechanism], *, seed: int = 0, n_poses: int = 8, resolution: int | None = None
) -> list[str]:
    """Run every conformance check on a mechanism class; one line per failure.

    Parameters
    ----------
    cls : type
        A :class:`~kinematics.base.Mechanism` subclass.
    seed : int
        Seed of the sampled poses and actuator values.
    n_poses : int
        Reachable poses used by the batch, IK∘FK and Jacobian checks (and
        actuator vectors for the pose-bounds check), >= 1.
    resolution : int, optional
        Grid resolution of the workspace checks; default the class's
        ``min_resolution`` (the coarsest the pipeline accepts).

    Returns
    -------
    list of str
        ``"<check>: <what is wrong>"`` per failure (see the module
        docstring for the checks); empty when the class conforms.
    """
    if not (isinstance(cls, type) and issubclass(cls, Mechanism)):
        return [f"attributes: {cls!r} is not a subclass of kinematics.base.Mechanism"]
    if isinstance(n_poses, bool) or not isinstance(n_poses, int) or n_poses < 1:
        raise ValueError(f"n_poses must be an integer >= 1; got {n_poses!r}")
    failures = _check_attributes(cls)
    if failures:
        return failures
    rng = np.random.default_rng(seed)
    res = int(resolution if resolution is not None else cls.min_resolution)
    try:
        mech, failures = _check_build(cls)
        box = _check_shapes(mech, rng, 64 * n_poses)
        reachable = box[_reachable(mech, box)]
        with np.errstate(invalid="ignore"):
            reachable = reachable[mech.inverse_condition(reachable) > SINGULAR_IC][:n_poses]
        if not len(reachable):
            raise _Stop(
                f"shapes: none of {len(box)} poses drawn in pose_bounds(default_orientation) is "
                f"reachable away from singularities (1/kappa > {SINGULAR_IC:g})"
            )
    except _Stop as stop:
        return failures + [str(stop)]
    except Exception as exc:
        return failures + [f"shapes: raised {_one_line(exc)}"]

    steps: list[tuple[str, Callable[[], list[str]]]] = [
        ("batch", lambda: _check_batch(mech, np.vstack([reachable, box[:n_poses]]))),
        ("ik-fk", lambda: _check_round_trip(mech, reachable)),
        ("jacobian", lambda: _check_jacobian(mech, reachable)),
        ("pose-bounds", lambda: _check_pose_bounds(mech, rng, 2 * n_poses)),
        ("margins", lambda: _check_margins(mech, box)),
        ("transverse-extent", lambda: _check_transverse_extent(mech, box)),
    ]
    for name, step in steps:
        try:
            failures += step()
        except Exception as exc:
            failures.append(f"{name}: raised {_one_line(exc)}")
    try:
        centre_values, workspace_failures = _check_workspace(mech, res)
        failures += workspace_failures
        failures += _check_design_variables(cls, centre_values, res)
    except _Stop as stop:
        failures.append(str(stop))
    except Exception as exc:
        failures.append(f"workspace: raised {_one_line(exc)}")
    return failures


def assert_conforms(cls: type[Mechanism], *, seed: int = 0, n_poses: int = 8, resolution: int | None = None) -> None:
    """Raise ``AssertionError`` listing every failure of :func:`check_mechanism` (same parameters)."""
    failures = check_mechanism(cls, seed=seed, n_poses=n_poses, resolution=resolution)
    if failures:
        name = getattr(cls, "__qualname__", repr(cls))
        raise AssertionError(f"{name} fails {len(failures)} conformance check(s):\n" + "\n".join(failures))


__all__ = ["assert_conforms", "central_differences", "check_mechanism"]
