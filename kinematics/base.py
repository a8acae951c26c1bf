"""The small vectorised interface every mechanism implements.

Each mechanism is a subclass of :class:`Mechanism`. The public methods check
their input (shape, dtype) and delegate to private vectorised kernels
(``_inverse``, ``_jacobian``, ``_forward``), in the style of pymoo's
checked-public / private-kernel split.

Conventions (all mechanisms)
----------------------------
* Rows are samples: poses have shape ``(N, dof)``, actuator values
  ``(N, dof)``, Jacobians ``(N, dof, dof)``. A 1-D pose of length ``dof`` is
  accepted and treated as ``N = 1``; the result is still a batch.
* Angles are in radians; lengths in the unit of the mechanism's paper (cm for
  H4, mm for the others).
* ``jacobian`` is the *inverse-kinematic* Jacobian ``J`` with
  ``q_dot = J @ x_dot`` (the papers' ``J_q^-1 J_x``).
* ``inverse_condition`` is ``1/kappa`` of the dimensionally homogeneous
  Jacobian: every angular column of ``J`` is divided by a characteristic
  length ``L`` (seed 001 eq. 37; seed 000 Sec. 4.2), so that all singular
  values carry the same unit.
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from kinematics import kernels
from kinematics.algebra import newton_polish, unique_rows, wrap_angle
from kinematics.conditioning import inverse_condition_number

#: the cell rules of ``method="grid"`` a mechanism may declare (:attr:`Mechanism.cell_rule`)
CELL_RULES = ("planes", "margins")

#: poses per block of the compiled Jacobian + conditioning path (see ``Mechanism._blocked``)
CONDITIONING_BLOCK = 8192


def _filling_default_fixed(from_design):
    """``from_design`` (a subclass's own) called with the omitted fixed parameters at their
    defaults (:meth:`Mechanism.with_default_fixed`), so no mechanism repeats its defaults there."""

    @functools.wraps(from_design)
    def wrapper(cls, design, **fixed):
        return from_design(cls, design, **cls.with_default_fixed(fixed))

    wrapper._fills_default_fixed = True
    return wrapper


class Mechanism(ABC):
    """Abstract base of a parallel mechanism with ``dof`` actuators and pose variables.

    Subclasses set the class attributes and implement the private kernels.
    """

    #: registry name, e.g. ``"h4"``
    name: ClassVar[str]
    #: number of actuators == number of pose variables
    dof: ClassVar[int]
    #: names of the pose variables, in column order
    pose_names: ClassVar[tuple[str, ...]]
    #: which pose variables are angles (radians); the others are lengths
    angular: ClassVar[tuple[bool, ...]]
    #: unit of every length of this mechanism
    length_unit: ClassVar[str]

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        if cls.cell_rule not in CELL_RULES:
            raise TypeError(f"{cls.__name__}.cell_rule must be one of {CELL_RULES}; got {cls.cell_rule!r}")
        # one source: the defaults of mechanism.fixed come from the declared parameters
        if "fixed_parameters" in cls.__dict__:
            cls.default_fixed = {p.name: p.default for p in cls.fixed_parameters}
        # one place for the documented defaults: a class's own from_design gets every fixed
        # parameter its caller omits at its declared default (a caller of the library API gives
        # the design variables alone, as the pipeline's mechanism.fixed would fill the rest)
        own = cls.__dict__.get("from_design")
        if isinstance(own, classmethod) and not getattr(own.__func__, "_fills_default_fixed", False):
            cls.from_design = classmethod(_filling_default_fixed(own.__func__))

    # ------------------------------------------------------------------ checks
    def _check_poses(self, poses: np.ndarray) -> np.ndarray:
        arr = np.asarray(poses, dtype=float)
        if arr.ndim == 1 and arr.shape[0] == self.dof:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise ValueError(
                f"{self.name}: poses must have shape (N, {self.dof}) with columns "
                f"{self.pose_names}; got shape {np.shape(poses)}"
            )
        return arr

    def _check_actuators(self, q: np.ndarray) -> np.ndarray:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.dof,):
            raise ValueError(f"{self.name}: actuator vector must have shape ({self.dof},); got shape {np.shape(q)}")
        return arr

    # ------------------------------------------------------------ public API
    def inverse(self, poses: np.ndarray) -> np.ndarray:
        """Actuator values of each pose (inverse kinematics).

        Parameters
        ----------
        poses : array_like, shape (N, dof)
            Poses in the base frame, columns :attr:`pose_names`.

        Returns
        -------
        ndarray, shape (N, dof)
            Actuator values (lengths in :attr:`length_unit`); a row of NaN where
            the pose has no real solution. Never raises or warns for such poses.
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self._inverse(poses)

    def forward(self, q: np.ndarray) -> np.ndarray:
        """All real poses that give the actuator values ``q`` (forward kinematics).

        Parameters
        ----------
        q : array_like, shape (dof,)
            One actuator vector.

        Returns
        -------
        ndarray, shape (k, dof)
            Every real pose ``x`` with ``inverse(x) == q`` (``k`` may be 0), sorted
            lexicographically by the pose columns so the order is deterministic.
        """
        q = self._check_actuators(q)
        if not np.all(np.isfinite(q)):
            return np.empty((0, self.dof))
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            sols = self._forward(q)
            # keep the poses whose inverse kinematics (on the branch `inverse`
            # uses) gives back q: the polynomial routes also find the other
            # branches, and a negative length squares to a valid constraint
            back = self._inverse(sols) if len(sols) else sols
        same = np.all(np.abs(back - q) <= 1e-7 * (1.0 + np.abs(q)), axis=1)
        return sort_poses(sols[same])

    def jacobian(self, poses: np.ndarray) -> np.ndarray:
        """Analytic inverse-kinematic Jacobian ``J`` with ``q_dot = J @ x_dot``.

        Parameters
        ----------
        poses : array_like, shape (N, dof)

        Returns
        -------
        ndarray, shape (N, dof, dof)
            ``J[n, i, j] = d q_i / d x_j`` at pose ``n``; units length/length for
            translational columns and length/rad for angular ones. NaN where the
            pose is unreachable, +-inf where the actuator Jacobian is singular.
        """
        poses = self._check_poses(poses)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return self._jacobian(poses)

    def inverse_condition(self, poses: np.ndarray, length: float | None = None) -> np.ndarray:
        """Inverse condition number ``1/kappa`` of the homogenised Jacobian.

        ``kappa = sigma_max / sigma_min`` (seed 000 eq. 35) of ``J @ diag(s)`` with
        ``s_j = 1/length`` for angular pose variables and 1 otherwise.

        Parameters
        ----------
        poses : array_like, shape (N, dof)
        length : float, optional
            Characteristic length in :attr:`length_unit`; ``None`` uses
            :attr:`characteristic_length`.

        Returns
        -------
        ndarray, shape (N,)
            Values in [0, 1]: 1 is isotropic, 0 singular; NaN where unreachable.
        """
        poses = self._check_poses(poses)
        scale = self.angular_scale(length)
        compiled = self._blocked(self._compiled_jacobian, poses, scale) if kernels.compiled() else None
        if compiled is not None:
            return compiled
        jac = self.jacobian(poses)
        return inverse_condition_number(jac, scale)

    def _blocked(self, jacobian_kernel, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray | None:
        """``1/kappa`` (N,) of ``jacobian_kernel(poses, column_scale)``, :data:`CONDITIONING_BLOCK`
        poses at a time; None when the kernel is (None: no compiled path).

        Why blocks: each block's Jacobians (128 bytes a pose for 4 x 4) stay in
        the core's cache between the kernel that writes them and the
        conditioning that reads them.
        """
        out = np.empty(poses.shape[0])
        ones = np.ones(self.dof)
        for start in range(0, poses.shape[0], CONDITIONING_BLOCK):
            jac = jacobian_kernel(poses[start : start + CONDITIONING_BLOCK], column_scale)
            if jac is None:
                return None
            out[start : start + CONDITIONING_BLOCK] = kernels.inverse_condition_batch(jac, ones)
        return out

    def _compiled_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray | None:
        """Optional compiled ``jacobian(poses) * column_scale`` (N, dof, dof), same NaN/inf rows.

        ``None`` (the default): the numpy kernels, the reference the compiled
        one is tested against (``tests/test_kernels.py``).
        """
        return None

    def reachable_inverse_condition(self, poses: np.ndarray, length: float | None = None) -> np.ndarray | None:
        """Compiled fused membership test, if this mechanism has one.

        Per pose of ``poses`` (N, dof), in one compiled loop: inverse
        kinematics, actuator range, passive-joint limits and ``1/kappa`` of
        the Jacobian homogenised by ``length`` (as :meth:`inverse_condition`).

        Returns
        -------
        ndarray, shape (N,), or None
            ``1/kappa`` where the pose is reachable within the actuator range
            and the passive-joint limits, NaN elsewhere (the orientation box
            and the dexterity limit are the caller's). None when the mechanism
            has no compiled kernel (:meth:`_compiled_reachable_jacobian`) or the
            numpy reference is selected: :func:`kinematics.workspace.membership`
            then runs the numpy path, which the tests compare this one with.
        """
        if not kernels.compiled():
            return None
        return self._blocked(
            self._compiled_reachable_jacobian, np.ascontiguousarray(poses, dtype=float), self.angular_scale(length)
        )

    def _compiled_reachable_jacobian(self, poses: np.ndarray, column_scale: np.ndarray) -> np.ndarray | None:
        """Optional compiled ``jacobian(poses) * column_scale`` (N, dof, dof) with NaN rows
        where the pose is out of the actuator range or the passive-joint limits.

        ``None`` (the default): no compiled path (see :meth:`reachable_inverse_condition`).
        """
        return None

    def angular_scale(self, length: float | None = None) -> np.ndarray:
        """Column scale ``s`` (shape (dof,)) that homogenises the Jacobian.

        ``s_j = 1/length`` for angular pose variables, 1 for translational ones.
        """
        if length is None:
            length = self.characteristic_length
        length = float(length)
        if not (math.isfinite(length) and length > 0):
            raise ValueError(f"{self.name}: length must be a finite number > 0; got {length}")
        return np.where(np.asarray(self.angular), 1.0 / length, 1.0)

    # ------------------------------------------------------------- properties
    @property
    @abstractmethod
    def characteristic_length(self) -> float:
        """Default length (in :attr:`length_unit`) dividing angular Jacobian columns."""

    @property
    @abstractmethod
    def actuator_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper actuator limits, each shape (dof,), in :attr:`length_unit`."""

    # ------------------------------------------------ workspace description
    #: design variables (name, lower, upper, unit) for :meth:`from_design`
    design_variables: ClassVar[tuple[DesignVariable, ...]] = ()
    #: constructor parameters that are not design variables (the pipeline's ``mechanism.fixed``;
    #: readings of the paper are among them): default, allowed range or choices, unit. Required for
    #: every such parameter; the pipeline refuses a value outside it before any work
    fixed_parameters: ClassVar[tuple[FixedParameter, ...]] = ()
    #: ``{name: default}`` of :attr:`fixed_parameters` (derived from them when a class declares them)
    default_fixed: ClassVar[dict[str, object]] = {}
    #: constructor parameters given in degrees (all other numbers are lengths in
    #: :attr:`length_unit` unless listed in :attr:`unitless_params`)
    angle_params: ClassVar[tuple[str, ...]] = ()
    #: numeric constructor parameters without a unit (flags, signs)
    unitless_params: ClassVar[tuple[str, ...]] = ()
    #: grid nodes per evaluation at the default resolution (speed vs. accuracy;
    #: see :func:`kinematics.workspace.default_resolution`)
    default_nodes: ClassVar[int] = 32**3
    #: the node budget of ``method="grid"`` (None: :attr:`default_nodes`), chosen per mechanism
    #: from the error-cost curve of docs/accuracy.md (its cells near the boundary cost more)
    grid_nodes: ClassVar[int | None] = None
    #: how ``method="grid"`` counts the cells along the workspace's boundary: ``"planes"`` (each
    #: cell cut by one plane through its nearest crossings) or ``"margins"`` (each reachability
    #: and the dexterity margin linear over the cell, the part where all hold:
    #: :mod:`kinematics.margin_cells`; needs :meth:`constraint_margins` and no exact axis; a grid
    #: of more than 3 sampled axes, or none, keeps one plane per cell), chosen per mechanism from
    #: the error-cost measurements of docs/accuracy.md
    cell_rule: ClassVar[str] = "planes"
    #: nodes of ``method="grid"`` along a pose variable, as a multiple of ``resolution``, where
    #: not 1 (rounded up): an axis along which the workspace's margins and ``1/kappa`` vary
    #: slowly needs fewer (H4: theta, docs/accuracy.md)
    grid_axis_nodes: ClassVar[dict[str, float]] = {}
    #: coarsest resolution whose volume and GDI stay within about 3 % of a fine
    #: grid (measured in ``tests/test_workspace.py``); the pipeline refuses coarser
    min_resolution: ClassVar[int] = 8

    @classmethod
    def from_design(cls, design: np.ndarray, **fixed: object) -> Mechanism:
        """Build the mechanism of a design vector (see :attr:`design_variables`).

        The default maps each design variable to the constructor parameter
        of the same name; ``fixed`` supplies the other parameters.
        """
        values = {v.name: float(x) for v, x in zip(cls.design_variables, np.ravel(design))}
        return cls(**cls.with_default_fixed(fixed), **values)

    @classmethod
    def with_default_fixed(cls, params: dict[str, object]) -> dict[str, object]:
        """``params`` with every omitted fixed parameter at its documented default.

        Parameters
        ----------
        params : dict
            Keyword arguments of :meth:`from_design` (fixed parameters) or of the
            constructor; a value given here is kept as given.

        Returns
        -------
        dict
            :attr:`default_fixed` updated with ``params``.
        """
        return {**cls.default_fixed, **params}

    @property
    @abstractmethod
    def default_orientation(self) -> tuple[float, float]:
        """Default range (rad) of every angular pose variable in the workspace."""

    @abstractmethod
    def pose_bounds(self, orientation: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Box (lower, upper), each shape (dof,), that contains the whole workspace.

        Derived from the geometry and the actuator range; angular variables
        take ``orientation`` (rad).
        """

    @abstractmethod
    def reference_volume(self, orientation: tuple[float, float]) -> float:
        """Robot size ``V*`` for the space utility ratio ``V/V*`` (seed 000 Sec. 4.3).

        Same unit as the workspace volume over the full pose space; the
        angular measure is the orientation range's width (or 1 when the
        range is a single value).
        """

    def invariant_axis_interval(self, poses: np.ndarray) -> tuple[int, np.ndarray, np.ndarray] | None:
        """An axis along which the workspace can be integrated exactly, if any.

        Some mechanisms have a translational pose variable along which the
        Jacobian, its conditioning and the joint limits do not change (H4: z,
        because every carriage slides along z). For such a mechanism this
        returns ``(axis, lower, upper)``: the variable's column index and, for
        each pose (N,) (whose value in that column is ignored), the interval
        where every actuator stays within its range (``lower > upper`` when
        none). ``None`` (the default) means no such axis. Whether there is
        one, and which, is a property of the class (the workspace module asks
        once per class); the interval is the design's.
        """
        return None

    def exact_axis_columns(
        self, poses: np.ndarray, axis_lo: float, axis_hi: float, length: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Optional compiled path of the exact-axis integration (see :meth:`invariant_axis_interval`).

        A mechanism with an invariant axis may fuse, per pose (N, dof), the
        feasible interval of that axis clipped to ``[axis_lo, axis_hi]``, its
        passive-joint limits and ``1/kappa`` (homogenised by ``length``) into
        one compiled loop, returning ``(lower, upper, ic)`` each (N,) with
        ``ic`` NaN where the pose is outside for any reason but orientation
        and dexterity. ``None`` (the default) selects the numpy path, which is
        the reference the compiled one is tested against.
        """
        return None

    #: the pose variable along which :meth:`exact_sections` integrates in closed form, if any; a
    #: class that sets it implements :meth:`exact_sections` (``evaluate(method="grid")`` then uses it)
    section_axis: ClassVar[int | None] = None

    def exact_sections(
        self, poses: np.ndarray, origin: float, step: float, min_inverse_condition: float, length: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int] | None:
        """Optional exact 1-D sections of the workspace along :attr:`section_axis`.

        For each row of ``poses`` (N, dof) (its value in the section column ignored):
        the measure of the dexterous section (``1/kappa > min_inverse_condition``; the section's
        reachable intervals in closed form), the measure of the reachable section, the integral
        of ``1/kappa`` over the dexterous one, the extremes of ``1/kappa`` over its samples and
        the number of Jacobians evaluated; ``1/kappa`` is sampled at the intervals' ends and at
        the nodes ``origin + k step``. Used by ``workspace.evaluate(method="grid")`` in place of
        the cut-cell grid (3-RPR: :meth:`kinematics.rpr3.RPR3.exact_sections`, 2-RPR:
        :meth:`kinematics.rpr2.RPR2.exact_sections`). ``None`` (the default, with
        :attr:`section_axis` None): no such sections.
        """
        return None

    def transverse_extent(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Optional exact extent of the reachable workspace (no dexterity limit) along the linear
        pose variable across :meth:`exact_sections` (3-RPR: y), at each orientation ``angles``
        (L,) (rad): ``(lower, upper)``, each (L,) in the length unit, NaN where nothing is
        reachable. ``workspace.evaluate(method="grid")`` then spreads each layer's rows over its
        extent, and its layers over the orientations where the extent is not empty, instead of
        over the pose box (3-RPR: :meth:`kinematics.rpr3.RPR3.transverse_extent`). ``None`` (the
        default): not known; the rows span the pose box."""
        return None

    def exact_volume(self, orientation: tuple[float, float]) -> float | None:
        """Optional closed-form volume of the reachable workspace (no dexterity limit) over the
        whole pose box at ``orientation`` (rad), in :meth:`volume_unit`; ``None`` (the default):
        not known. With :meth:`exact_sections`, ``evaluate(method="grid")`` takes V as this
        volume times the sections' dexterous share (2-RPR: :meth:`kinematics.rpr2.RPR2.exact_area`)."""
        return None

    def volume_unit(self, orientation: tuple[float, float] | None = None, fixed: dict[str, float] | None = None) -> str:
        """Unit of the workspace volume over the pose variables not in ``fixed``.

        E.g. ``"cm³·rad"`` for H4; angular variables count only when the
        orientation range (rad) has non-zero width.
        """
        orientation = self.default_orientation if orientation is None else orientation
        fixed = fixed or {}
        free = [a for n, a in zip(self.pose_names, self.angular) if n not in fixed]
        n_angles = sum(free) if float(orientation[0]) < float(orientation[1]) else 0
        n_lengths = len(free) - sum(free)
        powers = {1: "", 2: "²", 3: "³"}
        unit = f"{self.length_unit}{powers.get(n_lengths, f'^{n_lengths}')}" if n_lengths else ""
        if n_angles:
            unit += ("·" if unit else "") + f"rad{powers.get(n_angles, f'^{n_angles}')}"
        return unit or "1"

    def plot_slice(self, orientation: tuple[float, float]) -> tuple[dict[str, float], tuple[int, int], str]:
        """The 2-D slice of the workspace that figures show.

        Returns ``(fixed, (i, j), label)``: pose variables held fixed (for
        :func:`kinematics.workspace.evaluate`), the two plotted columns, and a
        label of the slice. Default: angular variables at the middle of
        ``orientation`` (rad), the first two pose variables plotted; a
        mechanism whose first two variables are not the natural plane
        overrides it.
        """
        mid = 0.5 * (float(orientation[0]) + float(orientation[1]))
        fixed = {n: mid for n, a in zip(self.pose_names, self.angular) if a}
        label = ", ".join(f"{n} = {np.degrees(v):.1f}°" for n, v in fixed.items())
        return fixed, (0, 1), label

    def within_joint_limits(self, poses: np.ndarray) -> np.ndarray:
        """Passive-joint limits (N,) bool; True for mechanisms without such limits."""
        return np.ones(np.asarray(poses).shape[0], dtype=bool)

    def constraint_margins(self, poses: np.ndarray) -> np.ndarray | None:
        """Signed margins of the reachability constraints of each pose, if the mechanism has them.

        A margin is a smooth function of the pose, ``>= 0`` exactly where its
        constraint holds (actuator range, passive-joint limit, real inverse
        kinematics); the pose is reachable (real IK within the actuator range and
        the joint limits, as :func:`kinematics.workspace.membership` tests it) exactly
        where every margin is ``>= 0``. Each column may carry its own unit (only its
        sign and its linear interpolation between two poses are used): the grid
        method of :func:`kinematics.workspace.evaluate` places a reachability boundary
        on a grid edge where the margins, interpolated linearly between the edge's
        ends, first change sign: a crossing continuous in the design, at no further
        evaluation (docs/accuracy.md).

        Parameters
        ----------
        poses : ndarray, shape (N, dof)

        Returns
        -------
        ndarray, shape (N, K), or None
            NaN where a margin is undefined (e.g. an imaginary IK root); None (the
            default) when the mechanism has no margins: the grid method then locates
            its boundary crossings by bisection of the membership test.
        """
        return None

    def exact_axis_margins(self, poses: np.ndarray, axis_lo: float, axis_hi: float) -> np.ndarray | None:
        """:meth:`constraint_margins` of the columns of the exact axis (see
        :meth:`invariant_axis_interval`): a column is in the workspace's reachable part where
        every margin is ``>= 0``, the first being the length of its feasible interval clipped
        to ``[axis_lo, axis_hi]`` (NaN where it is empty for an imaginary root). None (the
        default): no margins."""
        return None

    def _actuator_margins(self, poses: np.ndarray) -> np.ndarray:
        """``q - q_lo`` and ``q_hi - q`` (N, 2 dof) of :meth:`inverse` and :attr:`actuator_range`
        (unit of the actuators; NaN where the IK has no real root)."""
        q = self.inverse(poses)
        q_lo, q_hi = self.actuator_range
        return np.hstack([q - q_lo, q_hi - q])

    @classmethod
    def param_unit(cls, name: str, value: object) -> str:
        """Unit of constructor parameter ``name`` holding ``value``: "deg" for
        :attr:`angle_params`, "1" for :attr:`unitless_params`, "" for text (a
        reading's name), else :attr:`length_unit`."""
        if isinstance(value, str):
            return ""
        if name in cls.angle_params:
            return "deg"
        if name in cls.unitless_params:
            return "1"
        return cls.length_unit

    def params(self) -> dict[str, object]:
        """Constructor keyword arguments that rebuild this mechanism."""
        return dict(self._params)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self._params.items())
        return f"{type(self).__name__}({args})"

    # ------------------------------------------------- forward-kinematics aids
    def _constraints(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Residuals (K, dof) of the closure equations; zero at a solution for ``q``.

        Default for leg-length actuators: ``|leg_i|^2 - q_i^2`` (length^2).
        """
        return self._inverse(poses) ** 2 - q**2

    def _constraints_jacobian(self, poses: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Derivative (K, dof, dof) of :meth:`_constraints` with respect to the pose."""
        return 2.0 * self._inverse(poses)[..., None] * self._jacobian(poses)

    def _polish(self, starts: np.ndarray, q: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Newton-polish candidate poses (K, dof) on the closure equations for ``q``.

        Keeps the ones whose residuals fall below ``1e-9 * scale`` (per
        equation), wraps the angles to (-pi, pi] and removes duplicates.
        """
        starts = starts[np.isfinite(starts).all(axis=1)]
        sols, res = newton_polish(lambda p: self._constraints(p, q), lambda p: self._constraints_jacobian(p, q), starts)
        sols = sols[np.all(np.abs(res) <= 1e-9 * scale, axis=1)]
        angular = np.asarray(self.angular)
        sols[:, angular] = wrap_angle(sols[:, angular])
        return unique_rows(sols)

    # --------------------------------------------------------------- kernels
    @abstractmethod
    def _inverse(self, poses: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _jacobian(self, poses: np.ndarray) -> np.ndarray: ...

    @abstractmethod
    def _forward(self, q: np.ndarray) -> np.ndarray: ...

    _params: dict[str, object]


@dataclass(frozen=True)
class DesignVariable:
    """One design variable: name, bounds and unit (documentation only)."""

    name: str
    lower: float
    upper: float
    unit: str = ""


@dataclass(frozen=True)
class FixedParameter:
    """One fixed constructor parameter (``mechanism.fixed.<name>``): its default and allowed values.

    A number lies in the closed range ``[lower, upper]`` (in ``unit``); a
    named reading is one of ``choices``; ``optional`` also allows None (the
    feature off). The ranges are those in which the mechanism's kinematics
    are meaningful and numerically safe (no overflow or underflow of the
    workspace integrals), not the constructor's looser checks.
    """

    name: str
    default: object
    lower: float | None = None
    upper: float | None = None
    unit: str = ""
    choices: tuple = ()
    optional: bool = False

    def allowed(self) -> str:
        """The allowed values as words, e.g. ``"a number in [1, 1000] cm"``."""
        text = (
            f"one of {', '.join(map(str, self.choices))}"
            if self.choices
            else f"a number in [{self.lower:g}, {self.upper:g}]{' ' + self.unit if self.unit else ''}"
        )
        return f"null or {text}" if self.optional else text

    def accepts(self, value: object) -> bool:
        """True if ``value`` is allowed (bools are not numbers; NaN and inf never are)."""
        if value is None:
            return self.optional
        if self.choices:
            return any(value == c and type(value) is type(c) for c in self.choices)
        return (
            isinstance(value, (int, float))
            and not isinstance(value, bool)
            and math.isfinite(value)
            and self.lower <= value <= self.upper
        )


def cosine_range(lo: float, hi: float, phase: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Exact min and max of ``cos(angle + phase)`` for ``angle`` in [lo, hi] (rad)."""
    if np.ndim(phase) == 0:
        # one phase: a function of the orientation range alone, asked for once per evaluation
        return _cosine_range_of_scalars(float(lo), float(hi), float(phase))
    return _cosine_range(lo, hi, phase)


@functools.lru_cache(maxsize=256)
def _cosine_range_of_scalars(lo: float, hi: float, phase: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cosine_range` of one phase, memoised; the arrays are read-only (shared)."""
    out = _cosine_range(lo, hi, phase)
    for arr in out:
        arr.flags.writeable = False
    return out


def _cosine_range(lo: float, hi: float, phase: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    phase = np.asarray(phase, dtype=float)
    ends = np.cos(np.stack([lo + phase, hi + phase]))
    cmin, cmax = ends.min(axis=0), ends.max(axis=0)
    # an interior extremum where angle + phase crosses a multiple of pi
    k_max = np.ceil((lo + phase) / (2 * np.pi))
    has_max = 2 * np.pi * k_max <= hi + phase
    k_min = np.ceil((lo + phase - np.pi) / (2 * np.pi))
    has_min = 2 * np.pi * k_min + np.pi <= hi + phase
    return np.where(has_min, -1.0, cmin), np.where(has_max, 1.0, cmax)


def orientation_measure(orientation: tuple[float, float], n_angles: int) -> float:
    """Measure (rad^n) of an orientation box; 1 when the range is one value."""
    width = float(orientation[1]) - float(orientation[0])
    return width**n_angles if width > 0 else 1.0


# ---------------------------------------------------------------- validation
def check_positive(owner: str, name: str, value: float) -> float:
    """Return ``value`` as float, or raise ValueError unless it is finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: parameter '{name}' must be a number > 0; got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{owner}: parameter '{name}' must be a finite number > 0; got {value!r}")
    return v


def check_range(owner: str, lo_name: str, lo: float, hi_name: str, hi: float) -> tuple[float, float]:
    """Return ``(lo, hi)`` as floats, or raise unless ``0 < lo < hi`` and both finite."""
    lo_v = check_positive(owner, lo_name, lo)
    hi_v = check_positive(owner, hi_name, hi)
    if not lo_v < hi_v:
        raise ValueError(
            f"{owner}: parameter '{lo_name}' must be below '{hi_name}' "
            f"(allowed: 0 < {lo_name} < {hi_name}); got {lo_name}={lo_v}, {hi_name}={hi_v}"
        )
    return lo_v, hi_v


def sort_poses(poses: np.ndarray) -> np.ndarray:
    """Sort poses (k, dof) lexicographically by column 0, then 1, ...; deterministic."""
    poses = np.asarray(poses, dtype=float)
    if poses.shape[0] <= 1:
        return poses
    order = np.lexsort(tuple(np.round(poses[:, j], 9) for j in reversed(range(poses.shape[1]))))
    return poses[order]
